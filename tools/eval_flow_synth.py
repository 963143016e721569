#!/usr/bin/env python3
"""Overtaking detection on the synthetic motion scenes (pyvehtrack.synth_motion), the issue-9 targets:
an overtaking vehicle reported within 5 frames of being half in view, no false overtakes on traffic that
keeps its distance.

Split, fixed by seed before any tuning: seeds 0-9 are the tuning part (the defaults were checked on
them), seeds 100-129 the evaluation part reported in the README (`--split eval`, the default).
`--split fresh` (seeds 300-329) was added for the pipeline's hand-over after its first eval run had
shown false hand-overs that led to a change of its rule: the figure on seeds nobody looked at. It showed
one more false hand-over of the same kind, which led to a second change (the rule's history starts over
when a track's box jumps); `--split fresh2` (seeds 400-429) is the figure after it. `--split fresh3`
(seeds 500-529) checks the eval part's 59/60 on seeds nobody had looked at: the defaults give 56/60
there (4 reports 1-4 frames late, 0 false). A lower change gate (`--set diff_thresh=8`, suggested by
the eval part's one late report, seed 102: a dark car with little texture) gives 57/60, so it was not
taken. 8-connected blobs (flow.h) gave 60/60 on both 100-129 and 500-529; `--split fresh4` (seeds
600-629) is the figure after that change, run once: 60/60, 0 false.

Per scenario and seed:
- overtake_left (sides=left, right-hand traffic) / overtake_right (sides=right): the first frame with
  an overtaking hypothesis on the vehicle's side that overlaps its GT box; latency = that frame minus
  the first frame where the vehicle is half in view (GT truncation <= 0.5; negative = earlier).
  Hit if latency <= 5. False: hypotheses overlapping no GT box of the overtaking car.
- keep_distance and ego_overtakes (sides=both, the stricter setting): every hypothesis is false.

With --model, each overtaking sequence also hands the vehicle to the geometric model as the paper does
(sec. 6): on the first frame with a report where the vehicle is at least 90 % in view, VehicleModel.fit_flow on
the first hypothesis (road: a 1.78 m wide vehicle on the synthetic flat road, +-30 %), IoU with the GT box.

    PYTHONPATH=. python3 tools/eval_flow_synth.py [--split eval|tune] [--engine c|reference] [--set k=v ...]
                                                  [--model] [--scenarios a,b]

--pipeline: the reverse case through vt_pipeline_step (issue 9): Pipeline(sources=("flow",)) with the
default flow settings, fed boxes made from the ground truth on every frame (synth.gt_detections: 1 px
noise, 10 % dropped, none once more than 30 % of a car is cut off by the border, as a detector that
needs most of the car), with the hand-over on (the default) and off (--handover off: the tracker alone,
the behaviour before it was wired). On ego_overtakes_left/right (the slower car, id 1, leaves by that
side) per sequence: one id for it from its first report to its last; the GT truncation of the last
frame it is reported (how far out it is followed); frames where it is at most 65 % cut off and not
reported after its first report (misses); frames with a hand-over after it has gone (ghosts). On
overtake_left/right and keep_distance: tracks handed over (all false: none of those cars is overtaken
by the ego car).

    PYTHONPATH=. python3 tools/eval_flow_synth.py --pipeline [--handover on|off] [--split eval|tune]
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from pyvehtrack import synth_motion as SM
from pyvehtrack.flow import OvertakingDetector

SPLITS = {"tune": range(0, 10), "eval": range(100, 130), "fresh": range(300, 330), "fresh2": range(400, 430),
          "fresh3": range(500, 530), "fresh4": range(600, 630)}


def _overlaps(box, g) -> bool:
    return not (box[2] < g["left"] or box[0] > g["right"] or box[3] < g["top"] or box[1] > g["bottom"])


def _iou(a, b) -> float:
    iw, ih = min(a[2], b[2]) - max(a[0], b[0]) + 1, min(a[3], b[3]) - max(a[1], b[1]) + 1
    if iw <= 0 or ih <= 0:
        return 0.0
    i = iw * ih
    return i / ((a[2] - a[0] + 1) * (a[3] - a[1] + 1) + (b[2] - b[0] + 1) * (b[3] - b[1] + 1) - i)


def run_one(scenario: str, seed: int, engine: str, overrides: dict, model: bool = False) -> dict:
    seq = SM.make_sequence(scenario, seed)
    vm = None
    if model and scenario.startswith("overtake"):
        from pyvehtrack.vehicle_model import VehicleModel
        cam = seq.camera
        k = 1.78 / cam.cam_height
        y0, y1 = int(round(cam.yh + 40)), int(round(cam.yh + 240))
        vm = VehicleModel(road=(y0, int(round(k * (y0 - cam.yh))), y1, int(round(k * (y1 - cam.yh)))))
    model_iou = None
    sides = {"overtake_left": "left", "overtake_right": "right"}.get(scenario, "both")
    det = OvertakingDetector(engine, sides=sides, **overrides)
    first, false_frames, false_hyps = None, 0, 0
    for t in range(seq.n_frames):
        res = det.step(seq.frame(t))
        gt = seq.gt[(seq.gt["frame"] == t) & (seq.gt["id"] == 1)]
        bad = 0
        for h in res.hyps:
            ok = scenario.startswith("overtake") and h.side == sides and any(_overlaps(h.box, g) for g in gt)
            if ok and first is None:
                first = t
            bad += 0 if ok else 1
        false_hyps += bad
        false_frames += 1 if bad else 0
        if vm is not None and model_iou is None and res.hyps and len(gt) and gt[0]["truncation"] <= 0.1:
            fit = vm.fit_flow(seq.frame(t), res.hyps[0])
            model_iou = _iou(fit.box, [gt[0][q] for q in ("left", "top", "right", "bottom")])
    out = {"scenario": scenario, "seed": seed, "frames": seq.n_frames, "false_frames": false_frames,
           "false_hyps": false_hyps}
    if scenario.startswith("overtake"):
        half = SM.half_in_view(seq, 1)
        out.update(half_in_view=half, first_report=first,
                   latency=None if first is None or half is None else first - half, model_iou=model_iou)
    return out


PIPE_SCENARIOS = ("ego_overtakes_left", "ego_overtakes_right", "overtake_left", "overtake_right",
                  "keep_distance")


def _gt_box(seq, t, vid):
    g = seq.gt[(seq.gt["frame"] == t) & (seq.gt["id"] == vid)]
    if not len(g):
        return None, None
    return [float(g[0][k]) for k in ("left", "top", "right", "bottom")], float(g[0]["truncation"])


def run_pipeline(scenario: str, seed: int, engine: str, handover: bool) -> dict:
    from pyvehtrack import synth as S
    from pyvehtrack.pipeline import Pipeline
    seq = SM.make_sequence(scenario, seed)
    dets = S.gt_detections(seq, sigma=1.0, p_drop=0.1, seed=seed, max_truncation=0.3)
    p = Pipeline(engine, sources=("flow",), road="fixed", detect_every=1, flow={"handover": handover})
    ids, first, last_trunc, misses, ghosts, gone, handovers = set(), None, None, 0, 0, None, set()
    for t in range(seq.n_frames):
        r = p.step(seq.frame(t), detections=np.round(dets[t][:, :4]).astype(np.int64))
        handovers |= {x.id for x in r.tracks if x.state == "handover"}
        if not scenario.startswith("ego_overtakes"):
            continue
        g, trunc = _gt_box(seq, t, 1)
        if g is None:
            gone = t if gone is None else gone
            ghosts += first is not None and any(x.state == "handover" for x in r.tracks)
            continue
        on = [x for x in r.tracks if _overlaps(x.box, {"left": g[0], "top": g[1], "right": g[2], "bottom": g[3]})]
        if on:
            first = t if first is None else first
            last_trunc = trunc
            ids |= {x.id for x in on}
        elif first is not None and trunc <= 0.65:
            misses += 1
    return {"scenario": scenario, "seed": seed, "handover": handover, "frames": seq.n_frames,
            "ids": sorted(ids), "first": first, "last_truncation": last_trunc, "misses": misses,
            "ghost_frames": ghosts, "handovers": sorted(handovers)}


def main_pipeline(a, seeds) -> int:
    scen = a.scenarios.split(",") if a.scenarios else list(PIPE_SCENARIOS)
    ho = a.handover == "on"
    rows = [run_pipeline(sc, s, a.engine, ho) for sc in scen for s in seeds]
    print(f"pipeline, split {a.split} (seeds {seeds[0]}..{seeds[-1]}), engine {a.engine}, hand-over {a.handover}")
    print("| scenario | sequences | one id | GT truncation at the last report: median / min | misses "
          "(<= 65 % cut off) | ghost frames | tracks handed over |")
    print("|---|---|---|---|---|---|---|")
    for sc in scen:
        rs = [r for r in rows if r["scenario"] == sc]
        n_ho = sum(len(r["handovers"]) for r in rs)
        if sc.startswith("ego_overtakes"):
            one = sum(1 for r in rs if len(r["ids"]) == 1)
            lt = [r["last_truncation"] for r in rs if r["last_truncation"] is not None]
            lt_s = f"{np.median(lt):.2f} / {min(lt):.2f}" if lt else "-"
            print(f"| {sc} | {len(rs)} | {one}/{len(rs)} | {lt_s} | {sum(r['misses'] for r in rs)} | "
                  f"{sum(r['ghost_frames'] for r in rs)} | {n_ho} |")
        else:
            print(f"| {sc} | {len(rs)} | - | - | - | - | {n_ho} (false) |")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--split", choices=sorted(SPLITS), default="eval")
    ap.add_argument("--engine", choices=["c", "reference"], default="c")
    ap.add_argument("--set", action="append", default=[], metavar="K=V", help="flow cfg override")
    ap.add_argument("--json", help="write the per-sequence records here")
    ap.add_argument("--n", type=int, default=None, help="only the first N seeds of the split")
    ap.add_argument("--model", action="store_true", help="also hand each overtaking vehicle to the model")
    ap.add_argument("--scenarios", help="comma-separated subset of " + ",".join(SM.SCENARIOS))
    ap.add_argument("--pipeline", action="store_true", help="the reverse hand-over through vt_pipeline_step")
    ap.add_argument("--handover", choices=["on", "off"], default="on", help="with --pipeline")
    a = ap.parse_args(argv)
    overrides = {}
    for kv in a.set:
        k, _, v = kv.partition("=")
        overrides[k] = int(v)
    seeds = list(SPLITS[a.split])[: a.n]
    if a.pipeline:
        return main_pipeline(a, seeds)
    scen = a.scenarios.split(",") if a.scenarios else list(SM.SCENARIOS)
    rows = [run_one(sc, s, a.engine, overrides, a.model) for sc in scen for s in seeds]
    print(f"split {a.split} (seeds {seeds[0]}..{seeds[-1]}), engine {a.engine}, overrides {overrides or 'none'}")
    print("| scenario | sequences | reported within 5 frames of half in view | latency median / max (frames) "
          "| frames with a false overtake |")
    print("|---|---|---|---|---|")
    for sc in scen:
        rs = [r for r in rows if r["scenario"] == sc]
        frames = sum(r["frames"] for r in rs)
        ff = sum(r["false_frames"] for r in rs)
        if sc.startswith("overtake"):
            lat = [r["latency"] for r in rs if r["latency"] is not None]
            hit = sum(1 for v in lat if v <= 5)
            lat_s = f"{np.median(lat):+.0f} / {max(lat):+d}" if lat else "-"
            print(f"| {sc} | {len(rs)} | {hit}/{len(rs)} | {lat_s} | {ff}/{frames} |")
        else:
            print(f"| {sc} | {len(rs)} | - | - | {ff}/{frames} |")
    if a.model:
        ious = [r["model_iou"] for r in rows if r.get("model_iou") is not None]
        n_ov = sum(1 for r in rows if r["scenario"].startswith("overtake"))
        if ious:
            v = np.array(ious)
            print(f"model from the flow hypothesis: {len(v)}/{n_ov} vehicles fitted, IoU >= 0.5 {np.mean(v >= 0.5):.1%}, "
                  f">= 0.7 {np.mean(v >= 0.7):.1%}, median {np.median(v):.3f}")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
