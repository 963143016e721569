"""Full-road detection (c/fulldet.c) against its oracle (reference/fulldet.py) with one
shared window scorer (a Python function, called from C through vt_window_scorer):
boxes, scores, sources and counters must agree EXACTLY -- the pyramid (vt_pyr_down vs
cv2-style pyr_down), window rules, shadow and vertical-edge stages are each exact
against their oracles (tests/test_primitives.py, test_windows.py, test_detect.py), and
the composition adds only integer comparisons. Also bad arguments and a scorer error."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pyvehtrack import _native
from pyvehtrack._native import VtError, ffi, lib
from pyvehtrack.reference import fulldet as rfd
from pyvehtrack.reference import windows as rw

DATA = Path(__file__).parent / "data"
MAXW, MAXH = int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)


def mean_score(img: np.ndarray, level: int, s: int, x: int, y: int) -> int:
    """A stand-in classifier: mean brightness of the window minus 100, plus a fixed
    pseudo-random part so that scores tie rarely and both signs occur."""
    win = img[y:y + s, x:x + s].astype(np.int64)
    return int(win.sum() // (s * s)) - 100 + ((x * 7 + y * 13 + level * 5 + s) % 11)


class CScorer:
    """The same scorer for C: a vt_window_scorer whose score() reads the level image."""

    def __init__(self, fn, fail_at: int | None = None):
        self.calls, self.levels = 0, []

        @ffi.callback("vt_status(void *, const vt_image_u8 *, const vt_window *, int32_t *)")
        def score(ctx, img, win, out):
            self.calls += 1
            if fail_at is not None and self.calls >= fail_at:
                return lib.VT_E_ARG
            a = np.frombuffer(ffi.buffer(img.px, img.stride * img.h), np.uint8).reshape(img.h, img.stride)
            out[0] = fn(a[:, :img.w], win.level, win.size, win.x, win.y)
            return 0

        @ffi.callback("vt_status(void *, const vt_image_u8 *, int32_t, int32_t, int32_t)")
        def level(ctx, img, lvl, y0, y1):
            self.levels.append((lvl, y0, y1, img.w, img.h))
            return 0

        self._cb = (score, level)
        self.c = ffi.new("vt_window_scorer *")
        self.c.score, self.c.level = score, level


def c_cfg(cfg: rfd.FullDetConfig):
    c = _native.fulldet_cfg_default()
    c.sources = (1 if cfg.shadow_source else 0) | (2 if cfg.window_source else 0)
    w = cfg.win
    c.win.veh_w_min_mm, c.win.veh_w_max_mm = round(w.veh_w_min_m * 1000), round(w.veh_w_max_m * 1000)
    c.win.n_sizes = len(w.sizes)
    for i, s in enumerate(w.sizes):
        c.win.size[i] = s
    c.win.step_q8, c.win.levels = round(w.step * 256), w.levels
    c.win.lane_w_mm, c.win.top_margin = round(w.lane_w_m * 1000), w.top_margin
    c.window_score_min, c.edge_check = cfg.window_score_min, int(cfg.edge_check)
    c.shadow_classify, c.shadow_score_min, c.shadow_score = int(cfg.shadow_classify), cfg.shadow_score_min, \
        cfg.shadow_score
    c.nms_iou_permille, c.nms_contain_permille = cfg.nms_iou_permille, cfg.nms_contain_permille
    c.box_height_q8 = round(cfg.box_height * 256)
    c.merge_iou_permille = cfg.merge_iou_permille
    assert lib.vt_fulldet_cfg_check(c) == 0
    return c


def run_both(gray, cam: rw.Camera, cfg: rfd.FullDetConfig, use_scorer=True):
    h, w = gray.shape
    ccfg = c_cfg(cfg)
    ccam = _native.camera_min(cam.fx, cam.horizon_y, round(cam.height_m * 1000), cam.hood_y)
    road_c = _native.road_from_camera(ffi.addressof(ccfg, "win"), ccam, w, h)
    road_r = rw.road_from_camera(cam, cfg.win, w, h)
    st_ = ffi.new("vt_fulldet_state *")
    out = ffi.new("vt_fulldet_result *")
    sc = CScorer(mean_score) if use_scorer else None
    got = _native.fulldet(st_, ccfg, ccam, gray, road_c, sc.c if sc else None, out)
    ref, stats = rfd.detect(gray, road_r, cam, cfg, mean_score if use_scorer else None,
                            max_windows=int(lib.VT_FULLDET_MAX_WINDOWS), max_cand=int(lib.VT_FULLDET_MAX_CAND),
                            max_boxes=int(lib.VT_MAX_BOXES), max_hyp=int(lib.VT_MAX_HYPOTHESES))
    got_a = np.stack([got[k] for k in ("left", "top", "right", "bottom", "score", "source")], 1).reshape(-1, 6)
    return got_a, ref, {k: getattr(out, k) for k in stats}, stats, sc


def kitti_frame():
    img = cv2.imread(str(DATA / "kitti_lead_30_gray_621x188.png"), cv2.IMREAD_GRAYSCALE)
    assert img is not None
    return img


KITTI_CAM = rw.Camera(fx=360.0, horizon_y=88, height_m=1.65, hood_y=188)


def test_real_frame_matches_oracle():
    gray = kitti_frame()
    cfg = rfd.FullDetConfig(win=rw.WindowConfig(sizes=(16, 23), levels=4))
    got, ref, cst, rst, sc = run_both(gray, KITTI_CAM, cfg)
    assert cst == rst
    assert rst["n_windows"] > 100 and rst["n_window_hits"] > 0 and len(ref) > 0
    assert np.array_equal(got, ref)
    # the level hook saw every level that has windows, with the band its windows cover
    assert sorted({lv for lv, *_ in sc.levels}) == sorted({lv for lv in range(4)
                                                          if len(rw.windows_level(cfg.win, KITTI_CAM, None, 621,
                                                                                  188, lv))})


def test_without_scorer_shadow_only():
    gray = kitti_frame()
    cfg = rfd.FullDetConfig(win=rw.WindowConfig(sizes=(16, 23), levels=4), shadow_score=5)
    got, ref, cst, rst, _ = run_both(gray, KITTI_CAM, cfg, use_scorer=False)
    assert cst == rst and np.array_equal(got, ref)
    assert rst["n_window_hits"] == 0 and (ref[:, 5] == 1).all() and (ref[:, 4] == 5).all()


@settings(max_examples=12)
@given(st.integers(0, 2 ** 31 - 1), st.booleans(), st.booleans(), st.booleans(), st.integers(-20, 20),
       st.integers(0, 1000), st.integers(0, 1000), st.integers(1, 1024))
def test_random_frames_match_oracle(seed, shadow, windows, edge, smin, iou, contain, bh):
    rng = np.random.default_rng(seed)
    h, w = int(rng.integers(24, min(MAXH, 160))), int(rng.integers(24, min(MAXW, 220)))
    # blocky scene: dark rectangles (vehicle-like) on a mid-gray road with noise
    gray = np.full((h, w), 120, np.int64) + rng.integers(-10, 10, (h, w))
    for _ in range(int(rng.integers(1, 6))):
        x0, y0 = int(rng.integers(0, w - 8)), int(rng.integers(h // 3, h - 4))
        gray[y0 - min(y0, 20):y0, x0:x0 + int(rng.integers(6, 40))] = int(rng.integers(0, 255))
    gray = np.clip(gray, 0, 255).astype(np.uint8)
    cam = rw.Camera(fx=300.0, horizon_y=int(rng.integers(-5, h // 2)), height_m=1.5,
                    hood_y=int(rng.integers(h * 3 // 4, h + 2)))
    cfg = rfd.FullDetConfig(shadow_source=shadow or not windows, window_source=windows,
                            win=rw.WindowConfig(sizes=(8, 11, 16), levels=3, step=0.25),
                            edge_check=edge, window_score_min=smin, shadow_score_min=smin,
                            nms_iou_permille=iou, nms_contain_permille=contain, box_height=bh / 256)
    got, ref, cst, rst, _ = run_both(gray, cam, cfg)
    assert cst == rst
    assert np.array_equal(got, ref)


def test_bad_arguments_and_scorer_error():
    gray = kitti_frame()
    cfg = _native.fulldet_cfg_default()
    cam = _native.camera_min(360.0, 88, 1650, 188)
    road = _native.road_from_camera(ffi.addressof(cfg, "win"), cam, 621, 188)
    st_ = ffi.new("vt_fulldet_state *")
    out = ffi.new("vt_fulldet_result *")
    v = _native.view(gray, "img")
    assert lib.vt_fulldet(st_, cfg, cam, v, road, ffi.NULL, ffi.NULL) == lib.VT_E_ARG
    out.n_boxes = 9
    for args in ((ffi.NULL, cfg, cam, v, road), (st_, ffi.NULL, cam, v, road), (st_, cfg, ffi.NULL, v, road),
                 (st_, cfg, cam, ffi.NULL, road), (st_, cfg, cam, v, ffi.NULL)):
        assert lib.vt_fulldet(*args, ffi.NULL, out) == lib.VT_E_ARG and out.n_boxes == 0
    empty = ffi.new("vt_window_scorer *")          # score NULL
    assert lib.vt_fulldet(st_, cfg, cam, v, road, empty, out) == lib.VT_E_ARG
    bad = _native.fulldet_cfg_default()
    bad.sources = 0
    assert lib.vt_fulldet_cfg_check(bad) == lib.VT_E_ARG
    bad = _native.fulldet_cfg_default()
    bad.nms_iou_permille = 1001
    assert lib.vt_fulldet_cfg_check(bad) == lib.VT_E_ARG
    bad = _native.fulldet_cfg_default()
    bad.nms_contain_permille = -1
    assert lib.vt_fulldet_cfg_check(bad) == lib.VT_E_ARG
    bad = _native.fulldet_cfg_default()
    bad.win.levels = 0
    assert lib.vt_fulldet_cfg_check(bad) == lib.VT_E_ARG
    other = _native.road_from_camera(ffi.addressof(cfg, "win"), cam, 621, 150)
    assert lib.vt_fulldet(st_, cfg, cam, v, other, ffi.NULL, out) == lib.VT_E_SIZE
    zero = np.zeros((0, 5), np.uint8)
    with pytest.raises(VtError, match="vt_fulldet"):
        _native.fulldet(st_, cfg, cam, zero, road, None, out)
    sc = CScorer(mean_score, fail_at=3)
    with pytest.raises(VtError, match="vt_fulldet"):
        _native.fulldet(st_, cfg, cam, gray, road, sc.c, out)
    assert out.n_boxes == 0 and sc.calls == 3


def test_c_default_config_equals_oracle_default():
    c = _native.fulldet_cfg_default()
    assert lib.vt_fulldet_cfg_check(c) == 0
    cc = c_cfg(rfd.FullDetConfig())
    for name in ("sources", "window_score_min", "edge_check", "shadow_classify", "shadow_score_min", "shadow_score",
                 "nms_iou_permille", "nms_contain_permille", "box_height_q8", "merge_iou_permille"):
        assert getattr(c, name) == getattr(cc, name), name
    assert bytes(ffi.buffer(ffi.addressof(c, "win"))) == bytes(ffi.buffer(ffi.addressof(cc, "win")))
    ref = rfd.FullDetConfig()
    for f in ref.verify.__dataclass_fields__:
        assert getattr(c.det.verify, f) == getattr(ref.verify, f), f
    for f in ref.shadow.__dataclass_fields__:
        assert getattr(c.det.shadow, f) == getattr(ref.shadow, f), f


# ---------------------------------------------------------------- box refinement (merge_iou_permille)
@settings(max_examples=12)
@given(st.integers(0, 2 ** 31 - 1), st.integers(1, 1000), st.integers(0, 1000), st.integers(-20, 10))
def test_merge_matches_oracle(seed, merge, iou, smin):
    """With merge_iou_permille > 0 each kept box is the mean (rounded half up) of the
    candidates overlapping it: C and oracle agree exactly, scores and sources untouched."""
    rng = np.random.default_rng(seed)
    h, w = int(rng.integers(40, min(MAXH, 160))), int(rng.integers(40, min(MAXW, 220)))
    gray = np.clip(np.full((h, w), 120) + rng.integers(-40, 40, (h, w)), 0, 255).astype(np.uint8)
    cam = rw.Camera(fx=300.0, horizon_y=int(rng.integers(0, h // 3)), height_m=1.5, hood_y=h)
    base = rfd.FullDetConfig(win=rw.WindowConfig(sizes=(8, 11, 16), levels=3, step=0.25), edge_check=False,
                             window_score_min=smin, shadow_score_min=smin, nms_iou_permille=iou,
                             nms_contain_permille=1000)
    plain = run_both(gray, cam, base)
    from dataclasses import replace
    got, ref, cst, rst, _ = run_both(gray, cam, replace(base, merge_iou_permille=merge))
    assert cst == rst
    assert np.array_equal(got, ref)
    # the same boxes were kept: merging moves them, it does not add or drop any
    assert len(got) == len(plain[0]) and np.array_equal(got[:, 4:], plain[0][:, 4:])


def test_merge_moves_a_box_to_its_neighbours_mean():
    gray = kitti_frame()
    from dataclasses import replace
    cfg = rfd.FullDetConfig(win=rw.WindowConfig(sizes=(16, 23), levels=4), edge_check=False,
                            nms_iou_permille=300)
    plain, *_ = run_both(gray, KITTI_CAM, cfg)
    got, ref, *_ = run_both(gray, KITTI_CAM, replace(cfg, merge_iou_permille=300))
    assert np.array_equal(got, ref) and len(got) == len(plain)
    assert (got[:, :4] != plain[:, :4]).any()        # some box moved (it had overlapping neighbours)
    bad = _native.fulldet_cfg_default()
    for v in (-1, 1001):
        bad.merge_iou_permille = v
        assert lib.vt_fulldet_cfg_check(bad) == lib.VT_E_ARG


# ---------------------------------------------------------------- second stage (vt_fulldet_verify)
def _result(boxes):
    out = ffi.new("vt_fulldet_result *")
    out.n_boxes = len(boxes)
    for i, (l, t, r, b, sc, src) in enumerate(boxes):
        out.box[i].box.left, out.box[i].box.top, out.box[i].box.right, out.box[i].box.bottom = l, t, r, b
        out.box[i].score, out.box[i].source = sc, src
    return out


def test_verify_matches_oracle_and_rejects_bad_arguments():
    """vt_fulldet_verify = reference.fulldet.verify_boxes with the same box scorer
    (vt_classify_box_mlp, exact against its own oracle in tests/test_classify.py)."""
    gray = kitti_frame()
    h, w = gray.shape
    rng = np.random.default_rng(3)
    boxes = []
    for _ in range(int(lib.VT_MAX_BOXES)):
        l = int(rng.integers(0, w - 20)); r = int(rng.integers(l + 4, min(w, l + 120)))
        b = int(rng.integers(10, h)); t = int(rng.integers(max(0, b - 80), b + 1))
        boxes.append((l, t, r, b, int(rng.integers(-9, 9)), int(rng.integers(1, 3))))
    m = _native.mlp_default_model()
    ws = _native.box_ws_new()

    def score_box(l, t, r, b):
        out = ffi.new("int32_t *")
        bx = ffi.new("vt_box *", [l, t, r, b])
        assert lib.vt_classify_box_mlp(ws, m, _native.view(gray, "img"), bx, out) == 0
        return int(out[0])

    all_scores = [score_box(l, max(0, b - (r - l)), r, b) for l, t, r, b, _, _ in boxes]
    for smin in (-2 ** 31, int(np.median(all_scores)), 2 ** 31 - 1):
        res = _result(boxes)
        got = _native.fulldet_verify(ws, m, gray, smin, res)
        got_a = np.stack([got[k] for k in ("left", "top", "right", "bottom", "score", "source")], 1).reshape(-1, 6)
        ref = rfd.verify_boxes(np.array(boxes, np.int64), score_box, smin)
        assert np.array_equal(got_a, ref)
    assert 0 < len(rfd.verify_boxes(np.array(boxes), score_box, int(np.median(all_scores)))) < len(boxes)
    # bad arguments: clear status, result unchanged
    v = _native.view(gray, "img")
    res = _result(boxes[:3])
    for args in ((ffi.NULL, m, v, 0, res), (ws, ffi.NULL, v, 0, res), (ws, m, ffi.NULL, 0, res),
                 (ws, m, v, 0, ffi.NULL)):
        assert lib.vt_fulldet_verify(*args) == lib.VT_E_ARG
    for bad in ([(0, 0, w, 5, 0, 1)], [(5, 5, 4, 9, 0, 1)], [(-1, 0, 5, 5, 0, 1)], [(0, 0, 5, h, 0, 1)]):
        r2 = _result(bad)
        assert lib.vt_fulldet_verify(ws, m, v, 0, r2) == lib.VT_E_ARG and r2.n_boxes == 1
    res.n_boxes = int(lib.VT_MAX_BOXES) + 1
    assert lib.vt_fulldet_verify(ws, m, v, 0, res) == lib.VT_E_ARG and res.n_boxes == int(lib.VT_MAX_BOXES) + 1
    res.n_boxes = -1
    assert lib.vt_fulldet_verify(ws, m, v, 0, res) == lib.VT_E_ARG
    with pytest.raises(VtError, match="vt_fulldet_verify"):
        _native.fulldet_verify(ws, m, np.zeros((0, 4), np.uint8), 0, _result([]))
