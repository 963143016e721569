"""The CNN's bands placed at the camera's horizon (vt_cnn_cfg_at_horizon, cnn.h; its twin
pyvehtrack.reference.cnn.at_horizon; vt_pipeline_set_cnn places them at the road camera's).

Tolerance: exact. The shift is an integer (d = floor(((horizon_q16 - 30037) 1000 + 32768) / 65536)
permille), the bands integers in permille, so C and the twin agree field for field; the pipeline's
boxes equal pyvehtrack.cnn.detect_frame's with the placed cfg, box for box (test_pipeline_cnn's
rule), on both engines.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyvehtrack import Pipeline
from pyvehtrack import cnn as C
from pyvehtrack._native import ffi, lib
from pyvehtrack.fullroad import Camera
from pyvehtrack.reference import cnn as R
from test_pipeline_cnn import _c_pipeline, _got, scene, tiny_model

SHIPPED = C.CnnConfig(first_level=0, n_levels=5, thr_offset=2, cap_per_level=64, nms_iou_permille=500,
                      nms_contain_permille=700, l0_top_permille=380, l0_bottom_permille=640,
                      stretch_tail_permille=5, up_top_permille=450, up_bottom_permille=530,
                      up_left_permille=350, up_right_permille=650)
BANDS = ("l0_top_permille", "l0_bottom_permille", "up_top_permille", "up_bottom_permille")


def _full(cfg):
    """cfg with the core's defaults filled in (the twin takes every field, as the pipeline gives it)."""
    return C.CnnConfig.from_c(cfg.c())


def _bands(cfg):
    return tuple(int(getattr(cfg, k) if not isinstance(cfg, dict) else cfg[k]) for k in BANDS)


def test_constant_is_the_default_road_camera():
    rc = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(rc) == lib.VT_OK
    assert int(lib.VT_CNN_REF_HORIZON_Q16) == rc.road_camera.horizon_q16 == R.REF_HORIZON_Q16
    assert round(Camera().horizon_frac * 65536) == R.REF_HORIZON_Q16


@pytest.mark.parametrize("horizon_q16, want", [
    (30037, (380, 640, 450, 530)),        # the reference camera: unchanged
    # Udacity's camera file: cy 388.1 + fy tan(1.61 deg) = 420.6 of 720 -> 38285;
    # d = floor((8248 * 1000 + 32768) / 65536) = floor(126.35) = 126
    (38285, (506, 766, 576, 656)),
    # d = floor(35499032768 / 65536 ... ) = 542: both bands stop at the bottom edge, heights kept
    (65536, (740, 1000, 920, 1000)),
    (-65536, (0, 260, 0, 80)),            # d = -1458: stopped at the top edge
    (30004, (379, 639, 449, 529)),        # -33 000 + 32 768 = -232: floor -> -1
    (30005, (380, 640, 450, 530)),        # -32 000 + 32 768 = 768: 0
    # exact halves: (hz - 30037) 1000 / 65536 = +-62.5 for hz - 30037 = +-4096: half up -> 63, -62
    (30037 + 4096, (443, 703, 513, 593)),
    (30037 - 4096, (318, 578, 388, 468)),
])
def test_hand_computed(horizon_q16, want):
    got = C.at_horizon(SHIPPED, horizon_q16)
    assert _bands(got) == want
    assert _bands(R.at_horizon(SHIPPED, horizon_q16)) == want
    # everything else copied
    rest = {f.name for f in dataclasses.fields(C.CnnConfig)} - set(BANDS)
    assert all(getattr(got, k) == getattr(SHIPPED, k) for k in rest)


def test_band_off_stays_off_and_whole_frame_stays_whole():
    cfg = C.CnnConfig(first_level=0, n_levels=2)     # level 0 on the whole frame, no upsampled band
    for hz in (-65536, 0, 30037, 50000, 65536):
        got = C.at_horizon(cfg, hz)
        assert _bands(got) == (0, 1000, 0, 0) and not C.up_band_on(got)
        assert R.at_horizon(_full(cfg), hz)["up_bottom_permille"] == 0


@st.composite
def cfgs(draw):
    t0 = draw(st.integers(0, 999))
    b0 = draw(st.integers(t0 + 1, 1000))
    kw = dict(first_level=draw(st.integers(0, 2)), n_levels=draw(st.integers(1, 3)), cap_per_level=8,
              l0_top_permille=t0, l0_bottom_permille=b0, thr_offset=draw(st.integers(-5, 5)))
    if draw(st.booleans()):
        ut = draw(st.integers(0, 999))
        ul = draw(st.integers(0, 999))
        kw.update(up_top_permille=ut, up_bottom_permille=draw(st.integers(ut + 1, 1000)),
                  up_left_permille=ul, up_right_permille=draw(st.integers(ul + 1, 1000)))
    return C.CnnConfig(**kw)


@settings(max_examples=300, deadline=None)
@given(cfgs(), st.integers(-65536, 65536))
def test_c_equals_twin_and_keeps_heights(cfg, hz):
    got = C.at_horizon(cfg, hz)
    twin = R.at_horizon(_full(cfg), hz)
    assert {f.name: getattr(got, f.name) for f in dataclasses.fields(got)} == twin
    got.c()   # still a valid cfg
    d = ((hz - 30037) * 1000 + 32768) // 65536
    pairs = [("l0_top_permille", "l0_bottom_permille")] + ([("up_top_permille", "up_bottom_permille")]
                                                          if C.up_band_on(cfg) else [])
    for t, b in pairs:
        span = getattr(cfg, b) - getattr(cfg, t)
        assert getattr(got, b) - getattr(got, t) == span and 0 <= getattr(got, t) and getattr(got, b) <= 1000
        if 0 <= getattr(cfg, t) + d <= 1000 - span:   # inside the frame: moved by exactly d
            assert getattr(got, t) == getattr(cfg, t) + d
    assert got.up_left_permille == (cfg.up_left_permille or 0)
    assert got.up_right_permille == (cfg.up_right_permille or 0)


def test_bad_arguments_leave_out_unwritten():
    good = SHIPPED.c()
    bad = ffi.new("vt_cnn_cfg *", good[0])
    bad.up_top_permille = 600    # top >= bottom
    out = ffi.new("vt_cnn_cfg *")
    out.n_levels = 77
    for args in ((ffi.NULL, 0, out), (good, 0, ffi.NULL), (bad, 0, out), (good, 65537, out),
                 (good, -65537, out), (good, 2**31 - 1, out), (good, -2**31, out)):
        assert lib.vt_cnn_cfg_at_horizon(*args) == lib.VT_E_ARG
        assert out.n_levels == 77
    # out may be cfg itself
    io = ffi.new("vt_cnn_cfg *", good[0])
    assert lib.vt_cnn_cfg_at_horizon(io, 38285, io) == lib.VT_OK and io.up_top_permille == 576


def test_python_errors():
    with pytest.raises(ValueError, match="horizon_q16"):
        C.at_horizon(SHIPPED, 65537)
    with pytest.raises(TypeError, match="horizon_q16"):
        C.at_horizon(SHIPPED, True)
    with pytest.raises(ValueError, match="horizon_q16"):
        C.at_horizon(SHIPPED, 0.5)
    with pytest.raises(TypeError, match="cfg"):
        C.at_horizon({"n_levels": 1}, 0)
    with pytest.raises(ValueError, match="up_"):
        C.at_horizon(dataclasses.replace(SHIPPED, up_top_permille=900), 0)


# a tiny network with both bands on a 320x180 scene: level 0 on rows 300-700, the 2x band
# on rows 350-560 x columns 200-800 (a 2x image of 384 x 76, inside every build's maxima)
BAND_CFG = C.CnnConfig(first_level=0, n_levels=2, thr_offset=-30, cap_per_level=16, l0_top_permille=300,
                       l0_bottom_permille=700, up_top_permille=350, up_bottom_permille=560,
                       up_left_permille=200, up_right_permille=800)


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_pipeline_places_the_bands_at_its_road_camera(engine):
    """A road camera whose horizon is 0.6 of the height (39322 in Q16, d = 142 permille): the
    pipeline's boxes are detect_frame's with the placed cfg, and not those of the cfg as given
    (else the test could not tell); the default camera gives the cfg as given."""
    m = tiny_model()
    gray = scene()
    cam = Camera(horizon_frac=0.6)
    hz = int(round(0.6 * 65536))
    placed = C.at_horizon(BAND_CFG, hz)
    assert _bands(placed) == (442, 842, 492, 702)
    want = [((int(r[0]), int(r[1]), int(r[2]), int(r[3])), "classifier", int(r[4]) * m.heat_scale_q16 / 65536)
            for r in C.detect_frame(m, gray, placed)[0][:int(lib.VT_MAX_BOXES)]]
    as_given = [((int(r[0]), int(r[1]), int(r[2]), int(r[3])), "classifier",
                 int(r[4]) * m.heat_scale_q16 / 65536) for r in C.detect_frame(m, gray, BAND_CFG)[0]]
    assert want and want != as_given, "the scene does not tell the placed bands from the given ones"
    pipe = Pipeline(engine, model=m, cnn_cfg=BAND_CFG, road_camera=cam, sources=("classifier",), road="fixed",
                    detect_every=1, track=False, cnn_hood_min_width_mm=0)   # every box (the hood rule aside)
    assert _got(pipe.step(gray)) == want
    pipe = Pipeline(engine, model=m, cnn_cfg=BAND_CFG, sources=("classifier",), road="fixed",
                    detect_every=1, track=False, cnn_hood_min_width_mm=0)
    assert _got(pipe.step(gray)) == as_given[:int(lib.VT_MAX_BOXES)]


def test_set_cnn_keeps_the_placed_cfg_and_sizes_the_work_by_it():
    """vt_pipeline_set_cnn copies the placed cfg (p->cnn_cfg); a buffer one byte short of the
    placed cfg's vt_cnn_frame_work_bytes is VT_E_CAPACITY from the step."""
    m = tiny_model()
    cm = m.c_model()[0]
    gray = scene()
    p = _c_pipeline(39322)
    placed = C.at_horizon(BAND_CFG, 39322)
    need = C.frame_work_bytes(m, gray.shape[1], gray.shape[0], placed)
    work = np.zeros(need, np.uint8)
    pw = ffi.cast("uint8_t *", work.ctypes.data)
    assert lib.vt_pipeline_set_cnn(p, cm, BAND_CFG.c(), pw, need - 1) == lib.VT_OK
    assert _bands(p.cnn_cfg) == _bands(placed)
    ws = ffi.new("vt_pipe_cls_ws *")
    assert lib.vt_pipeline_set_cls_ws(p, ws, ffi.NULL) == lib.VT_OK
    from pyvehtrack import _native
    v = _native.view(gray, "img")
    out = ffi.new("vt_frame_out *")
    assert lib.vt_pipeline_step(p, v, out) == lib.VT_E_CAPACITY
    assert lib.vt_pipeline_set_cnn(p, cm, BAND_CFG.c(), pw, need) == lib.VT_OK
    assert lib.vt_pipeline_set_cls_ws(p, ws, ffi.NULL) == lib.VT_OK
    assert lib.vt_pipeline_step(p, v, out) == lib.VT_OK and out.n_boxes > 0
