#!/usr/bin/env python3
"""Lead-car distance, TTC and pitch on the 78 KITTI frames of ../shared/data/kitti-raw-sfnd-ttc,
against the lidar (derived_lidar_lead_distance.csv).

    PYTHONPATH=. python3 tools/eval_kitti_range.py [--data DIR] [--engine c|reference]
                                                   [--json OUT.json] [--png OUT.png]
                                                   [--model offset|height]
                                                   [--codec none|mp4v|h264] [--measurement auto|roi|roi+edges]

Pipeline (all pyvehtrack, nothing fitted on this sequence): Detector + Tracker (detection
every 10th frame, the tracker's defaults), LaneDetector for the vanishing row of the ego
lanes -> pitch (vt_pitch_update), RangeEstimator (vt_range_step) per track. Camera: f, cx,
cy from P_rect_00 of calib_sfnd_2011_09_26.txt, 1.65 m above the road, nominal pitch 0.

Which track is the lead: per frame, the track whose box has the largest IoU (>= 0.5) with the
lidar lead box (derived_lidar_lead_box.csv). The lidar box is used only for this
association, never for a distance. Frames with no such track count as "not tracked".

Truth: the lidar's closest point in the ego-lane box (ego_lane_min_x_m, the rear bumper), in
the lidar frame, which sits 0.27 m behind the camera: camera distance = lidar - 0.27 m.
Lidar TTC: the slope of a least-squares line through the lidar distances of frames t-2..t+2
(the "smoothed over 5 frames" of the issue), TTC = d_t / -slope, at 10 Hz; only where the
lidar closes faster than 0.1 m/s (else there is no finite TTC to compare).

Every parameter of the range stage is its default, chosen before this sequence was run
(NHTSA thresholds, 3 m/s^2 relative acceleration noise, +-1 px row error, 1.8 m assumed width
only for the cross-check); the figures are reported for all frames, and for each half.

Distance models, each with one parameter fitted on frames 0-38 (the first half) only:
"offset" subtracts rear_offset (m) from eq. 1; "height" reads the box's bottom edge as a line
bottom_height (m) above the road (eq. 1 with the camera height minus it: the tracker's box
ends at the bumper's lower edge, not at the tyres' road contact). Both are printed; --model
picks the one in the JSON rows and the PNG.

Four TTCs, side by side: the range filter's distance / rate, the box's width change over 5
frames (both vt_range_step), and the scale of SAD-matched blocks inside the box over 5 frames
(vt_ttc_step, pyvehtrack.camera.ScaleTtc; its grid, texture, lag and anchor radius were chosen
on frames 0-38), computed twice: by the stand-alone stage over the collected tracks and inside
vt_pipeline_step (Tracker(ttc_points=True): vt_pipeline_set_ttc_ws, "TTC block scale (pipeline)"),
which must agree frame by frame (printed). Each against the lidar TTC of the issue (5-frame centred fit), and for
diagnosis against a trailing 5-frame fit (t-4..t, what a causal estimate can know) and a
9-frame centred fit (less lidar noise); "lidar p05 vs lidar min" is the lidar's own spread.
The fourth, "TTC fused", is the pipeline's rule (vt_pipe_track.ttc_fused_q16,
pyvehtrack.camera.fuse_ttc) on the first and the third: 0.3 x distance/rate + 0.7 x block
scale where both are known, else the known one; its weight was chosen on frames 0-38 only
(the printed table, fuse_weight_table).

The last lines ("tune_0_38", "held_out_39_77", "all") put the block TTC with its current
defaults (nearest-track slots, scale prior past a 10 % gate, fallback lags down to 2, no
scale when fewer than half the blocks match: chosen on frames 0-38) beside the same stage
with the earlier defaults (EARLIER_POINTS, the README's earlier figures), with the number of
lidar-TTC frames that have a block TTC, and the lidar's 9-frame fit scored against its own
5-frame TTC: what a perfectly smooth estimate would score against this truth.
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pyvehtrack.camera import Camera, RangeEstimator, ScaleTtc, fuse_ttc, lane_vanishing_row  # noqa: E402
from pyvehtrack.detector import Detector  # noqa: E402
from pyvehtrack.lane import LaneDetector  # noqa: E402
from pyvehtrack.tracker import Tracker  # noqa: E402

DEFAULT_DATA = Path("/work/shared/data/kitti-raw-sfnd-ttc")
LIDAR_BEHIND_CAMERA_M = 0.27
CAM_HEIGHT_M = 1.65
FPS = 10.0


def kitti_camera(data: Path, w: int, h: int) -> Camera:
    for line in (data / "calib_sfnd_2011_09_26.txt").read_text().splitlines():
        if line.startswith("P_rect_00"):
            v = [float(t) for t in line.split(":", 1)[1].split()]
            return Camera(fx=v[0], fy=v[5], cx=v[2], cy=v[6], height_m=CAM_HEIGHT_M, pitch_deg=0.0,
                          image_size=(w, h))
    raise SystemExit("no P_rect_00 in the calibration file")


def iou(box, gt) -> float:
    """IoU of an inclusive pixel box and the lidar's continuous box."""
    l, t, r, b = box[0], box[1], box[2] + 1, box[3] + 1
    ix = max(0.0, min(r, gt[2]) - max(l, gt[0]))
    iy = max(0.0, min(b, gt[3]) - max(t, gt[1]))
    inter = ix * iy
    union = (r - l) * (b - t) + (gt[2] - gt[0]) * (gt[3] - gt[1]) - inter
    return inter / union if union > 0 else 0.0


def lidar_ttc(d: np.ndarray, dt: float, half: int = 2) -> np.ndarray:
    """TTC from the slope of a least-squares line through frames t-half..t+half."""
    out = np.full(len(d), np.nan)
    t = np.arange(2 * half + 1) * dt
    for i in range(half, len(d) - half):
        slope = np.polyfit(t, d[i - half:i + half + 1], 1)[0]
        if slope < -0.1:
            out[i] = d[i] / -slope
    return out


def lidar_ttc_trailing(d: np.ndarray, dt: float) -> np.ndarray:
    """The same least-squares TTC over frames t-4..t: no look-ahead, as a causal estimator."""
    out = np.full(len(d), np.nan)
    t = np.arange(5) * dt
    for i in range(4, len(d)):
        slope = np.polyfit(t, d[i - 4:i + 1], 1)[0]
        if slope < -0.1:
            out[i] = d[i] / -slope
    return out


def stats(rel: np.ndarray) -> dict:
    rel = np.abs(rel[np.isfinite(rel)])
    if len(rel) == 0:
        return {"n": 0}
    return {"n": int(len(rel)), "median": float(np.median(rel)), "p95": float(np.percentile(rel, 95)),
            "mean": float(np.mean(rel))}


def collect(data: Path, engine: str, lane_cfg=None, codec: str = "none", measurement: str = "roi"):
    """Detector + tracker + lanes over the sequence: per frame the tracks, the vanishing row
    and the lead track's id (by IoU with the lidar box). codec: "mp4v" or "h264" runs on the
    frames written as one video and decoded (pyvehtrack.eval.conditions.through_codec);
    measurement: the tracker's (Tracker(measurement=...))."""
    files = sorted((data / "image_02" / "data").glob("*.png"))
    lbox = {int(r["frame"]): [float(r[k]) for k in ("left", "top", "right", "bottom")]
            for r in csv.DictReader(open(data / "derived_lidar_lead_box.csv"))}
    images = [(i, cv2.imread(str(p), cv2.IMREAD_COLOR)) for i, p in enumerate(files)]
    if codec != "none":
        from pyvehtrack.eval.conditions import through_codec  # noqa: PLC0415
        images = through_codec(images, codec)
        if images is None:
            raise RuntimeError(f"the {codec} video lost frames")
    h, w = images[0][1].shape[:2]
    det = Detector(engine=engine, lane_detector=LaneDetector(engine=engine, cfg=lane_cfg))
    trk = Tracker(engine=engine, detect_every=10, detector=det, ttc_points=True, fps=FPS,
                  measurement=measurement)
    lanes = LaneDetector(engine=engine, cfg=lane_cfg)
    frames = []
    for i, img in images:
        vp = lane_vanishing_row(lanes.detect(img))
        tracks = trk.step(img)
        best, best_iou = None, 0.5
        for t in tracks:
            v = iou(t.box, lbox[i])
            if v >= best_iou:
                best, best_iou = t, v
        frames.append({"tracks": [(t.id, list(t.box)) for t in tracks], "vp": vp,
                       "grey": cv2.cvtColor(img, cv2.COLOR_BGR2GRAY),
                       "lead": None if best is None else best.id,
                       "points_pipe": {t.id: t.ttc_points for t in tracks},
                       "iou": None if best is None else round(best_iou, 3)})
    return frames, (w, h)


def points_ttc(engine: str, frames, **params):
    """The block-scale TTC (c/ttc_scale.c) over the collected tracks: {frame: {id: out}}."""
    est = ScaleTtc(FPS, engine=engine, **params)
    return [{o.id: o for o in est.step(fr["grey"], fr["tracks"])} for fr in frames]


def ranges(data: Path, engine: str, frames, size, points=None, bottom_height=0.0, **params):
    """The range stage over the collected tracks. bottom_height (m): the height above the
    road of what the box's bottom edge shows; eq. 1 then uses the camera height minus it."""
    w, h = size
    lid = {int(r["frame"]): r for r in csv.DictReader(open(data / "derived_lidar_lead_distance.csv"))}
    rng = RangeEstimator(kitti_camera(data, w, h), (w, h), FPS, engine=engine,
                         bottom_height=bottom_height, **params)
    rows = []
    for i, fr in enumerate(frames):
        rng.update_pitch(fr["vp"])
        outs = {o.id: o for o in rng.step(fr["tracks"])}
        po = points[i].get(fr["lead"]) if points is not None and fr["lead"] is not None else None
        o = outs.get(fr["lead"]) if fr["lead"] is not None else None
        box = dict(fr["tracks"]).get(fr["lead"]) if fr["lead"] is not None else None
        rows.append({
            "frame": i, "vp_row": fr["vp"], "pitch_deg": rng.pitch_deg, "pitch_flag": rng.pitch_flag,
            "lead_id": fr["lead"], "lead_box": box, "iou": fr["iou"],
            "distance_m": None if o is None else o.distance,
            "dist_filt_m": None if o is None else o.dist_filt,
            "from_width": None if o is None else o.from_width,
            "dist_width_1p8_m": None if o is None else o.dist_width,
            "rate_mps": None if o is None else o.rate,
            "ttc_dist_s": None if o is None else o.ttc_dist,
            "ttc_scale_s": None if o is None else o.ttc_scale,
            "ttc_points_s": None if po is None else po.ttc,
            "ttc_points_pipeline_s": None if fr["lead"] is None else fr["points_pipe"].get(fr["lead"]),
            # the pipeline's fused TTC rule (vt_pipe_track.ttc_fused_q16) on these two
            "ttc_fused_s": fuse_ttc(None if po is None else po.ttc, None if o is None else o.ttc_dist),
            "scale_points": None if po is None else po.scale,
            "points_pairs": None if po is None else po.pairs,
            "warning": None if o is None else o.warning,
            "lidar_min_m": float(lid[i]["ego_lane_min_x_m"]),
            "lidar_p05_m": float(lid[i]["ego_lane_p05_x_m"]),
        })
    return rows


def summarise(rows) -> dict:
    n = len(rows)
    truth = np.array([r["lidar_min_m"] for r in rows]) - LIDAR_BEHIND_CAMERA_M
    ttc_l = lidar_ttc(np.array([r["lidar_min_m"] for r in rows]), 1.0 / FPS)
    ttc_lc = lidar_ttc_trailing(np.array([r["lidar_min_m"] for r in rows]), 1.0 / FPS)
    ttc_l9 = lidar_ttc(np.array([r["lidar_min_m"] for r in rows]), 1.0 / FPS, half=4)
    ttc_p05 = lidar_ttc(np.array([r["lidar_p05_m"] for r in rows]), 1.0 / FPS)

    def arr(key):
        return np.array([np.nan if r[key] is None else float(r[key]) for r in rows])
    d_f, d_m = arr("dist_filt_m"), arr("distance_m")
    t_d, t_s, t_p = arr("ttc_dist_s"), arr("ttc_scale_s"), arr("ttc_points_s")
    t_pp = arr("ttc_points_pipeline_s")
    t_f = arr("ttc_fused_s")
    out = {"frames": n, "lead_tracked": int(np.sum([r["lead_id"] is not None for r in rows]))}
    halves = {"all": slice(0, n), "first_half": slice(0, n // 2), "second_half": slice(n // 2, n)}
    for name, sl in halves.items():
        out[name] = {
            "distance_filtered_rel": stats((d_f[sl] - truth[sl]) / truth[sl]),
            "distance_measured_rel": stats((d_m[sl] - truth[sl]) / truth[sl]),
            "ttc_dist_rel": stats((t_d[sl] - ttc_l[sl]) / ttc_l[sl]),
            "ttc_scale_rel": stats((t_s[sl] - ttc_l[sl]) / ttc_l[sl]),
            "ttc_points_rel": stats((t_p[sl] - ttc_l[sl]) / ttc_l[sl]),
            "ttc_points_reported": int(np.sum(np.isfinite(t_p[sl]) & np.isfinite(ttc_l[sl]))),
            "ttc_fused_rel": stats((t_f[sl] - ttc_l[sl]) / ttc_l[sl]),
            "ttc_points_pipeline_rel": stats((t_pp[sl] - ttc_l[sl]) / ttc_l[sl]),
            "ttc_points_pipeline_equal": int(np.sum((t_pp[sl] == t_p[sl]) |
                                                    (np.isnan(t_pp[sl]) & np.isnan(t_p[sl])))),
            # against the lidar TTC fitted over frames t-4..t (what a causal estimate can know)
            "trailing": {"ttc_dist_rel": stats((t_d[sl] - ttc_lc[sl]) / ttc_lc[sl]),
                         "ttc_scale_rel": stats((t_s[sl] - ttc_lc[sl]) / ttc_lc[sl]),
                         "ttc_points_rel": stats((t_p[sl] - ttc_lc[sl]) / ttc_lc[sl]),
                         "frames_with_lidar_ttc": int(np.sum(np.isfinite(ttc_lc[sl])))},
            # against a smoother lidar TTC (9-frame centred fit): how much of the error is
            # the 5-frame lidar TTC's own noise
            "smooth9": {"ttc_dist_rel": stats((t_d[sl] - ttc_l9[sl]) / ttc_l9[sl]),
                        "ttc_scale_rel": stats((t_s[sl] - ttc_l9[sl]) / ttc_l9[sl]),
                        "ttc_points_rel": stats((t_p[sl] - ttc_l9[sl]) / ttc_l9[sl]),
                        "frames_with_lidar_ttc": int(np.sum(np.isfinite(ttc_l9[sl])))},
            # the lidar against itself: the 5-frame TTC of the 5th-percentile distance vs
            # that of the minimum (the truth's own noise floor)
            "lidar_p05_vs_min_ttc_rel": stats((ttc_p05[sl] - ttc_l[sl]) / ttc_l[sl]),
            "ttc_frames_with_lidar_ttc": int(np.sum(np.isfinite(ttc_l[sl]))),
            "ttc_dist_reported": int(np.sum(np.isfinite(t_d[sl]) & np.isfinite(ttc_l[sl]))),
            "ttc_scale_reported": int(np.sum(np.isfinite(t_s[sl]) & np.isfinite(ttc_l[sl]))),
        }
    out["from_width_frames"] = int(np.sum([bool(r["from_width"]) for r in rows]))
    pitch = np.array([r["pitch_deg"] for r in rows])
    out["pitch_deg"] = {"min": float(pitch.min()), "max": float(pitch.max()),
                        "median": float(np.median(pitch)),
                        "frames_with_vp": int(np.sum([r["vp_row"] is not None for r in rows]))}
    out["lidar_ttc_s"] = [None if not np.isfinite(v) else round(float(v), 3) for v in ttc_l]
    out["lidar_ttc_trailing_s"] = [None if not np.isfinite(v) else round(float(v), 3) for v in ttc_lc]
    return out


# The block-scale TTC's settings before the slot, prior, fallback-lag and matched-share
# rules (vt_ttc_cfg's evict_margin_px, prior_gate_permille, min_lag, min_match_permille):
# the README's earlier figures come from these.
EARLIER_POINTS = dict(evict_margin_px=-1, prior_gate_permille=-1, min_lag=5, min_match_permille=0)


def points_compare(frames, points, points_old, lid_min: np.ndarray) -> dict:
    """The block TTC with the current defaults and with EARLIER_POINTS, per part of the
    split (frames 0-38 tune, 39-77 held out, all): median / P95 abs. rel. error against the
    5-frame lidar TTC and how many of its frames have a block TTC; and the lidar's own
    9-frame fit against its 5-frame TTC (the truth's noise floor for a smooth estimate)."""
    n = len(frames)
    tl = lidar_ttc(lid_min, 1.0 / FPS)
    t9 = lidar_ttc(lid_min, 1.0 / FPS, half=4)

    def lead(pts):
        return np.array([np.nan if fr["lead"] is None or pts[i].get(fr["lead"]) is None
                         or pts[i][fr["lead"]].ttc is None else pts[i][fr["lead"]].ttc
                         for i, fr in enumerate(frames)])
    cur, old = lead(points), lead(points_old)
    lags = [None if fr["lead"] is None or points[i].get(fr["lead"]) is None else points[i][fr["lead"]].lag
            for i, fr in enumerate(frames)]
    out = {}
    for name, sl in (("tune_0_38", slice(0, n // 2)), ("held_out_39_77", slice(n // 2, n)), ("all", slice(0, n))):
        ok = np.isfinite(tl[sl])
        out[name] = {"lidar_ttc_frames": int(ok.sum()),
                     "block_ttc_rel": stats((cur[sl] - tl[sl]) / tl[sl]),
                     "block_ttc_earlier_rel": stats((old[sl] - tl[sl]) / tl[sl]),
                     "block_ttc_vs_lidar9_rel": stats((cur[sl] - t9[sl]) / t9[sl]),
                     "lidar9_vs_lidar5_rel": stats((t9[sl] - tl[sl]) / tl[sl]),
                     "fallback_lag_frames": int(sum(1 for v in lags[sl] if v is not None and 0 < v < 5))}
    return out


def plot(rows, summary, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fr = [r["frame"] for r in rows]
    val = lambda k: [np.nan if r[k] is None else r[k] for r in rows]  # noqa: E731
    nn = lambda v: [np.nan if x is None else x for x in v]  # noqa: E731
    fig, ax = plt.subplots(3, 1, figsize=(9, 10), sharex=True)
    ax[0].plot(fr, np.array(val("lidar_min_m")) - LIDAR_BEHIND_CAMERA_M, "k-", label="lidar - 0.27 m")
    ax[0].plot(fr, val("distance_m"), "c.", label="measured (row, or learnt width)")
    ax[0].plot(fr, val("dist_filt_m"), "b-", label="filtered")
    ax[0].plot(fr, val("dist_width_1p8_m"), "g:", label="width cross-check (1.8 m)")
    ax[0].axvline(38.5, color="0.6", lw=0.8)
    ax[0].set_ylabel("distance (m)")
    ax[0].set_title(f"KITTI lead car; left of the grey line: tuning frames 0-38 "
                    f"({summary.get('model', '')})", fontsize=9)
    ax[0].legend(fontsize=8)
    ax[1].plot(fr, nn(summary["lidar_ttc_s"]), "k-", label="lidar (5-frame fit, centred)")
    ax[1].plot(fr, nn(summary["lidar_ttc_trailing_s"]), "k--", lw=0.8, label="lidar (5-frame fit, t-4..t)")
    ax[1].plot(fr, val("ttc_dist_s"), "b.-", label="filtered distance / rate")
    ax[1].plot(fr, val("ttc_scale_s"), "r.-", label="box scale change (5 frames)")
    ax[1].plot(fr, val("ttc_points_s"), "g.-", label="matched blocks' scale (ttc_scale.c)")
    ax[1].plot(fr, val("ttc_fused_s"), "m.-", lw=2, label="fused: 0.3 distance/rate + 0.7 blocks")
    ax[1].axvline(38.5, color="0.6", lw=0.8)
    ax[1].set_ylim(0, 20)
    ax[1].set_ylabel("TTC (s)")
    ax[1].legend(fontsize=8)
    ax[2].plot(fr, val("pitch_deg"), "m.-")
    ax[2].set_ylabel("pitch (deg, + down)")
    ax[2].set_xlabel("frame (10 Hz)")
    fig.tight_layout()
    fig.savefig(path, dpi=80)


def _fit(a, frames, size, points, key, grid):
    """The one distance parameter, fitted on the first half only (frames 0-38)."""
    errs = []
    for g in grid:
        s0 = summarise(ranges(a.data, a.engine, frames, size, points, **{key: float(g)}))
        errs.append(s0["first_half"]["distance_filtered_rel"].get("median", np.inf))
    return float(grid[int(np.argmin(errs))]), errs


def fuse_weight_table(rows, grid=range(0, 1001, 50)) -> dict:
    """How the fused TTC's weight (vt_pipeline_cfg.ttc_fuse_permille, default 300) was
    chosen: the median abs. rel. error against the 5-frame lidar TTC on frames 0-38 only,
    for each weight w (permille on distance/rate) of the grid; the smallest wins (the first
    of equals). Frames 39-77 are not read here."""
    n = len(rows)
    tl = lidar_ttc(np.array([r["lidar_min_m"] for r in rows]), 1.0 / FPS)[:n // 2]
    med = []
    for w in grid:
        e = [abs(f - tl[i]) / tl[i] for i, r in enumerate(rows[:n // 2])
             if np.isfinite(tl[i]) and (f := fuse_ttc(r["ttc_points_s"], r["ttc_dist_s"], w)) is not None]
        med.append(float(np.median(e)) if e else float("nan"))
    # no fused TTC on frames 0-38 at all (e.g. the lead car lost there through a codec): nothing chosen
    chosen = None if np.all(np.isnan(med)) else list(grid)[int(np.nanargmin(med))]
    return {"grid": list(grid), "first_half_median": med, "chosen": chosen}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--engine", choices=("c", "reference"), default="c")
    ap.add_argument("--json", type=Path, default=Path("eval_kitti_range.json"))
    ap.add_argument("--png", type=Path, default=None)
    ap.add_argument("--model", choices=("offset", "height"), default="offset",
                    help="distance model reported: 'offset' subtracts rear_offset (m) from eq. 1; "
                         "'height' reads the box bottom as a line bottom_height (m) above the road "
                         "(eq. 1 with the camera height minus it). Both are fitted on frames 0-38 "
                         "and both are printed; this picks the one in the JSON rows and the PNG")
    ap.add_argument("--rear-offset", type=float, default=None, metavar="M",
                    help="range stage's rear_offset (m); default: fitted on the first half (frames 0-38)")
    ap.add_argument("--bottom-height", type=float, default=None, metavar="M",
                    help="height above the road of the box's bottom edge (m); default: fitted on "
                         "the first half (frames 0-38)")
    ap.add_argument("--lane-set", nargs="+", default=[], metavar="FIELD=VALUE",
                    help="lane-stage fields other than the defaults (pyvehtrack.lane.LaneConfig), for the "
                         "detector's road area and the vanishing row alike")
    ap.add_argument("--codec", choices=("none", "mp4v", "h264"), default="none",
                    help="run on the frames written as one video and decoded: OpenCV mp4v at default "
                         "quality, or libx264 CRF 23 (default none: the PNG frames)")
    ap.add_argument("--measurement", choices=("auto", "roi", "roi+edges"), default="auto",
                    help="the tracker's per-frame measurement; auto (default): as `pyvehtrack track`, "
                         "roi+edges with --codec mp4v|h264, roi on the PNG frames")
    a = ap.parse_args(argv)
    from pyvehtrack.frames import measurement_for  # noqa: PLC0415  (the command line's rule)
    measurement = a.measurement if a.measurement != "auto" else measurement_for(lossy=a.codec != "none")
    lane_cfg = None
    if a.lane_set:
        from dataclasses import replace  # noqa: PLC0415
        from pyvehtrack.lane import default_config  # noqa: PLC0415
        try:
            kv = dict(x.split("=", 1) for x in a.lane_set)
            lane_cfg = replace(default_config(), **{k: int(v) for k, v in kv.items()})
        except (ValueError, TypeError) as e:
            print(f"eval_kitti_range: --lane-set: {e}", file=sys.stderr)
            return 2
    if not (a.data / "derived_lidar_lead_distance.csv").is_file():
        print(f"eval_kitti_range: {a.data}: not the kitti-raw-sfnd-ttc folder", file=sys.stderr)
        return 2
    frames, size = collect(a.data, a.engine, lane_cfg, codec=a.codec, measurement=measurement)
    print(f"[{a.engine}] frames: {'PNG' if a.codec == 'none' else a.codec}; measurement {measurement}")
    points = points_ttc(a.engine, frames)
    points_old = points_ttc(a.engine, frames, **EARLIER_POINTS)
    tuning = {}
    offset, height = a.rear_offset, a.bottom_height
    if offset is None:
        # where the bottom edge's road point lies relative to the rear bumper the lidar sees
        grid = np.round(np.arange(0.0, 2.01, 0.05), 2)
        offset, errs = _fit(a, frames, size, points, "rear_offset", grid)
        tuning["rear_offset"] = {"grid": grid.tolist(), "first_half_median": errs, "chosen": offset}
    if height is None:
        grid = np.round(np.arange(0.0, 0.61, 0.01), 2)
        height, errs = _fit(a, frames, size, points, "bottom_height", grid)
        tuning["bottom_height"] = {"grid": grid.tolist(), "first_half_median": errs, "chosen": height}
    base = summarise(ranges(a.data, a.engine, frames, size, points, rear_offset=0.0))
    models = {"offset": ranges(a.data, a.engine, frames, size, points, rear_offset=offset),
              "height": ranges(a.data, a.engine, frames, size, points, bottom_height=height)}
    sums = {k: summarise(v) for k, v in models.items()}
    sums["offset"]["rear_offset_m"] = offset
    sums["height"]["bottom_height_m"] = height
    s, rows = sums[a.model], models[a.model]
    s["model"] = (f"rear_offset {offset} m" if a.model == "offset" else f"bottom_height {height} m")
    s["block_ttc_split"] = points_compare(frames, points, points_old,
                                          np.array([r["lidar_min_m"] for r in rows]))
    tuning["ttc_fuse_permille"] = fuse_weight_table(rows)
    a.json.write_text(json.dumps({"engine": a.engine, "model": a.model, "summary": s,
                                  "summaries": sums, "tuning": tuning or None,
                                  "summary_eq1_as_is": base, "per_frame": rows}, indent=1))
    if a.png:
        plot(rows, s, a.png)
    print(f"[{a.engine}] eq. 1 as is (no offset, no height): second half distance median "
          f"{base['second_half']['distance_filtered_rel'].get('median', float('nan')):.1%}, all "
          f"{base['all']['distance_filtered_rel'].get('median', float('nan')):.1%}")
    f = lambda d: (f"median {d['median']:.1%}  P95 {d['p95']:.1%}  (n={d['n']})"  # noqa: E731
                   if d.get("n") else "n=0")
    for m, sm in sums.items():
        par = f"rear_offset = {offset} m" if m == "offset" else f"bottom_height = {height} m"
        fitted = (a.rear_offset if m == "offset" else a.bottom_height) is None
        print(f"[{a.engine}] model {m}: {par} ({'fitted on frames 0-38' if fitted else 'given'})")
        for name in ("all", "first_half", "second_half"):
            x = sm[name]
            print(f"[{a.engine}] {m} {name}: distance (filtered) {f(x['distance_filtered_rel'])}")
            print(f"[{a.engine}] {m} {name}: distance (measured) {f(x['distance_measured_rel'])}")
            print(f"[{a.engine}] {m} {name}: TTC distance/rate   {f(x['ttc_dist_rel'])}  "
                  f"of {x['ttc_frames_with_lidar_ttc']} lidar-TTC frames")
    x0 = s
    for name in ("all", "first_half", "second_half"):
        x = x0[name]
        print(f"[{a.engine}] {name}: TTC box scale change {f(x['ttc_scale_rel'])}")
        print(f"[{a.engine}] {name}: TTC block scale      {f(x['ttc_points_rel'])}")
        print(f"[{a.engine}] {name}: TTC fused (0.3 distance/rate + 0.7 block scale) {f(x['ttc_fused_rel'])}")
        print(f"[{a.engine}] {name}: TTC block scale (pipeline) {f(x['ttc_points_pipeline_rel'])}; "
              f"equal to the stand-alone stage on {x['ttc_points_pipeline_equal']} of the frames")
        for key, lab in (("trailing", "lidar t-4..t"), ("smooth9", "lidar 9-frame fit")):
            t = x[key]
            print(f"[{a.engine}] {name}: vs {lab} ({t['frames_with_lidar_ttc']} frames): "
                  f"distance/rate ({a.model}) {f(t['ttc_dist_rel'])}; box scale {f(t['ttc_scale_rel'])}; "
                  f"block scale {f(t['ttc_points_rel'])}")
        print(f"[{a.engine}] {name}: lidar p05 vs lidar min, 5-frame TTC: {f(x['lidar_p05_vs_min_ttc_rel'])}")
    lid_min = np.array([r["lidar_min_m"] for r in rows])
    pc = points_compare(frames, points, points_old, lid_min)
    for name, x in pc.items():
        print(f"[{a.engine}] {name}: TTC block scale (defaults) {f(x['block_ttc_rel'])} of "
              f"{x['lidar_ttc_frames']} lidar-TTC frames ({x['fallback_lag_frames']} frames over a shorter "
              f"lag); earlier defaults {f(x['block_ttc_earlier_rel'])}; vs lidar 9-frame fit "
              f"{f(x['block_ttc_vs_lidar9_rel'])}; lidar 9-frame fit vs 5-frame TTC (noise floor) "
              f"{f(x['lidar9_vs_lidar5_rel'])}")
    ft = tuning["ttc_fuse_permille"]
    print(f"[{a.engine}] fused TTC weight on distance/rate, chosen on frames 0-38 ({a.model} model): "
          f"{ft['chosen']} permille (the pipeline's default: 300); median there by weight: "
          + ", ".join(f"{w}: {m:.1%}" for w, m in zip(ft["grid"], ft["first_half_median"])))
    print(f"[{a.engine}] lead tracked in {s['lead_tracked']}/{s['frames']} frames; distance from the "
          f"learnt width in {s['from_width_frames']}; pitch {s['pitch_deg']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
