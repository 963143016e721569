"""Plain types both engines share: the stage configurations of the detection stages
(fields, integer units and defaults as the C structs: shadow.h, verify.h, windows.h,
fulldet.h), the road area (vt_road_area, road.h), the flat-road camera of the window
stage and the fixed trapezoid road. No C and no oracle logic lives here, so the
friendly layer (detector.py, fullroad.py) uses them without importing
pyvehtrack.reference, and the oracle (reference/) re-exports them under its old names.
tests/test_detect.py and tests/test_fulldet.py check the defaults against the core's.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

FIXED = 0
ADAPTIVE = 1
DARK_ABOVE = 0
DARK_BELOW = 1


@dataclass(frozen=True)
class ShadowConfig:
    """Same fields, units and defaults as vt_shadow_cfg (include/vehtrack/shadow.h).

    Fractions of at most one are permille, scale factors that may exceed one Q8 integers
    (256 = 1.0), so the oracle uses exactly C's values."""
    threshold_mode: int = ADAPTIVE
    polarity: int = DARK_ABOVE     # the thesis's edge: dark shadow above the lit road
    grad_threshold: int = 48       # fixed: s*sobel_y >= this (Sobel gain 4: a 12-level step)
    adapt_k_q8: int = 96           # adaptive: dark = I < median - k*MAD, k = 0.375
    adapt_grad_min: int = 8        # adaptive: and s*sobel_y >= this (a 2-level step)
    stat_step: int = 2             # adaptive: statistics on every 2nd row and column
    min_run: int = 12              # thesis: 10-15 px
    max_gap: int = 2               # gaps bridged inside a run
    merge_rows: int = 2            # thesis: rows within 2 px are combined
    width_min_q8: int = 77         # 0.30 of the lane width
    width_max_q8: int = 256        # 1.00 of the lane width
    reduce_overlap_permille: int = 500  # 0.5 of the narrower edge
    reduce_height_q8: int = 256    # up to 1.0 x width above a kept edge


@dataclass(frozen=True)
class VerifyConfig:
    """Same fields, units and defaults as vt_verify_cfg (include/vehtrack/verify.h)."""
    widen_px: int = 6              # thesis: 6 px on each side
    widen_q8: int = 26             # plus this x edge length, 0.1 (thesis: 0)
    roi_height_q8: int = 128       # thesis: half the edge length
    vedge_threshold: int = 40      # |sobel_x| >= this (Sobel gain 4: a 10-level step)
    side_min_frac_permille: int = 250  # a side needs vertical edges on 1/4 of the ROI rows
    side_min_px: int = 3           # and on at least 3 rows
    side_contrast_q8: int = 384    # and >= 1.5 x the ROI's mean column count
    min_width_q8: int = 128        # sides >= 0.5 x edge length apart
    aspect_q8: int = 256           # height / width = 1.0 (thesis default)


@dataclass(frozen=True)
class Camera:
    """Minimal flat-road camera: focal length (px), horizon row, camera height (m),
    first hood row (rows at or below it are not road)."""
    fx: float = 714.0
    horizon_y: int = 376
    height_m: float = 1.8
    hood_y: int = 720


@dataclass(frozen=True)
class WindowConfig:
    veh_w_min_m: float = 1.4
    veh_w_max_m: float = 2.6
    sizes: tuple = (32, 45)
    step: float = 0.25          # fraction of the window side (C: step_q8 / 256)
    levels: int = 5
    lane_w_m: float = 3.7
    top_margin: int = 2


@dataclass(frozen=True)
class FullDetConfig:
    shadow_source: bool = True
    window_source: bool = True
    win: WindowConfig = field(default_factory=WindowConfig)
    shadow: ShadowConfig = field(default_factory=ShadowConfig)
    verify: VerifyConfig = field(default_factory=lambda: VerifyConfig(aspect_q8=192))
    window_score_min: int = 0
    edge_check: bool = True
    shadow_classify: bool = True
    shadow_score_min: int = 0
    shadow_score: int = 0
    nms_iou: float = 77 / 256
    nms_contain: float = 179 / 256
    box_height: float = 192 / 256     # window box height / width (bottom row kept)
    merge_iou: float = 0.0            # 0: off; else each kept box -> mean of candidates with IoU >= this


@dataclass
class RoadArea:
    """Python twin of vt_road_area (include/vehtrack/road.h): per-row road span
    x_left[y]..x_right[y] (inclusive) for y_top <= y <= y_bottom and the ego lane
    width per row. Arrays have one entry per image row."""
    y_top: int
    y_bottom: int
    x_left: np.ndarray
    x_right: np.ndarray
    lane_width: np.ndarray
    valid: bool = True

    @property
    def height(self) -> int:
        return len(self.x_left)


def trapezoid_road(h: int, w: int, *, vp=(0.5, 0.45), bottom=(0.0, 1.0),
                   lane_bottom: float = 0.5, top_margin: int = 4) -> RoadArea:
    """A fixed road area for frames without lane lines: a trapezoid from the frame's
    bottom row (columns bottom[0]*w .. bottom[1]*w) toward the vanishing point
    vp = (x, y) (fractions of w, h), cut `top_margin` rows below it. The ego lane
    width grows linearly from 0 at the vanishing point to lane_bottom*w at the
    bottom row (flat road, straight lanes). Integer arrays, as C gets them."""
    vx, vy = vp[0] * (w - 1), vp[1] * (h - 1)
    yb = h - 1
    yt = int(np.ceil(vy)) + top_margin
    ys = np.arange(h, dtype=np.float64)
    span = yb - vy if yb > vy else 1.0
    t = np.clip((ys - vy) / span, 0.0, 1.0)
    xl = np.floor(vx + t * (bottom[0] * (w - 1) - vx) + 0.5)
    xr = np.floor(vx + t * (bottom[1] * (w - 1) - vx) + 0.5)
    lw = np.floor(t * lane_bottom * w + 0.5)
    yt = min(max(yt, 0), yb)
    return RoadArea(y_top=yt, y_bottom=yb, x_left=xl.astype(np.int16),
                    x_right=xr.astype(np.int16), lane_width=lw.astype(np.int16))


def road_polygon(road) -> np.ndarray:
    """The road area's outline as an (N, 2) int array of (x, y), clockwise from the
    top-left: left border downward, then right border upward."""
    if road is None or not road.valid or road.y_top > road.y_bottom:
        return np.zeros((0, 2), np.int64)
    ys = np.arange(road.y_top, road.y_bottom + 1)
    left = np.stack([np.asarray(road.x_left)[ys], ys], 1)
    right = np.stack([np.asarray(road.x_right)[ys], ys], 1)[::-1]
    return np.concatenate([left, right]).astype(np.int64)


# Fields renamed when the configs moved to one unit for fractions (permille; issue 10
# item 6): old name -> (new name, factor), the conversion exact (new = old * factor).
TRACKER_RENAMED = {"roi_margin_percent": ("roi_margin_permille", 10), "gate_percent": ("gate_permille", 10),
                   "gate_bottom_percent": ("gate_bottom_permille", 10),
                   "match_iou_percent": ("match_iou_permille", 10)}
SEARCH_RENAMED = {"min_h_percent": ("min_h_permille", 10), "min_v_percent": ("min_v_permille", 10),
                  "bottom_percent": ("bottom_permille", 10)}
# Q8 fractions of at most 1 (256 = 1.0): new = old * 1000 / 256, accepted only where exact.
SHADOW_RENAMED = {"reduce_overlap_q8": ("reduce_overlap_permille", Fraction(1000, 256))}
VERIFY_RENAMED = {"side_min_frac_q8": ("side_min_frac_permille", Fraction(1000, 256))}


def accept_renamed(cls, renamed: dict):
    """Let dataclass `cls` still take the fields in `renamed` under their old names:
    cls(old=v) sets new = v * factor, and obj.old reads new / factor, both with a
    DeprecationWarning. A value that is not an int is passed on as it is, so the
    config's own check names the field and the type; an int whose new value would
    not be a whole number is a ValueError (never rounded silently)."""
    init = cls.__init__

    def __init__(self, *args, **kw):
        for old, (new, factor) in renamed.items():
            if old in kw:
                if new in kw:
                    raise TypeError(f"{cls.__name__}: give {new} or the deprecated {old}, not both")
                warnings.warn(f"{cls.__name__}.{old} is deprecated: use {new} (= {old} x {factor})",
                              DeprecationWarning, stacklevel=2)
                v = kw.pop(old)
                if isinstance(v, (int, np.integer)) and not isinstance(v, bool):
                    nv = Fraction(int(v)) * factor
                    if nv.denominator != 1:
                        raise ValueError(f"{cls.__name__}.{old}={v}: is {float(nv)} in {new}, not a whole "
                                         f"number; give {new} instead")
                    v = int(nv)
                kw[new] = v
        init(self, *args, **kw)

    __init__.__wrapped__ = init
    cls.__init__ = __init__
    for old, (new, factor) in renamed.items():
        def _get(self, old=old, new=new, factor=factor):
            warnings.warn(f"{type(self).__name__}.{old} is deprecated: use {new} (= {old} x {factor})",
                          DeprecationWarning, stacklevel=2)
            v = Fraction(getattr(self, new)) / factor
            return int(v) if v.denominator == 1 else float(v)
        setattr(cls, old, property(_get))
    return cls


accept_renamed(ShadowConfig, SHADOW_RENAMED)  # the Q8 names of before issue 10
accept_renamed(VerifyConfig, VERIFY_RENAMED)
