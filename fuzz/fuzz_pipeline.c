/* fuzz-requires: vehtrack/pipeline.h
 * fuzz_pipeline.c -- the whole per-frame system (vehtrack/pipeline.h, thesis
 * fig. 4.1: lanes -> road area -> detection -> tracking): a configuration
 * mutated from the defaults (its own fields and the stages' inside it), up to
 * four frames whose size may change between frames, through vt_pipeline_step,
 * vt_pipeline_step_road (any road area) and vt_pipeline_step_dets (any boxes,
 * counts past the limits), plus vt_pipeline_work_size and vt_fixed_road_area on
 * edge values; the block-scale TTC's state attached or not (vt_pipeline_set_ttc_ws),
 * its ttc_points_q16 VT_UNKNOWN or within (0, ttc_max]; a camera (the defaults) attached or
 * not, the fused TTC (ttc_fused_q16) VT_UNKNOWN or > 0, and without a camera the block-scale
 * one; the warning on the fused TTC (cfg.fcw_fused) in half of the inputs; in one input of four the built-in HOG SVM and the whole-road detector's workspace
 * (vt_pipeline_set_cls_ws), with the ego-lane detector beside it (VT_SRC_EGO) in half of
 * those: ego boxes come first; in another one of four the CNN detector instead (the firmware's model,
 * firmware_demo/cnn_data.h, from level 0 at a fuzzed threshold, its work buffer sometimes
 * short), whose boxes pass the hood rule (cfg.cnn_hood_min_width_mm, in the mutated tail):
 * every box kept is not one the rule drops, and no ego box and CNN box the tracker gets name the
 * same vehicle (the detector's NMS test between them fails), an ego box being reported as it
 * is or with a box it overlaps at IoU >= cfg.cnn_ego_iou_permille; the tracks are the
 * tracker's, only their tops moved by cfg.cnn_track_top's heights. fuzz.mk
 * builds this harness only where the header exists. */
#include "fuzz.h"
#include "vehtrack/pipeline.h"
#include "../firmware_demo/cnn_data.h"

static vt_pipeline g_p;
static vt_frame_out g_out;
static vt_road_area g_road;
static vt_box g_dets[300];
static vt_ttc_state g_ttc;
static vt_flow_state g_flow;
static vt_camera_cfg g_cam;
static vt_pipe_cls_ws g_cls;
static uint8_t g_cnn_work[1u << 20];

#ifdef PIPE_FUZZ_STATS /* -DPIPE_FUZZ_STATS: how often the CNN path runs (a harness check) */
#include <stdio.h>
#include <stdlib.h>
static long g_st[7];
static void st_print(void)
{
    fprintf(stderr, "stats: cnn_inputs %ld cnn_detect_ok %ld cnn_boxes %ld below_hood_kept %ld ego_beside_cnn %ld "
            "ego_reported_as_cnn_box %ld track_top_moved %ld\n", g_st[0], g_st[1], g_st[2], g_st[3], g_st[4],
            g_st[5], g_st[6]);
}
#define STAT(i, c) (g_st[i] += (c))
#else
#define STAT(i, c) ((void)0)
#endif

/* boxes' areas and overlap (inclusive), and c/windows.c's NMS test (IoU or containment
 * past its limit), written out again */
static int64_t area(const vt_box *a)
{
    return ((int64_t)a->right - a->left + 1) * ((int64_t)a->bottom - a->top + 1);
}

static int64_t overlap(const vt_box *a, const vt_box *b)
{
    const int64_t iw = (int64_t)(a->right < b->right ? a->right : b->right) - (a->left > b->left ? a->left : b->left) + 1;
    const int64_t ih = (int64_t)(a->bottom < b->bottom ? a->bottom : b->bottom) - (a->top > b->top ? a->top : b->top) + 1;
    return iw > 0 && ih > 0 ? iw * ih : 0;
}

static int same_vehicle(const vt_box *a, const vt_box *b, int32_t iou_pm, int32_t contain_pm)
{
    const int64_t inter = overlap(a, b), aa = area(a), ab = area(b);
    return inter > 0 && (inter * 1000 > (int64_t)iou_pm * (aa + ab - inter) ||
                         inter * 1000 > (int64_t)contain_pm * (aa < ab ? aa : ab));
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    vt_pipeline_cfg cfg;
    vt_image_u8 img;
    int32_t k, n, i, ww = 0, wh = 0;
    vt_status s;
    const vt_svm_model *model = NULL;
    int use_cnn = 0;
    vt_cnn_cfg ccfg = fw_cnn_cfg_synth;
    fz_status(vt_pipeline_cfg_default(&cfg));
    if (fz_u8(&f) & 1) {
        /* the pipeline's own fields (after the three stage configurations) */
        fz_mutate_i32s(&f, &cfg.fixed_road, sizeof cfg - offsetof(vt_pipeline_cfg, fixed_road));
    } else {
        fz_mutate_i32s(&f, &cfg, sizeof cfg);
    }
    if (fz_u8(&f) & 1) { /* the flow source on (its hand-over policy is in the mutated tail) */
        cfg.sources |= VT_SRC_FLOW;
    }
    if (fz_u8(&f) & 1) { /* the warning on the fused TTC (vt_range_step_fused inside the step) */
        cfg.fcw_fused = 1;
    }
    k = fz_u8(&f) & 3;
    if (k == 0) { /* the whole-road detector (a classifier), the ego one beside it or not */
        fz_status(vt_svm_default_model(VT_DESC_HOG, &model));
        cfg.sources |= VT_SRC_CLASSIFIER | ((fz_u8(&f) & 1) ? VT_SRC_EGO : 0);
    } else if (k == 1) { /* the CNN detector in its place */
        use_cnn = 1;
        cfg.sources |= VT_SRC_CLASSIFIER | ((fz_u8(&f) & 1) ? VT_SRC_EGO : 0);
        ccfg.thr_offset = fz_range(&f, -40, 8); /* low: many boxes, some on the frame's last rows */
        cfg.cnn_ego_iou_permille = fz_range(&f, 0, 1000);
    }
    cfg.cnn_track_top = fz_u8(&f) & 1;
    fz_status(vt_pipeline_cfg_check(fz_u8(&f) == 0xFF ? NULL : &cfg));
    fz_status(vt_camera_cfg_default(&g_cam));
    s = vt_pipeline_init(fz_u8(&f) == 0xFF ? NULL : &g_p, &cfg, (fz_u8(&f) & 1) ? &g_cam : NULL, model);
    fz_status(s);
    if (s == VT_OK && model != NULL) {
        fz_status(vt_pipeline_set_cls_ws(&g_p, &g_cls, NULL));
    }
#ifdef PIPE_FUZZ_STATS
    {
        static int once;
        if (!once) {
            once = 1;
            atexit(st_print);
        }
    }
#endif
    STAT(0, use_cnn);
    if (s == VT_OK && use_cnn) {
        /* a work buffer of the fuzzed size: short ones make the detection steps VT_E_CAPACITY */
        size_t wb = (size_t)fz_range(&f, 0, (int32_t)sizeof g_cnn_work);
        s = vt_pipeline_set_cnn(&g_p, &fw_cnn_model, &ccfg, g_cnn_work, fz_u8(&f) < 200 ? sizeof g_cnn_work : wb);
        fz_status(s);
        if (s == VT_OK) {
            s = vt_pipeline_set_cls_ws(&g_p, &g_cls, NULL);
            fz_status(s);
        }
    }
    fz_status(vt_pipeline_work_size(fz_edge(&f, 1920), fz_edge(&f, 1080), fz_edge(&f, VT_MAX_WIDTH),
                                    fz_edge(&f, VT_MAX_HEIGHT), fz_u8(&f) == 0xFF ? NULL : &ww, &wh));
    fz_status(vt_fixed_road_area(&cfg.fixed_road, fz_edge(&f, VT_MAX_WIDTH), fz_edge(&f, VT_MAX_HEIGHT),
                                 &g_road));
    if (s != VT_OK) {
        fz_close(&f);
        return 0;
    }
    fz_status(vt_pipeline_set_ttc_ws(fz_u8(&f) == 0xFF ? NULL : &g_p, (fz_u8(&f) & 1) ? &g_ttc : NULL));
    /* the flow state attached or not (with the flow bit, the reverse hand-over runs:
     * tracks seeded into flow and dropped from the tracker) */
    fz_status(vt_pipeline_set_flow_ws(&g_p, (fz_u8(&f) & 1) ? &g_flow : NULL));
    img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    n = 1 + (fz_u8(&f) & 3);
    for (k = 0; k < n; k++) {
        uint8_t how = fz_u8(&f) % 3u;
        if (k > 0 && fz_u8(&f) > 220) {
            img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
        }
        if (how == 0) {
            s = vt_pipeline_step(&g_p, &img, fz_u8(&f) == 0xFF ? NULL : &g_out);
        } else if (how == 1) {
            g_road.valid = fz_edge(&f, 1);
            g_road.y_top = fz_edge(&f, img.h);
            g_road.y_bottom = fz_edge(&f, img.h);
            g_road.height = fz_u8(&f) < 200 ? img.h : fz_edge(&f, img.h);
            for (i = 0; i < VT_MAX_HEIGHT; i += 1 + (fz_u8(&f) & 63)) {
                g_road.x_left[i] = (int16_t)fz_raw_i32(&f);
                g_road.x_right[i] = (int16_t)fz_raw_i32(&f);
                g_road.lane_width[i] = (int16_t)fz_raw_i32(&f);
            }
            s = vt_pipeline_step_road(&g_p, &img, fz_u8(&f) == 0xFF ? NULL : &g_road, &g_out);
        } else {
            int32_t nd = fz_u8(&f) < 230 ? (fz_u8(&f) & 7) : fz_edge(&f, 256);
            for (i = 0; i < nd && i < 300; i++) {
                g_dets[i].left = fz_range(&f, -8, 80);
                g_dets[i].top = fz_range(&f, -8, 60);
                g_dets[i].right = fz_near(&f, g_dets[i].left, -2, 40);
                g_dets[i].bottom = fz_near(&f, g_dets[i].top, -2, 40);
            }
            s = vt_pipeline_step_dets(&g_p, &img, fz_u8(&f) == 0xFF ? NULL : g_dets,
                                      nd > 300 ? 300 : nd, &g_out);
        }
        fz_status(s);
        if (s == VT_OK) {
            FZ_ASSERT(g_out.n_tracks >= 0 && g_out.n_tracks <= VT_MAX_TRACKS);
            FZ_ASSERT(g_out.n_boxes >= 0 && g_out.n_boxes <= VT_MAX_BOXES);
            for (i = 1; i < g_out.n_boxes; i++) { /* the ego boxes first */
                FZ_ASSERT(g_out.boxes[i].source != VT_SRC_EGO || g_out.boxes[i - 1].source == VT_SRC_EGO);
            }
            STAT(1, use_cnn && g_out.detection_frame);
            for (i = 0; use_cnn && g_out.detection_frame && i < g_out.n_boxes; i++) {
                /* no CNN box left that the hood rule drops (horizon_y: the detector's camera) */
                const vt_box *b = &g_out.boxes[i].box;
                STAT(2, g_out.boxes[i].source == VT_SRC_CLASSIFIER);
                const int32_t w = img.w, m = img.w / 64;
                const int32_t hood = (int32_t)(((int64_t)img.h * g_p.cfg.road_camera.hood_q16 + 32768) >> 16);
                const int64_t hz_num = (int64_t)img.h * g_p.cfg.road_camera.horizon_q16 + 32768;
                const int32_t hz = g_p.horizon_known ? g_p.horizon_y
                                                     : (int32_t)(hz_num >= 0 ? hz_num / 65536
                                                                             : -((-hz_num + 65535) / 65536));
                if (g_out.boxes[i].source == VT_SRC_CLASSIFIER && g_p.cfg.cnn_hood_min_width_mm > 0 &&
                    b->bottom > (hood < 1 ? 1 : hood) && b->left > m && b->right < w - 1 - m) {
                    STAT(3, 1);
                    FZ_ASSERT((int64_t)(b->right - b->left + 1) * g_p.cfg.road_camera.height_mm >=
                              (int64_t)g_p.cfg.cnn_hood_min_width_mm * (b->bottom - hz));
                }
            }
            for (i = 0; use_cnn && g_out.detection_frame && g_p.n_ho == 0 && i < g_out.n_boxes; i++) {
                /* the tracker's boxes (g_p.det, aligned with the reported ones while no
                 * hand-over filters them): an ego box there never pairs with a kept CNN box,
                 * and is reported as it is or with a CNN box it overlaps at IoU >= the limit */
                const vt_box *e = &g_p.det.box[i], *r = &g_out.boxes[i].box;
                int32_t j;
                if (g_out.boxes[i].source != VT_SRC_EGO) {
                    continue;
                }
                if (e->left != r->left || e->top != r->top || e->right != r->right || e->bottom != r->bottom) {
                    const int64_t in = overlap(e, r);
                    STAT(5, 1);
                    FZ_ASSERT(g_p.cfg.cnn_ego_iou_permille > 0 &&
                              in * 1000 >= (int64_t)g_p.cfg.cnn_ego_iou_permille * (area(e) + area(r) - in));
                }
                for (j = 0; j < g_out.n_boxes; j++) {
                    if (g_out.boxes[j].source == VT_SRC_CLASSIFIER) {
                        STAT(4, 1);
                        FZ_ASSERT(!same_vehicle(e, &g_p.det.box[j], g_p.cfg.fulldet.nms_iou_permille,
                                                g_p.cfg.fulldet.nms_contain_permille));
                    }
                }
            }
            for (i = 0; i < g_out.n_tracks; i++) {
                vt_q16 t = g_out.tracks[i].ttc_points_q16;
                FZ_ASSERT(t == VT_UNKNOWN || (g_p.ttc_st != NULL && t > 0 && t <= g_p.cfg.ttc.ttc_max));
                FZ_ASSERT(g_p.camera != NULL ? (g_out.tracks[i].ttc_fused_q16 == VT_UNKNOWN ||
                                                g_out.tracks[i].ttc_fused_q16 > 0)
                                             : g_out.tracks[i].ttc_fused_q16 == t);
            }
            for (i = 0; g_p.cfg.track && i < g_p.n_trk && i < g_out.n_tracks; i++) {
                /* cfg.cnn_track_top: the tracker's track with only its top moved, by the
                 * height its id holds in the table (0: none), which holds the live tracks */
                const vt_box *o = &g_out.tracks[i].box, *t = &g_p.tracks[i].box;
                const int32_t q = g_p.top_q8[i];
                FZ_ASSERT(g_p.n_top == g_p.n_trk && g_p.top_id[i] == g_out.tracks[i].id &&
                          g_p.tracks[i].id == g_out.tracks[i].id);
                FZ_ASSERT(o->left == t->left && o->right == t->right && o->bottom == t->bottom);
                FZ_ASSERT(q >= 0 && (q == 0 || g_p.cfg.cnn_track_top));
                if (q == 0) {
                    FZ_ASSERT(o->top == t->top);
                } else {
                    const int64_t h = ((int64_t)(t->right - t->left + 1) * q + 128) >> 8;
                    STAT(6, o->top != t->top);
                    FZ_ASSERT(o->top == t->bottom - (h < 1 ? 1 : h) + 1);
                }
            }
        }
    }
    fz_close(&f);
    return 0;
}
