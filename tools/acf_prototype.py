#!/usr/bin/env python3
"""A float prototype of the next window classifier (issue 8; not in the library, not a test).

    PYTHONPATH=. python3 tools/acf_prototype.py train --out /tmp/acf [--rounds 1] [--data DIR]
    PYTHONPATH=. python3 tools/acf_prototype.py eval /tmp/acf/acf_r1.pkl --split val [--thr -2 -1 0]

Aggregated channel features (Dollar et al.'s ACF, in gray): the frame smoothed by a
triangle filter, its [-1 0 1] gradient magnitude normalised by the magnitude smoothed
over 11 px, and that magnitude split into 6 orientation channels; every channel
averaged over 4x4 px cells and smoothed by [1 2 1]/4. A window is 10 x 9 cells (a 32 x
28 px box and one cell of context on each side: 720 values) taken densely (4 px steps)
from a quarter-octave pyramid (16 scales, 2^(1/4) .. 2^(-14/4)), so every window's
features are lookups into one channel image per level, not a descriptor per window.
Windows are kept where their width fits a 0.6-2.2 m-per-1.8 m-of-camera-height band at
their bottom row (a horizon slack of 20 px); the horizon is the one the shipped detector
uses on that frame. Classifier: scikit-learn's HistGradientBoostingClassifier (400 trees
of depth 3) on the 'fit' frames only: every box >= 24 px wide (and its mirror image)
warped to the model box, 100 random windows per frame (IoU < 0.3 with every box), then
--rounds rounds of hard negatives (windows scoring > -1 there, at most 150 per frame).
Detection: windows over --thr, greedy NMS at IoU 0.3. Measured on 'val' only (see the
README, "Where the misses are"); TEST is kept for a built version.
"""
from __future__ import annotations

import argparse
import json
import os
import pickle
import sys
from multiprocessing import Pool
from pathlib import Path

import cv2
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(_ROOT))
from pyvehtrack.eval_boxes import box_iou_matrix  # noqa: E402
sys.path.insert(0, str(_ROOT / "tools"))
from train_acf import horizons  # noqa: E402  (the shipped detector's horizon per frame, cached)
DATA = _ROOT.parent / "shared" / "data" / "tusimple-vehicles-dev"
SH, BW, BH, PAD, NCH = 4, 32, 28, 1, 8
CW, CH = BW // SH + 2 * PAD, BH // SH + 2 * PAD
SCALES = [2 ** (-k / 4) for k in range(-1, 15)]


def _tri(x, r):
    k = np.concatenate([np.arange(1, r + 2), np.arange(r, 0, -1)]).astype(np.float32)
    k /= k.sum()
    return cv2.sepFilter2D(x, -1, k, k, borderType=cv2.BORDER_REFLECT)


def channels(g: np.ndarray) -> np.ndarray:
    """g: float32 gray 0..1, sides multiples of 4 -> (8, h/4, w/4)."""
    g = _tri(g, 1)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=1)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=1)
    m = np.sqrt(gx * gx + gy * gy)
    m = m / (_tri(m, 5) + 0.005)
    b = np.minimum((np.mod(np.arctan2(gy, gx), np.pi) * (6 / np.pi)).astype(np.int32), 5)
    h, w = g.shape
    a = np.stack([g, m] + [m * (b == k) for k in range(6)]).reshape(NCH, h // SH, SH, w // SH, SH).mean((2, 4))
    k = np.array([0.25, 0.5, 0.25], np.float32)
    return np.stack([cv2.sepFilter2D(c, -1, k, k, borderType=cv2.BORDER_REFLECT) for c in a])


def crop_feature(gray: np.ndarray, box) -> np.ndarray:
    """One box warped to the model box; channels on a larger crop, then cut (no border effects)."""
    l, t, r, b = box
    sx, sy = BW / (r - l + 1), BH / (b - t + 1)
    m = 2 * SH
    x0, y0 = l - (PAD * SH + m) / sx, t - (PAD * SH + m) / sy
    mat = np.float32([[sx, 0, -x0 * sx], [0, sy, -y0 * sy]])
    crop = cv2.warpAffine(gray, mat, (CW * SH + 2 * m, CH * SH + 2 * m),
                          flags=cv2.INTER_AREA if sx < 1 else cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    c = channels(crop.astype(np.float32) / 255)
    k = m // SH
    return c[:, k:k + CH, k:k + CW].ravel()


def windows(gray: np.ndarray, hor: int, band=(0.6, 2.2), slack=20):
    """Every window of the pyramid inside the flat-road band -> (features (N, 720), boxes (N, 4))."""
    feats, boxes = [], []
    h, w = gray.shape
    for s in SCALES:
        lw, lh = int(round(w * s)) // SH * SH, int(round(h * s)) // SH * SH
        if lw < CW * SH or lh < CH * SH:
            continue
        im = cv2.resize(gray, (lw, lh), interpolation=cv2.INTER_AREA if s < 1 else cv2.INTER_LINEAR)
        c = channels(im.astype(np.float32) / 255)
        fx, fy = lw / w, lh / h
        v = sliding_window_view(c, (NCH, CH, CW))[0]
        ny, nx = v.shape[:2]
        ys = np.arange(ny)
        bot = (ys * SH + PAD * SH + BH) / fy - 1
        wpx = BW / fx
        ok = ((wpx >= band[0] * (bot - hor - slack)) & (wpx <= band[1] * (bot - hor + slack))
              & (bot > hor - 5) & (bot < h - 40))
        yi = np.nonzero(ok)[0]
        if not len(yi):
            continue
        feats.append(v[yi].reshape(len(yi) * nx, -1))
        yy, xx = np.meshgrid(yi, np.arange(nx), indexing="ij")
        left, top = (xx.ravel() * SH + PAD * SH) / fx, (yy.ravel() * SH + PAD * SH) / fy
        boxes.append(np.stack([left, top, left + BW / fx - 1, top + BH / fy - 1], 1))
    return np.concatenate(feats).astype(np.float32), np.concatenate(boxes)


def iou(a, bs):
    return box_iou_matrix(a, bs)[0]


def nms(bs, sc, thr=0.3):
    order, keep = np.argsort(-sc), []
    while len(order):
        i = order[0]
        keep.append(i)
        rest = order[1:]
        order = rest[iou(bs[i], bs[rest]) < thr]
    return np.array(keep, int)


_G: dict = {}


def _gt(f):
    return np.array([(b["left"], b["top"], b["right"], b["bottom"]) for b in _G["ann"][f]["bbox"]],
                    float).reshape(-1, 4)


def _init(data, hor, model):
    os.environ["OMP_NUM_THREADS"] = "1"
    _G.update(data=data, hor=hor, clf=pickle.load(open(model, "rb")) if model else None,
              ann={e["file_name"]: e for e in json.load(open(Path(data) / "annotation.json"))})


def _base(f):
    rng = np.random.default_rng(int(f[-8:-4]))
    g = cv2.imread(str(Path(_G["data"]) / f), cv2.IMREAD_GRAYSCALE)
    gm, w, pos = g[:, ::-1].copy(), g.shape[1], []
    for b in _gt(f):
        if b[2] - b[0] + 1 >= 24:
            pos += [crop_feature(g, b), crop_feature(gm, [w - 1 - b[2], b[1], w - 1 - b[0], b[3]])]
    feats, boxes = windows(g, _G["hor"][f])
    ok = np.ones(len(boxes), bool)
    for b in _gt(f):
        ok &= iou(b, boxes) < 0.3
    idx = rng.choice(np.nonzero(ok)[0], size=min(100, int(ok.sum())), replace=False)
    return np.array(pos, np.float32).reshape(-1, CW * CH * NCH), feats[idx]


def _mine(f):
    g = cv2.imread(str(Path(_G["data"]) / f), cv2.IMREAD_GRAYSCALE)
    feats, boxes = windows(g, _G["hor"][f])
    s = _G["clf"].decision_function(feats)
    ok = s > -1.0
    for b in _gt(f):
        ok &= iou(b, boxes) < 0.3
    i = np.nonzero(ok)[0]
    return feats[i[np.argsort(-s[i])[:150]]]


def _candidates(f):
    g = cv2.imread(str(Path(_G["data"]) / f), cv2.IMREAD_GRAYSCALE)
    feats, boxes = windows(g, _G["hor"][f])
    s = _G["clf"].decision_function(feats)
    m = s > -2.5
    return f, boxes[m], s[m]


def main(argv=None) -> int:
    from pyvehtrack.datasets import tusimple_frames
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("train")
    t.add_argument("--out", required=True, type=Path)
    t.add_argument("--rounds", type=int, default=1)
    t.add_argument("--data", default=str(DATA))
    e = sub.add_parser("eval")
    e.add_argument("model")
    e.add_argument("--split", default="val", choices=("fit", "val", "train", "test"))
    e.add_argument("--thr", nargs="+", type=float, default=[-2.0, -1.5, -1.0, -0.5, 0.0])
    e.add_argument("--data", default=str(DATA))
    a = ap.parse_args(argv)
    from sklearn.ensemble import HistGradientBoostingClassifier
    if a.cmd == "train":
        a.out.mkdir(parents=True, exist_ok=True)
        files = [r["file_name"] for r in tusimple_frames(a.data, "fit")]
        hor = horizons(a.data, "fit", a.out / "horizons_fit.json")
        with Pool(2, _init, (a.data, hor, None)) as pool:
            r = pool.map(_base, files, chunksize=4)
        pos, neg = np.concatenate([p for p, _ in r]), np.concatenate([n for _, n in r])
        for rnd in range(a.rounds + 1):
            x = np.concatenate([pos, neg])
            y = np.r_[np.ones(len(pos)), np.zeros(len(neg))]
            clf = HistGradientBoostingClassifier(max_iter=400, max_depth=3, learning_rate=0.1, early_stopping=False,
                                                 random_state=0).fit(x, y)
            path = a.out / f"acf_r{rnd}.pkl"
            pickle.dump(clf, open(path, "wb"))
            print(f"{path}: {len(pos)} positives, {len(neg)} negatives", flush=True)
            if rnd == a.rounds:
                break
            with Pool(2, _init, (a.data, hor, str(path))) as pool:
                neg = np.concatenate([neg] + pool.map(_mine, files, chunksize=4))
        return 0
    from pyvehtrack import eval_boxes as eb
    files = [r["file_name"] for r in tusimple_frames(a.data, a.split)]
    hor = horizons(a.data, a.split, Path(a.model).with_name(f"horizons_{a.split}.json"))
    with Pool(2, _init, (a.data, hor, a.model)) as pool:
        cand = {f: (b, s) for f, b, s in pool.map(_candidates, files, chunksize=2)}
    _init(a.data, hor, None)
    for thr in a.thr:
        gt, pr = [], []
        for f in files:
            b, s = cand[f]
            m = s >= thr
            k = nms(b[m], s[m]) if m.any() else np.zeros(0, int)
            gt.append(eb.FrameBoxes(f, _gt(f), None))
            pr.append(eb.FrameBoxes(f, b[m][k].round(), s[m][k]))
        sc = eb.score(gt, pr)
        c = sc.classes[">=32px"]
        print(f"thr {thr:5.2f}: recall >= 32 px {c['recall']:.1%}, precision {c['precision']:.1%}, "
              f"lead {sc.lead['recall']:.1%}, AP50 {sc.ap50:.1%}, recall all {sc.classes['all']['recall']:.1%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
