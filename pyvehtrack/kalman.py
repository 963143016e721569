"""A filterpy-like Kalman filter on top of the fixed-point C core (kalman.h).

    kf = KalmanFilter.bottom_edge(x1=120, y1=300, x2=190)   # thesis sec. 3.5
    kf.predict()
    kf.update([121.5, 300.2, 191.0])                        # or update(None)
    kf.x, kf.P                                              # float NumPy arrays

Properties x, P, F, H, Q, R (and read-only K, y, S) are float NumPy copies
converted from the C fixed-point fields (vectors Q15.16, matrices Q31.32);
assigning one converts back, rounding to nearest. Values outside the C range
(|x| >= 32768 px, |matrix entry| >= 2^31) raise ValueError rather than being
clipped silently; P, Q and R must be symmetric positive semi-definite (ValueError
otherwise). Errors of the core arrive as `pyvehtrack.VtError`.
Unlike filterpy, x is a 1-D array of shape (dim_x,); a column (dim_x, 1) is
accepted on assignment.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from . import _check, _native
from ._native import ffi, lib

Q16_ONE = 1 << 16
Q32_ONE = 1 << 32
_MAX_X = lib.VT_KF_MAX_X
_MAX_Z = lib.VT_KF_MAX_Z
_CFG_FIELDS = ("dt", "accel_x", "accel_y", "p_max", "p_zero", "meas_sigma_x", "meas_sigma_y",
               "init_sigma_pos", "init_sigma_vel")


def _to_fixed(values, scale: int, lo: int, hi: int, name: str) -> np.ndarray:
    a = _check.real_array(values, name)     # no str, bool, NaN or inf
    q = np.rint(a * scale)
    if np.any(q < lo) or np.any(q > hi):
        raise ValueError(f"{name}: values must lie in [{lo / scale:g}, {hi / scale:g}] "
                         f"(the fixed-point range)")
    return q.astype(np.int64)


def to_q16(values, name: str = "value") -> np.ndarray:
    """Round floats to Q15.16 ints (int64 array); ValueError outside int32."""
    return _to_fixed(values, Q16_ONE, -(1 << 31), (1 << 31) - 1, name)


def to_q32(values, name: str = "value") -> np.ndarray:
    """Round floats to Q31.32 ints (int64 array); ValueError outside int64."""
    # 2^63 - 1024 is the largest float64 below 2^63, so the cast cannot overflow.
    return _to_fixed(values, Q32_ONE, -(1 << 63), (1 << 63) - 1024, name)


@dataclass(frozen=True)
class ModelConfig:
    """Parameters of the two motion models (C: vt_kf_model_cfg, all Q15.16).

    dt (frames per step), accel_x/accel_y (A of the acceleration model,
    px/frame^2), p_max (P1: probability of +A, and of -A), p_zero (P2:
    probability of constant velocity), meas_sigma_x/y (px), init_sigma_pos (px),
    init_sigma_vel (px/frame). Values are rounded to Q15.16 when passed to C;
    `quantized()` gives the values C actually uses."""

    dt: float
    accel_x: float
    accel_y: float
    p_max: float
    p_zero: float
    meas_sigma_x: float
    meas_sigma_y: float
    init_sigma_pos: float
    init_sigma_vel: float

    @classmethod
    def default(cls) -> "ModelConfig":
        """VT_KF_MODEL_CFG_DEFAULT, read from C."""
        return cls.from_c(_native.kf_model_cfg_default())

    @classmethod
    def from_c(cls, cfg) -> "ModelConfig":
        return cls(**{f: getattr(cfg, f) / Q16_ONE for f in _CFG_FIELDS})

    def to_c(self):
        cfg = ffi.new("vt_kf_model_cfg *")
        for f in _CFG_FIELDS:
            setattr(cfg, f, int(to_q16(getattr(self, f), f"ModelConfig.{f}")))
        return cfg

    def quantized(self) -> "ModelConfig":
        return ModelConfig.from_c(self.to_c())

    def replace(self, **changes) -> "ModelConfig":
        return dataclasses.replace(self, **changes)


def accel_var(accel: float, p_max: float, p_zero: float) -> float:
    """A^2/3 (1 + 4 P1 - P2) computed by C (Q31.32), as a float."""
    return _native.kf_accel_var(int(to_q16(accel, "accel")), int(to_q16(p_max, "p_max")),
                                int(to_q16(p_zero, "p_zero"))) / Q32_ONE


class KalmanFilter:
    """Fixed-point Kalman filter (C vt_kf) with filterpy's names.

    KalmanFilter(dim_x, dim_z) starts as filterpy's: x = 0, P = Q = F = R = I,
    H = 0. `bottom_edge` and `constant_velocity` build the two motion models.
    The C struct is `self.c` (a cffi `vt_kf *`), for passing to other C calls."""

    def __init__(self, dim_x: int, dim_z: int):
        dim_x = _check.integer(dim_x, "dim_x")     # the core checks the range (VtError)
        dim_z = _check.integer(dim_z, "dim_z")
        self.c = _native.kf_new()
        _native.kf_init(self.c, dim_x, dim_z)

    # ---- models
    @classmethod
    def bottom_edge(cls, x1: float, y1: float, x2: float,
                    cfg: ModelConfig | None = None) -> "KalmanFilter":
        """The thesis's 6-state model [x1, y1, x2, vx1, vy1, vx2], measuring
        [x1, y1, x2] (the bottom-left and bottom-right box corners)."""
        cfg = ModelConfig.default() if cfg is None else cfg
        self = cls.__new__(cls)
        self.c = _native.kf_new()
        q = to_q16([x1, y1, x2], "bottom_edge position")
        _native.kf_init_bottom_edge(self.c, cfg.to_c(), int(q[0]), int(q[1]), int(q[2]))
        return self

    @classmethod
    def constant_velocity(cls, x: float, y: float,
                          cfg: ModelConfig | None = None) -> "KalmanFilter":
        """The GIST paper's 4-state model [x, y, vx, vy], measuring [x, y]."""
        cfg = ModelConfig.default() if cfg is None else cfg
        self = cls.__new__(cls)
        self.c = _native.kf_new()
        q = to_q16([x, y], "constant_velocity position")
        _native.kf_init_cv(self.c, cfg.to_c(), int(q[0]), int(q[1]))
        return self

    # ---- steps
    def predict(self) -> None:
        _native.kf_predict(self.c)

    def update(self, z) -> None:
        """Correct with measurement z (dim_z values, px); None skips the update
        (a dropout), as filterpy."""
        if z is None:
            return
        zq = to_q16(_check.real_array(z, "z").reshape(-1), "z")
        if zq.size != self.dim_z:
            raise ValueError(f"z: expected {self.dim_z} values, got {zq.size}")
        _native.kf_update(self.c, zq.tolist())

    # ---- raw fixed-point access (int64 views into the C struct, writable)
    def _raw(self, name: str) -> np.ndarray:
        field = getattr(self.c, name)
        shape = {"x": (_MAX_X,), "y": (_MAX_Z,), "P": (_MAX_X, _MAX_X), "F": (_MAX_X, _MAX_X),
                 "Q": (_MAX_X, _MAX_X), "H": (_MAX_Z, _MAX_X), "R": (_MAX_Z, _MAX_Z),
                 "K": (_MAX_X, _MAX_Z), "S": (_MAX_Z, _MAX_Z)}[name]
        dtype = np.int32 if name in ("x", "y") else np.int64
        a = np.frombuffer(ffi.buffer(field), dtype=dtype).reshape(shape)
        n, m = self.dim_x, self.dim_z
        dims = {"x": (n,), "y": (m,), "P": (n, n), "F": (n, n), "Q": (n, n), "H": (m, n),
                "R": (m, m), "K": (n, m), "S": (m, m)}[name]
        return a[tuple(slice(0, d) for d in dims)]

    def raw(self, name: str) -> np.ndarray:
        """Copy of a field as its fixed-point ints (x, y: Q15.16; matrices:
        Q31.32)."""
        return self._raw(name).copy()

    def _get(self, name: str) -> np.ndarray:
        scale = Q16_ONE if name in ("x", "y") else Q32_ONE
        return self._raw(name).astype(np.float64) / scale

    def _set(self, name: str, value) -> None:
        dst = self._raw(name)
        v = _check.real_array(value, name)
        if name == "x" and v.shape == (self.dim_x, 1):
            v = v.reshape(-1)
        if v.shape != dst.shape:
            raise ValueError(f"{name}: expected shape {dst.shape}, got {v.shape}")
        q = to_q16(v, name) if name == "x" else to_q32(v, name)
        if name in ("P", "Q", "R"):     # covariances: symmetric PSD, within one Q31.32 step
            _check.covariance(v, name, 1.0 / Q32_ONE)
        dst[...] = q

    @property
    def dim_x(self) -> int:
        return int(self.c.dim_x)

    @property
    def dim_z(self) -> int:
        return int(self.c.dim_z)

    x = property(lambda s: s._get("x"), lambda s, v: s._set("x", v), doc="state (px, px/frame)")
    P = property(lambda s: s._get("P"), lambda s, v: s._set("P", v), doc="state covariance")
    F = property(lambda s: s._get("F"), lambda s, v: s._set("F", v), doc="state transition")
    H = property(lambda s: s._get("H"), lambda s, v: s._set("H", v), doc="measurement function")
    Q = property(lambda s: s._get("Q"), lambda s, v: s._set("Q", v), doc="process noise")
    R = property(lambda s: s._get("R"), lambda s, v: s._set("R", v), doc="measurement noise")
    K = property(lambda s: s._get("K"), doc="last Kalman gain (read-only)")
    y = property(lambda s: s._get("y"), doc="last residual z - Hx (read-only)")
    S = property(lambda s: s._get("S"), doc="last innovation covariance (read-only)")

    def __repr__(self) -> str:
        return f"KalmanFilter(dim_x={self.dim_x}, dim_z={self.dim_z}, x={self.x.round(3)})"


SIZEOF_KF = ffi.sizeof("vt_kf")

__all__ = ["KalmanFilter", "ModelConfig", "accel_var", "to_q16", "to_q32", "SIZEOF_KF"]
