/* main.c -- the firmware proof: the C core's pixel, trig and fixed-point
 * primitives run on a real road frame held in flash, on a bare Cortex-M3
 * (soft-float ABI) and Cortex-M7, and every output is folded into an FNV-1a
 * checksum that tests/test_firmware.py recomputes on the host through cffi.
 * Then the whole vehicle system over five real 640x256 frames in flash, through
 * its one call: a static vt_pipeline stepped once per frame (lanes on every
 * frame, detection on the first in the lanes' road area, the tracker on all
 * five), printing every frame's road area, boxes and tracks and a checksum of
 * every vt_frame_out (the host test repeats them too); then once more with every
 * hypothesis source built: the whole-road detector with the default classifier
 * model (c/tables, in flash), the overtaking flow stage, the block-scale TTC and
 * the GA vehicle model refitting coasting tracks (run_pipeline). Last, the CNN
 * detector (vt_cnn_detect_frame) with a model held in flash (cnn_data.h, from
 * tools/gen_cnn_table.py) on a synthetic frame it draws (run_cnn).
 * Equal checksums mean the same C gives the same bits on ARM and on the host.
 *
 * Every buffer is static (.bss), so the linker's size table is the RAM bill.
 * The checksum recipe (what is hashed, in which order) is mirrored line by line
 * in tests/test_firmware.py; change both together. */
#include <stddef.h>
#include <stdint.h>
#include "vehtrack/cnn.h"
#include "vehtrack/fixed.h"
#include "vehtrack/image.h"
#include "vehtrack/pipeline.h"
#include "vehtrack/status.h"
#include "vehtrack/trig.h"
#include "board.h"
#include "clip_data.h"
#include "cnn_data.h"
#include "frame_data.h"

#ifndef FW_CORE_NAME
#define FW_CORE_NAME "unknown-core"
#endif

#define W FW_FRAME_W
#define H FW_FRAME_H
#define PW ((W + 1) / 2)
#define PH ((H + 1) / 2)

/* Outputs, all in .bss. */
static int16_t g_h101[H * W];
static int16_t g_sobx[H * W];
static int16_t g_soby[H * W];
static uint8_t g_pyr[PH * PW];
static uint32_t g_ii[(H + 1) * (W + 1)];

/* The whole vehicle system's state, in .bss: its configuration, the pipeline
 * (every stage's configuration copy and state) and one frame's output. */
static vt_pipeline_cfg g_pipe_cfg;
static vt_camera_cfg g_cam;
static vt_pipeline g_pipe;
static vt_frame_out g_out;
/* The workspaces the second run attaches: the whole-road detector's scratch
 * (classifier windows, pyramid) and the overtaking stage's state (two level images). */
static vt_pipe_cls_ws g_cls_ws;
static vt_flow_state g_flow;
/* ... and the block-scale TTC's state (VT_TTC_TRACKS slots of past blocks). */
static vt_ttc_state g_ttc;
/* ... and the vehicle model's workspace (GA populations, the ROI's pyramid and
 * gradients: 5.3 bytes per VT_MODEL_MAX_ROI_PIXELS). It fits beside the others
 * because firmware.mk builds for the clip's 640x256 frames (FW_CAPS). FW_MODEL=0
 * (FW_DEFS=-DFW_MODEL=0) leaves the model source out of the full run, to measure
 * what it costs; the host comparisons then leave it out too (firmware-caps). */
#ifndef FW_MODEL
#define FW_MODEL 1
#endif
#if FW_MODEL
static vt_model_ws g_model_ws;
#endif

/* ---------------------------------------------------------------- FNV-1a 32 */
#define FNV_BASIS 2166136261u
#define FNV_PRIME 16777619u

static uint32_t fnv_u8(uint32_t h, uint8_t b)
{
    return (h ^ b) * FNV_PRIME;
}

/* Multi-byte values are hashed as their little-endian bytes, whatever the
 * target's byte order. */
static uint32_t fnv_u16(uint32_t h, uint16_t v)
{
    h = fnv_u8(h, (uint8_t)(v & 0xFFu));
    return fnv_u8(h, (uint8_t)(v >> 8));
}

static uint32_t fnv_u32(uint32_t h, uint32_t v)
{
    h = fnv_u16(h, (uint16_t)(v & 0xFFFFu));
    return fnv_u16(h, (uint16_t)(v >> 16));
}

static uint32_t fnv_s16(uint32_t h, int16_t v)
{
    return fnv_u16(h, (uint16_t)v); /* two's complement bits, modulo 2^16 */
}

static uint32_t fnv_s32(uint32_t h, int32_t v)
{
    return fnv_u32(h, (uint32_t)v);
}

static uint32_t fnv_status(uint32_t h, vt_status s)
{
    return fnv_s32(h, (int32_t)s);
}

/* ---------------------------------------------------------------- sequences */
/* Numerical Recipes LCG: a deterministic sequence both sides can reproduce. */
static uint32_t lcg(uint32_t *state)
{
    *state = *state * 1664525u + 1013904223u;
    return *state;
}

/* uint32 -> int32 with two's complement meaning, without implementation-
 * defined conversion. */
static int32_t u2s(uint32_t u)
{
    return u <= (uint32_t)INT32_MAX ? (int32_t)u : -(int32_t)(~u) - 1;
}

/* A signed value of random magnitude: |v| < 2^(31-k) for a random k. */
static int32_t lcg_scaled(uint32_t *state)
{
    uint32_t k = lcg(state) >> 27;
    uint32_t m = (lcg(state) >> k) >> 1;
    uint32_t neg = lcg(state) >> 31;
    return neg ? -(int32_t)m : (int32_t)m;
}

/* ---------------------------------------------------------------- output */
static uint32_t g_all = FNV_BASIS;
static uint32_t g_t0;

static void print_checksum(const char *name, uint32_t sum)
{
    fw_line_str("checksum ");
    fw_line_str(name);
    fw_line_str(" ");
    fw_line_hex32(sum);
    fw_line_end();
}

static void report(const char *name, uint32_t sum)
{
    print_checksum(name, sum);
    g_all = fnv_u32(g_all, sum);
}

/* Time one call: start() before it, stop() right after it (hashing the
 * output is not counted). QEMU's MPS2 runs the processor clock, and so
 * SysTick, at 25 MHz: 40 ns a tick. With -icount shift=0 one instruction is
 * 1 ns, so ticks * 40 counts instructions to within 40 (without -icount the
 * figure is meaningless). */
static void start(void)
{
    g_t0 = fw_ticks();
}

static void insns(const char *name, uint32_t ticks)
{
    fw_line_str("insns ");
    fw_line_str(name);
    fw_line_str(" ");
    fw_line_u32(ticks * 40u);
    fw_line_end();
}

static void stop(const char *name)
{
    insns(name, fw_ticks_since(g_t0));
}

/* The capacities the image was built with (firmware.mk's FW_CAPS, FW_DEFS): the
 * host side of the comparison must be built with the same (tests/test_firmware.py
 * checks this line against its build), or equal lines would be luck. */
static void print_config(void)
{
    static const struct {
        const char *name;
        int32_t value;
    } caps[] = {
        {"VT_MAX_WIDTH", VT_MAX_WIDTH},
        {"VT_MAX_HEIGHT", VT_MAX_HEIGHT},
        {"VT_MAX_TRACKS", VT_MAX_TRACKS},
        {"VT_MAX_BOXES", VT_MAX_BOXES},
        {"VT_MAX_HYPOTHESES", VT_MAX_HYPOTHESES},
        {"VT_CLS_MAX_W", VT_CLS_MAX_W},
        {"VT_CLS_MAX_H", VT_CLS_MAX_H},
        {"VT_FLOW_MAX_PIXELS", VT_FLOW_MAX_PIXELS},
        {"VT_FLOW_MAX_CELLS", VT_FLOW_MAX_CELLS},
        {"VT_TTC_TRACKS", VT_TTC_TRACKS},
        {"VT_MODEL_MAX_ROI_PIXELS", VT_MODEL_MAX_ROI_PIXELS},
        {"VT_MODEL_MAX_POP", VT_MODEL_MAX_POP},
    };
    size_t i;
    for (i = 0; i < sizeof caps / sizeof caps[0]; ++i) {
        fw_line_str("config ");
        fw_line_str(caps[i].name);
        fw_line_str(" ");
        fw_line_s32(caps[i].value);
        fw_line_end();
    }
    fw_line_str("config FW_MODEL ");
    fw_line_s32(FW_MODEL);
    fw_line_end();
}

static void print_size(const char *what, uint32_t bytes)
{
    fw_line_str(what);
    fw_line_str(" ");
    fw_line_u32(bytes);
    fw_line_end();
}

/* ---------------------------------------------------------------- checks */
static const vt_image_u8 g_frame = {fw_frame, W, H, W};

static uint32_t hash_s16_image(uint32_t h, const int16_t *px, int32_t n)
{
    int32_t i;
    for (i = 0; i < n; ++i) {
        h = fnv_s16(h, px[i]);
    }
    return h;
}

static void check_frame(void)
{
    uint32_t h = FNV_BASIS;
    int32_t i;
    for (i = 0; i < W * H; ++i) {
        h = fnv_u8(h, fw_frame[i]);
    }
    report("frame", h);
}

typedef vt_status (*fw_grad_fn)(const vt_image_u8 *src, vt_image_s16 *dst);

static void check_grad(const char *name, fw_grad_fn fn, int16_t *buf)
{
    vt_image_s16 dst;
    uint32_t h = FNV_BASIS;
    vt_status s;
    dst.px = buf;
    dst.w = W;
    dst.h = H;
    dst.stride = W;
    start();
    s = fn(&g_frame, &dst);
    stop(name);
    h = fnv_status(h, s);
    h = hash_s16_image(h, buf, W * H);
    report(name, h);
}

static void check_pyr(void)
{
    vt_image_u8_mut dst;
    uint32_t h = FNV_BASIS;
    vt_status s;
    int32_t i;
    dst.px = g_pyr;
    dst.w = PW;
    dst.h = PH;
    dst.stride = PW;
    start();
    s = vt_pyr_down(&g_frame, &dst);
    stop("pyr_down");
    h = fnv_status(h, s);
    for (i = 0; i < PW * PH; ++i) {
        h = fnv_u8(h, g_pyr[i]);
    }
    report("pyr_down", h);
}

static void check_integral_and_boxes(void)
{
    vt_image_u32 ii;
    uint32_t h = FNV_BASIS, state = 12345u, sum;
    vt_status s;
    int32_t i, x, y, bw, bh;
    ii.px = g_ii;
    ii.w = W + 1;
    ii.h = H + 1;
    ii.stride = W + 1;
    start();
    s = vt_integral(&g_frame, &ii);
    stop("integral");
    h = fnv_status(h, s);
    for (i = 0; i < (W + 1) * (H + 1); ++i) {
        h = fnv_u32(h, g_ii[i]);
    }
    report("integral", h);

    /* Box sums: the whole frame, a NULL output, then 256 pseudo-random boxes of
     * which about half stick out of the frame (VT_E_SIZE, folded in too). */
    h = FNV_BASIS;
    sum = 0;
    s = vt_box_sum(&ii, 0, 0, W, H, &sum);
    h = fnv_u32(fnv_status(h, s), sum);
    s = vt_box_sum(&ii, 0, 0, 1, 1, NULL);
    h = fnv_status(h, s);
    for (i = 0; i < 256; ++i) {
        x = (int32_t)(lcg(&state) % (W + 8)) - 4;
        y = (int32_t)(lcg(&state) % (H + 8)) - 4;
        bw = (int32_t)(lcg(&state) % (W / 2 + 1));
        bh = (int32_t)(lcg(&state) % (H / 2 + 1));
        sum = 0;
        s = vt_box_sum(&ii, x, y, bw, bh, &sum);
        h = fnv_u32(fnv_status(h, s), sum);
    }
    report("box_sum", h);
}

/* Patch pairs inside the frame: {ax, ay, bx, by, w, h}. */
static const int16_t g_pairs[][6] = {
    {40, 30, 42, 31, 32, 24},   /* overlapping, shifted by (2, 1) */
    {120, 40, 120, 40, 48, 40}, /* identical: NCC 1.0, SAD 0 */
    {0, 0, 288, 72, 32, 24},    /* opposite corners */
    {130, 44, 134, 46, 56, 40}, /* the lead car, shifted by (4, 2) */
    {0, 10, 0, 11, 320, 1},     /* a full row against the next */
    {300, 0, 301, 0, 19, 96},   /* a tall strip at the right edge */
    {0, 0, 1, 0, 319, 96},      /* nearly the whole frame, shifted by one column */
    {24, 0, 60, 0, 8, 4},       /* sky: saturated, possibly flat */
};
#define N_PAIRS (sizeof g_pairs / sizeof g_pairs[0])

static const uint8_t g_flat[8 * 8] = {
    128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128,
    128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128,
    128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128,
    128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128, 128,
};

static vt_image_u8 sub(int32_t x, int32_t y, int32_t w, int32_t h)
{
    vt_image_u8 v;
    v.px = fw_frame + (size_t)y * W + (size_t)x;
    v.w = w;
    v.h = h;
    v.stride = W;
    return v;
}

static void check_patches(void)
{
    uint32_t hn = FNV_BASIS, hs = FNV_BASIS, t_ncc = 0, t_sad = 0, t;
    size_t i;
    vt_image_u8 a, b, flat;
    vt_q14 ncc;
    uint32_t sad;
    vt_status s;
    for (i = 0; i < N_PAIRS; ++i) {
        a = sub(g_pairs[i][0], g_pairs[i][1], g_pairs[i][4], g_pairs[i][5]);
        b = sub(g_pairs[i][2], g_pairs[i][3], g_pairs[i][4], g_pairs[i][5]);
        ncc = 0;
        t = fw_ticks();
        s = vt_ncc_u8(&a, &b, &ncc);
        t_ncc += fw_ticks_since(t);
        hn = fnv_s16(fnv_status(hn, s), ncc);
        sad = 0;
        t = fw_ticks();
        s = vt_sad_u8(&a, &b, &sad);
        t_sad += fw_ticks_since(t);
        hs = fnv_u32(fnv_status(hs, s), sad);
    }
    /* Error paths: a flat patch (NCC undefined), unequal sizes, NULL output. */
    flat.px = g_flat;
    flat.w = 8;
    flat.h = 8;
    flat.stride = 8;
    a = sub(100, 50, 8, 8);
    b = sub(100, 50, 8, 7);
    ncc = 0;
    s = vt_ncc_u8(&a, &flat, &ncc);
    hn = fnv_s16(fnv_status(hn, s), ncc);
    s = vt_ncc_u8(&a, &b, &ncc);
    hn = fnv_status(hn, s);
    s = vt_ncc_u8(&a, &a, NULL);
    hn = fnv_status(hn, s);
    sad = 0;
    s = vt_sad_u8(&a, &flat, &sad);
    hs = fnv_u32(fnv_status(hs, s), sad);
    s = vt_sad_u8(&a, &b, &sad);
    hs = fnv_status(hs, s);
    s = vt_sad_u8(&a, &a, NULL);
    hs = fnv_status(hs, s);
    insns("ncc_u8", t_ncc);
    insns("sad_u8", t_sad);
    report("ncc_u8", hn);
    report("sad_u8", hs);
}

static void check_sincos(void)
{
    static const int32_t extra[] = {-1, -1440, 1440, 1441, 2879, -721, INT32_MAX, INT32_MIN};
    uint32_t h = FNV_BASIS;
    int32_t a;
    size_t i;
    vt_q14 sn, cs;
    vt_status s;
    for (a = 0; a < VT_QDEG_TURN; ++a) {
        sn = 0;
        cs = 0;
        s = vt_sincos_q14(a, &sn, &cs);
        h = fnv_s16(fnv_s16(fnv_status(h, s), sn), cs);
    }
    for (i = 0; i < sizeof extra / sizeof extra[0]; ++i) {
        sn = 0;
        cs = 0;
        s = vt_sincos_q14(extra[i], &sn, &cs);
        h = fnv_s16(fnv_s16(fnv_status(h, s), sn), cs);
    }
    s = vt_sincos_q14(0, NULL, NULL);
    h = fnv_status(h, s);
    report("sincos_q14", h);
}

/* Edge values for the Q16 helpers: zero, one LSB, 0.5, 1.0, the limits. */
static const int32_t g_q16_edges[] = {
    0, 1, -1, 2, -2, 32768, -32768, 65535, 65536, -65536, 98304, -98304,
    INT32_MAX, INT32_MIN, INT32_MAX - 1, INT32_MIN + 1,
};
#define N_EDGES (sizeof g_q16_edges / sizeof g_q16_edges[0])
#define N_RANDOM 512

static void check_fixed(void)
{
    static const uint64_t edges64[] = {
        0u, 1u, 2u, 3u, 4u, 15u, 16u, 17u, 0xFFFFFFFFu, 0x100000000u,
        0xFFFFFFFE00000001u, /* (2^32 - 1)^2 */
        0xFFFFFFFE00000000u, /* (2^32 - 1)^2 - 1 */
        0x4000000000000000u, 0x8000000000000000u, 0xFFFFFFFFFFFFFFFFu,
    };
    uint32_t h, state, k;
    size_t i, j;
    int32_t a, b;
    vt_q16 q;
    vt_status s;
    uint64_t x;

    /* vt_q16_mul_sat: all edge pairs, then random value x random magnitude. */
    h = FNV_BASIS;
    state = 1u;
    for (i = 0; i < N_EDGES; ++i) {
        for (j = 0; j < N_EDGES; ++j) {
            h = fnv_s32(h, vt_q16_mul_sat(g_q16_edges[i], g_q16_edges[j]));
        }
    }
    for (i = 0; i < N_RANDOM; ++i) {
        a = u2s(lcg(&state));
        b = lcg_scaled(&state);
        h = fnv_s32(h, vt_q16_mul_sat(a, b));
    }
    report("q16_mul_sat", h);

    /* vt_q16_div: the same, with its status (division by zero included). */
    h = FNV_BASIS;
    state = 2u;
    for (i = 0; i < N_EDGES; ++i) {
        for (j = 0; j < N_EDGES; ++j) {
            q = 0;
            s = vt_q16_div(g_q16_edges[i], g_q16_edges[j], &q);
            h = fnv_s32(fnv_status(h, s), q);
        }
    }
    for (i = 0; i < N_RANDOM; ++i) {
        a = lcg_scaled(&state);
        b = lcg_scaled(&state);
        q = 0;
        s = vt_q16_div(a, b, &q);
        h = fnv_s32(fnv_status(h, s), q);
    }
    s = vt_q16_div(1, 1, NULL);
    h = fnv_status(h, s);
    report("q16_div", h);

    /* vt_isqrt_u64: edges, then 64-bit values of random magnitude. */
    h = FNV_BASIS;
    state = 3u;
    for (i = 0; i < sizeof edges64 / sizeof edges64[0]; ++i) {
        h = fnv_u32(h, vt_isqrt_u64(edges64[i]));
    }
    for (i = 0; i < N_RANDOM; ++i) {
        x = (uint64_t)lcg(&state) << 32;
        x |= lcg(&state);
        k = lcg(&state) >> 26; /* 0..63 */
        h = fnv_u32(h, vt_isqrt_u64(x >> k));
    }
    report("isqrt_u64", h);
}

/* ---------------------------------------------------------------- pipeline */
static uint32_t fnv_box(uint32_t h, const vt_box *b)
{
    h = fnv_s32(h, b->left);
    h = fnv_s32(h, b->top);
    h = fnv_s32(h, b->right);
    return fnv_s32(h, b->bottom);
}

static void line_box(const vt_box *b)
{
    fw_line_s32(b->left);
    fw_line_str(" ");
    fw_line_s32(b->top);
    fw_line_str(" ");
    fw_line_s32(b->right);
    fw_line_str(" ");
    fw_line_s32(b->bottom);
}

static void line_sp(int32_t v)
{
    fw_line_str(" ");
    fw_line_s32(v);
}

/* The boxes the vehicle model gave (the fits used), of out->model_fits run. */
static int32_t fw_model_boxes(const vt_frame_out *o)
{
    int32_t i, n = 0;
    for (i = 0; i < o->n_boxes && i < VT_MAX_BOXES; ++i) {
        n += o->boxes[i].source == VT_SRC_MODEL;
    }
    return n;
}

/* One vt_frame_out into h (the recipe tests/test_firmware.py mirrors), printing a
 * line per road area, box and track. */
static uint32_t hash_frame_out(uint32_t h, vt_status s, const vt_frame_out *o)
{
    int32_t i, f = o->frame;
    const vt_lane_result *ln = &o->lanes;
    h = fnv_status(h, s);
    h = fnv_s32(fnv_s32(h, o->frame), o->detection_frame);
    h = fnv_s32(fnv_s32(h, o->lanes_ran), o->lane_status);
    h = fnv_s32(fnv_s32(fnv_s32(h, ln->shift), ln->w), ln->h);
    h = fnv_s32(fnv_s32(h, ln->vp_known), ln->vp_y);
    for (i = 0; i < VT_LANE_SLOTS; ++i) {
        h = fnv_s32(fnv_s32(h, ln->lines[i].state), ln->lines[i].n_verts);
        h = fnv_s32(fnv_s32(h, ln->lines[i].xb), ln->lines[i].slope);
    }
    h = fnv_s32(fnv_s32(h, o->road_source), o->road.valid);
    fw_line_str("road ");
    fw_line_s32(f);
    line_sp(o->lane_status);
    line_sp(o->road.valid);
    line_sp(o->road.y_top);
    line_sp(o->road.y_bottom);
    line_sp(o->road_source);
    fw_line_end();
    if (o->road.valid) {
        h = fnv_s32(fnv_s32(fnv_s32(h, o->road.y_top), o->road.y_bottom), o->road.height);
        for (i = 0; i < o->road.height && i < VT_MAX_HEIGHT; ++i) {
            h = fnv_s16(h, o->road.x_left[i]);
            h = fnv_s16(h, o->road.x_right[i]);
            h = fnv_s16(h, o->road.lane_width[i]);
        }
    }
    h = fnv_s32(h, o->n_hyp);
    for (i = 0; i < o->n_hyp && i < VT_MAX_HYPOTHESES; ++i) {
        h = fnv_s32(fnv_s32(fnv_s32(h, o->hyp[i].row), o->hyp[i].x_start), o->hyp[i].x_end);
    }
    h = fnv_s32(fnv_s32(h, o->n_boxes), o->flow_ready);
    h = fnv_s32(h, o->model_fits);
    fw_line_str("boxes ");
    fw_line_s32(f);
    line_sp(o->n_boxes);
    fw_line_end();
    for (i = 0; i < o->n_boxes && i < VT_MAX_BOXES; ++i) {
        h = fnv_box(h, &o->boxes[i].box);
        h = fnv_s32(fnv_s32(h, o->boxes[i].source), o->boxes[i].score);
        fw_line_str("box ");
        fw_line_s32(f);
        fw_line_str(" ");
        line_box(&o->boxes[i].box);
        line_sp(o->boxes[i].source);
        fw_line_end();
    }
    fw_line_str("model ");
    fw_line_s32(f);
    line_sp(o->model_fits);
    line_sp(fw_model_boxes(o));
    fw_line_end();
    h = fnv_s32(h, o->n_tracks);
    fw_line_str("tracks ");
    fw_line_s32(f);
    line_sp(o->n_tracks);
    fw_line_end();
    for (i = 0; i < o->n_tracks && i < VT_MAX_TRACKS; ++i) {
        const vt_pipe_track *t = &o->tracks[i];
        h = fnv_s32(fnv_s32(h, t->id), t->state);
        h = fnv_box(h, &t->box);
        h = fnv_s32(fnv_s32(h, t->vx), t->vy);
        h = fnv_s32(fnv_s32(fnv_s32(h, t->distance_mm), t->ttc_ms), t->warning);
        h = fnv_s32(h, t->source);
        h = fnv_s32(fnv_s32(h, t->ttc_points_q16), t->ttc_fused_q16);
        fw_line_str("track ");
        fw_line_s32(f);
        line_sp(t->id);
        line_sp(t->state);
        fw_line_str(" ");
        line_box(&t->box);
        line_sp(t->vx);
        line_sp(t->vy);
        line_sp(t->distance_mm);
        line_sp(t->ttc_ms);
        line_sp(t->warning);
        line_sp(t->ttc_points_q16);
        line_sp(t->ttc_fused_q16);
        line_sp(t->source);
        fw_line_end();
    }
    return h;
}

#if FW_CLIP_N != 5
#error "run_pipeline() names one checksum and insns line per clip frame: update g_step_names"
#endif
static const char *const g_step_names[2][FW_CLIP_N] = {
    {"step_frame0", "step_frame1", "step_frame2", "step_frame3", "step_frame4"},
    {"step_full0", "step_full1", "step_full2", "step_full3", "step_full4"}};
static const char *const g_out_names[2][FW_CLIP_N] = {
    {"frame_out0", "frame_out1", "frame_out2", "frame_out3", "frame_out4"},
    {"full_out0", "full_out1", "full_out2", "full_out3", "full_out4"}};

/* The whole system through its one call: a static vt_pipeline with the default
 * configuration but lanes on every frame (as a detector keeps its lane tracker
 * fed), and the clip's camera, so over the 5-frame clip detection runs on frame 0
 * in the lanes' road, the tracker follows on frames 1 to 4, and every track gets
 * its distance, TTC and warning. Each frame's vt_frame_out is hashed into
 * its own checksum line and all of them, after the init statuses, into
 * `checksum pipeline`; `checksum all` stays the primitives' alone. The stack
 * high-water mark of one step is measured by painting the stack right before
 * each step and scanning it right after (the largest of the steps); it counts
 * from the top of the stack, so main's and this function's frames (a few dozen
 * bytes) are included: an upper bound, the reserve a step needs.
 * full = 1: the second run, every hypothesis source built: the whole-road detector
 * with the core's default HOG model (c/tables, in flash) -- classified shadow
 * hypotheses and classifier windows -- detecting on every second frame (0, 2, 4;
 * the frames between are tracked: only there can a confirmed track coast, since on
 * a detection frame a track no box matches is kept only if its template still
 * correlates), the overtaking stage on both sides (every frame; it reports from
 * frame 1 on), the block-scale TTC after the tracker with lag 2 (frame 2 is measured
 * against frame 0), and the vehicle model (VT_SRC_MODEL, unless FW_MODEL is 0) for
 * the tracks the previous step left coasting: the lead car's track, confirmed on
 * frame 2 (three hits), loses its ROI search on frame 3 and coasts, and on frame 4
 * the GA refits it (a `model F FITS USED` line per frame: fits run, boxes of source
 * VT_SRC_MODEL); its checksums full_out0..4 and pipeline_full. */
static uint32_t g_stack_step;

static void run_pipeline(int32_t full)
{
    uint32_t h, hf, used;
    vt_image_u8 img;
    vt_status s;
    int32_t f;
    const vt_svm_model *model = NULL;

    fw_line_str("clip ");
    fw_line_u32(FW_CLIP_W);
    fw_line_str("x");
    fw_line_u32(FW_CLIP_H);
    fw_line_str("x");
    fw_line_u32(FW_CLIP_N);
    fw_line_end();

    h = fnv_status(FNV_BASIS, vt_pipeline_cfg_default(&g_pipe_cfg));
    g_pipe_cfg.lanes_every_frame = 1;
    /* The clip's camera: KITTI's (the default camera) with the principal point moved
     * by the crop (x 300, y 118 of the 1242x375 frames); 10 frames/s is the range
     * configuration's default frame_dt. */
    h = fnv_status(h, vt_camera_cfg_default(&g_cam));
    g_cam.img_w = FW_CLIP_W;
    g_cam.img_h = FW_CLIP_H;
    g_cam.cx -= 300 * VT_Q16_ONE;
    g_cam.cy -= 118 * VT_Q16_ONE;
    if (full) {
        g_pipe_cfg.sources = VT_SRC_SHADOW | VT_SRC_CLASSIFIER | VT_SRC_FLOW;
        g_pipe_cfg.detect_every = 2; /* frames 0, 2, 4: tracking alone in between */
        g_pipe_cfg.flow.sides = VT_FLOW_SIDE_BOTH;
        g_pipe_cfg.flow.min_age = 1; /* report from frame 1: the clip has five frames */
        g_pipe_cfg.ttc.lag = 2;      /* likewise: a TTC from frame 2 on */
#if FW_MODEL
        g_pipe_cfg.sources |= VT_SRC_MODEL;
#endif
        h = fnv_status(h, vt_svm_default_model(VT_DESC_HOG, &model));
        if (model != NULL) {
            /* Windows of the model's own size a cell apart, as pyvehtrack's
             * Pipeline(model=...) lays them (scored from the prepared HOG band;
             * other sizes would be resampled window by window, ~10x the work). */
            g_pipe_cfg.fulldet.win.n_sizes = 1;
            g_pipe_cfg.fulldet.win.size[0] = model->win_w;
            g_pipe_cfg.fulldet.win.step_q8 = 8 * 256 / model->win_w;
            g_pipe_cfg.fulldet.window_score_min = model->threshold_q16;
            g_pipe_cfg.fulldet.shadow_score_min = model->threshold_q16;
        }
    }
    h = fnv_status(h, vt_pipeline_init(&g_pipe, &g_pipe_cfg, &g_cam, model));
    if (full) {
        h = fnv_status(h, vt_pipeline_set_cls_ws(&g_pipe, &g_cls_ws, NULL));
        h = fnv_status(h, vt_pipeline_set_flow_ws(&g_pipe, &g_flow));
        h = fnv_status(h, vt_pipeline_set_ttc_ws(&g_pipe, &g_ttc));
#if FW_MODEL
        h = fnv_status(h, vt_pipeline_set_model_ws(&g_pipe, &g_model_ws));
#endif
    }
    img.w = FW_CLIP_W;
    img.h = FW_CLIP_H;
    img.stride = FW_CLIP_W;
    g_stack_step = 0;
    for (f = 0; f < FW_CLIP_N; ++f) {
        img.px = fw_clip[f];
        fw_stack_paint();
        start();
        s = vt_pipeline_step(&g_pipe, &img, &g_out);
        stop(g_step_names[full][f]);
        used = fw_stack_used();
        g_stack_step = used > g_stack_step ? used : g_stack_step;
        hf = hash_frame_out(FNV_BASIS, s, &g_out);
        print_checksum(g_out_names[full][f], hf);
        h = fnv_u32(h, hf);
    }
    print_checksum(full ? "pipeline_full" : "pipeline", h);
}

/* The reverse hand-over (issue 9; IVVI paper sec. 3, last paragraph) on a scene made
 * here, so it needs no flash: a 160x120 frame of static texture, and a textured 40x30
 * "car" (its texture moves with it) 2 px right and 1 px down per frame, as a car the
 * ego car overtakes on the right. Its exact box is the caller's detection on every
 * frame while it is wholly in view (vt_pipeline_step_dets), flow at level 0 on both
 * sides. The tracker confirms it and the pipeline hands it to the flow stage as it
 * reaches the right border (frame 13 of 32); the flow stage then moves the box by the
 * mean flow of its cells (over this static background, which a real ego car would see
 * flow outward too, the box falls behind the car: the scene is a proof of equal bits,
 * not of tracking quality, which tests/test_pipeline_handover.py measures). Per frame the status and every track (id, state, box, velocity, source) go into
 * `checksum pipeline_handover`, which tests/test_firmware.py recomputes on the host;
 * `handover frames N` counts the frames that reported a VT_PIPE_HANDOVER track. */
#define HO_W 160
#define HO_H 120
#define HO_N 32
static uint8_t g_ho_frame[HO_W * HO_H];
static vt_box g_ho_det;

/* xorshift32 of a pixel's coordinates: the texture (both sides compute it alike). */
static uint32_t ho_tex(uint32_t x, uint32_t y, uint32_t salt)
{
    uint32_t v = (x * 73856093u) ^ (y * 19349663u) ^ salt;
    v ^= v << 13;
    v ^= v >> 17;
    v ^= v << 5;
    return v;
}

static void ho_make_frame(int32_t f)
{
    int32_t x, y, l = 92 + 2 * f, t = 50 + f;
    for (y = 0; y < HO_H; ++y) {
        for (x = 0; x < HO_W; ++x) {
            uint32_t v;
            if (x >= l && x < l + 40 && y >= t && y < t + 30) {
                v = 150u + (ho_tex((uint32_t)(x - l), (uint32_t)(y - t), 0x5eedu) & 63u);
            } else {
                v = 40u + (ho_tex((uint32_t)x, (uint32_t)y, 0xba5eu) & 63u);
            }
            g_ho_frame[y * HO_W + x] = (uint8_t)v;
        }
    }
    g_ho_det.left = l;
    g_ho_det.top = t;
    g_ho_det.right = l + 39;
    g_ho_det.bottom = t + 29;
}

static void run_handover(void)
{
    uint32_t h;
    vt_image_u8 img;
    vt_status s;
    int32_t f, i, n_ho = 0, seen;
    h = fnv_status(FNV_BASIS, vt_pipeline_cfg_default(&g_pipe_cfg));
    g_pipe_cfg.sources = VT_SRC_FLOW;
    g_pipe_cfg.flow.level = 0;
    g_pipe_cfg.flow.sides = VT_FLOW_SIDE_BOTH;
    h = fnv_status(h, vt_pipeline_init(&g_pipe, &g_pipe_cfg, NULL, NULL));
    h = fnv_status(h, vt_pipeline_set_flow_ws(&g_pipe, &g_flow));
    img.px = g_ho_frame;
    img.w = HO_W;
    img.h = HO_H;
    img.stride = HO_W;
    for (f = 0; f < HO_N; ++f) {
        ho_make_frame(f);
        s = vt_pipeline_step_dets(&g_pipe, &img, &g_ho_det, g_ho_det.right < HO_W ? 1 : 0, &g_out);
        h = fnv_s32(fnv_status(h, s), g_out.n_tracks);
        seen = 0;
        for (i = 0; i < g_out.n_tracks && i < VT_MAX_TRACKS; ++i) {
            const vt_pipe_track *t = &g_out.tracks[i];
            h = fnv_s32(fnv_s32(h, t->id), t->state);
            h = fnv_s32(fnv_s32(fnv_s32(fnv_s32(h, t->box.left), t->box.top), t->box.right), t->box.bottom);
            h = fnv_s32(fnv_s32(fnv_s32(h, t->vx), t->vy), t->source);
            seen |= t->state == VT_PIPE_HANDOVER;
        }
        n_ho += seen;
    }
    fw_line_str("handover frames ");
    fw_line_s32(n_ho);
    fw_line_end();
    print_checksum("pipeline_handover", h);
}

/* The CNN detector (cnn.h): the model of cnn_data.h (static const, in flash;
 * tools/gen_cnn_table.py writes it) run twice through vt_cnn_detect_frame. First on a
 * synthetic FW_CNN_FRAME_W x FW_CNN_FRAME_H frame drawn here (cnn_make_frame; the
 * generator's cnn_frame() is the same recipe: a textured road ramp and three dark
 * textured "cars" with a bright window band and a black shadow row pair) with
 * fw_cnn_cfg_synth (the model's settings from level 0: the frame is small; with the
 * contrast stretch, cnn.h's stretch_tail_permille, so that path runs here too); then on
 * the first clip frame in flash with the model's own settings fw_cnn_cfg.
 * `checksum cnn_input` is the synthetic frame's bytes; per run, `checksum cnn_NAME`
 * folds the model and cfg checks, vt_cnn_frame_work_bytes (and that it is the
 * header's size), a call with one byte too few (VT_E_CAPACITY), then the detection's
 * status, box count, peak count and every box (l, t, r, b, heat), printed as
 * `cnn NAME N PEAKS` and `cnn_box NAME I L T R B HEAT` lines; tests/test_firmware.py
 * recomputes them through pyvehtrack.cnn. One work buffer serves both runs. */
#if FW_CNN_CLIP_W != FW_CLIP_W || FW_CNN_CLIP_H != FW_CLIP_H
#error "cnn_data.h was generated for another clip size: rerun tools/gen_cnn_table.py"
#endif
static uint8_t g_cnn_frame[FW_CNN_FRAME_W * FW_CNN_FRAME_H];
static uint8_t g_cnn_work[FW_CNN_WORK_BYTES];
static vt_cnn_box g_cnn_boxes[FW_CNN_MAX_BOXES];

static void cnn_make_frame(void)
{
    static const int32_t cars[3][4] = {{18, 44, 40, 30}, {84, 36, 52, 38}, {128, 62, 26, 20}};
    int32_t x, y, c;
    for (y = 0; y < FW_CNN_FRAME_H; ++y) {
        for (x = 0; x < FW_CNN_FRAME_W; ++x) {
            uint32_t v = 70u + (uint32_t)(y * 80 / FW_CNN_FRAME_H) + (ho_tex((uint32_t)x, (uint32_t)y, 0xc0deu) & 31u);
            g_cnn_frame[y * FW_CNN_FRAME_W + x] = (uint8_t)v;
        }
    }
    for (c = 0; c < 3; ++c) {
        int32_t l = cars[c][0], t = cars[c][1], w = cars[c][2], h = cars[c][3];
        for (y = t; y < t + h && y < FW_CNN_FRAME_H; ++y) {
            for (x = l; x < l + w && x < FW_CNN_FRAME_W; ++x) {
                uint32_t tx = ho_tex((uint32_t)(x - l), (uint32_t)(y - t), 0xca75u) & 31u, v;
                if (y - t < h / 3) {
                    v = 170u + tx;
                } else if (y - t >= h - 2) {
                    v = 8u;
                } else {
                    v = 30u + tx;
                }
                g_cnn_frame[y * FW_CNN_FRAME_W + x] = (uint8_t)v;
            }
        }
    }
}

static void run_cnn_on(const char *name, const char *sum_name, const vt_cnn_cfg *cfg, const uint8_t *img,
                       int32_t w, int32_t h, size_t header_need)
{
    uint32_t hs = FNV_BASIS;
    size_t need = 0;
    int32_t i, n = -1, n_peaks = -1;
    vt_status s;
    hs = fnv_status(hs, vt_cnn_check_model(&fw_cnn_model));
    hs = fnv_status(hs, vt_cnn_cfg_check(cfg));
    s = vt_cnn_frame_work_bytes(&fw_cnn_model, cfg, w, h, &need);
    hs = fnv_u32(fnv_status(hs, s), (uint32_t)need);
    hs = fnv_s32(hs, need == header_need); /* the header's size is the core's */
    /* one byte short: refused, nothing decoded */
    s = vt_cnn_detect_frame(&fw_cnn_model, cfg, img, w, h, w, g_cnn_work, need - 1, g_cnn_boxes,
                            FW_CNN_MAX_BOXES, &n, &n_peaks);
    hs = fnv_s32(fnv_s32(fnv_status(hs, s), n), n_peaks);
    start();
    s = vt_cnn_detect_frame(&fw_cnn_model, cfg, img, w, h, w, g_cnn_work, sizeof g_cnn_work, g_cnn_boxes,
                            FW_CNN_MAX_BOXES, &n, &n_peaks);
    stop(sum_name);
    hs = fnv_s32(fnv_s32(fnv_status(hs, s), n), n_peaks);
    fw_line_str("cnn ");
    fw_line_str(name);
    line_sp(n);
    line_sp(n_peaks);
    fw_line_end();
    for (i = 0; i < n && i < FW_CNN_MAX_BOXES; ++i) {
        const vt_cnn_box *b = &g_cnn_boxes[i];
        hs = fnv_s32(fnv_s32(fnv_s32(fnv_s32(fnv_s32(hs, b->l), b->t), b->r), b->b), b->score);
        fw_line_str("cnn_box ");
        fw_line_str(name);
        line_sp(i);
        line_sp(b->l);
        line_sp(b->t);
        line_sp(b->r);
        line_sp(b->b);
        line_sp(b->score);
        fw_line_end();
    }
    print_checksum(sum_name, hs);
}

static void run_cnn(void)
{
    uint32_t h = FNV_BASIS;
    int32_t i;
    cnn_make_frame();
    for (i = 0; i < FW_CNN_FRAME_W * FW_CNN_FRAME_H; ++i) {
        h = fnv_u8(h, g_cnn_frame[i]);
    }
    print_checksum("cnn_input", h);
    run_cnn_on("synth", "cnn_synth", &fw_cnn_cfg_synth, g_cnn_frame, FW_CNN_FRAME_W, FW_CNN_FRAME_H, FW_CNN_WORK_SYNTH);
    run_cnn_on("clip0", "cnn_clip0", &fw_cnn_cfg, fw_clip[0], FW_CLIP_W, FW_CLIP_H, FW_CNN_WORK_CLIP);
}

int main(void)
{
    uint32_t stack_primitives, stack_pipeline, stack_cnn;

    fw_line_str("core " FW_CORE_NAME);
    fw_line_end();
    fw_line_str("frame ");
    fw_line_u32(W);
    fw_line_str("x");
    fw_line_u32(H);
    fw_line_end();
    print_config();

    check_frame();
    check_grad("filter_h101", vt_filter_h101, g_h101);
    check_grad("sobel_x", vt_sobel_x, g_sobx);
    check_grad("sobel_y", vt_sobel_y, g_soby);
    check_pyr();
    check_integral_and_boxes();
    check_patches();
    check_sincos();
    check_fixed();

    fw_line_str("checksum all ");
    fw_line_hex32(g_all);
    fw_line_end();

    /* The pipeline's own stack: paint again, run, scan. */
    stack_primitives = fw_stack_used();
    fw_stack_paint();
    run_pipeline(0);
    run_pipeline(1);
    run_handover();
    stack_pipeline = fw_stack_used();
    fw_stack_paint();
    run_cnn();
    stack_cnn = fw_stack_used();

    /* The RAM bill, from sizeof: the static outputs, then the stack. */
    print_size("ram filter_h101", (uint32_t)sizeof g_h101);
    print_size("ram sobel_x", (uint32_t)sizeof g_sobx);
    print_size("ram sobel_y", (uint32_t)sizeof g_soby);
    print_size("ram pyr_down", (uint32_t)sizeof g_pyr);
    print_size("ram integral", (uint32_t)sizeof g_ii);
    print_size("ram pipeline", (uint32_t)sizeof g_pipe);
    print_size("ram pipeline.lane", (uint32_t)sizeof g_pipe.lane);
    print_size("ram pipeline.detect", (uint32_t)(sizeof g_pipe.detect + sizeof g_pipe.det));
    print_size("ram pipeline.tracker", (uint32_t)sizeof g_pipe.tracker);
    print_size("ram pipeline.range", (uint32_t)sizeof g_pipe.range);
    print_size("ram pipeline.cfg", (uint32_t)sizeof g_pipe.cfg);
    print_size("ram frame_out", (uint32_t)sizeof g_out);
    print_size("ram pipe_cls_ws", (uint32_t)sizeof g_cls_ws);
    print_size("ram flow_state", (uint32_t)sizeof g_flow);
    print_size("ram ttc_state", (uint32_t)sizeof g_ttc);
#if FW_MODEL
    print_size("ram model_ws", (uint32_t)sizeof g_model_ws);
#endif
    print_size("ram pipeline_cfg", (uint32_t)sizeof g_pipe_cfg);
    print_size("ram cnn_frame", (uint32_t)sizeof g_cnn_frame);
    print_size("ram cnn_work", (uint32_t)sizeof g_cnn_work);
    print_size("ram cnn_boxes", (uint32_t)sizeof g_cnn_boxes);
    print_size("sizeof vt_image_u8", (uint32_t)sizeof(vt_image_u8));
    print_size("sizeof vt_road_area", (uint32_t)sizeof(vt_road_area));
    print_size("stack reserved", fw_stack_size());
    print_size("stack pipeline", stack_pipeline);
    print_size("stack step", g_stack_step);
    print_size("stack cnn", stack_cnn);
    stack_pipeline = stack_pipeline > stack_cnn ? stack_pipeline : stack_cnn;
    print_size("stack used", stack_primitives > stack_pipeline ? stack_primitives : stack_pipeline);
    fw_line_str("done");
    fw_line_end();
    return 0;
}
