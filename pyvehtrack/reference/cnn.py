"""Integer twin of the quantised CNN detector (include/vehtrack/cnn.h, c/cnn.c): the appearance
stage as a CenterNet-style heat map + box sides at the model's output stride, in place of the
GIST paper's sliding-window classifier (sec. III).

Unlike the float oracles beside it, this one is the C's arithmetic written again in NumPy
int64 from cnn.h's definitions (zero-padded convolution as a sum of shifted slices, the
requantisation floor((acc mult + 2^(shift-1)) / 2^shift), the clamps, the peak rule and the
Q4 box decode), so the tests hold the two to 0 LSB. A layer is a dict (or any object with
the same keys as attributes): ksize, stride, dilation, relu, w (cout, k, k, cin) int8,
bias, mult (cout,) int32, shift (cout,) uint8.

detect_frame is vt_cnn_detect_frame: the pyramid from reference.image.pyr_down (exact: its
float sums of 1/256 steps are exact in float64, then rounded half up as the C), forward and
decode per level (level 0 on its row band only, the boxes moved down by the band's first row),
clipping to the frame, and greedy NMS with reference.windows.suppresses (the permille test of
c/windows.c) after a stable sort by heat.
"""
from __future__ import annotations

import numpy as np

OUT_CH = 5


def _get(layer, key):
    return layer[key] if isinstance(layer, dict) else getattr(layer, key)


def out_size(layers, w: int, h: int) -> tuple[int, int]:
    """(gw, gh): each layer's output is ceil(in / stride) per axis."""
    for L in layers:
        s = int(_get(L, "stride"))
        w, h = (w + s - 1) // s, (h + s - 1) // s
    return w, h


def accumulate(a: np.ndarray, layer) -> np.ndarray:
    """acc = bias + the zero-padded convolution of an (h, w, cin) activation: (oh, ow, cout) int64."""
    k, s, d = int(_get(layer, "ksize")), int(_get(layer, "stride")), int(_get(layer, "dilation"))
    w = np.asarray(_get(layer, "w"), np.int64)
    bias = np.asarray(_get(layer, "bias"), np.int64)
    h, wd, cin = a.shape
    cout = w.shape[0]
    oh, ow = (h + s - 1) // s, (wd + s - 1) // s
    pad = d * (k // 2)
    ap = np.zeros((h + 2 * pad, wd + 2 * pad, cin), np.int64)
    ap[pad:pad + h, pad:pad + wd] = a
    acc = np.broadcast_to(bias, (oh, ow, cout)).copy()
    for ky in range(k):
        for kx in range(k):
            # output (ox, oy) reads input (ox s + (kx - k//2) d, ...): padded (ox s + kx d, ...)
            tap = ap[ky * d:ky * d + (oh - 1) * s + 1:s, kx * d:kx * d + (ow - 1) * s + 1:s]
            acc += (tap.reshape(-1, cin) @ w[:, ky, kx, :].T).reshape(oh, ow, cout)
    return acc


def requantise(acc: np.ndarray, layer) -> np.ndarray:
    """floor((acc mult + 2^(shift-1)) / 2^shift), clamped: uint8 0..255 (relu) or int8 (last)."""
    mult = np.asarray(_get(layer, "mult"), np.int64)
    shift = np.asarray(_get(layer, "shift"), np.int64)
    q = (acc * mult + (np.int64(1) << (shift - 1))) >> shift    # NumPy's >> on int64 is a floor
    if int(_get(layer, "relu")):
        return np.clip(q, 0, 255).astype(np.uint8)
    return np.clip(q, -128, 127).astype(np.int8)


def conv_layer(a: np.ndarray, layer) -> np.ndarray:
    """One layer on an (h, w, cin) activation -> (oh, ow, cout) uint8 (relu) or int8 (the last)."""
    return requantise(accumulate(a, layer), layer)


def forward(layers, img: np.ndarray) -> np.ndarray:
    """The forward pass over a 2-D uint8 image -> (gh, gw, 5) int8."""
    a = np.asarray(img, np.uint8)[:, :, None]
    for L in layers:
        a = conv_layer(a, L)
    return a


def peaks(out: np.ndarray, thr: int) -> np.ndarray:
    """(N, 2) [y, x] of the peaks of out[..., 0] (heat >= thr and >= every in-grid
    neighbour), heat descending, ties in raster order."""
    heat = out[..., 0].astype(np.int64)
    gh, gw = heat.shape
    hp = np.full((gh + 2, gw + 2), -(1 << 20), np.int64)
    hp[1:-1, 1:-1] = heat
    nb = np.full_like(heat, -(1 << 20))
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy or dx:
                nb = np.maximum(nb, hp[1 + dy:1 + dy + gh, 1 + dx:1 + dx + gw])
    ys, xs = np.nonzero((heat >= thr) & (heat >= nb))     # raster order
    order = np.argsort(-heat[ys, xs], kind="stable")
    return np.stack([ys[order], xs[order]], axis=1)


def decode(out: np.ndarray, out_stride: int, side_lut: np.ndarray, thr: int, scale_shift: int = 0,
           cap: int | None = None) -> tuple[np.ndarray, int]:
    """(boxes (N, 5) int64 [l, t, r, b, score], inclusive full-frame px; the number of peaks).
    scale_shift -1 is the upsampled band's (cnn.h): each Q4 value v becomes floor((v + 16) / 32)."""
    p = peaks(out, thr)
    total = len(p)
    if cap is not None:
        p = p[:cap]
    lut = np.asarray(side_lut, np.int64).reshape(4, 256)
    S = int(out_stride)
    res = np.zeros((len(p), 5), np.int64)
    for i, (y, x) in enumerate(p):
        c = out[y, x].astype(np.int64)
        cx, cy = (int(x) * S + S // 2) * 16, (int(y) * S + S // 2) * 16
        q4 = (cx - lut[0, c[1] + 128], cy - lut[1, c[2] + 128], cx + lut[2, c[3] + 128],
              cy + lut[3, c[4] + 128])
        px = [((int(v) << scale_shift) + 8) >> 4 if scale_shift >= 0 else (int(v) + 16) >> 5 for v in q4]
        res[i] = (px[0], px[1], px[2] - 1, px[3] - 1, c[0])
    return res, total


# The level-0 band's fields a cfg may leave out (a dict or object written before they
# existed): the whole frame, as VT_CNN_CFG_DEFAULT and an old 6-entry cnn_cfg file.
_BAND_DEFAULTS = {"l0_top_permille": 0, "l0_bottom_permille": 1000, "stretch_tail_permille": 0,
                  "up_top_permille": 0, "up_bottom_permille": 0, "up_left_permille": 0, "up_right_permille": 0}
_UP_KEYS = ("up_top_permille", "up_bottom_permille", "up_left_permille", "up_right_permille")

# cnn.h's VT_CNN_STRETCH_MIN_SPAN
STRETCH_MIN_SPAN = 64


def stretch(img: np.ndarray, tail_permille: int) -> np.ndarray:
    """vt_cnn_cfg.stretch_tail_permille's contrast stretch (cnn.h), in exact integers: the
    least level lo with more than k = floor(n tail / 1000) pixels at or below it, the greatest hi
    with more than k at or above it, span = max(hi - lo, 64); x -> 0 at or below lo, else
    min(255, floor(((x - lo) 510 + span) / (2 span)))."""
    g = np.asarray(img, np.uint8)
    hist = np.bincount(g.ravel(), minlength=256).astype(np.int64)
    k = g.size * int(tail_permille) // 1000
    lo = int(np.argmax(np.cumsum(hist) > k))
    hi = 255 - int(np.argmax(np.cumsum(hist[::-1]) > k))
    span = max(hi - lo, STRETCH_MIN_SPAN)
    d = np.arange(256, dtype=np.int64) - lo
    lut = np.where(d <= 0, 0, np.minimum(255, (d * 510 + span) // (2 * span))).astype(np.uint8)
    return lut[g]


def _cfg_get(cfg, key):
    v = (cfg.get(key) if isinstance(cfg, dict) else getattr(cfg, key, None))
    if v is None and key in _BAND_DEFAULTS:     # absent, or a CnnConfig's None: the core's default
        return _BAND_DEFAULTS[key]
    return int(v)


def band_rows(h: int, top_permille: int, bottom_permille: int) -> tuple[int, int]:
    """(y0, y1): level 0's band rows y0 .. y1 - 1 of an h-row frame (cnn.h), exact integers:
    y0 = floor(h top / 1000), y1 = ceil(h bottom / 1000). Never empty for 0 <= top < bottom
    <= 1000 and h >= 1 (y1 >= h bottom / 1000 > h top / 1000 >= y0)."""
    return (h * top_permille) // 1000, (h * bottom_permille + 999) // 1000


# cnn.h's VT_CNN_REF_HORIZON_Q16: the default road camera's horizon, 330 / 720 of the height
REF_HORIZON_Q16 = 30037


def at_horizon(cfg, horizon_q16: int) -> dict:
    """vt_cnn_cfg_at_horizon (cnn.h) on a cfg (dict or object with CnnConfig's fields): the
    fields as a dict with level 0's band and, when on, the upsampled band moved by
    d = round_half_up((horizon_q16 - REF_HORIZON_Q16) 1000 / 65536) permille, each keeping its
    height and stopped at the frame's edges. Python's // floors, as the C's shifted division."""
    keys = ("first_level", "n_levels", "thr_offset", "cap_per_level", "nms_iou_permille",
            "nms_contain_permille") + tuple(_BAND_DEFAULTS)
    out = {k: _cfg_get(cfg, k) for k in keys}
    d = ((int(horizon_q16) - REF_HORIZON_Q16) * 1000 + 32768) // 65536
    pairs = [("l0_top_permille", "l0_bottom_permille")]
    if any(out[k] for k in _UP_KEYS):
        pairs.append(("up_top_permille", "up_bottom_permille"))
    for top, bottom in pairs:
        span = out[bottom] - out[top]
        out[top] = max(0, min(out[top] + d, 1000 - span))
        out[bottom] = out[top] + span
    return out


def upsample2x(img: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
    """vt_cnn_cfg's upsampled band (cnn.h): the frame's columns x0 .. x1 - 1 and rows y0 .. y1 - 1
    at twice the size, bilinear with the pixel centres of cv2.INTER_LINEAR (output j samples
    x0 + j / 2 - 1/4): out j of source c = x0 + floor(j / 2) weighs c 3/4 and its neighbour
    (c - 1 for even j, c + 1 for odd; clamped to the frame, not to the band) 1/4, per axis;
    out = floor((sum of the 4 weights (1, 3, 3, 9) x pixel + 8) / 16), exact integers."""
    g = np.asarray(img, np.uint8).astype(np.int32)
    h, w = g.shape

    def taps(a, b, n):
        j = np.arange(2 * (b - a))
        c = a + j // 2
        return c, np.clip(np.where(j % 2 == 0, c - 1, c + 1), 0, n - 1)

    cx, nx = taps(x0, x1, w)
    cy, ny = taps(y0, y1, h)
    rows = 3 * g[cy] + g[ny]                      # (2 (y1 - y0), w), weights 3 / 1 by row
    out = 3 * rows[:, cx] + rows[:, nx]
    return ((out + 8) >> 4).astype(np.uint8)


def up_rect(h: int, w: int, top: int, bottom: int, left: int, right: int) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1): the upsampled band's source rectangle of an h x w frame (cnn.h), rows and
    columns with level 0's band rounding (band_rows)."""
    y0, y1 = band_rows(h, top, bottom)
    x0, x1 = band_rows(w, left, right)
    return x0, y0, x1, y1


def level_inputs(img: np.ndarray, cfg):
    """The network's inputs of vt_cnn_detect_frame, in its order: (k, dx, dy, image) per level
    k = first_level .. first_level + n_levels - 1, built from the frame after the cfg's stretch
    (level 0 is its row band, dy its first row; other levels whole, dx = dy = 0); then, with the
    upsampled band on, (-1, x0, y0, its 2x image): k is the decode's scale shift."""
    from . import image as rimage     # noqa: PLC0415
    first, nl = _cfg_get(cfg, "first_level"), _cfg_get(cfg, "n_levels")
    g = np.asarray(img, np.uint8)
    tail = _cfg_get(cfg, "stretch_tail_permille")
    if tail > 0:
        g = stretch(g, tail)
    y0, y1 = band_rows(g.shape[0], _cfg_get(cfg, "l0_top_permille"), _cfg_get(cfg, "l0_bottom_permille"))
    level = g
    for k in range(first + nl):
        if k > 0:
            level = rimage.pyr_down(level)     # from the whole frame: the band is level 0's only
        if k >= first:
            yield k, 0, (y0 if k == 0 else 0), (level[y0:y1] if k == 0 else level)
    up = [_cfg_get(cfg, k) for k in _UP_KEYS]
    if any(up):
        r = up_rect(*g.shape, *up)
        yield -1, r[0], r[1], upsample2x(g, *r)


def merge_levels(rows, w: int, h: int, cfg) -> np.ndarray:
    """vt_cnn_detect_frame's last step: rows (l, t, r, b, heat) in full-frame px, in level then
    decode order, clipped to the w x h frame (empty ones dropped), then one NMS by heat
    (stable: level, then decode order) with the cfg's limits. (N, 5) int64."""
    from . import windows as rw       # noqa: PLC0415
    clipped = []
    for l, t, r, bt, sc in rows:
        l, t, r, bt = max(l, 0), max(t, 0), min(r, w - 1), min(bt, h - 1)
        if l <= r and t <= bt:
            clipped.append((l, t, r, bt, sc))
    order = sorted(range(len(clipped)), key=lambda i: -clipped[i][4])
    iou, con = _cfg_get(cfg, "nms_iou_permille"), _cfg_get(cfg, "nms_contain_permille")
    kept = []
    for i in order:
        if not any(rw.suppresses(clipped[j][:4], clipped[i][:4], iou, con) for j in kept):
            kept.append(i)
    return np.array([clipped[i] for i in kept], np.int64).reshape(-1, 5)


def detect_frame(model, img: np.ndarray, cfg) -> tuple[np.ndarray, int]:
    """vt_cnn_detect_frame (cnn.h). model: an object with layers, out_stride, side_lut,
    heat_thr (e.g. pyvehtrack.cnn.CnnModel); cfg: every vt_cnn_cfg field as an attribute or a
    key (first_level, n_levels, thr_offset, cap_per_level, nms_iou_permille,
    nms_contain_permille, l0_top_permille, l0_bottom_permille, stretch_tail_permille, up_*_permille),
    none left to defaults but the band's, the stretch's and the upsampled band's (absent: 0 and 1000,
    the whole frame; 0, no stretch; 0, no upsampled band). Returns ((N, 5) int64 [l, t, r, b, heat]
    in NMS order, the peaks over the levels before cap, clipping and NMS)."""
    cap = _cfg_get(cfg, "cap_per_level")
    thr = min(max(int(model.heat_thr) + _cfg_get(cfg, "thr_offset"), -128), 128)
    h, w = np.asarray(img).shape[:2]
    rows, total = [], 0
    for k, dx, dy, level in level_inputs(img, cfg):
        b, n = decode(forward(model.layers, level), model.out_stride, model.side_lut, thr, k, cap)
        total += n
        rows += [(l + dx, t + dy, r + dx, bt + dy, sc) for l, t, r, bt, sc in b.tolist()]
    return merge_levels(rows, w, h, cfg), total
