/* fuzz-requires: vehtrack/fulldet.h
 * fuzz_fulldet.c -- vehicle detection over the whole road (vehtrack/fulldet.h;
 * IVVI paper sec. III, thesis sec. 2.4) and its non-maximum suppression
 * (windows.h): the configuration (window rules, shadow and verify fields, NMS
 * limits, sources) mutated from the bytes, the camera, a road area (camera road,
 * plausible or every field fuzzed), a fuzzed view, and a scorer that is NULL,
 * the HOG scorer, the MLP scorer or a fuzz scorer whose scores and statuses
 * come from the bytes (an error mid-frame must come back as the call's status);
 * then, from the bytes, re-ranking (vt_fulldet_rerank, its weight and NULLs fuzzed)
 * and the wide pass (its height choice among the fuzzed fields), then box
 * regression (vt_fulldet_refine, vt_box_regress: a regressor whose weights,
 * shifts, biases, margin and sources come from the bytes, extreme offsets and
 * boxes outside the image included).
 * vt_nms on boxes from the bytes (inverted boxes, equal scores, INT32 edges) in
 * an exact-size array. After a call: boxes are within capacity and the frame,
 * ordered by score, NMS keeps a prefix in score order, and box regression moves
 * only its sources' boxes, inside the frame, scores and order kept (on error:
 * nothing changed). */
#include "fuzz.h"
#include "vehtrack/fulldet.h"

static vt_fulldet_state g_st;
static vt_fulldet_result g_out;
static vt_road_area g_road;
static vt_hog_scorer g_hog_sc;
static vt_mlp_scorer g_mlp_sc;
static vt_cls_box_ws g_box_ws; /* the wide pass's and re-ranking's classifier scratch */
static vt_fulldet_result g_keep; /* the result before re-ranking (unchanged on error) */
static fz *g_f; /* the bytes the fuzz scorer reads */
static vt_box_regressor g_reg;
static int16_t g_reg_w[4][324]; /* HOG 32x32 at most: (32/8 - 1)^2 * 36 */
static int32_t g_calls;

/* b lies inside img and is not inside out */
static int in_frame(const vt_box *b, const vt_image_u8 *img)
{
    return b->left >= 0 && b->left <= b->right && b->right < img->w && b->top >= 0 && b->top <= b->bottom &&
           b->bottom < img->h;
}

static vt_status fz_score(void *ctx, const vt_image_u8 *level_img, const vt_window *win, int32_t *score)
{
    uint8_t k = fz_u8(g_f);
    (void)ctx;
    FZ_ASSERT(level_img != NULL && win != NULL && score != NULL);
    FZ_ASSERT(win->x >= 0 && win->y >= 0 && win->x + win->size <= level_img->w &&
              win->y + win->size <= level_img->h);
    if (++g_calls > 20000) {
        return VT_OK; /* keep one input fast */
    }
    if (k == 0xFE) {
        return VT_E_ARG; /* a scorer failing mid-frame */
    }
    *score = k < 200 ? (int32_t)k - 100 : fz_edge(g_f, 1 << 20);
    return VT_OK;
}

static vt_status fz_level(void *ctx, const vt_image_u8 *level_img, int32_t level, int32_t y0, int32_t y1)
{
    (void)ctx;
    FZ_ASSERT(level_img != NULL && level >= 0 && level < VT_WIN_MAX_LEVELS && 0 <= y0 && y0 <= y1 &&
              y1 < level_img->h);
    return fz_u8(g_f) == 0xFD ? VT_E_SIZE : VT_OK;
}

static void nms(fz *f)
{
    int32_t n = fz_u8(f) < 230 ? fz_range(f, 0, 64) : fz_edge(f, VT_MAX_NMS_BOXES);
    int32_t iou = fz_u8(f) < 200 ? fz_range(f, 0, 1000) : fz_edge(f, 1000);
    int32_t con = fz_u8(f) < 200 ? fz_range(f, 0, 1000) : fz_edge(f, 1000);
    int32_t i, n_out = -1, alloc = n >= 0 && n <= 64 ? n : 0;
    vt_scored_box *b = (vt_scored_box *)fz_alloc(f, (size_t)alloc * sizeof(vt_scored_box));
    vt_status s;
    if (n > 64 && n <= VT_MAX_NMS_BOXES) {
        n = 64 + (n & 1); /* within capacity but past the array: not a test of nms */
        b = (vt_scored_box *)fz_alloc(f, (size_t)n * sizeof(vt_scored_box));
        alloc = n;
    }
    for (i = 0; i < alloc && b != NULL; i++) {
        if (fz_u8(f) < 220) {
            b[i].box.left = fz_range(f, -8, 100);
            b[i].box.top = fz_range(f, -8, 100);
            b[i].box.right = fz_near(f, b[i].box.left, -1, 40);
            b[i].box.bottom = fz_near(f, b[i].box.top, -1, 40);
            b[i].score = fz_range(f, -3, 3);
        } else {
            b[i].box.left = fz_edge(f, 100);
            b[i].box.top = fz_edge(f, 100);
            b[i].box.right = fz_edge(f, 100);
            b[i].box.bottom = fz_edge(f, 100);
            b[i].score = fz_raw_i32(f);
        }
        b[i].source = fz_u8(f) & 3;
    }
    s = vt_nms((fz_u8(f) == 0xFF) ? NULL : b, n, iou, con, (fz_u8(f) == 0xFF) ? NULL : &n_out);
    fz_status(s);
    if (s == VT_OK) {
        FZ_ASSERT(n_out >= 0 && n_out <= n);
        for (i = 1; i < n_out; i++) {
            FZ_ASSERT(b[i - 1].score >= b[i].score);
        }
    }
}

/* Box regression on the result so far: a regressor from the bytes (a small HOG
 * window so one input stays fast; weights, shifts and biases often at their
 * edges, which move a side far outside the frame). */
static void refine(fz *f, const vt_image_u8 *img, vt_fulldet_result *res)
{
    static const int32_t wins[3] = {16, 24, 32};
    int32_t win = wins[fz_u8(f) % 3u], dim = (win / 8 - 1) * (win / 8 - 1) * 36;
    int32_t k, i;
    uint8_t rn = fz_u8(f);
    vt_status s;
    g_reg.margin_permille = fz_u8(f) < 220 ? fz_range(f, 0, 1000) : fz_edge(f, 1000);
    g_reg.sources = fz_u8(f) < 220 ? fz_range(f, 1, 3) : fz_edge(f, 3);
    for (k = 0; k < 4; k++) {
        vt_svm_model *m = &g_reg.side[k];
        m->kind = VT_DESC_HOG;
        m->win_w = win;
        m->win_h = win;
        m->dim = dim;
        m->w_shift = fz_u8(f) < 220 ? fz_range(f, 1, 30) : fz_edge(f, 30);
        m->bias_q16 = fz_u8(f) < 200 ? fz_range(f, -65536, 65536) : fz_edge(f, INT32_MAX);
        m->threshold_q16 = 0;
        for (i = 0; i < dim; i++) {
            uint8_t b = fz_u8(f);
            g_reg_w[k][i] = (int16_t)(b < 240 ? (int32_t)b - 120 : (b & 1 ? 32767 : -32767));
        }
        m->w = g_reg_w[k];
    }
    if (rn & 64) { /* an unlike side: a wrong dim, kind or window -> VT_E_ARG */
        vt_svm_model *m = &g_reg.side[fz_u8(f) & 3u];
        fz_mutate_i32s(f, m, 4 * sizeof(int32_t));
    }
    fz_status(vt_box_regressor_check((rn & 1) ? NULL : &g_reg));
    if (res != NULL) {
        g_keep = *res;
    }
    s = vt_fulldet_refine((rn & 2) ? NULL : &g_box_ws, (rn & 4) ? NULL : &g_reg, (rn & 8) ? NULL : img,
                          (rn & 16) ? NULL : res);
    fz_status(s);
    if (res != NULL && !(rn & 16)) {
        if (s != VT_OK) {
            FZ_ASSERT(memcmp(&g_keep, res, sizeof *res) == 0); /* unchanged on error */
        } else {
            FZ_ASSERT(res->n_boxes == g_keep.n_boxes);
            for (i = 0; i < res->n_boxes; i++) {
                const vt_box *b = &res->box[i].box;
                FZ_ASSERT(res->box[i].score == g_keep.box[i].score);
                FZ_ASSERT(res->box[i].source == g_keep.box[i].source);
                FZ_ASSERT(in_frame(b, img));
                if (!(res->box[i].source & g_reg.sources)) {
                    FZ_ASSERT(memcmp(b, &g_keep.box[i].box, sizeof *b) == 0);
                }
            }
        }
    }
    { /* one box from the bytes: inside, on an edge or outside the frame */
        vt_box in, out;
        in.left = fz_u8(f) < 200 ? fz_range(f, -4, img->w > 0 ? img->w : 4) : fz_edge(f, VT_MAX_WIDTH);
        in.top = fz_u8(f) < 200 ? fz_range(f, -4, img->h > 0 ? img->h : 4) : fz_edge(f, VT_MAX_HEIGHT);
        in.right = fz_near(f, in.left, -2, 64);
        in.bottom = fz_near(f, in.top, -2, 64);
        out.left = out.top = out.right = out.bottom = -7;
        s = vt_box_regress((rn & 32) ? NULL : &g_box_ws, &g_reg, img, &in, (rn & 128) ? NULL : &out);
        fz_status(s);
        if (!(rn & 128)) {
            if (s != VT_OK) {
                FZ_ASSERT(memcmp(&in, &out, sizeof in) == 0); /* *out = *in on error */
            } else {
                FZ_ASSERT(in_frame(&out, img));
            }
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz f = fz_open(data, size);
    uint8_t op = fz_u8(&f), nulls = fz_u8(&f) & (fz_u8(&f) | 0xC0u);
    vt_fulldet_cfg cfg;
    vt_camera_min cam = {16 * 700, 0, 1500, 0};
    vt_window_scorer sc = {NULL, NULL, NULL};
    vt_image_u8 img;
    vt_status s;
    int32_t i;
    g_f = &f;
    g_calls = 0;
    if ((op & 7) == 7) {
        nms(&f);
        fz_close(&f);
        return 0;
    }
    img = fz_image_u8(&f, VT_MAX_WIDTH, VT_MAX_HEIGHT);
    fz_status(vt_fulldet_cfg_default(&cfg));
    if (fz_u8(&f) < 128) { /* one or two levels: the rest is the same code again */
        cfg.win.levels = 1 + (fz_u8(&f) & 1);
        cfg.win.size[0] = 16;
        cfg.win.size[1] = 24;
    }
    fz_mutate_i32s(&f, &cfg, sizeof cfg);
    fz_status(vt_fulldet_cfg_check(&cfg));
    {
        int32_t h = img.h > 0 && img.h <= VT_MAX_HEIGHT ? img.h : 48;
        cam.horizon_y = fz_u8(&f) < 200 ? fz_range(&f, -h, h / 2) : fz_edge(&f, VT_MAX_HEIGHT);
        cam.hood_y = fz_u8(&f) < 200 ? h : fz_edge(&f, 2 * VT_MAX_HEIGHT);
        cam.fx_q4 = fz_u8(&f) < 200 ? fz_range(&f, 16 * 20, 16 * 1500) : fz_edge(&f, 1 << 24);
        fz_mutate_i32s(&f, &cam, sizeof cam);
    }
    if (fz_u8(&f) & 1) {
        fz_status(vt_road_from_camera(&cfg.win, &cam, img.w, img.h, &g_road));
    } else {
        fz_road(&f, &g_road, img.w, img.h);
    }
    switch (fz_u8(&f) & 3u) {
    case 0: /* no scorer: shadow boxes only */
        break;
    case 1: {
        const vt_svm_model *m = NULL;
        fz_status(vt_svm_default_model(VT_DESC_HOG, &m));
        fz_status(vt_hog_scorer_init(&g_hog_sc, m));
        sc.level = vt_hog_scorer_level;
        sc.score = vt_hog_scorer_score;
        sc.ctx = &g_hog_sc;
        break;
    }
    case 2: {
        const vt_mlp_model *m = NULL;
        if (vt_mlp_default_model(&m) == VT_OK) {
            fz_status(vt_mlp_scorer_init(&g_mlp_sc, m));
            sc.score = vt_mlp_scorer_score;
            sc.ctx = &g_mlp_sc;
        }
        break;
    }
    default:
        sc.level = (fz_u8(&f) & 1) ? fz_level : NULL;
        sc.score = (fz_u8(&f) == 0xFF) ? NULL : fz_score; /* a scorer with no score: VT_E_ARG */
        break;
    }
    s = vt_fulldet((nulls & 1) ? NULL : &g_st, (nulls & 2) ? NULL : &cfg, (nulls & 4) ? NULL : &cam,
                   (nulls & 8) ? NULL : &img, (nulls & 16) ? NULL : &g_road,
                   (nulls & 32) ? NULL : (sc.score == NULL && sc.level == NULL ? NULL : &sc),
                   (nulls & 128) ? NULL : &g_out);
    fz_status(s);
    if (!(nulls & 128)) {
        if (s != VT_OK) {
            FZ_ASSERT(g_out.n_boxes == 0);
        } else {
            FZ_ASSERT(g_out.n_boxes >= 0 && g_out.n_boxes <= VT_MAX_BOXES);
            FZ_ASSERT(g_out.n_windows_dropped >= 0 && g_out.n_cand >= 0 && g_out.n_cand <= VT_FULLDET_MAX_CAND);
            for (i = 0; i < g_out.n_boxes; i++) {
                const vt_box *b = &g_out.box[i].box;
                FZ_ASSERT(in_frame(b, &img));
                FZ_ASSERT(i == 0 || g_out.box[i - 1].score >= g_out.box[i].score);
            }
        }
    }
    if (fz_u8(&f) < 96) { /* re-ranking before NMS on vt_fulldet's candidates (as the pipeline) */
        const vt_mlp_model *m = NULL;
        uint8_t rn = fz_u8(&f);
        if (rn & 64) {
            cfg.rerank_permille = fz_edge(&f, 1000); /* off the default 0, bad values included */
        }
        g_keep = g_out;
        fz_status(vt_mlp_default_model(&m));
        s = vt_fulldet_rerank((rn & 1) ? NULL : &g_st, (rn & 2) ? NULL : &g_box_ws, (rn & 4) ? NULL : m,
                              (rn & 8) ? NULL : &cfg, (rn & 16) ? NULL : &img, (rn & 32) ? NULL : &g_out);
        fz_status(s);
        if (s != VT_OK || cfg.rerank_permille == 0) {
            /* unchanged on error, and at weight 0 (res may then be a result of an
             * earlier input, when vt_fulldet above was given a NULL out) */
            FZ_ASSERT(memcmp(&g_keep, &g_out, sizeof g_out) == 0);
        } else { /* from the candidates, each checked against this img */
            FZ_ASSERT(g_out.n_boxes >= 0 && g_out.n_boxes <= VT_MAX_BOXES);
            for (i = 0; i < g_out.n_boxes; i++) {
                const vt_box *b = &g_out.box[i].box;
                FZ_ASSERT(in_frame(b, &img));
                FZ_ASSERT(i == 0 || g_out.box[i - 1].score >= g_out.box[i].score);
            }
        }
    }
    if (fz_u8(&f) < 96) { /* the wide pass on the same frame, appending to the result */
        vt_fulldet_wide_cfg wc;
        const vt_mlp_model *m = NULL;
        int32_t before = g_out.n_boxes;
        uint8_t wn = fz_u8(&f);
        fz_status(vt_fulldet_wide_cfg_default(&wc));
        fz_mutate_i32s(&f, &wc, sizeof wc);
        fz_status(vt_fulldet_wide_cfg_check((wn & 1) ? NULL : &wc));
        fz_status(vt_mlp_default_model(&m));
        s = vt_fulldet_wide((wn & 2) ? NULL : &g_st, (wn & 4) ? NULL : &g_box_ws, &wc,
                            (wn & 8) ? NULL : &cfg.win, (wn & 16) ? NULL : m, &cam,
                            (wn & 32) ? NULL : &img, &g_road, (wn & 64) ? NULL : &g_out);
        fz_status(s);
        if (s != VT_OK) {
            FZ_ASSERT(g_out.n_boxes == before); /* unchanged on error */
        } else {
            FZ_ASSERT(g_out.n_boxes >= before && g_out.n_boxes <= VT_MAX_BOXES);
            for (i = 0; i < g_out.n_boxes; i++) {
                const vt_box *b = &g_out.box[i].box;
                FZ_ASSERT(b->left <= b->right && b->top <= b->bottom);
            }
        }
    }
    if (fz_u8(&f) < 96) {
        refine(&f, &img, (nulls & 128) ? NULL : &g_out);
    }
    fz_close(&f);
    return 0;
}
