"""The tracker (c/track_search.c, c/tracker.c) against its float reference
(pyvehtrack/reference/track_search.py, tracker.py, filterpy inside), plus its
lifecycle rules, capacity behaviour and bad arguments."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pyvehtrack as vt
from pyvehtrack import _native
from pyvehtrack.reference import track_search as rts
from pyvehtrack.reference import tracker as rtrk
from pyvehtrack.tracker import Tracker, cfg_to_c

ffi, lib = vt.ffi, vt.lib
# Scenes with several vehicles need the slots; `make check CHECK_DEFS=-DVT_MAX_TRACKS=1`
# runs the rest of this file against the smallest build.
needs_tracks = lambda n: pytest.mark.skipif(  # noqa: E731
    int(lib.VT_MAX_TRACKS) < n, reason=f"needs VT_MAX_TRACKS >= {n}")


def draw_car(img, l, by, w, body=200, shadow=20):
    """A rear view: bright body, dark window band, dark shadow under it (rows by-2..by+2).
    Returns the inclusive box down to the shadow's last row: the dark-above-bright edge
    the detector and the tracker both take as the bottom (VT_EDGE_DARK_ABOVE)."""
    h, W = img.shape
    top = by - w + 5
    r = l + w
    sl = slice(max(0, l), max(0, min(W, r)))
    img[max(0, top):max(0, min(h, by - 2)), sl] = body
    img[max(0, by - w // 2):max(0, min(h, by - w // 3)), max(0, l + 5):max(0, min(W, r - 5))] = 60
    img[max(0, by - 2):max(0, min(h, by + 3)), sl] = shadow
    return (l, top, r - 1, by + 2)


def make_scene(rng, cars, t, shape=(240, 320), noise=8):
    img = np.full(shape, 110, np.uint8)
    if noise:
        img += rng.integers(0, noise, shape, dtype=np.uint8)
    boxes = []
    for (x0, y0, w0, vx, vy, vw) in cars:
        l, by, w = int(x0 + vx * t), int(y0 + vy * t), int(w0 + vw * t)
        boxes.append(draw_car(img, l, by, w))
    return img, boxes


def run(engine, frames, dets_at):
    tr = Tracker(engine)
    return [tr.step(img, detections=dets_at.get(k)) for k, img in enumerate(frames)]


iou = rtrk.box_iou


@st.composite
def sequences(draw):
    seed = draw(st.integers(0, 2**31))
    n = draw(st.integers(1, 3))
    cars = []
    for k in range(n):
        cars.append((draw(st.integers(10 + 100 * k, 40 + 100 * k)), draw(st.integers(120, 200)),
                     draw(st.integers(30, 60)), draw(st.floats(-2, 2)), draw(st.floats(-0.5, 0.5)),
                     draw(st.floats(-0.3, 0.3))))
    every = draw(st.integers(3, 10))
    return seed, cars, every


# Tolerance. The fixed-point filter follows filterpy to ~1e-3 px (tests/test_kalman.py
# bounds it), so a rounded box corner can differ by 1 px only when the float value lies
# within that distance of a .5 boundary; everything after the rounding (projections,
# thresholds, association, lifecycle) is exact integer logic on both sides. So: the
# same ids in the same states in every frame, and matching boxes within IoU >= 0.9
# (a 1-px shift of one corner of a box >= 30 px wide costs < 0.07 IoU).
@settings(max_examples=25)
@given(seq=sequences())
def test_tracker_c_matches_reference(seq):
    seed, cars, every = seq
    rng = np.random.default_rng(seed)
    frames, dets_at = [], {}
    for t in range(40):
        img, boxes = make_scene(rng, cars, t)
        frames.append(img)
        if t % every == 0:
            dets_at[t] = boxes
    c_out, r_out = run("c", frames, dets_at), run("reference", frames, dets_at)
    for k, (c, r) in enumerate(zip(c_out, r_out)):
        assert [(a.id, a.state) for a in c] == [(b.id, b.state) for b in r], k
        for a, b in zip(c, r):
            assert iou(a.box, b.box) >= 0.9, (k, a, b)
            assert abs(a.velocity[0] - b.velocity[0]) <= 0.05 and abs(a.velocity[1] - b.velocity[1]) <= 0.05


def test_tracks_a_moving_car_and_reports_velocity():
    rng = np.random.default_rng(1)
    cars = [(60, 150, 50, 2.0, 0.5, 0.0)]
    tr = Tracker("c")
    for t in range(30):
        img, boxes = make_scene(rng, cars, t)
        out = tr.step(img, detections=boxes if t % 10 == 0 else None)
    assert len(out) == 1 and out[0].id == 1 and out[0].state == "confirmed"
    assert iou(out[0].box, boxes[0]) >= 0.8
    # Constant image velocity 2 px/frame right, 0.5 down (integer positions: +-0.1).
    assert abs(out[0].velocity[0] - 2.0) <= 0.1 and abs(out[0].velocity[1] - 0.5) <= 0.1


@needs_tracks(2)
@pytest.mark.parametrize("engine", ["c", "reference"])
def test_correlation_keeps_an_undetected_vehicle_and_drops_a_vanished_one(engine):
    rng = np.random.default_rng(2)
    tr = Tracker(engine)
    cars = [(60, 150, 50, 0.0, 0.0, 0.0), (200, 170, 50, 0.0, 0.0, 0.0)]
    for t in range(10):
        img, boxes = make_scene(rng, cars, t)
        out = tr.step(img, detections=boxes if t == 0 else None)
    assert sorted(o.id for o in out) == [1, 2]
    # Detection frame where the detector misses car 1 (still in the image) and car 2
    # has gone (its place is plain road): car 1 survives on correlation, car 2 is dropped.
    img, _ = make_scene(rng, cars[:1], 10)
    out = tr.step(img, detections=[])
    assert [o.id for o in out] == [1]


def test_ids_never_reused_and_full_capacity_is_defined():
    cap = int(lib.VT_MAX_TRACKS)
    tr = Tracker("c", cfg=rtrk.TrackerCfg(confirm_hits=1))
    img = np.full((240, 320), 110, np.uint8)  # plain road: searches fail, tracks coast
    boxes = [(x, 10 + 14 * k, x + 9, 19 + 14 * k) for k in range(cap + 4) for x in [5]]
    boxes = [(5 + 18 * (k % 16), 10 + 30 * (k // 16), 5 + 18 * (k % 16) + 9, 19 + 30 * (k // 16))
             for k in range(cap + 4)]
    out = tr.step(img, detections=boxes)
    assert len(out) == cap and tr._tr.dropped_full == 4
    ids = {o.id for o in out}
    for _ in range(12):  # everything coasts out and is deleted (max_coast = 9)
        out = tr.step(img)
    assert out == []
    out = tr.step(img, detections=boxes[:1])
    assert out[0].id == cap + 1 and out[0].id not in ids


@settings(max_examples=100)
@given(seed=st.integers(0, 2**31), l=st.integers(-20, 300), t=st.integers(-20, 220),
       w=st.integers(-5, 120), h=st.integers(-5, 120), prev=st.booleans(), polarity=st.sampled_from([0, 1]),
       bottom_permille=st.sampled_from([1, 10, 500, 770, 999, 1000]), side_mode=st.sampled_from([0, 1]),
       h_thresh=st.sampled_from([16, 48, 200]))
def test_track_search_exact(seed, l, t, w, h, prev, polarity, bottom_permille, side_mode, h_thresh):
    """Integer counts and comparisons on both sides: exact equality, box and sides."""
    rng = np.random.default_rng(seed)
    img, _ = make_scene(rng, [(rng.integers(0, 250), rng.integers(60, 230), rng.integers(20, 70), 0, 0, 0)], 0)
    roi = (l, t, l + w, t + h)
    cfg = rts.SearchCfg(polarity=polarity, bottom_permille=bottom_permille, side_mode=side_mode, h_thresh=h_thresh)
    sides_r = rts.Sides(True, l + 3, l + w - 3, 2, 2) if prev else None
    ref = rts.track_search(img, cfg, roi, sides_r)
    c_cfg = ffi.new("vt_track_search_cfg *", [cfg.polarity, cfg.h_thresh, cfg.v_thresh, cfg.min_h_permille,
                                               cfg.min_v_permille, cfg.bottom_permille, cfg.side_mode])
    c_roi = ffi.new("vt_box *", list(roi))
    c_sides = ffi.new("vt_track_sides *", [1, l + 3, l + w - 3, 2, 2]) if prev else ffi.NULL
    ws = ffi.new("vt_track_search_ws *")
    meas = ffi.new("vt_box *")
    found = ffi.new("int32_t *")
    assert lib.vt_track_search(ws, c_sides, c_cfg, _native.view(img, "img"), c_roi, meas, found) == lib.VT_OK
    if ref is None:
        assert found[0] == 0
    else:
        assert found[0] == 1 and (meas.left, meas.top, meas.right, meas.bottom) == ref
    if prev:
        assert (c_sides.have_prev, c_sides.prev_left, c_sides.prev_right, c_sides.max_change_left,
                c_sides.max_change_right) == (int(sides_r.have_prev), sides_r.prev_left, sides_r.prev_right,
                                              sides_r.max_change_left, sides_r.max_change_right)


@settings(max_examples=150)
@given(seed=st.integers(0, 2**31), w=st.integers(4, 90), h=st.integers(2, 40), l=st.integers(-3, 90),
       t=st.integers(-3, 40), rw=st.integers(0, 95), rh=st.integers(0, 45), polarity=st.sampled_from([0, 1]),
       h_thresh=st.sampled_from([1, 40, 300, 1020, 1021, 5000]), v_thresh=st.sampled_from([1, 40, 300, 1020, 1021, 5000]))
def test_track_search_projections_exact(seed, w, h, l, t, rw, rh, polarity, h_thresh, v_thresh):
    """The workspace's projections, against NumPy's Sobel counts: every row of the ROI
    (s * d/dy >= h_thresh, s = +1 for a dark-above edge), and, once a bottom row was
    chosen (found), every column over the rows down to it (|d/dx| >= v_thresh); edge
    replicated. Exact: the SSE2 inner loops take 8 columns at a time and the rest go
    the portable way, so widths 4..90 cover full blocks, tails and the border columns;
    thresholds past the Sobel range (1020) too."""
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, (h, w), dtype=np.uint8)
    img[:, rng.integers(0, w):] //= 3      # some structure beside the noise
    p = np.pad(img.astype(np.int32), 1, mode="edge")
    gy = (p[2:, :-2] + 2 * p[2:, 1:-1] + p[2:, 2:]) - (p[:-2, :-2] + 2 * p[:-2, 1:-1] + p[:-2, 2:])
    gx = (p[:-2, 2:] + 2 * p[1:-1, 2:] + p[2:, 2:]) - (p[:-2, :-2] + 2 * p[1:-1, :-2] + p[2:, :-2])
    cfg = rts.SearchCfg(polarity=polarity, h_thresh=h_thresh, v_thresh=v_thresh, min_h_permille=0,
                        min_v_permille=0, bottom_permille=1000, side_mode=1)
    c_cfg = ffi.new("vt_track_search_cfg *", [cfg.polarity, cfg.h_thresh, cfg.v_thresh, cfg.min_h_permille,
                                               cfg.min_v_permille, cfg.bottom_permille, cfg.side_mode])
    c_roi = ffi.new("vt_box *", [l, t, l + rw - 1, t + rh - 1])
    ws = ffi.new("vt_track_search_ws *")
    meas, found = ffi.new("vt_box *"), ffi.new("int32_t *")
    assert lib.vt_track_search(ws, ffi.NULL, c_cfg, _native.view(img, "img"), c_roi, meas, found) == lib.VT_OK
    x0, x1 = min(max(l, 0), w), min(max(l + rw - 1, -1), w - 1) + 1
    y0, y1 = min(max(t, 0), h), min(max(t + rh - 1, -1), h - 1) + 1
    if x1 - x0 < 4 or y1 - y0 < 2:
        return   # too small: nothing computed
    s = 1 if polarity == lib.VT_EDGE_DARK_ABOVE else -1
    want_h = (s * gy[y0:y1, x0:x1] >= h_thresh).sum(axis=1)
    got_h = np.frombuffer(ffi.buffer(ws.hproj), np.int32)[y0:y1]
    assert (got_h == want_h).all()
    if found[0]:
        ybest = meas.bottom
        want_v = (np.abs(gx[y0:ybest + 1, x0:x1]) >= v_thresh).sum(axis=0)
        got_v = np.frombuffer(ffi.buffer(ws.vproj), np.int32)[x0:x1]
        assert (got_v == want_v).all()


def test_python_defaults_equal_c_defaults():
    """No drift between VT_TRACKER_CFG_DEFAULT and rtrk.TrackerCfg(). The C model
    defaults are written as fractions of VT_Q16_ONE in integer arithmetic (truncated,
    e.g. 0.1 -> 6553), the Python ones round (6554): 1 LSB of Q16 apart at most."""
    c = _native.tracker_cfg_default()
    p = cfg_to_c(rtrk.TrackerCfg())
    for f in ("polarity", "h_thresh", "v_thresh", "min_h_permille", "min_v_permille", "bottom_permille",
              "side_mode"):
        assert getattr(c.search, f) == getattr(p.search, f), f
    for f in ("dt", "accel_x", "accel_y", "p_max", "p_zero", "meas_sigma_x", "meas_sigma_y",
              "init_sigma_pos", "init_sigma_vel"):
        assert abs(getattr(c.model, f) - getattr(p.model, f)) <= 1, f
    for f in ("roi_margin_min", "roi_margin_permille", "gate_permille", "gate_bottom_permille",
              "confirm_hits", "max_coast",
              "match_iou_permille", "keep_ncc", "init_max_change", "tmatch_radius",
              "tmatch_ncc_permille", "tmatch_max", "part_permille", "min_width", "scale_tol_permille",
              "snap_bottom", "birth_search"):
        assert getattr(c, f) == getattr(p, f), f


def test_tracker_bad_arguments():
    tr = _native.tracker_new()
    cfg = _native.tracker_cfg_default()
    img = np.zeros((40, 40), np.uint8)
    v = _native.view(img, "img")
    out = ffi.new("vt_track_out[4]")
    n = ffi.new("int32_t *")
    box = ffi.new("vt_box[1]", [[1, 1, 10, 10]])
    step = lib.vt_tracker_step
    assert step(ffi.NULL, cfg, v, 0, ffi.NULL, 0, out, 4, n) == lib.VT_E_ARG
    assert step(tr, ffi.NULL, v, 0, ffi.NULL, 0, out, 4, n) == lib.VT_E_ARG
    assert step(tr, cfg, ffi.NULL, 0, ffi.NULL, 0, out, 4, n) == lib.VT_E_ARG
    assert step(tr, cfg, v, 0, ffi.NULL, 0, out, 4, ffi.NULL) == lib.VT_E_ARG
    assert step(tr, cfg, v, 0, ffi.NULL, 0, ffi.NULL, 4, n) == lib.VT_E_ARG
    assert step(tr, cfg, v, 0, ffi.NULL, 0, out, -1, n) == lib.VT_E_ARG
    assert step(tr, cfg, v, 1, ffi.NULL, 1, out, 4, n) == lib.VT_E_ARG
    assert step(tr, cfg, v, 1, box, -1, out, 4, n) == lib.VT_E_SIZE
    assert step(tr, cfg, v, 1, box, 10**6, out, 4, n) == lib.VT_E_SIZE
    bad = ffi.new("vt_box[1]", [[10, 1, 1, 10]])  # right < left
    assert step(tr, cfg, v, 1, bad, 1, out, 4, n) == lib.VT_E_ARG
    huge = ffi.new("vt_box[1]", [[-(2**31), 0, 2**31 - 1, 10]])
    assert step(tr, cfg, v, 1, huge, 1, out, 4, n) == lib.VT_E_ARG
    for field, value in [("confirm_hits", 0), ("match_iou_permille", 0), ("match_iou_permille", 1001),
                         ("max_coast", -1), ("keep_ncc", 16385), ("roi_margin_min", -1)]:
        c2 = _native.tracker_cfg_default()
        setattr(c2, field, value)
        assert step(tr, c2, v, 0, ffi.NULL, 0, out, 4, n) == lib.VT_E_ARG, field
    c2 = _native.tracker_cfg_default()
    c2.model.dt = 0
    assert step(tr, c2, v, 0, ffi.NULL, 0, out, 4, n) == lib.VT_E_ARG
    for field, value in [("h_thresh", 0), ("bottom_permille", 0), ("bottom_permille", 1001), ("side_mode", 2),
                         ("polarity", -1), ("min_v_permille", 1001)]:
        c2 = _native.tracker_cfg_default()
        setattr(c2.search, field, value)
        assert step(tr, c2, v, 0, ffi.NULL, 0, out, 4, n) == lib.VT_E_ARG, field
    assert tr.frame == 0  # nothing above touched the tracker
    assert lib.vt_tracker_init(ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_tracker_cfg_default(ffi.NULL) == lib.VT_E_ARG


@needs_tracks(3)
def test_tracker_output_capacity_and_guard():
    tr = _native.tracker_new()
    cfg = _native.tracker_cfg_default()
    img = np.full((100, 200), 110, np.uint8)
    dets = ffi.new("vt_box[3]", [[5, 5, 30, 30], [60, 5, 90, 30], [120, 5, 150, 30]])
    out = ffi.new("vt_track_out[4]")
    for k in range(4):
        out[k].id = 0x5A5A5A5A
    n = ffi.new("int32_t *")
    s = lib.vt_tracker_step(tr, cfg, _native.view(img, "img"), 1, dets, 3, out, 2, n)
    assert s == lib.VT_E_CAPACITY and n[0] == 2
    assert out[2].id == 0x5A5A5A5A and out[3].id == 0x5A5A5A5A  # nothing past out_cap


def test_python_tracker_bad_input():
    with pytest.raises(ValueError):
        Tracker("gpu")
    with pytest.raises(ValueError):
        Tracker(detect_every=0)
    tr = Tracker()
    with pytest.raises(TypeError):
        tr.step([[1, 2]])
    with pytest.raises(TypeError):
        tr.step(np.zeros((10, 10), np.float32))
    with pytest.raises(ValueError):
        tr.step(np.zeros((10, 10, 2), np.uint8))
    with pytest.raises(ValueError):
        tr.step(np.zeros((10, 10), np.uint8), detections=np.zeros((2, 3)))
    with pytest.raises(ValueError):
        tr.step(np.zeros((10, 10), np.uint8), detections=[[0, 0, np.nan, 1]])
    with pytest.raises(vt.VtError, match="vt_tracker_step"):
        tr.step(np.zeros((10, 10), np.uint8), detections=[[5, 5, 1, 1]])
    assert tr.step(np.zeros((1, 1), np.uint8)) == []
    big = np.zeros((vt.MAX_HEIGHT * 2 + 1, vt.MAX_WIDTH * 2 + 3, 3), np.uint8)
    assert tr.step(big) == []  # downscaled, not clipped, not an error


def test_track_list_check_is_the_one_rule_range_and_ttc_apply():
    """vt_track_list_check (written once for vt_range_step and vt_ttc_scale_step): free
    slots are ignored; a live track needs an id > 0, unique, and an ordered box."""
    ffi, lib = _native.ffi, _native.lib
    t = ffi.new("vt_track_out[3]")
    for i in range(3):
        t[i].state, t[i].id = lib.VT_TRACK_CONFIRMED, i + 1
        t[i].box.left, t[i].box.top, t[i].box.right, t[i].box.bottom = 10, 10, 20, 20
    assert lib.vt_track_list_check(t, 3) == lib.VT_OK
    assert lib.vt_track_list_check(t, 0) == lib.VT_OK
    assert lib.vt_track_list_check(ffi.NULL, 0) == lib.VT_OK
    assert lib.vt_track_list_check(ffi.NULL, 1) == lib.VT_E_ARG
    assert lib.vt_track_list_check(t, -1) == lib.VT_E_ARG
    t[2].id = 1                                              # a repeated id
    assert lib.vt_track_list_check(t, 3) == lib.VT_E_ARG
    t[2].state = lib.VT_TRACK_FREE                           # ... in a free slot: ignored
    assert lib.vt_track_list_check(t, 3) == lib.VT_OK
    t[1].id = 0
    assert lib.vt_track_list_check(t, 3) == lib.VT_E_ARG
    t[1].id, t[1].box.right = 2, 9                           # right < left
    assert lib.vt_track_list_check(t, 3) == lib.VT_E_ARG
