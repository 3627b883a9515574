"""Tests for liecontrol.integrators (SPEC §3): RK4, RKMK4 and the rigid-body LGVI.

Independent routes: scipy's Rotation and expm, the closed-form torque-free axisymmetric rigid
body, RKMK4 at a fine step as reference for the LGVI, the defining matrix equation of the LGVI
checked directly, and explicit RK4 on the matrix entries as the drifting baseline.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from liecontrol._kernels.so3 import dexpinv_rkmk4
from liecontrol.integrators import (
    LGVIConvergenceError,
    RigidBodyLGVI,
    integrate,
    lgvi_step,
    rk4_step,
    rk4_step_unchecked,
    rkmk4_step,
    rkmk4_step_unchecked,
)
from liecontrol.integrators import rk as rkmod
from liecontrol.lie import so3

J_ASYM = np.diag([1.0, 2.0, 3.0])
# near the intermediate (unstable) axis: the body tumbles
W_TUMBLE = np.array([[0.05, 1.0, 0.05]])


def euler_field(J, torque=None):
    """Rigid body on SO(3) × ℝ³: Ṙ = R ω^, J ω̇ = −ω × Jω + M(t, R)."""
    Jinv = np.linalg.inv(J)

    def f(t, R, x):
        w = x[..., :3]
        rhs = -np.cross(w, w @ J.T)
        if torque is not None:
            rhs = rhs + torque(t, R)
        return w, rhs @ Jinv.T

    return f


def orth_err(R):
    return np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-2, -1))


def random_inertia(rng):
    lam = rng.uniform(1.0, 1.9, size=3)
    Q = Rotation.random(random_state=rng).as_matrix()
    return Q @ np.diag(lam) @ Q.T


vec3 = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3).map(np.array)


# ---------------------------------------------------------------------------------------------
# kernels of the RKMK4 hot path


@settings(max_examples=60, deadline=None)
@given(vec3, st.sampled_from([1.0, 1e-3, 1e-9, 0.0, np.pi / np.sqrt(3) * 0.999]))
def test_exp_kernel_matches_scipy_and_so3(w, scale):
    w = w * scale
    E = rkmod._exp(w[None])[0]
    assert np.allclose(E, Rotation.from_rotvec(w).as_matrix(), atol=1e-14, rtol=0)
    assert np.allclose(E, so3.exp(w), atol=1e-14, rtol=0)
    # the single-body (Python float) kernel
    assert np.allclose(rkmod._exp_f(*w.tolist()), E, atol=1e-15, rtol=0)


@settings(max_examples=60, deadline=None)
@given(vec3, vec3, st.floats(1e-3, 0.3))
def test_truncated_dexpinv_is_third_order_accurate(th, w, scale):
    theta = th / max(np.linalg.norm(th), 1e-12) * scale
    exact = so3.right_jacobian_inv(theta) @ w
    approx = rkmod._dexpinv(theta[None], w[None])[0]
    assert np.allclose(dexpinv_rkmk4(*theta.tolist(), *w.tolist()), approx, atol=1e-15)
    # the next Bernoulli term is θ⁴/720: the truncation error is O(|θ|⁴ |ω|)
    assert np.linalg.norm(approx - exact) <= 2e-3 * scale**4 * np.linalg.norm(w) + 1e-15


# ---------------------------------------------------------------------------------------------
# RK4 on ℝⁿ


def test_rk4_fourth_order_on_linear_system():
    A = np.array([[0.0, 1.0, 0.0], [-2.0, -0.1, 0.5], [0.0, -0.5, -0.3]])
    y0 = np.array([[1.0, 0.0, -1.0], [0.5, 2.0, 0.0]])  # batch of 2
    T = 2.0
    exact = y0 @ expm(A * T).T
    errs = []
    for n in (20, 40, 80):
        y, h = y0, T / n
        for k in range(n):
            y = rk4_step(lambda t, y: y @ A.T, k * h, y, h)
        errs.append(np.abs(y - exact).max())
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 14) & (ratios < 18)), ratios


def test_rk4_time_dependent_matches_quadrature():
    # y' = cos(t): exercises the stage times
    y = np.zeros((1, 1))
    h = 0.1
    for k in range(10):
        y = rk4_step_unchecked(lambda t, y: np.full_like(y, np.cos(t)), k * h, y, h)
    assert abs(y[0, 0] - np.sin(1.0)) < 1e-7


# ---------------------------------------------------------------------------------------------
# RKMK4 on SO(3) × ℝⁿ


def axisymmetric_exact(I1, I3, R0, w0, t):
    """Torque-free axisymmetric body: ω(t) = exp(Ω t e₃^) ω₀, R(t) = exp(t a^) R₀ exp(−Ω t e₃^),
    Ω = (I₃ − I₁) ω₃ / I₁, a = R₀ (ω₀ + Ω e₃) = L / I₁."""
    Om = (I3 - I1) * w0[2] / I1
    e3 = np.array([0.0, 0.0, 1.0])
    a = R0 @ (w0 + Om * e3)
    R = so3.exp(t * a) @ R0 @ so3.exp(-Om * t * e3)
    return R, so3.exp(Om * t * e3) @ w0


def test_axisymmetric_reference_solves_euler_equations():
    # the closed form used below, checked against the ODE by central finite differences
    I1, I3 = 2.0, 3.5
    R0 = so3.exp(np.array([0.3, -0.2, 0.5]))
    w0 = np.array([0.4, -0.7, 1.1])
    J = np.diag([I1, I1, I3])
    f = euler_field(J)
    t, d = 1.3, 1e-5
    Rp, wp = axisymmetric_exact(I1, I3, R0, w0, t + d)
    Rm, wm = axisymmetric_exact(I1, I3, R0, w0, t - d)
    R, w = axisymmetric_exact(I1, I3, R0, w0, t)
    om, wdot = f(t, R[None], w[None])
    assert np.allclose((Rp - Rm) / (2 * d), R @ so3.hat(om[0]), atol=1e-8)
    assert np.allclose((wp - wm) / (2 * d), wdot[0], atol=1e-8)


def test_rkmk4_fourth_order_convergence():
    I1, I3 = 2.0, 3.5
    R0 = so3.exp(np.array([0.3, -0.2, 0.5]))
    w0 = np.array([0.4, -0.7, 1.1])
    T = 4.0
    R_ex, w_ex = axisymmetric_exact(I1, I3, R0, w0, T)
    f = euler_field(np.diag([I1, I1, I3]))
    errR, errw = [], []
    for n in (40, 80, 160):
        tr = integrate(f, 0.0, R0[None], w0[None], T / n, n)
        errR.append(np.abs(tr.R[-1, 0] - R_ex).max())
        errw.append(np.abs(tr.x[-1, 0] - w_ex).max())
    for e in (errR, errw):
        ratios = np.array(e[:-1]) / np.array(e[1:])
        assert np.all((ratios > 14) & (ratios < 18)), ratios


def test_rkmk4_exact_for_constant_angular_velocity():
    # θ ∥ ω in every stage, so the truncated dexp⁻¹ is exact and R_k = R₀ exp(k h ω)
    w = np.array([[0.7, -1.3, 2.1]])
    R0 = so3.exp(np.array([[1.0, 0.2, -0.4]]))

    def f(t, R, x):
        return w, np.zeros_like(x)

    R, x = R0, np.zeros((1, 0))
    h = 0.37
    for _ in range(50):
        R, x = rkmk4_step_unchecked(f, 0.0, R, x, h)
    assert np.allclose(R, R0 @ so3.exp(50 * h * w), atol=1e-12)
    assert x.shape == (1, 0)


def test_rkmk4_stays_on_so3_with_large_steps():
    f = euler_field(J_ASYM)
    tr = integrate(f, 0.0, np.eye(3)[None], np.array([[2.0, -3.0, 1.5]]), 0.2, 2000)
    assert orth_err(tr.R).max() < 1e-12
    assert np.all(np.linalg.det(tr.R) > 0)


def test_rkmk4_batched_equals_per_element():
    rng = np.random.default_rng(7)
    B = 5
    R = Rotation.random(B, random_state=rng).as_matrix()
    x = rng.normal(size=(B, 5))
    Jb = np.diag([1.0, 1.5, 2.2])
    Jinv = np.linalg.inv(Jb)

    def f(t, R, x):  # rigid body + two extra states driven by attitude and time
        w = x[..., :3]
        wdot = (-np.cross(w, w @ Jb) + 0.1 * np.sin(t) * R[..., 2, :]) @ Jinv
        extra = np.stack((x[..., 3] * np.cos(t), R[..., 0, 1] - x[..., 4]), axis=-1)
        return w, np.concatenate((wdot, extra), axis=-1)

    Rb, xb = rkmk4_step(f, 0.3, R, x, 0.05)
    for i in range(B):
        Ri, xi = rkmk4_step(f, 0.3, R[i : i + 1], x[i : i + 1], 0.05)
        assert np.allclose(Ri[0], Rb[i], atol=1e-15, rtol=0)
        assert np.allclose(xi[0], xb[i], atol=1e-15, rtol=0)


def test_rkmk4_does_not_mutate_inputs_or_f_outputs():
    const = np.array([[0.1, 0.2, 0.3]])
    xd = np.array([[1.0, -1.0]])

    def f(t, R, x):
        return const, xd  # returns the same arrays every call

    R, x = np.eye(3)[None], np.array([[0.0, 0.0]])
    R_c, x_c = R.copy(), x.copy()
    rkmk4_step(f, 0.0, R, x, 0.1)
    assert np.array_equal(R, R_c) and np.array_equal(x, x_c)
    assert np.array_equal(const, [[0.1, 0.2, 0.3]]) and np.array_equal(xd, [[1.0, -1.0]])


# ---------------------------------------------------------------------------------------------
# LGVI


def test_lgvi_torque_free_1e5_steps_conserves_structure():
    lg = RigidBodyLGVI(J_ASYM)
    tr = lg.integrate(np.eye(3)[None], W_TUMBLE, h=0.01, n_steps=100_000)
    R, Pi = tr.R[:, 0], tr.Pi[:, 0]
    assert tr.R.shape == (100_001, 1, 3, 3)
    # it really tumbles: ω₂ changes sign
    assert tr.omega[:, 0, 1].min() < -0.9 and tr.omega[:, 0, 1].max() > 0.9
    assert orth_err(R).max() < 1e-12
    L = np.einsum("kij,kj->ki", R, Pi)
    assert np.abs(L - L[0]).max() / np.linalg.norm(L[0]) < 1e-12
    E = lg.energy(Pi)
    dE = np.abs(E - E[0]) / E[0]
    half = len(dE) // 2
    # bounded with no drift; for the free body the error even stays at round-off
    assert dE.max() < 1e-12
    assert dE[half:].max() <= 1.5 * dE[:half].max() + 1e-13


def pendulum_torque(mg=9.81, rho=(0.0, 0.0, 0.3)):
    """3D pendulum (Lee, Leok & McClamroch 2005): M = −m g ρ × Rᵀe₃, U = m g e₃ᵀ R ρ."""
    rho = np.asarray(rho)

    def torque(t, R):
        return -mg * np.cross(rho, R[..., 2, :])

    def potential(R):
        return mg * (R[..., 2, :] @ rho)

    return torque, potential


def test_lgvi_3d_pendulum_energy_bounded_no_drift():
    J = np.diag([0.13, 0.28, 0.17])
    torque, potential = pendulum_torque()
    lg = RigidBodyLGVI(J)
    R0 = so3.exp(np.array([[0.5, 0.8, 0.2]]))
    tr = lg.integrate(R0, np.array([[4.14, 4.14, 4.14]]), h=0.01, n_steps=40_000, torque=torque)
    E = lg.energy(tr.Pi[:, 0]) + potential(tr.R[:, 0])
    dE = np.abs(E - E[0])
    half = len(dE) // 2
    assert 1e-4 < dE[:half].max() < 0.05  # the O(h²) oscillation is visible ...
    assert dE[half:].max() <= 1.5 * dE[:half].max()  # ... and does not drift
    assert orth_err(tr.R).max() < 1e-12
    # gravity is vertical: the vertical component of R Π is conserved
    L3 = np.einsum("kj,kj->k", tr.R[:, 0, 2, :], tr.Pi[:, 0])
    assert np.abs(L3 - L3[0]).max() < 1e-11 * np.abs(tr.Pi[0]).max()


def test_explicit_rk4_on_matrix_entries_drifts_where_lgvi_does_not():
    h, n = 0.1, 10_000
    tr = integrate(euler_field(J_ASYM), 0.0, np.eye(3)[None], W_TUMBLE, h, n, method="rk4")
    lg = RigidBodyLGVI(J_ASYM)
    tl = lg.integrate(np.eye(3)[None], W_TUMBLE, h, n)

    def quarters(a):
        return np.array([a[i * n // 4 : (i + 1) * n // 4 + 1].max() for i in range(4)])

    o_rk = quarters(orth_err(tr.R[:, 0]))
    w = tr.x[:, 0]
    E_rk = 0.5 * np.einsum("ki,ij,kj->k", w, J_ASYM, w)
    e_rk = quarters(np.abs(E_rk - E_rk[0]) / E_rk[0])
    # RK4: errors grow steadily (secular drift) ...
    assert np.all(np.diff(o_rk) > 0) and o_rk[-1] > 3 * o_rk[0] and o_rk[-1] > 1e-5
    assert np.all(np.diff(e_rk) > 0) and e_rk[-1] > 3 * e_rk[0] and e_rk[-1] > 1e-7
    # ... LGVI on the same case and step: round-off
    assert orth_err(tl.R).max() < 1e-12
    E_lg = lg.energy(tl.Pi[:, 0])
    assert np.abs(E_lg - E_lg[0]).max() / E_lg[0] < 1e-12


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(1e-3, 0.2))
def test_lgvi_solves_its_defining_equation(seed, h):
    rng = np.random.default_rng(seed)
    J = random_inertia(rng)
    R = Rotation.random(random_state=rng).as_matrix()
    Pi = rng.normal(size=3)
    M0, M1 = rng.normal(size=3), rng.normal(size=3)
    R1, Pi1 = lgvi_step(R, Pi, M0, M1, h, J)
    F = R.T @ R1
    Jd = 0.5 * np.trace(J) * np.eye(3) - J
    lhs = h * so3.hat(Pi + 0.5 * h * M0)
    assert np.allclose(lhs, F @ Jd - Jd @ F.T, atol=1e-14, rtol=0)
    assert np.allclose(Pi1, F.T @ Pi + 0.5 * h * F.T @ M0 + 0.5 * h * M1, atol=1e-13, rtol=0)
    assert orth_err(R1) < 1e-14 and np.linalg.det(F) > 0


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_lgvi_free_step_conserves_spatial_momentum_and_casimir(seed):
    rng = np.random.default_rng(seed)
    J = random_inertia(rng)
    R = Rotation.random(random_state=rng).as_matrix()
    Pi = rng.normal(size=3)
    zero = np.zeros(3)
    R1, Pi1 = lgvi_step(R, Pi, zero, zero, 0.05, J)
    assert np.allclose(R1 @ Pi1, R @ Pi, atol=1e-14)
    assert abs(np.linalg.norm(Pi1) - np.linalg.norm(Pi)) < 1e-14
    # like the Moser–Veselov map it is equivalent to, it also keeps ½ Πᵀ J⁻¹ Π exactly
    E = 0.5 * Pi @ np.linalg.solve(J, Pi)
    assert abs(0.5 * Pi1 @ np.linalg.solve(J, Pi1) - E) < 1e-13 * max(E, 1.0)


def test_lgvi_forced_body_agrees_with_rkmk4_second_order():
    J = np.array([[2.0, 0.1, -0.05], [0.1, 1.5, 0.02], [-0.05, 0.02, 1.2]])
    n2 = 0.4**2
    e_r = np.array([1.0, 0.0, 0.0])

    def torque(t, R):  # gravity gradient toward a fixed direction + a scheduled torque
        r = R.T @ e_r if R.ndim == 2 else np.einsum("...ji,j->...i", R, e_r)
        gg = 3 * n2 * np.cross(r, r @ J.T)
        return gg + 0.05 * np.sin(2 * t) * np.array([1.0, -0.5, 0.2])

    R0 = so3.exp(np.array([[0.4, -0.3, 0.9]]))
    w0 = np.array([[0.3, -0.5, 0.8]])
    T = 5.0
    ref = integrate(euler_field(J, torque), 0.0, R0, w0, T / 2000, 2000)
    lg = RigidBodyLGVI(J)
    errs = []
    for n in (250, 500, 1000):
        tl = lg.integrate(R0, w0, T / n, n, torque=torque)
        errs.append(max(np.abs(tl.R[-1] - ref.R[-1]).max(), np.abs(tl.omega[-1] - ref.x[-1]).max()))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 3.6) & (ratios < 4.4)), ratios  # LGVI is 2nd order
    assert errs[-1] < 1e-4


def test_lgvi_batched_equals_per_element():
    rng = np.random.default_rng(3)
    B = 6
    J = random_inertia(rng)
    R = Rotation.random(B, random_state=rng).as_matrix()
    Pi = rng.normal(size=(B, 3))
    M0, M1 = rng.normal(size=(B, 3)), rng.normal(size=3)  # M_k1 broadcast from (3,)
    R1, Pi1 = lgvi_step(R, Pi, M0, M1, 0.05, J)
    for i in range(B):
        Ri, Pii = lgvi_step(R[i], Pi[i], M0[i], M1, 0.05, J)  # scalar (Python-float) path
        assert np.allclose(Ri, R1[i], atol=1e-15, rtol=0)
        assert np.allclose(Pii, Pi1[i], atol=1e-15, rtol=0)
    # the class's step is the same step
    R1c, Pi1c = RigidBodyLGVI(J).step(R, Pi, M0, M1, 0.05)
    assert np.array_equal(R1c, R1) and np.array_equal(Pi1c, Pi1)
    # per-spacecraft inertia, batched integrate vs single
    Jb = np.stack([random_inertia(rng) for _ in range(3)])
    w0 = rng.normal(size=(3, 3))
    tb = RigidBodyLGVI(Jb).integrate(R[:3], w0, 0.02, 50, save_every=10)
    assert tb.R.shape == (6, 3, 3, 3) and np.allclose(tb.t, np.arange(6) * 0.2)
    for i in range(3):
        ti = RigidBodyLGVI(Jb[i]).integrate(R[i], w0[i], 0.02, 50, save_every=10)
        assert np.allclose(ti.R, tb.R[:, i], atol=1e-14)
        assert np.allclose(ti.omega, tb.omega[:, i], atol=1e-14)


def test_lgvi_step_does_not_mutate_inputs():
    R = so3.exp(np.array([0.1, 0.2, 0.3]))
    Pi, M = np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.0, -0.1])
    J = J_ASYM.copy()
    copies = [a.copy() for a in (R, Pi, M, J)]
    lgvi_step(R, Pi, M, M, 0.1, J)
    for a, c in zip((R, Pi, M, J), copies, strict=True):
        assert np.array_equal(a, c)


def test_lgvi_nonconvergence_raises():
    with pytest.raises(LGVIConvergenceError, match="did not converge"):
        lgvi_step(
            np.eye(3), np.array([1.0, 2.0, 3.0]), np.zeros(3), np.zeros(3), 0.1, J_ASYM, max_iter=1
        )
    with pytest.raises(LGVIConvergenceError):  # batched path
        lgvi_step(
            np.stack([np.eye(3)] * 2),
            np.array([[1.0, 2.0, 3.0]] * 2),
            np.zeros(3),
            np.zeros(3),
            0.1,
            J_ASYM,
            max_iter=1,
        )


# ---------------------------------------------------------------------------------------------
# bad input


def _f_ok(t, R, x):
    return np.zeros(R.shape[:-2] + (3,)), np.zeros_like(x)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(h=0.0), "h"),
        (dict(h=-0.1), "h"),
        (dict(h=np.nan), "h"),
        (dict(R=np.ones((1, 3, 3))), "R"),
        (dict(R=np.eye(4)[None]), "R"),
        (dict(x=np.zeros((2, 3))), "x"),
        (dict(f=3.0), "f"),
        (dict(f=lambda t, R, x: (np.zeros(3), x)), "f"),
        (dict(f=lambda t, R, x: (np.full((1, 3), np.nan), x)), "f"),
        (dict(t=np.array([0.0, 1.0])), "t"),
    ],
)
def test_rkmk4_step_bad_input(kwargs, name):
    args = dict(f=_f_ok, t=0.0, R=np.eye(3)[None], x=np.zeros((1, 3)), h=0.1)
    args.update(kwargs)
    with pytest.raises(ValueError, match=f"^{name}:"):
        rkmk4_step(args["f"], args["t"], args["R"], args["x"], args["h"])


def test_rk4_and_integrate_bad_input():
    with pytest.raises(ValueError, match="^h:"):
        rk4_step(lambda t, y: y, 0.0, np.ones(2), -1.0)
    with pytest.raises(ValueError, match="^f:"):
        rk4_step(lambda t, y: y[:1], 0.0, np.ones(2), 0.1)
    with pytest.raises(ValueError, match="^y:"):
        rk4_step(lambda t, y: y, 0.0, 1.0, 0.1)
    R0, x0 = np.eye(3)[None], np.zeros((1, 3))
    with pytest.raises(ValueError, match="^method:"):
        integrate(_f_ok, 0.0, R0, x0, 0.1, 3, method="euler")
    with pytest.raises(ValueError, match="^n_steps:"):
        integrate(_f_ok, 0.0, R0, x0, 0.1, -1)
    with pytest.raises(ValueError, match="^x0:"):
        integrate(_f_ok, 0.0, R0, np.zeros(3), 0.1, 3)

    def blows_up(t, R, x):
        return np.zeros((1, 3)), np.full_like(x, 1e308) * (1 + t)

    with pytest.raises(FloatingPointError, match="non-finite"), np.errstate(over="ignore"):
        integrate(blows_up, 0.0, R0, np.full((1, 3), 1e308), 1.0, 3)


@pytest.mark.parametrize(
    "J, msg",
    [
        (np.array([[1.0, 0.5, 0], [0, 2.0, 0], [0, 0, 3.0]]), "not symmetric"),
        (np.diag([1.0, -2.0, 3.0]), "not positive definite"),
        (np.diag([1.0, 1.0, 3.0]), "triangle"),
        (np.eye(2), "expected shape"),
    ],
)
def test_lgvi_bad_inertia(J, msg):
    with pytest.raises(ValueError, match=f"^J: .*{msg}"):
        RigidBodyLGVI(J)
    with pytest.raises(ValueError, match=f"^J: .*{msg}"):
        lgvi_step(np.eye(3), np.ones(3), np.zeros(3), np.zeros(3), 0.1, J)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(h=0.0), "h"),
        (dict(h=-1.0), "h"),
        (dict(R=2 * np.eye(3)), "R"),
        (dict(Pi=np.ones(4)), "Pi"),
        (dict(Pi=np.ones((2, 3))), "Pi"),
        (dict(M_k=np.ones(2)), "M_k"),
        (dict(M_k1=np.full(3, np.inf)), "M_k1"),
        (dict(tol=0.0), "tol"),
        (dict(max_iter=0), "max_iter"),
    ],
)
def test_lgvi_step_bad_input(kwargs, name):
    args = dict(R=np.eye(3), Pi=np.ones(3), M_k=np.zeros(3), M_k1=np.zeros(3), h=0.1, J=J_ASYM)
    args.update(kwargs)
    with pytest.raises(ValueError, match=f"^{name}:"):
        lgvi_step(**args)


def test_lgvi_integrate_bad_input():
    lg = RigidBodyLGVI(J_ASYM)
    with pytest.raises(ValueError, match="^h:"):
        lg.integrate(np.eye(3), np.ones(3), 0.0, 10)
    with pytest.raises(ValueError, match="^omega0:"):
        lg.integrate(np.eye(3), np.ones(2), 0.1, 10)
    with pytest.raises(ValueError, match="^R0:"):
        lg.integrate(np.zeros((3, 3)), np.ones(3), 0.1, 10)
    with pytest.raises(ValueError, match="^n_steps:"):
        lg.integrate(np.eye(3), np.ones(3), 0.1, 2.5)
    with pytest.raises(ValueError, match="^torque:"):
        lg.integrate(np.eye(3), np.ones(3), 0.1, 10, torque=lambda t, R: np.zeros(2))
    with pytest.raises(ValueError, match="^R0:"):
        RigidBodyLGVI(np.stack([J_ASYM] * 2)).integrate(np.eye(3), np.ones(3), 0.1, 10)


def test_single_body_exp_returns_nan_instead_of_raising_on_overflow():
    """A diverging single-body run must produce NaN (the simulator catches it), not a
    ``math domain error`` from ``math.sin(inf)``."""
    for w in ((np.inf, 0.0, 0.0), (1e200, 1e200, 0.0), (np.nan, 1.0, 0.0)):
        E = rkmod._exp_f(*w)
        assert E.shape == (3, 3) and np.all(np.isnan(E))
    np.testing.assert_allclose(rkmod._exp_f(0.1, -0.2, 0.3), so3.exp([0.1, -0.2, 0.3]), atol=1e-15)

    def blow_up(t, R, x):
        return x * 1e200, x * 1e200

    with np.errstate(over="ignore", invalid="ignore"):
        R1, x1 = rkmk4_step_unchecked(blow_up, 0.0, np.eye(3)[None], np.ones((1, 3)), 1.0)
    assert not np.all(np.isfinite(R1)) and not np.all(np.isfinite(x1))


def test_lgvi_step_unchecked_equals_the_validated_step():
    """The unchecked entry point (hot loops, e.g. the MPC prediction) is the same step, bit for
    bit, on the single-body (Python-float) and the batched path, and mutates nothing."""
    from liecontrol.integrators.lgvi import lgvi_step_unchecked

    rng = np.random.default_rng(11)
    J = random_inertia(rng)
    Jinv = np.linalg.inv(J)
    R = Rotation.random(4, random_state=rng).as_matrix()
    Pi = rng.normal(size=(4, 3))
    M0, M1 = rng.normal(size=(4, 3)), rng.normal(size=3)
    copies = [a.copy() for a in (R, Pi, M0, M1, J)]
    R1, Pi1 = lgvi_step_unchecked(R, Pi, M0, M1, 0.05, J, Jinv)
    R1v, Pi1v = lgvi_step(R, Pi, M0, M1, 0.05, J)
    assert np.array_equal(R1, R1v) and np.array_equal(Pi1, Pi1v)
    for shape in ((3, 3), (1, 3, 3)):
        Rs, Ps = R[0].reshape(shape), Pi[0].reshape(shape[:-1])
        R1s, Pi1s = lgvi_step_unchecked(Rs, Ps, M0[0], M1, 0.05, J, Jinv)
        R1sv, Pi1sv = lgvi_step(Rs, Ps, M0[0], M1, 0.05, J)
        assert R1s.shape == shape and Pi1s.shape == shape[:-1]
        assert np.array_equal(R1s, R1sv) and np.array_equal(Pi1s, Pi1sv)
    for a, c in zip((R, Pi, M0, M1, J), copies, strict=True):
        assert np.array_equal(a, c)
    with pytest.raises(LGVIConvergenceError):
        lgvi_step_unchecked(
            np.eye(3), np.array([1.0, 2.0, 3.0]), np.zeros(3), np.zeros(3), 0.1, J_ASYM,
            np.linalg.inv(J_ASYM), max_iter=1,
        )  # fmt: skip
