"""The shipped CNN detectors with a full-resolution band (pyvehtrack/models/cnn_gray_l0.npz,
tools/train_cnn.py --level0 380 640; cnn_gray_l0_big.npz, the same with --channels 16 32 48
64 64 64): each loads with the settings it was validated with (levels 0-4, level 0 on rows
380..640 permille of the frame, the ego-lane detector beside it and the second stage on the
ego boxes; C = twin on real frames: tests/test_cnn_shipped.py), and each boxes real vehicles
on frames from other cameras than its training set's.

Tolerances: the detection checks are floors on frames nothing was tuned on (KITTI, Udacity;
the model learnt on tusimple-vehicles-dev TRAIN frames only): a box counts at IoU >= 0.5 with
the frame's reference box (KITTI: the lidar-derived lead-car box of
tests/data/kitti_lead_boxes_621x188.csv; Udacity test1: the two cars labelled by hand on the
640x360 frame, tests/test_fullroad.py's CARS).
"""
from __future__ import annotations

import csv
from pathlib import Path

import cv2
import pytest

from pyvehtrack import Detector, cnn, fullroad
from pyvehtrack.eval.boxes import iou

DATA = Path(__file__).parent / "data"
MODELS = Path(fullroad.__file__).parent / "models"
FILES = pytest.mark.parametrize("name", ["cnn_gray_l0.npz", "cnn_gray_l0_big.npz", "cnn_gray_l0_e240.npz"])
# the files that carry the stretch and the upsampled band (the default and its 240-epoch twin)
BAND_FILES = ("cnn_gray_l0_big.npz", "cnn_gray_l0_e240.npz")
UDACITY_CARS = [[408, 206, 471, 246], [527, 204, 635, 252]]   # tests/test_fullroad.py's CARS


@FILES
def test_shipped_l0_model_loads_with_its_settings(name):
    m = fullroad.load_model(MODELS / name)
    assert isinstance(m, cnn.CnnModel)
    c = m.cfg
    assert (c.first_level, c.n_levels, c.l0_top_permille, c.l0_bottom_permille) == (0, 5, 380, 640)
    # the default (big) file sees the frame's contrast stretched (README, "What users feed it")
    assert c.stretch_tail_permille == (5 if name in BAND_FILES else 0)
    # the default also runs on a 2x band by the vanishing point (README, "Far specks: an upsampled band")
    up = (c.up_top_permille, c.up_bottom_permille, c.up_left_permille, c.up_right_permille)
    assert up == ((450, 530, 350, 650) if name in BAND_FILES else (0, 0, 0, 0))
    assert m.settings == {"sources": ["windows", "ego"], "verify_min": 2.0}
    assert m.out_stride == 8


@FILES
def test_shipped_l0_model_boxes_the_kitti_lead_car(name):
    """Detector(model=each band file) boxes the lead car at IoU >= 0.5 on at least 5 of the 6
    KITTI frames (another camera: 1242x375 halved, no hood)."""
    det = Detector(model=MODELS / name)
    hits = 0
    for row in csv.DictReader((DATA / "kitti_lead_boxes_621x188.csv").open()):
        f = int(row["frame"])
        img = cv2.imread(str(DATA / f"kitti_lead_{f:02d}_gray_621x188.png"), cv2.IMREAD_GRAYSCALE)
        gt = [float(row[k]) for k in ("left", "top", "right", "bottom")]
        hits += max([iou(b, gt) for b in det.detect(img).boxes] or [0.0]) >= 0.5
    assert hits >= 5


@FILES
def test_shipped_l0_model_boxes_both_udacity_cars(name):
    """Udacity test1 (another camera): the dark car ahead-right and the white car in the right
    lane are both boxed at IoU >= 0.5."""
    det = Detector(model=MODELS / name)
    boxes = det.detect(cv2.imread(str(DATA / "udacity_test1_640x360.jpg"))).boxes
    assert all(max([iou(b, car) for b in boxes] or [0.0]) >= 0.5 for car in UDACITY_CARS), boxes
