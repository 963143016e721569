/* vehicle_model.c -- seven-parameter geometric vehicle model fitted by a genetic
 * algorithm, coarse to fine on a Gaussian pyramid (IVVI paper, sec. 5 "Geometric
 * Models", sec. 6 "Perceiving the Environment", Table 1). Model, fitness, search
 * and cost are specified in vehtrack/vehicle_model.h; the oracle twin is
 * pyvehtrack/reference/vehicle_model.py, which must draw the same random numbers
 * in the same order, so the order of every draw below is part of the contract. */
#include <string.h>

#include "vehtrack/vehicle_model.h"
#include "internal.h"

#define VT__S VT_MODEL_SAMPLES
#define VT__GENES 7
#define VT__SEED0 0x9E3779B9u

/* ------------------------------------------------------------------ config */

vt_status vt_model_cfg_default(vt_model_cfg *cfg)
{
    static const vt_model_cfg def = VT_MODEL_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

static int vt__in(int32_t v, int32_t lo, int32_t hi)
{
    return v >= lo && v <= hi;
}

vt_status vt_model_cfg_check(const vt_model_cfg *c)
{
    int32_t m, l;
    if (c == NULL) {
        return VT_E_ARG;
    }
    if (!vt__in(c->levels, 1, VT_MODEL_LEVELS)) {
        return VT_E_ARG;
    }
    for (m = 0; m < 2; m++) {
        for (l = 0; l < VT_MODEL_LEVELS; l++) {
            if (!vt__in(c->pop[m][l], 2, 4096) || !vt__in(c->gens[m][l], 0, 1000)) {
                return VT_E_ARG;
            }
        }
    }
    if (!vt__in(c->mut_permille, 0, 1000) || !vt__in(c->w_sym, 0, 64) || !vt__in(c->w_grad, 0, 64) ||
        !vt__in(c->w_dist, 0, 64) || !vt__in(c->w_shadow, 0, 64) ||
        !vt__in(c->edge_thresh, 0, 2040) || !vt__in(c->dist_cap, 1, 64) ||
        !vt__in(c->horizon_row, -4 * VT_MAX_HEIGHT, 4 * VT_MAX_HEIGHT) ||
        !vt__in(c->width_per_row, 1, 16 * VT_Q16_ONE) || !vt__in(c->width_tol_permille, 0, 900) ||
        !vt__in(c->aspect_min_permille, 100, 4000) ||
        !vt__in(c->aspect_max_permille, c->aspect_min_permille, 4000) ||
        !vt__in(c->wind_min, 0, 100) || !vt__in(c->wind_max, c->wind_min, 100) ||
        !vt__in(c->bump_min, 0, 100) || !vt__in(c->bump_max, c->bump_min, 100) ||
        !vt__in(c->roof_max, 0, 45)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

vt_status vt_model_cfg_road(vt_model_cfg *cfg, int32_t y0, int32_t w0, int32_t y1, int32_t w1)
{
    int64_t slope = 0, hz = 0;
    if (cfg == NULL || y0 == y1 || !vt__in(w0, 1, VT_MAX_WIDTH) || !vt__in(w1, 1, VT_MAX_WIDTH) ||
        !vt__in(y0, -4 * VT_MAX_HEIGHT, 4 * VT_MAX_HEIGHT) ||
        !vt__in(y1, -4 * VT_MAX_HEIGHT, 4 * VT_MAX_HEIGHT)) {
        return VT_E_ARG;
    }
    /* Q16 slope, rounded half away from zero; the horizon is where the width
     * line reaches zero: y0 - w0 / slope, rounded the same way. */
    (void)vt_div_round_s64((int64_t)(w1 - w0) * VT_Q16_ONE, (int64_t)(y1 - y0), &slope);
    if (slope < 1 || slope > 16 * VT_Q16_ONE) {
        return VT_E_ARG;
    }
    (void)vt_div_round_s64((int64_t)w0 * VT_Q16_ONE, slope, &hz);
    if (!vt__in((int32_t)(y0 - hz), -4 * VT_MAX_HEIGHT, 4 * VT_MAX_HEIGHT)) {
        return VT_E_ARG;
    }
    cfg->width_per_row = (vt_q16)slope;
    cfg->horizon_row = (int32_t)(y0 - hz);
    return VT_OK;
}

/* (y - horizon) * slope in px, half up; 0 above the horizon; <= VT_MAX_WIDTH. */
static int32_t vt__expected_width(const vt_model_cfg *cfg, int32_t y)
{
    int64_t d = (int64_t)y - cfg->horizon_row;
    int64_t w;
    if (d <= 0) {
        return 0;
    }
    w = (d * cfg->width_per_row + VT_Q16_ONE / 2) >> VT_Q16_SHIFT;
    return (int32_t)(w > VT_MAX_WIDTH ? VT_MAX_WIDTH : w);
}

vt_status vt_model_expected_width(const vt_model_cfg *cfg, int32_t y, int32_t *w)
{
    if (w != NULL) {
        *w = 0;
    }
    if (cfg == NULL || w == NULL || vt_model_cfg_check(cfg) != VT_OK) {
        return VT_E_ARG;
    }
    *w = vt__expected_width(cfg, y);
    return VT_OK;
}

/* ------------------------------------------------------------------ random */

/* xorshift32 (Marsaglia 2003, shifts 13, 17, 5), then r * n >> 32: a draw in
 * [0, n) for 1 <= n <= 2^31 with no division. */
static int32_t vt__rand(uint32_t *s, int32_t n)
{
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *s = x;
    return (int32_t)(((uint64_t)x * (uint64_t)n) >> 32);
}

/* Uniform in [-m, m]. */
static int32_t vt__rand_pm(uint32_t *s, int32_t m)
{
    return vt__rand(s, 2 * m + 1) - m;
}

/* ------------------------------------------------------------------ search setup */

typedef struct {
    int32_t ox, oy, ex, ey, rw, rh; /* ROI clipped, input px, inclusive end */
    int32_t ylo, yhi;               /* rows the bottom may take               */
} vt__geom;

static vt_status vt__geometry_of(const vt_image_u8 *frame, const vt_model_search *sr, vt__geom *g)
{
    const vt_box *r = &sr->roi;
    if (r->left > r->right || r->top > r->bottom) {
        return VT_E_SIZE;
    }
    g->ox = vt__clamp_i32(r->left, 0, frame->w - 1);
    g->oy = vt__clamp_i32(r->top, 0, frame->h - 1);
    g->ex = vt__clamp_i32(r->right, 0, frame->w - 1);
    g->ey = vt__clamp_i32(r->bottom, 0, frame->h - 1);
    g->rw = g->ex - g->ox + 1;
    g->rh = g->ey - g->oy + 1;
    if (r->right < 0 || r->bottom < 0 || r->left >= frame->w || r->top >= frame->h || g->rw < 8 ||
        g->rh < 8) {
        return VT_E_SIZE;
    }
    if ((int64_t)g->rw * g->rh > VT_MODEL_MAX_ROI_PIXELS) {
        return VT_E_CAPACITY;
    }
    /* A model needs at least 8 rows above its bottom inside the ROI. */
    g->ylo = vt__clamp_i32(sr->y_min, g->oy + 7, g->ey);
    g->yhi = vt__clamp_i32(sr->y_max, g->oy + 7, g->ey);
    return VT_OK;
}

/* The frame checked, then the search's geometry in it. */
static vt_status vt__geometry(const vt_image_u8 *frame, const vt_model_search *sr, vt__geom *g)
{
    vt_status s = vt_image_u8_check(frame);
    return s != VT_OK ? s : vt__geometry_of(frame, sr, g);
}

static vt_status vt__check_search(const vt_model_search *sr)
{
    const int32_t lim = 4 * (VT_MAX_WIDTH > VT_MAX_HEIGHT ? VT_MAX_WIDTH : VT_MAX_HEIGHT);
    const vt_model_params *p = &sr->pred, *q = &sr->sigma;
    if (sr->y_min > sr->y_max || !vt__in(sr->tracking, 0, 1) || !vt__in(sr->y_min, -lim, lim) ||
        !vt__in(sr->y_max, -lim, lim) || !vt__in(sr->roi.left, -lim, lim) ||
        !vt__in(sr->roi.right, -lim, lim) || !vt__in(sr->roi.top, -lim, lim) ||
        !vt__in(sr->roi.bottom, -lim, lim)) {
        return VT_E_ARG;
    }
    if (sr->tracking &&
        (!vt__in(p->x, -lim, lim) || !vt__in(p->y, -lim, lim) || !vt__in(p->w, -lim, lim) ||
         !vt__in(p->h, -lim, lim) || !vt__in(p->wind, 0, 100) || !vt__in(p->bump, 0, 100) ||
         !vt__in(p->roof, 0, 100) || !vt__in(q->x, 0, 1024) || !vt__in(q->y, 0, 1024) ||
         !vt__in(q->w, 0, 1024) || !vt__in(q->h, 0, 1024) || !vt__in(q->wind, 0, 100) ||
         !vt__in(q->bump, 0, 100) || !vt__in(q->roof, 0, 100))) {
        return VT_E_ARG;
    }
    return VT_OK;
}

/* The constraints, in this order: bottom row, width from the road at that row
 * (and the ROI width), height from the aspect range (and the ROI rows above the
 * bottom), centre so the box lies in the ROI, the three shape percentages. */
static void vt__repair(const vt_model_cfg *c, const vt__geom *g, vt_model_params *p)
{
    int32_t we, wmin, wmax, hmin, hmax, half;
    p->y = vt__clamp_i32(p->y, g->ylo, g->yhi);
    we = vt__expected_width(c, p->y);
    wmin = vt__max_i32(8, we * (1000 - c->width_tol_permille) / 1000);
    wmax = vt__max_i32(wmin, we * (1000 + c->width_tol_permille) / 1000);
    p->w = vt__clamp_i32(p->w, vt__clamp_i32(wmin, 1, g->rw), vt__clamp_i32(wmax, 1, g->rw));
    hmin = vt__max_i32(4, p->w * c->aspect_min_permille / 1000);
    hmax = vt__max_i32(hmin, p->w * c->aspect_max_permille / 1000);
    p->h = vt__clamp_i32(p->h, hmin, hmax);
    p->h = vt__clamp_i32(p->h, 1, p->y - g->oy + 1);
    half = p->w / 2;
    p->x = vt__clamp_i32(p->x, g->ox + half, g->ex - p->w + 1 + half);
    p->wind = vt__clamp_i32(p->wind, c->wind_min, c->wind_max);
    p->bump = vt__clamp_i32(p->bump, c->bump_min, c->bump_max);
    p->roof = vt__clamp_i32(p->roof, 0, c->roof_max);
}

/* A uniform individual inside the constraints; 7 draws, in gene order. */
static void vt__random_individual(const vt_model_cfg *c, const vt__geom *g, uint32_t *rs,
                                  vt_model_params *p)
{
    int32_t we, wmin, wmax, hmin, hmax, half;
    p->y = g->ylo + vt__rand(rs, g->yhi - g->ylo + 1);
    we = vt__expected_width(c, p->y);
    wmin = vt__clamp_i32(vt__max_i32(8, we * (1000 - c->width_tol_permille) / 1000), 1, g->rw);
    wmax = vt__clamp_i32(vt__max_i32(wmin, we * (1000 + c->width_tol_permille) / 1000), wmin, g->rw);
    p->w = wmin + vt__rand(rs, wmax - wmin + 1);
    hmin = vt__max_i32(4, p->w * c->aspect_min_permille / 1000);
    hmax = vt__max_i32(hmin, p->w * c->aspect_max_permille / 1000);
    p->h = hmin + vt__rand(rs, hmax - hmin + 1);
    half = p->w / 2;
    p->x = g->ox + half + vt__rand(rs, vt__max_i32(1, g->rw - p->w + 1));
    p->wind = c->wind_min + vt__rand(rs, c->wind_max - c->wind_min + 1);
    p->bump = c->bump_min + vt__rand(rs, c->bump_max - c->bump_min + 1);
    p->roof = vt__rand(rs, c->roof_max + 1);
    vt__repair(c, g, p);
}

static int32_t *vt__gene(vt_model_params *p, int32_t k)
{
    int32_t *g[VT__GENES];
    g[0] = &p->x;
    g[1] = &p->y;
    g[2] = &p->w;
    g[3] = &p->h;
    g[4] = &p->wind;
    g[5] = &p->bump;
    g[6] = &p->roof;
    return g[k];
}

/* ------------------------------------------------------------------ features */

/* floor((v - o) / 2^l), clamped to 0..n-1: a level-0 coordinate at level l. */
static int32_t vt__to_level(int32_t v, int32_t o, int32_t l, int32_t n)
{
    int32_t d = v - o;
    d = d >= 0 ? d >> l : -((-d + (1 << l) - 1) >> l);
    return vt__clamp_i32(d, 0, n - 1);
}

/* a + (b - a) k / (S - 1), C division (toward zero). */
static int32_t vt__lerp(int32_t a, int32_t b, int32_t k)
{
    return a + (b - a) * k / (VT__S - 1);
}

/* row[x] = min(row[x], next[x] + 1) for x < w: the sweeps' step from the row above
 * (below), which does not depend on the row's own left (right) neighbour, so it runs
 * first and in SSE2 where there is one (a saturating + 1: 255 + 1 never lowers a
 * distance <= 255, as before). */
static void vt__min_next(uint8_t *row, const uint8_t *next, int32_t w)
{
    int32_t x = 0;
#if VT__SSE2
    const __m128i one = _mm_set1_epi8(1);
    for (; x + 16 <= w; x += 16) {
        __m128i n = _mm_adds_epu8(_mm_loadu_si128((const __m128i *)(const void *)(next + x)), one);
        __m128i *r = (__m128i *)(void *)(row + x);
        _mm_storeu_si128(r, _mm_min_epu8(_mm_loadu_si128(r), n));
    }
#endif
    for (; x < w; x++) {
        if (next[x] + 1 < row[x]) {
            row[x] = (uint8_t)(next[x] + 1);
        }
    }
}

vt_status vt_model_prepare(vt_model_ws *ws, const vt_model_cfg *cfg,
                           const vt_image_u8 *frame, const vt_model_search *search, int32_t level)
{
    vt__geom g;
    vt_status s;
    vt_image_u8 src;
    vt_image_u8_mut dst;
    vt_image_s16 gx, gy;
    int32_t l, x, y;
    if (ws != NULL) {
        ws->level = -1; /* nothing ready until this call succeeds */
        ws->img = NULL;
    }
    if (frame == NULL || cfg == NULL || search == NULL || ws == NULL ||
        vt_model_cfg_check(cfg) != VT_OK || vt__check_search(search) != VT_OK ||
        !vt__in(level, 0, cfg->levels - 1)) {
        return VT_E_ARG;
    }
    s = vt__geometry(frame, search, &g);
    if (s != VT_OK) {
        return s;
    }
    src.px = frame->px + (size_t)g.oy * (size_t)frame->stride + (size_t)g.ox;
    src.w = g.rw;
    src.h = g.rh;
    src.stride = frame->stride;
    for (l = 1; l <= level; l++) {
        uint8_t *buf = l == 1 ? ws->lvl1 : ws->lvl2;
        size_t cap = l == 1 ? sizeof ws->lvl1 : sizeof ws->lvl2;
        dst.px = buf;
        dst.w = (src.w + 1) / 2;
        dst.h = (src.h + 1) / 2;
        dst.stride = dst.w;
        if ((size_t)dst.w * (size_t)dst.h > cap) {
            return VT_E_CAPACITY;
        }
        s = vt_pyr_down(&src, &dst);
        if (s != VT_OK) {
            return s;
        }
        src.px = buf;
        src.w = dst.w;
        src.h = dst.h;
        src.stride = dst.stride;
    }
    gx.px = ws->gx;
    gy.px = ws->gy;
    gx.w = gy.w = src.w;
    gx.h = gy.h = src.h;
    gx.stride = gy.stride = src.w;
    s = vt_sobel_x(&src, &gx);
    if (s == VT_OK) {
        s = vt_sobel_y(&src, &gy);
    }
    if (s != VT_OK) {
        return s;
    }
    /* Exact city-block distance to the nearest edge pixel, saturated at 255:
     * two passes with unit steps (shortest L1 paths are monotone, so they never
     * leave the rectangle and two sweeps find them). */
    /* The left / right neighbour is carried in a register, 255 before the first
     * column (255 + 1 never improves a distance <= 255), and the first / last row
     * has no row above / below: the same sweeps without per-pixel bounds tests. */
    for (y = 0; y < src.h; y++) {
        uint8_t *row = ws->dist + (size_t)y * (size_t)src.w;
        const uint8_t *up = y > 0 ? row - src.w : NULL;
        const int16_t *rx = ws->gx + (size_t)y * (size_t)src.w;
        const int16_t *ry = ws->gy + (size_t)y * (size_t)src.w;
        int32_t left = 255;
        /* The edge test first (0 on an edge, else 255), vectorisable; then the sweep. */
        x = 0;
#if VT__SSE2
        {
            /* |gx| + |gy| <= 2040 and edge_thresh in 0..2040 (the cfg check): int16 lanes */
            const __m128i thr = _mm_set1_epi16((int16_t)cfg->edge_thresh);
            const __m128i zero = _mm_setzero_si128();
            for (; x + 8 <= src.w; x += 8) {
                __m128i a = _mm_loadu_si128((const __m128i *)(const void *)(rx + x));
                __m128i b = _mm_loadu_si128((const __m128i *)(const void *)(ry + x));
                __m128i e = _mm_add_epi16(_mm_max_epi16(a, _mm_sub_epi16(zero, a)),
                                          _mm_max_epi16(b, _mm_sub_epi16(zero, b)));
                /* not an edge: 0xFFFF lanes, packed to 255 */
                __m128i far = _mm_cmpgt_epi16(_mm_add_epi16(thr, _mm_set1_epi16(1)), e);
                _mm_storel_epi64((__m128i *)(void *)(row + x), _mm_packus_epi16(_mm_srli_epi16(far, 8), zero));
            }
        }
#endif
        for (; x < src.w; x++) {
            row[x] = (uint8_t)(vt__abs_i32(rx[x]) + vt__abs_i32(ry[x]) > cfg->edge_thresh ? 0 : 255);
        }
        if (up != NULL) {
            vt__min_next(row, up, src.w);
        }
        for (x = 0; x < src.w; x++) {
            int32_t d = row[x];
            if (left + 1 < d) {
                d = left + 1;
            }
            row[x] = (uint8_t)d;
            left = d;
        }
    }
    for (y = src.h - 1; y >= 0; y--) {
        uint8_t *row = ws->dist + (size_t)y * (size_t)src.w;
        int32_t right = 255;
        if (y + 1 < src.h) {
            vt__min_next(row, row + src.w, src.w);
        }
        for (x = src.w - 1; x >= 0; x--) {
            int32_t d = row[x];
            if (right + 1 < d) {
                d = right + 1;
            }
            row[x] = (uint8_t)d;
            right = d;
        }
    }
    ws->level = level;
    ws->ox = g.ox;
    ws->oy = g.oy;
    ws->rw = g.rw;
    ws->rh = g.rh;
    ws->lw = src.w;
    ws->lh = src.h;
    ws->istride = src.stride;
    ws->img = src.px;
    return VT_OK;
}

/* The fitness of p on the prepared level (see the header for the terms). */
static int32_t vt__fitness(const vt_model_cfg *c, const vt_model_ws *ws, const vt_model_params *p)
{
    const int32_t l = ws->level, lw = ws->lw, lh = ws->lh, st = ws->istride;
    const uint8_t *img = ws->img;
    /* Level-0 outline: columns L, R and the roof's L + I, R - I; rows T (roof),
     * S (windshield's lower edge), P (bumper), B (bottom). */
    const int32_t L = p->x - p->w / 2, R = L + p->w - 1, B = p->y, T = p->y - p->h + 1;
    const int32_t I = p->w * p->roof / 100, S = T + p->h * p->wind / 100;
    const int32_t P = B - p->h * p->bump / 100;
    /* Segments {xa, ya, xb, yb}: 4 vertical (body sides, slanted cabin sides,
     * scored on |gx|), then 4 horizontal (roof, windshield, bumper, bottom, |gy|). */
    int32_t seg[8][4], ca[VT__S], cb[VT__S];
    int32_t e, k, j, sum_g = 0, sum_d = 0, sum_s = 0, sum_in = 0, sh_b = 0, sh_a = 0;
    int32_t sym, grad, dist, shadow, xc, half, b;
    seg[0][0] = L;     seg[0][1] = S; seg[0][2] = L;     seg[0][3] = B;
    seg[1][0] = R;     seg[1][1] = S; seg[1][2] = R;     seg[1][3] = B;
    seg[2][0] = L + I; seg[2][1] = T; seg[2][2] = L;     seg[2][3] = S;
    seg[3][0] = R - I; seg[3][1] = T; seg[3][2] = R;     seg[3][3] = S;
    seg[4][0] = L + I; seg[4][1] = T; seg[4][2] = R - I; seg[4][3] = T;
    seg[5][0] = L;     seg[5][1] = S; seg[5][2] = R;     seg[5][3] = S;
    seg[6][0] = L;     seg[6][1] = P; seg[6][2] = R;     seg[6][3] = P;
    seg[7][0] = L;     seg[7][1] = B; seg[7][2] = R;     seg[7][3] = B;
    for (e = 0; e < 8; e++) {
        const int16_t *gr = e < 4 ? ws->gx : ws->gy;
        /* Six of the eight segments are axis-parallel: their fixed coordinate is
         * mapped once (vt__lerp(a, a, k) = a). */
        const int32_t fx = seg[e][0] == seg[e][2] ? vt__to_level(seg[e][0], ws->ox, l, lw) : -1;
        const int32_t fy = seg[e][1] == seg[e][3] ? vt__to_level(seg[e][1], ws->oy, l, lh) : -1;
        for (k = 0; k < VT__S; k++) {
            int32_t px = fx >= 0 ? fx : vt__to_level(vt__lerp(seg[e][0], seg[e][2], k), ws->ox, l, lw);
            int32_t py = fy >= 0 ? fy : vt__to_level(vt__lerp(seg[e][1], seg[e][3], k), ws->oy, l, lh);
            int32_t i = py * lw + px;
            int32_t d = ws->dist[i];
            sum_g += vt__abs_i32(gr[i]) >> 2;
            sum_d += c->dist_cap - (d < c->dist_cap ? d : c->dist_cap);
        }
    }
    grad = sum_g / (8 * VT__S);
    dist = sum_d * 255 / (c->dist_cap * 8 * VT__S);
    /* Vertical symmetry about the centre column. The column pairs are the same on
     * every row: computed once (the division per sample cost 5% of a fit). */
    xc = vt__to_level(p->x, ws->ox, l, lw);
    half = vt__max_i32(1, (p->w / 2) >> l);
    for (j = 0; j < VT__S; j++) {
        int32_t d = 1 + (half - 1) * j / (VT__S - 1);
        ca[j] = vt__clamp_i32(xc - d, 0, lw - 1);
        cb[j] = vt__clamp_i32(xc + d, 0, lw - 1);
    }
    for (k = 0; k < VT__S; k++) {
        int32_t r = vt__to_level(vt__lerp(T, B, k), ws->oy, l, lh);
        const uint8_t *row = img + (size_t)r * (size_t)st;
        for (j = 0; j < VT__S; j++) {
            int32_t a = row[ca[j]];
            int32_t bb = row[cb[j]];
            sum_s += vt__abs_i32(a - bb);
            sum_in += a + bb;
        }
    }
    sym = 255 - sum_s / (VT__S * VT__S);
    /* Shadow: lit road below the bottom row, dark shadow ending at it. */
    b = vt__to_level(B, ws->oy, l, lh);
    for (j = 0; j < VT__S; j++) {
        int32_t cx = vt__to_level(L + (p->w - 1) * (j + 1) / (VT__S + 1), ws->ox, l, lw);
        sh_b += img[(size_t)vt__clamp_i32(b + 1, 0, lh - 1) * (size_t)st + (size_t)cx];
        sh_b += img[(size_t)vt__clamp_i32(b + 2, 0, lh - 1) * (size_t)st + (size_t)cx];
        sh_a += img[(size_t)b * (size_t)st + (size_t)cx];
        sh_a += img[(size_t)vt__clamp_i32(b - 1, 0, lh - 1) * (size_t)st + (size_t)cx];
    }
    /* The shadow is the darkest part: darker than the road below it and than the
     * vehicle above it (so a rear window over a bright body does not pass). */
    sh_b /= 2 * VT__S;
    sh_a /= 2 * VT__S;
    sum_in /= 2 * VT__S * VT__S;
    shadow = vt__clamp_i32(sh_b - sh_a < sum_in - sh_a ? sh_b - sh_a : sum_in - sh_a, 0, 255);
    return c->w_sym * sym + c->w_grad * grad + c->w_dist * dist + c->w_shadow * shadow;
}

vt_status vt_model_fitness(vt_model_ws *ws, const vt_model_cfg *cfg,
                           const vt_image_u8 *frame, const vt_model_search *search, int32_t level,
                           const vt_model_params *p, int32_t *fitness)
{
    const int32_t lim = 4 * (VT_MAX_WIDTH > VT_MAX_HEIGHT ? VT_MAX_WIDTH : VT_MAX_HEIGHT);
    if (fitness != NULL) {
        *fitness = 0;
    }
    if (frame == NULL || cfg == NULL || search == NULL || ws == NULL || p == NULL ||
        fitness == NULL || vt_model_cfg_check(cfg) != VT_OK || !vt__in(level, 0, cfg->levels - 1) ||
        ws->level != level || ws->img == NULL) {
        return VT_E_ARG;
    }
    if (!vt__in(p->x, -lim, lim) || !vt__in(p->y, -lim, lim) || !vt__in(p->w, 1, lim) ||
        !vt__in(p->h, 1, lim) || !vt__in(p->wind, 0, 100) || !vt__in(p->bump, 0, 100) ||
        !vt__in(p->roof, 0, 100)) {
        return VT_E_ARG;
    }
    *fitness = vt__fitness(cfg, ws, p);
    return VT_OK;
}

vt_status vt_model_search_from_flow(const vt_model_cfg *cfg, const vt_flow_hyp *h,
                                    vt_model_search *search)
{
    const int32_t lim = 4 * (VT_MAX_WIDTH > VT_MAX_HEIGHT ? VT_MAX_WIDTH : VT_MAX_HEIGHT);
    int32_t W;
    if (search != NULL) {
        memset(search, 0, sizeof *search);
    }
    if (h == NULL || search == NULL || vt_model_cfg_check(cfg) != VT_OK ||
        h->box.left > h->box.right || h->box.top > h->box.bottom ||
        !vt__in(h->box.left, -lim, lim) || !vt__in(h->box.right, -lim, lim) ||
        !vt__in(h->box.top, -lim, lim) || !vt__in(h->box.bottom, -lim, lim)) {
        return VT_E_ARG;
    }
    W = vt__max_i32(vt__expected_width(cfg, h->box.bottom), h->box.right - h->box.left + 1);
    search->roi.left = h->box.left - W;
    search->roi.right = h->box.right + W;
    search->roi.top = h->box.bottom - W * cfg->aspect_max_permille / 1000 - W / 4;
    search->roi.bottom = h->box.bottom + W / 4;
    search->y_min = vt__clamp_i32(h->cy, h->box.top, h->box.bottom);
    search->y_max = h->box.bottom + W / 8;
    return VT_OK;
}

/* ------------------------------------------------------------------ the GA */

static int32_t vt__best(const int32_t *fit, int32_t n)
{
    int32_t i, b = 0;
    for (i = 1; i < n; i++) {
        if (fit[i] > fit[b]) {
            b = i;
        }
    }
    return b;
}

static int32_t vt__tournament(const int32_t *fit, int32_t n, uint32_t *rs)
{
    int32_t i = vt__rand(rs, n);
    int32_t j = vt__rand(rs, n);
    return fit[j] > fit[i] ? j : i;
}

vt_status vt_model_fit(vt_model_ws *ws, const vt_model_cfg *cfg,
                       const vt_image_u8 *frame, const vt_model_search *search, vt_model_result *out)
{
    vt__geom g;
    vt_status s;
    uint32_t rs;
    int32_t mode, level, i, k, gen, evals = 0, have_best = 0, cur = 0, n_prev = 0;
    vt_model_params best;
    if (out != NULL) {
        memset(out, 0, sizeof *out);
    }
    if (frame == NULL || cfg == NULL || search == NULL || ws == NULL || out == NULL ||
        vt_model_cfg_check(cfg) != VT_OK || vt__check_search(search) != VT_OK) {
        return VT_E_ARG;
    }
    s = vt__geometry(frame, search, &g);
    if (s != VT_OK) {
        return s;
    }
    mode = search->tracking;
    for (level = 0; level < cfg->levels; level++) {
        if (cfg->pop[mode][level] > VT_MODEL_MAX_POP) {
            return VT_E_CAPACITY;
        }
    }
    if (search->y_max < g.oy + 7 || search->y_min > g.ey) {
        return VT_E_SINGULAR; /* no bottom row leaves room for a model in the ROI */
    }
    rs = cfg->seed != 0 ? cfg->seed : VT__SEED0;
    memset(&best, 0, sizeof best);
    for (level = cfg->levels - 1; level >= 0; level--) {
        const int32_t P = cfg->pop[mode][level];
        const int32_t G = cfg->gens[mode][level];
        const int32_t jit = 2 << level;
        /* A finer level starts from the coarser level's last generation: its best
         * as is (elitism), the others jittered (the levels exchange their
         * detections, paper sec. 6); extra individuals start afresh. */
        const int32_t nb = have_best ? 1 - cur : cur;
        const vt_model_params *prev = ws->pop + cur * VT_MODEL_MAX_POP;
        vt_model_params *pop;
        int32_t *fit;
        s = vt_model_prepare(ws, cfg, frame, search, level);
        if (s != VT_OK) {
            return s;
        }
        pop = ws->pop + nb * VT_MODEL_MAX_POP;
        fit = ws->fit + nb * VT_MODEL_MAX_POP;
        for (i = 0; i < P; i++) {
            vt_model_params *p = &pop[i];
            if (have_best && i < n_prev) {
                *p = i == 0 ? best : prev[i];
                if (i > 0) {
                    for (k = 0; k < VT__GENES; k++) {
                        *vt__gene(p, k) += vt__rand_pm(&rs, k < 4 ? jit : 5);
                    }
                }
            } else if (mode == 1) {
                /* Tracking: around the prediction, three uniform draws per gene
                 * (std sigma, |offset| <= 3 sigma); individual 0 is the prediction. */
                vt_model_params sig = search->sigma;
                *p = search->pred;
                if (i > 0) {
                    for (k = 0; k < VT__GENES; k++) {
                        int32_t sg = *vt__gene(&sig, k);
                        *vt__gene(p, k) += vt__rand_pm(&rs, sg) + vt__rand_pm(&rs, sg) +
                                           vt__rand_pm(&rs, sg);
                    }
                }
            } else {
                vt__random_individual(cfg, &g, &rs, p);
            }
            vt__repair(cfg, &g, p);
            fit[i] = vt__fitness(cfg, ws, p);
            evals++;
        }
        cur = nb;
        for (gen = 0; gen < G; gen++) {
            const int32_t nxt = 1 - cur;
            vt_model_params *np_ = ws->pop + nxt * VT_MODEL_MAX_POP;
            int32_t *nf = ws->fit + nxt * VT_MODEL_MAX_POP;
            int32_t e = vt__best(ws->fit + cur * VT_MODEL_MAX_POP, P);
            pop = ws->pop + cur * VT_MODEL_MAX_POP;
            fit = ws->fit + cur * VT_MODEL_MAX_POP;
            np_[0] = pop[e]; /* elitism */
            nf[0] = fit[e];
            for (i = 1; i < P; i++) {
                int32_t a = vt__tournament(fit, P, &rs);
                int32_t b = vt__tournament(fit, P, &rs);
                int32_t mask = vt__rand(&rs, 1 << VT__GENES);
                vt_model_params ch;
                for (k = 0; k < VT__GENES; k++) {
                    *vt__gene(&ch, k) = *vt__gene(&pop[(mask >> k) & 1 ? a : b], k);
                }
                for (k = 0; k < VT__GENES; k++) {
                    /* (r * 1000) >> 32 < p  <=>  r < p 2^32 / 1000: the same
                     * decision as the percent draw of before, (r * 100) >> 32 <
                     * p / 10, for every p that is a whole percent. */
                    if (vt__rand(&rs, 1000) < cfg->mut_permille) {
                        *vt__gene(&ch, k) += vt__rand_pm(&rs, k < 4 ? jit : 5);
                    }
                }
                vt__repair(cfg, &g, &ch);
                np_[i] = ch;
                nf[i] = vt__fitness(cfg, ws, &ch);
                evals++;
            }
            cur = nxt;
        }
        pop = ws->pop + cur * VT_MODEL_MAX_POP;
        fit = ws->fit + cur * VT_MODEL_MAX_POP;
        i = vt__best(fit, P);
        best = pop[i];
        have_best = 1;
        n_prev = P;
        ws->cur = cur;
        ws->n = P;
        out->fitness = fit[i];
    }
    ws->rng = rs;
    out->best = best;
    out->evaluations = evals;
    out->box.left = best.x - best.w / 2;
    out->box.right = out->box.left + best.w - 1;
    out->box.bottom = best.y;
    out->box.top = best.y - best.h + 1;
    return VT_OK;
}
