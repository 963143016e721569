"""What every subcommand shares: the user-error type, the one list of image and video
extensions, the frame reader (images, folders, videos; corrupt frames found, not guessed)
and the all-or-nothing output files.

Outputs are all or nothing: `Outputs.reserve()` checks an output path and creates a hidden
temporary file beside it *before* the run (so an unwritable path is found at once), the run
writes to the temporary names, and `Outputs.commit()` renames them all into place at the end.
On any error `Outputs.abort()` removes them, so a failed run leaves no partial output.
"""
from __future__ import annotations

import os
import sys
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["CliError", "add_command", "IMAGE_EXTS", "VIDEO_EXTS", "VIDEO_OUT_EXTS", "output_kind", "frame_sources",
           "FrameReader", "read_image", "progress", "count_frames", "video_fps", "VideoOut", "Outputs"]

# The one list of file types (pyvehtrack.frames, where the coding rule reads them too).
# VIDEO_OUT_EXTS: the containers cv2.VideoWriter writes here (.avi with MJPG, the others with mp4v).
from ..frames import IMAGE_EXTS, VIDEO_EXTS  # noqa: E402
VIDEO_OUT_EXTS = frozenset({".mp4", ".avi", ".mov", ".mkv"})


def add_command(sub, name: str, **kw):
    """A subcommand's parser: `sub.add_parser(name, **kw)` with the epilog's examples kept
    as written (RawDescriptionHelpFormatter), the one layout every subcommand uses."""
    import argparse
    return sub.add_parser(name, formatter_class=argparse.RawDescriptionHelpFormatter, **kw)


class CliError(Exception):
    """A user-facing error: main() prints it as one line and exits with status 2."""


def add_range_args(p) -> None:
    """The range stage's and the warning's options of `track` and `report` (all need a
    camera; pyvehtrack._check.range_options checks the first three)."""
    p.add_argument("--ego-speed", type=float, default=None, metavar="M/S",
                   help="own speed, m/s, if known: picks the NHTSA threshold of the lead's class")
    p.add_argument("--rear-offset", type=float, default=0.0, metavar="M",
                   help="m from the road contact the box's bottom shows to the vehicle's rear "
                        "(default 0: eq. 1 as is; about 1.8 on KITTI, see the README)")
    p.add_argument("--bottom-height", type=float, default=0.0, metavar="M",
                   help="height above the road of what the box's bottom edge shows, m (default 0: "
                        "the road contact; about 0.37 on KITTI, where the box ends at the bumper's "
                        "lower edge): eq. 1 then uses the camera height minus it")
    p.add_argument("--path-half-width", type=float, default=1.5, metavar="M",
                   help="the warning is for tracks in the ego path only: a box must overlap the "
                        "straight corridor of +-M m around the car's centre line at its distance "
                        "(the camera file's lateral_m says how far right of it the camera sits) "
                        "(default 1.5; 0: every closing track may warn)")
    p.add_argument("--warn-ttc", choices=("distance", "fused"), default="distance",
                   help="the TTC the collision warning decides on: distance (default; the "
                        "distance/rate TTC, ttc_s) or fused (the block-scale and distance/rate TTCs "
                        "in one, the TTC drawn and written as ttc_fused_s; opt-in: on the synthetic "
                        "NHTSA scenes it warns in time but with less margin on a braking lead)")


def add_model_arg(p) -> None:
    """--model / --sources of `detect` and `track` (the full-road detector)."""
    p.add_argument("--model", metavar="MODEL.npz", default=None,
                   help="classifier model for detection over the whole road, run with the settings it "
                        "carries (default: the shipped pyvehtrack/models/cnn_gray_l0_big.npz on the C "
                        "engine: a small CNN on a pyramid and on a full-resolution band for far vehicles, "
                        "beside the ego-lane detector; window_mlp_hog32.npz with --engine reference; "
                        "acf_gray_rescore.npz, the default before); 'none': the thesis's "
                        "ego-lane detector alone")
    p.add_argument("--sources", nargs="+", choices=("shadow", "windows", "ego"), default=None,
                   help="full-road hypothesis sources (default with --model: the model's, else shadow; "
                        "windows = classifier sliding windows; ego beside them = the ego-lane detector's "
                        "boxes first, e.g. --sources ego shadow windows); without --model the built-in "
                        "classifier is used")
    add_work_width_arg(p)
    p.add_argument("--no-hood-finder", action="store_true",
                   help="do not look for the ego car's hood in the frame (by default, without a camera file's "
                        "hood_row, the ego-lane detector's road ends above a hood found as a level edge across "
                        "the frame's bottom)")


def load_camera(path: str, hint: str = ""):
    """The camera file given with --camera, which must hold the camera height (the
    distances need it); CliError naming the flag otherwise."""
    from ..camera import Camera, CameraFileError
    try:
        cam = Camera.load(path)
    except CameraFileError as e:
        raise CliError(f"--camera: {e}") from None
    if cam.height_m is None:
        raise CliError(f"--camera {path}: 'height_m' (camera height above the road) is missing{hint}")
    return cam


def out_folder(path: str) -> Path:
    """The --out folder of `batch` and `report`: may exist (as a folder); its parent must."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise CliError(f"--out {path}: exists and is not a folder")
    if not out.parent.exists():
        raise CliError(f"--out {path}: folder {out.parent} does not exist")
    return out


def resolve_model(model, sources=None, engine="c"):
    """--model as a path or None: not given -> the shipped whole-road model of the engine
    (fullroad.default_model_path; unless --sources chose the built-in classifier); "none"
    -> None, the ego-lane detector alone. CliError for a missing file or "none" with --sources."""
    from ..fullroad import default_model_path
    if model is None and not sources:
        model = str(default_model_path(engine))   # no choice made: the shipped whole-road model
    elif model is None:
        # documented, but easy to miss: a user narrowing the default's sources gets another detector
        import warnings  # noqa: PLC0415
        warnings.warn(f"--sources without --model: the whole-road detector runs with the built-in HOG SVM "
                      f"classifier, not the default model; to narrow the default's own sources add --model "
                      f"{default_model_path(engine)}", stacklevel=2)
    elif model == "none":
        if sources:
            raise CliError("--sources needs a classifier; --model none is the ego-lane detector alone")
        return None
    if model is not None and not Path(model).is_file():
        raise CliError(f"--model {model}: no such file")
    return model


def add_work_width_arg(p, prefix: str = "") -> None:
    """--work-width of `detect`, `track`, `report` and `batch` (prefix: what the command does
    with it, e.g. "passed to track: ")."""
    from ..shared import WORK_WIDTH
    p.add_argument("--work-width", type=int, default=WORK_WIDTH, metavar="PX",
                   help=f"{prefix}frames wider than this are processed downscaled to it, results in the "
                        f"input's pixels (default {WORK_WIDTH}: the width the stages were tuned and the networks "
                        f"trained at; a 1920x1080 frame is processed at 1280x720); 0: only frames past the "
                        f"core's maximum are downscaled")


def work_width_arg(args):
    """--work-width as the Pipeline's work_width (0 -> None); CliError outside 16..65535."""
    from ..shared import WORK_WIDTH
    ww = getattr(args, "work_width", WORK_WIDTH)
    if ww == 0:
        return None
    if not 16 <= ww <= 65535:
        raise CliError(f"--work-width {ww}: expected 16..65535 px, or 0")
    return ww


def make_detector(args, cam=None):
    """The Detector of `detect` and `track`, with the user's mistakes as CliError. cam: the
    --camera file's Camera; its geometry (horizon, focal length, height) places the
    whole-road detector's windows (Camera.road_camera), else the defaults (TuSimple's)."""
    from ..detector import Detector
    srcs = getattr(args, "sources", None)
    model = resolve_model(getattr(args, "model", None), srcs, getattr(args, "engine", "c"))
    try:
        road_cam = cam.road_camera() if cam is not None else None
        return Detector(engine=args.engine, road=args.road, model=model,
                        sources=tuple(srcs) if srcs else None, camera=road_cam,
                        auto_hood=not getattr(args, "no_hood_finder", False),
                        work_width=work_width_arg(args))
    except (RuntimeError, ValueError, TypeError) as e:
        raise CliError(f"--model {model}: {e}" if model else str(e)) from None


def output_kind(path: str | os.PathLike) -> str | None:
    """"image" or "video" by the output name's extension, None for anything else."""
    suffix = Path(path).suffix.lower()
    return "image" if suffix in IMAGE_EXTS else "video" if suffix in VIDEO_OUT_EXTS else None


# ====================================================================== inputs
def frame_sources(inputs: list[str]) -> list[tuple[str, str]]:
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


# Formats whose decoder in OpenCV fails on truncated or corrupt data by itself (it returns
# None): PNG (libpng checks chunk lengths and CRCs), BMP, PGM/PPM. Everything else -- JPEG
# above all, which OpenCV decodes cut short with only a warning and the rest of the frame
# grey -- is decoded by Pillow first, which refuses truncated data.
_SELF_CHECKING = (b"\x89PNG\r\n\x1a\n", b"BM", b"P5", b"P6")


def read_image(path: str):
    """A uint8 image (gray, BGR or BGRA) read from `path`; CliError naming the file when it is
    missing, unreadable, empty, truncated or corrupt. OpenCV's decoding is the one used, as
    before; Pillow only checks the formats OpenCV would accept truncated (see _SELF_CHECKING).
    Costs one extra decode per JPEG frame, none per PNG frame."""
    import io

    import cv2
    import numpy as np
    from PIL import Image, UnidentifiedImageError

    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise CliError(f"{path}: cannot read ({e.strerror})") from None
    if not data:
        raise CliError(f"{path}: empty file")
    if not data.startswith(_SELF_CHECKING):
        try:
            with Image.open(io.BytesIO(data)) as im:
                im.load()
        except UnidentifiedImageError:
            pass                                # a type Pillow does not know: OpenCV decides
        except (OSError, SyntaxError, ValueError, EOFError, Image.DecompressionBombError) as e:
            raise CliError(f"{path}: corrupt or truncated image ({e})") from None
    with _quiet_fd2():                          # libpng prints its own error on fd 2
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise CliError(f"{path}: cannot read as an image (corrupt, truncated or not an image)")
    if img.dtype != np.uint8:
        if img.dtype != np.uint16:
            raise CliError(f"{path}: unsupported pixel type {img.dtype}")
        img = (img >> 8).astype(np.uint8)       # 16-bit PNGs: keep the high byte
    return img


@dataclass
class FrameReader:
    """Iterate (frame index in input order, file label, BGR or gray uint8 frame) over sources.

    A frame that cannot be decoded raises CliError naming it; with skip_bad=True it is
    skipped instead, counted in `skipped` (labels) and announced on stderr, and the frame
    index still advances, so later frames keep their input-order numbers."""
    sources: list
    skip_bad: bool = False
    skipped: list = field(default_factory=list)

    def _bad(self, label: str, why: str) -> None:
        if not self.skip_bad:
            raise CliError(f"{label}: {why} (use --skip-bad-frames to skip it)")
        self.skipped.append(label)
        print(f"pyvehtrack: skipping {label}: {why}", file=sys.stderr)

    def __iter__(self):
        import cv2

        from ..frames import read_video
        i = 0
        for kind, path in self.sources:
            if kind == "image":
                try:
                    img = read_image(path)
                except CliError as e:
                    self._bad(path, str(e).split(": ", 1)[-1])
                else:
                    yield i, path, img
                i += 1
                continue
            cap = open_video(path)
            if cap is None:
                raise CliError(f"{path}: cannot open as a video")
            declared = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
            k = 0
            for img in read_video(cap):
                yield i, path, img
                i += 1
                k += 1
            if k == 0:
                raise CliError(f"{path}: the video has no readable frame")
            if declared > k:                    # the stream ends before its container says
                self._bad(f"{path} frame {k}", f"cannot decode (the video ends early: {k} of "
                          f"{declared} frames read)")
                i += declared - k


@contextmanager
def _quiet_fd2():
    """Silence what C libraries print on fd 2 (OpenCV's AVI parser, FFmpeg) while a video is
    opened: a file that cannot be opened is reported once, as a CliError line."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):           # no real fd 2 (embedded use): nothing to silence
        yield
        return
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(null)


def open_video(path: str):
    """cv2.VideoCapture on `path`, opened quietly; None when it cannot be opened."""
    import cv2
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")     # FFmpeg: quiet (read at open)
    with _quiet_fd2():
        cap = cv2.VideoCapture(path)
    if not cap.isOpened():
        cap.release()
        return None
    return cap


def count_frames(sources) -> int | None:
    """The number of frames, or None when a video does not declare its length."""
    import cv2
    n = 0
    for kind, path in sources:
        if kind == "image":
            n += 1
        else:
            cap = open_video(path)
            c = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if cap is not None else 0
            if cap is not None:
                cap.release()
            if c <= 0:
                return None
            n += c
    return n


def video_fps(sources) -> float:
    """The first input video's frame rate, 10 fps (KITTI's) for frames."""
    import cv2
    for kind, path in sources:
        if kind == "video":
            cap = open_video(path)
            fps = cap.get(cv2.CAP_PROP_FPS) if cap is not None else 0
            if cap is not None:
                cap.release()
            if fps and fps > 0:
                return float(fps)
    return 10.0


@contextmanager
def progress(total: int | None, disable: bool):
    """A tqdm frame counter on stderr that erases itself when the run fails, so the error
    is the one line left on the screen."""
    from tqdm import tqdm
    bar = tqdm(total=total, unit="frame", disable=disable, file=sys.stderr)
    try:
        yield bar
    except BaseException:
        bar.leave = False
        raise
    finally:
        bar.close()


# ====================================================================== outputs
class Outputs:
    """All-or-nothing output files (see the module doc). Use as a context manager: the
    temporary files are removed unless commit() ran."""

    def __init__(self):
        self._pending: list[tuple[Path, Path]] = []     # (temporary, final)

    def reserve(self, option: str, path: str | os.PathLike) -> Path:
        """Check that `path` can be written and return a temporary path beside it, with the same
        extension (OpenCV picks the format from it); CliError naming `option` otherwise."""
        final = Path(path)
        for _tmp, other in self._pending:
            if other.resolve() == final.resolve():
                raise CliError(f"{option} {path}: the same file as another output")
        if final.is_dir():
            raise CliError(f"{option} {path}: is a folder")
        parent = final.parent
        if not parent.exists():
            raise CliError(f"{option} {path}: folder {parent} does not exist")
        if final.exists() and not os.access(final, os.W_OK):
            raise CliError(f"{option} {path}: file is not writable")
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{final.stem}.", suffix=f".part{final.suffix}", dir=parent)
        except OSError as e:
            raise CliError(f"{option} {path}: cannot write in {parent} ({e.strerror})") from None
        os.close(fd)
        self._pending.append((Path(tmp), final))
        return Path(tmp)

    def check(self, option: str, path: str | os.PathLike) -> None:
        """reserve() without keeping the file: for outputs named only during the run (numbered
        frames), checked before it."""
        tmp = self.reserve(option, path)
        self._pending.pop()
        tmp.unlink()

    def commit(self) -> None:
        """Rename every temporary file into place."""
        for tmp, final in self._pending:
            os.replace(tmp, final)
        self._pending = []

    def abort(self) -> None:
        for tmp, _ in self._pending:
            try:
                tmp.unlink()
            except FileNotFoundError:
                pass
        self._pending = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.abort()
        return False


class VideoOut:
    """An annotated-video writer opened on the first frame (its size fixes the video's);
    later frames of another size are resized to it. `path` picks the container and is where
    it writes (a temporary name from Outputs.reserve); `name` is what errors call it."""

    def __init__(self, path: Path, sources, name: str | None = None):
        self.path, self.sources, self.writer, self.size = Path(path), sources, None, None
        self.name = name or str(path)

    def write(self, img) -> None:
        import cv2
        if self.writer is None:
            self.size = (img.shape[1], img.shape[0])
            fourcc = cv2.VideoWriter_fourcc(*("MJPG" if self.path.suffix.lower() == ".avi" else "mp4v"))
            self.writer = cv2.VideoWriter(str(self.path), fourcc, video_fps(self.sources), self.size)
            if not self.writer.isOpened():
                raise CliError(f"{self.name}: cannot open a video writer")
        if (img.shape[1], img.shape[0]) != self.size:
            img = cv2.resize(img, self.size, interpolation=cv2.INTER_AREA)
        self.writer.write(img)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.release()
