"""Score the lane detector on TuSimple frames with TuSimple's own rules.

    python tools/eval_tusimple.py [--data ../shared/data/tusimple-lane-test100]
                                  [--engine c reference both] [--out lanes_tusimple.json]
                                  [--limit N] [--set FIELD=VALUE ...]

The metric is recomputed as TuSimple's evaluate/lane.py does it (pyvehtrack/eval/lanes.py
says how). Two scores per engine:
  * ego (the project's target): ground truth = the two labelled lanes nearest the image
    centre at the bottom (one per side); prediction = the detector's "left" and "right"
    lines;
  * all (the benchmark's own scoring, for reference): ground truth = every labelled
    lane; prediction = the four slot lines (left-most .. right-most). TuSimple labels up
    to 5 lanes, so a detector that reports the 4 lines around the ego lane is capped
    below 100% here;
  * every: as "all", the prediction being every line of `lanes_all` (the slot lines
    plus the further lines through the vanishing point).
--half A|B scores only the first / last 50 entries of test_label.json (file order):
the split used to choose the lane defaults (tools/tune_lanes.py tunes on A).
Every frame is scored on its own: the tracker is reset before each (the set holds one
frame per clip). Prints a table and writes JSON (summary + per-frame scores).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from ..lane import LaneDetector, tusimple_lanes
from . import lanes as eval_lanes

# Where the project's data sit beside the repository (tools/eval_tusimple.py's default).
DEFAULT_DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "tusimple-lane-test100"


def load_labels(data: Path) -> list[dict]:
    with open(data / "test_label.json") as f:
        return [json.loads(line) for line in f if line.strip()]


def run(engine: str, labels: list[dict], data: Path, overrides: dict) -> dict:
    det = LaneDetector(engine, **overrides)
    frames = []
    t_total = 0.0
    for lab in tqdm(labels, desc=f"TuSimple [{engine}]", unit="frame"):
        img = cv2.imread(str(data / lab["raw_file"]), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise FileNotFoundError(data / lab["raw_file"])
        det.reset()
        t0 = time.perf_counter()
        res = det.detect(img)
        t_total += time.perf_counter() - t0
        hs = lab["h_samples"]
        w = img.shape[1]
        ego_pred = tusimple_lanes(res, hs, w, sides=("left", "right"))
        all_pred = tusimple_lanes(res, hs, w, sides=("left-most", "left", "right", "right-most"))
        ego_gt = eval_lanes.ego_lanes(lab["lanes"], hs, w)
        ego = eval_lanes.bench(ego_pred, ego_gt, hs)
        full = eval_lanes.bench(all_pred, lab["lanes"], hs)
        every = eval_lanes.bench(tusimple_lanes(res, hs, w, sides="all"), lab["lanes"], hs)
        frames.append({"raw_file": lab["raw_file"], "ego": ego, "all": full, "every": every,
                       "n_pred": len(all_pred), "ego_lanes": ego_pred})
    summary = {}
    for key in ("ego", "all", "every"):
        a = np.array([f[key] for f in frames])
        summary[key] = {"accuracy": float(a[:, 0].mean()), "fp": float(a[:, 1].mean()),
                        "fn": float(a[:, 2].mean())}
    summary["ms_per_frame_python_api"] = 1e3 * t_total / max(len(frames), 1)
    return {"engine": engine, "summary": summary, "frames": frames}


def main(argv=None, default_data: Path = DEFAULT_DATA) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=default_data)
    ap.add_argument("--engine", choices=("c", "reference", "both"), default="both")
    ap.add_argument("--out", type=Path, default=Path("lanes_tusimple.json"))
    ap.add_argument("--limit", type=int, default=0, help="score only the first N frames")
    ap.add_argument("--half", choices=("A", "B"), default=None,
                    help="only entries 0-49 (A, the tuning half) or 50-99 (B, held out) of test_label.json")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="override a lane config field (e.g. --set work_width_max=640)")
    args = ap.parse_args(argv)
    labels = load_labels(args.data)
    if args.half:
        labels = labels[:50] if args.half == "A" else labels[50:100]
    if args.limit:
        labels = labels[:args.limit]
    overrides = {}
    for kv in args.set:
        k, _, v = kv.partition("=")
        overrides[k] = int(v)
    engines = ("c", "reference") if args.engine == "both" else (args.engine,)
    results = [run(e, labels, args.data, overrides) for e in engines]
    print(f"\nTuSimple lane metric, {len(labels)} frames of {args.data.name}"
          + (f" (half {args.half})" if args.half else "")
          + (f", config overrides {overrides}" if overrides else ""))
    print(f"{'engine':<10} {'score':<5} {'accuracy':>9} {'FP':>7} {'FN':>7}")
    for r in results:
        for key in ("ego", "all", "every"):
            s = r["summary"][key]
            print(f"{r['engine']:<10} {key:<5} {100 * s['accuracy']:8.2f}% {s['fp']:7.4f} {s['fn']:7.4f}")
    out = {"data": str(args.data), "n_frames": len(labels), "overrides": overrides,
           "metric": "TuSimple evaluate/lane.py rules (pixel_thresh 20 / cos(angle), pt_thresh 0.85)",
           "results": results}
    args.out.write_text(json.dumps(out, indent=1))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
