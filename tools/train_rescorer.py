#!/usr/bin/env python3
"""Train the ACF file's rescorer (vt_box_rescorer, fulldet.h; issue 8, the GIST paper's
sec. III classifier stage on the first stage's own boxes) and write a model file with it.

    python tools/train_rescorer.py MODEL.npz OUT.npz [--offset -1.5] [--slack 1.5]
        [--trees 150] [--depth 3] [--C 0.3] [--margin-permille 250] [--win 48]
        [--split fit] [--nms-iou 300] [--nms-contain 400] [--score-min 0] [--side-score-min T] [--mirror]

Why: at its own thresholds the ACF file finds about half of the vehicles >= 32 px on
unseen frames; lowered by 1.5 it boxes three in four, with 31 false boxes a frame that
its tree score cannot sort out (tusimple 'val'). A second opinion on each box, from what
the trees do not see, sorts them better: the HOG of the box's surroundings (the box
regressor's context box) through a logistic regression, and where the box sits on a
flat road (its width at its row, its aspect, its row and column).

Recipe (frames of --split only: 'fit' by default, TRAIN minus the 'val' frames that
choose the settings; never TEST):
  1. MODEL's ACF models with every threshold lowered by --offset and every soft-cascade
     trace lowered by --slack, one NMS at containment 1000 (IoU as the file's): the
     candidate boxes of each frame (C, vt_acf_detect_n; at most VT_MAX_BOXES a frame);
  2. labels: IoU >= 0.5 with a vehicle of the frame;
  3. the HOG head: logistic regression (C=--C) on the C core's context HOG (Q15 / 2^15),
     quantised as the box regressor's rows; its decisions on the training boxes come
     from 5 frame-grouped folds (each fold's boxes scored by a head that never saw them),
     so that the trees learn how far to trust it on boxes it has not seen;
  4. the trees: scikit-learn's HistGradientBoostingClassifier (--trees, --depth) on the
     seven integer features exactly as the C core computes them, turned into full
     binary trees (sklearn goes left when x <= t: with integer x that is x <= floor(t),
     so C's threshold is floor(t)), leaves and baseline in Q16.
  5. with --side-score-min T: a box the frame's side cuts stays when its ACF score is >= T
     (the side rule: the trees learnt from whole boxes; T = 0, the edge windows' own
     threshold in MODEL, chosen on 'val').
OUT: every key of MODEL with the lowered thresholds and traces and containment 1000,
plus rescore_* keys (fullroad.load_model / acf.AcfModel read them).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(_ROOT))
sys.path.insert(0, str(_ROOT / "tools"))

DEFAULT_DATA = _ROOT.parent / "shared" / "data" / "tusimple-vehicles-dev"


def loosened(z: dict, offset: float, slack: float) -> dict:
    """The file's keys with every ACF threshold lowered by offset and every cascade trace
    by slack (Q16), containment 1000 (the rescorer's NMS decides)."""
    out = dict(z)
    for k in list(out):
        if k.endswith("score_min_q16"):
            out[k] = np.asarray(int(out[k]) + int(round(offset * 65536)), np.int32)
        elif k.endswith("reject_q16") and np.asarray(out[k]).size:
            out[k] = (np.asarray(out[k], np.int64) - int(round(slack * 65536))).clip(
                -2 ** 31, 2 ** 31 - 1).astype(np.int32)
        elif k.endswith("nms_contain_permille"):
            out[k] = np.asarray(1000, np.int32)
    return out


def hgb_trees(clf, depth: int):
    """Full binary trees (feat, thr, leaf_q16, bias_q16) of a fitted HistGradientBoostingClassifier
    (train_acf.hgb_full_trees): sklearn goes left when x <= t, with integer x that is
    x <= floor(t); a padding node's 2^31 - 1 sends everything left."""
    from train_acf import hgb_full_trees
    feat, th, split, leaf, bias = hgb_full_trees(clf, depth)
    thr = np.where(split, np.clip(np.floor(np.where(split, th, 0)), -2 ** 31, 2 ** 31 - 1), 2 ** 31 - 1)
    return (feat.astype(np.uint8), thr.astype(np.int32), np.floor(leaf * 65536 + 0.5).astype(np.int32),
            int(np.floor(bias * 65536 + 0.5)))


def rescorer_keys(w_q, w_shift, b_q16, win, margin, depth, feat, thr, leaf, bias, score_min, iou, contain,
                  info: dict, side_score_min=None) -> dict:
    """The rescore_* keys; side_score_min (Q16, or None: off) is vt_box_rescorer's side rule."""
    side = {} if side_score_min is None else {"rescore_side_keep": np.asarray(1, np.int32),
                                              "rescore_side_score_min_q16": np.asarray(side_score_min, np.int32)}
    return {**side, "rescore_w_q": np.asarray(w_q, np.int16), "rescore_w_shift": np.asarray(w_shift, np.int32),
            "rescore_b_q16": np.asarray(b_q16, np.int32), "rescore_win": np.asarray(win, np.int32),
            "rescore_margin_permille": np.asarray(margin, np.int32), "rescore_depth": np.asarray(depth, np.int32),
            "rescore_feat": feat, "rescore_thr": thr, "rescore_leaf_q16": leaf,
            "rescore_bias_q16": np.asarray(bias, np.int32), "rescore_score_min_q16": np.asarray(score_min, np.int32),
            "rescore_nms_iou_permille": np.asarray(iou, np.int32),
            "rescore_nms_contain_permille": np.asarray(contain, np.int32),
            "rescore_info": np.asarray(json.dumps(info))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model")
    ap.add_argument("out")
    ap.add_argument("--data", default=str(DEFAULT_DATA))
    ap.add_argument("--split", default="fit", choices=("fit", "train"))
    ap.add_argument("--offset", type=float, default=-1.5, help="added to every ACF threshold")
    ap.add_argument("--slack", type=float, default=1.5, help="taken off every soft-cascade trace")
    ap.add_argument("--trees", type=int, default=150)
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--C", type=float, default=0.3, help="logistic regression's C (HOG head)")
    ap.add_argument("--margin-permille", type=int, default=250)
    ap.add_argument("--win", type=int, default=48)
    ap.add_argument("--nms-iou", type=int, default=300, help="permille")
    ap.add_argument("--nms-contain", type=int, default=400, help="permille")
    ap.add_argument("--score-min", type=float, default=0.0, help="rescorer threshold (log-odds)")
    ap.add_argument("--mirror", action="store_true",
                    help="also learn from each frame's mirror image (twice the boxes)")
    ap.add_argument("--side-score-min", type=float, default=None,
                    help="keep a box the frame's side cuts when its ACF score is >= this (vt_box_rescorer's "
                         "side rule; default: off)")
    a = ap.parse_args(argv)
    from sklearn.ensemble import HistGradientBoostingClassifier
    from sklearn.linear_model import LogisticRegression
    from tqdm import tqdm

    from pyvehtrack import _native as N
    from pyvehtrack import acf
    from pyvehtrack.datasets import tusimple_frames
    from pyvehtrack.eval_boxes import box_iou_matrix
    from train_acf import horizons, hood_y
    from train_box_regressor import context_features, quantise

    z = loosened(dict(np.load(a.model, allow_pickle=False)), a.offset, a.slack)
    tmp = Path(a.out).with_suffix(".stage1.npz")
    np.savez_compressed(tmp, **z)
    m = acf.AcfModel.load(tmp)
    tmp.unlink()
    hor = horizons(a.data, a.split, Path(a.out).parent / f"horizons_{a.split}.json")
    ws = N.box_ws_new()
    hws = N.hog_ws_new()
    rows = []   # (frame index, box, score, hog, label)
    frames = tusimple_frames(a.data, a.split)
    for i, e in enumerate(tqdm(frames, desc="candidates", unit="frame")):
        g0 = cv2.imread(str(Path(a.data) / e["file_name"]), cv2.IMREAD_GRAYSCALE)
        gt0 = np.array([(b["left"], b["top"], b["right"], b["bottom"]) for b in e["bbox"]], float).reshape(-1, 4)
        h = hor[e["file_name"]]
        for mir in ((False, True) if a.mirror else (False,)):
            # the mirror image: the same road seen with left and right swapped (its boxes too)
            g = g0[:, ::-1].copy() if mir else g0
            gt = np.stack([g.shape[1] - 1 - gt0[:, 2], gt0[:, 1], g.shape[1] - 1 - gt0[:, 0], gt0[:, 3]], 1) \
                if mir else gt0
            boxes, _ = acf.detect(m, g, h, hood_y(g.shape[0]), 1000.0)
            for b in boxes:
                bx = (int(b["left"]), int(b["top"]), int(b["right"]), int(b["bottom"]))
                iou = box_iou_matrix(np.array([bx], float), gt).max() if len(gt) else 0.0
                rows.append(((i, mir), bx, int(b["score"]), context_features(g, bx, a.margin_permille, a.win, hws),
                             iou >= 0.5, h, g.shape))
    fr = np.array([r[0][0] for r in rows])   # a mirror image's boxes share its frame's fold
    X = np.array([r[3] for r in rows], np.float64) / 32768
    y = np.array([r[4] for r in rows])
    print(f"{len(rows)} boxes on {len(frames)} frames, {int(y.sum())} on a vehicle", flush=True)
    dummy = (np.zeros((1, (1 << a.depth) - 1), np.uint8), np.zeros((1, (1 << a.depth) - 1), np.int32),
             np.zeros((1, 1 << a.depth), np.int32))

    def c_features(r, idx):
        out = []
        for k in idx:
            _i, bx, sc, _f, _y, h, shape = rows[k]
            cam = N.camera_min(1000.0, int(h), 1800, hood_y(shape[0]))
            img = cache.get(_i)
            out.append(N.box_rescore_features(ws, r, cam, img, bx, sc))
        return np.array(out)

    cache = {}

    def load(idx):
        for k in idx:
            i, mir = rows[k][0]
            if (i, mir) not in cache:
                cache.clear()
                g = cv2.imread(str(Path(a.data) / frames[i]["file_name"]), cv2.IMREAD_GRAYSCALE)
                cache[(i, mir)] = g[:, ::-1].copy() if mir else g
            yield k

    def head(Xs, ys):
        lr = LogisticRegression(C=a.C, max_iter=3000).fit(Xs, ys)
        w_q, sh, b = quantise(lr.coef_, lr.intercept_)
        return w_q[0], int(sh[0]), int(b[0])

    nf = int(N.lib.VT_RESCORE_N_FEAT)
    F = np.zeros((len(rows), nf), np.int64)
    for fold in range(5):   # out-of-fold HOG decisions for the trees
        te = (fr // 10) % 5 == fold
        w_q, sh, b = head(X[~te], y[~te])
        r, _keep = N.box_rescorer(a.win, a.win, w_q, sh, b, a.margin_permille, a.depth, *dummy, 0, 0, 0, 0)
        idx = np.flatnonzero(te)
        F[idx] = np.array([c_features(r, [k])[0] for k in load(idx)]).reshape(-1, nf)
    w_q, sh, b = head(X, y)
    clf = HistGradientBoostingClassifier(max_iter=a.trees, max_depth=a.depth, learning_rate=0.1,
                                         random_state=0).fit(F.astype(np.float64), y)
    feat, thr, leaf, bias = hgb_trees(clf, a.depth)
    # the C trees on the integer features = sklearn's raw decision (Q16 rounding aside)
    r, _keep = N.box_rescorer(a.win, a.win, w_q, sh, b, a.margin_permille, a.depth, feat, thr, leaf, bias,
                              0, a.nms_iou, a.nms_contain)
    probe = np.random.default_rng(0).choice(len(F), min(300, len(F)), replace=False)
    c = np.array([N.box_rescore_trees(r, F[k]) for k in probe]) / 65536
    d = np.abs(c - clf.decision_function(F[probe].astype(np.float64))).max()
    print(f"trees: {len(feat)} of depth {a.depth}; C vs sklearn max |diff| {d:.2e} (Q16 leaves: "
          f"<= {len(feat)} x 2^-17)", flush=True)
    info = {"split": a.split, "offset": a.offset, "slack": a.slack, "trees": a.trees, "depth": a.depth, "C": a.C,
            "n_boxes": len(rows), "n_pos": int(y.sum()), "mirror": bool(a.mirror)}
    keys = rescorer_keys(w_q, sh, b, a.win, a.margin_permille, a.depth, feat, thr, leaf, bias,
                         int(round(a.score_min * 65536)), a.nms_iou, a.nms_contain, info,
                         None if a.side_score_min is None else int(round(a.side_score_min * 65536)))
    np.savez_compressed(a.out, **{k: v for k, v in z.items() if not k.startswith("rescore_")}, **keys)
    print(f"wrote {a.out}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
