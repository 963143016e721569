"""Vertical-edge verification on compressed video (issue 8 item 5): the two codec
tolerances of vt_verify_cfg, vedge_reach (the derivative over a wider baseline) and
vedge_hyst_permille (hysteresis along each ROI column), in C (c/verify.c) against the
float oracle (pyvehtrack/reference/verify.py); what each one does on a drawn side;
their domains; and the lead car of the shipped KITTI clip through mp4v and JPEG.

Tolerance, C vs oracle: 0 (exact equality of boxes). The derivative is a difference
of integer [1 2 1] sums (|value| <= 1020) in C and in float32 in the oracle, exact in
both; the weak threshold is the same integer (floor division); the counts are
integers. So boxes agree exactly, as in tests/test_detect.py.
"""
from __future__ import annotations

import csv
import dataclasses
import tempfile
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import _native
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.detector import DetectConfig, Detector
from pyvehtrack.eval.boxes import from_inclusive, iou
from pyvehtrack.reference import verify as rv
from pyvehtrack.reference.verify import VerifyConfig

CLIP = Path(__file__).resolve().parent / "data" / "kitti_clip"
THESIS = dict(vedge_reach=0, vedge_hyst_permille=0)
# The codec tolerance chosen on KITTI frames 0-38 (off by default: no gain on 39-77).
CODEC = dict(vedge_reach=1, vedge_hyst_permille=200)
GUARD = 0x5A5A5A5A


def c_verify(gray, hyps, cfg: VerifyConfig, cap: int = 8):
    """vt_verify with guard rows after the output: (boxes, guards intact)."""
    st_ = ffi.new("vt_verify_state *")
    c = _native.verify_cfg_default()
    for f in dataclasses.fields(VerifyConfig):
        setattr(c, f.name, getattr(cfg, f.name))
    out = np.full((cap + 3, 4), GUARD, np.int32)
    n = _native.verify(st_, c, gray, np.ascontiguousarray(hyps, np.int32).reshape(-1, 3), out, cap)
    return out[:n].astype(np.int64), bool((out[cap:] == GUARD).all())


def side_image(h=40, w=60, body=40, road=20, left=15, right=44, ramp=1, strong_rows=None, seed=0):
    """A dark body (gray `body`) between columns left..right on a darker road, each side
    a ramp `ramp` px wide (1 = a sharp step). strong_rows: rows where the sides are
    sharp steps of twice the contrast (the rest keeps `ramp`)."""
    img = np.full((h, w), road, np.float64)
    x = np.arange(w)
    for y in range(h):
        r = ramp
        c = body - road
        if strong_rows is not None and y in strong_rows:
            r, c = 1, 2 * (body - road)
        up = np.clip((x - left + 1) / r, 0, 1)      # rises over `r` columns up to `left`
        down = np.clip((right + r - x) / r, 0, 1)   # falls over `r` columns after `right`
        img[y] = road + c * np.minimum(up, down)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


# ---------------------------------------------------------------- C vs oracle
@settings(max_examples=60, deadline=None)
@given(h=st.integers(3, 70), w=st.integers(3, 90), seed=st.integers(0, 2**32 - 1),
       n_hyp=st.integers(0, 4), reach=st.integers(0, 3), hyst=st.sampled_from([0, 1, 200, 500, 999, 1000]),
       thr=st.integers(1, 200), blur=st.sampled_from([0, 3, 5]), data=st.data())
def test_c_equals_oracle_any_reach_and_hysteresis(h, w, seed, n_hyp, reach, hyst, thr, blur, data):
    """Random bars, noise and blur (the codec's smoothing) with hypotheses anywhere,
    ROIs at the image borders (the reach reads replicated columns there)."""
    rng = np.random.default_rng(seed)
    img = rng.normal(100, 6, (h, w))
    for _ in range(int(rng.integers(0, 6))):
        a = int(rng.integers(0, w))
        img[:, a:a + int(rng.integers(1, 6))] += rng.uniform(-90, 90)
    img = np.clip(img, 0, 255).astype(np.uint8)
    if blur:
        img = cv2.GaussianBlur(img, (blur, blur), 0)
    hyps = []
    for _ in range(n_hyp):
        row = data.draw(st.integers(0, h - 1))
        xs = data.draw(st.integers(0, w - 1))
        hyps.append([row, xs, data.draw(st.integers(xs, w - 1))])
    cfg = VerifyConfig(vedge_threshold=thr, vedge_reach=reach, vedge_hyst_permille=hyst,
                       side_min_px=data.draw(st.integers(0, 4)),
                       side_min_frac_permille=data.draw(st.integers(0, 600)),
                       side_contrast_q8=data.draw(st.integers(0, 512)),
                       roi_height_q8=data.draw(st.integers(16, 600)))
    hyps = np.array(hyps, np.int64).reshape(-1, 3)
    bc, guards = c_verify(img, hyps, cfg)
    assert guards
    assert np.array_equal(bc, rv.verify(img, hyps, cfg, max_out=8))


def test_column_counts_hysteresis_rule():
    """The oracle's count by hand: weak pixels count only in a run that holds a strong one."""
    m = np.array([[0, 35, 35],
                  [35, 35, 35],
                  [45, 0, 35],
                  [35, 0, 0],
                  [0, 45, 35]], np.float64)
    assert rv.column_counts(m, 40, 32).tolist() == [3, 1, 0]
    assert rv.column_counts(m, 40, 40).tolist() == [1, 1, 0]   # no hysteresis: strong only
    assert rv.weak_threshold(VerifyConfig(**CODEC)) == 32
    assert rv.weak_threshold(VerifyConfig(vedge_threshold=1, vedge_hyst_permille=1000)) == 1


# ---------------------------------------------------------------- what each tolerance does
def test_reach_keeps_a_ramp_side_that_sobel_loses():
    """Sides ramped over 5 px (as a codec spreads a step on a dark car): a 20-level step
    rises 4 levels a column, so the Sobel peak is 4*8 = 32 < 40 on every row, while the
    4-px baseline sees 4*16 = 64."""
    img = side_image(body=40, road=20, ramp=5)
    hyp = np.array([[39, 17, 42]])
    thesis = VerifyConfig(**THESIS)
    assert len(c_verify(img, hyp, thesis)[0]) == 0
    assert len(rv.verify(img, hyp, thesis)) == 0
    b, _ = c_verify(img, hyp, dataclasses.replace(thesis, vedge_reach=1))
    # the sides lie on the ramps (columns 14..19 and 44..49)
    assert len(b) == 1 and 14 <= b[0][0] <= 19 and 44 <= b[0][2] <= 49, b


def test_hysteresis_counts_a_side_weak_on_most_rows():
    """Sides that are a sharp 18-level step on 3 of 40 rows and a 9-level step (Sobel
    36: >= 32, < 40) on the others: without hysteresis a side has 9 edge rows (the
    [1 2 1] smoothing spreads each sharp row over 3), fewer than 1/4 of the ROI; with it
    the whole side counts; a weak side with no strong row never does."""
    strong = {5, 20, 35}
    img = side_image(body=29, road=20, ramp=1, strong_rows=strong)
    hyp = np.array([[39, 17, 42]])
    cfg = VerifyConfig(**THESIS, roi_height_q8=512)        # ROI: all 40 rows
    assert len(c_verify(img, hyp, cfg)[0]) == 0
    b, _ = c_verify(img, hyp, dataclasses.replace(cfg, vedge_hyst_permille=200))
    assert len(b) == 1 and (b[0][0], b[0][2]) in {(14, 44), (15, 44), (14, 45), (15, 45)}
    weak_only = side_image(body=29, road=20, ramp=1)
    assert len(c_verify(weak_only, hyp, dataclasses.replace(cfg, vedge_hyst_permille=200))[0]) == 0


def test_zero_is_the_thesis_verification():
    """reach 0 and hysteresis 0 give the plain Sobel count (the old verification)."""
    img = cv2.GaussianBlur(side_image(body=60, road=20, ramp=2), (3, 3), 0)
    hyp = np.array([[39, 17, 42]])
    cfg = VerifyConfig(**THESIS)
    sx = np.abs(cv2.Sobel(img.astype(np.float32), cv2.CV_32F, 1, 0, ksize=3,
                          borderType=cv2.BORDER_REPLICATE))
    assert np.array_equal(rv.vertical_edges(img, 0), sx)
    assert np.array_equal(c_verify(img, hyp, cfg)[0], rv.verify(img, hyp, cfg))


# ---------------------------------------------------------------- domains
@pytest.mark.parametrize("field,value", [("vedge_reach", -1), ("vedge_reach", 4),
                                         ("vedge_hyst_permille", -1), ("vedge_hyst_permille", 1001)])
def test_out_of_domain_is_an_error(field, value):
    c = _native.verify_cfg_default()
    setattr(c, field, value)
    assert lib.vt_verify_cfg_check(c) == lib.VT_E_ARG
    with pytest.raises(VtError):
        c_verify(np.zeros((8, 8), np.uint8), np.array([[7, 0, 7]]),
                 dataclasses.replace(VerifyConfig(), **{field: value}))
    with pytest.raises(ValueError, match="verify config"):
        Detector("c", DetectConfig(verify=dataclasses.replace(VerifyConfig(), **{field: value})))


def test_defaults_and_the_full_road_default():
    """The shipped defaults are the thesis's verification (the codec tolerance is opt-in);
    the full-road detector's verify (VT_FULLDET_CFG_DEFAULT) too, and the Python twins say so."""
    c = _native.verify_cfg_default()
    assert (c.vedge_reach, c.vedge_hyst_permille) == (0, 0)
    assert (VerifyConfig().vedge_reach, VerifyConfig().vedge_hyst_permille) == (0, 0)
    f = ffi.new("vt_fulldet_cfg *")
    assert lib.vt_fulldet_cfg_default(f) == lib.VT_OK
    assert (f.det.verify.vedge_reach, f.det.verify.vedge_hyst_permille) == (0, 0)
    from pyvehtrack.shared import FullDetConfig
    assert (FullDetConfig().verify.vedge_reach, FullDetConfig().verify.vedge_hyst_permille) == (0, 0)


# ---------------------------------------------------------------- the KITTI clip, compressed
def _clip():
    frames = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted(CLIP.glob("*.png"))]
    with (CLIP / "lead_boxes.csv").open() as f:
        lead = [[float(r[k]) for k in ("left", "top", "right", "bottom")] for r in csv.DictReader(f)]
    return frames, lead


def _through_mp4v(frames):
    with tempfile.TemporaryDirectory() as td:
        path = str(Path(td) / "clip.mp4")
        h, w = frames[0].shape
        vw = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (w, h))
        if not vw.isOpened():
            return None
        for f in frames:
            vw.write(cv2.cvtColor(f, cv2.COLOR_GRAY2BGR))
        vw.release()
        cap = cv2.VideoCapture(path)
        out = []
        for _ in frames:
            ok, img = cap.read()
            if not ok:
                return None
            out.append(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY))
    return out


def _found(frames, lead, verify: VerifyConfig) -> int:
    det = Detector("c", DetectConfig(verify=verify))
    return sum(any(iou(from_inclusive(b), lead[i]) >= 0.6 for b in det.detect(f).boxes)
               for i, f in enumerate(frames))


def test_clip_lead_car_through_jpeg50():
    """The 20 frames of tests/data/kitti_clip (KITTI frames 0-19: the tuning part) at JPEG
    quality 50. Measured when written: 20/20 with the codec tolerance, 18/20 with the thesis's
    verification (and 20 / 19 on the PNG frames)."""
    frames, lead = _clip()
    jpg = [cv2.imdecode(cv2.imencode(".jpg", f, [cv2.IMWRITE_JPEG_QUALITY, 50])[1],
                        cv2.IMREAD_GRAYSCALE) for f in frames]
    new, old = _found(jpg, lead, VerifyConfig(**CODEC)), _found(jpg, lead, VerifyConfig(**THESIS))
    assert new >= 19 and new > old, (new, old)
    assert _found(frames, lead, VerifyConfig(**CODEC)) >= _found(frames, lead, VerifyConfig(**THESIS))


def test_clip_lead_car_through_mp4v():
    """The same frames written as an mp4v video (OpenCV, default quality). Measured when
    written: 12/20 with the codec tolerance, 10/20 with the thesis's verification (a 640x256 gray
    crop compresses harder than the full colour frame of tools/eval_kitti_lead.py)."""
    frames, lead = _clip()
    mp4 = _through_mp4v(frames)
    if mp4 is None:
        pytest.skip("this OpenCV build cannot write and read back mp4v")
    new, old = _found(mp4, lead, VerifyConfig(**CODEC)), _found(mp4, lead, VerifyConfig(**THESIS))
    assert new >= 11 and new >= old, (new, old)


def test_codec_stage_table_on_the_clip():
    """pyvehtrack.eval.kitti_codec (tools/eval_kitti_codec.py) on 5 clip frames: the
    same frames lose nothing; flat gray frames lose every PNG find at the shadow stage."""
    from pyvehtrack.eval import kitti_codec as kc
    frames, lead = _clip()
    png = [(i, cv2.cvtColor(f, cv2.COLOR_GRAY2BGR)) for i, f in enumerate(frames[:5])]
    gt = dict(enumerate(lead[:5]))
    calib = (721.5377, 609.5593 - 300, 172.854 - 118)   # the clip's crop of the KITTI camera
    same = kc.compare(png, png, gt, calib, DetectConfig())
    assert [r["stage"] for r in same] == [""] * 5 and sum(r["png"] for r in same) >= 4
    flat = [(i, np.full_like(f, 90)) for i, f in png]
    lost = kc.compare(png, flat, gt, calib, DetectConfig())
    assert all(r["stage"] == kc.STAGES[0] for r in lost if r["png"])
    assert not any(r["coded"] for r in lost)
