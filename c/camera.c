/* camera.c -- flat-road geometry, range filter, TTC and forward-collision warning
 * (IVVI paper sec. 4: eq. 1 for a camera tilted towards the road, eq. 3-6 for the
 * distance spread of a +-delta px row error, which becomes the distance filter's
 * measurement noise; the pitch from the vanishing point of the detected lanes).
 *
 * Why tan(pitch) and not an angle: eq. 1 written with t = tan(pitch) is a ratio of
 * two linear terms, Y = h (fy - v t) / (v + fy t), so it needs no trig table and the
 * vanishing row gives t with one division. The NHTSA FCW thresholds and the state
 * machine are in vt_fcw_step; see camera.h for every contract. */
#include "vehtrack/camera.h"
#include <stddef.h>
#include "internal.h"

#define VT__Q16_MAXDIST ((int64_t)VT_DIST_MAX_M * VT_Q16_ONE)
#define VT__IN(v, lo, hi) ((v) >= (lo) && (v) <= (hi))

/* x * y / 2^16 for Q16 values, rounded half up, in int64 (no saturation: callers
 * keep |x y| < 2^62). */
static int64_t vt__mul16(int64_t x, int64_t y)
{
    return vt__floor_shr64(x * y + (1 << 15), 16);
}

static int64_t vt__div_or(int64_t n, int64_t d, int64_t fallback)
{
    int64_t q;
    if (vt_div_round_s64(n, d, &q) != VT_OK) {
        return fallback;
    }
    return q;
}

vt_status vt_camera_cfg_default(vt_camera_cfg *cam)
{
    static const vt_camera_cfg def = VT_CAMERA_CFG_DEFAULT;
    return vt__cfg_copy(cam, &def, sizeof def);
}

vt_status vt_camera_cfg_check(const vt_camera_cfg *c)
{
    const int64_t one = VT_Q16_ONE;
    if (c == NULL) {
        return VT_E_ARG;
    }
    if (!VT__IN(c->img_w, 1, 32767) || !VT__IN(c->img_h, 1, 32767)) {
        return VT_E_SIZE;
    }
    if (!VT__IN((int64_t)c->fx, one, 16384 * one) || !VT__IN((int64_t)c->fy, one, 16384 * one) ||
        !VT__IN((int64_t)c->cx, -(int64_t)c->img_w * one, 2 * (int64_t)c->img_w * one) ||
        !VT__IN((int64_t)c->cy, -(int64_t)c->img_h * one, 2 * (int64_t)c->img_h * one) ||
        !VT__IN((int64_t)c->height, 1, 100 * one) || !VT__IN(c->tan_pitch_min, -one, one) ||
        !VT__IN(c->tan_pitch_max, c->tan_pitch_min, one) ||
        !VT__IN(c->tan_pitch, c->tan_pitch_min, c->tan_pitch_max) ||
        !VT__IN(c->pitch_max_step, 1, one) || !VT__IN(c->pitch_alpha_permille, 0, 1000) ||
        !VT__IN(c->pitch_reacquire, 1, 1000) || !VT__IN((int64_t)c->delta_px, 1, 64 * one) ||
        !VT__IN((int64_t)c->bottom_offset, -8 * one, 8 * one) ||
        !VT__IN((int64_t)c->vehicle_width, 1, 10 * one) || !VT__IN(c->width_tol_permille, 10, 10000) ||
        !VT__IN((int64_t)c->lateral, -5 * one, 5 * one)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

/* Eq. 1 on checked arguments. |v| < 2^31 (Q16 px), |tp| <= 2^16, fy <= 2^30 and
 * h <= 2^23 keep every product below 2^62. */
static vt_q16 vt__row_dist(const vt_camera_cfg *c, vt_q16 tp, vt_q16 row, int32_t *valid)
{
    int64_t v = (int64_t)row - c->cy;
    int64_t num = (int64_t)c->fy - vt__mul16(v, tp);
    int64_t den = v + vt__mul16(c->fy, tp);
    int64_t y;
    if (den <= 0) { /* at or above the horizon: the ray never meets the road */
        *valid = 0;
        return (vt_q16)VT__Q16_MAXDIST;
    }
    if (num <= 0) { /* the ray points behind the camera's foot point */
        *valid = 0;
        return 0;
    }
    y = vt__div_or((int64_t)c->height * num, den, VT__Q16_MAXDIST);
    if (y >= VT__Q16_MAXDIST) {
        *valid = 0;
        return (vt_q16)VT__Q16_MAXDIST;
    }
    *valid = 1;
    return (vt_q16)y;
}

vt_status vt_camera_row_distance(const vt_camera_cfg *cam, vt_q16 tp, vt_q16 row, vt_q16 *dist,
                                 int32_t *valid)
{
    if (dist == NULL || valid == NULL || vt_camera_cfg_check(cam) != VT_OK ||
        !VT__IN(tp, -VT_Q16_ONE, VT_Q16_ONE)) {
        return VT_E_ARG;
    }
    *dist = vt__row_dist(cam, tp, row, valid);
    return VT_OK;
}

vt_status vt_camera_box_distance(const vt_camera_cfg *cam, vt_q16 tp, const vt_box *box,
                                 vt_distance *out)
{
    int32_t ok, ok_far, ok_near;
    vt_q16 row, d, dn, df;
    int64_t w, dw;
    if (out == NULL || box == NULL || vt_camera_cfg_check(cam) != VT_OK ||
        !VT__IN(tp, -VT_Q16_ONE, VT_Q16_ONE) || box->right < box->left || box->bottom < box->top) {
        return VT_E_ARG;
    }
    row = vt_sat_s32((int64_t)box->bottom * VT_Q16_ONE + cam->bottom_offset);
    d = vt__row_dist(cam, tp, row, &ok);
    dn = vt__row_dist(cam, tp, vt_q16_add_sat(row, cam->delta_px), &ok_near);
    df = vt__row_dist(cam, tp, vt_q16_sub_sat(row, cam->delta_px), &ok_far);
    (void)ok_near;
    w = ((int64_t)box->right - box->left + 1) * VT_Q16_ONE;
    dw = vt__div_or((int64_t)cam->fx * cam->vehicle_width, w, VT__Q16_MAXDIST);
    if (box->bottom >= cam->img_h - 1) { /* the contact row is below the frame */
        ok = 0;
    }
    out->flags = (ok ? VT_DIST_VALID : 0) | (ok_far ? VT_DIST_FAR_VALID : 0) |
                 (box->bottom >= cam->img_h - 1 ? VT_DIST_BOTTOM_CLIPPED : 0) |
                 (box->left <= 0 || box->right >= cam->img_w - 1 ? VT_DIST_SIDE_CLIPPED : 0);
    out->distance = d;
    out->dist_near = dn;
    out->dist_far = df;
    /* A far row above the horizon saturates at VT_DIST_MAX_M, so sigma is large
     * then: the filter trusts such a measurement little, as it should. */
    out->sigma = (vt_q16)vt__floor_shr64((int64_t)df - dn + 1, 1);
    out->dist_width = (vt_q16)(dw > VT__Q16_MAXDIST ? VT__Q16_MAXDIST : dw);
    /* x 1000 vs permille x d: the old x 100 vs percent x d scaled by 10, the same test */
    if (ok && ((int64_t)out->dist_width - d) * 1000 <= (int64_t)cam->width_tol_permille * d &&
        ((int64_t)d - out->dist_width) * 1000 <= (int64_t)cam->width_tol_permille * d) {
        out->flags |= VT_DIST_WIDTH_AGREES;
    }
    return VT_OK;
}

/* ------------------------------------------------------------------ pitch */
vt_status vt_pitch_init(vt_pitch_state *st, const vt_camera_cfg *cam)
{
    if (st == NULL || vt_camera_cfg_check(cam) != VT_OK) {
        return VT_E_ARG;
    }
    st->tan_pitch = cam->tan_pitch;
    st->flag = VT_PITCH_NOMINAL;
    st->outliers = 0;
    st->run_tan = 0;
    st->measured = 0;
    return VT_OK;
}

vt_status vt_pitch_update(vt_pitch_state *st, const vt_camera_cfg *cam, int32_t vp_valid,
                          vt_q16 vp_row)
{
    int64_t m;
    if (st == NULL || vt_camera_cfg_check(cam) != VT_OK || !VT__IN(vp_valid, 0, 1) ||
        !VT__IN(st->tan_pitch, -VT_Q16_ONE, VT_Q16_ONE)) {
        return VT_E_ARG;
    }
    if (!vp_valid) {
        st->flag = st->measured > 0 ? VT_PITCH_HELD : VT_PITCH_NOMINAL;
        return VT_OK;
    }
    /* tan(pitch) = (cy - vp_row) / fy: the horizon is fy tan(pitch) above cy. */
    m = vt__div_or(((int64_t)cam->cy - vp_row) * VT_Q16_ONE, cam->fy, 0);
    if (m < cam->tan_pitch_min || m > cam->tan_pitch_max) {
        st->flag = VT_PITCH_REJECTED;
        return VT_OK;
    }
    if (m - st->tan_pitch > cam->pitch_max_step || st->tan_pitch - m > cam->pitch_max_step) {
        /* Only a run of outliers that agree with one another is a lasting change: the
         * run restarts at any outlier farther than pitch_max_step from its first one, so
         * scattered wrong rows (a lane pair on a curve, on the barrier) never take over. */
        if (st->outliers > 0 && m - st->run_tan <= cam->pitch_max_step &&
            st->run_tan - m <= cam->pitch_max_step) {
            st->outliers += 1;
        } else {
            st->outliers = 1;
            st->run_tan = (vt_q16)m;
        }
        if (st->outliers < cam->pitch_reacquire) {
            st->flag = VT_PITCH_REJECTED;
            return VT_OK;
        }
        st->tan_pitch = (vt_q16)m;
    } else {
        /* |m|, |tan_pitch| <= 2^16 here; the blend stays between them, so within
         * the limits checked above. */
        st->tan_pitch = (vt_q16)vt__blend_permille(st->tan_pitch, m, cam->pitch_alpha_permille);
    }
    st->outliers = 0;
    st->flag = VT_PITCH_MEASURED;
    if (st->measured < INT32_MAX) {
        st->measured += 1;
    }
    return VT_OK;
}

vt_status vt_lane_vanishing_row(const vt_lane_result *res, int32_t img_h, vt_q16 *vp_row,
                                int32_t *valid)
{
    const vt_lane_line *l, *r;
    int64_t dx, ds, dy, yw, yin;
    if (res == NULL || vp_row == NULL || valid == NULL || !VT__IN(res->scale, 1, VT_LANE_MAX_SCALE)) {
        return VT_E_ARG;
    }
    if (img_h < 1 || img_h > VT_MAX_HEIGHT || res->h < 1 || img_h / res->scale != res->h) {
        return VT_E_SIZE;
    }
    *vp_row = 0;
    *valid = 0;
    l = &res->lines[VT_LANE_LEFT];
    r = &res->lines[VT_LANE_RIGHT];
    if (l->state == VT_LANE_NONE || r->state == VT_LANE_NONE) {
        return VT_OK;
    }
    /* xl + sl dy = xr + sr dy  ->  dy = (xr - xl) / (sl - sr), negative above row H-1 */
    dx = (int64_t)r->xb - l->xb;
    ds = (int64_t)l->slope - r->slope;
    if (ds == 0) {
        return VT_OK;
    }
    dy = vt__div_or(dx * VT_Q16_ONE, ds, 0);
    if (dy >= 0) {
        return VT_OK;
    }
    yw = ((int64_t)res->h - 1) * VT_Q16_ONE + dy;
    /* working row -> input row: (y + 1/2) k - 1/2 */
    yin = (yw + VT_Q16_ONE / 2) * res->scale - VT_Q16_ONE / 2;
    if (yin < -(int64_t)VT_MAX_HEIGHT * 4 * VT_Q16_ONE) {
        return VT_OK; /* meets absurdly far above the frame: no usable point */
    }
    *vp_row = (vt_q16)yin;
    *valid = 1;
    return VT_OK;
}

/* ------------------------------------------------------------------ range + FCW */
vt_status vt_range_cfg_default(vt_range_cfg *cfg)
{
    static const vt_range_cfg def = VT_RANGE_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_range_cfg_check(const vt_range_cfg *c)
{
    const int64_t one = VT_Q16_ONE;
    if (c == NULL) {
        return VT_E_ARG;
    }
    if (!VT__IN((int64_t)c->frame_dt, 1, one) || !VT__IN((int64_t)c->jerk_sigma, 1, 50 * one) ||
        !VT__IN((int64_t)c->init_sigma_rate, 1, 100 * one) ||
        !VT__IN((int64_t)c->init_sigma_accel, 1, 100 * one) ||
        !VT__IN((int64_t)c->sigma_min, 1, 100 * one) || !VT__IN(c->min_frames, 1, 1000) ||
        !VT__IN(c->scale_lag, 1, VT_RANGE_HIST - 1) || !VT__IN((int64_t)c->ttc_max, 1, 1000 * one) ||
        !VT__IN((int64_t)c->ttc_stopped, 0, 1000 * one) ||
        !VT__IN((int64_t)c->ttc_slower, 0, 1000 * one) ||
        !VT__IN((int64_t)c->ttc_decel, 0, 1000 * one) ||
        !VT__IN((int64_t)c->ttc_margin, 0, 10 * one) || !VT__IN(c->confirm_frames, 1, 1000) ||
        !VT__IN(c->rearm_frames, 0, 100000) || !VT__IN(c->release_frames, 1, 1000) ||
        !VT__IN((int64_t)c->min_closing, 0, 100 * one) ||
        !VT__IN((int64_t)c->stopped_speed, 0, 100 * one) ||
        !VT__IN((int64_t)c->decel_thresh, 1, 100 * one) || !VT__IN(c->width_min_frames, 1, 1000) ||
        !VT__IN(c->width_window, 1, 1000) || !VT__IN((int64_t)c->rear_offset, 0, 5 * one) ||
        !VT__IN((int64_t)c->path_half_width, 0, 10 * one)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

vt_status vt_fcw_step(vt_fcw_state *st, const vt_range_cfg *cfg, int32_t ttc_valid, vt_q16 ttc,
                      int32_t closing, int32_t lead_class, int32_t *out)
{
    int64_t thr;
    int32_t cond, bits = 0;
    if (st == NULL || out == NULL || vt_range_cfg_check(cfg) != VT_OK || !VT__IN(ttc_valid, 0, 1) ||
        !VT__IN(closing, 0, 1) || !VT__IN(lead_class, VT_LEAD_UNKNOWN, VT_LEAD_DECEL)) {
        return VT_E_ARG;
    }
    switch (lead_class) {
    case VT_LEAD_STOPPED:
        thr = cfg->ttc_stopped;
        break;
    case VT_LEAD_SLOWER:
        thr = cfg->ttc_slower;
        break;
    case VT_LEAD_DECEL:
        thr = cfg->ttc_decel;
        break;
    default: /* not knowing the lead's class must not make a warning late */
        thr = vt__max_i32(cfg->ttc_stopped, vt__max_i32(cfg->ttc_slower, cfg->ttc_decel));
        break;
    }
    thr += cfg->ttc_margin;
    cond = ttc_valid && closing && (int64_t)ttc <= thr;
    st->below = cond ? (st->below < INT32_MAX ? st->below + 1 : st->below) : 0;
    st->above = cond ? 0 : (st->above < INT32_MAX ? st->above + 1 : st->above);
    if (st->warning) {
        if (st->above >= cfg->release_frames) {
            st->warning = 0;
            st->since_end = 0;
        }
    } else {
        if (st->below >= cfg->confirm_frames) {
            if (st->since_end >= cfg->rearm_frames) {
                st->warning = 1;
                bits |= VT_FCW_ONSET;
                if (st->warnings < INT32_MAX) {
                    st->warnings += 1;
                }
            } else {
                bits |= VT_FCW_SUPPRESSED;
            }
        }
        if (!st->warning && st->since_end < INT32_MAX) {
            st->since_end += 1;
        }
    }
    if (st->warning) {
        bits |= VT_FCW_WARNING;
    }
    *out = bits;
    return VT_OK;
}

/* Start a slot's filter at distance d (Q16 m) with measurement std sig (Q16 m). */
static void vt__range_kf_start(vt_range_track *t, const vt_range_cfg *cfg, vt_q16 d, vt_q16 sig)
{
    /* Constant acceleration, x = [d, d', d''], F = [[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]];
     * the acceleration changes by a white step of std s = jerk dt per frame (filterpy
     * Q_discrete_white_noise, dim 3, var = s^2):
     *   Q = s^2 [[dt^4/4, dt^3/2, dt^2/2], [dt^3/2, dt^2, dt], [dt^2/2, dt, 1]].
     * s, u = s dt and w = s dt^2 go through Q24 (rounded half up) so that their products
     * (Q48, < 2^60 for jerk <= 50, dt <= 1) stay in int64; each entry is one product
     * rounded half up to Q32. */
    int64_t j = cfg->jerk_sigma, dt = cfg->frame_dt, dt32 = (int64_t)cfg->frame_dt * VT_Q16_ONE;
    int64_t s24 = vt__floor_shr64(j * dt + (1 << 7), 8);
    int64_t u24 = vt__floor_shr64(s24 * dt + (1 << 15), 16);
    int64_t w24 = vt__floor_shr64(u24 * dt + (1 << 15), 16);
    int64_t r = cfg->init_sigma_rate, a = cfg->init_sigma_accel;
    (void)vt_kf_init(&t->kf, 3, 1);
    t->kf.F[0][1] = dt32; /* Q16 s -> Q32 */
    t->kf.F[1][2] = dt32;
    t->kf.F[0][2] = vt__floor_shr64((int64_t)dt * dt + 1, 1); /* dt^2 / 2: Q32 */
    t->kf.H[0][0] = VT_Q32_ONE;
    t->kf.Q[0][0] = vt__floor_shr64(w24 * w24 + ((int64_t)1 << 17), 18);
    t->kf.Q[0][1] = vt__floor_shr64(u24 * w24 + ((int64_t)1 << 16), 17);
    t->kf.Q[0][2] = vt__floor_shr64(s24 * w24 + ((int64_t)1 << 16), 17);
    t->kf.Q[1][1] = vt__floor_shr64(u24 * u24 + ((int64_t)1 << 15), 16);
    t->kf.Q[1][2] = vt__floor_shr64(s24 * u24 + ((int64_t)1 << 15), 16);
    t->kf.Q[2][2] = vt__floor_shr64(s24 * s24 + ((int64_t)1 << 15), 16);
    t->kf.Q[1][0] = t->kf.Q[0][1];
    t->kf.Q[2][0] = t->kf.Q[0][2];
    t->kf.Q[2][1] = t->kf.Q[1][2];
    t->kf.P[0][0] = (int64_t)sig * sig;
    t->kf.P[1][1] = r * r;
    t->kf.P[2][2] = a * a;
    t->kf.R[0][0] = (int64_t)sig * sig;
    t->kf.x[0] = d;
    t->kf.x[1] = 0;
    t->kf.x[2] = 0;
}

static void vt__range_slot_open(vt_range_track *t, int32_t id)
{
    int32_t i;
    t->id = id;
    t->updates = 0;
    t->n_hist = 0;
    t->head = 0;
    for (i = 0; i < VT_RANGE_HIST; i++) {
        t->width_hist[i] = 0;
    }
    t->width_n = 0;
    t->width_m = 0;
    t->fcw.below = 0;
    t->fcw.above = 0;
    t->fcw.warning = 0;
    t->fcw.since_end = INT32_MAX; /* no warning yet: nothing to wait for */
    t->fcw.warnings = 0;
}

vt_status vt_range_init(vt_range_state *st)
{
    int32_t i;
    if (st == NULL) {
        return VT_E_ARG;
    }
    st->frame = 0;
    for (i = 0; i < VT_MAX_TRACKS; i++) {
        vt__range_slot_open(&st->t[i], 0);
        (void)vt_kf_init(&st->t[i].kf, 3, 1);
    }
    return VT_OK;
}

/* Ring entry `back` frames before the newest (0 = newest). */
static vt_q16 vt__ring(const vt_q16 *ring, int32_t head, int32_t back)
{
    return ring[(head - 1 - back + 2 * VT_RANGE_HIST) % VT_RANGE_HIST];
}

/* The box in the ego corridor at distance d (Q16 m): the lateral offsets of its
 * column edges, X = (u - cx) d / fx, against the corridor c - half < X < c + half
 * centred on the car, c = -cam->lateral; i.e. (left - cx) d < (c + half) fx and
 * (right + 1 - cx) d > (c - half) fx, in Q16 px x Q16 m. Boxes may lie anywhere in
 * int32, so the products are not formed: for integers a, L and d > 0,
 * a d < L <=> a <= floor((L - 1) / d) and a d > L <=> a >= floor(L / d) + 1, with
 * |L| <= 15 * 2^16 * 2^30 and |a| < 2^48. Not in the path without a distance
 * (d <= 0); always in it when the check is off. */
static int32_t vt__range_in_path(const vt_range_cfg *cfg, const vt_camera_cfg *cam,
                                 const vt_box *b, vt_q16 d)
{
    int64_t lr, ll, a, c;
    if (cfg->path_half_width == 0) {
        return 1;
    }
    if (d <= 0) {
        return 0;
    }
    lr = ((int64_t)cfg->path_half_width - cam->lateral) * cam->fx;
    ll = (-(int64_t)cfg->path_half_width - cam->lateral) * cam->fx;
    a = (int64_t)b->left * VT_Q16_ONE - cam->cx;
    c = ((int64_t)b->right + 1) * VT_Q16_ONE - cam->cx;
    return a <= vt__floor_div64(lr - 1, d) && c >= vt__floor_div64(ll, d) + 1;
}

vt_status vt_ttc_fuse(vt_q16 points, vt_q16 dist, int32_t weight_permille, vt_q16 *fused)
{
    if (fused == NULL || !VT__IN(weight_permille, 0, 1000)) {
        return VT_E_ARG;
    }
    if (points < 0) {
        *fused = dist < 0 ? -1 : dist;
    } else if (dist < 0) {
        *fused = points;
    } else {
        *fused = (vt_q16)(((int64_t)points * (1000 - weight_permille) +
                           (int64_t)dist * weight_permille + 500) / 1000);
    }
    return VT_OK;
}

/* One track's frame. pts: its block-scale TTC (negative: none), w the fusion weight
 * (checked by the caller): the warning's TTC is vt_ttc_fuse of it and the
 * distance/rate TTC, which is the latter alone without pts. */
static void vt__range_track_step(vt_range_track *t, const vt_range_cfg *cfg,
                                 const vt_camera_cfg *cam, vt_q16 tp, vt_q16 ego_speed,
                                 const vt_track_out *tr, vt_q16 pts, int32_t w, vt_range_out *o)
{
    vt_distance dist;
    vt_q16 sig, z[1], ttc, w_now, w_old, d, fcw_ttc = -1;
    vt_q32 r[1];
    int64_t q, wpx = (int64_t)tr->box.right - tr->box.left + 1;
    int32_t closing, lag = cfg->scale_lag, ttc_ok, cls, have, side_ok, n, in_path;
    (void)vt_camera_box_distance(cam, tp, &tr->box, &dist);
    side_ok = !(dist.flags & VT_DIST_SIDE_CLIPPED);
    o->id = tr->id;
    o->flags = 0;
    o->fcw = 0;
    o->dist_width = dist.dist_width;
    if (dist.flags & VT_DIST_WIDTH_AGREES) {
        o->flags |= VT_RANGE_WIDTH_AGREES;
    }
    have = 0;
    d = dist.distance;
    sig = dist.sigma;
    if (dist.flags & VT_DIST_VALID) {
        have = 1;
        d = d > cfg->rear_offset ? d - cfg->rear_offset : 0;
        if (side_ok) {
            /* learn this vehicle's width, d w / fx (m), as a running mean whose weight
             * 1/n stops falling at 1/width_window (w < img_w <= 32767 here, so
             * d w 2^16 < 2^58) */
            q = vt__div_or((int64_t)d * wpx * VT_Q16_ONE, cam->fx, 0) - t->width_m;
            n = t->width_n < cfg->width_window ? t->width_n + 1 : cfg->width_window;
            t->width_m = vt_sat_s32(t->width_m + vt__div_or(q, n, 0));
            t->width_n = t->width_n < INT32_MAX ? t->width_n + 1 : t->width_n;
        }
    } else if (t->width_n >= cfg->width_min_frames && side_ok) {
        /* the contact row is not seen (a near vehicle): its learnt width gives the
         * distance, d = fx W / w, with the spread of +-delta px on each side */
        have = 1;
        d = vt_sat_s32(vt__div_or((int64_t)cam->fx * t->width_m, wpx * VT_Q16_ONE, 0));
        sig = vt_sat_s32(vt__div_or((int64_t)d * 2 * cam->delta_px, wpx * VT_Q16_ONE, 0));
        o->flags |= VT_RANGE_FROM_WIDTH;
    }
    sig = sig > cfg->sigma_min ? sig : cfg->sigma_min;
    o->distance = d;
    o->sigma = sig;
    if (have) {
        o->flags |= VT_RANGE_DIST_VALID;
    }
    /* the filter: predict every frame, update when there is a distance */
    if (t->updates > 0) {
        (void)vt_kf_predict(&t->kf);
        if (have) {
            r[0] = (int64_t)sig * sig; /* eq. 6: R per measurement */
            z[0] = d;
            if (vt_kf_update_r(&t->kf, z, r) == VT_OK && t->updates < INT32_MAX) {
                t->updates += 1;
            }
        }
    } else if (have) {
        vt__range_kf_start(t, cfg, d, sig);
        t->updates = 1;
    }
    /* the rings: box width (px) and filtered rate */
    t->width_hist[t->head] = vt_sat_s32(wpx * VT_Q16_ONE);
    t->head = (t->head + 1) % VT_RANGE_HIST;
    if (t->n_hist < VT_RANGE_HIST) {
        t->n_hist += 1;
    }
    o->dist_filt = t->updates > 0 ? t->kf.x[0] : 0;
    o->rate = t->updates > 0 ? t->kf.x[1] : 0;
    o->accel = t->updates > 0 ? t->kf.x[2] : 0;
    o->ttc_dist = 0;
    o->ttc_scale = 0;
    if (t->updates > 0) {
        o->flags |= VT_RANGE_FILT_VALID;
    }
    closing = t->updates > 0 && o->rate < -cfg->min_closing;
    if (closing) {
        o->flags |= VT_RANGE_CLOSING;
    }
    /* TTC from the filtered distance and rate: d / -rate (Q16 / Q16 -> Q16 s) */
    ttc_ok = 0;
    if (t->updates >= cfg->min_frames && o->rate < 0 && o->dist_filt > 0) {
        /* compared in int64: a tiny rate gives a quotient past int32 */
        q = vt__div_or((int64_t)o->dist_filt * VT_Q16_ONE, -(int64_t)o->rate, (int64_t)INT32_MAX);
        if (q <= cfg->ttc_max) {
            ttc = (vt_q16)q;
            o->ttc_dist = ttc;
            o->flags |= VT_RANGE_TTC_DIST_VALID;
            ttc_ok = 1;
        }
    }
    /* TTC from the scale change over lag frames: w ~ 1/d, so for a constant closing
     * speed TTC = lag dt / (w_now / w_old - 1) = lag dt w_old / (w_now - w_old). */
    if (t->n_hist > lag) {
        w_now = vt__ring(t->width_hist, t->head, 0);
        w_old = vt__ring(t->width_hist, t->head, lag);
        if (w_now > w_old && w_old > 0) {
            q = vt__div_or((int64_t)lag * cfg->frame_dt * w_old, (int64_t)w_now - w_old,
                           (int64_t)INT32_MAX);
            if (q <= cfg->ttc_max) {
                o->ttc_scale = (vt_q16)q;
                o->flags |= VT_RANGE_TTC_SCALE_VALID;
            }
        }
    }
    /* the lead's class for the NHTSA threshold: its speed is ego + rate, its
     * acceleration the range acceleration (the ego speed taken as constant, as in the
     * test) */
    /* ... and only once the filter knows the rate to within the class boundary's own
     * scale, sqrt(P_rate) <= stopped_speed (Q32 against a Q16 square, exact): a young
     * track's rate is still on its way from 0, and a stopped lead read as "slower" got
     * the lower threshold and warned late (synthetic NHTSA seed 10, 2026-11-30). Until
     * then the class is unknown: the largest threshold, as without an ego speed. */
    cls = VT_LEAD_UNKNOWN;
    if (ego_speed >= 0 && t->updates > 0 &&
        t->kf.P[1][1] <= (int64_t)cfg->stopped_speed * cfg->stopped_speed) {
        if ((int64_t)ego_speed + o->rate < cfg->stopped_speed) {
            cls = VT_LEAD_STOPPED;
        } else if (t->updates > lag && o->accel < -cfg->decel_thresh) {
            cls = VT_LEAD_DECEL;
        } else {
            cls = VT_LEAD_SLOWER;
        }
    }
    o->lead_class = cls;
    in_path = vt__range_in_path(cfg, cam, &tr->box, t->updates > 0 ? o->dist_filt : 0);
    if (in_path) {
        o->flags |= VT_RANGE_IN_PATH;
    }
    /* a warning rests on a distance measured this frame: the filter's extrapolation alone
     * (a box cut by the frame's bottom and side, a vehicle being passed) does not count */
    (void)vt_ttc_fuse(pts, ttc_ok ? o->ttc_dist : -1, w, &fcw_ttc);
    (void)vt_fcw_step(&t->fcw, cfg, fcw_ttc >= 0 && in_path && have, fcw_ttc, closing, cls, &o->fcw);
}

vt_status vt_range_step(vt_range_state *st, const vt_range_cfg *cfg, const vt_camera_cfg *cam,
                        vt_q16 tp, vt_q16 ego_speed, const vt_track_out *tracks,
                        int32_t n_tracks, vt_range_out *out, int32_t out_cap, int32_t *n_out)
{
    return vt_range_step_fused(st, cfg, cam, tp, ego_speed, tracks, n_tracks, NULL, 0, out, out_cap,
                               n_out);
}

vt_status vt_range_step_fused(vt_range_state *st, const vt_range_cfg *cfg, const vt_camera_cfg *cam,
                              vt_q16 tp, vt_q16 ego_speed, const vt_track_out *tracks,
                              int32_t n_tracks, const vt_q16 *ttc_points, int32_t fuse_permille,
                              vt_range_out *out, int32_t out_cap, int32_t *n_out)
{
    int32_t i, k, written = 0, full = 0;
    vt_range_track *slot;
    if (st == NULL || n_out == NULL || vt_range_cfg_check(cfg) != VT_OK ||
        vt_camera_cfg_check(cam) != VT_OK || !VT__IN(tp, -VT_Q16_ONE, VT_Q16_ONE) ||
        n_tracks < 0 || (n_tracks > 0 && tracks == NULL) || out_cap < 0 ||
        (out_cap > 0 && out == NULL) || !VT__IN(fuse_permille, 0, 1000)) {
        return VT_E_ARG;
    }
    /* Check every input before touching the state. */
    if (vt_track_list_check(tracks, n_tracks) != VT_OK) {
        return VT_E_ARG;
    }
    *n_out = 0;
    /* free the slots of ids gone this frame */
    for (k = 0; k < VT_MAX_TRACKS; k++) {
        int32_t seen = 0;
        if (st->t[k].id == 0) {
            continue;
        }
        for (i = 0; i < n_tracks && !seen; i++) {
            seen = tracks[i].state != VT_TRACK_FREE && tracks[i].id == st->t[k].id;
        }
        if (!seen) {
            vt__range_slot_open(&st->t[k], 0);
        }
    }
    for (i = 0; i < n_tracks; i++) {
        vt_range_out tmp;
        if (tracks[i].state == VT_TRACK_FREE) {
            continue;
        }
        slot = NULL;
        for (k = 0; k < VT_MAX_TRACKS && slot == NULL; k++) {
            if (st->t[k].id == tracks[i].id) {
                slot = &st->t[k];
            }
        }
        for (k = 0; k < VT_MAX_TRACKS && slot == NULL; k++) {
            if (st->t[k].id == 0) {
                slot = &st->t[k];
                vt__range_slot_open(slot, tracks[i].id);
            }
        }
        if (slot == NULL) {
            full = 1;
            continue;
        }
        vt__range_track_step(slot, cfg, cam, tp, ego_speed, &tracks[i],
                             ttc_points != NULL ? ttc_points[i] : -1, fuse_permille, &tmp);
        if (written < out_cap) {
            out[written++] = tmp;
        } else {
            full = 1;
        }
    }
    st->frame = st->frame < INT32_MAX ? st->frame + 1 : st->frame;
    *n_out = written;
    return full ? VT_E_CAPACITY : VT_OK;
}
