"""The shipped CNN detector (pyvehtrack/models/cnn_gray.npz, tools/train_cnn.py): it loads
with the settings it was validated with, the C core and the NumPy twin give the same boxes
on real frames, and it boxes real vehicles on frames nothing was tuned on.

Tolerances: C = twin is exact (integer arithmetic on both sides, tests/test_cnn.py's
contract). The detection checks are floors on frames from other cameras than the training
set's (KITTI, Udacity; the model learnt on tusimple-vehicles-dev 'fit' frames only): a
box counts at IoU >= 0.5 with the frame's reference box (KITTI: the lidar-derived lead-car
box of tests/data/kitti_lead_boxes_621x188.csv).
"""
from __future__ import annotations

import csv
from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack import Detector, fullroad
from pyvehtrack import cnn
from pyvehtrack.eval.boxes import iou
from pyvehtrack.reference import cnn as rcnn

DATA = Path(__file__).parent / "data"
MODEL = Path(fullroad.__file__).parent / "models" / "cnn_gray.npz"


def test_shipped_model_loads_with_its_settings():
    m = fullroad.load_model(MODEL)
    assert isinstance(m, cnn.CnnModel)
    assert m.cfg is not None and m.cfg.first_level == 1 and m.cfg.n_levels == 4
    assert m.settings == {"sources": ["windows", "ego"]}
    assert m.out_stride == 8


@pytest.mark.parametrize("model", ["cnn_gray.npz", "cnn_gray_l0.npz", "cnn_gray_l0_big.npz",
                                   "cnn_gray_l0_e240.npz"])
@pytest.mark.parametrize("name", ["udacity_test1_640x360.jpg", "kitti_lead_30_gray_621x188.png",
                                  "tusimple_vehicles_4065_gray_640x360.png"])
def test_shipped_model_c_equals_twin(name, model):
    """Every shipped CNN file (cnn_gray_l0*.npz with level 0's row band; _big with 64-channel
    layers, VT_CNN_MAX_CH) at its own settings."""
    m = cnn.CnnModel.load(MODEL.parent / model)
    g = cv2.imread(str(DATA / name), cv2.IMREAD_GRAYSCALE)
    got, n = cnn.detect_frame(m, g, m.cfg)
    want, n_r = rcnn.detect_frame(m, g, m.cfg)
    assert n == n_r and np.array_equal(got, np.asarray(want, np.int64).astype(np.int32))
    assert len(got) >= 1


def _kitti():
    for row in csv.DictReader((DATA / "kitti_lead_boxes_621x188.csv").open()):
        f = int(row["frame"])
        yield (cv2.imread(str(DATA / f"kitti_lead_{f:02d}_gray_621x188.png"), cv2.IMREAD_GRAYSCALE),
               [float(row[k]) for k in ("left", "top", "right", "bottom")])


def test_shipped_model_with_its_settings_boxes_the_kitti_lead_car():
    """Detector(model=cnn_gray.npz) (the CNN and, as the file says, the ego-lane detector
    beside it) boxes the lead car at IoU >= 0.5 on at least 5 of the 6 KITTI frames."""
    det = Detector(model=MODEL)
    hits = sum(max([iou(b, gt) for b in det.detect(img).boxes] or [0.0]) >= 0.5 for img, gt in _kitti())
    assert hits >= 5
