#!/usr/bin/env python3
"""`make bench`: each stage, C (through cffi) against the float oracle in one run,
plus callgrind instructions per pixel of the C alone. A benchmark, not a test:
it prints figures and never passes or fails on them.

    make bench                      # the usual way (builds an -O2 extension and the driver)
    python bench/bench.py [--quick] [--driver BUILD/bench/callgrind_main] [--out bench/results]

For every registered stage it reports
- the median wall time of one run, in µs, for the C through `pyvehtrack._native`
  (outputs preallocated, so the C column is the C plus the cffi call) and for the
  oracle in `pyvehtrack.reference`, and the ratio oracle/C;
- from `valgrind --tool=callgrind` on bench/callgrind_main.c doing the same run on
  the same frame: instructions (Ir) per run, per pixel and per item;
- whether the driver's output digest equals the one from the cffi run (same work,
  same data).
It writes the table to stdout, to OUT.md and to OUT.json, with the machine,
compiler, date, and sizeof of every struct the cffi binding knows.

Adding a stage (lane, detect, tracker, ...) is one entry: a function decorated
with `@register("name", sizes=...)` that receives a `Ctx` (the gray frame, quick
flag, seeded random numbers) and returns a `Stage` with a "C" and a "reference"
callable, the pixel count and the number of items one run handles. Give
bench/callgrind_main.c a stage of the same name (setup/run/digest) to get its
instruction count; without one the callgrind columns show "—".
"""
from __future__ import annotations

import argparse
import datetime as _dt
import gc
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
import callgrind  # noqa: E402  (bench/callgrind.py, next to this file)

BASE_FRAME = HERE / "data" / "road_640x480.png"
FULL_SIZES = ((640, 480),)


# ---------------------------------------------------------------- registry
@dataclass
class Stage:
    """One benchmarked unit of work. `c` and `reference` each do one complete run,
    from the same starting state every time (reset any state inside the callable).

    pixels: image pixels one run processes (0 when cost does not scale with
    pixels, e.g. box sums from an integral image); units/unit: the items one run
    handles ("frame", "box", ...); digest: checksum of the C outputs of the last
    run, the same fold as bench/callgrind_main.c (None: not compared)."""

    name: str
    c: Callable[[], Any]
    reference: Callable[[], Any] | None
    pixels: int
    units: int = 1
    unit: str = "frame"
    digest: Callable[[], int] | None = None
    note: str = ""
    calls: int | None = None  # pyvehtrack calls one C run makes (None: one per unit)

    @property
    def binding_calls(self) -> int:
        return self.units if self.calls is None else self.calls


@dataclass
class StageSpec:
    name: str
    make: Callable[["Ctx"], Stage]
    sizes: tuple[tuple[int, int], ...]
    driver: bool  # bench/callgrind_main.c has a stage of this name


REGISTRY: list[StageSpec] = []


def register(name: str, sizes: tuple[tuple[int, int], ...] = FULL_SIZES, driver: bool = True):
    """Decorator: add a stage factory `make(ctx) -> Stage` to the bench."""
    def deco(make: Callable[["Ctx"], Stage]):
        if any(s.name == name for s in REGISTRY):
            raise ValueError(f"stage {name!r} registered twice")
        REGISTRY.append(StageSpec(name, make, tuple(sizes), driver))
        return make
    return deco


@dataclass
class Ctx:
    frame: np.ndarray  # gray uint8 (h, w)
    quick: bool

    def units(self, full: int, quick: int) -> int:
        return quick if self.quick else full

    @staticmethod
    def xorshift32(seed: int) -> Iterator[int]:
        """The generator bench/callgrind_main.c uses, so both draw the same inputs."""
        x = seed & 0xFFFFFFFF
        while True:
            x ^= (x << 13) & 0xFFFFFFFF
            x ^= x >> 17
            x ^= (x << 5) & 0xFFFFFFFF
            yield x


def digest(values) -> int:
    """sum((uint32)v[i] * (i + 1)) mod 2^32 over the values in row-major order.
    uint64 arithmetic wraps mod 2^64, a multiple of 2^32, so the result is exact."""
    v = np.asarray(values).astype(np.int64).ravel().astype(np.uint64)
    idx = np.arange(1, v.size + 1, dtype=np.uint64)
    return int((v * idx).sum(dtype=np.uint64)) & 0xFFFFFFFF


# ---------------------------------------------------------------- the primitives (issue 2)
def _frame_op(name: str, c_name: str, out_shape: Callable[[tuple[int, int]], tuple[int, int]],
              dtype, note: str = ""):
    def make(ctx: Ctx) -> Stage:
        from pyvehtrack import _native
        from pyvehtrack.reference import image as ref
        img = ctx.frame
        out = np.empty(out_shape(img.shape), dtype)
        cfn, rfn = getattr(_native, c_name), getattr(ref, name)
        return Stage(name, c=lambda: cfn(img, out), reference=lambda: rfn(img),
                     pixels=img.size, digest=lambda: digest(out), note=note, calls=1)
    register(name)(make)


_same = lambda s: s  # noqa: E731
_frame_op("filter_h101", "filter_h101", _same, np.int16)
_frame_op("sobel_x", "sobel_x", _same, np.int16)
_frame_op("sobel_y", "sobel_y", _same, np.int16)
_frame_op("pyr_down", "pyr_down", lambda s: ((s[0] + 1) // 2, (s[1] + 1) // 2), np.uint8,
          note="per input px")
_frame_op("integral", "integral", lambda s: (s[0] + 1, s[1] + 1), np.uint32)


@register("box_sum")
def _box_sum(ctx: Ctx) -> Stage:
    from pyvehtrack import _native
    from pyvehtrack.reference import image as ref
    img = ctx.frame
    h, w = img.shape
    ii = np.empty((h + 1, w + 1), np.uint32)
    _native.integral(img, ii)
    rnd = ctx.xorshift32(1)
    boxes = []
    for _ in range(ctx.units(10000, 100)):
        x = next(rnd) % w
        bw = 1 + next(rnd) % (w - x)
        y = next(rnd) % h
        bh = 1 + next(rnd) % (h - y)
        boxes.append((x, y, bw, bh))
    out = np.zeros(len(boxes), np.int64)

    def c():
        f = _native.box_sum
        for i, (x, y, bw, bh) in enumerate(boxes):
            out[i] = f(ii, x, y, bw, bh)

    def reference():
        return [ref.box_sum(img, x, y, bw, bh) for x, y, bw, bh in boxes]

    return Stage("box_sum", c, reference, pixels=0, units=len(boxes), unit="box",
                 digest=lambda: digest(out),
                 note="C: 4 lookups in a prepared integral image; oracle: sums the box's pixels")


def _pairs(ctx: Ctx, seed: int, side: int, n: int):
    img = ctx.frame
    h, w = img.shape
    p = min(side, w, h)
    rnd = ctx.xorshift32(seed)
    pairs = []
    for _ in range(n):
        xa, ya, xb, yb = (next(rnd) % (w - p + 1), next(rnd) % (h - p + 1),
                          next(rnd) % (w - p + 1), next(rnd) % (h - p + 1))
        pairs.append((img[ya:ya + p, xa:xa + p], img[yb:yb + p, xb:xb + p]))
    return p, pairs


@register("ncc")
def _ncc(ctx: Ctx) -> Stage:
    from pyvehtrack import _native
    from pyvehtrack.reference import image as ref
    p, pairs = _pairs(ctx, 2, 64, ctx.units(100, 4))
    out = np.zeros(len(pairs), np.int64)

    def c():
        f, err = _native.ncc_u8, _native.VtError
        for i, (a, b) in enumerate(pairs):
            try:
                out[i] = f(a, b)
            except err as e:  # a flat patch: the driver records the status code too
                out[i] = e.status

    def reference():
        return [ref.ncc(a, b) for a, b in pairs]

    return Stage("ncc", c, reference, pixels=len(pairs) * p * p, units=len(pairs),
                 unit=f"{p}x{p} pair", digest=lambda: digest(out))


@register("sad")
def _sad(ctx: Ctx) -> Stage:
    from pyvehtrack import _native
    from pyvehtrack.reference import image as ref
    p, pairs = _pairs(ctx, 3, 16, ctx.units(1000, 20))
    out = np.zeros(len(pairs), np.int64)

    def c():
        f = _native.sad_u8
        for i, (a, b) in enumerate(pairs):
            out[i] = f(a, b)

    def reference():
        return [ref.sad(a, b) for a, b in pairs]

    return Stage("sad", c, reference, pixels=len(pairs) * p * p, units=len(pairs),
                 unit=f"{p}x{p} pair", digest=lambda: digest(out))


@register("sincos")
def _sincos(ctx: Ctx) -> Stage:
    from pyvehtrack import _native
    from pyvehtrack.reference import image as ref
    rnd = ctx.xorshift32(4)
    # Any int32 angle in quarter degrees, as the driver draws them.
    angles = [(r - (1 << 32)) if r >= 1 << 31 else r
              for r in (next(rnd) for _ in range(ctx.units(1440, 64)))]
    out = np.zeros(2 * len(angles), np.int64)

    def c():
        f = _native.sincos_q14
        for i, a in enumerate(angles):
            out[2 * i], out[2 * i + 1] = f(a)

    def reference():
        return [ref.sincos(a / 4.0) for a in angles]

    return Stage("sincos", c, reference, pixels=0, units=len(angles), unit="angle",
                 digest=lambda: digest(out))


# ---------------------------------------------------------------- detection (issue 3)
DETECT_SIZES = ((640, 480), (1280, 720))


def _bench_road(h: int, w: int):
    """The Detector's fixed fallback trapezoid (pyvehtrack.detector.FixedRoad defaults);
    bench/callgrind_main.c builds the same one."""
    from pyvehtrack.reference.shadow import trapezoid_road
    return trapezoid_road(h, w, vp=(0.5, 0.45), bottom=(0.05, 0.95), lane_bottom=0.45)


def _detect_setup(ctx: Ctx):
    from pyvehtrack import _native
    from pyvehtrack.detector import DetectConfig, c_default_config
    img = ctx.frame
    road = _bench_road(*img.shape)
    return _native, img, road, _native.road_area(road, img.shape[0]), _native.detect_cfg_default(), \
        c_default_config()


@register("shadow", sizes=DETECT_SIZES)
def _shadow(ctx: Ctx) -> Stage:
    from pyvehtrack.reference import shadow as rshadow
    nat, img, road, croad, ccfg, pcfg = _detect_setup(ctx)
    st = nat.ffi.new("vt_shadow_state *")
    cap = int(nat.lib.VT_MAX_HYPOTHESES)
    out = np.zeros((cap, 3), np.int32)
    last = {}

    def c():
        last["n"] = nat.shadow_find(st, nat.ffi.addressof(ccfg, "shadow"), img, croad, out, cap)

    def reference():
        return rshadow.find_hypotheses(img, road, pcfg.shadow, max_active=int(nat.lib.VT_MAX_SHADOW_ACTIVE),
                                       max_cand=int(nat.lib.VT_MAX_SHADOW_CAND), max_out=cap)

    return Stage("shadow", c, reference, pixels=img.size, calls=1,
                 digest=lambda: digest(out[: last["n"]]) if last.get("n") else 0,
                 note="road area: the fixed trapezoid")


@register("verify", sizes=DETECT_SIZES)
def _verify(ctx: Ctx) -> Stage:
    from pyvehtrack.reference import verify as rverify
    nat, img, road, croad, ccfg, pcfg = _detect_setup(ctx)
    st = nat.ffi.new("vt_shadow_state *")
    cap = int(nat.lib.VT_MAX_HYPOTHESES)
    hyp = np.zeros((cap, 3), np.int32)
    n = nat.shadow_find(st, nat.ffi.addressof(ccfg, "shadow"), img, croad, hyp, cap)
    hyp = np.ascontiguousarray(hyp[:n])
    vst = nat.ffi.new("vt_verify_state *")
    bcap = int(nat.lib.VT_MAX_BOXES)
    out = np.zeros((bcap, 4), np.int32)
    last = {}

    def c():
        last["n"] = nat.verify(vst, nat.ffi.addressof(ccfg, "verify"), img, hyp, out, bcap)

    def reference():
        return rverify.verify(img, hyp, pcfg.verify, max_out=bcap)

    return Stage("verify", c, reference, pixels=img.size, calls=1,
                 digest=lambda: digest(out[: last["n"]]) if last.get("n") else 0,
                 note=f"{n} hypotheses; oracle: Sobel of the whole frame")


@register("detect", sizes=DETECT_SIZES)
def _detect(ctx: Ctx) -> Stage:
    from pyvehtrack.reference import shadow as rshadow
    from pyvehtrack.reference import verify as rverify
    nat, img, road, croad, ccfg, pcfg = _detect_setup(ctx)
    st = nat.ffi.new("vt_detect_state *")
    res = nat.ffi.new("vt_detect_result *")
    last = {}

    def c():
        last["boxes"] = nat.detect(st, ccfg, img, croad, res)[1]

    def reference():
        h = rshadow.find_hypotheses(img, road, pcfg.shadow, max_active=int(nat.lib.VT_MAX_SHADOW_ACTIVE),
                                    max_cand=int(nat.lib.VT_MAX_SHADOW_CAND),
                                    max_out=int(nat.lib.VT_MAX_HYPOTHESES))
        return rverify.verify(img, h.hypotheses, pcfg.verify, max_out=int(nat.lib.VT_MAX_BOXES))

    return Stage("detect", c, reference, pixels=img.size, calls=1,
                 digest=lambda: digest(last["boxes"]) if len(last.get("boxes", [])) else 0,
                 note="shadow + verify (vt_detect), fixed trapezoid road")


def _road_digest(road) -> int:
    """Fold of a vt_road_area: valid, rows, then x_left/x_right/lane_width over the rows
    (the driver folds the same values)."""
    if not road.valid:
        return 0
    ys = range(road.y_top, road.y_bottom + 1)
    vals = [road.valid, road.y_top, road.y_bottom] + [v for y in ys for v in
                                                      (road.x_left[y], road.x_right[y], road.lane_width[y])]
    return digest(np.array(vals, np.int64))


@register("lane", sizes=DETECT_SIZES)
def _lane(ctx: Ctx) -> Stage:
    """The lane stage from a fresh tracker (reset each run), road area out."""
    from pyvehtrack import _native as nat
    from pyvehtrack.lane import LaneDetector
    img = ctx.frame
    cfg = nat.lane_cfg_default()
    st = nat.lane_state_new()
    res = nat.ffi.new("vt_lane_result *")
    road = nat.ffi.new("vt_road_area *")
    ref = LaneDetector(engine="reference")

    def c():
        nat.lane_reset(st)
        nat.lane_detect(cfg, st, img, res, road)

    def reference():
        ref.reset()
        return ref.detect(img)

    return Stage("lane", c, reference, pixels=img.size, calls=2, digest=lambda: _road_digest(road),
                 note="fresh lane tracker each run")


@register("full_detect", sizes=DETECT_SIZES)
def _full_detect(ctx: Ctx) -> Stage:
    """Lanes -> road area -> shadow -> verify: the whole detection frame."""
    from pyvehtrack import _native as nat
    from pyvehtrack.detector import Detector
    img = ctx.frame
    lcfg = nat.lane_cfg_default()
    lst = nat.lane_state_new()
    lres = nat.ffi.new("vt_lane_result *")
    road = nat.ffi.new("vt_road_area *")
    dcfg = nat.detect_cfg_default()
    dst = nat.ffi.new("vt_detect_state *")
    dres = nat.ffi.new("vt_detect_result *")
    ref = Detector(engine="reference", road="lanes")  # as the C side: no fallback road
    last = {}

    def c():
        nat.lane_reset(lst)
        nat.lane_detect(lcfg, lst, img, lres, road)
        last["boxes"] = nat.detect(dst, dcfg, img, road, dres)[1]

    def reference():
        ref.reset()
        return ref.detect(img)

    return Stage("full_detect", c, reference, pixels=img.size, calls=3,
                 digest=lambda: digest(last["boxes"]) if len(last.get("boxes", [])) else 0,
                 note="lane + shadow + verify; road area from the lanes")


# ---------------------------------------------------------------- full-road detection (issue 8)
FULLROAD_MODEL = ROOT / "tests" / "data" / "window_svm_hog32.npz"


@register("fullroad_detect", sizes=((1280, 720),), driver=False)
def _fullroad_detect(ctx: Ctx) -> Stage:
    """Whole-road detection in C (vt_fulldet: pyramid, flat-road windows scored by the
    HOG 32x32 linear SVM of tests/data, classified shadow hypotheses, NMS) against the
    classic float way, as a Python user writes it: skimage.transform.pyramid_gaussian,
    skimage.feature.hog on every window of the same window set, a scikit-learn LinearSVC
    with the same weights (decision_function over all windows at once). The reference
    column is that classic pipeline, not the oracle (reference/fulldet.py is exact
    against C in tests/test_fulldet.py)."""
    from skimage.feature import hog
    from skimage.transform import pyramid_gaussian
    from sklearn.svm import LinearSVC
    from pyvehtrack import _native as nat
    from pyvehtrack.fullroad import FullRoadDetector, SOURCES
    from pyvehtrack.reference import windows as rw
    img = ctx.frame
    h, w = img.shape
    det = FullRoadDetector(str(FULLROAD_MODEL), sources=SOURCES)
    m = det.model
    cam = det.camera_for(h, w)
    wins = [wn for lv in range(det.det_cfg.win.levels)
            for wn in rw.windows_level(det.det_cfg.win, cam, rw.road_from_camera(cam, det.det_cfg.win, w, h), w, h, lv)]
    clf = LinearSVC()
    clf.coef_ = (m.w_q.astype(np.float64) / 2 ** m.w_shift)[None, :]
    clf.intercept_ = np.array([m.bias_q16 / 65536])
    clf.classes_ = np.array([-1, 1])
    last = {}

    def c():
        last["boxes"] = det.detect_gray(img)

    def reference():
        levels = list(pyramid_gaussian(img, max_layer=det.det_cfg.win.levels - 1, downscale=2))
        feats = [hog(levels[lv][y:y + s, x:x + s], orientations=9, pixels_per_cell=(8, 8),
                     cells_per_block=(2, 2), block_norm="L2-Hys") for lv, s, x, y in wins]
        return clf.decision_function(np.asarray(feats)) if feats else np.zeros(0)

    return Stage("fullroad_detect", c, reference, pixels=img.size, calls=1,
                 digest=lambda: digest(last["boxes"][:, :4]) if len(last.get("boxes", [])) else 0,
                 note=f"C: vt_fulldet (shadow + {len(wins)} windows, HOG 32x32 SVM); reference: classic "
                      "skimage hog + sklearn LinearSVC on the same windows")


@register("fullroad_mlp", sizes=((1280, 720),), driver=False)
def _fullroad_mlp(ctx: Ctx) -> Stage:
    """Whole-road detection in C with the shipped pyvehtrack/models/window_mlp_hog32.npz and the
    settings it carries (windows at two sizes per octave scored by the HOG 32x32 MLP, each
    window resampled to 32x32 and described alone; shadow hypotheses; NMS, merge, the HOG
    64x64 second stage) against the classic float way over the same windows:
    skimage.transform.pyramid_gaussian, cv2.resize (INTER_AREA) of each window to 32x32,
    skimage.feature.hog, the MLP's float weights in NumPy over all windows at once."""
    from skimage.feature import hog
    from skimage.transform import pyramid_gaussian
    from pyvehtrack.fullroad import FullRoadDetector
    from pyvehtrack.reference import windows as rw
    img = ctx.frame
    h, w = img.shape
    det = FullRoadDetector(str(ROOT / "pyvehtrack" / "models" / "window_mlp_hog32.npz"))
    m = det.model
    cam = det.camera_for(h, w)
    wins = [wn for lv in range(det.det_cfg.win.levels)
            for wn in rw.windows_level(det.det_cfg.win, cam, rw.road_from_camera(cam, det.det_cfg.win, w, h), w, h, lv)]
    w1 = m.w1_q.reshape(len(m.b1_q16), -1).astype(np.float64) / 2 ** m.w1_shift
    b1 = m.b1_q16 / 65536
    w2 = m.w2_q.astype(np.float64) / 2 ** m.w2_shift
    last = {}

    import cv2

    def c():
        last["boxes"] = det.detect_gray(img)

    def reference():
        levels = [(lv * 255).astype(np.uint8) for lv in
                  pyramid_gaussian(img, max_layer=det.det_cfg.win.levels - 1, downscale=2)]
        feats = [hog(cv2.resize(levels[lv][y:y + s, x:x + s], (m.win_w, m.win_h), interpolation=cv2.INTER_AREA),
                     orientations=9, pixels_per_cell=(8, 8), cells_per_block=(2, 2), block_norm="L2-Hys")
                 for lv, s, x, y in wins if y + s <= levels[lv].shape[0] and x + s <= levels[lv].shape[1]]
        if not feats:
            return np.zeros(0)
        return np.maximum(np.asarray(feats) @ w1.T + b1, 0.0) @ w2 + m.b2_q16 / 65536

    return Stage("fullroad_mlp", c, reference, pixels=img.size, calls=1,
                 digest=lambda: digest(last["boxes"][:, :4]) if len(last.get("boxes", [])) else 0,
                 note=f"C: vt_fulldet + vt_fulldet_verify, window_mlp_hog32.npz settings ({len(wins)} windows at "
                      "2 sizes per octave, HOG 32x32 MLP); reference: classic skimage hog + NumPy MLP on the "
                      "same windows")


@register("acf_detect", sizes=((1280, 720),), driver=False)
def _acf_detect(ctx: Ctx) -> Stage:
    """The ACF first stage of the opt-in pyvehtrack/models/acf_gray.npz (vt_acf_detect_n: its
    rear-view and flat windows on one quarter-octave pyramid, channels, trees with the soft
    cascade, one NMS) on the frame, with the pipeline's road camera for it; no reference
    column (the float oracle is per stage: tests/test_acf.py)."""
    from pyvehtrack import acf
    from pyvehtrack.pipeline import Pipeline
    img = ctx.frame
    path = ROOT / "pyvehtrack" / "models" / "acf_gray.npz"
    m = acf.AcfModel.load(path)
    cam = Pipeline("c", model=str(path), detect_every=1, track=False).road_camera.for_frame(*img.shape, None)
    last = {}

    def c():
        last["boxes"], last["st"] = acf.detect(m, img, cam.horizon_y, cam.hood_y, cam.fx,
                                               round(cam.height_m * 1000))

    def dig():
        b = last.get("boxes")
        return digest(np.stack([b["left"], b["top"], b["right"], b["bottom"]], 1)) if b is not None and len(b) else 0

    return Stage("acf_detect", c, None, pixels=img.size, calls=1, digest=dig,
                 note=f"C: vt_acf_detect_n, {1 + len(m.more)} windows (acf_gray.npz)")


def _detect_model(name: str, path: Path, img: np.ndarray, sources=None, what: str = "and its settings") -> Stage:
    """One detection frame with the model file at `path` and the settings it carries (or the
    given pipeline `sources`), as `pyvehtrack detect --model` runs it on the C engine: one
    vt_pipeline_step."""
    from pyvehtrack.pipeline import Pipeline
    kw = {} if sources is None else {"sources": sources}
    pipe = Pipeline("c", model=str(path), detect_every=1, track=False, **kw)
    last = {}

    def c():
        last["boxes"] = pipe.step_gray(img).box_array

    return Stage(name, c, None, pixels=img.size, calls=1,
                 digest=lambda: digest(np.asarray(last["boxes"])[:, :4]) if len(last.get("boxes", [])) else 0,
                 note=f"C: vt_pipeline_step, detection frame, {path.name} {what}")


@register("detect_default", sizes=((1280, 720),), driver=False)
def _detect_default(ctx: Ctx) -> Stage:
    """One detection frame as `pyvehtrack detect` runs it without --model on the C engine
    (fullroad.default_model_path: cnn_gray_l0_big.npz and its settings since 2026-11-29): the
    lane stage, the ego-lane detector, the CNN on its levels, the second stage on the ego
    boxes, one vt_pipeline_step; no reference column (the CNN-alone stages have it)."""
    from pyvehtrack.fullroad import default_model_path
    return _detect_model("detect_default", default_model_path("c"), ctx.frame)


@register("detect_acf_rescore", sizes=((1280, 720),), driver=False)
def _detect_acf_rescore(ctx: Ctx) -> Stage:
    """One detection frame with acf_gray_rescore.npz (the C engine's default before
    2026-11-29): the lane stage, the ego-lane detector, the ACF windows, the second stage,
    the box regressor and the rescorer; no reference column (no float twin of the ACF stage)."""
    from pyvehtrack.fullroad import DEFAULT_RESCORE_MODEL
    return _detect_model("detect_acf_rescore", DEFAULT_RESCORE_MODEL, ctx.frame)


def _cnn_alone(name: str, fname: str, img: np.ndarray, **cfg_changes) -> Stage:
    """The CNN detector of pyvehtrack/models/<fname> alone (vt_cnn_detect_frame at the file's
    cnn_cfg, with cfg_changes: the pyramid, the network on each level, the peak decoder, one
    NMS); the reference column is its bit-exact NumPy twin (pyvehtrack.reference.cnn.detect_frame)."""
    import dataclasses

    from pyvehtrack import cnn
    from pyvehtrack.reference import cnn as rcnn
    m = cnn.CnnModel.load(ROOT / "pyvehtrack" / "models" / fname)
    if cfg_changes:
        m.cfg = dataclasses.replace(m.cfg, **cfg_changes)
    last = {}

    def c():
        last["boxes"] = cnn.detect_frame(m, img, m.cfg)[0]

    def reference():
        return rcnn.detect_frame(m, img, m.cfg)

    return Stage(name, c, reference, pixels=img.size, calls=1,
                 digest=lambda: digest(last["boxes"][:, :4]) if len(last.get("boxes", [])) else 0,
                 note=f"C: vt_cnn_detect_frame ({fname}); reference: the NumPy integer twin")


def _cnn_frame(name: str, fname: str, img: np.ndarray) -> Stage:
    """One detection frame as `pyvehtrack detect --model pyvehtrack/models/<fname>` runs it on
    the C engine: the lane stage, the ego-lane detector, the CNN over its levels, the NMS
    against the ego boxes, one vt_pipeline_step; no reference column (the CNN-alone stage has
    it)."""
    return _detect_model(name, ROOT / "pyvehtrack" / "models" / fname, img, sources=("ego", "classifier"),
                         what="with the ego-lane detector")


@register("cnn_detect", sizes=((1280, 720),), driver=False)
def _cnn_detect(ctx: Ctx) -> Stage:
    """cnn_gray.npz alone (_cnn_alone)."""
    return _cnn_alone("cnn_detect", "cnn_gray.npz", ctx.frame)


@register("cnn_l0_detect", sizes=((1280, 720),), driver=False)
def _cnn_l0_detect(ctx: Ctx) -> Stage:
    """cnn_gray_l0.npz alone (_cnn_alone): levels 1-4 and level 0's row band."""
    return _cnn_alone("cnn_l0_detect", "cnn_gray_l0.npz", ctx.frame)


@register("cnn_l0big_detect", sizes=((1280, 720),), driver=False)
def _cnn_l0big_detect(ctx: Ctx) -> Stage:
    """cnn_gray_l0_big.npz alone (_cnn_alone): the band network with 64-channel layers."""
    return _cnn_alone("cnn_l0big_detect", "cnn_gray_l0_big.npz", ctx.frame)


@register("cnn_l0big_noup_detect", sizes=((1280, 720),), driver=False)
def _cnn_l0big_noup_detect(ctx: Ctx) -> Stage:
    """cnn_gray_l0_big.npz alone without its upsampled band (up_*_permille 0): the band's cost
    is cnn_l0big_detect's time minus this one's, in the same run."""
    return _cnn_alone("cnn_l0big_noup_detect", "cnn_gray_l0_big.npz", ctx.frame, up_top_permille=0,
                      up_bottom_permille=0, up_left_permille=0, up_right_permille=0)


# A CNN file outside pyvehtrack/models (a training run's cnn.npz), benched beside the shipped
# ones: `--cnn-file PATH` (or VT_BENCH_CNN_FILE=PATH). An environment variable, not only a flag,
# because the callgrind column re-runs this script in a subprocess, which must register it too.
CNN_FILE_ENV = "VT_BENCH_CNN_FILE"


def _cnn_file_detect(ctx: Ctx) -> Stage:
    """The file named by VT_BENCH_CNN_FILE alone (_cnn_alone), at its own cnn_cfg."""
    return _cnn_alone("cnn_file_detect", os.path.abspath(os.environ[CNN_FILE_ENV]), ctx.frame)


def _register_cnn_file() -> None:
    if not any(s.name == "cnn_file_detect" for s in REGISTRY):
        register("cnn_file_detect", sizes=((1280, 720),), driver=False)(_cnn_file_detect)


if os.environ.get(CNN_FILE_ENV):
    _register_cnn_file()


@register("detect_cnn", sizes=((1280, 720),), driver=False)
def _detect_cnn(ctx: Ctx) -> Stage:
    """One detection frame with cnn_gray.npz (_cnn_frame)."""
    return _cnn_frame("detect_cnn", "cnn_gray.npz", ctx.frame)


@register("detect_cnn_l0", sizes=((1280, 720),), driver=False)
def _detect_cnn_l0(ctx: Ctx) -> Stage:
    """One detection frame with cnn_gray_l0.npz (_cnn_frame)."""
    return _cnn_frame("detect_cnn_l0", "cnn_gray_l0.npz", ctx.frame)


@register("detect_cnn_l0big", sizes=((1280, 720),), driver=False)
def _detect_cnn_l0big(ctx: Ctx) -> Stage:
    """One detection frame with cnn_gray_l0_big.npz (_cnn_frame)."""
    return _cnn_frame("detect_cnn_l0big", "cnn_gray_l0_big.npz", ctx.frame)


@register("fullroad_mlp_wide", sizes=((1280, 720),), driver=False)
def _fullroad_mlp_wide(ctx: Ctx) -> Stage:
    """Whole-road detection in C with the opt-in tests/data/window_mlp_hog32_wide.npz and
    the settings it carries (HOG 32 MLP windows, merge, re-ranking before NMS, second
    stage, the wide pass with its aspect choice); no reference column (the oracle is exact
    against C in tests/test_fulldet_wide*.py and tests/test_fulldet_rerank.py)."""
    from pyvehtrack.fullroad import FullRoadDetector
    img = ctx.frame
    det = FullRoadDetector(str(ROOT / "tests" / "data" / "window_mlp_hog32_wide.npz"))
    last = {}

    def c():
        last["boxes"] = det.detect_gray(img)

    return Stage("fullroad_mlp_wide", c, None, pixels=img.size, calls=1,
                 digest=lambda: digest(last["boxes"][:, :4]) if len(last.get("boxes", [])) else 0,
                 note="C: vt_fulldet + vt_fulldet_rerank + vt_fulldet_verify + vt_fulldet_wide "
                      "(window_mlp_hog32_wide.npz settings)")


# ---------------------------------------------------------------- the tracker (issue 4)
@register("track_frame")
def _track_frame(ctx: Ctx) -> Stage:
    """One tracked frame (no detection) with the two cars of the bench frame, from the
    same primed state every run (the C side restores a 55 KB state copy first)."""
    return _tracked(ctx, confirmed=False)


@register("track_frame_confirmed")
def _track_frame_confirmed(ctx: Ctx) -> Stage:
    """track_frame primed with confirm_hits detection frames: confirmed tracks (the usual
    tracked frame; a tentative track is also held by the NCC template)."""
    return _tracked(ctx, confirmed=True)


def _tracked(ctx: Ctx, confirmed: bool) -> Stage:
    import copy

    from pyvehtrack import _native
    from pyvehtrack.reference import tracker as rtrk
    from pyvehtrack.tracker import cfg_to_c
    img = ctx.frame
    h, w = img.shape
    dets = np.array([[370 * w // 640, 270 * h // 480, 456 * w // 640, 328 * h // 480],
                     [528 * w // 640, 268 * h // 480, 639 * w // 640, 336 * h // 480]])
    ccfg = cfg_to_c(rtrk.TrackerCfg())
    primes = int(ccfg.confirm_hits) if confirmed else 1
    tr = _native.tracker_new()
    for _ in range(primes):
        _native.tracker_step(tr, ccfg, img, True, dets)
    saved = _native.ffi.new("vt_tracker *")
    _native.ffi.memmove(saved, tr, _native.ffi.sizeof("vt_tracker"))
    ref = rtrk.Tracker(rtrk.TrackerCfg(), max_tracks=int(_native.lib.VT_MAX_TRACKS))
    for _ in range(primes):
        ref.step(img, True, dets)
    last = {}

    def c():
        _native.ffi.memmove(tr, saved, _native.ffi.sizeof("vt_tracker"))
        last["out"] = _native.tracker_step(tr, ccfg, img, False)

    def reference():
        return copy.deepcopy(ref).step(img, False)

    def dig():
        o = last["out"]
        return digest(np.stack([o["id"], o["left"], o["top"], o["right"], o["bottom"]], 1)) if len(o) else 0

    if confirmed:
        return Stage("track_frame_confirmed", c, reference, pixels=img.size, digest=dig, calls=1,
                     note=f"2 confirmed tracks ({primes} detection frames first); oracle copies its tracker each run")
    return Stage("track_frame", c, reference, pixels=img.size, digest=dig, calls=1,
                 note="2 tentative tracks (one detection frame first); oracle copies its tracker each run")


# ---------------------------------------------------------------- motion (issue 9)
FLOW_SHIFT = 4   # px: the previous frame is the bench frame moved 4 px left (content moves right)


def _flow_prev(img: np.ndarray) -> np.ndarray:
    """prev[y, x] = img[y, min(x + 4, w - 1)], as bench/callgrind_main.c builds it."""
    w = img.shape[1]
    return np.ascontiguousarray(img[:, np.minimum(np.arange(w) + FLOW_SHIFT, w - 1)])


@register("flow")
def _flow(ctx: Ctx) -> Stage:
    """One flow frame (vt_flow_step) on both lateral areas: the state holds the previous frame
    (restored each run by resetting two ints), the frame's whole content moved 4 px inward on the
    left, so every textured left cell is searched, checked backward and blobbed (the worst case)."""
    from types import SimpleNamespace

    from pyvehtrack import _native
    from pyvehtrack.flow import CFG_FIELDS, make_cfg
    from pyvehtrack.reference import flow as rflow
    img = ctx.frame
    prev = _flow_prev(img)
    cfg = make_cfg(sides="both")
    st = _native.flow_new()
    _native.flow_step(st, cfg, prev)
    pi = int(st.prev_index)
    ns = SimpleNamespace(**{f: int(getattr(cfg, f)) for f in CFG_FIELDS})
    last = {}

    def c():
        st.prev_index = pi
        st.n_blobs[0] = st.n_blobs[1] = 0
        last["hyps"] = _native.flow_step(st, cfg, img)[1]

    def reference():
        o = rflow.FlowOracle(ns)
        o.step(prev)
        return o.step(img)

    def dig():
        hy = last["hyps"]
        return digest(np.stack([hy["left"], hy["top"], hy["right"], hy["bottom"], hy["cells"]], 1)) if len(hy) else 0

    return Stage("flow", c, reference, pixels=img.size, digest=dig, calls=1,
                 note="both lateral areas, level 1 (level image over the areas and search margins only), "
                      "worst case (all left cells move)")


def _model_setup(ctx: Ctx):
    """The left car of the bench frame: ROI around it, road through its bottom (86 px wide at row
    328 of 640x480, horizon near row 240), scaled to the frame as the tracker bench does."""
    from pyvehtrack import _native
    from pyvehtrack.vehicle_model import make_cfg
    h, w = ctx.frame.shape
    car = (370 * w // 640, 270 * h // 480, 456 * w // 640, 328 * h // 480)
    cw, ch = car[2] - car[0] + 1, car[3] - car[1] + 1
    roi = (car[0] - cw // 2, car[1] - (4 * ch) // 10, car[2] + cw // 2, car[3] + (3 * ch) // 10)
    cfg = make_cfg(road=(288 * h // 480, 47 * w // 640, 328 * h // 480, 86 * w // 640))
    if w < 160:  # the quick bench's tiny frame: a small GA, so the oracle takes well under a second
        for m, (pops, gens) in enumerate((((16, 8, 8), (4, 1, 1)), ((8, 8, 8), (2, 1, 1)))):
            for lv in range(3):
                cfg.pop[m][lv], cfg.gens[m][lv] = pops[lv], gens[lv]
    pred = ((car[0] + car[2] + 1) // 2, car[3], cw, ch, 40, 20, 10)
    return _native, cfg, roi, pred


def _model_stage(ctx: Ctx, name: str, tracking: bool) -> Stage:
    from pyvehtrack.vehicle_model import oracle_cfg, oracle_search
    from pyvehtrack.reference import vehicle_model as rvm
    nat, cfg, roi, pred = _model_setup(ctx)
    img = ctx.frame
    sigma = (3, 3, 3, 3, 8, 8, 5)
    s = nat.model_search(roi, roi[1], roi[3], tracking, pred if tracking else None, sigma if tracking else None)
    ws = nat.model_ws_new()
    ocfg = oracle_cfg(cfg)
    osr = oracle_search(roi, roi[1], roi[3], pred if tracking else None, sigma if tracking else None)
    last = {}

    def c():
        last["r"] = nat.model_fit(img, cfg, s, ws)

    def dig():
        r = last["r"]
        return digest(np.array(list(r["best"]) + [r["fitness"], r["evaluations"]], np.int64))

    mode = 1 if tracking else 0
    evals = sum(int(cfg.pop[mode][l]) * (int(cfg.gens[mode][l]) + 1) for l in range(int(cfg.levels)))
    return Stage(name, c, lambda: rvm.fit(img, ocfg, osr), pixels=img.size, digest=dig, calls=1,
                 note=f"GA {'tracking' if tracking else 'detection'}, "
                      f"{'Table 1' if img.shape[1] >= 160 else 'small GA (quick frame)'}, ROI "
                      f"{roi[2] - roi[0] + 1}x{roi[3] - roi[1] + 1}, <= {evals} evaluations (pop x (gens + 1))")


@register("model_detect")
def _model_detect(ctx: Ctx) -> Stage:
    return _model_stage(ctx, "model_detect", False)


@register("model_track")
def _model_track(ctx: Ctx) -> Stage:
    return _model_stage(ctx, "model_track", True)


@register("track_frame_edges", driver=False)
def _track_frame_edges(ctx: Ctx) -> Stage:
    """track_frame with the edge-curve measurement (GIST paper sec. III.B) in place of
    the ROI search: edge map + chamfer transform of each track's crop, 5 scales x 17 x 17
    displacements, then a fresh template."""
    return _edge_stage(ctx, "track_frame_edges", "MEAS_EDGE_CURVES",
                       "2 tracks, edge-curve measurement; oracle copies its tracker each run")


@register("track_frame_roi_edges", driver=False)
def _track_frame_roi_edges(ctx: Ctx) -> Stage:
    """track_frame with measurement roi+edges: the ROI search, and the edge curves where it
    fails on a track it measured before; on this frame the searches of the birth frame's
    tentative tracks run, and every measured track refreshes its curves."""
    return _edge_stage(ctx, "track_frame_roi_edges", "MEAS_ROI_EDGES",
                       "2 tracks, roi+edges; oracle copies its tracker each run")


def _edge_stage(ctx: Ctx, name: str, meas: str, note: str) -> Stage:
    import copy

    from pyvehtrack import _native
    from pyvehtrack.reference import tracker as rtrk
    from pyvehtrack.tracker import cfg_to_c
    img = ctx.frame
    h, w = img.shape
    dets = np.array([[370 * w // 640, 270 * h // 480, 456 * w // 640, 328 * h // 480],
                     [528 * w // 640, 268 * h // 480, 639 * w // 640, 336 * h // 480]])
    pcfg = rtrk.TrackerCfg(measurement=getattr(rtrk, meas))
    ccfg = cfg_to_c(pcfg)
    tr = _native.tracker_new()
    ws = _native.edge_ws_new()          # caller-owned: the tracker keeps only a pointer
    _native.tracker_set_edge_ws(tr, ws)
    _native.tracker_step(tr, ccfg, img, True, dets)
    saved = _native.ffi.new("vt_tracker *")
    _native.ffi.memmove(saved, tr, _native.ffi.sizeof("vt_tracker"))
    lib = _native.lib
    ref = rtrk.Tracker(pcfg, max_tracks=int(lib.VT_MAX_TRACKS), max_edge_points=int(lib.VT_EDGE_MAX_POINTS),
                       max_edge_pixels=int(lib.VT_EDGE_MAX_PIXELS),
                       coord_lim=4 * max(int(lib.VT_MAX_WIDTH), int(lib.VT_MAX_HEIGHT)))
    ref.step(img, True, dets)
    last = {}

    keep = (ws, saved)   # the tracker (and its saved copy) point at ws: keep it alive

    def c():
        _native.ffi.memmove(tr, saved, _native.ffi.sizeof("vt_tracker"))  # the ws pointer too
        last["out"] = _native.tracker_step(tr, ccfg, img, False)
        last["keep"] = keep

    def reference():
        return copy.deepcopy(ref).step(img, False)

    return Stage(name, c, reference, pixels=img.size, calls=1, note=note)


# ---------------------------------------------------------------- the whole system (issue 10)
@register("pipeline", sizes=DETECT_SIZES)
def _pipeline(ctx: Ctx) -> Stage:
    """One detection frame of a fresh pipeline through its one call (vt_pipeline_init +
    vt_pipeline_step): lanes -> road -> shadow -> verify -> tracker."""
    from pyvehtrack import _native as nat
    from pyvehtrack import config
    from pyvehtrack.reference import pipeline as rpipe
    img = ctx.frame
    cfg = config.PipelineConfig()
    ccfg = config.to_c(cfg)
    p = nat.ffi.new("vt_pipeline *")
    out = nat.ffi.new("vt_frame_out *")
    rcfg, caps = config.to_reference(cfg), config.reference_capacities()
    last = {}

    def c():
        nat.check("vt_pipeline_init", nat.lib.vt_pipeline_init(p, ccfg, nat.ffi.NULL, nat.ffi.NULL))
        nat.pipeline_step(p, img, out)
        last["v"] = [getattr(out.boxes[i].box, k) for i in range(out.n_boxes)
                     for k in ("left", "top", "right", "bottom")] + \
                    [getattr(out.tracks[i], k) if k == "id" else getattr(out.tracks[i].box, k)
                     for i in range(out.n_tracks) for k in ("id", "left", "top", "right", "bottom")]

    def reference():
        return rpipe.Pipeline(rcfg, caps).step(img)

    return Stage("pipeline", c, reference, pixels=img.size, calls=2,
                 digest=lambda: digest(last["v"]) if last.get("v") else 0,
                 note="fresh pipeline, one detection frame (init included)")


# ---------------------------------------------------------------- the pipeline with flow / model (issues 9/10)
FLOW_BOOK = ("have_prev", "prev_index", "w", "h", "lw", "lh", "level", "next_id", "gw", "gh", "x0", "y0",
             "seeds", "n_blobs", "blob_box", "blob_age", "n_rect")


def _pipe_digest(out) -> list:
    """The boxes handed to the tracker, then the tracks' ids and boxes (bench_digest_pipe)."""
    return [getattr(out.boxes[i].box, k) for i in range(out.n_boxes) for k in ("left", "top", "right", "bottom")] + \
        [getattr(out.tracks[i], k) if k == "id" else getattr(out.tracks[i].box, k)
         for i in range(out.n_tracks) for k in ("id", "left", "top", "right", "bottom")]


def _pipe_primed(ctx: Ctx, source: str):
    """A pipeline (C and oracle) with shadow + `source`, primed as bench/callgrind_main.c's
    bench_setup_pipeline_SOURCE: flow: one step on the flow bench's previous frame (the frame
    moved 4 px; a detection frame, the shadow source starts the tracks); model: one step on
    the frame (a detection frame), three with its boxes as the caller's detections (the
    tracks are confirmed) and one on a flat grey frame (their ROI search fails: they coast,
    so the measured step refits them, at most model_fits = 2). Returns (C run, oracle run,
    digest)."""
    import copy

    from pyvehtrack import _native as nat
    from pyvehtrack.pipeline import Pipeline
    img = ctx.frame
    ffi, lib = nat.ffi, nat.lib
    kw = dict(sources=("shadow", source))
    if source == "flow":
        kw["flow"] = {"sides": 3}
    cp, rp = Pipeline("c", **kw), Pipeline("reference", **kw)
    if source == "flow":
        cp.step_gray(_flow_prev(img))
        rp.step_gray(_flow_prev(img))
    else:
        # frame 0 detects; its boxes given again on frames 1-3 confirm the tracks whatever
        # their ROI search does; the flat frame 4 makes them coast
        boxes = np.array([b.box for b in cp.step_gray(img).boxes], np.int32).reshape(-1, 4)
        rp.step_gray(img)
        for _ in range(3):
            cp.step_gray(img, detections=boxes)
            rp.step_gray(img, detections=boxes)
        cp.step_gray(np.full_like(img, 128))
        rp.step_gray(np.full_like(img, 128))
    p, out = cp._p, ffi.new("vt_frame_out *")
    fv = nat.view(img, "frame")    # img is ctx.frame: alive for the whole bench
    saved = ffi.new("vt_pipeline *")
    ffi.memmove(saved, p, ffi.sizeof("vt_pipeline"))
    book = []
    if source == "flow":
        st = cp._flow_st
        for f in FLOW_BOOK:
            a = ffi.addressof(st, f)
            keep = ffi.new(ffi.typeof(a))
            ffi.memmove(keep, a, ffi.sizeof(ffi.typeof(a).item))
            book.append((a, keep, ffi.sizeof(ffi.typeof(a).item)))
    last = {"keep": cp}    # cp owns the attached flow state / model workspace p points to

    def c():
        ffi.memmove(p, saved, ffi.sizeof("vt_pipeline"))
        for a, keep, n in book:
            ffi.memmove(a, keep, n)
        nat.check("vt_pipeline_step", lib.vt_pipeline_step(p, fv, out))
        last["v"] = _pipe_digest(out)

    def reference():
        return copy.deepcopy(rp._ref).step(img)

    return c, reference, lambda: digest(last["v"]) if last.get("v") else 0


@register("pipeline_flow", sizes=DETECT_SIZES)
def _pipeline_flow(ctx: Ctx) -> Stage:
    """One tracking step of a primed pipeline with the flow source on (shadow + flow, both
    lateral areas, level 1): the state restored first (a copy of vt_pipeline and the flow
    state's bookkeeping; its level image is only read), then vt_pipeline_step."""
    c, ref, dig = _pipe_primed(ctx, "flow")
    return Stage("pipeline_flow", c, ref, pixels=ctx.frame.size, calls=1, digest=dig,
                 note="primed pipeline, one tracking frame with flow (state copy included); "
                      "oracle deep-copies its pipeline each run")


@register("pipeline_model", sizes=DETECT_SIZES)
def _pipeline_model(ctx: Ctx) -> Stage:
    """One tracking step of a primed pipeline with the vehicle model on (shadow + model): the
    previous step left the track COASTING, so the GA refits it (only where tracking asks)."""
    c, ref, dig = _pipe_primed(ctx, "model")
    return Stage("pipeline_model", c, ref, pixels=ctx.frame.size, calls=1, digest=dig,
                 note="primed pipeline, one tracking frame, the GA refits the coasting track "
                      "(state copy included); oracle deep-copies its pipeline each run")


def ram_bill() -> list[dict]:
    """sizeof(vt_pipeline) and its parts in this build (the cffi extension's)."""
    from pyvehtrack._native import ffi, lib
    rows = [("vt_pipeline (the whole state)", "vt_pipeline"), ("  vt_lane_state", "vt_lane_state"),
            ("  vt_tracker", "vt_tracker"), ("  vt_detect_state", "vt_detect_state"),
            ("  vt_detect_result", "vt_detect_result"), ("  vt_pipeline_cfg", "vt_pipeline_cfg"),
            ("vt_frame_out (one frame's output)", "vt_frame_out"), ("  vt_road_area", "vt_road_area"),
            ("  vt_lane_result", "vt_lane_result")]
    caps = {k: int(getattr(lib, k)) for k in ("VT_MAX_WIDTH", "VT_MAX_HEIGHT", "VT_MAX_TRACKS")}
    return [{"what": w, "bytes": ffi.sizeof(t), **caps} for w, t in rows]


# ---------------------------------------------------------------- frames
def load_frame(w: int, h: int, quick: bool) -> tuple[np.ndarray, str]:
    """The gray bench frame of size w x h (quick: an eighth of each side, at least
    64x48), and where it came from."""
    import cv2
    if quick:
        w, h = max(64, w // 8), max(48, h // 8)
    own = HERE / "data" / f"road_{w}x{h}.png"
    src = own if own.exists() else BASE_FRAME
    img = cv2.imread(str(src), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise SystemExit(f"bench: cannot read {src}")
    if img.shape != (h, w):
        img = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
        return np.ascontiguousarray(img), f"{src.relative_to(ROOT)} resized to {w}x{h}"
    return np.ascontiguousarray(img), str(src.relative_to(ROOT))


def write_pgm(path: Path, img: np.ndarray) -> None:
    h, w = img.shape
    path.write_bytes(b"P5\n%d %d\n255\n" % (w, h) + img.tobytes())


# ---------------------------------------------------------------- timing
def time_us(fn: Callable[[], Any], min_reps: int, max_reps: int, budget_s: float) -> tuple[float, int]:
    """Median wall time of one call in µs, after one warm-up call. Repeats until
    max_reps, or min_reps once budget_s has been spent. gc is off while timing."""
    fn()
    times: list[int] = []
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        start = time.perf_counter()
        while len(times) < max_reps:
            t0 = time.perf_counter_ns()
            fn()
            times.append(time.perf_counter_ns() - t0)
            if len(times) >= min_reps and time.perf_counter() - start > budget_s:
                break
    finally:
        if was_enabled:
            gc.enable()
    return statistics.median(times) / 1000.0, len(times)


def cffi_overhead_us(quick: bool) -> dict[str, float]:
    """What a tiny op pays for the binding, per pyvehtrack._native call, at the two
    ends: sincos_q14 (no image views, two outputs) and sad_u8 of two 1x1 blocks
    (two view structs built from NumPy arrays, one output)."""
    from pyvehtrack import _native
    a = np.zeros((1, 1), np.uint8)
    b = np.ones((1, 1), np.uint8)
    n = 100 if quick else 2000
    calls = {"sincos_q14": lambda: _native.sincos_q14(0), "sad_u8_1x1": lambda: _native.sad_u8(a, b)}
    out = {}
    for name, f in calls.items():
        def batch(f=f):
            for _ in range(n):
                f()
        us, _ = time_us(batch, 1 if quick else 5, 1 if quick else 15, 0.5)
        out[name] = us / n
    return out


# ---------------------------------------------------------------- callgrind
def tool_env() -> dict[str, str]:
    """The environment for the tools bench runs (driver, valgrind, cc, git): without
    the sanitizer runtime that `make check SAN=1` preloads for the extension, which
    valgrind and an uninstrumented driver cannot run under."""
    return {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}


def driver_stages(driver: Path) -> set[str]:
    out = subprocess.run([str(driver), "--list"], check=True, capture_output=True, text=True,
                         env=tool_env()).stdout
    return {line.split()[0] for line in out.splitlines() if line.strip()}


def run_callgrind(valgrind: str, driver: Path, pgm: Path, stages: list[Stage],
                  out_file: Path) -> dict[str, dict]:
    """One callgrind run of the driver over `stages`: Ir per run, status, digest."""
    args = [f"{s.name}:{s.units}" for s in stages]
    cmd = [valgrind, "--tool=callgrind", "-q", f"--callgrind-out-file={out_file}",
           "--dump-instr=no", str(driver), str(pgm), *args]
    res = subprocess.run(cmd, capture_output=True, text=True, env=tool_env())
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}):\n{res.stderr}")
    printed = {}
    for line in res.stdout.splitlines():
        tok = line.split()
        if len(tok) == 8 and tok[0] == "stage":
            printed[tok[1]] = {"status": int(tok[5]), "digest": int(tok[7], 16)}
    prof = callgrind.parse(out_file)
    found = {}
    for s in stages:
        fn = f"bench_run_{s.name}"
        calls = prof.calls_in.get(fn, 0)
        found[s.name] = {"ir": prof.inclusive(fn) // max(calls, 1), "calls": calls,
                         **printed.get(s.name, {"status": None, "digest": None})}
    return found


def run_callgrind_python(valgrind: str, name: str, size: tuple[int, int], quick: bool,
                         out_file: Path) -> dict:
    """Instructions of one C run of a stage bench/callgrind_main.c has no entry for: this
    script under callgrind with collection on only inside cffi's wrappers of the library's
    functions (--toggle-collect=_cffi_f_vt_*: the C and what it calls, plus the wrapper's
    argument unpacking, not Python or NumPy), the stage built, then its C callable run once
    (--cg-one). The wrappers never nest, so each call is counted whole; a pattern on the
    library's own names (vt_*) toggled collection off again inside every nested vt_ call
    and undercounted stages such as a whole vt_pipeline_step. Setup calls during the
    stage's construction (model checks, config defaults) are counted too: a few thousand
    instructions."""
    cmd = [valgrind, "--tool=callgrind", "-q", f"--callgrind-out-file={out_file}", "--dump-instr=no",
           "--toggle-collect=_cffi_f_vt_*", sys.executable, str(Path(__file__).resolve()), "--cg-one", name,
           "--cg-size", f"{size[0]}x{size[1]}"] + (["--quick"] if quick else [])
    res = subprocess.run(cmd, capture_output=True, text=True, env=tool_env())
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}):\n{res.stderr[-2000:]}")
    return {"ir": callgrind.parse(out_file).total(), "calls": 1, "status": None, "digest": None,
            "via": "python"}


def _cg_one(name: str, size: str, quick: bool) -> int:
    """--cg-one: build one stage at one frame size and run its C callable once."""
    fw, fh = (int(v) for v in size.split("x"))
    spec = next(s for s in REGISTRY if s.name == name)
    frame, _ = load_frame(fw, fh, quick=quick)
    spec.make(Ctx(frame=frame, quick=quick)).c()
    return 0


# ---------------------------------------------------------------- machine
def _first_line(cmd: list[str]) -> str:
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=20, env=tool_env())
        return (out.stdout or out.stderr).strip().splitlines()[0]
    except (OSError, IndexError, subprocess.SubprocessError):
        return "unknown"


def _cnn_path() -> str:
    """The CNN stages' inner loops in the timed extension; callgrind's may differ: valgrind
    3.19 reports neither AVX-VNNI nor AVX-512 to the program, so there the CNN counts the
    AVX2 loops' instructions (the same bits)."""
    from pyvehtrack import cnn  # noqa: PLC0415
    try:
        path = cnn.simd_path()
    except AttributeError:   # an extension built before vt_cnn_simd_path (2026-12-01)
        return "not reported by this extension"
    return path + ("; under callgrind avx2 (valgrind reports neither VNNI kind)" if "vnni" in path else "")


def machine_info(cc: str, cflags: str, valgrind: str | None) -> dict[str, str]:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import cffi
    import cv2
    commit = _first_line(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"])
    try:
        if subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                          capture_output=True, text=True, timeout=20, env=tool_env()).stdout.strip():
            commit += " + uncommitted changes"
    except (OSError, subprocess.SubprocessError):
        pass
    info = {
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "cpu": f"{cpu} ({os.cpu_count()} logical CPUs)",
        "load average (1/5/15 min, at the end)": " ".join(f"{x:.2f}" for x in os.getloadavg()),
        "compiler": f"{_first_line(cc.split() + ['--version'])} ({cc})",
        "cflags": cflags,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "opencv": cv2.__version__,
        "cffi": cffi.__version__,
        "valgrind": _first_line([valgrind, "--version"]) if valgrind else "not found",
        "extension": os.environ.get("PYVEHTRACK_FFI", "installed pyvehtrack._vtffi"),
        "commit": commit,
        "cnn inner loops (vt_cnn_simd_path)": _cnn_path(),
    }
    return info


def struct_sizes() -> list[dict]:
    """sizeof/alignof of every struct and union cffi knows (typedef'd or tagged),
    read from the compiled extension, so new modules show up by themselves."""
    from pyvehtrack import ffi
    typedefs, structs, unions = ffi.list_types()
    rows = []
    for name in typedefs:
        t = ffi.typeof(name)
        if t.kind in ("struct", "union"):
            rows.append({"type": name, "sizeof": ffi.sizeof(t), "alignof": ffi.alignof(t)})
    for kind, names in (("struct", structs), ("union", unions)):
        for n in names:
            if not n.startswith("$"):
                t = ffi.typeof(f"{kind} {n}")
                try:
                    ffi.sizeof(t)
                except ffi.error:  # opaque (a stage's slot not built in: struct vt_svm_model)
                    continue
                rows.append({"type": f"{kind} {n}", "sizeof": ffi.sizeof(t), "alignof": ffi.alignof(t)})
    return rows


# ---------------------------------------------------------------- report
def _fmt(v, digits: int = 1) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        if v >= 100:
            return f"{v:,.0f}"
        return f"{v:.{digits}f}"
    return f"{v:,}"


def render(result: dict) -> str:
    m = result["machine"]
    ov = result["cffi_overhead_us"]
    lines = ["# make bench", ""]
    lines += [f"- {k}: {v}" for k, v in m.items()]
    lines += [f"- frames: {', '.join(result['frames'])}",
              f"- command: `{result['command']}`", ""]
    lines += ["| stage | size | work per run | reps C/ref | C µs | oracle µs | oracle/C | "
              "C Ir per run | Ir/px | Ir/item | driver = cffi | note |",
              "|---|---|---|---|---:|---:|---:|---:|---:|---:|---|---|"]
    for r in result["rows"]:
        unit = r["unit"]
        if r["units"] != 1:
            unit += "es" if unit.endswith(("s", "x")) else "s"
        work = f"{r['units']:,} {unit}"
        match = {True: "yes", False: "**NO**", None: "—"}[r["digest_match"]]
        lines.append(
            f"| {r['stage']} | {r['size']} | {work} | {r['reps_c']}/{r['reps_ref'] or '—'} | "
            f"{_fmt(r['c_us'])} | {_fmt(r['ref_us'])} | {_fmt(r['ratio'])} | {_fmt(r['ir'])} | "
            f"{_fmt(r['ir_per_px'], 2)} | {_fmt(r['ir_per_item'])} | {match} | {r['note']} |")
    lines += ["",
              f"C µs: one run through `pyvehtrack._native` (cffi), outputs preallocated, so it includes "
              f"the binding: {ov['sincos_q14']:.2f} µs per call without image views (sincos_q14) "
              f"to {ov['sad_u8_1x1']:.2f} µs with two (sad_u8 of 1x1 blocks) on this machine. "
              f"Where a stage makes one call per item, the note estimates the binding's share of "
              f"its C column (its instructions at the Ir/µs the C reaches on the one-call frame "
              f"stages, against the time measured); where that share is large the callgrind "
              f"columns, which count the C alone, are the figure to read. Medians over the "
              f"reps shown. Ir: instructions counted by callgrind on bench/callgrind_main.c built "
              f"with the flags above, doing the same run on the same frame (`driver = cffi`: its "
              f"output digest equals the cffi run's).", ""]
    lines += ["## sizeof of the public structs (from the cffi extension)", "",
              "| type | sizeof | alignof |", "|---|---:|---:|"]
    lines += [f"| {s['type']} | {s['sizeof']:,} | {s['alignof']} |" for s in result["sizeof"]]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help="tiny frames, few items, one repeat (for the test suite)")
    ap.add_argument("--driver", type=Path, help="bench/callgrind_main.c built; omit to skip callgrind")
    ap.add_argument("--valgrind", default=os.environ.get("VALGRIND", "valgrind"))
    ap.add_argument("--workdir", type=Path, default=ROOT / "build" / "bench",
                    help="where the frames and callgrind outputs go")
    ap.add_argument("--out", type=Path, default=HERE / "results",
                    help="writes OUT.md and OUT.json")
    ap.add_argument("--cc", default=os.environ.get("CC", "cc"), help="compiler, for the report")
    ap.add_argument("--cflags", default="?", help="flags the C was built with, for the report")
    ap.add_argument("--stages", help="comma-separated subset of stage names")
    ap.add_argument("--command", help="the command to print in the report (make passes 'make bench')")
    ap.add_argument("--oracle-threads", type=int, default=1,
                    help="cv2.setNumThreads for the oracle (0: OpenCV's default, all cores)")
    ap.add_argument("--budget", type=float, default=1.0,
                    help="seconds of timing per stage and variant before stopping at min reps")
    ap.add_argument("--python-callgrind", choices=("auto", "on", "off"), default="auto",
                    help="the callgrind columns of stages without a callgrind_main.c entry: this script "
                         "under callgrind, collecting inside the cffi calls only (auto: on unless --quick)")
    ap.add_argument("--cg-one", help=argparse.SUPPRESS)
    ap.add_argument("--cg-size", help=argparse.SUPPRESS)
    ap.add_argument("--cnn-file", type=Path,
                    help="also bench this CNN .npz alone (stage cnn_file_detect; same as VT_BENCH_CNN_FILE)")
    args = ap.parse_args(argv)
    if args.cnn_file is not None:
        if not args.cnn_file.is_file():
            ap.error(f"--cnn-file {args.cnn_file}: no such file")
        os.environ[CNN_FILE_ENV] = str(args.cnn_file.resolve())
        _register_cnn_file()
    if args.cg_one:
        return _cg_one(args.cg_one, args.cg_size, args.quick)

    specs = REGISTRY
    if args.stages:
        want = args.stages.split(",")
        unknown = set(want) - {s.name for s in REGISTRY}
        if unknown:
            ap.error(f"unknown stage(s) {sorted(unknown)}; have {[s.name for s in REGISTRY]}")
        specs = [s for s in REGISTRY if s.name in want]

    import pyvehtrack  # noqa: F401  (fails early and clearly if the extension is missing)
    import cv2
    # The C runs on one core; by default so does the oracle's OpenCV, which makes the
    # ratio a like-for-like figure and keeps it steady on a shared machine.
    cv2.setNumThreads(args.oracle_threads)

    valgrind = shutil.which(args.valgrind)
    if args.driver is not None and valgrind is None:
        print(f"bench: {args.valgrind} not found; callgrind columns left empty", file=sys.stderr)
    in_driver = driver_stages(args.driver) if args.driver is not None else set()
    args.workdir.mkdir(parents=True, exist_ok=True)
    min_reps, max_reps = (1, 1) if args.quick else (3, 101)

    overhead = cffi_overhead_us(args.quick)
    rows, frames = [], []
    sizes = sorted({sz for s in specs for sz in s.sizes})
    for size in sizes:
        frame, origin = load_frame(*size, quick=args.quick)
        fh, fw = frame.shape
        frames.append(f"{fw}x{fh} from {origin}")
        ctx = Ctx(frame=frame, quick=args.quick)
        stages = [(spec, spec.make(ctx)) for spec in specs if size in spec.sizes]
        for spec, st in stages:
            if st.name != spec.name:
                raise ValueError(f"stage registered as {spec.name!r} returned Stage({st.name!r})")
        timed = {}
        for spec, st in stages:
            c_us, reps_c = time_us(st.c, min_reps, max_reps, args.budget)
            got_digest = st.digest() if st.digest else None
            ref_us, reps_ref = (time_us(st.reference, min_reps, max_reps, args.budget)
                                if st.reference else (None, 0))
            timed[st.name] = (c_us, reps_c, ref_us, reps_ref, got_digest)
            print(f"  {st.name:<14} {fw}x{fh}: C {c_us:10.1f} µs   oracle "
                  f"{_fmt(ref_us):>10} µs", file=sys.stderr)
        cg = {}
        cg_stages = [st for spec, st in stages if spec.driver and st.name in in_driver]
        if cg_stages and valgrind is not None:
            pgm = args.workdir / f"frame_{fw}x{fh}.pgm"
            write_pgm(pgm, frame)
            cg = run_callgrind(valgrind, args.driver, pgm, cg_stages,
                               args.workdir / f"callgrind_{fw}x{fh}.out")
        py_cg = args.python_callgrind == "on" or (args.python_callgrind == "auto" and not args.quick)
        if args.driver is not None and valgrind is not None and py_cg:
            for spec, st in stages:
                if not (spec.driver and st.name in in_driver):
                    cg[st.name] = run_callgrind_python(valgrind, st.name, (fw, fh), args.quick,
                                                       args.workdir / f"callgrind_py_{st.name}_{fw}x{fh}.out")
        # The C's own speed on this machine, from stages that make one binding call
        # per run (where the binding is negligible): instructions per µs.
        speeds = [cg[st.name]["ir"] / timed[st.name][0] for _, st in stages
                  if st.binding_calls == 1 and st.name in cg and timed[st.name][0] > 0]
        ir_per_us = statistics.median(speeds) if speeds else None
        for spec, st in stages:
            c_us, reps_c, ref_us, reps_ref, got_digest = timed[st.name]
            g = cg.get(st.name)
            ir = g["ir"] if g else None
            note = [st.note] if st.note else []
            n_calls = st.binding_calls
            if n_calls > 1:
                if ir is not None and ir_per_us:
                    share = max(0.0, 1.0 - (ir / ir_per_us) / c_us)
                    note.append(f"{n_calls:,} cffi calls: ~{share:.0%} of the C column is binding "
                                f"(est. from Ir at {ir_per_us:,.0f} Ir/µs)")
                else:
                    note.append(f"{n_calls:,} cffi calls: {n_calls * min(overhead.values()):,.0f}"
                                f"–{n_calls * max(overhead.values()):,.0f} µs of binding")
            if args.driver is not None and not (spec.driver and st.name in in_driver):
                note.append("Ir: Python under callgrind, inside the cffi calls only" if g else "no callgrind_main.c entry")
            if g and g["status"] not in (None, 0):
                note.append(f"driver status {g['status']}")
            match = None
            if g and g["digest"] is not None and got_digest is not None:
                match = g["digest"] == got_digest
            rows.append({
                "stage": st.name, "size": f"{fw}x{fh}", "units": st.units, "unit": st.unit,
                "pixels": st.pixels, "c_us": c_us, "reps_c": reps_c, "ref_us": ref_us,
                "reps_ref": reps_ref, "ratio": (ref_us / c_us) if ref_us and c_us > 0 else None,
                "ir": ir, "ir_per_px": (ir / st.pixels) if ir is not None and st.pixels else None,
                "ir_per_item": (ir / st.units) if ir is not None else None,
                "digest_c": got_digest, "digest_driver": g["digest"] if g else None,
                "digest_match": match, "note": "; ".join(note)})

    command = args.command or " ".join(["python", "bench/bench.py", *(argv if argv is not None
                                                                       else sys.argv[1:])])
    machine = machine_info(args.cc, args.cflags, valgrind)
    machine["oracle threads (cv2.setNumThreads)"] = str(args.oracle_threads)
    result = {"machine": machine, "frames": frames,
              "command": command, "quick": args.quick, "cffi_overhead_us": overhead,
              "rows": rows, "sizeof": struct_sizes()}
    text = render(result)
    sys.stdout.write(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".md").write_text(text)
    args.out.with_suffix(".json").write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
