"""Float reference for the tracker's ROI measurement (thesis sec. 3.6.1); the
specification of c/track_search.c.

Within the predicted ROI: count shadow-edge pixels (s * Sobel d/dy >= h_thresh) per
row; searched from the bottom row up to the middle row, the first row reaching
bottom_permille of the largest count there is the bottom edge (1000: the thesis's
largest); count vertical-edge pixels (|Sobel d/dx| >= v_thresh) per column above
it; the left half searched from the left and the right half from the right for the
largest count (LARGEST, the verification step's rule) or (TWO_THRESHOLD, the
thesis's tracking rule) for the first column reaching half of that half's largest
count, or, when that moves the side more than the largest move accepted so far,
the largest count."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import image as rimg
from ..shared import DARK_ABOVE, DARK_BELOW, LARGEST, TWO_THRESHOLD, SearchCfg  # noqa: F401  (shared plain types)




@dataclass
class Sides:
    have_prev: bool = False
    prev_left: int = 0
    prev_right: int = 0
    max_change_left: int = 0
    max_change_right: int = 0


def _scan(v: np.ndarray, idx, frac: float, vmax: float):
    for i in idx:
        if v[i] >= vmax * frac:
            return i
    return None


def track_search(img: np.ndarray, cfg: SearchCfg, roi, sides: Sides | None = None,
                 grads=None):
    """Returns the inclusive box (left, top, right, bottom) or None. `sides` is updated in place.
    `grads` = (sobel_x, sobel_y) of the whole image may be passed to reuse them."""
    h, w = img.shape
    # half-open [l, r) x [t, b) inside the image, from the inclusive ROI
    l, t = int(np.clip(roi[0], 0, w)), int(np.clip(roi[1], 0, h))
    r = l if roi[2] < roi[0] else int(np.clip(roi[2], -1, w - 1)) + 1
    b = t if roi[3] < roi[1] else int(np.clip(roi[3], -1, h - 1)) + 1
    if r - l < 4 or b - t < 2:
        return None
    gx, gy = grads if grads is not None else (rimg.sobel_x(img), rimg.sobel_y(img))
    sign = 1 if cfg.polarity == DARK_ABOVE else -1
    hproj = (sign * gy[t:b, l:r] >= cfg.h_thresh).sum(axis=1)
    mid = t + (b - t) // 2
    best = int(hproj[mid - t:].max(initial=0))
    if best == 0 or best * 1000 < cfg.min_h_permille * (r - l):
        return None
    ybest = next(y for y in range(b - 1, mid - 1, -1) if hproj[y - t] * 1000 >= best * cfg.bottom_permille)
    rows = ybest - t + 1
    vproj = np.zeros(w)
    vproj[l:r] = (np.abs(gx[t:ybest + 1, l:r]) >= cfg.v_thresh).sum(axis=0)
    midx = l + (r - l) // 2
    lmax, rmax = vproj[l:midx].max(initial=0), vproj[midx:r].max(initial=0)
    if lmax == 0 or rmax == 0 or lmax * 1000 < cfg.min_v_permille * rows or rmax * 1000 < cfg.min_v_permille * rows:
        return None
    left_idx, right_idx = range(l, midx), range(r - 1, midx - 1, -1)
    first = 1.0 if cfg.side_mode == LARGEST else 0.5
    xl = _scan(vproj, left_idx, first, lmax)
    xr = _scan(vproj, right_idx, first, rmax)
    if cfg.side_mode == TWO_THRESHOLD and sides is not None and sides.have_prev:
        dl, dr = abs(xl - sides.prev_left), abs(xr - sides.prev_right)
        if dl > sides.max_change_left:
            xl = _scan(vproj, left_idx, 1.0, lmax)
            dl = abs(xl - sides.prev_left)
        if dr > sides.max_change_right:
            xr = _scan(vproj, right_idx, 1.0, rmax)
            dr = abs(xr - sides.prev_right)
        sides.max_change_left = max(sides.max_change_left, dl)
        sides.max_change_right = max(sides.max_change_right, dr)
    if sides is not None:
        sides.have_prev, sides.prev_left, sides.prev_right = True, xl, xr
    return (xl, t, xr, ybest)
