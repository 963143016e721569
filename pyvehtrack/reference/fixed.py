"""Exact reference for the fixed-point helpers of include/vehtrack/fixed.h.

Each C helper is specified as "exact value, then one rounding, then saturation";
this module computes the exact value with Python integers/Fractions and applies
the same rounding and saturation, so C must match it to 0 LSB."""
from __future__ import annotations

import math
from fractions import Fraction

INT16 = (-(1 << 15), (1 << 15) - 1)
INT32 = (-(1 << 31), (1 << 31) - 1)
INT64 = (-(1 << 63), (1 << 63) - 1)


def sat(v: int, lim: tuple[int, int]) -> int:
    return max(lim[0], min(lim[1], v))


def round_half_up(q: Fraction) -> int:
    return math.floor(q + Fraction(1, 2))


def round_half_away(q: Fraction) -> int:
    r = math.floor(abs(q) + Fraction(1, 2))
    return r if q >= 0 else -r


def q16_mul(a: int, b: int) -> int:
    return sat(round_half_up(Fraction(a * b, 1 << 16)), INT32)


def q16_mul_q14(a: int, b: int) -> int:
    return sat(round_half_up(Fraction(a * b, 1 << 14)), INT32)


def q14_mul(a: int, b: int) -> int:
    return sat(round_half_up(Fraction(a * b, 1 << 14)), INT16)


def q16_round(a: int) -> int:
    return round_half_up(Fraction(a, 1 << 16))


def q16_from_int(n: int) -> int:
    return sat(n << 16, INT32)


def div_round(n: int, d: int, lim=INT64) -> int:
    return sat(round_half_away(Fraction(n, d)), lim)


def q16_div(a: int, b: int) -> int:
    return sat(round_half_away(Fraction(a * (1 << 16), b)), INT32)
