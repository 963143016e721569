"""Overtaking flow (c/flow.c) vs its float oracle (pyvehtrack/reference/flow.py),
on hypothesis-drawn frame pairs: shifted textures with a patch moving the other
way, odd sizes, padded strides, every pyramid level, both lateral areas.

Tolerances: 0. The SAD of a block is an exact integer sum on both sides, the
candidate order and tie rule are the same, the level images are equal to the LSB
(vt_pyr_down = cv2.pyrDown, tests/test_primitives.py), so every vector, SAD, flag
and blob must be equal. The mean flow is Q16 in C (sum * 2^level * 65536 / n,
rounded half away from zero); the oracle divides in float64: the quotient is
below 2^43 / 1 and a non-half-integer quotient sits at least 1/(2n) >= 2^-15 from a
rounding boundary, far above float64's 2^-24 error at that magnitude, so it rounds
to the same Q16 value. Hand-over boxes accumulate those exact Q16 values on both
sides (multiples of 2^-16 below 2^16: exact in float64), so they are equal too."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import _native, VtError
from pyvehtrack import flow as F
from pyvehtrack.reference import flow as rflow

from conftest import padded_copy

FIELDS = F.CFG_FIELDS


def _ns(cfg):
    return SimpleNamespace(**{f: int(getattr(cfg, f)) for f in FIELDS})


def _texture(rng, h, w, smooth):
    t = rng.integers(0, 256, (h, w)).astype(np.float64)
    for _ in range(smooth):  # a few box blurs: texture that block matching can lock on
        t = (t + np.roll(t, 1, 0) + np.roll(t, 1, 1) + np.roll(t, -1, 0)) / 4
    return np.clip(t, 0, 255).astype(np.uint8)


@st.composite
def scenes(draw):
    h = draw(st.integers(12, 67))
    w = draw(st.integers(12, 67))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    smooth = draw(st.integers(0, 2))
    bg = _texture(rng, h + 24, w + 24, smooth)
    bdx, bdy = draw(st.integers(-4, 4)), draw(st.integers(-2, 2))
    # A patch that moves against the background (the "overtaking vehicle").
    ph, pw = draw(st.integers(h // 4, h // 2 + 2)), draw(st.integers(w // 4, w // 2 + 2))
    # mostly at a border, where the lateral areas are
    px = draw(st.sampled_from([0, w - pw, draw(st.integers(0, w - pw))]))
    py = draw(st.integers(0, h - ph))
    pdx, pdy = draw(st.integers(-4, 4)), draw(st.integers(-2, 2))
    patch = _texture(rng, ph, pw, smooth)
    noisy = draw(st.booleans())   # noise on top, so the change gate has work to do
    frames = []
    for t in range(3):
        f = bg[12 - t * bdy:12 - t * bdy + h, 12 - t * bdx:12 - t * bdx + w].copy()
        qx, qy = min(max(px + t * pdx, 0), w - pw), min(max(py + t * pdy, 0), h - ph)
        f[qy:qy + ph, qx:qx + pw] = patch
        if noisy:
            f = np.clip(f.astype(np.int16) + rng.integers(-6, 7, f.shape), 0, 255).astype(np.uint8)
        pad = draw(st.integers(0, 5))
        frames.append(padded_copy(f, pad) if pad else f)
    cfg = dict(
        # level 0 most often: a 67 px frame has only 17 px left at level 2
        level=draw(st.sampled_from([0, 0, 0, 1, 2])), sides=draw(st.integers(1, 3)),
        # permille: any value, not only the old whole percents
        strip_permille=draw(st.sampled_from([1, 200, 255, 300, 400, 500])),
        top_permille=draw(st.integers(0, 400)), bottom_permille=draw(st.integers(600, 1000)),
        cell=draw(st.integers(2, 6)),
        search_x=draw(st.integers(0, 4)), search_y=draw(st.integers(0, 2)),
        diff_thresh=draw(st.integers(0, 40)), diff_min_permille=draw(st.integers(0, 600)),
        min_inward=draw(st.integers(0, 2)), max_mag=draw(st.integers(0, 8)),
        max_sad_per_px=draw(st.integers(0, 80)), min_blob_cells=draw(st.integers(1, 4)),
        min_texture=draw(st.sampled_from([0, 0, 1, 3, 8])), min_age=draw(st.integers(1, 3)),
        back_tol=draw(st.integers(-1, 2)))
    return frames, cfg


def _hyps_c(hyps):
    return [((int(h["left"]), int(h["top"]), int(h["right"]), int(h["bottom"])), int(h["side"]),
             int(h["kind"]), int(h["id"]), int(h["cells"]), int(h["flow_x"]), int(h["flow_y"]), int(h["age"]),
             int(h["cy"]))
            for h in hyps]


def _hyps_ref(hyps):
    return [(h.box, h.side, h.kind, h.id, h.cells, round(h.flow[0] * 65536), round(h.flow[1] * 65536), h.age, h.cy)
            for h in hyps]


@settings(max_examples=60)
@given(scene=scenes())
def test_flow_vectors_and_blobs_exact(scene):
    frames, kw = scene
    cfg = F.make_cfg(**kw)
    st_ = _native.flow_new()
    ref = rflow.FlowOracle(_ns(cfg), int(_native.lib.VT_FLOW_MAX_HYPS), int(_native.lib.VT_FLOW_MAX_SEEDS),
                           int(_native.lib.VT_FLOW_MAX_BLOBS))
    ready, hyps, _ = _native.flow_step(st_, cfg, frames[0])
    assert not ready and len(hyps) == 0          # first frame: a documented no-op
    r_ready, r_hyps = ref.step(np.ascontiguousarray(frames[0]))
    assert not r_ready and r_hyps == []
    for f in frames[1:]:
        ready, hyps, stats = _native.flow_step(st_, cfg, f)
        r_ready, r_hyps = ref.step(np.ascontiguousarray(f))
        assert ready and r_ready
        for side in (0, 1):
            x0, y0, dx, dy, flag, sad = _native.flow_field(st_, side)
            ar = ref.areas[side]
            assert (dx.shape, x0, y0) == (ar.dx.shape, ar.x0, ar.y0) or ar.dx.size == dx.size == 0
            np.testing.assert_array_equal(flag, ar.flag)
            np.testing.assert_array_equal(dx, ar.dx)
            np.testing.assert_array_equal(dy, ar.dy)
            np.testing.assert_array_equal(sad, ar.sad)
        assert stats["cells_accepted"] == sum(int(((a.flag & 2) > 0).sum()) for a in ref.areas)
        assert stats["cells_computed"] == sum(int(((a.flag & 1) > 0).sum()) for a in ref.areas)
        assert _hyps_c(hyps) == _hyps_ref(r_hyps)


def _moving_scene(n, h=64, w=96, step=3, seed=0):
    """A textured background drifting outward-left and a textured 'vehicle' moving
    right across the left area."""
    rng = np.random.default_rng(seed)
    bg = _texture(rng, h, w + 4 * n, 1)
    car = _texture(rng, 24, 20, 1)
    frames = []
    for t in range(n):
        f = bg[:, 2 * t: 2 * t + w].copy()
        x = 2 + step * t
        f[30:54, x:x + 20] = car
        frames.append(f)
    return frames


def test_handover_exact_and_follows_the_box():
    frames = _moving_scene(8)
    cfg = F.make_cfg(level=1, cell=4, search_x=4, search_y=2, seed_min_visible_permille=100)
    st_ = _native.flow_new()
    ref = rflow.FlowOracle(_ns(cfg), int(_native.lib.VT_FLOW_MAX_HYPS), int(_native.lib.VT_FLOW_MAX_SEEDS),
                            int(_native.lib.VT_FLOW_MAX_BLOBS))
    _native.flow_step(st_, cfg, frames[0])
    ref.step(frames[0])
    tid = _native.flow_seed(st_, cfg, (2, 30, 21, 53))
    assert tid == ref.seed((2, 30, 21, 53)) == 1
    for t, f in enumerate(frames[1:], 1):
        _, hyps, _ = _native.flow_step(st_, cfg, f)
        _, r_hyps = ref.step(f)
        assert _hyps_c(hyps) == _hyps_ref(r_hyps)
        ho = [h for h in hyps if h["kind"] == _native.lib.VT_FLOW_KIND_HANDOVER]
        assert len(ho) == 1 and ho[0]["id"] == tid
        # the car moves 3 px/frame; the box must stay within one level pixel + rounding
        assert abs(int(ho[0]["left"]) - (2 + 3 * t)) <= 3, (t, ho)
    _native.flow_unseed(st_, tid)
    with pytest.raises(VtError, match="vt_flow_unseed"):
        _native.flow_unseed(st_, tid)


def test_overtaking_detected_background_rejected():
    """The patch moving inward on the left is reported; the outward-drifting
    background alone is not (direction filter)."""
    frames = _moving_scene(4)
    det = F.OvertakingDetector(level=0, cell=4, search_x=5, search_y=2)
    assert det.step(frames[0]).hyps == []
    assert det.step(frames[1]).hyps == []       # age 1, 2: not yet (min_age 3)
    assert det.step(frames[2]).hyps == []
    res = det.step(frames[3])
    assert res.ready and len(res.hyps) >= 1
    h = res.hyps[0]
    assert h.age == 3
    assert h.side == "left" and h.kind == "overtaking" and h.flow[0] > 0
    assert h.box[0] <= 8 and h.box[2] >= 12 and 24 <= h.box[1] <= 36
    # background only: no car
    rng = np.random.default_rng(3)
    bg = _texture(rng, 64, 120, 1)
    det2 = F.OvertakingDetector(level=0, cell=4, search_x=5, search_y=2, min_age=1)
    det2.step(bg[:, 0:96].copy())
    assert det2.step(bg[:, 2:98].copy()).hyps == []


def _diagonal_patches(t, step=2):
    """Flat grey frame (no texture: no cell is searched) with two textured 4x4
    patches moving inward (+x) by `step` px per frame, cell-aligned at t = 1 and
    touching only at a corner: cells (1, 1) and (2, 2) of a 4 px grid."""
    rng = np.random.default_rng(7)
    f = np.full((32, 48), 128, np.uint8)
    a, b = rng.integers(0, 256, (4, 4)), rng.integers(0, 256, (4, 4))
    x = 4 + step * (t - 1)
    f[4:8, x:x + 4] = a
    f[8:12, x + 4:x + 8] = b
    return f


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_blobs_are_8_connected(engine):
    """Two accepted cells that touch only at a corner are one blob (flow.h: 8-connected
    components; a dark car gives accepted cells on its edges and lights that often meet
    only diagonally). With min_blob_cells 2, 4-connected labelling would report nothing."""
    det = F.OvertakingDetector(engine, level=0, cell=4, search_x=3, search_y=1, min_age=1,
                               min_blob_cells=2, strip_permille=500, top_permille=0)
    det.step(_diagonal_patches(0))
    res = det.step(_diagonal_patches(1))
    assert res.ready and len(res.hyps) == 1, res.hyps
    h = res.hyps[0]
    assert (h.cells, h.box, h.flow) == (2, (4, 4, 11, 11), (2.0, 0.0))


def test_bad_inputs():
    cfg = F.make_cfg()
    st_ = _native.flow_new()
    f = np.zeros((40, 50), np.uint8)
    # NULLs and a bad cfg
    out = _native.ffi.new("vt_flow_result *")
    v = _native.view(f, "f")
    assert _native.lib.vt_flow_step(_native.ffi.NULL, cfg, v, out) == _native.lib.VT_E_ARG
    assert _native.lib.vt_flow_step(st_, _native.ffi.NULL, v, out) == _native.lib.VT_E_ARG
    assert _native.lib.vt_flow_step(st_, cfg, _native.ffi.NULL, out) == _native.lib.VT_E_ARG
    assert _native.lib.vt_flow_step(st_, cfg, v, _native.ffi.NULL) == _native.lib.VT_E_ARG
    assert _native.lib.vt_flow_init(_native.ffi.NULL) == _native.lib.VT_E_ARG
    assert _native.lib.vt_flow_reset(_native.ffi.NULL) == _native.lib.VT_E_ARG
    assert _native.lib.vt_flow_cfg_default(_native.ffi.NULL) == _native.lib.VT_E_ARG
    assert _native.lib.vt_flow_cfg_check(_native.ffi.NULL) == _native.lib.VT_E_ARG
    for k, bad in [("level", 3), ("level", -1), ("sides", 0), ("sides", 4), ("cell", 1),
                   ("cell", 33), ("strip_permille", 0), ("strip_permille", 501),
                   ("top_permille", 600), ("diff_min_permille", 1001),
                   ("seed_min_visible_permille", -1), ("search_x", -1), ("min_blob_cells", 0),
                   ("diff_thresh", 256), ("max_sad_per_px", -1)]:
        kw = {k: bad}
        if k == "top_permille":
            kw["bottom_permille"] = 600
        with pytest.raises(VtError, match="vt_flow_cfg_check"):
            F.make_cfg(**kw)
    with pytest.raises(TypeError, match="nonsense"):
        F.make_cfg(nonsense=1)
    with pytest.raises(TypeError, match="level"):
        F.make_cfg(level=1.5)
    with pytest.raises(ValueError, match="sides"):
        F.make_cfg(sides="middle")
    # zero sizes and stride < width, through the C checks
    v0 = _native.ffi.new("vt_image_u8 *")
    v0.px = _native.ffi.cast("uint8_t *", f.ctypes.data)
    for w, h, s in [(0, 10, 10), (10, 0, 10), (10, 10, 9), (-1, 5, 5)]:
        v0.w, v0.h, v0.stride = w, h, s
        assert _native.lib.vt_flow_step(st_, cfg, v0, out) == _native.lib.VT_E_SIZE
        assert out.n == 0 and out.ready == 0
    # seeding before any frame
    with pytest.raises(VtError, match="vt_flow_seed"):
        _native.flow_seed(st_, cfg, (1, 1, 5, 5))
    # first frame: a no-op; then a frame of another size: VT_E_SIZE, state kept
    ready, hyps, _ = _native.flow_step(st_, cfg, f)
    assert not ready and len(hyps) == 0
    with pytest.raises(VtError, match="vt_flow_step.*size"):
        _native.flow_step(st_, cfg, np.zeros((41, 50), np.uint8))
    ready, _, _ = _native.flow_step(st_, cfg, f)
    assert ready  # the stored frame survived the refused one
    # seed boxes outside the frame or inverted
    for box in [(60, 1, 70, 5), (-10, 1, -1, 5), (5, 5, 4, 9), (1, 45, 5, 50)]:
        with pytest.raises(VtError, match="vt_flow_seed"):
            _native.flow_seed(st_, cfg, box)
    ids = [_native.flow_seed(st_, cfg, (1, 1, 9, 9)) for _ in range(int(_native.lib.VT_FLOW_MAX_SEEDS))]
    assert len(set(ids)) == len(ids)
    with pytest.raises(VtError, match="capacity"):
        _native.flow_seed(st_, cfg, (1, 1, 9, 9))
    # reset: a first frame again, hand-over tracks gone
    _native.flow_reset(st_)
    ready, _, _ = _native.flow_step(st_, cfg, np.zeros((41, 50), np.uint8))
    assert not ready
    # Python-level checks
    det = F.OvertakingDetector()
    with pytest.raises(TypeError, match="frame"):
        det.step(f.astype(np.float32))
    with pytest.raises(TypeError, match="frame"):
        det.step([[1, 2]])
    with pytest.raises(ValueError, match="frame"):
        det.step(np.zeros((4, 4, 2), np.uint8))
    with pytest.raises(ValueError, match="engine"):
        F.OvertakingDetector("gpu")
    ref = F.OvertakingDetector("reference")
    ref.step(f)
    with pytest.raises(ValueError, match="frame"):
        ref.step(np.zeros((41, 50), np.uint8))


def test_capacity_errors():
    """A frame whose level image exceeds the state's buffers is refused, not clipped."""
    lib = _native.lib
    w, h = int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)
    if w * h <= int(lib.VT_FLOW_MAX_PIXELS):
        pytest.skip("level 0 of the largest frame fits this build's flow buffers")
    cfg = F.make_cfg(level=0)
    st_ = _native.flow_new()
    with pytest.raises(VtError, match="capacity"):
        _native.flow_step(st_, cfg, np.zeros((h, w), np.uint8))


def test_old_percent_names_convert_exactly_with_a_warning():
    """Issue 10 item 6: the flow fractions became permille (x 10, exact); the old percent
    names are still taken by make_cfg (and so by Pipeline(flow={...})) with a warning."""
    import warnings
    with pytest.warns(DeprecationWarning, match="strip_permille"):
        old = F.make_cfg(strip_percent=20, top_percent=35, bottom_percent=90, diff_min_percent=30,
                         seed_min_visible=15)
    new = F.make_cfg(strip_permille=200, top_permille=350, bottom_permille=900, diff_min_permille=300,
                     seed_min_visible_permille=150)
    assert [getattr(old, f) for f in F.CFG_FIELDS] == [getattr(new, f) for f in F.CFG_FIELDS]
    with pytest.raises(TypeError, match="not both"):
        F.make_cfg(strip_percent=20, strip_permille=200)
    with pytest.warns(DeprecationWarning), pytest.raises(VtError, match="vt_flow_cfg_check"):
        F.make_cfg(strip_percent=51)                      # 510 permille: out of range, as before
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        F.make_cfg(strip_permille=300)

