/* ttc_scale.h: TTC from the scale change of SAD-matched blocks inside a box. */
#define VT_TTC_TRACKS ...
#define VT_TTC_GRID ...
#define VT_TTC_BLOCK ...
#define VT_TTC_HIST ...
#define VT_TTC_MAX_BLOCKS ...
#define VT_TTC_MAX_PAIRS ...
#define VT_TTC_ANCHORS ...
#define VT_TTC_SCALE_VALID ...
#define VT_TTC_VALID ...

typedef struct vt_ttc_cfg {
    int32_t block;
    int32_t grid;
    int32_t margin_permille;
    int32_t radius;
    int32_t min_texture;
    int32_t max_sad;
    int32_t lag;
    int32_t min_pair_px;
    int32_t min_pairs;
    vt_q16 frame_dt;
    vt_q16 ttc_max;
    int32_t anchor_radius;
    int32_t evict_margin_px;
    int32_t prior_gate_permille;
    int32_t min_lag;
    int32_t min_match_permille;
} vt_ttc_cfg;

typedef struct vt_ttc_state { ...; } vt_ttc_state;

typedef struct vt_ttc_out {
    int32_t id;
    int32_t flags;
    int32_t blocks;
    int32_t matched;
    int32_t pairs;
    vt_q16 scale;
    vt_q16 ttc;
    int32_t lag;
} vt_ttc_out;

vt_status vt_ttc_cfg_default(vt_ttc_cfg *cfg);
vt_status vt_ttc_cfg_check(const vt_ttc_cfg *cfg);
vt_status vt_ttc_init(vt_ttc_state *st);
vt_status vt_ttc_step(vt_ttc_state *st, const vt_ttc_cfg *cfg, const vt_image_u8 *img,
                      const vt_track_out *tracks, int32_t n_tracks, vt_ttc_out *out,
                      int32_t out_cap, int32_t *n_out);
