#!/usr/bin/env python3
"""Track the lead car through the 78 KITTI frames of ../shared/data/kitti-raw-sfnd-ttc.

The evaluation lives in pyvehtrack.eval.kitti_track (its docstring gives the figures and options);
this entry script only points it at the data beside the repository.

    PYTHONPATH=. python3 tools/eval_kitti_track.py --help
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pyvehtrack.eval import kitti_track  # noqa: E402

if __name__ == "__main__":
    sys.exit(kitti_track.main(default_data=ROOT.parent / "shared" / "data" / "kitti-raw-sfnd-ttc"))
