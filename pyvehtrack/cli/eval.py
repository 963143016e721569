"""`pyvehtrack eval`: score KITTI-format tracks against labels with TrackEval.

    pyvehtrack eval --gt GT.txt --tracks tracks.txt [--tracks other.txt ...] [--num-frames N]
                    [--no-preproc] [--json OUT.json]
"""
from __future__ import annotations

import json
from pathlib import Path

from .common import CliError, Outputs, add_command

EXAMPLES = """examples:
  pyvehtrack eval --gt label_02/0000.txt --tracks tracks.txt
  pyvehtrack eval --gt gt.txt --tracks ours.txt --tracks sort.txt --no-preproc --json scores.json"""


def register(sub) -> None:
    p = add_command(sub, "eval", help="score KITTI-format tracks against labels with TrackEval",
                       description="HOTA, CLEAR (MOTA...) and Identity (IDF1) from TrackEval, class Car.",
                       epilog=EXAMPLES)
    p.add_argument("--gt", required=True, help="ground truth, KITTI tracking label file")
    p.add_argument("--tracks", required=True, action="append",
                   help="tracks to score, KITTI tracking format (repeat to compare several)")
    p.add_argument("--num-frames", type=int, help="frames in the sequence (default: from the files)")
    p.add_argument("--no-preproc", action="store_true",
                   help="count every box (default: KITTI benchmark rules via TrackEval's Kitti2DBox)")
    p.add_argument("--json", help="also write the figures here")
    p.set_defaults(func=run)


register_eval = register        # the name SUBCOMMANDS used before the package


def run(args) -> int:
    from ..eval.kitti import read_kitti
    try:
        from ..eval.tracking import evaluate_kitti, format_results
    except ImportError as e:                # TrackEval is installed by `make setup`
        raise CliError(str(e).splitlines()[0]) from None

    if args.num_frames is not None and args.num_frames < 1:
        raise CliError(f"--num-frames {args.num_frames}: must be >= 1")
    for path in [args.gt] + args.tracks:
        if not Path(path).is_file():
            raise CliError(f"{path}: no such file")
    with Outputs() as outs:
        json_tmp = outs.reserve("--json", args.json) if args.json else None
        try:
            gt = read_kitti(args.gt)
        except (ValueError, OSError) as e:
            raise CliError(f"--gt {e}" if str(e).startswith(args.gt) else f"--gt {args.gt}: {e}") from None
        results = {}
        for tr in args.tracks:
            try:
                tracks = read_kitti(tr)
                results[tr] = evaluate_kitti(gt, tracks, num_frames=args.num_frames,
                                             preproc="none" if args.no_preproc else "kitti")
            except (ValueError, OSError) as e:
                raise CliError(f"--tracks {e}" if str(e).startswith(tr) else f"--tracks {tr}: {e}") from None
        print(format_results(results))
        if json_tmp is not None:
            json_tmp.write_text(json.dumps(results, indent=2, default=float) + "\n")
            outs.commit()
    return 0
