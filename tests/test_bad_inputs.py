"""The bad-input table (reliability issue, item 4): one row per bad input, for the Python API,
the CLI and a few C entries through cffi.

Each row states what must happen: a clear error naming the argument or file (a Python
exception of the stated type whose message holds the stated words; for the CLI exit status 2
and exactly one line on stderr, never a traceback, and no output file left behind), or a
documented behaviour ("ok": the call returns normally; the row says what it gives).
test_table_size prints the number of rows (the README quotes it).
"""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

import pyvehtrack as vt
from pyvehtrack import VtError
from pyvehtrack.cli import main as cli_main
from pyvehtrack.detector import DetectConfig, Detector, ShadowConfig
from pyvehtrack.kalman import KalmanFilter, ModelConfig
from pyvehtrack.lane import LaneDetector
from pyvehtrack.reference.tracker import ModelCfg, TrackerCfg
from pyvehtrack.tracker import Tracker

ffi, lib = vt.ffi, vt.lib
DATA = Path(__file__).parent / "data"
GOOD = DATA / "kitti_0000_gray_320x96.png"      # a real frame, small and fast
U8 = np.zeros((96, 128), np.uint8)
OK = "ok"


def _kf_with(name, value):
    kf = KalmanFilter(2, 1)
    setattr(kf, name, value)


def _cfg(**kw):
    return TrackerCfg(**kw)


# ============================================================ Python API
# (id, thunk, expected exception type or OK, words the message must hold / what "ok" gives)
PY_ROWS = [
    # frames: None, wrong types, empty, thin, huge
    ("detect None frame", lambda: Detector().detect(None), TypeError, "frame"),
    ("detect list frame", lambda: Detector().detect([[1, 2], [3, 4]]), TypeError, "frame"),
    ("detect float32 frame", lambda: Detector().detect(U8.astype(np.float32)), TypeError, "uint8"),
    ("detect bool frame", lambda: Detector().detect(U8.astype(bool)), TypeError, "uint8"),
    ("detect 0x0 frame", lambda: Detector().detect(np.zeros((0, 0), np.uint8)), ValueError, "empty"),
    ("detect 2-channel frame", lambda: Detector().detect(np.zeros((8, 8, 2), np.uint8)), ValueError, "shape"),
    ("detect 4-D frame", lambda: Detector().detect(np.zeros((2, 8, 8, 3), np.uint8)), ValueError, "shape"),
    ("detect 5000x1 frame", lambda: Detector().detect(np.zeros((5000, 1), np.uint8)), OK, "no boxes"),
    ("detect 1x5000 frame", lambda: Detector().detect(np.zeros((1, 5000), np.uint8)), OK, "no boxes"),
    ("detect 1x1 frame", lambda: Detector().detect(np.zeros((1, 1), np.uint8)), OK, "no boxes"),
    ("detect 2500x3000 frame", lambda: Detector().detect(np.zeros((2500, 3000), np.uint8)), OK,
     "downscaled, warned"),
    ("track None frame", lambda: Tracker().step(None), TypeError, "frame"),
    ("track int16 frame", lambda: Tracker().step(U8.astype(np.int16)), TypeError, "uint8"),
    ("track 0x5 frame", lambda: Tracker().step(np.zeros((0, 5), np.uint8)), ValueError, "empty"),
    ("track 5000x1 frame", lambda: Tracker().step(np.zeros((5000, 1), np.uint8)), OK, "no tracks"),
    ("track 1x5000 frame", lambda: Tracker().step(np.zeros((1, 5000), np.uint8)), OK, "no tracks"),
    ("track 1x1 frame", lambda: Tracker().step(np.zeros((1, 1), np.uint8)), OK, "no tracks"),
    ("track 3000x2500 frame", lambda: Tracker().step(np.zeros((3000, 2500), np.uint8)), OK, "no tracks"),
    ("lanes 3x3 frame", lambda: LaneDetector().detect(np.zeros((3, 3), np.uint8)), ValueError, "too small"),
    ("lanes None frame", lambda: LaneDetector().detect(None), TypeError, "frame"),
    # detections
    ("track detections (N, 3)", lambda: Tracker().step(U8, detections=[[1, 2, 3]]), ValueError, "detections"),
    ("track detections NaN", lambda: Tracker().step(U8, detections=[[1, 2, np.nan, 4]]), ValueError,
     "detections"),
    ("track detections inf", lambda: Tracker().step(U8, detections=[[1, 2, np.inf, 4]]), ValueError,
     "detections"),
    ("track detections str", lambda: Tracker().step(U8, detections="1 2 3 4"), ValueError, "detections"),
    ("track detections bool", lambda: Tracker().step(U8, detections=np.ones((1, 4), bool)), ValueError,
     "detections"),
    ("track detections huge", lambda: Tracker().step(U8, detections=[[0, 0, 2**40, 5]]), ValueError,
     "out of range"),
    ("track detections float", lambda: [t.box for t in Tracker().step(U8, detections=[[10.4, 20.6, 60.5, 70.0]])]
     == [(10, 21, 60, 70)], OK, "documented: rounded to the nearest pixel (np.rint, halves to even)"),
    ("track detections inverted", lambda: Tracker().step(U8, detections=[[50, 50, 10, 10]]), VtError,
     "vt_tracker_step"),
    # numbers where integers go
    ("Tracker detect_every=1.5", lambda: Tracker(detect_every=1.5), ValueError, "detect_every"),
    ("Tracker detect_every=True", lambda: Tracker(detect_every=True), TypeError, "detect_every"),
    ("Tracker detect_every='10'", lambda: Tracker(detect_every="10"), TypeError, "detect_every"),
    ("Tracker detect_every=nan", lambda: Tracker(detect_every=float("nan")), ValueError, "detect_every"),
    ("Tracker detect_every=0", lambda: Tracker(detect_every=0), ValueError, "detect_every"),
    # the fused TTC's weight (vt_pipeline_cfg.ttc_fuse_permille, 0..1000)
    ("Pipeline fuse_permille=1001", lambda: vt.Pipeline(ttc_points={"fuse_permille": 1001}), ValueError,
     "fuse_permille"),
    ("Pipeline fuse_permille=0.3", lambda: vt.Pipeline(ttc_points={"fuse_permille": 0.3}), ValueError,
     "fuse_permille"),
    ("Pipeline fuse_permille=None", lambda: vt.Pipeline(ttc_points={"fuse_permille": None}), TypeError,
     "fuse_permille"),
    ("fuse_ttc weight -1", lambda: vt.camera.fuse_ttc(1.0, 2.0, -1), ValueError, "weight_permille"),
    # the warning on the fused TTC (vt_pipeline_cfg.fcw_fused, a bool)
    ("Pipeline fcw_fused=1", lambda: vt.Pipeline(ttc_points={"fcw_fused": 1}), TypeError, "fcw_fused"),
    ("Pipeline fcw_fused='yes'", lambda: vt.Pipeline(ttc_points={"fcw_fused": "yes"}), TypeError, "fcw_fused"),
    ("Tracker detect_every=-3", lambda: Tracker(detect_every=-3), ValueError, "detect_every"),
    ("Tracker detect_every=2.0", lambda: Tracker(detect_every=2.0), OK, "2 (an integer value)"),
    ("KalmanFilter(2.5, 1)", lambda: KalmanFilter(2.5, 1), ValueError, "dim_x"),
    ("KalmanFilter(2, 1.5)", lambda: KalmanFilter(2, 1.5), ValueError, "dim_z"),
    ("KalmanFilter(True, 1)", lambda: KalmanFilter(True, 1), TypeError, "dim_x"),
    ("KalmanFilter('2', 1)", lambda: KalmanFilter("2", 1), TypeError, "dim_x"),
    ("KalmanFilter(None, 1)", lambda: KalmanFilter(None, 1), TypeError, "dim_x"),
    ("KalmanFilter(0, 1)", lambda: KalmanFilter(0, 1), VtError, "vt_kf_init"),
    ("KalmanFilter(-1, 1)", lambda: KalmanFilter(-1, 1), VtError, "vt_kf_init"),
    ("KalmanFilter(99, 1)", lambda: KalmanFilter(99, 1), VtError, "vt_kf_init"),
    ("KalmanFilter(2**40, 1)", lambda: KalmanFilter(2**40, 1), ValueError, "dim_x"),
    # covariances and matrices
    ("kf.P = -1e9 I", lambda: _kf_with("P", -1e9 * np.eye(2)), ValueError, "positive semi-definite"),
    ("kf.P = -I", lambda: _kf_with("P", -np.eye(2)), ValueError, "P"),
    ("kf.P not symmetric", lambda: _kf_with("P", [[1.0, 0.5], [0.0, 1.0]]), ValueError, "symmetric"),
    ("kf.P indefinite", lambda: _kf_with("P", [[1.0, 2.0], [2.0, 1.0]]), ValueError, "semi-definite"),
    ("kf.Q = -I", lambda: _kf_with("Q", -np.eye(2)), ValueError, "Q"),
    ("kf.R = -1", lambda: _kf_with("R", [[-1.0]]), ValueError, "R"),
    ("kf.P NaN", lambda: _kf_with("P", np.full((2, 2), np.nan)), ValueError, "finite"),
    ("kf.P str", lambda: _kf_with("P", "eye"), TypeError, "P"),
    ("kf.P bool", lambda: _kf_with("P", np.eye(2, dtype=bool)), TypeError, "P"),
    ("kf.P wrong shape", lambda: _kf_with("P", np.eye(3)), ValueError, "shape"),
    ("kf.P over Q31.32", lambda: _kf_with("P", 3e9 * np.eye(2)), ValueError, "fixed-point range"),
    ("kf.F = diag(-4, 4)", lambda: _kf_with("F", np.diag([-4.0, 4.0])), OK, "F is no covariance"),
    ("kf.x inf", lambda: _kf_with("x", [np.inf, 0]), ValueError, "finite"),
    ("kf.update str", lambda: KalmanFilter(2, 1).update("1"), TypeError, "z"),
    ("kf.update NaN", lambda: KalmanFilter(2, 1).update([np.nan]), ValueError, "z"),
    ("kf.update 2 values", lambda: KalmanFilter(2, 1).update([1.0, 2.0]), ValueError, "z"),
    ("bottom_edge(nan, ..)", lambda: KalmanFilter.bottom_edge(np.nan, 0, 10), ValueError, "finite"),
    ("ModelConfig dt='1'", lambda: ModelConfig.default().replace(dt="1").to_c(), TypeError, "dt"),
    ("ModelConfig dt=True", lambda: ModelConfig.default().replace(dt=True).to_c(), TypeError, "dt"),
    ("ModelConfig dt=inf", lambda: ModelConfig.default().replace(dt=np.inf).to_c(), ValueError, "dt"),
    ("ModelConfig p_max=0.6", lambda: KalmanFilter.bottom_edge(0, 0, 9, ModelConfig.default().replace(p_max=0.6)),
     VtError, "vt_kf_init_bottom_edge"),
    # tracker config: errors at construction, naming the field
    ("TrackerCfg confirm_hits=0", lambda: Tracker(cfg=_cfg(confirm_hits=0)), ValueError, "confirm_hits"),
    ("TrackerCfg confirm_hits=0 (reference)", lambda: Tracker("reference", cfg=_cfg(confirm_hits=0)),
     ValueError, "confirm_hits"),
    ("TrackerCfg confirm_hits=2.5", lambda: Tracker(cfg=_cfg(confirm_hits=2.5)), ValueError, "confirm_hits"),
    ("TrackerCfg max_coast=True", lambda: Tracker(cfg=_cfg(max_coast=True)), TypeError, "max_coast"),
    ("TrackerCfg match_iou_permille=1001", lambda: Tracker(cfg=_cfg(match_iou_permille=1001)), ValueError,
     "match_iou_permille"),
    ("TrackerCfg gate_permille=-1", lambda: Tracker(cfg=_cfg(gate_permille=-1)), ValueError, "gate_permille"),
    ("TrackerCfg keep_ncc=nan", lambda: Tracker(cfg=_cfg(keep_ncc=float("nan"))), ValueError, "keep_ncc"),
    ("TrackerCfg keep_ncc=2", lambda: Tracker(cfg=_cfg(keep_ncc=2.0)), ValueError, "keep_ncc"),
    ("TrackerCfg model.dt=0", lambda: Tracker(cfg=_cfg(model=ModelCfg(dt=0.0))), ValueError, "dt"),
    ("TrackerCfg model.dt=-1", lambda: Tracker(cfg=_cfg(model=ModelCfg(dt=-1.0))), ValueError, "dt"),
    ("TrackerCfg model.p_max=0.6", lambda: Tracker(cfg=_cfg(model=ModelCfg(p_max=0.6))), ValueError, "p_max"),
    ("TrackerCfg search.h_thresh=0", lambda: Tracker(cfg=_cfg(search=_search(h_thresh=0))), ValueError,
     "h_thresh"),
    ("TrackerCfg search.polarity=7", lambda: Tracker(cfg=_cfg(search=_search(polarity=7))), ValueError,
     "polarity"),
    ("Tracker cfg=dict", lambda: Tracker(cfg={"confirm_hits": 3}), TypeError, "cfg"),
    # unknown enum values and wrong objects, at construction
    ("Tracker engine='gpu'", lambda: Tracker(engine="gpu"), ValueError, "engine"),
    ("Tracker engine=None", lambda: Tracker(engine=None), ValueError, "engine"),
    ("Tracker detector=123", lambda: Tracker(detector=123), TypeError, "detector"),
    ("Detector engine='gpu'", lambda: Detector(engine="gpu"), ValueError, "engine"),
    ("Detector road=123", lambda: Detector(road=123), TypeError, "road"),
    ("Detector road='lane'", lambda: Detector(road="lane"), ValueError, "road"),
    ("Detector road=None", lambda: Detector(road=None), TypeError, "road"),
    ("Detector cfg='x'", lambda: Detector(cfg="x"), TypeError, "cfg"),
    ("Detector fixed_road=5", lambda: Detector(fixed_road=5), TypeError, "fixed_road"),
    ("Detector lane_detector=5", lambda: Detector(lane_detector=5), TypeError, "lane_detector"),
    ("Detector shadow field 1.5", lambda: Detector(cfg=_detect_cfg(1.5)), ValueError, "ShadowConfig."),
    ("Detector shadow field True", lambda: Detector(cfg=_detect_cfg(True)), TypeError, "ShadowConfig."),
    ("LaneDetector engine='x'", lambda: LaneDetector(engine="x"), ValueError, "engine"),
    ("LaneDetector unknown field", lambda: LaneDetector(bogus=1), TypeError, "bogus"),
    ("LaneDetector grad_min=1.5", lambda: LaneDetector(grad_min=1.5), ValueError, "grad_min"),
    ("LaneDetector grad_min=True", lambda: LaneDetector(grad_min=True), TypeError, "grad_min"),
    ("LaneDetector grad_min=2**40", lambda: LaneDetector(grad_min=2**40), ValueError, "grad_min"),
    # image primitives
    ("sobel_x None", lambda: vt.image.sobel_x(None), TypeError, "ndarray"),
    ("sobel_x float32", lambda: vt.image.sobel_x(U8.astype(np.float32)), TypeError, "uint8"),
    ("sobel_x 3-D", lambda: vt.image.sobel_x(np.zeros((4, 4, 3), np.uint8)), ValueError, "2-D"),
    ("sobel_x over capacity", lambda: vt.image.sobel_x(np.zeros((4, int(lib.VT_MAX_WIDTH) + 1), np.uint8)),
     VtError, "vt_sobel_x"),
    ("box_sum x=1.5", lambda: vt.image.box_sum(vt.image.integral(U8), 1.5, 0, 2, 2), ValueError, "x"),
    ("box_sum w=True", lambda: vt.image.box_sum(vt.image.integral(U8), 0, 0, True, 2), TypeError, "w"),
    ("box_sum h=2**40", lambda: vt.image.box_sum(vt.image.integral(U8), 0, 0, 2, 2**40), ValueError, "h"),
    ("box_sum outside", lambda: vt.image.box_sum(vt.image.integral(U8), 120, 0, 20, 2), VtError, "vt_box_sum"),
    # the CNN detector (pyvehtrack.cnn; more rows in tests/test_cnn.py)
    ("cnn forward None", lambda: _cnn_mod().forward(_cnn(), None), TypeError, "gray"),
    ("cnn forward float32", lambda: _cnn_mod().forward(_cnn(), U8.astype(np.float32)), TypeError, "uint8"),
    ("cnn forward 0x4 frame", lambda: _cnn_mod().forward(_cnn(), np.zeros((0, 4), np.uint8)), ValueError, "empty"),
    ("cnn forward over capacity", lambda: _cnn_mod().forward(_cnn(), np.zeros((1, int(lib.VT_MAX_WIDTH) + 1),
                                                                               np.uint8)), VtError, "bad size"),
    ("cnn forward 1x1 frame", lambda: _cnn_mod().forward(_cnn(), np.zeros((1, 1), np.uint8)).shape == (1, 1, 5),
     OK, "one cell"),
    ("cnn decode int16 out", lambda: _cnn_mod().decode(_cnn(), np.zeros((2, 2, 5), np.int16)), TypeError, "int8"),
    ("cnn decode cap=0", lambda: _cnn_mod().decode(_cnn(), np.zeros((2, 2, 5), np.int8), cap=0), ValueError, "cap"),
    ("cnn decode scale_shift=9", lambda: _cnn_mod().decode(_cnn(), np.zeros((2, 2, 5), np.int8), scale_shift=9),
     ValueError, "scale_shift"),
    ("cnn load missing key", lambda: _cnn_mod().CnnModel.load({"cnn_n_layers": 1}), ValueError, "cnn_l0_meta"),
    ("cnn detect_frame None", lambda: _cnn_mod().detect_frame(_cnn(), None), TypeError, "gray"),
    ("cnn detect_frame float32", lambda: _cnn_mod().detect_frame(_cnn(), U8.astype(np.float32)), TypeError, "uint8"),
    ("cnn detect_frame over capacity", lambda: _cnn_mod().detect_frame(_cnn(), np.zeros((1, int(lib.VT_MAX_WIDTH) + 1),
                                                                                        np.uint8)), VtError, "bad size"),
    ("cnn detect_frame cfg dict", lambda: _cnn_mod().detect_frame(_cnn(), U8, {"n_levels": 1}), TypeError, "CnnConfig"),
    ("cnn detect_frame n_levels=0", lambda: _cnn_mod().detect_frame(_cnn(), U8, _cnn_mod().CnnConfig(n_levels=0)),
     ValueError, "n_levels"),
    ("cnn detect_frame cap_per_level=1.5", lambda: _cnn_mod().CnnConfig(cap_per_level=1.5).c(), ValueError,
     "cap_per_level"),
    ("cnn heat_scale_q16=0", lambda: _cnn_mod().CnnModel(_cnn().layers, np.zeros((4, 256), np.uint16), heat_scale_q16=0),
     ValueError, "cnn_heat_scale_q16"),
    ("cnn load missing heat scale", lambda: _cnn_mod().CnnModel.load({k: v for k, v in _cnn().keys().items()
                                                                      if k != "cnn_heat_scale_q16"}),
     ValueError, "cnn_heat_scale_q16"),
    ("ncc shape mismatch", lambda: vt.image.ncc(U8[:4, :4], U8[:4, :5]), VtError, "vt_ncc_u8"),
    ("sad str", lambda: vt.image.sad("a", U8), TypeError, "a"),
    # evaluation inputs
    ("iou_matrix 5 numbers", lambda: vt_eval_iou([1, 2, 3, 4, 5]), ValueError, "boxes"),
    ("read_kitti missing file", lambda: _read_kitti("no/such/file.txt"), FileNotFoundError, "file.txt"),
    ("read_kitti short line", lambda: _read_kitti_text("0 1 Car\n"), ValueError, ":1:"),
    ("read_kitti bad number", lambda: _read_kitti_text("0 x Car 0 0 0 1 2 3 4\n"), ValueError, ":1:"),
    ("evaluate preproc='x'", lambda: _evaluate(preproc="x"), ValueError, "preproc"),
]


def _cnn_mod():
    from pyvehtrack import cnn
    return cnn


def _cnn():
    """A one-layer 1x1 CNN model (5 output channels)."""
    i8 = lambda v: np.array(v, np.int8)   # noqa: E731
    layer = dict(ksize=1, stride=1, dilation=1, relu=0, cin=1, cout=5, w=i8([1, -1, 2, 0, 3]).reshape(5, 1, 1, 1),
                 bias=np.zeros(5, np.int32), mult=np.ones(5, np.int32), shift=np.ones(5, np.uint8))
    return _cnn_mod().CnnModel([layer], np.zeros((4, 256), np.uint16))


def _cnn_call(f):
    """f(the one-layer model's C struct), the model kept alive over the call (its arrays are
    what the struct points at)."""
    model = _cnn()
    return f(model.c_model()[0])


def _cnn_c(**kw):
    """vt_cnn_forward on a 4x4 image with the one-layer model; kw: NULL pointers, sizes."""
    model = _cnn()
    m = model.c_model()[0]   # model holds the arrays m points at: keep it alive over the call
    img = np.zeros((4, 4), np.uint8)
    out = ffi.new("int8_t[80]")
    px = ffi.NULL if kw.get("img") is None and "img" in kw else ffi.cast("uint8_t *", img.ctypes.data)
    return lib.vt_cnn_forward(ffi.NULL if "model" in kw else m, px, kw.get("w", 4), kw.get("h", 4),
                              kw.get("stride", 4), ffi.NULL, 0, ffi.NULL if "out" in kw else out,
                              kw.get("out_len", 80))


def _cnn_frame_c(**kw):
    """vt_cnn_detect_frame on a 4x4 image with the one-layer model and the default cfg; kw:
    NULL pointers, sizes, the work buffer `short` bytes below vt_cnn_frame_work_bytes."""
    model = _cnn()
    m = model.c_model()[0]   # model holds the arrays m points at: keep it alive over the call
    cfg = _cnn_mod().CnnConfig().c()
    img = np.zeros((4, 4), np.uint8)
    nb = _cnn_mod().frame_work_bytes(_cnn(), 4, 4)
    work = np.zeros(nb, np.uint8)
    boxes = ffi.new("vt_cnn_box[4]")
    n, t = ffi.new("int32_t *"), ffi.new("int32_t *")
    nul = lambda k, v: ffi.NULL if k in kw and kw[k] is None else v   # noqa: E731
    return lib.vt_cnn_detect_frame(nul("model", m), nul("cfg", cfg), nul("img", ffi.cast("uint8_t *", img.ctypes.data)),
                                   kw.get("w", 4), kw.get("h", 4), kw.get("stride", 4),
                                   nul("work", ffi.cast("uint8_t *", work.ctypes.data)), nb - kw.get("short", 0),
                                   nul("boxes", boxes), kw.get("cap", 4), n, t)


def _search(**kw):
    from pyvehtrack.reference.track_search import SearchCfg
    return SearchCfg(**kw)


def _detect_cfg(value):
    from dataclasses import fields, replace
    name = fields(ShadowConfig)[0].name
    return DetectConfig(shadow=replace(ShadowConfig(), **{name: value}))


def vt_eval_iou(boxes):
    from pyvehtrack.eval.boxes import iou_matrix
    return iou_matrix(boxes, [[0, 0, 1, 1]])


def _read_kitti(path):
    from pyvehtrack.eval.kitti import read_kitti
    return read_kitti(path)


_TMP = {}


def _read_kitti_text(text):
    p = _TMP["dir"] / "labels.txt"
    p.write_text(text)
    return _read_kitti(p)


def _evaluate(**kw):
    pytest.importorskip("trackeval")
    from pyvehtrack.eval.tracking import evaluate_kitti
    return evaluate_kitti([[(1, 0, 0, 10, 10)]], [[(1, 0, 0, 10, 10)]], **kw)


@pytest.mark.parametrize("row", PY_ROWS, ids=[r[0] for r in PY_ROWS])
def test_python_api(row, tmp_path, recwarn):
    _TMP["dir"] = tmp_path
    name, thunk, expected, words = row
    if expected is OK:
        out = thunk()
        if isinstance(out, bool):               # the row checks its own documented result
            assert out, name
        elif isinstance(out, list):             # Tracker.step: no vehicle in a blank frame
            assert out == []
        elif hasattr(out, "boxes"):              # Detector.detect on a blank frame
            assert len(out.boxes) == 0
        return
    with pytest.raises(expected) as e:
        thunk()
    assert words in str(e.value), (name, str(e.value))


def test_fractional_detect_every_is_not_coerced():
    """The issue's example: detect_every=1.5 used to run as 1."""
    with pytest.raises(ValueError, match="detect_every"):
        Tracker(detect_every=1.5)
    assert Tracker(detect_every=2.0).detect_every == 2


# ============================================================ C through cffi
def _tracker_step(tr=True, cfg=True, img=True, n_dets=0, dets=False, out=True, cap=None):
    t = ffi.new("vt_tracker *")
    lib.vt_tracker_init(t)
    c = ffi.new("vt_tracker_cfg *")
    lib.vt_tracker_cfg_default(c)
    buf = np.zeros((16, 16), np.uint8)
    im = ffi.new("vt_image_u8 *", {"px": ffi.cast("uint8_t *", buf.ctypes.data), "w": 16, "h": 16,
                                    "stride": 16})
    o = ffi.new("vt_track_out[4]")
    n = ffi.new("int32_t *")
    return lib.vt_tracker_step(t if tr else ffi.NULL, c if cfg else ffi.NULL, im if img else ffi.NULL, 1,
                               ffi.new("vt_box[1]") if dets else ffi.NULL, n_dets, o if out else ffi.NULL,
                               4 if cap is None else cap, n)


def _pipe_cfg_check(**fields):
    cfg = vt._native.pipeline_cfg_default()
    for k, v in fields.items():
        setattr(cfg, k, v)
    return lib.vt_pipeline_cfg_check(cfg)


C_ROWS = [
    ("vt_tracker_init(NULL)", lambda: lib.vt_tracker_init(ffi.NULL), "VT_E_ARG"),
    ("vt_tracker_step NULL tracker", lambda: _tracker_step(tr=False), "VT_E_ARG"),
    ("vt_tracker_step NULL cfg", lambda: _tracker_step(cfg=False), "VT_E_ARG"),
    ("vt_tracker_step NULL image", lambda: _tracker_step(img=False), "VT_E_ARG"),
    ("vt_tracker_step NULL out", lambda: _tracker_step(out=False), "VT_E_ARG"),
    ("vt_tracker_step n_dets=1, dets NULL", lambda: _tracker_step(n_dets=1), "VT_E_ARG"),
    ("vt_tracker_step n_dets=-1", lambda: _tracker_step(n_dets=-1, dets=True), "VT_E_SIZE"),
    ("vt_tracker_step cap=-1", lambda: _tracker_step(cap=-1), "VT_E_ARG"),
    ("vt_ttc_fuse NULL out", lambda: lib.vt_ttc_fuse(65536, 65536, 300, ffi.NULL), "VT_E_ARG"),
    ("vt_ttc_fuse weight 1001", lambda: lib.vt_ttc_fuse(65536, 65536, 1001, ffi.new("vt_q16 *")), "VT_E_ARG"),
    ("vt_pipeline_cfg_check fcw_fused=2", lambda: _pipe_cfg_check(fcw_fused=2), "VT_E_ARG"),
    ("vt_kf_init(NULL)", lambda: lib.vt_kf_init(ffi.NULL, 2, 1), "VT_E_ARG"),
    ("vt_kf_init dim_x=0", lambda: lib.vt_kf_init(ffi.new("vt_kf *"), 0, 1), "VT_E_SIZE"),
    ("vt_kf_predict(NULL)", lambda: lib.vt_kf_predict(ffi.NULL), "VT_E_ARG"),
    ("vt_kf_update NULL z", lambda: lib.vt_kf_update(_kf_c(), ffi.NULL), "VT_E_ARG"),
    ("vt_cnn_forward ok", lambda: _cnn_c(), "VT_OK"),
    ("vt_cnn_forward NULL model", lambda: _cnn_c(model=None), "VT_E_ARG"),
    ("vt_cnn_forward NULL image", lambda: _cnn_c(img=None), "VT_E_ARG"),
    ("vt_cnn_forward NULL out", lambda: _cnn_c(out=None), "VT_E_ARG"),
    ("vt_cnn_forward w=0", lambda: _cnn_c(w=0), "VT_E_SIZE"),
    ("vt_cnn_forward stride < w", lambda: _cnn_c(stride=3), "VT_E_SIZE"),
    ("vt_cnn_forward out one short", lambda: _cnn_c(out_len=79), "VT_E_CAPACITY"),
    ("vt_cnn_check_model(NULL)", lambda: lib.vt_cnn_check_model(ffi.NULL), "VT_E_ARG"),
    ("vt_cnn_cfg_check(NULL)", lambda: lib.vt_cnn_cfg_check(ffi.NULL), "VT_E_ARG"),
    ("vt_cnn_cfg_default(NULL)", lambda: lib.vt_cnn_cfg_default(ffi.NULL), "VT_E_ARG"),
    ("vt_cnn_detect_frame ok", lambda: _cnn_frame_c(), "VT_OK"),
    ("vt_cnn_detect_frame NULL model", lambda: _cnn_frame_c(model=None), "VT_E_ARG"),
    ("vt_cnn_detect_frame NULL cfg", lambda: _cnn_frame_c(cfg=None), "VT_E_ARG"),
    ("vt_cnn_detect_frame NULL image", lambda: _cnn_frame_c(img=None), "VT_E_ARG"),
    ("vt_cnn_detect_frame NULL work", lambda: _cnn_frame_c(work=None), "VT_E_ARG"),
    ("vt_cnn_detect_frame NULL boxes", lambda: _cnn_frame_c(boxes=None), "VT_E_ARG"),
    ("vt_cnn_detect_frame cap=0", lambda: _cnn_frame_c(cap=0), "VT_E_ARG"),
    ("vt_cnn_detect_frame w=0", lambda: _cnn_frame_c(w=0), "VT_E_SIZE"),
    ("vt_cnn_detect_frame stride < w", lambda: _cnn_frame_c(stride=3), "VT_E_SIZE"),
    ("vt_cnn_detect_frame over VT_MAX_WIDTH", lambda: _cnn_frame_c(w=int(lib.VT_MAX_WIDTH) + 1,
                                                                   stride=int(lib.VT_MAX_WIDTH) + 1), "VT_E_SIZE"),
    ("vt_cnn_detect_frame work one short", lambda: _cnn_frame_c(short=1), "VT_E_CAPACITY"),
    ("vt_cnn_frame_work_bytes NULL bytes", lambda: _cnn_call(lambda m: lib.vt_cnn_frame_work_bytes(
        m, _cnn_mod().CnnConfig().c(), 4, 4, ffi.NULL)), "VT_E_ARG"),
    ("vt_pipeline_set_cnn NULL pipeline", lambda: lib.vt_pipeline_set_cnn(ffi.NULL, ffi.NULL, ffi.NULL, ffi.NULL, 0),
     "VT_E_ARG"),
]


def _kf_c():
    kf = ffi.new("vt_kf *")
    lib.vt_kf_init(kf, 2, 1)
    return kf


@pytest.mark.parametrize("row", C_ROWS, ids=[r[0] for r in C_ROWS])
def test_c_entry(row):
    name, thunk, status = row
    got = thunk()
    assert got == getattr(lib, status), (name, got, vt._native.status_name(got))


# ============================================================ CLI
def _frames(d: Path, n: int = 3) -> Path:
    d.mkdir(parents=True, exist_ok=True)
    img = cv2.imread(str(GOOD), cv2.IMREAD_GRAYSCALE)
    for k in range(n):
        cv2.imwrite(str(d / f"{k:06d}.png"), np.roll(img, 2 * k, axis=1))
    return d


def _truncate(src: Path, dst: Path, frac: float = 1 / 3) -> Path:
    data = src.read_bytes()
    dst.write_bytes(data[: int(len(data) * frac)])
    return dst


def _flip_byte(src: Path, dst: Path) -> Path:
    """A copy with one byte in the middle of the compressed data inverted."""
    data = bytearray(src.read_bytes())
    data[len(data) // 2] ^= 0xFF
    dst.write_bytes(bytes(data))
    return dst


def _jpeg(tmp: Path) -> Path:
    p = tmp / "frame.jpg"
    cv2.imwrite(str(p), cv2.imread(str(GOOD)))
    return p


def _video(tmp: Path, name="in.avi", n=6) -> Path:
    p = tmp / name
    w = cv2.VideoWriter(str(p), cv2.VideoWriter_fourcc(*"MJPG"), 10, (320, 96))
    if not w.isOpened():
        pytest.skip("no MJPG writer in this OpenCV build")
    img = cv2.imread(str(GOOD))
    for k in range(n):
        w.write(np.roll(img, k, axis=1))
    w.release()
    return p


def _corrupt_mid_folder(tmp: Path) -> Path:
    d = _frames(tmp / "frames", 4)
    _truncate(d / "000002.png", d / "000002.png", 0.4)
    return d


def _not_a_folder(tmp: Path) -> str:
    (tmp / "file.txt").write_text("x")
    return str(tmp / "file.txt" / "out.json")


def _garbage(tmp: Path, name: str, data: bytes = b"\x00\x01 not an image at all" * 10) -> Path:
    p = tmp / name
    p.write_bytes(data)
    return p


# (id, argv builder(tmp) -> list[str], words the one error line must hold)
CLI_ERRORS = [
    ("no command", lambda t: [], "required"),
    ("unknown command", lambda t: ["fly"], "invalid choice"),
    ("unknown option", lambda t: ["detect", str(GOOD), "--out", str(t / "o.png"), "--fast"], "unrecognized"),
    ("detect missing file", lambda t: ["detect", str(t / "missing.png"), "--out", str(t / "o.png")],
     "no such file"),
    ("detect empty file", lambda t: ["detect", str(_garbage(t, "e.png", b"")), "--out", str(t / "o.png")],
     "empty file"),
    ("detect garbage bytes", lambda t: ["detect", str(_garbage(t, "g.png")), "--out", str(t / "o.png")],
     "cannot read"),
    ("detect JPEG truncated to a third", lambda t: ["detect", str(_truncate(_jpeg(t), t / "t.jpg")),
                                                    "--out", str(t / "o.png")], "truncated"),
    ("detect PNG truncated to a third", lambda t: ["detect", str(_truncate(GOOD, t / "t.png")),
                                                   "--out", str(t / "o.png")], "truncated"),
    ("detect PNG with a flipped byte", lambda t: ["detect", str(_flip_byte(GOOD, t / "f.png")),
                                                  "--out", str(t / "o.png")], "corrupt"),
    ("detect corrupt frame mid-folder", lambda t: ["detect", str(_corrupt_mid_folder(t)), "--out",
                                                   str(t / "o.avi"), "--json", str(t / "o.json")], "000002.png"),
    ("track corrupt frame mid-folder", lambda t: ["track", str(_corrupt_mid_folder(t)), "--out",
                                                  str(t / "o.avi"), "--tracks", str(t / "o.txt")], "000002.png"),
    ("detect empty folder", lambda t: ["detect", str((t / "empty").mkdir() or t / "empty"), "--out",
                                       str(t / "o.png")], "no image files"),
    ("detect empty video file", lambda t: ["detect", str(_garbage(t, "e.mp4", b"")), "--out",
                                           str(t / "o.png")], "cannot open"),
    ("detect garbage video", lambda t: ["detect", str(_garbage(t, "g.avi")), "--out", str(t / "o.png")],
     "cannot open"),
    ("detect truncated video", lambda t: ["detect", str(_truncate(_video(t), t / "t.avi", 0.5)), "--out",
                                          str(t / "o.png")], "t.avi"),
    ("detect no --out, no --json", lambda t: ["detect", str(GOOD)], "--json"),
    ("detect --out .txt", lambda t: ["detect", str(GOOD), "--out", str(t / "o.txt")], "expected a .png"),
    ("detect --out in missing folder", lambda t: ["detect", str(GOOD), "--out", str(t / "no" / "o.png")],
     "does not exist"),
    ("detect --out is a folder", lambda t: ["detect", str(GOOD), "--out", str((t / "d.png").mkdir() or
                                                                            t / "d.png")], "is a folder"),
    ("detect --json under a file", lambda t: ["detect", str(GOOD), "--json", _not_a_folder(t)], "--json"),
    ("detect --engine gpu", lambda t: ["detect", str(GOOD), "--json", str(t / "o.json"), "--engine", "gpu"],
     "invalid choice"),
    ("detect --road 5", lambda t: ["detect", str(GOOD), "--json", str(t / "o.json"), "--road", "5"],
     "invalid choice"),
    ("track --detect-every 0", lambda t: ["track", str(GOOD), "--out", str(t / "o.avi"), "--detect-every", "0"],
     "must be >= 1"),
    ("track --detect-every 1.5", lambda t: ["track", str(GOOD), "--out", str(t / "o.avi"),
                                            "--detect-every", "1.5"], "invalid int value"),
    ("track --detect-every x", lambda t: ["track", str(GOOD), "--out", str(t / "o.avi"),
                                          "--detect-every", "x"], "invalid int value"),
    ("track no --out", lambda t: ["track", str(GOOD)], "--out"),
    ("track --tracks under a file", lambda t: ["track", str(GOOD), "--out", str(t / "o.avi"), "--tracks",
                                               _not_a_folder(t)], "--tracks"),
    ("track --tracks is a folder", lambda t: ["track", str(GOOD), "--out", str(t / "o.avi"), "--tracks",
                                              str(t)], "is a folder"),
    ("track --out in missing folder", lambda t: ["track", str(GOOD), "--out", str(t / "no" / "o.mp4")],
     "does not exist"),
    ("detect --json same as --out", lambda t: ["detect", str(GOOD), "--out", str(t / "o.png"), "--json",
                                               str(t / "o.png")], "same file"),
    ("track --tracks same as --out", lambda t: ["track", str(GOOD), "--out", str(t / "o.avi"), "--tracks",
                                                str(t / "o.avi")], "same file"),
    ("eval missing gt", lambda t: ["eval", "--gt", str(t / "gt.txt"), "--tracks", str(GOOD)], "no such file"),
    ("eval corrupt gt", lambda t: ["eval", "--gt", str(_garbage(t, "gt.txt", b"0 1 Car\n")), "--tracks",
                                   str(_garbage(t, "tr.txt", b""))], ":1:"),
    ("eval binary gt", lambda t: ["eval", "--gt", str(_garbage(t, "gt.txt", b"\xff\xfe\x00\x81" * 20)),
                                  "--tracks", str(_garbage(t, "tr.txt", b""))], "gt.txt"),
    ("eval --num-frames 0", lambda t: ["eval", "--gt", str(_garbage(t, "gt.txt", b"")), "--tracks",
                                       str(_garbage(t, "tr.txt", b"")), "--num-frames", "0"], "--num-frames"),
    ("eval --json under a file", lambda t: ["eval", "--gt", str(_garbage(t, "gt.txt", b"")), "--tracks",
                                            str(_garbage(t, "tr.txt", b"")), "--json", _not_a_folder(t)],
     "--json"),
]


def _screen_lines(text: str) -> list:
    """The lines a terminal shows for `text`: a progress bar redrawn with carriage returns
    and erased at the end leaves nothing, so only what follows the last \\r of a line counts."""
    return [ln.split("\r")[-1].strip() for ln in text.split("\n") if ln.split("\r")[-1].strip()]


def _outputs_left(tmp: Path, before: set) -> list:
    """Files the run created (temporary names included)."""
    return sorted(str(p.relative_to(tmp)) for p in tmp.rglob("*") if p.is_file() and p not in before)


@pytest.mark.parametrize("row", CLI_ERRORS, ids=[r[0] for r in CLI_ERRORS])
def test_cli_error(row, tmp_path, capsys, monkeypatch):
    name, build, words = row
    if "trackeval" in name or name.startswith("eval"):
        pytest.importorskip("trackeval")
    monkeypatch.chdir(tmp_path)
    argv = build(tmp_path)
    before = {p for p in tmp_path.rglob("*")}
    rc = cli_main(argv)
    err = _screen_lines(capsys.readouterr().err)
    assert rc == 2, (name, rc, err)
    assert len(err) == 1 and words in err[0] and "Traceback" not in err[0], (name, err)
    assert _outputs_left(tmp_path, before) == [], name


def test_unwritable_output_found_before_the_run(tmp_path, capsys, monkeypatch):
    """--tracks / --json that cannot be written stop the run before its first frame."""
    import pyvehtrack.detector
    import pyvehtrack.tracker

    def boom(*a, **k):
        raise AssertionError("a frame was processed before the outputs were checked")
    monkeypatch.setattr(pyvehtrack.detector.Detector, "detect", boom)
    monkeypatch.setattr(pyvehtrack.tracker.Tracker, "step", boom)
    d = _frames(tmp_path / "f", 2)
    bad = _not_a_folder(tmp_path)
    for argv in (["track", str(d), "--out", str(tmp_path / "o.avi"), "--tracks", bad],
                 ["detect", str(d), "--out", str(tmp_path / "o.avi"), "--json", bad],
                 ["detect", str(d), "--json", str(tmp_path / "o.json"), "--out", str(tmp_path / "x" / "o.avi")]):
        assert cli_main(argv + ["--no-progress"]) == 2
        assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not (tmp_path / "o.avi").exists() and not (tmp_path / "o.json").exists()


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_folder(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        assert cli_main(["detect", str(GOOD), "--json", str(ro / "o.json")]) == 2
        assert "--json" in capsys.readouterr().err
    finally:
        ro.chmod(0o700)


# ---------------------------------------------------------------- documented behaviours
def test_skip_bad_frames_counts_and_says(tmp_path, capsys):
    d = _corrupt_mid_folder(tmp_path)
    js, tr = tmp_path / "o.json", tmp_path / "o.txt"
    assert cli_main(["detect", str(d), "--json", str(js), "--skip-bad-frames", "--no-progress"]) == 0
    cap = capsys.readouterr()
    assert "1 bad frame(s) skipped" in cap.out and "000002.png" in cap.err
    entries = json.loads(js.read_text())
    assert [e["frame"] for e in entries] == [0, 1, 3]       # input-order numbers kept
    assert cli_main(["track", str(d), "--out", str(tmp_path / "o.avi"), "--tracks", str(tr),
                     "--skip-bad-frames", "--no-progress"]) == 0
    assert "1 bad frame(s) skipped" in capsys.readouterr().out
    cap = cv2.VideoCapture(str(tmp_path / "o.avi"))
    n = 0
    while cap.read()[0]:
        n += 1
    assert n == 3                                             # the bad frame is not drawn
    # every frame bad: each skip is announced, then one error line, exit 2, nothing written
    bad = _truncate(GOOD, tmp_path / "t.png")
    assert cli_main(["detect", str(bad), "--json", str(tmp_path / "x.json"), "--skip-bad-frames"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "skipping" in err[0] and "no frame could be decoded" in err[1], err
    assert not (tmp_path / "x.json").exists()


def test_jpeg_with_a_flipped_byte_is_read(tmp_path, capsys):
    """Documented limit: JPEG has no checksum, so a byte flipped inside the compressed data
    decodes to a damaged picture that no reader can tell from a real one; the run goes on.
    (A flipped byte in a PNG fails its CRC: the row 'detect PNG with a flipped byte'.)"""
    bad = _flip_byte(_jpeg(tmp_path), tmp_path / "f.jpg")
    rc = cli_main(["detect", str(bad), "--json", str(tmp_path / "o.json")])
    err = _screen_lines(capsys.readouterr().err)
    # 0 with this encoder's bytes; should a flip land on a marker elsewhere, the decoder may
    # refuse it, and then it must be the one-line error
    assert rc == 0 or (rc == 2 and len(err) == 1 and "f.jpg" in err[0]), (rc, err)


def test_detect_json_without_out(tmp_path, capsys):
    js = tmp_path / "o.json"
    assert cli_main(["detect", str(GOOD), "--json", str(js)]) == 0
    assert len(json.loads(js.read_text())) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.json"]   # nothing drawn
    assert "json: " in capsys.readouterr().out


def test_track_thin_png(tmp_path, capsys):
    """The issue's 1x5000 PNG: a clean run with no track (formerly a raw cv2.error)."""
    p = tmp_path / "thin.png"
    cv2.imwrite(str(p), np.zeros((1, 5000), np.uint8))
    tr = tmp_path / "t.txt"
    assert cli_main(["track", str(p), "--out", str(tmp_path / "o.png"), "--tracks", str(tr), "--no-progress"]) == 0
    assert tr.read_text() == ""
    assert cli_main(["detect", str(p), "--json", str(tmp_path / "d.json")]) == 0
    capsys.readouterr()


def test_huge_frame_cli(tmp_path, capsys):
    """A frame over the core's maximum is downscaled (documented), boxes in input pixels."""
    img = cv2.resize(cv2.imread(str(GOOD)), (2400, 720), interpolation=cv2.INTER_LINEAR)
    p = tmp_path / "big.png"
    cv2.imwrite(str(p), img)
    js = tmp_path / "o.json"
    assert cli_main(["detect", str(p), "--json", str(js)]) == 0
    for b in json.loads(js.read_text())[0]["boxes"]:
        assert 0 <= b[0] <= b[2] < 2400 and 0 <= b[1] <= b[3] < 720
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pyvehtrack detect: warning: frame 2400x720"), err


def test_existing_output_replaced_only_on_success(tmp_path, capsys):
    """A failed run leaves an existing output as it was (written to a temporary name first)."""
    js = tmp_path / "o.json"
    js.write_text("previous")
    bad = _truncate(GOOD, tmp_path / "t.png")
    assert cli_main(["detect", str(GOOD), str(bad), "--json", str(js), "--no-progress"]) == 2
    assert js.read_text() == "previous"
    assert cli_main(["detect", str(GOOD), "--json", str(js), "--no-progress"]) == 0
    assert json.loads(js.read_text())[0]["file"] == str(GOOD)
    capsys.readouterr()


def _every_command():
    from pyvehtrack.cli import SUBCOMMANDS
    return [[name, "--help"] for name in SUBCOMMANDS]


# every registered command, so a command added later without an example fails here
@pytest.mark.parametrize("argv", [["--version"], ["--help"], *_every_command()])
def test_help_has_examples_and_version(argv, capsys):
    assert cli_main(argv) == 0
    out = capsys.readouterr().out
    if argv == ["--version"]:
        assert out.strip() == f"pyvehtrack {vt.__version__}"
    else:
        assert "examples:" in out and "pyvehtrack " in out.split("examples:")[1]


def test_python_dash_m(tmp_path):
    import subprocess
    import sys
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parent.parent))
    r = subprocess.run([sys.executable, "-m", "pyvehtrack", "--version"], capture_output=True, text=True,
                       env=env, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == f"pyvehtrack {vt.__version__}", r.stderr
    r = subprocess.run([sys.executable, "-m", "pyvehtrack", "detect", str(tmp_path / "none.png"),
                        "--json", str(tmp_path / "o.json")], capture_output=True, text=True, env=env, timeout=60)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_table_size(capsys):
    n = len(PY_ROWS) + len(C_ROWS) + len(CLI_ERRORS)
    with capsys.disabled():
        print(f"\nbad-input table: {len(PY_ROWS)} Python API rows, {len(C_ROWS)} C rows, "
              f"{len(CLI_ERRORS)} CLI rows = {n}")
    assert n >= 100
