"""Re-ranking before NMS (vt_fulldet_rerank, c/fulldet.c; vt_fulldet_cfg.rerank_permille)
against its oracle (reference/fulldet.py detect with rescore) with one shared classifier
(the C vt_classify_box_mlp with the built-in HOG 64x64 MLP, proven in
tests/test_classify.py): boxes, scores, sources and order must agree EXACTLY -- the step
adds only integer keys (score + floor(w * v / 1000), saturated), a total order and the
NMS / merge already exact in tests/test_fulldet.py. Also inside vt_pipeline_step (C and
reference pipelines), weight 0 is a no-op, and bad arguments are refused."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack.fullroad import DEFAULT_WINDOW_MODEL
from pyvehtrack import _native, fullroad
from pyvehtrack._native import ffi, lib

DATA = Path(__file__).parent / "data"
MLP = DEFAULT_WINDOW_MODEL
FRAMES = (DATA / "udacity_test1_640x360.jpg", DATA / "kitti_lead_30_gray_621x188.png")
MAXW, MAXH = int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)
HAVE_MLP = fullroad.default_model() is not None and _native.mlp_default_model() is not None


def _gray(p):
    g = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
    if g.shape[1] > MAXW or g.shape[0] > MAXH:
        pytest.skip(f"the frame {g.shape[::-1]} exceeds this build's VT_MAX_WIDTH x VT_MAX_HEIGHT")
    return g


def _detectors(rerank, sources=("shadow", "windows")):
    base = fullroad.FullRoadDetector(str(MLP), sources=sources)
    cfg = replace(base.cfg, det=replace(base.det_cfg, rerank_permille=rerank))
    return (fullroad.FullRoadDetector(str(MLP), sources=sources, cfg=cfg),
            fullroad.FullRoadDetector(str(MLP), sources=sources, cfg=cfg, engine="reference"))


@pytest.mark.skipif(not HAVE_MLP, reason="the build has no built-in MLP (the re-ranking model)")
@settings(max_examples=4, deadline=None)
@given(st.sampled_from([0, 1]), st.integers(1, 1000))
def test_c_matches_oracle(frame, rerank):
    gray = _gray(FRAMES[frame])
    c, r = _detectors(rerank)
    a, b = c.detect_gray(gray), r.detect_gray(gray)
    assert np.array_equal(a, b)


@pytest.mark.skipif(not HAVE_MLP, reason="the build has no built-in MLP (the re-ranking model)")
def test_weight_changes_the_ranking_and_zero_changes_nothing():
    """Udacity test1: weight 0 leaves the result as it is (also when rerank is called);
    a full weight changes the boxes (the step really runs)."""
    gray = _gray(FRAMES[0])
    c0, _ = _detectors(0)
    plain = c0.detect_gray(gray)
    st_ = c0._state
    out = c0._out
    ws, m = _native.box_ws_new(), _native.mlp_default_model()
    again = _native.fulldet_rerank(st_, ws, m, c0._cfg_c, gray, out)   # weight 0: no-op
    assert np.array_equal(np.stack([again[k] for k in ("left", "top", "right", "bottom")], 1),
                          plain[:, :4].astype(np.int64))
    assert np.array_equal(again["score"], np.round(plain[:, 4] * 65536).astype(np.int64))
    # before the second stage: the same candidates ranked with weight 1000 change the result
    h, w = gray.shape
    ccam = c0._c_camera(c0.camera_for(h, w))
    road = _native.road_from_camera(ffi.addressof(c0._cfg_c, "win"), ccam, w, h)
    first = _native.fulldet(st_, c0._cfg_c, ccam, gray, road, c0._scorer, out)
    cfg1 = ffi.new("vt_fulldet_cfg *", c0._cfg_c[0])
    cfg1.rerank_permille = 1000
    ranked = _native.fulldet_rerank(st_, ws, m, cfg1, gray, out)
    assert len(first) > 0 and len(ranked) > 0
    assert not np.array_equal(first, ranked)


def test_bad_arguments():
    gray = np.full((120, 200), 100, np.uint8)
    cfg = _native.fulldet_cfg_default()
    cfg.rerank_permille = 250
    st_ = ffi.new("vt_fulldet_state *")
    out = ffi.new("vt_fulldet_result *")
    ws = _native.box_ws_new()
    m = _native.mlp_default_model() if HAVE_MLP else None
    if m is not None:
        v = _native.view(gray, "img")
        args = [st_, ws, m, cfg, v, out]
        for i in range(len(args)):
            bad = list(args)
            bad[i] = ffi.NULL
            assert lib.vt_fulldet_rerank(*bad) == lib.VT_E_ARG
        for n in (-1, int(lib.VT_FULLDET_MAX_CAND) + 1):
            out.n_cand, out.n_boxes = n, 3
            assert lib.vt_fulldet_rerank(st_, ws, m, cfg, v, out) == lib.VT_E_ARG
            assert out.n_boxes == 3   # unchanged
        out.n_cand = 0
        assert lib.vt_fulldet_rerank(st_, ws, m, cfg, v, out) == lib.VT_OK and out.n_boxes == 0
        with pytest.raises(_native.VtError, match="vt_fulldet_rerank"):
            _native.fulldet_rerank(st_, ws, m, cfg, np.zeros((0, 5), np.uint8), out)
    for value in (-1, 1001):
        b = _native.fulldet_cfg_default()
        b.rerank_permille = value
        assert lib.vt_fulldet_cfg_check(b) == lib.VT_E_ARG
    from pyvehtrack.reference import fulldet as rfd
    from pyvehtrack.shared import FullDetConfig
    with pytest.raises(TypeError, match="rerank_permille"):
        fullroad._c_cfg(FullDetConfig(rerank_permille=0.5))
    with pytest.raises(ValueError, match="rerank_permille"):
        fullroad._c_cfg(FullDetConfig(rerank_permille=1001))
    assert rfd.FullDetConfig is FullDetConfig


@pytest.mark.parametrize("value", [1001, -1, 2.5, True])
def test_model_file_setting_is_checked(tmp_path, value):
    z = np.load(MLP, allow_pickle=False)
    d = {k: z[k] for k in z.files}
    dj = json.loads(str(z["detector_json"]))
    dj["rerank_permille"] = value
    d["detector_json"] = np.array(json.dumps(dj))
    np.savez(tmp_path / "bad.npz", **d)
    with pytest.raises(ValueError, match="rerank_permille"):
        fullroad.load_model(tmp_path / "bad.npz")


@pytest.mark.skipif(not HAVE_MLP, reason="the build has no built-in MLP (the re-ranking model)")
@pytest.mark.skipif(MAXW < 640 or MAXH < 360, reason="needs a build that takes 640x360 frames")
def test_inside_the_pipeline(tmp_path):
    """A model file carrying rerank_permille: vt_pipeline_step re-ranks as the stand-alone
    stage does (same boxes and scores), and the reference pipeline agrees."""
    from pyvehtrack.pipeline import Pipeline
    z = np.load(MLP, allow_pickle=False)
    d = {k: z[k] for k in z.files}
    dj = json.loads(str(z["detector_json"]))
    dj["rerank_permille"] = 1000
    d["detector_json"] = np.array(json.dumps(dj))
    p = tmp_path / "rr.npz"
    np.savez(p, **d)
    gray = _gray(FRAMES[0])
    kw = dict(model=str(p), sources=("shadow",), road="fixed", detect_every=1, track=False)
    res = Pipeline("c", **kw).step(gray)
    ref = Pipeline("reference", **kw).step(gray)
    alone = fullroad.FullRoadDetector(str(p), sources=("shadow",)).detect_gray(gray)
    assert res.box_array.tolist() == alone[:, :4].astype(int).tolist() == ref.box_array.tolist()
    assert [b.score for b in res.boxes] == alone[:, 4].tolist() == [b.score for b in ref.boxes]
    plain = Pipeline("c", **{**kw, "model": str(MLP)}).step(gray)
    assert len(res.boxes) > 0 and len(plain.boxes) > 0
