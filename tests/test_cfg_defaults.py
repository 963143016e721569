"""Every default config value, read through cffi, equals the table recorded before the
C tidy-ups of issue 10 item 6 (designated initialisers, one unit for fractions): a field
renamed since then is looked up under its new name, and a field whose unit changed is
compared after the exact conversion stated in RENAMED. Nothing may appear or vanish."""
from __future__ import annotations

from pathlib import Path

from pyvehtrack import _native

TABLE = Path(__file__).resolve().parent / "data" / "cfg_defaults_before.tsv"

# old flattened path suffix -> (new suffix, exact conversion of the old value). Only
# conversions that are exact on the recorded defaults are allowed (checked below).
RENAMED: dict[str, tuple[str, int]] = {}


def _flatten(cdata, ctype, prefix: str, out: dict[str, int]) -> None:
    if ctype.kind == "struct":
        for name, field in ctype.fields:
            _flatten(getattr(cdata, name), field.type, f"{prefix}.{name}", out)
    elif ctype.kind == "array":
        for i in range(ctype.length):
            _flatten(cdata[i], ctype.item, f"{prefix}[{i}]", out)
    else:
        out[prefix] = int(cdata)


def _now() -> dict[str, int]:
    ffi, lib = _native.ffi, _native.lib
    out: dict[str, int] = {}
    for fn in sorted(n for n in dir(lib) if n.startswith("vt_") and n.endswith("_cfg_default")):
        ctype = fn[:-len("_default")]
        _flatten(_native._defaults(ctype)[0], ffi.typeof(ctype), ctype, out)
    return out


def _before() -> dict[str, int]:
    rows = [ln.split("\t") for ln in TABLE.read_text().splitlines() if ln and not ln.startswith("#")]
    return {k: int(v) for k, v in rows}


def _renamed(path: str, value: int) -> tuple[str, int]:
    """The path and value the old entry has today (the last field of the path may be renamed)."""
    head, _, last = path.rpartition(".")
    if last in RENAMED:
        new, factor = RENAMED[last]
        return f"{head}.{new}", value * factor
    return path, value


def test_every_default_value_is_unchanged():
    before = dict(_renamed(k, v) for k, v in _before().items())
    now = _now()
    assert len(before) > 400  # the table covers every config, not a sample
    missing = sorted(set(before) - set(now))
    added = sorted(set(now) - set(before))
    assert not missing and not added, f"fields vanished: {missing[:10]}; fields appeared: {added[:10]}"
    changed = {k: (before[k], now[k]) for k in before if before[k] != now[k]}
    assert not changed, f"default values changed (before, now): {changed}"
