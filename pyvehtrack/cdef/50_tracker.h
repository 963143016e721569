/* track_search.h, tracker.h: ROI measurement and the multi-vehicle tracker. */
#define VT_TRACK_TEMPLATE ...

/* vt_box is declared in 40_detect.h */
#define VT_EDGE_DARK_ABOVE ...
#define VT_EDGE_DARK_BELOW ...
typedef struct {
    int32_t polarity;
    int32_t h_thresh;
    int32_t v_thresh;
    int32_t min_h_permille;
    int32_t min_v_permille;
    int32_t bottom_permille;
    int32_t side_mode;
} vt_track_search_cfg;
#define VT_SIDES_TWO_THRESHOLD ...
#define VT_SIDES_LARGEST ...
#define VT_TRACK_MAX_FRAMES_CFG ...
#define VT_TRACK_MAX_BIRTH_SEARCH ...
#define VT_TRACK_MAX_ASPECT_PERMILLE ...
typedef struct {
    int32_t hproj[...];
    int32_t vproj[...];
} vt_track_search_ws;
typedef struct {
    int32_t have_prev;
    int32_t prev_left;
    int32_t prev_right;
    int32_t max_change_left;
    int32_t max_change_right;
} vt_track_sides;

vt_status vt_track_search_cfg_check(const vt_track_search_cfg *cfg);
vt_status vt_track_search(vt_track_search_ws *ws, vt_track_sides *sides,
                          const vt_track_search_cfg *cfg, const vt_image_u8 *img,
                          const vt_box *roi, vt_box *meas, int32_t *found);

typedef enum { VT_TRACK_FREE, VT_TRACK_TENTATIVE, VT_TRACK_CONFIRMED, VT_TRACK_COASTING, ... } vt_track_state;

typedef struct {
    vt_track_search_cfg search;
    vt_kf_model_cfg model;
    int32_t roi_margin_min;
    int32_t roi_margin_permille;
    int32_t gate_permille;
    int32_t gate_bottom_permille;
    int32_t confirm_hits;
    int32_t max_coast;
    int32_t match_iou_permille;
    vt_q14 keep_ncc;
    int32_t init_max_change;
    int32_t measurement;
    vt_edge_cfg edge;
    int32_t tmatch_radius;
    int32_t tmatch_ncc_permille;
    int32_t tmatch_max;
    int32_t part_permille;
    int32_t min_width;
    int32_t scale_tol_permille;
    int32_t snap_bottom;
    int32_t birth_search;
    int32_t search_max_aspect_permille;
} vt_tracker_cfg;
#define VT_MEAS_ROI_SEARCH ...
#define VT_MEAS_EDGE_CURVES ...
#define VT_MEAS_ROI_EDGES ...

typedef struct {
    int32_t id;
    int32_t state;
    int32_t hits;
    int32_t misses;
    int32_t age;
    int32_t aspect_q8;
    vt_box box;
    vt_q16 vx;
    vt_q16 vy;
    vt_track_sides sides;
    vt_kf kf;
    uint8_t tmpl[...];
    vt_edge_template edges;
    int32_t tm_frames;
    vt_box tmpl_box;
    int32_t ref_w;
    int32_t ref_b;
    int32_t tm_only;
} vt_track;

typedef struct {
    int32_t next_id;
    int32_t frame;
    int32_t dropped_full;
    vt_track tracks[...];
    vt_edge_ws *edge_ws;
    int32_t horizon_known;
    int32_t horizon_y;
    ...;
} vt_tracker;

typedef struct {
    int32_t id;
    int32_t state;
    vt_box box;
    vt_q16 vx;
    vt_q16 vy;
} vt_track_out;

vt_status vt_tracker_init(vt_tracker *tr);
vt_status vt_tracker_cfg_default(vt_tracker_cfg *cfg);
vt_status vt_tracker_cfg_check(const vt_tracker_cfg *cfg);
vt_status vt_tracker_set_edge_ws(vt_tracker *tr, vt_edge_ws *ws);
vt_status vt_tracker_set_horizon(vt_tracker *tr, int32_t known, int32_t row);
vt_status vt_track_list_check(const vt_track_out *tracks, int32_t n_tracks);
vt_status vt_tracker_drop(vt_tracker *tr, int32_t id);
vt_status vt_tracker_step(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                          int32_t detection_frame, const vt_box *dets, int32_t n_dets,
                          vt_track_out *out, int32_t out_cap, int32_t *n_out);
