"""The vehicle / non-vehicle classifier, friendly API.

    from pyvehtrack.classify import Classifier
    clf = Classifier()                    # the built-in default model (c/tables/svm_default.h)
    clf = Classifier("model.npz")         # a model written by `pyvehtrack train`
    clf.score([img1, img2])               # scores (float; >= threshold -> vehicle)
    clf.descriptor(img)                   # the model's descriptor (floats in [0, 1])

Images are gray (h, w) or BGR (h, w, 3) uint8 arrays of any size: each is resampled
to the model's window by integer area means (C vt_resample_area) and scored by the
C core (engine="c", fixed point) or the float oracle (engine="reference")."""
from __future__ import annotations

import cv2
import numpy as np

from . import _native as N
from .train import KINDS, c_model, load_model

_KIND_NAMES = {v: k for k, v in KINDS.items()}


def _gray(img, name: str = "image") -> np.ndarray:
    if not isinstance(img, np.ndarray):
        raise TypeError(f"{name}: expected a numpy.ndarray, got {type(img).__name__}")
    if img.dtype != np.uint8:
        raise TypeError(f"{name}: expected dtype uint8, got {img.dtype}")
    if img.ndim == 3 and img.shape[2] in (3, 4):
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2GRAY if img.shape[2] == 4 else cv2.COLOR_BGR2GRAY)
    elif img.ndim != 2:
        raise ValueError(f"{name}: expected a gray (h, w) or BGR (h, w, 3) image, got shape {img.shape}")
    if img.shape[0] < 1 or img.shape[1] < 1:
        raise ValueError(f"{name}: empty image, shape {img.shape}")
    img = np.ascontiguousarray(img)
    mw, mh = int(N.lib.VT_MAX_WIDTH), int(N.lib.VT_MAX_HEIGHT)
    if img.shape[1] > mw or img.shape[0] > mh:
        # Larger than the core takes: shrink (area means) to fit; the window is smaller anyway.
        f = min(mw / img.shape[1], mh / img.shape[0])
        img = cv2.resize(img, (max(1, int(img.shape[1] * f)), max(1, int(img.shape[0] * f))),
                         interpolation=cv2.INTER_AREA)
    return img


class Classifier:
    """A linear SVM over HOG or GIST (see pyvehtrack.train for the training)."""

    def __init__(self, model=None, engine: str = "c"):
        if engine not in ("c", "reference"):
            raise ValueError(f"engine: expected 'c' or 'reference', got {engine!r}")
        self.engine = engine
        if model is None:
            # The built-in model: the MLP if one is built in (better on the TEST split),
            # else the linear HOG SVM. Only the quantised weights are built in: the float
            # view is w_q / 2^shift.
            self._mlp = self._builtin_mlp()
            if self._mlp is not None:
                m = self._mlp
                self.model_type = "mlp"
                self._cmodel, self._keep = m, None
                self.w1 = np.frombuffer(N.ffi.buffer(m.w1, 2 * m.dim * m.hidden), np.int16).reshape(
                    m.hidden, m.dim) / 2.0 ** m.w1_shift
                self.b1 = np.frombuffer(N.ffi.buffer(m.b1_q16, 4 * m.hidden), np.int32) / 65536.0
                self.w2 = np.frombuffer(N.ffi.buffer(m.w2, 2 * m.hidden), np.int16) / 2.0 ** m.w2_shift
                self.b2 = m.b2_q16 / 65536.0
            else:
                m = N.svm_default_model(N.lib.VT_DESC_HOG)
                self.model_type = "svm"
                self._cmodel, self._keep = m, None
                wq = np.frombuffer(N.ffi.buffer(m.w, 2 * m.dim), np.int16).copy()
                self.w = wq / 2.0 ** m.w_shift
                self.b = m.bias_q16 / 65536.0
            self.kind = _KIND_NAMES[m.kind]
            self.win_w, self.win_h = int(m.win_w), int(m.win_h)
            self.threshold = m.threshold_q16 / 65536.0
        else:
            d = load_model(model)
            self.model_type = d["model_type"]
            self._cmodel, self._keep = c_model(d)
            self.kind, self.win_w, self.win_h = d["kind"], d["win_w"], d["win_h"]
            if self.model_type == "mlp":
                self.w1, self.b1, self.w2, self.b2 = d["w1"], d["b1"], d["w2"], d["b2"]
            else:
                self.w, self.b = np.asarray(d["w"], float), float(d["b"])
            self.threshold = d["threshold_q16"] / 65536.0
        self._box_ws = N.box_ws_new()

    @staticmethod
    def _builtin_mlp():
        try:
            return N.mlp_default_model()
        except N.VtError:
            return None

    def _float_score(self, x: np.ndarray) -> float:
        from .reference import classify as R   # the float scorer is the oracle's
        if self.model_type == "mlp":
            return float(R.mlp_decision(self.w1, self.b1, self.w2, self.b2, x))
        return float(R.svm_decision(self.w, self.b, x))

    def window(self, img) -> np.ndarray:
        """The image resampled to the model's window (integer area means)."""
        g = _gray(img)
        return N.resample_area(g, (0, 0, g.shape[1] - 1, g.shape[0] - 1), self.win_w, self.win_h)

    def descriptor(self, img) -> np.ndarray:
        """The model's descriptor of one image, floats (C: Q15 / 32768)."""
        win = self.window(img)
        if self.engine == "reference":
            from .reference import classify as R
            return R.descriptor(self.kind, win)
        if self.kind == "hog":
            ws = N.hog_ws_new()
            N.hog_prepare(ws, win)
            d = N.hog_descriptor(ws, 0, 0, self.win_w, self.win_h)
        else:
            ws = N.gist_ws_new()
            N.gist_prepare(ws, win)
            d = N.gist_descriptor(ws, 0, 0, self.win_w, self.win_h)
        return d / 32768.0

    def score(self, images) -> np.ndarray:
        """SVM scores of a list of images (or one image), float."""
        if isinstance(images, np.ndarray) and images.ndim == 2:
            images = [images]
        out = []
        for i, img in enumerate(images):
            g = _gray(img, f"images[{i}]")
            if self.engine == "c":
                box = (0, 0, g.shape[1] - 1, g.shape[0] - 1)
                fn = N.classify_box_mlp if self.model_type == "mlp" else N.classify_box
                q = fn(self._box_ws, self._cmodel, g, box)
                out.append(q / 65536.0)
            else:
                out.append(self._float_score(self.descriptor(g)))
        return np.array(out, float)

    def is_vehicle(self, scores) -> np.ndarray:
        return np.asarray(scores) >= self.threshold
