/* vehtrack/windows.h -- hypotheses over the whole road: sliding windows on a
 * Gaussian pyramid whose size at each row is bounded by flat-road geometry (IVVI
 * paper sec. 4/5: the road restriction, a vehicle's image width follows from its
 * distance, hence from its row), the camera-aware road area used when no lanes
 * are found, and non-maximum suppression of scored boxes in the caller's array.
 *
 * Flat road: a point on the road at image row y lies at distance
 * Z = fx * H / (y - y_h) (H the camera height, y_h the horizon row); an object of
 * width W at that distance is fx * W / Z = W * (y - y_h) / H pixels wide. So the
 * width band of a vehicle standing at row y, W in [w_min, w_max] metres, needs
 * only the horizon and the camera height: S * H in [w_min * d, w_max * d] with
 * S the window width in input px and d = y - y_h. All of it is integer (mm, px),
 * compared exactly in int64; no rounding anywhere in the window rules.
 *
 * Cost: no state. vt_windows_level: one pass over the level's rows and, for
 * rows in the band, its columns (a compare per window). vt_nms: in place,
 * O(n^2) compares (n <= VT_MAX_NMS_BOXES). vt_road_from_camera: one pass over
 * the rows. */
#ifndef VEHTRACK_WINDOWS_H
#define VEHTRACK_WINDOWS_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/road.h"
#include "vehtrack/status.h"
#include "vehtrack/verify.h"

/* Window sizes per pyramid level and levels searched (capacities of vt_win_cfg). */
#ifndef VT_WIN_MAX_SIZES
#define VT_WIN_MAX_SIZES 4
#endif
#ifndef VT_WIN_MAX_LEVELS
#define VT_WIN_MAX_LEVELS 6
#endif
/* Most boxes vt_nms takes in one call (it is O(n^2)). */
#ifndef VT_MAX_NMS_BOXES
#define VT_MAX_NMS_BOXES 8192
#endif
#if VT_WIN_MAX_SIZES < 1 || VT_WIN_MAX_LEVELS < 1 || VT_WIN_MAX_LEVELS > 12 || \
    VT_MAX_NMS_BOXES < 1 || VT_MAX_NMS_BOXES > 65535
#error "window capacities out of range (see vehtrack/windows.h)"
#endif

/* The smallest camera model the road restriction needs (the full model, with
 * pitch and distance tables, is the geometry stage's). Input-frame pixels. */
typedef struct {
    int32_t fx_q4;      /* focal length, px in Q4 (1/16 px), 16..2^24; for distances */
    int32_t horizon_y;  /* row of the flat road's horizon, -VT_MAX_HEIGHT..VT_MAX_HEIGHT */
    int32_t height_mm;  /* camera height above the road, 100..20000 mm */
    int32_t hood_y;     /* first row of the ego vehicle's hood (h, or more, if none);
                           rows >= this are never road, 1..2*VT_MAX_HEIGHT */
} vt_camera_min;

/* Window rules (const: may live in flash). */
typedef struct {
    int32_t veh_w_min_mm;             /* vehicle width band, mm: 100..veh_w_max_mm       */
    int32_t veh_w_max_mm;             /* ... ..20000 (IVVI: 1.4-2.6 m; trucks 2.6 m)      */
    int32_t n_sizes;                  /* window sizes per level, 1..VT_WIN_MAX_SIZES      */
    int32_t size[VT_WIN_MAX_SIZES];   /* square window side in level px, 4..1024          */
    int32_t step_q8;                  /* step = max(1, size * step_q8 >> 8) level px, 1..1024 */
    int32_t levels;                   /* levels 0..levels-1 searched, 1..VT_WIN_MAX_LEVELS */
    int32_t lane_w_mm;                /* lane width for the camera road, 1000..10000 mm   */
    int32_t top_margin;               /* camera road starts this many rows below the
                                         horizon, 0..VT_MAX_HEIGHT                        */
} vt_win_cfg;

/* Defaults: the IVVI paper's 1.4-2.6 m band, 32 and 45 px windows (a half-octave
 * apart: two sizes per pyramid level cover every width at <= 2^(1/4) ratio),
 * a quarter-window step, five levels (32 .. 720 px at the input), a 3.7 m lane. */
#define VT_WIN_CFG_DEFAULT      \
    {                           \
        .veh_w_min_mm = 1400,   \
        .veh_w_max_mm = 2600,   \
        .n_sizes = 2,           \
        .size = {32, 45, 0, 0}, \
        .step_q8 = 64,          \
        .levels = 5,            \
        .lane_w_mm = 3700,      \
        .top_margin = 2,        \
    }

/* One window: level, side, top-left corner in level pixels. Its box in input
 * pixels is [x << level, (x + size) << level) x [y << level, (y + size) << level). */
typedef struct {
    int32_t level;
    int32_t size;
    int32_t x;
    int32_t y;
} vt_window;

/* Box sources. */
#define VT_SRC_SHADOW 1 /* shadow hypothesis verified by vertical edges */
#define VT_SRC_WINDOW 2 /* sliding window accepted by the classifier    */

/* A box with its score (higher = more sure; a source's own scale) and source. */
typedef struct {
    vt_box box;
    int32_t score;
    int32_t source;
} vt_scored_box;

/* *cfg = VT_WIN_CFG_DEFAULT. */
vt_status vt_win_cfg_default(vt_win_cfg *cfg);

/* VT_OK if every field is in its range (above), sizes strictly increasing; else
 * VT_E_ARG (VT_E_CAPACITY for n_sizes > VT_WIN_MAX_SIZES or levels >
 * VT_WIN_MAX_LEVELS). */
vt_status vt_win_cfg_check(const vt_win_cfg *cfg);

/* VT_OK if every field of *cam is in its range (above), else VT_E_ARG. */
vt_status vt_camera_min_check(const vt_camera_min *cam);

/* Distance along the road (mm) of the road point at input row `row`:
 * fx * H / (row - horizon), rounded half up, saturated to INT32_MAX. VT_E_ARG if
 * row <= horizon (no road point there). Exact int64 arithmetic. */
vt_status vt_camera_min_row_distance(const vt_camera_min *cam, int32_t row, int32_t *mm);

/* The road area when no lanes are found: every column of rows
 * max(0, horizon + top_margin) .. min(h, hood_y) - 1 (valid = 0 if that is
 * empty), lane_width[y] = lane_w_mm * (y - horizon) / height_mm px, rounded half
 * up, clamped to 1..32767. Rows outside the area hold 0. w, h: the input frame,
 * 1..VT_MAX_WIDTH x 1..VT_MAX_HEIGHT (else VT_E_SIZE). */
vt_status vt_road_from_camera(const vt_win_cfg *cfg, const vt_camera_min *cam, int32_t w,
                              int32_t h, vt_road_area *road);

/* The windows of pyramid level `level` (0..cfg->levels-1) of a w x h input frame
 * (level sizes: w_{l+1} = (w_l + 1) / 2, as vt_pyr_down). For each size s of
 * cfg (in order), a window at level corner (x, y) is kept when
 *   - it lies inside the level image;
 *   - its bottom input row b = ((y + s) << level) - 1 is below the horizon,
 *     above the hood (b < hood_y), inside the road rows (road->y_top..y_bottom;
 *     a NULL or invalid road restricts nothing), and the flat-road width band
 *     holds: veh_w_min * d <= (s << level) * height <= veh_w_max * d, d = b - horizon;
 *   - its centre column c = ((x << level) + ((x + s) << level) - 1) >> 1 lies in
 *     road->x_left[b]..x_right[b] (any column for no road).
 * Rows: from the first kept y (smallest), every step-th row while they are kept;
 * columns: x = 0, step, 2 step, ... (step = max(1, s * step_q8 >> 8)). Output order:
 * size, then y, then x. At most cap windows are written to out (out may be NULL if
 * cap is 0); *n_out is the number of windows the level has (may exceed cap: then
 * out holds the first cap). Errors: NULLs, cap < 0, a bad cfg or cam -> VT_E_ARG;
 * w, h out of 1..VT_MAX_* -> VT_E_SIZE; level out of range -> VT_E_ARG; a road
 * made for another height -> VT_E_SIZE. On error *n_out (if not NULL) is 0. */
vt_status vt_windows_level(const vt_win_cfg *cfg, const vt_camera_min *cam,
                           const vt_road_area *road, int32_t w, int32_t h, int32_t level,
                           vt_window *out, int32_t cap, int32_t *n_out);

/* Greedy non-maximum suppression in place: boxes are ordered by score,
 * highest first (stable: equal scores keep their input order); going down that
 * order, a box is dropped when it overlaps an already kept box with
 *   inter * 1000 > iou_permille * union          (IoU above iou_permille / 1000), or
 *   inter * 1000 > contain_permille * min(area)  (mostly inside the other box),
 * areas of inclusive boxes ((r - l + 1) * (b - t + 1)), exact in int64. The kept
 * boxes end up in boxes[0..*n_out-1] in that order; the rest of the array is
 * left in an unspecified order. n in 0..VT_MAX_NMS_BOXES (else VT_E_CAPACITY),
 * iou_permille and contain_permille in 0..1000, every box with left <= right, top <= bottom
 * (else VT_E_ARG, nothing moved). boxes may be NULL when n is 0. */
vt_status vt_nms(vt_scored_box *boxes, int32_t n, int32_t iou_permille, int32_t contain_permille,
                 int32_t *n_out);

#endif /* VEHTRACK_WINDOWS_H */
