"""Frame-level CNN detection over pyramid levels (include/vehtrack/cnn.h vt_cnn_detect_frame,
pyvehtrack.cnn.detect_frame) against its integer twin (pyvehtrack/reference/cnn.py
detect_frame: reference.image.pyr_down, the forward / decode twins, clipping, NMS with
reference.windows.suppresses).

Tolerance: 0 LSB / 0 px. The pyramid twin is exact (sums of 1/256 steps in float64, rounded
half up as the C), the forward pass and the decode are bit-exact twins, NMS is the same
permille test after the same stable sort, so any difference is a bug:
  * hypothesis: random small models (1-4 layers, strides 1..8), frames 8..200 x 8..120 with a
    padded row stride, every cfg field drawn (levels 0..5, threshold offsets that give many
    peaks or none, small caps, NMS limits 0..1000), a caller's cap that truncates: the same
    boxes in the same order and the same peak count; nothing written outside the work
    buffer's needed bytes or past boxes[*n] (guard bytes), whatever the buffer's alignment;
  * a constant head (every cell a peak, ties everywhere): NMS order is level then raster,
    boxes past the frame are clipped, a box entirely outside dropped, counted in n_peaks;
  * bad arguments: each cfg field just outside its range refused (C VT_E_ARG, Python
    ValueError naming it), work one byte short VT_E_CAPACITY, frames past VT_MAX_* VT_E_SIZE.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyvehtrack import cnn as C
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.reference import cnn as R
from test_cnn import layer, random_model

GUARD = 0xA5
I32_MIN, I32_MAX = -(2 ** 31), 2 ** 31 - 1
FIELDS = ("first_level", "n_levels", "thr_offset", "cap_per_level", "nms_iou_permille", "nms_contain_permille",
          "l0_top_permille", "l0_bottom_permille", "stretch_tail_permille")


def c_cfg(**kw):
    c = ffi.new("vt_cnn_cfg *")
    assert lib.vt_cnn_cfg_default(c) == lib.VT_OK
    for k, v in kw.items():
        setattr(c, k, v)
    return c


def c_detect_guarded(model, img, cfg, cap, pad=0, slack=16, shift=0):
    """vt_cnn_detect_frame through cffi: the image's rows padded by `pad` bytes, the work buffer
    starting `shift` bytes past an aligned address and both it and the boxes inside sentinels.
    Returns (boxes (n, 5), n_peaks, guards intact)."""
    h, w = img.shape
    big = np.full((h, w + pad), 77, np.uint8)
    big[:, :w] = img
    m = model.c_model()[0]
    nb = ffi.new("size_t *")
    assert lib.vt_cnn_frame_work_bytes(m, cfg, w, h, nb) == lib.VT_OK
    work = np.full(nb[0] + 2 * slack + 8, GUARD, np.uint8)
    start = slack + shift
    boxes = ffi.new("vt_cnn_box[]", cap + 3)
    sentinel = (0x5A5A5A5A,) * 5
    for i in range(cap + 3):
        boxes[i] = sentinel
    n, tot = ffi.new("int32_t *"), ffi.new("int32_t *")
    s = lib.vt_cnn_detect_frame(m, cfg, ffi.cast("uint8_t *", big.ctypes.data), w, h, w + pad,
                                ffi.cast("uint8_t *", work.ctypes.data) + start, nb[0], boxes, cap, n, tot)
    assert s == lib.VT_OK, s
    got = np.array([[boxes[i].l, boxes[i].t, boxes[i].r, boxes[i].b, boxes[i].score] for i in range(n[0])],
                   np.int64).reshape(-1, 5)
    ok = bool((work[:start] == GUARD).all() and (work[start + nb[0]:] == GUARD).all())
    ok = ok and all(tuple([boxes[i].l, boxes[i].t, boxes[i].r, boxes[i].b, boxes[i].score]) == sentinel
                    for i in range(n[0], cap + 3))
    return got, int(tot[0]), ok


spec_layer = st.tuples(st.sampled_from([1, 3]), st.sampled_from([1, 2]), st.sampled_from([1, 2]),
                       st.integers(1, 6))


@st.composite
def frame_cfgs(draw):
    first = draw(st.integers(0, int(lib.VT_CNN_MAX_LEVEL) - 1))
    n_levels = draw(st.integers(1, min(int(lib.VT_CNN_MAX_RUN_LEVELS), int(lib.VT_CNN_MAX_LEVEL) - first + 1)))
    return dict(first_level=first, n_levels=n_levels,
                thr_offset=draw(st.sampled_from([-300, -100, -40, -10, 0, 10, 200, I32_MIN, I32_MAX])),
                cap_per_level=draw(st.sampled_from([1, 2, 5, 17, 64, int(lib.VT_CNN_MAX_PEAKS)])),
                nms_iou_permille=draw(st.sampled_from([0, 200, 500, 999, 1000])),
                nms_contain_permille=draw(st.sampled_from([0, 500, 800, 1000])),
                stretch_tail_permille=draw(st.sampled_from([0, 0, 1, 5, 50, 100])))


@given(st.lists(spec_layer, min_size=0, max_size=3), st.sampled_from([1, 3]), st.integers(8, 200),
       st.integers(8, 120), st.integers(0, 5), st.integers(0, 2 ** 32 - 1), frame_cfgs(),
       st.sampled_from(["noise", "blobs", "flat"]), st.integers(1, 40), st.integers(0, 7))
def test_detect_frame_equals_twin(hidden, last_k, w, h, pad, seed, cfgd, kind, cap, shift):
    rng = np.random.default_rng(seed)
    spec = [(k, s, d if k == 3 else 1, c) for k, s, d, c in hidden] + [(last_k, 1, 1, 5)]
    if kind == "noise":
        img = rng.integers(0, 256, (h, w)).astype(np.uint8)
    elif kind == "flat":
        img = np.full((h, w), int(rng.integers(0, 256)), np.uint8)
    else:   # dark boxes on a ramp: structure at every level
        img = np.tile(np.linspace(90, 200, h).astype(np.uint8)[:, None], (1, w))
        for _ in range(4):
            x0, y0 = int(rng.integers(0, w)), int(rng.integers(0, h))
            img[y0:y0 + int(rng.integers(2, 40)), x0:x0 + int(rng.integers(2, 50))] = int(rng.integers(0, 60))
    lut = rng.integers(0, 600, (4, 256))    # sides up to 37 level px: boxes that overlap and cross the border
    model = random_model(rng, spec, img, 60.0, lut)
    got = check_c_equals_twin(model, img, cfgd, cap, pad, shift)
    assert (got[:, 0] <= got[:, 2]).all() and (got[:, 1] <= got[:, 3]).all()
    assert (np.diff(got[:, 4]) <= 0).all()     # NMS order: heat descending


def check_c_equals_twin(model, img, cfgd, cap, pad, shift):
    """vt_cnn_detect_frame (guarded, c_detect_guarded) = the twin's first cap boxes and its peak
    count, nothing written outside, every box inside the frame; the Python wrapper = every kept
    box of the twin (its cap is n_levels x cap_per_level). Returns C's boxes."""
    h, w = img.shape
    got, tot, intact = c_detect_guarded(model, img, c_cfg(**cfgd), cap, pad, shift=shift)
    want, want_tot = R.detect_frame(model, img, cfgd)
    assert tot == want_tot
    np.testing.assert_array_equal(got, want[:cap])
    assert intact, "vt_cnn_detect_frame wrote outside vt_cnn_frame_work_bytes or past boxes[*n]"
    assert ((got[:, 0] >= 0) & (got[:, 2] < w) & (got[:, 1] >= 0) & (got[:, 3] < h)).all()
    pb, pt = C.detect_frame(model, img, C.CnnConfig(**cfgd))
    assert pt == want_tot
    np.testing.assert_array_equal(pb, want)
    return got


# ---------------------------------------------------------------- a constant head
def const_model(heat=5, sides=(0, 0, 0, 0), strides=(2, 2, 2), lut=None):
    """Layers of 1x1 zero weights: hidden outputs 0, the head's channels the constants
    (bias 2v, mult 1, shift 1: q = floor((2v + 1) / 2) = v)."""
    layers = []
    n = len(strides)
    for i, s in enumerate(strides):
        last = i == n - 1
        cout = 5 if last else 1
        bias = [2 * v for v in (heat, *sides)] if last else [0]
        layers.append(layer(1, s, 1, 0 if last else 1, 1, cout, np.zeros(cout), bias, np.ones(cout), np.ones(cout)))
    if lut is None:
        lut = np.tile(np.arange(256), (4, 1))
    return C.CnnModel(layers, np.asarray(lut, np.uint16), 0, heat_scale_q16=3 * 65536)


def test_constant_head_order_clip_drop():
    """heat 5 everywhere: every cell of every level is a peak, all tied. S = 8, identity LUT,
    side codes (l, t, r, b) = (-128 + 16 ...): the Q4 sides are (code + 128); at level k a
    cell's box is its centre -16..+48 Q4 (-1..+3 px), times 2^k. Frame 20 x 9: level 0's grid
    is 3 x 2, level 1 (10 x 5) 2 x 1; cell x = 2 of level 0 has its centre at column 20,
    outside the frame: l = 20 - 1 = 19 (in), r = 20 + 3 - 1 = 22 -> clipped to 19. Cell (1, 0)
    of level 1: centre 12 level px = 24 frame px: l = 24 - 2 = 22 > 19: dropped."""
    lut = np.tile(np.arange(256), (4, 1))
    m = const_model(5, (-112, -112, -80, -80), lut=lut)    # l = t = 16 Q4 (1 px), r = b = 48 Q4 (3 px)
    img = np.zeros((9, 20), np.uint8)
    cfgd = dict(first_level=0, n_levels=2, thr_offset=0, cap_per_level=64, nms_iou_permille=1000,
                nms_contain_permille=1000)
    b, n = C.detect_frame(m, img, C.CnnConfig(**cfgd))
    assert n == 3 * 2 + 2 * 1
    want = [
        # level 0, raster: centres (4, 4), (12, 4), (20, 4), (4, 12), ...: l = c - 1, r = c + 3 - 1
        [3, 3, 6, 6, 5], [11, 3, 14, 6, 5], [19, 3, 19, 6, 5],
        [3, 11, 6, 8, 5], [11, 11, 14, 8, 5], [19, 11, 19, 8, 5],
        # level 1: centre (4, 4) level px -> Q4 64 -> l = (64 - 16) 2 = 96 Q4 = 6 px, r = (64 + 48) 2 = 14 - 1
        [6, 6, 13, 8, 5],
    ]
    want = [r for r in want if r[1] <= r[3]]   # rows 11.. are below the 9-row frame: dropped
    assert b.tolist() == want
    rb, rn = R.detect_frame(m, img, cfgd)
    assert rn == n and rb.tolist() == want
    # the caller's cap truncates, the peak count does not
    cfg = c_cfg(**cfgd)
    got, tot, ok = c_detect_guarded(m, img, cfg, 2)
    assert got.tolist() == want[:2] and tot == 8 and ok
    # thr_offset past every heat: nothing; far below: the same as -128
    assert C.detect_frame(m, img, C.CnnConfig(**{**cfgd, "thr_offset": 123}))[1] == 0
    assert C.detect_frame(m, img, C.CnnConfig(**{**cfgd, "thr_offset": I32_MIN}))[1] == 8
    assert C.detect_frame(m, img, C.CnnConfig(**{**cfgd, "thr_offset": I32_MAX}))[1] == 0
    # NMS at IoU 0 keeps one box of each overlapping cluster, the first in order
    b0, _ = C.detect_frame(m, img, C.CnnConfig(**{**cfgd, "nms_iou_permille": 0}))
    assert b0.tolist()[0] == want[0] and len(b0) < len(want)


def test_deepest_level_and_scale_shift_5():
    """first_level 4, n_levels 2: levels 4 and 5 (decode's scale_shift 5)."""
    m = const_model(7, (0, 0, 0, 0), strides=(1,))
    img = np.full((120, 200), 100, np.uint8)
    cfgd = dict(first_level=4, n_levels=2, thr_offset=0, cap_per_level=256, nms_iou_permille=1000,
                nms_contain_permille=1000)
    b, n = C.detect_frame(m, img, C.CnnConfig(**cfgd))
    # levels: 200x120 -> 100x60 -> 50x30 -> 25x15 -> 13x8 (4) -> 7x4 (5); stride 1: a cell per pixel
    assert n == 13 * 8 + 7 * 4
    rb, rn = R.detect_frame(m, img, cfgd)
    assert rn == n and (b == rb).all()


# ---------------------------------------------------------------- sizes
def test_frame_work_bytes_layout():
    """One case by hand: stride-2 one-layer model, levels 1..2 of a 21 x 11 frame, cap 3.
    Boxes: 2 x 3 x 24 (vt_scored_box) + 3 x 20 (vt_cnn_box) = 204; level 1 11 x 6 = 66, level 2
    6 x 3 = 18; forward work 0 (one layer); outputs 6 x 3 x 5 = 90 (level 1's grid); + 7 align."""
    m = C.CnnModel([layer(1, 2, 1, 0, 1, 5, np.ones(5), np.zeros(5), np.ones(5), np.ones(5))],
                   np.zeros((4, 256), np.uint16))
    assert ffi.sizeof("vt_scored_box") == 24 and ffi.sizeof("vt_cnn_box") == 20
    cfg = C.CnnConfig(first_level=1, n_levels=2, cap_per_level=3)
    assert C.frame_work_bytes(m, 21, 11, cfg) == 204 + 66 + 18 + 0 + 90 + 7
    # level 0 runs on the caller's frame: no level image
    cfg0 = C.CnnConfig(first_level=0, n_levels=1, cap_per_level=3)
    assert C.frame_work_bytes(m, 21, 11, cfg0) == 3 * 24 + 3 * 20 + 11 * 6 * 5 + 7
    # the contrast stretch adds the stretched frame, 21 x 11 bytes
    assert C.frame_work_bytes(m, 21, 11, C.CnnConfig(first_level=1, n_levels=2, cap_per_level=3,
                                                     stretch_tail_permille=5)) == 204 + 66 + 18 + 90 + 7 + 231


def test_stretch_by_hand():
    """cnn.h's rule on a frame whose histogram is known: 1000 pixels, 10 at level 3, 980 at 100..
    (spread over 100..179), 10 at 250. Tail 10 permille: k = 10, lo = the least level with more
    than 10 pixels at or below it = 100 (10 at 3, then the first of 100..179), hi = 179 likewise;
    span 79; x = 140 -> floor((40 x 510 + 79) / 158) = 129; 3 -> 0; 250 -> 255 (clamped).
    Tail 0: lo = 3, hi = 250, span 247. A flat frame: span 64, its level maps to 0."""
    mid = np.repeat(np.arange(100, 180), [13] * 20 + [12] * 60)[:980]
    img = np.concatenate([np.full(10, 3), mid, np.full(10, 250)]).astype(np.uint8).reshape(20, 50)
    assert mid.size == 980 and mid.max() == 179
    out = R.stretch(img, 10)
    lut = {int(a): int(b) for a, b in zip(img.ravel(), out.ravel())}
    assert lut[3] == 0 and lut[100] == 0 and lut[140] == (40 * 510 + 79) // 158 == 129 and lut[250] == 255
    assert lut[179] == 255 and lut[178] == (78 * 510 + 79) // 158
    out0 = R.stretch(img, 0)
    assert {int(a): int(b) for a, b in zip(img.ravel(), out0.ravel())}[140] == (137 * 510 + 247) // 494
    assert (R.stretch(np.full((4, 4), 77, np.uint8), 5) == 0).all()
    # C takes the same rule: a 1x1 stride-1 head whose heat is (x + 1) >> 1 of the pixel it sees,
    # so which cells peak above the threshold (heat 60: a seen level >= 119) is the stretch's doing
    hd = layer(1, 1, 1, 0, 1, 5, [1, 0, 0, 0, 0], np.zeros(5), np.ones(5), np.ones(5))
    m = C.CnnModel([hd], np.tile(np.arange(256), (4, 1)).astype(np.uint16), 60, heat_scale_q16=65536)
    rng = np.random.default_rng(4)
    img2 = np.clip(rng.normal(120, 12, (40, 64)), 0, 255).astype(np.uint8)   # low contrast
    peaks = {}
    for tail in (0, 5, 10):
        cfg = dict(first_level=0, n_levels=1, thr_offset=0, cap_per_level=256, nms_iou_permille=500,
                   nms_contain_permille=800, stretch_tail_permille=tail)
        got, tot, intact = c_detect_guarded(m, img2, c_cfg(**cfg), 256, 3)
        want, want_tot = R.detect_frame(m, img2, cfg)
        np.testing.assert_array_equal(got, want[:256])
        assert intact and tot == want_tot
        peaks[tail] = tot
    assert peaks[5] != peaks[0] and peaks[10] != peaks[0]   # the stretch changes what the head sees


# ---------------------------------------------------------------- bad arguments
CFG_BOUNDS = [   # (field, lowest accepted, highest accepted) with the other fields at the defaults
    ("first_level", 0, int(lib.VT_CNN_MAX_LEVEL) - 1),
    ("n_levels", 1, 5),    # first_level 1: 1 + 5 - 1 = 5 <= 5; 6 is past VT_CNN_MAX_RUN_LEVELS too
    ("cap_per_level", 1, int(lib.VT_CNN_MAX_PEAKS)),
    ("nms_iou_permille", 0, 1000),
    ("nms_contain_permille", 0, 1000),
    ("l0_top_permille", 0, 999),       # bottom 1000: top 1000 is an empty band
    ("l0_bottom_permille", 1, 1000),   # top 0: bottom 0 is an empty band
    ("stretch_tail_permille", 0, 100),
]


@pytest.mark.parametrize("field,lo,hi", CFG_BOUNDS, ids=[b[0] for b in CFG_BOUNDS])
def test_cfg_field_bounds(field, lo, hi):
    m = const_model()
    cm = m.c_model()[0]
    nb = ffi.new("size_t *")
    for v, ok in ((lo, True), (hi, True), (lo - 1, False), (hi + 1, False), (I32_MIN, False), (I32_MAX, False)):
        kw = {field: v}
        if field == "first_level" and ok:
            kw["n_levels"] = 1
        cfg = c_cfg(**kw)
        assert (lib.vt_cnn_cfg_check(cfg) == lib.VT_OK) == ok, (field, v)
        assert (lib.vt_cnn_frame_work_bytes(cm, cfg, 16, 16, nb) == lib.VT_OK) == ok, (field, v)
        if ok:
            C.detect_frame(m, np.zeros((16, 16), np.uint8), C.CnnConfig(**kw))
        else:
            with pytest.raises(ValueError, match=field):
                C.CnnConfig(**kw).c()


def test_cfg_level_sum_and_defaults():
    d = C.CnnConfig().c()
    assert [getattr(d, f) for f in FIELDS] == [1, 3, 0, 64, 500, 800, 0, 1000, 0]
    assert lib.vt_cnn_cfg_check(ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_cnn_cfg_default(ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_cnn_cfg_check(c_cfg(first_level=2, n_levels=4)) == lib.VT_OK     # levels 2..5
    assert lib.vt_cnn_cfg_check(c_cfg(first_level=3, n_levels=4)) == lib.VT_E_ARG  # level 6
    with pytest.raises(ValueError, match="deepest level"):
        C.CnnConfig(first_level=3, n_levels=4).c()
    # thr_offset: any int32
    for v in (I32_MIN, -1, 0, I32_MAX):
        assert lib.vt_cnn_cfg_check(c_cfg(thr_offset=v)) == lib.VT_OK
    with pytest.raises(TypeError, match="CnnConfig.cap_per_level"):
        C.CnnConfig(cap_per_level=True).c()
    with pytest.raises(ValueError, match="CnnConfig.thr_offset"):
        C.CnnConfig(thr_offset=2 ** 31).c()


def test_detect_frame_bad_args():
    m = const_model()
    cm = m.c_model()[0]
    w, h = 24, 20
    cfg = c_cfg()
    nb = C.frame_work_bytes(m, w, h)
    img = np.zeros((h, w + 2), np.uint8)
    work = np.zeros(nb + 8, np.uint8)
    b = ffi.new("vt_cnn_box[4]")
    n, t = ffi.new("int32_t *"), ffi.new("int32_t *")
    pi, pw = ffi.cast("uint8_t *", img.ctypes.data), ffi.cast("uint8_t *", work.ctypes.data)
    f = lib.vt_cnn_detect_frame
    big = lib.VT_MAX_WIDTH + 1
    rows = [
        ((cm, cfg, pi, w, h, w, pw, nb, b, 4, n, t), lib.VT_OK),
        ((ffi.NULL, cfg, pi, w, h, w, pw, nb, b, 4, n, t), lib.VT_E_ARG),
        ((cm, ffi.NULL, pi, w, h, w, pw, nb, b, 4, n, t), lib.VT_E_ARG),
        ((cm, c_cfg(n_levels=0), pi, w, h, w, pw, nb, b, 4, n, t), lib.VT_E_ARG),
        ((cm, cfg, ffi.NULL, w, h, w, pw, nb, b, 4, n, t), lib.VT_E_ARG),
        ((cm, cfg, pi, w, h, w, ffi.NULL, nb, b, 4, n, t), lib.VT_E_ARG),
        ((cm, cfg, pi, w, h, w, pw, nb, ffi.NULL, 4, n, t), lib.VT_E_ARG),
        ((cm, cfg, pi, w, h, w, pw, nb, b, 0, n, t), lib.VT_E_ARG),
        ((cm, cfg, pi, w, h, w, pw, nb, b, I32_MIN, n, t), lib.VT_E_ARG),
        ((cm, cfg, pi, 0, h, w, pw, nb, b, 4, n, t), lib.VT_E_SIZE),
        ((cm, cfg, pi, w, -1, w, pw, nb, b, 4, n, t), lib.VT_E_SIZE),
        ((cm, cfg, pi, w, h, w - 1, pw, nb, b, 4, n, t), lib.VT_E_SIZE),
        ((cm, cfg, pi, big, 1, big, pw, nb, b, 4, n, t), lib.VT_E_SIZE),
        ((cm, cfg, pi, 1, lib.VT_MAX_HEIGHT + 1, 1, pw, nb, b, 4, n, t), lib.VT_E_SIZE),
        ((cm, cfg, pi, I32_MAX, I32_MAX, I32_MAX, pw, nb, b, 4, n, t), lib.VT_E_SIZE),
        ((cm, cfg, pi, w, h, w, pw, nb - 1, b, 4, n, t), lib.VT_E_CAPACITY),
        ((cm, cfg, pi, w, h, w, pw, 0, b, 4, n, t), lib.VT_E_CAPACITY),
        ((cm, cfg, pi, w, h, w + 2, pw + 1, nb, b, 4, n, t), lib.VT_OK),    # unaligned work, padded rows
        ((cm, cfg, pi, w, h, w, pw, 2 ** 64 - 1, b, 4, n, t), lib.VT_OK),
    ]
    for args, want in rows:
        for i in range(4):
            b[i] = (9, 9, 9, 9, 9)
        n[0], t[0] = 77, 77
        s = f(*args)
        assert s == want, (args[3:6], args[7], args[9], s)
        if s != lib.VT_OK:
            assert (n[0], t[0]) == (0, 0)
            assert all(tuple([b[i].l, b[i].t, b[i].r, b[i].b, b[i].score]) == (9,) * 5 for i in range(4)), \
                "boxes written on an error"
    assert f(cm, cfg, pi, w, h, w, pw, nb, b, 4, ffi.NULL, t) == lib.VT_E_ARG and t[0] == 0
    assert f(cm, cfg, pi, w, h, w, pw, nb, b, 4, n, ffi.NULL) == lib.VT_E_ARG and n[0] == 0
    sz = ffi.new("size_t *")
    fb = lib.vt_cnn_frame_work_bytes
    assert fb(cm, cfg, w, h, ffi.NULL) == lib.VT_E_ARG
    assert fb(ffi.NULL, cfg, w, h, sz) == lib.VT_E_ARG
    assert fb(cm, ffi.NULL, w, h, sz) == lib.VT_E_ARG
    for ww, hh in [(0, 4), (4, 0), (big, 4), (4, lib.VT_MAX_HEIGHT + 1), (I32_MIN, I32_MIN)]:
        assert fb(cm, cfg, ww, hh, sz) == lib.VT_E_SIZE
    assert fb(cm, cfg, lib.VT_MAX_WIDTH, lib.VT_MAX_HEIGHT, sz) == lib.VT_OK


@pytest.mark.parametrize("thunk,exc,words", [
    (lambda m: C.detect_frame(m, None), TypeError, "gray"),
    (lambda m: C.detect_frame(m, np.zeros((4, 4), np.float32)), TypeError, "uint8"),
    (lambda m: C.detect_frame(m, np.zeros((4, 4, 3), np.uint8)), ValueError, "2-D"),
    (lambda m: C.detect_frame(m, np.zeros((0, 4), np.uint8)), ValueError, "empty"),
    (lambda m: C.detect_frame(m, np.zeros((4, 8), np.uint8)[:, ::2]), ValueError, "contiguous"),
    (lambda m: C.detect_frame(m, np.zeros((1, lib.VT_MAX_WIDTH + 1), np.uint8)), VtError, "bad size"),
    (lambda m: C.detect_frame(m, np.zeros((4, 4), np.uint8), cfg={"n_levels": 2}), TypeError, "CnnConfig"),
    (lambda m: C.detect_frame(m, np.zeros((4, 4), np.uint8), cfg=C.CnnConfig(n_levels=9)), ValueError, "n_levels"),
    (lambda m: C.detect_frame("model.npz", np.zeros((4, 4), np.uint8)), TypeError, "CnnModel"),
    (lambda m: C.frame_work_bytes(m, 0, 4), VtError, "vt_cnn_frame_work_bytes"),
])
def test_python_bad_inputs(thunk, exc, words):
    with pytest.raises(exc) as e:
        thunk(const_model())
    assert words in str(e.value), str(e.value)


def test_python_one_pixel_and_padded_view():
    m = const_model()
    b, n = C.detect_frame(m, np.zeros((1, 1), np.uint8), C.CnnConfig(first_level=0, n_levels=4))
    assert n == 4 and len(b) >= 1
    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, (40, 60)).astype(np.uint8)
    big = np.zeros((40, 64), np.uint8)
    big[:, :60] = img
    assert (C.detect_frame(m, big[:, :60])[0] == C.detect_frame(m, img)[0]).all()


def test_is_cnn(tmp_path):
    m = const_model()
    m.save(tmp_path / "c.npz")
    assert C.is_cnn(tmp_path / "c.npz") and C.is_cnn(str(tmp_path / "c.npz")) and C.is_cnn(m)
    assert C.is_cnn(np.load(tmp_path / "c.npz")) and C.is_cnn(m.keys())
    np.savez(tmp_path / "other.npz", w=np.zeros(3), cnn_n_layers=np.int32(1))
    assert not C.is_cnn(tmp_path / "other.npz")
    assert not C.is_cnn(tmp_path / "missing.npz") and not C.is_cnn(42)
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    assert not C.is_cnn(tmp_path / "junk.npz")
