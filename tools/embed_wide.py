#!/usr/bin/env python3
"""Put a wide-pass model (tools/train_wide_mlp.py) into a window model file, so that
`pyvehtrack detect --model OUT.npz` runs the wide pass with the settings chosen for it.

    python tools/embed_wide.py MAIN.npz WIDE.npz OUT.npz [--settings '{"wide_score_min": 1.0, ...}']

OUT holds every key of MAIN, the wide model's arrays under the prefix wide_ (as
fullroad.load_model reads them) and MAIN's detector_json with --settings merged in
(keys wide_veh_w_min, wide_veh_w_max, wide_box_height_permille, wide_score_min,
wide_nms_iou_permille, wide_nms_contain_permille, and the aspect choice wide_alt_height_a_permille,
wide_alt_height_b_permille, wide_alt_score_min; fullroad.load_model checks them). The wide model's box height and band
(its `info`) are written as wide_box_height_permille / wide_veh_w_* unless --settings gives them.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

KEYS = ("win_w", "win_h", "w1_q", "w1_shift", "b1_q16", "w2_q", "w2_shift", "b2_q16")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("main")
    ap.add_argument("wide")
    ap.add_argument("out")
    ap.add_argument("--settings", default="{}")
    args = ap.parse_args(argv)
    z = np.load(args.main, allow_pickle=False)
    wz = np.load(args.wide, allow_pickle=False)
    out = {k: z[k] for k in z.files if not k.startswith("wide_")}
    for k in KEYS:
        out["wide_" + k] = wz[k]
    info = json.loads(str(wz["info"])) if "info" in wz.files else {}
    d = json.loads(str(z["detector_json"])) if "detector_json" in z.files else {}
    if "box_height" in info:
        d["wide_box_height_permille"] = round(info["box_height"] * 1000)
    if "band" in info:
        d["wide_veh_w_min"], d["wide_veh_w_max"] = info["band"]
    d.update(json.loads(args.settings))
    out["detector_json"] = np.array(json.dumps(d))
    if "info" in wz.files:
        out["wide_info"] = wz["info"]
    np.savez(args.out, **out)
    from pyvehtrack.fullroad import load_model  # noqa: PLC0415  (checks what was written)
    m = load_model(args.out)
    print(f"wrote {args.out}: wide model {m.wide.win_w}x{m.wide.win_h}, detector_json {json.dumps(d)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
