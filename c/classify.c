/* classify.c -- HOG and GIST descriptors and a linear SVM with quantised weights,
 * for verifying vehicle hypotheses (GIST paper sec. III: the GIST descriptor
 * of 32 Gabor filters over a 4x4 grid, classified by an SVM; HOG as Dalal &
 * Triggs in skimage.feature.hog's layout). The arithmetic of every function is
 * stated in classify.h; the float twin is pyvehtrack/reference/classify.py. */
#include <string.h>

#include "vehtrack/classify.h"
#include "vehtrack/fixed.h"
#include "internal.h"
#include "tables/classify_q.h"
#include "tables/svm_default.h"

#define VT__HCAP (VT_CLS_MAX_W / VT_CLS_CELL)    /* cells per row, band workspace */
#define VT__BCAP (VT_CLS_MAX_W / VT_CLS_CELL - 1) /* blocks per row, band workspace */
#define VT__GCX (VT_GIST_MAX_W / VT_CLS_CELL)
#define VT__GCY (VT_GIST_MAX_H / VT_CLS_CELL)
#define VT__LVL_STRIDE (VT_GIST_MAX_W / 2 + 1)

/* ------------------------------------------------------------------ HOG */

/* round(16 sqrt(n)) for 0 <= n <= 2 * 255^2, exact: a table below 1024; above,
 * an estimate from n >> 7 (off by <= 16), one Newton step on N = 256 n (then off
 * by <= 1) and a fix-up to the r with r^2 - r < N <= r^2 + r, which is exactly
 * round(sqrt(N)) since sqrt(N) is never a half-integer. */
static int32_t vt__mag_q4(int32_t n)
{
    int32_t r, big_n;
    if (n < VT__MAG_SMALL) {
        return vt__mag_small_q4[n];
    }
    big_n = n * 256;
    r = vt__mag_big_q4[n >> VT__MAG_SHIFT];
    r = (r + big_n / r) / 2;
    while (r * r - r >= big_n) {
        --r;
    }
    while (r * r + r < big_n) {
        ++r;
    }
    return r;
}

/* |g| sin(angle - theta_k) >= 0, i.e. angle >= 20 k degrees, for the folded
 * gradient (angle in [0, 180)) and k = 1..8. Exact in int64 (|g| <= 255, Q30;
 * tests/test_classify.py checks every gradient against the exact sign). */
static int vt__ge_bound(int32_t gx, int32_t gy, int k)
{
    return (int64_t)gy * vt__hog_bound_cos_q30[k - 1] - (int64_t)gx * vt__hog_bound_sin_q30[k - 1] >=
           0;
}

/* The orientation bin of a folded gradient (gy > 0, or gy == 0 and gx > 0): a
 * binary search over the boundaries. */
static int vt__hog_bin(int32_t gx, int32_t gy)
{
    int b = 0;
    if (vt__ge_bound(gx, gy, 4)) {
        b = 4;
    }
    if (vt__ge_bound(gx, gy, b + 2)) {
        b += 2;
    }
    if (vt__ge_bound(gx, gy, b + 1)) {
        b += 1;
    }
    if (b == 7 && vt__ge_bound(gx, gy, 8)) {
        b = 8;
    }
    return b;
}

/* Add one pixel's gradient to its cell's histogram hc[0..8]: the magnitude
 * round(16 |g|) into its unsigned orientation's bin (angle folded onto [0, 180)
 * degrees; 180 is bin 0). Most gradients of a road image have gx^2 + gy^2 <
 * VT__MAG_SMALL: both values then come from tables (the bin table is the search
 * of vt__hog_bin run by tools/gen_tables.py, fold included); the rest take the
 * search and the square root out of line. */
static void vt__hog_px_big(int32_t gx, int32_t gy, int32_t n, uint32_t *hc)
{
    if (gy < 0 || (gy == 0 && gx < 0)) {
        gx = -gx;
        gy = -gy;
    }
    hc[vt__hog_bin(gx, gy)] += (uint32_t)vt__mag_q4(n);
}

#define VT__HOG_PX(gx, gy, hc)                                                                    \
    do {                                                                                          \
        const int32_t n_ = (gx) * (gx) + (gy) * (gy);                                             \
        if (n_ < VT__MAG_SMALL) {                                                                 \
            (hc)[vt__hog_bin_small[((gy) + (VT__BIN_SMALL - 1)) * (2 * VT__BIN_SMALL - 1) + (gx) +   \
                                   (VT__BIN_SMALL - 1)]] += vt__mag_small_q4[n_];                    \
        } else {                                                                                  \
            vt__hog_px_big((gx), (gy), n_, (hc));                                                 \
        }                                                                                         \
    } while (0)

/* Cell histograms of one cell row (rows 8 cy .. 8 cy + 7) into hrow[cx][9]. A zero
 * gradient adds round(16 * 0) = 0 to bin 0, so it needs no test. */
static void vt__hog_cell_row(const vt_image_u8 *img, int32_t cy, int32_t cells_x, uint32_t *hrow)
{
    const int32_t w = img->w, h = img->h, xe = cells_x * VT_CLS_CELL;
    /* columns 1 .. xi - 1 have both neighbours; skimage's rule: d/dx is 0 on the
     * image's outermost columns, d/dy on its outermost rows */
    const int32_t xi = xe < w - 1 ? xe : w - 1;
    const size_t stride = (size_t)img->stride;
    int32_t x, y;
    memset(hrow, 0, (size_t)cells_x * VT_HOG_BINS * sizeof hrow[0]);
    for (y = cy * VT_CLS_CELL; y < (cy + 1) * VT_CLS_CELL; ++y) {
        const uint8_t *p0 = img->px + (size_t)y * stride;
        const int rows_ok = y > 0 && y < h - 1;
        const uint8_t *pu = rows_ok ? p0 - stride : p0;
        const uint8_t *pd = rows_ok ? p0 + stride : p0;
        int32_t gx = 0, gy = (int32_t)pd[0] - (int32_t)pu[0];
        VT__HOG_PX(gx, gy, hrow);
        for (x = 1; x < xi; ++x) {
            uint32_t *hc = hrow + (size_t)(x >> 3) * VT_HOG_BINS;
            gx = (int32_t)p0[x + 1] - (int32_t)p0[x - 1];
            gy = (int32_t)pd[x] - (int32_t)pu[x];
            VT__HOG_PX(gx, gy, hc);
        }
        for (; x < xe; ++x) {
            uint32_t *hc = hrow + (size_t)(x >> 3) * VT_HOG_BINS;
            gx = 0;
            gy = (int32_t)pd[x] - (int32_t)pu[x];
            VT__HOG_PX(gx, gy, hc);
        }
    }
}

/* L2-Hys of one block: cells a, a+9 (top row) and b, b+9 (bottom row) -> out[36] Q15.
 * See classify.h for the exact arithmetic. */
static void vt__hog_block(const uint32_t *a, const uint32_t *b, uint16_t *out)
{
    uint32_t hv[VT_HOG_BLOCK_LEN];
    uint64_t s2 = 0, s_un = 0, big_s, rs, rs2;
    int32_t i, nclip = 0;
    memcpy(hv, a, 18 * sizeof hv[0]);
    memcpy(hv + 18, b, 18 * sizeof hv[0]);
    for (i = 0; i < VT_HOG_BLOCK_LEN; ++i) {
        s2 += (uint64_t)hv[i] * hv[i];
    }
    if (s2 == 0) {
        memset(out, 0, VT_HOG_BLOCK_LEN * sizeof out[0]);
        return;
    }
    for (i = 0; i < VT_HOG_BLOCK_LEN; ++i) {
        uint64_t q = (uint64_t)hv[i] * hv[i];
        if (25u * q > s2) {
            ++nclip;
        } else {
            s_un += q;
        }
    }
    /* 25 ||c||^2 / ||h||^2 scaled by ||h||^2: S = 25 sum_unclipped h^2 + nclip s2. */
    big_s = 25u * s_un + (uint64_t)nclip * s2;
    rs = vt_isqrt_u64(big_s << 16);  /* 256 sqrt(S), floor */
    rs2 = vt_isqrt_u64(s2 << 16);    /* 256 ||h||, floor */
    for (i = 0; i < VT_HOG_BLOCK_LEN; ++i) {
        uint64_t q = (uint64_t)hv[i] * hv[i];
        uint64_t num = 25u * q > s2 ? rs2 << 15 : ((uint64_t)hv[i] * 5u * 256u) << 15;
        uint64_t v = (num + rs / 2) / rs;
        out[i] = (uint16_t)(v > 32768u ? 32768u : v);
    }
}

/* The prepare core, shared by the band workspace and vt_classify_box: cell rows
 * ping-pong in hist (2 x hcap x 9), blocks written at blocks + by * bstride +
 * bx * 36. */
static void vt__hog_run(const vt_image_u8 *img, int32_t cells_x, int32_t cells_y, uint32_t *hist,
                        int32_t hcap, uint16_t *blocks, size_t bstride)
{
    int32_t cy, bx;
    for (cy = 0; cy < cells_y; ++cy) {
        uint32_t *cur = hist + (size_t)(cy & 1) * (size_t)hcap * VT_HOG_BINS;
        const uint32_t *prev = hist + (size_t)((cy + 1) & 1) * (size_t)hcap * VT_HOG_BINS;
        vt__hog_cell_row(img, cy, cells_x, cur);
        if (cy == 0) {
            continue;
        }
        for (bx = 0; bx + 1 < cells_x; ++bx) {
            vt__hog_block(prev + (size_t)bx * VT_HOG_BINS, cur + (size_t)bx * VT_HOG_BINS,
                          blocks + (size_t)(cy - 1) * bstride + (size_t)bx * VT_HOG_BLOCK_LEN);
        }
    }
}

static vt_status vt__check_view(const vt_image_u8 *img, int32_t minw, int32_t minh, int32_t maxw,
                                int32_t maxh)
{
    if (img == NULL || img->px == NULL) {
        return VT_E_ARG;
    }
    if (img->w < minw || img->h < minh) {
        return VT_E_SIZE;
    }
    return vt__check_dims(img->w, img->h, img->stride, maxw, maxh);
}

vt_status vt_hog_prepare(vt_hog_ws *ws, const vt_image_u8 *img)
{
    vt_status s;
    if (ws == NULL) {
        return VT_E_ARG;
    }
    ws->cells_x = 0;
    ws->cells_y = 0;
    s = vt__check_view(img, 2 * VT_CLS_CELL, 2 * VT_CLS_CELL, VT_CLS_MAX_W, VT_CLS_MAX_H);
    if (s != VT_OK) {
        return s;
    }
    vt__hog_run(img, img->w / VT_CLS_CELL, img->h / VT_CLS_CELL, &ws->hist[0][0][0], VT__HCAP,
                &ws->blocks[0][0][0], (size_t)VT__BCAP * VT_HOG_BLOCK_LEN);
    ws->cells_x = img->w / VT_CLS_CELL;
    ws->cells_y = img->h / VT_CLS_CELL;
    return VT_OK;
}

/* A prepared HOG workspace is usable: its sizes are ones vt_hog_prepare sets. */
static int vt__hog_ws_ok(const vt_hog_ws *ws)
{
    return ws != NULL && ws->cells_x >= 2 && ws->cells_y >= 2 && ws->cells_x <= VT__HCAP &&
           ws->cells_y <= VT_CLS_MAX_H / VT_CLS_CELL;
}

/* The window (in cells) fits the prepared image. */
static int vt__win_fits(int32_t cx, int32_t cy, int32_t win_w, int32_t win_h, int32_t cells_x,
                        int32_t cells_y)
{
    return cx >= 0 && cy >= 0 && cx <= cells_x - win_w / VT_CLS_CELL &&
           cy <= cells_y - win_h / VT_CLS_CELL;
}

static int vt__hog_win_ok(int32_t win_w, int32_t win_h)
{
    return win_w >= 2 * VT_CLS_CELL && win_h >= 2 * VT_CLS_CELL && win_w <= VT_CLS_MAX_WIN &&
           win_h <= VT_CLS_MAX_WIN && win_w % VT_CLS_CELL == 0 && win_h % VT_CLS_CELL == 0;
}

vt_status vt_hog_descriptor(const vt_hog_ws *ws, int32_t cx, int32_t cy, int32_t win_w,
                            int32_t win_h, uint16_t *out, int32_t cap, int32_t *n_out)
{
    int32_t nbx, nby, j, n;
    if (n_out != NULL) {
        *n_out = 0;
    }
    if (!vt__hog_ws_ok(ws) || n_out == NULL || (out == NULL && cap != 0)) {
        return VT_E_ARG;
    }
    if (!vt__hog_win_ok(win_w, win_h) ||
        !vt__win_fits(cx, cy, win_w, win_h, ws->cells_x, ws->cells_y)) {
        return VT_E_SIZE;
    }
    nbx = win_w / VT_CLS_CELL - 1;
    nby = win_h / VT_CLS_CELL - 1;
    n = nbx * nby * VT_HOG_BLOCK_LEN;
    if (cap < n) {
        return VT_E_SIZE;
    }
    for (j = 0; j < nby; ++j) {
        memcpy(out + (size_t)j * (size_t)nbx * VT_HOG_BLOCK_LEN, &ws->blocks[cy + j][cx][0],
               (size_t)nbx * VT_HOG_BLOCK_LEN * sizeof out[0]);
    }
    *n_out = n;
    return VT_OK;
}

/* ------------------------------------------------------------------ SVM */

static int32_t vt__hog_dim(int32_t win_w, int32_t win_h)
{
    return (win_w / VT_CLS_CELL - 1) * (win_h / VT_CLS_CELL - 1) * VT_HOG_BLOCK_LEN;
}

vt_status vt_svm_model_check(const vt_svm_model *m)
{
    if (m == NULL || m->w == NULL || m->w_shift < 1 || m->w_shift > 30) {
        return VT_E_ARG;
    }
    if (m->kind == VT_DESC_HOG) {
        if (!vt__hog_win_ok(m->win_w, m->win_h) || m->dim != vt__hog_dim(m->win_w, m->win_h)) {
            return VT_E_ARG;
        }
        return VT_OK;
    }
    if (m->kind == VT_DESC_GIST) {
        if (m->win_w < 32 || m->win_h < 32 || m->win_w > VT_CLS_MAX_WIN ||
            m->win_h > VT_CLS_MAX_WIN || m->win_w % 32 != 0 || m->win_h % 32 != 0 ||
            m->dim != VT_GIST_DIM) {
            return VT_E_ARG;
        }
        return VT_OK;
    }
    return VT_E_ARG;
}

/* sum (Q(w_shift + 15)) -> Q16, round half up, plus bias, saturated. */
static int32_t vt__svm_finish(const vt_svm_model *m, int64_t acc)
{
    const int sh = (int)m->w_shift - 1;
    int64_t q = sh > 0 ? vt__floor_shr64(acc + ((int64_t)1 << (sh - 1)), sh) : acc;
    return vt_sat_s32(q + (int64_t)m->bias_q16);
}

static int64_t vt__dot(const int16_t *w, const uint16_t *x, int32_t n)
{
    int64_t acc = 0;
    int32_t i;
    for (i = 0; i < n; ++i) {
        acc += (int32_t)w[i] * (int32_t)x[i];
    }
    return acc;
}

vt_status vt_svm_decision(const vt_svm_model *m, const uint16_t *desc, int32_t n,
                          int32_t *score_q16)
{
    vt_status s;
    if (score_q16 != NULL) {
        *score_q16 = 0;
    }
    s = vt_svm_model_check(m);
    if (s != VT_OK || desc == NULL || score_q16 == NULL) {
        return VT_E_ARG;
    }
    if (n != m->dim) {
        return VT_E_SIZE;
    }
    *score_q16 = vt__svm_finish(m, vt__dot(m->w, desc, n));
    return VT_OK;
}

static int32_t vt__hog_score_at(const vt_hog_ws *ws, const vt_svm_model *m, int32_t cx, int32_t cy)
{
    const int32_t nbx = m->win_w / VT_CLS_CELL - 1, nby = m->win_h / VT_CLS_CELL - 1;
    const int32_t rl = nbx * VT_HOG_BLOCK_LEN;
    int64_t acc = 0;
    int32_t j;
    for (j = 0; j < nby; ++j) {
        acc += vt__dot(m->w + (size_t)j * (size_t)rl, &ws->blocks[cy + j][cx][0], rl);
    }
    return vt__svm_finish(m, acc);
}

vt_status vt_hog_window_score(const vt_hog_ws *ws, const vt_svm_model *m, int32_t cx,
                              int32_t cy, int32_t *score_q16)
{
    if (score_q16 != NULL) {
        *score_q16 = 0;
    }
    if (!vt__hog_ws_ok(ws) || vt_svm_model_check(m) != VT_OK || m->kind != VT_DESC_HOG ||
        score_q16 == NULL) {
        return VT_E_ARG;
    }
    if (!vt__win_fits(cx, cy, m->win_w, m->win_h, ws->cells_x, ws->cells_y)) {
        return VT_E_SIZE;
    }
    *score_q16 = vt__hog_score_at(ws, m, cx, cy);
    return VT_OK;
}

vt_status vt_hog_scan(const vt_hog_ws *ws, const vt_svm_model *m, int32_t cx0, int32_t cy0,
                      int32_t ncx, int32_t ncy, int32_t *scores, int32_t cap)
{
    int32_t i, j;
    if (!vt__hog_ws_ok(ws) || vt_svm_model_check(m) != VT_OK || m->kind != VT_DESC_HOG ||
        scores == NULL) {
        return VT_E_ARG;
    }
    if (ncx < 1 || ncy < 1 || ncx > VT__HCAP || ncy > VT_CLS_MAX_H / VT_CLS_CELL ||
        !vt__win_fits(cx0, cy0, m->win_w, m->win_h, ws->cells_x, ws->cells_y) ||
        !vt__win_fits(cx0 + ncx - 1, cy0 + ncy - 1, m->win_w, m->win_h, ws->cells_x,
                      ws->cells_y)) {
        return VT_E_SIZE;
    }
    if (cap < ncx * ncy) {
        return VT_E_CAPACITY;
    }
    for (j = 0; j < ncy; ++j) {
        for (i = 0; i < ncx; ++i) {
            scores[j * ncx + i] = vt__hog_score_at(ws, m, cx0 + i, cy0 + j);
        }
    }
    return VT_OK;
}

/* ------------------------------------------------------------------ GIST */

/* One scale's filtering of level image L (lw x lh, stride ls) for orientation o,
 * energies averaged into ws->cell[..][..][f]. cs = level pixels per cell side. */
static void vt__gist_filter(vt_gist_ws *ws, const uint8_t *lp, int32_t lw, int32_t lh, int32_t ls,
                            int32_t cs, int o, int f)
{
    const int half = VT_GIST_KSIZE / 2;
    const int16_t *fx = vt__gist_fx_q14 + o * 2 * VT_GIST_KSIZE;
    const int16_t *fy = vt__gist_fy_q14 + o * 2 * VT_GIST_KSIZE;
    const int32_t xe = ws->cells_x * cs, ye = ws->cells_y * cs;
    uint64_t acc[VT__GCX];
    int32_t slot[VT_GIST_KSIZE];
    int32_t next = 0, x, y, t;
    memset(acc, 0, sizeof acc);
    for (y = 0; y < ye; ++y) {
        /* Row pass for every row the column pass at y reads (y-5 .. y+5, clipped). */
        int32_t need = y + half < lh - 1 ? y + half : lh - 1;
        for (; next <= need; ++next) {
            const uint8_t *p = lp + (size_t)next * (size_t)ls;
            int32_t(*r)[2] = ws->rows[next % VT_GIST_KSIZE];
            for (x = 0; x < xe; ++x) {
                int32_t re = 0, im = 0;
                if (x >= half && x + half < lw) {
                    const uint8_t *q = p + x - half;
                    for (t = 0; t < VT_GIST_KSIZE; ++t) {
                        re += fx[2 * t] * q[t];
                        im += fx[2 * t + 1] * q[t];
                    }
                } else {
                    for (t = -half; t <= half; ++t) {
                        const int32_t v = p[vt__reflect101(x + t, lw)];
                        re += fx[2 * (t + half)] * v;
                        im += fx[2 * (t + half) + 1] * v;
                    }
                }
                /* Q14 -> Q4, round half up. */
                r[x][0] = (int32_t)vt__floor_shr64((int64_t)re + 512, 10);
                r[x][1] = (int32_t)vt__floor_shr64((int64_t)im + 512, 10);
            }
        }
        for (t = -half; t <= half; ++t) {
            slot[t + half] = vt__reflect101(y + t, lh) % VT_GIST_KSIZE;
        }
        for (x = 0; x < xe; ++x) {
            int64_t re = 0, im = 0, e;
            for (t = -half; t <= half; ++t) {
                const int32_t *rv = ws->rows[slot[t + half]][x];
                const int32_t kr = fy[2 * (t + half)], ki = fy[2 * (t + half) + 1];
                re += (int64_t)kr * rv[0] - (int64_t)ki * rv[1];
                im += (int64_t)kr * rv[1] + (int64_t)ki * rv[0];
            }
            /* Q18 -> Q0, round half up; |re|, |im| < 2^14, so e < 2^29. */
            re = vt__floor_shr64(re + ((int64_t)1 << 17), 18);
            im = vt__floor_shr64(im + ((int64_t)1 << 17), 18);
            e = re * re + im * im;
            acc[x / cs] += (uint64_t)e;
        }
        if (y % cs == cs - 1) {
            const int32_t cy = y / cs;
            const uint64_t n = (uint64_t)cs * (uint64_t)cs;
            int32_t cx;
            for (cx = 0; cx < ws->cells_x; ++cx) {
                uint64_t mean = (acc[cx] + n / 2) / n;
                ws->cell[cy][cx][f] = (uint32_t)(mean > 0xFFFFFFFFu ? 0xFFFFFFFFu : mean);
                acc[cx] = 0;
            }
        }
    }
}

vt_status vt_gist_prepare(vt_gist_ws *ws, const vt_image_u8 *img)
{
    vt_status s;
    const uint8_t *lp;
    int32_t lw, lh, ls, sc;
    int o;
    if (ws == NULL) {
        return VT_E_ARG;
    }
    ws->cells_x = 0;
    ws->cells_y = 0;
    s = vt__check_view(img, 32, 32, VT_GIST_MAX_W, VT_GIST_MAX_H);
    if (s != VT_OK) {
        return s;
    }
    ws->cells_x = img->w / VT_CLS_CELL;
    ws->cells_y = img->h / VT_CLS_CELL;
    lp = img->px;
    lw = img->w;
    lh = img->h;
    ls = img->stride;
    for (sc = 0; sc < VT_GIST_SCALES; ++sc) {
        if (sc > 0) {
            vt_image_u8 src;
            vt_image_u8_mut dst;
            src.px = lp;
            src.w = lw;
            src.h = lh;
            src.stride = ls;
            dst.px = &ws->level[sc & 1][0][0];
            dst.w = (lw + 1) / 2;
            dst.h = (lh + 1) / 2;
            dst.stride = VT__LVL_STRIDE;
            s = vt_pyr_down(&src, &dst);
            if (s != VT_OK) {
                ws->cells_x = 0;
                ws->cells_y = 0;
                return s;
            }
            lp = dst.px;
            lw = dst.w;
            lh = dst.h;
            ls = dst.stride;
        }
        for (o = 0; o < VT_GIST_ORIENT; ++o) {
            vt__gist_filter(ws, lp, lw, lh, ls, VT_CLS_CELL >> sc, o, sc * VT_GIST_ORIENT + o);
        }
    }
    return VT_OK;
}

vt_status vt_gist_descriptor(const vt_gist_ws *ws, int32_t cx, int32_t cy, int32_t win_w,
                             int32_t win_h, uint16_t *out, int32_t cap, int32_t *n_out)
{
    uint64_t rms[VT_GIST_DIM];
    uint64_t norm2 = 0, rn;
    int32_t gcw, gch, gx, gy, f, i, j;
    if (n_out != NULL) {
        *n_out = 0;
    }
    if (ws == NULL || n_out == NULL || (out == NULL && cap != 0) || ws->cells_x < 4 ||
        ws->cells_y < 4 || ws->cells_x > VT__GCX || ws->cells_y > VT__GCY) {
        return VT_E_ARG;
    }
    if (win_w < 32 || win_h < 32 || win_w % 32 != 0 || win_h % 32 != 0 ||
        !vt__win_fits(cx, cy, win_w, win_h, ws->cells_x, ws->cells_y) || cap < VT_GIST_DIM) {
        return VT_E_SIZE;
    }
    gcw = win_w / 32; /* cells per grid cell side */
    gch = win_h / 32;
    for (gy = 0; gy < VT_GIST_GRID; ++gy) {
        for (gx = 0; gx < VT_GIST_GRID; ++gx) {
            for (f = 0; f < VT_GIST_FILTERS; ++f) {
                uint64_t e = 0, n = (uint64_t)gcw * (uint64_t)gch, mean;
                uint64_t r;
                for (j = 0; j < gch; ++j) {
                    for (i = 0; i < gcw; ++i) {
                        e += ws->cell[cy + gy * gch + j][cx + gx * gcw + i][f];
                    }
                }
                mean = (e + n / 2) / n;
                r = vt_isqrt_u64(mean << 8); /* 16 sqrt(mean energy), floor: Q4 RMS */
                rms[(gy * VT_GIST_GRID + gx) * VT_GIST_FILTERS + f] = r;
                norm2 += r * r;
            }
        }
    }
    rn = vt_isqrt_u64(norm2 << 16); /* 256 ||rms||, floor */
    for (i = 0; i < VT_GIST_DIM; ++i) {
        uint64_t v = rn == 0 ? 0 : ((rms[i] << 23) + rn / 2) / rn;
        out[i] = (uint16_t)(v > 32768u ? 32768u : v);
    }
    *n_out = VT_GIST_DIM;
    return VT_OK;
}

/* ------------------------------------------------------------------ boxes */

/* One output pixel: the rounded mean of src rows y0..y1-1, columns x0..x1-1 (n pixels). */
static uint8_t vt__area_mean(const vt_image_u8 *src, int32_t x0, int32_t x1, int32_t y0, int32_t y1)
{
    uint64_t sum = 0, n = (uint64_t)(x1 - x0) * (uint64_t)(y1 - y0);
    int32_t x, y;
    for (y = y0; y < y1; ++y) {
        const uint8_t *p = src->px + (size_t)y * (size_t)src->stride;
        for (x = x0; x < x1; ++x) {
            sum += p[x];
        }
    }
    /* a 32-bit division where it suffices (Cortex-M has no 64-bit divide) */
    if (sum < 0x80000000u && n < 0x80000000u) {
        return (uint8_t)(((uint32_t)sum + (uint32_t)(n / 2)) / (uint32_t)n);
    }
    return (uint8_t)((sum + n / 2) / n);
}

/* One step of floor(i n / d) walked as quotient q + remainder r (q n/d and r n%d
 * its increments, 0 <= r < d): returns the value before the step. */
static int32_t vt__qr_step(int32_t *q, int32_t *r, int32_t qn, int32_t rn, int32_t d)
{
    int32_t before = *q;
    *q += qn;
    *r += rn;
    if (*r >= d) {
        *r -= d;
        ++*q;
    }
    return before;
}

vt_status vt_resample_area(const vt_image_u8 *src, const vt_box *box, vt_image_u8_mut *dst)
{
    vt_status s = vt_image_u8_check(src);
    int32_t bw, bh, i, j, dw, dh, qx, rx, qy, ry, yq = 0, yr = 0, xq = 0, xr = 0, narrow;
    uint16_t col0[VT_CLS_MAX_WIN];
    uint8_t two_x[VT_CLS_MAX_WIN];
    size_t ss;
    if (s != VT_OK) {
        return s;
    }
    if (box == NULL || dst == NULL || dst->px == NULL) {
        return VT_E_ARG;
    }
    s = vt__check_dims(dst->w, dst->h, dst->stride, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    if (s != VT_OK) {
        return s;
    }
    if (box->left < 0 || box->top < 0 || box->right < box->left || box->bottom < box->top ||
        box->right >= src->w || box->bottom >= src->h) {
        return VT_E_ARG;
    }
    bw = box->right - box->left + 1;
    bh = box->bottom - box->top + 1;
    if (bw == dst->w && bh == dst->h) {
        /* every output pixel is one source pixel */
        for (j = 0; j < bh; ++j) {
            memcpy(dst->px + (size_t)j * (size_t)dst->stride,
                   src->px + (size_t)(box->top + j) * (size_t)src->stride + (size_t)box->left,
                   (size_t)bw);
        }
        return VT_OK;
    }
    /* floor(i bw / w) walked as quotient + remainder (no division per pixel):
     * the same bounds as the per-pixel formula, so the same output. Sizes in
     * locals: the uint8_t stores may alias anything, so fields would be reloaded. */
    dw = dst->w;
    dh = dst->h;
    ss = (size_t)src->stride;
    qx = bw / dw;
    rx = bw % dw;
    qy = bh / dh;
    ry = bh % dh;
    /* A window-sized output of a box under twice its width (every sliding window):
     * the columns' first pixel and span (1 or 2) once, then each output pixel is
     * 1, 2 or 4 pixels whose mean is a shift, (sum + n/2) >> log2 n, the same value
     * as the division. */
    narrow = dw <= VT_CLS_MAX_WIN && bw < 2 * dw;
    for (i = 0; narrow && i < dw; ++i) {
        int32_t x0 = vt__qr_step(&xq, &xr, qx, rx, dw);
        col0[i] = (uint16_t)x0;
        two_x[i] = (uint8_t)(xq - x0 == 2);
    }
    for (j = 0; j < dh; ++j) {
        int32_t y0 = box->top + vt__qr_step(&yq, &yr, qy, ry, dh), y1;
        uint8_t *o = dst->px + (size_t)j * (size_t)dst->stride;
        const uint8_t *row;
        y1 = box->top + yq;
        y1 = y1 <= y0 ? y0 + 1 : y1;
        row = src->px + (size_t)y0 * ss + (size_t)box->left;
        if (narrow && y1 - y0 == 1) {
            for (i = 0; i < dw; ++i) {
                const uint8_t *p = row + col0[i];
                o[i] = (uint8_t)(two_x[i] ? (p[0] + p[1] + 1u) >> 1 : p[0]);
            }
        } else if (narrow && y1 - y0 == 2) {
            for (i = 0; i < dw; ++i) {
                const uint8_t *p = row + col0[i];
                o[i] = (uint8_t)(two_x[i] ? (p[0] + p[1] + p[ss] + p[ss + 1] + 2u) >> 2
                                          : (p[0] + p[ss] + 1u) >> 1);
            }
        } else {
            int32_t xq2 = 0, xr2 = 0;
            for (i = 0; i < dw; ++i) {
                int32_t x0 = vt__qr_step(&xq2, &xr2, qx, rx, dw);
                o[i] = vt__area_mean(src, box->left + x0, box->left + (xq2 <= x0 ? x0 + 1 : xq2), y0,
                                     y1);
            }
        }
    }
    return VT_OK;
}

/* The box resampled to the window and its descriptor, into ws->desc (*n values).
 * kind, win_w and win_h come from a checked model. */
static vt_status vt__box_descriptor(vt_cls_box_ws *ws, int32_t kind, int32_t win_w, int32_t win_h,
                                    const vt_image_u8 *frame, const vt_box *box, int32_t *n)
{
    vt_status s;
    vt_image_u8_mut wv;
    vt_image_u8 wr;
    *n = 0;
    wv.px = ws->win;
    wv.w = win_w;
    wv.h = win_h;
    wv.stride = win_w;
    s = vt_resample_area(frame, box, &wv);
    if (s != VT_OK) {
        return s;
    }
    wr.px = ws->win;
    wr.w = wv.w;
    wr.h = wv.h;
    wr.stride = wv.stride;
    if (kind == VT_DESC_HOG) {
        vt__hog_run(&wr, wr.w / VT_CLS_CELL, wr.h / VT_CLS_CELL, &ws->hist[0][0][0],
                    VT_CLS_MAX_WIN / VT_CLS_CELL, ws->desc,
                    (size_t)(wr.w / VT_CLS_CELL - 1) * VT_HOG_BLOCK_LEN);
        *n = vt__hog_dim(win_w, win_h);
        return VT_OK;
    }
    s = vt_gist_prepare(&ws->gist, &wr);
    if (s == VT_OK) {
        s = vt_gist_descriptor(&ws->gist, 0, 0, wr.w, wr.h, ws->desc, VT_CLS_MAX_DIM, n);
    }
    return s;
}

/* ------------------------------------------------------------------ MLP */

static int vt__desc_ok(int32_t kind, int32_t win_w, int32_t win_h, int32_t dim)
{
    if (kind == VT_DESC_HOG) {
        return vt__hog_win_ok(win_w, win_h) && dim == vt__hog_dim(win_w, win_h);
    }
    if (kind == VT_DESC_GIST) {
        return win_w >= 32 && win_h >= 32 && win_w <= VT_CLS_MAX_WIN && win_h <= VT_CLS_MAX_WIN &&
               win_w % 32 == 0 && win_h % 32 == 0 && dim == VT_GIST_DIM;
    }
    return 0;
}

vt_status vt_mlp_model_check(const vt_mlp_model *m)
{
    if (m == NULL || m->w1 == NULL || m->b1_q16 == NULL || m->w2 == NULL || m->hidden < 1 ||
        m->hidden > VT_MLP_MAX_HIDDEN || m->w1_shift < 1 || m->w1_shift > 30 ||
        m->w2_shift < 1 || m->w2_shift > 30 || !vt__desc_ok(m->kind, m->win_w, m->win_h, m->dim)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

vt_status vt_mlp_decision(const vt_mlp_model *m, const uint16_t *desc, int32_t n,
                          int32_t *score_q16)
{
    int64_t out = 0;
    int32_t j;
    if (score_q16 != NULL) {
        *score_q16 = 0;
    }
    if (vt_mlp_model_check(m) != VT_OK || desc == NULL || score_q16 == NULL) {
        return VT_E_ARG;
    }
    if (n != m->dim) {
        return VT_E_SIZE;
    }
    for (j = 0; j < m->hidden; ++j) {
        const int sh = (int)m->w1_shift - 1;
        int64_t a = vt__dot(m->w1 + (size_t)j * (size_t)m->dim, desc, n);
        int32_t hq;
        a = sh > 0 ? vt__floor_shr64(a + ((int64_t)1 << (sh - 1)), sh) : a;
        hq = vt_sat_s32(a + (int64_t)m->b1_q16[j]);
        if (hq > 0) {
            /* |w2| < 2^15, h < 2^31, hidden <= 64: the sum stays below 2^52. */
            out += (int64_t)m->w2[j] * hq;
        }
    }
    out = vt__floor_shr64(out + ((int64_t)1 << (m->w2_shift - 1)), (int)m->w2_shift);
    *score_q16 = vt_sat_s32(out + (int64_t)m->b2_q16);
    return VT_OK;
}

/* One box through one model: the SVM when mlp is NULL, else the MLP (the model is
 * checked first, so a NULL model of either kind is VT_E_ARG). */
static vt_status vt__classify_box(vt_cls_box_ws *ws, const vt_svm_model *svm, const vt_mlp_model *mlp,
                                  const vt_image_u8 *frame, const vt_box *box, int32_t *score_q16)
{
    vt_status s;
    int32_t n = 0;
    int32_t ok = mlp != NULL ? vt_mlp_model_check(mlp) == VT_OK : vt_svm_model_check(svm) == VT_OK;
    if (score_q16 != NULL) {
        *score_q16 = 0;
    }
    if (ws == NULL || score_q16 == NULL || !ok) {
        return VT_E_ARG;
    }
    s = mlp != NULL ? vt__box_descriptor(ws, mlp->kind, mlp->win_w, mlp->win_h, frame, box, &n)
                    : vt__box_descriptor(ws, svm->kind, svm->win_w, svm->win_h, frame, box, &n);
    if (s != VT_OK) {
        return s;
    }
    return mlp != NULL ? vt_mlp_decision(mlp, ws->desc, n, score_q16)
                       : vt_svm_decision(svm, ws->desc, n, score_q16);
}

vt_status vt_classify_box(vt_cls_box_ws *ws, const vt_svm_model *m, const vt_image_u8 *frame,
                          const vt_box *box, int32_t *score_q16)
{
    return vt__classify_box(ws, m, NULL, frame, box, score_q16);
}

vt_status vt_classify_box_mlp(vt_cls_box_ws *ws, const vt_mlp_model *m, const vt_image_u8 *frame,
                              const vt_box *box, int32_t *score_q16)
{
    if (m == NULL) {
        if (score_q16 != NULL) {
            *score_q16 = 0;
        }
        return VT_E_ARG;
    }
    return vt__classify_box(ws, NULL, m, frame, box, score_q16);
}

/* ------------------------------------------------------------------ default models */

#if VT__HAVE_DEFAULT_HOG
static const vt_svm_model vt__model_hog = {
    VT_DESC_HOG, VT__DEFAULT_HOG_WIN_W, VT__DEFAULT_HOG_WIN_H, VT__DEFAULT_HOG_DIM,
    VT__DEFAULT_HOG_W_SHIFT, VT__DEFAULT_HOG_BIAS_Q16, VT__DEFAULT_HOG_THRESHOLD_Q16,
    vt__default_hog_w};
#endif
#if VT__HAVE_DEFAULT_GIST
static const vt_svm_model vt__model_gist = {
    VT_DESC_GIST, VT__DEFAULT_GIST_WIN_W, VT__DEFAULT_GIST_WIN_H, VT__DEFAULT_GIST_DIM,
    VT__DEFAULT_GIST_W_SHIFT, VT__DEFAULT_GIST_BIAS_Q16, VT__DEFAULT_GIST_THRESHOLD_Q16,
    vt__default_gist_w};
#endif

#if VT__HAVE_DEFAULT_MLP
static const vt_mlp_model vt__model_mlp = {
    VT__DEFAULT_MLP_KIND, VT__DEFAULT_MLP_WIN_W, VT__DEFAULT_MLP_WIN_H, VT__DEFAULT_MLP_DIM,
    VT__DEFAULT_MLP_HIDDEN, VT__DEFAULT_MLP_W1_SHIFT, VT__DEFAULT_MLP_W2_SHIFT,
    VT__DEFAULT_MLP_B2_Q16, VT__DEFAULT_MLP_THRESHOLD_Q16, vt__default_mlp_w1, vt__default_mlp_b1,
    vt__default_mlp_w2};
#endif

vt_status vt_mlp_default_model(const vt_mlp_model **m)
{
    if (m == NULL) {
        return VT_E_ARG;
    }
    *m = NULL;
#if VT__HAVE_DEFAULT_MLP
    *m = &vt__model_mlp;
    return VT_OK;
#else
    return VT_E_ARG;
#endif
}

vt_status vt_svm_default_model(int32_t kind, const vt_svm_model **m)
{
    if (m == NULL) {
        return VT_E_ARG;
    }
    *m = NULL;
#if VT__HAVE_DEFAULT_HOG
    if (kind == VT_DESC_HOG) {
        *m = &vt__model_hog;
        return VT_OK;
    }
#endif
#if VT__HAVE_DEFAULT_GIST
    if (kind == VT_DESC_GIST) {
        *m = &vt__model_gist;
        return VT_OK;
    }
#endif
    (void)kind;
    return VT_E_ARG;
}
