/* vehtrack/tracker.h -- multi-vehicle tracker (thesis ch. 3, sec. 3.5-3.6): per
 * track a Kalman filter on the box's bottom edge predicts the box, a search in the
 * predicted ROI measures it (vt_track_search), detections every N frames start
 * new tracks, and normalised correlation decides whether a track the detector no
 * longer sees is still there before it is dropped.
 *
 * Cost: sizeof(vt_tracker) = VT_MAX_TRACKS * sizeof(vt_track) plus the
 * projection workspace (4 * (VT_MAX_WIDTH + VT_MAX_HEIGHT) bytes), one pointer
 * and the horizon: 72,192 bytes at the defaults on x86-64. vt_track is 3,760 bytes:
 * the 2,360-byte fixed-point Kalman filter, a VT_TRACK_TEMPLATE^2-byte template (and
 * the 16-byte box it came from, for the template measurement), the scale check's
 * 8-byte reference and
 * the edge-curve template (vt_edge_template, 4 * VT_EDGE_MAX_POINTS + 20 = 1,044
 * bytes, kept in every track whichever measurement is configured: it is the
 * track's own state, small, and keeps a track copyable). The edge measurement's
 * crop workspace (vt_edge_ws, 327,704 bytes at VT_EDGE_MAX_PIXELS = 65536) is
 * NOT in vt_tracker: the caller owns it and attaches it with
 * vt_tracker_set_edge_ws only when it uses VT_MEAS_EDGE_CURVES or VT_MEAS_ROI_EDGES, so the ROI
 * search pays nothing for it. Work per frame and track: one predict +
 * update (about 1 100 multiplies) and two Sobel responses per ROI pixel (2.3
 * instructions per frame pixel for two tracks at 640x480, `make bench`); nothing
 * outside the ROIs is touched except on detection frames (the template check,
 * VT_TRACK_TEMPLATE^2 pixels per track). The template measurement, when on and
 * the search failed for a tentative track, costs (2 * tmatch_radius + 1)^2
 * resamples and correlations of VT_TRACK_TEMPLATE^2 pixels (81 at radius 4).
 * Stack: about 2 KB (the Kalman update). */
#ifndef VEHTRACK_TRACKER_H
#define VEHTRACK_TRACKER_H

#include <stdint.h>
#include "vehtrack/config.h"
#include "vehtrack/edge_track.h"
#include "vehtrack/fixed.h"
#include "vehtrack/image.h"
#include "vehtrack/kalman.h"
#include "vehtrack/status.h"
#include "vehtrack/track_search.h"

/* Side of the square template kept per track for the correlation check. */
#ifndef VT_TRACK_TEMPLATE
#define VT_TRACK_TEMPLATE 16
#endif

/* Track lifecycle. A slot in state VT_TRACK_FREE holds no track. */
typedef enum {
    VT_TRACK_FREE = 0,
    VT_TRACK_TENTATIVE = 1, /* seen, not yet confirmed_hits times */
    VT_TRACK_CONFIRMED = 2, /* measured in this frame */
    VT_TRACK_COASTING = 3   /* confirmed, running on predictions (occlusion) */
} vt_track_state;

typedef struct {
    vt_track_search_cfg search;
    vt_kf_model_cfg model;
    int32_t roi_margin_min;      /* ROI = predicted box widened by the larger of   */
    int32_t roi_margin_permille; /* these two, px and permille of the box width
                                    (thesis: 6 px, as the verification ROI)         */
    int32_t gate_permille;       /* a measurement moving a side more than this
                                    permille of the box width (or 8 px) is rejected */
    int32_t gate_bottom_permille; /* ... or the bottom more than this (or 4 px)     */
    int32_t confirm_hits;        /* measurements before tentative -> confirmed      */
    int32_t max_coast;           /* frames without measurement before deletion
                                    (9: a track lost between two detection runs
                                    every 10th frame lives to the next one, where
                                    a detection or keep_ncc decides, as the thesis
                                    checks correlation before dropping a track)     */
    int32_t match_iou_permille;  /* detection <-> track association: IoU >= this/1000 */
    vt_q14 keep_ncc;             /* correlation that keeps an undetected track      */
    int32_t init_max_change;     /* px: the two-threshold rule's starting allowance */
    /* The per-frame measurement: VT_MEAS_ROI_SEARCH (thesis sec. 3.6.1, the
     * default), VT_MEAS_EDGE_CURVES (GIST paper sec. III.B: the track's edge
     * curves matched by chamfer distance, vehtrack/edge_track.h, with `edge`) or
     * VT_MEAS_ROI_EDGES (both papers: the ROI search, and where it fails on a
     * confirmed or coasting track it has measured before (not tm_only, not flat),
     * the edge curves, kept fresh on every measured frame; the same gates and scale
     * check; a fallback measurement counts as the frame's measurement, but the
     * track's template stays the one the search or a detection last took, so the
     * correlation check of the next detection frame (keep_ncc) asks for that
     * vehicle and not for the occluder whose side the curves may follow. A compressed
     * frame softens the shadow row and sides the search needs, while the curves
     * still match; the search never measured a part-track or a tentative track,
     * and the curves do not carry those). */
    int32_t measurement;
    vt_edge_cfg edge;
    /* Template tracking (GIST paper sec. III.B tracks by matching), for
     * tentative tracks: when the frame's measurement fails, the track's template
     * (16x16, from its last real measurement) is correlated (vt_ncc_u8) with its
     * box at that measurement's size, bottom centre on the prediction, shifted by
     * every dx, dy in -tmatch_radius..tmatch_radius px; the best shift (first in
     * row-major order on ties) is the measurement if its NCC >= tmatch_ncc_permille
     * / 1000. It updates the filter but is no hit and no miss: a tentative track
     * born from a classifier box (not aligned to the shadow edge the ROI search
     * wants) lives on until a detection re-confirms it, for at most tmatch_max
     * consecutive template frames. Confirmed tracks keep the thesis's coasting:
     * the template's coarse 16x16 grid (a cell is w/16 px) is a poor measurement
     * of the sides and fed a wrong side velocity into a confirmed KITTI track;
     * except a track the frame's measurement has never taken (vt_track.tm_only,
     * e.g. a side view with no shadow edge under its box, confirmed by
     * detections alone): it has nothing else, and coasting dropped it within
     * max_coast frames of its confirmation.
     * tmatch_radius 0: off (the thesis's lifecycle). */
    int32_t tmatch_radius;
    int32_t tmatch_ncc_permille;
    int32_t tmatch_max;
    /* Parts are not vehicles: a detection with >= part_permille of its area inside
     * a live track starts none; an unmatched live track with >= part_permille of
     * its area inside a larger unmatched detection is re-anchored to it (keeping its
     * id); a track with >= part_permille of its area inside a larger live track is
     * dropped. 0: off. */
    int32_t part_permille;
    /* A track narrower than min_width px (or whose corners crossed) is dropped. */
    int32_t min_width;
    /* Flat-road scale consistency (IVVI paper sec. 4's road restriction, used over
     * time): a vehicle's width w and its bottom row b keep w / (b - horizon)
     * constant as its distance changes. Each track keeps the (w, b) of its box
     * after the last detection it took (birth, match, re-anchor); once the caller gave the horizon
     * row h (vt_tracker_set_horizon), a measurement (ROI search, edge curves or
     * template) is taken only if, with R = b_ref - h >= 1 and B = max(b - h, 0),
     *   |w R - w_ref (b - h)| * 1000 <= scale_tol_permille * w_ref * B
     *                                   + 2000 * (w_ref + R)
     * (the relative tolerance, plus 2 px of measurement error in each of w and b),
     * and a track whose frame brought no real measurement is dropped when its
     * predicted box fails the same test. A box that slides down the road without
     * growing (a classifier box whose search walks onto the road's shadows) is
     * then no longer followed. 0, no horizon given, or R < 1: no check. */
    int32_t scale_tol_permille;
    /* A detection's bottom row snapped down to the ROI search (thesis sec. 2.4.2:
     * the verification step gives the box): before a detection starts, re-anchors
     * or updates a track, the ROI search runs on the ROI a track with the
     * detection's box would search (same margin, gates and rules, no side memory);
     * if it finds a box whose sides are within the side gate of the detection's
     * and whose bottom row lies below the detection's, by at most the bottom gate,
     * the detection's bottom becomes that row (its top and sides stay). A
     * classifier box's bottom may sit above the wheels (a side view's window ends
     * at the sills); the next frames' search, and the scale check's reference,
     * then agree with it. Not upwards: on a far car (the KITTI clip's right-lane
     * car, 66 px wide) the search's row above a box's bottom was a bumper line the
     * next frames' search did not find again, and the track was lost. Not the
     * sides: on a 3/4 view the search measures the rear only, and snapping to it
     * on every detection a track took split the Udacity clip's white car into two
     * tracks (birth_search moves them, on births only).
     * 0: off (detections taken as given), 1: on. */
    int32_t snap_bottom;
    /* A new track starts where the ROI search measures (thesis sec. 3.6.1), not
     * where the detector drew: after the bottom snap, the search runs on the birth
     * frame from the detection's box, as a track with that box would search its
     * next frame (same ROI, gates and rules, no side memory), and its box (left,
     * right, bottom; the detection's top) becomes the start, again from that box,
     * until the search stops moving it, finds nothing, leaves a gate or gives an
     * empty box, at most birth_search times. A classifier box of a 3/4 view covers
     * side and rear, the search the rear face; started on the detection, the
     * filter took the next frames' narrower measurements for motion, the box drifted,
     * and the scale check dropped the track (the Udacity clip's white car with
     * cnn_gray_l0_big.npz, the black car with cnn_gray_l0.npz: a second id at
     * the next detection run). On the birth frame there is no motion to confuse.
     * 0: off, 1 .. VT_TRACK_MAX_BIRTH_SEARCH. */
    int32_t birth_search;
    /* The ROI search measures a rear view (thesis sec. 2.4.2: the shadow under the
     * vehicle and its two vertical sides). A box w px wide and h = bottom - top + 1
     * high with w * 1000 > search_max_aspect_permille * h cannot be one: a car's
     * rear, ground to roof, is 1.4-2.0 m wide and 1.2-1.7 m high (at most 1.7:1),
     * trucks and buses are taller; the rest up to 2.5:1 is a detector's box error
     * and the side of a 3/4 view. Flatter boxes are side views (crossing or parked
     * cars) and roofs seen over a barrier: on the Udacity clip such a track (29 x 10
     * px, a car's roof over the median barrier) was confirmed by the search on the
     * barrier's rail and followed the rail after the car had gone. For such a box
     * the search is not run (no bottom snap, no birth search, no per-frame
     * measurement): its template carries it between detections (as a track only
     * detections confirmed, tm_only) and only detections confirm it.
     * VT_MEAS_ROI_SEARCH only (edge curves follow any shape). 0: off. */
    int32_t search_max_aspect_permille;
} vt_tracker_cfg;

/* Largest search_max_aspect_permille (100:1): keeps w * 1000 and the bound times
 * a height inside int64 for any checked box. */
#define VT_TRACK_MAX_ASPECT_PERMILLE 100000

/* Largest birth_search: the search settles in one or two steps on real frames. */
#define VT_TRACK_MAX_BIRTH_SEARCH 8

#define VT_MEAS_ROI_SEARCH 0
#define VT_MEAS_EDGE_CURVES 1
#define VT_MEAS_ROI_EDGES 2

#define VT_TRACKER_CFG_DEFAULT                                              \
    {                                                                       \
        .search = VT_TRACK_SEARCH_CFG_DEFAULT,                              \
        .model = VT_KF_MODEL_CFG_DEFAULT,                                   \
        .roi_margin_min = 6,                                                \
        .roi_margin_permille = 0,                                           \
        .gate_permille = 350,                                               \
        .gate_bottom_permille = 100,                                        \
        .confirm_hits = 3,                                                  \
        .max_coast = 9,                                                     \
        .match_iou_permille = 300,                                          \
        .keep_ncc = (vt_q14)((VT_Q14_ONE * 7 + 5) / 10), /* 0.7, rounded */ \
        .init_max_change = 3,                                               \
        .measurement = VT_MEAS_ROI_SEARCH,                                  \
        .edge = VT_EDGE_CFG_DEFAULT,                                        \
        .tmatch_radius = 6,                                                 \
        .tmatch_ncc_permille = 800,                                         \
        .tmatch_max = 12,                                                   \
        .part_permille = 600,                                               \
        .min_width = 4,                                                     \
        .scale_tol_permille = 200,                                          \
        .snap_bottom = 1,                                                   \
        .birth_search = 2,                                                  \
        .search_max_aspect_permille = 2500,                                 \
    }

/* One track. Public so that callers can inspect and save it; change it only
 * through the functions below. */
typedef struct {
    int32_t id;           /* 1..INT32_MAX-1, never reused within a run */
    int32_t state;        /* vt_track_state */
    int32_t hits;         /* successful measurements so far */
    int32_t misses;       /* consecutive frames without a measurement */
    int32_t age;          /* frames since the track started */
    int32_t aspect_q8;    /* box height / width, Q8, from the detection */
    vt_box box;           /* current estimate (inclusive pixels) */
    vt_q16 vx;            /* image velocity of the bottom edge, px/frame */
    vt_q16 vy;
    vt_track_sides sides; /* the two-threshold side rule's memory */
    vt_kf kf;             /* bottom-edge model [x1, y1, x2, vx1, vy1, vx2] */
    uint8_t tmpl[VT_TRACK_TEMPLATE * VT_TRACK_TEMPLATE];
    vt_edge_template edges; /* curve points, used by VT_MEAS_EDGE_CURVES only */
    int32_t tm_frames;    /* consecutive frames measured by the template only */
    vt_box tmpl_box;      /* the box tmpl was sampled from */
    int32_t ref_w;        /* width and bottom row after the last detection taken */
    int32_t ref_b;        /* (scale_tol_permille's reference) */
    int32_t tm_only;      /* 1 until a real measurement (ROI search, edge curves)
                             took the track: between detections only its template
                             measures it, confirmed or not */
} vt_track;

typedef struct {
    int32_t next_id;        /* INT32_MAX: every id given out, no track starts */
    int32_t frame;          /* frames stepped so far (saturates at INT32_MAX) */
    int32_t dropped_full;   /* detections not started because every slot (or every
                               id) was used; saturates, as hits, misses and age */
    vt_track tracks[VT_MAX_TRACKS];
    vt_track_search_ws ws;
    vt_edge_ws *edge_ws;    /* VT_MEAS_EDGE_CURVES's crop workspace, caller-owned;
                               NULL (vt_tracker_init) until vt_tracker_set_edge_ws */
    int32_t horizon_known;  /* 0 (vt_tracker_init) until vt_tracker_set_horizon */
    int32_t horizon_y;      /* the road's horizon row, input pixels */
} vt_tracker;

/* What the tracker reports per track and frame. */
typedef struct {
    int32_t id;
    int32_t state;
    vt_box box;
    vt_q16 vx; /* px/frame */
    vt_q16 vy;
} vt_track_out;

/* Largest confirm_hits and max_coast, frames (a minute at 30 fps): a longer
 * coast only lets the covariance saturate. */
#define VT_TRACK_MAX_FRAMES_CFG 1800

/* VT_OK if every field of *cfg is in its domain: search as
 * vt_track_search_cfg_check, model as vt_kf_model_cfg_check, 0 <= roi_margin_min
 * <= VT_MAX_WIDTH, roi_margin_permille, gate_permille, gate_bottom_permille in
 * 0..4000, 1 <= confirm_hits <= VT_TRACK_MAX_FRAMES_CFG, 0 <= max_coast <=
 * VT_TRACK_MAX_FRAMES_CFG, match_iou_permille in 1..1000, keep_ncc in [-1, 1]
 * (Q14), 0 <= init_max_change <= VT_MAX_WIDTH, 0 <= tmatch_radius <= 64,
 * tmatch_ncc_permille in -1000..1000, 0 <= tmatch_max <= VT_TRACK_MAX_FRAMES_CFG,
 * part_permille in 0..1000, 0 <= min_width <= VT_MAX_WIDTH, scale_tol_permille in
 * 0..1000, snap_bottom 0 or 1, birth_search in 0..VT_TRACK_MAX_BIRTH_SEARCH,
 * search_max_aspect_permille in 0..VT_TRACK_MAX_ASPECT_PERMILLE. VT_E_ARG otherwise and for NULL.
 * vt_tracker_step checks the same before touching the tracker. */
vt_status vt_tracker_cfg_check(const vt_tracker_cfg *cfg);

/* Empty the tracker (ids restart at 1). VT_E_ARG for NULL. */
vt_status vt_tracker_init(vt_tracker *tr);

/* Fill *cfg with VT_TRACKER_CFG_DEFAULT. VT_E_ARG for NULL. */
vt_status vt_tracker_cfg_default(vt_tracker_cfg *cfg);

/* Attach the caller's workspace for VT_MEAS_EDGE_CURVES (ws NULL detaches it).
 * Call after vt_tracker_init, which detaches it. The tracker keeps the pointer:
 * *ws must outlive its use and is overwritten by every vt_tracker_step with the
 * edge measurement. It holds nothing from one step to the next (scratch only), so
 * trackers stepped one after another may share one workspace, never trackers
 * stepped concurrently. The ROI search never touches it. VT_E_ARG for tr NULL. */
vt_status vt_tracker_set_edge_ws(vt_tracker *tr, vt_edge_ws *ws);

/* The horizon row for scale_tol_permille's check from the next vt_tracker_step on
 * (the pipeline passes the one its whole-road detector uses, every frame): known
 * non-zero and |row| <= 4 * VT_MAX_HEIGHT, or known 0 to turn the check off (as
 * after vt_tracker_init). VT_E_ARG for tr NULL or a row out of range (the tracker
 * unchanged). */
vt_status vt_tracker_set_horizon(vt_tracker *tr, int32_t known, int32_t row);

/* A track list as vt_tracker_step writes it: every track that is not VT_TRACK_FREE has
 * an id > 0, unique among them, and an ordered box (left <= right, top <= bottom).
 * VT_OK, or VT_E_ARG (also for n_tracks < 0, or NULL with n_tracks > 0). */
vt_status vt_track_list_check(const vt_track_out *tracks, int32_t n_tracks);

/* One frame. Every live track: predict, search its ROI in `img`, update when
 * found (else it coasts). If `detection_frame` is non-zero, `dets[0..n_dets-1]`
 * are this frame's detections (n_dets may be 0; dets may be NULL only then):
 * each is matched to at most one track by IoU (greedy, best pair first, at least
 * match_iou_permille); a matched track is updated with the detection as a
 * second measurement (counted as its hit when the search failed); a track no detection matched survives only if its template
 * correlates with the same box in `img` at >= keep_ncc; an unmatched detection
 * that overlaps no track starts a tentative track (or, when every slot is used,
 * is counted in dropped_full: the defined behaviour when full; likewise once
 * every id 1..INT32_MAX-1 was given out, so an id is never reused).
 * Writes up to out_cap live tracks to out (all states but FREE) and their count
 * to *n_out; VT_E_CAPACITY if more were live than out_cap (out is still filled).
 * VT_E_ARG / VT_E_SIZE for bad arguments (then the tracker is unchanged),
 * including VT_E_ARG when cfg->measurement is VT_MEAS_EDGE_CURVES and no
 * workspace is attached (vt_tracker_set_edge_ws). */
vt_status vt_tracker_step(vt_tracker *tr, const vt_tracker_cfg *cfg, const vt_image_u8 *img,
                          int32_t detection_frame, const vt_box *dets, int32_t n_dets,
                          vt_track_out *out, int32_t out_cap, int32_t *n_out);

/* End the live track `id` now (its slot becomes free; the other tracks keep their
 * slots, so the output order of the others is unchanged; the id is never given
 * again). Used by the pipeline when it hands a vehicle over to the flow stage
 * (vehtrack/pipeline.h). VT_E_ARG for tr NULL or no live track with this id. */
vt_status vt_tracker_drop(vt_tracker *tr, int32_t id);

#endif /* VEHTRACK_TRACKER_H */
