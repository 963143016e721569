"""tools/package_cnn.py: a trained network given a shipped file's detector settings. It must
rebuild the shipped 240-epoch file from its own weights bit for bit (that file was made by hand
from the default's settings and +0.25 logit), round the offset at the new network's heat scale,
and refuse a file that is not a CNN model with a one-line error."""
import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pyvehtrack import cnn as C

ROOT = Path(__file__).resolve().parent.parent
TOOL = ROOT / "tools" / "package_cnn.py"
MODELS = ROOT / "pyvehtrack" / "models"


@pytest.fixture()
def tool():
    spec = importlib.util.spec_from_file_location("package_cnn_under_test", TOOL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_rebuilds_the_shipped_e240_file(tool):
    z, steps = tool.package(MODELS / "cnn_gray_l0_e240.npz", MODELS / "cnn_gray_l0_big.npz", 0.25)
    with np.load(MODELS / "cnn_gray_l0_e240.npz") as e:
        assert set(z) == set(e.files)
        for k in e.files:
            assert np.array_equal(z[k], e[k]), k
    # 0.25 logit at 7616 / 65536 logit a step is 2.15 steps: 2
    assert steps == 2


def test_offset_is_rounded_at_the_new_heat_scale(tool, tmp_path):
    with np.load(MODELS / "cnn_gray_l0_e240.npz") as e:
        arrays = {k: e[k] for k in e.files}
    arrays["cnn_heat_scale_q16"] = np.array(3000, np.int32)     # 0.0458 logit a step
    arrays["cnn_cfg"] = np.array([0, 5, 0, 64, 500, 700, 380, 640], np.int32)
    np.savez(tmp_path / "w.npz", **arrays)
    z, steps = tool.package(tmp_path / "w.npz", MODELS / "cnn_gray_l0_big.npz", 0.25)
    assert steps == round(0.25 * 65536 / 3000) == 5
    with np.load(MODELS / "cnn_gray_l0_big.npz") as d:
        want = d["cnn_cfg"].copy()
        want[2] = 5
        assert np.array_equal(z["cnn_cfg"], want)
        assert str(z["cnn_detector_json"]) == str(d["cnn_detector_json"])
    C.CnnConfig(*z["cnn_cfg"].tolist()).c()                          # a row the core accepts
    for k in arrays:
        if k not in ("cnn_cfg", "cnn_detector_json"):
            assert np.array_equal(z[k], arrays[k]), k


def test_not_a_cnn_file_is_a_one_line_error(tmp_path):
    np.savez(tmp_path / "svm.npz", w=np.zeros(3))
    r = subprocess.run([sys.executable, str(TOOL), "--weights", str(tmp_path / "svm.npz"), "--like",
                        str(MODELS / "cnn_gray_l0_big.npz"), "--offset-logit", "0.25", "--out",
                        str(tmp_path / "o.npz")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert "--weights: no cnn_heat_scale_q16" in r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "o.npz").exists()
