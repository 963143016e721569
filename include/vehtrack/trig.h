/* vehtrack/trig.h -- sine and cosine from a flash table, for the Hough transform
 * (thesis sec. 2.4.1.1: rho = x cos(theta) + y sin(theta)).
 *
 * Cost: a 361-entry static const int16 quarter-wave table (722 bytes of flash),
 * no RAM; one lookup and a sign per call. The table is written by
 * tools/gen_tables.py into c/tables/trig_q14.h; a test regenerates and compares. */
#ifndef VEHTRACK_TRIG_H
#define VEHTRACK_TRIG_H

#include <stdint.h>
#include "vehtrack/fixed.h"
#include "vehtrack/status.h"

/* Angles in quarter degrees: 1440 units per turn. Any int32 is accepted and
 * reduced modulo 1440. */
typedef int32_t vt_angle_qdeg;
#define VT_QDEG_PER_DEG 4
#define VT_QDEG_TURN 1440

/* sin and cos of `a` in Q1.14, each round(v * 16384) of the exact value (table
 * entries are rounded half away from zero at generation time), so the error
 * is <= 0.5 LSB. Either output pointer may be NULL if that value is not wanted,
 * but not both (VT_E_ARG). */
vt_status vt_sincos_q14(vt_angle_qdeg a, vt_q14 *sin_out, vt_q14 *cos_out);

#endif /* VEHTRACK_TRIG_H */
