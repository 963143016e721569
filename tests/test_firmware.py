"""The firmware proof: the same C core on a bare Cortex-M3 and Cortex-M7 (under
QEMU) and on the host (through cffi) gives the same bits.

firmware_demo/main.c runs the pixel, trig and fixed-point primitives on a real
road frame held in flash and prints an FNV-1a checksum of each output (statuses
folded in). `host_checksums()` below repeats that recipe step by step through
the cffi binding on the PNG the flash frame was generated from; the checksums
must be equal, line by line, for both cores. There is no tolerance: the
primitives are exact integer functions, so any difference is a portability bug
(int width, shift or division semantics, byte order) or a stale frame.

Then the whole vehicle system over five 640x256 clip frames in flash through its
one call, vt_pipeline_step on a static vt_pipeline (lanes on every frame, detection
on the first in the lanes' road area, the tracker on all five, the camera stage's
distance, TTC and warning per track), and again with every source (classifier,
flow, block TTC, the GA vehicle model refitting a coasting track). The image prints
every frame's road area (lane status, valid, rows, source), boxes, model fits and
tracks (box and Q16 velocity) and a checksum of every vt_frame_out;
`host_pipeline()` repeats it and every line must be equal, again with no tolerance
(the Kalman filter and the GA are fixed-point too).

Last, the CNN detector (vt_cnn_detect_frame) with the model and settings of
firmware_demo/cnn_data.h (static const, written by tools/gen_cnn_table.py: the shipped
pyvehtrack/models/cnn_gray.npz when it exists, else the script's deterministic tiny model)
on a synthetic 160x96 frame the image draws itself, then on clip frame 0; `host_cnn()`
draws the same frame (the generator's cnn_frame()) and detects through pyvehtrack.cnn, and
the `cnn` / `cnn_box` lines and the cnn_input / cnn_synth / cnn_clip0 checksums must be
equal too.

Same capacities on both sides: the images are built with firmware.mk's FW_CAPS (the
clip's 640x256, so every workspace fits the boards' 4 MB of RAM) and FW_DEFS, which
`make firmware-caps` prints; the host recipe runs through a cffi extension built
here with exactly those flags (`fw_native()`, cached under build/), not through the
suite's own build, and the image's `config` line must equal that build's capacities.

The ARM toolchain and QEMU are required, not optional: CI installs them with
`make setup`, and a skipped proof would prove nothing, so a missing tool FAILS.
"""
from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from pyvehtrack import _native

ROOT = Path(__file__).resolve().parent.parent
PNG = ROOT / "tests" / "data" / "kitti_0000_gray_320x96.png"
CLIP = [ROOT / "tests" / "data" / "kitti_clip" / f"{i:06d}.png" for i in range(5)]
CORES = ("cortex-m3", "cortex-m7")
TOOLS = ("arm-none-eabi-gcc", "arm-none-eabi-nm", "arm-none-eabi-objdump",
         "arm-none-eabi-size", "qemu-system-arm")

lib, ffi, view = _native.lib, _native.ffi, _native.view
CDEF_DIR = ROOT / "pyvehtrack" / "cdef"

INT32_MAX, INT32_MIN = 2**31 - 1, -2**31
M32 = 0xFFFFFFFF


def _tool_env() -> dict[str, str]:
    """The environment for the toolchain and QEMU: without the sanitizer
    runtime `make check SAN=1` preloads into this Python process."""
    return {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}


def _require_tools() -> None:
    missing = [t for t in TOOLS if shutil.which(t) is None]
    if missing:
        pytest.fail(f"firmware proof needs {', '.join(missing)}: run `make setup` "
                    "(apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm)",
                    pytrace=False)


# ---------------------------------------------------------------- the firmware's capacities
def fw_caps() -> list[str]:
    """The -D flags the images are built with (firmware.mk's FW_CAPS and FW_DEFS, as
    `make firmware-run` sees them: the caller's make command line reaches the nested
    make through MAKEFLAGS)."""
    proc = subprocess.run(["make", "-s", "--no-print-directory", "firmware-caps"], cwd=ROOT,
                          capture_output=True, text=True, timeout=60, env=_tool_env())
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.split()


def _fw_view(ffi_, arr: np.ndarray, writable: bool = False):
    """_native.view for another build's ffi: a C view struct over a 2-D array whose
    rows are contiguous (row padding allowed); the caller keeps `arr` alive."""
    ro, rw, ptype = {np.dtype(np.uint8): ("vt_image_u8", "vt_image_u8_mut", "uint8_t *"),
                     np.dtype(np.int16): (None, "vt_image_s16", "int16_t *"),
                     np.dtype(np.uint32): (None, "vt_image_u32", "uint32_t *")}[arr.dtype]
    assert arr.ndim == 2 and arr.strides[1] == arr.itemsize, arr.strides
    v = ffi_.new(((ro or rw) if not writable else rw) + " *")
    v.px = ffi_.cast(ptype, arr.ctypes.data)
    v.h, v.w = arr.shape
    v.stride = arr.strides[0] // arr.itemsize
    return v


def fw_native(caps: list[str]) -> SimpleNamespace:
    """The cffi extension built with the firmware's capacity flags (the same sources,
    cdefs and generator as meson's; -O1 as `make check`), cached by content and flags
    in build/fwffi-*/, loaded beside the suite's own build: lib, ffi, view."""
    import sysconfig
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc, "no C compiler (cc/gcc) for the firmware's host extension"
    srcs = sorted((ROOT / "c").glob("*.c"))
    deps = [*srcs, *sorted((ROOT / "include" / "vehtrack").glob("*.h")), *sorted((ROOT / "c").glob("*.h")),
            *sorted((ROOT / "c" / "tables").glob("*.h")), *sorted(CDEF_DIR.glob("*.h")),
            ROOT / "tools" / "build_ffi.py"]
    h = hashlib.sha256(" ".join([cc, *caps]).encode())
    for f in deps:
        h.update(f.read_bytes())
    out_dir = ROOT / "build" / f"fwffi-{h.hexdigest()[:16]}"
    so = out_dir / ("_vtffi" + sysconfig.get_config_var("EXT_SUFFIX"))
    if not so.exists():
        out_dir.mkdir(parents=True, exist_ok=True)
        gen = out_dir / "_vtffi.c"
        subprocess.run([sys.executable, str(ROOT / "tools" / "build_ffi.py"), str(gen)], check=True,
                       capture_output=True, env=_tool_env())
        tmp = so.with_suffix(".tmp")
        r = subprocess.run([cc, "-shared", "-fPIC", "-O1", *caps, f"-I{ROOT / 'include'}",
                            f"-I{sysconfig.get_paths()['include']}", *map(str, srcs), str(gen), "-o", str(tmp)],
                           capture_output=True, text=True, env=_tool_env())
        assert r.returncode == 0, r.stderr[-4000:]
        tmp.replace(so)
    # The same module name as the suite's build (its init symbol), from another file:
    # a separate library with its own ffi and struct sizes, not put in sys.modules.
    loader = importlib.machinery.ExtensionFileLoader("pyvehtrack._vtffi", str(so))
    spec = importlib.util.spec_from_file_location("pyvehtrack._vtffi", str(so), loader=loader)
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    return SimpleNamespace(lib=mod.lib, ffi=mod.ffi,
                           view=lambda arr, name, writable=False, dtype=None: _fw_view(mod.ffi, arr, writable))


# ---------------------------------------------------------------- FNV-1a 32, as main.c
FNV_BASIS = 2166136261
FNV_PRIME = 16777619


def fnv(h: int, data: bytes) -> int:
    for b in data:
        h = ((h ^ b) * FNV_PRIME) & M32
    return h


def fnv_u32(h: int, v: int) -> int:
    return fnv(h, (v & M32).to_bytes(4, "little"))


fnv_s32 = fnv_u32  # two's complement bits, little-endian


def fnv_s16(h: int, v: int) -> int:
    return fnv(h, (v & 0xFFFF).to_bytes(2, "little"))


def lcg_stream(seed: int):
    """main.c's lcg(): Numerical Recipes constants, mod 2^32."""
    state = seed

    def nxt() -> int:
        nonlocal state
        state = (state * 1664525 + 1013904223) & M32
        return state
    return nxt


def u2s(u: int) -> int:
    return u - 2**32 if u >= 2**31 else u


def lcg_scaled(nxt) -> int:
    k = nxt() >> 27
    m = (nxt() >> k) >> 1
    neg = nxt() >> 31
    return -m if neg else m


# ---------------------------------------------------------------- the recipe, on the host
PAIRS = [  # {ax, ay, bx, by, w, h}, as g_pairs in main.c
    (40, 30, 42, 31, 32, 24),
    (120, 40, 120, 40, 48, 40),
    (0, 0, 288, 72, 32, 24),
    (130, 44, 134, 46, 56, 40),
    (0, 10, 0, 11, 320, 1),
    (300, 0, 301, 0, 19, 96),
    (0, 0, 1, 0, 319, 96),
    (24, 0, 60, 0, 8, 4),
]
SINCOS_EXTRA = [-1, -1440, 1440, 1441, 2879, -721, INT32_MAX, INT32_MIN]
Q16_EDGES = [0, 1, -1, 2, -2, 32768, -32768, 65535, 65536, -65536, 98304, -98304,
             INT32_MAX, INT32_MIN, INT32_MAX - 1, INT32_MIN + 1]
U64_EDGES = [0, 1, 2, 3, 4, 15, 16, 17, 0xFFFFFFFF, 0x100000000,
             0xFFFFFFFE00000001, 0xFFFFFFFE00000000,
             0x4000000000000000, 0x8000000000000000, 0xFFFFFFFFFFFFFFFF]
N_RANDOM = 512


def load_frame() -> np.ndarray:
    img = cv2.imread(str(PNG), cv2.IMREAD_UNCHANGED)
    assert img is not None and img.dtype == np.uint8 and img.ndim == 2, PNG
    return img


def host_checksums(frame: np.ndarray, n: SimpleNamespace) -> list[tuple[str, int]]:
    """main.c's checksums of the primitives, through the build `n` (fw_native)."""
    lib, ffi, view = n.lib, n.ffi, n.view
    h_, w_ = frame.shape
    out: list[tuple[str, int]] = []
    src = view(frame, "frame")

    out.append(("frame", fnv(FNV_BASIS, frame.tobytes())))

    for name in ("filter_h101", "sobel_x", "sobel_y"):
        g = np.zeros((h_, w_), np.int16)
        s = getattr(lib, "vt_" + name)(src, view(g, "dst", writable=True, dtype=np.int16))
        out.append((name, fnv(fnv_s32(FNV_BASIS, s), g.astype("<i2").tobytes())))

    p = np.zeros(((h_ + 1) // 2, (w_ + 1) // 2), np.uint8)
    s = lib.vt_pyr_down(src, view(p, "dst", writable=True))
    out.append(("pyr_down", fnv(fnv_s32(FNV_BASIS, s), p.tobytes())))

    ii = np.zeros((h_ + 1, w_ + 1), np.uint32)
    iiv = view(ii, "ii", writable=True, dtype=np.uint32)
    s = lib.vt_integral(src, iiv)
    out.append(("integral", fnv(fnv_s32(FNV_BASIS, s), ii.astype("<u4").tobytes())))

    h = FNV_BASIS
    box = ffi.new("uint32_t *")
    s = lib.vt_box_sum(iiv, 0, 0, w_, h_, box)
    h = fnv_u32(fnv_s32(h, s), box[0])
    h = fnv_s32(h, lib.vt_box_sum(iiv, 0, 0, 1, 1, ffi.NULL))
    nxt = lcg_stream(12345)
    for _ in range(256):
        x = nxt() % (w_ + 8) - 4
        y = nxt() % (h_ + 8) - 4
        bw = nxt() % (w_ // 2 + 1)
        bh = nxt() % (h_ // 2 + 1)
        box[0] = 0
        s = lib.vt_box_sum(iiv, x, y, bw, bh, box)
        h = fnv_u32(fnv_s32(h, s), box[0])
    out.append(("box_sum", h))

    hn = hs = FNV_BASIS
    ncc = ffi.new("vt_q14 *")
    sad = ffi.new("uint32_t *")
    for ax, ay, bx, by, pw, ph in PAIRS:
        a, b = frame[ay:ay + ph, ax:ax + pw], frame[by:by + ph, bx:bx + pw]
        va, vb = view(a, "a"), view(b, "b")
        ncc[0] = 0
        s = lib.vt_ncc_u8(va, vb, ncc)
        hn = fnv_s16(fnv_s32(hn, s), ncc[0])
        sad[0] = 0
        s = lib.vt_sad_u8(va, vb, sad)
        hs = fnv_u32(fnv_s32(hs, s), sad[0])
    flat = np.full((8, 8), 128, np.uint8)
    a, b = frame[50:58, 100:108], frame[50:57, 100:108]
    va, vb, vf = view(a, "a"), view(b, "b"), view(flat, "flat")
    ncc[0] = 0
    s = lib.vt_ncc_u8(va, vf, ncc)
    hn = fnv_s16(fnv_s32(hn, s), ncc[0])
    hn = fnv_s32(hn, lib.vt_ncc_u8(va, vb, ncc))
    hn = fnv_s32(hn, lib.vt_ncc_u8(va, va, ffi.NULL))
    sad[0] = 0
    s = lib.vt_sad_u8(va, vf, sad)
    hs = fnv_u32(fnv_s32(hs, s), sad[0])
    hs = fnv_s32(hs, lib.vt_sad_u8(va, vb, sad))
    hs = fnv_s32(hs, lib.vt_sad_u8(va, va, ffi.NULL))
    out.append(("ncc_u8", hn))
    out.append(("sad_u8", hs))

    h = FNV_BASIS
    sn, cs = ffi.new("vt_q14 *"), ffi.new("vt_q14 *")
    for ang in list(range(lib.VT_QDEG_TURN)) + SINCOS_EXTRA:
        sn[0] = cs[0] = 0
        s = lib.vt_sincos_q14(ang, sn, cs)
        h = fnv_s16(fnv_s16(fnv_s32(h, s), sn[0]), cs[0])
    h = fnv_s32(h, lib.vt_sincos_q14(0, ffi.NULL, ffi.NULL))
    out.append(("sincos_q14", h))

    h = FNV_BASIS
    nxt = lcg_stream(1)
    for a_ in Q16_EDGES:
        for b_ in Q16_EDGES:
            h = fnv_s32(h, lib.vt_q16_mul_sat(a_, b_))
    for _ in range(N_RANDOM):
        a_ = u2s(nxt())
        b_ = lcg_scaled(nxt)
        h = fnv_s32(h, lib.vt_q16_mul_sat(a_, b_))
    out.append(("q16_mul_sat", h))

    h = FNV_BASIS
    nxt = lcg_stream(2)
    q = ffi.new("vt_q16 *")
    pairs = [(a_, b_) for a_ in Q16_EDGES for b_ in Q16_EDGES]
    for _ in range(N_RANDOM):
        a_ = lcg_scaled(nxt)
        b_ = lcg_scaled(nxt)
        pairs.append((a_, b_))
    for a_, b_ in pairs:
        q[0] = 0
        s = lib.vt_q16_div(a_, b_, q)
        h = fnv_s32(fnv_s32(h, s), q[0])
    h = fnv_s32(h, lib.vt_q16_div(1, 1, ffi.NULL))
    out.append(("q16_div", h))

    h = FNV_BASIS
    nxt = lcg_stream(3)
    for x in U64_EDGES:
        h = fnv_u32(h, lib.vt_isqrt_u64(x))
    for _ in range(N_RANDOM):
        x = nxt() << 32
        x |= nxt()
        k = nxt() >> 26
        h = fnv_u32(h, lib.vt_isqrt_u64(x >> k))
    out.append(("isqrt_u64", h))

    total = FNV_BASIS
    for _, v in out:
        total = fnv_u32(total, v)
    out.append(("all", total))
    return out


# ---------------------------------------------------------------- the pipeline, on the host
def load_clip() -> list[np.ndarray]:
    frames = [cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in CLIP]
    for p, f in zip(CLIP, frames):
        assert f is not None and f.dtype == np.uint8 and f.ndim == 2, p
    return frames


def _box_line(b) -> str:
    return f"{b.left} {b.top} {b.right} {b.bottom}"


def _fnv_box(h: int, b) -> int:
    for v in (b.left, b.top, b.right, b.bottom):
        h = fnv_s32(h, v)
    return h


def host_pipeline(frames: list[np.ndarray], n: SimpleNamespace,
                  with_model: bool = True) -> tuple[list[str], list[tuple[str, int]]]:
    """main.c's two run_pipeline() calls (the shadow source alone, then every source),
    their lines and checksums concatenated in the order printed, through the build `n`, then
    run_handover()'s checksum. with_model: main.c's FW_MODEL (the vehicle model source in the
    full run)."""
    la, sa = host_pipeline_run(frames, n, full=False, with_model=with_model)
    lb, sb = host_pipeline_run(frames, n, full=True, with_model=with_model)
    return la + lb, sa + sb + [("pipeline_handover", host_handover(n)[1])]


HO_W, HO_H, HO_N = 160, 120, 32


def _ho_tex(x, y, salt: int) -> np.ndarray:
    """main.c's ho_tex: xorshift32 of (x * 73856093) ^ (y * 19349663) ^ salt, mod 2^32."""
    v = (np.uint32(73856093) * x.astype(np.uint32)) ^ (np.uint32(19349663) * y.astype(np.uint32)) ^ np.uint32(salt)
    v ^= v << np.uint32(13)
    v ^= v >> np.uint32(17)
    v ^= v << np.uint32(5)
    return v


def ho_frame(f: int) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """main.c's ho_make_frame: static texture, and the 40x30 textured car at (92 + 2f, 50 + f)."""
    y, x = np.mgrid[0:HO_H, 0:HO_W]
    l, t = 92 + 2 * f, 50 + f
    img = (40 + (_ho_tex(x, y, 0xBA5E) & 63)).astype(np.uint8)
    car = (x >= l) & (x < l + 40) & (y >= t) & (y < t + 30)
    inner = (150 + (_ho_tex(x - l, y - t, 0x5EED) & 63)).astype(np.uint8)
    img[car] = inner[car]
    return img, (l, t, l + 39, t + 29)


def host_handover(n: SimpleNamespace) -> tuple[int, int]:
    """main.c's run_handover() through the build `n`: (frames with a VT_PIPE_HANDOVER
    track, checksum)."""
    lib, ffi, view = n.lib, n.ffi, n.view
    cfg = ffi.new("vt_pipeline_cfg *")
    h = fnv_s32(FNV_BASIS, lib.vt_pipeline_cfg_default(cfg))
    cfg.sources = lib.VT_SRC_FLOW
    cfg.flow.level = 0
    cfg.flow.sides = lib.VT_FLOW_SIDE_BOTH
    p = ffi.new("vt_pipeline *")
    h = fnv_s32(h, lib.vt_pipeline_init(p, cfg, ffi.NULL, ffi.NULL))
    st = ffi.new("vt_flow_state *")
    h = fnv_s32(h, lib.vt_pipeline_set_flow_ws(p, st))
    o = ffi.new("vt_frame_out *")
    det = ffi.new("vt_box *")
    n_ho = 0
    for f in range(HO_N):
        img, b = ho_frame(f)
        det.left, det.top, det.right, det.bottom = b
        s = lib.vt_pipeline_step_dets(p, view(img, "frame"), det, 1 if b[2] < HO_W else 0, o)
        h = fnv_s32(fnv_s32(h, s), o.n_tracks)
        seen = False
        for i in range(o.n_tracks):
            t = o.tracks[i]
            h = _fnv_box(fnv_s32(fnv_s32(h, t.id), t.state), t.box)
            for v in (t.vx, t.vy, t.source):
                h = fnv_s32(h, v)
            seen |= t.state == lib.VT_PIPE_HANDOVER
        n_ho += seen
    return n_ho, h


def test_handover_scene_hands_over(fw):
    """The firmware's hand-over scene (main.c run_handover, recomputed here) does hand the
    car over: a proof over a scene without a hand-over would prove little."""
    if int(fw.lib.VT_MAX_TRACKS) < 1:
        pytest.skip("no track slot")
    n_ho, _ = host_handover(fw)
    assert n_ho >= 10, n_ho


# ---------------------------------------------------------------- the CNN, on the host
CNN_GEN = ROOT / "tools" / "gen_cnn_table.py"
CNN_HEADER = ROOT / "firmware_demo" / "cnn_data.h"


def cnn_gen():
    """tools/gen_cnn_table.py as a module: the frame recipe and the model the header holds."""
    spec = importlib.util.spec_from_file_location("gen_cnn_table", CNN_GEN)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _host_cnn_run(name: str, model, cfg, frame: np.ndarray, header_need: int):
    """main.c's run_cnn_on(): (lines, checksum, what the tests check)."""
    from pyvehtrack import cnn as C

    h_, w_ = frame.shape
    frame = np.ascontiguousarray(frame)
    m, c = model.c_model()[0], cfg.c()
    h = fnv_s32(FNV_BASIS, lib.vt_cnn_check_model(m))
    h = fnv_s32(h, lib.vt_cnn_cfg_check(c))
    need = C.frame_work_bytes(model, w_, h_, cfg)
    h = fnv_u32(fnv_s32(h, lib.VT_OK), need)
    h = fnv_s32(h, int(need == header_need))
    work = np.zeros(need, np.uint8)
    cap = cfg.n_levels * cfg.cap_per_level
    boxes = ffi.new("vt_cnn_box[]", cap)
    n, tot = ffi.new("int32_t *", -1), ffi.new("int32_t *", -1)
    s = lib.vt_cnn_detect_frame(m, c, ffi.cast("const uint8_t *", frame.ctypes.data), w_, h_, w_,
                                ffi.cast("uint8_t *", work.ctypes.data), need - 1, boxes, cap, n, tot)
    h = fnv_s32(fnv_s32(fnv_s32(h, s), n[0]), tot[0])
    got, n_peaks = C.detect_frame(model, frame, cfg)
    h = fnv_s32(fnv_s32(fnv_s32(h, lib.VT_OK), len(got)), n_peaks)
    lines = [f"cnn {name} {len(got)} {n_peaks}"]
    for i, b in enumerate(got.tolist()):
        for v in b:
            h = fnv_s32(h, v)
        lines.append(f"cnn_box {name} {i} {' '.join(map(str, b))}")
    info = dict(cfg=cfg, frame=frame, boxes=got, n_peaks=n_peaks, need=need, header_need=header_need,
                refused=int(s))
    return lines, h, info


def host_cnn() -> tuple[list[str], list[tuple[str, int]], dict]:
    """main.c's run_cnn() through pyvehtrack.cnn (and, for the refused call, the suite's cffi
    build): the synthetic frame's checksum, then per run (the synthetic frame with the model's
    settings from level 0, clip frame 0 with the model's own) its `cnn` / `cnn_box` lines and
    checksum; plus what the tests below check, per run name."""
    g = cnn_gen()
    model, cfg, _ = g.load_model()
    header = CNN_HEADER.read_text()

    def define(name: str) -> int:
        return int(re.search(rf"#define {name} (\d+)", header).group(1))

    synth = g.cnn_frame()
    lines, sums, info = [], [("cnn_input", fnv(FNV_BASIS, synth.tobytes()))], {"model": model}
    for name, c, frame, need in (("synth", g.synth_cfg(cfg), synth, define("FW_CNN_WORK_SYNTH")),
                                 ("clip0", cfg, load_clip()[0], define("FW_CNN_WORK_CLIP"))):
        ln, h, info[name] = _host_cnn_run(name, model, c, frame, need)
        lines += ln
        sums.append((f"cnn_{name}", h))
    return lines, sums, info


def host_pipeline_run(frames: list[np.ndarray], n: SimpleNamespace, full: bool,
                      with_model: bool = True) -> tuple[list[str], list[tuple[str, int]]]:
    """main.c's run_pipeline(full): the printed lines (clip, then per frame road/boxes/box/
    model/tracks/track) and the checksums in the order printed, one per vt_frame_out
    (frame_out0..4 / full_out0..4), then pipeline / pipeline_full (the init statuses and
    the five). full: the default classifier model, the flow stage, the block TTC and
    (with_model) the vehicle model attached, detection on every second frame."""
    lib, ffi, view = n.lib, n.ffi, n.view
    h_, w_ = frames[0].shape
    lines = [f"clip {w_}x{h_}x{len(frames)}"]
    sums: list[tuple[str, int]] = []
    cfg = ffi.new("vt_pipeline_cfg *")
    total = fnv_s32(FNV_BASIS, lib.vt_pipeline_cfg_default(cfg))
    cfg.lanes_every_frame = 1
    cam = ffi.new("vt_camera_cfg *")  # the clip's camera, as main.c builds it
    total = fnv_s32(total, lib.vt_camera_cfg_default(cam))
    cam.img_w, cam.img_h = w_, h_
    cam.cx -= 300 * 65536
    cam.cy -= 118 * 65536
    p = ffi.new("vt_pipeline *")  # zeroed, as main.c's .bss one
    model = ffi.new("const vt_svm_model **")
    if full:
        cfg.sources = lib.VT_SRC_SHADOW | lib.VT_SRC_CLASSIFIER | lib.VT_SRC_FLOW
        if with_model:
            cfg.sources |= lib.VT_SRC_MODEL
        cfg.detect_every = 2
        cfg.flow.sides = lib.VT_FLOW_SIDE_BOTH
        cfg.flow.min_age = 1
        cfg.ttc.lag = 2
        total = fnv_s32(total, lib.vt_svm_default_model(lib.VT_DESC_HOG, model))
        m = model[0]
        cfg.fulldet.win.n_sizes = 1
        cfg.fulldet.win.size[0] = m.win_w
        cfg.fulldet.win.step_q8 = 8 * 256 // m.win_w
        cfg.fulldet.window_score_min = cfg.fulldet.shadow_score_min = m.threshold_q16
    total = fnv_s32(total, lib.vt_pipeline_init(p, cfg, cam, model[0] if full else ffi.NULL))
    keep = []
    if full:
        keep = [ffi.new("vt_pipe_cls_ws *"), ffi.new("vt_flow_state *"), ffi.new("vt_ttc_state *")]
        total = fnv_s32(total, lib.vt_pipeline_set_cls_ws(p, keep[0], ffi.NULL))
        total = fnv_s32(total, lib.vt_pipeline_set_flow_ws(p, keep[1]))
        total = fnv_s32(total, lib.vt_pipeline_set_ttc_ws(p, keep[2]))
        if with_model:
            keep.append(ffi.new("vt_model_ws *"))
            total = fnv_s32(total, lib.vt_pipeline_set_model_ws(p, keep[3]))
    o = ffi.new("vt_frame_out *")
    for f, frame in enumerate(frames):
        s = lib.vt_pipeline_step(p, view(frame, "frame"), o)
        h = fnv_s32(FNV_BASIS, s)
        ln = o.lanes
        for v in (o.frame, o.detection_frame, o.lanes_ran, o.lane_status, ln.shift, ln.w, ln.h,
                  ln.vp_known, ln.vp_y):
            h = fnv_s32(h, v)
        for k in range(int(lib.VT_LANE_SLOTS)):
            li = ln.lines[k]
            for v in (li.state, li.n_verts, li.xb, li.slope):
                h = fnv_s32(h, v)
        r = o.road
        h = fnv_s32(fnv_s32(h, o.road_source), r.valid)
        lines.append(f"road {f} {o.lane_status} {r.valid} {r.y_top} {r.y_bottom} {o.road_source}")
        if r.valid:
            for v in (r.y_top, r.y_bottom, r.height):
                h = fnv_s32(h, v)
            for i in range(min(r.height, int(lib.VT_MAX_HEIGHT))):
                h = fnv_s16(fnv_s16(fnv_s16(h, r.x_left[i]), r.x_right[i]), r.lane_width[i])
        h = fnv_s32(h, o.n_hyp)
        for i in range(o.n_hyp):
            hy = o.hyp[i]
            h = fnv_s32(fnv_s32(fnv_s32(h, hy.row), hy.x_start), hy.x_end)
        h = fnv_s32(fnv_s32(fnv_s32(h, o.n_boxes), o.flow_ready), o.model_fits)
        lines.append(f"boxes {f} {o.n_boxes}")
        for i in range(o.n_boxes):
            b = o.boxes[i]
            h = fnv_s32(fnv_s32(_fnv_box(h, b.box), b.source), b.score)
            lines.append(f"box {f} {_box_line(b.box)} {b.source}")
        used = sum(o.boxes[i].source == lib.VT_SRC_MODEL for i in range(o.n_boxes))
        lines.append(f"model {f} {o.model_fits} {used}")
        h = fnv_s32(h, o.n_tracks)
        lines.append(f"tracks {f} {o.n_tracks}")
        for i in range(o.n_tracks):
            t = o.tracks[i]
            h = _fnv_box(fnv_s32(fnv_s32(h, t.id), t.state), t.box)
            for v in (t.vx, t.vy, t.distance_mm, t.ttc_ms, t.warning, t.source, t.ttc_points_q16,
                      t.ttc_fused_q16):
                h = fnv_s32(h, v)
            lines.append(f"track {f} {t.id} {t.state} {_box_line(t.box)} {t.vx} {t.vy} "
                         f"{t.distance_mm} {t.ttc_ms} {t.warning} {t.ttc_points_q16} "
                         f"{t.ttc_fused_q16} {t.source}")
        sums.append((f"{'full_out' if full else 'frame_out'}{f}", h))
        total = fnv_u32(total, h)
    sums.append(("pipeline_full" if full else "pipeline", total))
    return lines, sums


# ---------------------------------------------------------------- the QEMU run
def parse_run(text: str) -> dict[str, dict]:
    """Per core: ordered checksum lines, the frame size, and whether it finished."""
    cores: dict[str, dict] = {}
    cur = None
    for line in text.splitlines():
        m = re.match(r"== qemu (\S+) (\S+) ==$", line)
        if m:
            cur = cores.setdefault(m.group(1), {"board": m.group(2), "checksums": [],
                                                "frame": None, "done": False, "core": None,
                                                "pipeline": [], "config": {}, "cnn": []})
            continue
        if cur is None:
            continue
        if re.match(r"(clip|road|boxes|box|model|tracks|track) ", line):
            cur["pipeline"].append(line)
        elif re.match(r"(cnn|cnn_box) ", line):
            cur["cnn"].append(line)
        elif m := re.match(r"config (\w+) (-?\d+)$", line):
            cur["config"][m.group(1)] = int(m.group(2))
        elif m := re.match(r"checksum (\S+) 0x([0-9a-f]{8})$", line):
            cur["checksums"].append((m.group(1), int(m.group(2), 16)))
        elif m := re.match(r"frame (\d+)x(\d+)$", line):
            cur["frame"] = (int(m.group(1)), int(m.group(2)))
        elif m := re.match(r"core (\S+)$", line):
            cur["core"] = m.group(1)
        elif line == "done":
            cur["done"] = True
    return cores


@pytest.fixture(scope="module")
def firmware_run():
    """One `make firmware-run` per session (the build dir comes from the caller's
    make command line through MAKEFLAGS, e.g. `make check BUILD=build-x`)."""
    _require_tools()
    proc = subprocess.run(["make", "--no-print-directory", "firmware-run"], cwd=ROOT,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=900, env=_tool_env())
    text = proc.stdout
    assert proc.returncode == 0, f"make firmware-run failed (exit {proc.returncode}):\n{text[-4000:]}"
    return text


@pytest.fixture(scope="module")
def caps():
    return fw_caps()


def _model_on(caps: list[str]) -> bool:
    """main.c's FW_MODEL (1 unless FW_DEFS sets it to 0)."""
    vals = [c.split("=", 1)[1] for c in caps if c.startswith("-DFW_MODEL=")]
    return not vals or vals[-1] != "0"


@pytest.fixture(scope="module")
def fw(caps):
    """The host side of the comparison: the core built with the images' capacities."""
    return fw_native(caps)


@pytest.fixture(scope="module")
def pipeline(fw, caps):
    return host_pipeline(load_clip(), fw, with_model=_model_on(caps))


@pytest.fixture(scope="module")
def cnn_host():
    return host_cnn()


@pytest.fixture(scope="module")
def host(pipeline, fw, cnn_host):
    """Every checksum line the image prints, in order: the primitives (ending with
    `all`, which covers them alone), then detect, road, tracker and pipeline, then the CNN."""
    return host_checksums(load_frame(), fw) + pipeline[1] + cnn_host[1]


def test_symbol_check_ran_and_passed(firmware_run):
    for core in CORES:
        assert re.search(rf"^symbol check {core}: OK\b", firmware_run, re.M), \
            f"the forbidden-symbol check did not report OK for {core}:\n{firmware_run[-3000:]}"
    assert "FAIL" not in firmware_run
    # The size table of both images was printed (arm-none-eabi-size, berkeley format).
    assert len(re.findall(r"^\s*\d+\s+\d+\s+\d+\s+\d+\s+[0-9a-f]+\s+\S*firmware-m[37]\.elf$",
                          firmware_run, re.M)) == 2


@pytest.mark.parametrize("core", CORES)
def test_image_capacities_equal_host(firmware_run, fw, caps, core):
    """The image says which capacities it was built with; the host build the lines are
    compared with has the same ones (and a model source only if the image has one)."""
    run = parse_run(firmware_run).get(core)
    assert run is not None and run["done"], f"{core} image did not finish:\n{firmware_run[-3000:]}"
    cfg = dict(run["config"])
    assert cfg.pop("FW_MODEL") == int(_model_on(caps))
    assert len(cfg) >= 10, cfg
    for name, value in cfg.items():
        assert int(getattr(fw.lib, name)) == value, f"{core}: {name} {value} in the image, " \
            f"{int(getattr(fw.lib, name))} on the host ({' '.join(caps)})"


@pytest.mark.parametrize("core", CORES)
def test_qemu_checksums_equal_host(firmware_run, host, core):
    cores = parse_run(firmware_run)
    assert core in cores, f"no QEMU output section for {core}:\n{firmware_run[-3000:]}"
    run = cores[core]
    assert run["core"] == core
    assert run["done"], f"{core} image did not finish:\n{firmware_run[-3000:]}"
    h_, w_ = load_frame().shape
    assert run["frame"] == (w_, h_)
    got = run["checksums"]
    assert [n for n, _ in got] == [n for n, _ in host], "checksum lines differ in names/order"
    for (name, g), (_, e) in zip(got, host):
        assert g == e, f"{core}: checksum {name} 0x{g:08x} on QEMU, 0x{e:08x} on the host"


@pytest.mark.parametrize("core", CORES)
def test_qemu_pipeline_equal_host(firmware_run, pipeline, core):
    """Every box and track line (ids, states, boxes, Q16 velocities) as on the host."""
    run = parse_run(firmware_run).get(core)
    assert run is not None and run["done"], f"{core} image did not finish:\n{firmware_run[-3000:]}"
    got, want = run["pipeline"], pipeline[0]
    for i, (g, e) in enumerate(zip(got, want)):
        assert g == e, f"{core}: pipeline line {i}: {g!r} on QEMU, {e!r} on the host"
    assert len(got) == len(want), f"{core}: {len(got)} pipeline lines on QEMU, {len(want)} on the host"


def _runs(lines: list[str]) -> tuple[list[str], list[str]]:
    """The lines of main.c's first run (shadow source) and of its second (every source)."""
    k = [i for i, ln in enumerate(lines) if ln.startswith("clip ")]
    assert len(k) == 2, k
    return lines[:k[1]], lines[k[1]:]


def test_pipeline_exercises_detection_and_tracking(pipeline):
    """A proof over an empty pipeline would prove little: the detector finds at
    least one box on frame 0, and a track exists in every frame, so the tracked
    frames run the ROI search and the Kalman filter."""
    lines = _runs(pipeline[0])[0]
    assert int(next(ln for ln in lines if ln.startswith("boxes 0 ")).split()[2]) >= 1, lines
    for f in range(len(CLIP)):
        assert any(ln.startswith(f"track {f} ") for ln in lines), (f, lines)


def test_pipeline_detects_in_the_lane_road(pipeline):
    """The detection runs in a road area the lane stage found (VT_OK, valid) on every
    frame, and in it the lead car's track is confirmed by frame 2 (three hits:
    the detection and two ROI searches), as Detector + Tracker find on this clip
    (tests/test_tracker_real.py)."""
    lines = _runs(pipeline[0])[0]
    for f in range(len(CLIP)):
        road = next(ln for ln in lines if ln.startswith(f"road {f} ")).split()
        assert road[2:4] == [str(int(lib.VT_OK)), "1"], (f, road)
        assert road[6] == str(int(lib.VT_ROAD_SRC_LANES)), (f, road)
    last = [ln.split() for ln in lines if ln.startswith(f"track {len(CLIP) - 1} ")]
    assert any(int(t[3]) == int(lib.VT_TRACK_CONFIRMED) for t in last), lines
    # The camera stage ran: every track has a filtered distance (mm), plausible for the
    # lead car about 8-10 m ahead (lidar 7.8-8.0 m; the flat-road distance has no rear offset).
    for ln in lines:
        if ln.startswith("track "):
            d = int(ln.split()[10])
            assert d != int(lib.VT_UNKNOWN) and 5000 < d < 15000, ln


def test_full_run_exercises_every_source(pipeline):
    """The second run is no empty proof either: every init/attach status is VT_OK (the
    default model exists in this build), the whole-road detector works on the camera
    road on every detection frame (every second; the lanes' road in between) with
    classifier boxes among its boxes, and tracks say which source started them."""
    lines = _runs(pipeline[0])[1]
    for f in range(len(CLIP)):
        road = next(ln for ln in lines if ln.startswith(f"road {f} ")).split()
        want = lib.VT_ROAD_SRC_CAMERA if f % 2 == 0 else lib.VT_ROAD_SRC_LANES
        assert road[6] == str(int(want)), (f, road)
    srcs = {int(ln.split()[6]) for ln in lines if ln.startswith("box ")}
    assert {int(lib.VT_SRC_CLASSIFIER), int(lib.VT_SRC_FLOW)} <= srcs, lines
    tsrc = {int(ln.split()[-1]) for ln in lines if ln.startswith("track ")}
    assert tsrc and tsrc <= {int(lib.VT_SRC_SHADOW), int(lib.VT_SRC_CLASSIFIER), int(lib.VT_SRC_FLOW),
                             int(lib.VT_SRC_MODEL)}, lines
    # the block-scale TTC (lag 2) measures a track on frame 2; nothing before (no history)
    pts = [(int(ln.split()[1]), int(ln.split()[-2])) for ln in lines if ln.startswith("track ")]
    assert any(f == 2 and v != int(lib.VT_UNKNOWN) for f, v in pts), lines
    assert all(v == int(lib.VT_UNKNOWN) for f, v in pts if f < 2), lines


def test_full_run_refits_a_coasting_track(pipeline, caps):
    """The vehicle model source runs in the image, not just links: a track the previous
    step left coasting (its ROI search failed on a tracked frame) is refitted by the GA
    on the next frame, the fit is used (a box of source VT_SRC_MODEL overlapping the
    track's last box), and the track is confirmed again. Fits run only for coasting
    tracks, at most model_fits (2) per frame, and never more used than run."""
    if not _model_on(caps):
        pytest.skip("FW_DEFS=-DFW_MODEL=0: the image leaves the model source out (a cost measurement)")
    lines = _runs(pipeline[0])[1]
    model = {int(ln.split()[1]): tuple(map(int, ln.split()[2:4])) for ln in lines if ln.startswith("model ")}
    assert sorted(model) == list(range(len(CLIP))), model
    tracks = {f: {int(t[2]): (int(t[3]), tuple(map(int, t[4:8]))) for t in
                  (ln.split() for ln in lines if ln.startswith(f"track {f} "))} for f in model}
    coast = int(lib.VT_TRACK_COASTING)
    for f, (run, used) in model.items():
        asked = sum(st == coast for st, _ in tracks[f - 1].values()) if f > 0 else 0
        assert 0 <= used <= run <= min(2, asked), (f, run, used, asked, lines)
    refits = [f for f, (run, used) in model.items() if used > 0]
    assert refits, f"no model fit used over the clip: {model}"
    f = refits[0]
    boxes = [tuple(map(int, ln.split()[2:6])) for ln in lines
             if ln.startswith(f"box {f} ") and int(ln.split()[6]) == int(lib.VT_SRC_MODEL)]
    assert boxes, lines
    again = [i for i, (st, _) in tracks[f - 1].items()
             if st == coast and tracks[f].get(i, (0,))[0] == int(lib.VT_TRACK_CONFIRMED)]
    assert again, (f, tracks[f - 1], tracks[f])


def test_host_recipe_sees_error_statuses():
    """The recipe must exercise error paths too, or folding statuses would prove
    nothing: the flat patch is singular, a NULL output is an argument error."""
    flat = np.full((8, 8), 128, np.uint8)
    out = ffi.new("vt_q14 *")
    assert lib.vt_ncc_u8(view(flat, "a"), view(flat, "b"), out) == lib.VT_E_SINGULAR
    assert lib.vt_q16_div(1, 0, ffi.new("vt_q16 *")) == lib.VT_E_SINGULAR
    assert lib.vt_sincos_q14(0, ffi.NULL, ffi.NULL) == lib.VT_E_ARG


def test_frame_header_is_fresh():
    proc = subprocess.run([sys.executable, str(ROOT / "tools" / "gen_firmware_frame.py"), "--check"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def test_cnn_header_is_fresh():
    """firmware_demo/cnn_data.h is what tools/gen_cnn_table.py writes now (the model it picks:
    the shipped cnn_gray.npz when it exists, else the tiny one)."""
    proc = subprocess.run([sys.executable, str(CNN_GEN), "--check"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize("core", CORES)
def test_qemu_cnn_equal_host(firmware_run, cnn_host, core):
    """The CNN's `cnn NAME N PEAKS` and every `cnn_box` line (frame px, heat) as on the host."""
    run = parse_run(firmware_run).get(core)
    assert run is not None and run["done"], f"{core} image did not finish:\n{firmware_run[-3000:]}"
    assert run["cnn"] == cnn_host[0], f"{core}: CNN lines differ:\n{run['cnn']}\nhost:\n{cnn_host[0]}"


def test_cnn_run_is_not_empty(cnn_host):
    """A proof over no boxes would prove little: per run, the work size in the header is the
    core's, one byte fewer is refused, the boxes lie inside the frame and are the bit-exact
    NumPy twin's (pyvehtrack/reference/cnn.py) too; and the runs find boxes."""
    from pyvehtrack.reference import cnn as R

    lines, _, info = cnn_host
    total = 0
    for name in ("synth", "clip0"):
        i = info[name]
        assert i["need"] == i["header_need"], (name, i["need"], i["header_need"])
        assert i["refused"] == lib.VT_E_CAPACITY, name
        b = i["boxes"]
        h_, w_ = i["frame"].shape
        assert i["n_peaks"] >= len(b), (name, lines)
        assert (b[:, 0] >= 0).all() and (b[:, 2] < w_).all() and (b[:, 1] >= 0).all() and (b[:, 3] < h_).all()
        assert (b[:, 0] <= b[:, 2]).all() and (b[:, 1] <= b[:, 3]).all()
        rb, rn = R.detect_frame(info["model"], i["frame"], i["cfg"])
        assert rn == i["n_peaks"] and np.array_equal(rb, b), name
        total += len(b)
    assert total >= 2, lines


BAD_SOFT = r"""
#include <stdlib.h>
float f(float a, int b);
float f(float a, int b) { return a / (float)b; }
void *volatile keep;
int main(void) { keep = malloc(16); return (int)f(3.0f, 2); }
"""

BAD_HARD = r"""
float g(float a, float b);
float g(float a, float b) { return a * b + 1.0f; }
void _start(void);
void _start(void) { volatile float x = g(2.0f, 3.0f); (void)x; for (;;) {} }
"""


def _check_elf(elf: Path):
    return subprocess.run(["sh", str(ROOT / "firmware_demo" / "check_elf.sh"), "bad", str(elf)],
                          capture_output=True, text=True, env=_tool_env())


def test_symbol_check_catches_heap_and_soft_float(tmp_path):
    """The checker itself can fail: a Cortex-M3 soft-float image with a float
    division and a malloc is rejected, naming both."""
    _require_tools()
    c = tmp_path / "bad.c"
    c.write_text(BAD_SOFT)
    elf = tmp_path / "bad.elf"
    subprocess.run(["arm-none-eabi-gcc", "-mcpu=cortex-m3", "-mthumb", "-mfloat-abi=soft", "-O2",
                    "--specs=nosys.specs", str(c), "-o", str(elf)], check=True,
                   capture_output=True, text=True, env=_tool_env())
    proc = _check_elf(elf)
    assert proc.returncode != 0
    assert "malloc" in proc.stderr and "__aeabi_fdiv" in proc.stderr, proc.stderr


def test_symbol_check_catches_fp_instructions(tmp_path):
    """... and a hard-float Cortex-M7 image computing in float, which needs no
    helper, is rejected for its VFP instructions."""
    _require_tools()
    c = tmp_path / "badhf.c"
    c.write_text(BAD_HARD)
    elf = tmp_path / "badhf.elf"
    subprocess.run(["arm-none-eabi-gcc", "-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16",
                    "-mfloat-abi=hard", "-O2", "-nostdlib", str(c), "-o", str(elf), "-lgcc"],
                   check=True, capture_output=True, text=True, env=_tool_env())
    proc = _check_elf(elf)
    assert proc.returncode != 0
    assert "floating-point instructions" in proc.stderr, proc.stderr
