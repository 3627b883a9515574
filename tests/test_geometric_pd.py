"""Tests of the geometric PD controller (SPEC §6 item 1) and the region-of-attraction functions
(survey seed 002, Lemmas 1–4), on an ideal rigid body integrated in the test."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import attitude_reference as ref

from liecontrol import errors as E
from liecontrol.control import (
    AttitudeReference,
    AttitudeState,
    GeometricPD,
    gains_from_bandwidth,
)
from liecontrol.control import region_of_attraction as roa
from liecontrol.control.geometric_pd import check_gain, linear_error_slope
from liecontrol.lie import so3

KINDS = ("trace", "large_angle", "log")
J0 = np.array([[10.0, 0.5, -0.2], [0.5, 12.0, 0.3], [-0.2, 0.3, 8.0]])


def make(kind="large_angle", k_R=3.0, k_Omega=8.0, J=J0, B=1, **kw) -> GeometricPD:
    c = GeometricPD(J, k_R, k_Omega, error=kind, **kw)
    c.reset(0.0, B)
    return c


# ---------------------------------------------------------------------------------------------
# the control law


@pytest.mark.parametrize("kind", KINDS)
def test_zero_torque_at_reference_at_rest(kind):
    rng = np.random.default_rng(0)
    R = so3.random(rng, 4)
    c = make(kind, B=4)
    M = c.command(0.0, AttitudeState(R=R, omega=np.zeros((4, 3))), ref(R))
    np.testing.assert_allclose(M, 0.0, atol=1e-14)


@pytest.mark.parametrize("kind", KINDS)
def test_on_reference_gives_inverse_dynamics(kind):
    """R = R_d, Ω = Ω_d: M = Ω × JΩ + J Ω̇_d, the torque that keeps the body on the reference."""
    rng = np.random.default_rng(1)
    R = so3.random(rng, 3)
    w = rng.standard_normal((3, 3))
    dw = rng.standard_normal((3, 3))
    c = make(kind, B=3)
    M = c.command(0.0, AttitudeState(R=R, omega=w), ref(R, w, dw))
    expect = np.cross(w, w @ J0.T) + dw @ J0.T
    np.testing.assert_allclose(M, expect, atol=1e-13)


@pytest.mark.parametrize("kind", KINDS)
def test_torque_opposes_small_error(kind):
    rng = np.random.default_rng(2)
    c = make(kind)
    for _ in range(5):
        n = rng.standard_normal(3)
        n /= np.linalg.norm(n)
        R_d = so3.random(rng)
        R = R_d @ so3.exp(1e-3 * n)
        M = c.command(0.0, AttitudeState(R=R[None], omega=np.zeros((1, 3))), ref(R_d))
        assert M[0] @ n < 0
        # pure rate error: M·Ω = −k_Ω‖Ω‖² (Ω × JΩ is orthogonal to Ω)
        w = rng.standard_normal(3)
        M = c.command(0.0, AttitudeState(R=R_d[None], omega=w[None]), ref(R_d))
        assert M[0] @ w == pytest.approx(-8.0 * w @ w, rel=1e-12)


def test_hand_computed_tracking_case():
    """J = diag(1,2,3), R = I, R_d = Rz(90°), Ω = (.1,.2,.3), Ω_d = (0,0,.5), Ω̇_d = (.1,0,0),
    k_R = 2, k_Ω = 3. By hand: RᵀR_dΩ_d = (0,0,.5), RᵀR_dΩ̇_d = (0,.1,0), e_Ω = (.1,.2,−.2),
    Ω × JΩ = (.06,−.06,.02), −J(Ω × RᵀR_dΩ_d − RᵀR_dΩ̇_d) = −J(.1,−.15,0) = (−.1,.3,0),
    −k_Ω e_Ω = (−.3,−.6,.6); R̃ = Rz(−90°) so e_R = (0,0,−π/2) (log), (0,0,−sin 45°)
    (large-angle), (0,0,−0.95) (trace, G = diag(.9,1,1.1))."""
    J = np.diag([1.0, 2.0, 3.0])
    R_d = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    state = AttitudeState(R=np.eye(3)[None], omega=np.array([[0.1, 0.2, 0.3]]))
    reference = ref(R_d, [0.0, 0.0, 0.5], [0.1, 0.0, 0.0])
    base = np.array([0.06 - 0.1 - 0.3, -0.06 + 0.3 - 0.6, 0.02 + 0.0 + 0.6])
    for kind, ez in (("log", -np.pi / 2), ("large_angle", -np.sqrt(0.5)), ("trace", -0.95)):
        c = make(kind, k_R=2.0, k_Omega=3.0, J=J)
        M = c.command(0.0, state, reference)
        np.testing.assert_allclose(M[0], base + np.array([0, 0, -2.0 * ez]), atol=1e-13)
        d = c.diagnostics()
        np.testing.assert_allclose(d["e_R"][0], [0, 0, ez], atol=1e-13)
        np.testing.assert_allclose(d["e_Omega"][0], [0.1, 0.2, -0.2], atol=1e-15)


@pytest.mark.parametrize("kind", KINDS)
def test_batched_equals_per_element(kind):
    rng = np.random.default_rng(3)
    B = 6
    R, R_d = so3.random(rng, B), so3.random(rng, B)
    w, w_d, dw_d = (rng.standard_normal((B, 3)) for _ in range(3))
    K_R = np.array([[3.0, 0.2, 0], [0.2, 2.0, 0.1], [0, 0.1, 4.0]])
    c = make(kind, k_R=K_R, k_Omega=[5.0, 6.0, 7.0], B=B)
    M = c.command(0.0, AttitudeState(R=R, omega=w), ref(R_d, w_d, dw_d))
    diag = c.diagnostics()
    assert M.shape == (B, 3) and diag["Psi"].shape == (B,) and diag["e_R"].shape == (B, 3)
    one = make(kind, k_R=K_R, k_Omega=np.diag([5.0, 6.0, 7.0]), B=1)
    for i in range(B):
        Mi = one.command(
            0.0, AttitudeState(R=R[i : i + 1], omega=w[i : i + 1]), ref(R_d[i], w_d[i], dw_d[i])
        )
        np.testing.assert_allclose(M[i], Mi[0], atol=1e-13)
        Psi, e_R = E.attitude_error(kind, R[i], R_d[i])
        assert diag["Psi"][i] == pytest.approx(Psi, abs=1e-13)
        np.testing.assert_allclose(diag["e_R"][i], e_R, atol=1e-13)
    # a single (3, 3) reference broadcasts over the batch
    M1 = c.command(0.0, AttitudeState(R=R, omega=w), ref(R_d[0], w_d[0], dw_d[0]))
    Mb = c.command(
        0.0,
        AttitudeState(R=R, omega=w),
        ref(np.broadcast_to(R_d[0], (B, 3, 3)), np.tile(w_d[0], (B, 1)), np.tile(dw_d[0], (B, 1))),
    )
    np.testing.assert_allclose(M1, Mb, atol=1e-14)


def test_reference_validation_each_step_unless_frozen():
    from liecontrol.control import ConstantAttitude

    c = make("log")
    state = AttitudeState(R=np.eye(3)[None], omega=np.zeros((1, 3)))
    frozen = ConstantAttitude(so3.exp([0.0, 0.0, 1.0]))
    M1 = c.command(0.0, state, frozen(0.0))
    M2 = c.command(1.0, state, frozen(1.0))
    np.testing.assert_array_equal(M1, M2)
    R_d = np.eye(3)
    c.command(0.0, state, ref(R_d))
    R_d[0, 0] = 2.0  # a writeable reference is re-validated every call
    with pytest.raises(ValueError, match="^R_d:"):
        c.command(0.0, state, ref(R_d))


def test_inputs_not_mutated_and_no_nan_at_pi():
    R = np.diag([1.0, -1.0, -1.0])[None]
    w = np.zeros((1, 3))
    R0, w0 = R.copy(), w.copy()
    for kind in KINDS:
        c = make(kind)
        M = c.command(0.0, AttitudeState(R=R, omega=w), ref(np.eye(3)))
        assert np.all(np.isfinite(M))
        if kind != "trace":  # the trace error vanishes at this critical point; the others push
            assert np.linalg.norm(M) > 0
    np.testing.assert_array_equal(R, R0)
    np.testing.assert_array_equal(w, w0)


# ---------------------------------------------------------------------------------------------
# closed loop on an ideal rigid body (integrator written here: 2nd-order Lie midpoint)


def simulate(controller, J, R0, w0, reference, T, h):
    """J ω̇ + ω × Jω = M; R_{k+½} = R exp(h/2 ω), midpoint rule on SO(3) × ℝ³."""
    Jinv = np.linalg.inv(J)

    def f(t, R, w):
        M = controller.command(t, AttitudeState(R=R, omega=w), reference(t))
        return (M - np.cross(w, w @ J.T)) @ Jinv.T

    R, w = R0.copy(), w0.copy()
    Psi_hist = []
    n = int(round(T / h))
    for k in range(n):
        t = k * h
        a1 = f(t, R, w)
        Psi_hist.append(controller.diagnostics()["Psi"].copy())
        R_mid = R @ so3.exp(0.5 * h * w)
        w_mid = w + 0.5 * h * a1
        a2 = f(t + 0.5 * h, R_mid, w_mid)
        R = R @ so3.exp(h * w_mid)
        w = w + h * a2
    return R, w, np.array(Psi_hist)


def slewing_reference(R0, n, amp, freq):
    """R_d(t) = R0 exp(α(t) n^), α = amp sin(freq t): Ω_d = α̇ n, Ω̇_d = α̈ n (exact)."""
    n = np.asarray(n, float) / np.linalg.norm(n)

    def reference(t):
        a = amp * np.sin(freq * t)
        da = amp * freq * np.cos(freq * t)
        dda = -amp * freq**2 * np.sin(freq * t)
        return AttitudeReference(R_d=R0 @ so3.exp(a * n), omega_d=da * n, omega_dot_d=dda * n)

    return reference


@pytest.mark.parametrize("kind", KINDS)
def test_closed_loop_tracking_converges(kind):
    rng = np.random.default_rng(10)
    B = 6
    k_R, k_Om = gains_from_bandwidth(J0, omega_n=1.0, zeta=0.9, error=kind)
    c = GeometricPD(J0, k_R, k_Om, error=kind)
    c.reset(0.0, B)
    R_ref0 = so3.random(rng)
    reference = slewing_reference(R_ref0, [1.0, -0.5, 0.3], amp=0.8, freq=0.4)
    # initial attitude errors up to 150° and rates of 0.1 rad/s
    axes = rng.standard_normal((B, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.linspace(0.3, np.deg2rad(150.0), B)
    R0 = R_ref0 @ so3.exp(axes * angles[:, None])
    w0 = rng.normal(scale=0.1, size=(B, 3))
    R, w, Psi = simulate(c, J0, R0, w0, reference, T=25.0, h=0.02)
    final = reference(25.0)
    Psi_end, _ = E.attitude_error(kind, R, final.R_d)
    assert np.all(Psi_end < 1e-6), Psi_end
    e_W = E.angular_velocity_error(R, w, final.R_d, final.omega_d)
    assert np.all(np.linalg.norm(e_W, axis=1) < 1e-3)
    # Lyapunov bound of the ideal loop holds along the trajectory (gains are scalar here)
    ref0 = reference(0.0)
    Psi0, _ = E.attitude_error(kind, R0, ref0.R_d)
    e0 = E.angular_velocity_error(R0, w0, ref0.R_d, ref0.omega_d)
    bound = roa.psi_bound(kind, Psi0, e0, J0, k_R)
    assert np.all(Psi.max(axis=0) <= bound * (1 + 1e-3) + 1e-9)


def test_large_angle_179_deg_rest_to_rest():
    c = GeometricPD(J0, 20.0, 30.0, error="large_angle")
    c.reset(0.0, 1)
    R0 = so3.exp(np.deg2rad(179.0) * np.array([[0.0, 0.6, 0.8]]))
    reference = lambda t: ref(np.eye(3))  # noqa: E731
    R, w, Psi = simulate(c, J0, R0, np.zeros((1, 3)), reference, T=30.0, h=0.02)
    assert so3.angle(R)[0] < 1e-3
    # at rest initially V(0) = k_R Ψ(0), so Ψ(t) ≤ V(t)/k_R ≤ Ψ(0): never beyond the start
    assert Psi[:, 0].max() <= Psi[0, 0] + 1e-9
    assert abs(E.large_angle_error(R0, np.eye(3))[0][0] - Psi[0, 0]) < 1e-15


# ---------------------------------------------------------------------------------------------
# gains


def closed_loop_jacobian(c: GeometricPD, J: np.ndarray) -> np.ndarray:
    """Numerical linearisation of the regulated loop at R = I, Ω = 0 through the controller."""
    Jinv = np.linalg.inv(J)
    A = np.zeros((6, 6))
    A[:3, 3:] = np.eye(3)
    h = 1e-6
    for i in range(6):
        dx = np.zeros(6)
        dx[i] = h
        Ms = []
        for s in (1.0, -1.0):
            R = so3.exp(s * dx[:3])[None]
            w = (s * dx[3:])[None]
            Ms.append(c.command(0.0, AttitudeState(R=R, omega=w), ref(np.eye(3)))[0])
        A[3:, i] = Jinv @ (Ms[0] - Ms[1]) / (2 * h)
    return A


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("matrix", [False, True])
def test_gains_from_bandwidth_linear_response(kind, matrix):
    J = np.diag([10.0, 12.0, 8.0])
    k_R, k_Om = gains_from_bandwidth(J, omega_n=0.7, zeta=0.8, error=kind, matrix=matrix)
    c = make(kind, k_R=k_R, k_Omega=k_Om, J=J)
    A = closed_loop_jacobian(c, J)
    # J, G diagonal: the loop decouples per axis, δθ̈_i + D_ii δθ̇_i + K_ii δθ_i = 0
    K, D = -A[3:, :3], -A[3:, 3:]
    np.testing.assert_allclose(K - np.diag(np.diag(K)), 0.0, atol=1e-6)
    np.testing.assert_allclose(D - np.diag(np.diag(D)), 0.0, atol=1e-6)
    wn = np.sqrt(np.diag(K))
    zeta = np.diag(D) / (2 * wn)
    # every axis at least (ω_n, ζ); for log/large-angle the largest-inertia axis (y) exactly
    assert wn.min() >= 0.7 * (1 - 1e-6)
    assert zeta.min() >= 0.8 - 1e-6
    if kind != "trace":
        assert wn[1] == pytest.approx(0.7, rel=1e-6)
        assert zeta[1] == pytest.approx(0.8, rel=1e-6)
    if matrix:
        assert wn.min() == pytest.approx(0.7, rel=1e-6)
        if kind != "trace":
            np.testing.assert_allclose(wn, 0.7, rtol=1e-6)
            np.testing.assert_allclose(zeta, 0.8, rtol=1e-6)


def test_linear_error_slope_values():
    assert linear_error_slope("log") == 1.0
    assert linear_error_slope("large_angle") == 0.5
    assert linear_error_slope("trace") == pytest.approx(0.95)
    assert linear_error_slope("trace", np.diag([1.0, 2.0, 3.0])) == pytest.approx(1.5)
    assert linear_error_slope("trace", which="max") == pytest.approx(1.05)
    with pytest.raises(ValueError, match="^which:"):
        linear_error_slope("log", which="median")


# ---------------------------------------------------------------------------------------------
# bad input


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"k_R": -1.0}, "k_R:"),
        ({"k_R": 0.0}, "k_R:"),
        ({"k_Omega": np.diag([1.0, -2.0, 3.0])}, "k_Omega:"),
        ({"k_R": [[1.0, 2.0, 0], [0, 1.0, 0], [0, 0, 1.0]]}, "k_R:"),
        ({"k_R": np.diag([1.0, 1.0, 1.0]) - 2 * np.eye(3) * 0.9}, "k_R:"),
        ({"k_Omega": [1.0, 2.0]}, "k_Omega:"),
        ({"k_Omega": np.nan}, "k_Omega:"),
        ({"J": np.diag([1.0, 1.0, 5.0])}, "J:"),
        ({"J": -np.eye(3)}, "J:"),
        ({"error": "quaternion"}, "error:"),
        ({"error": "log", "G": np.diag([1.0, 2.0, 3.0])}, "G:"),
        ({"error": "trace", "G": np.eye(3)}, "G:"),
    ],
)
def test_bad_parameters(kw, name):
    args = {"J": J0, "k_R": 1.0, "k_Omega": 1.0}
    args.update(kw)
    with pytest.raises(ValueError) as exc:
        GeometricPD(**args)
    assert str(exc.value).startswith(name)


def test_check_gain_forms():
    assert check_gain(2, "k") == 2.0
    np.testing.assert_array_equal(check_gain([1, 2, 3], "k"), np.diag([1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match="^k:"):
        check_gain([[1, 0, 0], [0, 1, 0], [0, 0, 0]], "k")


def test_bad_command_inputs():
    c = GeometricPD(J0, 1.0, 1.0)
    state = AttitudeState(R=np.eye(3)[None], omega=np.zeros((1, 3)))
    with pytest.raises(RuntimeError):
        c.command(0.0, state, ref(np.eye(3)))
    with pytest.raises(ValueError, match="^batch_size:"):
        c.reset(0.0, 0)
    c.reset(0.0, 2)
    with pytest.raises(ValueError, match="^state:"):
        c.command(0.0, state, ref(np.eye(3)))
    c.reset(0.0, 1)
    # the containers validate on construction; unchecked ones reach the controller's checks
    with pytest.raises(ValueError, match="^R:"):
        AttitudeState(R=(1.1 * np.eye(3))[None], omega=np.zeros((1, 3)))
    bad = AttitudeState.unchecked(R=(1.1 * np.eye(3))[None], omega=np.zeros((1, 3)))
    with pytest.raises(ValueError, match="^R:"):
        c.command(0.0, bad, ref(np.eye(3)))
    with pytest.raises(ValueError, match="^R_d:"):
        c.command(0.0, state, ref(so3.identity((3,))))
    with pytest.raises(ValueError, match="^omega_d:"):
        AttitudeReference(np.eye(3), np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match="^omega_d:"):
        c.command(0.0, state, AttitudeReference.unchecked(np.eye(3), np.zeros(2), np.zeros(3)))
    with pytest.raises(ValueError, match="^omega:"):
        AttitudeState(R=np.eye(3)[None], omega=np.full((1, 3), np.nan))
    with pytest.raises(ValueError, match="^omega:"):
        c.command(
            0.0,
            AttitudeState.unchecked(R=np.eye(3)[None], omega=np.full((1, 3), np.nan)),
            ref(np.eye(3)),
        )
    assert c.diagnostics() == {}


# ---------------------------------------------------------------------------------------------
# regions of attraction (seed 002 Lemmas 1–4): hand-computed cases


def test_lemma4_hand_case():
    """J = diag(1,2,3), k_R = 4, Ψ(0) = 1: ‖e_Ω(0)‖² < 2·4·(2 − 1)/3 = 8/3 ≈ 2.667."""
    J = np.diag([1.0, 2.0, 3.0])
    assert roa.lemma4_condition(1.0, [1.6, 0, 0], J, 4.0)  # 2.56 < 2.667
    assert not roa.lemma4_condition(1.0, [0, 1.7, 0], J, 4.0)  # 2.89
    assert not roa.lemma4_condition(2.0, [0, 0, 0], J, 4.0)  # antipodal set excluded
    assert roa.lemma4_condition(0.0, [0, 0, 0], J, 4.0)
    out = roa.lemma4_condition([1.0, 1.0], [[1.6, 0, 0], [0, 1.7, 0]], J, 4.0)
    np.testing.assert_array_equal(out, [True, False])


def test_lemma2_hand_case():
    """θ(0) = π/2 (Ψ = π²/8), k = 1, unit inertia: ‖ω(0)‖² < π² − π²/4 = 7.402."""
    Psi0 = np.pi**2 / 8
    assert roa.lemma2_condition(Psi0, [2.7, 0, 0], 1.0)  # 7.29
    assert not roa.lemma2_condition(Psi0, [2.75, 0, 0], 1.0)  # 7.5625
    # torque-level gains with J = diag(1,2,3): threshold 7.402/3 = 2.467
    J = np.diag([1.0, 2.0, 3.0])
    assert roa.lemma2_condition(Psi0, [0, 1.5, 0], 1.0, J)
    assert not roa.lemma2_condition(Psi0, [0, 1.6, 0], 1.0, J)
    # matrix gain: λ_min as stated in the survey
    assert roa.lemma2_condition(Psi0, [2.7, 0, 0], np.diag([1.0, 5.0, 9.0]))
    assert not roa.lemma2_condition(Psi0, [2.75, 0, 0], np.diag([1.0, 5.0, 9.0]))
    # θ(0) = π excluded (tr R = −1), no division by zero
    assert not roa.lemma2_condition(np.pi**2 / 2, [0, 0, 0], 100.0)
    assert roa.lemma3_condition(Psi0, [2.7, 0, 0], 1.0) == roa.lemma2_condition(
        Psi0, [2.7, 0, 0], 1.0
    )


def test_lemma1_and_critical_levels():
    assert roa.lemma1_condition(np.diag([1.0, 2.0, 3.0]))
    assert not roa.lemma1_condition(np.eye(3))
    assert not roa.lemma1_condition(np.diag([1.0, 2.0, -1.0]))
    with pytest.raises(ValueError, match="^P:"):
        roa.lemma1_condition(np.eye(2))
    assert roa.lemma1_lyapunov(8.0, np.diag([1.0, 2.0, 3.0])) == pytest.approx(2.0)  # λ' = 4
    assert roa.critical_level("large_angle") == 2.0
    assert roa.critical_level("log") == pytest.approx(np.pi**2 / 2)
    assert roa.critical_level("trace") == pytest.approx(3.8)  # 2(0.9 + 1.0)
    # Ψ* of the trace form is Ψ at the π-rotation about the largest-eigenvalue axis
    Psi, e_R = E.trace_error(np.diag([-1.0, -1.0, 1.0]), np.eye(3))
    assert Psi == pytest.approx(3.8) and np.allclose(e_R, 0.0)


def test_lyapunov_condition_is_tighter_than_survey_form():
    J = np.diag([1.0, 2.0, 3.0])
    for kind in KINDS:
        rng = np.random.default_rng(11)
        Psi0 = rng.uniform(0, roa.critical_level(kind), 200)
        e0 = rng.normal(scale=1.5, size=(200, 3))
        suff = roa.sufficient_condition(kind, Psi0, e0, J, 4.0)
        tight = roa.lyapunov_condition(kind, Psi0, e0, J, 4.0)
        assert np.all(tight[suff])  # survey form ⇒ sublevel condition
        assert np.any(tight & ~suff)  # and the sublevel set is strictly larger
    # along the axis of smallest inertia the sublevel set admits more rate than Lemma 4
    assert roa.lyapunov_condition("large_angle", 1.0, [2.0, 0, 0], J, 4.0)
    assert not roa.lemma4_condition(1.0, [2.0, 0, 0], J, 4.0)
    assert roa.lyapunov_function("log", 2.0, [1.0, 1.0, 1.0], J, 4.0) == pytest.approx(11.0)
    with pytest.raises(ValueError, match="^k_R:"):
        roa.lyapunov_function("log", 2.0, [1.0, 1.0, 1.0], J, np.eye(3))
    with pytest.raises(ValueError, match="^Psi0:"):
        roa.lemma4_condition(-1.0, [0, 0, 0], J, 1.0)


def test_region_of_attraction_on_simulation():
    """Inside Lemma 4's region the ideal loop converges; the rate bound holds."""
    J = np.diag([1.0, 2.0, 3.0])
    k_R, k_Om = 4.0, 4.0
    R0 = so3.exp(np.array([[0.0, 0.0, 2.5], [1.5, 0.0, 0.0]]))
    Psi0, _ = E.large_angle_error(R0, np.eye(3))
    w0 = np.array([[0.5, 0.0, 0.0], [0.0, 1.4, 0.0]])
    assert np.all(roa.lemma4_condition(Psi0, w0, J, k_R))
    c = GeometricPD(J, k_R, k_Om, error="large_angle")
    c.reset(0.0, 2)
    R, w, Psi = simulate(c, J, R0, w0, lambda t: ref(np.eye(3)), T=20.0, h=0.02)
    assert np.all(Psi.max(axis=0) < 2.0)
    assert np.all(so3.angle(R) < 1e-3)
    assert np.all(np.linalg.norm(w, axis=1) <= roa.rate_bound("large_angle", Psi0, w0, J, k_R))


# ---------------------------------------------------------------------------------------------
# hot path: one spacecraft runs on Python floats, validation by cheap checks


@pytest.mark.parametrize("kind", KINDS)
def test_single_spacecraft_kernel_route_matches_batched_route(kind):
    """One spacecraft at a time and the whole batch agree to round-off, including tiny angles,
    θ → π and θ = π (the compiled kernel against the numpy route: tests/test_kernels.py)."""
    rng = np.random.default_rng(11)
    N = 60
    R, R_d = so3.random(rng, N), so3.random(rng, N)
    R_d[:10] = R[:10] @ so3.exp(rng.normal(size=(10, 3)) * 1e-6)
    axis = rng.normal(size=(10, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    R_d[10:20] = R[10:20] @ so3.exp(axis * (np.pi - 0.05 * rng.random((10, 1))))
    R_d[20] = R[20]
    R_d[21] = R[21] @ np.diag([1.0, -1.0, -1.0])  # exactly π
    w, w_d, dw_d = (0.1 * rng.standard_normal((N, 3)) for _ in range(3))
    for k_R, k_W in (
        (3.0, 8.0),
        (np.array([1.0, 2.0, 3.0]), [[5.0, 1.0, 0], [1.0, 6.0, 0], [0, 0, 7.0]]),
    ):
        batched = make(kind, k_R=k_R, k_Omega=k_W, B=N)
        M = batched.command(0.0, AttitudeState(R=R, omega=w), ref(R_d, w_d, dw_d))
        diag = batched.diagnostics()
        one = make(kind, k_R=k_R, k_Omega=k_W, B=1)
        for i in range(N):
            Mi = one.command(
                0.0, AttitudeState(R=R[i : i + 1], omega=w[i : i + 1]), ref(R_d[i], w_d[i], dw_d[i])
            )
            scale = np.abs(M[i]).max()
            np.testing.assert_allclose(Mi[0], M[i], rtol=0, atol=1e-14 * scale)
            for key, v in one.diagnostics().items():
                np.testing.assert_allclose(v[0], diag[key][i], rtol=1e-14, atol=1e-15)


def test_fast_validation_rejects_what_the_validators_reject():
    for B in (1, 3):
        c = make("large_angle", B=B)
        I = np.broadcast_to(np.eye(3), (B, 3, 3)).copy()
        z = np.zeros((B, 3))
        for bad in (np.diag([1.0, 1.0, -1.0]), 1.0 + 1e-8 * np.eye(3), np.full((3, 3), np.nan)):
            Rb = I.copy()
            Rb[-1] = bad
            with pytest.raises(ValueError, match="^R:"):
                c.command(0.0, AttitudeState(R=Rb, omega=z), ref(np.eye(3)))
            with pytest.raises(ValueError, match="^R_d:"):
                c.command(0.0, AttitudeState(R=I, omega=z), ref(Rb))
        zb = z.copy()
        zb[-1, 1] = np.inf
        with pytest.raises(ValueError, match="^omega:"):
            c.command(0.0, AttitudeState(R=I, omega=zb), ref(np.eye(3)))
        with pytest.raises(ValueError, match="^omega_dot_d:"):
            c.command(0.0, AttitudeState(R=I, omega=z), ref(np.eye(3), None, [np.nan, 0, 0]))
        # lists and integer arrays still go through the validators and work
        M = c.command(0.0, AttitudeState(R=I.tolist(), omega=z.astype(int)), ref(np.eye(3)))
        np.testing.assert_array_equal(M, np.zeros((B, 3)))


@pytest.mark.parametrize("kind", KINDS)
def test_batched_command_matches_the_public_error_functions(kind):
    """``command`` feeds checked input to the unchecked error kernels (and forms R_dᵀR for one
    shared R_d as a single BLAS product): torque and diagnostics equal the control law written
    out on the validating public functions of liecontrol.errors, to round-off, for a shared and
    a per-spacecraft reference, in regulation and tracking, with tiny, generic and π errors."""
    rng = np.random.default_rng(23)
    B = 40
    R_d = so3.random(rng)
    R = so3.random(rng, B)
    R[:3] = R_d @ so3.exp(rng.normal(size=(3, 3)) * 1e-7)
    R[3] = R_d @ np.diag([-1.0, 1.0, -1.0])  # exactly π
    w = 0.1 * rng.standard_normal((B, 3))
    K_W = np.array([[5.0, 1.0, 0], [1.0, 6.0, 0], [0, 0, 7.0]])
    for w_d, dw_d in ((np.zeros(3), np.zeros(3)), (rng.normal(size=3), rng.normal(size=3))):
        Psi, e_R = E.attitude_error(kind, R, R_d)
        # e_Ω = Ω − RᵀR_dΩ_d; M = −K_R e_R − K_Ω e_Ω + Ω × JΩ − J (Ω^ RᵀR_dΩ_d − RᵀR_dΩ̇_d)
        RtT = np.swapaxes(R, -1, -2) @ R_d
        wb, dwb = RtT @ w_d, RtT @ dw_d
        e_W = E.angular_velocity_error(R, w, R_d, w_d)
        M_ref = -3.0 * e_R - e_W @ K_W.T + np.cross(w, w @ J0.T) - (np.cross(w, wb) - dwb) @ J0.T
        for R_d_in, w_d_in, dw_d_in in (
            (R_d, w_d, dw_d),
            (np.tile(R_d, (B, 1, 1)), np.tile(w_d, (B, 1)), np.tile(dw_d, (B, 1))),
        ):
            c = make(kind, k_R=3.0, k_Omega=K_W, B=B)
            M = c.command(0.0, AttitudeState(R=R, omega=w), ref(R_d_in, w_d_in, dw_d_in))
            np.testing.assert_allclose(M, M_ref, rtol=0, atol=1e-13 * np.abs(M_ref).max())
            d = c.diagnostics()
            np.testing.assert_allclose(d["Psi"], Psi, rtol=1e-14, atol=1e-15)
            np.testing.assert_allclose(d["e_R"], e_R, rtol=1e-14, atol=1e-15)
            np.testing.assert_allclose(d["e_Omega"], e_W, rtol=1e-14, atol=1e-15)
