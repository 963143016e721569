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
from .shared import QDEG, SIDE_NAMES, WORK_WIDTH, LaneConfig, lane_config_from

SIDES = SIDE_NAMES
FURTHER = "further"   # side of a line of lanes_all that is in no slot
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
    work_shift: int                   # log2(work_scale) if that is a power of two, else -1
    work_scale: int = 1               # the core worked on the frame box-downscaled by this
    input_scale: float = 1.0          # < 1 when the frame was downscaled to fit the core
    engine: str = "c"
    note: str = ""
    raw: object = field(default=None, repr=False)  # vt_lane_result (C) or LaneFrame (oracle)
    # Every lane line found, left to right (issue 8): the slot lines above (side =
    # their slot) and the further outer lines through the vanishing point (side
    # "further"); and the road area spanning all of them (lane_width_all = mean lane
    # width). The ego fields above are unchanged.
    lanes_all: list = field(default_factory=list)
    road_all: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int32))
    road_all_valid: bool = False
    road_all_y_top: int = 0
    road_all_y_bottom: int = 0
    x_left_all: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    x_right_all: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    lane_width_all: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))

    def lane(self, side: str) -> Lane | None:
        for ln in self.lanes:
            if ln.side == side:
                return ln
        return None


def default_config() -> LaneConfig:
    """The core's default configuration (VT_LANE_CFG_DEFAULT) as a LaneConfig."""
    return lane_config_from(_native.lane_cfg_default())


def _to_c_cfg(cfg: LaneConfig):
    c = _native.ffi.new("vt_lane_cfg *")
    for f in fields(LaneConfig):
        setattr(c, f.name, _check.integer(getattr(cfg, f.name), f.name))
    return c


_as_gray = to_gray  # one conversion for every entry point (pyvehtrack.frames)


class LaneDetector:
    """Lane detector over a sequence of frames.

    engine: "c" (the fixed-point core, default) or "reference" (the float oracle).
    cfg: a pyvehtrack.shared.LaneConfig (the oracle re-exports it; default: the core's defaults);
    keyword arguments override single fields, e.g. LaneDetector(work_width_max=320).
    work_width: frames wider than this are downscaled to it first, as the pipeline does
    (default 1280, pyvehtrack.pipeline.WORK_WIDTH; None: only past the core's maximum);
    the result is in the input frame's pixels either way."""

    def __init__(self, engine: str = "c", cfg: LaneConfig | None = None, *, work_width=WORK_WIDTH,
                 **overrides):
        if engine not in ("c", "reference"):
            raise ValueError(f"engine must be 'c' or 'reference', got {engine!r}")
        cfg = cfg if cfg is not None else default_config()
        unknown = set(overrides) - {f.name for f in fields(LaneConfig)}
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
        lane = config.LaneConfig(**{f.name: getattr(self.cfg, f.name) for f in fields(LaneConfig)})
        self.pipeline = Pipeline(engine, lane=lane, road="lanes", sources=(), lanes_every_frame=True,
                                 track=False, work_width=work_width)

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
            from .pipeline import resample  # noqa: PLC0415
            gray = resample(gray, (w1, h1), self.engine)
            scale = w1 / w0
            past = w0 > self.max_w or h0 > self.max_h
            note = (f"frame {w0}x{h0} is larger than the core's maximum {self.max_w}x{self.max_h}"
                    if past else f"frame {w0}x{h0} is wider than work_width {self.pipeline.work_width}")
            note += f": it was downscaled to {w1}x{h1} before detection; coordinates are given in the input frame"
            if past and not self._warned:
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
    h, w = shape

    def c_line(k, ln):
        n = ln.n_verts
        vy = [int(ln.vy[i]) for i in range(n)]
        vx = [ln.vx[i] / 65536.0 for i in range(n)]
        return (k, int(ln.state), int(ln.votes), int(ln.theta), int(ln.rho),
                int(ln.y_top), vy, vx)

    lines = [c_line(k, r.lines[k]) for k in range(int(_native.lib.VT_LANE_SLOTS))
             if r.lines[k].state != 0]
    lines_all = [c_line(int(r.lines_all_slot[i]), r.lines_all[i]) for i in range(r.n_lines_all)]

    def c_road(rd):
        arrs = [np.frombuffer(ffi.buffer(getattr(rd, nm)), np.int16)[:h].astype(np.int32)
                for nm in ("x_left", "x_right", "lane_width")]
        return bool(rd.valid), int(rd.y_top), int(rd.y_bottom), arrs

    road_all = ffi.new("vt_road_area *")
    _native.lane_road_all(r, w, h, road_all)
    # Copies: the next call overwrites the core's buffers.
    raw = ffi.new("vt_lane_result *", r[0])
    return _build(shape, int(r.scale), int(r.w), int(r.h), lines,
                  int(r.vp_y) if r.vp_known else None, *c_road(road), raw,
                  lines_all, c_road(road_all))


def from_reference(fr, shape) -> LaneResult:
    """The LaneResult of the oracle's LaneFrame for a frame of `shape` (h, w)."""
    h, w = shape

    def r_line(k, ln):
        return (k, ln.state, ln.votes, ln.theta_qdeg, ln.rho, ln.y_top,
                [v[0] for v in ln.verts], [v[1] for v in ln.verts])

    lines = [r_line(k, ln) for k, ln in enumerate(fr.lines) if ln is not None]
    lines_all = [r_line(k, ln) for k, ln in zip(fr.lines_all_slot, fr.lines_all)]

    def r_road(road):
        arrs = [np.asarray(road[nm][:h], np.int32) for nm in ("x_left", "x_right", "lane_width")]
        return bool(road["valid"]), int(road["y_top"]), int(road["y_bottom"]), arrs

    from .reference import lane as _ref   # only the reference engine has a LaneFrame
    road_all = _ref.road_area_all(fr.lines_all, w, h, fr.scale, len(fr.road["x_left"]))
    return _build(shape, fr.scale, fr.W, fr.H, lines, fr.vp_y if fr.vp_known else None,
                  *r_road(fr.road), fr, lines_all, r_road(road_all))


def _polygon(valid, y_top, y_bottom, x_left, x_right) -> np.ndarray:
    if not valid:
        return np.zeros((0, 2), np.int32)
    ys = np.arange(y_top, y_bottom + 1)
    return np.concatenate([np.stack([x_left[ys], ys], 1),
                           np.stack([x_right[ys[::-1]], ys[::-1]], 1)]).astype(np.int32)


def _build(shape, n, W, H, lines, vp_y, road_valid, y_top, y_bottom, arrs, raw,
           lines_all=(), road_all=None) -> LaneResult:
    h, w = shape

    def to_in(v):
        return (v + 0.5) * n - 0.5

    def lane(k, state, votes, theta, rho, top, vy, vx):
        ys = np.arange(top, vy[0] + 1)
        # The vertices span exactly rows top..H-1 (y decreasing): linear interpolation.
        xs = np.interp(ys, np.asarray(vy[::-1], float), np.asarray(vx[::-1], float))
        pts = np.stack([to_in(xs), to_in(ys.astype(float))], axis=1)
        pts = pts[(pts[:, 0] >= 0) & (pts[:, 0] <= w - 1)]
        return Lane(SIDES[k] if k >= 0 else FURTHER, STATES.get(state, "found"), float(rho * n),
                    theta / QDEG, votes, pts)

    lanes = [lane(*t) for t in lines]
    x_left, x_right, lane_width = arrs
    poly = _polygon(road_valid, y_top, y_bottom, x_left, x_right)
    out = LaneResult(lanes, poly, road_valid, y_top, y_bottom, x_left, x_right, lane_width,
                     None if vp_y is None else to_in(float(vp_y)),
                     (to_in(float(W // 2)), to_in(float(H - 1))), n.bit_length() - 1 if n & (n - 1) == 0 else -1,
                     work_scale=n, raw=raw)
    out.lanes_all = [lane(*t) for t in lines_all]
    if road_all is not None:
        valid, top, bottom, (xl, xr, lw) = road_all
        out.road_all_valid, out.road_all_y_top, out.road_all_y_bottom = valid, top, bottom
        out.x_left_all, out.x_right_all, out.lane_width_all = xl, xr, lw
        out.road_all = _polygon(valid, top, bottom, xl, xr)
    return out


def _rescale(res: LaneResult, f: float, w0: int, h0: int) -> None:
    """Map a result computed on a frame downscaled by f back to the input frame."""
    def back(v):
        return (v + 0.5) / f - 0.5

    for ln in res.lanes + res.lanes_all:
        ln.points = back(ln.points)
        ln.rho = ln.rho / f
    res.origin = (back(res.origin[0]), back(res.origin[1]))
    if res.vanishing_row is not None:
        res.vanishing_row = back(res.vanishing_row)
    h1 = res.x_left.shape[0]
    rows = np.clip(np.floor((np.arange(h0) + 0.5) * f).astype(int), 0, h1 - 1)
    for sfx, vname, pname in (("", "road_valid", "road"), ("_all", "road_all_valid", "road_all")):
        names = [nm + sfx for nm in ("x_left", "x_right", "lane_width")]
        if getattr(res, names[0]).shape[0] != h1:
            continue
        for nm in names:
            a = getattr(res, nm)[rows].astype(float)
            v = np.clip(back(a), 0, w0 - 1) if not nm.startswith("lane_width") else a / f
            setattr(res, nm, np.round(v).astype(np.int32))
        top_name, bottom_name = f"{pname}_y_top", f"{pname}_y_bottom"
        if getattr(res, vname):
            inside = (rows >= getattr(res, top_name)) & (rows <= getattr(res, bottom_name))
            for nm in names:
                getattr(res, nm)[~inside] = 0
            ys = np.flatnonzero(inside)
            setattr(res, top_name, int(ys[0]))
            setattr(res, bottom_name, int(ys[-1]))
        setattr(res, pname, _polygon(getattr(res, vname), getattr(res, top_name),
                                     getattr(res, bottom_name), getattr(res, names[0]),
                                     getattr(res, names[1])))


def tusimple_lanes(res: LaneResult, h_samples, width: int, sides=("left", "right")) -> list:
    """The result's lanes of the given sides as TuSimple lane lists (x per h_sample, -2
    where the lane has no point)."""
    from .eval.lanes import sample_points
    if sides == "all":   # every line of lanes_all
        return [sample_points(ln.points, h_samples, width) for ln in res.lanes_all]
    return [sample_points(ln.points, h_samples, width) for ln in res.lanes if ln.side in sides]


__all__ = ["Lane", "LaneResult", "LaneDetector", "default_config", "tusimple_lanes", "SIDES", "FURTHER"]
