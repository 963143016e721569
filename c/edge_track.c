/* edge_track.c -- the GIST paper's tracking measurement (sec. III.B): a
 * vehicle's continuous edge curves (Canny-style: Sobel, non-maximum suppression,
 * two-threshold hysteresis) matched to the next frame's curves by a search over
 * integer displacements scoring the truncated 3-4 chamfer distance. Fixed
 * memory: one workspace per crop, one point list per track. */
#include "vehtrack/edge_track.h"
#include <string.h>
#include "internal.h"

#define VT__DT_INF 65535u

/* Coordinates beyond this are refused (keeps every sum inside int32). */
#define VT__COORD_LIM (4 * (VT_MAX_WIDTH > VT_MAX_HEIGHT ? VT_MAX_WIDTH : VT_MAX_HEIGHT))

vt_status vt_edge_cfg_default(vt_edge_cfg *cfg)
{
    static const vt_edge_cfg def = VT_EDGE_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_edge_cfg_check(const vt_edge_cfg *c)
{
    if (c == NULL || c->low < 1 || c->high < c->low || c->high > 4096 || c->min_len < 1 ||
        c->radius < 0 || c->radius > 64 || c->trunc < 1 || c->trunc > 1000 ||
        c->max_mean_q8 < 0 || c->max_mean_q8 > 256000 || c->min_points < 1 ||
        c->min_points > VT_EDGE_MAX_POINTS || c->scale_steps < 0 || c->scale_steps > 8 ||
        c->scale_step_q8 < 1 || c->scale_step_q8 > 64) {
        return VT_E_ARG;
    }
    return VT_OK;
}

static int vt__box_ok(const vt_box *b)
{
    return b->left <= b->right && b->top <= b->bottom && b->left >= -VT__COORD_LIM &&
           b->right <= VT__COORD_LIM && b->top >= -VT__COORD_LIM && b->bottom <= VT__COORD_LIM;
}

/* Gradient sector: 0 along x, 1 the (1,1) diagonal, 2 along y, 3 the (1,-1) diagonal. */
static int16_t vt__sector(int32_t gx, int32_t gy)
{
    /* ay / ax <= tan 22.5 deg = sqrt(2) - 1  <=>  (ax + ay)^2 <= 2 ax^2, exact
     * (|g| <= 1020: the squares stay below 2^23; equality only at ax = ay = 0). */
    int32_t ax = vt__abs_i32(gx), ay = vt__abs_i32(gy), s2 = (ax + ay) * (ax + ay);
    if (s2 <= 2 * ax * ax) {
        return 0;
    }
    if (s2 <= 2 * ay * ay) {
        return 2;
    }
    return (int16_t)(((gx > 0) == (gy > 0)) ? 1 : 3);
}

static const int32_t vt__ux[4] = { 1, 1, 0, 1 };
static const int32_t vt__uy[4] = { 0, 1, 1, -1 };

/* Magnitude at (x, y), 0 outside the crop. */
static int32_t vt__mag_at(const vt_edge_ws *ws, int32_t x, int32_t y)
{
    if (x < 0 || y < 0 || x >= ws->w || y >= ws->h) {
        return 0;
    }
    return ws->u.g.mag[y * ws->w + x];
}

/* Breadth-first flood from queue[head..*tail) through 8-neighbours labelled
 * `from`, relabelled `to` as they enter (so each pixel enters once). */
static void vt__flood(vt_edge_ws *ws, int32_t head, int32_t *tail, uint8_t from, uint8_t to)
{
    int32_t w = ws->w, h = ws->h;
    while (head < *tail) {
        int32_t p = ws->u.queue[head++], x = p % w, y = p / w, ddx, ddy;
        for (ddy = -1; ddy <= 1; ++ddy) {
            for (ddx = -1; ddx <= 1; ++ddx) {
                int32_t nx = x + ddx, ny = y + ddy, q;
                if (nx < 0 || ny < 0 || nx >= w || ny >= h) {
                    continue;
                }
                q = ny * w + nx;
                if (ws->lab[q] == from) {
                    ws->lab[q] = to;
                    ws->u.queue[(*tail)++] = q;
                }
            }
        }
    }
}

vt_status vt_edge_map(vt_edge_ws *ws, const vt_edge_cfg *cfg, const vt_image_u8 *img,
                      const vt_box *roi)
{
    int32_t l, t, r, b, w, h, n, i, x, y, tail;
    vt_image_u8 crop;
    vt_image_s16 gx, gy;
    vt_status s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    if (roi == NULL || ws == NULL || vt_edge_cfg_check(cfg) != VT_OK || !vt__box_ok(roi)) {
        return VT_E_ARG;
    }
    l = vt__max_i32(roi->left, 0);
    t = vt__max_i32(roi->top, 0);
    r = roi->right < img->w - 1 ? roi->right : img->w - 1;
    b = roi->bottom < img->h - 1 ? roi->bottom : img->h - 1;
    if (l > r || t > b) {
        return VT_E_SIZE;
    }
    w = r - l + 1;
    h = b - t + 1;
    if ((int64_t)w * h > VT_EDGE_MAX_PIXELS) {
        return VT_E_CAPACITY;
    }
    n = w * h;
    ws->x0 = l;
    ws->y0 = t;
    ws->w = w;
    ws->h = h;
    ws->n_curve = 0;
    ws->n_curves = 0;

    /* 1-2. Sobel on the crop as an image of its own, then |gx|+|gy| and sector. */
    crop.px = img->px + (size_t)t * (size_t)img->stride + (size_t)l;
    crop.w = w;
    crop.h = h;
    crop.stride = img->stride;
    gx.px = ws->u.g.mag;
    gy.px = ws->u.g.dir;
    gx.w = gy.w = w;
    gx.h = gy.h = h;
    gx.stride = gy.stride = w;
    if (vt_sobel_x(&crop, &gx) != VT_OK || vt_sobel_y(&crop, &gy) != VT_OK) {
        return VT_E_ARG; /* cannot happen: the crop is a valid view */
    }
    for (i = 0; i < n; ++i) {
        int32_t a = ws->u.g.mag[i], c = ws->u.g.dir[i];
        ws->u.g.dir[i] = vt__sector(a, c);
        ws->u.g.mag[i] = (int16_t)(vt__abs_i32(a) + vt__abs_i32(c));
    }

    /* 3. Non-maximum suppression: 2 = seed (>= high), 1 = candidate (>= low). */
    for (y = 0; y < h; ++y) {
        for (x = 0; x < w; ++x) {
            int32_t p = y * w + x, m = ws->u.g.mag[p], d = ws->u.g.dir[p];
            uint8_t v = 0;
            if (m >= cfg->low && m > vt__mag_at(ws, x - vt__ux[d], y - vt__uy[d]) &&
                m >= vt__mag_at(ws, x + vt__ux[d], y + vt__uy[d])) {
                v = (uint8_t)(m >= cfg->high ? 2 : 1);
            }
            ws->lab[p] = v;
        }
    }

    /* 4. Hysteresis (the gradient planes are dead from here: the queue reuses them). */
    tail = 0;
    for (i = 0; i < n; ++i) {
        if (ws->lab[i] == 2) {
            ws->u.queue[tail++] = i;
        }
    }
    vt__flood(ws, 0, &tail, 1, 2);
    for (i = 0; i < n; ++i) {
        ws->lab[i] = (uint8_t)(ws->lab[i] == 2 ? 1 : 0);
    }

    /* 5. Curves: components of label 1 -> 3 while flooded; short ones -> 0. */
    tail = 0;
    for (i = 0; i < n; ++i) {
        int32_t start = tail, k;
        if (ws->lab[i] != 1) {
            continue;
        }
        ws->lab[i] = 3;
        ws->u.queue[tail++] = i;
        vt__flood(ws, start, &tail, 1, 3);
        if (tail - start < cfg->min_len) {
            for (k = start; k < tail; ++k) {
                ws->lab[ws->u.queue[k]] = 0;
            }
            tail = start;
        } else {
            ws->n_curves += 1;
        }
    }
    ws->n_curve = tail;
    for (i = 0; i < n; ++i) {
        ws->lab[i] = (uint8_t)(ws->lab[i] == 3 ? 1 : 0);
    }

    /* 6. Two-pass 3-4 chamfer distance (the queue is dead: dt reuses it). */
    for (i = 0; i < n; ++i) {
        ws->u.dt[i] = (uint16_t)(ws->lab[i] ? 0u : VT__DT_INF);
    }
#define VT__RELAX(q, c)                                                                    \
    do {                                                                                   \
        uint32_t v_ = (uint32_t)ws->u.dt[q] + (c);                                          \
        if (v_ < best) {                                                                   \
            best = v_;                                                                     \
        }                                                                                  \
    } while (0)
    for (y = 0; y < h; ++y) {
        for (x = 0; x < w; ++x) {
            int32_t p = y * w + x;
            uint32_t best = ws->u.dt[p];
            if (x > 0) {
                VT__RELAX(p - 1, 3u);
            }
            if (y > 0) {
                VT__RELAX(p - w, 3u);
                if (x > 0) {
                    VT__RELAX(p - w - 1, 4u);
                }
                if (x < w - 1) {
                    VT__RELAX(p - w + 1, 4u);
                }
            }
            ws->u.dt[p] = (uint16_t)best;
        }
    }
    for (y = h - 1; y >= 0; --y) {
        for (x = w - 1; x >= 0; --x) {
            int32_t p = y * w + x;
            uint32_t best = ws->u.dt[p];
            if (x < w - 1) {
                VT__RELAX(p + 1, 3u);
            }
            if (y < h - 1) {
                VT__RELAX(p + w, 3u);
                if (x < w - 1) {
                    VT__RELAX(p + w + 1, 4u);
                }
                if (x > 0) {
                    VT__RELAX(p + w - 1, 4u);
                }
            }
            ws->u.dt[p] = (uint16_t)best;
        }
    }
#undef VT__RELAX
    return VT_OK;
}

static int vt__ws_ok(const vt_edge_ws *ws)
{
    return ws->w >= 1 && ws->h >= 1 && (int64_t)ws->w * ws->h <= VT_EDGE_MAX_PIXELS &&
           ws->x0 >= 0 && ws->y0 >= 0 && ws->x0 <= VT__COORD_LIM && ws->y0 <= VT__COORD_LIM;
}

vt_status vt_edge_template_set(const vt_edge_ws *ws, const vt_box *box, vt_edge_template *tpl,
                               int32_t *n_out)
{
    int32_t l, t, r, b, x, y, k = 0, cnt = 0, next_i = 0;
    if (ws == NULL || box == NULL || tpl == NULL || !vt__box_ok(box)) {
        return VT_E_ARG;
    }
    if (!vt__ws_ok(ws)) {
        return VT_E_SIZE;
    }
    /* The box in crop coordinates, clipped. */
    l = vt__max_i32(box->left - ws->x0, 0);
    t = vt__max_i32(box->top - ws->y0, 0);
    r = box->right - ws->x0 < ws->w - 1 ? box->right - ws->x0 : ws->w - 1;
    b = box->bottom - ws->y0 < ws->h - 1 ? box->bottom - ws->y0 : ws->h - 1;
    tpl->n = 0;
    tpl->box = *box;
    if (l <= r && t <= b) {
        for (y = t; y <= b; ++y) {
            for (x = l; x <= r; ++x) {
                cnt += ws->lab[y * ws->w + x] ? 1 : 0;
            }
        }
        /* Keep pixel number k when k == floor(i * cnt / cap) for the next i. */
        for (y = t; y <= b && tpl->n < VT_EDGE_MAX_POINTS; ++y) {
            for (x = l; x <= r && tpl->n < VT_EDGE_MAX_POINTS; ++x) {
                if (!ws->lab[y * ws->w + x]) {
                    continue;
                }
                if (cnt <= VT_EDGE_MAX_POINTS ||
                    k == (int32_t)(((int64_t)next_i * cnt) / VT_EDGE_MAX_POINTS)) {
                    tpl->x[tpl->n] = (int16_t)(x + ws->x0);
                    tpl->y[tpl->n] = (int16_t)(y + ws->y0);
                    tpl->n += 1;
                    next_i += 1;
                }
                ++k;
            }
        }
    }
    if (n_out != NULL) {
        *n_out = tpl->n;
    }
    return VT_OK;
}

/* floor((v s + 128) / 256): |v s| < 2^20 * 2^10, no overflow in int64. */
static int32_t vt__scale(int32_t v, int32_t s)
{
    return (int32_t)vt__floor_shr64((int64_t)v * s + 128, 8);
}

vt_status vt_edge_scale(int32_t v, int32_t s_q8, int32_t *out)
{
    if (out == NULL || v < -(1 << 20) || v > (1 << 20) || s_q8 < 1 || s_q8 > 1024) {
        return VT_E_ARG;
    }
    *out = vt__scale(v, s_q8);
    return VT_OK;
}

vt_status vt_edge_match(const vt_edge_ws *ws, const vt_edge_cfg *cfg, const vt_edge_template *tpl,
                        int32_t cx, int32_t cy, int32_t *dx, int32_t *dy, int32_t *scale_q8,
                        int32_t *score, int32_t *found)
{
    int32_t ddx, ddy, i, j, best = -1, bx = 0, by = 0, bs = 256, ax, ay;
    int16_t sx[VT_EDGE_MAX_POINTS], sy[VT_EDGE_MAX_POINTS];
    if (ws == NULL || tpl == NULL || dx == NULL || dy == NULL || scale_q8 == NULL ||
        score == NULL || found == NULL || vt_edge_cfg_check(cfg) != VT_OK || cx < -8192 ||
        cx > 8192 || cy < -8192 || cy > 8192 || tpl->n < 0 || tpl->n > VT_EDGE_MAX_POINTS ||
        !vt__box_ok(&tpl->box)) {
        return VT_E_ARG;
    }
    if (!vt__ws_ok(ws)) {
        return VT_E_SIZE;
    }
    *found = 0;
    if (tpl->n == 0) {
        return VT_OK;
    }
    ax = (int32_t)vt__floor_shr64((int64_t)tpl->box.left + tpl->box.right, 1);
    ay = tpl->box.bottom;
    for (j = 0; j <= 2 * cfg->scale_steps; ++j) {
        /* k = 0, -1, +1, -2, +2, ... */
        int32_t k = (j + 1) / 2 * (j % 2 ? -1 : 1), s = 256 + k * cfg->scale_step_q8;
        for (i = 0; i < tpl->n; ++i) {
            /* |x - ax| < 2^16 (int16 points, bounded box): the result fits int16 for
             * s <= 2 (256 + 8 * 64 = 768 < 2^10): clamp keeps it defined anyway. */
            int32_t u = ax + vt__scale(tpl->x[i] - ax, s), v = ay + vt__scale(tpl->y[i] - ay, s);
            sx[i] = (int16_t)vt__clamp_i32(u, -32768, 32767);
            sy[i] = (int16_t)vt__clamp_i32(v, -32768, 32767);
        }
        for (ddy = cy - cfg->radius; ddy <= cy + cfg->radius; ++ddy) {
            for (ddx = cx - cfg->radius; ddx <= cx + cfg->radius; ++ddx) {
                int32_t sum = 0; /* <= 1000 * 4096 */
                /* Terms are >= 0: once the partial sum reaches the best, this
                 * displacement cannot win (strictly smaller wins), so stop early;
                 * the result is the full search's. */
                for (i = 0; i < tpl->n && (best < 0 || sum < best); ++i) {
                    int32_t x = sx[i] + ddx - ws->x0, y = sy[i] + ddy - ws->y0;
                    int32_t d = cfg->trunc;
                    if (x >= 0 && y >= 0 && x < ws->w && y < ws->h) {
                        int32_t v = ws->u.dt[y * ws->w + x];
                        d = v < d ? v : d;
                    }
                    sum += d;
                }
                if (best < 0 || sum < best) {
                    best = sum;
                    bx = ddx;
                    by = ddy;
                    bs = s;
                }
            }
        }
    }
    *dx = bx;
    *dy = by;
    *scale_q8 = bs;
    *score = best;
    *found = (tpl->n >= cfg->min_points &&
              (int64_t)best * 256 <= (int64_t)cfg->max_mean_q8 * tpl->n) ? 1 : 0;
    return VT_OK;
}
