"""Sampled-data keep-out (issue 25): a 120° slew whose geodesic takes the body-z boresight
through the centre of a 20° Sun cone, initial rates 0–0.1 rad/s toward it, control periods
0.05–1 s. The barrier law alone crosses the cone; SampledSafeConstrainedPD keeps the margin
positive at every logged sample within the torque bound, and warns before a start it cannot
certify."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from liecontrol.control.constrained import (
    ConstrainedGeometricPD,
    KeepInCone,
    KeepOutCone,
    SampledSafeConstrainedPD,
    UnrecoverableStartWarning,
    braking_margins_deg,
    check_cone_set,
    cone_margins_deg,
)
from liecontrol.control.reference import ConstantAttitude
from liecontrol.control.tuning import ClosedLoopSpec, tune_geometric_pd
from liecontrol.lie import so3
from spacecraft.actuators import IdealTorqueActuator
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.simulator import simulate

# the sgcmg-bus and the keep-out-sun-slew scenario of the benchmarks
J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
SUN = KeepOutCone((0.0, 0.0, 1.0), (0.104528, -0.861281, 0.497261), 20.0)
R0 = so3.exp(np.radians(120.0) * np.array([1.0, 0.0, 0.0]))
U_MAX = 300.0  # per-axis torque bound [N·m]
RATES = np.array([0.0, 0.05, 0.1])  # toward the cone: ω = −v x̂ runs the slew back through it


def _gains(T: float) -> tuple:
    kw = tune_geometric_pd(J, ClosedLoopSpec(0.03, 0.9, T))
    return kw["k_R"], kw["k_Omega"]


def _run(ctrl, T: float, rates=RATES, t_final: float = 60.0, max_torque=U_MAX):
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(max_torque=max_torque))
    w0 = -np.asarray(rates)[:, None] * np.array([1.0, 0.0, 0.0])
    st = plant.initial_state(np.broadcast_to(R0, (len(rates), 3, 3)), omega0=w0)
    return simulate(plant, ctrl, ConstantAttitude(np.eye(3)), st, t_final, 0.05, T)


def test_barrier_alone_crosses_the_cone_in_sampled_data():
    """The counter-example: the log-barrier law at a 0.1 s period, 0.1 rad/s toward the cone,
    ideal torque, crosses the cone (margin ≈ −19.7°)."""
    ctrl = ConstrainedGeometricPD(J, *_gains(0.1), keep_out=(SUN,))
    res = _run(ctrl, 0.1, rates=[0.1], t_final=20.0, max_torque=None)
    assert cone_margins_deg((SUN,), res.R).min() < -10.0


@pytest.mark.parametrize("T", [0.05, 0.1, 0.2, 0.5, 1.0])
def test_sampled_safe_law_keeps_the_margin_over_the_grid(T):
    """Rates 0, 0.05, 0.1 rad/s toward the cone × control period T: the margin stays positive at
    every logged sample (every 0.05 s integration step, also inside the held periods), the
    command stays within the torque bound, and no start is flagged unrecoverable."""
    ctrl = SampledSafeConstrainedPD(
        J, *_gains(T), keep_out=(SUN,), max_torque=U_MAX, sample_period=T
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnrecoverableStartWarning)
        res = _run(ctrl, T)
    m = cone_margins_deg((SUN,), res.R)[..., 0]
    assert m.min() > 0.0, m.min(axis=0)
    assert np.abs(res.u_cmd).max() <= U_MAX * (1.0 + 1e-12)
    # the fast starts really were braked by the filter
    assert res.controller["filter_active"][:, -1].any()


@pytest.mark.parametrize("T", [0.05, 1.0])
def test_largest_certified_rate_is_held(T):
    """At 99 % of the largest initial rate the certificate accepts (braking margin 0 at the
    start: 0.135 rad/s at 0.05 s, 0.123 rad/s at 1 s) the margin stays positive, without a
    warning."""
    from scipy.optimize import brentq

    def h0(v):
        w = np.array([[-v, 0.0, 0.0]])
        return braking_margins_deg((SUN,), R0[None], w, J, U_MAX, T)[0, 0]

    v_max = brentq(h0, 0.01, 1.0, xtol=1e-6)
    assert 0.1 < v_max < 0.2
    ctrl = SampledSafeConstrainedPD(
        J, *_gains(T), keep_out=(SUN,), max_torque=U_MAX, sample_period=T
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnrecoverableStartWarning)
        res = _run(ctrl, T, rates=[0.99 * v_max], t_final=40.0)
    assert cone_margins_deg((SUN,), res.R).min() > 0.0


def test_keep_in_and_keep_out_together():
    """The keep-in-keep-out scenario at 1 s with the fastest start: both margins stay positive."""
    keep_in = KeepInCone((0.0, 1.0, 0.0), (0.0, 0.5, 0.866025), 75.0)
    ctrl = SampledSafeConstrainedPD(
        J, *_gains(1.0), keep_out=(SUN,), keep_in=(keep_in,), max_torque=U_MAX, sample_period=1.0
    )
    res = _run(ctrl, 1.0, rates=[0.1])
    assert cone_margins_deg((SUN, keep_in), res.R).min() > 0.0


def test_unrecoverable_start_warned_before_running():
    """0.3 rad/s toward the cone with 300 N·m on a 15 000 kg·m² body cannot be stopped in the
    40° left: braking_margins_deg < 0, and the first command warns (strict: raises naming R)."""
    w0 = np.array([[-0.3, 0.0, 0.0]])
    h = braking_margins_deg((SUN,), R0[None], w0, J, U_MAX, 1.0)
    assert h[0, 0] < 0.0
    h_ok = braking_margins_deg((SUN,), R0[None], -RATES[:, None] * [1.0, 0, 0], J, U_MAX, 1.0)
    assert np.all(h_ok > 0.0)
    ctrl = SampledSafeConstrainedPD(
        J, *_gains(1.0), keep_out=(SUN,), max_torque=U_MAX, sample_period=1.0
    )
    with pytest.warns(UnrecoverableStartWarning, match="^R: spacecraft 0 starts in the unrec"):
        _run(ctrl, 1.0, rates=[0.3], t_final=2.0)
    strict = SampledSafeConstrainedPD(
        J, *_gains(1.0), keep_out=(SUN,), max_torque=U_MAX, sample_period=1.0, strict=True
    )
    with pytest.raises(ValueError, match="^R: spacecraft 0 starts in the unrecoverable set"):
        _run(strict, 1.0, rates=[0.3], t_final=2.0)


def test_bad_input():
    k = _gains(0.1)
    with pytest.raises(ValueError, match="^max_torque"):
        SampledSafeConstrainedPD(J, *k, keep_out=(SUN,), max_torque=0.0, sample_period=0.1)
    with pytest.raises(ValueError, match="^sample_period"):
        SampledSafeConstrainedPD(J, *k, keep_out=(SUN,), max_torque=1.0, sample_period=0.0)
    with pytest.raises(ValueError, match="^efficiency"):
        SampledSafeConstrainedPD(
            J, *k, keep_out=(SUN,), max_torque=1.0, sample_period=0.1, efficiency=1.5
        )
    with pytest.raises(ValueError, match="^half_angle_deg"):
        KeepOutCone((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), 90.0)
    # a keep-in cone inside a keep-out cone of the same body axis: no admissible attitude
    out = KeepOutCone((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), 40.0)
    inside = KeepInCone((0.0, 0.0, 1.0), (1.0, 0.1, 0.0), 20.0)
    with pytest.raises(ValueError, match="^keep_in"):
        check_cone_set((out,), (inside,))
    with pytest.raises(ValueError, match="^keep_in"):
        ConstrainedGeometricPD(J, *k, keep_out=(out,), keep_in=(inside,))
    far = KeepInCone((0.0, 0.0, 1.0), (-1.0, 0.0, 0.0), 30.0)
    with pytest.raises(ValueError, match="^keep_in"):
        check_cone_set((), (inside, far))
    check_cone_set((out,), (far,))  # compatible
