"""`--measurement auto` (the default of `pyvehtrack track` and `report` since 2026-11-30): the
tracker's per-frame measurement chosen from how the recording was coded
(pyvehtrack.frames.auto_measurement): the ROI search with the edge-curve fallback ("roi+edges")
for lossy-coded frames (a video in a lossy codec, JPEG/WebP frames), the thesis's ROI search
("roi") for lossless ones (PNG/BMP/TIFF/PGM frames, FFV1/HuffYUV/PNG/raw video). Why the rule
reads the coding: README, "Tracking measurement: ROI search, edge curves, or both".

The frames are the shipped KITTI clip (tests/data/kitti_clip, tests/data/README.md)."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack.cli import main as cli_main
from pyvehtrack.frames import auto_measurement, lossy_coding, video_fourcc

CLIP = Path(__file__).parent / "data" / "kitti_clip"
N = 8   # frames: detection on frames 0 and 4 (--detect-every 4), tracking on the others


def _frames():
    return [cv2.imread(str(p)) for p in sorted(CLIP.glob("*.png"))[:N]]


def _video(path: Path, fourcc: str) -> Path:
    frames = _frames()
    h, w = frames[0].shape[:2]
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), 10.0, (w, h))
    if not vw.isOpened():
        pytest.skip(f"this OpenCV cannot write {fourcc}")
    for f in frames:
        vw.write(f)
    vw.release()
    return path


def test_lossless_inputs_get_roi(tmp_path):
    png = tmp_path / "png"
    png.mkdir()
    for p in sorted(CLIP.glob("*.png"))[:2]:
        shutil.copy(p, png / p.name)
    cv2.imwrite(str(tmp_path / "one.bmp"), _frames()[0])
    ffv1 = _video(tmp_path / "clip.avi", "FFV1")
    # FFV1 decodes to the very pixels written: the lossless case the rule names
    cap = cv2.VideoCapture(str(ffv1))
    ok, first = cap.read()
    cap.release()
    assert ok and np.array_equal(first, _frames()[0])
    for p in (png, tmp_path / "one.bmp", ffv1, CLIP):
        assert lossy_coding(p) is None, p
    assert auto_measurement([png, ffv1, tmp_path / "one.bmp"]) == ("roi", "lossless input")
    # the layout pyvehtrack.synth.write_kitti writes (REC/frames/) is looked into, as the report does
    rec = tmp_path / "rec"
    (rec / "frames").mkdir(parents=True)
    cv2.imwrite(str(rec / "frames" / "000000.jpg"), _frames()[0])
    assert lossy_coding(rec) == ".jpg frames"


def test_lossy_inputs_get_roi_edges(tmp_path):
    mp4 = _video(tmp_path / "clip.mp4", "mp4v")
    assert video_fourcc(mp4).lower() in ("fmp4", "mp4v")
    assert auto_measurement(mp4) == ("roi+edges", f"lossy input: {video_fourcc(mp4)} video")
    jpg = tmp_path / "jpg"
    jpg.mkdir()
    cv2.imwrite(str(jpg / "a.jpg"), _frames()[0])
    cv2.imwrite(str(jpg / "b.png"), _frames()[1])
    assert lossy_coding(jpg) == ".jpg frames"   # one lossy frame is enough
    assert lossy_coding(jpg / "a.jpg") == ".jpg frames" and lossy_coding(jpg / "b.png") is None
    # any lossy part makes the recording lossy
    assert auto_measurement([jpg / "b.png", mp4])[0] == "roi+edges"
    # a video file OpenCV cannot open: nearly every recording is lossy
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    assert video_fourcc(bad) == "" and lossy_coding(bad) == "unreadable video"


def _track(args, tmp_path, name):
    out = tmp_path / f"{name}.json"
    rc = cli_main(["track", *args, "--out", str(tmp_path / f"{name}.mp4"), "--json", str(out),
                   "--detect-every", "4", "--no-progress"])
    assert rc == 0
    return json.loads(out.read_text())


def test_track_default_follows_the_coding(tmp_path, capsys):
    mp4 = str(_video(tmp_path / "clip.mp4", "mp4v"))
    auto = _track([mp4], tmp_path, "auto")
    said = capsys.readouterr().out
    assert "measurement roi+edges (lossy input: " in said
    assert auto == _track([mp4, "--measurement", "roi+edges"], tmp_path, "explicit")
    assert "measurement" not in capsys.readouterr().out   # chosen by hand: nothing to report
    assert sum(len(r["tracks"]) for r in auto) > 0
    png = tmp_path / "png"
    png.mkdir()
    for p in sorted(CLIP.glob("*.png"))[:N]:
        shutil.copy(p, png / p.name)
    auto = _track([str(png)], tmp_path, "auto_png")
    assert "measurement roi (lossless input)" in capsys.readouterr().out
    assert auto == _track([str(png), "--measurement", "roi"], tmp_path, "roi_png")


def test_report_names_the_measurement(tmp_path):
    from pyvehtrack.report import make_report
    mp4 = _video(tmp_path / "clip.mp4", "mp4v")
    page = make_report(mp4, tmp_path / "r", truth=(), camera=None, progress=False)
    html = page.read_text()
    assert "tracking measurement" in html and "roi+edges (lossy input: " in html
    page = make_report(mp4, tmp_path / "r2", truth=(), camera=None, progress=False, measurement="roi")
    assert "roi (given)" in page.read_text()
    with pytest.raises(ValueError, match="measurement"):
        make_report(mp4, tmp_path / "r3", truth=(), camera=None, progress=False, measurement="best")
