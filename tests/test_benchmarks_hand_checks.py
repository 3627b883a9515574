"""Benchmark formulas against independent routes: every metric of one synthetic log against
hand values, the constant-rate reference against a finite difference of Ṙ_d = R_d ω_d^, and the
Monte Carlo attitudes against the Haar law of the rotation angle (Kolmogorov–Smirnov)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import pytest
from scipy.integrate import trapezoid as sp_trapezoid
from scipy.spatial.transform import Rotation
from scipy.stats import kstest

from benchmarks.metrics import Metrics, compute_metrics
from benchmarks.montecarlo import MonteCarloConfig, chunk_samples
from benchmarks.runner import ConstantRateReference


@dataclass(frozen=True)
class Log:
    t: np.ndarray
    R: np.ndarray
    omega: np.ndarray
    R_d: np.ndarray
    omega_d: np.ndarray
    u: np.ndarray
    u_cmd: np.ndarray
    actuator: dict = field(default_factory=dict)


# A single-axis manoeuvre about z, seen from a tilted, fixed target R_d0, piecewise linear in
# angle (degrees): 30° → −6° (overshoot, 7.5°/s) → 0° (3°/s) → 0.05° (slow drift), 10 s at 0.1 s.
KNOTS_T = [0.0, 4.8, 6.8, 10.0]
KNOTS_A = [30.0, -6.0, 0.0, 0.05]
R_D0 = Rotation.from_rotvec([0.4, -0.3, 0.8]).as_matrix()


def _log() -> tuple[Log, np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 10.0, 101)
    K = t.size
    a = np.interp(t, KNOTS_T, KNOTS_A)  # deg
    adot = np.gradient(a, t)  # deg/s; the log's rate, need not be consistent for the metrics
    R = R_D0 @ Rotation.from_rotvec(np.deg2rad(a)[:, None] * [0.0, 0.0, 1.0]).as_matrix()
    omega = np.deg2rad(adot)[:, None] * [0.0, 0.0, 1.0]
    # delivered torque |u| = 3 t/10 along (1, 2, 2)/3
    u = (t / 10.0)[:, None] * np.array([1.0, 2.0, 2.0])
    # commands: 10 alternating samples of norm 1 (9 reversals), one tiny flip below the 5 % floor
    u_cmd = np.zeros((K, 3))
    u_cmd[10:20, 0] = (-1.0) ** np.arange(10)
    u_cmd[30, 0], u_cmd[31, 0] = 0.01, -0.01
    delta_dot = np.zeros((K, 1, 4))
    delta_dot[37, 0, 2] = -0.7
    delta_dot[50, 0, 1] = 0.4
    sing = (1.0 - 0.05 * t)[:, None]  # decreasing to 0.5 at the end ...
    sing[60, 0] = 0.123  # ... with one deeper dip: the minimum
    sat = np.zeros((K, 1, 4), dtype=bool)
    sat[20:25, 0, 3] = True  # 5 samples → 0.5 s (left rectangle)
    sat[22, 0, 0] = True  # two gimbals at once still count once
    sat[K - 1, 0, 1] = True  # the last sample has no interval after it
    # wheel-type arrays in the same log (each metric reads only its own array)
    wheel_speed = np.zeros((K, 1, 4))
    wheel_speed[40, 0, 2] = -450.0  # 450/500 = 0.9 of that wheel's limit: the peak fraction
    wheel_speed[70, 0, 0] = 539.0  # 0.898 of its limit: larger speed, smaller fraction
    speed_sat = np.zeros((K, 1, 4), dtype=bool)
    speed_sat[80:83, 0, 1] = True  # 3 samples → 0.3 s
    torque_sat = np.zeros((K, 1, 4), dtype=bool)
    torque_sat[5:7, 0, 2] = True  # 0.2 s
    torque_sat[K - 1, 0, 0] = True
    stop = np.zeros((K, 1, 4), dtype=bool)
    stop[20:24, 0, 3] = True  # a gimbal at a stop for 4 samples → 0.4 s (full CMG model)
    h = (t / 10.0)[:, None] * np.array([3.0, 4.0, 12.0])  # ‖h‖ = 13 t/10 ...
    h[55] = [12.0, 0.0, 16.0]  # ... and one larger sample: ‖h‖ = 20 (largest component 16)
    log = Log(
        t=t,
        R=R[:, None],
        omega=omega[:, None],
        R_d=np.broadcast_to(R_D0, (K, 1, 3, 3)),
        omega_d=np.zeros((K, 1, 3)),
        u=u[:, None],
        u_cmd=u_cmd[:, None],
        actuator={
            "delta_dot": delta_dot,
            "singularity": sing,
            "saturated": sat,
            "wheel_speed": wheel_speed,
            "speed_saturated": speed_sat,
            "torque_saturated": torque_sat,
            "stop_contact": stop,
            "h": h[:, None],
        },
    )
    return log, a, adot


def test_every_metric_against_a_hand_computation():
    log, a, adot = _log()
    t = log.t
    from spacecraft.actuators import ReactionWheelAssembly

    limits = [600.0, 600.0, 500.0, 600.0]
    wheels = ReactionWheelAssembly.pyramid(max_speed=limits)
    from liecontrol.control.constrained import KeepInCone, KeepOutCone

    # the body x axis points along R_D0 (cos a, sin a, 0): its angle to R_D0 ŷ is 90° − a
    # (smallest 60° at a = 30°) and to R_D0 x̂ is |a| (largest 30°)
    keep_out = (KeepOutCone((1.0, 0.0, 0.0), tuple(R_D0[:, 1]), 40.0),)
    keep_in = (KeepInCone((1.0, 0.0, 0.0), tuple(R_D0[:, 0]), 35.0),)
    m = compute_metrics(
        log,
        gimbal_rate_limit=2.0,
        wheel_max_speed=limits,
        momentum_actuator=wheels,
        keep_out=keep_out,
        keep_in=keep_in,
        rpe_window_s=0.5,
    )
    got = m.as_dict(0)
    theta = np.abs(a)
    win = t >= 9.0 - 1e-9
    rate = np.abs(adot)
    expected = {
        "initial_error_deg": 30.0,
        "final_error_deg": 0.05,
        # |a| = 6 − 3 (t − 4.8) crosses 0.1° at t = 4.8 + 5.9/3 (linear, so interpolation is exact)
        "settling_time_s": 4.8 + 5.9 / 3.0,
        "settled": True,
        "steady_error_max_deg": 0.05,
        "steady_error_rms_deg": np.sqrt(sp_trapezoid(theta[win] ** 2, t[win]) / 1.0),
        "peak_rate_deg_s": 7.5,
        "rms_rate_deg_s": np.sqrt(sp_trapezoid(rate**2, t) / 10.0),
        "overshoot_deg": 6.0,
        "overshoot_pct": 20.0,
        "effort_Nms": 15.0,  # ∫ 3t/10 dt over [0, 10], trapezoid exact on a line
        # ∫ 9t²/100 dt = 30, plus the trapezoid's h²/12 (f'(b) − f'(a)) = 0.01/12 · 1.8
        "effort_sq_N2m2s": 30.0 + 0.01 / 12.0 * 1.8,
        "peak_gimbal_rate_rad_s": 0.7,
        "min_singularity": 0.123,
        "saturation_time_s": 0.5,
        "peak_gimbal_rate_frac": 0.35,
        "peak_wheel_speed_frac": 0.9,
        "wheel_speed_saturation_time_s": 0.3,
        "torque_saturation_time_s": 0.2,
        "peak_momentum_Nms": 20.0,
        "peak_torque_Nm": 3.0,  # ‖u‖ = 3 t/10 at t = 10
        "path_angle_deg": sp_trapezoid(rate, t),
        "unwinding_ratio": sp_trapezoid(rate, t) / 30.0,
        "unwound": False,
        "command_reversals": 9.0,
        # wheels: max_i |Ω_i|/Ω_max,i over the run (450/500) and at the last sample (all 0)
        "peak_momentum_fraction": 0.9,
        "final_momentum_fraction": 0.0,
        # cones: 60° − 40° closest to the keep-out cone, 35° − 30° closest to leaving keep-in
        "min_keep_out_margin_deg": 20.0,
        "min_keep_in_margin_deg": 5.0,
        "stop_contact_time_s": 0.4,
        # over [9, 10] the error is a = 0.05 (t − 6.8)/3.2 about z: windows [9, 9.5) (5 samples,
        # mean at 9.2) and [9.5, 10] (6 samples, mean at 9.75); RPE = largest deviation from
        # the window mean (0.25 s of slope), PDE = the step between the two means (0.55 s)
        "rpe_deg": 0.05 * 0.25 / 3.2,
        "pde_deg": 0.05 * 0.55 / 3.2,
    }
    # the dict covers every field, so a new metric without a hand value fails here
    assert set(expected) == {f.name for f in dataclasses.fields(Metrics)}
    for k, v in expected.items():
        assert got[k] == pytest.approx(v, rel=1e-9, abs=1e-9), k
    # two sanity anchors of the hand values themselves (not of the code)
    assert 1.0 < expected["unwinding_ratio"] < 1.5  # path ≈ 30 + 6 + 6 + 0.05 degrees
    assert expected["rms_rate_deg_s"] > 1.1 * np.mean(rate)  # RMS and mean differ here


def test_constant_rate_reference_solves_the_kinematics_from_any_start():
    """R_d(t0) = R_d0 and Ṙ_d = R_d ω_d^ (central difference, h = 1e-5) with R_d0 ≠ I, for which
    the left-multiplied exp(tω^) R_d0 would fail; ω̇_d = 0."""
    R0 = Rotation.from_rotvec([1.1, -0.4, 0.7]).as_matrix()
    w = np.array([0.02, -0.05, 0.03])
    ref = ConstantRateReference(R_d0=R0, omega_d=w, t0=3.0)
    np.testing.assert_allclose(ref(3.0).R_d, R0, atol=1e-15)
    W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    h = 1e-5
    for t in (3.0, 10.0, 250.0):
        r = ref(t)
        dR = (ref(t + h).R_d - ref(t - h).R_d) / (2 * h)
        np.testing.assert_allclose(dR, r.R_d @ W, atol=1e-9)
        np.testing.assert_allclose(r.R_d.T @ r.R_d, np.eye(3), atol=1e-13)
        np.testing.assert_array_equal(r.omega_d, w)
        np.testing.assert_array_equal(r.omega_dot_d, 0.0)
    # and against scipy's composition R_d0 · Exp((t − t0) ω)
    expect = R0 @ Rotation.from_rotvec(7.0 * w).as_matrix()
    np.testing.assert_allclose(ref(10.0).R_d, expect, atol=1e-14)


def test_monte_carlo_attitudes_follow_the_haar_angle_law():
    """For Haar-uniform rotations the angle θ has CDF F(θ) = (θ − sin θ)/π on [0, π]. KS on
    4000 seeded samples: the shipped draw gives D ≈ 0.02; attitudes from normalised
    uniform-cube quaternions give D ≈ 0.08. The 1e-3 critical value is 1.95/√4000 ≈ 0.031."""
    cfg = MonteCarloConfig(n_samples=4000, chunk_size=4000, seed=1, max_rate_deg_s=0.5)
    R0 = chunk_samples(cfg, 0).R0
    theta = np.linalg.norm(Rotation.from_matrix(R0).as_rotvec(), axis=-1)
    res = kstest(theta, lambda x: (x - np.sin(x)) / np.pi)
    assert res.statistic < 0.031, res


def test_monte_carlo_rates_are_uniform_in_magnitude_and_direction():
    """Initial rates: magnitude U(0, max_rate), direction uniform on the sphere (so each unit
    component is U(−1, 1)). KS on 4000 seeded samples, 1e-3 critical value 0.031."""
    cfg = MonteCarloConfig(n_samples=4000, chunk_size=4000, seed=2, max_rate_deg_s=0.5)
    w = chunk_samples(cfg, 0).omega0
    mag = np.linalg.norm(w, axis=-1)
    assert kstest(mag, "uniform", args=(0.0, np.deg2rad(0.5))).statistic < 0.031
    unit = w / mag[:, None]
    for k in range(3):
        assert kstest(unit[:, k], "uniform", args=(-1.0, 2.0)).statistic < 0.031
