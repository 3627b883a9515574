"""Wie & Lu's rate-limited eigenaxis law on the JAX route: its pure formula
(``rate_limited_eigenaxis_torque``, the one ``command`` calls) equals the fused numba loop from
179.9° with the rate limit and the torque box active, its gradients are finite at the identity,
near and at π and across the saturations, and the registry's configuration flies the suite's
JAX route with the numba run's metrics. Skips without JAX (``liecontrol[jax]``)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_same_outcomes, suite_on_both_routes

from liecontrol.control.eigenaxis import RateLimitedEigenaxis, wie_lu_gains
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import RigidBody, Spacecraft, simulate
from spacecraft.actuators import IdealTorqueActuator, SgcmgActuator

J0 = np.diag([20.0, 25.0, 30.0])
J0[0, 1] = J0[1, 0] = 0.8


@pytest.fixture
def jax():
    jax = pytest.importorskip("jax")
    with jax.enable_x64(True):
        yield jax


def _case(actuator: str, u_max):
    ctrl = RateLimitedEigenaxis(J0, max_rate=0.02, u_max=u_max, **wie_lu_gains(0.1, 0.9))
    act = SgcmgActuator() if actuator == "sgcmg" else IdealTorqueActuator(max_torque=u_max)
    plant = Spacecraft(RigidBody(J0), act)
    ref = ConstantAttitude(so3.exp(np.array([0.1, -0.2, 0.3])))
    rng = np.random.default_rng(11)
    ax = rng.normal(size=(3, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    R0 = ref.R_d @ so3.exp(ax * np.radians([179.9, 60.0, 5.0])[:, None])
    w0 = rng.normal(size=(3, 3)) * 0.005
    return plant, ctrl, ref, R0, w0


@pytest.mark.parametrize(("actuator", "u_max"), [("ideal", 0.05), ("sgcmg", None)])
def test_eigenaxis_equals_fused_simulate(actuator, u_max, jax):
    from spacecraft.differentiable import closed_loop

    plant, ctrl, ref, R0, w0 = _case(actuator, u_max)
    want = simulate(plant, ctrl, ref, plant.initial_state(R0, w0), 60.0, 0.1,
                    control_period=0.2, log_every=2)  # fmt: skip
    run = closed_loop(plant, ctrl, ref, 60.0, 0.1, 0.2).run(R0, w0)
    np.testing.assert_allclose(run.R, want.R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.u_cmd, want.u_cmd, rtol=0, atol=1e-11)
    np.testing.assert_allclose(run.controller["attitude_error_rad"],
                               want.controller["attitude_error_rad"], atol=1e-11)  # fmt: skip
    np.testing.assert_array_equal(run.controller["rate_saturated"],
                                  want.controller["rate_saturated"] > 0)  # fmt: skip
    assert want.controller["rate_saturated"].any()  # the coast is flown
    if u_max is not None:  # the torque box scales the feedback in some samples
        lim = np.abs(want.u_cmd).max(axis=-1)
        assert (np.abs(lim - u_max) < 1e-3 * u_max).any()  # (the feed-forward is small)


@pytest.mark.parametrize("angle_deg", [0.0, 179.9, 180.0])
def test_eigenaxis_gradient_finite_from_identity_and_at_pi(angle_deg, jax):
    from spacecraft.differentiable import closed_loop

    plant, ctrl, ref, _, _ = _case("ideal", 0.4)
    R0 = ref.R_d @ so3.exp(np.radians(angle_deg) * np.array([[0.0, 0.6, 0.8]]))
    loop = closed_loop(plant, ctrl, ref, 20.0, 0.1, 0.2)
    v, gk, gc = loop.value_and_grad(ctrl.k, ctrl.c, R0, np.zeros((1, 3)), effort_weight=0.01)
    assert np.isfinite([v, gk, gc]).all()
    if angle_deg > 0.0:
        assert gk != 0.0 and gc != 0.0


def test_eigenaxis_gradient_matches_central_differences(jax):
    from spacecraft.differentiable import closed_loop

    plant, ctrl, ref, R0, w0 = _case("ideal", 0.4)
    loop = closed_loop(plant, ctrl, ref, 10.0, 0.1, 0.2)
    v, gk, gc = loop.value_and_grad(ctrl.k, ctrl.c, R0, w0, effort_weight=0.01)
    h = 1e-6
    for i, g in ((0, gk), (1, gc)):
        e = np.array([h, 0.0]) if i == 0 else np.array([0.0, h])
        up = loop.value_and_grad(ctrl.k + e[0], ctrl.c + e[1], R0, w0, effort_weight=0.01)[0]
        dn = loop.value_and_grad(ctrl.k - e[0], ctrl.c - e[1], R0, w0, effort_weight=0.01)[0]
        np.testing.assert_allclose(g, (up - dn) / (2 * h), rtol=1e-5)


def test_registry_eigenaxis_flies_the_suite_jax_route(jax, caplog):
    from benchmarks.scenarios import get_scenario

    scs = [get_scenario("slew-90").with_duration(40.0)]
    a, b = suite_on_both_routes(scs, ["eigenaxis-rate-limited"], caplog)
    assert "ran on the numba loop" not in caplog.text
    assert_same_outcomes(a, b)


def test_pure_formula_equals_the_compiled_kernel_near_0_and_pi():
    """The numpy route (the pure formula) against the compiled kernel on a dense grid of
    angles about the identity, the coast threshold and π (no JAX needed)."""
    from liecontrol._kernels.eigenaxis import rate_limited_eigenaxis_law

    ctrl = RateLimitedEigenaxis(J0, max_rate=0.02, u_max=0.4, **wie_lu_gains(0.1, 0.9))
    kern = ctrl.fused_kernel(1)
    rng = np.random.default_rng(5)
    th0 = ctrl.coast_threshold
    angles = np.concatenate([np.geomspace(1e-12, 1e-3, 20), th0 + np.linspace(-1e-6, 1e-6, 21),
                             np.pi - np.geomspace(1e-12, 1e-2, 20), [np.pi]])  # fmt: skip
    ax = rng.normal(size=(angles.size, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    R = so3.exp(ax * angles[:, None])
    w = rng.normal(size=(angles.size, 3)) * 0.01
    ref = ConstantAttitude(np.eye(3))(0.0)
    from liecontrol.control.base import AttitudeState

    ctrl.reset(0.0, angles.size)
    u = ctrl.command(0.0, AttitudeState(R, w), ref)
    d = ctrl.diagnostics()
    for b in range(angles.size):
        M, dg = np.empty(3), np.empty(2)
        rate_limited_eigenaxis_law(0.0, R[b], w[b], np.eye(3), np.zeros(3), np.zeros(3),
                                   kern.params, np.zeros(0), M, dg)  # fmt: skip
        np.testing.assert_allclose(u[b], M, rtol=0, atol=1e-13)
        assert d["rate_saturated"][b] == dg[0]
        np.testing.assert_allclose(d["attitude_error_rad"][b], dg[1], rtol=0, atol=1e-13)
