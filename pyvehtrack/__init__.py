"""pyvehtrack: camera-based vehicle detection and tracking.

A fixed-point C99 core (static memory, no float) called through cffi, with a float
NumPy/OpenCV reference in `pyvehtrack.reference` that serves as its oracle."""
from ._native import VtError, ffi, lib
from . import image
from . import kalman

__all__ = ["VtError", "ffi", "lib", "image", "MAX_WIDTH", "MAX_HEIGHT", "__version__"]

__version__ = f"{lib.VT_VERSION_MAJOR}.{lib.VT_VERSION_MINOR}.{lib.VT_VERSION_PATCH}"
MAX_WIDTH = lib.VT_MAX_WIDTH
MAX_HEIGHT = lib.VT_MAX_HEIGHT
