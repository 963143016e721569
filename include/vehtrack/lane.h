/* vehtrack/lane.h -- lane lines and the road area (thesis sec. 2.4.1: [-1 0 1] filter
 * and Hough transform per half image, reduction to left-most/left/right/right-most
 * lines, grouping into a road area, lane tracking over frames).
 *
 * Cost: sizeof(vt_lane_state) = 85,652 bytes on x86-64 at the default capacities: the
 * Hough accumulator (VT_LANE_ACC_CELLS * 2 bytes) is 64 KB of it, marking centres 8 KB,
 * row buffers and per-row indices 4.4 KB, the extension histogram 3.8 KB; no frame
 * buffer: the frame is read once, one working row at a time. vt_lane_result is 2,908
 * bytes (1.9 KB of it lines_all), vt_road_area 6.5 KB. Work per frame, W x H the working frame (the input
 * box-downscaled by the smallest integer k (1..VT_LANE_MAX_SCALE) such that W = w / k
 * <= work_width_max and H = h / k <= work_height_max; 320 x 240 by default, so 640,
 * 960, 1280, 1600 and 1920 px wide 16:9 frames all work at 320 x 180, where the
 * defaults were tuned):
 *   - k^2 adds per working pixel below roi_top (downscale), then ~6 operations per
 *     working pixel for the filter, threshold and edge pairing;
 *   - n_theta (77) votes per marking centre in the Hough band, a window test per
 *     accumulator cell above the vote floor;
 *   - per candidate (<= 2 * max_peaks): refine_iters least-squares passes, one centre
 *     per band row; per kept line (<= 4) ~10 extension segments, one pass each over
 *     the centres of their rows.
 * Measured: 0.23 ms per 640x480 frame, 0.30 ms per 1280x720 frame (gcc -O2, one core).
 *
 * The algorithm, step by step, with the reasons for each addition to the thesis, is in
 * the first comment of c/lane.c and in pyvehtrack/reference/lane.py (the float oracle
 * it is tested against). Coordinates in vt_lane_result are working-frame pixels:
 * input x = (x + 1/2) * k - 1/2, likewise y. The road area is in input pixels.
 *
 * Usage (firmware):
 *     static const vt_lane_cfg cfg = VT_LANE_CFG_DEFAULT;
 *     static vt_lane_state st;         (zero-initialised = fresh tracker)
 *     static vt_lane_result res;
 *     static vt_road_area road;
 *     vt_lane_detect(&st, &cfg, &frame, &res, &road);   once per frame
 */
#ifndef VEHTRACK_LANE_H
#define VEHTRACK_LANE_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/fixed.h"
#include "vehtrack/image.h"
#include "vehtrack/road.h"
#include "vehtrack/status.h"
#include "vehtrack/trig.h"

/* The largest working-frame downscale factor (VT_MAX_WIDTH / 8 fits any work_width_max
 * of 240 or more). */
#define VT_LANE_MAX_SCALE 8

/* Line slots, left to right. */
typedef enum {
    VT_LANE_LEFT_MOST = 0,
    VT_LANE_LEFT = 1,
    VT_LANE_RIGHT = 2,
    VT_LANE_RIGHT_MOST = 3,
    VT_LANE_SLOTS = 4
} vt_lane_side;

/* State of a slot in a frame. */
typedef enum {
    VT_LANE_NONE = 0,     /* no line */
    VT_LANE_FOUND = 1,    /* found in this frame (possibly smoothed with the last one) */
    VT_LANE_HELD = 2      /* marking hidden: last frame's line, re-extended this frame */
} vt_lane_state_code;

/* Configuration, all integers; units in the comments ("permille of W": thousandths of
 * the working width). VT_LANE_CFG_DEFAULT gives the values tuned on all of TuSimple
 * test100 (see README): the set re-chosen by cross-validation on its halves
 * (tools/tune_lanes.py) lost the KITTI lead car (tracking IoU >= 0.6 96.2% -> 70.5%), so
 * it is not the default (see c/lane.c). vt_lane_cfg_check() states the valid ranges. */
typedef struct {
    int32_t work_width_max;       /* box-downscale by k (k <= 8) until W <= this ...     */
    int32_t work_height_max;      /* ... and H <= this                                   */
    int32_t roi_top_permille;     /* rows above H*this/1000 are never looked at          */
    int32_t hough_top_permille;   /* Hough votes come from rows >= H*this/1000           */
    int32_t grad_min;             /* [-1 0 1] threshold floor (gray levels)              */
    int32_t noise_gain_q4;        /* row threshold >= mean |g| of the row * this / 16    */
    int32_t mark_w_top_permille;  /* widest marking (xf - xr) at row 0 / row H-1,        */
    int32_t mark_w_bottom_permille; /* permille of W, linear in between                  */
    int32_t mark_wmin_top_permille; /* narrowest marking, same (at least 1 px)           */
    int32_t mark_wmin_bottom_permille;
    int32_t marks_per_row_max;    /* a row with more centres is texture and is dropped   */
    int32_t marks_max;            /* centres kept per frame, bottom rows first           */
    int32_t theta_min_qdeg;       /* left-half theta range, quarter degrees; the right   */
    int32_t theta_max_qdeg;       /* half uses the mirrored range [-max, -min]           */
    int32_t theta_step_qdeg;
    int32_t rho_step_shift;       /* a rho bin is 2^this working px                      */
    int32_t vote_min;             /* a peak needs >= this many votes ...                 */
    int32_t vote_min_permille;    /* ... and >= (band rows) * this / 1000                */
    int32_t nms_theta_bins;       /* a peak is the maximum of a (2a+1) x (2b+1) window   */
    int32_t nms_rho_bins;
    int32_t max_peaks;            /* candidate lines per half (<= VT_LANE_MAX_PEAKS)     */
    int32_t merge_permille;       /* lines closer than W*this/1000 at both band ends merge */
    int32_t min_dtheta_qdeg;      /* ego vs outer line: angle difference at least this   */
    int32_t ego_theta_max_qdeg;   /* flatter lines can only be outer lines               */
    int32_t ego_vote_permille;    /* an inner line replacing the ego line needs this share
                                     of the strongest line's votes                       */
    int32_t vp_x_permille;        /* vanishing point within cx +- W*this/1000 ...        */
    int32_t vp_low_permille;      /* ... and not below row H*this/1000                   */
    int32_t vp_tol_permille;      /* lane lines pass within W*this/1000 px of it ...     */
    int32_t vp_tol_min;           /* ... or within this many px (small frames)           */
    int32_t lane_w_min_permille;  /* ego lane width at the bottom row, permille of W     */
    int32_t lane_w_max_permille;
    int32_t refine_iters;         /* least-squares passes over the band                  */
    int32_t refine_tol_permille;  /* first pass window W*this/1000 px, halved per pass, */
    int32_t refine_tol_min;       /* ... but never below this many px                    */
    int32_t fit_min_points;       /* fewer points: the line is kept as it was            */
    int32_t seg_min;              /* extension segment rows: at least this ...           */
    int32_t seg_permille;         /* ... else this share of the distance to the VP       */
    int32_t bend_q8;              /* slope change per segment <= this / 256 px per row   */
    int32_t seg_count_min;        /* a segment needs this many centres ...               */
    int32_t seg_count_permille;   /* ... and (segment rows) * this / 1000                */
    int32_t seg_miss_max;         /* without a VP: stop after this many empty segments   */
    int32_t win_bottom_permille;  /* segment window: W*this/1000 px at the bottom row ...*/
    int32_t win_top;              /* ... this many px at the vanishing row               */
    int32_t vp_margin;            /* without a VP: lanes end this far below roi_top      */
    int32_t top_margin_permille;  /* with a VP: lanes end H*this/1000 rows below it      */
    int32_t track_alpha_permille; /* tracker: gain toward the new line, 0..1000; the step
                                     a (new - old) / 1000 rounded half away from zero */
    int32_t track_hold;           /* frames a hidden marking's line is kept              */
    int32_t track_gate_permille;  /* a new line farther than W*this/1000 px replaces the
                                     old one instead of being smoothed with it           */
    int32_t solo_vote_permille;   /* no ego pair meets at a plausible vanishing point (night,
                                     faded markings): a line then needs votes >= the vote
                                     floor * this / 1000 (1000: no extra demand)         */
} vt_lane_cfg;

/* The defaults, each value named by its field. */
#define VT_LANE_CFG_DEFAULT             \
    {                                   \
        .work_width_max = 320,          \
        .work_height_max = 240,         \
        .roi_top_permille = 250,        \
        .hough_top_permille = 500,      \
        .grad_min = 14,                 \
        .noise_gain_q4 = 48,            \
        .mark_w_top_permille = 6,       \
        .mark_w_bottom_permille = 40,   \
        .mark_wmin_top_permille = 0,    \
        .mark_wmin_bottom_permille = 4, \
        .marks_per_row_max = 24,        \
        .marks_max = 4096,              \
        .theta_min_qdeg = 16,           \
        .theta_max_qdeg = 320,          \
        .theta_step_qdeg = 4,           \
        .rho_step_shift = 0,            \
        .vote_min = 8,                  \
        .vote_min_permille = 80,        \
        .nms_theta_bins = 4,            \
        .nms_rho_bins = 8,              \
        .max_peaks = 6,                 \
        .merge_permille = 19,           \
        .min_dtheta_qdeg = 48,          \
        .ego_theta_max_qdeg = 260,      \
        .ego_vote_permille = 500,       \
        .vp_x_permille = 250,           \
        .vp_low_permille = 700,         \
        .vp_tol_permille = 15,          \
        .vp_tol_min = 2,                \
        .lane_w_min_permille = 250,     \
        .lane_w_max_permille = 2000,    \
        .refine_iters = 2,              \
        .refine_tol_permille = 16,      \
        .refine_tol_min = 2,            \
        .fit_min_points = 6,            \
        .seg_min = 3,                   \
        .seg_permille = 500,            \
        .bend_q8 = 128,                 \
        .seg_count_min = 2,             \
        .seg_count_permille = 150,      \
        .seg_miss_max = 1,              \
        .win_bottom_permille = 20,      \
        .win_top = 2,                   \
        .vp_margin = 2,                 \
        .top_margin_permille = 25,      \
        .track_alpha_permille = 500,    \
        .track_hold = 5,                \
        .track_gate_permille = 31,      \
        .solo_vote_permille = 1500,     \
    }

/* One lane line. A line is x(y) = xb + slope * (y - (H-1)) over the Hough band; above
 * it, the polyline through vy/vx (vy decreasing from H-1 to y_top) follows the
 * marking. */
typedef struct {
    int32_t state;         /* vt_lane_state_code */
    int32_t held;          /* frames since the marking was last seen (0 if found)    */
    int32_t votes;         /* Hough votes of the peak                                */
    int32_t theta_bin;     /* accumulator cell of the peak: theta index ...          */
    int32_t rho_bin;       /* ... and rho bin (rho = rho_bin << rho_step_shift)      */
    vt_angle_qdeg theta;   /* normal angle of the peak line, quarter degrees         */
    int32_t rho;           /* its distance from (W/2, H-1), working px               */
    vt_q16 xb;             /* refined (and tracked) line: x at row H-1, working px   */
    vt_q16 slope;          /* dx per row down, Q16                                   */
    int32_t n_verts;       /* polyline: 2..VT_LANE_MAX_VERTS vertices                */
    int32_t vy[VT_LANE_MAX_VERTS];
    vt_q16 vx[VT_LANE_MAX_VERTS];
    int32_t y_top;         /* the line covers working rows y_top..H-1                */
} vt_lane_line;

/* The output of one frame. */
typedef struct {
    int32_t shift;         /* log2(scale) if scale is a power of two, else -1         */
    int32_t scale;         /* working frame = input box-downscaled by this (1..8)     */
    int32_t w;             /* working width and height                               */
    int32_t h;
    int32_t roi_top;       /* first working row looked at                            */
    int32_t band_top;      /* first row of the Hough band                            */
    int32_t vp_known;      /* 1 if the two ego lines meet in rows [roi_top,          */
                           /* H*vp_low_permille/1000] and are >= W*lane_w_min_      */
                           /* permille/2000 apart at the bottom row                  */
    int32_t vp_y;          /* that row (roi_top if unknown)                          */
    int32_t n_marks;       /* marking centres kept                                   */
    int32_t rows_dropped;  /* rows dropped as texture or for lack of room            */
    vt_lane_line lines[VT_LANE_SLOTS];
    /* Every lane line found, left to right by x at the bottom row (xb): the slot lines
     * above (FOUND or HELD) and, when the ego pair gives a vanishing point, every
     * further candidate of a half that passes through it and lies further out than
     * that half's ego line (FOUND, not tracked). lines_all_slot[i] is the slot of
     * lines_all[i] (vt_lane_side) or -1 for a further line. */
    int32_t n_lines_all;
    int32_t lines_all_dropped; /* further lines left out for VT_LANE_MAX_LINES */
    int32_t lines_all_slot[VT_LANE_MAX_LINES];
    vt_lane_line lines_all[VT_LANE_MAX_LINES];
    /* The row where the strongest plausible left/right candidate pair meets (the pair
     * that confirmed the selection; floor of its crossing), -1 if no pair did. Without
     * vp_known (an ego line missing or not in the pair) every line still ends
     * H*top_margin_permille/1000 rows below it: a lone line does not run on past the
     * horizon into texture (trees) above it. */
    int32_t pair_vp_y;
} vt_lane_result;

/* A Hough candidate (internal, in the state for its size). */
typedef struct {
    int32_t votes;
    int32_t theta_bin;
    int32_t rho_bin;
    vt_angle_qdeg theta;
    int32_t rho;
    vt_q16 xb;
    vt_q16 slope;
} vt_lane_cand;

/* Everything the lane stage keeps between and within frames. Caller-owned; zero it
 * (static storage, or vt_lane_reset) before the first frame. Fields are private. */
typedef struct {
    /* tracker: last frame's lines and the working geometry they belong to */
    int32_t prev_valid;
    int32_t prev_scale;
    int32_t prev_w;
    int32_t prev_h;
    vt_lane_line prev[VT_LANE_SLOTS];
    /* row buffers */
    uint16_t colsum[VT_LANE_MAX_WORK_W];
    int16_t grad[VT_LANE_MAX_WORK_W];
    /* marking centres (half px), rows bottom-up; row y holds row_n[y] of them from
     * marks[row_start[y]] */
    int16_t marks[VT_LANE_MAX_MARKS];
    uint16_t row_start[VT_LANE_MAX_WORK_H];
    uint16_t row_n[VT_LANE_MAX_WORK_H];
    /* Hough: one half at a time; theta row k spans rho bins acc_lo[k].. and starts at
     * acc[acc_off[k]] */
    uint16_t acc[VT_LANE_ACC_CELLS];
    int32_t acc_lo[VT_LANE_MAX_THETA];
    int32_t acc_off[VT_LANE_MAX_THETA + 1];
    vt_q14 sin_t[VT_LANE_MAX_THETA];
    vt_q14 cos_t[VT_LANE_MAX_THETA];
    vt_lane_cand cand[2][VT_LANE_MAX_PEAKS];
    int32_t n_cand[2];
    /* extension: difference array over the slope candidates of a segment */
    int32_t hist[2 * VT_LANE_MAX_WORK_H + 3];
} vt_lane_state;

/* *cfg = VT_LANE_CFG_DEFAULT (for bindings, which cannot read the macro). */
vt_status vt_lane_cfg_default(vt_lane_cfg *cfg);

/* VT_OK if every field is in range, else VT_E_ARG (outside its domain) or
 * VT_E_CAPACITY (beyond a compile-time capacity: work_width_max >
 * VT_LANE_MAX_WORK_W, work_height_max > VT_LANE_MAX_WORK_H, marks_per_row_max >
 * VT_LANE_MAX_ROW_MARKS, marks_max > VT_LANE_MAX_MARKS, max_peaks >
 * VT_LANE_MAX_PEAKS, more than VT_LANE_MAX_THETA theta bins). Ranges: sizes >= 16;
 * permille fields 0..1000 (lane_w_*: 0..10000, lane_w_min <= lane_w_max); angles
 * -356..356 qdeg (|theta| <= 89 degrees), theta_min <= theta_max, step >= 1;
 * rho_step_shift 0..3; solo_vote_permille 1000..10000; bend_q8 0..256; noise_gain_q4 0..1024; grad_min 1..255;
 * refine_iters 0..8; refine_tol_min, vp_tol_min 0..4096 px; seg_min >= 1; counts >= 0
 * (fit_min_points >= 2). */
vt_status vt_lane_cfg_check(const vt_lane_cfg *cfg);

/* Forget the tracked lines (next frame starts fresh). Also clears the scratch. */
vt_status vt_lane_reset(vt_lane_state *st);

/* Detect the lane lines of one gray frame and update the tracker.
 *   cfg: vt_lane_cfg_check() must pass; st: the state (tracker + scratch);
 *   img: the frame, 16x16 .. VT_MAX_WIDTH x VT_MAX_HEIGHT, and small enough that a
 *        factor k <= VT_LANE_MAX_SCALE brings it within work_width_max x work_height_max (else
 *        VT_E_SIZE); res: the lines; road: the road area in input pixels, or NULL.
 * The road area (thesis fig. 2.8, the lines grouped): between the left boundary (the
 * left ego line, else the left-most line) and the right one (right, else right-most),
 * from the lower of their top rows down to the last input row, x clamped to the frame;
 * the area ends above the first row (going up) where the boundaries cross. lane_width
 * is the ego lane's width: the boundaries' distance divided by the number of lanes
 * they span (1, 2 or 3). valid = 0 if a side has no line.
 * A change of working geometry resets the tracker. VT_E_CAPACITY if the Hough
 * accumulator of a half would need more than VT_LANE_ACC_CELLS cells (a finer
 * rho/theta step than the capacities were sized for). On an error, res and road are
 * left untouched and the tracker is unchanged. */
vt_status vt_lane_detect(vt_lane_state *st, const vt_lane_cfg *cfg, const vt_image_u8 *img,
                         vt_lane_result *res, vt_road_area *road);

/* The road area over all lanes (issue 8): between lines_all[0] and
 * lines_all[n_lines_all - 1] of res, with the same rules as the ego road area of
 * vt_lane_detect (rows from the lower of the two top rows down, x clamped to the
 * frame, ends above the first crossing row); lane_width = the span divided by
 * n_lines_all - 1 (the mean lane width). img_w x img_h: the input frame res was made
 * from (1..VT_MAX_WIDTH x 1..VT_MAX_HEIGHT, else VT_E_SIZE). valid = 0 with fewer than
 * two lines. VT_E_ARG for NULL pointers or a result whose counts or scale are out of
 * range. */
vt_status vt_lane_road_all(const vt_lane_result *res, int32_t img_w, int32_t img_h,
                           vt_road_area *road);

/* x (Q16, working px) of a line's polyline at working row y (Q16): linear between
 * vertices, the end segments extended beyond them. VT_E_ARG if the line has no
 * polyline (state NONE or n_verts outside 2..VT_LANE_MAX_VERTS). Rounds half away
 * from zero; saturates. */
vt_status vt_lane_line_x(const vt_lane_line *line, vt_q16 y, vt_q16 *x);

#endif /* VEHTRACK_LANE_H */
