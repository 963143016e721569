"""Old import path of pyvehtrack.eval.tracking (the TrackEval wrapper), kept so existing imports work.

`import pyvehtrack.evaluate` gives the very module object of pyvehtrack.eval.tracking (same functions, same
globals, so monkeypatching either name patches both). New code imports pyvehtrack.eval.tracking.
"""
import importlib as _importlib
import sys as _sys

_sys.modules[__name__] = _importlib.import_module("pyvehtrack.eval.tracking")
