"""Liu, Tang & Yu's terminal sliding mode on Euler angles on the JAX route: the Euler adapter's
pure conversion composed with the law's pure step (the functions ``command`` calls), the
prescribed-time shaping polynomial's initial conditions captured at the first sample and carried
by the scan; the fused numba loop's trajectories, torques and diagnostics before and after the
prescribed time T, finite gradients, the registry's configuration on the suite's JAX route.
Skips without JAX (``liecontrol[jax]``)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_same_outcomes, suite_on_both_routes

from liecontrol.control.reference import ConstantAttitude
from liecontrol.control.terminal_sliding_mode import TerminalSlidingModeSO3
from liecontrol.lie import so3
from spacecraft import RigidBody, Spacecraft, simulate
from spacecraft.actuators import IdealTorqueActuator, SgcmgActuator

J0 = np.diag([20.0, 25.0, 30.0])
J0[0, 1] = J0[1, 0] = 0.8
REF = ConstantAttitude(so3.exp(np.array([0.1, -0.2, 0.3])))
KEYS = ("sigma", "e", "edot", "p", "u", "chart_y")


@pytest.fixture
def jax():
    jax = pytest.importorskip("jax")
    with jax.enable_x64(True):
        yield jax


def _starts() -> tuple[np.ndarray, np.ndarray]:
    """179.9° about the yaw axis (the Euler error's a1 at the wrap), 60° and 5° about random
    axes (away from pitch ±90°), with rates."""
    rng = np.random.default_rng(3)
    ax = np.vstack([[0.0, 0.0, 1.0], [0.3, 0.2, 0.93], rng.normal(size=3)])
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    R0 = REF.R_d @ so3.exp(ax * np.radians([179.9, 60.0, 5.0])[:, None])
    return R0, rng.normal(size=(3, 3)) * 0.003


@pytest.mark.parametrize("actuator", ["ideal", "sgcmg"])
def test_tsm_equals_fused_simulate_before_and_after_T(actuator, jax):
    from spacecraft.differentiable import closed_loop

    ctrl = TerminalSlidingModeSO3(J0, T=30.0, C1=0.2, C2=1.0, K=0.02, base="reference")
    act = SgcmgActuator() if actuator == "sgcmg" else IdealTorqueActuator(max_torque=0.3)
    plant = Spacecraft(RigidBody(J0), act)
    R0, w0 = _starts()
    want = simulate(plant, ctrl, REF, plant.initial_state(R0, w0), 50.0, 0.1,
                    control_period=0.2, log_every=2)  # fmt: skip
    run = closed_loop(plant, ctrl, REF, 50.0, 0.1, 0.2).run(R0, w0)
    np.testing.assert_allclose(run.R, want.R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.u_cmd, want.u_cmd, rtol=0, atol=1e-11)
    for k in KEYS:
        np.testing.assert_allclose(run.controller[k], want.controller[k], rtol=0, atol=1e-11,
                                   err_msg=k)  # fmt: skip
    p = want.controller["p"]
    assert np.abs(p[0]).max() > 1.0 and np.abs(p[-1]).max() == 0.0  # shaped, then past T
    if actuator == "ideal":
        assert (np.abs(want.u_cmd).max(axis=-1) > 0.3).any()  # saturating samples


@pytest.mark.parametrize("angle_deg", [0.0, 179.9])
def test_tsm_gradients_finite_from_the_reference_and_near_pi(angle_deg, jax):
    from spacecraft.differentiable import closed_loop

    ctrl = TerminalSlidingModeSO3(J0, T=20.0, C1=0.2, C2=1.0, K=0.02, base="reference")
    plant = Spacecraft(RigidBody(J0), IdealTorqueActuator(max_torque=0.3))
    R0 = REF.R_d @ so3.exp(np.radians(angle_deg) * np.array([[0.0, 0.0, 1.0]]))
    loop = closed_loop(plant, ctrl, REF, 30.0, 0.1, 0.2)
    assert set(loop.params) == {"K", "delta0", "delta1"}
    v, g1, g2 = loop.value_and_grad(loop.k_R, loop.k_Omega, R0, np.zeros((1, 3)),
                                    effort_weight=0.01)  # fmt: skip
    assert np.isfinite(v) and np.isfinite(g1).all() and np.isfinite(g2).all()
    if angle_deg > 0.0:
        assert np.abs(g1).max() > 0.0


def test_tsm_gradient_matches_central_differences(jax):
    from spacecraft.differentiable import closed_loop

    ctrl = TerminalSlidingModeSO3(J0, T=10.0, C1=0.2, C2=1.0, K=0.02, base="reference")
    plant = Spacecraft(RigidBody(J0), IdealTorqueActuator())
    R0, w0 = _starts()
    loop = closed_loop(plant, ctrl, REF, 10.0, 0.1, 0.2)
    C1, C2 = np.array(loop.k_R), np.array(loop.k_Omega)
    _, g1, _ = loop.value_and_grad(C1, C2, R0[1:], w0[1:], effort_weight=0.01)
    E = np.zeros((3, 3))
    E[0, 0] = E[2, 2] = 1.0  # a symmetric direction
    h = 1e-6
    up = loop.value_and_grad(C1 + h * E, C2, R0[1:], w0[1:], effort_weight=0.01)[0]
    dn = loop.value_and_grad(C1 - h * E, C2, R0[1:], w0[1:], effort_weight=0.01)[0]
    np.testing.assert_allclose(np.sum(g1 * E), (up - dn) / (2 * h), rtol=1e-5)


def test_registry_tsm_flies_the_suite_jax_route(jax, caplog):
    from benchmarks.scenarios import get_scenario

    scs = [get_scenario("slew-90").with_duration(40.0)]
    a, b = suite_on_both_routes(scs, ["euler-tsm"], caplog)
    assert "ran on the numba loop" not in caplog.text, caplog.text
    assert_same_outcomes(a, b)


def test_a_swapped_law_is_refused_naming_it(jax):
    from liecontrol.control.terminal_sliding_mode import TerminalSlidingMode
    from spacecraft.differentiable import closed_loop

    class OwnTSM(TerminalSlidingMode):
        def __call__(self, t, s):  # noqa: ANN001, ANN204
            return super().__call__(t, s)

    ctrl = TerminalSlidingModeSO3(J0, T=10.0, base="reference")
    ctrl.law = OwnTSM(J0, 10.0)
    plant = Spacecraft(RigidBody(J0), IdealTorqueActuator())
    with pytest.raises(ValueError, match=r"^controller\.law: OwnTSM overrides __call__"):
        closed_loop(plant, ctrl, REF, 10.0, 0.1, 0.2)
