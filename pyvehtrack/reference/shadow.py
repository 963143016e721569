"""Float reference for the shadow hypothesis stage (thesis sec. 2.4.2.1), twin of c/shadow.c.

The thesis looks for the shadow underneath a vehicle by scanning the road area
bottom-up for "vertical transitions from brighter gray values to darker ones":
going UP from the lit road into the dark shadow. In image coordinates (y grows
downward) that edge is the bottom border of the dark region -- dark above, bright
road below -- i.e. the line where the vehicle's shadow meets the road, the bottom of
the vehicle. The Sobel d/dy used here is positive where the image gets brighter
going down, so a shadow edge pixel is one where sobel_y >= threshold (the thesis's
"negative vertical gradient" is the same thing seen in its upward scan direction).

Steps (each mirrored exactly in C):
 1. edge pixels in the road area, s = +1 for DARK_ABOVE (the thesis's edge, the
    default) and -1 for DARK_BELOW (the vehicle body above its shadow, for shadows a
    low sun casts toward the camera): fixed mode (the thesis):
    s*sobel_y >= grad_threshold; adaptive mode (our addition for the weakness the
    thesis names): s*sobel_y >= adapt_grad_min and the pixel on the dark side (the
    row above for DARK_ABOVE, below for DARK_BELOW) is darker than
    median - k*MAD of the road area's own intensities, sampled every `stat_step`-th
    row and column (robust statistics: a road half covered by vehicles and their
    shadows still gives the road's gray);
 2. per row, runs of edge pixels (gaps of <= max_gap non-edge pixels bridged);
    runs shorter than min_run px are dropped (thesis: 10-15 px);
 3. rows scanned bottom-up; a run joins the first (oldest) open group that overlaps
    it in x and whose last (topmost) row is at most merge_rows rows below the run
    (thesis: edges within 2 px are combined);
    a group closes when the scan has moved more than merge_rows above its last row;
 4. a closed group's width (union of its runs) is compared with the expected vehicle
    width at its bottom row: width_min..width_max (Q8 fractions) of the ego lane
    width there; too wide or too narrow -> rejected;
 5. the survivors, bottom-most first, are reduced to one bottom edge per vehicle: an
    edge is dropped if a kept edge below it overlaps it in x by >= reduce_overlap of
    the narrower one and lies no more than reduce_height x (kept width) rows below
    (`suppresses`). With reduce_verified = 1 this step is left to the caller that
    verifies (reference.detect: only an edge that passes verification suppresses),
    and every survivor of step 4 is returned, bottom-most first.

Every comparison is between integers or exactly representable values (Sobel of
8-bit pixels is exact in float32; median and MAD are sample values; k is k_q8/256),
so this oracle and the C code agree exactly.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

# The config, road type and road helpers are plain types both engines share.
from ..shared import (ADAPTIVE, DARK_ABOVE, DARK_BELOW, FIXED, RoadArea, ShadowConfig,  # noqa: F401
                      road_polygon, trapezoid_road)

@dataclass
class ShadowResult:
    hypotheses: np.ndarray                 # (N, 3) int: row, x_start, x_end
    median: int = 0                        # adaptive statistics (0 in fixed mode)
    mad: int = 0
    dark_threshold: float = float("nan")   # adaptive: dark if I < this
    n_samples: int = 0
    n_runs: int = 0                        # runs >= min_run found
    n_dropped: int = 0                     # runs/groups/hypotheses lost to capacities
    edge_rows: list = field(default_factory=list)  # (row, x_start, x_end) of every kept run


def road_spans(road, h: int, w: int):
    """Row range and per-row clamped spans as C does: rows clamped to the image, columns
    clamped to [0, w-1]; rows whose span is empty are skipped. None if no road."""
    if road is None or not road.valid:
        return None
    for name in ("x_left", "x_right", "lane_width"):
        if len(getattr(road, name)) < h:
            raise ValueError(f"road area: {name} has {len(getattr(road, name))} entries for {h} rows")
    yt = max(int(road.y_top), 0)
    yb = min(int(road.y_bottom), h - 1)
    if yt > yb:
        return None
    xl = np.clip(np.asarray(road.x_left, np.int64)[:h], 0, w - 1)
    xr = np.clip(np.asarray(road.x_right, np.int64)[:h], 0, w - 1)
    return yt, yb, xl, xr


def road_stats(gray: np.ndarray, road, step: int):
    """Lower median and lower-median absolute deviation (MAD) of the road pixels
    sampled every `step`-th row from y_top and every `step`-th column from each row's
    x_left, and the number of samples; None if there is none. The lower median of n
    values is the ((n-1)//2)-th smallest."""
    h, w = gray.shape
    sp = road_spans(road, h, w)
    if sp is None:
        return None
    yt, yb, xl, xr = sp
    vals = []
    for y in range(yt, yb + 1, step):
        if xl[y] <= xr[y]:
            vals.append(gray[y, xl[y]:xr[y] + 1:step])
    if not vals:
        return None
    v = np.sort(np.concatenate(vals).astype(np.int64))
    k = (v.size - 1) // 2
    med = int(v[k])
    mad = int(np.sort(np.abs(v - med))[k])
    return med, mad, int(v.size)


def runs_in_row(xs: np.ndarray, max_gap: int, min_run: int):
    """Runs of sorted edge columns, bridging gaps of <= max_gap missing pixels."""
    if xs.size == 0:
        return []
    cuts = np.nonzero(np.diff(xs) > max_gap + 1)[0]
    starts = np.concatenate(([0], cuts + 1))
    ends = np.concatenate((cuts, [xs.size - 1]))
    out = []
    for s, e in zip(starts, ends):
        a, b = int(xs[s]), int(xs[e])
        if b - a + 1 >= min_run:
            out.append((a, b))
    return out


def suppresses(cfg: ShadowConfig, k, c) -> bool:
    """The one-edge-per-vehicle rule: does kept edge k = (row, x_start, x_end) suppress
    edge c above it? They overlap in x by >= reduce_overlap of the narrower one and k
    lies no more than reduce_height x (k's width) rows below c."""
    wc, wk = c[2] - c[1] + 1, k[2] - k[1] + 1
    ov = min(c[2], k[2]) - max(c[1], k[1]) + 1
    return bool(ov > 0 and ov * 1000 >= min(wc, wk) * cfg.reduce_overlap_permille
                and (k[0] - c[0]) * 256 <= wk * cfg.reduce_height_q8)


def find_hypotheses(gray: np.ndarray, road, cfg: ShadowConfig = ShadowConfig(), *,
                    max_active: int = 64, max_cand: int = 64,
                    max_out: int = 32) -> ShadowResult:
    """Bottom edges of vehicle hypotheses in `road` (see the module docstring).

    Capacities mirror VT_MAX_SHADOW_ACTIVE, VT_MAX_SHADOW_CAND and the caller's output
    capacity in C: a run that finds no free open group, a closed group that finds no
    candidate slot, and hypotheses past max_out are dropped and counted."""
    gray = np.asarray(gray, np.uint8)
    h, w = gray.shape
    res = ShadowResult(hypotheses=np.zeros((0, 3), np.int64))
    sp = road_spans(road, h, w)
    if sp is None:
        return res
    yt, yb, xl, xr = sp
    sy = cv2.Sobel(gray.astype(np.float32), cv2.CV_32F, 0, 1, ksize=3,
                   borderType=cv2.BORDER_REPLICATE)
    if cfg.polarity == DARK_BELOW:
        sy = -sy
    if cfg.threshold_mode == ADAPTIVE:
        st = road_stats(gray, road, cfg.stat_step)
        if st is None:
            return res
        res.median, res.mad, res.n_samples = st
        res.dark_threshold = res.median - (cfg.adapt_k_q8 / 256.0) * res.mad
        if cfg.polarity == DARK_ABOVE:      # the dark side: row y-1 (replicated at the top)
            side = np.vstack([gray[:1], gray[:-1]])
        else:                               # row y+1 (replicated at the bottom)
            side = np.vstack([gray[1:], gray[-1:]])
        edge = (sy >= cfg.adapt_grad_min) & (side.astype(np.float64) < res.dark_threshold)
    else:
        edge = sy >= cfg.grad_threshold

    lane_w = np.asarray(road.lane_width, np.int64)
    active: list[list[int]] = []   # [bottom, last, xs, xe, id]
    cand: list[list[int]] = []
    next_id = 0

    def close(g):
        width = g[3] - g[2] + 1
        lw = int(lane_w[g[0]])
        if lw <= 0 or width * 256 < lw * cfg.width_min_q8 or width * 256 > lw * cfg.width_max_q8:
            return
        if len(cand) >= max_cand:
            res.n_dropped += 1
            return
        cand.append(g)

    for y in range(yb, yt - 1, -1):
        still = []
        for g in active:
            if g[1] - y > cfg.merge_rows:
                close(g)
            else:
                still.append(g)
        active = still
        if xl[y] > xr[y]:
            continue
        xs = np.nonzero(edge[y, xl[y]:xr[y] + 1])[0] + xl[y]
        for a, b in runs_in_row(xs, cfg.max_gap, cfg.min_run):
            res.n_runs += 1
            res.edge_rows.append((y, a, b))
            for g in active:
                if g[2] <= b and a <= g[3]:
                    g[1] = y
                    g[2] = min(g[2], a)
                    g[3] = max(g[3], b)
                    break
            else:
                if len(active) >= max_active:
                    res.n_dropped += 1
                else:
                    active.append([y, y, a, b, next_id])
                    next_id += 1
    for g in active:
        close(g)

    cand.sort(key=lambda g: (-g[0], g[2], g[4]))
    kept: list[list[int]] = []
    for c in cand:
        if cfg.reduce_verified or not any(suppresses(cfg, (k[0], k[2], k[3]), (c[0], c[2], c[3]))
                                          for k in kept):
            kept.append(c)
    if len(kept) > max_out:
        res.n_dropped += len(kept) - max_out
        kept = kept[:max_out]
    res.hypotheses = np.array([[k[0], k[2], k[3]] for k in kept], np.int64).reshape(-1, 3)
    return res
