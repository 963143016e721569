"""Fixed-point helpers (include/vehtrack/fixed.h) vs the exact reference
(pyvehtrack/reference/fixed.py). Each helper is specified as one rounding of the
exact value followed by saturation, so the tolerance is 0 LSB everywhere,
including at the int16/int32/int64 limits."""
from __future__ import annotations

import math

import pytest
from hypothesis import example, given, strategies as st

import pyvehtrack as vt
from pyvehtrack import _native
from pyvehtrack.reference import fixed as ref

lib = vt.lib
I16 = st.integers(-(2**15), 2**15 - 1)
I32 = st.integers(-(2**31), 2**31 - 1)
I64 = st.integers(-(2**63), 2**63 - 1)
# Draw often at and next to the limits, where saturation and rounding meet.
I32_EDGE = st.one_of(I32, st.sampled_from([-(2**31), -(2**31) + 1, -1, 0, 1, 2**31 - 2, 2**31 - 1,
                                           1 << 16, -(1 << 16), (1 << 15), -(1 << 15)]))
I16_EDGE = st.one_of(I16, st.sampled_from([-(2**15), -(2**15) + 1, -1, 0, 1, 2**14, -(2**14), 2**15 - 1]))


@given(x=st.integers(-(2**31), 2**31 - 1))
def test_sat_s16(x):
    assert lib.vt_sat_s16(x) == ref.sat(x, ref.INT16)


@given(x=I64)
def test_sat_s32(x):
    assert lib.vt_sat_s32(x) == ref.sat(x, ref.INT32)


@given(n=I32_EDGE)
def test_q16_from_int_and_round(n):
    assert lib.vt_q16_from_int(n) == ref.q16_from_int(n)
    assert lib.vt_q16_round(n) == ref.q16_round(n)


@given(a=I32_EDGE, b=I32_EDGE)
def test_q16_add_sub_mul(a, b):
    assert lib.vt_q16_add_sat(a, b) == ref.sat(a + b, ref.INT32)
    assert lib.vt_q16_sub_sat(a, b) == ref.sat(a - b, ref.INT32)
    assert lib.vt_q16_mul_sat(a, b) == ref.q16_mul(a, b)


@given(a=I32_EDGE, b=I16_EDGE)
def test_q16_mul_q14(a, b):
    assert lib.vt_q16_mul_q14(a, b) == ref.q16_mul_q14(a, b)


@given(a=I16_EDGE, b=I16_EDGE)
@example(-(2**15), -(2**15))
def test_q14_mul(a, b):
    assert lib.vt_q14_mul_sat(a, b) == ref.q14_mul(a, b)


@given(x=st.one_of(st.integers(0, 2**32 - 1), st.sampled_from([0, 1, 2, 3, 4, 2**32 - 1, 2**31])))
def test_isqrt_u32(x):
    assert lib.vt_isqrt_u32(x) == math.isqrt(x)


@given(x=st.one_of(st.integers(0, 2**64 - 1), st.sampled_from([0, 1, 2**62, 2**64 - 1, (2**32 - 1) ** 2])))
def test_isqrt_u64(x):
    assert lib.vt_isqrt_u64(x) == math.isqrt(x)


@given(n=I64, d=I64)
@example(-(2**63), -1)
@example(-(2**63), 1)
@example(7, 2)
@example(-7, 2)
def test_div_round_s64(n, d):
    if d == 0:
        with pytest.raises(vt.VtError) as e:
            _native.div_round_s64(n, d)
        assert e.value.status == lib.VT_E_SINGULAR
        return
    assert _native.div_round_s64(n, d) == ref.div_round(n, d)


@given(a=I32_EDGE, b=I32_EDGE)
def test_q16_div_and_recip(a, b):
    if b == 0:
        with pytest.raises(vt.VtError):
            _native.q16_div(a, b)
    else:
        assert _native.q16_div(a, b) == ref.q16_div(a, b)
    if a == 0:
        with pytest.raises(vt.VtError):
            _native.q16_recip(a)
    else:
        assert _native.q16_recip(a) == ref.q16_div(1 << 16, a)


def test_division_null_output():
    assert lib.vt_q16_div(1, 1, vt.ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_div_round_s64(1, 1, vt.ffi.NULL) == lib.VT_E_ARG


def test_status_names():
    for code in (lib.VT_OK, lib.VT_E_ARG, lib.VT_E_SIZE, lib.VT_E_CAPACITY, lib.VT_E_SINGULAR):
        assert _native.status_name(code) not in ("", "unknown status")
    out = vt.ffi.new("const char **")
    assert lib.vt_status_name(12345, out) == lib.VT_E_ARG
    assert lib.vt_status_name(0, vt.ffi.NULL) == lib.VT_E_ARG
