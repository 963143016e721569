"""Old import path of pyvehtrack.eval.sort (the SORT baseline), kept so existing imports work.

`import pyvehtrack.reference.sort` gives the very module object of pyvehtrack.eval.sort (same functions, same
globals, so monkeypatching either name patches both). New code imports pyvehtrack.eval.sort.
"""
import importlib as _importlib
import sys as _sys

_sys.modules[__name__] = _importlib.import_module("pyvehtrack.eval.sort")
