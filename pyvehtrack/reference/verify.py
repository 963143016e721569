"""Float reference for hypothesis verification (thesis sec. 2.4.2.2), twin of c/verify.c.

For each bottom edge (row, x_start, x_end) from the shadow stage:
 1. ROI: the edge widened on each side by widen_px (thesis: 6 px) plus
    floor(widen_q8 x length / 256) (the shadow between the wheels can be narrower
    than the body; the thesis has 0), clipped to the image; its height is roi_height (Q8, thesis: 1/2) of the edge length, ending at
    the edge's row (at least one row);
 2. vertical edges: |Sobel d/dx| >= vedge_threshold; their horizontal projection
    p[x] = number of vertical-edge pixels in column x of the ROI. Two tolerances for
    compressed video (issue 8; each 0 = the thesis): vedge_reach r takes the
    derivative over a wider baseline, v[x+1+r] - v[x-1-r] of the vertical [1 2 1]
    sums v (r = 0 is Sobel), so a step the codec spread over 2-3 columns keeps its
    height; vedge_hyst_permille sets a weak threshold
    vedge_threshold - floor(vedge_threshold * hyst / 1000) (at least 1), and a weak
    pixel counts when its vertical run of weak pixels in the same column holds a
    strong one (hysteresis, as Canny's, along the vehicle's side);
 3. the left side is the largest p searched from the left over the left half of the
    ROI (first maximum), the right side the largest p searched from the right over
    the right half (first maximum from the right). The halves: columns x0..mid-1 and
    mid..x1 with mid = (x0 + x1 + 1) // 2;
 4. a vehicle needs one horizontal edge (the shadow edge, present by construction)
    and two vertical edges: both sides need p >= side_min_px,
    p * 1000 >= roi_rows * side_min_frac_permille and p >= side_contrast x the mean of p over
    the ROI (p * n * 256 >= sum(p) * side_contrast_q8: a vehicle's side stands out,
    road texture and noise do not; our addition), and the sides must be at least
    min_width_q8 of the edge length apart (right - left + 1);
 5. the top follows from the aspect ratio (thesis: no consistent cue for the top):
    height = round_half_up(width * aspect_q8 / 256), clipped at row 0.

Only integer counts are compared, so C and this oracle agree exactly wherever the
derivatives agree (they are exact integers in both)."""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from ..shared import VerifyConfig  # noqa: F401  (a plain type both engines share)


def vertical_edges(gray: np.ndarray, reach: int = 0) -> np.ndarray:
    """|d/dx| of the image: Sobel (cv2, replicated border) for reach 0, else the
    difference of the vertical [1 2 1] sums reach+1 columns to each side (replicated)."""
    g = np.asarray(gray, np.float32)
    if reach == 0:
        return np.abs(cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE))
    v = cv2.filter2D(g, cv2.CV_32F, np.array([[1], [2], [1]], np.float32),
                     borderType=cv2.BORDER_REPLICATE)
    s = reach + 1
    vp = np.pad(v, ((0, 0), (s, s)), mode="edge")
    return np.abs(vp[:, 2 * s:] - vp[:, :-2 * s])


def weak_threshold(cfg: VerifyConfig) -> int:
    return max(1, cfg.vedge_threshold - cfg.vedge_threshold * cfg.vedge_hyst_permille // 1000)


def column_counts(mag: np.ndarray, strong: float, weak: float) -> np.ndarray:
    """Per column of `mag` (ROI rows x columns): the pixels >= weak in vertical runs
    (4-connected along the column) that hold a pixel >= strong."""
    wk, st = mag >= weak, mag >= strong
    # label each column's runs separately: a 3x3 cross restricted to the vertical axis
    lab, n = ndimage.label(wk, structure=np.array([[0, 1, 0], [0, 1, 0], [0, 1, 0]]))
    anchored = np.zeros(n + 1, bool)
    anchored[np.unique(lab[st])] = True
    anchored[0] = False
    return (anchored[lab]).sum(0).astype(np.int64)


def verify_one(gray: np.ndarray, hyp, cfg: VerifyConfig, sx_abs: np.ndarray | None = None):
    """The box [left, top, right, bottom] for one hypothesis, or None if rejected.
    sx_abs: vertical_edges(gray, cfg.vedge_reach), if the caller has it."""
    h, w = gray.shape
    row, xs, xe = (int(v) for v in hyp)
    length = xe - xs + 1
    wid = cfg.widen_px + ((length * cfg.widen_q8) >> 8)
    x0 = max(0, xs - wid)
    x1 = min(w - 1, xe + wid)
    rows = max(1, (length * cfg.roi_height_q8) >> 8)
    top = max(0, row - rows + 1)
    rows = row - top + 1
    if sx_abs is None:
        sx_abs = vertical_edges(gray, cfg.vedge_reach)
    p = column_counts(sx_abs[top:row + 1, x0:x1 + 1], cfg.vedge_threshold, weak_threshold(cfg))
    n = x1 - x0 + 1
    mid = (n + 1) // 2                   # local index of the first right-half column
    if mid < 1 or n - mid < 1:
        return None
    li = int(np.argmax(p[:mid]))                       # first maximum from the left
    ri = n - 1 - int(np.argmax(p[mid:][::-1]))         # first maximum from the right

    total = int(p.sum())

    def strong(v):
        return (v >= cfg.side_min_px and v * 1000 >= rows * cfg.side_min_frac_permille
                and v * n * 256 >= total * cfg.side_contrast_q8)

    if not (strong(p[li]) and strong(p[ri])):
        return None
    left, right = x0 + li, x0 + ri
    width = right - left + 1
    if width * 256 < length * cfg.min_width_q8:
        return None
    height = max(1, (width * cfg.aspect_q8 + 128) >> 8)
    return [left, max(0, row - height + 1), right, row]


def verify(gray: np.ndarray, hypotheses, cfg: VerifyConfig = VerifyConfig(), *,
           max_out: int = 32) -> np.ndarray:
    """Boxes (N, 4) int [left, top, right, bottom] (inclusive pixel coordinates) for the
    hypotheses that pass, in hypothesis order, at most max_out."""
    gray = np.asarray(gray, np.uint8)
    hyps = np.asarray(hypotheses, np.int64).reshape(-1, 3)
    if hyps.shape[0] == 0:
        return np.zeros((0, 4), np.int64)
    sx_abs = vertical_edges(gray, cfg.vedge_reach)
    out = []
    for hyp in hyps:
        b = verify_one(gray, hyp, cfg, sx_abs)
        if b is not None and len(out) < max_out:
            out.append(b)
    return np.array(out, np.int64).reshape(-1, 4)
