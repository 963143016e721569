/* acf.c -- aggregated channel features on a quarter-octave pyramid scored by a
 * boosted tree ensemble with a soft cascade: the dense first stage of whole-road
 * detection (GIST paper sec. III's sliding windows + classifier; IVVI paper sec.
 * 4/5's flat-road band). The arithmetic is stated in acf.h. */
#include <stddef.h>

#include "vehtrack/acf.h"
#include "vehtrack/fixed.h"
#include "internal.h"

static const int32_t vt__acf_scale[VT_ACF_MAX_SCALES] = VT_ACF_SCALE_Q16_INIT;

/* tan 30 and tan 60 in Q32 (rounded): the orientation bin boundaries. */
#define VT__TAN30_Q32 INT64_C(2479700525)
#define VT__TAN60_Q32 INT64_C(7439101575)

vt_status vt_acf_cfg_default(vt_acf_cfg *cfg)
{
    static const vt_acf_cfg def = VT_ACF_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_acf_cfg_check(const vt_acf_cfg *cfg)
{
    if (cfg == NULL || cfg->first_scale < 0 || cfg->first_scale >= VT_ACF_MAX_SCALES ||
        cfg->n_scales < 1 || cfg->n_scales > VT_ACF_MAX_SCALES - cfg->first_scale ||
        cfg->veh_w_min_mm < 100 || cfg->veh_w_max_mm < cfg->veh_w_min_mm ||
        cfg->veh_w_max_mm > 20000 || cfg->slack_px < 0 || cfg->slack_px > VT_MAX_HEIGHT ||
        cfg->above_px < 0 || cfg->above_px > VT_MAX_HEIGHT || cfg->nms_iou_permille < 0 ||
        cfg->nms_iou_permille > 1000 || cfg->nms_contain_permille < 0 ||
        cfg->nms_contain_permille > 1000 || cfg->cols < VT_ACF_COLS_ALL ||
        cfg->cols > VT_ACF_COLS_RIGHT) {
        return VT_E_ARG;
    }
    return VT_OK;
}

vt_status vt_acf_model_check(const vt_acf_model *m)
{
    int32_t i, n_in, n_leaf, n_feat;
    if (m == NULL || m->feat == NULL || m->thr == NULL || m->leaf == NULL || m->pad < 0 ||
        m->pad > 4 || m->win_cw < 2 * m->pad + 1 || m->win_cw > VT_ACF_MAX_WIN_CELLS ||
        m->win_ch < 2 * m->pad + 1 || m->win_ch > VT_ACF_MAX_WIN_CELLS || m->n_trees < 1 ||
        m->n_trees > VT_ACF_MAX_TREES || m->depth < 1 || m->depth > VT_ACF_MAX_DEPTH ||
        m->bias_q16 < -(1 << 30) || m->bias_q16 > (1 << 30)) {
        return VT_E_ARG;
    }
    n_in = (1 << m->depth) - 1;
    n_leaf = 1 << m->depth;
    n_feat = VT_ACF_NCH * m->win_ch * m->win_cw;
    for (i = 0; i < m->n_trees * n_in; ++i) {
        if ((int32_t)m->feat[i] >= n_feat) {
            return VT_E_ARG;
        }
    }
    for (i = 0; i < m->n_trees * n_leaf; ++i) {
        if (m->leaf[i] < -(1 << 24) || m->leaf[i] > (1 << 24)) {
            return VT_E_ARG;
        }
    }
    return VT_OK;
}

vt_status vt_acf_scale_q16(int32_t k, int32_t *r_q16)
{
    if (r_q16 == NULL || k < 0 || k >= VT_ACF_MAX_SCALES) {
        return VT_E_ARG;
    }
    *r_q16 = vt__acf_scale[k];
    return VT_OK;
}

/* Level size along one axis: floor(n * 65536 / r). */
static int32_t vt__acf_lsize(int32_t n, int32_t r)
{
    return (int32_t)(((int64_t)n << 16) / r);
}

/* One input row resampled horizontally: hrow[x] = sum_i wx_i p[i] (Q16 weights of
 * the span [x r, (x + 1) r)), at most r * 255 < 2^28. */
static void vt__acf_hpass(const uint8_t *p, int32_t lw, int32_t r, uint32_t *hrow)
{
    int32_t x;
    for (x = 0; x < lw; ++x) {
        int64_t a = (int64_t)x * r, b = a + r;
        int32_t i0 = (int32_t)(a >> 16), i1 = (int32_t)((b - 1) >> 16), i;
        uint32_t acc;
        if (i0 == i1) {
            acc = (uint32_t)r * p[i0];
        } else {
            acc = (uint32_t)(65536 - (int32_t)(a & 0xffff)) * p[i0];
            for (i = i0 + 1; i < i1; ++i) {
                acc += (uint32_t)65536 * p[i];
            }
            acc += (uint32_t)(b - ((int64_t)i1 << 16)) * p[i1];
        }
        hrow[x] = acc;
    }
}

/* The resampling itself (arguments checked): level rows y0 .. y0 + nh - 1, lw columns. */
static void vt__acf_resample(const vt_image_u8 *src, int32_t r, int32_t y0, int32_t lw,
                             int32_t nh, uint8_t *dst, int32_t dstride, uint32_t *hrow,
                             uint64_t *acc)
{
    int64_t rr = (int64_t)r * r;
    int32_t y, x, j;
    for (y = y0; y < y0 + nh; ++y) {
        int64_t a = (int64_t)y * r, b = a + r;
        int32_t j0 = (int32_t)(a >> 16), j1 = (int32_t)((b - 1) >> 16);
        uint8_t *out = dst + (size_t)(y - y0) * (size_t)dstride;
        for (x = 0; x < lw; ++x) {
            acc[x] = 0;
        }
        for (j = j0; j <= j1; ++j) {
            int64_t lo = (int64_t)j << 16, hi = lo + 65536;
            uint64_t wy = (uint64_t)((hi < b ? hi : b) - (lo > a ? lo : a));
            vt__acf_hpass(src->px + (size_t)j * (size_t)src->stride, lw, r, hrow);
            for (x = 0; x < lw; ++x) {
                acc[x] += wy * hrow[x];
            }
        }
        for (x = 0; x < lw; ++x) {
            out[x] = (uint8_t)((acc[x] + (uint64_t)(rr >> 1)) / (uint64_t)rr);
        }
    }
}

vt_status vt_acf_resample(vt_acf_ws *ws, const vt_image_u8 *src, int32_t r_q16, int32_t y0,
                          vt_image_u8_mut *dst)
{
    vt_status s;
    if (ws == NULL || src == NULL || dst == NULL || dst->px == NULL) {
        return VT_E_ARG;
    }
    s = vt_image_u8_check(src);
    if (s != VT_OK) {
        return s;
    }
    if (r_q16 < 65536 || r_q16 > 16 * 65536) {
        return VT_E_ARG;
    }
    if (dst->w < 1 || dst->h < 1 || dst->stride < dst->w || y0 < 0 ||
        dst->w > vt__acf_lsize(src->w, r_q16) || dst->h > vt__acf_lsize(src->h, r_q16) - y0) {
        return VT_E_SIZE;
    }
    vt__acf_resample(src, r_q16, y0, dst->w, dst->h, dst->px, dst->stride, ws->hrow, ws->acc);
    return VT_OK;
}

/* A level (or image) as the channel code reads it: rows py0 .. py1 of an image of
 * w x h px held at px (row py0 first). */
typedef struct {
    const uint8_t *px;
    int32_t stride;
    int32_t w;
    int32_t h;
    int32_t py0;
} vt__acf_src;

/* g(x, y) for x = -1 .. w into g[0 .. w + 1] (acf.h: L at clamped x, y). */
static void vt__acf_grow(const vt__acf_src *L, int32_t y, uint16_t *g, uint16_t *v)
{
    const uint8_t *a = L->px + (size_t)(vt__clamp_i32(y - 1, 0, L->h - 1) - L->py0) * (size_t)L->stride;
    const uint8_t *b = L->px + (size_t)(vt__clamp_i32(y, 0, L->h - 1) - L->py0) * (size_t)L->stride;
    const uint8_t *c = L->px + (size_t)(vt__clamp_i32(y + 1, 0, L->h - 1) - L->py0) * (size_t)L->stride;
    int32_t x, w = L->w;
    for (x = 0; x < w; ++x) {
        v[x] = (uint16_t)(a[x] + 2 * b[x] + c[x]);
    }
    for (x = -1; x <= w; ++x) {
        int32_t l = vt__clamp_i32(x - 1, 0, w - 1), m = vt__clamp_i32(x, 0, w - 1);
        int32_t r = vt__clamp_i32(x + 1, 0, w - 1);
        g[x + 1] = (uint16_t)(v[l] + 2 * v[m] + v[r]);
    }
}

/* Orientation bin 0..5 of (gx, gy): floor(6 a / pi), a = atan2(gy, gx) mod pi. */
static int32_t vt__acf_bin(int32_t gx, int32_t gy)
{
    int64_t t;
    if (gy < 0 || (gy == 0 && gx < 0)) {
        gx = -gx;
        gy = -gy;
    }
    t = (int64_t)gy << 32;
    if (gx > 0) {
        return t < gx * VT__TAN30_Q32 ? 0 : (t < gx * VT__TAN60_Q32 ? 1 : 2);
    }
    if (gx == 0) {
        return gy > 0 ? 3 : 0;
    }
    return t > -gx * VT__TAN60_Q32 ? 3 : (t > -gx * VT__TAN30_Q32 ? 4 : 5);
}

/* Raw cell sums of cell row cy (acf.h: G, M, O_0..5) into raw[c][cx], cw cells. */
static void vt__acf_raw(vt_acf_ws *ws, const vt__acf_src *L, int32_t cy, int32_t cw,
                        uint32_t raw[VT_ACF_NCH][(VT_MAX_WIDTH) / 4])
{
    int32_t i, x, c;
    uint16_t *v = ws->vrow;
    for (c = 0; c < VT_ACF_NCH; ++c) {
        for (x = 0; x < cw; ++x) {
            raw[c][x] = 0;
        }
    }
    for (i = 0; i < 6; ++i) {
        vt__acf_grow(L, 4 * cy - 1 + i, ws->grow[i], v);
    }
    for (i = 1; i <= 4; ++i) {
        const uint16_t *gu = ws->grow[i - 1], *g = ws->grow[i], *gd = ws->grow[i + 1];
        for (x = 0; x < 4 * cw; ++x) {
            int32_t gx = (int32_t)g[x + 2] - (int32_t)g[x];
            int32_t gy = (int32_t)gd[x + 1] - (int32_t)gu[x + 1];
            uint32_t m = vt_isqrt_u32((uint32_t)(gx * gx + gy * gy));
            int32_t cx = x >> 2;
            raw[0][cx] += g[x + 1];
            raw[1][cx] += m;
            raw[2 + vt__acf_bin(gx, gy)][cx] += m;
        }
    }
}

/* Channel bytes of cell rows cy0 .. cy0 + n_cy - 1 (acf.h) into out[c][cy - cy0][cx]
 * (streaming: rings of 4 raw and 4 normalised cell rows). */
static void vt__acf_chan(vt_acf_ws *ws, const vt__acf_src *L, int32_t cy0, int32_t n_cy,
                         uint8_t *out)
{
    int32_t cw = L->w / 4, nch = L->h / 4, last = nch - 1;
    int32_t next_raw = vt__max_i32(0, cy0 - 2), next_nrm = vt__max_i32(0, cy0 - 1);
    int32_t cy, c, x;
    size_t plane = (size_t)n_cy * (size_t)cw;
    for (cy = cy0; cy < cy0 + n_cy; ++cy) {
        int32_t lim = cy + 1 < last ? cy + 1 : last;
        uint32_t(*nu)[(VT_MAX_WIDTH) / 4], (*nc)[(VT_MAX_WIDTH) / 4], (*nd)[(VT_MAX_WIDTH) / 4];
        while (next_nrm <= lim) {
            int32_t r = next_nrm, rl = r + 1 < last ? r + 1 : last;
            const uint32_t *mu, *mc, *md;
            while (next_raw <= rl) {
                vt__acf_raw(ws, L, next_raw, cw, ws->raw[next_raw & 3]);
                ++next_raw;
            }
            mu = ws->raw[vt__max_i32(r - 1, 0) & 3][1];
            mc = ws->raw[r & 3][1];
            md = ws->raw[rl & 3][1];
            for (x = 0; x < cw; ++x) {
                int32_t xl = vt__max_i32(x - 1, 0), xr = x + 1 < cw ? x + 1 : cw - 1;
                uint32_t n9 = mu[xl] + mu[x] + mu[xr] + mc[xl] + mc[x] + mc[xr] + md[xl] + md[x] +
                              md[xr] + 2880u;
                ws->nrm[r & 3][0][x] = ws->raw[r & 3][0][x];
                for (c = 1; c < VT_ACF_NCH; ++c) {
                    ws->nrm[r & 3][c][x] =
                        (uint32_t)(((uint64_t)576 * ws->raw[r & 3][c][x]) / n9);
                }
            }
            ++next_nrm;
        }
        nu = ws->nrm[vt__max_i32(cy - 1, 0) & 3];
        nc = ws->nrm[cy & 3];
        nd = ws->nrm[lim & 3];
        for (c = 0; c < VT_ACF_NCH; ++c) {
            uint8_t *o = out + (size_t)c * plane + (size_t)(cy - cy0) * (size_t)cw;
            for (x = 0; x < cw; ++x) {
                int32_t xl = vt__max_i32(x - 1, 0), xr = x + 1 < cw ? x + 1 : cw - 1;
                uint32_t s = nu[c][xl] + 2 * nu[c][x] + nu[c][xr] +
                             2 * (nc[c][xl] + 2 * nc[c][x] + nc[c][xr]) + nd[c][xl] +
                             2 * nd[c][x] + nd[c][xr];
                uint32_t q = c == 0 ? (s + 2048) >> 12 : (s + 8) >> 4;
                o[x] = (uint8_t)(q > 255 ? 255 : q);
            }
        }
    }
}

vt_status vt_acf_channels(vt_acf_ws *ws, const vt_image_u8 *img, int32_t cy0, int32_t n_cy,
                          uint8_t *out, int32_t out_cap)
{
    vt__acf_src L;
    vt_status s;
    if (ws == NULL || img == NULL || out == NULL) {
        return VT_E_ARG;
    }
    s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    if (img->w < 4 || img->h < 4 || cy0 < 0 || n_cy < 1 || n_cy > img->h / 4 - cy0) {
        return VT_E_SIZE;
    }
    if (out_cap < 0 || (int64_t)out_cap < (int64_t)VT_ACF_NCH * n_cy * (img->w / 4)) {
        return VT_E_CAPACITY;
    }
    L.px = img->px;
    L.stride = img->stride;
    L.w = img->w;
    L.h = img->h;
    L.py0 = 0;
    vt__acf_chan(ws, &L, cy0, n_cy, out);
    return VT_OK;
}

/* Sum of the trees at one window (base: its top-left byte of plane 0); off: the
 * model's node offsets into the planes. *full = 0 if the cascade rejected it. */
static int32_t vt__acf_off1(const vt_acf_model *m, int32_t f, int32_t rows, int32_t cols);

static int64_t vt__acf_eval(const vt_acf_model *m, const uint8_t *base, const int32_t *off,
                            int32_t rows, int32_t cols, int use_reject, int *full)
{
    int32_t n_in = (1 << m->depth) - 1, t, d;
    int64_t acc = m->bias_q16;
    if (off != NULL && m->depth == 3) {
        /* the shipped depth unrolled: the same nodes and sums, ~40% fewer instructions
         * per tree (the scan's hot loop; make bench) */
        const uint8_t *th = m->thr;
        const int32_t *lf = m->leaf, *rej = use_reject ? m->reject : NULL;
        for (t = 0; t < m->n_trees; ++t, off += 7, th += 7, lf += 8) {
            int32_t n = 1 + (base[off[0]] > th[0]);
            n = 2 * n + 1 + (base[off[n]] > th[n]);
            n = 2 * n + 1 + (base[off[n]] > th[n]);
            acc += lf[n - 7];
            if (rej != NULL && acc < rej[t]) {
                *full = 0;
                return acc;
            }
        }
        *full = 1;
        return acc;
    }
    for (t = 0; t < m->n_trees; ++t) {
        const uint8_t *th = m->thr + (size_t)t * (size_t)n_in;
        int32_t n = 0;
        if (off != NULL) {
            const int32_t *o = off + (size_t)t * (size_t)n_in;
            for (d = 0; d < m->depth; ++d) {
                n = 2 * n + 1 + (base[o[n]] > th[n]);
            }
        } else {
            const uint16_t *f = m->feat + (size_t)t * (size_t)n_in;
            for (d = 0; d < m->depth; ++d) {
                n = 2 * n + 1 + (base[vt__acf_off1(m, f[n], rows, cols)] > th[n]);
            }
        }
        acc += m->leaf[(size_t)t * (size_t)(n_in + 1) + (size_t)(n - n_in)];
        if (use_reject && m->reject != NULL && acc < m->reject[t]) {
            *full = 0;
            return acc;
        }
    }
    *full = 1;
    return acc;
}

/* Offset of window byte f (c win_ch win_cw + y win_cw + x) in planes of rows x cols. */
static int32_t vt__acf_off1(const vt_acf_model *m, int32_t f, int32_t rows, int32_t cols)
{
    int32_t cells = m->win_cw * m->win_ch, c = f / cells, rem = f % cells;
    return c * rows * cols + (rem / m->win_cw) * cols + rem % m->win_cw;
}

/* Node offsets for planes of `rows` x `cols` bytes. */
static void vt__acf_offsets(const vt_acf_model *m, int32_t rows, int32_t cols, int32_t *off)
{
    int32_t i, n = m->n_trees * ((1 << m->depth) - 1);
    for (i = 0; i < n; ++i) {
        off[i] = vt__acf_off1(m, m->feat[i], rows, cols);
    }
}

static int32_t vt__sat_i32(int64_t v)
{
    return v > INT32_MAX ? INT32_MAX : (v < INT32_MIN ? INT32_MIN : (int32_t)v);
}

vt_status vt_acf_score(const vt_acf_model *m, const uint8_t *ch, int32_t rows, int32_t cols,
                       int32_t cx, int32_t cy, int32_t *score)
{
    int full;
    vt_status s;
    if (ch == NULL || score == NULL) {
        return VT_E_ARG;
    }
    s = vt_acf_model_check(m);
    if (s != VT_OK) {
        return s;
    }
    if (rows < 1 || cols < 1 || cx < 0 || cy < 0 || cx > cols - m->win_cw ||
        cy > rows - m->win_ch || (int64_t)rows * cols > (int64_t)INT32_MAX / VT_ACF_NCH) {
        return VT_E_SIZE;
    }
    *score = vt__sat_i32(
        vt__acf_eval(m, ch + (size_t)cy * (size_t)cols + (size_t)cx, NULL, rows, cols, 0, &full));
    return VT_OK;
}

/* Input-px coordinate floor(v r / 65536) of level coordinate v. */
static int32_t vt__acf_in(int32_t v, int32_t r)
{
    return (int32_t)(((int64_t)v * r) >> 16);
}

/* 1 if a window bottom row b (input px) of a level whose box is W px wide is in the band. */
static int vt__acf_band(const vt_acf_cfg *cfg, const vt_camera_min *cam, int32_t b, int32_t W)
{
    int64_t d = (int64_t)b - cam->horizon_y, wh = (int64_t)W * cam->height_mm;
    return b >= cam->horizon_y - cfg->above_px && b < cam->hood_y &&
           (int64_t)cfg->veh_w_min_mm * (d - cfg->slack_px) <= wh &&
           wh <= (int64_t)cfg->veh_w_max_mm * (d + cfg->slack_px);
}

/* Model i's band rows at one level: cell rows *a .. *b whose windows' bottoms are in
 * its band (*a = -1: none; also when the level is smaller than its window or the level
 * is outside its cfg's levels). */
static void vt__acf_rows(const vt_acf_model *m, const vt_acf_cfg *cfg, const vt_camera_min *cam,
                         int32_t k, int32_t r, int32_t cw, int32_t nch, int32_t *a, int32_t *b)
{
    int32_t cy, W = vt__acf_in(4 * (m->win_cw - 2 * m->pad), r);
    *a = *b = -1;
    if (k < cfg->first_scale || k >= cfg->first_scale + cfg->n_scales || cw < m->win_cw ||
        nch < m->win_ch) {
        return;
    }
    for (cy = 0; cy <= nch - m->win_ch; ++cy) {
        if (vt__acf_band(cfg, cam, vt__acf_in(4 * (cy + m->win_ch - m->pad), r) - 1, W)) {
            *a = *a < 0 ? cy : *a;
            *b = cy;
        }
    }
}

/* Model m's windows at cell rows cya .. cyb of one level's channels (planes of n_cy
 * rows from cell row ca, cw columns) into the candidates. */
static void vt__acf_scan(vt_acf_ws *ws, const vt_acf_model *m, const vt_acf_cfg *cfg,
                         const vt_camera_min *cam, int32_t r, int32_t cw, int32_t ca, int32_t n_cy,
                         int32_t cya, int32_t cyb, vt_fulldet_result *res)
{
    int32_t cy, cx, pad4 = 4 * m->pad, W = vt__acf_in(4 * (m->win_cw - 2 * m->pad), r);
    int32_t cx0 = cfg->cols == VT_ACF_COLS_RIGHT ? cw - m->win_cw : 0;
    int32_t cx1 = cfg->cols == VT_ACF_COLS_LEFT ? 0 : cw - m->win_cw;
    vt__acf_offsets(m, n_cy, cw, ws->off);
    for (cy = cya; cy <= cyb; ++cy) {
        vt_box b;
        b.bottom = vt__acf_in(4 * (cy + m->win_ch) - pad4, r) - 1;
        if (!vt__acf_band(cfg, cam, b.bottom, W)) {
            continue;
        }
        b.top = vt__acf_in(4 * cy + pad4, r);
        for (cx = cx0; cx <= cx1; ++cx) {
            int full;
            int64_t v = vt__acf_eval(m, ws->ch + (size_t)(cy - ca) * (size_t)cw + (size_t)cx,
                                     ws->off, n_cy, cw, 1, &full);
            int32_t sc = vt__sat_i32(v);
            ++res->n_windows;
            if (!full || sc < cfg->score_min) {
                continue;
            }
            ++res->n_window_hits;
            b.left = vt__acf_in(4 * cx + pad4, r);
            b.right = vt__acf_in(4 * (cx + m->win_cw) - pad4, r) - 1;
            vt__cand_add(ws->cand, &res->n_cand, VT_ACF_MAX_CAND, &res->n_cand_dropped, &b, sc,
                         VT_SRC_WINDOW);
        }
    }
}

vt_status vt_acf_detect_n(vt_acf_ws *ws, int32_t n, const vt_acf_model *const *m,
                          const vt_acf_cfg *const *cfg, const vt_camera_min *cam,
                          const vt_image_u8 *img, vt_fulldet_result *res)
{
    int32_t k, i, kept = 0, k0 = VT_ACF_MAX_SCALES, k1 = 0;
    vt_status s = VT_OK;
    if (res == NULL) {
        return VT_E_ARG;
    }
    res->n_boxes = res->n_windows = res->n_windows_dropped = res->n_window_hits = 0;
    res->n_shadow = res->n_cand = res->n_cand_dropped = 0;
    if (ws == NULL || m == NULL || cfg == NULL || n < 1 || n > VT_ACF_MAX_MODELS) {
        return VT_E_ARG;
    }
    for (i = 0; i < n && s == VT_OK; ++i) {
        s = vt_acf_model_check(m[i]);
        if (s == VT_OK) {
            s = vt_acf_cfg_check(cfg[i]);
        }
        if (s == VT_OK) {
            k0 = cfg[i]->first_scale < k0 ? cfg[i]->first_scale : k0;
            k1 = cfg[i]->first_scale + cfg[i]->n_scales > k1 ? cfg[i]->first_scale + cfg[i]->n_scales
                                                             : k1;
        }
    }
    if (s == VT_OK) {
        s = vt_camera_min_check(cam);
    }
    if (s == VT_OK) {
        s = vt_image_u8_check(img);
    }
    if (s != VT_OK) {
        return s;
    }
    for (k = k0; k < k1; ++k) {
        int32_t r = vt__acf_scale[k];
        int32_t lw = vt__acf_lsize(img->w, r), lh = vt__acf_lsize(img->h, r);
        int32_t cw = lw / 4, nch = lh / 4, ca = -1, cb = -1, n_cy, ly0, ly1;
        int32_t ra[VT_ACF_MAX_MODELS], rb[VT_ACF_MAX_MODELS];
        vt__acf_src L;
        /* one pyramid level and one channel computation for every model's rows */
        for (i = 0; i < n; ++i) {
            vt__acf_rows(m[i], cfg[i], cam, k, r, cw, nch, &ra[i], &rb[i]);
            if (ra[i] >= 0) {
                ca = ca < 0 || ra[i] < ca ? ra[i] : ca;
                cb = rb[i] + m[i]->win_ch - 1 > cb ? rb[i] + m[i]->win_ch - 1 : cb;
            }
        }
        if (ca < 0) {
            continue;
        }
        n_cy = cb - ca + 1;
        ly0 = vt__max_i32(0, 4 * vt__max_i32(0, ca - 2) - 2);
        ly1 = 4 * (cb + 2) + 5;
        ly1 = ly1 < lh - 1 ? ly1 : lh - 1;
        if (r == 65536) {
            L.px = img->px + (size_t)ly0 * (size_t)img->stride;
            L.stride = img->stride;
        } else {
            vt__acf_resample(img, r, ly0, lw, ly1 - ly0 + 1, ws->lvl, lw, ws->hrow, ws->acc);
            L.px = ws->lvl;
            L.stride = lw;
        }
        L.w = lw;
        L.h = lh;
        L.py0 = ly0;
        vt__acf_chan(ws, &L, ca, n_cy, ws->ch);
        for (i = 0; i < n; ++i) {
            if (ra[i] >= 0) {
                vt__acf_scan(ws, m[i], cfg[i], cam, r, cw, ca, n_cy, ra[i], rb[i], res);
            }
        }
    }
    s = vt_nms(ws->cand, res->n_cand, cfg[0]->nms_iou_permille, cfg[0]->nms_contain_permille, &kept);
    if (s != VT_OK) {
        res->n_boxes = 0;
        return s;
    }
    res->n_boxes = kept < VT_MAX_BOXES ? kept : VT_MAX_BOXES;
    for (i = 0; i < res->n_boxes; ++i) {
        res->box[i] = ws->cand[i];
    }
    return VT_OK;
}

vt_status vt_acf_detect(vt_acf_ws *ws, const vt_acf_model *m, const vt_acf_cfg *cfg,
                        const vt_camera_min *cam, const vt_image_u8 *img,
                        vt_fulldet_result *res)
{
    return vt_acf_detect_n(ws, 1, &m, &cfg, cam, img, res);
}
