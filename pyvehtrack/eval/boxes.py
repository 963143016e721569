"""The one box IoU of the evaluation code.

Convention: a box is [left, top, right, bottom] in continuous pixel coordinates, its area
(right - left) * (bottom - top). This is the convention of KITTI labels, TrackEval and
pycocotools. The C core's boxes are *inclusive* integer pixel ranges (right and bottom are
the last pixel inside): turn them into this convention with `from_inclusive` first.
(`pyvehtrack.reference.tracker.box_iou` is different on purpose: it mirrors the C tracker's
integer arithmetic on inclusive boxes, as the oracle must; it is not an evaluation metric.)
"""
from __future__ import annotations

import numpy as np

__all__ = ["iou", "iou_matrix", "from_inclusive"]


def from_inclusive(boxes) -> np.ndarray:
    """Inclusive [l, t, r, b] pixel boxes (one box or an (N, 4) array) as continuous boxes
    [l, t, r + 1, b + 1], float64, same shape."""
    b = np.array(boxes, dtype=np.float64)
    b[..., 2:4] += 1.0
    return b


def _boxes(x, name: str) -> np.ndarray:
    a = np.asarray(x, np.float64)
    if a.size % 4:
        raise ValueError(f"{name}: expected boxes of 4 numbers [l, t, r, b], got shape {a.shape}")
    return a.reshape(-1, 4)


def iou_matrix(a, b) -> np.ndarray:
    """IoU of every box in a (N, 4) with every box in b (M, 4): an (N, M) float64 array.
    Empty or inverted boxes have area 0; a pair with zero union has IoU 0."""
    a, b = _boxes(a, "a"), _boxes(b, "b")
    lt = np.maximum(a[:, None, :2], b[None, :, :2])
    rb = np.minimum(a[:, None, 2:], b[None, :, 2:])
    inter = np.prod(np.clip(rb - lt, 0, None), axis=2)
    area_a = np.prod(np.clip(a[:, 2:] - a[:, :2], 0, None), axis=1)
    area_b = np.prod(np.clip(b[:, 2:] - b[:, :2], 0, None), axis=1)
    union = area_a[:, None] + area_b[None, :] - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1), 0.0)


def iou(a, b) -> float:
    """IoU of two boxes (continuous convention, see the module doc)."""
    return float(iou_matrix(a, b)[0, 0])
