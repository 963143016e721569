"""Float oracle of the ACF first stage (include/vehtrack/acf.h; issue 8, after Dollar et
al.'s aggregated channel features, in the GIST paper's sliding-window frame, sec. III).

Written from the header's definitions with NumPy / OpenCV in float64, not from the C:
the area resampling as weight matrices, the smoothing with cv2.sepFilter2D, the
orientation from np.arctan2, the normalisation and cell smoothing as real
divisions. Where the header says floor (the gradient magnitude), the oracle takes
the floor of the float value too (exact for integers below 2^52), so the only
differences from the C are its integer floors in the normalisation and the final
rounding: tests state the tolerance that follows.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..acf import NCH, SCALE_Q16, level_size


def resample_weights(n: int, r_q16: int) -> np.ndarray:
    """(level_size(n), n) float: row x = the overlap of [x r, (x + 1) r) with each input px, / r."""
    r = r_q16 / 65536.0
    ln = level_size(n, r_q16)
    x = np.arange(ln)[:, None]
    i = np.arange(n)[None, :]
    lo, hi = x * r, (x + 1) * r
    w = np.clip(np.minimum(hi, i + 1) - np.maximum(lo, i), 0, None)
    return w / r


def resample(gray: np.ndarray, k: int) -> np.ndarray:
    """Level k: area means, rounded half up (float: may differ by 1 at exact halves)."""
    r = SCALE_Q16[k]
    wy, wx = resample_weights(gray.shape[0], r), resample_weights(gray.shape[1], r)
    return np.floor(wy @ gray.astype(np.float64) @ wx.T + 0.5).clip(0, 255).astype(np.uint8)


def channels_float(img: np.ndarray) -> np.ndarray:
    """(8, h // 4, w // 4) float channel values on the byte scale (before rounding and saturation)."""
    L = img.astype(np.float64)
    h, w = L.shape
    P = np.pad(L, 2, mode="edge")
    k = np.array([1.0, 2.0, 1.0])
    g = cv2.sepFilter2D(P, cv2.CV_64F, k, k, borderType=cv2.BORDER_REPLICATE)[1:-1, 1:-1]  # g at -1..w, -1..h
    gx = g[1:-1, 2:] - g[1:-1, :-2]
    gy = g[2:, 1:-1] - g[:-2, 1:-1]
    gc = g[1:-1, 1:-1]
    m = np.floor(np.sqrt(gx * gx + gy * gy))
    a = np.mod(np.arctan2(gy, gx), np.pi)
    b = np.minimum(np.floor(a * 6 / np.pi), 5).astype(int)
    cw, chn = w // 4, h // 4

    def cells(x):
        return x[:chn * 4, :cw * 4].reshape(chn, 4, cw, 4).sum((1, 3))

    G, M = cells(gc), cells(m)
    O = [cells(m * (b == j)) for j in range(6)]
    n9 = cv2.boxFilter(M, cv2.CV_64F, (3, 3), normalize=False, borderType=cv2.BORDER_REPLICATE) + 2880.0
    q = [G, 576 * M / n9] + [576 * o / n9 for o in O]
    out = []
    for c, x in enumerate(q):
        s = cv2.sepFilter2D(x, cv2.CV_64F, k, k, borderType=cv2.BORDER_REPLICATE)
        out.append(s / 4096 if c == 0 else s / 16)
    return np.stack(out)


def channels(img: np.ndarray) -> np.ndarray:
    """Channel bytes: round half up, saturated at 255."""
    return np.minimum(np.floor(channels_float(img) + 0.5), 255).astype(np.uint8)


def window_features(ch: np.ndarray, win_cw: int, win_ch: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every window of channel planes ch (8, rows, cols) -> (features (N, 8 win_ch win_cw), cx, cy)."""
    v = np.lib.stride_tricks.sliding_window_view(ch, (NCH, win_ch, win_cw))[0]
    ny, nx = v.shape[:2]
    cy, cx = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    return v.reshape(ny * nx, -1), cx.ravel(), cy.ravel()


def tree_scores(model, feats: np.ndarray) -> np.ndarray:
    """Float decision values (bias + leaves, no cascade) of window features (N, D)."""
    n_in = (1 << model.depth) - 1
    node = np.zeros((model.n_trees, len(feats)), np.int64)
    t = np.arange(model.n_trees)[:, None]
    for _ in range(model.depth):
        f = model.feat[t, node].astype(np.int64)
        x = feats[np.arange(len(feats))[None, :], f]
        node = 2 * node + 1 + (x > model.thr[t, node])
    return model.bias + model.leaf[t, node - n_in].sum(0)


def box_of(model, k: int, cx, cy):
    """Input-px boxes (left, top, right, bottom) of windows (cx, cy) of level k (acf.h)."""
    r, p4 = SCALE_Q16[k], 4 * model.pad
    cx, cy = np.asarray(cx, np.int64), np.asarray(cy, np.int64)
    f = lambda v: (v * r) >> 16  # noqa: E731
    return np.stack([f(4 * cx + p4), f(4 * cy + p4), f(4 * (cx + model.win_cw) - p4) - 1,
                     f(4 * (cy + model.win_ch) - p4) - 1], -1)


def band_ok(bottom, width, horizon_y: int, hood_y: int, height_mm: int = 1800, veh_w_min_mm: int = 1080,
            veh_w_max_mm: int = 3960, slack_px: int = 20, above_px: int = 5) -> np.ndarray:
    """The flat-road band of acf.h for window bottoms and the level's box width."""
    b = np.asarray(bottom, np.int64)
    d, wh = b - horizon_y, np.int64(width) * height_mm
    return ((b >= horizon_y - above_px) & (b < hood_y) & (veh_w_min_mm * (d - slack_px) <= wh)
            & (wh <= veh_w_max_mm * (d + slack_px)))
