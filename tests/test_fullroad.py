"""The full-road detector through the friendly API and the CLI: a real frame (Udacity
test1, 640x360, see tests/data/README.md) with a model trained on tusimple TRAIN frames
only (tests/data/window_svm_hog32.npz, tools/train_window_svm.py); model files, sources and
camera checked with clear errors; `detect --model` writes scored boxes."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack import fullroad
from pyvehtrack._native import lib
from pyvehtrack.cli import main as cli_main
from pyvehtrack.detector import Detector
from pyvehtrack.eval_boxes import box_iou_matrix

DATA = Path(__file__).parent / "data"
MODEL = DATA / "window_svm_hog32.npz"
FRAME = DATA / "udacity_test1_640x360.jpg"
# the two cars of test1, labelled by hand on the 640x360 frame (inclusive px)
CARS = np.array([[408, 206, 471, 246], [527, 204, 635, 252]])
BIG = int(lib.VT_MAX_WIDTH) >= 640 and int(lib.VT_MAX_HEIGHT) >= 360


def frame():
    img = cv2.imread(str(FRAME))
    assert img is not None
    return img


@pytest.mark.skipif(not BIG, reason="needs a build that takes 640x360 frames")
def test_real_frame_shadow_classified():
    """Shadow hypotheses over the whole road, each kept only if the classifier accepts it:
    the dark car in the ego-right lane and the white car in the right lane are boxed
    (IoU >= 0.5), nothing lies above the horizon (the trees) or on the hood."""
    det = Detector(model=str(MODEL), sources=("shadow",))
    res = det.detect(frame())
    assert res.road_source == "camera" and res.scores is not None and len(res.scores) == len(res.boxes)
    assert len(res.boxes) >= 2
    iou = box_iou_matrix(CARS, res.boxes)
    assert (iou.max(1) >= 0.5).all(), (res.boxes, iou)
    horizon = res.stats["horizon_y"]
    assert (res.boxes[:, 3] > horizon).all() and (res.boxes[:, 3] < 0.93 * 360).all()
    assert set(res.sources) == {"shadow"}
    # gray in, same boxes
    res_g = Detector(model=str(MODEL), sources=("shadow",)).detect(cv2.cvtColor(frame(), cv2.COLOR_BGR2GRAY))
    assert np.array_equal(res_g.boxes, res.boxes)


@pytest.mark.skipif(not BIG, reason="needs a build that takes 640x360 frames")
def test_real_frame_windows_source():
    """The window source runs, scores windows with the model, and its boxes are window
    boxes (width a pyramid window's, bottom-aligned) within the flat-road band."""
    det = Detector(model=str(MODEL), sources=("windows",))
    res = det.detect(frame())
    assert det.full.last_stats["n_windows"] > 100
    assert set(res.sources) <= {"windows"}
    for (l, t, r, b), s in zip(res.boxes, res.scores):
        w = r - l + 1
        assert w in (32, 64, 128, 256) or r == 639
        assert s >= 0.0


def test_model_file_errors(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        fullroad.load_model(tmp_path / "nope.npz")
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="is not a .npz file"):
        fullroad.load_model(bad)
    bad.write_bytes(b"PK\x03\x04 a zip cut short")
    with pytest.raises(ValueError, match="not a readable .npz"):
        fullroad.load_model(bad)
    np.savez(tmp_path / "miss.npz", kind="hog", win_w=32)
    with pytest.raises(ValueError, match="lacks win_h, w_q, w_shift, bias_q16"):
        fullroad.load_model(tmp_path / "miss.npz")
    np.savez(tmp_path / "kind.npz", kind="svm", win_w=32, win_h=32, w_q=np.zeros(324, np.int16), w_shift=10,
             bias_q16=0)
    with pytest.raises(ValueError, match="kind must be"):
        fullroad.load_model(tmp_path / "kind.npz")
    np.savez(tmp_path / "dim.npz", kind="hog", win_w=32, win_h=32, w_q=np.zeros(100, np.int16), w_shift=10,
             bias_q16=0)
    with pytest.raises(Exception, match="vt_svm_model_check"):
        fullroad.load_model(tmp_path / "dim.npz")
    np.savez(tmp_path / "big.npz", kind="hog", win_w=32, win_h=32, w_q=np.full(324, 40000), w_shift=10,
             bias_q16=0)
    with pytest.raises(ValueError, match="int16"):
        fullroad.load_model(tmp_path / "big.npz")


def test_argument_errors():
    with pytest.raises(ValueError, match="sources"):
        Detector(model=str(MODEL), sources=("shadow", "trees"))
    with pytest.raises(ValueError, match="sources"):
        Detector(model=str(MODEL), sources=())
    with pytest.raises(TypeError, match="model"):
        Detector(model=3)
    with pytest.raises(ValueError, match="ego-lane"):
        Detector(model=str(MODEL), sources="ego")
    with pytest.raises(TypeError, match="score_offset"):
        Detector(model=str(MODEL), score_offset="high")
    with pytest.raises(ValueError, match="horizon_frac"):
        fullroad.Camera(horizon_frac=3.0)
    with pytest.raises(TypeError, match="height_m"):
        fullroad.Camera(height_m=float("nan"))
    with pytest.raises(TypeError, match="camera"):
        Detector(model=str(MODEL), camera="high")
    assert Detector().full is None              # the default stays the ego-lane detector
    if fullroad.default_model() is None:
        with pytest.raises(ValueError, match="no default model"):
            fullroad.FullRoadDetector(None, sources=("windows",))
    else:
        assert Detector(sources=("shadow",)).full.model.path == "<built-in>"


@pytest.mark.skipif(not BIG, reason="needs a build that takes 640x360 frames")
def test_cli_detect_model_scores(tmp_path, capsys):
    js = tmp_path / "found.json"
    rc = cli_main(["detect", str(FRAME), "--out", str(tmp_path / "a.png"), "--json", str(js), "--model", str(MODEL),
                   "--no-progress"])
    assert rc == 0 and (tmp_path / "a.png").is_file()
    entry = json.loads(js.read_text())[0]
    assert entry["boxes"] and all(len(b) == 5 and isinstance(b[4], float) for b in entry["boxes"])
    # what found each box, as the Detector says (its result's sources), one per box
    res = Detector(model=str(MODEL)).detect(cv2.imread(str(FRAME), cv2.IMREAD_GRAYSCALE))
    assert entry["box_sources"] == [str(x) for x in res.sources] and len(entry["box_sources"]) == len(entry["boxes"])
    assert set(entry["box_sources"]) <= {"ego", "windows", "shadow"}
    # eval-boxes reads it back (file names match by base name)
    gt = tmp_path / "gt.json"
    gt.write_text(json.dumps([{"file_name": FRAME.name, "bbox": [dict(zip(("left", "top", "right", "bottom"),
                                                                           map(float, c))) for c in CARS]}]))
    assert cli_main(["eval-boxes", "--gt", str(gt), "--pred", str(js), "--image-size", "640x360"]) == 0
    assert "COCO AP50" in capsys.readouterr().out


def test_cli_model_missing(tmp_path, capsys):
    rc = cli_main(["detect", str(FRAME), "--out", str(tmp_path / "a.png"), "--model", str(tmp_path / "none.npz"),
                   "--no-progress"])
    assert rc == 2 and "--model" in capsys.readouterr().err
    rc = cli_main(["track", str(FRAME), "--out", str(tmp_path / "a.mp4"), "--model", str(tmp_path / "none.npz"),
                   "--no-progress"])
    assert rc == 2 and "--model" in capsys.readouterr().err
