"""`pyvehtrack report`: run a recording once and write a self-contained HTML page.

    from pyvehtrack.report import make_report
    page = make_report("tests/data/kitti_clip", "r/", truth=["tests/data/kitti_clip/lead_boxes.csv"])

records.py: the per-frame records (the `track --json` schema) and the Python adapter over
the existing stages; render.py: the plots and the page."""
from __future__ import annotations

import sys
from pathlib import Path

from .._check import range_options, warning_options
from ..shared import WORK_WIDTH
from .records import (FrameInfo, PythonPipeline, Truth, companion_files, load_truth, read_camera,  # noqa: F401
                      read_records, recording_frames, track_record, write_records)
from .render import MAX_THUMBS, TrackTiles, annotate, pick_thumbs, render_html, thumbnail, write_page


def _video_fps(path) -> float:
    """A video's frame rate from its container, else 10 (KITTI's 10 Hz)."""
    from .records import VIDEO_EXTS
    p = Path(path)
    if p.is_file() and p.suffix.lower() in VIDEO_EXTS:
        import cv2
        cap = cv2.VideoCapture(str(p))
        fps = cap.get(cv2.CAP_PROP_FPS) if cap.isOpened() else 0.0
        cap.release()
        if fps and 0 < fps < 1000:
            return float(fps)
    return 10.0


def make_report(inputs, out_dir, *, truth="auto", camera="auto", engine: str = "c", detect_every: int = 10,
                progress: bool = True, records_json: bool = True, fps: float | None = None,
                model="default", measurement: str = "auto", rear_offset: float = 0.0,
                bottom_height: float = 0.0, path_half_width: float = 1.5, ego_speed: float | None = None,
                warn_ttc: str = "distance", box_top: str = "cnn", work_width=WORK_WIDTH) -> Path:
    """Run the pipeline over one recording (a video, a folder of frames or an image) and
    write out_dir/index.html (and out_dir/tracks.json, the records, when records_json).
    truth: truth file paths (see records.load_truth), or "auto": the files the naming rule
    finds (records.companion_files); camera: a camera JSON path or dict, None, or "auto".
    fps: frame rate (the range stage's time step, the truth TTC's); None: a video's own
    frame rate, else 10 (KITTI's).
    model: the whole-road classifier .npz, "default" (fullroad.default_model_path(engine):
    cnn_gray_l0_big.npz on the C engine, window_mlp_hog32.npz on the reference one, as `pyvehtrack
    track` without --model) or None (the thesis's ego-lane detector alone).
    measurement: the tracker's per-frame measurement ("roi", "edges", "roi+edges"), or "auto"
    (as `pyvehtrack track`: pyvehtrack.frames.auto_measurement, roi+edges for lossy-coded input).
    rear_offset, bottom_height, path_half_width (m): the range stage's corrections and the
    warning's ego path, as `pyvehtrack track --rear-offset / --bottom-height / --path-half-width`
    (camera.RangeEstimator); anything but their defaults needs a camera.
    ego_speed (m/s, None: unknown) and warn_ttc ("distance" or "fused"): as `pyvehtrack track
    --ego-speed / --warn-ttc`, the warning's lead class and the TTC it decides on; need a camera.
    box_top: "cnn" (default) or "tracker", as `pyvehtrack track --box-top` (Tracker(cnn_track_top=...)).
    work_width: frames wider than this are processed downscaled to it (Pipeline's work_width; None:
    only past the core's maximum), as `pyvehtrack track --work-width`.
    Returns the page path. ValueError / TypeError naming the argument for bad input."""
    from tqdm import tqdm

    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"out_dir {out_dir}: exists and is not a folder")
    if fps is None:
        fps = _video_fps(inputs)
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not fps > 0 or fps == float("inf"):
        raise ValueError(f"fps must be a number > 0, got {fps!r}")
    found = companion_files(inputs) if Path(inputs).exists() else {"truth": [], "camera": None}
    auto = []
    if isinstance(truth, str) and truth == "auto":
        truth = found["truth"]
        auto += [f"truth {t}" for t in truth]
    if isinstance(camera, str) and camera == "auto":
        camera = found["camera"]
        auto += [f"camera {camera}"] if camera else []
    cam = read_camera(camera) if isinstance(camera, (str, Path)) else camera
    if cam is not None and not isinstance(cam, dict):
        raise TypeError(f"camera: expected a path or a dict, got {type(cam).__name__}")
    rng = range_options(rear_offset, bottom_height, path_half_width, camera=cam is not None,
                        height_m=cam.get("height_m") if isinstance(cam, dict) else None)
    warning_options(ego_speed, warn_ttc)
    if cam is None and (ego_speed is not None or warn_ttc != "distance"):
        raise ValueError("ego_speed and warn_ttc need a camera")
    tr = load_truth(list(truth or ()), dt=1.0 / fps)
    total, frames = recording_frames(inputs)
    if isinstance(model, str) and model == "default":
        from ..fullroad import default_model_path
        model = default_model_path(engine)
    if model is not None and not Path(model).is_file():
        raise ValueError(f"model {model}: no such file")
    why = "given"
    if isinstance(measurement, str) and measurement == "auto":
        from ..frames import auto_measurement
        measurement, why = auto_measurement(inputs)
    pipe = PythonPipeline(engine=engine, detect_every=detect_every, camera=cam, fps=fps, model=model,
                          measurement=measurement, range_params=rng, ego_speed=ego_speed, warn_ttc=warn_ttc,
                          box_top=box_top, work_width=work_width)
    want = set(pick_thumbs(total)) if total is not None else None
    stride, kept = 1, {}
    records, infos = [], []
    tiles = TrackTiles()
    with tqdm(total=total, unit="frame", disable=not progress, file=sys.stderr, desc="report") as bar:
        for k, (file, frame) in enumerate(frames):
            rec, info = pipe.step(frame, file)
            records.append(rec)
            infos.append(info)
            tiles.add(frame, rec)
            if want is not None:
                if k in want:
                    kept[k] = thumbnail(annotate(frame, rec, info))
            elif k % stride == 0:       # unknown length: keep every stride-th, doubling the stride
                kept[k] = thumbnail(annotate(frame, rec, info))
                if len(kept) > 2 * MAX_THUMBS:
                    stride *= 2
                    kept = {j: v for j, v in kept.items() if j % stride == 0}
            bar.update(1)
    if want is None and kept:
        pick = {sorted(kept)[i] for i in pick_thumbs(len(kept))}
        kept = {j: v for j, v in kept.items() if j in pick}
    h, w = (frame.shape[:2] if records else (0, 0))
    meta = {"input": str(inputs), "frames": f"{len(records)} ({w}x{h}, {fps:g} Hz)", "engine": engine,
            "detect every": f"{detect_every} frames (lanes and tracking every frame)",
            "tracking measurement": f"{measurement} ({why})",
            "camera": (str(camera) if isinstance(camera, (str, Path)) else "given") if cam else "none",
            "truth": ", ".join(str(t) for t in truth) if truth else "none"}
    if cam:
        meta["range"] = (f"rear offset {rng['rear_offset']:g} m, bottom height {rng['bottom_height']:g} m, "
                         f"ego path +-{rng['path_half_width']:g} m"
                         + (f" around the car's centre line (the camera {abs(lat):g} m "
                            f"{'right' if lat > 0 else 'left'} of it)" if (lat := cam.get("lateral_m")) else ""))
        meta["warning"] = (f"on the {'fused' if warn_ttc == 'fused' else 'distance/rate'} TTC, ego speed "
                           + (f"{ego_speed:g} m/s" if ego_speed is not None else "unknown (the largest threshold)"))
    if auto:
        meta["found by name"] = "; ".join(auto)
    page = render_html(records, infos, sorted(kept.items()), title="pyvehtrack report: " + "/".join(Path(inputs).parts[-3:]),
                       meta=meta, truth=tr, stage_notes=pipe.notes,
                       pitch_source=pipe.pitch_source, track_tiles=tiles.pick())
    out_dir.mkdir(parents=True, exist_ok=True)
    if records_json:
        write_records(out_dir / "tracks.json", records)
    return write_page(out_dir, page)
