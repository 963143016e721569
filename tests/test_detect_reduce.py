"""The verify-aware shadow reduce (ShadowConfig.reduce_verified, issue 8 item 5):
vt_detect (c/detect.c) against its oracle twin pyvehtrack/reference/detect.py, and the
case it exists for -- a false hard step below a real car's shadow.

Tolerance, C vs oracle: 0 (exact equality of hypotheses, boxes and the dropped count).
Both interleave the same integer steps -- the shadow stage's candidates (exact, see
tests/test_detect.py), the one-edge-per-vehicle rule (integer products), and per
hypothesis the vertical-edge verification (integer counts) -- in the same bottom-up
order, so nothing can round differently."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import _native, config
from pyvehtrack._native import ffi, lib
from pyvehtrack.detector import DetectConfig, Detector
from pyvehtrack.fullroad import FullRoadConfig
from pyvehtrack.pipeline import Pipeline
from pyvehtrack.reference import detect as rdetect
from pyvehtrack.reference import shadow as rs
from pyvehtrack.reference.shadow import RoadArea, ShadowConfig
from pyvehtrack.shared import FullDetConfig
from pyvehtrack.reference.verify import VerifyConfig

from test_detect import draw_scene, iou, shadow_cfgs, verify_cfgs

CAPS = dict(max_active=int(lib.VT_MAX_SHADOW_ACTIVE), max_cand=int(lib.VT_MAX_SHADOW_CAND),
            max_hyp=int(lib.VT_MAX_HYPOTHESES), max_boxes=int(lib.VT_MAX_BOXES))


def c_detect(gray, road, scfg: ShadowConfig, vcfg: VerifyConfig):
    st_ = ffi.new("vt_detect_state *")
    out = ffi.new("vt_detect_result *")
    c = _native.detect_cfg_default()
    for f in dataclasses.fields(ShadowConfig):
        setattr(c.shadow, f.name, getattr(scfg, f.name))
    for f in dataclasses.fields(VerifyConfig):
        setattr(c.verify, f.name, getattr(vcfg, f.name))
    hyp, box = _native.detect(st_, c, gray, _native.road_area(road, gray.shape[0]), out)
    return hyp.astype(np.int64), box.astype(np.int64), st_


def both(gray, road, scfg, vcfg):
    hc, bc, stc = c_detect(gray, road, scfg, vcfg)
    ro, bo = rdetect.detect(gray, road, scfg, vcfg, **CAPS)
    assert np.array_equal(hc, ro.hypotheses)
    assert np.array_equal(bc, bo)
    assert (stc.shadow.n_runs, stc.shadow.n_dropped) == (ro.n_runs, ro.n_dropped)
    return hc, bc, ro


# ---------------------------------------------------------------- C vs oracle
@settings(max_examples=80, deadline=None)
@given(h=st.integers(8, 120), w=st.integers(8, 200), seed=st.integers(0, 2**32 - 1),
       n_cars=st.integers(0, 5), noise=st.sampled_from([0.0, 3.0, 8.0, 20.0]),
       scfg=shadow_cfgs, vcfg=verify_cfgs, rv=st.sampled_from([0, 1]))
def test_detect_c_equals_oracle(h, w, seed, n_cars, noise, scfg, vcfg, rv):
    """Random scenes and configurations, either reduce rule."""
    gray, road, _ = draw_scene(h, w, seed, n_cars, noise, scfg.polarity)
    both(gray, road, dataclasses.replace(scfg, reduce_verified=rv), vcfg)


@settings(max_examples=40, deadline=None)
@given(h=st.integers(30, 120), w=st.integers(40, 200), seed=st.integers(0, 2**32 - 1),
       n_cars=st.integers(0, 5), noise=st.sampled_from([0.0, 3.0, 8.0]))
def test_reduce_verified_invariants(h, w, seed, n_cars, noise):
    """The rule as invariants over the shadow stage's unreduced candidates (bottom-up):
    no examined hypothesis is suppressed by a verified one before it; every candidate
    left out is suppressed by a verified one before it; the boxes are verify's boxes of
    the hypotheses that pass, in order."""
    from pyvehtrack.reference import verify as rv  # noqa: PLC0415
    gray, road, _ = draw_scene(h, w, seed, n_cars, noise)
    scfg, vcfg = ShadowConfig(reduce_verified=1), VerifyConfig()
    hc, bc, _ = both(gray, road, scfg, vcfg)
    cand = [tuple(int(v) for v in c) for c in rs.find_hypotheses(
        gray, road, scfg, max_active=CAPS["max_active"], max_cand=CAPS["max_cand"],
        max_out=CAPS["max_cand"]).hypotheses]
    examined = [tuple(int(v) for v in x) for x in hc]
    assert len(examined) < CAPS["max_hyp"]          # small scenes: no capacity cut
    boxes = {c: rv.verify_one(gray, c, vcfg) for c in examined}
    for i, c in enumerate(cand):
        by = [k for k in cand[:i] if k in boxes and boxes[k] is not None and rs.suppresses(scfg, k, c)]
        assert (c in boxes) == (not by), c
    assert [list(b) for b in bc] == [boxes[c] for c in examined if boxes[c] is not None]


def test_overflow_examined_hypotheses_counts_dropped():
    """More unsuppressed edges than VT_MAX_HYPOTHESES: nothing verifies (side_min_px
    beyond any ROI), so nothing suppresses; the nearest VT_MAX_HYPOTHESES are examined and the
    rest counted in n_dropped, C and oracle alike."""
    h, w = 400, 600
    gray = np.full((h, w), 180, np.uint8)
    for y in range(20, h, 10):
        for x in range(5, w - 20, 30):
            gray[y - 2:y + 1, x:x + 20] = 20
    road = RoadArea(0, h - 1, np.zeros(h, np.int16), np.full(h, w - 1, np.int16), np.full(h, 30, np.int16))
    scfg = ShadowConfig(threshold_mode=rs.FIXED, reduce_verified=1)
    hc, bc, ro = both(gray, road, scfg, VerifyConfig(side_min_px=4096))
    assert len(hc) == lib.VT_MAX_HYPOTHESES and ro.n_dropped > 0 and len(bc) == 0


# ---------------------------------------------------------------- the codec's false step
def false_step_scene():
    """A car (body 180, 60 px wide and high, a dark shadow band 30 along its bottom
    rows, bottom row 150) on a road of 120; below it a penumbra of gray 60 that fades
    sideways over 15 px (4 levels/px: its sides stay under the vertical-edge threshold)
    and ends 42 rows lower in a HARD step to the road -- what mp4v makes of a shadow's
    soft lower border. The penumbra's step is the bottom-most shadow edge (about 100 px
    long); the car's own edge (30 -> 60) lies 42 rows above it, within one vehicle
    height, so the thesis's rule lets the step suppress it. The step's ROI (50 rows
    over the penumbra) holds the car's sides on only 8 rows (< 1/4): it fails
    verification. Returns image, road, drawn car box."""
    h, w = 240, 320
    gray = np.full((h, w), 120, np.float64)
    l, r, yb = 130, 189, 150
    gray[yb - 59:yb + 1, l:r + 1] = 180
    gray[yb - 9:yb + 1, l:r + 1] = 30
    core_l, core_r, p = l - 5, r + 5, 42
    for x in range(core_l - 15, core_r + 16):
        d = max(core_l - x, x - core_r, 0)          # px outside the core
        gray[yb + 1:yb + p + 1, x] = 60 + 4 * d
    road = RoadArea(100, h - 1, np.zeros(h, np.int16), np.full(h, w - 1, np.int16), np.full(h, 160, np.int16))
    return gray.astype(np.uint8), road, (l, yb - 59, r, yb)


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_false_step_below_a_shadow(engine):
    gray, road, car = false_step_scene()
    res = {}
    for rv in (0, 1):
        det = Detector(engine, DetectConfig(ShadowConfig(reduce_verified=rv), VerifyConfig()), road=road)
        out = det.detect(gray)
        res[rv] = out
    # the thesis's rule: the step wins, fails verification, and the car is lost
    h0 = res[0].hypotheses
    assert len(h0) >= 1 and h0[0][0] == 193 and not any(iou(b, car) >= 0.6 for b in res[0].boxes)
    # verify-aware: the failed step suppresses nothing, the car's own edge is verified
    h1 = res[1].hypotheses
    assert [tuple(x[:1]) for x in h1[:2]] == [(193,), (151,)]
    assert len(res[1].boxes) == 1 and iou(res[1].boxes[0], car) >= 0.9


def test_verified_edge_still_suppresses():
    """A verified edge keeps the thesis's suppression: a second dark-above edge inside
    the car (its rear window's lower border) is not a hypothesis under either rule."""
    gray, road, car = false_step_scene()
    gray = gray.copy()
    gray[150 + 1:, :] = 120                        # no penumbra: the car's edge is the lowest
    gray[100:112, 140:180] = 20                    # a dark band inside the body, edge at row 111
    for rv in (0, 1):
        hc, bc, _ = both(gray, road, ShadowConfig(reduce_verified=rv), VerifyConfig())
        assert 111 not in hc[:, 0] and 112 not in hc[:, 0] and hc[0][0] == 151
        assert len(bc) == 1 and iou(bc[0], car) >= 0.9


def test_reduce_verified_bad_values_rejected():
    c = _native.shadow_cfg_default()
    for bad in (-1, 2, 2**31 - 1):
        c.reduce_verified = bad
        assert lib.vt_shadow_cfg_check(c) == lib.VT_E_ARG
    with pytest.raises(ValueError, match="reduce_verified"):
        Detector("c", DetectConfig(ShadowConfig(reduce_verified=2), VerifyConfig()))


# ---------------------------------------------------------------- through the pipeline
CLIP = Path(__file__).parent / "data" / "kitti_clip"


def _jpeg_clip(n: int, quality: int = 30):
    """The first n frames of the KITTI clip through JPEG (what a codec does to them)."""
    out = []
    for p in sorted(CLIP.glob("*.png"))[:n]:
        ok, buf = cv2.imencode(".jpg", cv2.imread(str(p), cv2.IMREAD_GRAYSCALE),
                               [cv2.IMWRITE_JPEG_QUALITY, quality])
        assert ok
        out.append(cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE))
    return out


def _mean_score(img, level, s, x, y) -> int:
    """The stand-in classifier of tests/test_pipeline_classifier.py."""
    win = img[y:y + s, x:x + s].astype(np.int64)
    return int(win.sum() // (s * s)) - 100 + ((x * 7 + y * 13 + level * 5 + s) % 11)


@pytest.mark.parametrize("whole", [False, True])
def test_pipeline_c_equals_reference_with_reduce_verified(whole):
    """vt_pipeline_step with reduce_verified, ego-lane (vt_detect) and whole-road
    (vt_fulldet's shadow source), against reference.pipeline on compressed real frames:
    hypotheses and boxes exactly equal (fixed road)."""
    frames = _jpeg_clip(6)
    if whole:
        fc = FullRoadConfig(det=FullDetConfig(shadow=ShadowConfig(reduce_verified=1)))
        kw = dict(road="fixed", detect_every=1, sources=("shadow", "classifier"), model=_mean_score,
                  fullroad=fc)
    else:
        kw = dict(road="fixed", detect_every=1, shadow=config.ShadowConfig(reduce_verified=1))
    a, b = Pipeline("c", **kw), Pipeline("reference", **kw)
    n_hyp = 0
    for i, f in enumerate(frames):
        ra, rb = a.step(f), b.step(f)
        assert np.array_equal(ra.hypotheses, rb.hypotheses), i
        assert [x.box for x in ra.boxes] == [x.box for x in rb.boxes], i
        n_hyp += len(ra.hypotheses)
    assert n_hyp > 0
