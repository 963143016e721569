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
 * is used. Likewise caller-owned and attached only for their sources: the whole-road
 * detector's vt_pipe_cls_ws (vt_pipeline_set_cls_ws; 1,176,248 bytes at the default
 * capacities, 568,488 at VGA), the overtaking stage's vt_flow_state
 * (vt_pipeline_set_flow_ws; 1,917,112 / 592,312) and the vehicle model's vt_model_ws
 * (vt_pipeline_set_model_ws; 416,760), and the block-scale TTC's vt_ttc_state
 * (vt_pipeline_set_ttc_ws; 113,064 at the defaults), and the CNN detector's work buffer
 * (vt_pipeline_set_cnn; vt_cnn_frame_work_bytes for the largest frame). Work: the stages' own (see their headers);
 * detection runs only every detect_every frames, the flow stage on every frame, the
 * vehicle model at most model_fits times per frame. Stack: measured in firmware_demo/
 * (`stack step`: 3.5 KB on the Cortex-M3 with every source on, the vehicle model
 * included, in its 640x256 build; vt_pyr_down alone keeps a row of VT_MAX_WIDTH
 * uint16 column sums there, 3.8 KB at the default width). */
#ifndef VEHTRACK_PIPELINE_H
#define VEHTRACK_PIPELINE_H

#include <stdint.h>
#include "vehtrack/acf.h"
#include "vehtrack/camera.h"
#include "vehtrack/classify.h"
#include "vehtrack/cnn.h"
#include "vehtrack/config.h"
#include "vehtrack/detect.h"
#include "vehtrack/flow.h"
#include "vehtrack/fulldet.h"
#include "vehtrack/hood.h"
#include "vehtrack/image.h"
#include "vehtrack/lane.h"
#include "vehtrack/road.h"
#include "vehtrack/status.h"
#include "vehtrack/tracker.h"
#include "vehtrack/ttc_scale.h"
#include "vehtrack/vehicle_model.h"

/* Hypothesis sources (bit mask in vt_pipeline_cfg.sources). Shadow and classifier
 * are built; asking for another one is VT_E_ARG at init.
 * Without a classifier, detection is the ego-lane detector (vehtrack/detect.h) on
 * the lanes' road. With one (a model at vt_pipeline_init, or a scorer given to
 * vt_pipeline_set_cls_ws) detection is the whole-road detector (vehtrack/fulldet.h)
 * on the camera road: VT_SRC_SHADOW its shadow hypotheses (classified by the model),
 * VT_SRC_CLASSIFIER its sliding windows; VT_SRC_EGO adds the ego-lane detector's boxes
 * (the thesis's lead-car detector, on the lanes' road or the fixed one per the road
 * policy; a road given to vt_pipeline_step_road is then the ego detector's, and the
 * whole-road detector keeps the camera road) ahead of them, so the lead car keeps the
 * ego detector's box and the other lanes get the classifier's. */
#define VT_SRC_SHADOW 1     /* shadow rows + vertical-edge verification (sec. 2.4.2) */
#define VT_SRC_CLASSIFIER 2 /* classifier windows over the whole road (needs a classifier) */
#define VT_SRC_FLOW 4       /* overtaking vehicles from lateral SAD flow (every frame; needs
                               its state attached: vt_pipeline_set_flow_ws)               */
#define VT_SRC_MODEL 8      /* the 7-parameter vehicle model fitted by a GA, for tracks
                               whose ROI search failed (needs vt_pipeline_set_model_ws)   */
#define VT_SRC_EXTERNAL 16  /* the caller's detections (vt_pipeline_step_dets); not a policy bit */
#define VT_SRC_EGO 32       /* with a classifier: the ego-lane detector too, on the lanes' road
                               (its boxes first; a whole-road box NMS would suppress against
                               one of them is dropped); needs a classifier like
                               VT_SRC_CLASSIFIER                                          */
#define VT_SRC_BUILT (VT_SRC_SHADOW | VT_SRC_CLASSIFIER | VT_SRC_FLOW | VT_SRC_MODEL | VT_SRC_EGO)

/* Where the road area of a frame came from (vt_frame_out.road_source) and which
 * the pipeline may use (vt_pipeline_cfg.road_policy). */
#define VT_ROAD_SRC_NONE 0
#define VT_ROAD_SRC_LANES 1
#define VT_ROAD_SRC_FIXED 2
#define VT_ROAD_SRC_CAMERA 3 /* the whole-road detector's camera road (vt_road_from_camera) */

#define VT_ROAD_AUTO 0  /* the lanes' road area, else the fixed trapezoid */
#define VT_ROAD_LANES 1 /* the lanes' road area only (no detection without it) */
#define VT_ROAD_FIXED 2 /* always the fixed trapezoid (the lane stage does not run) */

/* "Not known": the value of every distance/TTC field without a camera, or when
 * the geometry cannot say (no filtered distance yet, opening, beyond ttc_max). */
#define VT_UNKNOWN INT32_MIN

/* vt_pipe_track.state of a vehicle the pipeline handed over to the flow stage (the
 * ego car is overtaking it; see vt_pipeline_set_flow_ws): after the tracker's
 * VT_TRACK_* states. */
#define VT_PIPE_HANDOVER 4

/* Frames of box history the hand-over rule can look back (cfg.handover_frames < it). */
#ifndef VT_PIPE_HO_HIST
#define VT_PIPE_HO_HIST 16
#endif
#if VT_PIPE_HO_HIST < 2 || VT_PIPE_HO_HIST > 256
#error "VT_PIPE_HO_HIST out of range (2..256)"
#endif

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

/* The whole-road detector's flat-road camera relative to the frame, so one setting
 * serves any frame size. For a w x h frame (vt_camera_min, input px):
 *   horizon_y = floor((h * horizon_q16 + 32768) / 65536)   (half up; Q16 of h)
 *   hood_y    = max(1, floor((h * hood_q16 + 32768) / 65536))
 *   fx_q4     = max(16, floor((w * fx_per_w_q16 + 2048) / 4096))  (fx = w * fx_per_w, Q4)
 * exact in int64. The lane stage's vanishing row (vt_lane_result vp_y when vp_known, in
 * input rows (vp_y + 1/2) 2^shift - 1/2 rounded half up) replaces the horizon when the
 * lane stage finds one, and is held while they are lost.
 * Defaults: horizon 330/720 of h (fitted on tusimple-vehicles-dev TRAIN), hood from
 * 0.93 h, 1.8 m camera, fx = 714.15/1280 of w (TuSimple), as pyvehtrack.fullroad.Camera. */
typedef struct {
    int32_t horizon_q16;  /* -65536..65536                   */
    int32_t hood_q16;     /* 3277..131072 (0.05 .. 2 h)      */
    int32_t height_mm;    /* 100..20000                      */
    int32_t fx_per_w_q16; /* 3277..1310720 (0.05 .. 20 w)    */
} vt_road_camera;

#define VT_ROAD_CAMERA_DEFAULT \
    {.horizon_q16 = 30037, .hood_q16 = 60948, .height_mm = 1800, .fx_per_w_q16 = 36564}

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
    vt_fulldet_cfg fulldet;  /* the whole-road detector (with a classifier); its own
                                `sources` field is ignored: the pipeline's bits decide */
    vt_road_camera road_camera; /* its camera (with a classifier)                        */
    vt_flow_cfg flow;        /* the overtaking stage (VT_SRC_FLOW)                       */
    vt_model_cfg model;      /* the vehicle model's GA (VT_SRC_MODEL); its road fields
                                are set per fit (see vt_pipeline_set_model_ws)          */
    int32_t model_fits;      /* most model fits per frame, 0..VT_MAX_TRACKS (the cost
                                bound with the GA's pop x gens; default 2, or
                                VT_MAX_TRACKS if smaller)                               */
    int32_t model_min_fitness; /* a fit below this is not used, >= 0. Default 256: more
                                than a featureless patch scores (255 w_sym: perfectly
                                symmetric, no edge, no shadow) at the default weights  */
    int32_t verify;          /* 0, or 1: a second stage on the whole-road detector's boxes
                                (a cascade): the built-in HOG 64x64 MLP re-scores each
                                box (vt_fulldet_verify) and those under verify_min are
                                dropped; needs a classifier workspace and a build with
                                the default MLP. 2: the same, but a whole-road box
                                flatter than 1:2 (height < width / 2: a side view, whose
                                bottom-row square the rear-view MLP cannot judge) keeps
                                its first-stage score; the ego boxes as with 1. 3: as
                                2, and so does a whole-road box whose gap to the
                                frame's left or right side is at most a quarter of its
                                width plus 1 px (4 gap <= width + 4: a vehicle the edge
                                cuts; acf.h's edge models). 4: as 3, and so does a
                                whole-road box narrower than 32 px (a far car, which the
                                64x64 MLP would judge enlarged 2x or more)             */
    vt_q16 verify_min;       /* that stage's threshold, a Q16 decision value            */
    vt_ttc_cfg ttc;          /* the block-scale TTC (vehtrack/ttc_scale.h) run after the
                                tracker when its state is attached (vt_pipeline_set_ttc_ws);
                                frame_dt is the frame period (default 0.1 s)            */
    int32_t handover;        /* 0/1: hand vehicles the ego car overtakes to the flow stage
                                (IVVI paper sec. 3, the reverse case); acts only with
                                VT_SRC_FLOW on (rule: vt_pipeline_set_flow_ws)           */
    int32_t handover_frames; /* the rule's look-back N, 2..VT_PIPE_HO_HIST - 1 frames    */
    int32_t handover_dy_permille; /* its bottom row moved down by at least this permille
                                of the frame height over those N frames (half of it in
                                each half), 0..1000                                    */
    int32_t handover_edge_permille; /* its outer side within this permille of the width
                                of the frame's border, 0..500                          */
    int32_t ttc_fuse_permille; /* the fused TTC (vt_pipe_track.ttc_fused_q16): the weight of
                                the distance/rate TTC, 0..1000 permille; the block-scale
                                TTC gets the rest. Default 300, chosen on KITTI frames
                                0-38 only (tools/eval_kitti_range.py)                  */
    int32_t road_above_hood; /* 0/1: the ego-lane detector's road (the lanes' or the fixed
                                trapezoid; never a caller's) ends two rows above the
                                road camera's hood row (road_camera.hood_q16, rounded
                                as there; the shadow scan's Sobel reads the row below),
                                none if that is above its top: the hood's edge against
                                the road, dark above bright, is not a vehicle's shadow.
                                Set it when the camera's hood row is known (a camera
                                file's hood_row); 0 (default): the road runs to the
                                frame's bottom, as the default hood fraction is a
                                guess and a near lead car's bottom may be below it
                                (KITTI's cameras see no hood)                          */
    int32_t auto_hood;       /* 0/1: with road_above_hood 0 (no known hood row), look for
                                the hood in each detection frame (vt_hood_find with
                                `hood`) and, when found, end the ego-lane detector's road
                                two rows above its top row, as road_above_hood does with
                                a known one; vt_frame_out.hood_row says what was found */
    vt_hood_cfg hood;        /* the hood finder's settings (vehtrack/hood.h)             */
    int32_t fcw_fused;       /* 0/1: the warning decides on the fused TTC where a track has
                                a block-scale one (vt_range_step_fused; needs the block
                                TTC's workspace attached), else (0, the default) on the
                                distance/rate TTC. Opt-in: on the rendered NHTSA scenes it
                                keeps 0.03 s of margin on a decelerating lead (0.29 s on
                                the distance/rate TTC), and before the lead class waited
                                for a known rate it warned late once (README, "The
                                warning on the fused TTC")                               */
    int32_t cnn_hood_min_width_mm; /* 0..10000 (0: off). The CNN detector's boxes on the
                                hood: a box whose bottom row b is below the road camera's
                                hood row (b > hood_y), which is more than w / 64 px (w the
                                frame width, integer division) from both sides of the frame,
                                and for which width x height_mm < this x (b - horizon_y)
                                (inclusive width; int64; horizon_y and hood_y as the
                                whole-road detector's camera places them) is dropped: at
                                that row's flat-road distance it is narrower than this many
                                mm, narrower than any vehicle. A reflection on the ego car's
                                hood or debris on the road, not a car; a near car down there
                                is 0.7-2.3 m wide, and one the frame's side cuts is kept.
                                The ACF stage and the windows keep b < hood_y outright.
                                Default 600 (README, "No box on the hood")              */
    int32_t cnn_ego_iou_permille; /* 0..1000, with VT_SRC_EGO and a CNN detector attached:
                                whose box is reported for a vehicle both found. The ego box
                                drops each CNN box the whole-road detector's NMS test pairs
                                with it and takes the highest of their scores, as always.
                                0: it is reported as it is. 1..1000: it is reported with the
                                box of the dropped CNN box that overlaps it most (the first
                                of equals), when that IoU is >= this / 1000 (inter x 1000 >=
                                this x union, int64); its source stays VT_SRC_EGO. The
                                tracker's input keeps the ego box either way: its ROI search
                                measures the shadow bottom and vertical edges the ego box
                                came from, while the CNN's box fits a rear view better than
                                the ego detector's square one. Default 302: the NMS's IoU
                                limit, 0.301, as a >= test (README, "Whose box names a
                                vehicle both detectors found")                          */
    int32_t cnn_track_top; /* 0 or 1, with cnn_ego_iou_permille: the top of a track's
                                reported box. 1: on a detection frame, each ego box the
                                tracker gets goes to the output track that overlaps it most
                                (IoU >= tracker.match_iou_permille, int64; the first of
                                equals; later boxes win). Reported with a CNN box, it gives
                                that track the height q = max(1, round(256 (b - t + 1) / w))
                                (Q8; b, w the track's own bottom row and width there, t the
                                CNN box's top); reported as it is, it clears the track's
                                height. The track keeps it by id until its next ego box, and
                                its output box is the tracker's with top = bottom - max(1,
                                floor((w q + 128) / 256)) + 1 (w its own width now) while it
                                has one. The tracker, its ROI search, the distance, TTC,
                                warning and source read the tracker's box: unchanged. 0:
                                the tracker's box (square for an ego box). Default 1 (README,
                                "The top of a track's box")                             */
} vt_pipeline_cfg;

#define VT_PIPELINE_CFG_DEFAULT                                   \
    {                                                             \
        .lane = VT_LANE_CFG_DEFAULT,                              \
        .detect = VT_DETECT_CFG_DEFAULT,                          \
        .tracker = VT_TRACKER_CFG_DEFAULT,                        \
        .range = VT_RANGE_CFG_DEFAULT,                            \
        .fixed_road = VT_FIXED_ROAD_DEFAULT,                      \
        .detect_every = 10,                                       \
        .road_policy = VT_ROAD_AUTO,                              \
        .lanes_every_frame = 0,                                   \
        .sources = VT_SRC_SHADOW,                                 \
        .track = 1,                                               \
        .fulldet = VT_FULLDET_CFG_DEFAULT,                        \
        .road_camera = VT_ROAD_CAMERA_DEFAULT,                    \
        .flow = VT_FLOW_CFG_DEFAULT,                              \
        .model = VT_MODEL_CFG_DEFAULT,                            \
        .model_fits = ((VT_MAX_TRACKS) < 2 ? (VT_MAX_TRACKS) : 2), \
        .model_min_fitness = 256,                                 \
        .verify = 0,                                              \
        .verify_min = 0,                                          \
        .ttc = VT_TTC_CFG_DEFAULT,                                \
        .handover = 1,                                            \
        .handover_frames = 8,                                     \
        .handover_dy_permille = 10,                               \
        .handover_edge_permille = 20,                             \
        .ttc_fuse_permille = 300,                                 \
        .road_above_hood = 0,                                     \
        .auto_hood = 1,                                           \
        .hood = VT_HOOD_CFG_DEFAULT,                              \
        .fcw_fused = 0,                                           \
        .cnn_hood_min_width_mm = 600,                             \
        .cnn_ego_iou_permille = 302,                              \
        .cnn_track_top = 1,                                       \
    }

/* The whole-road detector's scratch, owned by the caller and attached with
 * vt_pipeline_set_cls_ws (too large for vt_pipeline: sizeof is the pyramid of a
 * VT_MAX_WIDTH x VT_MAX_HEIGHT frame plus the window lists and the HOG band, about
 * 1.2 MB at the default capacities, see `make ram-bill`). Rewritten every detection
 * frame; nothing in it outlives a step. */
typedef struct {
    vt_fulldet_state st;
    vt_fulldet_result res;
    vt_hog_scorer hog;
    vt_cls_box_ws box; /* the second stage's scratch (cfg.verify) */
} vt_pipe_cls_ws;

/* Everything the pipeline keeps. Caller-owned (static storage on firmware);
 * initialise with vt_pipeline_init. Fields are private: read the output. */
typedef struct {
    vt_pipeline_cfg cfg; /* a checked copy */
    const vt_svm_model *model;   /* NULL: no built-in classifier (see vt_pipeline_set_cls_ws) */
    const vt_camera_cfg *camera; /* NULL: no geometry */
    vt_pipe_cls_ws *cls_ws;      /* the whole-road detector's scratch (NULL: none)        */
    vt_window_scorer scorer;     /* its classifier (score NULL: none)                     */
    const vt_mlp_model *wide_model; /* the wide pass's model (NULL: off; vt_pipeline_set_wide) */
    vt_fulldet_wide_cfg wide_cfg;   /* and its settings (a checked copy)                     */
    const vt_box_regressor *refine; /* box regression (NULL: off; vt_pipeline_set_refine)   */
    const vt_box_rescorer *rescore; /* the ACF boxes' second stage (vt_pipeline_set_rescore) */
    const vt_acf_model *acf;        /* the ACF first stage (NULL: off; vt_pipeline_set_acf) */
    vt_acf_ws *acf_ws;              /* and its scratch                                       */
    int32_t acf_n;                  /* its models (vt_pipeline_set_acf_n; acf_m[0] = acf)    */
    const vt_acf_model *acf_m[VT_ACF_MAX_MODELS];
    vt_acf_cfg acf_cfg[VT_ACF_MAX_MODELS]; /* and their settings (checked copies)          */
    const vt_cnn_model *cnn;        /* the CNN detector (NULL: off; vt_pipeline_set_cnn)     */
    vt_cnn_cfg cnn_cfg;             /* its settings (a checked copy)                         */
    uint8_t *cnn_work;              /* its work buffer (caller-owned) ...                    */
    size_t cnn_work_bytes;          /* ... and its size, checked at each detection step      */
    int32_t horizon_y;           /* the last lanes' vanishing row, input px               */
    int32_t horizon_known;       /* 1 once the lanes gave one (this run)                  */
    vt_flow_state *flow_st;      /* the overtaking stage's state (NULL: none attached)    */
    vt_flow_result flow;         /* its last result                                       */
    vt_model_ws *model_ws;       /* the vehicle model's workspace (NULL: none attached)   */
    int32_t frame;    /* frames stepped so far */
    vt_q16 ego_speed; /* m/s, negative = unknown (vt_pipeline_set_ego_speed) */
    vt_lane_state lane;
    vt_detect_state detect;
    vt_detect_result det;
    vt_hood_state hood;    /* the hood finder's scratch (cfg.auto_hood)            */
    vt_tracker tracker;
    vt_track_out tracks[VT_MAX_TRACKS];
    vt_pitch_state pitch;  /* camera stage: pitch from the lanes' vanishing row */
    vt_range_state range;  /* camera stage: per-track range filter and FCW state */
    vt_range_out ranges[VT_MAX_TRACKS];
    int32_t n_src;                      /* the source that started each live track:   */
    int32_t src_id[VT_MAX_TRACKS];      /* track ids ...                               */
    int32_t src_of[VT_MAX_TRACKS];      /* ... and their VT_SRC_* (0: not known)       */
    int32_t n_top;                      /* cfg.cnn_track_top's heights of live tracks: */
    int32_t top_id[VT_MAX_TRACKS];      /* track ids ...                               */
    int32_t top_q8[VT_MAX_TRACKS];      /* ... and their heights in widths, Q8 (0: none) */
    vt_ttc_state *ttc_st;               /* the block-scale TTC's state (NULL: none)    */
    int32_t n_ttc;                      /* its outputs of the last step ...            */
    vt_ttc_out ttc_out[VT_MAX_TRACKS];  /* ... (kept here, not on the stack)           */
    int32_t n_trk;                      /* the tracker's tracks in tracks[] (the other
                                           output tracks are hand-overs)               */
    /* The hand-over rule's memory per tracker slot: the id of the track it is about,
     * its last frames' bottom rows and centre columns x 2 (l + r), newest at [0],
     * ho_len of them known. */
    int32_t ho_tid[VT_MAX_TRACKS];
    int32_t ho_len[VT_MAX_TRACKS];
    int32_t ho_bot[VT_MAX_TRACKS][VT_PIPE_HO_HIST];
    int32_t ho_cx2[VT_MAX_TRACKS][VT_PIPE_HO_HIST];
    vt_box ho_last[VT_MAX_TRACKS]; /* the box of the newest entry (the jump test)     */
    /* Live hand-overs, in the order they were made: the track's id, the flow stage's
     * seed id, and this frame's box and flow (Q16 px/frame). */
    int32_t n_ho;
    int32_t ho_id[VT_FLOW_MAX_SEEDS];
    int32_t ho_seed[VT_FLOW_MAX_SEEDS];
    vt_box ho_box[VT_FLOW_MAX_SEEDS];
    vt_q16 ho_vx[VT_FLOW_MAX_SEEDS];
    vt_q16 ho_vy[VT_FLOW_MAX_SEEDS];
    int32_t ho_side[VT_FLOW_MAX_SEEDS];  /* 1 left, 2 right: the side it leaves by       */
    int32_t ho_best[VT_FLOW_MAX_SEEDS];  /* its inner side's furthest-out column so far  */
    int32_t ho_stall[VT_FLOW_MAX_SEEDS]; /* frames in a row it did not get further out   */
} vt_pipeline;

/* A detected box and the source that proposed it. score: the source's confidence:
 * the classifier's decision value (Q16, the model's scale) for every box of the
 * whole-road detector (a shadow box not classified: cfg.fulldet.shadow_score);
 * VT_UNKNOWN for the ego-lane shadow source, which has none; beside a classifier
 * (VT_SRC_EGO) an ego box takes the highest score of the whole-road boxes it
 * suppresses, or the detector's threshold (cfg.fulldet.window_score_min) if none. */
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
    int32_t source;  /* VT_SRC_* of the detection that started the track: on the frame
                        a track first appears, the source of the frame's box with the
                        largest intersection with its box (the first of equals); 0 if
                        no box meets it. Kept for the track's life. */
    vt_q16 ttc_points_q16; /* s, Q16: the block-scale TTC of the track (vt_ttc_step's ttc,
                              VT_TTC_VALID), VT_UNKNOWN when not known: no state attached
                              (vt_pipeline_set_ttc_ws), fewer than cfg.ttc.lag frames of
                              the track, too few pairs, not closing, beyond ttc_max, or
                              a track without one of the VT_TTC_TRACKS slots (they go to
                              the nearest tracks: vt_ttc_cfg.evict_margin_px) */
    vt_q16 ttc_fused_q16;  /* s, Q16: the two TTCs in one. Both known (ttc_points_q16 = P,
                              the camera stage's distance/rate TTC in Q16 = D, before its
                              rounding to ttc_ms): floor((P (1000 - w) + D w + 500) / 1000)
                              with w = cfg.ttc_fuse_permille, exact in int64 (P, D < 2^31);
                              one known: that one; neither: VT_UNKNOWN. The two err in
                              opposite directions on KITTI (the scale lags, the rate of a
                              filtered distance overshoots), so their mean beats either */
} vt_pipe_track;

/* One frame's results, all in the pixels of the frame given to vt_pipeline_step. */
typedef struct {
    int32_t frame;           /* index of this frame (0 for the first)                */
    int32_t detection_frame; /* 1 if detection ran on this frame                     */
    int32_t lane_status;     /* vt_lane_detect's status (VT_OK if it did not run)    */
    int32_t lanes_ran;       /* 1 if the lane stage ran on this frame                */
    vt_lane_result lanes;    /* its lines (valid only when lanes_ran and lane_status == VT_OK) */
    int32_t road_source;     /* VT_ROAD_SRC_* (CAMERA: the whole-road detector's)     */
    vt_road_area road;       /* the road area used (valid = 0 if none)               */
    int32_t n_hyp;           /* shadow hypotheses (nearest first; of the whole-road
                                detector's shadow source when a classifier runs)     */
    vt_hypothesis hyp[VT_MAX_HYPOTHESES];
    int32_t n_boxes;         /* boxes handed to the tracker (the first VT_MAX_BOXES);
                                the flow boxes are listed on every frame, handed over
                                as vt_pipeline_set_flow_ws says, as are the boxes of a
                                vehicle handed over to the flow stage (listed, not
                                given to the tracker)                                */
    int32_t n_boxes_in;      /* all of them: more than n_boxes only when the caller's
                                detections (vt_pipeline_step_dets) exceed VT_MAX_BOXES,
                                or the flow boxes did not fit (not handed over)      */
    int32_t flow_ready;      /* the overtaking stage compared two frames (VT_SRC_FLOW) */
    int32_t hood_row;        /* the hood's top row found on this detection frame
                                (cfg.auto_hood; the ego-lane road then ends two rows
                                above it), -1 if none was found or the finder did not
                                run (not a detection frame, auto_hood 0, or a known
                                hood row: road_above_hood 1)                        */
    int32_t model_fits;      /* vehicle-model fits run on this frame (VT_SRC_MODEL; each
                                a GA over a coasting track's ROI, used or not: the used
                                ones are the boxes of source VT_SRC_MODEL)           */
    vt_pipe_box boxes[VT_MAX_BOXES];
    int32_t n_tracks;        /* live tracks: the tracker's, then the hand-overs (state
                                VT_PIPE_HANDOVER, see vt_pipeline_set_flow_ws)       */
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
 * range configuration must pass vt_range_cfg_check. model: NULL, or a linear SVM
 * passing vt_svm_model_check (kept by pointer, may live in flash, e.g.
 * vt_svm_default_model): the classifier of the whole-road detector, which then runs
 * on detection frames once its workspace is attached (vt_pipeline_set_cls_ws; until
 * then every step is VT_E_ARG). The classifier source (VT_SRC_CLASSIFIER) needs a
 * classifier: a model here or a scorer attached later (the step checks). init
 * detaches the workspace and the scorer. On error *p is left unchanged. */
vt_status vt_pipeline_init(vt_pipeline *p, const vt_pipeline_cfg *cfg,
                           const vt_camera_cfg *camera, const vt_svm_model *model);

/* Attach the whole-road detector's workspace (after vt_pipeline_init, which detaches
 * it; ws NULL detaches it and the scorer). scorer: NULL for the HOG scorer of the
 * model given at init (vt_hog_scorer in ws: VT_E_ARG without a model, unless the ACF
 * first stage or the CNN detector is set (vt_pipeline_set_acf / vt_pipeline_set_cnn,
 * before this): then no scorer), or the
 * caller's classifier (e.g. {NULL, vt_mlp_scorer_score, &mlp}; copied, its ctx must
 * outlive the run). The pipeline keeps the pointer (*ws must outlive the run). With
 * a classifier attached, detection frames run vt_fulldet (see VT_SRC_SHADOW). VT_E_ARG
 * for p NULL, a scorer without `score`, or ws NULL with a scorer (nothing changes). */
vt_status vt_pipeline_set_cls_ws(vt_pipeline *p, vt_pipe_cls_ws *ws, const vt_window_scorer *scorer);

/* Turn on the whole-road detector's wide pass (vt_fulldet_wide, vehtrack/fulldet.h: boxes
 * flatter than 1:2 -- side views, trucks -- from a second window grid scored by a wide
 * window model): on every detection frame that runs vt_fulldet, after it (and after the
 * second stage when cfg.verify), the pass scores its grid on the same camera and road
 * with the model m and appends its boxes to the detector's result (the tracker's input),
 * using the attached vt_pipe_cls_ws as scratch. m is kept by pointer (it must outlive
 * the run; may live in flash); cfg is copied. m NULL turns the pass off, as
 * vt_pipeline_init does. VT_E_ARG for p NULL or cfg NULL with m; m and cfg as
 * vt_mlp_model_check / vt_fulldet_wide_cfg_check. On error nothing changes. */
vt_status vt_pipeline_set_wide(vt_pipeline *p, const vt_mlp_model *m, const vt_fulldet_wide_cfg *cfg);

/* Turn on box regression (vt_fulldet_refine, vehtrack/fulldet.h: each side of a
 * whole-road box moved by the offset a regressor predicts from the box's surroundings):
 * on every detection frame that runs vt_fulldet, after it and after the second stage
 * when cfg.verify, before the wide pass, using the attached vt_pipe_cls_ws as scratch.
 * The ego-lane detector's boxes (VT_SRC_EGO) are not moved. r is kept by pointer (it
 * must outlive the run; may live in flash). r NULL turns it off, as vt_pipeline_init
 * does. VT_E_ARG for p NULL; r as vt_box_regressor_check. On error nothing changes. */
vt_status vt_pipeline_set_refine(vt_pipeline *p, const vt_box_regressor *r);

/* Rescore the ACF first stage's boxes (vt_fulldet_rescore, vehtrack/fulldet.h: boosted
 * trees on the box's context HOG score, its ACF score and its place on the road) in
 * place of the second stage (cfg.verify) on them: on every detection frame that runs
 * the ACF stage (vt_pipeline_set_acf), after it and before box regression, with the
 * detector's camera and the attached vt_pipe_cls_ws as scratch; the ego-lane
 * detector's boxes keep the second stage. r is kept by pointer (it must outlive the
 * run; may live in flash). r NULL turns it off, as vt_pipeline_init does. VT_E_ARG for
 * p NULL; r as vt_box_rescorer_check. On error nothing changes. */
vt_status vt_pipeline_set_rescore(vt_pipeline *p, const vt_box_rescorer *r);

/* Use the ACF first stage (vehtrack/acf.h: channel features + boosted trees, dense over
 * a quarter-octave pyramid) in place of vt_fulldet on every detection frame of the
 * whole-road detector: vt_acf_detect on the frame with the detector's camera (horizon,
 * hood, height), its boxes into the detector's result, then the second stage (when
 * cfg.verify), box regression and the wide pass as after vt_fulldet; no shadow
 * hypotheses and no re-ranking then. The whole-road detector still needs its
 * workspace (vt_pipeline_set_cls_ws; a scorer is not needed). m and ws are kept by
 * pointer (they must outlive the run; m may live in flash), cfg is copied. m NULL
 * turns it off, as vt_pipeline_init does. VT_E_ARG for p NULL, or m given with cfg or
 * ws NULL; m and cfg as vt_acf_model_check / vt_acf_cfg_check. On error nothing
 * changes. */
vt_status vt_pipeline_set_acf(vt_pipeline *p, const vt_acf_model *m, const vt_acf_cfg *cfg,
                              vt_acf_ws *ws);

/* vt_pipeline_set_acf with n models on one pyramid (vt_acf_detect_n: e.g. rear and
 * side views); m[i] kept by pointer, cfg[i] copied. n = 0 turns the stage off. VT_E_ARG
 * for p NULL, n outside 0..VT_ACF_MAX_MODELS, or n > 0 with m, cfg, ws or an m[i] or
 * cfg[i] NULL; m[i] and cfg[i] as their checks. On error nothing changes. */
vt_status vt_pipeline_set_acf_n(vt_pipeline *p, int32_t n, const vt_acf_model *const *m,
                                const vt_acf_cfg *const *cfg, vt_acf_ws *ws);

/* Use the CNN detector (vehtrack/cnn.h: vt_cnn_detect_frame over pyramid levels of the
 * frame) in place of vt_fulldet and of the ACF stage (it wins when both are set) on every
 * detection frame of the whole-road detector that has a road (the camera road, or the
 * caller's, as for the other detectors): its boxes go into the detector's result as
 * classifier boxes (VT_SRC_CLASSIFIER in the output, the tracker's input as ACF boxes
 * are) with score = heat x m->heat_scale_q16 (a Q16 logit, in int32 by
 * VT_CNN_HEAT_SCALE_MAX), at most VT_MAX_BOXES of them in NMS order. The network is its
 * own verification: the second stage (cfg.verify), re-ranking, box regression, the wide
 * pass and the shadow hypotheses are skipped for its boxes; the ego-lane detector's
 * boxes (VT_SRC_EGO) are merged beside them as for the ACF stage. As the ACF stage, it
 * needs the whole-road detector's workspace (vt_pipeline_set_cls_ws after this, which
 * then needs no scorer: the merge and the result live there). m and work are kept by
 * pointer (they must outlive the run; m may live in flash), cfg is copied with its rows
 * placed at the pipeline's road camera (vt_cnn_cfg_at_horizon(cfg,
 * cfg.road_camera.horizon_q16): the bands move with a camera whose horizon is not the
 * default's; the lanes' vanishing row does not move them). work_bytes
 * is checked at each detection step against vt_cnn_frame_work_bytes for that frame and
 * the placed cfg
 * (VT_E_CAPACITY from the step when short), so one buffer sized for the largest frame
 * serves every size (with a level-0 band, first_level 0, size it by the query for each
 * frame size: the band's rounding can make a shorter frame need one band row more,
 * cnn.h). m NULL turns it off, as vt_pipeline_init does (cfg and work are
 * then ignored). VT_E_ARG for p NULL, or m given with cfg or work NULL; m and cfg as
 * vt_cnn_check_model / vt_cnn_cfg_check. On error nothing changes. */
vt_status vt_pipeline_set_cnn(vt_pipeline *p, const vt_cnn_model *m, const vt_cnn_cfg *cfg,
                              uint8_t *work, size_t work_bytes);

/* Attach the caller's workspace for the tracker's edge-curve measurement
 * (cfg.tracker.measurement VT_MEAS_EDGE_CURVES or VT_MEAS_ROI_EDGES; vehtrack/edge_track.h), as
 * vt_tracker_set_edge_ws: call after vt_pipeline_init (which detaches it); ws NULL
 * detaches. The pipeline keeps the pointer (*ws must outlive the run; it is scratch,
 * rewritten every step). A pipeline tracking with the edge measurement and no
 * workspace refuses every vt_pipeline_step* with VT_E_ARG before any stage runs
 * (nothing changes); vt_pipeline_init itself accepts that configuration, since the
 * workspace can only be attached after it. VT_E_ARG for p NULL. */
vt_status vt_pipeline_set_edge_ws(vt_pipeline *p, vt_edge_ws *ws);

/* Attach the caller's state of the overtaking stage (vehtrack/flow.h; ~1.9 MB at the
 * default capacities, which is why it is not in vt_pipeline: a firmware build sizes it
 * with VT_MAX_WIDTH/HEIGHT or VT_FLOW_MAX_PIXELS/CELLS). It is emptied here
 * (vt_flow_init) and then holds the previous frame: it must outlive the run and serve
 * one pipeline only. Call after vt_pipeline_init (which detaches it); st NULL detaches.
 * With VT_SRC_FLOW on and no state attached every step is VT_E_ARG. VT_E_ARG for p NULL.
 *
 * Policy (vt_pipeline_step): the stage runs on every frame (it compares consecutive
 * frames; a frame of another size restarts it). Its hypotheses (overtaking blobs) are
 * boxes of source VT_SRC_FLOW, score = the blob's cells, after the detector's boxes
 * (while VT_MAX_BOXES allows). They reach the tracker on detection frames, and on any
 * other frame where one of them meets no live track (an overtaking vehicle cannot wait
 * for the next detection frame): that frame is then a detection frame for the tracker
 * with the flow boxes alone (out->detection_frame still says whether the detector ran).
 *
 * The reverse case (IVVI paper sec. 3, last paragraph), with cfg.handover = 1 (the
 * default; it acts only with VT_SRC_FLOW on): after the tracker, a track the ego car is
 * overtaking that leaves by the side is handed to the flow stage. The rule (exact
 * integers on the tracker's boxes, kept per track for the last VT_PIPE_HO_HIST frames):
 * the track is CONFIRMED or COASTING; over the last N = handover_frames frames its
 * bottom row came down by at least handover_dy_permille / 1000 of the frame height,
 * and by half of that in each half of them (it comes closer all along: on a flat road
 * its box grows); its centre column is in a lateral strip of the flow stage's width
 * (floor(w flow.strip_permille / 1000) px, on either side, whatever side flow.sides
 * watches for overtaking vehicles); its outer side is within handover_edge_permille /
 * 1000 of the width of the frame's border; it did not move inward over the N frames.
 * Such a track is seeded (vt_flow_seed_frame with its box and this frame, after this frame's
 * vt_flow_step) and dropped from the tracker (vt_tracker_drop): from then on it is
 * reported after the tracker's tracks with the SAME id, state VT_PIPE_HANDOVER, the flow
 * stage's box (the size it had at the hand-over, moved by the mean flow of its textured
 * cells) and mean flow as velocity, no distance or TTC, and the source that started it.
 * It ends when the flow stage ends it (fewer than flow.seed_min_visible_permille of its
 * columns in the frame, no textured cell matching, a frame of another size) or when its
 * inner side has not got further out for handover_frames frames in a row (a box left on
 * the road or a marking by the border). While it lives, the frame's boxes (detector, flow,
 * model, the caller's) with IoU >= tracker.match_iou_permille with its box are listed in
 * out->boxes but not handed to the tracker, so the vehicle keeps its one id. Capacity: at
 * most VT_FLOW_MAX_SEEDS hand-overs; when vt_flow_seed refuses (every seed slot taken,
 * e.g. by the caller's own vt_flow_seed calls on this state, or a box outside the frame)
 * the track stays with the tracker, and a hand-over that does not fit in out->tracks
 * (VT_MAX_TRACKS, tracker tracks first) lives on unreported. */
vt_status vt_pipeline_set_flow_ws(vt_pipeline *p, vt_flow_state *st);

/* Attach the caller's workspace of the vehicle model (vehtrack/vehicle_model.h;
 * 416,760 bytes at the default VT_MODEL_MAX_ROI_PIXELS; scratch, rewritten by every
 * fit). Call after vt_pipeline_init (which detaches it); ws NULL detaches. With
 * VT_SRC_MODEL on and no workspace every step is VT_E_ARG. VT_E_ARG for p NULL.
 *
 * Policy (vt_pipeline_step): the model runs only where tracking asks for it: for the
 * tracks the previous step left COASTING (their ROI search failed and no detection
 * matched), in output order, at most cfg.model_fits per frame, before the tracker.
 * For a track with last box (l, t, r, b), w = r - l + 1, h = b - t + 1: a tracking
 * search (the GA's individuals start around the prediction within 3 sigma) with
 * prediction x = l + w / 2, y = b, w, h and the middle of each shape range, sigma
 * (w / 8, h / 8, w / 8, h / 8, 5, 5, 5), the bottom row within b -+ h / 4, in the ROI
 * (l - w / 2, t - h / 2, r + w / 2, b + h / 2) clipped to the frame (skipped when
 * larger than VT_MODEL_MAX_ROI_PIXELS); the road constraint through the track: horizon = the
 * whole-road detector's horizon (the lanes' vanishing row once known, else
 * cfg.road_camera), width_per_row = floor(w * 65536 / (b - horizon)) (skipped for b at
 * or above the horizon). A fit that fails (VT_E_SINGULAR, VT_E_SIZE: no model fits)
 * or scores below cfg.model_min_fitness is skipped; one whose box overlaps the track's last box with IoU >= the tracker's
 * match_iou_percent is a box of source VT_SRC_MODEL (score = its fitness), after the
 * detector's and the flow's boxes, and makes this a detection frame for the tracker
 * (as a fresh flow box does), so it updates the track it refines. */
vt_status vt_pipeline_set_model_ws(vt_pipeline *p, vt_model_ws *ws);

/* Attach the caller's state of the block-scale TTC (vehtrack/ttc_scale.h; sizeof
 * (vt_ttc_state), 113,064 bytes on x86-64 at the default VT_TTC_* capacities, which is
 * why it is not in vt_pipeline; a firmware build lowers VT_TTC_TRACKS). It is emptied
 * here (vt_ttc_init) and then holds the tracks' past blocks: it must outlive the run and
 * serve one pipeline only. Call after vt_pipeline_init (which detaches it); st NULL
 * detaches. VT_E_ARG for p NULL.
 *
 * Policy (vt_pipeline_step): with the state attached and the tracker on, vt_ttc_step
 * runs on every frame after the tracker (and the camera stage) with cfg.ttc, the frame
 * and the tracker's live tracks in output order (every state); it needs no camera (only
 * cfg.ttc.frame_dt). Its TTC is each output track's ttc_points_q16. VT_TTC_TRACKS
 * tracks get a slot (the others VT_UNKNOWN; that capacity is not an error of the step):
 * by default the nearest (lowest box bottom), a slot staying with its track until one
 * more than cfg.ttc.evict_margin_px rows lower needs it (evict_margin_px -1: the first
 * in output order, kept while the id lives). A frame of another size restarts it
 * (vt_ttc_step's rule). */
vt_status vt_pipeline_set_ttc_ws(vt_pipeline *p, vt_ttc_state *st);

/* The ego vehicle's speed for the next steps (the camera stage's lead class), Q16
 * m/s; negative = unknown. VT_E_ARG for NULL. */
vt_status vt_pipeline_set_ego_speed(vt_pipeline *p, vt_q16 speed);

/* One frame: lanes (every frame or detection frames, per the policy) -> road area
 * (lanes, else the fixed trapezoid, per the policy) -> on detection frames (every
 * detect_every-th, when a hypothesis source is on) hypotheses and verification ->
 * tracker (if on) -> geometry. With a classifier attached (vt_pipeline_set_cls_ws)
 * the detection frames run the whole-road detector instead: its road is the camera
 * road (vt_road_from_camera with cfg.road_camera; the road policy then only says
 * whether the lanes run, for the horizon), or the caller's road (step_road).
 * VT_E_ARG when the tracker runs the edge-curve measurement without a workspace
 * (vt_pipeline_set_edge_ws), or a classifier is asked for (a model at init, or
 * VT_SRC_CLASSIFIER) without one attached (vt_pipeline_set_cls_ws). frame: 1x1 ..
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
 * downscale rule of the library; callers resample the frame to it (vt_resize_area,
 * image.h). pyvehtrack passes max_w = min(work_width, VT_MAX_WIDTH), work_width 1280 by
 * default: the stages' pixel settings were chosen on frames 1,242-1,280 px wide, so a
 * firmware with a 1920 x 1080 camera does best to call this with max_w 1280 and
 * vt_resize_area before vt_pipeline_step, as pyvehtrack does. VT_E_ARG for
 * NULL outputs, VT_E_SIZE for w, h, max_w or max_h < 1. */
vt_status vt_pipeline_work_size(int32_t w, int32_t h, int32_t max_w, int32_t max_h,
                                int32_t *work_w, int32_t *work_h);

/* The fixed trapezoid road area of a w x h frame into *road (see vt_fixed_road):
 * exact rational arithmetic in int64, each x rounded half up (as floor(v + 0.5)),
 * t = (y - vp_y) / (h - 1 - vp_y) clamped to [0, 1]. VT_E_ARG for NULL or a bad
 * vt_fixed_road, VT_E_SIZE for h outside 1..VT_MAX_HEIGHT or w outside
 * 1..VT_MAX_WIDTH. */
vt_status vt_fixed_road_area(const vt_fixed_road *fr, int32_t w, int32_t h, vt_road_area *road);

/* The ranges vt_pipeline_cfg_check applies to a vt_fixed_road (every permille in
 * 0..1000, bottom_left <= bottom_right, top_margin 0..4096) and to a vt_road_camera (the
 * ranges next to its fields): VT_OK, or VT_E_ARG for NULL or a field out of range. */
vt_status vt_fixed_road_check(const vt_fixed_road *fr);
vt_status vt_road_camera_check(const vt_road_camera *rc);

#endif /* VEHTRACK_PIPELINE_H */
