#!/usr/bin/env python3
"""Probe what the CNN detector's decoder and thresholds could gain, from one run of the network:
each pyramid level's raw output (C forward, as vt_cnn_detect_frame runs the levels, with the
file's level-0 band and contrast stretch) is computed once per frame and decoded offline.

    python tools/probe_cnn_decode.py --model M.npz --probe none|vote|nms|levels|upsample
                                     [--split val] [--light dusk|overcast] [--limit N]
                                     [--levels-offsets O0 O1 O2 O3 O4] [--band TOP BOTTOM] [--cols LEFT RIGHT]
                                     [--stretch PERMILLE]

Probes (the file as it is is always the first line; README, "The decoder and the thresholds, measured and not taken"):
  none      only that line (the network alone, e.g. under --light)
  vote      each peak's box as the heat-weighted mean of the boxes of its 3x3 / 5x5 cells
  nms       the NMS's IoU and containment limits (500 / 600 x 700 .. 1000 permille)
  levels    a heat-threshold offset per level: a coordinate search (or --levels-offsets, applied)
  upsample  the same network also on a 2x upsampled rectangle (--band rows, --cols columns, permille),
            as vt_cnn_cfg's upsampled band (reference.cnn.upsample2x, decoded at half scale; the
            NumPy twin's forward when the 2x image is wider than the core's maximum)
Every figure is the network alone at the file's threshold, scored by eval_boxes on tusimple-vehicles-dev.
Choose on --split val with a network trained on 'fit' only; never on test.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from pyvehtrack import cnn  # noqa: E402
from pyvehtrack import eval_boxes as eb  # noqa: E402
from pyvehtrack.datasets import tusimple_frames  # noqa: E402
from pyvehtrack.eval import conditions as cd  # noqa: E402
from pyvehtrack.reference import cnn as rc  # noqa: E402

DATA = ROOT.parent / "shared" / "data" / "tusimple-vehicles-dev"


def fwd(model, img):
    """The forward pass: the C core's, or the NumPy twin's (the same bits) for an image past
    the core's maximum size (an upsampled band of the whole width)."""
    h, w = img.shape
    if w <= cnn.lib.VT_MAX_WIDTH and h <= cnn.lib.VT_MAX_HEIGHT:
        return cnn.forward(model, np.ascontiguousarray(img))
    return rc.forward(model.layers, img)


def frames_of(model, cfg, data, split, light, limit):
    """[(annotation, gray after the stretch, [(scale shift, column and row offset, raw output)])]."""
    out = []
    for i, e in enumerate(tusimple_frames(data, split, limit)):
        x = cv2.imread(str(data / e["file_name"]))
        if x is None:
            raise SystemExit(f"cannot read {data / e['file_name']}")
        if light:
            x = cd.light(x, light, seed=i)     # the seed eval_tusimple_boxes.py --light uses
        g = cv2.cvtColor(x, cv2.COLOR_BGR2GRAY)
        outs = [(k, dx, dy, fwd(model, lv)) for k, dx, dy, lv in rc.level_inputs(g, cfg)]
        if cfg.stretch_tail_permille:
            g = rc.stretch(g, cfg.stretch_tail_permille)
        out.append((e, g, outs))
    return out


def cell_boxes(out, stride, lut, k):
    """Every cell's box, full-frame px of the level's scale, exclusive right / bottom, (gh, gw, 4)."""
    gh, gw = out.shape[:2]
    o = out.astype(np.int64)
    cx, cy = np.meshgrid((np.arange(gw) * stride + stride // 2) * 16.0, (np.arange(gh) * stride + stride // 2) * 16.0)
    b = np.stack([cx - lut[0][o[..., 1] + 128], cy - lut[1][o[..., 2] + 128],
                  cx + lut[2][o[..., 3] + 128], cy + lut[3][o[..., 4] + 128]], -1)
    return b * (2 ** k) / 16.0


def frame_boxes(model, cfg, outs, w, h, offsets=None, vote=0, iou=None, contain=None, extra=()):
    """The frame's boxes after NMS: decode per level (thr = file's + offsets[k]; vote > 0: the
    heat-weighted mean box of the (2 vote + 1)^2 cells around each peak), plus `extra` rows."""
    lut = np.asarray(model.side_lut, np.float64).reshape(4, 256)
    rows = []
    for k, dx, dy, out in outs:
        thr = min(max(model.heat_thr + cfg.thr_offset + (offsets[k] if offsets and k >= 0 else 0), -128), 128)
        if vote:
            heat = out[..., 0].astype(np.float64)
            cb = cell_boxes(out, model.out_stride, lut, k)
            gh, gw = heat.shape
            for y, x in rc.peaks(out, thr)[:cfg.cap_per_level]:
                ys, xs = slice(max(y - vote, 0), min(y + vote + 1, gh)), slice(max(x - vote, 0), min(x + vote + 1, gw))
                wgt = np.maximum(heat[ys, xs] - (thr - 8), 0)      # cells within 8 heat steps of the threshold
                b = (cb[ys, xs] * wgt[..., None]).sum((0, 1)) / wgt.sum()
                rows.append((np.floor(b[0] + .5) + dx, np.floor(b[1] + .5) + dy, np.floor(b[2] + .5) - 1 + dx,
                             np.floor(b[3] + .5) - 1 + dy, heat[y, x]))
        else:
            b, _ = rc.decode(out, model.out_stride, model.side_lut, thr, k, cfg.cap_per_level)
            rows += [(l + dx, t + dy, r + dx, bt + dy, sc) for l, t, r, bt, sc in b.tolist()]
    rows += list(extra)      # after the levels, as vt_cnn_detect_frame's upsampled band
    lim = {"nms_iou_permille": cfg.nms_iou_permille if iou is None else iou,
           "nms_contain_permille": cfg.nms_contain_permille if contain is None else contain}
    return rc.merge_levels(rows, w, h, lim).astype(np.float64).tolist()


def score(frames, boxes_of):
    gt = eb.load_gt([e for e, _, _ in frames])
    pred = eb.load_pred([{"file": e["file_name"], "boxes": boxes_of(e, g, outs)} for e, g, outs in frames])
    return eb.score(gt, pred)


def summary(s) -> str:
    keep = ("all", ">=32px", "lead", "COCO")
    return " | ".join(" ".join(x.split()) for x in eb.format_scores(s).splitlines() if x.split()[:1]
                      and x.split()[0] in keep)


def f1_32(s) -> float:
    """F1 of the vehicles >= 32 px wide, in percent (0 where there is no box or no vehicle)."""
    c = s.classes[">=32px"]
    r, p = (0.0 if v != v else 100.0 * v for v in (c["recall"], c["precision"]))
    return 2 * r * p / (r + p) if r + p else 0.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", required=True)
    ap.add_argument("--probe", choices=("none", "vote", "nms", "levels", "upsample"), required=True)
    ap.add_argument("--split", choices=("fit", "val", "train", "test"), default="val")
    ap.add_argument("--data", default=str(DATA))
    ap.add_argument("--light", choices=("dusk", "overcast"), default=None)
    ap.add_argument("--limit", type=int, default=0)
    ap.add_argument("--levels-offsets", nargs="+", type=int, default=None, metavar="O",
                    help="with --probe levels: apply these heat offsets (one per level) instead of searching")
    ap.add_argument("--stretch", type=int, default=None, metavar="PERMILLE",
                    help="the contrast stretch's tail (default: the file's; 5 to run a 'fit' stand-in as the default file)")
    ap.add_argument("--band", nargs=2, type=int, default=(400, 560), metavar=("TOP", "BOTTOM"),
                    help="with --probe upsample: the band's rows, permille of the height")
    ap.add_argument("--cols", nargs=2, type=int, default=(0, 1000), metavar=("LEFT", "RIGHT"),
                    help="with --probe upsample: the band's columns, permille of the width")
    a = ap.parse_args(argv)
    if a.limit < 0:
        ap.error("--limit: expected >= 0")
    for name, (lo, hi) in (("--band", a.band), ("--cols", a.cols)):
        if not 0 <= lo < hi <= 1000:
            ap.error(f"{name}: expected 0 <= {lo} < {hi} <= 1000")
    try:
        model = cnn.CnnModel.load(a.model)
    except (OSError, ValueError, KeyError) as e:
        ap.error(f"--model: {e}")
    z = np.load(a.model)
    if "cnn_cfg" not in z:
        ap.error("--model: the file has no cnn_cfg")
    cfg = cnn.CnnConfig(*[int(v) for v in z["cnn_cfg"]])
    tail = a.stretch if a.stretch is not None else (cfg.stretch_tail_permille or 0)
    if not 0 <= tail <= 100:
        ap.error(f"--stretch: expected 0..100 permille (vt_cnn_cfg.stretch_tail_permille), got {tail}")
    cfg = dataclasses.replace(cfg, stretch_tail_permille=tail,     # a file of 6 entries: the whole frame
                              l0_top_permille=cfg.l0_top_permille or 0,
                              l0_bottom_permille=cfg.l0_bottom_permille or 1000)
    n_lv = cfg.first_level + cfg.n_levels
    if a.levels_offsets is not None and len(a.levels_offsets) != n_lv:
        ap.error(f"--levels-offsets: one per level 0..{n_lv - 1}, got {len(a.levels_offsets)}")
    frames = frames_of(model, cfg, Path(a.data), a.split, a.light, a.limit)
    print(f"{len(frames)} {a.split} frames{', ' + a.light if a.light else ''}; the file's cfg {cfg}", flush=True)

    def run(name, **kw):
        s = score(frames, lambda e, g, outs: frame_boxes(model, cfg, outs, g.shape[1], g.shape[0], **kw))
        print(f"{name:28s} F1>=32 {f1_32(s):5.1f} | {summary(s)}", flush=True)
        return s

    run("as shipped")
    if a.probe == "vote":
        run("vote 3x3", vote=1)
        run("vote 5x5", vote=2)
    elif a.probe == "nms":
        for iou in (500, 600):
            for con in (700, 800, 900, 1000):
                run(f"nms iou {iou} contain {con}", iou=iou, contain=con)
    elif a.probe == "none":
        pass
    elif a.probe == "levels":
        if a.levels_offsets is not None:
            run(f"offsets {a.levels_offsets}", offsets=list(a.levels_offsets))
        else:
            for g in (-8, -4, 4, 8):
                run(f"all levels {g:+d}", offsets=[g] * n_lv)
            offs, best = [0] * n_lv, f1_32(run("search start", offsets=[0] * n_lv))
            for _ in range(2):
                for k in range(cfg.first_level, n_lv):
                    for v in (-12, -8, -4, 0, 4, 8, 12):
                        o = offs[:k] + [v] + offs[k + 1:]
                        f = f1_32(score(frames, lambda e, g, outs, o=o: frame_boxes(
                            model, cfg, outs, g.shape[1], g.shape[0], offsets=o)))
                        if f > best + 1e-9:
                            best, offs = f, o
            run(f"searched offsets {offs}", offsets=offs)
    elif a.probe == "upsample":
        ups = {}
        for e, g, _ in frames:
            h, w = g.shape
            x0, y0, x1, y1 = rc.up_rect(h, w, *a.band, *a.cols)
            up = rc.upsample2x(g, x0, y0, x1, y1)
            b, _ = rc.decode(rc.forward(model.layers, up), model.out_stride, model.side_lut,
                             model.heat_thr + cfg.thr_offset, -1, cfg.cap_per_level)
            ups[e["file_name"]] = [(l + x0, t + y0, r + x0, bt + y0, sc) for l, t, r, bt, sc in b.tolist()]
        s = score(frames, lambda e, g, outs: frame_boxes(model, cfg, outs, g.shape[1], g.shape[0],
                                                         extra=ups[e["file_name"]]))
        print(f"{'+ upsampled band':28s} F1>=32 {f1_32(s):5.1f} | {summary(s)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
