"""Every lane line (vt_lane_result.lines_all) and the road area over all lanes
(vt_lane_road_all), C against the float oracle (pyvehtrack/reference/lane.py), and the
lane stage on a night frame.

Tolerances (the same arithmetic as tests/test_lane.py, whose module doc derives them):
  * a line's Hough cell within 1 bin in theta and rho (Q1.14 sin/cos in C: a vote at a
    bin boundary can move one bin), unless the oracle's window holds another cell more
    than one bin away with at most one vote less (a flat ridge, where one moved vote
    decides);
  * its refined line within 0.25 px across the line when the cells agree, 1 px when
    they are one bin apart (refinement windows starting a bin apart); lines flatter
    than ego_theta_max are not refined, only their cell is compared;
  * polylines: the same, from the rows where the oracle's extension was not decided by
    a margin of one count (sure_y) and both lines exist;
  * road_all: 1 px per row (C rounds the Q16 x half up) plus the boundary lines'
    tolerance in input px; lane_width_all twice that (a difference of two xs, divided).
Further lines (and outer slots) pass a vanishing-point test with a tolerance; a
one-bin difference in an ego line moves that point a little, so a line right at the
tolerance can be kept by one engine only. Their presence is therefore compared on the
clean scenes below (test_all_lines_found_where_drawn), not on random ones; when both
engines report a line it is held to the rules above.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyvehtrack import VtError
from pyvehtrack import _native as N
from pyvehtrack.lane import FURTHER, LaneDetector
from pyvehtrack.reference import lane as rl
from test_lane import _same_cap

ffi, lib = N.ffi, N.lib
DATA = Path(__file__).parent / "data"


def multi_scene(w, h, seed, n_side=3, lane_w=0.25, vp_dx=0.0, vp_y=0.4, noise=2.0, bg=70,
                contrast=120, mark_w=0.012):
    """Gray road with 2 * n_side solid markings lane_w * w apart at the bottom row,
    symmetric about the centre, meeting at a vanishing point. Returns (image, xbs)."""
    rng = np.random.default_rng(seed)
    img = np.full((h, w), float(bg))
    img[: int(vp_y * h)] = bg + 40
    vx, vy = w / 2 + vp_dx * w, vp_y * h
    xbs = [w / 2 + (k + 0.5) * lane_w * w for k in range(-n_side, n_side)]
    for xb in xbs:
        for y in range(int(vy) + 2, h):
            t = (y - vy) / (h - 1 - vy)
            xc = vx + (xb - vx) * t
            half = max(0.6, mark_w * w * t / 2)
            x0, x1 = int(round(xc - half)), int(round(xc + half))
            if x1 < 0 or x0 >= w:
                continue
            img[y, max(x0, 0):min(x1, w - 1) + 1] = bg + contrast
    img += rng.normal(0, noise, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8), xbs, (vx, vy)


def _near_tie(frame, line):
    acc, bin0 = frame.accs[0 if line.theta_qdeg >= 0 else 1]
    cfg = rl.DEFAULT
    k, col = line.theta_bin, line.rho_bin - bin0
    for kk in range(max(0, k - cfg.nms_theta_bins), min(acc.shape[0], k + cfg.nms_theta_bins + 1)):
        for cc in range(max(0, col - cfg.nms_rho_bins), min(acc.shape[1], col + cfg.nms_rho_bins + 1)):
            if max(abs(kk - k), abs(cc - col)) > 1 and acc[kk, cc] >= line.votes - 1:
                return True
    return False


def _compare_line(la, lb, ra, rb, where):
    """C vt_lane_line la vs oracle LaneLine lb; returns the x tolerance (working px) of
    the rows compared, or None when only the cell could be compared."""
    if _near_tie(rb, lb):
        return None
    assert abs(la.theta_bin - lb.theta_bin) <= 1 and abs(la.rho_bin - lb.rho_bin) <= 1, \
        f"{where}: C bin ({la.theta_bin}, {la.rho_bin}), oracle ({lb.theta_bin}, {lb.rho_bin})"
    same_bin = (la.theta_bin, la.rho_bin) == (lb.theta_bin, lb.rho_bin)
    if not same_bin and abs(lb.theta_qdeg) > rl.DEFAULT.ego_theta_max_qdeg:
        return None
    across = 1.0 / np.hypot(1.0, lb.slope)
    tol = 0.25 if same_bin else 1.0
    assert abs(la.xb / 65536 - lb.xb) * across <= tol, where
    tol = 0.25 if ra.vp_y == rb.vp_y and same_bin else 1.0
    vc = [(int(la.vy[i]), la.vx[i] / 65536.0) for i in range(la.n_verts)]
    ext = ra.vp_known == rb.vp_known and _same_cap(ra, rb, where)
    first = max(la.y_top, lb.y_top, lb.sure_y, -1 if ext else max(la.vy[1], lb.verts[1][0]))
    for y in range(first, ra.h):
        d = abs(rl.polyline_x(vc, y) - rl.polyline_x(lb.verts, y)) * across
        assert d <= tol, f"{where} row {y}"
    return tol / across if lb.sure_y < 0 and ext else None


def compare_all(a, b, where=""):
    """lines_all and road_all of C LaneResult a vs oracle LaneResult b."""
    ra, rb = a.raw, b.raw
    n = ra.n_lines_all
    assert 0 <= n <= lib.VT_LANE_MAX_LINES and ra.lines_all_dropped >= 0, where
    xbs = [ra.lines_all[i].xb for i in range(n)]
    assert xbs == sorted(xbs), where                       # left to right
    slots = [ra.lines_all_slot[i] for i in range(n)]
    # Every slot line is in lines_all once, identical to it.
    for k in range(4):
        if ra.lines[k].state != 0:
            assert slots.count(k) == 1, where
            i = slots.index(k)
            assert bytes(ffi.buffer(ffi.addressof(ra.lines_all, i))) == \
                bytes(ffi.buffer(ffi.addressof(ra.lines, k))), where
        else:
            assert k not in slots, where
    assert all(s == -1 or 0 <= s < 4 for s in slots), where
    assert all(ra.lines_all[i].state == 1 for i in range(n) if slots[i] == -1), where
    assert [s for s in slots if s >= 0] == sorted(s for s in slots if s >= 0), where
    # The oracle's list: same rules.
    assert len(b.lanes_all) == len(rb.lines_all) == len(rb.lines_all_slot)
    # Further lines present in both (matched by the nearest xb) agree like slot lines.
    fa = [i for i in range(n) if slots[i] == -1]
    fb = [j for j, s in enumerate(rb.lines_all_slot) if s == -1]
    strict = {}
    for i in fa:
        if not fb:
            break
        j = min(fb, key=lambda j: abs(rb.lines_all[j].xb - ra.lines_all[i].xb / 65536))
        lb = rb.lines_all[j]
        if abs(lb.xb - ra.lines_all[i].xb / 65536) > 0.02 * ra.w:
            continue
        strict[i] = _compare_line(ra.lines_all[i], lb, ra, rb, f"{where} further line {i}")
    same = [s for s in slots] == list(rb.lines_all_slot)
    if not same:
        return
    assert a.road_all_valid == b.road_all_valid, where
    if not a.road_all_valid:
        return
    # Boundary lines: both must have a row tolerance (else only the cells were compared).
    tols = []
    for i in (0, n - 1):
        la, lb = ra.lines_all[i], rb.lines_all[i]
        t = _compare_line(la, lb, ra, rb, f"{where} boundary {i}")
        tols.append(t)
    if any(t is None for t in tols):
        return
    m = ra.scale
    xtol = 1 + max(tols) * m
    ya = max(ra.lines_all[0].y_top, ra.lines_all[n - 1].y_top)
    first = max(a.road_all_y_top, b.road_all_y_top, (ya + 2) * m)
    rows = slice(first, a.road_all_y_bottom + 1)
    for nm, k in (("x_left_all", 1), ("x_right_all", 1), ("lane_width_all", 2)):
        d = np.abs(getattr(a, nm)[rows].astype(float) - getattr(b, nm)[rows])
        assert d.size == 0 or d.max() <= k * xtol, f"{where} {nm}"


multi_scenes = st.fixed_dictionaries({
    "w": st.integers(160, 640), "h": st.integers(120, 400), "seed": st.integers(0, 2**31),
    "n_side": st.integers(1, 4), "lane_w": st.floats(0.15, 0.4), "vp_dx": st.floats(-0.05, 0.05),
    "vp_y": st.floats(0.3, 0.45), "noise": st.floats(0.0, 5.0), "contrast": st.integers(60, 150),
    "mark_w": st.floats(0.008, 0.02)})


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(multi_scenes)
def test_all_lines_c_matches_oracle(p):
    img, _, _ = multi_scene(**p)
    a = LaneDetector("c").detect(img)
    b = LaneDetector("reference").detect(img)
    compare_all(a, b, str(p))


@pytest.mark.parametrize("lane_w", [0.2, 0.25, 0.3])
@pytest.mark.parametrize("engine", ["c", "reference"])
def test_all_lines_found_where_drawn(engine, lane_w):
    # Six solid markings, four or more of them crossing the bottom row inside the frame:
    # every marking whose bottom point is inside the frame is reported (within 2 px at
    # the bottom row), left to right, and the road area spans the outermost two.
    w, h = 640, 360
    img, xbs, (vx, vy) = multi_scene(w, h, 3, n_side=3, lane_w=lane_w)
    res = LaneDetector(engine).detect(img)
    got = [ln.points[np.argmax(ln.points[:, 1])] for ln in res.lanes_all]  # lowest point
    xs = [float(p[0]) for p in got]
    assert xs == sorted(xs)
    # Every reported line is a drawn marking: its lowest point within 2 px of one, plus
    # half the marking's width where it leaves through a side (the frame edge cuts the
    # marking, so the centre of what is visible moves by up to that much).
    for x, y in got:
        t = (y - vy) / (h - 1 - vy)
        tol = 2.0 + (0.012 * w * t / 2 if min(x, w - 1 - x) <= 0.012 * w else 0.0)
        assert min(abs(x - (vx + (xb - vx) * t)) for xb in xbs) <= tol, (x, y, xbs)
    # Every marking crossing the bottom row inside the frame is reported.
    inside = [x for x in xbs if 2 <= x <= w - 3]
    assert len(inside) >= 4
    bottom = [float(p[0]) for p in got if p[1] >= h - 2]
    for x in inside:
        assert min(abs(x - g) for g in bottom) <= 2.0, (x, bottom)
    assert sum(ln.side == FURTHER for ln in res.lanes_all) >= 1
    assert {ln.side for ln in res.lanes} <= {ln.side for ln in res.lanes_all}
    assert res.road_all_valid
    y = h - 1
    xl = res.lanes_all[0].points
    xr = res.lanes_all[-1].points
    if xl[:, 1].max() >= h - 2 and xr[:, 1].max() >= h - 2:   # both cross the bottom row
        assert abs(res.x_left_all[y] - xs[0]) <= 2 and abs(res.x_right_all[y] - xs[-1]) <= 2
        # Mean lane width at the bottom: the span over the number of lanes.
        assert abs(res.lane_width_all[y] - (xs[-1] - xs[0]) / (len(xs) - 1)) <= 2
    # The ego road area is unchanged by the new output: it lies within road_all.
    assert res.road_valid
    rows = np.arange(max(res.road_y_top, res.road_all_y_top), h)
    assert (res.x_left_all[rows] <= res.x_left[rows]).all()
    assert (res.x_right_all[rows] >= res.x_right[rows]).all()


def test_real_frames_all_lines_c_matches_oracle():
    for f in sorted(DATA.glob("lane_*_gray_640x360.png")):
        img = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
        a, b = LaneDetector("c").detect(img), LaneDetector("reference").detect(img)
        compare_all(a, b, f.name)
        assert a.raw.n_lines_all >= 2 and a.road_all_valid, f.name


def test_capacity_keeps_slots_first():
    # A dense scene (ten markings): at most VT_LANE_MAX_LINES lines, every slot line
    # among them, and lines are left out only when the list is full.
    img, _, _ = multi_scene(640, 360, 5, n_side=5, lane_w=0.12, mark_w=0.008)
    for eng in ("c", "reference"):
        res = LaneDetector(eng).detect(img)
        assert len(res.lanes_all) <= lib.VT_LANE_MAX_LINES
        assert [ln.side for ln in res.lanes_all if ln.side != FURTHER] == [ln.side for ln in res.lanes]
        raw = res.raw
        dropped = raw.lines_all_dropped
        assert dropped == 0 or len(res.lanes_all) == lib.VT_LANE_MAX_LINES


# ------------------------------------------------------------------ bad arguments
def test_road_all_bad_arguments():
    img, _, _ = multi_scene(320, 180, 1)
    cfg, st_ = N.lane_cfg_default(), N.lane_state_new()
    res, road = ffi.new("vt_lane_result *"), ffi.new("vt_road_area *")
    N.lane_detect(cfg, st_, img, res, None)
    assert res.n_lines_all >= 2
    E = lib.VT_E_ARG
    assert lib.vt_lane_road_all(ffi.NULL, 320, 180, road) == E
    assert lib.vt_lane_road_all(res, 320, 180, ffi.NULL) == E
    for w, h in ((0, 180), (320, 0), (-1, 180), (lib.VT_MAX_WIDTH + 1, 180), (320, lib.VT_MAX_HEIGHT + 1)):
        assert lib.vt_lane_road_all(res, w, h, road) == lib.VT_E_SIZE, (w, h)
    with pytest.raises(VtError, match="vt_lane_road_all"):
        N.lane_road_all(res, 0, 180, road)
    assert lib.vt_lane_road_all(res, 320, 180, road) == lib.VT_OK and road.valid == 1
    # A corrupted result: counts, scale, vertex counts out of range.
    for field, val in (("n_lines_all", -1), ("n_lines_all", lib.VT_LANE_MAX_LINES + 1),
                       ("scale", 0), ("scale", lib.VT_LANE_MAX_SCALE + 1), ("scale", -1)):
        bad = ffi.new("vt_lane_result *", res[0])
        setattr(bad, field, val)
        assert lib.vt_lane_road_all(bad, 320, 180, road) == E, field
    bad = ffi.new("vt_lane_result *", res[0])
    bad.lines_all[0].n_verts = lib.VT_LANE_MAX_VERTS + 1
    assert lib.vt_lane_road_all(bad, 320, 180, road) == E
    bad.lines_all[0].n_verts = 2
    bad.lines_all[0].state = 0
    assert lib.vt_lane_road_all(bad, 320, 180, road) == E
    # Fewer than two lines: an empty, invalid area (not an error).
    bad = ffi.new("vt_lane_result *", res[0])
    bad.n_lines_all = 1
    assert lib.vt_lane_road_all(bad, 320, 180, road) == lib.VT_OK and road.valid == 0 and road.height == 180
    # A result from a larger frame than the one named: rows still within the arrays.
    assert lib.vt_lane_road_all(res, 16, 16, road) == lib.VT_OK
    assert road.y_bottom <= 15


def test_road_all_guard_bytes():
    img, _, _ = multi_scene(320, 180, 2)
    cfg, st_ = N.lane_cfg_default(), N.lane_state_new()
    n = ffi.sizeof("vt_lane_result")
    rbuf = ffi.new("uint8_t[]", n + 64)
    ffi.memmove(rbuf + n, b"\xa5" * 64, 64)
    res = ffi.cast("vt_lane_result *", rbuf)
    m = ffi.sizeof("vt_road_area")
    dbuf = ffi.new("uint8_t[]", m + 64)
    ffi.memmove(dbuf + m, b"\xa5" * 64, 64)
    road = ffi.cast("vt_road_area *", dbuf)
    N.lane_detect(cfg, st_, img, res, None)
    N.lane_road_all(res, 320, 180, road)
    assert road.valid == 1
    assert bytes(ffi.buffer(rbuf + n, 64)) == b"\xa5" * 64
    assert bytes(ffi.buffer(dbuf + m, 64)) == b"\xa5" * 64


# ------------------------------------------------------------------ night
def night_frame(img, dark, seed):
    """A daylight frame as at night: scaled to `dark` of its brightness, except for the
    headlights' reach (brightest at the bottom centre, a smooth Gaussian falloff
    sideways that widens toward the car, fading out at 55% of the height), plus
    Gaussian sensor noise (sigma 3 gray levels)."""
    h, w = img.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    t = np.clip((yy - 0.55 * h) / (0.45 * h), 0, 1)
    sigma = 0.05 * w + 0.3 * w * t
    gain = dark + (0.8 - dark) * t * np.exp(-0.5 * ((xx - w / 2) / sigma) ** 2)
    rng = np.random.default_rng(seed)
    out = img * gain + rng.normal(0, 3.0, img.shape)
    return np.clip(np.round(out), 0, 255).astype(np.uint8)


def _night_cases():
    import json
    labs = json.loads((DATA / "lane_tusimple_ego_labels_640x360.json").read_text())
    return labs


# Known gap (strict xfail: it fails the suite the day it passes): one case reports a right
# line that follows the marking but lies 15-16 px (threshold 14.8) off its label at the three
# rows nearest the vanishing point, on frame 0601_...3287. With the lane defaults before
# 2026-11-30 (tuned on all 100 frames) that case was seed 2 at 20% and seed 6 passed; with the
# cross-validated defaults since (tools/tune_lanes.py --tune B --kitti-guard --range-guard)
# seed 2 passes (no line) and seed 6 at 20% fails.
@pytest.mark.parametrize("seed,dark", [
    (2, 0.1), (3, 0.1), (3, 0.2), (2, 0.2),
    # seeds 4-9 added later and run once when added: every case passed (with the defaults then)
    *[(s, d) for s in range(4, 10) for d in (0.1, 0.2) if (s, d) != (6, 0.2)],
    pytest.param(6, 0.2, marks=pytest.mark.xfail(
        strict=True, reason="seed 6 at 20%: the right line 15-16 px off its label near the vanishing point "
                            "on frame 0601_...3287 with the shipped defaults"))])
def test_night_reports_visible_markings_or_none(dark, seed):
    # Issue 8: at night, with only the headlights' reach visible, the stage reports the
    # markings that are visible or none, never a wrong line. Every row of a reported ego
    # line where the label has a point must be within TuSimple's threshold of it
    # (20 px / cos(angle) at 1280 px: half that in these 640-px frames). Not all of
    # the labelled lane need be reported (its far part is dark). The frames are the
    # four labelled tests/data frames; solo_vote_permille was chosen on these night
    # frames with noise seed 1 (seeds 2 and 3 here were not looked at before).
    from pyvehtrack.eval import lanes as ev
    n_pairs = 0
    for lab in _night_cases():
        img = night_frame(cv2.imread(str(DATA / lab["file"]), cv2.IMREAD_GRAYSCALE), dark, seed)
        hs, gt = lab["h_samples"], lab["ego_lanes"]
        engines = ("c", "reference") if seed == 2 and dark == 0.1 else ("c",)
        for eng in engines:
            res = LaneDetector(eng).detect(img)
            found = 0
            for side, g in zip(("left", "right"), gt):
                ln = res.lane(side)
                if ln is None:
                    continue
                found += 1
                pred = ev.sample_points(ln.points, hs, img.shape[1])
                thr = ev.PIXEL_THRESH / 2 / np.cos(ev._angle(np.array(g, float), np.array(hs)))
                both = [(p, q) for p, q in zip(pred, g) if p >= 0 and q >= 0]
                assert both, (lab["file"], side)
                bad = [(p, q) for p, q in both if abs(p - q) >= thr]
                assert not bad, (eng, lab["file"], side, dark, bad)
            n_pairs += found == 2
    # Not vacuous: the markings in the headlights' reach are still found somewhere.
    assert n_pairs >= 2


def test_downscaled_frame_maps_all_lines_back():
    # A frame larger than the core's maximum is downscaled first; lanes_all and road_all
    # come back in the input frame's pixels (pyvehtrack.lane._rescale), like the ego ones.
    img, _, _ = multi_scene(640, 360, 4, n_side=3, lane_w=0.25)
    f = 2 * max(1, -(-int(lib.VT_MAX_WIDTH) // 640))       # big enough to be downscaled
    big = cv2.resize(img, (640 * f, 360 * f), interpolation=cv2.INTER_NEAREST)
    det = LaneDetector("c")
    small = det.detect(img)
    det.reset()
    with pytest.warns(UserWarning, match="downscaled"):
        res = det.detect(big)
    assert res.input_scale < 1
    assert res.x_left_all.shape == (360 * f,) and res.road_all_valid
    # The same lines, left to right (which of them is an outer slot and which a further
    # line can change with the working width: the slots are picked by votes and angle).
    assert len(res.lanes_all) == len(small.lanes_all)
    # One working pixel of the big frame is work_scale / input_scale input px; the lines'
    # bottom points agree within that (the small frame's times f).
    px = res.work_scale / res.input_scale
    for a, b in zip(small.lanes_all, res.lanes_all):
        pa = a.points[np.argmax(a.points[:, 1])]
        pb = b.points[np.argmax(b.points[:, 1])]
        assert abs(pb[0] - (f * (pa[0] + 0.5) - 0.5)) <= px + f, (a.side, b.side, pa, pb)
    y = 360 * f - 1
    assert abs(res.x_left_all[y] - f * small.x_left_all[359]) <= px + f
    assert abs(res.x_right_all[y] - f * small.x_right_all[359]) <= px + f
