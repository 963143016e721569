"""`pyvehtrack calibrate`: a camera file from chessboard pictures (OpenCV).

    pyvehtrack calibrate IMAGES... --pattern 9x6 [--square-mm S] [--height-m H]
                         [--pitch-deg P] [--lateral-m L] --out CAMERA.json

Finds the inner corners of the chessboard (cv2.findChessboardCorners, refined with
cornerSubPix) in every picture, then cv2.calibrateCamera gives fx, fy, cx, cy and the
distortion coefficients (OpenCV order k1 k2 p1 p2 k3), in pixels of these pictures: take
them with the camera and resolution that will film the road. The camera's height above
the road cannot come from a chessboard: give it with --height-m, or add "height_m" to the
file later (distances need it); nor can the camera's mounting offset right of the car's
centre line, --lateral-m, which centres the collision warning's ego corridor on the car.
--square-mm only scales the board's pose, which the camera file does not keep; it is
accepted for the record."""
from __future__ import annotations

import re
import sys

from .common import CliError, Outputs, add_command, frame_sources, read_image

EXAMPLES = """examples:
  pyvehtrack calibrate camera_cal/*.jpg --pattern 9x6 --height-m 1.2 --out camera.json
  pyvehtrack track drive.mp4 --camera camera.json --out annotated.mp4 --json tracks.json"""

MIN_VIEWS = 3   # calibrateCamera solves 4 intrinsics + 5 distortion terms: a few views at least


def register(sub) -> None:
    p = add_command(sub, "calibrate", help="camera intrinsics from chessboard pictures (a camera file)",
                       description=__doc__.split("\n\n", 2)[2].replace("\n", " "), epilog=EXAMPLES)
    p.add_argument("inputs", nargs="+", metavar="IMAGE", help="chessboard pictures (files or folders)")
    p.add_argument("--pattern", required=True, metavar="COLSxROWS",
                   help="inner corners per row and per column, e.g. 9x6")
    p.add_argument("--square-mm", type=float, default=25.0, metavar="S",
                   help="side of a square, mm (default 25; does not change the intrinsics)")
    p.add_argument("--height-m", type=float, default=None, metavar="H",
                   help="camera height above the road, m (not measurable from a chessboard)")
    p.add_argument("--pitch-deg", type=float, default=None, metavar="P",
                   help="nominal pitch, degrees, positive looking down (optional)")
    p.add_argument("--lateral-m", type=float, default=None, metavar="L",
                   help="the camera's mounting offset right of the car's centre line, m, -5..5 (optional; "
                        "the warning's ego corridor is centred on the car)")
    p.add_argument("--out", required=True, metavar="CAMERA.json", help="the camera file to write")
    p.add_argument("--min-views", type=int, default=MIN_VIEWS, metavar="N",
                   help=f"views with the board found needed (default {MIN_VIEWS})")
    p.set_defaults(func=run)


def parse_pattern(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text or "")
    if not m:
        raise CliError(f"--pattern {text!r}: expected COLSxROWS inner corners, e.g. 9x6")
    cols, rows = int(m.group(1)), int(m.group(2))
    if cols < 2 or rows < 2 or cols > 100 or rows > 100:
        raise CliError(f"--pattern {text}: each count must be in 2..100 inner corners")
    return cols, rows


def run(args) -> int:
    import math

    import cv2
    import numpy as np

    from ..camera import Camera, CameraFileError

    cols, rows = parse_pattern(args.pattern)
    if not (math.isfinite(args.square_mm) and args.square_mm > 0):
        raise CliError(f"--square-mm {args.square_mm}: must be a positive number")
    if args.height_m is not None and not (math.isfinite(args.height_m) and 0 < args.height_m <= 100):
        raise CliError(f"--height-m {args.height_m}: must be in (0, 100] metres")
    if args.pitch_deg is not None and not (math.isfinite(args.pitch_deg) and abs(args.pitch_deg) <= 45):
        raise CliError(f"--pitch-deg {args.pitch_deg}: must be within +-45 degrees")
    if args.lateral_m is not None and not (math.isfinite(args.lateral_m) and abs(args.lateral_m) <= 5):
        raise CliError(f"--lateral-m {args.lateral_m}: must be within +-5 metres")
    if args.min_views < 1:
        raise CliError(f"--min-views {args.min_views}: must be >= 1")
    sources = frame_sources(args.inputs)
    if any(kind != "image" for kind, _ in sources):
        raise CliError("calibrate takes pictures (image files or folders of them), not videos")
    board = np.zeros((cols * rows, 3), np.float32)
    board[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * float(args.square_mm)
    obj, img_pts, used, size = [], [], [], None
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    with Outputs() as outs:
        tmp = outs.reserve("--out", args.out)
        for _kind, path in sources:
            img = read_image(path)
            gray = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
            s = (gray.shape[1], gray.shape[0])
            if size is None:
                size = s
            elif s != size:
                # intrinsics are per resolution: a picture of another size cannot join
                print(f"calibrate: {path}: {s[0]}x{s[1]} pixels, the first picture has {size[0]}x{size[1]}: "
                      "skipped", file=sys.stderr)
                continue
            found, corners = cv2.findChessboardCorners(gray, (cols, rows), None)
            if not found:
                print(f"calibrate: {path}: no {cols}x{rows} board found, skipped", file=sys.stderr)
                continue
            # refine within a quarter of the smallest corner spacing (at most OpenCV's usual
            # 11 px): a larger window reaches the next corner on small pictures
            pts = corners.reshape(rows, cols, 2)
            gap = min(np.linalg.norm(np.diff(pts, axis=0), axis=2).min(),
                      np.linalg.norm(np.diff(pts, axis=1), axis=2).min())
            win = int(max(2, min(11, gap // 4)))
            corners = cv2.cornerSubPix(gray, corners, (win, win), (-1, -1), crit)
            obj.append(board)
            img_pts.append(corners)
            used.append(path)
        if len(used) < args.min_views:
            raise CliError(f"the {cols}x{rows} board was found in {len(used)} of {len(sources)} picture(s); "
                           f"{args.min_views} needed (check --pattern: inner corners, not squares)")
        rms, k, dist, _r, _t = cv2.calibrateCamera(obj, img_pts, size, None, None)
        try:
            cam = Camera(fx=float(k[0, 0]), fy=float(k[1, 1]), cx=float(k[0, 2]), cy=float(k[1, 2]),
                         height_m=args.height_m, pitch_deg=args.pitch_deg, lateral_m=args.lateral_m,
                         dist=[float(v) for v in np.ravel(dist)[:5]], image_size=size)
        except CameraFileError as e:
            raise CliError(f"calibration gave an unusable camera ({e}); use more, sharper views") from None
        cam.save(tmp)
        outs.commit()
    print(f"{len(used)} of {len(sources)} picture(s) used, RMS reprojection error {rms:.3f} px; "
          f"fx {cam.fx:.1f} fy {cam.fy:.1f} cx {cam.cx:.1f} cy {cam.cy:.1f} ({size[0]}x{size[1]}); "
          f"camera: {args.out}" + ("" if args.height_m is not None else
                                   " (no height_m: add it before computing distances)"))
    return 0
