"""Adaptive fault-tolerant law on SO(3) (liecontrol.control.fault_tolerant)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.fault_tolerant import (
    AdaptiveFaultTolerantSO3,
    fault_tolerant_gains,
    inverse_right_jacobian_apply,
)
from liecontrol.control.tuning import measure_small_angle_response
from liecontrol.lie import so3
from spacecraft.actuators import IdealTorqueActuator, SgcmgActuator
from spacecraft.faults import ActuatorBias, EfficiencyLoss, FaultyActuator, GimbalStuck, with_faults
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.sgcmg import SgcmgPyramid
from spacecraft.simulator import simulate
from spacecraft.steering import PseudoInverseNullMotion

J = np.array([[1500.0, 30.0, -10.0], [30.0, 1200.0, 20.0], [-10.0, 20.0, 1000.0]])


def _ref(t: float) -> AttitudeReference:
    return AttitudeReference.regulation(np.eye(3))


def _angle_deg(R: np.ndarray) -> np.ndarray:
    return np.degrees(np.linalg.norm(Rotation.from_matrix(R).as_rotvec(), axis=-1))


def test_log_error_rate_against_finite_differences():
    rng = np.random.default_rng(0)
    for _ in range(20):
        x = Rotation.random(random_state=rng).as_rotvec()
        x *= min(1.0, 3.1 / np.linalg.norm(x))
        e = rng.normal(size=3)
        # independent routes: the package's J_r⁻¹ matrix and d/dt log(exp(x) exp(h e))
        np.testing.assert_allclose(
            inverse_right_jacobian_apply(x, e), so3.right_jacobian_inv(x) @ e, atol=1e-12
        )
        h = 1e-6
        R = so3.exp(x)
        fd = (so3.log(R @ so3.exp(h * e)) - so3.log(R @ so3.exp(-h * e))) / (2 * h)
        np.testing.assert_allclose(inverse_right_jacobian_apply(x, e), fd, atol=1e-6)
    # series branch near 0 and the value at π
    x = np.array([1e-5, 0.0, 0.0])
    np.testing.assert_allclose(
        inverse_right_jacobian_apply(x, [0.0, 1.0, 0.0]), so3.right_jacobian_inv(x) @ [0, 1, 0]
    )
    x = np.array([0.0, 0.0, math.pi])
    np.testing.assert_allclose(
        inverse_right_jacobian_apply(x, [1.0, 0.0, 0.0]),
        [1.0 - 1.0, math.pi / 2, 0.0],  # e + ½ x×e + (1/π²) x×(x×e), x×e = (0, π, 0)
        atol=1e-12,
    )


def test_small_angle_loop_meets_the_spec():
    w = 0.1
    ctrl = AdaptiveFaultTolerantSO3(J, **fault_tolerant_gains(J, w, 0.2))
    r = measure_small_angle_response(ctrl, J, 0.2, duration=5.0 / w)
    np.testing.assert_allclose(r.omega_n, w, rtol=0.1)  # β̂ grows a little during the kick
    np.testing.assert_allclose(r.zeta, 1.01, rtol=0.1)  # poles −1.15 ω_n, −ω_n/1.15


def _ideal_run(faults, ctrl, t_final=300.0, rotvec=(0.6, -0.4, 0.3)):
    act = FaultyActuator(IdealTorqueActuator(), faults)
    plant = Spacecraft(RigidBody(J), act)
    R0 = Rotation.from_rotvec(rotvec).as_matrix()
    return simulate(plant, ctrl, _ref, plant.initial_state(R0), t_final, 0.1, control_period=0.2)


def test_adapts_to_an_unknown_loss_of_effectiveness_and_a_bias():
    faults = [EfficiencyLoss(1, 20.0, 0.3), ActuatorBias(2, 20.0, 0.4)]
    gains = fault_tolerant_gains(J, 0.05, 0.2, beta_max=1.0)
    ft = AdaptiveFaultTolerantSO3(J, **gains)
    res = _ideal_run(faults, ft)
    d = res.controller
    k_hat = d["k_hat"][:, 0]
    # k̂ grows on the faulty axis (towards 1/0.3) and stays in its box; a persistent bias also
    # raises k̂ on its axis (a gain increase, bounded by the projection), the healthy axis stays
    assert np.all(k_hat >= 1.0) and np.all(k_hat <= gains["k_max"])
    assert k_hat[-1, 1] > 1.5 and k_hat[-1, 1] >= k_hat[-1, 0]
    beta = d["beta_hat"][:, 0]
    assert np.all(np.diff(beta) >= 0.0) and 0.0 < beta[-1] <= 1.0
    theta = _angle_deg(res.R[:, 0])
    # residual of the boundary layer: ‖s‖ ≈ σ‖d‖/β̂ (the PD's would be ‖d‖/(ω_n² J) ≈ 9°)
    assert theta[-1] < 0.5
    # the same loop without adaptation (γ = 0) keeps a larger error against the bias
    fixed = AdaptiveFaultTolerantSO3(J, **{**gains, "gamma_k": 0.0, "gamma_beta": 0.0})
    theta0 = _angle_deg(_ideal_run(faults, fixed).R[:, 0])
    assert theta0[-1] > 3.0 * theta[-1]


def test_ultimate_bound_of_the_sliding_variable():
    # V̇ ≤ −sᵀKs + βσ: with β̂ saturated at β_max ≥ ‖d‖ the steady ‖s‖ is ≤ σ‖d‖/(β_max − ...)
    gains = fault_tolerant_gains(J, 0.05, 0.2, beta_max=1.0)
    ft = AdaptiveFaultTolerantSO3(J, **gains)
    res = _ideal_run([ActuatorBias(0, 0.0, 0.3)], ft, t_final=600.0)
    s = np.linalg.norm(res.controller["s"][-200:, 0], axis=-1)
    Kmin = np.linalg.eigvalsh(gains["K"]).min()
    assert s.max() <= math.sqrt(0.3 * gains["sigma"] / Kmin) + 1e-12


def test_stuck_gimbal_slew_completes():
    # 90° slew of a CMG spacecraft; gimbal 1 sticks mid-manoeuvre, the steering is told
    cl = SgcmgPyramid()
    act = SgcmgActuator(cl, PseudoInverseNullMotion(cluster=cl))
    plant = with_faults(Spacecraft(RigidBody(J), act), [GimbalStuck(1, 15.0)])
    ft = AdaptiveFaultTolerantSO3(J, **fault_tolerant_gains(J, 0.05, 0.2))
    axis = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)
    R0 = Rotation.from_rotvec(math.radians(90.0) * axis).as_matrix()
    res = simulate(plant, ft, _ref, plant.initial_state(R0), 250.0, 0.1, control_period=0.2)
    theta = _angle_deg(res.R[:, 0])
    k = int(np.searchsorted(res.t, 15.0))
    assert theta[k] > 60.0  # the gimbal stuck well before the end of the slew
    assert np.all(res.actuator["delta"][k:, 0, 1] == res.actuator["delta"][k, 0, 1])
    assert theta[-1] < 0.1
    assert res.actuator["singularity_remaining"][k:].min() > 0.05


def test_bad_input():
    with pytest.raises(ValueError, match="^J:"):
        AdaptiveFaultTolerantSO3(np.eye(2), 1.0, 0.1)
    with pytest.raises(ValueError, match="^K: must be > 0"):
        AdaptiveFaultTolerantSO3(J, -1.0, 0.1)
    with pytest.raises(ValueError, match="^K: must be positive definite"):
        AdaptiveFaultTolerantSO3(J, np.diag([1.0, -1.0, 1.0]), 0.1)
    with pytest.raises(ValueError, match="^lam:"):
        AdaptiveFaultTolerantSO3(J, 1.0, 0.0)
    with pytest.raises(ValueError, match="^gamma_k: must be >= 0"):
        AdaptiveFaultTolerantSO3(J, 1.0, 0.1, gamma_k=-1.0)
    with pytest.raises(ValueError, match="^k_max: must be >= 1"):
        AdaptiveFaultTolerantSO3(J, 1.0, 0.1, k_max=0.5)
    with pytest.raises(ValueError, match="^sigma:"):
        AdaptiveFaultTolerantSO3(J, 1.0, 0.1, sigma=0.0)
    with pytest.raises(ValueError, match="^max_torque:"):
        AdaptiveFaultTolerantSO3(J, 1.0, 0.1, max_torque=[1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match="^x: expected ‖x‖ ≤ π"):
        inverse_right_jacobian_apply([4.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="^omega_n:"):
        fault_tolerant_gains(J, -0.1, 0.2)
    c = AdaptiveFaultTolerantSO3(J, 1.0, 0.1)
    st = AttitudeState(R=np.eye(3)[None], omega=np.zeros((1, 3)))
    with pytest.raises(RuntimeError, match="reset"):
        c.command(0.0, st, _ref(0.0))
    c.reset(0.0, 2)
    with pytest.raises(ValueError, match="^state: batch size 1 differs"):
        c.command(0.0, st, _ref(0.0))
    c.reset(0.0, 1)
    c.command(1.0, st, _ref(1.0))
    with pytest.raises(ValueError, match="^t: 0.5 is earlier"):
        c.command(0.5, st, _ref(0.5))


def test_saturation_clips_and_freezes_the_effectiveness_estimate():
    c = AdaptiveFaultTolerantSO3(J, 500.0, 0.1, gamma_k=1.0, max_torque=0.5)
    c.reset(0.0, 1)
    R = Rotation.from_rotvec([1.0, 0, 0]).as_matrix()[None]
    st = AttitudeState(R=R, omega=np.zeros((1, 3)))
    u = c.command(0.0, st, _ref(0.0))
    assert np.all(np.abs(u) <= 0.5) and c.diagnostics()["saturated"][0]
    c.command(1.0, st, _ref(1.0))
    np.testing.assert_array_equal(c.k_hat, np.ones((1, 3)))
