"""Filters of ``liecontrol.estimation``: SRUKF ≡ UKF, square-root robustness, fading factors,
NEES consistency of the manifold UKF and the MEKF, bad input, and the seed-001 ranking."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from scipy.stats import chi2

from liecontrol.charts import quaternion as quat
from liecontrol.estimation import (
    ISTSRUKF,
    MEKF,
    SRUKF,
    STUKF,
    UKF,
    GyroAttitudeModel,
    GyrolessAttitudeModel,
    ManifoldUKF,
    NotPositiveDefiniteError,
    StrongTrackingParams,
)

J = np.diag([10.0, 12.0, 15.0])
X0 = np.r_[quat.from_rotvec(np.array([0.05, -0.03, 0.1])), 0.001, -0.002, 0.05]
P0_ADD = np.diag([2.5e-5] * 4 + [4e-6] * 3)
P0_ERR = np.diag([1e-4] * 3 + [4e-6] * 3)


class LinearCV:
    """Constant-velocity linear model, position measured (stress case for the PD tests)."""

    n, m = 2, 1

    def __init__(self, r: float) -> None:
        self.r = r
        self.A = np.array([[1.0, 1.0], [0.0, 1.0]])

    def f(self, X, u, dt):
        return X @ self.A.T

    def h(self, X):
        return X[:, :1]

    def Q(self, dt):
        return np.zeros((2, 2))

    @property
    def R(self):
        return np.array([[self.r]])

    def normalize(self, X):
        return X

    def z_mean(self, Z, W):
        return W @ Z

    def z_residual(self, a, b):
        return a - b


def _gyroless_data(K: int, seed: int, jump_at: int | None = None):
    m = GyrolessAttitudeModel(J)
    rng = np.random.default_rng(seed)
    x = X0.copy()
    xs, zs = [], []
    for k in range(K):
        x = m.f(x[None], np.zeros(3), 1.0)[0]
        x[4:] += rng.normal(0, m.sigma_w, 3)
        if jump_at is not None and k == jump_at:
            x[4:] += 0.01
        xs.append(x)
        zs.append(m.h(x[None])[0] + rng.normal(0, m.sigma_z))
    return m, np.array(xs), np.array(zs)


# --------------------------------------------------------------------------- SRUKF ≡ UKF


def test_srukf_equals_ukf_with_positive_weights():
    m, _, Z = _gyroless_data(40, 0)
    kw = {"alpha": 1.0, "beta": 2.0, "kappa": 1.0}  # λ = 1: every weight positive
    a, b = UKF(m, X0, P0_ADD, **kw), SRUKF(m, X0, P0_ADD, **kw)
    assert np.all(a.weights.Wc > 0)
    for z in Z:
        for f in (a, b):
            f.predict(np.zeros(3), 1.0)
        np.testing.assert_allclose(b.S @ b.S.T, a.P, rtol=0, atol=1e-10 * np.abs(a.P).max())
        for f in (a, b):
            f.update(z)
        np.testing.assert_allclose(b.S @ b.S.T, a.P, rtol=0, atol=1e-10 * np.abs(a.P).max())
        np.testing.assert_allclose(b.x, a.x, atol=1e-12)
        np.testing.assert_allclose(b.innovation, a.innovation, atol=1e-12)
    assert np.allclose(np.triu(b.S, 1), 0.0)


def _run_stress(cls, seed, alpha=1e-2, pd_policy="raise", steps=100):
    """Constant velocity, near-perfect position measurements (R = 1e-14): returns the step at
    which a NotPositiveDefiniteError was raised (-1 if none) and the filter."""
    m = LinearCV(r=1e-14)
    rng = np.random.default_rng(seed)
    f = cls(m, np.array([1.0, 1.0]), np.eye(2), alpha=alpha, pd_policy=pd_policy)
    xt = np.array([1.0, 1.0])
    for k in range(steps):
        xt = m.A @ xt
        try:
            f.predict(np.zeros(3), 1.0)
            f.update(xt[:1] + rng.normal(0, 1e-7, 1))
        except NotPositiveDefiniteError:
            return k, f
    return -1, f


def test_srukf_stays_pd_where_ukf_loses_it():
    """α = 1e-2 (W₀ᶜ ≈ −6.7e3) and near-perfect measurements: the covariance-form UKF loses
    positive-definiteness by round-off on most seeds; the SRUKF on none."""
    assert UKF(LinearCV(1e-14), np.ones(2), np.eye(2), alpha=1e-2).weights.Wc[0] < -1e3
    ukf_fail = [_run_stress(UKF, s)[0] for s in range(8)]
    assert sum(k >= 0 for k in ukf_fail) >= 4
    for s in range(8):
        k, f = _run_stress(SRUKF, s)
        assert k == -1
        assert np.all(np.diag(f.S) > 0) and np.all(np.isfinite(f.S))
    # with the repair policy the UKF carries on with a PD covariance, never NaN
    k, f = _run_stress(UKF, 0, pd_policy="repair")
    assert k == -1 and np.linalg.eigvalsh(f.P).min() > 0


def test_istsrukf_central_form_never_needs_a_downdate():
    """α = 1e-3 (W₀ᶜ ≈ −6.7e5): the SRUKF's zeroth-point downdate fails on some seeds; the
    ISTSRUKF (central-point covariance, Joseph update) on none (SPEC §7 item 4)."""
    sr = [_run_stress(SRUKF, s, alpha=1e-3)[0] for s in range(8)]
    assert any(k >= 0 for k in sr)
    for s in range(8):
        k, f = _run_stress(ISTSRUKF, s, alpha=1e-3)
        assert k == -1 and np.all(np.isfinite(f.x))
        assert abs(f.x[0] - (1.0 + 100.0)) < 1e-5


def test_repair_is_flagged(caplog):
    seed = next(s for s in range(8) if _run_stress(UKF, s)[0] >= 0)
    m = LinearCV(r=1e-14)
    rng = np.random.default_rng(seed)
    f = UKF(m, np.array([1.0, 1.0]), np.eye(2), alpha=1e-2, pd_policy="repair")
    xt = np.array([1.0, 1.0])
    flags = []
    with caplog.at_level(logging.WARNING, logger="liecontrol.estimation"):
        for _ in range(100):
            xt = m.A @ xt
            f.step(np.zeros(3), 1.0, xt[:1] + rng.normal(0, 1e-7, 1))
            flags.append(f.diagnostics["repaired"])
    assert any(flags)
    assert "positive-definiteness" in caplog.text
    assert np.all(np.isfinite(f.x)) and abs(f.x[0] - 101.0) < 1e-5


# --------------------------------------------------------------------------- fading factors


@pytest.mark.parametrize("cls", [STUKF, ISTSRUKF])
def test_fading_factors_quiet_then_jump(cls):
    m, _, Z = _gyroless_data(130, 1, jump_at=120)
    f = cls(m, X0, P0_ADD)
    mus = []
    for z in Z:
        f.step(np.zeros(3), 1.0, z)
        mus.append(f.diagnostics["fading"])
    mus = np.array(mus)
    assert mus.shape == (130, 7)
    np.testing.assert_array_equal(mus[30:121], 1.0)  # steady state, correct model
    assert mus[121:124].max() > 10.0  # right after the rate jump


def test_strong_tracking_params_validation():
    with pytest.raises(ValueError, match="^rho"):
        StrongTrackingParams(rho=1.5)
    with pytest.raises(ValueError, match="^softening"):
        StrongTrackingParams(softening=0.5)
    with pytest.raises(ValueError, match="^alphas"):
        StrongTrackingParams(alphas=[1.0, 0.5])
    m = GyrolessAttitudeModel(J)
    with pytest.raises(ValueError, match="^alphas"):
        STUKF(m, X0, P0_ADD, tracking=StrongTrackingParams(alphas=[1.0, 2.0]))


# --------------------------------------------------------------------------- NEES consistency


def _nees_band(nees: np.ndarray, d: int) -> float:
    N = nees.shape[1]
    lo, hi = chi2.ppf([0.025, 0.975], d * N) / N
    avg = nees.mean(axis=1)
    return float(np.mean((avg > lo) & (avg < hi)))


def test_manifold_ukf_nees_tumbling():
    N, K, dt = 16, 60, 0.5
    m = GyrolessAttitudeModel(J, sigma_w=1e-4, sigma_theta=1e-4, sigma_z=2e-3)
    rng = np.random.default_rng(7)
    x0 = np.r_[quat.from_rotvec(np.array([0.1, -0.2, 0.3])), 0.02, -0.015, 0.3]
    X = np.tile(x0, (N, 1))
    LQ = np.linalg.cholesky(m.Q_err(dt))
    xh = m.boxplus(X, rng.normal(size=(N, 6)) @ np.linalg.cholesky(P0_ERR).T)
    fs = [ManifoldUKF(m, xh[i], P0_ERR) for i in range(N)]
    nees = np.empty((K, N))
    for k in range(K):
        X = m.boxplus(m.f(X, np.zeros(3), dt), rng.normal(size=(N, 6)) @ LQ.T)
        Z = m.h(X) + rng.normal(0, 2e-3, (N, 3))
        for i, f in enumerate(fs):
            f.step(np.zeros(3), dt, Z[i])
            nees[k, i] = f.nees(X[i])
    # quaternions stay unit without any normalisation constraint in the covariance
    assert abs(np.linalg.norm(fs[0].x[:4]) - 1.0) < 1e-12
    assert _nees_band(nees, 6) >= 0.9
    assert 0.85 * 6 < nees.mean() < 1.15 * 6


def test_mekf_nees_tumbling_with_gyro():
    N, K, dt = 16, 80, 0.5
    m = GyroAttitudeModel(sigma_v=1e-3, sigma_u=1e-5, sigma_z=2e-3)
    plant = GyrolessAttitudeModel(J)
    rng = np.random.default_rng(8)
    q = np.tile(quat.from_rotvec(np.array([0.1, -0.2, 0.3])), (N, 1))
    X = np.concatenate((q, np.tile([0.01, -0.005, 0.002], (N, 1))), axis=1)
    W = np.tile([0.02, -0.015, 0.3], (N, 1))  # torque-free tumbling (Euler's equations)
    xh = m.boxplus(X, rng.normal(size=(N, 6)) @ np.linalg.cholesky(P0_ERR).T)
    fs = [MEKF(m, xh[i], P0_ERR) for i in range(N)]
    nees = np.empty((K, N))
    for k in range(K):
        gyro = W + X[:, 4:] + rng.normal(0, m.sigma_v / np.sqrt(dt), (N, 3))
        qn = quat.multiply(X[:, :4], quat.from_rotvec(W * dt))
        bn = X[:, 4:] + rng.normal(0, m.sigma_u * np.sqrt(dt), (N, 3))
        W = plant.f(np.concatenate((qn, W), axis=1), np.zeros(3), dt)[:, 4:]
        X = np.concatenate((qn, bn), axis=1)
        Z = m.h(X) + rng.normal(0, 2e-3, (N, 3))
        for i, f in enumerate(fs):
            f.step(gyro[i], dt, Z[i])
            nees[k, i] = f.nees(X[i])
    assert _nees_band(nees, 6) >= 0.9
    assert 0.85 * 6 < nees.mean() < 1.15 * 6


def test_mekf_numerical_jacobian_path_on_gyroless_model():
    m, xs, Z = _gyroless_data(60, 3)
    f = MEKF(m, X0, P0_ERR)
    g = ManifoldUKF(m, X0, P0_ERR)
    for z in Z:
        f.step(np.zeros(3), 1.0, z)
        g.step(np.zeros(3), 1.0, z)
    # EKF and UKF agree closely on this mildly nonlinear problem, and both track the truth
    np.testing.assert_allclose(f.x[4:], g.x[4:], atol=2e-4)
    assert np.linalg.norm(f.error(xs[-1])[:3]) < 0.01


# --------------------------------------------------------------------------- bad input


ALL = [
    (UKF, P0_ADD),
    (SRUKF, P0_ADD),
    (STUKF, P0_ADD),
    (ISTSRUKF, P0_ADD),
    (ManifoldUKF, P0_ERR),
    (MEKF, P0_ERR),
]


@pytest.mark.parametrize("cls,P0", ALL, ids=[c.__name__ for c, _ in ALL])
def test_bad_input(cls, P0, caplog):
    m = GyrolessAttitudeModel(J)
    with pytest.raises(ValueError, match="^P0: not positive definite"):
        cls(m, X0, -P0)
    with pytest.raises(ValueError, match="^P0: expected shape"):
        cls(m, X0, np.eye(3))
    with pytest.raises(ValueError, match="^x0"):
        cls(m, X0[:6], P0)
    with pytest.raises(ValueError, match="^pd_policy"):
        cls(m, X0, P0, pd_policy="ignore")
    if cls is not MEKF:
        with pytest.raises(ValueError, match="^alpha"):
            cls(m, X0, P0, alpha=0.0)
    f = cls(m, X0, P0)
    with pytest.raises(ValueError, match="^dt"):
        f.predict(np.zeros(3), 0.0)
    with pytest.raises(ValueError, match="^u"):
        f.predict(np.zeros(2), 1.0)
    f.predict(np.zeros(3), 1.0)
    x_pred, P_pred = f.x, f.P
    with pytest.raises(ValueError, match="^z: expected shape"):
        f.update(np.zeros(4))
    with caplog.at_level(logging.WARNING, logger="liecontrol.estimation"):
        ok = f.update(np.array([0.1, np.nan, 0.0]))
    assert not ok
    assert f.diagnostics["update_rejected"]
    assert f.diagnostics["reason"].startswith("z: non-finite")
    assert "rejected" in caplog.text
    np.testing.assert_array_equal(f.x, x_pred)
    np.testing.assert_array_equal(f.P, P_pred)
    assert f.update(m.h(f.x[None])[0])  # a good measurement is accepted afterwards
    assert not f.diagnostics["update_rejected"]


# --------------------------------------------------------------------------- seed 001


def test_seed001_ranking_quick(tmp_path):
    from benchmarks.reproductions import seed001

    cfg = seed001.Seed001Config(n_seeds=3, substeps=5, filters=seed001.RANKED)
    result = seed001.run(cfg, quick=True)
    failed = [c for c in result["checks"] if c["result"] != "PASS"]
    assert not failed, failed
    assert len(result["checks"]) >= 8
    paths = seed001._figures(result, tmp_path)
    assert all(p.exists() and p.stat().st_size > 0 for p in paths)
    md = seed001._markdown(result)
    assert "| SRUKF | 200-300 s |" in md and "PASS" in md
