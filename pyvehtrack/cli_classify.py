"""`pyvehtrack train` and `pyvehtrack classify` (the classifier issue's commands).

    pyvehtrack train --vehicles DIR... --non-vehicles DIR... [--frames DIR --frames-json ANN.json]
                     [--descriptor hog|gist] [--window N] [--C C] [--model-type svm|mlp [--hidden N|auto]]
                     [--hard-negatives]
                     --out MODEL.npz [--no-progress]
    pyvehtrack classify INPUT... --json OUT.json [--model MODEL.npz] [--engine c|reference]

train prints the TEST accuracy (grouped split, see pyvehtrack.datasets) of the float
model and of the C fixed-point model, per source, and their sign agreement.
classify writes a JSON list of {"file", "score", "vehicle"}, one entry per image."""
from __future__ import annotations


import json
import sys
from pathlib import Path

from .cli import CliError, IMAGE_EXTS
from .cli.common import add_command


def register_train(sub) -> None:
    p = add_command(sub, "train", help="train the vehicle classifier (HOG/GIST + linear SVM)",
                       epilog="examples:\n"
                              "  pyvehtrack train --vehicles gti-vehicles/vehicles --non-vehicles gti-vehicles/non-vehicles "
                              "--out model.npz\n"
                              "  pyvehtrack train --vehicles V --non-vehicles N --frames tusimple-vehicles-dev "
                              "--frames-json tusimple-vehicles-dev/annotation.json --descriptor gist --out gist.npz")
    p.add_argument("--vehicles", nargs="+", required=True, metavar="DIR",
                   help="folders of vehicle crops (sub-folders are read too)")
    p.add_argument("--non-vehicles", nargs="+", required=True, metavar="DIR")
    p.add_argument("--frames", metavar="DIR", help="frames folder (tusimple-vehicles-dev layout)")
    p.add_argument("--frames-json", metavar="ANNOTATION.json", help="boxes of the frames")
    p.add_argument("--descriptor", choices=("hog", "gist"), default="hog")
    p.add_argument("--window", type=int, default=64, help="square window in px (default 64)")
    p.add_argument("--C", type=float, default=None, help="SVM C (default: chosen on an inner validation fold)")
    p.add_argument("--model-type", choices=("svm", "mlp"), default="svm",
                   help="linear SVM (default; the sliding-window scorer) or a one-hidden-layer MLP")
    p.add_argument("--hidden", default="16",
                   help="MLP hidden units, 1..64 (default 16), or 'auto': chosen among 16 / 32 / 64 on the "
                        "inner validation fold of TRAIN")
    p.add_argument("--hard-negatives", action="store_true",
                   help="linear HOG with --frames: add the model's false detections on the TRAIN frames "
                        "as negatives and fit again (one round)")
    p.add_argument("--out", required=True, metavar="MODEL.npz")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run_train)


def run_train(args) -> int:
    from . import train as T
    if not args.out.endswith(".npz"):
        raise CliError(f"--out: expected a .npz path, got {args.out!r}")
    for d in list(args.vehicles) + list(args.non_vehicles) + ([args.frames] if args.frames else []):
        if not Path(d).is_dir():
            raise CliError(f"not a folder: {d!r}")
    if args.frames_json and not Path(args.frames_json).is_file():
        raise CliError(f"--frames-json: no such file {args.frames_json!r}")
    try:
        hidden = T.parse_hidden(args.hidden)
    except ValueError as e:
        raise CliError(str(e)) from e
    if args.C is not None and not args.C > 0:
        raise CliError(f"--C: must be > 0, got {args.C}")
    try:
        d, rep = T.run(args.vehicles, args.non_vehicles, args.frames, args.frames_json,
                       kind=args.descriptor, win=args.window, C=args.C,
                       progress=not args.no_progress, log=lambda s: print(s, file=sys.stderr),
                       model_type=args.model_type, hidden=hidden, hard_negatives=args.hard_negatives)
    except ValueError as e:
        raise CliError(str(e)) from e
    T.save_model(args.out, d)
    t = rep["test"]
    if args.model_type == "mlp":
        print(f"model {args.out}: {args.descriptor} {args.window}x{args.window}, MLP {d['hidden']} hidden, "
              f"weights int16 Q{d['w1_shift']} / Q{d['w2_shift']}")
    else:
        print(f"model {args.out}: {args.descriptor} {args.window}x{args.window}, SVM C={rep['C']}, "
              f"weights int16 Q{d['w_shift']}")
    print(f"TEST split ({t['n']} crops; grouped by file number, never used for fitting or C):")
    for src in sorted(k for k in t if isinstance(t[k], dict)):
        s = t[src]
        print(f"  {src:9s} n={s['n']:5d}  float accuracy {100 * s['float_acc']:.2f}%  "
              f"C fixed-point accuracy {100 * s['c_acc']:.2f}%")
    print(f"  float vs C sign agreement {100 * t['sign_agreement']:.3f}%, "
          f"max |score difference| {t['max_abs_score_diff']:.4f}")
    return 0


def register_classify(sub) -> None:
    p = add_command(sub, "classify", help="score image crops: vehicle or not",
                       epilog="examples:\n  pyvehtrack classify crops/ --json scores.json\n"
                              "  pyvehtrack classify car.png road.png --json scores.json --model model.npz")
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="image files or folders of images")
    p.add_argument("--json", required=True, metavar="OUT.json")
    p.add_argument("--model", metavar="MODEL.npz", help="a model from `pyvehtrack train` (default: built in)")
    p.add_argument("--engine", choices=("c", "reference"), default="c")
    p.set_defaults(func=run_classify)


def _images_of(inputs) -> list[Path]:
    out = []
    for s in inputs:
        p = Path(s)
        if p.is_dir():
            files = sorted(q for q in p.iterdir() if q.suffix.lower() in IMAGE_EXTS)
            if not files:
                raise CliError(f"no images in folder {s!r}")
            out += files
        elif p.is_file():
            if p.suffix.lower() not in IMAGE_EXTS:
                raise CliError(f"not an image file: {s!r}")
            out.append(p)
        else:
            raise CliError(f"no such file or folder: {s!r}")
    return out


def run_classify(args) -> int:
    from .classify import Classifier
    from .train import read_gray
    if args.model is not None and not Path(args.model).is_file():
        raise CliError(f"--model: no such file {args.model!r}")
    files = _images_of(args.inputs)
    try:
        clf = Classifier(args.model, engine=args.engine)
    except ValueError as e:
        raise CliError(str(e)) from e
    res = []
    for f in files:
        try:
            img = read_gray(f)
        except ValueError as e:
            raise CliError(str(e)) from e
        s = float(clf.score([img])[0])
        res.append({"file": str(f), "score": s, "vehicle": bool(clf.is_vehicle(s))})
    Path(args.json).write_text(json.dumps(res, indent=1))
    print(f"{len(res)} images, {sum(r['vehicle'] for r in res)} vehicles -> {args.json}")
    return 0
