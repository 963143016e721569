/* tracker.c -- multi-vehicle tracking (thesis ch. 3): Kalman prediction of the
 * bottom edge (sec. 3.5), ROI search by edge projections (sec. 3.6.1),
 * detection every N frames and the correlation check before a track is dropped
 * (sec. 3.6). The order of slots, matches and deletions is fully determined, so
 * pyvehtrack/reference/tracker.py can replay it step for step. */
#include "vehtrack/tracker.h"
#include <string.h>
#include "internal.h"

/* Detections accepted per frame; more is a caller error. */
#define VT__MAX_DETS 256

/* Counters saturate at INT32_MAX instead of wrapping (signed overflow is UB,
 * and a wrapped age or frame count would reorder the lifecycle). */
static int32_t vt__inc_sat(int32_t v)
{
    return v < INT32_MAX ? v + 1 : v;
}

/* Box from the filter state: corners rounded half up; height from the aspect. */
static void vt__box_from_state(vt_track *t)
{
    int32_t l = vt_q16_round(t->kf.x[0]);
    int32_t b = vt_q16_round(t->kf.x[1]);
    int32_t r = vt_q16_round(t->kf.x[2]);
    int32_t w, h;
    if (r < l) { /* the corners crossed: keep a one-pixel box at their middle */
        int32_t m = (int32_t)vt__floor_shr64((int64_t)l + r, 1);
        l = m;
        r = m;
    }
    w = r - l + 1;
    h = (int32_t)vt__floor_shr64((int64_t)w * t->aspect_q8 + 128, 8);
    h = h < 1 ? 1 : h;
    t->box.left = l;
    t->box.right = r;
    t->box.bottom = b;
    t->box.top = b - h + 1;
    t->vx = (vt_q16)vt__floor_shr64((int64_t)t->kf.x[3] + t->kf.x[5], 1);
    t->vy = t->kf.x[4];
}

/* Offsets of a T x T nearest-pixel resample of n px (a box side), sampling each cell's
 * centre: off[i] = floor((2i + 1) n / 2T); n >= 1. */
static void vt__sample_offsets(int32_t n, int32_t *off)
{
    int32_t i;
    for (i = 0; i < VT_TRACK_TEMPLATE; ++i) {
        off[i] = (int32_t)(((int64_t)(2 * i + 1) * n) / (2 * VT_TRACK_TEMPLATE));
    }
}

/* The T x T samples at (left + xo[j], top + yo[i]), each clamped into the image. */
static void vt__sample_at(const vt_image_u8 *img, int32_t left, int32_t top, const int32_t *xo,
                          const int32_t *yo, uint8_t *dst)
{
    int32_t i, j, xi[VT_TRACK_TEMPLATE];
    for (j = 0; j < VT_TRACK_TEMPLATE; ++j) {
        xi[j] = vt__clamp_i32(left + xo[j], 0, img->w - 1);
    }
    for (i = 0; i < VT_TRACK_TEMPLATE; ++i) {
        const uint8_t *row = img->px + (size_t)vt__clamp_i32(top + yo[i], 0, img->h - 1) *
                                           (size_t)img->stride;
        for (j = 0; j < VT_TRACK_TEMPLATE; ++j) {
            dst[i * VT_TRACK_TEMPLATE + j] = row[xi[j]];
        }
    }
}

/* Nearest-pixel resample of `box` (clamped into the image) to T x T, sampling
 * each cell's centre: y = top + floor((2i + 1) h / 2T). */
static void vt__sample(const vt_image_u8 *img, const vt_box *box, uint8_t *dst)
{
    int32_t xo[VT_TRACK_TEMPLATE], yo[VT_TRACK_TEMPLATE];
    vt__sample_offsets(box->right - box->left + 1, xo);
    vt__sample_offsets(box->bottom - box->top + 1, yo);
    vt__sample_at(img, box->left, box->top, xo, yo, dst);
}

/* The template and the box it was taken from (the template measurement keeps
 * that size, so a velocity error cannot shrink or grow the box through it). */
static void vt__set_tmpl(vt_track *t, const vt_image_u8 *img)
{
    vt__sample(img, &t->box, t->tmpl);
    t->tmpl_box = t->box;
}

/* IoU as a fraction inter / uni (both >= 0, uni > 0 for valid boxes). */
static void vt__iou(const vt_box *a, const vt_box *b, int64_t *inter, int64_t *uni)
{
    int64_t iw = (int64_t)(a->right < b->right ? a->right : b->right) -
                 (a->left > b->left ? a->left : b->left) + 1;
    int64_t ih = (int64_t)(a->bottom < b->bottom ? a->bottom : b->bottom) -
                 (a->top > b->top ? a->top : b->top) + 1;
    int64_t aa = ((int64_t)a->right - a->left + 1) * ((int64_t)a->bottom - a->top + 1);
    int64_t ab = ((int64_t)b->right - b->left + 1) * ((int64_t)b->bottom - b->top + 1);
    *inter = (iw > 0 && ih > 0) ? iw * ih : 0;
    *uni = aa + ab - *inter;
}

static int vt__box_ok(const vt_box *b)
{
    /* Generous bounds keep every later product inside int64. */
    const int32_t lim = 4 * (VT_MAX_WIDTH > VT_MAX_HEIGHT ? VT_MAX_WIDTH : VT_MAX_HEIGHT);
    return b->left <= b->right && b->top <= b->bottom && b->left >= -lim && b->right <= lim &&
           b->top >= -lim && b->bottom <= lim;
}

vt_status vt_tracker_cfg_check(const vt_tracker_cfg *c)
{
    if (c == NULL || vt_track_search_cfg_check(&c->search) != VT_OK ||
        vt_kf_model_cfg_check(&c->model) != VT_OK) {
        return VT_E_ARG;
    }
    if (c->roi_margin_min < 0 || c->roi_margin_min > VT_MAX_WIDTH || c->roi_margin_permille < 0 ||
        c->roi_margin_permille > 4000 || c->gate_permille < 0 || c->gate_permille > 4000 ||
        c->gate_bottom_permille < 0 || c->gate_bottom_permille > 4000 ||
        c->confirm_hits < 1 || c->confirm_hits > VT_TRACK_MAX_FRAMES_CFG || c->max_coast < 0 ||
        c->max_coast > VT_TRACK_MAX_FRAMES_CFG || c->match_iou_permille < 1 ||
        c->match_iou_permille > 1000 || c->keep_ncc < -VT_Q14_ONE || c->keep_ncc > VT_Q14_ONE ||
        c->init_max_change < 0 || c->init_max_change > VT_MAX_WIDTH) {
        return VT_E_ARG;
    }
    if ((c->measurement != VT_MEAS_ROI_SEARCH && c->measurement != VT_MEAS_EDGE_CURVES &&
         c->measurement != VT_MEAS_ROI_EDGES) ||
        vt_edge_cfg_check(&c->edge) != VT_OK) {
        return VT_E_ARG;
    }
    if (c->tmatch_radius < 0 || c->tmatch_radius > 64 || c->tmatch_ncc_permille < -1000 ||
        c->tmatch_ncc_permille > 1000 || c->tmatch_max < 0 ||
        c->tmatch_max > VT_TRACK_MAX_FRAMES_CFG || c->part_permille < 0 ||
        c->part_permille > 1000 || c->min_width < 0 || c->min_width > VT_MAX_WIDTH ||
        c->scale_tol_permille < 0 || c->scale_tol_permille > 1000 ||
        (c->snap_bottom != 0 && c->snap_bottom != 1) || c->birth_search < 0 ||
        c->birth_search > VT_TRACK_MAX_BIRTH_SEARCH || c->search_max_aspect_permille < 0 ||
        c->search_max_aspect_permille > VT_TRACK_MAX_ASPECT_PERMILLE) {
        return VT_E_ARG;
    }
    return VT_OK;
}

vt_status vt_tracker_init(vt_tracker *tr)
{
    if (tr == NULL) {
        return VT_E_ARG;
    }
    memset(tr, 0, sizeof(*tr));
    tr->next_id = 1;
    tr->edge_ws = NULL; /* memset need not make a null pointer */
    return VT_OK;
}

/* The stages that read a track list (range, block-scale TTC) check it here, once. */
vt_status vt_track_list_check(const vt_track_out *tracks, int32_t n_tracks)
{
    int32_t i, j;
    if (n_tracks < 0 || (n_tracks > 0 && tracks == NULL)) {
        return VT_E_ARG;
    }
    for (i = 0; i < n_tracks; i++) {
        const vt_track_out *a = &tracks[i];
        if (a->state == VT_TRACK_FREE) {
            continue;
        }
        if (a->id <= 0 || a->box.right < a->box.left || a->box.bottom < a->box.top) {
            return VT_E_ARG;
        }
        for (j = 0; j < i; j++) {
            if (tracks[j].state != VT_TRACK_FREE && tracks[j].id == a->id) {
                return VT_E_ARG;
            }
        }
    }
    return VT_OK;
}

vt_status vt_tracker_drop(vt_tracker *tr, int32_t id)
{
    int32_t i;
    if (tr == NULL || id <= 0) {
        return VT_E_ARG;
    }
    for (i = 0; i < VT_MAX_TRACKS; ++i) {
        if (tr->tracks[i].state != VT_TRACK_FREE && tr->tracks[i].id == id) {
            tr->tracks[i].state = VT_TRACK_FREE;
            return VT_OK;
        }
    }
    return VT_E_ARG;
}

vt_status vt_tracker_set_horizon(vt_tracker *tr, int32_t known, int32_t row)
{
    if (tr == NULL || (known && (row < -4 * VT_MAX_HEIGHT || row > 4 * VT_MAX_HEIGHT))) {
        return VT_E_ARG;
    }
    tr->horizon_known = known != 0;
    tr->horizon_y = known ? row : 0;
    return VT_OK;
}

/* scale_tol_permille's test (tracker.h) of a box with these sides and bottom row.
 * Coordinates are Kalman positions or checked boxes (|v| < 2^17), so every product
 * stays below 2^45. */
static int vt__scale_ok(const vt_tracker *tr, const vt_track *t, const vt_tracker_cfg *cfg,
                        int32_t left, int32_t bottom, int32_t right)
{
    int64_t r, b, w, d;
    if (cfg->scale_tol_permille == 0 || !tr->horizon_known || t->ref_w < 1) {
        return 1;
    }
    r = (int64_t)t->ref_b - tr->horizon_y;
    if (r < 1) {
        return 1; /* the reference at or above the horizon: no scale to keep */
    }
    b = (int64_t)bottom - tr->horizon_y;
    w = (int64_t)right - left + 1;
    d = w * r - (int64_t)t->ref_w * b;
    return (d < 0 ? -d : d) * 1000 <=
           (int64_t)cfg->scale_tol_permille * t->ref_w * (b > 0 ? b : 0) + 2000 * ((int64_t)t->ref_w + r);
}

vt_status vt_tracker_set_edge_ws(vt_tracker *tr, vt_edge_ws *ws)
{
    if (tr == NULL) {
        return VT_E_ARG;
    }
    tr->edge_ws = ws;
    return VT_OK;
}

vt_status vt_tracker_cfg_default(vt_tracker_cfg *cfg)
{
    static const vt_tracker_cfg def = VT_TRACKER_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

/* A successful measurement: lifecycle and template. */
static void vt__hit_keep_tmpl(vt_track *t, const vt_tracker_cfg *cfg)
{
    t->hits = vt__inc_sat(t->hits);
    t->misses = 0;
    t->tm_frames = 0;
    if (t->state == VT_TRACK_TENTATIVE && t->hits >= cfg->confirm_hits) {
        t->state = VT_TRACK_CONFIRMED;
    } else if (t->state == VT_TRACK_COASTING) {
        t->state = VT_TRACK_CONFIRMED;
    }
}

static void vt__hit(vt_track *t, const vt_tracker_cfg *cfg, const vt_image_u8 *img)
{
    vt__hit_keep_tmpl(t, cfg);
    vt__set_tmpl(t, img);
}

static vt_status vt__update(vt_track *t, int32_t left, int32_t bottom, int32_t right)
{
    vt_q16 z[3];
    vt_status s;
    z[0] = vt_q16_from_int(left);
    z[1] = vt_q16_from_int(bottom);
    z[2] = vt_q16_from_int(right);
    s = vt_kf_update(&t->kf, z);
    if (s == VT_OK) {
        vt__box_from_state(t);
    }
    return s;
}

/* The ROI margin of a track `w` px wide (as the verification step widens an edge). */
static int32_t vt__roi_margin(const vt_tracker_cfg *cfg, int32_t w)
{
    return vt__max_i32(cfg->roi_margin_min, (int32_t)((int64_t)w * cfg->roi_margin_permille / 1000));
}

/* VT_MEAS_EDGE_CURVES: the template is the curve points inside the track's box,
 * found in the box widened by the ROI margin `m` (so the box's own border is not
 * the crop's). A crop over capacity (or off the image) leaves no template, and
 * the track coasts until a detection gives a smaller box. */
static void vt__edge_refresh(vt_tracker *tr, vt_track *t, const vt_tracker_cfg *cfg,
                             const vt_image_u8 *img)
{
    int32_t m = vt__roi_margin(cfg, t->box.right - t->box.left + 1);
    vt_box roi;
    roi.left = t->box.left - m;
    roi.right = t->box.right + m;
    roi.top = t->box.top - m;
    roi.bottom = t->box.bottom + m;
    t->edges.n = 0;
    t->edges.box = t->box;
    if (vt_edge_map(tr->edge_ws, &cfg->edge, img, &roi) == VT_OK) {
        (void)vt_edge_template_set(tr->edge_ws, &t->box, &t->edges, NULL);
    }
}

/* VT_MEAS_EDGE_CURVES's measurement: the template's box moved by the best
 * displacement within +-radius of the prediction (the predicted box's left and
 * bottom against the template box's), in a crop widened by radius + m. */
static void vt__edge_measure(vt_tracker *tr, vt_track *t, const vt_tracker_cfg *cfg,
                             const vt_image_u8 *img, int32_t m, vt_box *meas, int32_t *found)
{
    const vt_box *tb = &t->edges.box;
    int32_t cx = t->box.left - tb->left, cy = t->box.bottom - tb->bottom;
    int32_t pad = cfg->edge.radius + m, dx, dy, sc, score, ax, grow;
    vt_box roi;
    *found = 0;
    if (t->edges.n == 0 || cx < -8192 || cx > 8192 || cy < -8192 || cy > 8192) {
        return;
    }
    /* The crop also holds the template grown by the largest scale. */
    grow = (int32_t)(((int64_t)(tb->right - tb->left + tb->bottom - tb->top + 2) *
                      cfg->edge.scale_steps * cfg->edge.scale_step_q8) / 256) + 1;
    roi.left = tb->left + cx - pad - grow;
    roi.right = tb->right + cx + pad + grow;
    roi.top = tb->top + cy - pad - grow;
    roi.bottom = tb->bottom + cy + pad;
    if (vt_edge_map(tr->edge_ws, &cfg->edge, img, &roi) != VT_OK ||
        vt_edge_match(tr->edge_ws, &cfg->edge, &t->edges, cx, cy, &dx, &dy, &sc, &score,
                      found) != VT_OK) {
        *found = 0;
        return;
    }
    /* The template box scaled about its bottom centre, as its points were. */
    ax = (int32_t)vt__floor_shr64((int64_t)tb->left + tb->right, 1);
    meas->left = ax + (int32_t)vt__floor_shr64((int64_t)(tb->left - ax) * sc + 128, 8) + dx;
    meas->right = ax + (int32_t)vt__floor_shr64((int64_t)(tb->right - ax) * sc + 128, 8) + dx;
    meas->top = tb->bottom + (int32_t)vt__floor_shr64((int64_t)(tb->top - tb->bottom) * sc + 128, 8) + dy;
    meas->bottom = tb->bottom + dy;
}

/* The ROI of the verification step around `box` (thesis sec. 3.6: "determined as
 * described in the hypothesis verification step"): the bottom edge widened by
 * the margin *m, half the edge length high; below it, as far as the bottom gate
 * *gate_b lets the edge move. *gate: how far a side may move. */
static void vt__search_roi(const vt_tracker_cfg *cfg, const vt_box *box, vt_box *roi, int32_t *m,
                           int32_t *gate, int32_t *gate_b)
{
    int32_t w = box->right - box->left + 1;
    *m = vt__roi_margin(cfg, w);
    *gate = vt__max_i32(8, (int32_t)((int64_t)w * cfg->gate_permille / 1000));
    *gate_b = vt__max_i32(4, (int32_t)((int64_t)w * cfg->gate_bottom_permille / 1000));
    roi->left = box->left - *m;
    roi->right = box->right + *m;
    roi->top = box->bottom - w / 2;
    roi->bottom = box->bottom + vt__max_i32(*m, *gate_b);
}

/* search_max_aspect_permille (tracker.h): a box flatter than a rear view, which
 * the ROI search does not measure. Checked boxes (|v| <= 4 * VT_MAX_*) keep both
 * products far inside int64. */
static int vt__flat(const vt_tracker_cfg *cfg, const vt_box *b)
{
    return cfg->search_max_aspect_permille > 0 && cfg->measurement != VT_MEAS_EDGE_CURVES &&
           ((int64_t)b->right - b->left + 1) * 1000 >
               (int64_t)cfg->search_max_aspect_permille * ((int64_t)b->bottom - b->top + 1);
}

/* snap_bottom (tracker.h): `d` with its bottom moved down to the row the ROI
 * search finds under it, searched as a track with the box `d` would search its next frame. */
static vt_box vt__snap(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                              const vt_box *d)
{
    vt_box out = *d, roi, meas;
    int32_t found = 0, m, gate, gate_b;
    if (!cfg->snap_bottom || vt__flat(cfg, d)) {
        return out;
    }
    vt__search_roi(cfg, d, &roi, &m, &gate, &gate_b);
    if (vt_track_search(&tr->ws, NULL, &cfg->search, img, &roi, &meas, &found) == VT_OK && found &&
        vt__abs_i32(meas.left - d->left) <= gate && vt__abs_i32(meas.right - d->right) <= gate &&
        meas.bottom > d->bottom && meas.bottom - d->bottom <= gate_b) {
        out.bottom = meas.bottom;
    }
    return out;
}

/* birth_search (tracker.h): the ROI search repeated on the birth frame from the
 * (snapped) detection `d` until it stops moving, at most birth_search times. */
static vt_box vt__birth_search(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                               const vt_box *d)
{
    vt_box out = *d, roi, meas;
    int32_t it, found, m, gate, gate_b;
    if (vt__flat(cfg, d)) {
        return out;
    }
    for (it = 0; it < cfg->birth_search; ++it) {
        found = 0;
        vt__search_roi(cfg, &out, &roi, &m, &gate, &gate_b);
        if (vt_track_search(&tr->ws, NULL, &cfg->search, img, &roi, &meas, &found) != VT_OK || !found ||
            vt__abs_i32(meas.left - out.left) > gate || vt__abs_i32(meas.right - out.right) > gate ||
            vt__abs_i32(meas.bottom - out.bottom) > gate_b || meas.right <= meas.left ||
            meas.bottom <= out.top) {
            break;
        }
        if (meas.left == out.left && meas.right == out.right && meas.bottom == out.bottom) {
            break;
        }
        out.left = meas.left;
        out.right = meas.right;
        out.bottom = meas.bottom;
    }
    return out;
}

static void vt__start(vt_tracker *tr, vt_track *t, const vt_tracker_cfg *cfg,
                      const vt_image_u8 *img, const vt_box *d_in)
{
    const vt_box snapped = vt__snap(tr, cfg, img, d_in);
    const vt_box born = vt__birth_search(tr, cfg, img, &snapped), *d = &born;
    int32_t w = d->right - d->left + 1, h = d->bottom - d->top + 1;
    memset(t, 0, sizeof(*t));
    if (vt_kf_init_bottom_edge(&t->kf, &cfg->model, vt_q16_from_int(d->left),
                               vt_q16_from_int(d->bottom), vt_q16_from_int(d->right)) != VT_OK) {
        return; /* cannot happen: the model was validated; leave the slot free */
    }
    t->id = tr->next_id; /* < INT32_MAX: the caller checked */
    tr->next_id += 1;
    t->state = cfg->confirm_hits <= 1 ? VT_TRACK_CONFIRMED : VT_TRACK_TENTATIVE;
    t->hits = 1;
    t->aspect_q8 = (int32_t)(((int64_t)h * 256 + w / 2) / w);
    t->ref_w = w;
    t->ref_b = d->bottom;
    t->tm_only = 1;
    t->sides.have_prev = 1;
    t->sides.prev_left = d->left;
    t->sides.prev_right = d->right;
    t->sides.max_change_left = cfg->init_max_change;
    t->sides.max_change_right = cfg->init_max_change;
    vt__box_from_state(t);
    vt__set_tmpl(t, img);
    if (cfg->measurement != VT_MEAS_ROI_SEARCH) {
        vt__edge_refresh(tr, t, cfg, img);
    }
}

/* Inclusive area of a valid box (vt__box_ok bounds keep it inside int64). */
static int64_t vt__area(const vt_box *b)
{
    return ((int64_t)b->right - b->left + 1) * ((int64_t)b->bottom - b->top + 1);
}

/* `inner` has at least part_permille of its area inside `outer`. */
static int vt__mostly_inside(const vt_box *inner, const vt_box *outer, int32_t part_permille)
{
    int64_t in, un;
    vt__iou(inner, outer, &in, &un);
    return in * 1000 >= (int64_t)part_permille * vt__area(inner);
}

/* Template measurement: the template's box, its bottom centre moved onto the
 * predicted one (centres floor((l + r) / 2)), then shifted by the dx, dy in
 * -tmatch_radius..tmatch_radius (row-major, dy outer) whose 16x16 resample
 * correlates best with the track's template; the first of equal Q14 scores wins.
 * Accepted if score * 1000 >= tmatch_ncc_permille * 2^14 (exact integers). A
 * flat patch (vt_ncc_u8's VT_E_SINGULAR) is no candidate. Cost: (2r+1)^2
 * resamples and correlations of 256 pixels. */
static int vt__tmatch(const vt_track *t, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                      vt_box *meas)
{
    int32_t dx, dy, i, r = cfg->tmatch_radius, have = 0;
    int32_t xo[VT_TRACK_TEMPLATE], yo[VT_TRACK_TEMPLATE];
    uint8_t now[VT_TRACK_TEMPLATE * VT_TRACK_TEMPLATE];
    uint32_t sa = 0, saa = 0;
    vt__ncc_norm na, nb;
    const uint64_t n = (uint64_t)VT_TRACK_TEMPLATE * VT_TRACK_TEMPLATE;
    /* Both boxes pass vt__box_ok or come from the bounded filter: no overflow. */
    int32_t ox = (int32_t)(vt__floor_shr64((int64_t)t->box.left + t->box.right, 1) -
                           vt__floor_shr64((int64_t)t->tmpl_box.left + t->tmpl_box.right, 1));
    int32_t oy = t->box.bottom - t->tmpl_box.bottom;
    vt_q14 best = 0;
    /* Every candidate has the template box's size: one set of sample offsets, and the
     * template's own sums once (vt_ncc_u8's arithmetic, the same bits). */
    vt__sample_offsets(t->tmpl_box.right - t->tmpl_box.left + 1, xo);
    vt__sample_offsets(t->tmpl_box.bottom - t->tmpl_box.top + 1, yo);
    for (i = 0; i < VT_TRACK_TEMPLATE * VT_TRACK_TEMPLATE; ++i) {
        uint32_t u = t->tmpl[i];
        sa += u;
        saa += u * u;
    }
    if (!vt__ncc_norm_of(n, sa, saa, &na)) {
        return 0;   /* a flat template correlates with nothing (vt_ncc_u8: singular) */
    }
    for (dy = -r; dy <= r; ++dy) {
        for (dx = -r; dx <= r; ++dx) {
            vt_box sh;
            vt_q14 q = 0;
            /* 256 pixels: sums below 256 * 255^2 < 2^24 */
            uint32_t sb = 0, sbb = 0, sab = 0;
            sh.left = t->tmpl_box.left + ox + dx;
            sh.right = t->tmpl_box.right + ox + dx;
            sh.top = t->tmpl_box.top + oy + dy;
            sh.bottom = t->tmpl_box.bottom + oy + dy;
            vt__sample_at(img, sh.left, sh.top, xo, yo, now);
            for (i = 0; i < VT_TRACK_TEMPLATE * VT_TRACK_TEMPLATE; ++i) {
                uint32_t v = now[i];
                sb += v;
                sbb += v * v;
                sab += (uint32_t)t->tmpl[i] * v;
            }
            if (!vt__ncc_norm_of(n, sb, sbb, &nb) || vt__ncc_from_norms(n, sa, sb, sab, &na, &nb, &q) != VT_OK) {
                continue;   /* a flat patch is no candidate */
            }
            if (!have || q > best) {
                have = 1;
                best = q;
                *meas = sh;
            }
        }
    }
    return have && (int64_t)best * 1000 >= (int64_t)cfg->tmatch_ncc_permille * VT_Q14_ONE;
}

/* Every argument of vt_tracker_step, before anything is touched. */
static vt_status vt__step_args(const vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                               int32_t detection_frame, const vt_box *dets, int32_t n_dets,
                               const vt_track_out *out, int32_t out_cap, const int32_t *n_out)
{
    int32_t j;
    vt_status s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    if (tr == NULL || cfg == NULL || n_out == NULL || (out == NULL && out_cap != 0) ||
        out_cap < 0 || tr->next_id < 1) {
        return VT_E_ARG;
    }
    if (detection_frame) {
        if (n_dets < 0 || n_dets > VT__MAX_DETS) {
            return VT_E_SIZE;
        }
        if (n_dets > 0 && dets == NULL) {
            return VT_E_ARG;
        }
        for (j = 0; j < n_dets; ++j) {
            if (!vt__box_ok(&dets[j])) {
                return VT_E_ARG;
            }
        }
    }
    s = vt_tracker_cfg_check(cfg);
    if (s != VT_OK) {
        return s;
    }
    if (cfg->measurement != VT_MEAS_ROI_SEARCH && tr->edge_ws == NULL) {
        return VT_E_ARG; /* the edge measurement needs its workspace (vt_tracker_set_edge_ws) */
    }
    return VT_OK;
}

/* A frame's measurement is taken when found, within the side and bottom gates of
 * the predicted box and on the road's scale (vt__scale_ok). */
static int vt__meas_ok(const vt_tracker *tr, const vt_track *t, const vt_tracker_cfg *cfg, int32_t found,
                       const vt_box *meas, int32_t gate, int32_t gate_b)
{
    return found && vt__abs_i32(meas->left - t->box.left) <= gate &&
           vt__abs_i32(meas->right - t->box.right) <= gate &&
           vt__abs_i32(meas->bottom - t->box.bottom) <= gate_b &&
           vt__scale_ok(tr, t, cfg, meas->left, meas->bottom, meas->right);
}

/* Phase 1, one live track: predict, search the ROI, update or coast. Returns 1
 * if the track was measured. */
static int vt__predict_measure(vt_tracker *tr, vt_track *t, const vt_tracker_cfg *cfg,
                               const vt_image_u8 *img)
{
    vt_box roi, meas;
    vt_track_sides sides;
    int32_t found = 0, m, gate, gate_b, flat, ok, by_edges = 0;
    vt_status s;
    t->age = vt__inc_sat(t->age);
    if (vt_kf_predict(&t->kf) != VT_OK) {
        t->state = VT_TRACK_FREE;
        return 0;
    }
    vt__box_from_state(t);
    vt__search_roi(cfg, &t->box, &roi, &m, &gate, &gate_b);
    sides = t->sides;
    flat = vt__flat(cfg, &t->box); /* 0 with edge curves */
    if (cfg->measurement == VT_MEAS_EDGE_CURVES) {
        vt__edge_measure(tr, t, cfg, img, m, &meas, &found);
        s = VT_OK;
    } else if (flat) {
        s = VT_OK; /* not a rear view: only the template below measures it */
    } else {
        s = vt_track_search(&tr->ws, &sides, &cfg->search, img, &roi, &meas, &found);
    }
    ok = s == VT_OK && vt__meas_ok(tr, t, cfg, found, &meas, gate, gate_b);
    if (!ok && cfg->measurement == VT_MEAS_ROI_EDGES && !flat && !t->tm_only &&
        (t->state == VT_TRACK_CONFIRMED || t->state == VT_TRACK_COASTING)) {
        /* the search failed on a rear view it measured before: its edge curves */
        vt__edge_measure(tr, t, cfg, img, m, &meas, &found);
        sides = t->sides; /* the failed search's side memory is not kept */
        ok = vt__meas_ok(tr, t, cfg, found, &meas, gate, gate_b);
        by_edges = ok;
    }
    if (ok && vt__update(t, meas.left, meas.bottom, meas.right) == VT_OK) {
        t->sides = sides;
        t->tm_only = 0;
        if (by_edges) {
            /* the template stays the rear the search or a detection last saw: the
             * correlation check of the next detection frame then asks whether that
             * vehicle is still in the box, not whatever edges the curves followed
             * (an occluder's side, while the vehicle is hidden behind it) */
            vt__hit_keep_tmpl(t, cfg);
        } else {
            vt__hit(t, cfg, img);
        }
        if (cfg->measurement != VT_MEAS_ROI_SEARCH) {
            vt__edge_refresh(tr, t, cfg, img);
        }
        return 1;
    }
    /* A tentative track's template keeps its filter on the vehicle; no hit (only
     * real measurements confirm) and no miss (the lifecycle waits for a detection).
     * Confirmed tracks coast as in the thesis (tracker.h says why), but for those the
     * measurement never took (tm_only) or does not measure (flat). */
    if (cfg->tmatch_radius > 0 &&
        (t->state == VT_TRACK_TENTATIVE || (t->state == VT_TRACK_CONFIRMED && (t->tm_only || flat))) &&
        t->tm_frames < INT32_MAX &&
        vt__tmatch(t, cfg, img, &meas) && vt__scale_ok(tr, t, cfg, meas.left, meas.bottom, meas.right) &&
        vt__update(t, meas.left, meas.bottom, meas.right) == VT_OK) {
        t->tm_frames += 1;
        return 0;
    }
    t->misses = vt__inc_sat(t->misses);
    if (t->state == VT_TRACK_CONFIRMED) {
        t->state = VT_TRACK_COASTING;
    }
    return 0;
}


/* After a track's filter was reset onto a detection: the frame's hit (once per
 * track and frame) or, if it already had one, a fresh template; and the edge
 * curves when that measurement runs. */
static void vt__after_reset(vt_tracker *tr, vt_track *t, const vt_tracker_cfg *cfg,
                            const vt_image_u8 *img, uint8_t *measured)
{
    if (!*measured) {
        *measured = 1;
        vt__hit(t, cfg, img);
    } else {
        vt__set_tmpl(t, img);
    }
    if (cfg->measurement != VT_MEAS_ROI_SEARCH) {
        vt__edge_refresh(tr, t, cfg, img);
    }
}
/* Phase 2a, a matched pair: the detection is a second, independent measurement
 * of the same bottom edge: it pulls back a search that drifted, and re-anchors
 * the aspect ratio and the side memory. */
static void vt__absorb_detection(vt_tracker *tr, vt_track *t, const vt_tracker_cfg *cfg,
                                 const vt_image_u8 *img, const vt_box *d_in, uint8_t *measured)
{
    const vt_box snapped = vt__snap(tr, cfg, img, d_in), *d = &snapped;
    int32_t dw = d->right - d->left + 1;
    if (vt__update(t, d->left, d->bottom, d->right) != VT_OK) {
        return;
    }
    t->aspect_q8 = (int32_t)(((int64_t)(d->bottom - d->top + 1) * 256 + dw / 2) / dw);
    vt__box_from_state(t);
    /* the filtered box, not the detection: one partial detection (a car half hidden
     * in a lane change) must not become the scale every later measurement is held to */
    t->ref_w = t->box.right - t->box.left + 1;
    t->ref_b = t->box.bottom;
    t->sides.prev_left = d->left;
    t->sides.prev_right = d->right;
    vt__after_reset(tr, t, cfg, img, measured);
}

/* A part-track (a wheel, a window band, half a car) re-anchored to the whole
 * detection: the filter restarts on the detection's bottom edge (a Kalman update
 * would only drag it halfway); id, hits and state are kept. */
static void vt__reanchor(vt_tracker *tr, vt_track *t, const vt_tracker_cfg *cfg,
                         const vt_image_u8 *img, const vt_box *d_in, uint8_t *measured)
{
    const vt_box snapped = vt__snap(tr, cfg, img, d_in), *d = &snapped;
    int32_t w = d->right - d->left + 1;
    if (vt_kf_init_bottom_edge(&t->kf, &cfg->model, vt_q16_from_int(d->left),
                               vt_q16_from_int(d->bottom), vt_q16_from_int(d->right)) != VT_OK) {
        return; /* cannot happen: the model was validated */
    }
    t->aspect_q8 = (int32_t)(((int64_t)(d->bottom - d->top + 1) * 256 + w / 2) / w);
    t->ref_w = w;
    t->ref_b = d->bottom;
    t->sides.have_prev = 1;
    t->sides.prev_left = d->left;
    t->sides.prev_right = d->right;
    t->sides.max_change_left = cfg->init_max_change;
    t->sides.max_change_right = cfg->init_max_change;
    vt__box_from_state(t);
    vt__after_reset(tr, t, cfg, img, measured);
}

/* After the IoU matching: each unmatched live track (slot order) takes the
 * first unmatched detection, larger than it, that holds part_permille of it. */
static void vt__reanchor_parts(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                               const vt_box *dets, int32_t n_dets, uint8_t *measured,
                               uint8_t *track_matched, int16_t *match_of_det)
{
    int32_t i, j;
    for (i = 0; i < VT_MAX_TRACKS; ++i) {
        vt_track *t = &tr->tracks[i];
        if (t->state == VT_TRACK_FREE || track_matched[i]) {
            continue;
        }
        for (j = 0; j < n_dets; ++j) {
            if (match_of_det[j] < 0 && vt__area(&dets[j]) > vt__area(&t->box) &&
                vt__mostly_inside(&t->box, &dets[j], cfg->part_permille)) {
                track_matched[i] = 1;
                match_of_det[j] = (int16_t)i;
                vt__reanchor(tr, t, cfg, img, &dets[j], &measured[i]);
                break;
            }
        }
    }
}

/* Phase 2a: greedy association by IoU, best pair first; match_of_det[j] is the
 * slot detection j went to, or -1. */
static void vt__associate(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                          const vt_box *dets, int32_t n_dets, uint8_t *measured,
                          uint8_t *track_matched, int16_t *match_of_det)
{
    int32_t i, j;
    for (j = 0; j < n_dets; ++j) {
        match_of_det[j] = -1;
    }
    for (;;) {
        int32_t bi = -1, bj = -1;
        int64_t bin = 0, bun = 1;
        for (i = 0; i < VT_MAX_TRACKS; ++i) {
            if (tr->tracks[i].state == VT_TRACK_FREE || track_matched[i]) {
                continue;
            }
            for (j = 0; j < n_dets; ++j) {
                int64_t in, un;
                if (match_of_det[j] >= 0) {
                    continue;
                }
                vt__iou(&tr->tracks[i].box, &dets[j], &in, &un);
                /* IoU >= threshold, and strictly better than the best so far
                 * (so the first of equal pairs, in slot then detection order, wins). */
                if (in * 1000 >= (int64_t)cfg->match_iou_permille * un && in * bun > bin * un) {
                    bi = i;
                    bj = j;
                    bin = in;
                    bun = un;
                }
            }
        }
        if (bi < 0) {
            break;
        }
        track_matched[bi] = 1;
        match_of_det[bj] = (int16_t)bi;
        vt__absorb_detection(tr, &tr->tracks[bi], cfg, img, &dets[bj], &measured[bi]);
    }
    if (cfg->part_permille > 0) {
        vt__reanchor_parts(tr, cfg, img, dets, n_dets, measured, track_matched, match_of_det);
    }
}

/* Phase 2b: tracks the detector no longer sees are kept only if the last
 * template still correlates with the same place in this frame. */
static void vt__drop_uncorrelated(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                                  const uint8_t *track_matched)
{
    int32_t i;
    for (i = 0; i < VT_MAX_TRACKS; ++i) {
        vt_track *t = &tr->tracks[i];
        uint8_t now[VT_TRACK_TEMPLATE * VT_TRACK_TEMPLATE];
        vt_image_u8 a, b;
        vt_q14 r = 0;
        if (t->state == VT_TRACK_FREE || track_matched[i]) {
            continue;
        }
        vt__sample(img, &t->box, now);
        a.px = t->tmpl;
        b.px = now;
        a.w = b.w = a.h = b.h = a.stride = b.stride = VT_TRACK_TEMPLATE;
        if (vt_ncc_u8(&a, &b, &r) != VT_OK || r < cfg->keep_ncc) {
            t->state = VT_TRACK_FREE;
        }
    }
}

/* Phase 2c: an unmatched detection that overlaps no live track starts one in
 * the first free slot. */
static void vt__births(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                       const vt_box *dets, int32_t n_dets, const int16_t *match_of_det)
{
    int32_t i, j;
    for (j = 0; j < n_dets; ++j) {
        int overlaps = 0;
        if (match_of_det[j] >= 0) {
            continue;
        }
        for (i = 0; i < VT_MAX_TRACKS && !overlaps; ++i) {
            int64_t in, un;
            if (tr->tracks[i].state == VT_TRACK_FREE) {
                continue;
            }
            vt__iou(&tr->tracks[i].box, &dets[j], &in, &un);
            overlaps = in * 10 >= un || /* IoU >= 10 %: the same vehicle, not a new one */
                       (cfg->part_permille > 0 && in * 1000 >= (int64_t)cfg->part_permille * vt__area(&dets[j]));
        }
        if (dets[j].right - dets[j].left + 1 < cfg->min_width) {
            continue; /* it would be dropped as degenerate at once */
        }
        if (overlaps) {
            continue;
        }
        for (i = 0; i < VT_MAX_TRACKS && tr->tracks[i].state != VT_TRACK_FREE; ++i) {
        }
        if (i == VT_MAX_TRACKS || tr->next_id == INT32_MAX) {
            /* Every slot used, or every id given out: ids are never reused. */
            tr->dropped_full = vt__inc_sat(tr->dropped_full);
            continue;
        }
        vt__start(tr, &tr->tracks[i], cfg, img, &dets[j]);
    }
}

/* A live track mostly inside a larger live track (equal areas: the later slot)
 * is a part of it: dropped, slot order (a dropped track holds no other). */
static void vt__drop_parts(vt_tracker *tr, const vt_tracker_cfg *cfg)
{
    int32_t i, k;
    for (i = 0; i < VT_MAX_TRACKS; ++i) {
        vt_track *t = &tr->tracks[i];
        if (t->state == VT_TRACK_FREE) {
            continue;
        }
        for (k = 0; k < VT_MAX_TRACKS; ++k) {
            const vt_track *o = &tr->tracks[k];
            int64_t ao, at;
            if (k == i || o->state == VT_TRACK_FREE) {
                continue;
            }
            ao = vt__area(&o->box);
            at = vt__area(&t->box);
            if ((ao > at || (ao == at && k < i)) && vt__mostly_inside(&t->box, &o->box, cfg->part_permille)) {
                t->state = VT_TRACK_FREE;
                break;
            }
        }
    }
}

/* Phase 3, lifecycle: drop tracks that coasted too long or left the frame. */
static void vt__expire(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img)
{
    int32_t i;
    for (i = 0; i < VT_MAX_TRACKS; ++i) {
        vt_track *t = &tr->tracks[i];
        if (t->state == VT_TRACK_FREE) {
            continue;
        }
        if (t->misses > cfg->max_coast || (t->state == VT_TRACK_TENTATIVE && t->misses >= 2) ||
            t->box.right < 0 || t->box.left >= img->w || t->box.bottom < 0 ||
            t->box.top >= img->h || t->tm_frames > cfg->tmatch_max ||
            t->box.right - t->box.left + 1 < cfg->min_width ||
            ((t->misses > 0 || t->tm_frames > 0) &&
             !vt__scale_ok(tr, t, cfg, t->box.left, t->box.bottom, t->box.right))) {
            t->state = VT_TRACK_FREE;
        }
    }
    if (cfg->part_permille > 0) {
        vt__drop_parts(tr, cfg);
    }
}

/* Phase 4: the live tracks in slot order, at most out_cap of them. */
static vt_status vt__report(const vt_tracker *tr, vt_track_out *out, int32_t out_cap, int32_t *n_out)
{
    int32_t i, n = 0;
    for (i = 0; i < VT_MAX_TRACKS; ++i) {
        const vt_track *t = &tr->tracks[i];
        if (t->state == VT_TRACK_FREE) {
            continue;
        }
        if (n < out_cap) {
            out[n].id = t->id;
            out[n].state = t->state;
            out[n].box = t->box;
            out[n].vx = t->vx;
            out[n].vy = t->vy;
        }
        ++n;
    }
    *n_out = n < out_cap ? n : out_cap;
    return n > out_cap ? VT_E_CAPACITY : VT_OK;
}

vt_status vt_tracker_step(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                          int32_t detection_frame, const vt_box *dets, int32_t n_dets,
                          vt_track_out *out, int32_t out_cap, int32_t *n_out)
{
    int32_t i;
    uint8_t measured[VT_MAX_TRACKS];
    uint8_t track_matched[VT_MAX_TRACKS];
    int16_t match_of_det[VT__MAX_DETS];
    vt_status s = vt__step_args(tr, cfg, img, detection_frame, dets, n_dets, out, out_cap, n_out);
    if (s != VT_OK) {
        return s;
    }
    tr->frame = vt__inc_sat(tr->frame);
    for (i = 0; i < VT_MAX_TRACKS; ++i) {
        track_matched[i] = 0;
        measured[i] = (uint8_t)(tr->tracks[i].state != VT_TRACK_FREE &&
                                vt__predict_measure(tr, &tr->tracks[i], cfg, img));
    }
    if (detection_frame) {
        vt__associate(tr, cfg, img, dets, n_dets, measured, track_matched, match_of_det);
        vt__drop_uncorrelated(tr, cfg, img, track_matched);
        vt__births(tr, cfg, img, dets, n_dets, match_of_det);
    }
    vt__expire(tr, cfg, img);
    return vt__report(tr, out, out_cap, n_out);
}
