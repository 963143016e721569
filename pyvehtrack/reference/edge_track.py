"""Float/NumPy oracle of c/edge_track.c: the GIST paper's tracking measurement
(sec. III.B). A tracked vehicle's continuous edge curves (Canny: gradient,
non-maximum suppression, hysteresis with two thresholds) are matched to the next
frame's curves; the displacement with the smallest (truncated) chamfer distance
is the Kalman filter's measurement.

Written from the definitions, never calling C: OpenCV's float Sobel (exact on
8-bit inputs), gradient angles from arctan2 (45-degree sectors), connected
components from cv2.connectedComponents, and the 3-4 chamfer distance as the
brute-force minimum over curve pixels of 3 max(|dx|,|dy|) + min(|dx|,|dy|)
(`chamfer_brute`) or, for large crops, the two raster passes of Borgefors
(`chamfer_two_pass`, rows vectorised with a running minimum); a test checks that
the two agree. cv2.Canny is not used: its magnitude and thresholds differ from
an integer pipeline, so it can only be compared statistically."""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from . import image as rimg
from ..shared import EdgeCfg  # noqa: F401  (a plain type both engines share)

DT_INF = 65535


def clip_roi(shape, roi):
    """The crop (left, top, right, bottom) of roi inside an image of this shape, or None."""
    h, w = shape
    l, t, r, b = (int(v) for v in roi)
    l, t, r, b = max(l, 0), max(t, 0), min(r, w - 1), min(b, h - 1)
    return None if l > r or t > b else (l, t, r, b)


def sectors(gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
    """0: gradient along x, 1: along the (1, 1) diagonal, 2: along y, 3: along (1, -1).
    45-degree sectors centred on these directions (boundaries at 22.5 and 67.5 deg)."""
    ang = np.degrees(np.arctan2(np.abs(gy), np.abs(gx)))  # 0..90
    diag = np.where(gx * gy > 0, 1, 3)
    return np.where(ang < 22.5, 0, np.where(ang > 67.5, 2, diag))


_STEP = {0: (1, 0), 1: (1, 1), 2: (0, 1), 3: (1, -1)}


def nms(mag: np.ndarray, sec: np.ndarray, low: int, high: int) -> np.ndarray:
    """2 = seed (>= high), 1 = candidate (>= low), 0 = suppressed: a pixel is kept when
    m > m(p - u) and m >= m(p + u), u the step along its sector, 0 outside the crop."""
    h, w = mag.shape
    pad = np.zeros((h + 2, w + 2), mag.dtype)
    pad[1:-1, 1:-1] = mag
    keep = np.zeros(mag.shape, bool)
    for s, (ux, uy) in _STEP.items():
        before = pad[1 - uy:1 - uy + h, 1 - ux:1 - ux + w]
        after = pad[1 + uy:1 + uy + h, 1 + ux:1 + ux + w]
        keep |= (sec == s) & (mag > before) & (mag >= after)
    keep &= mag >= low
    return np.where(keep, np.where(mag >= high, 2, 1), 0).astype(np.uint8)


def hysteresis(lab: np.ndarray) -> np.ndarray:
    """Candidates 8-connected (through candidates) to a seed."""
    n, comp = cv2.connectedComponents((lab > 0).astype(np.uint8), connectivity=8)
    seeded = np.zeros(n, bool)
    seeded[np.unique(comp[lab == 2])] = True
    seeded[0] = False
    return seeded[comp]


def curves(edges: np.ndarray, min_len: int) -> np.ndarray:
    """Edge pixels in 8-connected curves of at least min_len pixels."""
    n, comp, stats, _ = cv2.connectedComponentsWithStats(edges.astype(np.uint8), connectivity=8)
    ok = stats[:, cv2.CC_STAT_AREA] >= min_len
    ok[0] = False
    return ok[comp]


def chamfer_brute(curve: np.ndarray) -> np.ndarray:
    """3-4 chamfer distance of every pixel to the nearest curve pixel, by definition."""
    h, w = curve.shape
    ys, xs = np.nonzero(curve)
    if len(xs) == 0:
        return np.full((h, w), DT_INF, np.int64)
    gy, gx = np.mgrid[0:h, 0:w]
    out = np.full(h * w, DT_INF, np.int64)
    px, py = gx.ravel(), gy.ravel()
    for k in range(0, len(xs), 256):
        dx = np.abs(px[:, None] - xs[None, k:k + 256])
        dy = np.abs(py[:, None] - ys[None, k:k + 256])
        d = 3 * np.maximum(dx, dy) + np.minimum(dx, dy)
        out = np.minimum(out, d.min(axis=1))
    return out.reshape(h, w)


def _row_pass(cur: np.ndarray, prev: np.ndarray | None) -> np.ndarray:
    """One row of the forward pass: neighbours in the previous row (+3 above, +4 on the
    diagonals), then left to right min(d[x], d[x-1] + 3) = 3x + running min(d[k] - 3k)."""
    t = cur.copy()
    if prev is not None:
        t = np.minimum(t, prev + 3)
        t[1:] = np.minimum(t[1:], prev[:-1] + 4)
        t[:-1] = np.minimum(t[:-1], prev[1:] + 4)
    k = 3 * np.arange(len(t))
    return np.minimum.accumulate(t - k) + k


def chamfer_two_pass(curve: np.ndarray) -> np.ndarray:
    """Borgefors's two raster passes (forward, then backward on the flipped image),
    saturating at DT_INF. Equal to chamfer_brute (tests/test_edge_track.py)."""
    d = np.where(curve, 0, DT_INF).astype(np.int64)
    for _ in range(2):
        prev = None
        for y in range(d.shape[0]):
            d[y] = _row_pass(d[y], prev)
            prev = d[y]
        d = d[::-1, ::-1]  # the backward pass is the forward pass of the flipped image
    return np.minimum(d, DT_INF)


@dataclass
class EdgeMap:
    x0: int
    y0: int
    curve: np.ndarray   # bool, the crop's curve pixels
    dt: np.ndarray      # int, 3-4 chamfer distance to them


def edge_map(img: np.ndarray, cfg: EdgeCfg, roi, brute: bool = False) -> EdgeMap | None:
    """Edge curves and their chamfer distance in the crop roi (clipped) of img, filtered
    as an image of its own (border replicated). None when the crop is empty."""
    c = clip_roi(img.shape, roi)
    if c is None:
        return None
    l, t, r, b = c
    crop = np.asarray(img, np.uint8)[t:b + 1, l:r + 1]
    gx = rimg.sobel_x(crop).round().astype(np.int64)
    gy = rimg.sobel_y(crop).round().astype(np.int64)
    mag = np.abs(gx) + np.abs(gy)
    lab = nms(mag, sectors(gx, gy), cfg.low, cfg.high)
    curve = curves(hysteresis(lab), cfg.min_len)
    dt = chamfer_brute(curve) if brute else chamfer_two_pass(curve)
    return EdgeMap(l, t, curve, dt)


@dataclass
class Template:
    xs: np.ndarray   # frame coordinates of the curve points
    ys: np.ndarray
    box: tuple


def template_set(em: EdgeMap, box, max_points: int) -> Template:
    """Curve pixels inside box (clipped to the crop), raster order; more than max_points
    are thinned evenly to pixels floor(i K / max_points)."""
    h, w = em.curve.shape
    l, t = max(box[0] - em.x0, 0), max(box[1] - em.y0, 0)
    r, b = min(box[2] - em.x0, w - 1), min(box[3] - em.y0, h - 1)
    if l > r or t > b:
        return Template(np.zeros(0, np.int64), np.zeros(0, np.int64), tuple(box))
    ys, xs = np.nonzero(em.curve[t:b + 1, l:r + 1])  # row-major = raster order
    k = len(xs)
    if k > max_points:
        pick = (np.arange(max_points) * k) // max_points
        xs, ys = xs[pick], ys[pick]
    return Template(xs + l + em.x0, ys + t + em.y0, tuple(int(v) for v in box))


def scale(v, s_q8: int):
    """v * s_q8 / 256 rounded to the nearest integer, halves up (works on arrays)."""
    return (v * s_q8 + 128) // 256


def scales(cfg: EdgeCfg) -> list[int]:
    """Candidate scales (Q8) in search order: 1, then 1 -+ step, 1 -+ 2 steps, ..."""
    out = [256]
    for k in range(1, cfg.scale_steps + 1):
        out += [256 - k * cfg.scale_step_q8, 256 + k * cfg.scale_step_q8]
    return out


def anchor(box) -> tuple[int, int]:
    """Scaling centre: the box's bottom centre (an approaching vehicle grows about it)."""
    return (box[0] + box[2]) // 2, box[3]


def scale_box(box, s_q8: int, dx: int = 0, dy: int = 0) -> tuple:
    ax, ay = anchor(box)
    l, t, r, b = box
    return (ax + scale(l - ax, s_q8) + dx, ay + scale(t - ay, s_q8) + dy,
            ax + scale(r - ax, s_q8) + dx, b + dy)


def match(em: EdgeMap, cfg: EdgeCfg, tpl: Template, cx: int, cy: int):
    """(dx, dy, scale_q8, score, found): over the scales (in `scales` order) and the
    displacements within +-radius of (cx, cy), the one whose summed distance, each capped
    at trunc (trunc outside the crop), is smallest; the first in (scale, dy, dx) order on
    ties. None for an empty template."""
    n = len(tpl.xs)
    if n == 0:
        return None
    h, w = em.dt.shape
    ax, ay = anchor(tpl.box)
    dys, dxs = np.mgrid[cy - cfg.radius:cy + cfg.radius + 1, cx - cfg.radius:cx + cfg.radius + 1]
    dxs, dys = dxs.ravel()[:, None], dys.ravel()[:, None]   # (dy, dx) in row-major order
    best = None
    for s in scales(cfg):
        xs = np.clip(ax + scale(tpl.xs - ax, s), -32768, 32767)
        ys = np.clip(ay + scale(tpl.ys - ay, s), -32768, 32767)
        x, y = xs[None, :] + dxs - em.x0, ys[None, :] + dys - em.y0      # displacements x points
        inside = (x >= 0) & (y >= 0) & (x < w) & (y < h)
        d = np.minimum(em.dt[np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)], cfg.trunc)
        sums = np.where(inside, d, cfg.trunc).sum(axis=1)
        k = int(np.argmin(sums))                                      # the first smallest
        if best is None or int(sums[k]) < best[3]:
            best = (int(dxs[k, 0]), int(dys[k, 0]), s, int(sums[k]))
    found = n >= cfg.min_points and best[3] * 256 <= cfg.max_mean_q8 * n
    return (*best, found)
