/* fuzz-requires: vehtrack/cnn.h
 * fuzz_cnn.c -- the quantised CNN detector (vehtrack/cnn.h): a model whose layer meta
 * (ksize, stride, dilation, relu, cin, cout), weights, biases, multipliers, shifts,
 * side table, out_stride, threshold and heat scale come from the bytes (mostly valid,
 * each field sometimes on or past the edge of its range, arrays sometimes NULL; every
 * array an exact-size heap block, so ASan sees a read past the model's own sizes), a
 * fuzzed view (1..~40 px mostly, degenerate sizes, stride < w, px NULL), and a
 * vt_cnn_cfg mutated from its default (level 0's row band drawn too). Then:
 *   vt_cnn_cfg_at_horizon: the header's shift and push written another way, out untouched on error;
 *   vt_cnn_check_model / vt_cnn_cfg_check / vt_cnn_cfg_default: the status a mirror of
 *     the header's ranges gives;
 *   vt_cnn_out_size / vt_cnn_work_bytes / vt_cnn_frame_work_bytes (NULLs, any w, h):
 *     the documented status and, on success, the sizes the header's formulas give;
 *   vt_cnn_forward into a work buffer and an output of fuzzed sizes (exact, larger,
 *     one or more bytes short, 0, SIZE_MAX over an exact block, NULL): the documented
 *     status; on error nothing written; on success the output equal to a direct
 *     convolution written here from the header's arithmetic, and no byte past the
 *     needed work or output written (guard bytes);
 *   vt_cnn_decode of that output or of heat / side codes from the bytes (plateaus,
 *     ties), any thr, scale_shift and cap: the status; the boxes equal to a decode
 *     written here (peaks, heat descending then raster, the Q4 box formula), *n =
 *     min(cap, peaks), nothing written past boxes[*n]; on error *n = *n_peaks = 0;
 *   vt_cnn_detect_frame with a work buffer of fuzzed size at a fuzzed misalignment
 *     (guard bytes before it and after the needed bytes) and a fuzzed cap: the status;
 *     on success the boxes equal to the same detection composed here (vt_pyr_down per
 *     level, the direct forward and decode above, level 0 on its band's rows and its
 *     boxes moved down to them, clipping, vt_nms, the cap), every
 *     box inside the frame, heat descending; nothing written outside the work buffer's
 *     needed bytes or past boxes[*n]; on error boxes untouched and *n = *n_peaks = 0.
 * Calls the harness predicts to succeed with more than WORK_BUDGET multiply-adds are
 * skipped (64-channel layers on a large view would make one input take seconds). */
#include "fuzz.h"
#include "vehtrack/cnn.h"
#include "vehtrack/image.h"
#include "vehtrack/windows.h"

#define GUARD 0xA5u
#define WORK_BUDGET 4000000
#define ALLOC_MAX ((size_t)1 << 22)

/* The model's arrays: up to 8 layers x 4 arrays + the table, past fz's 16 blocks. */
#define MAX_BLK 96
static void *g_blk[MAX_BLK];
static int g_nblk;

static void *blk(size_t n)
{
    void *p;
    if (g_nblk == MAX_BLK) {
        abort();
    }
    p = malloc(n ? n : 1);
    if (p == NULL) {
        abort();
    }
    g_blk[g_nblk++] = p;
    return p;
}

static void blk_free(void)
{
    while (g_nblk > 0) {
        free(g_blk[--g_nblk]);
    }
}

#ifdef CNN_FUZZ_STATS /* -DCNN_FUZZ_STATS: how often each call succeeds (a harness check) */
#include <stdio.h>
static long g_st[8];
static void st_print(void)
{
    fprintf(stderr, "stats: model_ok %ld fwd_ok %ld fwd_err %ld dec_ok %ld dec_boxes %ld det_ok %ld det_boxes %ld det_err %ld\n",
            g_st[0], g_st[1], g_st[2], g_st[3], g_st[4], g_st[5], g_st[6], g_st[7]);
}
#define STAT(i, c) (g_st[i] += (c))
#else
#define STAT(i, c) ((void)0)
#endif

/* NULL-argument bits: none in 7 of 8 calls. */
static uint8_t fz_nulls(fz *f)
{
    uint8_t b = fz_u8(f);
    return (b & 0xE0u) == 0xE0u ? (uint8_t)(b & 0x7Fu) : 0u;
}

/* ---------------------------------------------------------------- the model */
typedef struct {
    vt_cnn_model m;
    int ok; /* the header's verdict, mirrored here */
} model_t;

static uint32_t lcg_next(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return *s;
}

static void model(fz *f, model_t *mt)
{
    vt_cnn_model *m = &mt->m;
    uint8_t sel = fz_u8(f);
    int32_t n, i, c, prod = 1, cin = 1;
    memset(m, 0, sizeof *m);
    m->n_layers = (uint8_t)(sel < 240 ? fz_range(f, 1, 4) : fz_edge(f, VT_CNN_MAX_LAYERS));
    n = m->n_layers < VT_CNN_MAX_LAYERS ? m->n_layers : VT_CNN_MAX_LAYERS;
    for (i = 0; i < n; i++) {
        vt_cnn_layer *L = &m->layer[i];
        int last = i == m->n_layers - 1;
        uint8_t b = fz_u8(f), wmode, arr_bad;
        int32_t k, ci, co;
        size_t nw, j;
        int8_t *w;
        int32_t *bias, *mult;
        uint8_t *shift;
        if (b < 232) { /* valid meta */
            L->ksize = (fz_u8(f) & 1) ? 3 : 1;
            L->stride = (uint8_t)(1 + (fz_u8(f) & 1));
            L->dilation = L->ksize == 3 ? (uint8_t)(1 + (fz_u8(f) & 1)) : 1;
            L->relu = last ? 0 : 1;
            L->cin = (uint16_t)cin;
            L->cout = last ? VT_CNN_OUT_CH
                           : (uint16_t)(fz_u8(f) < 240 ? fz_range(f, 1, 8) : fz_range(f, 1, VT_CNN_MAX_CH));
        } else { /* one field or all from the bytes, on or past its edge */
            L->ksize = (uint8_t)fz_edge(f, 3);
            L->stride = (uint8_t)fz_edge(f, 2);
            L->dilation = (uint8_t)fz_edge(f, 2);
            L->relu = (uint8_t)fz_edge(f, 1);
            L->cin = (uint16_t)(fz_u8(f) < 128 ? cin : fz_edge(f, VT_CNN_MAX_CH));
            L->cout = (uint16_t)(fz_u8(f) < 128 ? (last ? VT_CNN_OUT_CH : fz_range(f, 1, 8))
                                                : fz_edge(f, VT_CNN_MAX_CH));
        }
        /* arrays of the meta's sizes (one element when the meta is out of range: a core
         * that reads them before refusing the meta reads past the block) */
        k = L->ksize == 1 || L->ksize == 3 ? L->ksize : 1;
        ci = L->cin >= 1 && L->cin <= VT_CNN_MAX_CH ? L->cin : 1;
        co = L->cout >= 1 && L->cout <= VT_CNN_MAX_CH ? L->cout : 1;
        nw = (size_t)co * (size_t)k * (size_t)k * (size_t)ci;
        w = (int8_t *)blk(nw);
        bias = (int32_t *)blk((size_t)co * sizeof(int32_t));
        mult = (int32_t *)blk((size_t)co * sizeof(int32_t));
        shift = (uint8_t *)blk((size_t)co);
        wmode = fz_u8(f);
        if ((wmode & 3) == 0) { /* raw bytes, tiled */
            size_t len = f->n < nw ? f->n : nw;
            for (j = 0; j < nw; j++) {
                w[j] = len ? (int8_t)f->d[j % len] : 0;
            }
            f->d += len;
            f->n -= len;
        } else if ((wmode & 3) == 1) { /* a constant (-128 and 127 included) */
            int8_t v = (int8_t)fz_u8(f);
            memset(w, (uint8_t)v, nw);
        } else { /* an LCG from a seed */
            uint32_t s = fz_u32(f);
            for (j = 0; j < nw; j++) {
                w[j] = (int8_t)(lcg_next(&s) >> 24);
            }
        }
        for (c = 0; c < co; c++) {
            uint8_t q = fz_u8(f);
            if (q < 200) {
                bias[c] = (int32_t)(int8_t)fz_u8(f) * 64;
                shift[c] = (uint8_t)fz_range(f, 6, 20);
                mult[c] = fz_range(f, 1, 4096);
            } else {
                static const int32_t be[] = {VT_CNN_BIAS_MAX, -VT_CNN_BIAS_MAX, VT_CNN_BIAS_MAX + 1,
                                             -VT_CNN_BIAS_MAX - 1, INT32_MIN, INT32_MAX, 0, -1};
                bias[c] = be[fz_u8(f) & 7];
                shift[c] = (uint8_t)(fz_u8(f) < 128 ? fz_range(f, 0, 63) : fz_u8(f));
                mult[c] = fz_edge(f, INT32_MAX - 1);
            }
        }
        arr_bad = fz_u8(f); /* 1 in 64 each: an array NULL */
        L->w = (arr_bad & 0xFC) == 0xFC ? NULL : w;
        L->bias = (arr_bad & 0xFC) == 0xF8 ? NULL : bias;
        L->mult = (arr_bad & 0xFC) == 0xF4 ? NULL : mult;
        L->shift = (arr_bad & 0xFC) == 0xF0 ? NULL : shift;
        prod = prod < 65536 ? prod * L->stride : prod; /* out_stride below: the product, as uint8 */
        cin = L->cout;
    }
    m->out_stride = (uint8_t)(fz_u8(f) < 235 ? prod : fz_u8(f));
    m->heat_thr = (int8_t)fz_u8(f);
    m->heat_scale_q16 = fz_u8(f) < 235 ? 65536 : fz_edge(f, VT_CNN_HEAT_SCALE_MAX);
    {
        uint16_t *lut = (uint16_t *)blk(4 * 256 * sizeof(uint16_t));
        uint8_t lm = fz_u8(f);
        for (i = 0; i < 4 * 256; i++) {
            lut[i] = (lm & 3) == 0   ? (uint16_t)(i % 256 * 16)
                     : (lm & 3) == 1 ? (uint16_t)((uint32_t)(i % 256) * 257u) /* up to 65535 */
                     : (lm & 3) == 2 ? (uint16_t)(lm * 8u)
                                     : (uint16_t)(fz_u8(f) * 40u);
        }
        m->side_lut = lm >= 250 ? NULL : lut;
    }
}

/* The header's rules for vt_cnn_check_model. */
static int model_ok(const vt_cnn_model *m)
{
    int32_t i, c, prod = 1;
    if (m->n_layers < 1 || m->n_layers > VT_CNN_MAX_LAYERS || m->side_lut == NULL || m->heat_scale_q16 < 1 ||
        m->heat_scale_q16 > VT_CNN_HEAT_SCALE_MAX) {
        return 0;
    }
    for (i = 0; i < m->n_layers; i++) {
        const vt_cnn_layer *L = &m->layer[i];
        int last = i == m->n_layers - 1;
        if (!(L->ksize == 1 || L->ksize == 3) || !(L->stride == 1 || L->stride == 2) ||
            !(L->dilation == 1 || L->dilation == 2) || (L->ksize == 1 && L->dilation != 1) ||
            L->relu != (last ? 0 : 1) || L->cin < 1 || L->cin > VT_CNN_MAX_CH || L->cout < 1 ||
            L->cout > VT_CNN_MAX_CH || (i == 0 && L->cin != 1) || (i > 0 && L->cin != m->layer[i - 1].cout) ||
            (last && L->cout != VT_CNN_OUT_CH) || L->w == NULL || L->bias == NULL || L->mult == NULL ||
            L->shift == NULL) {
            return 0;
        }
        for (c = 0; c < L->cout; c++) {
            if (L->bias[c] < -VT_CNN_BIAS_MAX || L->bias[c] > VT_CNN_BIAS_MAX || L->mult[c] < 1 ||
                L->shift[c] < 1 || L->shift[c] > 62) {
                return 0;
            }
        }
        prod *= L->stride;
    }
    return prod == m->out_stride;
}

static int dims_ok(int32_t w, int32_t h)
{
    return w >= 1 && h >= 1 && w <= VT_MAX_WIDTH && h <= VT_MAX_HEIGHT;
}

/* The header's sizes for a w x h input (valid model and dims): each layer's ceil, its
 * output bytes, the two ping-pong regions, the multiply-adds. */
typedef struct {
    int32_t gw, gh;
    size_t r0, r1, out;
    int64_t macs;
} plan_t;

static plan_t plan(const vt_cnn_model *m, int32_t w, int32_t h)
{
    plan_t p;
    int32_t i;
    memset(&p, 0, sizeof p);
    for (i = 0; i < m->n_layers; i++) {
        const vt_cnn_layer *L = &m->layer[i];
        size_t bytes;
        w = (w + L->stride - 1) / L->stride;
        h = (h + L->stride - 1) / L->stride;
        bytes = (size_t)w * (size_t)h * L->cout;
        p.macs += (int64_t)w * h * L->cout * L->ksize * L->ksize * L->cin;
        if (i == m->n_layers - 1) {
            p.out = bytes;
        } else if (i & 1) {
            p.r1 = bytes > p.r1 ? bytes : p.r1;
        } else {
            p.r0 = bytes > p.r0 ? bytes : p.r0;
        }
    }
    p.gw = w;
    p.gh = h;
    return p;
}

/* ---------------------------------------------------------------- the oracle */
/* floor(v / 2^s), 0 <= s <= 62, for any int64 v whose negation fits */
static int64_t floor_div_pow2(int64_t v, int32_t s)
{
    int64_t d = (int64_t)1 << s;
    return v >= 0 ? v / d : -((-v + d - 1) / d);
}

/* The forward pass as the header states it, one output value at a time. */
static void ref_forward(const vt_cnn_model *m, const uint8_t *img, int32_t w, int32_t h, int32_t stride,
                        int8_t *out)
{
    plan_t p = plan(m, w, h);
    size_t cap = p.r0 > p.r1 ? p.r0 : p.r1;
    uint8_t *a = (uint8_t *)malloc(cap ? cap : 1), *b = (uint8_t *)malloc(cap ? cap : 1);
    const uint8_t *in = img;
    size_t rs = (size_t)stride;
    int32_t i, iw = w, ih = h;
    if (a == NULL || b == NULL) {
        abort();
    }
    for (i = 0; i < m->n_layers; i++) {
        const vt_cnn_layer *L = &m->layer[i];
        int32_t k = L->ksize, s = L->stride, d = L->dilation, cin = L->cin, cout = L->cout;
        int32_t ow = (iw + s - 1) / s, oh = (ih + s - 1) / s, ox, oy, co, ky, kx, ci;
        int last = i == m->n_layers - 1;
        uint8_t *dst = (i & 1) ? b : a;
        for (oy = 0; oy < oh; oy++) {
            for (ox = 0; ox < ow; ox++) {
                for (co = 0; co < cout; co++) {
                    int64_t acc = L->bias[co], q;
                    for (ky = 0; ky < k; ky++) {
                        for (kx = 0; kx < k; kx++) {
                            int32_t iy = k == 1 ? oy * s : oy * s + (ky - 1) * d;
                            int32_t ix = k == 1 ? ox * s : ox * s + (kx - 1) * d;
                            if (iy < 0 || iy >= ih || ix < 0 || ix >= iw) {
                                continue; /* zero padding */
                            }
                            for (ci = 0; ci < cin; ci++) {
                                acc += (int64_t)L->w[(((size_t)co * k + ky) * k + kx) * cin + ci] *
                                       in[(size_t)iy * rs + (size_t)ix * cin + ci];
                            }
                        }
                    }
                    FZ_ASSERT(acc > INT32_MIN && acc < INT32_MAX); /* the header's bound */
                    q = floor_div_pow2(acc * L->mult[co] + ((int64_t)1 << (L->shift[co] - 1)), L->shift[co]);
                    if (last) {
                        out[((size_t)oy * ow + ox) * cout + co] = (int8_t)(q < -128 ? -128 : (q > 127 ? 127 : q));
                    } else {
                        dst[((size_t)oy * ow + ox) * cout + co] = (uint8_t)(q < 0 ? 0 : (q > 255 ? 255 : q));
                    }
                }
            }
        }
        in = dst;
        rs = (size_t)ow * cout;
        iw = ow;
        ih = oh;
    }
    free(a);
    free(b);
}

static int32_t heat_at(const int8_t *out, int32_t gw, int32_t x, int32_t y)
{
    return out[((size_t)y * gw + x) * VT_CNN_OUT_CH];
}

static int is_peak(const int8_t *out, int32_t gw, int32_t gh, int32_t x, int32_t y, int32_t thr)
{
    int32_t v = heat_at(out, gw, x, y), dx, dy;
    if (v < thr) {
        return 0;
    }
    for (dy = -1; dy <= 1; dy++) {
        for (dx = -1; dx <= 1; dx++) {
            int32_t nx = x + dx, ny = y + dy;
            if ((dx || dy) && nx >= 0 && ny >= 0 && nx < gw && ny < gh && heat_at(out, gw, nx, ny) > v) {
                return 0;
            }
        }
    }
    return 1;
}

static int32_t to_px(int64_t v_q4, int32_t ss)
{
    if (ss < 0) { /* the upsampled band: v / 32 rounded half up, i.e. (v / 16) / 2 */
        return (int32_t)floor_div_pow2(v_q4 + 16, 5);
    }
    return (int32_t)floor_div_pow2(v_q4 * ((int64_t)1 << ss) + 8, 4);
}

/* A peak: its heat and raster index (qsort's order: heat descending, then raster). */
typedef struct {
    int32_t heat;
    int32_t idx;
} peak_t;

static int peak_cmp(const void *a, const void *b)
{
    const peak_t *p = (const peak_t *)a, *q = (const peak_t *)b;
    if (p->heat != q->heat) {
        return p->heat > q->heat ? -1 : 1;
    }
    return p->idx < q->idx ? -1 : (p->idx > q->idx ? 1 : 0);
}

/* Every peak's box (heat descending, raster among equal heats) into res[0 .. cap), the
 * peak count returned. */
static int32_t ref_decode(const vt_cnn_model *m, const int8_t *out, int32_t gw, int32_t gh, int32_t thr,
                          int32_t ss, vt_cnn_box *res, int32_t cap)
{
    int32_t x, y, n = 0, i;
    int32_t S = m->out_stride;
    const uint16_t *lut = m->side_lut;
    peak_t *pk = (peak_t *)malloc((size_t)gw * (size_t)gh * sizeof(peak_t));
    if (pk == NULL) {
        abort();
    }
    for (y = 0; y < gh; y++) {
        for (x = 0; x < gw; x++) {
            if (is_peak(out, gw, gh, x, y, thr)) {
                pk[n].heat = heat_at(out, gw, x, y);
                pk[n].idx = y * gw + x;
                n++;
            }
        }
    }
    qsort(pk, (size_t)n, sizeof(peak_t), peak_cmp);
    for (i = 0; i < n && i < cap; i++) {
        const int8_t *c = out + (size_t)pk[i].idx * VT_CNN_OUT_CH;
        int64_t cx = ((int64_t)(pk[i].idx % gw) * S + S / 2) * 16;
        int64_t cy = ((int64_t)(pk[i].idx / gw) * S + S / 2) * 16;
        res[i].l = to_px(cx - lut[0 * 256 + c[1] + 128], ss);
        res[i].t = to_px(cy - lut[1 * 256 + c[2] + 128], ss);
        res[i].r = to_px(cx + lut[2 * 256 + c[3] + 128], ss) - 1;
        res[i].b = to_px(cy + lut[3 * 256 + c[4] + 128], ss) - 1;
        res[i].score = c[0];
    }
    free(pk);
    return n;
}

static int same_box(const vt_cnn_box *a, const vt_cnn_box *b)
{
    return a->l == b->l && a->t == b->t && a->r == b->r && a->b == b->b && a->score == b->score;
}

static void check_guard(const uint8_t *p, size_t from, size_t to)
{
    size_t i;
    for (i = from; i < to; i++) {
        FZ_ASSERT(p[i] == GUARD);
    }
}

/* A buffer size around `need`: exact, larger, short, an edge, or SIZE_MAX. */
static size_t size_near(fz *f, size_t need)
{
    uint8_t c = fz_u8(f);
    if (c < 150) {
        return need;
    }
    if (c < 190) {
        return need + (size_t)fz_range(f, 1, 16);
    }
    if (c < 230) {
        size_t d = (size_t)fz_range(f, 1, 8);
        return need > d ? need - d : 0;
    }
    if (c < 245) {
        return 0;
    }
    return (size_t)-1;
}

/* ---------------------------------------------------------------- the calls */
static void sizes(fz *f, const model_t *mt)
{
    uint8_t nulls = fz_nulls(f);
    int32_t w = fz_size(f, 64, VT_MAX_WIDTH), h = fz_size(f, 64, VT_MAX_HEIGHT), gw = -7, gh = -7;
    size_t bytes = 7;
    vt_status s, want;
    want = (nulls & 7) || !mt->ok ? VT_E_ARG : (dims_ok(w, h) ? VT_OK : VT_E_SIZE);
    s = vt_cnn_out_size((nulls & 1) ? NULL : &mt->m, w, h, (nulls & 2) ? NULL : &gw, (nulls & 4) ? NULL : &gh);
    fz_status(s);
    FZ_ASSERT(s == want);
    if (s == VT_OK) {
        plan_t p = plan(&mt->m, w, h);
        FZ_ASSERT(gw == p.gw && gh == p.gh);
    }
    want = (nulls & 9) || !mt->ok ? VT_E_ARG : (dims_ok(w, h) ? VT_OK : VT_E_SIZE);
    s = vt_cnn_work_bytes((nulls & 1) ? NULL : &mt->m, w, h, (nulls & 8) ? NULL : &bytes);
    fz_status(s);
    FZ_ASSERT(s == want);
    if (s == VT_OK) {
        plan_t p = plan(&mt->m, w, h);
        FZ_ASSERT(bytes == p.r0 + p.r1);
    }
}

/* vt_cnn_forward; returns the output (gw x gh x 5) when it succeeded, else NULL. */
static const int8_t *forward(fz *f, const model_t *mt, const vt_image_u8 *img, int32_t *gw, int32_t *gh)
{
    uint8_t nulls = fz_nulls(f);
    int valid = mt->ok && dims_ok(img->w, img->h);
    plan_t p;
    size_t need_w = 0, need_o = 0, work_bytes, out_len, wa, oa;
    uint8_t *work;
    int8_t *out, *ref;
    vt_status s, want;
    memset(&p, 0, sizeof p);
    if (valid) {
        p = plan(&mt->m, img->w, img->h);
        need_w = p.r0 + p.r1;
        need_o = p.out;
    }
    work_bytes = size_near(f, need_w);
    out_len = size_near(f, need_o);
    wa = work_bytes <= need_w + 16 ? work_bytes : need_w; /* SIZE_MAX over an exact block */
    oa = out_len <= need_o + 16 ? out_len : need_o;
    if (wa > ALLOC_MAX || oa > ALLOC_MAX) {
        return NULL;
    }
    work = (uint8_t *)blk(wa);
    out = (int8_t *)blk(oa);
    memset(work, GUARD, wa ? wa : 1);
    memset(out, GUARD, oa ? oa : 1);
    if ((nulls & 7) || img->px == NULL || !mt->ok) {
        want = VT_E_ARG;
    } else if (!dims_ok(img->w, img->h) || img->stride < img->w) {
        want = VT_E_SIZE;
    } else if ((nulls & 8) && need_w > 0) {
        want = VT_E_ARG;
    } else if (work_bytes < need_w || out_len < need_o) {
        want = VT_E_CAPACITY;
    } else {
        want = VT_OK;
    }
    if (want == VT_OK && p.macs > WORK_BUDGET) {
        return NULL;
    }
    s = vt_cnn_forward((nulls & 1) ? NULL : &mt->m, (nulls & 2) ? NULL : img->px, img->w, img->h, img->stride,
                       (nulls & 8) ? NULL : work, work_bytes, (nulls & 4) ? NULL : out, out_len);
    fz_status(s);
    FZ_ASSERT(s == want);
    if (s != VT_OK) {
        STAT(2, 1);
        check_guard(work, 0, wa);
        check_guard((const uint8_t *)out, 0, oa);
        return NULL;
    }
    STAT(1, 1);
    check_guard(work, need_w, wa);
    check_guard((const uint8_t *)out, need_o, oa);
    ref = (int8_t *)blk(need_o);
    ref_forward(&mt->m, img->px, img->w, img->h, img->stride, ref);
    FZ_ASSERT(memcmp(ref, out, need_o) == 0);
    *gw = p.gw;
    *gh = p.gh;
    return out;
}

static void decode(fz *f, const model_t *mt, const int8_t *out, int32_t gw, int32_t gh)
{
    uint8_t nulls = fz_nulls(f), sel = fz_u8(f);
    int32_t thr, ss, cap, n = 12345, np = 12345, k, cells, want_np;
    size_t alloc, nb;
    vt_cnn_box *boxes, *ref;
    vt_status s, want;
    if (out == NULL || (sel & 1)) { /* heat and side codes from the bytes */
        uint8_t mode = fz_u8(f);
        int8_t *o;
        size_t j;
        int fits;
        gw = fz_u8(f) < 230 ? fz_range(f, 1, 24) : fz_edge(f, VT_MAX_WIDTH);
        gh = fz_u8(f) < 230 ? fz_range(f, 1, 24) : fz_edge(f, VT_MAX_HEIGHT);
        fits = dims_ok(gw, gh) && (uint64_t)gw * (uint64_t)gh <= 4096u;
        if (dims_ok(gw, gh) && !fits) {
            return; /* a grid the harness does not allocate */
        }
        nb = fits ? (size_t)gw * (size_t)gh * VT_CNN_OUT_CH : 1; /* 1: the core must refuse the grid */
        o = (int8_t *)blk(nb);
        for (j = 0; j < nb; j++) {
            uint8_t b = fz_u8(f);
            /* mode 0: raw; 1: heat of 4 values (plateaus, ties); 2: one heat */
            o[j] = (int8_t)((mode % 3 == 0 || j % VT_CNN_OUT_CH) ? b : (mode % 3 == 1 ? (b & 3) * 40 - 60 : mode));
        }
        out = o;
    }
    thr = fz_u8(f) < 200 ? fz_range(f, -130, 130) : fz_edge(f, 128);
    ss = fz_u8(f) < 230 ? fz_range(f, 0, VT_CNN_MAX_LEVEL) : fz_edge(f, VT_CNN_MAX_LEVEL);
    cap = fz_u8(f) < 200 ? fz_range(f, 1, 40) : fz_edge(f, 64);
    cells = dims_ok(gw, gh) ? gw * gh : 1;
    alloc = cap >= 1 ? (size_t)(cap < cells ? cap : cells) : 1; /* never more boxes than cells */
    if (alloc > 65536) {
        return;
    }
    boxes = (vt_cnn_box *)blk(alloc * sizeof(vt_cnn_box));
    memset(boxes, GUARD, alloc * sizeof(vt_cnn_box));
    if ((nulls & 31) || cap < 1 || ss < 0 || ss > VT_CNN_MAX_LEVEL || !mt->ok) {
        want = VT_E_ARG;
    } else if (!dims_ok(gw, gh)) {
        want = VT_E_SIZE;
    } else {
        want = VT_OK;
    }
    s = vt_cnn_decode((nulls & 16) ? NULL : &mt->m, (nulls & 1) ? NULL : out, gw, gh, thr, ss,
                      (nulls & 2) ? NULL : boxes, cap, (nulls & 4) ? NULL : &n, (nulls & 8) ? NULL : &np);
    fz_status(s);
    FZ_ASSERT(s == want);
    if (s != VT_OK) {
        FZ_ASSERT((nulls & 4) || n == 0);
        FZ_ASSERT((nulls & 8) || np == 0);
        check_guard((const uint8_t *)boxes, 0, alloc * sizeof(vt_cnn_box));
        return;
    }
    STAT(3, 1);
    STAT(4, n > 0);
    ref = (vt_cnn_box *)blk(alloc * sizeof(vt_cnn_box));
    want_np = ref_decode(&mt->m, out, gw, gh, thr, ss, ref, (int32_t)alloc);
    FZ_ASSERT(np == want_np && n == (want_np < cap ? want_np : cap) && n <= (int32_t)alloc);
    for (k = 0; k < n; k++) {
        FZ_ASSERT(same_box(&boxes[k], &ref[k]));
        FZ_ASSERT(boxes[k].score >= thr && (k == 0 || boxes[k - 1].score >= boxes[k].score));
    }
    check_guard((const uint8_t *)boxes, (size_t)n * sizeof(vt_cnn_box), alloc * sizeof(vt_cnn_box));
}

static int32_t clampi(int32_t v, int32_t lo, int32_t hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

/* The upsampled band is on unless all four of its fields are 0. */
static int up_on(const vt_cnn_cfg *c)
{
    return c->up_top_permille != 0 || c->up_bottom_permille != 0 || c->up_left_permille != 0 ||
           c->up_right_permille != 0;
}

/* The header's rules for vt_cnn_cfg_check. */
static int cfg_ok(const vt_cnn_cfg *c)
{
    return c->first_level >= 0 && c->first_level <= VT_CNN_MAX_LEVEL - 1 && c->n_levels >= 1 &&
           c->n_levels <= VT_CNN_MAX_RUN_LEVELS && c->first_level + c->n_levels - 1 <= VT_CNN_MAX_LEVEL &&
           c->cap_per_level >= 1 && c->cap_per_level <= VT_CNN_MAX_PEAKS &&
           (int64_t)c->n_levels * c->cap_per_level <= VT_MAX_NMS_BOXES && c->nms_iou_permille >= 0 &&
           c->nms_iou_permille <= 1000 && c->nms_contain_permille >= 0 && c->nms_contain_permille <= 1000 &&
           c->l0_top_permille >= 0 && c->l0_top_permille < c->l0_bottom_permille && c->l0_bottom_permille <= 1000 &&
           c->stretch_tail_permille >= 0 && c->stretch_tail_permille <= 100 &&
           (!up_on(c) || (c->up_top_permille >= 0 && c->up_top_permille < c->up_bottom_permille &&
                          c->up_bottom_permille <= 1000 && c->up_left_permille >= 0 &&
                          c->up_left_permille < c->up_right_permille && c->up_right_permille <= 1000 &&
                          (int64_t)(c->n_levels + 1) * c->cap_per_level <= VT_MAX_NMS_BOXES));
}

/* The header's upsampled band of a w x h frame (cfg valid, on): source rectangle
 * (*x0, *y0), 2x size *uw x *uh. */
static void up_rect(const vt_cnn_cfg *c, int32_t w, int32_t h, int32_t *x0, int32_t *y0, int32_t *uw, int32_t *uh)
{
    int32_t x1 = (int32_t)(((int64_t)w * c->up_right_permille + 999) / 1000);
    int32_t y1 = (int32_t)(((int64_t)h * c->up_bottom_permille + 999) / 1000);
    *x0 = (int32_t)((int64_t)w * c->up_left_permille / 1000);
    *y0 = (int32_t)((int64_t)h * c->up_top_permille / 1000);
    FZ_ASSERT(0 <= *x0 && *x0 < x1 && x1 <= w && 0 <= *y0 && *y0 < y1 && y1 <= h);
    *uw = 2 * (x1 - *x0);
    *uh = 2 * (y1 - *y0);
}

/* The 2x image fits the core's maximum (else VT_E_SIZE); true when the band is off. */
static int up_fits(const vt_cnn_cfg *c, int32_t w, int32_t h)
{
    int32_t x0, y0, uw, uh;
    if (!up_on(c)) {
        return 1;
    }
    up_rect(c, w, h, &x0, &y0, &uw, &uh);
    return uw <= VT_MAX_WIDTH && uh <= VT_MAX_HEIGHT;
}

/* The 2x image another way: output j samples source (2 j - 1) / 4 (quarter pixels),
 * general bilinear between floor and floor + 1 with quarter weights, clamped to the frame;
 * the 2-D weight over 16, rounded half up. Returns a malloc'd uw x uh image. */
static uint8_t *ref_upsample(const vt_image_u8 *img, int32_t x0, int32_t y0, int32_t uw, int32_t uh)
{
    uint8_t *o = (uint8_t *)malloc((size_t)uw * (size_t)uh);
    int32_t i, j, a, b;
    if (o == NULL) {
        abort();
    }
    for (i = 0; i < uh; i++) {
        int64_t qy = 4 * (int64_t)y0 + 2 * i - 1, ly = floor_div_pow2(qy, 2), fy = qy - 4 * ly;
        for (j = 0; j < uw; j++) {
            int64_t qx = 4 * (int64_t)x0 + 2 * j - 1, lx = floor_div_pow2(qx, 2), fx = qx - 4 * lx, acc = 0;
            for (a = 0; a < 2; a++) {
                for (b = 0; b < 2; b++) {
                    int32_t yy = clampi((int32_t)ly + a, 0, img->h - 1), xx = clampi((int32_t)lx + b, 0, img->w - 1);
                    int64_t wy = a ? fy : 4 - fy, wx = b ? fx : 4 - fx;
                    acc += wy * wx * img->px[(size_t)yy * (size_t)img->stride + (size_t)xx];
                }
            }
            o[(size_t)i * (size_t)uw + (size_t)j] = (uint8_t)((acc + 8) / 16);
        }
    }
    return o;
}

static int cmp_u8(const void *a, const void *b)
{
    return (int)*(const uint8_t *)a - (int)*(const uint8_t *)b;
}

/* The header's contrast stretch, another way: lo and hi as order statistics of the
 * sorted pixels (more than k pixels <= v <=> sorted[k] <= v), the table entry by entry
 * in int64. Returns a malloc'd w x h copy (stride w). */
static uint8_t *ref_stretch(const vt_image_u8 *img, int32_t tail)
{
    size_t n = (size_t)img->w * (size_t)img->h, i = 0, k = (size_t)((int64_t)n * tail / 1000);
    uint8_t *s = (uint8_t *)malloc(n), *o = (uint8_t *)malloc(n);
    int64_t lo, hi, span;
    int32_t x, y;
    if (s == NULL || o == NULL) {
        abort();
    }
    for (y = 0; y < img->h; y++) {
        for (x = 0; x < img->w; x++) {
            s[i++] = img->px[(size_t)y * (size_t)img->stride + (size_t)x];
        }
    }
    qsort(s, n, 1, cmp_u8);
    lo = s[k];
    hi = s[n - 1 - k];
    FZ_ASSERT(lo <= hi);
    span = hi - lo < VT_CNN_STRETCH_MIN_SPAN ? VT_CNN_STRETCH_MIN_SPAN : hi - lo;
    for (y = 0; y < img->h; y++) {
        for (x = 0; x < img->w; x++) {
            int64_t v = img->px[(size_t)y * (size_t)img->stride + (size_t)x], q = 0;
            if (v > lo) {
                q = ((v - lo) * 510 + span) / (2 * span);
            }
            o[(size_t)y * (size_t)img->w + (size_t)x] = (uint8_t)(q > 255 ? 255 : q);
        }
    }
    free(s);
    return o;
}

/* The header's level-0 band of an h-row frame (cfg valid): rows *y0 .. *y1 - 1. */
static void band(const vt_cnn_cfg *c, int32_t h, int32_t *y0, int32_t *y1)
{
    *y0 = (int32_t)((int64_t)h * c->l0_top_permille / 1000);
    *y1 = (int32_t)(((int64_t)h * c->l0_bottom_permille + 999) / 1000);
    FZ_ASSERT(0 <= *y0 && *y0 < *y1 && *y1 <= h); /* never empty (cnn.h) */
}

/* The header's vt_cnn_frame_work_bytes and the multiply-adds of a frame (m, cfg valid). */
static size_t frame_need(const vt_cnn_model *m, const vt_cnn_cfg *c, int32_t w, int32_t h, int64_t *macs)
{
    int32_t k, lw = w, lh = h, last = c->first_level + c->n_levels - 1, y0, y1;
    size_t odd = 0, even = 0, fwd = 0, out = 0, up = 0;
    *macs = 0;
    band(c, h, &y0, &y1);
    for (k = 0; k <= last; k++) {
        if (k > 0) {
            size_t b;
            lw = (lw + 1) / 2;
            lh = (lh + 1) / 2;
            b = (size_t)lw * (size_t)lh;
            if (k & 1) {
                odd = b > odd ? b : odd;
            } else {
                even = b > even ? b : even;
            }
        }
        if (k >= c->first_level) {
            plan_t p = plan(m, lw, k == 0 ? y1 - y0 : lh); /* level 0: its band */
            fwd = p.r0 + p.r1 > fwd ? p.r0 + p.r1 : fwd;
            out = p.out > out ? p.out : out;
            *macs += p.macs;
        }
    }
    if (up_on(c)) {
        int32_t x0, uy0, uw, uh;
        plan_t p;
        up_rect(c, w, h, &x0, &uy0, &uw, &uh);
        p = plan(m, uw, uh);
        fwd = p.r0 + p.r1 > fwd ? p.r0 + p.r1 : fwd;
        out = p.out > out ? p.out : out;
        *macs += p.macs;
        up = (size_t)uw * (size_t)uh;
    }
    return 7 + (size_t)(c->n_levels + up_on(c)) * (size_t)c->cap_per_level * sizeof(vt_scored_box) +
           (size_t)c->cap_per_level * sizeof(vt_cnn_box) + odd + even + fwd + out +
           (c->stretch_tail_permille > 0 ? (size_t)w * (size_t)h : 0) + up;
}

/* The detection composed from the public single-level pieces and the direct oracle;
 * returns the peak count, *n the boxes in res (at most cap). */
static int32_t ref_detect(const vt_cnn_model *m, const vt_cnn_cfg *c, const vt_image_u8 *img, vt_cnn_box *res,
                          int32_t cap, int32_t *n)
{
    int32_t k, i, total = 0, peaks = 0, kept = 0, last = c->first_level + c->n_levels - 1, y0, y1;
    int64_t t = (int64_t)m->heat_thr + c->thr_offset;
    int32_t thr = (int32_t)(t < -128 ? -128 : (t > 128 ? 128 : t));
    vt_scored_box *sb = (vt_scored_box *)malloc((size_t)(c->n_levels + 1) * (size_t)c->cap_per_level * sizeof *sb);
    vt_cnn_box *cb = (vt_cnn_box *)malloc((size_t)c->cap_per_level * sizeof *cb);
    uint8_t *lv[2] = {NULL, NULL}, *str = NULL;
    vt_image_u8 src = *img;
    if (sb == NULL || cb == NULL) {
        abort();
    }
    if (c->stretch_tail_permille > 0) {
        str = ref_stretch(img, c->stretch_tail_permille);
        src.px = str;
        src.stride = img->w;
    }
    band(c, img->h, &y0, &y1);
    for (k = 0; k <= last; k++) {
        if (k > 0) {
            vt_image_u8_mut dst;
            dst.w = (src.w + 1) / 2;
            dst.h = (src.h + 1) / 2;
            dst.stride = dst.w;
            dst.px = (uint8_t *)malloc((size_t)dst.w * (size_t)dst.h);
            if (dst.px == NULL) {
                abort();
            }
            FZ_ASSERT(vt_pyr_down(&src, &dst) == VT_OK);
            free(lv[k & 1]);
            lv[k & 1] = dst.px;
            src.px = dst.px;
            src.w = dst.w;
            src.h = dst.h;
            src.stride = dst.stride;
        }
        if (k >= c->first_level) {
            /* level 0: the band's rows of the caller's frame, boxes moved down by y0 */
            int32_t rh = k == 0 ? y1 - y0 : src.h, dy = k == 0 ? y0 : 0;
            const uint8_t *rpx = k == 0 ? src.px + (size_t)y0 * (size_t)src.stride : src.px;
            plan_t p = plan(m, src.w, rh);
            int8_t *out = (int8_t *)malloc(p.out);
            int32_t nd;
            if (out == NULL) {
                abort();
            }
            ref_forward(m, rpx, src.w, rh, src.stride, out);
            nd = ref_decode(m, out, p.gw, p.gh, thr, k, cb, c->cap_per_level);
            peaks += nd;
            nd = nd < c->cap_per_level ? nd : c->cap_per_level;
            for (i = 0; i < nd; i++) {
                vt_scored_box *o = &sb[total];
                o->box.left = clampi(cb[i].l, 0, INT32_MAX);
                o->box.top = clampi(cb[i].t + dy, 0, INT32_MAX);
                o->box.right = clampi(cb[i].r, INT32_MIN, img->w - 1);
                o->box.bottom = clampi(cb[i].b + dy, INT32_MIN, img->h - 1);
                o->score = cb[i].score;
                o->source = k;
                if (o->box.left <= o->box.right && o->box.top <= o->box.bottom) {
                    total++;
                }
            }
            free(out);
        }
    }
    if (up_on(c)) {
        /* after every level: the 2x image of the (stretched) frame, decoded at half scale */
        vt_image_u8 fr = *img;
        int32_t x0, uy0, uw, uh, nd;
        uint8_t *up;
        int8_t *out;
        plan_t p;
        if (str != NULL) {
            fr.px = str;
            fr.stride = img->w;
        }
        up_rect(c, img->w, img->h, &x0, &uy0, &uw, &uh);
        up = ref_upsample(&fr, x0, uy0, uw, uh);
        p = plan(m, uw, uh);
        out = (int8_t *)malloc(p.out);
        if (out == NULL) {
            abort();
        }
        ref_forward(m, up, uw, uh, uw, out);
        nd = ref_decode(m, out, p.gw, p.gh, thr, -1, cb, c->cap_per_level);
        peaks += nd;
        nd = nd < c->cap_per_level ? nd : c->cap_per_level;
        for (i = 0; i < nd; i++) {
            vt_scored_box *o = &sb[total];
            o->box.left = clampi(cb[i].l + x0, 0, INT32_MAX);
            o->box.top = clampi(cb[i].t + uy0, 0, INT32_MAX);
            o->box.right = clampi(cb[i].r + x0, INT32_MIN, img->w - 1);
            o->box.bottom = clampi(cb[i].b + uy0, INT32_MIN, img->h - 1);
            o->score = cb[i].score;
            o->source = last + 1;
            if (o->box.left <= o->box.right && o->box.top <= o->box.bottom) {
                total++;
            }
        }
        free(out);
        free(up);
    }
    FZ_ASSERT(vt_nms(sb, total, c->nms_iou_permille, c->nms_contain_permille, &kept) == VT_OK);
    *n = kept < cap ? kept : cap;
    for (i = 0; i < *n; i++) {
        res[i].l = sb[i].box.left;
        res[i].t = sb[i].box.top;
        res[i].r = sb[i].box.right;
        res[i].b = sb[i].box.bottom;
        res[i].score = sb[i].score;
    }
    free(sb);
    free(cb);
    free(lv[0]);
    free(lv[1]);
    free(str);
    return peaks;
}

static void detect(fz *f, const model_t *mt, const vt_cnn_cfg *cfg, int ok_c, const vt_image_u8 *img)
{
    uint8_t nulls = fz_nulls(f);
    int valid = mt->ok && ok_c && dims_ok(img->w, img->h) && up_fits(cfg, img->w, img->h);
    size_t need = 0, work_bytes, wa, off, nbox;
    int64_t macs = 0;
    int32_t cap, n = 12345, np = 12345, rn = 0, rp, k;
    uint8_t *block;
    vt_cnn_box *boxes, *ref;
    vt_status s, want;
    /* the size query */
    {
        size_t q = 3;
        int32_t qw = fz_u8(f) < 230 ? img->w : fz_edge(f, VT_MAX_WIDTH);
        int32_t qh = fz_u8(f) < 230 ? img->h : fz_edge(f, VT_MAX_HEIGHT);
        uint8_t qn = fz_nulls(f);
        want = (qn & 7) || !mt->ok || !ok_c ? VT_E_ARG
                                            : (dims_ok(qw, qh) && up_fits(cfg, qw, qh) ? VT_OK : VT_E_SIZE);
        s = vt_cnn_frame_work_bytes((qn & 1) ? NULL : &mt->m, (qn & 2) ? NULL : cfg, qw, qh, (qn & 4) ? NULL : &q);
        fz_status(s);
        FZ_ASSERT(s == want);
        if (s == VT_OK) {
            FZ_ASSERT(q == frame_need(&mt->m, cfg, qw, qh, &macs));
        } else if (!(qn & 4)) {
            FZ_ASSERT(q == 3);
        }
    }
    if (valid) {
        need = frame_need(&mt->m, cfg, img->w, img->h, &macs);
    }
    work_bytes = size_near(f, need);
    wa = work_bytes <= need + 16 ? work_bytes : need;
    off = fz_u8(f) & 7;
    cap = fz_u8(f) < 200 ? fz_range(f, 1, 24) : fz_edge(f, 64);
    nbox = valid ? (size_t)(cfg->n_levels + up_on(cfg)) * (size_t)cfg->cap_per_level : 64;
    nbox = cap >= 1 && (size_t)cap < nbox ? (size_t)cap : nbox; /* NMS keeps no more than it is given */
    if (wa + off > ALLOC_MAX) {
        return;
    }
    block = (uint8_t *)blk(wa + off);
    boxes = (vt_cnn_box *)blk(nbox * sizeof(vt_cnn_box));
    memset(block, GUARD, wa + off ? wa + off : 1);
    memset(boxes, GUARD, nbox * sizeof(vt_cnn_box));
    if ((nulls & 127) || img->px == NULL || cap < 1 || !mt->ok || !ok_c) {
        want = VT_E_ARG;
    } else if (!dims_ok(img->w, img->h) || img->stride < img->w || !up_fits(cfg, img->w, img->h)) {
        want = VT_E_SIZE;
    } else if (work_bytes < need) {
        want = VT_E_CAPACITY;
    } else {
        want = VT_OK;
    }
    if (want == VT_OK && macs > WORK_BUDGET) {
        return;
    }
    s = vt_cnn_detect_frame((nulls & 1) ? NULL : &mt->m, (nulls & 2) ? NULL : cfg, (nulls & 4) ? NULL : img->px,
                            img->w, img->h, img->stride, (nulls & 8) ? NULL : block + off, work_bytes,
                            (nulls & 16) ? NULL : boxes, cap, (nulls & 32) ? NULL : &n, (nulls & 64) ? NULL : &np);
    fz_status(s);
    FZ_ASSERT(s == want);
    if (s != VT_OK) {
        STAT(7, 1);
        FZ_ASSERT((nulls & 32) || n == 0);
        FZ_ASSERT((nulls & 64) || np == 0);
        check_guard((const uint8_t *)boxes, 0, nbox * sizeof(vt_cnn_box));
        return;
    }
    STAT(5, 1);
    STAT(6, n > 0);
    /* nothing outside work[0 .. need) or past boxes[n] */
    check_guard(block, 0, off);
    check_guard(block, off + need, off + wa);
    check_guard((const uint8_t *)boxes, (size_t)n * sizeof(vt_cnn_box), nbox * sizeof(vt_cnn_box));
    ref = (vt_cnn_box *)blk(nbox * sizeof(vt_cnn_box));
    rp = ref_detect(&mt->m, cfg, img, ref, cap, &rn);
    FZ_ASSERT(np == rp && n == rn && n <= cap);
    for (k = 0; k < n; k++) {
        const vt_cnn_box *b = &boxes[k];
        FZ_ASSERT(same_box(b, &ref[k]));
        FZ_ASSERT(b->l >= 0 && b->l <= b->r && b->r < img->w && b->t >= 0 && b->t <= b->b && b->b < img->h);
        FZ_ASSERT(b->score >= -128 && b->score <= 127 && (k == 0 || boxes[k - 1].score >= b->score));
    }
}

/* vt_cnn_cfg_at_horizon against the header's rule written another way: d by a division of the
 * magnitude (C99 truncates toward zero), each band moved and then pushed back inside. */
static void at_horizon(fz *f, const vt_cnn_cfg *cfg, int ok_c)
{
    uint8_t nulls = fz_nulls(f);
    uint8_t k = fz_u8(f);
    /* mostly any valid horizon; sometimes an exact half permille (ref + 4096 (2j + 1):
     * (hz - ref) 1000 / 65536 = 62.5 (2j + 1)), where the rounding shows; or near an edge */
    int32_t hz = k < 180 ? fz_range(f, -65536, 65536)
                         : (k < 220 ? VT_CNN_REF_HORIZON_Q16 + 4096 * (2 * fz_range(f, -12, 7) + 1)
                                    : fz_near(f, fz_edge(f, 65536), -2, 2));
    vt_cnn_cfg out, want = *cfg;
    vt_status s;
    int ok = ok_c && !(nulls & 3) && hz >= -65536 && hz <= 65536;
    memset(&out, 0x5a, sizeof out);
    s = vt_cnn_cfg_at_horizon((nulls & 1) ? NULL : cfg, hz, (nulls & 2) ? NULL : &out);
    fz_status(s);
    FZ_ASSERT(s == (ok ? VT_OK : VT_E_ARG));
    if (!ok) {
        vt_cnn_cfg untouched;
        memset(&untouched, 0x5a, sizeof untouched);
        FZ_ASSERT(memcmp(&out, &untouched, sizeof out) == 0);
        return;
    }
    {
        int64_t num = ((int64_t)hz - VT_CNN_REF_HORIZON_Q16) * 1000 + 32768;
        int32_t d = (int32_t)(num >= 0 ? num / 65536 : -((-num + 65535) / 65536));
        int32_t *tb[2][2];
        int k, nb = up_on(cfg) ? 2 : 1;
        tb[0][0] = &want.l0_top_permille;
        tb[0][1] = &want.l0_bottom_permille;
        tb[1][0] = &want.up_top_permille;
        tb[1][1] = &want.up_bottom_permille;
        for (k = 0; k < nb; k++) {
            int32_t span = *tb[k][1] - *tb[k][0];
            int32_t t = *tb[k][0] + d;
            if (t + span > 1000) {
                t = 1000 - span;
            }
            if (t < 0) {
                t = 0;
            }
            *tb[k][0] = t;
            *tb[k][1] = t + span;
        }
    }
    FZ_ASSERT(memcmp(&out, &want, sizeof out) == 0 && cfg_ok(&out));
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t op = fz_u8(&f);
    model_t mt;
    vt_cnn_cfg cfg;
    vt_image_u8 img;
    const int8_t *out = NULL;
    int32_t gw = 0, gh = 0, ok_c;
    model(&f, &mt);
    mt.ok = model_ok(&mt.m);
#ifdef CNN_FUZZ_STATS
    {
        static int once;
        if (!once) {
            once = 1;
            atexit(st_print);
        }
    }
#endif
    STAT(0, mt.ok);
    FZ_ASSERT((vt_cnn_check_model(&mt.m) == VT_OK) == mt.ok);
    FZ_ASSERT(vt_cnn_check_model(&mt.m) == (mt.ok ? VT_OK : VT_E_ARG));
    FZ_ASSERT(vt_cnn_check_model(NULL) == VT_E_ARG);
    img = fz_image_u8_small(&f, 40, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    {
        static const vt_cnn_cfg def = VT_CNN_CFG_DEFAULT;
        FZ_ASSERT(vt_cnn_cfg_default(&cfg) == VT_OK && memcmp(&cfg, &def, sizeof cfg) == 0 && cfg_ok(&cfg));
        FZ_ASSERT(vt_cnn_cfg_default(NULL) == VT_E_ARG && vt_cnn_cfg_check(NULL) == VT_E_ARG);
    }
    if (fz_u8(&f) < 200) {
        cfg.first_level = fz_range(&f, 0, VT_CNN_MAX_LEVEL - 1);
        cfg.n_levels = fz_range(&f, 1, VT_CNN_MAX_RUN_LEVELS);
        if (cfg.first_level + cfg.n_levels - 1 > VT_CNN_MAX_LEVEL) {
            cfg.n_levels = VT_CNN_MAX_LEVEL - cfg.first_level + 1;
        }
        cfg.thr_offset = fz_u8(&f) < 200 ? fz_range(&f, -40, 40) : fz_edge(&f, 256);
        cfg.cap_per_level = fz_u8(&f) < 220 ? fz_range(&f, 1, 16) : fz_range(&f, 1, VT_CNN_MAX_PEAKS);
        cfg.nms_iou_permille = fz_range(&f, 0, 1000);
        cfg.nms_contain_permille = fz_range(&f, 0, 1000);
        /* level 0's band: the whole frame, a band, or one as thin as a permille */
        if (fz_u8(&f) >= 96) {
            cfg.l0_top_permille = fz_range(&f, 0, 999);
            cfg.l0_bottom_permille = fz_u8(&f) < 64 ? cfg.l0_top_permille + 1
                                                    : fz_range(&f, cfg.l0_top_permille + 1, 1000);
        }
        /* the contrast stretch: off, or a tail of 0.1 .. 10% */
        cfg.stretch_tail_permille = fz_u8(&f) < 128 ? 0 : fz_range(&f, 1, 100);
        /* the upsampled band: off, a rectangle, or one a permille thin */
        if (fz_u8(&f) >= 128) {
            cfg.up_top_permille = fz_range(&f, 0, 999);
            cfg.up_bottom_permille = fz_u8(&f) < 64 ? cfg.up_top_permille + 1
                                                    : fz_range(&f, cfg.up_top_permille + 1, 1000);
            cfg.up_left_permille = fz_range(&f, 0, 999);
            cfg.up_right_permille = fz_u8(&f) < 64 ? cfg.up_left_permille + 1
                                                   : fz_range(&f, cfg.up_left_permille + 1, 1000);
        }
    }
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    ok_c = cfg_ok(&cfg);
    FZ_ASSERT(vt_cnn_cfg_check(&cfg) == (ok_c ? VT_OK : VT_E_ARG));
    if (op & 1) {
        sizes(&f, &mt);
    }
    if (!(op & 2)) {
        out = forward(&f, &mt, &img, &gw, &gh);
    }
    if (!(op & 4)) {
        decode(&f, &mt, out, gw, gh);
    }
    if (!(op & 8)) {
        detect(&f, &mt, &cfg, ok_c, &img);
    }
    if (op & 16) {
        at_horizon(&f, &cfg, ok_c);
    }
    fz_close(&f);
    blk_free();
    return 0;
}
