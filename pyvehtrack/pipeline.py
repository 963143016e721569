"""The whole system, one call per frame: lanes -> road area -> vehicle hypotheses ->
verification -> tracker [-> camera geometry], on the C core (vt_pipeline_step) or on
the float oracle (pyvehtrack.reference.pipeline), which compose the stages in the
same order.

    from pyvehtrack import Pipeline
    pipe = Pipeline()                       # engine="c"; Pipeline(detect_every=5, road="fixed")
    for frame in frames:                    # gray (h, w) or BGR (h, w, 3) uint8
        res = pipe.step(frame)
        for t in res.tracks:
            print(t.id, t.state, t.box, t.velocity, t.distance, t.ttc, t.warning)

Coordinates in a result are the INPUT frame's pixels, boxes inclusive. The one
downscale rule of the library lives here: a frame wider than work_width (default
WORK_WIDTH, 1280 px) or larger than the core's compile-time maximum
(pyvehtrack.MAX_WIDTH x MAX_HEIGHT) is resampled by area (the core's vt_resize_area
on the C engine, which firmware can call the same way; cv2 INTER_AREA on the oracle's) to the size
vt_pipeline_work_size gives for a maximum of min(work_width, MAX_WIDTH) x MAX_HEIGHT
(same aspect ratio, the limiting side at its maximum), and results are mapped back
(x_in = floor((x + 0.5) * sx) for box corners, velocities times sx, sy); a warning
says so once when the frame is past the core's maximum. The stages' pixel settings
(the ego-lane detector's shadow and edges, the tracker's ROI) were chosen on frames
1,242-1,280 px wide, the shipped networks trained on 1280 x 720: a 1920 x 1080
dashcam frame is processed at 1280 x 720. work_width=None keeps every frame the
core takes at its own size. Frames are never upscaled.

With a camera (pyvehtrack.camera.Camera, and the frame rate: Pipeline(camera=cam,
fps=10)) each track gets its filtered distance (m), the TTC from it and its rate (s)
and the forward-collision warning (c/camera.c: pitch from the lanes' vanishing row,
a [d, rate, accel] filter per track, NHTSA thresholds); without one they are None.
Box scores are None for the shadow source, which has no confidence.

With a classifier (Pipeline(model="model.npz"), an SvmModel / MlpModel, "default" for
the core's built-in model, or a callable score(level_image, level, size, x, y) -> int
Q16) the detection frames run the whole-road detector (c/fulldet.c through
vt_pipeline_step): shadow hypotheses over the camera road kept when the classifier
accepts them (sources "shadow") and sliding windows scored by it ("classifier"),
merged by NMS; every box carries its source and score (the classifier's decision
value, model units = Q16 / 65536). Sources "ego" adds the ego-lane detector (shadow +
vertical edges on the lanes' road, the thesis's lead-car detector): its boxes come first
(source "ego"; its score the highest of the whole-road boxes it suppresses, else the
detector's threshold) and a whole-road box NMS would suppress against one of them is
dropped. road_camera (pyvehtrack.fullroad.Camera) places its
road; fullroad (a fullroad.FullRoadConfig) tunes it. The C engine allocates the
detector's workspace (sizeof(vt_pipe_cls_ws)) and attaches it with
vt_pipeline_set_cls_ws.

With a CNN detector (Pipeline(model=cnn_model) with a pyvehtrack.cnn.CnnModel, or the path
of an .npz whose keys are cnn_*; cnn_cfg=pyvehtrack.cnn.CnnConfig(...) sets its levels,
threshold offset, cap and NMS) the detection frames run vt_cnn_detect_frame over the pyramid
levels in place of the windows (vt_pipeline_set_cnn, which places the cfg's row bands at
road_camera's horizon: pyvehtrack.cnn.at_horizon): its boxes are source "classifier",
score = heat x the model's heat_scale_q16 (a logit, as pyvehtrack.cnn.detect_frame's heat
times heat_scale_q16 / 65536); no second stage, re-ranking, box regression, wide pass or
shadow hypotheses on them (the network is its own verification); "ego" boxes beside them
as for any classifier. The C engine's CNN work buffer is sized for the first frame's size
and grown (re-attached) when a frame needs more; the reference engine runs the twin
(pyvehtrack.reference.cnn.detect_frame) in the same place.

sources "flow" (Pipeline(sources=("shadow", "flow"), flow={"sides": 3})): the overtaking
stage (c/flow.c) on every frame, its blobs handed to the tracker (source "flow"); and
the reverse case: a confirmed track the ego car overtakes, leaving by the side, is handed
to the flow stage and reported with the same id and state "handover" until the flow stage
ends it (flow={"handover": False} turns it off; "handover_frames",
"handover_dy_permille", "handover_edge_permille" tune the rule, vt_pipeline_set_flow_ws);
sources "model" (vehicle_model={"fits": 2, ...}): the GA vehicle model refits the
tracks whose ROI search failed (source "model"). Their state / workspace is allocated
and attached here (vt_pipeline_set_flow_ws, vt_pipeline_set_model_ws). Each track says
which source started it (Track.source).

ttc_points=True (or a dict of reference.ttc_scale.TtcScaleParams fields, e.g.
{"lag": 4}): the block-scale TTC (c/ttc_scale.c: the median scale change of SAD-matched
blocks inside each track's box over `lag` frames) runs after the tracker on every frame
(vt_pipeline_set_ttc_ws; its 113 KB state allocated here); Track.ttc_points is that TTC
in s, None when unknown (fewer than lag frames, too few pairs, not closing, beyond
ttc_max, or a track without one of the VT_TTC_TRACKS slots, which go to the nearest
tracks: TtcScaleParams.evict_margin_px). It needs no camera: frame_dt is 1/fps
when fps is given, else the dict's frame_dt, else 0.1 s.
Track.ttc_fused is the two TTCs in one: with a camera, the weighted mean of ttc_points and
the distance/rate TTC (Track.ttc), "fuse_permille" (default 300) on the latter; the known
one where only one is (vt_pipe_track.ttc_fused_q16).
"""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field

import cv2
import numpy as np

from . import _check, _native
from . import config as _config
from . import lane as _lane
from ._native import ffi, lib
from .config import PipelineConfig
from .frames import to_gray
from .shared import WORK_WIDTH, TrackBase

ENGINES = ("c", "reference")
STATES = {1: "tentative", 2: "confirmed", 3: "coasting", 4: "handover"}
HANDOVER_KEYS = ("handover", "handover_frames", "handover_dy_permille", "handover_edge_permille")
ROAD_SOURCES = {0: "none", 1: "lanes", 2: "fixed", 3: "camera"}


def resample(gray: np.ndarray, size, engine: str = "c") -> np.ndarray:
    """gray downscaled to size = (w, h) by area: the C core's vt_resize_area on the C engine
    (so a firmware build that resamples with it gets the same bytes), cv2.INTER_AREA, the
    same rule in float (at most 1 level apart), on the oracle's and for a frame past the
    core's maximum, which the core cannot take."""
    h, w = gray.shape
    if engine == "c" and w <= int(lib.VT_MAX_WIDTH) and h <= int(lib.VT_MAX_HEIGHT):
        from .image import resize_area  # noqa: PLC0415
        return resize_area(gray, size)
    return cv2.resize(gray, tuple(size), interpolation=cv2.INTER_AREA)


def check_work_width(work_width):
    """work_width as given (None or an int 16..65535; one past the core's MAX_WIDTH means
    that maximum, so the default suits a core built for smaller frames), else a clear error."""
    if work_width is None:
        return None
    if isinstance(work_width, bool) or not isinstance(work_width, (int, np.integer)):
        raise TypeError(f"work_width: expected an int or None, got {type(work_width).__name__}")
    if not 16 <= int(work_width) <= 65535:
        raise ValueError(f"work_width: expected 16..65535 px (or None: the core's maximum), got {work_width}")
    return int(work_width)
SOURCE_NAMES = {1: "shadow", 2: "classifier", 4: "flow", 8: "model", 16: "external", 32: "ego"}


class _NoRoad:
    """A road argument meaning "no road on this frame" (see Pipeline.step)."""
    valid = False

    def __repr__(self) -> str:
        return "NO_ROAD"


NO_ROAD = _NoRoad()


@dataclass(frozen=True)
class Box:
    box: tuple                 # (left, top, right, bottom), inclusive, input pixels
    source: str                # "shadow" | "classifier" | "flow" | "model" | "external" | "ego"
    score: float | None = None  # the source's confidence, None if it has none: the classifier's
                                # decision value (model units), the flow blob's cells, the
                                # vehicle model's fitness


@dataclass(frozen=True)
class Track(TrackBase):
    distance: float | None = None  # filtered distance, m (camera stage); None while unknown
    ttc: float | None = None       # time to collision from it and its rate, s; None if unknown
    warning: bool | None = None    # forward-collision warning; None without a camera
    source: str | None = None      # the source that started the track ("shadow", "classifier",
                                   # "external"); None if no box of its first frame met it
    ttc_points: float | None = None  # block-scale TTC, s (Pipeline(ttc_points=...)); None if unknown
    ttc_fused: float | None = None  # the two TTCs in one (vt_pipe_track.ttc_fused_q16): their
                                    # weighted mean when both are known, else the known one


@dataclass
class FrameResult:
    frame: int                     # index of the frame in this run (0 first)
    detection_frame: bool          # detection ran on this frame
    lanes: object                  # pyvehtrack.lane.LaneResult when the lane stage ran, else None
    road: np.ndarray               # (N, 2) int outline of the road area used; (0, 2) if none
    road_source: str               # "lanes", "fixed" or "none"
    hypotheses: np.ndarray         # (N, 3) int [row, x_start, x_end], nearest first
    boxes: list                    # [Box]: the detections handed to the tracker
    tracks: list                   # [Track]
    scale: float = 1.0             # input pixels per processed pixel (max of x, y)
    stats: dict = field(default_factory=dict)  # shadow stage statistics (detection frames)
    flow_ready: bool = False       # the overtaking stage compared two frames (sources "flow")
    model_fits: int = 0            # vehicle-model fits run on this frame (sources "model"), used
                                   # or not; the used ones are the boxes of source "model"
    hood_row: int = -1             # the hood's top row found on this detection frame
                                   # (PipelineConfig.auto_hood), -1 if none or not looked for

    @property
    def box_array(self) -> np.ndarray:
        """The boxes as an (N, 4) int64 array."""
        return np.array([b.box for b in self.boxes], np.int64).reshape(-1, 4)


def _polygon(x_left, x_right, y_top, y_bottom) -> np.ndarray:
    """The road outline (the lane module's one rule), int64."""
    return _lane._polygon(True, y_top, y_bottom, np.asarray(x_left), np.asarray(x_right)).astype(np.int64)


def _camera_and_cfg(road_camera, fullroad):
    """The whole-road detector's camera and configuration as given, or their defaults;
    TypeError naming the argument otherwise."""
    from . import fullroad as _fr  # noqa: PLC0415
    cam = road_camera if road_camera is not None else _fr.Camera()
    if not isinstance(cam, _fr.Camera):
        raise TypeError(f"road_camera: expected a fullroad.Camera, got {type(cam).__name__}")
    frc = fullroad if fullroad is not None else _fr.FullRoadConfig()
    if not isinstance(frc, _fr.FullRoadConfig):
        raise TypeError(f"fullroad: expected a fullroad.FullRoadConfig, got {type(frc).__name__}")
    return cam, frc


class Pipeline:
    """Frame-by-frame detection and tracking of one video.

    engine: "c" (the fixed-point core) or "reference" (the float oracle).
    camera: a pyvehtrack.camera.Camera for distance, TTC and warning (with fps).
    model: None (the ego-lane shadow detector), or the whole-road detector's classifier:
    a model path, an SvmModel / MlpModel, "default" (the core's built-in model) or a
    callable score(level_image, level, size, x, y) -> int (module doc); road_camera and
    fullroad configure that detector. cfg: a pyvehtrack.config.PipelineConfig (default: the core's);
    keyword arguments replace its top-level fields, e.g. Pipeline(detect_every=5,
    road="fixed", tracker=TrackerConfig(confirm_hits=2)). reference_quantized: the
    reference engine runs the Kalman model and keep_ncc rounded as C holds them
    (default) or as given. With the tracker's edge-curve measurement
    (TrackerConfig(measurement=config.MEASUREMENTS["edges"])) the C engine allocates
    its workspace (sizeof(vt_edge_ws)) and attaches it with vt_pipeline_set_edge_ws;
    otherwise there is none."""

    def __init__(self, engine: str = "c", camera=None, model=None,
                 cfg: PipelineConfig | None = None, *, fps: float | None = None,
                 ego_speed: float | None = None, reference_quantized: bool = True,
                 road_camera=None, fullroad=None, flow=None, vehicle_model=None, ttc_points=None,
                 cnn_cfg=None, work_width=WORK_WIDTH, **config):
        if engine not in ENGINES:
            raise ValueError(f"engine: expected one of {ENGINES}, got {engine!r}")
        if camera is not None:
            from .camera import Camera  # noqa: PLC0415
            if not isinstance(camera, Camera):
                raise TypeError(f"camera: expected a pyvehtrack.camera.Camera, got {type(camera).__name__}")
            if camera.height_m is None:
                raise ValueError("camera: 'height_m' (camera height above the road) is required")
            if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not np.isfinite(fps) or fps < 1:
                raise ValueError(f"fps: a camera needs the frame rate, a number >= 1; got {fps!r}")
        elif ego_speed is not None or (fps is not None and not ttc_points):
            raise ValueError("fps and ego_speed are for the camera stage: pass camera= too "
                             "(fps also sets the block-scale TTC's frame period, ttc_points=)")
        elif fps is not None and (isinstance(fps, bool) or not isinstance(fps, (int, float))
                                  or not np.isfinite(fps) or fps < 1):
            raise ValueError(f"fps: the frame rate, a number >= 1; got {fps!r}")
        self.camera, self.fps = camera, fps
        self._geom = None          # (input w, h) the camera stage was set up for
        self.ego_speed = None
        self.set_ego_speed(ego_speed)
        self.engine = engine
        self._ref_quantized = bool(reference_quantized)
        self.cfg = _config.from_kwargs(cfg, **config)
        self._ccfg = _config.to_c(self.cfg)  # checks the whole config once, for both engines
        self._setup_classifier(model, road_camera, fullroad, cnn_cfg)
        if cfg is None and "tracker" not in config:
            self._model_tracker()
        self._setup_flow(flow)
        self._setup_vehicle_model(vehicle_model)
        self._setup_ttc_points(ttc_points, fps)
        self.max_w, self.max_h = int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)
        self.work_width = check_work_width(work_width)
        self._warned = False
        self.reset()

    def _setup_classifier(self, model, road_camera, fullroad, cnn_cfg=None) -> None:
        """The whole-road detector's model, scorer and configuration (C and oracle)."""
        from . import cnn as _cnn  # noqa: PLC0415
        from . import fullroad as _fr  # noqa: PLC0415
        self.model, self._score_fn, self.whole_road = None, None, model is not None
        self._cmodel = self._cscorer = None
        self._cnn = None   # the CNN detector: (CnnModel, checked vt_cnn_cfg) or None
        self._cnn_work = None
        self._wide = None   # the wide pass: (MlpModel, WideConfig, C model, C cfg, box ws) or None
        self._refine = None   # box regression: (BoxRegressor, (C regressor, keepalive), box ws) or None
        self._rescore = None   # the ACF boxes' rescorer: (Rescorer, (C rescorer, keepalive)) or None
        self._acf = None   # the ACF first stage: (C model pointers, C cfg pointers, n, keepalive) or None
        is_cnn = isinstance(model, _cnn.CnnModel) or (isinstance(model, (str, os.PathLike)) and _cnn.is_cnn(model))
        if cnn_cfg is not None and not is_cnn:
            raise ValueError("cnn_cfg configures the CNN detector: pass a CNN model (model=CnnModel or a cnn_* .npz)")
        if is_cnn:
            self._setup_cnn(model, road_camera, fullroad, cnn_cfg)
            return
        if model is None:
            if road_camera is not None or fullroad is not None:
                raise ValueError("road_camera and fullroad configure the whole-road detector: pass model= too")
            for need in ("classifier", "ego"):
                if need in self.cfg.sources:
                    raise ValueError(f"sources: {need!r} needs a classifier: pass model=")
            return
        srcs = tuple({"shadow": "shadow", "classifier": "windows"}[s] for s in self.cfg.sources
                     if s in ("shadow", "classifier"))
        if isinstance(model, str) and model == "default":
            model = None
            if _fr.default_model() is None:
                raise ValueError("model: this build has no built-in model; pass a path")
        if callable(model) and not isinstance(model, (_fr.SvmModel, _fr.MlpModel)):
            # any classifier: the configuration as given (thresholds in its own scale)
            from dataclasses import replace  # noqa: PLC0415
            self._score_fn, _m = model, None
            cam, frc = _camera_and_cfg(road_camera, fullroad)
            det = frc.det if frc.det is not None else _fr.FullDetConfig()   # None: the library defaults
            det = replace(det, shadow_source="shadow" in srcs, window_source="windows" in srcs)
            if frc.verify_min is not None:   # the second stage (vt_fulldet_verify)
                self._ccfg.verify, self._ccfg.verify_min = (_fr.verify_mode(frc),
                                                            int(round(float(frc.verify_min) * 65536)))
        else:
            _m, _, cam, _frc, det = _fr.setup(model, srcs or ("shadow",), road_camera, fullroad)
            det = replace_sources(det, srcs)
            wide = _fr.wide_setup(_m, _frc)   # the model's wide pass (vt_pipeline_set_wide)
            if wide is not None:
                self._wide = (*wide, _fr._c_model(wide[0]), _fr.wide_c_cfg(wide[1]), _native.box_ws_new())
            if _fr._is_acf(_m):   # the ACF first stage in place of vt_fulldet (vt_pipeline_set_acf)
                if self.engine != "c":
                    raise ValueError("model: an ACF model runs on the C engine only (its float oracle is "
                                     "per stage: pyvehtrack.reference.acf)")
                # every model of the file (vt_pipeline_set_acf_n), the score offset on each threshold
                off = round(float(_frc.score_offset or 0) * 65536)
                models = [_m] + list(_m.more)
                cfgs = [m_.c_cfg(off) for m_ in models]   # kept: the arrays below only point at them
                self._acf = (ffi.new("vt_acf_model *[]", [m_.c_model()[0] for m_ in models]),
                             ffi.new("vt_acf_cfg *[]", cfgs), len(models), (models, cfgs))
                rs = getattr(_m, "rescore", None)
                if rs is not None and _frc.rescore is not False:   # vt_pipeline_set_rescore
                    self._rescore = (rs, rs.c())
            reg = _fr.refine_setup(_m, _frc)   # the model's box regressor (vt_pipeline_set_refine)
            if reg is not None:
                self._refine = (reg, reg.c(), _native.box_ws_new())
            if _frc.verify_min is not None:   # the model's second stage (vt_fulldet_verify)
                self._ccfg.verify, self._ccfg.verify_min = (_fr.verify_mode(_frc),
                                                            int(round(_frc.verify_min * 65536)))
        self.model, self.road_camera, self._det_cfg = _m, cam, det
        self._ccfg.fulldet = _fr._c_cfg(det)[0]
        self._ccfg.road_camera = _fr.road_camera_to_c(cam)[0]
        self._ccfg.road_above_hood = int(cam.hood_known)
        _native.pipeline_cfg_check(self._ccfg)
        self._cmodel = None
        if isinstance(_m, _fr.SvmModel):
            self._cmodel = _fr._c_model(_m)           # (vt_svm_model *, keepalive)
        self._cscorer = None
        if self._score_fn is not None:
            self._cscorer = _callback_scorer(self._score_fn)
        elif isinstance(_m, _fr.MlpModel):
            self._cscorer = _fr.c_scorer(_m)

    def _model_tracker(self) -> None:
        """The tracker settings the model file carries (tracker_json), over the default
        tracker configuration; only when the caller gave none (cfg= or tracker=)."""
        from dataclasses import replace  # noqa: PLC0415

        from . import fullroad as _fr  # noqa: PLC0415
        own = _fr.model_tracker_settings(self.model)
        if not own:
            return
        name = getattr(self.model, "path", "model")
        t = replace(self.cfg.tracker, **own)
        _config._tracker_to_c(self._ccfg.tracker, t)
        _native.check("vt_tracker_cfg_check", lib.vt_tracker_cfg_check(ffi.addressof(self._ccfg, "tracker")),
                      f"model {name}: tracker_json {own} is out of the tracker's ranges")
        self.cfg = replace(self.cfg, tracker=t)

    def _setup_cnn(self, model, road_camera, fullroad, cnn_cfg) -> None:
        """The CNN detector in place of the windows (vt_pipeline_set_cnn): the model, its
        checked vt_cnn_cfg, and the whole-road detector's camera road, NMS against the ego
        boxes and (for the ego boxes only) second stage from road_camera / fullroad."""
        from . import cnn as _cnn  # noqa: PLC0415
        from . import fullroad as _fr  # noqa: PLC0415
        m = model if isinstance(model, _cnn.CnnModel) else _cnn.CnnModel.load(model)
        if cnn_cfg is not None and not isinstance(cnn_cfg, _cnn.CnnConfig):
            raise TypeError(f"cnn_cfg: expected a pyvehtrack.cnn.CnnConfig or None, got {type(cnn_cfg).__name__}")
        ccfg = (cnn_cfg or m.cfg or _cnn.CnnConfig()).c()
        cam, frc = _camera_and_cfg(road_camera, fullroad)
        if frc.score_offset:   # a logit offset (the CLI's --offset) in heat steps, rounded
            ccfg.thr_offset += int(round(float(frc.score_offset) * 65536 / m.heat_scale_q16))
        det = frc.det if frc.det is not None else _fr.FullDetConfig()   # None: the library defaults
        srcs = tuple({"shadow": "shadow", "classifier": "windows"}[s] for s in self.cfg.sources
                     if s in ("shadow", "classifier"))
        det = replace_sources(det, srcs)
        if frc.verify_min is not None:   # the second stage, on the ego boxes only
            self._ccfg.verify, self._ccfg.verify_min = (_fr.verify_mode(frc),
                                                        int(round(float(frc.verify_min) * 65536)))
        self._cnn = (m, ccfg)
        self.model, self.road_camera, self._det_cfg = m, cam, det
        self._ccfg.fulldet = _fr._c_cfg(det)[0]
        self._ccfg.road_camera = _fr.road_camera_to_c(cam)[0]
        self._ccfg.road_above_hood = int(cam.hood_known)
        _native.pipeline_cfg_check(self._ccfg)
        # the cfg vt_pipeline_set_cnn keeps (its bands at the road camera's horizon): the work
        # buffer is sized for its rows
        self._cnn_placed = ffi.new("vt_cnn_cfg *")
        _native.check("vt_cnn_cfg_at_horizon",
                      lib.vt_cnn_cfg_at_horizon(ccfg, self._ccfg.road_camera.horizon_q16, self._cnn_placed))

    def _cnn_attach(self, w: int, h: int) -> None:
        """vt_pipeline_set_cnn with a work buffer of at least vt_cnn_frame_work_bytes for a w x h
        frame: allocated at the first size asked for, grown (and re-attached) when a frame needs
        more; one per Pipeline serves every run."""
        m, ccfg = self._cnn
        nb = ffi.new("size_t *")
        _native.check("vt_cnn_frame_work_bytes",
                      lib.vt_cnn_frame_work_bytes(m.c_model()[0], self._cnn_placed, w, h, nb),
                      f"frame {w}x{h}")
        grown = self._cnn_work is None or self._cnn_work.size < nb[0]
        if grown:
            self._cnn_work = np.zeros(int(nb[0]), np.uint8)
        if grown or getattr(self, "_cnn_p", None) is not self._p:   # a new buffer, or a new run's pipeline
            _native.check("vt_pipeline_set_cnn",
                          lib.vt_pipeline_set_cnn(self._p, m.c_model()[0], ccfg,
                                                  ffi.cast("uint8_t *", self._cnn_work.ctypes.data),
                                                  self._cnn_work.size))
            self._cnn_p = self._p

    def _setup_flow(self, flow) -> None:
        """The overtaking stage's settings (sources "flow"): a dict of vt_flow_cfg fields
        replacing the core's defaults (pyvehtrack.flow.make_cfg checks them)."""
        self._flow_st = None
        if "flow" not in self.cfg.sources:
            if flow is not None:
                raise ValueError("flow: the overtaking stage's settings need sources including 'flow'")
            return
        if flow is not None and not isinstance(flow, dict):
            raise TypeError(f"flow: expected a dict of vt_flow_cfg fields, got {type(flow).__name__}")
        from . import flow as _flow  # noqa: PLC0415
        flow = dict(flow or {})
        ho = {k: flow.pop(k) for k in HANDOVER_KEYS if k in flow}
        if "handover" in ho:
            if not isinstance(ho["handover"], (bool, np.bool_)):
                raise TypeError(f"flow['handover']: expected a bool, got {type(ho['handover']).__name__}")
            self._ccfg.handover = int(bool(ho["handover"]))
        limits = {"handover_frames": (2, int(lib.VT_PIPE_HO_HIST) - 1),
                  "handover_dy_permille": (0, 1000), "handover_edge_permille": (0, 500)}
        for k, (lo, hi) in limits.items():
            if k in ho:
                setattr(self._ccfg, k, _check.integer(ho[k], f"flow[{k!r}]", lo=lo, hi=hi))
        fc = _flow.make_cfg(**flow)
        self._ccfg.flow = fc[0]
        self._flow_fields = {f: int(getattr(fc, f)) for f in _flow.CFG_FIELDS}
        _native.pipeline_cfg_check(self._ccfg)

    def _setup_vehicle_model(self, vm) -> None:
        """The vehicle model's settings (sources "model"): a dict of vt_model_cfg fields
        replacing the core's defaults (pyvehtrack.vehicle_model.make_cfg checks them) and
        "fits", the most fits per frame (vt_pipeline_cfg.model_fits)."""
        self._model_ws = None
        if "model" not in self.cfg.sources:
            if vm is not None:
                raise ValueError("vehicle_model: the vehicle model's settings need sources including 'model'")
            return
        if vm is not None and not isinstance(vm, dict):
            raise TypeError(f"vehicle_model: expected a dict of vt_model_cfg fields, got {type(vm).__name__}")
        from . import vehicle_model as _vm  # noqa: PLC0415
        vm = dict(vm or {})
        fits = vm.pop("fits", int(self._ccfg.model_fits))
        fits = _check.integer(fits, "vehicle_model['fits']", lo=0, hi=int(lib.VT_MAX_TRACKS))
        min_fit = _check.integer(vm.pop("min_fitness", int(self._ccfg.model_min_fitness)),
                                 "vehicle_model['min_fitness']", lo=0)
        self._ccfg.model_min_fitness = min_fit
        mc = _vm.make_cfg(**vm)
        self._ccfg.model = mc[0]
        self._ccfg.model_fits = fits
        self._model_oracle_cfg = _vm.oracle_cfg(mc)
        _native.pipeline_cfg_check(self._ccfg)

    def _setup_ttc_points(self, tp, fps) -> None:
        """The block-scale TTC's settings (vt_pipeline_cfg.ttc): None/False (not run), True
        (the core's defaults) or a dict of reference.ttc_scale.TtcScaleParams fields; frame_dt
        = 1/fps when fps is given."""
        self._ttc_st = None
        self._ttc_params = None
        if tp is None or tp is False:
            return
        if tp is not True and not isinstance(tp, dict):
            raise TypeError(f"ttc_points: expected True or a dict of TtcScaleParams fields, "
                            f"got {type(tp).__name__}")
        from .camera import ScaleTtc  # noqa: PLC0415
        params = dict(tp) if isinstance(tp, dict) else {}
        if "fuse_permille" in params:   # the fused TTC's weight (vt_pipeline_cfg.ttc_fuse_permille)
            self._ccfg.ttc_fuse_permille = _check.integer(params.pop("fuse_permille"),
                                                          "ttc_points['fuse_permille']", lo=0, hi=1000)
        if "fcw_fused" in params:       # the warning on the fused TTC (vt_pipeline_cfg.fcw_fused)
            v = params.pop("fcw_fused")
            if not isinstance(v, bool):
                raise TypeError(f"ttc_points['fcw_fused'] must be True or False, got {v!r}")
            self._ccfg.fcw_fused = int(v)
        if fps is not None:
            if "frame_dt" in params:
                raise ValueError("ttc_points: give the frame period as fps= or as 'frame_dt', not both")
            rate = float(fps)
        else:
            dt = params.pop("frame_dt", 0.1)
            if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not np.isfinite(dt) \
                    or not 0 < dt <= 1:
                raise ValueError(f"ttc_points: 'frame_dt' must be a number in (0, 1] s, got {dt!r}")
            rate = 1.0 / float(dt)
        try:
            # ScaleTtc checks every field (names, int32, the core's ranges) and holds the
            # vt_ttc_cfg and the values C runs (for the oracle); its reference engine
            # allocates nothing big
            est = ScaleTtc(rate, engine="reference", **params)
        except (TypeError, ValueError) as e:
            raise type(e)(f"ttc_points: {e}") from None
        self._ccfg.ttc = est._c[0]
        self._ttc_params = est.params
        _native.pipeline_cfg_check(self._ccfg)

    def _ref_score(self):
        """The classifier for the reference engine: the callable, else the C classifier
        on the window alone (its own oracle lives with the classify stage)."""
        if self._score_fn is not None:
            return self._score_fn
        if getattr(self, "_ref_scorer", None) is None:
            from . import fullroad as _fr  # noqa: PLC0415
            if isinstance(self.model, _fr.MlpModel):
                sc, keep = _fr.c_scorer(self.model)
            else:
                m, keep = self._cmodel
                hog = ffi.new("vt_hog_scorer *")
                _native.check("vt_hog_scorer_init", lib.vt_hog_scorer_init(hog, m))
                sc = ffi.new("vt_window_scorer *")
                sc.level, sc.score, sc.ctx = ffi.NULL, ffi.addressof(lib, "vt_hog_scorer_score"), hog
                keep = (keep, hog)
            self._ref_scorer = (sc, keep)
        sc = self._ref_scorer[0]

        def score(img, level, s, x, y):
            win = ffi.new("vt_window *", [level, s, x, y])
            out = ffi.new("int32_t *")
            v = _native.view(np.ascontiguousarray(img), "level_img")
            _native.check("window scorer", sc.score(sc.ctx, v, win, out))
            return int(out[0])
        return score

    def set_ego_speed(self, speed: float | None) -> None:
        """The ego vehicle's speed (m/s, >= 0) for the next frames, or None (unknown):
        the camera stage's lead class and so its warning threshold."""
        if speed is not None and (isinstance(speed, bool) or not isinstance(speed, (int, float, np.number))
                                  or not np.isfinite(speed) or speed < 0):
            raise ValueError(f"ego_speed: expected a speed >= 0 m/s or None, got {speed!r}")
        self.ego_speed = None if speed is None else float(speed)
        if getattr(self, "_p", None) is not None:
            from .camera import q16  # noqa: PLC0415
            _native.check("vt_pipeline_set_ego_speed", lib.vt_pipeline_set_ego_speed(
                self._p, -65536 if speed is None else q16(speed, "ego_speed")))
        if getattr(self, "_ref", None) is not None:
            self._ref.ego_speed = self.ego_speed

    def _setup_camera(self, w0: int, h0: int, pw: int, ph: int) -> None:
        """The camera stage for input frames of w0 x h0 processed at pw x ph: the
        intrinsics mapped to the processed pixels, the range filter at 1/fps."""
        from .camera import params_to_c, range_to_c, range_from_c  # noqa: PLC0415
        from .reference import camera as rcam  # noqa: PLC0415  (parameter records only)
        import dataclasses  # noqa: PLC0415
        cp = self.camera.params(w0, h0)
        if (pw, ph) != (w0, h0):
            sx, sy = w0 / pw, h0 / ph
            cp = dataclasses.replace(cp, img_w=pw, img_h=ph, fx=cp.fx / sx, fy=cp.fy / sy,
                                     cx=(cp.cx + 0.5) / sx - 0.5, cy=(cp.cy + 0.5) / sy - 0.5)
        self._ccam = params_to_c(cp)
        crng = range_to_c(rcam.RangeParams(frame_dt=1.0 / float(self.fps)))
        self._ccfg.range = crng[0]
        from .camera import params_from_c  # noqa: PLC0415
        self._cam_params = params_from_c(self._ccam)   # the values C holds, for the oracle too
        self._range_params = range_from_c(crng)
        self._geom = (w0, h0)
        self.reset()

    def reset(self) -> None:
        """Start a new run: every stage empty, track ids from 1, frame 0 next."""
        if self.engine == "c":
            self._p = ffi.new("vt_pipeline *")
            cam = self._ccam if self._geom is not None else ffi.NULL
            model = self._cmodel[0] if self._cmodel is not None else ffi.NULL
            _native.check("vt_pipeline_init", lib.vt_pipeline_init(self._p, self._ccfg, cam, model),
                          "a stage configuration, policy or the camera is out of range")
            if self.whole_road:
                # the whole-road detector's scratch (sizeof(vt_pipe_cls_ws), ~1.2 MB at the
                # default capacities): one per Pipeline serves every run (init detaches it)
                if getattr(self, "_cls_ws", None) is None:
                    self._cls_ws = ffi.new("vt_pipe_cls_ws *")
                if self._cnn is not None:
                    # the CNN's work buffer: the last size seen (1 x 1 before any frame), grown
                    # by _step_c; set before the workspace, which then needs no scorer
                    self._cnn_attach(*getattr(self, "_cnn_wh", (1, 1)))
                if self._acf is not None:
                    # the ACF scratch (sizeof(vt_acf_ws), a few MB): one per Pipeline; set before
                    # the workspace, which then needs no scorer
                    if getattr(self, "_acf_ws", None) is None:
                        self._acf_ws = ffi.new("vt_acf_ws *")
                    _native.check("vt_pipeline_set_acf_n",
                                  lib.vt_pipeline_set_acf_n(self._p, self._acf[2], self._acf[0], self._acf[1],
                                                            self._acf_ws))
                sc = self._cscorer[0] if self._cscorer is not None else ffi.NULL
                _native.check("vt_pipeline_set_cls_ws", lib.vt_pipeline_set_cls_ws(self._p, self._cls_ws, sc))
                if self._wide is not None:
                    _native.check("vt_pipeline_set_wide",
                                  lib.vt_pipeline_set_wide(self._p, self._wide[2][0], self._wide[3]))
                if self._refine is not None:
                    _native.check("vt_pipeline_set_refine", lib.vt_pipeline_set_refine(self._p, self._refine[1][0]))
                if self._rescore is not None:
                    _native.check("vt_pipeline_set_rescore",
                                  lib.vt_pipeline_set_rescore(self._p, self._rescore[1][0]))

            if "flow" in self.cfg.sources:
                # the overtaking stage's state (sizeof(vt_flow_state), ~1.9 MB at the default
                # capacities): one per Pipeline, emptied by every attach
                if self._flow_st is None:
                    self._flow_st = ffi.new("vt_flow_state *")
                _native.check("vt_pipeline_set_flow_ws", lib.vt_pipeline_set_flow_ws(self._p, self._flow_st))
            if "model" in self.cfg.sources:
                # the vehicle model's scratch (sizeof(vt_model_ws), ~0.4 MB by default)
                if self._model_ws is None:
                    self._model_ws = ffi.new("vt_model_ws *")
                _native.check("vt_pipeline_set_model_ws", lib.vt_pipeline_set_model_ws(self._p, self._model_ws))
            if self._ttc_params is not None:
                # the block-scale TTC's state (sizeof(vt_ttc_state), 113 KB at the default
                # capacities): one per Pipeline, emptied by every attach
                if self._ttc_st is None:
                    self._ttc_st = ffi.new("vt_ttc_state *")
                _native.check("vt_pipeline_set_ttc_ws", lib.vt_pipeline_set_ttc_ws(self._p, self._ttc_st))
            # The edge-curve measurement's workspace (sizeof(vt_edge_ws), 320 KB at the
            # default VT_EDGE_MAX_PIXELS) exists only when that measurement runs; it is
            # scratch, so one per Pipeline serves every run (init detaches it).
            if self._ccfg.track and self._ccfg.tracker.measurement != lib.VT_MEAS_ROI_SEARCH:
                if getattr(self, "_edge_ws", None) is None:
                    self._edge_ws = _native.edge_ws_new()
                _native.pipeline_set_edge_ws(self._p, self._edge_ws)
            else:
                self._edge_ws = None
            self._out = ffi.new("vt_frame_out *")
        else:
            from .reference import pipeline as rpipe  # noqa: PLC0415  (the reference engine only)
            geom = (self._cam_params, self._range_params) if self._geom is not None else None
            rcfg = _config.to_reference(self.cfg, self._ref_quantized)
            score = None
            if "model" in self.cfg.sources:
                import dataclasses  # noqa: PLC0415
                rcfg = dataclasses.replace(rcfg, model=self._model_oracle_cfg,
                                           model_fits=int(self._ccfg.model_fits),
                                           model_min_fitness=int(self._ccfg.model_min_fitness))
            if "flow" in self.cfg.sources:
                import dataclasses  # noqa: PLC0415
                from types import SimpleNamespace  # noqa: PLC0415
                rcfg = dataclasses.replace(rcfg, flow=SimpleNamespace(**self._flow_fields),
                                           **{k: int(getattr(self._ccfg, k)) for k in HANDOVER_KEYS})
            box_score = None
            cnn = None
            if self.whole_road:
                rcfg = _whole_road_reference(rcfg, self._ccfg)
                if self._cnn is not None:
                    cnn = _cnn_reference(*self._cnn, int(lib.VT_MAX_BOXES),
                                         int(self._ccfg.road_camera.horizon_q16))
                else:
                    score = self._ref_score()
                if self._ccfg.verify:
                    import dataclasses  # noqa: PLC0415
                    rcfg = dataclasses.replace(rcfg, verify_min=int(self._ccfg.verify_min),
                                               verify_flat=int(self._ccfg.verify) == 1,
                                               verify_side=int(self._ccfg.verify) < 3,
                                               verify_small=int(self._ccfg.verify) < 4)
                    box_score = _native.classify_box_mlp_default
                if self._ccfg.fulldet.rerank_permille > 0:   # re-ranking uses the same model
                    box_score = _native.classify_box_mlp_default
            caps = _config.reference_capacities()
            if self._ttc_params is not None:
                import dataclasses  # noqa: PLC0415
                rcfg = dataclasses.replace(rcfg, ttc_points=self._ttc_params,
                                           ttc_fuse_permille=int(self._ccfg.ttc_fuse_permille),
                                           fcw_fused=bool(self._ccfg.fcw_fused))
                caps = dataclasses.replace(caps, ttc_tracks=int(lib.VT_TTC_TRACKS),
                                           ttc_hist=int(lib.VT_TTC_HIST))
            wide = None
            if self.whole_road and self._wide is not None:
                wm, wcfg, (cm, _keep), _c, wws = self._wide
                wide = (wcfg, lambda g, l, t, r, b: _native.classify_box_mlp(wws, cm, g, [l, t, r, b]))
            refine = None
            if self.whole_road and self._refine is not None:
                from .fullroad import refine_offsets_c  # noqa: PLC0415
                reg, (creg, _keep), rws = self._refine
                refine = (reg.margin_permille, reg.sources,
                          lambda g, l, t, r, b: refine_offsets_c(rws, creg, g, (l, t, r, b)))
            self._ref = rpipe.Pipeline(rcfg, caps, camera=geom, score=score,
                                       box_score=box_score, wide=wide, refine=refine, cnn=cnn)
        self.set_ego_speed(self.ego_speed)

    @property
    def frame_index(self) -> int:
        """Frames stepped so far."""
        return int(self._p.frame) if self.engine == "c" else int(self._ref.frame)

    # ------------------------------------------------------------------ the one downscale rule
    def work_size(self, w: int, h: int) -> tuple[int, int]:
        """The (w, h) a w x h frame is processed at (vt_pipeline_work_size, for a maximum
        width of min(work_width, MAX_WIDTH))."""
        mw = self.max_w if self.work_width is None else min(self.max_w, self.work_width)
        return _native.pipeline_work_size(int(w), int(h), mw, self.max_h)

    def prepare(self, frame) -> tuple[np.ndarray, tuple[float, float]]:
        """The gray frame the core processes and (sx, sy), input pixels per processed pixel."""
        gray = to_gray(frame)
        h, w = gray.shape
        pw, ph = self.work_size(w, h)
        if (pw, ph) != (w, h):
            if not self._warned and (w > self.max_w or h > self.max_h):
                warnings.warn(f"frame {w}x{h} is larger than the core's maximum "
                              f"{self.max_w}x{self.max_h}: downscaled to {pw}x{ph}", stacklevel=3)
                self._warned = True
            gray = resample(gray, (pw, ph), self.engine)
        return gray, (w / pw, h / ph)

    # ------------------------------------------------------------------ step
    def step(self, frame, *, road=None, detections=None) -> FrameResult:
        """One frame (gray or BGR uint8); the result in input pixels.

        road: a road area (an object with y_top, y_bottom, x_left, x_right, lane_width
        per row and valid, e.g. reference RoadArea) in the pixels of the PROCESSED frame
        (see prepare), replacing the fixed trapezoid: the road of road="fixed" and the
        fallback of road="auto"; NO_ROAD for none. detections: an (N, 4) array of
        [left, top, right, bottom] input-pixel boxes making this a detection frame with
        them (lanes and hypothesis stages do not run)."""
        gray, (sx, sy) = self.prepare(frame)
        self._camera_for(int(round(gray.shape[1] * sx)), int(round(gray.shape[0] * sy)), gray)
        if detections is not None:
            d = _native._boxes_i32(detections, "detections").astype(np.float64)
            if sx != 1.0 or sy != 1.0:
                d = np.floor(d / np.array([sx, sy, sx, sy]))
            detections = d.astype(np.int32).reshape(-1, 4)
        res = self._run(gray, road, detections)
        if sx != 1.0 or sy != 1.0:
            res = _rescale(res, sx, sy, int(round(gray.shape[0] * sy)), int(round(gray.shape[1] * sx)))
        return res

    def _camera_for(self, w0: int, h0: int, gray: np.ndarray) -> None:
        if self.camera is None:
            return
        if self._geom is None:
            if self.frame_index != 0:
                raise RuntimeError("the camera stage must be set up on the first frame")
            self._setup_camera(w0, h0, gray.shape[1], gray.shape[0])
        elif self._geom != (w0, h0):
            raise ValueError(f"frame {w0}x{h0}: the camera stage was set up for "
                             f"{self._geom[0]}x{self._geom[1]} frames (reset() or a new Pipeline "
                             f"for another size)")

    def step_gray(self, gray: np.ndarray, *, road=None, detections=None) -> FrameResult:
        """One frame already at the working size (see prepare); road, detections and the
        result in its pixels."""
        self._camera_for(gray.shape[1], gray.shape[0], gray)
        return self._run(gray, road, detections)

    def _run(self, gray: np.ndarray, road, detections) -> FrameResult:
        if self.engine == "c":
            return self._step_c(gray, road, detections)
        return self._step_ref(gray, road, detections)

    def _step_c(self, gray: np.ndarray, road, detections) -> FrameResult:
        o = self._out
        if self._cnn is not None and self.whole_road:
            self._cnn_wh = (int(gray.shape[1]), int(gray.shape[0]))
            self._cnn_attach(*self._cnn_wh)
        croad = None
        if road is not None and detections is None:
            croad = _native.road_area(None if road is NO_ROAD else road, gray.shape[0])
        _native.pipeline_step(self._p, gray, o, road=croad, dets=detections)
        h = gray.shape[0]
        lanes = None
        if o.lanes_ran and o.lane_status == lib.VT_OK:
            lanes = _lane.from_c(ffi.addressof(o, "lanes"), ffi.addressof(o, "road"), gray.shape)
        road = np.zeros((0, 2), np.int64)
        if o.road.valid:
            arrs = [np.frombuffer(ffi.buffer(getattr(o.road, nm)), np.int16)[:h].astype(np.int64)
                    for nm in ("x_left", "x_right")]
            road = _polygon(arrs[0], arrs[1], int(o.road.y_top), int(o.road.y_bottom))
        hyp = np.array([(o.hyp[i].row, o.hyp[i].x_start, o.hyp[i].x_end) for i in range(o.n_hyp)],
                       np.int64).reshape(-1, 3)
        boxes = [Box((int(b.box.left), int(b.box.top), int(b.box.right), int(b.box.bottom)),
                     SOURCE_NAMES.get(int(b.source), "unknown"),
                     _score(int(b.source), None if b.score == lib.VT_UNKNOWN else int(b.score)))
                 for b in (o.boxes[i] for i in range(o.n_boxes))]
        tracks = [Track(int(t.id), STATES[int(t.state)],
                        (int(t.box.left), int(t.box.top), int(t.box.right), int(t.box.bottom)),
                        (t.vx / 65536, t.vy / 65536),
                        None if t.distance_mm == lib.VT_UNKNOWN else t.distance_mm / 1000,
                        None if t.ttc_ms == lib.VT_UNKNOWN else t.ttc_ms / 1000,
                        None if t.warning == lib.VT_FCW_UNKNOWN else bool(t.warning & lib.VT_FCW_WARNING),
                        SOURCE_NAMES.get(int(t.source)),
                        None if t.ttc_points_q16 == lib.VT_UNKNOWN else t.ttc_points_q16 / 65536,
                        None if t.ttc_fused_q16 == lib.VT_UNKNOWN else t.ttc_fused_q16 / 65536)
                  for t in (o.tracks[i] for i in range(o.n_tracks))]
        stats = {}
        if o.detection_frame and self.whole_road and detections is None:
            r = self._cls_ws.res
            stats = {k: int(getattr(r, k)) for k in ("n_windows", "n_windows_dropped", "n_window_hits",
                                                      "n_shadow", "n_cand", "n_cand_dropped")}
            stats["horizon_y"] = self._horizon_c(gray.shape)
        elif o.detection_frame:
            s = self._p.detect.shadow
            stats = {"median": int(s.median), "mad": int(s.mad), "dark_limit": int(s.dark_limit),
                     "n_runs": int(s.n_runs), "n_dropped": int(s.n_dropped)}
        return FrameResult(int(o.frame), bool(o.detection_frame), lanes, road,
                           ROAD_SOURCES[int(o.road_source)], hyp, boxes, tracks, 1.0, stats,
                           bool(o.flow_ready), model_fits=int(o.model_fits), hood_row=int(o.hood_row))

    def _horizon_c(self, shape) -> int:
        """The horizon row the C whole-road detector used on this frame."""
        if self._p.horizon_known:
            return int(self._p.horizon_y)
        return int(np.floor((shape[0] * int(self._ccfg.road_camera.horizon_q16) + 32768) / 65536))

    def _step_ref(self, gray: np.ndarray, road, detections) -> FrameResult:
        r = self._ref.step(gray, road=road, detections=detections)
        lanes = _lane.from_reference(r.lanes, gray.shape) if r.lanes_ok else None
        road = np.zeros((0, 2), np.int64)
        if r.road is not None:
            road = _polygon(r.road.x_left, r.road.x_right, r.road.y_top, r.road.y_bottom)
        boxes = [Box(tuple(int(v) for v in b), s, _score(s, sc))
                 for b, s, sc in zip(r.boxes, r.box_source, r.box_score)]
        pts = r.track_ttc_points or [None] * len(r.tracks)
        fused = r.track_ttc_fused or [None] * len(r.tracks)
        tracks = [Track(int(i), STATES[int(s)], b, (float(vx), float(vy)), d, ttc, wn, src, tp, tf)
                  for (i, s, b, vx, vy, d, ttc, wn), src, tp, tf
                  in zip(r.tracks, r.track_source, pts, fused)]
        return FrameResult(r.frame, r.detection_frame, lanes, road, r.road_source,
                           np.asarray(r.hypotheses, np.int64).reshape(-1, 3), boxes, tracks, 1.0,
                           dict(r.stats), bool(getattr(r, "flow_ready", False)),
                           model_fits=int(getattr(r, "model_fits", 0)),
                           hood_row=int(getattr(r, "hood_row", -1)))


def _score(source, v):
    """A box's score in its source's unit: the classifier's decision value (Q16 -> float,
    for the whole-road detector's boxes and the ego boxes beside them), the flow blob's
    cells and the model's fitness as the integers they are; None where the source has none."""
    if v is None:
        return None
    if source in (1, 2, 32, "shadow", "classifier", "ego"):
        return v / 65536
    return v


def _cnn_reference(model, ccfg, max_boxes: int, horizon_q16: int):
    """The reference engine's CNN detector: the twin of vt_cnn_detect_frame as the pipeline
    runs it (c/pipeline.c's vt__detect_cnn, the bands placed at the road camera's horizon as
    vt_pipeline_set_cnn does): gray -> (N, 6) [l, t, r, b, heat x heat_scale_q16, 2 (windows)]
    for the first max_boxes boxes in NMS order."""
    from .cnn import CnnConfig  # noqa: PLC0415
    from .reference import cnn as rcnn  # noqa: PLC0415  (the reference engine only)
    cfg = rcnn.at_horizon(CnnConfig.from_c(ccfg), horizon_q16)

    def detect(gray):
        b, _n = rcnn.detect_frame(model, gray, cfg)
        b = np.asarray(b, np.int64).reshape(-1, 5)[:max_boxes]
        return np.concatenate([b[:, :4], b[:, 4:5] * int(model.heat_scale_q16),
                               np.full((len(b), 1), 2, np.int64)], axis=1)
    return detect


def replace_sources(det, srcs):
    """det with exactly the sources srcs ("shadow", "windows")."""
    import dataclasses  # noqa: PLC0415
    return dataclasses.replace(det, shadow_source="shadow" in srcs, window_source="windows" in srcs)


def _callback_scorer(fn):
    """A vt_window_scorer calling the Python function fn(level_image, level, size, x, y)."""
    @ffi.callback("vt_status(void *, const vt_image_u8 *, const vt_window *, int32_t *)", onerror=lambda *a: -1)
    def score(ctx, img, win, out):
        a = np.frombuffer(ffi.buffer(img.px, img.stride * img.h), np.uint8).reshape(img.h, img.stride)[:, :img.w]
        v = int(fn(a, int(win.level), int(win.size), int(win.x), int(win.y)))
        out[0] = max(-2**31, min(2**31 - 1, v))
        return 0
    sc = ffi.new("vt_window_scorer *")
    sc.level, sc.score, sc.ctx = ffi.NULL, score, ffi.NULL
    return sc, score


def _whole_road_reference(rcfg, c):
    """The oracle's whole-road configuration from the values C holds (vt_fulldet_cfg in
    its integer units, vt_road_camera in Q16)."""
    import dataclasses  # noqa: PLC0415
    from .reference import fulldet as rfd  # noqa: PLC0415  (the reference engine only)
    from .reference import pipeline as rpipe  # noqa: PLC0415
    from .reference import shadow as rshadow  # noqa: PLC0415
    from .reference import verify as rverify  # noqa: PLC0415
    from .reference import windows as rw  # noqa: PLC0415
    f, w = c.fulldet, c.fulldet.win
    win = rw.WindowConfig(veh_w_min_m=w.veh_w_min_mm / 1000, veh_w_max_m=w.veh_w_max_mm / 1000,
                          sizes=tuple(int(w.size[i]) for i in range(w.n_sizes)), step=w.step_q8 / 256,
                          levels=int(w.levels), lane_w_m=w.lane_w_mm / 1000, top_margin=int(w.top_margin))
    det = rfd.FullDetConfig(
        win=win,
        shadow=rshadow.ShadowConfig(**{k: int(getattr(f.det.shadow, k)) for k in
                                       rshadow.ShadowConfig.__dataclass_fields__}),
        verify=rverify.VerifyConfig(**{k: int(getattr(f.det.verify, k)) for k in
                                       rverify.VerifyConfig.__dataclass_fields__}),
        window_score_min=int(f.window_score_min), edge_check=bool(f.edge_check),
        shadow_classify=bool(f.shadow_classify), shadow_score_min=int(f.shadow_score_min),
        shadow_score=int(f.shadow_score), nms_iou_permille=int(f.nms_iou_permille),
        nms_contain_permille=int(f.nms_contain_permille), box_height=f.box_height_q8 / 256,
        merge_iou_permille=int(f.merge_iou_permille), rerank_permille=int(f.rerank_permille))
    rc = c.road_camera
    cam = rpipe.RoadCameraRef(rc.horizon_q16 / 65536, rc.hood_q16 / 65536, rc.height_mm / 1000,
                              rc.fx_per_w_q16 / 65536)
    return dataclasses.replace(rcfg, fulldet=det, road_camera=cam, road_above_hood=bool(c.road_above_hood))


def _rescale(res: FrameResult, sx: float, sy: float, h0: int, w0: int) -> FrameResult:
    """Map a result computed on the working frame back to the input frame."""
    def mx(x):
        return np.floor((np.asarray(x, np.float64) + 0.5) * sx).astype(np.int64)

    def my(y):
        return np.floor((np.asarray(y, np.float64) + 0.5) * sy).astype(np.int64)

    def box(b):
        return (int(mx(b[0])), int(my(b[1])), int(mx(b[2])), int(my(b[3])))

    hyp = res.hypotheses
    if len(hyp):
        hyp = np.stack([my(hyp[:, 0]), mx(hyp[:, 1]), mx(hyp[:, 2])], 1)
    road = res.road
    if len(road):
        road = np.stack([mx(road[:, 0]), my(road[:, 1])], 1)
    if res.lanes is not None:
        _lane._rescale(res.lanes, 1.0 / sx, w0, h0)
        res.lanes.input_scale = 1.0 / sx
    return FrameResult(res.frame, res.detection_frame, res.lanes, road, res.road_source, hyp,
                       [Box(box(b.box), b.source, b.score) for b in res.boxes],
                       [Track(t.id, t.state, box(t.box), (t.velocity[0] * sx, t.velocity[1] * sy),
                              t.distance, t.ttc, t.warning, t.source, t.ttc_points, t.ttc_fused)
                        for t in res.tracks],
                       float(max(sx, sy)), res.stats, res.flow_ready, model_fits=res.model_fits)


__all__ = ["Pipeline", "FrameResult", "Box", "Track", "PipelineConfig", "NO_ROAD"]
