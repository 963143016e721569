#!/usr/bin/env python3
"""Lead-vehicle detection on the 78 KITTI frames of ../shared/data/kitti-raw-sfnd-ttc: `pyvehtrack.eval.kitti_lead` (figures and options: its docstring, or --help)."""
from _evaltool import run

if __name__ == "__main__":
    run("kitti_lead", "kitti-raw-sfnd-ttc")
