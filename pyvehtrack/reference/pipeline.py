"""The float oracle of c/pipeline.c: the oracle stages composed in the same order
(thesis fig. 4.1 for detection, ch. 3 for tracking), so C and oracle can be compared
frame by frame end to end.

    lanes (reference.lane)                on detection frames, or every frame
      -> road area                        the lanes' area, else the fixed trapezoid
      -> shadow hypotheses (reference.shadow) -> verification (reference.verify)
                                          on frames 0, N, 2N, ...
         or, with a classifier (score), the whole-road detector (reference.fulldet)
         on the camera road (reference.windows.road_from_camera), the horizon the
         lanes' vanishing row once they found one (held while they are lost)
      -> tracker (reference.tracker)      every frame
      -> hand-over (with the flow stage)  a track the ego car overtakes, leaving by the side,
                                          goes to the flow stage (reference.flow seed) and is
                                          reported with its id until the flow stage ends it
      -> geometry (reference.camera)      with a camera: pitch from the lanes' vanishing
                                          row, range filter, TTC and FCW per track

Plain NumPy/OpenCV, never calling C. Capacities (VT_MAX_*) are passed in, so the
oracle drops what C drops.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from fractions import Fraction

import numpy as np

from . import camera as rcam
from . import flow as rflow
from . import hood as rhood
from . import fulldet as rfd
from . import lane as rlane
from . import tracker as rtrk
from . import ttc_scale as rttc
from . import vehicle_model as rvm
from . import detect as rdetect
from . import windows as rw
from .shadow import RoadArea, ShadowConfig, trapezoid_road
from .verify import VerifyConfig

ROAD_AUTO, ROAD_LANES, ROAD_FIXED = "auto", "lanes", "fixed"
SRC_SHADOW = "shadow"
SRC_CLASSIFIER = "classifier"
SRC_FLOW = "flow"
SRC_MODEL = "model"
SRC_EGO = "ego"       # with a classifier: the ego-lane detector's boxes ahead of the whole-road ones
HANDOVER = 4   # a track's state once handed over to the flow stage (VT_PIPE_HANDOVER)


# vt_pipeline_cfg.verify 4: boxes narrower than this (px) skip the second stage (c/internal.h
# VT__VERIFY_SMALL_W: the rear-view window's smallest box; the 64x64 MLP would see them enlarged 2x+)
VERIFY_SMALL_W = 32


def _verify_skips(row, w: int, c) -> bool:
    """vt_pipeline_cfg.verify 2 / 3 / 4: a box the rear-view second stage does not judge (it
    keeps its own score): flatter than 1:2 (verify_flat False), or with a gap to the frame's
    left or right side of at most a quarter of its width plus 1 px (verify_side False), or
    narrower than VERIFY_SMALL_W px (verify_small False)."""
    bw = int(row[2]) - int(row[0]) + 1
    flat = 2 * (int(row[3]) - int(row[1]) + 1) < bw
    side = 4 * int(row[0]) <= bw + 4 or 4 * (w - 1 - int(row[2])) <= bw + 4
    return (not c.verify_flat and flat) or (not c.verify_side and side) or (not c.verify_small and bw < VERIFY_SMALL_W)


@dataclass
class RoadCameraRef:
    """The whole-road detector's camera relative to the frame (vt_road_camera): the
    horizon and hood rows as fractions of h, rounded half up per frame; the camera
    height; fx as a fraction of w (used for distances only, not by the windows)."""
    horizon: float = 30037 / 65536
    hood: float = 60948 / 65536
    height_m: float = 1.8
    fx_per_w: float = 36564 / 65536

    def for_frame(self, h: int, w: int, horizon_y: int | None) -> rw.Camera:
        hy = int(np.floor(h * self.horizon + 0.5)) if horizon_y is None else horizon_y
        return rw.Camera(fx=max(1.0, self.fx_per_w * w), horizon_y=hy, height_m=self.height_m,
                         hood_y=max(1, int(np.floor(h * self.hood + 0.5))))


def road_above_hood(road: RoadArea, first: int) -> RoadArea | None:
    """The road without the hood's rows (vt_pipeline_cfg.road_above_hood, auto_hood): it
    ends two rows above the hood's first row `first` (a known hood: round(h hood), half up,
    at least 1; a found one: its top row), as the shadow scan's Sobel at the last road row
    reads the row below; None when nothing is left."""
    if first - 2 < road.y_top:
        return None
    return replace(road, y_bottom=first - 2) if road.y_bottom > first - 2 else road


@dataclass
class FixedRoadRef:
    """The fixed trapezoid as fractions (see shadow.trapezoid_road)."""
    vp: tuple = (0.5, 0.45)
    bottom: tuple = (0.05, 0.95)
    lane_bottom: float = 0.45
    top_margin: int = 4

    def make(self, h: int, w: int) -> RoadArea:
        return trapezoid_road(h, w, vp=self.vp, bottom=self.bottom, lane_bottom=self.lane_bottom,
                              top_margin=self.top_margin)


@dataclass
class Capacities:
    """The compile-time capacities of the C build the oracle mirrors."""
    max_width: int = 1920
    max_height: int = 1080
    max_tracks: int = 16
    max_hypotheses: int = 32
    max_boxes: int = 32
    max_shadow_active: int = 64
    max_shadow_cand: int = 64
    max_verts: int = 24
    max_edge_points: int = 256      # VT_EDGE_MAX_POINTS
    max_edge_pixels: int = 65536    # VT_EDGE_MAX_PIXELS
    max_windows: int = 4096         # VT_FULLDET_MAX_WINDOWS
    max_cand: int = 1024            # VT_FULLDET_MAX_CAND
    max_flow_hyps: int = 16         # VT_FLOW_MAX_HYPS
    max_flow_seeds: int = 4         # VT_FLOW_MAX_SEEDS
    max_flow_blobs: int = 32        # VT_FLOW_MAX_BLOBS
    ho_hist: int = 16               # VT_PIPE_HO_HIST
    max_model_roi_pixels: int = 320 * 240  # VT_MODEL_MAX_ROI_PIXELS
    coord_lim: int = 7680           # 4 * max(VT_MAX_WIDTH, VT_MAX_HEIGHT): the tracker's box limit
    ttc_tracks: int = 4             # VT_TTC_TRACKS
    ttc_hist: int = 6               # VT_TTC_HIST


@dataclass
class PipelineRefConfig:
    lane: rlane.LaneConfig = field(default_factory=rlane.LaneConfig)
    shadow: ShadowConfig = field(default_factory=ShadowConfig)
    verify: VerifyConfig = field(default_factory=VerifyConfig)
    tracker: rtrk.TrackerCfg = field(default_factory=rtrk.TrackerCfg)
    fixed_road: FixedRoadRef = field(default_factory=FixedRoadRef)
    detect_every: int = 10
    road_policy: str = ROAD_AUTO
    lanes_every_frame: bool = False
    sources: tuple = (SRC_SHADOW,)
    track: bool = True
    fulldet: rfd.FullDetConfig = field(default_factory=rfd.FullDetConfig)  # its sources: ours
    road_camera: RoadCameraRef = field(default_factory=RoadCameraRef)
    flow: object = None   # the overtaking stage's settings (the fields of vt_flow_cfg), with "flow"
    model: object = None  # the vehicle model's settings (reference.vehicle_model's cfg), with "model"
    model_fits: int = 2   # most model fits per frame
    model_min_fitness: int = 256  # a fit below this is not used
    verify_min: int | None = None  # Q16: the whole-road boxes' second stage (box_score) and its threshold
    verify_flat: bool = True       # False: boxes flatter than 1:2 skip that stage (vt_pipeline_cfg.verify 2)
    verify_side: bool = True       # False: boxes the frame's side cuts (4 gap <= width + 4) skip it too (verify 3)
    verify_small: bool = True      # False: boxes narrower than 32 px skip it too (verify 4)
    ttc_points: object = None  # reference.ttc_scale.TtcScaleParams: the block-scale TTC after the
    #                            tracker (vt_pipeline_set_ttc_ws attached); None: not run
    handover: bool = True      # the reverse hand-over to the flow stage (with "flow")
    handover_frames: int = 8   # its look-back N, frames
    handover_dy_permille: int = 10   # bottom row down by >= this permille of h over N frames
    handover_edge_permille: int = 20  # outer side within this permille of w of the border
    ttc_fuse_permille: int = 300  # the fused TTC: weight of the distance/rate TTC (permille)
    fcw_fused: bool = False   # the warning decides on the fused TTC (vt_pipeline_cfg.fcw_fused)
    road_above_hood: bool = False  # the ego detector's road ends above road_camera's hood row
    auto_hood: bool = True    # else, above the hood found in the frame (reference.hood), if any
    hood: rhood.HoodConfig = field(default_factory=rhood.HoodConfig)
    cnn_hood_min_width_mm: int = 600  # the CNN's boxes on the hood are dropped (cnn_hood_drop)
    cnn_ego_iou_permille: int = 302  # an ego box is reported with its CNN box of IoU >= this / 1000
    cnn_track_top: bool = True  # the track an ego box goes to shows detect's top of it (_track_tops)


def cnn_hood_drop(rows: np.ndarray, cam, w: int, min_w_mm: int) -> np.ndarray:
    """vt_pipeline_cfg.cnn_hood_min_width_mm's rule: drop the boxes (rows l, t, r, b, ...,
    inclusive) whose bottom b is below the hood row (b > cam.hood_y), more than w // 64 px
    from both sides, and narrower than min_w_mm at that row's flat-road distance:
    (r - l + 1) height_mm < min_w_mm (b - horizon_y). The others keep their order."""
    rows = np.asarray(rows, np.int64)
    if min_w_mm <= 0 or len(rows) == 0:
        return rows
    m = w // 64
    l, r, b = rows[:, 0], rows[:, 2], rows[:, 3]
    drop = ((b > cam.hood_y) & (l > m) & (r < w - 1 - m)
            & ((r - l + 1) * int(round(cam.height_m * 1000)) < min_w_mm * (b - cam.horizon_y)))
    return rows[~drop]


@dataclass
class RefFrame:
    frame: int
    detection_frame: bool
    lanes_ran: bool
    lanes_ok: bool
    lanes: object                 # reference.lane.LaneFrame or None
    road_source: str              # "none" | "lanes" | "fixed"
    road: RoadArea | None
    hypotheses: np.ndarray        # (N, 3) row, x_start, x_end
    boxes: np.ndarray             # (M, 4) inclusive
    box_source: list              # one source name per box
    tracks: list                  # (id, state, (l, t, r, b), vx, vy, distance_m, ttc_s, warning)
    stats: dict                   # the shadow stage's statistics (detection frames), or the
                                  # whole-road detector's counters and horizon_y
    box_score: list = field(default_factory=list)  # one score per box (None: no confidence)
    track_source: list = field(default_factory=list)  # per track: the source that started it
    track_ttc_points: list = field(default_factory=list)  # per track: block-scale TTC, s (None: unknown)
    track_ttc_fused: list = field(default_factory=list)  # per track: the fused TTC, s (None: unknown)


# the fused TTC (c/pipeline.c's vt__ttc_fuse is camera.c's vt_ttc_fuse)
ttc_fuse = rcam.ttc_fuse


def _lane_fits(h: int, w: int, cfg: rlane.LaneConfig) -> bool:
    """The lane stage's size rule (vt_lane_detect): 16x16 at least, and a box
    downscale by an integer k <= 8 brings the frame within the working maximum (>= 8x8)."""
    if w < 16 or h < 16:
        return False
    k = rlane.choose_scale(w, h, cfg)
    W, H = w // k, h // k
    return W <= cfg.work_width_max and H <= cfg.work_height_max and W >= 8 and H >= 8


def _road_from_lane_frame(fr) -> RoadArea | None:
    r = fr.road
    if not r["valid"]:
        return None
    return RoadArea(int(r["y_top"]), int(r["y_bottom"]), np.asarray(r["x_left"]),
                    np.asarray(r["x_right"]), np.asarray(r["lane_width"]), True)


class Pipeline:
    """One run over a video: step(gray) per frame, in order."""

    def __init__(self, cfg: PipelineRefConfig | None = None, caps: Capacities | None = None,
                 camera=None, score=None, box_score=None, wide=None, refine=None, cnn=None):
        """camera: None, or (reference.camera.CameraParams, RangeParams) for frames of
        exactly the camera's img_w x img_h. score: None (the ego-lane detector), or the
        classifier of the whole-road detector, score(level_image, level, size, x, y) ->
        int (see reference.fulldet). box_score: the second stage's classifier of one box,
        box_score(gray, l, t, r, b) -> int (cfg.verify_min; see reference.fulldet.verify_boxes).
        wide: None, or (shared.WideConfig, wide_score(gray, l, t, r, b) -> int): the
        whole-road detector's wide pass after the second stage (reference.fulldet.wide;
        vt_pipeline_set_wide). refine: None, or (margin_permille, sources,
        offsets(gray, l, t, r, b) -> four Q16 ints on a context box): box regression of
        the whole-road detector's boxes after the second stage, before the wide pass
        (reference.fulldet.refine; vt_pipeline_set_refine). cnn: None, or the CNN detector in
        place of the windows (vt_pipeline_set_cnn), cnn(gray) -> (N, 6) [l, t, r, b, score,
        2] (e.g. reference.cnn.detect_frame with the score in Q16 logits): its boxes skip the
        second stage, box regression and the wide pass, and bring no shadow hypotheses."""
        self.cfg = cfg or PipelineRefConfig()
        self.cnn = cnn
        self.wide = wide
        self.refine = refine
        self.score = score
        self.box_score = box_score
        if self.cfg.verify_min is not None and box_score is None:
            raise ValueError("verify_min: the second stage needs box_score")
        self.horizon_y = None      # the last lanes' vanishing row (whole-road detector)
        self.caps = caps or Capacities()
        self.camera = camera
        self.ego_speed = None      # m/s or None (unknown)
        if camera is not None:
            self.pitch = rcam.PitchEstimator(camera[0])
            self.ranges = rcam.RangeTracker(camera[0], camera[1], self.caps.max_tracks)
        if int(self.cfg.detect_every) < 1:
            raise ValueError(f"detect_every must be >= 1, got {self.cfg.detect_every}")
        if self.cfg.road_policy not in (ROAD_AUTO, ROAD_LANES, ROAD_FIXED):
            raise ValueError(f"road_policy: expected 'auto', 'lanes' or 'fixed', got {self.cfg.road_policy!r}")
        if not set(self.cfg.sources) <= {SRC_SHADOW, SRC_CLASSIFIER, SRC_FLOW, SRC_MODEL, SRC_EGO}:
            raise ValueError(f"sources: only 'shadow', 'classifier', 'flow', 'model' and 'ego' are built, "
                             f"got {self.cfg.sources!r}")
        if SRC_MODEL in self.cfg.sources and self.cfg.model is None:
            raise ValueError("sources: 'model' needs cfg.model (the vehicle model's settings)")
        self.flow = None
        if SRC_FLOW in self.cfg.sources:
            if self.cfg.flow is None:
                raise ValueError("sources: 'flow' needs cfg.flow (the vt_flow_cfg fields)")
            self.flow = rflow.FlowOracle(self.cfg.flow, self.caps.max_flow_hyps, self.caps.max_flow_seeds,
                                         self.caps.max_flow_blobs)
        self.last_boxes = []       # the previous step's track boxes (the flow hand-over rule)
        self.ho = []               # live hand-overs, in order made: [track id, seed id, box, vx, vy,
        #                            side (1 left, 2 right), inner side's furthest-out column, stall]
        self.ho_hist = {}          # track id -> ([(bottom, l + r), ...] newest first, last box): the rule's memory
        if not 2 <= int(self.cfg.handover_frames) <= self.caps.ho_hist - 1:
            raise ValueError(f"handover_frames must be in 2..{self.caps.ho_hist - 1}, "
                             f"got {self.cfg.handover_frames}")
        self.last_tracks = []      # the previous step's tracks (the vehicle model's rule)
        for need in (SRC_CLASSIFIER, SRC_EGO):
            if need in self.cfg.sources and score is None and cnn is None:
                raise ValueError(f"sources: {need!r} needs a classifier (score)")
        self.lane = rlane.LaneDetector(self.cfg.lane, max_height=self.caps.max_height,
                                       max_verts=self.caps.max_verts)
        self.tracker = rtrk.Tracker(self.cfg.tracker, max_tracks=self.caps.max_tracks,
                                    max_edge_points=self.caps.max_edge_points,
                                    max_edge_pixels=self.caps.max_edge_pixels,
                                    coord_lim=self.caps.coord_lim)
        self.ttc = None            # the block-scale TTC (c/pipeline.c's vt_pipeline_set_ttc_ws)
        if self.cfg.ttc_points is not None:
            self.ttc = rttc.TtcScaleTracker(self.cfg.ttc_points, self.caps.ttc_tracks, self.caps.ttc_hist)
        self.frame = 0
        self.track_src = {}        # id -> the source of the box that started the track
        self.track_top = {}        # id -> its height in widths, Q8 (cnn_track_top)
        self._top_pairs = []       # this frame's (ego box, top of the CNN box it was reported with or None)

    def _track_sources(self, tracks, boxes, box_source) -> list:
        """The source that started each track (c/pipeline.c's vt__track_sources): kept
        for a known id, else the source of this frame's box with the largest
        intersection with the track's box (the first of equals), None if none meets it."""
        out = []
        for t in tracks:
            if t[0] in self.track_src:
                out.append(self.track_src[t[0]])
                continue
            best, src = 0, None
            l, tp, r, b = t[2]
            for bx, s in zip(boxes, box_source):
                iw = min(r, int(bx[2])) - max(l, int(bx[0])) + 1
                ih = min(b, int(bx[3])) - max(tp, int(bx[1])) + 1
                if iw > 0 and ih > 0 and iw * ih > best:
                    best, src = iw * ih, s
            out.append(src)
        self.track_src = {t[0]: s for t, s in zip(tracks, out)}
        return out

    def _track_tops(self, tracks) -> list:
        """cnn_track_top (c/pipeline.c's vt__track_tops): each of this frame's pairs (ego box e
        the tracker got, top row t of the CNN box it was reported with, None when it was reported
        as it is) goes to the track that overlaps e most (IoU >= the tracker's
        match_iou_permille, the first of equals; a later pair wins): t gives it the height
        q = max(1, round half up 256 (bottom - t + 1) / width) of its own box, None clears
        it; other tracks keep theirs by id. tracks (the tracker's, hand-overs excluded) come
        back with top = bottom - max(1, (w q + 128) // 256) + 1 where q > 0."""
        q = [self.track_top.get(t[0], 0) for t in tracks]
        lim = self.cfg.tracker.match_iou_permille
        for e, top in self._top_pairs:
            best, bv = None, None
            for i, t in enumerate(tracks):
                inter, union, _, _ = rw._iou_parts(list(e), list(t[2]))
                if inter * 1000 >= lim * union and (bv is None or Fraction(inter, union) > bv):
                    best, bv = i, Fraction(inter, union)
            if best is not None and top is None:
                q[best] = 0     # detect's latest box of it is the ego box itself
            elif best is not None:
                l, _tp, r, b = tracks[best][2]
                q[best] = max(1, ((b - top + 1) * 256 + (r - l + 1) // 2) // (r - l + 1))
        out = []
        for t, qi in zip(tracks, q):
            if qi > 0:
                l, _tp, r, b = t[2]
                t = (t[0], t[1], (l, b - max(1, ((r - l + 1) * qi + 128) // 256) + 1, r, b)) + tuple(t[3:])
            out.append(t)
        self.track_top = {t[0]: qi for t, qi in zip(tracks, q)}
        return out

    def step(self, gray: np.ndarray, road=None, detections=None) -> RefFrame:
        """One frame. road: a RoadArea (or one with valid False: no road) replacing the
        fixed trapezoid (the fallback of "auto", the road of "fixed"). detections: an
        (N, 4) box array making this a detection frame with those boxes (the lane and
        hypothesis stages do not run), as c/pipeline.c's step_road / step_dets."""
        c = self.cfg
        gray = np.asarray(gray, np.uint8)
        h, w = gray.shape
        if not (1 <= w <= self.caps.max_width and 1 <= h <= self.caps.max_height):
            raise ValueError(f"frame {w}x{h} outside 1x1..{self.caps.max_width}x{self.caps.max_height}")
        if self.camera is not None and (w, h) != (self.camera[0].img_w, self.camera[0].img_h):
            raise ValueError(f"frame {w}x{h}: the camera is for {self.camera[0].img_w}x{self.camera[0].img_h}")
        ext = detections is not None
        det_frame = ext or (bool(c.sources) and self.frame % c.detect_every == 0)
        run_lanes = not ext and c.road_policy != ROAD_FIXED and \
            ((det_frame and bool(c.sources)) or c.lanes_every_frame)
        given = road
        lanes, lanes_ok, road, source = None, False, None, "none"
        if run_lanes and _lane_fits(h, w, c.lane):
            lanes = self.lane.detect(gray)
            lanes_ok = True
        lane_road = _road_from_lane_frame(lanes) if lanes_ok else None
        whole = self.score is not None or self.cnn is not None
        if lanes_ok and lanes.vp_known:
            # the lane stage's own vanishing row in input rows, (vp + 1/2) k - 1/2 half up
            vp = (lanes.vp_y + 0.5) * lanes.scale - 0.5
            self.horizon_y = int(min(max(np.floor(vp + 0.5), -self.caps.max_height), self.caps.max_height))
        hyp = np.zeros((0, 3), np.int64)
        boxes = np.zeros((0, 4), np.int64)
        stats = {}
        self._top_pairs = []
        self._hood_row = -1   # _detect_ego's finding (vt_frame_out.hood_row)
        box_source = SRC_SHADOW
        scores = None
        if ext:
            boxes = np.asarray(detections, np.int64).reshape(-1, 4)
            box_source = "external"
        elif det_frame and whole:
            ego = self._detect_ego(gray, lane_road, given, h, w) if SRC_EGO in c.sources else None
            # with the ego detector, a given road is its road; the whole-road detector keeps the camera road
            road, source, hyp, boxes, box_source, scores, stats = self._detect_whole(
                gray, None if ego is not None else given, ego)
        elif det_frame:
            road, source, hyp, boxes, stats = self._detect_ego(gray, lane_road, given, h, w)
        elif lane_road is not None:
            road, source = lane_road, "lanes"
        # the tracker's boxes: the whole-road detector's as detected, before box regression
        tboxes = self._trk_whole if det_frame and whole and not ext else boxes
        trk_det, trk_boxes = det_frame, tboxes
        flow_ready, model_fits = False, 0
        if self.flow is not None or (SRC_MODEL in c.sources and c.track):
            box_source = [box_source] * len(boxes) if isinstance(box_source, str) else list(box_source)
            scores = [None] * len(boxes) if scores is None else list(scores)
            boxes = boxes[:self.caps.max_boxes] if ext else boxes
            tboxes = tboxes if det_frame and whole and not ext else boxes
            extra, extra_src, extra_sc = [], [], []
            fresh, n_model = False, 0
            if self.flow is not None:
                flow_ready, fboxes, fcells, fresh = self._flow(gray)
                extra += fboxes
                extra_src += [SRC_FLOW] * len(fboxes)
                extra_sc += fcells
            if SRC_MODEL in c.sources and c.track:
                mboxes, mfit, model_fits = self._model(gray)
                n_model = len(mboxes)
                extra += mboxes
                extra_src += [SRC_MODEL] * len(mboxes)
                extra_sc += mfit
            room = max(0, self.caps.max_boxes - len(boxes))
            boxes = np.concatenate([boxes, np.asarray(extra[:room], np.int64).reshape(-1, 4)])
            box_source += extra_src[:room]
            scores += extra_sc[:room]
            trk_boxes = np.concatenate([np.asarray(tboxes, np.int64).reshape(-1, 4),
                                        np.asarray(extra[:room], np.int64).reshape(-1, 4)])
            if not det_frame:
                trk_det = fresh or n_model > 0
                if not trk_det:
                    trk_boxes = np.zeros((0, 4), np.int64)
            if self.ho:
                # a handed-over vehicle keeps its one id: its boxes do not reach the tracker
                trk_boxes = np.asarray([b for b in trk_boxes if not self._ho_covers(b)],
                                       np.int64).reshape(-1, 4)
                self._top_pairs = [(e, t) for e, t in self._top_pairs if not self._ho_covers(e)]
        if c.track:
            # the tracker's scale check: the whole-road detector's horizon (C's rule)
            self.tracker.set_horizon(self._horizon(h, w))
        rows = self.tracker.step(gray, trk_det, trk_boxes) if c.track else []
        if c.track:
            self._ho_history(rows)
            if c.handover and self.flow is not None:
                rows = self._handover(rows, w, h, gray)
        pts = {}
        if self.ttc is not None and c.track:
            # after the tracker, before the camera stage (whose warning takes it), on every
            # live track in output order (c/pipeline.c: vt_ttc_step on p->tracks; tracks
            # past its capacity: unknown)
            pts = {o.id: o.ttc for o in self.ttc.step(gray, [(int(r[0]), tuple(int(v) for v in r[2]))
                                                             for r in rows])}
        geo = {}
        if self.camera is not None and c.track:
            geo = self._geometry(lanes if lanes_ok else None, rows, pts)
        tracks = [(i, s, tuple(int(v) for v in b), vx, vy) + geo.get(i, (None, None, None))
                  for i, s, b, vx, vy in rows]
        n_trk = len(tracks)
        # the live hand-overs after the tracker's tracks, while the output has room
        warn_ho = None if self.camera is None else False
        tracks += [(tid, HANDOVER, tuple(b), vx, vy, None, None, warn_ho)
                   for tid, _sid, b, vx, vy, *_rest in self.ho[:max(0, self.caps.max_tracks - n_trk)]]
        if isinstance(box_source, str):
            box_source = [box_source] * len(boxes)
        tsrc = self._track_sources(tracks, boxes[:self.caps.max_boxes], box_source[:self.caps.max_boxes])
        shown = (self._track_tops(tracks[:n_trk]) if c.track else []) + tracks[n_trk:]
        out = RefFrame(self.frame, det_frame, bool(run_lanes), lanes_ok, lanes, source, road,
                       np.asarray(hyp, np.int64).reshape(-1, 3), boxes, box_source,
                       shown, stats, [None] * len(boxes) if scores is None else scores, tsrc,
                       [pts.get(int(t[0])) for t in tracks])
        out.track_ttc_fused = [ttc_fuse(p, t[6], c.ttc_fuse_permille)
                               for p, t in zip(out.track_ttc_points, tracks)]
        out.flow_ready = flow_ready
        out.model_fits = model_fits
        out.hood_row = self._hood_row
        self.last_boxes = [t[2] for t in tracks[:n_trk]]
        self.last_tracks = tracks[:n_trk]
        self.frame = self.frame + 1 if self.frame < 2**31 - 1 else 0
        return out


    def _horizon(self, h: int, w: int) -> int:
        """c/pipeline.c's vt__horizon: the last lanes' vanishing row, else the road
        camera's row for this frame size."""
        return self.cfg.road_camera.for_frame(h, w, self.horizon_y).horizon_y

    def _model(self, gray):
        """The vehicle model for the tracks the previous step left coasting
        (c/pipeline.c's vt__model; the rules in vt_pipeline_set_model_ws): the refined
        boxes, their fitnesses and the fits run (used or not: vt_frame_out.model_fits)."""
        from types import SimpleNamespace  # noqa: PLC0415
        c = self.cfg
        h_img, w_img = gray.shape
        horizon = self._horizon(h_img, w_img)
        out, fit_ = [], []
        fits = 0
        for t in self.last_tracks:
            if fits >= c.model_fits:
                break
            if t[1] != rtrk.COASTING:
                continue
            l, tp, r, b = t[2]
            w, h = r - l + 1, b - tp + 1
            if b <= horizon or w < 1 or h < 1:
                continue
            roi = (min(max(l - w // 2, 0), w_img - 1), min(max(tp - h // 2, 0), h_img - 1),
                   min(max(r + w // 2, 0), w_img - 1), min(max(b + h // 2, 0), h_img - 1))
            if (roi[2] - roi[0] + 1) * (roi[3] - roi[1] + 1) > self.caps.max_model_roi_pixels:
                continue
            wpr = w * 65536 // (b - horizon)
            if wpr < 1 or wpr > 2**31 - 1:
                continue
            m = c.model
            cfg = SimpleNamespace(**dict(vars(m), horizon_row=horizon, width_per_row=wpr))
            pred = (l + w // 2, b, w, h, (m.wind_min + m.wind_max) // 2, (m.bump_min + m.bump_max) // 2,
                    m.roof_max // 2)
            sigma = (w // 8, h // 8, w // 8, h // 8, 5, 5, 5)
            search = SimpleNamespace(roi=roi, y_min=b - h // 4, y_max=b + h // 4, tracking=True,
                                     pred=pred, sigma=sigma)
            fits += 1
            try:
                res = rvm.fit(gray, cfg, search)
            except ValueError:          # no model fits (C: VT_E_SINGULAR / VT_E_SIZE)
                continue
            if res.fitness < c.model_min_fitness:
                continue
            box = tuple(int(v) for v in res.box)
            iw = min(box[2], r) - max(box[0], l) + 1
            ih = min(box[3], b) - max(box[1], tp) + 1
            inter = iw * ih if iw > 0 and ih > 0 else 0
            ua = (box[2] - box[0] + 1) * (box[3] - box[1] + 1)
            if inter * 1000 < c.tracker.match_iou_permille * (ua + w * h - inter):
                continue
            out.append(box)
            fit_.append(int(res.fitness))
        return out, fit_, fits

    def _flow(self, gray):
        """The overtaking stage on this frame (c/pipeline.c's vt__flow): (ready, boxes,
        their cells, whether one of them meets no track of the previous step). A frame
        of another size restarts the stage."""
        try:
            ready, hyps = self.flow.step(gray)
        except ValueError:
            self.flow.reset()
            ready, hyps = self.flow.step(gray)
        # the live hand-overs take their seeds' hypotheses; one no longer reported has ended
        # (c/pipeline.c's vt__ho_refresh), and so has one whose inner side did not get
        # further out than its furthest-out column for handover_frames frames in a row
        kept = []
        for tid, sid, _b, _vx, _vy, side, best, stall in self.ho:
            hp = next((q for q in hyps if q.kind == rflow.KIND_HANDOVER and q.id == sid), None)
            if hp is not None:
                inner = int(hp.box[2]) if side == 1 else int(hp.box[0])
                if (inner < best) if side == 1 else (inner > best):
                    best, stall = inner, 0
                else:
                    stall += 1
            if hp is None or stall >= self.cfg.handover_frames:
                try:
                    self.flow.unseed(sid)
                except ValueError:
                    pass
                continue
            kept.append([tid, sid, tuple(int(v) for v in hp.box), hp.flow[0], hp.flow[1], side, best, stall])
        self.ho = kept
        hyps = [q for q in hyps if q.kind != rflow.KIND_HANDOVER]   # reported as their tracks
        boxes = [tuple(int(v) for v in q.box) for q in hyps]

        def meets(a, b):
            return min(a[2], b[2]) >= max(a[0], b[0]) and min(a[3], b[3]) >= max(a[1], b[1])
        fresh = any(not any(meets(b, t) for t in self.last_boxes) and not self._ho_covers(b)
                    for b in boxes)
        return ready, boxes, [int(q.cells) for q in hyps], fresh

    def _ho_covers(self, b) -> bool:
        """A box that is a handed-over vehicle: IoU with a live hand-over's box >= the
        tracker's match_iou_permille (exact integers, as c/pipeline.c)."""
        thr = self.cfg.tracker.match_iou_permille
        for _tid, _sid, hb, *_rest in self.ho:
            iw = min(int(b[2]), hb[2]) - max(int(b[0]), hb[0]) + 1
            ih = min(int(b[3]), hb[3]) - max(int(b[1]), hb[1]) + 1
            inter = iw * ih if iw > 0 and ih > 0 else 0
            ua = (int(b[2]) - int(b[0]) + 1) * (int(b[3]) - int(b[1]) + 1)
            ub = (hb[2] - hb[0] + 1) * (hb[3] - hb[1] + 1)
            if inter * 1000 >= thr * (ua + ub - inter):
                return True
        return False

    def _ho_history(self, rows) -> None:
        """Per live track id, its bottom rows and l + r, newest first (at most ho_hist),
        and its last box; the history starts over when the box jumped since the last frame
        (width or bottom moved by more than a quarter of the last width or height)."""
        live = {}
        for i, _s, b, _vx, _vy in rows:
            hist, last = self.ho_hist.get(i, ([], None))
            b = tuple(int(v) for v in b)
            if last is not None:
                w0, h0 = last[2] - last[0] + 1, last[3] - last[1] + 1
                if 4 * abs((b[2] - b[0] + 1) - w0) > w0 or 4 * abs(b[3] - last[3]) > h0:
                    hist = []
            live[i] = ([(b[3], b[0] + b[2])] + hist[:self.caps.ho_hist - 1], b)
        self.ho_hist = live

    def _handover(self, rows, w: int, h: int, gray: np.ndarray) -> list:
        """The reverse hand-over (IVVI paper sec. 3, last paragraph; c/pipeline.c's
        vt__handover): a track that was confirmed (CONFIRMED or COASTING), whose bottom
        row came down by at least handover_dy_permille of the frame height over the last
        N = handover_frames frames and by half of that in each half of them, whose centre lies in a lateral strip of the flow
        stage's width and whose outer side is within handover_edge_permille of the width
        from the border, not moving inward, is seeded into the flow stage and leaves the
        tracker; it is reported with its id until the flow stage ends it."""
        c = self.cfg
        n = c.handover_frames
        sw = w * c.flow.strip_permille // 1000
        edge = c.handover_edge_permille * w
        out = []
        for row in rows:
            tid, st, b, vx, vy = row
            l, _t, r, _b = (int(v) for v in b)
            hist = self.ho_hist.get(tid, ([], None))[0]
            side = 0
            if len(hist) > n and st in (rtrk.CONFIRMED, rtrk.COASTING):
                half = n // 2
                dy1, dy2 = hist[0][0] - hist[half][0], hist[half][0] - hist[n][0]
                dc = hist[0][1] - hist[n][1]
                need = c.handover_dy_permille * h
                if dy1 * 2000 >= need and dy2 * 2000 >= need:
                    if l + r < 2 * sw and l * 1000 <= edge and dc <= 0:
                        side = 1
                    elif l + r >= 2 * (w - sw) and (w - 1 - r) * 1000 <= edge and dc >= 0:
                        side = 2
            # vt_flow_seed's own limits: the box meets the frame and stays within twice the capacities
            mw, mh = self.caps.max_width, self.caps.max_height
            if side and len(self.ho) < self.caps.max_flow_seeds and \
                    l >= -mw and int(b[1]) >= -mh and r < 2 * mw and int(b[3]) < 2 * mh:
                try:
                    sid = self.flow.seed(b, frame=gray)    # vt_flow_seed_frame
                except ValueError:       # no room, or a box outside the frame: the tracker keeps it
                    sid = None
                if sid is not None:
                    self.ho.append([tid, sid, tuple(int(v) for v in b), vx, vy, side, r if side == 1 else l, 0])
                    self.tracker.drop(tid)
                    self.ho_hist.pop(tid, None)
                    continue
            out.append(row)
        return out


    @staticmethod
    def _vanishing_row(lane_frame):
        left, right = lane_frame.lines[rlane.LEFT], lane_frame.lines[rlane.RIGHT]
        return rcam.vanishing_row(None if left is None else (left.xb, left.slope),
                                  None if right is None else (right.xb, right.slope),
                                  lane_frame.H, lane_frame.scale)

    def _detect_ego(self, gray: np.ndarray, lane_road, given, h: int, w: int):
        """The ego-lane detector on a detection frame (c/pipeline.c's vt__detect_ego):
        road, road source, hypotheses, boxes and the shadow stage's statistics."""
        c = self.cfg
        road, source, stats = None, "none", {}
        hyp, boxes = np.zeros((0, 3), np.int64), np.zeros((0, 4), np.int64)
        if lane_road is not None:
            road, source = lane_road, "lanes"
        elif c.road_policy != ROAD_LANES:
            if given is None:
                road, source = c.fixed_road.make(h, w), "fixed"
            elif getattr(given, "valid", True):
                road, source = given, "fixed"
        hood_row = -1   # vt_frame_out.hood_row: the hood found (auto_hood), else -1
        if c.road_above_hood:
            first = c.road_camera.for_frame(h, w, None).hood_y
        elif c.auto_hood:
            hood_row = rhood.find(gray, c.hood)["row"]
            first = hood_row
        else:
            first = -1
        if road is not None and first >= 0 and (source == "lanes" or given is None):
            road = road_above_hood(road, first)
            source = source if road is not None else "none"
        self._hood_row = hood_row
        if road is not None:
            res, boxes = rdetect.detect(gray, road, c.shadow, c.verify,
                                        max_active=self.caps.max_shadow_active,
                                        max_cand=self.caps.max_shadow_cand,
                                        max_hyp=self.caps.max_hypotheses,
                                        max_boxes=self.caps.max_boxes)
            hyp = res.hypotheses
            stats = {"median": res.median, "mad": res.mad, "dark_limit": res.dark_threshold,
                     "n_runs": res.n_runs, "n_dropped": res.n_dropped}
        return road, source, np.asarray(hyp, np.int64).reshape(-1, 3), np.asarray(boxes, np.int64).reshape(-1, 4), stats

    def _detect_whole(self, gray: np.ndarray, given, ego=None):
        """The whole-road detector on a detection frame (c/pipeline.c's
        vt__detect_whole): road, road source, hypotheses, boxes, their sources and
        scores, and the detector's counters. ego: _detect_ego's result (sources "ego"):
        its boxes first (through the second stage too when it is on), then the whole-road
        boxes NMS would not suppress against one of them (the detector's IoU /
        containment limits); an ego box scores the highest of itself and the boxes it
        suppresses (unscored and suppressing none: the detector's threshold). With a CNN and
        cfg.cnn_ego_iou_permille > 0, an ego box is reported with the CNN box it drops of the
        highest IoU with it, when that IoU is >= the limit (the tracker keeps the ego box). Its
        hypotheses before the detector's shadow hypotheses (to the capacity)."""
        c = self.cfg
        h, w = gray.shape
        cam = c.road_camera.for_frame(h, w, self.horizon_y)
        stats = {"horizon_y": cam.horizon_y}
        ego_hyp = np.zeros((0, 3), np.int64) if ego is None else ego[2]
        ego_boxes = np.zeros((0, 4), np.int64) if ego is None else ego[3]
        ego_scores = [None] * len(ego_boxes)
        if len(ego_boxes) and c.verify_min is not None:
            # the ego boxes through the second stage too: the survivors carry its score
            rows = np.concatenate([ego_boxes, np.zeros((len(ego_boxes), 2), np.int64)], 1)
            kept = rfd.verify_boxes(rows, lambda l, t, r, b: self.box_score(gray, l, t, r, b), c.verify_min)
            ego_boxes, ego_scores = kept[:, :4], [int(v) for v in kept[:, 4]]
        empty = (ego_hyp, ego_boxes, [SRC_EGO] * len(ego_boxes), list(ego_scores))
        # the tracker's boxes when no road is left for the windows: the ego boxes alone,
        # reported as they are (cnn_track_top's pairs)
        self._trk_whole = np.asarray(ego_boxes, np.int64).reshape(-1, 4)
        if c.cnn_track_top:
            self._top_pairs = [([int(v) for v in e], None) for e in ego_boxes]
        if given is not None:
            if not getattr(given, "valid", True):
                return (None, "none") + empty + (stats,)
            road, source = given, "fixed"
        else:
            ok, y0, y1, xl, xr, lw = rw.road_from_camera(cam, c.fulldet.win, w, h)
            if not ok:
                return (None, "none") + empty + (stats,)
            road, source = RoadArea(y0, y1, xl, xr, lw, True), "camera"
        from dataclasses import replace  # noqa: PLC0415
        fc = replace(c.fulldet, shadow_source=SRC_SHADOW in c.sources,
                     window_source=SRC_CLASSIFIER in c.sources)
        if self.cnn is not None:
            rows = cnn_hood_drop(np.asarray(self.cnn(gray), np.int64).reshape(-1, 6), cam, w,
                                 c.cnn_hood_min_width_mm)
            return self._merge_whole(gray, road, source, ego_hyp, ego_boxes, ego_scores, fc, rows, None, stats,
                                     cnn_iou=c.cnn_ego_iou_permille)
        arr, st = rfd.detect(gray, road, cam, fc, self.score, max_windows=self.caps.max_windows,
                             max_cand=self.caps.max_cand, max_boxes=self.caps.max_boxes,
                             max_hyp=self.caps.max_hypotheses,
                             max_shadow_active=self.caps.max_shadow_active,
                             max_shadow_cand=self.caps.max_shadow_cand,
                             rescore=(lambda l, t, r, b: self.box_score(gray, l, t, r, b))
                             if self.box_score is not None else None)
        if c.verify_min is not None:
            arr = np.asarray(arr, np.int64).reshape(-1, 6)
            keep = [rfd.verify_boxes(row[None], lambda l, t, r, b: self.box_score(gray, l, t, r, b), c.verify_min)
                    if not _verify_skips(row, w, c) else row[None]
                    for row in arr]   # one box at a time: a skipped box keeps its place and score
            arr = np.concatenate(keep) if keep else arr
        raw = np.asarray(arr, np.int64).reshape(-1, 6)[:, :4].copy()   # as detected: the tracker's boxes
        if self.refine is not None:
            margin, rsrc, offsets = self.refine
            arr = rfd.refine(arr, lambda l, t, r, b: offsets(gray, l, t, r, b), margin, rsrc, w, h)
        if self.wide is not None:
            wcfg, wscore = self.wide
            arr = rfd.wide(gray, road, cam, c.fulldet.win, wcfg, lambda l, t, r, b: wscore(gray, l, t, r, b), arr,
                           max_windows=self.caps.max_windows, max_cand=self.caps.max_cand,
                           max_boxes=self.caps.max_boxes)
        stats.update(st)
        hyp = ego_hyp
        if fc.shadow_source:
            more = rdetect.detect(gray, road, fc.shadow, fc.verify, max_active=self.caps.max_shadow_active,
                                  max_cand=self.caps.max_shadow_cand, max_hyp=self.caps.max_hypotheses,
                                  max_boxes=self.caps.max_boxes)[0].hypotheses
            hyp = np.concatenate([hyp, np.asarray(more, np.int64).reshape(-1, 3)])[:self.caps.max_hypotheses]
        return self._merge_whole(gray, road, source, hyp, ego_boxes, ego_scores, fc, arr, raw, stats)

    def _merge_whole(self, gray, road, source, hyp, ego_boxes, ego_scores, fc, arr, raw, stats, cnn_iou=0):
        """The whole-road boxes arr (rows [l, t, r, b, score, source]; raw: the boxes as
        detected, the tracker's input, None when arr's are) after the ego boxes: a box one of
        them suppresses is dropped and raises that ego box's score (c/pipeline.c). cnn_iou > 0
        (the CNN's boxes, cnn_ego_iou_permille): an ego box is reported with the box it dropped
        of the highest IoU with it (the first of equals) when that IoU is >= cnn_iou / 1000;
        the tracker's list keeps the ego box."""
        raw = np.asarray(arr, np.int64).reshape(-1, 6)[:, :4] if raw is None else raw
        boxes, src, scores = [list(b) for b in ego_boxes], [SRC_EGO] * len(ego_boxes), list(ego_scores)
        tboxes = [list(b) for b in ego_boxes]
        best = [None] * len(ego_boxes)   # per ego box: (IoU as a Fraction, its reported box)
        for i, row in enumerate(arr):
            # b: the box as detected (the tracker's input, tested against the ego boxes);
            # reported: the regressed one
            b = [int(v) for v in (raw[i] if i < len(raw) else row[:4])]
            hit = next((j for j, e in enumerate(ego_boxes)
                        if rw.suppresses(e, b, fc.nms_iou_permille, fc.nms_contain_permille)), None)
            if hit is not None:   # the ego box's score: the best the classifier gave the same vehicle
                scores[hit] = int(row[4]) if scores[hit] is None else max(scores[hit], int(row[4]))
                if cnn_iou:
                    inter, union, _, _ = rw._iou_parts([int(v) for v in ego_boxes[hit]], b)
                    v = Fraction(inter, union)
                    if best[hit] is None or v > best[hit][0]:
                        best[hit] = (v, [int(x) for x in row[:4]])
                continue
            if len(boxes) >= self.caps.max_boxes:
                continue
            boxes.append([int(v) for v in row[:4]])
            tboxes.append(b)
            src.append(SRC_CLASSIFIER if int(row[5]) == 2 else SRC_SHADOW)
            scores.append(int(row[4]))
        # an ego box the classifier did not see scores at the detector's threshold
        scores = [fc.window_score_min if v is None else v for v in scores]
        tops = [None] * len(ego_boxes)
        for j, bj in enumerate(best):   # reported with the CNN's box of the same car
            if bj is not None and bj[0] * 1000 >= cnn_iou:
                boxes[j] = bj[1]
                tops[j] = int(bj[1][1])
        if self.cfg.cnn_track_top:
            self._top_pairs = [([int(v) for v in e], t) for e, t in zip(ego_boxes, tops)]
        self._trk_whole = np.asarray(tboxes, np.int64).reshape(-1, 4)
        return road, source, np.asarray(hyp, np.int64).reshape(-1, 3), np.asarray(boxes, np.int64).reshape(-1, 4), \
            src, scores, stats

    def _geometry(self, lane_frame, rows, pts) -> dict:
        """The camera stage after the tracker (c/pipeline.c's vt__geometry): the pitch from
        the two ego lines' vanishing row when the lanes ran, then the range filters, whose
        warning takes the fused TTC where pts (id -> block-scale TTC, s) has one.
        id -> (filtered distance m, TTC s, warning) with None where C says VT_UNKNOWN."""
        vp = None
        if lane_frame is not None:
            left, right = lane_frame.lines[rlane.LEFT], lane_frame.lines[rlane.RIGHT]
            vp = rcam.vanishing_row(None if left is None else (left.xb, left.slope),
                                    None if right is None else (right.xb, right.slope),
                                    lane_frame.H, lane_frame.scale)
        self.pitch.update(vp)
        outs = self.ranges.step([(int(i), [int(v) for v in b]) for i, _s, b, _vx, _vy in rows],
                                self.pitch.tan_pitch, self.ego_speed,
                                ttc_points=pts if self.cfg.fcw_fused else None,
                                fuse_permille=self.cfg.ttc_fuse_permille)
        return {r.id: (r.dist_filt, r.ttc_dist, r.warning) for r in outs}


def work_size(w: int, h: int, max_w: int, max_h: int) -> tuple[int, int]:
    """The working size rule of c/pipeline.c (vt_pipeline_work_size) in plain
    arithmetic: unchanged if the frame fits, else the limiting side at its maximum
    and the other scaled by the same ratio, rounded down (>= 1)."""
    if w <= max_w and h <= max_h:
        return w, h
    if w * max_h >= h * max_w:
        return max_w, max(1, h * max_w // w)
    return max(1, w * max_h // h), max_h
