"""pyvehtrack: camera-based vehicle detection and tracking.

A fixed-point C99 core (static memory, no float) called through cffi, with a float
NumPy/OpenCV/filterpy reference in `pyvehtrack.reference` that serves as its oracle.

    from pyvehtrack import Detector, Tracker
    trk = Tracker(detector=Detector())        # engine="c" (default) or "reference"
    for frame in frames:
        for t in trk.step(frame):
            print(t.id, t.state, t.box, t.velocity)
"""
from ._native import VtError, ffi, lib
from . import image
from . import kalman

__all__ = ["VtError", "ffi", "lib", "image", "kalman", "Detector", "LaneDetector", "Tracker",
           "KalmanFilter", "Pipeline", "FrameResult", "MAX_WIDTH", "MAX_HEIGHT", "__version__"]

__version__ = f"{lib.VT_VERSION_MAJOR}.{lib.VT_VERSION_MINOR}.{lib.VT_VERSION_PATCH}"
MAX_WIDTH = lib.VT_MAX_WIDTH
MAX_HEIGHT = lib.VT_MAX_HEIGHT

# The friendly classes load on first use, so `import pyvehtrack` stays light.
_LAZY = {"Detector": "detector", "LaneDetector": "lane", "Tracker": "tracker", "KalmanFilter": "kalman",
         "Pipeline": "pipeline", "FrameResult": "pipeline"}


def __getattr__(name):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'pyvehtrack' has no attribute {name!r}")
