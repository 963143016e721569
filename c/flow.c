/* flow.c -- overtaking vehicles by SAD block-matching flow in the lateral areas
 * (IVVI paper, sec. 3: "block similarity ... sum of absolute differences",
 * filtered by range, direction and blob size, computed only where the frame
 * difference exceeds a threshold; the reverse hand-over of sec. 3's last
 * paragraph). Contract, conventions and costs in vehtrack/flow.h. */
#include <string.h>

#include "vehtrack/flow.h"
#include "internal.h"

vt_status vt_flow_cfg_default(vt_flow_cfg *cfg)
{
    static const vt_flow_cfg def = VT_FLOW_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

static int vt__in(int32_t v, int32_t lo, int32_t hi)
{
    return v >= lo && v <= hi;
}

vt_status vt_flow_cfg_check(const vt_flow_cfg *c)
{
    if (c == NULL) {
        return VT_E_ARG;
    }
    if (!vt__in(c->level, 0, 2) || !vt__in(c->sides, 1, 3) || !vt__in(c->strip_permille, 1, 500) ||
        !vt__in(c->top_permille, 0, 999) || !vt__in(c->bottom_permille, c->top_permille + 1, 1000) ||
        !vt__in(c->cell, 2, 32) || !vt__in(c->search_x, 0, 32) || !vt__in(c->search_y, 0, 32) ||
        !vt__in(c->diff_thresh, 0, 255) || !vt__in(c->diff_min_permille, 0, 1000) ||
        !vt__in(c->min_inward, 0, 64) || !vt__in(c->max_mag, 0, 128) ||
        !vt__in(c->max_sad_per_px, 0, 255) || !vt__in(c->min_blob_cells, 1, VT_FLOW_MAX_CELLS) ||
        !vt__in(c->seed_min_visible_permille, 0, 1000) || !vt__in(c->min_texture, 0, 255) ||
        !vt__in(c->min_age, 1, 1000) ||
        !vt__in(c->back_tol, -1, 32)) {
        return VT_E_ARG;
    }
    return VT_OK;
}

vt_status vt_flow_init(vt_flow_state *st)
{
    if (st == NULL) {
        return VT_E_ARG;
    }
    /* Only the bookkeeping is cleared: the image and cell buffers are written
     * before they are read (for the images: only the recorded rectangles are
     * read, see vt_flow_step), and clearing 1.8 MB per init would cost for nothing. */
    st->have_prev = 0;
    st->prev_index = 0;
    st->w = st->h = st->lw = st->lh = 0;
    st->level = 0;
    st->next_id = 1;
    st->gw[0] = st->gw[1] = st->gh[0] = st->gh[1] = 0;
    st->x0[0] = st->x0[1] = st->y0[0] = st->y0[1] = 0;
    st->n_blobs[0] = st->n_blobs[1] = 0;
    st->n_rect[0] = st->n_rect[1] = 0;
    memset(st->seeds, 0, sizeof st->seeds);
    return VT_OK;
}

vt_status vt_flow_reset(vt_flow_state *st)
{
    if (st == NULL) {
        return VT_E_ARG;
    }
    st->have_prev = 0;
    st->gw[0] = st->gw[1] = st->gh[0] = st->gh[1] = 0;
    st->n_blobs[0] = st->n_blobs[1] = 0;
    st->n_rect[0] = st->n_rect[1] = 0;
    memset(st->seeds, 0, sizeof st->seeds);
    return VT_OK;
}

static int32_t vt__imin(int32_t a, int32_t b)
{
    return a < b ? a : b;
}

/* Level-image size of a w x h frame: each vt_pyr_down step gives (n + 1) / 2. */
static void vt__level_size(int32_t w, int32_t h, int32_t level, int32_t *lw, int32_t *lh)
{
    int32_t i;
    for (i = 0; i < level; i++) {
        w = (w + 1) / 2;
        h = (h + 1) / 2;
    }
    *lw = w;
    *lh = h;
}

/* Lateral area `side` (0 left, 1 right) of an lw x lh level image, in cells. */
static void vt__area(const vt_flow_cfg *cfg, int32_t lw, int32_t lh, int32_t side, int32_t *x0,
                     int32_t *y0, int32_t *gw, int32_t *gh)
{
    /* floor(l * permille / 1000): the old percent values x 10 give the same rows */
    int32_t sw = lw * cfg->strip_permille / 1000;
    int32_t ya = lh * cfg->top_permille / 1000;
    int32_t yb = lh * cfg->bottom_permille / 1000;
    *gw = sw / cfg->cell;
    *gh = (yb - ya) / cfg->cell;
    *y0 = ya;
    /* The right area's cells are flush with the right border, where vehicles enter. */
    *x0 = side == 0 ? 0 : lw - *gw * cfg->cell;
}

/* SAD of the n x n block at a (stride as) and at b (stride bs), at most
 * 32 * 32 * 255 < 2^18: exact in uint32. Rows stop once the sum reaches `bound`
 * (the best so far): such a candidate cannot win the strict comparison, so the
 * result of the search is the same as with full sums, for far less work. */
static uint32_t vt__sad(const uint8_t *a, int32_t as, const uint8_t *b, int32_t bs, int32_t n,
                        uint32_t bound)
{
    uint32_t s = 0;
    int32_t y, x;
    for (y = 0; y < n && s < bound; y++) {
        const uint8_t *pa = a + (size_t)y * (size_t)as;
        const uint8_t *pb = b + (size_t)y * (size_t)bs;
        for (x = 0; x < n; x++) {
            int32_t d = (int32_t)pa[x] - (int32_t)pb[x];
            s += (uint32_t)(d < 0 ? -d : d);
        }
    }
    return s;
}

/* Best displacement of the n x n block of `a` at (x, y) in `b` (both lw x lh,
 * stride lw): the block of b at (x - dx, y - dy) with the smallest SAD; (0, 0)
 * first, then dy outer, dx inner, strict improvement; candidates leaving b are
 * skipped. (x, y) must be a block inside a, so (0, 0) is always a candidate.
 * Successive elimination: |sum(block a) - sum(block b)| <= SAD(a, b), so a
 * candidate whose block sum differs from the cell's by at least the best SAD so far
 * cannot win the strict comparison and is not matched: the result is the same as
 * the exhaustive search's. The candidates' block sums come from one row of column
 * sums over n rows (<= 32 * 255, uint16), slid down one row per dy and along the
 * row per dx; both read only pixels of the candidate blocks. Sums <= 32^2 * 255 <
 * 2^18: exact in uint32. */
static void vt__search(const uint8_t *a, const uint8_t *b, int32_t lw, int32_t lh, int32_t x,
                       int32_t y, int32_t n, int32_t sx, int32_t sy, int32_t *bdx, int32_t *bdy,
                       uint32_t *bsad)
{
    const uint8_t *pa = a + (size_t)y * (size_t)lw + (size_t)x;
    uint32_t best = vt__sad(pa, lw, b + (size_t)y * (size_t)lw + (size_t)x, lw, n, UINT32_MAX);
    /* The candidate blocks' corners: bx in [cx0, cx1], by in [cy0, cy1]. */
    const int32_t cx0 = vt__max_i32(0, x - sx), cx1 = vt__imin(lw - n, x + sx);
    const int32_t cy0 = vt__max_i32(0, y - sy), cy1 = vt__imin(lh - n, y + sy);
    const int32_t cw = cx1 + n - cx0; /* <= 2 * 32 + 32 columns */
    uint16_t cs[3 * 32];
    uint32_t sa = 0;
    int32_t rx = 0, ry = 0, bx, by, c, j;
    for (j = 0; j < n && best > 0; j++) {
        const uint8_t *p = pa + (size_t)j * (size_t)lw;
        for (c = 0; c < n; c++) {
            sa += p[c];
        }
    }
    /* dy = y - by runs from -sy up, so by from cy1 down; likewise bx. */
    for (by = cy1; by >= cy0 && best > 0; by--) {
        const uint8_t *top = b + (size_t)by * (size_t)lw + (size_t)cx0;
        uint32_t sb = 0;
        if (by == cy1) {
            for (c = 0; c < cw; c++) {
                uint32_t t = 0;
                for (j = 0; j < n; j++) {
                    t += top[(size_t)j * (size_t)lw + (size_t)c];
                }
                cs[c] = (uint16_t)t;
            }
        } else {
            const uint8_t *gone = top + (size_t)n * (size_t)lw;
            for (c = 0; c < cw; c++) {
                cs[c] = (uint16_t)(cs[c] + top[c] - gone[c]);
            }
        }
        for (c = cx1 - cx0; c < cw; c++) {
            sb += cs[c];
        }
        for (bx = cx1; bx >= cx0; bx--) {
            uint32_t s, d;
            if (bx < cx1) {
                sb = sb + cs[bx - cx0] - cs[bx - cx0 + n];
            }
            if (bx == x && by == y) {
                continue;
            }
            d = sa > sb ? sa - sb : sb - sa;
            if (d >= best) {
                continue;
            }
            s = vt__sad(pa, lw, b + (size_t)by * (size_t)lw + (size_t)bx, lw, n, best);
            if (s < best) {
                best = s;
                rx = x - bx;
                ry = y - by;
            }
        }
    }
    *bdx = rx;
    *bdy = ry;
    *bsad = best;
}

/* Pixels of the n x n block at (x, y) whose absolute change exceeds thr. */
static int32_t vt__changed(const uint8_t *a, const uint8_t *b, int32_t lw, int32_t x, int32_t y,
                           int32_t n, int32_t thr)
{
    int32_t cnt = 0, i, j;
    for (j = 0; j < n; j++) {
        const uint8_t *pa = a + (size_t)(y + j) * (size_t)lw + (size_t)x;
        const uint8_t *pb = b + (size_t)(y + j) * (size_t)lw + (size_t)x;
        for (i = 0; i < n; i++) {
            int32_t d = (int32_t)pa[i] - (int32_t)pb[i];
            cnt += (d > thr || d < -thr) ? 1 : 0;
        }
    }
    return cnt;
}

/* Sum of |I(x+1) - I(x)| over the pairs inside the n x n block at (x, y):
 * at most 32 * 31 * 255, exact. */
static int32_t vt__texture(const uint8_t *a, int32_t lw, int32_t x, int32_t y, int32_t n)
{
    int32_t s = 0, i, j;
    for (j = 0; j < n; j++) {
        const uint8_t *p = a + (size_t)(y + j) * (size_t)lw + (size_t)x;
        for (i = 0; i + 1 < n; i++) {
            int32_t d = (int32_t)p[i + 1] - (int32_t)p[i];
            s += d < 0 ? -d : d;
        }
    }
    return s;
}

/* Forward-backward check: the previous frame's block the cell matched, searched
 * back in the current frame, must land on the cell within back_tol px (a match
 * in repetitive or changing texture, such as foliage, usually does not). */
static int vt__consistent(const vt_flow_cfg *cfg, const uint8_t *cur, const uint8_t *prev,
                          int32_t lw, int32_t lh, int32_t x, int32_t y, int32_t dx, int32_t dy)
{
    int32_t rdx = 0, rdy = 0;
    uint32_t s = 0;
    if (cfg->back_tol < 0) {
        return 1;
    }
    vt__search(prev, cur, lw, lh, x - dx, y - dy, cfg->cell, cfg->search_x, cfg->search_y, &rdx,
               &rdy, &s);
    return vt__abs_i32(rdx + dx) <= cfg->back_tol && vt__abs_i32(rdy + dy) <= cfg->back_tol;
}

/* Union-find with path halving; roots are the smallest cell index of their set. */
static int32_t vt__find(int32_t *parent, int32_t i)
{
    while (parent[i] != i) {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    return i;
}

static void vt__union(int32_t *parent, int32_t a, int32_t b)
{
    int32_t ra = vt__find(parent, a);
    int32_t rb = vt__find(parent, b);
    if (ra < rb) {
        parent[rb] = ra;
    } else if (rb < ra) {
        parent[ra] = rb;
    }
}

/* floor(n / 2^k) for k in 0..2 without shifting a negative value. */
static int32_t vt__floor_shift(int32_t n, int32_t k)
{
    int32_t d = (int32_t)1 << k;
    return n >= 0 ? n / d : -((-n + d - 1) / d);
}

/* Mean of `sum` over `n` in input px, Q16: sum * 2^level * 65536 / n, rounded
 * half away from zero. |sum| <= 32 * VT_FLOW_MAX_CELLS < 2^25, so the product
 * stays < 2^43 in int64; the mean is <= 128 px, well inside Q15.16. */
static vt_q16 vt__mean_q16(int32_t sum, int32_t n, int32_t level)
{
    int64_t q = 0;
    (void)vt_div_round_s64((int64_t)sum * ((int64_t)65536 << level), (int64_t)n, &q);
    return (vt_q16)q;
}

/* Cells, vectors and blobs of one lateral area; appends hypotheses to *out. */
static void vt__area_flow(vt_flow_state *st, const vt_flow_cfg *cfg, int32_t side,
                          const uint8_t *cur, const uint8_t *prev, vt_flow_result *out)
{
    const int32_t gw = st->gw[side], gh = st->gh[side], n = cfg->cell;
    const int32_t x0 = st->x0[side], y0 = st->y0[side], lw = st->lw, lh = st->lh;
    const int32_t inward = side == 0 ? 1 : -1;
    const int32_t need = cfg->diff_min_permille * n * n; /* compared with 1000 * count */
    const uint32_t max_sad = (uint32_t)(cfg->max_sad_per_px * n * n);
    int8_t *vdx = st->dx + side * VT_FLOW_MAX_CELLS;
    int8_t *vdy = st->dy + side * VT_FLOW_MAX_CELLS;
    uint8_t *flag = st->flag + side * VT_FLOW_MAX_CELLS;
    uint32_t *vsad = st->sad + side * VT_FLOW_MAX_CELLS;
    int32_t *parent = st->parent;
    int32_t *count = st->count;
    int32_t nb = 0;
    int32_t sum_dx[VT_FLOW_MAX_BLOBS], sum_dy[VT_FLOW_MAX_BLOBS], sum_j[VT_FLOW_MAX_BLOBS];
    vt_flow_hyp blob[VT_FLOW_MAX_BLOBS];
    int32_t i, j, k;

    for (j = 0; j < gh; j++) {
        for (i = 0; i < gw; i++) {
            const int32_t c = j * gw + i, x = x0 + i * n, y = y0 + j * n;
            int32_t dx = 0, dy = 0, mag;
            uint32_t s = 0;
            flag[c] = 0;
            vdx[c] = 0;
            vdy[c] = 0;
            vsad[c] = 0;
            parent[c] = c;
            count[c] = 0;
            out->cells_total++;
            /* The paper's speed-up: no search where (almost) nothing changed. */
            if (1000 * vt__changed(cur, prev, lw, x, y, n, cfg->diff_thresh) < need) {
                continue;
            }
            /* Without horizontal texture the best dx is arbitrary (aperture problem):
             * the flat band under a car would pass the direction filter by chance. */
            if (vt__texture(cur, lw, x, y, n) < cfg->min_texture * n * (n - 1)) {
                flag[c] = VT_FLOW_CELL_FLAT;
                continue;
            }
            vt__search(cur, prev, lw, lh, x, y, n, cfg->search_x, cfg->search_y, &dx, &dy, &s);
            flag[c] = VT_FLOW_CELL_COMPUTED;
            vdx[c] = (int8_t)dx;
            vdy[c] = (int8_t)dy;
            vsad[c] = s;
            out->cells_computed++;
            mag = vt__abs_i32(dx) + vt__abs_i32(dy);
            /* Range rejects noise (too small) and mismatches (too large); direction
             * rejects the background, which flows outward as the ego car passes it. */
            if (s <= max_sad && inward * dx >= cfg->min_inward && mag <= cfg->max_mag &&
                vt__consistent(cfg, cur, prev, lw, lh, x, y, dx, dy)) {
                flag[c] |= VT_FLOW_CELL_ACCEPTED;
                out->cells_accepted++;
                if (i > 0 && (flag[c - 1] & VT_FLOW_CELL_ACCEPTED)) {
                    vt__union(parent, c, c - 1);
                }
                if (j > 0 && (flag[c - gw] & VT_FLOW_CELL_ACCEPTED)) {
                    vt__union(parent, c, c - gw);
                }
                /* 8-connected: the two upper diagonal neighbours too (flow.h). */
                if (j > 0 && i > 0 && (flag[c - gw - 1] & VT_FLOW_CELL_ACCEPTED)) {
                    vt__union(parent, c, c - gw - 1);
                }
                if (j > 0 && i + 1 < gw && (flag[c - gw + 1] & VT_FLOW_CELL_ACCEPTED)) {
                    vt__union(parent, c, c - gw + 1);
                }
            }
        }
    }
    for (k = 0; k < gw * gh; k++) {
        if (flag[k] & VT_FLOW_CELL_ACCEPTED) {
            count[vt__find(parent, k)]++;
        }
    }
    /* Blobs over the area threshold get a slot in the order of their first cell
     * (their root); count[root] becomes -(slot + 1), small blobs 0. */
    for (k = 0; k < gw * gh; k++) {
        if (!(flag[k] & VT_FLOW_CELL_ACCEPTED) || parent[k] != k) {
            continue;
        }
        if (count[k] < cfg->min_blob_cells) {
            count[k] = 0;
        } else if (nb >= VT_FLOW_MAX_BLOBS) {
            out->dropped++;
            count[k] = 0;
        } else {
            vt_flow_hyp *hp = &blob[nb];
            hp->box.left = hp->box.top = INT32_MAX;
            hp->box.right = hp->box.bottom = -1;
            hp->side = side == 0 ? VT_FLOW_SIDE_LEFT : VT_FLOW_SIDE_RIGHT;
            hp->kind = VT_FLOW_KIND_OVERTAKING;
            hp->id = 0;
            hp->cells = 0;
            sum_dx[nb] = sum_dy[nb] = sum_j[nb] = 0;
            nb++;
            count[k] = -nb;
        }
    }
    for (k = 0; k < gw * gh && nb > 0; k++) {
        int32_t r, slot;
        vt_flow_hyp *hp;
        if (!(flag[k] & VT_FLOW_CELL_ACCEPTED)) {
            continue;
        }
        r = vt__find(parent, k);
        if (count[r] >= 0) {
            continue;
        }
        slot = -count[r] - 1;
        hp = &blob[slot];
        i = k % gw;
        j = k / gw;
        /* Box in cells for now; converted to input pixels below. */
        hp->box.left = i < hp->box.left ? i : hp->box.left;
        hp->box.right = i > hp->box.right ? i : hp->box.right;
        hp->box.top = j < hp->box.top ? j : hp->box.top;
        hp->box.bottom = j > hp->box.bottom ? j : hp->box.bottom;
        hp->cells++;
        sum_dx[slot] += vdx[k];
        sum_dy[slot] += vdy[k];
        sum_j[slot] += j;
    }
    for (k = 0; k < nb; k++) {
        vt_flow_hyp *hp = &blob[k];
        const int32_t lv = st->level;
        int32_t q, age = 0;
        hp->box.left = (x0 + hp->box.left * n) << lv;
        hp->box.top = (y0 + hp->box.top * n) << lv;
        hp->box.right = vt__clamp_i32(((x0 + (hp->box.right + 1) * n) << lv) - 1, 0, st->w - 1);
        hp->box.bottom = vt__clamp_i32(((y0 + (hp->box.bottom + 1) * n) << lv) - 1, 0, st->h - 1);
        hp->flow_x = vt__mean_q16(sum_dx[k], hp->cells, lv);
        hp->flow_y = vt__mean_q16(sum_dy[k], hp->cells, lv);
        /* Row of the blob's centre of gravity (cell centres), truncated. */
        hp->cy = (y0 + n * (2 * sum_j[k] + hp->cells) / (2 * hp->cells)) << lv;
        /* Persistence: a vehicle's blob overlaps one of the previous frame's;
         * texture that matches by chance (foliage, glare) rarely does twice. */
        for (q = 0; q < st->n_blobs[side]; q++) {
            const vt_box *pb = &st->blob_box[side * VT_FLOW_MAX_BLOBS + q];
            if (pb->left <= hp->box.right && hp->box.left <= pb->right &&
                pb->top <= hp->box.bottom && hp->box.top <= pb->bottom) {
                age = vt__max_i32(age, st->blob_age[side * VT_FLOW_MAX_BLOBS + q]);
            }
        }
        hp->age = age < INT32_MAX ? age + 1 : age;
    }
    for (k = 0; k < nb; k++) {
        st->blob_box[side * VT_FLOW_MAX_BLOBS + k] = blob[k].box;
        st->blob_age[side * VT_FLOW_MAX_BLOBS + k] = blob[k].age;
        if (blob[k].age < cfg->min_age) {
            continue;
        }
        if (out->n < VT_FLOW_MAX_HYPS) {
            out->hyp[out->n++] = blob[k];
        } else {
            out->dropped++;
        }
    }
    st->n_blobs[side] = nb;
}

/* The level-px span of a hand-over track's box, clamped to the lw x lh level image:
 * b = {bx0, by0, bx1, by1}, half-open; its cells are the whole cells from (bx0, by0). */
static void vt__seed_span(const vt_flow_state *st, const vt_flow_seed_track *sd, int32_t b[4])
{
    const int32_t lv = st->level;
    const int32_t left = vt_q16_round(sd->left), top = vt_q16_round(sd->top);
    b[0] = vt__clamp_i32(vt__floor_shift(left, lv), 0, st->lw);
    b[1] = vt__clamp_i32(vt__floor_shift(top, lv), 0, st->lh);
    b[2] = vt__clamp_i32(vt__floor_shift(left + sd->width - 1, lv) + 1, 0, st->lw);
    b[3] = vt__clamp_i32(vt__floor_shift(top + sd->height - 1, lv) + 1, 0, st->lh);
}

/* 1 when the n x n block at (x, y) lies inside one rectangle recorded as computed
 * for level image idx. */
static int vt__computed(const vt_flow_state *st, int32_t idx, int32_t x, int32_t y, int32_t n)
{
    int32_t k;
    for (k = 0; k < st->n_rect[idx]; k++) {
        const int32_t *r = st->rect[idx][k];
        if (x >= r[0] && y >= r[1] && x + n <= r[2] && y + n <= r[3]) {
            return 1;
        }
    }
    return 0;
}

/* 1 when the rectangle r (level px, half-open) lies inside one rectangle recorded
 * for level image idx. */
static int vt__computed_rect(const vt_flow_state *st, int32_t idx, const int32_t r[4])
{
    int32_t k;
    for (k = 0; k < st->n_rect[idx]; k++) {
        const int32_t *q = st->rect[idx][k];
        if (r[0] >= q[0] && r[1] >= q[1] && r[2] <= q[2] && r[3] <= q[3]) {
            return 1;
        }
    }
    return 0;
}

/* Computes level image idx (lw x lh, level lv) over the level-px rectangle
 * [x0, x1) x [y0, y1) from the input frame. Level 0 copies; level 1 is one
 * vt_pyr_down_rect; level 2 first computes the level-1 pixels that rectangle reads
 * (columns max(0, 2 x0 - 2) .. min(w1, 2 x1 + 1), rows likewise: see vt__pyr_rect in
 * image.c) into the scratch, then the level-2 rectangle from them. */
static vt_status vt__level_rect(vt_flow_state *st, int32_t lv, int32_t idx, const vt_image_u8 *frame,
                                int32_t lw, int32_t lh, int32_t x0, int32_t y0, int32_t x1,
                                int32_t y1)
{
    vt_image_u8_mut d;
    vt_image_u8 src;
    vt_status s;
    int32_t y;
    d.px = st->img[idx];
    d.w = lw;
    d.h = lh;
    d.stride = lw;
    if (lv == 0) {
        for (y = y0; y < y1; y++) {
            memcpy(d.px + (size_t)y * (size_t)lw + (size_t)x0,
                   frame->px + (size_t)y * (size_t)frame->stride + (size_t)x0, (size_t)(x1 - x0));
        }
        return VT_OK;
    }
    if (lv == 1) {
        return vt_pyr_down_rect(frame, &d, x0, y0, x1, y1);
    }
    src.px = st->scratch;
    vt__level_size(frame->w, frame->h, 1, &src.w, &src.h);
    src.stride = src.w;
    {
        vt_image_u8_mut sc;
        sc.px = st->scratch;
        sc.w = src.w;
        sc.h = src.h;
        sc.stride = src.w;
        s = vt_pyr_down_rect(frame, &sc, x0 > 1 ? 2 * x0 - 2 : 0, y0 > 1 ? 2 * y0 - 2 : 0,
                             vt__imin(2 * x1 + 1, src.w), vt__imin(2 * y1 + 1, src.h));
    }
    return s != VT_OK ? s : vt_pyr_down_rect(&src, &d, x0, y0, x1, y1);
}

/* Clips [x0, x1) x [y0, y1) to the lw x lh level image; a non-empty result is
 * recorded for image idx (appended; with VT_FLOW_MAX_RECTS recorded, merged into the
 * last one, which becomes the bounding box of both) and computed from the frame. */
static vt_status vt__add_rect(vt_flow_state *st, int32_t lv, int32_t idx, const vt_image_u8 *frame,
                              int32_t lw, int32_t lh, int32_t x0, int32_t y0, int32_t x1, int32_t y1)
{
    int32_t *r;
    x0 = vt__clamp_i32(x0, 0, lw);
    x1 = vt__clamp_i32(x1, 0, lw);
    y0 = vt__clamp_i32(y0, 0, lh);
    y1 = vt__clamp_i32(y1, 0, lh);
    if (x0 >= x1 || y0 >= y1) {
        return VT_OK;
    }
    if (st->n_rect[idx] < VT_FLOW_MAX_RECTS) {
        r = st->rect[idx][st->n_rect[idx]++];
        r[0] = x0;
        r[1] = y0;
        r[2] = x1;
        r[3] = y1;
    } else {
        r = st->rect[idx][VT_FLOW_MAX_RECTS - 1];
        r[0] = vt__imin(r[0], x0);
        r[1] = vt__imin(r[1], y0);
        r[2] = vt__max_i32(r[2], x1);
        r[3] = vt__max_i32(r[3], y1);
    }
    return vt__level_rect(st, lv, idx, frame, lw, lh, r[0], r[1], r[2], r[3]);
}

/* The rectangle of lateral area `side` that a step reads in both level images:
 * its cells widened by 2 search_x / 2 search_y (the search reads the previous image
 * up to one search range beyond a cell, the backward check the current one up to
 * two); not clipped. */
static void vt__area_rect(const vt_flow_cfg *cfg, int32_t x0, int32_t y0, int32_t gw, int32_t gh,
                          int32_t r[4])
{
    r[0] = x0 - 2 * cfg->search_x;
    r[1] = y0 - 2 * cfg->search_y;
    r[2] = x0 + gw * cfg->cell + 2 * cfg->search_x;
    r[3] = y0 + gh * cfg->cell + 2 * cfg->search_y;
}

/* Moves one hand-over track by the mean vector of the textured cells inside its
 * box (searched from the previous frame into the current one); returns 0 when the
 * track ends (no textured cell, no match, or too little of it left in the frame). */
static int vt__seed_step(vt_flow_state *st, const vt_flow_cfg *cfg, vt_flow_seed_track *sd,
                         const uint8_t *cur, const uint8_t *prev, vt_flow_hyp *hp)
{
    const int32_t lv = st->level, n = cfg->cell, lw = st->lw, lh = st->lh;
    const uint32_t max_sad = (uint32_t)(cfg->max_sad_per_px * n * n);
    int32_t left, top, b[4], bx0, by0;
    int32_t gw, gh, i, j, cnt = 0, sdx = 0, sdy = 0, vis;
    vt_q16 mx, my;
    vt__seed_span(st, sd, b);
    bx0 = b[0];
    by0 = b[1];
    gw = (b[2] - bx0) / n;
    gh = (b[3] - by0) / n;
    for (j = 0; j < gh; j++) {
        for (i = 0; i < gw; i++) {
            int32_t dx = 0, dy = 0;
            uint32_t s = 0;
            /* Only the computed parts of the previous level image hold that frame: a
             * track seeded (vt_flow_seed) where the last step computed nothing is
             * followed from the cells that were computed, and from all of them from its
             * second step on (its own rectangle below covers where it moves). */
            if (!vt__computed(st, st->prev_index, bx0 + i * n, by0 + j * n, n)) {
                continue;
            }
            /* A flat cell (a uniform car body, the road once the car has left) matches
             * at zero motion whatever moved (the aperture problem, as in the areas): it
             * would hold the box back, and on bare road keep it forever. */
            if (vt__texture(prev, lw, bx0 + i * n, by0 + j * n, n) < cfg->min_texture * n * (n - 1)) {
                continue;
            }
            /* The box is known in the previous frame, so its cells are searched in
             * the current one; the motion is the opposite of that displacement. */
            vt__search(prev, cur, lw, lh, bx0 + i * n, by0 + j * n, n, cfg->search_x,
                       cfg->search_y, &dx, &dy, &s);
            if (s <= max_sad) {
                sdx -= dx;
                sdy -= dy;
                cnt++;
            }
        }
    }
    if (cnt == 0) {
        return 0;
    }
    mx = vt__mean_q16(sdx, cnt, lv);
    my = vt__mean_q16(sdy, cnt, lv);
    sd->left = vt_q16_add_sat(sd->left, mx);
    sd->top = vt_q16_add_sat(sd->top, my);
    left = vt_q16_round(sd->left);
    top = vt_q16_round(sd->top);
    vis = vt__clamp_i32(left + sd->width, 0, st->w) - vt__clamp_i32(left, 0, st->w);
    if ((int64_t)vis * 1000 < (int64_t)cfg->seed_min_visible_permille * sd->width || vis <= 0 ||
        top >= st->h || top + sd->height <= 0) {
        return 0;
    }
    hp->box.left = vt__clamp_i32(left, 0, st->w - 1);
    hp->box.right = vt__clamp_i32(left + sd->width - 1, 0, st->w - 1);
    hp->box.top = vt__clamp_i32(top, 0, st->h - 1);
    hp->box.bottom = vt__clamp_i32(top + sd->height - 1, 0, st->h - 1);
    hp->side = 2 * (hp->box.left + hp->box.right) < 2 * (st->w - 1) ? VT_FLOW_SIDE_LEFT
                                                                    : VT_FLOW_SIDE_RIGHT;
    hp->kind = VT_FLOW_KIND_HANDOVER;
    hp->cy = (hp->box.top + hp->box.bottom) / 2;
    hp->id = sd->id;
    hp->age = ++sd->age;
    hp->cells = cnt;
    hp->flow_x = mx;
    hp->flow_y = my;
    return 1;
}

vt_status vt_flow_step(vt_flow_state *st, const vt_flow_cfg *cfg, const vt_image_u8 *frame,
                       vt_flow_result *out)
{
    vt_status s;
    int32_t lw, lh, cur_i, side, k, restart, r[4];
    int32_t ax0[2], ay0[2], agw[2], agh[2];
    uint8_t *cur;
    if (out != NULL) {
        memset(out, 0, sizeof *out);
    }
    if (st == NULL || out == NULL || vt_flow_cfg_check(cfg) != VT_OK) {
        return VT_E_ARG;
    }
    s = vt_image_u8_check(frame);
    if (s != VT_OK) {
        return s;
    }
    if (st->have_prev && (frame->w != st->w || frame->h != st->h)) {
        return VT_E_SIZE;
    }
    /* Level 2 passes through the level-1 scratch, which must fit as well. */
    vt__level_size(frame->w, frame->h, cfg->level < 1 ? cfg->level : 1, &lw, &lh);
    if ((int64_t)lw * lh > VT_FLOW_MAX_PIXELS) {
        return VT_E_CAPACITY;
    }
    vt__level_size(frame->w, frame->h, cfg->level, &lw, &lh);
    for (side = 0; side < 2; side++) {
        vt__area(cfg, lw, lh, side, &ax0[side], &ay0[side], &agw[side], &agh[side]);
        if (!(cfg->sides & (1 << side))) {
            agw[side] = agh[side] = 0;
        }
        if ((int64_t)agw[side] * agh[side] > VT_FLOW_MAX_CELLS) {
            return VT_E_CAPACITY;
        }
    }

    /* A first frame when there is no previous one, the level changed, or the
     * previous level image was not computed over this frame's areas (a cfg change
     * that widened them): its other pixels are stale or were never written. */
    restart = !st->have_prev || st->level != cfg->level;
    for (side = 0; side < 2 && !restart; side++) {
        if (agw[side] * agh[side] > 0) {
            vt__area_rect(cfg, ax0[side], ay0[side], agw[side], agh[side], r);
            r[0] = vt__clamp_i32(r[0], 0, lw);
            r[1] = vt__clamp_i32(r[1], 0, lh);
            r[2] = vt__clamp_i32(r[2], 0, lw);
            r[3] = vt__clamp_i32(r[3], 0, lh);
            restart = !vt__computed_rect(st, st->prev_index, r);
        }
    }
    cur_i = st->have_prev ? 1 - st->prev_index : st->prev_index;
    cur = st->img[cur_i];
    /* The level image only where this step or the next reads it: the areas with
     * their search margins, and each hand-over track's cells with one search range
     * and 1 px more on each side. A track moves by the mean of its vectors, |m| <=
     * search << level input px, and its rounded position by less than |m| + 1
     * (round half up: floor(a + m + 1/2) - floor(a + 1/2) lies in (m - 1, m + 1)), so
     * by at most `search` level px once floored: next frame's cells, read in this
     * image as the previous one, lie inside that rectangle (the 1 px is slack). */
    st->n_rect[cur_i] = 0;
    s = VT_OK;
    for (side = 0; side < 2 && s == VT_OK; side++) {
        if (agw[side] * agh[side] > 0) {
            vt__area_rect(cfg, ax0[side], ay0[side], agw[side], agh[side], r);
            s = vt__add_rect(st, cfg->level, cur_i, frame, lw, lh, r[0], r[1], r[2], r[3]);
        }
    }
    for (k = 0; k < VT_FLOW_MAX_SEEDS && !restart && s == VT_OK; k++) {
        if (st->seeds[k].active) {
            vt__seed_span(st, &st->seeds[k], r);
            s = vt__add_rect(st, cfg->level, cur_i, frame, lw, lh, r[0] - cfg->search_x - 1,
                             r[1] - cfg->search_y - 1, r[2] + cfg->search_x + 1,
                             r[3] + cfg->search_y + 1);
        }
    }
    if (s != VT_OK) {
        return s;
    }

    if (restart) {
        /* First frame (or a new level): nothing to compare with yet. */
        st->have_prev = 1;
        st->prev_index = cur_i;
        st->w = frame->w;
        st->h = frame->h;
        st->lw = lw;
        st->lh = lh;
        st->level = cfg->level;
        st->gw[0] = st->gw[1] = st->gh[0] = st->gh[1] = 0;
        st->n_blobs[0] = st->n_blobs[1] = 0;
        memset(st->seeds, 0, sizeof st->seeds);
        return VT_OK;
    }
    for (side = 0; side < 2; side++) {
        st->x0[side] = ax0[side];
        st->y0[side] = ay0[side];
        st->gw[side] = agw[side];
        st->gh[side] = agh[side];
    }
    out->ready = 1;
    for (side = 0; side < 2; side++) {
        vt__area_flow(st, cfg, side, cur, st->img[st->prev_index], out);
    }
    for (k = 0; k < VT_FLOW_MAX_SEEDS; k++) {
        vt_flow_seed_track *sd = &st->seeds[k];
        vt_flow_hyp hyp;
        if (!sd->active) {
            continue;
        }
        if (!vt__seed_step(st, cfg, sd, cur, st->img[st->prev_index], &hyp)) {
            sd->active = 0;
        } else if (out->n < VT_FLOW_MAX_HYPS) {
            out->hyp[out->n++] = hyp;
        } else {
            out->dropped++;
        }
    }
    st->prev_index = cur_i;
    return VT_OK;
}

vt_status vt_flow_seed(vt_flow_state *st, const vt_flow_cfg *cfg, const vt_box *box, int32_t *id)
{
    int32_t k;
    if (id != NULL) {
        *id = 0;
    }
    if (st == NULL || box == NULL || id == NULL || vt_flow_cfg_check(cfg) != VT_OK ||
        !st->have_prev) {
        return VT_E_ARG;
    }
    if (box->left > box->right || box->top > box->bottom || box->right < 0 || box->bottom < 0 ||
        box->left >= st->w || box->top >= st->h || box->left < -VT_MAX_WIDTH ||
        box->top < -VT_MAX_HEIGHT || box->right >= 2 * VT_MAX_WIDTH ||
        box->bottom >= 2 * VT_MAX_HEIGHT) {
        return VT_E_ARG;
    }
    for (k = 0; k < VT_FLOW_MAX_SEEDS; k++) {
        vt_flow_seed_track *sd = &st->seeds[k];
        if (sd->active) {
            continue;
        }
        sd->active = 1;
        sd->id = st->next_id;
        st->next_id = st->next_id >= INT32_MAX - 1 ? 1 : st->next_id + 1;
        sd->left = vt_q16_from_int(box->left);
        sd->top = vt_q16_from_int(box->top);
        sd->width = box->right - box->left + 1;
        sd->age = 0;
        sd->height = box->bottom - box->top + 1;
        *id = sd->id;
        return VT_OK;
    }
    return VT_E_CAPACITY;
}

vt_status vt_flow_unseed(vt_flow_state *st, int32_t id)
{
    int32_t k;
    if (st == NULL || id <= 0) {
        return VT_E_ARG;
    }
    for (k = 0; k < VT_FLOW_MAX_SEEDS; k++) {
        if (st->seeds[k].active && st->seeds[k].id == id) {
            st->seeds[k].active = 0;
            return VT_OK;
        }
    }
    return VT_E_ARG;
}

vt_status vt_flow_seed_frame(vt_flow_state *st, const vt_flow_cfg *cfg, const vt_image_u8 *frame,
                             const vt_box *box, int32_t *id)
{
    vt_status s;
    int32_t k, b[4];
    if (id != NULL) {
        *id = 0;
    }
    if (st == NULL || box == NULL || id == NULL || vt_flow_cfg_check(cfg) != VT_OK ||
        !st->have_prev) {
        return VT_E_ARG;
    }
    s = vt_image_u8_check(frame);
    if (s != VT_OK) {
        return s;
    }
    if (frame->w != st->w || frame->h != st->h) {
        return VT_E_SIZE;
    }
    s = vt_flow_seed(st, cfg, box, id);
    if (s != VT_OK) {
        return s;
    }
    for (k = 0; k < VT_FLOW_MAX_SEEDS; k++) {
        if (st->seeds[k].active && st->seeds[k].id == *id) {
            break;
        }
    }
    if (k == VT_FLOW_MAX_SEEDS) {
        return VT_OK; /* not reached: vt_flow_seed just made this track */
    }
    /* The cells its first step reads in this (the previous) level image. */
    vt__seed_span(st, &st->seeds[k], b);
    return vt__add_rect(st, st->level, st->prev_index, frame, st->lw, st->lh, b[0], b[1], b[2], b[3]);
}
