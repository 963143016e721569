"""Every configuration of the pipeline, as plain frozen dataclasses, in one place.

Field names, integer units and defaults are those of the C structs
(include/vehtrack/*.h): each class is built from its struct's cffi type and the
core's `*_cfg_default()`, so no default is copied into Python by hand. The two
exceptions are where a friendlier unit is natural and the conversion is exact or
stated: `TrackerConfig.model` (a kalman.ModelConfig in px and frames, rounded to
Q15.16 for C), `TrackerConfig.keep_ncc` (a correlation in [-1, 1], rounded to Q1.14)
and `FixedRoad` (fractions of the frame, which must be whole thousandths).

    from pyvehtrack.config import PipelineConfig, ShadowConfig
    cfg = PipelineConfig(detect_every=5, shadow=ShadowConfig(min_run=6))

`to_c(cfg)` gives the checked C struct; `to_reference(cfg)` the oracle's configs
(the only place this layer touches pyvehtrack.reference).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field, fields, make_dataclass

import numpy as np

from . import _check, _native
from ._native import ffi, lib
from .kalman import ModelConfig, Q16_ONE
from .shared import LANE_RENAMED, SEARCH_RENAMED, SHADOW_RENAMED, TRACKER_RENAMED, VERIFY_RENAMED, accept_renamed

def _int_config(name: str, ctype: str, doc: str, c=None):
    """A frozen dataclass with one int field per field of C struct `ctype`, in the
    struct's order, defaulting to the core's `<ctype>_default()` (or to struct c)."""
    c = _native._defaults(ctype) if c is None else c
    specs = [(f, int, field(default=int(getattr(c, f)))) for f, _ in ffi.typeof(ctype).fields]
    cls = make_dataclass(name, specs, frozen=True, namespace={"__doc__": doc, "_ctype": ctype})
    cls.__module__ = __name__
    return cls


LaneConfig = accept_renamed(_int_config("LaneConfig", "vt_lane_cfg",
                                        "vt_lane_cfg (vehtrack/lane.h): lane lines and the road area."),
                           LANE_RENAMED)
ShadowConfig = accept_renamed(_int_config("ShadowConfig", "vt_shadow_cfg",
                                          "vt_shadow_cfg (vehtrack/shadow.h): shadow hypotheses."),
                              SHADOW_RENAMED)
VerifyConfig = accept_renamed(_int_config("VerifyConfig", "vt_verify_cfg",
                                          "vt_verify_cfg (vehtrack/verify.h): vertical-edge verification."),
                              VERIFY_RENAMED)
SearchConfig = accept_renamed(_int_config("SearchConfig", "vt_track_search_cfg",
                                          "vt_track_search_cfg (vehtrack/track_search.h): ROI measurement.",
                                          _native.tracker_cfg_default().search), SEARCH_RENAMED)
HoodConfig = _int_config("HoodConfig", "vt_hood_cfg",
                         "vt_hood_cfg (vehtrack/hood.h): the hood finder (PipelineConfig.auto_hood).")
EdgeConfig = _int_config("EdgeConfig", "vt_edge_cfg",
                         "vt_edge_cfg (vehtrack/edge_track.h): the edge-curve measurement "
                         "(GIST paper sec. III.B), used when TrackerConfig.measurement is "
                         "MEASUREMENTS['edges'].",
                         _native.tracker_cfg_default().edge)
# TrackerConfig.measurement: the C values (VT_MEAS_*) by name.
MEASUREMENTS = {"roi": int(lib.VT_MEAS_ROI_SEARCH), "edges": int(lib.VT_MEAS_EDGE_CURVES),
                "roi+edges": int(lib.VT_MEAS_ROI_EDGES)}


def _tracker_defaults() -> dict:
    c = _native.tracker_cfg_default()
    out = {}
    for f, _ in ffi.typeof("vt_tracker_cfg").fields:
        if f == "search":
            out[f] = SearchConfig(**{g.name: int(getattr(c.search, g.name)) for g in fields(SearchConfig)})
        elif f == "edge":
            out[f] = EdgeConfig(**{g.name: int(getattr(c.edge, g.name)) for g in fields(EdgeConfig)})
        elif f == "model":
            out[f] = ModelConfig.from_c(c.model)
        elif f == "keep_ncc":
            out[f] = int(c.keep_ncc) / 16384
        else:
            out[f] = int(getattr(c, f))
    return out


_TD = _tracker_defaults()
TrackerConfig = make_dataclass(
    "TrackerConfig",
    [(k, type(v), field(default=v)) for k, v in _TD.items()],
    frozen=True,
    namespace={"__doc__": "vt_tracker_cfg (vehtrack/tracker.h). model: a kalman.ModelConfig "
                          "(px, frames); keep_ncc: a correlation in [-1, 1]; edge: an EdgeConfig; "
                          "measurement: MEASUREMENTS['roi'] (ROI search, default) or "
                          "MEASUREMENTS['edges'] (edge curves); the rest C's ints."})
TrackerConfig.__module__ = __name__
accept_renamed(TrackerConfig, TRACKER_RENAMED)
del _TD


def _fixed_road_defaults():
    c = _native.pipeline_cfg_default().fixed_road
    return (c.vp_x_permille / 1000, c.vp_y_permille / 1000), \
        (c.bottom_left_permille / 1000, c.bottom_right_permille / 1000), \
        c.lane_bottom_permille / 1000, int(c.top_margin)


_FR = _fixed_road_defaults()


@dataclass(frozen=True)
class FixedRoad:
    """The road area used when no lane lines are found (vt_fixed_road): a trapezoid
    from the bottom row (columns bottom[0]..bottom[1], fractions of w-1) toward the
    vanishing point vp = (x, y) (fractions of w-1, h-1), cut top_margin rows below it;
    the ego lane width grows to lane_bottom * w at the bottom row. Fractions must be
    whole thousandths (C holds them in permille)."""
    vp: tuple = _FR[0]
    bottom: tuple = _FR[1]
    lane_bottom: float = _FR[2]
    top_margin: int = _FR[3]

    def make(self, h: int, w: int):
        """The C core's road area (a vt_road_area *) of an h x w frame."""
        return _native.fixed_road_area(_fixed_road_to_c(self), int(w), int(h))


del _FR

ROAD_POLICIES = {"auto": "VT_ROAD_AUTO", "lanes": "VT_ROAD_LANES", "fixed": "VT_ROAD_FIXED"}
SOURCES = {"shadow": "VT_SRC_SHADOW", "classifier": "VT_SRC_CLASSIFIER", "flow": "VT_SRC_FLOW",
           "model": "VT_SRC_MODEL", "ego": "VT_SRC_EGO"}


def _policy_defaults():
    c = _native.pipeline_cfg_default()
    road = next(k for k, v in ROAD_POLICIES.items() if getattr(lib, v) == c.road_policy)
    src = tuple(k for k, v in SOURCES.items() if c.sources & getattr(lib, v))
    return (int(c.detect_every), road, bool(c.lanes_every_frame), src, bool(c.track), bool(c.auto_hood),
            int(c.cnn_hood_min_width_mm), int(c.cnn_ego_iou_permille), bool(c.cnn_track_top))


_PD = _policy_defaults()


@dataclass(frozen=True)
class PipelineConfig:
    """Everything vt_pipeline_step runs with: each stage's configuration and the
    policies. detect_every: detection on frames 0, N, 2N, ...; road: "auto" (lanes,
    else the fixed trapezoid), "lanes" or "fixed"; lanes_every_frame: run the lane
    stage on every frame (else on detection frames only); sources: hypothesis
    sources, a subset of "shadow", "classifier", "flow", "model" and "ego" ("classifier"
    and "ego" need a classifier, "flow" and "model" their settings: pyvehtrack.Pipeline;
    () for none: detections only from the caller); track: run the tracker (False: detection only);
    auto_hood: on detection frames look for the ego car's hood (hood: its settings) and end the
    ego-lane detector's road above it, unless a camera file gives the hood row;
    cnn_hood_min_width_mm: the CNN detector's boxes below the hood row narrower than this many mm
    at their row's flat-road distance, away from the frame's sides, are dropped (0: off;
    vt_pipeline_cfg.cnn_hood_min_width_mm); cnn_ego_iou_permille (0..1000): with "ego" and a CNN
    detector, an ego-lane box is reported with the CNN box it replaced that overlaps it most, when
    that IoU is >= this / 1000; the tracker keeps the ego box (0: off;
    vt_pipeline_cfg.cnn_ego_iou_permille); cnn_track_top: the track an ego box goes to is reported
    with the top of the box detection reported for it (that CNN box's, as a height in widths kept by
    track id; an ego box reported as it is clears it); the tracker, the distance and the TTC keep
    the tracker's box (vt_pipeline_cfg.cnn_track_top)."""
    lane: LaneConfig = field(default_factory=LaneConfig)
    shadow: ShadowConfig = field(default_factory=ShadowConfig)
    verify: VerifyConfig = field(default_factory=VerifyConfig)
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    fixed_road: FixedRoad = field(default_factory=FixedRoad)
    detect_every: int = _PD[0]
    road: str = _PD[1]
    lanes_every_frame: bool = _PD[2]
    sources: tuple = _PD[3]
    track: bool = _PD[4]
    auto_hood: bool = _PD[5]
    hood: HoodConfig = field(default_factory=HoodConfig)
    cnn_hood_min_width_mm: int = _PD[6]
    cnn_ego_iou_permille: int = _PD[7]
    cnn_track_top: bool = _PD[8]

    def replace(self, **changes) -> "PipelineConfig":
        return dataclasses.replace(self, **changes)


del _PD

STAGES = ("lane", "shadow", "verify", "tracker", "fixed_road")


def from_kwargs(cfg: PipelineConfig | None = None, **overrides) -> PipelineConfig:
    """A PipelineConfig from `cfg` (default: the core's) with top-level fields replaced;
    TypeError naming an unknown one."""
    cfg = PipelineConfig() if cfg is None else cfg
    if not isinstance(cfg, PipelineConfig):
        raise TypeError(f"cfg: expected a PipelineConfig, got {type(cfg).__name__}")
    known = {f.name for f in fields(PipelineConfig)}
    unknown = sorted(set(overrides) - known)
    if unknown:
        raise TypeError(f"unknown pipeline config field(s) {unknown}; known: {sorted(known)}")
    return dataclasses.replace(cfg, **overrides)


# ---------------------------------------------------------------- to C
def _int(v, name: str) -> int:
    """An int32 field (the project's one integer check, pyvehtrack._check)."""
    return _check.integer(v, name)


def _expect(obj, cls, name: str):
    if not isinstance(obj, cls):
        raise TypeError(f"{name}: expected a {cls.__name__}, got {type(obj).__name__}")


def _fill_ints(dst, obj, cls, name: str) -> None:
    _expect(obj, cls, name)
    for f in fields(cls):
        setattr(dst, f.name, _int(getattr(obj, f.name), f"{name}.{f.name}"))


def _permille(v, name: str) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}: expected a number, got {type(v).__name__}")
    if not np.isfinite(v) or not 0.0 <= float(v) <= 1.0:
        raise ValueError(f"{name}: {v} must be a fraction in [0, 1]")
    q = int(round(float(v) * 1000))
    if abs(q - float(v) * 1000) > 1e-6:
        raise ValueError(f"{name}: {v} is not a whole thousandth (C holds it in permille)")
    return q


def _fixed_road_to_c(fr: FixedRoad):
    _expect(fr, FixedRoad, "fixed_road")
    c = ffi.new("vt_fixed_road *")
    for attr, pair in (("vp", ("vp_x_permille", "vp_y_permille")),
                       ("bottom", ("bottom_left_permille", "bottom_right_permille"))):
        v = getattr(fr, attr)
        if not isinstance(v, (tuple, list)) or len(v) != 2:
            raise ValueError(f"fixed_road.{attr}: expected a pair of fractions, got {v!r}")
        for k, cname in enumerate(pair):
            setattr(c, cname, _permille(v[k], f"fixed_road.{attr}[{k}]"))
    c.lane_bottom_permille = _permille(fr.lane_bottom, "fixed_road.lane_bottom")
    c.top_margin = _int(fr.top_margin, "fixed_road.top_margin")
    if c.bottom_left_permille > c.bottom_right_permille:
        raise ValueError(f"fixed_road.bottom: left {fr.bottom[0]} is right of {fr.bottom[1]}")
    if not 0 <= c.top_margin <= 4096:
        raise ValueError(f"fixed_road.top_margin: {fr.top_margin} must be in 0..4096")
    return c


def _tracker_to_c(dst, t) -> None:
    _expect(t, TrackerConfig, "tracker")
    _fill_ints(dst.search, t.search, SearchConfig, "tracker.search")
    _expect(t.model, ModelConfig, "tracker.model")
    dst.model = t.model.to_c()[0]
    k = t.keep_ncc
    if isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, float, np.integer, np.floating)) \
            or not np.isfinite(k) or not -1.0 <= float(k) <= 1.0:
        raise ValueError(f"tracker.keep_ncc: {k!r} must be a number in [-1, 1]")
    dst.keep_ncc = int(np.floor(float(k) * 16384 + 0.5))
    _fill_ints(dst.edge, t.edge, EdgeConfig, "tracker.edge")
    for f in fields(TrackerConfig):
        if f.name not in ("search", "model", "keep_ncc", "edge"):
            setattr(dst, f.name, _int(getattr(t, f.name), f"tracker.{f.name}"))


def to_c(cfg: PipelineConfig):
    """The checked vt_pipeline_cfg * for cfg. TypeError for a wrong type, ValueError
    (pyvehtrack.VtError for the core's range checks) naming the stage."""
    _expect(cfg, PipelineConfig, "cfg")
    c = _native.pipeline_cfg_default()
    _fill_ints(c.lane, cfg.lane, LaneConfig, "lane")
    _fill_ints(c.detect.shadow, cfg.shadow, ShadowConfig, "shadow")
    _fill_ints(c.detect.verify, cfg.verify, VerifyConfig, "verify")
    _tracker_to_c(c.tracker, cfg.tracker)
    c.fixed_road = _fixed_road_to_c(cfg.fixed_road)[0]
    c.detect_every = _int(cfg.detect_every, "detect_every")
    if c.detect_every < 1:
        raise ValueError(f"detect_every: {cfg.detect_every} must be >= 1")
    if cfg.road not in ROAD_POLICIES:
        raise ValueError(f"road: expected one of {sorted(ROAD_POLICIES)}, got {cfg.road!r}")
    c.road_policy = getattr(lib, ROAD_POLICIES[cfg.road])
    if not isinstance(cfg.lanes_every_frame, (bool, np.bool_)):
        raise TypeError(f"lanes_every_frame: expected a bool, got {type(cfg.lanes_every_frame).__name__}")
    c.lanes_every_frame = int(bool(cfg.lanes_every_frame))
    if not isinstance(cfg.track, (bool, np.bool_)):
        raise TypeError(f"track: expected a bool, got {type(cfg.track).__name__}")
    c.track = int(bool(cfg.track))
    if not isinstance(cfg.auto_hood, (bool, np.bool_)):
        raise TypeError(f"auto_hood: expected a bool, got {type(cfg.auto_hood).__name__}")
    c.auto_hood = int(bool(cfg.auto_hood))
    _fill_ints(c.hood, cfg.hood, HoodConfig, "hood")
    c.cnn_hood_min_width_mm = _int(cfg.cnn_hood_min_width_mm, "cnn_hood_min_width_mm")
    if not 0 <= c.cnn_hood_min_width_mm <= 10000:
        raise ValueError(f"cnn_hood_min_width_mm: {cfg.cnn_hood_min_width_mm} must be in 0..10000 (0: off)")
    c.cnn_ego_iou_permille = _int(cfg.cnn_ego_iou_permille, "cnn_ego_iou_permille")
    if not 0 <= c.cnn_ego_iou_permille <= 1000:
        raise ValueError(f"cnn_ego_iou_permille: {cfg.cnn_ego_iou_permille} must be in 0..1000 (0: off)")
    if not isinstance(cfg.cnn_track_top, (bool, np.bool_)):
        raise TypeError(f"cnn_track_top: expected a bool, got {type(cfg.cnn_track_top).__name__}")
    c.cnn_track_top = int(bool(cfg.cnn_track_top))
    _native.check("vt_hood_cfg_check", lib.vt_hood_cfg_check(ffi.addressof(c, "hood")), f"hood config {cfg.hood}")
    src = tuple(cfg.sources) if isinstance(cfg.sources, (tuple, list)) else None
    if src is None or any(s not in SOURCES for s in src):
        raise ValueError(f"sources: expected a tuple of {sorted(SOURCES)}, got {cfg.sources!r}")
    c.sources = 0
    for s in src:
        c.sources |= getattr(lib, SOURCES[s])
    if c.sources & ~lib.VT_SRC_BUILT:
        raise ValueError(f"sources: {cfg.sources!r} asks for a stage not built yet (built: shadow, classifier, flow, model, ego)")
    checks = [("lane", "vt_lane_cfg_check", ffi.addressof(c, "lane")),
              ("shadow", "vt_shadow_cfg_check", ffi.addressof(c.detect, "shadow")),
              ("verify", "vt_verify_cfg_check", ffi.addressof(c.detect, "verify")),
              ("tracker", "vt_tracker_cfg_check", ffi.addressof(c, "tracker"))]
    for stage, fn, ptr in checks:
        if stage == "lane" and cfg.road == "fixed":
            continue  # the lane stage does not run
        _native.check(fn, getattr(lib, fn)(ptr), f"{stage} config {getattr(cfg, stage)}")
    _native.pipeline_cfg_check(c)
    return c


def from_c(c) -> PipelineConfig:
    """The PipelineConfig of a vt_pipeline_cfg (struct or pointer)."""
    def ints(obj, cls):
        return cls(**{f.name: int(getattr(obj, f.name)) for f in fields(cls)})
    tr = {f.name: int(getattr(c.tracker, f.name)) for f in fields(TrackerConfig)
          if f.name not in ("search", "model", "keep_ncc", "edge")}
    tracker = TrackerConfig(search=ints(c.tracker.search, SearchConfig),
                            edge=ints(c.tracker.edge, EdgeConfig),
                            model=ModelConfig.from_c(c.tracker.model),
                            keep_ncc=int(c.tracker.keep_ncc) / 16384, **tr)
    fr = c.fixed_road
    road = next(k for k, v in ROAD_POLICIES.items() if getattr(lib, v) == c.road_policy)
    return PipelineConfig(
        lane=ints(c.lane, LaneConfig), shadow=ints(c.detect.shadow, ShadowConfig),
        verify=ints(c.detect.verify, VerifyConfig), tracker=tracker,
        fixed_road=FixedRoad((fr.vp_x_permille / 1000, fr.vp_y_permille / 1000),
                             (fr.bottom_left_permille / 1000, fr.bottom_right_permille / 1000),
                             fr.lane_bottom_permille / 1000, int(fr.top_margin)),
        detect_every=int(c.detect_every), road=road, lanes_every_frame=bool(c.lanes_every_frame),
        sources=tuple(k for k, v in SOURCES.items() if c.sources & getattr(lib, v)),
        track=bool(c.track), auto_hood=bool(c.auto_hood), hood=ints(c.hood, HoodConfig),
        cnn_hood_min_width_mm=int(c.cnn_hood_min_width_mm), cnn_ego_iou_permille=int(c.cnn_ego_iou_permille),
        cnn_track_top=bool(c.cnn_track_top))


# ---------------------------------------------------------------- to the oracle
def to_reference(cfg: PipelineConfig, quantize: bool = True):
    """The oracle's configuration (reference.pipeline.PipelineRefConfig) with the values
    C actually runs: the Kalman model rounded to Q15.16 and keep_ncc to Q1.14, so both
    engines start from the same numbers (quantize=False: the float values as given,
    as the Tracker's reference engine always had them). Validates through to_c first."""
    from .reference import hood as rhood  # noqa: PLC0415  (the reference engine only)
    from .reference import lane as rlane  # noqa: PLC0415
    from .reference import pipeline as rpipe  # noqa: PLC0415
    from .reference import shadow as rshadow  # noqa: PLC0415
    from .reference import track_search as rts  # noqa: PLC0415
    from .reference import edge_track as redge  # noqa: PLC0415
    from .reference import tracker as rtrk  # noqa: PLC0415
    from .reference import verify as rverify  # noqa: PLC0415
    c = to_c(cfg)
    q = from_c(c)   # the values C holds

    def conv(obj, ref_cls):
        return ref_cls(**{f.name: getattr(obj, f.name) for f in fields(ref_cls)})
    t = q.tracker if quantize else cfg.tracker
    tracker = rtrk.TrackerCfg(search=conv(t.search, rts.SearchCfg),
                              model=rtrk.ModelCfg(**dataclasses.asdict(t.model)),
                              keep_ncc=t.keep_ncc, edge=conv(t.edge, redge.EdgeCfg),
                              **{f.name: getattr(t, f.name) for f in fields(rtrk.TrackerCfg)
                                 if f.name not in ("search", "model", "keep_ncc", "edge")})
    fr = rpipe.FixedRoadRef(q.fixed_road.vp, q.fixed_road.bottom, q.fixed_road.lane_bottom,
                            q.fixed_road.top_margin)
    return rpipe.PipelineRefConfig(
        lane=conv(q.lane, rlane.LaneConfig), shadow=conv(q.shadow, rshadow.ShadowConfig),
        verify=conv(q.verify, rverify.VerifyConfig), tracker=tracker, fixed_road=fr,
        detect_every=q.detect_every, road_policy=q.road, lanes_every_frame=q.lanes_every_frame,
        sources=q.sources, track=q.track, auto_hood=q.auto_hood,
        hood=rhood.HoodConfig(**dataclasses.asdict(q.hood)), cnn_hood_min_width_mm=q.cnn_hood_min_width_mm,
        cnn_ego_iou_permille=q.cnn_ego_iou_permille, cnn_track_top=q.cnn_track_top)


def reference_capacities():
    """The C build's capacities for the oracle (reference.pipeline.Capacities)."""
    from .reference.pipeline import Capacities  # noqa: PLC0415
    return Capacities(max_windows=int(lib.VT_FULLDET_MAX_WINDOWS), max_cand=int(lib.VT_FULLDET_MAX_CAND),
                      max_flow_hyps=int(lib.VT_FLOW_MAX_HYPS), max_flow_seeds=int(lib.VT_FLOW_MAX_SEEDS),
                      max_flow_blobs=int(lib.VT_FLOW_MAX_BLOBS), ho_hist=int(lib.VT_PIPE_HO_HIST),
                      max_model_roi_pixels=int(lib.VT_MODEL_MAX_ROI_PIXELS),
                      max_width=int(lib.VT_MAX_WIDTH), max_height=int(lib.VT_MAX_HEIGHT),
                      max_tracks=int(lib.VT_MAX_TRACKS), max_hypotheses=int(lib.VT_MAX_HYPOTHESES),
                      max_boxes=int(lib.VT_MAX_BOXES),
                      max_shadow_active=int(lib.VT_MAX_SHADOW_ACTIVE),
                      max_shadow_cand=int(lib.VT_MAX_SHADOW_CAND),
                      max_verts=int(lib.VT_LANE_MAX_VERTS),
                      max_edge_points=int(lib.VT_EDGE_MAX_POINTS),
                      max_edge_pixels=int(lib.VT_EDGE_MAX_PIXELS),
                      coord_lim=4 * max(int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)))


__all__ = ["LaneConfig", "ShadowConfig", "VerifyConfig", "SearchConfig", "EdgeConfig", "MEASUREMENTS",
           "TrackerConfig",
           "FixedRoad", "PipelineConfig", "ModelConfig", "from_kwargs", "to_c", "from_c",
           "to_reference", "reference_capacities", "Q16_ONE"]
