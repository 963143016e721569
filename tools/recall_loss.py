#!/usr/bin/env python3
"""Where the whole-road detector loses each vehicle, step by step.

    python tools/recall_loss.py --split val [--model M.npz] [--min-width 32] [--limit N]

For each tusimple-vehicles-dev frame of the split, the frame goes through
pyvehtrack.Detector (the C pipeline, as `pyvehtrack detect` and
tools/eval_tusimple_boxes.py run it) for the final boxes and the horizon it used; the
same frame then goes through the float oracle (reference/fulldet.py, exact against C)
with the same horizon and the C classifier, recording every window's score, the
candidates before NMS, the boxes NMS keeps and the merged boxes. Each vehicle >=
--min-width px wide that no final box reaches (IoU >= 0.5 throughout, as eval_boxes;
greedy matching aside) counts in the first step that loses it:
  no_window  -- no window of the grid reaches it (tools/window_coverage.py says why);
  low_score  -- every window reaching it scores under the threshold;
  edge       -- a window reaching it scores >= threshold, but none passes the edge check;
  nms        -- a candidate reaches it, no box kept by NMS does (suppressed by a neighbour;
                with rerank_permille, NMS ranks by the re-ranked keys);
  merge      -- a kept box reaches it, the merged (mean) box does not;
  verify     -- the merged box reaches it, the second stage drops it;
  refine     -- the box the second stage keeps reaches it, the box regressor moves it
                off (the model's refine_* regressor, vt_fulldet_refine), or its
                regressed box is suppressed next to an ego-lane box;
  found      -- a final box reaches it (checked first: a merged box may reach a
                vehicle whose own window NMS dropped; with a wide model in the file,
                the wide pass's boxes are final boxes too).
With "ego" among the model's sources the pipeline's ego-lane boxes come first and the
replay drops the boxes they suppress, as c/pipeline.c does (a vehicle an ego box reaches
is "found"). The final count is checked against the pipeline's own boxes (they must
agree: the oracle is exact). Not a test: reads /work/shared.
"""
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
from pyvehtrack.datasets import tusimple_frames  # noqa: E402

DATA = Path("/work/shared/data/tusimple-vehicles-dev")
STEPS = ("no_window", "low_score", "edge", "nms", "merge", "verify", "refine", "found")


def iou(a, b):
    b = np.asarray(b, np.float64).reshape(-1, 4)
    if not len(b):
        return np.zeros(0)
    iw = np.minimum(a[2], b[:, 2]) - np.maximum(a[0], b[:, 0]) + 1
    ih = np.minimum(a[3], b[:, 3]) - np.maximum(a[1], b[:, 1]) + 1
    inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
    ua = (a[2] - a[0] + 1) * (a[3] - a[1] + 1) + (b[:, 2] - b[:, 0] + 1) * (b[:, 3] - b[:, 1] + 1) - inter
    return inter / ua


def hit(g, boxes):
    v = iou(g, boxes)
    return bool(len(v) and v.max() >= 0.5)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--split", choices=("train", "test", "fit", "val"), required=True)
    ap.add_argument("--data", default=str(DATA))
    ap.add_argument("--model", default=str(_ROOT / "pyvehtrack" / "models" / "window_mlp_hog32.npz"))
    ap.add_argument("--min-width", type=int, default=32)
    ap.add_argument("--limit", type=int, default=0)
    ap.add_argument("--json", default=None, help="write the per-vehicle step (file, box, step, best score)")
    args = ap.parse_args(argv)
    from pyvehtrack import _native, fullroad  # noqa: PLC0415
    from pyvehtrack.detector import Detector  # noqa: PLC0415
    from pyvehtrack.reference import fulldet as rfd  # noqa: PLC0415
    from pyvehtrack.reference import windows as rw  # noqa: PLC0415
    data = Path(args.data)
    frames = tusimple_frames(data, args.split, args.limit)
    det = Detector(model=args.model)
    ref = fullroad.FullRoadDetector(det.full.model, sources=det.full.sources, camera=det.full.camera,
                                    cfg=det.full.cfg, engine="reference")
    cfg = ref.det_cfg
    thr = cfg.window_score_min
    counts, rows, mismatch = Counter(), [], 0
    for e in frames:
        img = cv2.imread(str(data / e["file_name"]))
        res = det.detect(img)
        final_c = np.asarray(res.boxes, np.int64).reshape(-1, 4)
        hz = int(res.stats["horizon_y"])
        gray = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        h, w = gray.shape
        cam = ref.camera_for(h, w, hz)
        road = rw.road_from_camera(cam, cfg.win, w, h)
        scored = []   # (box as the detector cuts it, score)

        def score(level_img, lv, s, x, y, _sc=scored):
            v = ref._score_py(level_img, lv, s, x, y)
            l, t, r, b = rw.window_box((lv, s, x, y))
            r, b = min(r, w - 1), min(b, h - 1)
            bh = max(1, int(np.floor(s * 2 ** lv * cfg.box_height)))
            _sc.append((l, min(max(b - bh + 1, 0), b), r, b, v))
            return v

        cap = {}
        nms0 = rw.nms

        def nms(boxes, scores, a, c):
            keep = nms0(boxes, scores, a, c)
            cap["cand"], cap["kept"] = np.asarray(boxes, np.int64).reshape(-1, 4), \
                np.asarray([boxes[i] for i in keep], np.int64).reshape(-1, 4)
            return keep
        rw.nms = nms
        try:
            merged, _ = rfd.detect(gray, road, cam, cfg, score, max_windows=4096, max_cand=1024, max_boxes=32,
                                   rescore=(lambda l, t, r, b: ref._score_box(gray, l, t, r, b))
                                   if cfg.rerank_permille > 0 else None)
        finally:
            rw.nms = nms0
        final = merged
        if ref.verify_min_q16 is not None:
            final = rfd.verify_boxes(merged, lambda l, t, r, b: ref._score_box(gray, l, t, r, b),
                                     ref.verify_min_q16)
        verified = final
        if ref.refine is not None:   # box regression (vt_fulldet_refine) after the second stage
            final = ref.refine_ref(gray, final)
        if ref.wide is not None:   # the wide pass (vt_fulldet_wide) after the second stage
            final = rfd.wide(gray, road, cam, cfg.win, ref.wide[1],
                             lambda l, t, r, b: _native.classify_box_mlp(ref._wide_ws, ref._wide_m[0], gray,
                                                                         [l, t, r, b]), final)
        if det.ego_too:   # the ego-lane detector beside it (VT_SRC_EGO): its boxes first, duplicates dropped
            ego = final_c[np.asarray(res.sources) == "ego"].reshape(-1, 4)
            # tested as detected (the pipeline's p->det): a regressed box is tested by its box before the move
            det_boxes = [verified[i][:4] if i < len(verified) else r[:4] for i, r in enumerate(final)]
            keep = [r for r, d in zip(final, det_boxes) if not any(
                rw.suppresses(a, d, cfg.nms_iou_permille, cfg.nms_contain_permille) for a in ego)]
            final = np.concatenate([np.concatenate([ego, np.zeros((len(ego), 2), np.int64)], 1),
                                    np.asarray(keep, np.int64).reshape(-1, final.shape[1])])
        if not np.array_equal(np.asarray(final[:, :4], np.int64), final_c):
            mismatch += 1
        sc = np.asarray(scored, np.int64).reshape(-1, 5)
        for g in e["bbox"]:
            gb = np.array([g["left"], g["top"], g["right"], g["bottom"]], np.float64)
            if gb[2] - gb[0] + 1 < args.min_width:
                continue
            ov = iou(gb, sc[:, :4]) >= 0.5
            best = int(sc[ov, 4].max()) if ov.any() else None
            if hit(gb, final[:, :4]):
                step = "found"
            elif hit(gb, cap["cand"]):   # a window or a shadow box became a candidate
                step = ("nms" if not hit(gb, cap["kept"]) else "merge" if not hit(gb, merged[:, :4])
                        else "verify" if not hit(gb, verified[:, :4]) else "refine")
            elif not ov.any():
                step = "no_window"
            elif best < thr:
                step = "low_score"
            else:
                step = "edge"
            counts[step] += 1
            rows.append({"file": e["file_name"], "box": gb.tolist(), "step": step,
                         "best_window_score": None if best is None else best / 65536})
    n = sum(counts.values())
    print(f"split {args.split}: {len(frames)} frames, {n} vehicles >= {args.min_width} px, model {args.model}")
    print("  " + "  ".join(f"{k} {counts[k]}" for k in STEPS))
    print(f"  frames where the oracle's final boxes differ from the pipeline's: {mismatch}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
