#!/usr/bin/env python3
"""Train the whole-road detector's box regressor (vt_box_regressor, fulldet.h) and put
it into a window model file, so `pyvehtrack detect --model OUT.npz` moves each box's
sides to fit the vehicle (bounding-box regression as in R-CNN, on this library's HOG).

    python tools/train_box_regressor.py MODEL.npz OUT.npz [--data DIR] [--split fit]
        [--margin-permille 250] [--win 48] [--alpha 1.0] [--jitter 6] [--seed 0]
        [--sources shadow windows]

Why: the window grid cuts every box to one aspect and the merge step averages
neighbours, so a box often sits on a vehicle but misses its outline (on tusimple 'val'
57 of the 141 false boxes >= 32 px of window_mlp_hog32.npz have IoU 0.2-0.5 with a
vehicle). Training set, tusimple-vehicles-dev frames of --split only ('fit' by default:
TRAIN minus the 'val' frames that choose the settings; never TEST):
  - the boxes MODEL's detector finds there (its settings, no regressor), of --sources;
  - --jitter boxes per vehicle >= 24 px wide, drawn around it as the detector errs
    (width x exp(N(0, 0.2)), centre +- N(0, 0.12) w, bottom +- N(0, 0.1) w, height
    0.75-0.95 w);
each kept when its IoU with its best-matching vehicle is >= 0.25, the target being
that vehicle's sides minus the box's, in box widths (inclusive: r - l + 1). Features:
the C core's HOG of the context box (the box grown by --margin-permille of its width,
cut to the image, area-resampled to --win x --win), exactly what vt_box_regress
computes. Four ridge regressions (scikit-learn), weights quantised to int16 per side
(the largest shift keeping every weight in range, at most 30), bias Q16.
OUT holds every key of MODEL plus refine_* (fullroad.load_model reads them).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

DEFAULT_DATA = Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "tusimple-vehicles-dev"
SRC_BITS = {"shadow": 1, "windows": 2}


def _iou(a, b) -> float:
    ix = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    i = ix * iy
    u = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - i
    return i / u if u > 0 else 0.0


def context_features(gray: np.ndarray, box, margin_permille: int, win: int, ws) -> np.ndarray:
    """The C HOG (Q15) of box's context, as vt_box_regress computes it."""
    from pyvehtrack import _native as N
    from pyvehtrack.reference.fulldet import context_box
    h, w = gray.shape
    ctx = context_box(box, margin_permille, w, h)
    crop = N.resample_area(gray, ctx, win, win)
    N.hog_prepare(ws, crop)
    return N.hog_descriptor(ws, 0, 0, win, win)


def jitter_boxes(gt: np.ndarray, k: int, rng, w_img: int, h_img: int, aspect: str = "rear") -> list:
    out = []
    for g in gt:
        gw = g[2] - g[0]
        if gw < 24:
            continue
        for _ in range(k):
            w = gw * np.exp(rng.normal(0, 0.2))
            cx = (g[0] + g[2]) / 2 + rng.normal(0, 0.12) * gw
            bot = g[3] + rng.normal(0, 0.1) * gw
            if aspect == "gt":   # the vehicle's own shape, as a detector with several windows errs
                hh = w * (g[3] - g[1]) / gw * np.exp(rng.normal(0, 0.1))
            else:
                hh = w * rng.uniform(0.75, 0.95)
            b = [max(0, round(cx - w / 2)), max(0, round(bot - hh)), min(w_img - 1, round(cx + w / 2)),
                 min(h_img - 1, round(bot))]
            if b[2] - b[0] >= 24 and b[3] - b[1] >= 8:
                out.append(b)
    return out


def quantise(coef: np.ndarray, intercept: np.ndarray):
    """int16 weights per side with the largest shift (<= 30) keeping |w q| <= 32767; Q16 bias."""
    w_q, shifts = [], []
    for row in coef:
        m = float(np.abs(row).max()) or 1.0
        sh = int(min(30, np.floor(np.log2(32767 / m))))
        q = np.round(row * 2.0 ** sh)
        w_q.append(np.clip(q, -32767, 32767).astype(np.int16))
        shifts.append(sh)
    return np.stack(w_q), np.array(shifts, np.int32), np.round(intercept * 65536).astype(np.int32)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model")
    ap.add_argument("out")
    ap.add_argument("--data", default=str(DEFAULT_DATA))
    ap.add_argument("--split", default="fit", choices=("fit", "train"),
                    help="training frames: 'fit' (TRAIN minus 'val', the default) or all of TRAIN")
    ap.add_argument("--margin-permille", type=int, default=250)
    ap.add_argument("--win", type=int, default=48)
    ap.add_argument("--alpha", type=float, default=1.0)
    ap.add_argument("--jitter", type=int, default=6)
    ap.add_argument("--jitter-aspect", choices=("rear", "gt"), default="rear",
                    help="the jittered boxes' height: 0.75-0.95 of their width (one rear-view window's "
                         "shape), or the vehicle's own aspect x exp(N(0, 0.1)) (a detector of several windows)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--offset", type=float, default=0.0,
                    help="added to MODEL's score threshold while collecting its boxes (below 0: more of them)")
    ap.add_argument("--sources", nargs="+", default=["shadow", "windows"], choices=tuple(SRC_BITS))
    args = ap.parse_args(argv)

    import cv2
    from sklearn.linear_model import Ridge
    from tqdm import tqdm

    from pyvehtrack import _native as N
    from pyvehtrack.datasets import tusimple_frames
    from pyvehtrack.detector import Detector
    from pyvehtrack.fullroad import load_model

    model = load_model(args.model)
    model.refine = None   # the detector's boxes as they are without a regressor
    det = Detector(model=model, score_offset=args.offset)
    frames = tusimple_frames(args.data, args.split)
    if not frames:
        raise SystemExit(f"no {args.split} frames under {args.data}")
    rng = np.random.default_rng(args.seed)
    ws = N.hog_ws_new()
    X, Y, n_det = [], [], 0
    for e in tqdm(frames, unit="frame", file=sys.stderr, desc="features"):
        img = cv2.imread(str(Path(args.data) / e["file_name"]))
        gray = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        h, w = gray.shape
        gt = np.array([(b["left"], b["top"], b["right"], b["bottom"]) for b in e["bbox"]], float).reshape(-1, 4)
        if len(gt) == 0:
            continue
        res = det.detect(img)
        boxes = [[int(v) for v in b[:4]] for b, s in zip(res.boxes, res.sources) if s in args.sources]
        n_det += len(boxes)
        boxes += jitter_boxes(gt, args.jitter, rng, w, h, args.jitter_aspect)
        for b in boxes:
            ious = [_iou(b, g) for g in gt]
            j = int(np.argmax(ious))
            if ious[j] < 0.25:
                continue
            X.append(context_features(gray, b, args.margin_permille, args.win, ws))
            Y.append((gt[j] - np.array(b, float)) / (b[2] - b[0] + 1))
    X = np.asarray(X, np.float64) / 32768
    Y = np.asarray(Y, np.float64)
    reg = Ridge(alpha=args.alpha).fit(X, Y)
    w_q, shifts, b_q16 = quantise(reg.coef_, reg.intercept_)
    err_f = np.abs(reg.predict(X) - Y).mean(0)
    print(f"{len(X)} training boxes ({n_det} detector boxes of {args.sources} on {len(frames)} "
          f"{args.split} frames, the rest jittered); mean |offset| before {np.abs(Y).mean(0).round(3)}, "
          f"after {err_f.round(3)} box widths (left, top, right, bottom)")
    z = np.load(args.model, allow_pickle=False)
    out = {k: z[k] for k in z.files if not k.startswith("refine_")}
    out.update(refine_win_w=np.int32(args.win), refine_win_h=np.int32(args.win), refine_w_q=w_q,
               refine_w_shift=shifts, refine_b_q16=b_q16,
               refine_margin_permille=np.int32(args.margin_permille),
               refine_sources=np.int32(sum(SRC_BITS[s] for s in set(args.sources))),
               refine_info=np.array(json.dumps({"tool": "tools/train_box_regressor.py", "split": args.split,
                                                "alpha": args.alpha, "jitter": args.jitter, "seed": args.seed,
                                                "jitter_aspect": args.jitter_aspect, "offset": args.offset,
                                                "sources": args.sources,
                                                "samples": len(X)})))
    np.savez(args.out, **out)
    print(f"wrote {args.out} (shifts {shifts.tolist()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
