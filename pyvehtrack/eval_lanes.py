"""Old import path of pyvehtrack.eval.lanes (TuSimple lane scoring), kept so existing imports work.

`import pyvehtrack.eval_lanes` gives the very module object of pyvehtrack.eval.lanes (same functions, same
globals, so monkeypatching either name patches both). New code imports pyvehtrack.eval.lanes.
"""
import importlib as _importlib
import sys as _sys

_sys.modules[__name__] = _importlib.import_module("pyvehtrack.eval.lanes")
