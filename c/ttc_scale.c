/* ttc_scale.c -- time to collision from the scale change of SAD-matched blocks inside
 * a track's box (IVVI paper sec. 4, "TTC from the box's scale change"; measured as the
 * SFND camera TTC does it, from many points: the box edges jitter by +-1 px, which on a
 * 100 px box is as large as the 1 % per-frame scale change of a 10 s TTC at 10 Hz, so
 * the scale is taken as a median over many point pairs and over `lag` frames).
 * Integers only; every rounding is stated in ttc_scale.h. */
#include "vehtrack/ttc_scale.h"
#include <stddef.h>
#include "internal.h"

#define VT__IN(v, lo, hi) ((v) >= (lo) && (v) <= (hi))

vt_status vt_ttc_cfg_default(vt_ttc_cfg *cfg)
{
    static const vt_ttc_cfg def = VT_TTC_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_ttc_cfg_check(const vt_ttc_cfg *c)
{
    if (c == NULL || !VT__IN(c->block, 4, VT_TTC_BLOCK) || !VT__IN(c->grid, 2, VT_TTC_GRID) ||
        !VT__IN(c->margin_permille, 0, 400) || !VT__IN(c->radius, 1, 16) ||
        !VT__IN(c->min_texture, 0, 255) || !VT__IN(c->max_sad, 1, 255) ||
        !VT__IN(c->lag, 1, VT_TTC_HIST - 1) || !VT__IN(c->min_pair_px, 1, 4096) ||
        !VT__IN(c->min_pairs, 1, VT_TTC_MAX_PAIRS) || !VT__IN(c->frame_dt, 1, VT_Q16_ONE) ||
        !VT__IN(c->ttc_max, 1, 1000 * VT_Q16_ONE) ||
        !(c->anchor_radius == 0 || VT__IN(c->anchor_radius, c->radius + 1, 48)) ||
        !VT__IN(c->evict_margin_px, -1, 4096) || !VT__IN(c->prior_gate_permille, -1, 1000) ||
        !VT__IN(c->min_lag, 1, VT_TTC_HIST - 1) || !VT__IN(c->min_match_permille, 0, 1000)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

static void vt__slot_clear(vt_ttc_track *t, int32_t id)
{
    t->id = id;
    t->n_hist = 0;
    t->head = 0;
    t->prior = 0;
}

vt_status vt_ttc_init(vt_ttc_state *st)
{
    int32_t k;
    if (st == NULL) {
        return VT_E_ARG;
    }
    st->img_w = 0;
    st->img_h = 0;
    for (k = 0; k < VT_TTC_TRACKS; k++) {
        vt__slot_clear(&st->t[k], 0);
    }
    return VT_OK;
}

/* n / d rounded half away from zero; d > 0 here. */
static int64_t vt__rdiv(int64_t n, int64_t d)
{
    int64_t q = 0;
    (void)vt_div_round_s64(n, d, &q);
    return q;
}

/* SAD of the stored block against the frame at (x, y) (the block lies inside). Stops
 * after a row once the sum reaches `limit` (the result is then >= limit, which is all a
 * caller keeping only a strictly smaller SAD needs: the search stays exact). */
static int32_t vt__sad(const vt_image_u8 *img, const uint8_t *tm, int32_t b, int32_t x, int32_t y,
                       int32_t limit)
{
    int32_t i, j, s = 0;
    for (j = 0; j < b && s < limit; j++) {
        const uint8_t *p = img->px + (size_t)(y + j) * (size_t)img->stride + (size_t)x;
        for (i = 0; i < b; i++) {
            s += vt__abs_i32((int32_t)p[i] - tm[j * b + i]);
        }
    }
    return s;
}

/* Q8 parabola vertex offset through (-1, sm), (0, s0), (1, sp), clamped to +-1/2. */
static int32_t vt__sub(int32_t sm, int32_t s0, int32_t sp)
{
    int64_t den = (int64_t)sm - 2 * (int64_t)s0 + sp, q;
    if (den <= 0) {
        return 0;
    }
    q = vt__rdiv(((int64_t)sm - sp) * 256, 2 * den);
    return (int32_t)(q > 128 ? 128 : (q < -128 ? -128 : q));
}

/* Integer SAD search of one block over +-r around (px, py): 1 if the best lies inside
 * the window (not on its edge) with SAD <= max_sad per pixel; *bx, *by its offset. */
static int32_t vt__search(const vt_ttc_cfg *c, const vt_image_u8 *img, const uint8_t *tm,
                          int32_t px, int32_t py, int32_t r, int32_t *obx, int32_t *oby,
                          int32_t *obest)
{
    int32_t b = c->block, dx, dy, bx = 0, by = 0, best = -1, s;
    for (dy = -r; dy <= r; dy++) {
        for (dx = -r; dx <= r; dx++) {
            int32_t x = px + dx, y = py + dy;
            if (x < 0 || y < 0 || x > img->w - b || y > img->h - b) {
                continue;
            }
            s = vt__sad(img, tm, b, x, y, best < 0 ? INT32_MAX : best);
            if (best < 0 || s < best) { /* ties: the first in raster order */
                best = s;
                bx = dx;
                by = dy;
            }
        }
    }
    if (best < 0 || bx == -r || bx == r || by == -r || by == r ||
        best > c->max_sad * b * b) {
        return 0;
    }
    *obx = bx;
    *oby = by;
    *obest = best;
    return 1;
}

/* Search one block; *mx, *my in Q8 px. 1 if matched. */
static int32_t vt__match(const vt_ttc_cfg *c, const vt_image_u8 *img, const uint8_t *tm,
                         int32_t px, int32_t py, int32_t *mx, int32_t *my, int32_t *ix, int32_t *iy)
{
    int32_t b = c->block, bx, by, best, sxm, sxp, sym, syp;
    if (!vt__search(c, img, tm, px, py, c->radius, &bx, &by, &best)) {
        return 0;
    }
    /* the four neighbours exist unless the match touches the frame's edge */
    if (px + bx - 1 < 0 || px + bx + 1 > img->w - b || py + by - 1 < 0 ||
        py + by + 1 > img->h - b) {
        return 0;
    }
    sxm = vt__sad(img, tm, b, px + bx - 1, py + by, INT32_MAX);
    sxp = vt__sad(img, tm, b, px + bx + 1, py + by, INT32_MAX);
    sym = vt__sad(img, tm, b, px + bx, py + by - 1, INT32_MAX);
    syp = vt__sad(img, tm, b, px + bx, py + by + 1, INT32_MAX);
    *mx = (px + bx) * 256 + vt__sub(sxm, best, sxp);
    *my = (py + by) * 256 + vt__sub(sym, best, syp);
    *ix = px + bx;
    *iy = py + by;
    return 1;
}

/* Where block (x, y) of old box o lands in new box n: shifted with the box centre and
 * scaled about it by (w + h)_n / (w + h)_o, rounded half away from zero (px). */
static int32_t vt__predict(int32_t x, int32_t b, int32_t lo, int32_t ro, int32_t ln, int32_t rn,
                           int64_t so, int64_t sn)
{
    int64_t co = (int64_t)lo + ro, cn = (int64_t)ln + rn;
    return x + (int32_t)vt__rdiv((cn - co) * so + (2 * (int64_t)x + b - 1 - co) * (sn - so), 2 * so);
}

/* Where block (x, y) lands given the box's extent along one axis then (lo, ro) and now
 * (ln, rn): vt__predict, or with a prior scale (Q16, > 0) in place of the box's size
 * ratio (so = 2^16, sn = prior; |products| < 2^42). */
static int32_t vt__predict_p(int32_t x, int32_t b, int32_t lo, int32_t ro, int32_t ln, int32_t rn,
                             int64_t so, int64_t sn, vt_q16 prior)
{
    if (prior > 0) {
        return vt__predict(x, b, lo, ro, ln, rn, VT_Q16_ONE, prior);
    }
    return vt__predict(x, b, lo, ro, ln, rn, so, sn);
}

/* The k-th smallest of a[0..n-1] (0-based), reordering a (deterministic quickselect). */
static int32_t vt__select(int32_t *a, int32_t n, int32_t k)
{
    int32_t lo = 0, hi = n - 1;
    while (lo < hi) {
        int32_t p = a[lo + (hi - lo) / 2], i = lo, j = hi, t;
        while (i <= j) {
            while (a[i] < p) {
                i++;
            }
            while (a[j] > p) {
                j--;
            }
            if (i <= j) {
                t = a[i];
                a[i] = a[j];
                a[j] = t;
                i++;
                j--;
            }
        }
        if (k <= j) {
            hi = j;
        } else if (k >= i) {
            lo = i;
        } else {
            return a[k];
        }
    }
    return a[k];
}

/* The lower median of a[0..n-1], 1 <= n <= VT_TTC_ANCHORS (insertion sort). */
static int32_t vt__small_median(int32_t *a, int32_t n)
{
    int32_t i, j, t;
    for (i = 1; i < n; i++) {
        for (j = i; j > 0 && a[j - 1] > a[j]; j--) {
            t = a[j];
            a[j] = a[j - 1];
            a[j - 1] = t;
        }
    }
    return a[(n - 1) / 2];
}

/* The lower median of the squared ratios st->pair[0..np-1] (Q16) as a scale: floor(sqrt(
 * median 2^16)), Q16. */
static int64_t vt__median_scale(vt_ttc_state *st, int32_t np)
{
    int64_t med = vt__select(st->pair, np, (np - 1) / 2);
    return (int64_t)vt_isqrt_u64((uint64_t)med << 16);
}

/* Squared ratio of a pair, Q16: d1 (Q16 px^2 or, with q = 0, px^2) over d0 (px^2 >= 1),
 * rounded half away from zero, saturated at 2^31 - 1. */
static int32_t vt__ratio(int64_t d1, int64_t d0)
{
    int64_t r2 = vt__rdiv(d1, d0);
    return (int32_t)(r2 > INT32_MAX ? INT32_MAX : r2);
}

/* The scale ratio of every pair of matched blocks at least min_pair_px apart, into
 * st->pair: new positions (nx, ny) squared and shifted left by sh give Q16 px^2.
 * Returns the number of pairs. */
static int32_t vt__pairs(vt_ttc_state *st, const vt_ttc_entry *e, const int32_t *ok, const int32_t *nx,
                         const int32_t *ny, int32_t sh, int64_t minp2)
{
    int32_t i, j, np = 0;
    for (i = 0; i < e->n; i++) {
        for (j = i + 1; j < e->n; j++) {
            int64_t ax, ay, d0, d1;
            if (!ok[i] || !ok[j]) {
                continue;
            }
            ax = (int64_t)e->x[i] - e->x[j];
            ay = (int64_t)e->y[i] - e->y[j];
            d0 = ax * ax + ay * ay;
            if (d0 < minp2) {
                continue;
            }
            ax = (int64_t)nx[i] - nx[j];
            ay = (int64_t)ny[i] - ny[j];
            d1 = (ax * ax + ay * ay) << sh;
            st->pair[np++] = vt__ratio(d1, d0);
        }
    }
    return np;
}

/* Match the blocks of entry e (lag frames old) in this frame and measure s and the TTC
 * into o. `last` is the track's prior (0: none); with lag == c->lag the track's new
 * prior is set from this measurement (a shorter fallback lag sets none: its scale is
 * not one over c->lag frames). */
static void vt__measure(vt_ttc_state *st, const vt_ttc_cfg *c, int32_t lag, vt_q16 last,
                        const vt_image_u8 *img, vt_ttc_track *t, const vt_ttc_entry *e,
                        const vt_box *nb, vt_ttc_out *o)
{
    int32_t mx[VT_TTC_MAX_BLOCKS], my[VT_TTC_MAX_BLOCKS], ok[VT_TTC_MAX_BLOCKS];
    int32_t ix[VT_TTC_MAX_BLOCKS], iy[VT_TTC_MAX_BLOCKS];
    int32_t anx[VT_TTC_ANCHORS], any[VT_TTC_ANCHORS];
    int32_t i, k, np, na = 0, ox = 0, oy = 0, b = c->block;
    int64_t so = ((int64_t)e->box.right - e->box.left + 1) + ((int64_t)e->box.bottom - e->box.top + 1);
    int64_t sn = ((int64_t)nb->right - nb->left + 1) + ((int64_t)nb->bottom - nb->top + 1);
    int64_t minp2 = (int64_t)c->min_pair_px * c->min_pair_px;
    vt_q16 prior = 0;
    o->blocks = e->n;
    o->lag = lag;
    /* the prior replaces the box's size ratio only where the two disagree by more than
     * the gate: |sn / so - prior| > gate prior / 1000 (products < 2^45) */
    if (c->prior_gate_permille >= 0 && last > 0 && lag == c->lag) {
        int64_t dev = sn * VT_Q16_ONE - (int64_t)last * so;
        if ((dev < 0 ? -dev : dev) * 1000 > (int64_t)c->prior_gate_permille * last * so) {
            prior = last;
        }
    }
    /* anchors: blocks k n / VT_TTC_ANCHORS searched wide; the median of their offsets
     * corrects the box's prediction for all */
    for (k = 0; c->anchor_radius > 0 && k < VT_TTC_ANCHORS && e->n > 0; k++) {
        int32_t bx, by, best;
        i = k * e->n / VT_TTC_ANCHORS;
        if (k > 0 && i == (k - 1) * e->n / VT_TTC_ANCHORS) {
            continue;
        }
        if (vt__search(c, img, e->px[i],
                       vt__predict_p(e->x[i], b, e->box.left, e->box.right, nb->left, nb->right, so, sn,
                                     prior),
                       vt__predict_p(e->y[i], b, e->box.top, e->box.bottom, nb->top, nb->bottom, so, sn,
                                     prior),
                       c->anchor_radius, &bx, &by, &best)) {
            anx[na] = bx;
            any[na] = by;
            na++;
        }
    }
    if (na > 0) {
        ox = vt__small_median(anx, na);
        oy = vt__small_median(any, na);
    }
    for (i = 0; i < e->n; i++) {
        int32_t px = vt__predict_p(e->x[i], b, e->box.left, e->box.right, nb->left, nb->right, so, sn,
                                   prior) + ox;
        int32_t py = vt__predict_p(e->y[i], b, e->box.top, e->box.bottom, nb->top, nb->bottom, so, sn,
                                   prior) + oy;
        ok[i] = vt__match(c, img, e->px[i], px, py, &mx[i], &my[i], &ix[i], &iy[i]);
        o->matched += ok[i];
    }
    /* most blocks lost: the windows were put in the wrong place (a box jump), and what
     * matched inside them is not to be trusted either */
    if ((int64_t)o->matched * 1000 < (int64_t)c->min_match_permille * e->n) {
        return;
    }
    np = vt__pairs(st, e, ok, mx, my, 0, minp2); /* Q8; |.| < 2^24, squares < 2^48: Q16 px^2 */
    o->pairs = np;
    if (np < c->min_pairs) {
        return;
    }
    {
        int64_t s = vt__median_scale(st, np), q;
        o->scale = (vt_q16)s;
        o->flags |= VT_TTC_SCALE_VALID;
        if (s > VT_Q16_ONE) {
            q = vt__rdiv((int64_t)lag * c->frame_dt * VT_Q16_ONE, s - VT_Q16_ONE);
            if (q <= c->ttc_max) {
                o->ttc = (vt_q16)q;
                o->flags |= VT_TTC_VALID;
            }
        }
    }
    /* the prior: the same pairs on integer positions, so the oracle reproduces it exactly
     * (it only steers the next frame's search windows, never the reported scale) */
    np = (c->prior_gate_permille >= 0 && lag == c->lag) ? vt__pairs(st, e, ok, ix, iy, 16, minp2)
                                                        : 0; /* px; squares < 2^32 */
    if (np > 0) {
        /* outside [1/2, 2] it is no guide to where the blocks went: none */
        int64_t s = vt__median_scale(st, np);
        t->prior = (s >= VT_Q16_ONE / 2 && s <= 2 * VT_Q16_ONE) ? (vt_q16)s : 0;
    }
}

/* Store this frame's textured grid blocks of box bx as the track's newest entry. */
static void vt__store(vt_ttc_track *t, const vt_ttc_cfg *c, const vt_image_u8 *img, const vt_box *bx,
                      int32_t inside)
{
    vt_ttc_entry *e = &t->e[t->head];
    int64_t bw = (int64_t)bx->right - bx->left + 1, bh = (int64_t)bx->bottom - bx->top + 1;
    int64_t mw = bw * c->margin_permille / 1000, mh = bh * c->margin_permille / 1000;
    int64_t li = bx->left + mw, ti = bx->top + mh, wi = bw - 2 * mw, hi = bh - 2 * mh;
    int32_t b = c->block, gx, gy, i, j, need = c->min_texture * b * (b - 1);
    e->box = *bx;
    e->n = 0;
    if (inside && wi >= b && hi >= b) {
        for (gy = 0; gy < c->grid; gy++) {
            int64_t y = ti + (hi - b) * gy / (c->grid - 1);
            for (gx = 0; gx < c->grid; gx++) {
                int64_t x = li + (wi - b) * gx / (c->grid - 1);
                int32_t th = 0, tv = 0;
                const uint8_t *p;
                if (x < 0 || y < 0 || x + b > img->w || y + b > img->h) {
                    continue;
                }
                p = img->px + (size_t)y * (size_t)img->stride + (size_t)x;
                for (j = 0; j < b; j++) {
                    for (i = 0; i < b; i++) {
                        int32_t v = p[(size_t)j * (size_t)img->stride + (size_t)i];
                        if (i + 1 < b) {
                            th += vt__abs_i32(p[(size_t)j * (size_t)img->stride + (size_t)i + 1] - v);
                        }
                        if (j + 1 < b) {
                            tv += vt__abs_i32(p[(size_t)(j + 1) * (size_t)img->stride + (size_t)i] - v);
                        }
                        e->px[e->n][j * b + i] = (uint8_t)v;
                    }
                }
                if (th >= need && tv >= need) {
                    e->x[e->n] = (int16_t)x;
                    e->y[e->n] = (int16_t)y;
                    e->n += 1;
                }
            }
        }
    }
    t->head = (t->head + 1) % VT_TTC_HIST;
    if (t->n_hist < VT_TTC_HIST) {
        t->n_hist += 1;
    }
}

/* An output with nothing measured (its id aside). */
static void vt__out_clear(vt_ttc_out *o)
{
    o->flags = 0;
    o->blocks = 0;
    o->matched = 0;
    o->pairs = 0;
    o->scale = 0;
    o->ttc = 0;
    o->lag = 0;
}

/* The slot of id, or NULL. */
static vt_ttc_track *vt__slot_of(vt_ttc_state *st, int32_t id)
{
    int32_t k;
    for (k = 0; k < VT_TTC_TRACKS; k++) {
        if (st->t[k].id == id) {
            return &st->t[k];
        }
    }
    return NULL;
}

/* Priority order of live tracks: larger box bottom first (nearer on a flat road), then
 * the earlier in input order. 1 if track i comes before track j. */
static int32_t vt__before(const vt_track_out *tracks, int32_t i, int32_t j)
{
    return tracks[i].box.bottom > tracks[j].box.bottom ||
           (tracks[i].box.bottom == tracks[j].box.bottom && i < j);
}

/* Give slots to the tracks without one, nearest first (vt_ttc_step's rule). The next
 * candidate is the first, in priority order, after the previous one, so no mark per
 * track is needed; once a candidate gets no slot, no later one can (free slots are
 * gone and every later one is at most as near), which bounds the picks by
 * 2 VT_TTC_TRACKS + 1. Returns 1 if a live track was left without a slot. */
static int32_t vt__assign_nearest(vt_ttc_state *st, const vt_track_out *tracks, int32_t n_tracks,
                                  int32_t margin)
{
    int32_t prev = -1, i, k;
    for (;;) {
        int32_t cand = -1, far_i = -1;
        vt_ttc_track *slot = NULL;
        for (i = 0; i < n_tracks; i++) {
            if (tracks[i].state == VT_TRACK_FREE || vt__slot_of(st, tracks[i].id) != NULL ||
                (prev >= 0 && !vt__before(tracks, prev, i))) {
                continue;
            }
            if (cand < 0 || vt__before(tracks, i, cand)) {
                cand = i;
            }
        }
        if (cand < 0) {
            return 0;
        }
        prev = cand;
        for (k = 0; k < VT_TTC_TRACKS && slot == NULL; k++) {
            if (st->t[k].id == 0) {
                slot = &st->t[k];
            }
        }
        if (slot == NULL) {
            /* the farthest owner: the last in priority order */
            for (i = 0; i < n_tracks; i++) {
                if (tracks[i].state != VT_TRACK_FREE && vt__slot_of(st, tracks[i].id) != NULL &&
                    (far_i < 0 || vt__before(tracks, far_i, i))) {
                    far_i = i;
                }
            }
            if (far_i >= 0 && (int64_t)tracks[cand].box.bottom > (int64_t)tracks[far_i].box.bottom + margin) {
                slot = vt__slot_of(st, tracks[far_i].id);
            }
        }
        if (slot == NULL) {
            return 1;
        }
        vt__slot_clear(slot, tracks[cand].id);
    }
}

vt_status vt_ttc_step(vt_ttc_state *st, const vt_ttc_cfg *cfg, const vt_image_u8 *img,
                      const vt_track_out *tracks, int32_t n_tracks, vt_ttc_out *out,
                      int32_t out_cap, int32_t *n_out)
{
    int32_t i, k, written = 0, full = 0, inside, lag;
    vt_q16 last;
    vt_status s;
    if (st == NULL || n_out == NULL || vt_ttc_cfg_check(cfg) != VT_OK || img == NULL ||
        n_tracks < 0 || (n_tracks > 0 && tracks == NULL) || out_cap < 0 ||
        (out_cap > 0 && out == NULL)) {
        return VT_E_ARG;
    }
    s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    if (img->w > 32767 || img->h > 32767) { /* positions are int16 */
        return VT_E_SIZE;
    }
    if (vt_track_list_check(tracks, n_tracks) != VT_OK) {
        return VT_E_ARG;
    }
    *n_out = 0;
    if (img->w != st->img_w || img->h != st->img_h) { /* another frame size: restart */
        (void)vt_ttc_init(st);
        st->img_w = img->w;
        st->img_h = img->h;
    }
    for (k = 0; k < VT_TTC_TRACKS; k++) {
        int32_t seen = 0;
        for (i = 0; i < n_tracks && !seen && st->t[k].id != 0; i++) {
            seen = tracks[i].state != VT_TRACK_FREE && tracks[i].id == st->t[k].id;
        }
        if (!seen) {
            vt__slot_clear(&st->t[k], 0);
        }
    }
    if (cfg->evict_margin_px >= 0) {
        full = vt__assign_nearest(st, tracks, n_tracks, cfg->evict_margin_px);
    }
    for (i = 0; i < n_tracks; i++) {
        vt_ttc_track *slot = NULL;
        vt_ttc_out o;
        if (tracks[i].state == VT_TRACK_FREE) {
            continue;
        }
        slot = vt__slot_of(st, tracks[i].id);
        for (k = 0; k < VT_TTC_TRACKS && slot == NULL && cfg->evict_margin_px < 0; k++) {
            if (st->t[k].id == 0) {
                slot = &st->t[k];
                vt__slot_clear(slot, tracks[i].id);
            }
        }
        if (slot == NULL) {
            full = 1;
            continue;
        }
        o.id = tracks[i].id;
        vt__out_clear(&o);
        /* a box beyond +-32767 px is neither measured nor stored (keeps every product
         * of vt__predict below 2^40) */
        inside = VT__IN(tracks[i].box.left, -32768, 32767) && VT__IN(tracks[i].box.right, -32768, 32767) &&
                 VT__IN(tracks[i].box.top, -32768, 32767) && VT__IN(tracks[i].box.bottom, -32768, 32767);
        last = slot->prior;
        slot->prior = 0;
        /* the longest lag that measures a scale: lag, else lag - 1 .. min_lag (a young
         * track, or blocks lost over the full lag) */
        for (lag = cfg->lag; inside && (lag == cfg->lag || lag >= cfg->min_lag) &&
                              !(o.flags & VT_TTC_SCALE_VALID);
             lag--) {
            if (slot->n_hist >= lag) {
                vt__out_clear(&o);
                vt__measure(st, cfg, lag, last, img, slot,
                            &slot->e[(slot->head - lag + VT_TTC_HIST) % VT_TTC_HIST], &tracks[i].box, &o);
            }
        }
        vt__store(slot, cfg, img, &tracks[i].box, inside);
        if (written < out_cap) {
            out[written++] = o;
        } else {
            full = 1;
        }
    }
    *n_out = written;
    return full ? VT_E_CAPACITY : VT_OK;
}
