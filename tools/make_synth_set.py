#!/usr/bin/env python3
"""Write a small synthetic tracking set (frames + exact GT + detection sets) and score the SORT
baseline on it with TrackEval, so later trackers can be scored against it on the same detections.

    python tools/make_synth_set.py OUT [--n 5] [--seed 0] [--size 640x480] [--no-frames]

Layout (one folder per sequence, KITTI tracking text formats):
    OUT/<scenario>_<seed>/frames/000000.png ...   gray uint8 frames
    OUT/<scenario>_<seed>/gt.txt                  GT: frame id Car trunc occ alpha l t r b h w l x y z ry
    OUT/<scenario>_<seed>/meta.json               camera (focal, horizon, height), fps, vehicles
    OUT/<scenario>_<seed>/dets/<setting>.txt      GT boxes perturbed per setting (KITTI result lines, id -1)
    OUT/<scenario>_<seed>/sort/<setting>.txt      SORT tracks on those detections (KITTI tracking results)
    OUT/results.json                              TrackEval figures of SORT per setting (combined and per sequence)

The detection settings are GT boxes with per-edge Gaussian noise, random dropouts and false boxes
(pyvehtrack.synth.gt_detections); everything is deterministic in --seed.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pyvehtrack.eval import tracking as ev  # noqa: E402
from pyvehtrack.eval import synth  # noqa: E402
from pyvehtrack.eval.sort import run_sort, write_tracks_kitti  # noqa: E402

# name -> gt_detections keyword arguments
SETTINGS = {
    "gt": dict(sigma=0.0),
    "noise1": dict(sigma=1.0),
    "noise2_drop10": dict(sigma=2.0, p_drop=0.10),
    "noise2_drop20_fp10": dict(sigma=2.0, p_drop=0.20, p_false=0.10),
}


def write_dets(dets, path):
    with open(path, "w") as fh:
        for t, d in enumerate(dets):
            for l, tp, r, b, s in d:
                fh.write(f"{t} -1 Car -1 -1 -10 {l:.3f} {tp:.3f} {r:.3f} {b:.3f} "
                         f"-1 -1 -1 -1000 -1000 -1000 -10 {s:.4f}\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--n", type=int, default=5, help="number of sequences (cycling through the scenarios)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--size", default="640x480", help="WxH")
    ap.add_argument("--no-frames", action="store_true", help="write GT, detections and tracks only")
    ap.add_argument("--max-age", type=int, default=1, help="SORT max_age (frames a track may go unmatched)")
    ap.add_argument("--min-hits", type=int, default=3, help="SORT min_hits")
    ap.add_argument("--preproc", choices=["kitti", "none"], default="kitti")
    a = ap.parse_args(argv)
    try:
        w, h = (int(v) for v in a.size.lower().split("x"))
    except ValueError:
        ap.error(f"--size must be WxH, got {a.size!r}")
    t0 = time.time()
    seqs = synth.make_set(a.n, a.seed, camera=synth.Camera(w, h))
    pairs = {k: [] for k in SETTINGS}
    for i, seq in enumerate(seqs):
        d = a.out / seq.name
        synth.write_kitti(seq, d, frames=not a.no_frames)
        os.makedirs(d / "dets", exist_ok=True)
        os.makedirs(d / "sort", exist_ok=True)
        for k, kw in SETTINGS.items():
            dets = synth.gt_detections(seq, seed=a.seed * 1000 + i, **kw)
            write_dets(dets, d / "dets" / f"{k}.txt")
            tracks = run_sort(dets, max_age=a.max_age, min_hits=a.min_hits)
            write_tracks_kitti(tracks, d / "sort" / f"{k}.txt")
            pairs[k].append((seq, tracks))
        print(f"{seq.name}: {seq.n_frames} frames, {len(seq.gt)} GT boxes, "
              f"{len(set(seq.gt['id'].tolist()))} vehicles", file=sys.stderr)
    results = {k: ev.evaluate_many(p, preproc=a.preproc, per_sequence=True) for k, p in pairs.items()}
    with open(a.out / "results.json", "w") as fh:
        json.dump({"args": {k: str(v) for k, v in vars(a).items()}, "settings": SETTINGS,
                   "sort": results}, fh, indent=1)
    print(f"SORT (max_age={a.max_age}, min_hits={a.min_hits}) on {len(seqs)} sequences, "
          f"TrackEval preproc={a.preproc}:")
    print(ev.format_results({k: r for k, r in results.items()}))
    print(f"({time.time() - t0:.1f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
