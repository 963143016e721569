"""The shipped ACF model (pyvehtrack/models/acf_gray.npz) through the pipeline
(vt_pipeline_set_acf), on frames shipped in tests/data (README there: sources)."""
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack import acf
from pyvehtrack.detector import Detector
from pyvehtrack.fullroad import load_model
from pyvehtrack.pipeline import Pipeline

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "pyvehtrack" / "models" / "acf_gray.npz"
DATA = Path(__file__).resolve().parent / "data"


def _train_acf():
    """tools/train_acf.py as a module (it is a script, not part of the package)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("train_acf", ROOT / "tools" / "train_acf.py")
    ta = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ta)
    return ta


def test_model_loads_with_its_settings():
    m = load_model(MODEL)
    assert isinstance(m, acf.AcfModel)
    assert m.n_trees == 400 and m.depth == 3 and (m.win_cw, m.win_ch, m.pad) == (10, 9, 1)
    # its box regressor learnt from its own window boxes (train_box_regressor.py --sources windows
    # --jitter 0): one learnt from rear-view jitter moved the flat window's boxes to rear-view shapes
    r = m.refine
    assert r is not None and r.sources == 2 and (r.win_w, r.win_h, r.margin_permille) == (48, 48, 250)
    info = json.loads(str(np.load(MODEL)["refine_info"]))
    assert info["split"] == "fit" and info["jitter"] == 0 and info["sources"] == ["windows"]
    assert m.settings.get("sources") == ["ego", "windows"] and m.settings.get("verify_min") == 2.0
    assert m.settings.get("verify_skip_flat") is True and m.settings.get("verify_skip_edge") is True
    assert m.settings.get("verify_skip_small") is True
    assert m.threshold_q16 == -65536 and m.band_mm is None and m.nms_contain_permille == 400 and m.cols == 0
    # the flat (side-view), the small far-car and the two edge windows on the same pyramid, each its
    # own band, threshold and columns
    assert len(m.more) == 4
    f, t, el, er = m.more
    for e, cols in ((el, 1), (er, 2)):
        assert (e.win_cw, e.win_ch, e.pad, e.n_trees, e.depth, e.cols) == (10, 8, 1, 400, 3, cols)
        assert e.band_mm == (1000, 5000) and e.threshold_q16 == 0 and e.c_cfg().cols == cols
    assert f.cols == t.cols == 0
    assert (f.win_cw, f.win_ch, f.pad, f.n_trees, f.depth) == (16, 8, 1, 400, 3)
    assert f.band_mm == (1500, 9000) and f.threshold_q16 == 0
    assert (t.win_cw, t.win_ch, t.pad, t.n_trees, t.depth, t.win_w, t.win_h) == (7, 6, 1, 400, 3, 20, 16)
    assert t.band_mm == (1080, 3960) and t.threshold_q16 == 0


def test_pipeline_boxes_are_the_acf_stage_s():
    """With the ego-lane detector off and no regressor, the pipeline's boxes are exactly
    vt_acf_detect's on the same camera (same horizon: the fixed road camera)."""
    from pyvehtrack.fullroad import FullRoadConfig
    gray = cv2.imread(str(DATA / "udacity_test1_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    m = load_model(MODEL)
    pipe = Pipeline("c", model=m, fullroad=FullRoadConfig(refine=False), detect_every=1, track=False,
                    road="fixed", sources=("classifier",))
    out = pipe.step(gray)
    got = sorted(tuple(int(v) for v in b.box) for b in out.boxes)
    cam = pipe.road_camera.for_frame(*gray.shape, None)
    ref, _ = acf.detect(m, gray, cam.horizon_y, cam.hood_y, cam.fx, round(cam.height_m * 1000))
    want = sorted((int(b["left"]), int(b["top"]), int(b["right"]), int(b["bottom"])) for b in ref)
    assert got == want


def test_detector_finds_the_udacity_cars():
    """test1 (Udacity, 640x360): the two cars in the right lanes are boxed (IoU >= 0.5 with
    hand boxes read off the frame), and no box stands in the trees (bottom above row 200:
    the shadow detector's boxes there without the second stage had bottoms 189 and 194)."""
    from pyvehtrack.eval_boxes import box_iou_matrix
    img = cv2.imread(str(DATA / "udacity_test1_640x360.jpg"))
    res = Detector(model=str(MODEL)).detect(img)
    boxes = np.asarray([b[:4] for b in res.boxes], float).reshape(-1, 4)
    cars = np.array([[413, 207, 468, 248], [527, 199, 632, 250]], float)
    assert (box_iou_matrix(cars, boxes).max(1) >= 0.5).all(), boxes
    assert (boxes[:, 3] >= 200).all(), boxes


def test_reference_engine_says_so():
    with pytest.raises(ValueError, match="C engine only"):
        Pipeline("reference", model=str(MODEL), detect_every=1, track=False)


def test_pack_rebuilds_the_shipped_file(tmp_path, monkeypatch):
    """tools/train_acf.py pack is the shipped file's recipe (README): packing the shipped file's own five
    windows again, each with its threshold and band, gives back every array of the shipped file."""
    ta = _train_acf()
    m = acf.AcfModel.load(MODEL)
    z = np.load(MODEL, allow_pickle=False)
    rear = acf.AcfModel.load(MODEL)
    rear.more = []
    rear.save(tmp_path / "rear.npz", **{k: z[k] for k in ("n_pos", "n_neg", "rounds")})  # training notes
    more = []
    for i, mm in enumerate(m.more):
        thr, mm.score_min_q16 = mm.score_min_q16 / 65536.0, 1 << 20     # pack must set the threshold
        band, mm.band_mm = mm.band_mm, (700, 7000)                          # ... and the band
        mm.save(tmp_path / f"m{i}.npz")
        more += ["--more", str(tmp_path / f"m{i}.npz"), str(thr), str(band[0]), str(band[1])]
    out = tmp_path / "packed.npz"
    assert ta.main(["pack", str(tmp_path / "rear.npz"), "--out", str(out), "--thr", str(m.threshold_q16 / 65536),
                    "--settings", json.dumps(m.settings), "--nms-contain", str(m.nms_contain_permille),
                    "--base", str(MODEL)] + more) == 0
    p = np.load(out, allow_pickle=False)
    arrays = [k for k in z.files if k != "detector_json"]
    assert not [k for k in arrays if k not in p.files or not np.array_equal(z[k], p[k])]
    assert json.loads(str(p["detector_json"])) == m.settings
    with pytest.raises(SystemExit):    # --more takes 2 or 4 values
        ta.main(["pack", str(tmp_path / "rear.npz"), "--out", str(out), "--more", str(tmp_path / "m0.npz"), "0", "1"])


def test_add_appends_a_window_and_keeps_the_rest(tmp_path):
    """tools/train_acf.py add (the recipe of the windows measured beside the rescorer, README): the
    window goes under the file's next prefix with its threshold, loosened as train_rescorer.py loosens
    the others when asked; every key of the file stays as it was; a full file is refused (exit 2)."""
    ta = _train_acf()
    base = MODEL.parent / "acf_gray_rescore.npz"
    win = acf.AcfModel.load(MODEL)
    win.more = []
    win.first_scale = 4
    win.save(tmp_path / "near.npz")
    out = tmp_path / "added.npz"
    assert ta.main(["add", str(base), str(tmp_path / "near.npz"), "--thr", "0.5", "--loosen", "-1.5", "1.5",
                    "--out", str(out)]) == 0
    z, p = np.load(base, allow_pickle=False), np.load(out, allow_pickle=False)
    assert all(np.array_equal(z[k], p[k]) for k in z.files)
    m = acf.AcfModel.load(out)
    i = len(acf.AcfModel.load(base).more) + 1
    assert len(m.more) == i and i == acf.MAX_MODELS - 1
    got = m.more[-1]
    # 0.5 - 1.5 = -1.0 real units = -65536 in Q16; each trace entry 1.5 * 65536 = 98304 lower
    assert got.score_min_q16 == -65536 and got.first_scale == 4 and got.nms_contain_permille == 1000
    assert np.array_equal(got.reject_q16.astype(np.int64), win.reject_q16.astype(np.int64) - 98304)
    assert np.array_equal(got.leaf_q16, win.leaf_q16) and np.array_equal(p[f"acf{i}_feat"], win.feat)
    with pytest.raises(SystemExit) as e:    # VT_ACF_MAX_MODELS windows already
        ta.main(["add", str(out), str(tmp_path / "near.npz"), "--out", str(tmp_path / "more.npz")])
    assert e.value.code == 2 and not (tmp_path / "more.npz").exists()


def test_first_scale_reaches_the_core(tmp_path):
    """A model's first_scale (a near-vehicle window: train_acf.py train --first-level) is saved, loaded
    and given to vt_acf_detect_n: from level 4 on every box is at least twice the window (level 4's
    input px per level px: SCALE_Q16[4] = 2.0 exactly), while the same trees from level 0 box smaller
    cars on the same frame; a first level past acf.h's last is a clear error."""
    m = acf.AcfModel.load(MODEL)
    m.more, m.score_min_q16 = [], -4 << 16    # a low threshold: many boxes at every level
    gray = cv2.imread(str(DATA / "udacity_test1_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    allb, _ = acf.detect(m, gray, 200, 330, 600.0)
    m.first_scale = 4
    m.save(tmp_path / "near.npz")
    n = acf.AcfModel.load(tmp_path / "near.npz")
    assert n.first_scale == 4 and (n.c_cfg().first_scale, n.c_cfg().n_scales) == (4, 11)
    nearb, _ = acf.detect(n, gray, 200, 330, 600.0)
    w = lambda b: b["right"] - b["left"] + 1   # noqa: E731
    assert len(nearb) and (w(nearb) >= 2 * m.win_w).all()
    assert (w(allb) < 2 * m.win_w).any()
    n.first_scale = 16
    n.save(tmp_path / "bad.npz")
    with pytest.raises(ValueError, match="first_scale 16"):
        acf.AcfModel.load(tmp_path / "bad.npz")
