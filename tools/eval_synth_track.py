#!/usr/bin/env python3
"""Tracker vs the SORT baseline on the synthetic set, scored with TrackEval.

The evaluation lives in pyvehtrack.eval.synth_track (its docstring gives the figures and options);
this entry script only points it at the data beside the repository.

    PYTHONPATH=. python3 tools/eval_synth_track.py --help
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pyvehtrack.eval import synth_track  # noqa: E402

if __name__ == "__main__":
    sys.exit(synth_track.main())
