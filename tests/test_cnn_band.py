"""Level 0's row band in the CNN detector's frame-level settings (vt_cnn_cfg l0_top_permille,
l0_bottom_permille; include/vehtrack/cnn.h): with first_level 0 the network runs on rows
y0 = floor(h top / 1000) .. y1 - 1, y1 = ceil(h bottom / 1000), of the frame and its boxes are
moved down y0 rows; the levels >= 1 still come from the whole frame.

Tolerance: 0 LSB / 0 px everywhere. The band is integer arithmetic on both sides (C in int64,
the twin pyvehtrack/reference/cnn.py in Python ints) and the rest is the bit-exact contract of
tests/test_cnn_frame.py, so any difference is a bug:
  * hypothesis: random small models and frames (1..120 rows, so the rounding of the band's
    edges is exercised), first_level 0, 1..5 levels, random bands: C == twin (boxes, order,
    peak count), the band rows equal the exact rational floor / ceil and are never empty,
    vt_cnn_frame_work_bytes equals the single-level pieces with level 0 at its band and never
    exceeds the band-less size, nothing written outside it or past boxes[*n], one byte short
    VT_E_CAPACITY with nothing written;
  * the defaults (0, 1000) and any band that rounds to the whole frame give the band-less result;
  * by hand: a constant head on a 24 x 64 frame, band 250..750 = rows 16..47: exactly its
    12 cells' boxes, their centres inside the band; a random model equals forward / decode on
    the cropped rows, moved down y0;
  * bad values refused (C VT_E_ARG; Python ValueError naming the field), even when first_level
    is not 0; n_levels 5 from level 0 runs, 6 does not;
  * model files: an old 6-entry cnn_cfg loads with the band's defaults, 8 entries round-trip,
    other lengths are refused; the shipped model gives the band-less boxes; the pipeline
    carries the band.
"""
from __future__ import annotations

from fractions import Fraction
from math import ceil, floor

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyvehtrack import Pipeline, fullroad
from pyvehtrack import cnn as C
from pyvehtrack._native import ffi, lib
from pyvehtrack.reference import cnn as R
from test_cnn import random_model
from test_cnn_frame import GUARD, I32_MAX, I32_MIN, c_cfg, c_detect_guarded, check_c_equals_twin, const_model
from test_pipeline_cnn import scene, tiny_model

BAND = ("l0_top_permille", "l0_bottom_permille")
NO_UP = dict(up_top_permille=0, up_bottom_permille=0, up_left_permille=0, up_right_permille=0)  # loaded as off
SB, CB = 24, 20     # sizeof vt_scored_box, vt_cnn_box (test_cnn_frame checks them)


def _img(rng, kind, h, w):
    if kind == "noise":
        return rng.integers(0, 256, (h, w)).astype(np.uint8)
    img = np.tile(np.linspace(90, 200, h).astype(np.uint8)[:, None], (1, w))
    for _ in range(5):      # dark boxes: structure inside and outside any band
        x0, y0 = int(rng.integers(0, w)), int(rng.integers(0, h))
        img[y0:y0 + int(rng.integers(2, 30)), x0:x0 + int(rng.integers(2, 40))] = int(rng.integers(0, 60))
    return img


def _need_by_hand(model, cfgd, w, h):
    """cnn.h's vt_cnn_frame_work_bytes from the single-level queries, level 0 at its band."""
    y0, y1 = R.band_rows(h, cfgd["l0_top_permille"], cfgd["l0_bottom_permille"])
    first, nl, cap = cfgd["first_level"], cfgd["n_levels"], cfgd["cap_per_level"]
    lw, lh, lvl, fwd, out = [w], [h], [0, 0], 0, 0
    for k in range(1, first + nl):
        lw.append((lw[-1] + 1) // 2)
        lh.append((lh[-1] + 1) // 2)
        lvl[0 if k & 1 else 1] = max(lvl[0 if k & 1 else 1], lw[k] * lh[k])
    for k in range(first, first + nl):
        hh = y1 - y0 if k == 0 else lh[k]
        gw, gh = C.out_size(model, lw[k], hh)
        fwd = max(fwd, C.work_bytes(model, lw[k], hh))
        out = max(out, gw * gh * 5)
    return 7 + nl * cap * SB + cap * CB + lvl[0] + lvl[1] + fwd + out


@st.composite
def bands(draw):
    kind = draw(st.sampled_from(["whole", "any", "thin", "edge"]))
    if kind == "whole":
        return 0, 1000
    if kind == "thin":      # one permille: a single row for every h <= 1000
        t = draw(st.integers(0, 999))
        return t, t + 1
    if kind == "edge":
        return draw(st.sampled_from([(0, 1), (999, 1000), (0, 999), (1, 1000), (333, 667), (250, 750)]))
    t = draw(st.integers(0, 999))
    return t, draw(st.integers(t + 1, 1000))


spec_layer = st.tuples(st.sampled_from([1, 3]), st.sampled_from([1, 2]), st.sampled_from([1, 2]),
                       st.integers(1, 6))


# ---------------------------------------------------------------- (a), (e): C == twin, sizes, guards
@given(st.lists(spec_layer, min_size=0, max_size=3), st.sampled_from([1, 3]), st.integers(1, 160),
       st.one_of(st.integers(1, 12), st.integers(24, 120)), st.integers(0, 5), st.integers(0, 2 ** 32 - 1), bands(),
       st.integers(1, 5),
       st.sampled_from([-300, -40, -10, 0, 10, 200]), st.sampled_from([1, 3, 17, 64, 256]),
       st.sampled_from([0, 500, 1000]), st.sampled_from([0, 800, 1000]), st.sampled_from(["noise", "blobs"]),
       st.integers(1, 40), st.integers(0, 7))
def test_band_equals_twin(hidden, last_k, w, h, pad, seed, band, n_levels, thr_off, cpl, iou, con, kind, cap,
                          shift):
    rng = np.random.default_rng(seed)
    spec = [(k, s, d if k == 3 else 1, c) for k, s, d, c in hidden] + [(last_k, 1, 1, 5)]
    img = _img(rng, kind, h, w)
    model = random_model(rng, spec, img, 60.0, rng.integers(0, 600, (4, 256)))
    top, bot = band
    cfgd = dict(first_level=0, n_levels=n_levels, thr_offset=thr_off, cap_per_level=cpl, nms_iou_permille=iou,
                nms_contain_permille=con, l0_top_permille=top, l0_bottom_permille=bot)
    # the band: the exact rational floor / ceil, never empty
    y0, y1 = R.band_rows(h, top, bot)
    assert (y0, y1) == (floor(Fraction(h * top, 1000)), ceil(Fraction(h * bot, 1000)))
    assert 0 <= y0 < y1 <= h
    check_c_equals_twin(model, img, cfgd, cap, pad, shift)
    # the size: the single-level pieces with level 0 at its band; never above the band-less size
    need = C.frame_work_bytes(model, w, h, C.CnnConfig(**cfgd))
    assert need == _need_by_hand(model, cfgd, w, h)
    assert need <= C.frame_work_bytes(model, w, h, C.CnnConfig(**{**cfgd, "l0_top_permille": 0,
                                                                   "l0_bottom_permille": 1000}))
    # one byte short: VT_E_CAPACITY, nothing written (work included)
    work = np.full(need + 8, GUARD, np.uint8)
    boxes = ffi.new("vt_cnn_box[2]", [(9,) * 5, (9,) * 5])
    n, t = ffi.new("int32_t *", 77), ffi.new("int32_t *", 77)
    s = lib.vt_cnn_detect_frame(model.c_model()[0], c_cfg(**cfgd), ffi.cast("uint8_t *", img.ctypes.data), w, h,
                                w, ffi.cast("uint8_t *", work.ctypes.data), need - 1, boxes, 2, n, t)
    assert s == lib.VT_E_CAPACITY and (n[0], t[0]) == (0, 0)
    assert (work == GUARD).all() and [tuple([b.l, b.t, b.r, b.b, b.score]) for b in boxes] == [(9,) * 5] * 2


# ---------------------------------------------------------------- (b): the defaults are the band-less call
@pytest.mark.parametrize("seed", range(6))
def test_defaults_and_whole_frame_bands_are_bandless(seed):
    """The band-less twin call (a cfg without the band's keys) is the detector as it was before
    the band; C at the defaults (fields left None), at explicit 0 / 1000, and at bands that round
    to rows 0 .. h - 1 all equal it, box for box."""
    rng = np.random.default_rng(seed)
    h, w = 40 + 7 * seed, 90 + 13 * seed
    img = _img(rng, "blobs", h, w)
    model = random_model(rng, [(3, 2, 1, 4), (3, 2, 2, 6), (1, 1, 1, 5)], img, 60.0, rng.integers(0, 600, (4, 256)))
    base = dict(first_level=0, n_levels=3, thr_offset=-20, cap_per_level=32, nms_iou_permille=500,
                nms_contain_permille=800)
    want, want_n = R.detect_frame(model, img, base)      # no band keys
    assert want_n > 0
    whole = [(0, 1000)]
    # h <= 1000: floor(h t / 1000) = 0 for t < 1000 / h, ceil(h b / 1000) = h for b > 1000 (h - 1) / h
    whole += [((1000 - 1) // h, 1000 - 1000 // h + 1), (0, 1000 - 1000 // h + 1), ((1000 - 1) // h, 1000)]
    for top, bot in whole:
        assert R.band_rows(h, top, bot) == (0, h), (top, bot)
        for cfg in (C.CnnConfig(**base), C.CnnConfig(**base, l0_top_permille=top, l0_bottom_permille=bot)):
            got, n = C.detect_frame(model, img, cfg)
            assert n == want_n and np.array_equal(got, want), (top, bot)
    assert C.frame_work_bytes(model, w, h, C.CnnConfig(**base)) == \
        C.frame_work_bytes(model, w, h, C.CnnConfig(**base, l0_top_permille=0, l0_bottom_permille=1000))
    # a struct filled by vt_cnn_cfg_default carries the band's defaults
    d = c_cfg()
    assert (d.l0_top_permille, d.l0_bottom_permille) == (0, 1000)


def test_band_ignored_above_level_0():
    """first_level >= 1: the band changes nothing (the levels come from the whole frame)."""
    rng = np.random.default_rng(11)
    img = _img(rng, "blobs", 90, 150)
    model = random_model(rng, [(3, 2, 1, 4), (1, 1, 1, 5)], img, 60.0, rng.integers(0, 600, (4, 256)))
    base = dict(first_level=1, n_levels=3, thr_offset=-20, cap_per_level=32)
    want = C.detect_frame(model, img, C.CnnConfig(**base))
    assert want[1] > 0
    for top, bot in ((400, 401), (0, 1), (999, 1000), (300, 600)):
        cfg = C.CnnConfig(**base, l0_top_permille=top, l0_bottom_permille=bot)
        got = C.detect_frame(model, img, cfg)
        assert got[1] == want[1] and np.array_equal(got[0], want[0])
        assert C.frame_work_bytes(model, 150, 90, cfg) == C.frame_work_bytes(model, 150, 90, C.CnnConfig(**base))


# ---------------------------------------------------------------- (c): by hand
def test_constant_head_band_by_hand():
    """heat 5 everywhere, stride 8, identity LUT, sides l = t = 1 px, r = b = 3 px (as in
    test_cnn_frame's constant head). Frame 24 x 64, band 250..750: y0 = 16, y1 = 48, 32 rows,
    a 3 x 4 grid. Cell (x, y): centre (8x + 4, 8y + 4) in band rows -> frame row 8y + 20, box
    [8x + 3, 8y + 19, 8x + 6, 8y + 22]; all 12 tied, raster order (NMS 1000 / 1000 keeps all:
    they do not overlap). The whole frame would give 3 x 8 = 24 peaks."""
    m = const_model(5, (-112, -112, -80, -80))
    img = np.zeros((64, 24), np.uint8)
    cfgd = dict(first_level=0, n_levels=1, thr_offset=0, cap_per_level=64, nms_iou_permille=1000,
                nms_contain_permille=1000, l0_top_permille=250, l0_bottom_permille=750)
    b, n = C.detect_frame(m, img, C.CnnConfig(**cfgd))
    want = [[8 * x + 3, 8 * y + 19, 8 * x + 6, 8 * y + 22, 5] for y in range(4) for x in range(3)]
    assert n == 12 and b.tolist() == want
    centres = (b[:, 1] + 1, b[:, 3] - 2)      # t = c - 1, b = c + 3 - 1
    assert (centres[0] == centres[1]).all() and ((centres[0] >= 16) & (centres[0] < 48)).all()
    rb, rn = R.detect_frame(m, img, cfgd)
    assert rn == 12 and rb.tolist() == want
    assert C.detect_frame(m, img, C.CnnConfig(**{**cfgd, "l0_top_permille": 0, "l0_bottom_permille": 1000}))[1] == 24
    # the size by hand: boxes 1 x 64 x 24 + 64 x 20, no level image, a 3-layer forward over 24 x 32
    # (outputs 12 x 16 x 1 even, 6 x 8 x 1 odd), output 3 x 4 x 5
    assert C.frame_work_bytes(m, 24, 64, C.CnnConfig(**cfgd)) == 7 + 64 * 24 + 64 * 20 + 12 * 16 + 6 * 8 + 3 * 4 * 5


def test_band_rounding_by_hand():
    """Band 500..600: h = 7 -> rows 3..4 (floor 3.5, ceil 4.2), h = 8 -> row 4 only (floor 4,
    ceil 4.8): the shorter frame needs one band row more (cnn.h: not monotone). h = 1: any band
    is the one row. With a one-layer stride-1 model the work is the output, w x rows x 5."""
    assert R.band_rows(7, 500, 600) == (3, 5) and R.band_rows(8, 500, 600) == (4, 5)
    assert all(R.band_rows(1, t, b) == (0, 1) for t, b in ((0, 1), (999, 1000), (500, 501)))
    m = const_model(3, strides=(1,))
    cfg = C.CnnConfig(first_level=0, n_levels=1, cap_per_level=4, l0_top_permille=500, l0_bottom_permille=600)
    fixed = 7 + 4 * SB + 4 * CB
    assert C.frame_work_bytes(m, 10, 7, cfg) == fixed + 10 * 2 * 5
    assert C.frame_work_bytes(m, 10, 8, cfg) == fixed + 10 * 1 * 5
    # every cell is a peak: the peak count is the band's cells
    assert C.detect_frame(m, np.zeros((7, 10), np.uint8), cfg)[1] == 20
    assert C.detect_frame(m, np.zeros((8, 10), np.uint8), cfg)[1] == 10
    assert C.detect_frame(m, np.zeros((1, 10), np.uint8), cfg)[1] == 10


def test_band_rows_exact_in_c():
    """The C's rows against the exact rational floor / ceil for h = 1..60 and bands whose
    products sit one off a multiple of 1000 (h b = 1000 n + 1: the ceil goes up; h t =
    1000 n - 1: the floor stays down), read from the peak count: a stride-1 constant head
    makes every cell of level 0's band a peak, w of them per row."""
    m = const_model(3, strides=(1,))
    bands = [(0, 1), (999, 1000), (111, 143), (1, 999), (333, 667), (500, 600), (250, 750), (0, 1000), (998, 999)]
    for h in range(1, 61):
        img = np.zeros((h, 3), np.uint8)
        for top, bot in bands:
            y0, y1 = floor(Fraction(h * top, 1000)), ceil(Fraction(h * bot, 1000))
            assert R.band_rows(h, top, bot) == (y0, y1) and 1 <= y1 - y0
            cfg = C.CnnConfig(first_level=0, n_levels=1, cap_per_level=1, l0_top_permille=top,
                              l0_bottom_permille=bot)
            assert C.detect_frame(m, img, cfg)[1] == 3 * (y1 - y0), (h, top, bot)


@pytest.mark.parametrize("band", [(250, 750), (400, 650), (0, 300), (700, 1000), (500, 501)])
def test_band_is_forward_decode_on_the_crop(band):
    """One level (0), NMS that keeps everything, a cap above the peaks: detect_frame's boxes are
    vt_cnn_forward / vt_cnn_decode on rows y0 .. y1 - 1 (a view with the frame's stride), t and b
    moved down y0, clipped to the frame, empty ones dropped; the peaks' centres lie in rows
    y0 .. y0 + gh S - 1 (the band rounded up to the stride: the last cell may hang past y1)."""
    img = scene(w=200, h=120, seed=band[0] % 7)
    m = tiny_model(2)
    top, bot = band
    cfgd = dict(first_level=0, n_levels=1, thr_offset=-30, cap_per_level=256, nms_iou_permille=1000,
                nms_contain_permille=1000, l0_top_permille=top, l0_bottom_permille=bot)
    got, n = C.detect_frame(m, img, C.CnnConfig(**cfgd))
    y0, y1 = R.band_rows(120, top, bot)
    crop = img[y0:y1]                                   # a view: row stride 200
    out = C.forward(m, crop)
    dec, nd = C.decode(m, out, m.heat_thr - 30, 0, 256)
    assert n == nd and nd > 0, "the drawn model finds nothing in the band"
    dec = dec.astype(np.int64)
    dec[:, 1] += y0
    dec[:, 3] += y0
    dec[:, 0] = np.maximum(dec[:, 0], 0)
    dec[:, 1] = np.maximum(dec[:, 1], 0)
    dec[:, 2] = np.minimum(dec[:, 2], 199)
    dec[:, 3] = np.minimum(dec[:, 3], 119)
    dec = dec[(dec[:, 0] <= dec[:, 2]) & (dec[:, 1] <= dec[:, 3])]
    assert got.tolist() == dec.tolist()
    S, gh = m.out_stride, out.shape[0]
    cy = R.peaks(out, m.heat_thr - 30)[:, 0] * S + S // 2 + y0
    assert ((cy >= y0) & (cy < y0 + gh * S)).all() and gh == -(-(y1 - y0) // S)
    # a dark block outside the band changes nothing
    img2 = img.copy()
    img2[:y0] = 0
    img2[y1:] = 255
    assert np.array_equal(C.detect_frame(m, img2, C.CnnConfig(**cfgd))[0], got)


# ---------------------------------------------------------------- (d): bad values
BAD = [(-1, 1000), (I32_MIN, 1000), (0, 1001), (0, I32_MAX), (500, 500), (600, 400), (1000, 1000), (0, 0),
       (-5, -1), (1000, 1001)]


def assert_c_refuses(m, cfg):
    """The core refuses a bad vt_cnn_cfg everywhere it is taken (VT_E_ARG) and writes nothing:
    not the size, not the counts, not the boxes. Returns the 16 x 16 frame it tried."""
    cm = m.c_model()[0]
    assert lib.vt_cnn_cfg_check(cfg) == lib.VT_E_ARG
    nb = ffi.new("size_t *", 3)
    assert lib.vt_cnn_frame_work_bytes(cm, cfg, 16, 16, nb) == lib.VT_E_ARG and nb[0] == 3
    img = np.zeros((16, 16), np.uint8)
    work = np.zeros(1 << 16, np.uint8)
    boxes = ffi.new("vt_cnn_box[1]", [(9,) * 5])
    n, t = ffi.new("int32_t *", 7), ffi.new("int32_t *", 7)
    assert lib.vt_cnn_detect_frame(cm, cfg, ffi.cast("uint8_t *", img.ctypes.data), 16, 16, 16,
                                   ffi.cast("uint8_t *", work.ctypes.data), work.size, boxes, 1, n, t) == lib.VT_E_ARG
    assert (n[0], t[0]) == (0, 0)
    assert tuple([boxes[0].l, boxes[0].t, boxes[0].r, boxes[0].b, boxes[0].score]) == (9,) * 5
    return img


@pytest.mark.parametrize("top,bot", BAD)
@pytest.mark.parametrize("first", [0, 1])
def test_bad_band_refused(top, bot, first):
    m = const_model()
    img = assert_c_refuses(m, c_cfg(first_level=first, n_levels=1, l0_top_permille=top, l0_bottom_permille=bot))
    kw = dict(first_level=first, n_levels=1, l0_top_permille=top, l0_bottom_permille=bot)
    field = "l0_bottom_permille" if 0 <= top <= 999 and not 1 <= bot <= 1000 else "l0_top_permille"
    for thunk in (lambda: C.CnnConfig(**kw).c(), lambda: C.detect_frame(m, img, C.CnnConfig(**kw)),
                  lambda: C.frame_work_bytes(m, 16, 16, C.CnnConfig(**kw))):
        with pytest.raises(ValueError, match=field) as e:
            thunk()
        assert "CnnConfig" in str(e.value)
    if 0 <= top <= 999 and 1 <= bot <= 1000:        # both in range: the order is the complaint
        with pytest.raises(ValueError, match="must be below l0_bottom_permille"):
            C.CnnConfig(**kw).c()


def test_band_edges_accepted():
    for top, bot in ((0, 1), (999, 1000), (0, 1000), (499, 500)):
        assert lib.vt_cnn_cfg_check(c_cfg(l0_top_permille=top, l0_bottom_permille=bot)) == lib.VT_OK
    with pytest.raises(ValueError, match="CnnConfig.l0_bottom_permille"):
        C.CnnConfig(l0_bottom_permille=2 ** 31).c()
    with pytest.raises(TypeError, match="CnnConfig.l0_top_permille"):
        C.CnnConfig(l0_top_permille=True).c()
    with pytest.raises(ValueError, match="CnnConfig.l0_top_permille"):
        C.CnnConfig(l0_top_permille=1.5).c()


# ---------------------------------------------------------------- (f): five levels from level 0
def test_five_levels_from_level_0():
    assert int(lib.VT_CNN_MAX_RUN_LEVELS) == 5 and C.MAX_RUN_LEVELS == 5
    rng = np.random.default_rng(4)
    img = _img(rng, "blobs", 120, 200)
    model = random_model(rng, [(3, 1, 1, 4), (1, 1, 1, 5)], img, 60.0, rng.integers(0, 600, (4, 256)))
    for band in ((0, 1000), (300, 700)):
        cfgd = dict(first_level=0, n_levels=5, thr_offset=-200, cap_per_level=256, nms_iou_permille=500,
                    nms_contain_permille=800, l0_top_permille=band[0], l0_bottom_permille=band[1])
        got, n = C.detect_frame(model, img, C.CnnConfig(**cfgd))
        want, wn = R.detect_frame(model, img, cfgd)
        y0, y1 = R.band_rows(120, *band)
        assert n == wn and np.array_equal(got, want) and n > 0
        # level 0 counts: its peaks are the band-only forward's, the rest the levels 1..4
        lvl0 = C.decode(model, C.forward(model, img[y0:y1]), model.heat_thr - 200)[1]
        rest = C.detect_frame(model, img, C.CnnConfig(**{**cfgd, "first_level": 1, "n_levels": 4}))[1]
        assert lvl0 > 0 and n == lvl0 + rest
        got_c, tot, ok = c_detect_guarded(model, img, c_cfg(**cfgd), 1280)
        assert ok and tot == n and np.array_equal(got_c, want)
    assert lib.vt_cnn_cfg_check(c_cfg(first_level=0, n_levels=5, cap_per_level=256)) == lib.VT_OK
    assert lib.vt_cnn_cfg_check(c_cfg(first_level=1, n_levels=5)) == lib.VT_OK       # levels 1..5
    for first, nl in ((0, 6), (1, 6), (2, 5)):
        assert lib.vt_cnn_cfg_check(c_cfg(first_level=first, n_levels=nl)) == lib.VT_E_ARG
    with pytest.raises(ValueError, match="n_levels = 6 is outside"):
        C.CnnConfig(first_level=0, n_levels=6).c()


# ---------------------------------------------------------------- (g): files, the shipped model, the pipeline
def _saved(tmp_path, cfg):
    m = tiny_model(3)
    m.cfg = cfg
    m.save(tmp_path / "m.npz")
    return m, tmp_path / "m.npz"


def test_old_six_entry_cnn_cfg_loads_with_band_defaults(tmp_path):
    m, p = _saved(tmp_path, C.CnnConfig(first_level=0, n_levels=3, thr_offset=-30, cap_per_level=16,
                                        l0_top_permille=300, l0_bottom_permille=700))
    d = dict(np.load(p))
    assert d["cnn_cfg"].tolist() == [0, 3, -30, 16, 500, 800, 300, 700, 0]  # written in CFG_KEYS order
    assert C.CnnModel.load(p).cfg == C.CnnConfig.from_c(m.cfg.c())           # and read back
    d["cnn_cfg"] = d["cnn_cfg"][:6]            # a file from before the band
    np.savez(p, **d)
    got = C.CnnModel.load(p)
    assert got.cfg == C.CnnConfig(first_level=0, n_levels=3, thr_offset=-30, cap_per_level=16, nms_iou_permille=500,
                                  nms_contain_permille=800, l0_top_permille=0, l0_bottom_permille=1000,
                                  stretch_tail_permille=0, **NO_UP)
    assert isinstance(fullroad.load_model(p), C.CnnModel)
    d["cnn_cfg"] = np.array([0, 3, -30, 16, 500, 800, 300, 700], np.int32)   # from before the stretch
    np.savez(p, **d)
    assert C.CnnModel.load(p).cfg == C.CnnConfig(first_level=0, n_levels=3, thr_offset=-30, cap_per_level=16,
                                                 nms_iou_permille=500, nms_contain_permille=800,
                                                 l0_top_permille=300, l0_bottom_permille=700,
                                                 stretch_tail_permille=0, **NO_UP)
    for bad in ([0, 3, -30, 16, 500, 800, 0], [0, 3, -30, 16, 500], list(range(10)), [[0, 3, -30, 16, 500, 800]]):
        d["cnn_cfg"] = np.array(bad, np.int32)
        np.savez(p, **d)
        with pytest.raises(ValueError, match=r"cnn_cfg must have shape \(13,\)"):
            C.CnnModel.load(p)
    d["cnn_cfg"] = np.array([0, 3, -30, 16, 500, 800, 300, 700, 101], np.int32)   # stretch out of range
    np.savez(p, **d)
    with pytest.raises(ValueError, match="stretch_tail_permille"):
        C.CnnModel.load(p)
    d["cnn_cfg"] = np.array([0, 3, -30, 16, 500, 800, 700, 300], np.int32)    # an empty band
    np.savez(p, **d)
    with pytest.raises(ValueError, match="l0_top_permille"):
        C.CnnModel.load(p)


def test_shipped_model_is_bandless():
    """pyvehtrack/models/cnn_gray.npz loads; its settings take the band's defaults, and its boxes
    (its own levels, and from level 0) are the band-less twin's, as before the band."""
    import cv2
    from pathlib import Path
    path = Path(fullroad.__file__).parent / "models" / "cnn_gray.npz"
    m = C.CnnModel.load(path)
    assert m.cfg is not None and (m.cfg.l0_top_permille, m.cfg.l0_bottom_permille) == (0, 1000)
    g = cv2.imread(str(Path(__file__).parent / "data" / "kitti_lead_30_gray_621x188.png"), cv2.IMREAD_GRAYSCALE)
    from dataclasses import replace
    for cfg in (m.cfg, replace(m.cfg, first_level=0)):
        old = {k: getattr(cfg, k) for k in C.CFG_KEYS[:C.CFG_KEYS_OLD]}       # no band keys
        want, wn = R.detect_frame(m, g, old)
        got, n = C.detect_frame(m, g, cfg)
        assert n == wn and np.array_equal(got, want) and len(got) >= 1


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_pipeline_carries_the_band(engine):
    m = tiny_model()
    gray = scene()
    cfg = C.CnnConfig(first_level=0, n_levels=2, thr_offset=-30, cap_per_level=16, l0_top_permille=300,
                      l0_bottom_permille=800)
    b, _ = C.detect_frame(m, gray, cfg)
    want = [((int(r[0]), int(r[1]), int(r[2]), int(r[3])), "classifier", int(r[4]) * m.heat_scale_q16 / 65536)
            for r in b[:int(lib.VT_MAX_BOXES)]]
    bandless = C.detect_frame(m, gray, C.CnnConfig(first_level=0, n_levels=2, thr_offset=-30, cap_per_level=16))[0]
    assert len(want) >= 3 and not np.array_equal(b, bandless), "the band should change this scene's boxes"
    pipe = Pipeline(engine, model=m, cnn_cfg=cfg, sources=("classifier",), road="fixed", detect_every=1, track=False,
                    cnn_hood_min_width_mm=0)    # every box (the hood rule: test_pipeline_cnn)
    res = pipe.step(gray)
    assert [(x.box, x.source, x.score) for x in res.boxes] == want
