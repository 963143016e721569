"""Any camera size (issue 8 item 5): frames wider than the pipeline's work_width (default
1280, the width the stages' pixel settings were chosen and the networks trained at) are
processed downscaled to it, and the results come back in the input frame's pixels.

The rule is vt_pipeline_work_size for a maximum width of min(work_width, MAX_WIDTH), so
these tests check the plumbing, exactly: the same boxes as the frame downscaled by hand
(cv2 INTER_AREA, what Pipeline.prepare does) with the boxes mapped back by the pipeline's
own rule; frames no wider than work_width untouched; clear errors for bad values."""
from __future__ import annotations

import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack import Pipeline
from pyvehtrack._native import lib
from pyvehtrack.cli import main as cli_main
from pyvehtrack.detector import Detector
from pyvehtrack.lane import LaneDetector
from pyvehtrack.shared import WORK_WIDTH

DATA = Path(__file__).parent / "data"
MODEL = Path(__file__).resolve().parent.parent / "pyvehtrack" / "models" / "cnn_gray_l0_big.npz"
# the 1920 x 1080 frames need the full-size core (the smallest build takes 700 x 500)
FULL_SIZE = pytest.mark.skipif(int(lib.VT_MAX_WIDTH) < 1920 or int(lib.VT_MAX_HEIGHT) < 1080,
                               reason="needs VT_MAX_WIDTH x VT_MAX_HEIGHT >= 1920 x 1080")


def _frame():
    # a real road frame, 640x360, upscaled to the most common dashcam size
    small = cv2.imread(str(DATA / "udacity_test1_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    return small, cv2.resize(small, (1920, 1080), interpolation=cv2.INTER_LINEAR)


@FULL_SIZE
def test_default_is_1280_and_sizes_follow_the_core_rule():
    assert WORK_WIDTH == 1280
    p = Pipeline()
    assert p.work_width == 1280
    assert p.work_size(1920, 1080) == (1280, 720)
    assert p.work_size(1600, 900) == (1280, 720)
    assert p.work_size(1280, 720) == (1280, 720)
    assert p.work_size(1242, 375) == (1242, 375)        # KITTI: no wider than 1280, untouched
    assert p.work_size(640, 360) == (640, 360)          # never upscaled
    assert p.work_size(720, 1280) == (607, 1080)        # portrait: the core's height limits it
    assert Pipeline(work_width=None).work_size(1920, 1080) == (1920, 1080)
    assert Pipeline(work_width=640).work_size(1280, 720) == (640, 360)


def test_a_width_past_the_core_maximum_means_the_maximum():
    mw, mh = int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)
    assert Pipeline(work_width=65535).work_size(mw, mh) == (mw, mh)
    assert Pipeline(work_width=65535).work_size(2 * mw, 2 * mh) == Pipeline(work_width=None).work_size(2 * mw, 2 * mh)
    # the default on any core: no wider than min(1280, MAX_WIDTH), and a frame that fits both untouched
    assert Pipeline().work_size(4 * mw, 4 * mh)[0] == min(1280, mw)
    assert Pipeline().work_size(min(1280, mw), min(720, mh)) == (min(1280, mw), min(720, mh))


@pytest.mark.parametrize("bad, err", [(15, ValueError), (0, ValueError), (65536, ValueError),
                                      (-1, ValueError), (1280.0, TypeError), (True, TypeError),
                                      ("1280", TypeError)])
def test_bad_work_width_is_a_clear_error(bad, err):
    for make in (lambda: Pipeline(work_width=bad), lambda: Detector(work_width=bad),
                 lambda: LaneDetector(work_width=bad)):
        with pytest.raises(err, match="work_width"):
            make()


@FULL_SIZE
def test_wide_frame_gives_the_boxes_of_the_frame_downscaled_by_hand():
    """1920x1080 through Detector() = the 1280x720 INTER_AREA copy through Detector, its
    boxes' corners mapped back by floor((x + 0.5) * 1.5) (the pipeline's rule); no warning, as the
    frame fits the core."""
    _small, big = _frame()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = Detector(model=str(MODEL)).detect(big)
    ref = Detector(model=str(MODEL), work_width=None).detect(
        cv2.resize(big, (1280, 720), interpolation=cv2.INTER_AREA))
    assert len(r.boxes) >= 2 and len(r.boxes) == len(ref.boxes)     # test1's two cars at least
    back = np.floor((np.asarray(ref.boxes, float) + 0.5) * 1.5).astype(np.int64)   # every corner
    assert np.array_equal(np.asarray(r.boxes), back)
    assert np.array_equal(r.scores, ref.scores)


def test_frames_no_wider_than_work_width_are_untouched():
    small, _big = _frame()
    a = Detector(model=str(MODEL)).detect(small)
    b = Detector(model=str(MODEL), work_width=None).detect(small)
    assert np.array_equal(a.boxes, b.boxes) and np.array_equal(a.scores, b.scores)
    la, lb = LaneDetector().detect(small), LaneDetector(work_width=None).detect(small)
    assert la.input_scale == 1.0 and [ln.points.tolist() for ln in la.lanes] == \
        [ln.points.tolist() for ln in lb.lanes]


@FULL_SIZE
def test_the_c_engine_resamples_with_the_core():
    """Pipeline.prepare on the C engine is vt_resize_area (what a firmware build calls), the
    oracle's cv2.INTER_AREA (the same rule in float, at most 1 level apart)."""
    _small, big = _frame()
    g, (sx, sy) = Pipeline().prepare(big)
    assert g.shape == (720, 1280) and (sx, sy) == (1.5, 1.5)
    from pyvehtrack.image import resize_area
    assert np.array_equal(g, resize_area(big, (1280, 720)))
    gr, _ = Pipeline("reference").prepare(big)
    assert np.abs(gr.astype(int) - g).max() <= 1


@FULL_SIZE
def test_lanes_of_a_wide_frame_come_back_in_its_pixels():
    _small, big = _frame()
    res = LaneDetector().detect(big)
    assert res.input_scale == pytest.approx(1280 / 1920) and res.note.startswith("frame 1920x1080 is wider")
    assert res.x_left.shape == (1080,)
    for ln in res.lanes:
        assert ln.points[:, 1].max() <= 1079 and ln.points[:, 0].max() <= 1919


def test_past_the_core_maximum_still_warns():
    big = np.zeros((int(lib.VT_MAX_HEIGHT), int(lib.VT_MAX_WIDTH) + 100), np.uint8)
    with pytest.warns(UserWarning, match="larger than the core's maximum"):
        Pipeline().prepare(big)


@pytest.mark.parametrize("val, msg", [("5", "--work-width 5: expected 16..65535 px, or 0"),
                                      ("70000", "--work-width 70000")])
def test_cli_bad_work_width(val, msg, capsys, tmp_path):
    img = tmp_path / "f.png"
    cv2.imwrite(str(img), _frame()[0])
    assert cli_main(["detect", str(img), "--json", str(tmp_path / "o.json"), "--work-width", val]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and msg in err[0], err


@FULL_SIZE
def test_cli_work_width_zero_keeps_the_frame(tmp_path):
    """--work-width 0: the frame as it comes (the lanes' working frame is then 320x180 with
    k = 6, c/lane.c), not the same boxes as the default's 1280-wide processing."""
    img = tmp_path / "f.png"
    cv2.imwrite(str(img), _frame()[1])
    import json
    for ww in ("1280", "0"):
        assert cli_main(["detect", str(img), "--json", str(tmp_path / f"{ww}.json"), "--work-width", ww,
                         "--no-progress"]) == 0
    a = json.loads((tmp_path / "1280.json").read_text())[0]
    b = json.loads((tmp_path / "0.json").read_text())[0]
    assert a["boxes"] and b["boxes"] and a["boxes"] != b["boxes"]


@FULL_SIZE
@pytest.mark.parametrize("ww", [None, 640, 1280])
def test_tracker_takes_its_detectors_work_width(ww):
    from pyvehtrack.tracker import Tracker
    t = Tracker(detector=Detector(model=str(MODEL), work_width=ww))
    assert t.pipeline.work_width == ww
    big = _frame()[1]
    tracks = t.step(big)            # a detection frame: boxes in the 1920x1080 frame's pixels
    assert tracks and all(0 <= tr.box[0] <= tr.box[2] <= 1919 and 0 <= tr.box[1] <= tr.box[3] <= 1079 for tr in tracks)


@FULL_SIZE
def test_report_and_batch_take_work_width(tmp_path):
    from pyvehtrack.batch import run_batch
    from pyvehtrack.report import make_report
    img = tmp_path / "f.png"
    cv2.imwrite(str(img), _frame()[0])
    with pytest.raises(ValueError, match="work_width"):
        make_report(str(img), tmp_path / "r", work_width=5, progress=False)
    with pytest.raises(TypeError, match="work_width"):
        run_batch([str(img)], tmp_path / "b", work_width="1280", progress=False)
    # the page's stages take the given width: a 1920x1080 frame is processed at 640x360
    from pyvehtrack.report.records import PythonPipeline
    big = _frame()[1]
    p = PythonPipeline(work_width=640)
    assert p.lanes.pipeline.work_width == 640 and p.detector.work_width == 640
    assert p.tracker.pipeline.work_width == 640
    assert p.lanes.detect(big).input_scale == pytest.approx(640 / 1920)
