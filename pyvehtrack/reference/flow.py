"""Float oracle of c/flow.c: overtaking vehicles by SAD block matching in the
lateral areas of the image (IVVI paper, sec. 3), written from the paper.

The paper: optical flow by block similarity (sum of absolute differences) in the
lateral areas where overtaking vehicles appear; flow computed only for pixels whose
difference with the previous image exceeds a threshold; vectors filtered by range
(magnitude), direction (an overtaking vehicle moves against the background, which
flows outward as the ego car passes it) and the size of the blobs of equal motion;
a blob over an area threshold is an overtaking vehicle. When the ego car overtakes
another vehicle, the tracker hands that vehicle to this module.

Which parts of a level image hold their frame: the C stage computes its level image
only where it reads it (the lateral areas widened by twice the search range, each
hand-over track's cells widened by the search range + 1 px) and records those
rectangles. This oracle computes whole level images but keeps the same list, for the
two rules it implies: a hand-over cell whose block in the previous image lies inside
no recorded rectangle is skipped (a track seeded without its frame, elsewhere than
the areas), and a frame whose areas were not covered in the previous image (a cfg
change that widened them) is a first frame again.

This module never calls the C core. `cfg` is any object with the fields of the C
struct vt_flow_cfg (documented in include/vehtrack/flow.h), e.g. the cffi struct
or a types.SimpleNamespace; the friendly API passes the C defaults.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

LEFT, RIGHT = 1, 2
KIND_OVERTAKING, KIND_HANDOVER = 1, 2
COMPUTED, ACCEPTED, FLAT = 1, 2, 4


@dataclass
class Hyp:
    box: tuple[int, int, int, int]  # left, top, right, bottom (inclusive, input px)
    side: int
    kind: int
    id: int
    cells: int
    flow: tuple[float, float]       # mean motion, input px/frame
    age: int = 1                    # frames in a row the blob (or hand-over track) was seen
    cy: int = 0                     # row of the centre of gravity of its cells (input px)


@dataclass
class Area:
    x0: int
    y0: int
    gw: int
    gh: int
    dx: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.int64))
    dy: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.int64))
    flag: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.uint8))
    sad: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.int64))
    dropped: int = 0


def level_image(frame: np.ndarray, level: int) -> np.ndarray:
    """The Gaussian pyramid level the flow runs on (cv2.pyrDown: 5x5 binomial,
    reflect-101 border, every second pixel)."""
    img = np.ascontiguousarray(frame)
    for _ in range(level):
        img = cv2.pyrDown(img)
    return img


def lateral_area(cfg, lw: int, lh: int, side: int) -> Area:
    """Cell grid of the left (side 0) or right (side 1) lateral area of a level image."""
    sw = lw * cfg.strip_permille // 1000
    ya, yb = lh * cfg.top_permille // 1000, lh * cfg.bottom_permille // 1000
    gw, gh = sw // cfg.cell, (yb - ya) // cfg.cell
    x0 = 0 if side == 0 else lw - gw * cfg.cell
    return Area(x0, ya, gw, gh)


def area_rect(cfg, ar: Area, lw: int, lh: int):
    """The rectangle (x0, y0, x1, y1), half-open, level px, that a step reads of an area
    in both images: its cells widened by 2 search_x / 2 search_y (the search reaches one
    range beyond a cell, the backward check two), clipped to the image."""
    n = cfg.cell
    return _clip((ar.x0 - 2 * cfg.search_x, ar.y0 - 2 * cfg.search_y,
                  ar.x0 + ar.gw * n + 2 * cfg.search_x, ar.y0 + ar.gh * n + 2 * cfg.search_y), lw, lh)


def _clip(r, lw, lh):
    return (min(max(r[0], 0), lw), min(max(r[1], 0), lh), min(max(r[2], 0), lw), min(max(r[3], 0), lh))


def _inside(r, rects) -> bool:
    """r inside one of rects (all half-open (x0, y0, x1, y1))."""
    return any(r[0] >= q[0] and r[1] >= q[1] and r[2] <= q[2] and r[3] <= q[3] for q in rects)


def best_match(cur: np.ndarray, prev: np.ndarray, x: int, y: int, n: int, sx: int, sy: int):
    """(dx, dy, sad): the block of `cur` at (x, y) matched in `prev` at (x-dx, y-dy)
    with the smallest SAD; zero motion wins ties, then the first candidate with dy
    outer, dx inner; blocks leaving `prev` are not candidates."""
    h, w = prev.shape
    a = cur[y:y + n, x:x + n].astype(np.int64)
    best = (int(np.abs(a - prev[y:y + n, x:x + n]).sum()), 0, 0)
    for dy in range(-sy, sy + 1):
        for dx in range(-sx, sx + 1):
            bx, by = x - dx, y - dy
            if (dx, dy) == (0, 0) or bx < 0 or by < 0 or bx + n > w or by + n > h:
                continue
            s = int(np.abs(a - prev[by:by + n, bx:bx + n]).sum())
            if s < best[0]:
                best = (s, dx, dy)
    return best[1], best[2], best[0]


def consistent(cfg, cur, prev, x, y, dx, dy) -> bool:
    """Forward-backward check: the matched block of `prev`, searched back in `cur`, returns to
    the cell within back_tol px (-1: no check)."""
    if cfg.back_tol < 0:
        return True
    rdx, rdy, _ = best_match(prev, cur, x - dx, y - dy, cfg.cell, cfg.search_x, cfg.search_y)
    return abs(rdx + dx) <= cfg.back_tol and abs(rdy + dy) <= cfg.back_tol


def _q16_mean(total: int, count: int, level: int) -> float:
    """Mean in input px, quantised as the C result is (Q16, half away from zero);
    the quotient is exact enough in float64 (see tests/test_flow.py)."""
    q = total * (2 ** level) * 65536 / count
    return math.copysign(math.floor(abs(q) + 0.5), q) / 65536


def area_flow(cfg, cur: np.ndarray, prev: np.ndarray, side: int, level: int, w: int, h: int,
              max_blobs: int = 32):
    """Vectors, flags and the blobs over the area threshold of one lateral area (at most
    max_blobs, in the order of their first cell; the rest are counted as dropped)."""
    lh, lw = cur.shape
    ar = lateral_area(cfg, lw, lh, side)
    n = cfg.cell
    ar.dx = np.zeros((ar.gh, ar.gw), np.int64)
    ar.dy = np.zeros((ar.gh, ar.gw), np.int64)
    ar.sad = np.zeros((ar.gh, ar.gw), np.int64)
    ar.flag = np.zeros((ar.gh, ar.gw), np.uint8)
    inward = 1 if side == 0 else -1
    diff = np.abs(cur.astype(np.int64) - prev.astype(np.int64)) > cfg.diff_thresh
    for j in range(ar.gh):
        for i in range(ar.gw):
            x, y = ar.x0 + i * n, ar.y0 + j * n
            changed = int(diff[y:y + n, x:x + n].sum())
            if 1000 * changed < cfg.diff_min_permille * n * n:   # the paper's speed-up
                continue
            block = cur[y:y + n, x:x + n].astype(np.int64)
            if np.abs(np.diff(block, axis=1)).sum() < cfg.min_texture * n * (n - 1):
                ar.flag[j, i] = FLAT      # no horizontal texture: dx would be arbitrary
                continue
            dx, dy, s = best_match(cur, prev, x, y, n, cfg.search_x, cfg.search_y)
            ar.dx[j, i], ar.dy[j, i], ar.sad[j, i] = dx, dy, s
            ar.flag[j, i] = COMPUTED
            if (s <= cfg.max_sad_per_px * n * n and inward * dx >= cfg.min_inward
                    and abs(dx) + abs(dy) <= cfg.max_mag and consistent(cfg, cur, prev, x, y, dx, dy)):
                ar.flag[j, i] |= ACCEPTED
    acc = ((ar.flag & ACCEPTED) > 0).astype(np.uint8)
    hyps = []
    if acc.size:
        nlab, labels = cv2.connectedComponents(acc, connectivity=8)
        blobs = []
        for lab in range(1, nlab):
            jj, ii = np.nonzero(labels == lab)
            if len(jj) < cfg.min_blob_cells:
                continue
            first = int(min(jj * ar.gw + ii))
            blobs.append((first, jj, ii))
        blobs = sorted(blobs, key=lambda b: b[0])
        ar.dropped = max(0, len(blobs) - max_blobs)
        for _, jj, ii in blobs[:max_blobs]:
            sdx, sdy = int(ar.dx[jj, ii].sum()), int(ar.dy[jj, ii].sum())
            box = ((ar.x0 + ii.min() * n) << level, (ar.y0 + jj.min() * n) << level,
                   min(((ar.x0 + (ii.max() + 1) * n) << level) - 1, w - 1),
                   min(((ar.y0 + (jj.max() + 1) * n) << level) - 1, h - 1))
            cy = (ar.y0 + n * (2 * int(jj.sum()) + len(jj)) // (2 * len(jj))) << level
            hyps.append(Hyp(tuple(int(v) for v in box), LEFT if side == 0 else RIGHT,
                            KIND_OVERTAKING, 0, len(jj),
                            (_q16_mean(sdx, len(jj), level), _q16_mean(sdy, len(jj), level)), 1, cy))
    return ar, hyps


@dataclass
class Seed:
    id: int
    left: float
    top: float
    width: int
    height: int
    age: int = 0


def _overlap(a, b) -> bool:
    return a[0] <= b[2] and b[0] <= a[2] and a[1] <= b[3] and b[1] <= a[3]


class FlowOracle:
    """Per-frame overtaking detection with the state the C stage keeps: the
    previous level image and the hand-over tracks."""

    def __init__(self, cfg, max_hyps: int = 16, max_seeds: int = 4, max_blobs: int = 32):
        self.cfg = cfg
        self.max_hyps, self.max_seeds, self.max_blobs = max_hyps, max_seeds, max_blobs
        self.blobs: list[list[Hyp]] = [[], []]      # the last frame's blobs per side
        self.prev = None
        self.size = None
        self.level = None
        self.seeds: list[Seed] = []
        self.next_id = 1
        self.areas: list[Area] = []
        self.max_rects = 2 + 2 * max_seeds      # VT_FLOW_MAX_RECTS
        self.prev_rects: list[tuple] = []       # the computed parts of the previous level image

    def reset(self):
        self.prev, self.size, self.seeds, self.areas = None, None, [], []
        self.blobs = [[], []]
        self.prev_rects = []

    def _add_rect(self, rects: list, r) -> None:
        """Record a non-empty rectangle; past max_rects the last one grows to cover it."""
        if r[0] >= r[2] or r[1] >= r[3]:
            return
        if len(rects) < self.max_rects:
            rects.append(tuple(r))
        else:
            q = rects[-1]
            rects[-1] = (min(q[0], r[0]), min(q[1], r[1]), max(q[2], r[2]), max(q[3], r[3]))

    def _seed_span(self, sd: Seed, lw: int, lh: int):
        """Level-px span (bx0, by0, bx1, by1) of a hand-over track's box, clamped to the image."""
        lv = self.level
        left, top = math.floor(sd.left + 0.5), math.floor(sd.top + 0.5)
        return (min(max(left // 2 ** lv, 0), lw), min(max(top // 2 ** lv, 0), lh),
                min(max((left + sd.width - 1) // 2 ** lv + 1, 0), lw),
                min(max((top + sd.height - 1) // 2 ** lv + 1, 0), lh))

    def step(self, frame: np.ndarray):
        """(ready, hypotheses); a first frame only stores its level image."""
        cfg = self.cfg
        h, w = frame.shape
        if self.prev is not None and (w, h) != self.size:
            raise ValueError(f"frame: size {w}x{h} differs from the previous frame's "
                             f"{self.size[0]}x{self.size[1]}; reset() first")
        cur = level_image(frame, cfg.level)
        lh, lw = cur.shape
        rects = []
        for side in (0, 1):
            ar = lateral_area(cfg, lw, lh, side)
            if cfg.sides & (1 << side) and ar.gw * ar.gh > 0:
                self._add_rect(rects, area_rect(cfg, ar, lw, lh))
        restart = (self.prev is None or self.level != cfg.level
                   or not all(_inside(r, self.prev_rects) for r in rects))
        if restart:
            self.prev, self.size, self.level, self.seeds, self.areas = cur, (w, h), cfg.level, [], []
            self.blobs = [[], []]
            self.prev_rects = rects
            return False, []
        for sd in self.seeds:   # what the track's step reads now, and its cells next frame
            b = self._seed_span(sd, lw, lh)
            sx, sy = cfg.search_x + 1, cfg.search_y + 1
            self._add_rect(rects, _clip((b[0] - sx, b[1] - sy, b[2] + sx, b[3] + sy), lw, lh))
        hyps, self.areas = [], []
        for side in (0, 1):
            if cfg.sides & (1 << side):
                ar, hs = area_flow(cfg, cur, self.prev, side, cfg.level, w, h, self.max_blobs)
            else:
                ar, hs = Area(0, 0, 0, 0), []
            self.areas.append(ar)
            # persistence: 1 + the age of the previous frame's overlapping blobs on this side
            for b in hs:
                ages = [p.age for p in self.blobs[side] if _overlap(p.box, b.box)]
                b.age = 1 + max(ages, default=0)
            self.blobs[side] = hs
            hyps += [b for b in hs if b.age >= cfg.min_age]
        hyps = hyps[: self.max_hyps]
        kept = []
        for sd in self.seeds:
            hp = self._seed_step(sd, cur, self.prev)
            if hp is not None:
                kept.append(sd)
                if len(hyps) < self.max_hyps:
                    hyps.append(hp)
        self.seeds = kept
        self.prev = cur
        self.prev_rects = rects
        return True, hyps

    def seed(self, box, frame: np.ndarray | None = None) -> int:
        """Start a hand-over track (vt_flow_seed); with `frame`, the last frame stepped, its
        box counts as computed in the previous level image too (vt_flow_seed_frame)."""
        l, t, r, b = (int(v) for v in box)
        if self.prev is None:
            raise ValueError("seed: no previous frame")
        w, h = self.size
        if frame is not None and frame.shape != (h, w):
            raise ValueError(f"frame: shape {frame.shape} is not the last frame's {(h, w)}")
        if l > r or t > b or r < 0 or b < 0 or l >= w or t >= h:
            raise ValueError(f"box: {box} does not overlap the {w}x{h} frame")
        if len(self.seeds) >= self.max_seeds:
            raise ValueError("seed: all hand-over slots are in use")
        sid = self.next_id
        self.next_id += 1
        self.seeds.append(Seed(sid, float(l), float(t), r - l + 1, b - t + 1, 0))
        if frame is not None:
            lh, lw = self.prev.shape
            self._add_rect(self.prev_rects, self._seed_span(self.seeds[-1], lw, lh))
        return sid

    def unseed(self, sid: int) -> None:
        """Stop the hand-over track `sid` (vt_flow_unseed); ValueError if none is live."""
        for k, sd in enumerate(self.seeds):
            if sd.id == sid:
                del self.seeds[k]
                return
        raise ValueError(f"unseed: no hand-over track with id {sid}")

    def _seed_step(self, sd: Seed, cur: np.ndarray, prev: np.ndarray):
        """Move a hand-over track by the mean motion of the textured cells inside its box
        (a flat cell matches at zero motion whatever moved: the aperture problem)."""
        cfg, lv, n = self.cfg, self.level, self.cfg.cell
        lh, lw = cur.shape
        w, h = self.size
        bx0, by0, bx1, by1 = self._seed_span(sd, lw, lh)
        vecs = []
        for j in range((by1 - by0) // n):
            for i in range((bx1 - bx0) // n):
                x, y = bx0 + i * n, by0 + j * n
                if not _inside((x, y, x + n, y + n), self.prev_rects):
                    continue        # that part of the previous frame was never computed
                block = prev[by0 + j * n:by0 + (j + 1) * n, bx0 + i * n:bx0 + (i + 1) * n].astype(np.int64)
                if np.abs(np.diff(block, axis=1)).sum() < cfg.min_texture * n * (n - 1):
                    continue        # flat: it matches at zero motion whatever moved
                dx, dy, s = best_match(prev, cur, bx0 + i * n, by0 + j * n, n,
                                       cfg.search_x, cfg.search_y)
                if s <= cfg.max_sad_per_px * n * n:
                    vecs.append((-dx, -dy))
        if not vecs:
            return None
        mx = _q16_mean(sum(v[0] for v in vecs), len(vecs), lv)
        my = _q16_mean(sum(v[1] for v in vecs), len(vecs), lv)
        sd.left += mx
        sd.top += my
        left, top = math.floor(sd.left + 0.5), math.floor(sd.top + 0.5)
        vis = min(max(left + sd.width, 0), w) - min(max(left, 0), w)
        if vis * 1000 < cfg.seed_min_visible_permille * sd.width or vis <= 0 or top >= h or top + sd.height <= 0:
            return None
        box = (min(max(left, 0), w - 1), min(max(top, 0), h - 1),
               min(max(left + sd.width - 1, 0), w - 1), min(max(top + sd.height - 1, 0), h - 1))
        side = LEFT if box[0] + box[2] < w - 1 else RIGHT
        sd.age += 1
        return Hyp(box, side, KIND_HANDOVER, sd.id, len(vecs), (mx, my), sd.age, (box[1] + box[3]) // 2)
