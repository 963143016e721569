"""`pyvehtrack track`: track vehicles through a video or a folder of frames.

    pyvehtrack track INPUT... --out annotated.mp4 [--tracks tracks.txt] [--engine c|reference]
                     [--detect-every N] [--road auto|lanes|fixed] [--all-states]
                     [--skip-bad-frames] [--no-progress]

tracks.txt is the KITTI tracking label format, one line per track and frame:
`frame id Car -1 -1 -10 left top right bottom -1 -1 -1 -1000 -1000 -1000 -10 score`,
so TrackEval and other tools read it as is. Frame numbers follow the input order
(a folder's files in sorted name order; a skipped bad frame keeps its number)."""
from __future__ import annotations

import colorsys
from pathlib import Path

from ..eval.kitti import track_line
from .common import (CliError, FrameReader, Outputs, VideoOut, count_frames, frame_sources,
                     output_kind, progress)

STATE_SCORE = {"confirmed": 1.0, "coasting": 0.5, "tentative": 0.25}

EXAMPLES = """examples:
  pyvehtrack track drive.mp4 --out annotated.mp4 --tracks tracks.txt
  pyvehtrack track frames/ --out annotated.mp4 --tracks tracks.txt --detect-every 5
  pyvehtrack eval --gt gt.txt --tracks tracks.txt            (score the tracks)"""


def id_colour(track_id: int) -> tuple[int, int, int]:
    """A stable, well-spread BGR colour per id (golden-ratio hue steps)."""
    h = (track_id * 0.6180339887) % 1.0
    r, g, b = colorsys.hsv_to_rgb(h, 0.85, 1.0)
    return int(b * 255), int(g * 255), int(r * 255)


def kitti_line(frame: int, t) -> str:
    """A track as a KITTI tracking result line; the score says its state (STATE_SCORE)."""
    return track_line(frame, t.id, t.box, STATE_SCORE[t.state], digits=2)


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


def register(sub) -> None:
    import argparse
    p = sub.add_parser("track", help="track vehicles through a video or a folder of frames",
                       description="Detect every N frames, track every frame (Kalman + ROI search), "
                       "write an annotated video and KITTI-format tracks.", epilog=EXAMPLES,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="a video, a folder of frames, or images")
    p.add_argument("--out", required=True, help="annotated output: .mp4/.avi video (or .png for frames)")
    p.add_argument("--tracks", help="write tracks here in the KITTI tracking label format")
    p.add_argument("--engine", choices=("c", "reference"), default="c",
                   help="the C core (default) or the float reference")
    p.add_argument("--detect-every", type=int, default=10, metavar="N",
                   help="run the detector every N frames (thesis: 10)")
    p.add_argument("--road", choices=("auto", "lanes", "fixed"), default="auto",
                   help="road area for the detector: lanes, a fixed trapezoid, or lanes with fallback")
    p.add_argument("--measurement", choices=("roi", "edges"), default="roi",
                   help="per-frame measurement of a track: the thesis's ROI search (roi, default) or "
                        "the GIST paper's edge curves matched by chamfer distance (edges)")
    p.add_argument("--all-states", action="store_true",
                   help="also write tentative tracks to --tracks (default: confirmed and coasting)")
    p.add_argument("--skip-bad-frames", action="store_true",
                   help="skip (and count) frames that cannot be decoded instead of stopping with exit 2")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


register_track = register        # the name SUBCOMMANDS used before the package


def run(args) -> int:
    import cv2

    from .._native import VtError
    from ..detector import Detector
    from ..tracker import Tracker

    if args.detect_every < 1:
        raise CliError(f"--detect-every {args.detect_every}: must be >= 1")
    out = Path(args.out)
    kind = output_kind(out)
    if kind is None:
        raise CliError(f"--out {args.out}: expected an .mp4/.avi video (or a .png/.jpg name for frames)")
    sources = frame_sources(args.inputs)
    total = count_frames(sources)
    try:
        det = Detector(engine=args.engine, road=args.road)
        trk = Tracker(engine=args.engine, detect_every=args.detect_every, detector=det,
                      measurement=getattr(args, "measurement", "roi"))
    except (RuntimeError, ValueError, TypeError) as e:
        raise CliError(str(e)) from None
    with Outputs() as outs:
        tracks_tmp = outs.reserve("--tracks", args.tracks) if args.tracks else None
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
                    except (VtError, ValueError, TypeError) as e:
                        raise CliError(f"{file}: {e}") from None
                    for t in tracks:
                        if args.all_states or t.state != "tentative":
                            lines.append(kitti_line(i, t))
                            ids.add(t.id)
                    img = draw_tracks(frame, tracks, i, trk.last_was_detection)
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
        outs.commit()
    print(f"{n} frame(s), {len(ids)} track(s), {len(lines)} track-frame(s); annotated: {out}"
          + (f"; tracks: {args.tracks}" if args.tracks else "")
          + (f"; {len(reader.skipped)} bad frame(s) skipped" if reader.skipped else ""))
    return 0
