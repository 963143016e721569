/* trig.c -- sin/cos lookup for the Hough transform (thesis sec. 2.4.1.1).
 * A quarter-wave table folded by symmetry keeps flash at 722 bytes. */
#include "vehtrack/trig.h"
#include <stddef.h>
#include "tables/trig_q14.h"

#define VT__QUARTER (VT_QDEG_TURN / 4)

/* sin of an angle already reduced to [0, VT_QDEG_TURN). */
static vt_q14 vt__sin_reduced(int32_t a)
{
    if (a <= VT__QUARTER) {
        return vt__sin_q14_quarter[a];
    }
    if (a <= 2 * VT__QUARTER) {
        return vt__sin_q14_quarter[2 * VT__QUARTER - a];
    }
    if (a <= 3 * VT__QUARTER) {
        return (vt_q14)-vt__sin_q14_quarter[a - 2 * VT__QUARTER];
    }
    return (vt_q14)-vt__sin_q14_quarter[VT_QDEG_TURN - a];
}

vt_status vt_sincos_q14(vt_angle_qdeg a, vt_q14 *sin_out, vt_q14 *cos_out)
{
    int32_t r;
    if (sin_out == NULL && cos_out == NULL) {
        return VT_E_ARG;
    }
    /* C99 % truncates toward zero; fold negatives up. Works for INT32_MIN. */
    r = a % VT_QDEG_TURN;
    if (r < 0) {
        r += VT_QDEG_TURN;
    }
    if (sin_out != NULL) {
        *sin_out = vt__sin_reduced(r);
    }
    if (cos_out != NULL) {
        /* cos(a) = sin(a + 90 deg) */
        *cos_out = vt__sin_reduced((r + VT__QUARTER) % VT_QDEG_TURN);
    }
    return VT_OK;
}
