"""Prescribed-performance control on SO(3) (SPEC §6 item 3): funnel, error transformation,
backstepping law (checked through its Lyapunov derivative and finite differences), bad input,
and the funnel guarantee on the seed-000 SGCMG spacecraft (nominal, disturbed, 150°, tracking)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SEED000_J, seed000_spacecraft
from conftest import attitude_reference as ref
from hypothesis import given, settings
from hypothesis import strategies as st

from liecontrol import errors as E
from liecontrol.control import AttitudeReference, AttitudeState, ConstantAttitude
from liecontrol.control.geometric_pd import gains_from_bandwidth
from liecontrol.control.prescribed_performance import (
    Funnel,
    PrescribedPerformance,
    ppc_gains,
    transform,
    transform_derivative,
    transform_inverse,
    virtual_rate,
)
from liecontrol.integrators import rkmk4_step
from liecontrol.lie import so3
from spacecraft import (
    ConstantHarmonicTorque,
    simulate,
)

J0 = np.array([[10.0, 0.5, -0.2], [0.5, 12.0, 0.3], [-0.2, 0.3, 8.0]])
J = SEED000_J
I3 = np.eye(3)


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


# ---------------------------------------------------------------------------------------------
# transformation and funnel


@settings(max_examples=60, deadline=None)
@given(st.floats(-0.999999, 0.999999))
def test_transform_properties(z):
    eps = transform(z)
    assert float(transform(-z)) == -float(eps)  # odd
    assert float(eps) == pytest.approx(0.5 * np.log((1 + z) / (1 - z)), rel=1e-12, abs=1e-15)
    assert float(transform_inverse(eps)) == pytest.approx(z, rel=1e-12, abs=1e-15)
    d = float(transform_derivative(z))
    assert d >= 1.0
    if abs(z) < 0.99:
        h = 1e-6
        fd = (float(transform(z + h)) - float(transform(z - h))) / (2 * h)
        assert d == pytest.approx(fd, rel=1e-6)


def test_transform_is_increasing_and_unbounded_at_the_edge():
    z = np.linspace(-0.999999, 0.999999, 2001)
    assert np.all(np.diff(transform(z)) > 0) and float(transform(0.0)) == 0.0
    assert float(transform(1 - 1e-12)) > 13.0
    for bad in (1.0, -1.0, 1.5, [0.0, 1.0]):
        with pytest.raises(ValueError, match="^z: "):
            transform(bad)
        with pytest.raises(ValueError, match="^z: "):
            transform_derivative(bad)


def test_funnel_values_and_derivatives():
    f = Funnel(rho_inf=0.02, decay=0.1, rho0=0.8)
    rho, rd, rdd = f.rho(0.0, 0.8)
    assert float(rho) == pytest.approx(0.8) and float(rd) == pytest.approx(-0.1 * 0.78)
    rho, _, _ = f.rho(1e4, 0.8)
    assert float(rho) == pytest.approx(0.02, abs=1e-15)
    t, h = 7.0, 1e-4
    r = lambda tt: f.rho(tt, 0.8)  # noqa: E731
    assert float(r(t)[1]) == pytest.approx(float(r(t + h)[0] - r(t - h)[0]) / (2 * h), rel=1e-7)
    assert float(r(t)[2]) == pytest.approx(float(r(t + h)[1] - r(t - h)[1]) / (2 * h), rel=1e-7)
    # ρ is monotone between ρ₀ and ρ_∞
    rr = f.rho(np.linspace(0, 100, 101), 0.8)[0]
    assert np.all(np.diff(rr) < 0) and rr.min() > 0.02


def test_funnel_initial_width_rule_and_feasibility():
    f = Funnel(rho_inf=0.01, decay=0.01)
    e0 = np.array([[0.4, -0.2, 0.1], [0.9, 0.0, 0.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(f.initial_width(e0), [0.5, 1.0, 0.02])
    # 180° about a body axis: |e_x| = 1, no funnel ≤ 1 contains it
    _, e_pi = E.large_angle_error(so3.exp([np.pi, 0.0, 0.0]), I3)
    with pytest.raises(ValueError, match="^rho0: funnel infeasible"):
        f.initial_width(e_pi[None])
    fixed = Funnel(rho_inf=0.01, decay=0.01, rho0=0.3)
    with pytest.raises(ValueError, match="^rho0: funnel infeasible"):
        fixed.initial_width(e0[:1])
    np.testing.assert_allclose(fixed.initial_width(e0[2:]), [0.3])


# ---------------------------------------------------------------------------------------------
# the law


def _trajectory(t, R_d, phi0, phi1, phi2):
    """R(t) = R_d exp(φ(t)^), φ = φ0 + φ1 t + φ2 t²: body rate Ω = J_r(φ) φ̇ (closed form)."""
    phi = phi0 + phi1 * t + phi2 * t * t
    R = R_d @ so3.exp(phi)
    w = so3.right_jacobian(phi) @ (phi1 + 2 * phi2 * t)
    return R, w


@pytest.mark.parametrize(
    "phi0, expect_floor",
    [(np.deg2rad(100.0) * _unit([1, 2, 3]), False), (np.deg2rad(172.0) * _unit([1, -1, 2]), True)],
)
def test_virtual_rate_derivative_matches_finite_differences(phi0, expect_floor):
    """α̇ of :func:`virtual_rate` (analytic, along ė_R = E e_Ω) against a central difference of α
    along a closed-form attitude trajectory, including the q₀ < q_min branch near 180°."""
    rng = np.random.default_rng(5)
    R_d = so3.random(rng)
    phi1, phi2 = np.array([0.05, -0.03, 0.02]), np.array([0.004, 0.002, -0.003])
    f = Funnel(rho_inf=0.05, decay=0.2)
    e0 = E.large_angle_error(R_d @ so3.exp(phi0), R_d)[1]
    rho0 = f.initial_width(e0[None])

    def alpha_at(t):
        R, w = _trajectory(t, R_d, phi0, phi1, phi2)
        Psi, e_R = E.large_angle_error(R, R_d)
        rho, rd, rdd = f.rho(t, rho0)
        return virtual_rate(e_R[None], np.atleast_1d(1 - Psi / 2), w[None], rho, rd, rdd, 0.7)

    for t in (0.3, 1.1):
        vr = alpha_at(t)
        R, _ = _trajectory(t, R_d, phi0, phi1, phi2)
        q0 = 1 - E.large_angle_error(R, R_d)[0] / 2
        assert (q0 < 0.1) == expect_floor
        h = 1e-5
        fd = (alpha_at(t + h).alpha - alpha_at(t - h).alpha) / (2 * h)
        np.testing.assert_allclose(vr.alpha_dot, fd, rtol=1e-6, atol=1e-9)
        assert 0.3 < np.abs(vr.z).max() < 1


def _closed_loop_rkmk4(ctrl, R0, w0, t_final, h):
    """Ideal rigid body J0 ω̇ = −ω × J0ω + M(t, R, ω) integrated with RKMK4, the controller
    evaluated at every stage (the continuous-time law the analysis is about)."""
    Ji = np.linalg.inv(J0)

    def f(t, R, w):
        M = ctrl.command(t, AttitudeState(R=R, omega=w), ref(I3))
        return w, (M - np.cross(w, w @ J0.T)) @ Ji.T

    R, w, t = R0[None].copy(), w0[None].copy(), 0.0
    ctrl.command(0.0, AttitudeState(R=R, omega=w), ref(I3))
    out = [(0.0, ctrl.diagnostics())]
    for k in range(int(round(t_final / h))):
        R, w = rkmk4_step(f, t, R, w, h)
        t = (k + 1) * h
        ctrl.command(t, AttitudeState(R=R, omega=w), ref(I3))
        out.append((t, ctrl.diagnostics()))
    return out


def test_lyapunov_derivative_along_the_closed_loop():
    """V = ½ k_c ρ²‖ε‖² + ½‖s‖² along the continuous closed loop (ideal rigid body, J known):
    the finite-difference V̇ equals k_c ρρ̇‖ε‖² − k₁k_cρ⁴‖Eᵀw‖² − k₂‖s‖² ≤ 0 (the derivation in
    the module docstring, which needs the analytic α̇ to be right), and the funnel holds."""
    k1, k2, kc = ppc_gains(1.0, 0.9)
    ctrl = PrescribedPerformance(J0, rho_inf=0.05, decay=0.5, k1=k1, k2=k2, kc=kc)
    ctrl.reset(0.0, 1)
    R0 = so3.exp(np.deg2rad(120.0) * _unit([1.0, -2.0, 0.5]))
    log = _closed_loop_rkmk4(ctrl, R0, np.array([0.2, -0.1, 0.3]), 5.0, 1e-2)
    t = np.array([x[0] for x in log])
    V, Vdot = [], []
    for _, d in log:
        rho = d["rho"][0]
        e = d["e_R"][0]
        q0 = 1 - d["Psi"][0] / 2
        z = e / rho
        wv = d["eps"][0] / (rho * (1 - z * z))
        ETw = 0.5 * (q0 * wv - np.cross(e, wv))
        _, rd, _ = ctrl.funnel.rho(t[len(V)], ctrl.rho0)
        eps, s = d["eps"][0], d["s"][0]
        V.append(0.5 * kc * rho**2 * eps @ eps + 0.5 * s @ s)
        Vdot.append(kc * rho * rd[0] * eps @ eps - k1 * kc * rho**4 * ETw @ ETw - k2 * s @ s)
        assert np.abs(z).max() < 1
    V, Vdot = np.array(V), np.array(Vdot)
    fd = (V[2:] - V[:-2]) / (t[2:] - t[:-2])
    np.testing.assert_allclose(fd, Vdot[1:-1], rtol=1e-3, atol=1e-6 * np.abs(Vdot).max())
    assert np.all(Vdot <= 0) and V[-1] < 1e-3 * V[0]


def test_zero_torque_at_equilibrium_and_inverse_dynamics_on_reference():
    rng = np.random.default_rng(6)
    R = so3.random(rng, 3)
    c = PrescribedPerformance(J0, 0.05, 0.1)
    c.reset(0.0, 3)
    M = c.command(0.0, AttitudeState(R=R, omega=np.zeros((3, 3))), ref(R))
    np.testing.assert_allclose(M, 0.0, atol=1e-14)
    np.testing.assert_allclose(c.rho0, 0.1)  # automatic: 2ρ_∞ at zero initial error
    w, dw = rng.standard_normal((3, 3)), rng.standard_normal((3, 3))
    M = c.command(1.0, AttitudeState(R=R, omega=w), ref(R, w, dw))
    np.testing.assert_allclose(M, np.cross(w, w @ J0.T) + dw @ J0.T, atol=1e-12)


def test_torque_opposes_error_and_batch_equals_single():
    rng = np.random.default_rng(7)
    B = 5
    R = so3.exp(rng.normal(size=(B, 3)))
    w = rng.normal(size=(B, 3)) * 0.1
    c = PrescribedPerformance(J0, 0.02, 0.1)
    c.reset(0.0, B)
    Mb = c.command(0.0, AttitudeState(R=R, omega=w), ref(I3))
    for b in range(B):
        one = PrescribedPerformance(J0, 0.02, 0.1)
        one.reset(0.0, 1)
        M1 = one.command(0.0, AttitudeState(R=R[b : b + 1], omega=w[b : b + 1]), ref(I3))
        np.testing.assert_allclose(Mb[b], M1[0], rtol=1e-12, atol=1e-14)
    c.reset(0.0, 1)
    n = _unit([0.3, -1.0, 0.4])
    M = c.command(0.0, AttitudeState(R=so3.exp(0.2 * n)[None], omega=np.zeros((1, 3))), ref(I3))
    assert M[0] @ n < 0


def test_never_nan_at_the_funnel_edge_and_at_180_degrees():
    c = PrescribedPerformance(J0, 0.02, 0.1, rho0=0.5)
    c.reset(0.0, 2)
    small = so3.exp(np.array([[0.2, 0.0, 0.0], [0.0, 0.1, 0.0]]))
    c.command(0.0, AttitudeState(R=small, omega=np.zeros((2, 3))), ref(I3))
    assert c.diagnostics()["funnel_violations"].tolist() == [0, 0]
    # at t = 50 s, ρ ≈ 0.02: spacecraft 0 is put far outside the funnel
    outside = so3.exp(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]))
    M = c.command(50.0, AttitudeState(R=outside, omega=np.zeros((2, 3))), ref(I3))
    d = c.diagnostics()
    assert np.all(np.isfinite(M)) and M[0, 0] < 0 and np.all(np.isfinite(d["eps"]))
    assert d["funnel_violations"].tolist() == [1, 0]
    assert d["edge_saturated"].tolist() == [True, False]
    # exactly 180° about a generic axis (|e_i| < 1): feasible, q₀ = 0 is floored, finite torque
    c180 = PrescribedPerformance(J0, 0.02, 0.1)
    c180.reset(0.0, 1)
    R_pi = so3.exp(np.pi * _unit([1.0, 2.0, 3.0]))
    M = c180.command(0.0, AttitudeState(R=R_pi[None], omega=np.zeros((1, 3))), ref(I3))
    assert np.all(np.isfinite(M)) and np.linalg.norm(M) > 0


def test_bad_input():
    ok = dict(J=J0, rho_inf=0.02, decay=0.1)
    cases = [
        ("rho_inf", 0.0),
        ("rho_inf", 1.0),
        ("rho_inf", -0.1),
        ("decay", 0.0),
        ("decay", -1.0),
        ("rho0", 0.02),  # ρ_∞ ≥ ρ₀
        ("rho0", 0.01),
        ("rho0", 1.5),
        ("margin", 1.0),
        ("k1", 0.0),
        ("k2", -1.0),
        ("kc", np.nan),
        ("q_min", 1.0),
        ("z_max", 1.0),
        ("z_max", 0.0),
        ("J", np.diag([1.0, 1.0, 3.0])),
        ("J", np.eye(3) - 2 * np.eye(3)),
    ]
    for name, v in cases:
        with pytest.raises(ValueError, match=f"^{name}: "):
            PrescribedPerformance(**{**ok, name: v})
    with pytest.raises(ValueError, match="^outer: "):
        ppc_gains(0.03, 0.5, outer=2.0)
    with pytest.raises(ValueError, match="^omega_n: "):
        ppc_gains(0.0)
    c = PrescribedPerformance(**ok, rho0=0.2)
    c.reset(0.0, 1)
    st0 = AttitudeState(R=so3.exp([0.5, 0.0, 0.0])[None], omega=np.zeros((1, 3)))
    with pytest.raises(ValueError, match="^rho0: funnel infeasible"):
        c.command(0.0, st0, ref(I3))
    c.reset(10.0, 1)
    with pytest.raises(ValueError, match="^t: "):
        c.command(5.0, st0, ref(I3))
    with pytest.raises(ValueError, match="^R_d: "):
        c.command(10.0, st0, ref(I3 + 1e-3))
    c180 = PrescribedPerformance(**ok)  # 180° about body x: |e_x| = 1
    c180.reset(0.0, 1)
    st_pi = AttitudeState(R=so3.exp([np.pi, 0.0, 0.0])[None], omega=np.zeros((1, 3)))
    with pytest.raises(ValueError, match="^rho0: funnel infeasible"):
        c180.command(0.0, st_pi, ref(I3))


# ---------------------------------------------------------------------------------------------
# the funnel on the seed-000 SGCMG spacecraft


class _Spin:
    """R_d(t) = exp(t Ω_d^) with constant Ω_d (desired-body frame): a slewing reference."""

    def __init__(self, w_d):
        self.w_d = np.asarray(w_d, float)

    def __call__(self, t):
        return AttitudeReference(
            R_d=so3.exp(t * self.w_d), omega_d=self.w_d, omega_dot_d=0 * self.w_d
        )


R0 = np.array(
    [
        so3.exp(np.deg2rad(150.0) * _unit([1, 2, 3])),
        so3.exp(np.deg2rad(150.0) * _unit([1, 1, 1])),
        so3.exp(np.deg2rad(60.0) * _unit([0, 1, 0])),
        I3,
    ]
)


@pytest.mark.parametrize(
    "case, rho_inf",
    [("nominal", 0.01), ("disturbed", 0.003), ("tracking+disturbed", 0.003)],
)
def test_funnel_is_never_left_on_the_sgcmg_spacecraft(case, rho_inf):
    """Every component of e_R (recomputed from the logged R, R_d) is inside ρ(t) (recomputed from
    the funnel formula and the automatic ρ₀ rule) at every logged sample, from 150°, 60° and 0°
    initial errors. With the seed-000 disturbance, ρ_∞ = 0.003 is below the steady error the
    linear design (a PD with the same ω_n) would leave, max_i |K_R⁻¹ d|_i ≈ 0.007: the funnel
    forces the error down."""
    dist = None if case == "nominal" else ConstantHarmonicTorque()
    plant = seed000_spacecraft(dist)
    decay = 0.01
    ctrl = PrescribedPerformance(J, rho_inf=rho_inf, decay=decay)
    reference = ConstantAttitude(I3) if case != "tracking+disturbed" else _Spin([0.0, 0.002, 0.001])
    res = simulate(plant, ctrl, reference, plant.initial_state(R0), t_final=700.0, dt=0.4)
    _, e = E.large_angle_error(res.R, res.R_d)
    m0 = np.abs(e[0]).max(axis=-1)
    rho0 = np.minimum(1.0, np.maximum(1.25 * m0, 2 * rho_inf))
    rho = (rho0 - rho_inf) * np.exp(-decay * res.t)[:, None] + rho_inf
    np.testing.assert_allclose(res.controller["rho"], rho, rtol=1e-12)
    z = np.abs(e).max(axis=-1) / rho
    assert z.max() < 1.0, z.max(axis=0)
    assert not res.controller["funnel_violations"].any()
    assert not res.controller["edge_saturated"].any()
    # the plant stayed healthy (the guarantee's "no saturation")
    assert not res.actuator["saturated"].any() and res.actuator["singularity"].min() > 0.3
    final = np.abs(e[-1]).max(axis=-1)
    if dist is None:
        assert np.all(final < 1e-5)
    else:
        k_R, _ = gains_from_bandwidth(J, 0.03, 0.9, error="large_angle", matrix=True)
        pd_steady = np.abs(np.linalg.solve(k_R, [0.02, 0.08, 0.02])).max()
        assert np.all(final < 0.5 * pd_steady)
