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
from conftest import simulate_fused, simulate_python_loop

from liecontrol._jit import JIT_ENABLED
from liecontrol._kernels.constrained import FILTER_HEAD, N_WORK, PER_CONE, braking_filter_one
from liecontrol.control.constrained import (
    KeepInCone,
    KeepOutCone,
    SampledSafeConstrainedPD,
    UnrecoverableStartWarning,
    braking_filter,
    braking_margins_deg,
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


_python_loop = simulate_python_loop
_fused = simulate_fused


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
        + [[float(np.linalg.norm(umax)) / float(np.linalg.eigvalsh(J)[0])]]
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


# ------------------------------------- the largest admissible approach acceleration (closed form)
def _h_after_period(a, m, v, a_b, T, buf):
    vp = np.maximum(v + a * T, 0.0)
    return (m - v * T - 0.5 * a * T * T) - vp * T - vp * vp / (2.0 * a_b) - buf


def _bisected(m, v, a_b, a_hi, T, buf):
    # the independent route: 200 halvings in float64 reach the root to the last bit
    lo, hi = np.minimum(-a_b, a_hi), np.array(a_hi, dtype=float)
    ok_hi = _h_after_period(hi, m, v, a_b, T, buf) >= 0.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        good = _h_after_period(mid, m, v, a_b, T, buf) >= 0.0
        lo, hi = np.where(good, mid, lo), np.where(good, hi, mid)
    return np.where(ok_hi, a_hi, lo)


def test_largest_approach_acceleration_is_the_clipped_root_on_both_branches():
    from liecontrol._kernels.constrained import largest_approach_acceleration_one
    from liecontrol.control.constrained import largest_approach_acceleration

    rng = np.random.default_rng(5)
    N = 20_000
    T = rng.choice([0.05, 0.1, 0.5, 2.0], size=N)
    buf = math.radians(0.5)
    a_b = 10.0 ** rng.uniform(-5, -1, size=N)
    m = rng.uniform(-0.05, 0.5, size=N)
    v = rng.normal(size=N) * 10.0 ** rng.uniform(-4, -1, size=N)
    a_hi = rng.normal(size=N) * 10.0 ** rng.uniform(-4, 0, size=N)
    # dense around the branch switch D = m − vT − buffer + ½vT = 0 (v' = 0 at the root)
    k = N // 4
    m[:k] = v[:k] * T[:k] * 0.5 + buf + rng.normal(size=k) * 10.0 ** rng.uniform(-16, -6, size=k)
    a_hi[:k] = np.abs(a_hi[:k]) + 1.0  # the root is inside the interval
    got = largest_approach_acceleration(m, v, a_b, a_hi, T, buf)
    want = _bisected(m, v, a_b, a_hi, T, buf)
    scale = np.abs(m) / T**2 + np.abs(v) / T + np.abs(a_hi) + a_b
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * scale.max())
    assert np.all(np.abs(got - want) <= 1e-13 * scale)
    # inside the interval it is the root: the end-of-period margin is 0 to rounding
    inside = (got < a_hi) & (got > np.minimum(-a_b, a_hi))
    D = m - v * T - buf + 0.5 * v * T
    assert (inside & (D > 0)).sum() > N // 20 and (inside & (D <= 0)).sum() > N // 20
    h = _h_after_period(got, m, v, a_b, T, buf)
    assert np.all(np.abs(h[inside]) <= 1e-14 * (np.abs(m) + np.abs(v) * T + 1.0)[inside])
    # the branches meet at D = 0: continuous across the switch (a = −v/T there)
    d = np.array([-1e-12, -1e-15, 0.0, 1e-15, 1e-12])
    mm = 0.02 * 0.1 * 0.5 + buf + d
    a = largest_approach_acceleration(mm, np.full(5, 0.02), 1.0, 10.0, 0.1, buf)
    assert np.all(np.abs(a - (-0.02 / 0.1)) < 1e-9)
    # the compiled kernel: the same operations, the same numbers
    if JIT_ENABLED:
        one = np.array(
            [
                largest_approach_acceleration_one(*x, buf)
                for x in zip(m, v, a_b, a_hi, T, strict=True)
            ]
        )
        np.testing.assert_array_equal(one, got)


# ------------------------------------------- far from a cone: the angle's singular curvature
@pytest.mark.parametrize("offset", [0.0, 1e-9, 1e-6, 1e-3, 2e-2])
def test_a_boresight_crossing_a_cone_axis_far_from_the_boundary_is_left_alone(offset):
    """On a keep-in cone's axis (and opposite a keep-out cone's) the curvature term of the
    angle's second derivative is unbounded while the boundary is 75° away: the filter must
    not act, and the margin it reports must be the boundary's distance less a braking distance
    (was −5·10⁹° and full braking, the keep-in-keep-out scenario's antenna mid-slew)."""
    umax = np.full(3, 300.0)
    T = 0.1
    # the scenario's slew about body x: at 60° body y (the antenna) is on the keep-in axis
    # (0, cos 60°, sin 60°), `offset` rad past it; body x is 55° clear of the Earth cone
    R = so3.exp(np.array([[math.radians(60.0) + offset, 0.0, 0.0]]))
    y_target = R[0, :, 1]
    # the antenna sweeps across its axis at 0.03 rad/s (the scenario's mid-slew rate)
    w = np.array([[0.03, 0.0, 0.0], [0.03, 0.0, 0.004], [-0.02, 0.001, 0.02]])
    R = np.broadcast_to(R, (3, 3, 3))
    u = np.array([[17.6, -19.8, 50.3], [40.0, 10.0, -60.0], [-100.0, 30.0, 5.0]])
    for cones in ((ANTENNA,), (EARTH, ANTENNA)):
        ref = braking_filter(u, R, w, J, cones, umax, T, 0.7, 0.5)
        got = _kernel_filter(u, R, w, cones, umax, T, 0.7, 0.5)
        for out in (ref, got):
            assert not np.any(out[1])  # the filter leaves the command alone
            np.testing.assert_array_equal(out[0], u)
        k = len(cones) - 1  # the antenna's column
        h = np.degrees(ref[2][:, k])
        m = np.degrees(ref[3][:, k])
        assert np.all(m > 73.0)
        assert np.all(h > m - 5.0) and np.all(h <= m)  # less a braking distance of a few °
        np.testing.assert_allclose(got[2], ref[2], rtol=1e-12, atol=1e-12)
        margins = braking_margins_deg(cones, R, w, J, umax, T)
        np.testing.assert_allclose(np.radians(margins), ref[2], rtol=1e-12, atol=1e-14)
    # a keep-out cone's far side (boresight opposite its axis): left alone as well
    far = KeepOutCone((0.0, 1.0, 0.0), tuple(-y_target), 20.0)
    out = braking_filter(u, R, w, J, (far,), umax, T, 0.7, 0.5)
    assert not np.any(out[1]) and np.all(np.degrees(out[2]) > 158.0)
