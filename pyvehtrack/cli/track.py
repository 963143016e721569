"""`pyvehtrack track`: track vehicles through a video or a folder of frames.

    pyvehtrack track INPUT... --out annotated.mp4 [--tracks tracks.txt] [--engine c|reference]
                     [--detect-every N] [--road auto|lanes|fixed] [--all-states]
                     [--measurement auto|roi|edges|roi+edges] [--box-top cnn|tracker]
                     [--camera CAMERA.json [--fps F] [--ego-speed V]] [--json TRACKS.json]
                     [--skip-bad-frames] [--no-progress]

tracks.txt is the KITTI tracking label format, one line per track and frame:
`frame id Car -1 -1 -10 left top right bottom -1 -1 -1 -1000 -1000 -1000 -10 score`,
so TrackEval and other tools read it as is. Frame numbers follow the input order
(a folder's files in sorted name order; a skipped bad frame keeps its number). With
--camera, the location fields (x y z, camera coordinates, m) hold the lateral offset, the
camera height and the filtered distance of the track's bottom centre.

TRACKS.json (--json) is a list of per-frame records
`{"frame": n, "tracks": [{"id", "box": [l, t, r, b], "state", "velocity_px": [vx, vy],
"distance_m", "ttc_s", "warning": bool, "source": "shadow"|"classifier"|"flow"|"model"|"ego"}]}`
with null where a value is unknown (no --camera: distance_m, ttc_s null and warning false).
"box" is the tracker's box; with `--box-top cnn` (the default since 2026-11-30) its top is the one
`detect` last reported for the track (the CNN box's, for a track the ego-lane detector's box goes to).
distance_m is the filtered distance, ttc_s the TTC from it and its rate (pyvehtrack.camera);
"ttc_points_s" (added field) is the TTC from the scale change of SAD-matched blocks inside the
box over 5 frames (c/ttc_scale.c run inside vt_pipeline_step after the tracker:
Pipeline(ttc_points=True)), null when unknown or without --camera.
"ttc_fused_s" (added field) is the two in one: the weighted mean of "ttc_s" and "ttc_points_s"
(0.3 / 0.7, vt_pipeline_cfg.ttc_fuse_permille), the known one if only one is."""
from __future__ import annotations

import colorsys
from pathlib import Path

from ..eval.kitti import track_line
from .common import (CliError, add_command, add_model_arg, add_range_args, load_camera, make_detector,
                     FrameReader, Outputs, VideoOut, count_frames, frame_sources, output_kind, progress)

STATE_SCORE = {"confirmed": 1.0, "coasting": 0.5, "tentative": 0.25, "handover": 0.4}

EXAMPLES = """examples:
  pyvehtrack track drive.mp4 --out annotated.mp4 --tracks tracks.txt
  pyvehtrack track frames/ --out annotated.mp4 --tracks tracks.txt --detect-every 5
  pyvehtrack eval --gt gt.txt --tracks tracks.txt            (score the tracks)"""


def id_colour(track_id: int) -> tuple[int, int, int]:
    """A stable, well-spread BGR colour per id (golden-ratio hue steps)."""
    h = (track_id * 0.6180339887) % 1.0
    r, g, b = colorsys.hsv_to_rgb(h, 0.85, 1.0)
    return int(b * 255), int(g * 255), int(r * 255)


def kitti_line(frame: int, t, location=None) -> str:
    """A track as a KITTI tracking result line; the score says its state (STATE_SCORE).
    location: (x, y, z) in metres (camera coordinates) for the location fields, or None."""
    line = track_line(frame, t.id, t.box, STATE_SCORE[t.state], digits=2)
    if location is None:
        return line
    f = line.split(" ")
    f[13:16] = [f"{v:.2f}" for v in location]   # fields: ... h w l x y z rotation_y score
    return " ".join(f)


def track_record(t, r=None, p=None) -> dict:
    """One track's entry of TRACKS.json; r: its pyvehtrack.camera range output or None; p: its
    block-scale TTC in s (the pipeline's Track.ttc_points) or None."""
    return {"id": int(t.id), "box": [int(v) for v in t.box], "state": t.state,
            "velocity_px": [round(float(t.velocity[0]), 4), round(float(t.velocity[1]), 4)],
            "distance_m": None if r is None or r.dist_filt is None else round(r.dist_filt, 3),
            "ttc_s": None if r is None or r.ttc_dist is None else round(r.ttc_dist, 3),
            "warning": bool(r is not None and r.warning),
            "source": getattr(t, "source", "shadow"),
            "ttc_points_s": None if p is None else round(p, 3),
            "ttc_fused_s": _fused(None if r is None else r.ttc_dist, p)}


def _fused(dist, points):
    """The two TTCs in one (pyvehtrack.camera.fuse_ttc, the pipeline's rule), rounded to ms."""
    from ..camera import fuse_ttc  # noqa: PLC0415
    f = fuse_ttc(points, dist)
    return None if f is None else round(f, 3)


def draw_tracks(frame, tracks, frame_index: int, detection_frame: bool, ranges=None):
    import cv2
    import numpy as np
    img = frame.copy() if frame.ndim == 3 else cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
    for t in tracks:
        c = id_colour(t.id)
        l, tp, r, b = (int(v) for v in t.box)
        thick = 2 if t.state == "confirmed" else 1
        cv2.rectangle(img, (l, tp), (r, b), c, thick, lineType=cv2.LINE_AA)
        if t.state == "coasting":  # dashed look: a second, inner rectangle
            cv2.rectangle(img, (l + 3, tp + 3), (r - 3, b - 3), c, 1)
        elif t.state == "handover":  # followed by the flow stage: an outer rectangle
            cv2.rectangle(img, (l - 3, tp - 3), (r + 3, b + 3), c, 1)
        vx, vy = t.velocity
        cx, cy = (l + r) // 2, b
        cv2.arrowedLine(img, (cx, cy), (int(cx + 5 * vx), int(cy + 5 * vy)), c, 2, tipLength=0.3)
        label = f"#{t.id} {vx:+.1f},{vy:+.1f}px/f"
        rg = (ranges or {}).get(t.id)
        if rg is not None and rg.dist_filt is not None:
            # the fused TTC (distance/rate with the block scale, when the track has one): the
            # best of the three on held-out KITTI frames; the warning decides on it with
            # --warn-ttc fused, else on distance/rate
            from ..camera import fuse_ttc  # noqa: PLC0415
            ttc = fuse_ttc(getattr(t, "ttc_points", None), rg.ttc_dist)
            label += f" {rg.dist_filt:.1f}m" + (f" TTC {ttc:.1f}s" if ttc is not None else "")
            if rg.warning:  # forward-collision warning: a thick red frame
                label += " WARN"
                cv2.rectangle(img, (l - 3, tp - 3), (r + 3, b + 3), (0, 0, 255), 3)
        ty = tp - 5 if tp >= 16 else tp + 15  # inside the box when there is no room above
        # on a dark plate: readable over sky, road and the box's own edge
        (tw, th), base = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)
        cv2.rectangle(img, (l, ty - th - 3), (l + tw + 4, ty + base), (0, 0, 0), -1)
        cv2.putText(img, label, (l + 2, ty), cv2.FONT_HERSHEY_SIMPLEX, 0.45, c, 1, cv2.LINE_AA)
    tag = f"frame {frame_index}" + ("  [detection]" if detection_frame else "")
    cv2.putText(img, tag, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (255, 255, 255), 2, cv2.LINE_AA)
    return np.ascontiguousarray(img)


def register(sub) -> None:
    p = add_command(sub, "track", help="track vehicles through a video or a folder of frames",
                       description="Detect every N frames, track every frame (Kalman + ROI search), "
                       "write an annotated video and KITTI-format tracks.", epilog=EXAMPLES)
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="a video, a folder of frames, or images")
    p.add_argument("--out", required=True, help="annotated output: .mp4/.avi video (or .png for frames)")
    p.add_argument("--tracks", help="write tracks here in the KITTI tracking label format")
    p.add_argument("--engine", choices=("c", "reference"), default="c",
                   help="the C core (default) or the float reference")
    p.add_argument("--detect-every", type=int, default=10, metavar="N",
                   help="run the detector every N frames (thesis: 10)")
    p.add_argument("--road", choices=("auto", "lanes", "fixed"), default="auto",
                   help="road area for the detector: lanes, a fixed trapezoid, or lanes with fallback")
    add_model_arg(p)
    p.add_argument("--measurement", choices=("auto", "roi", "edges", "roi+edges"), default="auto",
                   help="per-frame measurement of a track: the thesis's ROI search (roi), the GIST "
                        "paper's edge curves matched by chamfer distance (edges), or the ROI search "
                        "with the edge curves where it fails on a rear view it measured before "
                        "(roi+edges: for lossy-coded frames, e.g. dashcam MP4); auto (default): "
                        "roi+edges when the input is a lossy video (H.264, MPEG-4, ...) or JPEG/WebP "
                        "frames, roi for PNG/BMP/TIFF frames or lossless video (until 2026-11-30 the "
                        "default was roi)")
    p.add_argument("--box-top", choices=("cnn", "tracker"), default="cnn",
                   help="the top of a track's box: cnn (default), for a track the ego-lane detector's box "
                        "goes to, the top of the CNN box `detect` reported for it on the last detection "
                        "frame, kept as a height in box widths (vt_pipeline_cfg.cnn_track_top); tracker: "
                        "the tracker's box, square for those tracks (the default before 2026-11-30). The "
                        "tracker, distance and TTC are the same either way")
    p.add_argument("--flow", action="store_true",
                   help="also run the overtaking flow stage (sources 'flow'): overtaking cars from the "
                        "side, and the reverse hand-over of cars the ego car overtakes (state 'handover')")
    p.add_argument("--all-states", action="store_true",
                   help="also write tentative tracks to --tracks and --json and draw them in --out "
                        "(default: confirmed, coasting and handover tracks)")
    p.add_argument("--skip-bad-frames", action="store_true",
                   help="skip (and count) frames that cannot be decoded instead of stopping with exit 2")
    p.add_argument("--camera", metavar="CAMERA.json",
                   help="camera file (pyvehtrack calibrate; needs height_m): distance, TTC and warning; with "
                        "--model its geometry (and image_size) also places the whole-road detector's windows")
    p.add_argument("--fps", type=float, default=None, metavar="F",
                   help="frame rate for TTC (default: the video's, 10 for frames)")
    add_range_args(p)
    p.add_argument("--json", metavar="TRACKS.json", help="write per-frame track records (JSON)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


register_track = register        # the name SUBCOMMANDS used before the package


def run(args) -> int:
    import cv2

    from .._native import VtError
    from ..tracker import Tracker

    if args.detect_every < 1:
        raise CliError(f"--detect-every {args.detect_every}: must be >= 1")
    out = Path(args.out)
    kind = output_kind(out)
    if kind is None:
        raise CliError(f"--out {args.out}: expected an .mp4/.avi video (or a .png/.jpg name for frames)")
    sources = frame_sources(args.inputs)
    total = count_frames(sources)
    cam = None
    if args.camera:
        import math

        cam = load_camera(args.camera, "; a chessboard cannot give it, add it to the file")
        if args.fps is not None and not (math.isfinite(args.fps) and args.fps >= 1):
            raise CliError(f"--fps {args.fps}: must be >= 1")
        if args.ego_speed is not None and not (math.isfinite(args.ego_speed) and args.ego_speed >= 0):
            raise CliError(f"--ego-speed {args.ego_speed}: must be >= 0 m/s")
        from .._check import range_options  # noqa: PLC0415
        try:
            range_options(args.rear_offset, args.bottom_height, args.path_half_width, camera=True,
                          height_m=cam.height_m, spell=lambda k: "--" + k.replace("_", "-"))
        except (ValueError, TypeError) as e:
            raise CliError(str(e)) from None
    elif (args.fps is not None or args.ego_speed is not None or args.rear_offset != 0.0
          or args.bottom_height != 0.0 or args.path_half_width != 1.5 or args.warn_ttc != "distance"):
        raise CliError("--fps, --ego-speed, --rear-offset, --bottom-height, --path-half-width and --warn-ttc "
                       "need --camera")
    det = make_detector(args, cam)
    measurement = getattr(args, "measurement", "roi")
    if measurement == "auto":
        from ..frames import auto_measurement  # noqa: PLC0415
        measurement, why = auto_measurement(path for _kind, path in sources)
        measurement_note = f"; measurement {measurement} ({why})"
    else:
        measurement_note = ""
    try:
        # with a camera the pipeline also runs the block-scale TTC ("ttc_points_s") at the
        # range stage's frame rate
        fps = None
        if cam is not None:
            from .common import video_fps
            fps = args.fps if args.fps is not None else video_fps(sources)
        trk = Tracker(engine=args.engine, detect_every=args.detect_every, detector=det,
                      measurement=measurement, ttc_points=cam is not None,
                      fps=fps, flow=bool(getattr(args, "flow", False)),
                      cnn_track_top=getattr(args, "box_top", "cnn") == "cnn")
    except (RuntimeError, ValueError, TypeError) as e:
        raise CliError(str(e)) from None
    ranger = lanes = None
    records = []
    with Outputs() as outs:
        tracks_tmp = outs.reserve("--tracks", args.tracks) if args.tracks else None
        json_tmp = outs.reserve("--json", args.json) if args.json else None
        video = None
        if kind == "video":
            video = VideoOut(outs.reserve("--out", out), sources, name=str(out))
        else:
            outs.check("--out", out)
        lines, ids, n = [], set(), 0
        reader = FrameReader(sources, skip_bad=args.skip_bad_frames)
        try:
            with progress(total, disable=args.no_progress) as bar:
                for i, file, frame in reader:
                    try:
                        tracks = trk.step(frame)
                        ranges = {}
                        if cam is not None:
                            if ranger is None:
                                ranger, lanes = _range_stage(cam, frame, args, sources)
                            h, w = frame.shape[:2]
                            if (w, h) != ranger.size:
                                raise ValueError(f"frame size {w}x{h} differs from the first frame's "
                                                 f"{ranger.size[0]}x{ranger.size[1]}")
                            from ..camera import lane_vanishing_row
                            ranger.update_pitch(lane_vanishing_row(lanes.detect(frame)))
                            # --warn-ttc fused: the warning decides on the fused TTC where a
                            # track has a block-scale one (vt_range_step_fused), the TTC drawn
                            ranges = {r.id: r for r in ranger.step(
                                [(t.id, cam.undistort_box(t.box)) for t in tracks], args.ego_speed,
                                ttc_points=({t.id: t.ttc_points for t in tracks}
                                            if args.warn_ttc == "fused" else None))}
                    except (VtError, ValueError, TypeError) as e:
                        raise CliError(f"{file}: {e}") from None
                    # every output shows the same tracks: tentative ones only with --all-states
                    shown = [t for t in tracks if args.all_states or t.state != "tentative"]
                    for t in shown:
                        lines.append(kitti_line(i, t, _location(cam, t, ranges.get(t.id))))
                        ids.add(t.id)
                    records.append({"frame": i, "tracks": [track_record(t, ranges.get(t.id), t.ttc_points)
                                                           for t in shown]})
                    img = draw_tracks(frame, shown, i, trk.last_was_detection, ranges)
                    if kind == "image":
                        path = out.with_name(f"{out.stem}_{i:05d}{out.suffix}")
                        if not cv2.imwrite(str(outs.reserve("--out", path)), img):
                            raise CliError(f"{path}: cannot write")
                    else:
                        video.write(img)
                    n += 1
                    bar.update(1)
        finally:
            if video is not None:
                video.close()
        if n == 0:
            raise CliError("no frame could be decoded; nothing written")
        if tracks_tmp is not None:
            tracks_tmp.write_text("".join(s + "\n" for s in lines))
        if json_tmp is not None:
            import json
            json_tmp.write_text("[\n" + ",\n".join(json.dumps(r) for r in records) + "\n]\n")
        outs.commit()
    print(f"{n} frame(s), {len(ids)} track(s), {len(lines)} track-frame(s); annotated: {out}"
          + (f"; tracks: {args.tracks}" if args.tracks else "")
          + (f"; {len(reader.skipped)} bad frame(s) skipped" if reader.skipped else "")
          + measurement_note)
    return 0


def _range_stage(cam, frame, args, sources):
    """The range estimator and lane detector for this run (made at the first frame, whose
    size the camera file must match)."""
    from ..camera import RangeEstimator
    from ..lane import LaneDetector
    from .common import video_fps
    h, w = frame.shape[:2]
    fps = args.fps if args.fps is not None else video_fps(sources)
    from .common import work_width_arg
    return (RangeEstimator(cam, (w, h), fps, engine=args.engine, rear_offset=args.rear_offset,
                           bottom_height=args.bottom_height, path_half_width=args.path_half_width),
            LaneDetector(engine=args.engine, work_width=work_width_arg(args)))


def _location(cam, t, r):
    """KITTI location (x, y, z) of the track's bottom centre, camera coordinates (m)."""
    if cam is None or r is None or r.dist_filt is None:
        return None
    l, _t, rr, _b = t.box
    z = r.dist_filt
    return ((l + rr) / 2 - cam.cx) * z / cam.fx, cam.height_m, z
