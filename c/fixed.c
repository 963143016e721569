/* fixed.c -- the fixed-point helpers that can fail (divisions); see fixed.h for
 * the scaling and rounding conventions. */
#include "vehtrack/fixed.h"
#include <stddef.h>

vt_status vt_div_round_s64(int64_t n, int64_t d, int64_t *q)
{
    uint64_t un, ud, uq, ur;
    int neg;
    if (q == NULL) {
        return VT_E_ARG;
    }
    if (d == 0) {
        return VT_E_SINGULAR;
    }
    /* Work on magnitudes in uint64 so INT64_MIN has a magnitude too. */
    neg = (n < 0) != (d < 0);
    un = n < 0 ? (uint64_t)0 - (uint64_t)n : (uint64_t)n;
    ud = d < 0 ? (uint64_t)0 - (uint64_t)d : (uint64_t)d;
    uq = un / ud;
    ur = un % ud;
    if (ur >= ud - ur) { /* remainder >= d/2: ties go away from zero */
        uq += 1u;
    }
    /* uq <= 2^63 because un <= 2^63 and the rounding only adds 1 when ud >= 2. */
    if (neg) {
        *q = uq >= (uint64_t)INT64_MAX + 1u ? INT64_MIN : -(int64_t)uq;
    } else {
        *q = uq > (uint64_t)INT64_MAX ? INT64_MAX : (int64_t)uq;
    }
    return VT_OK;
}

vt_status vt_q16_div(vt_q16 a, vt_q16 b, vt_q16 *out)
{
    int64_t q;
    vt_status s;
    if (out == NULL) {
        return VT_E_ARG;
    }
    /* |a * 2^16| < 2^47: the numerator is exact in int64. */
    s = vt_div_round_s64((int64_t)a * VT_Q16_ONE, (int64_t)b, &q);
    if (s != VT_OK) {
        return s;
    }
    *out = vt_sat_s32(q);
    return VT_OK;
}

vt_status vt_q16_recip(vt_q16 a, vt_q16 *out)
{
    return vt_q16_div(VT_Q16_ONE, a, out);
}
