#!/usr/bin/env python3
"""Give a trained CNN file (tools/train_cnn.py's OUT/cnn.npz) a shipped file's detector settings.

    python tools/package_cnn.py --weights RUN/cnn.npz --like pyvehtrack/models/cnn_gray_l0_big.npz \
        --offset-logit 0.25 --out M.npz

train_cnn.py writes the network with the settings it was trained with (no contrast stretch unless
asked, no upsampled band, threshold offset 0, the network and ego-lane sources). A file the command
line runs as a default carries the settings chosen on 'val' (README, "The default detector"): this
copies --like's cnn_cfg and cnn_detector_json (and cnn_tracker_json, if it has one) onto --weights'
network, and sets the threshold offset to the whole number of heat steps nearest --offset-logit at
the new network's own heat scale (one step = cnn_heat_scale_q16 / 65536 logit), as the e240 file was
made. The weights are copied bit for bit; nothing is retrained or re-chosen."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

# cnn_cfg's entries in vt_cnn_cfg order (pyvehtrack.cnn.CnnConfig): thr_offset is the third.
THR_OFFSET = 2


def package(weights: Path, like: Path, offset_logit: float) -> tuple[dict, int]:
    """The arrays of the packaged file, and the offset in heat steps written into it."""
    with np.load(weights, allow_pickle=False) as w, np.load(like, allow_pickle=False) as lk:
        for need, z, name in (("cnn_heat_scale_q16", w, "--weights"), ("cnn_cfg", lk, "--like")):
            if need not in z.files:
                raise ValueError(f"{name}: no {need} in the file (is it a CNN model?)")
        out = {k: w[k] for k in w.files}
        scale = int(out["cnn_heat_scale_q16"])
        if scale <= 0:
            raise ValueError(f"--weights: cnn_heat_scale_q16 = {scale}, expected > 0")
        cfg = np.array(lk["cnn_cfg"], np.int32)
        steps = int(round(offset_logit * 65536 / scale))
        cfg[THR_OFFSET] = steps
        out["cnn_cfg"] = cfg
        for k in ("cnn_detector_json", "cnn_tracker_json"):
            if k in lk.files:
                json.loads(str(lk[k]))  # a broken --like fails here, not in the CLI later
                out[k] = lk[k]
    return out, steps


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weights", type=Path, required=True, help="train_cnn.py's cnn.npz")
    ap.add_argument("--like", type=Path, required=True, help="the shipped file whose settings to copy")
    ap.add_argument("--offset-logit", type=float, required=True,
                    help="threshold offset in logits, rounded to whole heat steps of --weights")
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    try:
        z, steps = package(a.weights, a.like, a.offset_logit)
    except (OSError, ValueError) as e:
        print(f"package_cnn: {e}", file=sys.stderr)
        return 2
    np.savez_compressed(a.out, **z)
    scale = int(z["cnn_heat_scale_q16"])
    print(f"wrote {a.out}: cnn_cfg {z['cnn_cfg'].tolist()} (offset {steps} heat steps = "
          f"{steps * scale / 65536:.3f} logit), detector {z['cnn_detector_json']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
