"""Gimbal servo of the SGCMG actuator: ideal or first-order lag (SPEC §5.2)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SEED000_J

from liecontrol.control import ConstantAttitude, GeometricPD, gains_from_bandwidth
from liecontrol.control.base import AttitudeController
from liecontrol.lie import so3
from spacecraft import (
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
    simulate,
)
from spacecraft.actuators import CmgCommand, FirstOrderServo

P = SgcmgPyramid()
J = SEED000_J
RATE = np.array([0.3, -0.2, 0.1, 0.05])  # rad/s, below the 1 rad/s limit


def constant_rate_law(A, hdot_cmd):
    """A steering 'law' that ignores the request and commands fixed rates (step input)."""
    return np.broadcast_to(RATE, A.shape[:-2] + (4,)).copy()


class _Zero(AttitudeController):
    def reset(self, t0, batch_size):
        self.B = batch_size

    def command(self, t, state, reference):
        return np.zeros((self.B, 3))


def test_step_response_matches_first_order_solution():
    """δ̇(t) = δ̇_cmd (1 − e^{−t/τ}), δ(t) = δ₀ + δ̇_cmd (t − τ(1 − e^{−t/τ}))."""
    tau = 0.4
    act = SgcmgActuator(P, constant_rate_law, servo=FirstOrderServo(tau))
    plant = Spacecraft(RigidBody(J), act)
    s0 = plant.initial_state(np.eye(3))
    assert s0.x_act.shape == (1, 8)
    res = simulate(plant, _Zero(), ConstantAttitude(np.eye(3)), s0, 3.0, 0.01, log_every=10)
    t = res.t[:, None]
    decay = 1.0 - np.exp(-t / tau)
    np.testing.assert_allclose(res.actuator["delta_dot"][:, 0], RATE * decay, atol=1e-9)
    np.testing.assert_allclose(
        res.actuator["delta"][:, 0], act.delta0 + RATE * (t - tau * decay), atol=1e-9
    )
    np.testing.assert_array_equal(res.actuator["delta_dot_cmd"][:, 0], np.tile(RATE, (t.size, 1)))
    assert not res.actuator["saturated"].any()
    # after 3τ the actual rate is within 5 % of the command: the lag is visible, then gone
    assert np.all(np.abs(res.actuator["delta_dot"][-1, 0] - RATE) < 0.001 * np.abs(RATE))


def test_ideal_servo_is_the_old_actuator():
    ideal = SgcmgActuator(P, SingularityRobust())
    assert ideal.n_states == 4 and ideal.servo == "ideal"
    x = ideal.initial_state(2)
    held = ideal.command(np.ones((2, 3)), np.zeros((2, 3)), x, 0.0)
    assert set(ideal.log(x, held)) == {"delta", "delta_dot", "saturated"}


def test_lag_body_torque_uses_actual_rates():
    """u = −A(δ) δ̇_actual − ω × h(δ), with ḣ from a finite difference along δ̇_actual."""
    rng = np.random.default_rng(0)
    act = SgcmgActuator(P, SingularityRobust(), servo=FirstOrderServo(0.2))
    delta = rng.uniform(-3, 3, (3, 4))
    actual = 0.3 * rng.normal(size=(3, 4))
    x = np.concatenate([delta, actual], axis=1)
    w = 0.02 * rng.normal(size=(3, 3))
    held = CmgCommand(
        delta_dot=rng.normal(size=(3, 4)), saturated=np.zeros(3, bool), h_dot_cmd=np.zeros((3, 3))
    )
    eps = 1e-6
    hdot = (P.momentum(delta + eps * actual) - P.momentum(delta - eps * actual)) / (2 * eps)
    ref = -hdot - np.cross(w, P.momentum(delta))
    np.testing.assert_allclose(act.body_torque(w, x, held), ref, atol=1e-6)
    for b in range(3):  # the single-spacecraft float route
        s = slice(b, b + 1)
        one = CmgCommand(held.delta_dot[s], held.saturated[s], held.h_dot_cmd[s])
        np.testing.assert_allclose(act.body_torque(w[s], x[s], one), ref[s], atol=1e-6)
    xdot = act.state_derivative(x, held)
    np.testing.assert_array_equal(xdot[:, :4], actual)
    np.testing.assert_allclose(xdot[:, 4:], (held.delta_dot - actual) / 0.2, rtol=1e-15)
    np.testing.assert_allclose(act.momentum(x), P.momentum(delta), atol=1e-12)


def _maneuver(servo, dt=0.1, t_final=150.0, B=2):
    plant = Spacecraft(RigidBody(J), SgcmgActuator(P, SingularityRobust(), servo=servo))
    k_R, k_W = gains_from_bandwidth(J, 0.05, 0.9, matrix=True)
    rng = np.random.default_rng(1)
    R_d = so3.exp(rng.normal(size=(B, 3)))
    s0 = plant.initial_state(np.eye(3), omega0=0.005 * rng.normal(size=(B, 3)))
    res = simulate(
        plant,
        GeometricPD(J, k_R, k_W),
        ConstantAttitude(R_d),
        s0,
        t_final,
        dt,
        control_period=0.1,
        log_every=round(5.0 / dt),
    )
    H = np.einsum("kbij,kbj->kbi", res.R, res.omega @ J + res.actuator["h"])
    drift = np.abs(H - H[0]).max() / np.abs(H[0]).max()
    return res, drift


def test_lag_closed_loop_approaches_ideal_and_respects_rate_limit():
    ideal, drift_ideal = _maneuver("ideal")
    fast, _ = _maneuver(FirstOrderServo(0.1))
    slow, _ = _maneuver(FirstOrderServo(2.0))
    assert drift_ideal < 1e-9
    for res in (fast, slow):
        assert np.abs(res.actuator["delta_dot"]).max() <= P.gimbal_rate_limit * (1 + 1e-12)
        assert res.actuator["delta_dot_cmd"].shape == res.actuator["delta_dot"].shape
    e_ideal = ideal.attitude_error_angle()
    gap_fast = np.abs(fast.attitude_error_angle() - e_ideal).max()
    gap_slow = np.abs(slow.attitude_error_angle() - e_ideal).max()
    assert gap_fast < 5e-3  # τ = 0.1 s ≪ the ~20 s closed-loop time scale
    assert gap_slow > 5 * gap_fast  # the lag is really there (and grows with τ)


def test_lag_momentum_exchange_converges_at_fourth_order():
    """R (Jω + h) is conserved by the continuous dynamics with the lag too (the bus feels the
    actual rates); the drift is RKMK4's truncation error: ÷16 per halving of dt. The gimbal
    rate is a fast state (δ̈ = O(1/τ)), so dt must resolve τ (drift ~ (dt/τ)⁴)."""
    servo = FirstOrderServo(0.5)
    _, d1 = _maneuver(servo, dt=0.1, t_final=60.0)
    _, d2 = _maneuver(servo, dt=0.05, t_final=60.0)
    assert d1 < 1e-5
    assert 10.0 < d1 / d2 < 25.0


def test_servo_validation():
    with pytest.raises(ValueError, match="^time_constant:"):
        FirstOrderServo(0.0)
    with pytest.raises(ValueError, match="^time_constant:"):
        FirstOrderServo(np.nan)
    with pytest.raises(ValueError, match="^time_constant:"):
        FirstOrderServo([0.1, 0.2])
    with pytest.raises(ValueError, match="^servo:"):
        SgcmgActuator(servo="lag")
    with pytest.raises(ValueError, match="^servo:"):
        SgcmgActuator(servo=0.1)
    act = SgcmgActuator(servo=FirstOrderServo(0.1), delta0=np.zeros((2, 4)))
    with pytest.raises(ValueError, match="^delta0:"):
        act.initial_state(3)
    x = act.initial_state(2)
    assert x.shape == (2, 8) and np.all(x == 0.0)
