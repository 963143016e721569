"""Old import path of pyvehtrack.eval.synth (the synthetic scenes), kept so existing imports work.

`import pyvehtrack.synth` gives the very module object of pyvehtrack.eval.synth (same functions, same
globals, so monkeypatching either name patches both). New code imports pyvehtrack.eval.synth.
"""
import importlib as _importlib
import sys as _sys

_sys.modules[__name__] = _importlib.import_module("pyvehtrack.eval.synth")
