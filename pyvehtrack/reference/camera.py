"""Float reference for include/vehtrack/camera.h (IVVI paper sec. 4), never calling C.

Flat road, camera at height h looking down by the pitch angle theta (positive towards
the road), focal length fy, principal row cy. The ray through row v = row - cy makes
the angle alpha = theta + atan(v / fy) with the road, so the road point it meets is at

    Y = h / tan(alpha) = h (fy - v tan theta) / (v + fy tan theta)          (eq. 1)

(theta = 0 gives Stein et al.'s Y = h fy / v). A row error of +-delta px gives the
range [Y(v + delta), Y(v - delta)] (eq. 3); its half width is the distance error
that grows about as Y^2 delta / (fy h) (eq. 4-6), and it is the measurement std of
the distance filter, so near vehicles are trusted more than far ones.

The horizon (the vanishing point of the lane lines on a flat road) is at
v = -fy tan theta, so tan theta = (cy - vp_row) / fy: the pitch follows from the
lanes every frame.

TTC: from the filtered distance and its rate, d / -d'; and from the scale change of
the box over k frames, k dt / (w_t / w_{t-k} - 1) (for a constant closing speed both
are the exact time to contact of the rear face).

FCW: the NHTSA forward-collision-warning confirmation test asks for a warning by a
TTC of 2.1 s (lead stopped), 2.0 s (lead slower), 2.4 s (lead decelerating); the
state machine warns when the TTC stays under the class's threshold (plus a margin for
the confirmation frames and the filter's lag) for N frames while closing, holds while
that lasts (ending only after the condition failed release_frames frames in a row, so a
noisy TTC does not make it flicker), and does not warn again within a rearm time after
a warning ends.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter

from ..shared import (DIST_MAX_M, FCW_ONSET, FCW_SUPPRESSED, FCW_WARNING, LEAD_DECEL,  # noqa: F401
                      LEAD_SLOWER, LEAD_STOPPED, LEAD_UNKNOWN, PITCH_HELD, PITCH_MEASURED, PITCH_NOMINAL,
                      PITCH_REJECTED, BoxDistance, CameraParams, RangeOut, RangeParams)  # shared plain types



def row_distance(cam: CameraParams, tan_pitch: float, row: float) -> tuple[float, bool]:
    """Eq. 1: (distance in m, valid). At or above the horizon: (DIST_MAX_M, False);
    a ray behind the camera's foot point: (0, False)."""
    v = row - cam.cy
    num = cam.fy - v * tan_pitch
    den = v + cam.fy * tan_pitch
    if den <= 0:
        return DIST_MAX_M, False
    if num <= 0:
        return 0.0, False
    y = cam.height * num / den
    if y >= DIST_MAX_M:
        return DIST_MAX_M, False
    return y, True


def box_distance(cam: CameraParams, tan_pitch: float, box) -> BoxDistance:
    """Distances of an inclusive pixel box [l, t, r, b]: eq. 1 at the contact row
    b + bottom_offset, eq. 3 at +-delta, sigma their half spread, and the width
    cross-check fx * vehicle_width / (r - l + 1)."""
    l, _t, r, b = box
    row = b + cam.bottom_offset
    d, ok = row_distance(cam, tan_pitch, row)
    dn, _ = row_distance(cam, tan_pitch, row + cam.delta_px)
    df, ok_far = row_distance(cam, tan_pitch, row - cam.delta_px)
    dw = min(cam.fx * cam.vehicle_width / (r - l + 1), DIST_MAX_M)
    bottom_clipped = b >= cam.img_h - 1          # the contact row is below the frame
    side_clipped = l <= 0 or r >= cam.img_w - 1  # the width is not the vehicle's
    ok = ok and not bottom_clipped
    agrees = ok and abs(dw - d) * 1000 <= cam.width_tol_permille * d
    return BoxDistance(ok, ok_far, agrees, d, dn, df, (df - dn) / 2, dw, bottom_clipped, side_clipped)


class PitchEstimator:
    """Pitch from the lanes' vanishing row: smoothed, clamped to the calibration
    limits, outliers held (vt_pitch_update)."""

    def __init__(self, cam: CameraParams):
        self.cam = cam
        self.tan_pitch = cam.tan_pitch
        self.flag = PITCH_NOMINAL
        self.outliers = 0
        self.run_tan = 0.0
        self.measured = 0

    def update(self, vp_row: float | None) -> float:
        c = self.cam
        if vp_row is None:
            self.flag = PITCH_HELD if self.measured else PITCH_NOMINAL
            return self.tan_pitch
        m = (c.cy - vp_row) / c.fy
        if m < c.tan_pitch_min or m > c.tan_pitch_max:
            self.flag = PITCH_REJECTED
            return self.tan_pitch
        if abs(m - self.tan_pitch) > c.pitch_max_step:
            # only outliers that agree with the run's first one count (vt_pitch_update)
            if self.outliers > 0 and abs(m - self.run_tan) <= c.pitch_max_step:
                self.outliers += 1
            else:
                self.outliers = 1
                self.run_tan = m
            if self.outliers < c.pitch_reacquire:
                self.flag = PITCH_REJECTED
                return self.tan_pitch
            self.tan_pitch = m
        else:
            # the blend of vt_pitch_update: tan_pitch + (m - tan_pitch) a / 1000 (C rounds
            # the step to the Q16 LSB, half away from zero; the oracle keeps it exact)
            self.tan_pitch += (m - self.tan_pitch) * c.pitch_alpha_permille / 1000
        self.outliers = 0
        self.flag = PITCH_MEASURED
        self.measured += 1
        return self.tan_pitch


def vanishing_row(left: tuple[float, float] | None, right: tuple[float, float] | None,
                  work_h: int, scale: int) -> float | None:
    """Row (input px) where the ego lines x = xb + slope (y - (H-1)) (working px) meet,
    or None when one is missing or they do not meet above the bottom row."""
    if left is None or right is None:
        return None
    (xl, sl), (xr, sr) = left, right
    if sl == sr:
        return None
    dy = (xr - xl) / (sl - sr)
    if dy >= 0:
        return None
    yw = work_h - 1 + dy
    return (yw + 0.5) * scale - 0.5


@dataclass
class FcwState:
    below: int = 0
    above: int = 0
    warning: bool = False
    since_end: int = 2**31 - 1
    warnings: int = 0


def ttc_fuse(points, dist, w: int):
    """The fused TTC (c/camera.c's vt_ttc_fuse) in float: the weighted mean of the
    block-scale TTC `points` and the distance/rate TTC `dist` (s), w permille on dist;
    the known one if only one is; None if neither."""
    if points is None:
        return dist
    if dist is None:
        return points
    return (points * (1000 - w) + dist * w) / 1000


def fcw_threshold(p: RangeParams, lead_class: int) -> float:
    thr = {LEAD_STOPPED: p.ttc_stopped, LEAD_SLOWER: p.ttc_slower, LEAD_DECEL: p.ttc_decel}.get(
        lead_class, max(p.ttc_stopped, p.ttc_slower, p.ttc_decel))
    return thr + p.ttc_margin


def fcw_step(p: RangeParams, st: FcwState, ttc: float | None, closing: bool, lead_class: int) -> int:
    """One frame of the warning state machine; returns the FCW_* bits."""
    cond = ttc is not None and closing and ttc <= fcw_threshold(p, lead_class)
    st.below = st.below + 1 if cond else 0
    st.above = 0 if cond else st.above + 1
    bits = 0
    if st.warning:
        if st.above >= p.release_frames:
            st.warning = False
            st.since_end = 0
    else:
        if st.below >= p.confirm_frames:
            if st.since_end >= p.rearm_frames:
                st.warning = True
                st.warnings += 1
                bits |= FCW_ONSET
            else:
                bits |= FCW_SUPPRESSED
        if not st.warning:
            st.since_end = min(st.since_end + 1, 2**31 - 1)
    if st.warning:
        bits |= FCW_WARNING
    return bits


@dataclass
class _Slot:
    kf: KalmanFilter | None = None
    updates: int = 0
    widths: list = field(default_factory=list)
    rates: list = field(default_factory=list)
    fcw: FcwState = field(default_factory=FcwState)
    width_n: int = 0
    width_m: float = 0.0


class RangeTracker:
    """Per tracker id: a [d, d', d''] Kalman filter (filterpy, constant relative
    acceleration) with R = sigma^2 per measurement, both TTCs, the lead class and the FCW
    state machine."""

    def __init__(self, cam: CameraParams, params: RangeParams | None = None, max_tracks: int = 16):
        self.cam = cam
        self.p = params or RangeParams()
        self.max_tracks = int(max_tracks)
        self.slots: dict[int, _Slot] = {}

    def _start(self, d: float, sig: float) -> KalmanFilter:
        p = self.p
        dt = p.frame_dt
        kf = KalmanFilter(dim_x=3, dim_z=1)
        kf.F = np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        kf.H = np.array([[1.0, 0.0, 0.0]])
        # the relative acceleration changes by a white step of std jerk * dt per frame
        kf.Q = Q_discrete_white_noise(dim=3, dt=dt, var=(p.jerk_sigma * dt) ** 2)
        kf.P = np.diag([sig * sig, p.init_sigma_rate ** 2, p.init_sigma_accel ** 2])
        kf.R = np.array([[sig * sig]])
        kf.x = np.array([[d], [0.0], [0.0]])
        return kf

    def _in_path(self, box, d) -> bool:
        """The box at distance d overlaps the straight corridor |X - m| < path_half_width
        centred on the car (m = -lateral, the camera's mounting offset), X = (u - cx) d / fx
        over its columns [left, right + 1)."""
        half = self.p.path_half_width
        if half == 0:
            return True
        if d is None or d <= 0:
            return False
        c = self.cam
        m = -c.lateral
        return (box[0] - c.cx) * d / c.fx < m + half and (box[2] + 1 - c.cx) * d / c.fx > m - half

    def step(self, tracks, tan_pitch: float, ego_speed: float | None = None, *,
             ttc_points: dict | None = None, fuse_permille: int = 0) -> list[RangeOut]:
        """tracks: iterable of (id, [l, t, r, b]). ego_speed m/s or None (unknown).
        ttc_points: id -> block-scale TTC (s) or None (vt_range_step_fused): the warning then
        decides on ttc_fuse(it, the distance/rate TTC, fuse_permille)."""
        ttc_points = ttc_points or {}
        p, lag = self.p, self.p.scale_lag
        tracks = list(tracks)
        ids = [int(i) for i, _ in tracks]
        for gone in [i for i in self.slots if i not in ids]:
            del self.slots[gone]
        out = []
        for tid, box in tracks:
            if tid not in self.slots:
                if len(self.slots) >= self.max_tracks:
                    continue
                self.slots[tid] = _Slot()
            s = self.slots[tid]
            bd = box_distance(self.cam, tan_pitch, box)
            l, _t, r, _b = box
            w_px = r - l + 1
            have, d, sig, from_width = False, bd.distance, bd.sigma, False
            if bd.valid:
                have = True
                d = max(d - p.rear_offset, 0.0)
                if not bd.side_clipped:
                    # the vehicle's own width, d w / fx, as a running mean (window)
                    n = min(s.width_n + 1, p.width_window)
                    s.width_m += (d * w_px / self.cam.fx - s.width_m) / n
                    s.width_n += 1
            elif s.width_n >= p.width_min_frames and not bd.side_clipped:
                # contact row not seen: distance from the learnt width
                have, from_width = True, True
                d = self.cam.fx * s.width_m / w_px
                sig = d * 2 * self.cam.delta_px / w_px
            sig = max(sig, p.sigma_min)
            if s.updates > 0:
                s.kf.predict()
                if have:
                    s.kf.R = np.array([[sig * sig]])
                    s.kf.update(np.array([[d]]))
                    s.updates += 1
            elif have:
                s.kf = self._start(d, sig)
                s.updates = 1
            s.widths.append(float(r - l + 1))
            rate = float(s.kf.x[1, 0]) if s.updates > 0 else 0.0
            s.rates.append(rate)
            d_f = float(s.kf.x[0, 0]) if s.updates > 0 else None
            closing = s.updates > 0 and rate < -p.min_closing
            ttc_d = None
            if s.updates >= p.min_frames and rate < 0 and d_f > 0 and d_f / -rate <= p.ttc_max:
                ttc_d = d_f / -rate
            ttc_s = None
            if len(s.widths) > lag:
                w_now, w_old = s.widths[-1], s.widths[-1 - lag]
                if w_now > w_old > 0:
                    v = lag * p.frame_dt * w_old / (w_now - w_old)
                    ttc_s = v if v <= p.ttc_max else None
            accel = float(s.kf.x[2, 0]) if s.updates > 0 else None
            cls = LEAD_UNKNOWN
            # a class only once the rate is known to within stopped_speed (c/camera.c)
            if ego_speed is not None and ego_speed >= 0 and s.updates > 0 and \
                    float(s.kf.P[1, 1]) <= p.stopped_speed ** 2:
                if ego_speed + rate < p.stopped_speed:
                    cls = LEAD_STOPPED
                elif s.updates > lag and accel < -p.decel_thresh:
                    cls = LEAD_DECEL
                else:
                    cls = LEAD_SLOWER
            in_path = self._in_path(box, d_f)
            # vt_range_step: a warning rests on a distance measured this frame
            ttc_w = ttc_fuse(ttc_points.get(tid), ttc_d, fuse_permille)
            bits = fcw_step(p, s.fcw, ttc_w if in_path and have else None, closing, cls)
            out.append(RangeOut(tid, d if have else None, sig, bd.dist_width,
                                bd.width_agrees, d_f, rate if s.updates > 0 else None, ttc_d, ttc_s,
                                closing, cls, bits, from_width, accel, in_path))
        return out
