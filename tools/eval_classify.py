#!/usr/bin/env python3
"""Train and score the classifier on the fixed splits; writes the models and the figures.

    PYTHONPATH=. python3 tools/eval_classify.py --descriptor hog --window 64 \
        --out tools/models/default_hog.npz --json classify_hog.json

Data (../shared/data): gti-vehicles (blocks of 40 consecutive files, every 5th block
TEST) and tusimple-vehicles-dev (frame NNNN TEST when (NNNN // 10) % 5 == 0); see
pyvehtrack/datasets.py. The SVM's C is chosen on fold 1 of TRAIN; every figure printed
is on TEST. Same code path as `pyvehtrack train` (pyvehtrack.train.run)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pyvehtrack import train as T  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="/work/shared/data" if Path("/work/shared/data").is_dir() else str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--descriptor", choices=("hog", "gist"), default="hog")
    ap.add_argument("--window", type=int, default=64)
    ap.add_argument("--C", type=float, default=None)
    ap.add_argument("--model-type", choices=("svm", "mlp"), default="svm")
    def hidden(text):
        try:
            return T.parse_hidden(text)
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    ap.add_argument("--hidden", type=hidden, default=16, help="MLP hidden units, or 'auto' (16/32/64 chosen on "
                    "the inner validation fold of TRAIN)")
    ap.add_argument("--hard-negatives", action="store_true")
    ap.add_argument("--out", required=True)
    ap.add_argument("--json", default=None)
    ap.add_argument("--cache", default=None, help="an .npz to keep the float features in (reused when "
                    "the crops are the same)")
    args = ap.parse_args(argv)
    d = Path(args.data)
    model, rep = T.run([d / "gti-vehicles" / "vehicles"], [d / "gti-vehicles" / "non-vehicles"],
                       d / "tusimple-vehicles-dev", d / "tusimple-vehicles-dev" / "annotation.json",
                       kind=args.descriptor, win=args.window, C=args.C, progress=False,
                       log=lambda s: print(s, file=sys.stderr), model_type=args.model_type,
                       hidden=args.hidden, feature_cache=args.cache,
                       hard_negatives=args.hard_negatives)
    T.save_model(args.out, model)
    print(json.dumps(rep, indent=1))
    if args.json:
        Path(args.json).write_text(json.dumps(rep, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
