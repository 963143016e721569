#!/usr/bin/env python3
"""Run the overtaking-flow stage on a video and write annotated frames (lateral areas, accepted cells,
hypotheses) for a person to look at; prints one line per frame with its hypotheses.

    PYTHONPATH=. python3 tools/flow_video.py ../shared/data/udacity-carnd-road/vehicle-detection/test_video.mp4 \
        --out flow_frames/ [--sides both] [--set k=v ...]
"""
from __future__ import annotations

import argparse
import os
import sys

import cv2
import numpy as np

from pyvehtrack import _native
from pyvehtrack.flow import OvertakingDetector


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("video")
    ap.add_argument("--out", required=True, help="folder for the annotated PNGs")
    ap.add_argument("--sides", default="both", choices=["left", "right", "both"])
    ap.add_argument("--set", action="append", default=[], metavar="K=V")
    ap.add_argument("--every", type=int, default=1, help="write every Nth frame")
    a = ap.parse_args(argv)
    over = {k: int(v) for k, _, v in (kv.partition("=") for kv in a.set)}
    cap = cv2.VideoCapture(a.video)
    if not cap.isOpened():
        print(f"cannot open {a.video}", file=sys.stderr)
        return 2
    os.makedirs(a.out, exist_ok=True)
    det = OvertakingDetector(sides=a.sides, **over)
    cfg = det.cfg
    t = 0
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        res = det.step(bgr)
        vis = bgr.copy()
        if res.ready:
            for side in (0, 1):
                x0, y0, dx, dy, flag, _ = _native.flow_field(det._st, side)
                n, lv = int(cfg.cell), int(cfg.level)
                for j, i in zip(*np.nonzero(flag & 1)):
                    cx, cy = ((x0 + i * n + n // 2) << lv), ((y0 + j * n + n // 2) << lv)
                    col = (0, 255, 0) if flag[j, i] & 2 else (160, 160, 160)
                    cv2.arrowedLine(vis, (cx, cy), (cx + 3 * (int(dx[j, i]) << lv), cy + 3 * (int(dy[j, i]) << lv)),
                                    col, 1, tipLength=0.3)
                if dx.size:
                    cv2.rectangle(vis, (x0 << lv, y0 << lv), ((x0 + dx.shape[1] * n) << lv, (y0 + dx.shape[0] * n) << lv),
                                  (255, 128, 0), 1)
        for h in res.hyps:
            cv2.rectangle(vis, h.box[:2], h.box[2:], (0, 0, 255), 3)
            cv2.putText(vis, f"{h.kind} {h.side} {h.flow[0]:+.1f}px", (h.box[0], max(15, h.box[1] - 6)),
                        cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 255), 2)
        print(t, [(h.kind, h.side, h.box, h.cells, round(h.flow[0], 2)) for h in res.hyps])
        if t % a.every == 0:
            cv2.imwrite(os.path.join(a.out, f"flow_{t:04d}.png"), vis)
        t += 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
