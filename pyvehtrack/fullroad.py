"""Vehicle detection over the whole road (IVVI paper sec. 4/5 road restriction, GIST paper
sec. III window classification, thesis sec. 2.4.2 shadow hypotheses), from the C core
(c/fulldet.c) or from its float oracle (reference/fulldet.py).

    from pyvehtrack.fullroad import FullRoadDetector, Camera
    det = FullRoadDetector(model="model.npz")          # or model=None: the built-in default
    boxes = det.detect_gray(gray)                      # (N, 6) [l, t, r, b, score, source]

A box's score is the classifier's decision value (float, the SVM margin; >= the model's
threshold means vehicle); source 1 = shadow hypothesis, 2 = classifier window.

Model files (.npz, written by `pyvehtrack train` or tools/train_window_svm.py) hold:
kind ("hog"/"gist" or 1/2), win_w, win_h, w_q (int16 weights), w_shift, bias_q16 and
optionally threshold_q16 and scan_sizes: the window sides (level pixels, increasing, the
model's window among them) the detector lays on each pyramid level, e.g. [32, 45] for
two sizes per octave (default: the model's window alone). Sides other than the model's
window are resampled to it per window (vt_classify_box: slower, same classifier).
Optionally `detector_json`, the detector settings chosen with the model (so `pyvehtrack
detect --model M.npz` runs as it was validated): a JSON object with any of "sources"
(list; "ego" beside them adds the ego-lane detector in pyvehtrack.Detector),
"score_offset" (float, added to threshold_q16 for detection only, the caller's
score_offset adds on top), "nms_iou_permille", "nms_contain_permille",
"merge_iou_permille" (ints 0..1000, as FullDetConfig), "box_height" (float),
"veh_w_min", "veh_w_max" (floats, m: the flat-road vehicle width band of the windows,
WindowConfig.veh_w_min_m / veh_w_max_m) and "verify_min" (float: a second stage, the
built-in HOG 64x64 MLP on each box, keeps boxes it scores >= this; vt_fulldet_verify).
Explicit arguments win.
Optionally `tracker_json`, the tracker settings chosen with the model: a JSON object of
TrackerCfg's integer fields (e.g. {"birth_search": 0}); a Pipeline or Tracker given the
model and no tracker configuration runs with them (model_tracker_settings); in a CNN
file (every key cnn_*) the key is `cnn_tracker_json`.
Optionally a box regressor (tools/train_box_regressor.py; BoxRegressor, vt_box_regressor):
refine_win_w, refine_win_h, refine_w_q (int16, 4 x dim: left, top, right, bottom),
refine_w_shift (4), refine_b_q16 (4), refine_margin_permille and refine_sources (bits, 1
shadow, 2 windows), all or none; it moves each reported box's sides after the second
stage (FullRoadConfig(refine=False): off). A pipeline's tracker keeps the boxes as detected.
Files written before issue 10 name the three limits "nms_iou", "nms_contain", "merge_iou"
(float fractions): they are still read, x 1000 when that is a whole number of permille
as written (0.2 -> 200), with a DeprecationWarning (shared.FULLDET_RENAMED).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import _check, _native
from ._native import ffi, lib
from .shared import Camera as FrameCamera
from .shared import FULLDET_RENAMED, FullDetConfig, RoadArea, WideConfig, take_renamed

SOURCES = ("shadow", "windows")
# The whole-road model `pyvehtrack detect` / `track` / `report` use on the reference engine when
# no --model is given (HOG 32x32 + 32-unit MLP with its settings: ego-lane detector, shadow and windows;
# how it was made: pyvehtrack/models/README.md). A file, not a C table: firmware that wants
# it generates tables from it as for c/tables/svm_default.h.
DEFAULT_WINDOW_MODEL = Path(__file__).resolve().parent / "models" / "window_mlp_hog32.npz"
# On the C engine they use the ACF first stage instead (five windows on one pyramid with the
# ego-lane detector beside them; pyvehtrack/models/README.md): on unseen TuSimple frames it
# finds more vehicles with fewer false boxes, at about 4.5 x the time; it has no float
# twin of the whole stage, so the reference engine keeps the window model.
DEFAULT_ACF_MODEL = Path(__file__).resolve().parent / "models" / "acf_gray.npz"
# Since issue 8's round of 2026-11-25 the C engine's default is that file loosened with a
# rescorer learnt on its boxes (models/README.md): on unseen TuSimple frames more vehicles
# and fewer false boxes (recall >= 32 px 49.2 -> 55.6%, precision 70.8 -> 77.9%), at about
# a quarter more time; the tracker's bottom snap keeps the Udacity clip's cars one id each.
DEFAULT_RESCORE_MODEL = Path(__file__).resolve().parent / "models" / "acf_gray_rescore.npz"
# Since issue 8's round of 2026-11-29 the C engine's default is the band CNN with wider layers
# (models/README.md, README "Far vehicles: wider layers"): on unseen TuSimple frames recall
# >= 32 px 55.6 -> 66.6%, lead vehicle 69.6 -> 75.5% at precision 77.9 -> 76.4%, no false box
# on the Udacity test images, in 0.77x the time since the CNN's inner loops; the tracker's
# birth search keeps the Udacity clip's cars one id each with it. Its NumPy twin is bit-exact
# but slow, so the reference engine keeps the window model.
DEFAULT_CNN_MODEL = Path(__file__).resolve().parent / "models" / "cnn_gray_l0_big.npz"


def default_model_path(engine: str = "c") -> Path:
    """The model the command line runs when no --model is given, for that engine."""
    return DEFAULT_CNN_MODEL if engine == "c" else DEFAULT_WINDOW_MODEL


# What Detector(model=...) uses when no sources are given: with the HOG 32x32 window
# model of tools/train_window_svm.py the windows add many false boxes for little recall
# on tusimple TRAIN frames (frames 200-280: precision >= 32 px 60% -> 5%, recall 27% ->
# 28%), so they are opt-in until a stronger window model exists.
DEFAULT_SOURCES = ("shadow",)
_KINDS = {"hog": 1, "gist": 2, 1: 1, 2: 2}


@dataclass(frozen=True)
class Camera:
    """The flat-road camera in frame-relative terms, so one setting serves any
    resolution: horizon row and first hood row as fractions of the frame height (the
    horizon is replaced by the lanes' vanishing row when the lane stage finds one),
    camera height in metres, focal length as a multiple of the frame width.
    Defaults: the horizon fitted on the TRAIN part of tusimple-vehicles-dev (row 330 of
    720, from the boxes' bottom rows and heights), TuSimple's 1.8 m camera height and
    714 px focal length at 1280 px, the hood from row 0.93 h. hood_known: the hood row
    is the camera's own (a camera file's hood_row), so the ego-lane detector's road
    ends above it too (vt_pipeline_cfg.road_above_hood); the default fraction is a
    guess only the windows heed (KITTI's cameras see no hood, and a near lead car's
    bottom lies below 0.93 h)."""
    horizon_frac: float = 330 / 720
    hood_frac: float = 0.93
    height_m: float = 1.8
    fx_per_width: float = 714.15 / 1280
    hood_known: bool = False

    def __post_init__(self):
        if not isinstance(self.hood_known, bool):
            raise TypeError(f"camera hood_known: expected a bool, got {self.hood_known!r}")
        for name, lo, hi in (("horizon_frac", -1.0, 1.0), ("hood_frac", 0.05, 2.0), ("height_m", 0.1, 20.0),
                             ("fx_per_width", 0.05, 20.0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise TypeError(f"camera {name}: expected a finite number, got {v!r}")
            if not lo <= v <= hi:
                raise ValueError(f"camera {name}: expected {lo}..{hi}, got {v}")

    def for_frame(self, h: int, w: int, horizon_y: int | None = None) -> FrameCamera:
        hy = int(round(self.horizon_frac * h)) if horizon_y is None else int(horizon_y)
        return FrameCamera(fx=self.fx_per_width * w, horizon_y=hy, height_m=self.height_m,
                         hood_y=max(1, int(round(self.hood_frac * h))))


@dataclass
class SvmModel:
    kind: int
    win_w: int
    win_h: int
    w_q: np.ndarray
    w_shift: int
    bias_q16: int
    threshold_q16: int = 0
    path: str = "<built-in>"
    scan_sizes: tuple = ()
    settings: dict = field(default_factory=dict)
    wide: "MlpModel | None" = None   # the wide pass's window model (wide_* keys of the file)
    refine: "BoxRegressor | None" = None   # box regression (refine_* keys of the file)
    tracker: dict = field(default_factory=dict)   # tracker settings chosen with it (tracker_json)

    def score_float(self, desc_q15: np.ndarray) -> float:
        """The model's decision value (real units) for a Q15 descriptor, in float."""
        w = self.w_q.astype(np.float64) / 2 ** self.w_shift
        return float(w @ (np.asarray(desc_q15, np.float64) / 32768) + self.bias_q16 / 65536)


@dataclass
class MlpModel:
    """A one-hidden-layer MLP on the model window's descriptor (classify.h vt_mlp_model;
    written by tools/train_window_svm.py --mlp or `pyvehtrack train --model-type mlp`).
    Scores are its Q16 logits; windows go through vt_mlp_scorer (vt_classify_box_mlp)."""
    kind: int
    win_w: int
    win_h: int
    w1_q: np.ndarray
    w1_shift: int
    b1_q16: np.ndarray
    w2_q: np.ndarray
    w2_shift: int
    b2_q16: int
    threshold_q16: int = 0
    path: str = "<in memory>"
    scan_sizes: tuple = ()
    settings: dict = field(default_factory=dict)
    wide: "MlpModel | None" = None   # the wide pass's window model (wide_* keys of the file)
    refine: "BoxRegressor | None" = None   # box regression (refine_* keys of the file)
    tracker: dict = field(default_factory=dict)   # tracker settings chosen with it (tracker_json)


@dataclass
class BoxRegressor:
    """Box regression (vt_box_regressor, fulldet.h; tools/train_box_regressor.py): four
    linear models on the HOG (win_w x win_h) of a box's context (the box grown by
    margin_permille of its width, cut to the image) predict the offsets of its left,
    top, right and bottom sides in box widths. w_q (4, dim) int16 in Q(w_shift[k]),
    b_q16 (4,) Q16. sources: bits of the boxes moved (1 shadow, 2 windows)."""
    win_w: int
    win_h: int
    w_q: np.ndarray
    w_shift: np.ndarray
    b_q16: np.ndarray
    margin_permille: int = 250
    sources: int = 3

    def offsets_float(self, desc_q15: np.ndarray) -> np.ndarray:
        """The four offsets (box widths) for a Q15 descriptor, in float (the oracle)."""
        w = self.w_q.astype(np.float64) / (2.0 ** self.w_shift.astype(np.float64))[:, None]
        return w @ (np.asarray(desc_q15, np.float64) / 32768) + self.b_q16 / 65536

    def c(self):
        """(vt_box_regressor *, keepalive)."""
        return _native.box_regressor(self.margin_permille, self.sources, self.win_w, self.win_h, self.w_q,
                                     self.w_shift, self.b_q16)


_REFINE_KEYS = ("refine_win_w", "refine_win_h", "refine_w_q", "refine_w_shift", "refine_b_q16",
                "refine_margin_permille", "refine_sources")


def _refine_model(z, p) -> "BoxRegressor | None":
    """The box regressor of a model file (keys refine_*), or None when it has none."""
    have = [k for k in _REFINE_KEYS if k in z.files]
    if not have:
        return None
    if len(have) != len(_REFINE_KEYS):
        raise ValueError(f"model: {p}: a box regressor needs all of {', '.join(_REFINE_KEYS)}")
    w = np.asarray(z["refine_w_q"])
    if w.ndim != 2 or w.shape[0] != 4 or not np.issubdtype(w.dtype, np.integer) or \
            (np.abs(w.astype(np.int64)) > 32767).any():
        raise ValueError(f"model: {p}: refine_w_q must be a (4, dim) array of int16 values")
    r = BoxRegressor(int(z["refine_win_w"]), int(z["refine_win_h"]), w.astype(np.int16),
                     np.asarray(z["refine_w_shift"], np.int64).reshape(-1),
                     np.asarray(z["refine_b_q16"], np.int64).reshape(-1),
                     int(z["refine_margin_permille"]), int(z["refine_sources"]))
    try:
        r.c()   # validates window, dim, shifts, margin and sources against the C core
    except (ValueError, RuntimeError) as e:
        raise ValueError(f"model: {p}: box regressor: {e}") from None
    return r


@dataclass
class Rescorer:
    """The ACF boxes' second stage (vt_box_rescorer, fulldet.h; tools/train_rescorer.py):
    a HOG linear model (w_q int16 in Q(w_shift), b_q16) over a win x win window of the
    box's context (grown by margin_permille of its width) and boosted trees of `depth`
    (feat, thr, leaf_q16, bias_q16) on seven integer features; boxes scoring below
    score_min_q16 go, the rest pass an NMS at the two permille limits; with side_keep a box
    the frame's side cuts stays when its first-stage score is >= side_score_min_q16."""
    win: int
    w_q: np.ndarray
    w_shift: int
    b_q16: int
    margin_permille: int
    depth: int
    feat: np.ndarray
    thr: np.ndarray
    leaf_q16: np.ndarray
    bias_q16: int
    score_min_q16: int
    nms_iou_permille: int
    nms_contain_permille: int
    info: str = ""
    side_keep: int = 0
    side_score_min_q16: int = 0

    def c(self):
        """(vt_box_rescorer *, keepalive)."""
        return _native.box_rescorer(self.win, self.win, self.w_q, self.w_shift, self.b_q16, self.margin_permille,
                                    self.depth, self.feat, self.thr, self.leaf_q16, self.bias_q16,
                                    self.score_min_q16, self.nms_iou_permille, self.nms_contain_permille,
                                    self.side_keep, self.side_score_min_q16)


_RESCORE_KEYS = ("rescore_w_q", "rescore_w_shift", "rescore_b_q16", "rescore_win", "rescore_margin_permille",
                 "rescore_depth", "rescore_feat", "rescore_thr", "rescore_leaf_q16", "rescore_bias_q16",
                 "rescore_score_min_q16", "rescore_nms_iou_permille", "rescore_nms_contain_permille")


def _rescore_model(z, p) -> "Rescorer | None":
    """The rescorer of an ACF model file (keys rescore_*), or None when it has none."""
    have = [k for k in _RESCORE_KEYS if k in z.files]
    if not have:
        return None
    if len(have) != len(_RESCORE_KEYS):
        raise ValueError(f"model: {p}: a rescorer needs all of {', '.join(_RESCORE_KEYS)}")
    try:
        r = Rescorer(int(z["rescore_win"]), np.asarray(z["rescore_w_q"]).reshape(-1),
                     int(z["rescore_w_shift"]), int(z["rescore_b_q16"]), int(z["rescore_margin_permille"]),
                     int(z["rescore_depth"]), np.asarray(z["rescore_feat"]), np.asarray(z["rescore_thr"]),
                     np.asarray(z["rescore_leaf_q16"]), int(z["rescore_bias_q16"]),
                     int(z["rescore_score_min_q16"]), int(z["rescore_nms_iou_permille"]),
                     int(z["rescore_nms_contain_permille"]),
                     str(z["rescore_info"]) if "rescore_info" in z.files else "",
                     # optional (older files: off): the side rule of vt_box_rescorer
                     int(z["rescore_side_keep"]) if "rescore_side_keep" in z.files else 0,
                     int(z["rescore_side_score_min_q16"]) if "rescore_side_score_min_q16" in z.files else 0)
        r.c()   # validates every array and limit against the C core
    except (ValueError, TypeError, RuntimeError) as e:
        raise ValueError(f"model: {p}: rescorer: {e}") from None
    return r


_SETTINGS = {"score_offset": (-32768.0, 32767.0), "box_height": (1 / 256, 4.0),
             "verify_min": (-32768.0, 32767.0), "veh_w_min": (0.1, 20.0), "veh_w_max": (0.1, 20.0),
             # the wide pass (WideConfig; used when the file holds a wide model)
             "wide_veh_w_min": (0.1, 20.0), "wide_veh_w_max": (0.1, 20.0),
             "wide_score_min": (-32768.0, 32767.0), "wide_alt_score_min": (-32768.0, 32767.0)}
_FULLDET_PERMILLE = ("nms_iou_permille", "nms_contain_permille", "merge_iou_permille",   # FullDetConfig's
                     "rerank_permille")
_PERMILLE = _FULLDET_PERMILLE + ("wide_box_height_permille", "wide_nms_iou_permille",   # ints 0..1000
                                 "wide_nms_contain_permille",
                                 "wide_alt_height_a_permille", "wide_alt_height_b_permille")   # 0: unused


def _json_object(z, key: str, p) -> dict | None:
    """The JSON object a model file holds under key (None without the key); ValueError
    naming the file and key otherwise."""
    if key not in z.files:
        return None
    import json  # noqa: PLC0415
    try:
        d = json.loads(str(z[key]))
    except ValueError as e:
        raise ValueError(f"model: {p}: {key} is not JSON ({e})") from None
    if not isinstance(d, dict):
        raise ValueError(f"model: {p}: {key} must be a JSON object")
    return d


def _settings(z, p) -> dict:
    d = _json_object(z, "detector_json", p)
    if d is None:
        return {}
    d = take_renamed(f"model {p}: detector_json", d, FULLDET_RENAMED, stacklevel=5)
    for k, v in d.items():
        if k in _PERMILLE:
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 1000:
                raise ValueError(f"model: {p}: detector_json {k} must be an int in 0..1000, got {v!r}")
        elif k in ("verify_skip_flat", "verify_skip_edge", "verify_skip_small"):
            if not isinstance(v, bool):
                raise ValueError(f"model: {p}: detector_json {k} must be true or false, got {v!r}")
        elif k == "sources":
            # "ego" beside them: pyvehtrack.Detector adds the ego-lane detector (VT_SRC_EGO)
            if not isinstance(v, list) or not any(x in SOURCES for x in v) or \
                    any(x not in SOURCES + ("ego",) for x in v):
                raise ValueError(f"model: {p}: detector_json sources must be a non-empty subset of {SOURCES}, "
                                 "optionally with 'ego'")
        elif k in _SETTINGS:
            lo, hi = _SETTINGS[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
                raise ValueError(f"model: {p}: detector_json {k} must be a number in {lo}..{hi}, got {v!r}")
        else:
            raise ValueError(f"model: {p}: detector_json has an unknown key {k!r} "
                             f"(known: sources, verify_skip_flat, verify_skip_edge, verify_skip_small, "
                             f"{', '.join(_PERMILLE + tuple(_SETTINGS))})")
    for a, b in (("veh_w_min", "veh_w_max"), ("wide_veh_w_min", "wide_veh_w_max")):
        if d.get(a, 0.0) > d.get(b, 20.0):
            raise ValueError(f"model: {p}: detector_json {a} must not exceed {b}")
    return d


def _tracker_settings(z, p) -> dict:
    """The optional `tracker_json` of a model file: the tracker settings chosen with the
    model (a JSON object of TrackerCfg's integer fields, e.g. {"birth_search": 0}). A
    Pipeline or Tracker built with the model and no tracker configuration of its own runs
    with them; their ranges are checked there (vt_tracker_cfg_check)."""
    d = _json_object(z, "tracker_json", p)
    if d is None:
        return {}
    from dataclasses import fields as _fields  # noqa: PLC0415

    from .shared import TrackerCfg  # noqa: PLC0415
    known = [f.name for f in _fields(TrackerCfg) if f.type in ("int", int)]
    for k, v in d.items():
        if k not in known:
            raise ValueError(f"model: {p}: tracker_json has an unknown key {k!r} (known: {', '.join(known)})")
        if isinstance(v, bool) or not isinstance(v, int):
            raise ValueError(f"model: {p}: tracker_json {k} must be an integer, got {v!r}")
    return d


def model_tracker_settings(model) -> dict:
    """The tracker settings a model (a loaded model, or an .npz path or a model object
    loaded from one) carries ({} if none)."""
    if model is None:
        return {}
    if hasattr(model, "tracker"):
        return dict(model.tracker or {})
    p = os.fspath(model) if isinstance(model, (str, os.PathLike)) else getattr(model, "path", None)
    if not isinstance(p, str) or not os.path.isfile(p):
        return {}
    with np.load(p, allow_pickle=False) as z:
        key = "cnn_tracker_json" if "cnn_tracker_json" in z.files else "tracker_json"
        return _tracker_settings(_Keys(tracker_json=z[key]) if key in z.files else _Keys(), p)


class _Keys(dict):
    """A mapping read like an opened .npz (its .files), for keys renamed on the way."""
    @property
    def files(self):
        return list(self)


def load_model(path) -> SvmModel | MlpModel:
    """A model from an .npz file (see the module doc); ValueError naming the problem."""
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise ValueError(f"model: no such file: {p}")
    _check.npz_file(p, "model")
    try:
        z = np.load(p, allow_pickle=False)
    except Exception as e:  # noqa: BLE001  (any unreadable file is the same user error)
        raise ValueError(f"model: {p} is not a readable .npz file ({e})") from None
    from .cnn import CnnModel, is_cnn  # noqa: PLC0415
    if is_cnn(z):
        # the CNN detector (cnn.h): its settings (sources, ...) in cnn_detector_json
        m = CnnModel.load(p)
        m.settings = _settings(_Keys(detector_json=z["cnn_detector_json"]) if "cnn_detector_json" in z.files
                               else _Keys(), p)
        m.wide = m.refine = m.rescore = None
        m.tracker = _tracker_settings(_Keys(tracker_json=z["cnn_tracker_json"]) if "cnn_tracker_json" in z.files
                                      else _Keys(), p)
        return m
    if "kind" in z.files and str(z["kind"]) == "acf":
        # the ACF first stage (acf.h); the whole-road settings, wide pass and box
        # regressor ride along in the same keys as for the window models
        from .acf import AcfModel  # noqa: PLC0415
        m = AcfModel.load(p)
        m.settings, m.wide, m.refine = _settings(z, p), _wide_model(z, p), _refine_model(z, p)
        m.rescore = _rescore_model(z, p)
        m.tracker = _tracker_settings(z, p)
        return m
    mlp = "model_type" in z.files and str(z["model_type"]) == "mlp"
    need = ("kind", "win_w", "win_h") + (("w1_q", "w1_shift", "b1_q16", "w2_q", "w2_shift", "b2_q16") if mlp
                                         else ("w_q", "w_shift", "bias_q16"))
    miss = [k for k in need if k not in z.files]
    if miss:
        raise ValueError(f"model: {p} lacks {', '.join(miss)} (expected the keys {', '.join(need)})")
    kind = z["kind"].item()
    kind = _KINDS.get(kind.lower() if isinstance(kind, str) else int(kind))
    if kind is None:
        raise ValueError(f"model: {p}: kind must be 'hog' or 'gist', got {z['kind'].item()!r}")
    scan = _scan_sizes(z, p)
    settings = _settings(z, p)
    thr = int(z["threshold_q16"]) if "threshold_q16" in z.files else 0
    wide = _wide_model(z, p)
    refine = _refine_model(z, p)
    if mlp:
        arrs = [np.asarray(z[k]) for k in ("w1_q", "b1_q16", "w2_q")]
        if any(not np.issubdtype(a.dtype, np.integer) for a in arrs) or arrs[0].ndim != 2:
            raise ValueError(f"model: {p}: w1_q (2-D), b1_q16 and w2_q must be integer arrays")
        m = MlpModel(kind, int(z["win_w"]), int(z["win_h"]), arrs[0], int(z["w1_shift"]), arrs[1], arrs[2],
                     int(z["w2_shift"]), int(z["b2_q16"]), thr, p, scan, settings, wide, refine,
                     _tracker_settings(z, p))
        _c_model(m)   # validates shapes, shifts and window against the C core
        return m
    w = np.asarray(z["w_q"])
    if w.ndim != 1 or not np.issubdtype(w.dtype, np.integer) or (np.abs(w.astype(np.int64)) > 32767).any():
        raise ValueError(f"model: {p}: w_q must be a 1-D array of int16 values")
    m = SvmModel(kind, int(z["win_w"]), int(z["win_h"]), w.astype(np.int16), int(z["w_shift"]),
                 int(z["bias_q16"]), thr, p, scan, settings, wide, refine, _tracker_settings(z, p))
    _c_model(m)   # validates window, dim and shift against the C core
    return m


_WIDE_KEYS = ("wide_win_w", "wide_win_h", "wide_w1_q", "wide_w1_shift", "wide_b1_q16", "wide_w2_q", "wide_w2_shift",
              "wide_b2_q16")


def _wide_model(z, p) -> "MlpModel | None":
    """The wide pass's HOG MLP (keys wide_win_w .. wide_b2_q16, as tools/train_wide_mlp.py
    writes them without the prefix), or None when the file holds none."""
    have = [k for k in _WIDE_KEYS if k in z.files]
    if not have:
        return None
    if len(have) != len(_WIDE_KEYS):
        raise ValueError(f"model: {p}: a wide model needs all of {', '.join(_WIDE_KEYS)}")
    arrs = [np.asarray(z[k]) for k in ("wide_w1_q", "wide_b1_q16", "wide_w2_q")]
    if any(not np.issubdtype(a.dtype, np.integer) for a in arrs) or arrs[0].ndim != 2:
        raise ValueError(f"model: {p}: wide_w1_q (2-D), wide_b1_q16 and wide_w2_q must be integer arrays")
    m = MlpModel(1, int(z["wide_win_w"]), int(z["wide_win_h"]), arrs[0], int(z["wide_w1_shift"]), arrs[1],
                 arrs[2], int(z["wide_w2_shift"]), int(z["wide_b2_q16"]), 0, p + " (wide)")
    _c_model(m)   # validates shapes, shifts and window against the C core
    return m


def wide_setup(model, cfg: "FullRoadConfig") -> "tuple[MlpModel, WideConfig] | None":
    """The wide pass a detector runs: (its model, its WideConfig from the model's
    detector_json wide_* settings over WideConfig's defaults, the threshold in Q16), or
    None when the model carries no wide model or cfg.wide is False."""
    wm = getattr(model, "wide", None)
    if wm is None or cfg.wide is False:
        if cfg.wide is True:
            raise ValueError("cfg.wide: the model holds no wide model (see tools/train_wide_mlp.py)")
        return None
    st = getattr(model, "settings", {}) or {}
    d = WideConfig()
    w = WideConfig(veh_w_min_m=float(st.get("wide_veh_w_min", d.veh_w_min_m)),
                   veh_w_max_m=float(st.get("wide_veh_w_max", d.veh_w_max_m)),
                   box_height_permille=int(st.get("wide_box_height_permille", d.box_height_permille)),
                   score_min=int(round(float(st.get("wide_score_min", d.score_min / 65536)) * 65536)),
                   nms_iou_permille=int(st.get("wide_nms_iou_permille", d.nms_iou_permille)),
                   nms_contain_permille=int(st.get("wide_nms_contain_permille", d.nms_contain_permille)),
                   alt_height_a_permille=int(st.get("wide_alt_height_a_permille", d.alt_height_a_permille)),
                   alt_height_b_permille=int(st.get("wide_alt_height_b_permille", d.alt_height_b_permille)),
                   alt_score_min=int(round(float(st.get("wide_alt_score_min", d.alt_score_min / 65536)) * 65536)))
    return wm, w


def _is_acf(model) -> bool:
    from .acf import AcfModel  # noqa: PLC0415
    return isinstance(model, AcfModel)


def _is_cnn(model) -> bool:
    from .cnn import CnnModel  # noqa: PLC0415
    return isinstance(model, CnnModel)


def refine_setup(model, cfg: "FullRoadConfig") -> "BoxRegressor | None":
    """The box regressor a detector runs: the model's, unless cfg.refine is False."""
    r = getattr(model, "refine", None)
    return None if r is None or cfg.refine is False else r


def wide_c_cfg(w: WideConfig):
    """vt_fulldet_wide_cfg of a WideConfig (fractions in permille), checked."""
    c = _native.fulldet_wide_cfg_default()
    c.veh_w_min_mm, c.veh_w_max_mm = round(w.veh_w_min_m * 1000), round(w.veh_w_max_m * 1000)
    c.box_height_permille, c.score_min = w.box_height_permille, int(w.score_min)
    c.nms_iou_permille, c.nms_contain_permille = w.nms_iou_permille, w.nms_contain_permille
    c.alt_height_a_permille, c.alt_height_b_permille = w.alt_height_a_permille, w.alt_height_b_permille
    c.alt_score_min = int(w.alt_score_min)
    _native.check("vt_fulldet_wide_cfg_check", lib.vt_fulldet_wide_cfg_check(c), f"wide pass {w}")
    return c


def _scan_sizes(z, p) -> tuple:
    if "scan_sizes" not in z.files:
        return ()
    a = np.asarray(z["scan_sizes"])
    if a.ndim != 1 or not np.issubdtype(a.dtype, np.integer) or not 1 <= len(a) <= int(lib.VT_WIN_MAX_SIZES) \
            or (a < 4).any() or (a > 1024).any() or (np.diff(a) <= 0).any() or int(z["win_w"]) not in a:
        raise ValueError(f"model: {p}: scan_sizes must be 1..{int(lib.VT_WIN_MAX_SIZES)} increasing window "
                         f"sides in 4..1024 including win_w, got {a.tolist()}")
    return tuple(int(v) for v in a)


def default_model() -> SvmModel | None:
    """The model built into the C core (c/tables/), or None if the build has none."""
    out = ffi.new("const vt_svm_model **")
    if lib.vt_svm_default_model(1, out) != 0:
        return None
    m = out[0]
    w = np.frombuffer(ffi.buffer(m.w, 2 * m.dim), np.int16).copy()
    return SvmModel(m.kind, m.win_w, m.win_h, w, m.w_shift, m.bias_q16, m.threshold_q16)


def _c_model(m):
    if isinstance(m, MlpModel):
        return _native.mlp_model(m.kind, m.win_w, m.win_h, m.w1_q, m.w1_shift, m.b1_q16, m.w2_q, m.w2_shift,
                                 m.b2_q16, m.threshold_q16)
    return _native.svm_model(m.kind, m.win_w, m.win_h, m.w_q, m.w_shift, m.bias_q16, m.threshold_q16)


@dataclass(frozen=True)
class FullRoadConfig:
    """Everything but the camera and the model: the oracle's FullDetConfig fields
    (windows, shadow/verify stages, thresholds, NMS; None: the library defaults with the
    model's detector_json settings applied); `score_offset` (float, the SVM's units) is
    added to the model's own threshold for windows and shadow boxes; `verify_min`
    (float, or None: the model's setting, else off) turns on the second stage: the
    built-in HOG 64x64 MLP scores each box (the square on its bottom row) and boxes
    below verify_min are dropped (vt_fulldet_verify); `verify_skip_flat` (None: the
    model's setting, else False): in a Pipeline (vt_pipeline_cfg.verify 2) whole-road
    boxes flatter than 1:2 (side views, which the rear-view MLP cannot judge on their
    bottom-row square) skip that stage and keep their first-stage score;
    `verify_skip_edge` (None: the model's setting while verify_skip_flat is on, else False;
    needs verify_skip_flat):
    so do boxes whose gap to the frame's left or right side is at most a quarter of their
    width plus 1 px (vehicles the frame's edge cuts; vt_pipeline_cfg.verify 3);
    `verify_skip_small` (None: the model's setting while verify_skip_edge is on, else False;
    needs verify_skip_edge): so do boxes narrower than 32 px (far cars, which the 64x64 MLP
    would judge enlarged 2x or more; vt_pipeline_cfg.verify 4)."""
    det: FullDetConfig | None = None
    score_offset: float = 0.0
    verify_min: float | None = None
    verify_skip_flat: bool | None = None
    verify_skip_edge: bool | None = None
    verify_skip_small: bool | None = None
    wide: bool | None = None   # the wide pass: None = on when the model holds a wide model
    refine: bool | None = None   # box regression: None = on when the model holds a box regressor
    rescore: bool | None = None   # the ACF boxes' rescorer: None = on when the model holds one


def verify_mode(cfg: FullRoadConfig) -> int:
    """vt_pipeline_cfg.verify for a FullRoadConfig whose verify_min is set: 1 every box, 2 all
    but flat boxes, 3 all but flat and edge-cut boxes, 4 all but those and boxes < 32 px wide."""
    if cfg.verify_skip_edge and not cfg.verify_skip_flat:
        raise ValueError("verify_skip_edge needs verify_skip_flat (vt_pipeline_cfg.verify 3 skips both)")
    if cfg.verify_skip_small and not cfg.verify_skip_edge:
        raise ValueError("verify_skip_small needs verify_skip_edge (vt_pipeline_cfg.verify 4 skips all three)")
    return 4 if cfg.verify_skip_small else 3 if cfg.verify_skip_edge else (2 if cfg.verify_skip_flat else 1)


def _c_cfg(cfg: FullDetConfig):
    c = _native.fulldet_cfg_default()
    c.sources = (1 if cfg.shadow_source else 0) | (2 if cfg.window_source else 0)
    w = cfg.win
    if len(w.sizes) > int(lib.VT_WIN_MAX_SIZES) or w.levels > int(lib.VT_WIN_MAX_LEVELS):
        raise ValueError(f"cfg.win: at most {int(lib.VT_WIN_MAX_SIZES)} sizes and "
                         f"{int(lib.VT_WIN_MAX_LEVELS)} levels in this build")
    c.win.veh_w_min_mm, c.win.veh_w_max_mm = round(w.veh_w_min_m * 1000), round(w.veh_w_max_m * 1000)
    c.win.n_sizes = len(w.sizes)
    for i, s in enumerate(w.sizes):
        c.win.size[i] = int(s)
    c.win.step_q8, c.win.levels = round(w.step * 256), int(w.levels)
    c.win.lane_w_mm, c.win.top_margin = round(w.lane_w_m * 1000), int(w.top_margin)
    for f in cfg.shadow.__dataclass_fields__:
        setattr(c.det.shadow, f, int(getattr(cfg.shadow, f)))
    for f in cfg.verify.__dataclass_fields__:
        setattr(c.det.verify, f, int(getattr(cfg.verify, f)))
    c.window_score_min, c.edge_check = int(cfg.window_score_min), int(bool(cfg.edge_check))
    c.shadow_classify = int(bool(cfg.shadow_classify))
    c.shadow_score_min, c.shadow_score = int(cfg.shadow_score_min), int(cfg.shadow_score)
    for f in ("nms_iou_permille", "nms_contain_permille", "merge_iou_permille", "rerank_permille"):
        v = getattr(cfg, f)
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
            raise TypeError(f"cfg.{f}: expected an int (permille), got {type(v).__name__}")
        if not 0 <= v <= 1000:
            raise ValueError(f"cfg.{f}: expected 0..1000 (permille), got {v}")
        setattr(c, f, int(v))
    c.box_height_q8 = round(cfg.box_height * 256)
    _native.check("vt_fulldet_cfg_check", lib.vt_fulldet_cfg_check(c), f"config {cfg}")
    return c


def setup(model=None, sources=SOURCES, camera: Camera | None = None, cfg: FullRoadConfig | None = None):
    """The checked pieces of a whole-road detector, shared by FullRoadDetector and
    pyvehtrack.Pipeline(model=...): (model, sources, camera, cfg, the oracle's
    FullDetConfig as run). model: a path, an SvmModel / MlpModel, or None for the core's
    built-in one; the window sizes follow the model's scan sizes and the score thresholds
    its threshold plus cfg.score_offset."""
    if isinstance(sources, str):
        sources = (sources,)
    sources = tuple(sources)
    bad = [s for s in sources if s not in SOURCES]
    if bad or not sources:
        raise ValueError(f"sources: expected a non-empty subset of {SOURCES}, got {sources!r}")
    from .acf import AcfModel  # noqa: PLC0415
    from .cnn import CnnModel  # noqa: PLC0415
    if model is None:
        model = default_model()
    elif isinstance(model, (SvmModel, MlpModel, AcfModel, CnnModel)):
        pass
    elif isinstance(model, (str, os.PathLike)):
        model = load_model(model)
    else:
        raise TypeError(f"model: expected a path, an SvmModel, an MlpModel or None, got {type(model).__name__}")
    if model is None and "windows" in sources:
        raise ValueError("sources: 'windows' needs a classifier model, and this build has no default "
                         "model: pass model=PATH.npz (see `pyvehtrack train`)")
    camera = camera if camera is not None else Camera()
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    cfg = cfg if cfg is not None else FullRoadConfig()
    if not isinstance(cfg, FullRoadConfig):
        raise TypeError(f"cfg: expected a FullRoadConfig, got {type(cfg).__name__}")
    if cfg.wide is not None and not isinstance(cfg.wide, bool):
        raise TypeError(f"cfg.wide: expected True, False or None, got {cfg.wide!r}")
    if cfg.refine is not None and not isinstance(cfg.refine, bool):
        raise TypeError(f"cfg.refine: expected True, False or None, got {cfg.refine!r}")
    if cfg.refine is True and getattr(model, "refine", None) is None:
        raise ValueError("cfg.refine: the model holds no box regressor (see tools/train_box_regressor.py)")
    if cfg.rescore is not None and not isinstance(cfg.rescore, bool):
        raise TypeError(f"cfg.rescore: expected True, False or None, got {cfg.rescore!r}")
    if cfg.rescore is True and getattr(model, "rescore", None) is None:
        raise ValueError("cfg.rescore: the model holds no rescorer (see tools/train_rescorer.py)")
    st = getattr(model, "settings", {}) or {}
    det = cfg.det
    if det is None:
        det = replace(FullDetConfig(), **{k: int(st[k]) for k in _FULLDET_PERMILLE if k in st},
                      **({"box_height": float(st["box_height"])} if "box_height" in st else {}))
        if "veh_w_min" in st or "veh_w_max" in st:
            det = replace(det, win=replace(det.win, veh_w_min_m=float(st.get("veh_w_min", det.win.veh_w_min_m)),
                                           veh_w_max_m=float(st.get("veh_w_max", det.win.veh_w_max_m))))
    elif not isinstance(det, FullDetConfig):
        raise TypeError(f"cfg.det: expected a FullDetConfig or None, got {type(det).__name__}")
    vmin = cfg.verify_min if cfg.verify_min is not None else st.get("verify_min")
    if vmin is not None and (isinstance(vmin, bool) or not isinstance(vmin, (int, float))
                             or not np.isfinite(vmin)):
        raise TypeError(f"cfg.verify_min: expected a finite number or None, got {vmin!r}")
    # the second stage's skips, each on top of the one before (vt_pipeline_cfg.verify 2, 3, 4); a
    # model's own setting rides with the one before it (verify_skip_edge with verify_skip_flat, ...)
    skips, prev = {}, None
    for name, what in (("verify_skip_flat", ""), ("verify_skip_edge", "verify 3 skips both"),
                       ("verify_skip_small", "verify 4 skips all three")):
        v = getattr(cfg, name)
        if v is None:
            v = st.get(name, False) if prev is None else (skips[prev] and st.get(name, False))
        if not isinstance(v, bool):
            raise TypeError(f"cfg.{name}: expected True, False or None, got {v!r}")
        if v and prev is not None and not skips[prev]:
            raise ValueError(f"{name} needs {prev} (vt_pipeline_cfg.{what})")
        skips[name], prev = v, name
    cfg = replace(cfg, det=det, verify_min=None if vmin is None else float(vmin), **skips)
    thr = 0
    if model is not None and not _is_cnn(model):   # a CNN's threshold is its own (Pipeline)
        thr = model.threshold_q16 + int(round((cfg.score_offset + float(st.get("score_offset", 0.0))) * 65536))
        sizes = model.scan_sizes or (model.win_w,)
        if det.win.sizes != sizes and model.win_w == model.win_h:
            det = replace(det, win=replace(det.win, sizes=sizes, step=8 / model.win_w))
    # the C core holds the box height in Q8: give the oracle the same quantised value
    det = replace(det, box_height=round(det.box_height * 256) / 256)
    det = replace(det, shadow_source="shadow" in sources, window_source="windows" in sources,
                  window_score_min=thr, shadow_score_min=thr,
                  shadow_classify=det.shadow_classify and model is not None)
    return model, sources, camera, cfg, det


def road_camera_to_c(cam: Camera):
    """The frame-relative camera as the pipeline holds it (vt_road_camera, Q16 fractions;
    pipeline.h gives the per-frame rounding)."""
    c = ffi.new("vt_road_camera *")
    c.horizon_q16 = int(round(cam.horizon_frac * 65536))
    c.hood_q16 = int(round(cam.hood_frac * 65536))
    c.height_mm = int(round(cam.height_m * 1000))
    c.fx_per_w_q16 = int(round(cam.fx_per_width * 65536))
    return c


def c_scorer(model):
    """(vt_window_scorer * or None, keepalive) for the C pipeline: None for an SVM model
    (the pipeline's own HOG scorer on the model given to vt_pipeline_init), the MLP
    scorer for an MlpModel."""
    if not isinstance(model, MlpModel):
        return None, None
    m, keep = _c_model(model)
    mlp = ffi.new("vt_mlp_scorer *")
    _native.check("vt_mlp_scorer_init", lib.vt_mlp_scorer_init(mlp, m))
    sc = ffi.new("vt_window_scorer *")
    sc.level = ffi.NULL
    sc.score = ffi.addressof(lib, "vt_mlp_scorer_score")
    sc.ctx = mlp
    return sc, (m, keep, mlp)


def refine_offsets_c(ws, reg, gray: np.ndarray, ctx) -> list:
    """The C regressor's four Q16 offsets on one context box (vt_classify_box per side:
    the values vt_box_regress adds), for the reference engine."""
    return [_native.classify_box(ws, ffi.addressof(reg.side[k]), gray, list(ctx)) for k in range(4)]


class FullRoadDetector:
    """Shadow hypotheses and classifier windows over the whole road, merged by NMS.

    model: path to an .npz model, an SvmModel, or None for the core's built-in model
    (if the build has none, the window source is unavailable: ValueError when asked for).
    sources: a subset of ("shadow", "windows").
    camera: a Camera (frame-relative flat-road camera).
    engine: "c" or "reference" (the float oracle; the classifier is the C one in both,
    its own oracle lives with the classify stage)."""

    def __init__(self, model=None, *, sources=SOURCES, camera: Camera | None = None,
                 cfg: FullRoadConfig | None = None, engine: str = "c"):
        if engine not in ("c", "reference"):
            raise ValueError(f"engine: expected 'c' or 'reference', got {engine!r}")
        self.model, sources, self.camera, cfg, det = setup(model, sources, camera, cfg)
        vmin = cfg.verify_min
        self.verify_skip_flat = bool(cfg.verify_skip_flat) or bool(cfg.verify_skip_edge) or \
            bool(cfg.verify_skip_small)
        self.verify_min_q16 = None if vmin is None else int(round(float(vmin) * 65536))
        use_v = vmin is not None or det.rerank_permille > 0   # the second stage's model, or re-ranking
        self._vmodel = _native.mlp_default_model() if use_v else None
        self._vws = _native.box_ws_new() if use_v else None
        self.cfg, self.det_cfg, self.sources, self.engine = cfg, det, sources, engine
        # the wide pass (side views, trucks): (its model, WideConfig) or None
        self.wide = wide_setup(self.model, cfg)
        if self.wide is not None:
            self._wide_m = _c_model(self.wide[0])
            self._wide_c = wide_c_cfg(self.wide[1])
            self._wide_ws = _native.box_ws_new()
        # box regression: (BoxRegressor, C regressor, keepalive, its scratch) or None
        self.refine = refine_setup(self.model, cfg)
        if self.refine is not None:
            self._ref_c = self.refine.c()
            self._ref_ws = _native.box_ws_new()
        self._cfg_c = _c_cfg(det)
        self._state = ffi.new("vt_fulldet_state *")
        self._out = ffi.new("vt_fulldet_result *")
        self._scorer = None
        if isinstance(self.model, MlpModel):
            self._m, self._keep = _c_model(self.model)
            self._mlp = ffi.new("vt_mlp_scorer *")
            _native.check("vt_mlp_scorer_init", lib.vt_mlp_scorer_init(self._mlp, self._m))
            self._scorer = ffi.new("vt_window_scorer *")
            self._scorer.level = ffi.NULL
            self._scorer.score = ffi.addressof(lib, "vt_mlp_scorer_score")
            self._scorer.ctx = self._mlp
        elif self.model is not None and not _is_acf(self.model) and not _is_cnn(self.model):
            self._m, self._keep = _c_model(self.model)
            self._hog = ffi.new("vt_hog_scorer *")
            _native.check("vt_hog_scorer_init", lib.vt_hog_scorer_init(self._hog, self._m))
            self._scorer = ffi.new("vt_window_scorer *")
            self._scorer.level = ffi.addressof(lib, "vt_hog_scorer_level")
            self._scorer.score = ffi.addressof(lib, "vt_hog_scorer_score")
            self._scorer.ctx = self._hog
        self.last_stats: dict = {}

    def camera_for(self, h: int, w: int, horizon_y: int | None = None) -> FrameCamera:
        return self.camera.for_frame(h, w, horizon_y)

    @staticmethod
    def _c_camera(cam: FrameCamera):
        return _native.camera_min(cam.fx, cam.horizon_y, round(cam.height_m * 1000), cam.hood_y)

    def camera_road(self, h: int, w: int, horizon_y: int | None = None) -> RoadArea | None:
        """The road the camera alone gives an h x w frame (every column between the
        horizon and the hood, rows where a vehicle of the window band fits), from this
        detector's engine (the two agree exactly: tests/test_windows.py), or None."""
        cam = self.camera_for(h, w, horizon_y)
        if self.engine == "c":
            r = _native.road_from_camera(ffi.addressof(self._cfg_c, "win"), self._c_camera(cam), w, h)
            if not r.valid:
                return None
            rows = [np.frombuffer(ffi.buffer(getattr(r, k)), np.int16)[:h].copy()
                    for k in ("x_left", "x_right", "lane_width")]
            return RoadArea(int(r.y_top), int(r.y_bottom), *rows, True)
        from .reference import windows as rw  # noqa: PLC0415  (the reference engine only)
        ok, y0, y1, xl, xr, lw = rw.road_from_camera(cam, self.det_cfg.win, w, h)
        return RoadArea(y0, y1, xl, xr, lw, ok) if ok else None

    def _score_py(self, img, level, s, x, y):
        """The C classifier on one window, for the reference engine."""
        win = ffi.new("vt_window *", [level, s, x, y])
        out = ffi.new("int32_t *")
        v = _native.view(np.ascontiguousarray(img), "level_img")
        _native.check("window scorer", self._scorer.score(self._scorer.ctx, v, win, out))
        return int(out[0])

    def _score_box(self, img, l, t, r, b):
        """The second-stage classifier (C, vt_classify_box_mlp) on one box, for the reference engine."""
        box = ffi.new("vt_box *", [l, t, r, b])
        out = ffi.new("int32_t *")
        v = _native.view(np.ascontiguousarray(img), "img")
        _native.check("vt_classify_box_mlp", lib.vt_classify_box_mlp(self._vws, self._vmodel, v, box, out))
        return int(out[0])

    def detect_gray(self, gray: np.ndarray, road=None, horizon_y: int | None = None) -> np.ndarray:
        """Boxes (N, 6) float [left, top, right, bottom, score, source] in the pixels of
        `gray` (uint8 (h, w), within the core's maximum size), highest score first.
        road: a RoadArea-like restriction, or None for the camera road (all columns
        between the horizon and the hood). Scores are in the model's units (Q16 / 65536)."""
        h, w = gray.shape
        if _is_acf(self.model) or _is_cnn(self.model):
            raise ValueError("detect_gray runs vt_fulldet's window models; an ACF or CNN model runs through "
                             "pyvehtrack.Detector / Pipeline (vt_pipeline_set_acf / _cnn), or "
                             "pyvehtrack.acf.detect / pyvehtrack.cnn.detect_frame")
        if self.verify_skip_flat and self.verify_min_q16 is not None:
            raise ValueError("detect_gray: verify_skip_flat / verify_skip_edge / verify_skip_small (the second "
                             "stage on all but flat, edge-cut or small boxes) runs in pyvehtrack.Detector / "
                             "Pipeline (vt_pipeline_cfg.verify 2 / 3 / 4) only")
        cam = self.camera_for(h, w, horizon_y)
        ccam = self._c_camera(cam)
        if road is None:
            road_c = _native.road_from_camera(ffi.addressof(self._cfg_c, "win"), ccam, w, h)
            road_r = None
            if self.engine != "c":
                from .reference import windows as rw  # noqa: PLC0415  (the reference engine only)
                road_r = rw.road_from_camera(cam, self.det_cfg.win, w, h)
        else:
            road_c = _native.road_area(road, h)
            road_r = road
        if self.engine == "c":
            a = _native.fulldet(self._state, self._cfg_c, ccam, gray, road_c, self._scorer, self._out)
            self.last_stats = {k: int(getattr(self._out, k)) for k in
                               ("n_windows", "n_windows_dropped", "n_window_hits", "n_shadow", "n_cand",
                                "n_cand_dropped")}
            if self.det_cfg.rerank_permille > 0:
                a = _native.fulldet_rerank(self._state, self._vws, self._vmodel, self._cfg_c, gray, self._out)
            if self.verify_min_q16 is not None:
                a = _native.fulldet_verify(self._vws, self._vmodel, gray, self.verify_min_q16, self._out)
                self.last_stats["n_verified"] = len(a)
            if self.refine is not None:
                a = _native.fulldet_refine(self._ref_ws, self._ref_c[0], gray, self._out)
            if self.wide is not None:
                n0 = int(self._out.n_boxes)
                a = _native.fulldet_wide(self._state, self._wide_ws, self._wide_c, ffi.addressof(self._cfg_c, "win"),
                                         self._wide_m[0], ccam, gray, road_c, self._out)
                self.last_stats["n_wide"] = len(a) - n0
            arr = np.stack([a[k] for k in ("left", "top", "right", "bottom", "score", "source")], 1)
        else:
            from .reference import fulldet as rfd  # noqa: PLC0415  (the reference engine only)
            arr, self.last_stats = rfd.detect(
                gray, road_r, cam, self.det_cfg, self._score_py if self._scorer is not None else None,
                max_windows=int(lib.VT_FULLDET_MAX_WINDOWS), max_cand=int(lib.VT_FULLDET_MAX_CAND),
                max_boxes=int(lib.VT_MAX_BOXES), max_hyp=int(lib.VT_MAX_HYPOTHESES),
                rescore=(lambda l, t, r, b: self._score_box(gray, l, t, r, b)) if self._vmodel is not None else None)
            if self.verify_min_q16 is not None:
                arr = rfd.verify_boxes(arr, lambda l, t, r, b: self._score_box(gray, l, t, r, b), self.verify_min_q16)
                self.last_stats["n_verified"] = len(arr)
            if self.refine is not None:
                arr = self.refine_ref(gray, arr)
            if self.wide is not None:
                n0 = len(arr)
                arr = rfd.wide(gray, road_r, cam, self.det_cfg.win, self.wide[1],
                               lambda l, t, r, b: _native.classify_box_mlp(self._wide_ws, self._wide_m[0], gray,
                                                                           [l, t, r, b]),
                               arr, max_windows=int(lib.VT_FULLDET_MAX_WINDOWS),
                               max_cand=int(lib.VT_FULLDET_MAX_CAND), max_boxes=int(lib.VT_MAX_BOXES))
                self.last_stats["n_wide"] = len(arr) - n0
        out = np.asarray(arr, np.float64).reshape(-1, 6)
        out[:, 4] /= 65536.0
        return out

    def refine_ref(self, gray: np.ndarray, arr) -> np.ndarray:
        """The oracle's box regression (reference.fulldet.refine) of result rows arr
        (N, 6) with this detector's regressor, its offsets from the C regressor."""
        from .reference import fulldet as rfd  # noqa: PLC0415  (the reference engine only)
        h, w = gray.shape
        return rfd.refine(arr, lambda l, t, r, b: refine_offsets_c(self._ref_ws, self._ref_c[0], gray, (l, t, r, b)),
                          self.refine.margin_permille, self.refine.sources, w, h)


__all__ = ["Camera", "SvmModel", "MlpModel", "FullRoadConfig", "FullRoadDetector", "load_model", "default_model",
           "default_model_path", "DEFAULT_ACF_MODEL", "DEFAULT_RESCORE_MODEL", "DEFAULT_CNN_MODEL", "DEFAULT_WINDOW_MODEL", "SOURCES",
           "DEFAULT_SOURCES", "setup", "road_camera_to_c", "c_scorer", "wide_setup", "wide_c_cfg", "WideConfig",
           "BoxRegressor", "refine_setup", "refine_offsets_c"]
