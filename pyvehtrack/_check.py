"""Argument checks shared by the friendly Python layer: a wrong type or value becomes a
TypeError / ValueError naming the argument, never a silent coercion (int(1.5) == 1,
True == 1, a NaN turned into a huge integer).

Rules: an integer argument takes int or NumPy integers, and floats only when they hold an
integer value exactly (2.0, not 2.5); bool is refused everywhere a number goes (it is an int
subclass in Python, rarely what was meant); a real-number argument takes int, float or NumPy
reals and refuses NaN and inf unless told otherwise; strings are never parsed.
"""
from __future__ import annotations

import math
import numbers

import numpy as np

INT32_MIN, INT32_MAX = -(1 << 31), (1 << 31) - 1


def integer(value, name: str, lo: int | None = INT32_MIN, hi: int | None = INT32_MAX) -> int:
    """`value` as an int in [lo, hi] (default: the int32 range of the C fields)."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected an integer, got the bool {value!r}")
    if isinstance(value, numbers.Integral):
        v = int(value)
    elif isinstance(value, numbers.Real):
        f = float(value)
        if not math.isfinite(f) or f != math.floor(f):
            raise ValueError(f"{name}: expected an integer, got {value!r}")
        v = int(f)
    else:
        raise TypeError(f"{name}: expected an integer, got {type(value).__name__} {value!r}")
    if lo is not None and v < lo or hi is not None and v > hi:
        rng = f"[{lo if lo is not None else '-inf'}, {hi if hi is not None else 'inf'}]"
        raise ValueError(f"{name}: {v} is outside {rng}")
    return v


def real(value, name: str, *, finite: bool = True) -> float:
    """`value` as a float; NaN and inf refused unless finite=False."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected a number, got the bool {value!r}")
    if not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a number, got {type(value).__name__} {value!r}")
    v = float(value)
    if finite and not math.isfinite(v):
        raise ValueError(f"{name}: expected a finite number, got {value!r}")
    return v


def real_array(values, name: str) -> np.ndarray:
    """A float64 array of finite reals; TypeError for strings, bools, objects, complex."""
    a = np.asarray(values)
    if a.dtype == np.bool_ or not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)):
        raise TypeError(f"{name}: expected real numbers, got an array of {a.dtype}")
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: values must be finite")
    return a


def choice(value, name: str, options) -> str:
    """`value` when it is one of the strings in `options`."""
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name}: expected one of {', '.join(repr(o) for o in options)}, got {value!r}")
    return value


def covariance(m: np.ndarray, name: str, lsb: float) -> None:
    """A covariance must be symmetric and positive semi-definite. Tolerances: entries of the
    transpose may differ by one fixed-point step `lsb` (the rounding of each entry), and the
    smallest eigenvalue may be below zero by n * lsb plus 1e-12 of the largest entry (float64
    rounding of the eigen-solver), so a matrix that is PSD before rounding passes."""
    n = m.shape[0]
    scale = float(np.abs(m).max(initial=0.0))
    if np.abs(m - m.T).max(initial=0.0) > lsb + 1e-12 * scale:
        raise ValueError(f"{name}: a covariance must be symmetric")
    lo = float(np.linalg.eigvalsh((m + m.T) / 2).min()) if n else 0.0
    if lo < -(n * lsb + 1e-12 * scale):
        raise ValueError(f"{name}: a covariance must be positive semi-definite "
                         f"(smallest eigenvalue {lo:g})")


def npz_file(path, name: str) -> None:
    """ValueError unless the file at `path` begins as a zip archive (what every .npz is).
    Without it NumPy's np.load on, say, a text or JPEG file falls through to its pickle
    branch and says "contains pickled (object) data ... allow_pickle", which is not the
    user's problem: they gave the wrong file."""
    with open(path, "rb") as f:
        head = f.read(4)
    if head[:2] != b"PK":
        raise ValueError(f"{name}: {path} is not a .npz file (an .npz is a zip archive; this file begins "
                         f"{head!r})")


def warning_options(ego_speed, warn_ttc) -> None:
    """The warning's options of `track`, `report` and `batch` checked (ValueError naming them):
    ego_speed a number >= 0 m/s or None (unknown), warn_ttc "distance" or "fused"."""
    if ego_speed is not None and (isinstance(ego_speed, bool) or not isinstance(ego_speed, (int, float))
                                  or not math.isfinite(ego_speed) or ego_speed < 0):
        raise ValueError(f"ego_speed must be a number >= 0 m/s or None, got {ego_speed!r}")
    if warn_ttc not in ("distance", "fused"):
        raise ValueError(f"warn_ttc must be 'distance' or 'fused', got {warn_ttc!r}")


def range_options(rear_offset, bottom_height, path_half_width, *, camera: bool, height_m=None,
                  spell=lambda k: k) -> dict:
    """The range stage's command-line corrections (camera.RangeEstimator's rear_offset,
    bottom_height, path_half_width; `track`, `report`) checked once for both: numbers, finite,
    rear_offset in [0, 5] m, path_half_width in [0, 10] m, bottom_height in [0, height_m) m;
    anything but 0 / 0 / 1.5 needs a camera (camera=False). spell(name) is how the caller's
    user writes the argument ("--rear-offset" on the command line). Returns them as floats."""
    vals = {"rear_offset": rear_offset, "bottom_height": bottom_height, "path_half_width": path_half_width}
    for k, v in vals.items():
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
            raise TypeError(f"{spell(k)} must be a number, got {type(v).__name__}")
        if not math.isfinite(v):
            raise ValueError(f"{spell(k)} must be finite, got {v!r}")
    if not camera:
        if (rear_offset, bottom_height, path_half_width) != (0, 0, 1.5):
            raise ValueError(", ".join(spell(k) for k in ("rear_offset", "bottom_height")) +
                             f" and {spell('path_half_width')} need a camera")
        return {k: float(v) for k, v in vals.items()}
    if not 0 <= rear_offset <= 5:
        raise ValueError(f"{spell('rear_offset')} {rear_offset}: must be in [0, 5] m")
    if not 0 <= path_half_width <= 10:
        raise ValueError(f"{spell('path_half_width')} {path_half_width}: must be in [0, 10] m")
    if bottom_height != 0 and not isinstance(height_m, numbers.Real):
        raise ValueError(f"{spell('bottom_height')} needs the camera file's height_m")
    if bottom_height != 0 and not 0 <= bottom_height < height_m:
        raise ValueError(f"{spell('bottom_height')} {bottom_height}: must be in [0, height_m = {height_m}) m")
    return {k: float(v) for k, v in vals.items()}
