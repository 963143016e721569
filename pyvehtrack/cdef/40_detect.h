/* shadow.h, verify.h, detect.h (thesis sec. 2.4.2): shadow hypotheses,
 * vertical-edge verification and their composition. */
#define VT_MAX_SHADOW_ACTIVE ...
#define VT_MAX_SHADOW_CAND ...
#define VT_MAX_HYPOTHESES ...
#define VT_MAX_BOXES ...
#define VT_SHADOW_FIXED ...
#define VT_SHADOW_ADAPTIVE ...
#define VT_SHADOW_DARK_ABOVE ...
#define VT_SHADOW_DARK_BELOW ...

typedef struct {
    int32_t threshold_mode;
    int32_t polarity;
    int32_t grad_threshold;
    int32_t adapt_k_q8;
    int32_t adapt_grad_min;
    int32_t stat_step;
    int32_t min_run;
    int32_t max_gap;
    int32_t merge_rows;
    int32_t width_min_q8;
    int32_t width_max_q8;
    int32_t reduce_overlap_permille;
    int32_t reduce_height_q8;
    int32_t reduce_verified;
} vt_shadow_cfg;

typedef struct {
    int32_t median;
    int32_t mad;
    int32_t dark_limit;
    int32_t n_samples;
    int32_t n_runs;
    int32_t n_dropped;
    ...;
} vt_shadow_state;

vt_status vt_shadow_cfg_default(vt_shadow_cfg *cfg);
vt_status vt_shadow_cfg_check(const vt_shadow_cfg *cfg);
vt_status vt_shadow_find(vt_shadow_state *st, const vt_shadow_cfg *cfg, const vt_image_u8 *img,
                         const vt_road_area *road, vt_hypothesis *out, int32_t cap,
                         int32_t *n_out);

typedef struct {
    int32_t widen_px;
    int32_t widen_q8;
    int32_t roi_height_q8;
    int32_t vedge_threshold;
    int32_t side_min_frac_permille;
    int32_t side_min_px;
    int32_t side_contrast_q8;
    int32_t min_width_q8;
    int32_t aspect_q8;
    int32_t vedge_reach;
    int32_t vedge_hyst_permille;
} vt_verify_cfg;

typedef struct { ...; } vt_verify_state;

vt_status vt_verify_cfg_default(vt_verify_cfg *cfg);
vt_status vt_verify_cfg_check(const vt_verify_cfg *cfg);
vt_status vt_verify(vt_verify_state *st, const vt_verify_cfg *cfg, const vt_image_u8 *img,
                    const vt_hypothesis *hyp, int32_t n_hyp, vt_box *out, int32_t cap,
                    int32_t *n_out);

typedef struct { vt_shadow_cfg shadow; vt_verify_cfg verify; } vt_detect_cfg;
typedef struct { vt_shadow_state shadow; vt_verify_state verify; vt_hypothesis cand[...]; } vt_detect_state;
typedef struct {
    int32_t n_hyp;
    vt_hypothesis hyp[...];
    int32_t n_boxes;
    vt_box box[...];
} vt_detect_result;

vt_status vt_detect_cfg_default(vt_detect_cfg *cfg);
vt_status vt_detect_cfg_check(const vt_detect_cfg *cfg);
vt_status vt_detect(vt_detect_state *st, const vt_detect_cfg *cfg, const vt_image_u8 *img,
                    const vt_road_area *road, vt_detect_result *out);
