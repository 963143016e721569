/* verify.c -- hypothesis verification by vertical edges (thesis sec. 2.4.2.2).
 * See verify.h for the cost; the float twin is pyvehtrack/reference/verify.py. */
#include <string.h>

#include "vehtrack/verify.h"
#include "internal.h"

vt_status vt_verify_cfg_default(vt_verify_cfg *cfg)
{
    static const vt_verify_cfg def = VT_VERIFY_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

static int vt__in(int32_t v, int32_t lo, int32_t hi)
{
    return v >= lo && v <= hi;
}

vt_status vt_verify_cfg_check(const vt_verify_cfg *cfg)
{
    if (cfg == NULL) {
        return VT_E_ARG;
    }
    if (!vt__in(cfg->widen_px, 0, 4096) || !vt__in(cfg->widen_q8, 0, 1024) ||
        !vt__in(cfg->roi_height_q8, 1, 4096) ||
        !vt__in(cfg->vedge_threshold, 1, 1020) || !vt__in(cfg->side_min_frac_permille, 0, 1000) ||
        !vt__in(cfg->side_min_px, 0, 4096) || !vt__in(cfg->side_contrast_q8, 0, 4096) ||
        !vt__in(cfg->min_width_q8, 0, 4096) ||
        !vt__in(cfg->aspect_q8, 1, 4096) || !vt__in(cfg->vedge_reach, 0, 3) ||
        !vt__in(cfg->vedge_hyst_permille, 0, 1000)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

/* A column's hysteresis state once its current run of weak pixels holds a
 * strong one; below it, the run's weak pixels not yet counted (<= VT_MAX_HEIGHT). */
#define VT__RUN_ANCHORED 0xFFFFu

/* Vertical-edge projection of ROI columns x0..x1, rows top..bottom, into
 * st->proj[0..x1-x0]: per ROI row, the vertical [1 2 1] sums of the columns
 * x0-1-r..x1+1+r (r = vedge_reach; replicated at the image border, as
 * vt_sobel_x), then g = vsum[x+1+r] - vsum[x-1-r] (r = 0: sobel_x; a sharp step
 * of d gray levels anywhere inside the baseline gives 4d for every r), exact in
 * int32. A pixel is strong if |g| >= thr, weak if |g| >= weak (weak <= thr).
 * Hysteresis along each column: a weak pixel counts once its vertical run of
 * weak pixels holds a strong pixel (the run's earlier weak pixels are counted
 * then, its later ones as they come); a run that never meets a strong pixel
 * counts nothing. With weak == thr every pixel counted is a strong one: the
 * thesis's count. Counts <= VT_MAX_HEIGHT fit uint16. */
static void vt__project(vt_verify_state *st, const vt_image_u8 *img, int32_t x0, int32_t x1,
                        int32_t top, int32_t bottom, int32_t thr, int32_t weak, int32_t r)
{
    const int32_t w = img->w;
    const int32_t a = x0 - 1 - r > 0 ? x0 - 1 - r : 0;
    const int32_t b = x1 + 1 + r < w - 1 ? x1 + 1 + r : w - 1;
    int32_t x, y;
    memset(st->proj, 0, (size_t)(x1 - x0 + 1) * sizeof st->proj[0]);
    memset(st->run, 0, (size_t)(x1 - x0 + 1) * sizeof st->run[0]);
    for (y = top; y <= bottom; ++y) {
        const uint8_t *pm, *p0, *pp;
        vt__sobel_rows(img, y, &pm, &p0, &pp);
        for (x = a; x <= b; ++x) {
            st->vsum[x] = (uint16_t)(pm[x] + 2 * p0[x] + pp[x]);
        }
        for (x = x0; x <= x1; ++x) {
            int32_t xa = x - 1 - r > 0 ? x - 1 - r : 0, xb = x + 1 + r < w - 1 ? x + 1 + r : w - 1;
            int32_t g = (int32_t)st->vsum[xb] - (int32_t)st->vsum[xa];
            uint16_t *run = &st->run[x - x0], *cnt = &st->proj[x - x0];
            if (g < 0) {
                g = -g;
            }
            if (g < weak) {
                *run = 0; /* the run ends; uncounted weak pixels stay uncounted */
            } else if (*run == VT__RUN_ANCHORED) {
                ++*cnt;
            } else if (g >= thr) {
                *cnt = (uint16_t)(*cnt + *run + 1);
                *run = (uint16_t)VT__RUN_ANCHORED;
            } else {
                ++*run;
            }
        }
    }
}

/* The weak threshold: thr - floor(thr * hyst / 1000), at least 1 (thr <= 1020,
 * hyst <= 1000: the product fits int32). */
static int32_t vt__weak(const vt_verify_cfg *cfg)
{
    int32_t weak = cfg->vedge_threshold - cfg->vedge_threshold * cfg->vedge_hyst_permille / 1000;
    return weak < 1 ? 1 : weak;
}

/* A side's column is a vertical edge if it has edge pixels on at least
 * side_min_px rows and on at least side_min_frac of the ROI rows, and stands out
 * from the ROI: count >= side_contrast x the mean count of its n columns, i.e.
 * count * n * 256 >= total * side_contrast_q8 (both sides < 2^37: exact in int64). */
static int vt__strong(const vt_verify_cfg *cfg, int32_t count, int32_t rows, int32_t n,
                      int64_t total)
{
    return count >= cfg->side_min_px &&
           (int64_t)count * 1000 >= (int64_t)rows * cfg->side_min_frac_permille &&
           (int64_t)count * n * 256 >= total * cfg->side_contrast_q8;
}

/* One hypothesis (already checked to lie in the image): 1 and the box if it
 * passes, else 0. */
static int vt__verify_one(vt_verify_state *st, const vt_verify_cfg *cfg, const vt_image_u8 *img,
                          const vt_hypothesis *hp, vt_box *box)
{
    const int32_t row = hp->row, len = hp->x_end - hp->x_start + 1;
    int32_t x0, x1, rows, top, n, mid, i, li, ri, width, height, wid;
    int64_t t, total = 0;
    /* ROI: the edge widened on each side by widen_px (thesis: 6 px) plus
     * widen_q8 x its length (the shadow between the wheels can be narrower than
     * the body), height roi_height x the edge length (thesis: half), ending at
     * the edge's row. wid <= 4096 + 4 * 4096: no overflow. */
    wid = cfg->widen_px + (int32_t)(((int64_t)len * cfg->widen_q8) >> 8);
    x0 = hp->x_start - wid > 0 ? hp->x_start - wid : 0;
    x1 = hp->x_end + wid < img->w - 1 ? hp->x_end + wid : img->w - 1;
    t = ((int64_t)len * cfg->roi_height_q8) >> 8;
    rows = t < 1 ? 1 : (t > row + 1 ? row + 1 : (int32_t)t);
    top = row - rows + 1;
    n = x1 - x0 + 1;
    mid = (n + 1) / 2;
    if (n < 2) {
        return 0;
    }
    vt__project(st, img, x0, x1, top, row, cfg->vedge_threshold, vt__weak(cfg), cfg->vedge_reach);
    /* Thesis: the projection is searched from the left and from the right; the
     * largest value met in each direction is that side. Each search covers its
     * own half so the two sides cannot coincide. */
    for (i = 0; i < n; ++i) {
        total += st->proj[i];
    }
    li = 0;
    for (i = 1; i < mid; ++i) {
        if (st->proj[i] > st->proj[li]) {
            li = i;
        }
    }
    ri = n - 1;
    for (i = n - 2; i >= mid; --i) {
        if (st->proj[i] > st->proj[ri]) {
            ri = i;
        }
    }
    /* A vehicle: one horizontal edge (the shadow edge) and two vertical edges. */
    if (!vt__strong(cfg, st->proj[li], rows, n, total) ||
        !vt__strong(cfg, st->proj[ri], rows, n, total)) {
        return 0;
    }
    width = ri - li + 1;
    if ((int64_t)width * 256 < (int64_t)len * cfg->min_width_q8) {
        return 0;
    }
    /* No consistent cue marks a vehicle's top (thesis): an aspect ratio gives
     * it. height = width * aspect, round half up, at least 1, clipped at row 0. */
    height = (int32_t)(((int64_t)width * cfg->aspect_q8 + 128) >> 8);
    if (height < 1) {
        height = 1;
    }
    box->left = x0 + li;
    box->right = x0 + ri;
    box->bottom = row;
    box->top = row - height + 1 > 0 ? row - height + 1 : 0;
    return 1;
}

vt_status vt_verify(vt_verify_state *st, const vt_verify_cfg *cfg, const vt_image_u8 *img,
                    const vt_hypothesis *hyp, int32_t n_hyp, vt_box *out, int32_t cap,
                    int32_t *n_out)
{
    int32_t i, n = 0;
    vt_status s;
    if (n_out == NULL) {
        return VT_E_ARG;
    }
    *n_out = 0;
    if (st == NULL || n_hyp < 0 || (n_hyp > 0 && hyp == NULL) || cap < 0 ||
        (cap > 0 && out == NULL)) {
        return VT_E_ARG;
    }
    s = vt_verify_cfg_check(cfg);
    if (s != VT_OK) {
        return s;
    }
    s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    for (i = 0; i < n_hyp; ++i) {
        const vt_hypothesis *hp = &hyp[i];
        if (hp->row < 0 || hp->row >= img->h || hp->x_start < 0 || hp->x_start > hp->x_end ||
            hp->x_end >= img->w) {
            return VT_E_ARG;
        }
    }
    for (i = 0; i < n_hyp && n < cap; ++i) {
        vt_box box;
        if (vt__verify_one(st, cfg, img, &hyp[i], &box)) {
            out[n++] = box;
        }
    }
    *n_out = n;
    return VT_OK;
}
