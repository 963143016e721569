"""Lead-vehicle detection on the 78 KITTI frames of ../shared/data/kitti-raw-sfnd-ttc.

For each engine (C core, float reference) it runs pyvehtrack.detector.Detector on every
frame and reports
  - found: the share of frames where some box has IoU >= --iou (0.6) with the lidar lead
    box of derived_lidar_lead_box.csv (columns frame,left,top,right,bottom,...);
  - other boxes per frame: boxes inside the road area (bottom centre inside its polygon)
    other than the one matched to the lead car. Other vehicles in the road area are not
    labelled, so a real car in the next lane counts here too;
  - the median best IoU and the time per frame of Detector.detect (Python included).

Road area: --road fixed (default) uses a trapezoid from the sequence's calibration
(horizon at cy for a level camera 1.65 m above the road, 3.5 m lanes, the ego lane plus
half a lane on each side); --road auto uses the lane stage when it is installed and finds
lanes, else that trapezoid. Boxes are inclusive pixels, so a box covers [left, right+1) x
[top, bottom+1) when IoU is computed against the (continuous) lidar box.

    PYTHONPATH=. python3 tools/eval_kitti_lead.py [--data DIR] [--json OUT.json]
    python3 -m pyvehtrack.eval.kitti_lead --data DIR [--json OUT.json]

Compression (what a dashcam does to the frames): --mp4 writes the frames as one MP4
(OpenCV mp4v, default quality) and detects on the decoded frames; --jpeg Q encodes
every frame as JPEG of quality Q (50: a little harder than mp4v's default, by PSNR); --h264 [CRF]
writes one H.264 MP4 (libx264 through imageio-ffmpeg's ffmpeg, CRF 23 = x264's default).
The found count is also printed for frames 0-38 (the tuning part of the codec
tolerances, --vedge-reach / --vedge-hyst, and of --reduce-verified) and 39-77 (held out).

The detector's default thresholds were chosen on these frames (see shadow.h): this is
not an unseen-data figure.
"""
from __future__ import annotations

import argparse
import dataclasses
import csv
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from ..detector import DetectConfig, Detector, FixedRoad
from ..reference.shadow import ShadowConfig
from ..reference.verify import VerifyConfig
from .boxes import from_inclusive, iou as box_iou

# Where the project's data sit beside the repository (tools/eval_kitti_lead.py's default).
DEFAULT_DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "kitti-raw-sfnd-ttc"
CAM_HEIGHT_M = 1.65   # KITTI's camera height above the road
LANE_M = 3.5


def load_calib(path: Path) -> tuple[float, float, float]:
    """f, cx, cy from P_rect_00 in calib_sfnd_2011_09_26.txt."""
    for line in path.read_text().splitlines():
        if line.startswith("P_rect_00"):
            v = [float(t) for t in line.split(":", 1)[1].split()]
            return v[0], v[2], v[6]
    raise SystemExit(f"{path}: no P_rect_00 line")


def kitti_road(h: int, w: int, calib) -> FixedRoad:
    _f, cx, cy = calib
    lane_bottom_px = LANE_M / CAM_HEIGHT_M * (h - 1 - cy)   # lane width at the bottom row
    lb = lane_bottom_px / w
    vx = cx / (w - 1)
    return FixedRoad(vp=(vx, cy / (h - 1)), bottom=(vx - lb, vx + lb), lane_bottom=lb)


def load_gt(path: Path) -> dict[int, list[float]]:
    with path.open() as f:
        return {int(r["frame"]): [float(r[k]) for k in ("left", "top", "right", "bottom")]
                for r in csv.DictReader(f)}


def iou(box, gt) -> float:
    """IoU of an inclusive detector box with a continuous lidar box (pyvehtrack.eval.boxes)."""
    return box_iou(from_inclusive(box), gt)


def inside(poly: np.ndarray, x: float, y: float) -> bool:
    if len(poly) < 3:
        return False
    return cv2.pointPolygonTest(poly.astype(np.float32).reshape(-1, 1, 2), (float(x), float(y)), False) >= 0


def through_mp4(frames):
    """The frames encoded as one MP4 (OpenCV mp4v, default quality) and decoded again, or
    None when the video lost frames: what a dashcam recording does to them."""
    import tempfile
    with tempfile.TemporaryDirectory() as td:
        path = str(Path(td) / "kitti.mp4")
        h, w = frames[0][1].shape[:2]
        vw = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (w, h))
        for _, img in frames:
            vw.write(img)
        vw.release()
        cap = cv2.VideoCapture(path)
        decoded = []
        for idx, _ in frames:
            ok, img = cap.read()
            if not ok:
                return None
            decoded.append((idx, img))
        cap.release()
    return decoded


def through_jpeg(frames, quality: int):
    """Every frame encoded as JPEG of `quality` (OpenCV) and decoded again, gray or colour as it came."""
    return [(idx, cv2.imdecode(cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, quality])[1],
                               cv2.IMREAD_UNCHANGED)) for idx, img in frames]


SPLIT = 39   # frames 0-38: the tuning part; 39-77: held out


def evaluate(engine: str, frames, gt, road_mode: str, calib, cfg: DetectConfig, thr: float,
             progress: bool, model=None, sources=None):
    h, w = frames[0][1].shape[:2]
    det = Detector(engine, cfg, road=road_mode, fixed_road=kitti_road(h, w, calib), model=model,
                   sources=sources)
    rows, times = [], []
    for idx, img in tqdm(frames, desc=f"{engine:9s}", unit="frame", disable=not progress,
                         file=sys.stderr):
        t0 = time.perf_counter()
        res = det.detect(img)
        times.append(time.perf_counter() - t0)
        ious = [iou(b, gt[idx]) for b in res.boxes]
        best = int(np.argmax(ious)) if ious else -1
        hit = best >= 0 and ious[best] >= thr
        others = sum(1 for i, b in enumerate(res.boxes)
                     if not (hit and i == best) and inside(res.road_polygon, (b[0] + b[2]) / 2, b[3]))
        rows.append({"frame": idx, "found": bool(hit), "best_iou": round(max(ious, default=0.0), 4),
                     "other_boxes": others, "boxes": [[int(v) for v in b] for b in res.boxes],
                     "road_source": res.road_source})
    n = len(rows)
    return {
        "engine": engine,
        "frames": n,
        "found": sum(r["found"] for r in rows),
        "found_share": sum(r["found"] for r in rows) / n,
        "found_0_38": sum(r["found"] for r in rows if r["frame"] < SPLIT),
        "found_39_77": sum(r["found"] for r in rows if r["frame"] >= SPLIT),
        "other_boxes_per_frame": sum(r["other_boxes"] for r in rows) / n,
        "median_best_iou": float(np.median([r["best_iou"] for r in rows])),
        "ms_per_frame": 1000.0 * float(np.median(times)),
        "road_sources": sorted({r["road_source"] for r in rows}),
        "per_frame": rows,
    }


def main(argv=None, default_data: Path = DEFAULT_DATA) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=default_data)
    ap.add_argument("--engines", nargs="+", choices=("c", "reference"), default=["c", "reference"])
    ap.add_argument("--road", choices=("fixed", "auto"), default="fixed")
    ap.add_argument("--iou", type=float, default=0.6)
    ap.add_argument("--aspect", type=float, default=None,
                    help="box height/width (default: the config's, 1.0 as the thesis)")
    ap.add_argument("--fixed-threshold", type=int, default=None, metavar="T",
                    help="use the thesis's fixed gradient threshold T instead of the adaptive one")
    ap.add_argument("--json", type=Path, default=Path("eval_kitti_lead.json"))
    ap.add_argument("--mp4", action="store_true",
                    help="encode the frames as one MP4 (OpenCV mp4v, default quality) and detect on the decoded frames")
    ap.add_argument("--jpeg", type=int, default=None, metavar="Q",
                    help="encode every frame as JPEG of quality Q (1..100) and detect on the decoded frames")
    ap.add_argument("--h264", type=int, nargs="?", const=23, default=None, metavar="CRF",
                    help="encode the frames as one H.264 MP4 (libx264, constant rate factor CRF, default 23 = "
                         "x264's default quality; needs imageio-ffmpeg) and detect on the decoded frames")
    ap.add_argument("--vedge-reach", type=int, default=None, metavar="R",
                    help="verify's derivative baseline (VerifyConfig.vedge_reach; 0 = the thesis's Sobel)")
    ap.add_argument("--vedge-hyst", type=int, default=None, metavar="P",
                    help="verify's hysteresis, permille below the edge threshold (0 = none, the thesis)")
    ap.add_argument("--reduce-verified", type=int, choices=(0, 1), default=None,
                    help="ShadowConfig.reduce_verified: 1 = only a shadow edge that passes verification "
                         "suppresses the edges above it (0 = the thesis; default: the config's)")
    ap.add_argument("--model", default=None, help="classifier .npz: the full-road detector (Detector(model=...))")
    ap.add_argument("--sources", nargs="+", default=None, help="full-road sources (shadow windows)")
    ap.add_argument("--no-progress", action="store_true")
    a = ap.parse_args(argv)
    if not (a.data / "derived_lidar_lead_box.csv").is_file():
        print(f"eval_kitti_lead: {a.data}: not the kitti-raw-sfnd-ttc folder", file=sys.stderr)
        return 2
    gt = load_gt(a.data / "derived_lidar_lead_box.csv")
    calib = load_calib(a.data / "calib_sfnd_2011_09_26.txt")
    frames = []
    for idx in sorted(gt):
        p = a.data / "image_02" / "data" / f"{idx:010d}.png"
        img = cv2.imread(str(p), cv2.IMREAD_COLOR)
        if img is None:
            print(f"eval_kitti_lead: cannot read {p}", file=sys.stderr)
            return 2
        frames.append((idx, img))
    if sum((a.mp4, a.jpeg is not None, a.h264 is not None)) > 1:
        ap.error("--jpeg, --mp4 and --h264: choose one")
    if a.h264 is not None and not 0 <= a.h264 <= 51:
        ap.error(f"--h264: expected a CRF 0..51, got {a.h264}")
    if a.jpeg is not None:
        if not 1 <= a.jpeg <= 100:
            ap.error(f"--jpeg: quality must be in 1..100, got {a.jpeg}")
        frames = through_jpeg(frames, a.jpeg)
    if a.mp4:
        frames = through_mp4(frames)
        if frames is None:
            print("eval_kitti_lead: the MP4 lost frames", file=sys.stderr)
            return 2
    if a.h264 is not None:
        from pyvehtrack.eval.conditions import through_h264
        frames = through_h264(frames, a.h264)
        if frames is None:
            print("eval_kitti_lead: the H.264 MP4 lost frames", file=sys.stderr)
            return 2
    shadow, verify = ShadowConfig(), VerifyConfig()
    if a.fixed_threshold is not None:
        shadow = ShadowConfig(threshold_mode=0, grad_threshold=a.fixed_threshold)
    if a.reduce_verified is not None:
        shadow = dataclasses.replace(shadow, reduce_verified=a.reduce_verified)
    if a.aspect is not None:
        verify = dataclasses.replace(verify, aspect_q8=int(round(a.aspect * 256)))
    if a.vedge_reach is not None:
        verify = dataclasses.replace(verify, vedge_reach=a.vedge_reach)
    if a.vedge_hyst is not None:
        verify = dataclasses.replace(verify, vedge_hyst_permille=a.vedge_hyst)
    cfg = DetectConfig(shadow, verify)
    sources = tuple(a.sources) if a.sources else None
    results = [evaluate(e, frames, gt, a.road, calib, cfg, a.iou, not a.no_progress, a.model, sources)
               for e in a.engines]
    via = (" (via MP4 mp4v)" if a.mp4 else f" (via JPEG {a.jpeg})" if a.jpeg is not None
           else f" (via H.264 CRF {a.h264})" if a.h264 is not None else "")
    print(f"\nKITTI lead vehicle, {len(frames)} frames{via}, IoU >= {a.iou}, "
          f"road {a.road}, model {a.model or '-'}, "
          f"{'fixed threshold ' + str(a.fixed_threshold) if a.fixed_threshold is not None else 'adaptive threshold'}, "
          f"aspect {cfg.verify.aspect_q8 / 256:g}, vedge reach {cfg.verify.vedge_reach} "
          f"hyst {cfg.verify.vedge_hyst_permille}, reduce verified {cfg.shadow.reduce_verified}")
    print(f"{'engine':10s} {'found':>12s} {'other/frame':>12s} {'med IoU':>8s} {'ms/frame':>9s}  road")
    for r in results:
        print(f"{r['engine']:10s} {r['found']:4d} ({100 * r['found_share']:5.1f}%) "
              f"{r['other_boxes_per_frame']:12.2f} {r['median_best_iou']:8.3f} {r['ms_per_frame']:9.2f}  "
              f"{','.join(r['road_sources'])}  [frames 0-38: {r['found_0_38']}, 39-77: {r['found_39_77']}]")
    if len(results) == 2:
        agree = sum(x["boxes"] == y["boxes"] for x, y in zip(results[0]["per_frame"], results[1]["per_frame"]))
        print(f"frames where both engines give identical boxes: {agree}/{len(frames)}")
    a.json.write_text(json.dumps({"iou_threshold": a.iou, "road": a.road,
                                  "config": dataclasses.asdict(cfg),
                                  "results": results}, indent=1) + "\n")
    print(f"written: {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
