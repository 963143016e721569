/* camera.h: flat-road geometry, pitch from lanes, range filter, TTC and FCW. */
#define VT_DIST_MAX_M ...
#define VT_RANGE_HIST ...
#define VT_DIST_VALID ...
#define VT_DIST_FAR_VALID ...
#define VT_DIST_WIDTH_AGREES ...
#define VT_DIST_BOTTOM_CLIPPED ...
#define VT_DIST_SIDE_CLIPPED ...
#define VT_FCW_WARNING ...
#define VT_FCW_ONSET ...
#define VT_FCW_SUPPRESSED ...
#define VT_RANGE_DIST_VALID ...
#define VT_RANGE_FILT_VALID ...
#define VT_RANGE_TTC_DIST_VALID ...
#define VT_RANGE_TTC_SCALE_VALID ...
#define VT_RANGE_WIDTH_AGREES ...
#define VT_RANGE_CLOSING ...
#define VT_RANGE_FROM_WIDTH ...
#define VT_RANGE_IN_PATH ...

typedef struct vt_camera_cfg {
    int32_t img_w;
    int32_t img_h;
    vt_q16 fx;
    vt_q16 fy;
    vt_q16 cx;
    vt_q16 cy;
    vt_q16 height;
    vt_q16 tan_pitch;
    vt_q16 tan_pitch_min;
    vt_q16 tan_pitch_max;
    vt_q16 pitch_max_step;
    int32_t pitch_alpha_permille;
    int32_t pitch_reacquire;
    vt_q16 delta_px;
    vt_q16 bottom_offset;
    vt_q16 vehicle_width;
    int32_t width_tol_permille;
    vt_q16 lateral;
} vt_camera_cfg;

vt_status vt_camera_cfg_check(const vt_camera_cfg *cam);
vt_status vt_camera_cfg_default(vt_camera_cfg *cam);
vt_status vt_camera_row_distance(const vt_camera_cfg *cam, vt_q16 tp, vt_q16 row, vt_q16 *dist,
                                 int32_t *valid);

typedef struct vt_distance {
    int32_t flags;
    vt_q16 distance;
    vt_q16 dist_near;
    vt_q16 dist_far;
    vt_q16 sigma;
    vt_q16 dist_width;
} vt_distance;

vt_status vt_camera_box_distance(const vt_camera_cfg *cam, vt_q16 tp, const vt_box *box,
                                 vt_distance *out);

typedef enum { VT_PITCH_NOMINAL, VT_PITCH_MEASURED, VT_PITCH_HELD, VT_PITCH_REJECTED, ... } vt_pitch_flag;

typedef struct vt_pitch_state {
    vt_q16 tan_pitch;
    int32_t flag;
    int32_t outliers;
    vt_q16 run_tan;
    int32_t measured;
} vt_pitch_state;

vt_status vt_pitch_init(vt_pitch_state *st, const vt_camera_cfg *cam);
vt_status vt_pitch_update(vt_pitch_state *st, const vt_camera_cfg *cam, int32_t vp_valid,
                          vt_q16 vp_row);
vt_status vt_lane_vanishing_row(const vt_lane_result *res, int32_t img_h, vt_q16 *vp_row,
                                int32_t *valid);

typedef enum { VT_LEAD_UNKNOWN, VT_LEAD_STOPPED, VT_LEAD_SLOWER, VT_LEAD_DECEL, ... } vt_lead_class;

typedef struct vt_range_cfg {
    vt_q16 frame_dt;
    vt_q16 jerk_sigma;
    vt_q16 init_sigma_rate;
    vt_q16 init_sigma_accel;
    vt_q16 sigma_min;
    int32_t min_frames;
    int32_t scale_lag;
    vt_q16 ttc_max;
    vt_q16 ttc_stopped;
    vt_q16 ttc_slower;
    vt_q16 ttc_decel;
    vt_q16 ttc_margin;
    int32_t confirm_frames;
    int32_t rearm_frames;
    int32_t release_frames;
    vt_q16 min_closing;
    vt_q16 stopped_speed;
    vt_q16 decel_thresh;
    int32_t width_min_frames;
    int32_t width_window;
    vt_q16 rear_offset;
    vt_q16 path_half_width;
} vt_range_cfg;

vt_status vt_range_cfg_check(const vt_range_cfg *cfg);
vt_status vt_range_cfg_default(vt_range_cfg *cfg);

typedef struct vt_fcw_state {
    int32_t below;
    int32_t above;
    int32_t warning;
    int32_t since_end;
    int32_t warnings;
} vt_fcw_state;

vt_status vt_fcw_step(vt_fcw_state *st, const vt_range_cfg *cfg, int32_t ttc_valid, vt_q16 ttc,
                      int32_t closing, int32_t lead_class, int32_t *out);

typedef struct vt_range_track {
    int32_t id;
    int32_t updates;
    int32_t n_hist;
    int32_t head;
    vt_q16 width_hist[...];
    int32_t width_n;
    vt_q16 width_m;
    vt_fcw_state fcw;
    vt_kf kf;
} vt_range_track;

typedef struct vt_range_state {
    int32_t frame;
    vt_range_track t[...];
} vt_range_state;

typedef struct vt_range_out {
    int32_t id;
    int32_t flags;
    int32_t fcw;
    int32_t lead_class;
    vt_q16 distance;
    vt_q16 sigma;
    vt_q16 dist_width;
    vt_q16 dist_filt;
    vt_q16 rate;
    vt_q16 accel;
    vt_q16 ttc_dist;
    vt_q16 ttc_scale;
} vt_range_out;

vt_status vt_range_init(vt_range_state *st);
vt_status vt_range_step(vt_range_state *st, const vt_range_cfg *cfg, const vt_camera_cfg *cam,
                        vt_q16 tp, vt_q16 ego_speed, const vt_track_out *tracks,
                        int32_t n_tracks, vt_range_out *out, int32_t out_cap, int32_t *n_out);
vt_status vt_ttc_fuse(vt_q16 points, vt_q16 dist, int32_t weight_permille, vt_q16 *fused);
vt_status vt_range_step_fused(vt_range_state *st, const vt_range_cfg *cfg, const vt_camera_cfg *cam,
                              vt_q16 tp, vt_q16 ego_speed, const vt_track_out *tracks,
                              int32_t n_tracks, const vt_q16 *ttc_points, int32_t fuse_permille,
                              vt_range_out *out, int32_t out_cap, int32_t *n_out);
