/* pipeline.h: the per-frame order of the whole system. */
#define VT_SRC_SHADOW ...
#define VT_SRC_CLASSIFIER ...
#define VT_SRC_FLOW ...
#define VT_SRC_MODEL ...
#define VT_SRC_EGO ...
#define VT_SRC_EXTERNAL ...
#define VT_SRC_BUILT ...
#define VT_ROAD_SRC_NONE ...
#define VT_ROAD_SRC_LANES ...
#define VT_ROAD_SRC_FIXED ...
#define VT_ROAD_SRC_CAMERA ...
#define VT_ROAD_AUTO ...
#define VT_ROAD_LANES ...
#define VT_ROAD_FIXED ...
#define VT_UNKNOWN ...
#define VT_FCW_UNKNOWN ...
#define VT_FCW_NONE ...
#define VT_PIPE_HANDOVER ...
#define VT_PIPE_HO_HIST ...

typedef struct {
    int32_t vp_x_permille;
    int32_t vp_y_permille;
    int32_t bottom_left_permille;
    int32_t bottom_right_permille;
    int32_t lane_bottom_permille;
    int32_t top_margin;
} vt_fixed_road;

typedef struct {
    int32_t horizon_q16;
    int32_t hood_q16;
    int32_t height_mm;
    int32_t fx_per_w_q16;
} vt_road_camera;

typedef struct {
    vt_lane_cfg lane;
    vt_detect_cfg detect;
    vt_tracker_cfg tracker;
    vt_range_cfg range;
    vt_fixed_road fixed_road;
    int32_t detect_every;
    int32_t road_policy;
    int32_t lanes_every_frame;
    int32_t sources;
    int32_t track;
    vt_fulldet_cfg fulldet;
    vt_road_camera road_camera;
    vt_flow_cfg flow;
    vt_model_cfg model;
    int32_t model_fits;
    int32_t model_min_fitness;
    int32_t verify;
    vt_q16 verify_min;
    vt_ttc_cfg ttc;
    int32_t handover;
    int32_t handover_frames;
    int32_t handover_dy_permille;
    int32_t handover_edge_permille;
    int32_t ttc_fuse_permille;
    int32_t road_above_hood;
    int32_t auto_hood;
    vt_hood_cfg hood;
    int32_t fcw_fused;
    int32_t cnn_hood_min_width_mm;
    int32_t cnn_ego_iou_permille;
    int32_t cnn_track_top;
} vt_pipeline_cfg;

typedef struct {
    vt_fulldet_state st;
    vt_fulldet_result res;
    vt_hog_scorer hog;
    vt_cls_box_ws box;
} vt_pipe_cls_ws;

typedef struct {
    vt_pipeline_cfg cfg;
    const vt_svm_model *model;
    vt_pipe_cls_ws *cls_ws;
    vt_window_scorer scorer;
    int32_t horizon_y;
    int32_t horizon_known;
    vt_flow_state *flow_st;
    vt_flow_result flow;
    vt_model_ws *model_ws;
    const vt_acf_model *acf;
    vt_acf_ws *acf_ws;
    int32_t acf_n;
    const vt_cnn_model *cnn;
    vt_cnn_cfg cnn_cfg;
    uint8_t *cnn_work;
    size_t cnn_work_bytes;
    int32_t frame;
    vt_q16 ego_speed;
    vt_lane_state lane;
    vt_detect_state detect;
    vt_detect_result det;
    vt_tracker tracker;
    vt_pitch_state pitch;
    vt_range_state range;
    vt_ttc_state *ttc_st;
    ...;
} vt_pipeline;

typedef struct {
    vt_box box;
    int32_t source;
    int32_t score;
} vt_pipe_box;

typedef struct {
    int32_t id;
    int32_t state;
    vt_box box;
    vt_q16 vx;
    vt_q16 vy;
    int32_t distance_mm;
    int32_t ttc_ms;
    int32_t warning;
    int32_t source;
    vt_q16 ttc_points_q16;
    vt_q16 ttc_fused_q16;
} vt_pipe_track;

typedef struct {
    int32_t frame;
    int32_t detection_frame;
    int32_t lane_status;
    int32_t lanes_ran;
    vt_lane_result lanes;
    int32_t road_source;
    vt_road_area road;
    int32_t n_hyp;
    vt_hypothesis hyp[...];
    int32_t n_boxes;
    int32_t n_boxes_in;
    int32_t flow_ready;
    int32_t hood_row;
    int32_t model_fits;
    vt_pipe_box boxes[...];
    int32_t n_tracks;
    vt_pipe_track tracks[...];
} vt_frame_out;

vt_status vt_pipeline_cfg_default(vt_pipeline_cfg *cfg);
vt_status vt_pipeline_cfg_check(const vt_pipeline_cfg *cfg);
vt_status vt_pipeline_init(vt_pipeline *p, const vt_pipeline_cfg *cfg,
                           const vt_camera_cfg *camera, const vt_svm_model *model);
vt_status vt_pipeline_set_cls_ws(vt_pipeline *p, vt_pipe_cls_ws *ws, const vt_window_scorer *scorer);
vt_status vt_pipeline_set_wide(vt_pipeline *p, const vt_mlp_model *m, const vt_fulldet_wide_cfg *cfg);
vt_status vt_pipeline_set_refine(vt_pipeline *p, const vt_box_regressor *r);
vt_status vt_pipeline_set_rescore(vt_pipeline *p, const vt_box_rescorer *r);
vt_status vt_pipeline_set_edge_ws(vt_pipeline *p, vt_edge_ws *ws);
vt_status vt_pipeline_set_flow_ws(vt_pipeline *p, vt_flow_state *st);
vt_status vt_pipeline_set_model_ws(vt_pipeline *p, vt_model_ws *ws);
vt_status vt_pipeline_set_ttc_ws(vt_pipeline *p, vt_ttc_state *st);
vt_status vt_pipeline_set_ego_speed(vt_pipeline *p, vt_q16 speed);
vt_status vt_pipeline_step(vt_pipeline *p, const vt_image_u8 *frame, vt_frame_out *out);
vt_status vt_pipeline_step_road(vt_pipeline *p, const vt_image_u8 *frame,
                                const vt_road_area *road, vt_frame_out *out);
vt_status vt_pipeline_step_dets(vt_pipeline *p, const vt_image_u8 *frame, const vt_box *dets,
                                int32_t n_dets, vt_frame_out *out);
vt_status vt_pipeline_work_size(int32_t w, int32_t h, int32_t max_w, int32_t max_h,
                                int32_t *work_w, int32_t *work_h);
vt_status vt_fixed_road_area(const vt_fixed_road *fr, int32_t w, int32_t h, vt_road_area *road);
vt_status vt_fixed_road_check(const vt_fixed_road *fr);
vt_status vt_road_camera_check(const vt_road_camera *rc);
vt_status vt_pipeline_set_acf(vt_pipeline *p, const vt_acf_model *m, const vt_acf_cfg *cfg,
                              vt_acf_ws *ws);
vt_status vt_pipeline_set_acf_n(vt_pipeline *p, int32_t n, const vt_acf_model *const *m,
                                const vt_acf_cfg *const *cfg, vt_acf_ws *ws);
vt_status vt_pipeline_set_cnn(vt_pipeline *p, const vt_cnn_model *m, const vt_cnn_cfg *cfg,
                              uint8_t *work, size_t work_bytes);
