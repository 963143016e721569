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
