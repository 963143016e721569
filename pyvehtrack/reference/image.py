"""Float reference for the pixel primitives of include/vehtrack/image.h.

Thesis sec. 2.4.1.2 ([-1 0 1] lane filter), sec. 2.4.2 (Sobel), sec. 3.3 (normalised
correlation); IVVI paper (Gaussian pyramid, SAD block matching). Everything is
computed in float64 (or OpenCV float32 where exact for 8-bit inputs) and only
rounded where the C contract says the result is an integer."""
from __future__ import annotations

import math

import cv2
import numpy as np


def _f(img: np.ndarray) -> np.ndarray:
    return np.asarray(img, dtype=np.float64)


def filter_h101(img: np.ndarray) -> np.ndarray:
    """out(x) = img(x+1) - img(x-1), edge replicated."""
    k = np.array([[-1.0, 0.0, 1.0]], dtype=np.float32)
    return cv2.filter2D(np.asarray(img, np.float32), cv2.CV_32F, k,
                        borderType=cv2.BORDER_REPLICATE).astype(np.float64)


def sobel_x(img: np.ndarray) -> np.ndarray:
    return cv2.Sobel(np.asarray(img, np.float32), cv2.CV_32F, 1, 0, ksize=3,
                     borderType=cv2.BORDER_REPLICATE).astype(np.float64)


def sobel_y(img: np.ndarray) -> np.ndarray:
    return cv2.Sobel(np.asarray(img, np.float32), cv2.CV_32F, 0, 1, ksize=3,
                     borderType=cv2.BORDER_REPLICATE).astype(np.float64)


_G5 = np.array([1.0, 4.0, 6.0, 4.0, 1.0]) / 16.0


def pyr_down_float(img: np.ndarray) -> np.ndarray:
    """5x5 Gaussian blur (reflect-101 border), every second row and column, in float."""
    a = _f(img)
    h, w = a.shape
    # np.pad's "reflect" is OpenCV's REFLECT_101 and repeats for tiny images; a
    # single row or column reflects onto itself.
    for axis, n in ((0, h), (1, w)):
        pad = [(0, 0), (0, 0)]
        pad[axis] = (2, 2)
        a = np.pad(a, pad, mode="reflect" if n > 1 else "edge")
    p = a
    v = sum(_G5[i] * p[i:i + h, :] for i in range(5))
    out = sum(_G5[i] * v[:, i:i + w] for i in range(5))
    return out[::2, ::2]


def pyr_down(img: np.ndarray) -> np.ndarray:
    """pyr_down_float rounded half up to uint8, the C contract."""
    return np.floor(pyr_down_float(img) + 0.5).astype(np.uint8)


def area_weights(n_in: int, n_out: int) -> np.ndarray:
    """(n_out, n_in) integer overlaps of output pixel x = [x n_in, (x+1) n_in) with input
    pixel i = [i n_out, (i+1) n_out) on a common axis; each row sums to n_in."""
    x = np.arange(n_out, dtype=np.int64)[:, None]
    i = np.arange(n_in, dtype=np.int64)[None, :]
    lo = np.maximum(x * n_in, i * n_out)
    hi = np.minimum((x + 1) * n_in, (i + 1) * n_out)
    return np.maximum(hi - lo, 0)


def resize_area(img: np.ndarray, size) -> np.ndarray:
    """vt_resize_area: the overlap-weighted mean, (sum + W H // 2) // (W H), in exact
    integers (the area rule of cv2.INTER_AREA, which rounds in float)."""
    a = np.asarray(img, np.int64)
    H, W = a.shape
    w, h = size
    s = area_weights(H, h) @ a @ area_weights(W, w).T
    return ((s + (W * H) // 2) // (W * H)).astype(np.uint8)


def integral(img: np.ndarray) -> np.ndarray:
    a = _f(img)
    out = np.zeros((a.shape[0] + 1, a.shape[1] + 1))
    out[1:, 1:] = a.cumsum(0).cumsum(1)
    return out


def box_sum(img: np.ndarray, x: int, y: int, w: int, h: int) -> float:
    return float(_f(img)[y:y + h, x:x + w].sum())


def ncc(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two equal-size patches; NaN if either is flat."""
    fa, fb = _f(a).ravel(), _f(b).ravel()
    da, db = fa - fa.mean(), fb - fb.mean()
    den = math.sqrt(float(da @ da) * float(db @ db))
    if den == 0.0:
        return float("nan")
    return float(da @ db) / den


def sad(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(_f(a) - _f(b)).sum())


def sincos(angle_deg: float) -> tuple[float, float]:
    r = math.radians(angle_deg)
    return math.sin(r), math.cos(r)
