"""Float reference for detection over the whole road, twin of c/fulldet.c.

The composition the IVVI paper (sec. 4/5) and the GIST paper (sec. III) describe:
  1. a Gaussian pyramid of the frame (cv2.pyrDown, as the C vt_pyr_down);
  2. sliding windows on each level, restricted to the flat-road width band of a
     vehicle at their bottom row (reference.windows), each scored by the classifier;
     a window scoring >= window_score_min (and, with edge_check, whose bottom edge
     passes the thesis's vertical-edge verification) becomes a box: the window's
     width and bottom row, box_height of its width high;
  3. shadow hypotheses over the road area verified by vertical edges (thesis sec.
     2.4.2, reference.shadow / reference.verify); with shadow_classify, the window
     of the pyramid nearest each shadow box in width is scored and the box kept if
     it scores >= shadow_score_min;
  4. greedy NMS of all boxes (reference.windows.nms), limits nms_iou_permille / 1000 and
     nms_contain_permille / 1000;
  5. with merge_iou_permille > 0, box refinement: each kept box becomes the mean of every
     candidate whose IoU with it is at least merge_iou_permille / 1000 (rounded half up);
  6. (verify_boxes, a separate call) a second classifier on the square standing on
     each box's bottom keeps the boxes it scores >= its minimum;
  6b. (refine, a separate call) box regression: each side of a box moved by an
     offset four linear models predict from the HOG of the box's surroundings;
  7. (wide, a separate call) the wide pass: boxes flatter than 1:2 (side views,
     trucks) from a second window grid with a wider vehicle band, scored by a wide
     window model, thinned by NMS and added where no box stands yet.
The classifier is any function score(level_image, level, size, x, y) -> int (the
same scale as the C scorer), so C and oracle can share one.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from . import shadow as rshadow
from . import detect as rdetect
from . import verify as rverify
from . import windows as rw
from .image import pyr_down
from ..shared import FullDetConfig  # noqa: F401  (a plain type both engines share)


def detect(gray: np.ndarray, road, cam: rw.Camera, cfg: FullDetConfig, score=None, *,
           max_windows: int = 4096, max_cand: int = 1024, max_boxes: int = 32,
           max_hyp: int = 32, max_shadow_active: int = 64, max_shadow_cand: int = 64, rescore=None):
    """Boxes (N, 6) int [left, top, right, bottom, score, source] after NMS, highest
    score first (source 1 shadow, 2 window), and counters as the C result has them.
    With cfg.rerank_permille > 0 (twin of vt_fulldet then vt_fulldet_rerank), rescore(l,
    t, r, b) -> int is the second-stage model on a box: each candidate's score becomes
    score + floor(rerank_permille * rescore(its bottom square) / 1000) (saturated to
    int32) before NMS, candidates ordered by that, then left, top, right, bottom."""
    gray = np.asarray(gray, np.uint8)
    h, w = gray.shape
    stats = dict(n_windows=0, n_windows_dropped=0, n_window_hits=0, n_shadow=0, n_cand=0,
                 n_cand_dropped=0)
    use_pyr = score is not None and (cfg.window_source or (cfg.shadow_source and cfg.shadow_classify))
    levels = [gray]
    if use_pyr:
        for _ in range(cfg.win.levels - 1):
            levels.append(pyr_down(levels[-1]))
    cands = []   # [l, t, r, b, score, source]

    def add(box, sc, src):
        if len(cands) < max_cand:
            cands.append([*box, sc, src])
            return
        stats["n_cand_dropped"] += 1
        lo = min(range(len(cands)), key=lambda i: cands[i][4])   # first lowest
        if cands[lo][4] < sc:
            cands[lo] = [*box, sc, src]

    if cfg.window_source:
        for lvl in range(cfg.win.levels):
            wins = rw.windows_level(cfg.win, cam, road, w, h, lvl)
            stats["n_windows"] += len(wins)
            if len(wins) > max_windows:
                stats["n_windows_dropped"] += len(wins) - max_windows
                wins = wins[:max_windows]
            if score is None or not len(wins):
                continue
            for lv, s, x, y in wins:
                sc = int(score(levels[lvl], int(lv), int(s), int(x), int(y)))
                if sc < cfg.window_score_min:
                    continue
                stats["n_window_hits"] += 1
                l, t, r, b = rw.window_box((lv, s, x, y))
                r, b = min(r, w - 1), min(b, h - 1)
                bh = max(1, int(np.floor(s * 2 ** lvl * cfg.box_height)))
                box = (l, min(max(b - bh + 1, 0), b), r, b)
                if cfg.edge_check and rverify.verify_one(gray, (box[3], box[0], box[2]), cfg.verify) is None:
                    continue
                add(box, sc, 2)
    road_t = rw.as_road_tuple(road)
    if cfg.shadow_source and road_t is not None and road_t[0]:
        area = rshadow.RoadArea(road_t[1], road_t[2], road_t[3], road_t[4], road_t[5], True)
        _, boxes = rdetect.detect(gray, area, cfg.shadow, cfg.verify, max_active=max_shadow_active,
                                  max_cand=max_shadow_cand, max_hyp=max_hyp, max_boxes=max_boxes)
        stats["n_shadow"] = len(boxes)
        for bx in boxes:
            l, t, r, b = (int(v) for v in bx)
            sc = cfg.shadow_score
            if use_pyr and cfg.shadow_classify:
                bw, best, pick = r - l + 1, None, None
                for lvl, img in enumerate(levels):
                    for s in cfg.win.sizes:
                        d = abs(s * 2 ** lvl - bw)
                        if s <= img.shape[1] and s <= img.shape[0] and (best is None or d < best):
                            best, pick = d, (lvl, s)
                if pick is None:
                    continue
                lvl, s = pick
                lh, lw = levels[lvl].shape
                x = min(max(((l + r + 1) >> (lvl + 1)) - s // 2, 0), lw - s)
                y = min(max(((b + 1) >> lvl) - s, 0), lh - s)
                sc = int(score(levels[lvl], lvl, s, x, y))
                if sc < cfg.shadow_score_min:
                    continue
            add((l, t, r, b), sc, 1)
    stats["n_cand"] = len(cands)
    if cfg.rerank_permille > 0:
        if rescore is None:
            raise ValueError("rescore: required when cfg.rerank_permille > 0")
        for c in cands:   # the square on the bottom row, as the second stage scores it
            key = int(c[4]) + cfg.rerank_permille * int(rescore(c[0], max(0, c[3] - (c[2] - c[0])), c[2], c[3])) // 1000
            c[4] = min(max(key, -2 ** 31), 2 ** 31 - 1)
        cands.sort(key=lambda c: (-c[4], c[0], c[1], c[2], c[3]))
    keep = rw.nms([c[:4] for c in cands], [c[4] for c in cands], Fraction(cfg.nms_iou_permille, 1000),
                  Fraction(cfg.nms_contain_permille, 1000))
    out = np.array([cands[i] for i in keep], np.int64).reshape(-1, 6)[:max_boxes]
    if cfg.merge_iou_permille > 0:
        lim = Fraction(cfg.merge_iou_permille, 1000)
        allc = [tuple(int(v) for v in c[:4]) for c in cands]
        for k in range(len(out)):
            a = tuple(int(v) for v in out[k, :4])
            grp = []
            for b in allc:
                inter, union, _, _ = rw._iou_parts(a, b)
                if inter > 0 and Fraction(inter, union) >= lim:
                    grp.append(b)
            if grp:   # mean rounded half up: floor(mean + 1/2)
                out[k, :4] = [int(np.floor(Fraction(sum(g[i] for g in grp), len(grp)) + Fraction(1, 2)))
                              for i in range(4)]
    return out, stats


def verify_boxes(boxes: np.ndarray, score_box, score_min: int) -> np.ndarray:
    """Second-stage check (twin of vt_fulldet_verify): score_box(l, t, r, b) -> int
    on the square standing on each box's bottom (top cut at row 0); boxes scoring
    >= score_min are kept in order, carrying that score."""
    out = []
    for row in np.asarray(boxes, np.int64).reshape(-1, 6):
        l, t, r, b = (int(v) for v in row[:4])
        sc = int(score_box(l, max(0, b - (r - l)), r, b))
        if sc >= score_min:
            out.append([l, t, r, b, sc, int(row[5])])
    return np.array(out, np.int64).reshape(-1, 6)


def context_box(box, margin_permille: int, w_img: int, h_img: int) -> tuple:
    """The box grown by margin_permille of its width on every side, cut to the image
    (twin of vt_box_regress's context)."""
    l, t, r, b = (int(v) for v in box)
    m = (margin_permille * (r - l + 1) + 500) // 1000
    return (min(max(l - m, 0), w_img - 1), min(max(t - m, 0), h_img - 1),
            min(max(r + m, 0), w_img - 1), min(max(b + m, 0), h_img - 1))


def regress_box(box, offsets_q16, w_img: int, h_img: int) -> tuple:
    """Twin of vt_box_regress's move: side k += round-half-up(o_k (r - l + 1) / 2^16),
    cut to the image; a box turned inside out is kept as it was."""
    l, t, r, b = (int(v) for v in box)
    wb = r - l + 1
    new = [v + Fraction(int(o) * wb, 65536) for v, o in zip((l, t, r, b), offsets_q16)]
    new = [int(np.floor(v + Fraction(1, 2))) for v in new]
    lim = (w_img - 1, h_img - 1, w_img - 1, h_img - 1)
    new = [min(max(v, 0), m) for v, m in zip(new, lim)]
    if new[2] < new[0] or new[3] < new[1]:
        return (l, t, r, b)
    return tuple(new)


def refine(boxes: np.ndarray, offsets, margin_permille: int, sources: int, w_img: int, h_img: int) -> np.ndarray:
    """Box regression (twin of vt_fulldet_refine): every box whose source bit is in
    `sources` is moved by regress_box with offsets(l, t, r, b) -> four Q16 ints, the
    regressor's output on its context box; scores, sources and order unchanged."""
    out = np.asarray(boxes, np.int64).reshape(-1, 6).copy()
    for row in out:
        if int(row[5]) & sources:
            ctx = context_box(row[:4], margin_permille, w_img, h_img)
            row[:4] = regress_box(row[:4], offsets(*ctx), w_img, h_img)
    return out


def wide(gray: np.ndarray, road, cam: rw.Camera, win, wcfg, score_box, boxes, *, max_windows: int = 4096,
         max_cand: int = 1024, max_boxes: int = 32) -> np.ndarray:
    """The wide pass (twin of vt_fulldet_wide, fulldet.h): boxes (N, 6) are the result
    so far; returns them followed by the wide boxes added. win: the WindowConfig of the
    main grid (its band replaced by wcfg's); wcfg: a shared.WideConfig; score_box(l, t,
    r, b) -> int, the wide model's score of an input-pixel box. With alternative heights
    (wcfg.alt_height_*_permille) a window whose box scores >= wcfg.alt_score_min takes
    the height its box scores highest at (ties: the earlier of base, a, b)."""
    from dataclasses import replace
    gray = np.asarray(gray, np.uint8)
    h, w = gray.shape
    grid = replace(win, veh_w_min_m=wcfg.veh_w_min_m, veh_w_max_m=wcfg.veh_w_max_m)
    bh_pm = wcfg.box_height_permille
    iou_pm, con_pm = wcfg.nms_iou_permille, wcfg.nms_contain_permille
    cands = []
    for lvl in range(grid.levels):
        for lv, s, x, y in rw.windows_level(grid, cam, road, w, h, lvl)[:max_windows]:
            lv, s, x, y = int(lv), int(s), int(x), int(y)
            span = s << lv
            b = min(((y + s) << lv) - 1, h - 1)

            def cut(pm, span=span, b=b, x=x, s=s, lv=lv):   # the window's box at height pm / 1000
                return (x << lv, max(b - max(1, span * pm // 1000) + 1, 0), min(((x + s) << lv) - 1, w - 1), b)
            box = cut(bh_pm)
            sc = int(score_box(*box))
            if sc >= wcfg.alt_score_min:   # the aspect the model prefers (strictly higher wins)
                for pm in (wcfg.alt_height_a_permille, wcfg.alt_height_b_permille):
                    if pm:
                        alt = cut(pm)
                        sa = int(score_box(*alt))
                        if sa > sc:
                            box, sc = alt, sa
            if sc < wcfg.score_min:
                continue
            if len(cands) < max_cand:
                cands.append((box, sc))
                continue
            lo = min(range(len(cands)), key=lambda i: cands[i][1])   # first lowest
            if cands[lo][1] < sc:
                cands[lo] = (box, sc)
    cands.sort(key=lambda c: -c[1])   # stable

    def overlap(a, b):   # the pass's suppression test, in permille
        inter, union, aa, ab = rw._iou_parts(a, b)
        return inter > 0 and (1000 * inter > iou_pm * union or 1000 * inter > con_pm * min(aa, ab))

    kept = []
    for box, sc in cands:
        if not any(overlap(k, box) for k, _ in kept):
            kept.append((box, sc))
    out = [list(int(v) for v in r) for r in np.asarray(boxes, np.int64).reshape(-1, 6)]
    have = [tuple(r[:4]) for r in out]
    for box, sc in kept:
        if len(out) >= max_boxes:
            break
        if not any(overlap(a, box) for a in have):
            out.append([*box, sc, 2])
    return np.array(out, np.int64).reshape(-1, 6)


__all__ = ["FullDetConfig", "detect", "verify_boxes", "wide"]


RESCORE_N_FEAT = 7


def rescore_features(box, score_q16: int, hog_q16: int, horizon_y: int, w_img: int, h_img: int) -> list:
    """Twin of vt_box_rescore_features (fulldet.h) given the context HOG's decision:
    [hog, score, w, aspect, width on the road, centre column, row below the horizon]."""
    l, t, r, b = (int(v) for v in box)
    w = r - l + 1
    d = max(1, b - int(horizon_y))
    return [int(hog_q16), int(score_q16), w, (b - t + 1) * 1000 // w, w * 1000 // d,
            (l + r + 1) * 1000 // (2 * w_img), d * 1000 // h_img]


def rescore_trees(feat, thr, leaf_q16, bias_q16: int, depth: int, f) -> int:
    """Twin of vt_box_rescore_trees: bias + the leaves the feature vector f reaches,
    saturated to int32."""
    n_in = (1 << depth) - 1
    acc = int(bias_q16)
    for ft, th, lf in zip(np.asarray(feat), np.asarray(thr), np.asarray(leaf_q16)):
        node = 0
        for _ in range(depth):
            node = 2 * node + 1 + int(int(f[int(ft[node])]) > int(th[node]))
        acc += int(lf[node - n_in])
    return max(-2 ** 31, min(2 ** 31 - 1, acc))


def side_cut(box, w_img: int) -> bool:
    """Twin of fulldet.c's vt__box_side_cut: the frame's left or right side cuts the box
    (within a quarter of its width + 1 px)."""
    l, r = int(box[0]), int(box[2])
    w = r - l + 1
    return 4 * l <= w + 4 or 4 * (int(w_img) - 1 - r) <= w + 4


def rescore(boxes: np.ndarray, score_of, score_min: int, nms_iou_permille: int,
            nms_contain_permille: int, side_keep: int = 0, side_score_min: int = 0,
            w_img: int = 0) -> np.ndarray:
    """Twin of vt_fulldet_rescore: score_of(row) -> the trees' Q16 score of a result row
    (l, t, r, b, score, source); rows scoring >= score_min, sorted by the new score
    (stable), thinned by greedy NMS (windows.suppresses). With side_keep, a row the
    frame's side cuts (side_cut, frame width w_img) whose first-stage score is >=
    side_score_min stays, scored max(new score, score_min)."""
    rows = []
    for row in np.asarray(boxes, np.int64).reshape(-1, 6):
        s = int(score_of(row))
        if s < score_min and side_keep and int(row[4]) >= side_score_min and side_cut(row[:4], w_img):
            s = int(score_min)
        if s >= score_min:
            rows.append((*[int(v) for v in row[:4]], s, int(row[5])))
    rows.sort(key=lambda r: -r[4])   # Python's sort is stable
    kept = []
    for r in rows:
        if not any(rw.suppresses(k[:4], r[:4], nms_iou_permille, nms_contain_permille) for k in kept):
            kept.append(r)
    return np.array(kept, np.int64).reshape(-1, 6)
