/* hood.h: the ego car's hood found in the frame. */
typedef struct {
    int32_t band_top_permille;
    int32_t col_step;
    int32_t grad_min;
    int32_t max_jump;
    int32_t cover_permille;
} vt_hood_cfg;

typedef struct { ...; } vt_hood_state;

typedef struct {
    int32_t found;
    int32_t row;
    int32_t n_cols;
    int32_t n_strong;
    int32_t path_end;
} vt_hood_result;

vt_status vt_hood_cfg_default(vt_hood_cfg *cfg);
vt_status vt_hood_cfg_check(const vt_hood_cfg *cfg);
vt_status vt_hood_find(vt_hood_state *st, const vt_hood_cfg *cfg, const vt_image_u8 *img,
                       vt_hood_result *res);
