/* lane.h: lane lines and the road area (thesis sec. 2.4.1). */
#define VT_LANE_MAX_WORK_W ...
#define VT_LANE_MAX_WORK_H ...
#define VT_LANE_MAX_MARKS ...
#define VT_LANE_MAX_ROW_MARKS ...
#define VT_LANE_MAX_THETA ...
#define VT_LANE_ACC_CELLS ...
#define VT_LANE_MAX_PEAKS ...
#define VT_LANE_MAX_VERTS ...
#define VT_LANE_MAX_LINES ...

typedef enum { VT_LANE_LEFT_MOST, VT_LANE_LEFT, VT_LANE_RIGHT, VT_LANE_RIGHT_MOST,
               VT_LANE_SLOTS, ... } vt_lane_side;
#define VT_LANE_MAX_SCALE ...

typedef enum { VT_LANE_NONE, VT_LANE_FOUND, VT_LANE_HELD, ... } vt_lane_state_code;

typedef struct {
    int32_t work_width_max;
    int32_t work_height_max;
    int32_t roi_top_permille;
    int32_t hough_top_permille;
    int32_t grad_min;
    int32_t noise_gain_q4;
    int32_t mark_w_top_permille;
    int32_t mark_w_bottom_permille;
    int32_t mark_wmin_top_permille;
    int32_t mark_wmin_bottom_permille;
    int32_t marks_per_row_max;
    int32_t marks_max;
    int32_t theta_min_qdeg;
    int32_t theta_max_qdeg;
    int32_t theta_step_qdeg;
    int32_t rho_step_shift;
    int32_t vote_min;
    int32_t vote_min_permille;
    int32_t nms_theta_bins;
    int32_t nms_rho_bins;
    int32_t max_peaks;
    int32_t merge_permille;
    int32_t min_dtheta_qdeg;
    int32_t ego_theta_max_qdeg;
    int32_t ego_vote_permille;
    int32_t vp_x_permille;
    int32_t vp_low_permille;
    int32_t vp_tol_permille;
    int32_t vp_tol_min;
    int32_t lane_w_min_permille;
    int32_t lane_w_max_permille;
    int32_t refine_iters;
    int32_t refine_tol_permille;
    int32_t refine_tol_min;
    int32_t fit_min_points;
    int32_t seg_min;
    int32_t seg_permille;
    int32_t bend_q8;
    int32_t seg_count_min;
    int32_t seg_count_permille;
    int32_t seg_miss_max;
    int32_t win_bottom_permille;
    int32_t win_top;
    int32_t vp_margin;
    int32_t top_margin_permille;
    int32_t track_alpha_permille;
    int32_t track_hold;
    int32_t track_gate_permille;
    int32_t solo_vote_permille;
} vt_lane_cfg;

typedef struct {
    int32_t state;
    int32_t held;
    int32_t votes;
    int32_t theta_bin;
    int32_t rho_bin;
    vt_angle_qdeg theta;
    int32_t rho;
    vt_q16 xb;
    vt_q16 slope;
    int32_t n_verts;
    int32_t vy[...];
    vt_q16 vx[...];
    int32_t y_top;
} vt_lane_line;

typedef struct {
    int32_t shift;
    int32_t scale;
    int32_t w;
    int32_t h;
    int32_t roi_top;
    int32_t band_top;
    int32_t vp_known;
    int32_t vp_y;
    int32_t n_marks;
    int32_t rows_dropped;
    vt_lane_line lines[...];
    int32_t n_lines_all;
    int32_t lines_all_dropped;
    int32_t lines_all_slot[...];
    vt_lane_line lines_all[...];
    int32_t pair_vp_y;
} vt_lane_result;

typedef struct { ...; } vt_lane_state;

vt_status vt_lane_cfg_default(vt_lane_cfg *cfg);
vt_status vt_lane_cfg_check(const vt_lane_cfg *cfg);
vt_status vt_lane_reset(vt_lane_state *st);
vt_status vt_lane_detect(vt_lane_state *st, const vt_lane_cfg *cfg, const vt_image_u8 *img,
                         vt_lane_result *res, vt_road_area *road);
vt_status vt_lane_road_all(const vt_lane_result *res, int32_t img_w, int32_t img_h,
                           vt_road_area *road);
vt_status vt_lane_line_x(const vt_lane_line *line, vt_q16 y, vt_q16 *x);
