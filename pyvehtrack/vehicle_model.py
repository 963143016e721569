"""The seven-parameter geometric vehicle model fitted by a genetic algorithm, coarse to fine (IVVI paper,
sec. 5-6), on the C core or the oracle.

    vm = VehicleModel(road=(300, 100, 400, 237))       # widths 100 px at row 300, 237 px at row 400
    fit = vm.fit(gray, roi=(l, t, r, b))               # detection: uniform start inside the constraints
    fit.box, fit.params, fit.fitness, fit.evaluations
    fit = vm.fit(gray, roi, prediction=fit.params, sigma=(4, 3, 4, 4, 5, 5, 3))   # tracking (Table 1)

Keyword settings are the fields of vt_model_cfg (include/vehtrack/vehicle_model.h); `pop` and `gens`
take [[detection per level], [tracking per level]], level 0 = full resolution."""
from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from . import _native
from .shared import MODEL_RENAMED, take_renamed

GENES = _native.MODEL_GENES
CFG_FIELDS = [f for f, _ in _native.ffi.typeof("vt_model_cfg").fields]


@dataclass(frozen=True)
class ModelFit:
    params: tuple       # (x, y, w, h, wind, bump, roof): centre column, bottom row, px; shape in %
    box: tuple          # (left, top, right, bottom), inclusive input px
    fitness: int
    evaluations: int    # fitness evaluations spent (the GA's cost)


def make_cfg(road=None, **overrides):
    """The C defaults with keyword overrides, checked by C; the percent names of before
    issue 10 (width_tol_percent, aspect_min/max_percent, mut_percent) are taken x 10, with a
    warning (exact for mut_percent too: the GA's draw makes the same decisions)."""
    cfg = _native.model_cfg_default()
    overrides = take_renamed("vehicle_model", overrides, MODEL_RENAMED)
    for k, v in overrides.items():
        if k not in CFG_FIELDS:
            raise TypeError(f"{k}: not a vehicle-model setting (expected one of {', '.join(CFG_FIELDS)})")
        if k in ("pop", "gens"):
            arr = np.asarray(v)
            if arr.shape != (2, int(_native.lib.VT_MODEL_LEVELS)) or not np.issubdtype(arr.dtype, np.integer):
                raise ValueError(f"{k}: expected 2 x {int(_native.lib.VT_MODEL_LEVELS)} ints "
                                 "[[detection per level], [tracking per level]]")
            for m in range(2):
                for lv in range(arr.shape[1]):
                    getattr(cfg, k)[m][lv] = int(arr[m, lv])
            continue
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
            raise TypeError(f"{k}: expected an int, got {type(v).__name__}")
        if not (0 if k == "seed" else -2**31) <= int(v) < (2**32 if k == "seed" else 2**31):
            raise ValueError(f"{k}: {v} out of range")
        setattr(cfg, k, int(v))
    if road is not None:
        if len(road) != 4:
            raise ValueError("road: expected (row0, width0, row1, width1)")
        _native.model_cfg_road(cfg, *road)
    _native.model_cfg_check(cfg)
    return cfg


def oracle_cfg(cfg) -> SimpleNamespace:
    """The oracle's view of a C config (plain ints; VT_MAX_WIDTH caps the expected width)."""
    ns = {f: getattr(cfg, f) for f in CFG_FIELDS if f not in ("pop", "gens")}
    ns = {k: int(v) for k, v in ns.items()}
    lv = int(_native.lib.VT_MODEL_LEVELS)
    ns["pop"] = [[int(cfg.pop[m][i]) for i in range(lv)] for m in range(2)]
    ns["gens"] = [[int(cfg.gens[m][i]) for i in range(lv)] for m in range(2)]
    ns["max_width"] = int(_native.lib.VT_MAX_WIDTH)
    return SimpleNamespace(**ns)


def oracle_search(roi, y_min, y_max, prediction=None, sigma=None) -> SimpleNamespace:
    return SimpleNamespace(roi=tuple(int(v) for v in roi), y_min=int(y_min), y_max=int(y_max),
                           tracking=prediction is not None,
                           pred=tuple(int(v) for v in prediction) if prediction is not None else None,
                           sigma=tuple(int(v) for v in sigma) if sigma is not None else None)


class VehicleModel:
    """engine="c" runs c/vehicle_model.c, "reference" the oracle (same individuals, slower)."""

    def __init__(self, engine: str = "c", road=None, **cfg):
        if engine not in ("c", "reference"):
            raise ValueError(f"engine: expected 'c' or 'reference', got {engine!r}")
        self.engine = engine
        self.cfg = make_cfg(road=road, **cfg)
        self._ws = _native.model_ws_new() if engine == "c" else None

    def fit(self, frame: np.ndarray, roi, y_range=None, prediction=None, sigma=None) -> ModelFit:
        """Fit inside roi (l, t, r, b); y_range = (y_min, y_max) bounds the bottom row (default: the
        ROI's rows); prediction + sigma (7-tuples) switch to tracking."""
        if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8 or frame.ndim != 2:
            raise TypeError(f"frame: expected a 2-D uint8 numpy array, got "
                            f"{type(frame).__name__} {getattr(frame, 'dtype', '')} {getattr(frame, 'shape', '')}")
        if len(roi) != 4:
            raise ValueError(f"roi: expected (left, top, right, bottom), got {roi!r}")
        if (prediction is None) != (sigma is None):
            raise ValueError("prediction and sigma: give both (tracking) or neither (detection)")
        if sigma is not None and any(int(s) < 0 for s in sigma):
            raise ValueError(f"sigma: must be >= 0, got {tuple(sigma)}")
        y_min, y_max = (int(roi[1]), int(roi[3])) if y_range is None else (int(y_range[0]), int(y_range[1]))
        if self.engine == "c":
            s = _native.model_search(roi, y_min, y_max, prediction is not None, prediction, sigma)
            r = _native.model_fit(frame, self.cfg, s, self._ws)
            return ModelFit(r["best"], r["box"], r["fitness"], r["evaluations"])
        from .reference import vehicle_model as rvm
        r = rvm.fit(frame, oracle_cfg(self.cfg), oracle_search(roi, y_min, y_max, prediction, sigma))
        return ModelFit(tuple(r.best), r.box, r.fitness, r.evaluations)

    def fit_flow(self, frame: np.ndarray, hyp) -> ModelFit:
        """Detect the vehicle behind an overtaking hypothesis (pyvehtrack.flow.FlowHyp): the ROI and
        the bottom-row range come from its box and centre of gravity (vt_model_search_from_flow)."""
        l, t, r, b = (int(v) for v in hyp.box)
        s = _native.model_search_from_flow(self.cfg, {"left": l, "top": t, "right": r, "bottom": b, "cy": int(hyp.cy)})
        roi = (s.roi.left, s.roi.top, s.roi.right, s.roi.bottom)
        return self.fit(frame, roi, y_range=(s.y_min, s.y_max))
