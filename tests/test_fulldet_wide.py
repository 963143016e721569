"""The whole-road detector's wide pass (vt_fulldet_wide, c/fulldet.c) against its oracle
(reference/fulldet.py wide) with one shared classifier (the C vt_classify_box_mlp, whose
own arithmetic is proven in tests/test_classify.py): boxes, scores, sources and order
must agree EXACTLY -- the window grid is exact against reference.windows
(tests/test_windows.py) and the pass adds only integer box cuts (floor of size x
permille / 1000), integer comparisons and a stable sort. Also guard entries past the
result, a full result, and bad arguments (the result unchanged on error)."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack.fullroad import DEFAULT_WINDOW_MODEL
from pyvehtrack import _native
from pyvehtrack._native import ffi, lib
from pyvehtrack.reference import fulldet as rfd
from pyvehtrack.reference import windows as rw
from pyvehtrack.shared import WideConfig

DATA = Path(__file__).parent / "data"
MAXW, MAXH = int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)
MAXB = int(lib.VT_MAX_BOXES)
SRC = ("left", "top", "right", "bottom", "score", "source")


def random_mlp(seed: int, win_w: int = 24, win_h: int = 16, hidden: int = 4):
    """A small HOG MLP with random int16 weights, biased so both signs occur."""
    rng = np.random.default_rng(seed)
    dim = (win_w // 8 - 1) * (win_h // 8 - 1) * 36
    w1 = rng.integers(-3000, 3000, (hidden, dim))
    b1 = rng.integers(-2 ** 15, 2 ** 15, hidden)
    w2 = rng.integers(-3000, 3000, hidden)
    return _native.mlp_model(1, win_w, win_h, w1, 12, b1, w2, 12, int(rng.integers(-2 ** 14, 2 ** 14)))


def c_wide_cfg(w: WideConfig):
    c = _native.fulldet_wide_cfg_default()
    c.veh_w_min_mm, c.veh_w_max_mm = round(w.veh_w_min_m * 1000), round(w.veh_w_max_m * 1000)
    c.box_height_permille, c.score_min = w.box_height_permille, int(w.score_min)
    c.nms_iou_permille, c.nms_contain_permille = w.nms_iou_permille, w.nms_contain_permille
    assert lib.vt_fulldet_wide_cfg_check(c) == 0
    return c


def c_win(w: rw.WindowConfig):
    c = _native.win_cfg_default()
    c.veh_w_min_mm, c.veh_w_max_mm = round(w.veh_w_min_m * 1000), round(w.veh_w_max_m * 1000)
    c.n_sizes = len(w.sizes)
    for i, s in enumerate(w.sizes):
        c.size[i] = s
    c.step_q8, c.levels = round(w.step * 256), w.levels
    c.lane_w_mm, c.top_margin = round(w.lane_w_m * 1000), w.top_margin
    return c


def result_with(boxes):
    out = ffi.new("vt_fulldet_result *")
    for i in range(MAXB):   # guard entries past n_boxes
        out.box[i].box.left = out.box[i].box.top = out.box[i].box.right = out.box[i].box.bottom = -7
        out.box[i].score, out.box[i].source = -77, 9
    out.n_boxes = len(boxes)
    for i, b in enumerate(boxes):
        out.box[i].box.left, out.box[i].box.top, out.box[i].box.right, out.box[i].box.bottom = b[:4]
        out.box[i].score, out.box[i].source = b[4], b[5]
    return out


def run_both(gray, cam: rw.Camera, win: rw.WindowConfig, wcfg: WideConfig, model, prior):
    h, w = gray.shape
    m, keep = model
    ws = _native.box_ws_new()
    cwin = c_win(win)
    ccam = _native.camera_min(cam.fx, cam.horizon_y, round(cam.height_m * 1000), cam.hood_y)
    road_c = _native.road_from_camera(cwin, ccam, w, h)
    road_r = rw.road_from_camera(cam, win, w, h)
    st_ = ffi.new("vt_fulldet_state *")
    out = result_with(prior)
    got = _native.fulldet_wide(st_, ws, c_wide_cfg(wcfg), cwin, m, ccam, gray, road_c, out)
    n = out.n_boxes
    for i in range(n, MAXB):   # nothing written past the result
        b = out.box[i]
        assert (b.box.left, b.box.top, b.box.right, b.box.bottom, b.score, b.source) == (-7, -7, -7, -7, -77, 9)
    ref = rfd.wide(gray, road_r, cam, win, wcfg,
                   lambda l, t, r, b: _native.classify_box_mlp(ws, m, gray, [l, t, r, b]),
                   np.asarray(prior, np.int64).reshape(-1, 6), max_windows=int(lib.VT_FULLDET_MAX_WINDOWS),
                   max_cand=int(lib.VT_FULLDET_MAX_CAND), max_boxes=MAXB)
    got_a = np.stack([got[k] for k in SRC], 1).reshape(-1, 6)
    return got_a, ref


def scene(rng, h, w):
    gray = np.full((h, w), 120, np.int64) + rng.integers(-12, 12, (h, w))
    for _ in range(int(rng.integers(1, 7))):   # flat dark / bright blocks: side-view-like shapes
        x0, y0 = int(rng.integers(0, w - 8)), int(rng.integers(h // 3, h - 2))
        bw = int(rng.integers(8, 80))
        gray[y0 - min(y0, bw // 3):y0, x0:x0 + bw] = int(rng.integers(0, 255))
    return np.clip(gray, 0, 255).astype(np.uint8)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2 ** 31 - 1), st.integers(1000, 3000), st.integers(3000, 9000), st.integers(150, 1000),
       st.integers(-30000, 30000), st.integers(0, 1000), st.integers(0, 1000), st.integers(0, 4))
def test_random_frames_match_oracle(seed, wmin, wmax, bh, smin, iou, contain, n_prior):
    rng = np.random.default_rng(seed)
    h, w = int(rng.integers(40, min(MAXH, 150))), int(rng.integers(60, min(MAXW, 240)))
    gray = scene(rng, h, w)
    cam = rw.Camera(fx=float(rng.integers(120, 300)), horizon_y=int(rng.integers(-5, h // 2)), height_m=1.5,
                    hood_y=int(rng.integers(h * 3 // 4, h + 2)))
    win = rw.WindowConfig(sizes=(8, 11, 16), levels=3, step=0.25)
    wcfg = WideConfig(veh_w_min_m=wmin / 1000, veh_w_max_m=wmax / 1000, box_height_permille=bh, score_min=smin,
                      nms_iou_permille=iou, nms_contain_permille=contain)
    prior = []
    for _ in range(n_prior):   # boxes already found (vt_fulldet's result)
        l, t = int(rng.integers(0, w - 10)), int(rng.integers(0, h - 10))
        prior.append([l, t, l + int(rng.integers(4, 40)) if l + 40 < w else w - 1,
                      t + int(rng.integers(4, 30)) if t + 30 < h else h - 1, int(rng.integers(-9, 9)), 1])
    got, ref = run_both(gray, cam, win, wcfg, random_mlp(seed), prior)
    assert np.array_equal(got, ref)
    assert np.array_equal(got[:len(prior)], np.asarray(prior, np.int64).reshape(-1, 6))   # kept, in order


def test_real_frame_matches_oracle_and_adds_boxes():
    """A 640x360 road frame (Udacity test1, tests/data) with the detector's grid rules
    and a score threshold that lets boxes through: C = oracle, some wide boxes added,
    every one box_height of its width high (floor), standing inside the frame."""
    gray = cv2.imread(str(DATA / "udacity_test1_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    if gray.shape[1] > MAXW or gray.shape[0] > MAXH:
        pytest.skip(f"the frame {gray.shape[::-1]} exceeds this build's VT_MAX_WIDTH x VT_MAX_HEIGHT")
    cam = rw.Camera(fx=357.0, horizon_y=212, height_m=1.8, hood_y=335)
    win = rw.WindowConfig(sizes=(32, 45), levels=4, step=0.25)
    wcfg = WideConfig(score_min=-2 ** 20)
    model = random_mlp(5, 48, 24, 8)
    got, ref = run_both(gray, cam, win, wcfg, model, [])
    assert np.array_equal(got, ref)
    assert 0 < len(got) <= MAXB and (got[:, 5] == 2).all()
    wd, ht = got[:, 2] - got[:, 0] + 1, got[:, 3] - got[:, 1] + 1
    assert (ht <= (wd * 400) // 1000 + 1).all() and (got[:, 3] < 360).all() and (got[:, 2] < 640).all()
    # raising the threshold above every score adds nothing; a full result takes nothing
    got2, _ = run_both(gray, cam, win, replace(wcfg, score_min=2 ** 31 - 1), model, [])
    assert len(got2) == 0
    full = [[0, 0, 1, 1, 0, 1]] * MAXB
    got3, ref3 = run_both(gray, cam, win, wcfg, model, full)
    assert len(got3) == MAXB and np.array_equal(got3, ref3)


def test_bad_arguments_leave_the_result_unchanged():
    gray = np.full((120, 200), 100, np.uint8)
    m, keep = random_mlp(1)
    ws = _native.box_ws_new()
    wc = _native.fulldet_wide_cfg_default()
    win = _native.win_cfg_default()
    cam = _native.camera_min(150.0, 40, 1500, 118)
    road = _native.road_from_camera(win, cam, 200, 120)
    st_ = ffi.new("vt_fulldet_state *")
    out = result_with([[1, 2, 30, 20, 5, 1]])
    v = _native.view(gray, "img")
    args = [st_, ws, wc, win, m, cam, v, road, out]
    for i in range(len(args)):
        bad = list(args)
        bad[i] = ffi.NULL
        assert lib.vt_fulldet_wide(*bad) == lib.VT_E_ARG
    assert out.n_boxes == 1
    for field, value in (("veh_w_min_mm", 99), ("veh_w_max_mm", 20001), ("box_height_permille", 0),
                         ("box_height_permille", 1001), ("nms_iou_permille", -1), ("nms_contain_permille", 1001)):
        b = _native.fulldet_wide_cfg_default()
        setattr(b, field, value)
        assert lib.vt_fulldet_wide_cfg_check(b) == lib.VT_E_ARG, field
        assert lib.vt_fulldet_wide(st_, ws, b, win, m, cam, v, road, out) == lib.VT_E_ARG
    b = _native.fulldet_wide_cfg_default()
    b.veh_w_min_mm, b.veh_w_max_mm = 5000, 4000
    assert lib.vt_fulldet_wide_cfg_check(b) == lib.VT_E_ARG
    other = _native.road_from_camera(win, cam, 200, 100)
    assert lib.vt_fulldet_wide(st_, ws, wc, win, m, cam, v, other, out) == lib.VT_E_SIZE
    for n in (-1, MAXB + 1):
        out.n_boxes = n
        assert lib.vt_fulldet_wide(st_, ws, wc, win, m, cam, v, road, out) == lib.VT_E_ARG
        assert out.n_boxes == n
    out.n_boxes = 1
    badm = ffi.new("vt_mlp_model *", m[0])
    badm.hidden = 0
    assert lib.vt_fulldet_wide(st_, ws, wc, win, badm, cam, v, road, out) < 0
    badwin = _native.win_cfg_default()
    badwin.levels = 0
    assert lib.vt_fulldet_wide(st_, ws, wc, badwin, m, cam, v, road, out) < 0
    zero = np.zeros((0, 5), np.uint8)
    with pytest.raises(_native.VtError, match="vt_fulldet_wide"):
        _native.fulldet_wide(st_, ws, wc, win, m, cam, zero, road, out)
    assert out.n_boxes == 1 and (out.box[0].box.left, out.box[0].score) == (1, 5)


def test_default_config_equals_shared_default():
    c = _native.fulldet_wide_cfg_default()
    assert lib.vt_fulldet_wide_cfg_check(c) == 0
    cc = c_wide_cfg(WideConfig())
    assert bytes(ffi.buffer(c)) == bytes(ffi.buffer(cc))


# ------------------------------------------------------------- model files, detector, pipeline
MLP = DEFAULT_WINDOW_MODEL
FRAME = DATA / "udacity_test1_640x360.jpg"


def with_wide(tmp_path, seed=5, settings=None, drop=()):
    """MLP's model file plus a random 48x24 wide model (wide_* keys) and wide settings."""
    import json
    z = np.load(MLP)
    rng = np.random.default_rng(seed)
    dim = 5 * 2 * 36
    out = {k: z[k] for k in z.files}
    out.update(wide_win_w=48, wide_win_h=24, wide_w1_q=rng.integers(-3000, 3000, (8, dim)).astype(np.int16),
               wide_w1_shift=12, wide_b1_q16=rng.integers(-2 ** 15, 2 ** 15, 8).astype(np.int32),
               wide_w2_q=rng.integers(-3000, 3000, 8).astype(np.int16), wide_w2_shift=12, wide_b2_q16=0)
    for k in drop:
        out.pop(k)
    d = json.loads(str(z["detector_json"]))
    d.update(settings if settings is not None else {"wide_score_min": -0.5})
    out["detector_json"] = np.array(json.dumps(d))
    p = tmp_path / f"wide_{seed}.npz"
    np.savez(p, **out)
    return str(p)


def test_model_file_and_detector_engines_agree(tmp_path):
    """fullroad.load_model reads the wide_* keys; FullRoadDetector runs the pass after the
    second stage in both engines (C = oracle, exact); cfg.wide=False turns it off and
    leaves the boxes of the detector without it, which are the first boxes with it."""
    from pyvehtrack import fullroad
    gray = cv2.imread(str(FRAME), cv2.IMREAD_GRAYSCALE)
    if gray.shape[1] > MAXW or gray.shape[0] > MAXH:
        pytest.skip(f"the frame {gray.shape[::-1]} exceeds this build's VT_MAX_WIDTH x VT_MAX_HEIGHT")
    path = with_wide(tmp_path)
    m = fullroad.load_model(path)
    assert m.wide is not None and (m.wide.win_w, m.wide.win_h) == (48, 24)
    srcs = ("shadow", "windows")
    c = fullroad.FullRoadDetector(path, sources=srcs)
    r = fullroad.FullRoadDetector(path, sources=srcs, engine="reference")
    off = fullroad.FullRoadDetector(path, sources=srcs, cfg=fullroad.FullRoadConfig(wide=False))
    assert c.wide[1].score_min == -32768 and off.wide is None
    a, b, o = c.detect_gray(gray), r.detect_gray(gray), off.detect_gray(gray)
    assert np.array_equal(a, b)
    assert c.last_stats["n_wide"] > 0 and len(a) == len(o) + c.last_stats["n_wide"]
    assert np.array_equal(a[:len(o)], o)
    plain = fullroad.FullRoadDetector(str(MLP), sources=srcs)
    assert plain.wide is None and np.array_equal(plain.detect_gray(gray), o)
    with pytest.raises(ValueError, match="no wide model"):
        fullroad.FullRoadDetector(str(MLP), sources=srcs, cfg=fullroad.FullRoadConfig(wide=True))
    with pytest.raises(TypeError, match="cfg.wide"):
        fullroad.FullRoadDetector(path, sources=srcs, cfg=fullroad.FullRoadConfig(wide=1))


def test_model_file_refusals(tmp_path):
    from pyvehtrack import fullroad
    with pytest.raises(ValueError, match="wide model needs all"):
        fullroad.load_model(with_wide(tmp_path, drop=("wide_b2_q16",)))
    with pytest.raises(ValueError, match="wide_box_height_permille"):
        fullroad.load_model(with_wide(tmp_path, settings={"wide_box_height_permille": 1001}))
    with pytest.raises(ValueError, match="wide_veh_w_min must not exceed"):
        fullroad.load_model(with_wide(tmp_path, settings={"wide_veh_w_min": 5.0, "wide_veh_w_max": 4.0}))
    with pytest.raises(ValueError, match="unknown key"):
        fullroad.load_model(with_wide(tmp_path, settings={"wide_foo": 1.0}))


def test_pipeline_runs_the_wide_pass(tmp_path):
    """vt_pipeline_set_wide: the pass runs inside vt_pipeline_step after the second stage,
    its boxes reach the output (and the tracker), equal to the stand-alone detector's
    and to the reference pipeline's (exact: road 'fixed', shadow source, shared C
    classifiers); Pipeline(fullroad=FullRoadConfig(wide=False)) runs without it."""
    from pyvehtrack import fullroad
    from pyvehtrack.pipeline import Pipeline
    gray = cv2.imread(str(FRAME), cv2.IMREAD_GRAYSCALE)
    if gray.shape[1] > MAXW or gray.shape[0] > MAXH:
        pytest.skip(f"the frame {gray.shape[::-1]} exceeds this build's VT_MAX_WIDTH x VT_MAX_HEIGHT")
    path = with_wide(tmp_path)
    kw = dict(model=path, sources=("shadow",), road="fixed", detect_every=1, track=False)
    res = Pipeline("c", **kw).step(gray)
    ref = Pipeline("reference", **kw).step(gray)
    assert [(b.box, b.source, b.score) for b in res.boxes] == [(b.box, b.source, b.score) for b in ref.boxes]
    off = Pipeline("c", fullroad=fullroad.FullRoadConfig(wide=False), **kw).step(gray)
    assert len(res.boxes) > len(off.boxes)
    assert [b.box for b in res.boxes[:len(off.boxes)]] == [b.box for b in off.boxes]
    alone = fullroad.FullRoadDetector(path, sources=("shadow",)).detect_gray(gray)
    assert res.box_array.tolist() == alone[:, :4].astype(int).tolist()
    # the C setter's refusals
    p = ffi.new("vt_pipeline *")
    cfg = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(cfg) == 0 and lib.vt_pipeline_init(p, cfg, ffi.NULL, ffi.NULL) == 0
    m, keep = random_mlp(2)
    wc = _native.fulldet_wide_cfg_default()
    assert lib.vt_pipeline_set_wide(ffi.NULL, m, wc) == lib.VT_E_ARG
    assert lib.vt_pipeline_set_wide(p, m, ffi.NULL) == lib.VT_E_ARG
    wc.box_height_permille = 0
    assert lib.vt_pipeline_set_wide(p, m, wc) == lib.VT_E_ARG
    assert lib.vt_pipeline_set_wide(p, ffi.NULL, ffi.NULL) == 0


def test_shipped_wide_model_file():
    """tests/data/window_mlp_hog32_wide.npz: the main model unchanged plus a 48x24 wide
    model and the settings chosen on 'val' (with re-ranking before NMS); on the Udacity frame the C detector equals the
    oracle with it (the pass really runs: its counter is reported)."""
    from pyvehtrack import fullroad
    m = fullroad.load_model(DATA / "window_mlp_hog32_wide.npz")
    base = fullroad.load_model(MLP)
    assert (m.wide.win_w, m.wide.win_h) == (48, 24) and np.array_equal(m.w1_q, base.w1_q)
    assert {k: v for k, v in m.settings.items() if not k.startswith("wide_") and k != "rerank_permille"} \
        == base.settings
    assert m.settings["rerank_permille"] == 250   # re-ranking before NMS (vt_fulldet_rerank)
    det = fullroad.FullRoadDetector(m, sources=("shadow", "windows"))
    assert det.wide[1] == fullroad.WideConfig(score_min=round(6.0 * 65536), nms_iou_permille=100,
                                               nms_contain_permille=300, alt_height_a_permille=350,
                                               alt_height_b_permille=500, alt_score_min=-2 * 65536)
    gray = cv2.imread(str(FRAME), cv2.IMREAD_GRAYSCALE)
    if gray.shape[1] > MAXW or gray.shape[0] > MAXH:
        pytest.skip(f"the frame {gray.shape[::-1]} exceeds this build's VT_MAX_WIDTH x VT_MAX_HEIGHT")
    ref = fullroad.FullRoadDetector(m, sources=("shadow", "windows"), engine="reference")
    a = det.detect_gray(gray)
    assert "n_wide" in det.last_stats and np.array_equal(a, ref.detect_gray(gray))
