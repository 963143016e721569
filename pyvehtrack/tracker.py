"""Multi-vehicle tracking from Python (thesis ch. 3), on the C core or the float
reference.

    trk = Tracker()                       # C engine, thesis defaults, detection every 10th frame
    for frame in frames:
        tracks = trk.step(frame)          # list[Track]: id, state, box, velocity (px/frame)

`step(frame, detections=...)` feeds your own detections instead (an (N, 4) array
of inclusive [left, top, right, bottom] boxes; float coordinates are rounded to the
nearest pixel, NaN/inf/non-numbers refused); then detection frames are the frames
where you pass them.

`Tracker(measurement="edges")` measures each track by matching its edge curves
(GIST paper sec. III.B) instead of the thesis's ROI search ("roi", the default)."""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

import cv2
import numpy as np

from . import _check, _native
from .frames import to_gray
from .kalman import ModelConfig
from .reference import tracker as rtrk

STATES = {1: "tentative", 2: "confirmed", 3: "coasting"}
MEASUREMENTS = {"roi": rtrk.MEAS_ROI_SEARCH, "edges": rtrk.MEAS_EDGE_CURVES}


@dataclass(frozen=True)
class Track:
    id: int
    state: str            # "tentative" | "confirmed" | "coasting"
    box: tuple            # (left, top, right, bottom), inclusive, input pixels
    velocity: tuple       # (vx, vy) of the bottom edge, input px/frame


def cfg_to_c(cfg: rtrk.TrackerCfg):
    """The C struct for a TrackerCfg: Q16 for model values, Q14 for the NCC threshold
    (each rounded to nearest). TypeError / ValueError naming the field for a value that is
    not an integer (or a number in [-1, 1] for keep_ncc); the C core checks the ranges."""
    if not isinstance(cfg, rtrk.TrackerCfg):
        raise TypeError(f"cfg: expected a TrackerCfg, got {type(cfg).__name__}")
    c = _native.ffi.new("vt_tracker_cfg *")
    for f in fields(cfg.search):
        setattr(c.search, f.name, _check.integer(getattr(cfg.search, f.name), f"cfg.search.{f.name}"))
    c.model = ModelConfig(**vars(cfg.model)).to_c()[0]  # Q16, checked, as the Kalman API does
    for f in fields(cfg):
        if f.name == "edge":
            for g in fields(cfg.edge):
                setattr(c.edge, g.name, _check.integer(getattr(cfg.edge, g.name), f"cfg.edge.{g.name}"))
        elif f.name not in ("search", "model", "keep_ncc"):
            setattr(c, f.name, _check.integer(getattr(cfg, f.name), f"cfg.{f.name}"))
    keep = _check.real(cfg.keep_ncc, "cfg.keep_ncc")
    if not -1.0 <= keep <= 1.0:
        raise ValueError(f"cfg.keep_ncc: {cfg.keep_ncc} must be in [-1, 1]")
    c.keep_ncc = int(round(keep * 16384))
    return c


def _c_accepts(c) -> bool:
    """Whether the core accepts a tracker config. The C tracker checks its config at every
    step (there is no separate check function), so step a fresh tracker once on a blank
    16x16 frame: nothing else in that call can fail."""
    st = _native.ffi.new("vt_tracker *")
    _native.lib.vt_tracker_init(st)
    img = np.zeros((16, 16), np.uint8)
    try:
        _native.tracker_step(st, c, img, False)
    except _native.VtError:
        return False
    return True


def check_cfg(cfg: rtrk.TrackerCfg):
    """The C struct of a config the core accepts; ValueError naming the offending field(s)
    otherwise (found by trying each field alone on top of the C defaults)."""
    c = cfg_to_c(cfg)
    if _c_accepts(c):
        return c
    default = _native.tracker_cfg_default()
    bad = []
    for f in fields(cfg):
        if f.name in ("search", "model", "edge"):
            for g in fields(getattr(cfg, f.name)):
                t = _native.ffi.new("vt_tracker_cfg *", default[0])
                setattr(getattr(t, f.name), g.name, getattr(getattr(c, f.name), g.name))
                if not _c_accepts(t):
                    bad.append(f"cfg.{f.name}.{g.name}={getattr(getattr(cfg, f.name), g.name)!r}")
        else:
            t = _native.ffi.new("vt_tracker_cfg *", default[0])
            setattr(t, f.name, getattr(c, f.name))
            if not _c_accepts(t):
                bad.append(f"cfg.{f.name}={getattr(cfg, f.name)!r}")
    what = ", ".join(bad) if bad else "a combination of fields"
    raise ValueError(f"tracker config refused by the core: {what} out of range")


class Tracker:
    """Vehicle tracker. engine="c" runs the fixed-point core, "reference" the float oracle.

    detector: an object with .detect(gray) -> result with .boxes (N, 4), used every
    `detect_every` frames when step() is not given detections. measurement: "roi" (thesis
    ROI search) or "edges" (edge curves matched by chamfer distance, GIST paper); when given
    it overrides cfg.measurement. Frames larger than the
    core's compile-time maximum are downscaled by an integer factor (boxes are scaled
    back to input pixels), never clipped."""

    def __init__(self, engine: str = "c", cfg: rtrk.TrackerCfg | None = None,
                 detect_every: int = 10, detector=None, measurement: str | None = None):
        _check.choice(engine, "engine", ("c", "reference"))
        if measurement is not None:
            _check.choice(measurement, "measurement", tuple(MEASUREMENTS))
        self.detect_every = _check.integer(detect_every, "detect_every", lo=1)
        if detector is not None and not callable(getattr(detector, "detect", None)):
            raise TypeError(f"detector: expected an object with a detect(frame) method, "
                            f"got {type(detector).__name__}")
        self.engine = engine
        self.cfg = cfg if cfg is not None else rtrk.TrackerCfg()
        if measurement is not None and isinstance(self.cfg, rtrk.TrackerCfg):  # else check_cfg names it
            self.cfg = replace(self.cfg, measurement=MEASUREMENTS[measurement])
        ccfg = check_cfg(self.cfg)      # both engines: errors now, naming the field
        self.detector = detector
        self.frame_index = 0
        self.last_was_detection = False  # whether the last step() had detections
        if engine == "c":
            self._ccfg = ccfg
            self._tr = _native.tracker_new()
        else:
            lib = _native.lib
            self._ref = rtrk.Tracker(self.cfg, max_tracks=int(lib.VT_MAX_TRACKS),
                                     max_edge_points=int(lib.VT_EDGE_MAX_POINTS),
                                     max_edge_pixels=int(lib.VT_EDGE_MAX_PIXELS),
                                     coord_lim=4 * max(int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)))

    def _scale(self, gray: np.ndarray) -> int:
        h, w = gray.shape
        f = 1
        while w // f > _native.lib.VT_MAX_WIDTH or h // f > _native.lib.VT_MAX_HEIGHT:
            f += 1
        return f

    def step(self, frame: np.ndarray, detections=None) -> list[Track]:
        gray = to_gray(frame)
        if gray.size == 0:
            raise ValueError("empty frame")
        f = self._scale(gray)
        # at least one pixel each way: a 5000x1 frame shrinks along its long side only
        small = cv2.resize(gray, (max(1, gray.shape[1] // f), max(1, gray.shape[0] // f)),
                           interpolation=cv2.INTER_AREA) if f > 1 else gray
        if detections is not None:
            det_frame, dets = True, _native._boxes_i32(detections, "detections")
        elif self.detector is not None and self.frame_index % self.detect_every == 0:
            det_frame, dets = True, np.asarray(self.detector.detect(frame).boxes).reshape(-1, 4)
        else:
            det_frame, dets = False, np.zeros((0, 4), np.int32)
        self.last_was_detection = det_frame
        if f > 1 and len(dets):
            dets = np.asarray(dets) // f
        self.frame_index += 1
        if self.engine == "c":
            rows = _native.tracker_step(self._tr, self._ccfg, small, det_frame, dets)
            out = [Track(int(r["id"]), STATES[int(r["state"])],
                         tuple(int(r[k]) * f for k in ("left", "top", "right", "bottom")),
                         (r["vx"] / 65536 * f, r["vy"] / 65536 * f)) for r in rows]
        else:
            rows = self._ref.step(small, det_frame, dets)
            out = [Track(i, STATES[s], tuple(int(v) * f for v in b), (vx * f, vy * f))
                   for i, s, b, vx, vy in rows]
        return out
