"""Friendly wrappers over the C pixel primitives (see include/vehtrack/image.h).

Each takes a 2-D uint8 NumPy image (any row stride), allocates the output and
returns it. Errors from the core arrive as `pyvehtrack.VtError`."""
from __future__ import annotations

import numpy as np

from . import _check, _native

Q14_ONE = 1 << 14


def _new(shape, dtype) -> np.ndarray:
    return np.empty(shape, dtype=dtype)


def _shape(img) -> tuple[int, int]:
    if not isinstance(img, np.ndarray):
        raise TypeError(f"expected a numpy.ndarray, got {type(img).__name__}")
    if img.ndim != 2:
        raise ValueError(f"expected a 2-D gray image, got shape {img.shape}")
    return img.shape


def filter_h101(img: np.ndarray) -> np.ndarray:
    """[-1 0 1] horizontal derivative, int16, edge replicated."""
    out = _new(_shape(img), np.int16)
    _native.filter_h101(img, out)
    return out


def sobel_x(img: np.ndarray) -> np.ndarray:
    """3x3 Sobel d/dx, int16, edge replicated."""
    out = _new(_shape(img), np.int16)
    _native.sobel_x(img, out)
    return out


def sobel_y(img: np.ndarray) -> np.ndarray:
    """3x3 Sobel d/dy (positive where brighter below), int16, edge replicated."""
    out = _new(_shape(img), np.int16)
    _native.sobel_y(img, out)
    return out


def pyr_down(img: np.ndarray) -> np.ndarray:
    """One 5x5 Gaussian pyramid step to ((h+1)//2, (w+1)//2), as cv2.pyrDown."""
    h, w = _shape(img)
    out = _new(((h + 1) // 2, (w + 1) // 2), np.uint8)
    _native.pyr_down(img, out)
    return out


def resize_area(img: np.ndarray, size) -> np.ndarray:
    """Area downscale to size = (w, h), 1 <= w <= width, 1 <= h <= height: OpenCV's
    INTER_AREA rule in exact integers (vt_resize_area; at most 1 level from cv2.resize's
    float rounding). For firmware the same bytes as here."""
    h, w = _shape(img)
    if not isinstance(size, (tuple, list)) or len(size) != 2:
        raise TypeError(f"size: expected (w, h), got {size!r}")
    ow, oh = (_check.integer(v, "size") for v in size)
    if not (1 <= ow <= w and 1 <= oh <= h):
        raise ValueError(f"size: {tuple(size)} is not a downscale of the {w}x{h} image "
                         f"(1 <= w <= {w}, 1 <= h <= {h})")
    out = _new((oh, ow), np.uint8)
    _native.resize_area(img, out)
    return out


def pyr_down_rect(img: np.ndarray, rect, out: np.ndarray | None = None) -> np.ndarray:
    """The pixels [x0, x1) x [y0, y1) of pyr_down(img), rect = (x0, y0, x1, y1) in level
    pixels, written into `out` (a ((h+1)//2, (w+1)//2) uint8 array, zeros if None; its
    other pixels are left as they are), which is returned."""
    h, w = _shape(img)
    if not isinstance(rect, (tuple, list)) or len(rect) != 4:
        raise TypeError(f"rect: expected (x0, y0, x1, y1), got {rect!r}")
    x0, y0, x1, y1 = (_check.integer(v, "rect") for v in rect)
    oh, ow = (h + 1) // 2, (w + 1) // 2
    if not (0 <= x0 <= x1 <= ow and 0 <= y0 <= y1 <= oh):
        raise ValueError(f"rect: {tuple(rect)} is not inside the {ow}x{oh} level image "
                         f"(0 <= x0 <= x1 <= {ow}, 0 <= y0 <= y1 <= {oh})")
    if out is None:
        out = np.zeros((oh, ow), np.uint8)
    _native.pyr_down_rect(img, out, x0, y0, x1, y1)
    return out


def integral(img: np.ndarray) -> np.ndarray:
    """(h+1, w+1) uint32 integral image with a zero first row and column."""
    h, w = _shape(img)
    out = _new((h + 1, w + 1), np.uint32)
    _native.integral(img, out)
    return out


def box_sum(ii: np.ndarray, x: int, y: int, w: int, h: int) -> int:
    """Sum of the source pixels in [x, x+w) x [y, y+h) from an integral image."""
    x, y, w, h = (_check.integer(v, n) for v, n in ((x, "x"), (y, "y"), (w, "w"), (h, "h")))
    return _native.box_sum(ii, x, y, w, h)


def ncc(a: np.ndarray, b: np.ndarray) -> float:
    """Normalised cross-correlation in [-1, 1] (the core's Q1.14 value / 16384).

    Returns NaN when a patch is flat, where the coefficient is undefined."""
    try:
        return _native.ncc_u8(a, b) / Q14_ONE
    except _native.VtError as e:
        if e.status == _native.lib.VT_E_SINGULAR:
            return float("nan")
        raise


def sad(a: np.ndarray, b: np.ndarray) -> int:
    """Sum of absolute differences of two equal-size uint8 blocks."""
    return _native.sad_u8(a, b)
