"""The `pyvehtrack` command.

    pyvehtrack detect INPUT... --out annotated.{png,mp4} [--json OUT.json] [--engine c|reference]

Subcommands register themselves through SUBCOMMANDS below: to add one, write a
function `register(subparsers)` that adds its parser and sets `func` (a function of
the parsed args returning an exit code), and add one line to SUBCOMMANDS. Raise
CliError for a user mistake: main() prints it as one line and exits with status 2.
"""
from __future__ import annotations

import argparse
import importlib
import json
import sys
from pathlib import Path

# name -> "module:register function"; imported only when the command line is parsed.
SUBCOMMANDS: dict[str, str] = {
    "detect": "pyvehtrack.cli:register_detect",
    "track": "pyvehtrack.cli_track:register_track",
    "eval": "pyvehtrack.cli_track:register_eval",
    "eval-boxes": "pyvehtrack.cli_boxes:register_eval_boxes",
    "train": "pyvehtrack.cli_classify:register_train",
    "classify": "pyvehtrack.cli_classify:register_classify",
}

IMAGE_EXTS = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm", ".webp"}
VIDEO_EXTS = {".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg"}


class CliError(Exception):
    """A user-facing error: printed as one line, exit status 2."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pyvehtrack", description="Camera-based vehicle "
                                     "detection and tracking (C fixed-point core, float reference).")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, target in SUBCOMMANDS.items():
        mod_name, fn_name = target.split(":")
        getattr(importlib.import_module(mod_name), fn_name)(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except CliError as e:
        print(f"pyvehtrack {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"pyvehtrack {args.command}: interrupted", file=sys.stderr)
        return 130


# ====================================================================== inputs
def _frames_of(inputs: list[str]):
    """Expand INPUT... into a list of sources: ("image", path) or ("video", path).
    Folders give their image files in sorted name order."""
    out = []
    for s in inputs:
        p = Path(s)
        if not p.exists():
            raise CliError(f"{s}: no such file or directory")
        if p.is_dir():
            files = sorted(q for q in p.iterdir() if q.is_file() and q.suffix.lower() in IMAGE_EXTS)
            if not files:
                raise CliError(f"{s}: folder holds no image files ({', '.join(sorted(IMAGE_EXTS))})")
            out += [("image", str(q)) for q in files]
        elif p.suffix.lower() in VIDEO_EXTS:
            out.append(("video", str(p)))
        else:
            out.append(("image", str(p)))
    return out


def _iter_frames(sources):
    """Yield (file label, frame index within its source, BGR or gray uint8 frame)."""
    import cv2
    for kind, path in sources:
        if kind == "image":
            img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
            if img is None:
                raise CliError(f"{path}: cannot read as an image")
            if img.dtype != "uint8":   # 16-bit PNGs: keep the high byte
                img = (img >> 8).astype("uint8") if img.dtype == "uint16" else None
                if img is None:
                    raise CliError(f"{path}: unsupported pixel type")
            yield path, 0, img
        else:
            cap = cv2.VideoCapture(path)
            if not cap.isOpened():
                raise CliError(f"{path}: cannot open as a video")
            k = 0
            try:
                while True:
                    ok, img = cap.read()
                    if not ok:
                        break
                    yield path, k, img
                    k += 1
            finally:
                cap.release()
            if k == 0:
                raise CliError(f"{path}: the video has no readable frame")


def _count_frames(sources) -> int | None:
    import cv2
    n = 0
    for kind, path in sources:
        if kind == "image":
            n += 1
        else:
            cap = cv2.VideoCapture(path)
            c = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if cap.isOpened() else 0
            cap.release()
            if c <= 0:
                return None
            n += c
    return n


def _video_fps(sources) -> float:
    import cv2
    for kind, path in sources:
        if kind == "video":
            cap = cv2.VideoCapture(path)
            fps = cap.get(cv2.CAP_PROP_FPS) if cap.isOpened() else 0
            cap.release()
            if fps and fps > 0:
                return float(fps)
    return 10.0


class VideoOut:
    """An annotated-video writer opened on the first frame (its size fixes the video's);
    later frames of another size are resized to it."""

    def __init__(self, path: Path, sources):
        self.path, self.sources, self.writer, self.size = path, sources, None, None

    def write(self, img) -> None:
        import cv2
        if self.writer is None:
            self.size = (img.shape[1], img.shape[0])
            fourcc = cv2.VideoWriter_fourcc(*("MJPG" if self.path.suffix.lower() == ".avi" else "mp4v"))
            self.writer = cv2.VideoWriter(str(self.path), fourcc, _video_fps(self.sources), self.size)
            if not self.writer.isOpened():
                raise CliError(f"{self.path}: cannot open a video writer")
        if (img.shape[1], img.shape[0]) != self.size:
            img = cv2.resize(img, self.size, interpolation=cv2.INTER_AREA)
        self.writer.write(img)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.release()


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
    [left, top, right, bottom, score]."""
    return {"frame": frame, "file": file,
            "lanes": [{"side": ln.side, "points": [[int(x), int(y)] for x, y in ln.points]}
                      for ln in res.lanes if ln.side in ("left", "right")],
            "boxes": [[int(v) for v in b] + ([] if getattr(res, "scores", None) is None
                                             else [round(float(res.scores[k]), 4)])
                      for k, b in enumerate(res.boxes)]}


# ====================================================================== detect
def register_detect(sub) -> None:
    p = sub.add_parser("detect", help="detect lanes and vehicles in images, folders or videos",
                       description="Lanes -> road area -> shadow hypotheses -> verified vehicle "
                       "boxes (thesis ch. 2), drawn on the frames.")
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="image files, folders of frames (sorted by name) or videos")
    p.add_argument("--out", required=True, metavar="OUT",
                   help="annotated output: .png/.jpg (one file per frame, numbered _00000 when "
                        "there is more than one frame) or .mp4/.avi (one video)")
    p.add_argument("--json", metavar="OUT.json", help="write the lanes and boxes of every frame")
    p.add_argument("--engine", choices=("c", "reference"), default="c",
                   help="the C fixed-point core (default) or the float reference")
    p.add_argument("--road", choices=("auto", "lanes", "fixed"), default="auto",
                   help="road area from the lanes (auto: fall back to a fixed trapezoid)")
    add_model_arg(p)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run_detect)


def add_model_arg(p) -> None:
    p.add_argument("--model", metavar="MODEL.npz", default=None,
                   help="classifier model: detect over the whole road (shadow hypotheses over every "
                        "lane, kept when the classifier accepts them) instead of the ego lane only")
    p.add_argument("--sources", nargs="+", choices=("shadow", "windows"), default=None,
                   help="full-road hypothesis sources (default with --model: shadow; windows = classifier "
                        "sliding windows); without --model the built-in classifier is used")


def make_detector(args):
    """The Detector of `detect` and `track`, with the user's mistakes as CliError."""
    from .detector import Detector
    model = getattr(args, "model", None)
    if model is not None and not Path(model).is_file():
        raise CliError(f"--model {model}: no such file")
    try:
        srcs = getattr(args, "sources", None)
        return Detector(engine=args.engine, road=args.road, model=model,
                        sources=tuple(srcs) if srcs else None)
    except (RuntimeError, ValueError, TypeError) as e:
        raise CliError(f"--model {model}: {e}" if model else str(e)) from None


def run_detect(args) -> int:
    import cv2
    from tqdm import tqdm

    from ._native import VtError

    out = Path(args.out)
    kind = "image" if out.suffix.lower() in IMAGE_EXTS else \
        "video" if out.suffix.lower() in {".mp4", ".avi", ".mov", ".mkv"} else None
    if kind is None:
        raise CliError(f"--out {args.out}: expected a .png/.jpg image or an .mp4/.avi video name")
    if not out.parent.exists():
        raise CliError(f"--out {args.out}: folder {out.parent} does not exist")
    if args.json and not Path(args.json).parent.exists():
        raise CliError(f"--json {args.json}: folder {Path(args.json).parent} does not exist")
    sources = _frames_of(args.inputs)
    total = _count_frames(sources)
    show = not args.no_progress and (total is None or total > 1)
    det = make_detector(args)
    entries, written, video = [], [], VideoOut(out, sources)
    multi = total is None or total > 1
    try:
        with tqdm(total=total, unit="frame", disable=not show, file=sys.stderr) as bar:
            for i, (file, _k, frame) in enumerate(_iter_frames(sources)):
                try:
                    res = det.detect(frame)
                except (VtError, ValueError, TypeError) as e:
                    raise CliError(f"{file}: {e}") from None
                entries.append(detection_json(i, file, res))
                img = draw_detection(frame, res)
                if kind == "image":
                    path = out if not multi else out.with_name(f"{out.stem}_{i:05d}{out.suffix}")
                    if not cv2.imwrite(str(path), img):
                        raise CliError(f"{path}: cannot write")
                    written.append(str(path))
                else:
                    video.write(img)
                bar.update(1)
    finally:
        video.close()
    if kind == "video":
        written.append(str(out))
    if args.json:
        try:
            Path(args.json).write_text("[\n" + ",\n".join(json.dumps(e) for e in entries) + "\n]\n")
        except OSError as e:
            raise CliError(f"--json {args.json}: {e.strerror}") from None
    n_boxes = sum(len(e["boxes"]) for e in entries)
    where = written[0] if len(written) == 1 else f"{written[0]} .. {written[-1]}"
    print(f"{len(entries)} frame(s), {n_boxes} box(es); annotated: {where}"
          + (f"; json: {args.json}" if args.json else ""))
    return 0


if __name__ == "__main__":
    # Run through the imported module, so every subcommand sees one CliError class.
    from pyvehtrack.cli import main as _main
    sys.exit(_main())
