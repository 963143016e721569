"""The wide pass's aspect choice (vt_fulldet_wide_cfg.alt_height_a/b_permille,
alt_score_min; c/fulldet.c) against its oracle (reference/fulldet.py wide) with one
shared classifier (the C vt_classify_box_mlp, proven in tests/test_classify.py):
boxes, scores, sources and order must agree EXACTLY -- the choice adds only integer
box cuts (floor of span x permille / 1000), one integer gate test and strict integer
score comparisons. Also: the chosen box is the best-scoring cut of its window, a gate
no score reaches changes nothing, and bad settings are refused (C and the model file)."""
from __future__ import annotations

import json
from dataclasses import replace

import cv2
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from test_fulldet_wide import DATA, MAXB, SRC, c_win, random_mlp, result_with, scene, with_wide

from pyvehtrack import _native, fullroad
from pyvehtrack._native import ffi, lib
from pyvehtrack.reference import fulldet as rfd
from pyvehtrack.reference import windows as rw
from pyvehtrack.shared import WideConfig

MAXW, MAXH = int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)
I32_MAX = 2 ** 31 - 1


def run_both(gray, cam: rw.Camera, win: rw.WindowConfig, wcfg: WideConfig, model, prior=()):
    """C (through fullroad.wide_c_cfg, the library's own conversion) and the oracle."""
    h, w = gray.shape
    m, _keep = model
    ws = _native.box_ws_new()
    cwin = c_win(win)
    ccam = _native.camera_min(cam.fx, cam.horizon_y, round(cam.height_m * 1000), cam.hood_y)
    road_c = _native.road_from_camera(cwin, ccam, w, h)
    road_r = rw.road_from_camera(cam, win, w, h)
    st_ = ffi.new("vt_fulldet_state *")
    out = result_with(list(prior))
    got = _native.fulldet_wide(st_, ws, fullroad.wide_c_cfg(wcfg), cwin, m, ccam, gray, road_c, out)
    for i in range(out.n_boxes, MAXB):   # nothing written past the result
        b = out.box[i]
        assert (b.box.left, b.box.top, b.box.right, b.box.bottom, b.score, b.source) == (-7, -7, -7, -7, -77, 9)
    ref = rfd.wide(gray, road_r, cam, win, wcfg,
                   lambda l, t, r, b: _native.classify_box_mlp(ws, m, gray, [l, t, r, b]),
                   np.asarray(list(prior), np.int64).reshape(-1, 6),
                   max_windows=int(lib.VT_FULLDET_MAX_WINDOWS), max_cand=int(lib.VT_FULLDET_MAX_CAND),
                   max_boxes=MAXB)
    return np.stack([got[k] for k in SRC], 1).reshape(-1, 6), ref


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2 ** 31 - 1), st.integers(150, 1000), st.integers(0, 1000), st.integers(0, 1000),
       st.one_of(st.integers(-30000, 30000), st.sampled_from([-2 ** 31, I32_MAX])), st.integers(-30000, 30000),
       st.integers(0, 1000), st.integers(0, 1000))
def test_random_frames_match_oracle(seed, bh, alt_a, alt_b, gate, smin, iou, contain):
    rng = np.random.default_rng(seed)
    h, w = int(rng.integers(40, min(MAXH, 150))), int(rng.integers(60, min(MAXW, 240)))
    gray = scene(rng, h, w)
    cam = rw.Camera(fx=float(rng.integers(120, 300)), horizon_y=int(rng.integers(-5, h // 2)), height_m=1.5,
                    hood_y=int(rng.integers(h * 3 // 4, h + 2)))
    win = rw.WindowConfig(sizes=(8, 11, 16), levels=3, step=0.25)
    wcfg = WideConfig(veh_w_min_m=1.0, veh_w_max_m=9.0, box_height_permille=bh, score_min=smin,
                      nms_iou_permille=iou, nms_contain_permille=contain, alt_height_a_permille=alt_a,
                      alt_height_b_permille=alt_b, alt_score_min=gate)
    prior = [[2, 3, 20, 12, 4, 1]] if seed % 2 else []
    got, ref = run_both(gray, cam, win, wcfg, random_mlp(seed), prior)
    assert np.array_equal(got, ref)


def _cut(box, pm, w, h):
    """The wide box of the window under `box` (same left, right, bottom) at pm permille."""
    l, _t, r, b = (int(v) for v in box[:4])
    span = r - l + 1   # the window's span (boxes off the right edge are not passed here)
    return [l, max(b - max(1, span * pm // 1000) + 1, 0), r, b]


def test_chosen_box_is_the_best_cut_of_its_window():
    """Udacity test1 (tests/data), the detector's grid rules, a random 48x24 MLP, a
    threshold and gate every window passes: each wide box is one of its window's three
    cuts, carries that cut's score, and no cut of the window scores higher; a gate no
    score reaches gives exactly the one-aspect pass; the alternatives change boxes."""
    gray = cv2.imread(str(DATA / "udacity_test1_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    if gray.shape[1] > MAXW or gray.shape[0] > MAXH:
        pytest.skip(f"the frame {gray.shape[::-1]} exceeds this build's VT_MAX_WIDTH x VT_MAX_HEIGHT")
    h, w = gray.shape
    cam = rw.Camera(fx=357.0, horizon_y=212, height_m=1.8, hood_y=335)
    win = rw.WindowConfig(sizes=(32, 45), levels=4, step=0.25)
    model = random_mlp(5, 48, 24, 8)
    base = WideConfig(score_min=-2 ** 20)
    alt = replace(base, alt_height_a_permille=300, alt_height_b_permille=550, alt_score_min=-2 ** 31)
    got, ref = run_both(gray, cam, win, alt, model)
    assert np.array_equal(got, ref) and len(got) > 0 and (got[:, 5] == 2).all()
    ws = _native.box_ws_new()
    m = model[0]
    heights = set()
    checked = 0
    for row in got:
        if row[2] == w - 1:   # the window may stick out on the right: its span is unknown here
            continue
        cuts = [_cut(row, pm, w, h) for pm in (400, 300, 550)]
        scores = [int(_native.classify_box_mlp(ws, m, gray, c)) for c in cuts]
        k = cuts.index([int(v) for v in row[:4]])   # one of the three cuts ...
        assert row[4] == scores[k] == max(scores)   # ... the best-scoring one, its own score
        assert scores.index(max(scores)) == k       # ties go to the earlier cut
        heights.add(k)
        checked += 1
    assert checked > 0 and len(heights) > 1         # the choice really varies
    one, _ = run_both(gray, cam, win, base, model)
    shut, _ = run_both(gray, cam, win, replace(alt, alt_score_min=I32_MAX), model)
    assert np.array_equal(shut, one) and not np.array_equal(got, one)
    # the gate is inclusive: a gate equal to a window's own score lets it choose
    for gate in sorted(set(int(v) for v in one[:, 4]))[-4:]:
        g, r = run_both(gray, cam, win, replace(alt, score_min=gate, alt_score_min=gate), model)
        assert np.array_equal(g, r) and not np.array_equal(g, run_both(gray, cam, win, replace(
            base, score_min=gate), model)[0])


def test_bad_settings_are_refused():
    m, _keep = random_mlp(1)
    ws = _native.box_ws_new()
    win = _native.win_cfg_default()
    cam = _native.camera_min(150.0, 40, 1500, 118)
    road = _native.road_from_camera(win, cam, 200, 120)
    st_ = ffi.new("vt_fulldet_state *")
    out = result_with([[1, 2, 30, 20, 5, 1]])
    v = _native.view(np.full((120, 200), 100, np.uint8), "img")
    for field, value in (("alt_height_a_permille", -1), ("alt_height_a_permille", 1001),
                         ("alt_height_b_permille", -1), ("alt_height_b_permille", 1001)):
        b = _native.fulldet_wide_cfg_default()
        setattr(b, field, value)
        assert lib.vt_fulldet_wide_cfg_check(b) == lib.VT_E_ARG, field
        assert lib.vt_fulldet_wide(st_, ws, b, win, m, cam, v, road, out) == lib.VT_E_ARG
        assert out.n_boxes == 1 and (out.box[0].box.left, out.box[0].score) == (1, 5)
    for field, value in (("alt_height_a_permille", 0), ("alt_height_b_permille", 1000)):
        b = _native.fulldet_wide_cfg_default()
        setattr(b, field, value)
        assert lib.vt_fulldet_wide_cfg_check(b) == 0
    with pytest.raises(_native.VtError, match="vt_fulldet_wide_cfg_check"):
        fullroad.wide_c_cfg(WideConfig(alt_height_b_permille=1001))


@pytest.mark.parametrize("key,value", [("wide_alt_height_a_permille", 1001), ("wide_alt_height_b_permille", -1),
                                       ("wide_alt_height_a_permille", 3.5), ("wide_alt_score_min", "x"),
                                       ("wide_alt_score_min", 1e9)])
def test_model_file_settings_are_checked(tmp_path, key, value):
    z = np.load(DATA / "window_mlp_hog32_wide.npz", allow_pickle=False)
    d = {k: z[k] for k in z.files}
    dj = json.loads(str(z["detector_json"]))
    dj[key] = value
    d["detector_json"] = np.array(json.dumps(dj))
    p = tmp_path / "bad.npz"
    np.savez(p, **d)
    with pytest.raises(ValueError, match=key):
        fullroad.load_model(p)


@pytest.mark.skipif(MAXW < 640 or MAXH < 360, reason="needs a build that takes 640x360 frames")
def test_pipeline_and_detector_run_the_aspect_choice(tmp_path):
    """Settings from the model file (wide_alt_*, rerank_permille too) reach vt_pipeline_step
    and FullRoadDetector: C pipeline = reference pipeline = stand-alone detector (exact),
    and the aspect choice changes the boxes against the same file without it."""
    from pyvehtrack.pipeline import Pipeline
    gray = cv2.imread(str(DATA / "udacity_test1_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    st_ = {"wide_score_min": -0.5, "wide_alt_height_a_permille": 300, "wide_alt_height_b_permille": 550,
           "wide_alt_score_min": -2.0, "rerank_permille": 250}
    path = with_wide(tmp_path, settings=st_)
    (tmp_path / "one").mkdir()   # the same wide model, one aspect
    plain = with_wide(tmp_path / "one", settings={"wide_score_min": -0.5, "rerank_permille": 250})
    kw = dict(sources=("shadow",), road="fixed", detect_every=1, track=False)
    res = Pipeline("c", model=path, **kw).step(gray)
    ref = Pipeline("reference", model=path, **kw).step(gray)
    assert [(b.box, b.source, b.score) for b in res.boxes] == [(b.box, b.source, b.score) for b in ref.boxes]
    alone = fullroad.FullRoadDetector(path, sources=("shadow",))
    assert alone.wide[1].alt_height_a_permille == 300 and alone.det_cfg.rerank_permille == 250
    assert res.box_array.tolist() == alone.detect_gray(gray)[:, :4].astype(int).tolist()
    one = Pipeline("c", model=plain, **kw).step(gray)
    assert res.box_array.tolist() != one.box_array.tolist()
