"""Reaction wheels in the compiled loop (``spacecraft._fused_wheels``, kernels
``spacecraft._kernels_wheels``): the fused run equals the Python loop — the assembly's NumPy
methods, the reference — to 1e-12 with the torque and speed limits active, friction and torque
quantisation, the disturbance codes and the seam, batches with per-spacecraft inertias and
initial wheel speeds, control periods and log strides; the built-in controllers through the
seam; threads bit for bit; what keeps the Python loop says so."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from conftest import simulate_fused, simulate_python_loop

from liecontrol._jit import JIT_ENABLED
from liecontrol.control import GeometricPD
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import ReactionWheelAssembly, RigidBody, Spacecraft, simulate
from spacecraft.disturbances import ConstantHarmonicTorque, SumOfDisturbances
from spacecraft.environment import GravityGradientTorque
from spacecraft.orbit import CircularOrbit
from spacecraft.payload import ROTATING_PAYLOAD_EXAMPLE, RotatingPayloadTorque

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the compiled loop needs numba")

J = np.diag([120.0, 100.0, 80.0])
FRICTION = dict(coulomb_friction=0.002, viscous_friction=1e-4, stribeck_torque=0.004,
                stribeck_speed=5.0, torque_lsb=1e-4)  # fmt: skip


def _wheels(friction: bool, layout: str = "pyramid", B: int = 1) -> ReactionWheelAssembly:
    n = 4 if layout == "pyramid" else 3
    speeds = np.array([50.0, -20.0, 0.0, 5.0])[:n]
    if B > 1:  # each spacecraft its own initial wheel speeds
        speeds = speeds + np.arange(B)[:, None] * np.array([-3.0, 2.0, 1.0, -1.0])[:n]
    kw = dict(wheel_inertia=0.01, max_torque=0.05, max_speed=60.0, initial_speeds=speeds)
    build = (
        ReactionWheelAssembly.pyramid if layout == "pyramid" else ReactionWheelAssembly.orthogonal
    )
    return build(**kw, **(FRICTION if friction else {}))


def _case(dist, friction, B=2, layout="pyramid", per_spacecraft=False, seed=5):
    rng = np.random.default_rng(seed)
    Jb = np.stack([J * (1.0 + 0.1 * i) for i in range(B)]) if per_spacecraft else J
    plant = Spacecraft(RigidBody(Jb), _wheels(friction, layout, B), disturbance=dist)
    ref = ConstantAttitude(so3.exp(np.array([0.1, -0.2, 0.3])))
    x0 = plant.initial_state(so3.exp(0.5 * rng.normal(size=(B, 3))), 0.01 * rng.normal(size=(B, 3)))
    return plant, GeometricPD(J, 2.0, 20.0), ref, x0


def _assert_same(a, b):
    for name in ("t", "R", "omega", "u_cmd", "u", "disturbance"):
        x, y = getattr(a, name), getattr(b, name)
        np.testing.assert_allclose(
            x, y, rtol=0, atol=1e-12 * max(1.0, np.abs(y).max()), err_msg=name
        )
    assert list(a.actuator) == list(b.actuator)
    for k, v in b.actuator.items():
        assert a.actuator[k].dtype == v.dtype and a.actuator[k].shape == v.shape, k
        if v.dtype == bool:
            np.testing.assert_array_equal(a.actuator[k], v, err_msg=k)
        else:
            scale = max(1.0, np.abs(v).max())
            np.testing.assert_allclose(a.actuator[k], v, rtol=0, atol=1e-12 * scale, err_msg=k)
    assert set(a.disturbance_components) == set(b.disturbance_components)
    for k, v in b.disturbance_components.items():
        np.testing.assert_allclose(a.disturbance_components[k], v, rtol=0, atol=1e-15, err_msg=k)


ORBIT = CircularOrbit.from_altitude(500e3)
DISTURBANCES = {
    "none": lambda: None,
    "harmonic": lambda: ConstantHarmonicTorque(),
    "payload": lambda: RotatingPayloadTorque([ROTATING_PAYLOAD_EXAMPLE]),
    "gg+payload": lambda: SumOfDisturbances(
        {
            "gg": GravityGradientTorque(J, ORBIT),
            "payload": RotatingPayloadTorque([ROTATING_PAYLOAD_EXAMPLE]),
        }
    ),  # fmt: skip
}


@pytest.mark.parametrize("dist", sorted(DISTURBANCES))
@pytest.mark.parametrize("friction", [False, True], ids=["plain", "friction-lsb"])
def test_the_compiled_wheel_loop_equals_the_python_loop(monkeypatch, dist, friction):
    """Torque-limited and speed-gated samples: every field, every key of the
    assembly's log (and its derived momentum) and each source's disturbance log."""
    plant, ctrl, ref, x0 = _case(DISTURBANCES[dist](), friction)
    kw = dict(control_period=0.2, log_every=3)
    fast = simulate_fused(monkeypatch, plant, ctrl, ref, x0, 30.0, 0.1, **kw)
    slow = simulate_python_loop(monkeypatch, plant, ctrl, ref, x0, 30.0, 0.1, **kw)
    _assert_same(fast, slow)
    assert slow.actuator["torque_saturated"].any()
    assert slow.actuator["speed_saturated"].any()
    assert ("friction_torque" in fast.actuator) == friction


def test_three_orthogonal_wheels_per_spacecraft_inertias_and_one_spacecraft(monkeypatch):
    for B, per in ((3, True), (1, False)):
        plant, ctrl, ref, x0 = _case(ConstantHarmonicTorque(), True, B, "orthogonal", per)
        fast = simulate_fused(monkeypatch, plant, ctrl, ref, x0, 12.0, 0.05, log_every=1)
        slow = simulate_python_loop(monkeypatch, plant, ctrl, ref, x0, 12.0, 0.05, log_every=1)
        _assert_same(fast, slow)
        assert fast.actuator["wheel_speed"].shape == (fast.n_samples, B, 3)


def _zoo():
    from liecontrol.control import IntrinsicPID, MrpADRC, TerminalSlidingModeSO3

    return {
        "intrinsic-pid": lambda: IntrinsicPID(J, 2.0, 20.0, 0.1, torque_limit=0.2),
        "mrp-adrc": lambda: MrpADRC(J, base="reference"),
        "euler-tsm": lambda: TerminalSlidingModeSO3(J, base="reference", T=20.0),
    }


@pytest.mark.parametrize("name", ["intrinsic-pid", "mrp-adrc", "euler-tsm"])
def test_stateful_and_chart_laws_fly_the_compiled_wheel_loop(monkeypatch, name):
    """Laws with internal state (an integrator, an observer, a chart's memory) reach the wheel
    loop through the same seam as the other actuators'."""
    plant, _, ref, x0 = _case(ConstantHarmonicTorque(), False)
    make = _zoo()[name]
    fast = simulate_fused(monkeypatch, plant, make(), ref, x0, 10.0, 0.1, control_period=0.2)
    slow = simulate_python_loop(monkeypatch, plant, make(), ref, x0, 10.0, 0.1, control_period=0.2)
    _assert_same(fast, slow)


def test_workers_give_the_serial_result_bit_for_bit(monkeypatch):
    plant, ctrl, ref, x0 = _case(ConstantHarmonicTorque(), True, B=5)
    one = simulate_fused(monkeypatch, plant, ctrl, ref, x0, 10.0, 0.1)
    two = simulate_fused(monkeypatch, plant, ctrl, ref, x0, 10.0, 0.1, workers=2)
    for name in ("R", "omega", "u_cmd", "u"):
        np.testing.assert_array_equal(getattr(two, name), getattr(one, name))
    for k, v in one.actuator.items():
        np.testing.assert_array_equal(two.actuator[k], v)


def test_a_subclass_or_momentum_management_keeps_the_python_loop_and_says_so(caplog):
    class MyWheels(ReactionWheelAssembly):
        pass

    plant = Spacecraft(RigidBody(J), MyWheels(_wheels(False).axes))
    ref = ConstantAttitude(np.eye(3))
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, GeometricPD(J, 2.0, 20.0), ref, plant.initial_state(np.eye(3)), 1.0, 0.1)
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1 and "the actuator MyWheels has no compiled kernel" in lines[0]
