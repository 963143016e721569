"""A CNN model file (cnn_* keys, tools/train_cnn.py) through the user's entry points:
fullroad.load_model, pyvehtrack.Detector and `pyvehtrack detect --model`.

Tolerance: exact. Detector runs the model through the pipeline (vt_pipeline_set_cnn), whose
classifier boxes are vt_cnn_detect_frame's (tests/test_pipeline_cnn.py), so with the file's
sources ["windows"] (no ego-lane detector) and a frame within the core's maximum size (no
resampling), Detector's boxes and scores are pyvehtrack.cnn.detect_frame's at the file's
cnn_cfg, box for box. A score offset of x logits moves the heat threshold by
round(x 65536 / heat_scale_q16) steps, so it equals detect_frame at that thr_offset.
"""
from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from pyvehtrack import Detector, fullroad
from pyvehtrack import cnn as C
from test_pipeline_cnn import scene, tiny_model

CFG = C.CnnConfig(first_level=0, n_levels=3, thr_offset=-30, cap_per_level=16)


def _file(tmp_path, sources=("windows",), cfg=CFG, name="m.npz"):
    m = tiny_model(3)
    m.cfg = cfg
    m.save(tmp_path / name)
    d = dict(np.load(tmp_path / name))
    d["cnn_detector_json"] = np.array(json.dumps({"sources": list(sources)}))
    np.savez(tmp_path / name, **d)
    return m, tmp_path / name


def test_load_model_reads_cfg_and_settings(tmp_path):
    m, p = _file(tmp_path, sources=("windows", "ego"))
    got = fullroad.load_model(p)
    assert isinstance(got, C.CnnModel)
    assert got.cfg == C.CnnConfig(**{k: getattr(CFG.c(), k) for k in C.CFG_KEYS})
    assert got.settings == {"sources": ["windows", "ego"]}
    assert all(np.array_equal(a["w"], b["w"]) for a, b in zip(got.layers, m.layers))


@pytest.mark.parametrize("offset", [0.0, -1.5, 2.0])
def test_detector_boxes_are_detect_frame_boxes(tmp_path, offset):
    m, p = _file(tmp_path)
    gray = scene(seed=3)
    steps = int(round(offset * 65536 / m.heat_scale_q16))
    want, _ = C.detect_frame(m, gray, C.CnnConfig(**{**{k: getattr(CFG, k) for k in C.CFG_KEYS},
                                                      "thr_offset": CFG.thr_offset + steps}))
    assert len(want) >= 3, "the drawn model finds too little to compare"
    res = Detector(model=p, score_offset=offset).detect(gray)
    assert res.boxes.tolist() == want[:, :4].tolist()
    assert np.allclose(res.scores, want[:, 4] * m.heat_scale_q16 / 65536, atol=0)


def test_bad_cnn_cfg_in_file_is_refused(tmp_path):
    _, p = _file(tmp_path)
    d = dict(np.load(p))
    d["cnn_cfg"] = np.array([1, 9, 0, 64, 500, 700], np.int32)   # 9 levels: past the deepest
    np.savez(p, **d)
    with pytest.raises(ValueError, match="n_levels"):
        fullroad.load_model(p)
    d["cnn_cfg"] = np.array([1, 2, 0], np.int32)
    np.savez(p, **d)
    with pytest.raises(ValueError, match="cnn_cfg"):
        fullroad.load_model(p)


@pytest.mark.parametrize("content", [b"# a README, not a model\n", b"\xff\xd8\xff\xe0 a JPEG", b""])
def test_a_file_that_is_not_an_npz_is_named_so(tmp_path, content):
    """A text, JPEG or empty file given as a model: every loader says it is not an .npz (a zip
    archive), not NumPy's advice about pickled data, and `detect` / `classify` pass that on."""
    from pyvehtrack import acf
    p = tmp_path / "wrong.npz"
    p.write_bytes(content)
    for load in (fullroad.load_model, C.CnnModel.load, acf.AcfModel.load):
        with pytest.raises(ValueError, match="is not a .npz file") as e:
            load(p)
        assert "pickle" not in str(e.value)
    frames = tmp_path / "frames"
    frames.mkdir()
    cv2.imwrite(str(frames / "f.png"), scene(seed=1))
    for cmd in ("detect", "classify"):
        res = subprocess.run([sys.executable, "-m", "pyvehtrack", cmd, str(frames), "--model", str(p),
                              "--json", str(tmp_path / "o.json")], capture_output=True, text=True, timeout=120)
        assert res.returncode == 2 and "is not a .npz file" in res.stderr and "Traceback" not in res.stderr, cmd


def test_cli_detect_with_a_cnn_model(tmp_path):
    import cv2
    _, p = _file(tmp_path)
    gray = scene(seed=3)
    cv2.imwrite(str(tmp_path / "f.png"), gray)
    r = subprocess.run([sys.executable, "-m", "pyvehtrack", "detect", str(tmp_path / "f.png"), "--model", str(p),
                        "--json", str(tmp_path / "o.json")], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    got = json.loads((tmp_path / "o.json").read_text())[0]["boxes"]
    want = Detector(model=p).detect(gray)
    assert [b[:4] for b in got] == want.boxes.tolist()
    assert all(len(b) == 5 for b in got)
