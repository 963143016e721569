/* callgrind_main.c -- host driver for `make bench`: runs each benchmark stage once on
 * a frame read from a binary PGM, so `valgrind --tool=callgrind` can count the
 * instructions of each stage on its own.
 *
 *   callgrind_main --list                     stage names, one per line
 *   callgrind_main FRAME.pgm NAME[:UNITS]...  run the named stages in that order
 *
 * Each stage is three functions: bench_setup_NAME prepares inputs (not measured),
 * bench_run_NAME does exactly the work one run of the Python stage of the same name
 * in bench/bench.py does, and bench_digest_NAME folds the outputs into a checksum.
 * bench/callgrind.py reads the inclusive cost of bench_run_NAME: the stages are
 * only ever called through the table's function pointers, chosen from argv at run
 * time, so the compiler cannot inline them into main and each keeps its own symbol.
 *
 * Per stage it prints `stage NAME units N status S digest 0xXXXXXXXX`; the digest
 * (sum over outputs of (uint32)v[i] * (i + 1), mod 2^32) equals the one bench.py
 * computes from the same C through cffi, which shows the callgrind run did the
 * same work on the same data. Random inputs come from xorshift32 with the seeds
 * bench.py uses.
 *
 * To add a stage: write its setup/run/digest functions below and add one line to
 * `stages[]`; add the Python twin to bench/bench.py's registry under the same name.
 * This file is a host tool, not part of the core: it may use stdio. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vehtrack/vehtrack.h"

#define BENCH_MAX_UNITS 100000

typedef struct {
    vt_image_u8 frame;
    int32_t units;
    int32_t status; /* the first negative status a run saw, else VT_OK */
} bench_ctx;

typedef struct {
    const char *name;
    int32_t default_units;
    void (*setup)(bench_ctx *ctx);
    void (*run)(bench_ctx *ctx);
    uint32_t (*digest)(const bench_ctx *ctx);
} bench_stage;

/* Frame and output buffers, static like the library's own memory. */
static uint8_t g_frame[VT_MAX_WIDTH * VT_MAX_HEIGHT];
static int16_t g_s16[VT_MAX_WIDTH * VT_MAX_HEIGHT];
static uint8_t g_u8[((VT_MAX_WIDTH + 1) / 2) * ((VT_MAX_HEIGHT + 1) / 2)];
static uint32_t g_u32[(VT_MAX_WIDTH + 1) * (VT_MAX_HEIGHT + 1)];
static int32_t g_arg[BENCH_MAX_UNITS][4]; /* per-unit inputs: rectangles, patch corners, angles */
static uint32_t g_out[2 * BENCH_MAX_UNITS]; /* per-unit outputs (negative codes mod 2^32) */

static vt_image_s16 g_s16_view;
static vt_image_u8_mut g_u8_view;
static vt_image_u32 g_u32_view;

/* ------------------------------------------------------------------ helpers */
static uint32_t xorshift32(uint32_t *s)
{
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *s = x;
    return x;
}

static void note_status(bench_ctx *ctx, vt_status s)
{
    if (s < 0 && ctx->status == VT_OK) {
        ctx->status = s;
    }
}

static uint32_t digest_u32(const uint32_t *v, size_t n)
{
    uint32_t acc = 0;
    size_t i;
    for (i = 0; i < n; ++i) {
        acc += v[i] * (uint32_t)(i + 1);
    }
    return acc;
}

static void setup_s16(bench_ctx *ctx)
{
    g_s16_view.px = g_s16;
    g_s16_view.w = ctx->frame.w;
    g_s16_view.h = ctx->frame.h;
    g_s16_view.stride = ctx->frame.w;
}

static uint32_t digest_s16(const bench_ctx *ctx)
{
    uint32_t acc = 0;
    size_t i, n = (size_t)ctx->frame.w * (size_t)ctx->frame.h;
    for (i = 0; i < n; ++i) {
        acc += (uint32_t)(int32_t)g_s16[i] * (uint32_t)(i + 1);
    }
    return acc;
}

/* A square patch side, clipped to the frame. */
static int32_t patch_side(const bench_ctx *ctx, int32_t want)
{
    int32_t p = want;
    if (p > ctx->frame.w) {
        p = ctx->frame.w;
    }
    if (p > ctx->frame.h) {
        p = ctx->frame.h;
    }
    return p;
}

/* Corners of `units` pairs of p x p patches, drawn as bench.py draws them. */
static void setup_pairs(bench_ctx *ctx, uint32_t seed, int32_t p)
{
    uint32_t s = seed;
    uint32_t nx = (uint32_t)(ctx->frame.w - p + 1), ny = (uint32_t)(ctx->frame.h - p + 1);
    int32_t i;
    for (i = 0; i < ctx->units; ++i) {
        g_arg[i][0] = (int32_t)(xorshift32(&s) % nx);
        g_arg[i][1] = (int32_t)(xorshift32(&s) % ny);
        g_arg[i][2] = (int32_t)(xorshift32(&s) % nx);
        g_arg[i][3] = (int32_t)(xorshift32(&s) % ny);
    }
}

static vt_image_u8 sub_view(const bench_ctx *ctx, int32_t x, int32_t y, int32_t p)
{
    vt_image_u8 v;
    v.px = ctx->frame.px + (size_t)y * (size_t)ctx->frame.stride + (size_t)x;
    v.w = p;
    v.h = p;
    v.stride = ctx->frame.stride;
    return v;
}

/* ------------------------------------------------------------------ stages */
static void bench_setup_filter_h101(bench_ctx *ctx) { setup_s16(ctx); }
static void bench_run_filter_h101(bench_ctx *ctx)
{
    note_status(ctx, vt_filter_h101(&ctx->frame, &g_s16_view));
}

static void bench_setup_sobel_x(bench_ctx *ctx) { setup_s16(ctx); }
static void bench_run_sobel_x(bench_ctx *ctx)
{
    note_status(ctx, vt_sobel_x(&ctx->frame, &g_s16_view));
}

static void bench_setup_sobel_y(bench_ctx *ctx) { setup_s16(ctx); }
static void bench_run_sobel_y(bench_ctx *ctx)
{
    note_status(ctx, vt_sobel_y(&ctx->frame, &g_s16_view));
}

static void bench_setup_pyr_down(bench_ctx *ctx)
{
    g_u8_view.px = g_u8;
    g_u8_view.w = (ctx->frame.w + 1) / 2;
    g_u8_view.h = (ctx->frame.h + 1) / 2;
    g_u8_view.stride = g_u8_view.w;
}
static void bench_run_pyr_down(bench_ctx *ctx)
{
    note_status(ctx, vt_pyr_down(&ctx->frame, &g_u8_view));
}
static uint32_t bench_digest_pyr_down(const bench_ctx *ctx)
{
    uint32_t acc = 0;
    size_t i, n = (size_t)g_u8_view.w * (size_t)g_u8_view.h;
    (void)ctx;
    for (i = 0; i < n; ++i) {
        acc += (uint32_t)g_u8[i] * (uint32_t)(i + 1);
    }
    return acc;
}

static void bench_setup_integral(bench_ctx *ctx)
{
    g_u32_view.px = g_u32;
    g_u32_view.w = ctx->frame.w + 1;
    g_u32_view.h = ctx->frame.h + 1;
    g_u32_view.stride = g_u32_view.w;
}
static void bench_run_integral(bench_ctx *ctx)
{
    note_status(ctx, vt_integral(&ctx->frame, &g_u32_view));
}
static uint32_t bench_digest_integral(const bench_ctx *ctx)
{
    uint32_t acc = 0;
    size_t i, n = (size_t)g_u32_view.w * (size_t)g_u32_view.h;
    (void)ctx;
    for (i = 0; i < n; ++i) {
        acc += g_u32[i] * (uint32_t)(i + 1);
    }
    return acc;
}

/* Random boxes inside the frame: x, w, y, h drawn in that order (seed 1). */
static void bench_setup_box_sum(bench_ctx *ctx)
{
    uint32_t s = 1u;
    uint32_t w = (uint32_t)ctx->frame.w, h = (uint32_t)ctx->frame.h;
    int32_t i;
    bench_setup_integral(ctx);
    note_status(ctx, vt_integral(&ctx->frame, &g_u32_view));
    for (i = 0; i < ctx->units; ++i) {
        uint32_t x = xorshift32(&s) % w;
        uint32_t bw = 1u + xorshift32(&s) % (w - x);
        uint32_t y = xorshift32(&s) % h;
        uint32_t bh = 1u + xorshift32(&s) % (h - y);
        g_arg[i][0] = (int32_t)x;
        g_arg[i][1] = (int32_t)y;
        g_arg[i][2] = (int32_t)bw;
        g_arg[i][3] = (int32_t)bh;
    }
}
static void bench_run_box_sum(bench_ctx *ctx)
{
    int32_t i;
    for (i = 0; i < ctx->units; ++i) {
        uint32_t sum = 0;
        note_status(ctx, vt_box_sum(&g_u32_view, g_arg[i][0], g_arg[i][1], g_arg[i][2],
                                    g_arg[i][3], &sum));
        g_out[i] = sum;
    }
}

#define BENCH_NCC_SIDE 64
static void bench_setup_ncc(bench_ctx *ctx)
{
    setup_pairs(ctx, 2u, patch_side(ctx, BENCH_NCC_SIDE));
}
static void bench_run_ncc(bench_ctx *ctx)
{
    int32_t i, p = patch_side(ctx, BENCH_NCC_SIDE);
    for (i = 0; i < ctx->units; ++i) {
        vt_image_u8 a = sub_view(ctx, g_arg[i][0], g_arg[i][1], p);
        vt_image_u8 b = sub_view(ctx, g_arg[i][2], g_arg[i][3], p);
        vt_q14 q = 0;
        vt_status s = vt_ncc_u8(&a, &b, &q);
        /* A flat patch is a legal outcome (VT_E_SINGULAR); its code is the result. */
        g_out[i] = (uint32_t)(s == VT_OK ? (int32_t)q : (int32_t)s);
        if (s != VT_E_SINGULAR) {
            note_status(ctx, s);
        }
    }
}

#define BENCH_SAD_SIDE 16
static void bench_setup_sad(bench_ctx *ctx)
{
    setup_pairs(ctx, 3u, patch_side(ctx, BENCH_SAD_SIDE));
}
static void bench_run_sad(bench_ctx *ctx)
{
    int32_t i, p = patch_side(ctx, BENCH_SAD_SIDE);
    for (i = 0; i < ctx->units; ++i) {
        vt_image_u8 a = sub_view(ctx, g_arg[i][0], g_arg[i][1], p);
        vt_image_u8 b = sub_view(ctx, g_arg[i][2], g_arg[i][3], p);
        uint32_t sad = 0;
        note_status(ctx, vt_sad_u8(&a, &b, &sad));
        g_out[i] = sad;
    }
}

/* Any int32 angle in quarter degrees (seed 4). */
static void bench_setup_sincos(bench_ctx *ctx)
{
    uint32_t s = 4u;
    int32_t i;
    for (i = 0; i < ctx->units; ++i) {
        uint32_t r = xorshift32(&s);
        /* Two's complement reinterpretation without implementation-defined casts. */
        g_arg[i][0] = r <= (uint32_t)INT32_MAX ? (int32_t)r : -(int32_t)(~r) - 1;
    }
}
static void bench_run_sincos(bench_ctx *ctx)
{
    int32_t i;
    for (i = 0; i < ctx->units; ++i) {
        vt_q14 sn = 0, cs = 0;
        note_status(ctx, vt_sincos_q14(g_arg[i][0], &sn, &cs));
        g_out[2 * i] = (uint32_t)(int32_t)sn;
        g_out[2 * i + 1] = (uint32_t)(int32_t)cs;
    }
}

static uint32_t bench_digest_units(const bench_ctx *ctx)
{
    return digest_u32(g_out, (size_t)ctx->units);
}
static uint32_t bench_digest_units2(const bench_ctx *ctx)
{
    return digest_u32(g_out, 2u * (size_t)ctx->units);
}

/* ---- detection (issue 3): shadow, verify and both (vt_detect) on the fixed
 * trapezoid road area of pyvehtrack.detector.FixedRoad, built here with the same
 * double arithmetic as pyvehtrack/reference/shadow.py:trapezoid_road (host tool:
 * doubles are fine here, the core never sees them). */
static vt_road_area g_road;
static vt_detect_cfg g_detect_cfg;
static vt_detect_state g_detect_state;
static vt_detect_result g_detect_out;
static vt_hypothesis g_hyp[VT_MAX_HYPOTHESES];
static int32_t g_n_hyp;
static vt_box g_boxes[VT_MAX_BOXES];
static int32_t g_n_boxes;

static double bench_floor(double v)
{
    double f = (double)(long long)v;
    return f > v ? f - 1.0 : f;
}

static void bench_make_road(bench_ctx *ctx)
{
    int32_t w = ctx->frame.w, h = ctx->frame.h, y, yt;
    double vx = 0.5 * (w - 1), vy = 0.45 * (h - 1), yb = h - 1, span, t;
    span = yb > vy ? yb - vy : 1.0;
    yt = (int32_t)(-bench_floor(-vy)) + 4;
    yt = yt < 0 ? 0 : (yt > h - 1 ? h - 1 : yt);
    memset(&g_road, 0, sizeof(g_road));
    g_road.valid = 1;
    g_road.height = h;
    g_road.y_top = yt;
    g_road.y_bottom = h - 1;
    for (y = 0; y < h; ++y) {
        t = (y - vy) / span;
        t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
        g_road.x_left[y] = (int16_t)bench_floor(vx + t * (0.05 * (w - 1) - vx) + 0.5);
        g_road.x_right[y] = (int16_t)bench_floor(vx + t * (0.95 * (w - 1) - vx) + 0.5);
        g_road.lane_width[y] = (int16_t)bench_floor(t * 0.45 * w + 0.5);
    }
    note_status(ctx, vt_detect_cfg_default(&g_detect_cfg));
}

static void bench_setup_shadow(bench_ctx *ctx) { bench_make_road(ctx); }

static void bench_run_shadow(bench_ctx *ctx)
{
    note_status(ctx, vt_shadow_find(&g_detect_state.shadow, &g_detect_cfg.shadow, &ctx->frame, &g_road,
                                    g_hyp, VT_MAX_HYPOTHESES, &g_n_hyp));
}

static uint32_t bench_digest_shadow(const bench_ctx *ctx)
{
    (void)ctx;
    return digest_u32((const uint32_t *)(const void *)g_hyp, 3u * (size_t)g_n_hyp);
}

static void bench_setup_verify(bench_ctx *ctx)
{
    bench_make_road(ctx);
    bench_run_shadow(ctx);
}

static void bench_run_verify(bench_ctx *ctx)
{
    note_status(ctx, vt_verify(&g_detect_state.verify, &g_detect_cfg.verify, &ctx->frame, g_hyp, g_n_hyp,
                               g_boxes, VT_MAX_BOXES, &g_n_boxes));
}

static uint32_t bench_digest_verify(const bench_ctx *ctx)
{
    (void)ctx;
    return digest_u32((const uint32_t *)(const void *)g_boxes, 4u * (size_t)g_n_boxes);
}

static void bench_setup_detect(bench_ctx *ctx) { bench_make_road(ctx); }

static void bench_run_detect(bench_ctx *ctx)
{
    note_status(ctx, vt_detect(&g_detect_state, &g_detect_cfg, &ctx->frame, &g_road, &g_detect_out));
}

static uint32_t bench_digest_detect(const bench_ctx *ctx)
{
    (void)ctx;
    return digest_u32((const uint32_t *)(const void *)g_detect_out.box, 4u * (size_t)g_detect_out.n_boxes);
}

/* ---- lanes, and the whole detection frame (lanes -> road -> shadow -> verify) */
static vt_lane_cfg g_lane_cfg;
static vt_lane_state g_lane_state;
static vt_lane_result g_lane_res;
static vt_road_area g_lane_road;

static void bench_setup_lane(bench_ctx *ctx)
{
    note_status(ctx, vt_lane_cfg_default(&g_lane_cfg));
    note_status(ctx, vt_lane_reset(&g_lane_state));
    note_status(ctx, vt_detect_cfg_default(&g_detect_cfg));
}

static void bench_run_lane(bench_ctx *ctx)
{
    note_status(ctx, vt_lane_detect(&g_lane_state, &g_lane_cfg, &ctx->frame, &g_lane_res, &g_lane_road));
}

static uint32_t bench_digest_lane(const bench_ctx *ctx)
{
    uint32_t acc = 0, i = 1;
    int32_t y;
    (void)ctx;
    if (!g_lane_road.valid) {
        return 0;
    }
    /* The fold of digest_u32 over valid, y_top, y_bottom, then (x_left, x_right,
     * lane_width) per row, as bench.py's _road_digest. */
    acc += (uint32_t)g_lane_road.valid * i++;
    acc += (uint32_t)g_lane_road.y_top * i++;
    acc += (uint32_t)g_lane_road.y_bottom * i++;
    for (y = g_lane_road.y_top; y <= g_lane_road.y_bottom; ++y) {
        acc += (uint32_t)(int32_t)g_lane_road.x_left[y] * i++;
        acc += (uint32_t)(int32_t)g_lane_road.x_right[y] * i++;
        acc += (uint32_t)(int32_t)g_lane_road.lane_width[y] * i++;
    }
    return acc;
}

static void bench_run_full_detect(bench_ctx *ctx)
{
    note_status(ctx, vt_lane_detect(&g_lane_state, &g_lane_cfg, &ctx->frame, &g_lane_res, &g_lane_road));
    note_status(ctx, vt_detect(&g_detect_state, &g_detect_cfg, &ctx->frame, &g_lane_road, &g_detect_out));
}

/* ---- tracker (issue 4): one tracked frame (no detection) with two vehicles.
 * The boxes are the two cars of bench/data/road_640x480.png, scaled to the frame
 * as bench.py scales them. Setup primes the tracker with a detection frame. */
static vt_tracker g_tracker;
static vt_tracker_cfg g_tracker_cfg;
static vt_track_out g_track_out[VT_MAX_TRACKS];
static int32_t g_track_n;

static void bench_setup_track_frame(bench_ctx *ctx)
{
    static const int32_t base[2][4] = {{370, 270, 456, 328}, {528, 268, 639, 336}};
    vt_box dets[2];
    int32_t i, n = 0;
    for (i = 0; i < 2; ++i) {
        dets[i].left = base[i][0] * ctx->frame.w / 640;
        dets[i].top = base[i][1] * ctx->frame.h / 480;
        dets[i].right = base[i][2] * ctx->frame.w / 640;
        dets[i].bottom = base[i][3] * ctx->frame.h / 480;
    }
    note_status(ctx, vt_tracker_cfg_default(&g_tracker_cfg));
    note_status(ctx, vt_tracker_init(&g_tracker));
    note_status(ctx, vt_tracker_step(&g_tracker, &g_tracker_cfg, &ctx->frame, 1, dets, 2,
                                     g_track_out, VT_MAX_TRACKS, &n));
}

/* The same two cars primed with confirm_hits detection frames: confirmed tracks, the
 * usual state of a tracked frame (tentative ones are also held by the NCC template). */
static void bench_setup_track_frame_confirmed(bench_ctx *ctx)
{
    static const int32_t base[2][4] = {{370, 270, 456, 328}, {528, 268, 639, 336}};
    vt_box dets[2];
    int32_t i, k, n = 0;
    for (i = 0; i < 2; ++i) {
        dets[i].left = base[i][0] * ctx->frame.w / 640;
        dets[i].top = base[i][1] * ctx->frame.h / 480;
        dets[i].right = base[i][2] * ctx->frame.w / 640;
        dets[i].bottom = base[i][3] * ctx->frame.h / 480;
    }
    note_status(ctx, vt_tracker_cfg_default(&g_tracker_cfg));
    note_status(ctx, vt_tracker_init(&g_tracker));
    for (k = 0; k < g_tracker_cfg.confirm_hits; ++k) {
        note_status(ctx, vt_tracker_step(&g_tracker, &g_tracker_cfg, &ctx->frame, 1, dets, 2,
                                         g_track_out, VT_MAX_TRACKS, &n));
    }
}

static void bench_run_track_frame(bench_ctx *ctx)
{
    note_status(ctx, vt_tracker_step(&g_tracker, &g_tracker_cfg, &ctx->frame, 0, NULL, 0,
                                     g_track_out, VT_MAX_TRACKS, &g_track_n));
}

/* bench/callgrind.py reads each stage's own bench_run_NAME symbol */
static void bench_run_track_frame_confirmed(bench_ctx *ctx)
{
    bench_run_track_frame(ctx);
}

static uint32_t bench_digest_track_frame(const bench_ctx *ctx)
{
    uint32_t v[VT_MAX_TRACKS * 5];
    int32_t i;
    (void)ctx;
    for (i = 0; i < g_track_n; ++i) {
        v[5 * i] = (uint32_t)g_track_out[i].id;
        v[5 * i + 1] = (uint32_t)g_track_out[i].box.left;
        v[5 * i + 2] = (uint32_t)g_track_out[i].box.top;
        v[5 * i + 3] = (uint32_t)g_track_out[i].box.right;
        v[5 * i + 4] = (uint32_t)g_track_out[i].box.bottom;
    }
    return digest_u32(v, 5u * (size_t)g_track_n);
}

/* ---- motion (issue 9): one flow frame on both lateral areas, the previous frame
 * being the bench frame moved 4 px left (prev[y][x] = frame[y][min(x + 4, w - 1)]);
 * the state is restored each run by resetting prev_index and the blob lists, as
 * bench.py does. */
static vt_flow_state g_flow;
static vt_flow_cfg g_flow_cfg;
static vt_flow_result g_flow_out;
static int32_t g_flow_prev_index;
static uint8_t g_flow_prev[VT_MAX_WIDTH * VT_MAX_HEIGHT];

static void bench_setup_flow(bench_ctx *ctx)
{
    vt_image_u8 pv;
    vt_flow_result tmp;
    int32_t x, y, w = ctx->frame.w;
    for (y = 0; y < ctx->frame.h; ++y) {
        for (x = 0; x < w; ++x) {
            int32_t sx = x + 4 < w ? x + 4 : w - 1;
            g_flow_prev[(size_t)y * (size_t)w + (size_t)x] = ctx->frame.px[(size_t)y * (size_t)ctx->frame.stride + (size_t)sx];
        }
    }
    pv.px = g_flow_prev;
    pv.w = w;
    pv.h = ctx->frame.h;
    pv.stride = w;
    note_status(ctx, vt_flow_cfg_default(&g_flow_cfg));
    g_flow_cfg.sides = VT_FLOW_SIDE_BOTH;
    note_status(ctx, vt_flow_init(&g_flow));
    note_status(ctx, vt_flow_step(&g_flow, &g_flow_cfg, &pv, &tmp));
    g_flow_prev_index = g_flow.prev_index;
}

static void bench_run_flow(bench_ctx *ctx)
{
    g_flow.prev_index = g_flow_prev_index;
    g_flow.n_blobs[0] = g_flow.n_blobs[1] = 0;
    note_status(ctx, vt_flow_step(&g_flow, &g_flow_cfg, &ctx->frame, &g_flow_out));
}

static uint32_t bench_digest_flow(const bench_ctx *ctx)
{
    uint32_t v[VT_FLOW_MAX_HYPS * 5];
    int32_t i;
    (void)ctx;
    for (i = 0; i < g_flow_out.n; ++i) {
        v[5 * i] = (uint32_t)g_flow_out.hyp[i].box.left;
        v[5 * i + 1] = (uint32_t)g_flow_out.hyp[i].box.top;
        v[5 * i + 2] = (uint32_t)g_flow_out.hyp[i].box.right;
        v[5 * i + 3] = (uint32_t)g_flow_out.hyp[i].box.bottom;
        v[5 * i + 4] = (uint32_t)g_flow_out.hyp[i].cells;
    }
    return digest_u32(v, 5u * (size_t)g_flow_out.n);
}

/* ---- the vehicle model GA (Table 1) on the left car of the bench frame, as
 * bench.py's _model_setup: ROI around it, road through its bottom. */
static vt_model_cfg g_model_cfg;
static vt_model_search g_model_search;
static vt_model_ws g_model_ws;
static vt_model_result g_model_out;

static void model_setup(bench_ctx *ctx, int32_t tracking)
{
    const int32_t w = ctx->frame.w, h = ctx->frame.h;
    const int32_t l = 370 * w / 640, t = 270 * h / 480, r = 456 * w / 640, b = 328 * h / 480;
    const int32_t cw = r - l + 1, ch = b - t + 1;
    note_status(ctx, vt_model_cfg_default(&g_model_cfg));
    note_status(ctx, vt_model_cfg_road(&g_model_cfg, 288 * h / 480, 47 * w / 640, 328 * h / 480, 86 * w / 640));
    if (w < 160) {
        /* The quick bench's tiny frame: the small GA bench.py uses there. */
        static const int32_t pops[2][3] = {{16, 8, 8}, {8, 8, 8}}, gens[2][3] = {{4, 1, 1}, {2, 1, 1}};
        int32_t m, lv;
        for (m = 0; m < 2; ++m) {
            for (lv = 0; lv < 3; ++lv) {
                g_model_cfg.pop[m][lv] = pops[m][lv];
                g_model_cfg.gens[m][lv] = gens[m][lv];
            }
        }
    }
    memset(&g_model_search, 0, sizeof g_model_search);
    g_model_search.roi.left = l - cw / 2;
    g_model_search.roi.top = t - (4 * ch) / 10;
    g_model_search.roi.right = r + cw / 2;
    g_model_search.roi.bottom = b + (3 * ch) / 10;
    g_model_search.y_min = g_model_search.roi.top;
    g_model_search.y_max = g_model_search.roi.bottom;
    g_model_search.tracking = tracking;
    if (tracking) {
        g_model_search.pred.x = (l + r + 1) / 2;
        g_model_search.pred.y = b;
        g_model_search.pred.w = cw;
        g_model_search.pred.h = ch;
        g_model_search.pred.wind = 40;
        g_model_search.pred.bump = 20;
        g_model_search.pred.roof = 10;
        g_model_search.sigma.x = g_model_search.sigma.y = 3;
        g_model_search.sigma.w = g_model_search.sigma.h = 3;
        g_model_search.sigma.wind = g_model_search.sigma.bump = 8;
        g_model_search.sigma.roof = 5;
    }
}

static void bench_setup_model_detect(bench_ctx *ctx)
{
    model_setup(ctx, 0);
}

static void bench_setup_model_track(bench_ctx *ctx)
{
    model_setup(ctx, 1);
}

static void bench_run_model_detect(bench_ctx *ctx)
{
    note_status(ctx, vt_model_fit(&g_model_ws, &g_model_cfg, &ctx->frame, &g_model_search, &g_model_out));
}

static void bench_run_model_track(bench_ctx *ctx)
{
    note_status(ctx, vt_model_fit(&g_model_ws, &g_model_cfg, &ctx->frame, &g_model_search, &g_model_out));
}

static uint32_t bench_digest_model(const bench_ctx *ctx)
{
    const vt_model_params *p = &g_model_out.best;
    uint32_t v[9];
    (void)ctx;
    v[0] = (uint32_t)p->x;
    v[1] = (uint32_t)p->y;
    v[2] = (uint32_t)p->w;
    v[3] = (uint32_t)p->h;
    v[4] = (uint32_t)p->wind;
    v[5] = (uint32_t)p->bump;
    v[6] = (uint32_t)p->roof;
    v[7] = (uint32_t)g_model_out.fitness;
    v[8] = (uint32_t)g_model_out.evaluations;
    return digest_u32(v, 9);
}

/* ---- the whole system through its one call (issue 10): a fresh pipeline (init
 * included) and one detection frame: lanes -> road -> shadow -> verify -> tracker. */
static vt_pipeline_cfg g_pipe_cfg;
static vt_pipeline g_pipe;
static vt_frame_out g_pipe_out;

static void bench_setup_pipeline(bench_ctx *ctx)
{
    note_status(ctx, vt_pipeline_cfg_default(&g_pipe_cfg));
}

static void bench_run_pipeline(bench_ctx *ctx)
{
    note_status(ctx, vt_pipeline_init(&g_pipe, &g_pipe_cfg, NULL, NULL));
    note_status(ctx, vt_pipeline_step(&g_pipe, &ctx->frame, &g_pipe_out));
}

/* The boxes handed to the tracker, then the tracks' ids and boxes, as bench.py. */
static uint32_t bench_digest_pipeline(const bench_ctx *ctx)
{
    uint32_t v[4 * VT_MAX_BOXES + 5 * VT_MAX_TRACKS];
    size_t n = 0;
    int32_t i;
    (void)ctx;
    for (i = 0; i < g_pipe_out.n_boxes; ++i) {
        v[n++] = (uint32_t)g_pipe_out.boxes[i].box.left;
        v[n++] = (uint32_t)g_pipe_out.boxes[i].box.top;
        v[n++] = (uint32_t)g_pipe_out.boxes[i].box.right;
        v[n++] = (uint32_t)g_pipe_out.boxes[i].box.bottom;
    }
    for (i = 0; i < g_pipe_out.n_tracks; ++i) {
        v[n++] = (uint32_t)g_pipe_out.tracks[i].id;
        v[n++] = (uint32_t)g_pipe_out.tracks[i].box.left;
        v[n++] = (uint32_t)g_pipe_out.tracks[i].box.top;
        v[n++] = (uint32_t)g_pipe_out.tracks[i].box.right;
        v[n++] = (uint32_t)g_pipe_out.tracks[i].box.bottom;
    }
    return digest_u32(v, n);
}

/* ---- the pipeline with the flow / model source (issues 9/10), primed as bench.py's
 * _pipe_primed: flow: one step on the flow bench's previous frame (the frame moved 4 px;
 * a detection frame, the shadow source starts the tracks); model: one step on the frame
 * (a detection frame), three with its boxes as the caller's detections (the tracks are
 * confirmed) and one on a flat grey frame (their ROI search fails: they coast, so the
 * measured step refits them, at most model_fits = 2). The run restores that state (a copy of vt_pipeline; for flow the flow state's
 * bookkeeping, whose level image is only read) and steps the frame once. */
static vt_pipeline_cfg g_pp_cfg;
static vt_pipeline g_pp, g_pp_saved;
static vt_frame_out g_pp_out;
static vt_flow_state g_pp_flow;
static vt_model_ws g_pp_model;
static uint8_t g_pp_aux[VT_MAX_WIDTH * VT_MAX_HEIGHT];
static struct {
    int32_t have_prev, prev_index, w, h, lw, lh, level, next_id, gw[2], gh[2], x0[2], y0[2];
    vt_flow_seed_track seeds[VT_FLOW_MAX_SEEDS];
    int32_t n_blobs[2];
    vt_box blob_box[2 * VT_FLOW_MAX_BLOBS];
    int32_t blob_age[2 * VT_FLOW_MAX_BLOBS];
    int32_t n_rect[2];
    int32_t rect[2][VT_FLOW_MAX_RECTS][4];
} g_pp_book;

#define PP_BOOK(dir)                                                                  \
    do {                                                                              \
        vt_flow_state *f_ = &g_pp_flow;                                               \
        if (dir) {                                                                    \
            g_pp_book.have_prev = f_->have_prev;                                      \
            g_pp_book.prev_index = f_->prev_index;                                    \
            g_pp_book.w = f_->w; g_pp_book.h = f_->h;                                 \
            g_pp_book.lw = f_->lw; g_pp_book.lh = f_->lh;                             \
            g_pp_book.level = f_->level; g_pp_book.next_id = f_->next_id;             \
            memcpy(g_pp_book.gw, f_->gw, sizeof f_->gw);                              \
            memcpy(g_pp_book.gh, f_->gh, sizeof f_->gh);                              \
            memcpy(g_pp_book.x0, f_->x0, sizeof f_->x0);                              \
            memcpy(g_pp_book.y0, f_->y0, sizeof f_->y0);                              \
            memcpy(g_pp_book.seeds, f_->seeds, sizeof f_->seeds);                     \
            memcpy(g_pp_book.n_blobs, f_->n_blobs, sizeof f_->n_blobs);               \
            memcpy(g_pp_book.blob_box, f_->blob_box, sizeof f_->blob_box);            \
            memcpy(g_pp_book.blob_age, f_->blob_age, sizeof f_->blob_age);            \
            memcpy(g_pp_book.n_rect, f_->n_rect, sizeof f_->n_rect);                  \
            memcpy(g_pp_book.rect, f_->rect, sizeof f_->rect);                        \
        } else {                                                                      \
            f_->have_prev = g_pp_book.have_prev;                                      \
            f_->prev_index = g_pp_book.prev_index;                                    \
            f_->w = g_pp_book.w; f_->h = g_pp_book.h;                                 \
            f_->lw = g_pp_book.lw; f_->lh = g_pp_book.lh;                             \
            f_->level = g_pp_book.level; f_->next_id = g_pp_book.next_id;             \
            memcpy(f_->gw, g_pp_book.gw, sizeof f_->gw);                              \
            memcpy(f_->gh, g_pp_book.gh, sizeof f_->gh);                              \
            memcpy(f_->x0, g_pp_book.x0, sizeof f_->x0);                              \
            memcpy(f_->y0, g_pp_book.y0, sizeof f_->y0);                              \
            memcpy(f_->seeds, g_pp_book.seeds, sizeof f_->seeds);                     \
            memcpy(f_->n_blobs, g_pp_book.n_blobs, sizeof f_->n_blobs);               \
            memcpy(f_->blob_box, g_pp_book.blob_box, sizeof f_->blob_box);            \
            memcpy(f_->blob_age, g_pp_book.blob_age, sizeof f_->blob_age);            \
            memcpy(f_->n_rect, g_pp_book.n_rect, sizeof f_->n_rect);                  \
            memcpy(f_->rect, g_pp_book.rect, sizeof f_->rect);                        \
        }                                                                             \
    } while (0)

static void pipe_primed(bench_ctx *ctx, int32_t source)
{
    vt_image_u8 aux;
    int32_t w = ctx->frame.w, h = ctx->frame.h, x, y, k;
    note_status(ctx, vt_pipeline_cfg_default(&g_pp_cfg));
    g_pp_cfg.sources = VT_SRC_SHADOW | source;
    g_pp_cfg.flow.sides = VT_FLOW_SIDE_BOTH;
    note_status(ctx, vt_pipeline_init(&g_pp, &g_pp_cfg, NULL, NULL));
    if (source == VT_SRC_FLOW) {
        note_status(ctx, vt_pipeline_set_flow_ws(&g_pp, &g_pp_flow));
    } else {
        note_status(ctx, vt_pipeline_set_model_ws(&g_pp, &g_pp_model));
    }
    aux.px = g_pp_aux;
    aux.w = w;
    aux.h = h;
    aux.stride = w;
    if (source == VT_SRC_FLOW) {
        /* prev[y][x] = frame[y][min(x + 4, w - 1)], as bench.py's _flow_prev */
        for (y = 0; y < h; ++y) {
            for (x = 0; x < w; ++x) {
                int32_t sx = x + 4 < w ? x + 4 : w - 1;
                g_pp_aux[(size_t)y * (size_t)w + (size_t)x] =
                    ctx->frame.px[(size_t)y * (size_t)ctx->frame.stride + (size_t)sx];
            }
        }
        note_status(ctx, vt_pipeline_step(&g_pp, &aux, &g_pp_out));
        PP_BOOK(1);
    } else {
        vt_box boxes[VT_MAX_BOXES];
        int32_t n;
        note_status(ctx, vt_pipeline_step(&g_pp, &ctx->frame, &g_pp_out));
        n = g_pp_out.n_boxes;
        for (k = 0; k < n; ++k) {
            boxes[k] = g_pp_out.boxes[k].box;
        }
        for (k = 0; k < 3; ++k) {
            note_status(ctx, vt_pipeline_step_dets(&g_pp, &ctx->frame, boxes, n, &g_pp_out));
        }
        memset(g_pp_aux, 128, (size_t)w * (size_t)h);
        note_status(ctx, vt_pipeline_step(&g_pp, &aux, &g_pp_out));
    }
    memcpy(&g_pp_saved, &g_pp, sizeof g_pp);
}

static void bench_setup_pipeline_flow(bench_ctx *ctx)
{
    pipe_primed(ctx, VT_SRC_FLOW);
}

static void bench_setup_pipeline_model(bench_ctx *ctx)
{
    pipe_primed(ctx, VT_SRC_MODEL);
}

static void bench_run_pipeline_flow(bench_ctx *ctx)
{
    memcpy(&g_pp, &g_pp_saved, sizeof g_pp);
    PP_BOOK(0);
    note_status(ctx, vt_pipeline_step(&g_pp, &ctx->frame, &g_pp_out));
}

static void bench_run_pipeline_model(bench_ctx *ctx)
{
    memcpy(&g_pp, &g_pp_saved, sizeof g_pp);
    note_status(ctx, vt_pipeline_step(&g_pp, &ctx->frame, &g_pp_out));
}

static uint32_t digest_frame_out(const vt_frame_out *o)
{
    uint32_t v[4 * VT_MAX_BOXES + 5 * VT_MAX_TRACKS];
    size_t n = 0;
    int32_t i;
    for (i = 0; i < o->n_boxes; ++i) {
        v[n++] = (uint32_t)o->boxes[i].box.left;
        v[n++] = (uint32_t)o->boxes[i].box.top;
        v[n++] = (uint32_t)o->boxes[i].box.right;
        v[n++] = (uint32_t)o->boxes[i].box.bottom;
    }
    for (i = 0; i < o->n_tracks; ++i) {
        v[n++] = (uint32_t)o->tracks[i].id;
        v[n++] = (uint32_t)o->tracks[i].box.left;
        v[n++] = (uint32_t)o->tracks[i].box.top;
        v[n++] = (uint32_t)o->tracks[i].box.right;
        v[n++] = (uint32_t)o->tracks[i].box.bottom;
    }
    return digest_u32(v, n);
}

static uint32_t bench_digest_pipe_primed(const bench_ctx *ctx)
{
    (void)ctx;
    return digest_frame_out(&g_pp_out);
}

/* The registry. Default units match bench.py's full run. */
static const bench_stage stages[] = {
    {"filter_h101", 1, bench_setup_filter_h101, bench_run_filter_h101, digest_s16},
    {"sobel_x", 1, bench_setup_sobel_x, bench_run_sobel_x, digest_s16},
    {"sobel_y", 1, bench_setup_sobel_y, bench_run_sobel_y, digest_s16},
    {"pyr_down", 1, bench_setup_pyr_down, bench_run_pyr_down, bench_digest_pyr_down},
    {"integral", 1, bench_setup_integral, bench_run_integral, bench_digest_integral},
    {"box_sum", 10000, bench_setup_box_sum, bench_run_box_sum, bench_digest_units},
    {"ncc", 100, bench_setup_ncc, bench_run_ncc, bench_digest_units},
    {"sad", 1000, bench_setup_sad, bench_run_sad, bench_digest_units},
    {"sincos", 1440, bench_setup_sincos, bench_run_sincos, bench_digest_units2},
    {"shadow", 1, bench_setup_shadow, bench_run_shadow, bench_digest_shadow},
    {"verify", 1, bench_setup_verify, bench_run_verify, bench_digest_verify},
    {"detect", 1, bench_setup_detect, bench_run_detect, bench_digest_detect},
    {"lane", 1, bench_setup_lane, bench_run_lane, bench_digest_lane},
    {"full_detect", 1, bench_setup_lane, bench_run_full_detect, bench_digest_detect},
    {"track_frame", 1, bench_setup_track_frame, bench_run_track_frame, bench_digest_track_frame},
    {"track_frame_confirmed", 1, bench_setup_track_frame_confirmed, bench_run_track_frame_confirmed,
     bench_digest_track_frame},
    {"flow", 1, bench_setup_flow, bench_run_flow, bench_digest_flow},
    {"model_detect", 1, bench_setup_model_detect, bench_run_model_detect, bench_digest_model},
    {"model_track", 1, bench_setup_model_track, bench_run_model_track, bench_digest_model},
    {"pipeline", 1, bench_setup_pipeline, bench_run_pipeline, bench_digest_pipeline},
    {"pipeline_flow", 1, bench_setup_pipeline_flow, bench_run_pipeline_flow, bench_digest_pipe_primed},
    {"pipeline_model", 1, bench_setup_pipeline_model, bench_run_pipeline_model, bench_digest_pipe_primed},
};
#define N_STAGES (sizeof stages / sizeof stages[0])

/* ------------------------------------------------------------------ frame I/O */
static int read_token(FILE *f, long *out)
{
    int c = fgetc(f);
    long v = 0;
    int digits = 0;
    while (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '#') {
        if (c == '#') {
            while (c != '\n' && c != EOF) {
                c = fgetc(f);
            }
        }
        c = fgetc(f);
    }
    while (c >= '0' && c <= '9' && v < 100000) {
        v = v * 10 + (c - '0');
        ++digits;
        c = fgetc(f);
    }
    *out = v;
    return digits > 0; /* the single whitespace after maxval is consumed here */
}

/* Binary 8-bit PGM (P5, maxval 255) into g_frame. */
static int read_pgm(const char *path, vt_image_u8 *img)
{
    FILE *f = fopen(path, "rb");
    long w = 0, h = 0, maxval = 0;
    size_t n;
    if (f == NULL) {
        fprintf(stderr, "callgrind_main: cannot open %s\n", path);
        return -1;
    }
    if (fgetc(f) != 'P' || fgetc(f) != '5' || !read_token(f, &w) || !read_token(f, &h) ||
        !read_token(f, &maxval) || maxval != 255 || w < 1 || h < 1 || w > VT_MAX_WIDTH ||
        h > VT_MAX_HEIGHT) {
        fprintf(stderr, "callgrind_main: %s is not an 8-bit P5 PGM within VT_MAX_*\n", path);
        fclose(f);
        return -1;
    }
    n = (size_t)w * (size_t)h;
    if (fread(g_frame, 1, n, f) != n) {
        fprintf(stderr, "callgrind_main: %s is truncated\n", path);
        fclose(f);
        return -1;
    }
    fclose(f);
    img->px = g_frame;
    img->w = (int32_t)w;
    img->h = (int32_t)h;
    img->stride = (int32_t)w;
    return 0;
}

static const bench_stage *find_stage(const char *name, size_t len)
{
    size_t i;
    for (i = 0; i < N_STAGES; ++i) {
        if (strlen(stages[i].name) == len && strncmp(stages[i].name, name, len) == 0) {
            return &stages[i];
        }
    }
    return NULL;
}

int main(int argc, char **argv)
{
    vt_image_u8 frame;
    int i;
    if (argc == 2 && strcmp(argv[1], "--list") == 0) {
        size_t k;
        for (k = 0; k < N_STAGES; ++k) {
            printf("%s %ld\n", stages[k].name, (long)stages[k].default_units);
        }
        return 0;
    }
    if (argc < 3) {
        fprintf(stderr, "usage: %s --list | FRAME.pgm NAME[:UNITS]...\n", argv[0]);
        return 2;
    }
    if (read_pgm(argv[1], &frame) != 0) {
        return 2;
    }
    for (i = 2; i < argc; ++i) {
        const char *colon = strchr(argv[i], ':');
        size_t len = colon != NULL ? (size_t)(colon - argv[i]) : strlen(argv[i]);
        const bench_stage *st = find_stage(argv[i], len);
        bench_ctx ctx;
        long units;
        if (st == NULL) {
            fprintf(stderr, "callgrind_main: unknown stage '%s' (see --list)\n", argv[i]);
            return 2;
        }
        units = colon != NULL ? strtol(colon + 1, NULL, 10) : (long)st->default_units;
        if (units < 1 || units > BENCH_MAX_UNITS) {
            fprintf(stderr, "callgrind_main: units for %s must be 1..%d\n", st->name,
                    BENCH_MAX_UNITS);
            return 2;
        }
        ctx.frame = frame;
        ctx.units = (int32_t)units;
        ctx.status = VT_OK;
        st->setup(&ctx);
        st->run(&ctx);
        printf("stage %s units %ld status %ld digest 0x%08lx\n", st->name, units,
               (long)ctx.status, (unsigned long)st->digest(&ctx));
    }
    return 0;
}
