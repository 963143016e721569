"""A new track starts where the ROI search measures (vt_tracker_cfg.birth_search, thesis
sec. 3.6.1): the search runs on the birth frame from the detection's box until it stops
moving it. A classifier box wider than the vehicle's edges (a 3/4 view's box over side and
rear, the Udacity clip's white car with cnn_gray_l0_big.npz) then starts its track on the
edges every later frame measures, instead of a filter that takes the narrower measurements
for motion and a scale check that refuses them. c/tracker.c against
pyvehtrack/reference/tracker.py, by hand and on random scenes, and the bad values."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import _native
from pyvehtrack._native import lib
from pyvehtrack.reference import tracker as rtrk

from test_tracker_scale import assert_cfg_field_refused, assert_engines_agree, run
from test_tracker_snap import moving_cars, one_car


# The car is drawn 60 px wide; the search marks its sides on the Sobel columns just outside
# the body, 62 px apart. The detection reaches 26 px further left, over plain road (inside
# the side gate, max(8, 35% of 86) = 30 px). Horizon 40, bottom row 153: R = b - h = 113.
# The scale check (tracker.h) refuses a measurement of width w at the same row when
# |w - w_ref| R 1000 > 200 w_ref R + 2000 (w_ref + R): for 62 px against the detection's
# 86, 24 x 113 x 1000 = 2,712,000 > 200 x 86 x 113 + 2000 x 199 = 2,341,600: started on
# the detection, every measurement of the car is refused.
WIDE = 26
HORIZON = 40


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_a_box_wider_than_the_car_starts_on_the_car(engine):
    frames, car = one_car(n=8)
    det = (car[0] - WIDE, car[1], car[2], car[3])
    on = run(engine, rtrk.TrackerCfg(), frames, {0: [det]}, horizon=HORIZON)
    off = run(engine, rtrk.TrackerCfg(birth_search=0), frames, {0: [det]}, horizon=HORIZON)
    first_on, first_off = on[0][0][2], off[0][0][2]
    assert first_off[:3] == det[:3], first_off      # (its bottom snapped down: test_tracker_snap.py)
    assert abs(first_on[0] - car[0]) <= 1 and abs(first_on[2] - car[2]) <= 1, (first_on, car)
    assert first_on[1] == det[1], first_on     # the detection's top stays
    # on: one id, confirmed from the third frame on, on the car every frame
    assert all([i for i, _, _ in f] == [1] for f in on), on
    assert all(s == "confirmed" for f in on[2:] for _, s, _ in f), on
    assert all(abs(f[0][2][0] - car[0]) <= 2 and abs(f[0][2][2] - car[2]) <= 2 for f in on), on
    # off: the measurements are refused, the track is never confirmed. Without the scale
    # check they are taken, and the filter reads the 23 px jump of the left side as motion:
    # the box of a car that stands still slides right, about 5 px a frame, beyond the gate
    assert all(s != "confirmed" for f in off for _, s, _ in f), off
    unchecked = run(engine, rtrk.TrackerCfg(birth_search=0, scale_tol_permille=0), frames, {0: [det]},
                    horizon=HORIZON)
    assert unchecked[-1][0][2][0] > car[0] + 20 and unchecked[-1][0][1] == "coasting", unchecked


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_a_box_on_the_car_moves_at_most_to_the_search_columns(engine):
    # the search marks a side on the edge column next to the drawn body (a 3x3 Sobel
    # responds on both), so a box on the car moves by at most 1 px and then stays
    frames, car = one_car()
    on = run(engine, rtrk.TrackerCfg(), frames, {0: [car]}, horizon=None)[0][0][2]
    again = run(engine, rtrk.TrackerCfg(), frames, {0: [on]}, horizon=None)[0][0][2]
    assert all(abs(a - b) <= 1 for a, b in zip(on, car)), (on, car)
    assert again == on, (again, on)


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_nothing_to_measure_keeps_the_detection(engine):
    # flat road under the box: the search finds nothing and the track starts as detected
    img = np.full((240, 320), 110, np.uint8)
    det = (100, 90, 159, 150)
    on = run(engine, rtrk.TrackerCfg(), [img], {0: [det]}, horizon=None)
    assert on[0][0][2] == det, on


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_one_search_step_is_one_step(engine):
    # birth_search = 1 takes the first search's box; more steps only where it still moves
    frames, car = one_car()
    det = (car[0] - WIDE, car[1], car[2], car[3])
    one = run(engine, rtrk.TrackerCfg(birth_search=1), frames, {0: [det]}, horizon=None)[0][0][2]
    many = run(engine, rtrk.TrackerCfg(birth_search=int(lib.VT_TRACK_MAX_BIRTH_SEARCH)), frames, {0: [det]},
               horizon=None)[0][0][2]
    assert abs(one[0] - car[0]) <= 1 and abs(many[0] - car[0]) <= 1, (one, many, car)


# Tolerance, as tests/test_tracker_scale.py's: the birth search is the same integer search
# on both sides (tests/test_tracker.py proves track_search exact), so the same ids and
# states every frame and boxes within IoU >= 0.9 (the filters agree to ~1e-3 px; a
# rounded corner may differ by 1 px near a .5 boundary). Detections are the drawn boxes
# with each side moved by -15..+15 px and the bottom by -8..+4, so most births move.
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), every=st.integers(3, 12), n=st.integers(1, 2),
       steps=st.sampled_from([0, 1, 2, 8]), horizon=st.sampled_from([None, 40, 90]))
def test_c_matches_reference_with_birth_search(seed, every, n, steps, horizon):
    frames, dets_at = moving_cars(seed, every, n, side=(-15, 15), bottom=(-8, 4))
    assert_engines_agree(rtrk.TrackerCfg(birth_search=steps), frames, dets_at, horizon)


def test_bad_values():
    top = int(lib.VT_TRACK_MAX_BIRTH_SEARCH)
    assert top == 8
    assert_cfg_field_refused(_native.tracker_new(), "birth_search", (-1, top + 1, 2**31 - 1, -2**31), "2")
