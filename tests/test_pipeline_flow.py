"""The flow source of vt_pipeline_step (the overtaking stage, c/flow.c, plugged into
c/pipeline.c) against reference.pipeline end to end, on the synthetic motion scenes
(pyvehtrack.synth_motion, small frames so the file takes a few seconds).

Tolerance: the flow stage is an exact twin (tests/test_flow.py: integer SAD, vectors and
hypotheses EQUAL), the pipeline's hand-over rule (a flow box meeting no track of the
previous step) and the track-source rule are integer comparisons written twice, and
with road="fixed" the other stages are exact twins (tests/test_pipeline.py). So boxes,
their sources and scores, track ids, states, boxes and sources must be EQUAL (where the
fixed roads agree, as in test_pipeline.py); velocities within 0.05 px/frame."""
from __future__ import annotations

import numpy as np
import pytest

from pyvehtrack import synth as S
from pyvehtrack import synth_motion as SM
from pyvehtrack._native import ffi, lib
from pyvehtrack.pipeline import Pipeline

CAM = S.Camera(320, 240)


def _compare(ra, rb, where):
    assert ra.frame == rb.frame and ra.detection_frame == rb.detection_frame, where
    assert ra.flow_ready == rb.flow_ready, where
    assert [(b.box, b.source, b.score) for b in ra.boxes] == [(b.box, b.source, b.score) for b in rb.boxes], where
    assert [(t.id, t.state, t.box, t.source) for t in ra.tracks] == \
        [(t.id, t.state, t.box, t.source) for t in rb.tracks], where
    for a, b in zip(ra.tracks, rb.tracks):
        assert abs(a.velocity[0] - b.velocity[0]) <= 0.05 and abs(a.velocity[1] - b.velocity[1]) <= 0.05, where


@pytest.mark.parametrize("scenario,side", [("overtake_left", "left"), ("overtake_right", "right"),
                                           ("keep_distance", "both")])
def test_c_matches_reference_and_overtakes_are_tracked(scenario, side):
    """C and oracle equal frame by frame; an overtaking car becomes a track started by the
    flow source within 5 frames of being half in view (the issue-9 target, here through the
    whole pipeline); traffic keeping its distance starts no flow track."""
    seq = SM.make_sequence(scenario, 0, camera=CAM, n_frames=60)
    half = SM.half_in_view(seq, 1) if scenario != "keep_distance" else None
    n = 40 if half is None else half + 6
    kw = dict(sources=("shadow", "flow"), road="fixed", detect_every=10,
              flow={"sides": {"left": 1, "right": 2, "both": 3}[side], "level": 0})
    a, b = Pipeline("c", **kw), Pipeline("reference", **kw)
    first = None
    for t in range(n):
        ra, rb = a.step(seq.frame(t)), b.step(seq.frame(t))
        _compare(ra, rb, f"{scenario} frame {t}")
        assert ra.flow_ready == (t > 0)
        if first is None and any(tr.source == "flow" for tr in ra.tracks):
            first = t
    if scenario == "keep_distance":
        assert first is None
    elif int(lib.VT_MAX_TRACKS) < 2:
        # One track slot: the shadow source's tentative track on the car ahead holds it (the
        # tracker's template measurement keeps a tentative track until the next detection),
        # so a flow box finds no free slot; C = oracle was checked on every frame above.
        pytest.skip("the timing needs a second track slot (this build has VT_MAX_TRACKS = 1)")
    else:
        assert half is not None and first is not None and first <= half + 5, (first, half)


def test_flow_state_refusals_and_attach():
    c = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(c) == lib.VT_OK
    c.sources = lib.VT_SRC_SHADOW | lib.VT_SRC_FLOW
    p = ffi.new("vt_pipeline *")
    assert lib.vt_pipeline_init(p, c, ffi.NULL, ffi.NULL) == lib.VT_OK
    a = np.zeros((48, 64), np.uint8)
    img = ffi.new("vt_image_u8 *")
    buf = ffi.from_buffer("uint8_t[]", a)
    img.px, img.w, img.h, img.stride = buf, 64, 48, 64
    out = ffi.new("vt_frame_out *")
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_E_ARG and p.frame == 0   # no state
    assert lib.vt_pipeline_set_flow_ws(ffi.NULL, ffi.NULL) == lib.VT_E_ARG
    st = ffi.new("vt_flow_state *")
    assert lib.vt_pipeline_set_flow_ws(p, st) == lib.VT_OK
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_OK and out.flow_ready == 0
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_OK and out.flow_ready == 1
    # another frame size restarts the stage (a first frame again), not an error
    img.w, img.h, img.stride = 32, 24, 32
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_OK and out.flow_ready == 0
    assert lib.vt_pipeline_set_flow_ws(p, ffi.NULL) == lib.VT_OK
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_E_ARG
    c.flow.cell = 1   # out of range: the pipeline's check names it
    assert lib.vt_pipeline_cfg_check(c) < 0


def test_python_flow_arguments():
    with pytest.raises(ValueError, match="flow"):
        Pipeline(flow={"level": 0})               # without the flow source
    with pytest.raises(TypeError, match="flow"):
        Pipeline(sources=("flow",), flow=3)
    with pytest.raises(TypeError, match="flowy"):
        Pipeline(sources=("flow",), flow={"flowy": 1})


@pytest.mark.parametrize("scenario,side,seed", [("overtake_left", "left", 600), ("overtake_right", "right", 601),
                                                ("keep_distance", "both", 602)])
def test_pipeline_reports_what_the_stand_alone_stage_reports(scenario, side, seed):
    """The README's overtaking figures (tools/eval_flow_synth.py) come from the stand-alone
    stage (pyvehtrack.flow.OvertakingDetector); the product reports through the pipeline's
    flow source. On the evaluation's own scenes (its fresh4 seeds, full-size frames) the
    pipeline's "flow" boxes are the stand-alone hypotheses, frame for frame: EQUAL (both run
    c/flow.c on the same frames with the same settings). Not vacuous: the overtakes give
    hypotheses."""
    from pyvehtrack.flow import OvertakingDetector
    seq = SM.make_sequence(scenario, seed)
    det = OvertakingDetector("c", sides=side)
    pipe = Pipeline("c", sources=("flow",), road="fixed", detect_every=1, flow={"sides": side})
    n = 0
    for t in range(seq.n_frames):
        frame = seq.frame(t)
        want = [tuple(int(v) for v in h.box) for h in det.step(frame).hyps]
        got = [tuple(int(v) for v in b.box) for b in pipe.step(frame).boxes if b.source == "flow"]
        assert sorted(got) == sorted(want), (t, got, want)
        n += len(want)
    assert n > 0 or scenario == "keep_distance"
