"""NHTSA-style forward-collision scenes for pyvehtrack.eval.synth, with exact truth.

The NHTSA FCW confirmation test (NCAP, 2013) drives the subject vehicle (the ego, 45 mph =
20.1 m/s) at a principal other vehicle (the lead) in three ways and asks for a warning no
later than a time to collision of

    "stopped":  lead stopped in the lane                          -> 2.1 s
    "slower":   lead at a steady 20 mph (8.9 m/s)                 -> 2.0 s
    "decel":    lead at 45 mph, 30 m ahead, braking at 0.3 g      -> 2.4 s

plus here "follow": the lead keeps a constant gap (same speed, small random relative
accelerations), where no warning may come. Each scene runs until the true TTC falls to
`end_ttc` (the driver would brake there) or, for "follow", for `follow_s` seconds.

Truth per frame: the lead's distance z (m, camera to its rear face), closing speed
(m/s, positive closing) and TTC = z / closing (inf when not closing) -- the same definition
as pyvehtrack.camera's TTC from distance and rate.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import synth

__all__ = ["NHTSA_TTC", "FcwScene", "make_fcw_scene", "EGO_SPEED"]

EGO_SPEED = 20.1             # m/s (45 mph)
SLOW_LEAD = 8.9              # m/s (20 mph)
DECEL_G = 0.3 * 9.81         # m/s^2
NHTSA_TTC = {"stopped": 2.1, "slower": 2.0, "decel": 2.4, "follow": None}


@dataclass
class FcwScene:
    kind: str
    sequence: synth.Sequence
    z: np.ndarray            # lead distance per frame, m
    closing: np.ndarray      # closing speed per frame, m/s (> 0: approaching)
    ttc: np.ndarray          # z / closing (inf if not closing)
    lead_speed: np.ndarray   # m/s
    test_ttc: float | None   # the warning must come at or before this TTC (None: never warn)

    @property
    def fps(self) -> float:
        return self.sequence.fps


def _kinematics(kind: str, fps: float, end_ttc: float, follow_s: float, rng):
    dt = 1.0 / fps
    if kind == "stopped":
        z0, lead = 60.0, lambda t: 0.0 * t
    elif kind == "slower":
        z0, lead = 45.0, lambda t: SLOW_LEAD + 0.0 * t
    elif kind == "decel":
        # 30 m at equal speed, braking starts after 1 s (the system has tracked the lead by then)
        z0, lead = 30.0, lambda t: np.maximum(EGO_SPEED - DECEL_G * np.maximum(t - 1.0, 0.0), 0.0)
    elif kind == "follow":
        z0, lead = float(rng.uniform(22, 32)), None
    else:
        raise ValueError(f"unknown FCW scene {kind!r}; choose from {sorted(NHTSA_TTC)}")
    if lead is None:
        n = int(round(follow_s * fps))
        z = synth._longitudinal(rng, n, dt, z0, 0.0, accel_sigma=0.15, hold_s=1.0)
        # constant gap on average: the random relative speed must not drift into an approach
        z = z0 + (z - z0) * 0.5
        v_lead = np.full(n, EGO_SPEED)
        closing = -np.gradient(z, dt)
        return z, closing, v_lead
    # integrate the relative motion finely, sample per frame, stop at end_ttc
    zs, vs, cl = [], [], []
    z, t = z0, 0.0
    sub = 20
    while True:
        v = float(lead(np.array(t)))
        c = EGO_SPEED - v
        zs.append(z)
        vs.append(v)
        cl.append(c)
        if (c > 0 and z / c <= end_ttc) or z < 2.0 or len(zs) > 60 * fps:
            break
        for k in range(sub):
            tk = t + k * dt / sub
            z -= (EGO_SPEED - float(lead(np.array(tk)))) * dt / sub
        t += dt
    return np.array(zs), np.array(cl), np.array(vs)


def make_fcw_scene(kind: str, seed: int = 0, *, fps: float = 30.0, camera: synth.Camera | None = None,
                   end_ttc: float = 1.0, follow_s: float = 6.0, noise_sigma: float = 2.0) -> FcwScene:
    """One scene (see the module doc), deterministic in its arguments."""
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    if kind not in NHTSA_TTC:
        raise ValueError(f"unknown FCW scene {kind!r}; choose from {sorted(NHTSA_TTC)}")
    rng = np.random.default_rng([int(seed), 0xFC3, sorted(NHTSA_TTC).index(kind)])
    z, closing, v_lead = _kinematics(kind, float(fps), float(end_ttc), float(follow_s), rng)
    n = len(z)
    dt = 1.0 / fps
    x = synth._lateral(rng, n, dt, 0.0, wander=0.05)
    lead = synth._new_vehicle(rng, 0, x, z)
    seq = synth.Sequence(name=f"fcw_{kind}_{int(seed)}", seed=int(seed), camera=camera or synth.Camera(),
                         vehicles=[lead], n_frames=n, fps=float(fps), ego_speed=EGO_SPEED,
                         noise_sigma=float(noise_sigma))
    with np.errstate(divide="ignore"):
        ttc = np.where(closing > 1e-6, z / np.maximum(closing, 1e-12), np.inf)
    return FcwScene(kind, seq, z, closing, ttc, v_lead, NHTSA_TTC[kind])


def camera_file_of(cam: synth.Camera):
    """The pyvehtrack.camera.Camera of a synthetic camera (level, so pitch 0 and cy = horizon)."""
    from ..camera import Camera
    return Camera(fx=cam.f, fy=cam.f, cx=cam.cx, cy=cam.yh, height_m=cam.cam_height, pitch_deg=0.0,
                  image_size=(cam.width, cam.height))
