/* vehtrack/kalman.h -- a linear Kalman filter in fixed point, sizes fixed at
 * compile time, names as in filterpy (x P F H Q R K y S), plus the two motion
 * models of the papers: the thesis's 6-state bottom-edge model (sec. 3.5) and
 * the GIST paper's 4-state constant-velocity model (sec. III.B.2).
 *
 * Cost: sizeof(vt_kf) = 8 + 4 (MX + MZ) (padded to a multiple of 8) +
 * 8 (3 MX^2 + 2 MX MZ + 2 MZ^2) bytes (MX = VT_KF_MAX_X, MZ = VT_KF_MAX_Z):
 * 2360 bytes per filter with the defaults 8 and 4. Stack: about 1.5 KB inside
 * vt_kf_update (1.8 KB on a Cortex-M3).
 * Work, with n = dim_x and m = dim_z: predict does 2 n^3 + n^2 multiplies;
 * update about 2 n^3 + 3 n^2 m + 2 n m^2 + m^3 / 3 multiplies and m (m + 2 n) / 2
 * divisions. Every multiply is 64 x 64 -> 128 bits (four 32 x 32 -> 64 hardware
 * multiplies), every division 128 / 64 bits (two 64 / 32 estimates). The 6-state
 * model costs about 1 400 multiplies and 21 divisions per predict + update.
 *
 * Number formats (why: positions fit the library's Q15.16, but covariances span
 * 1e-3 px^2 (a settled velocity) to 1e6 px^2 (a long coast), nine decades, which
 * no 32-bit format holds with useful resolution at both ends):
 *   - vectors x, z, y: vt_q16 (Q15.16 in int32): px and px/frame, +-32768,
 *     resolution 1.5e-5;
 *   - every matrix (P F H Q R K S): vt_q32 (Q31.32 in int64): +-2^31 (2.1e9 px^2),
 *     resolution 2^-32 (2.3e-10), so 1e-3 px^2 still has 6-7 significant
 *     digits and F, H, K keep 9 decimals.
 * Arithmetic: each product is formed exactly in 128 bits. In a matrix product
 * each term is rounded half up to Q31.32 (so a sum of 8 terms of 2^126 cannot
 * overflow), the terms are added exactly and the sum is saturated once. For
 * the vectors (F x, H x, x + K y) the exact products are summed and rounded
 * half up once. So a result never wraps: huge measurements or covariances
 * saturate at the type's limits (then the filter is at the edge of its range,
 * but no sign flips).
 * Divisions (solving K S = P H^T by Gaussian elimination with partial
 * pivoting) round half away from zero.
 *
 * Limit: an entry of P below ~1e-6 px^2 has fewer than 4 significant digits.
 * Tracking filters stay far above that (settled variances ~1e-2 px^2), but a
 * model with no process noise (Q = 0, e.g. P2 = 1 or A = 0) drives P towards 0
 * as 1/t^3 and, after some hundred updates, the gain and state drift from a
 * float filter's. Keep Q > 0. The state's own rounding (half an LSB per
 * update) is remembered by the filter like any estimation error: against a
 * float filter, x differs by a few LSB in fast filters and up to ~200 LSB
 * (3e-3 px) in the slowest tracking filters (tests/test_kalman.py).
 *
 * P is made exactly symmetric after every predict and update (each pair
 * P[i][j], P[j][i] is replaced by floor of their mean), and the update uses the
 * Joseph form P = (I-KH) P (I-KH)^T + K R K^T, which stays positive
 * semi-definite for any gain, so rounding cannot drive P indefinite beyond a
 * few LSB.
 *
 * Usage (as filterpy): vt_kf_init(&kf, 4, 2), set kf.F, kf.H, kf.Q, kf.R, kf.P,
 * kf.x, then per frame vt_kf_predict(&kf) and, when there is a measurement,
 * vt_kf_update(&kf, z). Only the leading dim_x x dim_x (etc.) entries are used. */
#ifndef VEHTRACK_KALMAN_H
#define VEHTRACK_KALMAN_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/fixed.h"
#include "vehtrack/status.h"

/* Q31.32 in int64: covariances (px^2, px^2/frame, px^2/frame^2) and the
 * matrices F, H, K; range [-2^31, 2^31), resolution 2^-32. 1.0 is
 * VT_Q32_ONE. */
typedef int64_t vt_q32;
#define VT_Q32_ONE ((vt_q32)1 << 32)
#define VT_Q32_SHIFT 32

/* The filter. All of it is state the caller owns (no pointers inside), so it
 * can be copied, placed in static memory, or saved and restored. Fields are
 * row-major [row][column] as filterpy's arrays. */
typedef struct {
    int32_t dim_x;                                  /* states, 1..VT_KF_MAX_X */
    int32_t dim_z;                                  /* measurements, 1..VT_KF_MAX_Z */
    vt_q16 x[VT_KF_MAX_X];                          /* state estimate */
    vt_q16 y[VT_KF_MAX_Z];                          /* last residual z - H x */
    vt_q32 P[VT_KF_MAX_X][VT_KF_MAX_X];             /* state covariance */
    vt_q32 F[VT_KF_MAX_X][VT_KF_MAX_X];             /* state transition */
    vt_q32 Q[VT_KF_MAX_X][VT_KF_MAX_X];             /* process noise covariance */
    vt_q32 H[VT_KF_MAX_Z][VT_KF_MAX_X];             /* measurement function */
    vt_q32 R[VT_KF_MAX_Z][VT_KF_MAX_Z];             /* measurement noise covariance */
    vt_q32 K[VT_KF_MAX_X][VT_KF_MAX_Z];             /* last gain */
    vt_q32 S[VT_KF_MAX_Z][VT_KF_MAX_Z];             /* last innovation covariance */
} vt_kf;

/* Set up an empty filter as filterpy's KalmanFilter(dim_x, dim_z): x = 0,
 * P = Q = F = I, R = I, H = 0, K = y = S = 0; unused entries are zeroed too.
 * VT_E_ARG for NULL, VT_E_SIZE unless 1 <= dim_x <= VT_KF_MAX_X and
 * 1 <= dim_z <= VT_KF_MAX_Z (then *kf is not touched). */
vt_status vt_kf_init(vt_kf *kf, int32_t dim_x, int32_t dim_z);

/* x = F x; P = F P F^T + Q; P symmetrised. VT_E_ARG for NULL, VT_E_SIZE if
 * the dims in *kf are out of range (nothing is changed then). */
vt_status vt_kf_predict(vt_kf *kf);

/* Measurement update with z[0..dim_z-1] (Q15.16):
 *   y = z - H x; S = H P H^T + R; K = P H^T S^-1; x = x + K y;
 *   P = (I-KH) P (I-KH)^T + K R K^T, symmetrised.
 * VT_E_ARG for NULL, VT_E_SIZE for bad dims, VT_E_SINGULAR when S has no
 * inverse (a zero pivot), the gain would leave the Q31.32 range (|K| >= 2^31,
 * i.e. S singular to working precision), or a diagonal entry of P is
 * saturated (INT64_MAX, e.g. after a long coast: such a P carries no usable
 * information, and a gain from it would leave P indefinite; then nothing is
 * changed). On any error x, P and K are unchanged; after the other
 * VT_E_SINGULAR cases, y and S hold this measurement's values. */
vt_status vt_kf_update(vt_kf *kf, const vt_q16 *z);

/* Variance of the thesis's acceleration model (sec. 3.5.1, eq. 3.24): the
 * acceleration is uniform on [-A, A] with point masses P1 at each of +A and -A
 * and P2 at 0 (Singer's model), so
 *     var = A^2 / 3 * (1 + 4 P1 - P2)     [(px/frame^2)^2].
 * accel = A >= 0 (Q15.16, px/frame^2), p_max = P1, p_zero = P2 (Q15.16
 * probabilities), with P1, P2 >= 0 and 2 P1 + P2 <= 1 (the uniform part's
 * weight cannot be negative); otherwise VT_E_ARG. *var is in Q31.32: the exact
 * value rounded half away from zero once; it cannot overflow (var <= A^2 < 2^30). */
vt_status vt_kf_accel_var(vt_q16 accel, vt_q16 p_max, vt_q16 p_zero, vt_q32 *var);

/* The parameters of the two motion models (const, may live in flash). All are
 * Q15.16. */
typedef struct {
    vt_q16 dt;             /* frames per step (> 0) */
    vt_q16 accel_x;        /* A along x, px/frame^2 (>= 0) */
    vt_q16 accel_y;        /* A along y, px/frame^2 (>= 0) */
    vt_q16 p_max;          /* P1: probability of full acceleration +A (and of -A) */
    vt_q16 p_zero;         /* P2: probability of constant velocity */
    vt_q16 meas_sigma_x;   /* measurement noise std along x, px (>= 0) */
    vt_q16 meas_sigma_y;   /* measurement noise std along y, px (>= 0) */
    vt_q16 init_sigma_pos; /* initial std of the positions, px (>= 0) */
    vt_q16 init_sigma_vel; /* initial std of the velocities, px/frame (>= 0) */
} vt_kf_model_cfg;

/* Plausible values for a 640x480 camera at 25-30 fps: a vehicle's image
 * acceleration rarely exceeds 1 px/frame^2, a shadow-edge / vertical-edge
 * measurement is good to about 2 px, and a detection says nothing of velocity. */
#define VT_KF_MODEL_CFG_DEFAULT                                             \
    {                                                                       \
        .dt = VT_Q16_ONE, /* 1 frame */                                \
        .accel_x = VT_Q16_ONE, /* 1 px/frame^2 */                 \
        .accel_y = VT_Q16_ONE / 2, /* 0.5 px/frame^2 */           \
        .p_max = VT_Q16_ONE / 10, /* 0.1 */                         \
        .p_zero = VT_Q16_ONE * 3 / 10, /* 0.3 */                   \
        .meas_sigma_x = 2 * VT_Q16_ONE, /* 2 px */           \
        .meas_sigma_y = 2 * VT_Q16_ONE, /* 2 px */           \
        .init_sigma_pos = 4 * VT_Q16_ONE, /* 4 px */       \
        .init_sigma_vel = 5 * VT_Q16_ONE, /* 5 px/frame */ \
    }

/* The domain of a vt_kf_model_cfg (all Q15.16). Why these bounds: with them
 * no initial P, Q or R entry saturates Q31.32 (sigma^2 <= 2^20 px^2, var dt^4 / 4
 * <= 2^12 * 2^12 / 4), a measurement is never trusted beyond the pixel grid's
 * quantisation (sigma >= 1/4 px: R = 0 with a sub-frame dt drives the Joseph
 * form into cancellations of 2^16-fold gains), and dt stays between a
 * sixteenth of a frame and 8 frames (the papers use 1). */
#define VT_KF_DT_MIN (VT_Q16_ONE / 16)
#define VT_KF_DT_MAX (8 * VT_Q16_ONE)
#define VT_KF_ACCEL_MAX (64 * VT_Q16_ONE)
#define VT_KF_MEAS_SIGMA_MIN (VT_Q16_ONE / 4)
#define VT_KF_MEAS_SIGMA_MAX (1024 * VT_Q16_ONE)
#define VT_KF_POS_SIGMA_MAX (1024 * VT_Q16_ONE)
#define VT_KF_VEL_SIGMA_MAX (256 * VT_Q16_ONE)

/* VT_OK if every field of *cfg is inside its domain: VT_KF_DT_MIN <= dt <=
 * VT_KF_DT_MAX, 0 <= accel_x, accel_y <= VT_KF_ACCEL_MAX, P1, P2 as
 * vt_kf_accel_var, VT_KF_MEAS_SIGMA_MIN <= meas_sigma_* <= VT_KF_MEAS_SIGMA_MAX,
 * 0 <= init_sigma_pos <= VT_KF_POS_SIGMA_MAX, 0 <= init_sigma_vel <=
 * VT_KF_VEL_SIGMA_MAX; VT_E_ARG otherwise (and for NULL). */
vt_status vt_kf_model_cfg_check(const vt_kf_model_cfg *cfg);

/* Fill *cfg with VT_KF_MODEL_CFG_DEFAULT (so bindings need not copy it).
 * VT_E_ARG for NULL. */
vt_status vt_kf_model_cfg_default(vt_kf_model_cfg *cfg);

/* State layout of the bottom-edge model (thesis eq. 3.17). */
#define VT_KF_BE_DIM_X 6
#define VT_KF_BE_DIM_Z 3
/* State layout of the constant-velocity model. */
#define VT_KF_CV_DIM_X 4
#define VT_KF_CV_DIM_Z 2

/* The thesis's bottom-edge model (sec. 3.5): state [x1, y1, x2, vx1, vy1, vx2]
 * (bottom-left and bottom-right corners of the box share one y), measurement
 * [x1, y1, x2]:
 *   F = [[I3, dt I3], [0, I3]], H = [I3 0],
 *   Q = diag(0, 0, 0, sx dt^2, sy dt^2, sx dt^2) with sx, sy the acceleration
 *       variances of vt_kf_accel_var for accel_x, accel_y (the process noise is
 *       a change of velocity only, eq. 3.20 and 3.25),
 *   R = diag(mx^2, my^2, mx^2), P = diag(p^2, p^2, p^2, v^2, v^2, v^2),
 *   x = [x1, y1, x2, 0, 0, 0].
 * VT_E_ARG for NULL or a cfg outside its domain (then *kf is not touched). */
vt_status vt_kf_init_bottom_edge(vt_kf *kf, const vt_kf_model_cfg *cfg, vt_q16 x1, vt_q16 y1,
                                 vt_q16 x2);

/* The constant-velocity model (GIST paper, eqs. 1-3): state [x, y, vx, vy],
 * measurement [x, y], F with dt, H picking x and y; Q is the piecewise-constant
 * white acceleration noise per axis (filterpy's Q_discrete_white_noise):
 *   var * [[dt^4/4, dt^3/2], [dt^3/2, dt^2]] on (x, vx) and on (y, vy),
 * with var from vt_kf_accel_var (the thesis's acceleration model, so both
 * models share one parameter set); R = diag(mx^2, my^2),
 * P = diag(p^2, p^2, v^2, v^2), x = [x, y, 0, 0].
 * VT_E_ARG for NULL or a cfg outside its domain (then *kf is not touched). */
vt_status vt_kf_init_cv(vt_kf *kf, const vt_kf_model_cfg *cfg, vt_q16 x, vt_q16 y);

/* A measurement with its own noise (IVVI paper eq. 6: the error of a distance grows with
 * it, so each measurement brings its R): kf->R = r (dim_z x dim_z, row-major, Q31.32),
 * then vt_kf_update(kf, z). r must be symmetric with a non-negative diagonal, else
 * VT_E_ARG. It must also be positive semi-definite, which is not checked (a
 * non-PSD r, e.g. [[a, b], [b, 1]] with b^2 > a, can leave a negative variance in
 * P). On any error *kf is unchanged (R included). (c/kalman_r.c) */
vt_status vt_kf_update_r(vt_kf *kf, const vt_q16 *z, const vt_q32 *r);

#endif /* VEHTRACK_KALMAN_H */
