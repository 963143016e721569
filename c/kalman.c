/* kalman.c -- fixed-point linear Kalman filter (thesis sec. 3.4.4, eqs.
 * 3.11-3.15, with the Joseph-form covariance update) and the two motion models:
 * the thesis's bottom-edge model with its acceleration noise (sec. 3.5, 3.5.1)
 * and the GIST paper's constant-velocity model (sec. III.B.2). Formats and
 * rounding are described in kalman.h.
 *
 * The 128-bit helpers below are written in portable C99 on uint64 halves
 * (no __int128), so the same code runs on a Cortex-M. */
#include "vehtrack/kalman.h"
#include "internal.h"
#include <stddef.h>
#include <string.h>

/* ------------------------------------------------------------ 128-bit helpers */

/* A 128-bit two's-complement integer held in two uint64 (so that no signed
 * overflow can ever happen while it is built). */
typedef struct {
    uint64_t hi;
    uint64_t lo;
} vt__i128;

#define VT__M32 ((uint64_t)0xFFFFFFFFu)

static vt__i128 vt__i128_from_s64(int64_t v)
{
    vt__i128 r;
    r.lo = (uint64_t)v; /* conversion to unsigned is modular: well defined */
    r.hi = v < 0 ? UINT64_MAX : 0u;
    return r;
}

static vt__i128 vt__i128_add(vt__i128 a, vt__i128 b)
{
    vt__i128 r;
    r.lo = a.lo + b.lo;
    r.hi = a.hi + b.hi + (r.lo < a.lo ? 1u : 0u);
    return r;
}

static vt__i128 vt__i128_neg(vt__i128 a)
{
    vt__i128 r;
    r.lo = ~a.lo + 1u;
    r.hi = ~a.hi + (r.lo == 0u ? 1u : 0u);
    return r;
}

static int vt__i128_is_neg(vt__i128 a)
{
    return (int)(a.hi >> 63);
}

/* |v| as uint64 (exact also for INT64_MIN). */
static uint64_t vt__mag64(int64_t v)
{
    return v < 0 ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
}

/* a * b for uint64, exact in 128 bits (schoolbook on 32-bit halves). */
static vt__i128 vt__umul64(uint64_t a, uint64_t b)
{
    uint64_t a0 = a & VT__M32, a1 = a >> 32, b0 = b & VT__M32, b1 = b >> 32;
    uint64_t p00 = a0 * b0, p01 = a0 * b1, p10 = a1 * b0, p11 = a1 * b1;
    uint64_t mid = (p00 >> 32) + (p01 & VT__M32) + (p10 & VT__M32);
    vt__i128 r;
    r.lo = (mid << 32) | (p00 & VT__M32);
    r.hi = p11 + (p01 >> 32) + (p10 >> 32) + (mid >> 32);
    return r;
}

/* a * b for int64, exact (|a * b| <= 2^126). */
static vt__i128 vt__mul_s64(int64_t a, int64_t b)
{
    vt__i128 r = vt__umul64(vt__mag64(a), vt__mag64(b));
    return ((a < 0) != (b < 0)) ? vt__i128_neg(r) : r;
}

/* floor((a + 2^(sh-1)) / 2^sh): round half up, 0 <= sh <= 63. The caller
 * guarantees |a| < 2^126 so adding the half cannot overflow. */
static vt__i128 vt__i128_rshr(vt__i128 a, int sh)
{
    vt__i128 half, r;
    uint64_t fill;
    if (sh <= 0) {
        return a;
    }
    half.hi = 0u;
    half.lo = (uint64_t)1 << (sh - 1);
    a = vt__i128_add(a, half);
    fill = vt__i128_is_neg(a) ? ~(UINT64_MAX >> sh) : 0u; /* arithmetic shift */
    r.lo = (a.lo >> sh) | (a.hi << (64 - sh));
    r.hi = (a.hi >> sh) | fill;
    return r;
}

/* a * 2^sh, 0 <= sh <= 63; the caller guarantees no overflow (|a| < 2^(127-sh)). */
static vt__i128 vt__i128_shl(vt__i128 a, int sh)
{
    vt__i128 r;
    if (sh <= 0) {
        return a;
    }
    r.hi = (a.hi << sh) | (a.lo >> (64 - sh));
    r.lo = a.lo << sh;
    return r;
}

/* round(a * b / 2^sh), half up, exact in 128 bits. */
static vt__i128 vt__mul_rshr(int64_t a, int64_t b, int sh)
{
    return vt__i128_rshr(vt__mul_s64(a, b), sh);
}

/* acc + sum over k < n of a[k*as] * b[k*bs] >> VT_Q32_SHIFT: one row of a Q31.32
 * matrix product, each product rounded down to Q31.32 and the sum exact in 128
 * bits (the strides walk a row, 1, or a column, the row length, of a [row][col]
 * array). */
static vt__i128 vt__dot_q32(vt__i128 acc, const int64_t *a, int32_t as, const int64_t *b, int32_t bs,
                            int32_t n)
{
    int32_t k;
    for (k = 0; k < n; k++) {
        acc = vt__i128_add(acc, vt__mul_rshr(a[k * as], b[k * bs], VT_Q32_SHIFT));
    }
    return acc;
}

/* Saturate to int64; *sat (if not NULL) is set to 1 when it saturated. */
static int64_t vt__sat64(vt__i128 a, int *sat)
{
    if (a.hi == 0u && (a.lo >> 63) == 0u) {
        return (int64_t)a.lo;
    }
    if (a.hi == UINT64_MAX && (a.lo >> 63) == 1u) {
        /* ~lo < 2^63: the negation stays in range and avoids converting an
         * out-of-range unsigned value to signed. */
        return -(int64_t)(~a.lo) - 1;
    }
    if (sat != NULL) {
        *sat = 1;
    }
    return vt__i128_is_neg(a) ? INT64_MIN : INT64_MAX;
}

static int32_t vt__sat32(vt__i128 a)
{
    return vt_sat_s32(vt__sat64(a, NULL));
}

/* Number of leading zero bits of v != 0. */
static int vt__nlz64(uint64_t v)
{
    int n = 0;
    if (v <= (uint64_t)0x00000000FFFFFFFFu) { n += 32; v <<= 32; }
    if (v <= (uint64_t)0x0000FFFFFFFFFFFFu) { n += 16; v <<= 16; }
    if (v <= (uint64_t)0x00FFFFFFFFFFFFFFu) { n += 8; v <<= 8; }
    if (v <= (uint64_t)0x0FFFFFFFFFFFFFFFu) { n += 4; v <<= 4; }
    if (v <= (uint64_t)0x3FFFFFFFFFFFFFFFu) { n += 2; v <<= 2; }
    if (v <= (uint64_t)0x7FFFFFFFFFFFFFFFu) { n += 1; }
    return n;
}

/* One 32-bit quotient digit of vt__divlu: the estimate num / vn1, corrected
 * (at most twice) until digit * (vn1:vn0) <= (num:lo), lo the next dividend digit. */
static uint64_t vt__divlu_digit(uint64_t num, uint64_t lo, uint64_t vn1, uint64_t vn0)
{
    const uint64_t b = (uint64_t)1 << 32;
    uint64_t q = num / vn1, rhat = num - q * vn1;
    while (q >= b || q * vn0 > b * rhat + lo) {
        q -= 1u;
        rhat += vn1;
        if (rhat >= b) {
            break;
        }
    }
    return q;
}

/* (u1 * 2^64 + u0) / v for u1 < v (so the quotient fits 64 bits), v != 0;
 * remainder in *rem. Knuth's algorithm D with 32-bit digits, as Hacker's
 * Delight's divlu: two 64/32 estimate steps, each corrected at most twice. */
static uint64_t vt__divlu(uint64_t u1, uint64_t u0, uint64_t v, uint64_t *rem)
{
    const uint64_t b = (uint64_t)1 << 32;
    uint64_t un1, un0, vn1, vn0, q1, q0, un32, un21, un10;
    int s = vt__nlz64(v);
    v <<= s;
    vn1 = v >> 32;
    vn0 = v & VT__M32;
    if (s > 0) {
        un32 = (u1 << s) | (u0 >> (64 - s));
        un10 = u0 << s;
    } else {
        un32 = u1;
        un10 = u0;
    }
    un1 = un10 >> 32;
    un0 = un10 & VT__M32;
    q1 = vt__divlu_digit(un32, un1, vn1, vn0);
    un21 = un32 * b + un1 - q1 * v; /* modulo 2^64; the true value is < v */
    q0 = vt__divlu_digit(un21, un0, vn1, vn0);
    *rem = (un21 * b + un0 - q0 * v) >> s;
    return q1 * b + q0;
}

/* round(n / d), half away from zero, for |n| < 2^127 and d != 0, saturated to
 * int64; *ovf is set to 1 when the exact quotient does not fit. */
static int64_t vt__i128_div(vt__i128 n, int64_t d, int *ovf)
{
    int neg = vt__i128_is_neg(n) != (d < 0);
    vt__i128 mag = vt__i128_is_neg(n) ? vt__i128_neg(n) : n;
    uint64_t ud = vt__mag64(d), q, r;
    if (mag.hi >= ud) { /* quotient >= 2^64 */
        *ovf = 1;
        return neg ? INT64_MIN : INT64_MAX;
    }
    q = vt__divlu(mag.hi, mag.lo, ud, &r);
    if (r >= ud - r) { /* remainder >= d/2: ties go away from zero */
        if (q == UINT64_MAX) {
            *ovf = 1;
            return neg ? INT64_MIN : INT64_MAX;
        }
        q += 1u;
    }
    if (neg) {
        if (q > (uint64_t)INT64_MAX + 1u) {
            *ovf = 1;
            return INT64_MIN;
        }
        return q == (uint64_t)INT64_MAX + 1u ? INT64_MIN : -(int64_t)q;
    }
    if (q > (uint64_t)INT64_MAX) {
        *ovf = 1;
        return INT64_MAX;
    }
    return (int64_t)q;
}

/* floor((a + b) / 2) without overflow. */
static int64_t vt__mean64(int64_t a, int64_t b)
{
    int64_t ra = a - 2 * vt__floor_shr64(a, 1); /* 0 or 1 */
    int64_t rb = b - 2 * vt__floor_shr64(b, 1);
    return vt__floor_shr64(a, 1) + vt__floor_shr64(b, 1) + ((ra + rb) >> 1);
}

/* ------------------------------------------------------------ filter */

static vt_status vt__kf_check(const vt_kf *kf)
{
    if (kf == NULL) {
        return VT_E_ARG;
    }
    if (kf->dim_x < 1 || kf->dim_x > VT_KF_MAX_X || kf->dim_z < 1 || kf->dim_z > VT_KF_MAX_Z) {
        return VT_E_SIZE;
    }
    return VT_OK;
}

/* Replace P[i][j] and P[j][i] by floor of their mean: P becomes exactly
 * symmetric, and a rounding asymmetry of a few LSB is split evenly. */
static void vt__kf_symmetrise(vt_kf *kf)
{
    int32_t i, j, n = kf->dim_x;
    for (i = 0; i < n; i++) {
        for (j = i + 1; j < n; j++) {
            int64_t m = vt__mean64(kf->P[i][j], kf->P[j][i]);
            kf->P[i][j] = m;
            kf->P[j][i] = m;
        }
    }
}

vt_status vt_kf_init(vt_kf *kf, int32_t dim_x, int32_t dim_z)
{
    int32_t i;
    if (kf == NULL) {
        return VT_E_ARG;
    }
    if (dim_x < 1 || dim_x > VT_KF_MAX_X || dim_z < 1 || dim_z > VT_KF_MAX_Z) {
        return VT_E_SIZE;
    }
    memset(kf, 0, sizeof(*kf));
    kf->dim_x = dim_x;
    kf->dim_z = dim_z;
    for (i = 0; i < dim_x; i++) {
        kf->P[i][i] = VT_Q32_ONE;
        kf->F[i][i] = VT_Q32_ONE;
        kf->Q[i][i] = VT_Q32_ONE;
    }
    for (i = 0; i < dim_z; i++) {
        kf->R[i][i] = VT_Q32_ONE;
    }
    return VT_OK;
}

vt_status vt_kf_predict(vt_kf *kf)
{
    /* T = F P, a scratch of 512 bytes. */
    int64_t T[VT_KF_MAX_X][VT_KF_MAX_X];
    vt_q16 xn[VT_KF_MAX_X];
    int32_t i, j, k, n;
    vt_status s = vt__kf_check(kf);
    if (s != VT_OK) {
        return s;
    }
    n = kf->dim_x;
    /* x = F x: Q31.32 * Q15.16 -> Q47.48 terms (< 2^94) summed exactly, one
     * rounding to Q15.16. */
    for (i = 0; i < n; i++) {
        vt__i128 acc = vt__i128_from_s64(0);
        for (k = 0; k < n; k++) {
            acc = vt__i128_add(acc, vt__mul_s64(kf->F[i][k], kf->x[k]));
        }
        xn[i] = vt__sat32(vt__i128_rshr(acc, VT_Q32_SHIFT));
    }
    for (i = 0; i < n; i++) {
        kf->x[i] = xn[i];
    }
    /* P = (F P) F^T + Q, all Q31.32. */
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++) {
            T[i][j] = vt__sat64(vt__dot_q32(vt__i128_from_s64(0), kf->F[i], 1, &kf->P[0][j], VT_KF_MAX_X, n),
                                NULL);
        }
    }
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++) {
            kf->P[i][j] = vt__sat64(vt__dot_q32(vt__i128_from_s64(kf->Q[i][j]), T[i], 1, kf->F[j], 1, n), NULL);
        }
    }
    vt__kf_symmetrise(kf);
    return VT_OK;
}

/* Scratch of vt_kf_update. The gain phase and the covariance phase never live
 * at once, so they share memory (1.3 KB with the default sizes). */
typedef struct {
    int64_t B[VT_KF_MAX_X][VT_KF_MAX_Z]; /* P H^T */
    int64_t M[VT_KF_MAX_Z][VT_KF_MAX_Z]; /* S^T, eliminated in place */
    int64_t X[VT_KF_MAX_Z][VT_KF_MAX_X]; /* right-hand sides B^T, then the solution K^T */
} vt__kf_gain_scratch;
typedef struct {
    int64_t A[VT_KF_MAX_X][VT_KF_MAX_X]; /* I - K H */
    int64_t T[VT_KF_MAX_X][VT_KF_MAX_X]; /* (I - K H) P */
    int64_t U[VT_KF_MAX_X][VT_KF_MAX_Z]; /* K R */
} vt__kf_correct_scratch;
typedef union {
    vt__kf_gain_scratch g;
    vt__kf_correct_scratch c;
} vt__kf_scratch;

/* Solve K S = B for K (n x m), B = P H^T (n x m), by Gaussian elimination with
 * partial pivoting on S^T K^T = B^T. Elimination factors are Q2.61 (|l| <= 1
 * thanks to the pivoting), so the only large rounding is the final division,
 * which is exact to half an LSB of Q31.32. VT_E_SINGULAR for a zero pivot or a
 * gain outside Q31.32; then K is not written. */
static vt_status vt__kf_gain(vt_kf *kf, vt__kf_gain_scratch *w)
{
    enum { LSH = 61 };
    int64_t(*B)[VT_KF_MAX_Z] = w->B;
    int64_t(*M)[VT_KF_MAX_Z] = w->M;
    int64_t(*X)[VT_KF_MAX_X] = w->X;
    int32_t i, j, k, n = kf->dim_x, m = kf->dim_z;
    int ovf = 0;
    for (i = 0; i < m; i++) {
        for (j = 0; j < m; j++) {
            M[i][j] = kf->S[j][i];
        }
        for (j = 0; j < n; j++) {
            X[i][j] = B[j][i];
        }
    }
    for (k = 0; k < m; k++) {
        int32_t p = k;
        for (i = k + 1; i < m; i++) {
            if (vt__mag64(M[i][k]) > vt__mag64(M[p][k])) {
                p = i;
            }
        }
        if (M[p][k] == 0) {
            return VT_E_SINGULAR;
        }
        if (p != k) {
            for (j = 0; j < m; j++) {
                int64_t t = M[k][j];
                M[k][j] = M[p][j];
                M[p][j] = t;
            }
            for (j = 0; j < n; j++) {
                int64_t t = X[k][j];
                X[k][j] = X[p][j];
                X[p][j] = t;
            }
        }
        for (i = k + 1; i < m; i++) {
            int64_t l;
            if (M[i][k] == 0) {
                continue;
            }
            /* l = M[i][k] / M[k][k] in Q2.61; |l| <= 1, so it cannot overflow. */
            l = vt__i128_div(vt__i128_shl(vt__i128_from_s64(M[i][k]), LSH), M[k][k], &ovf);
            for (j = k + 1; j < m; j++) {
                M[i][j] = vt__sat64(vt__i128_add(vt__i128_from_s64(M[i][j]),
                                                 vt__i128_neg(vt__mul_rshr(l, M[k][j], LSH))),
                                    NULL);
            }
            for (j = 0; j < n; j++) {
                X[i][j] = vt__sat64(vt__i128_add(vt__i128_from_s64(X[i][j]),
                                                 vt__i128_neg(vt__mul_rshr(l, X[k][j], LSH))),
                                    NULL);
            }
            M[i][k] = 0;
        }
    }
    /* Back substitution: X[k] = (X[k] - sum_{i>k} M[k][i] X[i]) / M[k][k]. */
    for (k = m - 1; k >= 0; k--) {
        for (j = 0; j < n; j++) {
            vt__i128 acc = vt__i128_from_s64(X[k][j]);
            int64_t num;
            for (i = k + 1; i < m; i++) {
                acc = vt__i128_add(acc, vt__i128_neg(vt__mul_rshr(M[k][i], X[i][j], VT_Q32_SHIFT)));
            }
            num = vt__sat64(acc, &ovf);
            X[k][j] = vt__i128_div(vt__i128_shl(vt__i128_from_s64(num), VT_Q32_SHIFT), M[k][k], &ovf);
        }
    }
    if (ovf) {
        return VT_E_SINGULAR;
    }
    for (i = 0; i < n; i++) {
        for (j = 0; j < m; j++) {
            kf->K[i][j] = X[j][i];
        }
    }
    return VT_OK;
}

/* x = x + K y, then P = (I-KH) P (I-KH)^T + K R K^T (Joseph form), symmetrised. */
static void vt__kf_correct(vt_kf *kf, vt__kf_correct_scratch *w)
{
    int64_t(*A)[VT_KF_MAX_X] = w->A;
    int64_t(*T)[VT_KF_MAX_X] = w->T;
    int64_t(*U)[VT_KF_MAX_Z] = w->U;
    int32_t i, j, k, n = kf->dim_x, m = kf->dim_z;
    /* x + K y summed exactly in Q47.48 and rounded once: the velocity, whose
     * rounding error a long coast multiplies, gets half an LSB per update. */
    for (i = 0; i < n; i++) {
        vt__i128 acc = vt__i128_shl(vt__i128_from_s64(kf->x[i]), VT_Q32_SHIFT);
        for (k = 0; k < m; k++) {
            acc = vt__i128_add(acc, vt__mul_s64(kf->K[i][k], kf->y[k]));
        }
        kf->x[i] = vt__sat32(vt__i128_rshr(acc, VT_Q32_SHIFT));
    }
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++) {
            /* I - K H: the negated sum is exact in 128 bits, as the terms were. */
            vt__i128 kh = vt__dot_q32(vt__i128_from_s64(0), kf->K[i], 1, &kf->H[0][j], VT_KF_MAX_X, m);
            A[i][j] = vt__sat64(vt__i128_add(vt__i128_from_s64(i == j ? VT_Q32_ONE : 0), vt__i128_neg(kh)), NULL);
        }
        for (j = 0; j < m; j++) {
            U[i][j] = vt__sat64(vt__dot_q32(vt__i128_from_s64(0), kf->K[i], 1, &kf->R[0][j], VT_KF_MAX_Z, m),
                                NULL);
        }
    }
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++) {
            T[i][j] = vt__sat64(vt__dot_q32(vt__i128_from_s64(0), A[i], 1, &kf->P[0][j], VT_KF_MAX_X, n), NULL);
        }
    }
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++) {
            vt__i128 acc = vt__dot_q32(vt__i128_from_s64(0), T[i], 1, A[j], 1, n);
            kf->P[i][j] = vt__sat64(vt__dot_q32(acc, U[i], 1, kf->K[j], 1, m), NULL);
        }
    }
    vt__kf_symmetrise(kf);
}

vt_status vt_kf_update(vt_kf *kf, const vt_q16 *z)
{
    vt__kf_scratch w;
    int64_t(*B)[VT_KF_MAX_Z] = w.g.B;
    int32_t i, j, k, n, m;
    vt_status s = vt__kf_check(kf);
    if (s != VT_OK) {
        return s;
    }
    if (z == NULL) {
        return VT_E_ARG;
    }
    n = kf->dim_x;
    m = kf->dim_z;
    /* A variance saturated at the top of Q31.32 (a long coast) carries no
     * usable information, and a gain from it would leave P indefinite: refuse
     * the update (the caller coasts and drops the track). */
    for (i = 0; i < n; i++) {
        if (kf->P[i][i] == INT64_MAX) {
            return VT_E_SINGULAR;
        }
    }
    /* y = z - H x (Q15.16, saturated: a residual beyond +-32768 px is clipped,
     * never wrapped). */
    for (i = 0; i < m; i++) {
        vt__i128 acc = vt__i128_shl(vt__i128_from_s64(z[i]), VT_Q32_SHIFT);
        for (k = 0; k < n; k++) {
            acc = vt__i128_add(acc, vt__i128_neg(vt__mul_s64(kf->H[i][k], kf->x[k])));
        }
        kf->y[i] = vt__sat32(vt__i128_rshr(acc, VT_Q32_SHIFT));
    }
    /* B = P H^T, S = H B + R. */
    for (i = 0; i < n; i++) {
        for (j = 0; j < m; j++) {
            B[i][j] = vt__sat64(vt__dot_q32(vt__i128_from_s64(0), kf->P[i], 1, kf->H[j], 1, n), NULL);
        }
    }
    for (i = 0; i < m; i++) {
        for (j = 0; j < m; j++) {
            kf->S[i][j] = vt__sat64(vt__dot_q32(vt__i128_from_s64(kf->R[i][j]), kf->H[i], 1, &B[0][j], VT_KF_MAX_Z,
                                                n), NULL);
        }
    }
    s = vt__kf_gain(kf, &w.g);
    if (s != VT_OK) {
        return s;
    }
    vt__kf_correct(kf, &w.c);
    return VT_OK;
}

/* ------------------------------------------------------------ models */

vt_status vt_kf_accel_var(vt_q16 accel, vt_q16 p_max, vt_q16 p_zero, vt_q32 *var)
{
    int64_t c;
    int ovf = 0;
    if (var == NULL || accel < 0 || p_max < 0 || p_zero < 0 ||
        2 * (int64_t)p_max + p_zero > VT_Q16_ONE) {
        return VT_E_ARG;
    }
    /* c = 1 + 4 P1 - P2 in Q16, in [0, 3]; A^2 is Q32 exactly (< 2^62). The
     * exact var = A^2 c / (3 * 2^16) is rounded once by the division. */
    c = VT_Q16_ONE + 4 * (int64_t)p_max - p_zero;
    *var = vt__i128_div(vt__mul_s64((int64_t)accel * accel, c), 3 * (int64_t)VT_Q16_ONE, &ovf);
    return VT_OK;
}

vt_status vt_kf_model_cfg_default(vt_kf_model_cfg *cfg)
{
    static const vt_kf_model_cfg def = VT_KF_MODEL_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

/* The parts both models share: validated acceleration variances (Q31.32),
 * dt^2 (Q31.32, exact) and the squared sigmas (Q31.32, exact: a Q15.16
 * square is Q31.32 with no rounding). */
typedef struct {
    vt_q32 var_x, var_y, dt2, mx2, my2, p2, v2;
} vt__kf_model_terms;

vt_status vt_kf_model_cfg_check(const vt_kf_model_cfg *cfg)
{
    vt_q32 var;
    if (cfg == NULL || cfg->dt < VT_KF_DT_MIN || cfg->dt > VT_KF_DT_MAX || cfg->accel_x < 0 ||
        cfg->accel_x > VT_KF_ACCEL_MAX || cfg->accel_y < 0 || cfg->accel_y > VT_KF_ACCEL_MAX ||
        cfg->meas_sigma_x < VT_KF_MEAS_SIGMA_MIN || cfg->meas_sigma_x > VT_KF_MEAS_SIGMA_MAX ||
        cfg->meas_sigma_y < VT_KF_MEAS_SIGMA_MIN || cfg->meas_sigma_y > VT_KF_MEAS_SIGMA_MAX ||
        cfg->init_sigma_pos < 0 || cfg->init_sigma_pos > VT_KF_POS_SIGMA_MAX ||
        cfg->init_sigma_vel < 0 || cfg->init_sigma_vel > VT_KF_VEL_SIGMA_MAX) {
        return VT_E_ARG;
    }
    return vt_kf_accel_var(cfg->accel_x, cfg->p_max, cfg->p_zero, &var);
}

static vt_status vt__kf_model_terms_get(const vt_kf_model_cfg *cfg, vt__kf_model_terms *t)
{
    vt_status s = vt_kf_model_cfg_check(cfg);
    if (s != VT_OK) {
        return s;
    }
    s = vt_kf_accel_var(cfg->accel_x, cfg->p_max, cfg->p_zero, &t->var_x);
    if (s != VT_OK) {
        return s;
    }
    s = vt_kf_accel_var(cfg->accel_y, cfg->p_max, cfg->p_zero, &t->var_y);
    if (s != VT_OK) {
        return s;
    }
    t->dt2 = (int64_t)cfg->dt * cfg->dt;
    t->mx2 = (int64_t)cfg->meas_sigma_x * cfg->meas_sigma_x;
    t->my2 = (int64_t)cfg->meas_sigma_y * cfg->meas_sigma_y;
    t->p2 = (int64_t)cfg->init_sigma_pos * cfg->init_sigma_pos;
    t->v2 = (int64_t)cfg->init_sigma_vel * cfg->init_sigma_vel;
    return VT_OK;
}

/* The common start of the model filters: the model's terms, then an empty
 * dim_x x dim_z filter (a valid size, so vt_kf_init cannot fail). */
static vt_status vt__kf_model_start(vt_kf *kf, const vt_kf_model_cfg *cfg, int32_t dim_x, int32_t dim_z,
                                    vt__kf_model_terms *t)
{
    vt_status s;
    if (kf == NULL) {
        return VT_E_ARG;
    }
    s = vt__kf_model_terms_get(cfg, t);
    if (s != VT_OK) {
        return s;
    }
    (void)vt_kf_init(kf, dim_x, dim_z);
    return VT_OK;
}

vt_status vt_kf_init_bottom_edge(vt_kf *kf, const vt_kf_model_cfg *cfg, vt_q16 x1, vt_q16 y1,
                                 vt_q16 x2)
{
    vt__kf_model_terms t;
    vt_q32 dt;
    int32_t i;
    vt_status s;
    s = vt__kf_model_start(kf, cfg, VT_KF_BE_DIM_X, VT_KF_BE_DIM_Z, &t);
    if (s != VT_OK) {
        return s;
    }
    dt = (vt_q32)cfg->dt << 16; /* Q15.16 -> Q31.32, exact */
    for (i = 0; i < 3; i++) {
        kf->F[i][i + 3] = dt;
        kf->H[i][i] = VT_Q32_ONE;
        kf->P[i][i] = t.p2;
        kf->P[i + 3][i + 3] = t.v2;
        kf->Q[i][i] = 0;
    }
    /* Velocity noise var * dt^2 (eq. 3.25 with T = dt); exact when dt = 1. */
    kf->Q[3][3] = vt__sat64(vt__mul_rshr(t.var_x, t.dt2, VT_Q32_SHIFT), NULL);
    kf->Q[4][4] = vt__sat64(vt__mul_rshr(t.var_y, t.dt2, VT_Q32_SHIFT), NULL);
    kf->Q[5][5] = kf->Q[3][3];
    kf->R[0][0] = t.mx2;
    kf->R[1][1] = t.my2;
    kf->R[2][2] = t.mx2;
    kf->x[0] = x1;
    kf->x[1] = y1;
    kf->x[2] = x2;
    return VT_OK;
}

vt_status vt_kf_init_cv(vt_kf *kf, const vt_kf_model_cfg *cfg, vt_q16 x, vt_q16 y)
{
    vt__kf_model_terms t;
    vt_q32 dt3, dt4;
    int32_t a;
    vt_status s;
    s = vt__kf_model_start(kf, cfg, VT_KF_CV_DIM_X, VT_KF_CV_DIM_Z, &t);
    if (s != VT_OK) {
        return s;
    }
    /* dt^3, dt^4 in Q31.32 (saturating for dt > 1290 frames). */
    dt3 = vt__sat64(vt__mul_rshr(t.dt2, cfg->dt, 16), NULL);
    dt4 = vt__sat64(vt__mul_rshr(t.dt2, t.dt2, VT_Q32_SHIFT), NULL);
    for (a = 0; a < 2; a++) {
        vt_q32 var = a == 0 ? t.var_x : t.var_y;
        /* var dt^4 / 4 and var dt^3 / 2: the /4 and /2 folded into the shift,
         * so dt = 1 gives one rounding of the exact value. */
        vt_q32 qpp = vt__sat64(vt__mul_rshr(var, dt4, VT_Q32_SHIFT + 2), NULL);
        vt_q32 qpv = vt__sat64(vt__mul_rshr(var, dt3, VT_Q32_SHIFT + 1), NULL);
        vt_q32 qvv = vt__sat64(vt__mul_rshr(var, t.dt2, VT_Q32_SHIFT), NULL);
        kf->F[a][a + 2] = (vt_q32)cfg->dt << 16;
        kf->H[a][a] = VT_Q32_ONE;
        kf->Q[a][a] = qpp;
        kf->Q[a][a + 2] = qpv;
        kf->Q[a + 2][a] = qpv;
        kf->Q[a + 2][a + 2] = qvv;
        kf->P[a][a] = t.p2;
        kf->P[a + 2][a + 2] = t.v2;
    }
    kf->R[0][0] = t.mx2;
    kf->R[1][1] = t.my2;
    kf->x[0] = x;
    kf->x[1] = y;
    return VT_OK;
}
