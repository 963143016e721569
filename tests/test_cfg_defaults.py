"""Every default config value, read through cffi, equals the table recorded before the
C tidy-ups of issue 10 item 6 (designated initialisers, one unit for fractions): a field
renamed since then is looked up under its new name, and a field whose unit changed is
compared after the exact conversion stated in RENAMED. Nothing recorded may vanish (a
rename without its entry in RENAMED shows up so); fields and configs added since (other
stages plugging in) are not in the table and are not compared."""
from __future__ import annotations

from fractions import Fraction
from pathlib import Path

from pyvehtrack import _native

TABLE = Path(__file__).resolve().parent / "data" / "cfg_defaults_before.tsv"

# old path suffix (last field, with its parent where the name is not unique) -> (new
# last field, exact factor). Only
# conversions that are exact on the recorded defaults are allowed (checked below).
RENAMED: dict[str, tuple[str, int | Fraction]] = {
    # percent -> permille (x 10, exact): tracker.h and track_search.h
    "roi_margin_percent": ("roi_margin_permille", 10), "gate_percent": ("gate_permille", 10),
    "gate_bottom_percent": ("gate_bottom_permille", 10), "match_iou_percent": ("match_iou_permille", 10),
    "search.min_h_percent": ("min_h_permille", 10), "search.min_v_percent": ("min_v_permille", 10),
    "search.bottom_percent": ("bottom_permille", 10),
    # percent -> permille (x 10, exact): flow.h
    "vt_flow_cfg.strip_percent": ("strip_permille", 10),
    "vt_flow_cfg.top_percent": ("top_permille", 10),
    "vt_flow_cfg.bottom_percent": ("bottom_permille", 10),
    "vt_flow_cfg.diff_min_percent": ("diff_min_permille", 10),
    "vt_flow_cfg.seed_min_visible": ("seed_min_visible_permille", 10),
    # vehicle_model.h (the GA's mut_percent stays: its random draw is r % 100)
    "vt_model_cfg.width_tol_percent": ("width_tol_permille", 10),
    "vt_model_cfg.aspect_min_percent": ("aspect_min_permille", 10),
    "vt_model_cfg.aspect_max_percent": ("aspect_max_permille", 10),
    # camera.h
    "vt_camera_cfg.width_tol_percent": ("width_tol_permille", 10),
    # Q8 fractions of at most 1 -> permille (x 1000/256, exact on the recorded defaults)
    "reduce_overlap_q8": ("reduce_overlap_permille", Fraction(1000, 256)),
    "side_min_frac_q8": ("side_min_frac_permille", Fraction(1000, 256)),
}


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
    for old, (new, factor) in RENAMED.items():
        if ("." + path).endswith("." + old):
            v = Fraction(value) * factor
            assert v.denominator == 1, f"{path}: {value} has no exact value in {new}"
            return f"{path.rpartition('.')[0]}.{new}", int(v)
    return path, value


def test_every_default_value_is_unchanged():
    before = dict(_renamed(k, v) for k, v in _before().items())
    now = _now()
    assert len(before) > 400  # the table covers every config, not a sample
    missing = sorted(set(before) - set(now))
    assert not missing, f"fields vanished (renamed without an entry in RENAMED?): {missing[:10]}"
    changed = {k: (before[k], now[k]) for k in before if before[k] != now[k]}
    assert not changed, f"default values changed (before, now): {changed}"


def test_old_percent_names_still_work_with_a_warning():
    """The tracker's and the search's percent fields became permille (issue 10 item 6);
    the public Python configs still take and give the old names, with a DeprecationWarning."""
    import warnings

    import pytest

    from pyvehtrack.config import SearchConfig, TrackerConfig
    from pyvehtrack.reference.track_search import SearchCfg
    from pyvehtrack.reference.tracker import TrackerCfg
    for cls in (TrackerConfig, TrackerCfg):
        with pytest.warns(DeprecationWarning, match="gate_permille"):
            old = cls(gate_percent=40, match_iou_percent=25)
        assert old == cls(gate_permille=400, match_iou_permille=250)
        with pytest.warns(DeprecationWarning, match="gate_bottom_permille"):
            assert cls(gate_bottom_permille=105).gate_bottom_percent == 10.5
        with pytest.raises(TypeError, match="not both"):
            cls(gate_percent=40, gate_permille=400)
    for cls in (SearchConfig, SearchCfg):
        with pytest.warns(DeprecationWarning, match="bottom_permille"):
            assert cls(bottom_percent=100) == cls(bottom_permille=1000)
    with warnings.catch_warnings():
        warnings.simplefilter("error")             # the new names warn about nothing
        assert TrackerConfig(gate_permille=350) == TrackerConfig()


def test_old_q8_fraction_names_still_work_when_exact():
    import pytest

    from pyvehtrack import config, shared
    for cls in (config.ShadowConfig, shared.ShadowConfig):
        with pytest.warns(DeprecationWarning, match="reduce_overlap_permille"):
            assert cls(reduce_overlap_q8=64) == cls(reduce_overlap_permille=250)
        with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="reduce_overlap_permille"):
            cls(reduce_overlap_q8=77)              # 300.78 permille: not taken by rounding
    for cls in (config.VerifyConfig, shared.VerifyConfig):
        with pytest.warns(DeprecationWarning, match="side_min_frac_permille"):
            assert cls().side_min_frac_q8 == 64


def test_old_camera_percent_name_still_works():
    """vt_camera_cfg.width_tol_percent became width_tol_permille (x 10, exact); the float
    twin (shared.CameraParams = reference.camera.CameraParams) takes the old name."""
    import pytest

    from pyvehtrack.reference.camera import CameraParams
    base = (640, 480, 700.0, 700.0, 320.0, 240.0, 1.2)
    with pytest.warns(DeprecationWarning, match="width_tol_permille"):
        assert CameraParams(*base, width_tol_percent=30) == CameraParams(*base, width_tol_permille=300)
    assert CameraParams(*base).width_tol_permille == 250
