"""Benchmark metrics (SPEC §8.2) on synthetic logs with known answers."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from benchmarks.metrics import (
    UNITS,
    Metrics,
    compute_metrics,
    error_angle,
    rate_error,
    settling_time,
    trapezoid,
)

AXIS = np.array([1.0, 2.0, -2.0]) / 3.0


@dataclass(frozen=True)
class FakeResult:
    t: np.ndarray
    R: np.ndarray
    omega: np.ndarray
    R_d: np.ndarray
    omega_d: np.ndarray
    u: np.ndarray
    actuator: dict = field(default_factory=dict)


def about_axis(angles: np.ndarray, axis: np.ndarray = AXIS) -> np.ndarray:
    """Rotation matrices exp(θ a^) for θ in ``angles`` (any shape) via scipy."""
    rv = np.asarray(angles)[..., None] * axis
    return Rotation.from_rotvec(rv.reshape(-1, 3)).as_matrix().reshape(rv.shape[:-1] + (3, 3))


def regulation_log(t: np.ndarray, theta: np.ndarray, theta_dot: np.ndarray, **kw) -> FakeResult:
    """Single-axis trajectory R = exp(θ(t) a^) regulated to R_d = I, batch of one."""
    K = t.shape[0]
    R = about_axis(theta)[:, None]
    omega = (theta_dot[:, None] * AXIS)[:, None]
    return FakeResult(
        t=t,
        R=R,
        omega=omega,
        R_d=np.broadcast_to(np.eye(3), (K, 1, 3, 3)),
        omega_d=np.zeros((K, 1, 3)),
        u=kw.pop("u", np.zeros((K, 1, 3))),
        actuator=kw.pop("actuator", {}),
    )


def test_first_order_decay_settling_time():
    tau, th0 = 20.0, np.deg2rad(10.0)
    t = np.arange(0.0, 200.0 + 1e-9, 0.1)
    theta = th0 * np.exp(-t / tau)
    m = compute_metrics(regulation_log(t, theta, -theta / tau))
    expected = tau * np.log(10.0 / 0.1)  # θ0 e^{-t/τ} = 0.1°
    assert m.settling_time_s[0] == pytest.approx(expected, rel=1e-4)
    assert m.settled[0]
    assert m.initial_error_deg[0] == pytest.approx(10.0, rel=1e-12)
    # a monotone decay never goes past the target and travels exactly θ0 − θ_f
    assert m.overshoot_deg[0] == pytest.approx(0.0, abs=1e-9)
    assert m.unwinding_ratio[0] == pytest.approx(1.0 - np.exp(-200.0 / tau), rel=1e-4)
    assert not m.unwound[0]
    # steady error over the final 10 %: max at t = 180 s, RMS from the closed form
    assert m.steady_error_max_deg[0] == pytest.approx(10.0 * np.exp(-180.0 / tau), rel=1e-9)
    rms = 10.0 * np.sqrt(tau / 2 * (np.exp(-360 / tau) - np.exp(-400 / tau)) / 20.0)
    assert m.steady_error_rms_deg[0] == pytest.approx(rms, rel=2e-3)
    # peak rate at t = 0
    assert m.peak_rate_deg_s[0] == pytest.approx(10.0 / tau, rel=1e-12)


def test_settling_time_edge_cases():
    t = np.linspace(0.0, 10.0, 11)
    th = np.deg2rad(0.1)
    err = np.stack(
        [
            np.full(11, th / 2),  # never above: settled from the start
            np.full(11, 2 * th),  # never below: not settled
            np.where(t < 5, 2 * th, th / 2),  # crosses between t=4 and t=5
            np.where((t < 2) | (t == 7), 2 * th, 0.0),  # re-exceeds at t=7
        ],
        axis=1,
    )
    ts = settling_time(t, err, th)
    assert ts[0] == 0.0
    assert np.isnan(ts[1])
    assert ts[2] == pytest.approx(4.0 + (2 - 1) / (2 - 0.5))
    assert ts[3] == pytest.approx(7.5)


def test_effort_integrals_known_values():
    t = np.linspace(0.0, np.pi, 2001)
    u = np.stack([3 * np.sin(t), 4 * np.sin(t), 0 * t], axis=-1)[:, None]  # ‖u‖ = 5 sin t
    zeros = np.zeros_like(t)
    m = compute_metrics(regulation_log(t, zeros, zeros, u=u))
    assert m.effort_Nms[0] == pytest.approx(10.0, rel=1e-6)
    assert m.effort_sq_N2m2s[0] == pytest.approx(25 * np.pi / 2, rel=1e-6)
    # no manoeuvre: overshoot and unwinding are undefined, not 0/0
    assert np.isnan(m.unwinding_ratio[0]) and np.isnan(m.overshoot_pct[0])
    assert not m.unwound[0]
    # no SGCMG arrays in the log: gimbal metrics are NaN, not an exception
    assert np.isnan(m.peak_gimbal_rate_rad_s[0]) and np.isnan(m.min_singularity[0])


def test_unwinding_long_way_ratio_two():
    # start 120° away and converge the long way round (through 240° of rotation)
    th0 = np.deg2rad(120.0)
    t = np.linspace(0.0, 100.0, 5001)
    s = 0.5 * (1 - np.cos(np.pi * t / 100.0))  # smooth 0 → 1
    s_dot = 0.5 * np.pi / 100.0 * np.sin(np.pi * t / 100.0)
    long_way = 2 * np.pi - th0
    theta = th0 + s * long_way  # ends at 2π ≡ identity
    m = compute_metrics(regulation_log(t, theta, s_dot * long_way))
    assert m.unwinding_ratio[0] == pytest.approx(2.0, rel=1e-5)
    assert m.unwound[0]
    assert m.path_angle_deg[0] == pytest.approx(240.0, rel=1e-5)
    assert m.settled[0] and m.final_error_deg[0] < 1e-6
    # the error angle grows to π then falls: after crossing π the run approaches the target
    # from the other side, the axis overshoot is measured along from then on — going the long
    # way round is unwinding, not overshoot (one flag, one meaning)
    assert m.overshoot_deg[0] == pytest.approx(0.0, abs=1e-9)


def test_overshoot_along_initial_axis():
    t = np.linspace(0.0, 30.0, 3001)
    # 30° → −3° (past the target) → 0
    theta = np.deg2rad(np.interp(t, [0, 10, 20, 30], [30, -3, 0, 0]))
    theta_dot = np.gradient(theta, t)
    m = compute_metrics(regulation_log(t, theta, theta_dot))
    assert m.overshoot_deg[0] == pytest.approx(3.0, rel=1e-9)
    assert m.overshoot_pct[0] == pytest.approx(10.0, rel=1e-9)
    assert m.unwinding_ratio[0] == pytest.approx(36.0 / 30.0, rel=1e-3)


def test_gimbal_metrics_and_saturation_time():
    t = np.arange(0.0, 10.0 + 1e-9, 0.5)
    K = t.size
    delta_dot = np.zeros((K, 2, 4))
    delta_dot[7, 0, 2] = -0.8
    delta_dot[3, 1, 1] = 0.3
    sing = np.stack([1.0 - 0.05 * t, 0.5 + 0 * t], axis=1)
    sat = np.zeros((K, 2), dtype=bool)
    sat[(t >= 2) & (t < 5), 0] = True  # flagged samples 2.0 ... 4.5 → 3 s
    zeros = np.zeros((K, 2, 3))
    res = FakeResult(
        t=t,
        R=np.broadcast_to(np.eye(3), (K, 2, 3, 3)),
        omega=zeros,
        R_d=np.broadcast_to(np.eye(3), (K, 2, 3, 3)),
        omega_d=zeros,
        u=zeros,
        actuator={"delta_dot": delta_dot, "singularity": sing, "saturated": sat},
    )
    m = compute_metrics(res)
    np.testing.assert_allclose(m.peak_gimbal_rate_rad_s, [0.8, 0.3])
    np.testing.assert_allclose(m.min_singularity, [0.5, 0.5])
    np.testing.assert_allclose(m.saturation_time_s, [3.0, 0.0])
    # per-gimbal flags (K, B, 4): a spacecraft is saturated when any of its gimbals is
    per_gimbal = np.zeros((K, 2, 4), dtype=bool)
    per_gimbal[(t >= 2) & (t < 3), 0, 1] = True
    per_gimbal[(t >= 2.5) & (t < 5), 0, 3] = True
    per_gimbal[t == 1, 1, 0] = True
    m4 = compute_metrics(dataclasses.replace(res, actuator={"saturated": per_gimbal}))
    np.testing.assert_allclose(m4.saturation_time_s, [3.0, 0.5])
    assert m.batch_size == 2
    rec = m.records()
    assert set(rec[0]) == set(UNITS)
    assert rec[0]["settling_time_s"] == 0.0 and rec[1]["settled"] is True


def test_tracking_rate_error_is_zero_on_an_offset_copy_of_the_reference():
    # R_d(t) = exp(t w^) spins at w; R = R_d Q with Q constant has ω = Qᵀw and a constant error
    w = np.array([0.02, -0.01, 0.03])
    t = np.linspace(0.0, 50.0, 501)
    R_d = Rotation.from_rotvec(t[:, None] * w).as_matrix()
    Q = Rotation.from_rotvec([0.3, -0.2, 0.1]).as_matrix()
    R = R_d @ Q
    omega = np.broadcast_to(Q.T @ w, (t.size, 3))
    e = rate_error(R, omega, R_d, np.broadcast_to(w, (t.size, 3)))
    np.testing.assert_allclose(e, 0.0, atol=1e-15)
    res = FakeResult(
        t=t,
        R=R[:, None],
        omega=omega[:, None],
        R_d=R_d[:, None],
        omega_d=np.broadcast_to(w, (t.size, 1, 3)),
        u=np.zeros((t.size, 1, 3)),
    )
    m = compute_metrics(res)
    ang = np.rad2deg(np.linalg.norm([0.3, -0.2, 0.1]))
    assert m.path_angle_deg[0] == pytest.approx(0.0, abs=1e-10)
    assert m.steady_error_max_deg[0] == pytest.approx(ang, rel=1e-10)
    assert np.isnan(m.settling_time_s[0]) and not m.settled[0]


rotvecs = st.tuples(*[st.floats(-1.0, 1.0) for _ in range(3)]).filter(
    lambda v: np.linalg.norm(v) > 1e-3
)


@settings(max_examples=60, deadline=None)
@given(v=rotvecs, angle=st.floats(0.0, np.pi), w=rotvecs, angle2=st.floats(0.0, np.pi))
def test_error_angle_matches_scipy_and_is_invariant(v, angle, w, angle2):
    a = np.asarray(v) / np.linalg.norm(v)
    R = Rotation.from_rotvec(angle * a).as_matrix()
    G = Rotation.from_rotvec(angle2 * np.asarray(w) / np.linalg.norm(w)).as_matrix()
    assert error_angle(R, np.eye(3)) == pytest.approx(angle, abs=1e-9)
    # bi-invariance: θ(GR, GR_d) = θ(RG, R_dG) = θ(R, R_d), and symmetry
    assert error_angle(G @ R, G) == pytest.approx(angle, abs=1e-9)
    assert error_angle(R @ G, G) == pytest.approx(
        Rotation.from_matrix(G.T @ R @ G).magnitude(), abs=1e-9
    )
    assert error_angle(np.eye(3), R) == pytest.approx(angle, abs=1e-9)


def test_trapezoid_matches_numpy():
    rng = np.random.default_rng(0)
    t = np.sort(rng.uniform(0, 5, 50))
    y = rng.normal(size=(50, 3, 2))
    np.testing.assert_allclose(trapezoid(y, t), np.trapezoid(y, t, axis=0))
    assert trapezoid(y[:1], t[:1]).shape == (3, 2)


@dataclass(frozen=True)
class FakeResultCmd(FakeResult):
    u_cmd: np.ndarray | None = None


def test_command_reversals_count_sign_flips_above_the_floor():
    t = np.arange(12.0)
    axis = np.array([1.0, 0.0, 0.0])
    # spacecraft 0: smooth accelerate/brake, one flip through a small command (below 5 % floor)
    smooth = np.array([10, 8, 5, 2, 0.1, -0.2, -3, -5, -3, -1, -0.2, 0.0])
    # spacecraft 1: a switching law chattering between ±1 (11 reversals), then one small flip
    chatter = np.array([1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1.0])
    u_cmd = np.stack([smooth[:, None] * axis, chatter[:, None] * axis], axis=1)
    K = t.shape[0]
    res = FakeResultCmd(
        t=t,
        R=np.broadcast_to(np.eye(3), (K, 2, 3, 3)),
        omega=np.zeros((K, 2, 3)),
        R_d=np.broadcast_to(np.eye(3), (K, 2, 3, 3)),
        omega_d=np.zeros((K, 2, 3)),
        u=np.zeros((K, 2, 3)),
        u_cmd=u_cmd,
    )
    m = compute_metrics(res)
    np.testing.assert_array_equal(m.command_reversals, [0.0, 11.0])
    # with a zero floor every sign change counts: 10 → … → 0.1 → −0.2 is one flip
    m0 = compute_metrics(res, reversal_floor=1e-12)
    np.testing.assert_array_equal(m0.command_reversals, [1.0, 11.0])
    # no command in the log: not defined
    assert np.isnan(compute_metrics(dataclasses.replace(res, u_cmd=None)).command_reversals).all()
    with pytest.raises(ValueError, match="^reversal_floor"):
        compute_metrics(res, reversal_floor=2.0)


def test_bad_input_names_the_argument():
    t = np.linspace(0, 1, 5)
    res = regulation_log(t, 0 * t, 0 * t)
    with pytest.raises(ValueError, match="^settle_threshold_deg"):
        compute_metrics(res, settle_threshold_deg=0.0)
    with pytest.raises(ValueError, match="^steady_fraction"):
        compute_metrics(res, steady_fraction=1.5)
    bad = FakeResult(
        t=t, R=res.R, omega=res.omega[:, :, :2], R_d=res.R_d, omega_d=res.omega_d, u=res.u
    )
    with pytest.raises(ValueError, match="^result: omega"):
        compute_metrics(bad)
    assert isinstance(compute_metrics(res), Metrics)
