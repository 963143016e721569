"""`pyvehtrack calibrate` on three real chessboard pictures (tests/data/chessboard, 320x180).

Reference: the same command on all 20 full-size pictures of the source folder (15 used:
3 show no full 9x6 board, 2 are 1281x721) gave fx 1158.9, fy 1154.2, cx 669.6, cy 388.1
at 1280x720; at 320x180 that is fx 289.7, fy 288.5, cx 167.0, cy 96.6 (x' = (x + 0.5) / 4 -
0.5). Three views fix the focal length to a few per cent (measured: 294.9 / 294.2, +1.8 %)
and the principal point to a few pixels (165.4, 97.0): tolerance 4 % and 4 px."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from pyvehtrack.camera import Camera
from pyvehtrack.cli import main

DATA = Path(__file__).parent / "data" / "chessboard"


def test_calibrate_three_pictures(tmp_path, capsys):
    out = tmp_path / "cam.json"
    assert main(["calibrate", str(DATA), "--pattern", "9x6", "--height-m", "1.2", "--lateral-m", "0.35",
                 "--out", str(out)]) == 0
    cam = Camera.load(out)
    assert cam.lateral_m == 0.35 and cam.params(320, 180).lateral == pytest.approx(0.35, abs=2 ** -16)
    assert abs(cam.fx / 289.7 - 1) < 0.04 and abs(cam.fy / 288.5 - 1) < 0.04
    assert abs(cam.cx - 167.0) < 4 and abs(cam.cy - 96.6) < 4
    assert cam.height_m == 1.2 and cam.image_size == (320, 180) and len(cam.dist) == 5
    assert "3 of 3 picture(s) used" in capsys.readouterr().out
    # the file works where a camera is needed
    assert cam.params(320, 180).fx == pytest.approx(cam.fx, abs=2 ** -16)


def test_calibrate_without_height_says_so(tmp_path, capsys):
    out = tmp_path / "cam.json"
    assert main(["calibrate", *sorted(map(str, DATA.iterdir())), "--pattern", "9x6", "--out", str(out)]) == 0
    assert "no height_m" in capsys.readouterr().out
    assert json.loads(out.read_text())["height_m"] is None


@pytest.mark.parametrize("args, msg", [
    (["--pattern", "9by6"], "COLSxROWS"),
    (["--pattern", "1x6"], "2..100"),
    (["--pattern", "9x6", "--square-mm", "-1"], "--square-mm"),
    (["--pattern", "9x6", "--height-m", "0"], "--height-m"),
    (["--pattern", "9x6", "--pitch-deg", "90"], "--pitch-deg"),
    (["--pattern", "9x6", "--lateral-m", "-6"], "--lateral-m"),
    (["--pattern", "9x6", "--lateral-m", "nan"], "--lateral-m"),
    (["--pattern", "12x12"], "found in 0 of 3"),          # no such board in the pictures
])
def test_calibrate_user_errors(tmp_path, capsys, args, msg):
    out = tmp_path / "cam.json"
    assert main(["calibrate", str(DATA), *args, "--out", str(out)]) == 2
    assert msg in capsys.readouterr().err
    assert not out.exists()                                 # nothing written on an error


def test_calibrate_bad_paths(tmp_path, capsys):
    assert main(["calibrate", str(tmp_path / "none"), "--pattern", "9x6", "--out",
                 str(tmp_path / "c.json")]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["calibrate", str(DATA), "--pattern", "9x6", "--out", str(tmp_path / "no" / "c.json")]) == 2
    assert "c.json" in capsys.readouterr().err
