"""The sampled-data safe keep-out PD (SampledSafeConstrainedPD) in the fused loop (issue 24).

- the compiled braking filter (``braking_filter_one``) equals the batched numpy
  ``braking_filter`` (the validated reference, also the MPC's filter) over random states,
  keep-out and keep-in cones, passive, projected and full-braking cases;
- the fused loop equals the Python loop to 1e-12 (same diagnostics keys, shapes, dtypes) on the
  keep-out scenarios at control periods 0.1 and 0.5 s with an initial rate toward the cone,
  batch 1 and 3, and without cones;
- an unrecoverable start still warns (strict: raises naming ``R`` before the first step).
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from liecontrol._jit import JIT_ENABLED
from liecontrol._kernels.constrained import FILTER_HEAD, N_WORK, PER_CONE, braking_filter_one
from liecontrol.control.constrained import (
    KeepInCone,
    KeepOutCone,
    SampledSafeConstrainedPD,
    UnrecoverableStartWarning,
    braking_filter,
)
from liecontrol.control.reference import ConstantAttitude
from liecontrol.control.tuning import ClosedLoopSpec, tune_geometric_pd
from liecontrol.lie import so3
from spacecraft import IdealTorqueActuator, RigidBody, Spacecraft
from spacecraft import simulator as simulator_module
from spacecraft._fused import fused_supported
from spacecraft.simulator import simulate

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the fused loop needs numba")

J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
SUN = KeepOutCone((0.0, 0.0, 1.0), (0.104528, -0.861281, 0.497261), 20.0)
EARTH = KeepOutCone((1.0, 0.0, 0.0), (0.0, 0.0, -1.0), 35.0)
ANTENNA = KeepInCone((0.0, 1.0, 0.0), (0.0, 0.5, 0.866025), 75.0)
R0 = so3.exp(np.radians(120.0) * np.array([1.0, 0.0, 0.0]))


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


def _assert_same(a, b):
    """1e-12, relative or (torques of a few hundred N·m) of each field's largest value."""
    for name in ("t", "R", "omega", "R_d", "omega_d", "u_cmd", "u", "disturbance"):
        x, y = getattr(a, name), getattr(b, name)
        scale = max(1.0, float(np.abs(y).max(initial=0.0)))
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * scale, err_msg=name)
    for group in ("actuator", "controller"):
        da, db = getattr(a, group), getattr(b, group)
        assert sorted(da) == sorted(db), group
        for k in da:
            assert da[k].dtype == db[k].dtype and da[k].shape == db[k].shape, (group, k)
            if da[k].dtype == bool:
                np.testing.assert_array_equal(da[k], db[k], err_msg=k)
            else:
                np.testing.assert_allclose(da[k], db[k], rtol=1e-12, atol=1e-12, err_msg=k)


# ------------------------------------------------------------ the filter: kernel vs numpy
def _kernel_filter(u, R, w, cones, umax, T, eta, buf_deg):
    """``braking_filter`` through the compiled one-spacecraft kernel, spacecraft by spacecraft,
    with the parameter blocks the controller's ``fused_kernel`` builds."""
    block = np.array(
        [
            [*c._b, *c._s, c.cos_half_angle, 0.0 if c.kind == "keep_out" else 1.0, c.half_angle_deg]
            for c in cones
        ]
    ).reshape(len(cones), PER_CONE)
    lam = float(np.linalg.eigvalsh(J)[-1])
    filt = np.concatenate(
        [umax, [T, eta, math.radians(buf_deg), lam], np.linalg.inv(J).ravel(), [0.0]]
        + [[math.radians(c.half_angle_deg) for c in cones]]
    )
    assert filt.shape == (FILTER_HEAD + len(cones),)
    B, n = u.shape[0], len(cones)
    out = u.copy()
    active = np.zeros(B, dtype=bool)
    work = np.zeros((B, n, N_WORK))
    for k in range(B):
        active[k] = braking_filter_one(out[k], R[k], w[k], J, block, filt, work[k])
    return out, active, work[..., 0], work[..., 1], work[..., 2], work[..., 3], work


@pytest.mark.parametrize("T", [0.05, 0.5, 2.0])
@pytest.mark.parametrize("cones", [(SUN,), (SUN, EARTH), (SUN, ANTENNA), (SUN, EARTH, ANTENNA)])
def test_compiled_braking_filter_equals_the_numpy_reference(cones, T):
    rng = np.random.default_rng(11)
    B = 400
    R = so3.random(rng, (B,))
    # keep the starts admissible for every cone (the filter's domain)
    m = np.stack([c.margin_deg(R) for c in cones], axis=-1).min(axis=-1)
    R = R[m > 0.5]
    B = R.shape[0]
    w = rng.normal(size=(B, 3)) * rng.choice([0.002, 0.03, 0.1], size=(B, 1))
    umax = np.array([300.0, 250.0, 350.0])
    u = np.clip(
        rng.normal(size=(B, 3)) * rng.choice([10.0, 300.0, 3000.0], size=(B, 1)), -umax, umax
    )
    ref = braking_filter(u, R, w, J, cones, umax, T, 0.7, 0.5)
    got = _kernel_filter(u, R, w, cones, umax, T, 0.7, 0.5)
    for name, x, y in zip(("h", "m", "v", "a_b"), got[2:6], ref[2:], strict=True):
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12, err_msg=name)
    # where the box has no braking authority left (a_b at its 1e-12 floor, h ≈ −1e11) a* is
    # ≈ −1e-12 and the last test, approach acceleration > a*(1 + 1e-12), compares rounding
    # noise: either route's choice there is arbitrary, so the commands are compared elsewhere
    ok = np.all(ref[5] > 1e-12, axis=-1)
    assert ok.mean() > 0.7
    np.testing.assert_allclose(got[0][ok], ref[0][ok], rtol=1e-12, atol=1e-12)
    # a command at the corner of the box that pushes toward a cone all commands are safe from
    # has excess pᵀu − (a* − a_free) = 0 exactly, so "active" is the sign of rounding noise
    # (the command moves by ~1e-16): the flags are compared away from such ties
    w_ = got[6]
    excess = np.einsum("bnk,bk->bn", w_[..., 5:8], u) - (w_[..., 8] - w_[..., 4])
    scale = np.einsum("bnk,bk->bn", np.abs(w_[..., 5:8]), np.abs(u)) + np.abs(w_[..., 8])
    tie = np.any(np.abs(excess) <= 1e-12 * (scale + np.abs(w_[..., 4])), axis=-1)
    assert not np.any((got[1] != ref[1]) & ok & ~tie)
    # every branch is exercised: passive, projected, full braking
    act = ref[1][ok]
    brake = np.all(np.isclose(np.abs(ref[0][ok]), umax, rtol=0, atol=1e-9), axis=-1) & act
    assert (~act).any() and brake.any() and (act & ~brake).any()


# ------------------------------------------------------------ the fused loop vs the Python loop
def _scenario_run(name, T, rates):
    from benchmarks.controllers import ControllerContext, get_controller
    from benchmarks.runner import build_plant, build_reference, initial_state
    from benchmarks.scenarios import get_scenario

    s = get_scenario(name).with_duration(40.0)
    s = dataclasses.replace(s, control_period=T)
    plant = build_plant(s.spacecraft, s.disturbances, s.true_inertia)
    ref = build_reference(s)
    R, _ = initial_state(s)
    B = len(rates)
    w0 = -np.asarray(rates, dtype=float)[:, None] * np.array([1.0, 0.0, 0.0])
    x0 = plant.initial_state(np.broadcast_to(R, (B, 3, 3)), w0)
    ctx = ControllerContext(
        spacecraft=s.spacecraft,
        control_period=T,
        batch_size=B,
        q_hint=np.broadcast_to(s.initial_quaternion, (B, 4)),
        reference=ref,
        keep_out=s.keep_out,
        keep_in=s.keep_in,
    )
    ctrl = get_controller("geometric-keep-out-sampled").factory(ctx)
    assert isinstance(ctrl, SampledSafeConstrainedPD)
    return plant, ctrl, ref, x0, s


@pytest.mark.parametrize("rates", [[0.03], [0.0, 0.02, 0.05]], ids=["batch1", "batch3"])
@pytest.mark.parametrize("T", [0.1, 0.5])
@pytest.mark.parametrize("name", ["keep-out-sun-slew", "keep-out-corridor", "keep-in-keep-out"])
def test_fused_loop_equals_python_loop_on_the_keep_out_scenarios(name, T, rates, monkeypatch):
    plant, ctrl, ref, x0, s = _scenario_run(name, T, rates)
    B = len(rates)
    ctrl.reset(0.0, B)
    assert fused_supported(plant, ctrl, [], None, False, batch_size=B, control_period=T)
    args = (plant, ctrl, ref, x0, s.duration, s.dt)
    fast = _fused(monkeypatch, *args, control_period=T)
    end_fast = (ctrl._first, ctrl.nominal._first, ctrl.diagnostics())
    slow = _python_loop(monkeypatch, *args, control_period=T)
    _assert_same(fast, slow)
    assert "filter_active" in slow.controller and "braking_margin" in slow.controller
    # the controller ends as the Python loop leaves it
    assert end_fast[:2] == (ctrl._first, ctrl.nominal._first)
    assert sorted(end_fast[2]) == sorted(ctrl.diagnostics())
    for k, v in ctrl.diagnostics().items():
        np.testing.assert_allclose(end_fast[2][k], v, rtol=1e-12, atol=1e-12)


def _ideal(rates, max_torque=300.0):
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(max_torque=max_torque))
    w0 = -np.asarray(rates, dtype=float)[:, None] * np.array([1.0, 0.0, 0.0])
    x0 = plant.initial_state(np.broadcast_to(R0, (len(rates), 3, 3)), w0)
    return plant, ConstantAttitude(np.eye(3)), x0


def _ctrl(T, **kw):
    g = tune_geometric_pd(J, ClosedLoopSpec(0.03, 0.9, T))
    kw = {"keep_out": (SUN,), "max_torque": 300.0, "sample_period": T, **kw}
    return SampledSafeConstrainedPD(J, g["k_R"], g["k_Omega"], **kw)


def test_fused_filter_brakes_like_the_python_loop_and_without_cones(monkeypatch):
    """Fast starts toward the Sun cone that the filter must brake (logged every 0.05 s step
    inside the held 0.5 s period), and the same law without cones (the nominal's diagnostics
    only)."""
    plant, ref, x0 = _ideal([0.05, 0.1, 0.12])
    args = (plant, _ctrl(0.5), ref, x0, 40.0, 0.05)
    slow = _python_loop(monkeypatch, *args, control_period=0.5)
    _assert_same(_fused(monkeypatch, *args, control_period=0.5), slow)
    assert slow.controller["filter_active"].any()
    args = (plant, _ctrl(0.5, keep_out=()), ref, x0, 10.0, 0.05)
    fast = _fused(monkeypatch, *args, control_period=0.5)
    _assert_same(fast, _python_loop(monkeypatch, *args, control_period=0.5))
    assert sorted(fast.controller) == ["Psi", "e_Omega", "e_R", "min_slack"]


def test_unrecoverable_start_warns_in_the_fused_loop_and_strict_raises(monkeypatch):
    plant, ref, x0 = _ideal([0.3])
    with pytest.warns(UnrecoverableStartWarning, match="^R: spacecraft 0 starts in the unrec"):
        fast = _fused(monkeypatch, plant, _ctrl(1.0), ref, x0, 4.0, 0.05, control_period=1.0)
    with pytest.warns(UnrecoverableStartWarning, match="^R: spacecraft 0 starts in the unrec"):
        slow = _python_loop(monkeypatch, plant, _ctrl(1.0), ref, x0, 4.0, 0.05, control_period=1.0)
    _assert_same(fast, slow)
    calls = []
    real = simulator_module.run_fused

    def spy(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(simulator_module, "run_fused", spy)
    with pytest.raises(ValueError, match="^R: spacecraft 0 starts in the unrecoverable set"):
        simulate(plant, _ctrl(1.0, strict=True), ref, x0, 4.0, 0.05, control_period=1.0)
    assert calls == [1]  # the compiled loop stopped at its first sample


def test_the_fused_loop_warns_of_an_unrecoverable_start_before_its_first_step(monkeypatch):
    """The warning comes from the kernel's preflight, before the compiled loop runs (as
    ``command`` warns at its first sample), not after the run."""
    from spacecraft import _fused

    plant, ref, x0 = _ideal([0.3])
    entered = []
    real = _fused._loop_entry

    def spy(*a, **k):
        entered.append(1)
        return real(*a, **k)

    monkeypatch.setattr(_fused, "_loop_entry", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnrecoverableStartWarning)
        with pytest.raises(UnrecoverableStartWarning, match="^R: spacecraft 0 starts"):
            simulate(plant, _ctrl(1.0), ref, x0, 4.0, 0.05, control_period=1.0)
    assert entered == []  # raised (as a warning turned error) before the loop was entered
    # and a recoverable start says nothing
    plant, ref, x0 = _ideal([0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnrecoverableStartWarning)
        simulate(plant, _ctrl(1.0), ref, x0, 4.0, 0.05, control_period=1.0)
    assert entered == [1]
