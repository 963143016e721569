"""`pyvehtrack batch`: `track` (and `report`) over many recordings on Dask.

    pyvehtrack batch RECORDINGS... --out RESULTS_DIR [--scheduler tcp://host:port] [--workers N]
                     [--reports] [--engine c|reference] [--detect-every N] [--retry-failed]
                     [--ego-speed M/S] [--rear-offset M] [--bottom-height M] [--path-half-width M]
                     [--warn-ttc distance|fused] [--box-top cnn|tracker]

The naming rule for truth and camera files and the output layout: pyvehtrack.batch."""
from __future__ import annotations

from .common import CliError, add_command, add_range_args, add_work_width_arg, out_folder, work_width_arg

EXAMPLES = """examples:
  pyvehtrack batch recordings/* --out results/                 # LocalCluster, 2 workers
  pyvehtrack batch a.mp4 b/ c/ --out results/ --workers 4 --reports
  pyvehtrack batch recordings/* --out results/ --scheduler tcp://10.0.0.5:8786
a recording's truth: REC/gt.txt, REC/truth*.{txt,csv} or REC.truth*.{txt,csv} beside it;
its camera: REC/camera.json or REC.camera.json. Rerunning skips finished recordings.
--ego-speed, --rear-offset, --bottom-height, --path-half-width and --warn-ttc go to track (and
report) for the recordings with a camera file, one value for all; the others run without them."""


def register(sub) -> None:
    p = add_command(sub, "batch", help="track (and report) many recordings on a Dask cluster",
                       description="Runs `pyvehtrack track` on every recording (video or folder of "
                       "frames) as Dask tasks, on a LocalCluster (processes, one thread each) or an "
                       "existing scheduler; writes per-recording outputs, RESULTS_DIR/results.csv and "
                       "results.md. A failing recording is listed with its error; a rerun skips "
                       "recordings whose outputs are complete.",
                       epilog=EXAMPLES)
    p.add_argument("recordings", nargs="+", metavar="RECORDING", help="videos or folders of frames")
    p.add_argument("--out", required=True, metavar="RESULTS_DIR", help="results folder (created)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--workers", type=int, default=2, metavar="N",
                   help="LocalCluster worker processes (default 2; ignored with --scheduler)")
    p.add_argument("--reports", action="store_true", help="also write each recording's HTML report")
    p.add_argument("--engine", choices=("c", "reference"), default="c",
                   help="the C core (default) or the float reference")
    p.add_argument("--detect-every", type=int, default=10, metavar="N",
                   help="run the detector every N frames (thesis: 10)")
    p.add_argument("--skip-bad-frames", action="store_true",
                   help="passed to track: skip frames that cannot be decoded instead of failing the recording")
    add_range_args(p)
    p.add_argument("--box-top", choices=("cnn", "tracker"), default="cnn",
                   help="passed to track: the top of a track's box (default cnn)")
    add_work_width_arg(p, "passed to track (and the reports): ")
    p.add_argument("--retry-failed", action="store_true", help="rerun recordings that failed before")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..batch import run_batch

    if args.workers < 1:
        raise CliError(f"--workers {args.workers}: must be >= 1")
    if args.detect_every < 1:
        raise CliError(f"--detect-every {args.detect_every}: must be >= 1")
    out = out_folder(args.out)
    if args.scheduler and "://" not in args.scheduler:
        raise CliError(f"--scheduler {args.scheduler}: expected an address like tcp://host:8786")
    try:
        s = run_batch(args.recordings, out, scheduler=args.scheduler, workers=args.workers,
                      reports=args.reports, engine=args.engine, detect_every=args.detect_every,
                      retry_failed=args.retry_failed, skip_bad_frames=args.skip_bad_frames, progress=not args.no_progress,
                      rear_offset=args.rear_offset, bottom_height=args.bottom_height,
                      path_half_width=args.path_half_width, ego_speed=args.ego_speed, warn_ttc=args.warn_ttc,
                      box_top=args.box_top, work_width=work_width_arg(args))
    except (ValueError, TypeError) as e:
        raise CliError(str(e)) from None
    a = s.aggregate
    skipped = sum(1 for r in s.rows if str(r.get("this_run", "")).startswith("skipped"))
    print(f"{a['recordings']} recording(s): {a['ok']} ok, {a['failed']} failed; {s.submitted} run now, "
          f"{skipped} skipped (done before); {s.wall_s:.1f} s; table: {s.md}")
    for r in s.rows:
        if r.get("status") != "ok":
            print(f"  failed: {r['recording']}: {r.get('error', '')}")
    return 1 if a["failed"] else 0
