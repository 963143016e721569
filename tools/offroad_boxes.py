#!/usr/bin/env python3
"""Where the whole-road detector's boxes lie relative to the lanes found (issue 8 analysis; not a test).

    PYTHONPATH=. python3 tools/eval_tusimple_boxes.py --split val --model M.npz --out pred.json
    PYTHONPATH=. python3 tools/offroad_boxes.py pred.json [--data DIR]

For each box >= 32 px of pred.json (the `detect --json` format) it says whether it reaches a
true box (IoU >= 0.5 with any, no one-to-one matching: a count, not a score) and how far its
bottom centre lies outside the road spanning every lane line the lane stage found
(`LaneResult.x_left_all` .. `x_right_all` on the box's bottom row), in lane widths
(`lane_width_all`); "no road row" when that row has no span. A cut at K lane widths keeps a
true box beyond K as a loss and a false box beyond K as a gain."""
from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

import cv2
import numpy as np

_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(_ROOT))
DATA = _ROOT.parent / "shared" / "data" / "tusimple-vehicles-dev"
BINS = ((0.0, "inside"), (1.0, "< 1"), (1.5, "1-1.5"), (2.0, "1.5-2"), (3.0, "2-3"), (float("inf"), ">= 3"))


def where(lr, box, h: int) -> str:
    y = int(min(max(box[3], 0), h - 1))
    if not lr.road_all_valid or len(lr.x_left_all) <= y or lr.x_right_all[y] <= lr.x_left_all[y]:
        return "no road row"
    xc = (box[0] + box[2]) / 2
    ex = max(lr.x_left_all[y] - xc, xc - lr.x_right_all[y], 0) / max(int(lr.lane_width_all[y]), 1)
    if ex == 0:
        return "inside"
    return next(name for lim, name in BINS[1:] if ex < lim)


def main(argv=None) -> int:
    from pyvehtrack.eval.boxes import iou_matrix
    from pyvehtrack.lane import LaneDetector
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pred")
    ap.add_argument("--data", type=Path, default=DATA)
    a = ap.parse_args(argv)
    if not (a.data / "annotation.json").is_file():
        print(f"error: {a.data} holds no annotation.json", file=sys.stderr)
        return 2
    gt = {r["file_name"]: [(b["left"], b["top"], b["right"], b["bottom"]) for b in r["bbox"]]
          for r in json.load(open(a.data / "annotation.json"))}
    ld, cnt = LaneDetector(), Counter()
    for p in json.load(open(a.pred)):
        img = cv2.imread(str(a.data / p["file"]))
        if img is None:
            print(f"error: cannot read {p['file']}", file=sys.stderr)
            return 2
        lr = ld.detect(img)
        boxes = [b[:4] for b in p["boxes"] if b[2] - b[0] + 1 >= 32]
        g = gt.get(p["file"], [])
        best = (iou_matrix(np.array(boxes, float), np.array(g, float)).max(axis=1)
                if boxes and g else np.zeros(len(boxes)))
        for b, v in zip(boxes, best):
            cnt[("true" if v >= 0.5 else "false", where(lr, b, img.shape[0]))] += 1
    print(f"{'boxes >= 32 px, bottom centre':<32}{'true':>6}{'false':>7}")
    for name in [n for _, n in BINS] + ["no road row"]:
        print(f"{name:<32}{cnt[('true', name)]:>6}{cnt[('false', name)]:>7}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
