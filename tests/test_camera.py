"""Flat-road geometry, pitch, range filter, TTC and FCW (c/camera.c) against the float
oracle (pyvehtrack/reference/camera.py), bad inputs, and the camera file.

Tolerances, from the arithmetic of camera.h:
- Row distance (eq. 1): C forms v tp and fy tp rounded half up to Q16 (each <= 2^-17 px
  off), so numerator and denominator are each within 2^-17 px of exact; the quotient is
  rounded once (half an LSB, 2^-17 m). Relative error <= 2^-17 (1/num + 1/den) px, so
  |C - ref| <= Y 2^-17 (1/num + 1/den) + 2^-17 m, which the test checks with a factor 2 for
  the quantised inputs' own float rounding (num, den in px).
- Box distance: the same for the three rows; sigma adds one halving (1 LSB); the width
  distance is one rounded division (1 LSB).
- Pitch: m = (cy - vp) / fy is rounded once (<= 0.5 LSB), each smoothing step rounds once
  (0.5 LSB); the smoothing contracts old errors by (1 - alpha/256) per step, so the
  estimate stays within (0.5 + 0.5) / (alpha/256) LSB (<= 4 LSB at alpha = 64) of the
  oracle's, checked with alpha drawn in [32, 256] (<= 8 LSB). Flags are compared where
  no decision is within 16 LSB of its threshold (elsewhere they must be equal).
- FCW: integer state machine on Q16 inputs, compared bit for bit (the oracle gets the
  same Q16 values as floats, exact).
- Range filter: the measured distance as above (<= 1e-4 relative); the [d, rate, accel]
  Kalman filter in Q16 / Q31.32 rounds x + K y once per update (0.5 LSB) and Q is built
  through Q24 intermediates (relative 2^-24 / (j dt^3) <= 1e-3 for the drawn j, dt, which
  moves the gain by less than that); the filter is a contraction, so a rounding is remembered
  for ~1/K frames (K >= ~0.05 here): <= ~20 LSB of distance, plus the measured distances'
  own 1e-4 relative difference filtered the same way. Tolerance 1e-3 m (65 LSB) on the
  distance and 5e-3 m/s on the rate (the rate gain is ~K/dt, dt >= 0.033 s, so a
  distance difference of 1e-4 m moves it by ~3e-3 m/s at most). Measured over 1920
  filtered frames: <= 4.8e-5 m (3.1 LSB) and 3.1e-4 m/s.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from pyvehtrack import _native
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.camera import (Camera, CameraFileError, RangeEstimator, params_from_c, params_to_c,
                               range_from_c, range_to_c)
from pyvehtrack.reference import camera as rc

Q = 65536.0
LSB = 1.0 / Q


def cam_params(w=640, h=480, fx=700.0, fy=700.0, cx=319.5, cy=240.0, height=1.3, tp=0.0, **kw):
    p = rc.CameraParams(w, h, fx, fy, cx, cy, height, tan_pitch=tp, **kw)
    c = params_to_c(p)
    return params_from_c(c), c


cams = st.builds(
    lambda w, h, f, fr, cxr, cyr, hh, tp: cam_params(w, h, f, f * fr, w * cxr, h * cyr, hh, tp),
    st.integers(64, 1920), st.integers(48, 1080), st.floats(100, 4000), st.floats(0.9, 1.1),
    st.floats(0.3, 0.7), st.floats(0.3, 0.7), st.floats(0.5, 5.0), st.floats(-0.05, 0.05))


def dist_tol(p, tp, row, y):
    v = row - p.cy
    num = p.fy - v * tp
    den = v + p.fy * tp
    return 2 * (y * 2 ** -17 * (1 / abs(num) + 1 / abs(den))) + 2 * LSB


@given(cams, st.floats(-0.2, 1.2), st.floats(-0.05, 0.05))
def test_row_distance_matches_oracle(pc, row_frac, tp):
    p, c = pc
    tpq = round(tp * Q)
    tp = tpq / Q
    rowq = round(row_frac * p.img_h * Q)
    row = rowq / Q
    dc, ok = _native.camera_row_distance(c, tpq, rowq)
    dr, okr = rc.row_distance(p, tp, row)
    den = (row - p.cy) + p.fy * tp
    assume(abs(den) > 0.01)  # not on the horizon itself (rounding decides the side there)
    assert bool(ok) == okr or abs(dr - rc.DIST_MAX_M) < 1.0
    if okr and ok:
        assert abs(dc / Q - dr) <= dist_tol(p, tp, row, dr), (dc / Q, dr)


@given(cams, st.integers(0, 2000), st.integers(1, 600), st.integers(0, 1200), st.integers(1, 400),
       st.floats(-0.05, 0.05))
def test_box_distance_matches_oracle(pc, l, w, b, hgt, tp):
    p, c = pc
    tpq = round(tp * Q)
    tp = tpq / Q
    box = [l, b - hgt, l + w - 1, b]
    out = _native.camera_box_distance(c, tpq, box)
    ref = rc.box_distance(p, tp, box)
    row = b + p.bottom_offset
    for dr in (row, row - p.delta_px, row + p.delta_px):
        assume(abs((dr - p.cy) + p.fy * tp) > 0.01)
    assert bool(out.flags & lib.VT_DIST_VALID) == ref.valid
    assert bool(out.flags & lib.VT_DIST_BOTTOM_CLIPPED) == ref.bottom_clipped
    assert bool(out.flags & lib.VT_DIST_SIDE_CLIPPED) == ref.side_clipped
    assert abs(out.dist_width / Q - ref.dist_width) <= 1.5 * LSB
    if ref.valid:
        assert abs(out.distance / Q - ref.distance) <= dist_tol(p, tp, row, ref.distance)
    if ref.far_valid and ref.valid:
        t = dist_tol(p, tp, row - p.delta_px, ref.dist_far) + dist_tol(p, tp, row + p.delta_px,
                                                                       ref.dist_near)
        assert abs(out.sigma / Q - ref.sigma) <= t / 2 + LSB


@given(st.integers(125, 1000), st.lists(st.one_of(st.none(), st.floats(100, 400)), min_size=1,
                                       max_size=60), st.integers(1, 6))
def test_pitch_matches_oracle(alpha, vps, reacq):
    p, c = cam_params(tp=0.01, pitch_alpha_permille=alpha, pitch_reacquire=reacq,
                      tan_pitch_min=-0.08, tan_pitch_max=0.1)
    st_c = _native.pitch_new(c)
    ref = rc.PitchEstimator(p)
    # per update C rounds m (one division, <= 0.5 LSB) and the blend's step (<= 0.5 LSB);
    # the filter keeps (1 - a) of the error it had, so the error stays <= (0.5 + 0.5) / a,
    # plus 1 LSB for the nominal pitch's own rounding
    bound = (0.5 + 0.5) / (alpha / 1000) + 1
    for vp in vps:
        if vp is None:
            _native.pitch_update(c, st_c, 0, 0)
            ref.update(None)
        else:
            vq = round(vp * Q)
            m = (p.cy - vq / Q) / p.fy
            # decisions within 16 LSB of a threshold may go either way: stop comparing there
            near = min(abs(m - p.tan_pitch_min), abs(m - p.tan_pitch_max),
                       abs(abs(m - ref.tan_pitch) - p.pitch_max_step),
                       abs(abs(m - ref.run_tan) - p.pitch_max_step) if ref.outliers else 1.0)
            if near < 16 * LSB:
                return
            _native.pitch_update(c, st_c, 1, vq)
            ref.update(vq / Q)
        assert st_c.flag == ref.flag
        assert abs(st_c.tan_pitch / Q - ref.tan_pitch) <= bound * LSB



def _round_half_away(n: int, d: int) -> int:
    q = (abs(n) + d // 2) // d
    return q if n >= 0 else -q


@given(st.integers(0, 1000), st.integers(-3000, 3000), st.integers(-30000, 30000))
def test_pitch_blend_rounds_half_away_from_zero(alpha, tp0, dv):
    """The blend's stated rule, in integers: tan_pitch + round_half_away((m - tan_pitch) *
    pitch_alpha_permille / 1000) (Q16), m = round_half_away((cy - vp_row) * 65536 / fy)."""
    p, c = cam_params(tp=tp0 / Q, pitch_alpha_permille=alpha, tan_pitch_min=-0.05, tan_pitch_max=0.05)
    st_c = _native.pitch_new(c)
    tp = int(st_c.tan_pitch)
    vq = int(c.cy) + dv * 16                     # vanishing row near the principal point
    m = _round_half_away((int(c.cy) - vq) * 65536, int(c.fy))
    assume(int(c.tan_pitch_min) <= m <= int(c.tan_pitch_max) and abs(m - tp) <= int(c.pitch_max_step))
    _native.pitch_update(c, st_c, 1, vq)
    assert st_c.flag == lib.VT_PITCH_MEASURED
    assert st_c.tan_pitch == tp + _round_half_away((m - tp) * alpha, 1000)
    assert min(tp, m) <= st_c.tan_pitch <= max(tp, m)


def test_pitch_blend_ties_go_away_from_zero():
    """Half a Q16 LSB either way (alpha 0.5, m - tan_pitch = +-1) lands on m both times:
    a rise and a fall are rounded alike (round half up would stop short on the fall)."""
    p, c = cam_params(tp=0.0, pitch_alpha_permille=500)
    vq = int(c.cy) - 7 * 65536
    m = _round_half_away((int(c.cy) - vq) * 65536, int(c.fy))
    for start in (m - 1, m + 1, m - 3, m + 3):
        st_c = _native.pitch_new(c)
        st_c.tan_pitch = start
        _native.pitch_update(c, st_c, 1, vq)
        assert st_c.tan_pitch == start + _round_half_away((m - start) * 500, 1000)
        assert st_c.tan_pitch == (m if abs(m - start) == 1 else start + (2 if m > start else -2))

def test_pitch_rejects_implausible_and_holds():
    p, c = cam_params(tp=0.0)
    s = _native.pitch_new(c)
    assert s.flag == lib.VT_PITCH_NOMINAL
    _native.pitch_update(c, s, 1, round((p.cy - 0.2 * p.fy) * Q))  # 11 degrees: beyond the limits
    assert s.flag == lib.VT_PITCH_REJECTED and s.tan_pitch == 0
    _native.pitch_update(c, s, 1, round((p.cy - 0.01 * p.fy) * Q))
    assert s.flag == lib.VT_PITCH_MEASURED and 0 < s.tan_pitch < round(0.01 * Q)
    good = s.tan_pitch
    _native.pitch_update(c, s, 0, 0)
    assert s.flag == lib.VT_PITCH_HELD and s.tan_pitch == good
    # an outlier inside the limits is held, until it lasts pitch_reacquire frames
    for k in range(p.pitch_reacquire):
        _native.pitch_update(c, s, 1, round((p.cy - 0.045 * p.fy) * Q))
        if k < p.pitch_reacquire - 1:
            assert s.flag == lib.VT_PITCH_REJECTED and s.tan_pitch == good
    assert s.flag == lib.VT_PITCH_MEASURED and abs(s.tan_pitch / Q - 0.045) < 2 * LSB


def test_pitch_scattered_outliers_never_take_over():
    """Wrong vanishing rows that disagree with one another (the KITTI frames 31-43 with some
    lane sets: rows -46, 78, 142, 97, ... against a true 172) are outliers however long they
    last; the same rows repeated are a lasting change and are followed after pitch_reacquire."""
    p, c = cam_params(tp=0.0, pitch_max_step=0.02, tan_pitch_min=-0.08, tan_pitch_max=0.08)
    s = _native.pitch_new(c)
    ref = rc.PitchEstimator(p)
    # alternating 0.03 and 0.06: each an outlier of the estimate 0 and 0.03 from the other
    seq = [0.03, 0.06] * (3 * p.pitch_reacquire)
    for t in seq:
        vq = round((p.cy - t * p.fy) * Q)
        _native.pitch_update(c, s, 1, vq)
        ref.update(vq / Q)
        assert s.flag == ref.flag == lib.VT_PITCH_REJECTED
        assert s.tan_pitch == 0 and ref.tan_pitch == 0
    # a run within pitch_max_step of its first outlier (0.05 .. 0.065) is followed
    for k, t in enumerate([0.05, 0.065, 0.055, 0.06, 0.05, 0.06][:p.pitch_reacquire]):
        vq = round((p.cy - t * p.fy) * Q)
        _native.pitch_update(c, s, 1, vq)
        ref.update(vq / Q)
        assert s.flag == ref.flag
    assert s.flag == lib.VT_PITCH_MEASURED and abs(s.tan_pitch / Q - ref.tan_pitch) < 2 * LSB
    assert ref.tan_pitch > 0.04


def _rcfg(**kw):
    p = rc.RangeParams(**kw)
    c = range_to_c(p)
    return range_from_c(c), c


@given(st.lists(st.tuples(st.one_of(st.none(), st.floats(0.0, 6.0)), st.booleans(),
                          st.sampled_from([0, 1, 2, 3])), min_size=1, max_size=80),
       st.integers(1, 5), st.integers(0, 12), st.floats(0, 1), st.integers(1, 4))
def test_fcw_state_machine_identical(seq, confirm, rearm, margin, release):
    p, c = _rcfg(confirm_frames=confirm, rearm_frames=rearm, ttc_margin=margin, release_frames=release)
    st_c = ffi.new("vt_fcw_state *", {"since_end": 2**31 - 1})
    ref = rc.FcwState()
    for ttc, closing, cls in seq:
        tq = 0 if ttc is None else round(ttc * Q)
        bits = _native.fcw_step(c, st_c, 0 if ttc is None else 1, tq, int(closing), cls)
        rbits = rc.fcw_step(p, ref, None if ttc is None else tq / Q, closing, cls)
        assert bits == rbits
        assert (st_c.below, st_c.above, bool(st_c.warning), st_c.warnings) == \
            (ref.below, ref.above, ref.warning, ref.warnings)


def test_fcw_rules():
    p, c = _rcfg(confirm_frames=3, rearm_frames=5, ttc_margin=0.0, release_frames=1)
    s = ffi.new("vt_fcw_state *", {"since_end": 2**31 - 1})
    step = lambda ttc, closing=1, cls=lib.VT_LEAD_STOPPED: _native.fcw_step(  # noqa: E731
        c, s, 1, round(ttc * Q), closing, cls)
    assert step(2.0) == 0 and step(2.0) == 0
    assert step(2.0) == lib.VT_FCW_WARNING | lib.VT_FCW_ONSET        # third frame under 2.1 s
    assert step(1.5) == lib.VT_FCW_WARNING                            # held
    assert step(1.5, closing=0) == 0                                  # opening: ends
    for _ in range(3):
        step(1.0)
    assert step(1.0) & lib.VT_FCW_SUPPRESSED                          # within the rearm time
    # slower lead: 2.05 s is above its 2.0 s threshold
    s2 = ffi.new("vt_fcw_state *", {"since_end": 2**31 - 1})
    for _ in range(5):
        assert _native.fcw_step(c, s2, 1, round(2.05 * Q), 1, lib.VT_LEAD_SLOWER) == 0
    for _ in range(5):  # unknown lead class: the largest threshold (2.4 s) applies
        b = _native.fcw_step(c, s2, 1, round(2.3 * Q), 1, lib.VT_LEAD_UNKNOWN)
    assert b & lib.VT_FCW_WARNING


def approach(n, z0, v, dt, cam, noise, rng, width=1.8, hgt=1.5):
    """Boxes of a vehicle at z0 closing at v m/s (pinhole, flat road, pitch 0)."""
    out = []
    for k in range(n):
        z = z0 - v * k * dt
        s = cam.fx / z
        b = cam.cy + s * cam.height - cam.bottom_offset + rng.normal(0, noise)
        l = cam.cx - s * width / 2 + rng.normal(0, noise)
        r = cam.cx + s * width / 2 + rng.normal(0, noise)
        out.append([int(round(l)), int(round(b - s * hgt)), int(round(r)), int(round(b))])
    return out


@given(st.floats(8, 60), st.floats(-3, 15), st.sampled_from([0.033, 0.1, 0.2]), st.floats(0, 1.5),
       st.integers(0, 2**31), st.floats(0.5, 5))
@settings(max_examples=40)
def test_range_filter_matches_oracle(z0, v, dt, noise, seed, accel):
    p, c = cam_params()
    rp, rcf = _rcfg(frame_dt=dt, jerk_sigma=accel)
    rng = np.random.default_rng(seed)
    n = 40
    assume(z0 - v * n * dt > 3)
    boxes = approach(n, z0, v, dt, p, noise, rng)
    st_c = _native.range_new()
    ref = rc.RangeTracker(p, rp)
    for b in boxes:
        arr = np.zeros(1, _native.TRACK_OUT_DTYPE)
        arr[0] = (7, 2, *b, 0, 0)
        oc = _native.range_step(st_c, rcf, c, 0, -65536, arr)[0]
        orf = ref.step([(7, b)], 0.0)[0]
        assert bool(oc["flags"] & lib.VT_RANGE_DIST_VALID) == (orf.distance is not None)
        if orf.distance is not None:
            assert abs(oc["distance"] / Q - orf.distance) <= 1e-4 * orf.distance + 2 * LSB
        if orf.dist_filt is not None:
            assert abs(oc["dist_filt"] / Q - orf.dist_filt) <= 1e-3
            assert abs(oc["rate"] / Q - orf.rate) <= 5e-3
        if orf.ttc_scale is not None and oc["flags"] & lib.VT_RANGE_TTC_SCALE_VALID:
            assert abs(oc["ttc_scale"] / Q - orf.ttc_scale) <= 1e-4 * orf.ttc_scale + 2 * LSB


def test_range_ttc_on_a_clean_approach():
    """No noise: 30 m closing at 10 m/s, 10 Hz -> both TTCs near the truth."""
    p, c = cam_params()
    rp, rcf = _rcfg(frame_dt=0.1)
    boxes = approach(20, 30.0, 10.0, 0.1, p, 0.0, np.random.default_rng(0))
    st_c = _native.range_new()
    for k, b in enumerate(boxes):
        arr = np.zeros(1, _native.TRACK_OUT_DTYPE)
        arr[0] = (1, 2, *b, 0, 0)
        o = _native.range_step(st_c, rcf, c, 0, -65536, arr)[0]
    z = 30.0 - 10.0 * 19 * 0.1
    assert o["flags"] & lib.VT_RANGE_TTC_DIST_VALID and o["flags"] & lib.VT_RANGE_TTC_SCALE_VALID
    assert abs(o["ttc_dist"] / Q - z / 10.0) < 0.15 * z / 10.0
    # scale TTC over 5 frames of integer-rounded widths: ~1 px of 90 px -> ~10 %
    assert abs(o["ttc_scale"] / Q - z / 10.0) < 0.2 * z / 10.0


def test_range_bad_inputs_and_guard():
    p, c = cam_params()
    _rp, rcf = _rcfg()
    st_c = _native.range_new()
    arr = np.zeros(2, _native.TRACK_OUT_DTYPE)
    arr[0] = (3, 2, 100, 100, 200, 300, 0, 0)
    arr[1] = (3, 2, 300, 100, 400, 300, 0, 0)
    with pytest.raises(VtError, match="vt_range_step"):
        _native.range_step(st_c, rcf, c, 0, -65536, arr)   # duplicate id
    arr[1]["id"] = 0
    with pytest.raises(VtError):
        _native.range_step(st_c, rcf, c, 0, -65536, arr)   # id 0 on a live track
    arr[1]["id"] = 4
    arr[1]["right"] = 200                                    # right < left
    with pytest.raises(VtError):
        _native.range_step(st_c, rcf, c, 0, -65536, arr)
    assert st_c.frame == 0                                   # nothing changed
    with pytest.raises(VtError):
        _native.range_step(st_c, rcf, c, 2 * 65536, -65536, arr[:1])  # |tan pitch| > 1
    # output capacity: room for one of two tracks; the entry after it stays untouched
    arr[1]["right"] = 400
    out = np.full(3, -7, _native.RANGE_OUT_DTYPE)
    n = ffi.new("int32_t *")
    s = lib.vt_range_step(st_c, rcf, c, 0, -65536, ffi.cast("vt_track_out *", arr.ctypes.data), 2,
                          ffi.cast("vt_range_out *", out.ctypes.data), 1, n)
    if lib.VT_MAX_TRACKS >= 2:
        assert s == lib.VT_E_CAPACITY and n[0] == 1
        assert out[0]["id"] == 3 and all(v == -7 for v in out[1].tolist()) and out[2]["id"] == -7
    else:
        assert s == lib.VT_E_CAPACITY
    # NULLs
    for args in [(ffi.NULL, rcf, c), (st_c, ffi.NULL, c), (st_c, rcf, ffi.NULL)]:
        assert lib.vt_range_step(*args, 0, 0, ffi.NULL, 0, ffi.NULL, 0, n) == lib.VT_E_ARG
    assert lib.vt_range_step(st_c, rcf, c, 0, 0, ffi.NULL, 0, ffi.NULL, 0, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_range_init(ffi.NULL) == lib.VT_E_ARG


def test_camera_cfg_bad_values():
    p, c = cam_params()
    assert lib.vt_camera_cfg_check(ffi.NULL) == lib.VT_E_ARG
    for field, val in [("fx", 0), ("fy", -65536), ("height", 0), ("tan_pitch", 2 * 65536),
                       ("tan_pitch_min", 65536), ("pitch_alpha_permille", 1001),
                       ("pitch_alpha_permille", -1), ("delta_px", 0),
                       ("vehicle_width", 0), ("width_tol_permille", 9)]:
        bad = ffi.new("vt_camera_cfg *", c[0])
        setattr(bad, field, val)
        assert lib.vt_camera_cfg_check(bad) == lib.VT_E_ARG, field
        d, ok = ffi.new("vt_q16 *"), ffi.new("int32_t *")
        assert lib.vt_camera_row_distance(bad, 0, 300 * 65536, d, ok) == lib.VT_E_ARG
    bad = ffi.new("vt_camera_cfg *", c[0])
    bad.img_w = 0
    assert lib.vt_camera_cfg_check(bad) == lib.VT_E_SIZE
    with pytest.raises(VtError, match="vt_camera_box_distance"):
        _native.camera_box_distance(c, 0, [10, 10, 5, 20])
    with pytest.raises(VtError):
        _native.camera_row_distance(c, 65537, 0)       # pitch out of range
    rb = ffi.new("vt_range_cfg *", range_to_c(rc.RangeParams())[0])
    rb.scale_lag = lib.VT_RANGE_HIST
    assert lib.vt_range_cfg_check(rb) == lib.VT_E_ARG
    s = ffi.new("vt_pitch_state *")
    assert lib.vt_pitch_update(s, c, 2, 0) == lib.VT_E_ARG
    assert lib.vt_pitch_init(s, ffi.NULL) == lib.VT_E_ARG


def test_vanishing_row_from_lanes_and_size_change():
    res = ffi.new("vt_lane_result *")
    res.shift, res.scale, res.w, res.h = 1, 2, 320, 240
    L, R = res.lines[lib.VT_LANE_LEFT], res.lines[lib.VT_LANE_RIGHT]
    # left line x = 100 - 1 * (y - 239), right x = 220 + 1 * (y - 239): meet at dy = -60
    L.state, L.xb, L.slope = 1, 100 * 65536, -65536
    R.state, R.xb, R.slope = 1, 220 * 65536, 65536
    row, ok = _native.lane_vanishing_row(res, 480)
    assert ok == 1
    yw = 239 - 60
    assert row == round(((yw + 0.5) * 2 - 0.5) * 65536)
    assert rc.vanishing_row((100, -1), (220, 1), 240, 2) == (yw + 0.5) * 2 - 0.5
    with pytest.raises(VtError, match="size"):
        _native.lane_vanishing_row(res, 640)           # the lanes were found in another frame size
    R.state = 0
    assert _native.lane_vanishing_row(res, 480) == (0, 0)
    R.state, R.slope = 1, -65536                       # parallel: no vanishing point
    assert _native.lane_vanishing_row(res, 481)[1] == 0
    # a scale that is not a power of two (a 1920 x 1080 frame at 320 x 180 is 6): the same
    # mapping, (y + 1/2) k - 1/2, exact in Q16 as yw is a whole row here
    R.slope = 65536
    res.shift, res.scale, res.h = -1, 3, 160
    yw = 159 - 60
    row, ok = _native.lane_vanishing_row(res, 482)       # 482 // 3 = 160 working rows
    assert ok == 1 and row == round(((yw + 0.5) * 3 - 0.5) * 65536)
    assert rc.vanishing_row((100, -1), (220, 1), 160, 3) == (yw + 0.5) * 3 - 0.5
    with pytest.raises(VtError, match="size"):
        _native.lane_vanishing_row(res, 483)
    for bad in (0, 9, -1):
        res.scale = bad
        with pytest.raises(VtError):
            _native.lane_vanishing_row(res, 720)


# ------------------------------------------------------------------ the camera file
def test_camera_file_roundtrip(tmp_path):
    cam = Camera(700.0, 701.0, 320.0, 240.0, height_m=1.3, pitch_deg=1.0, dist=[0.1, -0.2, 0, 0, 0.01],
                 image_size=(640, 480))
    f = tmp_path / "c.json"
    cam.save(f)
    back = Camera.load(f)
    assert back == cam and back.dist == (0.1, -0.2, 0.0, 0.0, 0.01)
    assert json.loads(f.read_text())["height_m"] == 1.3
    # the mounting offset: written, read back, and carried into the C camera (Q16)
    off = Camera(700.0, 701.0, 320.0, 240.0, height_m=1.3, image_size=(640, 480), lateral_m=-0.35)
    off.save(f)
    assert Camera.load(f) == off and json.loads(f.read_text())["lateral_m"] == -0.35
    assert params_to_c(off.params(640, 480)).lateral == round(-0.35 * Q)
    assert "lateral_m" not in json.loads((cam.save(f), f.read_text())[1])   # absent unless given


@pytest.mark.parametrize("content, msg", [
    ("{", "not JSON"),
    ("[]", "JSON object"),
    ('{"fx": 1, "fy": 1, "cx": 1}', "'cy' is missing"),
    ('{"fx": "a", "fy": 1, "cx": 1, "cy": 1}', "'fx' must be a number"),
    ('{"fx": 0, "fy": 1, "cx": 1, "cy": 1}', "'fx'"),
    ('{"fx": 500, "fy": 500, "cx": 1, "cy": 1, "height_m": -1}', "'height_m'"),
    ('{"fx": 500, "fy": 500, "cx": 1, "cy": 1, "pitch_deg": 60}', "'pitch_deg'"),
    ('{"fx": 500, "fy": 500, "cx": 1, "cy": 1, "dist": [1, 2]}', "'dist'"),
    ('{"fx": 500, "fy": 500, "cx": 1, "cy": 1, "foo": 1}', "unknown key"),
    ('{"fx": 500, "fy": 500, "cx": 1, "cy": 1, "image_size": [0, 5]}', "'image_size'"),
    ('{"fx": 500, "fy": 500, "cx": 1, "cy": 1, "lateral_m": 5.5}', "'lateral_m'=5.5 is outside"),
    ('{"fx": 500, "fy": 500, "cx": 1, "cy": 1, "lateral_m": "0.3"}', "'lateral_m' must be a number"),
])
def test_camera_file_errors(tmp_path, content, msg):
    f = tmp_path / "c.json"
    f.write_text(content)
    with pytest.raises(CameraFileError, match=msg):
        Camera.load(f)


def test_camera_missing_file_and_height(tmp_path):
    with pytest.raises(CameraFileError, match="c.json"):
        Camera.load(tmp_path / "c.json")
    cam = Camera(500.0, 500.0, 320.0, 240.0)
    with pytest.raises(ValueError, match="height_m"):
        RangeEstimator(cam, (640, 480), 30)
    cam = Camera(500.0, 500.0, 320.0, 240.0, height_m=1.2, image_size=(640, 480))
    with pytest.raises(ValueError, match="calibrated for 640x480"):
        RangeEstimator(cam, (1280, 720), 30)
    with pytest.raises(ValueError, match="fps"):
        RangeEstimator(cam, (640, 480), 0)
    with pytest.raises(TypeError):
        RangeEstimator({"fx": 1}, (640, 480), 30)
    r = RangeEstimator(cam, (640, 480), 30)
    with pytest.raises(ValueError, match="vp_row"):
        r.update_pitch(float("nan"))
    with pytest.raises(ValueError, match="box"):
        r.step([(1, [10, 10, 5, 20])])
    with pytest.raises(ValueError, match="ego_speed"):
        r.step([], ego_speed=-1)


def test_estimator_engines_agree():
    cam = Camera(700.0, 700.0, 319.5, 240.0, height_m=1.3)
    p = cam.params(640, 480)
    boxes = approach(30, 25.0, 5.0, 1 / 30, p, 0.5, np.random.default_rng(3))
    a, b = RangeEstimator(cam, (640, 480), 30), RangeEstimator(cam, (640, 480), 30, engine="reference")
    dtan = 0.0
    for bx in boxes:
        a.update_pitch(240.0 - 3.0)
        b.update_pitch(240.0 - 3.0)
        oa, ob = a.step([(1, bx)], 20.0)[0], b.step([(1, bx)], 20.0)[0]
        # plus the pitch estimates' few-LSB difference (the C smoothing stops within
        # 256 / alpha / 2 LSB of the measurement), dY/dtan = (Y^2 + h^2) / h, largest so
        # far since the filter remembers it
        dtan = max(dtan, abs(a.tan_pitch - b.tan_pitch))
        y = ob.dist_filt
        tol = 1e-3 + 1.5 * (y * y + 1.3 ** 2) / 1.3 * dtan
        assert abs(oa.dist_filt - ob.dist_filt) <= tol
        assert oa.warning == ob.warning
    assert abs(a.pitch_deg - b.pitch_deg) < 1e-3


def test_vanishing_row_on_a_real_frame_both_engines():
    """The ego lines' meeting row from the C lane stage (vt_lane_vanishing_row, Q16) and from
    the float oracle's lines on a real highway frame: the lane stages agree to a fraction of a
    working pixel (tests/test_lane.py), which the intersection of two lines ~45 degrees apart
    turns into about as much: within 2 input px."""
    from pathlib import Path

    import cv2

    from pyvehtrack.camera import lane_vanishing_row
    from pyvehtrack.lane import LaneDetector
    img = cv2.imread(str(Path(__file__).parent / "data" / "lane_udacity_solidWhiteCurve_gray_640x360.png"),
                     cv2.IMREAD_GRAYSCALE)
    vc = lane_vanishing_row(LaneDetector(engine="c").detect(img))
    vr = lane_vanishing_row(LaneDetector(engine="reference").detect(img))
    assert vc is not None and vr is not None
    assert 150 < vc < 250                       # the horizon of this 360-row frame
    assert abs(vc - vr) < 2.0


@given(st.lists(st.tuples(st.floats(-50, 50), st.floats(0.01, 30)), min_size=1, max_size=30))
@settings(max_examples=60)
def test_kf_update_r_matches_filterpy(meas):
    """vt_kf_update_r = set R then update: against filterpy's update(z, R=r) on a 1-D
    constant-velocity filter, with the same tolerance as plain updates (tests/test_kalman.py:
    0.01 px on the state, here with R between 1e-4 and 900)."""
    from filterpy.kalman import KalmanFilter as FKF
    kf = _native.kf_new()
    _native.kf_init(kf, 2, 1)
    kf.F[0][1] = 1 << 32
    kf.H[0][0] = 1 << 32
    kf.Q[0][0] = 0                # vt_kf_init starts from Q = I, as filterpy
    kf.Q[1][1] = 1 << 28          # 1/16
    kf.P[0][0] = kf.P[1][1] = 100 << 32
    ref = FKF(dim_x=2, dim_z=1)
    ref.F = np.array([[1.0, 1.0], [0.0, 1.0]])
    ref.H = np.array([[1.0, 0.0]])
    ref.Q = np.diag([0.0, 1 / 16])
    ref.P = np.diag([100.0, 100.0])
    ref.x = np.zeros((2, 1))
    for z, sig in meas:
        r = round(sig * sig * 2**32)
        _native.kf_predict(kf)
        zq = round(z * Q)
        assert lib.vt_kf_update_r(kf, ffi.new("vt_q16[]", [zq]), ffi.new("vt_q32[]", [r])) == lib.VT_OK
        ref.predict()
        ref.update(np.array([[zq / Q]]), R=np.array([[r / 2**32]]))
        assert kf.R[0][0] == r
        assert abs(kf.x[0] / Q - ref.x[0, 0]) <= 0.01 and abs(kf.x[1] / Q - ref.x[1, 0]) <= 0.01


def test_kf_update_r_bad_r_leaves_filter_unchanged():
    kf = _native.kf_new()
    _native.kf_init(kf, 2, 2)
    before = bytes(ffi.buffer(kf))
    z = ffi.new("vt_q16[]", [0, 0])
    for r in ([-1, 0, 0, 1], [1, 2, 3, 1]):           # negative variance; not symmetric
        assert lib.vt_kf_update_r(kf, z, ffi.new("vt_q32[]", r)) == lib.VT_E_ARG
    assert lib.vt_kf_update_r(kf, z, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_kf_update_r(ffi.NULL, z, ffi.new("vt_q32[]", 4)) == lib.VT_E_ARG
    # a singular S (H = 0, R = 0) fails in the update: R is put back (x, P, K were never
    # changed; y and S hold the failed measurement's values, as vt_kf_update documents)
    x, p, k, r0 = list(kf.x), [list(v) for v in kf.P], [list(v) for v in kf.K], [list(v) for v in kf.R]
    assert lib.vt_kf_update_r(kf, z, ffi.new("vt_q32[]", [0, 0, 0, 0])) == lib.VT_E_SINGULAR
    assert (list(kf.x), [list(v) for v in kf.P], [list(v) for v in kf.K], [list(v) for v in kf.R]) == \
        (x, p, k, r0)
    assert bytes(ffi.buffer(kf))[:8] == before[:8]


def _run_range(boxes, rcf, c, tid=5):
    st_c = _native.range_new()
    outs = []
    for b in boxes:
        arr = np.zeros(1, _native.TRACK_OUT_DTYPE)
        arr[0] = (tid, 2, *b, 0, 0)
        outs.append(_native.range_step(st_c, rcf, c, 0, 0, arr)[0])   # ego speed 0: lead "stopped"
    return outs


@pytest.mark.parametrize("lateral, half, warns", [
    (0.0, 1.5, True),      # in the ego lane: warns
    (3.6, 1.5, False),     # stopped in the next lane: inner edge 2.7 m from the axis, no warning
    (-3.6, 1.5, False),
    (2.3, 1.5, True),      # inner edge 1.4 m from the axis: overlaps the corridor
    (3.6, 0.0, True),      # the check off: every closing track may warn, as before it existed
])
def test_fcw_only_in_the_ego_path(lateral, half, warns):
    """A vehicle 1.8 m wide approached at 10 m/s from 30 m: the warning fires (ego speed 0,
    so the lead counts as stopped, 2.1 s + margin) only when its box overlaps the corridor
    |X| < path_half_width; VT_RANGE_IN_PATH says so on every frame with a distance."""
    p, c = cam_params()
    _rp, rcf = _rcfg(frame_dt=0.1, path_half_width=half)
    boxes = approach(25, 30.0, 10.0, 0.1, p, 0.0, np.random.default_rng(0))
    shift = lambda b, z: [b[0] + round(p.fx * lateral / z), b[1], b[2] + round(p.fx * lateral / z), b[3]]  # noqa: E731
    boxes = [shift(b, 30.0 - 10.0 * k * 0.1) for k, b in enumerate(boxes)]
    outs = _run_range(boxes, rcf, c)
    assert any(o["fcw"] & lib.VT_FCW_WARNING for o in outs) == warns
    assert all(bool(o["flags"] & lib.VT_RANGE_IN_PATH) == (warns or half == 0) for o in outs[1:])


def test_fcw_needs_a_distance_this_frame():
    """The approach of test_fcw_only_in_the_ego_path, but from frame 6 (24 m, TTC 2.4 s) the box
    fills the frame, cut at its bottom and both sides (a passed truck leaving the view, KITTI
    clip frame 15): no distance is measured, the filter's prediction alone keeps the TTC
    falling under 2.1 s in the ego path, and that raises no warning; measured, it does."""
    p, c = cam_params()
    _rp, rcf = _rcfg(frame_dt=0.1, path_half_width=1.5)
    boxes = approach(25, 30.0, 10.0, 0.1, p, 0.0, np.random.default_rng(0))
    assert any(o["fcw"] & lib.VT_FCW_WARNING for o in _run_range(boxes, rcf, c))
    cut = [b if k < 6 else [0, b[1], p.img_w - 1, p.img_h - 1] for k, b in enumerate(boxes)]
    outs = _run_range(cut, rcf, c)
    late = outs[6:]
    assert not any(o["flags"] & lib.VT_RANGE_DIST_VALID for o in late)
    # the condition the warning took before: a TTC under the stopped lead's 2.1 s, in the path
    assert any(o["flags"] & lib.VT_RANGE_TTC_DIST_VALID and o["ttc_dist"] / Q < 2.1 and
               o["flags"] & lib.VT_RANGE_IN_PATH for o in late)
    assert not any(o["fcw"] & lib.VT_FCW_WARNING for o in outs)
    ref = rc.RangeTracker(p, _rp)      # the oracle takes the same rule
    assert not any(ref.step([(5, b)], 0.0, 0.0)[0].fcw & rc.FCW_WARNING for b in cut)


@given(st.integers(-2**31, 2**31 - 1), st.integers(0, 2**31 - 1), st.floats(0.01, 200), st.floats(0, 10),
       st.one_of(st.just(0.0), st.floats(-5, 5)))
@settings(max_examples=300)
def test_in_path_matches_oracle_for_any_box(left, width, d, half, lateral):
    """The corridor test against the float oracle's m - half < (u - cx) d / fx < m + half
    (m = -lateral, the camera's mounting offset) on one frame, on the same Q16 values (cx,
    fx, half, lateral from the C configs, d = C's dist_filt): C compares integers exactly,
    the oracle in double, three roundings of 2^-53 each, so they may differ only where X
    is within 1e-12 relative of one of the corridor's edges."""
    p, c = cam_params(lateral=lateral)
    rp, rcf = _rcfg(path_half_width=half)
    right = min(left + width, 2**31 - 1)
    # a box whose bottom row gives distance d (eq. 1, pitch 0), its columns anywhere in int32
    row = int(round(p.cy + p.fx * p.height / d))
    box = [left, row - 10, right, row]
    oc = _run_range([box], rcf, c)[0]
    if not oc["flags"] & lib.VT_RANGE_FILT_VALID:
        return
    ref = rc.RangeTracker(p, rp)
    ref.step([(5, box)], 0.0)
    dq = oc["dist_filt"] / Q
    want = ref._in_path(box, dq)
    got = bool(oc["flags"] & lib.VT_RANGE_IN_PATH)
    if got != want:
        m, hw = -p.lateral, rp.path_half_width
        xl, xr = (left - p.cx) * dq / p.fx, (right + 1 - p.cx) * dq / p.fx
        edge = min(abs(xl - (m + hw)), abs(xr - (m - hw)))
        assert edge <= 1e-12 * max(abs(xl), abs(xr), 1), (box, dq, xl, xr, m, hw)


def test_range_cfg_path_half_width_range():
    _rp, rcf = _rcfg()
    assert rcf.path_half_width == round(1.5 * Q)
    for bad in (-1, int(10 * Q) + 1):
        rcf.path_half_width = bad
        with pytest.raises(VtError):
            _native.range_cfg_check(rcf)


@pytest.mark.parametrize("left, right, inside", [
    (337, 500, False), (336, 500, True),    # X of the left edge = +1.0 m exactly / 0.94 m
    (100, 301, False), (100, 302, True),    # X of the right edge (right + 1) = -1.0 m exactly / -0.94 m
])
def test_in_path_edge_is_strict(left, right, inside):
    """At the corridor's edge exactly: cx 319.5, fx 700, camera height 1 m, bottom row 257
    gives d = 40 m exactly in Q16 and half 1.0 m, so X = (u - 319.5) 40 / 700 = +-1.0 at
    u = 337 / 302: |X| = half is outside (X < half and X > -half are strict)."""
    p, c = cam_params(height=1.0)
    rp, rcf = _rcfg(path_half_width=1.0)
    o = _run_range([[left, 247, right, 257]], rcf, c)[0]
    assert o["dist_filt"] == 40 * 65536
    assert bool(o["flags"] & lib.VT_RANGE_IN_PATH) == inside
    assert rc.RangeTracker(p, rp)._in_path([left, 247, right, 257], 40.0) == inside


@pytest.mark.parametrize("left, right, inside", [
    (344, 500, False), (343, 500, True),    # X of the left edge = m + half = +1.5 m exactly / 1.4375 m
    (100, 311, False), (100, 312, True),    # X of the right edge (right + 1) = m - half = -0.5 m exactly / -0.4375 m
])
def test_in_path_edge_with_mounting_offset(left, right, inside):
    """The strict edges of the corridor centred on the car, not on the camera. The camera
    mounted 0.5 m left of the car's centre line (lateral -0.5) puts the corridor's centre at
    X = +0.5 m; with half 1.0 m its edges are X = +1.5 and -0.5 m. cx 320, fx 640, fy 700,
    camera height 1 m, bottom row 257: d = 40 m exactly in Q16, X = (u - 320) / 16, so the
    edges fall on whole columns u = 344 and 312, and every value is exact in Q16."""
    p, c = cam_params(fx=640.0, fy=700.0, cx=320.0, height=1.0, lateral=-0.5)
    rp, rcf = _rcfg(path_half_width=1.0)
    o = _run_range([[left, 247, right, 257]], rcf, c)[0]
    assert o["dist_filt"] == 40 * 65536
    assert bool(o["flags"] & lib.VT_RANGE_IN_PATH) == inside
    assert rc.RangeTracker(p, rp)._in_path([left, 247, right, 257], 40.0) == inside


@pytest.mark.parametrize("lateral, warns", [(0.0, False), (-0.9, True), (0.9, False)])
def test_fcw_corridor_follows_the_camera_mounting(lateral, warns):
    """A stopped vehicle 1.8 m wide, its centre 3.0 m right of the camera's axis (X in
    [2.1, 3.9] m), approached at 10 m/s from 30 m. The corridor (half 1.5 m) is centred on
    the car, at X = -lateral: with the camera on the car's centre line it is [-1.5, 1.5] m
    and nothing warns; a camera mounted 0.9 m left of the centre line (lateral -0.9) moves it
    to [-0.6, 2.4] m, which the vehicle overlaps, and it warns; mounted 0.9 m right, the
    corridor is [-2.4, 0.6] m and nothing warns. C and the oracle alike."""
    p, c = cam_params(lateral=lateral)
    _rp, rcf = _rcfg(frame_dt=0.1, path_half_width=1.5)
    boxes = approach(25, 30.0, 10.0, 0.1, p, 0.0, np.random.default_rng(0))
    shift = lambda b, z: [b[0] + round(p.fx * 3.0 / z), b[1], b[2] + round(p.fx * 3.0 / z), b[3]]  # noqa: E731
    boxes = [shift(b, 30.0 - 10.0 * k * 0.1) for k, b in enumerate(boxes)]
    outs = _run_range(boxes, rcf, c)
    assert any(o["fcw"] & lib.VT_FCW_WARNING for o in outs) == warns
    assert all(bool(o["flags"] & lib.VT_RANGE_IN_PATH) == warns for o in outs[1:])
    ref = rc.RangeTracker(p, _rp)
    assert any(ref.step([(5, b)], 0.0, 0.0)[0].fcw & rc.FCW_WARNING for b in boxes) == warns


def test_camera_cfg_lateral_range():
    _p, c = cam_params()
    assert c.lateral == 0
    for bad in (-5 * Q - 1, 5 * Q + 1):
        c.lateral = int(bad)
        with pytest.raises(VtError):
            _native.camera_cfg_check(c)
    for good in (-5 * Q, 5 * Q):
        c.lateral = int(good)
        _native.camera_cfg_check(c)
