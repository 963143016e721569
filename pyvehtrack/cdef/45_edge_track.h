/* edge_track.h: edge curves (Canny-style) and chamfer matching, GIST paper sec. III.B. */
#define VT_EDGE_MAX_PIXELS ...
#define VT_EDGE_MAX_POINTS ...

typedef struct {
    int32_t low;
    int32_t high;
    int32_t min_len;
    int32_t radius;
    int32_t trunc;
    int32_t max_mean_q8;
    int32_t min_points;
    int32_t scale_steps;
    int32_t scale_step_q8;
} vt_edge_cfg;

struct vt_edge_grad {
    int16_t mag[...];
    int16_t dir[...];
};
union vt_edge_planes {
    struct vt_edge_grad g;
    int32_t queue[...];
    uint16_t dt[...];
};
typedef struct {
    int32_t x0, y0, w, h;
    int32_t n_curve;
    int32_t n_curves;
    union vt_edge_planes u;
    uint8_t lab[...];
} vt_edge_ws;

typedef struct {
    int32_t n;
    vt_box box;
    int16_t x[...];
    int16_t y[...];
} vt_edge_template;

vt_status vt_edge_cfg_default(vt_edge_cfg *cfg);
vt_status vt_edge_cfg_check(const vt_edge_cfg *cfg);
vt_status vt_edge_map(vt_edge_ws *ws, const vt_edge_cfg *cfg, const vt_image_u8 *img,
                      const vt_box *roi);
vt_status vt_edge_template_set(const vt_edge_ws *ws, const vt_box *box, vt_edge_template *tpl,
                               int32_t *n_out);
vt_status vt_edge_match(const vt_edge_ws *ws, const vt_edge_cfg *cfg, const vt_edge_template *tpl,
                        int32_t cx, int32_t cy, int32_t *dx, int32_t *dy, int32_t *scale_q8,
                        int32_t *score, int32_t *found);
vt_status vt_edge_scale(int32_t v, int32_t s_q8, int32_t *out);
