"""`pyvehtrack track` and `pyvehtrack eval` (the tracking issue's commands).

    pyvehtrack track INPUT... --out annotated.mp4 --tracks tracks.txt [--engine c|reference]
                     [--detect-every N] [--all-states] [--no-progress]
    pyvehtrack eval --gt GT.txt --tracks tracks.txt [--json OUT.json] [--no-preproc]

tracks.txt is the KITTI tracking label format, one line per track and frame:
`frame id Car -1 -1 -10 left top right bottom -1 -1 -1 -1000 -1000 -1000 -10 score`,
so TrackEval and other tools read it as is. Frame numbers follow the input order
(a folder's files in sorted name order)."""
from __future__ import annotations

import colorsys
import json
import sys
from pathlib import Path

from .cli import (CliError, IMAGE_EXTS, VideoOut, _count_frames, _frames_of, _iter_frames, add_model_arg,
                  make_detector)

STATE_SCORE = {"confirmed": 1.0, "coasting": 0.5, "tentative": 0.25}


def id_colour(track_id: int) -> tuple[int, int, int]:
    """A stable, well-spread BGR colour per id (golden-ratio hue steps)."""
    h = (track_id * 0.6180339887) % 1.0
    r, g, b = colorsys.hsv_to_rgb(h, 0.85, 1.0)
    return int(b * 255), int(g * 255), int(r * 255)


def kitti_line(frame: int, t) -> str:
    l, tp, r, b = t.box
    return (f"{frame} {t.id} Car -1 -1 -10 {l:.2f} {tp:.2f} {r:.2f} {b:.2f} "
            f"-1 -1 -1 -1000 -1000 -1000 -10 {STATE_SCORE[t.state]:.2f}")


def draw_tracks(frame, tracks, frame_index: int, detection_frame: bool):
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
        vx, vy = t.velocity
        cx, cy = (l + r) // 2, b
        cv2.arrowedLine(img, (cx, cy), (int(cx + 5 * vx), int(cy + 5 * vy)), c, 2, tipLength=0.3)
        label = f"#{t.id} {vx:+.1f},{vy:+.1f}px/f"
        ty = tp - 5 if tp >= 16 else tp + 15  # inside the box when there is no room above
        cv2.putText(img, label, (l + 2, ty), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(img, label, (l + 2, ty), cv2.FONT_HERSHEY_SIMPLEX, 0.45, c, 1, cv2.LINE_AA)
    tag = f"frame {frame_index}" + ("  [detection]" if detection_frame else "")
    cv2.putText(img, tag, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (255, 255, 255), 2, cv2.LINE_AA)
    return np.ascontiguousarray(img)


def register_track(sub) -> None:
    p = sub.add_parser("track", help="track vehicles through a video or a folder of frames",
                       description="Detect every N frames, track every frame (Kalman + ROI search), "
                       "write an annotated video and KITTI-format tracks.")
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
    p.add_argument("--all-states", action="store_true",
                   help="also write tentative tracks to --tracks (default: confirmed and coasting)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run_track)


def run_track(args) -> int:
    import cv2
    from tqdm import tqdm

    from ._native import VtError
    from .tracker import Tracker

    if args.detect_every < 1:
        raise CliError(f"--detect-every {args.detect_every}: must be >= 1")
    out = Path(args.out)
    suffix = out.suffix.lower()
    kind = "video" if suffix in {".mp4", ".avi", ".mov", ".mkv"} else "image" if suffix in IMAGE_EXTS else None
    if kind is None:
        raise CliError(f"--out {args.out}: expected an .mp4/.avi video (or a .png/.jpg name for frames)")
    for opt, path in (("--out", out), ("--tracks", Path(args.tracks) if args.tracks else None)):
        if path is not None and not path.parent.exists():
            raise CliError(f"{opt} {path}: folder {path.parent} does not exist")
    sources = _frames_of(args.inputs)
    total = _count_frames(sources)
    det = make_detector(args)
    try:
        trk = Tracker(engine=args.engine, detect_every=args.detect_every, detector=det)
    except (RuntimeError, ValueError) as e:
        raise CliError(str(e)) from None
    lines, ids, n, video = [], set(), 0, VideoOut(out, sources)
    try:
        with tqdm(total=total, unit="frame", disable=args.no_progress, file=sys.stderr) as bar:
            for i, (file, _k, frame) in enumerate(_iter_frames(sources)):
                try:
                    tracks = trk.step(frame)
                except (VtError, ValueError, TypeError) as e:
                    raise CliError(f"{file}: {e}") from None
                for t in tracks:
                    if args.all_states or t.state != "tentative":
                        lines.append(kitti_line(i, t))
                        ids.add(t.id)
                img = draw_tracks(frame, tracks, i, trk.last_was_detection)
                if kind == "image":
                    path = out.with_name(f"{out.stem}_{i:05d}{out.suffix}")
                    if not cv2.imwrite(str(path), img):
                        raise CliError(f"{path}: cannot write")
                else:
                    video.write(img)
                n += 1
                bar.update(1)
    finally:
        video.close()
    if args.tracks:
        try:
            Path(args.tracks).write_text("".join(s + "\n" for s in lines))
        except OSError as e:
            raise CliError(f"--tracks {args.tracks}: {e.strerror}") from None
    print(f"{n} frame(s), {len(ids)} track(s), {len(lines)} track-frame(s); annotated: {out}"
          + (f"; tracks: {args.tracks}" if args.tracks else ""))
    return 0


def register_eval(sub) -> None:
    p = sub.add_parser("eval", help="score KITTI-format tracks against labels with TrackEval",
                       description="HOTA, CLEAR (MOTA...) and Identity (IDF1) from TrackEval, class Car.")
    p.add_argument("--gt", required=True, help="ground truth, KITTI tracking label file")
    p.add_argument("--tracks", required=True, action="append",
                   help="tracks to score, KITTI tracking format (repeat to compare several)")
    p.add_argument("--num-frames", type=int, help="frames in the sequence (default: from the files)")
    p.add_argument("--no-preproc", action="store_true",
                   help="count every box (default: KITTI benchmark rules via TrackEval's Kitti2DBox)")
    p.add_argument("--json", help="also write the figures here")
    p.set_defaults(func=run_eval)


def run_eval(args) -> int:
    from .evaluate import evaluate_kitti, format_results

    for path in [args.gt] + args.tracks:
        if not Path(path).is_file():
            raise CliError(f"{path}: no such file")
    results = {}
    for tr in args.tracks:
        try:
            results[tr] = evaluate_kitti(args.gt, tr, num_frames=args.num_frames,
                                         preproc="none" if args.no_preproc else "kitti")
        except (ValueError, OSError) as e:
            raise CliError(f"{tr}: {e}") from None
    print(format_results(results))
    if args.json:
        try:
            Path(args.json).write_text(json.dumps(results, indent=2, default=float) + "\n")
        except OSError as e:
            raise CliError(f"--json {args.json}: {e.strerror}") from None
    return 0
