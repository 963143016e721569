"""The quantised CNN detector from Python (C: include/vehtrack/cnn.h, c/cnn.c).

The appearance stage as a small CNN: a CenterNet-style heat map + box sides at the model's
output stride (8 for the intended layout), in place of the GIST paper's sliding-window
classifier (sec. III) for full-frame hypotheses. The arithmetic (int8 weights, uint8
activations, int32 accumulators, per-channel requantisation) is cnn.h's;
pyvehtrack/reference/cnn.py is its bit-exact NumPy twin.

Model file (.npz), every key required:
    cnn_n_layers        int, 1 .. VT_CNN_MAX_LAYERS
    cnn_l{i}_meta       int32 (6,): ksize, stride, dilation, relu, cin, cout
    cnn_l{i}_w          int8 (cout, k, k, cin)
    cnn_l{i}_bias       int32 (cout,)
    cnn_l{i}_mult       int32 (cout,)
    cnn_l{i}_shift      uint8 (cout,)
    cnn_side_lut        uint16 (4, 256)
    cnn_heat_thr        int, -128..127
    cnn_heat_scale_q16  int, 1..VT_CNN_HEAT_SCALE_MAX: the float logit of one heat step, Q16
                        (the pipeline reports a CNN box's score as heat x this / 65536)
(Any integer dtype whose values fit the stated one is accepted; out_stride is the product of
the strides.)

Frame-level detection (detect_frame, C vt_cnn_detect_frame): the network on several Gaussian
pyramid levels of a frame (CnnConfig: which levels, threshold offset, peaks per level, the NMS
merging all levels' boxes, the row band of level 0 it runs on, the contrast stretch). The optional
file key cnn_cfg holds those settings as int32 in CFG_KEYS order; a file written before the
level-0 band (its first 6 entries only), before the stretch (8) or before the upsampled band (9)
loads with the defaults of the rest (the whole frame, no stretch, no upsampled band). is_cnn(path_or_npz)
tells a CNN model file from the other detectors' (its keys start with cnn_).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from . import _check
from ._native import VtError, check, ffi, lib, view

MAX_LAYERS = int(lib.VT_CNN_MAX_LAYERS)
MAX_CH = int(lib.VT_CNN_MAX_CH)
OUT_CH = int(lib.VT_CNN_OUT_CH)
BIAS_MAX = int(lib.VT_CNN_BIAS_MAX)
HEAT_SCALE_MAX = int(lib.VT_CNN_HEAT_SCALE_MAX)
MAX_LEVEL = int(lib.VT_CNN_MAX_LEVEL)
MAX_RUN_LEVELS = int(lib.VT_CNN_MAX_RUN_LEVELS)
MAX_PEAKS = int(lib.VT_CNN_MAX_PEAKS)
META = ("ksize", "stride", "dilation", "relu", "cin", "cout")


def _int_array(z, key: str, dtype, shape=None) -> np.ndarray:
    """z[key] as a C-contiguous array of `dtype`; ValueError naming the key if it is missing,
    not integers, of another shape, or holds values `dtype` cannot."""
    if key not in z:
        raise ValueError(f"CNN model: missing key {key!r}")
    a = np.asarray(z[key])
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"CNN model: {key} must hold integers, got dtype {a.dtype}")
    if shape is not None and a.shape != tuple(shape):
        raise ValueError(f"CNN model: {key} must have shape {tuple(shape)}, got {a.shape}")
    info = np.iinfo(dtype)
    if a.size and (int(a.min()) < info.min or int(a.max()) > info.max):
        raise ValueError(f"CNN model: {key} holds values outside {np.dtype(dtype)} "
                         f"[{info.min}, {info.max}]")
    return np.ascontiguousarray(a, dtype=dtype)


def _int_scalar(z, key: str, lo: int, hi: int) -> int:
    a = _int_array(z, key, np.int64)
    if a.size != 1:
        raise ValueError(f"CNN model: {key} must be one integer, got shape {a.shape}")
    v = int(a.reshape(-1)[0])
    if not lo <= v <= hi:
        raise ValueError(f"CNN model: {key} = {v} is outside [{lo}, {hi}]")
    return v


class CnnModel:
    """A vt_cnn_model and the NumPy arrays behind it (kept alive as long as the model).
    heat_scale_q16: the float logit of one heat step in Q16 (the file's required
    cnn_heat_scale_q16; 65536, one logit per step, when a model is built in code)."""

    def __init__(self, layers: list[dict], side_lut: np.ndarray, heat_thr: int = 0, path: str = "", *,
                 heat_scale_q16: int = 65536):
        self.path = str(path)
        self.layers = [dict(L) for L in layers]
        self.side_lut = side_lut
        self.heat_thr = int(heat_thr)
        self.heat_scale_q16 = _check.integer(heat_scale_q16, "cnn_heat_scale_q16", 1, HEAT_SCALE_MAX)
        self._c = None
        self.cfg = None   # CnnConfig the model was validated with (file key cnn_cfg), or None
        self.c_model()  # the core's check, now

    @property
    def out_stride(self) -> int:
        s = 1
        for L in self.layers:
            s *= int(L["stride"])
        return s

    # ------------------------------------------------------------ file
    @classmethod
    def load(cls, path_or_npz) -> "CnnModel":
        """From an .npz path or an already opened mapping (np.load result, dict)."""
        if isinstance(path_or_npz, (str, Path)):
            p = Path(path_or_npz)
            if not p.is_file():
                raise FileNotFoundError(f"CNN model {p} does not exist")
            _check.npz_file(p, "CNN model")
            with np.load(p, allow_pickle=False) as z:
                return cls._from_keys(z, str(p))
        return cls._from_keys(path_or_npz, "")

    @classmethod
    def _from_keys(cls, z, path: str) -> "CnnModel":
        keys = set(z.files) if hasattr(z, "files") else set(z.keys())
        zz = {k: z[k] for k in keys}
        n = _int_scalar(zz, "cnn_n_layers", 1, MAX_LAYERS)
        layers = []
        for i in range(n):
            meta = _int_array(zz, f"cnn_l{i}_meta", np.int32, (6,))
            L = {name: int(v) for name, v in zip(META, meta)}
            for name in META[:4]:
                if not 0 <= L[name] <= 255:
                    raise ValueError(f"CNN model: cnn_l{i}_meta {name} = {L[name]} is outside [0, 255]")
            for name in META[4:]:
                if not 1 <= L[name] <= MAX_CH:
                    raise ValueError(f"CNN model: cnn_l{i}_meta {name} = {L[name]} is outside [1, {MAX_CH}]")
            k, cin, cout = L["ksize"], L["cin"], L["cout"]
            L["w"] = _int_array(zz, f"cnn_l{i}_w", np.int8, (cout, k, k, cin))
            L["bias"] = _int_array(zz, f"cnn_l{i}_bias", np.int32, (cout,))
            L["mult"] = _int_array(zz, f"cnn_l{i}_mult", np.int32, (cout,))
            L["shift"] = _int_array(zz, f"cnn_l{i}_shift", np.uint8, (cout,))
            layers.append(L)
        extra = sorted(k for k in keys if int((re.match(r"cnn_l(\d+)_", k) or [0, -1])[1]) >= n)
        if extra:
            raise ValueError(f"CNN model: cnn_n_layers is {n} but the file has {', '.join(extra)}")
        lut = _int_array(zz, "cnn_side_lut", np.uint16, (4, 256))
        thr = _int_scalar(zz, "cnn_heat_thr", -128, 127)
        scale = _int_scalar(zz, "cnn_heat_scale_q16", 1, HEAT_SCALE_MAX)
        m = cls(layers, lut, thr, path, heat_scale_q16=scale)
        if "cnn_cfg" in zz:   # optional: the settings the model was validated with
            v = _int_array(zz, "cnn_cfg", np.int32)
            if v.ndim != 1 or len(v) not in CFG_KEYS_LENGTHS:
                raise ValueError(f"CNN model: cnn_cfg must have shape ({len(CFG_KEYS)},) (CFG_KEYS), or "
                                 f"({CFG_KEYS_OLD},) / (8,) / (9,) in a file from before the level-0 band / the "
                                 f"contrast stretch / the upsampled band, got {v.shape}")
            d = {k: int(x) for k, x in zip(CFG_KEYS, v)}
            if len(d) < len(CFG_KEYS):   # an old file: the defaults (whole-frame band, no stretch)
                dc = CnnConfig().c()
                d.update({k: int(getattr(dc, k)) for k in CFG_KEYS[len(d):]})
            m.cfg = CnnConfig(**d)
            m.cfg.c()   # checked now: the file is refused, not the first frame
        return m

    def keys(self) -> dict:
        """The model under the file's key names (np.savez(path, **m.keys()) writes it)."""
        d = {"cnn_n_layers": np.int32(len(self.layers)), "cnn_side_lut": np.asarray(self.side_lut, np.uint16),
             "cnn_heat_thr": np.int32(self.heat_thr), "cnn_heat_scale_q16": np.int32(self.heat_scale_q16)}
        for i, L in enumerate(self.layers):
            d[f"cnn_l{i}_meta"] = np.array([L[k] for k in META], np.int32)
            d[f"cnn_l{i}_w"] = np.asarray(L["w"], np.int8)
            d[f"cnn_l{i}_bias"] = np.asarray(L["bias"], np.int32)
            d[f"cnn_l{i}_mult"] = np.asarray(L["mult"], np.int32)
            d[f"cnn_l{i}_shift"] = np.asarray(L["shift"], np.uint8)
        return d

    def save(self, path) -> None:
        d = self.keys()
        if self.cfg is not None:
            c = self.cfg.c()
            v = [int(getattr(c, k)) for k in CFG_KEYS]
            # without the upsampled band, the 9 entries a reader from before it takes
            d["cnn_cfg"] = np.array(v if up_band_on(c) else v[:len(CFG_KEYS) - len(UP_KEYS)], np.int32)
        np.savez_compressed(path, **d)

    # ------------------------------------------------------------ the C struct
    def _why(self) -> str:
        """Which rule of vt_cnn_check_model the model breaks, named by its file key."""
        n = len(self.layers)
        if not 1 <= n <= MAX_LAYERS:
            return f"cnn_n_layers = {n} is outside [1, {MAX_LAYERS}]"
        for i, L in enumerate(self.layers):
            key, last = f"cnn_l{i}_meta", i == n - 1
            if L["ksize"] not in (1, 3):
                return f"{key}: ksize {L['ksize']} is not 1 or 3"
            if L["stride"] not in (1, 2):
                return f"{key}: stride {L['stride']} is not 1 or 2"
            if L["dilation"] not in (1, 2) or (L["ksize"] == 1 and L["dilation"] != 1):
                return f"{key}: dilation {L['dilation']} (1 or 2 for 3x3, 1 for 1x1)"
            if L["relu"] != (0 if last else 1):
                return f"{key}: relu {L['relu']} (1 on every layer but the last, 0 on the last)"
            if not 1 <= L["cin"] <= MAX_CH or not 1 <= L["cout"] <= MAX_CH:
                return f"{key}: cin {L['cin']}, cout {L['cout']} outside [1, {MAX_CH}]"
            want = 1 if i == 0 else self.layers[i - 1]["cout"]
            if L["cin"] != want:
                return f"{key}: cin {L['cin']} must be {want} ({'the gray input' if i == 0 else 'the previous cout'})"
            if last and L["cout"] != OUT_CH:
                return f"{key}: the last layer's cout {L['cout']} must be {OUT_CH}"
            if np.abs(np.asarray(L["bias"], np.int64)).max(initial=0) > BIAS_MAX:
                return f"cnn_l{i}_bias: |bias| must be <= {BIAS_MAX}"
            if np.asarray(L["mult"], np.int64).min(initial=1) < 1:
                return f"cnn_l{i}_mult: every mult must be >= 1"
            sh = np.asarray(L["shift"], np.int64)
            if sh.size and (sh.min() < 1 or sh.max() > 62):
                return f"cnn_l{i}_shift: every shift must be in 1..62"
        if not 1 <= self.heat_scale_q16 <= HEAT_SCALE_MAX:
            return f"cnn_heat_scale_q16 = {self.heat_scale_q16} is outside [1, {HEAT_SCALE_MAX}]"
        if self.out_stride > 255:
            return f"the strides' product {self.out_stride} does not fit out_stride (uint8)"
        return "see vt_cnn_check_model"

    def c_model(self):
        """The checked vt_cnn_model (cached); its arrays point into this object's NumPy arrays."""
        if self._c is not None:
            return self._c
        n = len(self.layers)
        if not 1 <= n <= MAX_LAYERS:
            raise ValueError(f"CNN model: cnn_n_layers = {n} is outside [1, {MAX_LAYERS}]")
        m = ffi.new("vt_cnn_model *")
        keep = []

        def ptr(a, dtype, ctype):
            a = np.ascontiguousarray(a, dtype=dtype)
            keep.append(a)
            return ffi.cast(ctype, a.ctypes.data)

        m.n_layers = n
        for i, L in enumerate(self.layers):
            c = m.layer[i]
            for k in META[:4]:
                if not 0 <= int(L[k]) <= 255:
                    raise ValueError(f"CNN model: cnn_l{i}_meta {k} = {L[k]} is outside [0, 255]")
                setattr(c, k, int(L[k]))
            for k in META[4:]:
                if not 0 <= int(L[k]) <= 65535:
                    raise ValueError(f"CNN model: cnn_l{i}_meta {k} = {L[k]} is outside [0, 65535]")
                setattr(c, k, int(L[k]))
            c.w = ptr(L["w"], np.int8, "const int8_t *")
            c.bias = ptr(L["bias"], np.int32, "const int32_t *")
            c.mult = ptr(L["mult"], np.int32, "const int32_t *")
            c.shift = ptr(L["shift"], np.uint8, "const uint8_t *")
            want = (int(L["cout"]), int(L["ksize"]), int(L["ksize"]), int(L["cin"]))
            if keep[-4].shape != want:
                raise ValueError(f"CNN model: cnn_l{i}_w has shape {keep[-4].shape}, the meta says {want}")
            for j, name in ((-3, "bias"), (-2, "mult"), (-1, "shift")):
                if keep[j].shape != (want[0],):
                    raise ValueError(f"CNN model: cnn_l{i}_{name} has shape {keep[j].shape}, "
                                     f"the meta says ({want[0]},)")
        m.out_stride = self.out_stride & 0xFF
        m.heat_thr = _check.integer(self.heat_thr, "cnn_heat_thr", -128, 127)
        m.heat_scale_q16 = _check.integer(self.heat_scale_q16, "cnn_heat_scale_q16", 1, HEAT_SCALE_MAX)
        lut = np.asarray(self.side_lut)
        if lut.shape != (4, 256):
            raise ValueError(f"CNN model: cnn_side_lut must have shape (4, 256), got {lut.shape}")
        m.side_lut = ptr(lut, np.uint16, "const uint16_t *")
        s = lib.vt_cnn_check_model(m)
        if s < 0:
            raise VtError("vt_cnn_check_model", s, self._why() + (f" ({self.path})" if self.path else ""))
        self._c = (m, keep)
        return self._c


def _gray(img, name: str = "gray") -> np.ndarray:
    if not isinstance(img, np.ndarray):
        raise TypeError(f"{name}: expected a numpy.ndarray, got {type(img).__name__}")
    if img.dtype != np.uint8:
        raise TypeError(f"{name}: expected a uint8 gray image, got dtype {img.dtype}")
    if img.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D gray image (h, w), got shape {img.shape}")
    if img.size == 0:
        raise ValueError(f"{name}: the image is empty (shape {img.shape})")
    return img


def out_size(model: CnnModel, w: int, h: int) -> tuple[int, int]:
    """vt_cnn_out_size: (gw, gh) of the last layer for a w x h input."""
    gw, gh = ffi.new("int32_t *"), ffi.new("int32_t *")
    w = _check.integer(w, "w")
    h = _check.integer(h, "h")
    check("vt_cnn_out_size", lib.vt_cnn_out_size(model.c_model()[0], w, h, gw, gh), f"input {w}x{h}")
    return int(gw[0]), int(gh[0])


def work_bytes(model: CnnModel, w: int, h: int) -> int:
    """vt_cnn_work_bytes: the work buffer a w x h input needs."""
    b = ffi.new("size_t *")
    w = _check.integer(w, "w")
    h = _check.integer(h, "h")
    check("vt_cnn_work_bytes", lib.vt_cnn_work_bytes(model.c_model()[0], w, h, b), f"input {w}x{h}")
    return int(b[0])


SIMD_PATHS = ("portable", "sse2", "avx2", "avx-vnni", "avx512-vnni")


def simd_path() -> str:
    """vt_cnn_simd_path: which inner loops vt_cnn_forward takes in this build on this CPU,
    one of SIMD_PATHS (the same bits on every path, only the speed differs)."""
    p = ffi.new("int32_t *")
    check("vt_cnn_simd_path", lib.vt_cnn_simd_path(p))
    return SIMD_PATHS[int(p[0])]


def forward(model: CnnModel, gray: np.ndarray) -> np.ndarray:
    """vt_cnn_forward: (gh, gw, 5) int8 (heat, then the l, t, r, b side codes) of a uint8 gray
    image (rows may be padded: any row stride, contiguous columns)."""
    g = _gray(gray)
    v = view(g, "gray")              # dtype, ndim and column contiguity; keeps the row stride
    m = model.c_model()[0]
    gw, gh = out_size(model, g.shape[1], g.shape[0])
    nb = work_bytes(model, g.shape[1], g.shape[0])
    work = np.empty(max(nb, 1), np.uint8)
    out = np.empty((gh, gw, OUT_CH), np.int8)
    check("vt_cnn_forward",
          lib.vt_cnn_forward(m, v.px, v.w, v.h, v.stride, ffi.cast("uint8_t *", work.ctypes.data), nb,
                             ffi.cast("int8_t *", out.ctypes.data), out.size),
          f"gray {g.shape}, row stride {v.stride}")
    return out


def decode(model: CnnModel, out: np.ndarray, thr=None, scale_shift: int = 0, cap=None) -> tuple[np.ndarray, int]:
    """vt_cnn_decode: ((N, 5) int32 [l, t, r, b, score] inclusive full-frame px, heat descending,
    ties in raster order; the total number of peaks). thr: None = the model's heat_thr; cap:
    None = every cell (nothing clipped), else at most cap boxes (the total still counts all)."""
    if not isinstance(out, np.ndarray):
        raise TypeError(f"out: expected a numpy.ndarray, got {type(out).__name__}")
    if out.dtype != np.int8:
        raise TypeError(f"out: expected the int8 output of forward, got dtype {out.dtype}")
    if out.ndim != 3 or out.shape[2] != OUT_CH or out.shape[0] < 1 or out.shape[1] < 1:
        raise ValueError(f"out: expected shape (gh, gw, {OUT_CH}) with gh, gw >= 1, got {out.shape}")
    o = np.ascontiguousarray(out)
    gh, gw = o.shape[:2]
    thr = model.heat_thr if thr is None else _check.integer(thr, "thr")
    ss = _check.integer(scale_shift, "scale_shift", 0, MAX_LEVEL)
    cap = gh * gw if cap is None else _check.integer(cap, "cap", 1)
    cap = min(cap, gh * gw)          # no more peaks than cells: no bigger buffer needed
    boxes = ffi.new("vt_cnn_box[]", cap)
    n, tot = ffi.new("int32_t *"), ffi.new("int32_t *")
    check("vt_cnn_decode",
          lib.vt_cnn_decode(model.c_model()[0], ffi.cast("const int8_t *", o.ctypes.data), gw, gh, thr, ss,
                            boxes, cap, n, tot),
          f"out {o.shape}, thr {thr}, scale_shift {ss}, cap {cap}")
    res = np.frombuffer(ffi.buffer(boxes), np.int32).reshape(-1, 5)[:n[0]].copy()
    return res, int(tot[0])


# ---------------------------------------------------------------- frame-level detection
# The file key cnn_cfg: int32 values of these CnnConfig fields, in this order. Files written
# before the level-0 band hold the first CFG_KEYS_OLD only (the rest then take the defaults).
CFG_KEYS = ("first_level", "n_levels", "thr_offset", "cap_per_level", "nms_iou_permille", "nms_contain_permille",
            "l0_top_permille", "l0_bottom_permille", "stretch_tail_permille", "up_top_permille",
            "up_bottom_permille", "up_left_permille", "up_right_permille")
CFG_KEYS_OLD = 6
# the upsampled band's fields (all 0: off)
UP_KEYS = CFG_KEYS[9:]
# the lengths a file's cnn_cfg may have: before the level-0 band, before the contrast stretch,
# before the upsampled band, now
CFG_KEYS_LENGTHS = (CFG_KEYS_OLD, 8, 9, len(CFG_KEYS))


@dataclass(frozen=True)
class CnnConfig:
    """vt_cnn_cfg (cnn.h): the levels the network runs on, the threshold, the per-level cap,
    the NMS over every level's boxes and the rows of level 0 the network runs on (when
    first_level is 0: rows floor(h top / 1000) .. ceil(h bottom / 1000) - 1 of an h-row frame,
    never empty). None fields take the core's default (vt_cnn_cfg_default)."""
    first_level: int | None = None       # 0..MAX_LEVEL - 1 (1 = half size)
    n_levels: int | None = None          # 1..MAX_RUN_LEVELS, first_level + n_levels - 1 <= MAX_LEVEL
    thr_offset: int | None = None        # added to the model's heat_thr (any int32)
    cap_per_level: int | None = None     # 1..MAX_PEAKS peaks decoded per level
    nms_iou_permille: int | None = None  # 0..1000
    nms_contain_permille: int | None = None  # 0..1000
    l0_top_permille: int | None = None   # 0 <= top < bottom <= 1000; default 0
    l0_bottom_permille: int | None = None  # default 1000 (with top 0: the whole frame)
    stretch_tail_permille: int | None = None  # 0 (default): off; 1..100: contrast stretch (cnn.h)
    # the upsampled band (cnn.h): all four 0 (default): off; else 0 <= top < bottom <= 1000 and
    # 0 <= left < right <= 1000, a rectangle of the frame the network also runs on at 2x
    up_top_permille: int | None = None
    up_bottom_permille: int | None = None
    up_left_permille: int | None = None
    up_right_permille: int | None = None

    def c(self):
        """The checked vt_cnn_cfg (a new cffi struct); ValueError / TypeError naming the field."""
        c = ffi.new("vt_cnn_cfg *")
        check("vt_cnn_cfg_default", lib.vt_cnn_cfg_default(c))
        for f in fields(self):
            v = getattr(self, f.name)
            if v is not None:
                setattr(c, f.name, _check.integer(v, f"CnnConfig.{f.name}"))
        if lib.vt_cnn_cfg_check(c) != lib.VT_OK:
            raise ValueError(f"CnnConfig: {self._why(c)}")
        return c

    @staticmethod
    def _why(c) -> str:
        fl, nl = int(c.first_level), int(c.n_levels)
        if not 0 <= fl <= MAX_LEVEL - 1:
            return f"first_level = {fl} is outside [0, {MAX_LEVEL - 1}]"
        if not 1 <= nl <= MAX_RUN_LEVELS:
            return f"n_levels = {nl} is outside [1, {MAX_RUN_LEVELS}]"
        if fl + nl - 1 > MAX_LEVEL:
            return f"first_level + n_levels - 1 = {fl + nl - 1} is past the deepest level {MAX_LEVEL}"
        if not 1 <= int(c.cap_per_level) <= MAX_PEAKS:
            return f"cap_per_level = {int(c.cap_per_level)} is outside [1, {MAX_PEAKS}]"
        for k in ("nms_iou_permille", "nms_contain_permille"):
            if not 0 <= int(getattr(c, k)) <= 1000:
                return f"{k} = {int(getattr(c, k))} is outside [0, 1000]"
        top, bot = int(c.l0_top_permille), int(c.l0_bottom_permille)
        if not 0 <= top <= 999:
            return f"l0_top_permille = {top} is outside [0, 999]"
        if not 1 <= bot <= 1000:
            return f"l0_bottom_permille = {bot} is outside [1, 1000]"
        if top >= bot:
            return (f"l0_top_permille = {top} must be below l0_bottom_permille = {bot} "
                    f"(level 0's band would be empty)")
        if not 0 <= int(c.stretch_tail_permille) <= 100:
            return f"stretch_tail_permille = {int(c.stretch_tail_permille)} is outside [0, 100]"
        if up_band_on(c):
            for a, b in (("top", "bottom"), ("left", "right")):
                lo, hi = int(getattr(c, f"up_{a}_permille")), int(getattr(c, f"up_{b}_permille"))
                if not 0 <= lo < hi <= 1000:
                    return (f"the upsampled band needs 0 <= up_{a}_permille < up_{b}_permille <= 1000, "
                            f"got {lo} and {hi} (all four 0 turns it off)")
            if (nl + 1) * int(c.cap_per_level) > int(lib.VT_MAX_NMS_BOXES):
                return (f"(n_levels + 1) x cap_per_level = {(nl + 1) * int(c.cap_per_level)} (levels and the "
                        f"upsampled band) exceeds VT_MAX_NMS_BOXES ({int(lib.VT_MAX_NMS_BOXES)})")
        return (f"n_levels x cap_per_level = {nl * int(c.cap_per_level)} exceeds VT_MAX_NMS_BOXES "
                f"({int(lib.VT_MAX_NMS_BOXES)})")

    @classmethod
    def from_c(cls, c) -> "CnnConfig":
        return cls(**{f.name: int(getattr(c, f.name)) for f in fields(cls)})


def up_band_on(c) -> bool:
    """True when a vt_cnn_cfg (cffi) or CnnConfig runs the upsampled band: any of UP_KEYS nonzero
    (cnn.h; a CnnConfig's None is the default, 0)."""
    return any(int(getattr(c, k) or 0) for k in UP_KEYS)


def at_horizon(cfg: "CnnConfig | None", horizon_q16: int) -> CnnConfig:
    """cfg's bands placed for a camera whose horizon lies at horizon_q16 (Q16 share of the frame
    height, -65536..65536; e.g. fullroad.Camera's horizon_frac x 65536), by
    vt_cnn_cfg_at_horizon (cnn.h): they move by the horizon's distance from the default road
    camera's (VT_CNN_REF_HORIZON_Q16, 330 / 720), keeping their heights. The pipeline does this
    itself with its road camera; this is for a caller of detect_frame with another camera."""
    c = _cfg(cfg)
    hz = _check.integer(horizon_q16, "horizon_q16 (Q16 share of the height)", -65536, 65536)
    out = ffi.new("vt_cnn_cfg *")
    check("vt_cnn_cfg_at_horizon", lib.vt_cnn_cfg_at_horizon(c, hz, out))
    return CnnConfig.from_c(out)


def _cfg(cfg) -> object:
    if cfg is None:
        cfg = CnnConfig()
    if not isinstance(cfg, CnnConfig):
        raise TypeError(f"cfg: expected a pyvehtrack.cnn.CnnConfig or None, got {type(cfg).__name__}")
    return cfg.c()


def _model(model) -> CnnModel:
    if not isinstance(model, CnnModel):
        raise TypeError(f"model: expected a pyvehtrack.cnn.CnnModel, got {type(model).__name__}")
    return model


def frame_work_bytes(model: CnnModel, w: int, h: int, cfg: CnnConfig | None = None) -> int:
    """vt_cnn_frame_work_bytes: the work buffer detect_frame needs for a w x h frame."""
    b = ffi.new("size_t *")
    c = _cfg(cfg)
    w = _check.integer(w, "w")
    h = _check.integer(h, "h")
    check("vt_cnn_frame_work_bytes", lib.vt_cnn_frame_work_bytes(_model(model).c_model()[0], c, w, h, b),
          f"frame {w}x{h}")
    return int(b[0])


def detect_frame(model: CnnModel, gray: np.ndarray, cfg: CnnConfig | None = None) -> tuple[np.ndarray, int]:
    """vt_cnn_detect_frame: ((N, 5) int32 [l, t, r, b, heat] inclusive frame px, clipped to the
    frame, in NMS order over the pyramid levels cfg names; the peaks over those levels before
    the per-level cap, the clipping and the NMS). gray: a uint8 (h, w) image (any row stride,
    contiguous columns)."""
    m = _model(model).c_model()[0]
    c = _cfg(cfg)
    g = _gray(gray)
    v = view(g, "gray")
    b = ffi.new("size_t *")
    check("vt_cnn_frame_work_bytes", lib.vt_cnn_frame_work_bytes(m, c, v.w, v.h, b), f"gray {g.shape}")
    nb = int(b[0])
    work = np.empty(nb, np.uint8)
    # NMS keeps no more than it is given: every level's and the upsampled band's cap
    cap = (int(c.n_levels) + up_band_on(c)) * int(c.cap_per_level)
    boxes = ffi.new("vt_cnn_box[]", cap)
    n, tot = ffi.new("int32_t *"), ffi.new("int32_t *")
    check("vt_cnn_detect_frame",
          lib.vt_cnn_detect_frame(m, c, v.px, v.w, v.h, v.stride, ffi.cast("uint8_t *", work.ctypes.data), nb,
                                  boxes, cap, n, tot),
          f"gray {g.shape}, row stride {v.stride}")
    res = np.frombuffer(ffi.buffer(boxes), np.int32).reshape(-1, 5)[:n[0]].copy()
    return res, int(tot[0])


def is_cnn(path_or_npz) -> bool:
    """True when a model file (a path or an opened .npz / mapping) is a CNN model: it has
    cnn_n_layers and every key starts with cnn_. A path that is not a readable .npz is not."""
    if isinstance(path_or_npz, CnnModel):
        return True
    if isinstance(path_or_npz, (str, Path)):
        p = Path(path_or_npz)
        if not p.is_file():
            return False
        try:
            with np.load(p, allow_pickle=False) as z:
                keys = set(z.files) if hasattr(z, "files") else set()
        except (OSError, ValueError):
            return False
    elif hasattr(path_or_npz, "files"):
        keys = set(path_or_npz.files)
    elif hasattr(path_or_npz, "keys"):
        keys = set(path_or_npz.keys())
    else:
        return False
    return "cnn_n_layers" in keys and all(str(k).startswith("cnn_") for k in keys)
