/* pipeline.c -- the per-frame order of the whole system (thesis fig. 4.1 for
 * detection, ch. 3 for tracking): lanes and the road area (sec. 2.4.1), shadow
 * hypotheses and their verification (sec. 2.4.2) -- or, with a classifier, the
 * whole-road detector (IVVI paper sec. 4/5 windows, GIST paper sec. III
 * classifier, c/fulldet.c; or the ACF stage, c/acf.c, or the CNN, c/cnn.c, in place of
 * its windows) -- every detect_every frames, the
 * tracker on every frame (sec. 3.5-3.6), and with a camera the distance, TTC and
 * warning per track (IVVI paper sec. 4, c/camera.c), and the block-scale TTC per track
 * (IVVI paper sec. 4's scale-change TTC, c/ttc_scale.c). It only composes the stages through
 * their public functions; the firmware, the bench driver and Python all call
 * vt_pipeline_step, so the order is written once. With the flow stage on, vehicles
 * the ego car overtakes are handed from the tracker to the flow stage as they leave
 * by the side (IVVI paper sec. 3, last paragraph: the reverse case; vt__handover). */
#include "vehtrack/pipeline.h"
#include <stddef.h>
#include <string.h>
#include "internal.h"

vt_status vt_pipeline_cfg_default(vt_pipeline_cfg *cfg)
{
    static const vt_pipeline_cfg def = VT_PIPELINE_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_fixed_road_check(const vt_fixed_road *fr)
{
    if (fr == NULL) {
        return VT_E_ARG;
    }
    if (fr->vp_x_permille < 0 || fr->vp_x_permille > 1000 || fr->vp_y_permille < 0 ||
        fr->vp_y_permille > 1000 || fr->bottom_left_permille < 0 ||
        fr->bottom_left_permille > 1000 || fr->bottom_right_permille < 0 ||
        fr->bottom_right_permille > 1000 ||
        fr->bottom_left_permille > fr->bottom_right_permille || fr->lane_bottom_permille < 0 ||
        fr->lane_bottom_permille > 1000 || fr->top_margin < 0 || fr->top_margin > 4096) {
        return VT_E_ARG;
    }
    return VT_OK;
}

vt_status vt_road_camera_check(const vt_road_camera *rc)
{
    if (rc == NULL) {
        return VT_E_ARG;
    }
    if (rc->horizon_q16 < -65536 || rc->horizon_q16 > 65536 || rc->hood_q16 < 3277 ||
        rc->hood_q16 > 131072 || rc->height_mm < 100 || rc->height_mm > 20000 ||
        rc->fx_per_w_q16 < 3277 || rc->fx_per_w_q16 > 1310720) {
        return VT_E_ARG;
    }
    return VT_OK;
}

/* The whole-road detector's configuration as the pipeline runs it: its own
 * `sources` replaced by the pipeline's bits (0 when neither is on). */
static void vt__fulldet_cfg(const vt_pipeline_cfg *cfg, vt_fulldet_cfg *fc)
{
    *fc = cfg->fulldet;
    fc->sources = ((cfg->sources & VT_SRC_SHADOW) ? VT_FULLDET_SHADOW : 0) |
                  ((cfg->sources & VT_SRC_CLASSIFIER) ? VT_FULLDET_WINDOWS : 0);
}

vt_status vt_pipeline_cfg_check(const vt_pipeline_cfg *cfg)
{
    vt_fulldet_cfg fc;
    vt_status s;
    if (cfg == NULL) {
        return VT_E_ARG;
    }
    if (cfg->detect_every < 1 || cfg->road_policy < VT_ROAD_AUTO ||
        cfg->road_policy > VT_ROAD_FIXED || (cfg->lanes_every_frame != 0 && cfg->lanes_every_frame != 1) ||
        (cfg->track != 0 && cfg->track != 1) || (cfg->sources & ~VT_SRC_BUILT) != 0) {
        return VT_E_ARG;
    }
    s = vt_fixed_road_check(&cfg->fixed_road);
    if (s == VT_OK && cfg->road_policy != VT_ROAD_FIXED) {
        s = vt_lane_cfg_check(&cfg->lane);
    }
    if (s == VT_OK) {
        s = vt_shadow_cfg_check(&cfg->detect.shadow);
    }
    if (s == VT_OK) {
        s = vt_verify_cfg_check(&cfg->detect.verify);
    }
    if (s == VT_OK) {
        s = vt_tracker_cfg_check(&cfg->tracker);
    }
    if (s == VT_OK) {
        /* Checked whatever the sources, with both of its sources on, so that a
         * classifier attached later never meets a bad configuration. */
        vt__fulldet_cfg(cfg, &fc);
        fc.sources = VT_FULLDET_SHADOW | VT_FULLDET_WINDOWS;
        s = vt_fulldet_cfg_check(&fc);
    }
    if (s == VT_OK) {
        s = vt_road_camera_check(&cfg->road_camera);
    }
    if (s == VT_OK) {
        s = vt_flow_cfg_check(&cfg->flow);
    }
    if (s == VT_OK) {
        s = vt_model_cfg_check(&cfg->model);
    }
    if (s == VT_OK) {
        s = vt_ttc_cfg_check(&cfg->ttc);
    }
    if (s == VT_OK && (cfg->model_fits < 0 || cfg->model_fits > VT_MAX_TRACKS ||
                       cfg->model_min_fitness < 0 || cfg->verify < 0 || cfg->verify > 4)) {
        s = VT_E_ARG;
    }
    if (s == VT_OK && ((cfg->handover != 0 && cfg->handover != 1) || cfg->handover_frames < 2 ||
                       cfg->handover_frames > VT_PIPE_HO_HIST - 1 || cfg->handover_dy_permille < 0 ||
                       cfg->handover_dy_permille > 1000 || cfg->handover_edge_permille < 0 ||
                       cfg->handover_edge_permille > 500)) {
        s = VT_E_ARG;
    }
    if (s == VT_OK && (cfg->ttc_fuse_permille < 0 || cfg->ttc_fuse_permille > 1000 ||
                       (cfg->road_above_hood != 0 && cfg->road_above_hood != 1) ||
                       (cfg->auto_hood != 0 && cfg->auto_hood != 1) ||
                       (cfg->fcw_fused != 0 && cfg->fcw_fused != 1) ||
                       cfg->cnn_hood_min_width_mm < 0 || cfg->cnn_hood_min_width_mm > 10000 ||
                       cfg->cnn_ego_iou_permille < 0 || cfg->cnn_ego_iou_permille > 1000 ||
                       (cfg->cnn_track_top != 0 && cfg->cnn_track_top != 1))) {
        s = VT_E_ARG;
    }
    if (s == VT_OK) {
        s = vt_hood_cfg_check(&cfg->hood);
    }
    return s;
}

vt_status vt_pipeline_init(vt_pipeline *p, const vt_pipeline_cfg *cfg,
                           const vt_camera_cfg *camera, const vt_svm_model *model)
{
    vt_status s;
    if (p == NULL || cfg == NULL || (model != NULL && vt_svm_model_check(model) != VT_OK)) {
        return VT_E_ARG;
    }
    s = vt_pipeline_cfg_check(cfg);
    if (s == VT_OK && camera != NULL) {
        s = vt_camera_cfg_check(camera);
        if (s == VT_OK) {
            s = vt_range_cfg_check(&cfg->range);
        }
    }
    if (s != VT_OK) {
        return s;
    }
    /* cfg may alias p->cfg (re-initialising with the same settings): copy first. */
    memmove(&p->cfg, cfg, sizeof(p->cfg));
    p->model = model;
    p->camera = camera;
    p->cls_ws = NULL;
    memset(&p->scorer, 0, sizeof(p->scorer));
    p->wide_model = NULL;
    p->refine = NULL;
    p->rescore = NULL;
    p->acf = NULL;
    p->acf_ws = NULL;
    p->acf_n = 0;
    p->cnn = NULL;
    memset(&p->cnn_cfg, 0, sizeof(p->cnn_cfg));
    p->cnn_work = NULL;
    p->cnn_work_bytes = 0;
    p->horizon_y = 0;
    p->horizon_known = 0;
    p->flow_st = NULL;
    memset(&p->flow, 0, sizeof(p->flow));
    p->model_ws = NULL;
    p->ttc_st = NULL;
    p->n_ttc = 0;
    p->frame = 0;
    p->ego_speed = -VT_Q16_ONE;
    memset(&p->pitch, 0, sizeof(p->pitch));
    memset(p->ranges, 0, sizeof(p->ranges));
    s = vt_range_init(&p->range);
    if (s == VT_OK && camera != NULL) {
        s = vt_pitch_init(&p->pitch, camera);
    }
    if (s != VT_OK) {
        return s;
    }
    memset(&p->detect, 0, sizeof(p->detect));
    memset(&p->det, 0, sizeof(p->det));
    memset(p->tracks, 0, sizeof(p->tracks));
    p->n_src = 0;
    p->n_top = 0;
    p->n_trk = 0;
    p->n_ho = 0;
    memset(p->ho_tid, 0, sizeof(p->ho_tid));
    memset(p->ho_len, 0, sizeof(p->ho_len));
    s = vt_lane_reset(&p->lane);
    if (s == VT_OK) {
        s = vt_tracker_init(&p->tracker);
    }
    return s;
}

vt_status vt_pipeline_set_edge_ws(vt_pipeline *p, vt_edge_ws *ws)
{
    if (p == NULL) {
        return VT_E_ARG;
    }
    return vt_tracker_set_edge_ws(&p->tracker, ws);
}

vt_status vt_pipeline_set_cls_ws(vt_pipeline *p, vt_pipe_cls_ws *ws, const vt_window_scorer *scorer)
{
    vt_status s;
    if (p == NULL || (scorer != NULL && (scorer->score == NULL || ws == NULL))) {
        return VT_E_ARG;
    }
    if (ws == NULL) {
        p->cls_ws = NULL;
        memset(&p->scorer, 0, sizeof(p->scorer));
        return VT_OK;
    }
    if (scorer == NULL && p->model == NULL && (p->acf != NULL || p->cnn != NULL)) {
        /* the ACF stage and the CNN detector need no window scorer */
        memset(&p->scorer, 0, sizeof(p->scorer));
    } else if (scorer == NULL) {
        if (p->model == NULL) {
            return VT_E_ARG;
        }
        s = vt_hog_scorer_init(&ws->hog, p->model);
        if (s != VT_OK) {
            return s;
        }
        p->scorer.level = vt_hog_scorer_level;
        p->scorer.score = vt_hog_scorer_score;
        p->scorer.ctx = &ws->hog;
    } else {
        p->scorer = *scorer;
    }
    p->cls_ws = ws;
    return VT_OK;
}

vt_status vt_pipeline_set_wide(vt_pipeline *p, const vt_mlp_model *m, const vt_fulldet_wide_cfg *cfg)
{
    vt_status s;
    if (p == NULL || (m != NULL && cfg == NULL)) {
        return VT_E_ARG;
    }
    if (m == NULL) {
        p->wide_model = NULL;
        return VT_OK;
    }
    s = vt_mlp_model_check(m);
    if (s == VT_OK) {
        s = vt_fulldet_wide_cfg_check(cfg);
    }
    if (s != VT_OK) {
        return s;
    }
    p->wide_model = m;
    p->wide_cfg = *cfg;
    return VT_OK;
}

vt_status vt_pipeline_set_acf(vt_pipeline *p, const vt_acf_model *m, const vt_acf_cfg *cfg,
                              vt_acf_ws *ws)
{
    if (p == NULL || (m != NULL && (cfg == NULL || ws == NULL))) {
        return VT_E_ARG;
    }
    return vt_pipeline_set_acf_n(p, m != NULL, &m, &cfg, ws);
}

vt_status vt_pipeline_set_acf_n(vt_pipeline *p, int32_t n, const vt_acf_model *const *m,
                                const vt_acf_cfg *const *cfg, vt_acf_ws *ws)
{
    int32_t i;
    vt_status s = VT_OK;
    if (p == NULL || n < 0 || n > VT_ACF_MAX_MODELS ||
        (n > 0 && (m == NULL || cfg == NULL || ws == NULL))) {
        return VT_E_ARG;
    }
    for (i = 0; i < n && s == VT_OK; ++i) {
        s = vt_acf_model_check(m[i]);
        if (s == VT_OK) {
            s = vt_acf_cfg_check(cfg[i]);
        }
    }
    if (s != VT_OK) {
        return s;
    }
    p->acf = n > 0 ? m[0] : NULL;
    p->acf_ws = n > 0 ? ws : NULL;
    p->acf_n = n;
    for (i = 0; i < n; ++i) {
        p->acf_m[i] = m[i];
        p->acf_cfg[i] = *cfg[i];
    }
    return VT_OK;
}

vt_status vt_pipeline_set_cnn(vt_pipeline *p, const vt_cnn_model *m, const vt_cnn_cfg *cfg,
                              uint8_t *work, size_t work_bytes)
{
    vt_cnn_cfg placed;
    vt_status s;
    if (p == NULL || (m != NULL && (cfg == NULL || work == NULL))) {
        return VT_E_ARG;
    }
    if (m == NULL) {
        p->cnn = NULL;
        p->cnn_work = NULL;
        p->cnn_work_bytes = 0;
        return VT_OK;
    }
    s = vt_cnn_check_model(m);
    if (s == VT_OK) {
        /* checks cfg; the road camera was checked by vt_pipeline_init */
        s = vt_cnn_cfg_at_horizon(cfg, p->cfg.road_camera.horizon_q16, &placed);
    }
    if (s != VT_OK) {
        return s;
    }
    p->cnn = m;
    p->cnn_cfg = placed;
    p->cnn_work = work;
    p->cnn_work_bytes = work_bytes;
    return VT_OK;
}

vt_status vt_pipeline_set_refine(vt_pipeline *p, const vt_box_regressor *r)
{
    vt_status s = VT_OK;
    if (p == NULL) {
        return VT_E_ARG;
    }
    if (r != NULL) {
        s = vt_box_regressor_check(r);
    }
    if (s == VT_OK) {
        p->refine = r;
    }
    return s;
}

vt_status vt_pipeline_set_rescore(vt_pipeline *p, const vt_box_rescorer *r)
{
    vt_status s = VT_OK;
    if (p == NULL) {
        return VT_E_ARG;
    }
    if (r != NULL) {
        s = vt_box_rescorer_check(r);
    }
    if (s == VT_OK) {
        p->rescore = r;
    }
    return s;
}

vt_status vt_pipeline_set_flow_ws(vt_pipeline *p, vt_flow_state *st)
{
    vt_status s = VT_OK;
    if (p == NULL) {
        return VT_E_ARG;
    }
    if (st != NULL) {
        s = vt_flow_init(st);
    }
    if (s == VT_OK) {
        p->flow_st = st;
        memset(&p->flow, 0, sizeof(p->flow));
        p->n_ho = 0; /* the state's hand-over tracks are gone (vt_flow_init) */
    }
    return s;
}

vt_status vt_pipeline_set_model_ws(vt_pipeline *p, vt_model_ws *ws)
{
    if (p == NULL) {
        return VT_E_ARG;
    }
    p->model_ws = ws;
    return VT_OK;
}

vt_status vt_pipeline_set_ttc_ws(vt_pipeline *p, vt_ttc_state *st)
{
    vt_status s = VT_OK;
    if (p == NULL) {
        return VT_E_ARG;
    }
    if (st != NULL) {
        s = vt_ttc_init(st);
    }
    if (s == VT_OK) {
        p->ttc_st = st;
        p->n_ttc = 0;
    }
    return s;
}

vt_status vt_pipeline_set_ego_speed(vt_pipeline *p, vt_q16 speed)
{
    if (p == NULL) {
        return VT_E_ARG;
    }
    p->ego_speed = speed < 0 ? -VT_Q16_ONE : speed;
    return VT_OK;
}

vt_status vt_pipeline_work_size(int32_t w, int32_t h, int32_t max_w, int32_t max_h,
                                int32_t *work_w, int32_t *work_h)
{
    int64_t v;
    if (work_w == NULL || work_h == NULL) {
        return VT_E_ARG;
    }
    if (w < 1 || h < 1 || max_w < 1 || max_h < 1) {
        return VT_E_SIZE;
    }
    if (w <= max_w && h <= max_h) {
        *work_w = w;
        *work_h = h;
    } else if ((int64_t)w * max_h >= (int64_t)h * max_w) {
        /* Width limits: w/max_w >= h/max_h. */
        v = (int64_t)h * max_w / w;
        *work_w = max_w;
        *work_h = v < 1 ? 1 : (int32_t)v;
    } else {
        v = (int64_t)w * max_h / h;
        *work_w = v < 1 ? 1 : (int32_t)v;
        *work_h = max_h;
    }
    return VT_OK;
}

static int64_t vt__inter(const vt_box *a, const vt_box *b);

/* Everything is kept in thousandths of a pixel (K = 1000) so the permille
 * fractions are exact: VX = vp_x * (w - 1), VY = vp_y * (h - 1), SPAN = the
 * bottom row's distance below VY. t = (y K - VY) / SPAN clamped to [0, 1], then
 * x = VX + t (BX - VX) rounded half up: floor((VX SPAN + TN (BX - VX) + SPAN K / 2)
 * / (SPAN K)) with TN = clamp(y K - VY, 0, SPAN). Magnitudes stay below
 * 2^12 * 1000 squared ~ 2^44, so int64 never overflows. */
vt_status vt_fixed_road_area(const vt_fixed_road *fr, int32_t w, int32_t h, vt_road_area *road)
{
    const int64_t k = 1000;
    int64_t vx, vy, span, bl, br, lb, tn, den;
    int32_t y, yt;
    if (fr == NULL || road == NULL || vt_fixed_road_check(fr) != VT_OK) {
        return VT_E_ARG;
    }
    if (w < 1 || h < 1 || w > VT_MAX_WIDTH || h > VT_MAX_HEIGHT) {
        return VT_E_SIZE;
    }
    vx = (int64_t)fr->vp_x_permille * (w - 1);
    vy = (int64_t)fr->vp_y_permille * (h - 1);
    bl = (int64_t)fr->bottom_left_permille * (w - 1);
    br = (int64_t)fr->bottom_right_permille * (w - 1);
    lb = (int64_t)fr->lane_bottom_permille * w; /* lane width at the bottom, K px */
    span = (int64_t)(h - 1) * k - vy;
    if (span <= 0) {
        span = k; /* the vanishing point on the bottom row: t jumps to 1 there */
    }
    den = span * k;
    for (y = 0; y < h; ++y) {
        tn = (int64_t)y * k - vy;
        tn = tn < 0 ? 0 : (tn > span ? span : tn);
        road->x_left[y] = (int16_t)vt__floor_div64(vx * span + tn * (bl - vx) + den / 2, den);
        road->x_right[y] = (int16_t)vt__floor_div64(vx * span + tn * (br - vx) + den / 2, den);
        road->lane_width[y] = (int16_t)vt__floor_div64(tn * lb + den / 2, den);
    }
    /* First row: ceil(VY / K) + top_margin, kept inside the frame. */
    yt = (int32_t)(-vt__floor_div64(-vy, k)) + fr->top_margin;
    road->y_top = vt__clamp_i32(yt, 0, h - 1);
    road->y_bottom = h - 1;
    road->height = h;
    road->valid = 1;
    return VT_OK;
}

/* The road area of a detection frame per the policy: the lanes' (written to
 * out->road by the lane stage) when found, else the caller's road or the fixed
 * trapezoid (none with VT_ROAD_LANES). */
static void vt__road(const vt_pipeline *p, const vt_image_u8 *frame, const vt_road_area *given,
                     vt_frame_out *out, int32_t lanes_ok)
{
    if (lanes_ok && out->road.valid) {
        out->road_source = VT_ROAD_SRC_LANES;
        return;
    }
    out->road.valid = 0;
    out->road_source = VT_ROAD_SRC_NONE;
    if (p->cfg.road_policy == VT_ROAD_LANES) {
        return;
    }
    if (given != NULL) {
        if (given->valid) {
            out->road = *given;
            out->road_source = VT_ROAD_SRC_FIXED;
        }
    } else if (vt_fixed_road_area(&p->cfg.fixed_road, frame->w, frame->h, &out->road) == VT_OK) {
        out->road_source = VT_ROAD_SRC_FIXED;
    }
}

/* The frame counter wraps to 0 after INT32_MAX frames (over two years at 30
 * frames/s); only the detection cadence notices. */
static int32_t vt__next_frame(int32_t f)
{
    return f < INT32_MAX ? f + 1 : 0;
}

/* Q16 seconds or metres -> thousandths, rounded half up, saturated to int32
 * (VT_UNKNOWN is never produced for a known value: it saturates to INT32_MIN + 1). */
static int32_t vt__q16_milli(vt_q16 v)
{
    int64_t m = ((int64_t)v * 1000 + 32768) >> 16;
    return m > INT32_MAX ? INT32_MAX : (m <= INT32_MIN ? INT32_MIN + 1 : (int32_t)m);
}

/* Intersection area of two inclusive boxes (0 if disjoint), exact in int64. */
static int64_t vt__inter(const vt_box *a, const vt_box *b)
{
    int64_t w = (int64_t)(a->right < b->right ? a->right : b->right) -
                (a->left > b->left ? a->left : b->left) + 1;
    int64_t h = (int64_t)(a->bottom < b->bottom ? a->bottom : b->bottom) -
                (a->top > b->top ? a->top : b->top) + 1;
    return (w > 0 && h > 0) ? w * h : 0;
}

/* The source that started each output track (see vt_pipe_track.source): kept from the
 * table for known ids, else taken from this frame's boxes; then the table is rewritten
 * with the live tracks only (after every lookup, so no entry is read once overwritten). */
static void vt__track_sources(vt_pipeline *p, vt_frame_out *out)
{
    int32_t i, k, n_old = p->n_src, src;
    int64_t best, a;
    for (i = 0; i < out->n_tracks; ++i) {
        src = 0;
        for (k = 0; k < n_old; ++k) {
            if (p->src_id[k] == out->tracks[i].id) {
                src = p->src_of[k];
                break;
            }
        }
        if (k == n_old) {
            best = 0;
            for (k = 0; k < out->n_boxes; ++k) {
                a = vt__inter(&out->tracks[i].box, &out->boxes[k].box);
                if (a > best) {
                    best = a;
                    src = out->boxes[k].source;
                }
            }
        }
        out->tracks[i].source = src;
    }
    for (i = 0; i < out->n_tracks; ++i) {
        p->src_id[i] = out->tracks[i].id;
        p->src_of[i] = out->tracks[i].source;
    }
    p->n_src = out->n_tracks;
}

static int32_t vt__iou_at_least(const vt_box *a, const vt_box *b, int32_t permille);
static int32_t vt__iou_more(const vt_box *e, const vt_box *a, const vt_box *b);

/* A tracker box that is an ego box reported as it is (top_of in vt__step; boxes lie
 * within tracker.c's bounds, so no top row is INT32_MAX). */
#define VT__TOP_EGO INT32_MAX

/* cfg.cnn_track_top (pipeline.h): each of the tracker's n boxes e[k] of this frame that is
 * an ego box (t[k]: the top row of the CNN box it was reported with, VT__TOP_EGO when it
 * was reported as it is; VT_UNKNOWN: not an ego box) goes to the tracker's track that
 * overlaps it most (IoU >= the tracker's match_iou_permille, the first of equals; a later
 * box wins). That track's height becomes q = max(1, round half up 256 (bottom - t[k] + 1)
 * / width) of its own box, or none (0) for VT__TOP_EGO; other tracks keep theirs by id.
 * The tracker's tracks (the first n_trk output tracks, hand-overs follow) are then
 * reported with top = bottom - max(1, floor((w q + 128) / 256)) + 1 where q > 0, and the
 * table is rewritten with them only. */
static void vt__track_tops(vt_pipeline *p, int32_t n_trk, const vt_box *e, const int32_t *t, int32_t n,
                           vt_frame_out *out)
{
    int32_t q[VT_MAX_TRACKS], i, k, best;
    n_trk = n_trk < out->n_tracks ? n_trk : out->n_tracks;
    for (i = 0; i < n_trk; ++i) {
        q[i] = 0;
        for (k = 0; k < p->n_top; ++k) {
            if (p->top_id[k] == out->tracks[i].id) {
                q[i] = p->top_q8[k];
                break;
            }
        }
    }
    for (k = 0; k < n; ++k) {
        if (t[k] == VT_UNKNOWN) {
            continue;
        }
        best = -1;
        for (i = 0; i < n_trk; ++i) {
            if (vt__iou_at_least(&e[k], &out->tracks[i].box, p->cfg.tracker.match_iou_permille) &&
                (best < 0 || vt__iou_more(&e[k], &out->tracks[i].box, &out->tracks[best].box))) {
                best = i;
            }
        }
        if (best >= 0 && t[k] == VT__TOP_EGO) {
            q[best] = 0; /* detect's latest box of it is the ego box itself */
        } else if (best >= 0) {
            /* rounded half up, as the tracker's aspect; a CNN top below the track's bottom
             * (v <= 0, truncated or floored alike) gives 1. |num| < 2^16 (tracker.c's
             * bounds), so v < 2^24. */
            const vt_box *b = &out->tracks[best].box;
            int64_t w = (int64_t)b->right - b->left + 1, num = (int64_t)b->bottom - t[k] + 1;
            int64_t v = (num * 256 + w / 2) / w;
            q[best] = v < 1 ? 1 : (int32_t)v;
        }
    }
    for (i = 0; i < n_trk; ++i) {
        vt_box *b = &out->tracks[i].box;
        if (q[i] > 0) {
            int64_t h = vt__floor_shr64((int64_t)(b->right - b->left + 1) * q[i] + 128, 8);
            b->top = b->bottom - (int32_t)(h < 1 ? 1 : h) + 1;
        }
        p->top_id[i] = out->tracks[i].id;
        p->top_q8[i] = q[i];
    }
    p->n_top = n_trk;
}

/* vt_pipe_track.ttc_fused_q16 from the block-scale TTC pts and the distance/rate TTC
 * dist (VT_UNKNOWN: not known): vt_ttc_fuse (camera.h), w permille on dist (checked by
 * vt_pipeline_cfg_check), VT_UNKNOWN when neither is known. */
static vt_q16 vt__ttc_fuse(vt_q16 pts, vt_q16 dist, int32_t w)
{
    vt_q16 f = -1;
    (void)vt_ttc_fuse(pts, dist, w, &f);
    return f < 0 ? VT_UNKNOWN : f;
}

/* The block-scale TTC of the tracker's track i (VT_UNKNOWN: none this frame). */
static vt_q16 vt__ttc_points_of(const vt_pipeline *p, int32_t id)
{
    int32_t k;
    for (k = 0; k < p->n_ttc; ++k) {
        if (p->ttc_out[k].id == id) {
            return (p->ttc_out[k].flags & VT_TTC_VALID) ? p->ttc_out[k].ttc : VT_UNKNOWN;
        }
    }
    return VT_UNKNOWN;
}

static void vt__out_tracks(const vt_pipeline *p, int32_t n, int32_t n_ranges, vt_frame_out *out)
{
    int32_t i, k;
    for (i = 0; i < n && i < VT_MAX_TRACKS; ++i) {
        const vt_track_out *t = &p->tracks[i];
        vt_pipe_track *o = &out->tracks[i];
        vt_q16 dist = VT_UNKNOWN;
        o->id = t->id;
        o->state = t->state;
        o->box = t->box;
        o->vx = t->vx;
        o->vy = t->vy;
        o->distance_mm = VT_UNKNOWN;
        o->ttc_ms = VT_UNKNOWN;
        o->warning = p->camera != NULL ? VT_FCW_NONE : VT_FCW_UNKNOWN;
        o->source = 0;
        o->ttc_points_q16 = vt__ttc_points_of(p, t->id);
        for (k = 0; k < n_ranges; ++k) {
            const vt_range_out *r = &p->ranges[k];
            if (r->id != t->id) {
                continue;
            }
            if (r->flags & VT_RANGE_FILT_VALID) {
                o->distance_mm = vt__q16_milli(r->dist_filt);
            }
            if (r->flags & VT_RANGE_TTC_DIST_VALID) {
                o->ttc_ms = vt__q16_milli(r->ttc_dist);
                dist = r->ttc_dist;
            }
            o->warning = r->fcw;
            break;
        }
        o->ttc_fused_q16 = vt__ttc_fuse(o->ttc_points_q16, dist, p->cfg.ttc_fuse_permille);
    }
    out->n_tracks = i;
}

/* The camera stage after the tracker and the block-scale TTC: the pitch from this
 * frame's lanes (when they ran and both ego lines meet), then the range filters of the
 * tracks, whose warning decides on the fused TTC where a track has a block-scale one
 * when cfg.fcw_fused asks for it. */
static vt_status vt__geometry(vt_pipeline *p, const vt_image_u8 *frame, const vt_frame_out *out,
                              int32_t lanes_ok, int32_t n_tracks, int32_t *n_ranges)
{
    vt_q16 vp_row = 0, pts[VT_MAX_TRACKS];
    int32_t vp_valid = 0, i;
    vt_status s;
    *n_ranges = 0;
    for (i = 0; p->cfg.fcw_fused && i < n_tracks && i < VT_MAX_TRACKS; ++i) {
        pts[i] = vt__ttc_points_of(p, p->tracks[i].id); /* only the fused warning reads them */
    }
    if (lanes_ok && vt_lane_vanishing_row(&out->lanes, frame->h, &vp_row, &vp_valid) != VT_OK) {
        vp_valid = 0;
    }
    s = vt_pitch_update(&p->pitch, p->camera, vp_valid, vp_valid ? vp_row : 0);
    if (s == VT_OK) {
        s = vt_range_step_fused(&p->range, &p->cfg.range, p->camera, p->pitch.tan_pitch, p->ego_speed,
                                p->tracks, n_tracks, p->cfg.fcw_fused ? pts : NULL,
                                p->cfg.ttc_fuse_permille, p->ranges,
                                VT_MAX_TRACKS, n_ranges);
    }
    return s;
}

/* round(h * q / 65536), half up, exact (|h q| < 2^32). */
static int32_t vt__frac_q16(int32_t h, int32_t q)
{
    return (int32_t)vt__floor_div64((int64_t)h * q + 32768, 65536);
}

/* The horizon row of a frame h rows high, for the whole-road detector, the vehicle
 * model and the tracker's scale check: the last lanes' vanishing row once known
 * (clamped to +-VT_MAX_HEIGHT), else the road camera's configured fraction. */
static int32_t vt__horizon(const vt_pipeline *p, int32_t h)
{
    return p->horizon_known ? p->horizon_y : vt__frac_q16(h, p->cfg.road_camera.horizon_q16);
}

/* The ego-lane detector on a detection frame (thesis sec. 2.4.2): the lanes' road
 * (else the fixed or the caller's, per the policy), shadow hypotheses and vertical-edge
 * verification into p->det (the tracker's input) and out, the boxes labelled `source`.
 * On an error of vt_detect, p->det is empty and out has no boxes. */
static vt_status vt__detect_ego(vt_pipeline *p, const vt_image_u8 *frame, const vt_road_area *given,
                                vt_frame_out *out, int32_t lanes_ok, int32_t source)
{
    int32_t i;
    vt_status s = VT_OK;
    int32_t hood = -1;
    vt__road(p, frame, given, out, lanes_ok);
    if (p->cfg.road_above_hood) {
        hood = vt__frac_q16(frame->h, p->cfg.road_camera.hood_q16);
        hood = hood < 1 ? 1 : hood;
    } else if (p->cfg.auto_hood) {
        /* no known hood row: the hood's edge found in this frame, if any */
        vt_hood_result hr;
        s = vt_hood_find(&p->hood, &p->cfg.hood, frame, &hr);
        if (s != VT_OK) {
            return s;
        }
        hood = hr.found ? hr.row : -1;
        out->hood_row = hood;
    }
    if (hood >= 0 && out->road_source != VT_ROAD_SRC_NONE &&
        (out->road_source == VT_ROAD_SRC_LANES || given == NULL)) {
        /* the hood is not road: its edge against the road is dark above bright. The
         * shadow scan's Sobel at a row reads the row below, so the last road row is
         * two above the hood's first */
        if (hood - 2 < out->road.y_top) {
            out->road.valid = 0;
            out->road_source = VT_ROAD_SRC_NONE;
        } else if (out->road.y_bottom > hood - 2) {
            out->road.y_bottom = hood - 2;
        }
    }
    p->det.n_hyp = 0;
    p->det.n_boxes = 0;
    if (out->road_source != VT_ROAD_SRC_NONE) {
        s = vt_detect(&p->detect, &p->cfg.detect, frame, &out->road, &p->det);
    }
    out->n_hyp = p->det.n_hyp;
    for (i = 0; i < p->det.n_hyp; ++i) {
        out->hyp[i] = p->det.hyp[i];
    }
    for (i = 0; i < p->det.n_boxes; ++i) {
        out->boxes[i].box = p->det.box[i];
        out->boxes[i].source = source;
        out->boxes[i].score = VT_UNKNOWN;
    }
    out->n_boxes = p->det.n_boxes;
    return s;
}

/* The CNN detector on the frame into res (vt_pipeline_set_cnn): its boxes as classifier
 * boxes (VT_FULLDET_WINDOWS), score = heat x heat_scale_q16 (Q16 logit; |heat| <= 128
 * and heat_scale_q16 <= 2^24 keep it in int32), the first VT_MAX_BOXES in NMS order;
 * the counters: every peak is a window hit and a candidate (n_peaks), nothing else. */
static vt_status vt__detect_cnn(const vt_pipeline *p, const vt_image_u8 *frame,
                                vt_fulldet_result *res)
{
    vt_cnn_box b[VT_MAX_BOXES];
    int32_t i, n = 0, n_peaks = 0;
    vt_status s = vt_cnn_detect_frame(p->cnn, &p->cnn_cfg, frame->px, frame->w, frame->h,
                                      frame->stride, p->cnn_work, p->cnn_work_bytes, b,
                                      VT_MAX_BOXES, &n, &n_peaks);
    res->n_boxes = 0;
    res->n_windows = 0;
    res->n_windows_dropped = 0;
    res->n_window_hits = n_peaks;
    res->n_shadow = 0;
    res->n_cand = n_peaks;
    res->n_cand_dropped = 0;
    if (s != VT_OK) {
        return s;
    }
    for (i = 0; i < n; ++i) {
        res->box[i].box.left = b[i].l;
        res->box[i].box.top = b[i].t;
        res->box[i].box.right = b[i].r;
        res->box[i].box.bottom = b[i].b;
        res->box[i].score = b[i].score * p->cnn->heat_scale_q16;
        res->box[i].source = VT_FULLDET_WINDOWS;
    }
    res->n_boxes = n;
    return VT_OK;
}

/* Drop the CNN's boxes on the hood (vt_pipeline_cfg.cnn_hood_min_width_mm's rule), in
 * place, the others keeping their order. */
static void vt__cnn_hood_drop(vt_fulldet_result *res, const vt_camera_min *cam, int32_t frame_w,
                              int32_t min_w_mm)
{
    int32_t i, n = 0;
    const int32_t margin = frame_w / 64;
    for (i = 0; i < res->n_boxes; ++i) {
        const vt_box *b = &res->box[i].box;
        const int drop = min_w_mm > 0 && b->bottom > cam->hood_y && b->left > margin &&
                         b->right < frame_w - 1 - margin &&
                         (int64_t)(b->right - b->left + 1) * cam->height_mm <
                             (int64_t)min_w_mm * (b->bottom - cam->horizon_y);
        if (!drop) {
            res->box[n++] = res->box[i];
        }
    }
    res->n_boxes = n;
}

/* The whole-road detector on a detection frame: its camera (the road camera of the
 * frame's size, the horizon the last lanes' vanishing row once known), the road (the
 * caller's when given, else the camera road), vt_fulldet, and its boxes into out and
 * p->det (the tracker's input) after the n0 ego-lane boxes already there (VT_SRC_EGO;
 * 0 otherwise): a box NMS would suppress against one of those (the detector's IoU and
 * containment limits) is dropped. With the second stage on (cfg.verify) the ego boxes go
 * through it first (dropped under verify_min, else scored by it); an ego box then takes
 * the highest score of itself and the boxes it suppresses (unscored: the detector's
 * threshold, window_score_min, if it suppresses none); the shadow hypotheses follow
 * the ego ones. With a CNN and cfg.cnn_ego_iou_permille > 0, an ego box is reported with
 * the box of the CNN boxes it drops that overlaps it most, when that IoU is >= the limit;
 * p->det (the tracker's input) keeps the ego box. top_of[j] for each ego box j that
 * survives (the caller set them all VT_UNKNOWN): that reported box's top row, or
 * VT__TOP_EGO when it is reported as it is. */
static vt_status vt__detect_whole(vt_pipeline *p, const vt_image_u8 *frame,
                                  const vt_road_area *given, vt_frame_out *out, int32_t n0,
                                  int32_t *top_of)
{
    int32_t k, j, n_hyp0 = out->n_hyp; /* the ego hypotheses (0 without VT_SRC_EGO) */
    int32_t n_raw, cnn_iou;
    int32_t best[VT_MAX_BOXES]; /* per ego box: its dropped CNN box of the highest IoU, or -1 */
    vt_box raw[VT_MAX_BOXES]; /* the detector's boxes before box regression */
    vt_fulldet_cfg fc;
    vt_camera_min cam;
    vt_pipe_cls_ws *ws = p->cls_ws;
    const vt_road_camera *rc = &p->cfg.road_camera;
    int32_t i, fx;
    vt_status s;
    vt__fulldet_cfg(&p->cfg, &fc);
    if (n0 > 0 && p->cfg.verify) {
        /* the ego boxes through the second stage too (the detector's result is scratch
         * until vt_fulldet fills it): the survivors carry its score */
        const vt_mlp_model *m = NULL;
        s = vt_mlp_default_model(&m);
        ws->res.n_boxes = n0;
        for (j = 0; j < n0; ++j) {
            ws->res.box[j].box = p->det.box[j];
            ws->res.box[j].score = 0;
            ws->res.box[j].source = VT_FULLDET_SHADOW;
        }
        if (s == VT_OK) {
            s = vt_fulldet_verify(&ws->box, m, frame, p->cfg.verify_min, &ws->res);
        }
        if (s != VT_OK) {
            return s;
        }
        n0 = ws->res.n_boxes;
        for (j = 0; j < n0; ++j) {
            p->det.box[j] = ws->res.box[j].box;
            out->boxes[j].box = ws->res.box[j].box;
            out->boxes[j].score = ws->res.box[j].score;
        }
    }
    for (j = 0; j < n0; ++j) {
        top_of[j] = VT__TOP_EGO; /* before the early return below: no road, no CNN box */
    }
    cam.horizon_y = vt__horizon(p, frame->h);
    cam.hood_y = vt__frac_q16(frame->h, rc->hood_q16);
    cam.hood_y = cam.hood_y < 1 ? 1 : cam.hood_y;
    fx = (int32_t)(((int64_t)frame->w * rc->fx_per_w_q16 + 2048) >> 12);
    cam.fx_q4 = fx < 16 ? 16 : fx;
    cam.height_mm = rc->height_mm;
    out->road.valid = 0;
    out->road_source = VT_ROAD_SRC_NONE;
    if (given != NULL) {
        if (given->valid) {
            out->road = *given;
            out->road_source = VT_ROAD_SRC_FIXED;
        }
    } else {
        s = vt_road_from_camera(&fc.win, &cam, frame->w, frame->h, &out->road);
        if (s != VT_OK) {
            return s;
        }
        out->road_source = out->road.valid ? VT_ROAD_SRC_CAMERA : VT_ROAD_SRC_NONE;
    }
    p->det.n_hyp = 0;
    p->det.n_boxes = n0;
    out->n_boxes = n0;
    out->n_hyp = n_hyp0;
    if (out->road_source == VT_ROAD_SRC_NONE) {
        return VT_OK;
    }
    if (p->cnn != NULL) {
        s = vt__detect_cnn(p, frame, &ws->res);
        if (s == VT_OK) {
            vt__cnn_hood_drop(&ws->res, &cam, frame->w, p->cfg.cnn_hood_min_width_mm);
        }
    } else if (p->acf != NULL) {
        const vt_acf_cfg *cfgs[VT_ACF_MAX_MODELS];
        for (i = 0; i < p->acf_n; ++i) {
            cfgs[i] = &p->acf_cfg[i];
        }
        s = vt_acf_detect_n(p->acf_ws, p->acf_n, p->acf_m, cfgs, &cam, frame, &ws->res);
        if (s == VT_OK && p->rescore != NULL) {
            s = vt_fulldet_rescore(&ws->box, p->rescore, &cam, frame, &ws->res);
        }
    } else {
        s = vt_fulldet(&ws->st, &fc, &cam, frame, &out->road, &p->scorer, &ws->res);
    }
    /* the CNN is its own verification: none of the stages below run on its boxes */
    if (s == VT_OK && fc.rerank_permille > 0 && p->acf == NULL && p->cnn == NULL) {
        /* NMS again, ranked with the second stage's model too (fulldet.h) */
        const vt_mlp_model *m = NULL;
        s = vt_mlp_default_model(&m);
        if (s == VT_OK) {
            s = vt_fulldet_rerank(&ws->st, &ws->box, m, &fc, frame, &ws->res);
        }
    }
    if (s == VT_OK && p->cfg.verify != 0 && p->cnn == NULL &&
        !(p->acf != NULL && p->rescore != NULL)) {
        const vt_mlp_model *m = NULL;
        s = vt_mlp_default_model(&m);
        if (s == VT_OK) {
            /* verify 2: boxes flatter than 1:2 (side views) pass with their own score; 3: and
             * boxes the frame's side cuts; 4: and boxes narrower than 32 px (far cars) */
            static const int32_t skip[5] = {0, 0, VT__VERIFY_SKIP_FLAT,
                                            VT__VERIFY_SKIP_FLAT | VT__VERIFY_SKIP_SIDE,
                                            VT__VERIFY_SKIP_FLAT | VT__VERIFY_SKIP_SIDE |
                                                VT__VERIFY_SKIP_SMALL};
            s = vt__fulldet_verify(&ws->box, m, frame, p->cfg.verify_min, skip[p->cfg.verify],
                                   &ws->res);
        }
    }
    n_raw = s == VT_OK ? ws->res.n_boxes : 0;
    for (i = 0; i < n_raw; ++i) {
        raw[i] = ws->res.box[i].box;
    }
    if (s == VT_OK && p->refine != NULL && p->cnn == NULL) {
        /* box regression on the detector's own boxes (the ego boxes are not in res); the
         * tracker keeps the boxes as detected (raw), whose bottom edge and sides its ROI
         * search measures */
        s = vt_fulldet_refine(&ws->box, p->refine, frame, &ws->res);
    }
    if (s == VT_OK && p->wide_model != NULL && p->cnn == NULL) {
        /* the wide pass (side views, trucks): its scratch is the detector's, done with */
        s = vt_fulldet_wide(&ws->st, &ws->box, &p->wide_cfg, &fc.win, p->wide_model, &cam, frame,
                            &out->road, &ws->res);
    }
    if (s != VT_OK) {
        return s;
    }
    /* The shadow source's hypotheses (fulldet keeps them in its detect result). */
    if ((fc.sources & VT_FULLDET_SHADOW) && p->acf == NULL && p->cnn == NULL) {
        for (i = 0; i < ws->st.dres.n_hyp && n_hyp0 + i < VT_MAX_HYPOTHESES; ++i) {
            out->hyp[n_hyp0 + i] = ws->st.dres.hyp[i];
        }
        out->n_hyp = n_hyp0 + i;
    }
    /* the CNN's boxes are all in raw (no box regression runs on them) */
    cnn_iou = p->cnn != NULL && p->cfg.cnn_ego_iou_permille > 0 && n_raw == ws->res.n_boxes;
    for (j = 0; j < n0; ++j) {
        best[j] = -1;
    }
    k = n0;
    for (i = 0; i < ws->res.n_boxes; ++i) {
        /* b: the box as detected (the tracker's input, and what NMS tests against the ego
         * boxes); the reported box is the regressed one */
        const vt_box *b = i < n_raw ? &raw[i] : &ws->res.box[i].box;
        for (j = 0; j < n0; ++j) {
            if (vt__box_suppress(&p->det.box[j], b, fc.nms_iou_permille, fc.nms_contain_permille)) {
                break;
            }
        }
        if (j < n0) {
            /* the ego box's score: the best the classifier gave the same vehicle */
            if (out->boxes[j].score == VT_UNKNOWN || out->boxes[j].score < ws->res.box[i].score) {
                out->boxes[j].score = ws->res.box[i].score;
            }
            if (cnn_iou && (best[j] < 0 || vt__iou_more(&p->det.box[j], b, &raw[best[j]]))) {
                best[j] = i; /* the dropped CNN box of the highest IoU with it, the first of equals */
            }
            continue;
        }
        if (k == VT_MAX_BOXES) {
            continue;
        }
        p->det.box[k] = *b;
        out->boxes[k].box = ws->res.box[i].box;
        out->boxes[k].source = ws->res.box[i].source == VT_FULLDET_WINDOWS ? VT_SRC_CLASSIFIER
                                                                            : VT_SRC_SHADOW;
        out->boxes[k].score = ws->res.box[i].score;
        ++k;
    }
    /* an ego box the classifier did not see scores at the detector's threshold */
    for (j = 0; j < n0; ++j) {
        if (out->boxes[j].score == VT_UNKNOWN) {
            out->boxes[j].score = fc.window_score_min;
        }
        /* reported with the CNN's box of the same car; the tracker keeps the ego box */
        if (cnn_iou && best[j] >= 0 &&
            vt__iou_at_least(&p->det.box[j], &raw[best[j]], p->cfg.cnn_ego_iou_permille)) {
            out->boxes[j].box = ws->res.box[best[j]].box;
            top_of[j] = out->boxes[j].box.top;
        }
    }
    p->det.n_boxes = k;
    out->n_boxes = k;
    return VT_OK;
}

/* A box the tracker must not get because it is a handed-over vehicle: IoU with a live
 * hand-over's box of this frame >= the tracker's own association threshold
 * (match_iou_permille), so the vehicle keeps its one id. */
static int vt__ho_covers(const vt_pipeline *p, const vt_box *b)
{
    int32_t i;
    for (i = 0; i < p->n_ho; ++i) {
        if (vt__iou_at_least(b, &p->ho_box[i], p->cfg.tracker.match_iou_permille)) {
            return 1;
        }
    }
    return 0;
}

/* The live hand-overs after this frame's flow step: each takes its seed's hypothesis
 * (box, flow). One the flow stage no longer reports has ended (it left the frame, no
 * cell matched, or the stage restarted on a frame of another size). One whose inner
 * side (right on the left, left on the right) has not got further out than its
 * furthest-out column for handover_frames frames in a row ends here: the vehicle it
 * followed is leaving, a box that stays is on the road or a marking by the border.
 * An ended hand-over's seed is released (also when only the result's capacity,
 * VT_FLOW_MAX_HYPS, hid it), so the two lists never disagree. Order is kept. */
static void vt__ho_refresh(vt_pipeline *p)
{
    int32_t i, k, n = 0, inner;
    for (i = 0; i < p->n_ho; ++i) {
        for (k = 0; k < p->flow.n; ++k) {
            if (p->flow.hyp[k].kind == VT_FLOW_KIND_HANDOVER && p->flow.hyp[k].id == p->ho_seed[i]) {
                break;
            }
        }
        if (k < p->flow.n) {
            const vt_box *b = &p->flow.hyp[k].box;
            inner = p->ho_side[i] == 1 ? b->right : b->left;
            if (p->ho_side[i] == 1 ? inner < p->ho_best[i] : inner > p->ho_best[i]) {
                p->ho_best[i] = inner;
                p->ho_stall[i] = 0;
            } else {
                ++p->ho_stall[i];
            }
        }
        if (k == p->flow.n || p->ho_stall[i] >= p->cfg.handover_frames) {
            (void)vt_flow_unseed(p->flow_st, p->ho_seed[i]);
            continue;
        }
        p->ho_id[n] = p->ho_id[i];
        p->ho_seed[n] = p->ho_seed[i];
        p->ho_side[n] = p->ho_side[i];
        p->ho_best[n] = p->ho_best[i];
        p->ho_stall[n] = p->ho_stall[i];
        p->ho_box[n] = p->flow.hyp[k].box;
        p->ho_vx[n] = p->flow.hyp[k].flow_x;
        p->ho_vy[n] = p->flow.hyp[k].flow_y;
        ++n;
    }
    p->n_ho = n;
}

/* The hand-over rule's memory after the tracker: per tracker slot, the track's bottom
 * row and l + r pushed in front. It starts over for a slot given to a new id, and when
 * the box jumped since the last frame: its width or its bottom row moved by more than a
 * quarter of the last width or height (4 |dw| > w, 4 |db| > h; a part of a car
 * re-anchored to the whole car, not a car coming closer, which grows a few % a frame). */
static void vt__ho_history(vt_pipeline *p)
{
    int32_t i, j;
    for (i = 0; i < VT_MAX_TRACKS; ++i) {
        const vt_track *t = &p->tracker.tracks[i];
        const vt_box *o = &p->ho_last[i];
        if (t->state == VT_TRACK_FREE || p->ho_tid[i] != t->id) {
            p->ho_len[i] = 0;
            p->ho_tid[i] = t->state == VT_TRACK_FREE ? 0 : t->id;
        }
        if (t->state == VT_TRACK_FREE) {
            continue;
        }
        if (p->ho_len[i] > 0) {
            int64_t w0 = (int64_t)o->right - o->left + 1, h0 = (int64_t)o->bottom - o->top + 1;
            int64_t dw = ((int64_t)t->box.right - t->box.left + 1) - w0;
            int64_t db = (int64_t)t->box.bottom - o->bottom;
            if (4 * (dw < 0 ? -dw : dw) > w0 || 4 * (db < 0 ? -db : db) > h0) {
                p->ho_len[i] = 0;
            }
        }
        p->ho_last[i] = t->box;
        for (j = p->ho_len[i] < VT_PIPE_HO_HIST ? p->ho_len[i] : VT_PIPE_HO_HIST - 1; j > 0; --j) {
            p->ho_bot[i][j] = p->ho_bot[i][j - 1];
            p->ho_cx2[i][j] = p->ho_cx2[i][j - 1];
        }
        p->ho_bot[i][0] = t->box.bottom;
        p->ho_cx2[i][0] = t->box.left + t->box.right; /* |box| <= 4 VT_MAX_*: no overflow */
        p->ho_len[i] += p->ho_len[i] < VT_PIPE_HO_HIST;
    }
}

/* The reverse hand-over (IVVI paper sec. 3, last paragraph): the tracker's tracks
 * (output order) the ego car is overtaking and that are leaving by the side go to the
 * flow stage. A track qualifies when it is CONFIRMED or COASTING (it was confirmed),
 * has N = handover_frames frames of history before this one, and
 *   - its bottom row moved down by at least handover_dy_permille / 1000 of h over
 *     those N frames, and by half of that in each half of them (rows b0, b(N/2), bN,
 *     newest first: 2000 (b0 - b(N/2)) >= dy h and 2000 (b(N/2) - bN) >= dy h): it comes
 *     closer all along (on a flat road its box grows with it); a box that jumped once
 *     (a part of a car re-anchored to the whole car) passes the one-span test only,
 *   - its centre column lies in a lateral strip of the flow stage's width,
 *     sw = floor(w * flow.strip_permille / 1000) px: l + r < 2 sw (left) or
 *     l + r >= 2 (w - sw) (right), on either side whatever side the flow stage
 *     watches for overtaking vehicles (the ego car passes on the other one),
 *   - its outer side is within e of the border, e * 1000 = handover_edge_permille * w
 *     (l * 1000 <= e' on the left, (w - 1 - r) * 1000 <= e' on the right), and
 *   - it did not move inward over the N frames (l + r not larger on the left, not
 *     smaller on the right).
 * Then vt_flow_seed_frame(its box, this frame) and vt_tracker_drop(its id): it leaves p->tracks and is
 * reported as a hand-over with the same id (until vt__ho_refresh ends it). A seed refused (VT_FLOW_MAX_SEEDS live, or
 * a box outside the frame) leaves the track with the tracker. Exact integer tests. */
static void vt__handover(vt_pipeline *p, const vt_image_u8 *frame, int32_t *n_tracks)
{
    const int64_t w = frame->w, nf = p->cfg.handover_frames, half = nf / 2;
    const int64_t need = (int64_t)p->cfg.handover_dy_permille * frame->h; /* x 1000 */
    const int64_t sw = w * p->cfg.flow.strip_permille / 1000;
    const int64_t edge = (int64_t)p->cfg.handover_edge_permille * w;
    int32_t k = 0, i, side, sid = 0;
    while (k < *n_tracks) {
        const vt_track_out *t = &p->tracks[k];
        const vt_box *b = &t->box;
        int64_t c2 = (int64_t)b->left + b->right, dy1, dy2, dc;
        side = 0;
        for (i = 0; i < VT_MAX_TRACKS; ++i) {
            if (p->tracker.tracks[i].state != VT_TRACK_FREE && p->tracker.tracks[i].id == t->id) {
                break;
            }
        }
        if (i < VT_MAX_TRACKS && p->ho_tid[i] == t->id && p->ho_len[i] > nf &&
            (t->state == VT_TRACK_CONFIRMED || t->state == VT_TRACK_COASTING)) {
            dy1 = (int64_t)p->ho_bot[i][0] - p->ho_bot[i][half];
            dy2 = (int64_t)p->ho_bot[i][half] - p->ho_bot[i][nf];
            dc = (int64_t)p->ho_cx2[i][0] - p->ho_cx2[i][nf];
            if (dy1 * 2000 >= need && dy2 * 2000 >= need) {
                if (c2 < 2 * sw && (int64_t)b->left * 1000 <= edge && dc <= 0) {
                    side = 1;
                } else if (c2 >= 2 * (w - sw) && (w - 1 - b->right) * 1000 <= edge && dc >= 0) {
                    side = 2;
                }
            }
        }
        if (side != 0 && p->n_ho < VT_FLOW_MAX_SEEDS &&
            vt_flow_seed_frame(p->flow_st, &p->cfg.flow, frame, b, &sid) == VT_OK) {
            p->ho_id[p->n_ho] = t->id;
            p->ho_seed[p->n_ho] = sid;
            p->ho_box[p->n_ho] = *b;
            p->ho_vx[p->n_ho] = t->vx;
            p->ho_vy[p->n_ho] = t->vy;
            p->ho_side[p->n_ho] = side;
            p->ho_best[p->n_ho] = side == 1 ? b->right : b->left;
            p->ho_stall[p->n_ho] = 0;
            ++p->n_ho;
            (void)vt_tracker_drop(&p->tracker, t->id);
            p->ho_tid[i] = 0;
            p->ho_len[i] = 0;
            memmove(&p->tracks[k], &p->tracks[k + 1], (size_t)(*n_tracks - k - 1) * sizeof(p->tracks[0]));
            --*n_tracks;
            continue;
        }
        ++k;
    }
}

/* The live hand-overs after the tracker's tracks in the output, while VT_MAX_TRACKS
 * allows: same id as the track they came from, state VT_PIPE_HANDOVER, the flow
 * stage's box and mean flow; no geometry (its range filter ended with the track). */
static void vt__out_handovers(const vt_pipeline *p, vt_frame_out *out)
{
    int32_t i, n = out->n_tracks;
    for (i = 0; i < p->n_ho && n < VT_MAX_TRACKS; ++i, ++n) {
        vt_pipe_track *o = &out->tracks[n];
        o->id = p->ho_id[i];
        o->state = VT_PIPE_HANDOVER;
        o->box = p->ho_box[i];
        o->vx = p->ho_vx[i];
        o->vy = p->ho_vy[i];
        o->distance_mm = VT_UNKNOWN;
        o->ttc_ms = VT_UNKNOWN;
        o->warning = p->camera != NULL ? VT_FCW_NONE : VT_FCW_UNKNOWN;
        o->source = 0;
        o->ttc_points_q16 = VT_UNKNOWN;
        o->ttc_fused_q16 = VT_UNKNOWN;
    }
    out->n_tracks = n;
}

/* The overtaking stage on this frame (every frame: it compares consecutive ones); a
 * frame of another size restarts it. Its boxes are appended to out->boxes and
 * p->det.box from index n (while VT_MAX_BOXES allows; all counted in *n_in).
 * *fresh = 1 if one of them meets no track of the previous step. */
static vt_status vt__flow(vt_pipeline *p, const vt_image_u8 *frame, vt_frame_out *out, int32_t n,
                          int32_t *n_in, int32_t *fresh)
{
    int32_t i, k;
    vt_status s = vt_flow_step(p->flow_st, &p->cfg.flow, frame, &p->flow);
    *fresh = 0;
    if (s == VT_E_SIZE) {
        s = vt_flow_reset(p->flow_st);
        if (s == VT_OK) {
            s = vt_flow_step(p->flow_st, &p->cfg.flow, frame, &p->flow);
        }
    }
    if (s != VT_OK) {
        p->flow.n = 0;
        return s;
    }
    out->flow_ready = p->flow.ready;
    vt__ho_refresh(p);
    for (i = 0; i < p->flow.n; ++i) {
        const vt_box *b = &p->flow.hyp[i].box;
        if (p->flow.hyp[i].kind == VT_FLOW_KIND_HANDOVER) {
            continue; /* a hand-over is reported as its track, not as a detection */
        }
        for (k = 0; k < p->n_trk; ++k) {
            if (vt__inter(b, &p->tracks[k].box) > 0) {
                break;
            }
        }
        if (k == p->n_trk && !vt__ho_covers(p, b)) {
            *fresh = 1;
        }
        if (n < VT_MAX_BOXES) {
            p->det.box[n] = *b;
            out->boxes[n].box = *b;
            out->boxes[n].source = VT_SRC_FLOW;
            out->boxes[n].score = p->flow.hyp[i].cells;
            ++n;
        }
    }
    out->n_boxes = n;
    for (i = 0; i < p->flow.n; ++i) {
        *n_in += p->flow.hyp[i].kind != VT_FLOW_KIND_HANDOVER;
    }
    return VT_OK;
}

/* A box's area (inclusive), int64. */
static int64_t vt__area_of(const vt_box *a)
{
    return ((int64_t)a->right - a->left + 1) * ((int64_t)a->bottom - a->top + 1);
}

/* IoU(a, b) >= permille / 1000, exact in int64. */
static int32_t vt__iou_at_least(const vt_box *a, const vt_box *b, int32_t permille)
{
    int64_t in = vt__inter(a, b);
    return in * 1000 >= (int64_t)permille * (vt__area_of(a) + vt__area_of(b) - in);
}

/* IoU(e, a) > IoU(e, b), exactly: the two fractions compared as int64 cross products
 * (areas <= w h <= 2^22, config.h, so every product stays under 2^45; with e in the
 * frame and a, b tracker boxes, sides < 2^14 (tracker.c's bounds), under 2^52). */
static int32_t vt__iou_more(const vt_box *e, const vt_box *a, const vt_box *b)
{
    int64_t ia = vt__inter(e, a), ib = vt__inter(e, b);
    int64_t ua = vt__area_of(e) + vt__area_of(a) - ia, ub = vt__area_of(e) + vt__area_of(b) - ib;
    return ia * ub > ib * ua;
}

/* The vehicle model for the tracks the previous step left coasting (see
 * vt_pipeline_set_model_ws): their refined boxes appended at out->boxes[n..]
 * (while VT_MAX_BOXES allows; all counted in *n_in), *n_model of them. */
static void vt__model(vt_pipeline *p, const vt_image_u8 *frame, vt_frame_out *out, int32_t n,
                      int32_t *n_in, int32_t *n_model)
{
    const vt_model_cfg *mc0 = &p->cfg.model;
    vt_model_cfg mc;
    vt_model_search se;
    vt_model_result res;
    int32_t k, fits = 0, w, h, horizon;
    int64_t wpr;
    *n_model = 0;
    horizon = vt__horizon(p, frame->h);
    for (k = 0; k < p->n_trk && fits < p->cfg.model_fits; ++k) {
        const vt_box *b = &p->tracks[k].box;
        if (p->tracks[k].state != VT_TRACK_COASTING) {
            continue;
        }
        w = b->right - b->left + 1;
        h = b->bottom - b->top + 1;
        if (b->bottom <= horizon || w < 1 || h < 1) {
            continue;
        }
        se.roi.left = vt__clamp_i32(b->left - w / 2, 0, frame->w - 1);
        se.roi.top = vt__clamp_i32(b->top - h / 2, 0, frame->h - 1);
        se.roi.right = vt__clamp_i32(b->right + w / 2, 0, frame->w - 1);
        se.roi.bottom = vt__clamp_i32(b->bottom + h / 2, 0, frame->h - 1);
        if ((int64_t)(se.roi.right - se.roi.left + 1) * (se.roi.bottom - se.roi.top + 1) >
            VT_MODEL_MAX_ROI_PIXELS) {
            continue;
        }
        wpr = (int64_t)w * 65536 / (b->bottom - horizon);
        if (wpr < 1 || wpr > INT32_MAX) {
            continue;
        }
        mc = *mc0;
        mc.horizon_row = horizon;
        mc.width_per_row = (vt_q16)wpr;
        se.y_min = b->bottom - h / 4;
        se.y_max = b->bottom + h / 4;
        se.tracking = 1;
        se.pred.x = b->left + w / 2;
        se.pred.y = b->bottom;
        se.pred.w = w;
        se.pred.h = h;
        se.pred.wind = (mc.wind_min + mc.wind_max) / 2;
        se.pred.bump = (mc.bump_min + mc.bump_max) / 2;
        se.pred.roof = mc.roof_max / 2;
        se.sigma.x = w / 8;
        se.sigma.y = h / 8;
        se.sigma.w = w / 8;
        se.sigma.h = h / 8;
        se.sigma.wind = 5;
        se.sigma.bump = 5;
        se.sigma.roof = 5;
        ++fits; /* the bound counts attempts: a failed fit cost its GA too */
        out->model_fits = fits;
        if (vt_model_fit(p->model_ws, &mc, frame, &se, &res) != VT_OK ||
            res.fitness < p->cfg.model_min_fitness ||
            !vt__iou_at_least(&res.box, b, p->cfg.tracker.match_iou_permille)) {
            continue;
        }
        ++*n_in;
        ++*n_model;
        if (n < VT_MAX_BOXES) {
            p->det.box[n] = res.box;
            out->boxes[n].box = res.box;
            out->boxes[n].source = VT_SRC_MODEL;
            out->boxes[n].score = res.fitness;
            ++n;
        }
    }
    out->n_boxes = n;
}

/* The step behind the three entry points. road: the caller's fallback road (or
 * NULL); dets/n_dets: the caller's detections when ext is 1. */
static vt_status vt__step(vt_pipeline *p, const vt_image_u8 *frame, const vt_road_area *road,
                          const vt_box *dets, int32_t n_dets, int32_t ext, vt_frame_out *out)
{
    vt_status s;
    int32_t det_frame, run_lanes, lanes_ok = 0, n_boxes = 0, n_tracks = 0, n_ranges = 0, i;
    int32_t whole, n_in, fresh = 0, trk_det, n_model = 0;
    int32_t top_of[VT_MAX_BOXES]; /* per tracker box, for cfg.cnn_track_top: an ego box's
                                     reported CNN top or VT__TOP_EGO, else VT_UNKNOWN */
    const vt_box *boxes = p->det.box;
    if (frame->px == NULL) {
        return VT_E_ARG;
    }
    s = vt__check_dims(frame->w, frame->h, frame->stride, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    if (s != VT_OK) {
        return s;
    }
    if ((road != NULL && road->valid && road->height != frame->h) ||
        (p->camera != NULL && (p->camera->img_w != frame->w || p->camera->img_h != frame->h))) {
        return VT_E_SIZE;
    }
    /* A pipeline that was never initialised (or was corrupted) has no valid
     * configuration: refuse rather than run stages on garbage. */
    if (vt_pipeline_cfg_check(&p->cfg) != VT_OK || p->frame < 0) {
        return VT_E_ARG;
    }
    /* Checked here, not left to the tracker stage, so that nothing changes. */
    if (p->cfg.track && p->cfg.tracker.measurement != VT_MEAS_ROI_SEARCH &&
        p->tracker.edge_ws == NULL) {
        return VT_E_ARG;
    }
    /* A classifier asked for (a model, or the classifier source) needs its
     * workspace and scorer attached (vt_pipeline_set_cls_ws). */
    whole = p->cls_ws != NULL && (p->scorer.score != NULL || p->acf != NULL || p->cnn != NULL);
    if (!whole && (p->model != NULL || (p->cfg.sources & (VT_SRC_CLASSIFIER | VT_SRC_EGO)) != 0)) {
        return VT_E_ARG;
    }
    if (((p->cfg.sources & VT_SRC_FLOW) != 0 && p->flow_st == NULL) ||
        ((p->cfg.sources & VT_SRC_MODEL) != 0 && p->model_ws == NULL)) {
        return VT_E_ARG;
    }
    det_frame = ext || (p->cfg.sources != 0 && (p->frame % p->cfg.detect_every) == 0);
    run_lanes = !ext && p->cfg.road_policy != VT_ROAD_FIXED &&
                ((det_frame && p->cfg.sources != 0) || p->cfg.lanes_every_frame);

    out->frame = p->frame;
    out->detection_frame = det_frame;
    out->lanes_ran = run_lanes;
    out->lane_status = VT_OK;
    out->road_source = VT_ROAD_SRC_NONE;
    out->road.valid = 0;
    out->road.height = frame->h;
    out->n_hyp = 0;
    out->n_boxes = 0;
    out->n_boxes_in = 0;
    out->flow_ready = 0;
    out->hood_row = -1;
    out->model_fits = 0;
    out->n_tracks = 0;
    memset(&out->lanes, 0, sizeof(out->lanes));
    for (i = 0; i < VT_MAX_BOXES; ++i) {
        top_of[i] = VT_UNKNOWN;
    }

    if (run_lanes) {
        out->lane_status = vt_lane_detect(&p->lane, &p->cfg.lane, frame, &out->lanes, &out->road);
        lanes_ok = out->lane_status == VT_OK;
        /* The horizon of the whole-road detector and the vehicle model: the lane
         * stage's own vanishing row (the two ego lines meeting inside its plausible
         * rows, vp_known), in input rows (vp_y + 1/2) scale - 1/2 rounded half up,
         * held while the lanes are lost (the camera's pitch changes slowly). */
        if (lanes_ok && out->lanes.vp_known && out->lanes.scale >= 1 &&
            out->lanes.scale <= VT_LANE_MAX_SCALE) {
            p->horizon_y = vt__clamp_i32((2 * out->lanes.vp_y + 1) * out->lanes.scale >> 1,
                                         -VT_MAX_HEIGHT, VT_MAX_HEIGHT);
            p->horizon_known = 1;
        }
    }
    if (ext) {
        boxes = dets;
        n_boxes = n_dets;
        for (i = 0; i < n_dets && i < VT_MAX_BOXES; ++i) {
            out->boxes[i].box = dets[i];
            out->boxes[i].source = VT_SRC_EXTERNAL;
            out->boxes[i].score = VT_UNKNOWN;
        }
        out->n_boxes = i;
    } else if (det_frame && whole) {
        int32_t n_ego = 0;
        s = VT_OK;
        if ((p->cfg.sources & VT_SRC_EGO) != 0) {
            s = vt__detect_ego(p, frame, road, out, lanes_ok, VT_SRC_EGO);
            n_ego = p->det.n_boxes;
        }
        if (s == VT_OK) {
            /* with the ego detector, a caller's road is its road (the fixed one of the
             * policy); the whole-road detector keeps the camera road */
            s = vt__detect_whole(p, frame, (p->cfg.sources & VT_SRC_EGO) != 0 ? NULL : road, out, n_ego,
                                 top_of);
        }
        if (s != VT_OK) {
            out->n_boxes = 0;
            p->frame = vt__next_frame(p->frame);
            return s;
        }
        n_boxes = p->det.n_boxes;
    } else if (det_frame) {
        s = vt__detect_ego(p, frame, road, out, lanes_ok, VT_SRC_SHADOW);
        if (s != VT_OK) {
            p->frame = vt__next_frame(p->frame);
            return s;
        }
        n_boxes = p->det.n_boxes;
    } else if (lanes_ok && out->road.valid) {
        out->road_source = VT_ROAD_SRC_LANES; /* lanes every frame: report their road */
    } else {
        out->road.valid = 0;
    }
    out->n_boxes_in = n_boxes;
    trk_det = det_frame;
    if ((p->cfg.sources & (VT_SRC_FLOW | VT_SRC_MODEL)) != 0) {
        /* On a frame with the caller's boxes, the flow and model boxes go after the
         * copied ones. */
        n_in = n_boxes;
        if (ext) {
            boxes = p->det.box;
            for (i = 0; i < out->n_boxes; ++i) {
                p->det.box[i] = dets[i];
            }
        }
        if ((p->cfg.sources & VT_SRC_FLOW) != 0) {
            s = vt__flow(p, frame, out, out->n_boxes, &n_in, &fresh);
            if (s != VT_OK) {
                p->frame = vt__next_frame(p->frame);
                return s;
            }
        }
        if ((p->cfg.sources & VT_SRC_MODEL) != 0 && p->cfg.track) {
            vt__model(p, frame, out, out->n_boxes, &n_in, &n_model);
        }
        out->n_boxes_in = n_in;
        n_boxes = out->n_boxes;
        if (!det_frame && (fresh || n_model > 0)) {
            trk_det = 1; /* an overtaking vehicle no track covers, or a refined track */
        } else if (!det_frame) {
            n_boxes = 0;
        }
        if (p->n_ho > 0) {
            /* A handed-over vehicle keeps its one id: its boxes do not reach the tracker
             * (they stay listed in out->boxes). */
            int32_t j = 0;
            for (i = 0; i < n_boxes; ++i) {
                if (!vt__ho_covers(p, &p->det.box[i])) {
                    top_of[j] = top_of[i];
                    p->det.box[j++] = p->det.box[i];
                }
            }
            n_boxes = j;
        }
    }
    s = VT_OK;
    if (p->cfg.track) {
        /* in range (vt__horizon): the call cannot fail */
        (void)vt_tracker_set_horizon(&p->tracker, 1, vt__horizon(p, frame->h));
        s = vt_tracker_step(&p->tracker, &p->cfg.tracker, frame, trk_det, boxes, n_boxes,
                            p->tracks, VT_MAX_TRACKS, &n_tracks);
    }
    p->frame = vt__next_frame(p->frame);
    if (s != VT_OK && s != VT_E_CAPACITY) {
        return s;
    }
    if (p->cfg.track) {
        vt__ho_history(p);
        if (p->cfg.handover && (p->cfg.sources & VT_SRC_FLOW) != 0) {
            vt__handover(p, frame, &n_tracks);
        }
    }
    p->n_trk = n_tracks;
    p->n_ttc = 0;
    if (p->ttc_st != NULL && p->cfg.track) {
        /* Before the range stage, whose warning takes it. Capacity (more live tracks than
         * VT_TTC_TRACKS) leaves the rest unknown; the tracker's tracks always pass
         * vt_ttc_step's checks, so any other error is a bug worth returning. */
        vt_status st = vt_ttc_step(p->ttc_st, &p->cfg.ttc, frame, p->tracks, n_tracks,
                                   p->ttc_out, VT_MAX_TRACKS, &p->n_ttc);
        if (st != VT_OK && st != VT_E_CAPACITY) {
            p->n_ttc = 0;
            s = st;
        }
    }
    if (p->camera != NULL && p->cfg.track) {
        vt_status sg = vt__geometry(p, frame, out, lanes_ok, n_tracks, &n_ranges);
        if (sg != VT_OK && sg != VT_E_CAPACITY) {
            n_ranges = 0;
            s = sg;
        }
    }
    vt__out_tracks(p, n_tracks, n_ranges, out);
    vt__out_handovers(p, out);
    vt__track_sources(p, out);
    /* a caller's boxes (ext) are never reported with a CNN box */
    vt__track_tops(p, n_tracks, p->det.box, top_of,
                   p->cfg.cnn_track_top && !ext ? (n_boxes < VT_MAX_BOXES ? n_boxes : VT_MAX_BOXES) : 0, out);
    return s;
}

vt_status vt_pipeline_step(vt_pipeline *p, const vt_image_u8 *frame, vt_frame_out *out)
{
    if (p == NULL || frame == NULL || out == NULL) {
        return VT_E_ARG;
    }
    return vt__step(p, frame, NULL, NULL, 0, 0, out);
}

vt_status vt_pipeline_step_road(vt_pipeline *p, const vt_image_u8 *frame,
                                const vt_road_area *road, vt_frame_out *out)
{
    if (p == NULL || frame == NULL || out == NULL) {
        return VT_E_ARG;
    }
    return vt__step(p, frame, road, NULL, 0, 0, out);
}

vt_status vt_pipeline_step_dets(vt_pipeline *p, const vt_image_u8 *frame, const vt_box *dets,
                                int32_t n_dets, vt_frame_out *out)
{
    if (p == NULL || frame == NULL || out == NULL || n_dets < 0 || (dets == NULL && n_dets > 0)) {
        return VT_E_ARG;
    }
    return vt__step(p, frame, NULL, dets, n_dets, 1, out);
}
