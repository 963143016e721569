"""Synthetic road sequences with exact ground truth, for tracker tests and HOTA regressions.

Geometry (thesis ch. 3, flat-road camera): a pinhole camera at height `cam_height` above a flat road,
looking along it with zero pitch and roll, so the horizon is the row of the vanishing point. A point at
lateral offset X (m, right positive), height Y above the road and distance Z ahead projects to

    u = cx + f X / Z,        v = y_h + f (cam_height - Y) / Z,

with pixel centres at integer coordinates (KITTI's 0-based convention). A vehicle is its rear face, a
fronto-parallel rectangle, so its projection is exactly the box [cx + f(X -+ w/2)/Z, y_h + f(hc - h)/Z,
..., y_h + f hc/Z]: the bottom edge is where the tyres touch the road.

Appearance follows what the thesis detector looks for: the road is brighter than the dark band under
each vehicle (tyres and the shadow between them), so scanning bottom-up the first bright-to-dark
transition is the vehicle's bottom edge (sec. 2.4.2.1); the rear face (body, window band, lights,
plate) stands out from road and background at its left and right sides, giving the vertical edges of
the verification step (sec. 2.4.2.2); solid and dashed lane markings give the [-1 0 1] lane cue
(sec. 2.4.1.2).

Ground truth is computed analytically, not from pixels: the visible box is the bounding box of the
vehicle's rectangle clipped to the image and minus the rectangles of nearer vehicles; occlusion and
truncation are exact area fractions. A pixel belongs to a vehicle when its centre lies in the half-open
rectangle [l, r) x [t, b) and in no nearer one, so every drawn pixel centre lies inside its GT box.
Everything is a deterministic function of (scenario, seed): frame t is rendered from (seed, t) alone.
"""
from __future__ import annotations

import json
import math
import os
import zlib
from dataclasses import dataclass, field
from typing import Callable, Iterator, Sequence as _Seq

import cv2
import numpy as np

__all__ = ["Camera", "Vehicle", "Sequence", "GT_DTYPE", "SCENARIOS", "make_sequence", "make_set",
           "write_kitti", "gt_detections", "kitti_gt_lines"]

LANE_WIDTH = 3.5          # m, lanes centred at -3.5, 0, +3.5 (the ego drives in the middle one)
MARK_WIDTH = 0.15         # m
DASH_LEN, DASH_GAP = 3.0, 6.0
SHOULDER = 0.6            # m of asphalt outside the solid edge lines
GAP_HEIGHT = 0.28         # m, road clearance: the dark band under the body
Z_MIN = 0.5               # m, nearer than this a vehicle is not projected

GT_DTYPE = np.dtype([
    ("frame", "i4"), ("id", "i4"),
    # visible box in pixel coordinates (pixel centres at integers), clipped to [0, W-1] x [0, H-1]
    ("left", "f8"), ("top", "f8"), ("right", "f8"), ("bottom", "f8"),
    ("truncation", "f8"),   # fraction of the full rectangle's area outside the image
    ("occlusion", "f8"),    # fraction of the in-image area hidden by nearer vehicles
    ("trunc_level", "i4"),  # KITTI tracking: 0 none, 1 <= 50 % outside, 2 more
    ("occ_level", "i4"),    # KITTI: 0 visible, 1 partly (<= 50 %), 2 largely (<= 80 %), 3 more (ignored)
    # full projected rectangle, unclipped and unoccluded (amodal box)
    ("full_left", "f8"), ("full_top", "f8"), ("full_right", "f8"), ("full_bottom", "f8"),
    # world state: lateral centre and distance of the rear face (m), velocities (m/s) relative to the ego
    ("x", "f8"), ("z", "f8"), ("vx", "f8"), ("vz", "f8"),
    ("width", "f8"), ("height", "f8"), ("length", "f8"),
])


@dataclass(frozen=True)
class Camera:
    """Flat-road pinhole camera. `focal` defaults to 1.1 * width px (about 49 deg horizontal field of
    view), `horizon` to 0.45 * height; the principal column is the image centre (width - 1) / 2."""
    width: int = 640
    height: int = 480
    focal: float | None = None
    horizon: float | None = None
    cam_height: float = 1.3

    def __post_init__(self):
        if int(self.width) < 16 or int(self.height) < 16:
            raise ValueError(f"image size {self.width}x{self.height} is too small (16x16 at least)")
        if not self.cam_height > 0:
            raise ValueError("cam_height must be > 0")
        if self.focal is not None and not self.focal > 0:
            raise ValueError("focal must be > 0")

    @property
    def f(self) -> float:
        return float(self.focal) if self.focal is not None else 1.1 * self.width

    @property
    def yh(self) -> float:
        return float(self.horizon) if self.horizon is not None else 0.45 * self.height

    @property
    def cx(self) -> float:
        return (self.width - 1) / 2.0

    def project(self, x, y, z):
        """World (X right, Y up from the road, Z ahead) to image (u, v)."""
        z = np.asarray(z, dtype=np.float64)
        return self.cx + self.f * np.asarray(x) / z, self.yh + self.f * (self.cam_height - np.asarray(y)) / z

    def rear_box(self, x, z, w, h):
        """Projected rear face of a vehicle centred at lateral x, distance z: (l, t, r, b)."""
        s = self.f / z
        return (self.cx + s * (x - w / 2), self.yh + s * (self.cam_height - h),
                self.cx + s * (x + w / 2), self.yh + s * self.cam_height)

    def row_distance(self, v):
        """Distance (m) of the road point seen at row v (v > horizon)."""
        return self.f * self.cam_height / (np.asarray(v, dtype=np.float64) - self.yh)


@dataclass(eq=False)
class Vehicle:
    """One vehicle: fixed size and look, trajectory sampled per frame (relative to the ego camera).
    z is NaN in frames where the vehicle is not in the scene."""
    vid: int
    width: float
    height: float
    length: float
    x: np.ndarray
    z: np.ndarray
    texture: np.ndarray          # float32 (th, tw) rear view, row 0 at the roof
    dark: bool = False


# ---------------------------------------------------------------------------------------------------------
# exact rectangle geometry

def _rect_minus_rects(rect, others):
    """Area and bounding box of `rect` minus the union of `others` (all (l, t, r, b), l < r, t < b).
    Exact: the x axis is cut into slabs at every rectangle side, and inside a slab each other rectangle
    either spans it entirely or not at all, so the uncovered part is a union of y intervals."""
    l, t, r, b = rect
    if not others:
        return (r - l) * (b - t), rect
    xs = sorted({l, r, *[min(max(o[0], l), r) for o in others], *[min(max(o[2], l), r) for o in others]})
    area = 0.0
    bl = bt = math.inf
    br = bb = -math.inf
    for x0, x1 in zip(xs[:-1], xs[1:]):
        if x1 <= x0:
            continue
        xm = 0.5 * (x0 + x1)
        cover = sorted((max(o[1], t), min(o[3], b)) for o in others
                       if o[0] <= xm < o[2] and o[1] < b and o[3] > t)
        free, y = [], t
        for c0, c1 in cover:
            if c0 > y:
                free.append((y, c0))
            y = max(y, c1)
        if y < b:
            free.append((y, b))
        free = [(a, c) for a, c in free if c > a]
        if not free:
            continue
        area += (x1 - x0) * sum(c - a for a, c in free)
        bl, br = min(bl, x0), max(br, x1)
        bt, bb = min(bt, free[0][0]), max(bb, free[-1][1])
    if area <= 0.0:
        return 0.0, None
    return area, (bl, bt, br, bb)


def _clip(rect, w, h):
    l, t, r, b = rect
    c = (max(l, 0.0), max(t, 0.0), min(r, w - 1.0), min(b, h - 1.0))
    return c if c[0] < c[2] and c[1] < c[3] else None


def _trunc_level(frac: float) -> int:
    return 0 if frac <= 1e-12 else (1 if frac <= 0.5 else 2)


def _occ_level(frac: float) -> int:
    return 0 if frac <= 1e-12 else (1 if frac <= 0.5 else (2 if frac <= 0.8 else 3))


# ---------------------------------------------------------------------------------------------------------
# appearance

def _smooth_noise(rng, shape, sigma, amp):
    n = rng.standard_normal(shape).astype(np.float32)
    n = cv2.GaussianBlur(n, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    s = float(n.std()) or 1.0
    return n * (amp / s)


def _vehicle_texture(rng, w, h, dark: bool) -> np.ndarray:
    """Rear view at 1 cm per texel, row 0 = roof. Bands from the road up: the dark gap under the body
    (tyres at the sides), bumper with a bright plate, the trunk with two lights at the sides, the
    window band (dark glass framed by body-coloured pillars), the roof."""
    tw, th = max(8, int(round(w * 100))), max(8, int(round(h * 100)))
    body = rng.uniform(38, 72) if dark else rng.uniform(150, 215)
    tex = np.full((th, tw), body, np.float32)
    ym = (th - 0.5 - np.arange(th)) / 100.0           # metres above the road, per texel row
    xm = (np.arange(tw) + 0.5) / 100.0                # metres from the left side
    Y, X = np.meshgrid(ym, xm, indexing="ij")
    gap = GAP_HEIGHT
    bumper_top = gap + 0.24
    trunk_top = max(bumper_top + 0.15, 0.60 * h)
    win_top = max(trunk_top + 0.15, 0.90 * h)
    tex += (Y / h - 0.5).astype(np.float32) * (-8.0 if dark else 10.0)          # soft vertical shading
    tex[(Y >= gap) & (Y < bumper_top)] *= 0.88
    plate = (np.abs(X - w / 2) < 0.26) & (Y >= gap + 0.05) & (Y < gap + 0.17)
    tex[plate] = rng.uniform(195, 225)
    light_w = rng.uniform(0.18, 0.26) * w
    light = ((X < 0.04 * w + light_w) | (X > 0.96 * w - light_w)) & (X > 0.04 * w) & (X < 0.96 * w) \
        & (Y >= trunk_top - 0.20) & (Y < trunk_top - 0.05)
    tex[light] = rng.uniform(150, 185) if dark else rng.uniform(70, 105)
    glass = (Y >= trunk_top) & (Y < win_top) & (X > 0.12 * w) & (X < 0.88 * w)
    glass_val = rng.uniform(20, 35) if dark else rng.uniform(35, 60)
    tex[glass] = glass_val + 18.0 * np.clip((X[glass] - 0.2 * w) / w - (Y[glass] - trunk_top), 0, 1)
    tex[Y >= win_top] *= 0.95
    tex += _smooth_noise(rng, tex.shape, 2.0, 3.0)
    under = Y < gap
    tex[under] = rng.uniform(14, 26)
    tyre = under & ((X < 0.24) | (X > w - 0.24)) & ((X > 0.04) & (X < w - 0.04))
    tex[tyre] = rng.uniform(8, 16)
    return np.clip(tex, 0, 255).astype(np.float32)


@dataclass(eq=False)
class _Look:
    """Per-sequence look of the road and the background (drawn once from the seed)."""
    asphalt: float
    verge: float
    mark: float
    haze: float
    sky_top: float
    sky_bottom: float
    road_tbl: np.ndarray
    verge_tbl: np.ndarray
    skyline: np.ndarray       # per column height (px) of the tree/building band above the horizon
    skyline_tex: np.ndarray   # (rows, width) band texture


def _make_look(rng, cam: Camera) -> _Look:
    w = cam.width
    heights = np.cumsum(rng.normal(0.0, 1.0, w))
    heights = cv2.GaussianBlur(heights.reshape(1, -1).astype(np.float32), (0, 0), 3.0).ravel()
    heights -= heights.min()
    heights = heights / max(float(heights.max()), 1e-6) * (0.07 * cam.height) + 0.01 * cam.height
    band_rows = int(math.ceil(heights.max())) + 2
    tex = rng.uniform(60, 110) + _smooth_noise(rng, (band_rows, w), 1.5, 14.0)
    return _Look(asphalt=rng.uniform(95, 120), verge=rng.uniform(70, 88), mark=rng.uniform(185, 215),
                 haze=rng.uniform(150, 175), sky_top=rng.uniform(200, 230), sky_bottom=rng.uniform(165, 190),
                 road_tbl=rng.normal(0, 1, (256, 256)).astype(np.float32),
                 verge_tbl=rng.normal(0, 1, (256, 256)).astype(np.float32),
                 skyline=heights.astype(np.float64), skyline_tex=tex.astype(np.float32))


def _cum_dash(s):
    """Integral of the dash indicator (on for DASH_LEN, off for DASH_GAP) from 0 to s."""
    p = DASH_LEN + DASH_GAP
    return np.floor(s / p) * DASH_LEN + np.minimum(np.mod(s, p), DASH_LEN)


class _Background:
    """Sky, skyline band and the road (asphalt, verge, markings). Everything that does not depend on the
    ego's travelled distance is computed once: the sky, and the lateral coverage of each pixel's
    footprint by the road and by the markings (markings are anti-aliased by their exact coverage)."""

    def __init__(self, cam: Camera, look: _Look):
        W, H, f, yh, cx, hc = cam.width, cam.height, cam.f, cam.yh, cam.cx, cam.cam_height
        self.look = look
        self.first_road = first = min(int(math.floor(yh)) + 1, H)
        rows = np.arange(H, dtype=np.float64)
        sky = np.empty((first, W), np.float32)
        if first > 0:
            g = np.clip(rows[:first] / max(yh, 1.0), 0, 1)
            sky[:] = (look.sky_top + (look.sky_bottom - look.sky_top) * g)[:, None]
            band = look.skyline_tex.shape[0]
            r0 = max(0, first - band)
            rr = np.arange(r0, first)[:, None]
            on = (yh - rr) <= look.skyline[None, :]
            blk = sky[r0:first]
            blk[on] = look.skyline_tex[band - (first - r0):][on]
        self.sky = sky
        v = rows[first:]
        dz = v - yh
        self.Z = Z = f * hc / dz                                  # distance at the row centre
        self.z_near = f * hc / (dz + 0.5)
        self.z_far = np.where(dz > 0.5, f * hc / np.maximum(dz - 0.5, 1e-9), Z + 1e3)
        u = np.arange(W, dtype=np.float64)
        px_w = (Z / f)[:, None]                                   # metres per pixel across, per row
        X0 = (u[None, :] - 0.5 - cx) * px_w
        X1 = X0 + px_w

        def cover(a, b):
            return (np.clip(np.minimum(X1, b) - np.maximum(X0, a), 0, None) / px_w).astype(np.float32)

        edge = 1.5 * LANE_WIDTH
        hw = MARK_WIDTH / 2
        self.c_road = cover(-edge - SHOULDER, edge + SHOULDER)
        self.c_solid = cover(-edge - hw, -edge + hw) + cover(edge - hw, edge + hw)
        half = LANE_WIDTH / 2
        self.c_dash = cover(-half - hw, -half + hw) + cover(half - hw, half + hw)
        # texture lattice coordinates across (0.4 m cells), wrapped into the 256-cell noise table
        self.gx = np.mod((u[None, :] - cx) * px_w / 0.4, 256.0).astype(np.float32)
        self.fade = np.exp(-Z / 45.0).astype(np.float32)[:, None]
        self.hz = (1.0 - np.exp(-Z / 250.0)).astype(np.float32)[:, None]
        self.noise_tbl = np.dstack([look.road_tbl, look.verge_tbl])   # 2 channels, one lookup

    def render(self, ego_s: float) -> np.ndarray:
        look = self.look
        first = self.first_road
        H, W = self.sky.shape[0] + self.Z.shape[0], self.sky.shape[1]
        img = np.empty((H, W), np.float32)
        img[:first] = self.sky
        if first >= H:
            return img
        gz = np.broadcast_to(np.mod((self.Z + ego_s) / 0.4, 256.0).astype(np.float32)[:, None], self.gx.shape)
        # bilinear lattice noise anchored to the road: smooth, so it adds texture but no sharp edges
        n = cv2.remap(self.noise_tbl, np.ascontiguousarray(gz), self.gx, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
        road = look.asphalt + 3.0 * self.fade * n[..., 0]
        verge = look.verge + 8.0 * self.fade * n[..., 1]
        out = verge + (road - verge) * self.c_road
        dash = ((_cum_dash(self.z_far + ego_s) - _cum_dash(self.z_near + ego_s)) / (self.z_far - self.z_near))
        c_mark = np.minimum(self.c_solid + dash.astype(np.float32)[:, None] * self.c_dash, 1.0)
        out += (look.mark - out) * c_mark
        img[first:] = out * (1 - self.hz) + look.haze * self.hz
        return img


# ---------------------------------------------------------------------------------------------------------
# the sequence

class _Frames:
    """Lazy frames: len(), [t], iteration and np.asarray() render on demand (each frame from (seed, t))."""

    def __init__(self, seq: "Sequence"):
        self._seq = seq

    def __len__(self):
        return self._seq.n_frames

    def __getitem__(self, t):
        if isinstance(t, slice):
            return np.stack([self._seq.frame(i) for i in range(*t.indices(len(self)))])
        return self._seq.frame(int(t))

    def __iter__(self) -> Iterator[np.ndarray]:
        for t in range(len(self)):
            yield self._seq.frame(t)

    def __array__(self, dtype=None, copy=None):
        a = self[:]
        return a if dtype is None else a.astype(dtype)


@dataclass(eq=False)
class Sequence:
    """A synthetic sequence. `frames` renders lazily (`seq.frames[t]`, `for f in seq.frames`,
    `np.asarray(seq.frames)` for a (T, H, W) uint8 array); `gt` is a GT_DTYPE structured array with
    one row per visible vehicle and frame, sorted by (frame, id)."""
    name: str
    seed: int
    camera: Camera
    vehicles: list
    n_frames: int
    fps: float = 30.0
    ego_speed: float = 20.0       # m/s, moves the dashes and the road texture
    noise_sigma: float = 2.0      # grey levels, Gaussian sensor noise
    blur_sigma: float = 0.6       # px, optics blur before the noise
    gt: np.ndarray = field(init=False, repr=False)
    _look: _Look = field(init=False, repr=False)
    _bg: _Background | None = field(init=False, repr=False, default=None)

    def __post_init__(self):
        if self.n_frames < 1:
            raise ValueError("n_frames must be >= 1")
        self._look = _make_look(np.random.default_rng([self.seed, 0x5EED]), self.camera)
        self._bg = None
        self.gt = self._compute_gt()

    # -- geometry -------------------------------------------------------------------------------------
    def _placed(self, t: int):
        """[(vehicle, full rect)] present at frame t, far to near (ties by id)."""
        out = []
        for veh in self.vehicles:
            z = veh.z[t]
            if not np.isfinite(z) or z < Z_MIN:
                continue
            out.append((veh, self.camera.rear_box(float(veh.x[t]), float(z), veh.width, veh.height)))
        out.sort(key=lambda p: (-float(p[0].z[t]), p[0].vid))
        return out

    def _compute_gt(self) -> np.ndarray:
        W, H = self.camera.width, self.camera.height
        rows = []
        dt = 1.0 / self.fps
        for t in range(self.n_frames):
            placed = self._placed(t)
            clipped = [_clip(rect, W, H) for _, rect in placed]
            for k, (veh, rect) in enumerate(placed):
                c = clipped[k]
                if c is None:
                    continue
                nearer = [clipped[j] for j in range(k + 1, len(placed)) if clipped[j] is not None]
                area, vis = _rect_minus_rects(c, nearer)
                if vis is None:
                    continue
                full_area = (rect[2] - rect[0]) * (rect[3] - rect[1])
                c_area = (c[2] - c[0]) * (c[3] - c[1])
                trunc = max(0.0, 1.0 - c_area / full_area)
                occ = max(0.0, 1.0 - area / c_area)
                t0, t1 = max(t - 1, 0), min(t + 1, self.n_frames - 1)
                span = (t1 - t0) * dt if t1 > t0 else 1.0

                def vel(a):
                    d = (a[t1] - a[t0]) / span
                    return float(d) if np.isfinite(d) else 0.0
                rows.append((t, veh.vid, *vis, trunc, occ, _trunc_level(trunc), _occ_level(occ), *rect,
                             float(veh.x[t]), float(veh.z[t]), vel(veh.x), vel(veh.z),
                             veh.width, veh.height, veh.length))
        gt = np.array(rows, dtype=GT_DTYPE) if rows else np.zeros(0, GT_DTYPE)
        return np.sort(gt, order=["frame", "id"])

    # -- frames ---------------------------------------------------------------------------------------
    @property
    def frames(self) -> _Frames:
        return _Frames(self)

    def __len__(self):
        return self.n_frames

    def _render(self, t: int, labels: bool):
        if not 0 <= t < self.n_frames:
            raise IndexError(f"frame {t} out of range [0, {self.n_frames})")
        cam = self.camera
        W, H = cam.width, cam.height
        lab = np.full((H, W), -1, np.int32) if labels else None
        if not labels:
            if self._bg is None:
                self._bg = _Background(cam, self._look)
            img = self._bg.render(self.ego_speed * t / self.fps)
        for veh, (l, tp, r, b) in self._placed(t):
            i0, i1 = max(math.ceil(l), 0), min(math.ceil(r) - 1, W - 1)
            j0, j1 = max(math.ceil(tp), 0), min(math.ceil(b) - 1, H - 1)
            if i1 < i0 or j1 < j0:
                continue
            if lab is not None:
                lab[j0:j1 + 1, i0:i1 + 1] = veh.vid
                continue
            tex = veh.texture
            th, tw = tex.shape
            sw, sh = (r - l) / tw, (b - tp) / th        # pixels per texel
            if sw < 1.0 or sh < 1.0:                      # minifying: average first, then warp
                tw2, th2 = max(1, round(tw * min(sw, 1.0))), max(1, round(th * min(sh, 1.0)))
                tex = cv2.resize(tex, (tw2, th2), interpolation=cv2.INTER_AREA)
                th, tw = tex.shape
            ax, ay = tw / (r - l), th / (b - tp)           # texels per pixel
            M = np.array([[ax, 0.0, (i0 - l) * ax - 0.5], [0.0, ay, (j0 - tp) * ay - 0.5]])
            patch = cv2.warpAffine(tex, M, (i1 - i0 + 1, j1 - j0 + 1),
                                   flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REPLICATE)
            hz = 1.0 - math.exp(-float(veh.z[t]) / 250.0)
            img[j0:j1 + 1, i0:i1 + 1] = patch * (1 - hz) + self._look.haze * hz
        if lab is not None:
            return lab
        if self.blur_sigma > 0:
            img = cv2.GaussianBlur(img, (0, 0), self.blur_sigma, borderType=cv2.BORDER_REPLICATE)
        if self.noise_sigma > 0:
            rng = np.random.default_rng([self.seed, 0xF7A3E, t])
            img = img + rng.standard_normal(img.shape, dtype=np.float32) * np.float32(self.noise_sigma)
        return np.clip(np.rint(img), 0, 255).astype(np.uint8)

    def frame(self, t: int) -> np.ndarray:
        """Frame t, (H, W) uint8."""
        return self._render(int(t), labels=False)

    def label_map(self, t: int) -> np.ndarray:
        """(H, W) int32: the id of the vehicle whose rectangle holds each pixel centre (nearest wins), -1 else."""
        return self._render(int(t), labels=True)

    # -- ground truth views ---------------------------------------------------------------------------
    def gt_frame(self, t: int) -> np.ndarray:
        return self.gt[self.gt["frame"] == t]

    def boxes(self, t: int) -> np.ndarray:
        """(N, 4) visible boxes [l, t, r, b] at frame t."""
        g = self.gt_frame(t)
        return np.stack([g["left"], g["top"], g["right"], g["bottom"]], axis=1) if len(g) else np.zeros((0, 4))

    def meta(self) -> dict:
        c = self.camera
        return {"name": self.name, "seed": self.seed, "n_frames": self.n_frames, "fps": self.fps,
                "width": c.width, "height": c.height, "focal_px": c.f, "horizon_row": c.yh, "cx": c.cx,
                "cam_height_m": c.cam_height, "ego_speed_mps": self.ego_speed, "noise_sigma": self.noise_sigma,
                "blur_sigma": self.blur_sigma,
                "vehicles": [{"id": v.vid, "width_m": v.width, "height_m": v.height, "dark": v.dark}
                             for v in self.vehicles]}


# ---------------------------------------------------------------------------------------------------------
# dynamics

def _longitudinal(rng, T, dt, z0, vz0, accel_sigma=0.25, hold_s=1.0, events=()):
    """Relative distance z(t) of a vehicle: relative speed vz0 plus piecewise-constant small
    accelerations (N(0, accel_sigma) m/s^2, redrawn every hold_s) and scripted ones
    `events` = [(t_start_s, t_end_s, accel)], integrated exactly per step."""
    hold = max(1, int(round(hold_s / dt)))
    n_hold = T // hold + 1
    a_rand = np.repeat(rng.normal(0.0, accel_sigma, n_hold), hold)[:T]
    a = a_rand.copy()
    ts = np.arange(T) * dt
    for t0, t1, acc in events:
        a[(ts >= t0) & (ts < t1)] += acc
    z = np.empty(T)
    z[0], vz = z0, vz0
    for i in range(1, T):
        z[i] = z[i - 1] + vz * dt + 0.5 * a[i - 1] * dt * dt
        vz += a[i - 1] * dt
    return z


def _lateral(rng, T, dt, x0, changes=(), wander=0.08):
    """Lateral position: lane changes [(t_start_s, duration_s, x_target)] with a minimum-jerk profile
    (10 s^3 - 15 s^4 + 6 s^5), plus a slow sinusoidal wander of amplitude `wander` m."""
    ts = np.arange(T) * dt
    x = np.full(T, float(x0))
    cur = float(x0)
    for t0, dur, target in sorted(changes):
        s = np.clip((ts - t0) / dur, 0.0, 1.0)
        prof = s ** 3 * (10 - 15 * s + 6 * s * s)
        x = x + (target - cur) * prof
        cur = float(target)
    period = rng.uniform(3.0, 6.0)
    return x + wander * np.sin(2 * np.pi * ts / period + rng.uniform(0, 2 * np.pi))


def _new_vehicle(rng, vid, x, z, dark=None, width=None, height=None):
    dark = bool(rng.random() < 0.5) if dark is None else dark
    w = rng.uniform(1.65, 1.9) if width is None else width
    h = rng.uniform(1.38, 1.58) if height is None else height
    return Vehicle(vid=vid, width=float(w), height=float(h), length=float(rng.uniform(4.0, 4.8)), x=x, z=z,
                   texture=_vehicle_texture(rng, w, h, dark), dark=dark)


L, E, R = -LANE_WIDTH, 0.0, LANE_WIDTH     # lane centres: left, ego, right


def _sc_follow(rng, T, dt):
    """A lead car in the ego lane with small relative accelerations, a second car further on the right."""
    v0 = _new_vehicle(rng, 0, _lateral(rng, T, dt, E), _longitudinal(rng, T, dt, rng.uniform(14, 20),
                                                                     rng.uniform(-0.6, 0.6)))
    v1 = _new_vehicle(rng, 1, _lateral(rng, T, dt, R), _longitudinal(rng, T, dt, rng.uniform(26, 34),
                                                                     rng.uniform(-1.0, 1.0)))
    return [v0, v1]


def _sc_lane_change(rng, T, dt):
    """A car on the right cuts into the ego lane; a farther car in the ego lane moves to the left lane."""
    t_end = T * dt
    a = _new_vehicle(rng, 0, _lateral(rng, T, dt, R, [(rng.uniform(0.8, 1.5), rng.uniform(2.5, 3.5), E)]),
                     _longitudinal(rng, T, dt, rng.uniform(16, 21), rng.uniform(-0.3, 0.5)))
    t_b = rng.uniform(0.4, max(0.5, 0.25 * t_end))
    b = _new_vehicle(rng, 1, _lateral(rng, T, dt, E, [(t_b, rng.uniform(2.5, 3.5), L)]),
                     _longitudinal(rng, T, dt, rng.uniform(30, 36), rng.uniform(0.0, 1.0)))
    return [a, b]


def _sc_overtake(rng, T, dt):
    """A faster car comes from behind on the left (entering truncated at the image edge), overtakes the
    lead car in the ego lane, cuts in ahead of it and is hidden by it; later the lead car moves to the
    right lane and uncovers it again."""
    lead_z = rng.uniform(16, 20)
    v = rng.uniform(5.0, 6.0)
    t_cut = (lead_z + 6.0 - 4.0) / v
    lead = _new_vehicle(rng, 0, _lateral(rng, T, dt, E, [(t_cut + 2.6, 2.5, R)]),
                        _longitudinal(rng, T, dt, lead_z, rng.uniform(-0.3, 0.2), accel_sigma=0.15))
    fast = _new_vehicle(rng, 1, _lateral(rng, T, dt, L, [(t_cut, 2.0, E)]),
                        _longitudinal(rng, T, dt, 4.0, v, accel_sigma=0.15,
                                      events=[(t_cut + 1.0, t_cut + 3.0, -1.8)]))
    return [lead, fast]


def _sc_occlusion(rng, T, dt):
    """A near car in the ego lane; a far car from the right lane passes behind it (fully hidden for a
    while) and returns to the right lane; a third car on the left."""
    near = _new_vehicle(rng, 0, _lateral(rng, T, dt, E, wander=0.05),
                        _longitudinal(rng, T, dt, rng.uniform(12, 15), rng.uniform(-0.2, 0.2), accel_sigma=0.1))
    t1 = rng.uniform(0.5, 0.9)
    far = _new_vehicle(rng, 1, _lateral(rng, T, dt, R, [(t1, 2.0, E), (t1 + 2.0 + rng.uniform(0.6, 1.2), 2.0, R)],
                                        wander=0.0),
                       _longitudinal(rng, T, dt, rng.uniform(28, 34), rng.uniform(-0.4, 0.4), accel_sigma=0.1))
    left = _new_vehicle(rng, 2, _lateral(rng, T, dt, L),
                        _longitudinal(rng, T, dt, rng.uniform(20, 26), rng.uniform(-1.0, 0.5)))
    return [near, far, left]


def _sc_traffic(rng, T, dt):
    """3-4 cars in random lanes and distances, each maybe changing lane once."""
    n = int(rng.integers(3, 5))
    lanes = [L, E, R]
    out = []
    used: list[tuple[float, float]] = []
    for vid in range(n):
        for _ in range(50):
            lane, z0 = lanes[int(rng.integers(0, 3))], float(rng.uniform(12, 40))
            if all(lane != ul or abs(z0 - uz) > 9.0 for ul, uz in used):
                break
        used.append((lane, z0))
        changes = []
        if rng.random() < 0.5:
            nb = [c for c in lanes if abs(c - lane) == LANE_WIDTH]
            target = nb[int(rng.integers(len(nb)))]
            changes = [(rng.uniform(0.5, max(0.6, T * dt - 3.5)), rng.uniform(2.5, 3.5), target)]
        out.append(_new_vehicle(rng, vid, _lateral(rng, T, dt, lane, changes),
                                _longitudinal(rng, T, dt, z0, rng.uniform(-1.0, 1.0))))
    return out


def _collides(vehicles) -> bool:
    """True if two vehicles ever overlap on the road (lateral extents and [z, z + length] both overlap,
    with 0.5 m of margin) in a frame where both are present."""
    for i, a in enumerate(vehicles):
        for b in vehicles[i + 1:]:
            both = np.isfinite(a.z) & np.isfinite(b.z)
            lat = np.abs(a.x - b.x) < (a.width + b.width) / 2 + 0.5
            lon = (a.z < b.z + b.length + 0.5) & (b.z < a.z + a.length + 0.5)
            if np.any(both & lat & lon):
                return True
    return False


SCENARIOS: dict[str, tuple[Callable, int]] = {
    "follow": (_sc_follow, 150),
    "lane_change": (_sc_lane_change, 180),
    "overtake": (_sc_overtake, 270),
    "occlusion": (_sc_occlusion, 180),
    "traffic": (_sc_traffic, 180),
}
"""name -> (builder(rng, n_frames, dt) -> [Vehicle], default number of frames at 30 fps)."""


def scenario_args(scenarios: dict, scenario: str, seed: int, n_frames: int | None, fps: float):
    """(builder, number of frames) of a scenario table entry, the arguments checked
    (ValueError naming the one that is wrong); shared with pyvehtrack.synth_motion."""
    if scenario not in scenarios:
        raise ValueError(f"scenario: unknown {scenario!r}; choose from {sorted(scenarios)}")
    if not fps > 0:
        raise ValueError("fps must be > 0")
    builder, default_n = scenarios[scenario]
    n = int(round(default_n * fps / 30.0)) if n_frames is None else int(n_frames)
    if n < 1:
        raise ValueError("n_frames must be >= 1")
    if int(seed) < 0:
        raise ValueError("seed must be >= 0")
    return builder, n


def make_sequence(scenario: str = "follow", seed: int = 0, *, camera: Camera | None = None,
                  n_frames: int | None = None, fps: float = 30.0, noise_sigma: float = 2.0,
                  blur_sigma: float = 0.6, ego_speed: float | None = None) -> Sequence:
    """One named scenario (see SCENARIOS), deterministic in (scenario, seed, arguments)."""
    builder, n = scenario_args(SCENARIOS, scenario, seed, n_frames, fps)
    # the scenario's name (not its position in SCENARIOS) enters the stream, so adding a scenario
    # never changes the others
    rng = np.random.default_rng([int(seed), zlib.crc32(scenario.encode())])
    for _ in range(100):       # redraw (deterministically) until no two vehicles overlap in the world
        vehicles = builder(rng, n, 1.0 / fps)
        if not _collides(vehicles):
            break
    else:
        raise RuntimeError(f"scenario {scenario!r} seed {seed}: could not draw a collision-free scene")
    speed = float(rng.uniform(15, 28)) if ego_speed is None else float(ego_speed)
    return Sequence(name=f"{scenario}_{int(seed)}", seed=int(seed), camera=camera or Camera(), vehicles=vehicles,
                    n_frames=n, fps=float(fps), ego_speed=speed, noise_sigma=float(noise_sigma),
                    blur_sigma=float(blur_sigma))


def make_set(n: int = 5, seed: int = 0, *, scenarios: _Seq[str] | None = None, **kw) -> list[Sequence]:
    """n sequences cycling through `scenarios` (default: all, in SCENARIOS order), each with its own seed
    derived from (seed, index). Keyword arguments go to make_sequence."""
    names = list(scenarios) if scenarios is not None else list(SCENARIOS)
    if n < 0:
        raise ValueError("n must be >= 0")
    ss = np.random.SeedSequence(int(seed))
    seeds = [int(s.generate_state(1)[0] & 0x7FFFFFFF) for s in ss.spawn(n)]
    return [make_sequence(names[i % len(names)], seeds[i], **kw) for i in range(n)]


# ---------------------------------------------------------------------------------------------------------
# detections and KITTI output

def gt_detections(seq: Sequence, sigma: float = 0.0, p_drop: float = 0.0, p_false: float = 0.0, seed: int = 0,
                  max_occlusion: float = 0.8, max_truncation: float = 0.5) -> list[np.ndarray]:
    """Per frame an (N, 5) float array [l, t, r, b, score] made from the GT: each box edge perturbed by
    N(0, sigma) px, each box dropped with probability p_drop, and with probability p_false per frame a
    false box on the road. Vehicles more occluded or truncated than the limits are not 'detected' (a
    detector cannot see a sliver). Rows are shuffled; deterministic in `seed`."""
    rng = np.random.default_rng([int(seed), 0xDE7])
    cam = seq.camera
    out = []
    for t in range(seq.n_frames):
        g = seq.gt_frame(t)
        g = g[(g["occlusion"] <= max_occlusion) & (g["truncation"] <= max_truncation)]
        boxes = np.stack([g["left"], g["top"], g["right"], g["bottom"]], axis=1) if len(g) else np.zeros((0, 4))
        keep = rng.random(len(boxes)) >= p_drop
        noise = rng.normal(0.0, sigma, boxes.shape) if sigma > 0 else np.zeros_like(boxes)
        boxes = (boxes + noise)[keep]
        scores = rng.uniform(0.6, 1.0, len(boxes))
        dets = np.column_stack([boxes, scores]) if len(boxes) else np.zeros((0, 5))
        if p_false > 0 and rng.random() < p_false:
            z = rng.uniform(10, 40)
            x = rng.uniform(-5, 5)
            l, tp, r, b = cam.rear_box(x, z, 1.8, 1.5)
            dets = np.vstack([dets, [l, tp, r, b, rng.uniform(0.3, 0.7)]])
        ok = (dets[:, 2] > dets[:, 0]) & (dets[:, 3] > dets[:, 1])
        dets = dets[ok]
        out.append(dets[rng.permutation(len(dets))])
    return out


def kitti_gt_lines(seq: Sequence) -> list[str]:
    """The GT in the KITTI tracking label format, one line per row: frame id Car truncated occluded
    alpha l t r b h w l x y z rotation_y, with the true 3D box (camera frame: y down, location = bottom
    centre of the 3D box, rotation_y = -pi/2 for a car driving away along z; alpha = ry - atan2(x, z))."""
    hc = seq.camera.cam_height
    lines = []
    for g in seq.gt:
        zc = g["z"] + g["length"] / 2
        ry = -math.pi / 2
        alpha = (ry - math.atan2(g["x"], zc) + math.pi) % (2 * math.pi) - math.pi
        lines.append(f"{g['frame']} {g['id']} Car {g['trunc_level']} {g['occ_level']} {alpha:.6f} "
                     f"{g['left']:.6f} {g['top']:.6f} {g['right']:.6f} {g['bottom']:.6f} "
                     f"{g['height']:.6f} {g['width']:.6f} {g['length']:.6f} "
                     f"{g['x']:.6f} {hc:.6f} {zc:.6f} {ry:.6f}")
    return lines


def write_kitti(seq: Sequence, folder: str | os.PathLike, *, frames: bool = True) -> dict:
    """Write <folder>/frames/000000.png ... (gray PNG), <folder>/gt.txt (KITTI tracking labels, see
    kitti_gt_lines) and <folder>/meta.json (camera, seed, sizes). Returns the paths written."""
    folder = os.fspath(folder)
    os.makedirs(folder, exist_ok=True)
    paths = {"gt": os.path.join(folder, "gt.txt"), "meta": os.path.join(folder, "meta.json")}
    if frames:
        fdir = os.path.join(folder, "frames")
        os.makedirs(fdir, exist_ok=True)
        for t, img in enumerate(seq.frames):
            p = os.path.join(fdir, f"{t:06d}.png")
            if not cv2.imwrite(p, img):
                raise OSError(f"could not write {p}")
        paths["frames"] = fdir
    with open(paths["gt"], "w") as fh:
        fh.write("\n".join(kitti_gt_lines(seq)) + ("\n" if len(seq.gt) else ""))
    with open(paths["meta"], "w") as fh:
        json.dump(seq.meta(), fh, indent=1)
    return paths
