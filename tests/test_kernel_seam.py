"""The compiled-kernel seam (liecontrol.control.kernel) and the fused loop that composes it.

- a user's @njit law with internal state runs in the fused loop and equals its Python twin;
- a subclass that keeps the law inherits the kernel; one that overrides ``command`` keeps the
  Python loop, and ``simulate`` says so in one log line naming it;
- a malformed kernel (signature, parameters, state, non-finite torque) raises before the loop,
  naming the controller and the argument;
- the built-in controllers go through the same seam, the integral controllers included, and
  equal the Python loop to 1e-12;
- the fused loop imports no controller class, and no module it imports imports it back.
"""

from __future__ import annotations

import ast
import logging
import math
from pathlib import Path

import numpy as np
import pytest

from liecontrol._jit import JIT_ENABLED
from liecontrol.control import GeometricPD, IntegralPD, IntrinsicPID
from liecontrol.control.base import AttitudeController
from liecontrol.control.kernel import ControllerKernel
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import IdealTorqueActuator, RigidBody, SgcmgActuator, SgcmgPyramid, Spacecraft
from spacecraft import simulator as simulator_module
from spacecraft._fused import fused_supported
from spacecraft.simulator import simulate

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the fused loop needs numba")

J = np.array([[150.0, 3.0, -1.0], [3.0, 65.0, 2.0], [-1.0, 2.0, 111.0]])
ROOT = Path(__file__).resolve().parents[1]


def _python_loop(monkeypatch, *args, **kwargs):
    with monkeypatch.context() as m:
        m.setattr(simulator_module, "fused_supported", lambda *a, **k: None)
        return simulate(*args, **kwargs)


def _fused(monkeypatch, *args, **kwargs):
    """``simulate`` that must run (and finish) in the fused loop."""
    ran = []
    real = simulator_module.run_fused

    def spy(*a, **k):
        out = real(*a, **k)
        ran.append(out is not None)
        return out

    with monkeypatch.context() as m:
        m.setattr(simulator_module, "run_fused", spy)
        res = simulate(*args, **kwargs)
    assert ran == [True]
    return res


def _assert_same(a, b, scaled=False):
    """Equal to 1e-12 (relative, or absolute for small values); ``scaled``: absolute 1e-12 of
    each field's largest value (a high-gain observer's torques of a few hundred N·m carry
    rounding of a few 1e-12 N·m into the small later torques)."""

    def close(x, y, scale=None):
        scale = np.abs(y).max(initial=0.0) if scale is None else scale
        atol = 1e-12 * max(1.0, float(scale)) if scaled else 1e-12
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=atol)

    for name in ("t", "R", "omega", "R_d", "omega_d", "u_cmd", "u", "disturbance"):
        # the delivered torque is the (clipped) command: it carries the command's rounding
        ref = b.u_cmd if name == "u" else None
        close(getattr(a, name), getattr(b, name), None if ref is None else np.abs(ref).max())
    for group in ("actuator", "controller"):
        da, db = getattr(a, group), getattr(b, group)
        assert sorted(da) == sorted(db), group
        for k in da:
            assert da[k].dtype == db[k].dtype and da[k].shape == db[k].shape, (group, k)
            close(da[k], db[k])


def _setup(B=3, max_torque=2.0, seed=3):
    rng = np.random.default_rng(seed)
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(max_torque=max_torque))
    ref = ConstantAttitude(so3.random(rng, (B,)))
    x0 = plant.initial_state(np.eye(3), 0.05 * rng.normal(size=(B, 3)))
    return plant, ref, x0


# ------------------------------------------------------------------ a user's law with a state
if JIT_ENABLED:
    from numba import njit

    @njit
    def user_pi_law(t, R, w, R_d, w_d, dw_d, params, state, u_out, diag_out):
        """PD + integral of e = ½ vee(R_dᵀR − RᵀR_d); state = (has t_prev, t_prev, z (3))."""
        kp, kd, ki = params[0], params[1], params[2]
        E = R_d.T @ R  # (3, 3) C-contiguous arrays: numpy's operators work in the law
        e0 = 0.5 * (E[2, 1] - E[1, 2])
        e1 = 0.5 * (E[0, 2] - E[2, 0])
        e2 = 0.5 * (E[1, 0] - E[0, 1])
        if state[0] != 0.0:
            dt = t - state[1]
            state[2] += dt * e0
            state[3] += dt * e1
            state[4] += dt * e2
        state[0] = 1.0
        state[1] = t
        u_out[0] = -kp * e0 - kd * w[0] - ki * state[2]
        u_out[1] = -kp * e1 - kd * w[1] - ki * state[3]
        u_out[2] = -kp * e2 - kd * w[2] - ki * state[4]
        diag_out[0] = state[2]
        diag_out[1] = state[3]
        diag_out[2] = state[4]


class UserPI(AttitudeController):
    """The same law in numpy (the Python twin), with the kernel through the public seam."""

    def __init__(self, kp=20.0, kd=80.0, ki=0.5, law=None, params=None, state=None):
        self.kp, self.kd, self.ki = kp, kd, ki
        self.law, self.params, self.state = law, params, state

    def reset(self, t0, batch_size):
        self.z = np.zeros((batch_size, 3))
        self.t_prev = None

    def command(self, t, state, reference):
        E = np.swapaxes(np.broadcast_to(reference.R_d, state.R.shape), -1, -2) @ state.R
        e = 0.5 * np.stack(
            [E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0], E[:, 1, 0] - E[:, 0, 1]], axis=-1
        )
        if self.t_prev is not None:
            self.z = self.z + (t - self.t_prev) * e
        self.t_prev = t
        return -self.kp * e - self.kd * state.omega - self.ki * self.z

    def diagnostics(self):
        return {"z": self.z.copy()}

    def fused_kernel(self, batch_size, control_period):
        state = np.zeros((batch_size, 5)) if self.state is None else self.state
        params = np.array([self.kp, self.kd, self.ki]) if self.params is None else self.params

        def finish(st, diag):
            self.z = st[:, 2:5].copy()
            self.t_prev = float(st[0, 1])

        return ControllerKernel(
            user_pi_law if self.law is None else self.law, params, state, 3,
            diagnostics=lambda rows: {"z": rows[..., 0:3].copy()}, finish=finish,
        )  # fmt: skip


def test_user_njit_law_with_internal_state_equals_its_python_twin(monkeypatch):
    plant, ref, x0 = _setup()
    args = (plant, UserPI(), ref, x0, 6.0, 0.05)
    kw = {"control_period": 0.1, "log_every": 3}
    assert fused_supported(plant, args[1], [], None, False, batch_size=3) is not None
    fast = _fused(monkeypatch, *args, **kw)
    z_fast = args[1].z.copy()
    slow = _python_loop(monkeypatch, *args, **kw)
    _assert_same(fast, slow)
    np.testing.assert_allclose(z_fast, args[1].z, rtol=1e-12, atol=1e-15)
    assert np.abs(z_fast).max() > 0.0  # the integrator state was carried


class _Sub(GeometricPD):
    """Keeps the law: inherits the kernel."""


class _Override(GeometricPD):
    """Changes the law in Python: must not get its parent's kernel."""

    def command(self, t, state, reference):
        return 0.5 * super().command(t, state, reference)


def test_subclass_inherits_the_kernel_and_an_override_keeps_the_python_loop(monkeypatch, caplog):
    plant, ref, x0 = _setup(B=1)
    assert fused_supported(plant, _Sub(J, 10.0, 60.0), [], None, False) is not None
    reasons: list[str] = []
    over = _Override(J, 10.0, 60.0)
    assert fused_supported(plant, over, [], None, False, reasons=reasons) is None
    assert "_Override" in reasons[0] and "command" in reasons[0]
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        res = simulate(plant, over, ref, x0, 2.0, 0.05)
    lines = [r for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1 and "_Override" in lines[0].getMessage()
    base = simulate(plant, GeometricPD(J, 10.0, 60.0), ref, x0, 2.0, 0.05)
    np.testing.assert_allclose(res.u_cmd[0], 0.5 * base.u_cmd[0], rtol=1e-12)
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, _Sub(J, 10.0, 60.0), ref, x0, 2.0, 0.05)
    assert not [r for r in caplog.records if r.name == "spacecraft.simulator"]


def test_a_controller_without_a_kernel_says_so_once(caplog):
    class Plain(AttitudeController):
        def reset(self, t0, batch_size):
            pass

        def command(self, t, state, reference):
            return -10.0 * state.omega

    plant, ref, x0 = _setup(B=2)
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, Plain(), ref, x0, 1.0, 0.05)
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1 and "Plain" in lines[0]


def test_an_unbatched_controller_is_named_in_the_log_line(caplog):
    class OneAtATime(AttitudeController):
        batched = False

        def reset(self, t0, batch_size):
            pass

        def command(self, t, state, reference):
            return -10.0 * state.omega

    plant, ref, x0 = _setup(B=2)
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, OneAtATime(), ref, x0, 0.5, 0.05)
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1 and "OneAtATime" in lines[0] and "batched = False" in lines[0]


# ------------------------------------------------------------------ bad kernels, in words
if JIT_ENABLED:

    @njit
    def _three_args(t, R, w):
        return None

    @njit
    def _typing_error(t, R, w, R_d, w_d, dw_d, params, state, u_out, diag_out):
        M = np.linalg.inv(params)  # params is 1-D: numba cannot type this
        u_out[0] = M[0, 0]

    @njit
    def _nan_law(t, R, w, R_d, w_d, dw_d, params, state, u_out, diag_out):
        u_out[0] = math.nan
        u_out[1] = 0.0
        u_out[2] = 0.0


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"law": "_three_args"}, ["UserPI", "signature"]),
        ({"law": "_typing_error"}, ["UserPI", "_typing_error", "inv", "2-D"]),
        ({"law": "plain"}, ["UserPI", "law", "@njit"]),
        ({"law": "_nan_law"}, ["UserPI", "non-finite torque"]),
        ({"params": np.array([1, 2, 3])}, ["UserPI", "params", "float64"]),
        ({"params": np.ones((3, 1))}, ["UserPI", "params", "shape"]),
        ({"params": np.array([1.0, np.inf, 0.0])}, ["UserPI", "params", "finite"]),
        ({"state": np.zeros((2, 5))}, ["UserPI", "state", "shape"]),
        ({"state": [[0.0] * 5] * 3}, ["UserPI", "state", "array"]),
    ],
)
def test_a_malformed_kernel_raises_naming_the_controller_and_the_argument(kwargs, words):
    plant, ref, x0 = _setup()
    law = kwargs.get("law")
    if law is not None:
        kwargs = dict(kwargs, law={"plain": user_pi_law.py_func}.get(law) or globals()[law])
    with pytest.raises(ValueError) as info:
        simulate(plant, UserPI(**kwargs), ref, x0, 1.0, 0.05)
    for w in words:
        assert w in str(info.value), (w, str(info.value))


def test_a_builtin_law_that_fails_at_the_first_sample_gives_its_own_error():
    """The funnel cannot contain a 180° error: the kernel's NaN torque at the first sample is
    explained by the controller's own Python route (its message), not a generic one."""
    from liecontrol.control import PrescribedPerformance

    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    ref = ConstantAttitude(so3.exp(np.array([0.0, 0.0, np.pi])))
    x0 = plant.initial_state(np.eye(3))
    with pytest.raises(ValueError, match="funnel infeasible"):
        simulate(plant, PrescribedPerformance(J, 0.05, 0.2), ref, x0, 1.0, 0.1)


# ------------------------------------------------------------------ built-ins through the seam
@pytest.mark.parametrize(
    "make",
    [
        lambda: IntrinsicPID(J, 20.0, 90.0, 2.0, torque_limit=0.6, integral_limit=0.3),
        lambda: IntrinsicPID(J, [20.0, 15.0, 25.0], 90.0, 2.0, connection="levi_civita"),
        lambda: IntrinsicPID(J, 20.0, 90.0, 2.0, error="trace", torque_limit=[0.5, 0.8, 0.6]),
        lambda: IntegralPD(J, 20.0, 90.0, 4.0, c=0.2, torque_limit=0.5, conditional=False),
        lambda: IntegralPD(J, 20.0, 90.0, 4.0, c=0.2, torque_limit=0.5, integral_limit=0.2),
    ],
)
def test_integral_controllers_in_the_fused_loop_equal_the_python_loop(make, monkeypatch):
    plant, ref, x0 = _setup(max_torque=0.7)
    ctrl = make()
    assert fused_supported(plant, ctrl, [], None, False, batch_size=3) is not None
    kw = {"control_period": 0.1, "log_every": 2}
    fast = _fused(monkeypatch, plant, ctrl, ref, x0, 15.0, 0.05, **kw)
    z_fast = ctrl.z.copy()
    slow = _python_loop(monkeypatch, plant, ctrl, ref, x0, 15.0, 0.05, **kw)
    _assert_same(fast, slow)
    np.testing.assert_allclose(z_fast, ctrl.z, rtol=1e-12, atol=1e-14)
    flags = slow.controller["saturated"]
    if ctrl.torque_limit is not None:
        assert flags.any()  # the anti-windup branches ran


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"rho0": 0.95, "k1": 0.2, "k2": 0.5, "kc": 0.3, "z_max": 0.9},
        {"q_min": 0.5},
    ],
)
def test_prescribed_performance_in_the_fused_loop_equals_the_python_loop(kw, monkeypatch):
    from liecontrol.control import PrescribedPerformance

    plant, ref, x0 = _setup(max_torque=5.0)
    ctrl = PrescribedPerformance(J, 0.05, 0.2, **kw)
    args = (plant, ctrl, ref, x0, 15.0, 0.05)  # short: the saturated loop amplifies rounding
    fast = _fused(monkeypatch, *args, control_period=0.1)
    rho0 = ctrl.rho0.copy()
    slow = _python_loop(monkeypatch, *args, control_period=0.1)
    _assert_same(fast, slow)
    np.testing.assert_allclose(rho0, ctrl.rho0, rtol=1e-12)


@pytest.mark.parametrize(
    "kw",
    [
        {"gamma_k": 0.5, "gamma_beta": 0.05, "beta_max": 0.2, "max_torque": 0.6},
        {"gamma_k": 2.0, "gamma_beta": 0.5, "sigma": 0.05, "k_max": 2.0},
        {"gamma_k": 2.0, "gamma_beta": 0.5, "sigma": 0.05, "k_max": 2.0, "adaptive_sigma": True},
        {},
    ],
)
def test_fault_tolerant_law_in_the_fused_loop_equals_the_python_loop(kw, monkeypatch):
    from liecontrol.control.fault_tolerant import AdaptiveFaultTolerantSO3

    plant, ref, x0 = _setup(max_torque=5.0)
    ctrl = AdaptiveFaultTolerantSO3(J, 8.0 * J, 0.3, **kw)
    args = (plant, ctrl, ref, x0, 15.0, 0.05)
    fast = _fused(monkeypatch, *args, control_period=0.1, log_every=2)
    k_hat = ctrl.k_hat.copy()
    slow = _python_loop(monkeypatch, *args, control_period=0.1, log_every=2)
    _assert_same(fast, slow)
    np.testing.assert_allclose(k_hat, ctrl.k_hat, rtol=1e-12)
    if "max_torque" in kw:
        assert slow.controller["saturated"].any()


@pytest.mark.parametrize(
    "kw",
    [
        {"error": "trace", "frequencies": (0.3, 0.7), "disturbance_bound": 0.05},
        {"error": "large_angle", "frequencies": (0.2,), "disturbance_bound": 0.02,
         "inertia_bound": 0.01, "G": None, "gamma_theta": 1e4, "gamma_phi": 50.0},
        {"error": "large_angle", "disturbance_bound": 1.0},
        {"error": "log", "frequencies": (0.3,), "disturbance_bound": 0.05},
    ],
)  # fmt: skip
def test_adaptive_law_in_the_fused_loop_equals_the_python_loop(kw, monkeypatch):
    from liecontrol.control import AdaptiveGeometricSO3
    from spacecraft import ConstantHarmonicTorque

    plant = Spacecraft(RigidBody(1.3 * J), IdealTorqueActuator(), ConstantHarmonicTorque(n=0.3))
    rng = np.random.default_rng(11)
    ref = ConstantAttitude(so3.random(rng, (2,)))
    x0 = plant.initial_state(np.eye(3), 0.05 * rng.normal(size=(2, 3)))
    kw = {"gamma_theta": 50.0, "gamma_phi": 5.0, **kw}
    ctrl = AdaptiveGeometricSO3(J, 20.0, 80.0, 0.3, **kw)
    args = (plant, ctrl, ref, x0, 15.0, 0.05)
    fast = _fused(monkeypatch, *args, control_period=0.1, log_every=2)
    theta = ctrl.theta_hat.copy()
    slow = _python_loop(monkeypatch, *args, control_period=0.1, log_every=2)
    _assert_same(fast, slow)
    np.testing.assert_allclose(theta, ctrl.theta_hat, rtol=1e-12)
    if "inertia_bound" in kw:
        assert slow.controller["theta_projected"].any()


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"threshold": 1.0, "eso_init": "zero"},
        {"params_kw": {"beta": 0.25, "K1": [20.0, 25.0, 30.0], "k2": 6.0}},
    ],
)
def test_mrp_adrc_in_the_fused_loop_equals_the_python_loop(kw, monkeypatch):
    from liecontrol.control import ADRCParams, MrpADRC

    kw = dict(kw)
    params = ADRCParams(**kw.pop("params_kw", {}))
    plant, ref, x0 = _setup(max_torque=5.0, seed=7)
    ctrl = MrpADRC(J, params, base="reference", **kw)
    args = (plant, ctrl, ref, x0, 15.0, 0.05)
    fast = _fused(monkeypatch, *args, control_period=0.1, log_every=2)
    z, n_sw = ctrl.law.z.copy(), ctrl.n_switches
    slow = _python_loop(monkeypatch, *args, control_period=0.1, log_every=2)
    _assert_same(fast, slow, scaled=True)
    np.testing.assert_allclose(z, ctrl.law.z, rtol=1e-12, atol=1e-12)
    assert n_sw == ctrl.n_switches


def test_mrp_adrc_shadow_switch_maps_the_observer_like_the_python_loop(monkeypatch):
    """A start near 180° about a tumbling axis: the error MRP crosses |σ| = 1 and the observer
    states are mapped to the shadow set."""
    from liecontrol.control import MrpADRC

    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(max_torque=0.5))
    R_d = so3.exp(np.array([[0.0, 0.0, 3.0], [2.9, 0.0, 0.5]]))
    ref = ConstantAttitude(R_d)
    x0 = plant.initial_state(np.eye(3), np.array([[0.0, 0.0, -0.05], [0.04, 0.0, 0.02]]))
    ctrl = MrpADRC(J, base="reference")
    # 20 s: the switch is at 3.4 s; later the saturated loop amplifies rounding (1e-13 at 24 s)
    args = (plant, ctrl, ref, x0, 20.0, 0.1)
    fast = _fused(monkeypatch, *args, control_period=0.2)
    n_sw = ctrl.n_switches
    slow = _python_loop(monkeypatch, *args, control_period=0.2)
    assert n_sw == ctrl.n_switches and n_sw > 0
    _assert_same(fast, slow, scaled=True)


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"T": 30.0, "C1": [1.0, 2.0, 1.5], "F": 0.1, "D": 0.05},
        {"T": 1.0},  # past T: p = 0
    ],
)
def test_euler_tsm_in_the_fused_loop_equals_the_python_loop(kw, monkeypatch):
    """Short runs: on the sliding surface the sampled switching term chatters, and the loop
    (the Python one too) then amplifies a 1e-15 perturbation ~100× per second."""
    from liecontrol.control import TerminalSlidingModeSO3

    kw = {"T": 20.0, **kw}
    plant, ref, x0 = _setup(max_torque=5.0, seed=5)
    ctrl = TerminalSlidingModeSO3(J, base="reference", **kw)
    args = (plant, ctrl, ref, x0, min(15.0, kw["T"] + 1.0), 0.1)
    fast = _fused(monkeypatch, *args, control_period=0.2, log_every=2)
    init = [a.copy() for a in ctrl.law.initial_conditions]
    slow = _python_loop(monkeypatch, *args, control_period=0.2, log_every=2)
    _assert_same(fast, slow)
    for a, b in zip(init, ctrl.law.initial_conditions, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)


def test_keep_out_pd_in_the_fused_loop_equals_the_python_loop(monkeypatch):
    """A slew of the boresight (body x) past a 25° keep-out cone, and a keep-in cone on body z;
    a start inside the keep-out cone gives the controller's own error."""
    from liecontrol.control.constrained import ConstrainedGeometricPD, KeepInCone, KeepOutCone

    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(max_torque=2.0))
    out = KeepOutCone((1.0, 0.0, 0.0), (np.cos(0.9), np.sin(0.9), 0.1), 25.0)
    keep_in = KeepInCone((0.0, 0.0, 1.0), (0.0, 0.0, 1.0), 80.0)
    ref = ConstantAttitude(so3.exp(np.array([0.0, 0.0, 1.8])))
    x0 = plant.initial_state(np.eye(3), batch=2)
    ctrl = ConstrainedGeometricPD(J, 20.0, 90.0, keep_out=[out], keep_in=[keep_in])
    args = (plant, ctrl, ref, x0, 30.0, 0.1)
    fast = _fused(monkeypatch, *args, control_period=0.2, log_every=2)
    slow = _python_loop(monkeypatch, *args, control_period=0.2, log_every=2)
    _assert_same(fast, slow)
    assert slow.controller["min_slack"].min() < 0.5  # the barrier was active
    bad = plant.initial_state(so3.exp(np.array([0.0, 0.0, 0.9])))
    with pytest.raises(ValueError, match="inside keep-out cone"):
        simulate(plant, ctrl, ref, bad, 1.0, 0.1)


def test_every_builtin_kernel_is_a_controller_kernel():
    from liecontrol.control import (
        AdaptiveGeometricSO3,
        FiniteTimeSO3,
        MrpPD,
        PrescribedPerformance,
        QuaternionPD,
    )
    from liecontrol.control.fault_tolerant import AdaptiveFaultTolerantSO3

    for c in (
        GeometricPD(J, 1.0, 2.0),
        MrpPD(J, 1.0, 2.0),
        QuaternionPD(J, 1.0, 2.0),
        FiniteTimeSO3(J, 1.0, 0.5, 1.0),
        IntrinsicPID(J, 1.0, 2.0, 0.1),
        IntegralPD(J, 1.0, 2.0, 0.1),
        PrescribedPerformance(J, 0.05, 0.1),
        AdaptiveFaultTolerantSO3(J, 1.0, 0.3),
        AdaptiveGeometricSO3(J, 1.0, 2.0, 0.3, 1.0, 1.0, disturbance_bound=1.0),
    ):
        c.reset(0.0, 2)
        spec = c.fused_kernel(2, 0.1)
        assert isinstance(spec, ControllerKernel), type(c).__name__
        assert spec.state.shape[0] == 2


def test_saturation_flags_of_the_fused_loop_equal_the_python_loop(monkeypatch):
    """One saturation test (spacecraft._kernels.ideal_command) for the fused loop and the held
    substeps: the flags equal the Python loop's, with the limit reached."""
    plant, ref, x0 = _setup(max_torque=0.3)
    ctrl = GeometricPD(J, 30.0, 120.0)
    fast = _fused(monkeypatch, plant, ctrl, ref, x0, 10.0, 0.05)
    slow = _python_loop(monkeypatch, plant, ctrl, ref, x0, 10.0, 0.05)
    np.testing.assert_array_equal(fast.actuator["saturated"], slow.actuator["saturated"])
    assert slow.actuator["saturated"].sum() > 10


def test_sgcmg_plant_with_a_user_law_equals_the_python_loop(monkeypatch):
    plant = Spacecraft(RigidBody(J), SgcmgActuator(SgcmgPyramid(h0=5.0)))
    rng = np.random.default_rng(5)
    ref = ConstantAttitude(so3.random(rng, (2,)))
    x0 = plant.initial_state(np.eye(3), batch=2)
    args = (plant, UserPI(2.0, 20.0, 0.05), ref, x0, 4.0, 0.05)
    _assert_same(_fused(monkeypatch, *args), _python_loop(monkeypatch, *args))


# ------------------------------------------------------------------ the import structure
def _imports(path: Path) -> set[str]:
    """Sibling modules of the spacecraft package that a module imports (anywhere in it)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level == 1:
                out.add(mod.split(".")[0] if mod else "")
                if not mod:
                    out.update(a.name for a in node.names)
            elif mod.startswith("spacecraft."):
                out.add(mod.split(".")[1])
    return out


def test_the_fused_loop_imports_no_controller_class_and_no_circle():
    src = (ROOT / "spacecraft" / "_fused.py").read_text()
    tree = ast.parse(src)
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("liecontrol"):
            allowed = ("liecontrol._jit", "liecontrol._validation", "liecontrol.control")
            assert node.module in allowed, node.module
            if node.module == "liecontrol.control":
                assert [a.name for a in node.names] == ["kernel"]
    for name in ("GeometricPD", "MrpPD", "QuaternionPD", "FiniteTimeSO3", "controller_kernel"):
        assert name not in src
    graph = {p.stem: _imports(p) for p in (ROOT / "spacecraft").glob("*.py")}
    # nothing the fused loop's plan reads imports the fused loop (or the simulator) back
    for mod in ("actuators", "steering", "disturbances", "sgcmg", "_kernels", "cmg_dynamics"):
        assert "_fused" not in graph[mod] and "simulator" not in graph[mod], mod
    assert "simulator" not in graph["_fused"]


def _batch_setup(B: int, seed: int = 3):
    rng = np.random.default_rng(seed)
    plant = Spacecraft(RigidBody(J), SgcmgActuator(SgcmgPyramid(h0=10.0)))
    R0 = so3.exp(rng.normal(size=(B, 3)))
    state = plant.initial_state(R0, 0.02 * rng.normal(size=(B, 3)))
    ctrl = GeometricPD(J, 10.0, 60.0, error="large_angle")
    return plant, ctrl, ConstantAttitude(np.eye(3)), state


def test_workers_spread_the_batch_and_give_the_serial_result_bit_for_bit(monkeypatch):
    plant, ctrl, ref, state = _batch_setup(7)
    one = _fused(monkeypatch, plant, ctrl, ref, state, 20.0, 0.1, log_every=3)
    two = _fused(monkeypatch, plant, ctrl, ref, state, 20.0, 0.1, log_every=3, workers=2)
    for name in ("t", "R", "omega", "u_cmd", "u"):
        np.testing.assert_array_equal(getattr(two, name), getattr(one, name))
    for k in one.actuator:
        np.testing.assert_array_equal(two.actuator[k], one.actuator[k])
    for k in one.controller:
        np.testing.assert_array_equal(two.controller[k], one.controller[k])
    # and the batch's spacecraft are each the single run of that spacecraft
    single = plant.initial_state(state.R[4:5], state.omega[4:5])
    alone = _fused(monkeypatch, plant, ctrl, ref, single, 20.0, 0.1, log_every=3)
    np.testing.assert_array_equal(one.R[:, 4], alone.R[:, 0])


@pytest.mark.parametrize("bad", [0, -1, 2.5, "2", 10**6])
def test_workers_must_be_a_thread_count(bad):
    plant, ctrl, ref, state = _batch_setup(2)
    with pytest.raises((TypeError, ValueError), match="^workers"):
        simulate(plant, ctrl, ref, state, 1.0, 0.1, workers=bad)


def test_workers_on_the_python_loop_are_named_in_its_log_line(caplog):
    class Slow(AttitudeController):
        def reset(self, t0, batch_size):
            pass

        def command(self, t, state, ref):
            return -state.omega

    plant, _, ref, state = _batch_setup(2)
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, Slow(), ref, state, 1.0, 0.1, workers=2)
    assert "workers = 2 applies to the compiled loop only" in caplog.text


# ------------------------------------------------------------- the full CMG model, fused
def _vscmg_plant(servo, variable_speed=False, disturbance=None, stops=None):
    from spacecraft.cmg_dynamics import CmgInertias, VscmgActuator
    from spacecraft.steering import SingularityRobust

    Jb = np.diag([900.0, 800.0, 600.0])
    act = VscmgActuator(
        Jb, CmgInertias(0.5, 0.25, (0.1, 0.1, 0.1)), SgcmgPyramid(h0=20.0), SingularityRobust(),
        servo=servo, variable_speed=variable_speed, stops=stops,
    )  # fmt: skip
    kw = {} if disturbance is None else {"disturbance": disturbance}
    return Spacecraft(RigidBody(Jb), act, **kw), Jb


def _vscmg_cases():
    from spacecraft.actuators import FirstOrderServo
    from spacecraft.cmg_dynamics import GimbalServo
    from spacecraft.disturbances import ConstantTorque

    return [
        ({"servo": GimbalServo(5.0, 50.0)}, 1, 0.05, 1),
        ({"servo": GimbalServo(5.0, 50.0, gyro_feedforward=True)}, 3, 0.2, 3),
        (
            {
                "servo": GimbalServo(5.0, 2.0),
                "variable_speed": True,
                "disturbance": ConstantTorque([0.01, -0.02, 0.005]),
            },
            2,
            0.1,
            1,
        ),  # fmt: skip
        ({"servo": FirstOrderServo(0.2)}, 2, 0.1, 2),
    ]


@pytest.mark.parametrize("case", range(4))
def test_full_cmg_model_in_the_fused_loop_equals_the_python_loop(case, monkeypatch):
    kw, B, period, log_every = _vscmg_cases()[case]
    plant, Jb = _vscmg_plant(**kw)
    rng = np.random.default_rng(case)
    state = plant.initial_state(
        so3.exp(0.8 * rng.normal(size=(B, 3))), 0.01 * rng.normal(size=(B, 3))
    )
    ctrl = GeometricPD(Jb, 20.0, 200.0)
    args = (plant, ctrl, ConstantAttitude(np.eye(3)), state, 20.0, 0.05)
    opts = {"control_period": period, "log_every": log_every}
    fused = _fused(monkeypatch, *args, **opts)
    python = _python_loop(monkeypatch, *args, **opts)
    _assert_same(fused, python)
    assert fused.actuator["torque_saturated"].dtype == bool
    # the gimbal servo's torque limit is reached in the low-torque case: its flag is exercised
    if case == 2:
        assert python.actuator["torque_saturated"].any()


def test_full_cmg_model_with_stops_keeps_the_python_loop_and_says_why(caplog):
    from spacecraft.cmg_dynamics import GimbalServo, GimbalStops

    plant, Jb = _vscmg_plant(GimbalServo(5.0, 50.0), stops=GimbalStops(-1.2, 1.2))
    state = plant.initial_state(np.eye(3), np.zeros(3))
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, GeometricPD(Jb, 20.0, 200.0), ConstantAttitude(np.eye(3)), state, 0.2, 0.1)
    assert "gimbal stops has no compiled loop" in caplog.text


@pytest.mark.parametrize("u_max", [None, 40.0])
@pytest.mark.parametrize("B", [1, 3])
def test_rate_limited_eigenaxis_in_the_fused_loop_equals_the_python_loop(u_max, B, monkeypatch):
    from liecontrol.control.eigenaxis import RateLimitedEigenaxis, wie_lu_gains

    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    rng = np.random.default_rng(B)
    # large slews (the coast at the rate limit) and one near the antipode
    phi = rng.normal(size=(B, 3))
    phi *= (np.linspace(2.0, 3.1, B) / np.linalg.norm(phi, axis=1))[:, None]
    state = plant.initial_state(so3.exp(phi), 0.01 * rng.normal(size=(B, 3)))
    ctrl = RateLimitedEigenaxis(J, **wie_lu_gains(0.3, 0.9), max_rate=0.05, u_max=u_max)
    args = (plant, ctrl, ConstantAttitude(np.eye(3)), state, 60.0, 0.1)
    fused = _fused(monkeypatch, *args, control_period=0.2)
    python = _python_loop(monkeypatch, *args, control_period=0.2)
    _assert_same(fused, python)
    assert python.controller["rate_saturated"].any()  # the coast is exercised
    np.testing.assert_array_equal(ctrl.diagnostics()["rate_saturated"], fused.controller[
        "rate_saturated"][-1])  # fmt: skip


def test_a_time_invariant_reference_is_sampled_once_and_others_at_every_needed_step(monkeypatch):
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    state = plant.initial_state(so3.exp(np.array([0.3, -0.2, 0.1])))
    ctrl = GeometricPD(J, 10.0, 60.0)
    calls = []

    class Counted:
        def __init__(self, inner, invariant):
            self.inner = inner
            if invariant:
                self.time_invariant = True

        def __call__(self, t):
            calls.append(t)
            return self.inner(t)

    target = ConstantAttitude(np.eye(3))
    assert target.time_invariant is True
    once = _fused(monkeypatch, plant, ctrl, Counted(target, True), state, 2.0, 0.1)
    assert len(calls) == 1
    calls.clear()
    every = _fused(monkeypatch, plant, ctrl, Counted(target, False), state, 2.0, 0.1)
    assert len(calls) == 21
    _assert_same(once, every)
