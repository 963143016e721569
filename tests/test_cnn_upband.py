"""The CNN detector's upsampled band (vt_cnn_cfg up_top / up_bottom / up_left / up_right_permille;
include/vehtrack/cnn.h): the network also runs on a rectangle of the frame at twice its size, for
far vehicles narrower than the head's smallest box, its boxes decoded at half scale.

Tolerance: 0 LSB / 0 px everywhere. The 2x image is integer arithmetic (weights 9, 3, 3, 1 over
16, rounded half up) on both sides, and OpenCV's cv2.INTER_LINEAR_EXACT computes the same
rounding of the same weights (2x has exact quarter weights), so the twin must equal it bit for bit;
the half-scale decode is floor((v + 16) / 32) in integers on both sides; the rest is the bit-exact
contract of tests/test_cnn_frame.py. Any difference is a bug:
  * the twin's 2x image = cv2.resize(frame, 2x, INTER_LINEAR_EXACT) cut to the rectangle
    (neighbours clamped to the frame, not to the rectangle);
  * C's boxes = vt_cnn_forward / vt_cnn_decode on that OpenCV image, halved by the rule above and
    moved by (x0, y0), clipped: C's own upsampling checked against OpenCV, not only the twin;
  * hypothesis: random models, frames, levels, stretch and rectangles: C == twin (boxes, order,
    peak count), nothing written outside vt_cnn_frame_work_bytes or past boxes[*n], one byte
    short VT_E_CAPACITY, the size = the band-less size + the 2x image + cap boxes, with the
    forward's regions at least the 2x image's;
  * all four fields 0 is the band-less call; bad rectangles refused (C VT_E_ARG, Python
    ValueError naming the fields); a 2x image past VT_MAX_WIDTH / HEIGHT is VT_E_SIZE;
  * model files: 13 entries round-trip, 9 are still written without the band.
"""
from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyvehtrack import cnn as C
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.reference import cnn as R
from test_cnn import random_model
from test_cnn_band import assert_c_refuses
from test_cnn_frame import GUARD, c_cfg, check_c_equals_twin, const_model
from test_pipeline_cnn import scene, tiny_model

UP = ("up_top_permille", "up_bottom_permille", "up_left_permille", "up_right_permille")
SB = 24     # sizeof vt_scored_box (test_cnn_frame checks it)


def _up(top, bot, left, right):
    return dict(zip(UP, (top, bot, left, right)))


def _cv_up(img, x0, y0, x1, y1):
    h, w = img.shape
    return cv2.resize(img, (2 * w, 2 * h), interpolation=cv2.INTER_LINEAR_EXACT)[2 * y0:2 * y1, 2 * x0:2 * x1]


@given(st.integers(1, 90), st.integers(1, 70), st.integers(0, 2 ** 32 - 1), st.data())
def test_twin_upsample_is_opencv_linear_exact(w, h, seed, data):
    img = np.random.default_rng(seed).integers(0, 256, (h, w)).astype(np.uint8)
    x0 = data.draw(st.integers(0, w - 1))
    x1 = data.draw(st.integers(x0 + 1, w))
    y0 = data.draw(st.integers(0, h - 1))
    y1 = data.draw(st.integers(y0 + 1, h))
    np.testing.assert_array_equal(R.upsample2x(img, x0, y0, x1, y1), _cv_up(img, x0, y0, x1, y1))


@pytest.mark.parametrize("rect", [(300, 600, 250, 750), (0, 1000, 0, 1000), (440, 540, 0, 1), (999, 1000, 500, 501)])
def test_c_band_is_forward_decode_on_the_opencv_image(rect):
    """One level far away (4, a tiny grid), NMS that keeps all, a cap above the peaks: the band's
    boxes are C's forward / decode (scale 0) on OpenCV's 2x image, each Q4-exact value halved:
    decode at scale 0 gives floor((v + 8) / 16) = p; the band's rule gives floor((v + 16) / 32),
    which is not floor(p / 2) in general, so the check takes the Q4 values from the LUT itself."""
    img = scene(w=200, h=120, seed=3)
    m = tiny_model(2)
    cfgd = dict(first_level=4, n_levels=1, thr_offset=-30, cap_per_level=256, nms_iou_permille=1000,
                nms_contain_permille=1000, **_up(*rect))
    got, n = C.detect_frame(m, img, C.CnnConfig(**cfgd))
    y0, y1 = R.band_rows(120, rect[0], rect[1])
    x0, x1 = R.band_rows(200, rect[2], rect[3])
    up = _cv_up(img, x0, y0, x1, y1)
    out = C.forward(m, np.ascontiguousarray(up))
    thr = m.heat_thr - 30
    lvl5, n5 = C.detect_frame(m, img, C.CnnConfig(**{**cfgd, **_up(0, 0, 0, 0)}))
    pk = R.peaks(out, thr)
    assert n == n5 + len(pk) and len(pk) > 0, "the drawn model finds nothing in the band"
    lut = np.asarray(m.side_lut, np.int64).reshape(4, 256)
    S = m.out_stride
    want = [list(r) for r in lvl5.tolist()]
    for y, x in pk[:256].tolist():                      # the band's cap_per_level, highest heat first
        c = out[y, x].astype(np.int64)
        cx, cy = (x * S + S // 2) * 16, (y * S + S // 2) * 16
        q4 = (cx - lut[0, c[1] + 128], cy - lut[1, c[2] + 128], cx + lut[2, c[3] + 128], cy + lut[3, c[4] + 128])
        l, t, r, b = ((int(v) + 16) // 32 for v in q4)
        l, t, r, b = max(l + x0, 0), max(t + y0, 0), min(r - 1 + x0, 199), min(b - 1 + y0, 119)
        if l <= r and t <= b:
            want.append([l, t, r, b, int(c[0])])
    want.sort(key=lambda r: -r[4])      # NMS keeps all: heat descending, stable (levels first)
    assert got.tolist() == want
    # the frame outside the rectangle's one-pixel ring changes nothing of the band's boxes
    img2 = img.copy()
    img2[:max(y0 - 1, 0)] = 0
    img2[y1 + 1:] = 255
    img2[:, :max(x0 - 1, 0)] = 7
    img2[:, x1 + 1:] = 250
    b2, _ = C.detect_frame(m, img2, C.CnnConfig(**{**cfgd, "n_levels": 1}))
    band_only = [r for r in b2.tolist() if r not in C.detect_frame(m, img2, C.CnnConfig(
        **{**cfgd, **_up(0, 0, 0, 0)}))[0].tolist()]
    assert band_only == [r for r in want if r not in lvl5.tolist()]


@st.composite
def rects(draw):
    kind = draw(st.sampled_from(["any", "thin", "edge"]))
    if kind == "edge":
        return draw(st.sampled_from([(0, 1000, 0, 1000), (0, 1, 999, 1000), (999, 1000, 0, 1), (440, 540, 250, 750)]))
    t = draw(st.integers(0, 999))
    lf = draw(st.integers(0, 999))
    if kind == "thin":
        return t, t + 1, lf, lf + 1
    return t, draw(st.integers(t + 1, 1000)), lf, draw(st.integers(lf + 1, 1000))


spec_layer = st.tuples(st.sampled_from([1, 3]), st.sampled_from([1, 2]), st.sampled_from([1, 2]),
                       st.integers(1, 6))


@given(st.lists(spec_layer, min_size=0, max_size=3), st.sampled_from([1, 3]), st.integers(1, 160),
       st.integers(1, 110), st.integers(0, 5), st.integers(0, 2 ** 32 - 1), rects(), st.integers(0, 2),
       st.integers(1, 4), st.sampled_from([-300, -40, -10, 0, 10]), st.sampled_from([1, 3, 17, 64]),
       st.sampled_from([0, 500, 1000]), st.sampled_from([0, 800, 1000]), st.sampled_from([0, 5, 100]),
       st.integers(1, 40), st.integers(0, 7))
def test_upband_equals_twin(hidden, last_k, w, h, pad, seed, rect, first, n_levels, thr_off, cpl, iou, con, tail,
                            cap, shift):
    rng = np.random.default_rng(seed)
    spec = [(k, s, d if k == 3 else 1, c) for k, s, d, c in hidden] + [(last_k, 1, 1, 5)]
    img = rng.integers(0, 256, (h, w)).astype(np.uint8)
    for _ in range(4):      # dark blocks: structure at every scale
        x0, y0 = int(rng.integers(0, w)), int(rng.integers(0, h))
        img[y0:y0 + int(rng.integers(2, 30)), x0:x0 + int(rng.integers(2, 40))] = int(rng.integers(0, 60))
    model = random_model(rng, spec, img, 60.0, rng.integers(0, 600, (4, 256)))
    cfgd = dict(first_level=first, n_levels=n_levels, thr_offset=thr_off, cap_per_level=cpl, nms_iou_permille=iou,
                nms_contain_permille=con, stretch_tail_permille=tail, **_up(*rect))
    check_c_equals_twin(model, img, cfgd, cap, pad, shift)
    # the size: the band-less size + the 2x image + cap_per_level boxes, its forward's regions
    # folded into the largest (so at most their sum more)
    y0, y1 = R.band_rows(h, rect[0], rect[1])
    x0, x1 = R.band_rows(w, rect[2], rect[3])
    uw, uh = 2 * (x1 - x0), 2 * (y1 - y0)
    need = C.frame_work_bytes(model, w, h, C.CnnConfig(**cfgd))
    base = C.frame_work_bytes(model, w, h, C.CnnConfig(**{**cfgd, **_up(0, 0, 0, 0)}))
    gw, gh = C.out_size(model, uw, uh)
    extra = uw * uh + cpl * SB
    assert base + extra <= need <= base + extra + C.work_bytes(model, uw, uh) + gw * gh * 5
    # one byte short: VT_E_CAPACITY, nothing written
    work = np.full(need + 8, GUARD, np.uint8)
    boxes = ffi.new("vt_cnn_box[1]", [(9,) * 5])
    n, t = ffi.new("int32_t *", 77), ffi.new("int32_t *", 77)
    s = lib.vt_cnn_detect_frame(model.c_model()[0], c_cfg(**cfgd), ffi.cast("uint8_t *", img.ctypes.data), w, h,
                                w, ffi.cast("uint8_t *", work.ctypes.data), need - 1, boxes, 1, n, t)
    assert s == lib.VT_E_CAPACITY and (n[0], t[0]) == (0, 0) and (work == GUARD).all()


@pytest.mark.parametrize("seed", range(4))
def test_zero_fields_are_bandless(seed):
    img = scene(w=160, h=90, seed=seed)
    m = tiny_model(seed + 1)
    base = dict(first_level=0, n_levels=3, thr_offset=-30, cap_per_level=16)
    want = C.detect_frame(m, img, C.CnnConfig(**base))
    got = C.detect_frame(m, img, C.CnnConfig(**base, **_up(0, 0, 0, 0)))
    assert np.array_equal(want[0], got[0]) and want[1] == got[1]
    on = C.detect_frame(m, img, C.CnnConfig(**base, **_up(300, 700, 200, 800)))
    assert on[1] > want[1], "the band should add peaks on this scene"


BAD = [(0, 0, 0, 1), (0, 0, 1, 0), (500, 500, 0, 1000), (600, 400, 0, 1000), (-1, 10, 0, 1000),
       (0, 1001, 0, 1000), (0, 10, 700, 300), (0, 10, 0, 1001), (0, 10, -5, 10), (1000, 1000, 1000, 1000)]


@pytest.mark.parametrize("rect", BAD)
def test_bad_rect_refused(rect):
    assert_c_refuses(const_model(), c_cfg(first_level=1, n_levels=1, **_up(*rect)))
    with pytest.raises(ValueError, match=r"CnnConfig: the upsampled band needs 0 <= up_(top|left)_permille"):
        C.CnnConfig(first_level=1, n_levels=1, **_up(*rect)).c()


def test_2x_image_past_the_maximum_is_a_size_error():
    w = int(lib.VT_MAX_WIDTH)
    m = const_model()
    cfg = C.CnnConfig(first_level=1, n_levels=1, **_up(0, 1, 0, 1000))    # 2 w columns
    with pytest.raises(VtError) as e:
        C.frame_work_bytes(m, w, 8, cfg)
    assert e.value.status == lib.VT_E_SIZE
    nb = ffi.new("size_t *", 3)
    assert lib.vt_cnn_frame_work_bytes(m.c_model()[0], cfg.c(), w, 8, nb) == lib.VT_E_SIZE and nb[0] == 3
    with pytest.raises(VtError):
        C.detect_frame(m, np.zeros((8, w), np.uint8), cfg)
    C.frame_work_bytes(m, w, 8, C.CnnConfig(first_level=1, n_levels=1, **_up(0, 1, 0, 500)))   # w columns: fits


def test_model_file_round_trip(tmp_path):
    m = tiny_model()
    m.cfg = C.CnnConfig(first_level=0, n_levels=3, thr_offset=-30, cap_per_level=16, stretch_tail_permille=5,
                        **_up(440, 540, 250, 750))
    p = tmp_path / "m.npz"
    m.save(p)
    assert np.load(p)["cnn_cfg"].tolist() == [0, 3, -30, 16, 500, 800, 0, 1000, 5, 440, 540, 250, 750]
    got = C.CnnModel.load(p)
    assert got.cfg == C.CnnConfig.from_c(m.cfg.c())
    img = scene(seed=2)
    assert np.array_equal(C.detect_frame(got, img, got.cfg)[0], C.detect_frame(m, img, m.cfg)[0])
    m.cfg = C.CnnConfig(first_level=0, n_levels=3)          # no band: the 9 entries of before
    m.save(p)
    assert len(np.load(p)["cnn_cfg"]) == 9
    d = dict(np.load(p))
    d["cnn_cfg"] = np.array([0, 3, 0, 16, 500, 800, 0, 1000, 5, 440, 540, 250, 250], np.int32)   # empty columns
    np.savez(p, **d)
    with pytest.raises(ValueError, match="up_left_permille"):
        C.CnnModel.load(p)


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_pipeline_carries_the_upsampled_band(engine):
    from pyvehtrack import Pipeline
    m = tiny_model()
    gray = scene()
    cfg = C.CnnConfig(first_level=1, n_levels=2, thr_offset=-30, cap_per_level=16, **_up(300, 700, 200, 800))
    b, _ = C.detect_frame(m, gray, cfg)
    without = C.detect_frame(m, gray, C.CnnConfig(first_level=1, n_levels=2, thr_offset=-30, cap_per_level=16))[0]
    assert not np.array_equal(b, without), "the band should change this scene's boxes"
    want = [((int(r[0]), int(r[1]), int(r[2]), int(r[3])), "classifier", int(r[4]) * m.heat_scale_q16 / 65536)
            for r in b[:int(lib.VT_MAX_BOXES)]]
    pipe = Pipeline(engine, model=m, cnn_cfg=cfg, sources=("classifier",), road="fixed", detect_every=1, track=False,
                    cnn_hood_min_width_mm=0)    # every box (the hood rule: test_pipeline_cnn)
    res = pipe.step(gray)
    assert [(x.box, x.source, x.score) for x in res.boxes] == want
