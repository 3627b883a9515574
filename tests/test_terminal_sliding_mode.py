"""Terminal sliding mode on Euler angles (SPEC §6.2, seed 004): feedback linearisation against
finite differences of the Euler kinematics and the seed's closed form, the time-shaping
polynomial, σ(0) = 0, the σ dynamics identity, gimbal lock and bad input."""

from __future__ import annotations

import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from liecontrol.charts import euler
from liecontrol.control.adapters import RotatingFrame
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.terminal_sliding_mode import (
    SHAPING_COEFFICIENTS,
    TerminalSlidingMode,
    TerminalSlidingModeSO3,
    TSMParams,
    euler_angle_acceleration,
    euler_feedback_linearisation,
    euler_reference,
    sliding_surface,
    time_shaping_polynomial,
    tsm_control,
)
from liecontrol.exceptions import ChartSingularityError
from liecontrol.lie import so3

J_FULL = np.array([[10.0, 1.0, -0.5], [1.0, 12.0, 0.3], [-0.5, 0.3, 15.0]])


def _hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _flow(R0, w0, J, L, h, with_rate=False):
    """Integrate the rigid body (R, ω) for time h (may be negative) with constant torque L;
    returns R(h) (and ω(h) when ``with_rate``)."""

    def f(t, x):
        R = x[:9].reshape(3, 3)
        w = x[9:]
        wd = np.linalg.solve(J, L - np.cross(w, J @ w))
        return np.concatenate([(R @ _hat(w)).ravel(), wd])

    s = solve_ivp(f, (0.0, h), np.concatenate([R0.ravel(), w0]), method="DOP853", rtol=1e-12,
                  atol=1e-13)
    R = s.y[:9, -1].reshape(3, 3)
    return (R, s.y[9:, -1]) if with_rate else R


def _angles(R, seq):
    return Rotation.from_matrix(R).as_euler(seq)


def _start_angles(seq, rng):
    tb = euler.is_tait_bryan(seq)
    a2 = rng.uniform(-1.2, 1.2) if tb else rng.uniform(0.4, 2.7)
    return np.array([rng.uniform(-2.5, 2.5), a2, rng.uniform(-2.5, 2.5)])


# -- feedback linearisation ----------------------------------------------------------------------


@pytest.mark.parametrize("seq", ["ZYX", "XYZ", "ZXZ", "xyz", "zyx", "yzy"])
def test_b_and_A_against_finite_differences_of_the_euler_kinematics(seq):
    """ÿ from a second central difference of scipy's Euler angles along the true rigid-body
    trajectory (full inertia, random torque) equals b + A J⁻¹L."""
    # a stable seed: hash(str) changes with every process (PYTHONHASHSEED), which made the draw
    # — and whether the O(h²) difference error stays under atol — differ from run to run
    rng = np.random.default_rng(zlib.crc32(seq.encode()))
    a0 = _start_angles(seq, rng)
    w0 = rng.normal(size=3) * 0.5
    L = rng.normal(size=3)
    R0 = euler.to_matrix(a0, seq)
    h = 1e-3
    ap, am = _angles(_flow(R0, w0, J_FULL, L, h), seq), _angles(_flow(R0, w0, J_FULL, L, -h), seq)
    y0 = _angles(R0, seq)
    fd_acc = (ap - 2.0 * y0 + am) / h**2
    fd_rate = (ap - am) / (2.0 * h)
    A, b = euler_feedback_linearisation(a0, w0, J_FULL, seq)
    np.testing.assert_allclose(b + A @ np.linalg.solve(J_FULL, L), fd_acc, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(A @ w0, fd_rate, rtol=1e-5, atol=1e-6)


def test_A_is_the_partial_of_the_euler_rates_wrt_omega():
    """A = ∂ẏ/∂ω column by column: central differences of from_matrix(R exp(±h e_k^))."""
    rng = np.random.default_rng(3)
    a = np.array([0.4, -0.7, 1.1])
    R = euler.to_matrix(a, "ZYX")
    A, _ = euler_feedback_linearisation(a, rng.normal(size=3), J_FULL)
    h = 1e-6
    for k in range(3):
        dw = np.zeros(3)
        dw[k] = h
        col = (_angles(R @ so3.exp(dw), "ZYX") - _angles(R @ so3.exp(-dw), "ZYX")) / (2 * h)
        np.testing.assert_allclose(A[:, k], col, atol=1e-8)


@settings(max_examples=40, deadline=None)
@given(
    a=st.tuples(st.floats(-3.0, 3.0), st.floats(-1.4, 1.4), st.floats(-3.0, 3.0)),
    w=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
    Jd=st.tuples(*[st.floats(10.0, 19.9)] * 3),  # any three in [10, 20) are a physical body
)
def test_b_matches_the_seed_closed_form_eq12(a, w, Jd):
    """Seed eq. (12) (3-2-1, principal inertia), written out with its k₁…k₈."""
    Ix, Iy, Iz = Jd
    x1, x2, x3 = w
    _, x5, x6 = a
    k1 = x2 * x3 * (Iy - Iz) / Ix
    k2 = x3 * x1 * (Iz - Ix) / Iy
    k3 = x1 * x2 * (Ix - Iy) / Iz
    s6, c6, t5 = np.sin(x6), np.cos(x6), np.tan(x5)
    k4, k5 = k2 * s6 + k3 * c6, k2 * c6 - k3 * s6
    k6, k7 = x2 * s6 + x3 * c6, x2 * c6 - x3 * s6
    k8 = k6 * k7
    b_seed = [
        (k4 + 2 * k8 * t5 + k7 * x1) / np.cos(x5),
        k5 - k6 * x1 - k6**2 * t5,
        k1 + (k4 + k7 * x1) * t5 + k8 * (1 + 2 * t5**2),
    ]
    A_seed = np.array([[0, s6 / np.cos(x5), c6 / np.cos(x5)], [0, c6, -s6], [1, t5 * s6, t5 * c6]])
    A, b = euler_feedback_linearisation(a, w, np.diag([Ix, Iy, Iz]))
    scale = 1.0 + np.abs(b_seed).max()
    np.testing.assert_allclose(b, b_seed, atol=1e-10 * scale)
    np.testing.assert_allclose(A, A_seed, atol=1e-12 / np.cos(x5) ** 2)


def test_feedback_linearisation_is_batched_and_pure():
    rng = np.random.default_rng(5)
    a = np.column_stack([rng.uniform(-3, 3, 7), rng.uniform(-1.3, 1.3, 7), rng.uniform(-3, 3, 7)])
    a = a.reshape(7, 3)
    w = rng.normal(size=(7, 3))
    a_copy, w_copy = a.copy(), w.copy()
    A, b = euler_feedback_linearisation(a, w, J_FULL, "ZYX")
    assert A.shape == (7, 3, 3) and b.shape == (7, 3)
    for i in range(7):
        Ai, bi = euler_feedback_linearisation(a[i], w[i], J_FULL, "ZYX")
        np.testing.assert_allclose(A[i], Ai, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(b[i], bi, rtol=1e-13, atol=1e-14)
    np.testing.assert_array_equal(a, a_copy)
    np.testing.assert_array_equal(w, w_copy)


def test_rotating_base_linearisation_against_finite_differences():
    """Angles of the body relative to a frame turning at ω_b: ÿ_rel from central differences of
    y_rel(t) = euler(R_b(t)ᵀ R(t)) equals b + A J⁻¹L with omega_base = C_bo ω_b."""
    rng = np.random.default_rng(11)
    frame = RotatingFrame(R0=so3.exp(np.array([0.2, -0.1, 0.3])),
                          omega=np.array([0.0, -0.05, 0.02]))
    a0 = np.array([0.3, 0.5, -0.8])
    R_rel0 = euler.to_matrix(a0, "ZYX")
    R0 = frame(0.0).R_d @ R_rel0
    w0 = rng.normal(size=3) * 0.3
    L = rng.normal(size=3)
    h = 1e-3
    ys = [_angles(frame(s).R_d.T @ (_flow(R0, w0, J_FULL, L, s) if s else R0), "ZYX")
          for s in (-h, 0.0, h)]
    fd = (ys[2] - 2 * ys[1] + ys[0]) / h**2
    wb_body = R_rel0.T @ frame.omega
    A, b = euler_feedback_linearisation(a0, w0, J_FULL, omega_base=wb_body,
                                        omega_dot_base=np.zeros(3))
    np.testing.assert_allclose(b + A @ np.linalg.solve(J_FULL, L), fd, rtol=1e-5, atol=1e-5)


def test_euler_reference_of_a_rotating_frame():
    """R_d(t) = Rz(n t) → y_d = (n t, 0, 0), ẏ_d = (n, 0, 0), ÿ_d = 0."""
    n, t = 0.001, 123.0
    y, yd, ydd = euler_reference(euler.to_matrix([n * t, 0, 0], "ZYX"), [0, 0, n], np.zeros(3))
    np.testing.assert_allclose(y, [n * t, 0, 0], atol=1e-15)
    np.testing.assert_allclose(yd, [n, 0, 0], atol=1e-15)
    np.testing.assert_allclose(ydd, 0.0, atol=1e-15)


def test_euler_angle_acceleration_matches_a_slew_profile():
    """A pure rotation about a fixed body axis from a 1-axis Euler angle: ÿ = ω̇ on that axis."""
    adot, addot = euler_angle_acceleration([0.3, 0.0, 0.0], [0.0, 0.0, 0.2], [0.0, 0.0, 0.05])
    np.testing.assert_allclose(adot, [0.2, 0, 0], atol=1e-15)
    np.testing.assert_allclose(addot, [0.05, 0, 0], atol=1e-15)


# -- gimbal lock -----------------------------------------------------------------------------------


def test_gimbal_lock_raises_never_nan():
    a = np.array([0.1, np.pi / 2, 0.2])
    with pytest.raises(ChartSingularityError):
        euler_feedback_linearisation(a, [0.1, 0.2, 0.3], J_FULL)
    law = TerminalSlidingMode(J_FULL, 10.0)
    with pytest.raises(ChartSingularityError):
        law.command(0.0, a, [0.1, 0.2, 0.3], np.zeros(3), np.zeros(3), np.zeros(3))
    ctrl = TerminalSlidingModeSO3(J_FULL, 10.0)
    ctrl.reset(0.0, 1)
    near = euler.to_matrix(np.array([[0.1, np.radians(89.9), 0.2]]), "ZYX")
    ref = AttitudeReference.regulation(np.eye(3))
    with pytest.raises(ChartSingularityError):
        ctrl.command(0.0, AttitudeState(R=near, omega=np.zeros((1, 3))), ref)


# -- time-shaping polynomial -----------------------------------------------------------------------


def test_shaping_coefficients_solve_the_seed_system():
    """Seed eqs. (18)–(19): M R = S."""
    M = np.array([[1.0, 1, 1], [3, 4, 5], [6, 12, 20]])
    S = np.array([[-1.0, -1, -0.5], [0, -1, -1], [0, 0, -1]])
    np.testing.assert_allclose(M @ SHAPING_COEFFICIENTS, S, atol=1e-14)
    np.testing.assert_allclose(np.linalg.solve(M, S), SHAPING_COEFFICIENTS, atol=1e-13)


@settings(max_examples=40, deadline=None)
@given(
    T=st.floats(0.5, 60.0),
    e=st.lists(st.floats(-2.0, 2.0), min_size=9, max_size=9),
    frac=st.floats(0.0, 1.0),
)
def test_polynomial_boundary_conditions_and_spec_formula(T, e, frac):
    e0, e1, e2 = np.reshape(e, (3, 3))
    p, pd, pdd = time_shaping_polynomial(0.0, T, e0, e1, e2)
    np.testing.assert_allclose(p, e0, atol=1e-14)
    np.testing.assert_allclose(pd, e1, atol=1e-13)
    np.testing.assert_allclose(pdd, e2, atol=1e-12)
    for t in (T, T * 1.0000001, 2 * T):
        for v in time_shaping_polynomial(t, T, e0, e1, e2):
            np.testing.assert_allclose(v, 0.0, atol=1e-11 * (1 + T * T))
    t = frac * T
    tau = t / T
    spec = (e0 * (1 - 10 * tau**3 + 15 * tau**4 - 6 * tau**5)
            + e1 * T * (tau - 6 * tau**3 + 8 * tau**4 - 3 * tau**5)
            + e2 * T**2 * (tau**2 / 2 - 1.5 * tau**3 + 1.5 * tau**4 - 0.5 * tau**5))
    np.testing.assert_allclose(time_shaping_polynomial(t, T, e0, e1, e2)[0], spec,
                               atol=1e-12 * (1 + T * T))


def test_polynomial_derivatives_by_finite_differences_and_batch():
    rng = np.random.default_rng(2)
    e0, e1, e2 = rng.normal(size=(3, 4, 3))
    T = 7.0
    ts = np.array([0.3, 2.0, 5.5, 6.9])
    p, pd, pdd = time_shaping_polynomial(ts, T, e0, e1, e2)
    assert p.shape == (4, 3)
    h = 1e-5
    pp = time_shaping_polynomial(ts + h, T, e0, e1, e2)
    pm = time_shaping_polynomial(ts - h, T, e0, e1, e2)
    np.testing.assert_allclose(pd, (pp[0] - pm[0]) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(pdd, (pp[1] - pm[1]) / (2 * h), atol=1e-8)
    for i in range(4):
        # scalar-time path (one time for a batch) against the per-element array path
        pi = time_shaping_polynomial(ts[i], T, e0[i], e1[i], e2[i])
        for got, want in zip(pi, (p, pd, pdd), strict=True):
            np.testing.assert_allclose(got, want[i], rtol=1e-12, atol=1e-14)


# -- sliding surface and the law -------------------------------------------------------------------


def test_sigma_zero_and_zero_torque_at_start_and_sigma_dynamics():
    """σ(0) = 0 and L(0) = 0 (ë₀ = drift); later, with ÿ = b + A u the closed loop has
    σ̇ = −C₂ S_δ (F + D + K) (the reaching law, seed §3.2)."""
    rng = np.random.default_rng(7)
    C1, C2 = np.array([1.0, 2.0, 0.5]), np.array([0.7, 1.0, 1.5])
    law = TerminalSlidingMode(J_FULL, 8.0, C1=C1, C2=C2, F=0.01, D=0.02, K=0.3)
    a = np.array([[0.5, -0.4, 0.3], [-2.0, 0.9, 2.5]])
    w = rng.normal(size=(2, 3)) * 0.1
    y_d, yd_d, ydd_d = rng.normal(size=(3, 2, 3)) * 0.1
    L0 = law.command(0.0, a, w, y_d, yd_d, ydd_d)
    np.testing.assert_allclose(law.diagnostics()["sigma"], 0.0, atol=1e-15)
    np.testing.assert_allclose(L0, 0.0, atol=1e-12)
    # a later sample off the surface
    a1 = a + rng.normal(size=(2, 3)) * 0.05
    w1 = w + rng.normal(size=(2, 3)) * 0.05
    t = 3.0
    L = law.command(t, a1, w1, y_d, yd_d, ydd_d)
    d = law.diagnostics()
    A, b = euler_feedback_linearisation(a1, w1, J_FULL)
    ydd = b + np.einsum("bij,bj->bi", A, L @ np.linalg.inv(J_FULL).T)
    p, pd, pdd = time_shaping_polynomial(t, 8.0, *law.initial_conditions)
    edot = np.einsum("bij,bj->bi", A, w1) - yd_d
    sigma = sliding_surface(d["e"], edot, p, pd, np.diag(C1), np.diag(C2))
    np.testing.assert_allclose(d["sigma"], sigma, atol=1e-14)
    sigma_dot = (edot - pd) * C1 + (ydd - ydd_d - pdd) * C2
    c2s = sigma * C2
    delta = 0.03 + 5.0 * np.linalg.norm(d["e"], axis=-1, keepdims=True)
    expect = -C2 * c2s / (np.linalg.norm(c2s, axis=-1, keepdims=True) + delta) * (0.01 + 0.02 + 0.3)
    np.testing.assert_allclose(sigma_dot, expect, atol=1e-12)


def test_tsm_control_is_pure_function_of_its_inputs():
    params = TSMParams(T=5.0, C1=1.0, C2=1.0, delta0=0.03, delta1=5.0, F=0.0, D=0.0, K=0.1)
    rng = np.random.default_rng(1)
    args = [rng.normal(size=3) for _ in range(5)]
    A = np.eye(3) + 0.1 * rng.normal(size=(3, 3))
    b, ydd = rng.normal(size=3), rng.normal(size=3)
    copies = [x.copy() for x in args]
    u1, s1 = tsm_control(*args, A, b, ydd, params)
    u2, s2 = tsm_control(*args, A, b, ydd, params)
    np.testing.assert_array_equal(u1, u2)
    for x, c in zip(args, copies, strict=True):
        np.testing.assert_array_equal(x, c)


def test_exact_model_closed_loop_reaches_zero_at_T():
    """Law alone on the rigid body (scipy integration, no model error): e(T) ≈ 0 and the error
    follows p(t) (σ stays 0)."""
    T = 4.0
    law = TerminalSlidingMode(J_FULL, T, K=0.2)
    a0 = np.array([0.4, -0.3, 0.6])
    R = euler.to_matrix(a0, "ZYX")
    w = np.array([0.02, -0.01, 0.03])
    dt = 0.01
    z = np.zeros(3)
    for k in range(int(T / dt)):
        a = euler.from_matrix(R, "ZYX")
        L = law.command(k * dt, a, w, z, z, z)
        assert np.all(np.isfinite(L))
        R, w = _flow(R, w, J_FULL, L, dt, with_rate=True)
        # ZOH sampling (dt = 10 ms) is the only mismatch: σ stays in a thin layer
        assert np.linalg.norm(law.diagnostics()["sigma"]) < 5e-3
    e_T = euler.from_matrix(R, "ZYX")
    assert np.abs(e_T).max() < 1e-3 * np.abs(a0).max(), e_T  # from 0.6 rad: 3 decades


def test_so3_wrapper_equals_chart_law():
    """The adapter-wrapped controller returns the chart law's torque on the same angles."""
    J = np.diag([1000.0, 1200.0, 900.0])
    ctrl = TerminalSlidingModeSO3(J, 10.0, F=0.01, K=0.5)
    law = TerminalSlidingMode(J, 10.0, F=0.01, K=0.5)
    ctrl.reset(0.0, 2)
    law.reset(0.0, 2)
    a = np.array([[0.5, -0.5, 0.26], [-1.0, 0.2, 2.0]])
    w = np.array([[0.01, 0.0, -0.02], [0.0, 0.03, 0.01]])
    n = 0.001
    for t in (0.0, 1.5):
        R_d = euler.to_matrix([n * t, 0, 0], "ZYX")
        ref = AttitudeReference(R_d=R_d, omega_d=np.array([0, 0, n]), omega_dot_d=np.zeros(3))
        L1 = ctrl.command(t, AttitudeState(R=euler.to_matrix(a, "ZYX"), omega=w), ref)
        L2 = law.command(t, a, w, [n * t, 0, 0], [n, 0, 0], np.zeros(3))
        np.testing.assert_allclose(L1, L2, rtol=1e-7, atol=1e-9)
    assert set(ctrl.diagnostics()) >= {"sigma", "e", "chart_y"}


# -- bad input -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"T": 0.0}, "T"),
        ({"T": -1.0}, "T"),
        ({"delta0": 0.0}, "delta0"),
        ({"K": 0.0}, "K"),
        ({"K": -0.1}, "K"),
        ({"delta1": -1.0}, "delta1"),
        ({"F": -0.1}, "F"),
        ({"D": -0.1}, "D"),
        ({"C1": 0.0}, "C1"),
        ({"C2": [1.0, -1.0, 1.0]}, "C2"),
        ({"C1": [[1.0, 2.0, 0], [2.0, 1.0, 0], [0, 0, 1.0]]}, "C1"),
        ({"T": float("nan")}, "T"),
    ],
)
def test_bad_parameters_raise_value_error_naming_the_argument(kw, name):
    args = {"J": J_FULL, "T": 10.0} | kw
    with pytest.raises(ValueError, match=f"^{name}"):
        TerminalSlidingMode(**args)


def test_bad_inputs_of_the_pure_functions():
    with pytest.raises(ValueError, match="^T"):
        time_shaping_polynomial(1.0, 0.0, np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="^t"):
        time_shaping_polynomial(-1.0, 2.0, np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="^J"):
        euler_feedback_linearisation(np.zeros(3), np.zeros(3), -np.eye(3))
    with pytest.raises(ValueError, match="^angles"):
        euler_feedback_linearisation(np.zeros(4), np.zeros(3), np.eye(3))
    with pytest.raises(ValueError, match="^omega"):
        euler_feedback_linearisation(np.zeros(3), [np.nan, 0, 0], np.eye(3))
    with pytest.raises(ValueError, match="^seq"):
        euler_feedback_linearisation(np.zeros(3), np.zeros(3), np.eye(3), seq="ZZX")
    law = TerminalSlidingMode(np.eye(3), 5.0)
    law.command(2.0, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="^t"):
        law.command(1.0, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))


@pytest.mark.parametrize("seq", euler.SEQUENCES)
def test_A_equals_the_chart_rates_matrix_for_every_sequence(seq):
    rng = np.random.default_rng(len(seq) + sum(map(ord, seq)))
    a = np.stack([_start_angles(seq, rng) for _ in range(4)])
    A, _ = euler_feedback_linearisation(a, rng.normal(size=(4, 3)), J_FULL, seq)
    np.testing.assert_allclose(A, euler.rates_matrix(a, seq), rtol=1e-13, atol=1e-13)
    lock = a.copy()
    lock[0, 1] = np.pi / 2 if euler.is_tait_bryan(seq) else 0.0
    with pytest.raises(ChartSingularityError):
        euler_feedback_linearisation(lock, np.zeros(3), J_FULL, seq)
