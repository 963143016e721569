"""The quantised CNN detector (include/vehtrack/cnn.h, c/cnn.c, pyvehtrack/cnn.py) against its
NumPy integer twin (pyvehtrack/reference/cnn.py).

Tolerance: 0 LSB everywhere. Both sides compute the same integers (int32 accumulators that
cannot overflow, cnn.h's bound; an int64 requantisation rounded half up; clamps), so any
difference is a bug:
  * vt_cnn_forward = reference.forward bit for bit, for random valid models (1-4 layers,
    ksize / stride / dilation / channels drawn, mult and shift scaled to the drawn image so
    outputs are neither all zero nor all saturated, sometimes saturated on purpose) over
    images 1..40 x 1..40 with padded row strides; nothing written outside the work buffer's
    needed bytes and the output (guard bytes);
  * vt_cnn_decode = reference.decode: the same boxes in the same order, ties included
    (outputs drawn from a few values), cap truncation with the total peak count;
  * a hand-computed 1x1 layer on a 2x2 image: rounding of exact halves both signs, both
    clamps; its decode worked out by hand;
  * the accumulator at cnn.h's extremes (|bias| = 2^30, 9 x VT_CNN_MAX_CH taps of 255 x -128 / 127);
  * bad arguments: each documented status from C, clear exceptions from Python.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyvehtrack import cnn as C
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.reference import cnn as R

GUARD = 0xA5
I32_MIN, I32_MAX = -(2 ** 31), 2 ** 31 - 1


# ---------------------------------------------------------------- model builders
def layer(k, s, d, relu, cin, cout, w, bias, mult, shift):
    return dict(ksize=k, stride=s, dilation=d, relu=relu, cin=cin, cout=cout,
                w=np.asarray(w, np.int8).reshape(cout, k, k, cin), bias=np.asarray(bias, np.int32).reshape(cout),
                mult=np.asarray(mult, np.int32).reshape(cout), shift=np.asarray(shift, np.uint8).reshape(cout))


def random_model(rng, spec, img, gain=60.0, lut=None) -> C.CnnModel:
    """spec: [(ksize, stride, dilation, cout)], the last cout 5. Each layer's mult / shift put the
    spread of its accumulator on the drawn image at about `gain` output units."""
    layers, a, cin = [], img[:, :, None], 1
    for i, (k, s, d, cout) in enumerate(spec):
        last = i == len(spec) - 1
        w = rng.integers(-128, 128, (cout, k, k, cin))
        bias = rng.integers(-3000, 3000, cout) * (rng.random(cout) < 0.7)
        L = layer(k, s, d, 0 if last else 1, cin, cout, w, bias, np.ones(cout), np.ones(cout))
        acc = R.accumulate(a, L)
        spread = np.maximum(acc.reshape(-1, cout).std(axis=0), 1.0)
        shift = rng.integers(20, 31, cout)
        mult = np.clip(np.round(gain / spread * 2.0 ** shift), 1, I32_MAX).astype(np.int64)
        L["mult"], L["shift"] = mult.astype(np.int32), shift.astype(np.uint8)
        a = R.requantise(acc, L)
        layers.append(L)
        cin = cout
    if lut is None:
        lut = rng.integers(0, 4000, (4, 256))
    return C.CnnModel(layers, np.asarray(lut, np.uint16), int(rng.integers(-20, 20)))


def simple_model(spec=((3, 2, 1, 4), (1, 1, 1, 5)), seed=0) -> C.CnnModel:
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, (16, 16)).astype(np.uint8)
    return random_model(rng, spec, img)


# ---------------------------------------------------------------- C calls with guard bytes
def c_forward_guarded(model, img, pad=0, slack=7):
    """vt_cnn_forward through cffi with the image's rows padded by `pad` bytes, the work buffer
    and the output inside sentinel-filled buffers; returns (out, guards intact)."""
    h, w = img.shape
    big = np.full((h, w + pad), 77, np.uint8)
    big[:, :w] = img
    m = model.c_model()[0]
    nb, gw, gh = ffi.new("size_t *"), ffi.new("int32_t *"), ffi.new("int32_t *")
    assert lib.vt_cnn_work_bytes(m, w, h, nb) == lib.VT_OK
    assert lib.vt_cnn_out_size(m, w, h, gw, gh) == lib.VT_OK
    work = np.full(nb[0] + 2 * slack, GUARD, np.uint8)
    n_out = gw[0] * gh[0] * 5
    out = np.full(n_out + 2 * slack, -GUARD & 0x7F, np.int8)
    s = lib.vt_cnn_forward(m, ffi.cast("uint8_t *", big.ctypes.data), w, h, w + pad,
                           ffi.cast("uint8_t *", work.ctypes.data) + slack, nb[0],
                           ffi.cast("int8_t *", out.ctypes.data) + slack, n_out)
    assert s == lib.VT_OK
    ok = bool((work[:slack] == GUARD).all() and (work[slack + nb[0]:] == GUARD).all()
              and (out[:slack] == (-GUARD & 0x7F)).all() and (out[slack + n_out:] == (-GUARD & 0x7F)).all())
    return out[slack:slack + n_out].reshape(gh[0], gw[0], 5), ok


# ---------------------------------------------------------------- forward: C == twin
# channels: 1..8 (the four-channel blocks and the remainder), and 16, 19, 32 so the
# inner loops' 16-wide steps run with and without a tail (AVX2: 16 products per
# vpmaddwd and two neighbouring pixels per pass; SSE2: 8 per pmaddwd)
spec_layer = st.tuples(st.sampled_from([1, 3]), st.sampled_from([1, 2]), st.sampled_from([1, 2]),
                       st.one_of(st.integers(1, 8), st.sampled_from([16, 19, 32])))


@given(st.lists(spec_layer, min_size=0, max_size=3), st.tuples(st.sampled_from([1, 3]), st.sampled_from([1, 2]),
                                                               st.sampled_from([1, 2])),
       st.integers(1, 40), st.integers(1, 40), st.integers(0, 5), st.integers(0, 2 ** 32 - 1),
       st.sampled_from([60.0, 60.0, 5.0, 1000.0]), st.sampled_from(["noise", "flat", "few"]))
def test_forward_equals_twin(hidden, last, w, h, pad, seed, gain, kind):
    rng = np.random.default_rng(seed)
    spec = [(k, s, d if k == 3 else 1, c) for k, s, d, c in hidden]
    spec.append((last[0], last[1], last[2] if last[0] == 3 else 1, 5))
    if kind == "noise":
        img = rng.integers(0, 256, (h, w)).astype(np.uint8)
    elif kind == "flat":
        img = np.full((h, w), int(rng.integers(0, 256)), np.uint8)
    else:
        img = rng.choice(np.array([0, 1, 128, 255], np.uint8), (h, w))
    model = random_model(rng, spec, img, gain)
    got, intact = c_forward_guarded(model, img, pad)
    want = R.forward(model.layers, img)
    assert got.shape == want.shape == (*R.out_size(model.layers, w, h)[::-1], 5)
    np.testing.assert_array_equal(got, want)
    assert intact, "vt_cnn_forward wrote outside its work buffer or output"
    # the Python wrapper: the same bits, also through a padded view
    np.testing.assert_array_equal(C.forward(model, img), want)
    if pad:
        big = np.full((h, w + pad), 3, np.uint8)
        big[:, :w] = img
        np.testing.assert_array_equal(C.forward(model, big[:, :w]), want)


# Channels in lanes (c/cnn.c vt__cnn_cil_pass, AVX-512 VNNI): a layer whose cin is a
# multiple of 4, or the first layer's 3x3 of dilation 1 on cin 1, puts 16 output channels
# in the lanes of a register, two blocks a pass and eight pixels a tile; the other pixels
# one at a time over their in-frame taps. The first layer: 8 channels (the other loops),
# 16, 32 or 19 (16 in lanes, 3 by the other loops), any stride and dilation; then cout 16,
# 32, 48 (passes of two blocks and of one), 35 (two blocks in lanes, the last 3 channels
# by the pixel-pair path) and 4; frames up to 48 px wide, so rows hold whole tiles, tails
# of 1..7 pixels, or borders only. test_forward_equals_twin draws these shapes too rarely
# to catch every slip in them.
cil_layer = st.tuples(st.sampled_from([1, 3]), st.sampled_from([1, 2]), st.sampled_from([1, 2]),
                      st.sampled_from([4, 16, 32, 35, 48]))


@given(st.tuples(st.sampled_from([1, 2]), st.sampled_from([1, 2]), st.sampled_from([8, 16, 19, 32])),
       st.lists(cil_layer, min_size=1, max_size=3), st.integers(1, 48), st.integers(1, 30),
       st.integers(0, 2 ** 32 - 1), st.sampled_from([60.0, 5.0, 1000.0]))
def test_forward_equals_twin_channel_blocks(head, hidden, w, h, seed, gain):
    rng = np.random.default_rng(seed)
    spec = [(3, *head)] + [(k, s, d if k == 3 else 1, c) for k, s, d, c in hidden] + [(1, 1, 1, 5)]
    img = rng.integers(0, 256, (h, w)).astype(np.uint8)
    model = random_model(rng, spec, img, gain)
    got, intact = c_forward_guarded(model, img)
    np.testing.assert_array_equal(got, R.forward(model.layers, img))
    assert intact, "vt_cnn_forward wrote outside its work buffer or output"


def test_outputs_are_not_degenerate():
    """The drawn models exercise the arithmetic: over a few seeds, the last layer's values span
    the int8 range without being all clamped, and a hidden layer's are not all zero."""
    vals, hid = [], []
    for seed in range(10):
        rng = np.random.default_rng(seed)
        img = rng.integers(0, 256, (24, 24)).astype(np.uint8)
        m = random_model(rng, [(3, 2, 1, 6), (3, 1, 2, 6), (1, 1, 1, 5)], img)
        vals.append(C.forward(m, img).ravel())
        hid.append(R.conv_layer(img[:, :, None], m.layers[0]).ravel())
    v, hv = np.concatenate(vals), np.concatenate(hid)
    assert v.min() == -128 and v.max() == 127 and 0.05 < np.mean((v > -128) & (v < 127))
    assert np.mean(hv > 0) > 0.2 and np.mean(hv == 255) < 0.5


@pytest.mark.parametrize("sign", [-1, 1])
def test_accumulator_extremes_exact(sign):
    """cnn.h's bound: |bias| = 2^30 plus 9 x VT_CNN_MAX_CH (128) taps of 255 x (-128 or 127)
    stays in int32 (2^30 + 1152 x 255 x 128 = 1,111,342,304 < 2^31), and the requantisation
    with mult = 2^31 - 1, shift 62 stays in int64: C == twin exactly."""
    n = C.MAX_CH
    assert n == 128      # the bound in cnn.h's comment is for this cap
    l0 = layer(1, 1, 1, 1, 1, n, np.full(n, 127), np.full(n, 2 ** 30), np.ones(n), np.ones(n))
    wv = -128 if sign < 0 else 127
    l1 = layer(3, 1, 1, 0, n, 5, np.full(5 * 9 * n, wv), np.full(5, sign * 2 ** 30),
               np.full(5, I32_MAX), [62, 40, 33, 31, 1])
    m = C.CnnModel([l0, l1], np.zeros((4, 256), np.uint16))
    img = np.full((5, 6), 255, np.uint8)
    got, intact = c_forward_guarded(m, img, 2)
    want = R.forward(m.layers, img)
    np.testing.assert_array_equal(got, want)
    assert intact
    acc = R.accumulate(R.conv_layer(img[:, :, None], l0), l1)
    assert acc[2, 2, 0] == sign * (2 ** 30 + 9 * n * 255 * abs(wv)) and abs(acc).max() < 2 ** 31
    assert want[2, 2, 0] == (sign * (2 ** 30 + 9 * n * 255 * abs(wv)) * I32_MAX + 2 ** 61) >> 62


# ---------------------------------------------------------------- the hand-computed case
def hand_model(lut=None):
    # channel: w, bias, mult, shift
    ch = [(1, 0, 1, 1), (-1, 0, 1, 1), (-1, -10, 3, 2), (127, 100, 1, 8), (1, -3, 1, 1)]
    L = layer(1, 1, 1, 0, 1, 5, [c[0] for c in ch], [c[1] for c in ch], [c[2] for c in ch], [c[3] for c in ch])
    if lut is None:
        lut = np.tile(np.arange(256), (4, 1))
    return C.CnnModel([L], np.asarray(lut, np.uint16), 0)


def test_hand_computed_1x1():
    """q = floor((acc mult + 2^(shift-1)) / 2^shift), worked out per pixel a = 0, 1, 2, 255:
      ch0  a, /2:               0 -> 0, 1 -> 1 (0.5 up), 2 -> 1, 255 -> 128 -> 127 (clamp)
      ch1  -a, /2:              0, -0.5 -> 0 (half up, toward +inf), -1, -127.5 -> -127
      ch2  3(-a - 10) / 4:      -7.5 -> -7, -8.25 -> -8, -9, -198.75 -> -199 -> -128 (clamp)
      ch3  (127 a + 100) / 256: 0.39 -> 0, 0.89 -> 1, 1.38 -> 1, 126.9 -> 127
      ch4  (a - 3) / 2:         -1.5 -> -1, -1, -0.5 -> 0, 126"""
    img = np.array([[0, 1], [2, 255]], np.uint8)
    want = np.array([[[0, 0, -7, 0, -1], [1, 0, -8, 1, -1]],
                     [[1, -1, -9, 1, 0], [127, -127, -128, 127, 126]]], np.int8)
    m = hand_model()
    got, intact = c_forward_guarded(m, img, 3)
    np.testing.assert_array_equal(got, want)
    assert intact
    np.testing.assert_array_equal(R.forward(m.layers, img), want)
    np.testing.assert_array_equal(C.forward(m, img), want)


def test_hand_computed_decode():
    """Heat [[0, 1], [1, 127]], thr 0: the one peak is (1, 1) (the 1s have the 127 beside
    them). S = 1: cx = cy = (1 + 0) 16 = 16 (Q4); the identity LUT gives the side q + 128:
    l = 16 - (-127 + 128) = 15, t = 16 - 0 = 16, r = 16 + 255 = 271, b = 16 + 254 = 270;
    px: floor((v + 8) / 16): l 1, t 1, r 17 - 1 = 16, b 17 - 1 = 16. scale_shift 1: v 2:
    l floor(38 / 16) = 2, t floor(40 / 16) = 2, r floor(550 / 16) - 1 = 33, b floor(548 / 16) - 1 = 33."""
    m = hand_model()
    out = C.forward(m, np.array([[0, 1], [2, 255]], np.uint8))
    b, n = C.decode(m, out, thr=0)
    assert n == 1 and b.tolist() == [[1, 1, 16, 16, 127]]
    b, n = C.decode(m, out, thr=0, scale_shift=1)
    assert n == 1 and b.tolist() == [[2, 2, 33, 33, 127]]
    # a negative Q4 coordinate floors: l = 16 - 1001 = -985 -> floor(-977 / 16) = -62
    lut = np.tile(np.arange(256), (4, 1))
    lut[0, -127 + 128] = 1001
    b, _ = C.decode(hand_model(lut), out, thr=0)
    assert b[0, 0] == -62
    assert R.decode(out, 1, lut, 0)[0][0, 0] == -62
    # thr above every heat: no peak; thr 127: the 127 only; thr -128: plateaus count too
    assert C.decode(m, out, thr=128)[1] == 0
    assert C.decode(m, out, thr=127)[1] == 1


# ---------------------------------------------------------------- decode: C == twin
@given(st.integers(1, 30), st.integers(1, 30), st.integers(0, 2 ** 32 - 1), st.sampled_from([2, 3, 5, 256]),
       st.integers(-130, 130), st.integers(0, 5), st.integers(1, 40), st.sampled_from([1, 2, 4, 8]))
def test_decode_equals_twin(gw, gh, seed, n_vals, thr, scale_shift, cap, stride):
    """Outputs with few distinct heats (many ties and plateaus), any threshold, a cap that
    often truncates: the same boxes in the same order, the same total."""
    rng = np.random.default_rng(seed)
    vals = np.arange(-128, 128) if n_vals == 256 else rng.integers(-128, 128, n_vals)
    out = rng.choice(vals, (gh, gw, 5)).astype(np.int8)
    out[..., 1:] = rng.integers(-128, 128, (gh, gw, 4))
    spec = [(3, 2, 1, 4)] * (stride.bit_length() - 1) + [(1, 1, 1, 5)]
    model = simple_model(spec, seed % 1000)
    assert model.out_stride == stride
    cm = model.c_model()[0]
    boxes = ffi.new("vt_cnn_box[]", cap + 3)
    sentinel = (0x5A5A5A5A,) * 5
    for i in range(cap + 3):
        boxes[i] = sentinel
    n, tot = ffi.new("int32_t *"), ffi.new("int32_t *")
    o = np.ascontiguousarray(out)
    assert lib.vt_cnn_decode(cm, ffi.cast("int8_t *", o.ctypes.data), gw, gh, thr, scale_shift, boxes, cap,
                             n, tot) == lib.VT_OK
    want, want_tot = R.decode(out, stride, model.side_lut, thr, scale_shift, cap)
    assert tot[0] == want_tot and n[0] == min(cap, want_tot)
    got = np.array([[boxes[i].l, boxes[i].t, boxes[i].r, boxes[i].b, boxes[i].score] for i in range(n[0])],
                   np.int64).reshape(-1, 5)
    np.testing.assert_array_equal(got, want)
    assert all(tuple([boxes[i].l, boxes[i].t, boxes[i].r, boxes[i].b, boxes[i].score]) == sentinel
               for i in range(n[0], cap + 3)), "vt_cnn_decode wrote past *n"
    # the Python wrapper
    pb, pt = C.decode(model, out, thr=thr, scale_shift=scale_shift, cap=cap)
    assert pt == want_tot
    np.testing.assert_array_equal(pb, want)


def test_decode_all_equal_is_every_cell_in_raster_order():
    m = simple_model()
    out = np.zeros((3, 4, 5), np.int8)
    b, n = C.decode(m, out, thr=0)
    assert n == 12
    S = m.out_stride
    centres = [(x * S + S // 2, y * S + S // 2) for y in range(3) for x in range(4)]
    lut = m.side_lut.astype(np.int64)
    assert b[:, 0].tolist() == [(((cx * 16 - lut[0, 128]) + 8) >> 4) for cx, _ in centres]
    b2, n2 = C.decode(m, out, thr=0, cap=5)
    assert n2 == 12 and len(b2) == 5 and (b2 == b[:5]).all()


def test_forward_then_decode_matches_twin():
    rng = np.random.default_rng(7)
    img = rng.integers(0, 256, (40, 40)).astype(np.uint8)
    m = random_model(rng, [(3, 2, 1, 8), (3, 2, 1, 8), (3, 2, 2, 8), (1, 1, 1, 5)], img)
    out = C.forward(m, img)
    b, n = C.decode(m, out)
    rb, rn = R.decode(R.forward(m.layers, img), m.out_stride, m.side_lut, m.heat_thr)
    assert n == rn and (b == rb).all()


# ---------------------------------------------------------------- sizes
def test_sizes_and_work_bytes():
    m = simple_model([(3, 2, 1, 4), (3, 1, 1, 7), (3, 2, 1, 3), (1, 2, 1, 5)])
    assert C.out_size(m, 37, 1) == (5, 1)    # ceil(37 / 8), ceil(1 / 8)
    assert C.out_size(m, 40, 9) == (5, 2)
    # outputs before the last: 19x5x4 = 380 (even), 19x5x7 = 665 (odd), 10x3x3 = 90 (even)
    assert C.work_bytes(m, 37, 9) == 380 + 665
    one = simple_model([(3, 2, 1, 5)])
    assert C.work_bytes(one, 10, 10) == 0
    out = ffi.new("int8_t[]", 25 * 5)
    img = np.zeros((10, 10), np.uint8)
    assert lib.vt_cnn_forward(one.c_model()[0], ffi.cast("uint8_t *", img.ctypes.data), 10, 10, 10, ffi.NULL, 0,
                              out, 125) == lib.VT_OK


# ---------------------------------------------------------------- bad arguments (C)
def _mut_rows():
    """(name, mutation of a good 3-layer model's struct) -> VT_E_ARG from every function."""
    def L(i, **kw):
        def f(m):
            for k, v in kw.items():
                setattr(m.layer[i], k, v)
        return f

    def M(**kw):
        def f(m):
            for k, v in kw.items():
                setattr(m, k, v)
        return f

    def arr(i, name, idx, v):
        def f(m, keep):
            a = np.array(ffi.unpack(getattr(m.layer[i], name), m.layer[i].cout))
            a[idx] = v
            ct = {"bias": "int32_t[]", "mult": "int32_t[]", "shift": "uint8_t[]"}[name]
            keep.append(ffi.new(ct, a.tolist()))
            setattr(m.layer[i], name, keep[-1])
        return f

    return [
        ("n_layers 0", M(n_layers=0)), ("n_layers 9", M(n_layers=9)),
        ("n_layers 2 (last relu 1, cout 7)", M(n_layers=2)),
        ("ksize 2", L(0, ksize=2)), ("ksize 0", L(1, ksize=0)), ("stride 0", L(0, stride=0)),
        ("stride 3", L(0, stride=3, )), ("dilation 0", L(0, dilation=0)), ("dilation 3", L(0, dilation=3)),
        ("dilation 2 on 1x1", L(2, dilation=2)), ("relu 0 before the last", L(0, relu=0)),
        ("relu 2", L(0, relu=2)), ("last relu 1", L(2, relu=1)), ("cin 0", L(0, cin=0)),
        ("layer 0 cin 2", L(0, cin=2)), ("cin != previous cout", L(1, cin=3)), ("cout 0", L(1, cout=0)),
        ("cout MAX_CH + 1", L(0, cout=C.MAX_CH + 1)), ("last cout 4", L(2, cout=4)),
        ("cin MAX_CH + 1", L(1, cin=C.MAX_CH + 1)),
        ("w NULL", L(1, w=ffi.NULL)), ("bias NULL", L(0, bias=ffi.NULL)), ("mult NULL", L(2, mult=ffi.NULL)),
        ("shift NULL", L(1, shift=ffi.NULL)), ("side_lut NULL", M(side_lut=ffi.NULL)),
        ("out_stride 2", M(out_stride=2)), ("out_stride 0", M(out_stride=0)),
        ("heat_scale_q16 0", M(heat_scale_q16=0)), ("heat_scale_q16 -1", M(heat_scale_q16=-1)),
        ("heat_scale_q16 2^24 + 1", M(heat_scale_q16=2 ** 24 + 1)),
        ("heat_scale_q16 INT32_MIN", M(heat_scale_q16=I32_MIN)),
        ("mult 0", arr(1, "mult", 2, 0)), ("mult -1", arr(0, "mult", 0, -1)),
        ("mult INT32_MIN", arr(2, "mult", 4, I32_MIN)),
        ("shift 0", arr(0, "shift", 1, 0)), ("shift 63", arr(2, "shift", 0, 63)),
        ("bias 2^30 + 1", arr(1, "bias", 0, 2 ** 30 + 1)), ("bias -2^30 - 1", arr(2, "bias", 3, -(2 ** 30) - 1)),
        ("bias INT32_MIN", arr(0, "bias", 2, I32_MIN)),
    ]


def _good():
    return simple_model([(3, 2, 1, 6), (3, 2, 2, 7), (1, 1, 1, 5)], seed=3)


IMG = np.arange(24 * 20, dtype=np.uint8).reshape(20, 24)


def _call_all(cm):
    """Every public function on model cm with otherwise good arguments -> statuses."""
    nb = ffi.new("size_t *")
    gw, gh = ffi.new("int32_t *"), ffi.new("int32_t *")
    work = np.zeros(10000, np.uint8)
    out = np.zeros(6 * 5 * 5, np.int8)   # the 24x20 input's 6x5 grid
    boxes = ffi.new("vt_cnn_box[4]")
    n, t = ffi.new("int32_t *"), ffi.new("int32_t *")
    fcfg = ffi.new("vt_cnn_cfg *")
    lib.vt_cnn_cfg_default(fcfg)
    fb = ffi.new("vt_cnn_box[4]")
    return [lib.vt_cnn_check_model(cm), lib.vt_cnn_out_size(cm, 24, 20, gw, gh),
            lib.vt_cnn_frame_work_bytes(cm, fcfg, 24, 20, nb),
            lib.vt_cnn_detect_frame(cm, fcfg, ffi.cast("uint8_t *", IMG.ctypes.data), 24, 20, 24,
                                    ffi.cast("uint8_t *", work.ctypes.data), work.size, fb, 4, n, t),
            lib.vt_cnn_work_bytes(cm, 24, 20, nb),
            lib.vt_cnn_forward(cm, ffi.cast("uint8_t *", IMG.ctypes.data), 24, 20, 24,
                               ffi.cast("uint8_t *", work.ctypes.data), work.size,
                               ffi.cast("int8_t *", out.ctypes.data), out.size),
            lib.vt_cnn_decode(cm, ffi.cast("int8_t *", out.ctypes.data), 3, 3, 0, 0, boxes, 4, n, t)]


def test_good_model_passes_every_function():
    m = _good()
    assert _call_all(m.c_model()[0]) == [lib.VT_OK] * 7
    boundary = ffi.new("vt_cnn_model *", m.c_model()[0][0])
    keep = [ffi.new("int32_t[]", [2 ** 30, -(2 ** 30), 0, 1, -1, 5]), ffi.new("uint8_t[]", [1, 62, 1, 62, 1, 62]),
            ffi.new("int32_t[]", [1, I32_MAX, 1, 1, 1, 1])]
    boundary.layer[0].bias, boundary.layer[0].shift, boundary.layer[0].mult = keep
    boundary.heat_scale_q16 = lib.VT_CNN_HEAT_SCALE_MAX
    assert _call_all(boundary) == [lib.VT_OK] * 7
    boundary.heat_scale_q16 = 1
    assert _call_all(boundary) == [lib.VT_OK] * 7


def test_channel_cap_alone():
    """VT_CNN_MAX_CH channels (128) in a consistent model: accepted and C == twin (the forward
    with its own work buffer; _call_all's is sized for small models); one more, still
    consistent (cin = the previous cout): refused by every function and by the Python model,
    so nothing but the cap refuses it."""
    m = simple_model([(3, 2, 1, C.MAX_CH), (3, 1, 2, 5)], seed=5)
    assert lib.vt_cnn_check_model(m.c_model()[0]) == lib.VT_OK
    img = np.random.default_rng(5).integers(0, 256, (11, 13)).astype(np.uint8)
    got, intact = c_forward_guarded(m, img, 3)
    np.testing.assert_array_equal(got, R.forward(m.layers, img))
    assert intact
    cm = ffi.new("vt_cnn_model *", m.c_model()[0][0])
    keep = []
    for i, (cin, cout) in enumerate([(1, C.MAX_CH + 1), (C.MAX_CH + 1, 5)]):
        w = np.zeros(cout * 9 * cin, np.int8)
        keep += [ffi.new("int8_t[]", w.tolist()), ffi.new("int32_t[]", [0] * cout),
                 ffi.new("int32_t[]", [1] * cout), ffi.new("uint8_t[]", [1] * cout)]
        cm.layer[i].cin, cm.layer[i].cout = cin, cout
        cm.layer[i].w, cm.layer[i].bias, cm.layer[i].mult, cm.layer[i].shift = keep[-4:]
    assert _call_all(cm) == [lib.VT_E_ARG] * 7
    bad = [layer(3, 2, 1, 1, 1, C.MAX_CH + 1, np.zeros((C.MAX_CH + 1) * 9), np.zeros(C.MAX_CH + 1),
                 np.ones(C.MAX_CH + 1), np.ones(C.MAX_CH + 1)),
           layer(3, 1, 2, 0, C.MAX_CH + 1, 5, np.zeros(5 * 9 * (C.MAX_CH + 1)), np.zeros(5), np.ones(5),
                 np.ones(5))]
    with pytest.raises(ValueError, match="outside"):
        C.CnnModel(bad, np.zeros((4, 256), np.uint16))


@pytest.mark.parametrize("name,mut", _mut_rows(), ids=[r[0] for r in _mut_rows()])
def test_bad_model_field(name, mut):
    m = _good()
    cm = ffi.new("vt_cnn_model *", m.c_model()[0][0])
    keep = []
    mut(cm, keep) if mut.__code__.co_argcount == 2 else mut(cm)
    assert _call_all(cm) == [lib.VT_E_ARG] * 7, name


def test_forward_bad_args():
    m = _good()
    cm = m.c_model()[0]
    w, h = 24, 20
    nb = C.work_bytes(m, w, h)
    gw, gh = C.out_size(m, w, h)
    need = gw * gh * 5
    img = np.zeros((h, w + 2), np.uint8)
    work = np.zeros(nb, np.uint8)
    out = np.zeros(need, np.int8)
    P = lambda a, t: ffi.cast(t, a.ctypes.data)   # noqa: E731
    pi, pw, po = P(img, "uint8_t *"), P(work, "uint8_t *"), P(out, "int8_t *")
    f = lib.vt_cnn_forward
    assert f(cm, pi, w, h, w, pw, nb, po, need) == lib.VT_OK
    rows = [
        ((ffi.NULL, pi, w, h, w, pw, nb, po, need), lib.VT_E_ARG),
        ((cm, ffi.NULL, w, h, w, pw, nb, po, need), lib.VT_E_ARG),
        ((cm, pi, w, h, w, ffi.NULL, nb, po, need), lib.VT_E_ARG),
        ((cm, pi, w, h, w, pw, nb, ffi.NULL, need), lib.VT_E_ARG),
        ((cm, pi, 0, h, w, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, w, 0, w, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, -1, h, w, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, w, -5, w, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, I32_MIN, h, w, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, I32_MAX, I32_MAX, I32_MAX, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, lib.VT_MAX_WIDTH + 1, 1, lib.VT_MAX_WIDTH + 1, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, 1, lib.VT_MAX_HEIGHT + 1, 1, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, w, h, w - 1, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, w, h, -w, pw, nb, po, need), lib.VT_E_SIZE),
        ((cm, pi, w, h, w, pw, nb - 1, po, need), lib.VT_E_CAPACITY),
        ((cm, pi, w, h, w, pw, 0, po, need), lib.VT_E_CAPACITY),
        ((cm, pi, w, h, w, pw, nb, po, need - 1), lib.VT_E_CAPACITY),
        ((cm, pi, w, h, w, pw, nb, po, 0), lib.VT_E_CAPACITY),
        ((cm, pi, w, h, w + 2, pw, nb, po, need), lib.VT_OK),
        ((cm, pi, w, h, w, pw, 2 ** 64 - 1, po, 2 ** 64 - 1), lib.VT_OK),
    ]
    for args, want in rows:
        out[:] = 99
        s = f(*args)
        assert s == want, (args[2:5], args[6], args[8], s)
        if s != lib.VT_OK:
            assert (out == 99).all(), "written on an error"


def test_size_query_bad_args():
    m = _good()
    cm = m.c_model()[0]
    nb = ffi.new("size_t *")
    gw, gh = ffi.new("int32_t *"), ffi.new("int32_t *")
    assert lib.vt_cnn_out_size(cm, 4, 4, ffi.NULL, gh) == lib.VT_E_ARG
    assert lib.vt_cnn_out_size(cm, 4, 4, gw, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_cnn_out_size(ffi.NULL, 4, 4, gw, gh) == lib.VT_E_ARG
    assert lib.vt_cnn_work_bytes(cm, 4, 4, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_cnn_work_bytes(ffi.NULL, 4, 4, nb) == lib.VT_E_ARG
    assert lib.vt_cnn_check_model(ffi.NULL) == lib.VT_E_ARG
    for w, h in [(0, 4), (4, 0), (-1, 4), (I32_MIN, I32_MIN), (lib.VT_MAX_WIDTH + 1, 4),
                 (4, lib.VT_MAX_HEIGHT + 1), (I32_MAX, I32_MAX)]:
        assert lib.vt_cnn_out_size(cm, w, h, gw, gh) == lib.VT_E_SIZE
        assert lib.vt_cnn_work_bytes(cm, w, h, nb) == lib.VT_E_SIZE
    assert lib.vt_cnn_out_size(cm, lib.VT_MAX_WIDTH, lib.VT_MAX_HEIGHT, gw, gh) == lib.VT_OK
    assert (gw[0], gh[0]) == (-(-lib.VT_MAX_WIDTH // 4), -(-lib.VT_MAX_HEIGHT // 4))


def test_decode_bad_args():
    m = _good()
    cm = m.c_model()[0]
    out = np.zeros(4 * 3 * 5, np.int8)
    po = ffi.cast("int8_t *", out.ctypes.data)
    b = ffi.new("vt_cnn_box[2]")
    n, t = ffi.new("int32_t *"), ffi.new("int32_t *")
    f = lib.vt_cnn_decode
    assert f(cm, po, 4, 3, 0, 0, b, 2, n, t) == lib.VT_OK and (n[0], t[0]) == (2, 12)
    rows = [
        ((ffi.NULL, po, 4, 3, 0, 0, b, 2, n, t), lib.VT_E_ARG),
        ((cm, ffi.NULL, 4, 3, 0, 0, b, 2, n, t), lib.VT_E_ARG),
        ((cm, po, 4, 3, 0, 0, ffi.NULL, 2, n, t), lib.VT_E_ARG),
        ((cm, po, 4, 3, 0, 0, b, 0, n, t), lib.VT_E_ARG),
        ((cm, po, 4, 3, 0, 0, b, -1, n, t), lib.VT_E_ARG),
        ((cm, po, 4, 3, 0, 0, b, I32_MIN, n, t), lib.VT_E_ARG),
        ((cm, po, 4, 3, 0, -1, b, 2, n, t), lib.VT_E_ARG),
        ((cm, po, 4, 3, 0, 6, b, 2, n, t), lib.VT_E_ARG),
        ((cm, po, 4, 3, 0, 5, b, 2, n, t), lib.VT_OK),
        ((cm, po, 4, 3, 0, I32_MAX, b, 2, n, t), lib.VT_E_ARG),
        ((cm, po, 0, 3, 0, 0, b, 2, n, t), lib.VT_E_SIZE),
        ((cm, po, 4, 0, 0, 0, b, 2, n, t), lib.VT_E_SIZE),
        ((cm, po, -4, 3, 0, 0, b, 2, n, t), lib.VT_E_SIZE),
        ((cm, po, lib.VT_MAX_WIDTH + 1, 1, 0, 0, b, 2, n, t), lib.VT_E_SIZE),
        ((cm, po, 1, lib.VT_MAX_HEIGHT + 1, 0, 0, b, 2, n, t), lib.VT_E_SIZE),
        ((cm, po, 4, 3, I32_MIN, 4, b, 2, n, t), lib.VT_OK),
        ((cm, po, 4, 3, I32_MAX, 0, b, 2, n, t), lib.VT_OK),
    ]
    for args, want in rows:
        n[0], t[0] = 77, 77
        s = f(*args)
        assert s == want, (args[2:6], args[7], s)
        if s != lib.VT_OK:
            assert (n[0], t[0]) == (0, 0)
    assert f(cm, po, 4, 3, 0, 0, b, 2, ffi.NULL, t) == lib.VT_E_ARG and t[0] == 0
    assert f(cm, po, 4, 3, 0, 0, b, 2, n, ffi.NULL) == lib.VT_E_ARG and n[0] == 0
    assert f(cm, po, 4, 3, I32_MAX, 0, b, 2, n, t) == lib.VT_OK and (n[0], t[0]) == (0, 0)


# ---------------------------------------------------------------- Python: files and bad inputs
def test_save_load_round_trip(tmp_path):
    m = _good()
    m.save(tmp_path / "m.npz")
    m2 = C.CnnModel.load(tmp_path / "m.npz")
    assert m2.out_stride == 4 and m2.heat_thr == m.heat_thr and m2.heat_scale_q16 == m.heat_scale_q16 == 65536
    m4 = C.CnnModel(m.layers, m.side_lut, m.heat_thr, heat_scale_q16=12345)
    m4.save(tmp_path / "m4.npz")
    assert C.CnnModel.load(tmp_path / "m4.npz").heat_scale_q16 == 12345
    assert m4.c_model()[0].heat_scale_q16 == 12345
    np.testing.assert_array_equal(C.forward(m2, IMG), C.forward(m, IMG))
    m3 = C.CnnModel.load(np.load(tmp_path / "m.npz"))   # an opened npz works too
    np.testing.assert_array_equal(C.forward(m3, IMG), C.forward(m, IMG))


def _keys_with(**over):
    d = _good().keys()
    for k, v in over.items():
        if v is None:
            d.pop(k)
        else:
            d[k] = v
    return d


@pytest.mark.parametrize("over,exc,words", [
    (dict(cnn_n_layers=None), ValueError, "cnn_n_layers"),
    (dict(cnn_n_layers=np.int32(0)), ValueError, "cnn_n_layers"),
    (dict(cnn_n_layers=np.int32(9)), ValueError, "cnn_n_layers"),
    (dict(cnn_n_layers=np.int32(2)), ValueError, "cnn_l2_"),           # keys past the count
    (dict(cnn_n_layers=np.float64(3.0)), ValueError, "cnn_n_layers"),
    (dict(cnn_l1_w=None), ValueError, "cnn_l1_w"),
    (dict(cnn_l1_w=np.zeros((7, 3, 3, 5), np.int8)), ValueError, "cnn_l1_w"),
    (dict(cnn_l0_w=np.full((6, 3, 3, 1), 200, np.int32)), ValueError, "cnn_l0_w"),
    (dict(cnn_l0_w=np.zeros((6, 3, 3, 1), np.float32)), ValueError, "cnn_l0_w"),
    (dict(cnn_l2_bias=np.zeros(4, np.int32)), ValueError, "cnn_l2_bias"),
    (dict(cnn_l0_mult=None), ValueError, "cnn_l0_mult"),
    (dict(cnn_l0_mult=np.zeros(6, np.int32)), VtError, "cnn_l0_mult"),
    (dict(cnn_l1_shift=np.full(7, 63, np.uint8)), VtError, "cnn_l1_shift"),
    (dict(cnn_l1_shift=np.full(7, 300, np.int32)), ValueError, "cnn_l1_shift"),
    (dict(cnn_l1_bias=np.full(7, 2 ** 30 + 1, np.int32)), VtError, "cnn_l1_bias"),
    (dict(cnn_l0_meta=np.array([3, 2, 1, 1, 1], np.int32)), ValueError, "cnn_l0_meta"),
    (dict(cnn_l0_meta=np.array([3, 2, 1, 0, 1, 6], np.int32)), VtError, "relu"),
    (dict(cnn_l0_meta=np.array([3, 3, 1, 1, 1, 6], np.int32)), VtError, "stride"),
    (dict(cnn_l0_meta=np.array([3, 2, 1, 1, 1, 200], np.int32)), ValueError, "cout"),
    (dict(cnn_l2_meta=np.array([1, 1, 2, 0, 7, 5], np.int32)), VtError, "dilation"),
    (dict(cnn_side_lut=None), ValueError, "cnn_side_lut"),
    (dict(cnn_side_lut=np.zeros((4, 255), np.uint16)), ValueError, "cnn_side_lut"),
    (dict(cnn_side_lut=np.full((4, 256), -1, np.int32)), ValueError, "cnn_side_lut"),
    (dict(cnn_heat_thr=np.int32(128)), ValueError, "cnn_heat_thr"),
    (dict(cnn_heat_thr=None), ValueError, "cnn_heat_thr"),
    (dict(cnn_heat_scale_q16=None), ValueError, "cnn_heat_scale_q16"),
    (dict(cnn_heat_scale_q16=np.int32(0)), ValueError, "cnn_heat_scale_q16"),
    (dict(cnn_heat_scale_q16=np.int64(2 ** 24 + 1)), ValueError, "cnn_heat_scale_q16"),
    (dict(cnn_heat_scale_q16=np.float32(1.5)), ValueError, "cnn_heat_scale_q16"),
])
def test_load_bad_keys(tmp_path, over, exc, words):
    p = tmp_path / "bad.npz"
    np.savez(p, **_keys_with(**over))
    with pytest.raises(exc) as e:
        C.CnnModel.load(p)
    assert words in str(e.value), str(e.value)
    assert isinstance(e.value, ValueError)     # VtError is one too: one except clause catches all


def test_load_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.npz"):
        C.CnnModel.load(tmp_path / "nope.npz")


@pytest.mark.parametrize("thunk,exc,words", [
    (lambda m: C.forward(m, None), TypeError, "gray"),
    (lambda m: C.forward(m, [[1, 2], [3, 4]]), TypeError, "gray"),
    (lambda m: C.forward(m, IMG.astype(np.int16)), TypeError, "uint8"),
    (lambda m: C.forward(m, IMG.astype(bool)), TypeError, "uint8"),
    (lambda m: C.forward(m, np.zeros((4, 4, 3), np.uint8)), ValueError, "2-D"),
    (lambda m: C.forward(m, np.zeros((0, 4), np.uint8)), ValueError, "empty"),
    (lambda m: C.forward(m, np.zeros((4, 0), np.uint8)), ValueError, "empty"),
    (lambda m: C.forward(m, np.zeros((4, 8), np.uint8)[:, ::2]), ValueError, "contiguous"),
    (lambda m: C.forward(m, np.zeros((1, lib.VT_MAX_WIDTH + 1), np.uint8)), VtError, "bad size"),
    (lambda m: C.forward(m, np.zeros((lib.VT_MAX_HEIGHT + 1, 1), np.uint8)), VtError, "bad size"),
    (lambda m: C.decode(m, np.zeros((3, 3, 5), np.int16)), TypeError, "int8"),
    (lambda m: C.decode(m, np.zeros((3, 3, 4), np.int8)), ValueError, "shape"),
    (lambda m: C.decode(m, np.zeros((0, 3, 5), np.int8)), ValueError, "shape"),
    (lambda m: C.decode(m, "out"), TypeError, "out"),
    (lambda m: C.decode(m, np.zeros((3, 3, 5), np.int8), scale_shift=6), ValueError, "scale_shift"),
    (lambda m: C.decode(m, np.zeros((3, 3, 5), np.int8), cap=0), ValueError, "cap"),
    (lambda m: C.decode(m, np.zeros((3, 3, 5), np.int8), thr=1.5), ValueError, "thr"),
    (lambda m: C.decode(m, np.zeros((3, 3, 5), np.int8), thr=True), TypeError, "thr"),
    (lambda m: C.out_size(m, 0, 4), VtError, "vt_cnn_out_size"),
    (lambda m: C.work_bytes(m, 4, -1), VtError, "vt_cnn_work_bytes"),
])
def test_python_bad_inputs(thunk, exc, words):
    with pytest.raises(exc) as e:
        thunk(_good())
    assert words in str(e.value), str(e.value)


def test_python_odd_but_fine_inputs():
    m = _good()
    one = C.forward(m, np.zeros((1, 1), np.uint8))
    assert one.shape == (1, 1, 5)
    ro = IMG.copy()
    ro.setflags(write=False)
    np.testing.assert_array_equal(C.forward(m, ro), C.forward(m, IMG))
    out = C.forward(m, IMG)
    b, n = C.decode(m, np.asfortranarray(out))      # any memory order: copied to C order
    b2, n2 = C.decode(m, out)
    assert n == n2 and (b == b2).all()
    b3, n3 = C.decode(m, out, cap=10 ** 9)          # a huge cap is fine (no bigger than the grid)
    assert n3 == n2 and (b3 == b2).all()


# ---------------------------------------------------------------- which inner loops run
def _cpu_flags() -> set[str]:
    import pathlib  # noqa: PLC0415
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("flags"):
                return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def test_simd_path_is_one_this_cpu_runs():
    """vt_cnn_simd_path names a path the CPU has (every path gives the same bits: the suite
    runs once per path, `make test`). The main suite's build (meson, no -D flags, gcc >= 11)
    on an x86-64 CPU takes the best path the CPU offers, so a dispatch that silently fell
    back to a slower loop fails here; the other builds leave paths out on purpose."""
    import os  # noqa: PLC0415
    import platform  # noqa: PLC0415
    import subprocess  # noqa: PLC0415
    p = ffi.new("int32_t *")
    assert lib.vt_cnn_simd_path(ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_cnn_simd_path(p) == lib.VT_OK
    name = C.simd_path()
    assert name == C.SIMD_PATHS[p[0]]
    flags = _cpu_flags()
    if platform.machine() not in ("x86_64", "AMD64"):
        assert name == "portable"
        return
    avx512 = {"avx512f", "avx512bw", "avx512_vnni"} <= flags
    assert name != "avx512-vnni" or avx512
    assert name != "avx-vnni" or "avx_vnni" in flags
    assert name not in ("avx2", "avx-vnni", "avx512-vnni") or "avx2" in flags
    if os.environ.get("PYVEHTRACK_FFI") is None and flags:
        cc = subprocess.run(["cc", "-dumpversion"], capture_output=True, text=True).stdout.strip()
        gcc11 = cc.split(".")[0].isdigit() and int(cc.split(".")[0]) >= 11
        want = ("avx512-vnni" if avx512 and gcc11 else
                "avx-vnni" if "avx_vnni" in flags and gcc11 else
                "avx2" if "avx2" in flags else "sse2")
        assert name == want, f"cpu flags {sorted(flags & {'avx2', 'avx_vnni', 'avx512_vnni'})}, cc {cc}"
