#!/usr/bin/env python3
"""Tracker vs the SORT baseline on the synthetic set, scored with TrackEval: `pyvehtrack.eval.synth_track` (figures and options: its docstring, or --help)."""
from _evaltool import run

if __name__ == "__main__":
    run("synth_track")
