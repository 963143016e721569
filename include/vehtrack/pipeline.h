/* vehtrack/pipeline.h -- the whole per-frame system in one call (thesis fig. 4.1
 * and ch. 3): lanes -> road area -> vehicle hypotheses -> verification -> tracker
 * [-> camera geometry]. vt_pipeline holds every stage's configuration and state,
 * the frame counter and the policies; vt_pipeline_step() owns the order. Each
 * stage stays callable on its own; the pipeline only composes them and never
 * reaches into a stage's private state.
 *
 * Cost: sizeof(vt_pipeline) is the library's RAM bill (`make bench` prints it for
 * the default, VGA and 1280x720 builds): the lane stage (its Hough accumulator,
 * 64 KB, dominates at small frames), the tracker (3.7 KB per track plus a
 * projection workspace of 4 * (VT_MAX_WIDTH + VT_MAX_HEIGHT) bytes), the detector's
 * scratch and the road area (6 bytes per row). sizeof(vt_frame_out) is the
 * caller's output (lanes, road area, boxes, tracks). The tracker's edge-curve
 * measurement needs a vt_edge_ws more (327,704 bytes at the defaults), owned by
 * the caller and attached with vt_pipeline_set_edge_ws only when that measurement
 * is used. Work: the stages' own (see their headers); detection runs only every detect_every frames. Stack: the
 * stages' (about 2 KB, the Kalman update), measured in firmware_demo/. */
#ifndef VEHTRACK_PIPELINE_H
#define VEHTRACK_PIPELINE_H

#include <stdint.h>
#include "vehtrack/camera.h"
#include "vehtrack/config.h"
#include "vehtrack/detect.h"
#include "vehtrack/image.h"
#include "vehtrack/lane.h"
#include "vehtrack/road.h"
#include "vehtrack/status.h"
#include "vehtrack/tracker.h"

/* Stages that other modules provide and plug in here, by pointer; NULL means
 * "stage off". The classifier (its quantised weights) is not built in yet, so only
 * its slot exists; the camera (vehtrack/camera.h) is. */
struct vt_svm_model;

/* Hypothesis sources (bit mask in vt_pipeline_cfg.sources). Only the shadow
 * source is built today; asking for another one is VT_E_ARG at init. */
#define VT_SRC_SHADOW 1     /* shadow rows + vertical-edge verification (sec. 2.4.2) */
#define VT_SRC_CLASSIFIER 2 /* classifier windows (needs a model) */
#define VT_SRC_FLOW 4       /* overtaking vehicles from lateral SAD flow */
#define VT_SRC_MODEL 8      /* the 7-parameter vehicle model fitted by a GA */
#define VT_SRC_EXTERNAL 16  /* the caller's detections (vt_pipeline_step_dets); not a policy bit */
#define VT_SRC_BUILT (VT_SRC_SHADOW)

/* Where the road area of a frame came from (vt_frame_out.road_source) and which
 * the pipeline may use (vt_pipeline_cfg.road_policy). */
#define VT_ROAD_SRC_NONE 0
#define VT_ROAD_SRC_LANES 1
#define VT_ROAD_SRC_FIXED 2

#define VT_ROAD_AUTO 0  /* the lanes' road area, else the fixed trapezoid */
#define VT_ROAD_LANES 1 /* the lanes' road area only (no detection without it) */
#define VT_ROAD_FIXED 2 /* always the fixed trapezoid (the lane stage does not run) */

/* "Not known": the value of every distance/TTC field without a camera, or when
 * the geometry cannot say (no filtered distance yet, opening, beyond ttc_max). */
#define VT_UNKNOWN INT32_MIN

/* vt_pipe_track.warning: VT_FCW_UNKNOWN without a camera, else the VT_FCW_* bits
 * of vehtrack/camera.h (0: no warning). */
#define VT_FCW_UNKNOWN (-1)
#define VT_FCW_NONE 0

/* A fixed road area for frames without lane lines: a trapezoid from the bottom
 * row (columns bottom_left..bottom_right, permille of w-1) toward the vanishing
 * point (vp_x, vp_y permille of w-1 and h-1), cut top_margin rows below it; the
 * ego lane width grows linearly from 0 at the vanishing point to
 * lane_bottom_permille of w at the bottom row (flat road, straight lanes). */
typedef struct {
    int32_t vp_x_permille;
    int32_t vp_y_permille;
    int32_t bottom_left_permille;
    int32_t bottom_right_permille;
    int32_t lane_bottom_permille;
    int32_t top_margin;
} vt_fixed_road;

#define VT_FIXED_ROAD_DEFAULT         \
    {                                 \
        .vp_x_permille = 500,         \
        .vp_y_permille = 450,         \
        .bottom_left_permille = 50,   \
        .bottom_right_permille = 950, \
        .lane_bottom_permille = 450,  \
        .top_margin = 4,              \
    }

typedef struct {
    vt_lane_cfg lane;
    vt_detect_cfg detect;
    vt_tracker_cfg tracker;
    vt_range_cfg range;      /* the camera stage's range filter, TTC and FCW (used only
                                with a camera)                                           */
    vt_fixed_road fixed_road;
    int32_t detect_every;    /* detection on frames 0, N, 2N, ... (N >= 1)              */
    int32_t road_policy;     /* VT_ROAD_AUTO / _LANES / _FIXED                          */
    int32_t lanes_every_frame; /* 1: lanes on every frame; 0: on detection frames only
                                  (the road area is needed only there)                 */
    int32_t sources;         /* VT_SRC_* mask of hypothesis sources; 0: none (detections
                                come only from the caller, vt_pipeline_step_dets)        */
    int32_t track;           /* 1: the tracker runs; 0: detection only (no tracks)       */
} vt_pipeline_cfg;

#define VT_PIPELINE_CFG_DEFAULT              \
    {                                        \
        .lane = VT_LANE_CFG_DEFAULT,         \
        .detect = VT_DETECT_CFG_DEFAULT,     \
        .tracker = VT_TRACKER_CFG_DEFAULT,   \
        .range = VT_RANGE_CFG_DEFAULT,       \
        .fixed_road = VT_FIXED_ROAD_DEFAULT, \
        .detect_every = 10,                  \
        .road_policy = VT_ROAD_AUTO,         \
        .lanes_every_frame = 0,              \
        .sources = VT_SRC_SHADOW,            \
        .track = 1,                          \
    }

/* Everything the pipeline keeps. Caller-owned (static storage on firmware);
 * initialise with vt_pipeline_init. Fields are private: read the output. */
typedef struct {
    vt_pipeline_cfg cfg; /* a checked copy */
    const struct vt_svm_model *model;
    const vt_camera_cfg *camera; /* NULL: no geometry */
    int32_t frame;    /* frames stepped so far */
    vt_q16 ego_speed; /* m/s, negative = unknown (vt_pipeline_set_ego_speed) */
    vt_lane_state lane;
    vt_detect_state detect;
    vt_detect_result det;
    vt_tracker tracker;
    vt_track_out tracks[VT_MAX_TRACKS];
    vt_pitch_state pitch;  /* camera stage: pitch from the lanes' vanishing row */
    vt_range_state range;  /* camera stage: per-track range filter and FCW state */
    vt_range_out ranges[VT_MAX_TRACKS];
} vt_pipeline;

/* A detected box and the source that proposed it. score: the source's confidence
 * (the shadow source has none and gives VT_UNKNOWN). */
typedef struct {
    vt_box box;
    int32_t source; /* one VT_SRC_* bit */
    int32_t score;
} vt_pipe_box;

/* A track with its geometry (camera stage, vt_range_step): distance_mm the filtered
 * distance, ttc_ms the TTC from it and its rate, both rounded half up from Q16 and
 * VT_UNKNOWN when not known (no camera, no filtered distance yet, not closing);
 * warning the VT_FCW_* bits (VT_FCW_UNKNOWN without a camera). */
typedef struct {
    int32_t id;
    int32_t state; /* vt_track_state */
    vt_box box;
    vt_q16 vx; /* px/frame */
    vt_q16 vy;
    int32_t distance_mm;
    int32_t ttc_ms;
    int32_t warning;
} vt_pipe_track;

/* One frame's results, all in the pixels of the frame given to vt_pipeline_step. */
typedef struct {
    int32_t frame;           /* index of this frame (0 for the first)                */
    int32_t detection_frame; /* 1 if detection ran on this frame                     */
    int32_t lane_status;     /* vt_lane_detect's status (VT_OK if it did not run)    */
    int32_t lanes_ran;       /* 1 if the lane stage ran on this frame                */
    vt_lane_result lanes;    /* its lines (valid only when lanes_ran and lane_status == VT_OK) */
    int32_t road_source;     /* VT_ROAD_SRC_*                                        */
    vt_road_area road;       /* the road area used (valid = 0 if none)               */
    int32_t n_hyp;           /* shadow hypotheses (nearest first)                    */
    vt_hypothesis hyp[VT_MAX_HYPOTHESES];
    int32_t n_boxes;         /* boxes handed to the tracker (the first VT_MAX_BOXES)  */
    int32_t n_boxes_in;      /* all of them: more than n_boxes only when the caller's
                                detections (vt_pipeline_step_dets) exceed VT_MAX_BOXES */
    vt_pipe_box boxes[VT_MAX_BOXES];
    int32_t n_tracks;        /* live tracks                                          */
    vt_pipe_track tracks[VT_MAX_TRACKS];
} vt_frame_out;

/* *cfg = VT_PIPELINE_CFG_DEFAULT. VT_E_ARG for NULL. */
vt_status vt_pipeline_cfg_default(vt_pipeline_cfg *cfg);

/* VT_OK if every stage's configuration and every policy is valid: the lane, shadow,
 * verify and tracker checks (their codes), the fixed road (permille 0..1000,
 * bottom_left <= bottom_right, top_margin 0..4096), detect_every >= 1, a known
 * road policy, lanes_every_frame and track 0/1, sources a subset of the built ones
 * (VT_E_ARG otherwise). */
vt_status vt_pipeline_cfg_check(const vt_pipeline_cfg *cfg);

/* Check cfg once and start a run: copy it, empty every stage, frame 0 next, ego
 * speed unknown. camera: NULL (no geometry) or a camera passing vt_camera_cfg_check
 * (kept by pointer: it must outlive the pipeline; may live in flash), whose img_w x
 * img_h every frame must then have (VT_E_SIZE at the step otherwise); with it the
 * range configuration must pass vt_range_cfg_check. model: NULL (a non-NULL one is
 * VT_E_ARG while the classifier is not built in). On error *p is left unchanged. */
vt_status vt_pipeline_init(vt_pipeline *p, const vt_pipeline_cfg *cfg,
                           const vt_camera_cfg *camera, const struct vt_svm_model *model);

/* Attach the caller's workspace for the tracker's edge-curve measurement
 * (cfg.tracker.measurement == VT_MEAS_EDGE_CURVES; vehtrack/edge_track.h), as
 * vt_tracker_set_edge_ws: call after vt_pipeline_init (which detaches it); ws NULL
 * detaches. The pipeline keeps the pointer (*ws must outlive the run; it is scratch,
 * rewritten every step). A pipeline tracking with the edge measurement and no
 * workspace refuses every vt_pipeline_step* with VT_E_ARG before any stage runs
 * (nothing changes); vt_pipeline_init itself accepts that configuration, since the
 * workspace can only be attached after it. VT_E_ARG for p NULL. */
vt_status vt_pipeline_set_edge_ws(vt_pipeline *p, vt_edge_ws *ws);

/* The ego vehicle's speed for the next steps (the camera stage's lead class), Q16
 * m/s; negative = unknown. VT_E_ARG for NULL. */
vt_status vt_pipeline_set_ego_speed(vt_pipeline *p, vt_q16 speed);

/* One frame: lanes (every frame or detection frames, per the policy) -> road area
 * (lanes, else the fixed trapezoid, per the policy) -> on detection frames (every
 * detect_every-th, when a hypothesis source is on) hypotheses and verification ->
 * tracker (if on) -> geometry. VT_E_ARG when the tracker runs the edge-curve
 * measurement without a workspace (vt_pipeline_set_edge_ws). frame: 1x1 ..
 * VT_MAX_WIDTH x VT_MAX_HEIGHT (VT_E_SIZE otherwise; see vt_pipeline_work_size for
 * bringing a larger frame within it). A lane-stage error (e.g. a frame below its
 * 16x16 minimum) is not fatal: it is reported in out->lane_status and the road
 * falls back per the policy. Errors of the detection or tracker stage are returned
 * (out then holds what ran before them); on VT_E_ARG / VT_E_SIZE nothing changes
 * and the frame counter does not advance. */
vt_status vt_pipeline_step(vt_pipeline *p, const vt_image_u8 *frame, vt_frame_out *out);

/* vt_pipeline_step with the caller's road area in place of the fixed trapezoid: it
 * is the road of VT_ROAD_FIXED and the fallback of VT_ROAD_AUTO (the lanes' area
 * still wins when found). An invalid road (valid == 0) means "no road": no
 * detection on this frame unless the lanes find one. road NULL: the built-in
 * trapezoid, as vt_pipeline_step. VT_E_SIZE if a valid road was made for another
 * frame height (road->height != frame->h). */
vt_status vt_pipeline_step_road(vt_pipeline *p, const vt_image_u8 *frame,
                                const vt_road_area *road, vt_frame_out *out);

/* vt_pipeline_step where this frame is a detection frame with the caller's boxes
 * (dets[0..n_dets-1], inclusive pixels; NULL only if n_dets is 0), whatever the
 * cadence: the lane and hypothesis stages do not run; all the boxes go to the
 * tracker (which has its own limit and checks each box), the first VT_MAX_BOXES
 * are copied to out->boxes with source VT_SRC_EXTERNAL. VT_E_ARG for n_dets < 0
 * or dets NULL with n_dets > 0 (nothing changes then). */
vt_status vt_pipeline_step_dets(vt_pipeline *p, const vt_image_u8 *frame, const vt_box *dets,
                                int32_t n_dets, vt_frame_out *out);

/* The working size of a w x h frame for a core of max_w x max_h: unchanged if it
 * fits, else the largest size with the same aspect ratio that fits (each side
 * >= 1): the limiting side becomes its maximum, the other is scaled by the same
 * ratio and rounded down (integer arithmetic, no rounding ambiguity). The one
 * downscale rule of the library; callers resample the frame to it. VT_E_ARG for
 * NULL outputs, VT_E_SIZE for w, h, max_w or max_h < 1. */
vt_status vt_pipeline_work_size(int32_t w, int32_t h, int32_t max_w, int32_t max_h,
                                int32_t *work_w, int32_t *work_h);

/* The fixed trapezoid road area of a w x h frame into *road (see vt_fixed_road):
 * exact rational arithmetic in int64, each x rounded half up (as floor(v + 0.5)),
 * t = (y - vp_y) / (h - 1 - vp_y) clamped to [0, 1]. VT_E_ARG for NULL or a bad
 * vt_fixed_road, VT_E_SIZE for h outside 1..VT_MAX_HEIGHT or w outside
 * 1..VT_MAX_WIDTH. */
vt_status vt_fixed_road_area(const vt_fixed_road *fr, int32_t w, int32_t h, vt_road_area *road);

#endif /* VEHTRACK_PIPELINE_H */
