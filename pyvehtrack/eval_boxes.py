"""Box scoring for full-frame vehicle detection: recall and precision at IoU >= 0.5 by
size class and for the lead vehicle, and COCO AP50 computed by pycocotools.

Inputs (both plain Python data, so the eval package and the CLI share this module):
  * ground truth in the tusimple-vehicles-dev format: a list of
    {"file_name": "supp_img/0005.jpg", "bbox": [{"left", "top", "right", "bottom"}, ...]};
  * predictions as written by `pyvehtrack detect --json`: a list of
    {"frame": i, "file": path, "boxes": [[left, top, right, bottom(, score)], ...]}.
A prediction entry belongs to the ground-truth frame with the same file name (when names
repeat, the one whose file_name its `file` path ends with); frames of the ground truth with no prediction entry are
not scored (the count is reported), a prediction for a file the ground truth lacks is an
error.

Boxes are inclusive pixel boxes, as the README of tusimple-vehicles-dev says to treat
them: width = right - left + 1. IoU uses those widths, here and in the COCO boxes.

Matching (per frame): predictions in decreasing score order (ties: input order), each
takes the unmatched ground-truth box of highest IoU if that IoU >= 0.5 (COCO's greedy
rule). Then, for a size class "width >= S px":
  * recall    = matched ground-truth boxes of width >= S / ground-truth boxes of width >= S;
  * precision = predictions matched to a ground-truth box of width >= S /
                (those + unmatched predictions of width >= S);
    predictions matched to a smaller ground-truth box are left out of that class
    (neither right nor wrong there), as COCO's area ranges do.
Lead vehicle: per frame, the ground-truth box whose bottom-centre is nearest the
image's bottom-centre; recall = frames whose lead box is matched; precision = frames
whose predicted lead (the prediction nearest the bottom-centre) overlaps the true lead
at IoU >= 0.5 / frames with a prediction. The lead by size ("lead>=32px", "lead>=64px";
the near leads a collision warning is about, where the plain lead row also counts far specks):
recall over the frames whose true lead is at least S px wide, precision over the frames
whose predicted lead is (right when it overlaps the true lead, of any width, at IoU >= 0.5).
COCO AP50: pycocotools COCOeval (bbox, iouThrs = [0.5], all areas, maxDets 100);
predictions without a score get score 1.0 (then AP50 is precision x recall on one
operating point, as COCO interpolates it).
"""
from __future__ import annotations

import contextlib
import io
from dataclasses import dataclass, field

import numpy as np

IOU_MIN = 0.5
SIZE_CLASSES = (0, 32, 64)
LEAD_SIZES = (32, 64)

__all__ = ["FrameBoxes", "BoxScores", "load_gt", "load_pred", "pair_frames", "score",
           "format_scores", "box_iou_matrix", "lead_index", "errors", "error_sheet", "lead_errors", "lead_sheet"]


@dataclass
class FrameBoxes:
    file: str
    boxes: np.ndarray                 # (N, 4) float, inclusive [l, t, r, b]
    scores: np.ndarray | None = None  # (N,) or None


@dataclass
class BoxScores:
    frames: int
    unscored_gt_frames: int
    classes: dict = field(default_factory=dict)   # "all"/">=32px"/">=64px" -> dict
    lead: dict = field(default_factory=dict)
    ap50: float = float("nan")
    lead_by_size: dict = field(default_factory=dict)   # "lead>=32px"/"lead>=64px" -> dict as lead

    def as_dict(self) -> dict:
        return {"frames": self.frames, "unscored_gt_frames": self.unscored_gt_frames,
                "classes": self.classes, "lead": self.lead, "coco_ap50": self.ap50,
                "lead_by_size": self.lead_by_size}


# ------------------------------------------------------------------------ loading
def _box_array(boxes, what: str) -> tuple[np.ndarray, np.ndarray | None]:
    rows, scores = [], []
    for k, b in enumerate(boxes):
        if isinstance(b, dict):
            try:
                vals = [float(b[n]) for n in ("left", "top", "right", "bottom")]
            except (KeyError, TypeError, ValueError):
                raise ValueError(f"{what}: box {k} needs numeric left, top, right, bottom") from None
            sc = None
        else:
            if not isinstance(b, (list, tuple)) or len(b) not in (4, 5):
                raise ValueError(f"{what}: box {k} must be [left, top, right, bottom(, score)], got {b!r}")
            try:
                vals = [float(v) for v in b]
            except (TypeError, ValueError):
                raise ValueError(f"{what}: box {k} has a non-numeric value: {b!r}") from None
            sc = vals[4] if len(vals) == 5 else None
            vals = vals[:4]
        if not all(np.isfinite(vals)) or (sc is not None and not np.isfinite(sc)):
            raise ValueError(f"{what}: box {k} has a non-finite value")
        if vals[2] < vals[0] or vals[3] < vals[1]:
            raise ValueError(f"{what}: box {k} has right < left or bottom < top: {vals}")
        rows.append(vals)
        scores.append(sc)
    arr = np.asarray(rows, np.float64).reshape(-1, 4)
    if any(s is None for s in scores):
        if any(s is not None for s in scores):
            raise ValueError(f"{what}: some boxes carry a score and some do not")
        return arr, None
    return arr, np.asarray(scores, np.float64)


def load_gt(data) -> list[FrameBoxes]:
    """Ground truth (tusimple-vehicles-dev annotation.json, parsed) -> [FrameBoxes]."""
    if not isinstance(data, list):
        raise ValueError("gt: expected a JSON list of {file_name, bbox} entries")
    out = []
    for i, e in enumerate(data):
        if not isinstance(e, dict) or "file_name" not in e or "bbox" not in e:
            raise ValueError(f"gt: entry {i} needs 'file_name' and 'bbox'")
        boxes, _ = _box_array(e["bbox"], f"gt {e['file_name']}")
        out.append(FrameBoxes(str(e["file_name"]), boxes))
    return out


def load_pred(data) -> list[FrameBoxes]:
    """Predictions (detect --json, parsed) -> [FrameBoxes]."""
    if not isinstance(data, list):
        raise ValueError("pred: expected a JSON list of {frame, file, boxes} entries")
    out = []
    for i, e in enumerate(data):
        if not isinstance(e, dict) or "file" not in e or "boxes" not in e:
            raise ValueError(f"pred: entry {i} needs 'file' and 'boxes'")
        boxes, scores = _box_array(e["boxes"], f"pred {e['file']}")
        out.append(FrameBoxes(str(e["file"]), boxes, scores))
    return out


def _norm(p: str) -> str:
    return "/" + p.replace("\\", "/").lstrip("./")


def pair_frames(gt: list[FrameBoxes], pred: list[FrameBoxes]):
    """[(gt frame, pred frame)] for every prediction entry, and the number of ground-truth
    frames without one. A prediction whose file matches no (or two) gt frames: ValueError."""
    by_name = {}
    for g in gt:
        by_name.setdefault(_norm(g.file).rsplit("/", 1)[-1], []).append(g)
    pairs, used = [], set()
    for p in pred:
        pn = _norm(p.file)
        same = by_name.get(pn.rsplit("/", 1)[-1], [])
        cands = [g for g in same if pn.endswith(_norm(g.file))] or same
        if len(cands) != 1:
            raise ValueError(f"pred: file {p.file!r} matches {len(cands)} ground-truth frames "
                             "(expected exactly one: same file name, or a path ending with the gt "
                             "file_name when names repeat)")
        if id(cands[0]) in used:
            raise ValueError(f"pred: two entries for ground-truth frame {cands[0].file!r}")
        used.add(id(cands[0]))
        pairs.append((cands[0], p))
    return pairs, len(gt) - len(used)


# ------------------------------------------------------------------------ scoring
def box_iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of inclusive boxes a (N, 4) x b (M, 4)."""
    a = np.asarray(a, np.float64).reshape(-1, 4)
    b = np.asarray(b, np.float64).reshape(-1, 4)
    iw = np.minimum(a[:, None, 2], b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0]) + 1
    ih = np.minimum(a[:, None, 3], b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1]) + 1
    inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
    area_a = (a[:, 2] - a[:, 0] + 1) * (a[:, 3] - a[:, 1] + 1)
    area_b = (b[:, 2] - b[:, 0] + 1) * (b[:, 3] - b[:, 1] + 1)
    union = area_a[:, None] + area_b[None, :] - inter
    return np.where(union > 0, inter / np.maximum(union, 1e-12), 0.0)


def _match(gt: np.ndarray, pred: np.ndarray, scores: np.ndarray | None) -> np.ndarray:
    """For each prediction, the index of the gt box it matched, or -1."""
    out = np.full(len(pred), -1, np.int64)
    if len(pred) == 0 or len(gt) == 0:
        return out
    iou = box_iou_matrix(pred, gt)
    order = np.argsort(-scores, kind="stable") if scores is not None else np.arange(len(pred))
    taken = np.zeros(len(gt), bool)
    for i in order:
        cand = np.where(taken, -1.0, iou[i])
        j = int(np.argmax(cand))
        if cand[j] >= IOU_MIN:
            out[i] = j
            taken[j] = True
    return out


def lead_index(boxes: np.ndarray, width: float, height: float) -> int:
    """The box whose bottom-centre is nearest (width/2, height) (ties: first), -1 if none."""
    if len(boxes) == 0:
        return -1
    cx = (boxes[:, 0] + boxes[:, 2]) / 2
    d = (cx - width / 2) ** 2 + (boxes[:, 3] - height) ** 2
    return int(np.argmin(d))


def _widths(b: np.ndarray) -> np.ndarray:
    return b[:, 2] - b[:, 0] + 1


def _coco_ap50(pairs) -> float:
    from pycocotools.coco import COCO
    from pycocotools.cocoeval import COCOeval
    images, anns, dets = [], [], []
    for k, (g, p) in enumerate(pairs):
        images.append({"id": k + 1})
        for b in g.boxes:
            w, h = b[2] - b[0] + 1, b[3] - b[1] + 1
            anns.append({"id": len(anns) + 1, "image_id": k + 1, "category_id": 1,
                         "bbox": [b[0], b[1], w, h], "area": w * h, "iscrowd": 0})
        for i, b in enumerate(p.boxes):
            w, h = b[2] - b[0] + 1, b[3] - b[1] + 1
            dets.append({"image_id": k + 1, "category_id": 1, "bbox": [b[0], b[1], w, h],
                         "score": float(p.scores[i]) if p.scores is not None else 1.0})
    if not anns:
        return float("nan")
    with contextlib.redirect_stdout(io.StringIO()):
        coco = COCO()
        coco.dataset = {"images": images, "annotations": anns,
                        "categories": [{"id": 1, "name": "vehicle"}]}
        coco.createIndex()
        if not dets:
            return 0.0
        res = coco.loadRes(dets)
        ev = COCOeval(coco, res, "bbox")
        ev.params.iouThrs = np.array([IOU_MIN])
        ev.evaluate()
        ev.accumulate()
        ev.summarize()
    return float(ev.stats[0])   # AP over iouThrs = [0.5], area all, maxDets 100


def score(gt: list[FrameBoxes], pred: list[FrameBoxes], image_size=(1280, 720)) -> BoxScores:
    """Score predictions against ground truth (see the module doc). image_size (w, h)
    places the bottom-centre for the lead vehicle."""
    w_img, h_img = (float(v) for v in image_size)
    if not (w_img > 0 and h_img > 0):
        raise ValueError(f"image_size: expected positive (width, height), got {image_size!r}")
    pairs, unscored = pair_frames(gt, pred)
    counts = {s: [0, 0, 0, 0] for s in SIZE_CLASSES}   # gt, gt matched, pred TP, pred FP
    lead = [0, 0, 0, 0]   # frames with a gt lead, matched; frames with a pred lead, correct
    lead_s = {s: [0, 0, 0, 0] for s in LEAD_SIZES}   # the same, leads of width >= s
    for g, p in pairs:
        m = _match(g.boxes, p.boxes, p.scores)
        gw, pw = _widths(g.boxes), _widths(p.boxes)
        matched_gt = np.zeros(len(g.boxes), bool)
        matched_gt[m[m >= 0]] = True
        for s in SIZE_CLASSES:
            c = counts[s]
            c[0] += int((gw >= s).sum())
            c[1] += int((matched_gt & (gw >= s)).sum())
            c[2] += int(sum(1 for j in m if j >= 0 and gw[j] >= s))
            c[3] += int(((m < 0) & (pw >= s)).sum())
        gl = lead_index(g.boxes, w_img, h_img)
        if gl >= 0:
            lead[0] += 1
            lead[1] += int(matched_gt[gl])
            for s in LEAD_SIZES:
                if gw[gl] >= s:
                    lead_s[s][0] += 1
                    lead_s[s][1] += int(matched_gt[gl])
        pl = lead_index(p.boxes, w_img, h_img)
        if pl >= 0:
            right = gl >= 0 and box_iou_matrix(p.boxes[pl], g.boxes[gl])[0, 0] >= IOU_MIN
            lead[2] += 1
            lead[3] += int(right)
            for s in LEAD_SIZES:
                if pw[pl] >= s:
                    lead_s[s][2] += 1
                    lead_s[s][3] += int(right)

    def ratio(a, b):
        return a / b if b else float("nan")

    out = BoxScores(len(pairs), unscored)
    for s in SIZE_CLASSES:
        n_gt, tp_gt, tp, fp = counts[s]
        name = "all" if s == 0 else f">={s}px"
        out.classes[name] = {"gt": n_gt, "recall": ratio(tp_gt, n_gt), "pred": tp + fp,
                             "precision": ratio(tp, tp + fp)}
    out.lead = {"frames": lead[0], "recall": ratio(lead[1], lead[0]),
                "pred_frames": lead[2], "precision": ratio(lead[3], lead[2])}
    for s, (n, tp, npred, ok) in lead_s.items():
        out.lead_by_size[f"lead>={s}px"] = {"frames": n, "recall": ratio(tp, n), "pred_frames": npred,
                                            "precision": ratio(ok, npred)}
    out.ap50 = _coco_ap50(pairs) if pairs else float("nan")
    return out


def format_scores(s: BoxScores) -> str:
    def pct(v):
        return "   n/a" if v != v else f"{100 * v:5.1f}%"
    lines = [f"frames scored: {s.frames}" + (f" (ground-truth frames without a prediction entry, "
                                             f"not scored: {s.unscored_gt_frames})"
                                             if s.unscored_gt_frames else ""),
             f"{'vehicles':<12} {'gt':>6} {'recall':>7} {'pred':>6} {'precision':>9}   (IoU >= 0.5)"]
    for name, c in s.classes.items():
        lines.append(f"{name:<12} {c['gt']:>6} {pct(c['recall']):>7} {c['pred']:>6} {pct(c['precision']):>9}")
    for name, ld in [("lead", s.lead)] + list(s.lead_by_size.items()):
        lines.append(f"{name:<12} {ld['frames']:>6} {pct(ld['recall']):>7} {ld['pred_frames']:>6} "
                     f"{pct(ld['precision']):>9}")
    lines.append(f"COCO AP50 (pycocotools): {pct(s.ap50)}")
    return "\n".join(lines)


# ------------------------------------------------------------------------ what went wrong
def errors(gt: list[FrameBoxes], pred: list[FrameBoxes], min_w: float = 32) -> list[dict]:
    """The boxes behind score()'s size class "width >= min_w", matched by the same rule: each
    ground-truth box of that width left unmatched ({"kind": "missed", ...}, `iou` its best
    IoU with any prediction) and each unmatched prediction of that width ({"kind": "false",
    ...}, `iou` its best IoU with any ground-truth box, `score` its score or None); every
    entry names the ground-truth `file` and its `box` [l, t, r, b]. Misses first, in frame
    order. Their counts are that class's gt - matched and false positives."""
    pairs, _ = pair_frames(gt, pred)
    missed, false = [], []
    for g, p in pairs:
        m = _match(g.boxes, p.boxes, p.scores)
        iou = box_iou_matrix(g.boxes, p.boxes)
        matched = np.zeros(len(g.boxes), bool)
        matched[m[m >= 0]] = True
        for j in np.nonzero(~matched & (_widths(g.boxes) >= min_w))[0]:
            missed.append({"kind": "missed", "file": g.file, "box": g.boxes[j].tolist(),
                           "iou": float(iou[j].max()) if len(p.boxes) else 0.0, "score": None})
        for i in np.nonzero((m < 0) & (_widths(p.boxes) >= min_w))[0]:
            false.append({"kind": "false", "file": g.file, "box": p.boxes[i].tolist(),
                          "iou": float(iou[:, i].max()) if len(g.boxes) else 0.0,
                          "score": None if p.scores is None else float(p.scores[i])})
    return missed + false


def error_sheet(errs: list[dict], load_image, tile=(160, 120), cols: int = 8, per_kind: int = 120) -> np.ndarray:
    """A contact sheet (BGR uint8) of errors() entries, for a person to look at: a band per
    kind ("missed" in red, "false" in orange) with up to per_kind tiles, each the box with a
    quarter of its size of context around it, scaled to fit the tile, labelled with its
    width x height, file and IoU (and score). load_image(file) returns the frame (gray or
    BGR) or raises; a frame is read once."""
    import cv2  # noqa: PLC0415  (drawing only)
    tw, th = int(tile[0]), int(tile[1])
    if tw < 40 or th < 40 or cols < 1 or per_kind < 1:
        raise ValueError(f"error_sheet: tile {tile} (>= 40x40), cols {cols}, per_kind {per_kind} (>= 1)")
    colour = {"missed": (0, 0, 255), "false": (0, 140, 255)}
    cache: dict = {}
    bands = []
    for kind in ("missed", "false"):
        ent = [e for e in errs if e["kind"] == kind]
        head = np.zeros((24, cols * tw, 3), np.uint8)
        what = "missed vehicles" if kind == "missed" else "false boxes"
        shown = f" (first {per_kind} shown)" if len(ent) > per_kind else ""
        cv2.putText(head, f"{what}: {len(ent)}{shown}", (6, 17), cv2.FONT_HERSHEY_SIMPLEX, 0.55, colour[kind], 1)
        tiles = []
        for e in ent[:per_kind]:
            if e["file"] not in cache:
                img = load_image(e["file"])
                cache[e["file"]] = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR) if img.ndim == 2 else img
            img = cache[e["file"]]
            h, w = img.shape[:2]
            l, t, r, b = (int(round(v)) for v in e["box"])
            bw, bh = r - l + 1, b - t + 1
            x0, y0 = max(0, l - bw // 4), max(0, t - bh // 4)
            x1, y1 = min(w, r + 1 + bw // 4), min(h, b + 1 + bh // 4)
            t_img = np.zeros((th, tw, 3), np.uint8)
            if x1 > x0 and y1 > y0:
                crop = img[y0:y1, x0:x1].copy()
                cv2.rectangle(crop, (l - x0, t - y0), (r - x0, b - y0), colour[kind], 1)
                k = min(tw / crop.shape[1], (th - 28) / crop.shape[0])
                crop = cv2.resize(crop, (max(1, int(crop.shape[1] * k)), max(1, int(crop.shape[0] * k))),
                                  interpolation=cv2.INTER_AREA if k < 1 else cv2.INTER_LINEAR)
                t_img[14:14 + crop.shape[0], :crop.shape[1]] = crop
            name = str(e["file"]).replace("\\", "/").rsplit("/", 1)[-1]
            cv2.putText(t_img, f"{bw}x{bh} {name}", (2, 10), cv2.FONT_HERSHEY_SIMPLEX, 0.33, (255, 255, 255), 1)
            sc = "" if e["score"] is None else f" s {e['score']:.2f}"
            cv2.putText(t_img, f"IoU {e['iou']:.2f}{sc}", (2, th - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.33,
                        colour[kind], 1)
            tiles.append(t_img)
        rows = [np.hstack(tiles[i:i + cols] + [np.zeros((th, tw, 3), np.uint8)] * (cols - len(tiles[i:i + cols])))
                for i in range(0, len(tiles), cols)]
        bands += [head] + rows
    return np.vstack(bands)


def lead_errors(gt: list[FrameBoxes], pred: list[FrameBoxes], image_size=(1280, 720), min_w: float = 32) -> list[dict]:
    """The frames behind score()'s "lead>=<min_w>px" row that went wrong, in frame order: the
    true lead is at least min_w px wide and not matched ("missed" in `kinds`), and/or the
    predicted lead is at least min_w px wide and does not overlap the true lead at IoU >= 0.5
    ("wrong"). Each entry: file, kinds, gt_lead and pred_lead ([l, t, r, b] or None), the
    IoU of the two (0 when either is missing), the predicted lead's score (or None), and the
    frame's boxes (gt, pred) for drawing. The "missed" count is that row's frames minus its
    matched ones, the "wrong" count its pred_frames minus its right ones."""
    w_img, h_img = (float(v) for v in image_size)
    pairs, _ = pair_frames(gt, pred)
    out = []
    for g, p in pairs:
        m = _match(g.boxes, p.boxes, p.scores)
        matched = np.zeros(len(g.boxes), bool)
        matched[m[m >= 0]] = True
        gl, pl = lead_index(g.boxes, w_img, h_img), lead_index(p.boxes, w_img, h_img)
        iou = float(box_iou_matrix(p.boxes[pl], g.boxes[gl])[0, 0]) if gl >= 0 and pl >= 0 else 0.0
        kinds = []
        if gl >= 0 and _widths(g.boxes)[gl] >= min_w and not matched[gl]:
            kinds.append("missed")
        if pl >= 0 and _widths(p.boxes)[pl] >= min_w and not iou >= IOU_MIN:
            kinds.append("wrong")
        if kinds:
            out.append({"file": g.file, "kinds": kinds, "iou": iou,
                        "gt_lead": g.boxes[gl].tolist() if gl >= 0 else None,
                        "pred_lead": p.boxes[pl].tolist() if pl >= 0 else None,
                        "score": None if pl < 0 or p.scores is None else float(p.scores[pl]),
                        "gt": g.boxes.tolist(), "pred": p.boxes.tolist()})
    return out


def lead_sheet(entries: list[dict], load_image, tile=(480, 270), cols: int = 3, most: int = 60) -> np.ndarray:
    """A contact sheet (BGR uint8) of lead_errors() entries, whole frames scaled to `tile`, for
    a person to look at where the lead went wrong and what else was there: every labelled box
    thin green, the true lead thick green, every predicted box thin orange, the predicted lead
    thick red; captioned with the file, what went wrong, the IoU of the two leads and the
    predicted lead's score. load_image(file) returns the frame (gray or BGR) or raises."""
    import cv2  # noqa: PLC0415  (drawing only)
    tw, th = int(tile[0]), int(tile[1])
    if tw < 80 or th < 60 or cols < 1 or most < 1:
        raise ValueError(f"lead_sheet: tile {tile} (>= 80x60), cols {cols}, most {most} (>= 1)")
    head = np.zeros((24, cols * tw, 3), np.uint8)
    shown = f" (first {most} shown)" if len(entries) > most else ""
    cv2.putText(head, f"frames with a missed or wrong near lead: {len(entries)}{shown}  "
                "(green: labels, thick: the lead; orange: found, red: the found lead)", (6, 17),
                cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1)
    tiles = []
    for e in entries[:most]:
        img = load_image(e["file"])
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR) if img.ndim == 2 else img.copy()
        k = min(tw / img.shape[1], th / img.shape[0])

        def rect(b, colour, thick):
            l, t, r, bt = (int(round(v * k)) for v in b)
            cv2.rectangle(small, (l, t), (r, bt), colour, thick)
        small = cv2.resize(img, (max(1, int(img.shape[1] * k)), max(1, int(img.shape[0] * k))),
                           interpolation=cv2.INTER_AREA)
        for b in e["gt"]:
            rect(b, (0, 160, 0), 1)
        for b in e["pred"]:
            rect(b, (0, 140, 255), 1)
        if e["gt_lead"] is not None:
            rect(e["gt_lead"], (0, 255, 0), 2)
        if e["pred_lead"] is not None:
            rect(e["pred_lead"], (0, 0, 255), 2)
        t_img = np.zeros((th, tw, 3), np.uint8)
        t_img[:small.shape[0], :small.shape[1]] = small
        name = str(e["file"]).replace("\\", "/").rsplit("/", 1)[-1]
        sc = "" if e["score"] is None else f" s {e['score']:.2f}"
        cv2.putText(t_img, f"{name} {'+'.join(e['kinds'])} IoU {e['iou']:.2f}{sc}", (4, 14),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 255, 255), 1)
        tiles.append(t_img)
    rows = [np.hstack(tiles[i:i + cols] + [np.zeros((th, tw, 3), np.uint8)] * (cols - len(tiles[i:i + cols])))
            for i in range(0, len(tiles), cols)]
    return np.vstack([head] + rows)
