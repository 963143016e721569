"""`pyvehtrack batch`: `track` (and optionally `report`) over many recordings on Dask.

    from pyvehtrack.batch import run_batch
    summary = run_batch(["rec1/", "rec2.mp4"], "results/", workers=2)        # a LocalCluster
    summary = run_batch(recs, "results/", scheduler="tcp://host:8786")       # an existing cluster

Each recording (a video, or a folder of frames) is one task of `dask.distributed`: by
default on a LocalCluster of N worker processes with one thread each (the C core is
single-threaded; processes keep a crash in one recording inside its worker), or on an
existing scheduler. A task runs the `pyvehtrack track` command itself (the same code,
options and outputs as running it by hand) and, with reports=True, `pyvehtrack report`.

Per recording, RESULTS/<name>/ holds
    tracks.txt      KITTI tracking labels (`track --tracks`)
    annotated.mp4   the annotated video (`track --out`)
    tracks.json     per-frame records in the `track --json` schema
    report/         index.html (reports=True)
    result.json     this recording's row of the results table (error.txt: a traceback when
                    the failure was not one of track's own one-line errors)
    DONE | FAILED   the marker, written last: the input's fingerprint (file names, sizes,
                    modification times, options)
A rerun skips every recording whose marker matches its fingerprint (a completed one, and a
failed one unless retry_failed), so an interrupted batch resumes where it stopped and a
finished one does no work. RESULTS/results.csv and RESULTS/results.md hold one row per
recording plus the aggregate.

Truth and camera files are found by name (the first that exists is used for the camera;
every truth file found is used):
    folder REC/      REC/gt.txt, REC/truth*.txt, REC/truth*.csv   and  REC/camera.json
                     (or beside it: REC.truth*.txt|csv, REC.camera.json); the frames are
                     REC's image files, or those of REC/frames/ when REC holds none (the
                     layout pyvehtrack.synth.write_kitti writes)
    video  DIR/S.ext DIR/S.truth*.txt|csv                         and  DIR/S.camera.json
A truth file with track ids (KITTI labels, e.g. gt.txt) gives HOTA / MOTA / IDF1 in the table.
`track`'s range and warning options (rear_offset, bottom_height, path_half_width, ego_speed,
warn_ttc) go to the recordings that have a camera file, one value for all of them.
"""
from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import math
import os
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from ._check import choice, warning_options
from .shared import WORK_WIDTH
from .report.records import IMAGE_EXTS, VIDEO_EXTS, companion_files

MARK_DONE, MARK_FAILED = "DONE", "FAILED"
COLUMNS = ("recording", "status", "this_run", "frames", "tracks", "track_frames", "seconds", "fps",
           "HOTA", "MOTA", "IDF1", "IDSW", "truth", "camera", "error", "outputs")


# ====================================================================== naming rule
def frames_path(rec) -> str:
    """What `track` is given for a recording: the folder itself, or REC/frames/ when REC
    holds no image file but that subfolder exists; a video as is."""
    p = Path(rec)
    if p.is_dir() and not any(q.suffix.lower() in IMAGE_EXTS for q in p.iterdir() if q.is_file()) \
            and (p / "frames").is_dir():
        return str(p / "frames")
    return str(p)


def fingerprint(rec, opts: dict) -> str:
    """A hash of what a recording's outputs depend on: its files (name, size, mtime), its
    truth / camera files and the options."""
    p = Path(rec)
    items = []
    fr = Path(frames_path(p))
    files = sorted(q for q in fr.iterdir() if q.is_file()) if fr.is_dir() else [fr]
    comp = companion_files(p)
    files += [Path(q) for q in comp["truth"]] + ([Path(comp["camera"])] if comp["camera"] else [])
    for q in files:
        st = q.stat()
        items.append((str(q.resolve()), st.st_size, st.st_mtime_ns))
    blob = json.dumps({"files": items, "opts": opts}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def output_names(recordings) -> list:
    """A distinct folder name per recording (its name; a short hash of its path is added
    when two recordings share a name)."""
    base = [Path(r).name if Path(r).is_dir() else Path(r).stem for r in recordings]
    base = [re.sub(r"[^A-Za-z0-9._-]", "_", b) or "recording" for b in base]
    out = []
    for r, b in zip(recordings, base):
        if base.count(b) > 1:
            b = f"{b}-{hashlib.sha1(str(Path(r).resolve()).encode()).hexdigest()[:8]}"
        out.append(b)
    return out


def marker_state(out_dir: Path, fp: str) -> str | None:
    """'done' / 'failed' when a marker of this fingerprint is there, else None."""
    for name, state in ((MARK_DONE, "done"), (MARK_FAILED, "failed")):
        m = out_dir / name
        if m.is_file() and (out_dir / "result.json").is_file():
            try:
                if json.loads(m.read_text()).get("fingerprint") == fp:
                    return state
            except (OSError, ValueError):
                pass
    return None


# ====================================================================== one recording (a Dask task)
def _track_parser_has(option: str) -> bool:
    from .cli import build_parser
    parser = build_parser()
    for a in parser._subparsers._group_actions:          # the subcommand table
        sub = a.choices.get("track")
        if sub is not None:
            return any(option in act.option_strings for act in sub._actions)
    return False


def tracks_txt_to_records(path, n_frames: int) -> list:
    """Records in the `track --json` schema from a KITTI tracks file (the fallback while
    `track --json` is not in this build): state from the score column (1 confirmed,
    0.5 coasting, 0.25 tentative); velocity, distance, TTC, warning and source null."""
    states = {1.0: "confirmed", 0.5: "coasting", 0.25: "tentative", 0.4: "handover"}
    recs = [{"frame": k, "tracks": []} for k in range(n_frames)]
    for line in Path(path).read_text().splitlines():
        f = line.split()
        if len(f) < 18:
            continue
        k = int(f[0])
        while k >= len(recs):
            recs.append({"frame": len(recs), "tracks": []})
        recs[k]["tracks"].append({"id": int(f[1]), "box": [int(round(float(v))) for v in f[6:10]],
                                  "state": states.get(round(float(f[17]), 2), "confirmed"),
                                  "velocity_px": None, "distance_m": None, "ttc_s": None,
                                  "warning": None, "source": None})
    return recs


def _run_cli(argv) -> tuple[int, str, str]:
    from .cli import main
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as e:           # argparse errors
            code = e.code if isinstance(e.code, int) else 2
    return int(code or 0), out.getvalue(), err.getvalue()


class TrackFailed(Exception):
    """`pyvehtrack track` exited with an error (its one-line message)."""


def warm_worker() -> None:
    """Import what a task needs once per worker (so the first recording's time is not the
    imports') and silence OpenCV's own log of unreadable files (the row has the error)."""
    import cv2
    try:
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    except AttributeError:
        pass
    from . import _native, cli  # noqa: F401
    from .report import records  # noqa: F401
    try:
        from .eval import tracking  # noqa: F401
    except ImportError:
        pass
    cli.build_parser()


def process_recording(rec: str, out_dir: str, opts: dict, fp: str) -> dict:
    """Run track (and report) on one recording; write its outputs, result.json and the
    marker (last). Never raises for a bad recording: the row says status 'failed' and why."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for m in (MARK_DONE, MARK_FAILED, "error.txt"):
        (out / m).unlink(missing_ok=True)
    comp = companion_files(rec)
    row = {"recording": rec, "status": "failed", "this_run": "ran", "truth": ";".join(comp["truth"]),
           "camera": comp["camera"] or "", "outputs": str(out), "error": ""}
    t0 = time.perf_counter()
    try:
        src = frames_path(rec)
        argv = ["track", src, "--out", str(out / "annotated.mp4"), "--tracks", str(out / "tracks.txt"),
                "--engine", opts["engine"], "--detect-every", str(opts["detect_every"]), "--no-progress"]
        if opts.get("skip_bad_frames"):
            argv.append("--skip-bad-frames")
        if opts.get("box_top"):
            argv += ["--box-top", opts["box_top"]]
        if "work_width" in opts:
            argv += ["--work-width", str(opts["work_width"] or 0)]
        native_json = _track_parser_has("--json")
        if native_json:
            argv += ["--json", str(out / "tracks.json")]
        if comp["camera"] and _track_parser_has("--camera"):
            argv += ["--camera", comp["camera"]]
            for k, v in opts.items():
                if k in RANGE_DEFAULTS:
                    argv += ["--" + k.replace("_", "-"), v if isinstance(v, str) else repr(v)]
        code, so, se = _run_cli(argv)
        if code != 0:
            msg = [ln for ln in se.strip().splitlines() if ln.strip() and not ln.startswith("[")]
            raise TrackFailed(msg[-1].replace("pyvehtrack track: error: ", "")
                              if msg else f"track exited with status {code}")
        m = re.search(r"(\d+) frame\(s\), (\d+) track\(s\), (\d+) track-frame", so)
        row["frames"], row["tracks"], row["track_frames"] = (int(m.group(i)) for i in (1, 2, 3)) if m else ("",) * 3
        if not native_json:
            from .report.records import write_records
            write_records(out / "tracks.json", tracks_txt_to_records(out / "tracks.txt", int(row["frames"] or 0)))
        row["seconds"] = round(time.perf_counter() - t0, 3)
        row["fps"] = round(row["frames"] / row["seconds"], 1) if row["frames"] and row["seconds"] else ""
        gt = [t for t in comp["truth"] if _has_ids(t)]
        if gt:
            from .eval.tracking import evaluate_kitti
            res = evaluate_kitti(gt[0], str(out / "tracks.txt"), num_frames=row["frames"] or None)
            row.update({k: round(float(res[k]), 4) for k in ("HOTA", "MOTA", "IDF1")})
            row["IDSW"] = int(res["IDSW"])
        if opts.get("reports"):
            from .report import make_report
            make_report(src, out / "report", truth=comp["truth"], camera=comp["camera"], engine=opts["engine"],
                        detect_every=opts["detect_every"], progress=False, box_top=opts.get("box_top", "cnn"),
                        work_width=opts.get("work_width", WORK_WIDTH),
                        **({k: opts.get(k, d) for k, d in RANGE_DEFAULTS.items()} if comp["camera"] else {}))
        row["status"] = "ok"
    except TrackFailed as e:
        row["error"] = f"track: {e}"
    except Exception as e:                       # a failing recording is a row, not a crash
        import traceback
        row["error"] = f"{type(e).__name__}: {e} (traceback in {out / 'error.txt'})"
        (out / "error.txt").write_text(traceback.format_exc())
        row.setdefault("seconds", round(time.perf_counter() - t0, 3))
    (out / "result.json").write_text(json.dumps(row, indent=1) + "\n")
    marker = MARK_DONE if row["status"] == "ok" else MARK_FAILED
    (out / marker).write_text(json.dumps({"fingerprint": fp, "status": row["status"]}) + "\n")
    return row


def _has_ids(path) -> bool:
    """True for a KITTI tracking label file (frame id type ...), the truth TrackEval scores."""
    try:
        with open(path) as fh:
            for line in fh:
                f = line.split()
                if f:
                    return len(f) >= 10 and f[0].lstrip("-").isdigit() and f[1].lstrip("-").isdigit()
    except OSError:
        return False
    return False


# ====================================================================== the batch
# track's (and make_report's) range and warning options and their defaults: a recording with
# a camera file gets those given; the opts (and so the fingerprints) hold only the values
# that differ from these, so runs without them keep the fingerprints they had.
RANGE_DEFAULTS = {"rear_offset": 0.0, "bottom_height": 0.0, "path_half_width": 1.5, "ego_speed": None,
                  "warn_ttc": "distance"}


def _range_opts(rear_offset, bottom_height, path_half_width, ego_speed, warn_ttc) -> dict:
    """The range and warning options checked (ValueError naming the argument), as the
    non-default ones."""
    def number(name, v, lo, hi, unit):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not lo <= v <= hi:
            raise ValueError(f"{name} must be a number in [{lo}, {hi:g}] {unit}, got {v!r}")
        return float(v)

    warning_options(ego_speed, warn_ttc)
    vals = {"rear_offset": number("rear_offset", rear_offset, 0, 5, "m"),
            "bottom_height": number("bottom_height", bottom_height, 0, math.inf, "m"),
            "path_half_width": number("path_half_width", path_half_width, 0, 10, "m"),
            "ego_speed": None if ego_speed is None else float(ego_speed), "warn_ttc": warn_ttc}
    return {k: v for k, v in vals.items() if v != RANGE_DEFAULTS[k]}


@dataclass
class BatchSummary:
    rows: list = field(default_factory=list)
    submitted: int = 0              # recordings run in this call (0 on a complete rerun)
    wall_s: float = 0.0
    aggregate: dict = field(default_factory=dict)
    csv: str = ""
    md: str = ""


def _is_recording(p: Path) -> bool:
    if p.is_dir():
        return True
    return p.suffix.lower() in VIDEO_EXTS | IMAGE_EXTS


def run_batch(recordings, out, *, scheduler: str | None = None, workers: int = 2, reports: bool = False,
              engine: str = "c", detect_every: int = 10, retry_failed: bool = False,
              skip_bad_frames: bool = False, progress: bool = True, rear_offset: float = 0.0,
              bottom_height: float = 0.0, path_half_width: float = 1.5, ego_speed: float | None = None,
              warn_ttc: str = "distance", box_top: str = "cnn", work_width=WORK_WIDTH) -> BatchSummary:
    """Run every recording (see the module doc); returns the table rows and figures.
    rear_offset (m, 0..5), bottom_height (m, >= 0; below each camera file's height_m, which
    `track` checks per recording), path_half_width (m, 0..10), ego_speed (m/s >= 0, None:
    unknown) and warn_ttc ("distance" or "fused"): `track`'s options of the same names (and
    the report's), for the recordings that have a camera file; the others run without them.
    One ego speed serves every recording (a fleet driven at one speed, or a rough bound).
    box_top ("cnn", the default, or "tracker"): `track --box-top` for every recording.
    work_width (default 1280; None: only past the core's maximum): `track --work-width` for every
    recording.
    ValueError / TypeError naming the argument for bad arguments; a bad recording is a
    failed row, never an exception."""
    from tqdm import tqdm

    if isinstance(recordings, (str, os.PathLike)):
        raise TypeError("recordings: expected a list of paths, got a single path")
    recordings = [str(r) for r in recordings]
    if not recordings:
        raise ValueError("recordings: no recording given")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if engine not in ("c", "reference"):
        raise ValueError(f"engine must be 'c' or 'reference', got {engine!r}")
    if isinstance(detect_every, bool) or not isinstance(detect_every, int) or detect_every < 1:
        raise ValueError(f"detect_every must be an integer >= 1, got {detect_every!r}")
    range_opts = _range_opts(rear_offset, bottom_height, path_half_width, ego_speed, warn_ttc)
    choice(box_top, "box_top", ("cnn", "tracker"))
    from .pipeline import check_work_width  # noqa: PLC0415
    work_width = check_work_width(work_width)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"out {out}: exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    opts = {"engine": engine, "detect_every": detect_every, "reports": bool(reports),
            "skip_bad_frames": bool(skip_bad_frames)}
    opts.update(range_opts)
    if box_top != "cnn":   # only when not the default: earlier runs' fingerprints stay valid
        opts["box_top"] = box_top
    if work_width != WORK_WIDTH:   # likewise
        opts["work_width"] = work_width
    t_start = time.perf_counter()
    rows: dict = {}
    todo = []
    for rec, name in zip(recordings, output_names(recordings)):
        p, rdir = Path(rec), out / name
        if not p.exists() or not _is_recording(p):
            rows[rec] = {"recording": rec, "status": "failed", "this_run": "not run", "outputs": "",
                         "error": "no such file or directory" if not p.exists() else
                         f"not a video ({', '.join(sorted(VIDEO_EXTS))}), image or folder"}
            continue
        fp = fingerprint(p, opts)
        st = marker_state(rdir, fp)
        if st == "done" or (st == "failed" and not retry_failed):
            row = json.loads((rdir / "result.json").read_text())
            row["this_run"] = "skipped (complete)" if st == "done" else "skipped (failed before)"
            rows[rec] = row
        else:
            todo.append((rec, str(rdir), fp))
    if todo:
        _submit_all(todo, opts, rows, scheduler, workers, progress, tqdm)
    ordered = [rows[r] for r in recordings]
    summ = BatchSummary(rows=ordered, submitted=len(todo), wall_s=time.perf_counter() - t_start)
    summ.aggregate = aggregate(ordered, out, recordings)
    summ.aggregate["wall_s_this_run"] = round(summ.wall_s, 2)
    summ.csv, summ.md = write_tables(out, ordered, summ.aggregate)
    return summ


def _submit_all(todo, opts, rows, scheduler, workers, progress, tqdm):
    import logging

    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    try:
        if scheduler:
            try:
                client = Client(scheduler, timeout="15s")
            except (OSError, TimeoutError) as e:
                raise ValueError(f"scheduler {scheduler}: cannot connect ({e})") from None
        else:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=":0", silence_logs=logging.CRITICAL)
            client = Client(cluster)
        with client:
            client.run(warm_worker)
            futs = {client.submit(process_recording, rec, rdir, opts, fp, pure=False,
                                  key=f"pyvehtrack-{Path(rdir).name}-{fp[:12]}"): rec
                    for rec, rdir, fp in todo}
            with tqdm(total=len(futs), unit="recording", disable=not progress, file=sys.stderr,
                      desc="batch") as bar:
                for fut in as_completed(futs):
                    rec = futs[fut]
                    try:
                        rows[rec] = fut.result()
                    except Exception as e:       # the worker died (e.g. a crash in native code)
                        rows[rec] = {"recording": rec, "status": "failed", "this_run": "ran",
                                     "error": f"{type(e).__name__}: {e}", "outputs": ""}
                    bar.update(1)
    finally:
        if cluster is not None:
            cluster.close()


# ====================================================================== tables
def aggregate(rows, out: Path, recordings) -> dict:
    ok = [r for r in rows if r.get("status") == "ok"]
    agg = {"recordings": len(rows), "ok": len(ok), "failed": len(rows) - len(ok),
           "frames": sum(int(r.get("frames") or 0) for r in ok),
           "tracks": sum(int(r.get("tracks") or 0) for r in ok),
           "track_frames": sum(int(r.get("track_frames") or 0) for r in ok),
           "seconds": round(sum(float(r.get("seconds") or 0) for r in ok), 2)}
    agg["fps"] = round(agg["frames"] / agg["seconds"], 1) if agg["seconds"] else ""
    pairs = []
    for r in ok:
        gt = [t for t in (r.get("truth") or "").split(";") if t and _has_ids(t)]
        tr = Path(r["outputs"]) / "tracks.txt"
        if gt and tr.is_file():
            pairs.append((gt[0], str(tr), int(r["frames"]) if r.get("frames") else None))
    if pairs:
        from .eval.tracking import evaluate_many
        try:
            res = evaluate_many([p if p[2] else p[:2] for p in pairs])
            agg.update({k: round(float(res[k]), 4) for k in ("HOTA", "MOTA", "IDF1")})
            agg["IDSW"] = int(res["IDSW"])
            agg["scored"] = len(pairs)
        except (ValueError, OSError) as e:
            agg["score_error"] = str(e)
    return agg


def _fmt(v) -> str:
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:g}"
    return "" if v is None else str(v)


def write_tables(out: Path, rows, agg) -> tuple[str, str]:
    csv_path, md_path = out / "results.csv", out / "results.md"
    with open(csv_path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: _fmt(r.get(k)) for k in COLUMNS})
        w.writerow({"recording": "ALL", "status": f"{agg['ok']} ok, {agg['failed']} failed",
                    **{k: _fmt(agg.get(k)) for k in ("frames", "tracks", "track_frames", "seconds", "fps",
                                                     "HOTA", "MOTA", "IDF1", "IDSW")}})
    md_cols = ("recording", "status", "this_run", "frames", "tracks", "seconds", "fps", "HOTA", "MOTA",
               "IDF1", "IDSW", "error")

    def cell(v):
        return _fmt(v).replace("|", "\\|").replace("\n", " ")
    lines = ["# pyvehtrack batch results", "",
             "| " + " | ".join(md_cols) + " |", "|" + "---|" * len(md_cols)]
    for r in rows:
        lines.append("| " + " | ".join(cell(r.get(k)) for k in md_cols) + " |")
    lines += ["", "## All recordings", "", "| what | value |", "|---|---|"]
    for k, v in agg.items():
        lines.append(f"| {k} | {cell(v)} |")
    lines.append("")
    if any(k in agg for k in ("HOTA",)):
        lines.append(f"HOTA / MOTA / IDF1 over the {agg.get('scored')} recording(s) with KITTI labels "
                     "(TrackEval, KITTI rules, class Car, combined as TrackEval combines sequences).")
    md_path.write_text("\n".join(lines) + "\n")
    return str(csv_path), str(md_path)
