"""What users feed the detector (issue 8 item 5: dashcam H.264, gray or colour, any
resolution, dusk and overcast light), as transforms of a benchmark's frames, so a
detector scored on clean frames can be scored again on the same frames as a dashcam
would deliver them. Nothing here is chosen on any score: the settings are fixed, round
figures (stated per function) and every transform is deterministic.

    from pyvehtrack.eval import conditions as cd
    cd.dusk(img, seed=3); cd.overcast(img); cd.through_h264(frames, crf=23)
"""
from __future__ import annotations

import subprocess
import tempfile
from pathlib import Path

import cv2
import numpy as np

__all__ = ["LIGHTS", "CODECS", "dusk", "overcast", "light", "through_h264", "through_codec", "rescale"]

CODECS = ("mp4v", "h264")

LIGHTS = ("dusk", "overcast")


def _check(img: np.ndarray) -> np.ndarray:
    if not isinstance(img, np.ndarray) or img.dtype != np.uint8 or img.ndim not in (2, 3) or img.size == 0:
        raise ValueError("expected a non-empty uint8 gray (h, w) or colour (h, w, 3) image, got "
                         f"{getattr(img, 'dtype', type(img))} {getattr(img, 'shape', '')}")
    return img


def dusk(img: np.ndarray, seed: int = 0) -> np.ndarray:
    """Dusk: light falls to 40% (the mid-grey 128 goes to about 34), the shadows deepen (gamma
    1.6 on the normalised level) and the sensor's noise shows (Gaussian, sigma 3 grey levels,
    from `seed`), then rounded and clipped to 0..255."""
    x = _check(img).astype(np.float64) / 255.0
    y = 255.0 * 0.4 * x ** 1.6
    y += np.random.default_rng(seed).normal(0.0, 3.0, y.shape)
    return np.clip(np.rint(y), 0, 255).astype(np.uint8)


def overcast(img: np.ndarray) -> np.ndarray:
    """Overcast: flat light, no hard shadows: contrast halved about the frame's mean level,
    lifted by 20 grey levels (the haze of a bright, even sky), rounded and clipped."""
    x = _check(img).astype(np.float64)
    y = x.mean() + 0.5 * (x - x.mean()) + 20.0
    return np.clip(np.rint(y), 0, 255).astype(np.uint8)


def light(img: np.ndarray, name: str, seed: int = 0) -> np.ndarray:
    """`name` in LIGHTS."""
    if name == "dusk":
        return dusk(img, seed)
    if name == "overcast":
        return overcast(img)
    raise ValueError(f"light: expected one of {LIGHTS}, got {name!r}")


def rescale(img: np.ndarray, factor: float) -> np.ndarray:
    """The frame resized by `factor` (> 0): area averaging down, bilinear up, as a camera of
    another resolution would see the same scene; at least 1 x 1."""
    if not (isinstance(factor, (int, float)) and np.isfinite(factor) and factor > 0):
        raise ValueError(f"rescale: expected a factor > 0, got {factor!r}")
    h, w = _check(img).shape[:2]
    size = (max(1, int(round(w * factor))), max(1, int(round(h * factor))))
    return cv2.resize(img, size, interpolation=cv2.INTER_AREA if factor < 1 else cv2.INTER_LINEAR)


def through_h264(frames, crf: int = 23, fps: float = 10.0):
    """The frames [(index, image)] encoded as one H.264 MP4 (libx264, constant rate factor
    `crf`, 23 = x264's default quality; preset medium, yuv420p as dashcams write it) and decoded
    again by OpenCV, gray or colour as they came; None when the video lost frames. The encoder
    is the ffmpeg binary of the imageio-ffmpeg package (OpenCV's wheel has no H.264 encoder):
    `pip install imageio-ffmpeg`."""
    frames = list(frames)
    if not frames:
        raise ValueError("through_h264: no frames")
    if not (isinstance(crf, int) and 0 <= crf <= 51):
        raise ValueError(f"through_h264: expected a CRF 0..51, got {crf!r}")
    try:
        import imageio_ffmpeg
    except ImportError as e:
        raise RuntimeError("H.264 needs the imageio-ffmpeg package (pip install imageio-ffmpeg)") from e
    gray = frames[0][1].ndim == 2
    h, w = frames[0][1].shape[:2]
    if any(img.shape[:2] != (h, w) for _, img in frames):
        raise ValueError("through_h264: every frame must have the first one's size")
    with tempfile.TemporaryDirectory() as td:
        path = str(Path(td) / "clip.mp4")
        cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "rawvideo",
               "-pix_fmt", "gray" if gray else "bgr24", "-s", f"{w}x{h}", "-r", str(fps), "-i", "-",
               # 4:2:0 needs even sides: one black row / column padded on, cut off after decoding
               "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264", "-preset", "medium",
               "-crf", str(crf), "-pix_fmt", "yuv420p", path]
        raw = b"".join(np.ascontiguousarray(_check(img)).tobytes() for _, img in frames)
        p = subprocess.run(cmd, input=raw, capture_output=True)
        if p.returncode != 0:
            raise RuntimeError(f"ffmpeg (libx264) failed: {p.stderr.decode(errors='replace').strip()}")
        cap = cv2.VideoCapture(path)
        out = []
        for idx, _ in frames:
            ok, img = cap.read()
            if not ok:
                cap.release()
                return None
            img = np.ascontiguousarray(img[:h, :w])
            out.append((idx, cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if gray else img))
        cap.release()
    return out


def through_codec(frames, codec: str, fps: float = 10.0):
    """The frames [(index, image)] through one video of `codec` and decoded again, gray or colour
    as they came, or None when the video lost frames: "mp4v" (OpenCV's MPEG-4 part 2 at default
    quality, pyvehtrack.eval.kitti_lead.through_mp4) or "h264" (through_h264 at CRF 23)."""
    frames = list(frames)
    if codec == "h264":
        return through_h264(frames, fps=fps)
    if codec != "mp4v":
        raise ValueError(f"through_codec: codec {codec!r}: expected one of {CODECS}")
    from .kitti_lead import through_mp4  # noqa: PLC0415  (kitti_lead imports this module's users)
    gray = bool(frames) and frames[0][1].ndim == 2   # OpenCV's writer takes colour frames only
    coded = through_mp4([(i, cv2.cvtColor(f, cv2.COLOR_GRAY2BGR)) for i, f in frames] if gray else frames)
    if coded is None or not gray:
        return coded
    return [(i, cv2.cvtColor(f, cv2.COLOR_BGR2GRAY)) for i, f in coded]
