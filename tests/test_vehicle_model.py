"""The geometric vehicle model + GA (c/vehicle_model.c) vs its oracle
(pyvehtrack/reference/vehicle_model.py), on hypothesis-drawn frames, ROIs and configs.

Tolerance: 0 everywhere, and for a reason: the fitness is defined on integers
(vehicle_model.h); the oracle computes its inputs with independent tools (cv2.pyrDown
= vt_pyr_down to the LSB, cv2.Sobel with BORDER_REPLICATE = vt_sobel_x/y exactly,
scipy's exact city-block distance transform = the C two-pass sweep) and its sums
with Python integers; both GAs draw the same xorshift32 numbers in the same order.
So every feature pixel, every fitness, every individual of the last generation
and the generator's final state must be equal."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import _native, VtError
from pyvehtrack import vehicle_model as V
from pyvehtrack.reference import vehicle_model as rvm

from conftest import padded_copy


def _frame(rng, h, w, kind):
    if kind == "noise":
        return rng.integers(0, 256, (h, w)).astype(np.uint8)
    img = np.full((h, w), rng.integers(80, 200), np.uint8)
    if kind == "car":   # a dark-bottomed symmetric block: something to lock on
        cw, ch = max(4, w // 3), max(4, h // 3)
        x0, y0 = rng.integers(0, w - cw + 1), rng.integers(0, h - ch + 1)
        img[y0:y0 + ch, x0:x0 + cw] = rng.integers(150, 256)
        img[y0 + ch - max(1, ch // 5):y0 + ch, x0:x0 + cw] = rng.integers(0, 40)
        img[y0 + ch // 5:y0 + ch // 2, x0 + cw // 5:x0 + cw - cw // 5] = rng.integers(20, 90)
    noise = rng.integers(-8, 9, (h, w))
    return np.clip(img.astype(np.int16) + noise, 0, 255).astype(np.uint8)


@st.composite
def problems(draw, small=True):
    h, w = draw(st.integers(12, 67)), draw(st.integers(12, 67))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    img = _frame(rng, h, w, draw(st.sampled_from(["noise", "car", "flat"])))
    pad = draw(st.integers(0, 4))
    img = padded_copy(img, pad) if pad else img
    l = draw(st.integers(-5, w - 8))
    t = draw(st.integers(-5, h - 8))
    r = draw(st.integers(max(l, 0) + 7, w + 5))
    b = draw(st.integers(max(t, 0) + 7, h + 5))
    y_min = draw(st.integers(t - 3, b + 3))
    y_max = draw(st.integers(y_min, b + 6))
    levels = draw(st.integers(1, 3))
    pops = [[draw(st.integers(2, 8)) for _ in range(3)] for _ in range(2)]
    gens = [[draw(st.integers(0, 3)) for _ in range(3)] for _ in range(2)]
    road = (h // 4, draw(st.integers(1, 6)), h, draw(st.integers(8, max(9, w))))
    kw = dict(levels=levels, pop=pops, gens=gens, seed=draw(st.integers(0, 2**32 - 1)),
              mut_permille=draw(st.integers(0, 1000)), w_sym=draw(st.integers(0, 4)),
              w_grad=draw(st.integers(0, 4)), w_dist=draw(st.integers(0, 4)),
              w_shadow=draw(st.integers(0, 4)), edge_thresh=draw(st.integers(0, 400)),
              dist_cap=draw(st.integers(1, 12)), width_tol_permille=draw(st.integers(0, 900)),
              roof_max=draw(st.integers(0, 45)))
    tracking = draw(st.booleans())
    pred = sigma = None
    if tracking:
        pred = (draw(st.integers(-5, w + 5)), draw(st.integers(-5, h + 5)), draw(st.integers(1, w)),
                draw(st.integers(1, h)), draw(st.integers(0, 100)), draw(st.integers(0, 100)),
                draw(st.integers(0, 100)))
        sigma = tuple(draw(st.integers(0, 6)) for _ in range(7))
    return img, kw, road, (l, t, r, b), (y_min, y_max), pred, sigma


def _c_and_oracle(kw, road):
    try:
        cfg = V.make_cfg(road=road, **kw)
    except VtError:
        cfg = V.make_cfg(**kw)      # a road the C checks refuse (e.g. zero slope): keep the default
    return cfg, V.oracle_cfg(cfg)


@settings(max_examples=40)
@given(prob=problems())
def test_ga_individuals_identical(prob):
    img, kw, road, roi, yr, pred, sigma = prob
    cfg, ocfg = _c_and_oracle(kw, road)
    s = _native.model_search(roi, yr[0], yr[1], pred is not None, pred, sigma)
    os_ = V.oracle_search(roi, yr[0], yr[1], pred, sigma)
    ws = _native.model_ws_new()
    try:
        c = _native.model_fit(img, cfg, s, ws)
    except VtError as e:
        # the same refusal from the oracle: an infeasible search
        assert e.status == int(_native.lib.VT_E_SINGULAR)
        with pytest.raises(ValueError):
            rvm.fit(np.ascontiguousarray(img), ocfg, os_)
        return
    r = rvm.fit(np.ascontiguousarray(img), ocfg, os_)
    pop, fit = _native.model_population(ws)
    assert [tuple(p) for p in r.population] == pop
    assert r.fitnesses == fit
    assert (c["best"], c["fitness"], c["evaluations"], c["box"]) == (tuple(r.best), r.fitness, r.evaluations, r.box)
    assert int(ws.rng) == r.rng_state
    # cost bound: the config's sum of pop * (gens + 1)
    mode = 1 if pred is not None else 0
    assert c["evaluations"] <= sum(cfg.pop[mode][l] * (cfg.gens[mode][l] + 1) for l in range(cfg.levels))


@settings(max_examples=40)
@given(prob=problems(), level=st.integers(0, 2),
       params=st.tuples(st.integers(-80, 150), st.integers(-80, 150), st.integers(1, 120),
                        st.integers(1, 120), st.integers(0, 100), st.integers(0, 100), st.integers(0, 100)))
def test_features_and_fitness_exact(prob, level, params):
    """Any parameters, even outside the constraints or the frame (samples are clamped)."""
    img, kw, road, roi, yr, _, _ = prob
    kw["levels"] = 3
    cfg, ocfg = _c_and_oracle(kw, road)
    s = _native.model_search(roi, yr[0], yr[1])
    ws = _native.model_ws_new()
    _native.model_prepare(img, cfg, s, level, ws)
    lv = rvm.prepare(np.ascontiguousarray(img), ocfg, V.oracle_search(roi, *yr), level)
    lh, lw = lv.img.shape
    assert (int(ws.lw), int(ws.lh), int(ws.ox), int(ws.oy)) == (lw, lh, lv.ox, lv.oy)
    n = lw * lh
    gx = np.frombuffer(_native.ffi.buffer(ws.gx, 2 * n), np.int16).reshape(lh, lw)
    gy = np.frombuffer(_native.ffi.buffer(ws.gy, 2 * n), np.int16).reshape(lh, lw)
    dist = np.frombuffer(_native.ffi.buffer(ws.dist, n), np.uint8).reshape(lh, lw)
    np.testing.assert_array_equal(gx, lv.gx)
    np.testing.assert_array_equal(gy, lv.gy)
    np.testing.assert_array_equal(dist, lv.dist)
    assert _native.model_fitness(img, cfg, s, level, ws, params) == rvm.fitness(ocfg, lv, list(params))


def test_table1_defaults_identical_and_cost():
    """The paper's Table 1 populations (tracking: 32/2, 32/2, 64/10), one synthetic car."""
    rng = np.random.default_rng(7)
    img = _frame(rng, 64, 80, "car")
    cfg = V.make_cfg(road=(16, 8, 64, 40))
    roi, pred, sigma = (0, 0, 79, 63), (40, 50, 30, 24, 40, 20, 10), (4, 4, 4, 4, 5, 5, 3)
    c = V.VehicleModel("c", road=(16, 8, 64, 40)).fit(img, roi, prediction=pred, sigma=sigma)
    r = V.VehicleModel("reference", road=(16, 8, 64, 40)).fit(img, roi, prediction=pred, sigma=sigma)
    assert c == r
    # Table 1, tracking: 32 (2 + 1) + 32 (2 + 1) + 64 (10 + 1) populations, minus the elite
    # kept without re-evaluation in each generation
    assert c.evaluations == 32 + 2 * 31 + 32 + 2 * 31 + 64 + 10 * 63
    assert [list(cfg.pop[0]), list(cfg.gens[0])] == [[128, 64, 64], [40, 2, 2]]
    assert [list(cfg.pop[1]), list(cfg.gens[1])] == [[64, 32, 32], [10, 2, 2]]


def test_finds_a_clear_car():
    """On a clean synthetic car (dark bottom band, window, symmetric), a detection-mode fit lands
    on it: IoU >= 0.5 with the drawn box. Road: 60 px wide at its bottom row."""
    img = np.full((120, 160), 120, np.uint8)
    img[40:100, 50:110] = 200          # body
    img[90:100, 50:110] = 15           # dark band (shadow under the car)
    img[48:66, 58:102] = 50            # rear window
    img[72:78, 54:64] = 90             # lights
    img[72:78, 96:106] = 90
    rng = np.random.default_rng(0)
    img = np.clip(img + rng.integers(-4, 5, img.shape), 0, 255).astype(np.uint8)
    fit = V.VehicleModel("c", road=(40, 20, 99, 60)).fit(img, (10, 20, 150, 115))
    l, t, r, b = fit.box
    inter = max(0, min(r, 109) - max(l, 50) + 1) * max(0, min(b, 99) - max(t, 40) + 1)
    union = (r - l + 1) * (b - t + 1) + 60 * 60 - inter
    assert inter / union >= 0.5, fit


def test_bad_inputs():
    lib, ffi = _native.lib, _native.ffi
    cfg = V.make_cfg()
    img = np.zeros((40, 40), np.uint8)
    v = _native.view(img, "img")
    s = _native.model_search((0, 0, 39, 39), 0, 39)
    ws = _native.model_ws_new()
    out = ffi.new("vt_model_result *")
    N = ffi.NULL
    assert lib.vt_model_fit(ws, cfg, N, s, out) == lib.VT_E_ARG
    assert lib.vt_model_fit(ws, N, v, s, out) == lib.VT_E_ARG
    assert lib.vt_model_fit(ws, cfg, v, N, out) == lib.VT_E_ARG
    assert lib.vt_model_fit(N, cfg, v, s, out) == lib.VT_E_ARG
    assert lib.vt_model_fit(ws, cfg, v, s, N) == lib.VT_E_ARG
    assert lib.vt_model_cfg_default(N) == lib.VT_E_ARG
    assert lib.vt_model_cfg_check(N) == lib.VT_E_ARG
    assert lib.vt_model_prepare(ws, cfg, v, s, 3) == lib.VT_E_ARG
    p = ffi.new("vt_model_params *")
    f = ffi.new("int32_t *")
    # fitness before prepare, and at another level than prepared
    ws2 = _native.model_ws_new()
    ws2.level = -1
    assert lib.vt_model_fitness(ws2, cfg, v, s, 0, p, f) == lib.VT_E_ARG
    _native.model_prepare(img, cfg, s, 1, ws2)
    p.w = p.h = 10
    assert lib.vt_model_fitness(ws2, cfg, v, s, 0, p, f) == lib.VT_E_ARG
    assert lib.vt_model_fitness(ws2, cfg, v, s, 1, p, f) == lib.VT_OK
    p.w = 0
    assert lib.vt_model_fitness(ws2, cfg, v, s, 1, p, f) == lib.VT_E_ARG
    # sizes: bad frame view, ROI outside or under 8x8, over capacity
    v0 = ffi.new("vt_image_u8 *")
    v0.px = ffi.cast("uint8_t *", img.ctypes.data)
    for w, h, st_ in [(0, 10, 10), (10, -1, 10), (10, 10, 9)]:
        v0.w, v0.h, v0.stride = w, h, st_
        assert lib.vt_model_fit(ws, cfg, v0, s, out) == lib.VT_E_SIZE
    for roi in [(50, 0, 60, 39), (0, 0, 6, 39), (0, 0, 39, 5), (-20, -20, -1, -1), (10, 10, 5, 30)]:
        with pytest.raises(VtError, match="vt_model_fit.*size"):
            _native.model_fit(img, cfg, _native.model_search(roi, 0, 39), ws)
    cap = int(lib.VT_MODEL_MAX_ROI_PIXELS)
    side = int(np.sqrt(cap)) + 2
    if side <= min(int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)):
        big = np.zeros((side, side), np.uint8)
        with pytest.raises(VtError, match="capacity"):
            _native.model_fit(big, cfg, _native.model_search((0, 0, side - 1, side - 1), 0, side - 1), ws)
    # search: rows inverted, rows outside the ROI (infeasible), negative sigma
    with pytest.raises(VtError, match="vt_model_fit.*argument"):
        _native.model_fit(img, cfg, _native.model_search((0, 0, 39, 39), 30, 20), ws)
    with pytest.raises(VtError, match="singular|division"):
        _native.model_fit(img, cfg, _native.model_search((0, 10, 39, 39), 0, 12), ws)
    with pytest.raises(VtError, match="vt_model_fit"):
        _native.model_fit(img, cfg, _native.model_search((0, 0, 39, 39), 0, 39, True, (20,) * 7,
                                                         (-1, 0, 0, 0, 0, 0, 0)), ws)
    # config checks
    for k, bad in [("levels", 0), ("levels", 4), ("mut_permille", 1001), ("w_sym", -1),
                   ("dist_cap", 0), ("width_per_row", 0), ("roof_max", 46)]:
        with pytest.raises(VtError, match="vt_model_cfg_check"):
            V.make_cfg(**{k: bad})
    with pytest.raises(VtError, match="vt_model_cfg_check"):
        V.make_cfg(pop=[[1, 64, 64], [64, 32, 32]])
    with pytest.raises(ValueError, match="pop"):
        V.make_cfg(pop=[[1, 2]])
    with pytest.raises(TypeError, match="nonsense"):
        V.make_cfg(nonsense=3)
    with pytest.raises(VtError, match="vt_model_cfg_road"):
        V.make_cfg(road=(10, 50, 10, 60))      # same row twice
    with pytest.raises(VtError, match="vt_model_cfg_road"):
        V.make_cfg(road=(10, 60, 50, 20))      # width shrinking toward the camera
    big_pop = int(lib.VT_MODEL_MAX_POP) + 1
    if big_pop <= 4096:
        c2 = V.make_cfg(pop=[[big_pop, 64, 64], [64, 32, 32]])
        with pytest.raises(VtError, match="capacity"):
            _native.model_fit(img, c2, s, ws)
    # Python-level checks
    vm = V.VehicleModel()
    with pytest.raises(TypeError, match="frame"):
        vm.fit(img.astype(np.float32), (0, 0, 39, 39))
    with pytest.raises(ValueError, match="prediction"):
        vm.fit(img, (0, 0, 39, 39), prediction=(1,) * 7)
    with pytest.raises(ValueError, match="sigma"):
        vm.fit(img, (0, 0, 39, 39), prediction=(20,) * 7, sigma=(-1,) * 7)
    with pytest.raises(ValueError, match="roi"):
        vm.fit(img, (0, 0, 39))
    with pytest.raises(ValueError, match="engine"):
        V.VehicleModel("gpu")


def test_expected_width_and_road():
    cfg = V.make_cfg(road=(100, 20, 300, 220))
    assert int(cfg.width_per_row) == 65536 and int(cfg.horizon_row) == 80
    assert _native.model_expected_width(cfg, 80) == 0
    assert _native.model_expected_width(cfg, 50) == 0
    assert _native.model_expected_width(cfg, 200) == 120
    assert _native.model_expected_width(cfg, 10**6) == int(_native.lib.VT_MAX_WIDTH)
    ocfg = V.oracle_cfg(cfg)
    for y in (-5, 80, 81, 150, 333, 10**6):
        assert rvm.expected_width(ocfg, y) == _native.model_expected_width(cfg, y)


def test_search_from_flow():
    cfg = V.make_cfg(road=(100, 20, 300, 220))      # horizon row 80, 1 px of width per row
    hyp = {"left": 10, "top": 100, "right": 49, "bottom": 139, "cy": 120}
    s = _native.model_search_from_flow(cfg, hyp)
    W = 139 - 80                                     # expected width at the blob's lowest row
    assert (s.roi.left, s.roi.right) == (10 - W, 49 + W)
    assert (s.roi.top, s.roi.bottom) == (139 - W * int(cfg.aspect_max_permille) // 1000 - W // 4, 139 + W // 4)
    assert (s.y_min, s.y_max, s.tracking) == (120, 139 + W // 8, 0)
    with pytest.raises(VtError, match="vt_model_search_from_flow"):
        _native.model_search_from_flow(cfg, {"left": 50, "top": 100, "right": 49, "bottom": 139, "cy": 120})
    assert _native.lib.vt_model_search_from_flow(cfg, _native.ffi.NULL, s) == _native.lib.VT_E_ARG
    assert _native.lib.vt_model_search_from_flow(_native.ffi.NULL, _native.ffi.NULL, s) == _native.lib.VT_E_ARG


def test_old_percent_names_convert_exactly_with_a_warning():
    """Issue 10 item 6: width_tol / aspect_min / aspect_max became permille (x 10, exact)."""
    from pyvehtrack import vehicle_model as VM
    with pytest.warns(DeprecationWarning, match="width_tol_permille"):
        old = VM.make_cfg(width_tol_percent=20, aspect_min_percent=50, aspect_max_percent=120)
    new = VM.make_cfg(width_tol_permille=200, aspect_min_permille=500, aspect_max_permille=1200)
    assert [int(getattr(old, f)) for f in ("width_tol_permille", "aspect_min_permille", "aspect_max_permille")] \
        == [int(getattr(new, f)) for f in ("width_tol_permille", "aspect_min_permille", "aspect_max_permille")]
    with pytest.raises(TypeError, match="not both"):
        VM.make_cfg(width_tol_percent=20, width_tol_permille=200)
    with pytest.warns(DeprecationWarning, match="mut_permille"):
        assert int(VM.make_cfg(mut_percent=7).mut_permille) == 70


@given(st.integers(0, 2**32 - 1), st.integers(0, 100))
def test_mutation_draw_in_permille_decides_as_the_percent_draw(r, p):
    """mut_percent (draw (r * 100) >> 32 < p) became mut_permille (draw (r * 1000) >> 32 <
    10 p): for every xorshift state r both say r < p 2^32 / 100, so the GA's individuals are
    those of before (the draw count is one per gene either way; the C vs oracle test above
    checks the two engines against each other)."""
    assert ((r * 100) >> 32 < p) == ((r * 1000) >> 32 < 10 * p)
