"""SORT baseline: the tracker every pyvehtrack tracking score is shown beside.

Bewley, Ge, Ott, Ramos, Upcroft, "Simple Online and Realtime Tracking", ICIP 2016, re-implemented
from the paper with filterpy and SciPy (no code copied). Each track is a filterpy KalmanFilter on the
box state [u, v, s, r, u', v', s'] (centre, area, aspect ratio; constant velocity, r constant),
measured as [u, v, s, r]. Per frame: predict every track; match detections to predictions by IoU with
the Hungarian method (scipy.optimize.linear_sum_assignment), dropping pairs below `iou_threshold`;
update the matched tracks, start a track for every unmatched detection, delete tracks not matched for
more than `max_age` frames. A track is output in a frame when it was matched in that frame and has
`min_hits` consecutive matches (or the run is still in its first `min_hits` frames). The box output is
the filter's posterior. The noise settings are the ones published with SORT (measurement noise x10 on
area and ratio, initial velocity variance x1000, process noise x0.01 on the velocities)."""
from __future__ import annotations

from typing import Iterable

import numpy as np
from filterpy.kalman import KalmanFilter
from scipy.optimize import linear_sum_assignment

from .boxes import iou_matrix
from .kitti import write_tracks_kitti

__all__ = ["Sort", "run_sort", "iou_matrix", "write_tracks_kitti"]


def _to_z(box) -> np.ndarray:
    w, h = box[2] - box[0], box[3] - box[1]
    return np.array([[box[0] + w / 2], [box[1] + h / 2], [w * h], [w / h]])


def _to_box(x) -> np.ndarray:
    s, r = max(float(x[2, 0]), 0.0), max(float(x[3, 0]), 1e-9)
    w = np.sqrt(s * r)
    h = s / w if w > 0 else 0.0
    return np.array([x[0, 0] - w / 2, x[1, 0] - h / 2, x[0, 0] + w / 2, x[1, 0] + h / 2])


class _Track:
    def __init__(self, box, tid: int, score: float):
        kf = KalmanFilter(dim_x=7, dim_z=4)
        kf.F = np.eye(7)
        kf.F[0, 4] = kf.F[1, 5] = kf.F[2, 6] = 1.0
        kf.H = np.eye(4, 7)
        kf.R[2:, 2:] *= 10.0
        kf.P[4:, 4:] *= 1000.0          # unknown initial velocity
        kf.P *= 10.0
        kf.Q[-1, -1] *= 0.01
        kf.Q[4:, 4:] *= 0.01
        kf.x[:4] = _to_z(box)
        self.kf = kf
        self.id = tid
        self.score = score
        self.age_unmatched = 0          # frames since the last match
        self.streak = 0                 # consecutive matched frames

    def predict(self) -> np.ndarray:
        if self.kf.x[2, 0] + self.kf.x[6, 0] <= 0:     # the area would turn negative: stop shrinking
            self.kf.x[6, 0] = 0.0
        self.kf.predict()
        if self.age_unmatched > 0:
            self.streak = 0
        self.age_unmatched += 1
        return _to_box(self.kf.x)

    def update(self, box, score: float):
        self.kf.update(_to_z(box))
        self.age_unmatched = 0
        self.streak += 1
        self.score = score


class Sort:
    """Online SORT. `update(dets)` takes one frame's detections, (N, 4) [l, t, r, b] or (N, 5) with a
    score, and returns that frame's tracks as a list of (id, l, t, r, b, score), ids from 1, never
    reused within one Sort instance."""

    def __init__(self, max_age: int = 1, min_hits: int = 3, iou_threshold: float = 0.3):
        if max_age < 0 or min_hits < 0 or not 0.0 <= iou_threshold <= 1.0:
            raise ValueError("need max_age >= 0, min_hits >= 0, 0 <= iou_threshold <= 1")
        self.max_age, self.min_hits, self.iou_threshold = int(max_age), int(min_hits), float(iou_threshold)
        self.tracks: list[_Track] = []
        self.frame_count = 0
        self._next_id = 1

    def _associate(self, dets: np.ndarray, preds: np.ndarray):
        if len(dets) == 0 or len(preds) == 0:
            return [], list(range(len(dets)))
        iou = iou_matrix(dets, preds)
        rows, cols = linear_sum_assignment(-iou)
        pairs = [(r, c) for r, c in zip(rows, cols) if iou[r, c] >= self.iou_threshold]
        matched = {r for r, _ in pairs}
        return pairs, [d for d in range(len(dets)) if d not in matched]

    def update(self, dets) -> list[tuple]:
        dets = np.asarray(dets, dtype=np.float64)
        if dets.size == 0:
            dets = np.zeros((0, 5))
        if dets.ndim != 2 or dets.shape[1] not in (4, 5):
            raise ValueError(f"detections must be (N, 4) or (N, 5), got shape {dets.shape}")
        if not np.isfinite(dets).all():
            raise ValueError("detections must be finite")
        if dets.shape[1] == 4:
            dets = np.column_stack([dets, np.ones(len(dets))])
        dets = dets[(dets[:, 2] > dets[:, 0]) & (dets[:, 3] > dets[:, 1])]
        self.frame_count += 1
        preds = np.array([trk.predict() for trk in self.tracks]).reshape(-1, 4)
        alive = np.isfinite(preds).all(axis=1)
        self.tracks = [t for t, ok in zip(self.tracks, alive) if ok]
        preds = preds[alive]
        pairs, unmatched = self._associate(dets[:, :4], preds)
        for d, k in pairs:
            self.tracks[k].update(dets[d, :4], float(dets[d, 4]))
        for d in unmatched:
            self.tracks.append(_Track(dets[d, :4], self._next_id, float(dets[d, 4])))
            self._next_id += 1
        out = []
        for trk in self.tracks:
            if trk.age_unmatched == 0 and (trk.streak >= self.min_hits or self.frame_count <= self.min_hits):
                l, t, r, b = _to_box(trk.kf.x)
                out.append((trk.id, float(l), float(t), float(r), float(b), trk.score))
        self.tracks = [t for t in self.tracks if t.age_unmatched <= self.max_age]
        return sorted(out)


def run_sort(detections: Iterable, **kw) -> list[list[tuple]]:
    """SORT over a sequence: detections[t] is frame t's (N, 4|5) array; returns per frame the list of
    (id, l, t, r, b, score). Keyword arguments go to Sort."""
    s = Sort(**kw)
    return [s.update(d) for d in detections]
