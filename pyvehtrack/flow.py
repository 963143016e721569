"""Overtaking vehicles by SAD block-matching flow (IVVI paper, sec. 3), on the C
core or the float reference.

    det = OvertakingDetector()                    # C engine, defaults from the C core
    for frame in frames:
        res = det.step(frame)                     # FlowResult: ready, hyps
        for h in res.hyps: h.box, h.side, h.flow  # "left"/"right", px/frame
    tid = det.seed(box)                           # hand over a vehicle the ego car overtakes

Configuration: keyword overrides of the C struct vt_flow_cfg's fields (see
include/vehtrack/flow.h), e.g. OvertakingDetector(sides="both", level=2);
`sides` also takes "left" / "right" / "both"."""
from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from . import _native
from .shared import FLOW_RENAMED, take_renamed

SIDES = {"left": 1, "right": 2, "both": 3}
SIDE_NAMES = {1: "left", 2: "right"}
KIND_NAMES = {1: "overtaking", 2: "handover"}
CFG_FIELDS = [f for f, _ in _native.ffi.typeof("vt_flow_cfg").fields]


@dataclass(frozen=True)
class FlowHyp:
    box: tuple          # (left, top, right, bottom), inclusive, input pixels
    side: str           # "left" | "right"
    kind: str           # "overtaking" | "handover"
    id: int             # hand-over id, 0 for overtaking blobs
    cells: int          # blob size in cells (hand-over: matched cells)
    flow: tuple         # mean motion (dx, dy), input px/frame
    age: int            # frames in a row it was seen (reported from cfg.min_age on)
    cy: int             # row of its centre of gravity, input px (the model's upper y bound)


@dataclass(frozen=True)
class FlowResult:
    ready: bool         # False on a first frame (no previous one to compare with)
    hyps: list


def make_cfg(**overrides):
    """The C defaults (read from the core) with keyword overrides, checked by C. The percent
    names of before issue 10 (strip_percent, ..., seed_min_visible) are still taken, x 10
    into their permille fields, with a DeprecationWarning."""
    cfg = _native.flow_cfg_default()
    overrides = take_renamed("flow", overrides, FLOW_RENAMED)
    for k, v in overrides.items():
        if k not in CFG_FIELDS:
            raise TypeError(f"{k}: not a flow setting (expected one of {', '.join(CFG_FIELDS)})")
        if k == "sides" and isinstance(v, str):
            if v not in SIDES:
                raise ValueError(f"sides: expected 'left', 'right' or 'both', got {v!r}")
            v = SIDES[v]
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
            raise TypeError(f"{k}: expected an int, got {type(v).__name__}")
        if not -2**31 <= int(v) < 2**31:
            raise ValueError(f"{k}: {v} out of the int32 range")
        setattr(cfg, k, int(v))
    _native.flow_cfg_check(cfg)
    return cfg


def _gray(frame, name="frame") -> np.ndarray:
    if not isinstance(frame, np.ndarray):
        raise TypeError(f"{name}: expected a numpy.ndarray, got {type(frame).__name__}")
    if frame.dtype != np.uint8:
        raise TypeError(f"{name}: expected dtype uint8, got {frame.dtype}")
    if frame.ndim == 3 and frame.shape[2] == 3:
        import cv2
        return cv2.cvtColor(np.ascontiguousarray(frame), cv2.COLOR_BGR2GRAY)
    if frame.ndim != 2:
        raise ValueError(f"{name}: expected a gray (h, w) or BGR (h, w, 3) image, got shape {frame.shape}")
    if frame.shape[0] < 1 or frame.shape[1] < 1:
        raise ValueError(f"{name}: empty image {frame.shape}")
    return frame


class OvertakingDetector:
    """engine="c" runs c/flow.c, "reference" the float oracle (pyvehtrack.reference.flow)."""

    def __init__(self, engine: str = "c", **cfg):
        if engine not in ("c", "reference"):
            raise ValueError(f"engine: expected 'c' or 'reference', got {engine!r}")
        self.engine = engine
        self.cfg = make_cfg(**cfg)
        self._last = None       # the last frame stepped (gray): seed() computes its level image there
        if engine == "c":
            self._st = _native.flow_new()
        else:
            from .reference import flow as rflow
            ns = SimpleNamespace(**{f: int(getattr(self.cfg, f)) for f in CFG_FIELDS})
            self._ref = rflow.FlowOracle(ns, int(_native.lib.VT_FLOW_MAX_HYPS),
                                         int(_native.lib.VT_FLOW_MAX_SEEDS), int(_native.lib.VT_FLOW_MAX_BLOBS))

    def reset(self) -> None:
        self._last = None
        if self.engine == "c":
            _native.flow_reset(self._st)
        else:
            self._ref.reset()

    def step(self, frame: np.ndarray) -> FlowResult:
        g = _gray(frame)
        if self.engine == "c":
            ready, hyps, _ = _native.flow_step(self._st, self.cfg, g)
            self._last = g
            out = [FlowHyp((int(h["left"]), int(h["top"]), int(h["right"]), int(h["bottom"])),
                           SIDE_NAMES[int(h["side"])], KIND_NAMES[int(h["kind"])], int(h["id"]),
                           int(h["cells"]), (h["flow_x"] / 65536.0, h["flow_y"] / 65536.0), int(h["age"]),
                           int(h["cy"]))
                   for h in hyps]
            return FlowResult(ready, out)
        ready, hyps = self._ref.step(g)
        self._last = g
        return FlowResult(ready, [FlowHyp(h.box, SIDE_NAMES[h.side], KIND_NAMES[h.kind], h.id,
                                          h.cells, h.flow, h.age, h.cy) for h in hyps])

    def seed(self, box) -> int:
        """Hand a vehicle over (box in the last frame's pixels); returns its id. The last
        frame given to step() (kept by reference: do not overwrite it in place before
        this call) is passed on, so the track is followed from all its cells on its first
        step (vt_flow_seed_frame)."""
        if self._last is None:
            if self.engine == "c":
                return _native.flow_seed(self._st, self.cfg, box)   # no previous frame: the C error
            return self._ref.seed(box)
        if self.engine == "c":
            return _native.flow_seed_frame(self._st, self.cfg, self._last, box)
        return self._ref.seed(box, frame=self._last)
