"""Geometric PID controllers (SPEC §6 item 2; survey seed 002, Lemma 5): the intrinsic PID of
Maithripala & Berg and the integral-of-error variant, their ZOH integral states, anti-windup, and
constant-disturbance rejection on the seed-000 SGCMG spacecraft."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SEED000_J, OnePerSpacecraft, seed000_spacecraft
from conftest import attitude_reference as ref
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.integrate import solve_ivp

from liecontrol import errors as E
from liecontrol.control import (
    AttitudeState,
    ConstantAttitude,
)
from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
from liecontrol.control.geometric_pid import (
    IntegralPD,
    IntrinsicPID,
    connection_term,
    integral_gain,
)
from liecontrol.lie import so3
from spacecraft import (
    ConstantTorque,
    simulate,
)

J0 = np.array([[10.0, 0.5, -0.2], [0.5, 12.0, 0.3], [-0.2, 0.3, 8.0]])
J = SEED000_J
D_CONST = np.array([0.02, 0.08, 0.02])  # constant part of the seed-000 disturbance [N m]
OMEGA_N, ZETA, OMEGA_I = 0.03, 0.9, 0.006


def _gamma_by_hand(Jm, w, eta):
    """½(ω × η − J⁻¹(Jη × ω + Jω × η)), one spacecraft, with explicit matrices."""
    Ji = np.linalg.inv(Jm)
    return 0.5 * (np.cross(w, eta) - Ji @ (np.cross(Jm @ eta, w) + np.cross(Jm @ w, eta)))


# ---------------------------------------------------------------------------------------------
# the law at one sample


@pytest.mark.parametrize("cls", [IntrinsicPID, IntegralPD])
@pytest.mark.parametrize("kind", ["log", "large_angle", "trace"])
def test_zero_torque_at_equilibrium_with_zero_integral(cls, kind):
    rng = np.random.default_rng(0)
    R = so3.random(rng, 4)
    c = cls(J0, 3.0, 8.0, 0.5, error=kind)
    c.reset(0.0, 4)
    for t in (0.0, 0.5, 1.0):  # at equilibrium the integrand is zero: z stays zero
        M = c.command(t, AttitudeState(R=R, omega=np.zeros((4, 3))), ref(R))
        np.testing.assert_allclose(M, 0.0, atol=1e-14)
    np.testing.assert_allclose(c.diagnostics()["integral"], 0.0, atol=1e-15)


@pytest.mark.parametrize("cls", [IntrinsicPID, IntegralPD])
def test_pid_is_pd_minus_integral_torque(cls):
    rng = np.random.default_rng(1)
    B = 5
    R, R_d = so3.random(rng, B), so3.random(rng, B)
    w, w_d, dw_d = (rng.standard_normal((B, 3)) for _ in range(3))
    K_I = np.array([[2.0, 0.1, 0.0], [0.1, 1.5, 0.0], [0.0, 0.0, 1.0]])
    pid = cls(J0, 3.0, [5.0, 6.0, 7.0], K_I)
    pd = GeometricPD(J0, 3.0, [5.0, 6.0, 7.0], error=pid.error)
    pid.reset(0.0, B)
    pd.reset(0.0, B)
    st0 = AttitudeState(R=R, omega=w)
    r = ref(R_d, w_d, dw_d)
    np.testing.assert_allclose(pid.command(0.0, st0, r), pd.command(0.0, st0, r), atol=1e-13)
    M = pid.command(0.3, st0, r)
    z = pid.diagnostics()["integral"]
    assert np.abs(z).min() > 0
    np.testing.assert_allclose(M, pd.command(0.3, st0, r) - z @ K_I.T, atol=1e-12)


def test_intrinsic_integral_state_matches_hand_computation():
    """Three samples: ω_I(t₁) = Δ₁ e_R(t₀) (ω_I(t₀) = 0 kills the connection term), then
    ω_I(t₂) = ω_I(t₁) + Δ₂ (Γ(e_Ω(t₁), ω_I(t₁)) + e_R(t₁)), with Γ built from explicit matrices
    and e_R from :func:`liecontrol.errors.log_error`; tracking: e_Ω = ω − RᵀR_dω_d."""
    rng = np.random.default_rng(2)
    R_d = so3.random(rng)
    w_d = np.array([0.1, -0.2, 0.05])
    Rs = [R_d @ so3.exp(rng.normal(size=3) * 0.5) for _ in range(3)]
    ws = [rng.normal(size=3) * 0.3 for _ in range(3)]
    for connection, sign in (("survey", 1.0), ("levi_civita", -1.0)):
        c = IntrinsicPID(J0, 3.0, 8.0, 0.5, connection=connection)
        c.reset(0.0, 1)
        ts = [0.0, 0.2, 0.5]
        for t, R, w in zip(ts, Rs, ws, strict=True):
            c.command(t, AttitudeState(R=R[None], omega=w[None]), ref(R_d, w_d))
            if t == 0.2:
                z1 = c.diagnostics()["integral"][0]
        e0 = E.log_error(Rs[0], R_d)[1]
        np.testing.assert_allclose(z1, 0.2 * e0, rtol=1e-14)
        e1 = E.log_error(Rs[1], R_d)[1]
        eW1 = ws[1] - Rs[1].T @ R_d @ w_d
        expect = z1 + 0.3 * (sign * _gamma_by_hand(J0, eW1, z1) + e1)
        np.testing.assert_allclose(c.diagnostics()["integral"][0], expect, rtol=1e-13)


def test_integral_pd_state_matches_hand_computation():
    rng = np.random.default_rng(3)
    R_d = so3.random(rng)
    R = R_d @ so3.exp([0.3, -0.2, 0.4])
    w = np.array([0.05, 0.1, -0.02])
    c = IntegralPD(J0, 3.0, 8.0, 0.5, c=0.7)
    c.reset(0.0, 1)
    c.command(0.0, AttitudeState(R=R[None], omega=w[None]), ref(R_d))
    c.command(0.0, AttitudeState(R=R[None], omega=w[None]), ref(R_d))  # Δ = 0: no step
    c.command(0.4, AttitudeState(R=R_d[None], omega=np.zeros((1, 3))), ref(R_d))
    e_R = E.large_angle_error(R, R_d)[1]
    np.testing.assert_allclose(c.diagnostics()["integral"][0], 0.4 * (w + 0.7 * e_R), rtol=1e-14)
    with pytest.raises(ValueError, match="^t: "):
        c.command(0.3, AttitudeState(R=R_d[None], omega=np.zeros((1, 3))), ref(R_d))


def test_batched_equals_per_spacecraft():
    rng = np.random.default_rng(4)
    B = 4
    Rs = so3.random(rng, (3, B))
    ws = rng.normal(size=(3, B, 3)) * 0.2
    R_d = so3.random(rng)
    cb = IntrinsicPID(J0, 3.0, 8.0, 0.5, torque_limit=2.0, integral_limit=1.0)
    cb.reset(0.0, B)
    ones = [IntrinsicPID(J0, 3.0, 8.0, 0.5, torque_limit=2.0, integral_limit=1.0) for _ in range(B)]
    for c in ones:
        c.reset(0.0, 1)
    for k, t in enumerate((0.0, 0.7, 1.1)):
        Mb = cb.command(t, AttitudeState(R=Rs[k], omega=ws[k]), ref(R_d))
        for b, c in enumerate(ones):
            Mi = c.command(t, AttitudeState(R=Rs[k, b : b + 1], omega=ws[k, b : b + 1]), ref(R_d))
            np.testing.assert_allclose(Mb[b], Mi[0], atol=1e-13)
            np.testing.assert_allclose(
                cb.diagnostics()["integral"][b], c.diagnostics()["integral"][0]
            )


# ---------------------------------------------------------------------------------------------
# the connection term: the Levi-Civita connection of the metric J (independent properties)


vec3 = arrays(np.float64, (3,), elements=st.floats(-2.0, 2.0))


@settings(max_examples=50, deadline=None)
@given(vec3, vec3, vec3)
def test_connection_metric_compatible_and_torsion(w, eta, zeta):
    """For both signs ⟨Γ(ω,η), Jζ⟩ + ⟨Γ(ω,ζ), Jη⟩ = 0 (metric compatibility); the Levi-Civita
    variant has torsion-free ∇_ωη − ∇_ηω = ω × η, i.e. c(ω,η) − c(η,ω) = −ω × η for the term c
    with η̇ = c + ..., and the survey's sign is its negative."""
    W, H, Z = w[None], eta[None], zeta[None]
    scale = (
        1.0
        + np.abs(J0).max()
        * (1 + np.abs(w).max())
        * (1 + np.abs(eta).max() + np.abs(zeta).max()) ** 2
    )
    for conn in ("survey", "levi_civita"):
        g1 = connection_term(J0, W, H, conn)[0]
        g2 = connection_term(J0, W, Z, conn)[0]
        assert abs(g1 @ J0 @ zeta + g2 @ J0 @ eta) <= 1e-12 * scale
    lc = connection_term(J0, W, H, "levi_civita")[0] - connection_term(J0, H, W, "levi_civita")[0]
    np.testing.assert_allclose(lc, -np.cross(w, eta), atol=1e-12 * scale)
    np.testing.assert_allclose(
        connection_term(J0, W, H, "survey"), -connection_term(J0, W, H, "levi_civita"), atol=0
    )


def test_levi_civita_geodesics_are_free_rigid_body_motions():
    """Along a torque-free rigid body (solve_ivp of Euler's equations) ∇_ω ω = 0, i.e. the
    finite-difference ω̇ equals the Levi-Civita term c(ω, ω) (and minus the survey's)."""
    sol = solve_ivp(
        lambda t, w: np.linalg.solve(J0, np.cross(J0 @ w, w)),
        (0.0, 3.0),
        [0.4, -0.3, 0.8],
        rtol=1e-12,
        atol=1e-14,
        dense_output=True,
    )
    h = 1e-4
    for t in (0.5, 1.3, 2.7):
        w = sol.sol(t)
        w_dot = (sol.sol(t + h) - sol.sol(t - h)) / (2 * h)
        c = connection_term(J0, w[None], w[None], "levi_civita")[0]
        np.testing.assert_allclose(w_dot, c, atol=1e-7)
        np.testing.assert_allclose(connection_term(J0, w[None], w[None], "survey")[0], -c)


# ---------------------------------------------------------------------------------------------
# anti-windup at one sample


def test_clamp_bounds_integral_torque():
    K_I = np.diag([1.0, 2.0, 3.0])
    c = IntrinsicPID(J0, 3.0, 8.0, K_I, integral_limit=0.25)
    c.reset(0.0, 2)
    R = so3.exp(np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.01]]))
    st0 = AttitudeState(R=R, omega=np.zeros((2, 3)))
    for t in np.arange(0.0, 5.0, 0.5):
        c.command(t, st0, ref(np.eye(3)))
    d = c.diagnostics()
    n = np.linalg.norm(d["u_integral"], axis=-1)
    assert n[0] == pytest.approx(0.25, rel=1e-12) and d["integral_clamped"][0]
    # the clamp keeps the direction of K_I z
    free = IntrinsicPID(J0, 3.0, 8.0, K_I)
    free.reset(0.0, 2)
    for t in np.arange(0.0, 5.0, 0.5):
        free.command(t, st0, ref(np.eye(3)))
    uf = free.diagnostics()["u_integral"]
    np.testing.assert_allclose(d["u_integral"][1], uf[1], rtol=1e-13)  # small one: untouched
    assert n[1] < 0.25 and not d["integral_clamped"][1]
    cos = d["u_integral"][0] @ uf[0] / (n[0] * np.linalg.norm(uf[0]))
    assert cos > 0.99


def test_conditional_integration_freezes_only_when_pushing_into_saturation():
    I3 = ref(np.eye(3))
    rest = np.zeros((2, 3))
    c = IntegralPD(J0, 30.0, 8.0, 1.0, c=1.0, torque_limit=[0.5, 0.5, 0.5])
    c.reset(0.0, 2)
    # spacecraft 0: large error, saturated, the integrand grows the saturating torque -> frozen;
    # spacecraft 1: small error, not saturated -> integrates
    st0 = AttitudeState(R=so3.exp(np.array([[0.5, 0.0, 0.0], [0.001, 0.0, 0.0]])), omega=rest)
    M = c.command(0.0, st0, I3)
    assert np.abs(M).max() <= 0.5 and c.diagnostics()["saturated"].tolist() == [True, False]
    c.command(1.0, st0, I3)
    d = c.diagnostics()
    assert d["integration_frozen"].tolist() == [True, False]
    np.testing.assert_allclose(d["integral"][0], 0.0)
    assert d["integral"][1, 0] > 0
    # wind the integral up while unsaturated (small negative error), until −K_I z saturates the
    # command positively; then a small positive error: its integrand unwinds -> integration kept
    c.reset(0.0, 2)
    neg = AttitudeState(R=so3.exp(np.array([[-0.005, 0, 0], [-0.005, 0, 0]])), omega=rest)
    pos = AttitudeState(R=so3.exp(np.array([[0.005, 0, 0], [0.005, 0, 0]])), omega=rest)
    c.command(0.0, neg, I3)
    c.command(400.0, neg, I3)
    assert c.diagnostics()["saturated"].all() and not c.diagnostics()["integration_frozen"].any()
    c.command(401.0, pos, I3)  # step of the held negative error would push: frozen
    assert c.diagnostics()["integration_frozen"].all()
    z = c.diagnostics()["integral"].copy()
    c.command(402.0, pos, I3)  # held command saturated positive, integrand unwinds: kept
    d = c.diagnostics()
    assert d["saturated"].all() and not d["integration_frozen"].any()
    assert np.all(d["integral"][:, 0] > z[:, 0])


# ---------------------------------------------------------------------------------------------
# bad input


def test_bad_input():
    ok = dict(J=J0, k_R=3.0, k_Omega=8.0, k_I=0.5)
    bad = {
        "k_I": [
            -1.0,
            [1.0, 0.0, 2.0],
            np.array([[1.0, 2.0, 0], [0.0, 1.0, 0], [0, 0, 1.0]]),
            np.diag([1.0, -2.0, 3.0]) + 0.0 * np.eye(3),
            np.nan,
        ],
        "k_R": [0.0, np.diag([1.0, 1.0, -1.0])],
        "k_Omega": [-3.0],
        "J": [np.diag([1.0, 1.0, 3.0]), -np.eye(3)],
        "integral_limit": [0.0, -1.0, [1.0, 2.0]],
        "torque_limit": [0.0, [1.0, -1.0, 1.0], [1.0, 1.0]],
        "error": ["quaternion"],
    }
    for cls in (IntrinsicPID, IntegralPD):
        for name, values in bad.items():
            for v in values:
                with pytest.raises(ValueError, match=f"^{name}: "):
                    cls(**{**ok, name: v})
    with pytest.raises(ValueError, match="^connection: "):
        IntrinsicPID(**ok, connection="riemann")
    for v in (0.0, -0.1, np.inf):
        with pytest.raises(ValueError, match="^c: "):
            IntegralPD(**ok, c=v)
    with pytest.raises(ValueError, match="^omega_i: "):
        integral_gain(3.0, 0.0)
    c = IntrinsicPID(**ok)
    with pytest.raises(RuntimeError):
        c.command(0.0, AttitudeState(R=np.eye(3)[None], omega=np.zeros((1, 3))), ref(np.eye(3)))
    c.reset(0.0, 1)
    not_rot = np.eye(3) + 1e-3
    with pytest.raises(ValueError, match="^R_d: "):
        c.command(0.0, AttitudeState(R=np.eye(3)[None], omega=np.zeros((1, 3))), ref(not_rot))
    with pytest.raises(ValueError, match="^R: "):
        c.command(0.0, AttitudeState(R=not_rot[None], omega=np.zeros((1, 3))), ref(np.eye(3)))
    with pytest.raises(ValueError, match="^batch_size: "):
        c.reset(0.0, 0)


# ---------------------------------------------------------------------------------------------
# closed loop on the seed-000 SGCMG spacecraft


def test_pid_removes_the_steady_error_pd_leaves_under_constant_torque():
    """Constant torque d = (0.02, 0.08, 0.02) N·m from rest at R = R_d. Same PD gains
    (ω_n = 0.03 rad/s, ζ = 0.9, matrix gains ∝ J) for every design. PD settles at e_R = K_R⁻¹d
    (≈ 0.84° with the log error); the integral term drives the error to zero and its torque to
    −d (the independent route: the equilibrium of the closed loop)."""
    kR_log, kW_log = gains_from_bandwidth(J, OMEGA_N, ZETA, error="log", matrix=True)
    kR_la, kW_la = gains_from_bandwidth(J, OMEGA_N, ZETA, error="large_angle", matrix=True)
    kI = integral_gain(kR_log, OMEGA_I)
    designs = [
        GeometricPD(J, kR_log, kW_log, error="log"),
        IntrinsicPID(J, kR_log, kW_log, kI),
        IntrinsicPID(J, kR_log, kW_log, kI, connection="levi_civita"),
        GeometricPD(J, kR_la, kW_la),
        IntegralPD(J, kR_la, kW_la, integral_gain(kR_la, OMEGA_I, c=OMEGA_N), c=OMEGA_N),
    ]
    plant = seed000_spacecraft(ConstantTorque(D_CONST))
    res = simulate(
        plant,
        OnePerSpacecraft(designs),
        ConstantAttitude(np.eye(3)),
        plant.initial_state(np.eye(3), batch=len(designs)),
        t_final=1000.0,
        dt=0.4,
        log_every=25,
    )
    final = np.rad2deg(res.attitude_error_angle()[-1])
    e_R = res.controller["e_R"][-1]
    # PD: the steady state of J ė_Ω = −K_R e_R − K_Ω e_Ω + d
    np.testing.assert_allclose(e_R[0], np.linalg.solve(kR_log, D_CONST), rtol=2e-3, atol=1e-7)
    np.testing.assert_allclose(e_R[3], np.linalg.solve(kR_la, D_CONST), rtol=2e-3, atol=1e-7)
    assert final[0] > 0.8 and final[3] > 0.8
    # PID: the same gains, the steady error is gone
    for b in (1, 2):
        assert final[b] < 1e-4 * final[0], (b, final)
        np.testing.assert_allclose(res.controller["u_integral"][-1, b], -D_CONST, rtol=1e-3)
    assert final[4] < 0.01 * final[3], final
    np.testing.assert_allclose(res.controller["u_integral"][-1, 4], -D_CONST, rtol=0.05)
    assert res.actuator["singularity"].min() > 0.5 and not res.actuator["saturated"].any()


def test_anti_windup_limits_the_integral_under_saturation():
    """30° slew with the command clipped at 1 N·m per axis (the PD alone asks for ≈ 5 N·m) under
    the constant torque: without anti-windup the integral winds up during the saturated slew and
    the attitude overshoots; conditional integration and the clamp keep it small."""
    kR, kW = gains_from_bandwidth(J, OMEGA_N, ZETA, error="log", matrix=True)
    kI = integral_gain(kR, OMEGA_I)
    designs = [
        IntrinsicPID(J, kR, kW, kI, torque_limit=1.0, conditional=False),
        IntrinsicPID(J, kR, kW, kI, torque_limit=1.0),
        IntrinsicPID(J, kR, kW, kI, torque_limit=1.0, integral_limit=0.3),
    ]
    plant = seed000_spacecraft(ConstantTorque(D_CONST))
    R_d = so3.exp(np.deg2rad(30.0) * np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0))
    res = simulate(
        plant,
        OnePerSpacecraft(designs),
        ConstantAttitude(R_d),
        plant.initial_state(np.eye(3), batch=3),
        t_final=800.0,
        dt=0.4,
        log_every=5,
    )
    assert np.abs(res.u_cmd).max() <= 1.0
    assert res.controller["saturated"][0].all()
    uI = np.linalg.norm(res.controller["u_integral"], axis=-1).max(axis=0)
    assert uI[2] <= 0.3 * (1 + 1e-12)
    assert uI[1] < 0.6 * uI[0] and uI[2] < 0.6 * uI[1], uI
    assert res.controller["integration_frozen"][:, 1].any()
    assert not res.controller["integration_frozen"][:, 0].any()
    ang = np.rad2deg(res.attitude_error_angle())
    t = res.t
    # overshoot: the largest error after the first local minimum of the error
    first = np.argmax(np.diff(ang, axis=0) > 0, axis=0)
    over = np.array([ang[first[b] :, b].max() for b in range(3)])
    assert over[1] < 0.6 * over[0] and over[2] < 0.6 * over[1], over
    iae = np.trapezoid(ang, t, axis=0)
    assert iae[0] > iae[1] > iae[2]
    assert np.all(ang[-1] < 0.05), ang[-1]
