"""Tests for the SE(3) integrators (SPEC §3 items 2–3): the SE(3) LGVI and RKMK4 on SE(3) × ℝⁿ.

Independent routes: the MacCullagh full-body field written out here (not the plant's), scipy's
DOP853 on the embedded ODE (R entries, p, ω, v) as reference solution, the closed form
g(t) = g₀ exp(tξ) for a constant twist, the SO(3) RigidBodyLGVI for the free rotational part, and
the exact straight-line motion of a free body.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from liecontrol.integrators import RigidBodyLGVI
from liecontrol.integrators.lgvi_se3 import SE3RigidBodyLGVI, lgvi_se3_step
from liecontrol.integrators.rkmk_se3 import integrate_se3, rkmk4_se3_step
from liecontrol.lie import se3, so3

MU = 3.986004418e14
M = 500.0
J = np.diag([300.0, 400.0, 350.0])


def maccullagh(mu=MU, m=M, Jb=J):
    """Full-body point-mass field to second order: inertial force and body moment, and U."""
    trJ = np.trace(Jb)

    def fm(t, R, x):
        r = np.linalg.norm(x, axis=-1)[..., None]
        JI = R @ Jb @ np.swapaxes(R, -1, -2)
        JIx = np.einsum("...ij,...j->...i", JI, x)
        xJx = np.sum(x * JIx, -1)[..., None]
        f = -mu * m * x / r**3 - 1.5 * mu * trJ * x / r**5 - 3 * mu * JIx / r**5
        f = f + 7.5 * mu * xJx * x / r**7
        c = np.einsum("...ji,...j->...i", R, x) / r
        return f, 3 * mu / r**3 * np.cross(c, c @ Jb.T)

    def U(R, x):
        r = np.linalg.norm(x, axis=-1)
        c = np.einsum("...ji,...j->...i", R, x) / r[..., None]
        quad = np.einsum("...i,ij,...j->...", c, Jb, c)
        return -mu * m / r - mu * trJ / (2 * r**3) + 1.5 * mu * quad / r**3

    return fm, U


def eccentric_orbit(e=0.1, a=7.0e6):
    rp = a * (1 - e)
    vp = np.sqrt(MU * (1 + e) / rp)
    return np.array([[rp, 0.0, 0.0]]), np.array([[0.0, vp, 0.0]]), 2 * np.pi * np.sqrt(a**3 / MU)


# -- SE(3) LGVI --------------------------------------------------------------------------------


def test_lgvi_two_body_100_orbits_bounded_energy_and_conserved_momentum():
    """Coarse step (100 steps per orbit), e = 0.1, tumbling body, 100 orbits: the energy error
    oscillates without drift, total angular momentum is conserved to round-off, R stays on SO(3)."""
    fm, U = maccullagh()
    x0, v_in, T = eccentric_orbit()
    R0 = so3.exp(np.array([[0.3, 0.2, -0.1]]))
    v0 = np.einsum("...ji,...j->...i", R0, v_in)
    w0 = np.array([[0.004, 0.005, -0.003]])
    lg = SE3RigidBodyLGVI(M, J, fm)
    per = 100
    tr = lg.integrate(R0, x0, w0, v0, h=T / per, n_steps=100 * per, save_every=10)
    E = lg.kinetic_energy(tr.Pi, tr.gamma) + U(tr.R, tr.x)
    dE = np.abs(E - E[0]) / abs(E[0])
    first, last = dE[: 10 * per // 10], dE[-10 * per // 10 :]
    assert dE.max() < 1e-3
    # no secular drift: the last 10 orbits look like the first 10
    assert last.max() < 1.2 * first.max()
    assert abs(last.mean() - first.mean()) < 0.1 * first.mean()
    H = lg.angular_momentum(tr.R, tr.x, tr.Pi, tr.gamma)
    assert np.abs(H - H[0]).max() < 1e-12 * np.linalg.norm(H[0])
    RtR = np.swapaxes(tr.R, -1, -2) @ tr.R
    assert np.abs(RtR - np.eye(3)).max() < 1e-12
    # the orbit stayed an orbit: semi-major axis from the vis-viva energy within 1e-3
    r = np.linalg.norm(tr.x[-1], axis=-1)
    a_end = 1.0 / (2.0 / r - np.sum(tr.gamma[-1] ** 2, -1) / M**2 / MU)
    assert np.allclose(a_end, 7.0e6, rtol=1e-3)


def test_lgvi_free_body_straight_line_and_so3_rotation():
    """No field: x moves on a straight line exactly; the attitude equals the SO(3) LGVI's."""
    rng = np.random.default_rng(1)
    R0 = so3.random(rng, (3,))
    x0 = rng.normal(size=(3, 3))
    w0 = 0.3 * rng.normal(size=(3, 3))
    v0 = rng.normal(size=(3, 3))
    h, n = 0.05, 200
    tr = SE3RigidBodyLGVI(M, J).integrate(R0, x0, w0, v0, h, n)
    v_in = np.einsum("...ij,...j->...i", R0, v0)
    assert np.allclose(tr.x[-1], x0 + n * h * v_in, rtol=0, atol=1e-11)
    ref = RigidBodyLGVI(J).integrate(R0, w0, h, n)
    assert np.allclose(tr.R, ref.R, atol=1e-13)
    assert np.allclose(tr.omega, ref.omega, atol=1e-13)
    # body velocity is the inertial velocity in body axes
    assert np.allclose(np.einsum("...ij,...j->...i", tr.R, tr.v), v_in[None], atol=1e-11)


def _embedded_reference(f_xi_dot, g0, xi0, t_final):
    """DOP853 on (R entries, p, ω, v): Ṙ = R ω^, ṗ = R v, ξ̇ = f_xi_dot(g, ξ)."""

    def rhs(t, y):
        R = y[:9].reshape(3, 3)
        p = y[9:12]
        xi = y[12:18]
        # DOP853's stages leave SO(3) (this is an embedded reference), so g is assembled by
        # hand: se3.from_rt rejects a rotation block that is not a rotation
        g = np.zeros((1, 4, 4))
        g[0, :3, :3], g[0, :3, 3], g[0, 3, 3] = R, p, 1.0
        dxi = f_xi_dot(g, xi[None])[0]
        return np.concatenate(((R @ so3.hat(xi[:3])).ravel(), R @ xi[3:], dxi))

    y0 = np.concatenate((g0[0, :3, :3].ravel(), g0[0, :3, 3], xi0[0]))
    sol = solve_ivp(rhs, (0.0, t_final), y0, method="DOP853", rtol=1e-13, atol=1e-12)
    y = sol.y[:, -1]
    return se3.from_rt(y[:9].reshape(3, 3), y[9:12])[None], y[12:18][None]


def _small_body_field():
    """A tumbling body near a small central body (μ = 1e3): strong coupling, short times."""
    mu, m, Jb = 1.0e3, 2.0, np.diag([1.0, 2.0, 2.5])
    fm, U = maccullagh(mu, m, Jb)

    def xi_dot(g, xi):
        R, x = g[..., :3, :3], g[..., :3, 3]
        f, M_b = fm(0.0, R, x)
        w, v = xi[..., :3], xi[..., 3:]
        tau = -np.cross(w, w @ Jb.T) + M_b
        F = -m * np.cross(w, v) + np.einsum("...ji,...j->...i", R, f)
        return np.concatenate((tau @ np.linalg.inv(Jb).T, F / m), axis=-1)

    g0 = se3.from_rt(so3.exp(np.array([[0.2, -0.4, 0.9]])), np.array([[10.0, 1.0, -2.0]]))
    xi0 = np.array([[0.3, -0.5, 0.8, 0.2, 9.0, 1.0]])
    return mu, m, Jb, fm, xi_dot, g0, xi0


def test_lgvi_second_order_against_dop853():
    mu, m, Jb, fm, xi_dot, g0, xi0 = _small_body_field()
    T = 1.0
    g_ref, xi_ref = _embedded_reference(xi_dot, g0, xi0, T)
    lg = SE3RigidBodyLGVI(m, Jb, fm)
    errs = []
    for n in (100, 200, 400):
        tr = lg.integrate(g0[:, :3, :3], g0[:, :3, 3], xi0[:, :3], xi0[:, 3:], T / n, n)
        errs.append(np.abs(tr.g[-1] - g_ref).max())
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 3.5) & (ratios < 4.5)), ratios


def test_lgvi_step_function_matches_class_and_validates():
    fm, _ = maccullagh()
    x0, v_in, T = eccentric_orbit()
    R = np.eye(3)[None]
    Pi = np.array([[1.0, 2.0, -1.0]])
    gamma = M * v_in
    a = lgvi_se3_step(R, x0, Pi, gamma, 10.0, M, J, fm, 3.0)
    b = SE3RigidBodyLGVI(M, J, fm).step(3.0, R, x0, Pi, gamma, 10.0)
    for u, w in zip(a, b, strict=True):
        assert np.array_equal(u, w)
    with pytest.raises(ValueError, match="^h:"):
        lgvi_se3_step(R, x0, Pi, gamma, 0.0, M, J, fm)
    with pytest.raises(ValueError, match="^m:"):
        SE3RigidBodyLGVI(-1.0, J)
    with pytest.raises(ValueError, match="^J:"):
        SE3RigidBodyLGVI(M, np.diag([1.0, 1.0, 3.0]))
    with pytest.raises(ValueError, match="^R:"):
        lgvi_se3_step(2 * R, x0, Pi, gamma, 1.0, M, J)
    with pytest.raises(ValueError, match="^gamma:"):
        lgvi_se3_step(R, x0, Pi, gamma[0], 1.0, M, J)
    with pytest.raises(ValueError, match="^force_and_moment:"):
        lgvi_se3_step(R, x0, Pi, gamma, 1.0, M, J, lambda t, R, x: (x, x[0]))
    with pytest.raises(ValueError, match="^n_steps:"):
        SE3RigidBodyLGVI(M, J).integrate(R, x0, Pi, gamma, 1.0, -1)


# -- RKMK4 on SE(3) × ℝⁿ -----------------------------------------------------------------------


def test_rkmk4_se3_fourth_order_against_dop853():
    _, _, _, _, xi_dot, g0, xi0 = _small_body_field()
    T = 1.0
    g_ref, xi_ref = _embedded_reference(xi_dot, g0, xi0, T)

    def f(t, g, x):
        return x, xi_dot(g, x)

    errs = []
    for n in (25, 50, 100):
        tr = integrate_se3(f, 0.0, g0, xi0, T / n, n)
        errs.append(max(np.abs(tr.g[-1] - g_ref).max(), np.abs(tr.x[-1] - xi_ref).max()))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 13.0) & (ratios < 19.0)), ratios
    R = tr.g[..., :3, :3]
    assert np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max() < 1e-13


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.floats(-2.0, 2.0), min_size=6, max_size=6),
    st.floats(0.01, 1.0),
)
def test_rkmk4_se3_constant_twist_is_exact(xi, h):
    """ġ = g ξ^ with constant ξ: g(h) = g₀ exp(hξ) exactly, whatever the step."""
    xi = np.array([xi])
    g0 = se3.from_rt(so3.exp(np.array([[0.1, 0.2, 0.3]])), np.array([[1.0, -2.0, 3.0]]))
    x0 = np.array([[1.0, 2.0]])
    g1, x1 = rkmk4_se3_step(lambda t, g, x: (xi, -x), 0.0, g0, x0, h)
    assert np.allclose(g1, g0 @ se3.exp(h * xi), atol=1e-13)
    # the ℝⁿ part is classical RK4 on ẋ = −x
    assert np.allclose(x1, x0 * (1 - h + h**2 / 2 - h**3 / 6 + h**4 / 24), atol=1e-15)


def test_rkmk4_se3_batched_and_validation():
    _, _, _, _, xi_dot, g0, xi0 = _small_body_field()
    g = np.concatenate([g0, g0 @ se3.exp(np.array([[0.1, 0, 0, 1, 0, 0]]))])
    xi = np.concatenate([xi0, 0.5 * xi0])

    def f(t, gg, x):
        return x, xi_dot(gg, x)

    gb, xb = rkmk4_se3_step(f, 0.0, g, xi, 0.01)
    for b in range(2):
        g1, x1 = rkmk4_se3_step(f, 0.0, g[b : b + 1], xi[b : b + 1], 0.01)
        assert np.allclose(gb[b], g1[0], atol=1e-14) and np.allclose(xb[b], x1[0], atol=1e-14)
    with pytest.raises(ValueError, match="^h:"):
        rkmk4_se3_step(f, 0.0, g, xi, -0.1)
    with pytest.raises(ValueError, match="^g:"):
        rkmk4_se3_step(f, 0.0, 2 * g, xi, 0.1)
    with pytest.raises(ValueError, match="^x:"):
        rkmk4_se3_step(f, 0.0, g, xi[:1], 0.1)
    with pytest.raises(ValueError, match="^f:"):
        rkmk4_se3_step(lambda t, gg, x: (x[..., :3], x), 0.0, g, xi, 0.1)
    with pytest.raises(ValueError, match="^f:"):
        rkmk4_se3_step(None, 0.0, g, xi, 0.1)
    with pytest.raises(ValueError, match="^save_every:"):
        integrate_se3(f, 0.0, g, xi, 0.1, 3, save_every=0)
