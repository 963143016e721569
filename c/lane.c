/* lane.c -- lane lines and the road area: thesis sec. 2.4.1 (2.4.1.1 Hough transform,
 * 2.4.1.2 lane detection in the left and right half images with a [-1 0 1] filter,
 * reduction of the lines on one marking to one, left-most/left/right/right-most lines,
 * angle check; fig. 2.8 grouping into a road area; lane tracking over frames).
 *
 * The float oracle, pyvehtrack/reference/lane.py, is the specification; its first
 * comment lists the steps. What this file adds to the thesis, and what each addition
 * bought on the TuSimple test100 set (ego lanes, TuSimple rules, oracle at a 640-px
 * working width, measured in this order while developing):
 *   - the thesis as written (edge pairs voting over the lower frame, innermost line
 *     per half, the line traced upward):                        46.1%, FP 0.69, FN 0.80
 *   - extension toward the vanishing point by pivoting segments that follow the
 *     marking, so far curves are kept:                          66.8%, FP 0.23, FN 0.42
 *   - Hough from the near-field band only; the ego pair chosen by a plausible
 *     vanishing point and lane width:                           82.9%, FP 0.26, FN 0.27
 *   - a row threshold raised by the row's own mean gradient (rough concrete), a
 *     narrowest marking width:                                  85.2%, FP 0.26, FN 0.27
 *   - lanes end just below the vanishing point, where TuSimple's labels end,
 *     flat lines never ego lines:                               86.9%, FP 0.14, FN 0.18
 *   - a least-squares refinement of each line in the band:      87.5%, FP 0.08, FN 0.13
 * Those defaults (320-px working width, refinement before selection, vanishing point
 * allowed inside the band): 89.2%, FP 0.12, FN 0.135 -- tuned on all 100 frames.
 * Issue 8 re-chose them by cross-validation on halves fixed by file order of
 * test_label.json (A = entries 0-49, the 0531 recording; B = 50-99, 0601):
 * tools/tune_lanes.py --tune B (coordinate search over 15 fields) gives B 91.4%, and
 * on A, not used: 89.96%, FP 0.11, FN 0.13, C and oracle alike (tools/eval_tusimple.py
 * --half A). The other fold (tune on A: 92.8%; B, not used: 86.2%) shows the spread:
 * the two-fold mean, 88.1%, is the honest estimate of that procedure. But the B-tuned
 * set lost the KITTI lead car (tools/eval_kitti_track.py: IoU >= 0.6 in 70.5% of the
 * frames against 96.2%), so the defaults stayed the earlier ones. Since 2026-11-30 the
 * search takes no change that lowers the KITTI lead car's tracking or raises its
 * distance P95 or fused-TTC median on KITTI frames 0-38 (--kitti-guard --range-guard):
 * tuned on B (89.21%) it changes grad_min 12 -> 14, mark_wmin_bottom 8 -> 4 and
 * top_margin 37 -> 25, and scores 89.36%, FP 0.11, FN 0.13 on A, not used, C and
 * oracle alike. Those are the defaults. The other fold (tune on A: 90.48%) gives B,
 * not used, 87.96%; the two-fold mean is 88.66%. The search starts from the earlier
 * defaults, which saw both halves. solo_vote_permille (no ego pair: a line needs 1.5x
 * the vote floor) was added for night frames; it changes neither half's figure.
 *
 * Arithmetic: pixels and gradients are exact integers; the Hough rho is
 * x*cos + y*sin with Q1.14 table values (vt_sincos_q14) in Q15 px, binned by a floor
 * shift; geometry is Q16 (vt_q16) in int64 with round-half-away divisions
 * (vt_div_round_s64); every intermediate is bounded in a comment where it is formed. */
#include "vehtrack/lane.h"
#include <string.h>
#include "internal.h"

#define VT__Q16 ((int64_t)65536)
#define VT__SLOPE_MAX ((int64_t)16 * 65536) /* |dx/dy| of an extension segment, Q16 */
#define VT__X_MAX ((int64_t)1 << 30)        /* |x| of any vertex, Q16 (16384 px) */
#define VT__FIT_SLOPE_MAX ((int64_t)8 * 65536)

/* ------------------------------------------------------------------ small helpers */

/* floor(a / b) for b > 0. */
static int64_t vt__fdiv(int64_t a, int64_t b)
{
    int64_t q = a / b;
    return (a % b != 0 && a < 0) ? q - 1 : q;
}

/* ceil(a / b) for b > 0. */
static int64_t vt__cdiv(int64_t a, int64_t b)
{
    return -vt__fdiv(-a, b);
}

static int64_t vt__clamp64(int64_t v, int64_t lo, int64_t hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

static int64_t vt__abs64(int64_t v)
{
    return v < 0 ? -v : v;
}

/* n / d rounded half away from zero; d != 0 and no overflow by construction. */
static int64_t vt__rdiv(int64_t n, int64_t d)
{
    int64_t q = 0;
    (void)vt_div_round_s64(n, d, &q);
    return q;
}

/* W * permille / 1000 as Q16, compared without rounding: |v_q16| * 1000 vs
 * W * p * 65536 (both < 2^47). */
static int vt__le_permille(int64_t v_q16, int32_t W, int32_t p)
{
    return vt__abs64(v_q16) * 1000 <= (int64_t)W * p * VT__Q16;
}

/* x(y) of a line in Q16: xb + slope * (y - (H-1)); |slope| <= 2^21, |y| <= 2^13. */
static int64_t vt__line_x(vt_q16 xb, vt_q16 slope, int32_t y, int32_t H)
{
    return (int64_t)xb + (int64_t)slope * (y - (H - 1));
}

/* ------------------------------------------------------------------ configuration */

#define VT__IN(v, lo, hi) ((v) >= (lo) && (v) <= (hi))

vt_status vt_lane_cfg_default(vt_lane_cfg *cfg)
{
    static const vt_lane_cfg def = VT_LANE_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_lane_cfg_check(const vt_lane_cfg *c)
{
    int32_t nt;
    if (c == NULL) {
        return VT_E_ARG;
    }
    if (c->work_width_max < 16 || c->work_height_max < 16) {
        return VT_E_ARG;
    }
    if (c->work_width_max > VT_LANE_MAX_WORK_W || c->work_height_max > VT_LANE_MAX_WORK_H) {
        return VT_E_CAPACITY;
    }
    if (!VT__IN(c->roi_top_permille, 0, 1000) || !VT__IN(c->hough_top_permille, 0, 1000) ||
        !VT__IN(c->grad_min, 1, 255) || !VT__IN(c->noise_gain_q4, 0, 1024) ||
        !VT__IN(c->mark_w_top_permille, 0, 1000) || !VT__IN(c->mark_w_bottom_permille, 0, 1000) ||
        !VT__IN(c->mark_wmin_top_permille, 0, 1000) ||
        !VT__IN(c->mark_wmin_bottom_permille, 0, 1000) || c->marks_per_row_max < 1 ||
        c->marks_max < 1) {
        return VT_E_ARG;
    }
    if (c->marks_per_row_max > VT_LANE_MAX_ROW_MARKS || c->marks_max > VT_LANE_MAX_MARKS) {
        return VT_E_CAPACITY;
    }
    if (!VT__IN(c->theta_min_qdeg, -356, 356) || !VT__IN(c->theta_max_qdeg, -356, 356) ||
        c->theta_min_qdeg > c->theta_max_qdeg || !VT__IN(c->theta_step_qdeg, 1, 712) ||
        !VT__IN(c->rho_step_shift, 0, 3)) {
        return VT_E_ARG;
    }
    nt = (c->theta_max_qdeg - c->theta_min_qdeg) / c->theta_step_qdeg + 1;
    if (!VT__IN(c->vote_min, 0, 65535) || !VT__IN(c->vote_min_permille, 0, 1000) ||
        !VT__IN(c->nms_theta_bins, 0, 1024) || !VT__IN(c->nms_rho_bins, 0, 4096) ||
        c->max_peaks < 1 || !VT__IN(c->merge_permille, 0, 1000) ||
        !VT__IN(c->min_dtheta_qdeg, 0, 720) || !VT__IN(c->ego_theta_max_qdeg, 0, 360) ||
        !VT__IN(c->ego_vote_permille, 0, 1000) || !VT__IN(c->vp_x_permille, 0, 1000) ||
        !VT__IN(c->vp_low_permille, 0, 1000) ||
        !VT__IN(c->vp_tol_permille, 0, 1000) || !VT__IN(c->vp_tol_min, 0, 4096) ||
        !VT__IN(c->lane_w_min_permille, 0, 10000) ||
        !VT__IN(c->lane_w_max_permille, 0, 10000) ||
        c->lane_w_min_permille > c->lane_w_max_permille || !VT__IN(c->refine_iters, 0, 8) ||
        !VT__IN(c->refine_tol_permille, 0, 1000) || !VT__IN(c->refine_tol_min, 0, 4096) ||
        !VT__IN(c->fit_min_points, 2, 65535) ||
        !VT__IN(c->seg_min, 1, VT_LANE_MAX_WORK_H) || !VT__IN(c->seg_permille, 0, 1000) ||
        !VT__IN(c->bend_q8, 0, 256) || !VT__IN(c->seg_count_min, 0, 65535) ||
        !VT__IN(c->seg_count_permille, 0, 1000) || !VT__IN(c->seg_miss_max, 0, 65535) ||
        !VT__IN(c->win_bottom_permille, 0, 1000) || !VT__IN(c->win_top, 0, 4096) ||
        !VT__IN(c->vp_margin, 0, 4096) || !VT__IN(c->top_margin_permille, 0, 1000) ||
        !VT__IN(c->track_alpha_permille, 0, 1000) || !VT__IN(c->track_hold, 0, 1000000) ||
        !VT__IN(c->track_gate_permille, 0, 1000) ||
        !VT__IN(c->solo_vote_permille, 1000, 10000)) {
        return VT_E_ARG;
    }
    if (c->max_peaks > VT_LANE_MAX_PEAKS || nt > VT_LANE_MAX_THETA) {
        return VT_E_CAPACITY;
    }
    return VT_OK;
}

vt_status vt_lane_reset(vt_lane_state *st)
{
    if (st == NULL) {
        return VT_E_ARG;
    }
    memset(st, 0, sizeof(*st));
    return VT_OK;
}

/* ------------------------------------------------------------------ geometry of a frame */

typedef struct {
    int32_t k, s, W, H, cx, roi_top, band_top; /* k: downscale factor; s: log2 k, or -1 */
    int32_t vp_low; /* lowest plausible vanishing row */
} vt__geom;

static void vt__row_limits(const vt_lane_cfg *cfg, int32_t H, int32_t *roi_top,
                           int32_t *band_top)
{
    int32_t r = H * cfg->roi_top_permille / 1000;
    int32_t b = H * cfg->hough_top_permille / 1000;
    r = r > H - 1 ? H - 1 : r;
    b = b < r ? r : (b > H - 1 ? H - 1 : b);
    *roi_top = r;
    *band_top = b;
}

/* W*(top*(H-1-y) + bottom*y) / (1000*(H-1)), floor, at least 1 (marking widths). */
static int32_t vt__lerp_rows(int32_t y, int32_t W, int32_t H, int32_t top, int32_t bottom)
{
    int64_t den = (int64_t)1000 * (H > 1 ? H - 1 : 1);
    int64_t v = (int64_t)W * ((int64_t)top * (H - 1 - y) + (int64_t)bottom * y) / den;
    return v < 1 ? 1 : (int32_t)v;
}

/* ------------------------------------------------------------------ marking centres */

/* Working row y into st->colsum (values 0..255): mean of k x k blocks, half up. A power
 * of two takes its own loop (a shift); any other k (3, 5, 6, 7: 960, 1600 and 1920 px
 * wide frames come to the same 320 working columns as 1280) divides by a reciprocal.
 * One pass per input row; the inner loops are plain sums the compiler vectorises. */
static void vt__working_row(vt_lane_state *st, const vt_image_u8 *img, const vt__geom *g,
                            int32_t y)
{
    int32_t x, r, j, n = g->k, W = g->W;
    uint16_t *cs = st->colsum;
    const uint8_t *p0 = img->px + (size_t)y * (size_t)n * (size_t)img->stride;
    if (n == 1) {
        for (x = 0; x < W; ++x) {
            cs[x] = p0[x];
        }
        return;
    }
    if (n == 2) {
        const uint8_t *p1 = p0 + img->stride;
        for (x = 0; x < W; ++x) {
            cs[x] = (uint16_t)((p0[2 * x] + p0[2 * x + 1] + p1[2 * x] + p1[2 * x + 1] + 2) >> 2);
        }
        return;
    }
    if (n == 4) {
        for (x = 0; x < W; ++x) {
            cs[x] = 0;
        }
        for (r = 0; r < 4; ++r) {
            const uint8_t *p = p0 + (size_t)r * (size_t)img->stride;
            for (x = 0; x < W; ++x) {
                cs[x] = (uint16_t)(cs[x] + p[4 * x] + p[4 * x + 1] + p[4 * x + 2] + p[4 * x + 3]);
            }
        }
        for (x = 0; x < W; ++x) {
            cs[x] = (uint16_t)((cs[x] + 8) >> 4);
        }
        return;
    }
    /* <= 64 pixels of <= 255 per sum: fits uint16. */
    for (x = 0; x < W; ++x) {
        cs[x] = 0;
    }
    for (r = 0; r < n; ++r) {
        const uint8_t *p = p0 + (size_t)r * (size_t)img->stride;
        for (x = 0; x < W; ++x) {
            uint32_t acc = 0;
            for (j = 0; j < n; ++j) {
                acc += p[x * n + j];
            }
            cs[x] = (uint16_t)(cs[x] + acc);
        }
    }
    if (n == 8) {
        for (x = 0; x < W; ++x) {
            cs[x] = (uint16_t)((cs[x] + 32) >> 6);
        }
        return;
    }
    {
        /* floor(v / d) = (v m) >> 20 with m = ceil(2^20 / d), d = k^2 <= 49: the error
         * v (m d - 2^20) / (d 2^20) stays under 1/d while v d < 2^20, and v (the sum
         * plus d/2) <= 49 * 255 + 24 = 12,519 gives v d <= 613,431. v m < 2^31. */
        const uint32_t d = (uint32_t)(n * n), m = ((1u << 20) + d - 1u) / d, half = d / 2u;
        for (x = 0; x < W; ++x) {
            cs[x] = (uint16_t)(((cs[x] + half) * m) >> 20);
        }
    }
}

/* Marking centres of the working row in st->colsum, appended at st->marks[pos..].
 * Returns how many were found (possibly more than `room`: then none is stored past
 * room and the caller drops the row). */
static int32_t vt__row_marks(vt_lane_state *st, const vt_lane_cfg *cfg, int32_t W,
                             int32_t wmin, int32_t wmax, int32_t pos, int32_t room)
{
    const uint16_t *v = st->colsum;
    int16_t *gr = st->grad;
    int64_t sum;
    int32_t x, thr, xr = -1, n = 0;
    uint32_t acc = 0, span;
    gr[0] = (int16_t)(v[1] - v[0]);
    gr[W - 1] = (int16_t)(v[W - 1] - v[W - 2]);
    acc = (uint32_t)(gr[0] < 0 ? -gr[0] : gr[0]) + (uint32_t)(gr[W - 1] < 0 ? -gr[W - 1] : gr[W - 1]);
    for (x = 1; x < W - 1; ++x) {
        int32_t d = (int32_t)v[x + 1] - (int32_t)v[x - 1];
        gr[x] = (int16_t)d;
        acc += (uint32_t)(d < 0 ? -d : d); /* <= 255 * 4096 */
    }
    sum = acc;
    /* sum <= 255 * 4096, times the gain <= 1024: far below 2^63. */
    thr = (int32_t)(sum * cfg->noise_gain_q4 / (16 * (int64_t)W));
    thr = thr < cfg->grad_min ? cfg->grad_min : thr;
    /* |g| < thr  <=>  (unsigned)(g + thr - 1) <= 2 thr - 2 */
    span = (uint32_t)(2 * thr - 2);
    x = 0;
    for (;;) {
        int32_t best, sg;
        while (x < W && (uint32_t)(gr[x] + thr - 1) <= span) {
            ++x;
        }
        if (x >= W) {
            break;
        }
        /* A maximal run of one sign; its position is the first extreme value. */
        best = x;
        sg = gr[x] > 0;
        if (sg) {
            while (x + 1 < W && gr[x + 1] >= thr) {
                ++x;
                best = gr[x] > gr[best] ? x : best;
            }
            xr = best;
        } else {
            while (x + 1 < W && gr[x + 1] <= -thr) {
                ++x;
                best = gr[x] < gr[best] ? x : best;
            }
            if (xr >= 0 && best - xr >= wmin && best - xr <= wmax) {
                if (n < room) {
                    st->marks[pos + n] = (int16_t)(xr + best);
                }
                ++n;
            }
            xr = -1;
        }
        ++x;
    }
    return n;
}

static void vt__all_marks(vt_lane_state *st, const vt_lane_cfg *cfg, const vt_image_u8 *img,
                          const vt__geom *g, int32_t *n_marks, int32_t *dropped)
{
    int32_t y, pos = 0, drop = 0;
    for (y = 0; y < g->H; ++y) {
        st->row_start[y] = 0;
        st->row_n[y] = 0;
    }
    for (y = g->H - 1; y >= g->roi_top; --y) {
        int32_t wmin = vt__lerp_rows(y, g->W, g->H, cfg->mark_wmin_top_permille,
                                     cfg->mark_wmin_bottom_permille);
        int32_t wmax = vt__lerp_rows(y, g->W, g->H, cfg->mark_w_top_permille,
                                     cfg->mark_w_bottom_permille);
        int32_t left = cfg->marks_max - pos;
        int32_t room = left < cfg->marks_per_row_max ? left : cfg->marks_per_row_max;
        int32_t n;
        vt__working_row(st, img, g, y);
        n = vt__row_marks(st, cfg, g->W, wmin, wmax, pos, room);
        st->row_start[y] = (uint16_t)pos;
        if (n > room) {
            ++drop; /* texture, or no room left: the row is dropped whole */
        } else {
            st->row_n[y] = (uint16_t)n;
            pos += n;
        }
    }
    *n_marks = pos;
    *dropped = drop;
}

/* ------------------------------------------------------------------ Hough */

/* rho bin of a point: x2 = 2*(x - cx) (half px), yrel = y - (H-1), rho in Q15 px is
 * x2*cos + 2*yrel*sin (|x2| <= 8192, |yrel| < 4096: |rho| < 2^28), bin =
 * floor(rho / 2^sh + 1/2). */
static int32_t vt__rho_bin(int32_t x2, int32_t yrel, vt_q14 s, vt_q14 c, int32_t sh)
{
    int64_t r = (int64_t)x2 * c + (int64_t)2 * yrel * s;
    return (int32_t)vt__floor_shr64(r + ((int64_t)1 << (14 + sh)), 15 + sh);
}

/* Accumulator layout of one half (theta rows, their rho ranges from the four corners
 * of the half's band rectangle; rho is linear in x and y, so the corners bound it). */
static vt_status vt__layout(vt_lane_state *st, const vt_lane_cfg *cfg, const vt__geom *g,
                            int32_t half, int32_t *nt_out)
{
    int32_t nt = (cfg->theta_max_qdeg - cfg->theta_min_qdeg) / cfg->theta_step_qdeg + 1;
    int32_t k, total = 0;
    int32_t xlo = half == 0 ? -2 * g->cx : 0;
    int32_t xhi = half == 0 ? -1 : 2 * (g->W - 1) - 2 * g->cx;
    int32_t ylo = g->band_top - (g->H - 1);
    for (k = 0; k < nt; ++k) {
        int32_t t = cfg->theta_min_qdeg + k * cfg->theta_step_qdeg, lo, hi, b, i;
        vt_q14 s, c;
        (void)vt_sincos_q14(half == 0 ? t : -t, &s, &c);
        st->sin_t[k] = s;
        st->cos_t[k] = c;
        lo = hi = vt__rho_bin(xlo, ylo, s, c, cfg->rho_step_shift);
        for (i = 1; i < 4; ++i) {
            b = vt__rho_bin((i & 1) ? xhi : xlo, (i & 2) ? 0 : ylo, s, c, cfg->rho_step_shift);
            lo = b < lo ? b : lo;
            hi = b > hi ? b : hi;
        }
        st->acc_lo[k] = lo;
        st->acc_off[k] = total;
        if (hi - lo + 1 > VT_LANE_ACC_CELLS - total) {
            return VT_E_CAPACITY;
        }
        total += hi - lo + 1;
    }
    st->acc_off[nt] = total;
    *nt_out = nt;
    return VT_OK;
}

static void vt__vote(vt_lane_state *st, const vt_lane_cfg *cfg, const vt__geom *g,
                     int32_t half, int32_t nt)
{
    int32_t y, i, k;
    memset(st->acc, 0, (size_t)st->acc_off[nt] * sizeof(st->acc[0]));
    for (y = g->band_top; y < g->H; ++y) {
        const int16_t *m = st->marks + st->row_start[y];
        int32_t yrel = y - (g->H - 1);
        for (i = 0; i < st->row_n[y]; ++i) {
            int32_t x2 = m[i] - 2 * g->cx;
            if ((x2 < 0) != (half == 0)) {
                continue;
            }
            for (k = 0; k < nt; ++k) {
                int32_t b = vt__rho_bin(x2, yrel, st->sin_t[k], st->cos_t[k],
                                        cfg->rho_step_shift) - st->acc_lo[k];
                int32_t n = st->acc_off[k + 1] - st->acc_off[k];
                if (b >= 0 && b < n) { /* always, by the layout; kept as a guard */
                    uint16_t *a = st->acc + st->acc_off[k] + b;
                    if (*a != UINT16_MAX) {
                        ++*a;
                    }
                }
            }
        }
    }
}

/* Is cell (k, b) with value v the maximum of its window, the first in scan order among
 * equals? */
static int vt__is_peak(const vt_lane_state *st, const vt_lane_cfg *cfg, int32_t nt, int32_t k,
                       int32_t b, uint16_t v)
{
    int32_t kk, bb;
    int32_t k0 = k - cfg->nms_theta_bins < 0 ? 0 : k - cfg->nms_theta_bins;
    int32_t k1 = k + cfg->nms_theta_bins > nt - 1 ? nt - 1 : k + cfg->nms_theta_bins;
    for (kk = k0; kk <= k1; ++kk) {
        int32_t lo = st->acc_lo[kk], n = st->acc_off[kk + 1] - st->acc_off[kk];
        int32_t b0 = b - cfg->nms_rho_bins < lo ? lo : b - cfg->nms_rho_bins;
        int32_t b1 = b + cfg->nms_rho_bins > lo + n - 1 ? lo + n - 1 : b + cfg->nms_rho_bins;
        for (bb = b0; bb <= b1; ++bb) {
            uint16_t a = st->acc[st->acc_off[kk] + (bb - lo)];
            if (a > v) {
                return 0;
            }
            if (a == v && (kk < k || (kk == k && bb < b))) {
                return 0;
            }
        }
    }
    return 1;
}

/* Candidate from cell (k, rho bin b) of a half. */
static void vt__make_cand(vt_lane_cand *c, const vt_lane_state *st, const vt_lane_cfg *cfg,
                          const vt__geom *g, int32_t half, int32_t k, int32_t b, uint16_t v)
{
    int32_t t = cfg->theta_min_qdeg + k * cfg->theta_step_qdeg;
    int64_t rho = (int64_t)b * ((int64_t)1 << cfg->rho_step_shift);
    vt_q14 s = st->sin_t[k], co = st->cos_t[k];
    c->votes = v;
    c->theta_bin = k;
    c->rho_bin = b;
    c->theta = half == 0 ? t : -t;
    c->rho = (int32_t)rho;
    /* x at the bottom row = cx + rho / cos; slope dx/dy = -sin / cos. cos >= 286
     * (|theta| <= 89 deg) and |rho| < 2^13: rho * 2^30 < 2^43. */
    c->xb = (vt_q16)vt__clamp64((int64_t)g->cx * VT__Q16 + vt__rdiv(rho * ((int64_t)1 << 30), co),
                                -VT__X_MAX, VT__X_MAX);
    c->slope = (vt_q16)vt__rdiv(-(int64_t)s * VT__Q16, co);
}

/* ------------------------------------------------------------------ refinement */

/* Least-squares line through the centre nearest to the line in each band row (within
 * the window; the first of equals), refine_iters times with the window halved. */
static void vt__refine(const vt_lane_state *st, const vt_lane_cfg *cfg, const vt__geom *g,
                       vt_lane_cand *ln)
{
    int32_t it, y, i;
    /* A line flatter than any ego line crosses each row at a shallow angle: several
     * centres per row, the nearest one ill-defined. It keeps its Hough line. */
    if ((ln->theta < 0 ? -ln->theta : ln->theta) > cfg->ego_theta_max_qdeg) {
        return;
    }
    for (it = 0; it < cfg->refine_iters; ++it) {
        int64_t tol = ((int64_t)g->W * cfg->refine_tol_permille * VT__Q16 / 1000) >> it;
        int64_t tol_min = (int64_t)cfg->refine_tol_min * VT__Q16;
        int64_t n = 0, st_ = 0, su = 0, stt = 0, stu = 0, den, num, slope, xb;
        tol = tol < tol_min ? tol_min : tol;
        for (y = g->band_top; y < g->H; ++y) {
            const int16_t *m = st->marks + st->row_start[y];
            int64_t xp = vt__line_x(ln->xb, ln->slope, y, g->H), bd = -1;
            int32_t bu = 0;
            for (i = 0; i < st->row_n[y]; ++i) {
                int64_t d = vt__abs64((int64_t)m[i] * 32768 - xp);
                if (d <= tol && (bd < 0 || d < bd)) {
                    bd = d;
                    bu = m[i];
                }
            }
            if (bd >= 0) {
                int64_t t = y - (g->H - 1);
                ++n;
                st_ += t;
                su += bu;
                stt += t * t;
                stu += t * bu;
            }
        }
        if (n < cfg->fit_min_points || n < 2) {
            return;
        }
        /* n <= 4096 rows, |t| < 4096, u < 8192: every product below 2^52. */
        den = n * stt - st_ * st_;
        if (den <= 0) {
            return;
        }
        num = n * stu - st_ * su; /* in half px: slope = num / (2 den) */
        slope = vt__rdiv(num * 32768, den);
        if (vt__abs64(slope) > VT__FIT_SLOPE_MAX) {
            return;
        }
        xb = vt__rdiv(su * 32768 - slope * st_, n);
        ln->slope = (vt_q16)slope;
        ln->xb = (vt_q16)vt__clamp64(xb, -VT__X_MAX, VT__X_MAX);
    }
}

/* A peak needs at least this many votes: max(vote_min, band rows * vote_min_permille
 * / 1000, 1). */
static int32_t vt__vote_floor(const vt_lane_cfg *cfg, const vt__geom *g)
{
    int32_t vmin = (g->H - g->band_top) * cfg->vote_min_permille / 1000;
    vmin = vmin < cfg->vote_min ? cfg->vote_min : vmin;
    return vmin < 1 ? 1 : vmin;
}

/* Peaks of one half into st->cand[half] (strongest first, at most max_peaks), each
 * refined, lines on one marking merged into the stronger. */
static void vt__candidates(vt_lane_state *st, const vt_lane_cfg *cfg, const vt__geom *g,
                           int32_t half, int32_t nt)
{
    vt_lane_cand peaks[VT_LANE_MAX_PEAKS];
    int32_t np = 0, k, i, j, nk = 0;
    int32_t vmin = vt__vote_floor(cfg, g);
    vt__vote(st, cfg, g, half, nt);
    for (k = 0; k < nt; ++k) {
        int32_t lo = st->acc_lo[k], n = st->acc_off[k + 1] - st->acc_off[k], b;
        const uint16_t *row = st->acc + st->acc_off[k];
        for (b = 0; b < n; ++b) {
            uint16_t v = row[b];
            if (v < vmin || !vt__is_peak(st, cfg, nt, k, lo + b, v)) {
                continue;
            }
            /* Insert after every peak with >= votes (scan order among equals). */
            for (i = np; i > 0 && peaks[i - 1].votes < v; --i) {
            }
            if (i >= cfg->max_peaks) {
                continue;
            }
            for (j = (np < cfg->max_peaks ? np : cfg->max_peaks - 1); j > i; --j) {
                peaks[j] = peaks[j - 1];
            }
            vt__make_cand(&peaks[i], st, cfg, g, half, k, lo + b, v);
            np = np < cfg->max_peaks ? np + 1 : np;
        }
    }
    for (i = 0; i < np; ++i) {
        int keep = 1;
        vt__refine(st, cfg, g, &peaks[i]);
        for (j = 0; j < nk && keep; ++j) {
            const vt_lane_cand *o = &st->cand[half][j];
            int64_t dt = vt__line_x(peaks[i].xb, peaks[i].slope, g->band_top, g->H) -
                         vt__line_x(o->xb, o->slope, g->band_top, g->H);
            int64_t db = (int64_t)peaks[i].xb - o->xb;
            if (vt__le_permille(dt, g->W, cfg->merge_permille) &&
                vt__le_permille(db, g->W, cfg->merge_permille)) {
                keep = 0;
            }
        }
        if (keep) {
            st->cand[half][nk++] = peaks[i];
        }
    }
    st->n_cand[half] = nk;
}

/* ------------------------------------------------------------------ selection */

/* Where left line a and right line b meet above the bottom row: d = rows above it
 * (Q16, floor). 0 if they do not. */
static int vt__crossing(const vt_lane_cand *a, const vt_lane_cand *b, int64_t *d)
{
    int64_t num = (int64_t)b->xb - a->xb, den = (int64_t)b->slope - a->slope;
    if (den <= 0 || num <= 0) {
        return 0;
    }
    *d = num * VT__Q16 / den; /* 0 < num < 2^32: < 2^48 */
    return 1;
}

/* (ego, outer) indices of one half among the flagged candidates; -1 if none. */
static void vt__select_half(const vt_lane_cand *c, int32_t n, const uint8_t *ok,
                            const vt_lane_cfg *cfg, int32_t half, int32_t *ego_out,
                            int32_t *outer_out)
{
    int32_t i, first = -1, ego = -1, outer = -1;
    int32_t sgn = half == 0 ? 1 : -1;
    for (i = 0; i < n; ++i) {
        int32_t at = c[i].theta < 0 ? -c[i].theta : c[i].theta;
        if (!ok[i] || at > cfg->ego_theta_max_qdeg) {
            continue;
        }
        if (first < 0) {
            first = ego = i;
            continue;
        }
        {
            int32_t ae = c[ego].theta < 0 ? -c[ego].theta : c[ego].theta;
            if ((int64_t)c[i].votes * 1000 >= (int64_t)c[first].votes * cfg->ego_vote_permille &&
                (int64_t)sgn * c[i].xb > (int64_t)sgn * c[ego].xb &&
                at + cfg->min_dtheta_qdeg <= ae) {
                ego = i;
            }
        }
    }
    if (ego >= 0) {
        int32_t ae = c[ego].theta < 0 ? -c[ego].theta : c[ego].theta;
        for (i = 0; i < n; ++i) {
            int32_t at = c[i].theta < 0 ? -c[i].theta : c[i].theta;
            if (ok[i] && i != ego && (int64_t)sgn * c[i].xb < (int64_t)sgn * c[ego].xb &&
                at >= ae + cfg->min_dtheta_qdeg) {
                outer = i;
                break;
            }
        }
    }
    *ego_out = ego;
    *outer_out = outer;
}

/* Does candidate c pass within tol = max(W*p/1000, tmin) px of the point (xv, d rows
 * above the bottom row)? Measured across the line: |x(yv) - xv| <= tol *
 * sqrt(1 + slope^2), so a flat line's swing in x for one theta bin does not decide.
 * Scaling: |dx| < 2^33 (Q16), norm = sqrt(2^32 + slope^2) in Q16 (floor, < 2^23);
 * both sides of the comparison stay below 2^56. */
static int vt__through(const vt_lane_cand *c, int64_t d, int64_t xv, int32_t W, int32_t p,
                       int32_t tmin)
{
    int64_t dx = (int64_t)c->xb - vt__rdiv((int64_t)c->slope * d, VT__Q16) - xv;
    uint64_t s2 = (uint64_t)((int64_t)c->slope * c->slope);
    int64_t norm = (int64_t)vt_isqrt_u64(((uint64_t)1 << 32) + s2);
    int64_t t1000 = (int64_t)W * p;
    t1000 = t1000 < (int64_t)tmin * 1000 ? (int64_t)tmin * 1000 : t1000;
    return vt__abs64(dx) * 1000 <= t1000 * norm;
}

/* Further lines of one half (issue 8: all lanes): candidates through the vanishing
 * point (ok), in no slot, further out than the half's ego line (a line inside the ego
 * lane is no lane line); in candidate order (strongest first). Appended to
 * extra[*n]. */
static void vt__further(const vt_lane_cand *c, int32_t n, const uint8_t *ok, int32_t half,
                        int32_t ego, int32_t outer, const vt_lane_cand **extra, int32_t *ne)
{
    int32_t i, sgn = half == 0 ? 1 : -1;
    if (ego < 0) {
        return;
    }
    for (i = 0; i < n; ++i) {
        if (ok[i] && i != ego && i != outer &&
            (int64_t)sgn * c[i].xb < (int64_t)sgn * c[ego].xb) {
            extra[(*ne)++] = &c[i];
        }
    }
}

/* Picks the four slots from the candidates; found[slot] = candidate pointer or NULL;
 * extra[0..*n_extra) the further lines (only with a vanishing point); *pair_y the row
 * where the confirming pair meets (floor), -1 without one. */
static void vt__select(const vt_lane_state *st, const vt_lane_cfg *cfg, const vt__geom *g,
                       const vt_lane_cand *found[VT_LANE_SLOTS],
                       const vt_lane_cand *extra[2 * VT_LANE_MAX_PEAKS], int32_t *n_extra,
                       int32_t *pair_y)
{
    const vt_lane_cand *L = st->cand[0], *R = st->cand[1];
    int32_t nl = st->n_cand[0], nr = st->n_cand[1], i, j, best = -1, le, lo, re, ro, vmin;
    int32_t best_row = -1;
    int64_t best_d = 0, best_xv = 0;
    uint8_t okl[VT_LANE_MAX_PEAKS], okr[VT_LANE_MAX_PEAKS];
    for (i = 0; i < nl; ++i) {
        for (j = 0; j < nr; ++j) {
            int64_t d, yv, xv, wb = (int64_t)R[j].xb - L[i].xb;
            if (!vt__crossing(&L[i], &R[j], &d)) {
                continue;
            }
            yv = (int64_t)(g->H - 1) * VT__Q16 - d;
            /* Beyond 2^31 (32768 rows above the bottom) yv is out of range anyway;
             * the clamp keeps slope * d below 2^62. */
            d = d > ((int64_t)1 << 31) ? ((int64_t)1 << 31) : d;
            xv = (int64_t)L[i].xb - vt__rdiv((int64_t)L[i].slope * d, VT__Q16);
            if (yv < (int64_t)(g->roi_top - (g->H - g->band_top)) * VT__Q16 ||
                yv > (int64_t)g->vp_low * VT__Q16) {
                continue;
            }
            if (!vt__le_permille(xv - (int64_t)g->cx * VT__Q16, g->W, cfg->vp_x_permille)) {
                continue;
            }
            if (wb * 1000 < (int64_t)g->W * cfg->lane_w_min_permille * VT__Q16 ||
                wb * 1000 > (int64_t)g->W * cfg->lane_w_max_permille * VT__Q16) {
                continue;
            }
            if (L[i].votes + R[j].votes > best) {
                best = L[i].votes + R[j].votes;
                best_d = d;
                best_xv = xv;
                /* yv passed the range check: d < H * 2^16, so the row fits */
                best_row = (int32_t)(g->H - 1 - (d >> 16));
            }
        }
    }
    /* Without a pair meeting at a plausible vanishing point nothing confirms a line's
     * geometry (night, faded markings): it must then be solo_vote_permille times as
     * strong as the vote floor. votes < 2^16, floor < 2^16: products < 2^31. */
    vmin = vt__vote_floor(cfg, g);
    for (i = 0; i < nl; ++i) {
        okl[i] = (uint8_t)(best < 0 ? (int64_t)L[i].votes * 1000 >= (int64_t)vmin * cfg->solo_vote_permille
                                    : vt__through(&L[i], best_d, best_xv, g->W,
                                                  cfg->vp_tol_permille, cfg->vp_tol_min));
    }
    for (i = 0; i < nr; ++i) {
        okr[i] = (uint8_t)(best < 0 ? (int64_t)R[i].votes * 1000 >= (int64_t)vmin * cfg->solo_vote_permille
                                    : vt__through(&R[i], best_d, best_xv, g->W,
                                                  cfg->vp_tol_permille, cfg->vp_tol_min));
    }
    vt__select_half(L, nl, okl, cfg, 0, &le, &lo);
    vt__select_half(R, nr, okr, cfg, 1, &re, &ro);
    found[VT_LANE_LEFT_MOST] = lo >= 0 ? &L[lo] : NULL;
    found[VT_LANE_LEFT] = le >= 0 ? &L[le] : NULL;
    found[VT_LANE_RIGHT] = re >= 0 ? &R[re] : NULL;
    found[VT_LANE_RIGHT_MOST] = ro >= 0 ? &R[ro] : NULL;
    *n_extra = 0;
    *pair_y = best_row;
    if (best >= 0) {
        vt__further(L, nl, okl, 0, le, lo, extra, n_extra);
        vt__further(R, nr, okr, 1, re, ro, extra, n_extra);
    }
}

/* ------------------------------------------------------------------ extension */

/* y_cap: without vp_known, the line ends no higher than this row (-1: no cap). */
static void vt__extend(vt_lane_state *st, const vt_lane_cfg *cfg, const vt__geom *g,
                       vt_lane_line *ln, int32_t vp_known, int32_t y_v, int32_t y_cap)
{
    int32_t n = 2, y0, y1, misses = 0, target, top;
    int32_t last_i = -1, last_py = 0, last_top = 0;
    int64_t m = ln->slope, x0, last_px = 0, last_m = 0;
    int64_t win_b = (int64_t)g->W * cfg->win_bottom_permille * VT__Q16 / 1000;
    int64_t win_t = (int64_t)cfg->win_top * VT__Q16;
    int32_t den = g->H - 1 - y_v > 1 ? g->H - 1 - y_v : 1;
    target = vp_known ? y_v + g->H * cfg->top_margin_permille / 1000 : y_v + cfg->vp_margin;
    target = !vp_known && y_cap > target ? y_cap : target;
    /* A vanishing point inside the band (a low horizon) ends the line within it. */
    y1 = target > g->band_top ? target : g->band_top;
    y1 = y1 > g->H - 1 ? g->H - 1 : y1;
    y0 = top = y1;
    x0 = vt__clamp64(vt__line_x(ln->xb, ln->slope, y1, g->H), -VT__X_MAX, VT__X_MAX);
    ln->vy[0] = g->H - 1;
    ln->vx[0] = ln->xb;
    ln->vy[1] = y1;
    ln->vx[1] = (vt_q16)x0;
    while (y0 > target && n < VT_LANE_MAX_VERTS) {
        int32_t seg = (y0 - y_v) * cfg->seg_permille / 1000, ns, y, i, k, bestk = 0;
        int32_t need, cnt, best = -1;
        int64_t tol;
        seg = seg < cfg->seg_min ? cfg->seg_min : seg;
        seg = seg > y0 - target ? y0 - target : seg;
        tol = win_t + vt__fdiv((win_b - win_t) * (y0 - y_v), den);
        ns = seg * cfg->bend_q8 / 256;
        for (k = 0; k <= 2 * ns + 1; ++k) {
            st->hist[k] = 0;
        }
        /* Each centre covers the slope candidates k with |e + k*dy/seg| <= tol, e its
         * offset from the current slope's prediction: an interval of k. */
        for (y = y0 - seg; y < y0; ++y) {
            const int16_t *mk = st->marks + st->row_start[y];
            int64_t dy = y0 - y, pred = x0 - m * dy, q = dy * VT__Q16;
            for (i = 0; i < st->row_n[y]; ++i) {
                /* |e| < 2^34, |tol| < 2^29, seg < 2^12: products below 2^47 */
                int64_t e = (int64_t)mk[i] * 32768 - pred;
                int64_t lo = vt__cdiv((-tol - e) * seg, q), hi = vt__fdiv((tol - e) * seg, q);
                lo = lo < -ns ? -ns : lo;
                hi = hi > ns ? ns : hi;
                if (lo <= hi) {
                    ++st->hist[lo + ns];
                    --st->hist[hi + ns + 1];
                }
            }
        }
        cnt = 0;
        for (k = -ns; k <= ns; ++k) {
            int32_t ak = k < 0 ? -k : k, ab = bestk < 0 ? -bestk : bestk;
            cnt += st->hist[k + ns];
            if (cnt > best || (cnt == best && ak < ab)) {
                best = cnt;
                bestk = k;
            }
        }
        need = seg * cfg->seg_count_permille / 1000;
        need = need < cfg->seg_count_min ? cfg->seg_count_min : need;
        if (best >= need) {
            /* Highest row holding a centre covered by the chosen slope. */
            int32_t ytop = y0;
            for (y = y0 - seg; y < y0 && ytop == y0; ++y) {
                const int16_t *mk = st->marks + st->row_start[y];
                int64_t dy = y0 - y, pred = x0 - m * dy, q = dy * VT__Q16;
                for (i = 0; i < st->row_n[y]; ++i) {
                    int64_t e = (int64_t)mk[i] * 32768 - pred;
                    if (vt__cdiv((-tol - e) * seg, q) <= bestk &&
                        bestk <= vt__fdiv((tol - e) * seg, q)) {
                        ytop = y;
                        break;
                    }
                }
            }
            m = vt__clamp64(m + vt__rdiv((int64_t)bestk * VT__Q16, seg), -VT__SLOPE_MAX,
                            VT__SLOPE_MAX);
            last_i = n;
            last_py = y0;
            last_px = x0;
            last_m = m;
            last_top = ytop;
            misses = 0;
        } else {
            ++misses;
            if (!vp_known && misses > cfg->seg_miss_max) {
                break;
            }
        }
        y0 -= seg;
        x0 = vt__clamp64(x0 - m * seg, -VT__X_MAX, VT__X_MAX);
        ln->vy[n] = y0;
        ln->vx[n] = (vt_q16)x0;
        ++n;
    }
    if (vp_known) {
        top = ln->vy[n - 1];
    } else if (last_i < 0) {
        n = 2;
        top = y1;
    } else {
        n = last_i + 1;
        top = last_top;
        ln->vy[last_i] = top;
        ln->vx[last_i] = (vt_q16)vt__clamp64(last_px + last_m * (top - last_py), -VT__X_MAX,
                                             VT__X_MAX);
    }
    ln->n_verts = n;
    ln->y_top = top;
}

vt_status vt_lane_line_x(const vt_lane_line *ln, vt_q16 y, vt_q16 *x)
{
    int32_t i, n;
    int64_t yy;
    if (ln == NULL || x == NULL || ln->state == VT_LANE_NONE || ln->n_verts < 2 ||
        ln->n_verts > VT_LANE_MAX_VERTS) {
        return VT_E_ARG;
    }
    n = ln->n_verts;
    yy = y;
    for (i = 0; i < n - 1; ++i) {
        if (yy >= (int64_t)ln->vy[i + 1] * VT__Q16 || i == n - 2) {
            int64_t ya = vt__clamp64(ln->vy[i], -(1 << 20), 1 << 20);
            int64_t yb = vt__clamp64(ln->vy[i + 1], -(1 << 20), 1 << 20);
            int64_t xa = ln->vx[i], xb = ln->vx[i + 1], dyq;
            if (ya == yb) {
                *x = (vt_q16)xa;
                return VT_OK;
            }
            /* |xb - xa| < 2^32 and |dyq| <= 2^29: the product stays below 2^61. */
            dyq = vt__clamp64(ya * VT__Q16 - yy, -((int64_t)1 << 29), (int64_t)1 << 29);
            *x = (vt_q16)vt__clamp64(xa + vt__rdiv((xb - xa) * dyq, (ya - yb) * VT__Q16),
                                     INT32_MIN, INT32_MAX);
            return VT_OK;
        }
    }
    *x = ln->vx[n - 1];
    return VT_OK;
}

/* ------------------------------------------------------------------ road area */

/* The area between lines l and r (input frame img_w x img_h, working scale k); the
 * lane width per row is their distance / gaps. */
static void vt__road_between(const vt_lane_line *l, const vt_lane_line *r, int32_t gaps,
                             int32_t k, int32_t img_w, int32_t img_h, vt_road_area *road)
{
    int32_t y, y_first, top_w, good_top = -1;
    memset(road, 0, sizeof(*road));
    road->height = img_h;
    if (l->state == VT_LANE_NONE || r->state == VT_LANE_NONE) {
        return;
    }
    top_w = l->y_top > r->y_top ? l->y_top : r->y_top;
    y_first = top_w * k + (k >> 1); /* ceil((top + 1/2) k - 1/2) */
    y_first = y_first < 0 ? 0 : y_first;
    for (y = img_h - 1; y >= y_first; --y) {
        /* working row of input row y: (y + 1/2) / k - 1/2 in Q16, floored (exact when k
         * is a power of two) */
        vt_q16 yw = (vt_q16)((int64_t)(2 * y + 1) * 32768 / k - 32768), xl = 0, xr = 0;
        int64_t il, ir, cl, cr;
        /* both lines are set (checked above), so this fails only on a corrupted
         * result: stop the area there rather than use an unset x */
        if (vt_lane_line_x(l, yw, &xl) != VT_OK || vt_lane_line_x(r, yw, &xr) != VT_OK) {
            break;
        }
        /* input x = (x + 1/2) k - 1/2, rounded half up */
        il = vt__floor_shr64(((int64_t)xl + 32768) * k, 16);
        ir = vt__floor_shr64(((int64_t)xr + 32768) * k, 16);
        cl = vt__clamp64(il, 0, img_w - 1);
        cr = vt__clamp64(ir, 0, img_w - 1);
        if (il > ir || cl > cr) {
            break;
        }
        road->x_left[y] = (int16_t)cl;
        road->x_right[y] = (int16_t)cr;
        road->lane_width[y] = (int16_t)vt__clamp64(vt__fdiv(ir - il, gaps), 0, INT16_MAX);
        good_top = y;
    }
    if (good_top >= 0) {
        road->valid = 1;
        road->y_top = good_top;
        road->y_bottom = img_h - 1;
    }
}

static void vt__road(const vt_lane_result *res, const vt_image_u8 *img, vt_road_area *road)
{
    const vt_lane_line *l = &res->lines[VT_LANE_LEFT], *r = &res->lines[VT_LANE_RIGHT];
    int32_t gaps = 1;
    if (l->state == VT_LANE_NONE) {
        l = &res->lines[VT_LANE_LEFT_MOST];
        ++gaps;
    }
    if (r->state == VT_LANE_NONE) {
        r = &res->lines[VT_LANE_RIGHT_MOST];
        ++gaps;
    }
    vt__road_between(l, r, gaps, res->scale, img->w, img->h, road);
}

vt_status vt_lane_road_all(const vt_lane_result *res, int32_t img_w, int32_t img_h,
                           vt_road_area *road)
{
    int32_t i, n;
    if (res == NULL || road == NULL) {
        return VT_E_ARG;
    }
    if (img_w < 1 || img_h < 1 || img_w > VT_MAX_WIDTH || img_h > VT_MAX_HEIGHT) {
        return VT_E_SIZE;
    }
    n = res->n_lines_all;
    if (n < 0 || n > VT_LANE_MAX_LINES || res->scale < 1 || res->scale > VT_LANE_MAX_SCALE) {
        return VT_E_ARG;
    }
    for (i = 0; i < n; ++i) {
        const vt_lane_line *ln = &res->lines_all[i];
        if (ln->state == VT_LANE_NONE || ln->n_verts < 2 || ln->n_verts > VT_LANE_MAX_VERTS) {
            return VT_E_ARG;
        }
    }
    if (n < 2) {
        memset(road, 0, sizeof(*road));
        road->height = img_h;
        return VT_OK;
    }
    vt__road_between(&res->lines_all[0], &res->lines_all[n - 1], n - 1, res->scale, img_w,
                     img_h, road);
    return VT_OK;
}

/* ------------------------------------------------------------------ tracker */

static void vt__line_from_cand(vt_lane_line *ln, const vt_lane_cand *c)
{
    memset(ln, 0, sizeof(*ln));
    ln->state = VT_LANE_FOUND;
    ln->votes = c->votes;
    ln->theta_bin = c->theta_bin;
    ln->rho_bin = c->rho_bin;
    ln->theta = c->theta;
    ln->rho = c->rho;
    ln->xb = c->xb;
    ln->slope = c->slope;
}

/* The tracked line of a slot from this frame's line (cur, state NONE if absent) and the
 * previous one (prev, NULL if none). */
static void vt__track(const vt_lane_cfg *cfg, const vt__geom *g, const vt_lane_line *prev,
                      vt_lane_line *cur)
{
    int32_t a = cfg->track_alpha_permille;
    if (cur->state == VT_LANE_NONE) {
        if (prev == NULL || prev->held >= cfg->track_hold) {
            return;
        }
        *cur = *prev;
        cur->state = VT_LANE_HELD;
        cur->held = prev->held + 1;
        return;
    }
    if (prev == NULL) {
        return;
    }
    if (!vt__le_permille((int64_t)cur->xb - prev->xb, g->W, cfg->track_gate_permille) ||
        !vt__le_permille(vt__line_x(cur->xb, cur->slope, g->band_top, g->H) -
                             vt__line_x(prev->xb, prev->slope, g->band_top, g->H),
                         g->W, cfg->track_gate_permille)) {
        return;
    }
    /* prev + a (cur - prev) / 1000, the step rounded half away from zero
     * (vt__blend_permille); |cur - prev| < 2^32, and the result lies between
     * prev and cur, so it fits vt_q16. */
    cur->xb = (vt_q16)vt__blend_permille(prev->xb, cur->xb, a);
    cur->slope = (vt_q16)vt__blend_permille(prev->slope, cur->slope, a);
}

/* ------------------------------------------------------------------ the frame */

vt_status vt_lane_detect(vt_lane_state *st, const vt_lane_cfg *cfg, const vt_image_u8 *img,
                         vt_lane_result *res, vt_road_area *road)
{
    vt__geom g;
    vt_status s;
    int32_t nt, i, n_marks, dropped, vp_known = 0, y_v, prev_ok, pair_y, y_cap = -1;
    const vt_lane_cand *found[VT_LANE_SLOTS];
    const vt_lane_cand *extra[2 * VT_LANE_MAX_PEAKS];
    int32_t n_extra = 0;
    vt_lane_line lines[VT_LANE_SLOTS];
    if (st == NULL || res == NULL) {
        return VT_E_ARG;
    }
    s = vt_lane_cfg_check(cfg);
    if (s != VT_OK) {
        return s;
    }
    s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    if (img->w < 16 || img->h < 16) {
        return VT_E_SIZE;
    }
    /* The smallest integer factor that fits (not only powers of two): the defaults were
     * tuned on 320 x 180 working frames, which 640, 960, 1280, 1600 and 1920 px wide
     * 16:9 frames all give. */
    g.k = 1;
    while (g.k < VT_LANE_MAX_SCALE && (img->w / g.k > cfg->work_width_max ||
                                       img->h / g.k > cfg->work_height_max)) {
        ++g.k;
    }
    g.s = (g.k & (g.k - 1)) == 0 ? (g.k >= 8 ? 3 : g.k >= 4 ? 2 : g.k >= 2 ? 1 : 0) : -1;
    g.W = img->w / g.k;
    g.H = img->h / g.k;
    if (g.W > cfg->work_width_max || g.H > cfg->work_height_max || g.W < 8 || g.H < 8) {
        return VT_E_SIZE;
    }
    g.cx = g.W / 2;
    vt__row_limits(cfg, g.H, &g.roi_top, &g.band_top);
    g.vp_low = g.H * cfg->vp_low_permille / 1000;
    /* Both halves' accumulators must fit before anything is written out. */
    for (i = 0; i < 2; ++i) {
        s = vt__layout(st, cfg, &g, i, &nt);
        if (s != VT_OK) {
            return s;
        }
    }

    vt__all_marks(st, cfg, img, &g, &n_marks, &dropped);
    for (i = 0; i < 2; ++i) {
        (void)vt__layout(st, cfg, &g, i, &nt);
        vt__candidates(st, cfg, &g, i, nt);
    }
    vt__select(st, cfg, &g, found, extra, &n_extra, &pair_y);

    prev_ok = st->prev_valid == 1 && st->prev_scale == g.k && st->prev_w == g.W &&
              st->prev_h == g.H;
    for (i = 0; i < VT_LANE_SLOTS; ++i) {
        const vt_lane_line *prev = NULL;
        if (found[i] != NULL) {
            vt__line_from_cand(&lines[i], found[i]);
        } else {
            memset(&lines[i], 0, sizeof(lines[i]));
        }
        if (prev_ok && st->prev[i].state != VT_LANE_NONE && st->prev[i].held >= 0) {
            prev = &st->prev[i];
        }
        vt__track(cfg, &g, prev, &lines[i]);
        /* Whatever the state held, keep the line inside the ranges the geometry uses. */
        lines[i].xb = (vt_q16)vt__clamp64(lines[i].xb, -VT__X_MAX, VT__X_MAX);
        lines[i].slope = (vt_q16)vt__clamp64(lines[i].slope, -VT__SLOPE_MAX, VT__SLOPE_MAX);
    }

    y_v = g.roi_top;
    if (lines[VT_LANE_LEFT].state != VT_LANE_NONE && lines[VT_LANE_RIGHT].state != VT_LANE_NONE) {
        int64_t num = (int64_t)lines[VT_LANE_RIGHT].xb - lines[VT_LANE_LEFT].xb;
        int64_t den = (int64_t)lines[VT_LANE_RIGHT].slope - lines[VT_LANE_LEFT].slope;
        /* num is the ego lane's width at the bottom row. Two lines the refine passes or
         * the tracker pulled onto one marking meet at a false vanishing row (the
         * whole-road detector's horizon, 100 rows off on tusimple-vehicles-dev 4065):
         * the pair must still be at least half the selection's minimum width apart
         * (half: a pair selected at the minimum may narrow a little as it is refined). */
        if (num > 0 && den > 0 && num * 2000 >= (int64_t)g.W * cfg->lane_w_min_permille * VT__Q16) {
            int64_t yv = (int64_t)(g.H - 1) - num / den;
            if (yv >= g.roi_top && yv <= g.vp_low) {
                vp_known = 1;
                y_v = (int32_t)yv;
            }
        }
    }
    /* No ego vanishing point, but a pair confirmed the selection (one of its lines not
     * an ego line, or an ego line missing): no line runs on past that pair's
     * vanishing row (Udacity test1: a lone right line climbed into the trees). */
    if (!vp_known && pair_y >= g.roi_top && pair_y <= g.vp_low) {
        y_cap = pair_y + g.H * cfg->top_margin_permille / 1000;
    }
    for (i = 0; i < VT_LANE_SLOTS; ++i) {
        if (lines[i].state != VT_LANE_NONE) {
            vt__extend(st, cfg, &g, &lines[i], vp_known, y_v, y_cap);
        }
    }

    memset(res, 0, sizeof(*res));
    res->shift = g.s;
    res->scale = g.k;
    res->w = g.W;
    res->h = g.H;
    res->roi_top = g.roi_top;
    res->band_top = g.band_top;
    res->vp_known = vp_known;
    res->vp_y = y_v;
    res->n_marks = n_marks;
    res->rows_dropped = dropped;
    res->pair_vp_y = pair_y;
    for (i = 0; i < VT_LANE_SLOTS; ++i) {
        res->lines[i] = lines[i];
        st->prev[i] = lines[i];
    }
    /* Every line: the slot lines, then the further lines (strongest first within a
     * half, left half first) while there is room; each inserted left to right by xb,
     * after any equal xb (stable). Built in res: no error can occur past this point. */
    for (i = 0; i < VT_LANE_SLOTS + n_extra; ++i) {
        int32_t j, n = res->n_lines_all;
        vt_lane_line *dst;
        if (i < VT_LANE_SLOTS && lines[i].state == VT_LANE_NONE) {
            continue;
        }
        if (n >= VT_LANE_MAX_LINES) {
            ++res->lines_all_dropped; /* only further lines: the slots come first */
            continue;
        }
        j = n;
        while (j > 0 && res->lines_all[j - 1].xb >
                            (i < VT_LANE_SLOTS ? lines[i].xb : extra[i - VT_LANE_SLOTS]->xb)) {
            res->lines_all[j] = res->lines_all[j - 1];
            res->lines_all_slot[j] = res->lines_all_slot[j - 1];
            --j;
        }
        dst = &res->lines_all[j];
        if (i < VT_LANE_SLOTS) {
            *dst = lines[i];
            res->lines_all_slot[j] = i;
        } else {
            vt__line_from_cand(dst, extra[i - VT_LANE_SLOTS]);
            dst->xb = (vt_q16)vt__clamp64(dst->xb, -VT__X_MAX, VT__X_MAX);
            dst->slope = (vt_q16)vt__clamp64(dst->slope, -VT__SLOPE_MAX, VT__SLOPE_MAX);
            vt__extend(st, cfg, &g, dst, vp_known, y_v, y_cap);
            res->lines_all_slot[j] = -1;
        }
        res->n_lines_all = n + 1;
    }
    st->prev_valid = 1;
    st->prev_scale = g.k;
    st->prev_w = g.W;
    st->prev_h = g.H;
    if (road != NULL) {
        vt__road(res, img, road);
    }
    return VT_OK;
}
