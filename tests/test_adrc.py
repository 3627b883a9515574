"""MRP ADRC (SPEC §6.1, seed 000): ESO polynomial, pole placement, disturbance estimation,
exact discretisation, shadow remap, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SEED000_J
from hypothesis import given, settings
from hypothesis import strategies as st

from liecontrol.charts import mrp
from liecontrol.control.adapters import MrpChart, mrp_shadow_map
from liecontrol.control.adrc import (
    PAPER,
    ADRCParams,
    MrpADRC,
    MrpADRCLaw,
    eso_characteristic_polynomial,
    eso_error_matrix,
    eso_gains_from_poles,
    eso_poles,
)
from liecontrol.control.base import AttitudeState
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3

J = SEED000_J


class _S:
    """Minimal chart state for driving the law directly (the fields the ADRC reads)."""

    def __init__(self, y, y_dot, y_d=None):
        self.y = np.atleast_2d(y)
        self.y_dot = np.atleast_2d(y_dot)
        self.y_d = np.zeros_like(self.y) if y_d is None else np.atleast_2d(y_d)


def _law_step_matrix(params: ADRCParams, h: float) -> np.ndarray:
    """Identify the implemented per-axis ESO transition Φ (zero measurement and input)."""
    law = MrpADRCLaw(J, params)
    law.reset(0.0, 3)
    law(0.0, _S(np.zeros((3, 3)), np.zeros((3, 3))))
    Phi = np.zeros((3, 3, 3))
    for j in range(3):
        law.z = np.zeros((3, 3, 3))
        law.z[:, :, j] = 1.0  # unit initial state in component j on every axis
        law._bu = np.zeros((3, 3))
        law._t = 0.0
        law(h, _S(np.zeros((3, 3)), np.zeros((3, 3))))
        Phi[:, :, j] = law.z[0]  # axes of spacecraft 0
    return Phi


@pytest.mark.parametrize("beta", [0.5, 0.0, 1.0])
def test_implemented_error_dynamics_have_spec_polynomial(beta):
    params = ADRCParams(beta=beta, K1=[20.0, 25.0, 30.0], K2=[100.0, 120.0, 90.0])
    h = 0.01
    Phi = _law_step_matrix(params, h)
    want = eso_characteristic_polynomial(params.K1, params.K2, params.K3, params.alpha, beta)
    for a in range(3):
        lam = np.log(np.linalg.eigvals(Phi[a]).astype(complex)) / h
        got = np.real(np.poly(lam))
        np.testing.assert_allclose(got, want[a], rtol=1e-8)
        # and the continuous error matrix F of eq. (13)
        F = eso_error_matrix(params.K1, params.K2, params.K3, params.alpha, beta)[a]
        np.testing.assert_allclose(np.poly(F), want[a], rtol=1e-12)


def test_paper_gains_and_tuner_round_trip():
    poles = eso_poles(20, 100, 800, 1.0, 0.5)
    K1, K2, K3 = eso_gains_from_poles(poles[0], 1.0, 0.5)
    np.testing.assert_allclose([K1, K2, K3], [[20] * 3, [100] * 3, [800] * 3], rtol=1e-10)
    np.testing.assert_allclose(
        eso_characteristic_polynomial(20, 100, 800, 1.0, 0.5)[0], [1, 70, 500, 800]
    )
    np.testing.assert_allclose(
        eso_characteristic_polynomial(20, 100, 800, 1.0, 0.0)[0], [1, 20, 100, 800]
    )


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(0.5, 50.0), min_size=3, max_size=3),
    st.floats(0.2, 2.0),
    st.floats(0.0, 0.05),
)
def test_tuner_places_requested_poles(lams, alpha, beta):
    poles = -np.array(lams)
    want = np.poly(poles)
    # independent route: solve the linear system of eq. (18) for (K1, K2, K3)
    A = np.array([[alpha, beta, 0.0], [0.0, alpha, beta], [0.0, 0.0, alpha]])
    K_ref = np.linalg.solve(A, want[1:])
    if np.any(K_ref <= 0):
        with pytest.raises(ValueError, match="^poles:"):
            eso_gains_from_poles(poles, alpha, beta)
        return
    K1, K2, K3 = eso_gains_from_poles(poles, alpha, beta)
    np.testing.assert_allclose([K1[0], K2[0], K3[0]], K_ref, rtol=1e-10)
    # the resulting ESO polynomial is (s + λ1)(s + λ2)(s + λ3) on every axis
    got = eso_characteristic_polynomial(K1, K2, K3, alpha, beta)
    np.testing.assert_allclose(got, np.broadcast_to(want, (3, 4)), rtol=1e-10)
    if min(abs(lams[0] - lams[1]), abs(lams[1] - lams[2]), abs(lams[0] - lams[2])) > 0.1:
        roots = np.sort(eso_poles(K1, K2, K3, alpha, beta)[0].real)
        np.testing.assert_allclose(roots, np.sort(poles), rtol=1e-6)


def test_tuner_complex_pairs_and_bad_poles():
    poles = np.array([-3.0, -1.0 + 2.0j, -1.0 - 2.0j])
    K = eso_gains_from_poles(poles, 1.0, 0.1)
    got = np.sort_complex(eso_poles(*K, 1.0, 0.1)[0])
    np.testing.assert_allclose(got, np.sort_complex(poles), rtol=1e-9)
    with pytest.raises(ValueError, match="^poles:"):
        eso_gains_from_poles([-1.0, 0.0, -2.0], 1.0, 0.5)
    with pytest.raises(ValueError, match="^poles:"):
        eso_gains_from_poles([-1.0, 2.0, -2.0], 1.0, 0.5)
    with pytest.raises(ValueError, match="^poles:"):
        eso_gains_from_poles([-1.0, -1.0 + 1j, -2.0], 1.0, 0.5)  # unpaired
    with pytest.raises(ValueError, match="^poles:"):
        eso_gains_from_poles([-1.0, -2.0, -3.0], 1.0, 5.0)  # would need K ≤ 0
    with pytest.raises(ValueError, match="^alpha:"):
        eso_gains_from_poles([-1.0, -2.0, -3.0], 0.0, 0.0)


def test_discrete_eso_equals_fine_integration_of_the_continuous_eso():
    """One sample of the exact update = RK4 with 2000 sub-steps of eq. (11), with B τ held and
    the measurements interpolated linearly between the two samples."""
    P = PAPER
    law = MrpADRCLaw(J, P)
    law.reset(0.0, 1)
    y0 = np.array([[0.01, -0.02, 0.005]])
    law(0.0, _S(y0, np.zeros((1, 3))))
    z0 = np.random.default_rng(0).normal(size=(1, 3, 3)) * 1e-3
    bu = np.array([[1e-4, -2e-4, 3e-5]])
    law.z, law._bu = z0.copy(), bu.copy()
    y_p, y_v = np.array([[0.012, -0.018, 0.004]]), np.array([[1e-3, 2e-3, -1e-3]])
    h = 0.1
    law(h, _S(y_p, y_v))
    m1 = P.alpha * y_p + P.beta * y_v
    m0 = P.alpha * y0

    def f(z, s):
        m = m0 + (m1 - m0) * s / h
        e = m[0] - (P.alpha * z[:, 0] + P.beta * z[:, 1])
        return np.stack((z[:, 1] + P.K1 * e, z[:, 2] + P.K2 * e + bu[0], P.K3 * e), axis=-1)

    z = z0[0].copy()
    n = 2000
    dt = h / n
    for i in range(n):
        s0 = i * dt
        k1 = f(z, s0)
        k2 = f(z + 0.5 * dt * k1, s0 + 0.5 * dt)
        k3 = f(z + 0.5 * dt * k2, s0 + 0.5 * dt)
        k4 = f(z + dt * k3, s0 + dt)
        z = z + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    np.testing.assert_allclose(law.z[0], z, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("beta", [0.5, 0.0])
def test_extended_state_converges_to_constant_disturbance(beta):
    """Closed loop on p̈ = d + G(p)J⁻¹τ (per-axis double integrator in MRP): z₃ → d."""
    d = np.array([2e-5, -4e-5, 1e-5])
    law = MrpADRCLaw(J, ADRCParams(beta=beta))
    law.reset(0.0, 1)
    Jinv = np.linalg.inv(J)
    p, pd = np.array([0.01, -0.005, 0.002]), np.zeros(3)
    h, sub = 0.05, 4
    p0 = p.copy()
    for k in range(int(40.0 / h)):
        p_seen = p.copy()
        tau = law(k * h, _S(p, mrp.kinematics(p, mrp.kinematics_matrix_inv(p) @ pd)))[0]

        def f(x, tau=tau):
            pp, v = x[:3], x[3:]
            return np.concatenate((v, d + mrp.kinematics_matrix(pp) @ Jinv @ tau))

        x = np.concatenate((p, pd))
        dt = h / sub
        for _ in range(sub):
            k1 = f(x)
            k2 = f(x + 0.5 * dt * k1)
            k3 = f(x + 0.5 * dt * k2)
            k4 = f(x + dt * k3)
            x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        p, pd = x[:3], x[3:]
    z = law.z[0]
    np.testing.assert_allclose(z[:, 2], d, rtol=1e-3, atol=1e-9)
    np.testing.assert_allclose(z[:, 0], p_seen, atol=1e-9)
    # the AFC makes p follow the TD's transition v₁ from p(0) to p_d = 0 (time constant 1/r)
    r, t_end = PAPER.r, 40.0
    np.testing.assert_allclose(law.v[0, :, 0], p0 * (1 + r * t_end) * np.exp(-r * t_end), rtol=1e-3)
    assert np.linalg.norm(p_seen - law.v[0, :, 0]) < 0.02 * np.linalg.norm(p0)


def test_closed_loop_rigid_body_estimates_total_disturbance():
    """On the rigid body with a constant torque, z₃ matches the true f = p̈ − G J⁻¹ τ."""
    from spacecraft.actuators import IdealTorqueActuator
    from spacecraft.disturbances import ConstantTorque
    from spacecraft.plant import Spacecraft
    from spacecraft.rigid_body import RigidBody
    from spacecraft.simulator import simulate

    Td = np.array([0.5, -0.3, 0.2])
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(), ConstantTorque(Td))
    ctrl = MrpADRC(J, PAPER, base="inertial")
    x0 = plant.initial_state(so3.exp(np.array([0.02, -0.01, 0.03])))
    res = simulate(plant, ctrl, ConstantAttitude(np.eye(3)), x0, 30.0, 0.05, log_every=20)
    p = mrp.from_matrix(res.R[-1, 0])
    w = res.omega[-1, 0]
    chart = MrpChart()
    wdot = np.linalg.solve(J, res.u[-1, 0] + Td - np.cross(w, J @ w))
    p_dot = chart.rates(p, w)
    f = chart.acceleration(p, p_dot, wdot) - mrp.kinematics(p, np.linalg.solve(J, res.u_cmd[-1, 0]))
    np.testing.assert_allclose(res.controller["z3"][-1, 0], f, rtol=1e-2, atol=1e-10)
    np.testing.assert_allclose(f, mrp.kinematics(p, np.linalg.solve(J, Td)), rtol=0.05)
    v1 = res.controller["v1"][-1, 0]
    assert np.linalg.norm(p - v1) < 0.05 * np.linalg.norm(mrp.from_matrix(res.R[0, 0]))


def test_shadow_switch_remaps_eso_and_td_states():
    law = MrpADRCLaw(J, PAPER)
    law.reset(0.0, 2)
    rng = np.random.default_rng(3)
    z = rng.normal(size=(2, 3, 3))
    z[:, :, 0] *= 1.0 / np.linalg.norm(z[:, :, 0], axis=1, keepdims=True)
    law.z = z.copy()
    law.v = rng.normal(size=(2, 3, 2))
    v0 = law.v.copy()
    bu = rng.normal(size=(2, 3))
    law._bu = bu.copy()
    law.on_shadow_switch(np.array([True, False]), np.array([False, True]))
    s1, s2, s3 = mrp_shadow_map(z[0, :, 0], z[0, :, 1], z[0, :, 2])
    np.testing.assert_allclose(law.z[0], np.stack((s1, s2, s3), axis=-1), atol=1e-14)
    np.testing.assert_allclose(law.z[1], z[1])  # not switched
    G_ratio = mrp.kinematics_matrix(s1) @ np.linalg.inv(mrp.kinematics_matrix(z[0, :, 0]))
    np.testing.assert_allclose(law._bu[0], G_ratio @ bu[0], atol=1e-12)  # Bτ maps with D
    v1, v2, _ = mrp_shadow_map(v0[1, :, 0], v0[1, :, 1])
    np.testing.assert_allclose(law.v[1], np.stack((v1, v2), axis=-1), atol=1e-14)
    np.testing.assert_allclose(law.v[0], v0[0])


def test_adrc_through_adapter_runs_and_reports():
    """Through the MRP adapter, batch of two.

    First command by hand: the ESO and the tracking differentiator both start at the measured
    MRP (z₁ = v₁ = y_p, z₂ = v₂ = ṗ = 0 at rest, z₃ = 0), so τ₀ = k₁(v₁ − z₁) + k₂(v₂ − z₂) = 0
    and the command is exactly zero. Closed loop (ideal torque, no disturbance): the TD is a
    critically damped linear filter, so v₁(t) = p₀ (1 + r t) e^{−r t} in closed form; the
    attitude follows v₁ closely and the error decreases monotonically on both spacecraft."""
    from spacecraft.actuators import IdealTorqueActuator
    from spacecraft.plant import Spacecraft
    from spacecraft.rigid_body import RigidBody
    from spacecraft.simulator import simulate

    c = MrpADRC(J, PAPER)
    c.reset(0.0, 2)
    R = so3.exp(np.array([[0.01, 0.0, 0.0], [0.0, -0.02, 0.01]]))
    u = c.command(0.0, AttitudeState(R, np.zeros((2, 3))), ConstantAttitude(np.eye(3))(0.0))
    np.testing.assert_array_equal(u, 0.0)
    d = c.diagnostics()
    p = mrp.from_matrix(R)
    for k in ("z1", "v1", "chart_y"):
        np.testing.assert_allclose(d[k], p, rtol=0, atol=1e-15)
    for k in ("z2", "z3", "v2", "tau0", "eso_error"):
        np.testing.assert_array_equal(d[k], 0.0)

    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    R0 = so3.exp(np.array([[0.2, 0.0, 0.0], [0.0, -0.3, 0.1]]))
    res = simulate(plant, MrpADRC(J, PAPER), ConstantAttitude(np.eye(3)),
                   plant.initial_state(R0), 150.0, 0.1, log_every=10)
    p0 = mrp.from_matrix(R0)
    r_t = PAPER.r * res.t
    v1 = p0[None] * ((1.0 + r_t) * np.exp(-r_t))[:, None, None]
    np.testing.assert_allclose(res.controller["v1"], v1, rtol=0, atol=1e-12)
    p = mrp.from_matrix(res.R)
    assert np.abs(p - v1).max() < 1e-3 * np.abs(p0).max()  # follows the TD profile
    err = res.attitude_error_angle()
    assert np.all(np.diff(err, axis=0) < 0)  # monotone approach, no overshoot
    assert np.all(err[-1] < 0.25 * err[0])  # v₁(150 s) = 0.2 p₀: most of the way


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"K1": 0.0}, "K1"),
        ({"K2": -1.0}, "K2"),
        ({"K3": [800.0, 0.0, 800.0]}, "K3"),
        ({"k1": 0.0}, "k1"),
        ({"k2": -10.0}, "k2"),
        ({"r": 0.0}, "r"),
        ({"alpha": 0.0, "beta": 0.0}, "alpha"),
        ({"alpha": 0.0, "beta": 0.5}, "alpha"),
        ({"beta": -0.1}, "beta"),
        ({"K1": [1.0, 2.0]}, "K1"),
        ({"r": float("nan")}, "r"),
    ],
)
def test_bad_parameters(kw, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        ADRCParams(**kw)


def test_bad_construction():
    with pytest.raises(ValueError, match="^J:"):
        MrpADRC(np.diag([1.0, 1.0, 5.0]), PAPER)
    with pytest.raises(ValueError, match="^params:"):
        MrpADRCLaw(J, {"K1": 20})
    with pytest.raises(ValueError, match="^K1:"):
        eso_characteristic_polynomial(-1, 100, 800, 1.0, 0.5)
    with pytest.raises(ValueError, match="^eso_init:"):
        MrpADRC(J, PAPER, eso_init="guess")


def test_eso_initialisation():
    y, yd = np.array([[0.05, -0.02, 0.01]]), np.array([[1e-3, 0.0, -2e-3]])
    for beta, init, want1, want2 in (
        (0.5, "measured", y, yd),
        (0.0, "measured", y, 0 * yd),
        (0.5, "zero", 0 * y, 0 * yd),
    ):
        law = MrpADRCLaw(J, ADRCParams(beta=beta), eso_init=init)
        law.reset(0.0, 1)
        law(0.0, _S(y, yd))
        np.testing.assert_array_equal(law.z[..., 0], want1)
        np.testing.assert_array_equal(law.z[..., 1], want2)
        np.testing.assert_array_equal(law.z[..., 2], 0.0)
        np.testing.assert_array_equal(law.v[..., 0], y)
