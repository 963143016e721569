"""`pyvehtrack eval-boxes`: score `detect --json` boxes against tusimple-vehicles-dev
style ground truth (pyvehtrack.eval_boxes does the scoring).

    pyvehtrack eval-boxes --gt annotation.json --pred found.json [--image-size 1280x720]
                          [--json scores.json] [--sheet errors.png] [--lead-sheet leads.png] [--images DIR]
"""
from __future__ import annotations

import json
from pathlib import Path

from .cli import CliError
from .cli.common import add_command


def register_eval_boxes(sub) -> None:
    p = add_command(sub, "eval-boxes", help="recall/precision/AP50 of detected boxes against labelled boxes",
                       description="Recall and precision at IoU >= 0.5 (all vehicles, >= 32 px and >= 64 px "
                       "wide, the lead vehicle) and COCO AP50 (pycocotools) of `detect --json` output "
                       "against a tusimple-vehicles-dev style annotation.json. Only frames present in "
                       "--pred are scored.",
                       epilog="examples:\n  pyvehtrack detect frames/ --model M.npz --json found.json\n"
                              "  pyvehtrack eval-boxes --gt ../shared/data/tusimple-vehicles-dev/annotation.json "
                              "--pred found.json")
    p.add_argument("--gt", required=True, metavar="ANNOTATION.json",
                   help="[{file_name, bbox: [{left, top, right, bottom}, ...]}, ...]")
    p.add_argument("--pred", required=True, metavar="FOUND.json", help="as written by `pyvehtrack detect --json`")
    p.add_argument("--image-size", default="1280x720", metavar="WxH",
                   help="frame size that places the bottom centre for the lead vehicle (default 1280x720)")
    p.add_argument("--json", metavar="OUT.json", help="also write the scores as JSON")
    p.add_argument("--sheet", metavar="OUT.png",
                   help="a picture of what went wrong: the missed vehicles and the false boxes >= 32 px wide, "
                        "each cut from its frame (needs the frames: --images)")
    p.add_argument("--lead-sheet", metavar="OUT.png",
                   help="a picture of the frames whose near lead (>= 32 px wide, the lead>=32px row) was missed "
                        "or whose predicted near lead is wrong: each whole frame with every labelled and found "
                        "box, the two leads thick (needs the frames: --images)")
    p.add_argument("--images", metavar="DIR", default=None,
                   help="the folder the --gt file names are relative to (default: the --gt file's folder)")
    p.set_defaults(func=run_eval_boxes)


def _read_json(path: str, flag: str):
    p = Path(path)
    if not p.is_file():
        raise CliError(f"{flag} {path}: no such file")
    try:
        return json.loads(p.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise CliError(f"{flag} {path}: not readable as JSON ({e})") from None


def run_eval_boxes(args) -> int:
    from . import eval_boxes as eb
    try:
        w, h = (int(v) for v in args.image_size.lower().split("x"))
        if w <= 0 or h <= 0:
            raise ValueError
    except ValueError:
        raise CliError(f"--image-size {args.image_size}: expected WxH with positive integers") from None
    for flag, v in (("json", args.json), ("sheet", args.sheet), ("lead-sheet", args.lead_sheet)):
        if v and not Path(v).parent.exists():
            raise CliError(f"--{flag} {v}: folder {Path(v).parent} does not exist")
    for flag, v in (("sheet", args.sheet), ("lead-sheet", args.lead_sheet)):
        if v and Path(v).suffix.lower() not in (".png", ".jpg", ".jpeg"):
            raise CliError(f"--{flag} {v}: expected a .png or .jpg name")
    if args.images and not (args.sheet or args.lead_sheet):
        raise CliError("--images is read only with --sheet or --lead-sheet")
    try:
        gt = eb.load_gt(_read_json(args.gt, "--gt"))
    except ValueError as e:
        raise CliError(f"--gt {args.gt}: {e}") from None
    try:
        pred = eb.load_pred(_read_json(args.pred, "--pred"))
    except ValueError as e:
        raise CliError(f"--pred {args.pred}: {e}") from None
    try:
        s = eb.score(gt, pred, (w, h))
    except ValueError as e:
        raise CliError(str(e)) from None
    print(eb.format_scores(s))
    if args.json:
        Path(args.json).write_text(json.dumps(s.as_dict(), indent=1) + "\n")
    if args.sheet:
        _write_sheet(args, gt, pred)
    if args.lead_sheet:
        _write_lead_sheet(args, gt, pred, (w, h))
    return 0


def _frame_loader(args, flag: str):
    """load(name) -> the frame under --images (default: the --gt file's folder); CliError naming flag."""
    import cv2  # noqa: PLC0415
    root = Path(args.images) if args.images else Path(args.gt).parent
    if not root.is_dir():
        raise CliError(f"--images {root}: no such folder")

    def load(name):
        img = cv2.imread(str(root / name), cv2.IMREAD_COLOR)
        if img is None:
            raise CliError(f"{flag}: cannot read the frame {root / name} (--images names the folder the "
                           "--gt file names are relative to)")
        return img
    return load


def _write_sheet(args, gt, pred) -> None:
    import cv2  # noqa: PLC0415
    from . import eval_boxes as eb
    load = _frame_loader(args, "--sheet")
    errs = eb.errors(gt, pred)
    sheet = eb.error_sheet(errs, load)
    if not cv2.imwrite(str(args.sheet), sheet):
        raise CliError(f"--sheet {args.sheet}: could not be written")
    n_miss = sum(e["kind"] == "missed" for e in errs)
    print(f"sheet: {args.sheet} ({n_miss} missed, {len(errs) - n_miss} false, >= 32 px)")


def _write_lead_sheet(args, gt, pred, size) -> None:
    import cv2  # noqa: PLC0415
    from . import eval_boxes as eb
    load = _frame_loader(args, "--lead-sheet")
    ent = eb.lead_errors(gt, pred, size)
    if not cv2.imwrite(str(args.lead_sheet), eb.lead_sheet(ent, load)):
        raise CliError(f"--lead-sheet {args.lead_sheet}: could not be written")
    n_miss = sum("missed" in e["kinds"] for e in ent)
    n_wrong = sum("wrong" in e["kinds"] for e in ent)
    print(f"lead sheet: {args.lead_sheet} ({len(ent)} frames: near lead missed in {n_miss}, "
          f"predicted near lead wrong in {n_wrong})")
