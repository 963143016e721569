"""Per-frame records for the report: one pass of lanes -> detection -> tracking over a
recording, kept in the `track --json` schema

    {"frame": int, "tracks": [{"id", "box", "state", "velocity_px", "distance_m", "ttc_s",
                               "warning", "source"}]}

(null where a stage that would fill a field is not in this build: distance, TTC and
warnings come from the geometry stage, camera.c), plus what the page draws besides the
tracks (`FrameInfo`: lanes, road area, detector boxes, lane width, vanishing row, the
per-stage run time measured here with time.perf_counter).

`PythonPipeline` is the small adapter over the existing Tracker / Detector / LaneDetector:
lanes run on every frame (the lane stage tracks its lines over frames), the detector every
`detect_every` frames on the road area of that frame's lane result, the tracker every
frame. When `pyvehtrack.Pipeline` (vt_pipeline) lands, its FrameResult maps onto the same
record and this adapter is the only thing to replace.

Truth files (`load_truth`): the lidar lead-distance CSV of kitti-raw-sfnd-ttc
(`derived_lidar_lead_distance.csv`), a one-object box CSV (`frame,left,top,right,bottom`,
e.g. tests/data/kitti_clip/lead_boxes.csv) or KITTI tracking labels (`frame id type ...`)."""
from __future__ import annotations

import csv
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# The lidar sits about 0.27 m behind the camera along x (kitti-raw-sfnd-ttc README): lidar
# ranges are moved to the camera by this much before they are compared with a camera range.
LIDAR_BEHIND_CAMERA_M = 0.27
STAGES = ("lanes", "detect", "track")


@dataclass
class FrameInfo:
    """What one frame's record does not hold but the page draws (input pixels)."""
    frame: int
    file: str = ""
    lanes: list = field(default_factory=list)        # [(side, (N, 2) int points)]
    road: np.ndarray | None = None                   # (N, 2) polygon or None
    detections: np.ndarray | None = None             # (N, 4) detector boxes, None on non-detection frames
    lane_width_px: float | None = None               # ego lane width at the road's bottom row
    lane_width_row: int | None = None
    vanishing_row: float | None = None               # where the ego lines meet (input row)
    pitch_deg: float | None = None                   # from the camera stage (or vanishing row + camera)
    timing_ms: dict = field(default_factory=dict)    # stage -> milliseconds


def track_record(frame: int, tracks, *, detections=None, geometry=None) -> dict:
    """One frame's record in the `track --json` schema from Tracker tracks.

    source: "detection" when the frame ran the detector and a detector box overlaps the
    track (IoU >= 0.5), else "search" (the tracker's own ROI search). geometry: an
    optional callable(track) -> dict with distance_m / ttc_s / warning (the camera stage);
    without it those fields are null."""
    from ..reference.tracker import box_iou
    out = []
    for t in tracks:
        src = "search"
        if detections is not None and any(box_iou(t.box, d) >= 0.5 for d in detections):
            src = "detection"
        g = geometry(t) if geometry is not None else {}
        out.append({"id": int(t.id), "box": [int(v) for v in t.box], "state": t.state,
                    "velocity_px": [round(float(t.velocity[0]), 3), round(float(t.velocity[1]), 3)],
                    "distance_m": g.get("distance_m"), "ttc_s": g.get("ttc_s"),
                    "warning": g.get("warning"), "source": src})
    return {"frame": int(frame), "tracks": out}


class _CachedLanes:
    """Hands the Detector the lane result already computed (and timed) for this frame, so
    the lane stage runs once per frame; any other image is detected afresh."""

    def __init__(self, lane_detector):
        self.inner, self.shape, self.result = lane_detector, None, None

    def detect(self, gray):
        if self.result is not None and tuple(gray.shape[:2]) == self.shape:
            return self.result
        return self.inner.detect(gray)


def read_camera(path) -> dict:
    """A camera JSON as a dict (ValueError naming the file when it is not a JSON object).
    Keys the report itself uses, when present: fy (or f / focal_px) and cy (pixels)."""
    try:
        cam = json.loads(Path(path).read_text())
    except OSError as e:
        raise ValueError(f"camera {path}: {e.strerror}") from None
    except json.JSONDecodeError as e:
        raise ValueError(f"camera {path}: not valid JSON ({e.msg}, line {e.lineno})") from None
    if not isinstance(cam, dict):
        raise ValueError(f"camera {path}: expected a JSON object")
    return cam


def _cam_f_cy(cam: dict | None):
    if not cam:
        return None, None
    f = next((cam[k] for k in ("fy", "f", "focal_px", "fx") if isinstance(cam.get(k), (int, float))), None)
    cy = cam.get("cy") if isinstance(cam.get("cy"), (int, float)) else None
    return f, cy


def ego_vanishing_row(lanes):
    """The row where straight lines fitted (least squares, x = a y + b) to the points of the
    two ego lines meet, or None (no pair, or lines that do not converge upwards). The
    lane stage's own vanishing point is kept only inside its search rows, which a frame
    cropped near the horizon never reaches; this fit always answers."""
    fits = {}
    for side, pts in lanes:
        if side in ("left", "right") and len(pts) >= 2 and np.ptp(pts[:, 1]) > 0:
            fits[side] = np.polyfit(pts[:, 1].astype(float), pts[:, 0].astype(float), 1)
    if len(fits) != 2:
        return None
    (al, bl), (ar, br) = fits["left"], fits["right"]
    if al - ar >= -1e-9:       # going up (y falling) the left line must move right, the right left
        return None
    return float((br - bl) / (al - ar))


class PythonPipeline:
    """lanes (every frame) -> detector (every `detect_every` frames) -> tracker, each timed.

    step(frame) -> (record, FrameInfo). camera: the dict of --camera (used for the pitch
    from the vanishing row: pitch = atan((cy - row) / fy), positive nose down)."""

    def __init__(self, engine: str = "c", detect_every: int = 10, camera: dict | None = None,
                 geometry=None):
        from ..detector import Detector
        from ..lane import LaneDetector
        from ..tracker import Tracker
        if int(detect_every) < 1:
            raise ValueError(f"detect_every must be >= 1, got {detect_every}")
        self.lanes = LaneDetector(engine=engine)
        self._cache = _CachedLanes(self.lanes)
        self.detector = Detector(engine=engine, road="auto", lane_detector=self._cache)
        self.tracker = Tracker(engine=engine, detect_every=int(detect_every), detector=None)
        self.detect_every = int(detect_every)
        self.camera = camera
        self.geometry = geometry
        self.k = 0

    def step(self, frame, file: str = ""):
        from ..frames import to_gray
        gray = to_gray(frame)
        info = FrameInfo(frame=self.k, file=file)
        t0 = time.perf_counter()
        try:
            lr = self.lanes.detect(gray)
        except ValueError:              # a frame below the lane stage's minimum size
            lr = None
        t1 = time.perf_counter()
        self._cache.shape, self._cache.result = tuple(gray.shape), lr
        info.timing_ms["lanes"] = (t1 - t0) * 1e3
        dets = None
        if self.k % self.detect_every == 0:
            t1 = time.perf_counter()
            res = self.detector.detect(gray)
            info.timing_ms["detect"] = (time.perf_counter() - t1) * 1e3
            dets = np.asarray(res.boxes, np.int64).reshape(-1, 4)
            info.road = res.road_polygon if len(res.road_polygon) >= 3 else None
        t2 = time.perf_counter()
        tracks = self.tracker.step(gray, detections=dets) if dets is not None else self.tracker.step(gray)
        info.timing_ms["track"] = (time.perf_counter() - t2) * 1e3
        info.detections = dets
        if lr is not None:
            info.lanes = [(ln.side, np.asarray(ln.points).astype(np.int64)) for ln in lr.lanes
                          if len(ln.points) >= 2]
            if lr.road_valid and len(lr.road) >= 3:
                if info.road is None:
                    info.road = np.asarray(lr.road)
                row = int(lr.road_y_bottom)
                if 0 <= row < len(lr.lane_width) and lr.lane_width[row] > 0:
                    info.lane_width_px, info.lane_width_row = float(lr.lane_width[row]), row
            info.vanishing_row = ego_vanishing_row(info.lanes)
            f, cy = _cam_f_cy(self.camera)
            if f and cy is not None and info.vanishing_row is not None:
                info.pitch_deg = math.degrees(math.atan2(cy - info.vanishing_row, f))
        rec = track_record(self.k, tracks, detections=dets, geometry=self.geometry)
        self.k += 1
        return rec, info


# ====================================================================== truth
@dataclass
class Truth:
    """Everything the truth files gave: ranges (frame -> metres, at the camera), lead boxes
    (frame -> box, one object) and/or labelled tracks (KITTI rows with ids)."""
    ranges: dict = field(default_factory=dict)
    boxes: dict = field(default_factory=dict)
    labels: np.ndarray | None = None
    sources: list = field(default_factory=list)
    dt: float = 0.1

    def ttc(self, half_window: int = 2) -> dict:
        """TTC from the ranges: d / (-dd/dt), dd/dt a central difference over +-half_window
        frames (a one-frame difference of lidar ranges is mostly noise); None where the
        range does not shrink."""
        out = {}
        for k, d in self.ranges.items():
            a, b = k - half_window, k + half_window
            if a in self.ranges and b in self.ranges:
                rate = (self.ranges[b] - self.ranges[a]) / ((b - a) * self.dt)
                out[k] = d / -rate if rate < -1e-6 else None
        return out


def load_truth(paths, dt: float = 0.1) -> Truth:
    """Read one or more truth files (see the module doc); ValueError naming the file for
    anything unreadable or of an unknown layout."""
    tr = Truth(dt=dt)
    for p in paths or []:
        p = Path(p)
        if not p.is_file():
            raise ValueError(f"truth {p}: no such file")
        text = p.read_text(errors="replace")
        first = text.splitlines()[0] if text.strip() else ""
        if "ego_lane_" in first and "frame" in first:
            rows = list(csv.DictReader(text.splitlines()))
            col = "ego_lane_median_of_20_closest_x_m"
            if col not in rows[0]:
                col = next(c for c in rows[0] if c.startswith("ego_lane_") and c.endswith("_m"))
            for r in rows:
                try:
                    tr.ranges[int(r["frame"])] = float(r[col]) - LIDAR_BEHIND_CAMERA_M
                except (TypeError, ValueError):
                    continue
            tr.sources.append(f"{p.name}: lidar lead range ({col}, moved {LIDAR_BEHIND_CAMERA_M} m to the camera)")
        elif first.replace(" ", "").startswith("frame,left,top,right,bottom"):
            for r in csv.DictReader(text.splitlines()):
                tr.boxes[int(r["frame"])] = [float(r[k]) for k in ("left", "top", "right", "bottom")]
            tr.sources.append(f"{p.name}: one-object (lead car) boxes")
        else:
            from ..eval.kitti import read_kitti
            try:
                lab = read_kitti(p)
            except (ValueError, IndexError) as e:
                raise ValueError(f"truth {p}: neither a lidar range CSV, a frame,left,top,right,bottom "
                                 f"CSV nor KITTI tracking labels ({e})") from None
            tr.labels = lab if tr.labels is None else np.concatenate([tr.labels, lab])
            tr.sources.append(f"{p.name}: KITTI tracking labels ({len(np.unique(lab['id']))} ids)")
    return tr


# ====================================================================== JSON
def _jsonable(v):
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.floating,)):
        return float(v)
    raise TypeError(type(v).__name__)


def write_records(path, records) -> None:
    """The records as `track --json` writes them: a JSON list, one frame per line."""
    Path(path).write_text("[\n" + ",\n".join(json.dumps(r, default=_jsonable) for r in records) + "\n]\n")


def read_records(path) -> list:
    recs = json.loads(Path(path).read_text())
    if not isinstance(recs, list) or not all(isinstance(r, dict) and "frame" in r and "tracks" in r
                                             for r in recs):
        raise ValueError(f"{path}: expected a list of {{'frame', 'tracks'}} records")
    return recs


# ====================================================================== input
from ..cli.common import IMAGE_EXTS, VIDEO_EXTS  # noqa: E402  (the one list of file types)


def recording_frames(path):
    """(frame count or None, iterator of (file label, uint8 frame)) for a video, a folder
    of frames (image files in sorted name order) or one image. ValueError naming the path
    for anything that cannot be read (raised by the iterator for a frame that fails)."""
    import cv2
    p = Path(path)
    if not p.exists():
        raise ValueError(f"{path}: no such file or directory")
    if p.is_dir():
        files = sorted(q for q in p.iterdir() if q.is_file() and q.suffix.lower() in IMAGE_EXTS)
        if not files:
            raise ValueError(f"{path}: folder holds no image files")

        def gen_images():
            for q in files:
                img = cv2.imread(str(q), cv2.IMREAD_UNCHANGED)
                if img is None:
                    raise ValueError(f"{q}: cannot read as an image")
                if img.dtype == np.uint16:
                    img = (img >> 8).astype(np.uint8)
                if img.dtype != np.uint8:
                    raise ValueError(f"{q}: unsupported pixel type {img.dtype}")
                yield str(q), img
        return len(files), gen_images()
    if p.suffix.lower() in VIDEO_EXTS:
        cap = cv2.VideoCapture(str(p))
        if not cap.isOpened():
            raise ValueError(f"{path}: cannot open as a video")
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))

        def gen_video():
            k = 0
            try:
                while True:
                    ok, img = cap.read()
                    if not ok:
                        break
                    yield f"{p}#{k}", img
                    k += 1
            finally:
                cap.release()
            if k == 0:
                raise ValueError(f"{path}: the video has no readable frame")
        return (n if n > 0 else None), gen_video()
    img = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise ValueError(f"{path}: cannot read as an image or video")
    return 1, iter([(str(p), img)])
