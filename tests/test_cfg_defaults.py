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
    # vehicle_model.h; mut_percent too: the GA's draw (r * n) >> 32 < p decides the same for
    # n = 100, p and n = 1000, 10 p (tests/test_vehicle_model.py), so the individuals stay
    "vt_model_cfg.width_tol_percent": ("width_tol_permille", 10),
    "vt_model_cfg.mut_percent": ("mut_permille", 10),
    "vt_model_cfg.aspect_min_percent": ("aspect_min_permille", 10),
    "vt_model_cfg.aspect_max_percent": ("aspect_max_permille", 10),
    # camera.h
    "vt_camera_cfg.width_tol_percent": ("width_tol_permille", 10),
    # Q8 fractions of at most 1 -> permille (x 1000/256, exact on the recorded defaults)
    "reduce_overlap_q8": ("reduce_overlap_permille", Fraction(1000, 256)),
    "side_min_frac_q8": ("side_min_frac_permille", Fraction(1000, 256)),
    # smoothing gains (64 -> 250, 128 -> 500: exact; the blend's rounding rule changed for
    # the lanes, half up -> half away from zero, which moves a line by 1 Q16 LSB at a tie)
    "vt_camera_cfg.pitch_alpha_q8": ("pitch_alpha_permille", Fraction(1000, 256)),
    "track_alpha_q8": ("track_alpha_permille", Fraction(1000, 256)),
}

# Deliberate changes of name AND value (issue 10 item 6): a Q8 fraction with no exact
# permille takes the nearest one, round(q8 * 1000 / 256); re-validated on held-out data
# (the whole-road detector's TEST split; see the README). old path -> (new last field,
# value before, value now).
CHANGED: dict[str, tuple[str, int, int]] = {
    "vt_fulldet_cfg.nms_iou_q8": ("nms_iou_permille", 77, 301),          # 0.30078 -> 0.301
    "vt_fulldet_cfg.nms_contain_q8": ("nms_contain_permille", 179, 699),  # 0.69922 -> 0.699
}


# Deliberate changes of value, each measured and stated where the default is defined:
# path -> (value before, value now).
VALUE_CHANGED: dict[str, tuple[int, int]] = {
    # tracker.h: a track lost between two detection runs lives to the next one
    # (detection every 10th frame), where a detection or keep_ncc decides (issue 8)
    "vt_tracker_cfg.max_coast": (6, 9),
    "vt_pipeline_cfg.tracker.max_coast": (6, 9),
    # lane.h: chosen by cross-validation on tusimple-lane-test100 half B with the KITTI
    # tracking, distance and TTC guards on frames 0-38 (tools/tune_lanes.py --tune B
    # --kitti-guard --range-guard): 89.36% ego accuracy on half A, not used (2026-11-30)
    **{f"{cfg}.{field}": v for cfg in ("vt_lane_cfg", "vt_pipeline_cfg.lane")
       for field, v in (("grad_min", (12, 14)), ("mark_wmin_bottom_permille", (8, 4)),
                        ("top_margin_permille", (37, 25)))},
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
    recorded = _before()
    now = _now()
    for old, (new, was, is_) in CHANGED.items():
        assert recorded.pop(old) == was, old                   # the table says what it was
        assert is_ == round(Fraction(was * 1000, 256)), old     # the nearest permille
        assert now[f"{old.rpartition('.')[0]}.{new}"] == is_, old
    for path, (was, is_) in VALUE_CHANGED.items():
        assert recorded.pop(path) == was, path
        assert now[path] == is_, path
    before = dict(_renamed(k, v) for k, v in recorded.items())
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


def test_old_gain_and_fulldet_names_still_work():
    """pitch_alpha_q8 / track_alpha_q8 (Q8, exact when a multiple of 32) and FullDetConfig's
    float fractions nms_iou / nms_contain / merge_iou (exact when whole permille as written)
    are taken under their old names with a DeprecationWarning; anything else is an error,
    never rounded."""
    import pytest

    from pyvehtrack import config, shared
    from pyvehtrack.camera import Camera
    from pyvehtrack.reference.camera import CameraParams
    base = (640, 480, 700.0, 700.0, 320.0, 240.0, 1.2)
    with pytest.warns(DeprecationWarning, match="pitch_alpha_permille"):
        assert CameraParams(*base, pitch_alpha_q8=64) == CameraParams(*base)
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="pitch_alpha_permille"):
        CameraParams(*base, pitch_alpha_q8=77)
    cam = Camera(fx=700.0, fy=700.0, cx=320.0, cy=240.0, height_m=1.2)
    with pytest.warns(DeprecationWarning, match="pitch_alpha_permille"):
        assert cam.params(640, 480, pitch_alpha_q8=128).pitch_alpha_permille == 500
    for cls in (config.LaneConfig, shared.LaneConfig):
        with pytest.warns(DeprecationWarning, match="track_alpha_permille"):
            assert cls(track_alpha_q8=128) == cls(track_alpha_permille=500) == cls()
        with pytest.warns(DeprecationWarning, match="track_alpha_permille"):
            assert cls().track_alpha_q8 == 128
    fd = shared.FullDetConfig
    with pytest.warns(DeprecationWarning, match="nms_iou_permille"):
        assert fd(nms_iou=0.2, nms_contain=0.5, merge_iou=0.3) == fd(nms_iou_permille=200, nms_contain_permille=500,
                                                                    merge_iou_permille=300)
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="nms_iou_permille"):
        fd(nms_iou=77 / 256)
    with pytest.raises(TypeError, match="not both"):
        fd(merge_iou=0.3, merge_iou_permille=300)
    with pytest.warns(DeprecationWarning, match="nms_contain_permille"):
        assert fd().nms_contain == 0.699
