#!/usr/bin/env python3
"""How the block-scale TTC's choices were made: candidate estimators on the KITTI tuning
frames 0-38 only (the held-out frames 39-77 are never printed here; tools/eval_kitti_range.py
reports them).

    PYTHONPATH=. python3 tools/ttc_lag_study.py [--data DIR]

Tracks as tools/eval_kitti_range.py collects them (Detector + Tracker, the lead by IoU with
the lidar box). For lag L = 1..5 the stage (ScaleTtc, the earlier defaults but min_lag = lag,
so every figure is one lag) gives the lead's scale s_L over L frames; at a constant closing
speed s_L - 1 = L dt / TTC exactly, so the candidates are:
  - one lag L: TTC = L dt / (s_L - 1);
  - least squares through the origin over lags a..5: slope of (s_L - 1) on L;
  - Theil-Sen through the origin: the median of (s_L - 1) / L over lags a..5;
  - the lag-5 inverse TTC averaged over the last m frames (a moving-average filter);
  - the lag-5 value, else the longest shorter lag down to 2 (the fallback shipped as min_lag 2).
Each is scored against the lidar's 5-frame TTC (the issue's truth), its 9-frame fit and a
trailing t-4..t fit; the last line scores the lidar's own 9-frame fit against its 5-frame TTC:
the median error any smooth estimate has against that truth on these frames.
"""
from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

import eval_kitti_range as E  # noqa: E402

TUNE = slice(0, 39)
DT = 1.0 / E.FPS


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=E.DEFAULT_DATA)
    a = ap.parse_args(argv)
    if not (a.data / "derived_lidar_lead_distance.csv").is_file():
        print(f"ttc_lag_study: {a.data}: not the kitti-raw-sfnd-ttc folder", file=sys.stderr)
        return 2
    frames, _ = E.collect(a.data, "c")
    frames = frames[TUNE]                       # nothing of frames 39-77 goes further
    n = len(frames)
    # the truth at a frame as tools/eval_kitti_range.py defines it (a centred fit: frames
    # 37-38 use lidar distances up to frame 40-42), then cut to the tuning frames
    lid = np.array([float(r["ego_lane_min_x_m"])
                    for r in csv.DictReader(open(a.data / "derived_lidar_lead_distance.csv"))])
    truths = {"lidar 5-frame": E.lidar_ttc(lid, DT)[TUNE], "lidar 9-frame": E.lidar_ttc(lid, DT, half=4)[TUNE],
              "lidar t-4..t": E.lidar_ttc_trailing(lid, DT)[TUNE]}
    S = np.full((n, 6), np.nan)
    for lag in range(1, 6):
        pts = E.points_ttc("c", frames, **{**E.EARLIER_POINTS, "lag": lag, "min_lag": lag})
        for i, fr in enumerate(frames):
            o = pts[i].get(fr["lead"])
            if o is not None and o.scale is not None:
                S[i, lag] = o.scale
    k = {f"lag {L}": (S[:, L] - 1) / L for L in range(1, 6)}
    lags = np.arange(1, 6)
    for lo in (1, 2, 3):
        ls, ts = np.full(n, np.nan), np.full(n, np.nan)
        for i in range(n):
            y, x = S[i, lo:6] - 1, lags[lo - 1:]
            m = np.isfinite(y)
            if np.isfinite(S[i, 5]) and m.any():
                ls[i] = np.sum(x[m] * y[m]) / np.sum(x[m] ** 2)
                ts[i] = np.median(y[m] / x[m])
        k[f"least squares, lags {lo}-5"] = ls
        k[f"Theil-Sen, lags {lo}-5"] = ts
    for m in (2, 3, 5):
        v = np.full(n, np.nan)
        for i in range(n):
            if np.isfinite(k["lag 5"][i]):
                v[i] = np.nanmean(k["lag 5"][max(0, i - m + 1):i + 1])
        k[f"lag 5, mean of last {m}"] = v
    fb = k["lag 5"].copy()
    for i in range(n):
        for L in (4, 3, 2):
            if not np.isfinite(fb[i]) and np.isfinite(S[i, L]):
                fb[i] = (S[i, L] - 1) / L
    k["lag 5, else 4..2 (min_lag 2)"] = fb

    def score(t, truth):
        r = np.abs((t - truth) / truth)
        r = r[np.isfinite(r)]
        return f"{np.median(r):6.1%} (n={len(r):2d})" if len(r) else "   n=0     "

    print(f"KITTI frames 0-38 (tuning part); {int(np.isfinite(truths['lidar 5-frame']).sum())} frames have a "
          f"5-frame lidar TTC. Median abs. rel. error of the TTC (s) against:")
    print(f"{'estimator':34s}" + "".join(f"{t:>18s}" for t in truths))
    for name, inv in k.items():
        ttc = np.where(inv > 0, DT / np.where(inv > 0, inv, 1), np.nan)
        ttc = np.where(ttc <= 20.0, ttc, np.nan)            # the stage's ttc_max
        print(f"{name:34s}" + "".join(f"{score(ttc, t):>18s}" for t in truths.values()))
    print(f"{'lidar 9-frame fit itself':34s}" + "".join(f"{score(truths['lidar 9-frame'], t):>18s}"
                                                      for t in truths.values()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
