"""The ROI search measures rear views only (vt_tracker_cfg.search_max_aspect_permille; thesis
sec. 2.4.2: the shadow under the vehicle and its two sides). A track whose box is wider than
2.5 times its height (a side view, a car's roof seen over a barrier) is not searched: no
bottom snap, no birth search, no per-frame measurement. Its template carries it between
detections and only detections confirm it. On the Udacity clip such a box (29 x 10 px, a roof
over the median barrier) was confirmed by the search on the barrier's rail and followed the
rail after the car had gone. c/tracker.c against pyvehtrack/reference/tracker.py, by hand and
on random scenes, and the bad values."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import _native
from pyvehtrack._native import lib
from pyvehtrack.reference import tracker as rtrk
from pyvehtrack.shared import MEAS_ROI_SEARCH

from test_tracker_scale import assert_cfg_field_refused, assert_engines_agree, run
from test_tracker_snap import moving_cars, one_car

OFF = rtrk.TrackerCfg(search_max_aspect_permille=0)


def flat_box(car, h):
    """The car's box cut to its lowest h rows (bottom and sides kept)."""
    return (car[0], car[3] - h + 1, car[2], car[3])


def states(out):
    return [[s for _, s, _ in f] for f in out]


def test_default_is_two_and_a_half_to_one():
    assert rtrk.TrackerCfg().search_max_aspect_permille == 2500
    assert int(_native.tracker_cfg_default().search_max_aspect_permille) == 2500
    assert rtrk.TrackerCfg().measurement == MEAS_ROI_SEARCH


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_a_flat_box_is_not_searched_and_waits_for_detections(engine):
    # The drawn car is 60 px wide; its lowest 20 rows make a 60 x 20 box: 60,000 > 2500 x 20
    # = 50,000, flatter than a rear view. The search finds the car's sides and shadow under it
    # (the box's bottom and sides are the car's), so with the rule off it confirms the track
    # on the third frame (confirm_hits 3: the detection and two searches).
    frames, car = one_car(n=10)
    det = flat_box(car, 20)
    off = run(engine, OFF, frames, {0: [det]}, horizon=None)
    assert off[2][0][1] == "confirmed", off
    on = run(engine, rtrk.TrackerCfg(), frames, {0: [det]}, horizon=None)
    # on: one id every frame, never confirmed without more detections; the template holds
    # the box on the standing car (NCC 1 at shift 0; at most the 1 px of the filter's rounding)
    assert all([i for i, _, _ in f] == [1] for f in on), on
    assert all(s == "tentative" for f in states(on) for s in f), on
    assert all(max(abs(a - b) for a, b in zip(f[0][2], det)) <= 1 for f in on), on
    # detections on frames 0, 3 and 6 are its three hits: confirmed on frame 6, not before
    again = run(engine, rtrk.TrackerCfg(), frames, {0: [det], 3: [det], 6: [det]}, horizon=None)
    assert all(s == "tentative" for f in states(again)[:6] for s in f), again
    assert all(s == "confirmed" for f in states(again)[6:] for s in f), again


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_the_bound_is_inclusive(engine):
    # w = 60: h = 24 gives 60 x 1000 = 2500 x 24 exactly (a rear view, searched, confirmed on
    # the third frame); h = 23 gives 60,000 > 57,500 (flat, tentative to the end)
    frames, car = one_car(n=4)
    assert car[2] - car[0] + 1 == 60
    at = run(engine, rtrk.TrackerCfg(), frames, {0: [flat_box(car, 24)]}, horizon=None)
    below = run(engine, rtrk.TrackerCfg(), frames, {0: [flat_box(car, 23)]}, horizon=None)
    assert states(at)[2:] == [["confirmed"], ["confirmed"]], at
    assert all(s == "tentative" for f in states(below) for s in f), below


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_a_rear_view_box_is_unchanged_by_the_rule(engine):
    # the drawn car's own box (60 x 58 px): the same track with the rule on and off
    frames, car = one_car(n=6)
    assert run(engine, rtrk.TrackerCfg(), frames, {0: [car]}, horizon=None) == \
        run(engine, OFF, frames, {0: [car]}, horizon=None)


# Tolerance, as tests/test_tracker_scale.py's: the search and the template are the same
# integer computations on both sides (tests/test_tracker.py, tests/test_tracker_tmatch.py),
# so the same ids and states every frame and boxes within IoU >= 0.9 (the filters agree to
# ~1e-3 px; a rounded corner may differ by 1 px near a .5 boundary). Each detection keeps its
# bottom and sides and gets a random height from a quarter of its width to all of it, so
# about half of them are flatter than 2.5 : 1.
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), every=st.integers(3, 12), n=st.integers(1, 2),
       bound=st.sampled_from([0, 1000, 2500, 4000]), horizon=st.sampled_from([None, 40, 90]))
def test_c_matches_reference_with_flat_boxes(seed, every, n, bound, horizon):
    frames, dets_at = moving_cars(seed, every, n)
    rng = np.random.default_rng(seed)
    for k, boxes in dets_at.items():
        dets_at[k] = [flat_box(b, int(rng.integers((b[2] - b[0] + 1) // 4, b[2] - b[0] + 2))) for b in boxes]
    assert_engines_agree(rtrk.TrackerCfg(search_max_aspect_permille=bound), frames, dets_at, horizon)


def test_bad_values():
    top = int(lib.VT_TRACK_MAX_ASPECT_PERMILLE)
    assert top == 100000
    assert_cfg_field_refused(_native.tracker_new(), "search_max_aspect_permille",
                             (-1, top + 1, 2**31 - 1, -2**31), "2500")


# Real frames (tests/data/README.md, udacity_rail): the default model's box on a car's roof
# seen over the median barrier, 29 x 10 px (29,000 > 2500 x 10 = 25,000: flat), on frame 10
# of the Udacity clip; the car leaves over the next frames, the barrier's rail stays.
RAIL = Path(__file__).resolve().parent / "data" / "udacity_rail"
RAIL_BOX = (109, 51, 137, 60)


def rail_frames():
    frames = [cv2.imread(str(RAIL / f"{k}.png"), cv2.IMREAD_GRAYSCALE) for k in range(10, 20)]
    assert all(f is not None and f.shape == (100, 220) for f in frames), "tests/data/udacity_rail is incomplete"
    return frames


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_a_roof_over_the_barrier_is_not_confirmed_on_the_rail(engine):
    frames = rail_frames()
    off = run(engine, OFF, frames, {0: [RAIL_BOX]}, horizon=None)
    on = run(engine, rtrk.TrackerCfg(), frames, {0: [RAIL_BOX]}, horizon=None)
    # off (as before the rule): the search confirms it on frame 13 (crop frame 3) and the box
    # walks down onto the rail, its bottom 6 px lower by frame 19
    assert [f[0][1] for f in off[3:]] == ["confirmed"] * 7, off
    assert off[-1][0][2][3] - RAIL_BOX[3] >= 5, off
    # on: never confirmed; the template carries it while it correlates, then it is gone
    assert all(s == "tentative" for f in states(on) for s in f), on
    assert on[0][0][2] == RAIL_BOX, on
