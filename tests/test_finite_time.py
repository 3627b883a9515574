"""Finite- and fixed-time terminal sliding mode on SO(3) (liecontrol.control.finite_time).

Every formula against an independent route: the error kinematics and the closed-loop ṡ by finite
differences of an accurately integrated rigid body, the slide time by an ODE solve, the reaching
time by its closed form, the settling bound by simulation from Haar-sampled starts."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import SEED000_J, seed000_spacecraft
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from liecontrol.control import AttitudeReference, AttitudeState, ConstantAttitude
from liecontrol.control.finite_time import (
    FiniteTimeParams,
    FiniteTimeSO3,
    FixedTimeSO3,
    angle_decay_rate,
    convergence_time_bound,
    reaching_time,
    sliding_time,
    sliding_variable,
    terminal_gain,
)
from liecontrol.control.tuning import ClosedLoopSpec, tune_finite_time_so3
from liecontrol.lie import so3
from spacecraft import simulate
from spacecraft.actuators import IdealTorqueActuator
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody

J = SEED000_J
CL_SPEC = ClosedLoopSpec(0.2, 0.9, 0.02)


def _ctrl(fixed: bool, spec: ClosedLoopSpec = CL_SPEC) -> FiniteTimeSO3:
    kw = tune_finite_time_so3(J, spec, fixed_time=fixed)
    return (FixedTimeSO3 if fixed else FiniteTimeSO3)(J, **kw)


def _settle(res, tol):
    """Per spacecraft: first logged time after which the error angle stays ≤ tol."""
    err = res.attitude_error_angle()
    out = []
    for b in range(err.shape[1]):
        above = np.nonzero(err[:, b] > tol)[0]
        out.append(res.t[0] if above.size == 0 else res.t[min(above[-1] + 1, res.t.size - 1)])
    return np.array(out), err


def _path_ratio(res, theta0):
    """∫‖e_Ω‖dt / θ₀ (regulation: e_Ω = Ω), the unwinding measure of benchmarks.unwinding."""
    w = np.linalg.norm(res.omega, axis=-1)
    path = 0.5 * np.sum((w[1:] + w[:-1]) * np.diff(res.t)[:, None], axis=0)
    return path / theta0


@pytest.mark.parametrize("fixed", [False, True])
def test_haar_starts_settle_before_the_bound_without_unwinding(fixed):
    """Haar-uniform attitudes (seeded), at rest and with random rates: the angle reaches the
    tolerance before convergence_time_bound, and rest starts travel ≈ the geodesic angle."""
    c = _ctrl(fixed)
    rng = np.random.default_rng(20261124)
    B = 6
    R0 = Rotation.random(B, random_state=rng).as_matrix()
    w0 = np.zeros((B, 3))
    w0[B // 2 :] = rng.normal(scale=0.03, size=(B - B // 2, 3))
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    s0, _, _ = sliding_variable(R0, w0, np.eye(3), np.zeros(3), c.params)
    theta0 = so3.angle(R0)
    tol = np.deg2rad(0.2)
    bounds = np.array(
        [c.convergence_time_bound(tol, theta0[b], np.linalg.norm(s0[b])) for b in range(B)]
    )
    dt = 0.02
    t_final = dt * math.ceil(1.05 * bounds.max() / dt)
    res = simulate(plant, c, ConstantAttitude(np.eye(3)), plant.initial_state(R0, w0), t_final, dt)
    t_s, err = _settle(res, tol)
    # the bound is for the continuous law; the sampled loop (zero-order hold, T_s = dt) lags by
    # about T_s/2 and the logged settling time is quantised to dt: allow 3 dt
    assert np.all(t_s <= bounds + 3 * dt), (t_s, bounds)
    assert np.all(err[-1] <= tol)
    ratio = _path_ratio(res, theta0)
    assert np.all(ratio[: B // 2] < 1.02), ratio  # rest starts: the short way, no unwinding
    assert np.all(ratio < 1.5), ratio  # the unwinding verdict's threshold
    if fixed:
        assert np.all(bounds <= c.settling_bound(tol) + 1e-9)


def test_fixed_time_bound_holds_for_a_tumbling_start():
    """≈1 rad/s tumbling at 170°: the uniform bound (no initial-condition input) still holds."""
    c = _ctrl(True)
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    R0 = so3.exp(np.deg2rad(170.0) * np.array([0.0, 0.6, 0.8]))[None]
    w0 = np.array([[0.6, -0.5, 0.62]])
    tol = np.deg2rad(0.2)
    T = c.settling_bound(tol)
    t_f = 0.02 * math.ceil(T / 0.02)
    res = simulate(plant, c, ConstantAttitude(np.eye(3)), plant.initial_state(R0, w0), t_f, 0.02)
    t_s, _ = _settle(res, tol)
    assert t_s[0] <= T
    # the finite-time law's bound grows with the start's ‖s(0)‖, the fixed-time one's does not
    s0 = np.linalg.norm(sliding_variable(R0, w0, np.eye(3), np.zeros(3), c.params)[0])
    f = _ctrl(False)
    assert f.convergence_time_bound(tol, math.pi, 100 * s0) > f.convergence_time_bound(
        tol, math.pi, s0
    )
    assert c.convergence_time_bound(tol, math.pi, 1e6 * s0) <= T


def test_sgcmg_closed_loop_slew():
    """90° rest-to-rest on the SGCMG pyramid through spacecraft.simulate (ω_n = 0.03 rad/s)."""
    plant = seed000_spacecraft()
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    R_d = so3.exp(np.deg2rad(90.0) * axis)
    spec = ClosedLoopSpec(0.03, 0.9, 0.1)
    ctrls = [_ctrl(False, spec), _ctrl(True, spec)]
    for c in ctrls:
        res = simulate(plant, c, ConstantAttitude(R_d), plant.initial_state(np.eye(3)), 400.0, 0.1)
        assert np.rad2deg(res.attitude_error_angle()[-1, 0]) < 0.05
        assert np.abs(res.actuator["delta_dot"]).max() <= 1.0 + 1e-12
        assert not res.actuator["saturated"].any()
        # the commanded torque went through the CMGs
        assert np.abs(res.u - res.u_cmd).max() < 0.01 * np.abs(res.u_cmd).max()
        d = c.diagnostics()
        assert set(d) == {"Psi", "theta", "e_R", "e_Omega", "s"}


def _rigid_flow(R, w, M, h):
    """(R, ω) after time h of JΩ̇ + Ω × JΩ = M (constant M), RK45 at rtol 1e-12."""

    def f(_t, z):
        Rm, om = z[:9].reshape(3, 3), z[9:]
        return np.concatenate(
            [(Rm @ so3.hat(om)).ravel(), np.linalg.solve(J, M - np.cross(om, J @ om))]
        )

    z = solve_ivp(f, (0, h), np.concatenate([R.ravel(), w]), rtol=1e-12, atol=1e-14).y[:, -1]
    U, _, Vt = np.linalg.svd(z[:9].reshape(3, 3))
    return U @ Vt, z[9:]


@pytest.mark.parametrize(
    "angle_deg, fixed", [(150.0, False), (40.0, True), (1.0, False), (0.05, True)]
)
def test_commanded_torque_gives_the_reaching_law(angle_deg, fixed):
    """Finite differences of s along the true closed-loop flow (tracking, ω_d ≠ 0): ṡ = −k_s s,
    through both layers (1° and 0.05° are inside ‖e_R‖ < ε)."""
    c = _ctrl(fixed)
    prm = c.params
    rng = np.random.default_rng(7)
    R_d0 = so3.exp(rng.normal(size=3))
    w_d = np.array([0.01, -0.02, 0.015])
    R = R_d0 @ so3.exp(np.deg2rad(angle_deg) * np.array([0.48, -0.6, 0.64]))
    w = rng.normal(scale=0.02, size=3)
    c.reset(0.0, 1)
    ref = AttitudeReference(R_d=R_d0, omega_d=w_d, omega_dot_d=np.zeros(3))
    M = c.command(0.0, AttitudeState(R=R[None], omega=w[None]), ref)[0]
    h = 1e-3

    def s_at(t):
        Rt, wt = _rigid_flow(R, w, M, t) if t > 0 else _rigid_flow_back(R, w, M, -t)
        return sliding_variable(Rt, wt, R_d0 @ so3.exp(t * w_d), w_d, prm)[0]

    sdot = (s_at(h) - s_at(-h)) / (2 * h)
    s = sliding_variable(R, w, R_d0, w_d, prm)[0]
    y = np.linalg.norm(s)
    ks = prm.c1 + prm.c2 * terminal_gain(y, prm.rho, prm.eps_s) + prm.c3 * y ** (prm.mu - 1)
    np.testing.assert_allclose(sdot, -ks * s, rtol=2e-5, atol=1e-9)
    np.testing.assert_allclose(c.diagnostics()["s"][0], s, atol=1e-14)


def _rigid_flow_back(R, w, M, h):
    """Backward flow: integrate the time-reversed rigid body (Ṙ = −RΩ^, Ω̇ = −J⁻¹(…))."""

    def f(_t, z):
        Rm, om = z[:9].reshape(3, 3), z[9:]
        return -np.concatenate(
            [(Rm @ so3.hat(om)).ravel(), np.linalg.solve(J, M - np.cross(om, J @ om))]
        )

    z = solve_ivp(f, (0, h), np.concatenate([R.ravel(), w]), rtol=1e-12, atol=1e-14).y[:, -1]
    U, _, Vt = np.linalg.svd(z[:9].reshape(3, 3))
    return U @ Vt, z[9:]


def test_error_kinematics_and_angle_rate_by_finite_differences():
    """ė_R = ½(q₀e_Ω + e_R × e_Ω) and, on s = 0, θ̇ = −h(θ)."""
    prm = _ctrl(False).params
    for deg in (5.0, 100.0, 175.0):
        R = so3.exp(np.deg2rad(deg) * np.array([0.0, 0.6, 0.8]))
        _, e_R, _ = sliding_variable(R, np.zeros(3), np.eye(3), np.zeros(3), prm)
        x = np.linalg.norm(e_R)
        # on the surface: Ω = −(k₁ + k₂g)e_R
        w = -(prm.k1 + prm.k2 * terminal_gain(x, prm.r, prm.eps)) * e_R
        h = 1e-6

        def eR(t, R=R, w=w):
            return sliding_variable(R @ so3.exp(t * w), w, np.eye(3), np.zeros(3), prm)[1]

        fd = (eR(h) - eR(-h)) / (2 * h)
        q0 = math.cos(np.deg2rad(deg) / 2)
        np.testing.assert_allclose(fd, 0.5 * (q0 * w + np.cross(e_R, w)), rtol=1e-7, atol=1e-9)
        th = lambda t, R=R, w=w: float(so3.angle(R @ so3.exp(t * w)))  # noqa: E731
        np.testing.assert_allclose(
            (th(h) - th(-h)) / (2 * h), -angle_decay_rate(np.deg2rad(deg), prm), rtol=1e-7
        )


def test_terminal_gain_is_c1_and_the_power_above_eps():
    p, eps = 0.5, 0.05
    x = np.array([0.06, 0.3, 1.0])
    np.testing.assert_allclose(terminal_gain(x, p, eps), x ** (p - 1), rtol=1e-15)
    d = 1e-7
    lo, hi = terminal_gain(eps - d, p, eps), terminal_gain(eps + d, p, eps)
    assert abs(hi - lo) < 1e-5 * eps ** (p - 1)  # continuous
    left = (terminal_gain(eps - d, p, eps) - terminal_gain(eps - 2 * d, p, eps)) / d
    right = (terminal_gain(eps + 2 * d, p, eps) - terminal_gain(eps + d, p, eps)) / d
    np.testing.assert_allclose(left, right, rtol=1e-4)  # C¹
    np.testing.assert_allclose(right, (p - 1) * eps ** (p - 2), rtol=1e-4)


def test_sliding_time_matches_an_ode_solve():
    prm = _ctrl(False).params
    tol = np.deg2rad(0.5)
    for th0 in (math.pi, 1.0, 0.2):
        ev = lambda _t, z: z[0] - tol  # noqa: E731
        ev.terminal = True
        sol = solve_ivp(
            lambda _t, z: [-float(angle_decay_rate(min(z[0], math.pi), prm))],
            (0, 1e4),
            [th0],
            events=ev,
            rtol=1e-11,
            atol=1e-13,
        )
        np.testing.assert_allclose(sliding_time(prm, th0, tol), sol.t_events[0][0], rtol=1e-7)
        # s₀ = 0: the comparison system is the slide alone
        np.testing.assert_allclose(
            convergence_time_bound(prm, tol, th0, 0.0), sliding_time(prm, th0, tol), rtol=1e-7
        )


def test_reaching_time_closed_forms():
    """Above the layer with c₁ = c₃ = 0: t = (s₀^(1−ρ) − s₁^(1−ρ)) / (c₂(1−ρ)); the fixed-time
    term bounds the time from s₀ = ∞ by 1/(c₂(1−ρ)) + 1/(c₃(μ−1)) (Polyakov 2012)."""
    prm = FiniteTimeParams(k1=0.1, k2=0.02, r=0.5, eps=0.05, c1=0.0, c2=0.3, rho=0.6, eps_s=1e-3)
    s0, s1 = 2.0, 0.01
    exact = (s0**0.4 - s1**0.4) / (0.3 * 0.4)
    np.testing.assert_allclose(reaching_time(prm, s0, s1), exact, rtol=1e-8)
    fx = FiniteTimeParams(
        k1=0.1, k2=0.02, r=0.5, eps=0.05, c1=0.0, c2=0.3, rho=0.6, eps_s=1e-3, c3=0.2, mu=1.5
    )
    t_inf = reaching_time(fx, math.inf, 1e-3)
    assert t_inf <= 1 / (0.3 * 0.4) + 1 / (0.2 * 0.5)
    assert reaching_time(fx, 1e8, 1e-3) <= t_inf


def test_tuning_places_the_small_angle_poles():
    for zeta in (0.9, 1.5):
        spec = ClosedLoopSpec(0.05, zeta, 0.1)
        kw = tune_finite_time_so3(J, spec)
        lam, kap = FiniteTimeSO3(J, **kw).params.small_angle_poles
        if zeta <= 1:
            np.testing.assert_allclose([lam, kap], [0.05, 0.05], rtol=1e-12)
        else:
            np.testing.assert_allclose(lam * kap, 0.05**2, rtol=1e-12)
            np.testing.assert_allclose(lam + kap, 2 * zeta * 0.05, rtol=1e-12)
    # the linearised loop, measured: a 0.01° step decays like (1 + ω_n t)e^(−ω_n t)
    c = _ctrl(False)
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    R0 = so3.exp(np.deg2rad(0.01) * np.array([1.0, 0.0, 0.0]))
    res = simulate(plant, c, ConstantAttitude(np.eye(3)), plant.initial_state(R0), 10.0, 0.01)
    th = res.attitude_error_angle()[:, 0] / np.deg2rad(0.01)
    wt = 0.2 * res.t
    np.testing.assert_allclose(th, (1 + wt) * np.exp(-wt), atol=3e-3)


def test_bad_input_names_the_argument():
    good = dict(k1=0.1, k2=0.02, r=0.5, eps=0.05, c1=0.0, c2=0.3, rho=0.6, eps_s=1e-3)
    for name, bad in (
        ("k2", 0.0),
        ("r", 1.0),
        ("eps", -0.1),
        ("rho", float("nan")),
        ("c1", -1.0),
        ("eps_s", 0.0),
    ):
        with pytest.raises(ValueError, match=f"^{name}:"):
            FiniteTimeParams(**{**good, name: bad})
    with pytest.raises(ValueError, match="^mu:"):
        FiniteTimeParams(**good, mu=1.0)
    prm = FiniteTimeParams(**good)
    with pytest.raises(ValueError, match="^s0:"):
        convergence_time_bound(prm, 0.01)  # s0 = inf without the fixed-time term
    with pytest.raises(ValueError, match="^tol:"):
        convergence_time_bound(prm, 0.0, 1.0, 0.1)
    with pytest.raises(ValueError, match="^theta0:"):
        sliding_time(prm, 4.0, 0.1)
    with pytest.raises(ValueError, match="^s1:"):
        reaching_time(prm, 1.0, 0.0)
    with pytest.raises(TypeError, match="^params:"):
        sliding_time(good, 1.0, 0.1)
    with pytest.raises(ValueError, match="^c3:"):
        FixedTimeSO3(J, 0.1, 0.02, 0.3, c3=0.0)
    with pytest.raises(ValueError, match="^x:"):
        terminal_gain(-1.0, 0.5, 0.05)
    with pytest.raises(ValueError, match="^terminal_share:"):
        tune_finite_time_so3(J, CL_SPEC, terminal_share=2.0)
    c = FiniteTimeSO3(J, 0.1, 0.02, 0.3)
    st = AttitudeState(R=np.eye(3)[None], omega=np.zeros((1, 3)))
    with pytest.raises(RuntimeError, match="reset"):
        c.command(0.0, st, ConstantAttitude(np.eye(3))(0.0))
    c.reset(0.0, 2)
    with pytest.raises(ValueError, match="^state:"):
        c.command(0.0, st, ConstantAttitude(np.eye(3))(0.0))
    with pytest.raises(ValueError, match="^batch_size:"):
        c.reset(0.0, 0)
    # inputs are not mutated
    R = np.eye(3)[None].copy()
    w = np.array([[0.1, 0.0, 0.0]])
    c.reset(0.0, 1)
    c.command(0.0, AttitudeState(R=R, omega=w), ConstantAttitude(np.eye(3))(0.0))
    assert np.array_equal(w, [[0.1, 0.0, 0.0]]) and np.array_equal(R[0], np.eye(3))


def test_batched_equals_one_by_one():
    c = _ctrl(True)
    rng = np.random.default_rng(3)
    R = Rotation.random(5, random_state=rng).as_matrix()
    # starts near θ = π, where the log takes the axis from the symmetric part
    axis = np.array([0.36, 0.48, 0.8])
    R_d0 = so3.exp(np.array([0.3, -0.2, 0.1]))
    R[3] = R_d0 @ so3.exp(np.deg2rad(179.95) * axis)
    R[4] = R_d0 @ so3.exp(np.deg2rad(179.0) * axis)
    w = rng.normal(scale=0.05, size=(5, 3))
    ref = AttitudeReference(R_d=R_d0, omega_d=np.array([0.01, 0, 0]), omega_dot_d=np.zeros(3))
    c.reset(0.0, 5)
    M = c.command(1.0, AttitudeState(R=R, omega=w), ref)
    c.reset(0.0, 1)
    for b in range(5):
        Mb = c.command(1.0, AttitudeState(R=R[b : b + 1], omega=w[b : b + 1]), ref)
        np.testing.assert_allclose(Mb[0], M[b], rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------- compiled kernel == numpy route


def _kernel_case(B, rng, batched_reference):
    """B attitudes with angles to the reference at π, next to π (both sides of the log's
    symmetric-part branch), inside the ε layer, at 0 and random; tracking (ω_d, ω̇_d ≠ 0)."""
    R_d = so3.exp(rng.normal(size=(B, 3)) if batched_reference else rng.normal(size=3))
    R_db = np.broadcast_to(R_d, (B, 3, 3))
    axis = np.array([0.36, 0.48, 0.8])
    degs = [180.0, 0.0, 179.9999, 1e-7, 179.95, 0.5, 177.0, 60.0]
    R = so3.exp(rng.normal(size=(B, 3)))
    for b in range(B):
        if b < len(degs):
            R[b] = R_db[b] @ so3.exp(np.deg2rad(degs[b]) * axis)
    w = rng.normal(scale=0.05, size=(B, 3))
    shape = (B, 3) if batched_reference else (3,)
    w_d = rng.normal(scale=0.02, size=shape)
    dw_d = rng.normal(scale=0.005, size=shape)
    return R, w, R_d, w_d, dw_d


@pytest.mark.parametrize("fixed", [False, True])
@pytest.mark.parametrize("batch", [(), (5,), (2, 3)])
@pytest.mark.parametrize("batched_reference", [False, True])
def test_kernel_equals_numpy_route(fixed, batch, batched_reference):
    """The compiled kernel (the one implementation of the law, used at B = 1 and, when numba is
    present, for every batch) equals the batched numpy route to 1e-12, torque and diagnostics,
    including θ = π, θ → π, θ = 0 and tracking. Batch shape () is one spacecraft through
    finite_time_one directly; (2, 3) is flattened (the controller takes (B, 3, 3))."""
    from liecontrol._kernels.finite_time import N_DIAG, finite_time_one

    c = _ctrl(fixed)
    B = math.prod(batch)
    rng = np.random.default_rng(20261124 + B)
    R, w, R_d, w_d, dw_d = _kernel_case(B, rng, batched_reference and batch != ())
    c.reset(0.0, B)
    M_np = c._command_numpy(R, w, R_d, w_d, dw_d)
    d_np = c.diagnostics()
    if batch == ():
        M_k, diag = np.empty((1, 3)), np.empty((1, N_DIAG))
        kJ, kprm = c._kernel_args()
        finite_time_one(kJ, kprm, R[0], w[0], R_d, w_d, dw_d, M_k[0], diag[0])
        d_k = {"Psi": diag[:, 0], "theta": diag[:, 1], "e_R": diag[:, 2:5],
               "e_Omega": diag[:, 5:8], "s": diag[:, 8:11]}  # fmt: skip
    else:
        M_k = c._command_kernel(R, w, R_d, w_d, dw_d)
        d_k = c.diagnostics()
    M_pub = c.command(0.0, AttitudeState(R=R, omega=w), AttitudeReference(R_d, w_d, dw_d))
    scale = float(np.abs(M_np).max())
    np.testing.assert_allclose(M_k, M_np, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(M_pub, M_np, rtol=0, atol=1e-12 * scale)
    for key in ("Psi", "theta", "e_R", "e_Omega", "s"):
        np.testing.assert_allclose(d_k[key], d_np[key], rtol=0, atol=1e-12, err_msg=key)
    # θ = π is in the case: Ψ = 2 there, and e_R a unit vector
    np.testing.assert_allclose(d_k["Psi"][0], 2.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(d_k["e_R"][0]), 1.0, atol=1e-12)


def test_kernel_equals_numpy_route_at_huge_rates_without_fixed_time_term():
    """c₃ = 0 with a large μ: y^(μ−1) overflows, but the term is absent; both routes give the
    same finite torque instead of 0·inf = NaN."""
    c = FiniteTimeSO3(J, k1=0.5, k2=0.3, c2=0.2, mu=5.0)
    R = so3.exp(np.array([[0.3, -0.2, 1.0]]))
    w = np.array([[1e80, -2e80, 0.5e80]])
    c.reset(0.0, 1)
    ref = AttitudeReference(np.eye(3), np.zeros(3), np.zeros(3))
    M_k = c.command(0.0, AttitudeState(R=R, omega=w), ref)
    M_np = c._command_numpy(R, w, np.eye(3), np.zeros(3), np.zeros(3))
    assert np.all(np.isfinite(M_k))
    np.testing.assert_allclose(M_k, M_np, rtol=1e-12)


def test_study_arguments_are_validated():
    from benchmarks.finite_time_study import convergence_claim, unwinding_table

    for kw, name in (
        ({"n_starts": 1}, "n_starts"),
        ({"tol_deg": 0.0}, "tol_deg"),
        ({"rate_std": -1.0}, "rate_std"),
        ({"dt": float("nan")}, "dt"),
    ):
        with pytest.raises(ValueError, match=f"^{name}:"):
            convergence_claim(**kw)
    with pytest.raises(TypeError, match="^cfg:"):
        unwinding_table("quick")
