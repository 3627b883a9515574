"""The benchmark suite on the JAX route (``run_suite(..., backend="jax")``): a user's controller
that gives only its array law (no compiled kernel) flies it with the numba route's metrics and
verdicts. Skips without JAX (``liecontrol[jax]``)."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from conftest import assert_same_outcomes

from benchmarks.controllers import register, unregister
from benchmarks.runner import run_suite
from benchmarks.scenarios import get_scenario
from liecontrol._array_api import namespace
from liecontrol.control import AttitudeController
from liecontrol.control.array_law import ArrayLaw
from liecontrol.lie import so3

pytest.importorskip("jax")


def _law(k_R, k_Omega, R, omega, R_d):
    """u = −k_R log(R_dᵀR)^∨ − k_Ω ω (regulation); pure (NumPy or JAX)."""
    xp = namespace(R, omega, R_d)
    return -k_R * so3._log_angle_unchecked(xp.swapaxes(R_d, -1, -2) @ R)[0] - k_Omega * omega


class _UserLogPD(AttitudeController):
    """A user's law with an array law and no fused kernel (the numba route runs it in Python)."""

    def __init__(self, k_R: float, k_Omega: float) -> None:
        self.k_R, self.k_Omega = k_R, k_Omega

    def reset(self, t0, batch_size):  # noqa: ANN001, ANN201
        pass

    def command(self, t, state, reference):  # noqa: ANN001, ANN201
        return _law(self.k_R, self.k_Omega, state.R, state.omega, np.asarray(reference.R_d))

    def array_law(self) -> ArrayLaw:
        def step(k_R, k_Omega, s, R, omega, R_d, omega_d, omega_dot_d, T):  # noqa: ANN001
            return _law(k_R, k_Omega, R, omega, R_d), s, {}

        return ArrayLaw(self.k_R, self.k_Omega, (), step)


def test_a_user_array_law_without_kernel_flies_the_suite_jax_route(caplog):
    register("user-log-pd", lambda ctx: _UserLogPD(2.0, 40.0), quick=False, replace=True)
    try:
        scs = [get_scenario("slew-90").with_duration(30.0)]
        a = run_suite(scs, ["user-log-pd"], members=2, executor="serial", progress=False)
        with caplog.at_level(logging.INFO, logger="benchmarks.runner"):
            b = run_suite(scs, ["user-log-pd"], members=2, executor="serial", progress=False,
                          backend="jax")  # fmt: skip
    finally:
        unregister("user-log-pd")
    assert "ran on the numba loop" not in caplog.text, caplog.text
    assert_same_outcomes(a, b)


def test_every_quick_controller_but_mpc_flies_the_suite_jax_route(caplog):
    """The quick suite's controllers (all but the OSQP MPC, whose solve stays in Python) run
    the JAX route on a quick scenario with the numba route's metrics and verdicts (a dispersed
    batch of two members, each with its own sign hint and inertia); the MPC
    batch stays on the numba loop with its log line."""
    from benchmarks.controllers import quick_controllers

    names = [c for c in quick_controllers() if not c.startswith("mpc")]
    assert len(names) >= 9
    scs = [get_scenario("slew-90").with_duration(40.0)]
    a = run_suite(scs, names, members=3, executor="serial", progress=False)
    with caplog.at_level(logging.INFO, logger="benchmarks.runner"):
        b = run_suite(scs, [*names, "mpc-osqp"], members=3, executor="serial", progress=False,
                      backend="jax")  # fmt: skip
    fell = [line for line in caplog.text.splitlines() if "ran on the numba loop" in line]
    assert fell and all("mpc-osqp" in line for line in fell), fell
    assert_same_outcomes(a, b)


def test_members_with_their_own_references_fly_the_jax_route(caplog):
    """slew-90-planned (a time-varying eigenaxis profile) and slew-tracking (a constant-rate
    target): the dispersed members' references differ (each from its own start), so each
    member flies its own on the JAX route (such a batch kept the numba loop before)."""
    import spacecraft.differentiable as D

    scs = [get_scenario(n).with_duration(30.0) for n in ("slew-90-planned", "slew-tracking")]
    loops = []
    real = D.closed_loop

    def spy(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        loops.append(real(*args, **kwargs))
        return loops[-1]
    a = run_suite(scs, ["geometric-pd-large-angle"], members=2, executor="serial",
                  progress=False)  # fmt: skip
    with caplog.at_level(logging.INFO, logger="benchmarks.runner"):
        try:
            D.closed_loop = spy
            b = run_suite(scs, ["geometric-pd-large-angle"], members=2, executor="serial",
                          progress=False, backend="jax")  # fmt: skip
        finally:
            D.closed_loop = real
    assert "ran on the numba loop" not in caplog.text, caplog.text
    assert len(loops) == 2 and all(lp.member_refs and lp.R_d.shape[0] == 2 for lp in loops)
    assert_same_outcomes(a, b)


def test_earth_pointing_under_gravity_gradient_flies_the_jax_route(caplog):
    """earth-pointing: an LVLH-tracking reference under gravity gradient + the constant +
    harmonic torque (a SumOfDisturbances read at every stage's attitude) on the JAX route, with
    the numba route's metrics and verdicts."""
    scs = [get_scenario("earth-pointing").with_duration(60.0)]
    a = run_suite(scs, ["geometric-pd-large-angle", "mrp-adrc"], members=2, executor="serial",
                  progress=False)  # fmt: skip
    with caplog.at_level(logging.INFO, logger="benchmarks.runner"):
        b = run_suite(scs, ["geometric-pd-large-angle", "mrp-adrc"], members=2,
                      executor="serial", progress=False, backend="jax")  # fmt: skip
    assert "ran on the numba loop" not in caplog.text, caplog.text
    assert_same_outcomes(a, b)
