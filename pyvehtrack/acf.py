"""The ACF first stage from Python (issue 8; C: include/vehtrack/acf.h).

Aggregated channel features on a quarter-octave pyramid scored by boosted trees
(GIST paper sec. III's sliding windows + classifier, IVVI paper sec. 4/5's
flat-road band). The model file is an .npz with kind "acf" (written by
tools/train_acf.py): the trees as full binary trees of `depth` levels, thresholds
and feature indices in the C core's channel bytes, leaves in Q16 and as floats.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._check import npz_file
from ._native import SCORED_BOX_DTYPE, _defaults, camera_min, check, ffi, lib, view

NCH = 8
SCALE_Q16 = (65536, 77936, 92682, 110218, 131072, 155872, 185364, 220436, 262144, 311744, 370728,
             440872, 524288, 623487, 741455, 881744)


MAX_MODELS = int(lib.VT_ACF_MAX_MODELS)


def level_size(n: int, r_q16: int) -> int:
    return (int(n) << 16) // int(r_q16)


def cfg_default():
    return _defaults("vt_acf_cfg")


_WS = None


def _ws():
    """One scratch per process (the C functions keep nothing in it between calls)."""
    global _WS
    if _WS is None:
        _WS = ffi.new("vt_acf_ws *")
    return _WS


def _gray(img: np.ndarray, name: str) -> np.ndarray:
    if not isinstance(img, np.ndarray):
        raise TypeError(f"{name}: expected a numpy.ndarray, got {type(img).__name__}")
    if img.dtype != np.uint8:
        raise TypeError(f"{name}: expected a uint8 gray image, got dtype {img.dtype}")
    if img.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D gray image (h, w), got shape {img.shape}")
    return np.ascontiguousarray(img)


def resample(gray: np.ndarray, k: int) -> np.ndarray:
    """Level k of the pyramid (vt_acf_resample, all rows)."""
    g = _gray(gray, "resample")
    if not 0 <= int(k) < len(SCALE_Q16):
        raise ValueError(f"resample: level k must be 0..{len(SCALE_Q16) - 1}, got {k}")
    r = SCALE_Q16[int(k)]
    lw, lh = level_size(g.shape[1], r), level_size(g.shape[0], r)
    if lw < 1 or lh < 1:
        raise ValueError(f"resample: a {g.shape[1]}x{g.shape[0]} image has no level {k} (it would be {lw}x{lh})")
    out = np.zeros((lh, lw), np.uint8)
    check("vt_acf_resample", lib.vt_acf_resample(_ws(), view(g, "src"), r, 0, view(out, "dst", writable=True)),
          f"src {g.shape}, level {k}")
    return out


def channels(gray: np.ndarray, cy0: int = 0, n_cy: int | None = None) -> np.ndarray:
    """vt_acf_channels: (8, n_cy, w // 4) uint8 channel bytes of cell rows cy0.."""
    g = _gray(gray, "channels")
    if g.shape[0] < 4 or g.shape[1] < 4:
        raise ValueError(f"channels: the image must be at least 4x4 px, got {g.shape[1]}x{g.shape[0]}")
    n = g.shape[0] // 4 - cy0 if n_cy is None else int(n_cy)
    out = np.zeros((NCH, max(n, 1), g.shape[1] // 4), np.uint8)
    check("vt_acf_channels", lib.vt_acf_channels(_ws(), view(g, "img"), int(cy0), n,
                                                 ffi.cast("uint8_t *", out.ctypes.data), out.size),
          f"img {g.shape}, cell rows {cy0}+{n}")
    return out


@dataclass
class AcfModel:
    """A tree ensemble over one window's channel bytes (vt_acf_model) and its detector settings."""
    win_cw: int
    win_ch: int
    pad: int
    depth: int
    feat: np.ndarray        # (T, 2^d - 1) uint16
    thr: np.ndarray         # (T, 2^d - 1) uint8
    leaf: np.ndarray        # (T, 2^d) float64 (the trained values)
    leaf_q16: np.ndarray    # (T, 2^d) int32
    bias: float
    reject_q16: np.ndarray | None = None   # (T,) int32
    score_min_q16: int = 0
    path: str = ""
    band_mm: tuple | None = None   # its band's box widths (veh_w_min_mm, veh_w_max_mm); None: acf.h's
    nms_contain_permille: int = 1000   # the detector's NMS containment limit (the first model's counts)
    cols: int = 0           # vt_acf_cfg.cols: 0 every window column, 1 / 2 only the left / right edge's
    first_scale: int = 0    # vt_acf_cfg.first_scale: its first pyramid level (levels first_scale..14)
    more: list = field(default_factory=list)   # further models on the same pyramid (vt_acf_detect_n)
    # what the whole-road detector reads from any model file (fullroad.load_model fills them)
    settings: dict = field(default_factory=dict)
    wide: object = None
    refine: object = None
    scan_sizes: tuple = ()

    @property
    def win_w(self) -> int:
        """The box width at level 0 (px): the window less its pad."""
        return 4 * (self.win_cw - 2 * self.pad)

    @property
    def win_h(self) -> int:
        return 4 * (self.win_ch - 2 * self.pad)

    @property
    def threshold_q16(self) -> int:
        return int(self.score_min_q16)

    @property
    def n_trees(self) -> int:
        return int(self.feat.shape[0])

    @property
    def bias_q16(self) -> int:
        return int(np.floor(self.bias * 65536 + 0.5))

    @classmethod
    def load(cls, path) -> "AcfModel":
        """A model file: one tree ensemble under plain keys, and up to VT_ACF_MAX_MODELS - 1
        more (other windows on the same pyramid) under the prefixes acf1_, acf2_, ..."""
        p = Path(path)
        if not p.is_file():
            raise FileNotFoundError(f"ACF model {p} does not exist")
        npz_file(p, "ACF model")
        z = np.load(p, allow_pickle=False)
        kind = str(z["kind"]) if "kind" in z.files else ""
        if kind != "acf":
            raise ValueError(f"{p}: not an ACF model (kind {kind!r})")
        m = cls._from_keys(z, "", p)
        for i in range(1, MAX_MODELS):
            if f"acf{i}_feat" in z.files:
                m.more.append(cls._from_keys(z, f"acf{i}_", p))
            elif any(k.startswith(f"acf{i}_") for k in z.files):
                raise ValueError(f"{p}: ACF model {i} (keys acf{i}_*) lacks acf{i}_feat")
        return m

    @classmethod
    def _from_keys(cls, z, pre: str, p: Path) -> "AcfModel":
        need = ("win_cw", "win_ch", "pad", "depth", "feat", "thr", "leaf", "leaf_q16", "bias")
        miss = [pre + k for k in need if pre + k not in z.files]
        if miss:
            raise ValueError(f"{p}: ACF model lacks {', '.join(miss)}")
        rej = z[pre + "reject_q16"].astype(np.int32) if pre + "reject_q16" in z.files \
            and z[pre + "reject_q16"].size else None
        band = None
        if pre + "band_mm" in z.files:
            b = np.asarray(z[pre + "band_mm"]).ravel()
            if b.size != 2:
                raise ValueError(f"{p}: {pre}band_mm must hold 2 widths (mm), got {b.size} values")
            band = (int(b[0]), int(b[1]))
        m = cls(int(z[pre + "win_cw"]), int(z[pre + "win_ch"]), int(z[pre + "pad"]), int(z[pre + "depth"]),
                z[pre + "feat"].astype(np.uint16), z[pre + "thr"].astype(np.uint8), z[pre + "leaf"].astype(np.float64),
                z[pre + "leaf_q16"].astype(np.int32), float(z[pre + "bias"]), rej,
                int(z[pre + "score_min_q16"]) if pre + "score_min_q16" in z.files else 0, str(p), band,
                int(z[pre + "nms_contain_permille"]) if pre + "nms_contain_permille" in z.files else 1000,
                int(z[pre + "cols"]) if pre + "cols" in z.files else 0,
                int(z[pre + "first_scale"]) if pre + "first_scale" in z.files else 0)
        m.c_model()  # the core's check
        m.c_cfg()    # and the band's
        return m

    def keys(self, pre: str = "") -> dict:
        """This model's arrays under the file's key names (prefix pre), without the more models."""
        d = dict(win_cw=self.win_cw, win_ch=self.win_ch, pad=self.pad, depth=self.depth, feat=self.feat,
                 thr=self.thr, leaf=self.leaf, leaf_q16=self.leaf_q16, bias=self.bias,
                 reject_q16=self.reject_q16 if self.reject_q16 is not None else np.zeros(0, np.int32),
                 score_min_q16=self.score_min_q16, nms_contain_permille=self.nms_contain_permille)
        if self.cols:
            d["cols"] = np.int32(self.cols)
        if self.first_scale:
            d["first_scale"] = np.int32(self.first_scale)
        if self.band_mm is not None:
            d["band_mm"] = np.array(self.band_mm, np.int32)
        return {pre + k: v for k, v in d.items()}

    def save(self, path, **extra) -> None:
        d = self.keys()
        for i, mm in enumerate(self.more, 1):
            d.update(mm.keys(f"acf{i}_"))
        np.savez_compressed(path, kind="acf", **d, **extra)

    def c_cfg(self, score_offset_q16: int = 0):
        """vt_acf_cfg for this model: acf.h's defaults, its band, threshold (+ an offset), NMS
        containment limit, columns and first level (to acf.h's last default level); checked."""
        c = cfg_default()
        if self.first_scale:   # a window for near vehicles starts at a coarser level
            c.first_scale, c.n_scales = int(self.first_scale), max(1, int(c.n_scales) - int(self.first_scale))
        if self.band_mm is not None:
            c.veh_w_min_mm, c.veh_w_max_mm = self.band_mm
        c.score_min = int(np.clip(self.score_min_q16 + int(score_offset_q16), -2 ** 31, 2 ** 31 - 1))
        c.nms_contain_permille = int(self.nms_contain_permille)
        c.cols = int(self.cols)
        check("vt_acf_cfg_check", lib.vt_acf_cfg_check(c),
              f"band {self.band_mm}, nms_contain_permille {self.nms_contain_permille}, cols {self.cols}, "
              f"first_scale {self.first_scale}")
        return c

    def c_model(self):
        """The vt_acf_model (checked by the core) and its keepalive; cached."""
        if getattr(self, "_c", None) is not None:
            return self._c
        n_in, n_leaf = (1 << self.depth) - 1, 1 << self.depth
        if self.feat.shape != (self.n_trees, n_in) or self.thr.shape != self.feat.shape \
                or self.leaf_q16.shape != (self.n_trees, n_leaf):
            raise ValueError(f"ACF model: feat {self.feat.shape}, thr {self.thr.shape}, leaf_q16 "
                             f"{self.leaf_q16.shape} do not fit {self.n_trees} trees of depth {self.depth}")
        m = ffi.new("vt_acf_model *")
        keep = [ffi.new("uint16_t[]", self.feat.ravel().tolist()), ffi.new("uint8_t[]", self.thr.ravel().tolist()),
                ffi.new("int32_t[]", self.leaf_q16.ravel().tolist())]
        m.win_cw, m.win_ch, m.pad, m.n_trees, m.depth = self.win_cw, self.win_ch, self.pad, self.n_trees, self.depth
        m.feat, m.thr, m.leaf = keep
        if self.reject_q16 is not None:
            keep.append(ffi.new("int32_t[]", self.reject_q16.tolist()))
            m.reject = keep[-1]
        m.bias_q16 = self.bias_q16
        check("vt_acf_model_check", lib.vt_acf_model_check(m),
              f"{self.n_trees} trees of depth {self.depth}, window {self.win_cw}x{self.win_ch} cells")
        self._c = (m, keep)
        return self._c

    def score_c(self, ch: np.ndarray, cx: int, cy: int) -> int:
        """vt_acf_score: the full sum (Q16) at window (cx, cy) of channel planes ch (8, rows, cols)."""
        ch = np.ascontiguousarray(ch, dtype=np.uint8)
        out = ffi.new("int32_t *")
        check("vt_acf_score", lib.vt_acf_score(self.c_model()[0], ffi.cast("uint8_t *", ch.ctypes.data),
                                               ch.shape[1], ch.shape[2], int(cx), int(cy), out),
              f"planes {ch.shape}, window ({cx}, {cy})")
        return int(out[0])


def detect(model: AcfModel, gray: np.ndarray, horizon_y: int, hood_y: int, fx: float,
           height_mm: int = 1800, cfg=None) -> tuple[np.ndarray, dict]:
    """vt_acf_detect_n on one gray frame with the model and its more models -> (SCORED_BOX_DTYPE
    boxes, counters). cfg: None (each model's own c_cfg()), one vt_acf_cfg for the first model
    (the others keep theirs), or a list with one per model."""
    g = _gray(gray, "detect")
    models = [model] + list(model.more)
    if cfg is None:
        cfgs = [m.c_cfg() for m in models]
    elif isinstance(cfg, (list, tuple)):
        if len(cfg) != len(models):
            raise ValueError(f"detect: {len(cfg)} cfgs for {len(models)} models")
        cfgs = list(cfg)
    else:
        cfgs = [cfg] + [m.c_cfg() for m in models[1:]]
    cam = camera_min(fx, int(horizon_y), int(height_mm), int(hood_y))
    res = ffi.new("vt_fulldet_result *")
    mp = ffi.new("vt_acf_model *[]", [m.c_model()[0] for m in models])
    cp = ffi.new("vt_acf_cfg *[]", cfgs)
    check("vt_acf_detect_n", lib.vt_acf_detect_n(_ws(), len(models), mp, cp, cam, view(g, "img"), res),
          f"img {g.shape}, horizon {horizon_y}, hood {hood_y}, {len(models)} models")
    boxes = np.frombuffer(ffi.buffer(res.box), SCORED_BOX_DTYPE)[:res.n_boxes].copy()
    return boxes, {"n_windows": res.n_windows, "n_window_hits": res.n_window_hits, "n_cand": res.n_cand,
                   "n_cand_dropped": res.n_cand_dropped}
