"""The overtaking-flow stage on the synthetic motion scenes (pyvehtrack.synth_motion), small frames
(320x240, level 0, 60 frames) so the file runs in a few seconds: a regression guard for the issue-9
targets, not the reported figure (tools/eval_flow_synth.py gives that, at 640x480 on seeds 100-129).

- an overtaking vehicle is reported (a hypothesis overlapping its GT box, on its side) no later than
  5 frames after it is half in view, from either side (with the side set by the traffic rule);
- traffic that keeps its distance gives no overtaking hypothesis, on either side;
- a vehicle the ego car overtakes, handed over by vt_flow_seed, is followed (IoU >= 0.5 with its GT
  box) while at least 60 % of it is in view. The hand-over box keeps its size (the flow gives a
  translation only), so the IoU falls as the car grows; hence the 60 %."""
from __future__ import annotations

import pytest

from pyvehtrack import synth as S
from pyvehtrack import synth_motion as SM
from pyvehtrack.flow import OvertakingDetector

CAM = S.Camera(320, 240)


def _overlaps(b, g) -> bool:
    return not (b[2] < g["left"] or b[0] > g["right"] or b[3] < g["top"] or b[1] > g["bottom"])


def _iou(a, b) -> float:
    iw, ih = min(a[2], b[2]) - max(a[0], b[0]) + 1, min(a[3], b[3]) - max(a[1], b[1]) + 1
    if iw <= 0 or ih <= 0:
        return 0.0
    i = iw * ih
    return i / ((a[2] - a[0] + 1) * (a[3] - a[1] + 1) + (b[2] - b[0] + 1) * (b[3] - b[1] + 1) - i)


@pytest.mark.parametrize("scenario,side", [("overtake_left", "left"), ("overtake_right", "right")])
def test_overtake_reported_within_5_frames(scenario, side):
    seq = SM.make_sequence(scenario, 0, camera=CAM, n_frames=60)
    half = SM.half_in_view(seq, 1)
    assert half is not None and half < 50
    det = OvertakingDetector(sides=side, level=0)
    first = None
    for t in range(half + 6):
        res = det.step(seq.frame(t))
        gt = seq.gt[(seq.gt["frame"] == t) & (seq.gt["id"] == 1)]
        for h in res.hyps:
            assert h.side == side
            assert any(_overlaps(h.box, g) for g in gt), (t, h)   # nothing else is reported
            first = t if first is None else first
    assert first is not None and first <= half + 5, (first, half)


def test_no_false_overtakes_on_traffic_keeping_its_distance():
    seq = SM.make_sequence("keep_distance", 0, camera=CAM, n_frames=60)
    det = OvertakingDetector(sides="both", level=0)
    for t in range(seq.n_frames):
        assert det.step(seq.frame(t)).hyps == [], t


def test_handover_follows_the_overtaken_car():
    seq = SM.make_sequence("ego_overtakes", 0, camera=CAM, n_frames=40)
    det = OvertakingDetector(sides="both", level=0)
    tid, checked = None, 0
    for t in range(seq.n_frames):
        res = det.step(seq.frame(t))
        g = seq.gt[(seq.gt["frame"] == t) & (seq.gt["id"] == 1)]
        assert all(h.kind == "handover" for h in res.hyps), res.hyps   # it moves outward: no overtake
        if t == 2:
            tid = det.seed([int(round(g[0][k])) for k in ("left", "top", "right", "bottom")])
        elif tid is not None and len(g) and g[0]["truncation"] <= 0.4:
            ho = [h for h in res.hyps if h.id == tid]
            assert len(ho) == 1, t
            gb = [g[0][k] for k in ("left", "top", "right", "bottom")]
            assert _iou(ho[0].box, gb) >= 0.5, (t, ho[0].box, gb)
            checked += 1
    assert checked >= 10
