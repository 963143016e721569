"""`pyvehtrack report`: run a recording once and write a self-contained HTML page.

    pyvehtrack report INPUT --out REPORT_DIR [--camera CAMERA.json] [--truth TRUTH ...]
                      [--engine c|reference] [--detect-every N] [--fps F]
                      [--measurement auto|roi|edges|roi+edges] [--box-top cnn|tracker] [--rear-offset M]
                      [--bottom-height M] [--path-half-width M] [--no-progress]
"""
from __future__ import annotations

from pathlib import Path

from .common import (CliError, add_command, add_range_args, add_work_width_arg, out_folder, resolve_model,
                     work_width_arg)

EXAMPLES = """examples:
  pyvehtrack report tests/data/kitti_clip --out r/
  pyvehtrack report tests/data/kitti_clip --out r/ --truth tests/data/kitti_clip/lead_boxes.csv \\
      --truth tests/data/kitti_clip/truth_lidar_range.csv --camera tests/data/kitti_clip.camera.json
  pyvehtrack report drive.mp4 --out r/ --camera camera.json --truth label_02/0000.txt
then open r/index.html (one file: no script, no network)."""


def register(sub) -> None:
    p = add_command(sub, "report", help="run a recording once and write an HTML report with plots",
                       description="Lanes, detection and tracking over one recording; writes "
                       "REPORT_DIR/index.html (contact sheet, track timeline, distance/TTC against "
                       "the truth, lane width and pitch, run time per stage, summary figures) and "
                       "REPORT_DIR/tracks.json (the per-frame records).",
                       epilog=EXAMPLES)
    p.add_argument("input", metavar="INPUT", help="a video, a folder of frames or an image")
    p.add_argument("--out", required=True, metavar="REPORT_DIR", help="folder for index.html (created)")
    p.add_argument("--camera", metavar="CAMERA.json",
                   help="camera file (pyvehtrack.camera format: fx, fy, cx, cy, height_m); default: "
                        "INPUT/camera.json or INPUT.camera.json when there is one")
    p.add_argument("--truth", action="append", metavar="TRUTH",
                   help="truth: KITTI tracking labels, a frame,left,top,right,bottom CSV (one car) or "
                        "the kitti-raw-sfnd-ttc lidar range CSV; repeat for several; default: "
                        "INPUT/gt.txt, INPUT/truth*.{txt,csv}, INPUT.truth*.{txt,csv}")
    p.add_argument("--no-find", action="store_true",
                   help="do not look for a camera or truth file by name")
    p.add_argument("--engine", choices=("c", "reference"), default="c",
                   help="the C core (default) or the float reference")
    p.add_argument("--detect-every", type=int, default=10, metavar="N",
                   help="run the detector every N frames (thesis: 10)")
    p.add_argument("--fps", type=float, default=None,
                   help="frame rate: the range stage's time step and the truth TTC's (default: a video's "
                        "own, else 10 as KITTI)")
    p.add_argument("--model", metavar="MODEL.npz", default=None,
                   help="whole-road classifier model, as `track --model` (default: the shipped "
                        "pyvehtrack/models/cnn_gray_l0_big.npz, window_mlp_hog32.npz with --engine reference); "
                        "'none': the ego-lane detector alone")
    p.add_argument("--measurement", choices=("auto", "roi", "edges", "roi+edges"), default="auto",
                   help="the tracker's per-frame measurement, as `track --measurement` (default auto: "
                        "roi+edges for a lossy video or JPEG frames, roi otherwise)")
    p.add_argument("--box-top", choices=("cnn", "tracker"), default="cnn",
                   help="the top of a track's box, as `track --box-top` (default cnn)")
    add_work_width_arg(p, "as `track --work-width`: ")
    add_range_args(p)           # as `track`'s (they need a camera)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    from .._native import VtError
    from ..report import make_report

    if args.detect_every < 1:
        raise CliError(f"--detect-every {args.detect_every}: must be >= 1")
    if args.fps is not None and not args.fps > 0:
        raise CliError(f"--fps {args.fps}: must be > 0")
    out = out_folder(args.out)
    if args.camera and not Path(args.camera).is_file():
        raise CliError(f"--camera {args.camera}: no such file")
    for t in args.truth or []:
        if not Path(t).is_file():
            raise CliError(f"--truth {t}: no such file")
    model = resolve_model(args.model, engine=args.engine)
    try:
        auto = None if args.no_find else "auto"
        page = make_report(args.input, out, truth=args.truth or (auto or ()), camera=args.camera or auto,
                           engine=args.engine,
                           detect_every=args.detect_every, progress=not args.no_progress, fps=args.fps,
                           model=model, measurement=args.measurement, rear_offset=args.rear_offset,
                           bottom_height=args.bottom_height, path_half_width=args.path_half_width,
                           ego_speed=args.ego_speed, warn_ttc=args.warn_ttc, box_top=args.box_top,
                           work_width=work_width_arg(args))
    except (ValueError, TypeError, VtError) as e:
        raise CliError(str(e)) from None
    print(f"report: {page}")
    return 0
