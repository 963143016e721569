"""Full-road hypothesis stage (c/windows.c) against its oracle
(pyvehtrack/reference/windows.py): window generation and NMS must agree EXACTLY
(every rule is an integer or exact-rational comparison on both sides: no tolerance is
justified), the camera road area exactly too; bad arguments give clear errors."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import _native
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.reference import windows as rw

MAXW, MAXH = int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)


def c_cfg(cfg: rw.WindowConfig):
    c = _native.win_cfg_default()
    c.veh_w_min_mm = round(cfg.veh_w_min_m * 1000)
    c.veh_w_max_mm = round(cfg.veh_w_max_m * 1000)
    c.n_sizes = len(cfg.sizes)
    for i, s in enumerate(cfg.sizes):
        c.size[i] = s
    c.step_q8 = round(cfg.step * 256)
    c.levels = cfg.levels
    c.lane_w_mm = round(cfg.lane_w_m * 1000)
    c.top_margin = cfg.top_margin
    return c


def c_cam(cam: rw.Camera):
    return _native.camera_min(cam.fx, cam.horizon_y, round(cam.height_m * 1000), cam.hood_y)


@st.composite
def scenes(draw):
    w = draw(st.integers(8, min(MAXW, 400)))
    h = draw(st.integers(8, min(MAXH, 300)))
    sizes = sorted(draw(st.sets(st.integers(4, 64), min_size=1, max_size=int(lib.VT_WIN_MAX_SIZES))))
    wmin = draw(st.integers(500, 3000))
    cfg = rw.WindowConfig(veh_w_min_m=wmin / 1000, veh_w_max_m=draw(st.integers(wmin, 4000)) / 1000,
                          sizes=tuple(sizes), step=draw(st.integers(16, 300)) / 256,
                          levels=draw(st.integers(1, min(4, int(lib.VT_WIN_MAX_LEVELS)))),
                          lane_w_m=draw(st.integers(2500, 4500)) / 1000, top_margin=draw(st.integers(0, 10)))
    cam = rw.Camera(fx=700.0, horizon_y=draw(st.integers(-20, h)), height_m=draw(st.integers(500, 3000)) / 1000,
                    hood_y=draw(st.integers(h // 2, h + 5)))
    return w, h, cfg, cam, draw(st.booleans()), draw(st.integers(0, 2 ** 31 - 1))


def test_default_config_matches_oracle():
    c = _native.win_cfg_default()
    d = rw.WindowConfig()
    assert lib.vt_win_cfg_check(c) == 0
    assert (c.veh_w_min_mm, c.veh_w_max_mm, c.step_q8, c.levels, c.lane_w_mm, c.top_margin) == \
        (1400, 2600, 64, 5, 3700, 2)
    assert tuple(c.size[i] for i in range(c.n_sizes)) == d.sizes and d.step == 64 / 256


@settings(max_examples=60)
@given(scenes())
def test_windows_and_road_match_oracle(scene):
    w, h, cfg, cam, use_road, seed = scene
    ccfg, ccam = c_cfg(cfg), c_cam(cam)
    ref_road = rw.road_from_camera(cam, cfg, w, h)
    croad = _native.road_from_camera(ccfg, ccam, w, h)
    assert bool(croad.valid) == ref_road[0]
    if ref_road[0]:
        assert (croad.y_top, croad.y_bottom) == ref_road[1:3]
        for name, ref in zip(("x_left", "x_right", "lane_width"), ref_road[3:]):
            assert np.array_equal(np.frombuffer(ffi.buffer(getattr(croad, name)), np.int16)[:h], ref), name
    road_c, road_r = None, None
    if use_road:
        # a random road: a band of rows and a span per row (shrink the camera road)
        rng = np.random.default_rng(seed)
        y0 = int(rng.integers(0, h))
        y1 = int(rng.integers(y0, h))
        xl = rng.integers(0, w, h)
        xr = np.minimum(w - 1, xl + rng.integers(0, w, h))
        road_r = (True, y0, y1, xl, xr, np.ones(h, np.int64))
        road_c = ffi.new("vt_road_area *")
        road_c.valid, road_c.y_top, road_c.y_bottom, road_c.height = 1, y0, y1, h
        for y in range(h):
            road_c.x_left[y], road_c.x_right[y], road_c.lane_width[y] = int(xl[y]), int(xr[y]), 1
    for level in range(cfg.levels):
        got = _native.windows_level(ccfg, ccam, road_c, w, h, level)
        ref = rw.windows_level(cfg, cam, road_r, w, h, level)
        assert np.array_equal(np.stack([got["level"], got["size"], got["x"], got["y"]], 1).reshape(-1, 4), ref), \
            f"level {level}"


def test_windows_1280x720_band_follows_geometry():
    """At 1280x720 with the TuSimple camera (horizon 376, 1.8 m), every window's width
    is that of a 1.4-2.6 m vehicle at its bottom row, and all levels are searched."""
    if MAXW < 1280 or MAXH < 720:
        pytest.skip("needs a build that takes 1280x720 frames")
    cfg, cam = rw.WindowConfig(), rw.Camera(714.0, 376, 1.8, 660)
    ccfg, ccam = c_cfg(cfg), c_cam(cam)
    road = _native.road_from_camera(ccfg, ccam, 1280, 720)
    seen_levels = set()
    for level in range(cfg.levels):
        for win in _native.windows_level(ccfg, ccam, road, 1280, 720, level):
            l, t, r, b = rw.window_box((win["level"], win["size"], win["x"], win["y"]))
            width = r - l + 1
            assert 1.4 * (b - 376) / 1.8 - 1e-9 <= width <= 2.6 * (b - 376) / 1.8 + 1e-9
            assert b < 660
            seen_levels.add(level)
    assert seen_levels == {0, 1, 2, 3}   # 32..45 px up to 256..360 px; level 4 (512 px) cannot fit above the hood


@st.composite
def box_sets(draw):
    n = draw(st.integers(0, 40))
    boxes = np.zeros(n, _native.SCORED_BOX_DTYPE)
    for i in range(n):
        l, t = draw(st.integers(-5, 60)), draw(st.integers(-5, 60))
        boxes[i] = (l, t, l + draw(st.integers(0, 30)), t + draw(st.integers(0, 30)),
                    draw(st.integers(-3, 3)), draw(st.integers(1, 2)))
    return boxes, draw(st.integers(0, 1000)), draw(st.integers(0, 1000))


@settings(max_examples=150)
@given(box_sets())
def test_nms_matches_oracle(case):
    boxes, iou, contain = case      # permille
    got = _native.nms(boxes, iou, contain)
    b = np.stack([boxes["left"], boxes["top"], boxes["right"], boxes["bottom"]], 1).reshape(-1, 4)
    keep = rw.nms(b, boxes["score"].tolist(), Fraction(iou, 1000), Fraction(contain, 1000))
    assert np.array_equal(got, boxes[keep])


def test_nms_cases():
    b = np.array([(0, 0, 9, 9, 5, 2), (1, 0, 10, 9, 9, 2), (30, 30, 39, 39, 1, 1), (2, 2, 5, 5, 7, 1)],
                 _native.SCORED_BOX_DTYPE)
    # IoU(0,1) = 90/110 > 0.5: the score-9 box wins; the small box inside it survives IoU 0.5
    # (16/100) but not a containment limit of 0.5.
    assert _native.nms(b, 500)["score"].tolist() == [9, 7, 1]
    assert _native.nms(b, 500, 500)["score"].tolist() == [9, 1]
    assert _native.nms(b, 1000)["score"].tolist() == [9, 7, 5, 1]   # nothing exceeds IoU 1
    assert len(_native.nms(b[:0], 500)) == 0
    # the compare is strict and exact at a permille boundary: IoU(0,1) = 90/110 = 818.18 permille
    assert _native.nms(b[:2], 818)["score"].tolist() == [9]
    assert _native.nms(b[:2], 819)["score"].tolist() == [9, 5]


def test_camera_distance():
    cam = _native.camera_min(714.15, 376, 1800, 720)
    d = ffi.new("int32_t *")
    assert lib.vt_camera_min_row_distance(cam, 376 + 36, d) == 0
    assert d[0] == round(round(714.15 * 16) * 1800 / 16 / 36)
    assert lib.vt_camera_min_row_distance(cam, 376, d) == lib.VT_E_ARG and d[0] == 0
    assert lib.vt_camera_min_row_distance(ffi.NULL, 400, d) == lib.VT_E_ARG


def test_bad_arguments():
    cfg = _native.win_cfg_default()
    cam = _native.camera_min(714.0, 100, 1800, 200)
    n = ffi.new("int32_t *")
    n[0] = 7
    assert lib.vt_windows_level(ffi.NULL, cam, ffi.NULL, 100, 100, 0, ffi.NULL, 0, n) == lib.VT_E_ARG and n[0] == 0
    assert lib.vt_windows_level(cfg, ffi.NULL, ffi.NULL, 100, 100, 0, ffi.NULL, 0, n) == lib.VT_E_ARG
    assert lib.vt_windows_level(cfg, cam, ffi.NULL, 100, 100, 0, ffi.NULL, 0, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_windows_level(cfg, cam, ffi.NULL, 100, 100, 0, ffi.NULL, 5, n) == lib.VT_E_ARG
    assert lib.vt_windows_level(cfg, cam, ffi.NULL, 100, 100, -1, ffi.NULL, 0, n) == lib.VT_E_ARG
    assert lib.vt_windows_level(cfg, cam, ffi.NULL, 100, 100, cfg.levels, ffi.NULL, 0, n) == lib.VT_E_ARG
    assert lib.vt_windows_level(cfg, cam, ffi.NULL, 0, 100, 0, ffi.NULL, 0, n) == lib.VT_E_SIZE
    assert lib.vt_windows_level(cfg, cam, ffi.NULL, MAXW + 1, 100, 0, ffi.NULL, 0, n) == lib.VT_E_SIZE
    road = _native.road_from_camera(cfg, cam, 100, 150)
    assert lib.vt_windows_level(cfg, cam, road, 100, 100, 0, ffi.NULL, 0, n) == lib.VT_E_SIZE   # wrong height
    # capacity: *n_out is the full count, only cap windows written (guard entries intact)
    assert lib.vt_windows_level(cfg, cam, ffi.NULL, 100, 150, 0, ffi.NULL, 0, n) == 0
    total = n[0]
    assert total > 3
    buf = np.full(5, -77, _native.WINDOW_DTYPE)
    assert lib.vt_windows_level(cfg, cam, ffi.NULL, 100, 150, 0, ffi.cast("vt_window *", buf.ctypes.data), 3, n) == 0
    assert n[0] == total and (buf[3:]["x"] == -77).all() and (buf[:3]["size"] > 0).all()
    bad = _native.win_cfg_default()
    bad.size[1] = bad.size[0]          # not increasing
    assert lib.vt_win_cfg_check(bad) == lib.VT_E_ARG
    bad = _native.win_cfg_default()
    bad.n_sizes = lib.VT_WIN_MAX_SIZES + 1
    assert lib.vt_win_cfg_check(bad) == lib.VT_E_CAPACITY
    bad = _native.win_cfg_default()
    bad.veh_w_min_mm = bad.veh_w_max_mm + 1
    assert lib.vt_win_cfg_check(bad) == lib.VT_E_ARG
    with pytest.raises(VtError, match="vt_camera_min_check"):
        _native.camera_min(714.0, 100, 50, 200)
    with pytest.raises(TypeError, match="hood_y"):
        _native.camera_min(714.0, 100, 1800, 200.0)
    with pytest.raises(ValueError, match="fx"):
        _native.camera_min(float("nan"), 100, 1800, 200)
    assert lib.vt_road_from_camera(cfg, cam, 100, 100, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_road_from_camera(cfg, cam, 100, MAXH + 1, ffi.new("vt_road_area *")) == lib.VT_E_SIZE
    # NMS: bad boxes and over-capacity move nothing
    sb = np.array([(5, 0, 4, 9, 1, 1)], _native.SCORED_BOX_DTYPE)
    with pytest.raises(VtError, match="vt_nms"):
        _native.nms(sb, 500)
    ok = np.array([(0, 0, 4, 9, 1, 1)], _native.SCORED_BOX_DTYPE)
    with pytest.raises(VtError, match="vt_nms"):
        _native.nms(ok, 1001)
    with pytest.raises(VtError, match="vt_nms"):
        _native.nms(ok, 500, -1)
    assert lib.vt_nms(ffi.NULL, 1, 500, 1000, n) == lib.VT_E_ARG and n[0] == 0
    assert lib.vt_nms(ffi.NULL, 0, 500, 1000, n) == 0 and n[0] == 0
    assert lib.vt_nms(ffi.cast("vt_scored_box *", ok.ctypes.data), lib.VT_MAX_NMS_BOXES + 1, 500, 1000, n) == \
        lib.VT_E_CAPACITY
