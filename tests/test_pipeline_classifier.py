"""The classifier source of vt_pipeline_step (the whole-road detector, c/fulldet.c,
plugged into c/pipeline.c) against reference.pipeline end to end, and against the
Python-orchestrated full-road path it replaces.

Tolerances, from the arithmetic:
- With one shared classifier (a Python score function, called from C through a
  vt_window_scorer and directly by the oracle) the whole-road detector is an exact twin
  (tests/test_fulldet.py: boxes, scores, sources and counters EQUAL); the camera road's
  rows are integer rounding of the same Q16 fractions in both (half up); the tracker is
  an integer-exact twin (tests/test_pipeline.py). So with road="fixed" (no lanes: the
  horizon is the configured fraction) hypotheses, boxes, scores, sources, track ids,
  states and boxes must be EQUAL, velocities within 0.05 px/frame (Kalman Q16 vs float64).
- With road="auto" the horizon is the lane stage's vanishing row (vp_y, a working
  row, mapped to input rows): C's lane stage and the oracle's agree to about 1 px
  (tests/test_lane.py), so the horizon may differ by a row; on sequences where it never differs everything is EQUAL
  as above, otherwise only the ids/states are compared up to the first difference.
- With the real HOG model the C engine scores sliding windows from a prepared band
  (vt_hog_scorer_level) and the reference engine scores each window alone (the same C
  classifier, no band): their HOG differs at window borders, so only the shadow-source
  scores (a shadow box's window is scored alone in both) are compared exactly.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack.fullroad import DEFAULT_WINDOW_MODEL
from pyvehtrack import synth
from pyvehtrack._native import ffi, lib
from pyvehtrack.pipeline import Pipeline

DATA = Path(__file__).parent / "data"
MODEL = DATA / "window_svm_hog32.npz"
MLP = DEFAULT_WINDOW_MODEL
FRAME = DATA / "udacity_test1_640x360.jpg"
CLIP = DATA / "kitti_clip"
MAXW, MAXH = int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)


def mean_score(img, level, s, x, y) -> int:
    """A stand-in classifier (as tests/test_fulldet.py): mean brightness of the window
    minus 100 plus a fixed pseudo-random part, so that both signs occur and ties are rare."""
    win = img[y:y + s, x:x + s].astype(np.int64)
    return int(win.sum() // (s * s)) - 100 + ((x * 7 + y * 13 + level * 5 + s) % 11)


def _compare(ra, rb, where, exact=True):
    assert ra.frame == rb.frame and ra.detection_frame == rb.detection_frame, where
    assert ra.road_source == rb.road_source, where
    if ra.detection_frame:
        assert ra.stats.get("horizon_y") == rb.stats.get("horizon_y"), where
    assert [(t.id, t.state, t.source) for t in ra.tracks] == [(t.id, t.state, t.source) for t in rb.tracks], where
    if not exact:
        return
    assert np.array_equal(ra.road, rb.road), where
    assert np.array_equal(ra.hypotheses, rb.hypotheses), where
    assert [(b.box, b.source, b.score) for b in ra.boxes] == [(b.box, b.source, b.score) for b in rb.boxes], where
    if ra.detection_frame:
        assert {k: v for k, v in ra.stats.items()} == {k: v for k, v in rb.stats.items()}, where
    for a, b in zip(ra.tracks, rb.tracks):
        assert a.box == b.box, where
        assert abs(a.velocity[0] - b.velocity[0]) <= 0.05 and abs(a.velocity[1] - b.velocity[1]) <= 0.05, where


@settings(max_examples=8, deadline=None)
@given(scenario=st.sampled_from(sorted(synth.SCENARIOS)), seed=st.integers(0, 999),
       w=st.integers(64, 256), h=st.integers(48, 192), n=st.integers(2, 6),
       detect_every=st.integers(1, 3),
       sources=st.sampled_from([("shadow",), ("classifier",), ("shadow", "classifier")]))
def test_c_matches_reference_on_synthetic_sequences(scenario, seed, w, h, n, detect_every, sources):
    seq = synth.make_sequence(scenario, seed=seed, camera=synth.Camera(w, h), n_frames=n)
    kw = dict(detect_every=detect_every, road="fixed", sources=sources, model=mean_score)
    a, b = Pipeline("c", **kw), Pipeline("reference", **kw)
    for f in range(n):
        ra, rb = a.step(seq.frames[f]), b.step(seq.frames[f])
        _compare(ra, rb, f"{scenario} {seed} {w}x{h} {sources} frame {f}")
        assert all(x.source in sources and x.score is not None for x in ra.boxes)


def _clip():
    return [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted(CLIP.glob("*.png"))]


@pytest.mark.parametrize("road", ["auto", "fixed"])
def test_c_matches_reference_on_kitti_clip(road):
    """The real clip, tracking, classifier windows and classified shadows, every 2nd frame."""
    frames = _clip()[:10]
    kw = dict(detect_every=2, road=road, sources=("shadow", "classifier"), model=mean_score)
    a, b = Pipeline("c", **kw), Pipeline("reference", **kw)
    exact, n_boxes = True, 0
    for i, f in enumerate(frames):
        ra, rb = a.step(f), b.step(f)
        if ra.detection_frame and ra.stats["horizon_y"] != rb.stats["horizon_y"]:
            assert road == "auto" and abs(ra.stats["horizon_y"] - rb.stats["horizon_y"]) <= 1, i
            exact = False
        if not exact:
            break
        _compare(ra, rb, f"kitti {road} frame {i}")
        assert ra.road_source == ("camera" if ra.detection_frame else ("lanes" if road == "auto" and
                                                                       ra.lanes is not None else "none"))
        n_boxes += len(ra.boxes)
    assert n_boxes > 0
    if road == "fixed":
        assert exact


@pytest.mark.skipif(MAXW < 640 or MAXH < 360, reason="needs a build that takes 640x360 frames")
@pytest.mark.parametrize("sources", [("shadow",), ("shadow", "classifier")])
def test_real_model_equals_the_stand_alone_stage(sources):
    """Pipeline(model=...) gives exactly what the stand-alone stage (FullRoadDetector, the
    Python-orchestrated path before the pipeline had the source) gives on the same frame,
    road camera and horizon: boxes, scores and sources."""
    from pyvehtrack import fullroad
    gray = cv2.cvtColor(cv2.imread(str(FRAME)), cv2.COLOR_BGR2GRAY)
    pipe = Pipeline(model=str(MODEL), sources=sources, road="fixed", detect_every=1, track=False)
    res = pipe.step(gray)
    srcs = tuple({"shadow": "shadow", "classifier": "windows"}[s] for s in sources)
    det = fullroad.FullRoadDetector(str(MODEL), sources=srcs)
    old = det.detect_gray(gray)
    assert res.stats["horizon_y"] == det.camera_for(*gray.shape).horizon_y
    assert res.box_array.tolist() == old[:, :4].astype(int).tolist()
    assert [b.score for b in res.boxes] == old[:, 4].tolist()
    assert [b.source for b in res.boxes] == [{1: "shadow", 2: "classifier"}[int(s)] for s in old[:, 5]]
    assert len(res.boxes) >= 2
    # the shadow-only path: the reference engine scores a shadow box's window alone, as C
    if sources == ("shadow",):
        ref = Pipeline("reference", model=str(MODEL), sources=sources, road="fixed", detect_every=1,
                       track=False).step(gray)
        _compare(res, ref, "udacity shadow")


@pytest.mark.skipif(MAXW < 640 or MAXH < 360, reason="needs a build that takes 640x360 frames")
def test_mlp_model_and_default_model():
    """An MLP model goes through the caller's scorer slot (vt_mlp_scorer); the built-in
    model through the pipeline's own HOG scorer."""
    from pyvehtrack import fullroad
    gray = cv2.cvtColor(cv2.imread(str(FRAME)), cv2.COLOR_BGR2GRAY)
    res = Pipeline(model=str(MLP), road="fixed", detect_every=1, track=False).step(gray)
    old = fullroad.FullRoadDetector(str(MLP), sources=("shadow",)).detect_gray(gray)
    assert res.box_array.tolist() == old[:, :4].astype(int).tolist()
    if fullroad.default_model() is not None:
        res = Pipeline(model="default", road="fixed", detect_every=1, track=False).step(gray)
        old = fullroad.FullRoadDetector(None, sources=("shadow",)).detect_gray(gray)
        assert res.box_array.tolist() == old[:, :4].astype(int).tolist()


def _c_pipe(sources=lib.VT_SRC_SHADOW | lib.VT_SRC_CLASSIFIER, model=ffi.NULL):
    c = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(c) == lib.VT_OK
    c.sources = sources
    p = ffi.new("vt_pipeline *")
    assert lib.vt_pipeline_init(p, c, ffi.NULL, model) == lib.VT_OK
    return p


def _frame(w=96, h=64):
    a = np.random.default_rng(1).integers(0, 255, (h, w), dtype=np.uint8)
    img = ffi.new("vt_image_u8 *")
    img.w, img.h, img.stride = w, h, w
    buf = ffi.from_buffer("uint8_t[]", a)
    img.px = buf
    return img, buf


def test_cls_ws_arguments_and_refusals():
    """A classifier asked for without its workspace is refused before any stage runs
    (nothing changes); the attach call checks its arguments."""
    ws = ffi.new("vt_pipe_cls_ws *")
    out = ffi.new("vt_frame_out *")
    img, _keep = _frame()
    # the classifier source without a classifier: every step refused, frame 0 stays
    p = _c_pipe()
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_E_ARG and p.frame == 0
    # attach: NULL pipeline; a scorer without score(); a scorer without workspace;
    # no scorer and no model (the HOG scorer needs the model given at init)
    empty = ffi.new("vt_window_scorer *")
    assert lib.vt_pipeline_set_cls_ws(ffi.NULL, ws, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_pipeline_set_cls_ws(p, ws, empty) == lib.VT_E_ARG
    assert lib.vt_pipeline_set_cls_ws(p, ffi.NULL, empty) == lib.VT_E_ARG
    assert lib.vt_pipeline_set_cls_ws(p, ws, ffi.NULL) == lib.VT_E_ARG
    assert p.cls_ws == ffi.NULL
    # a model at init and no workspace: refused too
    from pyvehtrack import fullroad
    m, keep = fullroad._c_model(fullroad.load_model(MODEL))
    p = _c_pipe(lib.VT_SRC_SHADOW, m)
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_E_ARG and p.frame == 0
    assert lib.vt_pipeline_set_cls_ws(p, ws, ffi.NULL) == lib.VT_OK
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_OK and p.frame == 1
    # detaching makes it refuse again; re-init detaches
    assert lib.vt_pipeline_set_cls_ws(p, ffi.NULL, ffi.NULL) == lib.VT_OK
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_E_ARG and p.frame == 1
    assert lib.vt_pipeline_set_cls_ws(p, ws, ffi.NULL) == lib.VT_OK
    assert lib.vt_pipeline_init(p, ffi.addressof(p, "cfg"), ffi.NULL, m) == lib.VT_OK
    assert p.cls_ws == ffi.NULL and p.frame == 0


def test_frame_out_guard_bytes_with_the_classifier():
    """vt_pipeline_step with the whole-road detector writes nothing outside vt_frame_out."""
    from pyvehtrack import fullroad
    m, keep = fullroad._c_model(fullroad.load_model(MODEL))
    p = _c_pipe(lib.VT_SRC_SHADOW | lib.VT_SRC_CLASSIFIER, m)
    ws = ffi.new("vt_pipe_cls_ws *")
    assert lib.vt_pipeline_set_cls_ws(p, ws, ffi.NULL) == lib.VT_OK
    n, g = ffi.sizeof("vt_frame_out"), 64
    raw = ffi.new("uint8_t[]", n + 2 * g)
    ffi.memmove(raw, b"\xa5" * (n + 2 * g), n + 2 * g)
    out = ffi.cast("vt_frame_out *", raw + g)
    gray = cv2.cvtColor(cv2.imread(str(FRAME)), cv2.COLOR_BGR2GRAY)
    gray = np.ascontiguousarray(gray[: min(360, MAXH), : min(640, MAXW)])
    img = ffi.new("vt_image_u8 *")
    img.w, img.h, img.stride = gray.shape[1], gray.shape[0], gray.shape[1]
    buf = ffi.from_buffer("uint8_t[]", gray)
    img.px = buf
    assert lib.vt_pipeline_step(p, img, out) in (lib.VT_OK, lib.VT_E_CAPACITY)
    b = bytes(ffi.buffer(raw, n + 2 * g))
    assert b[:g] == b"\xa5" * g and b[g + n:] == b"\xa5" * g
    assert 0 <= out.n_boxes <= int(lib.VT_MAX_BOXES) and out.road_source == lib.VT_ROAD_SRC_CAMERA
    assert all(out.boxes[i].source in (lib.VT_SRC_SHADOW, lib.VT_SRC_CLASSIFIER) for i in range(out.n_boxes))


def test_python_classifier_arguments():
    with pytest.raises(ValueError, match="classifier"):
        Pipeline(sources=("classifier",))
    with pytest.raises(ValueError, match="road_camera"):
        Pipeline(fullroad=object())
    with pytest.raises(TypeError, match="road_camera"):
        Pipeline(model=mean_score, road_camera=object())
    with pytest.raises(TypeError, match="fullroad"):
        Pipeline(model=mean_score, fullroad=object())
    with pytest.raises(ValueError, match="model"):
        Pipeline(model=str(DATA / "README.md"))


def test_tracker_with_a_model_runs_the_classifier_source():
    """`track --model` (Tracker with a full-road Detector) is one pipeline step per frame
    with the classifier source: the same tracks as Pipeline(model=...), and each track
    says which source started it (before, the Tracker's pipeline ran the ego-lane
    detector and the model was not used)."""
    from pyvehtrack.detector import Detector
    from pyvehtrack.tracker import Tracker
    frames = _clip()[:8]
    trk = Tracker(detect_every=2, detector=Detector(model=str(MODEL), sources=("shadow", "windows")))
    pipe = Pipeline(model=str(MODEL), sources=("shadow", "classifier"), detect_every=2)
    seen = set()
    for i, f in enumerate(frames):
        old, new = trk.step(f), pipe.step(f).tracks
        assert [(t.id, t.state, t.box, t.source) for t in old] == [(t.id, t.state, t.box, t.source) for t in new], i
        seen |= {t.source for t in new}
    assert seen and seen <= {"shadow", "classifier"}


@pytest.mark.skipif(MAXW < 640 or MAXH < 360, reason="needs a build that takes 640x360 frames")
def test_second_stage_inside_the_pipeline():
    """cfg.verify: the built-in HOG 64x64 MLP re-scores each whole-road box inside
    vt_pipeline_step (vt_fulldet_verify), as the stand-alone stage does; the reference
    engine applies reference.fulldet.verify_boxes with the same (C) box classifier, so
    the shadow-only run is exact. A threshold no box reaches leaves no box, and none at
    all (-inf) leaves the first stage's boxes: the stage is really applied."""
    from pyvehtrack import fullroad
    gray = cv2.cvtColor(cv2.imread(str(FRAME)), cv2.COLOR_BGR2GRAY)

    def run(vmin, engine="c"):
        cfg = fullroad.FullRoadConfig(verify_min=vmin)
        return Pipeline(engine, model=str(MLP), sources=("shadow",), road="fixed", detect_every=1,
                        track=False, fullroad=cfg).step(gray)

    first = Pipeline(model=str(MLP), sources=("shadow",), road="fixed", detect_every=1, track=False,
                     fullroad=fullroad.FullRoadConfig(verify_min=-30000.0)).step(gray)
    assert len(first.boxes) >= 1
    none = run(30000.0)
    assert none.boxes == []
    for vmin in (0.0, 4.0):
        res = run(vmin)
        alone = fullroad.FullRoadDetector(str(MLP), sources=("shadow",),
                                          cfg=fullroad.FullRoadConfig(verify_min=vmin)).detect_gray(gray)
        assert res.box_array.tolist() == alone[:, :4].astype(int).tolist()
        assert [b.score for b in res.boxes] == alone[:, 4].tolist()
        _compare(res, run(vmin, "reference"), f"udacity shadow, second stage >= {vmin}")
        kept = {tuple(b.box) for b in res.boxes}
        assert kept <= {tuple(b.box) for b in first.boxes}
    cfg = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(cfg) == lib.VT_OK
    assert cfg.verify == 0
    for v, want in ((2, lib.VT_OK), (3, lib.VT_OK), (4, lib.VT_OK), (5, lib.VT_E_ARG), (-1, lib.VT_E_ARG)):   # 2-4: skips
        cfg.verify = v
        assert lib.vt_pipeline_cfg_check(cfg) == want, v
