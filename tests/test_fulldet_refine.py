"""Box regression of the whole-road detector's boxes (issue 8: vt_box_regressor,
vt_box_regress, vt_fulldet_refine, vt_pipeline_set_refine in c/fulldet.c and
c/pipeline.c; oracle reference/fulldet.py: context_box, regress_box, refine).

Checked here: the move of a box equals the oracle's exact rule (context box, one
descriptor shared by four linear models, round half up of offset x width, cut to the
image, an inside-out box kept) for random images, boxes and regressors, extreme offsets
included; the shipped regressor's offsets equal the float model on the float HOG within
the bound of the HOG's and the weights' roundings; only boxes of the regressor's sources
move; the pipeline and FullRoadDetector run it identically in both engines; bad
arguments are errors that change nothing."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyvehtrack import _native as N
from pyvehtrack import ffi, lib
from pyvehtrack.fullroad import DEFAULT_WINDOW_MODEL, FullRoadConfig, FullRoadDetector, load_model
from pyvehtrack.pipeline import Pipeline
from pyvehtrack.reference import classify as R
from pyvehtrack.reference import fulldet as rfd

DATA = Path(__file__).resolve().parent / "data"
Q15 = 32768.0


def _gray(p):
    g = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
    assert g is not None, p
    return g


def _random_regressor(rng, win, margin, sources, bias_scale):
    dim = R.hog_dim(win, win)
    w = rng.integers(-3000, 3001, size=(4, dim)).astype(np.int16)
    shifts = rng.integers(14, 20, size=4)   # |sum w x| up to about a box width
    bias = (rng.normal(0, bias_scale, size=4) * 65536).astype(np.int64)
    return N.box_regressor(margin, sources, win, win, w, shifts, bias)


def _offsets(ws, reg, img, ctx):
    return [N.classify_box(ws, ffi.addressof(reg.side[k]), img, list(ctx)) for k in range(4)]


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 31), w=st.integers(16, 160), h=st.integers(16, 120),
       win=st.sampled_from([16, 24, 48]), margin=st.integers(0, 1000),
       bias_scale=st.sampled_from([0.0, 0.3, 50.0]))
def test_regress_equals_oracle(seed, w, h, win, margin, bias_scale):
    """C's moved box = reference.fulldet.regress_box(box, offsets of the context box):
    bias 50 box widths pushes sides past the image (cut) or turns boxes inside out (kept)."""
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, size=(h, w)).astype(np.uint8)
    reg, _keep = _random_regressor(rng, win, margin, 3, bias_scale)
    ws = N.box_ws_new()
    for _ in range(4):
        l, r = sorted(rng.integers(0, w, size=2))
        t, b = sorted(rng.integers(0, h, size=2))
        box = (int(l), int(t), int(r), int(b))
        got = N.box_regress(ws, reg, img, box)
        ctx = rfd.context_box(box, margin, w, h)
        assert got == rfd.regress_box(box, _offsets(ws, reg, img, ctx), w, h), (box, ctx)
        assert 0 <= got[0] <= got[2] < w and 0 <= got[1] <= got[3] < h


def test_rounding_and_cut_by_hand():
    """A constant regressor (zero weights): the offsets are the Q16 biases. Width 16:
    2048 / 65536 w = +0.5 px rounds up to +1; -0.5 px rounds up to 0; -1.5 px -> -1;
    -100 widths on the left is cut to column 0; the right side 5 widths left of the left
    side turns the box inside out, so it is kept."""
    img = np.full((40, 60), 128, np.uint8)
    zero = np.zeros((4, R.hog_dim(16, 16)), np.int16)
    ws = N.box_ws_new()
    box = (20, 10, 35, 25)   # width 16
    for b_q16, want in [((2048, -2048, -6144, 0), (21, 10, 34, 25)),
                        ((-100 * 65536, 0, 0, 0), (0, 10, 35, 25)),
                        ((0, 0, -5 * 65536, 0), box)]:
        reg, _k = N.box_regressor(250, 3, 16, 16, zero, [15] * 4, b_q16)
        assert N.box_regress(ws, reg, img, box) == want, b_q16
        assert rfd.regress_box(box, b_q16, 60, 40) == want


def _hog_bound(crop: np.ndarray) -> np.ndarray:
    """Per-element bound of |C HOG - skimage HOG| of one crop (tests/test_classify.py's
    rule: the Q4 magnitude rounding of each cell through the block norm, plus 3 Q15 LSB)."""
    from test_classify import _hog_tolerance
    tol = _hog_tolerance(crop)
    return np.repeat(tol.ravel(), 36)


def test_shipped_regressor_close_to_float():
    """The shipped regressor's Q16 offsets against the float model (w_q / 2^shift, b) on
    the float HOG (skimage) of the same resampled context, within
    sum |w_f| x (HOG bound) + sum 2^-(shift+1) x_i + 2^-16 per side."""
    m = load_model(DEFAULT_WINDOW_MODEL)
    reg = m.refine
    assert reg is not None and reg.win_w == reg.win_h == 48
    creg, _keep = reg.c()
    ws = N.box_ws_new()
    wf = reg.w_q.astype(np.float64) / (2.0 ** reg.w_shift.astype(np.float64))[:, None]
    n = 0
    for p, boxes in [(DATA / "udacity_test1_640x360.jpg", [(400, 180, 470, 245), (500, 175, 630, 245)]),
                     (DATA / "kitti_clip" / "000000.png", [(250, 150, 330, 210), (20, 140, 120, 230)])]:
        g = _gray(p)
        gh, gw = g.shape
        for box in boxes:
            ctx = rfd.context_box(box, reg.margin_permille, gw, gh)
            crop = N.resample_area(g, ctx, reg.win_w, reg.win_h)
            assert np.array_equal(crop, R.resample_area(g, ctx, reg.win_w, reg.win_h))
            xf = R.hog(crop)
            want = wf @ xf + reg.b_q16 / 65536
            got = np.array(_offsets(ws, creg, g, ctx)) / 65536
            bound = np.abs(wf) @ _hog_bound(crop) + (2.0 ** -(reg.w_shift + 1.0)) * xf.sum() + 2 ** -16
            assert (np.abs(got - want) <= bound).all(), (p.name, box, got - want, bound)
            n += 1
    assert n == 4


def _result(boxes):
    res = ffi.new("vt_fulldet_result *")
    res.n_boxes = len(boxes)
    for i, (b, score, src) in enumerate(boxes):
        res.box[i].box.left, res.box[i].box.top, res.box[i].box.right, res.box[i].box.bottom = b
        res.box[i].score, res.box[i].source = score, src
    return res


@pytest.mark.parametrize("sources", [1, 2, 3])
def test_refine_moves_only_its_sources(sources):
    rng = np.random.default_rng(sources)
    img = _gray(DATA / "udacity_test1_640x360.jpg")
    h, w = img.shape
    reg, _keep = _random_regressor(rng, 24, 300, sources, 0.3)
    boxes = [((100, 150, 160, 200), 70000, 1), ((300, 160, 380, 230), 90000, 2), ((500, 170, 600, 250), 50000, 2),
             ((10, 10, 10, 10), 1, 1)]
    res = _result(boxes)
    got = N.fulldet_refine(N.box_ws_new(), reg, img, res)
    arr = np.array([[*b, s, src] for b, s, src in boxes], np.int64)
    ws = N.box_ws_new()
    want = rfd.refine(arr, lambda l, t, r, b: _offsets(ws, reg, img, (l, t, r, b)), 300, sources, w, h)
    rows = np.stack([got[k] for k in ("left", "top", "right", "bottom", "score", "source")], 1)
    assert np.array_equal(rows, want)
    moved = [tuple(rows[i, :4]) != b for i, (b, _, _) in enumerate(boxes)]
    assert not any(mv for mv, (_, _, src) in zip(moved, boxes) if not src & sources)
    assert any(moved)   # not vacuous: the random regressor moves some box


def test_bad_arguments_change_nothing():
    img = _gray(DATA / "udacity_test1_640x360.jpg")
    rng = np.random.default_rng(7)
    reg, _keep = _random_regressor(rng, 16, 250, 3, 0.3)
    ws = N.box_ws_new()
    v = N.view(img, "img")
    inb, outb = ffi.new("vt_box *", [10, 10, 50, 40]), ffi.new("vt_box *", [1, 2, 3, 4])
    assert lib.vt_box_regress(ffi.NULL, reg, v, inb, outb) == lib.VT_E_ARG
    assert (outb.left, outb.top, outb.right, outb.bottom) == (10, 10, 50, 40)   # *out = *in on error
    assert lib.vt_box_regress(ws, ffi.NULL, v, inb, outb) == lib.VT_E_ARG
    assert lib.vt_box_regress(ws, reg, ffi.NULL, inb, outb) == lib.VT_E_ARG
    assert lib.vt_box_regress(ws, reg, v, ffi.NULL, outb) == lib.VT_E_ARG
    assert lib.vt_box_regress(ws, reg, v, inb, ffi.NULL) == lib.VT_E_ARG
    for bad in ([-1, 0, 5, 5], [0, 0, img.shape[1], 5], [5, 5, 4, 9], [0, 0, 5, img.shape[0]]):
        assert lib.vt_box_regress(ws, reg, v, ffi.new("vt_box *", bad), outb) == lib.VT_E_ARG, bad
    # a regressor out of range, or its four models not alike
    for field, val in (("margin_permille", -1), ("margin_permille", 1001), ("sources", 0), ("sources", 4)):
        r2 = ffi.new("vt_box_regressor *", reg[0])
        setattr(r2, field, val)
        assert lib.vt_box_regressor_check(r2) == lib.VT_E_ARG, (field, val)
        assert lib.vt_box_regress(ws, r2, v, inb, outb) == lib.VT_E_ARG
    r2 = ffi.new("vt_box_regressor *", reg[0])
    r2.side[3].kind = lib.VT_DESC_GIST
    assert lib.vt_box_regressor_check(r2) == lib.VT_E_ARG
    r2 = ffi.new("vt_box_regressor *", reg[0])
    r2.side[2].w = ffi.NULL
    assert lib.vt_box_regressor_check(r2) == lib.VT_E_ARG
    other, _k2 = _random_regressor(rng, 24, 250, 3, 0.3)
    r2 = ffi.new("vt_box_regressor *", reg[0])
    r2.side[1] = other.side[1]   # another window and dim
    assert lib.vt_box_regressor_check(r2) == lib.VT_E_ARG
    with pytest.raises(ValueError, match="w_q"):
        N.box_regressor(250, 3, 16, 16, np.zeros((3, R.hog_dim(16, 16)), np.int16), [10] * 4, [0] * 4)
    with pytest.raises(N.VtError, match="vt_svm_model_check"):
        N.box_regressor(250, 3, 16, 16, np.zeros((4, 5), np.int16), [10] * 4, [0] * 4)
    # vt_fulldet_refine: the result unchanged on every error
    boxes = [((100, 150, 160, 200), 70000, 2), ((300, 160, 380, 230), 90000, 2)]
    for n_boxes, extra in ((-1, None), (int(lib.VT_MAX_BOXES) + 1, None), (2, (0, 0, img.shape[1], 9))):
        res = _result(boxes + ([(extra, 1, 2)] if extra else []))
        if extra is None:
            res.n_boxes = n_boxes
        before = bytes(ffi.buffer(res))
        assert lib.vt_fulldet_refine(ws, reg, v, res) == lib.VT_E_ARG
        assert bytes(ffi.buffer(res)) == before
    res = _result(boxes)
    assert lib.vt_fulldet_refine(ffi.NULL, reg, v, res) == lib.VT_E_ARG
    assert lib.vt_fulldet_refine(ws, reg, v, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_fulldet_refine(ws, reg, ffi.NULL, res) == lib.VT_E_ARG
    # the pipeline: NULL pipeline, a bad regressor; NULL turns it off
    r2 = ffi.new("vt_box_regressor *", reg[0])
    r2.sources = 9
    p = ffi.new("vt_pipeline *")
    assert lib.vt_pipeline_set_refine(ffi.NULL, reg) == lib.VT_E_ARG
    assert lib.vt_pipeline_set_refine(p, r2) == lib.VT_E_ARG
    assert lib.vt_pipeline_set_refine(p, reg) == lib.VT_OK
    assert lib.vt_pipeline_set_refine(p, ffi.NULL) == lib.VT_OK


def test_model_file_keys(tmp_path):
    """A file with some refine_* keys only is refused by name; refine=False turns the
    shipped regressor off, refine=True with a model holding none is an error."""
    z = dict(np.load(DEFAULT_WINDOW_MODEL, allow_pickle=False))
    del z["refine_b_q16"]
    bad = tmp_path / "partial.npz"
    np.savez(bad, **z)
    with pytest.raises(ValueError, match="refine_b_q16"):
        load_model(bad)
    z = dict(np.load(DEFAULT_WINDOW_MODEL, allow_pickle=False))
    z["refine_margin_permille"] = np.int32(2000)
    bad2 = tmp_path / "margin.npz"
    np.savez(bad2, **z)
    with pytest.raises(ValueError, match="box regressor"):
        load_model(bad2)
    plain = {k: v for k, v in np.load(DEFAULT_WINDOW_MODEL, allow_pickle=False).items()
             if not k.startswith("refine_")}
    none = tmp_path / "none.npz"
    np.savez(none, **plain)
    with pytest.raises(ValueError, match="no box regressor"):
        FullRoadDetector(str(none), cfg=FullRoadConfig(refine=True))
    with pytest.raises(TypeError, match="cfg.refine"):
        FullRoadDetector(DEFAULT_WINDOW_MODEL, cfg=FullRoadConfig(refine=1))
    g = _gray(DATA / "udacity_test1_640x360.jpg")
    off = FullRoadDetector(DEFAULT_WINDOW_MODEL, cfg=FullRoadConfig(refine=False)).detect_gray(g)
    plain_boxes = FullRoadDetector(str(none)).detect_gray(g)
    assert np.array_equal(off, plain_boxes)


@pytest.mark.parametrize("name", ["udacity_test1_640x360.jpg", "lane_tusimple_0601_1494452495543904834_gray_640x360.png",
                                  "kitti_clip/000003.png"])
def test_engines_agree_and_boxes_move(name):
    """FullRoadDetector and the Pipeline with the shipped model: C = oracle with the
    regressor on; and it moves boxes (against refine=False)."""
    g = _gray(DATA / name)
    c = FullRoadDetector(DEFAULT_WINDOW_MODEL).detect_gray(g)
    r = FullRoadDetector(DEFAULT_WINDOW_MODEL, engine="reference").detect_gray(g)
    assert np.array_equal(c, r)
    pc = Pipeline("c", model=str(DEFAULT_WINDOW_MODEL), sources=("shadow", "classifier"), detect_every=1,
                  track=False)
    pr = Pipeline("reference", model=str(DEFAULT_WINDOW_MODEL), sources=("shadow", "classifier"), detect_every=1,
                  track=False)
    a, b = pc.step_gray(g), pr.step_gray(g)
    assert [(x.source, tuple(x.box), x.score) for x in a.boxes] == [(x.source, tuple(x.box), x.score) for x in b.boxes]



def test_regressor_moves_boxes_on_real_frames():
    moved = 0
    for name in ("udacity_test1_640x360.jpg", "lane_tusimple_0601_1494452495543904834_gray_640x360.png"):
        g = _gray(DATA / name)
        on = FullRoadDetector(DEFAULT_WINDOW_MODEL).detect_gray(g)
        off = FullRoadDetector(DEFAULT_WINDOW_MODEL, cfg=FullRoadConfig(refine=False)).detect_gray(g)
        assert len(on) == len(off) and np.array_equal(on[:, 4:], off[:, 4:])
        moved += int((on[:, :4] != off[:, :4]).any(1).sum())
    assert moved >= 1


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_tracker_gets_the_boxes_as_detected(engine):
    """The pipeline reports regressed boxes but hands the tracker the boxes as detected
    (its ROI search measures their bottom edge and sides): over six KITTI clip frames the
    tracks are those of the same pipeline without the regressor, while some reported box
    differs."""
    frames = [_gray(DATA / "kitti_clip" / f"{i:06d}.png") for i in range(6)]
    kw = dict(model=str(DEFAULT_WINDOW_MODEL), detect_every=1, track=True)
    on = Pipeline(engine, **kw)
    off = Pipeline(engine, fullroad=FullRoadConfig(refine=False), **kw)
    differ = 0
    for g in frames:
        a, b = on.step_gray(g), off.step_gray(g)
        assert [(t.id, tuple(t.box), t.state) for t in a.tracks] == [(t.id, tuple(t.box), t.state) for t in b.tracks]
        assert len(a.boxes) == len(b.boxes)
        differ += sum(tuple(x.box) != tuple(y.box) for x, y in zip(a.boxes, b.boxes))
    assert differ >= 1
