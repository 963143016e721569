"""Multi-vehicle tracking from Python (thesis ch. 3), on the C core or the float
reference.

    trk = Tracker()                       # C engine, thesis defaults, detection every 10th frame
    for frame in frames:
        tracks = trk.step(frame)          # list[Track]: id, state, box, velocity (px/frame)

`step(frame, detections=...)` feeds your own detections instead (an (N, 4) array
of inclusive [left, top, right, bottom] boxes; float coordinates are rounded to the
nearest pixel, NaN/inf/non-numbers refused); then detection frames are the frames
where you pass them.

`Tracker(measurement="edges")` measures each track by matching its edge curves
(GIST paper sec. III.B) instead of the thesis's ROI search ("roi", the default).
For frames read from a recording, `Tracker(measurement=auto_measurement(path)[0])`
(pyvehtrack.frames) makes the command line's choice: "roi+edges" for a lossy-coded video or
JPEG frames, "roi" for lossless ones."""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from . import _check, _native
from .frames import to_gray
from .kalman import ModelConfig
from .shared import MEAS_EDGE_CURVES, MEAS_ROI_EDGES, MEAS_ROI_SEARCH, TrackBase, TrackerCfg

STATES = {1: "tentative", 2: "confirmed", 3: "coasting"}
MEASUREMENTS = {"roi": MEAS_ROI_SEARCH, "edges": MEAS_EDGE_CURVES, "roi+edges": MEAS_ROI_EDGES}


@dataclass(frozen=True)
class Track(TrackBase):
    source: str = "shadow"  # the hypothesis source that started it: "shadow" | "classifier" | "ego"
                            # (boxes given to step() count as "shadow": the CLI's detections)
    ttc_points: float | None = None  # block-scale TTC, s (Tracker(ttc_points=...)); None if unknown


def cfg_to_c(cfg: TrackerCfg):
    """The C struct for a TrackerCfg: Q16 for model values, Q14 for the NCC threshold
    (each rounded to nearest). TypeError / ValueError naming the field for a value that is
    not an integer (or a number in [-1, 1] for keep_ncc); the C core checks the ranges."""
    if not isinstance(cfg, TrackerCfg):
        raise TypeError(f"cfg: expected a TrackerCfg, got {type(cfg).__name__}")
    c = _native.ffi.new("vt_tracker_cfg *")
    for f in fields(cfg.search):
        setattr(c.search, f.name, _check.integer(getattr(cfg.search, f.name), f"cfg.search.{f.name}"))
    c.model = ModelConfig(**vars(cfg.model)).to_c()[0]  # Q16, checked, as the Kalman API does
    for f in fields(cfg):
        if f.name == "edge":
            for g in fields(cfg.edge):
                setattr(c.edge, g.name, _check.integer(getattr(cfg.edge, g.name), f"cfg.edge.{g.name}"))
        elif f.name not in ("search", "model", "keep_ncc"):
            setattr(c, f.name, _check.integer(getattr(cfg, f.name), f"cfg.{f.name}"))
    keep = _check.real(cfg.keep_ncc, "cfg.keep_ncc")
    if not -1.0 <= keep <= 1.0:
        raise ValueError(f"cfg.keep_ncc: {cfg.keep_ncc} must be in [-1, 1]")
    c.keep_ncc = int(round(keep * 16384))
    return c


def tracker_config(cfg: TrackerCfg):
    """The pyvehtrack.config.TrackerConfig of a reference TrackerCfg (same fields)."""
    from . import config  # noqa: PLC0415
    if not isinstance(cfg, TrackerCfg):
        raise TypeError(f"cfg: expected a TrackerCfg, got {type(cfg).__name__}")
    return config.TrackerConfig(
        search=config.SearchConfig(**{f.name: getattr(cfg.search, f.name) for f in fields(cfg.search)}),
        model=ModelConfig(**vars(cfg.model)), keep_ncc=cfg.keep_ncc,
        edge=config.EdgeConfig(**{f.name: getattr(cfg.edge, f.name) for f in fields(cfg.edge)}),
        **{f.name: getattr(cfg, f.name) for f in fields(cfg)
           if f.name not in ("search", "model", "keep_ncc", "edge")})


def _c_accepts(c) -> bool:
    """Whether the core accepts a tracker config (vt_tracker_cfg_check, the check
    vt_tracker_step makes before touching the tracker)."""
    return _native.lib.vt_tracker_cfg_check(c) == _native.lib.VT_OK


def check_cfg(cfg: TrackerCfg):
    """The C struct of a config the core accepts; ValueError naming the offending field(s)
    otherwise (found by trying each field alone on top of the C defaults)."""
    c = cfg_to_c(cfg)
    if _c_accepts(c):
        return c
    default = _native.tracker_cfg_default()
    bad = []
    for f in fields(cfg):
        if f.name in ("search", "model", "edge"):
            for g in fields(getattr(cfg, f.name)):
                t = _native.ffi.new("vt_tracker_cfg *", default[0])
                setattr(getattr(t, f.name), g.name, getattr(getattr(c, f.name), g.name))
                if not _c_accepts(t):
                    bad.append(f"cfg.{f.name}.{g.name}={getattr(getattr(cfg, f.name), g.name)!r}")
        else:
            t = _native.ffi.new("vt_tracker_cfg *", default[0])
            setattr(t, f.name, getattr(c, f.name))
            if not _c_accepts(t):
                bad.append(f"cfg.{f.name}={getattr(cfg, f.name)!r}")
    what = ", ".join(bad) if bad else "a combination of fields"
    raise ValueError(f"tracker config refused by the core: {what} out of range")


class Tracker:
    """Vehicle tracker. engine="c" runs the fixed-point core, "reference" the float oracle.

    detector: an object with .detect(gray) -> result with .boxes (N, 4), used every
    `detect_every` frames when step() is not given detections. measurement: "roi" (thesis
    ROI search), "edges" (edge curves matched by chamfer distance, GIST paper) or "roi+edges"
    (the ROI search, the edge curves where it fails on a confirmed track it measured before);
    when given it overrides cfg.measurement (the edge workspace, 320 KB at the default
    VT_EDGE_MAX_PIXELS, is allocated only then). Frames larger than the core's compile-time
    maximum are downscaled by the pipeline's one rule (boxes are scaled back to input
    pixels), never clipped.

    A view onto pyvehtrack.Pipeline: with a pyvehtrack Detector of the same engine
    (and its own lane stage) the whole frame, detection included, is one pipeline
    step; any other detector's boxes, and boxes passed to step(), enter the pipeline
    as the frame's detections. The scale check (cfg.scale_tol_permille) uses the
    pipeline's horizon: the lanes' vanishing row once its lane stage found one, else the
    whole-road detector's configured row (TuSimple's 0.458 of the height). With boxes
    from elsewhere on a camera whose horizon lies far from that row, pass
    TrackerCfg(scale_tol_permille=0): with a wrong horizon a vehicle's width over its
    height below it changes as it comes nearer, and the check may refuse it.

    ttc_points: True or a dict of reference.ttc_scale.TtcScaleParams fields: the pipeline's
    block-scale TTC (Pipeline(ttc_points=...)) at frame rate fps (default 10), each Track's
    ttc_points in s (None when unknown).

    flow: False, True or a dict of the pipeline's flow settings (Pipeline(flow=...)): the
    overtaking flow stage on every frame besides the detector, with its reverse hand-over (a
    car the ego car overtakes keeps its id with state "handover" while the flow stage
    follows it out of the frame).

    cnn_track_top: a track the ego-lane detector's box goes to, where the CNN detector reported
    that vehicle with its own box, is shown with the CNN box's top (PipelineConfig.cnn_track_top;
    only the box's top: the tracker, distance and TTC are unchanged). None (default): the
    pipeline's default, on; False: the tracker's box (README, "The top of a track's box")."""

    def __init__(self, engine: str = "c", cfg: TrackerCfg | None = None,
                 detect_every: int = 10, detector=None, measurement: str | None = None,
                 ttc_points=None, fps: float | None = None, flow=False, cnn_track_top: bool | None = None):
        from .pipeline import Pipeline  # noqa: PLC0415  (pipeline imports this module's users)
        _check.choice(engine, "engine", ("c", "reference"))
        if measurement is not None:
            _check.choice(measurement, "measurement", tuple(MEASUREMENTS))
        self.detect_every = _check.integer(detect_every, "detect_every", lo=1)
        if detector is not None and not callable(getattr(detector, "detect", None)):
            raise TypeError(f"detector: expected an object with a detect(frame) method, "
                            f"got {type(detector).__name__}")
        self.engine = engine
        self.cfg = cfg if cfg is not None else TrackerCfg()
        if cfg is None:   # the tracker settings the detector's model file carries (tracker_json)
            from .fullroad import model_tracker_settings  # noqa: PLC0415
            model = getattr(getattr(detector, "full", None), "model", None)
            own = model_tracker_settings(model)
            if own:
                self.cfg = replace(self.cfg, **own)
                try:
                    check_cfg(self.cfg)
                except ValueError as e:
                    raise ValueError(f"model {getattr(model, 'path', '')}: tracker_json: {e}") from None
        if measurement is not None and isinstance(self.cfg, TrackerCfg):  # else check_cfg names it
            self.cfg = replace(self.cfg, measurement=MEASUREMENTS[measurement])
        check_cfg(self.cfg)             # both engines: errors now, naming the field
        self.detector = detector
        self.frame_index = 0
        self.last_was_detection = False  # whether the last step() had detections
        self.last_result = None   # the last step()'s pipeline FrameResult (its detector boxes, road, ...)
        over = {}
        own = getattr(detector, "pipeline_overrides", None)
        self._own = callable(own) and getattr(detector, "engine", None) == engine and own() is not None
        if self._own:
            over = dict(own())
        else:
            over["sources"] = ()   # detections come from step() or the detector object
        if ttc_points:   # the pipeline's block-scale TTC (Pipeline(ttc_points=..., fps=...))
            over["ttc_points"] = ttc_points
            if fps is not None:
                over["fps"] = fps
        elif fps is not None:
            raise ValueError("fps: the frame rate is for the block-scale TTC: pass ttc_points= too")
        if flow is not False and flow is not None:
            if flow is not True and not isinstance(flow, dict):
                raise TypeError(f"flow: expected a bool or a dict of flow settings, got {type(flow).__name__}")
            over["sources"] = tuple(over.get("sources", ("shadow",))) + ("flow",)
            if isinstance(flow, dict):
                over["flow"] = dict(flow)
        if cnn_track_top is not None and not isinstance(cnn_track_top, (bool, np.bool_)):
            raise TypeError(f"cnn_track_top: expected a bool or None, got {type(cnn_track_top).__name__}")
        if cnn_track_top is not None:   # PipelineConfig.cnn_track_top: the CNN's top on the ego detector's tracks
            over["cnn_track_top"] = bool(cnn_track_top)
        self.pipeline = Pipeline(engine, tracker=tracker_config(self.cfg), detect_every=self.detect_every,
                                 reference_quantized=False, **over)

    @property
    def _tr(self):
        """The C engine's vt_tracker inside the pipeline (for inspection)."""
        return self.pipeline._p.tracker

    def step(self, frame: np.ndarray, detections=None) -> list[Track]:
        gray = to_gray(frame)
        dets = None
        road = None
        if detections is not None:
            dets = _native._boxes_i32(detections, "detections")
        elif self.detector is not None and self.frame_index % self.detect_every == 0:
            if self._own:
                h, w = self.pipeline.work_size(gray.shape[1], gray.shape[0])[::-1]
                road = self.detector.fallback_road(h, w)
            else:
                dets = np.asarray(self.detector.detect(frame).boxes).reshape(-1, 4)
        self.frame_index += 1
        res = self.pipeline.step(gray, road=road, detections=dets)
        self.last_was_detection = res.detection_frame
        self.last_result = res
        return [Track(t.id, t.state, t.box, t.velocity,
                      t.source if t.source in ("shadow", "classifier", "flow", "model", "ego") else "shadow",
                      t.ttc_points)
                for t in res.tracks]
