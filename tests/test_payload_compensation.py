"""Seed-003 PID + rotating-payload feed-forward (SPEC §6.3): gains, identifier, chart mapping,
hold/timing, closed-loop identification and compensation, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from liecontrol.charts import euler
from liecontrol.control.adapters import RotatingFrame
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.payload_compensation import (
    HarmonicIdentifier,
    SmallAnglePIDLaw,
    SmallAnglePIDWithFeedforward,
    pid_gains,
)
from liecontrol.lie import so3

J = np.diag([520.0, 450.0, 660.0])
WP = math.pi / 2  # 90°/s
N_ORB = 0.0011


def _ref_at_rest(t: float = 0.0) -> AttitudeReference:
    return AttitudeReference.regulation(np.eye(3))


def _state(R: np.ndarray, w: np.ndarray, h: np.ndarray | None = None) -> AttitudeState:
    return AttitudeState(R=np.asarray(R)[None], omega=np.asarray(w)[None],
                         h=None if h is None else np.asarray(h)[None])


# --------------------------------------------------------------------------- gains


@pytest.mark.parametrize("r", [0.0, 0.1, 0.5])
def test_pid_gains_place_the_designed_poles(r):
    """Roots of J s³ + k_d s² + k_p s + k_i (np.roots) = −rω_n and −ξω_n ± iω_n√(1 − ξ²)."""
    kp, ki, kd = pid_gains(J, 0.02, 0.707, r)
    wn, z = 2 * np.pi * 0.02, 0.707
    want = [-z * wn + 1j * wn * np.sqrt(1 - z**2), -z * wn - 1j * wn * np.sqrt(1 - z**2)]
    if r > 0:
        want.append(-r * wn)
    for j in range(3):
        coeffs = [J[j, j], kd[j], kp[j], ki[j]] if r > 0 else [J[j, j], kd[j], kp[j]]
        got = np.sort_complex(np.roots(coeffs))
        np.testing.assert_allclose(got, np.sort_complex(np.array(want)), atol=1e-12)


# --------------------------------------------------------------------------- identifier


def test_regressor_is_the_interval_average():
    ident = HarmonicIdentifier(1.3)
    t0, t1 = 2.1, 2.35
    phi = ident.regressor(t0, t1)
    s = quad(lambda t: math.sin(1.3 * t), t0, t1)[0] / (t1 - t0)
    c = quad(lambda t: math.cos(1.3 * t), t0, t1)[0] / (t1 - t0)
    np.testing.assert_allclose(phi, [s, c, 1.0], atol=1e-13)
    np.testing.assert_allclose(ident.regressor(t0, t0)[:2], [math.sin(1.3 * t0),
                                                            math.cos(1.3 * t0)], atol=1e-15)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.05, 20.0), st.floats(-100.0, 100.0), st.floats(0.01, 3.0), st.floats(0.1, 0.9))
def test_regressor_is_additive_over_subintervals(w, t0, span, frac):
    """(t1 − t0) φ[t0, t1] = (tm − t0) φ[t0, tm] + (t1 − tm) φ[tm, t1] (it is an integral)."""
    ident = HarmonicIdentifier(w)
    t1, tm = t0 + span, t0 + frac * span
    whole = span * ident.regressor(t0, t1)
    parts = (tm - t0) * ident.regressor(t0, tm) + (t1 - tm) * ident.regressor(tm, t1)
    np.testing.assert_allclose(whole, parts, atol=1e-9 * max(1.0, span))


def test_identifier_converges_on_interval_averaged_noisy_samples():
    """Averages over [t_{k-1}, t_k] of W sin(ωt + β) + c plus white noise σ = 0.003 N·m:
    after 2000 samples the phasor error |Ŵe^{iβ̂} − We^{iβ}| is within 5σ√(2/N) ≈ 5e-4 N·m."""
    rng = np.random.default_rng(7)
    W = np.array([[0.027, 0.019, 0.031], [0.01, 0.02, 0.005]])
    beta = np.array([[2.675, 1.609, 0.748], [-2.0, 0.3, -0.9]])
    c = np.array([[1e-3, -2e-3, 5e-4], [0.0, 1e-3, -1e-3]])
    ident = HarmonicIdentifier(WP, forgetting=1.0, batch_size=2)
    dt = 0.25
    for k in range(1, 2001):
        t0, t1 = (k - 1) * dt, k * dt
        # exact averages of the sinusoid: the closed form checked against quad above
        avg = (-np.cos(WP * t1 + beta) + np.cos(WP * t0 + beta)) / (WP * dt)
        y = W * avg + c + rng.normal(0.0, 0.003, size=W.shape)
        ident.update(t0, t1, y)
    err = np.abs(ident.amplitude * np.exp(1j * ident.phase) - W * np.exp(1j * beta))
    assert np.all(err < 5e-4), err
    np.testing.assert_allclose(ident.bias, c, atol=3e-4)
    t = 3.7
    np.testing.assert_allclose(ident.predict(t), W * np.sin(WP * t + beta), atol=5e-4)
    assert ident.n_updates == 2000


def test_forgetting_tracks_a_changed_harmonic():
    """The harmonic jumps at sample 400: with λ = 0.98 the old data weigh 0.98⁴⁰⁰ ≈ 3e-4 at the
    end (estimate within 1e-3), with λ = 1 (plain LS) the estimate is the blend of both."""
    est = {}
    for lam in (0.98, 1.0):
        ident = HarmonicIdentifier(WP, forgetting=lam)
        dt = 0.25
        for k in range(1, 801):
            W, b = (0.02, 0.5) if k <= 400 else (0.035, -1.0)
            t0, t1 = (k - 1) * dt, k * dt
            y = W * (math.cos(WP * t0 + b) - math.cos(WP * t1 + b)) / (WP * dt)
            ident.update(t0, t1, np.full((1, 3), y))
        est[lam] = ident.amplitude * np.exp(1j * ident.phase)
    want = 0.035 * np.exp(-1j)
    assert np.all(np.abs(est[0.98] - want) < 1e-3 * 0.035)
    assert np.all(np.abs(est[1.0] - want) > 0.1 * 0.035)


def test_covariance_is_capped_without_excitation():
    """Intervals of one full period give φ = (0, 0, 1): a, b unobservable, P would grow as λ⁻ᵏ;
    the trace cap keeps it finite and positive definite, no NaN."""
    ident = HarmonicIdentifier(2 * np.pi, forgetting=0.9, max_covariance=1e4)
    for k in range(1, 400):
        ident.update(k - 1.0, float(k), np.ones((1, 3)))
    P = ident.covariance
    assert np.all(np.isfinite(P)) and np.trace(P) <= 3e4 * (1 + 1e-12)
    assert np.linalg.eigvalsh(P)[0] > 0
    np.testing.assert_allclose(ident.bias, 1.0, rtol=1e-6)
    assert np.all(np.isfinite(ident.phase))


def test_identifier_bad_input():
    with pytest.raises(ValueError, match="^frequency"):
        HarmonicIdentifier(0.0)
    with pytest.raises(ValueError, match="^forgetting"):
        HarmonicIdentifier(1.0, forgetting=1.1)
    with pytest.raises(ValueError, match="^max_covariance"):
        HarmonicIdentifier(1.0, initial_covariance=10.0, max_covariance=5.0)
    ident = HarmonicIdentifier(1.0, batch_size=2)
    with pytest.raises(ValueError, match="^residual"):
        ident.update(0.0, 1.0, np.zeros((1, 3)))
    with pytest.raises(ValueError, match="^residual"):
        ident.update(0.0, 1.0, np.full((2, 3), np.nan))
    with pytest.raises(ValueError, match="^t1"):
        ident.update(1.0, 0.5, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="^batch_size"):
        ident.reset(0)


# --------------------------------------------------------------------------- chart law


@pytest.mark.parametrize("seq", ["XYZ", "ZYX", "zyx", "YXZ"])
def test_small_angles_map_to_body_axes(seq):
    """R = R_d exp(εv): the law's attitude error is εv to O(ε²) for every Tait–Bryan sequence."""
    eps = 1e-5
    v = np.array([0.6, -0.3, 0.8])
    ctrl = SmallAnglePIDWithFeedforward(J, WP, seq=seq, mode="off")
    ctrl.reset(0.0, 1)
    R_d = so3.exp(np.array([0.3, -1.0, 2.0]))
    ref = AttitudeReference.regulation(R_d)
    ctrl.command(0.0, _state(R_d @ so3.exp(eps * v), np.zeros(3)), ref)
    e = ctrl.diagnostics()["att_error"][0]
    np.testing.assert_allclose(e, eps * v, atol=5 * eps**2)


def test_rate_error_is_the_seeds_small_angle_kinematics():
    """Orbit frame turning at ω_o = (0, −n, 0): Δφ̇ = (ω_x + nψ, ω_y + n, ω_z − nφ) to first
    order (seed eq. (4): ω_x = φ̇ − nψ, ω_y = θ̇ − n, ω_z = ψ̇ + nφ)."""
    frame = RotatingFrame(so3.exp(np.array([0.1, 0.2, -0.4])), np.array([0.0, -N_ORB, 0.0]))
    errs = []
    for scale in (1.0, 0.5, 0.25):
        ctrl = SmallAnglePIDWithFeedforward(J, WP, mode="off")
        ctrl.reset(0.0, 1)
        ang = scale * np.array([2e-4, -1e-4, 3e-4])  # (φ, θ, ψ), "XYZ"
        w_rel_seed = scale * np.array([1e-5, 2e-5, -3e-5])  # (φ̇, θ̇, ψ̇) to first order
        phi, theta, psi = ang
        w = w_rel_seed + np.array([-N_ORB * psi, -N_ORB, N_ORB * phi])  # seed eq. (4)
        ref = frame(100.0)
        R = ref.R_d @ euler.to_matrix(ang, "XYZ")
        ctrl.command(100.0, _state(R, w), ref)
        e_dot = ctrl.diagnostics()["rate_error"][0]
        errs.append(np.abs(e_dot - w_rel_seed).max())
    # the remainder is second order in (angles, relative rates): ≤ |ang|·(|ω_rel| + n|ang|)
    assert errs[0] < 3e-4 * 4e-5
    np.testing.assert_allclose(errs[0] / errs[1], 4.0, rtol=0.05)
    np.testing.assert_allclose(errs[1] / errs[2], 4.0, rtol=0.05)


def test_law_torque_equation_and_gyroscopic_momentum_options():
    """T = −(k_p e + k_i ∫e + k_d ė) + ω × (Jω + h_x) [+ ω × h], recomputed by hand over two
    samples (rectangle-rule integral)."""
    kp, ki, kd = np.array([3.0, 4.0, 5.0]), np.array([0.1, 0.2, 0.3]), np.array([30.0, 20, 10])
    hx = np.array([0.5, -1.3, 2.4])
    h = np.array([[1.0, 2.0, -3.0]])
    for mode in ("actuator", "controller"):
        law = SmallAnglePIDLaw(J, kp, ki, kd, extra_momentum=hx, gyro_momentum=mode)
        from liecontrol.control.adapters import EulerChartAdapter

        ad = EulerChartAdapter(law, seq="XYZ", base="reference")
        ad.reset(0.0, 1)
        ref = _ref_at_rest()
        ang = np.array([1e-3, -2e-3, 5e-4])
        w = np.array([1e-3, 2e-3, -1e-3])
        R = euler.to_matrix(ang, "XYZ")
        st_ = AttitudeState(R=R[None], omega=w[None], h=h)
        ad.command(0.0, st_, ref)
        u = ad.command(0.25, st_, ref)[0]
        e = ang
        e_dot = euler.kinematics(ang, w, "XYZ")
        hg = hx + (h[0] if mode == "controller" else 0.0)
        want = -(kp * e + ki * 0.25 * e + kd * e_dot) + np.cross(w, J @ w + hg)
        np.testing.assert_allclose(u, want, rtol=1e-12, atol=1e-15)


# --------------------------------------------------------------------------- timing / holds


def test_pid_held_over_dt_c_and_feedforward_first_harmonic_is_exact():
    """Sampled every Δt_p over one payload period (160 calls): the PID part changes only at
    multiples of Δt_c, and the fundamental of the held feed-forward staircase equals
    −W sin(ω_p t + β) exactly with the hold correction (a plain hold lags by Δt_p/2)."""
    W, beta = np.array([0.027, 0.019, 0.031]), np.array([2.7, 1.6, 0.75])
    out = {}
    for corr in (True, False):
        ctrl = SmallAnglePIDWithFeedforward(J, WP, mode="inject", injected=(W, beta),
                                            compensation_start=0.0, hold_correction=corr)
        ctrl.reset(0.0, 1)
        ref = _ref_at_rest()
        comps, pids = [], []
        for k in range(160):
            t = k * 0.025
            # a state that changes every call: the PID part must still be held
            st_ = _state(so3.exp(np.array([1e-4, 0, 0]) * math.sin(t)), np.full(3, 1e-5 * t))
            ctrl.command(t, st_, ref)
            d = ctrl.diagnostics()
            comps.append(d["comp_torque"][0])
            pids.append(d["pid_torque"][0])
        comps, pids = np.array(comps), np.array(pids)
        changes = np.flatnonzero(np.any(np.diff(pids, axis=0) != 0, axis=1)) + 1
        np.testing.assert_array_equal(changes % 10, 0)
        # exact Fourier coefficients of the staircase: Σ u_k ∫ sin/cos over each hold
        tk = np.arange(160) * 0.025
        Is = (np.cos(WP * tk) - np.cos(WP * (tk + 0.025))) / WP
        Ic = (np.sin(WP * (tk + 0.025)) - np.sin(WP * tk)) / WP
        a = 2 / 4.0 * Is @ comps
        b = 2 / 4.0 * Ic @ comps
        out[corr] = a + 1j * b
    want = -W * np.exp(1j * beta)  # −W sin(ωt + β) = −W cos β sin ωt − W sin β cos ωt
    np.testing.assert_allclose(out[True], want, atol=1e-12)
    lag = np.abs(out[False] - want) / W
    np.testing.assert_allclose(lag, 2 * np.sin(WP * 0.025 / 4), rtol=1e-3)  # ≈ ω_pΔt_p/2


def test_compensation_starts_at_compensation_start_and_off_mode_is_pure_pid():
    W, beta = np.ones(3) * 0.02, np.zeros(3)
    ctrl = SmallAnglePIDWithFeedforward(J, WP, mode="inject", injected=(W, beta),
                                        compensation_start=1.0)
    off = SmallAnglePIDWithFeedforward(J, WP, mode="off", compensation_start=0.0)
    ctrl.reset(0.0, 1)
    off.reset(0.0, 1)
    ref = _ref_at_rest()
    st_ = _state(np.eye(3), np.zeros(3))
    for k in range(80):
        t = k * 0.025
        u = ctrl.command(t, st_, ref)
        u_off = off.command(t, st_, ref)
        np.testing.assert_array_equal(u_off, 0.0)
        if t < 1.0:
            np.testing.assert_array_equal(u, 0.0)
        else:
            assert np.abs(u).max() > 0


# --------------------------------------------------------------------------- closed loop


class _SineTorque:
    """T_j = W_j sin(ω t + β_j) + c_j on the bus."""

    def __init__(self, W, beta, c):
        self.W, self.beta, self.c = np.asarray(W), np.asarray(beta), np.asarray(c)

    def __call__(self, t, R, omega):
        return np.broadcast_to(self.W * np.sin(WP * t + self.beta) + self.c, omega.shape).copy()


def _closed_loop(mode, t_on, t_end, injected=None):
    from spacecraft import IdealTorqueActuator, RigidBody, Spacecraft, simulate

    W, beta, c = [0.027, 0.019, 0.031], [2.675, 1.609, 0.748], [2e-3, 0.0, -1e-3]
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(), _SineTorque(W, beta, c))
    ctrl = SmallAnglePIDWithFeedforward(J, WP, mode=mode, injected=injected,
                                        compensation_start=t_on)
    ref = RotatingFrame(np.eye(3), np.array([0.0, -N_ORB, 0.0]))
    x0 = plant.initial_state(np.eye(3), omega0=[0.0, -N_ORB, 0.0])
    res = simulate(plant, ctrl, ref, x0, t_end, 0.025, control_period=0.025, log_every=2)
    R_rel = np.swapaxes(res.R_d[:, 0], -1, -2) @ res.R[:, 0]
    rate = res.omega[:, 0] - np.einsum("kji,kj->ki", R_rel, res.omega_d[:, 0])
    return res, ctrl, rate, np.array(W), np.array(beta), np.array(c)


def _amp_at_wp(t, y):
    """Amplitude of the ω_p sinusoid in y (K, 3), fitted with a line (slow transients)."""
    A = np.column_stack([np.ones_like(t), t - t.mean(), np.sin(WP * t), np.cos(WP * t)])
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    return np.hypot(coef[2], coef[3])


def test_closed_loop_identification_converges_and_compensation_removes_the_jitter():
    """Ideal torques, a sinusoidal disturbance + constant: Ŵ, β̂ within 5 % of the truth (as a
    phasor) before switch-on; the rate oscillation at ω_p ≥ 30× smaller after it; the residual
    is unaffected by the switch (it measures T_d, not the jitter)."""
    t_on, t_end = 120.0, 260.0
    res, ctrl, rate, W, beta, c = _closed_loop("identify", t_on, t_end)
    t = res.t
    k_on = int(np.searchsorted(t, t_on)) - 1
    Wh, bh = res.controller["W_hat"][k_on, 0], res.controller["beta_hat"][k_on, 0]
    err = np.abs(Wh * np.exp(1j * bh) - W * np.exp(1j * beta)) / W
    assert np.all(err < 0.05), err
    Wh2, bh2 = ctrl.identifier.amplitude[0], ctrl.identifier.phase[0]
    assert np.all(np.abs(Wh2 * np.exp(1j * bh2) - W * np.exp(1j * beta)) / W < 0.02)
    np.testing.assert_allclose(ctrl.identifier.bias[0], c, atol=2e-4)
    mb, ma = (t > t_on - 40) & (t < t_on), t > t_on + 100
    before, after = _amp_at_wp(t[mb], rate[mb]), _amp_at_wp(t[ma], rate[ma])
    assert np.all(after < before / 30), (before, after)
    # the identifier's residual = the interval-averaged disturbance, with or without FF
    r = res.controller["residual"][:, 0]
    for m in (t < t_on, t > t_on + 1):
        tt = t[m][10:]
        avg = (W * (np.cos(WP * (tt[:, None] - 0.25) + beta) - np.cos(WP * tt[:, None] + beta))
               / (WP * 0.25) + c)
        # the residual is refreshed at PID samples; compare at PID-sample rows
        on_grid = np.isclose((tt / 0.25) % 1.0, 0.0, atol=1e-6)
        np.testing.assert_allclose(r[m][10:][on_grid], avg[on_grid], atol=2e-4)


def test_injected_mode_cancels_the_harmonic():
    t_on = 40.0
    W, beta = np.array([0.027, 0.019, 0.031]), np.array([2.675, 1.609, 0.748])
    res, ctrl, rate, *_ = _closed_loop("inject", t_on, 160.0, injected=(W, beta))
    t = res.t
    mb, ma = (t > 20) & (t < t_on), t > t_on + 100
    before, after = _amp_at_wp(t[mb], rate[mb]), _amp_at_wp(t[ma], rate[ma])
    assert np.all(after < before / 100), (before, after)


# --------------------------------------------------------------------------- bad input


def test_bad_input_raises_value_error_naming_the_argument():
    with pytest.raises(ValueError, match="^J"):
        SmallAnglePIDWithFeedforward(np.diag([1.0, 1.0, 3.0]), WP)
    with pytest.raises(ValueError, match="^payload_frequency"):
        SmallAnglePIDWithFeedforward(J, -1.0)
    with pytest.raises(ValueError, match="^payload_frequency"):
        SmallAnglePIDWithFeedforward(J, 13.0)  # ω_p Δt_c > π
    with pytest.raises(ValueError, match="^dt_c"):
        SmallAnglePIDWithFeedforward(J, WP, dt_c=0.25, dt_p=0.03)
    with pytest.raises(ValueError, match="^dt_p"):
        SmallAnglePIDWithFeedforward(J, WP, dt_p=0.0)
    with pytest.raises(ValueError, match="^mode"):
        SmallAnglePIDWithFeedforward(J, WP, mode="kalman")
    with pytest.raises(ValueError, match="^injected"):
        SmallAnglePIDWithFeedforward(J, WP, mode="inject")
    with pytest.raises(ValueError, match="^injected"):
        SmallAnglePIDWithFeedforward(J, WP, mode="inject", injected=(-np.ones(3), np.zeros(3)))
    with pytest.raises(ValueError, match="^seq"):
        SmallAnglePIDWithFeedforward(J, WP, seq="ZXZ")
    with pytest.raises(ValueError, match="^gyro_momentum"):
        SmallAnglePIDWithFeedforward(J, WP, gyro_momentum="wheels")
    with pytest.raises(ValueError, match="^extra_momentum"):
        SmallAnglePIDWithFeedforward(J, WP, extra_momentum=np.ones(2))
    with pytest.raises(ValueError, match="^bandwidth_hz"):
        SmallAnglePIDWithFeedforward(J, WP, bandwidth_hz=0.0)
    ctrl = SmallAnglePIDWithFeedforward(J, WP)
    ref = _ref_at_rest()
    st_ = _state(np.eye(3), np.zeros(3))
    with pytest.raises(RuntimeError):
        ctrl.command(0.0, st_, ref)
    ctrl.reset(0.0, 1)
    ctrl.command(0.0, st_, ref)
    with pytest.raises(ValueError, match="^t"):
        ctrl.command(0.25, st_, ref)  # gap > Δt_p: the feed-forward would be under-sampled
    ctrl.reset(0.0, 1)
    ctrl.command(0.025, st_, ref)
    with pytest.raises(ValueError, match="^t"):
        ctrl.command(0.0, st_, ref)
    ctrl.reset(0.0, 1)
    with pytest.raises(ValueError, match="^R"):  # the state is read at PID samples
        ctrl.command(0.0, _state(np.eye(3) * 1.1, np.zeros(3)), ref)
    with pytest.raises(ValueError, match="^batch_size"):
        ctrl.reset(0.0, 0)
    inj = SmallAnglePIDWithFeedforward(J, WP, mode="inject",
                                       injected=(np.ones((2, 3)), np.zeros((2, 3))))
    with pytest.raises(ValueError, match="^injected"):
        inj.reset(0.0, 3)


def test_batch_of_spacecraft_matches_single_runs():
    """B = 2 vectorised = two B = 1 controllers (no Python loop over the batch needed)."""
    ref = _ref_at_rest()
    rng = np.random.default_rng(1)
    Rs = so3.exp(rng.normal(0, 1e-3, (2, 3)))
    ws = rng.normal(0, 1e-4, (2, 3))
    both = SmallAnglePIDWithFeedforward(J, WP, compensation_start=0.0)
    both.reset(0.0, 2)
    singles = [SmallAnglePIDWithFeedforward(J, WP, compensation_start=0.0) for _ in range(2)]
    for s in singles:
        s.reset(0.0, 1)
    for k in range(25):
        t = k * 0.025
        wk = ws * (1 + 0.1 * k)
        u = both.command(t, AttitudeState(R=Rs, omega=wk), ref)
        for b, s in enumerate(singles):
            ub = s.command(t, AttitudeState(R=Rs[b:b + 1], omega=wk[b:b + 1]), ref)
            np.testing.assert_allclose(u[b:b + 1], ub, rtol=1e-12, atol=1e-18)
