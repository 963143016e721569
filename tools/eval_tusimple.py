#!/usr/bin/env python3
"""Score the lane detector on TuSimple frames with TuSimple's own rules: `pyvehtrack.eval.tusimple` (figures and options: its docstring, or --help)."""
from _evaltool import run

if __name__ == "__main__":
    run("tusimple", "tusimple-lane-test100")
