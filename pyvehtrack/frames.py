"""Frame conversion shared by the friendly APIs: every entry point takes gray or
BGR(A) uint8 NumPy frames and hands the core a contiguous gray image."""
from __future__ import annotations

import cv2
import numpy as np


def to_gray(frame) -> np.ndarray:
    """A contiguous uint8 (h, w) gray image from a gray, BGR or BGRA uint8 array;
    TypeError / ValueError, naming the problem, for anything else."""
    if not isinstance(frame, np.ndarray):
        raise TypeError(f"frame: expected a numpy.ndarray, got {type(frame).__name__}")
    if frame.dtype != np.uint8:
        raise TypeError(f"frame: expected dtype uint8, got {frame.dtype}")
    if frame.ndim == 3 and frame.shape[2] == 1:
        frame = frame[:, :, 0]
    if frame.ndim == 3 and frame.shape[2] in (3, 4):
        if frame.shape[0] == 0 or frame.shape[1] == 0:
            raise ValueError(f"frame: empty image of shape {frame.shape}")
        code = cv2.COLOR_BGR2GRAY if frame.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        return cv2.cvtColor(np.ascontiguousarray(frame), code)
    if frame.ndim != 2:
        raise ValueError(f"frame: expected (h, w) gray or (h, w, 3) BGR, got shape {frame.shape}")
    if frame.shape[0] == 0 or frame.shape[1] == 0:
        raise ValueError(f"frame: empty image of shape {frame.shape}")
    return np.ascontiguousarray(frame)


def read_video(cap):
    """Every frame an opened cv2.VideoCapture gives, in order; the capture is released
    when the frames run out or the reader stops (the one read loop of the CLI and the
    report)."""
    try:
        while True:
            ok, img = cap.read()
            if not ok:
                return
            yield img
    finally:
        cap.release()
