"""Float reference for include/vehtrack/kalman.h: filterpy KalmanFilter objects
for the two motion models, built from the papers (never calls C).

- Bottom-edge model, thesis sec. 3.5: state [x1, y1, x2, vx1, vy1, vx2] (eq. 3.17),
  constant velocity between frames (eq. 3.18-3.19), measurement [x1, y1, x2]
  (eq. 3.21a), process noise a change of velocity only (eq. 3.20) with the
  variance of the acceleration model of sec. 3.5.1 (eq. 3.24-3.25).
- Constant-velocity model, GIST paper sec. III.B.2: state [x, y, vx, vy],
  measurement [x, y]; its process noise (not given in the paper) is filterpy's
  piecewise-constant white acceleration, Q_discrete_white_noise, with the same
  acceleration variance, so both models share one parameter set.

All parameters are keyword arguments in px / frames; pass the values the C side
uses (pyvehtrack.kalman.ModelConfig.quantized()) for a like-for-like comparison.
"""
from __future__ import annotations

import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter


def accel_var(accel: float, p_max: float, p_zero: float) -> float:
    """Variance of the acceleration u (thesis eq. 3.24): u is uniform on [-A, A]
    with weight 1 - 2 P1 - P2, plus point masses P1 at +A, P1 at -A and P2 at 0:

        E[u^2] = (1 - 2 P1 - P2) A^2 / 3 + 2 P1 A^2 = A^2 / 3 (1 + 4 P1 - P2).
    """
    if accel < 0 or p_max < 0 or p_zero < 0 or 2 * p_max + p_zero > 1:
        raise ValueError("need A >= 0, P1 >= 0, P2 >= 0 and 2 P1 + P2 <= 1")
    return accel * accel / 3.0 * (1.0 + 4.0 * p_max - p_zero)


def bottom_edge_filter(x1: float, y1: float, x2: float, *, dt: float, accel_x: float,
                       accel_y: float, p_max: float, p_zero: float, meas_sigma_x: float,
                       meas_sigma_y: float, init_sigma_pos: float,
                       init_sigma_vel: float) -> KalmanFilter:
    kf = KalmanFilter(dim_x=6, dim_z=3)
    i3 = np.eye(3)
    kf.F = np.block([[i3, dt * i3], [np.zeros((3, 3)), i3]])
    kf.H = np.hstack([i3, np.zeros((3, 3))])
    # w = [0, 0, 0, u_x1, u_y1, u_x2] dt (eq. 3.20, 3.25): a velocity change only.
    sx = accel_var(accel_x, p_max, p_zero) * dt * dt
    sy = accel_var(accel_y, p_max, p_zero) * dt * dt
    kf.Q = np.diag([0.0, 0.0, 0.0, sx, sy, sx])
    kf.R = np.diag([meas_sigma_x ** 2, meas_sigma_y ** 2, meas_sigma_x ** 2])
    kf.P = np.diag([init_sigma_pos ** 2] * 3 + [init_sigma_vel ** 2] * 3)
    kf.x = np.array([[x1], [y1], [x2], [0.0], [0.0], [0.0]])
    return kf


def constant_velocity_filter(x: float, y: float, *, dt: float, accel_x: float,
                             accel_y: float, p_max: float, p_zero: float,
                             meas_sigma_x: float, meas_sigma_y: float, init_sigma_pos: float,
                             init_sigma_vel: float) -> KalmanFilter:
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.F = np.array([[1.0, 0.0, dt, 0.0],
                     [0.0, 1.0, 0.0, dt],
                     [0.0, 0.0, 1.0, 0.0],
                     [0.0, 0.0, 0.0, 1.0]])
    kf.H = np.array([[1.0, 0.0, 0.0, 0.0],
                     [0.0, 1.0, 0.0, 0.0]])
    q = np.zeros((4, 4))
    for axis, accel in ((0, accel_x), (1, accel_y)):
        # filterpy's (position, velocity) block for this axis, placed at the
        # state indices (axis, axis + 2).
        blk = Q_discrete_white_noise(dim=2, dt=dt, var=accel_var(accel, p_max, p_zero))
        idx = [axis, axis + 2]
        q[np.ix_(idx, idx)] = blk
    kf.Q = q
    kf.R = np.diag([meas_sigma_x ** 2, meas_sigma_y ** 2])
    kf.P = np.diag([init_sigma_pos ** 2] * 2 + [init_sigma_vel ** 2] * 2)
    kf.x = np.array([[x], [y], [0.0], [0.0]])
    return kf
