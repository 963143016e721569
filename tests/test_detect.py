"""Vehicle detection stages (thesis sec. 2.4.2): shadow hypotheses (c/shadow.c) and
vertical-edge verification (c/verify.c), C against the float oracle
(pyvehtrack/reference/shadow.py, verify.py), on drawn road scenes and on real KITTI
frames; bad frames and bad arguments; guard bytes; the `pyvehtrack detect` command.

Tolerance, C vs oracle: 0 (exact equality of hypotheses and boxes). Every decision in
both is a comparison of exact integers: Sobel of 8-bit pixels is an integer in C and
exact in float32 in OpenCV (|value| <= 1020); the adaptive threshold compares
I * 256 with median * 256 - k_q8 * MAD (median and MAD are sample values, k_q8 / 256
is exact in binary); width and overlap tests are integer products; projections are
counts. So rows agree to 0 px and boxes to IoU 1.0, which is stricter than the
issue's "rows within 1 px, IoU >= 0.95" (and, on real frames, ">= 0.9").
"""
from __future__ import annotations

import csv
import dataclasses
import json
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, strategies as st

from pyvehtrack import _native
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.cli import main as cli_main
from pyvehtrack.detector import (DetectConfig, Detector, FixedRoad, c_default_config,
                                 fit_size)
from pyvehtrack.reference import shadow as rs
from pyvehtrack.reference import verify as rv
from pyvehtrack.reference.shadow import RoadArea, ShadowConfig, trapezoid_road
from pyvehtrack.reference.verify import VerifyConfig

from conftest import padded_copy

DATA = Path(__file__).resolve().parent / "data"
CAPS = dict(max_active=int(lib.VT_MAX_SHADOW_ACTIVE), max_cand=int(lib.VT_MAX_SHADOW_CAND))


# ---------------------------------------------------------------- scenes
def draw_scene(h, w, seed, n_cars, noise, polarity=rs.DARK_ABOVE):
    """A flat road in perspective (a trapezoid toward a vanishing point) of one gray,
    background of another, and n_cars vehicles drawn far to near: a body brighter than
    the road, 0.5-0.85 lane widths wide and as high as wide (aspect 1 is the truth),
    with a dark band (its shadow) along its bottom rows for DARK_ABOVE (the band's lower
    border is the car's bottom) or right below its bottom row for DARK_BELOW. Returns
    the image, the road area given to the detector and the drawn boxes (inclusive)."""
    rng = np.random.default_rng(seed)
    road_g = int(rng.integers(90, 200))
    img = np.full((h, w), int(rng.integers(10, 246)), np.float64)
    vp = (float(rng.uniform(0.35, 0.65)), float(rng.uniform(0.2, 0.45)))
    bottom = (float(rng.uniform(-0.2, 0.15)), float(rng.uniform(0.85, 1.2)))
    lane_bottom = float(rng.uniform(0.3, 0.6))
    road = trapezoid_road(h, w, vp=vp, bottom=bottom, lane_bottom=lane_bottom, top_margin=2)
    for y in range(road.y_top, h):
        a, b = max(0, int(road.x_left[y])), min(w - 1, int(road.x_right[y]))
        img[y, a:b + 1] = road_g
    cars = []
    for _ in range(n_cars):
        yb = int(rng.integers(road.y_top + (h - road.y_top) // 3, h))
        lw = int(road.lane_width[yb])
        cw = int(lw * rng.uniform(0.5, 0.85))
        if cw < 6:
            continue
        xc = rng.uniform(road.x_left[yb] + cw / 2, max(road.x_left[yb] + cw / 2, road.x_right[yb] - cw / 2))
        l = int(np.clip(xc - cw / 2, 0, w - 1))
        r = int(np.clip(l + cw - 1, 0, w - 1))
        t = max(0, yb - cw + 1)
        cars.append((yb, l, t, r))
    boxes = []
    for yb, l, t, r in sorted(cars):          # far (small yb) first: near cars occlude
        body = min(255, road_g + int(rng.integers(25, 60)))
        dark = max(0, road_g - int(rng.integers(45, 85)))
        band = max(2, (yb - t + 1) // 6)
        img[t:yb + 1, l:r + 1] = body
        if polarity == rs.DARK_ABOVE:
            img[yb - band + 1:yb + 1, l:r + 1] = dark         # shadow at the body's bottom
        else:
            y2 = min(h - 1, yb + band)
            img[yb + 1:y2 + 1, l:r + 1] = dark                # shadow below the body
        boxes.append((l, t, r, yb))
    if noise > 0:
        img += rng.normal(0.0, noise, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8), road, boxes


def c_shadow(gray, road, cfg: ShadowConfig, cap=None, stride_pad=0):
    st_ = ffi.new("vt_shadow_state *")
    c = _native.shadow_cfg_default()
    for f in dataclasses.fields(ShadowConfig):
        setattr(c, f.name, getattr(cfg, f.name))
    cap = int(lib.VT_MAX_HYPOTHESES) if cap is None else cap
    out = np.zeros((cap + 4, 3), np.int32)
    g = padded_copy(gray, stride_pad) if stride_pad else gray
    n = _native.shadow_find(st_, c, g, _native.road_area(road, gray.shape[0]), out, cap)
    return out[:n].astype(np.int64), st_, out


def c_verify(gray, hyps, cfg: VerifyConfig, cap=None):
    st_ = ffi.new("vt_verify_state *")
    c = _native.verify_cfg_default()
    for f in dataclasses.fields(VerifyConfig):
        setattr(c, f.name, getattr(cfg, f.name))
    cap = int(lib.VT_MAX_BOXES) if cap is None else cap
    out = np.zeros((cap + 4, 4), np.int32)
    n = _native.verify(st_, c, gray, np.ascontiguousarray(hyps, np.int32).reshape(-1, 3), out, cap)
    return out[:n].astype(np.int64), out


def iou(a, b) -> float:
    """IoU of two inclusive-pixel boxes [l, t, r, b]."""
    ix = max(0, min(a[2], b[2]) - max(a[0], b[0]) + 1)
    iy = max(0, min(a[3], b[3]) - max(a[1], b[1]) + 1)
    inter = ix * iy
    area = lambda q: (q[2] - q[0] + 1) * (q[3] - q[1] + 1)  # noqa: E731
    return inter / (area(a) + area(b) - inter)


# ---------------------------------------------------------------- configuration
def test_defaults_agree():
    """The oracle's dataclass defaults are the C core's VT_*_CFG_DEFAULT."""
    assert c_default_config() == DetectConfig()
    c = _native.shadow_cfg_default()
    assert lib.vt_shadow_cfg_check(c) == lib.VT_OK
    assert c.threshold_mode == lib.VT_SHADOW_ADAPTIVE and c.polarity == lib.VT_SHADOW_DARK_ABOVE
    assert ShadowConfig().threshold_mode == rs.ADAPTIVE == lib.VT_SHADOW_ADAPTIVE
    assert rs.FIXED == lib.VT_SHADOW_FIXED and rs.DARK_BELOW == lib.VT_SHADOW_DARK_BELOW


shadow_cfgs = st.builds(
    ShadowConfig,
    threshold_mode=st.sampled_from([rs.FIXED, rs.ADAPTIVE]),
    polarity=st.sampled_from([rs.DARK_ABOVE, rs.DARK_BELOW]),
    grad_threshold=st.integers(1, 300), adapt_k_q8=st.integers(0, 600),
    adapt_grad_min=st.integers(1, 120), stat_step=st.integers(1, 5),
    min_run=st.integers(1, 20), max_gap=st.integers(0, 4), merge_rows=st.integers(0, 5),
    width_min_q8=st.integers(0, 128), width_max_q8=st.integers(128, 400),
    reduce_overlap_permille=st.integers(0, 1000), reduce_height_q8=st.integers(0, 512),
    reduce_verified=st.sampled_from([0, 1]))
verify_cfgs = st.builds(
    VerifyConfig, widen_px=st.integers(0, 12), widen_q8=st.integers(0, 80),
    roi_height_q8=st.integers(16, 400), vedge_threshold=st.integers(1, 200),
    side_min_frac_permille=st.integers(0, 1000), side_min_px=st.integers(0, 6),
    min_width_q8=st.integers(0, 300), aspect_q8=st.integers(64, 512),
    vedge_reach=st.integers(0, 3), vedge_hyst_permille=st.integers(0, 1000))


# ---------------------------------------------------------------- C vs oracle, drawn scenes
@given(h=st.integers(8, 150), w=st.integers(8, 230), seed=st.integers(0, 2**32 - 1),
       n_cars=st.integers(0, 4), noise=st.sampled_from([0.0, 0.0, 2.0, 5.0, 12.0]),
       polarity=st.sampled_from([rs.DARK_ABOVE, rs.DARK_BELOW]), mode=st.sampled_from([0, 1]),
       pad=st.sampled_from([0, 3]))
def test_scene_default_cfg_c_equals_oracle(h, w, seed, n_cars, noise, polarity, mode, pad):
    gray, road, _ = draw_scene(h, w, seed, n_cars, noise, polarity)
    cfg = dataclasses.replace(ShadowConfig(), polarity=polarity, threshold_mode=mode)
    hc, stc, _ = c_shadow(gray, road, cfg, stride_pad=pad)
    ro = rs.find_hypotheses(gray, road, cfg, max_out=int(lib.VT_MAX_HYPOTHESES), **CAPS)
    assert np.array_equal(hc, ro.hypotheses)
    assert (stc.n_runs, stc.n_dropped) == (ro.n_runs, ro.n_dropped)
    if mode == rs.ADAPTIVE:
        assert (stc.median, stc.mad) == (ro.median, ro.mad)
    bc, _ = c_verify(gray, hc, VerifyConfig())
    bo = rv.verify(gray, ro.hypotheses, VerifyConfig(), max_out=int(lib.VT_MAX_BOXES))
    assert np.array_equal(bc, bo)


@given(h=st.integers(8, 120), w=st.integers(8, 200), seed=st.integers(0, 2**32 - 1),
       n_cars=st.integers(0, 4), noise=st.sampled_from([0.0, 3.0, 8.0]),
       scfg=shadow_cfgs, vcfg=verify_cfgs, cap=st.integers(0, 5))
def test_scene_any_cfg_c_equals_oracle(h, w, seed, n_cars, noise, scfg, vcfg, cap):
    """Random configurations and small output capacities (truncation and the
    dropped count must agree too)."""
    gray, road, _ = draw_scene(h, w, seed, n_cars, noise, scfg.polarity)
    hc, stc, _ = c_shadow(gray, road, scfg, cap=cap)
    ro = rs.find_hypotheses(gray, road, scfg, max_out=cap, **CAPS)
    assert np.array_equal(hc, ro.hypotheses)
    assert (stc.n_runs, stc.n_dropped) == (ro.n_runs, ro.n_dropped)
    bc, _ = c_verify(gray, hc, vcfg, cap=cap)
    assert np.array_equal(bc, rv.verify(gray, hc, vcfg, max_out=cap))


@given(h=st.integers(4, 60), w=st.integers(4, 90), seed=st.integers(0, 2**32 - 1),
       yt=st.integers(-70, 70), yb=st.integers(-10, 90), valid=st.booleans())
def test_garbage_road_c_equals_oracle(h, w, seed, yt, yb, valid):
    """Road areas with spans outside the image, inverted spans, negative lane widths
    and rows outside the frame: clamped identically, never a crash."""
    rng = np.random.default_rng(seed)
    gray = rng.integers(0, 256, (h, w), dtype=np.uint8)
    gray[rng.integers(0, h):, :] //= 3
    road = RoadArea(yt, yb, rng.integers(-40, w + 40, h).astype(np.int16),
                    rng.integers(-40, w + 40, h).astype(np.int16),
                    rng.integers(-20, 3 * w, h).astype(np.int16), valid)
    for mode in (rs.FIXED, rs.ADAPTIVE):
        cfg = ShadowConfig(threshold_mode=mode, min_run=3, grad_threshold=30)
        hc, _, _ = c_shadow(gray, road, cfg)
        ro = rs.find_hypotheses(gray, road, cfg, max_out=int(lib.VT_MAX_HYPOTHESES), **CAPS)
        assert np.array_equal(hc, ro.hypotheses)


def test_scene_detection_finds_drawn_cars():
    """Not vacuous: on clean drawn scenes with one car the default detector finds
    it (IoU >= 0.7 with the drawn box) in most scenes, with both polarities."""
    for polarity in (rs.DARK_ABOVE, rs.DARK_BELOW):
        cfg = DetectConfig(ShadowConfig(polarity=polarity), VerifyConfig())
        found = 0
        for seed in range(30):
            gray, road, boxes = draw_scene(160, 240, seed, 1, 2.0, polarity)
            if not boxes:
                continue
            det = Detector("c", cfg, road=road)
            res = det.detect(gray)
            found += any(iou(b, boxes[0]) >= 0.7 for b in res.boxes)
        assert found >= 22, (polarity, found)


def test_shadow_edge_row_is_the_dark_to_bright_border():
    """The thesis's edge: scanning up, lit road then dark shadow. A dark band over
    rows 40..47 (columns 30..69) on a road of 150: the Sobel response is on rows 47
    and 48, and bottom-up the first is 48, whose dark side (row 47) is dark. The
    adaptive mode keeps only columns whose row above is dark (30..69); the fixed
    mode also takes the Sobel's one-column spill on each side (29..70)."""
    h, w = 80, 100
    gray = np.full((h, w), 150, np.uint8)
    gray[40:48, 30:70] = 30
    gray[20:40, 30:70] = 200
    road = RoadArea(10, h - 1, np.zeros(h, np.int16), np.full(h, w - 1, np.int16),
                    np.full(h, 60, np.int16))
    hyp, _, _ = c_shadow(gray, road, ShadowConfig())
    assert hyp.tolist() == [[48, 30, 69]]
    hyp, _, _ = c_shadow(gray, road, ShadowConfig(threshold_mode=rs.FIXED))
    assert hyp.tolist() == [[48, 29, 70]]
    # DARK_BELOW finds the body's bottom over the band instead (rows 39 and 40 respond).
    hyp, _, _ = c_shadow(gray, road, ShadowConfig(polarity=rs.DARK_BELOW, threshold_mode=rs.FIXED))
    assert hyp.tolist() == [[40, 29, 70]]


# ---------------------------------------------------------------- real frames
def _kitti_frames():
    with (DATA / "kitti_lead_boxes_621x188.csv").open() as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        i = int(r["frame"])
        gray = cv2.imread(str(DATA / f"kitti_lead_{i:02d}_gray_621x188.png"), cv2.IMREAD_GRAYSCALE)
        assert gray is not None
        yield i, gray, [float(r[k]) for k in ("left", "top", "right", "bottom")]


# The sequence's calibration (f 721.5, cx 609.6, cy 172.9 at 1242x375; camera 1.65 m
# above the road, 3.5 m lanes), as tools/eval_kitti_lead.py makes it.
KITTI_ROAD = FixedRoad(vp=(609.5593 / 1241, 172.854 / 374),
                       bottom=(609.5593 / 1241 - 0.34353, 609.5593 / 1241 + 0.34353),
                       lane_bottom=0.34353)


def test_kitti_frames_c_equals_oracle():
    found = 0
    for i, gray, gt in _kitti_frames():
        rc = Detector("c", road="fixed", fixed_road=KITTI_ROAD).detect(gray)
        ro = Detector("reference", road="fixed", fixed_road=KITTI_ROAD).detect(gray)
        assert np.array_equal(rc.hypotheses, ro.hypotheses), i
        assert np.array_equal(rc.boxes, ro.boxes), i
        g = [int(round(v)) for v in gt]
        found += any(iou(b, g) >= 0.6 for b in rc.boxes)
    # A floor against regressions: 4 of these 6 half-size frames at the time of
    # writing (the lead car's bottom is hidden below the frame from frame ~42).
    assert found >= 3


# ---------------------------------------------------------------- bad frames
@pytest.mark.parametrize("engine", ["c", "reference"])
@pytest.mark.parametrize("kind", ["black", "white", "noise", "1x1", "1xN", "Nx1", "2x2"])
def test_bad_frames_clean_empty(engine, kind):
    rng = np.random.default_rng(7)
    frame = {"black": np.zeros((120, 160), np.uint8), "white": np.full((120, 160), 255, np.uint8),
             "noise": rng.integers(0, 256, (120, 160), dtype=np.uint8),
             "1x1": np.zeros((1, 1), np.uint8), "1xN": np.full((1, 50), 9, np.uint8),
             "Nx1": np.full((50, 1), 9, np.uint8), "2x2": np.eye(2, dtype=np.uint8) * 255}[kind]
    res = Detector(engine, road="fixed").detect(frame)
    assert res.boxes.shape == (0, 4)
    # Noise does make shadow-like runs (hypotheses); verification must reject them,
    # as no column of vertical edges stands out (side_contrast). Flat frames have none.
    assert res.hypotheses.shape == (0, 3) or kind == "noise"


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_huge_frame_downscaled_not_clipped(engine):
    h, w = int(lib.VT_MAX_HEIGHT) * 2 + 6, int(lib.VT_MAX_WIDTH) + 640
    frame = np.full((h, w, 3), 120, np.uint8)
    frame[h // 2 + 200:h // 2 + 240, w // 2 - 300:w // 2 + 300] = 20   # a dark band
    det = Detector(engine, road="fixed")
    with pytest.warns(UserWarning, match="downscaled"):
        res = det.detect(frame)
    ph, pw = fit_size(h, w, int(lib.VT_MAX_HEIGHT), int(lib.VT_MAX_WIDTH))
    assert ph <= lib.VT_MAX_HEIGHT and pw <= lib.VT_MAX_WIDTH
    assert res.scale == pytest.approx(max(h / ph, w / pw))
    # Coordinates come back in the input's pixels: the road reaches its bottom row.
    assert res.road_polygon[:, 1].max() >= h - 1 - res.scale
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        det.detect(frame)        # warned once per Detector


def test_detector_bad_input():
    det = Detector("c")
    with pytest.raises(TypeError):
        det.detect(np.zeros((10, 10), np.float32))
    with pytest.raises(TypeError):
        det.detect([[1, 2], [3, 4]])
    with pytest.raises(ValueError):
        det.detect(np.zeros((0, 10), np.uint8))
    with pytest.raises(ValueError):
        det.detect(np.zeros((4, 4, 2), np.uint8))
    with pytest.raises(ValueError):
        Detector("fpga")
    with pytest.raises(ValueError):
        Detector("c", road="sky")
    with pytest.raises(VtError, match="vt_shadow_cfg_check"):
        Detector("c", DetectConfig(ShadowConfig(min_run=0)))
    with pytest.raises(VtError, match="vt_verify_cfg_check"):
        Detector("reference", DetectConfig(verify=VerifyConfig(aspect_q8=0)))
    # colour frames give the same result as their gray conversion
    gray, road, _ = draw_scene(120, 160, 3, 2, 1.0)
    bgr = cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR)
    assert np.array_equal(Detector("c", road=road).detect(bgr).boxes,
                          Detector("c", road=road).detect(gray).boxes)


# ---------------------------------------------------------------- bad arguments (C)
BUF = np.full(64 * 64, 100, np.uint8)


def u8(w, h, stride, px=True):
    v = ffi.new("vt_image_u8 *")
    v.px = ffi.cast("uint8_t *", BUF.ctypes.data) if px else ffi.NULL
    v.w, v.h, v.stride = w, h, stride
    return v


def road_c(h, valid=1):
    r = ffi.new("vt_road_area *")
    r.valid, r.y_top, r.y_bottom, r.height = valid, 0, h - 1, h
    for y in range(h):
        r.x_left[y], r.x_right[y], r.lane_width[y] = 0, 63, 40
    return r


def test_shadow_bad_args():
    st_, cfg, n = ffi.new("vt_shadow_state *"), _native.shadow_cfg_default(), ffi.new("int32_t *")
    out = ffi.new("vt_hypothesis[4]")
    img, road = u8(64, 64, 64), road_c(64)
    f = lib.vt_shadow_find
    assert f(st_, cfg, img, road, out, 4, n) == lib.VT_OK
    n[0] = 99
    assert f(ffi.NULL, cfg, img, road, out, 4, n) == lib.VT_E_ARG and n[0] == 0
    assert f(st_, ffi.NULL, img, road, out, 4, n) == lib.VT_E_ARG
    assert f(st_, cfg, ffi.NULL, road, out, 4, n) == lib.VT_E_ARG
    assert f(st_, cfg, u8(64, 64, 64, px=False), road, out, 4, n) == lib.VT_E_ARG
    assert f(st_, cfg, img, ffi.NULL, out, 4, n) == lib.VT_E_ARG
    assert f(st_, cfg, img, road, ffi.NULL, 4, n) == lib.VT_E_ARG
    assert f(st_, cfg, img, road, ffi.NULL, 0, n) == lib.VT_OK
    assert f(st_, cfg, img, road, out, -1, n) == lib.VT_E_ARG
    assert f(st_, cfg, img, road, out, 4, ffi.NULL) == lib.VT_E_ARG
    for d in [(0, 4, 4), (4, -1, 4), (4, 4, 3), (lib.VT_MAX_WIDTH + 1, 1, lib.VT_MAX_WIDTH + 1),
              (1, lib.VT_MAX_HEIGHT + 1, 1), (-(2**31), 4, 4)]:
        assert f(st_, cfg, u8(*d), road, out, 4, n) == lib.VT_E_SIZE, d
    assert f(st_, cfg, u8(64, 32, 64), road, out, 4, n) == lib.VT_E_SIZE   # road for 64 rows
    road.height = -5
    assert f(st_, cfg, img, road, out, 4, n) == lib.VT_E_SIZE
    # an invalid or empty road is a clean empty result
    for valid, yt, yb in [(0, 0, 63), (1, 40, 10), (1, -(2**31), -1), (1, 64, 2**31 - 1)]:
        r = road_c(64, valid)
        r.y_top, r.y_bottom = yt, yb
        assert f(st_, cfg, img, r, out, 4, n) == lib.VT_OK and n[0] == 0


def test_cfg_checks_reject_every_field_out_of_range():
    for make, check, cls in [(_native.shadow_cfg_default, lib.vt_shadow_cfg_check, ShadowConfig),
                             (_native.verify_cfg_default, lib.vt_verify_cfg_check, VerifyConfig)]:
        assert check(ffi.NULL) == lib.VT_E_ARG
        for fld in dataclasses.fields(cls):
            for bad in (-1, 70000, 2**31 - 1, -(2**31)):
                c = make()
                setattr(c, fld.name, bad)
                assert check(c) == lib.VT_E_ARG, (fld.name, bad)
    c = _native.shadow_cfg_default()
    c.width_min_q8, c.width_max_q8 = 200, 100
    assert lib.vt_shadow_cfg_check(c) == lib.VT_E_ARG
    for fn in (lib.vt_shadow_cfg_default, lib.vt_verify_cfg_default, lib.vt_detect_cfg_default):
        assert fn(ffi.NULL) == lib.VT_E_ARG


def test_verify_bad_args():
    st_, cfg, n = ffi.new("vt_verify_state *"), _native.verify_cfg_default(), ffi.new("int32_t *")
    hyp = ffi.new("vt_hypothesis[1]")
    hyp[0].row, hyp[0].x_start, hyp[0].x_end = 40, 10, 50
    out = ffi.new("vt_box[2]")
    img = u8(64, 64, 64)
    f = lib.vt_verify
    assert f(st_, cfg, img, hyp, 1, out, 2, n) == lib.VT_OK
    assert f(ffi.NULL, cfg, img, hyp, 1, out, 2, n) == lib.VT_E_ARG
    assert f(st_, ffi.NULL, img, hyp, 1, out, 2, n) == lib.VT_E_ARG
    assert f(st_, cfg, ffi.NULL, hyp, 1, out, 2, n) == lib.VT_E_ARG
    assert f(st_, cfg, img, ffi.NULL, 1, out, 2, n) == lib.VT_E_ARG
    assert f(st_, cfg, img, ffi.NULL, 0, out, 2, n) == lib.VT_OK and n[0] == 0
    assert f(st_, cfg, img, hyp, -1, out, 2, n) == lib.VT_E_ARG
    assert f(st_, cfg, img, hyp, 1, ffi.NULL, 2, n) == lib.VT_E_ARG
    assert f(st_, cfg, img, hyp, 1, out, -3, n) == lib.VT_E_ARG
    assert f(st_, cfg, img, hyp, 1, out, 2, ffi.NULL) == lib.VT_E_ARG
    assert f(st_, cfg, u8(64, 0, 64), hyp, 1, out, 2, n) == lib.VT_E_SIZE
    for row, xs, xe in [(-1, 10, 50), (64, 10, 50), (40, -1, 50), (40, 10, 64), (40, 50, 10),
                        (2**31 - 1, 0, 0), (0, -(2**31), 2**31 - 1)]:
        hyp[0].row, hyp[0].x_start, hyp[0].x_end = row, xs, xe
        n[0] = 7
        assert f(st_, cfg, img, hyp, 1, out, 2, n) == lib.VT_E_ARG, (row, xs, xe)
        assert n[0] == 0
    # extreme but valid: a 1-pixel edge on the image corner, the whole-width edge on row 0
    for row, xs, xe in [(0, 0, 0), (63, 63, 63), (0, 0, 63), (63, 0, 63)]:
        hyp[0].row, hyp[0].x_start, hyp[0].x_end = row, xs, xe
        assert f(st_, cfg, img, hyp, 1, out, 2, n) == lib.VT_OK


def test_detect_bad_args():
    st_, cfg = ffi.new("vt_detect_state *"), _native.detect_cfg_default()
    out, img, road = ffi.new("vt_detect_result *"), u8(64, 64, 64), road_c(64)
    f = lib.vt_detect
    assert f(st_, cfg, img, road, out) == lib.VT_OK
    out.n_hyp = out.n_boxes = 5
    assert f(st_, cfg, img, road, ffi.NULL) == lib.VT_E_ARG
    assert f(ffi.NULL, cfg, img, road, out) == lib.VT_E_ARG and out.n_hyp == 0 and out.n_boxes == 0
    assert f(st_, ffi.NULL, img, road, out) == lib.VT_E_ARG
    assert f(st_, cfg, ffi.NULL, road, out) == lib.VT_E_ARG
    assert f(st_, cfg, img, ffi.NULL, out) == lib.VT_E_ARG
    cfg.verify.aspect_q8 = 0
    assert f(st_, cfg, img, road, out) == lib.VT_E_ARG
    with pytest.raises(VtError, match="vt_detect"):
        _native.detect(st_, cfg, np.zeros((64, 64), np.uint8), road, out)
    with pytest.raises(VtError, match="vt_shadow_find"):
        c_shadow(np.zeros((8, 8), np.uint8), RoadArea(0, 7, np.zeros(8), np.full(8, 7), np.full(8, 8)),
                 ShadowConfig(stat_step=0))
    with pytest.raises(VtError, match="vt_verify"):
        c_verify(np.zeros((8, 8), np.uint8), np.array([[9, 0, 3]]), VerifyConfig())


# ---------------------------------------------------------------- guard bytes
@given(seed=st.integers(0, 2**32 - 1), cap=st.integers(0, 6))
def test_outputs_never_written_past_capacity(seed, cap):
    gray, road, _ = draw_scene(120, 180, seed, 4, 2.0)
    cfg = ShadowConfig(min_run=4, width_min_q8=0, width_max_q8=1000)
    hyp, _, buf = c_shadow(gray, road, cfg, cap=cap)
    assert (buf[cap:] == 0).all()
    full, _, _ = c_shadow(gray, road, cfg)
    assert np.array_equal(hyp, full[:cap])        # truncation keeps the nearest
    boxes, bbuf = c_verify(gray, full, VerifyConfig(side_min_px=0, side_min_frac_permille=0), cap=cap)
    assert (bbuf[cap:] == 0).all() and len(boxes) <= cap


def test_structs_not_written_past_their_end():
    """vt_detect writes only inside its state and result structs (their arrays are at
    the compile-time capacities): checked with a sentinel tail after each."""
    gray, road, _ = draw_scene(200, 300, 11, 4, 3.0)
    tail = 256
    raw = {}
    for name in ("vt_detect_state", "vt_detect_result"):
        size = ffi.sizeof(name)
        raw[name] = ffi.new("uint8_t[]", size + tail)
        ffi.memmove(raw[name] + size, b"\xa5" * tail, tail)
    st_ = ffi.cast("vt_detect_state *", raw["vt_detect_state"])
    out = ffi.cast("vt_detect_result *", raw["vt_detect_result"])
    cfg = _native.detect_cfg_default()
    cfg.shadow.min_run, cfg.shadow.width_min_q8, cfg.shadow.width_max_q8 = 3, 0, 4000
    cfg.verify.side_min_px, cfg.verify.side_min_frac_permille = 0, 0
    noisy = np.clip(gray.astype(int) + np.random.default_rng(1).integers(-60, 60, gray.shape), 0, 255)
    for img in (gray, noisy.astype(np.uint8)):
        _native.detect(st_, cfg, img, _native.road_area(road, img.shape[0]), out)
        assert 0 <= out.n_hyp <= lib.VT_MAX_HYPOTHESES and 0 <= out.n_boxes <= lib.VT_MAX_BOXES
        for name in raw:
            size = ffi.sizeof(name)
            assert bytes(ffi.buffer(raw[name] + size, tail)) == b"\xa5" * tail, name


def test_capacity_overflow_counts_dropped():
    """A frame of many separate dark bands overflows the hypothesis output: the
    nearest VT_MAX_HYPOTHESES are kept, the rest counted, C and oracle alike."""
    h, w = 400, 600
    gray = np.full((h, w), 180, np.uint8)
    for y in range(20, h, 10):
        for x in range(5, w - 20, 30):
            gray[y - 2:y + 1, x:x + 20] = 20
    road = RoadArea(0, h - 1, np.zeros(h, np.int16), np.full(h, w - 1, np.int16), np.full(h, 30, np.int16))
    cfg = ShadowConfig(threshold_mode=rs.FIXED, reduce_height_q8=0)
    hc, stc, _ = c_shadow(gray, road, cfg)
    ro = rs.find_hypotheses(gray, road, cfg, max_out=int(lib.VT_MAX_HYPOTHESES), **CAPS)
    assert len(hc) == lib.VT_MAX_HYPOTHESES and stc.n_dropped > 0
    assert np.array_equal(hc, ro.hypotheses) and stc.n_dropped == ro.n_dropped


# ---------------------------------------------------------------- CLI
def _two_frames(tmp_path):
    paths = []
    for k in range(2):
        gray, _, _ = draw_scene(96, 128, 100 + k, 2, 1.0)
        p = tmp_path / f"f{k}.png"
        cv2.imwrite(str(p), gray)
        paths.append(str(p))
    return paths


def _check_schema(entries, files):
    assert isinstance(entries, list) and len(entries) == len(files)
    for i, e in enumerate(entries):
        # the four keys of the contract; from a classifier (the default model) also "box_sources",
        # one name per box (added 2026-11-30, ninth session)
        assert set(e) in ({"frame", "file", "lanes", "boxes"}, {"frame", "file", "lanes", "boxes", "box_sources"})
        if "box_sources" in e:
            assert len(e["box_sources"]) == len(e["boxes"])
            assert set(e["box_sources"]) <= {"ego", "windows", "shadow"}
            assert all(len(b) == 5 for b in e["boxes"])
        assert e["frame"] == i and e["file"] == files[i]
        for ln in e["lanes"]:
            assert set(ln) == {"side", "points"} and ln["side"] in ("left", "right")
            assert all(len(p) == 2 and all(isinstance(v, int) for v in p) for p in ln["points"])
        for b in e["boxes"]:
            # [left, top, right, bottom] or, from a classifier (the default model), + its score
            assert len(b) in (4, 5) and all(isinstance(v, int) for v in b[:4]) and b[0] <= b[2] and b[1] <= b[3]
            assert len(b) == 4 or isinstance(b[4], float)


def test_cli_detect_png_and_json(tmp_path, capsys):
    files = _two_frames(tmp_path)
    out, js = tmp_path / "ann.png", tmp_path / "out.json"
    assert cli_main(["detect", *files, "--out", str(out), "--json", str(js), "--no-progress"]) == 0
    for k in range(2):
        img = cv2.imread(str(tmp_path / f"ann_{k:05d}.png"))
        assert img is not None and img.shape == (96, 128, 3)
    _check_schema(json.loads(js.read_text()), files)
    # one frame: exactly the --out name; the reference engine works the same way
    assert cli_main(["detect", files[0], "--out", str(out), "--engine", "reference"]) == 0
    assert cv2.imread(str(out)) is not None
    capsys.readouterr()


def test_cli_detect_folder_and_video(tmp_path):
    files = _two_frames(tmp_path)
    vid = tmp_path / "in.avi"
    wr = cv2.VideoWriter(str(vid), cv2.VideoWriter_fourcc(*"MJPG"), 10, (128, 96))
    if not wr.isOpened():
        pytest.skip("no MJPG writer in this OpenCV build")
    for f in files:
        wr.write(cv2.imread(f))
    wr.release()
    js = tmp_path / "v.json"
    assert cli_main(["detect", str(vid), "--out", str(tmp_path / "o.avi"), "--json", str(js),
                     "--no-progress"]) == 0
    assert (tmp_path / "o.avi").stat().st_size > 0
    _check_schema(json.loads(js.read_text()), [str(vid)] * 2)
    js2 = tmp_path / "d.json"
    assert cli_main(["detect", str(tmp_path), "--out", str(tmp_path / "d.png"), "--json", str(js2),
                     "--no-progress"]) == 0
    _check_schema(json.loads(js2.read_text()), files)  # the folder's images, sorted


@pytest.mark.parametrize("args, msg", [
    (["missing.png"], "no such file"),
    (["BAD"], "cannot read"),
    (["EMPTYDIR"], "no image files"),
    (["GOOD", "--out", "x.txt"], "expected a .png"),
    (["GOOD", "--out", "nodir/x.png"], "does not exist"),
])
def test_cli_errors_one_line(tmp_path, capsys, args, msg):
    good = _two_frames(tmp_path)[0]
    (tmp_path / "bad.png").write_bytes(b"not an image")
    (tmp_path / "empty").mkdir()
    subst = {"BAD": str(tmp_path / "bad.png"), "EMPTYDIR": str(tmp_path / "empty"), "GOOD": good,
             "missing.png": str(tmp_path / "missing.png"), "x.txt": str(tmp_path / "x.txt"),
             "nodir/x.png": str(tmp_path / "nodir" / "x.png")}
    argv = ["detect"] + [subst.get(a, a) for a in args]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "o.png")]
    assert cli_main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert msg in err and "Traceback" not in err and len(err.splitlines()) == 1


# ---------------------------------------------------------------- lane hand-over
class _FakeLanes:
    """A stand-in lane stage: returns a fixed road area (or none) and two lanes."""

    def __init__(self, road):
        self.road, self.calls = road, 0

    def detect(self, gray):
        self.calls += 1
        h, w = gray.shape
        lanes = [dataclasses.make_dataclass("L", ["side", "points"])(
            side, np.array([[w * f, h - 1], [w / 2, h / 3]])) for side, f in (("left", 0.1), ("right", 0.9))]
        return dataclasses.make_dataclass("R", ["road", "lanes"])(self.road, lanes)


def test_detector_uses_the_lane_stage_road():
    gray, road, boxes = draw_scene(160, 240, 5, 1, 1.0)
    fake = _FakeLanes(road)
    for engine in ("c", "reference"):
        res = Detector(engine, road="auto", lane_detector=fake).detect(gray)
        assert res.road_source == "lanes"
        assert [ln.side for ln in res.lanes] == ["left", "right"]
        assert np.array_equal(res.boxes, Detector(engine, road=road).detect(gray).boxes)
    # no road from the lanes: "auto" falls back to the fixed trapezoid, "lanes" gives nothing
    fake.road = None
    assert Detector("c", road="auto", lane_detector=fake).detect(gray).road_source == "fixed"
    res = Detector("c", road="lanes", lane_detector=fake).detect(gray)
    assert res.road_source == "none" and len(res.boxes) == 0 and len(res.road_polygon) == 0


def test_road_too_short_is_a_clear_error():
    gray = np.zeros((40, 50), np.uint8)
    short = RoadArea(0, 39, np.zeros(30, np.int16), np.full(30, 49, np.int16), np.full(30, 20, np.int16))
    for engine in ("c", "reference"):
        with pytest.raises(ValueError, match="x_left"):
            Detector(engine, road=short).detect(gray)


def test_cli_default_is_the_shipped_whole_road_model(tmp_path, capsys):
    """`detect` without --model runs pyvehtrack/models/cnn_gray_l0_big.npz with its settings on
    the C engine and window_mlp_hog32.npz on the reference one (the CNN's bit-exact NumPy twin
    is too slow for a default); boxes carry a score; --model none is the thesis's ego-lane
    detector alone (no score); --sources without a classifier contradicts --model none."""
    from pyvehtrack.fullroad import DEFAULT_CNN_MODEL, DEFAULT_WINDOW_MODEL, default_model_path
    assert default_model_path("c") == DEFAULT_CNN_MODEL
    assert default_model_path("reference") == DEFAULT_WINDOW_MODEL
    frame = str(Path(__file__).parent / "data" / "udacity_test1_640x360.jpg")
    boxes = {}
    for extra in ([], ["--engine", "reference"], ["--model", "none"], ["--model", str(DEFAULT_CNN_MODEL)],
                  ["--engine", "reference", "--model", str(DEFAULT_WINDOW_MODEL)]):
        js = tmp_path / "d.json"
        assert cli_main(["detect", frame, "--json", str(js), "--no-progress", *extra]) == 0
        boxes[" ".join(Path(x).name for x in extra)] = json.loads(js.read_text())[0]["boxes"]
    assert boxes[""] == boxes["--model cnn_gray_l0_big.npz"]
    assert boxes["--engine reference"] == boxes["--engine reference --model window_mlp_hog32.npz"]
    # the black car in the right lane (x 415-470, y 205-250 of this 640x360 frame) is boxed by both
    for k in ("", "--engine reference"):
        assert any(len(b) == 5 and b[0] < 440 < b[2] and b[1] < 225 < b[3] for b in boxes[k]), k
    assert all(len(b) == 4 for b in boxes["--model none"])
    assert cli_main(["detect", frame, "--model", "none", "--sources", "windows", "--json", str(tmp_path / "e.json"),
                     "--no-progress"]) == 2
    assert "--model none" in capsys.readouterr().err
    # --sources alone: the built-in classifier, said on stderr (a user narrowing the default's
    # sources would otherwise not know the CNN is not running); with --model no warning
    assert cli_main(["detect", frame, "--sources", "windows", "--json", str(tmp_path / "w.json"),
                     "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert "warning: --sources without --model" in err and str(DEFAULT_CNN_MODEL) in err
    assert cli_main(["detect", frame, "--model", str(DEFAULT_CNN_MODEL), "--sources", "windows", "--json",
                     str(tmp_path / "w.json"), "--no-progress"]) == 0
    assert "warning" not in capsys.readouterr().err


def test_collapsed_lane_pair_keeps_the_horizon(tmp_path):
    """tusimple-vehicles-dev 4065 (640x360 gray copy): the lane stage's ego pair collapses onto
    one marking and its lines meet 110 rows below the true horizon. That row used to become
    the whole-road detector's horizon, and the pickup straight ahead (human box 343,165 -
    390,204 at this scale) lay above it: no box at all. The pair gives no vanishing row
    now (tests/test_lane.py), the camera's horizon stays, and the CLI default boxes it."""
    from pyvehtrack.eval_boxes import box_iou_matrix
    frame = Path(__file__).parent / "data" / "tusimple_vehicles_4065_gray_640x360.png"
    js = tmp_path / "d.json"
    assert cli_main(["detect", str(frame), "--json", str(js), "--no-progress"]) == 0
    boxes = np.array([b[:4] for b in json.loads(js.read_text())[0]["boxes"]], float).reshape(-1, 4)
    truth = np.array([[343, 165, 390, 204]], float)
    assert len(boxes) and box_iou_matrix(truth, boxes).max() >= 0.5, boxes
