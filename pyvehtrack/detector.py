"""Vehicle detection in single frames (thesis sec. 2.4): lanes -> road area -> shadow
hypotheses -> vertical-edge verification, from the C core or from the float oracle.

    from pyvehtrack.detector import Detector
    det = Detector()                       # engine="c" (default) or "reference"
    res = det.detect(frame)                # uint8 gray (h, w) or BGR (h, w, 3)
    res.boxes                              # (N, 4) int [left, top, right, bottom]

Coordinates in a result are the INPUT frame's pixels, boxes inclusive. Frames larger
than the core's compile-time maximum (pyvehtrack.MAX_WIDTH x MAX_HEIGHT) are
downscaled to fit before detection (a warning says so once per Detector, and
`result.scale` gives the factor), never clipped; both engines see the same
downscaled frame.

The road area comes from the lane stage (pyvehtrack.lane.LaneDetector) when that
module is present and finds lanes; otherwise from a fixed trapezoid
(`fixed_road=`), and `result.road_source` says which was used.
"""
from __future__ import annotations

import os

from dataclasses import dataclass, field, fields

import numpy as np

from . import _check, _native
from ._native import ffi, lib
from .shared import WORK_WIDTH as _WORK_WIDTH
from .shared import RoadArea, ShadowConfig, VerifyConfig, road_polygon, trapezoid_road
from .frames import to_gray  # noqa: F401  (re-exported: pyvehtrack.detector.to_gray)

ENGINES = ("c", "reference")


@dataclass(frozen=True)
class DetectConfig:
    """Both stages' configurations (fields as vt_shadow_cfg / vt_verify_cfg)."""
    shadow: ShadowConfig = field(default_factory=ShadowConfig)
    verify: VerifyConfig = field(default_factory=VerifyConfig)


@dataclass(frozen=True)
class FixedRoad:
    """A fixed trapezoid road area (see shared.trapezoid_road): the
    vanishing point and the road's bottom span as fractions of the frame, the ego lane
    width at the bottom row as a fraction of the frame width."""
    vp: tuple = (0.5, 0.45)
    bottom: tuple = (0.05, 0.95)
    lane_bottom: float = 0.45

    def make(self, h: int, w: int) -> RoadArea:
        return trapezoid_road(h, w, vp=self.vp, bottom=self.bottom, lane_bottom=self.lane_bottom)


@dataclass
class Lane:
    side: str              # the lane stage's slot: "left-most", "left", "right", "right-most"
    points: np.ndarray     # (N, 2) int [x, y], input pixels


@dataclass
class DetectionResult:
    lanes: list                   # [Lane, ...]
    road_polygon: np.ndarray      # (N, 2) int [x, y] outline of the road area
    hypotheses: np.ndarray        # (N, 3) int [row, x_start, x_end], nearest first
    boxes: np.ndarray             # (N, 4) int [left, top, right, bottom], inclusive
    scale: float = 1.0            # input pixels per processed pixel
    road_source: str = "none"     # "lanes", "fixed", "camera", "given" or "none"
    stats: dict = field(default_factory=dict)  # median, mad, dark_limit, n_runs, n_dropped
    scores: np.ndarray | None = None   # (N,) float per box: the classifier's decision value
                                       # (full-road mode), None in the ego-lane mode
    sources: np.ndarray | None = None  # (N,) str per box: "shadow", "windows" or "ego" (full-road mode)


def _lane_module():
    try:
        from . import lane  # noqa: PLC0415  (written by the lane stage; optional)
    except ImportError:
        return None
    return lane if hasattr(lane, "LaneDetector") else None


def road_from_lanes(lr):
    """The road area of a lane-stage result as a RoadArea, or None when it has none.
    Takes pyvehtrack.lane.LaneResult (per-row arrays road_y_top, road_y_bottom, x_left,
    x_right, lane_width, road_valid) or any object whose `road` has RoadArea's fields."""
    if hasattr(lr, "road_valid"):
        if not lr.road_valid:
            return None
        return RoadArea(int(lr.road_y_top), int(lr.road_y_bottom), np.asarray(lr.x_left),
                        np.asarray(lr.x_right), np.asarray(lr.lane_width), True)
    road = getattr(lr, "road", None)
    if road is None or not hasattr(road, "y_top") or not getattr(road, "valid", True):
        return None
    return road


def fit_size(h: int, w: int, max_h: int, max_w: int) -> tuple[int, int]:
    """The largest (h', w') <= (max_h, max_w) with the frame's aspect ratio (each >= 1):
    the pipeline's one downscale rule (vt_pipeline_work_size)."""
    ww, wh = _native.pipeline_work_size(int(w), int(h), int(max_w), int(max_h))
    return wh, ww


def _cfg_to_c(cfg: DetectConfig):
    c = _native.detect_cfg_default()
    for f in fields(ShadowConfig):
        setattr(c.shadow, f.name, _check.integer(getattr(cfg.shadow, f.name), f"ShadowConfig.{f.name}"))
    for f in fields(VerifyConfig):
        setattr(c.verify, f.name, _check.integer(getattr(cfg.verify, f.name), f"VerifyConfig.{f.name}"))
    _native.check("vt_shadow_cfg_check", lib.vt_shadow_cfg_check(ffi.addressof(c, "shadow")),
                  f"shadow config {cfg.shadow}")
    _native.check("vt_verify_cfg_check", lib.vt_verify_cfg_check(ffi.addressof(c, "verify")),
                  f"verify config {cfg.verify}")
    return c


def c_default_config() -> DetectConfig:
    """The C core's VT_DETECT_CFG_DEFAULT as a DetectConfig."""
    c = _native.detect_cfg_default()
    return DetectConfig(
        ShadowConfig(**{f.name: int(getattr(c.shadow, f.name)) for f in fields(ShadowConfig)}),
        VerifyConfig(**{f.name: int(getattr(c.verify, f.name)) for f in fields(VerifyConfig)}))


class Detector:
    """Lanes -> road area -> shadow hypotheses -> verified boxes, frame by frame.

    engine: "c" (the fixed-point core) or "reference" (the float oracle).
    cfg: a DetectConfig (default: the thesis-based defaults shared by both engines).
    road: "auto" (lanes when the lane stage is available and finds them, else the
    fixed trapezoid), "lanes", "fixed", a RoadArea-like object for every frame, or a
    callable gray -> RoadArea-like (or None).
    fixed_road: the FixedRoad used for "fixed" and as the fallback of "auto".
    The lane stage tracks lines over frames, so use one Detector per video.

    Full-road mode (pyvehtrack.fullroad: shadow hypotheses and classifier windows over
    every lane, merged by NMS; boxes carry scores):
    model: path to a classifier .npz, or None for the core's built-in model;
    sources: None (with a model: full-road with fullroad.DEFAULT_SOURCES, the classified
    shadow hypotheses; without: the ego-lane mode above, the default), "ego" (the ego-lane mode), or a subset of
    ("shadow", "windows"), or "ego" with some of those (both detectors: the ego-lane
    detector's boxes first, source "ego", then the whole-road boxes NMS would not
    suppress against them; inside the pipeline only, so with no caller's lane_detector;
    the ego detector's road is the lanes', else fixed_road's trapezoid or the given road,
    and its settings are cfg's; the whole-road detector keeps the camera road); camera: a fullroad.Camera (horizon, hood, camera height;
    the horizon follows the lanes' vanishing row when the lane stage finds one);
    score_offset: added to the model's score threshold (float, the SVM's units);
    auto_hood: without a known hood row (camera), the ego-lane detector's road ends above
    the hood found in the frame (pyvehtrack.config.PipelineConfig.auto_hood), if any;
    work_width: frames wider than this are downscaled to it first (Pipeline's work_width,
    default pipeline.WORK_WIDTH = 1280; None: only past the core's maximum)."""

    def __init__(self, engine: str = "c", cfg: DetectConfig | None = None, *, road="auto",
                 fixed_road: FixedRoad | None = None, lane_detector=None, model=None,
                 sources=None, camera=None, score_offset: float = 0.0, auto_hood: bool = True,
                 work_width=_WORK_WIDTH):
        if engine not in ENGINES:
            raise ValueError(f"engine: expected one of {ENGINES}, got {engine!r}")
        # "ego" beside whole-road sources: the ego-lane detector's boxes ahead of the
        # whole-road detector's (the pipeline's VT_SRC_EGO)
        self.ego_too = isinstance(sources, (tuple, list)) and "ego" in sources and len(set(sources)) > 1
        if self.ego_too:
            sources = tuple(x for x in sources if x != "ego")
        self.full, ego_model = _full_road(engine, model, sources, camera, score_offset)
        self.ego_too = self.ego_too or ego_model   # or the model's own settings name "ego"
        if self.ego_too and lane_detector is not None:
            raise ValueError("sources: 'ego' (given, or in the model's settings) runs inside the pipeline with "
                             "the Detector's own lane stage: pass no lane_detector")
        self.engine = engine
        if not isinstance(auto_hood, (bool, np.bool_)):
            raise TypeError(f"auto_hood: expected a bool, got {type(auto_hood).__name__}")
        self.auto_hood = bool(auto_hood)   # the ego detector's road ends above a hood found in the frame
        self.cfg = cfg if cfg is not None else DetectConfig()
        if not isinstance(self.cfg, DetectConfig):
            raise TypeError(f"cfg: expected a DetectConfig, got {type(self.cfg).__name__}")
        self._cfg_c = _cfg_to_c(self.cfg)  # validates the config for both engines
        self.fixed_road = fixed_road if fixed_road is not None else FixedRoad()
        if not callable(getattr(self.fixed_road, "make", None)):
            raise TypeError(f"fixed_road: expected a FixedRoad, got {type(fixed_road).__name__}")
        if isinstance(road, str) and road not in ("auto", "lanes", "fixed"):
            raise ValueError(f"road: expected 'auto', 'lanes', 'fixed', a road area or a callable, got {road!r}")
        if not isinstance(road, str) and not callable(road) and not all(
                hasattr(road, a) for a in ("y_top", "y_bottom", "x_left", "x_right", "lane_width")):
            raise TypeError(f"road: expected 'auto', 'lanes', 'fixed', a RoadArea-like object (y_top, "
                            f"y_bottom, x_left, x_right, lane_width) or a callable, got {type(road).__name__}")
        if lane_detector is not None and not callable(getattr(lane_detector, "detect", None)):
            raise TypeError(f"lane_detector: expected an object with a detect(frame) method, "
                            f"got {type(lane_detector).__name__}")
        self.road = road
        self.lane_detector = lane_detector
        self._own_lanes = False
        if self.lane_detector is None and road in ("auto", "lanes"):
            mod = _lane_module()
            if mod is not None:
                self.lane_detector = mod.LaneDetector(engine=engine)
                self._own_lanes = True  # the pipeline runs the same lane stage itself
            elif road == "lanes":
                raise RuntimeError("road='lanes': the lane stage (pyvehtrack.lane) is not available")
        self.max_h, self.max_w = int(lib.VT_MAX_HEIGHT), int(lib.VT_MAX_WIDTH)
        from .pipeline import check_work_width  # noqa: PLC0415
        self.work_width = check_work_width(work_width)
        self._warned = False
        if engine == "c":
            self._state = ffi.new("vt_detect_state *")
            self._out = ffi.new("vt_detect_result *")
        # The view onto the pipeline: detection on every call, no tracker. With its own
        # lane stage the pipeline runs the lanes too; a given road, a road callable or
        # a caller's lane detector supply the road from here (policy "fixed").
        from .pipeline import Pipeline  # noqa: PLC0415
        self._lanes_inside = self.pipeline_overrides() is not None
        over = dict(self._stage_overrides())
        over["road"] = self.road if self._lanes_inside else "fixed"
        self.pipeline = Pipeline(engine, detect_every=1, track=False, work_width=self.work_width, **over)

    def reset(self) -> None:
        """Forget the lane tracker's lines (call between unrelated frames or videos)."""
        self.pipeline.reset()
        if self.lane_detector is not None and hasattr(self.lane_detector, "reset"):
            self.lane_detector.reset()

    def _stage_overrides(self) -> dict:
        from . import config  # noqa: PLC0415
        return {"shadow": config.ShadowConfig(**{f.name: getattr(self.cfg.shadow, f.name)
                                                 for f in fields(ShadowConfig)}),
                "verify": config.VerifyConfig(**{f.name: getattr(self.cfg.verify, f.name)
                                                 for f in fields(VerifyConfig)}),
                "auto_hood": self.auto_hood}

    def pipeline_overrides(self):
        """The pipeline configuration fields that make a Pipeline detect as this
        Detector does (stage configs and road policy), or None when the road comes
        from outside the pipeline (a given road, a callable, a caller's lane detector)."""
        if not isinstance(self.road, str) or (self.lane_detector is not None and
                                              not getattr(self, "_own_lanes", False)):
            return None
        over = self._stage_overrides()
        over["road"] = self.road
        over["work_width"] = self.work_width   # a Pipeline keyword, not a config field
        if self.full is not None:
            # full-road mode: the pipeline's classifier source with this Detector's model
            over.update(model=self.full.model if self.full.model is not None else "default",
                        road_camera=self.full.camera, fullroad=self.full.cfg,
                        sources=(("ego",) if self.ego_too else ()) +
                        tuple({"shadow": "shadow", "windows": "classifier"}[x] for x in self.full.sources))
        return over

    def fallback_road(self, h: int, w: int):
        """The road the pipeline uses where the lanes give none (road "auto") or always
        ("fixed"): this Detector's fixed trapezoid for an h x w processed frame; None in
        the full-road mode (the pipeline's camera road) unless the ego-lane detector runs
        beside it ("ego": the trapezoid is then its road)."""
        if self.full is not None and not self.ego_too:
            return None
        return self.fixed_road.make(h, w)

    # ------------------------------------------------------------------ road
    def _road_for(self, gray: np.ndarray):
        """(road area or None, lanes as [(side, points)], source) in processed pixels."""
        h, w = gray.shape
        if callable(self.road) and not isinstance(self.road, str):
            return self.road(gray), [], "given"
        if not isinstance(self.road, str):
            return self.road, [], "given"
        lanes, road = [], None
        if self.road in ("auto", "lanes") and self.lane_detector is not None:
            try:
                lr = self.lane_detector.detect(gray)
            except ValueError:          # e.g. a frame below the lane stage's minimum size
                lr = None
            if lr is not None:
                road = road_from_lanes(lr)
                for ln in getattr(lr, "lanes", None) or []:
                    side, pts = getattr(ln, "side", None), getattr(ln, "points", None)
                    if isinstance(side, str) and pts is not None and len(pts):
                        lanes.append((side, np.asarray(pts, np.float64).reshape(-1, 2)))
            if road is not None:
                return road, lanes, "lanes"
            if self.road == "lanes":
                return None, lanes, "none"
        return self.fixed_road.make(h, w), lanes, "fixed"

    # ------------------------------------------------------------------ detect
    def _prepare(self, frame):
        return self.pipeline.prepare(frame)  # the one downscale rule (and its warning)

    def detect_gray(self, gray: np.ndarray, road):
        """Hypotheses (N, 3) and boxes (M, 4) in the pixels of `gray` (which must fit the
        core) for a given road area (RoadArea-like or None), with the stage statistics."""
        if self.engine == "c":
            r = _native.road_area(road, gray.shape[0])
            hyp, box = _native.detect(self._state, self._cfg_c, gray, r, self._out)
            s = self._state.shadow
            stats = {"median": s.median, "mad": s.mad, "dark_limit": s.dark_limit,
                     "n_runs": s.n_runs, "n_dropped": s.n_dropped}
            return hyp.astype(np.int64), box.astype(np.int64), stats
        from .reference import detect as rdetect  # noqa: PLC0415  (the reference engine only)
        res, box = rdetect.detect(gray, road, self.cfg.shadow, self.cfg.verify,
                                  max_active=int(lib.VT_MAX_SHADOW_ACTIVE),
                                  max_cand=int(lib.VT_MAX_SHADOW_CAND),
                                  max_hyp=int(lib.VT_MAX_HYPOTHESES), max_boxes=int(lib.VT_MAX_BOXES))
        stats = {"median": res.median, "mad": res.mad, "dark_limit": res.dark_threshold,
                 "n_runs": res.n_runs, "n_dropped": res.n_dropped}
        return res.hypotheses, box, stats

    def _detect_full(self, gray):
        """Full-road mode: (hypotheses, boxes, scores, sources, road, lanes, road source, stats)."""
        lanes, horizon = [], None
        if self.lane_detector is not None and self.road in ("auto", "lanes"):
            try:
                lr = self.lane_detector.detect(gray)
            except ValueError:
                lr = None
            if lr is not None:
                if getattr(lr, "vanishing_row", None) is not None:
                    horizon = int(round(lr.vanishing_row))
                for ln in getattr(lr, "lanes", None) or []:
                    if isinstance(ln.side, str) and ln.points is not None and len(ln.points):
                        lanes.append((ln.side, np.asarray(ln.points, np.float64).reshape(-1, 2)))
        # a video keeps the last vanishing row while the lanes are lost (the camera's
        # pitch does not change between frames); a still image falls back to the camera's
        if horizon is None:
            horizon = getattr(self, "_last_horizon", None)
        else:
            self._last_horizon = horizon
        given = None
        if not isinstance(self.road, str):
            given = self.road(gray) if callable(self.road) else self.road
        out = self.full.detect_gray(gray, road=given, horizon_y=horizon)
        h, w = gray.shape
        if given is not None:
            road, source = given, "given"
        else:
            road = self.full.camera_road(h, w, horizon)
            source = "camera"
        names = np.array(["", "shadow", "windows"])[out[:, 5].astype(np.int64)]
        return (np.zeros((0, 3), np.int64), out[:, :4].astype(np.int64), out[:, 4].copy(), names, road,
                lanes, source, dict(self.full.last_stats, horizon_y=self.full.camera_for(h, w, horizon).horizon_y))

    def _whole_road_pipeline(self):
        """The pipeline running this Detector's full-road mode (vt_pipeline_step with the
        classifier), built from self.full (rebuilt if a caller replaced it), or None when a
        caller's lane detector supplies the horizon (then the stage runs beside it)."""
        if self.lane_detector is not None and not self._own_lanes:
            return None
        full = self.full
        if getattr(self, "_whole_for", None) is not full:
            from .pipeline import Pipeline  # noqa: PLC0415
            srcs = tuple({"shadow": "shadow", "windows": "classifier"}[x] for x in full.sources)
            model = full.model if full.model is not None else "default"
            # with "ego", the ego-lane detector runs with this Detector's stage settings
            # (its road: the lanes', else the road _detect_whole gives the step)
            ego = dict(self._stage_overrides(), sources=("ego",) + srcs) if self.ego_too else {"sources": srcs}
            self._whole = Pipeline(self.engine, model=model, road_camera=full.camera, fullroad=full.cfg,
                                   detect_every=1, track=False,
                                   road=self.road if isinstance(self.road, str) else "fixed", **ego)
            self._whole_for = full
        return self._whole

    def _detect_whole(self, gray):
        """Full-road mode through the pipeline: as _detect_full."""
        pipe = self._whole_road_pipeline()
        given = None
        if not isinstance(self.road, str):
            given = self.road(gray) if callable(self.road) else self.road
            if given is None:
                from .pipeline import NO_ROAD  # noqa: PLC0415
                given = NO_ROAD
        if self.ego_too and given is None and self.road != "lanes":
            # the ego detector's road where the lanes give none: this Detector's trapezoid
            h, w = gray.shape
            given = self.fixed_road.make(h, w)
            first = -1
            if self.full.camera.hood_known:
                # the pipeline cuts its own roads at the hood, never a caller's: cut this one
                hood = round(self.full.camera.hood_frac * 65536) / 65536   # as C holds it (Q16)
                first = max(1, int(np.floor(h * hood + 0.5)))
            elif pipe.cfg.auto_hood:   # as the pipeline cuts its own roads at a found hood
                if self.engine == "reference":
                    from dataclasses import asdict  # noqa: PLC0415
                    from .reference import hood as rhood  # noqa: PLC0415
                    first = rhood.find(gray, rhood.HoodConfig(**asdict(pipe.cfg.hood)))["row"]
                else:
                    first = _native.hood_find(gray, pipe._ccfg.hood)["row"]
            if first >= 0:
                from .reference.pipeline import road_above_hood  # noqa: PLC0415
                from .pipeline import NO_ROAD  # noqa: PLC0415
                given = road_above_hood(given, first) or NO_ROAD
        res = pipe.step_gray(gray, road=given)
        lanes = []
        for ln in (res.lanes.lanes if res.lanes is not None else []):
            if len(ln.points):
                lanes.append((ln.side, np.asarray(ln.points, np.float64).reshape(-1, 2)))
        source = {"fixed": "given"}.get(res.road_source, res.road_source)
        names = np.array(["windows" if b.source == "classifier" else b.source for b in res.boxes], dtype=object)
        names = names.astype(str) if len(names) else np.zeros(0, "<U7")
        scores = np.array([b.score for b in res.boxes], np.float64)
        self.full.last_stats = {k: v for k, v in res.stats.items() if k != "horizon_y"}
        return (res.hypotheses, res.box_array, scores, names, res.road, lanes, source, dict(res.stats))

    def detect(self, frame) -> DetectionResult:
        gray, (sx, sy) = self._prepare(frame)
        scores = names = None
        if self.full is not None and self._whole_road_pipeline() is not None:
            # full-road mode: the pipeline's classifier source (vt_pipeline_step)
            hyp, box, scores, names, poly, lanes, source, stats = self._detect_whole(gray)
        elif self.full is not None:
            # a caller's lane detector gives the horizon: the stage runs beside the pipeline
            hyp, box, scores, names, road, lanes, source, stats = self._detect_full(gray)
            poly = _road_polygon(road)
        else:
            if self._lanes_inside:
                h, w = gray.shape
                fallback = self.fixed_road.make(h, w) if self.road != "lanes" else None
                res = self.pipeline.step_gray(gray, road=fallback)
                lanes = []
                for ln in (res.lanes.lanes if res.lanes is not None else []):
                    if len(ln.points):
                        lanes.append((ln.side, np.asarray(ln.points, np.float64).reshape(-1, 2)))
                source = res.road_source
                poly = res.road
            else:
                from .pipeline import NO_ROAD  # noqa: PLC0415
                road, lanes, source = self._road_for(gray)
                res = self.pipeline.step_gray(gray, road=NO_ROAD if road is None else road)
                poly = res.road
            hyp = res.hypotheses
            box = res.box_array
            stats = dict(res.stats) if res.stats else {}

        def mx(x):
            return np.floor((np.asarray(x, np.float64) + 0.5) * sx).astype(np.int64)

        def my(y):
            return np.floor((np.asarray(y, np.float64) + 0.5) * sy).astype(np.int64)

        if sx != 1.0 or sy != 1.0:
            hyp = np.stack([my(hyp[:, 0]), mx(hyp[:, 1]), mx(hyp[:, 2])], 1).reshape(-1, 3)
            box = np.stack([mx(box[:, 0]), my(box[:, 1]), mx(box[:, 2]), my(box[:, 3])], 1).reshape(-1, 4)
        poly = np.stack([mx(poly[:, 0]), my(poly[:, 1])], 1).reshape(-1, 2) if len(poly) else poly
        out_lanes = [Lane(side, np.stack([mx(p[:, 0]), my(p[:, 1])], 1).reshape(-1, 2))
                     for side, p in lanes]
        return DetectionResult(out_lanes, poly, hyp, box, float(max(sx, sy)), source, stats, scores, names)


def _road_polygon(road) -> np.ndarray:
    """The outline of a road area (full-road mode), empty when there is none."""
    return road_polygon(road) if road is not None else np.zeros((0, 2), np.int64)


def _full_road(engine, model, sources, camera, score_offset):
    """(The FullRoadDetector of a Detector or None for the ego-lane mode, and whether the
    model's own settings add the ego-lane detector: "ego" among its sources)."""
    from . import fullroad  # noqa: PLC0415
    if isinstance(score_offset, bool) or not isinstance(score_offset, (int, float)) or \
            not np.isfinite(score_offset):
        raise TypeError(f"score_offset: expected a finite number, got {score_offset!r}")
    if sources == "ego" or (isinstance(sources, tuple) and sources == ("ego",)):
        if model is not None:
            raise ValueError("model: the ego-lane mode (sources='ego') uses no classifier")
        return None, False
    ego = False
    if sources is None:
        if model is None:
            # the ego-lane detector stays the default: on the KITTI lead frames the
            # full-road mode with the built-in model finds 30.8% of the lead cars at
            # IoU >= 0.6 against 97.4% (tools/eval_kitti_lead.py --sources shadow)
            return None, False
        if isinstance(model, (str, os.PathLike)):
            model = fullroad.load_model(model)
        # a model may name the sources it was validated with (its detector_json)
        sources = tuple((getattr(model, "settings", {}) or {}).get("sources", fullroad.DEFAULT_SOURCES))
        ego = "ego" in sources
        sources = tuple(x for x in sources if x != "ego")
        if ego and not sources:
            raise ValueError("model: its settings' sources name only 'ego' (the ego-lane mode uses no classifier)")
    cfg = fullroad.FullRoadConfig(score_offset=float(score_offset))
    return fullroad.FullRoadDetector(model, sources=sources, camera=camera, cfg=cfg, engine=engine), ego


__all__ = ["Detector", "DetectConfig", "DetectionResult", "FixedRoad", "Lane", "ShadowConfig",
           "VerifyConfig", "RoadArea", "c_default_config", "to_gray", "fit_size"]
