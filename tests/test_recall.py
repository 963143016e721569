"""Full-road recall work (issue 8): the MLP window scorer (vt_mlp_scorer, c/fulldet.c),
models that name their scan sizes (two window sizes per octave), and the full-road
detector with an MLP model, C against the reference engine.

The MLP scorer is the classify stage's vt_classify_box_mlp on the window's level-image
box, so its scores must equal that function's EXACTLY; the C and reference engines of
FullRoadDetector share the scorer and are exact twins otherwise (tests/test_fulldet.py),
so their boxes must agree EXACTLY with an MLP model too."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack.fullroad import DEFAULT_WINDOW_MODEL
from pyvehtrack import _native, fullroad
from pyvehtrack._native import ffi, lib

DATA = Path(__file__).parent / "data"
MLP_MODEL = DEFAULT_WINDOW_MODEL
HOG32_DIM = 3 * 3 * 36


def random_mlp(seed: int, hidden: int = 8, scan=()) -> fullroad.MlpModel:
    rng = np.random.default_rng(seed)
    w1 = rng.integers(-3000, 3000, (hidden, HOG32_DIM)).astype(np.int16)
    b1 = rng.integers(-20000, 20000, hidden).astype(np.int32)
    w2 = rng.integers(-3000, 3000, hidden).astype(np.int16)
    return fullroad.MlpModel(1, 32, 32, w1, 12, b1, w2, 12, int(rng.integers(-5000, 5000)), 0, scan_sizes=scan)


def kitti_frame():
    img = cv2.imread(str(DATA / "kitti_lead_30_gray_621x188.png"), cv2.IMREAD_GRAYSCALE)
    assert img is not None
    return img


def test_mlp_scorer_equals_classify_box_mlp_and_checks_arguments():
    m = random_mlp(1)
    cm, keep = fullroad._c_model(m)
    sc = ffi.new("vt_mlp_scorer *")
    assert lib.vt_mlp_scorer_init(sc, cm) == 0
    ws = ffi.new("vt_cls_box_ws *")
    img = kitti_frame()
    v = _native.view(img, "img")
    out = ffi.new("int32_t *")
    seen = set()
    for (x, y, s) in [(0, 0, 32), (100, 60, 32), (300, 100, 45), (589, 156, 32), (200, 40, 64), (7, 9, 20)]:
        win = ffi.new("vt_window *", [0, s, x, y])
        assert lib.vt_mlp_scorer_score(sc, v, win, out) == 0
        want = _native.classify_box_mlp(ws, cm, img, [x, y, x + s - 1, y + s - 1])
        assert out[0] == want
        seen.add(int(out[0]))
    assert len(seen) > 1   # the windows do not all score alike
    # bad arguments: clear statuses, score zeroed, nothing read out of bounds
    win = ffi.new("vt_window *", [0, 32, 600, 0])  # past the right edge
    out[0] = 123
    assert lib.vt_mlp_scorer_score(sc, v, win, out) < 0 and out[0] == 0
    assert lib.vt_mlp_scorer_score(ffi.NULL, v, win, out) < 0
    assert lib.vt_mlp_scorer_score(sc, v, ffi.NULL, out) < 0
    assert lib.vt_mlp_scorer_score(sc, ffi.NULL, ffi.new("vt_window *", [0, 32, 0, 0]), out) < 0
    assert lib.vt_mlp_scorer_score(sc, v, ffi.new("vt_window *", [0, 32, 0, 0]), ffi.NULL) < 0
    assert lib.vt_mlp_scorer_init(ffi.NULL, cm) < 0
    assert lib.vt_mlp_scorer_init(sc, ffi.NULL) < 0 and sc.model == ffi.NULL
    assert lib.vt_mlp_scorer_score(sc, v, ffi.new("vt_window *", [0, 32, 0, 0]), out) < 0
    del keep


@pytest.mark.parametrize("scan", [(), (32, 45)])
def test_full_road_mlp_c_equals_reference(scan):
    """With an MLP model (and two window sizes per octave), the C detector and the float
    oracle give the same boxes, scores and sources."""
    gray = kitti_frame()
    m = random_mlp(2, scan=scan)
    cam = fullroad.Camera(horizon_frac=88 / 188, hood_frac=0.99, height_m=1.65, fx_per_width=360 / 621)
    outs = []
    for engine in ("c", "reference"):
        det = fullroad.FullRoadDetector(m, sources=("shadow", "windows"), camera=cam, engine=engine)
        assert det.det_cfg.win.sizes == (scan or (32,))
        outs.append((det.detect_gray(gray), dict(det.last_stats)))
    (a, sa), (b, sb) = outs
    assert sa == sb and sa["n_windows"] > 50
    assert np.array_equal(a, b)


def _save(tmp_path, name, **kw):
    m = random_mlp(3)
    d = dict(model_type="mlp", kind="hog", win_w=32, win_h=32, w1_q=m.w1_q, w1_shift=m.w1_shift,
             b1_q16=m.b1_q16, w2_q=m.w2_q, w2_shift=m.w2_shift, b2_q16=m.b2_q16, threshold_q16=0)
    d.update(kw)
    p = tmp_path / name
    np.savez(p, **d)
    return p


def test_model_files_mlp_and_scan_sizes(tmp_path):
    m = fullroad.load_model(_save(tmp_path, "ok.npz", scan_sizes=np.array([32, 45])))
    assert isinstance(m, fullroad.MlpModel) and m.scan_sizes == (32, 45)
    det = fullroad.FullRoadDetector(m, sources=("windows",))
    assert det.det_cfg.win.sizes == (32, 45)
    for bad in ([45, 32], [16, 24], [32, 45, 64, 90, 128], [2, 32], [32.0, 45.0]):
        with pytest.raises(ValueError, match="scan_sizes"):
            fullroad.load_model(_save(tmp_path, "bad.npz", scan_sizes=np.array(bad)))
    with pytest.raises(ValueError, match="w1_q"):
        fullroad.load_model(_save(tmp_path, "bad2.npz", w1_q=np.zeros(5)))
    p = _save(tmp_path, "bad3.npz")
    z = dict(np.load(p))
    del z["b2_q16"]
    np.savez(tmp_path / "bad4.npz", **z)
    with pytest.raises(ValueError, match="b2_q16"):
        fullroad.load_model(tmp_path / "bad4.npz")


def test_shipped_mlp_model_loads():
    """The model shipped for the full-road detector (tools/train_window_svm.py --mlp,
    see tests/data/README.md) loads and scans two sizes per octave."""
    m = fullroad.load_model(MLP_MODEL)
    assert isinstance(m, fullroad.MlpModel) and m.win_w == 32 and m.scan_sizes == (32, 45)


def test_full_road_merge_and_second_stage_c_equals_reference():
    """Box refinement (merge_iou) and the second stage (verify_min: the built-in HOG 64
    MLP on each box, vt_fulldet_verify) keep the C detector and the oracle identical."""
    from dataclasses import replace

    from pyvehtrack.reference import fulldet as rfd
    gray = kitti_frame()
    m = random_mlp(2, scan=(32, 45))
    cam = fullroad.Camera(horizon_frac=88 / 188, hood_frac=0.99, height_m=1.65, fx_per_width=360 / 621)
    outs = []
    for engine in ("c", "reference"):
        cfg = fullroad.FullRoadConfig(det=replace(rfd.FullDetConfig(), merge_iou_permille=300, nms_iou_permille=200),
                                      verify_min=-40.0)
        det = fullroad.FullRoadDetector(m, sources=("shadow", "windows"), camera=cam, engine=engine, cfg=cfg)
        outs.append((det.detect_gray(gray), dict(det.last_stats)))
    (a, sa), (b, sb) = outs
    assert sa == sb and sa["n_windows"] > 50 and 0 < sa["n_verified"]
    assert np.array_equal(a, b)


def test_model_detector_settings(tmp_path):
    """detector_json in a model file sets the detector (sources, offset, NMS, box
    height, merge, second stage); explicit arguments win; bad settings are clear errors."""
    import json

    from pyvehtrack.detector import Detector
    good = {"sources": ["windows"], "score_offset": 1.5, "nms_iou_permille": 250, "nms_contain_permille": 500,
            "box_height": 0.875, "merge_iou_permille": 300, "verify_min": 2.0}
    p = _save(tmp_path, "set.npz", detector_json=np.array(json.dumps(good)))
    m = fullroad.load_model(p)
    assert m.settings == good
    det = fullroad.FullRoadDetector(m, sources=("shadow", "windows"))
    d = det.det_cfg
    assert (d.nms_iou_permille, d.nms_contain_permille, d.box_height, d.merge_iou_permille) == (250, 500, 0.875, 300)
    # a file of before issue 10 (float fractions) reads the same, with a warning
    old = dict(good, nms_iou=0.25, nms_contain=0.5, merge_iou=0.3)
    for k in ("nms_iou_permille", "nms_contain_permille", "merge_iou_permille"):
        del old[k]
    with pytest.warns(DeprecationWarning, match="merge_iou_permille"):
        mo = fullroad.load_model(_save(tmp_path, "old.npz", detector_json=np.array(json.dumps(old))))
    assert mo.settings == good
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="nms_iou_permille"):
        fullroad.load_model(_save(tmp_path, "q8.npz", detector_json=np.array('{"nms_iou": 0.30078125}')))
    assert d.window_score_min == m.threshold_q16 + round(1.5 * 65536) and det.verify_min_q16 == 2 * 65536
    det2 = fullroad.FullRoadDetector(m, cfg=fullroad.FullRoadConfig(score_offset=1.0, verify_min=-1.0))
    assert det2.det_cfg.window_score_min == m.threshold_q16 + round(2.5 * 65536) and det2.verify_min_q16 == -65536
    assert Detector(model=str(p)).full.sources == ("windows",)
    assert Detector(model=str(p), sources=("shadow",)).full.sources == ("shadow",)
    for bad, what in (("{", "not JSON"), ("[1]", "JSON object"), ('{"nms_iou_permille": 1001}', "nms_iou_permille"),
                      ('{"merge_iou_permille": 0.3}', "merge_iou_permille"),
                      ('{"sources": ["trees"]}', "sources"), ('{"colour": 1}', "unknown key"),
                      ('{"verify_min": true}', "verify_min"), ('{"verify_skip_small": 1}', "verify_skip_small")):
        with pytest.raises(ValueError, match=what):
            fullroad.load_model(_save(tmp_path, "bad.npz", detector_json=np.array(bad)))
    with pytest.raises(TypeError, match="verify_min"):
        fullroad.FullRoadDetector(m, cfg=fullroad.FullRoadConfig(verify_min=float("nan")))
    with pytest.raises(TypeError, match="cfg.det"):
        fullroad.FullRoadDetector(m, cfg=fullroad.FullRoadConfig(det="fast"))


def test_shipped_model_carries_its_settings():
    """The shipped window model names the settings chosen for it on the 'val' frames."""
    m = fullroad.load_model(MLP_MODEL)
    assert m.settings["sources"] == ["ego", "shadow", "windows"] and m.settings["verify_min"] > 0
    det = fullroad.FullRoadDetector(m, sources=("shadow", "windows"))
    assert det.verify_min_q16 is not None and det.det_cfg.merge_iou_permille > 0
    # pyvehtrack.Detector reads "ego" from the settings: the ego-lane detector beside it
    from pyvehtrack.detector import Detector
    d = Detector(model=MLP_MODEL)
    assert d.ego_too and d.full.sources == ("shadow", "windows")
    assert d.pipeline_overrides()["sources"] == ("ego", "shadow", "classifier")
