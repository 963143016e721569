"""The one thin, checked layer over the C core (cffi API mode).

Each function here maps 1:1 onto a C function: NumPy arrays are passed without
copies (a view struct pointing into the array's memory), and a negative
vt_status becomes a `VtError` naming the C function and the reason. Nothing else
happens here; the friendly API (pyvehtrack.image, ...) sits on top.

Set PYVEHTRACK_FFI=/path/to/_vtffi*.so to load another build of the extension
(the sanitizer build of `make check SAN=1` uses this).
"""
from __future__ import annotations

import importlib.machinery
import importlib.util
import os

import numpy as np


def _load_ffi_module():
    path = os.environ.get("PYVEHTRACK_FFI")
    if not path:
        try:
            from . import _vtffi
        except ImportError as e:
            raise ImportError(
                "pyvehtrack's C extension (pyvehtrack._vtffi) is not built: run `make setup` "
                "(pip install --no-build-isolation -e .), or point PYVEHTRACK_FFI at a build "
                "made by `make check`") from e
        return _vtffi
    loader = importlib.machinery.ExtensionFileLoader("pyvehtrack._vtffi", path)
    spec = importlib.util.spec_from_file_location("pyvehtrack._vtffi", path, loader=loader)
    if spec is None:
        raise ImportError(f"PYVEHTRACK_FFI={path!r} is not a loadable extension")
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    return mod


_mod = _load_ffi_module()
ffi = _mod.ffi
lib = _mod.lib


class VtError(ValueError):
    """A C function of the core returned a negative status.

    Attributes: `function` (the C name), `status` (the int code), `reason`
    (the core's name for the code) and `detail` (what the binding passed)."""

    def __init__(self, function: str, status: int, detail: str = ""):
        self.function = function
        self.status = int(status)
        self.reason = status_name(status)
        self.detail = detail
        msg = f"{function}: {self.reason} (status {self.status})"
        if detail:
            msg += f"; {detail}"
        super().__init__(msg)


def status_name(code: int) -> str:
    out = ffi.new("const char **")
    lib.vt_status_name(int(code), out)
    return ffi.string(out[0]).decode()


def _defaults(ctype: str):
    """A new `ctype` struct filled by the C function `<ctype>_default` (e.g.
    vt_tracker_cfg_default), so no default value is copied into Python."""
    cfg = ffi.new(ctype + " *")
    fn = ctype + "_default"
    check(fn, getattr(lib, fn)(cfg))
    return cfg


def check(function: str, status: int, detail: str = "") -> None:
    """Raise VtError for a negative status."""
    if status < 0:
        raise VtError(function, status, detail)


_VIEW_TYPES = {
    # numpy dtype -> (read-only struct, writable struct, C pointer type)
    np.dtype(np.uint8): ("vt_image_u8", "vt_image_u8_mut", "uint8_t *"),
    np.dtype(np.int16): (None, "vt_image_s16", "int16_t *"),
    np.dtype(np.uint32): (None, "vt_image_u32", "uint32_t *"),
}


def _describe(arr: np.ndarray) -> str:
    return f"array shape {arr.shape} dtype {arr.dtype} strides {arr.strides}"


def view(arr, name: str, *, writable: bool = False, dtype=np.uint8):
    """A C view struct over a 2-D NumPy array, without copying.

    The array must be 2-D with unit element stride along rows (row padding is
    fine). Sizes are not checked here: the C function checks them and its
    status says what is wrong. The caller must keep `arr` alive during the call."""
    if not isinstance(arr, np.ndarray):
        raise TypeError(f"{name}: expected a numpy.ndarray, got {type(arr).__name__}")
    dt = np.dtype(dtype)
    if arr.dtype != dt:
        raise TypeError(f"{name}: expected dtype {dt}, got {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D (h, w) array, got {arr.ndim}-D")
    ro, rw, ptype = _VIEW_TYPES[dt]
    if writable and not arr.flags.writeable:
        raise ValueError(f"{name}: output array is read-only")
    h, w = arr.shape
    item = dt.itemsize
    sy, sx = arr.strides
    if h > 0 and w > 0:
        if sx != item or sy < 0 or sy % item != 0:
            raise ValueError(f"{name}: rows must be contiguous with a non-negative row "
                             f"stride; {_describe(arr)} (use np.ascontiguousarray)")
    struct = rw if writable else (ro or rw)
    v = ffi.new(struct + " *")
    # from_buffer is the cheap path for contiguous arrays; a padded view has no
    # contiguous buffer, so its address is taken instead (the caller keeps it alive).
    if arr.flags.c_contiguous and arr.size:
        v.px = ffi.from_buffer(ptype[:-2] + "[]", arr, require_writable=writable)
    else:
        v.px = ffi.cast(ptype, arr.ctypes.data)
    v.w = w
    v.h = h
    v.stride = sy // item if h > 0 and w > 0 else w
    return v


# ---------------------------------------------------------------- image.h
def _unary(cname: str, src: np.ndarray, dst: np.ndarray, dst_dtype) -> None:
    vs = view(src, "src")
    vd = view(dst, "dst", writable=True, dtype=dst_dtype)
    check(cname, getattr(lib, cname)(vs, vd), f"src {src.shape}, dst {dst.shape}")


def filter_h101(src: np.ndarray, dst: np.ndarray) -> None:
    _unary("vt_filter_h101", src, dst, np.int16)


def sobel_x(src: np.ndarray, dst: np.ndarray) -> None:
    _unary("vt_sobel_x", src, dst, np.int16)


def sobel_y(src: np.ndarray, dst: np.ndarray) -> None:
    _unary("vt_sobel_y", src, dst, np.int16)


def pyr_down(src: np.ndarray, dst: np.ndarray) -> None:
    _unary("vt_pyr_down", src, dst, np.uint8)


def integral(src: np.ndarray, dst: np.ndarray) -> None:
    _unary("vt_integral", src, dst, np.uint32)


def box_sum(ii: np.ndarray, x: int, y: int, w: int, h: int) -> int:
    vi = view(ii, "ii", writable=True, dtype=np.uint32)
    out = ffi.new("uint32_t *")
    check("vt_box_sum", lib.vt_box_sum(vi, x, y, w, h, out),
          f"rect x={x} y={y} w={w} h={h} in integral {ii.shape}")
    return int(out[0])


def ncc_u8(a: np.ndarray, b: np.ndarray) -> int:
    va, vb = view(a, "a"), view(b, "b")
    out = ffi.new("vt_q14 *")
    check("vt_ncc_u8", lib.vt_ncc_u8(va, vb, out), f"a {a.shape}, b {b.shape}")
    return int(out[0])


def sad_u8(a: np.ndarray, b: np.ndarray) -> int:
    va, vb = view(a, "a"), view(b, "b")
    out = ffi.new("uint32_t *")
    check("vt_sad_u8", lib.vt_sad_u8(va, vb, out), f"a {a.shape}, b {b.shape}")
    return int(out[0])


# ---------------------------------------------------------------- trig.h
def sincos_q14(a: int) -> tuple[int, int]:
    s = ffi.new("vt_q14 *")
    c = ffi.new("vt_q14 *")
    check("vt_sincos_q14", lib.vt_sincos_q14(a, s, c), f"angle {a} quarter-degrees")
    return int(s[0]), int(c[0])


# ---------------------------------------------------------------- fixed.h
def div_round_s64(n: int, d: int) -> int:
    out = ffi.new("int64_t *")
    check("vt_div_round_s64", lib.vt_div_round_s64(n, d, out), f"{n} / {d}")
    return int(out[0])


def q16_div(a: int, b: int) -> int:
    out = ffi.new("vt_q16 *")
    check("vt_q16_div", lib.vt_q16_div(a, b, out), f"{a} / {b} (Q16)")
    return int(out[0])


def q16_recip(a: int) -> int:
    out = ffi.new("vt_q16 *")
    check("vt_q16_recip", lib.vt_q16_recip(a, out), f"1 / {a} (Q16)")
    return int(out[0])


# ================================================================ kalman.h
# (Kalman filter section; appended by the kf helper. Thin 1:1 wrappers: values
# are raw fixed-point ints, the friendly API is pyvehtrack.kalman.)
def kf_new():
    """A zeroed vt_kf owned by Python (dims 0: call kf_init or a model init)."""
    return ffi.new("vt_kf *")


def kf_init(kf, dim_x: int, dim_z: int) -> None:
    check("vt_kf_init", lib.vt_kf_init(kf, dim_x, dim_z), f"dim_x={dim_x}, dim_z={dim_z}")


def _kf_dims(kf) -> str:
    return "kf=NULL" if kf == ffi.NULL else f"dim_x={kf.dim_x}, dim_z={kf.dim_z}"


def kf_predict(kf) -> None:
    check("vt_kf_predict", lib.vt_kf_predict(kf), _kf_dims(kf))


def kf_update(kf, z_q16) -> None:
    """z_q16: dim_z ints in Q15.16 (C reads exactly dim_z of them)."""
    vals = [int(v) for v in z_q16]
    if kf != ffi.NULL and 1 <= kf.dim_z <= lib.VT_KF_MAX_Z and len(vals) != kf.dim_z:
        # C would read dim_z values from a shorter buffer: refuse here.
        raise ValueError(f"vt_kf_update: z has {len(vals)} values, the filter has "
                         f"dim_z={kf.dim_z}")
    z = ffi.new("vt_q16[]", vals) if vals else ffi.NULL
    check("vt_kf_update", lib.vt_kf_update(kf, z), f"{_kf_dims(kf)}, z={list(z_q16)} (Q16)")


def kf_accel_var(accel: int, p_max: int, p_zero: int) -> int:
    out = ffi.new("vt_q32 *")
    check("vt_kf_accel_var", lib.vt_kf_accel_var(accel, p_max, p_zero, out),
          f"accel={accel}, p_max={p_max}, p_zero={p_zero} (Q16)")
    return int(out[0])


def kf_model_cfg_default():
    return _defaults("vt_kf_model_cfg")


def _kf_cfg_detail(cfg) -> str:
    names = ("dt", "accel_x", "accel_y", "p_max", "p_zero", "meas_sigma_x", "meas_sigma_y",
             "init_sigma_pos", "init_sigma_vel")
    return "cfg (Q16) " + ", ".join(f"{n}={getattr(cfg, n)}" for n in names)


def kf_init_bottom_edge(kf, cfg, x1: int, y1: int, x2: int) -> None:
    check("vt_kf_init_bottom_edge", lib.vt_kf_init_bottom_edge(kf, cfg, x1, y1, x2),
          _kf_cfg_detail(cfg))


def kf_init_cv(kf, cfg, x: int, y: int) -> None:
    check("vt_kf_init_cv", lib.vt_kf_init_cv(kf, cfg, x, y), _kf_cfg_detail(cfg))
# ================================================================ end kalman.h


# ================================================================ tracker.h
TRACK_OUT_DTYPE = np.dtype([("id", np.int32), ("state", np.int32), ("left", np.int32),
                            ("top", np.int32), ("right", np.int32), ("bottom", np.int32),
                            ("vx", np.int32), ("vy", np.int32)])


def tracker_cfg_default():
    return _defaults("vt_tracker_cfg")


def tracker_new():
    tr = ffi.new("vt_tracker *")
    check("vt_tracker_init", lib.vt_tracker_init(tr))
    return tr


def _boxes_i32(dets, name: str) -> np.ndarray:
    a = np.asarray(dets if dets is not None else np.zeros((0, 4)))
    if a.size == 0:
        return np.zeros((0, 4), np.int32)
    if a.ndim != 2 or a.shape[1] != 4:
        raise ValueError(f"{name}: expected an (N, 4) array of [left, top, right, bottom], got shape {a.shape}")
    if not np.issubdtype(a.dtype, np.number) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: boxes must be finite numbers")
    if np.any(np.abs(a) > 2**30):
        raise ValueError(f"{name}: box coordinates out of range")
    return np.ascontiguousarray(np.rint(a), dtype=np.int32)


def tracker_step(tr, cfg, img: np.ndarray, detection_frame: bool, dets=None) -> np.ndarray:
    """One frame; returns the live tracks as a TRACK_OUT_DTYPE array (vx, vy in Q16)."""
    v = view(img, "img")
    boxes = _boxes_i32(dets, "dets")
    pdets = ffi.cast("vt_box *", boxes.ctypes.data) if len(boxes) else ffi.NULL
    cap = int(lib.VT_MAX_TRACKS)
    out = np.zeros(cap, TRACK_OUT_DTYPE)
    n = ffi.new("int32_t *")
    check("vt_tracker_step",
          lib.vt_tracker_step(tr, cfg, v, 1 if detection_frame else 0, pdets, len(boxes),
                              ffi.cast("vt_track_out *", out.ctypes.data), cap, n),
          f"img {img.shape}, {len(boxes)} detections")
    return out[: n[0]].copy()
# ================================================================ end tracker.h


# ================================================================ shadow.h, verify.h, detect.h
def shadow_cfg_default():
    return _defaults("vt_shadow_cfg")


def verify_cfg_default():
    return _defaults("vt_verify_cfg")


def detect_cfg_default():
    return _defaults("vt_detect_cfg")


def road_area(road, h: int):
    """A vt_road_area for an image of h rows from any object with y_top, y_bottom,
    x_left, x_right, lane_width (arrays of >= h entries, or None) and valid; None gives
    an invalid (empty) road. Values are clipped to int16; h must be 0..VT_MAX_HEIGHT."""
    r = ffi.new("vt_road_area *")
    n = int(lib.VT_MAX_HEIGHT)
    if not 0 <= h <= n:
        raise ValueError(f"road_area: {h} rows, the core holds at most {n}")
    r.height = h
    if road is None or not getattr(road, "valid", True):
        return r
    r.valid = 1
    r.y_top = int(np.clip(road.y_top, -2**31, 2**31 - 1))
    r.y_bottom = int(np.clip(road.y_bottom, -2**31, 2**31 - 1))
    for name in ("x_left", "x_right", "lane_width"):
        a = np.asarray(getattr(road, name))
        if a.ndim != 1 or a.shape[0] < h:
            raise ValueError(f"road_area: {name} needs one entry per image row ({h}), got shape {a.shape}")
        dst = np.frombuffer(ffi.buffer(getattr(r, name)), np.int16)
        dst[:h] = np.clip(a[:h], -32768, 32767).astype(np.int16)
    return r


_HYP_DTYPE = np.dtype(np.int32)


def _road_detail(road) -> str:
    if road is None or road == ffi.NULL:
        return "road NULL"
    return f"road rows {road.y_top}..{road.y_bottom} of {road.height}, valid {road.valid}"


def shadow_find(st, cfg, img: np.ndarray, road, out: np.ndarray, cap: int) -> int:
    """vt_shadow_find into out (an (M, 3) int32 array, M >= cap) -> number written."""
    v = view(img, "img")
    if out.dtype != _HYP_DTYPE or out.ndim != 2 or out.shape[1] != 3 or not out.flags.c_contiguous \
            or out.shape[0] < cap:
        raise ValueError(f"out: expected a C-contiguous (>= {cap}, 3) int32 array, got "
                         f"{out.shape} {out.dtype}")
    n = ffi.new("int32_t *")
    p = ffi.cast("vt_hypothesis *", out.ctypes.data) if out.shape[0] else ffi.NULL
    check("vt_shadow_find", lib.vt_shadow_find(st, cfg, v, road, p, cap, n),
          f"img {img.shape}, {_road_detail(road)}, cap {cap}")
    return int(n[0])


def verify(st, cfg, img: np.ndarray, hyps: np.ndarray, out: np.ndarray, cap: int) -> int:
    """vt_verify of hyps ((N, 3) int32 rows [row, x_start, x_end]) into out (an (M, 4)
    int32 array, M >= cap) -> number of boxes written."""
    v = view(img, "img")
    for name, a, k in (("hyps", hyps, 3), ("out", out, 4)):
        if a.dtype != np.int32 or a.ndim != 2 or a.shape[1] != k or not a.flags.c_contiguous:
            raise ValueError(f"{name}: expected a C-contiguous (N, {k}) int32 array, got "
                             f"{a.shape} {a.dtype}")
    if out.shape[0] < cap:
        raise ValueError(f"out: {out.shape[0]} rows for cap {cap}")
    n = ffi.new("int32_t *")
    ph = ffi.cast("vt_hypothesis *", hyps.ctypes.data) if hyps.shape[0] else ffi.NULL
    po = ffi.cast("vt_box *", out.ctypes.data) if out.shape[0] else ffi.NULL
    check("vt_verify", lib.vt_verify(st, cfg, v, ph, hyps.shape[0], po, cap, n),
          f"img {img.shape}, {hyps.shape[0]} hypotheses, cap {cap}")
    return int(n[0])


def detect(st, cfg, img: np.ndarray, road, out) -> tuple[np.ndarray, np.ndarray]:
    """vt_detect -> (hypotheses (N, 3) int32, boxes (M, 4) int32), copies of out's arrays."""
    v = view(img, "img")
    check("vt_detect", lib.vt_detect(st, cfg, v, road, out),
          f"img {img.shape}, {_road_detail(road)}")
    hyp = np.frombuffer(ffi.buffer(out.hyp), np.int32).reshape(-1, 3)[: out.n_hyp].copy()
    box = np.frombuffer(ffi.buffer(out.box), np.int32).reshape(-1, 4)[: out.n_boxes].copy()
    return hyp, box
# ================================================================ end shadow.h, verify.h, detect.h


# ================================================================ lane.h
# (lane section; thin 1:1 wrappers, raw fixed-point values; the friendly API is
# pyvehtrack.lane.)
def lane_cfg_default():
    return _defaults("vt_lane_cfg")


def lane_cfg_check(cfg) -> None:
    check("vt_lane_cfg_check", lib.vt_lane_cfg_check(cfg), "a field is out of range "
          "(see vt_lane_cfg_check in vehtrack/lane.h)")


def lane_state_new():
    """A zeroed vt_lane_state (a fresh tracker) owned by Python."""
    return ffi.new("vt_lane_state *")


def lane_reset(st) -> None:
    check("vt_lane_reset", lib.vt_lane_reset(st))


def lane_detect(cfg, st, img: np.ndarray, res, road=None) -> None:
    """vt_lane_detect into res (a vt_lane_result *) and road (a vt_road_area * or None)."""
    v = view(img, "img")
    check("vt_lane_detect", lib.vt_lane_detect(cfg, st, v, res, ffi.NULL if road is None else road),
          f"img {img.shape}")


def lane_line_x(line, y_q16: int) -> int:
    """vt_lane_line_x; line is a vt_lane_line * or a vt_lane_line (e.g. res.lines[k])."""
    if ffi.typeof(line).kind == "struct":
        line = ffi.addressof(line)
    out = ffi.new("vt_q16 *")
    check("vt_lane_line_x", lib.vt_lane_line_x(line, y_q16, out), f"y {y_q16} (Q16)")
    return int(out[0])
# ================================================================ end lane.h


# ================================================================ edge_track.h
# (thin 1:1 wrappers; the tracker selects this measurement with
# vt_tracker_cfg.measurement = VT_MEAS_EDGE_CURVES)
def edge_cfg_default():
    return _defaults("vt_edge_cfg")


def edge_ws_new():
    """A zeroed vt_edge_ws (5 bytes per pixel of VT_EDGE_MAX_PIXELS) owned by Python."""
    return ffi.new("vt_edge_ws *")


def tracker_set_edge_ws(tr, ws) -> None:
    """Attach ws (a vt_edge_ws *, or None to detach) to tr. The caller keeps ws alive
    as long as tr may step with the edge measurement (the tracker holds a pointer)."""
    check("vt_tracker_set_edge_ws", lib.vt_tracker_set_edge_ws(tr, ffi.NULL if ws is None else ws))


def pipeline_set_edge_ws(p, ws) -> None:
    """As tracker_set_edge_ws for a vt_pipeline's tracker (after vt_pipeline_init)."""
    check("vt_pipeline_set_edge_ws", lib.vt_pipeline_set_edge_ws(p, ffi.NULL if ws is None else ws))


def edge_template_new():
    return ffi.new("vt_edge_template *")


def _box(b, name: str):
    vals = [int(v) for v in b]
    if len(vals) != 4 or any(abs(v) > 2**30 for v in vals):
        raise ValueError(f"{name}: expected [left, top, right, bottom] integers, got {b!r}")
    return ffi.new("vt_box *", vals)


def edge_map(ws, cfg, img: np.ndarray, roi) -> None:
    v = view(img, "img")
    check("vt_edge_map", lib.vt_edge_map(v, cfg, _box(roi, "roi"), ws),
          f"img {getattr(img, 'shape', None)}, roi {list(roi)}")


def edge_ws_arrays(ws) -> tuple[np.ndarray, np.ndarray]:
    """Copies of the crop's curve labels (uint8, 1 on a curve) and 3-4 chamfer distances."""
    n = int(ws.w) * int(ws.h)
    lab = np.frombuffer(ffi.buffer(ws.lab, n), np.uint8).reshape(ws.h, ws.w).copy()
    dt = np.frombuffer(ffi.buffer(ws.u.dt, 2 * n), np.uint16).reshape(ws.h, ws.w).copy()
    return lab, dt


def edge_template_set(ws, box, tpl) -> int:
    n = ffi.new("int32_t *")
    check("vt_edge_template_set", lib.vt_edge_template_set(ws, _box(box, "box"), tpl, n),
          f"box {list(box)}")
    return int(n[0])


def edge_template_points(tpl) -> tuple[np.ndarray, np.ndarray]:
    n = int(tpl.n)
    return (np.array([tpl.x[i] for i in range(n)], np.int64),
            np.array([tpl.y[i] for i in range(n)], np.int64))


def edge_match(ws, cfg, tpl, cx: int, cy: int) -> tuple[int, int, int, int, bool]:
    """(dx, dy, scale_q8, score, found); all but found are meaningful only for a non-empty
    template."""
    dx, dy, s, sc, fd = (ffi.new("int32_t *") for _ in range(5))
    check("vt_edge_match", lib.vt_edge_match(ws, cfg, tpl, int(cx), int(cy), dx, dy, s, sc, fd),
          f"cx={cx}, cy={cy}")
    return int(dx[0]), int(dy[0]), int(s[0]), int(sc[0]), bool(fd[0])
# ================================================================ end edge_track.h
# ================================================================ camera.h
# Thin 1:1 wrappers (raw fixed-point ints; the friendly API is pyvehtrack.camera).
RANGE_OUT_DTYPE = np.dtype([("id", np.int32), ("flags", np.int32), ("fcw", np.int32),
                            ("lead_class", np.int32), ("distance", np.int32), ("sigma", np.int32),
                            ("dist_width", np.int32), ("dist_filt", np.int32), ("rate", np.int32), ("accel", np.int32),
                            ("ttc_dist", np.int32), ("ttc_scale", np.int32)])


def camera_cfg_default():
    return _defaults("vt_camera_cfg")


def camera_cfg_check(cam) -> None:
    check("vt_camera_cfg_check", lib.vt_camera_cfg_check(cam),
          "a camera field is out of range (see vt_camera_cfg_check in vehtrack/camera.h)")


def camera_row_distance(cam, tp: int, row: int) -> tuple[int, int]:
    d, ok = ffi.new("vt_q16 *"), ffi.new("int32_t *")
    check("vt_camera_row_distance", lib.vt_camera_row_distance(cam, tp, row, d, ok),
          f"tan_pitch={tp}, row={row} (Q16)")
    return int(d[0]), int(ok[0])


def camera_box_distance(cam, tp: int, box):
    b = ffi.new("vt_box *", [int(v) for v in box])
    out = ffi.new("vt_distance *")
    check("vt_camera_box_distance", lib.vt_camera_box_distance(cam, tp, b, out),
          f"tan_pitch={tp} (Q16), box={list(box)}")
    return out


def pitch_new(cam):
    st = ffi.new("vt_pitch_state *")
    check("vt_pitch_init", lib.vt_pitch_init(cam, st), "camera config")
    return st


def pitch_update(cam, st, vp_valid: int, vp_row: int) -> None:
    check("vt_pitch_update", lib.vt_pitch_update(cam, st, vp_valid, vp_row),
          f"vp_valid={vp_valid}, vp_row={vp_row} (Q16)")


def lane_vanishing_row(res, img_h: int) -> tuple[int, int]:
    row, ok = ffi.new("vt_q16 *"), ffi.new("int32_t *")
    check("vt_lane_vanishing_row", lib.vt_lane_vanishing_row(res, img_h, row, ok),
          f"img_h={img_h}, lane result {res.w}x{res.h} shift {res.shift}")
    return int(row[0]), int(ok[0])


def range_cfg_default():
    return _defaults("vt_range_cfg")


def range_cfg_check(cfg) -> None:
    check("vt_range_cfg_check", lib.vt_range_cfg_check(cfg),
          "a range field is out of range (see vt_range_cfg_check in vehtrack/camera.h)")


def fcw_step(cfg, st, ttc_valid: int, ttc: int, closing: int, lead_class: int) -> int:
    out = ffi.new("int32_t *")
    check("vt_fcw_step", lib.vt_fcw_step(cfg, st, ttc_valid, ttc, closing, lead_class, out),
          f"ttc_valid={ttc_valid}, ttc={ttc} (Q16), closing={closing}, lead_class={lead_class}")
    return int(out[0])


def range_new():
    st = ffi.new("vt_range_state *")
    check("vt_range_init", lib.vt_range_init(st))
    return st


def range_step(st, cfg, cam, tp: int, ego_speed: int, tracks: np.ndarray) -> np.ndarray:
    """tracks: a TRACK_OUT_DTYPE array (as tracker_step returns). Returns RANGE_OUT_DTYPE."""
    tr = np.ascontiguousarray(tracks, dtype=TRACK_OUT_DTYPE)
    n = len(tr)
    ptr = ffi.cast("vt_track_out *", tr.ctypes.data) if n else ffi.NULL
    cap = max(n, 1)
    out = np.zeros(cap, RANGE_OUT_DTYPE)
    n_out = ffi.new("int32_t *")
    check("vt_range_step", lib.vt_range_step(st, cfg, cam, tp, ego_speed, ptr, n,
                                             ffi.cast("vt_range_out *", out.ctypes.data), cap,
                                             n_out),
          f"{n} track(s), tan_pitch={tp}, ego_speed={ego_speed} (Q16)")
    return out[: int(n_out[0])].copy()
# ================================================================ end camera.h


# ================================================================ pipeline.h
def pipeline_cfg_default():
    return _defaults("vt_pipeline_cfg")


def pipeline_cfg_check(cfg) -> None:
    check("vt_pipeline_cfg_check", lib.vt_pipeline_cfg_check(cfg),
          "a stage configuration or policy is out of range (see vt_pipeline_cfg_check)")


def pipeline_new(cfg):
    """A vt_pipeline owned by Python, initialised with cfg (camera and model off)."""
    p = ffi.new("vt_pipeline *")
    check("vt_pipeline_init", lib.vt_pipeline_init(p, cfg, ffi.NULL, ffi.NULL),
          "a stage configuration or policy is out of range (see vt_pipeline_cfg_check)")
    return p


def pipeline_step(p, img: np.ndarray, out, road=None, dets=None) -> int:
    """vt_pipeline_step into out (a vt_frame_out *); with road (a vt_road_area *)
    vt_pipeline_step_road, with dets (an (N, 4) box array, N may be 0)
    vt_pipeline_step_dets. Returns the status (VT_OK, or VT_E_CAPACITY when more
    tracks were live than out holds); raises VtError on errors."""
    v = view(img, "img")
    if dets is not None:
        boxes = _boxes_i32(dets, "dets")
        pd = ffi.cast("vt_box *", boxes.ctypes.data) if len(boxes) else ffi.NULL
        name, s = "vt_pipeline_step_dets", lib.vt_pipeline_step_dets(p, v, pd, len(boxes), out)
    elif road is not None:
        name, s = "vt_pipeline_step_road", lib.vt_pipeline_step_road(p, v, road, out)
    else:
        name, s = "vt_pipeline_step", lib.vt_pipeline_step(p, v, out)
    detail = f"img {img.shape}"
    if dets is not None:
        # The caller's boxes go to the tracker stage as they are; it is the one that
        # refuses a bad box, so the message names it.
        detail += (f", {len(dets)} detections (the tracker stage, vt_tracker_step, refuses a box "
                   f"with left > right, top > bottom or coordinates beyond +-2^30)")
    if s != lib.VT_E_CAPACITY or dets is not None:
        check(name, s, detail)
    return int(s)


def pipeline_work_size(w: int, h: int, max_w: int, max_h: int) -> tuple[int, int]:
    ww, wh = ffi.new("int32_t *"), ffi.new("int32_t *")
    check("vt_pipeline_work_size", lib.vt_pipeline_work_size(w, h, max_w, max_h, ww, wh),
          f"{w}x{h} into {max_w}x{max_h}")
    return int(ww[0]), int(wh[0])


def fixed_road_area(fr, w: int, h: int):
    """A new vt_road_area holding the fixed trapezoid of a w x h frame."""
    road = ffi.new("vt_road_area *")
    check("vt_fixed_road_area", lib.vt_fixed_road_area(fr, w, h, road), f"frame {w}x{h}")
    return road
# ================================================================ end pipeline.h
