#!/usr/bin/env python3
"""Write firmware_demo/cnn_data.h: the CNN detector the firmware demo runs, as static const C tables.

The firmware image (firmware_demo/main.c, run_cnn) runs vt_cnn_detect_frame with this model
twice: on a synthetic FRAME_W x FRAME_H gray frame it draws itself (cnn_frame() below is the
same recipe) with the settings cfg_synth (the model's, from level 0: the frame is small, its
"cars" 26..52 px wide), and on the first KITTI clip frame already in flash (CLIP_W x CLIP_H,
firmware_demo/clip_data.h) with the model's own settings. It prints the boxes and a checksum
of each run, which tests/test_firmware.py recomputes on the host through pyvehtrack.cnn. The
header is checked in; the test runs this script with --check, so the tables in flash can
never drift from the model they come from.

The model: MODEL (an .npz in pyvehtrack.cnn's format) when given; else the shipped
pyvehtrack/models/cnn_gray.npz when it exists; else TINY, a deterministic 4-layer stride-8
network made here (weights from a fixed-seed LCG, biases and requantisation calibrated in
exact integers on the synthetic frame's pyramid level 1, heat threshold set so the frame has
peaks). Its detections mean nothing: it exists so the firmware runs the whole CNN path
(3x3 and 1x1 layers, strides 1 and 2, a dilated layer, the decode, the pyramid and the NMS)
with boxes to compare. When the shipped model appears (or changes), rerun this script: the
test then fails until the header is regenerated. The settings: the file's cnn_cfg when it
has one, else vt_cnn_cfg_default.

    python tools/gen_cnn_table.py                 # rewrite the header (model chosen as above)
    python tools/gen_cnn_table.py MODEL.npz       # from that model
    python tools/gen_cnn_table.py --tiny          # the tiny model, whatever exists
    python tools/gen_cnn_table.py --check         # exit 1 if the checked-in header differs
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:       # run as a script from anywhere: the package beside it
    sys.path.insert(0, str(ROOT))

HEADER = ROOT / "firmware_demo" / "cnn_data.h"
SHIPPED = ROOT / "pyvehtrack" / "models" / "cnn_gray.npz"
FRAME_W, FRAME_H = 160, 96
CLIP_W, CLIP_H = 640, 256      # firmware_demo/clip_data.h's frames (main.c checks)
TINY_SEED = 20261128
# (ksize, stride, dilation, cout): stride 8, one dilated layer, a 1x1 head
TINY_SPEC = ((3, 2, 1, 8), (3, 2, 1, 12), (3, 2, 2, 12), (1, 1, 1, 5))
TINY_HEAT_THR = 24
# every vt_cnn_cfg field, by name: a field left out of a designated initializer would be 0,
# and a zero l0_bottom_permille is refused
CFG_FIELDS = ("first_level", "n_levels", "thr_offset", "cap_per_level", "nms_iou_permille",
              "nms_contain_permille", "l0_top_permille", "l0_bottom_permille", "stretch_tail_permille",
              "up_top_permille", "up_bottom_permille", "up_left_permille", "up_right_permille")
BIAS_MAX = 1 << 30
M32 = 0xFFFFFFFF


# ---------------------------------------------------------------- the synthetic frame
def _tex(x: np.ndarray, y: np.ndarray, salt: int) -> np.ndarray:
    """main.c's cnn_tex: xorshift32 of (x * 73856093) ^ (y * 19349663) ^ salt, mod 2^32."""
    v = (np.uint32(73856093) * x.astype(np.uint32)) ^ (np.uint32(19349663) * y.astype(np.uint32)) ^ np.uint32(salt)
    v ^= v << np.uint32(13)
    v ^= v >> np.uint32(17)
    v ^= v << np.uint32(5)
    return v


# (left, top, width, height) of the "cars" cnn_frame draws, in drawing order
CARS = ((18, 44, 40, 30), (84, 36, 52, 38), (128, 62, 26, 20))


def cnn_frame() -> np.ndarray:
    """main.c's cnn_make_frame: a road-like ramp (brighter downwards) with texture, and dark
    textured boxes with a bright window band (their top third) and a black bottom row pair
    (the shadow under a car), drawn in CARS order (later ones on top)."""
    y, x = np.mgrid[0:FRAME_H, 0:FRAME_W]
    img = (70 + (y * 80) // FRAME_H + (_tex(x, y, 0xC0DE) & 31)).astype(np.uint8)
    for l, t, w, h in CARS:
        inside = (x >= l) & (x < l + w) & (y >= t) & (y < t + h)
        dy = y - t
        v = np.where(dy < h // 3, 170 + (_tex(x - l, y - t, 0xCA75) & 31),
                     np.where(dy >= h - 2, 8, 30 + (_tex(x - l, y - t, 0xCA75) & 31)))
        img[inside] = v[inside].astype(np.uint8)
    return img


# ---------------------------------------------------------------- the tiny model
def _lcg(seed: int):
    s = seed & M32

    def nxt() -> int:
        nonlocal s
        s = (s * 1664525 + 1013904223) & M32
        return s
    return nxt


def tiny_model():
    """The deterministic tiny model (a pyvehtrack.cnn.CnnModel): every number from integer
    arithmetic (the LCG, exact integer means and spreads of the reference twin's
    accumulators), so the table is the same on every machine."""
    from pyvehtrack.cnn import CnnModel
    from pyvehtrack.reference import cnn as R
    from pyvehtrack.reference import image as rimage

    nxt = _lcg(TINY_SEED)
    a = rimage.pyr_down(cnn_frame())[:, :, None]           # level 1: the first level the cfg runs
    layers, cin = [], 1
    for i, (k, s, d, cout) in enumerate(TINY_SPEC):
        last = i == len(TINY_SPEC) - 1
        w = np.array([((nxt() >> 24) & 0xFF) - 128 for _ in range(cout * k * k * cin)], np.int64)
        L = dict(ksize=k, stride=s, dilation=d, relu=0 if last else 1, cin=cin, cout=cout,
                 w=w.reshape(cout, k, k, cin).astype(np.int8), bias=np.zeros(cout, np.int32),
                 mult=np.ones(cout, np.int32), shift=np.ones(cout, np.uint8))
        acc = R.accumulate(a, L).reshape(-1, cout)
        n = acc.shape[0]
        bias, mult, shift = [], [], []
        for c in range(cout):
            col = [int(v) for v in acc[:, c]]
            s1, s2 = sum(col), sum(v * v for v in col)
            mean = s1 // n
            spread = max(math.isqrt(max(s2 * n - s1 * s1, 0)) // n, 1)
            gain = 40 if (last and c == 0) or not last else 48
            # ReLU layers: centred half a spread above zero; the head: centred on zero
            b = -mean + (0 if last else spread // 2)
            bias.append(max(-BIAS_MAX, min(BIAS_MAX, b)))
            sh = 24
            mult.append(max(1, min((gain << sh) // spread, 2**31 - 1)))
            shift.append(sh)
        L["bias"] = np.array(bias, np.int32)
        L["mult"] = np.array(mult, np.int32)
        L["shift"] = np.array(shift, np.uint8)
        a = R.requantise(R.accumulate(a, L), L)
        layers.append(L)
        cin = cout
    # side distances in level px Q4: 6 .. 30 px over the code's range, per side
    lut = np.array([[16 * 6 + (q * 24 * 16) // 255 for q in range(256)] for _ in range(4)], np.uint16)
    m = CnnModel(layers, lut, TINY_HEAT_THR, "tiny", heat_scale_q16=65536)
    return m


def synth_cfg(cfg):
    """The synthetic frame's settings: the model's, from pyramid level 0, with the contrast
    stretch of the default file (5 permille), so the image runs that path too."""
    from dataclasses import replace
    return replace(cfg, first_level=0, stretch_tail_permille=5)


def load_model(path: Path | None = None, tiny: bool = False):
    """(CnnModel, its settings as a CnnConfig with every field set, a one-line source name):
    the model the header holds (the module doc's order)."""
    from pyvehtrack import cnn as C

    if tiny or (path is None and not SHIPPED.exists()):
        m, src = tiny_model(), f"the tiny model of tools/gen_cnn_table.py (seed {TINY_SEED})"
    else:
        p = Path(path) if path is not None else SHIPPED
        m = C.CnnModel.load(p)
        try:
            src = str(p.resolve().relative_to(ROOT))
        except ValueError:
            src = p.name
    cfg = C.CnnConfig.from_c((getattr(m, "cfg", None) or C.CnnConfig()).c())   # the file's cnn_cfg, if any
    return m, cfg, src


# ---------------------------------------------------------------- the header
def _c_array(ctype: str, name: str, vals, per_row: int = 16) -> str:
    vals = [int(v) for v in vals]
    width = max(len(str(v)) for v in vals)
    rows = ["    " + ", ".join(f"{v:{width}d}" for v in vals[i:i + per_row]) + ","
            for i in range(0, len(vals), per_row)]
    return f"static const {ctype} {name}[{len(vals)}] = {{\n" + "\n".join(rows) + "\n};\n"


def render(m, cfg, src: str) -> str:
    from pyvehtrack import cnn as C

    cs = synth_cfg(cfg)
    nb_s = C.frame_work_bytes(m, FRAME_W, FRAME_H, cs)
    nb_c = C.frame_work_bytes(m, CLIP_W, CLIP_H, cfg)
    max_boxes = max((c.n_levels + C.up_band_on(c)) * c.cap_per_level
                    for c in (cfg, cs))      # the levels' and the upsampled band's caps
    parts = [
        "/* firmware_demo/cnn_data.h -- GENERATED by tools/gen_cnn_table.py; do not edit.\n"
        " * The CNN detector firmware_demo/main.c runs (run_cnn), from\n"
        f" * {src}:\n"
        f" * {len(m.layers)} layers, out_stride {m.out_stride}, heat_thr {m.heat_thr}; its settings (vt_cnn_cfg:\n"
        f" * fw_cnn_cfg for the {CLIP_W}x{CLIP_H} clip frame, fw_cnn_cfg_synth, the same from level 0 with the\n"
        " * contrast stretch, for the\n"
        f" * synthetic {FRAME_W}x{FRAME_H} frame) and the work buffers vt_cnn_frame_work_bytes gives for them\n"
        " * (main.c checks). static const: in flash. */\n"
        "#ifndef FW_CNN_DATA_H\n#define FW_CNN_DATA_H\n\n#include <stdint.h>\n#include \"vehtrack/cnn.h\"\n\n"
        f"#define FW_CNN_FRAME_W {FRAME_W}\n#define FW_CNN_FRAME_H {FRAME_H}\n"
        f"#define FW_CNN_CLIP_W {CLIP_W}\n#define FW_CNN_CLIP_H {CLIP_H}\n"
        f"#define FW_CNN_WORK_SYNTH {nb_s}\n#define FW_CNN_WORK_CLIP {nb_c}\n"
        f"#define FW_CNN_WORK_BYTES {max(nb_s, nb_c)}\n"
        f"#define FW_CNN_MAX_BOXES {max_boxes} /* (n_levels [+ 1 with the upsampled band]) x cap_per_level: "
        "NMS keeps no more */\n\n"]
    for i, L in enumerate(m.layers):
        parts.append(_c_array("int8_t", f"fw_cnn_l{i}_w", np.asarray(L["w"]).reshape(-1), 24))
        parts.append(_c_array("int32_t", f"fw_cnn_l{i}_bias", L["bias"], 8))
        parts.append(_c_array("int32_t", f"fw_cnn_l{i}_mult", L["mult"], 8))
        parts.append(_c_array("uint8_t", f"fw_cnn_l{i}_shift", L["shift"], 16) + "\n")
    parts.append(_c_array("uint16_t", "fw_cnn_side_lut", np.asarray(m.side_lut).reshape(-1), 16) + "\n")
    parts.append("static const vt_cnn_model fw_cnn_model = {\n"
                 f"    .n_layers = {len(m.layers)},\n    .layer = {{\n")
    for i, L in enumerate(m.layers):
        parts.append(f"        {{.ksize = {L['ksize']}, .stride = {L['stride']}, .dilation = {L['dilation']}, "
                     f".relu = {L['relu']}, .cin = {L['cin']}, .cout = {L['cout']},\n"
                     f"         .w = fw_cnn_l{i}_w, .bias = fw_cnn_l{i}_bias, .mult = fw_cnn_l{i}_mult, "
                     f".shift = fw_cnn_l{i}_shift}},\n")
    parts.append("    },\n"
                 f"    .out_stride = {m.out_stride},\n    .heat_thr = {m.heat_thr},\n"
                 f"    .heat_scale_q16 = {m.heat_scale_q16},\n    .side_lut = fw_cnn_side_lut,\n}};\n\n")
    for name, c in (("fw_cnn_cfg", cfg), ("fw_cnn_cfg_synth", cs)):
        parts.append(f"static const vt_cnn_cfg {name} = {{\n"
                     + "".join(f"    .{k} = {getattr(c, k)},\n" for k in CFG_FIELDS) + "};\n\n")
    parts.append("#endif /* FW_CNN_DATA_H */\n")
    return "".join(parts)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", nargs="?", type=Path, help=f"a CNN .npz (default: {SHIPPED.relative_to(ROOT)} "
                    "if it exists, else the tiny model)")
    ap.add_argument("--tiny", action="store_true", help="the tiny model even if the shipped one exists")
    ap.add_argument("--check", action="store_true", help="compare instead of writing")
    args = ap.parse_args(argv)
    if args.tiny and args.model is not None:
        ap.error("--tiny and a MODEL do not mix")
    text = render(*load_model(args.model, args.tiny))
    if args.check:
        if not HEADER.exists() or HEADER.read_text() != text:
            print(f"stale: {HEADER.relative_to(ROOT)} (run tools/gen_cnn_table.py)", file=sys.stderr)
            return 1
        return 0
    HEADER.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
