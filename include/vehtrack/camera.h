/* vehtrack/camera.h -- flat-road camera geometry, distance, time to collision and
 * forward-collision warning (IVVI paper sec. 4: distance of a vehicle from the row
 * of its bottom edge for a camera tilted towards the road, eq. 1; the distance
 * error for +-delta px, eq. 3-6, which sets the measurement noise of the distance
 * filter; the pitch corrected from the vanishing point of the lane lines).
 *
 * Three independent pieces, each its own struct, none inside another stage's state:
 *   - vt_camera_cfg (const, may live in flash): intrinsics, height, nominal pitch and
 *     its validity limits. vt_camera_row_distance / vt_camera_box_distance map a
 *     row / a box to metres.
 *   - vt_pitch_state: the per-frame pitch estimate from the lanes' vanishing row,
 *     smoothed, clamped to the calibration limits; an implausible vanishing row keeps
 *     the last good pitch and says so (vt_pitch_flag).
 *   - vt_range_state: per tracker id, a 3-state Kalman filter on distance [d, d', d'']
 *     (constant relative acceleration, so a braking lead's rate does not lag) whose R
 *     is set per measurement from eq. 6, TTC from the filtered distance and
 *     rate, TTC from the box's scale change, and the forward-collision warning state
 *     machine (vt_fcw_step). It is updated from vt_tracker_step's outputs.
 *
 * Cost: sizeof(vt_range_state) = 8 + VT_MAX_TRACKS * sizeof(vt_range_track) (2,472 bytes
 * each on x86-64, 2,360 of it the vt_kf): 39,560 bytes at the defaults; vt_pitch_state 20
 * bytes, vt_camera_cfg 68, vt_range_cfg 88 (both const, may live in flash).
 * Work per track and frame: one 3-state Kalman predict + update (about 150 multiplies),
 * 3 divisions for the distances, 2 for the TTCs. No frame access.
 *
 * Number formats (all named in the fields):
 *   - vt_q16 (Q15.16) for px (fx, fy, cx, cy, rows), metres (range +-32768 m,
 *     resolution 15 um), seconds, m/s and m/s^2;
 *   - the pitch is carried as tan(pitch) in Q16 (positive = looking down towards
 *     the road), resolution 1.5e-5 rad near 0, because every formula needs the
 *     tangent and the vanishing row gives it directly: tan(pitch) = (cy - vp_row) / fy.
 * Distances are horizontal, from the camera's foot point to where the vehicle's bottom
 * edge touches the road (the flat-road model). */
#ifndef VEHTRACK_CAMERA_H
#define VEHTRACK_CAMERA_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/fixed.h"
#include "vehtrack/kalman.h"
#include "vehtrack/lane.h"
#include "vehtrack/status.h"
#include "vehtrack/tracker.h"
#include "vehtrack/verify.h"

/* Largest distance reported (m); rows at or above the horizon, or nearer to it than
 * this distance, saturate to it with the VT_DIST_VALID flag cleared. */
#define VT_DIST_MAX_M 1000
/* Width/TTC history kept per range track (frames). */
#ifndef VT_RANGE_HIST
#define VT_RANGE_HIST 16
#endif
#if VT_RANGE_HIST < 2 || VT_RANGE_HIST > 256
#error "VT_RANGE_HIST must be in 2..256"
#endif

/* Camera (pixels of the input frame). vt_camera_cfg_check() states the ranges. */
typedef struct vt_camera_cfg {
    int32_t img_w;            /* frame size the intrinsics are for, 1..32767 (the    */
    int32_t img_h;            /* camera reads no pixels, so any frame size is fine)  */
    vt_q16 fx;                /* focal lengths, px, 1..16384                         */
    vt_q16 fy;
    vt_q16 cx;                /* principal point, px, within [-img, 2 img]           */
    vt_q16 cy;
    vt_q16 height;            /* camera height above the road, m, (0, 100]           */
    vt_q16 tan_pitch;         /* nominal pitch, tan, [tan_pitch_min, tan_pitch_max]  */
    vt_q16 tan_pitch_min;     /* calibration validity limits of the per-frame pitch, */
    vt_q16 tan_pitch_max;     /* |.| <= 1 (45 degrees)                               */
    vt_q16 pitch_max_step;    /* a vanishing row moving tan(pitch) more than this
                                 from the current estimate is an outlier, (0, 1]     */
    int32_t pitch_alpha_permille; /* smoothing gain toward a plausible measurement,
                                 permille, 0..1000: tan_pitch += (m - tan_pitch) a / 1000,
                                 the step rounded half away from zero (Q16 LSB)     */
    int32_t pitch_reacquire;  /* after this many consecutive outliers inside the
                                 limits that agree with one another (each within
                                 pitch_max_step of the first), jump to the
                                 measurement (1..1000)                               */
    vt_q16 delta_px;          /* row error +-delta of eq. 3-6, px, (0, 64]           */
    vt_q16 bottom_offset;     /* added to a box's bottom row to get the road contact
                                 row, px, [-8, 8] (0.5: the lower edge of the row)   */
    vt_q16 vehicle_width;     /* assumed vehicle width for the cross-check, m, (0, 10] */
    int32_t width_tol_permille;/* the two distances agree within this permille, 10..10000 */
    vt_q16 lateral;           /* the camera's mounting offset, m, right of the ego car's
                                 centre line positive, [-5, 5]: the ego corridor of the
                                 collision warning (vt_range_cfg.path_half_width) is
                                 centred on the car, at X = -lateral in camera metres.
                                 Distances stay in the camera's frame.               */
} vt_camera_cfg;

/* 1242 x 375 KITTI-like defaults (f = 721.5 px, 1.65 m, no pitch); a real camera
 * needs its own values (pyvehtrack.camera builds them from a camera file). */
#define VT_CAMERA_CFG_DEFAULT                     \
    {                                             \
        .img_w = 1242,                            \
        .img_h = 375,                             \
        .fx = 47286695,                           \
        .fy = 47286695,                           \
        .cx = 39948078,                           \
        .cy = 11328160,                           \
        .height = 108134,                         \
        .tan_pitch = 0,                           \
        .tan_pitch_min = -3434, /* tan(-3 deg) */ \
        .tan_pitch_max = 3434, /* tan(3 deg) */   \
        .pitch_max_step = 1311, /* 0.02 */        \
        .pitch_alpha_permille = 250,              \
        .pitch_reacquire = 5,                     \
        .delta_px = VT_Q16_ONE,                   \
        .bottom_offset = VT_Q16_ONE / 2,          \
        .vehicle_width = 117965, /* 1.8 m */      \
        .width_tol_permille = 250,                \
        .lateral = 0,                             \
    }

/* VT_OK if every field is in range, else VT_E_ARG (VT_E_SIZE for img_w/img_h). */
vt_status vt_camera_cfg_check(const vt_camera_cfg *cam);

/* *cam = VT_CAMERA_CFG_DEFAULT. */
vt_status vt_camera_cfg_default(vt_camera_cfg *cam);

/* Flat-road distance (eq. 1) of the road point seen at `row` (Q16 px, input frame)
 * with tan(pitch) = tp (Q16):
 *     v = row - cy,   Y = h (fy - v tp) / (v + fy tp)
 * (Y = h / tan(pitch + atan(v / fy)); tp = 0 gives Stein's Y = h fy / v).
 * Scaling: numerator h * (fy - v tp) and denominator v + fy tp are exact in int64
 * (products rounded half up to Q16 once), one division rounded half away from zero.
 * Relative error <= 2^-16 * (fy / (v + fy tp) + 1), i.e. < 1e-4 for rows at least
 * 1 px below the horizon at fy <= 4096. A row at or above the horizon
 * (v + fy tp <= 0), or one giving more than VT_DIST_MAX_M, gives
 * *dist = VT_DIST_MAX_M m and *valid = 0; a ray pointing behind the camera's foot
 * point (fy - v tp <= 0) gives 0 and *valid = 0; otherwise *valid = 1. VT_E_ARG for NULL
 * or a camera failing vt_camera_cfg_check, or |tp| > 1. */
vt_status vt_camera_row_distance(const vt_camera_cfg *cam, vt_q16 tp, vt_q16 row, vt_q16 *dist,
                                 int32_t *valid);

/* Flags of vt_distance. */
#define VT_DIST_VALID 1        /* bottom row below the horizon, distance < max      */
#define VT_DIST_FAR_VALID 2    /* row - delta is below the horizon too              */
#define VT_DIST_WIDTH_AGREES 4 /* |dist_width - dist| <= width_tol_permille of dist */
#define VT_DIST_BOTTOM_CLIPPED 8 /* the box ends on the frame's last row: its contact
                                    row is not seen, so VT_DIST_VALID is cleared     */
#define VT_DIST_SIDE_CLIPPED 16  /* the box touches the left or right frame edge:
                                    its width is not the vehicle's                   */

/* One box's distances (metres, Q16). */
typedef struct vt_distance {
    int32_t flags;       /* VT_DIST_* */
    vt_q16 distance;     /* eq. 1 at the contact row bottom + bottom_offset           */
    vt_q16 dist_near;    /* eq. 3: at contact row + delta                              */
    vt_q16 dist_far;     /* eq. 3: at contact row - delta (VT_DIST_MAX_M if above horizon) */
    vt_q16 sigma;        /* eq. 6: (dist_far - dist_near) / 2, the +-delta spread, m  */
    vt_q16 dist_width;   /* fx * vehicle_width / (right - left + 1): the cross-check  */
} vt_distance;

/* Distances of a box (inclusive pixel box of the tracker / detector) with
 * tan(pitch) = tp: the three row distances as vt_camera_row_distance, sigma rounded
 * half up, dist_width with one rounded division (saturating at VT_DIST_MAX_M). A box
 * whose bottom is at or below the last row (img_h - 1) is BOTTOM_CLIPPED and not
 * VALID; one touching column 0 or img_w - 1 is SIDE_CLIPPED.
 * VT_E_ARG for NULL, a bad camera, |tp| > 1, or a box with right < left or
 * bottom < top. */
vt_status vt_camera_box_distance(const vt_camera_cfg *cam, vt_q16 tp, const vt_box *box,
                                 vt_distance *out);

/* --------------------------------------------------------------- pitch from lanes */
typedef enum {
    VT_PITCH_NOMINAL = 0,  /* no vanishing row accepted yet: the nominal pitch        */
    VT_PITCH_MEASURED = 1, /* this frame's vanishing row was accepted (smoothed in)   */
    VT_PITCH_HELD = 2,     /* no vanishing row this frame: last good pitch kept       */
    VT_PITCH_REJECTED = 3  /* implausible vanishing row (outside the limits, or an
                              outlier): last good pitch kept                          */
} vt_pitch_flag;

typedef struct vt_pitch_state {
    vt_q16 tan_pitch;      /* the estimate to use this frame                         */
    int32_t flag;          /* vt_pitch_flag of the last update                       */
    int32_t outliers;      /* consecutive outliers within the limits                 */
    vt_q16 run_tan;        /* tan(pitch) of the run's first outlier (Q16)            */
    int32_t measured;      /* frames whose vanishing row was accepted, saturating    */
} vt_pitch_state;

/* Start from the nominal pitch. VT_E_ARG for NULL or a bad camera. */
vt_status vt_pitch_init(vt_pitch_state *st, const vt_camera_cfg *cam);

/* One frame. vp_valid = 0 (no vanishing point): tan_pitch kept, flag HELD (NOMINAL
 * if nothing was ever measured). Otherwise m = (cy - vp_row) / fy (Q16, one rounded
 * division) is:
 *   - outside [tan_pitch_min, tan_pitch_max]: REJECTED, estimate kept;
 *   - farther than pitch_max_step from the estimate (the nominal pitch at first): an
 *     outlier: REJECTED, kept, unless it is the pitch_reacquire-th outlier of a run
 *     that agrees with itself (each within pitch_max_step of the run's first outlier,
 *     run_tan; a disagreeing outlier starts a new run), then the estimate jumps to m
 *     (MEASURED) -- a lasting change (a load) is followed, scattered wrong rows are not;
 *   - else MEASURED: est += (m - est) * pitch_alpha_permille / 1000, the step rounded
 *     half away from zero.
 * VT_E_ARG for NULL, a bad camera, or vp_valid not 0/1 (state unchanged). */
vt_status vt_pitch_update(vt_pitch_state *st, const vt_camera_cfg *cam, int32_t vp_valid,
                          vt_q16 vp_row);

/* The vanishing row (Q16, input px) where the two ego lane lines (slots LEFT and
 * RIGHT, both not NONE) meet, from their refined straight lines x = xb + slope
 * (y - (H-1)) in working px, mapped to input rows by (y + 1/2) scale - 1/2.
 * *valid = 0 (and *vp_row = 0) when a line is missing or they do not meet above the
 * band (parallel or diverging). img_h must be the input height the lanes were found
 * in: VT_E_SIZE if the working frame does not match it (frame size changed), VT_E_ARG
 * for NULL or a result with scale outside 1..VT_LANE_MAX_SCALE. */
vt_status vt_lane_vanishing_row(const vt_lane_result *res, int32_t img_h, vt_q16 *vp_row,
                                int32_t *valid);

/* ------------------------------------------------ range, TTC and collision warning */
/* Lead-vehicle classes of the NHTSA FCW confirmation test: each has its warning TTC. */
typedef enum {
    VT_LEAD_UNKNOWN = 0,   /* ego speed unknown: the largest threshold applies        */
    VT_LEAD_STOPPED = 1,
    VT_LEAD_SLOWER = 2,
    VT_LEAD_DECEL = 3
} vt_lead_class;

typedef struct vt_range_cfg {
    vt_q16 frame_dt;        /* s per frame, (0, 1]                                    */
    vt_q16 jerk_sigma;      /* process noise of the [d, rate, accel] filter: the std
                               of the relative acceleration's change, m/s^3, (0, 50]  */
    vt_q16 init_sigma_rate; /* initial std of the range rate, m/s, (0, 100]           */
    vt_q16 init_sigma_accel;/* initial std of the range acceleration, m/s^2, (0, 100] */
    vt_q16 sigma_min;       /* floor of the measurement std, m, (0, 100]              */
    int32_t min_frames;     /* filter updates before a TTC is reported, 1..1000       */
    int32_t scale_lag;      /* scale TTC over this many frames, 1..VT_RANGE_HIST-1    */
    vt_q16 ttc_max;         /* s; larger TTCs, or opening, are "no TTC", (0, 1000]   */
    vt_q16 ttc_stopped;     /* NHTSA FCW test: warn by 2.1 s (lead stopped),          */
    vt_q16 ttc_slower;      /* 2.0 s (lead slower), 2.4 s (lead decelerating)         */
    vt_q16 ttc_decel;
    vt_q16 ttc_margin;      /* added to each threshold: the confirmation frames and
                               the filter's lag must not make a warning late, [0, 10] */
    int32_t confirm_frames; /* N: TTC under threshold this many frames in a row, 1..1000 */
    int32_t rearm_frames;   /* no new warning within this many frames after the end
                               of the last one, 0..100000                             */
    int32_t release_frames; /* a warning ends after the condition has been false this
                               many frames in a row (a noisy TTC must not make it
                               flicker), 1..1000                                      */
    vt_q16 min_closing;     /* closing only if the rate < -this, m/s, [0, 100]        */
    vt_q16 stopped_speed;   /* lead speed (ego + rate) below this: stopped, m/s       */
    vt_q16 decel_thresh;    /* range acceleration below -this: the lead decelerates
                               (the ego speed taken as constant, as in the test), m/s^2 */
    int32_t width_min_frames; /* a track's own vehicle width (m) is learnt from frames
                               with a seen contact row; after this many, a frame whose
                               contact row is not seen (a near vehicle below the frame)
                               is measured by its width instead, 1..1000              */
    int32_t width_window;   /* the width is a running mean over about this many
                               frames, 1..1000                                        */
    vt_q16 rear_offset;     /* m subtracted from eq. 1's distance, [0, 5] (0: eq. 1
                               as is): for a bottom edge on the road contact of the
                               rear wheels, the rear overhang (about 1 m on a car).
                               An empirical correction otherwise: on KITTI the box ends
                               at the bumper's lower edge, ~0.37 m above the road, for
                               which eq. 1 with the camera height lowered by that much
                               is the physical model (its error grows with distance,
                               d h_b / (h - h_b), so a constant offset only fits a
                               range of distances; see pyvehtrack.camera.RangeEstimator
                               bottom_height and tools/eval_kitti_range.py)           */
    vt_q16 path_half_width; /* m, [0, 10]; 0: no check. The warning asks for a track in
                               the ego path: its box, at its filtered distance d, must
                               overlap the straight corridor |X| < path_half_width around
                               the optical axis, X = (u - cx) d / fx for its columns u in
                               [left, right + 1). 1.5 m: a car 1.8 m wide in the middle of a
                               3.5-3.75 m lane keeps 0.6 m to a vehicle outside it. A
                               straight corridor: on a curve of radius R the lane's centre
                               moves d^2 / 2R sideways (0.6 m at 25 m on R = 500 m), so a
                               lead far ahead on a tight curve can fall outside it.     */
} vt_range_cfg;

/* jerk 5 m/s^3, margin 0.7 s and release 10 frames were chosen on the synthetic NHTSA
 * scenes' seeds 0-2 at 30 fps (tools/eval_synth_fcw.py reports other seeds). */
#define VT_RANGE_CFG_DEFAULT                \
    {                                       \
        .frame_dt = 6554, /* 0.1 s */       \
        .jerk_sigma = 5 * VT_Q16_ONE,       \
        .init_sigma_rate = 10 * VT_Q16_ONE, \
        .init_sigma_accel = 3 * VT_Q16_ONE, \
        .sigma_min = 3277, /* 0.05 m */     \
        .min_frames = 3,                    \
        .scale_lag = 5,                     \
        .ttc_max = 20 * VT_Q16_ONE,         \
        .ttc_stopped = 137626, /* 2.1 */    \
        .ttc_slower = 131072, /* 2.0 */     \
        .ttc_decel = 157286, /* 2.4 */      \
        .ttc_margin = 45875, /* 0.7 */      \
        .confirm_frames = 3,                \
        .rearm_frames = 30,                 \
        .release_frames = 10,               \
        .min_closing = 19661, /* 0.3 */     \
        .stopped_speed = VT_Q16_ONE,        \
        .decel_thresh = VT_Q16_ONE,         \
        .width_min_frames = 3,              \
        .width_window = 16,                 \
        .rear_offset = 0,                   \
        .path_half_width = 98304, /* 1.5 m */ \
    }

/* VT_OK if every field is in range (see the comments above), else VT_E_ARG. */
vt_status vt_range_cfg_check(const vt_range_cfg *cfg);
vt_status vt_range_cfg_default(vt_range_cfg *cfg);

/* The warning state machine (one per track). */
typedef struct vt_fcw_state {
    int32_t below;       /* consecutive frames with the condition true              */
    int32_t above;       /* consecutive frames with the condition false             */
    int32_t warning;     /* 1 while warning                                          */
    int32_t since_end;   /* frames since the last warning ended (large: never)       */
    int32_t warnings;    /* warnings started so far (saturating)                     */
} vt_fcw_state;

/* FCW outputs (bits). */
#define VT_FCW_WARNING 1     /* warn now                                              */
#define VT_FCW_ONSET 2       /* the warning started this frame                        */
#define VT_FCW_SUPPRESSED 4  /* the condition held long enough but the rearm time had
                                not passed                                            */

/* One frame of the state machine. cond = ttc_valid && closing && ttc <= threshold
 * + ttc_margin, threshold by lead class (UNKNOWN: the largest of the three).
 *   below = cond ? below + 1 : 0;  above = cond ? 0 : above + 1;
 *   warning: on -> stays on until above >= release_frames, then off (since_end = 0);
 *            off -> on when below >= confirm_frames and since_end >= rearm_frames
 *                   (else SUPPRESSED); since_end counts frames while off.
 * *out gets the VT_FCW_* bits. VT_E_ARG for NULL, a bad cfg, flags not 0/1 or a lead
 * class out of range (state unchanged). */
vt_status vt_fcw_step(vt_fcw_state *st, const vt_range_cfg *cfg, int32_t ttc_valid, vt_q16 ttc,
                      int32_t closing, int32_t lead_class, int32_t *out);

/* Per-track range memory (private; public for its size). */
typedef struct vt_range_track {
    int32_t id;                       /* tracker id, 0 = free slot                    */
    int32_t updates;                  /* distance measurements filtered               */
    int32_t n_hist;                   /* entries in the rings (<= VT_RANGE_HIST)      */
    int32_t head;                     /* next ring index                              */
    vt_q16 width_hist[VT_RANGE_HIST]; /* box widths, px                               */
    int32_t width_n;                  /* frames the width estimate is made of         */
    vt_q16 width_m;                   /* the vehicle's width learnt from d w / fx, m  */
    vt_fcw_state fcw;
    vt_kf kf;                         /* x = [d (m), rate (m/s), accel (m/s^2)], z = [d] */
} vt_range_track;

typedef struct vt_range_state {
    int32_t frame;
    vt_range_track t[VT_MAX_TRACKS];
} vt_range_state;

/* Flags of vt_range_out. */
#define VT_RANGE_DIST_VALID 1       /* distance measured this frame (below horizon)   */
#define VT_RANGE_FILT_VALID 2       /* the filter holds a distance                    */
#define VT_RANGE_TTC_DIST_VALID 4   /* ttc_dist is a TTC (closing, <= ttc_max)        */
#define VT_RANGE_TTC_SCALE_VALID 8  /* ttc_scale is a TTC (growing, <= ttc_max)       */
#define VT_RANGE_WIDTH_AGREES 16    /* the width cross-check agrees                   */
#define VT_RANGE_CLOSING 32         /* rate < -min_closing                            */
#define VT_RANGE_FROM_WIDTH 64      /* this frame's distance is fx * width_m / w_px,
                                       the contact row not being seen                 */
#define VT_RANGE_IN_PATH 128        /* the box at dist_filt overlaps the ego corridor
                                       (cfg.path_half_width; always set when it is 0);
                                       the warning's TTC counts only with it          */

/* Per track and frame. */
typedef struct vt_range_out {
    int32_t id;
    int32_t flags;       /* VT_RANGE_*                                                */
    int32_t fcw;         /* VT_FCW_* bits                                            */
    int32_t lead_class;  /* vt_lead_class used for the threshold                     */
    vt_q16 distance;     /* measured this frame, m (eq. 1, or the learnt width)      */
    vt_q16 sigma;        /* its +-delta spread (eq. 6; width: d 2 delta / w), m:
                            sqrt(R) of this update                                   */
    vt_q16 dist_width;   /* width cross-check, m                                     */
    vt_q16 dist_filt;    /* filtered distance, m                                     */
    vt_q16 rate;         /* filtered range rate, m/s (negative: closing)             */
    vt_q16 accel;        /* filtered range acceleration, m/s^2                       */
    vt_q16 ttc_dist;     /* dist_filt / -rate, s                                     */
    vt_q16 ttc_scale;    /* scale_lag frame_dt / (w_t / w_{t-lag} - 1), s            */
} vt_range_out;

/* Empty the range stage. VT_E_ARG for NULL. */
vt_status vt_range_init(vt_range_state *st);

/* One frame, after vt_tracker_step. For each of tracks[0..n_tracks-1] (FREE ones are
 * skipped): find or open the slot of its id (slots of ids absent this frame are freed
 * first); distance of its box with tan(pitch) = tp (VALID and not SIDE_CLIPPED: the
 * width estimate learns d w / fx); if the row distance is not valid but the width has
 * been learnt over width_min_frames and the box is not SIDE_CLIPPED, the distance is
 * fx width_m / w (FROM_WIDTH); the filter predicts one frame and, if there is a
 * distance, updates with R = max(sigma, sigma_min)^2; the width goes
 * into the ring; TTCs, lead class (from ego_speed, m/s, negative = unknown; unknown too
 * while the filter's rate variance P[1][1] exceeds stopped_speed^2, a young track's rate
 * not yet known to within the class boundary; then stopped if ego + rate < stopped_speed,
 * else decelerating if accel < -decel_thresh, else slower; unknown takes the largest
 * threshold) and
 * vt_fcw_step. A new id starts its filter at the measured distance (or waits for a
 * valid one). The FCW condition holds only for a track IN_PATH (cfg.path_half_width)
 * with a distance this frame (DIST_VALID: not the filter's prediction alone).
 * Writes one vt_range_out per non-free track, in input order, up to
 * out_cap; *n_out = their number. VT_E_CAPACITY if more than out_cap or
 * VT_MAX_TRACKS ids (out still filled as far as it goes), VT_E_ARG for NULL, bad
 * cfgs, |tp| > 1, n_tracks < 0, or a duplicate id (state unchanged for VT_E_ARG). */
vt_status vt_range_step(vt_range_state *st, const vt_range_cfg *cfg, const vt_camera_cfg *cam,
                        vt_q16 tp, vt_q16 ego_speed, const vt_track_out *tracks,
                        int32_t n_tracks, vt_range_out *out, int32_t out_cap, int32_t *n_out);

/* The block-scale TTC P (vehtrack/ttc_scale.h) and the distance/rate TTC D in one, both
 * Q16 s, a negative value meaning "not known" (0 is a TTC: now): both known,
 * (P (1000 - w) + D w + 500) / 1000 with w = weight_permille on D (0..1000; floor, exact
 * in int64 as P, D < 2^31); one known, that one; neither, -1. The two err in opposite
 * directions on KITTI (the block scale lags a falling TTC, the filtered distance's rate
 * overshoots). vt_pipe_track.ttc_fused_q16 and, with the block-scale TTCs given, the
 * warning's TTC (vt_range_step_fused).
 * VT_E_ARG for NULL or w outside 0..1000 (*fused untouched). */
vt_status vt_ttc_fuse(vt_q16 points, vt_q16 dist, int32_t weight_permille, vt_q16 *fused);

/* vt_range_step, with each track's block-scale TTC: ttc_points[i] for tracks[i] (Q16 s,
 * negative: none; ttc_points NULL: none for any track). The warning then decides on
 * vt_ttc_fuse(ttc_points[i], the distance/rate TTC, fuse_permille) instead of the
 * distance/rate TTC alone, behind the same gates (IN_PATH, a distance this frame,
 * CLOSING, the lead's class); every output field but fcw is vt_range_step's. The fused
 * TTC errs less (rendered NHTSA scenes: 5.2% median against 7.5%; held-out KITTI frames:
 * 13.3% against 29.6%) and its warning passes the rendered NHTSA scenes, but with less
 * margin on a decelerating lead (0.03 s against 0.29 s through the pipeline on seeds
 * 15-29; the block scale lags a falling TTC), so the pipeline asks for it only with
 * vt_pipeline_cfg.fcw_fused. vt_range_step is this with ttc_points NULL.
 * VT_E_ARG as vt_range_step, and for fuse_permille outside 0..1000. */
vt_status vt_range_step_fused(vt_range_state *st, const vt_range_cfg *cfg, const vt_camera_cfg *cam,
                              vt_q16 tp, vt_q16 ego_speed, const vt_track_out *tracks,
                              int32_t n_tracks, const vt_q16 *ttc_points, int32_t fuse_permille,
                              vt_range_out *out, int32_t out_cap, int32_t *n_out);

#endif /* VEHTRACK_CAMERA_H */
