#!/usr/bin/env python3
"""Train and measure the ACF first stage (issue 8; C: include/vehtrack/acf.h).

    PYTHONPATH=. python3 tools/train_acf.py train --out DIR [--rounds 2] [--trees 400] [--depth 3] [--min-w PX] [--crops DIR]
                                                 [--split fit|train]
    PYTHONPATH=. python3 tools/train_acf.py eval MODEL.npz --split val [--thr -1 0 1]
    PYTHONPATH=. python3 tools/train_acf.py pack MODEL.npz --out OUT.npz [--thr T] [--base BASE.npz]
                                                [--settings JSON] [--nms-contain P] [--more M2.npz T2]
    PYTHONPATH=. python3 tools/train_acf.py add MODEL.npz WINDOW.npz --out OUT.npz [--thr T] [--loosen -1.5 1.5]
    (train --win CW CH --aspect MIN MAX --veh-w MIN_MM MAX_MM: another window, e.g. the flat
    side-view one: --win 16 8 --aspect 0.2 0.65 --veh-w 1500 9000; --edge left|right: a window
    that scans only the frame's left / right edge column, for vehicles the edge cuts)

Features are the C core's channel bytes (pyvehtrack.acf: vt_acf_resample and
vt_acf_channels through the binding), so the trees' integer thresholds decide
exactly as the trained float thresholds did on the same bytes. Training frames:
tusimple-vehicles-dev 'fit' (datasets.tusimple_subsplit); choices are made on
'val'; TEST is for the final figure (--split train: 'fit' + 'val', for the final
model once the choices are made). Positives: every box >= 24 px wide and its
mirror image, warped (area resampling) into the window with its pad cell of
context; negatives: 100 random windows per frame of the detector's own dense
grid inside its band (IoU < 0.3 with every box), then --rounds rounds of hard
negatives (windows scoring > -1, at most 150 per frame). An edge model (--edge)
learns from its own windows instead of warped crops (a cut vehicle has no whole
box): positives are its windows with IoU >= 0.5 with a box the edge cuts, negatives
its windows far from every box, each from the frame and its mirror image. Trees:
scikit-learn's HistGradientBoostingClassifier (depth --depth), converted to full
binary trees; the soft cascade's trace is the running minimum over the training
positives that pass, less --margin.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import cv2
import numpy as np

_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(_ROOT))
from pyvehtrack import acf  # noqa: E402
from pyvehtrack.eval.kitti_lead import through_jpeg  # noqa: E402
from pyvehtrack.eval_boxes import box_iou_matrix  # noqa: E402
from pyvehtrack.reference import acf as ra  # noqa: E402

DATA = _ROOT.parent / "shared" / "data" / "tusimple-vehicles-dev"
WIN_CW, WIN_CH, PAD = 10, 9, 1
MARGIN = 8  # px of extra context around a warped crop, so its channels have no border effects
HOOD_Q16 = 60948  # the pipeline's road camera default


def hood_y(h: int) -> int:
    return max(1, (h * HOOD_Q16 + 32768) >> 16)


class _Geo:
    """The window being trained (train --win) and its positives and band (--aspect, --veh-w)."""
    win_cw, win_ch, pad = WIN_CW, WIN_CH, PAD
    aspect = (0.0, 99.0)        # box height / width of the positives
    min_w = 24                  # the positives' smallest width (px)
    veh_w = (1080, 3960)        # the band's box widths (mm), acf.h's veh_w_min_mm / veh_w_max_mm
    cols = 0                    # acf.h's VT_ACF_COLS_*: 1 / 2 an edge model (train --edge left / right)
    first = 0                   # acf.h's first_scale: a near-vehicle model's first level (train --first-level)
    jitter = 0                  # jittered copies of each positive box (train --jitter)
    degrade = 0                 # also learn from a JPEG round trip of each frame (train --degrade)


EDGE_PX = 3      # a box within this many px of the frame's side is cut by it (the edge models' positives)
EDGE_POS_IOU = 0.5


def _set_geo(geo) -> None:
    if geo:
        _Geo.win_cw, _Geo.win_ch, _Geo.aspect, _Geo.veh_w = geo[:4]
        _Geo.min_w = geo[4] if len(geo) > 4 else 24
        _Geo.cols = geo[5] if len(geo) > 5 else 0
        _Geo.first = geo[6] if len(geo) > 6 else 0
        _Geo.jitter = geo[7] if len(geo) > 7 else 0
        _Geo.degrade = geo[8] if len(geo) > 8 else 0


def dense(gray: np.ndarray, hor: int):
    """Every window of the band over the pyramid's levels _Geo.first..14 -> (features (N, 720)
    uint8, boxes (N, 4))."""
    feats, boxes = [], []
    h = gray.shape[0]
    for k in range(_Geo.first, 15):
        r = acf.SCALE_Q16[k]
        lw, lh = acf.level_size(gray.shape[1], r), acf.level_size(h, r)
        if lw // 4 < _Geo.win_cw or lh // 4 < _Geo.win_ch:
            continue
        lv = gray if k == 0 else acf.resample(gray, k)
        ch = acf.channels(lv)
        f, cx, cy = ra.window_features(ch, _Geo.win_cw, _Geo.win_ch)
        b = ra.box_of(_Geo, k, cx, cy)
        width = ((4 * (_Geo.win_cw - 2 * PAD)) * r) >> 16
        ok = ra.band_ok(b[:, 3], width, hor, hood_y(h), veh_w_min_mm=_Geo.veh_w[0], veh_w_max_mm=_Geo.veh_w[1])
        if _Geo.cols:   # an edge model scans one column (acf.h's cols)
            ok &= cx == (0 if _Geo.cols == 1 else lw // 4 - _Geo.win_cw)
        feats.append(f[ok])
        boxes.append(b[ok])
    return np.concatenate(feats), np.concatenate(boxes)


def crop_feature(gray: np.ndarray, box) -> np.ndarray:
    """A box warped (area resampling) into the window, with its pad and MARGIN px of context."""
    l, t, r, b = [float(v) for v in box]
    bw, bh = 4 * (_Geo.win_cw - 2 * PAD), 4 * (_Geo.win_ch - 2 * PAD)
    sx, sy = (r - l + 1) / bw, (b - t + 1) / bh  # input px per window px
    ext = 4 * PAD + MARGIN
    x0, y0 = l - ext * sx, t - ext * sy
    W, H = 4 * _Geo.win_cw + 2 * MARGIN, 4 * _Geo.win_ch + 2 * MARGIN
    mat = np.float32([[1 / sx, 0, -x0 / sx], [0, 1 / sy, -y0 / sy]])
    crop = cv2.warpAffine(gray, mat, (W, H), flags=cv2.INTER_AREA if sx > 1 else cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE)
    ch = acf.channels(crop)
    k = MARGIN // 4
    return ch[:, k:k + _Geo.win_ch, k:k + _Geo.win_cw].ravel()


_G: dict = {}


def _init(data, hor, model, geo=None):
    os.environ["OMP_NUM_THREADS"] = "1"
    _set_geo(geo)
    _G.update(data=data, hor=hor, model=acf.AcfModel.load(model) if model else None,
              ann={e["file_name"]: e for e in json.load(open(Path(data) / "annotation.json"))})


def _gt(f):
    return np.array([(b["left"], b["top"], b["right"], b["bottom"]) for b in _G["ann"][f]["bbox"]],
                    float).reshape(-1, 4)


def _far(boxes, gt, thr=0.3):
    return (box_iou_matrix(gt, boxes) < thr).all(0) if len(gt) else np.ones(len(boxes), bool)


def _mirror(boxes, w):
    return np.stack([w - 1 - boxes[:, 2], boxes[:, 1], w - 1 - boxes[:, 0], boxes[:, 3]], 1)


def _cut(gt, w):
    """The boxes >= min_w wide that the edge model's side of the frame cuts."""
    bw = gt[:, 2] - gt[:, 0] + 1
    side = gt[:, 0] <= EDGE_PX if _Geo.cols == 1 else gt[:, 2] >= w - 1 - EDGE_PX
    return gt[side & (bw >= _Geo.min_w)]


def _base_edge(f, rng):
    """An edge model's examples are its own dense windows (a cut vehicle has no whole box to
    warp): positives reach a cut box with IoU >= EDGE_POS_IOU, negatives (100 at random) are
    far from every box; the frame and its mirror image (whose cut boxes are the other side's)."""
    g = cv2.imread(str(Path(_G["data"]) / f), cv2.IMREAD_GRAYSCALE)
    w, pos, neg = g.shape[1], [], []
    for img, gt in ((g, _gt(f)), (np.ascontiguousarray(g[:, ::-1]), _mirror(_gt(f), w))):
        feats, boxes = dense(img, _G["hor"][f])
        cut = _cut(gt, w)
        if len(cut):
            pos.append(feats[box_iou_matrix(cut, boxes.astype(float)).max(0) >= EDGE_POS_IOU])
        ok = np.nonzero(_far(boxes, gt))[0]
        neg.append(feats[rng.choice(ok, size=min(50, len(ok)), replace=False)])
    d = _Geo.win_cw * _Geo.win_ch * 8
    return np.concatenate(pos) if pos else np.zeros((0, d), np.uint8), np.concatenate(neg)


JIT_SHIFT, JIT_SCALE = 0.05, 0.08   # the jittered boxes' shift (of the size) and log-scale ranges


def _jitter(b, rng):
    """_Geo.jitter copies of box b, moved up to JIT_SHIFT of its size and scaled by up to
    exp(JIT_SCALE) (the detector's grid places a vehicle that loosely: a level is 2^(1/4) apart)."""
    out = []
    bw, bh = b[2] - b[0] + 1, b[3] - b[1] + 1
    for _ in range(_Geo.jitter):
        dx, dy = rng.uniform(-JIT_SHIFT, JIT_SHIFT, 2) * (bw, bh)
        s = np.exp(rng.uniform(-JIT_SCALE, JIT_SCALE))
        cx, cy = (b[0] + b[2]) / 2 + dx, (b[1] + b[3]) / 2 + dy
        out.append([cx - s * bw / 2, cy - s * bh / 2, cx + s * bw / 2 - 1, cy + s * bh / 2 - 1])
    return out


DEGRADE_Q = (30, 70)   # the JPEG qualities of train --degrade (eval_kitti_lead.py: 50 is a little harder than mp4v)


def _views(f, g):
    """The frame, and with _Geo.degrade a JPEG round trip of it at a quality drawn from DEGRADE_Q
    (what a dashcam's codec does to the pixels; the same quality each time for one file)."""
    if not _Geo.degrade:
        return [g]
    q = int(np.random.default_rng(int(f[-8:-4]) + 7919).integers(DEGRADE_Q[0], DEGRADE_Q[1] + 1))
    return [g, through_jpeg([(0, g)], q)[0][1]]


def _base(f):
    rng = np.random.default_rng(int(f[-8:-4]))
    if _Geo.cols:
        return _base_edge(f, rng)
    g0 = cv2.imread(str(Path(_G["data"]) / f), cv2.IMREAD_GRAYSCALE)
    w, pos, negs = g0.shape[1], [], []
    for g in _views(f, g0):
        gm = np.ascontiguousarray(g[:, ::-1])
        for b in _gt(f):
            bw, bh = b[2] - b[0] + 1, b[3] - b[1] + 1
            if bw >= _Geo.min_w and _Geo.aspect[0] <= bh / bw < _Geo.aspect[1]:
                for bj in [b] + _jitter(b, rng):
                    pos += [crop_feature(g, bj), crop_feature(gm, [w - 1 - bj[2], bj[1], w - 1 - bj[0], bj[3]])]
        feats, boxes = dense(g, _G["hor"][f])
        ok = np.nonzero(_far(boxes, _gt(f)))[0]
        negs.append(feats[rng.choice(ok, size=min(100, len(ok)), replace=False)])
    return np.array(pos, np.uint8).reshape(-1, _Geo.win_cw * _Geo.win_ch * 8), np.concatenate(negs)


def _mine(f):
    g = cv2.imread(str(Path(_G["data"]) / f), cv2.IMREAD_GRAYSCALE)
    views = [(v, _gt(f)) for v in _views(f, g)]
    if _Geo.cols:   # the edge models' examples come from the mirror image too
        views.append((np.ascontiguousarray(g[:, ::-1]), _mirror(_gt(f), g.shape[1])))
    out = []
    for img, gt in views:
        feats, boxes = dense(img, _G["hor"][f])
        s = ra.tree_scores(_G["model"], feats)
        ok = (s > -1.0) & _far(boxes, gt)
        i = np.nonzero(ok)[0]
        out.append(feats[i[np.argsort(-s[i])[:150 // len(views)]]])
    return np.concatenate(out)


def _detect(args):
    f, thr, cascade = args
    g = cv2.imread(str(Path(_G["data"]) / f), cv2.IMREAD_GRAYSCALE)
    m = _G["model"]
    if not cascade:
        m.reject_q16, m._c = None, None
    cfg = acf.cfg_default()
    cfg.veh_w_min_mm, cfg.veh_w_max_mm = _Geo.veh_w
    cfg.cols = _Geo.cols
    cfg.first_scale, cfg.n_scales = _Geo.first, 15 - _Geo.first
    cfg.score_min = int(np.floor(thr * 65536))
    t0 = time.perf_counter()
    boxes, st = acf.detect(m, g, _G["hor"][f], hood_y(g.shape[0]), fx=1000.0, cfg=cfg)
    return f, boxes, st, time.perf_counter() - t0


def horizons(data, split, cache: Path) -> dict:
    """The horizon row the shipped detector uses on each frame (its stats)."""
    if cache.is_file():
        return json.loads(cache.read_text())
    from pyvehtrack.datasets import tusimple_frames
    from pyvehtrack.detector import Detector
    det, out = Detector(model=str(_ROOT / "pyvehtrack" / "models" / "window_mlp_hog32.npz")), {}
    for e in tusimple_frames(data, split):
        out[e["file_name"]] = int(det.detect(cv2.imread(str(Path(data) / e["file_name"]))).stats["horizon_y"])
    cache.write_text(json.dumps(out))
    return out


def hgb_full_trees(clf, depth: int):
    """A fitted HistGradientBoostingClassifier as full binary trees of `depth` (node 0, then
    node = 2 node + 1 + (x[feat] > thr)): feat (T, 2^depth - 1) int64, its float thresholds
    thr, `split` (True where a node is a real split; a padding node sends everything left,
    its leaf copied under both children), leaf (T, 2^depth) float and the baseline. Shared
    by the ACF trees and the rescorer's (tools/train_rescorer.py)."""
    n_in = (1 << depth) - 1
    T = len(clf._predictors)
    feat, thr = np.zeros((T, n_in), np.int64), np.zeros((T, n_in))
    split = np.zeros((T, n_in), bool)
    leaf = np.zeros((T, n_in + 1))
    for t, (pred,) in enumerate(clf._predictors):
        nodes = pred.nodes

        def fill(i, pos_, d):
            nd = nodes[i]
            if nd["is_leaf"]:
                lo = pos_
                for _ in range(depth - d):
                    lo = 2 * lo + 1
                leaf[t, lo - n_in: lo - n_in + (1 << (depth - d))] = nd["value"]
                return
            if d >= depth:
                raise ValueError(f"tree {t} deeper than {depth}")
            feat[t, pos_], thr[t, pos_], split[t, pos_] = int(nd["feature_idx"]), float(nd["num_threshold"]), True
            fill(int(nd["left"]), 2 * pos_ + 1, d + 1)
            fill(int(nd["right"]), 2 * pos_ + 2, d + 1)

        fill(0, 0, 0)
    return feat, thr, split, leaf, float(np.ravel(clf._baseline_prediction)[0])


def to_model(clf, depth: int, pos: np.ndarray, margin: float) -> acf.AcfModel:
    """Full binary trees of `depth` from a fitted HistGradientBoostingClassifier."""
    n_in = (1 << depth) - 1
    feat, th, split, leaf, bias = hgb_full_trees(clf, depth)
    T = len(feat)
    bad = split & ~((th >= 0) & (th < 255))
    if bad.any():
        t = int(np.argwhere(bad)[0, 0])
        raise ValueError(f"tree {t}: threshold {th[bad][0]} outside the byte range")
    # sklearn goes left when x <= t: with byte x that is x <= floor(t); a padding node's
    # 255 sends every byte left
    thr = np.where(split, np.floor(np.where(split, th, 0)), 255).astype(np.uint8)
    feat = feat.astype(np.uint16)
    leaf_q16 = np.floor(leaf * 65536 + 0.5).astype(np.int32)
    m = acf.AcfModel(_Geo.win_cw, _Geo.win_ch, PAD, depth, feat, thr, leaf, leaf_q16, bias)
    # soft cascade: the running sums (Q16) of the positives that pass score 0
    n_in_ = n_in
    node = np.zeros((T, len(pos)), np.int64)
    tt = np.arange(T)[:, None]
    for _ in range(depth):
        x = pos[np.arange(len(pos))[None, :], feat[tt, node].astype(np.int64)]
        node = 2 * node + 1 + (x > thr[tt, node])
    run = m.bias_q16 + np.cumsum(leaf_q16[tt, node - n_in_].astype(np.int64), 0)
    ok = run[-1] >= 0
    m.reject_q16 = (run[:, ok].min(1) - int(margin * 65536)).clip(-2 ** 31, 2 ** 31 - 1).astype(np.int32)
    return m


def main(argv=None) -> int:
    from pyvehtrack.datasets import tusimple_frames
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("train")
    t.add_argument("--out", required=True, type=Path)
    t.add_argument("--rounds", type=int, default=2)
    t.add_argument("--trees", type=int, default=400)
    t.add_argument("--depth", type=int, default=3)
    t.add_argument("--margin", type=float, default=1.0, help="soft-cascade slack below the positives' trace")
    t.add_argument("--data", default=str(DATA))
    t.add_argument("--win", nargs=2, type=int, default=[WIN_CW, WIN_CH], metavar=("CW", "CH"),
                   help="window in 4 px cells incl. one pad cell each side")
    t.add_argument("--aspect", nargs=2, type=float, default=[0.0, 99.0], metavar=("MIN", "MAX"),
                   help="positives: boxes with MIN <= height / width < MAX")
    t.add_argument("--veh-w", nargs=2, type=int, default=[1080, 3960], metavar=("MIN_MM", "MAX_MM"),
                   help="the band's box widths at the camera height 1.8 m (acf.h)")
    t.add_argument("--min-w", type=int, default=24, help="the positives' smallest box width (px)")
    t.add_argument("--crops", action="append", default=[], metavar="DIR",
                   help="more positives: a folder of whole-vehicle crops (e.g. gti-vehicles/vehicles/GTI_Far), "
                        "each with its mirror image, the box inset by --crop-inset of its size")
    t.add_argument("--crop-inset", type=float, default=1 / 16)
    t.add_argument("--edge", choices=("left", "right"), default=None,
                   help="a model of vehicles the frame's left / right edge cuts: it scans only that edge's "
                        "window column (acf.h's cols); examples are its own windows (module doc)")
    t.add_argument("--first-level", type=int, default=0, choices=range(15), metavar="K",
                   help="a model of near vehicles: negatives and detection from pyramid level K on (level k's "
                        "boxes are 2^(k/4) x the window's; acf.h's first_scale); pair with --min-w")
    t.add_argument("--jitter", type=int, default=0, metavar="N",
                   help="N more positives per box, shifted and scaled a little (_jitter), each with its mirror")
    t.add_argument("--degrade", action="store_true",
                   help="also learn from a JPEG round trip of each frame (quality DEGRADE_Q): compressed video")
    t.add_argument("--split", default="fit", choices=("fit", "train"),
                   help="training frames: 'fit' (choices are made on 'val'), or 'train' = 'fit' + 'val' (the "
                        "final model once the choices are made; TEST stays unseen either way)")
    e = sub.add_parser("eval")
    e.add_argument("model")
    e.add_argument("--split", default="val", choices=("fit", "val", "train", "test"))
    e.add_argument("--thr", nargs="+", type=float, default=[-1.0, -0.5, 0.0, 0.5, 1.0])
    e.add_argument("--no-cascade", action="store_true")
    e.add_argument("--json", type=Path, help="write the boxes at the first --thr as detect --json does")
    e.add_argument("--data", default=str(DATA))
    e.add_argument("--veh-w", nargs=2, type=int, default=None, metavar=("MIN_MM", "MAX_MM"),
                   help="the band (default: the model file's band_mm, else acf.h's)")
    k = sub.add_parser("pack", help="the shipped file: the trees, the detection threshold, and the box "
                                    "regressor (refine_*) and settings of a base model")
    k.add_argument("model")
    k.add_argument("--out", required=True, type=Path)
    k.add_argument("--thr", type=float, default=0.0, help="score_min (real units)")
    k.add_argument("--base", default=None, help="a window model whose refine_* keys ride along")
    k.add_argument("--settings", default=None, help="detector_json (the whole-road settings), JSON text")
    k.add_argument("--nms-contain", type=int, default=None, metavar="PERMILLE",
                   help="the detector's NMS containment limit, 0..1000 (default: the model's, else 1000)")
    k.add_argument("--more", nargs="+", action="append", default=[], metavar="MODEL THR [MIN_MM MAX_MM]",
                   help="another window's model and its threshold, run on the same pyramid (acf1_* keys); "
                        "MIN_MM MAX_MM replace that model's band (the widths it was trained on may be wider)")
    d = sub.add_parser("add", help="a window model appended to a shipped file (its next acfN_ prefix), the "
                                   "file's other keys (a rescorer's too) unchanged")
    d.add_argument("model")
    d.add_argument("window", help="the window's model (train --out DIR: DIR/acf_r1.npz)")
    d.add_argument("--thr", type=float, default=0.0, help="the window's score_min (real units)")
    d.add_argument("--loosen", nargs=2, type=float, default=None, metavar=("OFFSET", "SLACK"),
                   help="lower its threshold by OFFSET and its soft-cascade trace by SLACK, as "
                        "train_rescorer.py does to every window of a rescorer's file (e.g. -1.5 1.5)")
    d.add_argument("--out", required=True, type=Path)
    a = ap.parse_args(argv)
    if a.cmd == "add":
        z = dict(np.load(a.model, allow_pickle=False))
        i = 1 + len(acf.AcfModel.load(a.model).more)
        if i >= acf.MAX_MODELS:
            ap.error(f"{a.model}: already {i} windows (VT_ACF_MAX_MODELS {acf.MAX_MODELS})")
        mm = acf.AcfModel.load(a.window)
        mm.score_min_q16 = int(np.floor(a.thr * 65536 + 0.5))
        keys = mm.keys(f"acf{i}_")
        if a.loosen:
            sys.path.insert(0, str(_ROOT / "tools"))
            from train_rescorer import loosened  # noqa: PLC0415
            keys = loosened(keys, -abs(a.loosen[0]), abs(a.loosen[1]))
        z.update(keys)
        np.savez_compressed(a.out, **z)
        print(f"{a.out}: window {i} ({mm.win_cw} x {mm.win_ch} cells) added to {a.model}")
        return 0
    if a.cmd == "pack":
        z = dict(np.load(a.model, allow_pickle=False))
        z["score_min_q16"] = np.int64(np.floor(a.thr * 65536 + 0.5))
        if a.base:
            b = np.load(a.base, allow_pickle=False)
            z.update({k_: b[k_] for k_ in b.files if k_.startswith("refine_")})
        if a.settings:
            json.loads(a.settings)  # a clear error for bad JSON
            z["detector_json"] = np.array(a.settings)
        if a.nms_contain is not None:
            z["nms_contain_permille"] = np.int32(a.nms_contain)
        for i, more in enumerate(a.more, 1):
            if len(more) not in (2, 4):
                ap.error(f"--more takes MODEL THR [MIN_MM MAX_MM], got {more}")
            mm = acf.AcfModel.load(more[0])
            mm.score_min_q16 = int(np.floor(float(more[1]) * 65536 + 0.5))
            if len(more) == 4:
                mm.band_mm = (int(more[2]), int(more[3]))
            z.update(mm.keys(f"acf{i}_"))
        np.savez_compressed(a.out, **z)
        m = acf.AcfModel.load(a.out)
        print(f"{a.out}: {m.n_trees} trees, threshold {a.thr}, {len(m.more)} more models, keys {sorted(z)}")
        return 0
    from sklearn.ensemble import HistGradientBoostingClassifier
    if a.cmd == "train":
        a.out.mkdir(parents=True, exist_ok=True)
        geo = (a.win[0], a.win[1], tuple(a.aspect), tuple(a.veh_w), a.min_w,
               {None: 0, "left": 1, "right": 2}[a.edge], a.first_level, a.jitter, int(a.degrade))
        _set_geo(geo)
        files = [r["file_name"] for r in tusimple_frames(a.data, a.split)]
        hor = horizons(a.data, a.split, a.out / f"horizons_{a.split}.json")
        t0 = time.time()
        with Pool(2, _init, (a.data, hor, None, geo)) as pool:
            r = pool.map(_base, files, chunksize=4)
        pos, neg = np.concatenate([p for p, _ in r]), np.concatenate([n for _, n in r])
        extra = []
        for d in a.crops:
            files_c = sorted(Path(d).glob("*.png"))
            if not files_c:
                raise SystemExit(f"--crops {d}: no .png files")
            for f in files_c:
                g = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
                h_, w_ = g.shape
                box = [a.crop_inset * w_, a.crop_inset * h_, w_ - 1 - a.crop_inset * w_, h_ - 1 - a.crop_inset * h_]
                extra += [crop_feature(g, box), crop_feature(np.ascontiguousarray(g[:, ::-1]), box)]
        if extra:
            pos = np.concatenate([pos, np.array(extra, np.uint8)])
            print(f"crops: {len(extra)} positives from {len(a.crops)} folders", flush=True)
        print(f"features: {time.time() - t0:.0f} s", flush=True)
        for rnd in range(a.rounds + 1):
            x = np.concatenate([pos, neg]).astype(np.float32)
            y = np.r_[np.ones(len(pos)), np.zeros(len(neg))]
            clf = HistGradientBoostingClassifier(max_iter=a.trees, max_depth=a.depth, learning_rate=0.1,
                                                 early_stopping=False, random_state=0).fit(x, y)
            m = to_model(clf, a.depth, pos, a.margin)
            d = np.abs(ra.tree_scores(m, x[:2000].astype(np.uint8)) - clf.decision_function(x[:2000]))
            path = a.out / f"acf_r{rnd}.npz"
            m.cols, m.first_scale = _Geo.cols, _Geo.first
            m.save(path, n_pos=len(pos), n_neg=len(neg), rounds=rnd, band_mm=np.array(a.veh_w, np.int32),
                   aspect=np.array(a.aspect))
            print(f"{path}: {len(pos)} positives, {len(neg)} negatives, trees vs sklearn max |diff| {d.max():.2e}, "
                  f"{time.time() - t0:.0f} s", flush=True)
            if rnd == a.rounds:
                break
            with Pool(2, _init, (a.data, hor, str(path), geo)) as pool:
                neg = np.concatenate([neg] + pool.map(_mine, files, chunksize=4))
        return 0
    from pyvehtrack import eval_boxes as eb
    files = [r["file_name"] for r in tusimple_frames(a.data, a.split)]
    hor = horizons(a.data, a.split, Path(a.model).parent / f"horizons_{a.split}.json")
    mz = np.load(a.model, allow_pickle=False)
    band = tuple(a.veh_w) if a.veh_w else (tuple(int(v) for v in mz["band_mm"]) if "band_mm" in mz.files
                                            else _Geo.veh_w)
    geo = (int(mz["win_cw"]), int(mz["win_ch"]), _Geo.aspect, band, _Geo.min_w,
           int(mz["cols"]) if "cols" in mz.files else 0, int(mz["first_scale"]) if "first_scale" in mz.files else 0)
    _init(a.data, hor, None, geo)
    for thr in a.thr:
        with Pool(2, _init, (a.data, hor, a.model, geo)) as pool:
            out = pool.map(_detect, [(f, thr, not a.no_cascade) for f in files], chunksize=2)
        gt = [eb.FrameBoxes(f, _gt(f), None) for f in files]
        pr = [eb.FrameBoxes(f, np.stack([b["left"], b["top"], b["right"], b["bottom"]], 1).astype(float),
                            b["score"] / 65536.0) for f, b, _, _ in out]
        sc = eb.score(gt, pr)
        c = sc.classes[">=32px"]
        nw = np.mean([s["n_windows"] for _, _, s, _ in out])
        ms = 1000 * np.mean([dt for _, _, _, dt in out])
        print(f"thr {thr:5.2f}: recall >= 32 px {c['recall']:.1%}, precision {c['precision']:.1%}, "
              f"lead {sc.lead['recall']:.1%}, AP50 {sc.ap50:.1%}, recall all {sc.classes['all']['recall']:.1%} "
              f"({nw:.0f} windows scored, {ms:.0f} ms per frame)", flush=True)
        if a.json and thr == a.thr[0]:
            a.json.write_text(json.dumps([{"file": f, "boxes": [[int(b["left"]), int(b["top"]), int(b["right"]),
                                                                  int(b["bottom"]), b["score"] / 65536.0]
                                                                 for b in bx]} for f, bx, _, _ in out]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
