"""The model source of vt_pipeline_step (the GA vehicle model, c/vehicle_model.c, plugged
into c/pipeline.c for tracks whose ROI search failed) against reference.pipeline end to
end, on the shipped KITTI clip with two frames dropped (replaced by flat gray: the lead
car's ROI search fails there, so its track coasts and the model is asked).

Tolerance: the GA is an exact twin (tests/test_vehicle_model.py: the same xorshift32
draws, integer fitness, identical individuals and result), the pipeline's rules around
it (which tracks ask, ROI, prediction, sigma, road constraint through the track,
fitness and IoU gates) are integer arithmetic written twice, and the other stages are
exact twins on this clip (tests/test_pipeline.py), so boxes, sources, scores, track
ids, states, boxes and sources must be EQUAL."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack._native import ffi, lib
from pyvehtrack.pipeline import Pipeline

CLIP = Path(__file__).parent / "data" / "kitti_clip"
BIG = int(lib.VT_MAX_WIDTH) >= 640 and int(lib.VT_MAX_HEIGHT) >= 256


def _seq():
    frames = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted(CLIP.glob("*.png"))][:9]
    for k in (4, 5):
        frames[k] = np.full_like(frames[k], 128)   # dropped frames
    return frames


def _rows(res):
    return ([(b.box, b.source, b.score) for b in res.boxes],
            [(t.id, t.state, t.box, t.source) for t in res.tracks])


@pytest.mark.skipif(not BIG, reason="needs a build that takes the 640x256 clip")
def test_c_matches_reference_and_the_model_refines_the_coasting_track():
    kw = dict(sources=("shadow", "model"), detect_every=10)
    a, b = Pipeline("c", **kw), Pipeline("reference", **kw)
    states, model_boxes, fits = [], {}, []
    for i, f in enumerate(_seq()):
        ra, rb = a.step(f), b.step(f)
        assert _rows(ra) == _rows(rb), i
        assert ra.model_fits == rb.model_fits, i
        states.append([t.state for t in ra.tracks])
        model_boxes[i] = [x for x in ra.boxes if x.source == "model"]
        fits.append(ra.model_fits)
    # the lead car's track coasts through the dropped frames 4 and 5 ...
    assert states[4] == ["coasting"] and states[5] == ["coasting"], states
    # ... on the flat frame 5 the model fits nothing better than a featureless patch
    # (fitness 255 < model_min_fitness 256); on frame 6 it refines the track (a box
    # of IoU >= match_iou_permille with its last box, its fitness as score), and the
    # track is confirmed again
    assert model_boxes[5] == [] and len(model_boxes[6]) == 1, model_boxes
    assert model_boxes[6][0].score >= 256
    assert states[6] == ["confirmed"]
    assert all(not v for k, v in model_boxes.items() if k not in (6,)), model_boxes
    # fits run (vt_frame_out.model_fits): one per frame after a coasting step (5: run,
    # not used; 6: used), none elsewhere
    assert fits == [0, 0, 0, 0, 0, 1, 1, 0, 0], fits


@pytest.mark.skipif(not BIG, reason="needs a build that takes the 640x256 clip")
def test_model_fits_bound_the_cost():
    """model_fits 0: the model never runs (no model box), the rest as without it."""
    a = Pipeline(sources=("shadow", "model"), detect_every=10, vehicle_model={"fits": 0})
    b = Pipeline(sources=("shadow",), detect_every=10)
    for i, f in enumerate(_seq()):
        assert _rows(a.step(f)) == _rows(b.step(f)), i


def test_model_ws_refusals_and_config_checks():
    c = ffi.new("vt_pipeline_cfg *")
    assert lib.vt_pipeline_cfg_default(c) == lib.VT_OK
    c.sources = lib.VT_SRC_SHADOW | lib.VT_SRC_MODEL
    p = ffi.new("vt_pipeline *")
    assert lib.vt_pipeline_init(p, c, ffi.NULL, ffi.NULL) == lib.VT_OK
    a = np.zeros((48, 64), np.uint8)
    img = ffi.new("vt_image_u8 *")
    buf = ffi.from_buffer("uint8_t[]", a)
    img.px, img.w, img.h, img.stride = buf, 64, 48, 64
    out = ffi.new("vt_frame_out *")
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_E_ARG and p.frame == 0   # no workspace
    assert lib.vt_pipeline_set_model_ws(ffi.NULL, ffi.NULL) == lib.VT_E_ARG
    ws = ffi.new("vt_model_ws *")
    assert lib.vt_pipeline_set_model_ws(p, ws) == lib.VT_OK
    assert lib.vt_pipeline_step(p, img, out) == lib.VT_OK and p.frame == 1
    for field, value in (("model_fits", -1), ("model_fits", int(lib.VT_MAX_TRACKS) + 1),
                         ("model_min_fitness", -1)):
        d = ffi.new("vt_pipeline_cfg *", c[0])
        setattr(d, field, value)
        assert lib.vt_pipeline_cfg_check(d) == lib.VT_E_ARG, field
    d = ffi.new("vt_pipeline_cfg *", c[0])
    d.model.mut_permille = 1001
    assert lib.vt_pipeline_cfg_check(d) < 0


def test_python_model_arguments():
    with pytest.raises(ValueError, match="vehicle_model"):
        Pipeline(vehicle_model={"fits": 1})                 # without the model source
    with pytest.raises(TypeError, match="vehicle_model"):
        Pipeline(sources=("model",), vehicle_model=[1])
    with pytest.raises(ValueError, match="fits"):
        Pipeline(sources=("model",), vehicle_model={"fits": -1})
    with pytest.raises(TypeError, match="nonsense"):
        Pipeline(sources=("model",), vehicle_model={"nonsense": 1})
