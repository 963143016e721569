/* windows.c -- full-road hypotheses: flat-road bounded sliding windows on the
 * Gaussian pyramid (IVVI paper sec. 4/5, road restriction; GIST paper sec. III,
 * windows scored by the classifier), the camera-aware road area, and NMS.
 * See windows.h for the rules and arithmetic; the float twin is
 * pyvehtrack/reference/windows.py. */
#include <stddef.h>

#include "vehtrack/windows.h"
#include "internal.h"

vt_status vt_win_cfg_default(vt_win_cfg *cfg)
{
    static const vt_win_cfg def = VT_WIN_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

static int vt__in(int32_t v, int32_t lo, int32_t hi)
{
    return v >= lo && v <= hi;
}

vt_status vt_win_cfg_check(const vt_win_cfg *cfg)
{
    int32_t i;
    if (cfg == NULL) {
        return VT_E_ARG;
    }
    if (cfg->n_sizes > VT_WIN_MAX_SIZES || cfg->levels > VT_WIN_MAX_LEVELS) {
        return VT_E_CAPACITY;
    }
    if (!vt__in(cfg->veh_w_max_mm, 100, 20000) ||
        !vt__in(cfg->veh_w_min_mm, 100, cfg->veh_w_max_mm) || cfg->n_sizes < 1 ||
        !vt__in(cfg->step_q8, 1, 1024) || cfg->levels < 1 ||
        !vt__in(cfg->lane_w_mm, 1000, 10000) || !vt__in(cfg->top_margin, 0, VT_MAX_HEIGHT)) {
        return VT_E_ARG;
    }
    for (i = 0; i < cfg->n_sizes; ++i) {
        if (!vt__in(cfg->size[i], 4, 1024) || (i > 0 && cfg->size[i] <= cfg->size[i - 1])) {
            return VT_E_ARG;
        }
    }
    return VT_OK;
}

vt_status vt_camera_min_check(const vt_camera_min *cam)
{
    if (cam == NULL || !vt__in(cam->fx_q4, 16, 1 << 24) ||
        !vt__in(cam->horizon_y, -VT_MAX_HEIGHT, VT_MAX_HEIGHT) ||
        !vt__in(cam->height_mm, 100, 20000) || !vt__in(cam->hood_y, 1, 2 * VT_MAX_HEIGHT)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

vt_status vt_camera_min_row_distance(const vt_camera_min *cam, int32_t row, int32_t *mm)
{
    int64_t d, z;
    if (mm == NULL) {
        return VT_E_ARG;
    }
    *mm = 0;
    if (vt_camera_min_check(cam) != VT_OK || row <= cam->horizon_y) {
        return VT_E_ARG;
    }
    /* fx_q4 * H < 2^39; d >= 1. z = round(fx_q4 * H / (16 d)), half up. */
    d = (int64_t)row - cam->horizon_y;
    z = ((int64_t)cam->fx_q4 * cam->height_mm + 8 * d) / (16 * d);
    *mm = z > INT32_MAX ? INT32_MAX : (int32_t)z;
    return VT_OK;
}

vt_status vt_road_from_camera(const vt_win_cfg *cfg, const vt_camera_min *cam, int32_t w,
                              int32_t h, vt_road_area *road)
{
    int32_t y, y0, y1;
    vt_status s;
    if (road == NULL) {
        return VT_E_ARG;
    }
    road->valid = 0;
    s = vt_win_cfg_check(cfg);
    if (s != VT_OK) {
        return s;
    }
    if (vt_camera_min_check(cam) != VT_OK) {
        return VT_E_ARG;
    }
    if (!vt__in(w, 1, VT_MAX_WIDTH) || !vt__in(h, 1, VT_MAX_HEIGHT)) {
        return VT_E_SIZE;
    }
    y0 = vt__max_i32(0, cam->horizon_y + cfg->top_margin);
    y1 = (cam->hood_y < h ? cam->hood_y : h) - 1;
    for (y = 0; y < VT_MAX_HEIGHT; ++y) {
        road->x_left[y] = 0;
        road->x_right[y] = 0;
        road->lane_width[y] = 0;
    }
    road->height = h;
    road->y_top = y0;
    road->y_bottom = y1;
    if (y0 > y1) {
        road->y_top = 0;
        road->y_bottom = -1;
        return VT_OK;
    }
    for (y = y0; y <= y1; ++y) {
        /* lane_w * d < 2^14 * 2^12: exact in int64; half up. */
        int64_t d = (int64_t)y - cam->horizon_y;
        int64_t lw = (2 * (int64_t)cfg->lane_w_mm * d + cam->height_mm) / (2 * cam->height_mm);
        road->x_left[y] = 0;
        road->x_right[y] = (int16_t)(w - 1);
        road->lane_width[y] = (int16_t)(lw < 1 ? 1 : (lw > 32767 ? 32767 : lw));
    }
    road->valid = 1;
    return VT_OK;
}

/* The row rule of vt_windows_level for a window of side s at level row y. */
static int vt__row_ok(const vt_win_cfg *cfg, const vt_camera_min *cam, const vt_road_area *road,
                      int32_t level, int32_t s, int32_t y)
{
    int32_t b = ((y + s) << level) - 1;
    int64_t d = (int64_t)b - cam->horizon_y;
    int64_t span = ((int64_t)s << level) * cam->height_mm;
    if (d <= 0 || b >= cam->hood_y) {
        return 0;
    }
    if (road != NULL && (b < road->y_top || b > road->y_bottom)) {
        return 0;
    }
    return (int64_t)cfg->veh_w_min_mm * d <= span && span <= (int64_t)cfg->veh_w_max_mm * d;
}

vt_status vt_windows_level(const vt_win_cfg *cfg, const vt_camera_min *cam,
                           const vt_road_area *road, int32_t w, int32_t h, int32_t level,
                           vt_window *out, int32_t cap, int32_t *n_out)
{
    int32_t lw = w, lh = h, i, l, n = 0;
    vt_status s;
    if (n_out == NULL) {
        return VT_E_ARG;
    }
    *n_out = 0;
    s = vt_win_cfg_check(cfg);
    if (s != VT_OK) {
        return s;
    }
    if (vt_camera_min_check(cam) != VT_OK || cap < 0 || (out == NULL && cap > 0) ||
        level < 0 || level >= cfg->levels) {
        return VT_E_ARG;
    }
    if (!vt__in(w, 1, VT_MAX_WIDTH) || !vt__in(h, 1, VT_MAX_HEIGHT)) {
        return VT_E_SIZE;
    }
    if (road != NULL && !road->valid) {
        road = NULL;
    }
    if (road != NULL && (road->height != h || road->y_top < 0 || road->y_bottom >= h)) {
        return VT_E_SIZE;
    }
    for (l = 0; l < level; ++l) {
        lw = (lw + 1) / 2;
        lh = (lh + 1) / 2;
    }
    for (i = 0; i < cfg->n_sizes; ++i) {
        int32_t sz = cfg->size[i];
        int32_t step = vt__max_i32(1, (sz * cfg->step_q8) >> 8);
        int32_t y = 0, x;
        if (sz > lw || sz > lh) {
            continue;
        }
        while (y <= lh - sz && !vt__row_ok(cfg, cam, road, level, sz, y)) {
            ++y;
        }
        for (; y <= lh - sz && vt__row_ok(cfg, cam, road, level, sz, y); y += step) {
            int32_t b = ((y + sz) << level) - 1;
            for (x = 0; x <= lw - sz; x += step) {
                int32_t c = ((x << level) + ((x + sz) << level) - 1) >> 1;
                if (road != NULL && (c < road->x_left[b] || c > road->x_right[b])) {
                    continue;
                }
                if (n < cap) {
                    out[n].level = level;
                    out[n].size = sz;
                    out[n].x = x;
                    out[n].y = y;
                }
                ++n;
            }
        }
    }
    *n_out = n;
    return VT_OK;
}

static int64_t vt__area(const vt_box *b)
{
    return ((int64_t)b->right - b->left + 1) * ((int64_t)b->bottom - b->top + 1);
}

void vt__cand_add(vt_scored_box *cand, int32_t *n, int32_t cap, int32_t *n_dropped, const vt_box *b,
                  int32_t score, int32_t source)
{
    int32_t i, lo = 0;
    if (*n < cap) {
        i = (*n)++;
    } else {
        for (i = 1; i < cap; ++i) {
            if (cand[i].score < cand[lo].score) {
                lo = i;
            }
        }
        ++*n_dropped;
        if (cand[lo].score >= score) {
            return;
        }
        i = lo;
    }
    cand[i].box = *b;
    cand[i].score = score;
    cand[i].source = source;
}

/* 1 if box b is suppressed by the kept box a (internal.h; coordinates within +-2^24). */
int vt__box_suppress(const vt_box *a, const vt_box *b, int32_t iou_permille, int32_t contain_permille)
{
    int64_t iw = (int64_t)(a->right < b->right ? a->right : b->right) -
                 (a->left > b->left ? a->left : b->left) + 1;
    int64_t ih = (int64_t)(a->bottom < b->bottom ? a->bottom : b->bottom) -
                 (a->top > b->top ? a->top : b->top) + 1;
    int64_t inter, aa, ab, uni, mn;
    if (iw <= 0 || ih <= 0) {
        return 0;
    }
    /* vt_nms limits coordinates to +-2^24, so areas < 2^51 and the products
     * below (x 1000 < 2^10) stay exact in int64 */
    inter = iw * ih;
    aa = vt__area(a);
    ab = vt__area(b);
    uni = aa + ab - inter;
    mn = aa < ab ? aa : ab;
    return inter * 1000 > (int64_t)iou_permille * uni ||
           inter * 1000 > (int64_t)contain_permille * mn;
}

vt_status vt_nms(vt_scored_box *boxes, int32_t n, int32_t iou_permille, int32_t contain_permille,
                 int32_t *n_out)
{
    int32_t i, j, kept = 0;
    if (n_out == NULL) {
        return VT_E_ARG;
    }
    *n_out = 0;
    if (n < 0 || (boxes == NULL && n > 0) || !vt__in(iou_permille, 0, 1000) ||
        !vt__in(contain_permille, 0, 1000)) {
        return VT_E_ARG;
    }
    if (n > VT_MAX_NMS_BOXES) {
        return VT_E_CAPACITY;
    }
    for (i = 0; i < n; ++i) {
        const vt_box *b = &boxes[i].box;
        /* spans limited to 2^24 so the areas below are exact in int64 */
        if (b->left > b->right || b->top > b->bottom || b->left < -(1 << 24) ||
            b->right > (1 << 24) || b->top < -(1 << 24) || b->bottom > (1 << 24)) {
            return VT_E_ARG;
        }
    }
    /* stable insertion sort, score descending */
    for (i = 1; i < n; ++i) {
        vt_scored_box t = boxes[i];
        j = i - 1;
        while (j >= 0 && boxes[j].score < t.score) {
            boxes[j + 1] = boxes[j];
            --j;
        }
        boxes[j + 1] = t;
    }
    /* greedy: kept boxes are compacted to the front, in order */
    for (i = 0; i < n; ++i) {
        int keep = 1;
        for (j = 0; j < kept && keep; ++j) {
            keep = !vt__box_suppress(&boxes[j].box, &boxes[i].box, iou_permille, contain_permille);
        }
        if (keep) {
            if (kept != i) {
                vt_scored_box t = boxes[kept];
                boxes[kept] = boxes[i];
                boxes[i] = t;
            }
            ++kept;
        }
    }
    *n_out = kept;
    return VT_OK;
}
