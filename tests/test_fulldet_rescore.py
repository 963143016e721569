"""The ACF boxes' rescorer (issue 8: vt_box_rescorer, vt_box_rescore_trees,
vt_box_rescore_features, vt_fulldet_rescore, vt_pipeline_set_rescore in c/fulldet.c and
c/pipeline.c; oracle reference/fulldet.py: rescore_features, rescore_trees, rescore).

Checked here: the trees' sum equals the oracle's exactly for random trees and feature
vectors (extreme values and saturation included: integer arithmetic, no tolerance); the
seven features equal the oracle's integer formulas, feature 0 being the HOG model's
vt_classify_box on the context box (the regressor's, whose float agreement
test_fulldet_refine.py states); the rescored result equals the oracle's (threshold,
stable sort, NMS) exactly; bad arguments are errors that change nothing; the shipped
file's rescorer loads and changes what the pipeline reports."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyvehtrack import _native as N
from pyvehtrack import ffi, lib
from pyvehtrack.reference import classify as R
from pyvehtrack.reference import fulldet as rfd

DATA = Path(__file__).resolve().parent / "data"
MODELS = Path(__file__).resolve().parent.parent / "pyvehtrack" / "models"
NF = rfd.RESCORE_N_FEAT


def _random_rescorer(rng, depth, n_trees, win=16, margin=250, score_min=0, iou=300, contain=400, big=False,
                     side=(0, 0)):
    n_in = (1 << depth) - 1
    feat = rng.integers(0, NF, size=(n_trees, n_in))
    lim = 2 ** 31 - 1 if big else 3000
    thr = rng.integers(-lim, lim, size=(n_trees, n_in), endpoint=True)
    leaf = rng.integers(-lim, lim, size=(n_trees, n_in + 1), endpoint=True)
    w = rng.integers(-3000, 3001, size=R.hog_dim(win, win))
    return N.box_rescorer(win, win, w, int(rng.integers(12, 20)), int(rng.integers(-2 ** 18, 2 ** 18)), margin,
                          depth, feat, thr, leaf, int(rng.integers(-2 ** 20, 2 ** 20)), score_min, iou, contain,
                          *side), \
        (feat, thr, leaf)


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2 ** 31), depth=st.integers(1, 6), n_trees=st.integers(1, 40), big=st.booleans())
def test_trees_equal_oracle(seed, depth, n_trees, big):
    """Sum of leaves + bias, saturated: big leaves (up to 2^31) overflow int32 on purpose."""
    rng = np.random.default_rng(seed)
    (r, _keep), (feat, thr, leaf) = _random_rescorer(rng, depth, n_trees, big=big)
    for _ in range(20):
        f = rng.integers(-3500, 3500, size=NF) if not big else rng.integers(-2 ** 31, 2 ** 31 - 1, size=NF)
        assert N.box_rescore_trees(r, f) == rfd.rescore_trees(feat, thr, leaf, int(r.bias), depth, f)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 31), w=st.integers(16, 200), h=st.integers(16, 150),
       hor=st.integers(-300, 300), margin=st.integers(0, 1000))
def test_features_equal_oracle(seed, w, h, hor, margin):
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, size=(h, w)).astype(np.uint8)
    (r, _keep), _ = _random_rescorer(rng, 2, 3, margin=margin)
    ws = N.box_ws_new()
    cam = N.camera_min(1000.0, hor, 1800, h)
    for _ in range(5):
        l, rr = sorted(rng.integers(0, w, size=2).tolist())
        t, b = sorted(rng.integers(0, h, size=2).tolist())
        sc = int(rng.integers(-2 ** 31, 2 ** 31 - 1))
        got = N.box_rescore_features(ws, r, cam, img, (l, t, rr, b), sc)
        ctx = rfd.context_box((l, t, rr, b), margin, w, h)
        hog = N.classify_box(ws, ffi.addressof(r, "hog"), img, list(ctx))
        assert got.tolist() == rfd.rescore_features((l, t, rr, b), sc, hog, hor, w, h)


def test_features_by_hand():
    """A 40 x 20 box, bottom row 99, horizon 49 (d = 50) in a 200 x 100 frame."""
    img = np.full((100, 200), 90, np.uint8)
    (r, _keep), _ = _random_rescorer(np.random.default_rng(1), 1, 1)
    f = N.box_rescore_features(N.box_ws_new(), r, N.camera_min(1000.0, 49, 1800, 100), img, (10, 80, 49, 99), 777)
    assert f[1:].tolist() == [777, 40, 500, 800, 150, 500]


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2 ** 31), n=st.integers(0, 32), score_min=st.integers(-2000, 2000),
       iou=st.integers(0, 1000), contain=st.integers(0, 1000), side_keep=st.integers(0, 1),
       side_min=st.integers(-5000, 5000))
def test_fulldet_rescore_equals_oracle(seed, n, score_min, iou, contain, side_keep, side_min):
    rng = np.random.default_rng(seed)
    h, w = 90, 160
    img = rng.integers(0, 256, size=(h, w)).astype(np.uint8)
    (r, _keep), (feat, thr, leaf) = _random_rescorer(rng, 3, 12, score_min=score_min, iou=iou, contain=contain,
                                                     side=(side_keep, side_min))
    cam = N.camera_min(1000.0, 30, 1800, h)
    out = ffi.new("vt_fulldet_result *")
    rows = []
    for i in range(n):
        l, rr = sorted(rng.integers(0, w, size=2).tolist())
        t, b = sorted(rng.integers(0, h, size=2).tolist())
        rows.append((l, t, rr, b, int(rng.integers(-5000, 5000)), int(lib.VT_SRC_WINDOW)))
        out.box[i].box.left, out.box[i].box.top, out.box[i].box.right, out.box[i].box.bottom = l, t, rr, b
        out.box[i].score, out.box[i].source = rows[-1][4], rows[-1][5]
    out.n_boxes = n
    ws = N.box_ws_new()

    def score_of(row):
        f = N.box_rescore_features(ws, r, cam, img, row[:4], int(row[4]))
        return rfd.rescore_trees(feat, thr, leaf, int(r.bias), 3, f)

    want = rfd.rescore(np.array(rows, np.int64).reshape(-1, 6), score_of, score_min, iou, contain,
                       side_keep, side_min, w)
    got = N.fulldet_rescore(ws, r, cam, img, out)
    assert np.stack([got[k] for k in ("left", "top", "right", "bottom", "score", "source")], 1).tolist() \
        == want.tolist()


def test_side_rule_by_hand():
    """Trees that reject everything (bias -2^20): with side_keep only boxes the frame's
    side cuts (within w/4 + 1 px) whose first-stage score reaches side_score_min stay,
    at score_min; off, nothing stays."""
    img = np.full((90, 160), 100, np.uint8)
    cam = N.camera_min(1000.0, 30, 1800, 90)
    z = np.zeros((1, 1), np.int64)
    boxes = [((0, 40, 39, 70), 200),      # cut by the left side: stays
             ((120, 40, 159, 70), 200),   # right side: stays
             ((11, 40, 50, 70), 200),     # 4 * 11 = 44 <= 40 + 4: still cut, stays
             ((12, 40, 51, 70), 200),     # 48 > 44: whole, goes
             ((0, 40, 39, 80), 99)]       # cut, but under side_score_min: goes
    got = {}
    for keep in (0, 1):
        r, _k = N.box_rescorer(16, 16, np.zeros(R.hog_dim(16, 16)), 12, 0, 250, 1, z, z, np.zeros((1, 2)),
                               -2 ** 20, 7, 1000, 1000, keep, 100)   # NMS off: 1000 / 1000
        out = ffi.new("vt_fulldet_result *")
        for i, (b, sc) in enumerate(boxes):
            out.box[i].box.left, out.box[i].box.top, out.box[i].box.right, out.box[i].box.bottom = b
            out.box[i].score, out.box[i].source = sc, int(lib.VT_SRC_WINDOW)
        out.n_boxes = len(boxes)
        res = N.fulldet_rescore(N.box_ws_new(), r, cam, img, out)
        got[keep] = sorted((int(a), int(c), int(s)) for a, c, s in zip(res["left"], res["right"], res["score"]))
    assert got[0] == []
    assert got[1] == [(0, 39, 7), (11, 50, 7), (120, 159, 7)]


def test_bad_arguments_change_nothing():
    rng = np.random.default_rng(3)
    (r, _keep), _ = _random_rescorer(rng, 2, 4)
    img = np.full((60, 80), 100, np.uint8)
    v = N.view(img, "img")
    cam = N.camera_min(1000.0, 20, 1800, 60)
    ws = N.box_ws_new()
    f = ffi.new("int32_t[]", NF)
    sb = ffi.new("vt_scored_box *")
    sb.box.left, sb.box.top, sb.box.right, sb.box.bottom = 5, 5, 30, 20
    out = ffi.new("int32_t *")
    assert lib.vt_box_rescore_trees(ffi.NULL, f, out) == lib.VT_E_ARG
    assert lib.vt_box_rescore_trees(r, ffi.NULL, out) == lib.VT_E_ARG
    assert lib.vt_box_rescore_trees(r, f, ffi.NULL) == lib.VT_E_ARG
    for args in ((ffi.NULL, r, cam, v, sb, f), (ws, ffi.NULL, cam, v, sb, f), (ws, r, ffi.NULL, v, sb, f),
                 (ws, r, cam, ffi.NULL, sb, f), (ws, r, cam, v, ffi.NULL, f), (ws, r, cam, v, sb, ffi.NULL)):
        assert lib.vt_box_rescore_features(*args) == lib.VT_E_ARG
    for bad in ((-1, 0, 5, 5), (0, 0, 80, 5), (5, 5, 4, 9), (0, 0, 5, 60)):
        b2 = ffi.new("vt_scored_box *", sb[0])
        b2.box.left, b2.box.top, b2.box.right, b2.box.bottom = bad
        assert lib.vt_box_rescore_features(ws, r, cam, v, b2, f) == lib.VT_E_ARG, bad
    for field, val in (("margin_permille", -1), ("margin_permille", 1001), ("n_trees", 0), ("n_trees", 4097),
                       ("depth", 0), ("depth", 7), ("nms_iou_permille", -1), ("nms_contain_permille", 1001),
                       ("feat", ffi.NULL), ("thr", ffi.NULL), ("leaf", ffi.NULL), ("side_keep", -1),
                       ("side_keep", 2)):
        r2 = ffi.new("vt_box_rescorer *", r[0])
        setattr(r2, field, val)
        assert lib.vt_box_rescorer_check(r2) == lib.VT_E_ARG, (field, val)
    bad_feat = ffi.new("uint8_t[]", [NF, 0, 0])   # a feature index past the seven
    r2 = ffi.new("vt_box_rescorer *", r[0])
    r2.feat, r2.n_trees, r2.depth = bad_feat, 1, 2
    assert lib.vt_box_rescorer_check(r2) == lib.VT_E_ARG
    with pytest.raises(ValueError, match="depth"):
        N.box_rescorer(16, 16, np.zeros(R.hog_dim(16, 16)), 12, 0, 250, 9, np.zeros((1, 3)), np.zeros((1, 3)),
                       np.zeros((1, 4)), 0, 0, 300, 400)
    with pytest.raises(ValueError, match="side_keep"):
        N.box_rescorer(16, 16, np.zeros(R.hog_dim(16, 16)), 12, 0, 250, 2, np.zeros((1, 3)), np.zeros((1, 3)),
                       np.zeros((1, 4)), 0, 0, 300, 400, 2, 0)
    with pytest.raises(ValueError, match="do not fit"):
        N.box_rescorer(16, 16, np.zeros(R.hog_dim(16, 16)), 12, 0, 250, 2, np.zeros((1, 3)), np.zeros((1, 3)),
                       np.zeros((1, 3)), 0, 0, 300, 400)
    # a result with a box outside the image, or too many boxes: an error, res unchanged
    res = ffi.new("vt_fulldet_result *")
    res.n_boxes = 1
    res.box[0].box.left, res.box[0].box.top, res.box[0].box.right, res.box[0].box.bottom = 0, 0, 80, 10
    assert lib.vt_fulldet_rescore(ws, r, cam, v, res) == lib.VT_E_ARG
    assert res.n_boxes == 1 and res.box[0].box.right == 80
    res.n_boxes = int(lib.VT_MAX_BOXES) + 1
    assert lib.vt_fulldet_rescore(ws, r, cam, v, res) == lib.VT_E_ARG
    assert lib.vt_pipeline_set_rescore(ffi.NULL, r) == lib.VT_E_ARG


def test_shipped_file_loads_and_rescores():
    """acf_gray_rescore.npz: the ACF file loosened (thresholds - 1.5) + its rescorer; the
    pipeline with it reports other boxes than with the rescorer off (rescore=False)."""
    from pyvehtrack.fullroad import FullRoadConfig, load_model
    from pyvehtrack.pipeline import Pipeline
    m = load_model(MODELS / "acf_gray_rescore.npz")
    assert m.rescore is not None and m.rescore.depth == 3 and m.rescore.feat.shape == (150, 7)
    assert m.rescore.score_min_q16 == -32768   # -0.5 in log-odds, chosen on 'val'
    assert (m.rescore.side_keep, m.rescore.side_score_min_q16) == (1, 0)   # the side rule at 0, chosen on 'val'
    img = cv2.imread(str(DATA / "udacity_test1_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    got = {}
    for on in (None, False):
        p = Pipeline("c", model=str(MODELS / "acf_gray_rescore.npz"), sources=("ego", "classifier"),
                     fullroad=FullRoadConfig(rescore=on), detect_every=1, track=False)
        got[on] = p.step_gray(img).box_array.tolist()
    assert got[None] != got[False]
    with pytest.raises(ValueError, match="rescorer"):
        Pipeline("c", model=str(MODELS / "acf_gray.npz"), sources=("ego", "classifier"),
                 fullroad=FullRoadConfig(rescore=True))


def test_side_rule_keeps_the_edge_cut_car(tmp_path):
    """Udacity test5 (tests/data: 640x360): the white car cut by the right frame edge
    (hand box 543, 200, 639, 256). The rescorer alone scores it under its threshold (its
    trees learnt from whole boxes); with the shipped side rule it is boxed, IoU >= 0.5."""
    from pyvehtrack.eval_boxes import box_iou_matrix
    from pyvehtrack.pipeline import Pipeline
    img = cv2.imread(str(DATA / "udacity_test5_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    hand = np.array([[543, 200, 639, 256]], float)
    best = {}
    for keep in (1, 0):
        z = dict(np.load(MODELS / "acf_gray_rescore.npz", allow_pickle=False))
        z["rescore_side_keep"] = np.asarray(keep, np.int32)
        path = tmp_path / f"m{keep}.npz"
        np.savez(path, **z)
        p = Pipeline("c", model=str(path), sources=("ego", "classifier"), detect_every=1, track=False)
        boxes = np.asarray(p.step_gray(img).box_array, float).reshape(-1, 4)
        best[keep] = float(box_iou_matrix(hand, boxes).max()) if len(boxes) else 0.0
    assert best[1] >= 0.5 and best[0] < 0.5, best
