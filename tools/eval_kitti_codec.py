#!/usr/bin/env python3
"""Where compression (mp4v, JPEG) loses the KITTI lead car, stage by stage, on the 78 frames of ../shared/data/kitti-raw-sfnd-ttc: `pyvehtrack.eval.kitti_codec` (figures and options: its docstring, or --help)."""
from _evaltool import run

if __name__ == "__main__":
    run("kitti_codec", "kitti-raw-sfnd-ttc")
