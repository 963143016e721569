"""Float/rational reference for the full-road hypothesis stage, twin of c/windows.c.

IVVI paper sec. 4/5 (road restriction): on a flat road seen by a camera at height H
with its horizon at row y_h, the road point at row y is at distance Z = fx H / (y - y_h),
and a vehicle W metres wide standing there is fx W / Z = W (y - y_h) / H pixels wide.
A sliding window (GIST paper sec. III: windows scored by a classifier) whose bottom row
is y is therefore worth scoring only when its width lies between the widths of a
1.4 m and a 2.6 m vehicle at that row. Windows are laid on a Gaussian pyramid: a window
of s level pixels at level l covers s 2^l input pixels.

The bounds are written here with exact rationals (fractions.Fraction), so the rule is
the paper's formula with no rounding and the C twin (integer mm x px products) must
agree exactly. Non-maximum suppression is the textbook greedy one (highest score
first; drop boxes overlapping a kept one by IoU above a threshold, or lying mostly
inside it).
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from ..shared import Camera, WindowConfig  # noqa: F401  (plain types both engines share)


def _frac(x) -> Fraction:
    return Fraction(str(x)) if isinstance(x, float) else Fraction(x)


def vehicle_width_px(cam: Camera, width_m: float, row: int) -> Fraction:
    """Image width (px) of a `width_m`-metre object standing on the road at `row`."""
    return _frac(width_m) * (row - cam.horizon_y) / _frac(cam.height_m)


def row_distance_m(cam: Camera, row: int) -> float:
    """Distance (m) of the road point at `row` (row below the horizon)."""
    return cam.fx * cam.height_m / (row - cam.horizon_y)


def level_sizes(w: int, h: int, levels: int) -> list:
    """(w_l, h_l) of pyramid levels 0..levels-1, as cv2.pyrDown: (n + 1) // 2."""
    out = [(w, h)]
    for _ in range(levels - 1):
        w, h = (w + 1) // 2, (h + 1) // 2
        out.append((w, h))
    return out


def road_from_camera(cam: Camera, cfg: WindowConfig, w: int, h: int):
    """The camera road area: every column of the rows between the horizon (+ margin)
    and the hood; lane width from the flat-road formula with a lane_w_m lane, rounded
    half up, at least 1 px. Returns (valid, y_top, y_bottom, x_left, x_right,
    lane_width) with per-row arrays of h entries (0 outside the area)."""
    y0 = max(0, cam.horizon_y + cfg.top_margin)
    y1 = min(h, cam.hood_y) - 1
    xl = np.zeros(h, np.int64)
    xr = np.zeros(h, np.int64)
    lw = np.zeros(h, np.int64)
    if y0 > y1:
        return False, 0, -1, xl, xr, lw
    for y in range(y0, y1 + 1):
        xr[y] = w - 1
        v = vehicle_width_px(cam, cfg.lane_w_m, y)
        lw[y] = min(32767, max(1, int(np.floor(v + Fraction(1, 2)))))
    return True, y0, y1, xl, xr, lw


def windows_level(cfg: WindowConfig, cam: Camera, road, w: int, h: int, level: int) -> np.ndarray:
    """Windows (N, 4) [level, size, x, y] of one pyramid level (see windows.h for the
    rules: inside the level image, bottom row below the horizon, above the hood and in
    the road rows, window width inside the 1.4-2.6 m band at that row, centre column in
    the road span; rows from the first valid one every step rows, columns from 0 every
    step columns). `road` is None or (valid, y_top, y_bottom, x_left, x_right, ...)."""
    lw, lh = level_sizes(w, h, level + 1)[level]
    road = as_road_tuple(road)
    if road is not None and not road[0]:
        road = None
    out = []
    for s in cfg.sizes:
        step = max(1, int(s * cfg.step))
        if s > lw or s > lh:
            continue

        def bottom(y):
            return (y + s) * 2 ** level - 1

        def row_ok(y):
            b = bottom(y)
            if b <= cam.horizon_y or b >= cam.hood_y:
                return False
            if road is not None and not road[1] <= b <= road[2]:
                return False
            span = s * 2 ** level
            return vehicle_width_px(cam, cfg.veh_w_min_m, b) <= span <= vehicle_width_px(cam, cfg.veh_w_max_m, b)

        rows = [y for y in range(0, lh - s + 1) if row_ok(y)]
        if not rows:
            continue
        for y in range(rows[0], rows[-1] + 1, step):
            b = bottom(y)
            for x in range(0, lw - s + 1, step):
                centre = (x * 2 ** level + (x + s) * 2 ** level - 1) // 2
                if road is not None and not road[3][b] <= centre <= road[4][b]:
                    continue
                out.append((level, s, x, y))
    return np.asarray(out, np.int64).reshape(-1, 4)


def as_road_tuple(road):
    """(valid, y_top, y_bottom, x_left, x_right, lane_width) from such a tuple or from a
    RoadArea-like object (reference.shadow.RoadArea); None stays None."""
    if road is None or isinstance(road, tuple):
        return road
    return (bool(getattr(road, "valid", True)), int(road.y_top), int(road.y_bottom),
            np.asarray(road.x_left), np.asarray(road.x_right), np.asarray(road.lane_width))


def window_box(win) -> np.ndarray:
    """Input-pixel box [left, top, right, bottom] (inclusive) of a window row."""
    level, s, x, y = (int(v) for v in win)
    k = 2 ** level
    return np.array([x * k, y * k, (x + s) * k - 1, (y + s) * k - 1], np.int64)


def _iou_parts(a, b):
    iw = min(a[2], b[2]) - max(a[0], b[0]) + 1
    ih = min(a[3], b[3]) - max(a[1], b[1]) + 1
    if iw <= 0 or ih <= 0:
        return 0, 1, 1, 1
    inter = iw * ih
    area_a = (a[2] - a[0] + 1) * (a[3] - a[1] + 1)
    area_b = (b[2] - b[0] + 1) * (b[3] - b[1] + 1)
    return inter, area_a + area_b - inter, area_a, area_b


def suppresses(a, b, iou_permille: int, contain_permille: int) -> bool:
    """NMS's test in permille, exactly as c/windows.c's vt__box_suppress: box b is
    suppressed by the kept box a when their IoU exceeds iou_permille / 1000 or their
    overlap exceeds contain_permille / 1000 of the smaller box's area."""
    inter, union, aa, ab = _iou_parts([int(v) for v in a], [int(v) for v in b])
    return bool(inter) and (inter * 1000 > iou_permille * union or inter * 1000 > contain_permille * min(aa, ab))


def nms(boxes, scores, iou_max: float, contain_max: float = 1.0) -> list:
    """Indices of the boxes kept by greedy NMS, in keeping order: highest score first
    (equal scores in input order); a box is dropped if, with a kept box, its IoU exceeds
    iou_max or their overlap exceeds contain_max of the smaller box's area."""
    boxes = [tuple(int(v) for v in b) for b in boxes]
    order = sorted(range(len(boxes)), key=lambda i: -scores[i])   # sorted() is stable
    kept = []
    for i in order:
        ok = True
        for k in kept:
            inter, union, aa, ab = _iou_parts(boxes[k], boxes[i])
            if inter and (Fraction(inter, union) > _frac(iou_max)
                          or Fraction(inter, min(aa, ab)) > _frac(contain_max)):
                ok = False
                break
        if ok:
            kept.append(i)
    return kept


__all__ = ["Camera", "WindowConfig", "vehicle_width_px", "row_distance_m", "level_sizes",
           "road_from_camera", "windows_level", "window_box", "nms", "suppresses", "as_road_tuple"]
