"""Float reference of the multi-vehicle tracker (thesis ch. 3, sec. 3.5-3.6); the
specification of c/tracker.c, step for step, with filterpy's KalmanFilter in place
of the fixed-point one.

Per frame: every live track predicts its bottom edge [x1, y1, x2] (6-state model,
thesis eq. 3.17), searches the ROI around the predicted box (track_search) and is
updated when the measurement passes the gate, else coasts. On detection frames,
detections are matched to tracks by IoU (greedy, best pair first); a track no
detection matches survives only if its 16x16 template still correlates with the
same box in the new frame; unmatched detections that overlap no track start
tentative tracks in the first free slot.

With measurement=MEAS_ROI_EDGES the ROI search runs, and where it fails on a confirmed
or coasting track it measured before (not tm_only, not flat), the edge curves below
measure it (kept fresh on every measured frame); the template stays the one the search or a
detection last took, so the correlation check of the next detection frame asks for that vehicle.
With measurement=MEAS_EDGE_CURVES the ROI search is replaced by the GIST paper's
(sec. III.B): the track's edge curves at its last good frame are matched to the new
frame's curves by chamfer distance (reference/edge_track.py), and the template
is refreshed from the box after every update.

Template tracking (tmatch_radius > 0, GIST paper sec. III.B tracks by matching): when
the measurement of a tentative track (or of a confirmed one that no real measurement
has taken yet: tm_only, confirmed by detections alone) fails, the box (template's size) near the prediction whose 16x16 resample correlates
best with the track's template (taken at its last real measurement) measures it if
the correlation reaches tmatch_ncc_permille / 1000; that is neither a hit nor a miss.
Parts (part_permille > 0): a detection mostly inside a live track starts none, a
track mostly inside a larger unmatched detection restarts on it (same id), and a
track mostly inside a larger live track is dropped. min_width drops thin tracks.
Scale consistency (scale_tol_permille > 0, once set_horizon gave the horizon row; IVVI
paper sec. 4's road restriction over time): a vehicle's width over its bottom row's
distance below the horizon stays what it was at the last detection the track took; a
measurement that changes it by more than the tolerance (plus 2 px in width and bottom)
is refused, and a track whose frame brought no real measurement is dropped when its
predicted box fails the same test.
Bottom snap (snap_bottom, thesis sec. 2.4.2's verification gives the box): a detection
that starts, re-anchors or updates a track first has its bottom moved down to the row
the ROI search finds under it (sides within the side gate, at most the bottom gate
down), so a classifier box ending above the wheels and the next frames' search agree.
Birth search (birth_search): a new track starts on the box the ROI search settles on in
its birth frame (repeated from the snapped detection until it stops moving, at most
birth_search times), so a 3/4 view's box over side and rear starts on the rear face the
later frames measure instead of drifting toward it.
Rear views only (search_max_aspect_permille): the ROI search measures a vehicle's rear
(shadow and two sides); a box wider than search_max_aspect_permille / 1000 times its
height (a side view, a roof over a barrier) is not searched (no snap, no birth search,
no per-frame measurement): its template carries it and only detections confirm it."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from filterpy.kalman import KalmanFilter

from . import edge_track as redge
from . import image as rimg
from .kalman import bottom_edge_filter
from .track_search import SearchCfg, Sides, track_search
from ..shared import (  # noqa: F401  (shared plain types)
    MEAS_EDGE_CURVES, MEAS_ROI_EDGES, MEAS_ROI_SEARCH, ModelCfg, TrackerCfg)

FREE, TENTATIVE, CONFIRMED, COASTING = 0, 1, 2, 3
TEMPLATE = 16
MAX_DETS = 256


def _round(v: float) -> int:
    return math.floor(v + 0.5)


@dataclass
class Track:
    id: int = 0
    state: int = FREE
    hits: int = 0
    misses: int = 0
    age: int = 0
    aspect_q8: int = 256
    box: tuple = (0, 0, 0, 0)
    vx: float = 0.0
    vy: float = 0.0
    sides: Sides = field(default_factory=Sides)
    kf: KalmanFilter | None = None
    tmpl: np.ndarray | None = None
    edges: redge.Template | None = None
    tm_frames: int = 0
    tmpl_box: tuple = (0, 0, 0, 0)
    ref_w: int = 0                 # width and bottom row after the last detection taken
    ref_b: int = 0
    tm_only: bool = True           # no real measurement (ROI search, edge curves) took it yet

    def box_from_state(self):
        x = self.kf.x[:, 0]
        l, b, r = _round(x[0]), _round(x[1]), _round(x[2])
        if r < l:
            l = r = (l + r) // 2
        w = r - l + 1
        h = max(1, (w * self.aspect_q8 + 128) >> 8)
        self.box = (l, b - h + 1, r, b)
        self.vx = (x[3] + x[5]) / 2
        self.vy = x[4]


def sample(img: np.ndarray, box) -> np.ndarray:
    """Nearest-pixel T x T resample of the box at each cell's centre, clamped."""
    l, t, r, b = box
    w, h = r - l + 1, b - t + 1
    i = np.arange(TEMPLATE)
    ys = np.clip(t + ((2 * i + 1) * h) // (2 * TEMPLATE), 0, img.shape[0] - 1)
    xs = np.clip(l + ((2 * i + 1) * w) // (2 * TEMPLATE), 0, img.shape[1] - 1)
    return img[np.ix_(ys, xs)]


def iou_frac(a, b) -> tuple[int, int]:
    iw = min(a[2], b[2]) - max(a[0], b[0]) + 1
    ih = min(a[3], b[3]) - max(a[1], b[1]) + 1
    inter = iw * ih if iw > 0 and ih > 0 else 0
    uni = (a[2] - a[0] + 1) * (a[3] - a[1] + 1) + (b[2] - b[0] + 1) * (b[3] - b[1] + 1) - inter
    return inter, uni


def _area(b) -> int:
    return (b[2] - b[0] + 1) * (b[3] - b[1] + 1)


def _inside(inner, outer, part_permille: int) -> bool:
    """At least part_permille of inner's area lies inside outer."""
    return iou_frac(inner, outer)[0] * 1000 >= part_permille * _area(inner)


def box_iou(a, b) -> float:
    """IoU of two inclusive [left, top, right, bottom] boxes, as a float."""
    inter, uni = iou_frac(a, b)
    return inter / uni if uni > 0 else 0.0


class Tracker:
    def __init__(self, cfg: TrackerCfg | None = None, max_tracks: int = 16,
                 max_edge_points: int = 256, max_edge_pixels: int = 65536, coord_lim: int = 7680):
        self.cfg = cfg or TrackerCfg()
        # the C build's capacities (VT_EDGE_MAX_POINTS, VT_EDGE_MAX_PIXELS, 4 * max(VT_MAX_*))
        self.max_edge_points = max_edge_points
        self.max_edge_pixels = max_edge_pixels
        self.coord_lim = coord_lim
        self.tracks = [Track() for _ in range(max_tracks)]
        self.next_id = 1
        self.frame = 0
        self.dropped_full = 0
        self.horizon: int | None = None    # set_horizon; None: no scale check

    def set_horizon(self, row: int | None) -> None:
        """The horizon row for the scale check from the next step on (None: off)."""
        self.horizon = None if row is None else int(row)

    def _scale_ok(self, t: Track, box) -> bool:
        """c/tracker.c's vt__scale_ok: w / (b - h) within scale_tol_permille of the
        reference, on the same integers (no rounding to reproduce)."""
        tol = self.cfg.scale_tol_permille
        if tol == 0 or self.horizon is None or t.ref_w < 1:
            return True
        r = t.ref_b - self.horizon
        if r < 1:
            return True
        b = box[3] - self.horizon
        d = (box[2] - box[0] + 1) * r - t.ref_w * b
        return abs(d) * 1000 <= tol * t.ref_w * max(b, 0) + 2000 * (t.ref_w + r)

    def drop(self, tid: int) -> None:
        """End the live track `tid` now (c/tracker.c's vt_tracker_drop); ValueError if none."""
        for t in self.tracks:
            if t.state != FREE and t.id == tid:
                t.state = FREE
                return
        raise ValueError(f"drop: no live track with id {tid}")

    def _hit(self, t: Track, img, keep_tmpl: bool = False):
        t.hits += 1
        t.misses = 0
        t.tm_frames = 0
        if t.state == TENTATIVE and t.hits >= self.cfg.confirm_hits:
            t.state = CONFIRMED
        elif t.state == COASTING:
            t.state = CONFIRMED
        if not keep_tmpl:
            self._set_tmpl(t, img)

    def _margin(self, box) -> int:
        w = box[2] - box[0] + 1
        return max(self.cfg.roi_margin_min, (w * self.cfg.roi_margin_permille) // 1000)

    def _edge_map(self, img, roi):
        """edge_map, or None where C's vt_edge_map fails (empty, over capacity, out of range)."""
        lim = self.coord_lim
        if min(roi) < -lim or max(roi) > lim:
            return None
        c = redge.clip_roi(img.shape, roi)
        if c is None or (c[2] - c[0] + 1) * (c[3] - c[1] + 1) > self.max_edge_pixels:
            return None
        return redge.edge_map(img, self.cfg.edge, roi)

    def _edge_refresh(self, t: Track, img):
        """Template: the curve points in the box, found in the box widened by the margin."""
        l, top, r, b = t.box
        m = self._margin(t.box)
        em = self._edge_map(img, (l - m, top - m, r + m, b + m))
        t.edges = redge.template_set(em, t.box, self.max_edge_points) if em is not None else \
            redge.Template(np.zeros(0, np.int64), np.zeros(0, np.int64), t.box)

    def _edge_measure(self, t: Track, img, m):
        """The template box moved by the best displacement near the prediction, or None."""
        if t.edges is None or len(t.edges.xs) == 0:
            return None
        tl, tt, tr_, tb = t.edges.box
        cx, cy = t.box[0] - tl, t.box[3] - tb
        if abs(cx) > 8192 or abs(cy) > 8192:
            return None
        e = self.cfg.edge
        pad = e.radius + m
        # the crop also holds the template grown by the largest scale
        grow = ((tr_ - tl + tb - tt + 2) * e.scale_steps * e.scale_step_q8) // 256 + 1
        em = self._edge_map(img, (tl + cx - pad - grow, tt + cy - pad - grow,
                                  tr_ + cx + pad + grow, tb + cy + pad))
        if em is None:
            return None
        dx, dy, s, _, found = redge.match(em, e, t.edges, cx, cy)
        return redge.scale_box(t.edges.box, s, dx, dy) if found else None

    @staticmethod
    def _set_tmpl(t: Track, img):
        t.tmpl = sample(img, t.box)
        t.tmpl_box = t.box

    def _tmatch(self, t: Track, img):
        """The shifted predicted box correlating best with the template (first of equal
        Q14-rounded scores, dy outer), or None below the threshold or when all are flat."""
        rad = self.cfg.tmatch_radius
        # the template's box, bottom centre on the predicted one, then shifted
        l, top, r, b = t.tmpl_box
        ox = (t.box[0] + t.box[2]) // 2 - (l + r) // 2
        oy = t.box[3] - b
        best = None
        for dy in range(-rad, rad + 1):
            for dx in range(-rad, rad + 1):
                sh = (l + ox + dx, top + oy + dy, r + ox + dx, b + oy + dy)
                v = rimg.ncc(t.tmpl, sample(img, sh))
                if math.isnan(v):
                    continue
                q = math.floor(v * 16384 + 0.5)  # C's Q14 grid
                if best is None or q > best[0]:
                    best = (q, sh)
        if best is None or best[0] * 1000 < self.cfg.tmatch_ncc_permille * 16384:
            return None
        return best[1]

    def _search_roi(self, box):
        """c/tracker.c's vt__search_roi: the verification step's ROI around `box` (the
        bottom edge widened by the margin, half the edge length high; below, as far as
        the bottom gate lets the edge move), the margin, the side gate, the bottom gate."""
        c = self.cfg
        l, _, r, b = box
        w = r - l + 1
        m = max(c.roi_margin_min, (w * c.roi_margin_permille) // 1000)
        gate_b = max(4, (w * c.gate_bottom_permille) // 1000)
        return (l - m, b - w // 2, r + m, b + max(m, gate_b)), m, max(8, (w * c.gate_permille) // 1000), gate_b

    def _flat(self, box) -> bool:
        """c/tracker.c's vt__flat: a box flatter than a rear view (not searched)."""
        c = self.cfg
        return c.search_max_aspect_permille > 0 and c.measurement != MEAS_EDGE_CURVES and \
            (box[2] - box[0] + 1) * 1000 > c.search_max_aspect_permille * (box[3] - box[1] + 1)

    def _snap(self, img, d, grads):
        """snap_bottom: the detection with its bottom moved down to the row the ROI
        search finds under it, searched as a track with the box `d` would search its next frame."""
        c = self.cfg
        if not c.snap_bottom or self._flat(d):
            return d
        l, top, r, b = d
        roi, _, gate, gate_b = self._search_roi(d)
        meas = track_search(img, c.search, roi, None, grads)
        if meas is not None and abs(meas[0] - l) <= gate and abs(meas[2] - r) <= gate and \
                b < meas[3] <= b + gate_b:
            return (l, top, r, meas[3])
        return d

    def _birth_search(self, img, d, grads):
        """birth_search: the ROI search repeated on the birth frame from the (snapped)
        detection until it stops moving the box (left, right, bottom; the top stays)."""
        c = self.cfg
        l, top, r, b = d
        for _ in range(0 if self._flat(d) else c.birth_search):
            roi, _, gate, gate_b = self._search_roi((l, top, r, b))
            meas = track_search(img, c.search, roi, None, grads)
            if meas is None or abs(meas[0] - l) > gate or abs(meas[2] - r) > gate or \
                    abs(meas[3] - b) > gate_b or meas[2] <= meas[0] or meas[3] <= top:
                break
            if (meas[0], meas[2], meas[3]) == (l, r, b):
                break
            l, r, b = meas[0], meas[2], meas[3]
        return (l, top, r, b)

    def _reanchor(self, t: Track, img, d, measured: bool) -> None:
        """A part-track restarts on the whole detection, keeping id, hits and state."""
        c = self.cfg
        l, top, r, b = d
        w = r - l + 1
        t.kf = bottom_edge_filter(l, b, r, **vars(c.model))
        t.aspect_q8 = ((b - top + 1) * 256 + w // 2) // w
        t.ref_w, t.ref_b = w, b
        t.sides = Sides(True, l, r, c.init_max_change, c.init_max_change)
        t.box_from_state()
        if not measured:
            self._hit(t, img)
        else:
            self._set_tmpl(t, img)
        if c.measurement != MEAS_ROI_SEARCH:
            self._edge_refresh(t, img)

    def _update(self, t: Track, left, bottom, right):
        t.kf.update(np.array([[left], [bottom], [right]], dtype=float))
        t.box_from_state()

    def _start(self, t: Track, img, d):
        c = self.cfg
        l, top, r, b = (int(v) for v in d)
        w, h = r - l + 1, b - top + 1
        t.__init__()
        t.kf = bottom_edge_filter(l, b, r, **vars(c.model))
        t.id = self.next_id
        self.next_id += 1
        t.state = CONFIRMED if c.confirm_hits <= 1 else TENTATIVE
        t.hits = 1
        t.aspect_q8 = (h * 256 + w // 2) // w
        t.ref_w, t.ref_b = w, b
        t.sides = Sides(True, l, r, c.init_max_change, c.init_max_change)
        t.box_from_state()
        self._set_tmpl(t, img)
        if c.measurement != MEAS_ROI_SEARCH:
            self._edge_refresh(t, img)

    def step(self, img: np.ndarray, detection_frame: bool = False, dets=()):
        c = self.cfg
        img = np.asarray(img, np.uint8)
        dets = [tuple(int(v) for v in d) for d in (dets if detection_frame else [])]
        self.frame += 1
        grads = (rimg.sobel_x(img), rimg.sobel_y(img))
        n = len(self.tracks)
        measured = [False] * n
        matched = [False] * n
        for i, t in enumerate(self.tracks):
            if t.state == FREE:
                continue
            t.age += 1
            t.kf.predict()
            t.box_from_state()
            l, top, r, b = t.box
            roi, m, gate, gate_b = self._search_roi(t.box)
            sides = Sides(**vars(t.sides))
            flat = self._flat(t.box)     # False with edge curves
            if c.measurement == MEAS_EDGE_CURVES:
                meas = self._edge_measure(t, img, m)
            elif flat:
                meas = None      # not a rear view: only the template measures it
            else:
                meas = track_search(img, c.search, roi, sides, grads)
            def taken(meas):   # found, within the gates of the predicted box, on the road's scale
                return meas is not None and abs(meas[0] - l) <= gate and abs(meas[2] - r) <= gate \
                    and abs(meas[3] - b) <= gate_b and self._scale_ok(t, meas)
            ok = taken(meas)
            by_edges = False
            if not ok and c.measurement == MEAS_ROI_EDGES and not flat and not t.tm_only \
                    and t.state in (CONFIRMED, COASTING):
                # the search failed on a rear view it measured before: its edge curves
                meas = self._edge_measure(t, img, m)
                sides = Sides(**vars(t.sides))   # the failed search's side memory is not kept
                ok = by_edges = taken(meas)
            if ok:
                self._update(t, meas[0], meas[3], meas[2])
                t.sides = sides
                t.tm_only = False
                measured[i] = True
                # after the curves, the template stays the rear last seen by the search or a
                # detection (the next detection frame's correlation check asks for that vehicle)
                self._hit(t, img, keep_tmpl=by_edges)
                if c.measurement != MEAS_ROI_SEARCH:
                    self._edge_refresh(t, img)
            elif c.tmatch_radius > 0 and (t.state == TENTATIVE or (t.state == CONFIRMED and (t.tm_only or flat))) \
                    and (tm := self._tmatch(t, img)) is not None and self._scale_ok(t, tm):
                self._update(t, tm[0], tm[3], tm[2])
                t.tm_frames += 1
            else:
                t.misses += 1
                if t.state == CONFIRMED:
                    t.state = COASTING
        if detection_frame:
            match_of_det = [-1] * len(dets)
            while True:
                best = None  # (inter, uni, i, j)
                for i, t in enumerate(self.tracks):
                    if t.state == FREE or matched[i]:
                        continue
                    for j, d in enumerate(dets):
                        if match_of_det[j] >= 0:
                            continue
                        inter, uni = iou_frac(t.box, d)
                        if inter * 1000 >= c.match_iou_permille * uni and \
                                (best is None or inter * best[1] > best[0] * uni):
                            best = (inter, uni, i, j)
                if best is None:
                    break
                _, _, bi, bj = best
                matched[bi] = True
                match_of_det[bj] = bi
                # the detection is a second measurement of the bottom edge
                t, d = self.tracks[bi], self._snap(img, dets[bj], grads)
                dw = d[2] - d[0] + 1
                self._update(t, d[0], d[3], d[2])
                t.aspect_q8 = ((d[3] - d[1] + 1) * 256 + dw // 2) // dw
                t.box_from_state()
                t.ref_w, t.ref_b = t.box[2] - t.box[0] + 1, t.box[3]   # the filtered box
                t.sides.prev_left, t.sides.prev_right = d[0], d[2]
                if not measured[bi]:
                    measured[bi] = True
                    self._hit(t, img)
                else:
                    self._set_tmpl(t, img)
                if c.measurement != MEAS_ROI_SEARCH:
                    self._edge_refresh(t, img)
            if c.part_permille > 0:
                # a part-track takes the first unmatched larger detection holding it
                for i, t in enumerate(self.tracks):
                    if t.state == FREE or matched[i]:
                        continue
                    for j, d in enumerate(dets):
                        if match_of_det[j] < 0 and _area(d) > _area(t.box) and \
                                _inside(t.box, d, c.part_permille):
                            matched[i] = True
                            match_of_det[j] = i
                            self._reanchor(t, img, self._snap(img, d, grads), measured[i])
                            measured[i] = True
                            break
            for i, t in enumerate(self.tracks):
                if t.state == FREE or matched[i]:
                    continue
                r = rimg.ncc(t.tmpl, sample(img, t.box))
                # C compares the Q14-rounded coefficient; compare on that grid too.
                if math.isnan(r) or math.floor(r * 16384 + 0.5) < round(c.keep_ncc * 16384):
                    t.state = FREE
            for j, d in enumerate(dets):
                if match_of_det[j] >= 0:
                    continue
                overlaps = False
                for t in self.tracks:
                    if t.state != FREE:
                        inter, uni = iou_frac(t.box, d)
                        if inter * 10 >= uni or (c.part_permille > 0 and
                                                 inter * 1000 >= c.part_permille * _area(d)):
                            overlaps = True
                            break
                if overlaps or d[2] - d[0] + 1 < c.min_width:
                    continue
                free = next((k for k, t in enumerate(self.tracks) if t.state == FREE), None)
                if free is None:
                    self.dropped_full += 1
                    continue
                self._start(self.tracks[free], img, self._birth_search(img, self._snap(img, d, grads), grads))
        h, w = img.shape
        for t in self.tracks:
            if t.state == FREE:
                continue
            l, top, r, b = t.box
            if t.misses > c.max_coast or (t.state == TENTATIVE and t.misses >= 2) or \
                    r < 0 or l >= w or b < 0 or top >= h or t.tm_frames > c.tmatch_max or \
                    r - l + 1 < c.min_width or \
                    ((t.misses > 0 or t.tm_frames > 0) and not self._scale_ok(t, t.box)):
                t.state = FREE
        if c.part_permille > 0:
            for i, t in enumerate(self.tracks):
                if t.state == FREE:
                    continue
                for k, o in enumerate(self.tracks):
                    if k == i or o.state == FREE:
                        continue
                    ao, at = _area(o.box), _area(t.box)
                    if (ao > at or (ao == at and k < i)) and _inside(t.box, o.box, c.part_permille):
                        t.state = FREE
                        break
        return [(t.id, t.state, t.box, t.vx, t.vy) for t in self.tracks if t.state != FREE]
