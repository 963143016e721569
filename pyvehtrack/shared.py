"""Plain types both engines share: the stage configurations of the detection stages
(fields, integer units and defaults as the C structs: shadow.h, verify.h, windows.h,
fulldet.h), the road area (vt_road_area, road.h), the flat-road camera of the window
stage and the fixed trapezoid road. No C and no oracle logic lives here, so the
friendly layer (detector.py, fullroad.py) uses them without importing
pyvehtrack.reference, and the oracle (reference/) re-exports them under its old names.
tests/test_detect.py and tests/test_fulldet.py check the defaults against the core's.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, fields
from fractions import Fraction

import numpy as np

# The frame width the stages' pixel settings were chosen at and the shipped networks trained
# at: the friendly layer (pyvehtrack.pipeline.Pipeline's work_width) downscales wider frames
# to it (README, "Any camera size").
WORK_WIDTH = 1280

FIXED = 0
ADAPTIVE = 1
DARK_ABOVE = 0
DARK_BELOW = 1


@dataclass(frozen=True)
class ShadowConfig:
    """Same fields, units and defaults as vt_shadow_cfg (include/vehtrack/shadow.h).

    Fractions of at most one are permille, scale factors that may exceed one Q8 integers
    (256 = 1.0), so the oracle uses exactly C's values."""
    threshold_mode: int = ADAPTIVE
    polarity: int = DARK_ABOVE     # the thesis's edge: dark shadow above the lit road
    grad_threshold: int = 48       # fixed: s*sobel_y >= this (Sobel gain 4: a 12-level step)
    adapt_k_q8: int = 96           # adaptive: dark = I < median - k*MAD, k = 0.375
    adapt_grad_min: int = 8        # adaptive: and s*sobel_y >= this (a 2-level step)
    stat_step: int = 2             # adaptive: statistics on every 2nd row and column
    min_run: int = 12              # thesis: 10-15 px
    max_gap: int = 2               # gaps bridged inside a run
    merge_rows: int = 2            # thesis: rows within 2 px are combined
    width_min_q8: int = 77         # 0.30 of the lane width
    width_max_q8: int = 256        # 1.00 of the lane width
    reduce_overlap_permille: int = 500  # 0.5 of the narrower edge
    reduce_height_q8: int = 256    # up to 1.0 x width above a kept edge
    reduce_verified: int = 0       # 1: only an edge that passes verification suppresses (issue 8 item 5)


@dataclass(frozen=True)
class VerifyConfig:
    """Same fields, units and defaults as vt_verify_cfg (include/vehtrack/verify.h)."""
    widen_px: int = 6              # thesis: 6 px on each side
    widen_q8: int = 26             # plus this x edge length, 0.1 (thesis: 0)
    roi_height_q8: int = 128       # thesis: half the edge length
    vedge_threshold: int = 40      # |sobel_x| >= this (Sobel gain 4: a 10-level step)
    side_min_frac_permille: int = 250  # a side needs vertical edges on 1/4 of the ROI rows
    side_min_px: int = 3           # and on at least 3 rows
    side_contrast_q8: int = 384    # and >= 1.5 x the ROI's mean column count
    min_width_q8: int = 128        # sides >= 0.5 x edge length apart
    aspect_q8: int = 256           # height / width = 1.0 (thesis default)
    vedge_reach: int = 0           # 1: derivative over x-2..x+2 for codec-smoothed sides (thesis: Sobel, 0)
    vedge_hyst_permille: int = 0    # 200: weak pixels >= 40 - 8 count in a column run with a strong one (thesis: 0)


@dataclass(frozen=True)
class Camera:
    """Minimal flat-road camera: focal length (px), horizon row, camera height (m),
    first hood row (rows at or below it are not road)."""
    fx: float = 714.0
    horizon_y: int = 376
    height_m: float = 1.8
    hood_y: int = 720


@dataclass(frozen=True)
class WindowConfig:
    veh_w_min_m: float = 1.4
    veh_w_max_m: float = 2.6
    sizes: tuple = (32, 45)
    step: float = 0.25          # fraction of the window side (C: step_q8 / 256)
    levels: int = 5
    lane_w_m: float = 3.7
    top_margin: int = 2


@dataclass(frozen=True)
class FullDetConfig:
    shadow_source: bool = True
    window_source: bool = True
    win: WindowConfig = field(default_factory=WindowConfig)
    shadow: ShadowConfig = field(default_factory=ShadowConfig)
    # VT_FULLDET_CFG_DEFAULT's verify omits the codec tolerances: 0, the thesis's verification.
    verify: VerifyConfig = field(default_factory=lambda: VerifyConfig(aspect_q8=192, vedge_reach=0,
                                                                      vedge_hyst_permille=0))
    window_score_min: int = 0
    edge_check: bool = True
    shadow_classify: bool = True
    shadow_score_min: int = 0
    shadow_score: int = 0
    nms_iou_permille: int = 301       # NMS: drop a box whose IoU with a kept one is above this / 1000
    nms_contain_permille: int = 699   # ... or whose intersection is above this / 1000 of the smaller box
    box_height: float = 192 / 256     # window box height / width (bottom row kept; C: Q8, may exceed 1)
    merge_iou_permille: int = 0       # 0: off; else each kept box -> mean of candidates with IoU >= this / 1000
    rerank_permille: int = 0          # 0: off; else NMS ranks by score + this / 1000 x the second-stage score


@dataclass(frozen=True)
class WideConfig:
    """The whole-road detector's wide pass (vt_fulldet_wide_cfg, fulldet.h): a second
    window grid with the band veh_w_min_m..veh_w_max_m, boxes box_height of their width
    high, scored by a wide window model; score_min in the model's Q16 units; NMS limits
    among the wide boxes and against the boxes already found. C holds the fractions in
    permille, as here (the house's one unit for fractions)."""
    veh_w_min_m: float = 2.0
    veh_w_max_m: float = 8.0
    box_height_permille: int = 400
    score_min: int = 0
    nms_iou_permille: int = 200
    nms_contain_permille: int = 500
    # the aspect chosen by the wide model's score (vt_fulldet_wide_cfg.alt_*): 0, 0 = off
    alt_height_a_permille: int = 0
    alt_height_b_permille: int = 0
    alt_score_min: int = 0


@dataclass
class RoadArea:
    """Python twin of vt_road_area (include/vehtrack/road.h): per-row road span
    x_left[y]..x_right[y] (inclusive) for y_top <= y <= y_bottom and the ego lane
    width per row. Arrays have one entry per image row."""
    y_top: int
    y_bottom: int
    x_left: np.ndarray
    x_right: np.ndarray
    lane_width: np.ndarray
    valid: bool = True

    @property
    def height(self) -> int:
        return len(self.x_left)


def trapezoid_road(h: int, w: int, *, vp=(0.5, 0.45), bottom=(0.0, 1.0),
                   lane_bottom: float = 0.5, top_margin: int = 4) -> RoadArea:
    """A fixed road area for frames without lane lines: a trapezoid from the frame's
    bottom row (columns bottom[0]*w .. bottom[1]*w) toward the vanishing point
    vp = (x, y) (fractions of w, h), cut `top_margin` rows below it. The ego lane
    width grows linearly from 0 at the vanishing point to lane_bottom*w at the
    bottom row (flat road, straight lanes). Integer arrays, as C gets them."""
    vx, vy = vp[0] * (w - 1), vp[1] * (h - 1)
    yb = h - 1
    yt = int(np.ceil(vy)) + top_margin
    ys = np.arange(h, dtype=np.float64)
    span = yb - vy if yb > vy else 1.0
    t = np.clip((ys - vy) / span, 0.0, 1.0)
    xl = np.floor(vx + t * (bottom[0] * (w - 1) - vx) + 0.5)
    xr = np.floor(vx + t * (bottom[1] * (w - 1) - vx) + 0.5)
    lw = np.floor(t * lane_bottom * w + 0.5)
    yt = min(max(yt, 0), yb)
    return RoadArea(y_top=yt, y_bottom=yb, x_left=xl.astype(np.int16),
                    x_right=xr.astype(np.int16), lane_width=lw.astype(np.int16))


def road_polygon(road) -> np.ndarray:
    """The road area's outline as an (N, 2) int array of (x, y), clockwise from the
    top-left: left border downward, then right border upward."""
    if road is None or not road.valid or road.y_top > road.y_bottom:
        return np.zeros((0, 2), np.int64)
    ys = np.arange(road.y_top, road.y_bottom + 1)
    left = np.stack([np.asarray(road.x_left)[ys], ys], 1)
    right = np.stack([np.asarray(road.x_right)[ys], ys], 1)[::-1]
    return np.concatenate([left, right]).astype(np.int64)


# Fields renamed when the configs moved to one unit for fractions (permille; issue 10
# item 6): old name -> (new name, factor), the conversion exact (new = old * factor).
TRACKER_RENAMED = {"roi_margin_percent": ("roi_margin_permille", 10), "gate_percent": ("gate_permille", 10),
                   "gate_bottom_percent": ("gate_bottom_permille", 10),
                   "match_iou_percent": ("match_iou_permille", 10)}
SEARCH_RENAMED = {"min_h_percent": ("min_h_permille", 10), "min_v_percent": ("min_v_permille", 10),
                  "bottom_percent": ("bottom_permille", 10)}
# Q8 fractions of at most 1 (256 = 1.0): new = old * 1000 / 256, accepted only where exact.
SHADOW_RENAMED = {"reduce_overlap_q8": ("reduce_overlap_permille", Fraction(1000, 256))}
VERIFY_RENAMED = {"side_min_frac_q8": ("side_min_frac_permille", Fraction(1000, 256))}
LANE_RENAMED = {"track_alpha_q8": ("track_alpha_permille", Fraction(1000, 256))}
# vt_fulldet_cfg: FullDetConfig took these as float fractions (C rounded them to Q8); now
# permille ints. An old value is taken when it is a whole number of permille as written
# (0.2 -> 200, 0.3 -> 300), else a ValueError (77 / 256 = 0.30078125 is not rounded).
FULLDET_RENAMED = {"nms_iou": ("nms_iou_permille", 1000, "fraction"),
                   "nms_contain": ("nms_contain_permille", 1000, "fraction"),
                   "merge_iou": ("merge_iou_permille", 1000, "fraction")}
# vt_flow_cfg (pyvehtrack.flow.make_cfg): percent -> permille, x 10
FLOW_RENAMED = {"strip_percent": ("strip_permille", 10), "top_percent": ("top_permille", 10),
                "bottom_percent": ("bottom_permille", 10), "diff_min_percent": ("diff_min_permille", 10),
                "seed_min_visible": ("seed_min_visible_permille", 10)}


def take_renamed(owner: str, kw: dict, renamed: dict, stacklevel: int = 3) -> dict:
    """kw with every old name in `renamed` replaced by its new one (new = old x factor), with a
    DeprecationWarning. A value that is not an int is passed on as it is, so the config's own
    check names the field and the type; an int whose new value would not be a whole number
    is a ValueError (never rounded silently); old and new together is a TypeError. An entry
    (new, factor, "fraction") takes a float fraction too, read as its shortest decimal
    (repr: 0.3 is 3/10), so 0.3 x 1000 is 300 and 0.30078125 x 1000 a ValueError."""
    for old, (new, factor, *kind) in renamed.items():
        if old in kw:
            if new in kw:
                raise TypeError(f"{owner}: give {new} or the deprecated {old}, not both")
            warnings.warn(f"{owner}.{old} is deprecated: use {new} (= {old} x {factor})",
                          DeprecationWarning, stacklevel=stacklevel)
            v = kw.pop(old)
            fraction = kind == ["fraction"] and isinstance(v, (float, np.floating)) and math.isfinite(v)
            if fraction or (isinstance(v, (int, np.integer)) and not isinstance(v, bool)):
                nv = (Fraction(repr(float(v))) if fraction else Fraction(int(v))) * factor
                if nv.denominator != 1:
                    raise ValueError(f"{owner}.{old}={v}: is {float(nv)} in {new}, not a whole "
                                     f"number; give {new} instead")
                v = int(nv)
            kw[new] = v
    return kw


def accept_renamed(cls, renamed: dict):
    """Let dataclass `cls` still take the fields in `renamed` under their old names:
    cls(old=v) sets new = v * factor (take_renamed), and obj.old reads new / factor, both
    with a DeprecationWarning."""
    init = cls.__init__

    def __init__(self, *args, **kw):
        init(self, *args, **take_renamed(cls.__name__, kw, renamed))

    __init__.__wrapped__ = init
    cls.__init__ = __init__
    for old, (new, factor, *_) in renamed.items():
        def _get(self, old=old, new=new, factor=factor):
            warnings.warn(f"{type(self).__name__}.{old} is deprecated: use {new} (= {old} x {factor})",
                          DeprecationWarning, stacklevel=2)
            v = Fraction(getattr(self, new)) / factor
            return int(v) if v.denominator == 1 else float(v)
        setattr(cls, old, property(_get))
    return cls


accept_renamed(ShadowConfig, SHADOW_RENAMED)  # the Q8 names of before issue 10
accept_renamed(VerifyConfig, VERIFY_RENAMED)
accept_renamed(FullDetConfig, FULLDET_RENAMED)  # the float fractions of before issue 10


# ---------------------------------------------------------------- lanes (vt_lane_cfg, lane.h)
QDEG = 4  # quarter degrees per degree (vehtrack/trig.h)

SIDE_NAMES = ("left-most", "left", "right", "right-most")   # the four lane slots, left to right


@dataclass(frozen=True)
class LaneConfig:
    """Mirror of the C vt_lane_cfg (include/vehtrack/lane.h): same field names, same integer units. Defaults:
    chosen on half B of TuSimple test100 (tools/tune_lanes.py --tune B)."""
    work_width_max: int = 320         # box-downscale by 2^s (s <= 3) until W <= this
    work_height_max: int = 240        # ... and H <= this
    roi_top_permille: int = 250       # rows above H*this/1000 are never looked at
    hough_top_permille: int = 500     # Hough votes from rows >= H*this/1000
    grad_min: int = 14                # [-1 0 1] threshold floor
    noise_gain_q4: int = 48           # row threshold >= mean|g| * this / 16
    mark_w_top_permille: int = 6      # widest marking at row 0 / row H-1, per mille of W
    mark_w_bottom_permille: int = 40
    mark_wmin_top_permille: int = 0   # narrowest marking at row 0 / row H-1 (>= 1 px)
    mark_wmin_bottom_permille: int = 4
    marks_per_row_max: int = 24       # a row with more centres is texture: dropped
    marks_max: int = 4096             # centres kept per frame (bottom rows first)
    theta_min_qdeg: int = 4 * QDEG    # left half theta range; right half mirrored
    theta_max_qdeg: int = 80 * QDEG
    theta_step_qdeg: int = 1 * QDEG
    rho_step_shift: int = 0           # a rho bin is 2^this working px (0..3)
    vote_min: int = 8                 # a peak needs >= this many votes
    vote_min_permille: int = 80       # ... and >= band rows * this / 1000
    nms_theta_bins: int = 4           # peak = maximum of a (2a+1) x (2b+1) window
    nms_rho_bins: int = 8
    max_peaks: int = 6                # candidates per half
    merge_permille: int = 19          # lines closer than W*this/1000 at both band ends merge
    min_dtheta_qdeg: int = 12 * QDEG  # ego vs outer line angle difference
    ego_theta_max_qdeg: int = 65 * QDEG  # flatter lines can only be outer lines
    ego_vote_permille: int = 500      # an inner line replacing the ego needs this share
    vp_x_permille: int = 250          # vanishing point within cx +- W*this/1000
    vp_low_permille: int = 700        # ... and not below row H*this/1000
    vp_tol_permille: int = 15         # lane lines pass within W*this/1000 px of it
    vp_tol_min: int = 2               # ... or within this many px (small frames)
    lane_w_min_permille: int = 250    # ego lane width at the bottom row, per mille of W
    lane_w_max_permille: int = 2000
    refine_iters: int = 2             # least-squares passes over the band
    refine_tol_permille: int = 16     # first pass window W*this/1000, halved per pass
    refine_tol_min: int = 2           # ... but never below this many px
    fit_min_points: int = 6           # fewer points: keep the line as it was
    seg_min: int = 3                  # extension segment rows, at least
    seg_permille: int = 500           # ... else this share of the distance to the VP
    bend_q8: int = 128                # slope change per segment <= this/256 px/row
    seg_count_min: int = 2            # a segment needs this many centres ...
    seg_count_permille: int = 150     # ... and seg rows * this / 1000
    seg_miss_max: int = 1             # without a VP: stop after this many empty segments
    win_bottom_permille: int = 20     # segment window: W*this/1000 px at the bottom row,
    win_top: int = 2                  # ... this many px at the vanishing row
    vp_margin: int = 2                # without a VP: never above roi_top + this
    top_margin_permille: int = 25     # with a VP: lanes end H*this/1000 rows below it
    track_alpha_permille: int = 500   # smoothing gain toward the new line, permille
    track_hold: int = 5               # frames a hidden marking's line is kept
    track_gate_permille: int = 31     # farther than W*this/1000 px: replace, not smooth
    solo_vote_permille: int = 1500    # no ego pair at a plausible vanishing point: a line
                                      # needs votes >= vote floor * this / 1000


accept_renamed(LaneConfig, LANE_RENAMED)  # the Q8 gain of before issue 10


def lane_config_from(obj) -> LaneConfig:
    """A LaneConfig from anything with the same attribute names (e.g. a cffi vt_lane_cfg)."""
    return LaneConfig(**{f.name: int(getattr(obj, f.name)) for f in fields(LaneConfig)})


# ---------------------------------------------------------------- tracker (vt_tracker_cfg, tracker.h)
# The oracle's tracker configuration (reference.tracker.TrackerCfg and its parts re-export these);
# pyvehtrack.config.TrackerConfig is the friendly layer's integer twin.
MEAS_ROI_SEARCH, MEAS_EDGE_CURVES, MEAS_ROI_EDGES = 0, 1, 2    # vt_tracker_cfg.measurement
TWO_THRESHOLD, LARGEST = 0, 1               # vt_search_cfg.side_mode


@dataclass
class SearchCfg:
    polarity: int = DARK_ABOVE   # shadow above the lit road: sobel_y >= h_thresh
    h_thresh: int = 16
    v_thresh: int = 60
    min_h_permille: int = 200
    min_v_permille: int = 200
    bottom_permille: int = 500    # 1000: the thesis's largest value
    side_mode: int = LARGEST      # TWO_THRESHOLD: the thesis's tracking rule


accept_renamed(SearchCfg, SEARCH_RENAMED)  # the percent names of before issue 10


@dataclass
class EdgeCfg:
    """As vt_edge_cfg (see include/vehtrack/edge_track.h for each field)."""
    low: int = 40
    high: int = 100
    min_len: int = 10
    radius: int = 8
    trunc: int = 15
    max_mean_q8: int = 1536
    min_points: int = 16
    scale_steps: int = 2
    scale_step_q8: int = 4


@dataclass
class ModelCfg:
    """The bottom-edge model's parameters, as vt_kf_model_cfg (floats here)."""
    dt: float = 1.0
    accel_x: float = 1.0
    accel_y: float = 0.5
    p_max: float = 0.1
    p_zero: float = 0.3
    meas_sigma_x: float = 2.0
    meas_sigma_y: float = 2.0
    init_sigma_pos: float = 4.0
    init_sigma_vel: float = 5.0


@dataclass
class TrackerCfg:
    search: SearchCfg = field(default_factory=SearchCfg)
    model: ModelCfg = field(default_factory=ModelCfg)
    roi_margin_min: int = 6        # thesis: the verification ROI's 6 px
    roi_margin_permille: int = 0
    gate_permille: int = 350
    gate_bottom_permille: int = 100
    confirm_hits: int = 3
    max_coast: int = 9             # lives to the next detection run (every 10th frame)
    match_iou_permille: int = 300
    keep_ncc: float = 0.7
    init_max_change: int = 3
    measurement: int = MEAS_ROI_SEARCH
    edge: EdgeCfg = field(default_factory=EdgeCfg)
    # template tracking when the measurement fails (0: off), see reference.tracker.Tracker._tmatch
    tmatch_radius: int = 6
    tmatch_ncc_permille: int = 800
    tmatch_max: int = 12
    part_permille: int = 600       # parts are not vehicles (0: off)
    min_width: int = 4             # narrower tracks are dropped (0: off)
    # flat-road scale consistency: w / (bottom - horizon) kept within this permille of
    # the last detection's, plus 2 px (0: off; needs Tracker.set_horizon)
    scale_tol_permille: int = 200
    # a detection's bottom snapped down to the row the ROI search finds under it (0: off)
    snap_bottom: int = 1
    # a new track starts on the box the ROI search settles on in its birth frame, at most
    # this many searches (0: off; tracker.h's birth_search)
    birth_search: int = 2
    # the ROI search measures rear views only: a box with w * 1000 > this * h is not searched
    # (no snap, birth search or measurement); its template carries it and detections confirm
    # it (0: off; tracker.h's search_max_aspect_permille)
    search_max_aspect_permille: int = 2500


accept_renamed(TrackerCfg, TRACKER_RENAMED)  # the percent names of before issue 10


# ---------------------------------------------------------------- camera and range (camera.h)
# The float records of the camera stage (reference.camera re-exports them; the C engine
# converts its Q16 structs into the same records).
DIST_MAX_M = 1000.0
LEAD_UNKNOWN, LEAD_STOPPED, LEAD_SLOWER, LEAD_DECEL = 0, 1, 2, 3
PITCH_NOMINAL, PITCH_MEASURED, PITCH_HELD, PITCH_REJECTED = 0, 1, 2, 3
FCW_WARNING, FCW_ONSET, FCW_SUPPRESSED = 1, 2, 4


@dataclass(frozen=True)
class CameraParams:
    """The float twin of vt_camera_cfg (pitch as its tangent)."""
    img_w: int
    img_h: int
    fx: float
    fy: float
    cx: float
    cy: float
    height: float
    tan_pitch: float = 0.0
    tan_pitch_min: float = math.tan(math.radians(-3))
    tan_pitch_max: float = math.tan(math.radians(3))
    pitch_max_step: float = 0.02
    pitch_alpha_permille: int = 250   # smoothing gain of the pitch, permille
    pitch_reacquire: int = 5
    delta_px: float = 1.0
    bottom_offset: float = 0.5
    vehicle_width: float = 1.8
    width_tol_permille: int = 250   # the two distances agree within this permille
    lateral: float = 0.0            # m, the camera right of the car's centre line (the FCW corridor's centre)


@dataclass(frozen=True)
class RangeParams:
    """The float twin of vt_range_cfg."""
    frame_dt: float = 0.1
    jerk_sigma: float = 5.0
    init_sigma_rate: float = 10.0
    init_sigma_accel: float = 3.0
    sigma_min: float = 0.05
    min_frames: int = 3
    scale_lag: int = 5
    ttc_max: float = 20.0
    ttc_stopped: float = 2.1
    ttc_slower: float = 2.0
    ttc_decel: float = 2.4
    ttc_margin: float = 0.7
    confirm_frames: int = 3
    rearm_frames: int = 30
    release_frames: int = 10
    min_closing: float = 0.3
    stopped_speed: float = 1.0
    decel_thresh: float = 1.0
    width_min_frames: int = 3
    width_window: int = 16
    rear_offset: float = 0.0
    path_half_width: float = 1.5   # m; 0: every track may warn (no ego-path check)


@dataclass
class BoxDistance:
    valid: bool
    far_valid: bool
    width_agrees: bool
    distance: float
    dist_near: float
    dist_far: float
    sigma: float
    dist_width: float
    bottom_clipped: bool = False
    side_clipped: bool = False


@dataclass
class RangeOut:
    id: int
    distance: float | None      # this frame's eq. 1 distance (None: not below the horizon)
    sigma: float
    dist_width: float
    width_agrees: bool
    dist_filt: float | None
    rate: float | None          # m/s, negative closing
    ttc_dist: float | None
    ttc_scale: float | None
    closing: bool
    lead_class: int
    fcw: int
    from_width: bool = False
    accel: float | None = None  # m/s^2, range acceleration
    in_path: bool = True        # the box overlaps the ego corridor (path_half_width)

    @property
    def warning(self) -> bool:
        return bool(self.fcw & FCW_WARNING)


# ---------------------------------------------------------------- tracks (both views)
@dataclass(frozen=True)
class TrackBase:
    """What every view of a track carries (pyvehtrack.tracker.Track adds its source,
    pyvehtrack.pipeline.Track the camera stage's distance, TTC and warning)."""
    id: int
    state: str            # "tentative" | "confirmed" | "coasting" | "handover" (pipeline, flow source)
    box: tuple            # (left, top, right, bottom), inclusive, input pixels
    velocity: tuple       # (vx, vy) of the bottom edge, input px/frame


# vt_model_cfg (pyvehtrack.vehicle_model.make_cfg): percent -> permille, x 10
# mut_percent -> mut_permille is exact for the GA's draw too: (r * 1000) >> 32 < 10 p
# exactly when (r * 100) >> 32 < p (both say r < p 2^32 / 100).
MODEL_RENAMED = {"width_tol_percent": ("width_tol_permille", 10),
                 "aspect_min_percent": ("aspect_min_permille", 10),
                 "aspect_max_percent": ("aspect_max_permille", 10),
                 "mut_percent": ("mut_permille", 10)}
CAMERA_RENAMED = {"width_tol_percent": ("width_tol_permille", 10),
                  "pitch_alpha_q8": ("pitch_alpha_permille", Fraction(1000, 256))}
accept_renamed(CameraParams, CAMERA_RENAMED)  # the percent / Q8 names of before issue 10
