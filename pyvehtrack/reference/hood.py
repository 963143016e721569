"""Integer twin of c/hood.c: the ego car's hood found in the frame (issue 8, item 4's
"hood rows excluded"; thesis sec. 2.4.2.1's shadow scan reads the hood's edge against the
road, dark above bright, as a vehicle's underside).

A hood's edge is one continuous, nearly level curve across most of the frame's width at
its bottom; a vehicle's shadow spans only the vehicle. So: in the bottom band of rows,
every col_step-th column x gives an edge strength per row y, |s(y+1) - s(y-1)| with s the
sum of columns x-1..x+1 (three times a gray step); a dynamic programme finds the
left-to-right path, moving at most max_jump rows between sampled columns, that maximises
the sum of the strengths clipped at 4 x the threshold (so one bright lane line does not
pull the path onto it). The hood is there when at least cover_permille of the path's
columns are strong (>= 3 x grad_min); its top is the highest row of the strong columns.

Everything is integer and the order of ties is fixed (lowest row first), so the C twin
agrees exactly. No float is involved: this module is the reference by its simplicity
(NumPy, one column at a time), not by other arithmetic.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class HoodConfig:
    band_top_permille: int = 880  # rows floor(h * this / 1000) .. h - 2 are searched
    col_step: int = 8             # every col_step-th column, from col_step // 2
    grad_min: int = 24            # a strong column: |s(y+1) - s(y-1)| >= 3 * grad_min
    max_jump: int = 2             # rows the path moves between sampled columns
    cover_permille: int = 750     # strong share of the path's columns for a hood


def band(h: int, cfg: HoodConfig) -> tuple[int, int]:
    """First and last searched row (y0 <= y1 when the band is not empty)."""
    y0 = max(1, h * cfg.band_top_permille // 1000)
    return y0, h - 2


def columns(w: int, cfg: HoodConfig) -> np.ndarray:
    """The sampled columns: col_step // 2 (>= 1: col_step >= 2), + col_step, ... while x + 1 < w."""
    return np.arange(cfg.col_step // 2, w - 1, cfg.col_step)


def find(gray: np.ndarray, cfg: HoodConfig = HoodConfig()) -> dict:
    """{'found': bool, 'row': top row or -1, 'n_cols': sampled columns, 'n_strong':
    strong columns on the path, 'path_end': the path's last row (-1 if no band)}."""
    g = np.asarray(gray)
    if g.ndim != 2 or g.dtype != np.uint8:
        raise ValueError(f"hood: a 2-D uint8 image is needed, got {g.dtype} {g.shape}")
    h, w = g.shape
    y0, y1 = band(h, cfg)
    cols = columns(w, cfg)
    none = {"found": False, "row": -1, "n_cols": int(len(cols)), "n_strong": 0, "path_end": -1}
    if y1 < y0 or len(cols) == 0:
        return none
    gi = g.astype(np.int32)
    s = gi[:, cols - 1] + gi[:, cols] + gi[:, cols + 1]
    d = np.abs(s[y0 + 1:y1 + 2] - s[y0 - 1:y1])        # rows y0..y1, one per sampled column
    n_rows, n_cols = d.shape
    thr = 3 * cfg.grad_min
    strong = d >= thr
    gain = np.minimum(d, 4 * thr)
    rows = np.arange(n_rows)
    big = np.int64(1) << 40
    score = gain[:, 0].astype(np.int64)
    cnt = strong[:, 0].astype(np.int32)
    top = np.where(strong[:, 0], rows, big)
    for c in range(1, n_cols):
        best = np.full(n_rows, -1, np.int64)
        src = np.zeros(n_rows, np.int64)
        for dj in range(-cfg.max_jump, cfg.max_jump + 1):
            k = np.clip(rows + dj, 0, n_rows - 1)
            better = score[k] > best           # strict: the first (lowest dj) wins ties
            best = np.where(better, score[k], best)
            src = np.where(better, k, src)
        score = best + gain[:, c]
        cnt = cnt[src] + strong[:, c]
        top = np.where(strong[:, c], np.minimum(top[src], rows), top[src])
    r = int(np.argmax(score))                  # the first (highest) row of the best score
    n_strong = int(cnt[r])
    found = n_strong * 1000 >= cfg.cover_permille * n_cols and n_strong > 0
    return {"found": bool(found), "row": int(y0 + top[r]) if found else -1, "n_cols": int(n_cols),
            "n_strong": n_strong, "path_end": int(y0 + r)}
