"""Training of the vehicle / non-vehicle classifier (HOG or GIST + linear SVM).

Data, split and features:
  - crop folders (gti-vehicles): every folder sorted by file number, blocks of 40
    consecutive files, every 5th block TEST (pyvehtrack.datasets.gti_split);
  - frames with boxes (tusimple-vehicles-dev): frames split by file number
    (pyvehtrack.datasets.tusimple_split); positives are squares around boxes
    >= 24 px wide, negatives random squares that do not overlap a box;
  - every crop is gray, resampled to the window by integer area means (the C
    core's vt_resample_area, equal to the oracle's); float features come from the
    oracle (pyvehtrack.reference.classify), C features from the C core.
The float model is sklearn's LinearSVC on (standardised) oracle features; the
standardisation is folded into the weights, which are then quantised to int16
with the largest power-of-two scale that fits (vt_svm_model).
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from . import _check
from .datasets import GTI_BLOCK, GTI_TEST_EVERY, _last_number, gti_sorted, gti_split, tusimple_split

KINDS = {"hog": 1, "gist": 2}
IMG_EXT = {".png", ".jpg", ".jpeg", ".bmp", ".ppm", ".pgm", ".tif", ".tiff"}


def read_gray(path) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise ValueError(f"cannot read image {str(path)!r}")
    if img.dtype != np.uint8:
        raise ValueError(f"{str(path)!r}: expected an 8-bit image, got {img.dtype}")
    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2GRAY if img.shape[2] == 4 else cv2.COLOR_BGR2GRAY)
    return np.ascontiguousarray(img)


@dataclass
class Crops:
    """Gray crops already resampled to the window, with labels and the split."""
    images: list = field(default_factory=list)   # (h, w) uint8 each
    labels: list = field(default_factory=list)   # 1 vehicle, 0 not
    fold: list = field(default_factory=list)     # 0 = TEST, 1..4 = TRAIN (1 also inner validation)
    source: list = field(default_factory=list)   # "gti" / "tusimple"

    def add(self, img, label, fold, source):
        self.images.append(img)
        self.labels.append(int(label))
        self.fold.append(int(fold))
        self.source.append(source)

    def select(self, split=None, source=None, folds=None) -> np.ndarray:
        m = np.ones(len(self.labels), bool)
        f = np.array(self.fold)
        if split == "test":
            m &= f == 0
        elif split == "train":
            m &= f != 0
        if folds is not None:
            m &= np.isin(f, list(folds))
        if source is not None:
            m &= np.array([s == source for s in self.source])
        return np.flatnonzero(m)


def _resample(img: np.ndarray, box, win_w: int, win_h: int) -> np.ndarray:
    from . import _native as N
    return N.resample_area(img, box, win_w, win_h)


def add_crop_folders(crops: Crops, folders, label: int, win_w: int, win_h: int, progress=None):
    for d in folders:
        d = Path(d)
        if not d.is_dir():
            raise ValueError(f"{'--vehicles' if label else '--non-vehicles'}: {str(d)!r} is not a folder")
        subdirs = sorted(p for p in d.iterdir() if p.is_dir())
        groups = subdirs if subdirs else [d]
        for g in groups:
            files = [p for p in gti_sorted(g) if p.suffix.lower() in IMG_EXT]
            for i, p in enumerate(files):
                img = read_gray(p)
                h, w = img.shape
                assert (gti_split(i) == "test") == ((i // GTI_BLOCK) % GTI_TEST_EVERY == 0)
                crops.add(_resample(img, (0, 0, w - 1, h - 1), win_w, win_h), label,
                          (i // GTI_BLOCK) % GTI_TEST_EVERY, "gti")
                if progress:
                    progress()


def square_around(box, fw: int, fh: int, grow: float = 1.0):
    """The square of side max(w, h) * grow centred on box, shifted inside the frame."""
    left, top, right, bottom = box
    side = int(round(max(right - left + 1, bottom - top + 1) * grow))
    side = max(8, min(side, fw, fh))
    cx, cy = (left + right) / 2, (top + bottom) / 2
    x0 = int(round(cx - side / 2))
    y0 = int(round(cy - side / 2))
    x0 = min(max(x0, 0), fw - side)
    y0 = min(max(y0, 0), fh - side)
    return (x0, y0, x0 + side - 1, y0 + side - 1)


def load_annotation(path):
    with open(path) as f:
        ann = json.load(f)
    if not isinstance(ann, list):
        raise ValueError(f"--frames-json: expected a JSON list of frames, got {type(ann).__name__}")
    out = []
    for e in ann:
        boxes = [(b["left"], b["top"], b["right"], b["bottom"]) for b in e.get("bbox", [])]
        out.append((e["file_name"], np.array(boxes, float).reshape(-1, 4)))
    return out


def _overlap_frac(cand, boxes) -> float:
    if len(boxes) == 0:
        return 0.0
    x0, y0, x1, y1 = cand
    ix = np.clip(np.minimum(x1, boxes[:, 2]) - np.maximum(x0, boxes[:, 0]) + 1, 0, None)
    iy = np.clip(np.minimum(y1, boxes[:, 3]) - np.maximum(y0, boxes[:, 1]) + 1, 0, None)
    return float((ix * iy).max() / ((x1 - x0 + 1) * (y1 - y0 + 1)))


def frame_crops(frames_dir, annotation, win_w: int, win_h: int, *, min_width: int = 24,
                neg_per_frame: int = 12, seed: int = 0, progress=None):
    """Yield (frame_name, split, list of (square box, label)) with the frame's gray
    image, for the tusimple-vehicles-dev layout (annotation file names relative to
    frames_dir's parent or to frames_dir)."""
    rng = np.random.default_rng(seed)
    frames_dir = Path(frames_dir)
    for name, boxes in load_annotation(annotation):
        p = frames_dir / name
        if not p.exists():
            p = frames_dir / Path(name).name
        img = read_gray(p)
        fh, fw = img.shape
        items = []
        for b in boxes:
            if b[2] - b[0] + 1 < min_width:
                continue
            bb = [int(round(v)) for v in b]
            bb = [max(0, bb[0]), max(0, bb[1]), min(fw - 1, bb[2]), min(fh - 1, bb[3])]
            items.append((square_around(bb, fw, fh), 1))
        n = 0
        tries = 0
        while n < neg_per_frame and tries < 200:
            tries += 1
            side = int(np.exp(rng.uniform(np.log(24), np.log(240))))
            x0 = int(rng.integers(0, fw - side))
            y0 = int(rng.integers(int(fh * 0.3), min(fh - side, int(fh * 0.92))) if fh - side > fh * 0.3 else 0)
            cand = (x0, y0, x0 + side - 1, y0 + side - 1)
            if _overlap_frac(cand, boxes) > 0.1:
                continue
            items.append((cand, 0))
            n += 1
        if progress:
            progress()
        fold = (_last_number(name) // 10) % 5
        assert (fold == 0) == (tusimple_split(name) == "test")
        yield name, fold, img, items


def add_frames(crops: Crops, frames_dir, annotation, win_w: int, win_h: int, progress=None,
               boxes_out=None):
    for name, fold, img, items in frame_crops(frames_dir, annotation, win_w, win_h, progress=progress):
        for box, label in items:
            crops.add(_resample(img, box, win_w, win_h), label, fold, "tusimple")


# ---------------------------------------------------------------- features and model
def float_features(kind: str, images, progress=None) -> np.ndarray:
    from .reference import classify as R   # training runs on the float descriptors
    out = []
    for im in images:
        out.append(R.descriptor(kind, im))
        if progress:
            progress()
    return np.array(out)


def c_features(kind: str, images, win_w: int, win_h: int) -> np.ndarray:
    """Q15 descriptors from the C core (uint16)."""
    from . import _native as N
    ws = N.hog_ws_new() if kind == "hog" else N.gist_ws_new()
    out = []
    for im in images:
        if kind == "hog":
            N.hog_prepare(ws, im)
            out.append(N.hog_descriptor(ws, 0, 0, win_w, win_h))
        else:
            N.gist_prepare(ws, im)
            out.append(N.gist_descriptor(ws, 0, 0, win_w, win_h))
    return np.array(out)


def quantise(w: np.ndarray, b: float) -> tuple[np.ndarray, int, int]:
    """int16 weights with the largest power-of-two scale (1..30) that fits, Q16 bias."""
    m = float(np.abs(w).max()) if w.size else 0.0
    shift = 30
    while shift > 1 and m * 2 ** shift > 32767:
        shift -= 1
    wq = np.clip(np.rint(w * 2 ** shift), -32768, 32767).astype(np.int16)
    bq = int(np.clip(np.rint(b * 65536), -2 ** 31, 2 ** 31 - 1))
    return wq, shift, bq


def _shift_for(m: float) -> int:
    shift = 30
    while shift > 1 and m * 2 ** shift > 32767:
        shift -= 1
    return shift


def fit_mlp(X: np.ndarray, y: np.ndarray, hidden: int, alpha: float = 1e-3, max_iter: int = 120,
            seed: int = 0, standardise: bool = False):
    """sklearn MLPClassifier, one ReLU layer; fixed iterations (no early stopping on a
    random part of TRAIN: neighbouring crops are near-duplicates). The standardisation,
    if any, is folded into the first layer. Returns w1 (hidden x dim), b1, w2, b2."""
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPClassifier
    mu, sd = np.zeros(X.shape[1]), np.ones(X.shape[1])
    if standardise:
        mu, sd = X.mean(axis=0), np.maximum(X.std(axis=0), 1e-6)
    clf = MLPClassifier((hidden,), alpha=alpha, max_iter=max_iter, random_state=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        clf.fit((X - mu) / sd, y)
    w1 = clf.coefs_[0].T / sd
    b1 = clf.intercepts_[0] - w1 @ mu
    return w1, b1, clf.coefs_[1].ravel().copy(), float(clf.intercepts_[1][0])


def mlp_dict(kind, win_w, win_h, w1, b1, w2, b2, info) -> dict:
    s1 = _shift_for(float(np.abs(w1).max()))
    s2 = _shift_for(float(np.abs(w2).max()))
    q = lambda v, s: np.clip(np.rint(v * 2 ** s), -32768, 32767).astype(np.int16)  # noqa: E731
    q16 = lambda v: np.clip(np.rint(np.asarray(v) * 65536), -2 ** 31, 2 ** 31 - 1).astype(np.int64)  # noqa: E731
    return {"model_type": "mlp", "kind": kind, "kind_code": KINDS[kind], "win_w": win_w, "win_h": win_h,
            "hidden": int(w1.shape[0]), "w1": w1, "b1": b1, "w2": w2, "b2": float(b2),
            "w1_q": q(w1, s1), "w1_shift": s1, "b1_q16": q16(b1).astype(np.int32), "w2_q": q(w2, s2),
            "w2_shift": s2, "b2_q16": int(q16(b2)), "threshold_q16": 0, "info": json.dumps(info)}


def fit_svm(X: np.ndarray, y: np.ndarray, C: float, standardise: bool, sample_weight=None):
    from sklearn.svm import LinearSVC
    if standardise:
        mu = X.mean(axis=0)
        sd = X.std(axis=0)
        sd[sd < 1e-6] = 1e-6
    else:
        mu = np.zeros(X.shape[1])
        sd = np.ones(X.shape[1])
    clf = LinearSVC(C=C, max_iter=20000, dual=True, random_state=0)
    clf.fit((X - mu) / sd, y, sample_weight=sample_weight)
    w = clf.coef_.ravel() / sd
    b = float(clf.intercept_[0] - np.sum(clf.coef_.ravel() * mu / sd))
    return w, b


def model_dict(kind, win_w, win_h, w, b, C, info) -> dict:
    wq, shift, bq = quantise(w, b)
    return {"model_type": "svm", "kind": kind, "kind_code": KINDS[kind], "win_w": win_w, "win_h": win_h,
            "w": w.astype(np.float64), "b": float(b), "w_q": wq, "w_shift": shift,
            "bias_q16": bq, "threshold_q16": 0, "C": C, "info": json.dumps(info)}


def save_model(path, d: dict) -> None:
    np.savez(path, **{k: np.asarray(v) for k, v in d.items()})


def load_model(path) -> dict:
    if os.path.isfile(path):
        _check.npz_file(path, "--model")
    try:
        z = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as e:
        raise ValueError(f"--model: cannot read {str(path)!r} as a model .npz ({e})") from e
    mtype = str(z["model_type"]) if "model_type" in z.files else "svm"
    need = {"kind", "win_w", "win_h", "threshold_q16"} | (
        {"w", "b", "w_q", "w_shift", "bias_q16"} if mtype == "svm" else
        {"w1", "b1", "w2", "b2", "w1_q", "w1_shift", "b1_q16", "w2_q", "w2_shift", "b2_q16"})
    missing = need - set(z.files)
    if missing:
        raise ValueError(f"--model: {str(path)!r} is not a pyvehtrack model (missing {sorted(missing)})")
    d = {k: z[k] for k in z.files}
    d["model_type"] = mtype
    d["kind"] = str(d["kind"])
    for k in ("win_w", "win_h", "w_shift", "bias_q16", "threshold_q16", "w1_shift", "w2_shift", "b2_q16"):
        if k in d:
            d[k] = int(d[k])
    for k in ("b", "b2"):
        if k in d:
            d[k] = float(d[k])
    return d


def c_model(d: dict):
    """(vt_svm_model or vt_mlp_model, keepalive) for a model dict."""
    from . import _native as N
    if d.get("model_type", "svm") == "mlp":
        return N.mlp_model(KINDS[d["kind"]], d["win_w"], d["win_h"], d["w1_q"], d["w1_shift"], d["b1_q16"],
                           d["w2_q"], d["w2_shift"], d["b2_q16"], d["threshold_q16"])
    return N.svm_model(KINDS[d["kind"]], d["win_w"], d["win_h"], d["w_q"], d["w_shift"],
                       d["bias_q16"], d["threshold_q16"])


def float_scores(d: dict, X: np.ndarray) -> np.ndarray:
    if d.get("model_type", "svm") == "mlp":
        from .reference import classify as R
        return R.mlp_decision(d["w1"], d["b1"], d["w2"], d["b2"], X)
    return np.asarray(X, float) @ d["w"] + d["b"]


def c_scores(d: dict, Xc: np.ndarray) -> np.ndarray:
    """C decisions (float, from Q16) of C descriptors."""
    from . import _native as N
    m, keep = c_model(d)
    fn = N.mlp_decision if d.get("model_type", "svm") == "mlp" else N.svm_decision
    return np.array([fn(m, x) for x in Xc], float) / 65536.0


# ---------------------------------------------------------------- the whole run
C_GRID = (0.01, 0.03, 0.1)
HIDDEN_GRID = (16, 32, 64)


def parse_hidden(text: str) -> int | None:
    """A --hidden value: an integer 1..64, or 'auto' (None: chosen on the inner fold)."""
    if text == "auto":
        return None
    try:
        hidden = int(text)
    except ValueError:
        raise ValueError(f"--hidden: expected an integer in 1..64 or 'auto', got {text!r}") from None
    if not 1 <= hidden <= 64:
        raise ValueError(f"--hidden: must be in 1..64, got {hidden}")
    return hidden


def evaluate(d: dict, X: np.ndarray, Xc: np.ndarray, y: np.ndarray, src: np.ndarray, sel: np.ndarray) -> dict:
    """Float and C accuracy on the rows `sel`, per source, and the sign agreement."""
    sf = float_scores(d, X[sel])
    sc = c_scores(d, Xc[sel])
    ys, ss = y[sel], src[sel]
    out = {"n": int(sel.sum()), "sign_agreement": float(((sf >= 0) == (sc >= 0)).mean()),
           "max_abs_score_diff": float(np.abs(sf - sc).max()) if len(sf) else 0.0}
    for name in sorted(set(ss)):
        m = ss == name
        out[name] = {"n": int(m.sum()), "float_acc": float(((sf[m] >= 0) == ys[m]).mean()),
                     "c_acc": float(((sc[m] >= 0) == ys[m]).mean())}
    return out


def run(vehicles, non_vehicles, frames=None, frames_json=None, kind: str = "hog", win: int = 64,
        C: float | None = None, progress: bool = True, log=print, model_type: str = "svm",
        hidden: int | None = 16, feature_cache=None, hard_negatives: bool = False):
    """Build the crops, choose C on the inner validation fold (fold 1 of TRAIN), fit on
    all of TRAIN, quantise, and score float and C models on TEST. Returns (model dict,
    report dict). For the MLP, hidden=None chooses the hidden size among HIDDEN_GRID
    the same way (fitted on TRAIN folds 2-4, scored on fold 1), so no choice sees TEST."""
    from tqdm import tqdm

    if kind not in KINDS:
        raise ValueError(f"--descriptor: expected one of {sorted(KINDS)}, got {kind!r}")
    step = 8 if kind == "hog" else 32
    if win % step or not 16 <= win <= 128 or (kind == "gist" and win < 32):
        raise ValueError(f"--window: {win} is not a multiple of {step} in "
                         f"{step if kind == 'gist' else 16}..128 for {kind}")
    if (frames is None) != (frames_json is None):
        raise ValueError("--frames and --frames-json go together")
    crops = Crops()
    with tqdm(desc="crops", unit="img", disable=not progress, file=__import__("sys").stderr) as bar:
        add_crop_folders(crops, vehicles, 1, win, win, progress=bar.update)
        add_crop_folders(crops, non_vehicles, 0, win, win, progress=bar.update)
        if frames is not None:
            add_frames(crops, frames, frames_json, win, win, progress=bar.update)
    y = np.array(crops.labels)
    if len(set(y)) < 2:
        raise ValueError("need both vehicles and non-vehicles")
    fold = np.array(crops.fold)
    src = np.array(crops.source)
    X = None
    if feature_cache is not None and Path(feature_cache).exists():
        z = np.load(feature_cache)
        if z["X"].shape[0] == len(y) and np.array_equal(z["y"], y) and np.array_equal(z["fold"], fold):
            X = z["X"]
            log(f"  float features from {feature_cache}")
    if X is None:
        with tqdm(total=len(y), desc=f"{kind} features", unit="img", disable=not progress,
                  file=__import__("sys").stderr) as bar:
            X = float_features(kind, crops.images, progress=bar.update)
        if feature_cache is not None:
            np.savez(feature_cache, X=X, y=y, fold=fold)
    tr, te = fold != 0, fold == 0
    if len(set(y[tr])) < 2 or len(set(y[te])) < 2:
        raise ValueError(f"the grouped split leaves TRAIN with {int(y[tr].sum())} vehicles / "
                         f"{int((1 - y[tr]).sum())} non-vehicles and TEST with {int(y[te].sum())} / "
                         f"{int((1 - y[te]).sum())}: each needs both (a folder's files 0-39 are TEST, "
                         f"40-199 TRAIN, ...; give folders of more than 40 crops)")
    std = kind == "gist"
    val = {}
    if model_type == "mlp" and hidden is None:
        fit, v = tr & (fold != 1), fold == 1
        if len(set(y[fit])) < 2 or len(set(y[v])) < 2:
            raise ValueError("--hidden auto: the inner validation needs vehicles and non-vehicles both in TRAIN "
                             "fold 1 (files 40-79 of a folder, 240-279, ...) and in the other TRAIN folds; "
                             "give more crops or a fixed --hidden")
        for hsz in HIDDEN_GRID:
            w1, b1, w2, b2 = fit_mlp(X[fit], y[fit], hsz, standardise=std)
            val[f"hidden={hsz}"] = float(((np.maximum(X[v] @ w1.T + b1, 0) @ w2 + b2 >= 0) == y[v]).mean())
            log(f"  hidden={hsz}: inner-validation accuracy {val[f'hidden={hsz}']:.4f}")
        # ties: the smaller model (less flash, fewer instructions)
        hidden = max(HIDDEN_GRID, key=lambda hsz: (val[f"hidden={hsz}"], -hsz))
    if C is None and model_type == "mlp":
        C = 0.0  # unused by the MLP
    if C is None:
        fit, v = tr & (fold != 1), fold == 1
        for c in C_GRID:
            w, b = fit_svm(X[fit], y[fit], c, std)
            val[c] = float(((X[v] @ w + b >= 0) == y[v]).mean())
            log(f"  C={c}: inner-validation accuracy {val[c]:.4f}")
        C = max(val, key=val.get)
    info = {"train_crops": int(tr.sum()), "test_crops": int(te.sum()), "C": C,
            "split": "gti: blocks of 40 files, block % 5 == 0 TEST; tusimple: (NNNN // 10) % 5 == 0 TEST"}
    if model_type == "mlp":
        log(f"  fitting an MLP with {hidden} hidden units on TRAIN")
        d = mlp_dict(kind, win, win, *fit_mlp(X[tr], y[tr], hidden, standardise=std), info)
    else:
        w, b = fit_svm(X[tr], y[tr], C, std)
        d = model_dict(kind, win, win, w, b, C, info)
        if hard_negatives and frames is not None and kind == "hog":
            # One round: the model's false detections on the TRAIN frames become
            # negatives, and the SVM is fitted again with the same C.
            hn = mine_hard_negatives(frames, frames_json, d)
            hc = [_resample(img, box, win, win) for (_, _, img, box) in hn]
            log(f"  {len(hc)} hard negatives mined on TRAIN frames")
            Xh = float_features(kind, hc)
            w, b = fit_svm(np.vstack([X[tr], Xh]), np.concatenate([y[tr], np.zeros(len(hc), int)]), C, std)
            info["hard_negatives"] = len(hc)
            d = model_dict(kind, win, win, w, b, C, info)
    Xc = c_features(kind, crops.images, win, win)
    rep = {"kind": kind, "model_type": model_type, "window": win, "C": C, "validation": val,
           **({"hidden": hidden} if model_type == "mlp" else {}),
           "test": evaluate(d, X, Xc, y, src, te), "train": evaluate(d, X, Xc, y, src, tr)}
    return d, rep


# ---------------------------------------------------------------- hard negatives
def mine_hard_negatives(frames_dir, annotation, d: dict, scales=(1.0, 0.75, 0.5, 0.35),
                        per_frame: int = 10, max_overlap: float = 0.1, progress=None):
    """False detections of the linear HOG model `d` on the TRAIN frames only: every
    window position of each scale (the frame resized by `scale`, bands of
    VT_CLS_MAX_H rows scanned with vt_hog_scan), kept where the C score is >= 0 and
    at most `max_overlap` of the window covers a labelled box; the `per_frame`
    highest per frame. Returns [(frame name, frame fold, gray frame crop box)]."""
    from . import _native as N
    if d.get("model_type", "svm") != "svm" or d["kind"] != "hog":
        raise ValueError("hard negatives are mined with a linear HOG model")
    m, keep = c_model(d)
    ws = N.hog_ws_new()
    ww, wh = d["win_w"], d["win_h"]
    bh = int(N.lib.VT_CLS_MAX_H) // 8 * 8
    bw_max = int(N.lib.VT_CLS_MAX_W) // 8 * 8
    frames_dir = Path(frames_dir)
    out = []
    for name, boxes in load_annotation(annotation):
        fold = (_last_number(name) // 10) % 5
        if fold == 0:
            continue  # never look at TEST frames
        p = frames_dir / name
        img = read_gray(p if p.exists() else frames_dir / Path(name).name)
        fh, fw = img.shape
        cands = []
        for s in scales:
            sw, sh = int(fw * s) // 8 * 8, int(fh * s) // 8 * 8
            if sw < ww or sh < wh:
                continue
            im = np.ascontiguousarray(cv2.resize(img, (sw, sh), interpolation=cv2.INTER_AREA))
            for y0 in range(0, max(1, sh - wh + 1), bh - wh):
                band = im[y0:y0 + bh, :min(sw, bw_max)]
                if band.shape[0] < wh:
                    continue
                N.hog_prepare(ws, band)
                ncx, ncy = ws.cells_x - ww // 8 + 1, ws.cells_y - wh // 8 + 1
                sc = N.hog_scan(ws, m, 0, 0, ncx, ncy)
                for cy, cx in zip(*np.nonzero(sc >= 0)):
                    x0, yy0 = cx * 8 / s, (y0 + cy * 8) / s
                    box = (int(x0), int(yy0), min(fw - 1, int(x0 + ww / s) - 1), min(fh - 1, int(yy0 + wh / s) - 1))
                    if _overlap_frac(box, boxes) <= max_overlap:
                        cands.append((int(sc[cy, cx]), box))
        cands.sort(key=lambda t: -t[0])
        for _, box in cands[:per_frame]:
            out.append((name, fold, img, box))
        if progress:
            progress()
    return out
