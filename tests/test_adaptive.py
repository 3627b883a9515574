"""Adaptive geometric attitude control on SO(3) (liecontrol.control.adaptive)."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from conftest import SEED000_J, OnePerSpacecraft, seed000_spacecraft

from liecontrol import errors as E
from liecontrol.control import ConstantAttitude, GeometricPD
from liecontrol.control.adaptive import (
    AdaptiveGeometricSO3,
    disturbance_parameters,
    error_rate_matrix,
    harmonic_regressor,
    inertia_from_parameters,
    inertia_parameters,
    inertia_regressor,
)
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.tuning import (
    ClosedLoopSpec,
    TuningInfeasible,
    measure_small_angle_response,
    tune_adaptive_so3,
    tune_geometric_pd,
)
from liecontrol.lie import so3
from spacecraft import RigidBody, Spacecraft, simulate
from spacecraft.actuators import IdealTorqueActuator
from spacecraft.disturbances import ConstantHarmonicTorque

J0 = np.asarray(SEED000_J)
N_ORBIT = ConstantHarmonicTorque().n
#: coefficients of Wu, Huang, Wei & Guo's constant + harmonic torque in the order of Φ(t)
PHI_SEED = disturbance_parameters([0.02, 0.08, 0.02], sine=[[0.02, 0.04, 0.02], [0.01, 0.01, 0.01]])
SPEC = ClosedLoopSpec(0.03, 0.9, 0.5)
R_SLEW = so3.exp(np.deg2rad(60.0) * np.array([1.0, 2.0, -1.0]) / np.sqrt(6.0))


def _adaptive(J, spec=SPEC, frequencies=(N_ORBIT, 2 * N_ORBIT), **kw):
    gains = tune_adaptive_so3(J, spec, disturbance_bound=1.0, frequencies=frequencies)
    gains.update(kw)
    return AdaptiveGeometricSO3(J, **gains)


def _lyapunov_from_log(ctrl, res, J_true, phi_true):
    """V of the module docstring from the logged diagnostics (an independent evaluation of
    AdaptiveGeometricSO3.lyapunov)."""
    d = res.controller
    s, dth = d["s"], d["theta_hat"] - inertia_parameters(J_true)
    dph = d["phi_hat"] - phi_true
    c_psi = E.DERIVATIVE_FACTOR[ctrl.error]
    return (
        0.5 * np.einsum("kbi,ij,kbj->kb", s, J_true, s)
        + ctrl.k_R / c_psi * d["Psi"]
        + 0.5 * (dth**2).sum(-1) / ctrl.gamma_theta
        + 0.5 * (dph**2).sum(-1) / ctrl.gamma_phi
    )


# ------------------------------------------------------------------------------ pure functions


def test_regressor_identity_and_parameters_round_trip():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(3, 3))
    J = A @ A.T + 3.0 * np.eye(3)
    a = rng.normal(size=(7, 3))
    theta = inertia_parameters(J)
    np.testing.assert_allclose(inertia_regressor(a) @ theta, a @ J.T, rtol=1e-13, atol=1e-13)
    np.testing.assert_array_equal(inertia_from_parameters(theta), J)
    # batched parameters
    Jb = inertia_from_parameters(np.stack([theta, 2.0 * theta]))
    np.testing.assert_allclose(Jb[1], 2.0 * J)


def test_harmonic_regressor_reproduces_the_constant_harmonic_torque():
    dist = ConstantHarmonicTorque()
    for t in (0.0, 123.4, 4567.0):
        Phi = harmonic_regressor(t, [N_ORBIT, 2 * N_ORBIT])
        assert Phi.shape == (3, 15)
        np.testing.assert_allclose(Phi @ PHI_SEED, dist.torque_at(t), rtol=1e-14, atol=1e-16)
    # cosine terms: cos(νt) multiplies the second block of each frequency
    phi = disturbance_parameters(np.zeros(3), cosine=[[1.0, 2.0, 3.0]])
    np.testing.assert_allclose(harmonic_regressor(0.7, [2.0]) @ phi, np.cos(1.4) * np.arange(1, 4))


@pytest.mark.parametrize("kind", ["trace", "large_angle", "log"])
def test_error_rate_matrix_matches_finite_differences(kind):
    """ė_R = E(R̃) e_Ω along d/dt R̃ = R̃ e_Ω^ (central differences of the errors module)."""
    rng = np.random.default_rng(1)
    f = {"trace": E.trace_error, "large_angle": E.large_angle_error, "log": E.log_error}[kind]
    for _ in range(5):
        Rt = so3.exp(rng.normal(size=3) * 0.9)
        e = rng.normal(size=3)
        h = 1e-6
        fd = (f(Rt @ so3.exp(h * e), np.eye(3))[1] - f(Rt @ so3.exp(-h * e), np.eye(3))[1]) / (
            2 * h
        )
        np.testing.assert_allclose(error_rate_matrix(Rt, kind)[0] @ e, fd, atol=1e-8)


def test_tuning_places_the_small_angle_poles():
    """The linearised loop (no harmonics) measured through the seam has the spec's pair and the
    disturbance pole −ω_n/10 on the axis of largest inertia (tune_adaptive_so3; the log error,
    whose slope is isotropic, so that the principal axes decouple)."""
    J = J0 / 1e4
    spec = ClosedLoopSpec(1.0, 0.9, 0.04)
    gains = tune_adaptive_so3(J, spec, disturbance_bound=1.0, error="log")
    ctrl = AdaptiveGeometricSO3(J, **gains)
    r = measure_small_angle_response(ctrl, J, 0.04, duration=40.0)
    k = int(np.argmax(np.einsum("ik,ij,jk->k", r.axes, J, r.axes)))
    poles = r.poles[k]
    want = np.concatenate([np.roots([1.0, 1.8, 1.0]), [-0.1]])
    for p in want:
        assert np.min(np.abs(poles - p)) < 0.03 * abs(p) + 2e-3, (p, poles)


# ------------------------------------------------------------------------------- closed loop


def test_lyapunov_function_is_non_increasing():
    """Ideal actuator, no noise, plant J vs the controller's initial estimate 0.7 J and 1.3 J,
    the constant + harmonic torque of Wu et al.: V (true J, true φ) never grows by more than
    the O(Δt²) sampling error and ends far below its start, for every error function."""
    plant = Spacecraft(RigidBody(J0), IdealTorqueActuator(), ConstantHarmonicTorque())
    ctrls = [
        _adaptive(0.7 * J0),
        _adaptive(1.3 * J0, error="large_angle"),
        _adaptive(1.3 * J0, error="log"),
    ]
    res = simulate(
        plant,
        OnePerSpacecraft(ctrls),
        ConstantAttitude(R_SLEW),
        plant.initial_state(np.eye(3), batch=3),
        t_final=600.0,
        dt=0.5,
    )
    for b, c in enumerate(ctrls):
        rb = res.select(b)
        V = _lyapunov_from_log(c, rb, J0, PHI_SEED)[1:, 0]
        np.testing.assert_allclose(V[-1], c.lyapunov(J0, PHI_SEED)[0], rtol=1e-12)
        assert np.diff(V).max() <= 1e-6 * V[0], (b, np.diff(V).max() / V[0])
        # the tracking part decays; the parameter part need not (no persistent excitation)
        s = rb.controller["s"][1:, 0]
        track = (
            0.5 * np.einsum("ki,ij,kj->k", s, J0, s)
            + c.k_R / E.DERIVATIVE_FACTOR[c.error] * rb.controller["Psi"][1:, 0]
        )
        assert track[-1] < 0.01 * track[0] and V[-1] < V[0] - 0.9 * track[0], b


def test_inertia_error_and_seed_disturbance_on_the_sgcmg_bus():
    """The seed-000 SGCMG spacecraft (SR steering) with the constant + harmonic torque, a 60°
    slew, the controller's initial inertia 30 % above and 30 % below the plant's: the estimates
    stay bounded (|θ̃|, |φ̃| within the bound V(0) gives) and the attitude error
    converges — well below the geometric PD's steady error with the same initial J."""
    plant = seed000_spacecraft(ConstantHarmonicTorque())
    ctrls = [_adaptive(1.3 * J0), _adaptive(0.7 * J0)]
    pd = GeometricPD(1.3 * J0, **tune_geometric_pd(1.3 * J0, SPEC, error="trace"))
    res = simulate(
        plant,
        OnePerSpacecraft([*ctrls, pd]),
        ConstantAttitude(R_SLEW),
        plant.initial_state(np.eye(3), batch=3),
        t_final=3000.0,
        dt=1.0,
        log_every=4,
    )
    ang = np.rad2deg(res.attitude_error_angle())
    late = res.t >= 2000.0
    d = res.controller
    theta = inertia_parameters(J0)
    Psi0 = E.trace_error(R_SLEW.T, np.eye(3), G=E.DEFAULT_G)[0]
    for b, c in enumerate(ctrls):
        # V(0) with s(0) = 0 (from rest at R = I): the bound every estimate error obeys
        V0 = (
            0.5 * ((c.theta0 - theta) ** 2).sum() / c.gamma_theta
            + 0.5 * (PHI_SEED**2).sum() / c.gamma_phi
            + c.k_R / 2.0 * Psi0
        )
        dth = np.linalg.norm(d["theta_hat"][:, b] - theta, axis=-1)
        dph = np.linalg.norm(d["phi_hat"][:, b] - PHI_SEED, axis=-1)
        assert dth.max() <= np.sqrt(2.0 * c.gamma_theta * V0) * 1.01
        assert dph.max() <= np.sqrt(2.0 * c.gamma_phi * V0) * 1.01
        # the inertia ball is never reached; the disturbance ball (1 N·m) may clip the
        # estimate's transient excursion during the slew (∫s dt over a slew is ~ the slew angle)
        assert not d["theta_projected"][:, b].any()
        assert np.linalg.norm(d["phi_hat"][:, b], axis=-1).max() <= 1.0 + 1e-12
        assert ang[late, b].max() < 0.25, ang[late, b].max()
        assert ang[late, b].max() < 0.3 * ang[late, 2].min(), (b, ang[late].max(0))
    assert res.actuator["singularity"].min() > 0.3


def test_known_frequency_harmonic_is_rejected():
    """A constant + harmonic torque at a known frequency (ν = ω_n/3) on a 30 %-mis-modelled body
    (time-scaled: J/1e4, ω_n = 1 rad/s): the adaptive law's residual error is a small fraction
    of the geometric PD's with the same initial inertia and bandwidth."""
    J = J0 / 1e4
    nu = 1.0 / 3.0
    phi = disturbance_parameters([0.01, 0.03, -0.02], [[0.03, -0.02, 0.02]], [[0.0, 0.02, 0.01]])

    c0, a1, b1 = phi.reshape(3, 3)

    def torque(t, R, omega):
        return np.broadcast_to(c0 + a1 * np.sin(nu * t) + b1 * np.cos(nu * t), omega.shape)

    spec = ClosedLoopSpec(1.0, 0.9, 0.1)
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(), torque)
    Jc = 1.3 * J
    ctrls = [
        _adaptive(Jc, spec, frequencies=[nu]),
        GeometricPD(Jc, **tune_geometric_pd(Jc, spec, error="trace")),
    ]
    res = simulate(
        plant,
        OnePerSpacecraft(ctrls),
        ConstantAttitude(R_SLEW),
        plant.initial_state(np.eye(3), batch=2),
        t_final=200.0,
        dt=0.1,
        log_every=2,
    )
    ang = res.attitude_error_angle()
    last = res.t >= 200.0 - 2 * np.pi / nu
    assert ang[last, 1].max() > np.deg2rad(0.5)  # the PD's forced response is visible
    assert ang[last, 0].max() < 0.02 * ang[last, 1].max(), ang[last].max(0)
    # the disturbance estimate follows the true torque
    d_true = harmonic_regressor(float(res.t[-1]), [nu]) @ phi
    np.testing.assert_allclose(res.controller["d_hat"][-1, 0], d_true, atol=2e-3)


def test_projection_bounds_the_estimates():
    """Balls that exclude the true parameters: the estimates stay on them (flags set), and the
    loop remains bounded."""
    J = J0 / 1e4
    spec = ClosedLoopSpec(1.0, 0.9, 0.05)
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(), ConstantHarmonicTorque(n=0.3))
    ctrl = _adaptive(1.3 * J, spec, frequencies=[0.3, 0.6], disturbance_bound=0.05)
    ctrl_t = _adaptive(1.3 * J, spec, frequencies=[0.3, 0.6], inertia_bound=0.01)
    res = simulate(
        plant,
        OnePerSpacecraft([ctrl, ctrl_t]),
        ConstantAttitude(R_SLEW),
        plant.initial_state(np.eye(3), batch=2),
        t_final=60.0,
        dt=0.05,
    )
    d = res.controller
    assert np.linalg.norm(d["phi_hat"][:, 0], axis=-1).max() <= 0.05 * (1 + 1e-12)
    assert d["phi_projected"][:, 0].any()
    r = np.linalg.norm(d["theta_hat"][:, 1] - ctrl_t.theta0, axis=-1)
    assert r.max() <= ctrl_t.inertia_radius * (1 + 1e-12) and d["theta_projected"][:, 1].any()
    assert np.all(np.isfinite(res.omega)) and np.abs(res.omega).max() < 1.0


# ----------------------------------------------------------------------------- the seam


def _state(rng, B):
    return AttitudeState(so3.exp(rng.normal(size=(B, 3))), 0.01 * rng.normal(size=(B, 3)))


def test_batched_equals_per_spacecraft_and_reset_clears_state():
    rng = np.random.default_rng(3)
    B = 4
    ref = AttitudeReference(so3.exp(np.array([0.3, -0.2, 0.1])), [0.01, 0.0, 0.02], [0, 1e-4, 0])
    states = [_state(rng, B) for _ in range(3)]
    ctrl = _adaptive(1.3 * J0)
    singles = [copy.deepcopy(ctrl) for _ in range(B)]
    ctrl.reset(0.0, B)
    for s in singles:
        s.reset(0.0, 1)
    for k, st in enumerate(states):
        u = ctrl.command(10.0 * k, st, ref)
        for b, s in enumerate(singles):
            ub = s.command(10.0 * k, AttitudeState(st.R[b : b + 1], st.omega[b : b + 1]), ref)
            np.testing.assert_allclose(u[b : b + 1], ub, rtol=1e-12, atol=1e-12)
    d = ctrl.diagnostics()
    assert d["theta_hat"].shape == (B, 6) and d["phi_hat"].shape == (B, 15)
    assert d["J_hat"].shape == (B, 3, 3) and not np.allclose(d["theta_hat"], ctrl.theta0)
    ctrl.reset(0.0, 2)
    assert ctrl.diagnostics() == {}
    np.testing.assert_array_equal(ctrl.theta_hat, np.tile(ctrl.theta0, (2, 1)))
    np.testing.assert_array_equal(ctrl.phi_hat, 0.0)


def test_nominal_estimates_give_the_certainty_equivalent_torque():
    """With θ̂ = θ and φ̂ = φ: M = −K_s s − k_R e_R + ω × Jω + J a_r − d (hand evaluation)."""
    rng = np.random.default_rng(4)
    J = J0
    ctrl = _adaptive(J, phi0=PHI_SEED)
    ctrl.reset(0.0, 1)
    st = _state(rng, 1)
    R_d = so3.exp(np.array([0.2, 0.1, -0.3]))
    w_d, dw_d = np.array([0.01, -0.02, 0.005]), np.array([1e-4, 0.0, -2e-4])
    t = 321.0
    u = ctrl.command(t, st, AttitudeReference(R_d, w_d, dw_d))[0]
    R, w = st.R[0], st.omega[0]
    Rt = R_d.T @ R
    _, e_R = E.trace_error(R, R_d)
    wdb, dwdb = Rt.T @ w_d, Rt.T @ dw_d
    e_W = w - wdb
    s = e_W + ctrl.c * e_R
    a_r = dwdb - np.cross(w, wdb) - ctrl.c * error_rate_matrix(Rt)[0] @ e_W
    d = ConstantHarmonicTorque().torque_at(t)
    want = -ctrl.k_s @ s - ctrl.k_R * e_R + np.cross(w, J @ w) + J @ a_r - d
    np.testing.assert_allclose(u, want, rtol=1e-10, atol=1e-12)


def test_bad_input():
    J = J0
    ok = tune_adaptive_so3(J, SPEC, disturbance_bound=1.0, frequencies=[0.01])
    for key, bad in (
        ("k_R", -1.0),
        ("c", 0.0),
        ("gamma_theta", float("nan")),
        ("gamma_phi", -2.0),
        ("disturbance_bound", 0.0),
        ("inertia_bound", -0.1),
        ("frequencies", [0.0]),
        ("frequencies", [0.1, 0.1]),
        ("frequencies", [[0.1]]),
        ("error", "euler"),
        ("k_s", -np.eye(3)),
    ):
        kw = dict(ok, **{key: bad})
        with pytest.raises(ValueError, match=f"^{key}:"):
            AdaptiveGeometricSO3(J, **kw)
    with pytest.raises(ValueError, match="^phi0:"):
        AdaptiveGeometricSO3(J, **ok, phi0=np.zeros(4))
    with pytest.raises(ValueError, match="^phi0:"):
        AdaptiveGeometricSO3(J, **ok, phi0=np.full(9, 1.0))
    with pytest.raises(ValueError, match="^G:"):
        AdaptiveGeometricSO3(J, **dict(ok, error="log"), G=np.diag([1.0, 2.0, 3.0]))
    c = AdaptiveGeometricSO3(J, **ok)
    rng = np.random.default_rng(5)
    ref = AttitudeReference.regulation(np.eye(3))
    with pytest.raises(RuntimeError, match="reset"):
        c.command(0.0, _state(rng, 1), ref)
    c.reset(0.0, 1)
    with pytest.raises(ValueError, match="^state:"):
        c.command(0.0, _state(rng, 2), ref)
    c.command(5.0, _state(rng, 1), ref)
    with pytest.raises(ValueError, match="^t:"):
        c.command(4.0, _state(rng, 1), ref)
    with pytest.raises(ValueError, match="^t:"):
        c.command(float("nan"), _state(rng, 1), ref)
    with pytest.raises(ValueError, match="^phi_true:"):
        c.lyapunov(J, np.zeros(4))
    with pytest.raises(ValueError, match="^batch_size:"):
        c.reset(0.0, 0)
    with pytest.raises(ValueError, match="^a:"):
        inertia_regressor([1.0, 2.0])
    with pytest.raises(ValueError, match="^theta:"):
        inertia_from_parameters(np.zeros(5))
    with pytest.raises(ValueError, match="^constant:"):
        disturbance_parameters([1.0])
    with pytest.raises(ValueError, match="^cosine:"):
        disturbance_parameters(np.zeros(3), np.zeros((2, 3)), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="^R_tilde:"):
        error_rate_matrix(np.ones((3, 3)))
    with pytest.raises(TuningInfeasible, match="^integral_ratio:"):
        tune_adaptive_so3(J, SPEC, 1.0, integral_ratio=0.5)
    with pytest.raises(ValueError, match="^disturbance_bound:"):
        tune_adaptive_so3(J, SPEC, -1.0)
    # inputs are not mutated
    Jc = J.copy()
    phi0 = np.zeros(9)
    AdaptiveGeometricSO3(Jc, **ok, phi0=phi0)
    np.testing.assert_array_equal(Jc, J)
    np.testing.assert_array_equal(phi0, 0.0)
