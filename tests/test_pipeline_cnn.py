"""The CNN detector in the pipeline (vt_pipeline_set_cnn; pyvehtrack.Pipeline(model=CnnModel or a
cnn_* .npz)): on a detection frame its boxes replace the whole-road windows, as classifier
boxes scored heat x heat_scale_q16 (Q16 logit), with no second stage, regression or wide pass.

Tolerance: exact. The pipeline copies vt_cnn_detect_frame's boxes (the first VT_MAX_BOXES) into
the detector's result, so its classifier boxes equal pyvehtrack.cnn.detect_frame's, box for box
and in order; the reference engine runs the bit-exact twin in the same place, so it agrees too.
Bad arguments to vt_pipeline_set_cnn are refused with nothing changed; a work buffer too small
for a frame is VT_E_CAPACITY from the step.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import Pipeline
from pyvehtrack import cnn as C
from pyvehtrack._native import ffi, lib
from pyvehtrack.config import TrackerConfig
from test_cnn import random_model

MAX_BOXES = int(lib.VT_MAX_BOXES)


def scene(w=320, h=180, seed=0):
    """A road ramp with a few dark car-like blocks below the horizon."""
    rng = np.random.default_rng(seed)
    img = np.tile(np.linspace(120, 200, h).astype(np.uint8)[:, None], (1, w))
    img[: h // 3] = 210
    for _ in range(5):
        x0, y0 = int(rng.integers(0, w - 30)), int(rng.integers(h // 2, h - 20))
        img[y0:y0 + int(rng.integers(10, 30)), x0:x0 + int(rng.integers(15, 50))] = int(rng.integers(10, 70))
    return img + rng.integers(0, 6, (h, w)).astype(np.uint8)


def tiny_model(seed=1, scale=3 * 65536):
    rng = np.random.default_rng(seed)
    img = scene(seed=seed)
    m = random_model(rng, [(3, 2, 1, 4), (3, 2, 1, 6), (3, 2, 1, 6), (1, 1, 1, 5)], img, 60.0,
                     rng.integers(0, 500, (4, 256)))
    return C.CnnModel(m.layers, m.side_lut, m.heat_thr, heat_scale_q16=scale)


CFG = C.CnnConfig(first_level=0, n_levels=3, thr_offset=-30, cap_per_level=16)


def _expected(model, gray, cfg=CFG):
    b, _ = C.detect_frame(model, gray, cfg)
    return [((int(r[0]), int(r[1]), int(r[2]), int(r[3])), "classifier", int(r[4]) * model.heat_scale_q16 / 65536)
            for r in b[:MAX_BOXES]]


def _got(res):
    return [(b.box, b.source, b.score) for b in res.boxes]


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_pipeline_boxes_are_detect_frame_boxes(engine):
    m = tiny_model()
    gray = scene()
    want = _expected(m, gray)
    assert len(want) >= 3, "the drawn model finds too little to compare"
    pipe = Pipeline(engine, model=m, cnn_cfg=CFG, sources=("classifier",), road="fixed", detect_every=1,
                    track=False, cnn_hood_min_width_mm=0)     # the hood rule off: every box (next test)
    for _ in range(2):
        res = pipe.step(gray)
        assert res.detection_frame and res.road_source == "camera"
        assert _got(res) == want
        assert len(res.hypotheses) == 0    # no shadow hypotheses beside the CNN
    if engine == "c":
        assert res.stats["n_cand"] == C.detect_frame(m, gray, CFG)[1] and res.stats["n_windows"] == 0


@pytest.mark.parametrize("min_mm", [600, 300, 2000])
def test_cnn_boxes_on_the_hood_are_dropped(min_mm):
    """vt_pipeline_cfg.cnn_hood_min_width_mm: of detect_frame's boxes, exactly those whose
    bottom b is below the hood row (b > hood_y), that are more than w // 64 px from both sides
    and narrower than min_mm at the row's flat-road distance ((r - l + 1) height_mm <
    min_mm (b - horizon_y)) are gone; the rest keep their order. The arithmetic is written
    out here (integers, no tolerance), and C and the oracle agree."""
    m = tiny_model()
    gray = scene()
    h, w = gray.shape
    want_all = _expected(m, gray)
    hood_y = max(1, (h * 60948 + 32768) // 65536)    # VT_ROAD_CAMERA_DEFAULT's hood_q16, half up
    got = {}
    for engine in ("c", "reference"):
        pipe = Pipeline(engine, model=m, cnn_cfg=CFG, sources=("classifier",), road="fixed", detect_every=1,
                        track=False, cnn_hood_min_width_mm=min_mm)
        res = pipe.step(gray)
        hy = res.stats["horizon_y"]
        keep = [b for b in want_all
                if not (b[0][3] > hood_y and b[0][0] > w // 64 and b[0][2] < w - 1 - w // 64
                        and (b[0][2] - b[0][0] + 1) * 1800 < min_mm * (b[0][3] - hy))]
        assert _got(res) == keep, engine
        got[engine] = keep
    assert got["c"] == got["reference"]
    # not vacuous: the drawn scene has small boxes on its last rows, and a box the frame's
    # side cuts down there stays
    assert len(got["c"]) < len(want_all)
    low = [b for b in want_all if b[0][3] > hood_y]
    assert any(b in got["c"] for b in low) or min_mm == 2000


def test_cnn_hood_rule_bad_values():
    with pytest.raises(ValueError, match="cnn_hood_min_width_mm"):
        Pipeline("c", cnn_hood_min_width_mm=-1)
    with pytest.raises(ValueError, match="cnn_hood_min_width_mm"):
        Pipeline("c", cnn_hood_min_width_mm=10001)
    with pytest.raises(ValueError, match="cnn_hood_min_width_mm"):
        Pipeline("c", cnn_hood_min_width_mm=0.5)
    with pytest.raises(TypeError, match="cnn_hood_min_width_mm"):
        Pipeline("c", cnn_hood_min_width_mm="600")
    with pytest.raises(ValueError, match="cnn_ego_iou_permille"):
        Pipeline("c", cnn_ego_iou_permille=1001)
    with pytest.raises(ValueError, match="cnn_ego_iou_permille"):
        Pipeline("c", cnn_ego_iou_permille=-1)
    with pytest.raises(TypeError, match="cnn_ego_iou_permille"):
        Pipeline("c", cnn_ego_iou_permille="500")
    c = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(c) == lib.VT_OK and c.cnn_hood_min_width_mm == 600
    for bad in (-1, 10001):
        c.cnn_hood_min_width_mm = bad
        assert lib.vt_pipeline_cfg_check(c) == lib.VT_E_ARG
    c.cnn_hood_min_width_mm = 600
    assert c.cnn_ego_iou_permille == 302 and lib.vt_pipeline_cfg_check(c) == lib.VT_OK
    for bad in (-1, 1001):
        c.cnn_ego_iou_permille = bad
        assert lib.vt_pipeline_cfg_check(c) == lib.VT_E_ARG


def test_pipeline_from_a_cnn_file_and_second_stage_skipped(tmp_path):
    """A cnn_* .npz path is a CNN model; the second stage (verify_min) and the shadow source
    leave the CNN's boxes as they are (no verification, no shadow boxes)."""
    from pyvehtrack.fullroad import FullRoadConfig
    m = tiny_model(2)
    m.save(tmp_path / "cnn.npz")
    gray = scene(seed=2)
    want = _expected(m, gray, C.CnnConfig(thr_offset=-30))
    assert want
    pipe = Pipeline(model=str(tmp_path / "cnn.npz"), cnn_cfg=C.CnnConfig(thr_offset=-30),
                    sources=("shadow", "classifier"), fullroad=FullRoadConfig(verify_min=50.0), road="fixed",
                    detect_every=1, track=False)
    assert isinstance(pipe.model, C.CnnModel) and int(pipe._ccfg.verify) != 0
    assert _got(pipe.step(gray)) == want


def test_pipeline_ego_boxes_beside_the_cnn():
    """With the ego-lane detector, its boxes come first (source "ego"); the CNN's boxes that no
    ego box suppresses follow in detect_frame's order."""
    m = tiny_model(3)
    gray = scene(seed=3)
    want = _expected(m, gray)
    res = Pipeline(model=m, cnn_cfg=CFG, sources=("ego", "classifier"), road="fixed", detect_every=1,
                   track=False).step(gray)
    cls = [g for g in _got(res) if g[1] == "classifier"]
    assert all(b.source in ("ego", "classifier") for b in res.boxes)
    it = iter(want)
    assert all(any(g == w for w in it) for g in cls), "classifier boxes not a subsequence of detect_frame's"
    assert [b.source for b in res.boxes] == sorted((b.source for b in res.boxes), key=lambda s: s != "ego")


def _ego_iou_expected(m, base, want, limit):
    """cnn_ego_iou_permille's outcome worked out from the limit-0 run `base` and detect_frame's
    boxes `want`: each CNN box belongs to the first ego box the detector's NMS test pairs it with;
    an ego box is reported with the box of its own of the highest IoU (exact Fractions, the first of
    equals) when that IoU is >= limit / 1000. Also: the list of each ego box's IoUs (its own boxes)."""
    from fractions import Fraction

    from pyvehtrack.reference import windows as rw
    fd = Pipeline("c", model=m, cnn_cfg=CFG)._ccfg.fulldet   # the limits the merge uses
    iou, contain = int(fd.nms_iou_permille), int(fd.nms_contain_permille)
    ego = [g[0] for g in base if g[1] == "ego"]
    owner = [next((j for j, e in enumerate(ego) if rw.suppresses(e, w, iou, contain)), None) for w in want]
    expect, ious_of = list(base), []
    for j, e in enumerate(ego):
        dropped = [w for w, o in zip(want, owner) if o == j]
        ious = [Fraction(*rw._iou_parts(e, d)[:2]) for d in dropped]
        ious_of.append(ious)
        if ious and max(ious) * 1000 >= limit:
            expect[j] = (dropped[ious.index(max(ious))], "ego", base[j][2])
    return expect, ious_of


@pytest.mark.parametrize("seed,pair_iou", [(3, 0.122), (10, 0.172)])
@pytest.mark.parametrize("limit", [302, 150, 100, 1])
def test_pipeline_cnn_ego_iou(seed, pair_iou, limit):
    """vt_pipeline_cfg.cnn_ego_iou_permille: the merge is the limit-0 one (the ego boxes first,
    each dropping the CNN boxes the detector's NMS test pairs with it), but an ego box is reported
    with the box of the CNN boxes it dropped that overlaps it most (the first of equals) when that
    IoU is >= limit / 1000; its source and score stay. Exact, C = reference, against the lists
    worked out from detect_frame and windows.suppresses. The seeds are scenes where one of the two
    ego boxes drops one CNN box, at IoU pair_iou (asserted): 302 keeps the ego box's geometry, 150
    replaces it in the second scene only, 100 and 1 in both. The tracker's input is the ego box
    either way: three tracked steps give the same tracks as limit 0 (cnn_track_top off: the reported
    tops are test_pipeline_cnn_track_top's)."""
    m = tiny_model(seed)
    gray = scene(seed=seed)
    want = [w[0] for w in _expected(m, gray)]
    got, tracks = {}, {}
    for engine in ("c", "reference"):
        for lim in (0, limit):
            kw = dict(model=m, cnn_cfg=CFG, sources=("ego", "classifier"), road="fixed", detect_every=1,
                      cnn_hood_min_width_mm=0, cnn_ego_iou_permille=lim, cnn_track_top=False)
            got[engine, lim] = _got(Pipeline(engine, track=False, **kw).step(gray))
            pipe = Pipeline(engine, **kw)
            tracks[engine, lim] = [[(t.id, t.box) for t in pipe.step(gray).tracks] for _ in range(3)]
    assert got["c", limit] == got["reference", limit] and got["c", 0] == got["reference", 0]
    assert tracks["c", limit] == tracks["c", 0] == tracks["reference", limit] and tracks["c", 0][-1]
    expect, ious_of = _ego_iou_expected(m, got["c", 0], want, limit)
    assert sorted(len(v) for v in ious_of) == [0, 1]   # two ego boxes, one drops one CNN box
    assert float(max(max(v) for v in ious_of if v)) == pytest.approx(pair_iou, abs=5e-4)
    assert got["c", limit] == expect
    assert (got["c", limit] != got["c", 0]) == (pair_iou * 1000 >= limit)


@pytest.mark.parametrize("seed,limit", [(19, 302), (67, 100)])
def test_pipeline_cnn_ego_iou_best_of_several(seed, limit):
    """cnn_ego_iou_permille where one ego box drops several CNN boxes: it is reported with the one
    of the highest IoU with it (exact Fractions), the first in detect_frame's order among equals.
    Seed 19: three dropped boxes at IoU 0.276 / 0.447 / 0.503; seed 67: two (0.102 each at three
    decimals) and another ego box with three under 0.05 (kept as it is at 100). C = reference."""
    m = tiny_model(seed)
    gray = scene(seed=seed)
    want = [w[0] for w in _expected(m, gray)]
    kw = dict(model=m, cnn_cfg=CFG, sources=("ego", "classifier"), road="fixed", detect_every=1, track=False,
              cnn_hood_min_width_mm=0)
    base = _got(Pipeline("c", cnn_ego_iou_permille=0, **kw).step(gray))
    got = _got(Pipeline("c", cnn_ego_iou_permille=limit, **kw).step(gray))
    assert got == _got(Pipeline("reference", cnn_ego_iou_permille=limit, **kw).step(gray))
    expect, ious_of = _ego_iou_expected(m, base, want, limit)
    assert any(len(v) >= 2 for v in ious_of) and got == expect and got != base


def approach(gray, n=4):
    """n frames of a scene coming nearer: frame k is gray with 2k rows and 3k columns cut from
    each side, resized back (OpenCV bilinear), so boxes grow about 2% a frame."""
    import cv2
    h, w = gray.shape
    return [cv2.resize(gray[2 * k:h - 2 * k, 3 * k:w - 3 * k], (w, h), interpolation=cv2.INTER_LINEAR)
            for k in range(n)]


def _track_top_expected(base_boxes, rep_boxes, tracks_off, match_iou, rounding=True, best=True, clear=True):
    """cnn_track_top's tracks worked out from the same steps with it off (tracks_off: per frame
    [(id, state, box)], the tracker's boxes), the ego boxes as the tracker gets them (base_boxes:
    per frame, the limit-0 run's reported boxes) and the boxes reported with the limit on
    (rep_boxes; None: not a detection frame). On a detection frame each ego box e goes to the track
    of the highest IoU with it, >= match_iou / 1000 (exact, the first of equals; a later box wins):
    reported with another box r, it gives that track the height q = max(1, round half up
    256 (bottom - r.top + 1) / width) of the track's own box; reported as it is, it clears it.
    Heights are kept by id; a track with one is shown with top = bottom - max(1, (w q + 128) // 256)
    + 1. rounding / best / clear False: q rounded down / the first track over the bar / an ego box
    reported as it is leaves the height (the near misses)."""
    from fractions import Fraction

    from pyvehtrack.reference import windows as rw
    q, out = {}, []
    for base, rep, tracks in zip(base_boxes, rep_boxes, tracks_off):
        q = {t[0]: q[t[0]] for t in tracks if t[0] in q}
        pairs = [] if rep is None else [(b[0], r[0][1] if r[0] != b[0] else None)
                                        for b, r in zip(base, rep) if b[1] == "ego"]
        for e, top in pairs:
            ious = [Fraction(*rw._iou_parts(e, t[2])[:2]) for t in tracks]
            ok = [i for i, v in enumerate(ious) if v * 1000 >= match_iou]
            if not ok:
                continue
            k = max(ok, key=lambda i: (ious[i], -i)) if best else ok[0]
            l, _t, r, b = tracks[k][2]
            if top is None and not clear:
                continue
            q[tracks[k][0]] = 0 if top is None else \
                max(1, ((b - top + 1) * 256 + ((r - l + 1) // 2 if rounding else 0)) // (r - l + 1))
        shown = []
        for tid, st, (l, tp, r, b) in tracks:
            if q.get(tid, 0) > 0:
                tp = b - max(1, ((r - l + 1) * q[tid] + 128) // 256) + 1
            shown.append((tid, st, (l, tp, r, b)))
        out.append(shown)
    return out


@pytest.mark.parametrize("seed,limit,match_iou,tells", [(19, 302, 300, ""), (16, 302, 300, ""),
                                                        (4, 302, 300, "rounding"), (23, 302, 300, "clear"),
                                                        (56, 302, 10, "best")])
def test_pipeline_cnn_track_top(seed, limit, match_iou, tells):
    """vt_pipeline_cfg.cnn_track_top on a scene coming nearer (approach: four frames, detection on 0
    and 2): the tracker is untouched (ids, states, left, right and bottom equal to the run with it
    off), and a track an ego box reported with a CNN box goes to is shown with that box's top, as a
    height in its own widths kept by id over the frame without detection, and cleared by an ego
    box reported as it is. Exact, C = reference, against the tracks worked out from the run with
    it off (_track_top_expected). On frame 0 one ego box is reported with a CNN box (asserted). Each
    of the last three scenes tells the rule from one near miss, and only from it (asserted): q
    rounded down (the width changes after it is taken), an ego box reported as it is leaving the
    height (frame 2), the first track over a low association bar instead of the best. With the
    smallest build's one track slot the moved track may have no slot: there only C = reference =
    worked out is checked."""
    m = tiny_model(seed)
    frames = approach(scene(seed=seed))
    kw = dict(model=m, cnn_cfg=CFG, sources=("ego", "classifier"), road="fixed", detect_every=2,
              cnn_hood_min_width_mm=0, tracker=TrackerConfig(match_iou_permille=match_iou))

    def run(engine, lim, top):
        pipe = Pipeline(engine, cnn_ego_iou_permille=lim, cnn_track_top=top, **kw)
        res = [pipe.step(g) for g in frames]
        return ([[(b.box, b.source) for b in r.boxes] if r.detection_frame else None for r in res],
                [[(t.id, t.state, t.box) for t in r.tracks] for r in res], pipe)
    base, _, _ = run("c", 0, False)
    rep, off, pipe = run("c", limit, False)
    _, on, _ = run("c", limit, True)
    assert on == run("reference", limit, True)[1]
    assert sum(b[1] == "ego" and b[0] != r[0] for b, r in zip(base[0], rep[0])) == 1
    assert [f is not None for f in rep] == [True, False, True, False]
    assert [[(i, s, (b[0], b[2], b[3])) for i, s, b in f] for f in on] == \
        [[(i, s, (b[0], b[2], b[3])) for i, s, b in f] for f in off]
    mi = int(pipe._ccfg.tracker.match_iou_permille)
    want = _track_top_expected(base, rep, off, mi)
    assert on == want
    if int(lib.VT_MAX_TRACKS) >= 8:
        assert on[0] != off[0] and on[1] != off[1]   # frame 1 (no detection) keeps frame 0's heights
        for near in ("rounding", "best", "clear"):
            assert (_track_top_expected(base, rep, off, mi, **{near: False}) != want) == (tells == near), near


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10**6), limit=st.sampled_from([1, 100, 302, 600]),
       match_iou=st.sampled_from([1, 10, 300]), every=st.integers(1, 3))
def test_pipeline_cnn_track_top_c_matches_reference(seed, limit, match_iou, every):
    """cnn_track_top on random scenes coming nearer (approach), limits, association bars and
    detection intervals: C's tracks (id, state, box) equal the reference pipeline's over five
    steps, exactly (integer rules on both sides), and the tracker is untouched (the same steps with
    it off differ in tops only). About half of such examples move a top (13 of 25 drawn when
    written)."""
    m = tiny_model(seed)
    frames = approach(scene(seed=seed), 5)
    kw = dict(model=m, cnn_cfg=CFG, sources=("ego", "classifier"), road="fixed", detect_every=every,
              cnn_hood_min_width_mm=0, cnn_ego_iou_permille=limit, tracker=TrackerConfig(match_iou_permille=match_iou))
    got = {}
    for engine, top in (("c", True), ("reference", True), ("c", False)):
        pipe = Pipeline(engine, cnn_track_top=top, **kw)
        got[engine, top] = [[(t.id, t.state, t.box) for t in pipe.step(g).tracks] for g in frames]
    assert got["c", True] == got["reference", True]
    assert [[(i, s, (b[0], b[2], b[3])) for i, s, b in f] for f in got["c", True]] == \
        [[(i, s, (b[0], b[2], b[3])) for i, s, b in f] for f in got["c", False]]


def test_pipeline_cnn_track_top_bad_values():
    from pyvehtrack.report.records import PythonPipeline
    from pyvehtrack.tracker import Tracker
    m = tiny_model()
    for bad in (2, "yes", None):
        with pytest.raises(TypeError, match="cnn_track_top"):
            Pipeline(model=m, cnn_cfg=CFG, cnn_track_top=bad)
        if bad is not None:   # Tracker's None: the pipeline's default
            with pytest.raises(TypeError, match="cnn_track_top"):
                Tracker(cnn_track_top=bad)
    with pytest.raises(ValueError, match="box_top"):
        PythonPipeline(box_top="square")
    cfg = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(cfg) == lib.VT_OK and cfg.cnn_track_top == 1
    for bad in (-1, 2, 1 << 30):
        cfg.cnn_track_top = bad
        assert lib.vt_pipeline_cfg_check(cfg) == lib.VT_E_ARG
    cfg.cnn_track_top = 0
    assert lib.vt_pipeline_cfg_check(cfg) == lib.VT_OK


def test_pipeline_tracks_cnn_boxes_and_grows_its_work():
    """Tracking on: the CNN's boxes reach the tracker (tracks start from source "classifier");
    a larger frame after a smaller one grows the work buffer (re-attached), the boxes stay
    detect_frame's."""
    m = tiny_model(4)
    pipe = Pipeline(model=m, cnn_cfg=CFG, sources=("classifier",), road="fixed", detect_every=1,
                    cnn_hood_min_width_mm=0)
    small, big = scene(160, 90, 4), scene(320, 180, 4)
    res = pipe.step(small)
    n0 = pipe._cnn_work.size
    assert _got(res) == _expected(m, small)
    pipe.reset()
    for _ in range(3):
        res = pipe.step(big)
        assert _got(res) == _expected(m, big)
    assert pipe._cnn_work.size > n0
    assert res.tracks and all(t.source == "classifier" for t in res.tracks)


def test_pipeline_cnn_python_bad_inputs(tmp_path):
    m = tiny_model()
    with pytest.raises(TypeError, match="cnn_cfg"):
        Pipeline(model=m, cnn_cfg={"n_levels": 2})
    with pytest.raises(ValueError, match="n_levels"):
        Pipeline(model=m, cnn_cfg=C.CnnConfig(n_levels=0))
    with pytest.raises(ValueError, match="cnn_cfg"):
        Pipeline(cnn_cfg=C.CnnConfig())
    k = m.keys()
    k.pop("cnn_heat_scale_q16")
    np.savez(tmp_path / "old.npz", **k)
    with pytest.raises(ValueError, match="cnn_heat_scale_q16"):
        Pipeline(model=str(tmp_path / "old.npz"))


# ---------------------------------------------------------------- the C entry point
def _c_pipeline(horizon_q16=None):
    """A C pipeline for the CNN source alone (fixed road, no tracker); horizon_q16: its road
    camera's horizon (default: the default camera's)."""
    p = ffi.new("vt_pipeline *")
    pc = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(pc) == lib.VT_OK
    pc.sources = lib.VT_SRC_CLASSIFIER
    pc.road_policy = lib.VT_ROAD_FIXED
    pc.track = 0
    pc.detect_every = 1
    pc.cnn_hood_min_width_mm = 0     # every box of detect_frame's (the hood rule: its own test)
    if horizon_q16 is not None:
        pc.road_camera.horizon_q16 = horizon_q16
    assert lib.vt_pipeline_init(p, pc, ffi.NULL, ffi.NULL) == lib.VT_OK
    return p


def test_set_cnn_rows():
    m = tiny_model()
    cm = m.c_model()[0]
    cfg = C.CnnConfig().c()
    work = np.zeros(64, np.uint8)
    pw = ffi.cast("uint8_t *", work.ctypes.data)
    p = _c_pipeline()
    ws = ffi.new("vt_pipe_cls_ws *")
    # no classifier yet: the workspace without a scorer is refused; with the CNN set it is not
    assert lib.vt_pipeline_set_cls_ws(p, ws, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_pipeline_set_cnn(p, cm, cfg, pw, work.size) == lib.VT_OK
    assert p.cnn == cm and p.cnn_work == pw and p.cnn_work_bytes == 64 and p.cnn_cfg.n_levels == cfg.n_levels
    assert lib.vt_pipeline_set_cls_ws(p, ws, ffi.NULL) == lib.VT_OK
    bad_m = ffi.new("vt_cnn_model *", cm[0])
    bad_m.heat_scale_q16 = 0
    bad_m2 = ffi.new("vt_cnn_model *", cm[0])
    bad_m2.n_layers = 0
    bad_c = ffi.new("vt_cnn_cfg *", cfg[0])
    bad_c.nms_iou_permille = 1001
    other = C.CnnConfig(n_levels=1).c()
    rows = [(ffi.NULL, cm, other, pw, 1), (p, cm, ffi.NULL, pw, 1), (p, cm, other, ffi.NULL, 1),
            (p, bad_m, other, pw, 1), (p, bad_m2, other, pw, 1), (p, cm, bad_c, pw, 1)]
    for i, args in enumerate(rows):
        assert lib.vt_pipeline_set_cnn(*args) == lib.VT_E_ARG, i
        assert p.cnn == cm and p.cnn_work_bytes == 64 and p.cnn_cfg.n_levels == cfg.n_levels, i
    # off: m NULL (cfg and work ignored); init turns it off too
    assert lib.vt_pipeline_set_cnn(p, ffi.NULL, ffi.NULL, ffi.NULL, 0) == lib.VT_OK and p.cnn == ffi.NULL
    assert lib.vt_pipeline_set_cnn(p, cm, cfg, pw, 64) == lib.VT_OK
    pc = ffi.new("vt_pipeline_cfg *", p.cfg)
    assert lib.vt_pipeline_init(p, pc, ffi.NULL, ffi.NULL) == lib.VT_OK and p.cnn == ffi.NULL


def test_step_refuses_a_short_work_buffer():
    """The work size is checked at each detection step: one byte short of
    vt_cnn_frame_work_bytes for the frame -> VT_E_CAPACITY from the step; enough -> VT_OK."""
    m = tiny_model()
    cm = m.c_model()[0]
    cfg = CFG.c()
    gray = scene()
    need = C.frame_work_bytes(m, gray.shape[1], gray.shape[0], CFG)
    work = np.zeros(need, np.uint8)
    p = _c_pipeline()
    ws = ffi.new("vt_pipe_cls_ws *")
    out = ffi.new("vt_frame_out *")
    from pyvehtrack import _native
    v = _native.view(gray, "img")
    assert lib.vt_pipeline_set_cnn(p, cm, cfg, ffi.cast("uint8_t *", work.ctypes.data), need - 1) == lib.VT_OK
    assert lib.vt_pipeline_set_cls_ws(p, ws, ffi.NULL) == lib.VT_OK
    assert lib.vt_pipeline_step(p, v, out) == lib.VT_E_CAPACITY and out.n_boxes == 0
    assert lib.vt_pipeline_set_cnn(p, cm, cfg, ffi.cast("uint8_t *", work.ctypes.data), need) == lib.VT_OK
    assert lib.vt_pipeline_step(p, v, out) == lib.VT_OK and out.detection_frame
    b, _ = C.detect_frame(m, gray, CFG)
    got = [(o.box.left, o.box.top, o.box.right, o.box.bottom, o.source, o.score)
           for o in (out.boxes[i] for i in range(out.n_boxes))]
    assert got == [(*map(int, r[:4]), int(lib.VT_SRC_CLASSIFIER), int(r[4]) * m.heat_scale_q16)
                   for r in b[:MAX_BOXES]]
