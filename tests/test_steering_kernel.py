"""A user's steering law in the compiled loop (:mod:`spacecraft.steering_kernel`): the fused
loop equals the Python loop (which runs the law's own ``steer``), the seam carries a built-in
formula bit for bit, a subclass that overrides ``steer`` keeps the Python loop with its log
line, and a malformed kernel is refused by name when the plant is built."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from liecontrol._jit import JIT_ENABLED
from liecontrol.control import GeometricPD, gains_from_bandwidth
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import RigidBody, SgcmgActuator, SgcmgPyramid, Spacecraft
from spacecraft import _kernels as K
from spacecraft import simulator as simulator_module
from spacecraft._fused import hold_steps
from spacecraft.simulator import simulate
from spacecraft.steering import PINV_EPS, SingularityRobust, SteeringLaw
from spacecraft.steering_kernel import SteeringKernel

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the compiled loop needs numba")

from numba import njit  # noqa: E402  (numba is there when the module runs)

J = np.diag([1200.0, 1000.0, 800.0])
J[0, 1] = J[1, 0] = 30.0


@njit(cache=False)
def _damped(t, A, hdot, delta, params, out):  # noqa: ANN001, ANN202
    """δ̇ = Aᵀ(AAᵀ + λ I)⁻¹ ḣ, λ = params[0] + params[1]·sin(t) (a clock-dependent damping
    shows the time the loop hands over)."""
    lam = params[0] + params[1] * np.sin(t)
    M = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(A.shape[1]):
                s += A[i, k] * A[j, k]
            M[i, j] = s
        M[i, i] += lam
    y = np.linalg.solve(M, hdot)
    for i in range(A.shape[1]):
        out[i] = A[0, i] * y[0] + A[1, i] * y[1] + A[2, i] * y[2]


class Damped(SteeringLaw):
    """The Python law (its own numpy formula): the Python loop's reference."""

    def __init__(self, lam: float, wobble: float = 0.0) -> None:
        self.lam, self.wobble = float(lam), float(wobble)

    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None):  # noqa: ANN001, ANN201
        lam = self.lam + self.wobble * np.sin(t)
        M = np.einsum("...ik,...jk->...ij", A, A) + lam * np.eye(3)
        y = np.linalg.solve(M, hdot_cmd[..., None])[..., 0]
        return np.einsum("...ki,...k->...i", A, y)


class FastDamped(Damped):
    """The same law with its kernel (keeps ``steer``: the kernel speaks for it)."""

    def fused_kernel(self, cluster):  # noqa: ANN001, ANN201
        return SteeringKernel(_damped, np.array([self.lam, self.wobble]))


@njit
def _sr_wrapped(t, A, hdot, delta, params, out):  # noqa: ANN001, ANN202
    K.steer_regularised(K.STEER_SR, params, t, A, hdot[0], hdot[1], hdot[2], out)


class WrappedSR(SingularityRobust):
    """The built-in SR formula handed over through the seam (no kernel code of its own)."""

    def fused_kernel(self, cluster):  # noqa: ANN001, ANN201
        p = np.array([self.lambda0, self.mu, PINV_EPS, 0.0, 0.0, 0.0, 0.0, 0.0])
        return SteeringKernel(_sr_wrapped, p)


def _plant(law: SteeringLaw) -> Spacecraft:
    return Spacecraft(
        RigidBody(J), SgcmgActuator(SgcmgPyramid(h0=300.0, gimbal_rate_limit=0.2), law)
    )


def _starts(B: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    ax = rng.normal(size=(B, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    angles = np.radians([179.9, 90.0, 20.0])[:B]
    return so3.exp(ax * angles[:, None]), rng.normal(size=(B, 3)) * 0.01


def _run(plant: Spacecraft, B: int, monkeypatch, fused: bool):  # noqa: ANN001, ANN202
    kR, kW = gains_from_bandwidth(J, 0.3, 0.9)
    ctrl = GeometricPD(J, kR, kW)
    R0, w0 = _starts(B)
    ref = ConstantAttitude(np.eye(3))
    ran = []
    real = simulator_module.run_fused

    def spy(*a, **k):  # noqa: ANN002, ANN003, ANN202
        out = real(*a, **k)
        ran.append(out is not None)
        return out

    with monkeypatch.context() as m:
        m.setattr(simulator_module, "run_fused", spy)
        if not fused:
            m.setattr(simulator_module, "fused_supported", lambda *a, **k: None)
        res = simulate(plant, ctrl, ref, plant.initial_state(R0, w0), 60.0, 0.05,
                       control_period=0.1)  # fmt: skip
    assert ran == ([True] if fused else [])
    return res


@pytest.mark.parametrize("B", [1, 3])
def test_a_user_steering_kernel_flies_the_fused_loop_equal_to_its_python_law(B, monkeypatch):
    plant = _plant(FastDamped(5.0, 2.0))
    assert plant._kernel_plan is not None and plant._kernel_plan.steer == K.STEER_KERNEL
    fast = _run(plant, B, monkeypatch, fused=True)
    slow = _run(_plant(Damped(5.0, 2.0)), B, monkeypatch, fused=False)
    for name in ("R", "omega", "u_cmd", "u"):
        a, b = getattr(fast, name), getattr(slow, name)
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(b).max()))
    for name in ("delta", "delta_dot"):
        np.testing.assert_allclose(fast.actuator[name], slow.actuator[name], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fast.actuator["saturated"], slow.actuator["saturated"])
    assert fast.actuator["saturated"].any()  # the rate limit scales the kernel's rates too
    assert so3.distance(fast.R[-1], np.eye(3)).max() < np.radians(30.0)


def test_the_seam_carries_a_built_in_formula_bit_for_bit(monkeypatch):
    """The SR kernel handed over as a user's kernel equals the built-in SR code in the fused
    loop and in ``hold_steps`` (the RL environments' stepper): the pointer, its arguments and
    the rate limit are the same path."""
    own = _run(_plant(SingularityRobust()), 3, monkeypatch, fused=True)
    user = _plant(WrappedSR())
    seam = _run(user, 3, monkeypatch, fused=True)
    np.testing.assert_array_equal(seam.R, own.R)
    np.testing.assert_array_equal(seam.actuator["delta_dot"], own.actuator["delta_dot"])
    R0, w0 = _starts(3)
    x0 = user.initial_state(R0, w0).packed()
    u = np.array([[50.0, -20.0, 10.0], [0.0, 80.0, 0.0], [-30.0, 0.0, 60.0]])
    a = hold_steps(user._kernel_plan, 20, 0.0, 0.05, R0, x0, u)
    b = hold_steps(_plant(SingularityRobust())._kernel_plan, 20, 0.0, 0.05, R0, x0, u)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def test_a_subclass_overriding_steer_keeps_the_python_loop_and_says_so(monkeypatch, caplog):
    class Tweaked(FastDamped):
        def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None):  # noqa: ANN001, ANN202
            return 0.5 * super().steer(A, hdot_cmd, delta, t, cluster)

    plant = _plant(Tweaked(5.0))
    assert plant._kernel_plan is None
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        _run(plant, 1, monkeypatch, fused=False)
        simulate(plant, GeometricPD(J, 10.0, 100.0), ConstantAttitude(np.eye(3)),
                 plant.initial_state(np.eye(3)), 1.0, 0.1)  # fmt: skip
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1 and "steering Tweaked overrides steer() in Tweaked" in lines[0]
    assert "FastDamped.fused_kernel()" in lines[0]


def test_a_law_without_kernel_is_named_in_the_log_line(caplog):
    plant = _plant(Damped(5.0))
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, GeometricPD(J, 10.0, 100.0), ConstantAttitude(np.eye(3)),
                 plant.initial_state(np.eye(3)), 1.0, 0.1)  # fmt: skip
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1
    assert "steering Damped has no compiled kernel (no fused_kernel method)" in lines[0]


@njit
def _four_args(t, A, hdot, out):  # noqa: ANN001, ANN202
    out[:] = 0.0


@njit
def _nan_rates(t, A, hdot, delta, params, out):  # noqa: ANN001, ANN202
    for i in range(out.shape[0]):
        out[i] = np.nan


def _with(kernel):  # noqa: ANN001, ANN202
    class Law(Damped):
        def fused_kernel(self, cluster):  # noqa: ANN001, ANN202
            return kernel

    return Law(1.0)


@pytest.mark.parametrize(
    ("kernel", "match"),
    [
        (SteeringKernel(_four_args, np.array([1.0])), r"does not compile for the documented"),
        (SteeringKernel(_damped, np.array([1, 2])), r"params must be a 1-D float64"),
        (SteeringKernel(_damped, np.ones((2, 1))), r"params must be a 1-D float64"),
        (SteeringKernel(_damped, np.array([np.nan, 0.0])), r"params must be finite"),
        (SteeringKernel(_damped.py_func, np.array([1.0, 0.0])), r"must be a numba @njit"),
        (SteeringKernel(_nan_rates, np.array([1.0])), r"non-finite gimbal rate out"),
        ((_damped, np.array([1.0])), r"must return a SteeringKernel or None, got tuple"),
    ],
)
def test_a_malformed_kernel_is_refused_by_name_when_the_plant_is_built(kernel, match):
    with pytest.raises(ValueError, match=r"^steering Law: .*" + match):
        _plant(_with(kernel))
