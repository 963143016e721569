"""The tracker's template measurement, parts rule and width floor (issue 8: tracks
born from classifier boxes survive; parts are not vehicles; degenerate tracks go):
c/tracker.c against pyvehtrack/reference/tracker.py with the options on, the
behaviour each option exists for, and the new fields' bad values."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pyvehtrack as vt
from pyvehtrack import _native
from pyvehtrack.reference import tracker as rtrk
from pyvehtrack.tracker import Tracker

from test_tracker import make_scene
from test_tracker_scale import assert_cfg_field_refused

ffi, lib = vt.ffi, vt.lib
iou = rtrk.box_iou
ON = dict(tmatch_radius=4, part_permille=600, min_width=4)


def textured_scene(t, bg, tex, x0=60, top=50, vx=1):
    """A textured patch moving vx px/frame over a textured road: no shadow edge, so the
    ROI search finds nothing to measure (as for a classifier box not aligned to one),
    while the patch itself is plain to see by correlation."""
    img = bg.copy()
    l = x0 + vx * t
    img[top:top + tex.shape[0], l:l + tex.shape[1]] = tex
    return img, (l, top, l + tex.shape[1] - 1, top + tex.shape[0] - 1)


def _textures(seed):
    rng = np.random.default_rng(seed)
    bg = rng.integers(100, 180, (160, 240)).astype(np.uint8)
    tex = rng.integers(120, 250, (40, 48)).astype(np.uint8)
    return bg, tex


def _run(engine, cfg, frames, dets_at):
    tr = Tracker(engine, cfg=cfg)
    return [tr.step(img, detections=dets_at.get(k)) for k, img in enumerate(frames)]


# Tolerance, as tests/test_tracker.py's: the filters agree to ~1e-3 px, so a rounded
# corner may differ by 1 px; the template's argmax compares Q14 scores, C's within
# 1 LSB of the exact one (vt_ncc_u8) and the oracle's the exact one rounded, so two
# shifts within 1 LSB may swap: a 1-px shift again. Everything else is exact integer
# logic. So: the same ids and states every frame, boxes within IoU >= 0.9 (a 1-px
# shift of a box >= 30 px wide costs < 0.07), velocities within 0.05 px/frame.
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31), every=st.integers(3, 10), textured=st.booleans(),
       n=st.integers(1, 2))
def test_c_matches_reference_with_the_options_on(seed, every, textured, n):
    rng = np.random.default_rng(seed)
    frames, dets_at = [], {}
    if textured:  # template frames in plenty
        bg, tex = _textures(seed)
        for t in range(24):
            img, box = textured_scene(t, bg, tex)
            frames.append(img)
            if t % every == 0:
                # a part inside the box comes too (the parts rule's case)
                dets_at[t] = [box] + ([(box[0] + 4, box[1] + 4, box[0] + 20, box[1] + 20)] if n > 1 else [])
    else:
        cars = [(20 + 110 * k + int(rng.integers(0, 30)), int(rng.integers(120, 200)),
                 int(rng.integers(30, 60)), float(rng.uniform(-2, 2)), float(rng.uniform(-0.5, 0.5)), 0.0)
                for k in range(n)]
        for t in range(24):
            img, boxes = make_scene(rng, cars, t)
            frames.append(img)
            if t % every == 0:
                dets_at[t] = boxes
    cfg = rtrk.TrackerCfg(**ON)
    c_out, r_out = _run("c", cfg, frames, dets_at), _run("reference", cfg, frames, dets_at)
    for k, (c, r) in enumerate(zip(c_out, r_out)):
        assert [(a.id, a.state) for a in c] == [(b.id, b.state) for b in r], k
        for a, b in zip(c, r):
            assert iou(a.box, b.box) >= 0.9, (k, a, b)
            assert abs(a.velocity[0] - b.velocity[0]) <= 0.05 and abs(a.velocity[1] - b.velocity[1]) <= 0.05


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_template_keeps_a_tentative_track_until_the_next_detection(engine):
    bg, tex = _textures(3)
    frames, boxes = zip(*(textured_scene(t, bg, tex) for t in range(25)))

    def run(radius):
        tr = Tracker(engine, cfg=rtrk.TrackerCfg(tmatch_radius=radius))
        return [tr.step(f, detections=[boxes[t]] if t % 10 == 0 else None) for t, f in enumerate(frames)]

    off, on = run(0), run(4)
    # The thesis's lifecycle: the ROI search fails twice, the tentative track dies,
    # and the next detection starts a new id.
    assert off[5] == [] and [o.id for o in off[10]] == [2]
    # With the template: one id throughout, on the patch (it moves 1 px/frame), and
    # confirmed by the third detection (frames 0, 10, 20: template frames are no hits).
    for t in range(25):
        assert [o.id for o in on[t]] == [1], t
        assert iou(on[t][0].box, boxes[t]) >= 0.85, (t, on[t][0].box, boxes[t])
    assert on[19][0].state == "tentative" and on[20][0].state == "confirmed"


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_template_carries_a_track_only_detections_confirmed(engine):
    """A track the ROI search never measured (no shadow edge: a side view's box) is
    confirmed by its third detection and then has nothing but its template: it stays
    confirmed on the patch between detections, one id throughout. (Coasting, as
    confirmed tracks do, dropped it after max_coast frames and the next detection
    started a second id.)"""
    bg, tex = _textures(3)
    frames, boxes = zip(*(textured_scene(t, bg, tex) for t in range(40)))
    tr = Tracker(engine, cfg=rtrk.TrackerCfg(tmatch_radius=4))
    out = [tr.step(f, detections=[boxes[t]] if t % 10 == 0 else None) for t, f in enumerate(frames)]
    for t in range(40):
        assert [o.id for o in out[t]] == [1], t
        assert iou(out[t][0].box, boxes[t]) >= 0.85, (t, out[t][0].box, boxes[t])
    assert all(out[t][0].state == "confirmed" for t in range(20, 40))


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_template_gives_up_after_tmatch_max_frames_and_below_threshold(engine):
    bg, tex = _textures(4)
    frames, boxes = zip(*(textured_scene(t, bg, tex) for t in range(12)))
    tr = Tracker(engine, cfg=rtrk.TrackerCfg(tmatch_radius=4, tmatch_max=3))
    out = [tr.step(f, detections=[boxes[0]] if t == 0 else None) for t, f in enumerate(frames)]
    assert [o.id for o in out[3]] == [1] and out[4] == []  # 3 template frames, then gone
    # the patch gone after frame 0 (plain textured road): no shift correlates, the
    # thesis's lifecycle again (two misses end a tentative track)
    tr = Tracker(engine, cfg=rtrk.TrackerCfg(tmatch_radius=4))
    out = [tr.step(f if t == 0 else bg, detections=[boxes[0]] if t == 0 else None)
           for t, f in enumerate(frames)]
    assert [o.id for o in out[1]] == [1] and out[2] == []


@pytest.mark.skipif(int(lib.VT_MAX_TRACKS) < 2, reason="the rule-off case starts a second track")
@pytest.mark.parametrize("engine", ["c", "reference"])
def test_parts_start_no_track_and_part_tracks_are_reanchored(engine):
    bg, tex = _textures(5)
    img, box = textured_scene(0, bg, tex, vx=0)
    l, t, r, b = box
    part = (l + 4, t + 4, l + 20, t + 20)  # 17x17 inside a 48x40 box: IoU 0.15, all inside
    tr = Tracker(engine, cfg=rtrk.TrackerCfg(tmatch_radius=4, part_permille=600))
    out = tr.step(img, detections=[box])
    out = tr.step(img, detections=[box, part])
    assert [o.id for o in out] == [1]
    # without the rule the part (IoU 0.15 >= the 10 % overlap rule) is still refused here;
    # a smaller part (IoU < 10 %) starts its own track without the rule, none with it
    small = (l + 4, t + 4, l + 13, t + 13)
    for rule, ids in ((0, [1, 2]), (600, [1])):
        tr = Tracker(engine, cfg=rtrk.TrackerCfg(tmatch_radius=4, part_permille=rule))
        tr.step(img, detections=[box])
        assert [o.id for o in tr.step(img, detections=[small])] == ids, rule
    # a track born on a part is re-anchored to the whole vehicle's detection, same id
    tr = Tracker(engine, cfg=rtrk.TrackerCfg(tmatch_radius=4, part_permille=600))
    tr.step(img, detections=[part])
    out = tr.step(img, detections=[box])
    assert [o.id for o in out] == [1] and iou(out[0].box, box) >= 0.85, out
    # without the rule the part's track stays a part
    tr = Tracker(engine, cfg=rtrk.TrackerCfg(tmatch_radius=4, part_permille=0))
    tr.step(img, detections=[part])
    out = tr.step(img, detections=[box])
    assert [o.id for o in out] == [1] and iou(out[0].box, box) < 0.5, out


@pytest.mark.skipif(int(lib.VT_MAX_TRACKS) < 2, reason="needs VT_MAX_TRACKS >= 2")
@pytest.mark.parametrize("engine", ["c", "reference"])
def test_a_track_inside_a_larger_track_is_dropped(engine):
    # Two detections on one frame: the whole car and a part that the 10 % overlap rule
    # lets through (the rule looks at live tracks only, so both start); at the end of
    # the step the part is inside the larger track and goes.
    bg, tex = _textures(6)
    img, box = textured_scene(0, bg, tex, vx=0)
    part = (box[0] + 30, box[1] + 25, box[0] + 39, box[1] + 34)
    for rule, n in ((0, 2), (600, 1)):
        tr = Tracker(engine, cfg=rtrk.TrackerCfg(part_permille=rule))
        assert len(tr.step(img, detections=[box, part])) == n, rule


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_narrow_detections_start_no_track(engine):
    img = np.full((60, 80), 110, np.uint8)
    for mw, n in ((0, 1), (4, 0)):
        tr = Tracker(engine, cfg=rtrk.TrackerCfg(min_width=mw))
        assert len(tr.step(img, detections=[(10, 10, 12, 30)])) == n, mw  # 3 px wide


def test_new_fields_bad_values():
    tr = _native.tracker_new()
    for field, values in [("tmatch_radius", (-1, 65)), ("tmatch_ncc_permille", (1001, -1001)),
                          ("tmatch_max", (-1, 1801)), ("part_permille", (-1, 1001)),
                          ("min_width", (-1, int(lib.VT_MAX_WIDTH) + 1))]:
        assert_cfg_field_refused(tr, field, values)
    with pytest.raises(ValueError, match="tmatch_radius"):  # the project's rule: no silent rounding
        Tracker(cfg=rtrk.TrackerCfg(tmatch_radius=2.5))
    with pytest.raises(TypeError, match="part_permille"):
        Tracker(cfg=rtrk.TrackerCfg(part_permille="600"))
    assert tr.frame == 0
