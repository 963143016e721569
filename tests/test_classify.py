"""The classifier (c/classify.c) against its float oracle (pyvehtrack/reference/classify.py).

Tolerances, from the arithmetic stated in include/vehtrack/classify.h:
  - HOG: the orientation bins are exact; each pixel's magnitude is rounded to Q4
    (|error| <= 1/32), so a block's histogram h is off by ||dh|| <= ||count||/32
    (count = pixels with a nonzero gradient per bin). L2 normalisation moves a unit
    vector by <= 2 ||dh|| / ||h||, the 0.2 clip is 1-Lipschitz and the second
    normalisation divides by ||c|| >= 0.2, so each value is within
    20 ||dh|| / ||h|| of skimage's, plus <= 3 Q15 LSB of the C's own rounding.
  - GIST: each filter output re, im is within 1 of the float one (Q0 rounding 0.5,
    Q4 row rounding x sum|fy| / 32 ~ 0.2, Q14 taps ~ 0.1), so a cell's RMS moves by
    <= sqrt(2) and the Q4 floor adds 1/16; the unit-norm 512-vector then moves by
    <= 2 * 1.5 * sqrt(512) / ||rms|| per value, plus 2 LSB.
  - SVM: the C score equals the exact integer formula (0 LSB); against the float
    w . x + b it is within 2^-(w_shift+1) * sum(x) (weight rounding) + 2^-16.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyvehtrack import _native as N
from pyvehtrack import VtError
from pyvehtrack.reference import classify as R

ffi, lib = N.ffi, N.lib
ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data" / "classify"
Q15 = 32768.0


def _image(seed: int, h: int, w: int, kind: int) -> np.ndarray:
    """Test images: noise, smooth ramps with edges, or flat with a few blobs."""
    rng = np.random.default_rng(seed)
    if kind == 0:
        return rng.integers(0, 256, (h, w), dtype=np.uint8)
    yy, xx = np.mgrid[0:h, 0:w]
    if kind == 1:
        a = rng.uniform(-3, 3, 2)
        img = 128 + a[0] * xx + a[1] * yy + 40 * (((xx // rng.integers(3, 12)) + (yy // rng.integers(3, 12))) % 2)
        return np.clip(img + rng.normal(0, 4, (h, w)), 0, 255).astype(np.uint8)
    img = np.full((h, w), int(rng.integers(0, 256)), np.float64)
    for _ in range(4):
        cy, cx, r = rng.uniform(0, h), rng.uniform(0, w), rng.uniform(2, 12)
        img[(yy - cy) ** 2 + (xx - cx) ** 2 < r * r] = rng.integers(0, 256)
    return img.astype(np.uint8)


# ---------------------------------------------------------------- HOG
def _hog_tolerance(img: np.ndarray) -> np.ndarray:
    """Per block (by, bx): 20 ||dh|| / ||h|| + 3 LSB (see the module docstring)."""
    cnt, sm = R.hog_gradient_stats(img)
    cy, cx = cnt.shape[:2]
    tol = np.zeros((cy - 1, cx - 1))
    for by in range(cy - 1):
        for bx in range(cx - 1):
            c = cnt[by:by + 2, bx:bx + 2].ravel()
            s = sm[by:by + 2, bx:bx + 2].ravel()
            n = np.linalg.norm(s)
            tol[by, bx] = (20 * np.linalg.norm(c / 32) / n if n > 0 else 0) + 3 / Q15
    return tol


@settings(max_examples=30)
@given(st.integers(16, 72), st.integers(16, 56), st.integers(0, 2), st.integers(0, 2 ** 31), st.integers(0, 5))
def test_hog_blocks_match_skimage(w, h, kind, seed, pad):
    img = _image(seed, h, w, kind)
    big = np.full((h, w + pad), 77, np.uint8)  # a row stride > w whose padding must never be read
    big[:, :w] = img
    ws = N.hog_ws_new()
    N.hog_prepare(ws, big[:, :w])
    ref = R.hog_blocks(img)  # (cy-1, cx-1, 2, 2, 9)
    assert (ws.cells_y, ws.cells_x) == (h // 8, w // 8)
    tol = _hog_tolerance(img)
    c = N.hog_descriptor(ws, 0, 0, ws.cells_x * 8, ws.cells_y * 8).reshape(ref.shape[0], ref.shape[1], 36)
    diff = np.abs(c / Q15 - ref.reshape(c.shape))
    assert (diff <= tol[:, :, None]).all(), (diff.max(), tol.min())


def test_hog_real_crops_close_to_skimage():
    """On the real crops in tests/data the bound above is far from tight: <= 0.005."""
    from pyvehtrack.train import read_gray
    for p in sorted(DATA.rglob("*.png")):
        g = read_gray(p)
        ws = N.hog_ws_new()
        N.hog_prepare(ws, g)
        c = N.hog_descriptor(ws, 0, 0, 64, 64) / Q15
        assert np.abs(c - R.hog(g)).max() <= 0.005, p.name


@settings(max_examples=20)
@given(st.integers(0, 2 ** 31), st.sampled_from([(16, 16), (32, 32), (24, 40), (64, 64)]))
def test_hog_windows_scan_and_decision(seed, win):
    rng = np.random.default_rng(seed)
    ww, wh = win
    img = _image(seed, 80, 96, seed % 3)
    ws = N.hog_ws_new()
    N.hog_prepare(ws, img)
    blocks = R.hog_blocks(img)
    dim = R.hog_dim(ww, wh)
    w = rng.normal(0, 0.3, dim)
    b = float(rng.normal(0, 0.5))
    from pyvehtrack.train import quantise
    wq, shift, bq = quantise(w, b)
    m, keep = N.svm_model(lib.VT_DESC_HOG, ww, wh, wq, shift, bq)
    ncx, ncy = ws.cells_x - ww // 8 + 1, ws.cells_y - wh // 8 + 1
    scan = N.hog_scan(ws, m, 0, 0, ncx, ncy)
    for cy in range(ncy):
        for cx in range(ncx):
            d = N.hog_descriptor(ws, cx, cy, ww, wh)
            # The window is the slice of the prepared blocks (vs the oracle: the HOG bound).
            ref = R.hog_window(blocks, cx, cy, ww, wh)
            assert d.shape == ref.shape
            exact = int(np.dot(wq.astype(np.int64), d.astype(np.int64)))
            sh = shift - 1
            q = ((exact + (1 << (sh - 1))) >> sh) if sh > 0 else exact
            assert scan[cy, cx] == q + bq == N.hog_window_score(ws, m, cx, cy) == N.svm_decision(m, d)
            fl = float(w @ (d / Q15) + b)
            assert abs(scan[cy, cx] / 65536 - fl) <= 2.0 ** -(shift + 1) * (d / Q15).sum() + 2 ** -16 + 1e-9


# ---------------------------------------------------------------- GIST
@settings(max_examples=8)
@given(st.sampled_from([(32, 32), (64, 32), (40, 72), (96, 64)]), st.integers(0, 2), st.integers(0, 2 ** 31))
def test_gist_matches_oracle(size, kind, seed):
    w, h = size
    img = _image(seed, h, w, kind)
    ws = N.gist_ws_new()
    N.gist_prepare(ws, img)
    cells = R.gist_cells(img)
    ww, wh = w // 32 * 32, h // 32 * 32
    for cx, cy in {(0, 0), (ws.cells_x - ww // 8, ws.cells_y - wh // 8)}:
        d = N.gist_descriptor(ws, cx, cy, ww, wh) / Q15
        ref = R.gist_window(cells, cx, cy, ww, wh)
        gw, gh = ww // 32, wh // 32
        rms = np.sqrt(cells[cy:cy + 4 * gh, cx:cx + 4 * gw].reshape(4, gh, 4, gw, -1).mean(axis=(1, 3)))
        n = np.linalg.norm(rms)
        tol = (2 * 1.5 * math.sqrt(512) / n if n > 0 else 1.0) + 2 / Q15
        assert np.abs(d - ref).max() <= tol, (np.abs(d - ref).max(), tol)


def test_gist_real_crops_close_to_oracle():
    from pyvehtrack.train import read_gray
    for p in sorted(DATA.rglob("*.png"))[:4]:
        g = read_gray(p)
        ws = N.gist_ws_new()
        N.gist_prepare(ws, g)
        d = N.gist_descriptor(ws, 0, 0, 64, 64) / Q15
        assert np.abs(d - R.gist(g)).max() <= 0.002, p.name


# ---------------------------------------------------------------- resampling, decision
@settings(max_examples=40)
@given(st.integers(1, 60), st.integers(1, 50), st.data())
def test_resample_area_exact(w, h, data):
    seed = data.draw(st.integers(0, 2 ** 31))
    img = np.random.default_rng(seed).integers(0, 256, (h, w), dtype=np.uint8)
    l = data.draw(st.integers(0, w - 1))
    r = data.draw(st.integers(l, w - 1))
    t = data.draw(st.integers(0, h - 1))
    b = data.draw(st.integers(t, h - 1))
    ow, oh = data.draw(st.integers(1, 40)), data.draw(st.integers(1, 40))
    assert np.array_equal(N.resample_area(img, (l, t, r, b), ow, oh), R.resample_area(img, (l, t, r, b), ow, oh))


@settings(max_examples=60)
@given(st.integers(0, 2 ** 31), st.integers(8, 130), st.integers(8, 130), st.sampled_from([32, 48, 64, 128]),
       st.integers(0, 9), st.integers(0, 9), st.integers(1, 128))
def test_resample_area_window_sizes(seed, bw, bh, win, x, y, stride_pad):
    """The window-sized outputs vt_resample_area has fast paths for (a box equal to the
    window: copied; under twice it: 1, 2 or 4 pixels per output, the mean as a shift),
    and the general path beside them, in a strided view, against the oracle exactly."""
    rng = np.random.default_rng(seed)
    big = rng.integers(0, 256, (bh + y + 3, bw + x + stride_pad), dtype=np.uint8)
    img = big[:, :bw + x + 2]
    box = (x, y, x + bw - 1, y + bh - 1)
    assert np.array_equal(N.resample_area(img, box, win, win), R.resample_area(img, box, win, win))


@settings(max_examples=40)
@given(st.integers(0, 2 ** 31), st.sampled_from([(lib.VT_DESC_HOG, 32, 32), (lib.VT_DESC_HOG, 16, 24),
                                                 (lib.VT_DESC_GIST, 64, 64)]))
def test_svm_decision_exact_and_close_to_float(seed, spec):
    kind, ww, wh = spec
    rng = np.random.default_rng(seed)
    dim = R.hog_dim(ww, wh) if kind == lib.VT_DESC_HOG else 512
    w = rng.normal(0, rng.uniform(0.01, 5), dim)
    b = float(rng.normal(0, 3))
    x = rng.integers(0, 32769, dim).astype(np.uint16)
    from pyvehtrack.train import quantise
    wq, shift, bq = quantise(w, b)
    m, keep = N.svm_model(kind, ww, wh, wq, shift, bq)
    got = N.svm_decision(m, x)
    exact = int(np.dot(wq.astype(np.int64), x.astype(np.int64)))
    sh = shift - 1
    assert got == (((exact + (1 << (sh - 1))) >> sh) if sh > 0 else exact) + bq
    fl = R.svm_decision(w, b, x / Q15)
    assert abs(got / 65536 - fl) <= 2.0 ** -(shift + 1) * (x / Q15).sum() + 2 ** -16 + 1e-9


def test_classify_box_equals_crop_path():
    """vt_classify_box = resample + descriptor of the window alone + decision."""
    img = _image(5, 120, 160, 1)
    m = N.svm_default_model(lib.VT_DESC_HOG)
    ws = N.box_ws_new()
    box = (13, 20, 100, 90)
    win = R.resample_area(img, box, m.win_w, m.win_h)
    hw = N.hog_ws_new()
    N.hog_prepare(hw, win)
    d = N.hog_descriptor(hw, 0, 0, m.win_w, m.win_h)
    assert N.classify_box(ws, m, img, box) == N.svm_decision(m, d)


# ---------------------------------------------------------------- bad arguments, guards
def test_bad_arguments_are_clear_errors():
    m = N.svm_default_model(lib.VT_DESC_HOG)
    ws = N.hog_ws_new()
    out = ffi.new("int32_t *")
    d = np.zeros(m.dim, np.uint16)
    pd = ffi.cast("uint16_t *", d.ctypes.data)
    assert lib.vt_svm_decision(ffi.NULL, pd, m.dim, out) == lib.VT_E_ARG        # NULL model
    assert lib.vt_svm_decision(m, ffi.NULL, m.dim, out) == lib.VT_E_ARG
    assert lib.vt_svm_decision(m, pd, m.dim, ffi.NULL) == lib.VT_E_ARG
    with pytest.raises(VtError, match="vt_svm_decision"):
        N.svm_decision(m, d[:-1])                                              # wrong length
    with pytest.raises(VtError, match="vt_hog_prepare"):
        N.hog_prepare(ws, np.zeros((0, 0), np.uint8))                          # zero size
    with pytest.raises(VtError, match="vt_hog_prepare"):
        N.hog_prepare(ws, np.zeros((15, 40), np.uint8))                        # < one block
    N.hog_prepare(ws, np.zeros((40, 48), np.uint8))
    with pytest.raises(VtError, match="vt_hog_window_score"):
        N.hog_window_score(ws, m, 0, 0)                                        # window > image
    with pytest.raises(VtError, match="vt_hog_descriptor"):
        N.hog_descriptor(ws, 1, 0, 48, 40)                                     # off the edge
    with pytest.raises(VtError):
        N.hog_scan(ws, m, 0, 0, 1, 1)
    assert lib.vt_hog_prepare(ffi.NULL, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_hog_window_score(ffi.new("vt_hog_ws *"), m, 0, 0, out) == lib.VT_E_ARG  # unprepared
    assert lib.vt_gist_prepare(ffi.NULL, ffi.NULL) == lib.VT_E_ARG
    with pytest.raises(VtError, match="vt_gist_prepare"):
        N.gist_prepare(N.gist_ws_new(), np.zeros((31, 64), np.uint8))
    with pytest.raises(VtError, match="vt_svm_model_check"):
        N.svm_model(lib.VT_DESC_HOG, 64, 64, np.zeros(10, np.int16), 10, 0)    # dim vs window
    with pytest.raises(VtError, match="vt_svm_model_check"):
        N.svm_model(lib.VT_DESC_GIST, 48, 64, np.zeros(512, np.int16), 10, 0)  # GIST needs 32k
    with pytest.raises(VtError, match="vt_svm_model_check"):
        N.svm_model(7, 64, 64, np.zeros(1764, np.int16), 10, 0)                # unknown kind
    bws = N.box_ws_new()
    img = np.zeros((50, 60), np.uint8)
    for box in [(-1, 0, 10, 10), (0, 0, 60, 10), (5, 5, 4, 10), (0, 0, 10, 50)]:
        with pytest.raises(VtError, match="vt_classify_box"):
            N.classify_box(bws, m, img, box)
    assert lib.vt_classify_box(bws, ffi.NULL, N.view(img, "img"), ffi.new("vt_box *", [0, 0, 9, 9]),
                               out) == lib.VT_E_ARG
    assert lib.vt_svm_default_model(99, ffi.new("const vt_svm_model **")) == lib.VT_E_ARG


def test_descriptor_output_guards():
    img = _image(1, 64, 64, 1)
    ws = N.hog_ws_new()
    N.hog_prepare(ws, img)
    n = R.hog_dim(32, 32)
    buf = np.full(n + 8, 0xBEEF, np.uint16)
    cnt = ffi.new("int32_t *")
    p = ffi.cast("uint16_t *", buf.ctypes.data) + 4
    assert lib.vt_hog_descriptor(ws, 2, 3, 32, 32, p, n, cnt) == 0 and cnt[0] == n
    assert (buf[:4] == 0xBEEF).all() and (buf[-4:] == 0xBEEF).all()
    assert lib.vt_hog_descriptor(ws, 2, 3, 32, 32, p, n - 1, cnt) == lib.VT_E_SIZE and cnt[0] == 0
    gws = N.gist_ws_new()
    N.gist_prepare(gws, img)
    buf = np.full(512 + 8, 0xBEEF, np.uint16)
    p = ffi.cast("uint16_t *", buf.ctypes.data) + 4
    assert lib.vt_gist_descriptor(gws, 0, 0, 64, 64, p, 512, cnt) == 0 and cnt[0] == 512
    assert (buf[:4] == 0xBEEF).all() and (buf[-4:] == 0xBEEF).all()
    scores = np.full(6 + 4, 12345, np.int32)
    m = N.svm_default_model(lib.VT_DESC_HOG)
    if m.win_w <= 48:
        ps = ffi.cast("int32_t *", scores.ctypes.data) + 2
        ncx = 64 // 8 - m.win_w // 8 + 1
        assert lib.vt_hog_scan(ws, m, 0, 0, min(ncx, 3), 2, ps, 6) == 0
        assert (scores[:2] == 12345).all() and (scores[-2:] == 12345).all()


def test_python_bad_input():
    from pyvehtrack.classify import Classifier
    clf = Classifier()
    with pytest.raises(TypeError, match="images"):
        clf.score([np.zeros((10, 10), np.float32)])
    with pytest.raises(ValueError, match="empty"):
        clf.score([np.zeros((0, 10), np.uint8)])
    with pytest.raises(ValueError, match="shape"):
        clf.score([np.zeros((4, 4, 2), np.uint8)])
    with pytest.raises(ValueError, match="engine"):
        Classifier(engine="gpu")
    with pytest.raises(ValueError, match="model"):
        Classifier(str(ROOT / "tests" / "data" / "README.md"))


# ---------------------------------------------------------------- the default model, the CLI
def _crops():
    pos = sorted((DATA / "vehicles").glob("*.png"))
    neg = sorted((DATA / "non-vehicles").glob("*.png"))
    assert len(pos) >= 4 and len(neg) >= 4
    return pos, neg


def test_default_model_scores_test_crops():
    """Crops from the TEST splits (never trained on): the default model gets them right,
    in C and in the float reference alike."""
    from pyvehtrack.classify import Classifier
    from pyvehtrack.train import read_gray
    pos, neg = _crops()
    imgs = [read_gray(p) for p in pos + neg]
    truth = np.array([1] * len(pos) + [0] * len(neg), bool)
    clf = Classifier()
    assert clf.model_type == "mlp"  # the built-in default: the MLP on HOG
    c = clf.score(imgs)
    f = Classifier(engine="reference").score(imgs)
    # The MLP's GTI TEST accuracy is 97.6% (tools/eval_classify.py); these 16 crops were
    # picked by file position before any scoring, and it gets all of them right (the
    # 16-unit MLP tried first missed GTI_Right_image0302).
    assert ((c >= 0) == truth).all(), c
    assert ((f >= 0) == (c >= 0)).all()
    # The linear HOG SVM (the sliding-window scorer, 95.8% on GTI TEST) misses 3 of them.
    m = N.svm_default_model(lib.VT_DESC_HOG)
    ws = N.box_ws_new()
    lin = np.array([N.classify_box(ws, m, g, (0, 0, g.shape[1] - 1, g.shape[0] - 1)) for g in imgs])
    assert ((lin >= 0) == truth).sum() >= 13, lin


def test_classify_cli(tmp_path):
    pos, neg = _crops()
    out = tmp_path / "out.json"
    env_py = [sys.executable, "-c", "import sys; from pyvehtrack.cli import main; sys.exit(main())"]
    r = subprocess.run(env_py + ["classify", str(DATA / "vehicles"), str(neg[0]), "--json", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    res = json.loads(out.read_text())
    assert [Path(e["file"]).name for e in res] == [p.name for p in pos] + [neg[0].name]
    assert all(isinstance(e["score"], float) for e in res)
    from pyvehtrack.classify import Classifier
    from pyvehtrack.train import read_gray
    want = Classifier().score([read_gray(p) for p in pos + [neg[0]]])
    assert [e["vehicle"] for e in res] == [bool(v >= 0) for v in want]
    assert np.allclose([e["score"] for e in res], want)
    assert all(e["vehicle"] for e in res[:-1]) and not res[-1]["vehicle"]
    r = subprocess.run(env_py + ["classify", str(tmp_path / "nope.png"), "--json", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "no such file" in r.stderr
    r = subprocess.run(env_py + ["classify", str(pos[0]), "--json", str(out), "--model", str(pos[0])],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "model" in r.stderr


def test_model_struct_sizes():
    """sizeof of the new state structs (printed by the bench too); the band workspace
    must hold a 1280-wide band by default."""
    hog = ffi.sizeof("vt_hog_ws")
    assert hog >= (lib.VT_CLS_MAX_W // 8 - 1) * (lib.VT_CLS_MAX_H // 8 - 1) * 72
    assert ffi.sizeof("vt_gist_ws") > 0 and ffi.sizeof("vt_cls_box_ws") > 0


# ---------------------------------------------------------------- MLP
def _mlp_exact(w1q, s1, b1q, w2q, s2, b2q, x) -> int:
    """The arithmetic of vt_mlp_decision in Python integers."""
    out = 0
    for j in range(w1q.shape[0]):
        a = int(np.dot(w1q[j].astype(np.int64), x.astype(np.int64)))
        sh = s1 - 1
        a = ((a + (1 << (sh - 1))) >> sh) if sh > 0 else a
        h = max(-2 ** 31, min(2 ** 31 - 1, a + int(b1q[j])))
        if h > 0:
            out += int(w2q[j]) * h
    out = (out + (1 << (s2 - 1))) >> s2
    return max(-2 ** 31, min(2 ** 31 - 1, out + b2q))


@settings(max_examples=30)
@given(st.integers(0, 2 ** 31), st.integers(1, 24))
def test_mlp_decision_exact_and_close_to_float(seed, hidden):
    """0 LSB against the stated integer arithmetic; against the float net the error is
    bounded by the weight rounding: |dh_j| <= 2^-(s1+1) sum(x) + 2^-16 per hidden unit
    (ReLU is 1-Lipschitz), so |dscore| <= sum_j (|w2_j| |dh_j| + 2^-(s2+1) h_j) + 2^-16."""
    from pyvehtrack.train import mlp_dict
    rng = np.random.default_rng(seed)
    dim = R.hog_dim(32, 32)
    w1 = rng.normal(0, 0.2, (hidden, dim))
    b1 = rng.normal(0, 1, hidden)
    w2 = rng.normal(0, 2, hidden)
    b2 = float(rng.normal())
    d = mlp_dict("hog", 32, 32, w1, b1, w2, b2, {})
    m, keep = N.mlp_model(lib.VT_DESC_HOG, 32, 32, d["w1_q"], d["w1_shift"], d["b1_q16"], d["w2_q"],
                          d["w2_shift"], d["b2_q16"])
    x = rng.integers(0, 32769, dim).astype(np.uint16)
    got = N.mlp_decision(m, x)
    assert got == _mlp_exact(d["w1_q"], d["w1_shift"], d["b1_q16"], d["w2_q"], d["w2_shift"], d["b2_q16"], x)
    xf = x / Q15
    h = np.maximum(0, w1 @ xf + b1)
    dh = 2.0 ** -(d["w1_shift"] + 1) * xf.sum() + 2 ** -16 + 2 ** -17
    bound = float(np.sum(np.abs(w2) * dh + 2.0 ** -(d["w2_shift"] + 1) * (h + dh))) + 2 ** -16 + 1e-9
    assert abs(got / 65536 - R.mlp_decision(w1, b1, w2, b2, xf)) <= bound


def test_mlp_bad_arguments_and_box():
    rng = np.random.default_rng(3)
    dim = R.hog_dim(32, 32)
    w1q = rng.integers(-100, 100, (4, dim)).astype(np.int16)
    m, keep = N.mlp_model(lib.VT_DESC_HOG, 32, 32, w1q, 12, [0, 1, 2, 3], [5, -5, 5, -5], 10, 0)
    out = ffi.new("int32_t *")
    d = np.zeros(dim, np.uint16)
    pd = ffi.cast("uint16_t *", d.ctypes.data)
    assert lib.vt_mlp_decision(ffi.NULL, pd, dim, out) == lib.VT_E_ARG
    assert lib.vt_mlp_decision(m, pd, dim - 1, out) == lib.VT_E_SIZE
    with pytest.raises(VtError, match="vt_mlp_model_check"):
        N.mlp_model(lib.VT_DESC_HOG, 32, 32, w1q[:, :-1], 12, [0] * 4, [1] * 4, 10, 0)
    with pytest.raises(VtError, match="vt_mlp_model_check"):
        N.mlp_model(lib.VT_DESC_HOG, 32, 32, np.zeros((65, dim), np.int16), 12, [0] * 65, [1] * 65, 10, 0)
    img = _image(2, 70, 90, 1)
    ws = N.box_ws_new()
    box = (5, 6, 60, 50)
    win = R.resample_area(img, box, 32, 32)
    hw = N.hog_ws_new()
    N.hog_prepare(hw, win)
    assert N.classify_box_mlp(ws, m, img, box) == N.mlp_decision(m, N.hog_descriptor(hw, 0, 0, 32, 32))
    with pytest.raises(VtError, match="vt_classify_box_mlp"):
        N.classify_box_mlp(ws, m, img, (0, 0, 90, 10))


_BUF = np.zeros(1300 * 200, np.uint8)
_BAD_DIMS = [(0, 40, 40), (40, 0, 40), (-1, 40, 40), (40, -1, 40), (40, 40, 39), (40, 40, -40),
             (lib.VT_CLS_MAX_W + 1, 40, lib.VT_CLS_MAX_W + 1), (40, lib.VT_CLS_MAX_H + 1, 40),
             (2 ** 31 - 1, 2 ** 31 - 1, 2 ** 31 - 1), (-(2 ** 31), 40, 40)]


@pytest.mark.parametrize("dims", _BAD_DIMS)
def test_prepare_bad_views(dims):
    w, h, stride = dims
    v = ffi.new("vt_image_u8 *")
    v.px, v.w, v.h, v.stride = ffi.cast("uint8_t *", _BUF.ctypes.data), w, h, stride
    assert lib.vt_hog_prepare(N.hog_ws_new(), v) == lib.VT_E_SIZE
    assert lib.vt_gist_prepare(N.gist_ws_new(), v) == lib.VT_E_SIZE
    m = N.svm_default_model(lib.VT_DESC_HOG)
    out = ffi.new("int32_t *")
    box = ffi.new("vt_box *", [0, 0, 9, 9])
    if w < 1 or h < 1 or stride < w or w > lib.VT_MAX_WIDTH or h > lib.VT_MAX_HEIGHT:
        # over the band capacity is still a valid frame for vt_classify_box
        assert lib.vt_classify_box(N.box_ws_new(), m, v, box, out) < 0 and out[0] == 0
    v.w, v.h, v.stride = 40, 40, 40
    v.px = ffi.NULL
    assert lib.vt_hog_prepare(N.hog_ws_new(), v) == lib.VT_E_ARG
    assert lib.vt_resample_area(v, box, ffi.new("vt_image_u8_mut *")) < 0


def _crop_folders(tmp_path, n):
    """tmp_path/veh and tmp_path/non with n crops each, cycled from the test crops and
    shifted by one column per cycle so no two files are equal. Returns the source crops."""
    import cv2
    from pyvehtrack.train import read_gray
    pos, neg = _crops()
    for name, files in (("veh", pos), ("non", neg)):
        d = tmp_path / name
        d.mkdir()
        for i in range(n):
            g = read_gray(files[i % len(files)])
            cv2.imwrite(str(d / f"image{i:04d}.png"), np.roll(g, i // len(files), axis=1))
    return pos, neg


def test_train_cli_small(tmp_path):
    """`pyvehtrack train` end to end on 2 x 48 crops (files 0-39 of each folder are TEST,
    40-47 TRAIN): it writes a model the classify command reads, and prints both accuracies;
    too few files is a clear error."""
    pos, neg = _crop_folders(tmp_path, 48)
    env_py = [sys.executable, "-c", "import sys; from pyvehtrack.cli import main; sys.exit(main())"]
    out = tmp_path / "m.npz"
    r = subprocess.run(env_py + ["train", "--vehicles", str(tmp_path / "veh"), "--non-vehicles",
                                 str(tmp_path / "non"), "--window", "32", "--C", "0.1", "--out", str(out),
                                 "--no-progress"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "float accuracy" in r.stdout and "C fixed-point accuracy" in r.stdout and "agreement" in r.stdout
    js = tmp_path / "o.json"
    r = subprocess.run(env_py + ["classify", str(pos[0]), "--model", str(out), "--json", str(js)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert len(json.loads(js.read_text())) == 1
    r = subprocess.run(env_py + ["train", "--vehicles", str(DATA / "vehicles"), "--non-vehicles",
                                 str(DATA / "non-vehicles"), "--out", str(out), "--no-progress"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "grouped split" in r.stderr


def test_train_cli_hidden_auto(tmp_path):
    """`train --model-type mlp --hidden auto` chooses the hidden size on TRAIN's inner
    validation fold (files 40-79 of each folder; 80-119 are the fitting fold, 0-39 TEST):
    the size it fits is the best of the accuracies it logs (ties: the smaller). Bad values
    and too few files for the inner fold are clear errors."""
    import re

    from pyvehtrack.train import HIDDEN_GRID
    _crop_folders(tmp_path, 120)
    env_py = [sys.executable, "-c", "import sys; from pyvehtrack.cli import main; sys.exit(main())"]
    base = ["train", "--vehicles", str(tmp_path / "veh"), "--non-vehicles", str(tmp_path / "non"),
            "--window", "32", "--model-type", "mlp", "--out", str(tmp_path / "m.npz"), "--no-progress"]
    r = subprocess.run(env_py + base + ["--hidden", "auto"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    acc = {int(h): float(a) for h, a in re.findall(r"hidden=(\d+): inner-validation accuracy ([0-9.]+)", r.stderr)}
    assert sorted(acc) == sorted(HIDDEN_GRID)
    best = max(HIDDEN_GRID, key=lambda h: (acc[h], -h))
    assert f"MLP {best} hidden" in r.stdout
    with np.load(tmp_path / "m.npz") as z:
        assert int(z["hidden"]) == best
    for bad in ("abc", "0", "65"):
        r = subprocess.run(env_py + base + ["--hidden", bad], capture_output=True, text=True)
        assert r.returncode == 2 and "--hidden" in r.stderr, (bad, r.stderr)
    for name in ("veh", "non"):   # 60 files: no file in the fitting folds 2-4
        for i in range(60, 120):
            (tmp_path / name / f"image{i:04d}.png").unlink()
    r = subprocess.run(env_py + base + ["--hidden", "auto"], capture_output=True, text=True)
    assert r.returncode == 2 and "--hidden auto" in r.stderr, r.stderr


def test_hog_bin_boundaries_exact_for_every_gradient():
    """The Q30 boundary constants of c/tables/classify_q.h give the exact sign of
    |g| sin(angle - 20k deg) for every integer gradient |gx|, |gy| <= 255 (folded, gy >= 0):
    so C's orientation bins equal the float ones, never off at a boundary."""
    import re
    text = (ROOT / "c" / "tables" / "classify_q.h").read_text()

    def arr(name):
        body = text[text.index(name):]
        body = body[body.index("{") + 1:body.index("}")]
        return [int(v) for v in re.findall(r"-?\d+", body)]
    sq, cq = arr("vt__hog_bound_sin_q30"), arr("vt__hog_bound_cos_q30")
    gx, gy = np.meshgrid(np.arange(-255, 256, dtype=np.int64), np.arange(0, 256, dtype=np.int64))
    for k in range(1, 9):
        a = math.radians(20 * k)
        exact = gy * math.cos(a) - gx * math.sin(a)
        q = gy * cq[k - 1] - gx * sq[k - 1]
        nz = np.abs(exact) > 1e-9          # only (0, 0) is on a boundary; C skips it
        assert np.abs(exact[nz]).min() > 2 ** -10
        assert ((q >= 0) == (exact >= 0))[nz].all()


def test_hog_bin_table_is_the_float_bin():
    """c/tables/classify_q.h's vt__hog_bin_small (the bins vt__hog_px reads for every
    gradient with gx^2 + gy^2 < VT__MAG_SMALL) holds, for each |gx|, |gy| < 32, the
    float HOG's unsigned bin floor(angle / 20 deg), angle folded onto [0, 180)."""
    import re
    text = (ROOT / "c" / "tables" / "classify_q.h").read_text()
    side = int(re.search(r"#define VT__BIN_SMALL (\d+)", text).group(1))
    mag_small = int(re.search(r"#define VT__MAG_SMALL (\d+)", text).group(1))
    body = text[text.index("vt__hog_bin_small["):]
    table = np.array([int(v) for v in re.findall(r"-?\d+", body[body.index("{") + 1:body.index("}")])])
    assert table.size == (2 * side - 1) ** 2
    assert side * side >= mag_small          # gx^2 + gy^2 < VT__MAG_SMALL implies |gx|, |gy| < side
    g = np.arange(-side + 1, side)
    gx, gy = np.meshgrid(g, g)
    ang = np.degrees(np.arctan2(gy, gx)) % 180.0
    want = np.minimum((ang // 20).astype(int), 8)
    nz = (gx != 0) | (gy != 0)
    assert np.array_equal(table.reshape(2 * side - 1, 2 * side - 1)[nz], want[nz])
