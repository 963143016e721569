/* hood.c -- the ego car's hood found in the frame (issue 8, item 4: hood rows
 * excluded; the thesis's shadow scan, sec. 2.4.2.1, reads the hood's edge as a
 * vehicle's underside). Rule and arithmetic: vehtrack/hood.h; twin:
 * pyvehtrack/reference/hood.py. */
#include <stddef.h>

#include "vehtrack/hood.h"
#include "internal.h"

#define VT__HOOD_NONE 32767 /* no strong column on the path yet */

vt_status vt_hood_cfg_default(vt_hood_cfg *cfg)
{
    static const vt_hood_cfg def = VT_HOOD_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_hood_cfg_check(const vt_hood_cfg *cfg)
{
    if (cfg == NULL || cfg->band_top_permille < 500 || cfg->band_top_permille > 999 ||
        cfg->col_step < 2 || cfg->col_step > 64 || cfg->grad_min < 1 || cfg->grad_min > 255 ||
        cfg->max_jump < 0 || cfg->max_jump > 16 || cfg->cover_permille < 1 ||
        cfg->cover_permille > 1000) {
        return VT_E_ARG;
    }
    return VT_OK;
}

static void vt__hood_none(vt_hood_result *res)
{
    res->found = 0;
    res->row = -1;
    res->n_cols = 0;
    res->n_strong = 0;
    res->path_end = -1;
}

/* three times the vertical gray step at (x, y): |s(y+1) - s(y-1)| over columns x-1..x+1 */
static int32_t vt__hood_step(const vt_image_u8 *img, int32_t x, int32_t y)
{
    const uint8_t *a = img->px + (size_t)(y - 1) * (size_t)img->stride + (size_t)x;
    const uint8_t *b = img->px + (size_t)(y + 1) * (size_t)img->stride + (size_t)x;
    int32_t s = ((int32_t)b[-1] + b[0] + b[1]) - ((int32_t)a[-1] + a[0] + a[1]);
    return vt__abs_i32(s);
}

vt_status vt_hood_find(vt_hood_state *st, const vt_hood_cfg *cfg, const vt_image_u8 *img,
                       vt_hood_result *res)
{
    int32_t y0, y1, n_rows, x, x0, n_cols, r, c, thr, cap, cur, prv, best_r;
    vt_status s;
    if (res == NULL) {
        return VT_E_ARG;
    }
    vt__hood_none(res);
    if (st == NULL || vt_hood_cfg_check(cfg) != VT_OK) {
        return VT_E_ARG;
    }
    s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    y0 = (int32_t)(((int64_t)img->h * cfg->band_top_permille) / 1000);
    y0 = y0 < 1 ? 1 : y0;
    y1 = img->h - 2;
    x0 = cfg->col_step / 2; /* >= 1: col_step >= 2 */
    n_cols = x0 + 1 < img->w ? (img->w - 2 - x0) / cfg->col_step + 1 : 0;
    res->n_cols = n_cols;
    if (y1 < y0 || n_cols == 0) {
        return VT_OK;
    }
    n_rows = y1 - y0 + 1;
    thr = 3 * cfg->grad_min;
    cap = 12 * cfg->grad_min;
    cur = 0;
    for (r = 0; r < n_rows; ++r) {
        int32_t d = vt__hood_step(img, x0, y0 + r);
        st->score[cur][r] = d < cap ? d : cap;
        st->count[cur][r] = (int16_t)(d >= thr);
        st->top[cur][r] = (int16_t)(d >= thr ? r : VT__HOOD_NONE);
    }
    for (c = 1, x = x0 + cfg->col_step; c < n_cols; ++c, x += cfg->col_step) {
        prv = cur;
        cur = 1 - cur;
        for (r = 0; r < n_rows; ++r) {
            int32_t best = -1, src = 0, dj, d, top;
            for (dj = -cfg->max_jump; dj <= cfg->max_jump; ++dj) {
                int32_t k = vt__clamp_i32(r + dj, 0, n_rows - 1);
                if (st->score[prv][k] > best) { /* strict: the lowest row wins ties */
                    best = st->score[prv][k];
                    src = k;
                }
            }
            d = vt__hood_step(img, x, y0 + r);
            st->score[cur][r] = best + (d < cap ? d : cap);
            st->count[cur][r] = (int16_t)(st->count[prv][src] + (d >= thr));
            top = st->top[prv][src];
            st->top[cur][r] = (int16_t)(d >= thr && r < top ? r : top);
        }
    }
    best_r = 0;
    for (r = 1; r < n_rows; ++r) {
        if (st->score[cur][r] > st->score[cur][best_r]) {
            best_r = r;
        }
    }
    res->n_strong = st->count[cur][best_r];
    res->path_end = y0 + best_r;
    if (res->n_strong > 0 && (int64_t)res->n_strong * 1000 >= (int64_t)cfg->cover_permille * n_cols) {
        res->found = 1;
        res->row = y0 + st->top[cur][best_r];
    }
    return VT_OK;
}
