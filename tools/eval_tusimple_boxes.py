#!/usr/bin/env python3
"""Score full-frame vehicle detection on tusimple-vehicles-dev, one split at a time.

    python tools/eval_tusimple_boxes.py --split test|train [--model M.npz] [--sources shadow windows]
                                        [--offset F] [--limit N] [--out pred.json] [--draw DIR]
                                        [--mp4 | --jpeg Q | --h264 [CRF]] [--light dusk|overcast]
                                        [--scale F] [--gray] [--work-width PX]

The split is pyvehtrack.datasets.tusimple_split (TEST: (NNNN // 10) % 5 == 0, 102 frames).
Tune on --split train only (choices on --split val, the TRAIN frames the
classifier of tools/train_window_svm.py --fit-only never saw); report --split test. Prints eval_boxes' table (recall and
precision at IoU >= 0.5 by size, lead vehicle, COCO AP50 by pycocotools). Detection runs
through pyvehtrack.detector.Detector in its full-road mode, as `pyvehtrack detect` does.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys
import time
import warnings
from pathlib import Path

import cv2

_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(_ROOT))
from pyvehtrack import eval_boxes as eb  # noqa: E402
from pyvehtrack.datasets import tusimple_frames  # noqa: E402
from pyvehtrack.detector import Detector  # noqa: E402
from pyvehtrack.eval import conditions as cd  # noqa: E402
from pyvehtrack.eval import kitti_lead  # noqa: E402
from pyvehtrack.shared import FULLDET_RENAMED, take_renamed  # noqa: E402

_PERMILLE = ("nms_iou_permille", "nms_contain_permille", "merge_iou_permille", "rerank_permille")

DATA = next((p for p in (_ROOT.parent / "shared" / "data", _ROOT.parent.parent / "shared" / "data")
             if p.is_dir()), _ROOT.parent / "shared" / "data")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--split", choices=("train", "test", "fit", "val"), required=True,
                    help="test, train, or a TRAIN sub-split (datasets.tusimple_subsplit): fit or val")
    ap.add_argument("--data", default=str(DATA / "tusimple-vehicles-dev"))
    ap.add_argument("--model", default=None)
    ap.add_argument("--sources", nargs="+", default=None,
                    help="shadow and/or windows (full-road), or ego; default: Detector's (full-road shadow with "
                         "--model, else the ego-lane detector)")
    ap.add_argument("--offset", type=float, default=0.0, help="added to the model's score threshold")
    ap.add_argument("--nms-iou-permille", type=int, default=None,
                    help="full-road NMS IoU limit, permille (default: FullDetConfig's 301)")
    ap.add_argument("--nms-contain-permille", type=int, default=None,
                    help="full-road NMS containment limit, permille (default: FullDetConfig's 699)")
    ap.add_argument("--merge-iou-permille", type=int, default=None,
                    help="box refinement: each kept box -> mean of candidates with IoU >= this / 1000 (0: off)")
    ap.add_argument("--rerank-permille", type=int, default=None,
                    help="NMS ranks by score + this / 1000 x the built-in HOG 64 MLP's score (vt_fulldet_rerank; 0: off)")
    ap.add_argument("--nms-iou", type=float, default=None, help="deprecated: --nms-iou-permille (x 1000)")
    ap.add_argument("--nms-contain", type=float, default=None, help="deprecated: --nms-contain-permille (x 1000)")
    ap.add_argument("--merge-iou", type=float, default=None, help="deprecated: --merge-iou-permille (x 1000)")
    ap.add_argument("--box-height", type=float, default=None,
                    help="full-road window box height / width (default: FullDetConfig's 0.75)")
    ap.add_argument("--verify-min", type=float, default=None,
                    help="second stage: built-in HOG 64 MLP on each box, keep score >= this (default: the model's)")
    ap.add_argument("--veh-w", nargs=2, type=float, default=None, metavar=("MIN", "MAX"),
                    help="full-road window width band, m (default: the model's, else WindowConfig's 1.4 2.6)")
    ap.add_argument("--reduce-verified", type=int, choices=(0, 1), default=None, metavar="0|1",
                    help="ShadowConfig.reduce_verified of the shadow stage, ego-lane and full-road "
                         "(default: the config's)")
    ap.add_argument("--limit", type=int, default=0)
    ap.add_argument("--mp4", action="store_true",
                    help="detect on the frames after one MP4 round trip (OpenCV mp4v, default quality), as "
                         "eval_kitti_lead.py --mp4 does: a compression set to tune on that is not KITTI")
    ap.add_argument("--jpeg", type=int, default=None, metavar="Q",
                    help="detect on every frame after a JPEG round trip of quality Q (1..100)")
    ap.add_argument("--h264", type=int, nargs="?", const=23, default=None, metavar="CRF",
                    help="detect on the frames after one H.264 MP4 round trip (libx264, constant rate factor "
                         "CRF, default 23 = x264's default quality; needs imageio-ffmpeg)")
    ap.add_argument("--light", choices=("dusk", "overcast"), default=None,
                    help="detect on the frames relit (pyvehtrack.eval.conditions: dusk = 40%% light, gamma "
                         "1.6, noise; overcast = half the contrast, +20 levels)")
    ap.add_argument("--scale", type=float, default=None, metavar="F",
                    help="detect on the frames resized by F (another camera resolution); boxes are mapped "
                         "back by 1 / F for scoring")
    ap.add_argument("--gray", action="store_true", help="detect on gray frames (default: the colour files)")
    ap.add_argument("--work-width", type=int, default=1280, metavar="PX",
                    help="Detector(work_width=...): frames wider are downscaled to it first (default 1280, as "
                         "`pyvehtrack detect`; 0: only past the core's maximum)")
    ap.add_argument("--out", default=None, help="write the predictions (detect --json format)")
    ap.add_argument("--draw", default=None, help="folder for annotated frames (green: found, red: truth)")
    args = ap.parse_args(argv)
    # the float fractions of before issue 10: x 1000 when exact, with a DeprecationWarning
    lim = {k: getattr(args, k) for k in ("nms_iou", "nms_contain", "merge_iou") if getattr(args, k) is not None}
    lim.update({k: getattr(args, k) for k in _PERMILLE if getattr(args, k) is not None})
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", DeprecationWarning)
            warnings.showwarning = lambda m, *a, **k: print(f"warning: {m}", file=sys.stderr)
            lim = take_renamed("eval_tusimple_boxes", lim, FULLDET_RENAMED)
    except (TypeError, ValueError) as e:   # name the flags, not the fields
        msg = str(e).replace("eval_tusimple_boxes.", "").replace("eval_tusimple_boxes: ", "")
        ap.error(re.sub(r"\b(nms_iou|nms_contain|merge_iou)(_permille)?\b",
                        lambda m: "--" + m.group(0).replace("_", "-"), msg))
    for k, v in lim.items():
        if not 0 <= v <= 1000:
            ap.error(f"--{k.replace('_', '-')}: expected 0..1000 (permille), got {v}")
    if args.jpeg is not None and not 1 <= args.jpeg <= 100:
        ap.error(f"--jpeg: expected a quality 1..100, got {args.jpeg}")
    if sum((args.mp4, args.jpeg is not None, args.h264 is not None)) > 1:
        ap.error("--jpeg, --mp4 and --h264: choose one")
    if args.h264 is not None and not 0 <= args.h264 <= 51:
        ap.error(f"--h264: expected a CRF 0..51, got {args.h264}")
    if args.scale is not None and not (math.isfinite(args.scale) and 0.1 <= args.scale <= 4.0):
        ap.error(f"--scale: expected 0.1..4.0, got {args.scale}")
    data = Path(args.data)
    frames = tusimple_frames(data, args.split, args.limit)
    images = ((i, cv2.imread(str(data / e["file_name"]))) for i, e in enumerate(frames))   # one at a time
    # what a user's camera delivers, in the order it happens: the light, the sensor's size, gray
    # or colour, then the codec
    if args.light:
        images = ((i, cd.light(x, args.light, seed=i)) for i, x in images)
    if args.scale is not None:
        images = ((i, cd.rescale(x, args.scale)) for i, x in images)
    if args.gray:
        images = ((i, cv2.cvtColor(x, cv2.COLOR_BGR2GRAY)) for i, x in images)
    if args.h264 is not None:
        images = cd.through_h264(list(images), args.h264)
        if images is None:
            raise SystemExit("--h264: the decoded video lost frames")
    if args.mp4:   # one video of every frame: they are all in memory for it
        images = kitti_lead.through_mp4(list(images))
        if images is None:
            raise SystemExit("--mp4: the decoded video lost frames (OpenCV's mp4v writer)")
    elif args.jpeg is not None:
        images = (kitti_lead.through_jpeg([x], args.jpeg)[0] for x in images)
    cfg = None
    if args.reduce_verified is not None:
        from pyvehtrack.detector import DetectConfig
        from pyvehtrack.shared import ShadowConfig
        cfg = DetectConfig(shadow=ShadowConfig(reduce_verified=args.reduce_verified))
    det = Detector(cfg=cfg, model=args.model, sources=tuple(args.sources) if args.sources else None,
                   score_offset=args.offset, work_width=args.work_width or None)
    if args.reduce_verified is not None and det.full is not None:
        from dataclasses import replace

        from pyvehtrack import fullroad
        d = det.full.cfg.det
        d = replace(d, shadow=replace(d.shadow, reduce_verified=args.reduce_verified))
        det.full = fullroad.FullRoadDetector(det.full.model, sources=det.full.sources, camera=det.full.camera,
                                             cfg=replace(det.full.cfg, det=d))
    if (lim or args.box_height is not None or args.verify_min is not None
            or args.veh_w is not None) and det.full is not None:
        from dataclasses import replace

        from pyvehtrack import fullroad
        d = det.full.cfg.det
        d = replace(d, **lim, box_height=d.box_height if args.box_height is None else args.box_height)
        if args.veh_w is not None:
            d = replace(d, win=replace(d.win, veh_w_min_m=args.veh_w[0], veh_w_max_m=args.veh_w[1]))
        c = replace(det.full.cfg, det=d)
        if args.verify_min is not None:
            c = replace(c, verify_min=args.verify_min)
        det.full = fullroad.FullRoadDetector(det.full.model, sources=det.full.sources, camera=det.full.camera,
                                             cfg=c)
    preds, t0 = [], time.time()
    for (i, img), e in zip(images, frames):
        res = det.detect(img)
        scores = res.scores if res.scores is not None else [None] * len(res.boxes)
        f = 1.0 if args.scale is None else args.scale
        # back to the labelled frame's pixels: inclusive [l, t, r, b] covers [l, r + 1)
        boxes = [([int(v) for v in b] if f == 1.0 else
                  [int(round(b[0] / f)), int(round(b[1] / f)), int(round((b[2] + 1) / f)) - 1,
                   int(round((b[3] + 1) / f)) - 1])
                 + ([round(float(s), 4)] if s is not None else [])
                 for b, s in zip(res.boxes, scores)]
        entry = {"frame": i, "file": e["file_name"], "boxes": boxes}
        if res.sources is not None:
            entry["sources"] = [str(x) for x in res.sources]   # extra key: eval-boxes reads file and boxes only
        preds.append(entry)
        if args.draw:
            Path(args.draw).mkdir(parents=True, exist_ok=True)
            if f != 1.0:   # draw in the labelled frame's pixels
                img = cv2.resize(img, None, fx=1 / f, fy=1 / f, interpolation=cv2.INTER_LINEAR)
            if img.ndim == 2:
                img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
            for b in e["bbox"]:
                cv2.rectangle(img, (int(b["left"]), int(b["top"])), (int(b["right"]), int(b["bottom"])), (0, 0, 255), 1)
            for b in boxes:
                cv2.rectangle(img, (b[0], b[1]), (b[2], b[3]), (0, 255, 0), 2)
                if len(b) == 5:
                    cv2.putText(img, f"{b[4]:.2f}", (b[0], b[1] - 3), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 255, 0), 1)
            cv2.imwrite(str(Path(args.draw) / Path(e["file_name"]).name), img)
    dt = time.time() - t0
    s = eb.score(eb.load_gt([e for e in frames]), eb.load_pred(preds))
    print(f"split {args.split}: {len(frames)} frames, model {args.model or 'default'}, sources {args.sources}, "
          f"offset {args.offset}  ({1000 * dt / max(1, len(frames)):.0f} ms/frame in Python)")
    print(eb.format_scores(s))
    if args.out:
        Path(args.out).write_text(json.dumps(preds))
    return 0


if __name__ == "__main__":
    sys.exit(main())
