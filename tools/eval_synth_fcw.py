#!/usr/bin/env python3
"""Forward-collision warning on the NHTSA-style synthetic scenes (pyvehtrack.eval.synth_fcw),
end to end: rendered frames -> Detector + Tracker (C, detection every N frames) -> lanes'
vanishing row -> block-scale TTC (ScaleTtc, C) -> RangeEstimator (C) -> warning. Also the
same with the exact boxes (+-0.5 px noise) to separate the range stage from the
detector/tracker.

    PYTHONPATH=. python3 tools/eval_synth_fcw.py [--seeds 10-14] [--mode images|boxes|both|pipeline]
                                                 [--warn-ttc fused|distance] [--json OUT.json]

--mode pipeline: the product's own path instead of the separate stages, pyvehtrack.Pipeline
("c", camera, fps, ego_speed, detect_every; its lanes, tracker, block-scale TTC and range stage
in one vt_pipeline_step), a warning on any track.

--warn-ttc: the TTC the warning decides on, as `pyvehtrack track --warn-ttc`: distance (the
default: the distance/rate TTC) or fused (opt-in since 2026-11-30: the block-scale and
distance/rate TTCs in one).

Per scene and seed: the true TTC at the warning's onset (must be >= the test's TTC: 2.1 s
stopped, 2.0 s slower, 2.4 s decelerating; never a warning on "follow"), with the ego speed
given (20.1 m/s) and unknown. The FCW parameters were chosen on seeds 0-2 with exact boxes;
report other seeds. Also the median relative error of the TTCs (distance/rate, box scale,
block scale and fused) against the true TTC where it is below 6 s.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pyvehtrack.camera import RangeEstimator, ScaleTtc, fuse_ttc, lane_vanishing_row  # noqa: E402
from pyvehtrack.detector import Detector  # noqa: E402
from pyvehtrack.eval import synth_fcw as F  # noqa: E402
from pyvehtrack.lane import LaneDetector  # noqa: E402
from pyvehtrack.pipeline import Pipeline  # noqa: E402
from pyvehtrack.tracker import Tracker  # noqa: E402

KINDS = ("stopped", "slower", "decel", "follow")


def run_pipeline(sc, ego, detect_every, warn_ttc="distance"):
    """The scene through pyvehtrack.Pipeline (C): onset of a warning on any track, and the
    TTC errors of the track nearest the truth's bottom centre."""
    cam = F.camera_file_of(sc.sequence.camera)
    pipe = Pipeline("c", camera=cam, fps=sc.fps, ego_speed=ego, detect_every=detect_every,
                    ttc_points={"fcw_fused": warn_ttc == "fused"})
    gt = sc.sequence.gt
    onset, errs, tracked = None, {"dist": [], "points": [], "fused": []}, 0
    for t, frame in enumerate(sc.sequence.frames):
        tracks = pipe.step(frame).tracks
        if onset is None and any(tr.warning for tr in tracks):
            onset = t
        g = gt[gt["frame"] == t]
        truth = [float(g[k][0]) for k in ("left", "top", "right", "bottom")]
        near = [tr for tr in tracks if abs((tr.box[0] + tr.box[2]) / 2 - (truth[0] + truth[2]) / 2)
                < (truth[2] - truth[0]) / 2]
        if near:
            tracked += 1
            lead = min(near, key=lambda tr: abs(tr.box[3] - truth[3]))
            if np.isfinite(sc.ttc[t]) and sc.ttc[t] < 6:
                for key, v in (("dist", lead.ttc), ("points", lead.ttc_points), ("fused", lead.ttc_fused)):
                    if v is not None:
                        errs[key].append(v / sc.ttc[t] - 1)
    med = lambda e: float(np.median(np.abs(e))) if e else None  # noqa: E731
    return {"onset_frame": onset, "onset_ttc": None if onset is None else round(float(sc.ttc[onset]), 3),
            "test_ttc": sc.test_ttc, "frames": len(sc.z), "lead_tracked": tracked,
            "ttc_dist_rel_median": med(errs["dist"]), "ttc_scale_rel_median": None,
            "ttc_points_rel_median": med(errs["points"]), "ttc_fused_rel_median": med(errs["fused"])}


def run(sc, seed, ego, mode, detect_every, warn_ttc="distance"):
    if mode == "pipeline":
        return run_pipeline(sc, ego, detect_every, warn_ttc)
    cam = F.camera_file_of(sc.sequence.camera)
    w, h = sc.sequence.camera.width, sc.sequence.camera.height
    est = RangeEstimator(cam, (w, h), sc.fps)
    blocks = ScaleTtc(sc.fps)
    gt = sc.sequence.gt
    rng = np.random.default_rng([seed, 7])
    if mode == "images":
        trk = Tracker(detect_every=detect_every, detector=Detector())
        lanes = LaneDetector()
    onset, ttc_d, ttc_s, ttc_p, ttc_f, tracked = None, [], [], [], [], 0
    for t in range(len(sc.z)):
        g = gt[gt["frame"] == t]
        truth = [float(g[k][0]) for k in ("left", "top", "right", "bottom")]
        if mode == "boxes":
            pairs = [(1, [int(round(v + rng.normal(0, 0.5))) for v in truth])]
        else:
            frame = sc.sequence.frames[t]
            est.update_pitch(lane_vanishing_row(lanes.detect(frame)))
            pairs = [(tr.id, list(tr.box)) for tr in trk.step(frame) if tr.state != "tentative"]
        pts = {o.id: o.ttc for o in blocks.step(sc.sequence.frames[t], pairs)}
        outs = est.step(pairs, ego, ttc_points=pts if warn_ttc == "fused" else None)
        # the lead: the track whose bottom centre is nearest the truth's
        lead = None
        if outs:
            cx, b = (truth[0] + truth[2]) / 2, truth[3]
            k = int(np.argmin([abs((p[1][0] + p[1][2]) / 2 - cx) + abs(p[1][3] - b) for p in pairs]))
            if abs((pairs[k][1][0] + pairs[k][1][2]) / 2 - cx) < (truth[2] - truth[0]) / 2:
                lead = outs[k]
        if any(o.warning for o in outs) and onset is None:
            onset = t
        if lead is not None:
            tracked += 1
            if np.isfinite(sc.ttc[t]) and sc.ttc[t] < 6:
                if lead.ttc_dist is not None:
                    ttc_d.append(lead.ttc_dist / sc.ttc[t] - 1)
                if lead.ttc_scale is not None:
                    ttc_s.append(lead.ttc_scale / sc.ttc[t] - 1)
                if pts.get(lead.id) is not None:
                    ttc_p.append(pts[lead.id] / sc.ttc[t] - 1)
                fused = fuse_ttc(pts.get(lead.id), lead.ttc_dist)
                if fused is not None:
                    ttc_f.append(fused / sc.ttc[t] - 1)
    return {"onset_frame": onset, "onset_ttc": None if onset is None else round(float(sc.ttc[onset]), 3),
            "test_ttc": sc.test_ttc, "frames": len(sc.z), "lead_tracked": tracked,
            "ttc_dist_rel_median": float(np.median(np.abs(ttc_d))) if ttc_d else None,
            "ttc_scale_rel_median": float(np.median(np.abs(ttc_s))) if ttc_s else None,
            "ttc_points_rel_median": float(np.median(np.abs(ttc_p))) if ttc_p else None,
            "ttc_fused_rel_median": float(np.median(np.abs(ttc_f))) if ttc_f else None}


def verdict(r, kind) -> bool:
    if kind == "follow":
        return r["onset_frame"] is None
    return r["onset_ttc"] is not None and r["onset_ttc"] >= r["test_ttc"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="10-14", help="a-b or a,b,c (default 10-14; 0-2 were for tuning)")
    ap.add_argument("--mode", choices=("images", "boxes", "both", "pipeline"), default="both")
    ap.add_argument("--detect-every", type=int, default=5)
    ap.add_argument("--warn-ttc", choices=("distance", "fused"), default="distance")
    ap.add_argument("--json", type=Path, default=Path("eval_synth_fcw.json"))
    a = ap.parse_args(argv)
    if "-" in a.seeds:
        lo, hi = (int(v) for v in a.seeds.split("-"))
        seeds = list(range(lo, hi + 1))
    else:
        seeds = [int(v) for v in a.seeds.split(",")]
    modes = ("boxes", "images") if a.mode == "both" else (a.mode,)
    rows = []
    for mode in modes:
        for kind in KINDS:
            for seed in seeds:
                sc = F.make_fcw_scene(kind, seed, fps=30)
                for ego_name, ego in (("known", F.EGO_SPEED), ("unknown", None)):
                    r = run(sc, seed, ego, mode, a.detect_every, a.warn_ttc)
                    r.update(mode=mode, kind=kind, seed=seed, ego=ego_name, ok=verdict(r, kind),
                             warn_ttc=a.warn_ttc)
                    rows.append(r)
                    print(f"{mode:6s} {kind:7s} seed {seed:3d} ego {ego_name:7s}: onset TTC "
                          f"{r['onset_ttc']} (test {r['test_ttc']}) {'ok' if r['ok'] else 'FAIL'}; "
                          f"TTC err dist {r['ttc_dist_rel_median']}, scale {r['ttc_scale_rel_median']}, "
                          f"blocks {r['ttc_points_rel_median']}, fused {r['ttc_fused_rel_median']}",
                          flush=True)
    a.json.write_text(json.dumps(rows, indent=1))
    for mode in modes:
        sub = [r for r in rows if r["mode"] == mode]
        ok = sum(r["ok"] for r in sub)
        med = lambda k: np.median([r[k] for r in sub if r[k] is not None]) if any(  # noqa: E731
            r[k] is not None for r in sub) else float("nan")
        print(f"[{mode}] warning on the {a.warn_ttc} TTC: {ok}/{len(sub)} runs pass; median TTC rel. "
              f"error: distance/rate {med('ttc_dist_rel_median'):.1%}, box scale "
              f"{med('ttc_scale_rel_median'):.1%}, blocks {med('ttc_points_rel_median'):.1%}, fused "
              f"{med('ttc_fused_rel_median'):.1%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
