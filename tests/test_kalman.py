"""Fixed-point Kalman filter (c/kalman.c) against filterpy (pyvehtrack.reference.kalman).

Formats (kalman.h): x, z, y in Q15.16 (LSB 2^-16 px = 1.5e-5 px); P, F, H, Q, R,
K, S in Q31.32 (LSB 2^-32 = 2.3e-10). Every product is exact in 128 bits and
rounded once (half up) to the destination scale; sums are exact.

Tolerances, from that arithmetic:
- State, TOL_X_PX = 0.01 px (655 LSB), for positions and velocities alike.
  A predict adds no error for integer dt (F has entries 0, 1, dt: exact
  products); an update rounds x + K y once, 0.5 LSB per state (K itself is
  exact to ~1e-9 relative, see P below). These roundings are then processed by
  the filter like estimation errors, e' = (I - K H) F e: they decay, but slowly
  when the gain is small. With lambda = (q/r)^(1/4) (the closed-loop bandwidth of a
  constant-velocity filter), a velocity rounding is remembered ~1/lambda
  frames and integrated into position for ~1/lambda^2: worst-case sum
  0.5 LSB / lambda^2. In the domain drawn below the smallest q/r is
  A^2/3 * 0.25 / sigma_z^2 = 0.05^2/12 / 144 = 1.4e-6, lambda = 0.034, so
  <= 430 LSB, plus a coast of up to 40 frames times the velocity error
  (<= 0.5 LSB / lambda = 15 LSB): <= ~1000 LSB deterministic worst case; rounding
  errors are random, so in practice ~sqrt of the memory: measured <= 200 LSB
  (3e-3 px) at that corner. 655 LSB sits between the two.
- Covariance, compared as |dP_ij| <= RTOL_P * sqrt(P_ii P_jj) + ATOL_P (filterpy's
  P as the scale: off-diagonal terms can be 0, so plain relative error is
  meaningless there). One predict or update rounds each entry ~(2 n + m) times
  by half an LSB, ~10 LSB = 2.3e-9 px^2; the Riccati recursion contracts old
  errors, so the absolute error stays at a few LSB (measured <= 1e-9 px^2).
  ATOL_P = 64 LSB = 1.5e-8 px^2 covers that; RTOL_P = 1e-6 covers the gain
  error (K is solved to half an LSB of Q31.32, relative 1e-9 for K ~ 0.1),
  which enters P multiplied by P itself.
- PSD: the Joseph form keeps P PSD for any gain, so only rounding can create a
  negative eigenvalue; it is bounded by the entry error (norm-wise
  <= n * 10 LSB), so the minimum eigenvalue must be >= -PSD_TINY = -64 LSB.

Domain: A in [0.05, 3] px/frame^2 with 1 + 4 P1 - P2 >= 0.25, sigma_z in
[0.5, 12] px. This keeps settled variances >= ~5e-3 px^2 (the range kalman.h is
made for). Outside it -- zero process noise (P2 = 1 or A = 0) -- P shrinks as 1/t^3
towards the Q31.32 LSB and C drifts from filterpy (see the note in kalman.h).
"""
from __future__ import annotations

import dataclasses
from fractions import Fraction
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings, strategies as st

import pyvehtrack as vt
from pyvehtrack import ffi, lib
from pyvehtrack.kalman import KalmanFilter, ModelConfig
from pyvehtrack.reference import kalman as ref

Q16 = 1 << 16
Q32 = 1 << 32
LSB_P = 1.0 / Q32
TOL_X_PX = 0.01
RTOL_P = 1e-6
ATOL_P = 64 * LSB_P
PSD_TINY = 64 * LSB_P
MAXX, MAXZ = lib.VT_KF_MAX_X, lib.VT_KF_MAX_Z

SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])

# Worst errors seen by the long runs of this session, printed at the end of the
# module (visible with `pytest -s`), so the figures in reports can be reproduced.
MEASURED: dict[str, float] = {}


@pytest.fixture(scope="module", autouse=True)
def _print_measured():
    yield
    if MEASURED:
        print("\nKalman C vs filterpy, worst over the long runs: "
              + ", ".join(f"{k}={v:.3g}" for k, v in sorted(MEASURED.items())))


# ------------------------------------------------------------------ helpers
def q16_values(lo: float, hi: float, step: int = 256):
    """Floats exactly representable in Q15.16 (multiples of 1/step)."""
    return st.integers(int(lo * step), int(hi * step)).map(lambda k: k / step)


@st.composite
def model_cfgs(draw):
    p_max = draw(q16_values(0.0, 0.3))
    # 2 P1 + P2 <= 1 (a density), and 1 + 4 P1 - P2 >= 0.25 (see Domain above)
    p_zero = draw(q16_values(0.0, min(1.0 - 2 * p_max, 0.75 + 4 * p_max)))
    return ModelConfig(
        dt=1.0,
        accel_x=draw(q16_values(0.05, 3.0)),
        accel_y=draw(q16_values(0.05, 2.0)),
        p_max=p_max,
        p_zero=p_zero,
        meas_sigma_x=draw(q16_values(0.5, 12.0)),
        meas_sigma_y=draw(q16_values(0.5, 12.0)),
        init_sigma_pos=draw(q16_values(0.5, 30.0)),
        init_sigma_vel=draw(q16_values(0.5, 20.0)),
    )


def _trajectory(rng, n_steps: int, accel: float, model: str):
    """A plausible vehicle in a 640x480 image: bottom-edge y in [250, 470],
    width growing with y (perspective), velocity driven by random accelerations
    in [-accel, accel] and kept bounded (reflect at the borders, mild damping)."""
    x, y = rng.uniform(150, 450), rng.uniform(260, 460)
    vx, vy = rng.uniform(-3, 3), rng.uniform(-1, 1)
    out = np.empty((n_steps, 3))
    for k in range(n_steps):
        vx = 0.98 * vx + rng.uniform(-accel, accel)
        vy = 0.95 * vy + rng.uniform(-accel, accel) * 0.5
        x, y = x + vx, y + vy
        if not 20 < x < 560:
            vx, x = -vx, min(max(x, 20), 560)
        if not 250 < y < 470:
            vy, y = -vy, min(max(y, 250), 470)
        width = 0.55 * (y - 200) + 5 * math.sin(k / 50)
        out[k] = (x, y, x + width)
    return out if model == "be" else out[:, :2]


def run_vs_filterpy(model: str, cfg: ModelConfig, seed: int, n_steps: int, p_drop: float,
                    noise: float, check=True):
    """Run C and filterpy side by side; return the maxima of the errors.
    With check=True every step is asserted against the tolerances."""
    rng = np.random.default_rng(seed)
    cfg = cfg.quantized()
    truth = _trajectory(rng, n_steps + 1, max(cfg.accel_x, cfg.accel_y) * 0.3, model)
    z0 = np.rint((truth[0] + rng.normal(0, noise, truth.shape[1])) * Q16) / Q16
    if model == "be":
        c = KalmanFilter.bottom_edge(*z0, cfg=cfg)
        r = ref.bottom_edge_filter(*z0, **dataclasses.asdict(cfg))
    else:
        c = KalmanFilter.constant_velocity(*z0, cfg=cfg)
        r = ref.constant_velocity_filter(*z0, **dataclasses.asdict(cfg))
    worst = dict(x_px=0.0, p_rel=0.0, min_eig=np.inf, min_pdiag=np.inf)
    burst = 0
    for k in range(1, n_steps + 1):
        c.predict()
        r.predict()
        if burst == 0 and rng.random() < 0.01:
            burst = int(rng.integers(5, 40))  # an occlusion
        if burst > 0:
            burst -= 1
        elif rng.random() >= p_drop:
            # Both get the same Q15.16 measurement, so input quantisation is
            # not part of the comparison.
            z = np.rint((truth[k] + rng.normal(0, noise, truth.shape[1])) * Q16) / Q16
            c.update(z)
            r.update(z)
        rawp = c.raw("P")
        pc = rawp.astype(np.float64) / Q32
        pr = r.P
        ex = float(np.abs(c.x - r.x.ravel()).max())
        scale = np.sqrt(np.outer(np.diag(pr), np.diag(pr)))
        dp = np.abs(pc - pr)
        prel = float((dp / np.maximum(scale, 1e-30)).max())
        eig = float(np.linalg.eigvalsh(pc).min())
        worst["x_px"] = max(worst["x_px"], ex)
        worst["p_rel"] = max(worst["p_rel"], prel)
        worst["min_eig"] = min(worst["min_eig"], eig)
        worst["min_pdiag"] = min(worst["min_pdiag"], float(np.diag(pr).min()))
        if check:
            assert ex <= TOL_X_PX, f"step {k}: state error {ex} px"
            assert np.all(dp <= RTOL_P * scale + ATOL_P), f"step {k}: P error {dp.max()}"
            assert np.array_equal(rawp, rawp.T), f"step {k}: P not exactly symmetric"
            assert eig >= -PSD_TINY, f"step {k}: P has eigenvalue {eig}"
    for key, v in worst.items():
        name = f"{model}_{key}"
        MEASURED[name] = (min if key.startswith("min") else max)(MEASURED.get(name, v), v)
    return worst


# ------------------------------------------------------------------ size
def test_sizeof_vt_kf():
    size = ffi.sizeof("vt_kf")
    head = 8 + 4 * (MAXX + MAXZ)  # dims and the int32 vectors, padded to int64 alignment
    expect = (head + 7) // 8 * 8 + 8 * (3 * MAXX ** 2 + 2 * MAXX * MAXZ + 2 * MAXZ ** 2)
    print(f"sizeof(vt_kf) = {size} bytes (VT_KF_MAX_X={MAXX}, VT_KF_MAX_Z={MAXZ})")
    assert size == expect == vt.kalman.SIZEOF_KF


# ------------------------------------------------------------------ acceleration model
def _round_half_away(q: Fraction) -> int:
    r = math.floor(abs(q) + Fraction(1, 2))
    return r if q >= 0 else -r


@settings(max_examples=300, **SETTINGS)
@given(a=st.integers(0, (1 << 31) - 1), p1=st.integers(0, Q16 // 2),
       p2=st.integers(0, Q16))
def test_accel_var_exact(a, p1, p2):
    out = ffi.new("vt_q32 *")
    s = lib.vt_kf_accel_var(a, p1, p2, out)
    if 2 * p1 + p2 > Q16:
        assert s == lib.VT_E_ARG
        return
    assert s == lib.VT_OK
    exact = Fraction(a * a, Q32) / 3 * (1 + Fraction(4 * p1 - p2, Q16))  # px^2 units
    assert out[0] == _round_half_away(exact * Q32)  # 0 LSB: one rounding of the exact value
    assert out[0] >= 0


def test_accel_var_matches_reference_formula():
    # sigma^2 = A^2/3 (1 + 4 P1 - P2), e.g. A = 1, P1 = 0.25, P2 = 0.5: 1/3 * 1.5 = 0.5.
    assert vt.kalman.accel_var(1.0, 0.25, 0.5) == pytest.approx(0.5, abs=LSB_P)
    assert ref.accel_var(1.0, 0.25, 0.5) == pytest.approx(0.5)
    # uniform only (P1 = P2 = 0): A^2 / 3
    assert vt.kalman.accel_var(3.0, 0.0, 0.0) == pytest.approx(3.0, abs=LSB_P)


# ------------------------------------------------------------------ models
@settings(max_examples=40, **SETTINGS)
@given(cfg=model_cfgs(), dt=q16_values(0.25, 4.0, 16), model=st.sampled_from(["be", "cv"]))
def test_model_matrices_match_reference(cfg, dt, model):
    cfg = cfg.replace(dt=dt).quantized()
    if model == "be":
        c = KalmanFilter.bottom_edge(100.0, 300.0, 180.0, cfg=cfg)
        r = ref.bottom_edge_filter(100.0, 300.0, 180.0, **dataclasses.asdict(cfg))
    else:
        c = KalmanFilter.constant_velocity(100.0, 300.0, cfg=cfg)
        r = ref.constant_velocity_filter(100.0, 300.0, **dataclasses.asdict(cfg))
    np.testing.assert_array_equal(c.F, r.F)  # exact: dt is Q15.16
    np.testing.assert_array_equal(c.H, r.H)
    np.testing.assert_array_equal(c.R, r.R)  # a Q15.16 square is exact in Q31.32
    np.testing.assert_array_equal(c.P, r.P)
    np.testing.assert_array_equal(c.x, r.x.ravel())
    # Q: the variance is rounded once (0.5 LSB), then times dt^k (Q31.32) and
    # rounded again: <= 0.5 LSB * dt^4 + 0.5 LSB + 0.5 LSB (dt^3 rounding).
    assert np.abs(c.Q - r.Q).max() <= (0.5 * dt ** 4 + 1.5) * LSB_P
    assert np.array_equal(c.raw("Q"), c.raw("Q").T)


def test_default_config_is_read_from_c():
    cfg = ModelConfig.default()
    raw = ffi.new("vt_kf_model_cfg *")
    assert lib.vt_kf_model_cfg_default(raw) == lib.VT_OK
    assert cfg.dt == raw.dt / Q16 and cfg.p_max == raw.p_max / Q16
    assert 2 * cfg.p_max + cfg.p_zero <= 1 and cfg.dt > 0


# ------------------------------------------------------------------ long runs vs filterpy
# The corners of the domain always run: the slowest filter (smallest q/r, where
# rounding is remembered longest) and the fastest.
SLOW_CFG = ModelConfig(1.0, 0.05, 0.05, 0.0, 0.75, 12.0, 12.0, 30.0, 20.0)
FAST_CFG = ModelConfig(1.0, 3.0, 2.0, 0.3, 0.0, 0.5, 0.5, 0.5, 0.5)


@pytest.mark.parametrize("model", ["be", "cv"])
@settings(max_examples=12, **SETTINGS)
@given(cfg=model_cfgs(), seed=st.integers(0, 2 ** 32 - 1), n_steps=st.integers(1000, 1200),
       p_drop=st.sampled_from([0.0, 0.1, 0.3, 0.6]), noise=q16_values(0.25, 8.0))
@example(cfg=SLOW_CFG, seed=7, n_steps=1200, p_drop=0.0, noise=8.0)
@example(cfg=SLOW_CFG, seed=8, n_steps=1200, p_drop=0.6, noise=8.0)
@example(cfg=FAST_CFG, seed=9, n_steps=1000, p_drop=0.3, noise=0.25)
def test_long_runs_match_filterpy(model, cfg, seed, n_steps, p_drop, noise):
    run_vs_filterpy(model, cfg, seed, n_steps, p_drop, noise, check=True)


@st.composite
def general_filters(draw):
    """A random dense filter of any size up to the maxima: stable F, full-rank or
    not H, full (non-diagonal) PSD Q and R, so the gain solve pivots."""
    n = draw(st.integers(1, MAXX))
    m = draw(st.integers(1, MAXZ))
    seed = draw(st.integers(0, 2 ** 32 - 1))
    rng = np.random.default_rng(seed)
    f = rng.uniform(-1, 1, (n, n))
    f *= 0.98 / max(1.0, np.abs(np.linalg.eigvals(f)).max())
    h = rng.uniform(-2, 2, (m, n))
    a = rng.uniform(-1, 1, (n, n))
    q = a @ a.T * rng.uniform(0.01, 2)
    b = rng.uniform(-1, 1, (m, m))
    r = b @ b.T + np.eye(m) * rng.uniform(0.1, 3)
    p0 = np.diag(rng.uniform(1, 100, n))
    q32 = lambda v: np.rint(v * Q32) / Q32  # noqa: E731 (give both sides the same inputs)
    return n, m, seed, q32(f), q32(h), q32((q + q.T) / 2), q32((r + r.T) / 2), q32(p0)


@settings(max_examples=25, **SETTINGS)
@given(g=general_filters())
def test_general_filter_matches_filterpy(g):
    from filterpy.kalman import KalmanFilter as FpKalman
    n, m, seed, f, h, q, r, p0 = g
    c = KalmanFilter(n, m)
    fp = FpKalman(dim_x=n, dim_z=m)
    for name, v in (("F", f), ("H", h), ("Q", q), ("R", r), ("P", p0)):
        setattr(c, name, v)
        setattr(fp, name, v.copy())
    rng = np.random.default_rng(seed ^ 0x5A5A)
    for k in range(300):
        c.predict()
        fp.predict()
        if rng.random() < 0.8:
            z = np.rint(rng.uniform(-50, 50, m) * Q16) / Q16
            c.update(z)
            fp.update(z)
            np.testing.assert_allclose(c.K, fp.K, rtol=1e-6, atol=1e-7)
        assert np.abs(c.x - fp.x.ravel()).max() <= TOL_X_PX
        pc, pr = c.P, fp.P
        scale = np.sqrt(np.outer(np.diag(pr), np.diag(pr)))
        assert np.all(np.abs(pc - pr) <= RTOL_P * scale + ATOL_P)
        raw = c.raw("P")
        assert np.array_equal(raw, raw.T)
        assert np.linalg.eigvalsh(pc).min() >= -PSD_TINY


# ------------------------------------------------------------------ singular S
def test_singular_when_p_and_r_are_zero():
    kf = KalmanFilter.constant_velocity(10.0, 20.0)
    kf.P = np.zeros((4, 4))
    kf.R = np.zeros((2, 2))
    x0, p0, k0 = kf.raw("x"), kf.raw("P"), kf.raw("K")
    with pytest.raises(vt.VtError) as e:
        kf.update([11.0, 21.0])
    assert e.value.status == lib.VT_E_SINGULAR and e.value.function == "vt_kf_update"
    # nothing the filter relies on changed; y and S describe the failed update
    assert np.array_equal(kf.raw("x"), x0) and np.array_equal(kf.raw("P"), p0)
    assert np.array_equal(kf.raw("K"), k0)
    np.testing.assert_array_equal(kf.y, [1.0, 1.0])
    np.testing.assert_array_equal(kf.S, np.zeros((2, 2)))


def test_singular_rank_deficient_s_in_c():
    kf = ffi.new("vt_kf *")
    assert lib.vt_kf_init(kf, 3, 2) == lib.VT_OK
    for i in range(2):  # two identical measurement rows, no noise: S = [[a, a], [a, a]]
        kf.H[i][0] = Q32
        kf.R[i][i] = 0
    z = ffi.new("vt_q16[2]", [Q16, 2 * Q16])
    assert lib.vt_kf_update(kf, z) == lib.VT_E_SINGULAR


def test_near_singular_gain_overflow_is_singular():
    # S = 2^-32 (1 LSB) with P H^T = 2^30: the gain 2^62 cannot be held in Q31.32.
    kf = ffi.new("vt_kf *")
    assert lib.vt_kf_init(kf, 2, 1) == lib.VT_OK
    kf.H[0][0] = Q32
    kf.P[0][0] = 1
    kf.P[1][0] = kf.P[0][1] = 1 << 62
    kf.P[1][1] = (1 << 63) - 1
    kf.R[0][0] = 0
    z = ffi.new("vt_q16[1]", [Q16])
    assert lib.vt_kf_update(kf, z) == lib.VT_E_SINGULAR


# ------------------------------------------------------------------ saturation
def test_huge_measurements_saturate_never_wrap():
    kf = KalmanFilter.constant_velocity(30000.0, -30000.0)
    big = 32767.99998
    for _ in range(200):
        kf.predict()
        kf.update([big, -32768.0])
        x = kf.raw("x")
        assert x[0] > 0 and x[1] < 0  # never a sign flip
        assert x[0] <= (1 << 31) - 1 and x[1] >= -(1 << 31)
    assert kf.x[0] == pytest.approx(big, abs=0.01) and kf.x[1] == pytest.approx(-32768, abs=0.01)
    # The opposite extreme: a jump of 65535 px clips the residual at the Q15.16
    # limit instead of wrapping it.
    kf.update([-32768.0, 32767.0])
    assert kf.y[0] == -32768.0 and kf.y[1] == pytest.approx(32768.0, abs=1e-4)
    assert kf.raw("x")[0] < (1 << 31) - 1


def test_huge_covariance_saturates_symmetric():
    kf = ffi.new("vt_kf *")
    assert lib.vt_kf_init(kf, 4, 2) == lib.VT_OK
    top = (1 << 63) - 1
    for i in range(4):
        kf.P[i][i] = top
        kf.F[i][i] = Q32
    kf.F[0][2] = kf.F[1][3] = 8 * Q32
    kf.H[0][0] = kf.H[1][1] = Q32
    z = ffi.new("vt_q16[2]", [5 * Q16, -5 * Q16])
    for _ in range(20):
        assert lib.vt_kf_predict(kf) == lib.VT_OK
        assert lib.vt_kf_update(kf, z) in (lib.VT_OK, lib.VT_E_SINGULAR)
        p = np.frombuffer(ffi.buffer(kf.P), np.int64).reshape(MAXX, MAXX)[:4, :4]
        assert np.array_equal(p, p.T)
        assert np.all(np.diag(p) >= 0)  # a saturated variance stays at the top


@settings(max_examples=200, **SETTINGS)
@given(n=st.integers(1, MAXX), m=st.integers(1, MAXZ), data=st.data())
def test_any_field_values_never_crash(n, m, data):
    """Arbitrary bit patterns in every field (run under SAN=1 for UB): the
    status is OK or SINGULAR, and P is symmetric after an OK step."""
    extreme = st.one_of(st.integers(-(1 << 63), (1 << 63) - 1),
                        st.sampled_from([-(1 << 63), (1 << 63) - 1, 0, 1, -1, Q32, -Q32]))
    kf = ffi.new("vt_kf *")
    assert lib.vt_kf_init(kf, n, m) == lib.VT_OK
    for name, rows, cols in (("P", n, n), ("F", n, n), ("Q", n, n), ("H", m, n), ("R", m, m)):
        field = getattr(kf, name)
        for i in range(rows):
            for j in range(cols):
                field[i][j] = data.draw(extreme)
    for i in range(n):
        kf.x[i] = data.draw(st.integers(-(1 << 31), (1 << 31) - 1))
    z = ffi.new("vt_q16[]", [data.draw(st.integers(-(1 << 31), (1 << 31) - 1)) for _ in range(m)])
    for step in range(3):
        assert lib.vt_kf_predict(kf) == lib.VT_OK
        p = np.frombuffer(ffi.buffer(kf.P), np.int64).reshape(MAXX, MAXX)[:n, :n]
        assert np.array_equal(p, p.T)
        assert lib.vt_kf_update(kf, z) in (lib.VT_OK, lib.VT_E_SINGULAR)
        p = np.frombuffer(ffi.buffer(kf.P), np.int64).reshape(MAXX, MAXX)[:n, :n]
        assert np.array_equal(p, p.T)


# ------------------------------------------------------------------ bad arguments
def test_bad_arguments_c():
    NULL = ffi.NULL
    kf = ffi.new("vt_kf *")
    z = ffi.new("vt_q16[4]")
    cfg = ffi.new("vt_kf_model_cfg *")
    var = ffi.new("vt_q32 *")
    assert lib.vt_kf_model_cfg_default(cfg) == lib.VT_OK
    assert lib.vt_kf_init(NULL, 4, 2) == lib.VT_E_ARG
    for dx, dz in ((0, 1), (-1, 1), (MAXX + 1, 1), (1, 0), (1, MAXZ + 1), (-(1 << 31), 2),
                   ((1 << 31) - 1, 2), (4, -(1 << 31))):
        assert lib.vt_kf_init(kf, dx, dz) == lib.VT_E_SIZE
    # A zeroed (never initialised) filter has dims 0: refused, not run.
    assert lib.vt_kf_predict(kf) == lib.VT_E_SIZE
    assert lib.vt_kf_update(kf, z) == lib.VT_E_SIZE
    assert lib.vt_kf_predict(NULL) == lib.VT_E_ARG
    assert lib.vt_kf_update(NULL, z) == lib.VT_E_ARG
    assert lib.vt_kf_init(kf, 4, 2) == lib.VT_OK
    assert lib.vt_kf_update(kf, NULL) == lib.VT_E_ARG
    for dx, dz in ((MAXX + 1, 2), (4, MAXZ + 1), (-3, 2), (4, 0)):  # corrupted dims
        kf.dim_x, kf.dim_z = dx, dz
        assert lib.vt_kf_predict(kf) == lib.VT_E_SIZE
        assert lib.vt_kf_update(kf, z) == lib.VT_E_SIZE
    assert lib.vt_kf_accel_var(Q16, 0, 0, NULL) == lib.VT_E_ARG
    for a, p1, p2 in ((-1, 0, 0), (Q16, -1, 0), (Q16, 0, -1), (Q16, Q16 // 2 + 1, 0),
                      (Q16, Q16 // 4, Q16 // 2 + 1), (Q16, 1 << 30, 1 << 30)):
        assert lib.vt_kf_accel_var(a, p1, p2, var) == lib.VT_E_ARG
    assert lib.vt_kf_model_cfg_default(NULL) == lib.VT_E_ARG
    assert lib.vt_kf_init_bottom_edge(NULL, cfg, 0, 0, 0) == lib.VT_E_ARG
    assert lib.vt_kf_init_bottom_edge(kf, NULL, 0, 0, 0) == lib.VT_E_ARG
    assert lib.vt_kf_init_cv(NULL, cfg, 0, 0) == lib.VT_E_ARG
    assert lib.vt_kf_init_cv(kf, NULL, 0, 0) == lib.VT_E_ARG
    before = bytes(ffi.buffer(kf))
    for field, value in (("dt", 0), ("dt", -Q16), ("accel_x", -1), ("accel_y", -1),
                         ("p_max", -1), ("p_zero", -1), ("p_max", Q16), ("meas_sigma_x", -1),
                         ("meas_sigma_y", -1), ("init_sigma_pos", -1), ("init_sigma_vel", -1)):
        bad = ffi.new("vt_kf_model_cfg *", cfg[0])
        setattr(bad, field, value)
        assert lib.vt_kf_init_bottom_edge(kf, bad, 0, 0, 0) == lib.VT_E_ARG, field
        assert lib.vt_kf_init_cv(kf, bad, 0, 0) == lib.VT_E_ARG, field
    assert bytes(ffi.buffer(kf)) == before  # a refused init does not touch the filter


def test_bad_arguments_python():
    for dims in ((0, 1), (MAXX + 1, 1), (2, 0), (2, MAXZ + 1)):
        with pytest.raises(vt.VtError) as e:
            KalmanFilter(*dims)
        assert e.value.function == "vt_kf_init" and e.value.status == lib.VT_E_SIZE
    with pytest.raises(vt.VtError, match="vt_kf_init_bottom_edge"):
        KalmanFilter.bottom_edge(0, 0, 10, cfg=ModelConfig.default().replace(p_max=0.6))
    with pytest.raises(vt.VtError, match="vt_kf_init_cv"):
        KalmanFilter.constant_velocity(0, 0, cfg=ModelConfig.default().replace(dt=0.0))
    with pytest.raises(vt.VtError, match="vt_kf_accel_var"):
        vt.kalman.accel_var(1.0, 0.0, 1.5)
    kf = KalmanFilter(4, 2)
    with pytest.raises(ValueError):
        kf.update([1.0, 2.0, 3.0])  # wrong size
    with pytest.raises(ValueError):
        kf.update([np.nan, 0.0])
    with pytest.raises(ValueError):
        kf.update([40000.0, 0.0])  # outside Q15.16
    with pytest.raises(ValueError):
        kf.P = np.eye(3)
    with pytest.raises(ValueError):
        kf.P = np.eye(4) * 3e9  # outside Q31.32
    with pytest.raises(ValueError):
        kf.x = [np.inf, 0, 0, 0]
    kf.c.dim_x = MAXX + 5  # corrupted in C: the core refuses it
    with pytest.raises(vt.VtError) as e:
        kf.predict()
    assert e.value.function == "vt_kf_predict" and e.value.status == lib.VT_E_SIZE


def test_python_properties_round_trip():
    kf = KalmanFilter(3, 2)
    rng = np.random.default_rng(3)
    for name, shape in (("x", (3,)), ("P", (3, 3)), ("F", (3, 3)), ("Q", (3, 3)), ("H", (2, 3)),
                        ("R", (2, 2))):
        v = rng.uniform(-100, 100, shape)
        if name in ("P", "Q", "R"):  # covariances must be symmetric PSD (ValueError otherwise)
            v = v @ v.T / 100.0
        setattr(kf, name, v)
        lsb = 1 / Q16 if name == "x" else LSB_P
        assert np.abs(getattr(kf, name) - v).max() <= lsb / 2 + 1e-15
    kf.x = np.ones((3, 1))  # filterpy's column shape is accepted
    np.testing.assert_array_equal(kf.x, [1.0, 1.0, 1.0])
    kf.update(None)  # a dropout: nothing happens
    np.testing.assert_array_equal(kf.x, [1.0, 1.0, 1.0])
    fresh = KalmanFilter(3, 2)  # filterpy's defaults
    np.testing.assert_array_equal(fresh.P, np.eye(3))
    np.testing.assert_array_equal(fresh.F, np.eye(3))
    np.testing.assert_array_equal(fresh.R, np.eye(2))
    np.testing.assert_array_equal(fresh.H, np.zeros((2, 3)))


# ------------------------------------------------------------------ memory
GUARD = 64


@pytest.mark.parametrize("model", ["be", "cv", "max"])
def test_guard_bytes_and_unused_entries(model):
    """The filter placed inside a larger buffer writes neither past its end nor
    before its start, and never touches entries beyond dim_x / dim_z."""
    size = ffi.sizeof("vt_kf")
    buf = ffi.new("uint8_t[]", size + 2 * GUARD)
    ffi.memmove(buf, b"\xa5" * (size + 2 * GUARD), size + 2 * GUARD)
    kf = ffi.cast("vt_kf *", buf + GUARD)
    cfg = ffi.new("vt_kf_model_cfg *")
    lib.vt_kf_model_cfg_default(cfg)
    if model == "be":
        assert lib.vt_kf_init_bottom_edge(kf, cfg, 100 * Q16, 300 * Q16, 180 * Q16) == lib.VT_OK
    elif model == "cv":
        assert lib.vt_kf_init_cv(kf, cfg, 100 * Q16, 300 * Q16) == lib.VT_OK
    else:
        assert lib.vt_kf_init(kf, MAXX, MAXZ) == lib.VT_OK
        for i in range(MAXZ):
            kf.H[i][i] = Q32
    n, m = kf.dim_x, kf.dim_z
    # Mark every unused entry; they must survive the steps unchanged.
    marks = []
    for name, rows, cols, r_used, c_used in (
            ("P", MAXX, MAXX, n, n), ("F", MAXX, MAXX, n, n), ("Q", MAXX, MAXX, n, n),
            ("H", MAXZ, MAXX, m, n), ("R", MAXZ, MAXZ, m, m), ("K", MAXX, MAXZ, n, m),
            ("S", MAXZ, MAXZ, m, m)):
        field = getattr(kf, name)
        for i in range(rows):
            for j in range(cols):
                if i >= r_used or j >= c_used:
                    field[i][j] = 0x5A5A5A5A5A5A5A5A
                    marks.append((name, i, j))
    for i in range(n, MAXX):
        kf.x[i] = 0x5A5A5A5A
    for i in range(m, MAXZ):
        kf.y[i] = 0x5A5A5A5A
    rng = np.random.default_rng(7)
    z = ffi.new("vt_q16[]", m)
    for _ in range(100):
        assert lib.vt_kf_predict(kf) == lib.VT_OK
        for i in range(m):
            z[i] = int(rng.integers(0, 600 * Q16))
        assert lib.vt_kf_update(kf, z) == lib.VT_OK
    raw = bytes(ffi.buffer(buf, size + 2 * GUARD))
    assert raw[:GUARD] == b"\xa5" * GUARD and raw[-GUARD:] == b"\xa5" * GUARD
    for name, i, j in marks:
        assert getattr(kf, name)[i][j] == 0x5A5A5A5A5A5A5A5A, (name, i, j)
    assert all(kf.x[i] == 0x5A5A5A5A for i in range(n, MAXX))
    assert all(kf.y[i] == 0x5A5A5A5A for i in range(m, MAXZ))
