"""Oracle of c/vehicle_model.c: the seven-parameter geometric vehicle model searched by a genetic
algorithm, coarse to fine on a Gaussian pyramid (IVVI paper, sec. 5-6, Fig. 4-6, Table 1).

The paper: a vehicle is seven parameters -- position (x, y), width, height, windshield position, bumper
position and roof angle -- kept geometrically coherent by the detected road (the y coordinate gives the
distance, hence the width); three features score a model: vertical symmetry, shape (a gradient term and
a distance-to-edges term) and the vehicle's shadow; a GA searches the parameters on each level of a
Gaussian pyramid with the population and generations of Table 1 (fewer individuals when tracking, the
population initialised around the prediction).

The fitness is defined on integers (include/vehtrack/vehicle_model.h gives every term), so this oracle
computes it with independent tools -- cv2.pyrDown for the pyramid, cv2.Sobel for the gradients,
scipy's exact city-block distance transform for the distance to the edges -- and NumPy sums; the random
numbers come from the same xorshift32 as the C core, drawn in the same order, so the two searches produce
the same individuals. This module never calls the C core. `cfg` is any object with the fields of
vt_model_cfg (pop and gens as [mode][level] sequences); `search` one with those of vt_model_search
(roi as (left, top, right, bottom), pred and sigma as 7-tuples in gene order).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage

S = 8                     # VT_MODEL_SAMPLES
GENES = ("x", "y", "w", "h", "wind", "bump", "roof")
SEED0 = 0x9E3779B9
Q16 = 65536


def tdiv(a: int, b: int) -> int:
    """C99 integer division (truncates toward zero)."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b > 0) else -q


def clamp(v, lo, hi):
    return lo if v < lo else hi if v > hi else v


class XorShift32:
    """Marsaglia's xorshift32 (13, 17, 5); below(n) = (r * n) >> 32."""

    def __init__(self, seed: int):
        self.s = (seed & 0xFFFFFFFF) or SEED0

    def below(self, n: int) -> int:
        x = self.s
        x ^= (x << 13) & 0xFFFFFFFF
        x ^= x >> 17
        x ^= (x << 5) & 0xFFFFFFFF
        self.s = x
        return (x * n) >> 32

    def pm(self, m: int) -> int:
        return self.below(2 * m + 1) - m


def expected_width(cfg, y: int) -> int:
    """Vehicle width (px) the road allows at bottom row y: (y - horizon) * slope, half up."""
    d = y - cfg.horizon_row
    if d <= 0:
        return 0
    return min((d * cfg.width_per_row + Q16 // 2) >> 16, cfg.max_width)


@dataclass
class Geom:
    ox: int
    oy: int
    ex: int
    ey: int
    ylo: int
    yhi: int

    @property
    def rw(self):
        return self.ex - self.ox + 1


def geometry(frame_shape, search) -> Geom:
    h, w = frame_shape
    l, t, r, b = search.roi
    ox, oy, ex, ey = clamp(l, 0, w - 1), clamp(t, 0, h - 1), clamp(r, 0, w - 1), clamp(b, 0, h - 1)
    if l > r or t > b or r < 0 or b < 0 or l >= w or t >= h or ex - ox + 1 < 8 or ey - oy + 1 < 8:
        raise ValueError(f"roi: {search.roi} leaves less than 8x8 pixels of the {w}x{h} frame")
    return Geom(ox, oy, ex, ey, clamp(search.y_min, oy + 7, ey), clamp(search.y_max, oy + 7, ey))


def repair(cfg, g: Geom, p: list) -> list:
    """Road, aspect, ROI and shape constraints, in the C order (see vt__repair)."""
    x, y, w, h, wind, bump, roof = p
    y = clamp(y, g.ylo, g.yhi)
    we = expected_width(cfg, y)
    wmin = max(8, tdiv(we * (1000 - cfg.width_tol_permille), 1000))
    wmax = max(wmin, tdiv(we * (1000 + cfg.width_tol_permille), 1000))
    w = clamp(w, clamp(wmin, 1, g.rw), clamp(wmax, 1, g.rw))
    hmin = max(4, tdiv(w * cfg.aspect_min_permille, 1000))
    hmax = max(hmin, tdiv(w * cfg.aspect_max_permille, 1000))
    h = clamp(clamp(h, hmin, hmax), 1, y - g.oy + 1)
    half = w // 2
    x = clamp(x, g.ox + half, g.ex - w + 1 + half)
    return [x, y, w, h, clamp(wind, cfg.wind_min, cfg.wind_max), clamp(bump, cfg.bump_min, cfg.bump_max),
            clamp(roof, 0, cfg.roof_max)]


def random_individual(cfg, g: Geom, rng: XorShift32) -> list:
    y = g.ylo + rng.below(g.yhi - g.ylo + 1)
    we = expected_width(cfg, y)
    wmin = clamp(max(8, tdiv(we * (1000 - cfg.width_tol_permille), 1000)), 1, g.rw)
    wmax = clamp(max(wmin, tdiv(we * (1000 + cfg.width_tol_permille), 1000)), wmin, g.rw)
    w = wmin + rng.below(wmax - wmin + 1)
    hmin = max(4, tdiv(w * cfg.aspect_min_permille, 1000))
    hmax = max(hmin, tdiv(w * cfg.aspect_max_permille, 1000))
    h = hmin + rng.below(hmax - hmin + 1)
    x = g.ox + w // 2 + rng.below(max(1, g.rw - w + 1))
    wind = cfg.wind_min + rng.below(cfg.wind_max - cfg.wind_min + 1)
    bump = cfg.bump_min + rng.below(cfg.bump_max - cfg.bump_min + 1)
    roof = rng.below(cfg.roof_max + 1)
    return repair(cfg, g, [x, y, w, h, wind, bump, roof])


@dataclass
class Level:
    """One pyramid level of the ROI: image, |gradients| and distance to the nearest edge."""
    level: int
    ox: int
    oy: int
    img: np.ndarray
    gx: np.ndarray
    gy: np.ndarray
    dist: np.ndarray


def prepare(frame: np.ndarray, cfg, search, level: int) -> Level:
    g = geometry(frame.shape, search)
    img = np.ascontiguousarray(frame[g.oy:g.ey + 1, g.ox:g.ex + 1])
    for _ in range(level):
        img = cv2.pyrDown(img)
    gx = cv2.Sobel(img, cv2.CV_16S, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE).astype(np.int64)
    gy = cv2.Sobel(img, cv2.CV_16S, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE).astype(np.int64)
    edge = (np.abs(gx) + np.abs(gy)) > cfg.edge_thresh
    if edge.any():
        dist = np.minimum(ndimage.distance_transform_cdt(~edge, metric="taxicab"), 255)
    else:
        dist = np.full(img.shape, 255)
    return Level(level, g.ox, g.oy, img.astype(np.int64), gx, gy, dist.astype(np.int64))


def _to_level(v: int, o: int, lv: int, n: int) -> int:
    return clamp((v - o) >> lv, 0, n - 1)     # Python >> floors, as the C helper does


def _lerp(a: int, b: int, k: int) -> int:
    return a + tdiv((b - a) * k, S - 1)


def fitness(cfg, lv: Level, p) -> int:
    """Symmetry + shape (gradient, distance to edges) + shadow, weighted (vehicle_model.h)."""
    x, y, w, h, wind, bump, roof = p
    lh, lw = lv.img.shape
    L = x - w // 2
    R, B, T = L + w - 1, y, y - h + 1
    I = tdiv(w * roof, 100)
    Sr = T + tdiv(h * wind, 100)
    P = B - tdiv(h * bump, 100)
    segs = [(L, Sr, L, B), (R, Sr, R, B), (L + I, T, L, Sr), (R - I, T, R, Sr),      # |gx|
            (L + I, T, R - I, T), (L, Sr, R, Sr), (L, P, R, P), (L, B, R, B)]        # |gy|
    sum_g = sum_d = 0
    for e, (xa, ya, xb, yb) in enumerate(segs):
        grad = lv.gx if e < 4 else lv.gy
        for k in range(S):
            px = _to_level(_lerp(xa, xb, k), lv.ox, lv.level, lw)
            py = _to_level(_lerp(ya, yb, k), lv.oy, lv.level, lh)
            sum_g += abs(int(grad[py, px])) >> 2
            sum_d += cfg.dist_cap - min(int(lv.dist[py, px]), cfg.dist_cap)
    grad_t = sum_g // (8 * S)
    dist_t = sum_d * 255 // (cfg.dist_cap * 8 * S)
    xc = _to_level(x, lv.ox, lv.level, lw)
    half = max(1, (w // 2) >> lv.level)
    sum_s = sum_in = 0
    for k in range(S):
        r = _to_level(_lerp(T, B, k), lv.oy, lv.level, lh)
        for j in range(S):
            d = 1 + (half - 1) * j // (S - 1)
            a, bb = int(lv.img[r, clamp(xc - d, 0, lw - 1)]), int(lv.img[r, clamp(xc + d, 0, lw - 1)])
            sum_s += abs(a - bb)
            sum_in += a + bb
    sym = 255 - sum_s // (S * S)
    b = _to_level(B, lv.oy, lv.level, lh)
    below = above = 0
    for j in range(S):
        cx = _to_level(L + (w - 1) * (j + 1) // (S + 1), lv.ox, lv.level, lw)
        below += int(lv.img[clamp(b + 1, 0, lh - 1), cx]) + int(lv.img[clamp(b + 2, 0, lh - 1), cx])
        above += int(lv.img[b, cx]) + int(lv.img[clamp(b - 1, 0, lh - 1), cx])
    # the shadow is the darkest part: darker than the road below and the vehicle above it
    below, above, inside = below // (2 * S), above // (2 * S), sum_in // (2 * S * S)
    shadow = clamp(min(below - above, inside - above), 0, 255)
    return cfg.w_sym * sym + cfg.w_grad * grad_t + cfg.w_dist * dist_t + cfg.w_shadow * shadow


@dataclass
class FitResult:
    best: list
    fitness: int
    evaluations: int
    population: list      # the last generation, [7 genes] each
    fitnesses: list
    rng_state: int

    @property
    def box(self):
        x, y, w, h = self.best[:4]
        left = x - w // 2
        return (left, y - h + 1, left + w - 1, y)


def fit(frame: np.ndarray, cfg, search) -> FitResult:
    """The GA, coarsest level first (see vt_model_fit for the order of every random draw)."""
    g = geometry(frame.shape, search)
    if search.y_max < g.oy + 7 or search.y_min > g.ey:
        raise ValueError("search: no bottom row leaves room for a model in the ROI")
    mode = int(search.tracking)
    rng = XorShift32(cfg.seed)
    best, evals = None, 0
    pop, fit_ = [], []
    out_fit = 0
    for level in range(cfg.levels - 1, -1, -1):
        P, G = cfg.pop[mode][level], cfg.gens[mode][level]
        jit = 2 << level
        lv = prepare(frame, cfg, search, level)
        prev = pop
        pop, fit_ = [], []
        for i in range(P):
            if best is not None and i < len(prev):
                # a finer level starts from the coarser level's last generation: its best as is,
                # the others jittered; extra individuals start afresh
                p = list(best) if i == 0 else [v + rng.pm(jit if k < 4 else 5) for k, v in enumerate(prev[i])]
            elif mode == 1:                 # tracking: around the prediction, within 3 sigma
                p = list(search.pred)
                if i > 0:
                    p = [v + rng.pm(s) + rng.pm(s) + rng.pm(s) for v, s in zip(p, search.sigma)]
            else:
                p = random_individual(cfg, g, rng)
            p = repair(cfg, g, p)
            pop.append(p)
            fit_.append(fitness(cfg, lv, p))
            evals += 1
        for _ in range(G):
            e = int(np.argmax(fit_))        # first maximum, as the C loop
            npop, nfit = [pop[e]], [fit_[e]]
            for _i in range(1, P):
                def tour():
                    a, b = rng.below(P), rng.below(P)
                    return b if fit_[b] > fit_[a] else a
                a = tour()
                b = tour()
                mask = rng.below(1 << 7)
                child = [pop[a][k] if (mask >> k) & 1 else pop[b][k] for k in range(7)]
                for k in range(7):
                    if rng.below(1000) < cfg.mut_permille:
                        child[k] += rng.pm(jit if k < 4 else 5)
                child = repair(cfg, g, child)
                npop.append(child)
                nfit.append(fitness(cfg, lv, child))
                evals += 1
            pop, fit_ = npop, nfit
        i = int(np.argmax(fit_))
        best, out_fit = pop[i], fit_[i]
    return FitResult(list(best), out_fit, evals, pop, fit_, rng.s)
