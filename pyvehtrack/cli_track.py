"""Old import path of pyvehtrack.cli.track (`pyvehtrack track`), kept so existing imports
work: `import pyvehtrack.cli_track` gives the very module object of pyvehtrack.cli.track."""
import importlib as _importlib
import sys as _sys

_sys.modules[__name__] = _importlib.import_module("pyvehtrack.cli.track")
