"""Float reference for the lane stage (c/lane.c): thesis sec. 2.4.1, road area finding.

The thesis (sec. 2.4.1.1-2.4.1.2): split the frame into a left and a right half, filter
each with [-1 0 1], run a Hough transform (rho = x cos(theta) + y sin(theta), theta in
[-90, 90] degrees), reduce the many lines found on one marking to one, keep per half two
lines with a clear angle difference (left-most + left, right + right-most) and drop
lines whose angle cannot be a lane. Fig. 2.8: group the lines into one road area.
Sec. 2.4.1.2, last paragraph: track the lane lines over frames for frames where a
marking is hidden.

What is added here, each because the TuSimple benchmark (every labelled row scores, up
to where the lane fades toward the vanishing point) needs it; the first comment of
c/lane.c gives the measured effect:
  1. Working frame: the frame is box-averaged by 2^s (s = 0..3, the smallest with
     width <= work_width_max and height <= work_height_max).
  2. Marking centres: in each row below roi_top, a rising [-1 0 1] edge (>= thr) is
     paired with the next falling one (<= -thr) when the gap is a plausible marking
     width at that row, so both gradient signs pair up around a bright marking; the
     centre votes once. thr = max(grad_min, noise_gain * mean |g| of the row), so
     rough concrete raises its own threshold. A row with more centres than
     marks_per_row_max is texture and is dropped.
  3. Hough per half, from the near-field band (rows >= hough_top) only, where lanes
     are straight. Peaks: maxima of a window (first in scan order among equals).
  4. Refinement of each peak line: a least-squares line through the marking centre
     nearest to it in each band row (twice, the window halved); lines flatter than
     ego_theta_max keep their Hough line. Refined lines closer than merge px at both
     ends of the band are one marking (the stronger is kept).
  5. Selection: the left/right pair with the most votes whose crossing is a plausible
     vanishing point and whose bottom width is a plausible lane is the ego pair; lines
     through that point are lane lines. Per half the ego line is the strongest steep
     line, replaced by a line further in that is steeper by min_dtheta (a solid outer
     line often outvotes a dashed ego line); the outer line is the strongest line
     further out and flatter by min_dtheta. Without a pair at a plausible vanishing
     point nothing confirms a line's geometry (night, faded markings): a line then
     needs solo_vote_permille / 1000 times the vote floor (issue 8: report the visible
     markings or none). Every other line through the vanishing point further out than
     an ego line is a "further" line (lines_all: every lane line, left to right).
  6. Extension toward the vanishing row: segments whose height halves with the
     distance to the vanishing row, each pivoting on the previous vertex with the
     slope that covers the most marking centres, so a curve far away is followed. With
     a known vanishing point the lane runs to top_margin below it (where TuSimple's
     labels end); without, it stops where the marking stops.
  7. Tracker: per slot the refined line is smoothed with the previous frame's (when
     close) and held for up to track_hold frames when the marking is hidden.

Integer parts (working frame, marking centres, vote counting, peak rules) are exact
here, as in C. The Hough rho uses float sin/cos here and the Q1.14 table in C, so a
vote can land one rho bin away at a bin boundary: lines agree within one accumulator
bin. Geometry after the peaks is float here and Q16 in C: refined lines and vertices
agree within a fraction of a pixel, barring a borderline decision.

Coordinates are working-frame pixels (input >> s); Hough origin (cx, H-1) with
cx = W // 2. A line is x(y) = xb + slope * (y - (H-1)).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..shared import QDEG, SIDE_NAMES, LaneConfig  # noqa: F401  (plain types both engines share)
from ..shared import lane_config_from as config_from  # noqa: F401

LEFT_MOST, LEFT, RIGHT, RIGHT_MOST = 0, 1, 2, 3
NONE, DETECTED, HELD = 0, 1, 2

DEFAULT = LaneConfig()


# ------------------------------------------------------------------ working frame
MAX_SCALE = 8   # VT_LANE_MAX_SCALE


def choose_scale(w: int, h: int, cfg: LaneConfig) -> int:
    """The working frame's downscale factor: the smallest integer k (<= 8) with
    w // k <= work_width_max and h // k <= work_height_max (not only powers of two:
    960, 1280, 1600 and 1920 px wide 16:9 frames all work at 320 x 180)."""
    k = 1
    while k < MAX_SCALE and (w // k > cfg.work_width_max or h // k > cfg.work_height_max):
        k += 1
    return k


def working_image(gray: np.ndarray, k: int) -> np.ndarray:
    """Mean of each k x k block, rounded half up (floor((sum + k^2 // 2) / k^2)); the
    partial block at the right and bottom edges is dropped (W = w // k, H = h // k).
    Exact."""
    h, w = gray.shape
    H, W = h // k, w // k
    if k == 1:
        return gray[:H, :W].astype(np.int32)
    blk = gray[:H * k, :W * k].astype(np.int64).reshape(H, k, W, k).sum(axis=(1, 3))
    return ((blk + (k * k) // 2) // (k * k)).astype(np.int32)


def row_limits(H: int, cfg: LaneConfig) -> tuple[int, int]:
    """(roi_top, band_top)."""
    roi_top = min(H * cfg.roi_top_permille // 1000, H - 1)
    band_top = min(max(roi_top, H * cfg.hough_top_permille // 1000), H - 1)
    return roi_top, band_top


def _lerp_rows(y: int, H: int, W: int, top: int, bottom: int) -> int:
    return W * (top * (H - 1 - y) + bottom * y) // (1000 * max(H - 1, 1))


def mark_widths(y: int, W: int, H: int, cfg: LaneConfig) -> tuple[int, int]:
    """(narrowest, widest) xf - xr accepted at row y, both >= 1."""
    wmin = max(1, _lerp_rows(y, H, W, cfg.mark_wmin_top_permille, cfg.mark_wmin_bottom_permille))
    wmax = max(1, _lerp_rows(y, H, W, cfg.mark_w_top_permille, cfg.mark_w_bottom_permille))
    return wmin, wmax


# ------------------------------------------------------------------ marking centres
def row_marks(row: np.ndarray, cfg: LaneConfig, wmin: int, wmax: int) -> list[int]:
    """Marking centres of one working row in half pixels (xr + xf), left to right."""
    w = row.shape[0]
    if w < 3:
        return []
    p = row.astype(np.int64)
    g = np.empty(w, np.int64)
    g[1:-1] = p[2:] - p[:-2]
    g[0] = p[1] - p[0]
    g[-1] = p[-1] - p[-2]
    thr = max(cfg.grad_min, 1, int(np.abs(g).sum()) * cfg.noise_gain_q4 // (16 * w))
    sign = np.where(g >= thr, 1, np.where(g <= -thr, -1, 0))
    out: list[int] = []
    xr = -1
    nz = np.flatnonzero(sign)
    i = 0
    while i < len(nz):
        sg = sign[nz[i]]
        j = i
        while j + 1 < len(nz) and nz[j + 1] == nz[j] + 1 and sign[nz[j + 1]] == sg:
            j += 1
        run = nz[i:j + 1]
        if sg > 0:
            xr = int(run[np.argmax(g[run])])       # first maximum of the rising run
        else:
            xf = int(run[np.argmin(g[run])])       # first minimum of the falling run
            if xr >= 0 and wmin <= xf - xr <= wmax:
                out.append(xr + xf)
            xr = -1
        i = j + 1
    return out


def all_marks(work: np.ndarray, cfg: LaneConfig) -> list[list[int]]:
    """Centres per row, rows processed bottom-up; a row is dropped (empty) when it has
    more than marks_per_row_max centres or they no longer fit in marks_max."""
    H, W = work.shape
    roi_top, _ = row_limits(H, cfg)
    out: list[list[int]] = [[] for _ in range(H)]
    left = cfg.marks_max
    for y in range(H - 1, roi_top - 1, -1):
        m = row_marks(work[y], cfg, *mark_widths(y, W, H, cfg))
        if len(m) <= cfg.marks_per_row_max and len(m) <= left:
            out[y] = m
            left -= len(m)
    return out


# ------------------------------------------------------------------ Hough
def n_theta(cfg: LaneConfig) -> int:
    return (cfg.theta_max_qdeg - cfg.theta_min_qdeg) // cfg.theta_step_qdeg + 1


def theta_of(k: int, half: int, cfg: LaneConfig) -> int:
    """theta (quarter degrees) of bin k in half 0 (left) or 1 (right, mirrored)."""
    t = cfg.theta_min_qdeg + k * cfg.theta_step_qdeg
    return t if half == 0 else -t


def hough(marks, W: int, H: int, half: int, cfg: LaneConfig):
    """Votes of one half's band centres: (acc, bin0) with acc[k, b - bin0] the votes
    for (theta_of(k), rho = b * step), step = 2^rho_step_shift; bin = floor(rho/step + 1/2)."""
    _, band_top = row_limits(H, cfg)
    cx = W // 2
    nt = n_theta(cfg)
    th = np.radians([theta_of(k, half, cfg) / QDEG for k in range(nt)])
    c, s = np.cos(th), np.sin(th)
    step = 1 << cfg.rho_step_shift
    D = int(math.ceil(math.hypot(W, H))) // step + 2
    acc = np.zeros((nt, 2 * D + 1), np.int64)
    rows = np.arange(nt)
    for y in range(band_top, H):
        for c2 in marks[y]:
            if (c2 < 2 * cx) != (half == 0):
                continue
            rho = (c2 / 2.0 - cx) * c + (y - (H - 1)) * s
            b = np.floor(rho / step + 0.5).astype(np.int64)
            acc[rows, b + D] += 1
    return acc, -D


def find_peaks(acc: np.ndarray, vmin: int, cfg: LaneConfig) -> list[tuple[int, int, int]]:
    """(votes, k, col) of the cells >= vmin that are the maximum of their window; of
    equal cells in a window the first in (k, col) order wins. Strongest first (ties in
    scan order), at most max_peaks."""
    nt, nr = acc.shape
    a, b = cfg.nms_theta_bins, cfg.nms_rho_bins
    out = []
    for k, col in zip(*np.nonzero(acc >= max(vmin, 1))):
        v = acc[k, col]
        k0, k1 = max(0, k - a), min(nt, k + a + 1)
        c0, c1 = max(0, col - b), min(nr, col + b + 1)
        if acc[k0:k1, c0:c1].max() > v:
            continue
        earlier = any((acc[kk, c0:(c1 if kk < k else col)] == v).any() for kk in range(k0, k + 1))
        if not earlier:
            out.append((int(v), int(k), int(col)))
    out.sort(key=lambda t: (-t[0], t[1], t[2]))
    return out[:cfg.max_peaks]


# ------------------------------------------------------------------ lines
@dataclass
class LaneLine:
    side: int
    state: int = NONE
    held: int = 0
    votes: int = 0
    theta_bin: int = -1        # accumulator cell of the peak (this frame's or the held one)
    rho_bin: int = 0
    theta_qdeg: int = 0        # Hough normal angle of that cell
    rho: int = 0               # Hough rho (working px) of that cell
    xb: float = 0.0            # refined line: x at row H-1 ...
    slope: float = 0.0         # ... and dx/dy
    verts: list = field(default_factory=list)   # [(y, x)], y decreasing from H-1
    y_top: int = -1
    sure_y: int = -1           # test support: rows >= this (if >= 0) are decided by
                               # extension segments with a margin of > 1 count

    def x_at(self, y: float, H: int) -> float:
        return self.xb + self.slope * (y - (H - 1))


def hough_line(theta_qdeg: int, rho: float, W: int, H: int) -> tuple[float, float]:
    """(xb, slope) of the Hough line (theta, rho) about the origin (W//2, H-1)."""
    t = math.radians(theta_qdeg / QDEG)
    return W // 2 + rho / math.cos(t), -math.tan(t)


def candidates(marks, W: int, H: int, half: int, cfg: LaneConfig):
    """Peaks of one half as refined LaneLines (strongest first), lines on one marking
    merged into the stronger."""
    _, band_top = row_limits(H, cfg)
    acc, bin0 = hough(marks, W, H, half, cfg)
    vmin = max(cfg.vote_min, (H - band_top) * cfg.vote_min_permille // 1000)
    merge = W * cfg.merge_permille / 1000.0
    kept: list[LaneLine] = []
    for v, k, col in find_peaks(acc, vmin, cfg):
        th = theta_of(k, half, cfg)
        rho = (col + bin0) << cfg.rho_step_shift
        xb, sl = hough_line(th, rho, W, H)
        ln = LaneLine(-1, DETECTED, 0, v, k, col + bin0, th, rho, xb, sl)
        refine(ln, marks, W, H, cfg)
        if all(abs(ln.x_at(band_top, H) - o.x_at(band_top, H)) > merge or
               abs(ln.xb - o.xb) > merge for o in kept):
            kept.append(ln)
    return kept, acc, bin0


def crossing(a: LaneLine, b: LaneLine, H: int):
    """(x, y) where a (left) and b (right) meet above the bottom row, else None."""
    num, den = b.xb - a.xb, b.slope - a.slope
    if den <= 0 or num <= 0:
        return None
    d = num / den   # rows above the bottom row
    return a.xb - a.slope * d, (H - 1) - d


def select_half(kept: list[LaneLine], H: int, half: int, cfg: LaneConfig):
    """(ego, outer) of one half; kept is strongest first."""
    sgn = 1 if half == 0 else -1  # sgn * x grows toward the centre
    cand = [ln for ln in kept if abs(ln.theta_qdeg) <= cfg.ego_theta_max_qdeg]
    if not cand:
        return None, None
    ego = cand[0]
    for ln in cand[1:]:
        if (ln.votes * 1000 >= cand[0].votes * cfg.ego_vote_permille and
                sgn * ln.xb > sgn * ego.xb and
                abs(ln.theta_qdeg) + cfg.min_dtheta_qdeg <= abs(ego.theta_qdeg)):
            ego = ln
    for ln in kept:
        if ln is not ego and sgn * ln.xb < sgn * ego.xb and \
                abs(ln.theta_qdeg) >= abs(ego.theta_qdeg) + cfg.min_dtheta_qdeg:
            return ego, ln
    return ego, None


def select_lines(kl: list[LaneLine], kr: list[LaneLine], W: int, H: int, cfg: LaneConfig):
    """([left-most, left, right, right-most] (None where absent), further lines, the row
    where the confirming pair meets (floor; -1 without one))."""
    roi_top, band_top = row_limits(H, cfg)
    cx = W // 2
    best = None
    for a in kl:
        for b in kr:
            p = crossing(a, b, H)
            if p is None:
                continue
            xv, yv = p
            wb = b.xb - a.xb
            if (roi_top - (H - band_top) <= yv <= H * cfg.vp_low_permille // 1000 and
                    abs(xv - cx) <= W * cfg.vp_x_permille / 1000.0 and
                    W * cfg.lane_w_min_permille / 1000.0 <= wb <= W * cfg.lane_w_max_permille / 1000.0):
                if best is None or a.votes + b.votes > best[0]:
                    best = (a.votes + b.votes, xv, yv, (H - 1) - math.floor((H - 1) - yv))
    if best is None:
        # Nothing confirms a line's geometry (night, faded markings): demand more votes.
        vmin = max(cfg.vote_min, (H - band_top) * cfg.vote_min_permille // 1000, 1)
        kl = [ln for ln in kl if ln.votes * 1000 >= vmin * cfg.solo_vote_permille]
        kr = [ln for ln in kr if ln.votes * 1000 >= vmin * cfg.solo_vote_permille]
    if best is not None:
        _, xv, yv, _ = best
        tol = max(W * cfg.vp_tol_permille / 1000.0, cfg.vp_tol_min)
        # distance from the vanishing point across the line (not along the row, where a
        # flat line's x swings with one theta bin)
        kl = [ln for ln in kl if abs(ln.x_at(yv, H) - xv) <= tol * math.hypot(1.0, ln.slope)]
        kr = [ln for ln in kr if abs(ln.x_at(yv, H) - xv) <= tol * math.hypot(1.0, ln.slope)]
    le, lo = select_half(kl, H, 0, cfg)
    re, ro = select_half(kr, H, 1, cfg)
    out = [lo, le, re, ro]
    for i, ln in enumerate(out):
        if ln is not None:
            ln.side = i
    if best is None:
        return out, [], -1
    return out, further(kl, 0, le, lo) + further(kr, 1, re, ro), best[3]


def further(kept: list[LaneLine], half: int, ego, outer) -> list[LaneLine]:
    """The further lines of one half (issue 8, all lanes): the lines through the
    vanishing point (kept, already filtered) that are in no slot and further out than
    the half's ego line (a line inside the ego lane is no lane line); strongest first."""
    if ego is None:
        return []
    sgn = 1 if half == 0 else -1
    return [ln for ln in kept if ln is not ego and ln is not outer and sgn * ln.xb < sgn * ego.xb]


def refine(line: LaneLine, marks, W: int, H: int, cfg: LaneConfig) -> None:
    """Least-squares line through the centre nearest to the line in each band row
    (within the window; the first of equals), refine_iters times, window halved."""
    _, band_top = row_limits(H, cfg)
    if abs(line.theta_qdeg) > cfg.ego_theta_max_qdeg:
        return  # flatter than any ego line: the row-wise nearest centre is ill-defined
    for it in range(cfg.refine_iters):
        tol = max(W * cfg.refine_tol_permille / 1000.0 / (1 << it), cfg.refine_tol_min)
        ts, xs = [], []
        for y in range(band_top, H):
            xp = line.x_at(y, H)
            best = None
            for c2 in marks[y]:
                d = abs(c2 / 2.0 - xp)
                if d <= tol and (best is None or d < best[0]):
                    best = (d, c2 / 2.0)
            if best is not None:
                ts.append(y - (H - 1))
                xs.append(best[1])
        if len(ts) < max(cfg.fit_min_points, 2) or len(set(ts)) < 2:
            return
        t = np.array(ts, float)
        x = np.array(xs, float)
        tm = t.mean()
        slope = float(((t - tm) * (x - x.mean())).sum() / ((t - tm) ** 2).sum())
        if abs(slope) > 8.0:   # not a lane: keep the line as it was
            return
        line.slope = slope
        line.xb = float(x.mean() - slope * tm)


def vanishing_row(left: LaneLine | None, right: LaneLine | None, W: int, H: int, cfg: LaneConfig):
    """(known, y_v): the row where the two ego lines meet when it lies in
    [roi_top, H * vp_low / 1000] and the lines are still at least half the selection's
    minimum lane width apart at the bottom row (not pulled onto one marking); else
    (False, roi_top)."""
    roi_top, band_top = row_limits(H, cfg)
    if left is not None and right is not None:
        num, den = right.xb - left.xb, right.slope - left.slope
        if num > 0 and den > 0 and num >= W * cfg.lane_w_min_permille / 2000.0:
            y = (H - 1) - math.floor(num / den)
            if roi_top <= y <= H * cfg.vp_low_permille // 1000:
                return True, y
    return False, roi_top


SLOPE_MAX = 16.0  # |dx/dy| of an extension segment is clamped to this (px/row)


def extend(line: LaneLine, marks, W: int, H: int, vp_known: bool, y_v: int,
           cfg: LaneConfig, max_verts: int = 24, y_cap: int = -1) -> None:
    """Vertices from the bottom row up (see the module doc, step 6); at most max_verts
    (C: VT_LANE_MAX_VERTS). Without vp_known the line ends no higher than y_cap."""
    _, band_top = row_limits(H, cfg)
    target = y_v + H * cfg.top_margin_permille // 1000 if vp_known else max(y_v + cfg.vp_margin, y_cap)
    # A vanishing point inside the band (a low horizon) ends the line within it.
    y1 = min(max(band_top, target), H - 1)
    verts = [(H - 1, line.xb), (y1, line.x_at(y1, H))]
    m = line.slope
    line.sure_y = -1
    y0, x0 = verts[1]
    win_b = W * cfg.win_bottom_permille / 1000.0
    last = None          # (index of its vertex, pivot y, pivot x, slope, top row)
    misses = 0
    while y0 > target and len(verts) < max_verts:
        seg = min(max(cfg.seg_min, (y0 - y_v) * cfg.seg_permille // 1000), y0 - target)
        tol = cfg.win_top + (win_b - cfg.win_top) * (y0 - y_v) / max(H - 1 - y_v, 1)
        ns = seg * cfg.bend_q8 // 256
        best = None
        counts = {}
        for k in range(-ns, ns + 1):
            mk = m + k / seg
            cnt, ytop = 0, y0
            for y in range(y0 - 1, y0 - seg - 1, -1):
                xp = x0 + mk * (y - y0)
                n = sum(1 for c2 in marks[y] if abs(c2 / 2.0 - xp) <= tol)
                if n:
                    cnt += n
                    ytop = y
            counts[k] = cnt
            if best is None or cnt > best[0] or (cnt == best[0] and abs(k) < abs(best[1])):
                best = (cnt, k, ytop)
        cnt, k, ytop = best
        need = max(cfg.seg_count_min, seg * cfg.seg_count_permille // 1000)
        # Test support: a count moved by one (a centre at the window's edge, where C's
        # Q16 and this float arithmetic may disagree) could change this decision. Any
        # other slope is a rival, the neighbours too: a flip to k +- 1 moves the next
        # vertex by 1 px in x, beyond the 0.25 px the rows are compared with. (An
        # unrefined flat line differs by ~0.01 px between C, whose line comes from the
        # Q1.14 sin/cos of its Hough cell, and this float line; with a centre 0.003 px
        # outside the window C counted it and chose k = 0 over k = 1.)
        rival = max([c for kk, c in counts.items() if kk != k], default=-9)
        if line.sure_y < 0 and (cnt - rival <= 1 or abs(cnt - need) <= 1):
            line.sure_y = y0
        if cnt >= need:
            m = min(max(m + k / seg, -SLOPE_MAX), SLOPE_MAX)
            last = (len(verts), y0, x0, m, ytop)
            misses = 0
        else:
            misses += 1
            if not vp_known and misses > cfg.seg_miss_max:
                break
        y0, x0 = y0 - seg, x0 - m * seg
        verts.append((y0, x0))
    if vp_known:
        top = verts[-1][0]
    elif last is None:
        verts, top = verts[:2], y1
    else:
        i, py, px, pm, top = last
        verts = verts[:i] + [(top, px + pm * (top - py))]
    line.verts = verts
    line.y_top = top


# ------------------------------------------------------------------ frame + tracker
@dataclass
class LaneFrame:
    scale: int                       # the working frame is the input box-downscaled by this
    W: int
    H: int
    roi_top: int
    band_top: int
    vp_known: bool
    vp_y: int
    lines: list                      # LaneLine or None per slot
    road: dict | None = None         # valid, y_top, y_bottom, height, x_left, x_right, lane_width
    accs: tuple = ()                 # ((acc, bin0) left, (acc, bin0) right)
    lines_all: list = field(default_factory=list)  # every line, left to right by xb
    lines_all_slot: list = field(default_factory=list)  # its slot, -1 for a further line
    lines_all_dropped: int = 0       # further lines left out for max_lines
    pair_vp_y: int = -1              # row where the confirming pair meets (C: pair_vp_y)


def polyline_x(verts, yw: float) -> float:
    """x of the polyline (vertices with y decreasing) at working row yw: linear between
    vertices; outside them the end segment is extended."""
    if len(verts) == 1:
        return verts[0][1]
    for i in range(len(verts) - 1):
        (ya, xa), (yb, xb) = verts[i], verts[i + 1]
        if yw >= yb or i == len(verts) - 2:
            return xa if ya == yb else xa + (xb - xa) * (ya - yw) / (ya - yb)
    return verts[-1][1]


def line_points(line: LaneLine, n: int) -> np.ndarray:
    """(x, y) input-pixel points of a line, one per working row from y_top to H-1
    (working scale n)."""
    ys = np.arange(line.y_top, line.verts[0][0] + 1)
    xs = np.array([polyline_x(line.verts, y) for y in ys])
    return np.stack([(xs + 0.5) * n - 0.5, (ys + 0.5) * n - 0.5], axis=1)


def road_area(lines, frame_w: int, frame_h: int, k: int, max_height: int) -> dict:
    """The road area in input pixels (vt_road_area): between the inner-most found line on
    each side (ego line, else the outer one), from where both lines exist down to the
    bottom row; lane_width = ego lane width (the span / number of lanes it covers)."""
    lft = lines[LEFT] or lines[LEFT_MOST]
    rgt = lines[RIGHT] or lines[RIGHT_MOST]
    gaps = 1 + (lines[LEFT] is None) + (lines[RIGHT] is None)
    return road_between(lft, rgt, gaps, frame_w, frame_h, k, max_height)


def road_area_all(lines_all, frame_w: int, frame_h: int, k: int, max_height: int) -> dict:
    """The road area over all lanes (vt_lane_road_all): between the left-most and the
    right-most of all lines; lane_width = the span / (number of lines - 1)."""
    if len(lines_all) < 2:
        return road_between(None, None, 1, frame_w, frame_h, k, max_height)
    return road_between(lines_all[0], lines_all[-1], len(lines_all) - 1, frame_w, frame_h, k,
                        max_height)


def road_between(lft, rgt, gaps: int, frame_w: int, frame_h: int, n: int,
                 max_height: int) -> dict:
    """The area between lines lft and rgt (either None: not valid), working scale n,
    lane width per row = their distance // gaps."""
    road = dict(valid=0, y_top=0, y_bottom=0, height=frame_h,
                x_left=np.zeros(max_height, np.int64), x_right=np.zeros(max_height, np.int64),
                lane_width=np.zeros(max_height, np.int64))
    if lft is None or rgt is None:
        return road
    top_w = max(lft.y_top, rgt.y_top)
    y_first = max(0, math.ceil((top_w + 0.5) * n - 0.5))
    good = []
    for yi in range(frame_h - 1, y_first - 1, -1):
        # C's Q16 working row, floor((2 y + 1) 2^15 / n) - 2^15 (exact for a power of two)
        yw = (((2 * yi + 1) * 32768) // n - 32768) / 65536.0
        xl = math.floor((polyline_x(lft.verts, yw) + 0.5) * n - 0.5 + 0.5)
        xr = math.floor((polyline_x(rgt.verts, yw) + 0.5) * n - 0.5 + 0.5)
        cl, cr = min(max(xl, 0), frame_w - 1), min(max(xr, 0), frame_w - 1)
        if xl > xr or cl > cr:
            break
        good.append((yi, cl, cr, min(max((xr - xl) // gaps, 0), 32767)))
    if not good:
        return road
    for yi, cl, cr, lw in good:
        road["x_left"][yi], road["x_right"][yi], road["lane_width"][yi] = cl, cr, lw
    road.update(valid=1, y_top=good[-1][0], y_bottom=frame_h - 1)
    return road


class LaneDetector:
    """Reference lane detector; its state is the previous frame's lines (the tracker)."""

    def __init__(self, cfg: LaneConfig = DEFAULT, max_height: int = 1080, max_verts: int = 24,
                 max_lines: int = 8):
        self.cfg = cfg
        self.max_lines = max_lines      # C: VT_LANE_MAX_LINES
        self.max_height = max_height    # C: VT_MAX_HEIGHT (length of the road arrays)
        self.max_verts = max_verts      # C: VT_LANE_MAX_VERTS
        self.reset()

    def reset(self) -> None:
        self.prev: list[LaneLine | None] = [None] * 4
        self.geom = None

    def _track(self, slot: int, cur: LaneLine | None, W: int, H: int) -> LaneLine | None:
        cfg = self.cfg
        prev = self.prev[slot]
        if cur is None:
            if prev is None or prev.held >= cfg.track_hold:
                return None
            return replace(prev, state=HELD, held=prev.held + 1, verts=[], y_top=-1)
        if prev is None:
            return cur
        _, band_top = row_limits(H, cfg)
        gate = W * cfg.track_gate_permille / 1000.0
        if abs(cur.xb - prev.xb) > gate or abs(cur.x_at(band_top, H) - prev.x_at(band_top, H)) > gate:
            return cur
        a = cfg.track_alpha_permille / 1000.0   # C rounds each step to the Q16 LSB (half away from zero)
        cur.xb = prev.xb + a * (cur.xb - prev.xb)
        cur.slope = prev.slope + a * (cur.slope - prev.slope)
        return cur

    def detect(self, gray: np.ndarray) -> LaneFrame:
        cfg = self.cfg
        h, w = gray.shape
        s = choose_scale(w, h, cfg)
        work = working_image(gray, s)
        H, W = work.shape
        if self.geom != (s, W, H):
            self.reset()
            self.geom = (s, W, H)
        roi_top, band_top = row_limits(H, cfg)
        marks = all_marks(work, cfg)
        kl, accl, b0l = candidates(marks, W, H, 0, cfg)
        kr, accr, b0r = candidates(marks, W, H, 1, cfg)
        found, extra, pair_y = select_lines(kl, kr, W, H, cfg)
        lines = [self._track(i, found[i], W, H) for i in range(4)]
        known, y_v = vanishing_row(lines[LEFT], lines[RIGHT], W, H, cfg)
        # No ego vanishing point, but a pair confirmed the selection: no line runs on
        # past that pair's vanishing row (a lone line climbing into trees).
        y_cap = -1
        if not known and roi_top <= pair_y <= H * cfg.vp_low_permille // 1000:
            y_cap = pair_y + H * cfg.top_margin_permille // 1000
        for ln in lines:
            if ln is not None:
                extend(ln, marks, W, H, known, y_v, cfg, self.max_verts, y_cap)
        self.prev = lines
        road = road_area(lines, w, h, s, self.max_height)
        # Every line: slots first, then the further lines while there is room; sorted
        # left to right by xb, stable.
        all_ = [(ln, i) for i, ln in enumerate(lines) if ln is not None]
        room = self.max_lines - len(all_)
        for ln in extra[:max(room, 0)]:
            ln = replace(ln, side=-1)
            ln.xb = min(max(ln.xb, -16384.0), 16384.0)
            extend(ln, marks, W, H, known, y_v, cfg, self.max_verts, y_cap)
            all_.append((ln, -1))
        all_.sort(key=lambda t: t[0].xb)
        fr = LaneFrame(s, W, H, roi_top, band_top, known, y_v, lines, road,
                       ((accl, b0l), (accr, b0r)), [t[0] for t in all_], [t[1] for t in all_],
                       max(0, len(extra) - max(room, 0)), pair_y)
        return fr

    def road_all(self, frame: LaneFrame, frame_w: int, frame_h: int) -> dict:
        """The road area over all lanes of a frame this detector returned."""
        return road_area_all(frame.lines_all, frame_w, frame_h, frame.scale, self.max_height)
