"""Lane stage (c/lane.c) against its float oracle (pyvehtrack/reference/lane.py), on
synthetic road scenes, on real frames, on bad frames and bad arguments.

Tolerances, and why:
  * Hough lines: within 1 accumulator bin in theta and in rho. Everything before the
    votes is exact integer arithmetic in both (same marking centres); C computes
    rho = x cos + y sin with Q1.14 table values, each within 0.5/16384 of the exact
    sine, so |rho_C - rho| <= (|x| + |y|) / 32768 < 0.04 px for a 640-px working frame:
    a vote moves to the next bin only when the exact rho lies that close to a bin
    boundary, which can move a peak by one bin (or flip a tie between neighbours).
    Not covered: a near-tie, where the oracle's window holds another cell more than
    one bin away with at most one vote less (a flat ridge: short dashed lines in small
    frames); there a single moved vote decides, and only the slot is compared.
  * Refined lines and polylines: within 0.25 px across the line. They are least-squares
    fits to the same centres (Q16 in C, float here; the rounding is ~1e-4 px); the
    point sets differ only if a centre lies at the edge of a window. Within 1 px
    instead when (a) the Hough cells differ by a bin: the refinement windows then
    start from lines one bin apart and a centre near an edge can enter one fit only
    (lines flatter than ego_theta_max are not refined: for them one theta bin moves
    the line by pixels and only the bin is compared), or (b) the vanishing rows differ
    by one: it is the floor of a quotient that symmetric scenes make an exact integer,
    and the Q16 and float quotients can fall on either side; the extension segments
    then start a row apart. Not compared: rows above an extension segment chosen by a
    margin of one count over any other slope, the neighbouring ones included (the
    oracle records that row, `sure_y`), where a centre at a window edge can tip the
    choice. (Until issue 8 the neighbours were left out of that margin: a flat,
    unrefined outer line -- C's from the Q1.14 sin/cos of its cell, ~0.01 px from the
    float one -- counted a centre 0.003 px outside the window and chose the next
    slope, 1 px away in x at the next vertex; a hypothesis seed found it.)
  * Road area: within 1 px per row (C rounds the Q16 x half up, the oracle the float x:
    only a .5 tie can flip), plus the boundary lines' own tolerance scaled to input px.
Outer lines (left-most, right-most) are kept only if they pass within a tolerance of
the vanishing point of the ego pair; a one-bin difference in an ego line moves that
point a little, and an outer line at the tolerance is then kept by one engine only
(about 1 scene in 200 here). Their presence is not compared; when both engines report
them they are held to the rules above. The ego lines' presence must agree.
  * Without an ego vanishing point the lines end below the crossing row of the pair
    that confirmed the selection (pair_vp_y): a floor as vp_y, so within one row; when
    the two engines' rows differ the extensions aim at different rows and only the
    band is compared, as for (b).
"""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from pyvehtrack import VtError
from pyvehtrack import _native as N
from pyvehtrack import eval_lanes as ev
from pyvehtrack.lane import LaneDetector, default_config, tusimple_lanes
from pyvehtrack.reference import lane as rl

ffi, lib = N.ffi, N.lib
DATA = Path(__file__).parent / "data"


# ------------------------------------------------------------------ synthetic scenes
def road_scene(w, h, seed, vp_dx=0.0, vp_y=0.38, width_b=0.8, dashed=(False, False),
               outer=(False, False), noise=3.0, contrast=110, bg=80, mark_w=0.02,
               draw=(True, True)):
    """Gray road scene: two ego lane markings meeting at a vanishing point, narrower
    with distance; optional dashes (period shrinking with distance), outer lines,
    Gaussian noise. draw=(left, right) hides a marking."""
    rng = np.random.default_rng(seed)
    img = np.full((h, w), float(bg))
    img[: int(vp_y * h)] = bg + 40
    vx, vy = w / 2 + vp_dx * w, vp_y * h
    xl, xr = w / 2 - width_b * w / 2, w / 2 + width_b * w / 2
    lines = []
    if draw[0]:
        lines.append((xl, dashed[0]))
    if draw[1]:
        lines.append((xr, dashed[1]))
    if outer[0]:
        lines.append((xl - width_b * w, False))
    if outer[1]:
        lines.append((xr + width_b * w, False))
    for xb, dash in lines:
        for y in range(int(vy) + 2, h):
            t = (y - vy) / (h - 1 - vy)
            if dash and int(8 / max(t, 0.05)) % 2:
                continue
            xc = vx + (xb - vx) * t
            half = max(0.6, mark_w * w * t / 2)
            x0, x1 = int(round(xc - half)), int(round(xc + half))
            if x1 < 0 or x0 >= w:
                continue
            img[y, max(x0, 0):min(x1, w - 1) + 1] = bg + contrast
    img += rng.normal(0, noise, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


scenes = st.fixed_dictionaries({
    "w": st.integers(64, 700), "h": st.integers(120, 500), "seed": st.integers(0, 2**31),
    "vp_dx": st.floats(-0.08, 0.08), "vp_y": st.floats(0.30, 0.45),
    "width_b": st.floats(0.5, 1.0), "dashed": st.tuples(st.booleans(), st.booleans()),
    "outer": st.tuples(st.booleans(), st.booleans()), "noise": st.floats(0.0, 6.0),
    "contrast": st.integers(50, 150), "bg": st.integers(30, 120),
    "mark_w": st.floats(0.01, 0.04)})


def _ego_theta_deg(p):
    """Largest |theta| (normal angle, degrees) of the two ego markings of a scene."""
    w, h = p["w"], p["h"]
    vx, vy = w / 2 + p["vp_dx"] * w, p["vp_y"] * h
    dx = max(abs(w / 2 - p["width_b"] * w / 2 - vx), abs(w / 2 + p["width_b"] * w / 2 - vx))
    return float(np.degrees(np.arctan2(dx, h - 1 - vy)))


def _c_verts(line):
    return [(int(line.vy[i]), line.vx[i] / 65536.0) for i in range(line.n_verts)]


def _near_tie(frame, slot, line):
    """Does the oracle's NMS window around this line's peak hold another cell more than
    one bin away with at least votes - 1?"""
    acc, bin0 = frame.accs[0 if slot < 2 else 1]
    cfg = rl.DEFAULT
    k, col = line.theta_bin, line.rho_bin - bin0
    for kk in range(max(0, k - cfg.nms_theta_bins), min(acc.shape[0], k + cfg.nms_theta_bins + 1)):
        for cc in range(max(0, col - cfg.nms_rho_bins), min(acc.shape[1], col + cfg.nms_rho_bins + 1)):
            if max(abs(kk - k), abs(cc - col)) > 1 and acc[kk, cc] >= line.votes - 1:
                return True
    return False


def _same_cap(ra, rb, where):
    """Without an ego vanishing point the lines end below the confirming pair's
    crossing row (pair_vp_y, a floor: one row apart at most between C's Q16 and the
    oracle's float lines, as vp_y). True when both engines aim their extensions at the
    same row; else only the band is compared."""
    if ra.pair_vp_y >= 0 and rb.pair_vp_y >= 0:
        assert abs(ra.pair_vp_y - rb.pair_vp_y) <= 1, where
    return bool(ra.vp_known) or ra.pair_vp_y == rb.pair_vp_y


def compare_frames(a, b, where=""):
    """C LaneResult a against oracle LaneResult b, with the tolerances of the module doc."""
    ra, rb = a.raw, b.raw
    assert (ra.scale, ra.w, ra.h, ra.roi_top, ra.band_top) == \
        (rb.scale, rb.W, rb.H, rb.roi_top, rb.band_top), where
    # The vanishing row is known when it falls in [roi_top, vp_low]: at those limits
    # the one-row rounding difference (see above) can make it known to one engine only,
    # and then the extensions aim at different rows: only the band is compared.
    ext = ra.vp_known == rb.vp_known
    if ext:
        assert abs(ra.vp_y - rb.vp_y) <= 1, where
    else:
        y = ra.vp_y if ra.vp_known else rb.vp_y
        vp_low = ra.h * rl.DEFAULT.vp_low_permille // 1000
        assert min(abs(y - ra.roi_top), abs(y - vp_low)) <= 1, where
    ext = ext and _same_cap(ra, rb, where)
    same_slots = True
    strict = {}   # slot -> (first working row compared, x tolerance there in working px)
    for k in range(4):
        la, lb = ra.lines[k], rb.lines[k]
        if (la.state != 0) != (lb is not None):
            assert k in (0, 3), f"{where} slot {k}: C {la.state}, oracle {lb}"
            same_slots = False
            continue
        if lb is None:
            continue
        assert la.state == lb.state, where
        if lb.state != rl.HELD and _near_tie(rb, k, lb):
            continue
        assert abs(la.theta_bin - lb.theta_bin) <= 1 and abs(la.rho_bin - lb.rho_bin) <= 1, \
            f"{where} slot {k}: C bin ({la.theta_bin}, {la.rho_bin}), oracle ({lb.theta_bin}, {lb.rho_bin})"
        same_bin = (la.theta_bin, la.rho_bin) == (lb.theta_bin, lb.rho_bin)
        if same_bin:
            assert la.theta == lb.theta_qdeg and la.rho == lb.rho, where
        elif abs(lb.theta_qdeg) > rl.DEFAULT.ego_theta_max_qdeg:
            continue  # unrefined flat line: one theta bin moves it by pixels; the bin rule holds
        # Distances across the line (x difference / sqrt(1 + slope^2)): flat outer lines
        # move a lot in x for a small move across.
        across = 1.0 / np.hypot(1.0, lb.slope)
        tol = 0.25 if same_bin else 1.0
        assert abs(la.xb / 65536 - lb.xb) * across <= tol, where
        # Above the first extension segment decided by a margin of <= 1 count (sure_y),
        # one centre at a window edge may tip C and the oracle apart: not compared.
        vc = _c_verts(la)
        tol = 0.25 if ra.vp_y == rb.vp_y and same_bin else 1.0
        if lb.sure_y < 0 and ext:
            assert abs(la.y_top - lb.y_top) <= 1, where
        first = max(la.y_top, lb.y_top, lb.sure_y, -1 if ext else max(la.vy[1], lb.verts[1][0]))
        for y in range(first, ra.h):
            d = abs(rl.polyline_x(vc, y) - rl.polyline_x(lb.verts, y)) * across
            assert d <= tol, f"{where} slot {k} row {y}"
        strict[k] = (first if lb.sure_y >= 0 or not ext else -1, tol / across)
    if same_slots:
        assert a.road_valid == b.road_valid, where
        bounds = [1 if ra.lines[1].state else 0, 2 if ra.lines[2].state else 3]
        if a.road_valid and all(k in strict for k in bounds):
            n = ra.scale
            first_w = max(strict[k][0] for k in bounds)
            if first_w < 0:
                # the lanes' top rows agree within one working row = scale input rows
                assert abs(a.road_y_top - b.road_y_top) <= n, where
            # x per input row: the polylines' tolerance scaled to input pixels, plus the
            # rounding of either engine to whole pixels.
            xtol = 1 + max(strict[k][1] for k in bounds) * n
            first = max(a.road_y_top, b.road_y_top, (first_w + 1) * n)
            rows = slice(first, a.road_y_bottom + 1)
            for nm in ("x_left", "x_right", "lane_width"):
                diff = np.abs(getattr(a, nm)[rows].astype(float) - getattr(b, nm)[rows])
                assert diff.size == 0 or diff.max() <= xtol * (2 if nm == "lane_width" else 1), \
                    f"{where} {nm}"


def test_default_config_is_the_oracles():
    assert default_config() == rl.DEFAULT


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenes)
def test_synthetic_scene_c_matches_oracle(p):
    # Ego markings steeper than ego_theta_max (65 degrees) by a margin: at the limit
    # itself one theta bin decides whether a line may be an ego line at all.
    assume(_ego_theta_deg(p) <= 60)
    img = road_scene(**p)
    a = LaneDetector("c").detect(img)
    b = LaneDetector("reference").detect(img)
    compare_frames(a, b, str(p))
    # A solid ego marking drawn in full contrast must be found (C and oracle agree on the
    # slots, checked above), unless it sits at the frame's edge, the working frame is
    # tiny (an extreme aspect ratio downscaled to fit work_width_max x work_height_max),
    # or it is drawn wider than the widest marking accepted
    # (mark_w_bottom_permille of the width; the renderer adds a pixel). A dashed marking
    # can leave too few dashes in the Hough band of a small frame.
    if p["width_b"] <= 0.9 and a.raw.w >= 64 and a.raw.h >= 48 \
            and p["mark_w"] * p["w"] + 1 <= rl.DEFAULT.mark_w_bottom_permille / 1000 * p["w"]:
        for slot, dashed in ((1, p["dashed"][0]), (2, p["dashed"][1])):
            assert dashed or a.raw.lines[slot].state != 0, (slot, p)


def test_synthetic_scene_is_found_where_drawn():
    # Not only agreement: the lines found are the markings drawn (within 2 px at the
    # bottom row, the marking half-width plus the refinement's rounding).
    w, h = 640, 480
    img = road_scene(w, h, 1, vp_dx=0.03, vp_y=0.4, width_b=0.7, noise=2.0)
    res = LaneDetector("c").detect(img)
    vx, vy = w / 2 + 0.03 * w, 0.4 * h
    for side, xb in (("left", w / 2 - 0.35 * w), ("right", w / 2 + 0.35 * w)):
        ln = res.lane(side)
        assert ln is not None and ln.state == "found"
        pts = ln.points
        for x, y in pts[:: max(1, len(pts) // 20)]:
            t = (y - vy) / (h - 1 - vy)
            assert abs(x - (vx + (xb - vx) * t)) <= 2.0, (side, x, y)
        assert pts[:, 1].min() < vy + 0.1 * h  # runs up to near the vanishing point
    assert res.road_valid and res.road.shape[1] == 2
    assert res.vanishing_row is not None and abs(res.vanishing_row - vy) <= 6


def test_tracker_holds_a_hidden_marking_then_drops_it():
    cfg = default_config()
    c, r = LaneDetector("c"), LaneDetector("reference")
    seq = [road_scene(400, 300, i, vp_dx=0.01 * i, draw=(True, i < 3)) for i in range(3 + cfg.track_hold + 2)]
    for i, img in enumerate(seq):
        a, b = c.detect(img), r.detect(img)
        compare_frames(a, b, f"frame {i}")
        right = a.raw.lines[2]
        if i < 3:
            assert right.state == 1
        elif i - 2 <= cfg.track_hold:
            assert right.state == 2 and right.held == i - 2, i
        else:
            assert right.state == 0, i
    c.reset()
    assert c.detect(seq[-1]).raw.lines[2].state == 0


def test_tracker_smooths_toward_the_new_line():
    c, r = LaneDetector("c"), LaneDetector("reference")
    a0 = c.detect(road_scene(400, 300, 0, vp_dx=0.0))
    r.detect(road_scene(400, 300, 0, vp_dx=0.0))
    img = road_scene(400, 300, 1, vp_dx=0.02)
    a1, b1 = c.detect(img), r.detect(img)
    compare_frames(a1, b1)
    fresh = LaneDetector("c").detect(img)
    for k in (1, 2):
        x0, x1, xf = (v.raw.lines[k].xb / 65536 for v in (a0, a1, fresh))
        # alpha = 1/2: halfway between the last frame's line and this frame's.
        assert abs(x1 - (x0 + xf) / 2) <= 0.01


def test_collapsed_pair_gives_no_vanishing_row():
    """tusimple-vehicles-dev 4065 (640x360 copy, overcast): the refine passes pull the chosen
    ego pair onto one dashed marking, 27 px apart at the bottom row, about 4% of W. The two
    lines still meet, at row 224.5 (449 at 1280x720, against a camera horizon near 340):
    that is no vanishing point, so neither engine reports one (vp_known needs the pair to
    be at least half the selection's minimum width, W * lane_w_min_permille / 2000, apart
    at the bottom; 80 px here). Without the check both reported 224.5.
    The frame collapses the pair with the lane defaults of 2026-11-29 (grad_min 12,
    mark_wmin_bottom 8, top_margin 37); the cross-validated defaults since find only the left
    line there, so the check is exercised with the earlier set."""
    img = cv2.imread(str(DATA / "tusimple_vehicles_4065_gray_640x360.png"), cv2.IMREAD_GRAYSCALE)
    cfg = replace(default_config(), grad_min=12, mark_wmin_bottom_permille=8, top_margin_permille=37)
    for engine in ("c", "reference"):
        res = LaneDetector(engine, cfg=cfg).detect(img)
        left, right = res.lane("left"), res.lane("right")
        assert left is not None and right is not None, engine   # the pair itself is still reported
        gap = right.points[np.argmax(right.points[:, 1]), 0] - left.points[np.argmax(left.points[:, 1]), 0]
        assert 0 < gap < img.shape[1] * cfg.lane_w_min_permille / 2000, (engine, gap)
        assert res.vanishing_row is None, (engine, res.vanishing_row)


# ------------------------------------------------------------------ real frames
def _labels():
    return json.loads((DATA / "lane_tusimple_ego_labels_640x360.json").read_text())


@pytest.mark.parametrize("item", _labels(), ids=lambda it: it["file"][14:33])
def test_real_tusimple_frames(item):
    """Regression on 4 TuSimple frames (640x360 copies): both ego lanes are within N = 10 px
    (TuSimple's 20 px at 1280x720, divided by cos(angle) as TuSimple does) of the labels
    on >= 90% of the labelled rows (measured 95.5-99.1%), with no false or missed lane;
    and C agrees with the oracle."""
    img = cv2.imread(str(DATA / item["file"]), cv2.IMREAD_GRAYSCALE)
    a = LaneDetector("c").detect(img)
    b = LaneDetector("reference").detect(img)
    compare_frames(a, b, item["file"])
    _assert_ten_px_rule(tusimple_lanes(a, item["h_samples"], img.shape[1]), item)


def _assert_ten_px_rule(pred, item):
    """The benchmark's 20 px rule at twice the scale == 10 px on the 640x360 copies."""
    acc, fp, fn = ev.bench([[2 * x if x >= 0 else -2 for x in p] for p in pred],
                           [[2 * x if x >= 0 else -2 for x in g] for g in item["ego_lanes"]],
                           [2 * y for y in item["h_samples"]])
    assert fp == 0 and fn == 0 and acc >= 0.90, (acc, fp, fn)


@pytest.mark.skipif(int(N.lib.VT_MAX_WIDTH) < 1920 or int(N.lib.VT_MAX_HEIGHT) < 1080,
                    reason="needs VT_MAX_WIDTH x VT_MAX_HEIGHT >= 1920 x 1080")
@pytest.mark.parametrize("size, k", [((960, 540), 3), ((1600, 900), 5), ((1920, 1080), 6)])
@pytest.mark.parametrize("item", _labels(), ids=lambda it: it["file"][14:33])
def test_real_tusimple_frames_at_other_resolutions(item, size, k):
    """The common 16:9 camera sizes all work at 320 x 180, where the defaults were tuned:
    the working frame is the input box-downscaled by an integer k, not only a power of two
    (which gave 240 x 135 at 960 and 1920 px wide, 200 x 112 at 1600: ego accuracy 86.8,
    86.8 and 82.0% on tusimple-lane-test100 against 89.3% at 1280). The 640x360 copies
    upscaled (linear) must pass test_real_tusimple_frames' rule, in the copy's pixels, and
    C must agree with the oracle."""
    small = cv2.imread(str(DATA / item["file"]), cv2.IMREAD_GRAYSCALE)
    img = cv2.resize(small, size, interpolation=cv2.INTER_LINEAR)
    # work_width=None: the lane stage at the frame's own size (the pipeline's default would
    # first downscale frames wider than 1280 px to 1280)
    a = LaneDetector("c", work_width=None).detect(img)
    b = LaneDetector("reference", work_width=None).detect(img)
    assert (a.work_scale, a.raw.w, a.raw.h) == (k, 320, 180) and b.work_scale == k
    assert a.work_shift == -1
    compare_frames(a, b, f"{item['file']} at {size}")
    f = size[0] / small.shape[1]
    hs = item["h_samples"]
    pred = []
    for ln in a.lanes:
        if ln.side in ("left", "right"):
            pts = (np.asarray(ln.points) + 0.5) / f - 0.5       # back to the copy's pixels
            pred.append(ev.sample_points(pts, hs, small.shape[1]))
    _assert_ten_px_rule(pred, item)


@pytest.mark.skipif(int(N.lib.VT_MAX_WIDTH) < 1920 or int(N.lib.VT_MAX_HEIGHT) < 1080,
                    reason="needs VT_MAX_WIDTH x VT_MAX_HEIGHT >= 1920 x 1080")
def test_scale_seven_c_matches_oracle():
    """k = 7 (a 1920 px frame with work_width_max 280: 1920 / 6 = 320 is too wide): the
    reciprocal division's largest block, 49 pixels, in C against the oracle's exact
    integer mean, through the whole lane stage."""
    small = cv2.imread(str(DATA / _labels()[0]["file"]), cv2.IMREAD_GRAYSCALE)
    img = cv2.resize(small, (1920, 1080), interpolation=cv2.INTER_LINEAR)
    a = LaneDetector("c", work_width=None, work_width_max=280).detect(img)
    b = LaneDetector("reference", work_width=None, work_width_max=280).detect(img)
    assert (a.work_scale, a.raw.w, a.raw.h) == (7, 274, 154)
    compare_frames(a, b, "scale 7")


def test_real_udacity_frame():
    img = cv2.imread(str(DATA / "lane_udacity_solidWhiteCurve_gray_640x360.png"), cv2.IMREAD_GRAYSCALE)
    a = LaneDetector("c").detect(img)
    b = LaneDetector("reference").detect(img)
    compare_frames(a, b, "udacity")
    assert a.lane("left") is not None and a.lane("right") is not None and a.road_valid
    # Checked by eye: the dashed left marking meets the bottom row near x = 126, the
    # solid right one near x = 591, and they meet near row 206 (the horizon of this
    # camera is low: the vanishing point lies inside the Hough band). Within 6 px = 3
    # working pixels.
    left, right = a.lane("left").points, a.lane("right").points
    assert abs(left[-1, 0] - 126) <= 6 and abs(right[-1, 0] - 591) <= 6
    assert a.vanishing_row is not None and abs(a.vanishing_row - 206) <= 6
    # Both lines end just below the vanishing point, never above it.
    assert left[0, 1] > a.vanishing_row and right[0, 1] > a.vanishing_row


# ------------------------------------------------------------------ bad frames
@pytest.mark.parametrize("engine", ["c", "reference"])
def test_bad_frames_give_an_empty_result_or_a_clear_error(engine):
    det = LaneDetector(engine)
    rng = np.random.default_rng(0)
    for img in (np.zeros((480, 640), np.uint8), np.full((480, 640), 255, np.uint8),
                rng.integers(0, 256, (480, 640), dtype=np.uint8),
                rng.integers(0, 256, (16, 16), dtype=np.uint8),
                np.tile((np.arange(640) % 8 < 2).astype(np.uint8) * 255, (480, 1))):
        det.reset()
        res = det.detect(img)
        assert res.lanes == [] and not res.road_valid and res.road.shape == (0, 2)
        assert res.x_left.shape == (img.shape[0],) and not res.x_left.any()
    for shape in ((1, 1), (15, 640), (480, 15)):
        with pytest.raises(ValueError, match="too small"):
            det.detect(np.zeros(shape, np.uint8))
    with pytest.raises(ValueError, match="empty image"):
        det.detect(np.zeros((0, 0), np.uint8))
    with pytest.raises(TypeError):
        det.detect(np.zeros((64, 64), np.float32))
    with pytest.raises(TypeError):
        det.detect([[0] * 64] * 64)
    with pytest.raises(ValueError):
        det.detect(np.zeros((64, 64, 2), np.uint8))


# The big frame is downscaled to the core's maximum; only when that maximum is at least
# twice the original's width does the lane stage work at the original's resolution
# (a 700-px build halves it, and the lines found legitimately differ).
@pytest.mark.skipif(int(N.lib.VT_MAX_WIDTH) < 1280, reason="needs VT_MAX_WIDTH >= 1280")
def test_huge_and_colour_frames():
    # A frame whose lines are found alike at both working widths (the point here is the
    # coordinate mapping; on 0601_1494452495543904834 the left line's angle differs
    # between the 320- and 240-px working frames with the issue-8 defaults, both lines
    # within TuSimple's threshold of the label: 98% and 100% row accuracy).
    img = cv2.imread(str(DATA / "lane_tusimple_0531_1492626726476963805_gray_640x360.png"),
                     cv2.IMREAD_GRAYSCALE)
    det = LaneDetector("c")
    small = det.detect(img)
    det.reset()
    colour = det.detect(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR))
    assert [ln.side for ln in colour.lanes] == [ln.side for ln in small.lanes]
    big = cv2.resize(img, (3200, 1800), interpolation=cv2.INTER_NEAREST)
    det.reset()
    with pytest.warns(UserWarning, match="downscaled"):
        res = det.detect(big)
    assert "downscaled" in res.note and res.input_scale < 1
    assert res.x_left.shape == (1800,)
    # The same lanes in the big frame's coordinates (x5). The big frame is first
    # downscaled to 1920x1080 (x0.6), then worked on at 240 px wide (s = 3) instead of
    # 320: one working pixel is 8 / 0.6 = 13.3 input px. At the middle of each lane the
    # two results agree within that pixel (measured: <= 1 px).
    for ln in small.lanes:
        other = res.lane(ln.side)
        if other is None:
            # An outer line found at the vote floor in the 320-px working frame (here the
            # left-most, 8 votes with the defaults chosen in issue 8) can fall below it in
            # the 240-px one: only the ego lines must be in both.
            assert ln.side in ("left-most", "right-most") and ln.votes <= 2 * default_config().vote_min
            continue
        x, y = ln.points[len(ln.points) // 2]
        pts = other.points[np.argsort(other.points[:, 1])]
        xb = np.interp(5 * (y + 0.5) - 0.5, pts[:, 1], pts[:, 0])
        # Measured across the line (dx / sqrt(1 + slope^2)): a flat outer line's x
        # moves by |slope| px per px the line moves across.
        slope = np.polyfit(pts[:, 1], pts[:, 0], 1)[0]
        assert abs(xb - (5 * (x + 0.5) - 0.5)) / np.hypot(1.0, slope) <= 8 / 0.6


# ------------------------------------------------------------------ C arguments
def _st():
    return N.lane_state_new()


def test_c_null_arguments():
    cfg, st_ = N.lane_cfg_default(), _st()
    res, road = ffi.new("vt_lane_result *"), ffi.new("vt_road_area *")
    img = np.zeros((64, 64), np.uint8)
    v = N.view(img, "img")
    E = lib.VT_E_ARG
    assert lib.vt_lane_detect(st_, ffi.NULL, v, res, road) == E
    assert lib.vt_lane_detect(ffi.NULL, cfg, v, res, road) == E
    assert lib.vt_lane_detect(st_, cfg, ffi.NULL, res, road) == E
    assert lib.vt_lane_detect(st_, cfg, v, ffi.NULL, road) == E
    assert lib.vt_lane_detect(st_, cfg, v, res, ffi.NULL) == lib.VT_OK  # road is optional
    v.px = ffi.NULL
    assert lib.vt_lane_detect(st_, cfg, v, res, road) == E
    assert lib.vt_lane_cfg_check(ffi.NULL) == E
    assert lib.vt_lane_cfg_default(ffi.NULL) == E
    assert lib.vt_lane_reset(ffi.NULL) == E
    out = ffi.new("vt_q16 *")
    assert lib.vt_lane_line_x(ffi.NULL, 0, out) == E
    assert lib.vt_lane_line_x(res.lines, 0, ffi.NULL) == E
    with pytest.raises(VtError, match="vt_lane_detect"):
        N.lane_detect(cfg, st_, np.zeros((8, 8), np.uint8), res)


@pytest.mark.parametrize("w,h,stride", [(0, 64, 64), (64, 0, 64), (-5, 64, 64), (64, -1, 64),
                                        (64, 64, 63), (15, 64, 64), (64, 15, 64),
                                        (lib.VT_MAX_WIDTH + 1, 64, lib.VT_MAX_WIDTH + 1),
                                        (64, lib.VT_MAX_HEIGHT + 1, 64), (2**31 - 1, 2**31 - 1, 2**31 - 1)])
def test_c_bad_sizes(w, h, stride):
    cfg, st_ = N.lane_cfg_default(), _st()
    res = ffi.new("vt_lane_result *")
    buf = np.zeros(64 * 64, np.uint8)
    v = ffi.new("vt_image_u8 *")
    v.px = ffi.cast("uint8_t *", buf.ctypes.data)
    v.w, v.h, v.stride = w, h, stride
    assert lib.vt_lane_detect(st_, cfg, v, res, ffi.NULL) == lib.VT_E_SIZE


def test_c_frame_too_big_for_the_working_limits():
    cfg = N.lane_cfg_default()
    cfg.work_width_max = 16
    img = np.zeros((64, 1024), np.uint8)  # 1024 >> 3 = 128 > 16
    with pytest.raises(VtError) as e:
        N.lane_detect(cfg, _st(), img, ffi.new("vt_lane_result *"))
    assert e.value.status == lib.VT_E_SIZE


def test_c_config_fields_out_of_range():
    from dataclasses import fields
    assert lib.vt_lane_cfg_check(N.lane_cfg_default()) == lib.VT_OK
    for f in fields(rl.LaneConfig):
        for bad in (-10**6, 2**31 - 1):
            cfg = N.lane_cfg_default()
            setattr(cfg, f.name, bad)
            assert lib.vt_lane_cfg_check(cfg) < 0, (f.name, bad)
            res = ffi.new("vt_lane_result *")
            assert lib.vt_lane_detect(_st(), cfg, N.view(np.zeros((64, 64), np.uint8), "i"), res,
                                      ffi.NULL) < 0
    cap = {"work_width_max": lib.VT_LANE_MAX_WORK_W + 1, "work_height_max": lib.VT_LANE_MAX_WORK_H + 1,
           "marks_per_row_max": lib.VT_LANE_MAX_ROW_MARKS + 1, "marks_max": lib.VT_LANE_MAX_MARKS + 1,
           "max_peaks": lib.VT_LANE_MAX_PEAKS + 1}
    for name, v in cap.items():
        cfg = N.lane_cfg_default()
        setattr(cfg, name, v)
        assert lib.vt_lane_cfg_check(cfg) == lib.VT_E_CAPACITY, name
    cfg = N.lane_cfg_default()
    cfg.theta_min_qdeg, cfg.theta_max_qdeg, cfg.theta_step_qdeg = -356, 356, 1  # 713 bins
    assert lib.vt_lane_cfg_check(cfg) == lib.VT_E_CAPACITY
    cfg.lane_w_min_permille, cfg.lane_w_max_permille = 900, 800
    assert lib.vt_lane_cfg_check(cfg) == lib.VT_E_ARG
    # Friendly layer: the same check, as a VtError naming the C function.
    with pytest.raises(VtError, match="vt_lane_cfg_check"):
        LaneDetector(grad_min=0)
    with pytest.raises(TypeError):
        LaneDetector(no_such_field=1)


def test_c_accumulator_capacity():
    # 1 rho bin = 1 px, 0.25 degree theta steps over the full range: far more cells than
    # VT_LANE_ACC_CELLS for a 320x240 working frame.
    cfg = N.lane_cfg_default()
    cfg.theta_min_qdeg, cfg.theta_max_qdeg, cfg.theta_step_qdeg = 4, 4 + lib.VT_LANE_MAX_THETA - 1, 1
    assert lib.vt_lane_cfg_check(cfg) == lib.VT_OK
    res = ffi.new("vt_lane_result *")
    guard = bytes(ffi.buffer(res))
    with pytest.raises(VtError) as e:
        N.lane_detect(cfg, _st(), np.zeros((240, 320), np.uint8), res)
    assert e.value.status == lib.VT_E_CAPACITY
    assert bytes(ffi.buffer(res)) == guard


def test_c_errors_leave_outputs_untouched():
    cfg, st_ = N.lane_cfg_default(), _st()
    res, road = ffi.new("vt_lane_result *"), ffi.new("vt_road_area *")
    ffi.memmove(res, b"\x5a" * ffi.sizeof(res[0]), ffi.sizeof(res[0]))
    ffi.memmove(road, b"\x5a" * ffi.sizeof(road[0]), ffi.sizeof(road[0]))
    before = bytes(ffi.buffer(res)), bytes(ffi.buffer(road))
    assert lib.vt_lane_detect(st_, cfg, N.view(np.zeros((8, 64), np.uint8), "i"), res, road) < 0
    assert (bytes(ffi.buffer(res)), bytes(ffi.buffer(road))) == before


def _guarded(ctype, pad=64):
    n = ffi.sizeof(ctype)
    buf = ffi.new("uint8_t[]", n + pad)
    ffi.memmove(buf + n, b"\xa5" * pad, pad)
    return ffi.cast(ctype + " *", buf), buf, n, pad


def test_c_guard_bytes_after_outputs():
    img = cv2.imread(str(DATA / "lane_tusimple_0531_1492626726476963805_gray_640x360.png"),
                     cv2.IMREAD_GRAYSCALE)
    cfg = N.lane_cfg_default()
    st_, sbuf, sn, pad = _guarded("vt_lane_state")
    res, rbuf, rn, _ = _guarded("vt_lane_result")
    road, dbuf, dn, _ = _guarded("vt_road_area")
    lib.vt_lane_reset(st_)
    for frame in (img, img[:, ::-1].copy(), np.zeros_like(img), img):
        N.lane_detect(cfg, st_, frame, res, road)
    assert res.lines[1].state != 0 and road.valid == 1
    for buf, n in ((sbuf, sn), (rbuf, rn), (dbuf, dn)):
        assert bytes(ffi.buffer(buf + n, pad)) == b"\xa5" * pad


def test_c_survives_a_garbage_state():
    img = cv2.imread(str(DATA / "lane_tusimple_0601_1494453287696553635_gray_640x360.png"),
                     cv2.IMREAD_GRAYSCALE)
    cfg = N.lane_cfg_default()
    rng = np.random.default_rng(1)
    for trial in range(20):
        st_ = _st()
        n = ffi.sizeof(st_[0])
        ffi.memmove(st_, rng.integers(0, 256, n, dtype=np.uint8).tobytes(), n)
        # The first four fields (header order) say "previous frame, same geometry":
        # the tracker then reads garbage lines.
        head = ffi.cast("int32_t *", st_)
        head[0], head[1], head[2], head[3] = 1, 1, 320, 180
        res, road = ffi.new("vt_lane_result *"), ffi.new("vt_road_area *")
        N.lane_detect(cfg, st_, img, res, road)
        for k in range(4):
            ln = res.lines[k]
            assert ln.state in (0, 1, 2)
            if ln.state:
                assert 2 <= ln.n_verts <= lib.VT_LANE_MAX_VERTS and 0 <= ln.y_top < res.h
        if road.valid:
            assert 0 <= road.y_top <= road.y_bottom == img.shape[0] - 1
            xl = np.frombuffer(ffi.buffer(road.x_left), np.int16)[road.y_top:img.shape[0]]
            xr = np.frombuffer(ffi.buffer(road.x_right), np.int16)[road.y_top:img.shape[0]]
            assert (xl >= 0).all() and (xl <= xr).all() and (xr < img.shape[1]).all()


def test_c_line_x_matches_the_polyline():
    img = cv2.imread(str(DATA / "lane_tusimple_0601_1494453643540652356_gray_640x360.png"),
                     cv2.IMREAD_GRAYSCALE)
    a = LaneDetector("c").detect(img)
    for k in range(4):
        ln = a.raw.lines[k]
        if ln.state == 0:
            continue
        verts = _c_verts(ln)
        for yq in (0, 17 * 65536 + 12345, ln.y_top * 65536, (a.raw.h - 1) * 65536, a.raw.h * 65536 + 7,
                   -(2**31), 2**31 - 1):
            x = N.lane_line_x(ln, yq) / 65536
            ref = rl.polyline_x(verts, max(min(yq / 65536, 2**13), -2**13))
            if abs(yq) < 2**28:
                assert abs(x - ref) <= 1 / 32768 + 1e-9, (k, yq)
    bad = ffi.new("vt_lane_line *")
    with pytest.raises(VtError):
        N.lane_line_x(bad, 0)
    bad.state, bad.n_verts = 1, lib.VT_LANE_MAX_VERTS + 1
    with pytest.raises(VtError):
        N.lane_line_x(bad, 0)


def test_road_area_shape():
    img = cv2.imread(str(DATA / "lane_tusimple_0601_1494452495543904834_gray_640x360.png"),
                     cv2.IMREAD_GRAYSCALE)
    res = LaneDetector("c").detect(img)
    assert res.road_valid
    rows = np.arange(res.road_y_top, res.road_y_bottom + 1)
    assert (res.x_left[rows] <= res.x_right[rows]).all()
    assert not res.x_left[: res.road_y_top].any() and not res.x_right[: res.road_y_top].any()
    # Both ego lines found: lane width is their distance, growing toward the bottom.
    assert (res.lane_width[rows] >= 0).all() and res.lane_width[rows[-1]] > res.lane_width[rows[0]]
    assert len(res.road) == 2 * len(rows)
    r = res.raw
    assert r.vp_known == 1 and r.roi_top <= r.vp_y <= r.h * rl.DEFAULT.vp_low_permille // 1000


def test_lone_line_stops_at_the_pairs_vanishing_row():
    """Udacity test1 (grayscale): the yellow left line is as bright as the concrete, so
    the right ego line is alone; the pair that confirmed it (with the barrier's edge)
    meets at the horizon. The lines must end there, not climb on into the trees (the
    right line reached input row 278 of 720 before, 130 rows above the horizon)."""
    img = cv2.imread(str(DATA / "udacity_test1_640x360.jpg"), cv2.IMREAD_GRAYSCALE)
    a, b = LaneDetector("c").detect(img), LaneDetector("reference").detect(img)
    compare_frames(a, b, "udacity test1")
    for res in (a, b):
        r = res.raw
        assert not r.vp_known and r.pair_vp_y >= 0
        h = r.h if hasattr(r, "h") else r.H     # vt_lane_result / LaneFrame
        cap = r.pair_vp_y + h * rl.DEFAULT.top_margin_permille // 1000
        assert res.lane("right") is not None and res.lane("left") is None
        n = res.work_scale
        for ln in res.lanes:
            # points sit at working-row centres: working row y is input row (y + 0.5) * n - 0.5
            assert ln.points[:, 1].min() >= (cap + 0.5) * n - 0.5 - 1e-6, ln.side
    # Without the cap the oracle's right line runs on above the horizon: the scene tests it.
    rb = b.raw
    free = replace(rb.lines[rl.RIGHT], verts=[])
    marks = rl.all_marks(rl.working_image(img, rb.scale), rl.DEFAULT)
    rl.extend(free, marks, rb.W, rb.H, False, rb.vp_y, rl.DEFAULT)
    assert free.y_top < rb.pair_vp_y - 20
