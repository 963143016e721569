"""TTC from the scale change of SAD-matched blocks (c/ttc_scale.c) against its float twin
(pyvehtrack/reference/ttc_scale.py), accuracy on synthetic zooms with exact truth, bad
inputs, guard bytes and capacity.

Tolerances, from the arithmetic of ttc_scale.h:
- The block choice, the predicted window and the SAD search are integer rules shared
  exactly, so blocks, matched blocks and pairs must be equal.
- Sub-pixel offsets: C rounds (S- - S+) 256 / (2 den) half away from zero to Q8, so each
  coordinate is within 1/512 px of the oracle's exact parabola vertex; a difference of two
  positions is within 2/512 px per axis, so a pair's distance now is within
  sqrt(2) / 256 px of the oracle's and its ratio within sqrt(2) / (256 min_pair_px)
  (distance then >= min_pair_px, exact integers). The squared ratio is rounded once to
  Q16 (2^-17) and s = floor(sqrt(r2 2^16)) loses < 2^-16; the median (same index) moves by
  no more than the largest per-pair change. Tolerance on s: sqrt(2) / (256 min_pair_px)
  + 2^-15.
- TTC: C divides lag dt 2^16 by (s - 2^16) rounded half away from zero (0.5 LSB), from its
  own s; checked against lag dt / (s_C - 1) within 1 LSB (ties at the ttc_max or s = 1
  edges are compared only where both are valid).
"""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyvehtrack import _native
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.camera import ScaleTtc
from pyvehtrack.reference import ttc_scale as rts

Q = 65536.0


def texture(seed: int, size: int = 96) -> np.ndarray:
    """A car-like rear: smooth random blobs and a few sharp edges (deterministic)."""
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.integers(0, 256, (size, size)).astype(np.float32), (0, 0), 2.0)
    t = (t - t.min()) / max(1e-6, t.max() - t.min()) * 200 + 20
    t[size // 3: size // 3 + 3, :] = 240
    t[:, size // 2: size // 2 + 2] = 10
    return t.astype(np.uint8)


def zoom_frames(seed: int, scales, w: int = 200, h: int = 150, cx: float = 100.0, cy: float = 75.0,
                drift=(0.0, 0.0)):
    """Frames of the texture scaled by scales[k] about (cx + k dx, cy + k dy) on a flat grey
    background, and its exact box (inclusive px) per frame."""
    tex = texture(seed)
    n = tex.shape[0]
    frames, boxes = [], []
    for k, s in enumerate(scales):
        x0, y0 = cx + k * drift[0], cy + k * drift[1]
        # dst = s (src - n/2) + (x0, y0): src coords of the texture's centre map to (x0, y0)
        m = np.array([[s, 0, x0 - s * n / 2], [0, s, y0 - s * n / 2]], np.float64)
        img = np.full((h, w), 128, np.uint8)
        img = cv2.warpAffine(tex, m, (w, h), dst=img, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_TRANSPARENT)
        frames.append(img)
        half = s * n / 2
        boxes.append([int(round(x0 - half)), int(round(y0 - half)), int(round(x0 + half)) - 1,
                      int(round(y0 + half)) - 1])
    return frames, boxes


def tol_s(p: rts.TtcScaleParams) -> float:
    return math.sqrt(2) / (256 * p.min_pair_px) + 2.0 ** -15


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), rate=st.floats(0.0, 0.04), lag=st.integers(1, 4),
       grid=st.integers(2, 8), block=st.integers(4, 8), radius=st.integers(2, 6),
       jitter=st.lists(st.integers(-2, 2), min_size=8, max_size=8), min_pair=st.integers(1, 24),
       anchor=st.sampled_from([0, 0, 1, 4, 10]))
def test_c_matches_oracle(seed, rate, lag, grid, block, radius, jitter, min_pair, anchor):
    scales = [0.7 * (1 + rate) ** k for k in range(6)]
    frames, boxes = zoom_frames(seed, scales, drift=(1.3, -0.4))
    kw = dict(lag=lag, grid=grid, block=block, radius=radius, min_pair_px=min_pair, min_pairs=3,
              anchor_radius=anchor and radius + anchor)
    c, r = ScaleTtc(10, **kw), ScaleTtc(10, engine="reference", **kw)
    tol = tol_s(c.params)
    for k, (f, b) in enumerate(zip(frames, boxes)):
        b = [b[0] + jitter[k], b[1] + jitter[k + 1], b[2] - jitter[k + 2], b[3]]  # a jittering tracker
        if anchor and k == 3:
            b = [b[0], b[1] + 7, b[2], b[3] + 7]  # a box jump, as on a detection frame
        (a,) = c.step(f, [(7, b)])
        (o,) = r.step(f, [(7, b)])
        assert (a.id, a.blocks, a.matched, a.pairs, a.lag) == (o.id, o.blocks, o.matched, o.pairs, o.lag)
        assert (a.scale is None) == (o.scale is None)
        if a.scale is not None:
            assert abs(a.scale - o.scale) <= tol, (k, a, o)
        if a.ttc is not None:
            s_c = a.scale   # over a.lag frames: lag, or a shorter fallback (min_lag)
            assert abs(a.ttc - a.lag * c.params.frame_dt / (s_c - 1)) <= 1.0 / Q * (1 + 1e-9)
            if o.ttc is not None:
                # propagated: d ttc = lag dt ds / (s - 1)^2
                assert abs(a.ttc - o.ttc) <= a.lag * 0.1 * tol / ((min(s_c, o.scale) - 1 - tol) ** 2) + 2 / Q


@pytest.mark.parametrize("engine", ["c", "reference"])
@pytest.mark.parametrize("rate", [0.0, 0.01, 0.025])
def test_scale_is_measured(engine, rate):
    """A texture zooming by (1 + rate) per frame, its box given exactly: s over lag frames is
    (1 + rate)^lag within 0.5 % (sub-pixel matching of 8x8 blocks ~ 0.1 px on pairs >= 16 px
    apart, at least 10 pairs, median), and TTC = lag dt / (s - 1) follows."""
    lag = 4
    scales = [0.8 * (1 + rate) ** k for k in range(8)]
    frames, boxes = zoom_frames(3, scales, drift=(0.7, 0.3))
    est = ScaleTtc(10, engine=engine, lag=lag, min_lag=lag)   # no shorter fallback here
    got = [est.step(f, [(1, b)])[0] for f, b in zip(frames, boxes)]
    assert all(g.scale is None for g in got[:lag])
    for g in got[lag:]:
        assert g.scale is not None and g.pairs >= 10
        assert abs(g.scale - (1 + rate) ** lag) <= 0.005, g
        if rate >= 0.01:
            true_ttc = lag * 0.1 / ((1 + rate) ** lag - 1)
            assert g.ttc is not None and abs(g.ttc - true_ttc) / true_ttc <= 0.15
        else:
            assert g.ttc is None or g.ttc > 15  # no (or a far) TTC when nothing approaches


def test_flat_box_gives_no_scale():
    """A box on a flat region has no textured block: no scale, no TTC, never a crash."""
    f = np.full((60, 80), 90, np.uint8)
    est = ScaleTtc(10, lag=1)
    for _ in range(3):
        (o,) = est.step(f, [(1, [10, 10, 50, 40])])
        assert o.scale is None and o.ttc is None and o.pairs == 0


def test_python_bad_inputs():
    with pytest.raises(ValueError, match="engine"):
        ScaleTtc(10, engine="gpu")
    with pytest.raises(ValueError, match="fps"):
        ScaleTtc(0)
    with pytest.raises(TypeError, match="unknown parameter"):
        ScaleTtc(10, lags=3)
    with pytest.raises(ValueError, match="out of range"):
        ScaleTtc(10, lag=int(lib.VT_TTC_HIST))
    with pytest.raises(ValueError, match="out of range"):
        ScaleTtc(10, block=int(lib.VT_TTC_BLOCK) + 1)
    est = ScaleTtc(10)
    with pytest.raises(TypeError, match="frame"):
        est.step([[1, 2]], [])
    with pytest.raises(TypeError, match="uint8"):
        est.step(np.zeros((10, 10), np.float32), [])
    with pytest.raises(ValueError, match="shape"):
        est.step(np.zeros((10, 10, 2), np.uint8), [])
    with pytest.raises(ValueError, match="empty"):
        est.step(np.zeros((0, 10), np.uint8), [])
    f = np.zeros((20, 20), np.uint8)
    with pytest.raises(ValueError, match="box"):
        est.step(f, [(1, [5, 5, 4, 9])])
    with pytest.raises(ValueError, match="unique"):
        est.step(f, [(1, [0, 0, 5, 5]), (1, [2, 2, 8, 8])])
    with pytest.raises(ValueError, match="positive"):
        est.step(f, [(0, [0, 0, 5, 5])])


def _tracks(boxes, ids=None):
    arr = np.zeros(len(boxes), _native.TRACK_OUT_DTYPE)
    for k, b in enumerate(boxes):
        arr[k] = ((ids or range(1, len(boxes) + 1))[k], 2, *b, 0, 0)
    return arr


def test_c_bad_arguments_and_guards():
    cfg = _native.ttc_cfg_default()
    st_ = _native.ttc_new()
    img = np.zeros((30, 40), np.uint8)
    v = _native.view(img, "img")
    tr = _tracks([[2, 2, 30, 20]])
    tp = ffi.cast("vt_track_out *", tr.ctypes.data)
    out = ffi.new("vt_ttc_out[4]")
    n = ffi.new("int32_t *")
    E = lib.VT_E_ARG
    assert lib.vt_ttc_init(ffi.NULL) == E
    assert lib.vt_ttc_cfg_default(ffi.NULL) == E
    assert lib.vt_ttc_cfg_check(ffi.NULL) == E
    assert lib.vt_ttc_step(ffi.NULL, cfg, v, tp, 1, out, 4, n) == E
    assert lib.vt_ttc_step(st_, ffi.NULL, v, tp, 1, out, 4, n) == E
    assert lib.vt_ttc_step(st_, cfg, ffi.NULL, tp, 1, out, 4, n) == E
    assert lib.vt_ttc_step(st_, cfg, v, ffi.NULL, 1, out, 4, n) == E
    assert lib.vt_ttc_step(st_, cfg, v, tp, -1, out, 4, n) == E
    assert lib.vt_ttc_step(st_, cfg, v, tp, 1, ffi.NULL, 4, n) == E
    assert lib.vt_ttc_step(st_, cfg, v, tp, 1, out, -1, n) == E
    assert lib.vt_ttc_step(st_, cfg, v, tp, 1, out, 4, ffi.NULL) == E
    bad = _native.view(img, "img")
    bad.stride = 39  # stride < width
    assert lib.vt_ttc_step(st_, cfg, bad, tp, 1, out, 4, n) == lib.VT_E_SIZE
    bad.w, bad.stride = 0, 0
    assert lib.vt_ttc_step(st_, cfg, bad, tp, 1, out, 4, n) == lib.VT_E_SIZE
    for f, val in (("block", 3), ("block", lib.VT_TTC_BLOCK + 1), ("grid", 1), ("lag", 0),
                   ("lag", lib.VT_TTC_HIST), ("radius", 0), ("radius", 17), ("max_sad", 0),
                   ("min_pairs", 0), ("min_pairs", lib.VT_TTC_MAX_PAIRS + 1), ("frame_dt", 0),
                   ("ttc_max", 0), ("margin_permille", 401), ("min_pair_px", 0),
                   ("anchor_radius", 6), ("anchor_radius", 49), ("anchor_radius", -1)):
        c2 = _native.ttc_cfg_default()
        setattr(c2, f, val)
        assert lib.vt_ttc_cfg_check(c2) == E, f
        assert lib.vt_ttc_step(st_, c2, v, tp, 1, out, 4, n) == E, f
    # bad boxes and duplicate ids: VT_E_ARG, and nothing stored
    for boxes, ids in (([[5, 5, 4, 9]], None), ([[0, 0, 9, 9], [1, 1, 5, 5]], [3, 3]), ([[0, 0, 9, 9]], [0])):
        t2 = _tracks(boxes, ids)
        assert lib.vt_ttc_step(st_, cfg, v, ffi.cast("vt_track_out *", t2.ctypes.data), len(t2), out, 4,
                               n) == E
    # any box, however far outside the frame or huge, is a no-op, not a crash
    huge = _tracks([[-2**31, -2**31, 2**31 - 1, 2**31 - 1], [-50, -50, -10, -10], [35, 25, 99, 99]])
    for _ in range(3):
        assert lib.vt_ttc_step(st_, cfg, v, ffi.cast("vt_track_out *", huge.ctypes.data), 3, out, 4, n) == 0
        assert n[0] == 3 and all(out[k].flags == 0 for k in range(3))


def test_guard_bytes_and_capacity():
    """Outputs beyond out_cap are never written; more ids than VT_TTC_TRACKS slots, or than
    out_cap, give VT_E_CAPACITY with the outputs filled as far as they go."""
    cap_slots = int(lib.VT_TTC_TRACKS)
    nt = cap_slots + 2
    frames, boxes = zoom_frames(5, [1.0] * 3)
    cfg = _native.ttc_cfg_default()
    cfg.lag = 1
    st_ = _native.ttc_new()
    tr = _tracks([boxes[0]] * nt)
    sentinel = 0x5A5A5A5A
    for f in frames:
        buf = np.full(nt + 2, sentinel, _native.TTC_OUT_DTYPE)
        n = ffi.new("int32_t *")
        s = lib.vt_ttc_step(st_, cfg, _native.view(f, "f"), ffi.cast("vt_track_out *", tr.ctypes.data), nt,
                            ffi.cast("vt_ttc_out *", buf.ctypes.data), 2, n)
        assert s == lib.VT_E_CAPACITY and n[0] == 2
        assert all(int(buf[k][name]) == sentinel for k in range(2, nt + 2) for name in buf.dtype.names)
        buf = np.full(nt + 2, sentinel, _native.TTC_OUT_DTYPE)
        st2 = _native.ttc_new()
        s = lib.vt_ttc_step(st2, cfg, _native.view(f, "f"), ffi.cast("vt_track_out *", tr.ctypes.data), nt,
                            ffi.cast("vt_ttc_out *", buf.ctypes.data), nt, n)
        assert s == lib.VT_E_CAPACITY and n[0] == cap_slots
        assert [int(buf[k]["id"]) for k in range(cap_slots)] == list(range(1, cap_slots + 1))
        assert all(int(buf[k][name]) == sentinel for k in range(cap_slots, nt + 2) for name in buf.dtype.names)


def test_frame_size_change_restarts():
    """A frame of another size forgets every track (documented restart), in C and oracle."""
    frames, boxes = zoom_frames(9, [0.8, 0.82, 0.84], w=200, h=150)
    for engine in ("c", "reference"):
        est = ScaleTtc(10, engine=engine, lag=1)
        est.step(frames[0], [(1, boxes[0])])
        (o,) = est.step(frames[1][:149, :], [(1, boxes[1])])
        assert o.scale is None and o.blocks == 0
        (o,) = est.step(frames[2][:149, :], [(1, boxes[2])])
        assert o.scale is not None


def test_absent_id_is_forgotten():
    frames, boxes = zoom_frames(11, [0.8, 0.82, 0.84])
    for engine in ("c", "reference"):
        est = ScaleTtc(10, engine=engine, lag=1)
        est.step(frames[0], [(1, boxes[0])])
        est.step(frames[1], [(2, boxes[1])])
        (o,) = est.step(frames[2], [(1, boxes[2])])
        assert o.blocks == 0 and o.scale is None


def test_c_matches_oracle_many_tracks():
    """Several tracks at once, ids coming and going, more ids than slots: the same outputs
    (counts equal, scales within the tolerance above) in C and in the oracle."""
    frames, boxes = zoom_frames(21, [0.7 * 1.02 ** k for k in range(7)], w=240, h=160)
    n_slots = int(lib.VT_TTC_TRACKS)
    c, r = ScaleTtc(10, lag=2), ScaleTtc(10, engine="reference", lag=2)
    tol = tol_s(c.params)
    seen = 0
    for k, (f, b) in enumerate(zip(frames, boxes)):
        ids = [i for i in range(1, n_slots + 3) if (i + k) % 5 != 0]
        tracks = [(i, [b[0] + i % 3, b[1] - i % 2, b[2] + i % 3, b[3] - i % 2]) for i in ids]
        a, o = c.step(f, tracks), r.step(f, tracks)
        assert [x.id for x in a] == [x.id for x in o]
        for x, y in zip(a, o):
            assert (x.blocks, x.matched, x.pairs) == (y.blocks, y.matched, y.pairs)
            assert (x.scale is None) == (y.scale is None)
            if x.scale is not None:
                assert abs(x.scale - y.scale) <= tol
                seen += 1
    assert seen >= 3


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_anchors_follow_a_box_jump(engine):
    """The box jumps 9 px down on one frame while the texture does not move (a detection
    frame's re-fit): with radius 4 the blocks are lost without anchors and found with them."""
    frames, boxes = zoom_frames(4, [0.8 * 1.01 ** k for k in range(4)], drift=(0.5, 0.0))
    boxes[3] = [boxes[3][0], boxes[3][1] + 9, boxes[3][2], boxes[3][3] + 9]
    got = {}
    for anchor in (0, 16):
        est = ScaleTtc(10, engine=engine, lag=1, radius=4, anchor_radius=anchor)
        got[anchor] = [est.step(f, [(1, b)])[0] for f, b in zip(frames, boxes)][-1]
    assert got[0].matched <= got[0].blocks // 4
    assert got[16].matched >= got[16].blocks * 3 // 4 and abs(got[16].scale - 1.01) < 0.005
