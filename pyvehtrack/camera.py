"""Camera files, distance, time to collision and forward-collision warning.

The camera file (JSON) is what every command takes (`--camera CAMERA.json`):

    {"fx": 721.5, "fy": 721.5, "cx": 609.6, "cy": 172.9, "height_m": 1.65,
     "pitch_deg": 0.0,                       optional, positive = looking down
     "dist": [k1, k2, p1, p2, k3],           optional, OpenCV order
     "image_size": [1242, 375],              optional, written by `pyvehtrack calibrate`
     "hood_row": 668,                        optional (needs image_size): the hood's highest row
     "lateral_m": 0.0}                       optional: the camera's mounting offset right of the
                                             car's centre line (the warning's ego corridor)

in pixels of the input frame. `height_m` (the camera's height above the road) cannot
come from a chessboard: `pyvehtrack calibrate` takes it as --height-m or leaves it
out, and a file without it is refused where a distance is needed.

    cam = Camera.load("camera.json")
    rng = RangeEstimator(cam, (w, h), fps=10)          # engine="c" (default) or "reference"
    rng.update_pitch(vp_row)                            # per frame, from the lanes (or None)
    for r in rng.step(tracks, ego_speed=None):          # tracks from pyvehtrack.tracker
        r.id, r.distance, r.dist_filt, r.rate, r.ttc_dist, r.ttc_scale, r.warning
"""
from __future__ import annotations

import dataclasses
import functools
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import _check
from .shared import BoxDistance, CameraParams, RangeOut, RangeParams

Q16 = 1 << 16
PITCH_LIMIT_DEG = 3.0   # braking and load move a car's pitch by a degree or two, not more
__all__ = ["Camera", "CameraFileError", "RangeEstimator", "camera_params", "lane_vanishing_row",
           "params_to_c", "range_to_c", "params_from_c", "range_from_c", "q16", "fuse_ttc"]


# The camera file's keys, in the order of Camera's fields.
_FILE_KEYS = ("fx", "fy", "cx", "cy", "height_m", "pitch_deg", "dist", "image_size", "hood_row", "lateral_m")


class CameraFileError(ValueError):
    """A camera file that cannot be read or is not valid."""


def q16(v: float, name: str) -> int:
    """Round to Q16 (nearest); ValueError naming `name` for non-finite or out-of-range
    values (never clipped)."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {type(v).__name__}")
    if not math.isfinite(float(v)):
        raise ValueError(f"{name}={v} is not finite")
    q = int(round(float(v) * Q16))
    if not -(2**31) <= q < 2**31:
        raise ValueError(f"{name}={v} is outside the Q16 range (+-32768)")
    return q


def _num(d: dict, key: str, *, required: bool, positive: bool = False, lo=None, hi=None):
    if key not in d or d[key] is None:
        if required:
            raise CameraFileError(f"camera: '{key}' is missing")
        return None
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise CameraFileError(f"camera: '{key}' must be a number, got {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise CameraFileError(f"camera: '{key}' must be finite, got {v}")
    if positive and not v > 0:
        raise CameraFileError(f"camera: '{key}' must be > 0, got {v}")
    if lo is not None and not lo <= v <= hi:
        raise CameraFileError(f"camera: '{key}'={v} is outside [{lo}, {hi}]")
    return v


@dataclass(frozen=True)
class Camera:
    """Intrinsics (px of the input frame), height above the road (m), nominal pitch
    (degrees, positive = looking down), OpenCV distortion coefficients, the image size the
    pixels refer to and the first row of the ego car's hood in that image (hood_row, the
    hood's highest row; image_size's height when no hood is in view): with it the
    ego-lane detector's road ends above the hood, whose edge against the road looks
    like a vehicle's shadow. lateral_m: the camera's mounting offset right of the car's
    centre line, metres; the collision warning's ego corridor is centred on the car."""
    fx: float
    fy: float
    cx: float
    cy: float
    height_m: float | None = None
    pitch_deg: float | None = None
    dist: tuple | None = None
    image_size: tuple | None = None
    hood_row: int | None = None
    lateral_m: float | None = None

    def __post_init__(self):
        v = Camera.from_dict(self.to_dict())  # one validation path for files and code
        for f in _FILE_KEYS:
            object.__setattr__(self, f, getattr(v, f))

    # -- file I/O ---------------------------------------------------------------------
    def to_dict(self) -> dict:
        d = {"fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy, "height_m": self.height_m}
        if self.pitch_deg is not None:
            d["pitch_deg"] = self.pitch_deg
        if self.dist is not None:
            d["dist"] = list(self.dist)
        if self.image_size is not None:
            d["image_size"] = list(self.image_size)
        if self.hood_row is not None:
            d["hood_row"] = self.hood_row
        if self.lateral_m is not None:
            d["lateral_m"] = self.lateral_m
        return d

    @staticmethod
    def from_dict(d) -> "Camera":
        if not isinstance(d, dict):
            raise CameraFileError(f"camera: expected a JSON object, got {type(d).__name__}")
        known = set(_FILE_KEYS)
        unknown = sorted(set(d) - known)
        if unknown:
            raise CameraFileError(f"camera: unknown key(s) {unknown} (known: {sorted(known)})")
        fx = _num(d, "fx", required=True, lo=1.0, hi=16384.0)
        fy = _num(d, "fy", required=True, lo=1.0, hi=16384.0)
        cx = _num(d, "cx", required=True, lo=-32768.0, hi=32767.0)
        cy = _num(d, "cy", required=True, lo=-32768.0, hi=32767.0)
        h = _num(d, "height_m", required=False, lo=1e-3, hi=100.0)
        pitch = _num(d, "pitch_deg", required=False, lo=-45.0, hi=45.0)
        # vt_camera_cfg.lateral's range: a camera more than 5 m off the car is a mistake
        lateral = _num(d, "lateral_m", required=False, lo=-5.0, hi=5.0)
        dist = d.get("dist")
        if dist is not None:
            if not isinstance(dist, (list, tuple)) or len(dist) not in (4, 5, 8, 12, 14) or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                    for v in dist):
                raise CameraFileError("camera: 'dist' must be 4, 5, 8, 12 or 14 finite numbers "
                                      f"(OpenCV order k1 k2 p1 p2 [k3 ...]), got {dist!r}")
            dist = tuple(float(v) for v in dist)
        size = d.get("image_size")
        if size is not None:
            if (not isinstance(size, (list, tuple)) or len(size) != 2
                    or not all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 32767
                               for v in size)):
                raise CameraFileError(f"camera: 'image_size' must be [width, height] in pixels, got {size!r}")
            size = (int(size[0]), int(size[1]))
        hood = d.get("hood_row")
        if hood is not None:
            if size is None:
                raise CameraFileError("camera: 'hood_row' needs 'image_size' (the row is in pixels of that image)")
            # the road camera holds the hood as a fraction of the height, 0.05 .. 2
            lo = math.ceil(0.05 * size[1])
            if isinstance(hood, bool) or not isinstance(hood, int) or not lo <= hood <= size[1]:
                raise CameraFileError(f"camera: 'hood_row' must be a whole row {lo}..{size[1]} (the image "
                                      f"height: no hood in view), got {hood!r}")
        return Camera.__new__(Camera)._init(fx, fy, cx, cy, h, pitch, dist, size, hood, lateral)

    def _init(self, *vals) -> "Camera":
        for f, v in zip(_FILE_KEYS, vals, strict=True):
            object.__setattr__(self, f, v)
        return self

    @staticmethod
    def load(path) -> "Camera":
        p = Path(path)
        try:
            text = p.read_text()
        except OSError as e:
            raise CameraFileError(f"camera file {p}: {e.strerror or e}") from None
        try:
            d = json.loads(text)
        except json.JSONDecodeError as e:
            raise CameraFileError(f"camera file {p}: not JSON ({e.msg} at line {e.lineno})") from None
        try:
            return Camera.from_dict(d)
        except CameraFileError as e:
            raise CameraFileError(f"camera file {p}: {str(e).removeprefix('camera: ')}") from None

    def save(self, path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=2) + "\n")

    # -- use ----------------------------------------------------------------------------
    def undistort_box(self, box) -> list:
        """The box with its corners moved as OpenCV's undistortion moves them (no-op without
        "dist"): distances assume a pinhole, so the rows and widths must be undistorted ones."""
        if self.dist is None:
            return [int(v) for v in box]
        import cv2
        l, t, r, b = (float(v) for v in box)
        k = np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1]], np.float64)
        pts = np.array([[[l, b]], [[r, b]], [[(l + r) / 2, t]], [[(l + r) / 2, b]]], np.float64)
        u = cv2.undistortPoints(pts, k, np.asarray(self.dist, np.float64), P=k).reshape(-1, 2)
        return [int(round(min(u[0, 0], u[1, 0]))), int(round(u[2, 1])), int(round(max(u[0, 0], u[1, 0]))),
                int(round(u[3, 1]))]

    def road_camera(self):
        """The whole-road detector's flat-road camera (pyvehtrack.fullroad.Camera: where
        its windows go and how wide a vehicle is at each row) from this file: the horizon
        row cy - fy tan(pitch) and fx as fractions of image_size, the camera height; the
        hood row hood_row / height (hood_known: the ego-lane detector's road ends above
        it too), without hood_row the default fraction. None without image_size or
        height_m (the fractions and the distances need them)."""
        if self.image_size is None or self.height_m is None:
            return None
        from .fullroad import Camera as RoadCamera  # noqa: PLC0415  (fullroad loads the C core)
        w, h = self.image_size
        horizon = self.cy - self.fy * math.tan(math.radians(self.pitch_deg or 0.0))
        hood = {} if self.hood_row is None else {"hood_frac": self.hood_row / h, "hood_known": True}
        return RoadCamera(horizon_frac=min(max(horizon / h, -1.0), 1.0), fx_per_width=self.fx / w,
                          height_m=self.height_m, **hood)

    def check_frame(self, w: int, h: int) -> None:
        if self.image_size is not None and tuple(self.image_size) != (int(w), int(h)):
            raise ValueError(f"camera: calibrated for {self.image_size[0]}x{self.image_size[1]} frames, "
                             f"got {w}x{h} (the camera file is in pixels of the input frame)")

    def params(self, img_w: int, img_h: int, **overrides) -> CameraParams:
        """The stage's parameters for frames of img_w x img_h (quantised to what the C
        core holds). ValueError without height_m."""
        if self.height_m is None:
            raise ValueError("camera: 'height_m' (camera height above the road) is required for "
                             "distances; a chessboard calibration cannot give it, add it to the file")
        self.check_frame(img_w, img_h)
        pitch = self.pitch_deg or 0.0
        # the per-frame pitch may wander PITCH_LIMIT_DEG around the calibrated one
        p = CameraParams(int(img_w), int(img_h), self.fx, self.fy, self.cx, self.cy, self.height_m,
                              tan_pitch=math.tan(math.radians(pitch)),
                              tan_pitch_min=math.tan(math.radians(pitch - PITCH_LIMIT_DEG)),
                              tan_pitch_max=math.tan(math.radians(pitch + PITCH_LIMIT_DEG)),
                              lateral=self.lateral_m or 0.0)
        # the names of before issue 10 (pitch_alpha_q8, width_tol_percent), converted when
        # exact, with a DeprecationWarning; dataclasses.replace would see old and new together
        from .shared import CAMERA_RENAMED, take_renamed  # noqa: PLC0415
        p = dataclasses.replace(p, **take_renamed("camera", dict(overrides), CAMERA_RENAMED))
        return params_from_c(params_to_c(p))


def lane_vanishing_row(lanes) -> float | None:
    """Input row where the two ego lane lines meet, from a pyvehtrack.lane.LaneResult: on the
    C engine the refined lines' intersection (vt_lane_vanishing_row, sub-pixel); otherwise the
    result's own vanishing_row (None when the lanes do not give one)."""
    from . import _native
    raw = getattr(lanes, "raw", None)
    f = float(lanes.input_scale)
    if raw is not None and hasattr(raw, "H") and hasattr(raw, "lines"):
        # the float oracle's LaneFrame: the same intersection in floats
        ln = raw.lines
        left, right = (None if k >= len(ln) or ln[k] is None else (ln[k].xb, ln[k].slope) for k in (1, 2))
        from .reference import camera as rcam   # the oracle's lines: the oracle's arithmetic
        row = rcam.vanishing_row(left, right, int(raw.H), int(raw.scale))
        return None if row is None else (row + 0.5) / f - 0.5
    if raw is None or not hasattr(raw, "scale") or not hasattr(raw, "lines"):
        return lanes.vanishing_row
    k = int(raw.scale)
    h_seen = int(raw.h) * k
    # the frame the lane stage saw: its height is h k plus the rows the downscale dropped
    h_full = int(round(len(lanes.x_left) * f))
    if h_full // k == int(raw.h):
        h_seen = h_full
    row, ok = _native.lane_vanishing_row(raw, h_seen)
    if not ok:
        return None
    return ((row / Q16) + 0.5) / f - 0.5


def camera_params(cam: Camera, img_w: int, img_h: int, **kw) -> CameraParams:
    return cam.params(img_w, img_h, **kw)


_CAM_Q16 = ("fx", "fy", "cx", "cy", "height", "tan_pitch", "tan_pitch_min", "tan_pitch_max",
            "pitch_max_step", "delta_px", "bottom_offset", "vehicle_width", "lateral")
_CAM_INT = ("img_w", "img_h", "pitch_alpha_permille", "pitch_reacquire", "width_tol_permille")
_RNG_Q16 = ("frame_dt", "jerk_sigma", "init_sigma_rate", "init_sigma_accel", "sigma_min", "ttc_max",
            "ttc_stopped", "ttc_slower", "ttc_decel", "ttc_margin", "min_closing", "stopped_speed",
            "decel_thresh", "rear_offset", "path_half_width")
_RNG_INT = ("min_frames", "scale_lag", "confirm_frames", "rearm_frames", "release_frames",
            "width_min_frames", "width_window")


def _to_c(ctype: str, p, q16_fields, int_fields, check):
    from . import _native
    c = _native.ffi.new(ctype + " *")
    for f in q16_fields:
        setattr(c, f, q16(getattr(p, f), f"{type(p).__name__}.{f}"))
    for f in int_fields:
        v = getattr(p, f)
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not -(2**31) <= v < 2**31:
            raise ValueError(f"{type(p).__name__}.{f}={v!r} must be an int32")
        setattr(c, f, int(v))
    check(c)
    return c


def params_to_c(p: CameraParams):
    """vt_camera_cfg for p (Q16 rounded to nearest); VtError if a field is out of range."""
    from . import _native
    return _to_c("vt_camera_cfg", p, _CAM_Q16, _CAM_INT, _native.camera_cfg_check)


def range_to_c(p: RangeParams):
    from . import _native
    return _to_c("vt_range_cfg", p, _RNG_Q16, _RNG_INT, _native.range_cfg_check)


def params_from_c(c) -> CameraParams:
    return CameraParams(**{f: getattr(c, f) / Q16 for f in _CAM_Q16},
                             **{f: int(getattr(c, f)) for f in _CAM_INT})


def range_from_c(c) -> RangeParams:
    return RangeParams(**{f: getattr(c, f) / Q16 for f in _RNG_Q16},
                            **{f: int(getattr(c, f)) for f in _RNG_INT})


class RangeEstimator:
    """Distance, range rate, both TTCs and the FCW state per track, on the C core
    (engine="c") or the float reference. `params` overrides fields of
    reference.camera.RangeParams (frame_dt comes from fps).

    bottom_height (m, default 0): the height above the road of what a box's bottom edge
    shows. Eq. 1 assumes the road contact (0); a detector whose box ends at the lower edge
    of the rear bumper sees a line bottom_height above the road, and the same eq. 1 with
    the camera height minus bottom_height gives its distance (the plane through that line).
    On KITTI the tracker's box ends there: 0.37 m fitted on frames 0-38
    (tools/eval_kitti_range.py --model height). rear_offset (m, subtracted from the
    distance) is the other, empirical correction; the two can be combined."""

    def __init__(self, camera: Camera, image_size, fps: float, engine: str = "c",
                 camera_overrides: dict | None = None, bottom_height: float = 0.0, **params):
        if engine not in ("c", "reference"):
            raise ValueError(f"engine must be 'c' or 'reference', got {engine!r}")
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a pyvehtrack.camera.Camera, got {type(camera).__name__}")
        try:
            w, h = (int(v) for v in image_size)
        except (TypeError, ValueError):
            raise ValueError(f"image_size must be (width, height), got {image_size!r}") from None
        if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not math.isfinite(fps) or fps < 1:
            raise ValueError(f"fps must be a number >= 1, got {fps!r}")
        if (isinstance(bottom_height, bool) or not isinstance(bottom_height, (int, float))
                or not math.isfinite(bottom_height)
                or not (bottom_height == 0 or 0 < bottom_height < (camera.height_m or 0))):
            raise ValueError(f"bottom_height must be in [0, camera height {camera.height_m}) m, "
                             f"got {bottom_height!r}")
        self.engine = engine
        self.size = (w, h)
        over = dict(camera_overrides or {})
        if bottom_height:
            over["height"] = over.get("height", camera.height_m) - float(bottom_height)
        self.bottom_height = float(bottom_height)
        self.cam = camera.params(w, h, **over)
        rp = dataclasses.replace(RangeParams(frame_dt=1.0 / float(fps)), **params)
        from . import _native
        self._n = _native
        self._ccam = params_to_c(self.cam)
        self._crng = range_to_c(rp)
        self.params = range_from_c(self._crng)
        if engine == "c":
            self._pitch = _native.pitch_new(self._ccam)
            self._st = _native.range_new()
        else:
            from .reference import camera as rcam   # the reference engine
            self._pitch_ref = rcam.PitchEstimator(self.cam)
            self._ref = rcam.RangeTracker(self.cam, self.params, int(_native.lib.VT_MAX_TRACKS))

    @property
    def tan_pitch(self) -> float:
        return self._pitch.tan_pitch / Q16 if self.engine == "c" else self._pitch_ref.tan_pitch

    @property
    def pitch_deg(self) -> float:
        return math.degrees(math.atan(self.tan_pitch))

    @property
    def pitch_flag(self) -> int:
        return int(self._pitch.flag) if self.engine == "c" else self._pitch_ref.flag

    def update_pitch(self, vp_row: float | None) -> float:
        """Feed this frame's vanishing row (input px) or None; returns tan(pitch)."""
        if vp_row is not None and (isinstance(vp_row, bool) or not isinstance(vp_row, (int, float, np.number))
                                   or not math.isfinite(float(vp_row))):
            raise ValueError(f"vp_row must be a finite number or None, got {vp_row!r}")
        if self.engine == "c":
            if vp_row is None:
                self._n.pitch_update(self._ccam, self._pitch, 0, 0)
            else:
                self._n.pitch_update(self._ccam, self._pitch, 1, q16(vp_row, "vp_row"))
        else:
            self._pitch_ref.update(None if vp_row is None else float(vp_row))
        return self.tan_pitch

    def box_distance(self, box) -> BoxDistance:
        """One box's distances with the current pitch, no filter (for single pictures)."""
        box = [int(v) for v in box]
        if self.engine == "reference":
            from .reference import camera as rcam
            return rcam.box_distance(self.cam, self._pitch_ref.tan_pitch, box)
        d = self._n.camera_box_distance(self._ccam, int(self._pitch.tan_pitch), box)
        L = self._n.lib
        return BoxDistance(bool(d.flags & L.VT_DIST_VALID), bool(d.flags & L.VT_DIST_FAR_VALID),
                                bool(d.flags & L.VT_DIST_WIDTH_AGREES), d.distance / Q16,
                                d.dist_near / Q16, d.dist_far / Q16, d.sigma / Q16, d.dist_width / Q16,
                                bool(d.flags & L.VT_DIST_BOTTOM_CLIPPED),
                                bool(d.flags & L.VT_DIST_SIDE_CLIPPED))

    def step(self, tracks, ego_speed: float | None = None, ttc_points: dict | None = None,
             fuse_permille: int | None = None) -> list[RangeOut]:
        """tracks: pyvehtrack.tracker.Track objects (or (id, box) pairs), boxes in input px.
        ttc_points: {id: block-scale TTC in s, or None} (Track.ttc_points, ScaleTtc's ttc):
        the warning then decides on the fused TTC (fuse_ttc; fuse_permille on the
        distance/rate TTC, default vt_pipeline_cfg's 300), as the pipeline's does with
        vt_pipeline_cfg.fcw_fused; without it, on the distance/rate TTC (the default)."""
        pairs = []
        for t in tracks:
            tid, box = (t.id, t.box) if hasattr(t, "box") else t
            box = [int(v) for v in box]
            if len(box) != 4 or box[2] < box[0] or box[3] < box[1]:
                raise ValueError(f"track {tid}: box {box} is not [left, top, right, bottom]")
            pairs.append((int(tid), box))
        if ego_speed is not None and (not math.isfinite(float(ego_speed)) or ego_speed < 0):
            raise ValueError(f"ego_speed must be >= 0 m/s or None, got {ego_speed}")
        w = _fuse_weight(fuse_permille)
        pts = None
        if ttc_points is not None:
            if not isinstance(ttc_points, dict):
                raise TypeError(f"ttc_points must be a dict id -> seconds or None, got "
                                f"{type(ttc_points).__name__}")
            pts = {}
            for tid, v in ttc_points.items():
                if isinstance(tid, bool) or not isinstance(tid, (int, np.integer)):
                    raise TypeError(f"ttc_points: keys are track ids (int), got {tid!r}")
                if v is not None:
                    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                            or not math.isfinite(float(v)) or v < 0:
                        raise ValueError(f"ttc_points[{tid}] must be a TTC >= 0 s or None, got {v!r}")
                    pts[int(tid)] = float(v)
        if self.engine == "reference":
            return self._ref.step(pairs, self._pitch_ref.tan_pitch, ego_speed, ttc_points=pts,
                                  fuse_permille=w)
        arr = np.zeros(len(pairs), self._n.TRACK_OUT_DTYPE)
        for k, (tid, b) in enumerate(pairs):
            arr[k] = (tid, 2, b[0], b[1], b[2], b[3], 0, 0)
        ego = -Q16 if ego_speed is None else q16(ego_speed, "ego_speed")
        qp = None if pts is None else [q16(pts[tid], f"ttc_points[{tid}]") if tid in pts else -1
                                        for tid, _b in pairs]
        rows = self._n.range_step(self._st, self._crng, self._ccam, int(self._pitch.tan_pitch), ego, arr,
                                  qp, w)
        return [_range_out(r, self._n.lib) for r in rows]


@functools.cache
def _default_fuse_weight() -> int:
    """vt_pipeline_cfg's ttc_fuse_permille, read from the core once (not per frame)."""
    from . import _native  # noqa: PLC0415
    return int(_native.pipeline_cfg_default().ttc_fuse_permille)


def _fuse_weight(weight_permille) -> int:
    """The fusion weight on the distance/rate TTC: vt_pipeline_cfg's default, or checked."""
    return _default_fuse_weight() if weight_permille is None else \
        _check.integer(weight_permille, "weight_permille", lo=0, hi=1000)


def fuse_ttc(points: float | None, dist: float | None, weight_permille: int | None = None):
    """The two TTCs in one, as the pipeline's vt_pipe_track.ttc_fused_q16 (in float): the
    weighted mean of the block-scale TTC `points` and the distance/rate TTC `dist` (s), with
    weight_permille (default: vt_pipeline_cfg's, 300) on `dist`; the known one if only one
    is; None if neither. The two err in opposite directions on KITTI (the block scale lags,
    the filtered distance's rate overshoots)."""
    from .reference.camera import ttc_fuse  # noqa: PLC0415  (the one float rule)
    return ttc_fuse(points, dist, _fuse_weight(weight_permille))


def _range_out(r, lib) -> RangeOut:
    f = int(r["flags"])
    g = lambda k: float(r[k]) / Q16  # noqa: E731
    return RangeOut(
        id=int(r["id"]),
        distance=g("distance") if f & lib.VT_RANGE_DIST_VALID else None,
        sigma=g("sigma"), dist_width=g("dist_width"),
        width_agrees=bool(f & lib.VT_RANGE_WIDTH_AGREES),
        dist_filt=g("dist_filt") if f & lib.VT_RANGE_FILT_VALID else None,
        rate=g("rate") if f & lib.VT_RANGE_FILT_VALID else None,
        accel=g("accel") if f & lib.VT_RANGE_FILT_VALID else None,
        ttc_dist=g("ttc_dist") if f & lib.VT_RANGE_TTC_DIST_VALID else None,
        ttc_scale=g("ttc_scale") if f & lib.VT_RANGE_TTC_SCALE_VALID else None,
        closing=bool(f & lib.VT_RANGE_CLOSING), lead_class=int(r["lead_class"]), fcw=int(r["fcw"]),
        from_width=bool(f & lib.VT_RANGE_FROM_WIDTH), in_path=bool(f & lib.VT_RANGE_IN_PATH))


class ScaleTtc:
    """Time to collision from the scale change of SAD-matched blocks inside each track's
    box over `lag` frames (c/ttc_scale.c, or its float twin reference/ttc_scale.py with
    engine="reference"). `params` overrides fields of reference.ttc_scale.TtcScaleParams
    (frame_dt comes from fps). step() takes the frame (grey uint8, or BGR uint8) and the
    tracks of that frame."""

    def __init__(self, fps: float, engine: str = "c", **params):
        from . import _native
        from .reference import ttc_scale as rts
        if engine not in ("c", "reference"):
            raise ValueError(f"engine must be 'c' or 'reference', got {engine!r}")
        if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not math.isfinite(fps) or fps < 1:
            raise ValueError(f"fps must be a number >= 1, got {fps!r}")
        known = {f.name for f in dataclasses.fields(rts.TtcScaleParams)}
        for k in params:
            if k not in known:
                raise TypeError(f"ScaleTtc: unknown parameter {k!r} (known: {sorted(known)})")
        p = dataclasses.replace(rts.TtcScaleParams(frame_dt=1.0 / float(fps)), **params)
        self._n = _native
        self._c = _native.ffi.new("vt_ttc_cfg *")
        for f in ("block", "grid", "margin_permille", "radius", "min_texture", "max_sad", "lag",
                  "min_pair_px", "min_pairs", "anchor_radius", "evict_margin_px",
                  "prior_gate_permille", "min_lag", "min_match_permille"):
            v = getattr(p, f)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not -(2**31) <= v < 2**31:
                raise ValueError(f"TtcScaleParams.{f}={v!r} must be an int32")
            setattr(self._c, f, int(v))
        self._c.frame_dt = q16(p.frame_dt, "TtcScaleParams.frame_dt")
        self._c.ttc_max = q16(p.ttc_max, "TtcScaleParams.ttc_max")
        try:
            _native.ttc_cfg_check(self._c)
        except _native.VtError:
            raise ValueError(f"ScaleTtc: a parameter is out of range: {p} (see include/vehtrack/"
                             f"ttc_scale.h for the ranges)") from None
        # the oracle runs on exactly the C core's numbers
        self.params = dataclasses.replace(p, frame_dt=self._c.frame_dt / Q16, ttc_max=self._c.ttc_max / Q16)
        self.engine = engine
        if engine == "c":
            self._st = _native.ttc_new()
        else:
            self._ref = rts.TtcScaleTracker(self.params, int(_native.lib.VT_TTC_TRACKS),
                                            int(_native.lib.VT_TTC_HIST))

    def step(self, frame, tracks):
        """frame: (h, w) grey or (h, w, 3) BGR uint8 array; tracks: Track objects or (id, box)
        pairs, boxes [left, top, right, bottom] inclusive px. Returns one
        reference.ttc_scale.TtcScaleOut per measured track (ttc/scale None when unknown)."""
        from .reference.ttc_scale import TtcScaleOut
        if not isinstance(frame, np.ndarray):
            raise TypeError(f"frame must be a numpy.ndarray, got {type(frame).__name__}")
        if frame.dtype != np.uint8:
            raise TypeError(f"frame must be uint8, got {frame.dtype}")
        if frame.ndim == 3 and frame.shape[2] == 3:
            import cv2
            frame = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        elif frame.ndim != 2:
            raise ValueError(f"frame must be (h, w) grey or (h, w, 3) BGR, got shape {frame.shape}")
        if frame.shape[0] < 1 or frame.shape[1] < 1:
            raise ValueError(f"frame is empty: shape {frame.shape}")
        pairs, seen = [], set()
        for t in tracks:
            tid, box = (t.id, t.box) if hasattr(t, "box") else t
            box = [int(v) for v in box]
            if len(box) != 4 or box[2] < box[0] or box[3] < box[1]:
                raise ValueError(f"track {tid}: box {box} is not [left, top, right, bottom]")
            if int(tid) <= 0 or int(tid) in seen:
                raise ValueError(f"track id {tid} must be a positive, unique int")
            seen.add(int(tid))
            pairs.append((int(tid), box))
        if self.engine == "reference":
            return self._ref.step(np.ascontiguousarray(frame), pairs)
        arr = np.zeros(len(pairs), self._n.TRACK_OUT_DTYPE)
        for k, (tid, b) in enumerate(pairs):
            arr[k] = (tid, 2, b[0], b[1], b[2], b[3], 0, 0)
        rows = self._n.ttc_step(self._st, self._c, np.ascontiguousarray(frame), arr)
        L = self._n.lib
        return [TtcScaleOut(int(r["id"]),
                            float(r["scale"]) / Q16 if r["flags"] & L.VT_TTC_SCALE_VALID else None,
                            float(r["ttc"]) / Q16 if r["flags"] & L.VT_TTC_VALID else None,
                            int(r["blocks"]), int(r["matched"]), int(r["pairs"]), int(r["lag"]))
                for r in rows]
