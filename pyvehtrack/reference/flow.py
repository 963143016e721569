"""Float oracle of c/flow.c: overtaking vehicles by SAD block matching in the
lateral areas of the image (IVVI paper, sec. 3), written from the paper.

The paper: optical flow by block similarity (sum of absolute differences) in the
lateral areas where overtaking vehicles appear; flow computed only for pixels whose
difference with the previous image exceeds a threshold; vectors filtered by range
(magnitude), direction (an overtaking vehicle moves against the background, which
flows outward as the ego car passes it) and the size of the blobs of equal motion;
a blob over an area threshold is an overtaking vehicle. When the ego car overtakes
another vehicle, the tracker hands that vehicle to this module.

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
        nlab, labels = cv2.connectedComponents(acc, connectivity=4)
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

    def reset(self):
        self.prev, self.size, self.seeds, self.areas = None, None, [], []
        self.blobs = [[], []]

    def step(self, frame: np.ndarray):
        """(ready, hypotheses); a first frame only stores its level image."""
        cfg = self.cfg
        h, w = frame.shape
        if self.prev is not None and (w, h) != self.size:
            raise ValueError(f"frame: size {w}x{h} differs from the previous frame's "
                             f"{self.size[0]}x{self.size[1]}; reset() first")
        cur = level_image(frame, cfg.level)
        if self.prev is None or self.level != cfg.level:
            self.prev, self.size, self.level, self.seeds, self.areas = cur, (w, h), cfg.level, [], []
            self.blobs = [[], []]
            return False, []
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
        return True, hyps

    def seed(self, box) -> int:
        l, t, r, b = (int(v) for v in box)
        if self.prev is None:
            raise ValueError("seed: no previous frame")
        w, h = self.size
        if l > r or t > b or r < 0 or b < 0 or l >= w or t >= h:
            raise ValueError(f"box: {box} does not overlap the {w}x{h} frame")
        if len(self.seeds) >= self.max_seeds:
            raise ValueError("seed: all hand-over slots are in use")
        sid = self.next_id
        self.next_id += 1
        self.seeds.append(Seed(sid, float(l), float(t), r - l + 1, b - t + 1, 0))
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
        left, top = math.floor(sd.left + 0.5), math.floor(sd.top + 0.5)
        bx0 = min(max(left // 2 ** lv, 0), lw)
        by0 = min(max(top // 2 ** lv, 0), lh)
        bx1 = min(max((left + sd.width - 1) // 2 ** lv + 1, 0), lw)
        by1 = min(max((top + sd.height - 1) // 2 ** lv + 1, 0), lh)
        vecs = []
        for j in range((by1 - by0) // n):
            for i in range((bx1 - bx0) // n):
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
