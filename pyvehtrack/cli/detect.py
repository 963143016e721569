"""`pyvehtrack detect`: lanes, road area and vehicle boxes of images, folders or videos.

    pyvehtrack detect INPUT... [--out annotated.{png,mp4}] [--json OUT.json] [--engine c|reference]
                      [--road auto|lanes|fixed] [--skip-bad-frames] [--no-progress]

At least one of --out and --json. The JSON is a list with one entry per frame:
{"frame": input-order index, "file": its file, "lanes": [{"side": "left"|"right", "points":
[[x, y], ...]}], "boxes": [[left, top, right, bottom], ...]} in input pixels (inclusive boxes).
In the full-road mode (a model) each entry also has "box_sources": one name per box, what found
it ("ego": the thesis's ego-lane detector; "windows": the classifier / CNN over the whole road;
"shadow": a whole-road shadow hypothesis). With --camera CAMERA.json each entry also has
"distance_m": one flat-road distance per box
(eq. 1 of the IVVI paper at the box's bottom row, pitch from the lanes' vanishing point;
null when the bottom row is at or above the horizon or on the frame's last row).
"""
from __future__ import annotations

import json
from pathlib import Path

from .common import (CliError, add_command, add_model_arg, load_camera, make_detector, FrameReader, Outputs, VideoOut, count_frames, frame_sources,
                     output_kind, progress)

EXAMPLES = """examples:
  pyvehtrack detect frame.png --out annotated.png
  pyvehtrack detect frames/ --out annotated.mp4 --json detections.json
  pyvehtrack detect drive.mp4 --json detections.json        (JSON only, no drawing)"""


# ====================================================================== drawing
def draw_detection(frame, res):
    """A BGR copy of `frame` with the road area (yellow, translucent), lanes (left blue,
    right red), hypotheses (magenta) and boxes (green) of a DetectionResult."""
    import cv2
    import numpy as np
    img = frame if frame.ndim == 3 else cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
    if img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    img = np.ascontiguousarray(img).copy()
    th = max(1, round(max(img.shape[:2]) / 640))
    if len(res.road_polygon) >= 3:
        over = img.copy()
        cv2.fillPoly(over, [res.road_polygon.astype(np.int32)], (0, 200, 255))
        img = cv2.addWeighted(over, 0.25, img, 0.75, 0)
        cv2.polylines(img, [res.road_polygon.astype(np.int32)], True, (0, 200, 255), th)
    for ln in res.lanes:
        if len(ln.points) >= 2:
            ego = ln.side in ("left", "right")
            col = (255, 80, 0) if ln.side.startswith("left") else (0, 0, 255)
            cv2.polylines(img, [ln.points.astype(np.int32)], False, col, (2 if ego else 1) * th)
    for y, a, b in res.hypotheses:
        cv2.line(img, (int(a), int(y)), (int(b), int(y)), (255, 0, 255), 2 * th)
    for l, t, r, b in res.boxes:
        cv2.rectangle(img, (int(l), int(t)), (int(r), int(b)), (0, 255, 0), 2 * th)
    return img


def detection_json(frame: int, file: str, res) -> dict:
    """One frame's entry of `detect --json`, input pixels, plain ints. Lanes are the two
    ego lines ("left", "right"); the outer lines the lane stage may find are drawn only.
    In the full-road mode a box carries its classifier score as a 5th element:
    [left, top, right, bottom, score], and "box_sources" names what found each box."""
    scores = getattr(res, "scores", None)
    sources = getattr(res, "sources", None)
    entry = {"frame": frame, "file": file,
             "lanes": [{"side": ln.side, "points": [[int(x), int(y)] for x, y in ln.points]}
                       for ln in res.lanes if ln.side in ("left", "right")],
             "boxes": [[int(v) for v in b] + ([] if scores is None else [round(float(scores[k]), 4)])
                       for k, b in enumerate(res.boxes)]}
    if sources is not None:
        entry["box_sources"] = [str(x) for x in sources]
    return entry


def register(sub) -> None:
    p = add_command(sub, "detect", help="detect lanes and vehicles in images, folders or videos",
                       description="Lanes -> road area -> shadow hypotheses -> verified vehicle "
                       "boxes (thesis ch. 2), drawn on the frames.", epilog=EXAMPLES)
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="image files, folders of frames (sorted by name) or videos")
    p.add_argument("--out", metavar="OUT",
                   help="annotated output: .png/.jpg (one file per frame, numbered _00000 when "
                        "there is more than one frame) or .mp4/.avi (one video)")
    p.add_argument("--json", metavar="OUT.json", help="write the lanes and boxes of every frame")
    p.add_argument("--engine", choices=("c", "reference"), default="c",
                   help="the C fixed-point core (default) or the float reference")
    p.add_argument("--road", choices=("auto", "lanes", "fixed"), default="auto",
                   help="road area from the lanes (auto: fall back to a fixed trapezoid)")
    p.add_argument("--skip-bad-frames", action="store_true",
                   help="skip (and count) frames that cannot be decoded instead of stopping with exit 2")
    p.add_argument("--camera", metavar="CAMERA.json",
                   help="camera file (needs height_m): a distance per box in the JSON; with --model its geometry "
                        "(and image_size) also places the whole-road detector's windows")
    add_model_arg(p)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


register_detect = register        # the name SUBCOMMANDS used before the package


def run(args) -> int:
    import cv2

    from .._native import VtError

    if not args.out and not args.json:
        raise CliError("give --out (annotated frames) and/or --json (lanes and boxes)")
    out = Path(args.out) if args.out else None
    kind = output_kind(out) if out else None
    if out and kind is None:
        raise CliError(f"--out {args.out}: expected a .png/.jpg image or an .mp4/.avi video name")
    sources = frame_sources(args.inputs)
    total = count_frames(sources)
    multi = total is None or total > 1
    cam = ranger = lanes = None
    if args.camera:
        from ..camera import RangeEstimator, lane_vanishing_row
        from ..lane import LaneDetector
        cam = load_camera(args.camera)
    det = make_detector(args, cam)
    with Outputs() as outs:
        json_tmp = outs.reserve("--json", args.json) if args.json else None
        video = None
        if kind == "video":
            video = VideoOut(outs.reserve("--out", out), sources, name=str(out))
        elif kind == "image":
            if multi:
                outs.check("--out", out)
            else:
                single_tmp = outs.reserve("--out", out)
        entries, written = [], []
        reader = FrameReader(sources, skip_bad=args.skip_bad_frames)
        show = not args.no_progress and multi
        try:
            with progress(total, disable=not show) as bar:
                for i, file, frame in reader:
                    try:
                        res = det.detect(frame)
                        entry = detection_json(i, file, res)
                        if cam is not None:
                            h, w = frame.shape[:2]
                            if ranger is None or ranger.size != (w, h):
                                # a picture of another size: the camera file says whether it fits
                                ranger = RangeEstimator(cam, (w, h), 10.0, engine=args.engine)
                                lanes = LaneDetector(engine=args.engine, work_width=det.work_width)
                            ranger.update_pitch(lane_vanishing_row(lanes.detect(frame)))
                            dists = [ranger.box_distance(cam.undistort_box(b)) for b in res.boxes]
                            entry["distance_m"] = [round(d.distance, 3) if d.valid else None for d in dists]
                    except (VtError, ValueError, TypeError) as e:
                        raise CliError(f"{file}: {e}") from None
                    entries.append(entry)
                    if kind == "image":
                        path = out if not multi else out.with_name(f"{out.stem}_{i:05d}{out.suffix}")
                        tmp = single_tmp if not multi else outs.reserve("--out", path)
                        if not cv2.imwrite(str(tmp), draw_detection(frame, res)):
                            raise CliError(f"{path}: cannot write")
                        written.append(str(path))
                    elif kind == "video":
                        video.write(draw_detection(frame, res))
                    bar.update(1)
        finally:
            if video is not None:
                video.close()
        if not entries:
            raise CliError("no frame could be decoded; nothing written")
        if kind == "video":
            written.append(str(out))
        if json_tmp is not None:
            json_tmp.write_text("[\n" + ",\n".join(json.dumps(e) for e in entries) + "\n]\n")
        outs.commit()
    n_boxes = sum(len(e["boxes"]) for e in entries)
    parts = [f"{len(entries)} frame(s), {n_boxes} box(es)"]
    if written:
        parts.append("annotated: " + (written[0] if len(written) == 1 else f"{written[0]} .. {written[-1]}"))
    if args.json:
        parts.append(f"json: {args.json}")
    if reader.skipped:
        parts.append(f"{len(reader.skipped)} bad frame(s) skipped")
    print("; ".join(parts))
    return 0
