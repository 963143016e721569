"""The window grid's vehicle width band as a model setting (issue 8, "no window"
bucket): detector_json "veh_w_min" / "veh_w_max" (metres) reach the oracle's
WindowConfig and the C core's vt_win_cfg (mm) alike, widen the grid (more windows, a
superset of the rows), keep the C detector and the oracle EXACT twins (they share the
classifier and the integer window rule, tests/test_windows.py), and bad values are
clear errors."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from pyvehtrack.fullroad import DEFAULT_WINDOW_MODEL
from pyvehtrack import _native, fullroad
from pyvehtrack.reference import windows as rw

DATA = Path(__file__).parent / "data"
HOG32_DIM = 3 * 3 * 36


def _model_file(tmp_path, name, settings=None):
    rng = np.random.default_rng(7)
    d = dict(model_type="mlp", kind="hog", win_w=32, win_h=32,
             w1_q=rng.integers(-3000, 3000, (8, HOG32_DIM)).astype(np.int16), w1_shift=12,
             b1_q16=rng.integers(-20000, 20000, 8).astype(np.int32),
             w2_q=rng.integers(-3000, 3000, 8).astype(np.int16), w2_shift=12, b2_q16=-2000, threshold_q16=0,
             scan_sizes=np.array([32, 45]))
    if settings is not None:
        d["detector_json"] = np.array(settings if isinstance(settings, str) else json.dumps(settings))
    p = tmp_path / name
    np.savez(p, **d)
    return p


CAM = fullroad.Camera(horizon_frac=88 / 188, hood_frac=0.99, height_m=1.65, fx_per_width=360 / 621)


def _frame():
    img = cv2.imread(str(DATA / "kitti_lead_30_gray_621x188.png"), cv2.IMREAD_GRAYSCALE)
    assert img is not None
    return img


def test_band_setting_reaches_both_engines_and_widens_the_grid(tmp_path):
    base = fullroad.load_model(_model_file(tmp_path, "base.npz", {"sources": ["shadow", "windows"]}))
    wide = fullroad.load_model(_model_file(tmp_path, "wide.npz", {"sources": ["shadow", "windows"],
                                                                  "veh_w_min": 1.2, "veh_w_max": 3.2}))
    assert wide.settings["veh_w_min"] == 1.2
    gray = _frame()
    stats = {}
    for name, m in (("base", base), ("wide", wide)):
        outs = []
        for engine in ("c", "reference"):
            det = fullroad.FullRoadDetector(m, camera=CAM, engine=engine)
            outs.append((det.detect_gray(gray), dict(det.last_stats)))
        (a, sa), (b, sb) = outs
        assert sa == sb and np.array_equal(a, b)          # exact twins, as without the setting
        stats[name] = sa
        if name == "wide":
            w = det.det_cfg.win
            assert (w.veh_w_min_m, w.veh_w_max_m) == (1.2, 3.2)
            assert (det._cfg_c.win.veh_w_min_mm, det._cfg_c.win.veh_w_max_mm) == (1200, 3200)
    assert stats["wide"]["n_windows"] > stats["base"]["n_windows"] > 50
    # the wider band's rows span the default band's (the row rule only relaxes; rows are
    # laid every step from the first valid one, so they may shift by less than a step)
    h, w = gray.shape
    fc = CAM.for_frame(h, w)
    cfgs = [fullroad.setup(m, camera=CAM)[4].win for m in (base, wide)]
    for lv in range(5):
        got = [rw.windows_level(c, fc, rw.road_from_camera(fc, c, w, h), w, h, lv) for c in cfgs]
        for s in cfgs[0].sizes:
            ys = [g[g[:, 1] == s, 3] for g in got]
            if len(ys[0]):
                step = max(1, int(s * cfgs[0].step))
                assert ys[1].min() <= ys[0].min() and ys[1].max() > ys[0].max() - step


def test_band_setting_explicit_config_wins_and_pipeline_gets_it(tmp_path):
    from pyvehtrack.reference import fulldet as rfd
    m = fullroad.load_model(_model_file(tmp_path, "wide.npz", {"veh_w_min": 1.2, "veh_w_max": 3.2}))
    det = fullroad.FullRoadDetector(m, cfg=fullroad.FullRoadConfig(det=rfd.FullDetConfig()))
    assert (det.det_cfg.win.veh_w_min_m, det.det_cfg.win.veh_w_max_m) == (1.4, 2.6)
    only_max = fullroad.load_model(_model_file(tmp_path, "max.npz", {"veh_w_max": 3.0}))
    win = fullroad.setup(only_max)[4].win
    assert (win.veh_w_min_m, win.veh_w_max_m) == (1.4, 3.0)
    from pyvehtrack.pipeline import Pipeline
    p = Pipeline(model=m)
    assert (p._ccfg.fulldet.win.veh_w_min_mm, p._ccfg.fulldet.win.veh_w_max_mm) == (1200, 3200)


@pytest.mark.parametrize("bad, what", [('{"veh_w_min": 0.0}', "veh_w_min"), ('{"veh_w_max": 25}', "veh_w_max"),
                                       ('{"veh_w_min": "wide"}', "veh_w_min"), ('{"veh_w_max": true}', "veh_w_max"),
                                       ('{"veh_w_min": 3.0, "veh_w_max": 2.0}', "must not exceed")])
def test_band_setting_bad_values_are_clear_errors(tmp_path, bad, what):
    with pytest.raises(ValueError, match=what):
        fullroad.load_model(_model_file(tmp_path, "bad.npz", bad))


def test_band_beyond_default_max_alone_is_an_error_not_a_silent_clip(tmp_path):
    """veh_w_min above the default 2.6 m maximum without a veh_w_max: the C core refuses
    the band (min > max) and the user gets the error, nothing is reordered."""
    m = fullroad.load_model(_model_file(tmp_path, "odd.npz", {"veh_w_min": 3.0}))
    with pytest.raises(_native.VtError, match="vt_fulldet_cfg_check"):
        fullroad.FullRoadDetector(m)
    assert replace(fullroad.setup(m)[4].win).veh_w_min_m == 3.0


def test_shipped_model_names_its_band():
    """The shipped window model carries the band chosen for it on the 'val' frames, and
    the C core's window rules get it in mm."""
    m = fullroad.load_model(DEFAULT_WINDOW_MODEL)
    assert m.settings["veh_w_max"] == 3.0 and "veh_w_min" not in m.settings
    det = fullroad.FullRoadDetector(m)
    assert (det._cfg_c.win.veh_w_min_mm, det._cfg_c.win.veh_w_max_mm) == (1400, 3000)
