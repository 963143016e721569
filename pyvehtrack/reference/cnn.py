"""Integer twin of the quantised CNN detector (include/vehtrack/cnn.h, c/cnn.c): the appearance
stage as a CenterNet-style heat map + box sides at the model's output stride, in place of the
GIST paper's sliding-window classifier (sec. III).

Unlike the float oracles beside it, this one is the C's arithmetic written again in NumPy
int64 from cnn.h's definitions (zero-padded convolution as a sum of shifted slices, the
requantisation floor((acc mult + 2^(shift-1)) / 2^shift), the clamps, the peak rule and the
Q4 box decode), so the tests hold the two to 0 LSB. A layer is a dict (or any object with
the same keys as attributes): ksize, stride, dilation, relu, w (cout, k, k, cin) int8,
bias, mult (cout,) int32, shift (cout,) uint8.
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
    """(boxes (N, 5) int64 [l, t, r, b, score], inclusive full-frame px; the number of peaks)."""
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
        px = [((int(v) << scale_shift) + 8) >> 4 for v in q4]
        res[i] = (px[0], px[1], px[2] - 1, px[3] - 1, c[0])
    return res, total
