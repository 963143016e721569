/* windows.h: flat-road bounded sliding windows, camera road area, NMS. */
#define VT_WIN_MAX_SIZES ...
#define VT_WIN_MAX_LEVELS ...
#define VT_MAX_NMS_BOXES ...
#define VT_SRC_SHADOW ...
#define VT_SRC_WINDOW ...

typedef struct {
    int32_t fx_q4;
    int32_t horizon_y;
    int32_t height_mm;
    int32_t hood_y;
} vt_camera_min;

typedef struct {
    int32_t veh_w_min_mm;
    int32_t veh_w_max_mm;
    int32_t n_sizes;
    int32_t size[...];
    int32_t step_q8;
    int32_t levels;
    int32_t lane_w_mm;
    int32_t top_margin;
} vt_win_cfg;

typedef struct { int32_t level; int32_t size; int32_t x; int32_t y; } vt_window;
typedef struct { vt_box box; int32_t score; int32_t source; } vt_scored_box;

vt_status vt_win_cfg_default(vt_win_cfg *cfg);
vt_status vt_win_cfg_check(const vt_win_cfg *cfg);
vt_status vt_camera_min_check(const vt_camera_min *cam);
vt_status vt_camera_min_row_distance(const vt_camera_min *cam, int32_t row, int32_t *mm);
vt_status vt_road_from_camera(const vt_win_cfg *cfg, const vt_camera_min *cam, int32_t w,
                              int32_t h, vt_road_area *road);
vt_status vt_windows_level(const vt_win_cfg *cfg, const vt_camera_min *cam,
                           const vt_road_area *road, int32_t w, int32_t h, int32_t level,
                           vt_window *out, int32_t cap, int32_t *n_out);
vt_status vt_nms(vt_scored_box *boxes, int32_t n, int32_t iou_permille, int32_t contain_permille,
                 int32_t *n_out);
