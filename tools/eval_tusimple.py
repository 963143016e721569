#!/usr/bin/env python3
"""Score the lane detector on TuSimple frames with TuSimple's own rules.

The evaluation lives in pyvehtrack.eval.tusimple (its docstring gives the figures and options);
this entry script only points it at the data beside the repository.

    PYTHONPATH=. python3 tools/eval_tusimple.py --help
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pyvehtrack.eval import tusimple  # noqa: E402

if __name__ == "__main__":
    sys.exit(tusimple.main(default_data=ROOT.parent / "shared" / "data" / "tusimple-lane-test100"))
