/* vehicle_model.h: the seven-parameter vehicle model searched by a GA (IVVI sec. 5-6). */
#define VT_MODEL_MAX_ROI_PIXELS ...
#define VT_MODEL_MAX_POP ...
#define VT_MODEL_LEVELS ...
#define VT_MODEL_SAMPLES ...

typedef struct {
    int32_t x;
    int32_t y;
    int32_t w;
    int32_t h;
    int32_t wind;
    int32_t bump;
    int32_t roof;
} vt_model_params;

typedef struct {
    int32_t levels;
    int32_t pop[2][3];
    int32_t gens[2][3];
    uint32_t seed;
    int32_t mut_permille;
    int32_t w_sym, w_grad, w_dist, w_shadow;
    int32_t edge_thresh;
    int32_t dist_cap;
    int32_t horizon_row;
    vt_q16 width_per_row;
    int32_t width_tol_permille;
    int32_t aspect_min_permille;
    int32_t aspect_max_permille;
    int32_t wind_min, wind_max;
    int32_t bump_min, bump_max;
    int32_t roof_max;
} vt_model_cfg;

typedef struct {
    vt_box roi;
    int32_t y_min, y_max;
    int32_t tracking;
    vt_model_params pred;
    vt_model_params sigma;
} vt_model_search;

typedef struct {
    vt_model_params pop[...];
    int32_t fit[...];
    int32_t cur;
    int32_t n;
    uint32_t rng;
    int32_t level;
    int32_t ox, oy, rw, rh;
    int32_t lw, lh, istride;
    int16_t gx[...];
    int16_t gy[...];
    uint8_t dist[...];
    ...;
} vt_model_ws;

typedef struct {
    vt_model_params best;
    int32_t fitness;
    int32_t evaluations;
    vt_box box;
} vt_model_result;

vt_status vt_model_cfg_default(vt_model_cfg *cfg);
vt_status vt_model_cfg_check(const vt_model_cfg *cfg);
vt_status vt_model_cfg_road(vt_model_cfg *cfg, int32_t y0, int32_t w0, int32_t y1, int32_t w1);
vt_status vt_model_expected_width(const vt_model_cfg *cfg, int32_t y, int32_t *w);
vt_status vt_model_prepare(vt_model_ws *ws, const vt_model_cfg *cfg,
                           const vt_image_u8 *frame, const vt_model_search *search, int32_t level);
vt_status vt_model_fitness(vt_model_ws *ws, const vt_model_cfg *cfg,
                           const vt_image_u8 *frame, const vt_model_search *search, int32_t level,
                           const vt_model_params *p, int32_t *fitness);
vt_status vt_model_fit(vt_model_ws *ws, const vt_model_cfg *cfg,
                       const vt_image_u8 *frame, const vt_model_search *search, vt_model_result *out);
vt_status vt_model_search_from_flow(const vt_model_cfg *cfg, const vt_flow_hyp *h,
                                    vt_model_search *search);
