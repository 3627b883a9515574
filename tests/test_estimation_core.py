"""Unscented transform, Cholesky update/downdate, QR triangularisation and the attitude models
of ``liecontrol.estimation`` — each checked against an independent route."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from liecontrol.charts import quaternion as quat
from liecontrol.estimation import (
    GyroAttitudeModel,
    GyrolessAttitudeModel,
    NotPositiveDefiniteError,
    cholupdate,
    euler_rpy_from_quaternion,
    euler_rpy_jacobian,
    nearest_pd_sqrt,
    numerical_error_transition,
    tria,
    unscented_transform,
    ut_weights,
    wrap_angle,
)
from liecontrol.lie import so3

J = np.diag([10.0, 12.0, 15.0])


def _spd(rng: np.random.Generator, n: int, cond: float = 100.0) -> np.ndarray:
    U, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return (U * np.geomspace(1.0, 1.0 / cond, n)) @ U.T


# --------------------------------------------------------------------------- weights / UT


def test_weights_formulas():
    w = ut_weights(7, alpha=0.5, beta=2.0, kappa=None)
    lam = 0.25 * (7 + (3 - 7)) - 7
    assert w.lam == pytest.approx(lam)
    assert w.Wm[0] == pytest.approx(lam / (7 + lam))
    assert w.Wc[0] == pytest.approx(lam / (7 + lam) + 1 - 0.25 + 2)
    assert np.allclose(w.Wm[1:], 1 / (2 * (7 + lam)))
    assert w.Wm.sum() == pytest.approx(1.0)
    assert w.gamma == pytest.approx(np.sqrt(7 + lam))


@pytest.mark.parametrize("alpha", [0.0, -1.0, np.nan])
def test_weights_reject_bad_alpha(alpha):
    with pytest.raises(ValueError, match="^alpha"):
        ut_weights(3, alpha=alpha)


def test_weights_reject_imaginary_points():
    with pytest.raises(ValueError, match="^kappa"):
        ut_weights(3, alpha=1.0, kappa=-3.0)


@settings(max_examples=30, deadline=None)
@given(
    n=st.integers(1, 7),
    m=st.integers(1, 4),
    alpha=st.floats(0.05, 1.0),
    kappa=st.floats(0.0, 3.0),
    seed=st.integers(0, 2**31 - 1),
)
def test_ut_exact_for_linear_maps(n, m, alpha, kappa, seed):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=n)
    P = _spd(rng, n)
    A = rng.normal(size=(m, n))
    b = rng.normal(size=m)
    ybar, Py, Pxy = unscented_transform(lambda X: X @ A.T + b, x, P, alpha=alpha, kappa=kappa)
    np.testing.assert_allclose(ybar, A @ x + b, atol=1e-9)
    np.testing.assert_allclose(Py, A @ P @ A.T, atol=1e-9)
    np.testing.assert_allclose(Pxy, P @ A.T, atol=1e-9)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), alpha=st.floats(0.1, 1.0))
def test_central_form_identity(seed, alpha):
    """Julier's modified form = standard form (Wᶜ = Wᵐ) + (ȳ − Y₀)(ȳ − Y₀)ᵀ; always PSD."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=3)
    P = _spd(rng, 3)

    def g(X):
        return np.stack((np.sin(X[:, 0]) * X[:, 1], X[:, 2] ** 2, np.exp(0.3 * X[:, 0])), axis=1)

    ybar, Pc, _ = unscented_transform(g, x, P, alpha=alpha, beta=0.0, central=True)
    w = ut_weights(3, alpha=alpha)
    from liecontrol.estimation.unscented import sigma_points

    X = sigma_points(x, np.linalg.cholesky(P), w.gamma)
    Y = g(X)
    dY = Y - w.Wm @ Y
    Pstd = (dY * w.Wm[:, None]).T @ dY
    d = ybar - Y[0]
    np.testing.assert_allclose(Pc, Pstd + np.outer(d, d), rtol=1e-9, atol=1e-12)
    assert np.linalg.eigvalsh(Pc).min() >= -1e-12


def test_ut_rejects_non_pd_covariance():
    with pytest.raises(ValueError, match="^P: not positive definite"):
        unscented_transform(lambda X: X, np.zeros(2), np.diag([1.0, -1.0]))
    with pytest.raises(ValueError, match="^P: not symmetric"):
        unscented_transform(lambda X: X, np.zeros(2), np.array([[1.0, 0.5], [0.0, 1.0]]))


# --------------------------------------------------------------------------- Cholesky


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 8), k=st.integers(1, 3), seed=st.integers(0, 2**31 - 1))
def test_cholupdate_matches_dense(n, k, seed):
    rng = np.random.default_rng(seed)
    P = _spd(rng, n)
    L = np.linalg.cholesky(P)
    V = rng.normal(size=(n, k))
    up = cholupdate(L, V, +1)
    np.testing.assert_allclose(up, np.linalg.cholesky(P + V @ V.T), rtol=1e-9, atol=1e-11)
    # downdate by vectors small enough to keep P − V Vᵀ positive definite
    Vd = L @ rng.normal(size=(n, k))
    Vd *= 0.4 / np.sqrt(k) / np.linalg.norm(np.linalg.solve(L, Vd), axis=0)
    dn = cholupdate(L, Vd, -1)
    np.testing.assert_allclose(dn, np.linalg.cholesky(P - Vd @ Vd.T), rtol=1e-8, atol=1e-10)
    assert np.allclose(np.triu(dn, 1), 0.0)


def test_cholupdate_batched_equals_single():
    rng = np.random.default_rng(3)
    Ls = np.stack([np.linalg.cholesky(_spd(rng, 4)) for _ in range(5)])
    u = rng.normal(size=(5, 4))
    v = 0.5 * np.einsum("bij,bj->bi", Ls, u / np.linalg.norm(u, axis=1, keepdims=True))
    for sign in (+1, -1):
        batched = cholupdate(Ls, v, sign)
        single = np.stack([cholupdate(Ls[i], v[i], sign) for i in range(5)])
        dense = np.linalg.cholesky(Ls @ np.swapaxes(Ls, -1, -2) + sign * v[:, :, None] * v[:, None])
        np.testing.assert_allclose(batched, single, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(batched, dense, rtol=1e-9, atol=1e-12)


def test_cholupdate_failing_downdate_raises():
    L = np.eye(3)
    with pytest.raises(NotPositiveDefiniteError, match="^S:"):
        cholupdate(L, np.array([0.0, 1.5, 0.0]), -1)
    with pytest.raises(NotPositiveDefiniteError, match="^S:"):
        cholupdate(np.stack([L, L]), np.array([[0, 0, 0.5], [0.0, 1.0, 0.0]]), -1)


def test_cholupdate_bad_input():
    with pytest.raises(ValueError, match="^S:"):
        cholupdate(np.ones((2, 3)), np.ones(2))
    with pytest.raises(ValueError, match="^v:"):
        cholupdate(np.eye(3), np.ones(4))
    with pytest.raises(ValueError, match="^sign"):
        cholupdate(np.eye(3), np.ones(3), 0.5)
    L = np.eye(3)
    v = np.ones(3)
    cholupdate(L, v)
    assert np.array_equal(L, np.eye(3)) and np.array_equal(v, np.ones(3))  # inputs untouched


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 7), extra=st.integers(0, 10), seed=st.integers(0, 2**31 - 1))
def test_tria(n, extra, seed):
    A = np.random.default_rng(seed).normal(size=(n, n + extra))
    S = tria(A)
    np.testing.assert_allclose(S @ S.T, A @ A.T, rtol=1e-10, atol=1e-10)
    assert np.allclose(np.triu(S, 1), 0.0) and np.all(np.diag(S) >= 0)


def test_nearest_pd_sqrt_repairs():
    P = np.array([[1.0, 1.0], [1.0, 1.0 - 1e-9]])  # indefinite by rounding
    S = nearest_pd_sqrt(P)
    assert np.all(np.isfinite(S))
    np.testing.assert_allclose(S @ S.T, P, atol=1e-8)


# --------------------------------------------------------------------------- models


def test_euler_measurement_matches_scipy():
    rng = np.random.default_rng(0)
    R = Rotation.random(200, random_state=rng)
    q = np.roll(R.as_quat(), 1, axis=-1)
    ypr = R.as_euler("ZYX")
    rpy = euler_rpy_from_quaternion(q)
    np.testing.assert_allclose(wrap_angle(rpy - ypr[:, ::-1]), 0.0, atol=1e-9)
    # and against the project's Euler chart (angles returned in sequence order ψ, θ, φ)
    from liecontrol.charts import euler

    chart = euler.from_matrix(quat.to_matrix(q[:50]), "ZYX")
    np.testing.assert_allclose(wrap_angle(rpy[:50] - chart[:, ::-1]), 0.0, atol=1e-9)
    # non-unit quaternions (additive-UKF sigma points) are normalised first
    np.testing.assert_allclose(euler_rpy_from_quaternion(3.0 * q), rpy, atol=1e-12)


def test_euler_jacobian_matches_finite_differences():
    m = GyroAttitudeModel()
    rng = np.random.default_rng(1)
    q = quat.from_rotvec(0.6 * rng.normal(size=(5, 3)))
    x = np.concatenate((q, np.zeros((5, 3))), axis=1)
    eps = 1e-6
    for xi in x:
        Hn = np.empty((3, 3))
        for j in range(3):
            d = np.zeros(6)
            d[j] = eps
            zp = m.h(m.boxplus(xi[None], d[None]))[0]
            zm = m.h(m.boxplus(xi[None], -d[None]))[0]
            Hn[:, j] = wrap_angle(zp - zm) / (2 * eps)
        np.testing.assert_allclose(m.measurement_jacobian(xi)[:, :3], Hn, atol=1e-7)
    with pytest.raises(ValueError, match="^rpy"):
        euler_rpy_jacobian(np.array([0.1, np.pi / 2, 0.0]))


def test_gyroless_rk4_step_matches_solve_ivp():
    m = GyrolessAttitudeModel(J)
    x0 = np.r_[quat.from_rotvec(np.array([0.2, -0.1, 0.4])), 0.05, -0.03, 0.08]
    N = np.array([1e-3, -2e-3, 5e-4])
    sol = solve_ivp(lambda t, y: m.rhs(y[None], N)[0], (0, 0.5), x0, rtol=1e-12, atol=1e-14)
    ref = sol.y[:, -1]
    ref[:4] /= np.linalg.norm(ref[:4])
    np.testing.assert_allclose(m.f(x0[None], N, 0.5)[0], ref, atol=1e-9)
    # batched: each row equals its own single call
    X = np.stack([x0, x0 * np.r_[np.ones(4), 2 * np.ones(3)]])
    Y = m.f(X, N, 0.5)
    np.testing.assert_allclose(Y[1], m.f(X[1:2], N, 0.5)[0], atol=1e-15)


def test_gyroless_rhs_matches_quaternion_kinematics():
    m = GyrolessAttitudeModel(J)
    rng = np.random.default_rng(2)
    q = quat.normalize(rng.normal(size=(4, 4)))
    w = rng.normal(size=(4, 3))
    d = m.rhs(np.concatenate((q, w), axis=1), np.zeros(3))
    np.testing.assert_allclose(d[:, :4], quat.kinematics(q, w), atol=1e-14)
    np.testing.assert_allclose(d[:, 4:], -np.cross(w, w @ J) @ np.linalg.inv(J), atol=1e-14)


def test_gyro_model_transition_and_noise():
    m = GyroAttitudeModel(sigma_v=1e-3, sigma_u=1e-5)
    x = np.r_[quat.from_rotvec(np.array([0.3, 0.2, -0.5])), 0.01, -0.02, 0.005]
    u = np.array([0.3, -0.2, 0.4])
    F = m.error_transition(x, u, 0.5)
    Fn = numerical_error_transition(m, x, u, 0.5)
    np.testing.assert_allclose(F, Fn, atol=1e-7)
    # propagation is q ⊗ Exp((ω̃ − b) dt): compare with scipy's composition
    y = m.f(x[None], u, 0.5)[0]
    Rq = Rotation.from_quat(np.roll(x[:4], -1)) * Rotation.from_rotvec((u - x[4:]) * 0.5)
    np.testing.assert_allclose(np.roll(Rq.as_quat(), 1) * np.sign(Rq.as_quat()[3] * y[0]),
                               y[:4], atol=1e-12)
    Q = m.Q_err(0.5)
    assert np.allclose(Q, Q.T) and np.linalg.eigvalsh(Q).min() > 0


def test_boxplus_boxminus_roundtrip():
    m = GyrolessAttitudeModel(J)
    rng = np.random.default_rng(4)
    x = np.concatenate((quat.from_rotvec(rng.normal(size=(6, 3))), rng.normal(size=(6, 3))), 1)
    d = 0.5 * rng.normal(size=(6, 6))
    np.testing.assert_allclose(m.boxminus(m.boxplus(x, d), x), d, atol=1e-12)
    R = so3.exp(d[:, :3])
    np.testing.assert_allclose(quat.to_matrix(m.boxplus(x, d)[:, :4]),
                               quat.to_matrix(x[:, :4]) @ R, atol=1e-12)


def test_model_bad_input():
    with pytest.raises(ValueError, match="^J"):
        GyrolessAttitudeModel(np.diag([1.0, 1.0, 3.0]))
    with pytest.raises(ValueError, match="^sigma_z"):
        GyrolessAttitudeModel(J, sigma_z=0.0)
    with pytest.raises(ValueError, match="^sigma_v"):
        GyroAttitudeModel(sigma_v=-1.0)
