"""Tracker settings carried by a model file (`tracker_json`, in a CNN file
`cnn_tracker_json`; pyvehtrack/fullroad.py): a Pipeline or Tracker built with the model and
no tracker configuration of its own runs with them, an explicit configuration wins, and a
bad entry is a clear error naming the file. The shipped cnn_gray.npz turns the birth
search off (README, "A track starts where the ROI search measures")."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pyvehtrack import VtError
from pyvehtrack import fullroad as fr
from pyvehtrack.config import TrackerConfig
from pyvehtrack.detector import Detector
from pyvehtrack.pipeline import Pipeline
from pyvehtrack.shared import TrackerCfg
from pyvehtrack.tracker import Tracker

MODELS = Path(__file__).resolve().parents[1] / "pyvehtrack" / "models"
DATA = Path(__file__).parent / "data"
DEFAULT_BIRTH = TrackerCfg().birth_search


def _with(src: Path, dst: Path, key: str, value) -> Path:
    z = dict(np.load(src, allow_pickle=False))
    z[key] = np.array(value if isinstance(value, str) else json.dumps(value))
    np.savez(dst, **z)
    return dst


def test_shipped_files():
    assert DEFAULT_BIRTH != 0   # else the tests below could not tell the settings apply
    assert fr.load_model(MODELS / "cnn_gray.npz").tracker == {"birth_search": 0}
    assert fr.model_tracker_settings(str(MODELS / "cnn_gray.npz")) == {"birth_search": 0}
    for name in ("cnn_gray_l0_big.npz", "cnn_gray_l0.npz", "acf_gray_rescore.npz", "window_mlp_hog32.npz"):
        assert fr.model_tracker_settings(str(MODELS / name)) == {}, name
    assert fr.model_tracker_settings(None) == {} and fr.model_tracker_settings("default") == {}


@pytest.mark.parametrize("src,key", [(MODELS / "cnn_gray.npz", "cnn_tracker_json"),
                                     (DATA / "window_svm_hog32.npz", "tracker_json")])
def test_pipeline_takes_the_models_settings_unless_given_its_own(tmp_path, src, key):
    m = _with(src, tmp_path / "m.npz", key, {"birth_search": 1, "max_coast": 5})
    p = Pipeline("c", model=str(m))
    assert (p.cfg.tracker.birth_search, p.cfg.tracker.max_coast) == (1, 5)
    assert (p._ccfg.tracker.birth_search, p._ccfg.tracker.max_coast) == (1, 5)   # what the C core runs
    q = Pipeline("c", model=str(m), tracker=TrackerConfig())
    assert q.cfg.tracker.birth_search == DEFAULT_BIRTH == q._ccfg.tracker.birth_search
    assert q.cfg.tracker.max_coast == TrackerConfig().max_coast


def test_tracker_takes_the_detectors_model_settings(tmp_path):
    m = _with(MODELS / "cnn_gray.npz", tmp_path / "m.npz", "cnn_tracker_json", {"birth_search": 1})
    t = Tracker(detector=Detector(model=str(m)))
    assert t.cfg.birth_search == 1 and t.pipeline._ccfg.tracker.birth_search == 1
    t = Tracker(detector=Detector(model=str(m)), cfg=TrackerCfg())
    assert t.cfg.birth_search == DEFAULT_BIRTH == t.pipeline._ccfg.tracker.birth_search
    t = Tracker(detector=Detector(model=str(MODELS / "cnn_gray.npz")))   # the shipped file
    assert t.pipeline._ccfg.tracker.birth_search == 0


@pytest.mark.parametrize("value,msg", [("{not json", "not JSON"), ([1, 2], "JSON object"),
                                       ({"keep_ncc": 0.5}, "unknown key 'keep_ncc'"),
                                       ({"nope": 1}, "unknown key 'nope'"),
                                       ({"birth_search": True}, "must be an integer"),
                                       ({"birth_search": 1.5}, "must be an integer")])
def test_bad_entries_name_the_file(tmp_path, value, msg):
    m = _with(MODELS / "cnn_gray.npz", tmp_path / "bad.npz", "cnn_tracker_json", value)
    with pytest.raises(ValueError, match=msg) as e:
        fr.load_model(m)
    assert "bad.npz" in str(e.value)
    with pytest.raises(ValueError, match=msg):
        Pipeline("c", model=str(m))


def test_out_of_range_is_refused_by_the_core(tmp_path):
    m = _with(MODELS / "cnn_gray.npz", tmp_path / "big.npz", "cnn_tracker_json", {"birth_search": 99})
    with pytest.raises(VtError, match="big.npz"):
        Pipeline("c", model=str(m))
    with pytest.raises(ValueError, match="big.npz.*birth_search=99"):
        Tracker(detector=Detector(model=str(m)))
