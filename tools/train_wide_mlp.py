#!/usr/bin/env python3
"""Train the wide-box window model (side views, trucks: boxes flatter than 1:2) the
whole-road detector's wide pass scores its boxes with (vt_fulldet_wide).

    python tools/train_wide_mlp.py --out /tmp/wide.npz [--win 48 24] [--hidden 32] [--rounds 1]

Data: the 'fit' part of tusimple-vehicles-dev TRAIN only (datasets.tusimple_subsplit;
'val' stays unseen for choosing the pass's settings, TEST is never read):
  * positives: every box >= 20 px wide and flatter than 1:2 (height / width < 0.5),
    as annotated, plus up to `--jitter` shifted / scaled copies at IoU >= 0.65 with it,
    and the mirror image of each;
  * negatives: boxes of the wide pass's own grid (windows of the flat-road band
    --band MIN MAX metres, cut to --box-height of their width, bottom row kept) whose
    IoU with every annotated box is < 0.3; then `--rounds` rounds of hard negatives:
    grid boxes the current model accepts that match no box (IoU < 0.3).
Descriptor: the C core's HOG of the box resampled to the model window by
vt_resample_area (exactly what vt_classify_box_mlp computes at detection time). Model:
pyvehtrack.train.fit_mlp (one ReLU layer), quantised by train.mlp_dict.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(_ROOT))
from pyvehtrack import _native  # noqa: E402
from pyvehtrack.datasets import tusimple_subsplit  # noqa: E402
from pyvehtrack.eval_boxes import box_iou_matrix  # noqa: E402
from pyvehtrack.fullroad import Camera  # noqa: E402
from pyvehtrack.reference import windows as rw  # noqa: E402
from pyvehtrack.train import fit_mlp, mlp_dict  # noqa: E402

TUS = Path("/work/shared/data/tusimple-vehicles-dev")


def wide_grid(gray, horizon_y, band, box_q, sizes=(32, 45), cam_spec=None):
    """Input-pixel boxes (N, 4) of the wide pass's grid on one frame (camera road)."""
    h, w = gray.shape
    cam = (cam_spec or Camera()).for_frame(h, w, horizon_y)
    wcfg = rw.WindowConfig(sizes=tuple(sizes), step=8 / sizes[0], veh_w_min_m=band[0], veh_w_max_m=band[1])
    road = rw.road_from_camera(cam, wcfg, w, h)
    out = []
    for lvl in range(wcfg.levels):
        for lv, s, x, y in rw.windows_level(wcfg, cam, road, w, h, lvl):
            l, t, r, b = rw.window_box((lv, s, x, y))
            r, b = min(int(r), w - 1), min(int(b), h - 1)
            bh = max(1, (int(s) << int(lv)) * round(box_q * 1000) // 1000)   # as vt_fulldet_wide
            out.append((int(l), max(b - bh + 1, 0), r, b))
    return np.asarray(out, np.int64).reshape(-1, 4)


class Desc:
    def __init__(self, win_w, win_h):
        self.ws = _native.hog_ws_new()
        self.w, self.h = win_w, win_h

    def __call__(self, gray, box, mirror=False):
        crop = _native.resample_area(gray, [int(v) for v in box], self.w, self.h)
        if mirror:
            crop = np.ascontiguousarray(crop[:, ::-1])
        _native.hog_prepare(self.ws, np.ascontiguousarray(crop))
        return _native.hog_descriptor(self.ws, 0, 0, self.w, self.h).astype(np.float32) / 32768


def jitter(b, rng, n, w_img, h_img):
    out = []
    bw, bh = b[2] - b[0] + 1, b[3] - b[1] + 1
    for _ in range(50 * n):
        if len(out) >= n:
            break
        s = rng.uniform(0.85, 1.15)
        nw, nh = bw * s * rng.uniform(0.92, 1.08), bh * s * rng.uniform(0.92, 1.08)
        cx = (b[0] + b[2]) / 2 + rng.uniform(-0.12, 0.12) * bw
        cy = (b[1] + b[3]) / 2 + rng.uniform(-0.12, 0.12) * bh
        c = np.array([cx - nw / 2, cy - nh / 2, cx + nw / 2, cy + nh / 2]).round().astype(np.int64)
        if c[0] < 0 or c[1] < 0 or c[2] >= w_img or c[3] >= h_img or c[2] - c[0] < 8 or c[3] - c[1] < 4:
            continue
        if box_iou_matrix(c[None], np.asarray(b)[None])[0, 0] >= 0.65:
            out.append(c)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--win", type=int, nargs=2, default=(48, 24), metavar=("W", "H"))
    ap.add_argument("--hidden", type=int, default=32)
    ap.add_argument("--mlp-iter", type=int, default=60)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--band", type=float, nargs=2, default=(2.0, 8.0))
    ap.add_argument("--box-height", type=float, default=0.4)
    ap.add_argument("--jitter", type=int, default=4)
    ap.add_argument("--neg-per-frame", type=int, default=60)
    ap.add_argument("--init", default=None,
                    help="a wide model (.npz of this tool) whose accepted boxes seed the first round's hard "
                         "negatives (continues an earlier run's mining)")
    ap.add_argument("--hard-per-frame", type=int, default=40)
    ap.add_argument("--horizons", default="/tmp/vt_horizons_fit.json",
                    help="per-frame horizon rows (tools/window_coverage.py --split fit writes them)")
    args = ap.parse_args(argv)
    t0 = time.time()
    rng = np.random.default_rng(0)
    desc = Desc(*args.win)
    hz = json.loads(Path(args.horizons).read_text()) if Path(args.horizons).is_file() else {}
    ann = json.loads((TUS / "annotation.json").read_text())
    frames = []
    for e in ann:
        if tusimple_subsplit(e["file_name"]) != "fit":
            continue
        g = cv2.imread(str(TUS / e["file_name"]), cv2.IMREAD_GRAYSCALE)
        gt = np.round(np.array([[b["left"], b["top"], b["right"], b["bottom"]] for b in e["bbox"]],
                               np.float64).reshape(-1, 4)).astype(np.int64)
        gt[:, 0::2] = np.clip(gt[:, 0::2], 0, g.shape[1] - 1)
        gt[:, 1::2] = np.clip(gt[:, 1::2], 0, g.shape[0] - 1)
        grid = wide_grid(g, hz.get(e["file_name"]), args.band, args.box_height)
        frames.append((g, gt, grid))
    pos, neg = [], []
    for g, gt, grid in frames:
        h, w = g.shape
        for b in gt:
            bw, bh = b[2] - b[0] + 1, b[3] - b[1] + 1
            if bw < 20 or bh / bw >= 0.5:
                continue
            for c in [b] + jitter(b, rng, args.jitter, w, h):
                pos.append(desc(g, c))
                pos.append(desc(g, c, mirror=True))
        if len(grid):
            mx = box_iou_matrix(grid, gt).max(axis=1) if len(gt) else np.zeros(len(grid))
            free = np.flatnonzero(mx < 0.3)
            for i in rng.permutation(free)[: args.neg_per_frame]:
                neg.append(desc(g, grid[i]))
    print(f"{len(frames)} fit frames: {len(pos)} positives (jitter + mirrors), {len(neg)} negatives  "
          f"[{time.time() - t0:.0f}s]", flush=True)
    ws = _native.box_ws_new()

    def mine(m):
        added = 0
        for g, gt, grid in frames:
            if not len(grid):
                continue
            mx = box_iou_matrix(grid, gt).max(axis=1) if len(gt) else np.zeros(len(grid))
            hard = [i for i in np.flatnonzero(mx < 0.3)
                    if _native.classify_box_mlp(ws, m, g, [int(v) for v in grid[i]]) >= 0]
            for i in rng.permutation(hard)[:args.hard_per_frame] if hard else []:
                neg.append(desc(g, grid[i]))
                added += 1
        print(f"  hard negatives added: {added}  [{time.time() - t0:.0f}s]", flush=True)

    if args.init:
        z = np.load(args.init)
        m0 = _native.mlp_model(1, int(z["win_w"]), int(z["win_h"]), z["w1_q"], int(z["w1_shift"]), z["b1_q16"],
                               z["w2_q"], int(z["w2_shift"]), int(z["b2_q16"]), 0)
        mine(m0[0])
    for rnd in range(args.rounds + 1):
        X = np.vstack(pos + neg)
        y = np.r_[np.ones(len(pos)), -np.ones(len(neg))]
        rep = max(1, int(round(len(neg) / len(pos))))
        w1, b1, w2, b2 = fit_mlp(np.vstack(pos * rep + neg), np.r_[np.ones(len(pos) * rep), -np.ones(len(neg))],
                                 args.hidden, max_iter=args.mlp_iter)
        acc = ((np.maximum(X @ w1.T + b1, 0) @ w2 + b2 >= 0) == (y > 0)).mean()
        print(f"round {rnd}: {len(pos)} pos, {len(neg)} neg, training accuracy {acc:.4f}  "
              f"[{time.time() - t0:.0f}s]", flush=True)
        if rnd == args.rounds:
            break
        d = mlp_dict("hog", args.win[0], args.win[1], w1, b1, w2, b2, {})
        m = _native.mlp_model(1, args.win[0], args.win[1], d["w1_q"], d["w1_shift"], d["b1_q16"], d["w2_q"],
                              d["w2_shift"], d["b2_q16"], 0)
        mine(m[0])
        np.savez(args.out.replace(".npz", f"_r{rnd}.npz"), model_type="mlp", kind="hog", win_w=args.win[0],
                 win_h=args.win[1], w1_q=d["w1_q"], w1_shift=d["w1_shift"], b1_q16=d["b1_q16"], w2_q=d["w2_q"],
                 w2_shift=d["w2_shift"], b2_q16=d["b2_q16"], threshold_q16=0)
    d = mlp_dict("hog", args.win[0], args.win[1], w1, b1, w2, b2, {})
    info = {"band": list(args.band), "box_height": args.box_height, "trainer": "tools/train_wide_mlp.py",
            "frames": "tusimple-vehicles-dev fit part of TRAIN", "argv": sys.argv[1:] if argv is None else argv}
    np.savez(args.out, model_type="mlp", kind="hog", win_w=args.win[0], win_h=args.win[1], w1_q=d["w1_q"],
             w1_shift=d["w1_shift"], b1_q16=d["b1_q16"], w2_q=d["w2_q"], w2_shift=d["w2_shift"],
             b2_q16=d["b2_q16"], threshold_q16=0, info=json.dumps(info))
    print(f"wrote {args.out}  [{time.time() - t0:.0f}s]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
