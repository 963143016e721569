"""The C side of issue 11's bad-input table (item 4): one row per input, through
cffi, for the configurations and the stateful stages. (The pixel primitives'
NULL / size / stride rows are in tests/test_badargs.py; the Python API and CLI
rows are wip/house's.)

Rows, each a documented outcome -- an exact status, or "any vt_status, and then
the stage runs without UB" -- never a crash:
  * every int32 field of every configuration (lane, shadow, verify, detect,
    track search, Kalman model, tracker, ACF detector, CNN frame detection; nested ones
    included) set to
    INT32_MIN, -1, 0, 1, 2^30 and INT32_MAX: its _cfg_check returns a status,
    and a configuration it accepts runs its stage over a small synthetic frame
    (under `make check SAN=1 CC=clang` any UB there aborts);
  * the documented domains of vt_kf_model_cfg and vt_tracker_cfg, just inside
    (accepted) and just outside (VT_E_ARG) each bound;
  * NULLs, negative / over-capacity counts and capacities, invalid boxes and a
    corrupted tracker for vt_tracker_step (the tracker is unchanged after any
    error); bad filter dims, a NULL z and a saturated P for the Kalman filter;
  * regression rows for what fuzzing found (a side memory at INT32_MIN).
"""
from __future__ import annotations

import numpy as np
import pytest

from pyvehtrack import _native

ffi, lib = _native.ffi, _native.lib
I32_MIN, I32_MAX = -(2**31), 2**31 - 1
EDGES = [I32_MIN, -1, 0, 1, 2**30, I32_MAX]
STATUSES = {lib.VT_OK, lib.VT_E_ARG, lib.VT_E_SIZE, lib.VT_E_CAPACITY, lib.VT_E_SINGULAR}
Q16 = 65536
W, H = 64, 48


def scene() -> np.ndarray:
    """A road ramp with a dark box and its shadow: something for every stage."""
    img = np.tile(np.arange(100, 100 + H, dtype=np.uint8)[:, None], (1, W))
    img[20:34, 20:40] = 60
    img[34:36, 18:42] = 10
    img[:, 8] = 230
    img[:, W - 9] = 230
    return img


IMG = scene()


def img_view(arr=IMG):
    return _native.view(arr, "img")


def road_area():
    r = ffi.new("vt_road_area *")
    r.valid, r.y_top, r.y_bottom, r.height = 1, 10, H - 1, H
    for y in range(H):
        r.x_left[y], r.x_right[y], r.lane_width[y] = 4, W - 5, W // 2
    return r


def int_fields(ctype: str, prefix: str = ""):
    """(path, ...) of every int32 field of a struct, nested structs included."""
    out = []
    for name, f in ffi.typeof(ctype).fields:
        if f.type.kind == "struct":
            out += int_fields(f.type.cname, prefix + name + ".")
        elif f.type.kind == "primitive" and f.type.cname in ("int32_t", "int"):
            out.append(prefix + name)
    return out


def set_path(cfg, path, v):
    *head, last = path.split(".")
    obj = cfg
    for h in head:
        obj = getattr(obj, h)
    setattr(obj, last, v)


# ---- running each stage with a configuration its check accepted
def run_lane(cfg):
    st = ffi.new("vt_lane_state *")
    res = ffi.new("vt_lane_result *")
    road = ffi.new("vt_road_area *")
    assert lib.vt_lane_reset(st) == lib.VT_OK
    big = np.tile(scene(), (3, 3))
    v = img_view(big)
    return [lib.vt_lane_detect(st, cfg, v, res, road) for _ in range(2)]


def run_shadow(cfg):
    st = ffi.new("vt_shadow_state *")
    out = ffi.new("vt_hypothesis[4]")
    n = ffi.new("int32_t *")
    return [lib.vt_shadow_find(st, cfg, img_view(), road_area(), out, 4, n)]


def run_verify(cfg):
    st = ffi.new("vt_verify_state *")
    hyp = ffi.new("vt_hypothesis[3]", [(35, 18, 41), (47, 0, 63), (0, 60, 63)])
    out = ffi.new("vt_box[2]")
    n = ffi.new("int32_t *")
    return [lib.vt_verify(st, cfg, img_view(), hyp, 3, out, 2, n)]


def run_detect(cfg):
    st = ffi.new("vt_detect_state *")
    res = ffi.new("vt_detect_result *")
    return [lib.vt_detect(st, cfg, img_view(), road_area(), res)]


def run_track_search(cfg):
    ws = ffi.new("vt_track_search_ws *")
    roi = ffi.new("vt_box *", (10, 10, 50, 40))
    sides = ffi.new("vt_track_sides *", (1, 20, 39, 2, 2))
    meas = ffi.new("vt_box *")
    found = ffi.new("int32_t *")
    return [lib.vt_track_search(ws, sides, cfg, img_view(), roi, meas, found)]


def run_kf_model(cfg):
    kf = ffi.new("vt_kf *")
    out = [lib.vt_kf_init_bottom_edge(kf, cfg, 20 * Q16, 35 * Q16, 40 * Q16)]
    z = ffi.new("vt_q16[4]", [21 * Q16, 35 * Q16, 41 * Q16, 0])
    for k in range(40):
        out.append(lib.vt_kf_predict(kf))
        if k % 7 == 0:
            out.append(lib.vt_kf_update(kf, z))
    return out


def run_tracker(cfg):
    tr = ffi.new("vt_tracker *")
    lib.vt_tracker_init(tr)
    det = ffi.new("vt_box[1]", [(20, 20, 39, 35)])
    out = ffi.new("vt_track_out[%d]" % lib.VT_MAX_TRACKS)
    n = ffi.new("int32_t *")
    return [lib.vt_tracker_step(tr, cfg, img_view(), int(f % 3 == 0), det, 1, out, lib.VT_MAX_TRACKS, n)
            for f in range(8)]


_ACF = {}


def run_acf(cfg):
    """vt_acf_detect with a small fixed model (4 x 4 cells, 3 trees of depth 2) on the tiled scene."""
    if not _ACF:
        from pyvehtrack.acf import AcfModel
        feat = (np.arange(9, dtype=np.uint16).reshape(3, 3) * 13) % 128
        thr = np.full((3, 3), 40, np.uint8)
        leaf_q16 = np.array([[-3, 1, 2, 5], [4, -1, 0, 2], [1, 1, -6, 3]], np.int32) * Q16
        _ACF["model"] = AcfModel(4, 4, 0, 2, feat, thr, leaf_q16 / Q16, leaf_q16, 0.0)
        _ACF["ws"] = ffi.new("vt_acf_ws *")
        _ACF["img"] = np.tile(scene(), (3, 3))
    cam = _native.camera_min(300.0, 3 * H // 3, 1500, 3 * H)
    res = ffi.new("vt_fulldet_result *")
    return [lib.vt_acf_detect(_ACF["ws"], _ACF["model"].c_model()[0], cfg, cam, img_view(_ACF["img"]), res)]


_CNN = {}


def run_cnn(cfg):
    """vt_cnn_detect_frame with a small fixed model (3x3 s2, 3x3 s2, 1x1 head) on the tiled
    scene, the work buffer sized by vt_cnn_frame_work_bytes for this cfg."""
    if not _CNN:
        from pyvehtrack.cnn import CnnModel
        rng = np.random.default_rng(5)

        def lay(k, s, relu, cin, cout):
            return dict(ksize=k, stride=s, dilation=1, relu=relu, cin=cin, cout=cout,
                        w=rng.integers(-60, 60, (cout, k, k, cin)).astype(np.int8),
                        bias=rng.integers(-500, 500, cout).astype(np.int32),
                        mult=np.full(cout, 1 << 12, np.int32), shift=np.full(cout, 16, np.uint8))
        _CNN["model"] = CnnModel([lay(3, 2, 1, 1, 4), lay(3, 2, 1, 4, 4), lay(1, 1, 0, 4, 5)],
                                 rng.integers(0, 800, (4, 256)).astype(np.uint16), -10)
        _CNN["img"] = np.tile(scene(), (3, 3))
    m = _CNN["model"].c_model()[0]
    img = _CNN["img"]
    nb = ffi.new("size_t *")
    s = lib.vt_cnn_frame_work_bytes(m, cfg, img.shape[1], img.shape[0], nb)
    if s != lib.VT_OK:
        return [s]
    work = np.zeros(nb[0], np.uint8)
    boxes = ffi.new("vt_cnn_box[8]")
    n, t = ffi.new("int32_t *"), ffi.new("int32_t *")
    return [s, lib.vt_cnn_detect_frame(m, cfg, ffi.cast("uint8_t *", img.ctypes.data), img.shape[1], img.shape[0],
                                       img.shape[1], ffi.cast("uint8_t *", work.ctypes.data), nb[0], boxes, 8, n, t)]


STAGES = {
    "vt_lane_cfg": (lib.vt_lane_cfg_default, lib.vt_lane_cfg_check, run_lane),
    "vt_shadow_cfg": (lib.vt_shadow_cfg_default, lib.vt_shadow_cfg_check, run_shadow),
    "vt_verify_cfg": (lib.vt_verify_cfg_default, lib.vt_verify_cfg_check, run_verify),
    "vt_detect_cfg": (lib.vt_detect_cfg_default, lib.vt_detect_cfg_check, run_detect),
    "vt_track_search_cfg": (None, lib.vt_track_search_cfg_check, run_track_search),
    "vt_kf_model_cfg": (lib.vt_kf_model_cfg_default, lib.vt_kf_model_cfg_check, run_kf_model),
    "vt_tracker_cfg": (lib.vt_tracker_cfg_default, lib.vt_tracker_cfg_check, run_tracker),
    "vt_acf_cfg": (lib.vt_acf_cfg_default, lib.vt_acf_cfg_check, run_acf),
    "vt_cnn_cfg": (lib.vt_cnn_cfg_default, lib.vt_cnn_cfg_check, run_cnn),
}


def default_cfg(ctype):
    cfg = ffi.new(ctype + " *")
    fill = STAGES[ctype][0]
    if fill is None:  # the track search's defaults live inside the tracker's
        t = ffi.new("vt_tracker_cfg *")
        lib.vt_tracker_cfg_default(t)
        cfg[0] = t.search
    else:
        assert fill(cfg) == lib.VT_OK
    return cfg


ROWS = [(ct, path, v) for ct in STAGES for path in int_fields(ct) for v in EDGES]


def test_table_size():
    # Every configuration contributes one row per int32 field and edge value.
    assert len(ROWS) >= 6 * 90, len(ROWS)


@pytest.mark.parametrize("ctype", list(STAGES))
def test_cfg_field_edges(ctype):
    """Each field at each edge value: the check gives a status; an accepted
    configuration then runs its stage, which returns statuses only."""
    _, check, run = STAGES[ctype]
    assert check(ffi.NULL) == lib.VT_E_ARG
    assert check(default_cfg(ctype)) == lib.VT_OK
    assert all(s in STATUSES for s in run(default_cfg(ctype)))
    accepted = 0
    for c, path, v in ROWS:
        if c != ctype:
            continue
        cfg = default_cfg(ctype)
        set_path(cfg, path, v)
        s = check(cfg)
        assert s in STATUSES, (path, v, s)
        if s == lib.VT_OK:
            accepted += 1
            statuses = run(cfg)
            assert all(x in STATUSES for x in statuses), (path, v, statuses)
    # INT32_MIN and INT32_MAX are outside almost every domain: most rows reject.
    n = sum(1 for c, _, _ in ROWS if c == ctype)
    assert accepted < n, ctype


# ---- documented domains: just inside is accepted, just outside is VT_E_ARG
KF_BOUNDS = [
    ("dt", lib.VT_KF_DT_MIN, lib.VT_KF_DT_MAX),
    ("accel_x", 0, lib.VT_KF_ACCEL_MAX), ("accel_y", 0, lib.VT_KF_ACCEL_MAX),
    ("meas_sigma_x", lib.VT_KF_MEAS_SIGMA_MIN, lib.VT_KF_MEAS_SIGMA_MAX),
    ("meas_sigma_y", lib.VT_KF_MEAS_SIGMA_MIN, lib.VT_KF_MEAS_SIGMA_MAX),
    ("init_sigma_pos", 0, lib.VT_KF_POS_SIGMA_MAX), ("init_sigma_vel", 0, lib.VT_KF_VEL_SIGMA_MAX),
    ("p_max", 0, Q16 // 2), ("p_zero", 0, Q16 - 2 * (Q16 // 10)),  # 2 P1 + P2 <= 1
]
TRACKER_BOUNDS = [
    ("roi_margin_min", 0, lib.VT_MAX_WIDTH), ("roi_margin_permille", 0, 4000),
    ("gate_permille", 0, 4000), ("gate_bottom_permille", 0, 4000),
    ("confirm_hits", 1, lib.VT_TRACK_MAX_FRAMES_CFG), ("max_coast", 0, lib.VT_TRACK_MAX_FRAMES_CFG),
    ("match_iou_permille", 1, 1000), ("init_max_change", 0, lib.VT_MAX_WIDTH),
    ("keep_ncc", -16384, 16384),
    ("search.h_thresh", 1, I32_MAX), ("search.v_thresh", 1, I32_MAX),
    ("search.min_h_permille", 0, 1000), ("search.min_v_permille", 0, 1000),
    ("search.bottom_permille", 1, 1000), ("search.polarity", 0, 1), ("search.side_mode", 0, 1),
]


@pytest.mark.parametrize("field,lo,hi", KF_BOUNDS, ids=[b[0] for b in KF_BOUNDS])
def test_kf_model_domain(field, lo, hi):
    for v, ok in ((lo, True), (hi, True), (lo - 1, False), (hi + 1, False)):
        cfg = default_cfg("vt_kf_model_cfg")
        if field == "p_max":  # the other probability must leave room: 2 P1 + P2 <= 1
            cfg.p_zero = 0
        if field == "p_zero":
            cfg.p_max = Q16 // 10
        setattr(cfg, field, v)
        if v > I32_MAX:
            continue
        s = lib.vt_kf_model_cfg_check(cfg)
        assert (s == lib.VT_OK) == ok, (field, v, s)
        kf = ffi.new("vt_kf *")
        assert (lib.vt_kf_init_cv(kf, cfg, 0, 0) == lib.VT_OK) == ok, (field, v)
        t = default_cfg("vt_tracker_cfg")
        t.model = cfg[0]
        assert (lib.vt_tracker_cfg_check(t) == lib.VT_OK) == ok, (field, v)


@pytest.mark.parametrize("field,lo,hi", TRACKER_BOUNDS, ids=[b[0] for b in TRACKER_BOUNDS])
def test_tracker_cfg_domain(field, lo, hi):
    for v, ok in ((lo, True), (hi, True), (lo - 1, False), (hi + 1, False)):
        if v > I32_MAX or v < I32_MIN:
            continue
        cfg = default_cfg("vt_tracker_cfg")
        set_path(cfg, field, v)
        if field == "keep_ncc" and not -32768 <= v <= 32767:
            continue
        assert (lib.vt_tracker_cfg_check(cfg) == lib.VT_OK) == ok, (field, v)


def test_issue11_dt_500_frames_rejected():
    """The issue's configuration: model.dt = 500 frames is outside the domain now,
    so vt_tracker_step refuses it up front (and names it VT_E_ARG)."""
    cfg = default_cfg("vt_tracker_cfg")
    cfg.model.dt = 500 * Q16
    assert lib.vt_tracker_cfg_check(cfg) == lib.VT_E_ARG
    tr = ffi.new("vt_tracker *")
    lib.vt_tracker_init(tr)
    n = ffi.new("int32_t *")
    assert lib.vt_tracker_step(tr, cfg, img_view(), 0, ffi.NULL, 0, ffi.NULL, 0, n) == lib.VT_E_ARG
    assert tr.frame == 0


# ---- the tracker's arguments
def _tracker_rows():
    det_ok = [(20, 20, 39, 35)]
    lim = 4 * max(lib.VT_MAX_WIDTH, lib.VT_MAX_HEIGHT)
    return [
        # (name, overrides, expected status)
        ("tr NULL", dict(tr=None), lib.VT_E_ARG),
        ("cfg NULL", dict(cfg=None), lib.VT_E_ARG),
        ("img NULL", dict(img=None), lib.VT_E_ARG),
        ("n_out NULL", dict(n_out=None), lib.VT_E_ARG),
        ("out NULL, cap 4", dict(out=None, cap=4), lib.VT_E_ARG),
        ("out NULL, cap 0 (one track live)", dict(out=None, cap=0), lib.VT_E_CAPACITY),
        ("cap -1", dict(cap=-1), lib.VT_E_ARG),
        ("cap INT32_MIN", dict(cap=I32_MIN), lib.VT_E_ARG),
        ("n_dets -1", dict(n=-1), lib.VT_E_SIZE),
        ("n_dets 257", dict(n=257, dets=det_ok * 257), lib.VT_E_SIZE),
        ("n_dets INT32_MAX", dict(n=I32_MAX), lib.VT_E_SIZE),
        ("dets NULL, n 1", dict(dets=None, n=1), lib.VT_E_ARG),
        ("box left > right", dict(dets=[(30, 20, 29, 35)]), lib.VT_E_ARG),
        ("box top > bottom", dict(dets=[(20, 36, 39, 35)]), lib.VT_E_ARG),
        ("box past the limit", dict(dets=[(0, 0, lim + 1, 10)]), lib.VT_E_ARG),
        ("box INT32 edges", dict(dets=[(I32_MIN, I32_MIN, I32_MAX, I32_MAX)]), lib.VT_E_ARG),
        ("corrupted next_id 0", dict(next_id=0), lib.VT_E_ARG),
        ("corrupted next_id INT32_MIN", dict(next_id=I32_MIN), lib.VT_E_ARG),
        ("image 0 wide", dict(img_dims=(0, H, W)), lib.VT_E_SIZE),
        ("image stride < w", dict(img_dims=(W, H, W - 1)), lib.VT_E_SIZE),
        ("image over capacity", dict(img_dims=(lib.VT_MAX_WIDTH + 1, 1, lib.VT_MAX_WIDTH + 1)), lib.VT_E_SIZE),
        ("n_dets 256 (the limit)", dict(n=256, dets=det_ok * 256), lib.VT_OK),
        ("no detection frame, dets NULL, n -1", dict(det_frame=0, dets=None, n=-1), lib.VT_OK),
    ]


@pytest.mark.parametrize("name,over,expect", _tracker_rows(), ids=[r[0] for r in _tracker_rows()])
def test_tracker_step_rows(name, over, expect):
    tr = ffi.new("vt_tracker *")
    lib.vt_tracker_init(tr)
    cfg = default_cfg("vt_tracker_cfg")
    out = ffi.new("vt_track_out[4]")
    n = ffi.new("int32_t *")
    dets = ffi.new("vt_box[1]", [(20, 20, 39, 35)])
    # one good step first, so there is state to keep intact
    assert lib.vt_tracker_step(tr, cfg, img_view(), 1, dets, 1, out, 4, n) == lib.VT_OK
    if "next_id" in over:
        tr.next_id = over["next_id"]
    big = np.zeros((2, lib.VT_MAX_WIDTH + 2), np.uint8)
    v = img_view()
    if "img_dims" in over:
        v = img_view(big)
        v.w, v.h, v.stride = over["img_dims"]
    d = over.get("dets", [(20, 20, 39, 35)])
    cd = ffi.NULL if d is None else ffi.new("vt_box[]", d)
    before = bytes(ffi.buffer(tr))
    s = lib.vt_tracker_step(ffi.NULL if over.get("tr", 1) is None else tr,
                            ffi.NULL if over.get("cfg", 1) is None else cfg,
                            ffi.NULL if over.get("img", 1) is None else v,
                            over.get("det_frame", 1), cd, over.get("n", 1 if d is not None else 0),
                            ffi.NULL if over.get("out", 1) is None else out, over.get("cap", 4),
                            ffi.NULL if over.get("n_out", 1) is None else n)
    assert s == expect, (name, s)
    if s < 0 and s != lib.VT_E_CAPACITY:  # CAPACITY: the step ran, the output was short
        assert bytes(ffi.buffer(tr)) == before, f"{name}: the tracker changed on an error"


# ---- the Kalman filter
@pytest.mark.parametrize("dx,dz", [(0, 1), (1, 0), (-1, 1), (lib.VT_KF_MAX_X + 1, 1),
                                   (1, lib.VT_KF_MAX_Z + 1), (I32_MIN, I32_MAX)])
def test_kf_bad_dims(dx, dz):
    kf = ffi.new("vt_kf *")
    assert lib.vt_kf_init(kf, dx, dz) == lib.VT_E_SIZE
    assert lib.vt_kf_init(kf, 2, 1) == lib.VT_OK
    kf.dim_x, kf.dim_z = dx, dz  # a corrupted struct
    z = ffi.new("vt_q16[8]")
    assert lib.vt_kf_predict(kf) == lib.VT_E_SIZE
    assert lib.vt_kf_update(kf, z) == lib.VT_E_SIZE


def test_kf_null_rows():
    kf = ffi.new("vt_kf *")
    assert lib.vt_kf_init(ffi.NULL, 2, 1) == lib.VT_E_ARG
    assert lib.vt_kf_predict(ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_kf_init(kf, 2, 1) == lib.VT_OK
    assert lib.vt_kf_update(kf, ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_kf_update(ffi.NULL, ffi.new("vt_q16[1]")) == lib.VT_E_ARG
    assert lib.vt_kf_model_cfg_check(ffi.NULL) == lib.VT_E_ARG
    assert lib.vt_kf_init_cv(kf, ffi.NULL, 0, 0) == lib.VT_E_ARG
    assert lib.vt_kf_init_bottom_edge(ffi.NULL, default_cfg("vt_kf_model_cfg"), 0, 0, 0) == lib.VT_E_ARG


def test_kf_saturated_covariance_refuses_update():
    """After a long coast P's diagonal saturates; an update from it would leave P
    indefinite, so vt_kf_update refuses (VT_E_SINGULAR) and changes nothing."""
    kf = ffi.new("vt_kf *")
    lib.vt_kf_init(kf, 2, 1)
    kf.H[0][0] = lib.VT_Q32_ONE
    kf.P[0][0] = 2**63 - 1
    kf.P[1][1] = lib.VT_Q32_ONE
    before = bytes(ffi.buffer(kf))
    z = ffi.new("vt_q16[1]", [5 * Q16])
    assert lib.vt_kf_update(kf, z) == lib.VT_E_SINGULAR
    assert bytes(ffi.buffer(kf)) == before


def test_kf_extreme_matrices_stay_defined():
    """Any entries (the struct is public): predict stays defined and keeps P
    exactly symmetric; INT64_MIN/MAX saturate, never wrap (issue 11's row)."""
    kf = ffi.new("vt_kf *")
    lib.vt_kf_init(kf, 2, 1)
    kf.P[0][0] = kf.P[1][1] = 2**62
    kf.P[0][1] = kf.P[1][0] = 2**61
    kf.F[0][0], kf.F[1][1] = -4 * lib.VT_Q32_ONE, 4 * lib.VT_Q32_ONE
    for _ in range(3):
        assert lib.vt_kf_predict(kf) == lib.VT_OK
    assert kf.P[0][0] == 2**63 - 1 and kf.P[1][1] == 2**63 - 1
    assert kf.P[0][1] == kf.P[1][0] == -(2**63)
    for v in (-(2**63), 2**63 - 1):
        for i in range(2):
            for j in range(2):
                kf.F[i][j] = v
                kf.P[i][j] = -v - 1 if i != j else v
        assert lib.vt_kf_predict(kf) == lib.VT_OK
        assert kf.P[0][1] == kf.P[1][0]


# ---- regression rows from fuzzing
def test_track_search_side_memory_at_int32_edges():
    """fuzz_track_search's find: a side memory at INT32_MIN made |x - prev|
    overflow. Now the difference saturates and the search returns normally."""
    cfg = default_cfg("vt_track_search_cfg")
    cfg.side_mode = lib.VT_SIDES_TWO_THRESHOLD
    ws = ffi.new("vt_track_search_ws *")
    roi = ffi.new("vt_box *", (10, 10, 50, 40))
    meas = ffi.new("vt_box *")
    found = ffi.new("int32_t *")
    for prev in (I32_MIN, I32_MAX):
        sides = ffi.new("vt_track_sides *", (1, prev, prev, 0, 0))
        assert lib.vt_track_search(ws, sides, cfg, img_view(), roi, meas, found) == lib.VT_OK
        if found[0]:
            assert sides.max_change_left == I32_MAX or sides.max_change_left >= 0
