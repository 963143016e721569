/* determinism_stages.c -- the determinism matrix's second run (issue 11, item 6):
 * the stages firmware_demo/main.c does not run yet, on the firmware's three real
 * KITTI frames (firmware_demo/clip_data.h, 640 x 256 gray), each folded into an
 * FNV-1a 32 digest of its integer outputs:
 *   classify  HOG blocks of a band, the SVM scores of every window on its cell
 *             grid (vt_hog_scan), GIST descriptors and MLP scores of boxes;
 *   fulldet   whole-road detection with the HOG scorer on the camera road: the
 *             boxes after NMS, their scores and counters;
 *   flow      three frames of vt_flow_step: every cell's vector, flag and SAD,
 *             and the overtaking hypotheses; a hand-over seed followed;
 *   model     the GA (vt_model_fit) on a box of frame 0, detection then
 *             tracking: the best parameters, fitness, and every individual of
 *             the last generation;
 *   camera    distances of the fulldet boxes, the pitch filter over vanishing
 *             rows, and the range stage (distance, rate, TTC, FCW) over 34
 *             frames of a synthetic approaching vehicle.
 * It prints `stage NAME 0xDIGEST` per stage (and a few readable lines), then
 * `done`. Written against firmware_demo/board.h, so the same file runs on the
 * host (tests/c/board_host.c) under every compiler and flag set and on the
 * Cortex-M3 / M7 images under QEMU (firmware_demo/board.c); the test compares
 * every `stage` line. Built with -DVT_MAX_WIDTH=640 -DVT_MAX_HEIGHT=256 so the
 * states fit the boards' 4 MB of RAM; large states are static (8 KB stack). */
#include <stdint.h>
#include <string.h>
#include "board.h"
#include "clip_data.h"
#include "vehtrack/camera.h"
#include "vehtrack/classify.h"
#include "vehtrack/flow.h"
#include "vehtrack/fulldet.h"
#include "vehtrack/vehicle_model.h"
#include "vehtrack/windows.h"

#define FNV_BASIS 2166136261u
#define FNV_PRIME 16777619u

static uint32_t g_fail;       /* a call that must succeed did not          */
static uint32_t g_stage_fail; /* ... in the current stage (named in a line) */

static uint32_t fnv_u8(uint32_t h, uint8_t b)
{
    return (h ^ b) * FNV_PRIME;
}

/* little-endian bytes, whatever the target's byte order */
static uint32_t fnv_u32(uint32_t h, uint32_t v)
{
    h = fnv_u8(h, (uint8_t)(v & 0xFFu));
    h = fnv_u8(h, (uint8_t)((v >> 8) & 0xFFu));
    h = fnv_u8(h, (uint8_t)((v >> 16) & 0xFFu));
    return fnv_u8(h, (uint8_t)(v >> 24));
}

static uint32_t fnv_s32(uint32_t h, int32_t v)
{
    return fnv_u32(h, (uint32_t)v);
}

static uint32_t fnv_st(uint32_t h, vt_status s)
{
    if (s != VT_OK) {
        g_fail = 1;
        g_stage_fail = 1;
    }
    return fnv_s32(h, (int32_t)s);
}

static uint32_t fnv_box(uint32_t h, const vt_box *b)
{
    h = fnv_s32(h, b->left);
    h = fnv_s32(h, b->top);
    h = fnv_s32(h, b->right);
    return fnv_s32(h, b->bottom);
}

static void line_stage(const char *name, uint32_t h)
{
    fw_line_str("stage ");
    fw_line_str(name);
    fw_line_str(" ");
    fw_line_hex32(h);
    fw_line_end();
    if (g_stage_fail) {
        fw_line_str("status_error ");
        fw_line_str(name);
        fw_line_end();
        g_stage_fail = 0;
    }
}

static void line_kv(const char *name, int32_t a, int32_t b, int32_t c, int32_t d)
{
    fw_line_str(name);
    fw_line_str(" ");
    fw_line_s32(a);
    fw_line_str(" ");
    fw_line_s32(b);
    fw_line_str(" ");
    fw_line_s32(c);
    fw_line_str(" ");
    fw_line_s32(d);
    fw_line_end();
}

static vt_image_u8 frame(int32_t f)
{
    vt_image_u8 img;
    img.px = fw_clip[f];
    img.w = FW_CLIP_W;
    img.h = FW_CLIP_H;
    img.stride = FW_CLIP_W;
    return img;
}

/* ------------------------------------------------------------------ classify */
static vt_hog_ws g_hog;
static vt_gist_ws g_gist;
static vt_cls_box_ws g_box_ws;
static int32_t g_scores[80 * 8];
static uint16_t g_desc[VT_CLS_MAX_DIM];

static void run_classify(void)
{
    const vt_svm_model *m = NULL;
    const vt_mlp_model *mlp = NULL;
    vt_image_u8 band = frame(0), crop;
    uint32_t h = FNV_BASIS;
    int32_t i, n = 0, ncx, ncy, score = 0, hits = 0;
    static const vt_box boxes[4] = {{250, 120, 330, 190}, {0, 100, 63, 163}, {400, 130, 460, 180},
                                    {100, 150, 131, 181}};
    /* rows 96..191 of frame 0: the road band where the vehicles are */
    band.px = fw_clip[0] + 96 * FW_CLIP_W;
    band.h = 96;
    h = fnv_st(h, vt_svm_default_model(VT_DESC_HOG, &m));
    h = fnv_st(h, vt_hog_prepare(&g_hog, &band));
    for (i = 0; i < g_hog.cells_y - 1; i++) { /* the blocks themselves */
        int32_t j, k;
        for (j = 0; j < g_hog.cells_x - 1; j++) {
            for (k = 0; k < VT_HOG_BLOCK_LEN; k++) {
                h = fnv_u32(h, g_hog.blocks[i][j][k]);
            }
        }
    }
    ncx = g_hog.cells_x - m->win_w / VT_CLS_CELL + 1;
    ncy = g_hog.cells_y - m->win_h / VT_CLS_CELL + 1;
    h = fnv_st(h, vt_hog_scan(&g_hog, m, 0, 0, ncx, ncy, g_scores, (int32_t)(sizeof g_scores / sizeof g_scores[0])));
    for (i = 0; i < ncx * ncy; i++) {
        h = fnv_s32(h, g_scores[i]);
        hits += g_scores[i] >= m->threshold_q16;
    }
    line_kv("classify_windows", ncx, ncy, hits, 0);
    /* GIST of a 64x64 crop, and box scores with the SVMs and the MLP */
    crop = frame(0);
    crop.px = fw_clip[0] + 120 * FW_CLIP_W + 250;
    crop.w = 64;
    crop.h = 64;
    h = fnv_st(h, vt_gist_prepare(&g_gist, &crop));
    h = fnv_st(h, vt_gist_descriptor(&g_gist, 0, 0, 64, 64, g_desc, VT_CLS_MAX_DIM, &n));
    for (i = 0; i < n; i++) {
        h = fnv_u32(h, g_desc[i]);
    }
    h = fnv_st(h, vt_mlp_default_model(&mlp));
    for (i = 0; i < 4; i++) {
        vt_image_u8 f0 = frame(0);
        h = fnv_st(h, vt_classify_box(&g_box_ws, m, &f0, &boxes[i], &score));
        h = fnv_s32(h, score);
        h = fnv_st(h, vt_classify_box_mlp(&g_box_ws, mlp, &f0, &boxes[i], &score));
        h = fnv_s32(h, score);
    }
    line_stage("classify", h);
}

/* ------------------------------------------------------------------ fulldet */
static vt_fulldet_state g_fd;
static vt_fulldet_result g_fd_out;
static vt_road_area g_road;
static vt_hog_scorer g_sc;
static vt_camera_cfg g_cam;

static void run_fulldet(void)
{
    vt_fulldet_cfg cfg;
    vt_camera_min cam;
    vt_window_scorer sc;
    const vt_svm_model *m = NULL;
    vt_image_u8 img = frame(0);
    uint32_t h = FNV_BASIS;
    int32_t i;
    /* the clip's camera (KITTI's, principal point moved by the 300, 118 crop) */
    cam.fx_q4 = 16 * 721;
    cam.horizon_y = 172 - 118;
    cam.height_mm = 1650;
    cam.hood_y = FW_CLIP_H;
    h = fnv_st(h, vt_fulldet_cfg_default(&cfg));
    cfg.win.levels = 3; /* 32..180 px vehicles: enough for the clip, a third of the cost */
    h = fnv_st(h, vt_road_from_camera(&cfg.win, &cam, img.w, img.h, &g_road));
    h = fnv_st(h, vt_svm_default_model(VT_DESC_HOG, &m));
    h = fnv_st(h, vt_hog_scorer_init(&g_sc, m));
    sc.level = vt_hog_scorer_level;
    sc.score = vt_hog_scorer_score;
    sc.ctx = &g_sc;
    h = fnv_st(h, vt_fulldet(&g_fd, &cfg, &cam, &img, &g_road, &sc, &g_fd_out));
    h = fnv_s32(h, g_fd_out.n_boxes);
    h = fnv_s32(h, g_fd_out.n_windows);
    h = fnv_s32(h, g_fd_out.n_windows_dropped);
    h = fnv_s32(h, g_fd_out.n_window_hits);
    h = fnv_s32(h, g_fd_out.n_shadow);
    h = fnv_s32(h, g_fd_out.n_cand);
    for (i = 0; i < g_fd_out.n_boxes; i++) {
        h = fnv_box(h, &g_fd_out.box[i].box);
        h = fnv_s32(h, g_fd_out.box[i].score);
        h = fnv_s32(h, g_fd_out.box[i].source);
    }
    line_kv("fulldet", g_fd_out.n_boxes, g_fd_out.n_windows, g_fd_out.n_window_hits, g_fd_out.n_shadow);
    line_stage("fulldet", h);
}

/* --------------------------------------------------------------------- flow */
static vt_flow_state g_flow;
static vt_flow_result g_flow_out;

static void run_flow(void)
{
    vt_flow_cfg cfg;
    uint32_t h = FNV_BASIS;
    int32_t f, i, id = 0, hyps = 0, accepted = 0;
    vt_box seed = {20, 110, 120, 190};
    h = fnv_st(h, vt_flow_cfg_default(&cfg));
    cfg.sides = VT_FLOW_SIDE_BOTH;
    cfg.min_age = 1;
    h = fnv_st(h, vt_flow_init(&g_flow));
    for (f = 0; f < FW_CLIP_N; f++) {
        vt_image_u8 img = frame(f);
        int32_t side;
        h = fnv_st(h, vt_flow_step(&g_flow, &cfg, &img, &g_flow_out));
        h = fnv_s32(h, g_flow_out.ready);
        h = fnv_s32(h, g_flow_out.n);
        h = fnv_s32(h, g_flow_out.dropped);
        h = fnv_s32(h, g_flow_out.cells_total);
        h = fnv_s32(h, g_flow_out.cells_computed);
        h = fnv_s32(h, g_flow_out.cells_accepted);
        accepted += g_flow_out.cells_accepted;
        for (side = 0; side < 2 && g_flow_out.ready; side++) { /* every cell's vector */
            int32_t c, nc = g_flow.gw[side] * g_flow.gh[side];
            for (c = 0; c < nc && c < VT_FLOW_MAX_CELLS; c++) {
                int32_t k = side * VT_FLOW_MAX_CELLS + c;
                h = fnv_s32(h, g_flow.dx[k]);
                h = fnv_s32(h, g_flow.dy[k]);
                h = fnv_u32(h, g_flow.flag[k]);
                h = fnv_u32(h, g_flow.flag[k] & VT_FLOW_CELL_COMPUTED ? g_flow.sad[k] : 0u);
            }
        }
        for (i = 0; i < g_flow_out.n; i++) {
            const vt_flow_hyp *y = &g_flow_out.hyp[i];
            h = fnv_box(h, &y->box);
            h = fnv_s32(h, y->side);
            h = fnv_s32(h, y->kind);
            h = fnv_s32(h, y->id);
            h = fnv_s32(h, y->cells);
            h = fnv_s32(h, y->flow_x);
            h = fnv_s32(h, y->flow_y);
            h = fnv_s32(h, y->age);
            h = fnv_s32(h, y->cy);
        }
        hyps += g_flow_out.n;
        if (f == 0) { /* a hand-over track, followed over the next frames */
            h = fnv_st(h, vt_flow_seed(&g_flow, &cfg, &seed, &id));
            h = fnv_s32(h, id);
        }
    }
    line_kv("flow", hyps, accepted, id, 0);
    line_stage("flow", h);
}

/* ---------------------------------------------------------- vehicle model (GA) */
static vt_model_ws g_mws;

static void run_model(void)
{
    vt_model_cfg cfg;
    vt_model_search se;
    vt_model_result res;
    vt_image_u8 img = frame(0);
    uint32_t h = FNV_BASIS;
    int32_t pass, i;
    h = fnv_st(h, vt_model_cfg_default(&cfg));
    /* the road from the clip's camera: a 1.8 m wide car is 0 px at the horizon
     * (row 54) and ~150 px at the bottom row */
    h = fnv_st(h, vt_model_cfg_road(&cfg, 100, 38, 255, 165));
    memset(&se, 0, sizeof se);
    se.roi.left = 200;
    se.roi.top = 90;
    se.roi.right = 420;
    se.roi.bottom = 220;
    se.y_min = 150;
    se.y_max = 215;
    for (pass = 0; pass < 2; pass++) {
        vt_status s = vt_model_fit(&g_mws, &cfg, &img, &se, &res);
        h = fnv_s32(h, (int32_t)s);
        if (s != VT_OK && s != VT_E_SINGULAR) {
            g_fail = 1;
        }
        h = fnv_s32(h, res.best.x);
        h = fnv_s32(h, res.best.y);
        h = fnv_s32(h, res.best.w);
        h = fnv_s32(h, res.best.h);
        h = fnv_s32(h, res.best.wind);
        h = fnv_s32(h, res.best.bump);
        h = fnv_s32(h, res.best.roof);
        h = fnv_s32(h, res.fitness);
        h = fnv_s32(h, res.evaluations);
        h = fnv_box(h, &res.box);
        h = fnv_u32(h, g_mws.rng);
        for (i = 0; i < g_mws.n; i++) { /* the last generation */
            const vt_model_params *p = &g_mws.pop[g_mws.cur * VT_MODEL_MAX_POP + i];
            h = fnv_s32(h, p->x);
            h = fnv_s32(h, p->y);
            h = fnv_s32(h, p->w);
            h = fnv_s32(h, p->h);
            h = fnv_s32(h, p->wind);
            h = fnv_s32(h, p->bump);
            h = fnv_s32(h, p->roof);
            h = fnv_s32(h, g_mws.fit[g_mws.cur * VT_MODEL_MAX_POP + i]);
        }
        line_kv(pass == 0 ? "model_detect" : "model_track", res.best.x, res.best.y, res.best.w, res.fitness);
        /* then track it: the prediction is the detection */
        se.tracking = 1;
        se.pred = res.best;
        se.sigma.x = 4;
        se.sigma.y = 3;
        se.sigma.w = 4;
        se.sigma.h = 4;
        se.sigma.wind = 5;
        se.sigma.bump = 5;
        se.sigma.roof = 3;
    }
    line_stage("model", h);
}

/* ------------------------------------------------------------------- camera */
static vt_range_state g_range;

static void run_camera(void)
{
    vt_range_cfg rc;
    vt_pitch_state ps;
    uint32_t h = FNV_BASIS;
    int32_t i, f, warn_frame = -1;
    h = fnv_st(h, vt_camera_cfg_default(&g_cam));
    g_cam.img_w = FW_CLIP_W;
    g_cam.img_h = FW_CLIP_H;
    g_cam.cx -= 300 * VT_Q16_ONE;
    g_cam.cy -= 118 * VT_Q16_ONE;
    for (i = 0; i < g_fd_out.n_boxes; i++) { /* distances of the detections */
        vt_distance d;
        h = fnv_st(h, vt_camera_box_distance(&g_cam, 0, &g_fd_out.box[i].box, &d));
        h = fnv_s32(h, d.flags);
        h = fnv_s32(h, d.distance);
        h = fnv_s32(h, d.dist_near);
        h = fnv_s32(h, d.dist_far);
        h = fnv_s32(h, d.sigma);
        h = fnv_s32(h, d.dist_width);
    }
    for (i = 60; i < 256; i += 7) { /* the distance of every 7th row */
        vt_q16 d = 0;
        int32_t valid = 0;
        h = fnv_st(h, vt_camera_row_distance(&g_cam, 1000, i * VT_Q16_ONE, &d, &valid));
        h = fnv_s32(h, d);
        h = fnv_s32(h, valid);
    }
    h = fnv_st(h, vt_pitch_init(&ps, &g_cam));
    for (i = 0; i < 30; i++) { /* vanishing rows wobbling about the horizon, a jump at 20 */
        vt_q16 vp = (54 + (i % 5) - 2 + (i >= 20 ? 9 : 0)) * VT_Q16_ONE + i * 997;
        h = fnv_st(h, vt_pitch_update(&ps, &g_cam, i % 7 != 3, vp));
        h = fnv_s32(h, ps.tan_pitch);
        h = fnv_s32(h, ps.flag);
        h = fnv_s32(h, ps.outliers);
    }
    /* a car 1.8 m wide closing from 30 m at 8 m/s, seen at 10 frames/s */
    h = fnv_st(h, vt_range_cfg_default(&rc));
    h = fnv_st(h, vt_range_init(&g_range));
    for (f = 0; f < 34; f++) { /* to 3.6 m */
        vt_track_out t;
        vt_range_out out[2];
        int32_t n_out = 0;
        int32_t dist_mm = 30000 - f * 800;
        int32_t fx = 721, cy = 172 - 118, w;
        int32_t bottom = cy + (int32_t)((int64_t)fx * 1650 / dist_mm);
        w = (int32_t)((int64_t)fx * 1800 / dist_mm);
        t.id = 7;
        t.state = VT_TRACK_CONFIRMED;
        t.box.left = 320 - w / 2 + (f % 3) - 1;
        t.box.right = t.box.left + w - 1;
        t.box.bottom = bottom < FW_CLIP_H - 2 ? bottom : FW_CLIP_H - 2;
        t.box.top = t.box.bottom - (w * 3) / 4;
        t.vx = 0;
        t.vy = 0;
        h = fnv_st(h, vt_range_step(&g_range, &rc, &g_cam, 0, 12 * VT_Q16_ONE, &t, 1, out, 2, &n_out));
        for (i = 0; i < n_out; i++) {
            h = fnv_s32(h, out[i].id);
            h = fnv_s32(h, out[i].flags);
            h = fnv_s32(h, out[i].fcw);
            h = fnv_s32(h, out[i].lead_class);
            h = fnv_s32(h, out[i].distance);
            h = fnv_s32(h, out[i].sigma);
            h = fnv_s32(h, out[i].dist_width);
            h = fnv_s32(h, out[i].dist_filt);
            h = fnv_s32(h, out[i].rate);
            h = fnv_s32(h, out[i].accel);
            h = fnv_s32(h, out[i].ttc_dist);
            h = fnv_s32(h, out[i].ttc_scale);
            if ((out[i].fcw & VT_FCW_ONSET) && warn_frame < 0) {
                warn_frame = f;
            }
        }
    }
    line_kv("camera_fcw", warn_frame, 0, 0, 0);
    line_stage("camera", h);
}

int main(void)
{
    fw_line_str("determinism_stages ");
    fw_line_u32(FW_CLIP_W);
    fw_line_str("x");
    fw_line_u32(FW_CLIP_H);
    fw_line_end();
    run_classify();
    run_fulldet();
    run_flow();
    run_model();
    run_camera();
    fw_line_str(g_fail ? "failed" : "done");
    fw_line_end();
    fw_exit(!g_fail);
    return 0;
}
