"""`pyvehtrack batch` (issue 12, item 2) on a 2-worker dask LocalCluster (one per module):
synthetic recordings plus a corrupt one give the same per-recording outputs as `track` run
alone, the corrupt one is listed failed, and a rerun does no work."""
from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack import synth
from pyvehtrack.batch import companion_files, frames_path, output_names, run_batch
from pyvehtrack.cli import main

N_REC, N_FRAMES, W, H = 3, 12, 320, 240


@pytest.fixture(scope="module")
def cluster():
    import logging

    from dask.distributed import LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.CRITICAL) as c:
        yield c.scheduler_address


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    root = tmp_path_factory.mktemp("recs")
    recs = []
    for i, seq in enumerate(synth.make_set(N_REC, seed=11, camera=synth.Camera(W, H), n_frames=N_FRAMES)):
        synth.write_kitti(seq, root / f"rec{i}")          # rec{i}/frames/*.png + rec{i}/gt.txt
        recs.append(str(root / f"rec{i}"))
    bad = root / "corrupt"                              # a PNG signature and then garbage
    bad.mkdir()
    for k in range(2):
        (bad / f"{k:06d}.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(64)))
    return recs + [str(bad)]


@pytest.fixture(scope="module")
def first_run(cluster, recordings, tmp_path_factory):
    out = tmp_path_factory.mktemp("results")
    return out, run_batch(recordings, out, scheduler=cluster, progress=False)


def test_batch_matches_track_alone_and_lists_the_corrupt_one(first_run, recordings, tmp_path):
    out, s = first_run
    assert s.submitted == len(recordings)
    rows = {Path(r["recording"]).name: r for r in s.rows}
    assert rows["corrupt"]["status"] == "failed" and "cannot read as an image" in rows["corrupt"]["error"]
    assert not (out / "corrupt" / "DONE").exists() and (out / "corrupt" / "FAILED").exists()
    for rec in recordings[:-1]:
        name = Path(rec).name
        r = rows[name]
        assert r["status"] == "ok", r
        alone = tmp_path / f"{name}.txt"
        assert main(["track", frames_path(rec), "--out", str(tmp_path / f"{name}.mp4"), "--tracks", str(alone),
                     "--no-progress"]) == 0
        assert (out / name / "tracks.txt").read_text() == alone.read_text()
        assert r["frames"] == N_FRAMES
        assert (out / name / "annotated.mp4").stat().st_size > 0
        recs = json.loads((out / name / "tracks.json").read_text())
        assert [x["frame"] for x in recs] == list(range(N_FRAMES))
        n_lines = len(alone.read_text().splitlines())
        assert sum(len(x["tracks"]) for x in recs) == n_lines == r["track_frames"]
        assert 0.0 <= r["HOTA"] <= 1.0            # scored against the recording's gt.txt
        assert (out / name / "DONE").exists()
    table = list(csv.DictReader(open(out / "results.csv")))
    assert [t["recording"] for t in table] == recordings + ["ALL"]
    assert table[-1]["status"] == f"{len(recordings) - 1} ok, 1 failed"
    md = (out / "results.md").read_text()
    assert "| failed |" in md and "## All recordings" in md


def test_rerun_does_no_work_and_resumes_a_changed_recording(first_run, recordings, cluster):
    out, _ = first_run
    stamp = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p.parent != out}
    s = run_batch(recordings, out, scheduler=cluster, progress=False)
    assert s.submitted == 0
    assert {r["this_run"] for r in s.rows} == {"skipped (complete)", "skipped (failed before)"}
    assert stamp == {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p.parent != out}
    # the command too: nothing to do, so no cluster is even started; exit 1 = a recording failed
    assert main(["batch", *recordings, "--out", str(out), "--no-progress"]) == 1
    # a changed recording (one frame rewritten) is the only one run again
    f0 = Path(recordings[0]) / "frames" / "000000.png"
    os.utime(f0, ns=(f0.stat().st_atime_ns, f0.stat().st_mtime_ns + 10**9))
    s = run_batch(recordings, out, scheduler=cluster, progress=False)
    assert s.submitted == 1 and s.rows[0]["this_run"] == "ran" and s.rows[0]["status"] == "ok"


def test_reports_use_the_recordings_truth(recordings, cluster, tmp_path):
    s = run_batch(recordings[:1], tmp_path, scheduler=cluster, reports=True, progress=False)
    assert s.rows[0]["status"] == "ok", s.rows[0]
    page = (tmp_path / "rec0" / "report" / "index.html").read_text()
    assert "gt.txt: KITTI tracking labels" in page and "<td>HOTA</td>" in page
    assert s.aggregate["scored"] == 1 and "HOTA" in s.aggregate


def test_default_local_cluster(recordings, tmp_path):
    """Without --scheduler, run_batch starts (and closes) its own LocalCluster."""
    s = run_batch(recordings[1:2], tmp_path, workers=1, progress=False)
    assert s.submitted == 1 and s.rows[0]["status"] == "ok"
    assert (tmp_path / "rec1" / "tracks.txt").is_file() and (tmp_path / "rec1" / "DONE").is_file()


def test_naming_rule(tmp_path):
    rec = tmp_path / "drive"
    (rec / "frames").mkdir(parents=True)
    cv2.imwrite(str(rec / "frames" / "000000.png"), np.zeros((8, 8), np.uint8))
    (rec / "gt.txt").write_text("")
    (rec / "truth_lidar.csv").write_text("")
    (rec / "camera.json").write_text("{}")
    (tmp_path / "drive.truth.csv").write_text("")
    video = tmp_path / "run 1.mp4"
    video.write_bytes(b"")
    (tmp_path / "run 1.truth.txt").write_text("")
    (tmp_path / "run 1.camera.json").write_text("{}")
    c = companion_files(rec)
    assert [Path(p).name for p in c["truth"]] == ["gt.txt", "truth_lidar.csv", "drive.truth.csv"]
    assert Path(c["camera"]).name == "camera.json"
    assert frames_path(rec) == str(rec / "frames")
    c = companion_files(video)
    assert [Path(p).name for p in c["truth"]] == ["run 1.truth.txt"]
    assert Path(c["camera"]).name == "run 1.camera.json"
    assert output_names([str(rec), str(video), str(tmp_path / "x" / "drive")])[1] == "run_1"
    a, _, b = output_names([str(rec), str(video), str(tmp_path / "x" / "drive")])
    assert a != b and a.startswith("drive-") and b.startswith("drive-")


def test_bad_arguments(tmp_path):
    with pytest.raises(TypeError, match="recordings"):
        run_batch("rec", tmp_path)
    with pytest.raises(ValueError, match="recordings"):
        run_batch([], tmp_path)
    with pytest.raises(ValueError, match="workers"):
        run_batch(["a"], tmp_path, workers=0)
    with pytest.raises(ValueError, match="detect_every"):
        run_batch(["a"], tmp_path, detect_every=0)
    with pytest.raises(ValueError, match="box_top"):
        run_batch(["a"], tmp_path, box_top="square")
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="not a folder"):
        run_batch(["a"], tmp_path / "file")
    # a missing recording is a failed row (no cluster needed when nothing is left to run)
    s = run_batch([str(tmp_path / "missing")], tmp_path / "out", progress=False)
    assert s.submitted == 0 and s.rows[0]["status"] == "failed" and "no such file" in s.rows[0]["error"]
    assert main(["batch", "x", "--out", str(tmp_path / "o"), "--workers", "0"]) == 2
    assert main(["batch", "x", "--out", str(tmp_path / "o"), "--scheduler", "nowhere"]) == 2


def test_range_options_reach_track_and_report(cluster, recordings, first_run, tmp_path):
    """The range and warning options go to `track` (and the report) for a recording with a
    camera file: the batch's tracks.json is `track --camera ...`'s with the same options, byte
    for byte (the same command), and the page names them. A recording without a camera file
    in the same batch runs without them (its outputs are the plain run's). Bad values are
    refused before any work."""
    import shutil
    data = Path(__file__).parent / "data"
    rec = tmp_path / "kitti"
    shutil.copytree(data / "kitti_clip", rec)
    shutil.copy(data / "kitti_clip.camera.json", rec / "camera.json")
    s = run_batch([str(rec), recordings[0]], tmp_path / "out", scheduler=cluster, reports=True, progress=False,
                  rear_offset=1.8, ego_speed=10, warn_ttc="fused", path_half_width=1.2)
    assert [r["status"] for r in s.rows] == ["ok", "ok"], s.rows
    assert main(["track", str(rec), "--camera", str(rec / "camera.json"), "--rear-offset", "1.8",
                 "--ego-speed", "10", "--warn-ttc", "fused", "--path-half-width", "1.2",
                 "--out", str(tmp_path / "t.mp4"), "--json", str(tmp_path / "t.json"), "--no-progress"]) == 0
    assert (tmp_path / "out" / "kitti" / "tracks.json").read_text() == (tmp_path / "t.json").read_text()
    # and not the same as without the options (the fused TTC's warning rule and the offset are in it)
    assert main(["track", str(rec), "--camera", str(rec / "camera.json"), "--out", str(tmp_path / "p.mp4"),
                 "--json", str(tmp_path / "p.json"), "--no-progress"]) == 0
    assert (tmp_path / "p.json").read_text() != (tmp_path / "t.json").read_text()
    page = (tmp_path / "out" / "kitti" / "report" / "index.html").read_text()
    assert "rear offset 1.8 m" in page and "on the fused TTC, ego speed 10 m/s" in page
    name = Path(recordings[0]).name
    plain_out, _ = first_run
    assert (tmp_path / "out" / name / "tracks.json").read_text() == (plain_out / name / "tracks.json").read_text()
    for kw, bads in (("rear_offset", (-1, 6, float("nan"), "1.8", True)),
                     ("bottom_height", (-0.1, float("inf"), None)),
                     ("path_half_width", (-1, 11, "1")),
                     ("ego_speed", (-1, float("inf"), float("nan"), "10", True)),
                     ("warn_ttc", ("ttc", None))):
        for bad in bads:
            with pytest.raises(ValueError, match=kw):
                run_batch([str(rec)], tmp_path / "o2", **{kw: bad})
    assert not (tmp_path / "o2").exists()
    for flag, val in (("--ego-speed", "-1"), ("--warn-ttc", "x"), ("--path-half-width", "11")):
        assert main(["batch", str(rec), "--out", str(tmp_path / "o4"), flag, val]) == 2, flag
    assert main(["batch", str(rec), "--out", str(tmp_path / "o3"), "--rear-offset", "9"]) == 2


def test_box_top_reaches_track(cluster, tmp_path):
    """`batch --box-top tracker` runs `track --box-top tracker` on each recording: the batch's
    tracks.json is that command's, byte for byte, and not the default's (the KITTI clip's lead car
    has boxes whose top the default takes from the CNN)."""
    import shutil
    rec = tmp_path / "kitti"
    shutil.copytree(Path(__file__).parent / "data" / "kitti_clip", rec)
    assert main(["batch", str(rec), "--out", str(tmp_path / "out"), "--scheduler", cluster, "--box-top", "tracker",
                 "--no-progress"]) == 0
    got = (tmp_path / "out" / "kitti" / "tracks.json").read_text()
    for top in ("tracker", "cnn"):
        assert main(["track", str(rec), "--box-top", top, "--out", str(tmp_path / f"{top}.mp4"),
                     "--json", str(tmp_path / f"{top}.json"), "--no-progress"]) == 0
    assert got == (tmp_path / "tracker.json").read_text() != (tmp_path / "cnn.json").read_text()
