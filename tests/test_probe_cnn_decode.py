"""tools/probe_cnn_decode.py names a wrong flag before any frame is read (the frames live
outside the repository; these checks need only the shipped model file)."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TOOL = ROOT / "tools" / "probe_cnn_decode.py"
MODEL = ROOT / "pyvehtrack" / "models" / "cnn_gray_l0_big.npz"


@pytest.mark.parametrize("args,msg", [
    (["--probe", "levels", "--levels-offsets", "0", "4"], "one per level 0..4"),
    (["--probe", "upsample", "--band", "600", "500"], "--band"),
    (["--probe", "none", "--stretch", "500"], "--stretch"),
    (["--probe", "none", "--limit", "-1"], "--limit"),
    (["--probe", "fast"], "invalid choice"),
])
def test_probe_tool_rejects_bad_flags(args, msg, tmp_path):
    p = subprocess.run([sys.executable, str(TOOL), "--model", str(MODEL), "--data", str(tmp_path)] + args,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and msg in p.stderr, p.stderr


def test_probe_tool_names_a_file_that_is_not_a_cnn_model(tmp_path):
    bad = tmp_path / "x.npz"
    bad.write_bytes(b"not a model")
    p = subprocess.run([sys.executable, str(TOOL), "--model", str(bad), "--probe", "none"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "--model" in p.stderr, p.stderr
