#!/usr/bin/env python3
"""Cross-validated choice of the lane defaults on tusimple-lane-test100.

Split by file order of test_label.json: entries 0..49 = half A, 50..99 = half B
(fixed before tuning). A coordinate search (one field at a time over a few values,
repeated) maximises the ego accuracy (TuSimple rules, pyvehtrack.eval.lanes) of the C
engine on the tuning half; the figure to report is the same config on the other half.

    python tools/tune_lanes.py [--data DIR] [--tune A|B] [--rounds 2] [--kitti-guard] [--range-guard]
                               [--start EARLIER | FIELD=VALUE ...]

--kitti-guard: a candidate is taken only if tracking the KITTI lead car on frames
0-38 (the KITTI tuning part, pyvehtrack.eval.kitti_track, C engine) keeps its IoU >= 0.6
share at least at the start's figure (the defaults, or --start). Without it a set tuned on half B lost the
KITTI lead car (96.2% -> 70.5% of the frames): the lane stage also serves other cameras.
--range-guard: and only if the lead car's distance P95 and fused-TTC median on frames 0-38
(tools/eval_kitti_range.py, its offset refitted on 0-38) stay at most the start's
figures: the vanishing row sets the camera pitch, which the tracking guard does not see
(the set tuned on B with --kitti-guard alone scored fused TTC 14.5% on 0-38 against 10.6%,
and 17.9% on the held-out frames). Frames 39-77 stay held out for the report.

    python tools/tune_lanes.py --tune B --kitti-guard --range-guard --start EARLIER   # the shipped defaults
    -> grad_min 14, mark_wmin_bottom_permille 4, top_margin_permille 25; B 89.21%, A (unseen) 89.36%
    python tools/tune_lanes.py --tune A --kitti-guard --range-guard --start EARLIER   # the other fold
    -> top_margin_permille 43, win_bottom_permille 15; A 90.48%, B (unseen) 87.96%
(both searched from the defaults before 2026-11-30, which were tuned on all 100 frames.)
"""
import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from pyvehtrack.eval import lanes as ev  # noqa: E402
from pyvehtrack.lane import LaneDetector, default_config, tusimple_lanes  # noqa: E402

# Fields searched, with the values tried (the current default is always among them).
GRID = {
    "hough_top_permille": [400, 450, 500, 550, 600],
    "grad_min": [8, 10, 12, 14, 16],
    "noise_gain_q4": [32, 40, 48, 56, 64],
    "mark_w_bottom_permille": [30, 35, 40, 45, 50],
    "mark_wmin_bottom_permille": [4, 6, 8, 10, 12],
    "vote_min_permille": [60, 80, 100, 120],
    "merge_permille": [12, 16, 19, 24, 30],
    "min_dtheta_qdeg": [32, 40, 48, 56],
    "ego_theta_max_qdeg": [240, 250, 260, 270, 280],
    "ego_vote_permille": [300, 400, 500, 600],
    "vp_tol_permille": [10, 15, 20, 25],
    "lane_w_min_permille": [200, 250, 300],
    "top_margin_permille": [25, 31, 37, 43, 50],
    "win_bottom_permille": [15, 20, 25, 30],
    "seg_count_permille": [100, 150, 200],
    "solo_vote_permille": [1000, 1250, 1500, 2000, 2500, 3000],
}


# The lane defaults before 2026-11-30 (tuned on all 100 frames), where the search of the
# shipped set started: --start EARLIER.
EARLIER = {"grad_min": 12, "mark_wmin_bottom_permille": 8, "top_margin_permille": 37}


def load(data, idx):
    with open(data / "test_label.json") as f:
        labels = [json.loads(line) for line in f if line.strip()]
    out = []
    for i in idx:
        lab = labels[i]
        img = cv2.imread(str(data / lab["raw_file"]), cv2.IMREAD_GRAYSCALE)
        out.append((img, lab))
    return out


def score(cfg, frames, engine="c"):
    det = LaneDetector(engine, cfg=cfg)
    acc = []
    for img, lab in frames:
        det.reset()
        res = det.detect(img)
        hs = lab["h_samples"]
        pred = tusimple_lanes(res, hs, img.shape[1], sides=("left", "right"))
        acc.append(ev.bench(pred, ev.ego_lanes(lab["lanes"], hs, img.shape[1]), hs))
    a = np.array(acc)
    return float(a[:, 0].mean()), float(a[:, 1].mean()), float(a[:, 2].mean())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "tusimple-lane-test100")
    ap.add_argument("--tune", choices=("A", "B"), default="A")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--only", nargs="*", default=None,
                    help="search only these fields, starting from the current defaults")
    ap.add_argument("--kitti-guard", action="store_true",
                    help="reject candidates that lower KITTI lead-car tracking on frames 0-38")
    ap.add_argument("--range-guard", action="store_true",
                    help="also reject candidates that raise the KITTI lead car's distance P95 or fused-TTC "
                         "median on frames 0-38 (tools/eval_kitti_range.py, offset refitted on 0-38)")
    ap.add_argument("--kitti", type=Path, default=ROOT.parent / "shared" / "data" / "kitti-raw-sfnd-ttc")
    ap.add_argument("--start", nargs="+", default=[], metavar="FIELD=VALUE",
                    help="start the search (and set the guards' floors) from the defaults with these fields "
                         "changed; EARLIER is the set before 2026-11-30")
    args = ap.parse_args()
    kv = EARLIER if args.start == ["EARLIER"] else dict(x.split("=", 1) for x in args.start)
    start = replace(default_config(), **{k: int(v) for k, v in kv.items()})
    guard = None
    rguard = None
    if args.range_guard:
        import contextlib  # noqa: PLC0415
        import io  # noqa: PLC0415
        import tempfile  # noqa: PLC0415
        sys.path.insert(0, str(ROOT / "tools"))
        import eval_kitti_range as ekr  # noqa: PLC0415

        def krange(c):
            """(distance P95, fused TTC median) on KITTI frames 0-38 with lane config c."""
            d = default_config()
            kv = [f"{k}={getattr(c, k)}" for k in GRID if getattr(c, k) != getattr(d, k)]
            with tempfile.TemporaryDirectory() as t:
                out = Path(t) / "r.json"
                argv = ["--data", str(args.kitti), "--json", str(out)] + (["--lane-set", *kv] if kv else [])
                with contextlib.redirect_stdout(io.StringIO()):
                    rc = ekr.main(argv)
                if rc != 0:
                    raise SystemExit(f"tune_lanes: eval_kitti_range failed ({rc})")
                s = json.loads(out.read_text())["summaries"]["offset"]["first_half"]
            return (s["distance_filtered_rel"].get("p95", float("inf")),
                    s["ttc_fused_rel"].get("median", float("inf")))
        rguard = krange(start)
        print(f"KITTI frames 0-38 at the start: distance P95 {100 * rguard[0]:.1f}%, fused TTC median "
              f"{100 * rguard[1]:.1f}% (the ceilings)", flush=True)
    if args.kitti_guard:
        from pyvehtrack.eval import kitti_track as kt  # noqa: PLC0415
        from pyvehtrack.lane import LaneDetector as LD  # noqa: PLC0415
        kfiles, kboxes = kt.load(args.kitti)
        kimgs = [cv2.imread(str(f)) for f in kfiles]

        def kitti(c, part):
            idx = range(len(kimgs))[part]   # run() numbers the frames it is given from 0
            r = kt.run("c", [(i, kimgs[k]) for i, k in enumerate(idx)], {i: kboxes[k] for i, k in enumerate(idx)},
                       10, False, lane_detector=LD("c", cfg=c))
            return r["iou06_share"]
        guard = kitti(start, slice(0, 39))
        print(f"KITTI lead car, frames 0-38, IoU >= 0.6: {100 * guard:.1f}% (the floor)", flush=True)
    A, B = load(args.data, range(0, 50)), load(args.data, range(50, 100))
    tune, held = (A, B) if args.tune == "A" else (B, A)
    cfg = start
    best = score(cfg, tune)
    print(f"start: tune {best}, held-out {score(cfg, held)}", flush=True)
    for r in range(args.rounds):
        changed = False
        for name, vals in GRID.items():
            if args.only is not None and name not in args.only:
                continue
            for v in vals:
                if v == getattr(cfg, name):
                    continue
                c2 = replace(cfg, **{name: v})
                s = score(c2, tune)
                # Strictly better accuracy, or equal accuracy with fewer FP + FN.
                if s[0] > best[0] + 1e-9 or (abs(s[0] - best[0]) <= 1e-9 and s[1] + s[2] < best[1] + best[2] - 1e-9):
                    if guard is not None:
                        k = kitti(c2, slice(0, 39))
                        if k < guard - 1e-9:
                            print(f"round {r}: {name}={v} -> tune {s} rejected: KITTI 0-38 {100 * k:.1f}%",
                                  flush=True)
                            continue
                    if rguard is not None:
                        k = krange(c2)
                        if k[0] > rguard[0] + 1e-9 or k[1] > rguard[1] + 1e-9:
                            print(f"round {r}: {name}={v} -> tune {s} rejected: KITTI 0-38 distance P95 "
                                  f"{100 * k[0]:.1f}%, fused TTC {100 * k[1]:.1f}%", flush=True)
                            continue
                    cfg, best, changed = c2, s, True
                    print(f"round {r}: {name}={v} -> tune {s}", flush=True)
        if not changed:
            break
    d = default_config()
    diff = {k: getattr(cfg, k) for k in GRID if getattr(cfg, k) != getattr(start, k)}
    print("chosen (changes from the start):", diff)
    print("differs from the current defaults in:",
          {k: getattr(cfg, k) for k in GRID if getattr(cfg, k) != getattr(d, k)})
    print(f"tuning half {args.tune}: accuracy {100 * best[0]:.2f}% FP {best[1]:.4f} FN {best[2]:.4f}")
    h = score(cfg, held)
    print(f"held-out half {'B' if args.tune == 'A' else 'A'}: accuracy {100 * h[0]:.2f}% FP {h[1]:.4f} FN {h[2]:.4f}")
    if guard is not None:
        print(f"KITTI lead car IoU >= 0.6: frames 0-38 {100 * kitti(cfg, slice(0, 39)):.1f}%, held-out 39-77 "
              f"{100 * kitti(cfg, slice(39, 78)):.1f}% (start: {100 * kitti(start, slice(39, 78)):.1f}%)")


if __name__ == "__main__":
    main()
