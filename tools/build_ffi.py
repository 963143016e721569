#!/usr/bin/env python3
"""Emit the C source of the cffi extension `pyvehtrack._vtffi` (API mode, out of line).

meson runs this at build time (see meson.build), so the generated C file is never
checked in and cannot go stale:

    python tools/build_ffi.py OUT.c
"""
from __future__ import annotations

import sys
from pathlib import Path

import cffi

ROOT = Path(__file__).resolve().parent.parent
CDEF_DIR = ROOT / "pyvehtrack" / "cdef"


def make_ffi() -> cffi.FFI:
    ffi = cffi.FFI()
    # One cdef file per C module, read in name order (00_core.h first).
    ffi.cdef("\n".join(p.read_text() for p in sorted(CDEF_DIR.glob("*.h"))))
    # The library itself is linked by meson; here we only include its header.
    ffi.set_source("pyvehtrack._vtffi", '#include "vehtrack/vehtrack.h"\n')
    return ffi


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    make_ffi().emit_c_code(argv[1])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
