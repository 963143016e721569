/* fuzz-requires: vehtrack/classify.h
 * fuzz_classify.c -- the appearance classifier (vehtrack/classify.h; GIST paper
 * sec. II, thesis sec. 2.4.3): HOG and GIST preparation over a fuzzed view,
 * descriptors, window scores and scans at any cell position and window size
 * (window > image included), SVM and MLP decisions on fuzzed descriptors, and
 * box classification (resample + descriptor + decision) with models whose every
 * integer field comes from the bytes (wrong dim, shifts 0/31, NULL weights,
 * unknown kind). Weights are fixed tables (a pattern, all INT16_MAX, all
 * INT16_MIN) so saturation paths are reached without paying for 1 MB of bytes.
 * Output arrays are exact-size heap blocks: a write past cap is an ASan error.
 * Views stay within fz.h's 16 KB (mostly <= 48 x 48) so one input stays fast. */
#include <stddef.h>
#include "fuzz.h"
#include "vehtrack/classify.h"

#define FZ_W1_LEN (VT_MLP_MAX_HIDDEN * VT_CLS_MAX_DIM)

static vt_hog_ws g_hog;
static vt_gist_ws g_gist;
static vt_cls_box_ws g_box_ws;
static int16_t g_w[3][FZ_W1_LEN];
static int32_t g_b1[3][VT_MLP_MAX_HIDDEN];
static uint16_t g_desc[VT_CLS_MAX_DIM + 8];
static int g_ready;

static void tables(void)
{
    uint32_t s = 12345u;
    int32_t i;
    for (i = 0; i < FZ_W1_LEN; i++) {
        s = s * 1103515245u + 12345u;
        g_w[0][i] = (int16_t)(int32_t)((s >> 16) & 0x7FFFu) - 16384;
        g_w[1][i] = INT16_MAX;
        g_w[2][i] = INT16_MIN;
    }
    for (i = 0; i < VT_MLP_MAX_HIDDEN; i++) {
        g_b1[0][i] = (int32_t)(i * 4099) - 65536;
        g_b1[1][i] = INT32_MAX;
        g_b1[2][i] = INT32_MIN;
    }
    g_ready = 1;
}

/* Window sizes: mostly legal for the kind, sometimes any edge value. */
static void window(fz *f, int32_t kind, int32_t *ww, int32_t *wh)
{
    if (fz_u8(f) < 200) {
        int32_t unit = kind == VT_DESC_GIST ? 32 : 8;
        int32_t lo = kind == VT_DESC_GIST ? 1 : 2;
        *ww = unit * fz_range(f, lo, kind == VT_DESC_GIST ? 2 : 8);
        *wh = unit * fz_range(f, lo, kind == VT_DESC_GIST ? 2 : 8);
    } else {
        *ww = fz_edge(f, VT_CLS_MAX_WIN);
        *wh = fz_edge(f, VT_CLS_MAX_WIN);
    }
}

/* The HOG length of a ww x wh window (0 when either side is out of 16..1024). */
static int32_t hog_dim(int32_t ww, int32_t wh)
{
    if (ww < 16 || wh < 16 || ww > 1024 || wh > 1024) {
        return 0;
    }
    return (ww / 8 - 1) * (wh / 8 - 1) * 36;
}

static void svm(fz *f, vt_svm_model *m)
{
    uint8_t k = fz_u8(f);
    m->kind = (k & 1) ? VT_DESC_GIST : VT_DESC_HOG;
    window(f, m->kind, &m->win_w, &m->win_h);
    m->dim = m->kind == VT_DESC_GIST ? VT_GIST_DIM : hog_dim(m->win_w, m->win_h);
    m->w_shift = fz_range(f, 1, 30);
    m->bias_q16 = fz_raw_i32(f);
    m->threshold_q16 = 0;
    fz_mutate_i32s(f, m, offsetof(vt_svm_model, w));
    m->w = (k & 0x80) ? NULL : g_w[(k >> 1) % 3u];
}

static void mlp(fz *f, vt_mlp_model *m)
{
    uint8_t k = fz_u8(f), t = (uint8_t)((k >> 1) % 3u);
    m->kind = (k & 1) ? VT_DESC_GIST : VT_DESC_HOG;
    window(f, m->kind, &m->win_w, &m->win_h);
    m->dim = m->kind == VT_DESC_GIST ? VT_GIST_DIM : hog_dim(m->win_w, m->win_h);
    m->hidden = fz_range(f, 1, 8);
    m->w1_shift = fz_range(f, 1, 30);
    m->w2_shift = fz_range(f, 1, 30);
    m->b2_q16 = fz_raw_i32(f);
    m->threshold_q16 = 0;
    fz_mutate_i32s(f, m, offsetof(vt_mlp_model, w1));
    m->w1 = (k & 0x80) ? NULL : g_w[t];
    m->b1_q16 = (k & 0x40) ? NULL : g_b1[t];
    m->w2 = (k & 0x20) ? NULL : g_w[(t + 1u) % 3u];
}

static vt_box box(fz *f, const vt_image_u8 *img)
{
    vt_box b;
    if (fz_u8(f) < 200) {
        int32_t w = img->w > 0 && img->w <= 64 ? img->w : 64, h = img->h > 0 && img->h <= 64 ? img->h : 48;
        b.left = fz_range(f, -1, w - 1);
        b.top = fz_range(f, -1, h - 1);
        b.right = fz_near(f, b.left, -1, 64);
        b.bottom = fz_near(f, b.top, -1, 64);
    } else {
        b.left = fz_edge(f, img->w);
        b.top = fz_edge(f, img->h);
        b.right = fz_edge(f, img->w);
        b.bottom = fz_edge(f, img->h);
    }
    return b;
}

/* An exact-size output array of cap elements (cap from the bytes, -1..max+2). */
static int32_t cap_of(fz *f, int32_t want)
{
    return fz_u8(f) < 200 ? want : fz_range(f, -1, want + 2);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t op, nulls;
    vt_image_u8 img;
    vt_status s;
    int32_t score = 0, n = -1, i;
    if (!g_ready) {
        tables();
    }
    g_hog.cells_x = g_hog.cells_y = 0; /* no state from an earlier input */
    g_gist.cells_x = g_gist.cells_y = 0;
    op = fz_u8(&f) % 7u;
    nulls = fz_u8(&f) & (fz_u8(&f) | 0xC0u);
    img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT); /* fz_geom keeps it small */
    if (op == 0) { /* HOG: prepare, descriptor, score, scan */
        vt_svm_model m;
        int32_t cx, cy, ww, wh, cap, ncx, ncy;
        uint16_t *out;
        int32_t *scores;
        svm(&f, &m);
        fz_status(vt_hog_prepare((nulls & 1) ? NULL : &g_hog, (nulls & 2) ? NULL : &img));
        cx = fz_u8(&f) < 220 ? fz_range(&f, -1, 8) : fz_edge(&f, 8);
        cy = fz_u8(&f) < 220 ? fz_range(&f, -1, 6) : fz_edge(&f, 6);
        window(&f, VT_DESC_HOG, &ww, &wh);
        cap = cap_of(&f, ww > 0 && wh > 0 && ww <= 64 && wh <= 64 ? hog_dim(ww, wh) : 36);
        out = (uint16_t *)fz_alloc(&f, (size_t)(cap > 0 ? cap : 0) * sizeof(uint16_t));
        s = vt_hog_descriptor((nulls & 4) ? NULL : &g_hog, cx, cy, ww, wh, (nulls & 8) ? NULL : out,
                              cap, (nulls & 16) ? NULL : &n);
        fz_status(s);
        if (s == VT_OK) {
            FZ_ASSERT(n >= 0 && n <= cap);
            for (i = 0; i < n; i++) {
                FZ_ASSERT(out[i] <= 32768u);
            }
        }
        fz_status(vt_hog_window_score(&g_hog, (nulls & 32) ? NULL : &m, cx, cy,
                                      (nulls & 64) ? NULL : &score));
        ncx = fz_u8(&f) < 220 ? fz_range(&f, 0, 6) : fz_edge(&f, 200);
        ncy = fz_u8(&f) < 220 ? fz_range(&f, 0, 5) : fz_edge(&f, 30);
        cap = cap_of(&f, ncx > 0 && ncy > 0 && ncx <= 8 && ncy <= 8 ? ncx * ncy : 4);
        scores = (int32_t *)fz_alloc(&f, (size_t)(cap > 0 ? cap : 0) * sizeof(int32_t));
        fz_status(vt_hog_scan(&g_hog, &m, cx, cy, ncx, ncy, (nulls & 128) ? NULL : scores, cap));
    } else if (op == 1) { /* GIST: prepare, descriptor */
        int32_t cx, cy, ww, wh, cap;
        uint16_t *out;
        fz_status(vt_gist_prepare((nulls & 1) ? NULL : &g_gist, (nulls & 2) ? NULL : &img));
        cx = fz_u8(&f) < 220 ? fz_range(&f, -1, 4) : fz_edge(&f, 8);
        cy = fz_u8(&f) < 220 ? fz_range(&f, -1, 4) : fz_edge(&f, 6);
        window(&f, VT_DESC_GIST, &ww, &wh);
        cap = cap_of(&f, VT_GIST_DIM);
        out = (uint16_t *)fz_alloc(&f, (size_t)(cap > 0 ? cap : 0) * sizeof(uint16_t));
        s = vt_gist_descriptor((nulls & 4) ? NULL : &g_gist, cx, cy, ww, wh,
                               (nulls & 8) ? NULL : out, cap, (nulls & 16) ? NULL : &n);
        fz_status(s);
        if (s == VT_OK) {
            FZ_ASSERT(n == VT_GIST_DIM && n <= cap);
            for (i = 0; i < n; i++) {
                FZ_ASSERT(out[i] <= 32768u);
            }
        }
    } else if (op == 2 || op == 3) { /* decisions on a fuzzed descriptor */
        int32_t len = fz_u8(&f) < 200 ? -2 : fz_edge(&f, VT_CLS_MAX_DIM + 4);
        vt_svm_model m;
        vt_mlp_model mm;
        uint8_t mode = fz_u8(&f), v = fz_u8(&f);
        if (op == 2) {
            svm(&f, &m);
        } else {
            mlp(&f, &mm);
        }
        if (len == -2) { /* the model's own length, or one off */
            len = fz_near(&f, op == 2 ? m.dim : mm.dim, -1, 1);
        }
        for (i = 0; i < VT_CLS_MAX_DIM + 8; i++) { /* extreme or patterned descriptors */
            g_desc[i] = (mode & 8) ? (uint16_t)(32768u * ((uint32_t)(i + v) & 1u))
                                   : (uint16_t)((uint32_t)v * 128u + (uint32_t)i % 97u);
        }
        if (len > VT_CLS_MAX_DIM + 8) {
            len = VT_CLS_MAX_DIM + 8;
        }
        if (op == 2) {
            fz_status(vt_svm_model_check((nulls & 1) ? NULL : &m));
            fz_status(vt_svm_decision((nulls & 1) ? NULL : &m, (nulls & 2) ? NULL : g_desc, len,
                                      (nulls & 4) ? NULL : &score));
        } else {
            fz_status(vt_mlp_model_check((nulls & 1) ? NULL : &mm));
            fz_status(vt_mlp_decision((nulls & 1) ? NULL : &mm, (nulls & 2) ? NULL : g_desc, len,
                                      (nulls & 4) ? NULL : &score));
        }
    } else if (op == 4) { /* resample a box to a fuzzed output view */
        vt_box b = box(&f, &img);
        vt_image_u8_mut dst;
        int32_t w, h, stride;
        void *px = fz_out_view(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT, 1, &w, &h, &stride);
        dst.px = (uint8_t *)px;
        dst.w = w;
        dst.h = h;
        dst.stride = stride;
        fz_status(vt_resample_area((nulls & 1) ? NULL : &img, (nulls & 2) ? NULL : &b,
                                   (nulls & 4) ? NULL : &dst));
    } else { /* whole boxes: SVM (default or fuzzed), MLP (default or fuzzed) */
        vt_box b = box(&f, &img);
        uint8_t which = fz_u8(&f);
        if (op == 5) {
            vt_svm_model mine;
            const vt_svm_model *m = NULL;
            if (which & 1) {
                s = vt_svm_default_model((which & 2) ? VT_DESC_GIST : (which & 4) ? fz_raw_i32(&f) : VT_DESC_HOG,
                                         (nulls & 8) ? NULL : &m);
                fz_status(s);
                if (s == VT_OK) {
                    FZ_ASSERT(m != NULL && vt_svm_model_check(m) == VT_OK);
                }
            } else {
                svm(&f, &mine);
                m = &mine;
            }
            fz_status(vt_classify_box((nulls & 1) ? NULL : &g_box_ws, m, (nulls & 2) ? NULL : &img,
                                      (nulls & 4) ? NULL : &b, (nulls & 16) ? NULL : &score));
        } else {
            vt_mlp_model mine;
            const vt_mlp_model *m = NULL;
            if (which & 1) {
                s = vt_mlp_default_model((nulls & 8) ? NULL : &m);
                fz_status(s);
                if (s == VT_OK) {
                    FZ_ASSERT(m != NULL && vt_mlp_model_check(m) == VT_OK);
                }
            } else {
                mlp(&f, &mine);
                m = &mine;
            }
            fz_status(vt_classify_box_mlp((nulls & 1) ? NULL : &g_box_ws, m, (nulls & 2) ? NULL : &img,
                                          (nulls & 4) ? NULL : &b, (nulls & 16) ? NULL : &score));
        }
    }
    fz_close(&f);
    return 0;
}
