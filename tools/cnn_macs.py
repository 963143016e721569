#!/usr/bin/env python3
"""Multiply-adds of one detection frame of a CNN model file, per network run.

    python tools/cnn_macs.py pyvehtrack/models/cnn_gray_l0_big.npz [--size 1280x720] [--rate G] [--time N]

The runs are vt_cnn_detect_frame's (pyvehtrack.reference.cnn.level_inputs with the file's cnn_cfg:
the pyramid levels, level 0's row band, the upsampled band); a layer of stride s on a w x h input
costs ceil(w / s) ceil(h / s) cout k^2 cin. With --rate (G multiply-adds a second, e.g. what
bench/vnni_peak.c measures) it prints the time the frame would take at that rate: a floor for the
network on that core, as no loop does better than the instruction's own rate. With --time N it
also runs the C network (pyvehtrack.cnn.forward, this build's best inner loops) N times on each
run's input size (random pixels) and prints the multiply-adds it did a second: a benchmark line,
one run, never a test.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from pyvehtrack import cnn  # noqa: E402
from pyvehtrack.reference import cnn as R  # noqa: E402


def run_macs(layers, w: int, h: int) -> int:
    """Multiply-adds of the network on one w x h input."""
    total = 0
    for L in layers:    # the model's layers: dicts of the cnn_lN_* fields
        s = int(L["stride"])
        w, h = (w + s - 1) // s, (h + s - 1) // s
        total += w * h * int(L["cout"]) * int(L["ksize"]) ** 2 * int(L["cin"])
    return total


def frame_macs(model: cnn.CnnModel, w: int, h: int) -> list[tuple[str, int, int, int]]:
    """(run, input width, input height, multiply-adds) per network run of one w x h frame."""
    c = (model.cfg if model.cfg is not None else cnn.CnnConfig()).c()   # the core's defaults filled in
    cfg = {k: int(getattr(c, k)) for k in cnn.CFG_KEYS}
    rows = []
    for k, _dx, _dy, img in R.level_inputs(np.zeros((h, w), np.uint8), cfg):
        name = "upsampled band" if k < 0 else (f"level {k}" + (" band" if k == 0 else ""))
        ih, iw = img.shape
        rows.append((name, iw, ih, run_macs(model.layers, iw, ih)))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model")
    ap.add_argument("--size", default="1280x720", help="frame WxH (default 1280x720)")
    ap.add_argument("--rate", type=float, default=None, help="G multiply-adds a second: print the frame's floor")
    ap.add_argument("--time", type=int, default=0, metavar="N", help="time N C forward passes per run")
    a = ap.parse_args(argv)
    if a.time < 0:
        ap.error("--time: N must be 0 or more")
    try:
        w, h = (int(v) for v in a.size.lower().split("x"))
    except ValueError:
        ap.error(f"--size: expected WxH, got {a.size!r}")
    if w < 1 or h < 1:
        ap.error("--size: both sides must be at least 1")
    model = cnn.CnnModel.load(a.model)
    rows = frame_macs(model, w, h)
    total = sum(r[3] for r in rows)
    rng = np.random.default_rng(0)
    for name, iw, ih, m in rows:
        line = f"{name:16s} {iw:5d} x {ih:4d}  {m / 1e6:9.1f} M  {100 * m / max(total, 1):5.1f}%"
        if a.time:
            img = rng.integers(0, 256, (ih, iw)).astype(np.uint8)
            cnn.forward(model, img)
            t = time.perf_counter()
            for _ in range(a.time):
                cnn.forward(model, img)
            dt = (time.perf_counter() - t) / a.time
            line += f"  {dt * 1e3:7.3f} ms  {m / dt / 1e9:6.1f} G/s ({cnn.simd_path()})"
        print(line)
    print(f"total            {total / 1e6:.1f} M multiply-adds per {w}x{h} frame")
    if a.rate:
        print(f"at {a.rate:.0f} G multiply-adds a second: {total / (a.rate * 1e9) * 1e3:.2f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
