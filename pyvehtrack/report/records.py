"""Per-frame records for the report: one pass of lanes -> detection -> tracking over a
recording, kept in the `track --json` schema

    {"frame": int, "tracks": [{"id", "box", "state", "velocity_px", "distance_m", "ttc_s",
                               "warning", "source"}]}

(null where unknown: distance, TTC and warning come from the geometry stage,
pyvehtrack.camera / camera.c, given a camera file), plus what the page draws besides the
tracks (`FrameInfo`: lanes, road area, detector boxes, lane width, vanishing row, the
per-stage run time measured here with time.perf_counter).

`PythonPipeline` is the small adapter over the existing Tracker / Detector / LaneDetector:
lanes run on every frame (the lane stage tracks its lines over frames), the detector every
`detect_every` frames on the road area of that frame's lane result, the tracker every
frame. When `pyvehtrack.Pipeline` (vt_pipeline) lands, its FrameResult maps onto the same
record and this adapter is the only thing to replace.

Truth files (`load_truth`): the lidar lead-distance CSV of kitti-raw-sfnd-ttc
(`derived_lidar_lead_distance.csv`, its ego_lane_min_x_m column as the geometry stage's
evaluation uses it), a one-object box CSV (`frame,left,top,right,bottom`,
e.g. tests/data/kitti_clip/lead_boxes.csv) or KITTI tracking labels (`frame id type ...`)."""
from __future__ import annotations

import csv
import json
import math
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..shared import WORK_WIDTH

# The lidar sits about 0.27 m behind the camera along x (kitti-raw-sfnd-ttc README): lidar
# ranges are moved to the camera by this much before they are compared with a camera range.
LIDAR_BEHIND_CAMERA_M = 0.27
STAGES = ("lanes", "detect", "track", "geometry")


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
    matched: set = field(default_factory=set)        # track ids a detector box confirmed this frame
    width: int | None = None                         # the frame's width (input pixels)


def _matched_ids(tracks, dets) -> set:
    """Ids of the tracks a detector box overlaps (IoU >= 0.5) on a detection frame."""
    from ..reference.tracker import box_iou
    if dets is None:
        return set()
    return {t.id for t in tracks if any(box_iou(t.box, d) >= 0.5 for d in dets)}


def track_record(frame: int, tracks, *, geometry=None) -> dict:
    """One frame's record in the `track --json` schema from Tracker tracks.

    source: the detector the track's box came from, as the pipeline names them ("shadow",
    "classifier", "flow", "model"); the Tracker's tracks all start from the shadow
    detector today. geometry: an optional callable(track) -> dict with distance_m /
    ttc_s / warning / ttc_points_s / ttc_fused_s (the camera stage and the block-scale TTC);
    without it those fields are null (unknown)."""
    out = []
    for t in tracks:
        src = getattr(t, "source", None) or "shadow"
        g = geometry(t) if geometry is not None else {}
        out.append({"id": int(t.id), "box": [int(v) for v in t.box], "state": t.state,
                    "velocity_px": [round(float(t.velocity[0]), 3), round(float(t.velocity[1]), 3)],
                    "distance_m": g.get("distance_m"), "ttc_s": g.get("ttc_s"),
                    "warning": g.get("warning"), "source": src,
                    "ttc_points_s": g.get("ttc_points_s"), "ttc_fused_s": g.get("ttc_fused_s")})
    return {"frame": int(frame), "tracks": out}


def _ms(v):
    """A record's number rounded to 3 decimals (ms, mm), None kept."""
    return None if v is None else round(float(v), 3)


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


def lane_vanishing_row(lr) -> float | None:
    """The vanishing row the camera stage's pitch uses: vt_lane_vanishing_row on the C
    lane result (the geometry stage's helper) when this build has it, else the straight
    fit of ego_vanishing_row. Input pixels."""
    try:
        from ..camera import lane_vanishing_row as stage_vp
    except ImportError:
        stage_vp = None
    if stage_vp is not None:
        return stage_vp(lr)
    from .. import _native
    raw = getattr(lr, "raw", None)
    if hasattr(_native, "lane_vanishing_row") and raw is not None and hasattr(raw, "scale"):
        h_seen = max(int(round(lr.x_left.shape[0] * lr.input_scale)), int(raw.h) * int(raw.scale))
        try:
            row, ok = _native.lane_vanishing_row(raw, h_seen)
        except _native.VtError:
            return None
        return ((row / 65536.0) + 0.5) / lr.input_scale - 0.5 if ok else None
    return None


def camera_stage():
    """(Camera, RangeEstimator) of the geometry stage (pyvehtrack.camera), or None when
    this build does not have it."""
    try:
        from ..camera import Camera, RangeEstimator
    except ImportError:
        return None
    return Camera, RangeEstimator


class PythonPipeline:
    """lanes (every frame) -> detector (every `detect_every` frames) -> tracker ->
    (with a camera and the geometry stage) distance, TTC, warning; each stage timed.

    step(frame) -> (record, FrameInfo). camera: the --camera JSON as a dict. With the
    geometry stage (pyvehtrack.camera) and a camera with height_m, its RangeEstimator
    gives distance_m (the filtered range), ttc_s (from it and its rate), warning (the FCW
    bit) and the pitch, as `pyvehtrack track --camera --json` does; without it, those
    stay null and the pitch is atan((cy - vanishing row) / fy) when the camera has fy, cy.
    `notes` collects what the page should say about missing stages. model: a whole-road
    classifier .npz (pyvehtrack.Detector(model=...)), or None for the ego-lane detector.
    measurement: the tracker's ("roi", "edges" or "roi+edges"; Tracker(measurement=...)).
    range_params: keyword arguments of the RangeEstimator (rear_offset, bottom_height,
    path_half_width; _check.range_options checks them), None: its defaults. ego_speed (m/s,
    None: unknown) and warn_ttc ("distance" / "fused": the TTC the warning decides on), as
    `track --ego-speed / --warn-ttc`; box_top ("cnn" / "tracker") as `track --box-top`."""

    def __init__(self, engine: str = "c", detect_every: int = 10, camera: dict | None = None,
                 fps: float = 10.0, geometry=None, model=None, measurement: str = "roi",
                 range_params: dict | None = None, ego_speed: float | None = None,
                 warn_ttc: str = "distance", box_top: str = "cnn", work_width=WORK_WIDTH):
        from ..detector import Detector
        from ..lane import LaneDetector
        from ..tracker import Tracker
        if isinstance(detect_every, bool) or not isinstance(detect_every, (int, np.integer)):
            raise TypeError(f"detect_every must be an int, got {type(detect_every).__name__}")
        from .._check import choice  # noqa: PLC0415
        choice(box_top, "box_top", ("cnn", "tracker"))
        if detect_every < 1:
            raise ValueError(f"detect_every must be >= 1, got {detect_every}")
        if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not math.isfinite(fps) or fps <= 0:
            raise ValueError(f"fps must be a number > 0, got {fps!r}")
        self.engine = engine
        self.lanes = LaneDetector(engine=engine, work_width=work_width)
        stage = camera_stage()
        file_cam = None
        if camera is not None and stage is not None and (geometry is None or model is not None):
            file_cam = stage[0].from_dict(camera)   # CameraFileError (a ValueError) names the key
        # The detector and tracker exactly as `pyvehtrack track` makes them (cli.common.make_detector,
        # Tracker(detector=...)): the tracker owns the detector, so the model's sources, scores and
        # tracker settings (birth search, ...) apply and the page shows the tracks `track` writes.
        # Whole-road detection is placed by the camera file's geometry when it has one (as `track
        # --camera --model`). The pipeline runs its own lane stage, so lanes run twice (the page's
        # lane plots come from self.lanes).
        self.detector = Detector(engine=engine, road="auto", model=None if model is None else str(model),
                                 camera=file_cam.road_camera() if file_cam is not None and model is not None
                                 else None, work_width=work_width)
        # with a camera, as `track --camera`: the pipeline's block-scale TTC too, whose fusion with
        # the distance/rate TTC is what `track` draws (ttc_fused_s)
        self.tracker = Tracker(engine=engine, detect_every=int(detect_every), detector=self.detector,
                               measurement=measurement, ttc_points=file_cam is not None,
                               fps=float(fps) if file_cam is not None else None,
                               cnn_track_top=box_top == "cnn")
        self.detect_every = int(detect_every)
        self.camera = camera
        self.fps = float(fps)
        self.range_params = dict(range_params or {})
        if warn_ttc not in ("distance", "fused"):
            raise ValueError(f"warn_ttc must be 'distance' or 'fused', got {warn_ttc!r}")
        self.ego_speed, self.warn_ttc = ego_speed, warn_ttc
        self.geometry = geometry
        self.notes: list = []
        self._cam = None            # the geometry stage's Camera, when usable
        self.pitch_source = "atan((cy - vanishing row) / fy) of the camera file"
        self._rng = None
        if camera is not None and stage is not None and geometry is None:
            cam = file_cam
            if cam.height_m is None:
                self.notes.append("The camera file has no height_m: the geometry stage cannot give distances.")
            else:
                from ..camera import fuse_ttc  # noqa: PLC0415  (the geometry stage is there)
                self._cam, self._fuse = cam, fuse_ttc
                self.pitch_source = ("the geometry stage's pitch (vt_pitch: the lanes' vanishing row, "
                                     "filtered and gated around the camera's nominal pitch)")
        elif camera is None:
            self.notes.append("No camera file (--camera): no distance, TTC or warning.")
        elif stage is None:
            self.notes.append("This build has no geometry stage (pyvehtrack.camera): no distance, TTC "
                              "or warning.")
        self.k = 0

    def step(self, frame, file: str = ""):
        from ..frames import to_gray
        gray = to_gray(frame)
        info = FrameInfo(frame=self.k, file=file, width=int(gray.shape[1]))
        t0 = time.perf_counter()
        try:
            lr = self.lanes.detect(gray)
        except ValueError:              # a frame below the lane stage's minimum size
            lr = None
        t1 = time.perf_counter()
        info.timing_ms["lanes"] = (t1 - t0) * 1e3
        dets = None
        t2 = time.perf_counter()
        tracks = self.tracker.step(frame)
        res = self.tracker.last_result
        # one pipeline call detects and tracks: on a detection frame its time is the
        # "detect" stage's (the detector dominates it), else the "track" stage's
        info.timing_ms["detect" if res.detection_frame else "track"] = (time.perf_counter() - t2) * 1e3
        if res.detection_frame:
            dets = np.asarray([b.box for b in res.boxes], np.int64).reshape(-1, 4)
            info.road = np.asarray(res.road) if len(res.road) >= 3 else None
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
        vp_stage = lane_vanishing_row(lr) if lr is not None else None
        info.vanishing_row = vp_stage if vp_stage is not None else ego_vanishing_row(info.lanes)
        geometry = self.geometry
        if self._cam is not None:
            t3 = time.perf_counter()
            if self._rng is None:
                self._rng = camera_stage()[1](self._cam, (gray.shape[1], gray.shape[0]), self.fps,
                                              engine=self.engine, **self.range_params)
            self._rng.update_pitch(vp_stage)
            outs = {o.id: o for o in self._rng.step(
                [(t.id, self._cam.undistort_box(t.box)) for t in tracks], self.ego_speed,
                ttc_points=({t.id: getattr(t, "ttc_points", None) for t in tracks}
                            if self.warn_ttc == "fused" else None))}
            info.timing_ms["geometry"] = (time.perf_counter() - t3) * 1e3
            info.pitch_deg = float(self._rng.pitch_deg)

            def geometry(t, outs=outs):
                # as `track --json` writes them: the filtered distance, the TTC from it and its
                # rate, the block-scale TTC and the two fused (camera.fuse_ttc, the pipeline's rule)
                o = outs.get(t.id)
                p = getattr(t, "ttc_points", None)
                g = {"ttc_points_s": _ms(p), "ttc_fused_s": _ms(self._fuse(p, None if o is None else o.ttc_dist))}
                if o is not None:
                    g.update(distance_m=_ms(o.dist_filt), ttc_s=_ms(o.ttc_dist), warning=bool(o.warning))
                return g
        else:
            f, cy = _cam_f_cy(self.camera)
            if f and cy is not None and info.vanishing_row is not None:
                info.pitch_deg = math.degrees(math.atan2(cy - info.vanishing_row, f))
        info.matched = _matched_ids(tracks, dets)
        rec = track_record(self.k, tracks, geometry=geometry)
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

    def ttc(self, half_window: int = 2, min_closing: float = 0.1) -> dict:
        """TTC from the ranges: d / -rate, the rate the slope of a least-squares line through
        the 2 * half_window + 1 ranges around the frame (a one-frame difference of lidar
        ranges is mostly noise; as tools/eval_kitti_range.py does); None where the range
        closes slower than min_closing m/s."""
        out = {}
        for k, d in self.ranges.items():
            ks = list(range(k - half_window, k + half_window + 1))
            if all(j in self.ranges for j in ks):
                rate = float(np.polyfit(np.array(ks) * self.dt, [self.ranges[j] for j in ks], 1)[0])
                out[k] = d / -rate if rate < -min_closing else None
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
            col = "ego_lane_min_x_m"       # the geometry stage's evaluation uses the same column
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
def companion_files(rec) -> dict:
    """{'truth': [paths], 'camera': path or None} for a recording, by the naming rule:
    folder REC: REC/gt.txt, REC/truth*.txt|csv, then REC.truth*.txt|csv beside it; camera
    REC/camera.json, else REC.camera.json beside it. Video DIR/S.ext: DIR/S.truth*.txt|csv
    and DIR/S.camera.json."""
    p = Path(rec)
    inside = p if p.is_dir() else None
    stem = p.name if p.is_dir() else p.stem
    beside = p.parent
    truth: list = []
    if inside is not None:
        truth += [q for q in [inside / "gt.txt"] if q.is_file()]
        truth += sorted(q for q in inside.glob("truth*") if q.suffix in (".txt", ".csv") and q.is_file())
    truth += sorted(q for q in beside.glob(f"{glob_escape(stem)}.truth*")
                    if q.suffix in (".txt", ".csv") and q.is_file())
    cams = ([inside / "camera.json"] if inside is not None else []) + [beside / f"{stem}.camera.json"]
    cam = next((q for q in cams if q.is_file()), None)
    return {"truth": [str(q) for q in truth], "camera": str(cam) if cam else None}


def glob_escape(s: str) -> str:
    return re.sub(r"([\[\]*?])", r"[\1]", s)


from ..cli.common import IMAGE_EXTS, VIDEO_EXTS  # noqa: E402  (the one list of file types)


def recording_frames(path):
    """(frame count or None, iterator of (file label, uint8 frame)) for a video, a folder
    of frames (image files in sorted name order) or one image. ValueError naming the path
    for anything that cannot be read (raised by the iterator for a frame that fails)."""
    import cv2
    p = Path(path)
    if not p.exists():
        raise ValueError(f"{path}: no such file or directory")
    if p.is_dir() and (p / "frames").is_dir() and not any(
            q.suffix.lower() in IMAGE_EXTS for q in p.iterdir() if q.is_file()):
        p = p / "frames"                # the layout pyvehtrack.synth.write_kitti writes
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
            from ..frames import read_video
            k = 0
            for img in read_video(cap):
                yield f"{p}#{k}", img
                k += 1
            if k == 0:
                raise ValueError(f"{path}: the video has no readable frame")
        return (n if n > 0 else None), gen_video()
    img = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise ValueError(f"{path}: cannot read as an image or video")
    return 1, iter([(str(p), img)])
