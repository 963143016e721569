/* fulldet.h: shadow + classifier-window detection over the whole road, NMS. */
#define VT_FULLDET_MAX_WINDOWS ...
#define VT_FULLDET_MAX_CAND ...
#define VT_FULLDET_SHADOW ...
#define VT_FULLDET_WINDOWS ...

typedef struct {
    vt_status (*level)(void *ctx, const vt_image_u8 *level_img, int32_t level, int32_t y0,
                       int32_t y1);
    vt_status (*score)(void *ctx, const vt_image_u8 *level_img, const vt_window *win,
                       int32_t *score);
    void *ctx;
} vt_window_scorer;

typedef struct {
    int32_t sources;
    vt_win_cfg win;
    vt_detect_cfg det;
    int32_t window_score_min;
    int32_t edge_check;
    int32_t shadow_classify;
    int32_t shadow_score_min;
    int32_t shadow_score;
    int32_t nms_iou_permille;
    int32_t nms_contain_permille;
    int32_t box_height_q8;
    int32_t merge_iou_permille;
    int32_t rerank_permille;
} vt_fulldet_cfg;

typedef struct { ...; } vt_fulldet_state;

typedef struct {
    int32_t n_boxes;
    vt_scored_box box[...];
    int32_t n_windows;
    int32_t n_windows_dropped;
    int32_t n_window_hits;
    int32_t n_shadow;
    int32_t n_cand;
    int32_t n_cand_dropped;
} vt_fulldet_result;

vt_status vt_fulldet_cfg_default(vt_fulldet_cfg *cfg);
vt_status vt_fulldet_cfg_check(const vt_fulldet_cfg *cfg);
vt_status vt_fulldet_verify(vt_cls_box_ws *ws, const vt_mlp_model *m, const vt_image_u8 *img,
                            int32_t score_min, vt_fulldet_result *res);
vt_status vt_fulldet_rerank(vt_fulldet_state *st, vt_cls_box_ws *ws, const vt_mlp_model *m,
                            const vt_fulldet_cfg *cfg, const vt_image_u8 *img,
                            vt_fulldet_result *res);
vt_status vt_fulldet(vt_fulldet_state *st, const vt_fulldet_cfg *cfg, const vt_camera_min *cam,
                     const vt_image_u8 *img, const vt_road_area *road,
                     const vt_window_scorer *scorer, vt_fulldet_result *out);

typedef struct {
    const vt_svm_model *model;
    const uint8_t *px;
    int32_t level;
    int32_t x0;
    int32_t y0;
    int32_t w;
    int32_t h;
    ...;
} vt_hog_scorer;

vt_status vt_hog_scorer_init(vt_hog_scorer *sc, const vt_svm_model *m);
vt_status vt_hog_scorer_level(void *ctx, const vt_image_u8 *level_img, int32_t level, int32_t y0,
                              int32_t y1);
vt_status vt_hog_scorer_score(void *ctx, const vt_image_u8 *level_img, const vt_window *win,
                              int32_t *score);

typedef struct {
    const vt_mlp_model *model;
    ...;
} vt_mlp_scorer;

vt_status vt_mlp_scorer_init(vt_mlp_scorer *sc, const vt_mlp_model *m);
vt_status vt_mlp_scorer_score(void *ctx, const vt_image_u8 *level_img, const vt_window *win,
                              int32_t *score);

typedef struct {
    int32_t veh_w_min_mm;
    int32_t veh_w_max_mm;
    int32_t box_height_permille;
    int32_t score_min;
    int32_t nms_iou_permille;
    int32_t nms_contain_permille;
    int32_t alt_height_a_permille;
    int32_t alt_height_b_permille;
    int32_t alt_score_min;
} vt_fulldet_wide_cfg;

vt_status vt_fulldet_wide_cfg_default(vt_fulldet_wide_cfg *cfg);
vt_status vt_fulldet_wide_cfg_check(const vt_fulldet_wide_cfg *cfg);
vt_status vt_fulldet_wide(vt_fulldet_state *st, vt_cls_box_ws *ws, const vt_fulldet_wide_cfg *wc,
                          const vt_win_cfg *win, const vt_mlp_model *m, const vt_camera_min *cam,
                          const vt_image_u8 *img, const vt_road_area *road,
                          vt_fulldet_result *res);
typedef struct {
    int32_t margin_permille;
    int32_t sources;
    vt_svm_model side[4];
} vt_box_regressor;
vt_status vt_box_regressor_check(const vt_box_regressor *r);
vt_status vt_box_regress(vt_cls_box_ws *ws, const vt_box_regressor *r, const vt_image_u8 *img,
                         const vt_box *in, vt_box *out);
vt_status vt_fulldet_refine(vt_cls_box_ws *ws, const vt_box_regressor *r, const vt_image_u8 *img,
                            vt_fulldet_result *res);
#define VT_RESCORE_N_FEAT ...
#define VT_RESCORE_MAX_TREES ...
#define VT_RESCORE_MAX_DEPTH ...
typedef struct {
    vt_svm_model hog;
    int32_t margin_permille;
    int32_t n_trees;
    int32_t depth;
    const uint8_t *feat;
    const int32_t *thr;
    const int32_t *leaf;
    int32_t bias;
    int32_t score_min;
    int32_t nms_iou_permille;
    int32_t nms_contain_permille;
    int32_t side_keep;
    int32_t side_score_min;
} vt_box_rescorer;
vt_status vt_box_rescorer_check(const vt_box_rescorer *r);
vt_status vt_box_rescore_trees(const vt_box_rescorer *r, const int32_t *f, int32_t *score);
vt_status vt_box_rescore_features(vt_cls_box_ws *ws, const vt_box_rescorer *r,
                                  const vt_camera_min *cam, const vt_image_u8 *img,
                                  const vt_scored_box *in, int32_t *f);
vt_status vt_fulldet_rescore(vt_cls_box_ws *ws, const vt_box_rescorer *r,
                             const vt_camera_min *cam, const vt_image_u8 *img,
                             vt_fulldet_result *res);
