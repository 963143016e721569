"""The cffi declarations (pyvehtrack/cdef/*.h) must match the public headers:
every public function in include/vehtrack/ is declared to cffi with the same
signature, and nothing is declared that the headers do not have."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DECL = re.compile(r"(?:static\s+inline\s+)?((?:const\s+)?[a-z_][a-z0-9_]*\s*\**)\s*\b(vt_[a-z0-9_]+)\s*"
                  r"\(([^)]*)\)\s*[;{]")


def _strip_comments(s: str) -> str:
    return re.sub(r"//[^\n]*", "", re.sub(r"/\*.*?\*/", "", s, flags=re.S))


def _decls(text: str) -> dict[str, str]:
    out = {}
    for m in DECL.finditer(_strip_comments(text)):
        ret, name, args = m.groups()
        if name.startswith("vt__"):
            continue
        sig = re.sub(r"\s+", " ", f"{ret} {name}({args})").replace(" *", "*").replace("* ", "*")
        out[name] = sig.replace("( ", "(").replace(" )", ")")
    return out


def test_cdef_matches_headers():
    headers = _decls("\n".join(p.read_text() for p in sorted((ROOT / "include" / "vehtrack").glob("*.h"))))
    cdef = _decls("\n".join(p.read_text() for p in sorted((ROOT / "pyvehtrack" / "cdef").glob("*.h"))))
    assert headers, "no public declarations found: the parser is broken"
    missing = sorted(set(headers) - set(cdef))
    extra = sorted(set(cdef) - set(headers))
    assert not missing, f"public functions not declared to cffi: {missing}"
    assert not extra, f"cffi declares functions the headers do not have: {extra}"
    differ = {n: (headers[n], cdef[n]) for n in headers if headers[n] != cdef[n]}
    assert not differ, f"signatures differ: {differ}"


def test_every_public_function_returns_status():
    """House rule: public non-inline functions return vt_status (inline helpers in
    fixed.h are total arithmetic and return their value)."""
    text = _strip_comments("\n".join(p.read_text() for p in (ROOT / "include" / "vehtrack").glob("*.h")))
    for m in DECL.finditer(text):
        ret, name, _ = m.groups()
        if name.startswith("vt__") or m.group(0).startswith("static"):
            continue
        assert ret.strip() == "vt_status", f"{name} returns {ret.strip()}"


def test_no_float_in_core():
    """No float or double anywhere in the C core (the M3 soft-float firmware build
    proves it at link time too)."""
    for p in list((ROOT / "c").rglob("*.[ch]")) + list((ROOT / "include").rglob("*.h")):
        code = _strip_comments(p.read_text())
        assert not re.search(r"\b(float|double)\b", code), p
        assert not re.search(r"\b(malloc|calloc|realloc|free)\s*\(", code), p


def test_shared_geometry_types_have_one_home():
    """vt_box and vt_hypothesis (what the stages hand each other) are defined in
    vehtrack/geometry.h only (issue 10 item 6), in the headers and in the cdef."""
    for name in ("vt_box", "vt_hypothesis"):
        where = [p.name for p in sorted((ROOT / "include" / "vehtrack").glob("*.h"))
                 if re.search(r"\}\s*" + name + r"\s*;", _strip_comments(p.read_text()))]
        assert where == ["geometry.h"], (name, where)
        cdef = [p.name for p in sorted((ROOT / "pyvehtrack" / "cdef").glob("*.h"))
                if re.search(r"\}\s*" + name + r"\s*;", _strip_comments(p.read_text()))]
        assert cdef == ["00_core.h"], (name, cdef)
