/* fuzz-requires: vehtrack/acf.h
 * fuzz_acf.c -- the ACF first stage (vehtrack/acf.h; issue 8): a fuzzed view (1..~320
 * px, degenerate sizes, stride < w, px NULL), a tree ensemble whose geometry, depth,
 * tree count, feature indices, leaves, bias and soft-cascade trace come from the bytes
 * (in range, on the edges and past them; arrays of exactly the model's size), the
 * detector configuration and camera mutated from their defaults. Then:
 *   vt_acf_cfg_check / vt_acf_model_check: the status the header's ranges give (a
 *     mirror of each range here);
 *   vt_acf_scale_q16 at any k;
 *   vt_acf_resample of any rows and columns at any r_q16 into an exact-size view: its
 *     status as documented, nothing written on an error, and on success a sample of
 *     pixels equal to the area mean computed here directly in 2-D;
 *   vt_acf_channels of any cell rows into an exact-size buffer (out_cap the size, short
 *     or an edge): the documented status, nothing written on an error, and a band equal
 *     to the same rows of the whole image's channels;
 *   vt_acf_score on those planes or on planes from the bytes, any window: the status,
 *     and the score = bias + the leaves reached (walked here), saturated to int32;
 *   vt_acf_detect (NULLs from the bytes): on error n_boxes 0; on success the boxes lie
 *     in the frame, left <= right, top <= bottom, highest score first, every score >=
 *     score_min, no two kept boxes overlap past the IoU limit, the counters agree
 *     (hits = candidates + dropped), and a trace of INT32_MIN detects as none. */
#include "fuzz.h"
#include "vehtrack/acf.h"

static vt_acf_ws g_ws; /* a few MB: static, never on the stack */
static vt_fulldet_result g_res, g_res2;
static const int32_t g_scale[VT_ACF_MAX_SCALES] = VT_ACF_SCALE_Q16_INIT;
/* the whole image's channels (a band is checked against them): VT_MAX_WIDTH x 16384 px at most */
static uint8_t g_full[VT_ACF_NCH * ((FZ_MAX_BYTES) / 4 / 4 + (VT_MAX_WIDTH) / 4)];

static int valid_view(const vt_image_u8 *v)
{
    return v->px != NULL && v->w >= 1 && v->h >= 1 && v->stride >= v->w && v->w <= VT_MAX_WIDTH &&
           v->h <= VT_MAX_HEIGHT;
}

static vt_status view_status(const vt_image_u8 *v)
{
    if (v->px == NULL) {
        return VT_E_ARG;
    }
    return valid_view(v) ? VT_OK : VT_E_SIZE;
}

/* A view: mostly the house's small views, sometimes 1..320 px wide and as tall as 16 KB allows. */
static vt_image_u8 image(fz *f)
{
    vt_image_u8 v;
    if (fz_u8(f) < 170) {
        return fz_image_u8_small(f, 64, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    }
    v.w = fz_range(f, 1, 320);
    v.h = fz_range(f, 1, (int32_t)(FZ_MAX_BYTES / (uint32_t)(v.w + 3)));
    v.stride = v.w + (fz_u8(f) & 3);
    {
        size_t n = (size_t)(v.h - 1) * (size_t)v.stride + (size_t)v.w;
        uint8_t *px = (uint8_t *)fz_alloc(f, n);
        if (px != NULL) {
            fz_fill(f, px, v.w, v.h, v.stride);
        }
        v.px = px;
    }
    return v;
}

typedef struct {
    vt_acf_model m;
    int arrays; /* the arrays hold n_trees x depth's nodes (else 1 element each) */
    int32_t *reject; /* the trace array (allocated when arrays), m.reject may be NULL */
} model_t;

/* NULL-argument bits: none in 7 of 8 calls, so the calls mostly reach their work. */
static uint8_t fz_nulls(fz *f)
{
    uint8_t b = fz_u8(f);
    return (b & 0xE0u) == 0xE0u ? (uint8_t)(b & 0x3Fu) : 0u;
}

static int32_t signed_edge(fz *f, int32_t cap)
{
    int32_t v = fz_edge(f, cap);
    return (fz_u8(f) & 1) && v > INT32_MIN ? -v : v;
}

static void model(fz *f, model_t *mt)
{
    vt_acf_model *m = &mt->m;
    uint8_t sel = fz_u8(f);
    int32_t i, n_in, n_leaf, n_feat;
    if (sel < 235) {
        m->pad = fz_range(f, 0, 2);
        m->win_cw = fz_range(f, 2 * m->pad + 1, 2 * m->pad + 8);
        m->win_ch = fz_range(f, 2 * m->pad + 1, 2 * m->pad + 8);
    } else {
        m->pad = fz_edge(f, 4);
        m->win_cw = fz_edge(f, VT_ACF_MAX_WIN_CELLS);
        m->win_ch = fz_edge(f, VT_ACF_MAX_WIN_CELLS);
    }
    m->n_trees = fz_u8(f) < 240 ? fz_range(f, 1, 16) : fz_edge(f, VT_ACF_MAX_TREES);
    m->depth = fz_u8(f) < 240 ? fz_range(f, 1, VT_ACF_MAX_DEPTH) : fz_edge(f, VT_ACF_MAX_DEPTH);
    m->bias_q16 = fz_u8(f) < 235 ? (int32_t)(int8_t)fz_u8(f) * 4096 : signed_edge(f, 1 << 30);
    mt->arrays = m->n_trees >= 1 && m->n_trees <= VT_ACF_MAX_TREES && m->depth >= 1 &&
                 m->depth <= VT_ACF_MAX_DEPTH;
    n_in = mt->arrays ? (1 << m->depth) - 1 : 0;
    n_leaf = n_in + 1;
    /* feature indices of a window the model might have (a wrong window is refused first) */
    n_feat = m->win_cw >= 1 && m->win_cw <= VT_ACF_MAX_WIN_CELLS && m->win_ch >= 1 &&
                     m->win_ch <= VT_ACF_MAX_WIN_CELLS
                 ? VT_ACF_NCH * m->win_cw * m->win_ch
                 : 1;
    {
        int32_t nn = mt->arrays ? m->n_trees * n_in : 1, nl = mt->arrays ? m->n_trees * n_leaf : 1;
        uint16_t *feat = (uint16_t *)fz_alloc(f, (size_t)nn * sizeof(uint16_t));
        uint8_t *thr = (uint8_t *)fz_alloc(f, (size_t)nn);
        int32_t *leaf = (int32_t *)fz_alloc(f, (size_t)nl * sizeof(int32_t));
        int32_t *rej = (int32_t *)fz_alloc(f, (size_t)(mt->arrays ? m->n_trees : 1) * sizeof(int32_t));
        uint8_t bad = fz_u8(f); /* 1 in 16: a feature or a leaf past its range; 1 in 16: an array NULL */
        if (feat == NULL || thr == NULL || leaf == NULL || rej == NULL) {
            abort();
        }
        for (i = 0; i < nn; i++) {
            uint32_t u = (uint32_t)fz_u8(f) | (uint32_t)fz_u8(f) << 8;
            feat[i] = (uint16_t)(u % (uint32_t)n_feat);
            thr[i] = fz_u8(f);
        }
        for (i = 0; i < nl; i++) {
            uint8_t b = fz_u8(f);
            leaf[i] = b < 240 ? (int32_t)(int8_t)fz_u8(f) * 2048 : signed_edge(f, 1 << 24);
        }
        for (i = 0; i < (mt->arrays ? m->n_trees : 1); i++) {
            uint8_t b = fz_u8(f);
            rej[i] = b < 240 ? (int32_t)(int8_t)fz_u8(f) * 8192 * (i + 1) : fz_raw_i32(f);
        }
        if ((bad & 15) == 0) {
            int32_t k = fz_range(f, 0, nn - 1);
            feat[k] = (fz_u8(f) & 1) ? (uint16_t)n_feat : 65535u;
        } else if ((bad & 15) == 1) {
            leaf[fz_range(f, 0, nl - 1)] = (fz_u8(f) & 1) ? (1 << 24) + 1 : -(1 << 24) - 1;
        }
        m->feat = (bad & 0xFC) == 0xFC ? NULL : feat;
        m->thr = (bad & 0xFC) == 0xF8 ? NULL : thr;
        m->leaf = (bad & 0xF8) == 0xF0 ? NULL : leaf;
        mt->reject = rej;
        m->reject = (fz_u8(f) & 1) ? rej : NULL;
    }
}

/* The header's ranges (acf.h, vt_acf_model). */
static int model_ok(const model_t *mt)
{
    const vt_acf_model *m = &mt->m;
    int32_t i, n_in, n_feat;
    if (m->feat == NULL || m->thr == NULL || m->leaf == NULL || m->pad < 0 || m->pad > 4 ||
        m->win_cw < 2 * m->pad + 1 || m->win_cw > VT_ACF_MAX_WIN_CELLS || m->win_ch < 2 * m->pad + 1 ||
        m->win_ch > VT_ACF_MAX_WIN_CELLS || !mt->arrays || m->bias_q16 < -(1 << 30) || m->bias_q16 > (1 << 30)) {
        return 0;
    }
    n_in = (1 << m->depth) - 1;
    n_feat = VT_ACF_NCH * m->win_cw * m->win_ch;
    for (i = 0; i < m->n_trees * n_in; i++) {
        if (m->feat[i] >= n_feat) {
            return 0;
        }
    }
    for (i = 0; i < m->n_trees * (n_in + 1); i++) {
        if (m->leaf[i] < -(1 << 24) || m->leaf[i] > (1 << 24)) {
            return 0;
        }
    }
    return 1;
}

static int cfg_ok(const vt_acf_cfg *c)
{
    return c->first_scale >= 0 && c->first_scale < VT_ACF_MAX_SCALES && c->n_scales >= 1 &&
           c->n_scales <= VT_ACF_MAX_SCALES - c->first_scale && c->veh_w_min_mm >= 100 &&
           c->veh_w_min_mm <= c->veh_w_max_mm && c->veh_w_max_mm <= 20000 && c->slack_px >= 0 &&
           c->slack_px <= VT_MAX_HEIGHT && c->above_px >= 0 && c->above_px <= VT_MAX_HEIGHT &&
           c->nms_iou_permille >= 0 && c->nms_iou_permille <= 1000 && c->nms_contain_permille >= 0 &&
           c->nms_contain_permille <= 1000 && c->cols >= VT_ACF_COLS_ALL && c->cols <= VT_ACF_COLS_RIGHT;
}

static int cam_ok(const vt_camera_min *c)
{
    return c->fx_q4 >= 16 && c->fx_q4 <= (1 << 24) && c->horizon_y >= -VT_MAX_HEIGHT &&
           c->horizon_y <= VT_MAX_HEIGHT && c->height_mm >= 100 && c->height_mm <= 20000 && c->hood_y >= 1 &&
           c->hood_y <= 2 * VT_MAX_HEIGHT;
}

/* The model's score written out here: bias + the leaf each tree reaches (right when
 * byte feat[n] > thr[n]), int64, saturated to int32. */
static int32_t walk(const vt_acf_model *m, const uint8_t *ch, int32_t rows, int32_t cols, int32_t cx, int32_t cy)
{
    int32_t n_in = (1 << m->depth) - 1, t, d, cells = m->win_cw * m->win_ch;
    int64_t acc = m->bias_q16;
    for (t = 0; t < m->n_trees; t++) {
        int32_t n = 0;
        for (d = 0; d < m->depth; d++) {
            int32_t fi = m->feat[t * n_in + n], c = fi / cells, y = fi % cells / m->win_cw, x = fi % m->win_cw;
            uint8_t byte =
                ch[((size_t)c * (size_t)rows + (size_t)(cy + y)) * (size_t)cols + (size_t)(cx + x)];
            n = 2 * n + 1 + (byte > m->thr[t * n_in + n] ? 1 : 0);
        }
        acc += m->leaf[t * (n_in + 1) + n - n_in];
    }
    return acc > INT32_MAX ? INT32_MAX : (acc < INT32_MIN ? INT32_MIN : (int32_t)acc);
}

/* Level pixel (x, y) at r, straight from acf.h: the area mean of input [x r, (x + 1) r) x
 * [y r, (y + 1) r), weights in Q16 of an input px, rounded half up. */
static uint8_t level_px(const vt_image_u8 *src, int32_t r, int32_t x, int32_t y)
{
    int64_t ax = (int64_t)x * r, bx = ax + r, ay = (int64_t)y * r, by = ay + r, acc = 0, rr = (int64_t)r * r;
    int64_t i, j;
    for (j = ay >> 16; (j << 16) < by; j++) {
        int64_t wy = (by < (j + 1) << 16 ? by : (j + 1) << 16) - (ay > j << 16 ? ay : j << 16);
        for (i = ax >> 16; (i << 16) < bx; i++) {
            int64_t wx = (bx < (i + 1) << 16 ? bx : (i + 1) << 16) - (ax > i << 16 ? ax : i << 16);
            acc += wx * wy * src->px[(size_t)j * (size_t)src->stride + (size_t)i];
        }
    }
    return (uint8_t)((acc + rr / 2) / rr);
}

static void resample(fz *f, const vt_image_u8 *img)
{
    uint8_t sel = fz_u8(f), nulls = fz_nulls(f);
    int32_t r = sel < 160 ? g_scale[fz_u8(f) % VT_ACF_MAX_SCALES]
                          : (sel < 220 ? fz_range(f, 65536, 16 * 65536) : fz_edge(f, 16 * 65536));
    int32_t lw = valid_view(img) && r >= 65536 ? (int32_t)(((int64_t)img->w << 16) / r) : 0;
    int32_t lh = valid_view(img) && r >= 65536 ? (int32_t)(((int64_t)img->h << 16) / r) : 0;
    int32_t y0, w, h, stride, x, y, k;
    vt_image_u8_mut dst;
    size_t n;
    uint8_t *px;
    vt_status s, want;
    if (fz_u8(f) < 200 && lw >= 1 && lh >= 1) { /* rows and columns of the level, maybe one past */
        w = fz_range(f, 1, lw + (fz_u8(f) == 0 ? 1 : 0));
        y0 = fz_range(f, 0, lh - 1);
        h = fz_range(f, 1, lh - y0 + (fz_u8(f) == 0 ? 1 : 0));
        stride = w + (fz_u8(f) & 3);
    } else {
        w = fz_edge(f, lw);
        h = fz_edge(f, lh);
        y0 = fz_edge(f, lh);
        stride = fz_u8(f) < 200 ? w : fz_edge(f, w);
    }
    /* an exact-size block when the view is one the core may write, else one byte */
    n = w >= 1 && h >= 1 && stride >= w && w <= VT_MAX_WIDTH && h <= VT_MAX_HEIGHT &&
                (uint64_t)(h - 1) * (uint64_t)stride + (uint64_t)w <= 4u * FZ_MAX_BYTES
            ? (size_t)(h - 1) * (size_t)stride + (size_t)w
            : 1;
    px = (uint8_t *)fz_alloc(f, n);
    if (px == NULL) {
        return;
    }
    memset(px, 0xA5, n);
    dst.px = (nulls & 4) ? NULL : px;
    dst.w = w;
    dst.h = h;
    dst.stride = stride;
    if ((nulls & 3) || dst.px == NULL) {
        want = VT_E_ARG;
    } else if (view_status(img) != VT_OK) {
        want = view_status(img);
    } else if (r < 65536 || r > 16 * 65536) {
        want = VT_E_ARG;
    } else if (w < 1 || h < 1 || stride < w || y0 < 0 || w > lw || (int64_t)y0 + h > lh) {
        want = VT_E_SIZE;
    } else {
        want = VT_OK;
    }
    if (want == VT_OK && n == 1 && (w > 1 || h > 1)) {
        return; /* a view the core may write that the harness did not allocate: not a call to make */
    }
    s = vt_acf_resample((nulls & 1) ? NULL : &g_ws, (nulls & 2) ? NULL : img, r, y0, &dst);
    fz_status(s);
    FZ_ASSERT(s == want);
    if (s != VT_OK) {
        for (k = 0; k < (int32_t)n; k++) {
            FZ_ASSERT(px[k] == 0xA5); /* nothing written */
        }
        return;
    }
    for (k = 0; k < 48; k++) { /* a sample of pixels, from the definition */
        x = k == 0 ? 0 : (k == 1 ? w - 1 : fz_range(f, 0, w - 1));
        y = k == 0 ? 0 : (k == 1 ? h - 1 : fz_range(f, 0, h - 1));
        FZ_ASSERT(px[(size_t)y * (size_t)stride + (size_t)x] == level_px(img, r, x, y0 + y));
    }
    for (y = 0; y < h - 1; y++) { /* the padding between rows untouched */
        for (x = w; x < stride; x++) {
            FZ_ASSERT(px[(size_t)y * (size_t)stride + (size_t)x] == 0xA5);
        }
    }
}

/* vt_acf_channels of some cell rows; returns the planes (rows x cols) when it succeeded. */
static const uint8_t *channels(fz *f, const vt_image_u8 *img, int32_t *rows, int32_t *cols)
{
    uint8_t sel = fz_u8(f), nulls = fz_nulls(f);
    int32_t nch = valid_view(img) ? img->h / 4 : 0, cw = valid_view(img) ? img->w / 4 : 0;
    int32_t cy0, n_cy, cap, k;
    int64_t need;
    size_t alloc;
    uint8_t *out;
    vt_status s, want;
    if (sel < 200 && nch >= 1) {
        cy0 = fz_range(f, 0, nch - 1);
        n_cy = fz_range(f, 1, nch - cy0 + (fz_u8(f) == 0 ? 1 : 0));
    } else {
        cy0 = fz_edge(f, nch);
        n_cy = fz_edge(f, nch);
    }
    need = (int64_t)VT_ACF_NCH * n_cy * cw;
    {
        uint8_t c = fz_u8(f);
        int64_t n32 = need < INT32_MAX ? need : INT32_MAX; /* an invalid band's size may not fit */
        n32 = n32 > INT32_MIN ? n32 : INT32_MIN;
        if (c < 180) {
            cap = (int32_t)n32; /* exactly the size */
        } else if (c < 230) {
            int64_t v = n32 - fz_range(f, 1, 64); /* short */
            cap = (int32_t)(v > INT32_MIN ? v : INT32_MIN);
        } else {
            cap = fz_edge(f, (int32_t)n32);
        }
    }
    alloc = cap >= 1 ? (size_t)(cap < need ? cap : need) : 1;
    if (alloc > 64u * FZ_MAX_BYTES) {
        alloc = 1; /* a band this big is never valid for a view of FZ_MAX_BYTES px */
    }
    out = (uint8_t *)fz_alloc(f, alloc);
    if (out == NULL) {
        return NULL;
    }
    memset(out, 0xA5, alloc);
    if (nulls & 7) {
        want = VT_E_ARG;
    } else if (view_status(img) != VT_OK) {
        want = view_status(img);
    } else if (img->w < 4 || img->h < 4 || cy0 < 0 || n_cy < 1 || (int64_t)cy0 + n_cy > nch) {
        want = VT_E_SIZE;
    } else if (cap < need) {
        want = VT_E_CAPACITY;
    } else {
        want = VT_OK;
    }
    if (want == VT_OK && alloc < (size_t)need) {
        return NULL; /* not allocated: not a call to make */
    }
    s = vt_acf_channels((nulls & 1) ? NULL : &g_ws, (nulls & 2) ? NULL : img, cy0, n_cy,
                        (nulls & 4) ? NULL : out, cap);
    fz_status(s);
    FZ_ASSERT(s == want);
    if (s != VT_OK) {
        for (k = 0; k < (int32_t)alloc; k++) {
            FZ_ASSERT(out[k] == 0xA5);
        }
        return NULL;
    }
    /* the band = those rows of the whole image's channels */
    if ((int64_t)VT_ACF_NCH * nch * cw <= (int64_t)sizeof g_full) {
        int32_t c, y, x;
        FZ_ASSERT(vt_acf_channels(&g_ws, img, 0, nch, g_full, (int32_t)sizeof g_full) == VT_OK);
        for (c = 0; c < VT_ACF_NCH; c++) {
            for (y = 0; y < n_cy; y++) {
                for (x = 0; x < cw; x++) {
                    FZ_ASSERT(out[((size_t)c * (size_t)n_cy + (size_t)y) * (size_t)cw + (size_t)x] ==
                              g_full[((size_t)c * (size_t)nch + (size_t)(cy0 + y)) * (size_t)cw + (size_t)x]);
                }
            }
        }
    }
    *rows = n_cy;
    *cols = cw;
    return out;
}

static void score(fz *f, const model_t *mt, const uint8_t *planes, int32_t rows, int32_t cols)
{
    const vt_acf_model *m = &mt->m;
    uint8_t sel = fz_u8(f), nulls = fz_nulls(f);
    int32_t cx, cy, out = 12345;
    int64_t have;
    vt_status s, want;
    if (planes == NULL || (sel & 1)) { /* planes from the bytes */
        int32_t k;
        size_t n;
        uint8_t *p;
        rows = fz_u8(f) < 220 ? fz_range(f, 1, 40) : fz_edge(f, 40);
        cols = fz_u8(f) < 220 ? fz_range(f, 1, 40) : fz_edge(f, 40);
        n = rows >= 1 && cols >= 1 && rows <= 40 && cols <= 40 ? (size_t)VT_ACF_NCH * (size_t)rows * (size_t)cols : 1;
        p = (uint8_t *)fz_alloc(f, n);
        if (p == NULL) {
            return;
        }
        fz_fill(f, p, (int32_t)n, 1, (int32_t)n);
        for (k = 0; k < (int32_t)n; k += 97) {
            p[k] = fz_u8(f); /* a few bytes around the thresholds */
        }
        planes = p;
        have = (int64_t)n;
    } else {
        have = (int64_t)VT_ACF_NCH * rows * cols;
    }
    if (sel < 200 && m->win_cw >= 1 && m->win_ch >= 1 && m->win_cw <= cols && m->win_ch <= rows) {
        cx = fz_range(f, 0, cols - m->win_cw + (fz_u8(f) == 0 ? 1 : 0));
        cy = fz_range(f, 0, rows - m->win_ch + (fz_u8(f) == 0 ? 1 : 0));
    } else {
        cx = fz_edge(f, cols);
        cy = fz_edge(f, rows);
    }
    if (nulls & 3) {
        want = VT_E_ARG;
    } else if (!model_ok(mt)) {
        want = VT_E_ARG;
    } else if (rows < 1 || cols < 1 || cx < 0 || cy < 0 || cx > cols - m->win_cw || cy > rows - m->win_ch ||
               (int64_t)rows * cols > INT32_MAX / VT_ACF_NCH) {
        want = VT_E_SIZE;
    } else {
        want = VT_OK;
    }
    if (want == VT_OK && have < (int64_t)VT_ACF_NCH * rows * cols) {
        return; /* planes the harness did not allocate */
    }
    s = vt_acf_score(m, (nulls & 1) ? NULL : planes, rows, cols, cx, cy, (nulls & 2) ? NULL : &out);
    fz_status(s);
    FZ_ASSERT(s == want);
    if (s == VT_OK) {
        FZ_ASSERT(out == walk(m, planes, rows, cols, cx, cy));
    } else if (!(nulls & 2)) {
        FZ_ASSERT(out == 12345); /* nothing written */
    }
}

static int in_frame(const vt_box *b, const vt_image_u8 *img)
{
    return b->left >= 0 && b->left <= b->right && b->right < img->w && b->top >= 0 && b->top <= b->bottom &&
           b->bottom < img->h;
}

/* vt_nms's test: suppressed when inter x 1000 > iou_permille x union or > contain_permille x
 * the smaller area (inclusive px areas). */
static int overlaps(const vt_box *a, const vt_box *b, int32_t iou_permille, int32_t contain_permille)
{
    int64_t iw = (int64_t)(a->right < b->right ? a->right : b->right) - (a->left > b->left ? a->left : b->left) + 1;
    int64_t ih = (int64_t)(a->bottom < b->bottom ? a->bottom : b->bottom) - (a->top > b->top ? a->top : b->top) + 1;
    int64_t inter, ua, ub;
    if (iw <= 0 || ih <= 0) {
        return 0;
    }
    inter = iw * ih;
    ua = ((int64_t)a->right - a->left + 1) * ((int64_t)a->bottom - a->top + 1);
    ub = ((int64_t)b->right - b->left + 1) * ((int64_t)b->bottom - b->top + 1);
    return inter * 1000 > (int64_t)iou_permille * (ua + ub - inter) ||
           inter * 1000 > (int64_t)contain_permille * (ua < ub ? ua : ub);
}

static void detect(fz *f, model_t *mt, const vt_acf_cfg *cfg, const vt_camera_min *cam, const vt_image_u8 *img,
                   int ok_m, int ok_c)
{
    uint8_t nulls = fz_nulls(f);
    vt_status s, want;
    int32_t i, j;
    g_res.n_boxes = 77;
    if (nulls & 63) {
        want = VT_E_ARG;
    } else if (!ok_m || !ok_c || !cam_ok(cam)) {
        want = VT_E_ARG;
    } else {
        want = view_status(img);
    }
    s = vt_acf_detect((nulls & 1) ? NULL : &g_ws, (nulls & 2) ? NULL : &mt->m, (nulls & 4) ? NULL : cfg,
                      (nulls & 8) ? NULL : cam, (nulls & 16) ? NULL : img, (nulls & 32) ? NULL : &g_res);
    fz_status(s);
    FZ_ASSERT(s == want);
    if (nulls & 32) {
        return;
    }
    if (s != VT_OK) {
        FZ_ASSERT(g_res.n_boxes == 0);
        return;
    }
    FZ_ASSERT(g_res.n_boxes >= 0 && g_res.n_boxes <= VT_MAX_BOXES && g_res.n_boxes <= g_res.n_cand);
    FZ_ASSERT(g_res.n_cand >= 0 && g_res.n_cand <= VT_ACF_MAX_CAND && g_res.n_cand_dropped >= 0);
    FZ_ASSERT(g_res.n_window_hits == g_res.n_cand + g_res.n_cand_dropped);
    FZ_ASSERT(g_res.n_window_hits <= g_res.n_windows && g_res.n_shadow == 0 && g_res.n_windows_dropped == 0);
    for (i = 0; i < g_res.n_boxes; i++) {
        const vt_scored_box *b = &g_res.box[i];
        FZ_ASSERT(in_frame(&b->box, img));
        FZ_ASSERT(b->score >= cfg->score_min && b->source == VT_SRC_WINDOW);
        FZ_ASSERT(i == 0 || g_res.box[i - 1].score >= b->score);
        for (j = 0; j < i; j++) {
            FZ_ASSERT(!overlaps(&g_res.box[j].box, &b->box, cfg->nms_iou_permille, cfg->nms_contain_permille));
        }
    }
    /* vt_acf_detect_n with the model twice: every window scored twice, and NMS keeps one of
     * each twin (IoU 1) in the single run's order, so the boxes are the single run's */
    if (g_res.n_cand_dropped == 0 && 2 * g_res.n_cand <= VT_ACF_MAX_CAND && cfg->nms_iou_permille < 1000 &&
        (fz_u8(f) & 1)) {
        const vt_acf_model *ms[2];
        const vt_acf_cfg *cs[2];
        ms[0] = ms[1] = &mt->m;
        cs[0] = cs[1] = cfg;
        s = vt_acf_detect_n(&g_ws, 2, ms, cs, cam, img, &g_res2);
        FZ_ASSERT(s == VT_OK && g_res2.n_windows == 2 * g_res.n_windows && g_res2.n_cand == 2 * g_res.n_cand &&
                  g_res2.n_boxes == g_res.n_boxes && g_res2.n_cand_dropped == 0);
        FZ_ASSERT(memcmp(g_res.box, g_res2.box, (size_t)g_res.n_boxes * sizeof g_res.box[0]) == 0);
    }
    /* a trace of INT32_MIN drops nothing while no running sum can get below it */
    if (mt->m.reject == NULL && (int64_t)mt->m.n_trees * (1 << 24) + (1 << 30) < (int64_t)1 << 31 &&
        (fz_u8(f) & 3) == 0) {
        for (i = 0; i < mt->m.n_trees; i++) {
            mt->reject[i] = INT32_MIN;
        }
        mt->m.reject = mt->reject;
        s = vt_acf_detect(&g_ws, &mt->m, cfg, cam, img, &g_res2);
        mt->m.reject = NULL;
        FZ_ASSERT(s == VT_OK && g_res2.n_boxes == g_res.n_boxes && g_res2.n_windows == g_res.n_windows &&
                  g_res2.n_window_hits == g_res.n_window_hits && g_res2.n_cand == g_res.n_cand &&
                  g_res2.n_cand_dropped == g_res.n_cand_dropped);
        FZ_ASSERT(memcmp(g_res.box, g_res2.box, (size_t)g_res.n_boxes * sizeof g_res.box[0]) == 0);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t op = fz_u8(&f);
    vt_image_u8 img = image(&f);
    model_t mt;
    vt_acf_cfg cfg;
    vt_camera_min cam;
    const uint8_t *planes = NULL;
    int32_t rows = 0, cols = 0, ok_m, ok_c;
    memset(&mt, 0, sizeof mt);
    model(&f, &mt);
    fz_status(vt_acf_cfg_default(&cfg));
    if (fz_u8(&f) < 160) { /* a few levels: the rest is the same code again */
        int32_t left;
        cfg.first_scale = fz_range(&f, 0, VT_ACF_MAX_SCALES - 1);
        left = VT_ACF_MAX_SCALES - cfg.first_scale;
        cfg.n_scales = fz_range(&f, 1, left < 3 ? left : 3);
    }
    if (fz_u8(&f) < 128) {
        cfg.veh_w_min_mm = fz_range(&f, 100, 3000);
        cfg.veh_w_max_mm = fz_range(&f, cfg.veh_w_min_mm, 20000);
        cfg.slack_px = fz_range(&f, 0, 200);
        cfg.above_px = fz_range(&f, 0, 200);
        cfg.nms_iou_permille = fz_range(&f, 0, 1000);
        cfg.nms_contain_permille = fz_u8(&f) < 128 ? 1000 : fz_range(&f, 0, 1000);
        cfg.cols = fz_range(&f, VT_ACF_COLS_ALL, VT_ACF_COLS_RIGHT);
    }
    cfg.score_min = fz_u8(&f) < 200 ? (int32_t)(int8_t)fz_u8(&f) * 4096 : fz_raw_i32(&f);
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    {
        int32_t h = img.h > 0 && img.h <= VT_MAX_HEIGHT ? img.h : 48;
        cam.fx_q4 = 16 * 300;
        cam.height_mm = fz_u8(&f) < 200 ? fz_range(&f, 800, 3000) : fz_edge(&f, 20000);
        cam.horizon_y = fz_u8(&f) < 200 ? fz_range(&f, -h / 4, h) : fz_edge(&f, VT_MAX_HEIGHT);
        cam.hood_y = fz_u8(&f) < 200 ? fz_range(&f, 1, h + 8) : fz_edge(&f, 2 * VT_MAX_HEIGHT);
        if (fz_u8(&f) >= 224) {
            fz_mutate_i32s(&f, &cam, sizeof cam);
        }
    }
    ok_c = cfg_ok(&cfg);
    ok_m = model_ok(&mt);
    FZ_ASSERT((vt_acf_cfg_check(&cfg) == VT_OK) == ok_c);
    FZ_ASSERT(vt_acf_cfg_check(NULL) == VT_E_ARG && vt_acf_cfg_default(NULL) == VT_E_ARG);
    FZ_ASSERT((vt_acf_model_check(&mt.m) == VT_OK) == ok_m);
    FZ_ASSERT(vt_acf_model_check(NULL) == VT_E_ARG);
    {
        int32_t k = fz_edge(&f, VT_ACF_MAX_SCALES), r = -7;
        vt_status s = vt_acf_scale_q16(k, (op & 128) ? NULL : &r);
        fz_status(s);
        FZ_ASSERT((s == VT_OK) == (k >= 0 && k < VT_ACF_MAX_SCALES && !(op & 128)));
        FZ_ASSERT(s != VT_OK || r == g_scale[k]);
    }
    if (op & 1) {
        resample(&f, &img);
    }
    if (op & 2) {
        planes = channels(&f, &img, &rows, &cols);
    }
    if (op & 4) {
        score(&f, &mt, planes, rows, cols);
    }
    if (!(op & 8)) {
        detect(&f, &mt, &cfg, &cam, &img, ok_m, ok_c);
    }
    fz_close(&f);
    return 0;
}
