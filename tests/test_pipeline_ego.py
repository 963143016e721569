"""The ego-lane detector beside the whole-road detector (issue 8; VT_SRC_EGO in
c/pipeline.c, sources "ego" in pyvehtrack.Pipeline / Detector): the thesis's lead-car
detector keeps the lead car, the classifier's windows add the other lanes.

Checked here: C equals the oracle (reference/pipeline.py) box for box, score for score;
the union is exactly the ego boxes (through the second stage when it is on) followed by
the whole-road detector's own boxes minus those NMS's test suppresses against an ego box;
asking for "ego" without a classifier is an error; the Detector and CLI spellings."""
from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack.fullroad import DEFAULT_WINDOW_MODEL
from pyvehtrack import _native, ffi, lib
from pyvehtrack.detector import Detector
from pyvehtrack.pipeline import Pipeline
from pyvehtrack.reference import windows as rw

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
MODEL = str(DEFAULT_WINDOW_MODEL)
# KITTI frames where the ego detector boxes the lead car (and the windows box it too),
# a Udacity frame and a TuSimple frame with cars in other lanes
FRAMES = [DATA / "kitti_clip" / f"{i:06d}.png" for i in (0, 1, 3, 5)] + \
    [DATA / "udacity_test1_640x360.jpg", DATA / "lane_tusimple_0601_1494452495543904834_gray_640x360.png"]


def _gray(p):
    g = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
    assert g is not None, p
    return g


def _boxes(res):
    return [(b.source, tuple(int(v) for v in b.box), b.score) for b in res.boxes]


@pytest.mark.parametrize("sources", [("ego", "shadow", "classifier"), ("ego", "classifier")])
def test_c_equals_oracle_with_tracking(sources):
    """Four KITTI frames in a row and then the others, tracked (detection every frame):
    the same boxes, sources, scores, hypotheses and tracks in both engines."""
    pc = Pipeline("c", model=MODEL, sources=sources, detect_every=1, track=True)
    pr = Pipeline("reference", model=MODEL, sources=sources, detect_every=1, track=True)
    n_ego = 0
    for p in FRAMES[:4]:
        g = _gray(p)
        a, b = pc.step_gray(g), pr.step_gray(g)
        assert _boxes(a) == _boxes(b), p.name
        assert np.array_equal(a.hypotheses, b.hypotheses), p.name
        assert [(t.id, tuple(t.box)) for t in a.tracks] == [(t.id, tuple(t.box)) for t in b.tracks], p.name
        n_ego += sum(s == "ego" for s, _, _ in _boxes(a))
    assert n_ego >= 3   # not vacuous: the ego detector boxed the lead car
    for p in FRAMES[4:]:
        g = _gray(p)
        a = Pipeline("c", model=MODEL, sources=sources, detect_every=1, track=False).step_gray(g)
        b = Pipeline("reference", model=MODEL, sources=sources, detect_every=1, track=False).step_gray(g)
        assert _boxes(a) == _boxes(b), p.name
        assert np.array_equal(a.hypotheses, b.hypotheses), p.name


def test_union_is_ego_then_unsuppressed_whole_boxes():
    """The union's boxes: the ego detector's boxes that pass the second stage (the model's
    verify_min), then the whole-road detector's boxes in order, without those NMS's test
    (the detector's IoU / containment limits) suppresses against an ego box; an ego box
    scores at least its second-stage score."""
    probe = Pipeline("c", model=MODEL, sources=("ego", "shadow", "classifier"))
    fc = probe._ccfg.fulldet
    vmin = int(probe._ccfg.verify_min)
    assert probe._ccfg.verify == 1
    n_supp = n_ego = 0
    for p in FRAMES:
        g = _gray(p)
        u = Pipeline("c", model=MODEL, sources=("ego", "shadow", "classifier"), detect_every=1,
                     track=False).step_gray(g)
        w = Pipeline("c", model=MODEL, sources=("shadow", "classifier"), detect_every=1, track=False).step_gray(g)
        e = Pipeline("c", sources=("shadow",), detect_every=1, track=False).step_gray(g)   # the ego detector alone
        sq = [(b, _native.classify_box_mlp_default(g, b[0], max(0, b[3] - (b[2] - b[0])), b[2], b[3]))
              for b in (tuple(int(v) for v in x.box) for x in e.boxes)]
        ego = [b for b, s in sq if s >= vmin]
        got = _boxes(u)
        assert [b for s, b, _ in got if s == "ego"] == ego, p.name
        assert all(s == "ego" for s, _, _ in got[:len(ego)]) and all(s != "ego" for s, _, _ in got[len(ego):])
        for (_, _, sc), raw in zip(got, [s for _, s in sq if s >= vmin]):
            assert sc >= raw / 65536 - 1e-9
        kept = [x for x in _boxes(w) if not any(
            rw.suppresses(a, x[1], int(fc.nms_iou_permille), int(fc.nms_contain_permille)) for a in ego)]
        assert got[len(ego):] == kept, p.name
        n_supp += len(w.boxes) - len(kept)
        n_ego += len(ego)
    assert n_ego >= 4 and n_supp >= 3   # not vacuous: ego boxes kept, duplicates dropped


def test_verify_skip_flat():
    """FullRoadConfig(verify_skip_flat=True) (vt_pipeline_cfg.verify 2; a model's detector_json
    "verify_skip_flat"): a whole-road box flatter than 1:2 skips the second stage and keeps its
    first-stage score, every other box goes through it as with verify 1. The window model's
    boxes are never that flat, so there it equals verify 1 (both engines, box for box); the
    shipped ACF file's flat window gives flat boxes, checked in C (its windows alone): each box
    of the verify-2 run is a verify-1 box (tall) or a box of the run whose second stage keeps
    everything (flat), and no tall box is lost."""
    from pyvehtrack import fullroad
    cfg = fullroad.FullRoadConfig(verify_skip_flat=True, verify_skip_edge=False)   # the ACF file's: True
    srcs = ("ego", "shadow", "classifier")
    assert Pipeline("c", model=MODEL, sources=srcs, fullroad=cfg)._ccfg.verify == 2
    for p in FRAMES:
        g = _gray(p)
        v1 = _boxes(Pipeline("c", model=MODEL, sources=srcs, detect_every=1, track=False).step_gray(g))
        v2 = _boxes(Pipeline("c", model=MODEL, sources=srcs, detect_every=1, track=False,
                             fullroad=cfg).step_gray(g))
        ref = _boxes(Pipeline("reference", model=MODEL, sources=srcs, detect_every=1, track=False,
                              fullroad=cfg).step_gray(g))
        assert v2 == v1 == ref, p.name
    acf = str(ROOT / "pyvehtrack" / "models" / "acf_gray.npz")
    flat_kept = 0
    for p in FRAMES:
        g = _gray(p)
        # without the file's box regressor, which moves the sides after the second stage: the
        # skip rule judges the first stage's boxes
        run = [_boxes(Pipeline("c", model=acf, sources=("classifier",), detect_every=1, track=False,
                               fullroad=replace(c, refine=False)).step_gray(g))
               for c in (fullroad.FullRoadConfig(verify_skip_flat=False), cfg,
                         fullroad.FullRoadConfig(verify_min=-30000.0, verify_skip_flat=True,
                                                 verify_skip_edge=False))]
        v1, v2, none = run
        for src, b, sc in v2:
            flat = 2 * (b[3] - b[1] + 1) < b[2] - b[0] + 1
            assert (src, b, sc) in (none if flat else v1), (p.name, b)
            flat_kept += flat
        tall = [x for x in v1 if 2 * (x[1][3] - x[1][1] + 1) >= x[1][2] - x[1][0] + 1]
        assert [x for x in v2 if x in tall] == tall, p.name   # no tall box lost
    assert flat_kept >= 1   # not vacuous: flat boxes the rear-view stage would judge
    # bad values: a clear error naming the setting
    with pytest.raises(TypeError, match="verify_skip_flat"):
        Pipeline("c", model=MODEL, sources=srcs, fullroad=fullroad.FullRoadConfig(verify_skip_flat="yes"))
    with pytest.raises(ValueError, match="verify_skip_flat"):
        fullroad.FullRoadDetector(MODEL, cfg=cfg).detect_gray(_gray(FRAMES[0]))


def _side(b, w):
    """vt_pipeline_cfg.verify 3's edge rule: the gap to the frame's left or right side is at
    most a quarter of the box's width plus 1 px."""
    bw = b[2] - b[0] + 1
    return 4 * b[0] <= bw + 4 or 4 * (w - 1 - b[2]) <= bw + 4


def _skip_kept(cfg_new, cfg_old, skipped) -> int:
    """The second stage with one more kind of box skipped (cfg_new) against the run before
    (cfg_old), both window models: with the window model C == oracle box for box; every
    cfg_new box is a cfg_old box or a box that skipped(box, frame width) says may skip, as in
    the run whose second stage keeps everything; no cfg_old box is lost but for the 32-box
    cap (a skipped box keeps its tree score). Returns how many boxes the shipped ACF file keeps
    that cfg_old dropped. The ACF file runs without its box regressor, which moves the sides
    after the second stage: the skip rules judge the first stage's boxes."""

    from pyvehtrack import fullroad
    keep_all = replace(cfg_new, verify_min=-30000.0)
    srcs = ("ego", "shadow", "classifier")
    acf = str(ROOT / "pyvehtrack" / "models" / "acf_gray.npz")
    kept = 0
    ego = int(lib.VT_SRC_EGO)
    for model, engines, s_ in ((MODEL, ("c", "reference"), srcs), (acf, ("c",), ("classifier",))):
        unrefined = (lambda c: replace(c, refine=False)) if model == acf else (lambda c: c)
        for p in FRAMES:
            g = _gray(p)
            w = g.shape[1]
            new = [_boxes(Pipeline(e, model=model, sources=s_, detect_every=1, track=False,
                                   fullroad=unrefined(cfg_new)).step_gray(g)) for e in engines]
            assert all(x == new[0] for x in new), p.name                 # C == oracle
            new = new[0]
            old, none = [_boxes(Pipeline("c", model=model, sources=s_, detect_every=1, track=False,
                                         fullroad=unrefined(c)).step_gray(g)) for c in (cfg_old, keep_all)]
            for x in new:
                if x[0] == ego:   # the same ego box; its score may take a kept skipped box's
                    assert any(y[0] == ego and y[1] == x[1] and y[2] <= x[2] for y in old), (p.name, x)
                else:
                    assert x in old or (skipped(x[1], w) and x in none), (p.name, x)
                    kept += model == acf and x not in old
            for x in old:
                if x[0] != ego and len(new) < int(lib.VT_MAX_BOXES):
                    assert (x in new) if not skipped(x[1], w) else any(y[1] == x[1] for y in new), (p.name, x)
    return kept


def test_verify_skip_edge():
    """FullRoadConfig(verify_skip_edge=True) (vt_pipeline_cfg.verify 3; detector_json
    "verify_skip_edge"): as verify 2, and a whole-road box the frame's side cuts (4 gap <=
    width + 4) keeps its first-stage score (_skip_kept: C == oracle, nothing else changes),
    with >= 1 side box of the shipped ACF file (its edge models) that verify 2 drops. Bad
    values are clear errors."""
    from pyvehtrack import fullroad
    cfg = fullroad.FullRoadConfig(verify_skip_flat=True, verify_skip_edge=True,
                                  verify_skip_small=False)   # the ACF file's: True (verify 4, below)
    srcs = ("ego", "shadow", "classifier")
    assert Pipeline("c", model=MODEL, sources=srcs, fullroad=cfg)._ccfg.verify == 3
    old = fullroad.FullRoadConfig(verify_skip_flat=True, verify_skip_edge=False)
    assert _skip_kept(cfg, old, _side) >= 1   # not vacuous: an edge-cut box that the rear-view stage drops
    with pytest.raises(TypeError, match="verify_skip_edge"):
        Pipeline("c", model=MODEL, sources=srcs,
                 fullroad=fullroad.FullRoadConfig(verify_skip_flat=True, verify_skip_edge=1))
    with pytest.raises(ValueError, match="verify_skip_edge needs verify_skip_flat"):
        Pipeline("c", model=MODEL, sources=srcs,
                 fullroad=fullroad.FullRoadConfig(verify_skip_flat=False, verify_skip_edge=True))
    with pytest.raises(ValueError, match="verify_skip_edge"):
        fullroad.FullRoadDetector(MODEL, cfg=cfg).detect_gray(_gray(FRAMES[0]))


def test_verify_skip_small():
    """FullRoadConfig(verify_skip_small=True) (vt_pipeline_cfg.verify 4; detector_json
    "verify_skip_small"): as verify 3, and a whole-road box narrower than 32 px (a far car, which
    the 64x64 MLP would judge enlarged 2x or more) keeps its first-stage score (_skip_kept: C ==
    oracle, nothing else changes), with >= 1 small box of the shipped ACF file (its far-car
    window) that verify 3 drops. Bad values are clear errors."""
    from pyvehtrack import fullroad
    cfg = fullroad.FullRoadConfig(verify_skip_flat=True, verify_skip_edge=True, verify_skip_small=True)
    srcs = ("ego", "shadow", "classifier")
    assert Pipeline("c", model=MODEL, sources=srcs, fullroad=cfg)._ccfg.verify == 4
    acf = str(ROOT / "pyvehtrack" / "models" / "acf_gray.npz")
    assert Pipeline("c", model=acf, sources=("classifier",))._ccfg.verify == 4   # the shipped file's setting
    old = fullroad.FullRoadConfig(verify_skip_flat=True, verify_skip_edge=True, verify_skip_small=False)
    from pyvehtrack.reference.pipeline import VERIFY_SMALL_W
    assert VERIFY_SMALL_W == 32   # c/internal.h VT__VERIFY_SMALL_W
    assert _skip_kept(cfg, old, lambda b, w: b[2] - b[0] + 1 < VERIFY_SMALL_W) >= 1   # not vacuous: a far car's box
    with pytest.raises(TypeError, match="verify_skip_small"):
        Pipeline("c", model=MODEL, sources=srcs,
                 fullroad=fullroad.FullRoadConfig(verify_skip_flat=True, verify_skip_edge=True, verify_skip_small=1))
    with pytest.raises(ValueError, match="verify_skip_small needs verify_skip_edge"):
        Pipeline("c", model=MODEL, sources=srcs,
                 fullroad=fullroad.FullRoadConfig(verify_skip_flat=True, verify_skip_edge=False,
                                                  verify_skip_small=True))
    with pytest.raises(ValueError, match="verify_skip_small"):
        fullroad.FullRoadDetector(MODEL, cfg=cfg).detect_gray(_gray(FRAMES[0]))
    c = _native.pipeline_cfg_default()
    c.verify = 5
    with pytest.raises(ValueError):
        _native.pipeline_cfg_check(c)


def test_ego_needs_a_classifier():
    c = _native.pipeline_cfg_default()
    c.sources = lib.VT_SRC_SHADOW | lib.VT_SRC_EGO
    assert lib.vt_pipeline_cfg_check(c) == lib.VT_OK          # a built source ...
    p = ffi.new("vt_pipeline *")
    assert lib.vt_pipeline_init(p, c, ffi.NULL, ffi.NULL) == lib.VT_OK
    g = _gray(FRAMES[0])
    v = _native.view(g, "frame")
    out = ffi.new("vt_frame_out *")
    assert lib.vt_pipeline_step(p, v, out) == lib.VT_E_ARG    # ... that needs a classifier attached
    assert p.frame == 0
    for eng in ("c", "reference"):
        with pytest.raises(ValueError, match="'ego' needs a classifier"):
            Pipeline(eng, sources=("ego", "shadow"))


def test_detector_spellings():
    g = cv2.imread(str(FRAMES[0]))
    d = Detector(model=MODEL, sources=("ego", "shadow", "windows"))
    assert d.ego_too and d.full.sources == ("shadow", "windows")
    r = d.detect(g)
    assert "ego" in list(r.sources) and len(r.scores) == len(r.boxes) and np.isfinite(r.scores).all()
    # the model's own settings name "ego": the same detector without sources=
    r2 = Detector(model=MODEL).detect(g)
    assert np.array_equal(r.boxes, r2.boxes) and list(r.sources) == list(r2.sources)
    # "ego" alone is the ego-lane mode (no classifier); beside a caller's lane stage it cannot run
    with pytest.raises(ValueError, match="uses no classifier"):
        Detector(model=MODEL, sources=("ego",))

    class Lanes:
        def detect(self, frame):
            return None
    with pytest.raises(ValueError, match="lane_detector"):
        Detector(model=MODEL, sources=("ego", "windows"), lane_detector=Lanes())


def test_cli_detect_with_ego(tmp_path):
    out = tmp_path / "found.json"
    r = subprocess.run([sys.executable, "-m", "pyvehtrack", "detect", str(FRAMES[0]), "--model", MODEL,
                        "--sources", "ego", "shadow", "windows", "--json", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    frames = json.loads(out.read_text())
    boxes = frames[0]["boxes"] if isinstance(frames, list) else frames["frames"][0]["boxes"]
    assert boxes and all(len(b) == 5 for b in boxes)


def test_tracker_follows_the_ego_box():
    """`track --model` with the shipped model: the pipeline runs both detectors; on the
    KITTI clip the lead car's track is started by the ego-lane detector and keeps one id."""
    from pyvehtrack.tracker import Tracker
    det = Detector(model=MODEL)
    trk = Tracker(detector=det, detect_every=2)
    ids = []
    for i in range(8):
        tracks = trk.step(cv2.imread(str(DATA / "kitti_clip" / f"{i:06d}.png")))
        ego = [t for t in tracks if t.source == "ego"]
        assert ego, i
        ids.append(ego[0].id)
    assert len(set(ids)) == 1


def test_camera_file_places_the_whole_road_windows():
    """`detect` / `track` with --camera and --model: the file's geometry (horizon cy - fy
    tan(pitch), fx, height, as fractions of image_size) is the whole-road detector's
    flat-road camera; without image_size or height_m there is none (the defaults)."""
    import argparse
    import math

    from pyvehtrack.camera import Camera
    from pyvehtrack.cli.common import make_detector
    cam = Camera.load(DATA / "kitti_clip.camera.json")
    rc = cam.road_camera()
    assert rc.horizon_frac == pytest.approx(54.854 / 256) and rc.fx_per_width == pytest.approx(721.5377 / 640)
    assert rc.height_m == 1.65
    down = replace(cam, pitch_deg=2.0).road_camera()   # looking down: the horizon moves up
    assert down.horizon_frac == pytest.approx((54.854 - 721.5377 * math.tan(math.radians(2.0))) / 256)
    assert replace(cam, image_size=None).road_camera() is None
    assert replace(cam, height_m=None).road_camera() is None
    args = argparse.Namespace(engine="c", road="auto", model=MODEL, sources=None)
    assert make_detector(args, cam).full.camera == rc
    assert make_detector(args).full.camera != rc          # no file: the default (TuSimple) camera
