"""Track the lead car through the 78 KITTI frames of ../shared/data/kitti-raw-sfnd-ttc
and score it against the lidar-derived lead-car box (derived_lidar_lead_box.csv).

    python tools/eval_kitti_track.py [--data DIR] [--engine c|reference|both]
                                     [--measurement auto|roi|edges|roi+edges|both|all] [--json OUT]
                                     [--mp4 | --h264] [--reduce-verified 0|1]

Figures (the tracking issue's targets: one id through >= 95% of the frames, IoU >= 0.6
in >= 90%):
  - lead id: the track id that overlaps the lidar box (IoU >= 0.5) in the most frames;
  - id share: frames where the lead id's box overlaps the lidar box with IoU >= 0.5,
    over all 78 frames (so a switch to a new id, or a lost track, counts against it);
  - IoU>=0.6 share: frames where the lead id's box has IoU >= 0.6 with the lidar box;
  - TrackEval HOTA/MOTA/IDF1 of all confirmed tracks against the one-object lidar GT
    (no KITTI preprocessing: every box counts, so other vehicles are false positives
    there -- read HOTA as the lead car's, with that caveat).
The lidar box is good to about +-10 px at the sides (its README)."""
from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from .boxes import from_inclusive, iou as box_iou

# Where the project's data sit beside the repository (tools/eval_kitti_track.py's default).
DEFAULT_DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "kitti-raw-sfnd-ttc"


def iou(box, gt) -> float:
    """IoU of an inclusive track box with a continuous lidar box (pyvehtrack.eval.boxes)."""
    return box_iou(from_inclusive(box), gt)


def load(data: Path):
    rows = list(csv.DictReader(open(data / "derived_lidar_lead_box.csv")))
    boxes = {int(r["frame"]): [float(r[k]) for k in ("left", "top", "right", "bottom")] for r in rows}
    files = sorted((data / "image_02" / "data").glob("*.png"))
    return files, boxes


def run(engine: str, files, boxes, detect_every: int, progress: bool, measurement: str = "roi",
        cfg=None, lane_detector=None, model=None) -> dict:
    """files: image paths or (index, BGR image) pairs; cfg: the Detector's DetectConfig (None: default);
    lane_detector: the Detector's lane stage (None: the default pyvehtrack.lane.LaneDetector);
    model: a whole-road model .npz run with its settings, as `pyvehtrack track --model` (None: the
    ego-lane detector alone, this evaluation's detector since the thesis)."""
    from ..detector import Detector
    from ..tracker import Tracker
    from .tracking import evaluate_kitti

    det = Detector(engine=engine, cfg=cfg, lane_detector=lane_detector,
                   model=None if model is None else str(model))
    trk = Tracker(engine=engine, detect_every=detect_every, detector=det, measurement=measurement)
    per_frame = []
    for f in tqdm(files, desc=f"track ({engine}, {measurement})", unit="frame", disable=not progress, file=sys.stderr):
        img = f[1] if isinstance(f, tuple) else cv2.imread(str(f))
        per_frame.append([t for t in trk.step(img) if t.state != "tentative"])
    n = len(files)
    counts: dict[int, int] = {}
    for k, tracks in enumerate(per_frame):
        for t in tracks:
            if iou(t.box, boxes[k]) >= 0.5:
                counts[t.id] = counts.get(t.id, 0) + 1
    lead = max(counts, key=counts.get) if counts else None
    ious = []
    for k, tracks in enumerate(per_frame):
        best = [iou(t.box, boxes[k]) for t in tracks if t.id == lead]
        ious.append(best[0] if best else 0.0)
    ious = np.array(ious)
    gt = np.array([(k, 1, *boxes[k]) for k in range(n)], float)
    tr = np.array([(k, t.id, *t.box, 1.0) for k, ts in enumerate(per_frame) for t in ts], float).reshape(-1, 7)
    te = evaluate_kitti(gt, tr, num_frames=n, preproc="none")
    return {"engine": engine if measurement == "roi" else f"{engine}/{measurement}", "frames": n, "lead_id": lead,
            "id_share": float((ious >= 0.5).mean()), "iou06_share": float((ious >= 0.6).mean()),
            "mean_iou_lead": float(ious.mean()), "ids_over_lead": len(counts),
            "HOTA": te["HOTA"], "MOTA": te["MOTA"], "IDF1": te["IDF1"], "IDSW": te["IDSW"],
            "tracks_per_frame": float(np.mean([len(t) for t in per_frame]))}


def main(argv=None, default_data: Path = DEFAULT_DATA) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=default_data)
    ap.add_argument("--engine", choices=("c", "reference", "both"), default="both")
    ap.add_argument("--detect-every", type=int, default=10)
    ap.add_argument("--measurement", choices=("auto", "roi", "edges", "roi+edges", "both", "all"), default="auto",
                    help="the tracker's per-frame measurement (both: roi and edges, all: the three, "
                         "one row each; auto, the default: as `pyvehtrack track`, roi on the PNG frames, "
                         "roi+edges with --mp4 or --h264; roi until 2026-11-30)")
    ap.add_argument("--mp4", action="store_true",
                    help="track the frames written as one MP4 (OpenCV mp4v, default quality) and decoded")
    ap.add_argument("--h264", action="store_true",
                    help="the same through H.264 (libx264, CRF 23: pyvehtrack.eval.conditions.through_h264)")
    ap.add_argument("--reduce-verified", type=int, choices=(0, 1), default=None, metavar="0|1",
                    help="ShadowConfig.reduce_verified (default: the config's)")
    ap.add_argument("--model", type=Path, metavar="MODEL.npz",
                    help="track with this whole-road model and its settings, as `pyvehtrack track --model` "
                         "(pyvehtrack/models/cnn_gray_l0_big.npz is the command line's default); without it "
                         "the ego-lane detector alone, as `--model none`")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--no-progress", action="store_true")
    a = ap.parse_args(argv)
    if not (a.data / "derived_lidar_lead_box.csv").is_file():
        print(f"error: {a.data} does not hold derived_lidar_lead_box.csv", file=sys.stderr)
        return 2
    if a.model is not None and not a.model.is_file():
        print(f"error: --model {a.model}: no such file", file=sys.stderr)
        return 2
    files, boxes = load(a.data)
    cfg = None
    if a.reduce_verified is not None:
        from ..detector import DetectConfig  # noqa: PLC0415
        from ..shared import ShadowConfig  # noqa: PLC0415
        cfg = DetectConfig(shadow=ShadowConfig(reduce_verified=a.reduce_verified))
    if a.mp4 and a.h264:
        print("error: --mp4 and --h264: one codec at a time", file=sys.stderr)
        return 2
    if a.mp4 or a.h264:
        from .conditions import through_codec  # noqa: PLC0415
        files = through_codec([(k, cv2.imread(str(f))) for k, f in enumerate(files)], "mp4v" if a.mp4 else "h264")
        if files is None:
            print("error: the MP4 lost frames", file=sys.stderr)
            return 2
    engines = ("c", "reference") if a.engine == "both" else (a.engine,)
    # auto: the command line's rule (pyvehtrack.frames) for the frames tracked here
    from ..frames import measurement_for  # noqa: PLC0415
    auto = (measurement_for(lossy=a.mp4 or a.h264),)
    measurements = {"both": ("roi", "edges"), "all": ("roi", "edges", "roi+edges"),
                    "auto": auto}.get(a.measurement, (a.measurement,))
    res = [run(e, files, boxes, a.detect_every, not a.no_progress, m, cfg, model=a.model)
           for e in engines for m in measurements]
    print(f"{'engine':<20}{'lead id':>8}{'id share':>10}{'IoU>=0.6':>10}{'mean IoU':>10}"
          f"{'HOTA':>8}{'MOTA':>8}{'IDF1':>8}{'IDSW':>6}{'trk/frm':>8}")
    for r in res:
        print(f"{r['engine']:<20}{str(r['lead_id']):>8}{r['id_share']:>10.1%}{r['iou06_share']:>10.1%}"
              f"{r['mean_iou_lead']:>10.3f}{r['HOTA']:>8.3f}{r['MOTA']:>8.3f}{r['IDF1']:>8.3f}"
              f"{r['IDSW']:>6}{r['tracks_per_frame']:>8.2f}")
    if a.json:
        a.json.write_text(json.dumps(res, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
