"""Bad arguments reach the C core as error statuses, and Python as clear
exceptions, never a crash: NULL pointers, zero and negative sizes, stride < width,
sizes over the compile-time maxima, mismatched shapes."""
from __future__ import annotations

import numpy as np
import pytest

import pyvehtrack as vt

ffi, lib = vt.ffi, vt.lib
BUF = np.zeros(64 * 64, np.uint8)  # real memory behind every pointer below
BUF16 = np.zeros(64 * 64, np.int16)
BUF32 = np.zeros(65 * 65, np.uint32)


def u8(w, h, stride, px=True):
    v = ffi.new("vt_image_u8 *")
    v.px = ffi.cast("uint8_t *", BUF.ctypes.data) if px else ffi.NULL
    v.w, v.h, v.stride = w, h, stride
    return v


def s16(w, h, stride, px=True):
    v = ffi.new("vt_image_s16 *")
    v.px = ffi.cast("int16_t *", BUF16.ctypes.data) if px else ffi.NULL
    v.w, v.h, v.stride = w, h, stride
    return v


BAD_DIMS = [
    (0, 4, 4), (4, 0, 4), (-1, 4, 4), (4, -1, 4), (4, 4, 3), (4, 4, -4),
    (lib.VT_MAX_WIDTH + 1, 1, lib.VT_MAX_WIDTH + 1), (1, lib.VT_MAX_HEIGHT + 1, 1),
    (2**31 - 1, 2**31 - 1, 2**31 - 1), (-(2**31), 4, 4),
]


@pytest.mark.parametrize("fn", ["vt_filter_h101", "vt_sobel_x", "vt_sobel_y"])
def test_gradient_bad_args(fn):
    f = getattr(lib, fn)
    assert f(ffi.NULL, s16(4, 4, 4)) == lib.VT_E_ARG
    assert f(u8(4, 4, 4), ffi.NULL) == lib.VT_E_ARG
    assert f(u8(4, 4, 4, px=False), s16(4, 4, 4)) == lib.VT_E_ARG
    assert f(u8(4, 4, 4), s16(4, 4, 4, px=False)) == lib.VT_E_ARG
    for d in BAD_DIMS:
        assert f(u8(*d), s16(4, 4, 4)) == lib.VT_E_SIZE, d
        assert f(u8(4, 4, 4), s16(*d)) == lib.VT_E_SIZE, d
    assert f(u8(4, 4, 4), s16(5, 4, 5)) == lib.VT_E_SIZE  # shape mismatch
    assert f(u8(4, 4, 4), s16(4, 4, 4)) == lib.VT_OK


def test_pyr_integral_box_bad_args():
    d8 = ffi.new("vt_image_u8_mut *")
    d8.px = ffi.cast("uint8_t *", BUF.ctypes.data)
    d8.w, d8.h, d8.stride = 2, 2, 2
    assert lib.vt_pyr_down(u8(4, 4, 4), d8) == lib.VT_OK
    assert lib.vt_pyr_down(u8(4, 4, 4), ffi.NULL) == lib.VT_E_ARG
    d8.w = 3
    assert lib.vt_pyr_down(u8(4, 4, 4), d8) == lib.VT_E_SIZE
    for d in BAD_DIMS:
        assert lib.vt_pyr_down(u8(*d), d8) == lib.VT_E_SIZE
    ii = ffi.new("vt_image_u32 *")
    ii.px = ffi.cast("uint32_t *", BUF32.ctypes.data)
    ii.w, ii.h, ii.stride = 5, 5, 5
    assert lib.vt_integral(u8(4, 4, 4), ii) == lib.VT_OK
    assert lib.vt_integral(u8(4, 4, 4), ffi.NULL) == lib.VT_E_ARG
    ii.w = 4
    assert lib.vt_integral(u8(4, 4, 4), ii) == lib.VT_E_SIZE
    ii.w = 5
    s = ffi.new("uint32_t *")
    assert lib.vt_box_sum(ii, 0, 0, 4, 4, s) == lib.VT_OK
    assert lib.vt_box_sum(ii, 0, 0, 4, 4, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_box_sum(ffi.NULL, 0, 0, 4, 4, s) == lib.VT_E_ARG
    for rect in [(0, 0, 5, 1), (0, 0, 1, 5), (-1, 0, 1, 1), (0, -1, 1, 1), (0, 0, 0, 1), (0, 0, 1, 0),
                 (3, 0, 2, 1), (2**31 - 1, 0, 2**31 - 1, 1), (0, 2**31 - 1, 1, 2**31 - 1),
                 (-(2**31), 0, 1, 1), (1, 1, -(2**31), 1)]:
        assert lib.vt_box_sum(ii, *rect, s) == lib.VT_E_SIZE, rect


def test_pyr_down_rect_bad_args():
    d8 = ffi.new("vt_image_u8_mut *")
    d8.px = ffi.cast("uint8_t *", BUF.ctypes.data)
    d8.w, d8.h, d8.stride = 2, 2, 2
    f = lib.vt_pyr_down_rect
    assert f(u8(4, 4, 4), d8, 0, 0, 2, 2) == lib.VT_OK
    assert f(u8(4, 4, 4), d8, 1, 1, 1, 1) == lib.VT_OK           # empty: a no-op
    assert f(u8(4, 4, 4), ffi.NULL, 0, 0, 1, 1) == lib.VT_E_ARG
    assert f(ffi.NULL, d8, 0, 0, 1, 1) == lib.VT_E_ARG
    for r in [(-1, 0, 1, 1), (0, -1, 1, 1), (1, 0, 0, 1), (0, 1, 1, 0), (0, 0, 3, 1), (0, 0, 1, 3),
              (0, 0, 2**31 - 1, 1), (-(2**31), -(2**31), 2**31 - 1, 2**31 - 1), (2**31 - 1, 0, 2**31 - 1, 1)]:
        assert f(u8(4, 4, 4), d8, *r) == lib.VT_E_ARG, r
    d8.w = 3
    assert f(u8(4, 4, 4), d8, 0, 0, 1, 1) == lib.VT_E_SIZE
    for d in BAD_DIMS:
        assert f(u8(*d), d8, 0, 0, 1, 1) == lib.VT_E_SIZE


def test_pair_bad_args():
    q = ffi.new("vt_q14 *")
    s = ffi.new("uint32_t *")
    for f, out in ((lib.vt_ncc_u8, q), (lib.vt_sad_u8, s)):
        assert f(u8(4, 4, 4), u8(4, 4, 4), ffi.NULL) == lib.VT_E_ARG
        assert f(ffi.NULL, u8(4, 4, 4), out) == lib.VT_E_ARG
        assert f(u8(4, 4, 4), u8(4, 5, 4), out) == lib.VT_E_SIZE
        for d in BAD_DIMS:
            assert f(u8(*d), u8(4, 4, 4), out) == lib.VT_E_SIZE
    assert lib.vt_ncc_u8(u8(4, 4, 4), u8(4, 4, 4), q) == lib.VT_E_SINGULAR  # all-zero patches


def test_image_check():
    assert lib.vt_image_u8_check(ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_image_u8_check(u8(4, 4, 4, px=False)) == lib.VT_E_ARG
    assert lib.vt_image_u8_check(u8(4, 4, 4)) == lib.VT_OK
    for d in BAD_DIMS:
        assert lib.vt_image_u8_check(u8(*d)) == lib.VT_E_SIZE


# ------------------------------------------------------------------ Python side
@pytest.mark.parametrize("fn", [vt.image.filter_h101, vt.image.sobel_x, vt.image.sobel_y,
                                vt.image.pyr_down, vt.image.integral])
def test_python_bad_images(fn):
    with pytest.raises(TypeError):
        fn([[1, 2], [3, 4]])
    with pytest.raises(TypeError):
        fn(np.zeros((4, 4), np.float32))
    with pytest.raises(ValueError):
        fn(np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(ValueError):
        fn(np.zeros((4, 8), np.uint8)[:, ::2])  # columns not contiguous
    with pytest.raises(vt.VtError, match=r"vt_\w+: bad size"):
        fn(np.zeros((0, 4), np.uint8))
    with pytest.raises(vt.VtError, match=r"bad size"):
        fn(np.zeros((1, vt.MAX_WIDTH + 1), np.uint8))
    with pytest.raises(vt.VtError, match=r"bad size"):
        fn(np.zeros((vt.MAX_HEIGHT + 1, 1), np.uint8))


def test_python_readonly_output_and_pairs():
    dst = np.zeros((4, 4), np.int16)
    dst.setflags(write=False)
    with pytest.raises(ValueError, match="read-only"):
        vt._native.sobel_x(np.zeros((4, 4), np.uint8), dst)
    with pytest.raises(vt.VtError, match="vt_sad_u8: bad size"):
        vt.image.sad(np.zeros((4, 4), np.uint8), np.zeros((4, 5), np.uint8))
    with pytest.raises(vt.VtError, match="vt_box_sum: bad size"):
        vt.image.box_sum(vt.image.integral(np.zeros((4, 4), np.uint8)), 3, 3, 2, 2)


def test_readonly_input_is_fine():
    img = np.arange(16, dtype=np.uint8).reshape(4, 4)
    img.setflags(write=False)
    assert vt.image.sobel_y(img).shape == (4, 4)
