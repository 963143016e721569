/* shadow.c -- hypothesis generation from the shadow underneath vehicles (thesis
 * sec. 2.4.2.1). See shadow.h for the edge polarity and the cost; the float
 * twin is pyvehtrack/reference/shadow.py. */
#include <string.h>

#include "vehtrack/shadow.h"
#include "internal.h"

vt_status vt_shadow_cfg_default(vt_shadow_cfg *cfg)
{
    static const vt_shadow_cfg def = VT_SHADOW_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

static int vt__in(int32_t v, int32_t lo, int32_t hi)
{
    return v >= lo && v <= hi;
}

vt_status vt_shadow_cfg_check(const vt_shadow_cfg *cfg)
{
    if (cfg == NULL) {
        return VT_E_ARG;
    }
    if (!vt__in(cfg->threshold_mode, VT_SHADOW_FIXED, VT_SHADOW_ADAPTIVE) ||
        !vt__in(cfg->polarity, VT_SHADOW_DARK_ABOVE, VT_SHADOW_DARK_BELOW) ||
        !vt__in(cfg->grad_threshold, 1, 1020) || !vt__in(cfg->adapt_k_q8, 0, 4096) ||
        !vt__in(cfg->adapt_grad_min, 1, 1020) || !vt__in(cfg->stat_step, 1, 64) ||
        !vt__in(cfg->min_run, 1, 4096) || !vt__in(cfg->max_gap, 0, 255) ||
        !vt__in(cfg->merge_rows, 0, 255) || !vt__in(cfg->width_min_q8, 0, 65535) ||
        !vt__in(cfg->width_max_q8, cfg->width_min_q8, 65535) ||
        !vt__in(cfg->reduce_overlap_permille, 0, 1000) || !vt__in(cfg->reduce_height_q8, 0, 65535) ||
        !vt__in(cfg->reduce_verified, 0, 1)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

/* Road span of row y clamped to the image; *xl > *xr means an empty row. */
static void vt__span(const vt_road_area *road, int32_t y, int32_t w, int32_t *xl, int32_t *xr)
{
    *xl = vt__clamp_i32(road->x_left[y], 0, w - 1);
    *xr = vt__clamp_i32(road->x_right[y], 0, w - 1);
}

/* Lower median of the histogram: the smallest v with count(<= v) >= (n+1)/2. */
static int32_t vt__hist_median(const uint32_t *hist, uint32_t n)
{
    uint32_t need = (n + 1u) / 2u, cum = 0;
    int32_t v;
    for (v = 0; v < 255; ++v) {
        cum += hist[v];
        if (cum >= need) {
            return v;
        }
    }
    return 255;
}

/* Lower median of |I - med| from the same histogram: the smallest d with
 * count(|I - med| <= d) >= (n+1)/2. */
static int32_t vt__hist_mad(const uint32_t *hist, uint32_t n, int32_t med)
{
    uint32_t need = (n + 1u) / 2u, cum = hist[med];
    int32_t d;
    if (cum >= need) {
        return 0;
    }
    for (d = 1; d < 256; ++d) {
        if (med - d >= 0) {
            cum += hist[med - d];
        }
        if (med + d <= 255) {
            cum += hist[med + d];
        }
        if (cum >= need) {
            return d;
        }
    }
    return 255;
}

/* Adaptive threshold from the road's own intensities: median and MAD of every
 * stat_step-th road pixel (rows from y_top, columns from each row's x_left), so
 * a road half covered by vehicles and their shadows still yields the road's gray
 * (mean and standard deviation would be dragged by them). A pixel is dark if
 * I < med - k*MAD, i.e. I*256 < med*256 - k_q8*MAD: all integers, so the limit
 * below is exact. Returns the number of samples. */
static uint32_t vt__road_stats(vt_shadow_state *st, const vt_shadow_cfg *cfg,
                               const vt_image_u8 *img, const vt_road_area *road, int32_t yt,
                               int32_t yb)
{
    uint32_t n = 0;
    int32_t y, x, xl, xr;
    int64_t lim_q8;
    memset(st->hist, 0, sizeof st->hist);
    for (y = yt; y <= yb; y += cfg->stat_step) {
        const uint8_t *p = img->px + (size_t)y * (size_t)img->stride;
        vt__span(road, y, img->w, &xl, &xr);
        for (x = xl; x <= xr; x += cfg->stat_step) {
            ++st->hist[p[x]];
            ++n;
        }
    }
    st->n_samples = (int32_t)n;
    if (n == 0) {
        return 0;
    }
    st->median = vt__hist_median(st->hist, n);
    st->mad = vt__hist_mad(st->hist, n, st->median);
    /* dark iff I*256 < lim_q8 iff I < ceil(lim_q8 / 256). */
    lim_q8 = (int64_t)st->median * 256 - (int64_t)cfg->adapt_k_q8 * st->mad;
    st->dark_limit = (int32_t)vt__floor_shr64(lim_q8 + 255, 8);
    return n;
}

/* A closed group: keep it as a candidate if its width fits the vehicle width
 * expected from the lane width at its bottom row (thesis: too wide or too narrow
 * is rejected). */
static void vt__close(vt_shadow_state *st, const vt_shadow_cfg *cfg, const vt_road_area *road,
                      const vt_shadow_group *g)
{
    int64_t width = (int64_t)g->x_end - g->x_start + 1;
    int64_t lw = road->lane_width[g->bottom];
    if (lw <= 0 || width * 256 < lw * cfg->width_min_q8 || width * 256 > lw * cfg->width_max_q8) {
        return;
    }
    if (st->n_cand >= VT_MAX_SHADOW_CAND) {
        ++st->n_dropped;
        return;
    }
    st->cand[st->n_cand++] = *g;
}

/* Close the groups the scan has left behind (more than merge_rows below row y),
 * keeping the open ones in creation order (the first match wins when merging). */
static void vt__close_old(vt_shadow_state *st, const vt_shadow_cfg *cfg,
                          const vt_road_area *road, int32_t y)
{
    int32_t i, k = 0;
    for (i = 0; i < st->n_active; ++i) {
        if (st->active[i].last - y > cfg->merge_rows) {
            vt__close(st, cfg, road, &st->active[i]);
        } else {
            st->active[k++] = st->active[i];
        }
    }
    st->n_active = k;
}

/* A run a..b of edge pixels in row y: drop it if short (thesis: 10-15 px), else
 * merge it into the first open group it overlaps in x, else open a new group. */
static void vt__run(vt_shadow_state *st, const vt_shadow_cfg *cfg, int32_t y, int32_t a,
                    int32_t b, int32_t *next_id)
{
    int32_t i;
    if (b - a + 1 < cfg->min_run) {
        return;
    }
    ++st->n_runs;
    for (i = 0; i < st->n_active; ++i) {
        vt_shadow_group *g = &st->active[i];
        if (g->x_start <= b && a <= g->x_end) {
            g->last = (int16_t)y;
            if (a < g->x_start) {
                g->x_start = (int16_t)a;
            }
            if (b > g->x_end) {
                g->x_end = (int16_t)b;
            }
            return;
        }
    }
    if (st->n_active >= VT_MAX_SHADOW_ACTIVE) {
        ++st->n_dropped;
        return;
    }
    {
        vt_shadow_group *g = &st->active[st->n_active++];
        g->bottom = (int16_t)y;
        g->last = (int16_t)y;
        g->x_start = (int16_t)a;
        g->x_end = (int16_t)b;
        g->id = (*next_id)++;
    }
}

/* Scan row y of the road: Sobel d/dy from the row above and below through the
 * row of vertical differences, edge test, runs. */
static void vt__scan_row(vt_shadow_state *st, const vt_shadow_cfg *cfg, const vt_image_u8 *img,
                         int32_t y, int32_t xl, int32_t xr, int32_t *next_id)
{
    const int32_t w = img->w;
    const uint8_t *pm, *p0, *pp, *pd;
    const int32_t sgn = cfg->polarity == VT_SHADOW_DARK_ABOVE ? 1 : -1;
    const int adaptive = cfg->threshold_mode == VT_SHADOW_ADAPTIVE;
    const int32_t thr = adaptive ? cfg->adapt_grad_min : cfg->grad_threshold;
    const int32_t dark = st->dark_limit;
    int32_t a = xl > 0 ? xl - 1 : 0, b = xr < w - 1 ? xr + 1 : w - 1;
    int32_t x, rs = -1, re = -1;
    int16_t *dy = st->dy + 1; /* dy[-1] and dy[w] hold the replicated border */
    vt__sobel_rows(img, y, &pm, &p0, &pp);
    (void)p0; /* d/dy does not weigh the centre row */
    /* The dark side of the edge: above it for DARK_ABOVE, below it otherwise. */
    pd = cfg->polarity == VT_SHADOW_DARK_ABOVE ? pm : pp;
    for (x = a; x <= b; ++x) {
        dy[x] = (int16_t)(pp[x] - pm[x]);
    }
    dy[a - 1] = dy[a]; /* only read when a == 0: the border replicates column 0 */
    dy[b + 1] = dy[b]; /* likewise column w-1 */
    for (x = xl; x <= xr; ++x) {
        int32_t s = sgn * (dy[x - 1] + 2 * dy[x] + dy[x + 1]);
        if (s < thr || (adaptive && (int32_t)pd[x] >= dark)) {
            continue;
        }
        if (rs >= 0 && x - re - 1 <= cfg->max_gap) {
            re = x;
        } else {
            if (rs >= 0) {
                vt__run(st, cfg, y, rs, re, next_id);
            }
            rs = x;
            re = x;
        }
    }
    if (rs >= 0) {
        vt__run(st, cfg, y, rs, re, next_id);
    }
}

/* Candidates bottom-most first, then left-most, then oldest (insertion sort:
 * at most VT_MAX_SHADOW_CAND elements, stable, no recursion). */
static int vt__before(const vt_shadow_group *p, const vt_shadow_group *q)
{
    if (p->bottom != q->bottom) {
        return p->bottom > q->bottom;
    }
    if (p->x_start != q->x_start) {
        return p->x_start < q->x_start;
    }
    return p->id < q->id;
}

static void vt__sort_cand(vt_shadow_state *st)
{
    int32_t i, j;
    for (i = 1; i < st->n_cand; ++i) {
        vt_shadow_group g = st->cand[i];
        for (j = i; j > 0 && vt__before(&g, &st->cand[j - 1]); --j) {
            st->cand[j] = st->cand[j - 1];
        }
        st->cand[j] = g;
    }
}

/* The one-edge-per-vehicle rule (thesis sec. 2.4.2.1): the kept edge k (row
 * k_row, columns k_xs..k_xe) suppresses edge c above it when they overlap in x by
 * >= reduce_overlap/1000 of the narrower one and k lies no more than
 * reduce_height x (k's width) rows below c. Integer products in int64: exact. */
int vt__shadow_suppresses(const vt_shadow_cfg *cfg, int32_t k_row, int32_t k_xs, int32_t k_xe,
                          int32_t c_row, int32_t c_xs, int32_t c_xe)
{
    int64_t wc = (int64_t)c_xe - c_xs + 1;
    int64_t wk = (int64_t)k_xe - k_xs + 1;
    int64_t ov = (int64_t)(c_xe < k_xe ? c_xe : k_xe) - (c_xs > k_xs ? c_xs : k_xs) + 1;
    return ov > 0 && ov * 1000 >= (wc < wk ? wc : wk) * cfg->reduce_overlap_permille &&
           ((int64_t)k_row - c_row) * 256 <= wk * cfg->reduce_height_q8;
}

/* Reduce the edges on one vehicle to its bottom edge: walking bottom-up, an edge
 * is dropped when a kept edge below suppresses it (vt__shadow_suppresses). The
 * kept edges are compacted to the front of cand; returns their number. */
static int32_t vt__reduce(vt_shadow_state *st, const vt_shadow_cfg *cfg)
{
    int32_t i, j, n_kept = 0;
    for (i = 0; i < st->n_cand; ++i) {
        const vt_shadow_group c = st->cand[i];
        int drop = 0;
        for (j = 0; j < n_kept && !drop; ++j) {
            const vt_shadow_group *k = &st->cand[j];
            drop = vt__shadow_suppresses(cfg, k->bottom, k->x_start, k->x_end, c.bottom, c.x_start,
                                         c.x_end);
        }
        if (!drop) {
            st->cand[n_kept++] = c;
        }
    }
    return n_kept;
}

vt_status vt_shadow_find(vt_shadow_state *st, const vt_shadow_cfg *cfg, const vt_image_u8 *img,
                         const vt_road_area *road, vt_hypothesis *out, int32_t cap,
                         int32_t *n_out)
{
    int32_t y, yt, yb, xl, xr, n_kept, i, next_id = 0;
    vt_status s;
    if (n_out == NULL) {
        return VT_E_ARG;
    }
    *n_out = 0;
    if (st == NULL || road == NULL || cap < 0 || (cap > 0 && out == NULL)) {
        return VT_E_ARG;
    }
    s = vt_shadow_cfg_check(cfg);
    if (s != VT_OK) {
        return s;
    }
    s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    if (road->height != img->h) {
        return VT_E_SIZE;
    }
    st->n_active = 0;
    st->n_cand = 0;
    st->median = 0;
    st->mad = 0;
    st->dark_limit = 0;
    st->n_samples = 0;
    st->n_runs = 0;
    st->n_dropped = 0;
    yt = road->y_top > 0 ? road->y_top : 0;
    yb = road->y_bottom < img->h - 1 ? road->y_bottom : img->h - 1;
    if (!road->valid || yt > yb) {
        return VT_OK;
    }
    if (cfg->threshold_mode == VT_SHADOW_ADAPTIVE &&
        vt__road_stats(st, cfg, img, road, yt, yb) == 0) {
        return VT_OK;
    }
    /* Bottom-up, as the thesis scans: the first edges met are the nearest
     * vehicles' bottoms, which the reduce step keeps. */
    for (y = yb; y >= yt; --y) {
        vt__close_old(st, cfg, road, y);
        vt__span(road, y, img->w, &xl, &xr);
        if (xl <= xr) {
            vt__scan_row(st, cfg, img, y, xl, xr, &next_id);
        }
    }
    for (i = 0; i < st->n_active; ++i) {
        vt__close(st, cfg, road, &st->active[i]);
    }
    st->n_active = 0;
    vt__sort_cand(st);
    /* With reduce_verified the caller that verifies (vt_detect) reduces. */
    n_kept = cfg->reduce_verified ? st->n_cand : vt__reduce(st, cfg);
    for (i = 0; i < n_kept && i < cap; ++i) {
        out[i].row = st->cand[i].bottom;
        out[i].x_start = st->cand[i].x_start;
        out[i].x_end = st->cand[i].x_end;
    }
    *n_out = i;
    st->n_dropped += n_kept - i;
    return VT_OK;
}
