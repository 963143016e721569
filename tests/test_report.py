"""`pyvehtrack report` (issue 12, item 1): the per-frame records, the truth readers, the page.

The page is rendered in Debian's chromium (headless): the screenshot must not be blank and
the browser's own network log (--log-net-log) must show no request made by the page; a
control page with one http:// image proves that check can fail."""
from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack.cli import main
from pyvehtrack.report import PythonPipeline, load_truth, make_report, track_record
from pyvehtrack.report.records import LIDAR_BEHIND_CAMERA_M, Truth, ego_vanishing_row, read_records

DATA = Path(__file__).parent / "data"
CLIP = DATA / "kitti_clip"
CAMERA = DATA / "kitti_clip.camera.json"
TRACK_KEYS = {"id", "box", "state", "velocity_px", "distance_m", "ttc_s", "warning", "source", "ttc_points_s",
              "ttc_fused_s"}
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
# Chromium's own background services (update checks, time, accounts) show up in its net
# log whatever the page holds; everything else would be the page's.
_BROWSER_HOSTS = re.compile(r"^https?://([a-z0-9-]+\.)*(google\.com|googleapis\.com|gstatic\.com|"
                            r"gvt1\.com|googleusercontent\.com)(/|:|$)")


@pytest.fixture(scope="module")
def clip_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    page = make_report(CLIP, out, truth=[CLIP / "lead_boxes.csv", CLIP / "truth_lidar_range.csv"],
                       camera=CAMERA, progress=False)
    return page, read_records(out / "tracks.json")


def test_records_follow_the_track_json_schema(clip_report):
    page, recs = clip_report
    assert [r["frame"] for r in recs] == list(range(20))
    assert all(set(r) == {"frame", "tracks"} for r in recs)
    tracks = [t for r in recs for t in r["tracks"]]
    assert tracks, "the lead car is tracked on this clip"
    for t in tracks:
        assert set(t) == TRACK_KEYS
        assert t["state"] in ("tentative", "confirmed", "coasting")
        assert len(t["box"]) == 4 and t["box"][0] < t["box"][2] and t["box"][1] < t["box"][3]
        assert t["source"] in ("shadow", "classifier", "ego")   # the pipeline's names, as `track` writes them
        # the default whole-road model also tracks the parked van and the cars on the right,
        # which close fast as the ego car passes them: outside the ego path, none warns
        assert t["warning"] is False
    # the geometry stage (pyvehtrack.camera) with the clip's camera: a distance for the lead
    # car (the box over the image centre, cx 309.6) from the first frame, no warning at 7-8 m
    # and a 10 s TTC; TTC needs a few frames
    lead = [t for t in tracks if t["box"][0] < 310 < t["box"][2]]
    assert len(lead) >= 18 and all(3.0 < t["distance_m"] < 15.0 for t in lead)
    assert all(t["ttc_s"] is None or 0 < t["ttc_s"] < 60 for t in lead)
    assert sum(t["ttc_s"] is not None for t in lead) >= 10


def test_report_tracks_are_the_track_commands(clip_report, tmp_path):
    """The page shows the tracks `pyvehtrack track` writes for the same input: the report's
    tracker owns the same detector (the default model, the camera file's geometry), so its
    records without the tentative tracks (which `track --json` leaves out) are `track
    --json`'s, id for id, box for box, state and source. Tolerance: exact (the same C
    pipeline on the same frames). Distances are not compared: the report's geometry stage
    takes its pitch from its own lane run, `track`'s from the range stage's."""
    _, recs = clip_report
    out = tmp_path / "t.json"
    assert main(["track", str(CLIP), "--camera", str(CAMERA), "--out", str(tmp_path / "t.mp4"),
                 "--json", str(out), "--no-progress"]) == 0

    def key(rs):
        # the block-scale TTC too: the same pipeline stage after the same tracker (no pitch in it)
        return [(r["frame"], sorted((t["id"], tuple(t["box"]), t["state"], t["source"], t["ttc_points_s"])
                                    for t in r["tracks"] if t["state"] != "tentative")) for r in rs]
    want = key(json.loads(out.read_text()))
    assert sum(len(k[1]) for k in want) >= 20, "too few tracks to compare"
    assert key(recs) == want


def test_fused_ttc_is_the_pipelines_rule(clip_report):
    """With a camera the report runs the block-scale TTC as `track --camera` does, and its fused
    TTC is camera.fuse_ttc of the two it records. Tolerance 0.001 s: both inputs are recorded
    rounded to 1 ms (each off by <= 0.0005 s) and the fusion is a weighted mean (weights summing
    to 1), so fusing the rounded inputs moves the result by <= 0.0005 s, plus the rounding of
    the recorded fused value itself (<= 0.0005 s)."""
    from pyvehtrack.camera import fuse_ttc
    _, recs = clip_report
    tracks = [t for r in recs for t in r["tracks"]]
    both = [t for t in tracks if t["ttc_points_s"] is not None and t["ttc_s"] is not None]
    assert len(both) >= 5, "the lead car has both TTCs on some frames"
    for t in tracks:
        want = fuse_ttc(t["ttc_points_s"], t["ttc_s"])
        if want is None:
            assert t["ttc_fused_s"] is None
        else:
            assert abs(t["ttc_fused_s"] - want) <= 0.001
    # and the page draws and scores it
    assert any(t["ttc_fused_s"] != t["ttc_s"] for t in both)


def _cli_errors(frames, tmp_path, cases):
    """Each (extra args, message) of `report` on frames with the KITTI camera: a one-line
    error naming the problem (exit != 0, no traceback)."""
    for bad, msg in cases:
        r = subprocess.run([sys.executable, "-m", "pyvehtrack", "report", str(frames), "--out",
                            str(tmp_path / "bad"), "--camera", str(CAMERA), "--no-progress"] + bad,
                           capture_output=True, text=True, timeout=300)
        assert r.returncode != 0 and msg in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_warning_options_reach_the_range_stage(tmp_path, monkeypatch):
    """report --ego-speed / --warn-ttc are `track`'s: the ego speed and, with fused, each
    track's block-scale TTC reach RangeEstimator.step (recorded by a wrapper that calls the
    real one); the page names them; bad values and the options without a camera are
    one-line errors before the run."""
    from pyvehtrack import camera as vcam
    seen = []
    real = vcam.RangeEstimator.step

    def spy(self, tracks, ego_speed=None, ttc_points=None, fuse_permille=None):
        seen.append((ego_speed, ttc_points))
        return real(self, tracks, ego_speed, ttc_points=ttc_points, fuse_permille=fuse_permille)

    monkeypatch.setattr(vcam.RangeEstimator, "step", spy)
    frames = tmp_path / "few"
    frames.mkdir()
    for f in sorted(CLIP.glob("0*.png"))[:8]:
        shutil.copy(f, frames / f.name)
    page = make_report(frames, tmp_path / "r", camera=CAMERA, truth=(), progress=False, ego_speed=12.5,
                       warn_ttc="fused")
    assert seen and all(e == 12.5 and isinstance(p, dict) for e, p in seen)
    assert any(v is not None for _e, p in seen for v in p.values()), "a block-scale TTC on some frame"
    assert "on the fused TTC, ego speed 12.5 m/s" in html.unescape(page.read_text())
    seen.clear()
    page = make_report(frames, tmp_path / "r2", camera=CAMERA, truth=(), progress=False)
    assert seen and all(e is None and p is None for e, p in seen)
    assert "on the distance/rate TTC, ego speed unknown" in html.unescape(page.read_text())
    _cli_errors(frames, tmp_path, ((["--ego-speed", "-1"], "ego_speed must be a number >= 0"),
                                   (["--ego-speed", "inf"], "ego_speed must be a number >= 0"),
                                   (["--warn-ttc", "both"], "invalid choice")))
    with pytest.raises(ValueError, match="need a camera"):
        make_report(frames, tmp_path / "r3", camera=None, truth=(), progress=False, ego_speed=10.0)


def test_range_options_reach_the_range_stage(tmp_path):
    """--rear-offset / --bottom-height / --path-half-width of `report` are `track`'s: they reach
    the RangeEstimator, the page names them, and bad values are one-line errors before the run."""
    pipe = PythonPipeline(camera=json.loads(CAMERA.read_text()),
                          range_params={"rear_offset": 1.8, "bottom_height": 0.37, "path_half_width": 1.0})
    pipe.step(cv2.imread(str(CLIP / "000000.png")))
    assert pipe._rng.params.rear_offset == pytest.approx(1.8, abs=2 ** -16)     # Q16 in the core
    assert pipe._rng.params.path_half_width == pytest.approx(1.0, abs=2 ** -16)
    assert pipe._rng.bottom_height == 0.37
    frames = tmp_path / "one"
    frames.mkdir()
    shutil.copy(CLIP / "000000.png", frames / "000000.png")
    page = make_report(frames, tmp_path / "r", camera=CAMERA, truth=(), progress=False, rear_offset=1.8)
    assert "rear offset 1.8 m, bottom height 0 m, ego path +-1.5 m" in page.read_text()
    # a camera mounted off the car's centre line: the page says where the corridor is
    off = tmp_path / "cam_off.json"
    off.write_text(json.dumps(dict(json.loads(CAMERA.read_text()), lateral_m=-0.4)))
    page = make_report(frames, tmp_path / "r2", camera=off, truth=(), progress=False)
    text = html.unescape(page.read_text())
    assert "ego path +-1.5 m around the car's centre line (the camera 0.4 m left of it)" in text
    _cli_errors(frames, tmp_path, ((["--rear-offset", "6"], "rear_offset 6.0: must be in [0, 5] m"),
                                   (["--rear-offset", "nan"], "rear_offset must be finite"),
                                   (["--bottom-height", "1.65"], "bottom_height 1.65: must be in [0, height_m = 1.65) m"),
                                   (["--path-half-width", "-1"], "path_half_width -1.0: must be in [0, 10] m")))
    with pytest.raises(ValueError, match="need a camera"):
        make_report(frames, tmp_path / "r2", camera=None, truth=(), progress=False, rear_offset=1.8)
    with pytest.raises(TypeError, match="rear_offset must be a number"):
        make_report(frames, tmp_path / "r3", camera=CAMERA, truth=(), progress=False, rear_offset="1.8")


def test_every_track_once_section(clip_report):
    """One tile per track id, captioned with its frames, in the page's "Every track, once"."""
    page, recs = clip_report
    html = page.read_text()
    assert "<h2>Every track, once</h2>" in html
    ids = sorted({t["id"] for r in recs for t in r["tracks"]})
    tiles = re.findall(r'<img src="data:image/jpeg;base64,[^"]+" alt="track (\d+)">', html)
    assert sorted(int(i) for i in tiles) == ids
    for i in ids:
        frames = [r["frame"] for r in recs if any(t["id"] == i for t in r["tracks"])]
        assert f"#{i}: frames {frames[0]}-{frames[-1]} ({len(frames)})" in html


def test_page_is_self_contained_and_has_every_section(clip_report):
    page, _ = clip_report
    html = page.read_text()
    for head in ("Summary", "Contact sheet", "Every track, once", "Track timeline", "Distance and time to collision",
                 "Lane width and pitch", "Run time per frame and stage"):
        assert f"<h2>{head}</h2>" in html
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", html, re.I)
    assert "<script" not in html.lower() and "@import" not in html
    assert len(re.findall(r'src="data:image/(png|jpeg);base64,', html)) >= 12 + 4
    # the truth gave lead-car figures and distance / TTC errors
    assert "lead id kept (IoU &gt;= 0.5)" in html
    assert "<td>distance MAE</td>" in html and "<td>distance/rate TTC MAE</td>" in html
    assert "<td>fused TTC MAE</td>" in html
    # the lead-car id is kept on 18 of the 20 frames (frames 0-1 are tentative: 3 hits to confirm)
    assert re.search(r"<td>lead id kept \(IoU &gt;= 0.5\)</td><td>(9\d\.\d|100\.0)% of 20", html)


def test_pipeline_fills_lane_width_vanishing_row_pitch_and_timings():
    cam = json.loads(CAMERA.read_text())
    frames = [cv2.imread(str(CLIP / f"{k:06d}.png"), cv2.IMREAD_GRAYSCALE) for k in range(3)]
    # without the geometry stage's height: the pitch from the vanishing row and the camera's fy, cy
    pipe = PythonPipeline(camera={k: cam[k] for k in ("fx", "fy", "cx", "cy")})
    infos = [pipe.step(f)[1] for f in frames]
    assert any("height_m" in n for n in pipe.notes)
    for i in infos:
        # one pipeline call detects and tracks: timed as "detect" on a detection frame, else "track"
        assert "lanes" in i.timing_ms and len({"detect", "track"} & set(i.timing_ms)) == 1
        assert all(v >= 0 for v in i.timing_ms.values())
        assert "geometry" not in i.timing_ms
        assert i.lane_width_px is not None and 300 < i.lane_width_px < 640
        assert i.vanishing_row is not None and 0 < i.vanishing_row < 120    # near the crop's horizon
        assert i.pitch_deg == pytest.approx(np.degrees(np.arctan2(54.854 - i.vanishing_row, 721.5377)))
    assert "detect" in infos[0].timing_ms and "detect" not in infos[1].timing_ms
    # with the whole camera file: the geometry stage's own (gated) pitch, within its +-3 deg
    pipe = PythonPipeline(camera=cam)
    infos = [pipe.step(f)[1] for f in frames]
    assert pipe.notes == [] and all("geometry" in i.timing_ms and abs(i.pitch_deg) <= 3.0 for i in infos)
    with pytest.raises(ValueError, match="fx"):
        PythonPipeline(camera={"fy": 700.0, "cy": 50.0})           # the camera file format's rule


def test_vanishing_row_is_where_the_fitted_lines_meet():
    ys = np.arange(100, 200)
    left = np.stack([300 - 2 * (ys - 50), ys], 1)      # x = 300 at row 50, moving left downwards
    right = np.stack([300 + 3 * (ys - 50), ys], 1)     # and right
    assert ego_vanishing_row([("left", left), ("right", right)]) == pytest.approx(50.0)
    assert ego_vanishing_row([("left", left)]) is None
    assert ego_vanishing_row([("left", right), ("right", left)]) is None   # diverging upwards


def test_truth_readers(tmp_path):
    tr = load_truth([CLIP / "truth_lidar_range.csv", CLIP / "lead_boxes.csv"])
    assert sorted(tr.ranges) == list(range(20)) and sorted(tr.boxes) == list(range(20))
    assert tr.ranges[0] == pytest.approx(7.974 - LIDAR_BEHIND_CAMERA_M)    # ego_lane_min_x_m of frame 0
    # TTC from a range closing at a constant 5 m/s (0.5 m per 0.1 s frame): exactly d / 5
    t = Truth(ranges={k: 20.0 - 0.5 * k for k in range(10)}, dt=0.1)
    ttc = t.ttc()
    assert set(ttc) == set(range(2, 8)) and all(ttc[k] == pytest.approx((20 - 0.5 * k) / 5) for k in ttc)
    assert Truth(ranges={k: 10.0 for k in range(6)}).ttc()[3] is None      # not closing: no TTC
    kitti = tmp_path / "gt.txt"
    kitti.write_text("0 1 Car 0 0 -10 10 20 50 60 -1 -1 -1 -1000 -1000 -1000 -10\n")
    assert load_truth([kitti]).labels["id"].tolist() == [1]
    bad = tmp_path / "bad.txt"
    bad.write_text("hello world\n")
    with pytest.raises(ValueError, match="bad.txt"):
        load_truth([bad])
    with pytest.raises(ValueError, match="no such file"):
        load_truth([tmp_path / "missing.csv"])


def test_plot_helpers_break_lines_at_gaps_and_name_what_is_off_the_axis():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pyvehtrack.report.render import _axis_limit, _gapped
    fx, vy = _gapped([1, 2, 5, 6], [1.0, 2.0, 3.0, 4.0])
    assert fx == [1, 2, 4.5, 5, 6] and np.isnan(vy[2]) and vy[:2] == [1.0, 2.0] and vy[3:] == [3.0, 4.0]
    fig, ax = plt.subplots()
    _axis_limit(ax, {"#1": [5.0, 9.0], "#2": [220.0, 40.0], "truth": [7.0]}, 12.0, "m")
    assert ax.get_ylim() == (0.0, 12.0)
    assert [t.get_text() for t in ax.texts] == ["above the axis: #2 up to 220 m"]
    plt.close(fig)


def test_track_record_nulls_and_matches():
    from pyvehtrack.tracker import Track
    t = Track(3, "confirmed", (10, 20, 50, 60), (0.5, -0.25))
    r = track_record(7, [t])
    assert r == {"frame": 7, "tracks": [{"id": 3, "box": [10, 20, 50, 60], "state": "confirmed",
                                         "velocity_px": [0.5, -0.25], "distance_m": None, "ttc_s": None,
                                         "warning": None, "source": "shadow", "ttc_points_s": None,
                                         "ttc_fused_s": None}]}
    from pyvehtrack.report.records import _matched_ids
    assert _matched_ids([t], np.array([[11, 21, 50, 60]])) == {3}
    assert _matched_ids([t], np.array([[60, 21, 90, 60]])) == set() and _matched_ids([t], None) == set()
    g = track_record(7, [t], geometry=lambda _t: {"distance_m": 12.5, "ttc_s": 3.0, "warning": True})
    assert g["tracks"][0]["distance_m"] == 12.5 and g["tracks"][0]["warning"] is True


def test_no_data_sections_say_so(tmp_path):
    """A recording where nothing is found: every plot section explains itself."""
    rec = tmp_path / "flat"
    rec.mkdir()
    for k in range(3):
        cv2.imwrite(str(rec / f"{k:06d}.png"), np.full((120, 160), 90, np.uint8))
    page = make_report(rec, tmp_path / "out", progress=False).read_text()
    assert "No track was started" in page
    assert "No range truth given" in page and "No camera file (--camera)" in page
    assert "found no ego lane pair" in page
    assert "No box truth given" in page
    # the timeline and range sections have no image; the contact sheet (3) and run time (1) do
    assert len(re.findall(r'src="data:image/', page)) == 3 + 1


def test_naming_rule_finds_the_clip_camera_and_range_truth(tmp_path):
    rec = tmp_path / "clip4"                         # the first 4 frames, laid out as the shipped clip
    rec.mkdir()
    for k in range(4):
        shutil.copy(CLIP / f"{k:06d}.png", rec)
    shutil.copy(CLIP / "truth_lidar_range.csv", rec)
    shutil.copy(CAMERA, tmp_path / "clip4.camera.json")
    assert main(["report", str(rec), "--out", str(tmp_path / "r"), "--no-progress"]) == 0
    page = (tmp_path / "r" / "index.html").read_text()
    assert "clip4.camera.json" in page and "truth_lidar_range.csv" in page
    assert "<td>distance: frames compared</td><td>2</td>" in page      # frames 2-3: the track is confirmed
    assert main(["report", str(rec), "--out", str(tmp_path / "n"), "--no-progress", "--no-find"]) == 0
    page = (tmp_path / "n" / "index.html").read_text()
    assert "No camera file" in page and "distance MAE" not in page


def test_bad_arguments(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        make_report(tmp_path / "nothing", tmp_path / "o", progress=False)
    (tmp_path / "f.txt").write_text("x")
    with pytest.raises(ValueError, match="out_dir"):
        make_report(CLIP, tmp_path / "f.txt", progress=False)
    with pytest.raises(ValueError, match="fps"):
        make_report(CLIP, tmp_path / "o", fps=0, progress=False)
    with pytest.raises(TypeError, match="camera"):
        make_report(CLIP, tmp_path / "o", camera=3, progress=False)
    with pytest.raises(TypeError, match="detect_every"):
        make_report(CLIP, tmp_path / "o", detect_every=2.5, progress=False)
    with pytest.raises(ValueError, match="engine"):
        make_report(CLIP, tmp_path / "o", engine="gpu", progress=False)
    cam = tmp_path / "cam.json"
    cam.write_text("[1, 2")
    with pytest.raises(ValueError, match="cam.json"):
        make_report(CLIP, tmp_path / "o", camera=cam, progress=False)
    # the command: one line, exit 2
    assert main(["report", str(tmp_path / "nothing"), "--out", str(tmp_path / "o")]) == 2
    assert main(["report", str(CLIP), "--out", str(tmp_path / "o"), "--truth", str(tmp_path / "no.csv")]) == 2
    assert main(["report", str(CLIP), "--out", str(tmp_path / "o"), "--detect-every", "0"]) == 2


def _chromium(url: str, tmp: Path, name: str):
    """Screenshot (as an array) and the URLs of the page's own network requests."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("LD_PRELOAD", "ASAN_OPTIONS", "UBSAN_OPTIONS")}   # make check SAN=1 preloads ASan
    shot, netlog = tmp / f"{name}.png", tmp / f"{name}.netlog.json"
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                    "--disable-component-update", "--disable-sync", "--no-first-run",
                    f"--user-data-dir={tmp / (name + '.profile')}", "--proxy-server=127.0.0.1:9",
                    "--hide-scrollbars", f"--log-net-log={netlog}", f"--screenshot={shot}",
                    "--window-size=1200,2000", url],
                   env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=120, check=False)
    assert shot.is_file(), "chromium wrote no screenshot"
    urls = set(re.findall(r'"url":"([^"]+)"', netlog.read_text(errors="replace"))) if netlog.is_file() else None
    requested = None if urls is None else {u for u in urls if re.match(r"^(https?|wss?|ftp)://", u)
                                           and not _BROWSER_HOSTS.match(u)}
    return cv2.imread(str(shot)), requested


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (make setup installs it)")
def test_page_renders_in_chromium_without_network(clip_report, tmp_path):
    page, _ = clip_report
    img, requested = _chromium(page.resolve().as_uri(), tmp_path, "page")
    assert img is not None and img.shape[:2] == (2000, 1200)
    gray = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    assert np.mean(gray < 230) > 0.15, "the screenshot is (nearly) blank"
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 500, "no photo or plot rendered"
    assert requested is not None, "chromium wrote no net log"
    assert requested == set(), f"the page requested {sorted(requested)}"
    # control: the same check sees a page that loads one external image
    ctl = tmp_path / "control.html"
    ctl.write_text('<!DOCTYPE html><html><body><img src="http://example.com/x.png"></body></html>')
    _, requested = _chromium(ctl.as_uri(), tmp_path, "control")
    assert requested == {"http://example.com/x.png"}


def test_render_with_estimates_warnings_and_labels():
    """Records as the full pipeline will give them (distance, TTC, warnings) with KITTI labels:
    the warning note goes, the errors are the ones the numbers imply."""
    from pyvehtrack.report.records import FrameInfo
    from pyvehtrack.report.render import render_html
    recs, infos, labels = [], [], []
    for k in range(12):
        d = 20.0 - 0.5 * k                           # closing at 5 m/s (dt 0.1 s): TTC = d / 5
        warn = k >= 8
        recs.append({"frame": k, "tracks": [
            {"id": 4, "box": [100, 50, 160, 100], "state": "confirmed" if k >= 2 else "tentative",
             "velocity_px": [0.0, 0.1], "distance_m": d + 1.0, "ttc_s": d / 5 + 0.5, "warning": warn,
             "source": "shadow"}]})
        infos.append(FrameInfo(frame=k, timing_ms={"lanes": 0.3, "track": 0.1}))
        labels.append(f"{k} 1 Car 0 0 -10 100 50 160 100 -1 -1 -1 -1000 -1000 -1000 -10")
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        gt = Path(tmp) / "gt.txt"
        gt.write_text("\n".join(labels) + "\n")
        truth = load_truth([gt])
    truth.ranges = {k: 20.0 - 0.5 * k for k in range(12)}
    page = render_html(recs, infos, [], title="t", meta={}, truth=truth)
    assert "No forward-collision warning" not in page
    assert "<td>warnings (frames with a warning)</td><td>4</td>" in page
    assert "<td>distance MAE</td><td>1.00 m</td>" in page and "<td>distance bias</td><td>+1.00 m</td>" in page
    assert "<td>distance/rate TTC MAE</td><td>0.50 s</td>" in page
    assert "fused TTC" not in page           # these records carry no fused TTC
    assert "<td>MOTA</td><td>83.3%</td>" in page   # frames 0-1 tentative (not scored): 2 misses of 12
    assert "No frame in this recording." in page            # no thumbnails given


def test_track_tiles_keep_the_cut_nearest_the_middle_and_survive_odd_boxes():
    """TrackTiles cuts a track's tile on its 1st, 2nd, 4th, 8th, ... frame, holds at most two, and
    picks the cut nearest the middle of its life: a track seen on 10 frames shows its 4th (|4 - 5.5| = 1.5
    against 2.5 for the 8th). Each frame here is one grey level (its index x 20), so the tile's
    pixels say which frame it came from. A box wholly outside the frame gives an empty tile,
    one partly outside is cut clipped, gray and colour frames both give BGR tiles."""
    from pyvehtrack.report.render import TRACK_TILE, TrackTiles, track_tile
    tiles = TrackTiles()
    for k in range(10):
        frame = np.full((120, 160), 20 * k, np.uint8)
        tracks = [{"id": 7, "box": [60, 40, 90, 70]}] + ([{"id": 9, "box": [10, 10, 30, 30]}] if k < 3 else [])
        tiles.add(frame, {"tracks": tracks})
    assert all(len(c) <= 2 for c in tiles.cuts.values())   # older cuts dropped as the middle moves on
    got = {k: cv2.imdecode(np.frombuffer(v, np.uint8), cv2.IMREAD_COLOR) for k, v in tiles.pick().items()}
    assert set(got) == {7, 9}
    assert got[7].shape == (TRACK_TILE[1], TRACK_TILE[0], 3)
    # JPEG keeps a flat grey within a level or two; the frames differ by 20 levels
    assert abs(np.median(got[7]) - 20 * 3) <= 2      # its 4th frame (index 3)
    assert abs(np.median(got[9]) - 20 * 1) <= 2      # seen 3 times: cuts 1, 2; middle 2 -> the 2nd
    gray = np.full((50, 60), 100, np.uint8)
    assert not track_tile(gray, [200, 200, 220, 220]).any()
    part = track_tile(gray, [50, 40, 80, 70])
    assert part.shape == (TRACK_TILE[1], TRACK_TILE[0], 3) and part.any()
    colour = np.zeros((50, 60, 3), np.uint8)
    colour[..., 1] = 200
    c = track_tile(colour, [10, 10, 20, 20])
    assert c.shape == (TRACK_TILE[1], TRACK_TILE[0], 3) and int(np.median(c[..., 1])) == 200


def test_lead_without_box_truth_spans_the_centre_column():
    """Without truth boxes the page takes as the lead car the nearest confirmed track with a
    distance whose box spans the image's centre column (the KITTI clip: a parked truck at the
    left kerb, 4 m away, is not the lead car at 7 m); a frame with no known width takes any
    box, as before."""
    from pyvehtrack.report.render import lead_ids
    recs = [{"frame": 0, "tracks": [
        {"id": 1, "state": "confirmed", "box": [255, 35, 407, 187], "distance_m": 7.2},
        {"id": 6, "state": "confirmed", "box": [21, 60, 144, 253], "distance_m": 4.2},
        {"id": 5, "state": "tentative", "box": [300, 60, 340, 100], "distance_m": 3.0}]}]
    assert lead_ids(recs, Truth(), {0: 640}) == {0: 1}
    assert lead_ids(recs, Truth()) == {0: 6}
    assert lead_ids(recs, Truth(), {0: 1000}) == {}     # no confirmed box spans column 499.5
