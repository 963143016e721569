#!/usr/bin/env python3
"""Track the lead car through the 78 KITTI frames of ../shared/data/kitti-raw-sfnd-ttc: `pyvehtrack.eval.kitti_track` (figures and options: its docstring, or --help)."""
from _evaltool import run

if __name__ == "__main__":
    run("kitti_track", "kitti-raw-sfnd-ttc")
