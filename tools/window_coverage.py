#!/usr/bin/env python3
"""How many annotated vehicles the full-road window grid can find at all, by bucket.

    python tools/window_coverage.py --split val [--model M.npz] [--veh-w MIN MAX] [--box-heights H ...]
                                    [--horizons horizons.json]

For each tusimple-vehicles-dev frame of the split, the horizon the detector uses (the
lanes' vanishing row, carried over from the previous frame, else the camera's; as
tools/eval_tusimple_boxes.py runs it: read from Detector.detect's stats, cached in
--horizons) and the window grid of the model's settings (reference.windows, the exact
twin of c/windows.c; each window's box cut to each --box-heights ratio, bottom row
kept, as the detector does) are laid out; each vehicle >= --min-width px wide falls in
  covered    -- some window box has IoU >= 0.5 with it;
  above      -- its bottom row is at or above the horizon (no window can stand there);
  wide       -- height/width < 0.5 (side views);
  band       -- its width is outside the configured band at its bottom row;
  other      -- none of those, still no window (grid step, hood, frame border).
A vehicle counts in the first failing bucket of that order. Not a test: reads /work/shared.
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np

_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(_ROOT))
from pyvehtrack.datasets import tusimple_frames  # noqa: E402
from pyvehtrack.reference import windows as rw  # noqa: E402

DATA = Path("/work/shared/data/tusimple-vehicles-dev")


def horizons(frames, data, model, cache):
    if cache and Path(cache).is_file():
        d = json.loads(Path(cache).read_text())
        if all(e["file_name"] in d for e in frames):
            return d
    from pyvehtrack.detector import Detector  # noqa: PLC0415
    det = Detector(model=model)
    out = {}
    for e in frames:
        res = det.detect(cv2.imread(str(data / e["file_name"])))
        out[e["file_name"]] = int(res.stats["horizon_y"])
    if cache:
        Path(cache).write_text(json.dumps(out))
    return out


def iou(a, b):
    iw = np.minimum(a[2], b[:, 2]) - np.maximum(a[0], b[:, 0]) + 1
    ih = np.minimum(a[3], b[:, 3]) - np.maximum(a[1], b[:, 1]) + 1
    inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
    ua = (a[2] - a[0] + 1) * (a[3] - a[1] + 1) + (b[:, 2] - b[:, 0] + 1) * (b[:, 3] - b[:, 1] + 1) - inter
    return inter / ua


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--split", choices=("train", "test", "fit", "val"), required=True)
    ap.add_argument("--data", default=str(DATA))
    ap.add_argument("--model", default=str(_ROOT / "pyvehtrack" / "models" / "window_mlp_hog32.npz"))
    ap.add_argument("--veh-w", nargs=2, type=float, default=None, help="width band, m (default: the model's)")
    ap.add_argument("--box-heights", nargs="+", type=float, default=None,
                    help="box height / width ratios cut from each window (default: the model's box_height)")
    ap.add_argument("--min-width", type=int, default=32)
    ap.add_argument("--horizons", default="/tmp/vt_horizons_{split}.json")
    args = ap.parse_args(argv)
    from pyvehtrack import fullroad  # noqa: PLC0415
    data = Path(args.data)
    frames = tusimple_frames(data, args.split)
    hz = horizons(frames, data, args.model, args.horizons.format(split=args.split))
    model, _, camera, _, det = fullroad.setup(args.model, ("shadow", "windows"))
    win = det.win
    if args.veh_w:
        win = replace(win, veh_w_min_m=args.veh_w[0], veh_w_max_m=args.veh_w[1])
    ratios = args.box_heights or [det.box_height]
    counts = {k: 0 for k in ("covered", "above", "wide", "band", "other")}
    n_win = 0
    for e in frames:
        img_h, img_w = 720, 1280
        cam = camera.for_frame(img_h, img_w, hz[e["file_name"]])
        road = rw.road_from_camera(cam, win, img_w, img_h)
        wins = np.concatenate([rw.windows_level(win, cam, road, img_w, img_h, lv) for lv in range(win.levels)])
        n_win += len(wins)
        boxes = []
        for lv, s, x, y in wins:
            l, t, r, b = rw.window_box((lv, s, x, y))
            r, b = min(r, img_w - 1), min(b, img_h - 1)
            for q in ratios:
                bh = max(1, int(np.floor(s * 2 ** lv * q)))
                boxes.append((l, min(max(b - bh + 1, 0), b), r, b))
        boxes = np.asarray(boxes, np.int64).reshape(-1, 4)
        for g in e["bbox"]:
            gb = np.array([g["left"], g["top"], g["right"], g["bottom"]], np.float64)
            gw, gh = gb[2] - gb[0] + 1, gb[3] - gb[1] + 1
            if gw < args.min_width:
                continue
            if len(boxes) and iou(gb, boxes).max() >= 0.5:
                counts["covered"] += 1
            elif gb[3] <= cam.horizon_y:
                counts["above"] += 1
            elif gh / gw < 0.5:
                counts["wide"] += 1
            elif not (rw.vehicle_width_px(cam, win.veh_w_min_m, int(gb[3])) <= Fraction(int(gw))
                      <= rw.vehicle_width_px(cam, win.veh_w_max_m, int(gb[3]))):
                counts["band"] += 1
            else:
                counts["other"] += 1
    tot = sum(counts.values())
    print(f"split {args.split}: {len(frames)} frames, {tot} vehicles >= {args.min_width} px, band "
          f"{win.veh_w_min_m}-{win.veh_w_max_m} m, box heights {ratios}, {n_win / max(1, len(frames)):.0f} windows/frame")
    print("  " + "  ".join(f"{k} {v}" for k, v in counts.items()) + f"  (no window: {tot - counts['covered']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
