"""C core pixel primitives vs the float oracle (include/vehtrack/image.h vs
pyvehtrack/reference/image.py), on hypothesis-drawn images.

Sizes are drawn in 1..67 to hit every loop tail and the 1-pixel borders, rows
get random padding (stride > width) filled with a value a correct primitive
never reads, and every output lives inside a guard buffer that must stay intact."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st
from hypothesis.extra import numpy as hnp

import pyvehtrack as vt
from pyvehtrack import _native
from pyvehtrack.reference import image as ref

from conftest import Guarded, padded_copy

dims = st.integers(1, 67)


@st.composite
def images(draw, min_side=1, max_side=67):
    h = draw(st.integers(min_side, max_side))
    w = draw(st.integers(min_side, max_side))
    kind = draw(st.sampled_from(["random", "extremes", "flat", "checker"]))
    if kind == "random":
        img = draw(hnp.arrays(np.uint8, (h, w), elements=st.integers(0, 255)))
    elif kind == "extremes":  # values at the uint8 limits maximise every gradient
        img = draw(hnp.arrays(np.uint8, (h, w), elements=st.sampled_from([0, 255])))
    elif kind == "flat":
        img = np.full((h, w), draw(st.integers(0, 255)), np.uint8)
    else:
        yy, xx = np.mgrid[0:h, 0:w]
        img = (((yy + xx) % 2) * 255).astype(np.uint8)
    pad = draw(st.integers(0, 5))
    return padded_copy(img, pad) if pad else img


# The 3x3 filters are exact integer sums of at most 8 terms of |v| <= 255 on both
# sides (float32 represents them exactly), so the tolerance is 0 LSB.
@pytest.mark.parametrize("cname,oracle", [
    ("filter_h101", ref.filter_h101), ("sobel_x", ref.sobel_x), ("sobel_y", ref.sobel_y)])
@given(img=images())
def test_gradients_exact(cname, oracle, img):
    g = Guarded(*img.shape, np.int16)
    getattr(_native, cname)(img, g.view)
    assert g.intact()
    np.testing.assert_array_equal(g.view.astype(np.float64), oracle(np.ascontiguousarray(img)))


# pyr_down: the float oracle sums 25 products that are multiples of 1/256 with
# magnitude < 256, all exact in float64, then rounds half up as the C contract
# says; the C sum is the same exact integer. Tolerance: 0 LSB.
@given(img=images())
def test_pyr_down_exact(img):
    h, w = img.shape
    g = Guarded((h + 1) // 2, (w + 1) // 2, np.uint8)
    _native.pyr_down(img, g.view)
    assert g.intact()
    np.testing.assert_array_equal(g.view, ref.pyr_down(np.ascontiguousarray(img)))


@given(img=images(min_side=5))
def test_pyr_down_matches_opencv(img):
    """Same as cv2.pyrDown, the usual yardstick (0 LSB: same integer arithmetic)."""
    import cv2
    np.testing.assert_array_equal(vt.image.pyr_down(img), cv2.pyrDown(np.ascontiguousarray(img)))


# resize_area: the oracle computes the same overlap-weighted integer sum with NumPy
# (weights from area_weights, products and sums exact in int64) and the same rounding,
# (sum + W H // 2) // (W H); the C division is a 2^52 reciprocal proven exact for sums
# below 255.5 W H. Tolerance: 0 LSB. Against cv2.INTER_AREA, which weights and rounds in
# float: at most 1 LSB.
@given(img=images(), data=st.data())
def test_resize_area_exact(img, data):
    h, w = img.shape
    ow, oh = data.draw(st.integers(1, w)), data.draw(st.integers(1, h))
    g = Guarded(oh, ow, np.uint8)
    _native.resize_area(img, g.view)
    assert g.intact()
    np.testing.assert_array_equal(g.view, ref.resize_area(np.ascontiguousarray(img), (ow, oh)))
    import cv2
    d = np.abs(g.view.astype(np.int16) - cv2.resize(np.ascontiguousarray(img), (ow, oh),
                                                    interpolation=cv2.INTER_AREA))
    assert d.max() <= 1


def test_resize_area_extremes():
    # the largest weight sum this build takes (the division's bound), a flat image of 255
    # and of 0 at every size; a ramp keeps its order; the same size is a copy
    mw, mh = int(vt.MAX_WIDTH), int(vt.MAX_HEIGHT)
    for v in (0, 1, 254, 255):
        img = np.full((mh, mw), v, np.uint8)
        for size in ((1, 1), (mw, 1), (1, mh), (max(1, mw * 2 // 3), max(1, mh * 2 // 3)), (mw, mh)):
            assert (vt.image.resize_area(img, size) == v).all(), (v, size)
    rng = np.random.default_rng(5)
    img = rng.integers(0, 256, (mh, mw), dtype=np.uint8)
    assert np.array_equal(vt.image.resize_area(img, (mw, mh)), img)
    one = vt.image.resize_area(img, (1, 1))
    assert one[0, 0] == (int(img.astype(np.int64).sum()) + img.size // 2) // img.size
    ramp = np.tile(np.arange(mw, dtype=np.int64) * 255 // max(1, mw - 1), (4, 1)).astype(np.uint8)
    r = vt.image.resize_area(ramp, (max(1, mw * 2 // 3), 2))
    assert (np.diff(r[0].astype(int)) >= 0).all()


def test_resize_area_bad_arguments():
    from pyvehtrack._native import ffi, lib
    img = np.full((6, 8), 9, np.uint8)
    for size in ((9, 6), (8, 7), (0, 3), (3, 0)):
        with pytest.raises(ValueError, match="size"):
            vt.image.resize_area(img, size)
    with pytest.raises(TypeError, match="size"):
        vt.image.resize_area(img, (3,))
    with pytest.raises(TypeError):
        vt.image.resize_area([[1]], (1, 1))
    src = _native.view(img, "src")
    out = np.zeros((3, 4), np.uint8)
    dst = _native.view(out, "dst", writable=True)
    assert lib.vt_resize_area(ffi.NULL, dst) == lib.VT_E_ARG
    assert lib.vt_resize_area(src, ffi.NULL) == lib.VT_E_ARG
    for field, val, err in (("w", 9, lib.VT_E_SIZE), ("h", 7, lib.VT_E_SIZE), ("w", 0, lib.VT_E_SIZE),
                            ("h", -1, lib.VT_E_SIZE), ("stride", 3, lib.VT_E_SIZE)):
        bad = ffi.new("vt_image_u8_mut *", dst[0])
        if field == "w" and val == 9:
            bad.w, bad.stride = 9, 9
        else:
            setattr(bad, field, val)
        assert lib.vt_resize_area(src, bad) == err, (field, val)
    bad = ffi.new("vt_image_u8_mut *", dst[0])
    bad.px = ffi.NULL
    assert lib.vt_resize_area(src, bad) == lib.VT_E_ARG
    assert (out == 0).all()            # nothing written on an error


# pyr_down_rect: the pixels of the rectangle must equal cv2.pyrDown's there (the same
# integer sums and rounding: 0 LSB), every other pixel of the level image and the guard
# around it must keep what it held (a sentinel), whatever rectangle: empty ones, ones
# touching each border (the reflect-101 columns and rows) and the whole image.
@st.composite
def rects(draw, ow, oh):
    def span(n):
        kind = draw(st.sampled_from(["any", "from0", "toend", "all", "empty"]))
        if kind == "all":
            return 0, n
        if kind == "empty":
            a = draw(st.integers(0, n))
            return a, a
        a = 0 if kind == "from0" else draw(st.integers(0, n - 1))
        b = n if kind == "toend" else draw(st.integers(a + 1, n))
        return a, b
    (x0, x1), (y0, y1) = span(ow), span(oh)
    return x0, y0, x1, y1


@given(img=images(), data=st.data())
def test_pyr_down_rect_exact_and_nothing_else_written(img, data):
    import cv2
    h, w = img.shape
    oh, ow = (h + 1) // 2, (w + 1) // 2
    x0, y0, x1, y1 = data.draw(rects(ow, oh))
    g = Guarded(oh, ow, np.uint8)
    _native.pyr_down_rect(img, g.view, x0, y0, x1, y1)
    assert g.intact()
    full = cv2.pyrDown(np.ascontiguousarray(img)) if min(h, w) > 1 else ref.pyr_down(np.ascontiguousarray(img))
    expect = np.full((oh, ow), g.sentinel, np.uint8)
    expect[y0:y1, x0:x1] = full[y0:y1, x0:x1]
    np.testing.assert_array_equal(g.view, expect)


def test_pyr_down_rect_reads_only_what_it_needs():
    """Source pixels outside rows/columns 2 y0 - 2 .. 2 y1 (reflected) do not matter: they
    are replaced by noise and the rectangle's result stays the same."""
    rng = np.random.default_rng(7)
    img = rng.integers(0, 256, (41, 53)).astype(np.uint8)
    for x0, y0, x1, y1 in [(0, 0, 5, 4), (10, 7, 14, 12), (20, 15, 27, 21), (0, 0, 27, 21), (26, 20, 27, 21)]:
        a = vt.image.pyr_down_rect(img, (x0, y0, x1, y1))
        noisy = rng.integers(0, 256, img.shape).astype(np.uint8)
        ys = slice(max(0, 2 * y0 - 2), min(img.shape[0], 2 * y1 + 1))
        xs = slice(max(0, 2 * x0 - 2), min(img.shape[1], 2 * x1 + 1))
        noisy[ys, xs] = img[ys, xs]
        b = vt.image.pyr_down_rect(noisy, (x0, y0, x1, y1))
        np.testing.assert_array_equal(a[y0:y1, x0:x1], b[y0:y1, x0:x1])
        np.testing.assert_array_equal(a[y0:y1, x0:x1], vt.image.pyr_down(img)[y0:y1, x0:x1])


def test_pyr_down_rect_bad_rects():
    img = np.zeros((9, 7), np.uint8)         # level image 4 x 5
    out = np.zeros((5, 4), np.uint8)
    for r in [(-1, 0, 2, 2), (0, -1, 2, 2), (3, 0, 2, 2), (0, 3, 2, 2), (0, 0, 5, 2), (0, 0, 2, 6),
              (0, 0, 2**31 - 1, 2), (-(2**31), 0, 2**31 - 1, 5)]:
        with pytest.raises(vt.VtError, match="vt_pyr_down_rect"):
            _native.pyr_down_rect(img, out, *r)
        with pytest.raises(ValueError, match="rect"):
            vt.image.pyr_down_rect(img, r)
    with pytest.raises(vt.VtError, match="vt_pyr_down_rect"):      # level image of the wrong size
        _native.pyr_down_rect(img, np.zeros((4, 4), np.uint8), 0, 0, 1, 1)
    with pytest.raises(TypeError, match="rect"):
        vt.image.pyr_down_rect(img, (0, 0, 1))
    with pytest.raises(TypeError, match="rect"):
        vt.image.pyr_down_rect(img, (0, 0, 1, "2"))
    assert (vt.image.pyr_down_rect(img, (2, 2, 2, 5)) == 0).all()   # empty: a no-op


# Integral image and box sums: integers below 2^32 on the C side, float64 sums
# below 2^53 on the oracle side: both exact, tolerance 0.
@given(img=images(), data=st.data())
def test_integral_and_box_sum_exact(img, data):
    h, w = img.shape
    g = Guarded(h + 1, w + 1, np.uint32)
    _native.integral(img, g.view)
    assert g.intact()
    np.testing.assert_array_equal(g.view.astype(np.float64), ref.integral(img))
    x = data.draw(st.integers(0, w - 1))
    y = data.draw(st.integers(0, h - 1))
    bw = data.draw(st.integers(1, w - x))
    bh = data.draw(st.integers(1, h - y))
    assert _native.box_sum(g.view, x, y, bw, bh) == ref.box_sum(img, x, y, bw, bh)


def test_integral_full_frame_extreme():
    """The largest frame of all-255 pixels: the sum must not wrap uint32."""
    img = np.full((vt.MAX_HEIGHT, vt.MAX_WIDTH), 255, np.uint8)
    ii = vt.image.integral(img)
    assert int(ii[-1, -1]) == 255 * vt.MAX_WIDTH * vt.MAX_HEIGHT
    assert vt.image.box_sum(ii, 0, 0, vt.MAX_WIDTH, vt.MAX_HEIGHT) == 255 * vt.MAX_WIDTH * vt.MAX_HEIGHT


@st.composite
def patch_pairs(draw):
    h = draw(st.integers(1, 40))
    w = draw(st.integers(1, 40))
    a = draw(hnp.arrays(np.uint8, (h, w), elements=st.integers(0, 255)))
    mode = draw(st.sampled_from(["independent", "affine", "negated", "noisy"]))
    if mode == "independent":
        b = draw(hnp.arrays(np.uint8, (h, w), elements=st.integers(0, 255)))
    elif mode == "affine":  # correlation exactly 1 up to the uint8 rounding
        b = np.clip(a.astype(np.int32) // 2 + 40, 0, 255).astype(np.uint8)
    elif mode == "negated":
        b = (255 - a).astype(np.uint8)
    else:
        noise = draw(hnp.arrays(np.int16, (h, w), elements=st.integers(-20, 20)))
        b = np.clip(a.astype(np.int32) + noise, 0, 255).astype(np.uint8)
    return padded_copy(a, draw(st.integers(0, 3))), b


# NCC: the C side computes the centred sums exactly, then a quotient with ~29
# significant bits before rounding to Q14 (see vt_ncc_u8 in image.h), i.e. an
# error < 2^-15 LSB before the final rounding: result within 1 LSB of the exact
# value * 16384.
@given(pair=patch_pairs())
def test_ncc_within_1_lsb(pair):
    a, b = pair
    r = ref.ncc(a, b)
    if math.isnan(r):
        with pytest.raises(vt.VtError) as e:
            _native.ncc_u8(a, b)
        assert e.value.status == vt.lib.VT_E_SINGULAR
        assert math.isnan(vt.image.ncc(a, b))
        return
    c = _native.ncc_u8(a, b)
    assert abs(c - r * 16384) <= 1.0, (c, r * 16384)


def test_ncc_largest_patch_extremes():
    """VT_MAX_PATCH_PIXELS pixels of 0/255: the int64 sums are at their largest."""
    n = vt.lib.VT_MAX_PATCH_PIXELS
    side = int(math.isqrt(n))
    rng = np.random.default_rng(7)
    a = (rng.integers(0, 2, (side, n // side)) * 255).astype(np.uint8)
    for b in (a.copy(), (255 - a).astype(np.uint8), (rng.integers(0, 2, a.shape) * 255).astype(np.uint8)):
        assert abs(_native.ncc_u8(a, b) - ref.ncc(a, b) * 16384) <= 1.0
    with pytest.raises(vt.VtError) as e:
        _native.ncc_u8(np.zeros((side + 1, n // side), np.uint8), np.zeros((side + 1, n // side), np.uint8))
    assert e.value.status == vt.lib.VT_E_SIZE


@given(pair=patch_pairs())
def test_sad_exact(pair):
    a, b = pair
    assert _native.sad_u8(a, b) == ref.sad(a, b)


def test_sad_largest_frame():
    a = np.zeros((vt.MAX_HEIGHT, vt.MAX_WIDTH), np.uint8)
    b = np.full_like(a, 255)
    assert vt.image.sad(a, b) == 255 * a.size


# sin/cos: table entries are the exact value rounded to Q14, so |error| <= 0.5 LSB
# (plus 1e-9 for the float64 evaluation of the oracle itself).
def test_sincos_every_table_angle():
    for a in range(-1440, 2 * 1440 + 1):
        s, c = _native.sincos_q14(a)
        rs, rc = ref.sincos(a / 4)
        assert abs(s - rs * 16384) <= 0.5 + 1e-9 and abs(c - rc * 16384) <= 0.5 + 1e-9, a


@given(a=st.integers(-(2**31), 2**31 - 1))
def test_sincos_any_int32_angle(a):
    s, c = _native.sincos_q14(a)
    rs, rc = ref.sincos((a % 1440) / 4)
    assert abs(s - rs * 16384) <= 0.5 + 1e-9 and abs(c - rc * 16384) <= 0.5 + 1e-9


def test_sincos_null_outputs():
    s = vt.ffi.new("vt_q14 *")
    assert vt.lib.vt_sincos_q14(10, vt.ffi.NULL, vt.ffi.NULL) == vt.lib.VT_E_ARG
    assert vt.lib.vt_sincos_q14(360, s, vt.ffi.NULL) == vt.lib.VT_OK and s[0] == 16384
