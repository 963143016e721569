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
    v.px = ffi.cast(ptype, arr.__array_interface__["data"][0])
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
