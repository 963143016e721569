"""Where compression loses the KITTI lead car: the same frame as PNG and through a codec
(mp4v or JPEG), stage by stage, for the ego-lane detector (shadow hypotheses ->
vertical-edge verification, thesis sec. 2.4.2) on the fixed road of
pyvehtrack.eval.kitti_lead.

For every frame the PNG run finds and the compressed run does not, the stage is
  - "shadow: no hypothesis": no hypothesis of the compressed frame lies at the lead car
    (its row within 25 px of the lidar box's bottom, its span over >= 40% of the box's
    width); a lower edge (e.g. a soft shadow border the codec made hard) may have
    suppressed it in the shadow stage's reduce step;
  - "shadow: span": the compressed frame has such a hypothesis but it fails, while the
    PNG frame's hypothesis passes verification on the compressed frame (the codec cut
    the shadow edge short, so the ROI misses a side);
  - "verify: edges": the PNG frame's own hypothesis fails verification on the
    compressed frame too (the vehicle's sides lost their vertical edges).

    python3 tools/eval_kitti_codec.py [--data DIR] [--mp4 | --jpeg Q] [--vedge-reach R]
                                      [--vedge-hyst P] [--reduce-verified 0|1] [--draw DIR]

--draw writes, for each frame lost, the PNG and compressed crops one above the other
with the hypotheses (red), boxes (green) and lidar box (blue).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import cv2
import numpy as np

from ..detector import DetectConfig, Detector
from ..frames import to_gray
from ..reference import verify as rverify
from ..reference.verify import VerifyConfig
from ..shared import ShadowConfig
from . import kitti_lead as kl

DEFAULT_DATA = kl.DEFAULT_DATA
STAGES = ("shadow: no hypothesis", "shadow: span", "verify: edges")


def _lead_hyps(hyps: np.ndarray, gt) -> list[int]:
    out = []
    for k, (row, a, b) in enumerate(np.asarray(hyps).reshape(-1, 3)):
        ov = min(b, gt[2]) - max(a, gt[0])
        if ov > 0.4 * (gt[2] - gt[0]) and abs(row - gt[3]) < 25:
            out.append(k)
    return out


def _found(boxes, gt, thr: float) -> bool:
    return any(kl.iou(b, gt) >= thr for b in boxes)


def compare(png_frames, coded_frames, gt, calib, cfg: DetectConfig, thr: float = 0.6):
    """Per-frame rows: frame, found on PNG / compressed, the stage that lost it (or "")."""
    h, w = png_frames[0][1].shape[:2]
    runs = []
    for frames in (png_frames, coded_frames):
        fh, fw = frames[0][1].shape[:2]
        det = Detector("c", cfg, road="fixed", fixed_road=kl.kitti_road(fh, fw, calib))
        runs.append([det.detect(img) for _, img in frames])
    rows = []
    for (idx, _), (_, coded), rp, rc in zip(png_frames, coded_frames, *runs):
        g = gt[idx]
        fp, fc = _found(rp.boxes, g, thr), _found(rc.boxes, g, thr)
        stage = ""
        if fp and not fc:
            gray = to_gray(coded)
            own = [rp.hypotheses[k] for k in _lead_hyps(rp.hypotheses, g)
                   if rp.hypotheses[k][0] < gray.shape[0]]
            png_hyp_ok = any(_found(rverify.verify(gray, np.array([hp]), cfg.verify), g, thr)
                             for hp in own)
            if not _lead_hyps(rc.hypotheses, g):
                stage = STAGES[0]
            elif png_hyp_ok:
                stage = STAGES[1]
            else:
                stage = STAGES[2]
        rows.append({"frame": idx, "png": fp, "coded": fc, "stage": stage,
                     "png_hyp": rp.hypotheses.tolist(), "coded_hyp": rc.hypotheses.tolist(),
                     "png_boxes": rp.boxes.tolist(), "coded_boxes": rc.boxes.tolist()})
    return rows


def draw(rows, png_frames, coded_frames, gt, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for r, (idx, png), (_, coded) in zip(rows, png_frames, coded_frames):
        if not r["stage"]:
            continue
        g = [int(v) for v in gt[idx]]
        y0, y1 = max(0, g[1] - 20), min(coded.shape[0], g[3] + 60)
        x0, x1 = max(0, g[0] - 80), min(coded.shape[1], g[2] + 80)
        panels = []
        for img, hyps, boxes in ((png, r["png_hyp"], r["png_boxes"]),
                                 (coded, r["coded_hyp"], r["coded_boxes"])):
            im = cv2.cvtColor(to_gray(img), cv2.COLOR_GRAY2BGR)
            for row, a, b in hyps:
                cv2.line(im, (a, row), (b, row), (0, 0, 255), 1)
            for b in boxes:
                cv2.rectangle(im, (b[0], b[1]), (b[2], b[3]), (0, 255, 0), 1)
            cv2.rectangle(im, (g[0], g[1]), (g[2], g[3]), (255, 0, 0), 1)
            panels.append(im[y0:y1, x0:x1])
        pic = cv2.resize(np.vstack(panels), None, fx=2, fy=2, interpolation=cv2.INTER_NEAREST)
        cv2.imwrite(str(out / f"lost_{idx:02d}.png"), pic)


def main(argv=None, default_data: Path = DEFAULT_DATA) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=default_data)
    ap.add_argument("--mp4", action="store_true", help="OpenCV mp4v, default quality (the default)")
    ap.add_argument("--jpeg", type=int, default=None, metavar="Q", help="JPEG of quality Q instead")
    ap.add_argument("--vedge-reach", type=int, default=None, metavar="R")
    ap.add_argument("--vedge-hyst", type=int, default=None, metavar="P")
    ap.add_argument("--reduce-verified", type=int, choices=(0, 1), default=None, metavar="0|1",
                    help="ShadowConfig.reduce_verified (default: the config's)")
    ap.add_argument("--iou", type=float, default=0.6)
    ap.add_argument("--draw", type=Path, default=None, metavar="DIR")
    a = ap.parse_args(argv)
    if not (a.data / "derived_lidar_lead_box.csv").is_file():
        print(f"eval_kitti_codec: {a.data}: not the kitti-raw-sfnd-ttc folder", file=sys.stderr)
        return 2
    if a.jpeg is not None and (a.mp4 or not 1 <= a.jpeg <= 100):
        ap.error("--jpeg Q: Q in 1..100, and not with --mp4")
    gt = kl.load_gt(a.data / "derived_lidar_lead_box.csv")
    calib = kl.load_calib(a.data / "calib_sfnd_2011_09_26.txt")
    frames = []
    for idx in sorted(gt):
        img = cv2.imread(str(a.data / "image_02" / "data" / f"{idx:010d}.png"), cv2.IMREAD_COLOR)
        if img is None:
            print(f"eval_kitti_codec: cannot read frame {idx}", file=sys.stderr)
            return 2
        frames.append((idx, img))
    coded = kl.through_jpeg(frames, a.jpeg) if a.jpeg is not None else kl.through_mp4(frames)
    if coded is None:
        print("eval_kitti_codec: the MP4 lost frames", file=sys.stderr)
        return 2
    verify = VerifyConfig()
    if a.vedge_reach is not None:
        verify = dataclasses.replace(verify, vedge_reach=a.vedge_reach)
    if a.vedge_hyst is not None:
        verify = dataclasses.replace(verify, vedge_hyst_permille=a.vedge_hyst)
    shadow = ShadowConfig()
    if a.reduce_verified is not None:
        shadow = dataclasses.replace(shadow, reduce_verified=a.reduce_verified)
    cfg = DetectConfig(shadow=shadow, verify=verify)
    rows = compare(frames, coded, gt, calib, cfg, a.iou)
    codec = f"JPEG {a.jpeg}" if a.jpeg is not None else "mp4v"
    print(f"KITTI lead car, PNG vs {codec}, vedge reach {verify.vedge_reach} hyst "
          f"{verify.vedge_hyst_permille}, reduce verified {shadow.reduce_verified}, IoU >= {a.iou}")
    print(f"{'frames':8s} {'PNG':>4s} {codec:>8s}  " + "  ".join(f"{s:>22s}" for s in STAGES)
          + "  found only compressed")
    for name, sel in (("0-38", lambda i: i < kl.SPLIT), ("39-77", lambda i: i >= kl.SPLIT),
                      ("all", lambda i: True)):
        rs = [r for r in rows if sel(r["frame"])]
        print(f"{name:8s} {sum(r['png'] for r in rs):4d} {sum(r['coded'] for r in rs):8d}  "
              + "  ".join(f"{sum(r['stage'] == s for r in rs):22d}" for s in STAGES)
              + f"  {sum(r['coded'] and not r['png'] for r in rs):21d}")
    for s in STAGES:
        print(f"  {s}: frames {[r['frame'] for r in rows if r['stage'] == s]}")
    if a.draw is not None:
        draw(rows, frames, coded, gt, a.draw)
        print(f"written: {a.draw}/lost_NN.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
