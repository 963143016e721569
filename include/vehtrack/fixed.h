/* vehtrack/fixed.h -- fixed-point vocabulary: named Q formats and their helpers.
 *
 * Cost: header only, no state. Each helper below is a total function of its
 * arguments (every input gives a defined, saturated result), so, like CMSIS-DSP's
 * arithmetic helpers, they return the value; every helper that can fail
 * (a division) returns vt_status instead.
 *
 * Conventions for every helper:
 *   - products are formed in int64, so no intermediate can wrap;
 *   - "round half up" means floor(x + 1/2) on the exact value; "round half away"
 *     means ties go away from zero (as C's lround);
 *   - results outside the destination type saturate to its min/max.
 * C99 leaves >> of a negative value implementation-defined, so scaling shifts go
 * through vt__floor_shr64(), which is floor division by a power of two. */
#ifndef VEHTRACK_FIXED_H
#define VEHTRACK_FIXED_H

#include <stdint.h>
#include "vehtrack/status.h"

/* Q15.16 in int32: image positions and velocities, range [-32768, 32768) px,
 * resolution 1/65536 px. */
typedef int32_t vt_q16;
/* Q1.14 in int16: sines, cosines and correlation coefficients, range [-2, 2),
 * resolution 1/16384. 1.0 is exactly representable (16384). */
typedef int16_t vt_q14;

#define VT_Q16_ONE 65536
#define VT_Q16_SHIFT 16
#define VT_Q14_ONE 16384
#define VT_Q14_SHIFT 14

/* floor(x / 2^n) for every int64 x and 0 <= n <= 63, without relying on >> of
 * negatives. For x < 0 it uses floor(x / d) = -1 - floor((-1 - x) / d): -1 - x
 * is in [0, INT64_MAX] for every negative x, INT64_MIN included, so nothing is
 * ever negated out of range (a saturated covariance reaches INT64_MIN). */
static inline int64_t vt__floor_shr64(int64_t x, int n)
{
    if (x >= 0) {
        return x >> n;
    }
    return -1 - ((-1 - x) >> n);
}

/* Saturate an int32 to int16. */
static inline int16_t vt_sat_s16(int32_t x)
{
    return (int16_t)(x > INT16_MAX ? INT16_MAX : (x < INT16_MIN ? INT16_MIN : x));
}

/* Saturate an int64 to int32. */
static inline int32_t vt_sat_s32(int64_t x)
{
    return (int32_t)(x > INT32_MAX ? INT32_MAX : (x < INT32_MIN ? INT32_MIN : x));
}

/* Integer -> Q16, saturating (|n| >= 32768 saturates). */
static inline vt_q16 vt_q16_from_int(int32_t n)
{
    return vt_sat_s32((int64_t)n * VT_Q16_ONE);
}

/* Q16 -> nearest integer, round half up. Exact (no saturation possible). */
static inline int32_t vt_q16_round(vt_q16 a)
{
    return (int32_t)vt__floor_shr64((int64_t)a + (VT_Q16_ONE / 2), VT_Q16_SHIFT);
}

/* Q16 + Q16 -> Q16, exact, saturating. */
static inline vt_q16 vt_q16_add_sat(vt_q16 a, vt_q16 b)
{
    return vt_sat_s32((int64_t)a + b);
}

/* Q16 - Q16 -> Q16, exact, saturating. */
static inline vt_q16 vt_q16_sub_sat(vt_q16 a, vt_q16 b)
{
    return vt_sat_s32((int64_t)a - b);
}

/* Q16 * Q16 -> Q16: Q32 product in int64, round half up, saturate. */
static inline vt_q16 vt_q16_mul_sat(vt_q16 a, vt_q16 b)
{
    return vt_sat_s32(vt__floor_shr64((int64_t)a * b + (1 << 15), 16));
}

/* Q16 * Q14 -> Q16 (a position times a sine): Q30 in int64, round half up,
 * saturate. */
static inline vt_q16 vt_q16_mul_q14(vt_q16 a, vt_q14 b)
{
    return vt_sat_s32(vt__floor_shr64((int64_t)a * b + (1 << 13), 14));
}

/* Q14 * Q14 -> Q14: Q28 in int32 (cannot overflow), round half up, saturate
 * (only -2 * -2 = 4 saturates). */
static inline vt_q14 vt_q14_mul_sat(vt_q14 a, vt_q14 b)
{
    return vt_sat_s16((int32_t)vt__floor_shr64((int64_t)a * b + (1 << 13), 14));
}

/* floor(sqrt(x)) for any uint32; exact (bit-by-bit restoring method). */
static inline uint16_t vt_isqrt_u32(uint32_t x)
{
    uint32_t res = 0, bit = (uint32_t)1 << 30;
    while (bit > x) {
        bit >>= 2;
    }
    while (bit != 0) {
        if (x >= res + bit) {
            x -= res + bit;
            res = (res >> 1) + bit;
        } else {
            res >>= 1;
        }
        bit >>= 2;
    }
    return (uint16_t)res;
}

/* floor(sqrt(x)) for any uint64; exact. */
static inline uint32_t vt_isqrt_u64(uint64_t x)
{
    uint64_t res = 0, bit = (uint64_t)1 << 62;
    while (bit > x) {
        bit >>= 2;
    }
    while (bit != 0) {
        if (x >= res + bit) {
            x -= res + bit;
            res = (res >> 1) + bit;
        } else {
            res >>= 1;
        }
        bit >>= 2;
    }
    return (uint32_t)res;
}

/* n / d rounded to nearest, ties away from zero, for any int64 n and d != 0.
 * VT_E_SINGULAR if d == 0; INT64_MIN / -1 saturates to INT64_MAX. */
vt_status vt_div_round_s64(int64_t n, int64_t d, int64_t *q);

/* a / b in Q16: (a * 2^16) / b in int64, round half away from zero, saturate
 * to int32. VT_E_SINGULAR if b == 0. */
vt_status vt_q16_div(vt_q16 a, vt_q16 b, vt_q16 *out);

/* 1 / a in Q16, round half away from zero, saturate (|a| < 2 LSB saturates).
 * VT_E_SINGULAR if a == 0. */
vt_status vt_q16_recip(vt_q16 a, vt_q16 *out);

#endif /* VEHTRACK_FIXED_H */
