"""KITTI tracking labels: reading them into one structured array, and writing tracks.

The format (one object per line, 17 or 18 space-separated fields):
`frame id type truncated occluded alpha left top right bottom h w l x y z rotation_y [score]`;
a tracker's result file fills the 3D fields with -1 / -1000 / -10, so TrackEval and other
tools read it as is. Boxes are continuous pixel coordinates (see `pyvehtrack.eval.boxes`).
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

__all__ = ["LABEL_DTYPE", "read_kitti", "to_labels", "track_line", "write_tracks_kitti"]

LABEL_DTYPE = np.dtype([("frame", "i4"), ("id", "i4"), ("cls", "U16"), ("truncated", "i4"), ("occluded", "i4"),
                        ("left", "f8"), ("top", "f8"), ("right", "f8"), ("bottom", "f8"), ("score", "f8")])

# ---------------------------------------------------------------------------------------------------------
# loading

def _int_field(text: str) -> int:
    """An integer column: "12" or "12.0" (some tools write floats), never "12.5"."""
    v = float(text)
    if v != int(v):
        raise ValueError(f"{text!r} is not an integer")
    return int(v)


def read_kitti(path: str | os.PathLike) -> np.ndarray:
    """Read a KITTI tracking label/result file into a LABEL_DTYPE array (score NaN where absent).
    ValueError naming the file and line for anything that is not a KITTI line."""
    try:
        lines = open(os.fspath(path), encoding="utf-8").read().splitlines()
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file (KITTI labels are text)") from None
    rows = []
    for n, line in enumerate(lines, 1):
        parts = line.split()
        if not parts or parts[0].startswith('#'):
            continue
        if len(parts) < 10:
            raise ValueError(f"{path}:{n}: expected at least 10 columns (frame id type trunc occ alpha l t r b), "
                             f"got {len(parts)}")
        try:
            frame, tid = _int_field(parts[0]), _int_field(parts[1])
            trunc, occ = _int_field(parts[3]), _int_field(parts[4])
            l, t, r, b = (float(x) for x in parts[6:10])
            score = float(parts[17]) if len(parts) > 17 else np.nan
        except (ValueError, OverflowError) as exc:
            raise ValueError(f"{path}:{n}: cannot parse {line.strip()!r}: {exc}") from None
        if frame < 0:
            raise ValueError(f"{path}:{n}: negative frame number {frame}")
        rows.append((frame, tid, parts[2], trunc, occ, l, t, r, b, score))
    return np.array(rows, dtype=LABEL_DTYPE) if rows else np.zeros(0, LABEL_DTYPE)


def _from_struct(a: np.ndarray) -> np.ndarray:
    names = a.dtype.names
    need = ('frame', 'id', 'left', 'top', 'right', 'bottom')
    missing = [k for k in need if k not in names]
    if missing:
        raise ValueError(f"structured labels lack fields {missing}")
    out = np.zeros(len(a), LABEL_DTYPE)
    for k in need:
        out[k] = a[k]
    out['cls'] = a['cls'] if 'cls' in names else 'Car'
    for dst, cands in (('truncated', ('truncated', 'trunc_level')), ('occluded', ('occluded', 'occ_level'))):
        src = next((c for c in cands if c in names), None)
        out[dst] = a[src] if src is not None else 0
    out['score'] = a['score'] if 'score' in names else np.nan
    return out


def _from_numeric(a: np.ndarray) -> np.ndarray:
    if a.ndim != 2 or a.shape[1] < 6:
        raise ValueError(f"numeric labels must be (N, >= 6) [frame, id, l, t, r, b(, score)], got shape {a.shape}")
    out = np.zeros(len(a), LABEL_DTYPE)
    out['frame'], out['id'] = a[:, 0], a[:, 1]
    out['left'], out['top'], out['right'], out['bottom'] = a[:, 2], a[:, 3], a[:, 4], a[:, 5]
    out['cls'] = 'Car'
    out['score'] = a[:, 6] if a.shape[1] > 6 else np.nan
    return out


def _from_per_frame(tracks) -> np.ndarray:
    rows = []
    for t, items in enumerate(tracks):
        for it in (items if items is not None else []):
            it = tuple(it)
            if len(it) < 5:
                raise ValueError(f"frame {t}: a track must be (id, l, t, r, b[, score]), got {it!r}")
            score = float(it[5]) if len(it) > 5 else np.nan
            rows.append((t, int(it[0]), 'Car', 0, 0, *(float(x) for x in it[1:5]), score))
    return np.array(rows, dtype=LABEL_DTYPE) if rows else np.zeros(0, LABEL_DTYPE)


def to_labels(obj: Any) -> np.ndarray:
    """Any accepted input (see the module doc) as a LABEL_DTYPE array."""
    if isinstance(obj, (str, os.PathLike)):
        return read_kitti(obj)
    if hasattr(obj, 'gt') and isinstance(getattr(obj, 'gt'), np.ndarray):
        return _from_struct(obj.gt)
    if isinstance(obj, np.ndarray):
        if obj.dtype.names:
            return _from_struct(obj)
        if obj.size == 0:
            return np.zeros(0, LABEL_DTYPE)
        return _from_numeric(np.asarray(obj, dtype=np.float64))
    if isinstance(obj, (list, tuple)):
        return _from_per_frame(obj)
    raise TypeError(f"cannot read labels from {type(obj).__name__}")




# ---------------------------------------------------------------------------------------------------------
# writing

def track_line(frame: int, track_id: int, box, score: float, digits: int = 2,
               score_digits: int | None = None) -> str:
    """One KITTI tracking result line: `frame id Car -1 -1 -10 l t r b -1 -1 -1 -1000 -1000 -1000 -10
    score`, the box with `digits` decimals and the score with `score_digits` (default: `digits`)."""
    l, t, r, b = box
    sd = digits if score_digits is None else score_digits
    return (f"{int(frame)} {int(track_id)} Car -1 -1 -10 {l:.{digits}f} {t:.{digits}f} {r:.{digits}f} "
            f"{b:.{digits}f} -1 -1 -1 -1000 -1000 -1000 -10 {float(score):.{sd}f}")


def write_tracks_kitti(tracks, path: str | os.PathLike) -> None:
    """Write per-frame tracks [(id, l, t, r, b[, score]), ...] as KITTI tracking results
    (see track_line; 3 decimals for boxes, 4 for the score, score 1 when absent)."""
    with open(os.fspath(path), "w") as fh:
        for t, items in enumerate(tracks):
            for it in items:
                score = float(it[5]) if len(it) > 5 else 1.0
                fh.write(track_line(t, it[0], it[1:5], score, 3, 4) + "\n")
