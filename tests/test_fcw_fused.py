"""The forward-collision warning on the fused TTC (2026-11-30, eighth session): vt_ttc_fuse
and vt_range_step_fused (c/camera.c), the pipeline's range stage after its block-scale TTC.

What is proven, and the tolerances:
  - vt_ttc_fuse is floor((P (1000 - w) + D w + 500) / 1000), exactly, against Python's
    integers; the float twin (reference.camera.ttc_fuse) within one Q16 unit (C's one
    rounding of a value the float forms to 2^-53 relative).
  - vt_range_step_fused with no block-scale TTC (NULL, or every entry negative) writes the
    same bytes as vt_range_step, on any approach.
  - With block-scale TTCs, C's warning follows its rule from its own outputs exactly: the
    oracle's state machine (reference.camera.fcw_step) fed the fused TTC formed from C's
    Q16 ttc_dist and the given Q16 points, with C's own gates (IN_PATH, DIST_VALID,
    CLOSING, lead class), gives the same bits every frame (every value is a Q16 number, so
    the threshold comparisons are exact in double).
  - The whole oracle (reference.camera.RangeTracker) warns on the same frames as C on a
    clean approach, where no TTC lies within the filters' difference of a threshold.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from pyvehtrack import _native
from pyvehtrack._native import ffi, lib
from pyvehtrack.camera import RangeEstimator
from pyvehtrack.reference import camera as rc

from test_camera import _rcfg as _rcfg_dt
from test_camera import approach, cam_params

Q = 65536


def _fuse_c(p, d, w):
    out = ffi.new("vt_q16 *", 12345)
    s = lib.vt_ttc_fuse(p, d, w, out)
    return s, int(out[0])


ttc_q16 = st.one_of(st.just(-1), st.integers(-2**31, -1), st.integers(0, 2**31 - 1))


@given(ttc_q16, ttc_q16, st.integers(0, 1000))
@settings(max_examples=400)
def test_ttc_fuse_is_its_formula(p, d, w):
    s, f = _fuse_c(p, d, w)
    assert s == lib.VT_OK
    if p < 0 and d < 0:
        assert f == -1
    elif p < 0:
        assert f == d
    elif d < 0:
        assert f == p
    else:
        assert f == (p * (1000 - w) + d * w + 500) // 1000
        ref = rc.ttc_fuse(p / Q, d / Q, w)
        assert abs(f / Q - ref) <= 1 / Q


def test_ttc_fuse_arguments():
    assert lib.vt_ttc_fuse(Q, Q, 300, ffi.NULL) == lib.VT_E_ARG
    for w in (-1, 1001, -2**31, 2**31 - 1):
        s, f = _fuse_c(Q, Q, w)
        assert s == lib.VT_E_ARG and f == 12345      # untouched
    # 0 is a TTC (collision now), not "unknown"
    assert _fuse_c(0, -1, 300) == (lib.VT_OK, 0)
    assert _fuse_c(-1, 0, 300) == (lib.VT_OK, 0)


def _rcfg(**kw):
    """tests/test_camera.py's range configuration at 10 Hz."""
    return _rcfg_dt(frame_dt=0.1, **kw)


def _rows(n_tracks, boxes_per_frame):
    arr = np.zeros(n_tracks, _native.TRACK_OUT_DTYPE)
    for k, (tid, b) in enumerate(boxes_per_frame):
        arr[k] = (tid, 2, *b, 0, 0)
    return arr


def _step_plain(st_c, rcf, c, ego, arr):
    """vt_range_step itself (not the fused entry point) into raw bytes."""
    n = len(arr)
    out = np.zeros(max(n, 1), _native.RANGE_OUT_DTYPE)
    n_out = ffi.new("int32_t *")
    a = np.ascontiguousarray(arr)
    s = lib.vt_range_step(st_c, rcf, c, 0, ego, ffi.cast("vt_track_out *", a.ctypes.data), n,
                          ffi.cast("vt_range_out *", out.ctypes.data), len(out), n_out)
    assert s == lib.VT_OK
    return out[: int(n_out[0])].tobytes()


@given(st.floats(8, 60), st.floats(-3, 15), st.floats(0, 1.5), st.integers(0, 2**31),
       st.sampled_from([-Q, 0, 20 * Q]), st.integers(0, 1000))
@settings(max_examples=40)
def test_no_block_ttc_is_range_step(z0, v, noise, seed, ego, w):
    p, c = cam_params()
    _rp, rcf = _rcfg()
    assume(z0 - v * 30 * 0.1 > 3)
    boxes = approach(30, z0, v, 0.1, p, noise, np.random.default_rng(seed))
    a, b, k = _native.range_new(), _native.range_new(), _native.range_new()
    for box in boxes:
        arr = _rows(1, [(3, box)])
        plain = _step_plain(a, rcf, c, ego, arr)
        assert _native.range_step(b, rcf, c, 0, ego, arr, None, w).tobytes() == plain
        assert _native.range_step(k, rcf, c, 0, ego, arr, [-1], w).tobytes() == plain


def _rule_run(z0, v, noise, seed, bias, w, ego, n=30):
    """One approach through vt_range_step_fused; every frame's fcw bits checked against
    reference.camera.fcw_step fed C's own fused TTC and gates (see the module's note:
    exact). The block-scale TTC given is the truth times `bias` (a lagging or leading
    scale), missing on every fourth frame. Returns whether it warned."""
    p, c = cam_params()
    rp, rcf = _rcfg()
    boxes = approach(n, z0, v, 0.1, p, noise, np.random.default_rng(seed))
    st_c = _native.range_new()
    fsm = rc.FcwState()
    ego_q = -Q if ego is None else int(round(ego * Q))
    warned = False
    for k, box in enumerate(boxes):
        z = z0 - v * k * 0.1
        pts = -1 if k % 4 == 3 else int(round(z / v * bias * Q))
        o = _native.range_step(st_c, rcf, c, 0, ego_q, _rows(1, [(3, box)]), [pts], w)[0]
        f = int(o["flags"])
        d = int(o["ttc_dist"]) if f & lib.VT_RANGE_TTC_DIST_VALID else -1
        _s, fused = _fuse_c(pts, d, w)
        gate = f & lib.VT_RANGE_IN_PATH and f & lib.VT_RANGE_DIST_VALID and fused >= 0
        want = rc.fcw_step(rp, fsm, fused / Q if gate else None, bool(f & lib.VT_RANGE_CLOSING),
                           int(o["lead_class"]))
        assert int(o["fcw"]) == want, (k, o, fused)
        warned = warned or bool(want & rc.FCW_WARNING)
    return warned


@given(st.floats(15, 45), st.floats(4, 15), st.floats(0, 1.0), st.integers(0, 2**31),
       st.floats(0.6, 1.6), st.integers(0, 1000), st.sampled_from([None, 0.0, 20.1]))
@settings(max_examples=60)
def test_c_warning_follows_its_rule(z0, v, noise, seed, bias, w, ego):
    assume(z0 - v * 30 * 0.1 > 3)
    _rule_run(z0, v, noise, seed, bias, w, ego)


@pytest.mark.parametrize("bias, w", [(0.8, 300), (1.2, 300), (1.0, 0), (1.0, 1000)])
def test_c_warning_follows_its_rule_and_warns(bias, w):
    """The same check on approaches that end under the threshold (25 m at 8 m/s for 2.7 s,
    noise 0.5 px, lead stopped), so the warning's onset itself is compared."""
    assert _rule_run(25.0, 8.0, 0.5, 7, bias, w, 0.0)


def test_fused_warning_on_a_clean_approach_c_and_oracle():
    """A stopped car approached at 10 m/s from 60 m, 10 Hz, no noise, ego speed 0 (lead
    stopped once the rate is known: 2.1 s + 0.7 s margin = 2.8 s). A block-scale TTC
    reading 20% long (a lagging scale) delays the warning against the distance/rate TTC
    alone by the frames the fused value takes to fall under the threshold; one reading 20%
    short brings it forward. C and the whole float oracle (RangeTracker with ttc_points)
    warn on the same frames."""
    p, c = cam_params()
    rp, rcf = _rcfg()
    boxes = approach(52, 60.0, 10.0, 0.1, p, 0.0, np.random.default_rng(0))
    onsets = {}
    for bias in (None, 1.2, 0.8):
        st_c, ref = _native.range_new(), rc.RangeTracker(p, rp)
        on_c = on_r = None
        for k, box in enumerate(boxes):
            z = 60.0 - k
            pts = None if bias is None else z / 10.0 * bias
            qp = None if pts is None else [int(round(pts * Q))]
            o = _native.range_step(st_c, rcf, c, 0, 0, _rows(1, [(5, box)]), qp, 300)[0]
            r = ref.step([(5, box)], 0.0, 0.0, ttc_points={5: pts}, fuse_permille=300)[0]
            if on_c is None and o["fcw"] & lib.VT_FCW_WARNING:
                on_c = k
            if on_r is None and r.fcw & rc.FCW_WARNING:
                on_r = k
        assert on_c is not None and on_c == on_r, (bias, on_c, on_r)
        onsets[bias] = on_c
    assert onsets[0.8] < onsets[None] < onsets[1.2], onsets


def test_range_step_fused_arguments():
    p, c = cam_params()
    _rp, rcf = _rcfg()
    st_c = _native.range_new()
    arr = _rows(1, [(5, [300, 200, 340, 260])])
    for w in (-1, 1001):
        with pytest.raises(_native.VtError):
            _native.range_step(st_c, rcf, c, 0, 0, arr, [Q], w)
    with pytest.raises(ValueError, match="one per track"):
        _native.range_step(st_c, rcf, c, 0, 0, arr, [Q, Q], 300)


def test_estimator_takes_block_ttcs():
    """RangeEstimator.step(ttc_points=...): checked (a clear error for a bad value), and both
    engines warn on the same frames on the clean approach with a short block-scale TTC."""
    from pyvehtrack.camera import Camera
    cam = Camera(700.0, 700.0, 319.5, 240.0, height_m=1.3, image_size=(640, 480))
    p = cam.params(640, 480)
    boxes = approach(25, 30.0, 10.0, 0.1, p, 0.0, np.random.default_rng(0))
    est = {e: RangeEstimator(cam, (640, 480), 10, engine=e) for e in ("c", "reference")}
    for e in est.values():
        with pytest.raises(ValueError, match=r"ttc_points\[5\]"):
            e.step([(5, boxes[0])], 0.0, ttc_points={5: -1.0})
        with pytest.raises(TypeError, match="ttc_points"):
            e.step([(5, boxes[0])], 0.0, ttc_points=[1.0])
        with pytest.raises(TypeError, match="track ids"):
            e.step([(5, boxes[0])], 0.0, ttc_points={"5": 1.0})
        with pytest.raises(ValueError, match="weight_permille"):
            e.step([(5, boxes[0])], 0.0, ttc_points={5: 1.0}, fuse_permille=2000)
    est = {e: RangeEstimator(cam, (640, 480), 10, engine=e) for e in ("c", "reference")}
    warns = {e: [] for e in est}
    for k, box in enumerate(boxes):
        for e, r in est.items():
            o = r.step([(5, box)], 0.0, ttc_points={5: (30.0 - k) / 10.0 * 0.8})[0]
            warns[e].append(o.warning)
    assert warns["c"] == warns["reference"] and any(warns["c"])


def test_pipeline_switch_c_and_oracle():
    """vt_pipeline_cfg.fcw_fused through the whole pipeline, C against the float oracle
    (reference.pipeline), on the rendered NHTSA scene of a stopped lead (seed 3, 30 fps,
    ego speed known), switch off (the default) and on. Tolerance: the pipeline's TTC in C
    is within 2.1% of the oracle's (tests/test_pipeline.py), and near the threshold (3.1 s,
    the class unknown) the true TTC falls one frame (1/30 s) per frame, so a crossing may
    move by up to 0.021 x 3.1 / (1/30) = 2 frames: the onsets agree within 2 frames and
    both engines warn on every frame after the later one. The switch moves the onset (the
    fused TTC is another number), and with it off the warning comes before the test's
    2.1 s."""
    from pyvehtrack.eval import synth_fcw as F
    from pyvehtrack.pipeline import Pipeline
    sc = F.make_fcw_scene("stopped", 3, fps=30)
    cam = F.camera_file_of(sc.sequence.camera)
    onset = {}
    for fused in (False, True):
        warns = {}
        for eng in ("c", "reference"):
            p = Pipeline(eng, camera=cam, fps=30, ego_speed=F.EGO_SPEED, detect_every=5,
                         ttc_points={"fcw_fused": fused})
            assert int(p._ccfg.fcw_fused) == fused
            warns[eng] = [any(t.warning for t in p.step(f).tracks) for f in sc.sequence.frames]
        on = {e: w.index(True) for e, w in warns.items()}
        assert abs(on["c"] - on["reference"]) <= 2, (fused, on)
        late = max(on.values())
        assert all(warns["c"][late:]) and all(warns["reference"][late:]), fused
        onset[fused] = on["c"]
    assert sc.ttc[onset[False]] >= F.NHTSA_TTC["stopped"]
    assert onset[True] != onset[False]
    with pytest.raises(TypeError, match="fcw_fused"):
        Pipeline("c", camera=cam, fps=30, ttc_points={"fcw_fused": 1})
