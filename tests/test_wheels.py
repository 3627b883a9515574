"""Reaction-wheel assembly (SPEC §5.1–5.2): momentum exchange, distribution, limits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from liecontrol.control import ConstantAttitude, GeometricPD, gains_from_bandwidth
from liecontrol.lie import so3
from spacecraft import RigidBody, Spacecraft, simulate
from spacecraft.actuators import (
    ReactionWheelAssembly,
    WheelCommand,
    orthogonal_wheel_axes,
    pyramid_wheel_axes,
)

J = np.array([[12.0, 0.4, -0.3], [0.4, 10.0, 0.2], [-0.3, 0.2, 8.0]])  # small satellite
vec3 = st.tuples(*[st.floats(-1.0, 1.0)] * 3).map(np.array)


def wheels(kind: str = "pyramid", **kw) -> ReactionWheelAssembly:
    kw = {"wheel_inertia": 0.01, "max_torque": 1.0, "max_speed": 1000.0} | kw
    return ReactionWheelAssembly.pyramid(**kw) if kind == "pyramid" else (
        ReactionWheelAssembly.orthogonal(**kw)
    )  # fmt: skip


# ---------------------------------------------------------------------------- geometry
def test_axes_helpers():
    np.testing.assert_array_equal(orthogonal_wheel_axes(), np.eye(3))
    A = pyramid_wheel_axes()
    np.testing.assert_allclose(np.linalg.norm(A, axis=0), 1.0, rtol=1e-15)
    np.testing.assert_allclose(A @ A.T, 4.0 / 3.0 * np.eye(3), atol=1e-15)  # isotropic β
    for drop in range(4):  # any three wheels still span ℝ³ (one-failure tolerance)
        assert np.linalg.matrix_rank(np.delete(A, drop, axis=1)) == 3
    b = 0.4
    Ab = pyramid_wheel_axes(b)
    np.testing.assert_allclose(
        Ab @ Ab.T, np.diag([2 * np.sin(b) ** 2, 2 * np.sin(b) ** 2, 4 * np.cos(b) ** 2]), atol=1e-15
    )
    with pytest.raises(ValueError, match="^beta:"):
        pyramid_wheel_axes(0.0)


@settings(max_examples=30, deadline=None)
@given(speed=st.tuples(*[st.floats(-500.0, 500.0)] * 4).map(np.array), w=vec3, tq=vec3)
def test_body_torque_is_minus_hdot_minus_omega_cross_h(speed, w, tq):
    """u = −ḣ − ω × h with h = Σ I_w Ωᵢ aᵢ and ḣ by a finite difference along Ω̇ (SPEC §5.1)."""
    act = wheels(wheel_inertia=np.array([0.01, 0.02, 0.015, 0.01]))
    x = speed[None]
    held = act.command(tq[None], 0.1 * w[None], x, 0.0)
    Om_dot = act.state_derivative(x, held)
    h = lambda s: (act.wheel_inertia * s) @ act.axes.T  # noqa: E731 - independent route
    eps = 1e-3
    hdot = (h(x + eps * Om_dot) - h(x - eps * Om_dot)) / (2 * eps)
    u = act.body_torque(0.1 * w[None], x, held)
    np.testing.assert_allclose(u, -hdot - np.cross(0.1 * w, h(x)), atol=1e-9)
    np.testing.assert_allclose(act.momentum(x), h(x), rtol=1e-14, atol=1e-12)


@pytest.mark.parametrize("kind", ["orthogonal", "pyramid"])
def test_delivers_command_with_minimum_norm_torques(kind):
    act = wheels(kind)
    rng = np.random.default_rng(0)
    B = 6
    x = rng.uniform(-300, 300, (B, act.n_wheels))
    w = 0.05 * rng.normal(size=(B, 3))
    u_cmd = 0.3 * rng.normal(size=(B, 3))
    held = act.command(u_cmd, w, x, 0.0)
    assert not held.torque_saturated.any() and not held.speed_saturated.any()
    np.testing.assert_allclose(act.body_torque(w, x, held), u_cmd, atol=1e-12)
    # minimum norm: numpy's pseudo-inverse, and no component in the null space of A
    h_dot = -u_cmd - np.cross(w, act.momentum(x))
    np.testing.assert_allclose(held.torque, h_dot @ np.linalg.pinv(act.axes).T, atol=1e-12)
    if kind == "pyramid":
        null = np.linalg.svd(act.axes)[2][-1]
        np.testing.assert_allclose(held.torque @ null, 0.0, atol=1e-12)
    log = act.log(x, held)
    assert set(log) == {
        "wheel_speed",
        "wheel_torque",
        "wheel_torque_cmd",
        "torque_saturated",
        "speed_saturated",
        "saturated",
    }
    assert all(v.shape == (B, act.n_wheels) for v in log.values())
    derived = act.derived_log({k: v[None] for k, v in log.items()})
    np.testing.assert_allclose(derived["h"][0], act.momentum(x), rtol=1e-15)


def test_torque_and_speed_limits_in_one_command():
    act = wheels("orthogonal", max_torque=np.array([0.1, 0.2, 0.3]), max_speed=100.0)
    x = np.array([[100.0, -100.0, 50.0]])
    # ḣ_cmd = −u: wheel 1 asked for +0.5 (at +max speed: blocked), wheel 2 for −0.05 (at −max
    # speed, same sign: blocked), wheel 3 for +0.5 (clipped to 0.3)
    held = act.command(np.array([[-0.5, 0.05, -0.5]]), np.zeros((1, 3)), x, 0.0)
    np.testing.assert_array_equal(held.torque, [[0.0, 0.0, 0.3]])
    np.testing.assert_array_equal(held.torque_saturated, [[True, False, True]])
    np.testing.assert_array_equal(held.speed_saturated, [[True, True, False]])
    # pulling a saturated wheel back is allowed
    back = act.command(np.array([[0.05, -0.05, 0.0]]), np.zeros((1, 3)), x, 0.0)
    np.testing.assert_allclose(back.torque, [[-0.05, 0.05, 0.0]], atol=1e-15)
    assert not back.speed_saturated.any()
    # inside an integration stage a wheel that reaches max speed stops being accelerated
    free = WheelCommand(
        np.array([[0.1, 0.1, 0.1]]), np.zeros((1, 3)), np.zeros((1, 3), bool),
        np.zeros((1, 3), bool), np.zeros((1, 3)),
    )  # fmt: skip
    np.testing.assert_array_equal(
        act.state_derivative(np.array([[100.0, 99.0, -100.0]]), free), [[0.0, 10.0, 10.0]]
    )


def _run(act, omega0, t_final=120.0, dt=0.1, B=3):
    plant = Spacecraft(RigidBody(J), act)
    rng = np.random.default_rng(3)
    R0 = so3.random(rng, B)
    R_d = so3.exp(rng.normal(size=(B, 3)) * 0.6)
    k_R, k_W = gains_from_bandwidth(J, 0.15, 0.9, matrix=True)
    s0 = plant.initial_state(R0, omega0=omega0 * rng.normal(size=(B, 3)))
    res = simulate(plant, GeometricPD(J, k_R, k_W), ConstantAttitude(R_d), s0, t_final, dt)
    H = np.einsum("kbij,kbj->kbi", res.R, res.omega @ J + res.actuator["h"])
    return res, H


@pytest.mark.parametrize("kind", ["orthogonal", "pyramid"])
def test_closed_loop_conserves_total_momentum(kind):
    """Momentum exchange: R (Jω + h) constant without disturbance (SPEC §5.1), and the
    maneuver converges (the wheels deliver the PD torque)."""
    res, H = _run(wheels(kind), omega0=0.01)
    assert np.abs(H - H[0]).max() < 1e-9 * np.abs(H[0]).max()
    assert np.abs(res.actuator["h"]).max() > 0.05  # momentum really moved into the wheels
    assert not res.actuator["saturated"].any()
    np.testing.assert_allclose(res.u, res.u_cmd, atol=1e-9)
    assert np.all(res.attitude_error_angle()[-1] < np.deg2rad(0.5))


def test_limits_enforced_logged_and_momentum_still_conserved():
    """Tight limits: the torque clip and the speed gate both act; the wheel speeds never pass
    max_speed by more than one step's max_torque·dt/I_w; R (Jω + h) stays constant (the same
    gated torque acts on the wheel and on the bus)."""
    Iw, tmax, wmax, dt = 0.01, 0.02, 40.0, 0.1
    act = wheels(wheel_inertia=Iw, max_torque=tmax, max_speed=wmax)
    res, H = _run(act, omega0=0.03, dt=dt)
    log = res.actuator
    assert log["torque_saturated"].any() and log["speed_saturated"].any()
    np.testing.assert_array_equal(
        log["saturated"], log["torque_saturated"] | log["speed_saturated"]
    )
    assert np.abs(log["wheel_torque"]).max() <= tmax
    assert np.abs(log["wheel_speed"]).max() <= wmax + tmax * dt / Iw
    assert np.abs(log["wheel_speed"]).max() > 0.99 * wmax
    clipped = log["torque_saturated"] & ~log["speed_saturated"]
    np.testing.assert_allclose(np.abs(log["wheel_torque"][clipped]), tmax)
    blocked = log["speed_saturated"]
    assert np.all(log["wheel_torque"][blocked] == 0.0)
    assert np.abs(H - H[0]).max() < 1e-8 * np.abs(H[0]).max()
    # the delivered torque falls short of the command where limited
    assert np.abs(res.u - res.u_cmd).max() > 1e-3


def test_batched_equals_single_spacecraft():
    act = wheels(initial_speeds=[10.0, -20.0, 5.0, 0.0])
    res, _ = _run(act, omega0=0.01, t_final=20.0, B=2)
    plant = Spacecraft(RigidBody(J), act)
    one = simulate(
        plant,
        GeometricPD(J, *gains_from_bandwidth(J, 0.15, 0.9, matrix=True)),
        ConstantAttitude(res.R_d[0, 1]),
        plant.initial_state(res.R[0, 1], omega0=res.omega[0, 1]),
        20.0,
        0.1,
    )
    np.testing.assert_allclose(one.actuator["wheel_speed"][:, 0], res.actuator["wheel_speed"][:, 1])
    np.testing.assert_allclose(one.R[:, 0], res.R[:, 1], atol=1e-12)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"max_torque": 0.0}, "max_torque"),
        ({"max_torque": -1.0}, "max_torque"),
        ({"max_speed": 0.0}, "max_speed"),
        ({"max_speed": [1.0, 2.0, -3.0, 4.0]}, "max_speed"),
        ({"wheel_inertia": 0.0}, "wheel_inertia"),
        ({"wheel_inertia": np.nan}, "wheel_inertia"),
        ({"max_torque": [0.1, 0.2]}, "max_torque"),
        ({"initial_speeds": [0.0, 0.0, 0.0]}, "initial_speeds"),
        ({"initial_speeds": [2000.0, 0.0, 0.0, 0.0]}, "initial_speeds"),
        ({"axes": np.eye(3)[:, :2]}, "axes"),
        ({"axes": 2.0 * np.eye(3)}, "axes"),
        ({"axes": np.array([[1.0, 0, 1 / np.sqrt(2)], [0, 1, 1 / np.sqrt(2)], [0, 0, 0]])}, "axes"),
        ({"axes": np.full((3, 3), np.nan)}, "axes"),
    ],
)
def test_bad_parameters_raise_naming_the_field(kwargs, name):
    base = {"axes": pyramid_wheel_axes(), "wheel_inertia": 0.01, "max_torque": 0.1}
    with pytest.raises(ValueError, match=f"^{name}:"):
        ReactionWheelAssembly(**(base | kwargs))


def test_initial_speeds_batch_and_immutability():
    w0 = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    act = ReactionWheelAssembly.orthogonal(initial_speeds=w0)
    w0[0, 0] = 99.0  # the assembly keeps its own copy
    np.testing.assert_array_equal(act.initial_state(2)[0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="^initial_speeds:"):
        act.initial_state(3)
    with pytest.raises(AttributeError):
        act.max_speed = 1.0  # frozen
    x = act.initial_state(2)
    u = np.ones((2, 3))
    copies = (x.copy(), u.copy())
    held = act.command(u, np.zeros((2, 3)), x, 0.0)
    act.body_torque(np.zeros((2, 3)), x, held)
    np.testing.assert_array_equal(x, copies[0])
    np.testing.assert_array_equal(u, copies[1])
