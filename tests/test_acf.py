"""The ACF first stage (issue 8: include/vehtrack/acf.h, c/acf.c, pyvehtrack/acf.py) against
its float oracle (pyvehtrack/reference/acf.py) and a NumPy re-run of the detector.

Checked here, each with the tolerance acf.h's arithmetic allows (stated where it is used):
  * vt_acf_resample = reference.resample (area means) within 1, almost every pixel exact;
    a band of rows / a prefix of columns = the same rows of the whole level, exactly;
  * vt_acf_channels = reference.channels: channel 0 exact, channels 1..7 within the one
    floor per cell the C takes (and one float rounding at an exact half); a band of cell
    rows = the same rows of the whole image's channels, exactly;
  * vt_acf_score = bias_q16 + the Q16 leaves reached (exact) = reference.tree_scores within
    the Q16 rounding of each leaf and the bias; saturation at the int32 ends;
  * vt_acf_detect = per level resample -> channels -> band windows -> scores -> candidates ->
    greedy NMS, re-run here in NumPy (reference.window_features, box_of, band_ok,
    tree_scores): the same boxes, scores and counters; the soft cascade as its trace says;
    the candidate cap keeps the highest scores;
  * bad arguments: VT_E_* statuses from C, clear exceptions from Python, never a crash.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyvehtrack import _native as N
from pyvehtrack import acf as A
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.reference import acf as R

DATA = Path(__file__).resolve().parent / "data"
Q16 = 65536
I32_MIN, I32_MAX = -(2 ** 31), 2 ** 31 - 1
MAX_BOXES = int(lib.VT_MAX_BOXES)
MAX_CAND = int(lib.VT_ACF_MAX_CAND)


def _n(k: int) -> int:
    """k hypothesis examples, fewer when the profile asks for fewer (the secondary CI runs)."""
    return max(1, min(k, settings.default.max_examples))


# ------------------------------------------------------------------ inputs
KINDS = ("noise", "constant", "smooth", "binary", "road")


def _image(rng, h: int, w: int, kind: str) -> np.ndarray:
    if kind == "noise":
        return rng.integers(0, 256, size=(h, w)).astype(np.uint8)
    if kind == "constant":
        return np.full((h, w), rng.choice([0, 1, 128, 254, 255]), np.uint8)
    if kind == "smooth":
        y, x = np.mgrid[0:h, 0:w].astype(np.float64)
        a, b, c = rng.uniform(-2, 2, 3)
        v = 128 + 100 * np.sin(a * x / 7 + b * y / 5 + c) + rng.uniform(-1, 1) * x
        return np.clip(v, 0, 255).astype(np.uint8)
    if kind == "binary":   # the largest gradients: 0/255 blocks of random size
        s = int(rng.integers(1, 6))
        blk = rng.integers(0, 2, size=(h // s + 1, w // s + 1)).astype(np.uint8) * 255
        return np.repeat(np.repeat(blk, s, 0), s, 1)[:h, :w].copy()
    return _road(rng, h, w, int(h * rng.uniform(0.3, 0.55)))


def _road(rng, h: int, w: int, hor: int) -> np.ndarray:
    """A synthetic road frame: sky, a road with lane marks below the horizon, dark cars with
    a brighter body and a shadow under them, sized as the flat road says, plus noise."""
    img = np.empty((h, w), np.float64)
    img[:hor] = np.linspace(200, 150, max(hor, 1))[:, None] if hor else 0
    img[hor:] = np.linspace(110, 90, h - hor)[:, None]
    for x0 in (0.3, 0.7):                                     # dashed lane marks
        for y in range(hor + 1, h):
            d = (y - hor) / max(h - hor, 1)
            xc = int(w * (0.5 + (x0 - 0.5) * d * 2))
            if (y // 6) % 2 == 0 and 0 <= xc < w:
                img[y, max(0, xc - 1):xc + 2] = 230
    for _ in range(int(rng.integers(1, 5)) if hor + 4 < h else 0):
        b = int(rng.integers(hor + 4, h))
        cw = max(6, int((b - hor) * rng.uniform(0.8, 1.6)))
        ch = max(4, int(cw * rng.uniform(0.6, 0.9)))
        x = int(rng.integers(0, max(1, w - cw)))
        img[max(0, b - ch):b, x:x + cw] = rng.uniform(30, 170)
        img[max(0, b - ch // 2):b - ch // 4, x + 1:x + cw - 1] = rng.uniform(20, 80)  # windows / rear
        img[b:min(h, b + 3), x:x + cw] = 15                                              # shadow
    img += rng.normal(0, 6, size=(h, w))
    return np.clip(img, 0, 255).astype(np.uint8)


def _model(rng, win_cw, win_ch, pad, depth, n_trees, leaf_scale=100.0, bias=None, reject=None) -> A.AcfModel:
    """A random valid model: feature indices below 8 win_ch win_cw, thresholds any byte,
    leaves within +-256 (|leaf_q16| <= 2^24), the Q16 leaves rounded half up as acf.h says."""
    n_in, n_leaf = (1 << depth) - 1, 1 << depth
    feat = rng.integers(0, A.NCH * win_cw * win_ch, size=(n_trees, n_in)).astype(np.uint16)
    thr = rng.integers(0, 256, size=(n_trees, n_in)).astype(np.uint8)
    leaf = np.clip(rng.normal(0, leaf_scale, size=(n_trees, n_leaf)), -256, 256)
    if rng.random() < 0.3:   # exact Q16 halves: the rounding's tie (half up)
        leaf = (rng.integers(-2000, 2000, size=leaf.shape) + 0.5) / Q16
    leaf_q16 = np.floor(leaf * Q16 + 0.5).astype(np.int32)
    b = float(rng.normal(0, 50)) if bias is None else bias
    return A.AcfModel(win_cw, win_ch, pad, depth, feat, thr, leaf, leaf_q16, b, reject)


def _model_st():
    """(win_cw, win_ch, pad, depth, n_trees) of a valid model."""
    return st.tuples(st.integers(0, 4), st.integers(1, 4), st.integers(1, 50)).flatmap(
        lambda p: st.tuples(st.integers(2 * p[0] + 1, int(lib.VT_ACF_MAX_WIN_CELLS)),
                            st.integers(2 * p[0] + 1, int(lib.VT_ACF_MAX_WIN_CELLS)),
                            st.just(p[0]), st.just(p[1]), st.just(p[2])))


def _leaves(model, feats: np.ndarray) -> np.ndarray:
    """(T, N) leaf index reached by each window in each tree (acf.h: node n's children 2n+1 and
    2n+2, right when byte feat[n] > thr[n]; leaves are nodes 2^d - 1 ..)."""
    n_in = (1 << model.depth) - 1
    t = np.arange(model.n_trees)[:, None]
    node = np.zeros((model.n_trees, len(feats)), np.int64)
    rows = np.arange(len(feats))[None, :]
    for _ in range(model.depth):
        x = feats[rows, model.feat[t, node].astype(np.int64)]
        node = 2 * node + 1 + (x > model.thr[t, node])
    return node - n_in


def _running_q16(model, feats: np.ndarray) -> np.ndarray:
    """(T, N) running sums (Q16, int64) bias + leaves of trees 0..t: the last row is the score."""
    lv = _leaves(model, feats)
    return model.bias_q16 + np.cumsum(model.leaf_q16.astype(np.int64)[np.arange(model.n_trees)[:, None], lv], 0)


def _q16_tol(model) -> float:
    # Each leaf and the bias are rounded half up to Q16 once (|error| <= 1/2 LSB each) and the
    # C sums them exactly in int64: n_trees + 1 half-LSBs. Float slack: tree_scores adds up to
    # 51 float64 terms of magnitude <= 2^14, each sum within 2^14 * 2^-52 < 1e-11; 1e-9 covers it.
    return (model.n_trees + 1) * 0.5 / Q16 + 1e-9


# ------------------------------------------------------------------ resample
def test_scale_table():
    """vt_acf_scale_q16 = the binding's table = round(65536 2^(k/4)); k outside 0..15 refused."""
    r = ffi.new("int32_t *")
    for k in range(16):
        assert lib.vt_acf_scale_q16(k, r) == lib.VT_OK
        assert r[0] == A.SCALE_Q16[k] == round(Q16 * 2 ** (k / 4))
    for k in (-1, 16, I32_MIN, I32_MAX):
        assert lib.vt_acf_scale_q16(k, r) == lib.VT_E_ARG
    assert lib.vt_acf_scale_q16(0, ffi.NULL) == lib.VT_E_ARG


def _max_level(h, w):
    return max(k for k in range(16) if A.level_size(min(h, w), A.SCALE_Q16[k]) >= 1)


RESAMPLE_STATS = {"max": 0, "neq": 0, "n": 0}


@settings(max_examples=_n(150))
@given(seed=st.integers(0, 2 ** 31), h=st.integers(8, 200), w=st.integers(8, 200),
       kind=st.sampled_from(KINDS), kf=st.floats(0, 1))
def test_resample_matches_oracle(seed, h, w, kind, kf):
    """C rounds the exact rational area mean half up (int64, exact); the oracle's float64
    matrix product is within a few ulps of the same value, so it can land on the other side
    only at an exact half: |diff| <= 1, and nearly every pixel is equal."""
    rng = np.random.default_rng(seed)
    img = _image(rng, h, w, kind)
    k = int(round(kf * _max_level(h, w)))
    c = A.resample(img, k).astype(np.int64)
    ref = R.resample(img, k).astype(np.int64)
    r = A.SCALE_Q16[k]
    assert c.shape == ref.shape == (A.level_size(h, r), A.level_size(w, r))
    d = np.abs(c - ref)
    RESAMPLE_STATS["max"] = max(RESAMPLE_STATS["max"], int(d.max()))
    RESAMPLE_STATS["neq"] += int((d > 0).sum())
    RESAMPLE_STATS["n"] += d.size
    assert d.max() <= 1, (k, d.max())
    assert (d > 0).mean() <= 0.01, (k, (d > 0).mean())   # only exact halves may differ
    if k == 0:
        assert np.array_equal(c, img)                     # level 0 is the input itself
    if k in (4, 8, 12):                                   # r = 2, 4, 8: every weight a dyadic, exact in float too
        assert np.array_equal(c, ref)


@settings(max_examples=_n(100))
@given(seed=st.integers(0, 2 ** 31), h=st.integers(8, 160), w=st.integers(8, 160), kf=st.floats(0, 1),
       pad=st.integers(0, 5))
def test_resample_band_equals_full(seed, h, w, kf, pad):
    """Rows y0 .. y0 + n - 1 and columns 0 .. m - 1 of a level (what vt_acf_detect resamples
    for a band) are exactly those rows and columns of the whole level, at any dst stride."""
    rng = np.random.default_rng(seed)
    img = _image(rng, h, w, "noise")
    k = int(round(kf * _max_level(h, w)))
    full = A.resample(img, k)
    lh, lw = full.shape
    y0 = int(rng.integers(0, lh))
    n = int(rng.integers(1, lh - y0 + 1))
    m = int(rng.integers(1, lw + 1))
    buf = np.full((n, m + pad), 77, np.uint8)
    dst = N.view(buf[:, :m], "dst", writable=True)
    assert lib.vt_acf_resample(A._ws(), N.view(img, "src"), A.SCALE_Q16[k], y0, dst) == lib.VT_OK
    assert np.array_equal(buf[:, :m], full[y0:y0 + n, :m])
    assert (buf[:, m:] == 77).all()                       # the padding between rows untouched


# ------------------------------------------------------------------ channels
CHANNEL_STATS = {"max": np.zeros(8, np.int64), "neq": np.zeros(8, np.int64), "n": 0}


def _check_channels(img):
    c = A.channels(img).astype(np.int64)
    f = R.channels_float(img)
    ref = R.channels(img).astype(np.int64)
    assert c.shape == ref.shape == (8, img.shape[0] // 4, img.shape[1] // 4)
    d = c - ref
    CHANNEL_STATS["max"] = np.maximum(CHANNEL_STATS["max"], np.abs(d).reshape(8, -1).max(1))
    CHANNEL_STATS["neq"] += (d != 0).reshape(8, -1).sum(1)
    CHANNEL_STATS["n"] += d[0].size
    # Channel 0: S_G is an exact integer in both (float64 sums of integers < 2^53 are exact) and
    # (S + 2048) >> 12 is round half up of S / 4096, a division by a power of 2: exact.
    assert np.array_equal(c[0], ref[0])
    # Channels 1..7: the C floors each cell's 576 X / (N9 + 2880), up to 1 low per cell; the
    # [1 2 1]^2 weights sum to 16 and the byte is S / 16, so before rounding the C value y lies
    # in (v - 1, v] of the oracle's real value v; both round half up, so the bytes differ by
    # at most 1 (C never higher), and the float oracle may land on the other side of an exact
    # half: |diff| <= 2 allowed. Tighter and one-sided against the float value (1e-9: float64
    # error of v, whose terms are at most 576 x 16): v - 1.5 < C <= v + 0.5.
    assert np.abs(d[1:]).max(initial=0) <= 2
    v = np.minimum(f[1:], 255.0)
    assert (c[1:] <= np.floor(v + 0.5 + 1e-9)).all()
    assert (c[1:] >= np.minimum(np.floor(f[1:] - 0.5 - 1e-9), 255)).all()
    # saturation: C is 255 exactly where the oracle is (both clamp at 255 after the rounding)
    assert np.array_equal(c == 255, ref == 255)
    return c


@settings(max_examples=_n(200))
@given(seed=st.integers(0, 2 ** 31), h=st.integers(4, 200), w=st.integers(4, 200), kind=st.sampled_from(KINDS),
       tiny=st.booleans())
def test_channels_match_oracle(seed, h, w, kind, tiny):
    """Smooth, noise, constant, 0/255 blocks and road frames; tiny (4..12 px) and sizes that
    are not multiples of 4 (the last w % 4 columns are in no cell, but feed the gradients)."""
    rng = np.random.default_rng(seed)
    if tiny:
        h, w = 4 + h % 9, 4 + w % 9
    _check_channels(_image(rng, h, w, kind))


def test_channels_by_hand():
    """A constant image has no gradient: channels 1..7 are 0, channel 0 the gray value; white
    reaches the top byte exactly ((16 x 16 x 4080 + 2048) >> 12 = 255); a 4x4 image is one cell."""
    for v in (0, 1, 77, 254, 255):
        c = _check_channels(np.full((20, 28), v, np.uint8))
        assert (c[0] == v).all() and (c[1:] == 0).all(), v
    assert A.channels(np.full((4, 4), 255, np.uint8)).shape == (8, 1, 1)
    # a vertical edge: orientation bin 0 (gradient along x) only
    img = np.zeros((16, 16), np.uint8)
    img[:, 8:] = 200
    c = _check_channels(img)
    assert c[2].max() > 0 and (c[3:] == 0).all()
    # a horizontal edge: bin 3 (atan2 = pi/2) only
    c = _check_channels(np.ascontiguousarray(img.T))
    assert c[5].max() > 0 and (c[2:5] == 0).all() and (c[6:] == 0).all()


@settings(max_examples=_n(100))
@given(seed=st.integers(0, 2 ** 31), h=st.integers(4, 120), w=st.integers(4, 120), kind=st.sampled_from(KINDS))
def test_channel_band_equals_full(seed, h, w, kind):
    """vt_acf_channels(img, cy0, n) = channels(img)[:, cy0:cy0 + n] exactly (the streaming rings
    start two cell rows above the band and clamp at the image, not the band)."""
    rng = np.random.default_rng(seed)
    img = _image(rng, h, w, kind)
    full = A.channels(img)
    nch = h // 4
    cy0 = int(rng.integers(0, nch))
    n = int(rng.integers(1, nch - cy0 + 1))
    band = A.channels(img, cy0, n)
    assert np.array_equal(band, full[:, cy0:cy0 + n])


# ------------------------------------------------------------------ scores
SCORE_STATS = {"max": 0.0, "n": 0}
DETECT_STATS = {"cases": 0, "windows": 0, "cand": 0, "boxes": 0, "dropped_by_trace": 0, "multi_cases": 0,
                "multi_boxes": 0}


@settings(max_examples=_n(150))
@given(seed=st.integers(0, 2 ** 31), geo=_model_st(), extra=st.tuples(st.integers(0, 8), st.integers(0, 8)),
       small_alphabet=st.booleans())
def test_score_matches_oracle(seed, geo, extra, small_alphabet):
    """vt_acf_score at random windows of random planes: exactly bias_q16 + the Q16 leaves the
    header's traversal reaches; and within (n_trees + 1) / 2 LSB of reference.tree_scores on
    the float leaves (see _q16_tol). Planes drawn from the thresholds +-1 make byte == thr
    (left) and byte == thr + 1 (right) common."""
    win_cw, win_ch, pad, depth, n_trees = geo
    rng = np.random.default_rng(seed)
    m = _model(rng, win_cw, win_ch, pad, depth, n_trees, leaf_scale=float(rng.choice([0.01, 1.0, 100.0])),
               bias=float(rng.uniform(-2 ** 13, 2 ** 13)))
    rows, cols = win_ch + extra[1], win_cw + extra[0]
    if small_alphabet:
        vals = np.clip(np.concatenate([m.thr.ravel().astype(np.int64) + d for d in (-1, 0, 1)]), 0, 255)
        ch = rng.choice(vals, size=(A.NCH, rows, cols)).astype(np.uint8)
    else:
        ch = rng.integers(0, 256, size=(A.NCH, rows, cols)).astype(np.uint8)
    feats, cx, cy = R.window_features(ch, win_cw, win_ch)
    pick = rng.choice(len(feats), size=min(6, len(feats)), replace=False)
    want = R.tree_scores(m, feats[pick])
    exact = _running_q16(m, feats[pick])[-1]
    for i, j in enumerate(pick):
        got = m.score_c(ch, int(cx[j]), int(cy[j]))
        assert got == exact[i], (cx[j], cy[j])
        err = abs(got / Q16 - want[i])
        SCORE_STATS["max"] = max(SCORE_STATS["max"], err * Q16)
        SCORE_STATS["n"] += 1
        assert err <= _q16_tol(m), (got / Q16, want[i], err * Q16)


def test_score_feature_layout_by_hand():
    """Feature index c win_ch win_cw + y win_cw + x reads plane c, row cy + y, column cx + x:
    a depth-1 tree on one byte, the byte set just above / at the threshold."""
    rng = np.random.default_rng(3)
    m = _model(rng, 5, 3, 1, 1, 1)
    c, y, x = 6, 2, 4
    m.feat[:] = c * 15 + y * 5 + x
    m.thr[:] = 100
    m.leaf_q16[:] = [[-7, 11]]
    m.bias = 0.0
    ch = np.zeros((8, 6, 9), np.uint8)
    ch[c, 1 + y, 3 + x] = 101
    assert m.score_c(ch, 3, 1) == 11          # 101 > 100: right
    ch[c, 1 + y, 3 + x] = 100
    assert m.score_c(ch, 3, 1) == -7          # 100 > 100 is false: left
    ch[c, 1 + y, 3 + x] = 255
    assert m.score_c(ch, 4, 1) == -7          # another window reads another byte


def test_score_saturates():
    """bias + leaves past the int32 range saturate (the sum itself is int64)."""
    d = 1
    n = 65
    feat = np.zeros((n, 1), np.uint16)
    thr = np.zeros((n, 1), np.uint8)
    top = np.full((n, 2), 2 ** 24, np.int32)
    m = A.AcfModel(3, 3, 0, d, feat, thr, top / Q16, top, float(2 ** 14))
    ch = np.zeros((8, 3, 3), np.uint8)
    assert m.score_c(ch, 0, 0) == I32_MAX        # 2^30 + 65 x 2^24 > 2^31 - 1
    m2 = A.AcfModel(3, 3, 0, d, feat, thr, -top / Q16, -top, float(-2 ** 14))
    assert m2.score_c(ch, 0, 0) == I32_MIN       # -2^30 - 65 x 2^24 < -2^31
    m3 = A.AcfModel(3, 3, 0, d, feat[:64], thr[:64], top[:64] / Q16, top[:64], float(2 ** 14) - 1 / Q16)
    assert m3.score_c(ch, 0, 0) == I32_MAX       # 2^31 - 1 exactly: in range, not saturated


# ------------------------------------------------------------------ detection, re-run in NumPy
def _cfg(**kw):
    c = A.cfg_default()
    for k, v in kw.items():
        setattr(c, k, int(v))
    assert lib.vt_acf_cfg_check(c) == lib.VT_OK, kw
    return c


def _oracle_windows(model, img, horizon_y, hood_y, height_mm, cfg):
    """Every band window of every level the detector visits, in its order (level, cy, cx):
    boxes (N, 4), running Q16 sums (T, N), float scores (N,), and the level of each."""
    h, w = img.shape
    boxes, runs, fl = [], [], []
    for k in range(cfg.first_scale, cfg.first_scale + cfg.n_scales):
        r = A.SCALE_Q16[k]
        lw, lh = A.level_size(w, r), A.level_size(h, r)
        cw, nch = lw // 4, lh // 4
        if cw < model.win_cw or nch < model.win_ch:
            continue                                            # a level smaller than a window
        cy = np.arange(nch - model.win_ch + 1)
        bottom = R.box_of(model, k, np.zeros_like(cy), cy)[:, 3]
        W = (4 * (model.win_cw - 2 * model.pad) * r) >> 16    # the level's nominal box width
        ok = R.band_ok(bottom, W, horizon_y, hood_y, height_mm, cfg.veh_w_min_mm, cfg.veh_w_max_mm,
                       cfg.slack_px, cfg.above_px)
        if not ok.any():
            continue
        level = img if k == 0 else A.resample(img, k)
        assert level.shape == (lh, lw)
        ch = A.channels(level)
        cys = cy[ok]
        lo, hi = int(cys.min()), int(cys.max())
        feats, wcx, wcy = R.window_features(ch[:, lo:hi + model.win_ch], model.win_cw, model.win_ch)
        wcy = wcy + lo
        keep = ok[wcy]
        if cfg.cols == lib.VT_ACF_COLS_LEFT:         # only the edge column (a cut vehicle's model)
            keep &= wcx == 0
        elif cfg.cols == lib.VT_ACF_COLS_RIGHT:
            keep &= wcx == cw - model.win_cw
        feats, wcx, wcy = feats[keep], wcx[keep], wcy[keep]
        boxes.append(R.box_of(model, k, wcx, wcy))
        runs.append(_running_q16(model, feats))
        fl.append(R.tree_scores(model, feats))
    if not boxes:
        return np.zeros((0, 4), np.int64), np.zeros((model.n_trees, 0), np.int64), np.zeros(0)
    return np.concatenate(boxes), np.concatenate(runs, 1), np.concatenate(fl)


def _nms(boxes, scores, iou_permille, contain_permille=1000):
    """vt_nms: stable sort by score descending, then greedy; suppressed when inter x 1000 >
    iou_permille x union or > contain_permille x the smaller area, on inclusive pixel areas
    (exact integers)."""
    order = np.argsort(-scores, kind="stable")
    b = boxes[order].astype(np.int64)
    area = (b[:, 2] - b[:, 0] + 1) * (b[:, 3] - b[:, 1] + 1)
    kept = []
    for i in range(len(b)):
        if kept:
            kk = np.array(kept)
            iw = np.minimum(b[kk, 2], b[i, 2]) - np.maximum(b[kk, 0], b[i, 0]) + 1
            ih = np.minimum(b[kk, 3], b[i, 3]) - np.maximum(b[kk, 1], b[i, 1]) + 1
            inter = np.where((iw > 0) & (ih > 0), iw * ih, 0)
            union = area[kk] + area[i] - inter
            if (inter * 1000 > iou_permille * union).any() or \
                    (inter * 1000 > contain_permille * np.minimum(area[kk], area[i])).any():
                continue
        kept.append(i)
    return order[np.array(kept, np.int64)]


def _compare(model, img, hor, hood, height_mm, cfg, boxes, runs, fl):
    """acf.detect against the oracle's windows: counters, then boxes and scores after NMS."""
    score = runs[-1] if runs.shape[1] else np.zeros(0, np.int64)
    full = np.ones(len(score), bool)
    if model.reject_q16 is not None:
        full = (runs >= model.reject_q16.astype(np.int64)[:, None]).all(0)
    # the models here keep every running sum inside int32 (no saturation to re-run)
    assert (np.abs(runs) <= I32_MAX).all()
    cand = full & (score >= cfg.score_min)
    assert cand.sum() <= MAX_CAND
    got, info = A.detect(model, img, hor, hood, 300.0, height_mm, cfg)
    assert info["n_windows"] == len(score)
    assert info["n_window_hits"] == info["n_cand"] == int(cand.sum()) and info["n_cand_dropped"] == 0
    idx = np.flatnonzero(cand)
    kept = idx[_nms(boxes[idx], score[idx], cfg.nms_iou_permille, cfg.nms_contain_permille)][:MAX_BOXES]
    gb = np.stack([got["left"], got["top"], got["right"], got["bottom"]], 1) if len(got) else np.zeros((0, 4))
    assert np.array_equal(gb, boxes[kept]), (gb[:5], boxes[kept][:5])
    assert np.array_equal(got["score"], score[kept])
    assert (got["source"] == lib.VT_SRC_WINDOW).all()
    assert (np.abs(got["score"] / Q16 - fl[kept]) <= _q16_tol(model)).all()
    DETECT_STATS["cases"] += 1
    DETECT_STATS["windows"] += len(score)
    DETECT_STATS["cand"] += int(cand.sum())
    DETECT_STATS["boxes"] += len(got)
    DETECT_STATS["dropped_by_trace"] += int((~full).sum())
    return got, info


def _score_min_for(rng, runs, model, target):
    """A score_min giving about `target` candidates (0: above every score), never past the cap."""
    score = runs[-1] if runs.shape[1] else np.zeros(0, np.int64)
    if model.reject_q16 is not None:
        score = score[(runs >= model.reject_q16.astype(np.int64)[:, None]).all(0)]
    if target == 0 or len(score) == 0:
        return int(min(I32_MAX, (score.max() + 1) if len(score) else 0))
    s = np.sort(score)[::-1]
    v = int(s[min(target, len(s)) - 1])
    while (score >= v).sum() > min(MAX_CAND, 600):          # ties past the target: the next value up
        v = int(s[s > v].min()) if (s > v).any() else v + 1
    return v


def _det_case(seed, w, h, geo, cfg_draw):
    rng = np.random.default_rng(seed)
    win_cw, win_ch, pad, depth, n_trees = geo
    hor = int(h * rng.uniform(0.25, 0.6))
    hood = int(h - rng.integers(0, h // 5 + 1))
    height_mm = int(rng.integers(1000, 2600))
    img = _road(rng, h, w, hor) if rng.random() < 0.8 else _image(rng, h, w, str(rng.choice(KINDS)))
    model = _model(rng, win_cw, win_ch, pad, depth, n_trees, leaf_scale=float(rng.choice([1.0, 30.0])),
                   bias=float(rng.normal(0, 20)))
    first = int(rng.integers(0, 5))
    wmin = int(rng.integers(400, 2200))
    cfg = _cfg(first_scale=first, n_scales=int(rng.integers(1, 17 - first)), veh_w_min_mm=wmin,
               veh_w_max_mm=int(rng.integers(wmin, 6000)), slack_px=int(rng.integers(0, 41)),
               above_px=int(rng.integers(0, 21)),
               nms_iou_permille=int(rng.choice([0, 300, 500, 1000, rng.integers(0, 1001)])),
               nms_contain_permille=int(rng.choice([1000, 1000, 400, 700, rng.integers(0, 1001)])),
               cols=int(rng.choice([0, 0, 0, 1, 2])))
    for k, v in cfg_draw.items():
        setattr(cfg, k, v)
    return rng, img, hor, hood, height_mm, model, cfg


DET_GEO = st.tuples(st.integers(0, 2), st.integers(1, 4), st.integers(1, 40)).flatmap(
    lambda p: st.tuples(st.integers(2 * p[0] + 1, 12), st.integers(2 * p[0] + 1, 10), st.just(p[0]),
                        st.just(p[1]), st.just(p[2])))


@settings(max_examples=_n(150))
@given(seed=st.integers(0, 2 ** 31), w=st.integers(160, 400), h=st.integers(120, 240), geo=DET_GEO,
       target=st.sampled_from([0, 1, 5, 40, 300]))
def test_detect_matches_numpy(seed, w, h, geo, target):
    """No cascade: every band window of every level scored; candidates >= score_min; greedy
    NMS. Same boxes (exact), same Q16 scores (exact: the oracle sums the same Q16 leaves) and
    within the Q16 tolerance of the float model; n_windows = the band's windows."""
    rng, img, hor, hood, height_mm, model, cfg = _det_case(seed, w, h, geo, {})
    boxes, runs, fl = _oracle_windows(model, img, hor, hood, height_mm, cfg)
    cfg.score_min = _score_min_for(rng, runs, model, target)
    got, info = _compare(model, img, hor, hood, height_mm, cfg, boxes, runs, fl)
    assert len(got) <= MAX_BOXES
    assert (np.diff(got["score"].astype(np.int64)) <= 0).all()
    assert (got["score"] >= cfg.score_min).all()
    if len(fl) and (runs[-1] >= cfg.score_min).any():
        assert len(got) >= 1            # a candidate survives NMS (the first one always does)


@settings(max_examples=_n(100))
@given(seed=st.integers(0, 2 ** 31), w=st.integers(160, 360), h=st.integers(120, 220),
       geos=st.lists(DET_GEO, min_size=2, max_size=int(lib.VT_ACF_MAX_MODELS)),
       target=st.sampled_from([1, 5, 40, 200]))
def test_detect_n_matches_numpy(seed, w, h, geos, target):
    """vt_acf_detect_n on 2..4 models (each its own window, levels, band and score_min) =
    the NumPy re-run of each model on its own levels, the candidates in the C core's order
    (level by level, model by model within a level), one greedy NMS at cfg[0]'s IoU; exact
    boxes, scores and counters. No cascade here (test_soft_cascade covers the trace)."""
    rng, img, hor, hood, height_mm, m0, c0 = _det_case(seed, w, h, geos[0], {})
    models, cfgs = [m0], [c0]
    for g in geos[1:]:
        _, _, _, _, _, m_, c_ = _det_case(int(rng.integers(0, 2 ** 31)), w, h, g, {})
        models.append(m_)
        cfgs.append(c_)
    per = []   # (level, model i, boxes, runs, floats)
    for k in range(min(c.first_scale for c in cfgs), max(c.first_scale + c.n_scales for c in cfgs)):
        for i, (m_, c_) in enumerate(zip(models, cfgs)):
            if c_.first_scale <= k < c_.first_scale + c_.n_scales:
                ck = _cfg(first_scale=k, n_scales=1, veh_w_min_mm=c_.veh_w_min_mm, veh_w_max_mm=c_.veh_w_max_mm,
                          slack_px=c_.slack_px, above_px=c_.above_px, cols=c_.cols)
                per.append((i,) + _oracle_windows(m_, img, hor, hood, height_mm, ck))
    for i, (m_, c_) in enumerate(zip(models, cfgs)):   # each model's threshold from its own windows
        runs_i = [r for j, _, r, _ in per if j == i]
        r_all = np.concatenate(runs_i, 1) if runs_i else np.zeros((m_.n_trees, 0), np.int64)
        c_.score_min = _score_min_for(rng, r_all, m_, max(1, target // len(models)))
    boxes, score, fl, tol = [], [], [], []
    for i, b, r, f in per:
        s_ = r[-1] if r.shape[1] else np.zeros(0, np.int64)
        assert (np.abs(r) <= I32_MAX).all()
        keep = s_ >= cfgs[i].score_min
        boxes.append(b[keep])
        score.append(s_[keep])
        fl.append(f[keep])
        tol.append(np.full(int(keep.sum()), _q16_tol(models[i])))
    boxes, score, fl, tol = (np.concatenate(boxes), np.concatenate(score), np.concatenate(fl), np.concatenate(tol))
    assert len(score) <= MAX_CAND
    m_all = models[0]
    m_all.more = models[1:]
    got, info = A.detect(m_all, img, hor, hood, 300.0, height_mm, cfgs)
    assert info["n_windows"] == sum(r.shape[1] for _, _, r, _ in per)
    assert info["n_window_hits"] == info["n_cand"] == len(score) and info["n_cand_dropped"] == 0
    kept = _nms(boxes, score, cfgs[0].nms_iou_permille, cfgs[0].nms_contain_permille)[:MAX_BOXES]
    gb = np.stack([got["left"], got["top"], got["right"], got["bottom"]], 1) if len(got) else np.zeros((0, 4))
    assert np.array_equal(gb, boxes[kept]), (gb[:5], boxes[kept][:5])
    assert np.array_equal(got["score"], score[kept])
    assert (np.abs(got["score"] / Q16 - fl[kept]) <= tol[kept]).all()
    DETECT_STATS["multi_cases"] += 1
    DETECT_STATS["multi_boxes"] += len(got)


def test_detect_n_one_model_is_detect():
    """n = 1 through vt_acf_detect_n and vt_acf_detect: the same result, field for field."""
    rng, img, hor, hood, height_mm, m, c = _det_case(7, 320, 200, (10, 9, 1, 3, 20), {})
    c.score_min = -(2 ** 31)
    cam = N.camera_min(300.0, hor, height_mm, hood)
    r1, r2 = ffi.new("vt_fulldet_result *"), ffi.new("vt_fulldet_result *")
    ws = ffi.new("vt_acf_ws *")
    mc = m.c_model()[0]
    assert lib.vt_acf_detect(ws, mc, c, cam, N.view(img, "img"), r1) == lib.VT_OK
    mp, cp = ffi.new("vt_acf_model *[1]", [mc]), ffi.new("vt_acf_cfg *[1]", [c])
    assert lib.vt_acf_detect_n(ws, 1, mp, cp, cam, N.view(img, "img"), r2) == lib.VT_OK
    assert r1.n_boxes > 0 and bytes(ffi.buffer(r1)) == bytes(ffi.buffer(r2))


def test_detect_real_frames_not_vacuous():
    """Two real frames (KITTI 640x256, udacity at 400x225) with the default configuration and
    a random model: windows in the band on many levels, boxes after NMS, all as the oracle."""
    for name, size in (("kitti_clip/000003.png", None), ("udacity_test1_640x360.jpg", (400, 225))):
        g = cv2.imread(str(DATA / name), cv2.IMREAD_GRAYSCALE)
        if size:
            g = cv2.resize(g, size, interpolation=cv2.INTER_AREA)
        h = g.shape[0]
        rng = np.random.default_rng(11)
        model = _model(rng, 10, 9, 1, 3, 30, leaf_scale=1.0, bias=0.0)
        cfg = _cfg()
        hor, hood = int(h * 0.45), h - 2
        boxes, runs, fl = _oracle_windows(model, g, hor, hood, 1800, cfg)
        assert runs.shape[1] > 1000, name
        cfg.score_min = _score_min_for(rng, runs, model, 200)
        got, info = _compare(model, g, hor, hood, 1800, cfg, boxes, runs, fl)
        assert len(got) >= 5, name
        assert len({int(b) for b in got["right"] - got["left"]}) >= 3, name   # several levels' boxes
        # with a trace at the 20 % quantile of each tree's running sums: fewer hits, as the oracle
        casc = A.AcfModel(10, 9, 1, 3, model.feat, model.thr, model.leaf, model.leaf_q16, model.bias,
                          np.quantile(runs, 0.2, axis=1).astype(np.int64).astype(np.int32))
        got2, info2 = _compare(casc, g, hor, hood, 1800, cfg, boxes, runs, fl)
        assert 0 < info2["n_window_hits"] < info["n_window_hits"], name
        assert info2["n_windows"] == info["n_windows"]


@settings(max_examples=_n(100))
@given(seed=st.integers(0, 2 ** 31), w=st.integers(160, 360), h=st.integers(120, 220), geo=DET_GEO,
       q=st.sampled_from([0.0, 0.05, 0.3, 0.7]))
def test_soft_cascade(seed, w, h, geo, q):
    """With a trace (reject[t] = the q-quantile of the band windows' running sums after tree t,
    so each stage drops some): acf.detect = the oracle with the cascade (exact); every box's
    full score >= score_min and its running sums never went below the trace; and a trace of
    INT32_MIN everywhere (no sum gets that low here) detects as no trace at all."""
    rng, img, hor, hood, height_mm, model, cfg = _det_case(seed, w, h, geo, {})
    boxes, runs, fl = _oracle_windows(model, img, hor, hood, height_mm, cfg)
    if runs.shape[1] == 0:
        return
    reject = np.quantile(runs, q, axis=1).astype(np.int64).astype(np.int32)
    casc = A.AcfModel(model.win_cw, model.win_ch, model.pad, model.depth, model.feat, model.thr, model.leaf,
                      model.leaf_q16, model.bias, reject)
    cfg.score_min = _score_min_for(rng, runs, casc, 40)
    got, info = _compare(casc, img, hor, hood, height_mm, cfg, boxes, runs, fl)
    # each returned box: some window with that box passed the trace at every tree
    for b in got:
        hit = np.flatnonzero((boxes == [b["left"], b["top"], b["right"], b["bottom"]]).all(1))
        ok = [j for j in hit if (runs[:, j] >= reject).all() and runs[-1, j] == b["score"]]
        assert ok and b["score"] >= cfg.score_min, b
    never = A.AcfModel(model.win_cw, model.win_ch, model.pad, model.depth, model.feat, model.thr, model.leaf,
                       model.leaf_q16, model.bias, np.full(model.n_trees, I32_MIN, np.int32))
    a, ia = A.detect(never, img, hor, hood, 300.0, height_mm, cfg)
    b_, ib = A.detect(model, img, hor, hood, 300.0, height_mm, cfg)
    assert np.array_equal(a, b_) and ia == ib


def test_candidate_cap_keeps_the_highest():
    """score_min INT32_MIN on a big band: more windows than VT_ACF_MAX_CAND. The lowest candidate
    is replaced by a higher one, so the kept scores are the top VT_ACF_MAX_CAND; with NMS off
    (IoU limit 1000: inter x 1000 > 1000 union never holds) the boxes are the top VT_MAX_BOXES."""
    rng = np.random.default_rng(5)
    img = _road(rng, 240, 480, 100)
    model = _model(rng, 4, 4, 0, 2, 10, leaf_scale=30.0, bias=0.0)
    cfg = _cfg(first_scale=0, n_scales=3, veh_w_min_mm=100, veh_w_max_mm=20000, slack_px=200, above_px=100,
               score_min=I32_MIN, nms_iou_permille=1000)
    boxes, runs, fl = _oracle_windows(model, img, 100, 240, 1800, cfg)
    score = runs[-1]
    assert len(score) > MAX_CAND
    got, info = A.detect(model, img, 100, 240, 300.0, 1800, cfg)
    assert info["n_windows"] == info["n_window_hits"] == len(score)
    assert info["n_cand"] == MAX_CAND and info["n_cand_dropped"] == len(score) - MAX_CAND
    assert np.array_equal(got["score"], np.sort(score)[::-1][:MAX_BOXES])


def test_levels_smaller_than_a_window_are_skipped():
    """An 8x8-cell window on a 40x130 frame: levels 0 and 1 have room (10 and 8 cells wide), level
    2 (7) and the rest do not; n_windows counts the visited levels' band windows only, and a
    frame smaller than a window at every level gives no window at all."""
    rng = np.random.default_rng(9)
    model = _model(rng, 8, 8, 0, 1, 3)
    img = _image(rng, 130, 40, "noise")
    cfg = _cfg(veh_w_min_mm=100, veh_w_max_mm=20000, slack_px=500, above_px=500, score_min=I32_MIN)
    assert [A.level_size(40, A.SCALE_Q16[k]) // 4 for k in range(3)] == [10, 8, 7]
    boxes, runs, fl = _oracle_windows(model, img, 0, 130, 1800, cfg)
    # level 0: 40 x 130 px, 10 x 32 cells: 3 x 25 windows; level 1: 33 x 109 px, 8 x 27 cells: 1 x 20
    assert runs.shape[1] == 3 * 25 + 1 * 20
    _compare(model, img, 0, 130, 1800, _cfg(veh_w_min_mm=100, veh_w_max_mm=20000, slack_px=500, above_px=500,
                                            score_min=int(np.sort(runs[-1])[-min(50, runs.shape[1])])),
             boxes, runs, fl)
    got, info = A.detect(model, np.zeros((31, 31), np.uint8), 0, 31, 300.0, 1800, cfg)
    assert len(got) == 0 and info["n_windows"] == 0


# ------------------------------------------------------------------ bad arguments
def _cmodel(m: A.AcfModel):
    """The vt_acf_model struct without the binding's check (to hand bad ones to C)."""
    keep = [ffi.new("uint16_t[]", m.feat.ravel().tolist() or [0]), ffi.new("uint8_t[]", m.thr.ravel().tolist() or [0]),
            ffi.new("int32_t[]", m.leaf_q16.ravel().tolist() or [0])]
    c = ffi.new("vt_acf_model *")
    c.win_cw, c.win_ch, c.pad, c.n_trees, c.depth = m.win_cw, m.win_ch, m.pad, m.n_trees, m.depth
    c.feat, c.thr, c.leaf = keep
    c.bias_q16 = m.bias_q16
    return c, keep


def test_model_check_rows():
    rng = np.random.default_rng(1)
    good = _model(rng, 6, 5, 1, 3, 4)
    c, keep = _cmodel(good)
    assert lib.vt_acf_model_check(c) == lib.VT_OK
    assert lib.vt_acf_model_check(ffi.NULL) == lib.VT_E_ARG
    for field in ("feat", "thr", "leaf"):
        c2 = ffi.new("vt_acf_model *", c[0])
        setattr(c2, field, ffi.NULL)
        assert lib.vt_acf_model_check(c2) == lib.VT_E_ARG, field
    rows = [("pad", -1), ("pad", 5), ("win_cw", 2), ("win_ch", 2), ("win_cw", 33), ("win_ch", 33),
            ("n_trees", 0), ("n_trees", -1), ("n_trees", int(lib.VT_ACF_MAX_TREES) + 1), ("depth", 0),
            ("depth", 5), ("bias_q16", 2 ** 30 + 1), ("bias_q16", -(2 ** 30) - 1), ("depth", I32_MIN)]
    for field, v in rows:
        c2 = ffi.new("vt_acf_model *", c[0])
        setattr(c2, field, v)
        assert lib.vt_acf_model_check(c2) == lib.VT_E_ARG, (field, v)
    for field, v in (("bias_q16", 2 ** 30), ("bias_q16", -(2 ** 30)), ("n_trees", 1)):  # the edges themselves
        c2 = ffi.new("vt_acf_model *", c[0])
        setattr(c2, field, v)
        assert lib.vt_acf_model_check(c2) == lib.VT_OK, (field, v)
    # feature index: 8 win_cw win_ch - 1 is the last byte of the window
    for v, ok in ((8 * 6 * 5 - 1, True), (8 * 6 * 5, False), (65535, False)):
        bad = _model(rng, 6, 5, 1, 3, 4)
        bad.feat[2, 5] = v
        cb, keep_b = _cmodel(bad)                     # keep_b: the arrays stay alive
        assert (lib.vt_acf_model_check(cb) == lib.VT_OK) == ok, v
    for v, ok in ((2 ** 24, True), (-(2 ** 24), True), (2 ** 24 + 1, False), (-(2 ** 24) - 1, False)):
        bad = _model(rng, 6, 5, 1, 3, 4)
        bad.leaf_q16[3, 7] = v
        cb, keep_b = _cmodel(bad)                     # keep_b: the arrays stay alive
        assert (lib.vt_acf_model_check(cb) == lib.VT_OK) == ok, v


def test_python_model_errors(tmp_path):
    """AcfModel: the core's check as VtError (feat out of range, depth 0 / 5, no trees, a leaf
    past 2^24), mis-shaped arrays as ValueError; load: a missing file, a non-ACF npz, one
    lacking a key; save -> load gives the same model."""
    rng = np.random.default_rng(2)

    def mk(depth=2, n=3):
        n_in, n_leaf = (1 << depth) - 1, 1 << depth
        return A.AcfModel(4, 4, 0, depth, np.zeros((n, n_in), np.uint16), np.zeros((n, n_in), np.uint8),
                          np.zeros((n, n_leaf)), np.zeros((n, n_leaf), np.int32), 0.0)

    with pytest.raises(VtError, match="vt_acf_model_check"):
        m = mk()
        m.feat[0, 0] = 8 * 4 * 4
        m.c_model()
    for depth, n in ((0, 3), (5, 3), (2, 0)):
        with pytest.raises(VtError, match="vt_acf_model_check"):
            mk(depth, n).c_model()
    m = mk()
    m.leaf_q16[1, 1] = 2 ** 24 + 1
    with pytest.raises(VtError, match="vt_acf_model_check: bad argument"):
        m.c_model()
    m = mk()
    m.thr = m.thr[:, :2]
    with pytest.raises(ValueError, match="do not fit"):
        m.c_model()
    with pytest.raises(FileNotFoundError):
        A.AcfModel.load(tmp_path / "missing.npz")
    np.savez(tmp_path / "other.npz", w=np.zeros(3))
    with pytest.raises(ValueError, match="not an ACF model"):
        A.AcfModel.load(tmp_path / "other.npz")
    good = _model(rng, 6, 5, 1, 3, 4, reject=np.arange(4, dtype=np.int32) - 100)
    good.save(tmp_path / "good.npz")
    z = dict(np.load(tmp_path / "good.npz"))
    del z["leaf_q16"]
    np.savez(tmp_path / "partial.npz", **z)
    with pytest.raises(ValueError, match="lacks leaf_q16"):
        A.AcfModel.load(tmp_path / "partial.npz")
    back = A.AcfModel.load(tmp_path / "good.npz")
    for k in ("feat", "thr", "leaf", "leaf_q16", "reject_q16"):
        assert np.array_equal(getattr(back, k), getattr(good, k)), k
    assert (back.win_cw, back.win_ch, back.pad, back.depth, back.bias) == (6, 5, 1, 3, good.bias)


def test_model_file_with_more_models(tmp_path):
    """A file with more models (acf1_*, acf2_* keys): save -> load keeps each model, its band,
    threshold and the NMS containment limit; c_cfg carries them; a partial or bad extra model
    is a clear ValueError / VtError naming it."""
    rng = np.random.default_rng(11)
    m0, m1, m2 = _model(rng, 10, 9, 1, 3, 5), _model(rng, 16, 8, 1, 2, 4), _model(rng, 6, 6, 0, 1, 3)
    m0.nms_contain_permille, m1.band_mm, m1.score_min_q16, m2.score_min_q16 = 400, (1500, 9000), 7, -9
    m0.more = [m1, m2]
    p = tmp_path / "two.npz"
    m0.save(p)
    got = A.AcfModel.load(p)
    assert len(got.more) == 2 and got.nms_contain_permille == 400 and got.band_mm is None
    for a, b in zip([got] + got.more, [m0, m1, m2]):
        assert (a.win_cw, a.win_ch, a.pad, a.depth, a.band_mm, a.score_min_q16) == \
            (b.win_cw, b.win_ch, b.pad, b.depth, b.band_mm, b.score_min_q16)
        assert np.array_equal(a.feat, b.feat) and np.array_equal(a.leaf_q16, b.leaf_q16)
    c = got.more[0].c_cfg(65536)
    assert (c.veh_w_min_mm, c.veh_w_max_mm, c.score_min) == (1500, 9000, 7 + 65536)
    assert got.c_cfg().nms_contain_permille == 400
    z = dict(np.load(p))
    bad = dict(z)
    del bad["acf2_feat"]
    np.savez(tmp_path / "partial.npz", **bad)
    with pytest.raises(ValueError, match="acf2_"):
        A.AcfModel.load(tmp_path / "partial.npz")
    bad = dict(z, acf1_band_mm=np.array([1, 2, 3]))
    np.savez(tmp_path / "band3.npz", **bad)
    with pytest.raises(ValueError, match="band_mm"):
        A.AcfModel.load(tmp_path / "band3.npz")
    bad = dict(z, acf1_band_mm=np.array([50, 9000]))      # below acf.h's 100 mm
    np.savez(tmp_path / "band50.npz", **bad)
    with pytest.raises(VtError, match="vt_acf_cfg_check"):
        A.AcfModel.load(tmp_path / "band50.npz")
    bad = dict(z, nms_contain_permille=np.int32(1001))
    np.savez(tmp_path / "contain.npz", **bad)
    with pytest.raises(VtError, match="nms_contain_permille"):
        A.AcfModel.load(tmp_path / "contain.npz")
    with pytest.raises(ValueError, match="2 cfgs for 3 models"):
        A.detect(got, np.zeros((60, 80), np.uint8), 10, 60, 300.0, cfg=[A.cfg_default()] * 2)


def test_model_file_edge_columns(tmp_path):
    """An edge model's columns (key `cols`) survive save -> load into its vt_acf_cfg; its
    boxes are the edge column's windows only (the left edge's start at floor(4 pad r), the
    right edge's end less than (4 pad + 4) r + 1 px before the frame's; acf.h); a bad value
    is VtError."""
    rng = np.random.default_rng(12)
    img = _road(rng, 200, 320, 80)
    base = _model(rng, 6, 5, 1, 2, 4, leaf_scale=30.0)
    left, right = _model(rng, 6, 5, 1, 2, 4, leaf_scale=30.0), _model(rng, 6, 5, 1, 2, 4, leaf_scale=30.0)
    left.cols, right.cols = int(lib.VT_ACF_COLS_LEFT), int(lib.VT_ACF_COLS_RIGHT)
    base.more = [left, right]
    base.save(tmp_path / "edge.npz")
    got = A.AcfModel.load(tmp_path / "edge.npz")
    assert [m.cols for m in [got] + got.more] == [0, 1, 2]
    assert [m.c_cfg().cols for m in [got] + got.more] == [0, 1, 2]
    cfgs = []
    for m in got.more:
        c = m.c_cfg()
        c.score_min, c.nms_iou_permille = -(2 ** 31), 1000       # every window a box, no NMS
        cfgs.append(c)
    for m, c in zip(got.more, cfgs):
        m2 = A.AcfModel(**{k: getattr(m, k) for k in ("win_cw", "win_ch", "pad", "depth", "feat", "thr", "leaf",
                                                         "leaf_q16", "bias")}, cols=m.cols)
        boxes, info = A.detect(m2, img, 80, 190, 300.0, cfg=c)
        assert info["n_windows"] > 0 and len(boxes) > 0
        r = [A.SCALE_Q16[k] for k in range(15)]
        if m.cols == lib.VT_ACF_COLS_LEFT:
            assert set(boxes["left"]) <= {(4 * m.pad * rk) >> 16 for rk in r}
        else:
            assert all(320 - 1 - b < ((4 * m.pad + 4) * max(r) >> 16) + 1 for b in boxes["right"])  # acf.h
        # one column per level: no more windows than the levels' band rows
        c_all = m2.c_cfg()
        c_all.score_min, c_all.nms_iou_permille, c_all.cols = -(2 ** 31), 1000, 0
        _, info_all = A.detect(m2, img, 80, 190, 300.0, cfg=c_all)
        assert info["n_windows"] < info_all["n_windows"]
    z = dict(np.load(tmp_path / "edge.npz"))
    np.savez(tmp_path / "cols3.npz", **dict(z, acf1_cols=np.int32(3)))
    with pytest.raises(VtError, match="cols 3"):
        A.AcfModel.load(tmp_path / "cols3.npz")


def test_cfg_check_rows():
    c = A.cfg_default()
    assert lib.vt_acf_cfg_check(c) == lib.VT_OK
    assert lib.vt_acf_cfg_check(ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_acf_cfg_default(ffi.NULL) == lib.VT_E_ARG
    rows = [("first_scale", -1), ("first_scale", 16), ("n_scales", 0), ("n_scales", 17),
            ("veh_w_min_mm", 99), ("veh_w_max_mm", 20001), ("slack_px", -1),
            ("slack_px", int(lib.VT_MAX_HEIGHT) + 1), ("above_px", -1), ("above_px", int(lib.VT_MAX_HEIGHT) + 1),
            ("nms_iou_permille", -1), ("nms_iou_permille", 1001), ("n_scales", I32_MAX), ("first_scale", I32_MIN),
            ("nms_contain_permille", -1), ("nms_contain_permille", 1001), ("nms_contain_permille", I32_MIN),
            ("cols", -1), ("cols", 3), ("cols", I32_MIN), ("cols", I32_MAX)]
    for field, v in rows:
        c2 = A.cfg_default()
        setattr(c2, field, v)
        assert lib.vt_acf_cfg_check(c2) == lib.VT_E_ARG, (field, v)
    c2 = A.cfg_default()
    c2.veh_w_min_mm, c2.veh_w_max_mm = 2000, 1999                      # min > max
    assert lib.vt_acf_cfg_check(c2) == lib.VT_E_ARG
    c2 = A.cfg_default()
    c2.first_scale, c2.n_scales = 15, 2                                  # past the last level
    assert lib.vt_acf_cfg_check(c2) == lib.VT_E_ARG
    c2.n_scales = 1
    assert lib.vt_acf_cfg_check(c2) == lib.VT_OK
    for field, v in (("score_min", I32_MIN), ("score_min", I32_MAX), ("nms_iou_permille", 0),
                     ("nms_contain_permille", 0), ("nms_contain_permille", 1000),
                     ("nms_iou_permille", 1000), ("veh_w_max_mm", 20000), ("cols", int(lib.VT_ACF_COLS_LEFT)),
                     ("cols", int(lib.VT_ACF_COLS_RIGHT))):
        c2 = A.cfg_default()
        setattr(c2, field, v)
        assert lib.vt_acf_cfg_check(c2) == lib.VT_OK, (field, v)
    # through the binding: VtError naming vt_acf_detect
    m = _model(np.random.default_rng(0), 4, 4, 0, 1, 2)
    img = np.zeros((40, 40), np.uint8)
    for field, v in (("n_scales", 0), ("first_scale", 16), ("veh_w_min_mm", 5000), ("nms_iou_permille", 1001)):
        c2 = A.cfg_default()
        setattr(c2, field, v)
        with pytest.raises(VtError, match="vt_acf_detect_n: bad argument"):
            A.detect(m, img, 10, 40, 300.0, cfg=c2)
    with pytest.raises(ValueError, match="horizon_y"):                   # the camera's own check
        A.detect(m, img, 10 ** 6, 40, 300.0)


def test_python_bad_images():
    m = _model(np.random.default_rng(0), 4, 4, 0, 1, 1)
    for fn in (A.channels, lambda g: A.resample(g, 1), lambda g: A.detect(m, g, 5, 8, 300.0)):
        with pytest.raises(TypeError, match="numpy.ndarray"):
            fn([[1, 2], [3, 4]])
        with pytest.raises(TypeError, match="uint8"):
            fn(np.zeros((8, 8), np.float32))
        with pytest.raises(ValueError, match="2-D"):
            fn(np.zeros((8, 8, 3), np.uint8))
    for shape in ((3, 8), (8, 3), (0, 8), (1, 1)):
        with pytest.raises(ValueError, match="at least 4x4"):
            A.channels(np.zeros(shape, np.uint8))
    img = np.zeros((20, 20), np.uint8)
    for k in (-1, 16):
        with pytest.raises(ValueError, match="level k"):
            A.resample(img, k)
    with pytest.raises(ValueError, match="has no level"):
        A.resample(np.zeros((10, 10), np.uint8), 14)                     # 10 px / 11.3 -> 0 px
    with pytest.raises(VtError, match="vt_acf_channels: bad size"):
        A.channels(img, 4, 2)                                            # rows 4..5 of 5 cell rows
    with pytest.raises(VtError, match="vt_acf_channels: bad size"):
        A.channels(img, -1, 1)
    with pytest.raises(VtError, match="vt_acf_detect_n: bad size"):
        A.detect(m, np.zeros((8, lib.VT_MAX_WIDTH + 1), np.uint8), 2, 8, 300.0)
    with pytest.raises(VtError, match="vt_acf_score: bad size"):
        m.score_c(np.zeros((8, 3, 9), np.uint8), 0, 0)                   # 3 rows < 4
    with pytest.raises(VtError, match="vt_acf_score: bad size"):
        m.score_c(np.zeros((8, 9, 9), np.uint8), 6, 0)                   # past the columns


def _u8(arr):
    return N.view(arr, "img")


def test_c_null_and_size_rows():
    """Every ACF function: NULLs -> VT_E_ARG, bad sizes -> VT_E_SIZE, a short out -> VT_E_CAPACITY,
    nothing written on an error; vt_acf_detect leaves n_boxes 0 on every error."""
    ws = A._ws()
    img = np.arange(24 * 20, dtype=np.int64).astype(np.uint8).reshape(20, 24)
    v = _u8(img)
    out = np.full(8 * 5 * 6 + 4, 0xA5, np.uint8)
    po = ffi.cast("uint8_t *", out.ctypes.data)
    need = 8 * 5 * 6
    # channels
    assert lib.vt_acf_channels(ffi.NULL, v, 0, 5, po, need) == lib.VT_E_ARG
    assert lib.vt_acf_channels(ws, ffi.NULL, 0, 5, po, need) == lib.VT_E_ARG
    assert lib.vt_acf_channels(ws, v, 0, 5, ffi.NULL, need) == lib.VT_E_ARG
    for cy0, n in ((-1, 1), (0, 0), (0, 6), (5, 1), (4, 2), (0, I32_MAX), (I32_MAX, 1), (I32_MIN, 1)):
        assert lib.vt_acf_channels(ws, v, cy0, n, po, need) == lib.VT_E_SIZE, (cy0, n)
    for cap in (need - 1, 0, -1, I32_MIN):
        assert lib.vt_acf_channels(ws, v, 0, 5, po, cap) == lib.VT_E_CAPACITY, cap
    assert (out == 0xA5).all()
    for w, h in ((3, 20), (24, 3)):
        small = np.zeros((h, w), np.uint8)
        assert lib.vt_acf_channels(ws, _u8(small), 0, 1, po, need) == lib.VT_E_SIZE
    bad = _u8(img)
    bad.stride = 23
    assert lib.vt_acf_channels(ws, bad, 0, 1, po, need) == lib.VT_E_SIZE
    bad.px = ffi.NULL
    assert lib.vt_acf_channels(ws, bad, 0, 1, po, need) == lib.VT_E_ARG
    assert lib.vt_acf_channels(ws, v, 0, 5, po, need) == lib.VT_OK
    assert (out[need:] == 0xA5).all()                                   # exactly 8 n_cy (w / 4) bytes
    # resample
    dbuf = np.full((20, 24), 0xA5, np.uint8)
    d = N.view(dbuf, "dst", writable=True)
    r1 = A.SCALE_Q16[1]
    lw, lh = A.level_size(24, r1), A.level_size(20, r1)
    d.w, d.h = lw, lh
    assert lib.vt_acf_resample(ffi.NULL, v, r1, 0, d) == lib.VT_E_ARG
    assert lib.vt_acf_resample(ws, ffi.NULL, r1, 0, d) == lib.VT_E_ARG
    assert lib.vt_acf_resample(ws, v, r1, 0, ffi.NULL) == lib.VT_E_ARG
    for r in (Q16 - 1, 16 * Q16 + 1, 0, I32_MIN):
        assert lib.vt_acf_resample(ws, v, r, 0, d) == lib.VT_E_ARG, r
    for dw, dh, y0 in ((lw + 1, 1, 0), (lw, lh, 1), (0, 1, 0), (1, 0, 0), (1, 1, -1), (1, 1, lh), (1, 2, lh - 1),
                       (1, I32_MAX, 0), (1, 1, I32_MAX)):
        d.w, d.h = dw, dh
        assert lib.vt_acf_resample(ws, v, r1, y0, d) == lib.VT_E_SIZE, (dw, dh, y0)
    d.w, d.h, d.stride = 4, 2, 3
    assert lib.vt_acf_resample(ws, v, r1, 0, d) == lib.VT_E_SIZE          # stride < w
    assert (dbuf == 0xA5).all()
    d.stride = 24
    d.px = ffi.NULL
    assert lib.vt_acf_resample(ws, v, r1, 0, d) == lib.VT_E_ARG
    d.px = ffi.cast("uint8_t *", dbuf.ctypes.data)
    assert lib.vt_acf_resample(ws, v, 16 * Q16, 0, d) == lib.VT_E_SIZE     # 24 / 16 = 1 column, 20 / 16 = 1 row
    d.w, d.h = 1, 1
    assert lib.vt_acf_resample(ws, v, 16 * Q16, 0, d) == lib.VT_OK
    assert dbuf[0, 0] == (int(img[:16, :16].astype(np.int64).sum()) + 128) // 256 and dbuf[0, 1] == 0xA5
    # score
    m = _model(np.random.default_rng(4), 4, 4, 0, 2, 3)
    cm = m.c_model()[0]
    planes = np.zeros((8, 6, 6), np.uint8)
    pp = ffi.cast("uint8_t *", planes.ctypes.data)
    s = ffi.new("int32_t *", 12345)
    assert lib.vt_acf_score(ffi.NULL, pp, 6, 6, 0, 0, s) == lib.VT_E_ARG
    assert lib.vt_acf_score(cm, ffi.NULL, 6, 6, 0, 0, s) == lib.VT_E_ARG
    assert lib.vt_acf_score(cm, pp, 6, 6, 0, 0, ffi.NULL) == lib.VT_E_ARG
    for rows, cols, cx, cy in ((0, 6, 0, 0), (6, 0, 0, 0), (3, 6, 0, 0), (6, 3, 0, 0), (6, 6, 3, 0), (6, 6, 0, 3),
                               (6, 6, -1, 0), (6, 6, 0, -1), (I32_MAX, I32_MAX, 0, 0), (2 ** 15, 2 ** 15, 0, 0),
                               (6, 6, I32_MIN, 0), (-6, -6, 0, 0)):
        assert lib.vt_acf_score(cm, pp, rows, cols, cx, cy, s) == lib.VT_E_SIZE, (rows, cols, cx, cy)
    assert s[0] == 12345
    bad_m = ffi.new("vt_acf_model *", cm[0])
    bad_m.depth = 0
    assert lib.vt_acf_score(bad_m, pp, 6, 6, 0, 0, s) == lib.VT_E_ARG
    assert lib.vt_acf_score(cm, pp, 6, 6, 2, 2, s) == lib.VT_OK
    # detect
    cfg = A.cfg_default()
    cam = N.camera_min(300.0, 5, 1800, 20)
    res = ffi.new("vt_fulldet_result *")
    g = np.zeros((20, 24), np.uint8)
    for args in ((ffi.NULL, cm, cfg, cam, _u8(g)), (ws, ffi.NULL, cfg, cam, _u8(g)), (ws, cm, ffi.NULL, cam, _u8(g)),
                 (ws, cm, cfg, ffi.NULL, _u8(g)), (ws, cm, cfg, cam, ffi.NULL)):
        res.n_boxes = 7
        assert lib.vt_acf_detect(*args, res) == lib.VT_E_ARG
        assert res.n_boxes == 0
    assert lib.vt_acf_detect(ws, cm, cfg, cam, _u8(g), ffi.NULL) == lib.VT_E_ARG
    for field, val, want in (("hood_y", 0, lib.VT_E_ARG), ("height_mm", 99, lib.VT_E_ARG),
                             ("horizon_y", int(lib.VT_MAX_HEIGHT) + 1, lib.VT_E_ARG), ("fx_q4", 15, lib.VT_E_ARG)):
        c2 = ffi.new("vt_camera_min *", cam[0])
        setattr(c2, field, val)
        res.n_boxes = 7
        assert lib.vt_acf_detect(ws, cm, cfg, c2, _u8(g), res) == want, field
        assert res.n_boxes == 0
    wide = np.zeros((2, int(lib.VT_MAX_WIDTH) + 2), np.uint8)
    for dims in ((0, 20, 24), (24, 20, 23), (int(lib.VT_MAX_WIDTH) + 1, 1, int(lib.VT_MAX_WIDTH) + 1)):
        bv = _u8(wide)
        bv.w, bv.h, bv.stride = dims
        res.n_boxes = 7
        assert lib.vt_acf_detect(ws, cm, cfg, cam, bv, res) == lib.VT_E_SIZE, dims
        assert res.n_boxes == 0
    res.n_boxes = 7
    assert lib.vt_acf_detect(ws, bad_m, cfg, cam, _u8(g), res) == lib.VT_E_ARG and res.n_boxes == 0
    # tiny frames are fine: no level holds a window
    for h_, w_ in ((1, 1), (3, 200), (200, 3)):
        t = np.zeros((h_, w_), np.uint8)
        assert lib.vt_acf_detect(ws, cm, cfg, N.camera_min(300.0, 0, 1800, h_), _u8(t), res) == lib.VT_OK
        assert res.n_boxes == 0 and res.n_windows == 0
    # detect_n: n, the arrays and each entry
    n_arr = int(lib.VT_ACF_MAX_MODELS) + 1    # room for the n one past the limit
    mp = ffi.new(f"vt_acf_model *[{n_arr}]", [cm] * n_arr)
    cp = ffi.new(f"vt_acf_cfg *[{n_arr}]", [cfg] * n_arr)
    bad_c = ffi.new("vt_acf_cfg *", cfg[0])
    bad_c.n_scales = 0
    for n, m_, c_ in ((0, mp, cp), (-1, mp, cp), (int(lib.VT_ACF_MAX_MODELS) + 1, mp, cp), (I32_MIN, mp, cp),
                      (2, ffi.NULL, cp), (2, mp, ffi.NULL)):
        res.n_boxes = 7
        assert lib.vt_acf_detect_n(ws, n, m_, c_, cam, _u8(g), res) == lib.VT_E_ARG, n
        assert res.n_boxes == 0
    for i, (mm, cc) in enumerate(((ffi.NULL, cfg), (cm, ffi.NULL), (bad_m, cfg), (cm, bad_c))):
        m2 = ffi.new("vt_acf_model *[2]", [cm, mm])
        c2 = ffi.new("vt_acf_cfg *[2]", [cfg, cc])
        res.n_boxes = 7
        assert lib.vt_acf_detect_n(ws, 2, m2, c2, cam, _u8(g), res) == lib.VT_E_ARG, i
        assert res.n_boxes == 0
    assert lib.vt_acf_detect_n(ffi.NULL, 2, mp, cp, cam, _u8(g), res) == lib.VT_E_ARG
    assert lib.vt_acf_detect_n(ws, 2, mp, cp, cam, _u8(g), ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_acf_detect_n(ws, int(lib.VT_ACF_MAX_MODELS), mp, cp, cam, _u8(g), res) == lib.VT_OK


def test_pipeline_set_acf_n_rows():
    """vt_pipeline_set_acf_n: n outside 0..VT_ACF_MAX_MODELS, NULL arrays, entries or scratch,
    a bad model or cfg -> VT_E_ARG with nothing changed; n = 0 (and set_acf with m NULL)
    turn the stage off."""
    rng = np.random.default_rng(3)
    cm, keep = _cmodel(_model(rng, 6, 5, 1, 2, 3))
    cfg = A.cfg_default()
    p = ffi.new("vt_pipeline *")
    pc = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(pc) == lib.VT_OK
    assert lib.vt_pipeline_init(p, pc, ffi.NULL, ffi.NULL) == lib.VT_OK
    ws = ffi.new("vt_acf_ws *")
    mp = ffi.new("vt_acf_model *[2]", [cm, cm])
    cp = ffi.new("vt_acf_cfg *[2]", [cfg, cfg])
    assert lib.vt_pipeline_set_acf_n(p, 2, mp, cp, ws) == lib.VT_OK
    assert p.acf_n == 2 and p.acf == cm and p.acf_ws == ws
    bad_m = ffi.new("vt_acf_model *", cm[0])
    bad_m.depth = 0
    bad_c = ffi.new("vt_acf_cfg *", cfg[0])
    bad_c.nms_iou_permille = 1001
    rows = [(ffi.NULL, 1, mp, cp, ws), (p, -1, mp, cp, ws), (p, int(lib.VT_ACF_MAX_MODELS) + 1, mp, cp, ws),
            (p, 1, ffi.NULL, cp, ws), (p, 1, mp, ffi.NULL, ws), (p, 1, mp, cp, ffi.NULL),
            (p, 2, ffi.new("vt_acf_model *[2]", [cm, ffi.NULL]), cp, ws),
            (p, 2, mp, ffi.new("vt_acf_cfg *[2]", [cfg, ffi.NULL]), ws),
            (p, 2, ffi.new("vt_acf_model *[2]", [cm, bad_m]), cp, ws),
            (p, 2, mp, ffi.new("vt_acf_cfg *[2]", [cfg, bad_c]), ws)]
    for i, args in enumerate(rows):
        assert lib.vt_pipeline_set_acf_n(*args) == lib.VT_E_ARG, i
        assert p.acf_n == 2 and p.acf == cm, i
    assert lib.vt_pipeline_set_acf_n(p, 0, ffi.NULL, ffi.NULL, ffi.NULL) == lib.VT_OK
    assert p.acf_n == 0 and p.acf == ffi.NULL
    assert lib.vt_pipeline_set_acf(p, cm, cfg, ws) == lib.VT_OK and p.acf_n == 1
    assert lib.vt_pipeline_set_acf(p, ffi.NULL, ffi.NULL, ffi.NULL) == lib.VT_OK and p.acf_n == 0


def test_defaults():
    """The documented defaults (acf.h, VT_ACF_CFG_DEFAULT)."""
    c = A.cfg_default()
    assert (c.first_scale, c.n_scales, c.veh_w_min_mm, c.veh_w_max_mm, c.slack_px, c.above_px, c.score_min,
            c.nms_iou_permille, c.nms_contain_permille) == (0, 15, 1080, 3960, 20, 5, 0, 300, 1000)
    # the oracle's band defaults are the C's
    import inspect
    p = inspect.signature(R.band_ok).parameters
    assert (p["veh_w_min_mm"].default, p["veh_w_max_mm"].default, p["slack_px"].default,
            p["above_px"].default) == (c.veh_w_min_mm, c.veh_w_max_mm, c.slack_px, c.above_px)


@pytest.fixture(scope="module", autouse=True)
def _print_measured_differences():
    """After the module: what the random cases measured (shown with pytest -s)."""
    yield
    if RESAMPLE_STATS["n"]:
        print(f"\nacf resample: max |diff| {RESAMPLE_STATS['max']}, {RESAMPLE_STATS['neq']} of "
              f"{RESAMPLE_STATS['n']} px differ")
    if CHANNEL_STATS["n"]:
        print(f"acf channels: max |diff| per channel {CHANNEL_STATS['max'].tolist()}, fraction of cells "
              f"differing {(CHANNEL_STATS['neq'] / CHANNEL_STATS['n']).round(4).tolist()}")
    if SCORE_STATS["n"]:
        print(f"acf scores: max |C - float| {SCORE_STATS['max']:.4f} Q16 LSB over {SCORE_STATS['n']} windows")
    if DETECT_STATS["cases"] or DETECT_STATS["multi_cases"]:
        print(f"acf detect: {DETECT_STATS}")
