/* fulldet.c -- vehicle detection over the whole road: shadow hypotheses
 * verified by vertical edges (thesis sec. 2.4.2) and flat-road bounded sliding
 * windows on the Gaussian pyramid (IVVI paper sec. 4/5) scored by a classifier
 * (GIST paper sec. III), merged by NMS. Composition only: each step is its own
 * stage (detect.h, windows.h, image.h); see fulldet.h. */
#include <stddef.h>

#include "vehtrack/fulldet.h"
#include "internal.h"

vt_status vt_fulldet_cfg_default(vt_fulldet_cfg *cfg)
{
    static const vt_fulldet_cfg def = VT_FULLDET_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_fulldet_cfg_check(const vt_fulldet_cfg *cfg)
{
    vt_status s;
    if (cfg == NULL) {
        return VT_E_ARG;
    }
    s = vt_win_cfg_check(&cfg->win);
    if (s == VT_OK) {
        s = vt_shadow_cfg_check(&cfg->det.shadow);
    }
    if (s == VT_OK) {
        s = vt_verify_cfg_check(&cfg->det.verify);
    }
    if (s != VT_OK) {
        return s;
    }
    if (cfg->sources < 1 || cfg->sources > 3 || (cfg->edge_check & ~1) != 0 ||
        (cfg->shadow_classify & ~1) != 0 || cfg->nms_iou_permille < 0 ||
        cfg->nms_iou_permille > 1000 || cfg->nms_contain_permille < 0 ||
        cfg->nms_contain_permille > 1000 || cfg->box_height_q8 < 1 || cfg->box_height_q8 > 1024 ||
        cfg->merge_iou_permille < 0 || cfg->merge_iou_permille > 1000 ||
        cfg->rerank_permille < 0 || cfg->rerank_permille > 1000) {
        return VT_E_ARG;
    }
    return VT_OK;
}

/* floor((2 sum + n) / (2 n)), n > 0: the mean rounded half up, for any sign. */
static int32_t vt__mean_round(int64_t sum, int64_t n)
{
    int64_t a = 2 * sum + n, d = 2 * n, q = a / d;
    if ((a % d != 0) && (a < 0)) {
        --q;
    }
    return (int32_t)q;
}

/* Box refinement (fulldet.h, merge_iou_permille): *k becomes the mean of the
 * candidates overlapping it by IoU >= merge / 1000 (k itself among them). */
static void vt__merge(const vt_scored_box *cand, int32_t n, int32_t merge, vt_scored_box *k)
{
    int64_t sl = 0, st = 0, sr = 0, sb = 0, cnt = 0;
    const vt_box *a = &k->box;
    int64_t aa = ((int64_t)a->right - a->left + 1) * ((int64_t)a->bottom - a->top + 1);
    int32_t j;
    for (j = 0; j < n; ++j) {
        const vt_box *b = &cand[j].box;
        int64_t iw = (int64_t)(a->right < b->right ? a->right : b->right) -
                     (a->left > b->left ? a->left : b->left) + 1;
        int64_t ih = (int64_t)(a->bottom < b->bottom ? a->bottom : b->bottom) -
                     (a->top > b->top ? a->top : b->top) + 1;
        int64_t inter, uni;
        if (iw <= 0 || ih <= 0) {
            continue;
        }
        inter = iw * ih;
        uni = aa + ((int64_t)b->right - b->left + 1) * ((int64_t)b->bottom - b->top + 1) - inter;
        if (inter * 1000 >= (int64_t)merge * uni) {
            sl += b->left;
            st += b->top;
            sr += b->right;
            sb += b->bottom;
            ++cnt;
        }
    }
    if (cnt > 0) {
        vt_box m;
        m.left = vt__mean_round(sl, cnt);
        m.top = vt__mean_round(st, cnt);
        m.right = vt__mean_round(sr, cnt);
        m.bottom = vt__mean_round(sb, cnt);
        k->box = m;
    }
}

/* NMS over the candidates st->cand[0..out->n_cand-1] (vt_nms, in place), then the merge
 * step on each kept box; out->box gets the first VT_MAX_BOXES of them. */
static vt_status vt__nms_merge(vt_fulldet_state *st, const vt_fulldet_cfg *cfg,
                               vt_fulldet_result *out)
{
    int32_t i, kept = 0;
    vt_status s = vt_nms(st->cand, out->n_cand, cfg->nms_iou_permille, cfg->nms_contain_permille,
                         &kept);
    if (s != VT_OK) {
        return s;
    }
    out->n_boxes = kept < VT_MAX_BOXES ? kept : VT_MAX_BOXES;
    for (i = 0; i < out->n_boxes; ++i) {
        out->box[i] = st->cand[i];
        if (cfg->merge_iou_permille > 0) {
            vt__merge(st->cand, out->n_cand, cfg->merge_iou_permille, &out->box[i]);
        }
    }
    return VT_OK;
}

/* 1 if a goes before b in vt_fulldet_rerank's order: higher score, then smaller left,
 * top, right, bottom. */
static int vt__rank_before(const vt_scored_box *a, const vt_scored_box *b)
{
    if (a->score != b->score) {
        return a->score > b->score;
    }
    if (a->box.left != b->box.left) {
        return a->box.left < b->box.left;
    }
    if (a->box.top != b->box.top) {
        return a->box.top < b->box.top;
    }
    if (a->box.right != b->box.right) {
        return a->box.right < b->box.right;
    }
    return a->box.bottom < b->box.bottom;
}

/* Add a candidate (internal.h: vt__cand_add). */
static void vt__add(vt_fulldet_state *st, vt_fulldet_result *out, const vt_box *b, int32_t score,
                    int32_t source)
{
    vt__cand_add(st->cand, &out->n_cand, VT_FULLDET_MAX_CAND, &out->n_cand_dropped, b, score, source);
}

/* Input-pixel box of a window, clipped to the frame (a level's last column or row
 * may stand for fewer than 2^level input pixels). */
static vt_box vt__win_box(const vt_window *wn, int32_t w, int32_t h, int32_t height_q8)
{
    vt_box b;
    int32_t span = wn->size << wn->level;
    int32_t bh = vt__max_i32(1, (span * height_q8) >> 8);
    b.left = wn->x << wn->level;
    b.right = vt__clamp_i32(((wn->x + wn->size) << wn->level) - 1, 0, w - 1);
    b.bottom = vt__clamp_i32(((wn->y + wn->size) << wn->level) - 1, 0, h - 1);
    b.top = vt__clamp_i32(b.bottom - bh + 1, 0, b.bottom);
    return b;
}

vt_status vt_fulldet(vt_fulldet_state *st, const vt_fulldet_cfg *cfg, const vt_camera_min *cam,
                     const vt_image_u8 *img, const vt_road_area *road,
                     const vt_window_scorer *scorer, vt_fulldet_result *out)
{
    vt_image_u8 lv[VT_WIN_MAX_LEVELS];
    int32_t l, i, n_lv, w, h, use_pyr;
    size_t off = 0;
    vt_status s;
    if (out == NULL) {
        return VT_E_ARG;
    }
    out->n_boxes = out->n_windows = out->n_windows_dropped = out->n_window_hits = 0;
    out->n_shadow = out->n_cand = out->n_cand_dropped = 0;
    if (st == NULL || cam == NULL || road == NULL ||
        (scorer != NULL && scorer->score == NULL)) {
        return VT_E_ARG;
    }
    s = vt_fulldet_cfg_check(cfg);
    if (s != VT_OK) {
        return s;
    }
    s = vt_camera_min_check(cam);
    if (s != VT_OK) {
        return s;
    }
    s = vt_image_u8_check(img);
    if (s != VT_OK) {
        return s;
    }
    w = img->w;
    h = img->h;
    if (road->valid && road->height != h) {
        return VT_E_SIZE;
    }
    /* the pyramid, only when a classifier will look at it */
    use_pyr = scorer != NULL && ((cfg->sources & VT_FULLDET_WINDOWS) != 0 ||
                                 ((cfg->sources & VT_FULLDET_SHADOW) != 0 && cfg->shadow_classify));
    n_lv = use_pyr ? cfg->win.levels : 1;
    lv[0] = *img;
    for (l = 1; l < n_lv; ++l) {
        vt_image_u8_mut d;
        d.w = (lv[l - 1].w + 1) / 2;
        d.h = (lv[l - 1].h + 1) / 2;
        d.stride = d.w;
        d.px = st->pyr + off;
        off += (size_t)d.w * (size_t)d.h;   /* <= VT_FULLDET_PYR_BYTES, see fulldet.h */
        s = vt_pyr_down(&lv[l - 1], &d);
        if (s != VT_OK) {
            return s;
        }
        lv[l].px = d.px;
        lv[l].w = d.w;
        lv[l].h = d.h;
        lv[l].stride = d.stride;
    }
    /* windows */
    if ((cfg->sources & VT_FULLDET_WINDOWS) != 0) {
        for (l = 0; l < cfg->win.levels; ++l) {
            int32_t n, y0 = INT32_MAX, y1 = -1;
            s = vt_windows_level(&cfg->win, cam, road, w, h, l, st->win, VT_FULLDET_MAX_WINDOWS,
                                 &n);
            if (s != VT_OK) {
                return s;
            }
            out->n_windows += n;
            if (n > VT_FULLDET_MAX_WINDOWS) {
                out->n_windows_dropped += n - VT_FULLDET_MAX_WINDOWS;
                n = VT_FULLDET_MAX_WINDOWS;
            }
            if (n == 0 || scorer == NULL) {
                continue;
            }
            for (i = 0; i < n; ++i) {
                y0 = st->win[i].y < y0 ? st->win[i].y : y0;
                y1 = vt__max_i32(y1, st->win[i].y + st->win[i].size - 1);
            }
            if (scorer->level != NULL) {
                s = scorer->level(scorer->ctx, &lv[l], l, y0, y1);
                if (s != VT_OK) {
                    return s;
                }
            }
            for (i = 0; i < n; ++i) {
                int32_t sc = 0;
                vt_box b;
                s = scorer->score(scorer->ctx, &lv[l], &st->win[i], &sc);
                if (s != VT_OK) {
                    return s;
                }
                if (sc < cfg->window_score_min) {
                    continue;
                }
                ++out->n_window_hits;
                b = vt__win_box(&st->win[i], w, h, cfg->box_height_q8);
                if (cfg->edge_check) {
                    vt_hypothesis hy;
                    vt_box vb;
                    int32_t nv = 0;
                    hy.row = b.bottom;
                    hy.x_start = b.left;
                    hy.x_end = b.right;
                    s = vt_verify(&st->det.verify, &cfg->det.verify, img, &hy, 1, &vb, 1, &nv);
                    if (s != VT_OK) {
                        return s;
                    }
                    if (nv == 0) {
                        continue;
                    }
                }
                vt__add(st, out, &b, sc, VT_SRC_WINDOW);
            }
        }
    }
    /* shadow hypotheses over the road, verified by vertical edges */
    if ((cfg->sources & VT_FULLDET_SHADOW) != 0 && road->valid) {
        s = vt_detect(&st->det, &cfg->det, img, road, &st->dres);
        if (s != VT_OK) {
            return s;
        }
        out->n_shadow = st->dres.n_boxes;
        for (i = 0; i < st->dres.n_boxes; ++i) {
            const vt_box *b = &st->dres.box[i];
            int32_t sc = cfg->shadow_score;
            if (use_pyr && cfg->shadow_classify) {
                /* the window (level, size) whose input width is nearest the box's */
                int32_t bw = b->right - b->left + 1, best = INT32_MAX, k;
                vt_window wn;
                wn.level = -1;
                wn.size = 0;
                for (l = 0; l < n_lv; ++l) {
                    for (k = 0; k < cfg->win.n_sizes; ++k) {
                        int32_t sz = cfg->win.size[k];
                        int32_t d = vt__abs_i32((sz << l) - bw);
                        if (sz <= lv[l].w && sz <= lv[l].h && d < best) {
                            best = d;
                            wn.level = l;
                            wn.size = sz;
                        }
                    }
                }
                if (wn.level < 0) {
                    continue;
                }
                l = wn.level;
                wn.x = vt__clamp_i32(((b->left + b->right + 1) >> (l + 1)) - wn.size / 2, 0,
                                     lv[l].w - wn.size);
                wn.y = vt__clamp_i32(((b->bottom + 1) >> l) - wn.size, 0, lv[l].h - wn.size);
                s = scorer->score(scorer->ctx, &lv[l], &wn, &sc);
                if (s != VT_OK) {
                    return s;
                }
                if (sc < cfg->shadow_score_min) {
                    continue;
                }
            }
            vt__add(st, out, b, sc, VT_SRC_SHADOW);
        }
    }
    return vt__nms_merge(st, cfg, out);
}

/* Re-ranking before NMS (fulldet.h, vt_fulldet_rerank): the second-stage model's
 * score of each candidate joins its window score, so within a cluster the box the
 * stronger model finds better aligned may win. */
vt_status vt_fulldet_rerank(vt_fulldet_state *st, vt_cls_box_ws *ws, const vt_mlp_model *m,
                            const vt_fulldet_cfg *cfg, const vt_image_u8 *img,
                            vt_fulldet_result *res)
{
    vt_status s;
    int32_t i, j, n;
    if (st == NULL || ws == NULL || m == NULL || cfg == NULL || img == NULL || res == NULL) {
        return VT_E_ARG;
    }
    s = vt_fulldet_cfg_check(cfg);
    if (s == VT_OK) {
        s = vt_mlp_model_check(m);
    }
    if (s == VT_OK) {
        s = vt_image_u8_check(img);
    }
    if (s != VT_OK) {
        return s;
    }
    n = res->n_cand;
    if (n < 0 || n > VT_FULLDET_MAX_CAND) {
        return VT_E_ARG;
    }
    for (i = 0; i < n; ++i) {
        const vt_box *b = &st->cand[i].box;
        if (b->left < 0 || b->top < 0 || b->left > b->right || b->top > b->bottom ||
            b->right >= img->w || b->bottom >= img->h) {
            return VT_E_ARG;
        }
    }
    if (cfg->rerank_permille == 0) {
        return VT_OK;
    }
    /* key = score + floor(rerank * v / 1000), saturated to int32 (exact in int64:
     * |rerank * v| < 2^41) */
    for (i = 0; i < n; ++i) {
        vt_box sq = st->cand[i].box;
        int32_t top = sq.bottom - (sq.right - sq.left), v = 0;
        int64_t p, q, key;
        sq.top = top > 0 ? top : 0;
        s = vt_classify_box_mlp(ws, m, img, &sq, &v);
        if (s != VT_OK) {
            return s;
        }
        p = (int64_t)cfg->rerank_permille * v;
        q = p / 1000;
        if (p % 1000 != 0 && p < 0) {
            --q;
        }
        key = (int64_t)st->cand[i].score + q;
        st->cand[i].score = key > INT32_MAX ? INT32_MAX : (key < INT32_MIN ? INT32_MIN : (int32_t)key);
    }
    /* one total order, whatever order the candidates are in (vt_nms left them permuted):
     * key descending, then left, top, right, bottom ascending; vt_nms's stable sort keeps it */
    for (i = 1; i < n; ++i) {
        vt_scored_box t = st->cand[i];
        j = i - 1;
        while (j >= 0 && vt__rank_before(&t, &st->cand[j])) {
            st->cand[j + 1] = st->cand[j];
            --j;
        }
        st->cand[j + 1] = t;
    }
    return vt__nms_merge(st, cfg, res);
}

static int vt__box_in(const vt_box *b, const vt_image_u8 *img)
{
    return b->left >= 0 && b->top >= 0 && b->left <= b->right && b->top <= b->bottom && b->right < img->w &&
           b->bottom < img->h;
}

/* 1 when the frame's left or right side cuts b (within a quarter of its width + 1 px):
 * the second stages learnt from whole vehicles and cannot judge what the edge hides */
static int vt__box_side_cut(const vt_box *b, int32_t w_img)
{
    int64_t bw = (int64_t)b->right - b->left + 1;
    return 4 * (int64_t)b->left <= bw + 4 || 4 * ((int64_t)w_img - 1 - b->right) <= bw + 4;
}

/* A result a second pass may work on: 0..VT_MAX_BOXES boxes, each inside img. */
static int vt__result_in(const vt_fulldet_result *res, const vt_image_u8 *img)
{
    int32_t i;
    if (res->n_boxes < 0 || res->n_boxes > VT_MAX_BOXES) {
        return 0;
    }
    for (i = 0; i < res->n_boxes; ++i) {
        if (!vt__box_in(&res->box[i].box, img)) {
            return 0;
        }
    }
    return 1;
}

vt_status vt_fulldet_verify(vt_cls_box_ws *ws, const vt_mlp_model *m, const vt_image_u8 *img,
                            int32_t score_min, vt_fulldet_result *res)
{
    return vt__fulldet_verify(ws, m, img, score_min, 0, res);
}

vt_status vt__fulldet_verify(vt_cls_box_ws *ws, const vt_mlp_model *m, const vt_image_u8 *img,
                             int32_t score_min, int32_t skip, vt_fulldet_result *res)
{
    vt_status s;
    int32_t i, n = 0;
    if (ws == NULL || m == NULL || img == NULL || res == NULL) {
        return VT_E_ARG;
    }
    s = vt_mlp_model_check(m);
    if (s == VT_OK) {
        s = vt_image_u8_check(img);
    }
    if (s != VT_OK) {
        return s;
    }
    if (!vt__result_in(res, img)) {
        return VT_E_ARG;
    }
    /* score everything first, so an error leaves res unchanged */
    {
        int32_t sc[VT_MAX_BOXES];
        uint8_t pass[VT_MAX_BOXES];
        for (i = 0; i < res->n_boxes; ++i) {
            vt_box sq = res->box[i].box;
            int32_t top = sq.bottom - (sq.right - sq.left);
            int64_t bw = (int64_t)sq.right - sq.left + 1;
            if (((skip & VT__VERIFY_SKIP_FLAT) && 2 * ((int64_t)sq.bottom - sq.top + 1) < bw) ||
                ((skip & VT__VERIFY_SKIP_SIDE) && vt__box_side_cut(&sq, img->w)) ||
                ((skip & VT__VERIFY_SKIP_SMALL) && bw < VT__VERIFY_SMALL_W)) {
                sc[i] = res->box[i].score; /* passes with its own score */
                pass[i] = 1;
                continue;
            }
            sq.top = top > 0 ? top : 0;
            s = vt_classify_box_mlp(ws, m, img, &sq, &sc[i]);
            if (s != VT_OK) {
                return s;
            }
            pass[i] = sc[i] >= score_min;
        }
        for (i = 0; i < res->n_boxes; ++i) {
            if (pass[i]) {
                res->box[n] = res->box[i];
                res->box[n].score = sc[i];
                ++n;
            }
        }
    }
    res->n_boxes = n;
    return VT_OK;
}

/* ---------------------------------------------------------------- HOG scorer */
vt_status vt_hog_scorer_init(vt_hog_scorer *sc, const vt_svm_model *m)
{
    vt_status s;
    if (sc == NULL) {
        return VT_E_ARG;
    }
    s = vt_svm_model_check(m);
    if (s != VT_OK) {
        return s;
    }
    sc->model = m;
    sc->px = NULL;
    sc->level = -1;
    sc->x0 = sc->y0 = sc->w = sc->h = 0;
    return VT_OK;
}

/* Prepare rows y0.. and columns x0.. of the level image (as many as the HOG
 * workspace holds). */
static vt_status vt__hog_band(vt_hog_scorer *sc, const vt_image_u8 *img, int32_t level, int32_t x0,
                              int32_t y0, int32_t w, int32_t y1)
{
    vt_image_u8 band;
    vt_status s;
    int32_t h = y1 - y0 + 1;
    if (x0 < 0 || y0 < 0 || x0 >= img->w || y0 >= img->h || h < 1 || w < 1) {
        return VT_E_ARG;
    }
    h = h > VT_CLS_MAX_H ? VT_CLS_MAX_H : h;
    h = h > img->h - y0 ? img->h - y0 : h;
    w = w > VT_CLS_MAX_W ? VT_CLS_MAX_W : w;
    w = w > img->w - x0 ? img->w - x0 : w;
    band.px = img->px + (size_t)y0 * (size_t)img->stride + (size_t)x0;
    band.stride = img->stride;
    band.w = w;
    band.h = h;
    sc->px = NULL;
    s = vt_hog_prepare(&sc->hog, &band);
    if (s != VT_OK) {
        return s;
    }
    sc->px = img->px;
    sc->level = level;
    sc->x0 = x0;
    sc->y0 = y0;
    sc->w = band.w;
    sc->h = band.h;
    return VT_OK;
}

vt_status vt_hog_scorer_level(void *ctx, const vt_image_u8 *level_img, int32_t level, int32_t y0,
                              int32_t y1)
{
    vt_hog_scorer *sc = (vt_hog_scorer *)ctx;
    vt_status s;
    if (sc == NULL || sc->model == NULL) {
        return VT_E_ARG;
    }
    s = vt_image_u8_check(level_img);
    if (s != VT_OK) {
        return s;
    }
    if (y0 < 0 || y1 < y0 || y1 >= level_img->h) {
        return VT_E_ARG;
    }
    if (sc->model->kind != VT_DESC_HOG || y1 - y0 + 1 < sc->model->win_h) {
        sc->px = NULL; /* every window of this band goes through vt_classify_box */
        return VT_OK;
    }
    return vt__hog_band(sc, level_img, level, 0, y0, level_img->w, y1);
}

/* The checks both scorers make (score zeroed first; the scorer, ctx_ok, ready; a valid
 * level image; the window inside it) and the window as an inclusive box: VT_OK, or the
 * image's status / VT_E_ARG. */
static vt_status vt__scorer_window(int32_t ctx_ok, const vt_image_u8 *level_img, const vt_window *win,
                                   int32_t *score, vt_box *b)
{
    vt_status s;
    if (score == NULL) {
        return VT_E_ARG;
    }
    *score = 0;
    if (!ctx_ok || win == NULL) {
        return VT_E_ARG;
    }
    s = vt_image_u8_check(level_img);
    if (s != VT_OK) {
        return s;
    }
    /* x + size could overflow for a caller's window: compare against w - size */
    if (win->size < 1 || win->x < 0 || win->y < 0 || win->size > level_img->w ||
        win->size > level_img->h || win->x > level_img->w - win->size ||
        win->y > level_img->h - win->size) {
        return VT_E_ARG;
    }
    b->left = win->x;
    b->top = win->y;
    b->right = win->x + win->size - 1;
    b->bottom = win->y + win->size - 1;
    return VT_OK;
}

vt_status vt_hog_scorer_score(void *ctx, const vt_image_u8 *level_img, const vt_window *win,
                              int32_t *score)
{
    vt_hog_scorer *sc = (vt_hog_scorer *)ctx;
    const vt_svm_model *m;
    vt_status s;
    vt_box b;
    s = vt__scorer_window(sc != NULL && sc->model != NULL, level_img, win, score, &b);
    if (s != VT_OK) {
        return s;
    }
    m = sc->model;
    if (m->kind == VT_DESC_HOG && win->size == m->win_w && win->size == m->win_h) {
        int32_t inside = sc->px == level_img->px && sc->level == win->level &&
                         win->x >= sc->x0 && win->y >= sc->y0 &&
                         win->x + win->size <= sc->x0 + sc->w &&
                         win->y + win->size <= sc->y0 + sc->h;
        if (!inside || (win->x - sc->x0) % VT_CLS_CELL != 0 ||
            (win->y - sc->y0) % VT_CLS_CELL != 0) {
            /* the window alone (a shadow box's window, or one outside the band):
             * its cells then align, and the work is one window's */
            s = vt__hog_band(sc, level_img, win->level, win->x, win->y, win->size,
                             win->y + win->size - 1);
            if (s != VT_OK) {
                return s;
            }
        }
        return vt_hog_window_score(&sc->hog, m, (win->x - sc->x0) / VT_CLS_CELL,
                                   (win->y - sc->y0) / VT_CLS_CELL, score);
    }
    return vt_classify_box(&sc->box, m, level_img, &b, score);
}

vt_status vt_mlp_scorer_init(vt_mlp_scorer *sc, const vt_mlp_model *m)
{
    vt_status s;
    if (sc == NULL) {
        return VT_E_ARG;
    }
    sc->model = NULL;
    s = vt_mlp_model_check(m);
    if (s != VT_OK) {
        return s;
    }
    sc->model = m;
    return VT_OK;
}

vt_status vt_mlp_scorer_score(void *ctx, const vt_image_u8 *level_img, const vt_window *win,
                              int32_t *score)
{
    vt_mlp_scorer *sc = (vt_mlp_scorer *)ctx;
    vt_status s;
    vt_box b;
    s = vt__scorer_window(sc != NULL && sc->model != NULL, level_img, win, score, &b);
    if (s != VT_OK) {
        return s;
    }
    return vt_classify_box_mlp(&sc->box, sc->model, level_img, &b, score);
}

/* ----------------------------------------------------------------- wide pass */
vt_status vt_fulldet_wide_cfg_default(vt_fulldet_wide_cfg *cfg)
{
    static const vt_fulldet_wide_cfg def = VT_FULLDET_WIDE_CFG_DEFAULT;
    return vt__cfg_copy(cfg, &def, sizeof def);
}

vt_status vt_fulldet_wide_cfg_check(const vt_fulldet_wide_cfg *cfg)
{
    if (cfg == NULL || cfg->veh_w_min_mm < 100 || cfg->veh_w_max_mm > 20000 ||
        cfg->veh_w_min_mm > cfg->veh_w_max_mm || cfg->box_height_permille < 1 ||
        cfg->box_height_permille > 1000 || cfg->nms_iou_permille < 0 ||
        cfg->nms_iou_permille > 1000 || cfg->nms_contain_permille < 0 ||
        cfg->nms_contain_permille > 1000 || cfg->alt_height_a_permille < 0 ||
        cfg->alt_height_a_permille > 1000 || cfg->alt_height_b_permille < 0 ||
        cfg->alt_height_b_permille > 1000) {
        return VT_E_ARG;
    }
    return VT_OK;
}

/* The wide box of window wn cut to height_pm permille of its span (fulldet.h): bottom
 * row kept, height max(1, floor(span * height_pm / 1000)) exact in int64, clipped to
 * the frame. */
static void vt__wide_box(const vt_window *wn, int32_t height_pm, const vt_image_u8 *img, vt_box *b)
{
    int32_t span = wn->size << wn->level;
    int32_t bh = (int32_t)(((int64_t)span * height_pm) / 1000);
    bh = bh < 1 ? 1 : bh;
    b->left = wn->x << wn->level;
    b->right = vt__clamp_i32(((wn->x + wn->size) << wn->level) - 1, 0, img->w - 1);
    b->bottom = vt__clamp_i32(((wn->y + wn->size) << wn->level) - 1, 0, img->h - 1);
    b->top = vt__clamp_i32(b->bottom - bh + 1, 0, b->bottom);
}

/* 1 if a and b overlap past the wide pass's limits (fulldet.h): inter * 1000 >
 * iou * union or > contain * smaller area. Boxes are inside a checked frame
 * (coordinates < 2^15), so every product is exact in int64. */
static int vt__wide_overlap(const vt_box *a, const vt_box *b, int32_t iou_pm, int32_t contain_pm)
{
    int64_t iw = (int64_t)(a->right < b->right ? a->right : b->right) -
                 (a->left > b->left ? a->left : b->left) + 1;
    int64_t ih = (int64_t)(a->bottom < b->bottom ? a->bottom : b->bottom) -
                 (a->top > b->top ? a->top : b->top) + 1;
    int64_t inter, aa, ab, mn;
    if (iw <= 0 || ih <= 0) {
        return 0;
    }
    inter = iw * ih;
    aa = ((int64_t)a->right - a->left + 1) * ((int64_t)a->bottom - a->top + 1);
    ab = ((int64_t)b->right - b->left + 1) * ((int64_t)b->bottom - b->top + 1);
    mn = aa < ab ? aa : ab;
    return inter * 1000 > (int64_t)iou_pm * (aa + ab - inter) || inter * 1000 > (int64_t)contain_pm * mn;
}

vt_status vt_fulldet_wide(vt_fulldet_state *st, vt_cls_box_ws *ws, const vt_fulldet_wide_cfg *wc,
                          const vt_win_cfg *win, const vt_mlp_model *m, const vt_camera_min *cam,
                          const vt_image_u8 *img, const vt_road_area *road,
                          vt_fulldet_result *res)
{
    vt_win_cfg wcfg;
    int32_t l, i, j, n_cand = 0, kept = 0, n_out;
    vt_status s;
    if (st == NULL || ws == NULL || wc == NULL || win == NULL || m == NULL || cam == NULL ||
        road == NULL || res == NULL) {
        return VT_E_ARG;
    }
    s = vt_fulldet_wide_cfg_check(wc);
    if (s == VT_OK) {
        s = vt_mlp_model_check(m);
    }
    if (s == VT_OK) {
        wcfg = *win;
        wcfg.veh_w_min_mm = wc->veh_w_min_mm;
        wcfg.veh_w_max_mm = wc->veh_w_max_mm;
        s = vt_win_cfg_check(&wcfg);
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
    if (road->valid && road->height != img->h) {
        return VT_E_SIZE;
    }
    if (res->n_boxes < 0 || res->n_boxes > VT_MAX_BOXES) {
        return VT_E_ARG;
    }
    /* score the wide grid; candidates in st->cand */
    for (l = 0; l < wcfg.levels; ++l) {
        int32_t n;
        s = vt_windows_level(&wcfg, cam, road, img->w, img->h, l, st->win, VT_FULLDET_MAX_WINDOWS,
                             &n);
        if (s != VT_OK) {
            return s;
        }
        n = n > VT_FULLDET_MAX_WINDOWS ? VT_FULLDET_MAX_WINDOWS : n;
        for (i = 0; i < n; ++i) {
            const vt_window *wn = &st->win[i];
            int32_t sc = 0, k;
            int gate;
            vt_box b;
            vt__wide_box(wn, wc->box_height_permille, img, &b);
            s = vt_classify_box_mlp(ws, m, img, &b, &sc);
            if (s != VT_OK) {
                return s;
            }
            /* the aspect the wide model prefers: only windows past the gate pay for it */
            gate = sc >= wc->alt_score_min;
            for (k = 0; gate && k < 2; ++k) {
                int32_t pm = k == 0 ? wc->alt_height_a_permille : wc->alt_height_b_permille;
                int32_t sa = 0;
                vt_box ba;
                if (pm == 0) {
                    continue;
                }
                vt__wide_box(wn, pm, img, &ba);
                s = vt_classify_box_mlp(ws, m, img, &ba, &sa);
                if (s != VT_OK) {
                    return s;
                }
                if (sa > sc) {
                    sc = sa;
                    b = ba;
                }
            }
            if (sc < wc->score_min) {
                continue;
            }
            if (n_cand < VT_FULLDET_MAX_CAND) {
                j = n_cand++;
            } else {
                /* full: replace the (first) lowest score if this one is higher */
                int32_t lo = 0;
                for (j = 1; j < VT_FULLDET_MAX_CAND; ++j) {
                    lo = st->cand[j].score < st->cand[lo].score ? j : lo;
                }
                if (st->cand[lo].score >= sc) {
                    continue;
                }
                j = lo;
            }
            st->cand[j].box = b;
            st->cand[j].score = sc;
            st->cand[j].source = VT_SRC_WINDOW;
        }
    }
    /* stable insertion sort, score descending, then greedy NMS compacting to the front */
    for (i = 1; i < n_cand; ++i) {
        vt_scored_box t = st->cand[i];
        j = i - 1;
        while (j >= 0 && st->cand[j].score < t.score) {
            st->cand[j + 1] = st->cand[j];
            --j;
        }
        st->cand[j + 1] = t;
    }
    for (i = 0; i < n_cand; ++i) {
        int keep = 1;
        for (j = 0; j < kept && keep; ++j) {
            keep = !vt__wide_overlap(&st->cand[j].box, &st->cand[i].box, wc->nms_iou_permille,
                                     wc->nms_contain_permille);
        }
        if (keep) {
            st->cand[kept++] = st->cand[i];
        }
    }
    /* append the kept wide boxes that no box of the result overlaps */
    n_out = res->n_boxes;
    for (i = 0; i < kept && n_out < VT_MAX_BOXES; ++i) {
        int keep = 1;
        for (j = 0; j < res->n_boxes && keep; ++j) {
            keep = !vt__wide_overlap(&res->box[j].box, &st->cand[i].box, wc->nms_iou_permille,
                                     wc->nms_contain_permille);
        }
        if (keep) {
            res->box[n_out++] = st->cand[i];
        }
    }
    res->n_boxes = n_out;
    return VT_OK;
}

/* ------------------------------------------------------------ box regression */

vt_status vt_box_regressor_check(const vt_box_regressor *r)
{
    int32_t k;
    if (r == NULL || r->margin_permille < 0 || r->margin_permille > 1000 || r->sources < 1 ||
        r->sources > (VT_FULLDET_SHADOW | VT_FULLDET_WINDOWS)) {
        return VT_E_ARG;
    }
    for (k = 0; k < 4; ++k) {
        const vt_svm_model *m = &r->side[k];
        if (vt_svm_model_check(m) != VT_OK || m->kind != VT_DESC_HOG || m->win_w != r->side[0].win_w ||
            m->win_h != r->side[0].win_h || m->dim != r->side[0].dim) {
            return VT_E_ARG;
        }
    }
    return VT_OK;
}

static int32_t vt__clamp32(int64_t v, int32_t lo, int32_t hi)
{
    return v < lo ? lo : v > hi ? hi : (int32_t)v;
}

/* The box grown by m px on every side, cut to img (the regressor's and the rescorer's
 * context box). */
static void vt__context_box(const vt_box *b, int64_t m, const vt_image_u8 *img, vt_box *ctx)
{
    ctx->left = vt__clamp32(b->left - m, 0, img->w - 1);
    ctx->top = vt__clamp32(b->top - m, 0, img->h - 1);
    ctx->right = vt__clamp32(b->right + m, 0, img->w - 1);
    ctx->bottom = vt__clamp32(b->bottom + m, 0, img->h - 1);
}

/* The checked core of vt_box_regress (r, img and *in already valid). */
static vt_status vt__regress(vt_cls_box_ws *ws, const vt_box_regressor *r, const vt_image_u8 *img,
                             const vt_box *in, vt_box *out)
{
    int64_t w = (int64_t)in->right - in->left + 1;
    int64_t m = ((int64_t)r->margin_permille * w + 500) / 1000;
    int64_t side[4];
    int32_t o[4], k;
    vt_box ctx, nb;
    vt_status s;
    vt__context_box(in, m, img, &ctx);
    s = vt_classify_box(ws, &r->side[0], img, &ctx, &o[0]);
    for (k = 1; k < 4 && s == VT_OK; ++k) {
        s = vt_svm_decision(&r->side[k], ws->desc, r->side[k].dim, &o[k]);
    }
    if (s != VT_OK) {
        return s;
    }
    side[0] = in->left;
    side[1] = in->top;
    side[2] = in->right;
    side[3] = in->bottom;
    for (k = 0; k < 4; ++k) {
        /* floor((o w + 2^15) / 2^16): |o w| < 2^31 * 2^14, no overflow */
        int64_t d = (int64_t)o[k] * w + 32768;
        side[k] += d >= 0 ? d >> 16 : -((-d + 65535) >> 16);
    }
    nb.left = vt__clamp32(side[0], 0, img->w - 1);
    nb.top = vt__clamp32(side[1], 0, img->h - 1);
    nb.right = vt__clamp32(side[2], 0, img->w - 1);
    nb.bottom = vt__clamp32(side[3], 0, img->h - 1);
    *out = (nb.right < nb.left || nb.bottom < nb.top) ? *in : nb;
    return VT_OK;
}

vt_status vt_box_regress(vt_cls_box_ws *ws, const vt_box_regressor *r, const vt_image_u8 *img,
                         const vt_box *in, vt_box *out)
{
    vt_status s;
    if (in != NULL && out != NULL) {
        *out = *in;
    }
    if (ws == NULL || in == NULL || out == NULL) {
        return VT_E_ARG;
    }
    s = vt_box_regressor_check(r);
    if (s == VT_OK) {
        s = vt_image_u8_check(img);
    }
    if (s != VT_OK) {
        return s;
    }
    if (!vt__box_in(in, img)) {
        return VT_E_ARG;
    }
    return vt__regress(ws, r, img, in, out);
}

vt_status vt_fulldet_refine(vt_cls_box_ws *ws, const vt_box_regressor *r, const vt_image_u8 *img,
                            vt_fulldet_result *res)
{
    vt_box moved[VT_MAX_BOXES];
    int32_t i;
    vt_status s;
    if (ws == NULL || res == NULL) {
        return VT_E_ARG;
    }
    s = vt_box_regressor_check(r);
    if (s == VT_OK) {
        s = vt_image_u8_check(img);
    }
    if (s != VT_OK) {
        return s;
    }
    if (!vt__result_in(res, img)) {
        return VT_E_ARG;
    }
    /* every box first, so an error leaves res unchanged */
    for (i = 0; i < res->n_boxes; ++i) {
        moved[i] = res->box[i].box;
        if ((res->box[i].source & r->sources) != 0) {
            s = vt__regress(ws, r, img, &res->box[i].box, &moved[i]);
            if (s != VT_OK) {
                return s;
            }
        }
    }
    for (i = 0; i < res->n_boxes; ++i) {
        res->box[i].box = moved[i];
    }
    return VT_OK;
}

/* ------------------------------------------------------------ box rescoring */

vt_status vt_box_rescorer_check(const vt_box_rescorer *r)
{
    int64_t i, n_in;
    if (r == NULL || vt_svm_model_check(&r->hog) != VT_OK || r->hog.kind != VT_DESC_HOG ||
        r->margin_permille < 0 || r->margin_permille > 1000 || r->n_trees < 1 ||
        r->n_trees > VT_RESCORE_MAX_TREES || r->depth < 1 || r->depth > VT_RESCORE_MAX_DEPTH ||
        r->feat == NULL || r->thr == NULL || r->leaf == NULL || r->nms_iou_permille < 0 ||
        r->nms_iou_permille > 1000 || r->nms_contain_permille < 0 || r->nms_contain_permille > 1000 ||
        (r->side_keep != 0 && r->side_keep != 1)) {
        return VT_E_ARG;
    }
    n_in = (int64_t)r->n_trees * ((1 << r->depth) - 1);
    for (i = 0; i < n_in; ++i) {
        if (r->feat[i] >= VT_RESCORE_N_FEAT) {
            return VT_E_ARG;
        }
    }
    return VT_OK;
}

/* The checked core of vt_box_rescore_trees. */
static int32_t vt__rescore_trees(const vt_box_rescorer *r, const int32_t *f)
{
    int32_t t, d, n_in = (1 << r->depth) - 1;
    int64_t acc = r->bias; /* |sum| <= 4096 x 2^31 + 2^31 < 2^44: exact */
    for (t = 0; t < r->n_trees; ++t) {
        const uint8_t *ft = r->feat + (size_t)t * (size_t)n_in;
        const int32_t *th = r->thr + (size_t)t * (size_t)n_in;
        int32_t node = 0;
        for (d = 0; d < r->depth; ++d) {
            node = 2 * node + 1 + (f[ft[node]] > th[node]);
        }
        acc += r->leaf[(size_t)t * (size_t)(n_in + 1) + (size_t)(node - n_in)];
    }
    return acc > INT32_MAX ? INT32_MAX : acc < INT32_MIN ? INT32_MIN : (int32_t)acc;
}

vt_status vt_box_rescore_trees(const vt_box_rescorer *r, const int32_t *f, int32_t *score)
{
    vt_status s;
    if (score != NULL) {
        *score = 0;
    }
    if (f == NULL || score == NULL) {
        return VT_E_ARG;
    }
    s = vt_box_rescorer_check(r);
    if (s != VT_OK) {
        return s;
    }
    *score = vt__rescore_trees(r, f);
    return VT_OK;
}

/* The rescorer, camera and image checks vt_box_rescore_features and
 * vt_fulldet_rescore share, in that order (the first failure's status). */
static vt_status vt__rescore_args(const vt_box_rescorer *r, const vt_camera_min *cam, const vt_image_u8 *img)
{
    vt_status s = vt_box_rescorer_check(r);
    if (s == VT_OK) {
        s = vt_camera_min_check(cam);
    }
    if (s == VT_OK) {
        s = vt_image_u8_check(img);
    }
    return s;
}

/* The checked core of vt_box_rescore_features (r, cam, img and in->box valid). */
static vt_status vt__rescore_features(vt_cls_box_ws *ws, const vt_box_rescorer *r,
                                      const vt_camera_min *cam, const vt_image_u8 *img,
                                      const vt_scored_box *in, int32_t *f)
{
    const vt_box *b = &in->box;
    int64_t w = (int64_t)b->right - b->left + 1;
    int64_t m = ((int64_t)r->margin_permille * w + 500) / 1000;
    int64_t d = (int64_t)b->bottom - cam->horizon_y;
    vt_box ctx;
    vt_status s;
    vt__context_box(b, m, img, &ctx);
    s = vt_classify_box(ws, &r->hog, img, &ctx, &f[0]);
    if (s != VT_OK) {
        return s;
    }
    d = d < 1 ? 1 : d;
    /* every numerator below is >= 0 and < 2^45: floor is C's division */
    f[1] = in->score;
    f[2] = (int32_t)w;
    f[3] = (int32_t)(((int64_t)b->bottom - b->top + 1) * 1000 / w);
    f[4] = (int32_t)(w * 1000 / d);
    f[5] = (int32_t)(((int64_t)b->left + b->right + 1) * 1000 / (2 * (int64_t)img->w));
    f[6] = (int32_t)(d * 1000 / img->h);
    return VT_OK;
}

vt_status vt_box_rescore_features(vt_cls_box_ws *ws, const vt_box_rescorer *r,
                                  const vt_camera_min *cam, const vt_image_u8 *img,
                                  const vt_scored_box *in, int32_t *f)
{
    vt_status s;
    if (ws == NULL || in == NULL || f == NULL) {
        return VT_E_ARG;
    }
    s = vt__rescore_args(r, cam, img);
    if (s != VT_OK) {
        return s;
    }
    if (!vt__box_in(&in->box, img)) {
        return VT_E_ARG;
    }
    return vt__rescore_features(ws, r, cam, img, in, f);
}

vt_status vt_fulldet_rescore(vt_cls_box_ws *ws, const vt_box_rescorer *r,
                             const vt_camera_min *cam, const vt_image_u8 *img,
                             vt_fulldet_result *res)
{
    vt_scored_box cand[VT_MAX_BOXES];
    int32_t f[VT_RESCORE_N_FEAT];
    int32_t i, n = 0, kept = 0;
    vt_status s;
    if (ws == NULL || res == NULL) {
        return VT_E_ARG;
    }
    s = vt__rescore_args(r, cam, img);
    if (s != VT_OK) {
        return s;
    }
    if (!vt__result_in(res, img)) {
        return VT_E_ARG;
    }
    /* score every box first, so an error leaves res unchanged */
    for (i = 0; i < res->n_boxes; ++i) {
        s = vt__rescore_features(ws, r, cam, img, &res->box[i], f);
        if (s != VT_OK) {
            return s;
        }
        cand[n] = res->box[i];
        cand[n].score = vt__rescore_trees(r, f);
        if (cand[n].score < r->score_min && r->side_keep && res->box[i].score >= r->side_score_min &&
            vt__box_side_cut(&res->box[i].box, img->w)) {
            cand[n].score = r->score_min;
        }
        if (cand[n].score >= r->score_min) {
            ++n;
        }
    }
    /* sorted (stable, highest first) and thinned as every other result is */
    s = vt_nms(cand, n, r->nms_iou_permille, r->nms_contain_permille, &kept);
    if (s != VT_OK) {
        return s;
    }
    for (i = 0; i < kept; ++i) {
        res->box[i] = cand[i];
    }
    res->n_boxes = kept;
    return VT_OK;
}
