#!/usr/bin/env python3
"""Wall time of `pyvehtrack batch` (pyvehtrack.batch.run_batch) with 1 and 2 LocalCluster
workers over 8 synthetic recordings + 1 corrupt one (issue 12's acceptance figure).

    PYTHONPATH=. python3 bench/batch_bench.py [--frames 60] [--size 640x480] [--out bench/batch_results.md]

Each run starts its own LocalCluster (processes, one thread each), so the wall time includes
the cluster start and each worker's imports, as a user running the command sees it; the
"cluster + imports" column times that start-up alone (a LocalCluster started and warmed
with nothing to run), and a rerun over the finished results shows the resume cost.
A figure, never a pass/fail: on a shared machine it moves with the load."""
from __future__ import annotations

import argparse
import logging
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def make_recordings(root: Path, n: int, frames: int, w: int, h: int) -> list:
    from pyvehtrack import synth
    recs = []
    for i, seq in enumerate(synth.make_set(n, seed=2026, camera=synth.Camera(w, h), n_frames=frames)):
        synth.write_kitti(seq, root / f"rec{i}")
        recs.append(str(root / f"rec{i}"))
    bad = root / "corrupt"
    bad.mkdir()
    (bad / "000000.png").write_bytes(b"\x89PNG\r\n\x1a\n" + os.urandom(256))
    return recs + [str(bad)]


def startup(workers: int) -> float:
    from dask.distributed import Client, LocalCluster

    from pyvehtrack.batch import warm_worker
    t = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.CRITICAL) as c, Client(c) as cl:
        cl.run(warm_worker)
        return time.perf_counter() - t


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--out", default=str(ROOT / "bench" / "batch_results.md"))
    a = ap.parse_args()
    w, h = (int(v) for v in a.size.split("x"))
    from pyvehtrack.batch import run_batch
    rows = []
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        recs = make_recordings(Path(tmp) / "recs", 8, a.frames, w, h)
        for workers in (1, 2):
            out = Path(tmp) / f"out{workers}"
            t = time.perf_counter()
            s = run_batch(recs, out, workers=workers, progress=False)
            wall = time.perf_counter() - t
            t = time.perf_counter()
            s2 = run_batch(recs, out, workers=workers, progress=False)
            rerun = time.perf_counter() - t
            su = startup(workers)
            ok = sum(r["status"] == "ok" for r in s.rows)
            rows.append((workers, wall, su, s.aggregate["seconds"], ok, len(recs) - ok, s2.submitted, rerun,
                         s.aggregate["frames"]))
            print(f"workers={workers}: wall {wall:.1f} s (cluster + imports {su:.1f} s), "
                  f"sum of task times {s.aggregate['seconds']:.1f} s, {ok} ok, {len(recs) - ok} failed; "
                  f"rerun: {s2.submitted} run, {rerun:.2f} s", flush=True)
    lines = [f"# pyvehtrack batch: wall time, 8 synthetic recordings ({a.frames} frames of {w}x{h}) + 1 corrupt",
             "", f"`PYTHONPATH=. python3 bench/batch_bench.py --frames {a.frames} --size {a.size}`; "
             f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores (shared), "
             f"Python {platform.python_version()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
             f"1-minute load average {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end "
             "(the machine is shared: above 2 the workers compete with other jobs for the 2 cores).", "",
             "| workers | wall s | of which cluster start + imports s | sum of task s | frames | ok | failed "
             "| rerun: recordings run | rerun wall s |", "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for wk, wall, su, tasks, ok, bad, sub, rerun, frames in rows:
        lines.append(f"| {wk} | {wall:.1f} | {su:.1f} | {tasks:.1f} | {frames} | {ok} | {bad} | {sub} | {rerun:.2f} |")
    Path(a.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
