"""Float oracle of c/ttc_scale.c: monocular time to collision from the scale change of
many matched blocks inside a track's box (the classic camera TTC of the Udacity SFND
"3D object tracking" project, with block matching by SAD in place of keypoint descriptors;
IVVI paper sec. 4's TTC "from the box's scale change" measured inside the box, not at its
jittering edges).

For every track, every frame:
  1. blocks of B x B px on a G x G grid over the box's inner part, kept if they have
     texture in both directions, are stored with their positions (a ring of the last
     frames);
  2. the blocks stored `lag` frames ago are searched in this frame by SAD over +-radius px
     around where the box's own motion and size change put them; a match at the window's
     edge, or with a SAD over max_sad per pixel, is dropped; the integer match is refined
     by a parabola through the SAD of its two neighbours in x and in y;
  3. the scale s is the median over all pairs of matched blocks (at least min_pair px apart
     then) of their distance now / their distance then;
  4. TTC = lag dt / (s - 1) (d ~ 1/s for a rigid rear face seen head on, so at a constant
     closing speed d_t = d_{t-lag} - lag dt v and d_t / v = lag dt / (s - 1)).
Around that: fewer than min_match_permille of the blocks matched gives no scale (their
windows were misplaced); no scale over `lag` frames (a young track, lost blocks) tries
lag - 1 .. min_lag; when the box's size ratio over the lag is more than
prior_gate_permille away from the track's last coarse scale (the median ratio of its
integer matches, an exact integer rule), that scale places the windows instead of the box
(a detection re-fit, a box cut by the frame's edge); only `capacity` tracks are measured,
the nearest (largest box bottom), a slot changing hands only to a track more than
evict_margin_px rows nearer.

The block choice, the predicted window and the integer SAD search are integer rules shared
with C exactly (same candidates, same ties: first in raster order); only the sub-pixel
offsets, the ratios, the median and the TTC are real numbers here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class TtcScaleParams:
    block: int = 8            # block side, px, 4..16
    grid: int = 8             # G x G blocks over the inner box, 2..VT_TTC_GRID
    margin_permille: int = 100  # inner box: this many thousandths of the width/height cut from each side, 0..400
    radius: int = 6           # search +-radius px around the prediction, 1..16
    min_texture: int = 2      # mean |horizontal| and |vertical| step in a block, grey levels, 0..255
    max_sad: int = 24         # mean |difference| of a match, grey levels, 1..255
    lag: int = 5              # frames between the two views, 1..VT_TTC_HIST-1
    min_pair_px: int = 16     # pairs of blocks closer than this (then) are not used, 1..4096
    min_pairs: int = 10       # fewer usable pairs: no scale, 1..100000
    frame_dt: float = 0.1     # s per frame, (0, 1]
    ttc_max: float = 20.0     # s; a larger TTC (or s <= 1: not closing) is "no TTC", (0, 1000]
    anchor_radius: int = 12   # 0, or radius+1..48: ANCHORS blocks searched over +-this first;
    #                           the lower median of their offsets moves every block's window
    evict_margin_px: int = 8  # -1: slots stay with their tracks, given in input order; 0..4096:
    #                           nearest tracks first (largest box bottom), and a track takes the
    #                           farthest owner's slot when its bottom is more than this lower
    prior_gate_permille: int = 100  # -1: blocks always predicted with the box's size change;
    #                           0..1000: with the track's last coarse scale (integer match
    #                           positions) when the box's size ratio differs from it by more
    #                           than this many thousandths of it (a re-fit jump)
    min_lag: int = 2          # 1..HIST-1 (>= lag: none): no scale over `lag` frames (a young track, lost blocks):
    #                           the longest shorter lag down to this that gives one
    min_match_permille: int = 500  # fewer matched blocks than this share (1/1000) of those
    #                           searched: no scale (misplaced windows), the fallback lags try


@dataclass
class TtcScaleOut:
    id: int
    scale: float | None       # median distance ratio over lag frames (None: too few pairs)
    ttc: float | None         # lag dt / (s - 1), s; None unless 1 < s and ttc <= ttc_max
    blocks: int               # blocks searched (stored lag frames ago)
    matched: int              # of them matched
    pairs: int                # pairs used for the median
    lag: int = 0              # frames the scale spans (lag, or a shorter fallback; 0: none)


@dataclass
class _Entry:
    box: tuple
    pos: list                 # [(x, y)] top-left corners of the stored blocks
    tmpl: list                # [B x B uint8 array]


@dataclass
class _Slot:
    id: int
    ring: list = field(default_factory=list)   # newest last
    prior: int = 0                              # coarse scale of the last measurement, Q16 (0: none)


ANCHORS = 4                      # blocks k n / 4, k = 0..3 (VT_TTC_ANCHORS)
Q16 = 65536
R2_MAX = (2**31 - 1) / 2**16    # the C core saturates a squared ratio there (s = 181)
BOX_LIM = 32767                   # boxes with a coordinate beyond +-this are not measured


def div_round(n: int, d: int) -> int:
    """n / d rounded half away from zero (exact integers), as vt_div_round_s64."""
    q, r = divmod(abs(n), abs(d))
    if 2 * r >= abs(d):
        q += 1
    return q if (n >= 0) == (d > 0) else -q


def grid_blocks(p: TtcScaleParams, box, w: int, h: int) -> list[tuple[int, int]]:
    """Top-left corners of the grid's blocks inside the box's inner part (integer rule)."""
    l, t, r, b = box
    bw, bh = r - l + 1, b - t + 1
    li, ti = l + bw * p.margin_permille // 1000, t + bh * p.margin_permille // 1000
    wi, hi = bw - 2 * (bw * p.margin_permille // 1000), bh - 2 * (bh * p.margin_permille // 1000)
    if wi < p.block or hi < p.block:
        return []
    out = []
    for gy in range(p.grid):
        y = ti + (hi - p.block) * gy // (p.grid - 1)
        for gx in range(p.grid):
            x = li + (wi - p.block) * gx // (p.grid - 1)
            if 0 <= x and x + p.block <= w and 0 <= y and y + p.block <= h:
                out.append((x, y))
    return out


def textured(p: TtcScaleParams, blk: np.ndarray) -> bool:
    b = blk.astype(np.int32)
    need = p.min_texture * p.block * (p.block - 1)
    return int(np.abs(np.diff(b, axis=1)).sum()) >= need and int(np.abs(np.diff(b, axis=0)).sum()) >= need


def predict(p: TtcScaleParams, old_box, new_box, x: int, y: int, prior: int = 0) -> tuple[int, int]:
    """Where the block at (x, y) in old_box should be in new_box: moved with the box's
    centre and scaled about it by (w + h) new / (w + h) old, or by prior / 2^16 when a prior
    scale (Q16, an exact integer) is given, rounded half away from zero."""
    lo, to, ro, bo = old_box
    ln, tn, rn, bn = new_box
    so = (ro - lo + 1) + (bo - to + 1)
    sn = (rn - ln + 1) + (bn - tn + 1)
    if prior > 0:
        so, sn = Q16, prior
    cxo, cyo, cxn, cyn = lo + ro, to + bo, ln + rn, tn + bn   # 2 x centre
    px = x + div_round((cxn - cxo) * so + (2 * x + p.block - 1 - cxo) * (sn - so), 2 * so)
    py = y + div_round((cyn - cyo) * so + (2 * y + p.block - 1 - cyo) * (sn - so), 2 * so)
    return px, py


def search(p: TtcScaleParams, img: np.ndarray, tmpl: np.ndarray, px: int, py: int, R: int):
    """Integer SAD search over +-R: (dx, dy, sad table) of the best (first in raster order
    among equals), or None when it lies on the window's edge or its SAD is over max_sad."""
    h, w = img.shape
    B = p.block
    t = tmpl.astype(np.int32)
    sad = {}
    best = None
    for dy in range(-R, R + 1):
        for dx in range(-R, R + 1):
            x, y = px + dx, py + dy
            if x < 0 or y < 0 or x + B > w or y + B > h:
                continue
            s = int(np.abs(img[y:y + B, x:x + B].astype(np.int32) - t).sum())
            sad[(dx, dy)] = s
            if best is None or s < best[0]:
                best = (s, dx, dy)
    if best is None:
        return None
    s0, dx, dy = best
    if abs(dx) == R or abs(dy) == R or s0 > p.max_sad * B * B:
        return None
    return dx, dy, sad


def match(p: TtcScaleParams, img: np.ndarray, tmpl: np.ndarray, px: int, py: int):
    """The block's match: (sub-pixel x, y, integer x, y), or None."""
    r = search(p, img, tmpl, px, py, p.radius)
    if r is None:
        return None
    dx, dy, sad = r
    s0 = sad[(dx, dy)]
    if (dx - 1, dy) not in sad or (dx + 1, dy) not in sad or (dx, dy - 1) not in sad or (dx, dy + 1) not in sad:
        return None

    def sub(sm, sp):
        den = sm - 2 * s0 + sp
        if den <= 0:
            return 0.0
        return max(-0.5, min(0.5, (sm - sp) / (2.0 * den)))
    ox = sub(sad[(dx - 1, dy)], sad[(dx + 1, dy)])
    oy = sub(sad[(dx, dy - 1)], sad[(dx, dy + 1)])
    return px + dx + ox, py + dy + oy, px + dx, py + dy


def scale_of(p: TtcScaleParams, old_pos, new_pos):
    """Median over pairs of distance now / distance then; (scale or None, pairs)."""
    ratios = []
    n = len(old_pos)
    for i in range(n):
        for j in range(i + 1, n):
            if new_pos[i] is None or new_pos[j] is None:
                continue
            d0 = (old_pos[i][0] - old_pos[j][0]) ** 2 + (old_pos[i][1] - old_pos[j][1]) ** 2
            if d0 < p.min_pair_px ** 2:
                continue
            d1 = (new_pos[i][0] - new_pos[j][0]) ** 2 + (new_pos[i][1] - new_pos[j][1]) ** 2
            ratios.append(min(d1 / d0, R2_MAX))
    if len(ratios) < p.min_pairs:
        return None, len(ratios)
    ratios.sort()
    return math.sqrt(ratios[(len(ratios) - 1) // 2]), len(ratios)   # the lower median


def prior_of(p: TtcScaleParams, old_pos, new_int) -> int:
    """The coarse scale that steers the next frame's search: the lower median over the same
    pairs of the squared ratios of the integer match positions, each rounded to Q16
    (saturated at 2^31 - 1), floor(sqrt(median 2^16)); an exact integer (Q16), 0 (none)
    with fewer than min_pairs pairs or outside [1/2, 2]."""
    r2 = []
    n = len(old_pos)
    for i in range(n):
        for j in range(i + 1, n):
            if new_int[i] is None or new_int[j] is None:
                continue
            d0 = (old_pos[i][0] - old_pos[j][0]) ** 2 + (old_pos[i][1] - old_pos[j][1]) ** 2
            if d0 < p.min_pair_px ** 2:
                continue
            d1 = (new_int[i][0] - new_int[j][0]) ** 2 + (new_int[i][1] - new_int[j][1]) ** 2
            r2.append(min(div_round(d1 * Q16, d0), 2**31 - 1))
    if len(r2) < p.min_pairs:
        return 0
    r2.sort()
    s = math.isqrt(r2[(len(r2) - 1) // 2] * Q16)
    return s if Q16 // 2 <= s <= 2 * Q16 else 0


def assign_nearest(slots: list, capacity: int, tracks, margin: int) -> None:
    """Slots for tracks without one, nearest first (largest box bottom, then input order):
    a free slot, else the farthest owner's (smallest bottom, then later in input order)
    when the track's bottom is more than `margin` rows lower; the first track that gets
    none ends it (no later one could)."""
    order = sorted(range(len(tracks)), key=lambda i: (-tracks[i][1][3], i))
    rank = {tracks[i][0]: r for r, i in enumerate(order)}
    bottom = {tid: box[3] for tid, box in tracks}
    for i in order:
        tid = tracks[i][0]
        if any(s.id == tid for s in slots):
            continue
        if len(slots) < capacity:
            slots.append(_Slot(tid))
            continue
        far = max(slots, key=lambda s: rank[s.id])
        if bottom[tid] > bottom[far.id] + margin:
            slots[slots.index(far)] = _Slot(tid)
            continue
        return


class TtcScaleTracker:
    """Per track id (ids absent in a frame are forgotten), at most `capacity` tracks."""

    def __init__(self, params: TtcScaleParams, capacity: int, hist: int):
        self.p = params
        self.capacity = capacity
        self.hist = hist
        self.slots: list[_Slot] = []
        self.size = None

    def step(self, grey: np.ndarray, tracks) -> list[TtcScaleOut]:
        p = self.p
        h, w = grey.shape
        if self.size != (w, h):      # another frame size: every track starts again
            self.slots, self.size = [], (w, h)
        ids = [int(t) for t, _ in tracks]
        self.slots = [s for s in self.slots if s.id in ids]
        if p.evict_margin_px >= 0:
            assign_nearest(self.slots, self.capacity, [(int(t), tuple(int(v) for v in b)) for t, b in tracks],
                           p.evict_margin_px)
        out = []
        for tid, box in tracks:
            box = tuple(int(v) for v in box)
            slot = next((s for s in self.slots if s.id == tid), None)
            if slot is None:
                if len(self.slots) >= self.capacity or p.evict_margin_px >= 0:
                    continue
                slot = _Slot(tid)
                self.slots.append(slot)
            inside = all(-BOX_LIM - 1 <= v <= BOX_LIM for v in box)
            last, slot.prior = slot.prior, 0
            res = (None, None, 0, 0, 0, 0)
            # the longest lag, from `lag` down to min_lag, that measures a scale
            for lag in range(p.lag, min(p.min_lag, p.lag) - 1, -1):
                if res[0] is not None or not inside:
                    break
                if len(slot.ring) >= lag:
                    res = self._measure(grey, slot, slot.ring[-lag], box, lag, last)
            scale, ttc, nb, nm, npairs, used = res
            pos, tmpl = [], []
            for x, y in (grid_blocks(p, box, w, h) if inside else []):
                blk = grey[y:y + p.block, x:x + p.block]
                if textured(p, blk):
                    pos.append((x, y))
                    tmpl.append(blk.copy())
            slot.ring.append(_Entry(box, pos, tmpl))
            if len(slot.ring) > self.hist:
                slot.ring.pop(0)
            out.append(TtcScaleOut(tid, scale, ttc, nb, nm, npairs, used))
        return out

    def _measure(self, grey, slot, e, box, lag, last):
        """Blocks of entry e (lag frames old) matched in grey: (scale, ttc, blocks, matched,
        pairs, lag). With lag == p.lag the slot's prior for the next frame is set."""
        p = self.p
        n = len(e.pos)
        so = (e.box[2] - e.box[0] + 1) + (e.box[3] - e.box[1] + 1)
        sn = (box[2] - box[0] + 1) + (box[3] - box[1] + 1)
        # the box's size ratio sn / so against the prior: it steps in only past the gate
        prior = 0
        if p.prior_gate_permille >= 0 and last > 0 and lag == p.lag and \
                abs(sn * Q16 - last * so) * 1000 > p.prior_gate_permille * last * so:
            prior = last
        offs = []
        for k in range(ANCHORS if p.anchor_radius and n else 0):
            i = k * n // ANCHORS
            if k > 0 and i == (k - 1) * n // ANCHORS:
                continue
            r = search(p, grey, e.tmpl[i], *predict(p, e.box, box, *e.pos[i], prior), p.anchor_radius)
            if r is not None:
                offs.append(r[:2])
        ox = sorted(o[0] for o in offs)[(len(offs) - 1) // 2] if offs else 0
        oy = sorted(o[1] for o in offs)[(len(offs) - 1) // 2] if offs else 0
        new = []
        for (x, y), tm in zip(e.pos, e.tmpl):
            px, py = predict(p, e.box, box, x, y, prior)
            new.append(match(p, grey, tm, px + ox, py + oy))
        nm = sum(v is not None for v in new)
        if nm * 1000 < p.min_match_permille * n:   # most blocks lost: nothing trusted
            return None, None, n, nm, 0, lag
        scale, npairs = scale_of(p, e.pos, [None if v is None else v[:2] for v in new])
        if p.prior_gate_permille >= 0 and lag == p.lag:
            slot.prior = prior_of(p, e.pos, [None if v is None else v[2:] for v in new])
        ttc = None
        if scale is not None and scale > 1.0:
            t = lag * p.frame_dt / (scale - 1.0)
            ttc = t if t <= p.ttc_max else None
        return scale, ttc, n, nm, npairs, lag
