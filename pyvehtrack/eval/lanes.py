"""The TuSimple lane metric, recomputed as TuSimple's evaluate/lane.py does it.

Source of the rules: TuSimple/tusimple-benchmark, evaluate/lane.py (LaneEval.bench):
  * each GT lane gets a threshold of 20 / cos(angle) px, the angle from a least-squares
    line x(y) through its labelled points;
  * a predicted x and a GT x are compared at every h_sample; any negative value (-2 =
    "no point") becomes -100 first, so "both absent" counts as correct and "one absent"
    as wrong; line accuracy = correct rows / len(h_samples);
  * every GT lane takes its best predicted lane; it is matched when that accuracy is
    >= 0.85, else it is a false negative; frame accuracy = sum of the best accuracies
    / min(4, n_gt) (with more than 4 GT lanes the worst is dropped and one miss is
    forgiven); FP = (n_pred - matched) / n_pred, FN = misses / n_gt;
  * a prediction whose lane lists are not len(h_samples) long scores (0, 0, 1).
The three scores are averaged over the frames.

`ego_lanes` picks the two GT lanes this project scores against: the nearest labelled
lane on each side of the image centre at the bottom, each extrapolated to the lowest
h_sample by a line through its lowest (up to) 10 points.
"""
from __future__ import annotations

import numpy as np

PIXEL_THRESH = 20.0
PT_THRESH = 0.85


def _angle(xs: np.ndarray, ys: np.ndarray) -> float:
    m = xs >= 0
    xs, ys = xs[m], ys[m]
    if len(xs) > 1:
        # sklearn LinearRegression(fit x on y) == ordinary least squares slope.
        k = np.polyfit(ys.astype(float), xs.astype(float), 1)[0]
        return float(np.arctan(k))
    return 0.0


def line_accuracy(pred, gt, thresh: float) -> float:
    pred = np.array([p if p >= 0 else -100 for p in pred], float)
    gt = np.array([g if g >= 0 else -100 for g in gt], float)
    return float(np.sum(np.where(np.abs(pred - gt) < thresh, 1.0, 0.0)) / len(gt))


def bench(pred: list, gt: list, y_samples: list) -> tuple[float, float, float]:
    """(accuracy, fp, fn) of one frame, as LaneEval.bench (running time ignored)."""
    if any(len(p) != len(y_samples) for p in pred):
        return 0.0, 0.0, 1.0
    ys = np.array(y_samples)
    threshs = [PIXEL_THRESH / np.cos(_angle(np.array(x, float), ys)) for x in gt]
    line_accs = []
    fn = 0.0
    matched = 0.0
    for x_gts, thresh in zip(gt, threshs):
        accs = [line_accuracy(np.array(x_p), np.array(x_gts), thresh) for x_p in pred]
        max_acc = max(accs) if accs else 0.0
        if max_acc < PT_THRESH:
            fn += 1
        else:
            matched += 1
        line_accs.append(max_acc)
    fp = len(pred) - matched
    if len(gt) > 4 and fn > 0:
        fn -= 1
    s = sum(line_accs)
    if len(gt) > 4:
        s -= min(line_accs)
    return (s / max(min(4.0, len(gt)), 1.0),
            fp / len(pred) if len(pred) > 0 else 0.0,
            fn / max(len(gt), 1.0))


def bottom_x(lane: list, y_samples: list) -> float | None:
    """x of a GT lane extrapolated to the lowest h_sample (line through its lowest
    10 labelled points); None with fewer than 2 points."""
    xs = np.array(lane, float)
    ys = np.array(y_samples, float)
    m = xs >= 0
    if m.sum() < 2:
        return None
    k, c = np.polyfit(ys[m][-10:], xs[m][-10:], 1)
    return float(k * ys.max() + c)


def ego_lanes(lanes: list, y_samples: list, width: int = 1280) -> list:
    """The GT lanes nearest to the image centre at the bottom, one per side
    (left first); a side without a lane is left out."""
    cx = width / 2.0
    left, right = None, None
    for lane in lanes:
        xb = bottom_x(lane, y_samples)
        if xb is None:
            continue
        if xb < cx and (left is None or xb > left[0]):
            left = (xb, lane)
        elif xb >= cx and (right is None or xb < right[0]):
            right = (xb, lane)
    return [v[1] for v in (left, right) if v is not None]


def sample_points(points: np.ndarray, y_samples: list, width: int) -> list:
    """A lane given as (x, y) points (y increasing or decreasing) resampled at the
    h_samples by linear interpolation; -2 outside its row range or outside the image."""
    out = []
    if points is None or len(points) < 2:
        return [-2] * len(y_samples)
    p = np.asarray(points, float)
    order = np.argsort(p[:, 1])
    xs, ys = p[order, 0], p[order, 1]
    for y in y_samples:
        if y < ys[0] or y > ys[-1]:
            out.append(-2)
            continue
        x = float(np.interp(y, ys, xs))
        out.append(int(round(x)) if 0 <= x < width else -2)
    return out
