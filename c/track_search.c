/* track_search.c -- the tracker's measurement inside a predicted ROI (thesis
 * sec. 3.6.1): horizontal-edge projection searched from the bottom to the middle
 * for the bottom edge, vertical-edge projections searched from the left and the
 * right for the sides, with the thesis's two-threshold rule against jumps. */
#include "vehtrack/track_search.h"
#include "internal.h"

/* The two projections' inner rows take 8 columns at a time in SSE2 (VT__SSE2,
 * internal.h). Exact: a Sobel response is within +-1020 (4 x 255), an int16 lane, and a
 * column count or a row's per-lane count stays far below 2^15. */
#if VT__SSE2
/* thr - 1 for an int16 "> " compare standing for ">= thr" (thr >= 1, the cfg check):
 * thresholds past the Sobel range (|g| <= 1020) give the same answers clamped to 1021. */
static __m128i vt__thr16(int32_t thr)
{
    return _mm_set1_epi16((int16_t)((thr > 1021 ? 1021 : thr) - 1));
}
#endif

/* Count of columns x in [l, r) of row y whose s * Sobel d/dy >= thr (edge replicated,
 * as vt_sobel_y). Columns 0 and w-1 take the clamped path; the rest none. */
static int32_t vt__count_h(const vt_image_u8 *img, int32_t y, int32_t l, int32_t r, int32_t s,
                           int32_t thr)
{
    const uint8_t *pm, *p0, *pp;
    int32_t x, n = 0, lo = l > 1 ? l : 1, hi = r < img->w - 1 ? r : img->w - 1;
    vt__sobel_rows(img, y, &pm, &p0, &pp);
    for (x = l; x < lo && x < r; ++x) { /* column 0 */
        int32_t xr = img->w > 1 ? 1 : 0;
        n += s * ((pp[0] + 2 * pp[0] + pp[xr]) - (pm[0] + 2 * pm[0] + pm[xr])) >= thr;
    }
    x = lo;
#if VT__SSE2
    {
        /* columns x-1 .. x+8 read: x + 8 <= hi <= w - 1 */
        const __m128i t16 = vt__thr16(thr);
        __m128i cnt = _mm_setzero_si128();
        int16_t lane[8];
        int32_t k;
        for (; x + 8 <= hi; x += 8) {
            __m128i g = vt__sobel_y8(pm, pp, x);
            if (s < 0) {
                g = _mm_sub_epi16(_mm_setzero_si128(), g);
            }
            cnt = _mm_sub_epi16(cnt, _mm_cmpgt_epi16(g, t16)); /* true lanes are -1 */
        }
        _mm_storeu_si128((__m128i *)(void *)lane, cnt);
        for (k = 0; k < 8; ++k) {
            n += lane[k];
        }
    }
#endif
    for (; x < hi; ++x) {
        n += s * ((pp[x - 1] + 2 * pp[x] + pp[x + 1]) - (pm[x - 1] + 2 * pm[x] + pm[x + 1])) >= thr;
    }
    for (x = hi > lo ? hi : lo; x < r; ++x) { /* column w-1 */
        int32_t xl = x > 0 ? x - 1 : 0;
        n += s * ((pp[xl] + 2 * pp[x] + pp[x]) - (pm[xl] + 2 * pm[x] + pm[x])) >= thr;
    }
    return n;
}

/* |Sobel d/dx| >= thr at (x, y), edge replicated (as vt_sobel_x). */
static int32_t vt__vedge(const uint8_t *pm, const uint8_t *p0, const uint8_t *pp, int32_t xl,
                         int32_t xr, int32_t thr)
{
    int32_t g = (pm[xr] - pm[xl]) + 2 * (p0[xr] - p0[xl]) + (pp[xr] - pp[xl]);
    return (g < 0 ? -g : g) >= thr;
}

/* First index from `from` towards `to` (exclusive, stepping `step`) whose value
 * v >= vmax * num / den, or -1; compared as v * den >= vmax * num, exactly. */
static int32_t vt__scan(const int32_t *v, int32_t from, int32_t to, int32_t step, int32_t num,
                        int32_t den, int32_t vmax)
{
    int32_t i;
    for (i = from; i != to; i += step) {
        /* v >= vmax * num / den without a division (vmax, v < 2^20). */
        if ((int64_t)v[i] * den >= (int64_t)vmax * num) {
            return i;
        }
    }
    return -1;
}

/* |a - b|, saturated to INT32_MAX: the side memory is caller-owned, so its
 * previous positions may be anything (a - b can overflow int32). */
static int32_t vt__absdiff_sat(int32_t a, int32_t b)
{
    int64_t d = (int64_t)a - b;
    d = d < 0 ? -d : d;
    return d > INT32_MAX ? INT32_MAX : (int32_t)d;
}

static int32_t vt__max_range(const int32_t *v, int32_t lo, int32_t hi)
{
    int32_t i, m = 0;
    for (i = lo; i < hi; ++i) {
        m = v[i] > m ? v[i] : m;
    }
    return m;
}

vt_status vt_track_search_cfg_check(const vt_track_search_cfg *cfg)
{
    if (cfg == NULL ||
        (cfg->polarity != VT_EDGE_DARK_ABOVE && cfg->polarity != VT_EDGE_DARK_BELOW) ||
        cfg->h_thresh < 1 || cfg->v_thresh < 1 || cfg->min_h_permille < 0 ||
        cfg->min_h_permille > 1000 || cfg->min_v_permille < 0 || cfg->min_v_permille > 1000 ||
        cfg->bottom_permille < 1 || cfg->bottom_permille > 1000 ||
        (cfg->side_mode != VT_SIDES_TWO_THRESHOLD && cfg->side_mode != VT_SIDES_LARGEST)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

vt_status vt_track_search(vt_track_search_ws *ws, vt_track_sides *sides,
                          const vt_track_search_cfg *cfg, const vt_image_u8 *img,
                          const vt_box *roi, vt_box *meas, int32_t *found)
{
    int32_t l, t, r, b, x, y, ybest, hbest, mid, midx, lmax, rmax, xl, xr, rows, sign;
    vt_status s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    if (cfg == NULL || roi == NULL || ws == NULL || meas == NULL || found == NULL) {
        return VT_E_ARG;
    }
    if (vt_track_search_cfg_check(cfg) != VT_OK) {
        return VT_E_ARG;
    }
    *found = 0;
    /* Work on half-open ranges [l, r) x [t, b) inside the image. */
    l = vt__clamp_i32(roi->left, 0, img->w);
    r = roi->right < roi->left ? l : vt__clamp_i32(roi->right, -1, img->w - 1) + 1;
    t = vt__clamp_i32(roi->top, 0, img->h);
    b = roi->bottom < roi->top ? t : vt__clamp_i32(roi->bottom, -1, img->h - 1) + 1;
    /* Too small to hold a bottom edge and two sides: not found (not an error,
     * a predicted box may leave the frame). */
    if (r - l < 4 || b - t < 2) {
        return VT_OK;
    }
    sign = cfg->polarity == VT_EDGE_DARK_ABOVE ? 1 : -1;
    for (y = t; y < b; ++y) {
        ws->hproj[y] = vt__count_h(img, y, l, r, sign, cfg->h_thresh);
    }
    /* Bottom edge: between the bottom row and the middle row, the lowest row whose
     * count reaches bottom_permille of the largest count there (1000: the largest
     * itself, the thesis's rule; the lower row wins ties). */
    mid = t + (b - t) / 2;
    hbest = vt__max_range(ws->hproj, mid, b);
    if (hbest == 0 || (int64_t)hbest * 1000 < (int64_t)cfg->min_h_permille * (r - l)) {
        return VT_OK;
    }
    ybest = vt__scan(ws->hproj, b - 1, mid - 1, -1, cfg->bottom_permille, 1000, hbest);
    rows = ybest - t + 1;
    /* Row by row (cache-friendly), accumulating per column. */
    for (x = l; x < r; ++x) {
        ws->vproj[x] = 0;
    }
    for (y = t; y <= ybest; ++y) {
        const uint8_t *pm, *p0, *pp;
        /* Only columns 0 and w-1 need the replicated border; the rest none. */
        int32_t lo = l > 1 ? l : 1, hi = r < img->w - 1 ? r : img->w - 1;
        vt__sobel_rows(img, y, &pm, &p0, &pp);
        for (x = l; x < r && x < lo; ++x) {
            ws->vproj[x] += vt__vedge(pm, p0, pp, 0, img->w > 1 ? 1 : 0, cfg->v_thresh);
        }
        x = lo;
#if VT__SSE2
        {
            const __m128i t16 = vt__thr16(cfg->v_thresh);
            for (; x + 8 <= hi; x += 8) {
                __m128i g = vt__sobel_x8(pm, p0, pp, x);
                __m128i e = _mm_cmpgt_epi16(_mm_max_epi16(g, _mm_sub_epi16(_mm_setzero_si128(), g)), t16);
                __m128i *vp = (__m128i *)(void *)(ws->vproj + x);
                /* true lanes are -1: widened to int32 -1 and subtracted */
                _mm_storeu_si128(vp, _mm_sub_epi32(_mm_loadu_si128(vp), _mm_unpacklo_epi16(e, e)));
                _mm_storeu_si128(vp + 1, _mm_sub_epi32(_mm_loadu_si128(vp + 1), _mm_unpackhi_epi16(e, e)));
            }
        }
#endif
        for (; x < hi; ++x) {
            ws->vproj[x] += vt__vedge(pm, p0, pp, x - 1, x + 1, cfg->v_thresh);
        }
        for (x = hi > lo ? hi : lo; x < r; ++x) {
            ws->vproj[x] += vt__vedge(pm, p0, pp, x > 0 ? x - 1 : 0, img->w - 1, cfg->v_thresh);
        }
    }
    midx = l + (r - l) / 2;
    lmax = vt__max_range(ws->vproj, l, midx);
    rmax = vt__max_range(ws->vproj, midx, r);
    if ((int64_t)lmax * 1000 < (int64_t)cfg->min_v_permille * rows || lmax == 0 ||
        (int64_t)rmax * 1000 < (int64_t)cfg->min_v_permille * rows || rmax == 0) {
        return VT_OK;
    }
    if (cfg->side_mode == VT_SIDES_LARGEST) {
        /* The verification step's rule: the largest value of each half, met
         * first from the outside. */
        xl = vt__scan(ws->vproj, l, midx, 1, 1, 1, lmax);
        xr = vt__scan(ws->vproj, r - 1, midx - 1, -1, 1, 1, rmax);
    } else {
        /* First threshold: half the largest value; the halves' largest values
         * exist, so both scans succeed. */
        xl = vt__scan(ws->vproj, l, midx, 1, 1, 2, lmax);
        xr = vt__scan(ws->vproj, r - 1, midx - 1, -1, 1, 2, rmax);
    }
    if (cfg->side_mode == VT_SIDES_TWO_THRESHOLD && sides != NULL && sides->have_prev) {
        int32_t dl = vt__absdiff_sat(xl, sides->prev_left), dr = vt__absdiff_sat(xr, sides->prev_right);
        if (dl > sides->max_change_left) {
            xl = vt__scan(ws->vproj, l, midx, 1, 1, 1, lmax);
            dl = vt__absdiff_sat(xl, sides->prev_left);
        }
        if (dr > sides->max_change_right) {
            xr = vt__scan(ws->vproj, r - 1, midx - 1, -1, 1, 1, rmax);
            dr = vt__absdiff_sat(xr, sides->prev_right);
        }
        sides->max_change_left = dl > sides->max_change_left ? dl : sides->max_change_left;
        sides->max_change_right = dr > sides->max_change_right ? dr : sides->max_change_right;
    }
    if (sides != NULL) {
        sides->have_prev = 1;
        sides->prev_left = xl;
        sides->prev_right = xr;
    }
    meas->left = xl;
    meas->right = xr;
    meas->top = t;
    meas->bottom = ybest;
    *found = 1;
    return VT_OK;
}
