"""Lane lines and the road area of a camera frame (thesis sec. 2.4.1), friendly API.

    from pyvehtrack.lane import LaneDetector
    det = LaneDetector()                  # the C core; engine="reference" for the float oracle
    res = det.detect(frame)               # gray (h, w) or BGR (h, w, 3) uint8
    for lane in res.lanes:
        print(lane.side, lane.theta_deg, lane.points[:3])
    res.road                              # (N, 2) road-area polygon, input pixels

A detector keeps the lines of the previous frame (the lane tracker): feed the frames of
one video in order and call reset() between videos. Frames larger than the core's
compile-time maximum (VT_MAX_WIDTH x VT_MAX_HEIGHT) are downscaled first; the result
says so in `note` (and a warning is issued once), and all coordinates are still in the
input frame's pixels. Frames smaller than 16 x 16 raise ValueError.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field, fields, replace

import cv2
import numpy as np

from . import _check, _native
from .frames import to_gray
from .reference import lane as _ref

SIDES = _ref.SIDE_NAMES
STATES = {1: "found", 2: "held"}
MIN_SIZE = 16


@dataclass
class Lane:
    """One lane line. `points` are (x, y) input pixels, one per working-frame row from
    the top of the line down to the bottom row, only those inside the frame. rho and
    theta_deg are the Hough peak (normal form, theta from the x axis, y down) about
    `LaneResult.origin`, in input pixels."""
    side: str
    state: str
    rho: float
    theta_deg: float
    votes: int
    points: np.ndarray


@dataclass
class LaneResult:
    lanes: list                       # Lane, left to right (left-most, left, right, right-most)
    road: np.ndarray                  # (N, 2) int polygon of the road area; (0, 2) if none
    road_valid: bool
    road_y_top: int
    road_y_bottom: int
    x_left: np.ndarray                # (h,) road span per input row (0 outside the area)
    x_right: np.ndarray
    lane_width: np.ndarray            # (h,) ego lane width per input row
    vanishing_row: float | None       # input row where the two ego lines meet
    origin: tuple                     # Hough origin (x, y), input pixels
    work_shift: int                   # the core worked on the frame box-downscaled by 2^this
    input_scale: float = 1.0          # < 1 when the frame was downscaled to fit the core
    engine: str = "c"
    note: str = ""
    raw: object = field(default=None, repr=False)  # vt_lane_result (C) or LaneFrame (oracle)

    def lane(self, side: str) -> Lane | None:
        for ln in self.lanes:
            if ln.side == side:
                return ln
        return None


def default_config() -> _ref.LaneConfig:
    """The core's default configuration (VT_LANE_CFG_DEFAULT) as a LaneConfig."""
    return _ref.config_from(_native.lane_cfg_default())


def _to_c_cfg(cfg: _ref.LaneConfig):
    c = _native.ffi.new("vt_lane_cfg *")
    for f in fields(_ref.LaneConfig):
        setattr(c, f.name, _check.integer(getattr(cfg, f.name), f.name))
    return c


_as_gray = to_gray  # one conversion for every entry point (pyvehtrack.frames)


class LaneDetector:
    """Lane detector over a sequence of frames.

    engine: "c" (the fixed-point core, default) or "reference" (the float oracle).
    cfg: a pyvehtrack.reference.lane.LaneConfig (default: the core's defaults);
    keyword arguments override single fields, e.g. LaneDetector(work_width_max=320)."""

    def __init__(self, engine: str = "c", cfg: _ref.LaneConfig | None = None, **overrides):
        if engine not in ("c", "reference"):
            raise ValueError(f"engine must be 'c' or 'reference', got {engine!r}")
        cfg = cfg if cfg is not None else default_config()
        unknown = set(overrides) - {f.name for f in fields(_ref.LaneConfig)}
        if unknown:
            raise TypeError(f"unknown lane config field(s): {sorted(unknown)}")
        self.cfg = replace(cfg, **overrides)
        self.engine = engine
        self._ccfg = _to_c_cfg(self.cfg)
        _native.lane_cfg_check(self._ccfg)   # the same rules apply to both engines
        self.max_w = int(_native.lib.VT_MAX_WIDTH)
        self.max_h = int(_native.lib.VT_MAX_HEIGHT)
        self._warned = False
        # A view onto the pipeline: only its lane stage runs (every frame, no
        # hypotheses, no tracker); the pipeline owns the downscale rule.
        from . import config  # noqa: PLC0415
        from .pipeline import Pipeline  # noqa: PLC0415
        lane = config.LaneConfig(**{f.name: getattr(self.cfg, f.name) for f in fields(_ref.LaneConfig)})
        self.pipeline = Pipeline(engine, lane=lane, road="lanes", sources=(), lanes_every_frame=True,
                                 track=False)

    def reset(self) -> None:
        """Forget the tracked lines (call between unrelated frames or videos)."""
        self.pipeline.reset()

    # ------------------------------------------------------------------
    def detect(self, frame: np.ndarray) -> LaneResult:
        gray = _as_gray(frame)
        h0, w0 = gray.shape
        if h0 < MIN_SIZE or w0 < MIN_SIZE:
            raise ValueError(f"frame {w0}x{h0} is too small: the lane detector needs at "
                             f"least {MIN_SIZE}x{MIN_SIZE} pixels")
        scale, note = 1.0, ""
        w1, h1 = self.pipeline.work_size(w0, h0)
        if (w1, h1) != (w0, h0):
            gray = cv2.resize(gray, (w1, h1), interpolation=cv2.INTER_AREA)
            scale = w1 / w0
            note = (f"frame {w0}x{h0} is larger than the core's maximum "
                    f"{self.max_w}x{self.max_h}: it was downscaled to {w1}x{h1} before "
                    f"detection; coordinates are given in the input frame")
            if not self._warned:
                warnings.warn(note, stacklevel=2)
                self._warned = True
        res = self.pipeline.step_gray(gray)
        if res.lanes is None:
            status = int(self.pipeline._out.lane_status) if self.engine == "c" else int(_native.lib.VT_E_SIZE)
            _native.check("vt_lane_detect", status, f"img {gray.shape}")
            raise ValueError(f"frame {w1}x{h1}: the lane stage did not run")
        out = res.lanes
        out.engine, out.note, out.input_scale = self.engine, note, scale
        if scale != 1.0:
            _rescale(out, scale, w0, h0)
        return out


def from_c(r, road, shape) -> LaneResult:
    """The LaneResult of a C vt_lane_result * and vt_road_area * for a frame of
    `shape` (h, w) (the pixels the core saw; no rescaling). Copies everything."""
    ffi = _native.ffi
    lines = []
    for k in range(int(_native.lib.VT_LANE_SLOTS)):
        ln = r.lines[k]
        if ln.state == 0:
            continue
        n = ln.n_verts
        vy = [int(ln.vy[i]) for i in range(n)]
        vx = [ln.vx[i] / 65536.0 for i in range(n)]
        lines.append((k, int(ln.state), int(ln.votes), int(ln.theta), int(ln.rho),
                      int(ln.y_top), vy, vx))
    h = shape[0]
    arrs = [np.frombuffer(ffi.buffer(getattr(road, nm)), np.int16)[:h].astype(np.int32)
            for nm in ("x_left", "x_right", "lane_width")]
    # Copies: the next call overwrites the core's buffers.
    raw = ffi.new("vt_lane_result *", r[0])
    return _build(shape, int(r.shift), int(r.w), int(r.h), lines,
                  int(r.vp_y) if r.vp_known else None, bool(road.valid), int(road.y_top),
                  int(road.y_bottom), arrs, raw)


def from_reference(fr, shape) -> LaneResult:
    """The LaneResult of the oracle's LaneFrame for a frame of `shape` (h, w)."""
    lines = []
    for k, ln in enumerate(fr.lines):
        if ln is None:
            continue
        lines.append((k, ln.state, ln.votes, ln.theta_qdeg, ln.rho, ln.y_top,
                      [v[0] for v in ln.verts], [v[1] for v in ln.verts]))
    road = fr.road
    h = shape[0]
    arrs = [np.asarray(road[nm][:h], np.int32) for nm in ("x_left", "x_right", "lane_width")]
    return _build(shape, fr.shift, fr.W, fr.H, lines, fr.vp_y if fr.vp_known else None,
                  bool(road["valid"]), int(road["y_top"]), int(road["y_bottom"]), arrs, fr)


def _build(shape, s, W, H, lines, vp_y, road_valid, y_top, y_bottom, arrs, raw) -> LaneResult:
    h, w = shape
    n = 1 << s

    def to_in(v):
        return (v + 0.5) * n - 0.5

    lanes = []
    for k, state, votes, theta, rho, top, vy, vx in lines:
        ys = np.arange(top, vy[0] + 1)
        # The vertices span exactly rows top..H-1 (y decreasing): linear interpolation.
        xs = np.interp(ys, np.asarray(vy[::-1], float), np.asarray(vx[::-1], float))
        pts = np.stack([to_in(xs), to_in(ys.astype(float))], axis=1)
        pts = pts[(pts[:, 0] >= 0) & (pts[:, 0] <= w - 1)]
        lanes.append(Lane(SIDES[k], STATES.get(state, "found"), float(rho * n),
                          theta / _ref.QDEG, votes, pts))
    x_left, x_right, lane_width = arrs
    if road_valid:
        ys = np.arange(y_top, y_bottom + 1)
        poly = np.concatenate([np.stack([x_left[ys], ys], 1),
                               np.stack([x_right[ys[::-1]], ys[::-1]], 1)]).astype(np.int32)
    else:
        poly = np.zeros((0, 2), np.int32)
    return LaneResult(lanes, poly, road_valid, y_top, y_bottom, x_left, x_right, lane_width,
                      None if vp_y is None else to_in(float(vp_y)),
                      (to_in(float(W // 2)), to_in(float(H - 1))), s, raw=raw)


def _rescale(res: LaneResult, f: float, w0: int, h0: int) -> None:
    """Map a result computed on a frame downscaled by f back to the input frame."""
    def back(v):
        return (v + 0.5) / f - 0.5

    for ln in res.lanes:
        ln.points = back(ln.points)
        ln.rho = ln.rho / f
    res.origin = (back(res.origin[0]), back(res.origin[1]))
    if res.vanishing_row is not None:
        res.vanishing_row = back(res.vanishing_row)
    h1 = res.x_left.shape[0]
    rows = np.clip(np.floor((np.arange(h0) + 0.5) * f).astype(int), 0, h1 - 1)
    for nm in ("x_left", "x_right", "lane_width"):
        a = getattr(res, nm)[rows].astype(float)
        v = np.clip(back(a), 0, w0 - 1) if nm != "lane_width" else a / f
        setattr(res, nm, np.round(v).astype(np.int32))
    if res.road_valid:
        inside = (rows >= res.road_y_top) & (rows <= res.road_y_bottom)
        for nm in ("x_left", "x_right", "lane_width"):
            getattr(res, nm)[~inside] = 0
        ys = np.flatnonzero(inside)
        res.road_y_top, res.road_y_bottom = int(ys[0]), int(ys[-1])
        res.road = np.concatenate([np.stack([res.x_left[ys], ys], 1),
                                   np.stack([res.x_right[ys[::-1]], ys[::-1]], 1)]).astype(np.int32)
    else:
        res.road = np.zeros((0, 2), np.int32)


def tusimple_lanes(res: LaneResult, h_samples, width: int, sides=("left", "right")) -> list:
    """The result's lanes of the given sides as TuSimple lane lists (x per h_sample, -2
    where the lane has no point)."""
    from .eval.lanes import sample_points
    return [sample_points(ln.points, h_samples, width) for ln in res.lanes if ln.side in sides]


__all__ = ["Lane", "LaneResult", "LaneDetector", "default_config", "tusimple_lanes", "SIDES"]
