"""The fused TTC of vt_pipeline_step (vt_pipe_track.ttc_fused_q16, issue 9 item 4): the
weighted mean of the block-scale TTC P (ttc_points) and the camera stage's distance/rate
TTC D, w = cfg.ttc_fuse_permille on D; the known one when only one is.

Tolerances, from the arithmetic in pipeline.h:
  - C against its own rule: the output carries P exactly (Q16) but D only as ttc_ms =
    round(D / 65.536), so D = 65.536 ttc_ms +- 32.768 Q16 units; the mean then lies within
    w / 1000 x 32.768 + 1 (C's own rounding) Q16 units of the mean computed from ttc_ms.
  - C against the oracle (reference.pipeline.ttc_fuse, float): a weighted mean of two errors,
    (1 - w/1000) x the block-scale bound of tests/test_pipeline_ttc.py plus w/1000 x the
    distance TTC's 2.1 % + 0.5 ms of tests/test_pipeline.py, plus 1 / 65536 of C's rounding.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import pytest

from pyvehtrack import _native
from pyvehtrack._native import ffi, lib
from pyvehtrack.camera import Camera, fuse_ttc
from pyvehtrack.pipeline import Pipeline

from test_pipeline_ttc import _bound

CLIP = Path(__file__).parent / "data" / "kitti_clip"
CAM = {"fx": 721.5377, "fy": 721.5377, "cx": 309.5593, "cy": 54.854, "height_m": 1.65,
       "pitch_deg": 0.0, "image_size": [640, 256]}
Q = 65536


def _clip(n):
    return [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted(CLIP.glob("0*.png"))[:n]]


def _c_tracks(pipe, frames):
    """Each frame's raw vt_pipe_track values (P, ttc_ms, fused) from the C pipeline."""
    out = []
    for f in frames:
        pipe.step(f)
        o = pipe._out
        out.append([(int(o.tracks[i].ttc_points_q16), int(o.tracks[i].ttc_ms), int(o.tracks[i].ttc_fused_q16))
                    for i in range(o.n_tracks)])
    return out


@pytest.mark.parametrize("w", [None, 0, 1000, 457])
def test_c_follows_its_rule_on_kitti_clip(w):
    """C's fused value against the rule, from the values it outputs beside it (see the
    module's tolerance); both TTCs are known on several of the clip's frames."""
    tp = {"lag": 3, "min_lag": 3} if w is None else {"lag": 3, "min_lag": 3, "fuse_permille": w}
    pipe = Pipeline("c", camera=Camera.from_dict(CAM), fps=10, ttc_points=tp)
    ww = 300 if w is None else w
    assert int(pipe._ccfg.ttc_fuse_permille) == ww
    both = 0
    for i, rows in enumerate(_c_tracks(pipe, _clip(12))):
        for p, ms, fused in rows:
            if p != lib.VT_UNKNOWN and ms != lib.VT_UNKNOWN:
                want = (p * (1000 - ww) + ms * Q / 1000 * ww) / 1000
                assert abs(fused - want) <= ww / 1000 * Q / 2000 + 1, (i, p, ms, fused)
                assert min(p, ms * Q / 1000) - Q / 2000 - 1 <= fused <= max(p, ms * Q / 1000) + Q / 2000 + 1
                both += 1
            elif p != lib.VT_UNKNOWN:
                assert fused == p, i
            elif ms != lib.VT_UNKNOWN:
                assert abs(fused * 1000 / Q - ms) <= 0.5 + 1e-9, (i, ms, fused)
            else:
                assert fused == lib.VT_UNKNOWN, i
    assert both >= 3


def test_c_matches_reference_on_kitti_clip():
    """C against the oracle on the clip, with the camera and the block-scale TTC (lag 3 as in
    tests/test_pipeline_ttc.py, which keeps the oracle's Python SAD search short)."""
    cam = Camera.from_dict(CAM)
    kw = dict(camera=cam, fps=10, ttc_points={"lag": 3, "min_lag": 3})
    a, b = Pipeline("c", **kw), Pipeline("reference", **kw)
    both = 0
    for i, f in enumerate(_clip(10)):
        ra, rb = a.step(f), b.step(f)
        assert [(t.id, t.box) for t in ra.tracks] == [(t.id, t.box) for t in rb.tracks], i
        for x, y in zip(ra.tracks, rb.tracks):
            assert (x.ttc_fused is None) == (y.ttc_fused is None), (i, x, y)
            if x.ttc_fused is None:
                continue
            tol = 1 / Q
            if x.ttc_points is not None:
                tol += 0.7 * _bound(3, 6554 / Q, 16, 1 + 3 * 0.1 / max(x.ttc_points, y.ttc_points))
            if x.ttc is not None:
                tol += 0.3 * (0.021 * y.ttc + 5e-4)
            if x.ttc_points is not None and x.ttc is not None:
                both += 1
            assert abs(x.ttc_fused - y.ttc_fused) <= tol, (i, x.ttc_fused, y.ttc_fused, tol)
    assert both >= 3


def test_without_camera_the_fused_ttc_is_the_block_scale_one():
    pipe = Pipeline("c", fps=10, ttc_points={"lag": 3, "min_lag": 3})
    known = 0
    for f in _clip(8):
        for t in pipe.step(f).tracks:
            assert t.ttc_fused == t.ttc_points and t.ttc is None
            known += t.ttc_fused is not None
    assert known >= 3


def test_arguments():
    with pytest.raises(ValueError, match="fuse_permille"):
        Pipeline("c", ttc_points={"fuse_permille": 1001})
    with pytest.raises(ValueError, match="fuse_permille"):
        Pipeline("c", ttc_points={"fuse_permille": -1})
    with pytest.raises(ValueError, match="fuse_permille.*integer"):
        Pipeline("c", ttc_points={"fuse_permille": 0.5})
    with pytest.raises(TypeError, match="fuse_permille"):
        Pipeline("c", ttc_points={"fuse_permille": "300"})
    c = _native.pipeline_cfg_default()
    assert c.ttc_fuse_permille == 300
    for v, ok in ((0, True), (1000, True), (-1, False), (1001, False), (-2**31, False)):
        c.ttc_fuse_permille = v
        assert lib.vt_pipeline_cfg_check(c) == (lib.VT_OK if ok else lib.VT_E_ARG), v
    assert fuse_ttc(None, None) is None and fuse_ttc(2.0, None) == 2.0 and fuse_ttc(None, 3.0) == 3.0
    assert fuse_ttc(10.0, 20.0) == pytest.approx(13.0) and fuse_ttc(10.0, 20.0, 500) == pytest.approx(15.0)
    with pytest.raises(ValueError, match="weight_permille"):
        fuse_ttc(1.0, 2.0, 1001)
