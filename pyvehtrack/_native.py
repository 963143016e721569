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


def resize_area(src: np.ndarray, dst: np.ndarray) -> None:
    _unary("vt_resize_area", src, dst, np.uint8)


def pyr_down_rect(src: np.ndarray, dst: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> None:
    """vt_pyr_down_rect: the level-image pixels [x0, x1) x [y0, y1) of dst only."""
    vs = view(src, "src")
    vd = view(dst, "dst", writable=True)
    check("vt_pyr_down_rect", lib.vt_pyr_down_rect(vs, vd, x0, y0, x1, y1),
          f"rect x0={x0} y0={y0} x1={x1} y1={y1}, src {src.shape}, dst {dst.shape}")


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
    check("vt_lane_detect", lib.vt_lane_detect(st, cfg, v, res, ffi.NULL if road is None else road),
          f"img {img.shape}")


def lane_road_all(res, img_w: int, img_h: int, road) -> None:
    """vt_lane_road_all: the road area over all lanes of res into road (vt_road_area *)."""
    check("vt_lane_road_all", lib.vt_lane_road_all(res, img_w, img_h, road),
          f"frame {img_w}x{img_h}")


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
# vt_tracker_cfg.measurement = VT_MEAS_EDGE_CURVES, or VT_MEAS_ROI_EDGES as the fallback)
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
    check("vt_edge_map", lib.vt_edge_map(ws, cfg, v, _box(roi, "roi")),
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
    check("vt_pitch_init", lib.vt_pitch_init(st, cam), "camera config")
    return st


def pitch_update(cam, st, vp_valid: int, vp_row: int) -> None:
    check("vt_pitch_update", lib.vt_pitch_update(st, cam, vp_valid, vp_row),
          f"vp_valid={vp_valid}, vp_row={vp_row} (Q16)")


def lane_vanishing_row(res, img_h: int) -> tuple[int, int]:
    row, ok = ffi.new("vt_q16 *"), ffi.new("int32_t *")
    check("vt_lane_vanishing_row", lib.vt_lane_vanishing_row(res, img_h, row, ok),
          f"img_h={img_h}, lane result {res.w}x{res.h} scale {res.scale}")
    return int(row[0]), int(ok[0])


def range_cfg_default():
    return _defaults("vt_range_cfg")


def range_cfg_check(cfg) -> None:
    check("vt_range_cfg_check", lib.vt_range_cfg_check(cfg),
          "a range field is out of range (see vt_range_cfg_check in vehtrack/camera.h)")


def fcw_step(cfg, st, ttc_valid: int, ttc: int, closing: int, lead_class: int) -> int:
    out = ffi.new("int32_t *")
    check("vt_fcw_step", lib.vt_fcw_step(st, cfg, ttc_valid, ttc, closing, lead_class, out),
          f"ttc_valid={ttc_valid}, ttc={ttc} (Q16), closing={closing}, lead_class={lead_class}")
    return int(out[0])


def range_new():
    st = ffi.new("vt_range_state *")
    check("vt_range_init", lib.vt_range_init(st))
    return st


def _track_array(tracks):
    """(the contiguous TRACK_OUT_DTYPE array, its vt_track_out * or NULL, its length); the
    array is returned so that it outlives the call that reads the pointer."""
    tr = np.ascontiguousarray(tracks, dtype=TRACK_OUT_DTYPE)
    return tr, (ffi.cast("vt_track_out *", tr.ctypes.data) if len(tr) else ffi.NULL), len(tr)


def range_step(st, cfg, cam, tp: int, ego_speed: int, tracks: np.ndarray, ttc_points=None,
               fuse_permille: int = 0) -> np.ndarray:
    """tracks: a TRACK_OUT_DTYPE array (as tracker_step returns). ttc_points: None, or one
    Q16 block-scale TTC per track (negative: none) for vt_range_step_fused. Returns
    RANGE_OUT_DTYPE."""
    tr, ptr, n = _track_array(tracks)
    cap = max(n, 1)
    out = np.zeros(cap, RANGE_OUT_DTYPE)
    n_out = ffi.new("int32_t *")
    if ttc_points is None:
        pts = ffi.NULL
    else:
        arr = np.ascontiguousarray(ttc_points, np.int32)
        if arr.shape != (n,):
            raise ValueError(f"ttc_points: one per track ({n}), got shape {arr.shape}")
        pts = ffi.new("vt_q16[]", [int(v) for v in arr]) if n else ffi.NULL
    check("vt_range_step_fused", lib.vt_range_step_fused(st, cfg, cam, tp, ego_speed, ptr, n, pts,
                                                         fuse_permille,
                                                         ffi.cast("vt_range_out *", out.ctypes.data),
                                                         cap, n_out),
          f"{n} track(s), tan_pitch={tp}, ego_speed={ego_speed} (Q16), fuse_permille={fuse_permille}")
    return out[: int(n_out[0])].copy()
# ================================================================ end camera.h
# ================================================================ ttc_scale.h
TTC_OUT_DTYPE = np.dtype([("id", np.int32), ("flags", np.int32), ("blocks", np.int32),
                          ("matched", np.int32), ("pairs", np.int32), ("scale", np.int32),
                          ("ttc", np.int32), ("lag", np.int32)])


def ttc_cfg_default():
    cfg = ffi.new("vt_ttc_cfg *")
    check("vt_ttc_cfg_default", lib.vt_ttc_cfg_default(cfg))
    return cfg


def ttc_cfg_check(cfg) -> None:
    check("vt_ttc_cfg_check", lib.vt_ttc_cfg_check(cfg), "a vt_ttc_cfg field is out of range")


def ttc_new():
    st = ffi.new("vt_ttc_state *")
    check("vt_ttc_init", lib.vt_ttc_init(st))
    return st


def ttc_step(st, cfg, grey: np.ndarray, tracks: np.ndarray) -> np.ndarray:
    """grey: (h, w) uint8; tracks: a TRACK_OUT_DTYPE array. Returns TTC_OUT_DTYPE rows."""
    v = view(grey, "grey")
    tr, ptr, n = _track_array(tracks)
    cap = max(n, 1)
    out = np.zeros(cap, TTC_OUT_DTYPE)
    n_out = ffi.new("int32_t *")
    st_ = lib.vt_ttc_step(st, cfg, v, ptr, n, ffi.cast("vt_ttc_out *", out.ctypes.data), cap, n_out)
    if st_ != lib.VT_E_CAPACITY:
        check("vt_ttc_step", st_, f"{n} track(s), frame {grey.shape[1]}x{grey.shape[0]}")
    return out[: int(n_out[0])].copy()
# ================================================================ end ttc_scale.h
# ================================================================ windows.h
WINDOW_DTYPE = np.dtype([("level", "<i4"), ("size", "<i4"), ("x", "<i4"), ("y", "<i4")])
SCORED_BOX_DTYPE = np.dtype([("left", "<i4"), ("top", "<i4"), ("right", "<i4"), ("bottom", "<i4"),
                             ("score", "<i4"), ("source", "<i4")])


def win_cfg_default():
    return _defaults("vt_win_cfg")


def camera_min(fx: float, horizon_y: int, height_mm: int, hood_y: int):
    """A checked vt_camera_min (fx in px, stored in Q4, rounded to nearest)."""
    c = ffi.new("vt_camera_min *")
    for name, v in (("horizon_y", horizon_y), ("height_mm", height_mm), ("hood_y", hood_y)):
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool):
            raise TypeError(f"camera {name}: expected an int, got {type(v).__name__}")
    if not np.isfinite(fx) or not 1 <= fx <= 2 ** 20:
        raise ValueError(f"camera fx: expected 1..2^20 px, got {fx!r}")
    c.fx_q4, c.horizon_y, c.height_mm, c.hood_y = int(round(fx * 16)), int(horizon_y), int(height_mm), int(hood_y)
    check("vt_camera_min_check", lib.vt_camera_min_check(c),
          f"horizon_y {horizon_y}, height_mm {height_mm}, hood_y {hood_y}")
    return c


def road_from_camera(cfg, cam, w: int, h: int):
    r = ffi.new("vt_road_area *")
    check("vt_road_from_camera", lib.vt_road_from_camera(cfg, cam, int(w), int(h), r), f"{w}x{h}")
    return r


def windows_level(cfg, cam, road, w: int, h: int, level: int) -> np.ndarray:
    """vt_windows_level -> structured WINDOW_DTYPE array (every window of the level)."""
    n = ffi.new("int32_t *")
    rd = ffi.NULL if road is None else road
    check("vt_windows_level", lib.vt_windows_level(cfg, cam, rd, int(w), int(h), int(level), ffi.NULL, 0, n),
          f"{w}x{h} level {level}")
    out = np.zeros(max(1, n[0]), WINDOW_DTYPE)
    check("vt_windows_level",
          lib.vt_windows_level(cfg, cam, rd, int(w), int(h), int(level),
                               ffi.cast("vt_window *", out.ctypes.data), len(out), n),
          f"{w}x{h} level {level}")
    return out[: n[0]].copy()


def nms(boxes: np.ndarray, iou_permille: int, contain_permille: int = 1000) -> np.ndarray:
    """vt_nms on a copy of a SCORED_BOX_DTYPE array -> the kept boxes, in order (limits in
    permille, 0..1000)."""
    a = np.ascontiguousarray(boxes, SCORED_BOX_DTYPE).copy()
    n = ffi.new("int32_t *")
    p = ffi.cast("vt_scored_box *", a.ctypes.data) if len(a) else ffi.NULL
    check("vt_nms", lib.vt_nms(p, len(a), int(iou_permille), int(contain_permille), n), f"{len(a)} boxes")
    return a[: n[0]].copy()
# ================================================================ end windows.h
# ================================================================ hood.h
def hood_cfg_default():
    return _defaults("vt_hood_cfg")


def hood_find(gray: np.ndarray, cfg=None) -> dict:
    """vt_hood_find on a 2-D uint8 frame -> {'found', 'row', 'n_cols', 'n_strong',
    'path_end'} (keys as pyvehtrack.reference.hood.find)."""
    c = hood_cfg_default() if cfg is None else cfg
    if isinstance(c, ffi.CData) and ffi.typeof(c).kind == "struct":   # a field of a larger struct
        c = ffi.addressof(c)
    st = ffi.new("vt_hood_state *")
    res = ffi.new("vt_hood_result *")
    g = np.asarray(gray)
    v = view(g, "gray")
    check("vt_hood_find", lib.vt_hood_find(st, c, v, res), _describe(g))
    return {"found": bool(res.found), "row": int(res.row), "n_cols": int(res.n_cols),
            "n_strong": int(res.n_strong), "path_end": int(res.path_end)}
# ================================================================ end hood.h


# ================================================================ fulldet.h
def fulldet_cfg_default():
    return _defaults("vt_fulldet_cfg")


def fulldet(st, cfg, cam, img: np.ndarray, road, scorer, out) -> np.ndarray:
    """vt_fulldet -> the kept boxes as a SCORED_BOX_DTYPE array (a copy)."""
    v = view(img, "img")
    check("vt_fulldet", lib.vt_fulldet(st, cfg, cam, v, road, ffi.NULL if scorer is None else scorer, out),
          f"img {img.shape}, {_road_detail(road)}")
    n = out.n_boxes
    a = np.frombuffer(ffi.buffer(out.box), SCORED_BOX_DTYPE)[:n].copy()
    return a
def fulldet_verify(ws, model, img: np.ndarray, score_min: int, out) -> np.ndarray:
    """vt_fulldet_verify on the result `out` in place -> the kept boxes (a copy)."""
    v = view(img, "img")
    check("vt_fulldet_verify", lib.vt_fulldet_verify(ws, model, v, int(score_min), out),
          f"img {img.shape}, {out.n_boxes} boxes")
    return np.frombuffer(ffi.buffer(out.box), SCORED_BOX_DTYPE)[:out.n_boxes].copy()


def fulldet_rerank(st, ws, model, cfg, img: np.ndarray, out) -> np.ndarray:
    """vt_fulldet_rerank on the result `out` in place -> its boxes (a copy)."""
    v = view(img, "img")
    check("vt_fulldet_rerank", lib.vt_fulldet_rerank(st, ws, model, cfg, v, out),
          f"img {img.shape}, {out.n_cand} candidates")
    return np.frombuffer(ffi.buffer(out.box), SCORED_BOX_DTYPE)[:out.n_boxes].copy()


def fulldet_wide_cfg_default():
    return _defaults("vt_fulldet_wide_cfg")


def fulldet_wide(st, ws, wcfg, win, model, cam, img: np.ndarray, road, out) -> np.ndarray:
    """vt_fulldet_wide, appending to the result `out` in place -> its boxes (a copy)."""
    v = view(img, "img")
    check("vt_fulldet_wide", lib.vt_fulldet_wide(st, ws, wcfg, win, model, cam, v, road, out),
          f"img {img.shape}, {_road_detail(road)}, {out.n_boxes} boxes")
    return np.frombuffer(ffi.buffer(out.box), SCORED_BOX_DTYPE)[:out.n_boxes].copy()


def box_regressor(margin_permille: int, sources: int, win_w: int, win_h: int, w_q, w_shift, b_q16):
    """A vt_box_regressor: four HOG linear models (rows of w_q: left, top, right, bottom;
    w_shift and b_q16 one per side) over one window. Returns (regressor, keepalive)."""
    w = np.asarray(w_q)
    if w.ndim != 2 or w.shape[0] != 4:
        raise ValueError(f"w_q: expected a (4, dim) integer array, got shape {w.shape}")
    shifts, biases = np.asarray(w_shift).reshape(-1), np.asarray(b_q16).reshape(-1)
    if shifts.shape != (4,) or biases.shape != (4,):
        raise ValueError(f"w_shift, b_q16: expected 4 values each, got {shifts.shape} and {biases.shape}")
    r = ffi.new("vt_box_regressor *")
    r.margin_permille, r.sources = int(margin_permille), int(sources)
    keep = []
    for k in range(4):
        m, buf = svm_model(int(lib.VT_DESC_HOG), win_w, win_h, w[k], int(shifts[k]), int(biases[k]))
        r.side[k] = m[0]
        keep.append(buf)
    check("vt_box_regressor_check", lib.vt_box_regressor_check(r),
          f"margin {margin_permille} permille, sources {sources}")
    return r, keep


def box_regress(ws, reg, img: np.ndarray, box) -> tuple:
    """vt_box_regress of one inclusive box -> the moved box (l, t, r, b)."""
    v = view(img, "img")
    b = ffi.new("vt_box *", [int(x) for x in box])
    o = ffi.new("vt_box *")
    check("vt_box_regress", lib.vt_box_regress(ws, reg, v, b, o), f"img {img.shape}, box {list(box)}")
    return (int(o.left), int(o.top), int(o.right), int(o.bottom))


def fulldet_refine(ws, reg, img: np.ndarray, out) -> np.ndarray:
    """vt_fulldet_refine on the result `out` in place -> its boxes (a copy)."""
    v = view(img, "img")
    check("vt_fulldet_refine", lib.vt_fulldet_refine(ws, reg, v, out), f"img {img.shape}, {out.n_boxes} boxes")
    return np.frombuffer(ffi.buffer(out.box), SCORED_BOX_DTYPE)[:out.n_boxes].copy()

def box_rescorer(win_w: int, win_h: int, w_q, w_shift: int, b_q16: int, margin_permille: int, depth: int,
                 feat, thr, leaf_q16, bias_q16: int, score_min_q16: int, nms_iou_permille: int,
                 nms_contain_permille: int, side_keep: int = 0, side_score_min_q16: int = 0):
    """A vt_box_rescorer: a HOG linear model (w_q, w_shift, b_q16) over a win_w x win_h
    window and boosted trees (feat, thr: (T, 2^depth - 1); leaf_q16: (T, 2^depth)).
    Returns (rescorer, keepalive)."""
    depth = int(depth)
    if not 1 <= depth <= int(lib.VT_RESCORE_MAX_DEPTH):
        raise ValueError(f"rescorer depth: expected 1..{int(lib.VT_RESCORE_MAX_DEPTH)}, got {depth}")
    f, t, lf = np.asarray(feat), np.asarray(thr), np.asarray(leaf_q16)
    n_in = (1 << depth) - 1
    if f.ndim != 2 or f.shape[1] != n_in or t.shape != f.shape or lf.shape != (f.shape[0], n_in + 1):
        raise ValueError(f"rescorer trees: feat {f.shape}, thr {t.shape}, leaf {lf.shape} do not fit "
                         f"trees of depth {depth}")
    if f.size and (f.min() < 0 or f.max() > 255):
        raise ValueError("rescorer feat: indices must fit a byte")
    for name, a in (("thr", t), ("leaf_q16", lf)):
        if a.size and (a.min() < -2 ** 31 or a.max() >= 2 ** 31):
            raise ValueError(f"rescorer {name}: values must fit int32")
    r = ffi.new("vt_box_rescorer *")
    m, wbuf = svm_model(int(lib.VT_DESC_HOG), win_w, win_h, w_q, int(w_shift), int(b_q16))
    r.hog = m[0]
    keep = [wbuf, ffi.new("uint8_t[]", max(1, f.size)), ffi.new("int32_t[]", max(1, t.size)),
            ffi.new("int32_t[]", max(1, lf.size))]
    for buf, a in zip(keep[1:], (f, t, lf)):
        for i, v in enumerate(a.ravel().tolist()):
            buf[i] = int(v)
    r.feat, r.thr, r.leaf = keep[1], keep[2], keep[3]
    r.margin_permille, r.n_trees, r.depth = int(margin_permille), int(f.shape[0]), depth
    r.bias, r.score_min = int(bias_q16), int(score_min_q16)
    r.nms_iou_permille, r.nms_contain_permille = int(nms_iou_permille), int(nms_contain_permille)
    if int(side_keep) not in (0, 1):
        raise ValueError(f"rescorer side_keep: expected 0 or 1, got {side_keep}")
    if not -2 ** 31 <= int(side_score_min_q16) < 2 ** 31:
        raise ValueError(f"rescorer side_score_min_q16: must fit int32, got {side_score_min_q16}")
    r.side_keep, r.side_score_min = int(side_keep), int(side_score_min_q16)
    check("vt_box_rescorer_check", lib.vt_box_rescorer_check(r),
          f"{f.shape[0]} trees of depth {depth}, margin {margin_permille}, NMS {nms_iou_permille} / "
          f"{nms_contain_permille} permille")
    return r, keep


def box_rescore_trees(r, f) -> int:
    """vt_box_rescore_trees of one feature vector (VT_RESCORE_N_FEAT ints)."""
    a = np.asarray(f).reshape(-1)
    if a.shape != (int(lib.VT_RESCORE_N_FEAT),):
        raise ValueError(f"rescore features: expected {int(lib.VT_RESCORE_N_FEAT)} values, got {a.shape}")
    buf = ffi.new("int32_t[]", [int(v) for v in a])
    out = ffi.new("int32_t *")
    check("vt_box_rescore_trees", lib.vt_box_rescore_trees(r, buf, out), "features")
    return int(out[0])


def box_rescore_features(ws, r, cam, img: np.ndarray, box, score: int) -> np.ndarray:
    """vt_box_rescore_features of one inclusive box with its first-stage score (Q16)."""
    v = view(img, "img")
    b = ffi.new("vt_scored_box *")
    b.box.left, b.box.top, b.box.right, b.box.bottom = (int(x) for x in box)
    b.score, b.source = int(score), int(lib.VT_SRC_WINDOW)
    out = ffi.new("int32_t[]", int(lib.VT_RESCORE_N_FEAT))
    check("vt_box_rescore_features", lib.vt_box_rescore_features(ws, r, cam, v, b, out),
          f"img {img.shape}, box {list(box)}")
    return np.array(list(out), np.int64)


def fulldet_rescore(ws, r, cam, img: np.ndarray, out) -> np.ndarray:
    """vt_fulldet_rescore on the result `out` in place -> its boxes (a copy)."""
    v = view(img, "img")
    check("vt_fulldet_rescore", lib.vt_fulldet_rescore(ws, r, cam, v, out),
          f"img {img.shape}, {out.n_boxes} boxes")
    return np.frombuffer(ffi.buffer(out.box), SCORED_BOX_DTYPE)[:out.n_boxes].copy()
# ================================================================ end fulldet.h

# ================================================================ classify.h
# (thin 1:1 wrappers; descriptors are uint16 Q15, scores int Q16; the friendly
# API is pyvehtrack.classify.)
def svm_model(kind: int, win_w: int, win_h: int, w_q, w_shift: int, bias_q16: int,
              threshold_q16: int = 0):
    """A vt_svm_model over a copy of the int16 weights; returns (model, keepalive)
    -- keep the second alive as long as the model is used."""
    w = np.ascontiguousarray(np.asarray(w_q), dtype=np.int16)
    if w.ndim != 1:
        raise ValueError(f"w_q: expected a 1-D array, got shape {w.shape}")
    m = ffi.new("vt_svm_model *")
    m.kind, m.win_w, m.win_h, m.dim = int(kind), int(win_w), int(win_h), int(w.shape[0])
    m.w_shift, m.bias_q16, m.threshold_q16 = int(w_shift), int(bias_q16), int(threshold_q16)
    buf = ffi.new("int16_t[]", max(1, w.shape[0]))
    ffi.buffer(buf)[: w.nbytes] = w.tobytes()
    m.w = buf
    check("vt_svm_model_check", lib.vt_svm_model_check(m),
          f"kind={kind} window {win_w}x{win_h} dim={w.shape[0]} w_shift={w_shift}")
    return m, buf


def svm_default_model(kind: int):
    out = ffi.new("const vt_svm_model **")
    check("vt_svm_default_model", lib.vt_svm_default_model(int(kind), out),
          f"kind={kind} (no default model of this kind is built in)")
    return out[0]


def hog_ws_new():
    return ffi.new("vt_hog_ws *")


def gist_ws_new():
    return ffi.new("vt_gist_ws *")


def box_ws_new():
    return ffi.new("vt_cls_box_ws *")


def hog_prepare(ws, img: np.ndarray) -> None:
    v = view(img, "img")
    check("vt_hog_prepare", lib.vt_hog_prepare(ws, v), f"img {img.shape}")


def gist_prepare(ws, img: np.ndarray) -> None:
    v = view(img, "img")
    check("vt_gist_prepare", lib.vt_gist_prepare(ws, v), f"img {img.shape}")


def _descriptor(cname: str, ws, cx: int, cy: int, win_w: int, win_h: int) -> np.ndarray:
    cap = int(lib.VT_CLS_MAX_DIM)
    out = np.zeros(cap, np.uint16)
    n = ffi.new("int32_t *")
    check(cname, getattr(lib, cname)(ws, int(cx), int(cy), int(win_w), int(win_h),
                                     ffi.cast("uint16_t *", out.ctypes.data), cap, n),
          f"window {win_w}x{win_h} at cell ({cx}, {cy}) of a prepared "
          f"{ws.cells_x}x{ws.cells_y}-cell image")
    return out[: n[0]].copy()


def hog_descriptor(ws, cx: int, cy: int, win_w: int, win_h: int) -> np.ndarray:
    return _descriptor("vt_hog_descriptor", ws, cx, cy, win_w, win_h)


def gist_descriptor(ws, cx: int, cy: int, win_w: int, win_h: int) -> np.ndarray:
    return _descriptor("vt_gist_descriptor", ws, cx, cy, win_w, win_h)


def hog_window_score(ws, model, cx: int, cy: int) -> int:
    out = ffi.new("int32_t *")
    check("vt_hog_window_score", lib.vt_hog_window_score(ws, model, int(cx), int(cy), out),
          f"window at cell ({cx}, {cy}) of a prepared {ws.cells_x}x{ws.cells_y}-cell image")
    return int(out[0])


def hog_scan(ws, model, cx0: int, cy0: int, ncx: int, ncy: int) -> np.ndarray:
    """Scores (Q16) of every window position, an (ncy, ncx) int32 array."""
    if ncx < 1 or ncy < 1:
        raise ValueError(f"hog_scan: ncx={ncx}, ncy={ncy} must be >= 1")
    out = np.zeros((ncy, ncx), np.int32)
    check("vt_hog_scan", lib.vt_hog_scan(ws, model, int(cx0), int(cy0), int(ncx), int(ncy),
                                         ffi.cast("int32_t *", out.ctypes.data), out.size),
          f"positions ({cx0}, {cy0}) + {ncx}x{ncy} on {ws.cells_x}x{ws.cells_y} cells")
    return out


def _decision(function: str, model, desc: np.ndarray, detail: str = "") -> int:
    """A classifier's decision value (vt_svm_decision / vt_mlp_decision) for a 1-D
    uint16 descriptor."""
    d = np.ascontiguousarray(desc, dtype=np.uint16)
    if d.ndim != 1:
        raise ValueError(f"desc: expected a 1-D array, got shape {d.shape}")
    out = ffi.new("int32_t *")
    p = ffi.cast("uint16_t *", d.ctypes.data) if d.size else ffi.NULL
    check(function, getattr(lib, function)(model, p, d.shape[0], out), f"descriptor of {d.shape[0]} values{detail}")
    return int(out[0])


def svm_decision(model, desc: np.ndarray) -> int:
    return _decision("vt_svm_decision", model, desc,
                     f", model dim {model.dim if model != ffi.NULL else 'NULL'}")


def resample_area(src: np.ndarray, box, out_w: int, out_h: int) -> np.ndarray:
    v = view(src, "src")
    b = ffi.new("vt_box *", [int(x) for x in box])
    dst = np.zeros((max(out_h, 0), max(out_w, 0)), np.uint8)
    vd = view(dst, "dst", writable=True)
    vd.w, vd.h = int(out_w), int(out_h)
    check("vt_resample_area", lib.vt_resample_area(v, b, vd),
          f"src {src.shape}, box {list(box)}, out {out_w}x{out_h}")
    return dst


def _classify_box(function: str, ws, model, frame: np.ndarray, box) -> int:
    """vt_classify_box / vt_classify_box_mlp: the score of one box of a frame."""
    v = view(frame, "frame")
    b = ffi.new("vt_box *", [int(x) for x in box])
    out = ffi.new("int32_t *")
    check(function, getattr(lib, function)(ws, model, v, b, out), f"frame {frame.shape}, box {list(box)}")
    return int(out[0])


def classify_box(ws, model, frame: np.ndarray, box) -> int:
    return _classify_box("vt_classify_box", ws, model, frame, box)


def mlp_model(kind: int, win_w: int, win_h: int, w1_q, w1_shift: int, b1_q16, w2_q, w2_shift: int,
              b2_q16: int, threshold_q16: int = 0):
    """A vt_mlp_model over copies of the arrays; returns (model, keepalive)."""
    w1 = np.ascontiguousarray(np.asarray(w1_q), dtype=np.int16)
    b1 = np.ascontiguousarray(np.asarray(b1_q16), dtype=np.int32).ravel()
    w2 = np.ascontiguousarray(np.asarray(w2_q), dtype=np.int16).ravel()
    if w1.ndim != 2 or w1.shape[0] != b1.shape[0] or w1.shape[0] != w2.shape[0]:
        raise ValueError(f"mlp_model: w1 {w1.shape}, b1 {b1.shape}, w2 {w2.shape} disagree")
    m = ffi.new("vt_mlp_model *")
    m.kind, m.win_w, m.win_h, m.dim, m.hidden = int(kind), int(win_w), int(win_h), w1.shape[1], w1.shape[0]
    m.w1_shift, m.w2_shift, m.b2_q16, m.threshold_q16 = int(w1_shift), int(w2_shift), int(b2_q16), int(threshold_q16)
    keep = [ffi.new("int16_t[]", w1.ravel().tolist() or [0]), ffi.new("int32_t[]", b1.tolist() or [0]),
            ffi.new("int16_t[]", w2.tolist() or [0])]
    m.w1, m.b1_q16, m.w2 = keep
    check("vt_mlp_model_check", lib.vt_mlp_model_check(m),
          f"kind={kind} window {win_w}x{win_h} w1 {w1.shape} shifts {w1_shift}/{w2_shift}")
    return m, keep


def mlp_default_model():
    out = ffi.new("const vt_mlp_model **")
    check("vt_mlp_default_model", lib.vt_mlp_default_model(out), "no default MLP is built in")
    return out[0]


def mlp_decision(model, desc: np.ndarray) -> int:
    return _decision("vt_mlp_decision", model, desc)


def classify_box_mlp(ws, model, frame: np.ndarray, box) -> int:
    return _classify_box("vt_classify_box_mlp", ws, model, frame, box)


_BOX_MLP = {}


def classify_box_mlp_default(frame: np.ndarray, l: int, t: int, r: int, b: int) -> int:
    """The built-in MLP's score of one box (the whole-road detector's second stage, as
    the reference engine runs it: the classifier is the C one in both engines)."""
    if not _BOX_MLP:
        _BOX_MLP["ws"], _BOX_MLP["m"] = box_ws_new(), mlp_default_model()
    return classify_box_mlp(_BOX_MLP["ws"], _BOX_MLP["m"], np.ascontiguousarray(frame), (l, t, r, b))
# ================================================================ end classify.h
# ================================================================ flow.h
FLOW_HYP_DTYPE = np.dtype([("left", np.int32), ("top", np.int32), ("right", np.int32),
                           ("bottom", np.int32), ("side", np.int32), ("kind", np.int32),
                           ("id", np.int32), ("cells", np.int32), ("flow_x", np.int32),
                           ("flow_y", np.int32), ("age", np.int32), ("cy", np.int32)])


def flow_cfg_default():
    return _defaults("vt_flow_cfg")


def flow_cfg_check(cfg) -> None:
    check("vt_flow_cfg_check", lib.vt_flow_cfg_check(cfg), _flow_cfg_detail(cfg))


def _flow_cfg_detail(cfg) -> str:
    names = [f for f, _ in ffi.typeof("vt_flow_cfg").fields]
    return "cfg " + ", ".join(f"{n}={getattr(cfg, n)}" for n in names)


def flow_new():
    """A vt_flow_state owned by Python (about 3 * VT_FLOW_MAX_PIXELS bytes)."""
    st = ffi.new("vt_flow_state *")
    check("vt_flow_init", lib.vt_flow_init(st))
    return st


def flow_reset(st) -> None:
    check("vt_flow_reset", lib.vt_flow_reset(st))


def flow_step(st, cfg, img: np.ndarray):
    """One frame: (ready, hypotheses as FLOW_HYP_DTYPE (flow in Q16 input px),
    counters dict)."""
    v = view(img, "frame")
    out = ffi.new("vt_flow_result *")
    check("vt_flow_step", lib.vt_flow_step(st, cfg, v, out),
          f"frame {img.shape}, previous {st.h}x{st.w} (have_prev={st.have_prev}); "
          + _flow_cfg_detail(cfg))
    n = int(out.n)
    hyps = np.zeros(n, FLOW_HYP_DTYPE)
    for k in range(n):
        hp = out.hyp[k]
        hyps[k] = (hp.box.left, hp.box.top, hp.box.right, hp.box.bottom, hp.side, hp.kind,
                   hp.id, hp.cells, hp.flow_x, hp.flow_y, hp.age, hp.cy)
    stats = {"dropped": int(out.dropped), "cells_total": int(out.cells_total),
             "cells_computed": int(out.cells_computed), "cells_accepted": int(out.cells_accepted)}
    return bool(out.ready), hyps, stats


def flow_field(st, side: int):
    """The cell grid of lateral area `side` (0 left, 1 right) from the last step:
    (x0, y0, dx, dy, flag, sad) with (gh, gw) arrays, copies."""
    if side not in (0, 1):
        raise ValueError(f"side: expected 0 (left) or 1 (right), got {side!r}")
    gw, gh = int(st.gw[side]), int(st.gh[side])
    k = gw * gh

    off = side * int(lib.VT_FLOW_MAX_CELLS)

    def grab(arr, dt):
        size = np.dtype(dt).itemsize
        raw = ffi.buffer(ffi.addressof(arr, off), k * size) if k else b""
        return np.frombuffer(raw, dt).reshape(gh, gw).copy()

    return (int(st.x0[side]), int(st.y0[side]), grab(st.dx, np.int8), grab(st.dy, np.int8),
            grab(st.flag, np.uint8), grab(st.sad, np.uint32))


def flow_seed(st, cfg, box) -> int:
    b = ffi.new("vt_box *")
    vals = [int(v) for v in box]
    if len(vals) != 4 or any(abs(v) > 2**30 for v in vals):
        raise ValueError(f"box: expected [left, top, right, bottom] ints, got {box!r}")
    b.left, b.top, b.right, b.bottom = vals
    out = ffi.new("int32_t *")
    check("vt_flow_seed", lib.vt_flow_seed(st, cfg, b, out),
          f"box {vals} in a {st.w}x{st.h} frame (have_prev={st.have_prev})")
    return int(out[0])


def flow_seed_frame(st, cfg, img: np.ndarray, box) -> int:
    """vt_flow_seed_frame: flow_seed, and the previous level image computed over the box
    from `img`, the frame last given to flow_step."""
    v = view(img, "frame")
    b = ffi.new("vt_box *")
    vals = [int(v_) for v_ in box]
    if len(vals) != 4 or any(abs(v_) > 2**30 for v_ in vals):
        raise ValueError(f"box: expected [left, top, right, bottom] ints, got {box!r}")
    b.left, b.top, b.right, b.bottom = vals
    out = ffi.new("int32_t *")
    check("vt_flow_seed_frame", lib.vt_flow_seed_frame(st, cfg, v, b, out),
          f"box {vals}, frame {img.shape} in a {st.w}x{st.h} frame (have_prev={st.have_prev})")
    return int(out[0])


def flow_unseed(st, tid: int) -> None:
    check("vt_flow_unseed", lib.vt_flow_unseed(st, int(tid)), f"id {tid}")
# ================================================================ end flow.h


# ================================================================ vehicle_model.h
MODEL_GENES = ("x", "y", "w", "h", "wind", "bump", "roof")


def model_cfg_default():
    return _defaults("vt_model_cfg")


def model_cfg_check(cfg) -> None:
    check("vt_model_cfg_check", lib.vt_model_cfg_check(cfg), "see vt_model_cfg's ranges in vehicle_model.h")


def model_cfg_road(cfg, y0: int, w0: int, y1: int, w1: int) -> None:
    check("vt_model_cfg_road", lib.vt_model_cfg_road(cfg, int(y0), int(w0), int(y1), int(w1)),
          f"width {w0} px at row {y0}, {w1} px at row {y1}")


def model_expected_width(cfg, y: int) -> int:
    out = ffi.new("int32_t *")
    check("vt_model_expected_width", lib.vt_model_expected_width(cfg, int(y), out), f"row {y}")
    return int(out[0])


def model_ws_new():
    """A vt_model_ws owned by Python."""
    return ffi.new("vt_model_ws *")


def _params(p, name: str, out) -> None:
    vals = list(p)
    if len(vals) != 7:
        raise ValueError(f"{name}: expected 7 values {MODEL_GENES}, got {len(vals)}")
    for k, v in zip(MODEL_GENES, vals):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
            raise TypeError(f"{name}.{k}: expected an int, got {type(v).__name__}")
        if not -2**31 <= int(v) < 2**31:
            raise ValueError(f"{name}.{k}: {v} out of the int32 range")
        setattr(out, k, int(v))


def model_search(roi, y_min: int, y_max: int, tracking: bool = False, pred=None, sigma=None):
    """A vt_model_search: roi (left, top, right, bottom) inclusive input px, bottom rows
    y_min..y_max, and for tracking the prediction and per-gene sigmas (7-tuples)."""
    s = ffi.new("vt_model_search *")
    r = [int(v) for v in roi]
    if len(r) != 4 or any(abs(v) > 2**30 for v in r):
        raise ValueError(f"roi: expected (left, top, right, bottom) ints, got {roi!r}")
    s.roi.left, s.roi.top, s.roi.right, s.roi.bottom = r
    s.y_min, s.y_max = int(y_min), int(y_max)
    s.tracking = 1 if tracking else 0
    if tracking:
        if pred is None or sigma is None:
            raise ValueError("tracking: pred and sigma are required")
        _params(pred, "pred", s.pred)
        _params(sigma, "sigma", s.sigma)
    return s


def _p_tuple(p) -> tuple:
    return tuple(int(getattr(p, k)) for k in MODEL_GENES)


def model_prepare(img: np.ndarray, cfg, search, level: int, ws) -> None:
    v = view(img, "frame")
    check("vt_model_prepare", lib.vt_model_prepare(ws, cfg, v, search, int(level)),
          f"frame {img.shape}, roi {(search.roi.left, search.roi.top, search.roi.right, search.roi.bottom)}, "
          f"level {level}")


def model_fitness(img: np.ndarray, cfg, search, level: int, ws, params) -> int:
    v = view(img, "frame")
    p = ffi.new("vt_model_params *")
    _params(params, "params", p)
    out = ffi.new("int32_t *")
    check("vt_model_fitness", lib.vt_model_fitness(ws, cfg, v, search, int(level), p, out),
          f"params {tuple(params)} at level {level} (prepared level {ws.level})")
    return int(out[0])


def model_fit(img: np.ndarray, cfg, search, ws) -> dict:
    """The GA: {'best': 7-tuple, 'fitness', 'evaluations', 'box': (l, t, r, b)}."""
    v = view(img, "frame")
    out = ffi.new("vt_model_result *")
    check("vt_model_fit", lib.vt_model_fit(ws, cfg, v, search, out),
          f"frame {img.shape}, roi {(search.roi.left, search.roi.top, search.roi.right, search.roi.bottom)}, "
          f"rows {search.y_min}..{search.y_max}, tracking {search.tracking}")
    return {"best": _p_tuple(out.best), "fitness": int(out.fitness), "evaluations": int(out.evaluations),
            "box": (int(out.box.left), int(out.box.top), int(out.box.right), int(out.box.bottom))}


def model_search_from_flow(cfg, hyp) -> "ffi.CData":
    """vt_model_search_from_flow on a FLOW_HYP_DTYPE record (or any object with box fields
    left/top/right/bottom and cy)."""
    h = ffi.new("vt_flow_hyp *")
    for k in ("left", "top", "right", "bottom"):
        setattr(h.box, k, int(hyp[k]))
    h.cy = int(hyp["cy"])
    s = ffi.new("vt_model_search *")
    check("vt_model_search_from_flow", lib.vt_model_search_from_flow(cfg, h, s),
          f"box {[int(hyp[k]) for k in ('left', 'top', 'right', 'bottom')]}")
    return s


def model_population(ws) -> tuple[list, list]:
    """The last generation of the last vt_model_fit: ([7-tuples], [fitness])."""
    base = int(ws.cur) * int(lib.VT_MODEL_MAX_POP)
    n = int(ws.n)
    return ([_p_tuple(ws.pop[base + i]) for i in range(n)], [int(ws.fit[base + i]) for i in range(n)])
# ================================================================ end vehicle_model.h


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
def fixed_road_check(fr) -> None:
    check("vt_fixed_road_check", lib.vt_fixed_road_check(fr),
          "a fixed-road field is out of range (see vt_fixed_road_check in vehtrack/pipeline.h)")


def road_camera_check(rc) -> None:
    check("vt_road_camera_check", lib.vt_road_camera_check(rc),
          "a road-camera field is out of range (see vt_road_camera_check in vehtrack/pipeline.h)")


# ================================================================ end pipeline.h
