/* acf.h: aggregated channel features + boosted trees, dense over a quarter-octave pyramid. */
#define VT_ACF_NCH ...
#define VT_ACF_MAX_SCALES ...
#define VT_ACF_MAX_TREES ...
#define VT_ACF_MAX_DEPTH ...
#define VT_ACF_MAX_WIN_CELLS ...
#define VT_ACF_MAX_CAND ...
#define VT_ACF_MAX_MODELS ...
#define VT_ACF_COLS_ALL ...
#define VT_ACF_COLS_LEFT ...
#define VT_ACF_COLS_RIGHT ...

typedef struct {
    int32_t win_cw;
    int32_t win_ch;
    int32_t pad;
    int32_t n_trees;
    int32_t depth;
    const uint16_t *feat;
    const uint8_t *thr;
    const int32_t *leaf;
    const int32_t *reject;
    int32_t bias_q16;
} vt_acf_model;

typedef struct {
    int32_t first_scale;
    int32_t n_scales;
    int32_t veh_w_min_mm;
    int32_t veh_w_max_mm;
    int32_t slack_px;
    int32_t above_px;
    int32_t score_min;
    int32_t nms_iou_permille;
    int32_t nms_contain_permille;
    int32_t cols;
} vt_acf_cfg;

typedef struct { ...; } vt_acf_ws;

vt_status vt_acf_cfg_default(vt_acf_cfg *cfg);
vt_status vt_acf_cfg_check(const vt_acf_cfg *cfg);
vt_status vt_acf_model_check(const vt_acf_model *m);
vt_status vt_acf_scale_q16(int32_t k, int32_t *r_q16);
vt_status vt_acf_resample(vt_acf_ws *ws, const vt_image_u8 *src, int32_t r_q16, int32_t y0,
                          vt_image_u8_mut *dst);
vt_status vt_acf_channels(vt_acf_ws *ws, const vt_image_u8 *img, int32_t cy0, int32_t n_cy,
                          uint8_t *out, int32_t out_cap);
vt_status vt_acf_score(const vt_acf_model *m, const uint8_t *ch, int32_t rows, int32_t cols,
                       int32_t cx, int32_t cy, int32_t *score);
vt_status vt_acf_detect(vt_acf_ws *ws, const vt_acf_model *m, const vt_acf_cfg *cfg,
                        const vt_camera_min *cam, const vt_image_u8 *img,
                        vt_fulldet_result *res);
vt_status vt_acf_detect_n(vt_acf_ws *ws, int32_t n, const vt_acf_model *const *m,
                          const vt_acf_cfg *const *cfg, const vt_camera_min *cam,
                          const vt_image_u8 *img, vt_fulldet_result *res);
