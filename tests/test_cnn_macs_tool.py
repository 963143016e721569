"""tools/cnn_macs.py: the multiply-adds of one detection frame's network runs (the README's
speed figures divide by them)."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

from pyvehtrack import cnn as C

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
import cnn_macs  # noqa: E402

from test_cnn import simple_model  # noqa: E402


def test_by_hand():
    # 3x3 stride 2, 1 -> 4 channels, then 1x1, 4 -> 5. A 10 x 7 input: the first layer's
    # output is 5 x 4 (ceil), 5 * 4 * 4 * 9 * 1 = 720; the second 5 * 4 * 5 * 1 * 4 = 400.
    m = simple_model()
    assert cnn_macs.run_macs(m.layers, 10, 7) == 1120
    # One level on the whole 10 x 7 frame, then a second on its 5 x 4 pyramid level:
    # 3 x 2 outputs, 3 * 2 * 4 * 9 + 3 * 2 * 5 * 4 = 336.
    m.cfg = C.CnnConfig(first_level=0, n_levels=1, l0_top_permille=0, l0_bottom_permille=1000)
    assert cnn_macs.frame_macs(m, 10, 7) == [("level 0 band", 10, 7, 1120)]
    m.cfg = C.CnnConfig(first_level=0, n_levels=2, l0_top_permille=0, l0_bottom_permille=1000)
    assert [r[3] for r in cnn_macs.frame_macs(m, 10, 7)] == [1120, 336]


def test_shipped_figure():
    # cnn_gray.npz's 244.6 M multiply-adds per 1280x720 frame over its four levels was worked
    # out when the model was added ("A small CNN detector"); the tool agrees.
    rows = cnn_macs.frame_macs(C.CnnModel.load(ROOT / "pyvehtrack/models/cnn_gray.npz"), 1280, 720)
    assert [r[0] for r in rows] == ["level 1", "level 2", "level 3", "level 4"]
    assert round(sum(r[3] for r in rows) / 1e5) == 2446


def test_bad_size(capsys):
    with pytest.raises(SystemExit):
        cnn_macs.main([str(ROOT / "pyvehtrack/models/cnn_gray.npz"), "--size", "0x5"])
    assert "at least 1" in capsys.readouterr().err
