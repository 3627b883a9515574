"""MPC on SO(3) (SPEC §6 item 4): model, OSQP vs cvxpy, closed loop on the SGCMG plant, fallback.

Independent routes: the linearised LGVI against central finite differences of the nonlinear LGVI
step (:func:`liecontrol.integrators.lgvi_step`) in the error coordinates; the terminal weight
against the Riccati equation it must satisfy; the OSQP backend against the cvxpy/Clarabel
formulation (interior point); the closed loop on the seed-000 spacecraft (RKMK4 plant with the
SGCMG pyramid, :func:`spacecraft.simulate`).
"""

from __future__ import annotations

import copy
import logging

import numpy as np
import pytest
from conftest import SEED000_J, seed000_spacecraft
from hypothesis import given, settings
from hypothesis import strategies as st

from liecontrol.control import AttitudeReference, AttitudeState, ConstantAttitude, GeometricPD
from liecontrol.control.mpc import (
    SO3MPC,
    STATUS_NAMES,
    error_state,
    reference_model,
    rest_model,
    stage0_model,
)
from liecontrol.integrators import lgvi_step
from liecontrol.lie import so3
from spacecraft import simulate

J = SEED000_J
T = 1.0
N = 20
U_MAX = 20.0
Q = [200.0] * 3 + [2.0e5] * 3
R = [1.0] * 3


def _mpc(**kw) -> SO3MPC:
    args = dict(J=J, horizon=N, dt=T, Q=Q, R=R, u_max=U_MAX)
    args.update(kw)
    return SO3MPC(**args)


def _slew(t: float) -> AttitudeReference:
    """Constant-rate slew about a fixed axis: the extrapolation of the default path is exact."""
    w = np.array([0.0, 0.006, 0.008])
    return AttitudeReference(so3.exp(np.array([0.1, 0.2, 0.3])) @ so3.exp(t * w), w, np.zeros(3))


# ---------------------------------------------------------------------------------------------
# the prediction model


def _lgvi_error_step(x, u, Rd0, wd0, Rd1, wd1):
    """Nonlinear one-step map in error coordinates: x at knot k, torque u held → x at k+1."""
    Rk = Rd0 @ so3.exp(x[:3])
    wk = x[3:] + (Rk.T @ Rd0) @ wd0
    R1, Pi1 = lgvi_step(Rk, J @ wk, u, u, T, J)
    return error_state(R1, np.linalg.solve(J, Pi1), Rd1, wd1)


def test_reference_model_matches_finite_differences_of_the_lgvi():
    rng = np.random.default_rng(1)
    w0 = np.array([0.02, -0.01, 0.03])
    dw = np.array([1e-3, 2e-3, -1e-3])
    ws = w0 + T * np.arange(4)[:, None] * dw
    F = so3.exp(0.5 * T * (ws[:-1] + ws[1:]))
    A, B, u_ref, c = reference_model(J, T, ws, F)
    Rd = [so3.exp(rng.normal(size=3))]
    for k in range(3):
        Rd.append(Rd[-1] @ F[k])
    for k in range(3):
        args = (Rd[k], ws[k], Rd[k + 1], ws[k + 1])
        f0 = _lgvi_error_step(np.zeros(6), u_ref[k], *args)
        np.testing.assert_allclose(f0, c[k], atol=1e-12)  # the defect term
        h = 1e-6
        Afd = np.column_stack(
            [
                (
                    _lgvi_error_step(h * e, u_ref[k], *args)
                    - _lgvi_error_step(-h * e, u_ref[k], *args)
                )
                / (2 * h)
                for e in np.eye(6)
            ]
        )
        hu = 1e-3
        Bfd = np.column_stack(
            [
                (
                    _lgvi_error_step(np.zeros(6), u_ref[k] + hu * e, *args)
                    - _lgvi_error_step(np.zeros(6), u_ref[k] - hu * e, *args)
                )
                / (2 * hu)
                for e in np.eye(3)
            ]
        )
        np.testing.assert_allclose(A[k], Afd, atol=1e-8)
        np.testing.assert_allclose(B[k], Bfd, atol=1e-10 * np.abs(B[k]).max() + 1e-14)
    # the discrete reference torque converges to the continuous feed-forward JΩ̇_d + Ω_d × JΩ_d
    errs = []
    for h in (0.4, 0.2, 0.1):
        wk = w0 + h * np.arange(2)[:, None] * dw
        _, _, uh, _ = reference_model(J, h, wk, so3.exp(0.5 * h * (wk[:-1] + wk[1:])))
        wm = 0.5 * (wk[0] + wk[1])
        errs.append(np.abs(uh[0] - (J @ dw + np.cross(wm, J @ wm))).max())
    assert errs[0] / errs[1] > 1.8 and errs[1] / errs[2] > 1.8, errs


_vec3 = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3).map(np.array)


@settings(max_examples=40, deadline=None)
@given(_vec3, _vec3, _vec3, _vec3, _vec3)
def test_error_state_is_left_invariant(a, b, g, w, wd):
    """x(G R, Ω; G R_d, Ω_d) = x(R, Ω; R_d, Ω_d): the error lives in the Lie algebra, not in a
    chart of the inertial frame; and ξ = 0, e_Ω = 0 exactly on the reference."""
    R, R_d, G = so3.exp(a), so3.exp(b), so3.exp(g)
    x = error_state(R, 0.1 * w, R_d, 0.1 * wd)
    np.testing.assert_allclose(error_state(G @ R, 0.1 * w, G @ R_d, 0.1 * wd), x, atol=1e-9)
    np.testing.assert_allclose(error_state(R_d, 0.1 * wd, R_d, 0.1 * wd), 0.0, atol=1e-15)
    if np.linalg.norm(x[:3]) < np.pi - 1e-6:
        np.testing.assert_allclose(R_d @ so3.exp(x[:3]), R, atol=1e-12)


def test_rest_model_is_the_zoh_double_integrator():
    A, B = rest_model(J, T)
    Ji = np.linalg.inv(J)
    np.testing.assert_allclose(
        A, np.block([[np.eye(3), T * np.eye(3)], [np.zeros((3, 3)), np.eye(3)]]), atol=1e-15
    )
    np.testing.assert_allclose(B, np.vstack([0.5 * T * T * Ji, T * Ji]), rtol=1e-12)


def test_stage0_prediction_and_jacobian():
    rng = np.random.default_rng(2)
    R0 = so3.exp(rng.normal(size=3))
    w0 = 0.05 * rng.normal(size=3)
    Rd1 = so3.exp(rng.normal(size=3))
    wd1 = np.array([0.01, 0.0, -0.02])
    ub = np.array([1.0, -2.0, 3.0])

    def f(u):
        R1, Pi1 = lgvi_step(R0, J @ w0, u, u, T, J)
        return error_state(R1, np.linalg.solve(J, Pi1), Rd1, wd1)

    x1, B0 = stage0_model(J, T, R0, w0, Rd1, wd1, ub)
    np.testing.assert_allclose(x1, f(ub), atol=1e-14)
    Bfd = np.column_stack([(f(ub + 1e-3 * e) - f(ub - 1e-3 * e)) / 2e-3 for e in np.eye(3)])
    np.testing.assert_allclose(B0, Bfd, atol=1e-11)


def test_terminal_weight_solves_the_riccati_equation():
    ctrl = _mpc()
    A, B = rest_model(J, T)
    P, Qm, Rm = ctrl.P, ctrl.Q, ctrl.R
    res = A.T @ P @ A - P - A.T @ P @ B @ np.linalg.solve(Rm + B.T @ P @ B, B.T @ P @ A) + Qm
    assert np.abs(res).max() < 1e-9 * np.abs(P).max()
    assert np.linalg.eigvalsh(P)[0] > 0


# ---------------------------------------------------------------------------------------------
# OSQP-direct vs cvxpy-Parameter formulation


def _states(rng, B, scale_deg, rate):
    axes = rng.normal(size=(B, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    ang = np.deg2rad(scale_deg) * rng.uniform(0.2, 1.0, size=(B, 1))
    return AttitudeState(so3.exp(ang * axes), rate * rng.normal(size=(B, 3)))


def _mixed_states(seed):
    rng = np.random.default_rng(seed)
    small = _states(rng, 4, 0.5, 1e-5)  # near the reference: constraints inactive
    large = _states(rng, 4, 170.0, 0.01)  # large errors and rates: box active
    return AttitudeState(
        np.concatenate([small.R, large.R]), np.concatenate([small.omega, large.omega])
    )


def _momentum_rate_limit(limit):
    """A spacecraft-side style constraint on ḣ_cmd = −u − ω × h: |ḣ_cmd,i| ≤ limit."""

    def extra(state):
        h = np.zeros(3) if state.h is None else state.h[0]
        wxh = np.cross(state.omega[0], h)
        return -np.eye(3), -limit + wxh, limit + wxh

    return extra


@pytest.mark.parametrize(
    "case",
    ["regulation", "tracking", "extra_constraints", "exact_stage0_jacobian"],
)
def test_osqp_and_cvxpy_give_the_same_first_input(case):
    states = _mixed_states(3)
    B = states.batch_size
    kw: dict = {}
    ref = AttitudeReference.regulation(np.eye(3))
    if case == "tracking":
        ref = _slew(0.0)
    elif case == "extra_constraints":
        kw["extra_constraints"] = _momentum_rate_limit(12.0)
        states = AttitudeState(states.R, states.omega, np.full((B, 3), 50.0))
    elif case == "exact_stage0_jacobian":
        kw["exact_stage0_jacobian"] = True
    out = {}
    for backend in ("osqp", "cvxpy"):
        ctrl = _mpc(backend=backend, **kw)
        ctrl.reset(0.0, B)
        out[backend] = ctrl.command(0.0, states, ref)
        d = ctrl.diagnostics()
        assert (d["status"] == 1).all(), (backend, d["status"])
        assert not d["fallback_active"].any()
    np.testing.assert_allclose(out["osqp"], out["cvxpy"], atol=1e-4, rtol=0)
    u = out["osqp"]
    assert np.abs(u).max() <= U_MAX
    saturated = np.isclose(np.abs(u), U_MAX, atol=1e-6).any(axis=1)
    if case != "extra_constraints":
        assert saturated[4:].any() and not saturated[:4].any()  # active and inactive cases
    else:
        hdot = -u - np.cross(states.omega, states.h)
        assert np.abs(hdot).max() <= 12.0 + 1e-5
        assert np.isclose(np.abs(hdot), 12.0, atol=1e-5).any()  # the constraint binds


def test_preview_equals_extrapolation_on_a_constant_rate_slew():
    st = _mixed_states(4)
    us = []
    for preview in (None, _slew):
        ctrl = _mpc(reference_preview=preview)
        ctrl.reset(0.0, st.batch_size)
        us.append(ctrl.command(0.0, st, _slew(0.0)))
    np.testing.assert_allclose(us[0], us[1], atol=1e-6)


# ---------------------------------------------------------------------------------------------
# closed loop on the seed-000 SGCMG spacecraft


@pytest.fixture(scope="module")
def manoeuvres():
    """30°, 90° and 170° rest-to-rest about a generic axis, one batch (one QP per spacecraft)."""
    plant = seed000_spacecraft()
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    angles = np.deg2rad([30.0, 90.0, 170.0])
    R_d = so3.exp(np.deg2rad(20.0) * np.array([0.0, 0.0, 1.0]))
    R0 = R_d @ so3.exp(angles[:, None] * axis)
    res = simulate(
        plant,
        _mpc(),
        ConstantAttitude(R_d),
        plant.initial_state(R0),
        t_final=360.0,
        dt=0.2,
        control_period=T,
        log_every=5,
    )
    return res


def test_closed_loop_converges_on_30_90_170_deg(manoeuvres):
    res = manoeuvres
    err = np.rad2deg(res.attitude_error_angle())
    np.testing.assert_allclose(err[0], [30.0, 90.0, 170.0], atol=1e-9)
    assert (err[-1] < 0.1).all(), err[-1]
    assert np.abs(res.omega[-1]).max() < 1e-4
    # the larger manoeuvre is the slower one, and none of them unwinds (error falls overall)
    t_half = [res.t[np.argmax(err[:, b] < 0.5 * err[0, b])] for b in range(3)]
    assert t_half[0] <= t_half[1] <= t_half[2]
    d = res.controller
    assert (d["status"] == 1).all() and not d["fallback_active"].any()


def test_closed_loop_torque_limits_never_violated(manoeuvres):
    res = manoeuvres
    assert np.abs(res.u_cmd).max() <= U_MAX
    assert np.isclose(np.abs(res.u_cmd).max(), U_MAX)  # the limit was reached (170°)
    # the CMGs delivered the command (no gimbal-rate saturation, far from singular)
    assert not res.actuator["saturated"].any()
    assert np.abs(res.u - res.u_cmd).max() < 0.01 * U_MAX
    assert res.actuator["singularity"].min() > 0.3


def test_tracking_a_slewing_reference_on_the_ideal_rigid_body():
    """Time-varying linearisation along a slew; the body is the LGVI at T/4 (not the model's T)."""
    ctrl = _mpc()
    ctrl.reset(0.0, 1)
    Rk, wk = so3.exp(np.array([0.8, -0.5, 0.3])), np.zeros(3)
    errs = []
    for k in range(300):
        u = ctrl.command(k * T, AttitudeState(Rk[None], wk[None]), _slew(k * T))[0]
        assert np.abs(u).max() <= U_MAX
        for _ in range(4):
            Rk, Pi = lgvi_step(Rk, J @ wk, u, u, T / 4, J)
            wk = np.linalg.solve(J, Pi)
        ref = _slew((k + 1) * T)
        errs.append(np.linalg.norm(error_state(Rk, wk, ref.R_d, ref.omega_d)[:3]))
    errs = np.rad2deg(errs)
    assert errs[0] > 50.0 and errs[-1] < 0.05, (errs[0], errs[-1])
    assert errs[-1] < 0.2 * errs[199]  # still converging exponentially, no steady offset
    assert (ctrl.diagnostics()["status"] == 1).all()


# ---------------------------------------------------------------------------------------------
# failure → certified re-solve → fallback


def test_iteration_limit_is_resolved_and_reported(caplog):
    """OSQP stopped after one iteration: the step is re-solved by Clarabel on the same QP, the
    torque equals the interior-point backend's, and the re-solve is in the diagnostics and the
    log (once, at its onset), not silent; the fallback is not used."""
    st = _mixed_states(3)
    ref = AttitudeReference.regulation(np.eye(3))
    ctrl = _mpc(solver_settings={"max_iter": 1, "polishing": False})
    ctrl.reset(0.0, st.batch_size)
    with caplog.at_level(logging.WARNING, logger="liecontrol.control.mpc"):
        u = ctrl.command(0.0, st, ref)
        ctrl.command(T, st, ref)
    d = ctrl.diagnostics()
    assert (d["osqp_status"] == -7).all() and d["resolved"].all() and (d["status"] == 1).all()
    assert not d["fallback_active"].any() and (d["resolve_count"] == 2).all()
    assert (d["kkt_torque_bound"] <= ctrl.kkt_tolerance).all()
    assert caplog.text.count("re-solved by Clarabel") == st.batch_size  # onset only
    ref_ctrl = _mpc(backend="cvxpy")
    ref_ctrl.reset(0.0, st.batch_size)
    np.testing.assert_allclose(u, ref_ctrl.command(0.0, st, ref), atol=1e-4)


def test_uncertified_answer_without_resolve_falls_back(caplog):
    """An answer OSQP calls solved but the KKT certificate rejects (a loose tolerance, no
    polishing, a certificate demanding 1e-9 N·m) is not used: status −13, the fallback."""
    ctrl = _mpc(
        solver_settings={"eps_abs": 1e-1, "eps_rel": 1e-1, "polishing": False},
        kkt_tolerance=1e-9,
        resolve=False,
    )
    st = _mixed_states(2)
    ctrl.reset(0.0, st.batch_size)
    with caplog.at_level(logging.WARNING, logger="liecontrol.control.mpc"):
        ctrl.command(0.0, st, AttitudeReference.regulation(np.eye(3)))
    d = ctrl.diagnostics()
    assert (d["osqp_status"] == 1).all() and (d["status"] == -13).all()
    assert d["fallback_active"].all() and not d["resolved"].any()
    assert "KKT certificate failed" in caplog.text


def test_certified_answers_are_osqp_own():
    """On a well-conditioned step OSQP's polished answer passes the certificate: no re-solve,
    and the certified bound is far below the tolerance."""
    ctrl = _mpc()
    st = _mixed_states(4)
    ctrl.reset(0.0, st.batch_size)
    ctrl.command(0.0, st, AttitudeReference.regulation(np.eye(3)))
    d = ctrl.diagnostics()
    assert (d["status"] == 1).all() and not d["resolved"].any()
    assert (d["kkt_torque_bound"] < 1e-2 * ctrl.kkt_tolerance).all()


@pytest.mark.parametrize(
    ("kw", "match"),
    [({"kkt_tolerance": 0.0}, "kkt_tolerance"), ({"resolve": "yes"}, "resolve")],
)
def test_bad_certificate_arguments(kw, match):
    with pytest.raises(ValueError, match=f"^{match}"):
        _mpc(**kw)


@pytest.mark.parametrize("backend", ["osqp", "cvxpy"])
def test_infeasible_extra_constraint_triggers_fallback_and_is_logged(backend, caplog):
    def impossible(state):  # C u ≥ u_max + 1 contradicts the box
        return np.eye(3), np.full(3, U_MAX + 1.0), np.full(3, np.inf)

    ctrl = _mpc(backend=backend, horizon=3, extra_constraints=impossible)
    st = _mixed_states(5)
    ref = AttitudeReference.regulation(np.eye(3))
    ctrl.reset(0.0, st.batch_size)
    with caplog.at_level(logging.WARNING, logger="liecontrol.control.mpc"):
        u = ctrl.command(0.0, st, ref)
    d = ctrl.diagnostics()
    assert d["fallback_active"].all()
    assert (d["status"] == -3).all(), d["status"]  # primal infeasible
    assert STATUS_NAMES[-3] == "primal infeasible"
    assert "fallback GeometricPD" in caplog.text and "primal infeasible" in caplog.text
    # the fallback's torque, clipped to the box
    pd = copy.deepcopy(ctrl.fallback)
    pd.reset(0.0, st.batch_size)
    np.testing.assert_allclose(u, np.clip(pd.command(0.0, st, ref), -U_MAX, U_MAX), atol=1e-12)
    assert np.abs(u).max() <= U_MAX


def test_iteration_limit_triggers_configured_fallback_then_recovers(caplog):
    class Zero(GeometricPD):
        def command(self, t, state, reference):
            return np.zeros((state.batch_size, 3))

    fb = Zero(J, 1.0, 1.0)
    # resolve=False: the path without the Clarabel re-solve (test_iteration_limit_is_resolved)
    ctrl = _mpc(
        fallback=fb,
        solver_settings={"max_iter": 1, "eps_abs": 1e-12, "eps_rel": 1e-12},
        resolve=False,
    )
    st = _mixed_states(6)
    ctrl.reset(0.0, st.batch_size)
    with caplog.at_level(logging.WARNING, logger="liecontrol.control.mpc"):
        u = ctrl.command(0.0, st, AttitudeReference.regulation(np.eye(3)))
    d = ctrl.diagnostics()
    assert (d["status"] == -7).all() and d["fallback_active"].all()
    assert (d["fallback_count"] == 1).all()
    assert np.all(u == 0.0)
    assert "maximum iterations reached" in caplog.text


def test_fallback_recorded_in_simulation_log():
    """In a closed loop every fallback step shows up in the simulator's controller log."""
    plant = seed000_spacecraft()
    ctrl = _mpc(horizon=5, solver_settings={"max_iter": 1, "polishing": False}, resolve=False)
    res = simulate(
        plant,
        ctrl,
        ConstantAttitude(np.eye(3)),
        plant.initial_state(so3.exp(np.array([0.5, 0.0, 0.0]))),
        t_final=3.0,
        dt=0.5,
        control_period=T,
    )
    d = res.controller
    assert d["fallback_active"][:-1].all() and (d["status"][:-1] == -7).all()
    assert d["fallback_count"][-1, 0] >= 3
    assert np.abs(res.u_cmd).max() <= U_MAX


# ---------------------------------------------------------------------------------------------
# bad input


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"horizon": 0}, "horizon"),
        ({"horizon": 2.5}, "horizon"),
        ({"horizon": True}, "horizon"),
        ({"dt": 0.0}, "dt"),
        ({"dt": -1.0}, "dt"),
        ({"dt": np.nan}, "dt"),
        ({"Q": [1.0, 1.0, 1.0, 1.0, 1.0, 0.0]}, "Q"),
        ({"Q": -np.eye(6)}, "Q"),
        ({"Q": np.eye(5)}, "Q"),
        ({"R": np.diag([1.0, -1.0, 1.0])}, "R"),
        ({"R": np.array([[1.0, 2.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])}, "R"),
        ({"P": np.zeros((6, 6))}, "P"),
        ({"u_max": 0.0}, "u_max"),
        ({"u_max": [1.0, 2.0]}, "u_max"),
        ({"J": -J}, "J"),
        ({"backend": "gurobi"}, "backend"),
        ({"extra_constraints": 3}, "extra_constraints"),
        ({"reference_preview": "x"}, "reference_preview"),
        ({"fallback": object()}, "fallback"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(kw, name):
    with pytest.raises(ValueError, match=f"^{name}"):
        _mpc(**kw)


def test_reference_not_on_so3_raises():
    ctrl = _mpc(horizon=2)
    ctrl.reset(0.0, 1)
    st = AttitudeState(np.eye(3)[None], np.zeros((1, 3)))
    with pytest.raises(ValueError, match="^R_d"):  # the container checks first
        AttitudeReference(np.eye(3) * 1.1, np.zeros(3), np.zeros(3))
    bad = AttitudeReference.unchecked(np.eye(3) * 1.1, np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="^R_d"):
        ctrl.command(0.0, st, bad)
    bad_state = AttitudeState.unchecked(np.eye(3)[None] * 2, np.zeros((1, 3)))
    with pytest.raises(ValueError, match="^R"):
        ctrl.command(0.0, bad_state, _slew(0.0))
    with pytest.raises(ValueError, match="^batch_size"):
        ctrl.reset(0.0, 0)


def test_copy_of_a_reset_controller_starts_unreset():
    ctrl = _mpc(horizon=2)
    ctrl.reset(0.0, 1)
    ctrl.command(0.0, AttitudeState(np.eye(3)[None], np.zeros((1, 3))), _slew(0.0))
    twin = copy.deepcopy(ctrl)
    with pytest.raises(RuntimeError, match="reset"):
        twin.command(0.0, AttitudeState(np.eye(3)[None], np.zeros((1, 3))), _slew(0.0))


# ---------------------------------------------------------------------------------------------
# the fast path: caches, in-place updates, shifted warm starts, unchecked kernels


def _wobble(t: float) -> AttitudeReference:
    """Rate and acceleration vary every step: the linearisation (and the QP matrix) changes."""
    a = np.array([0.0, 0.6, 0.8])
    return AttitudeReference(
        so3.exp(0.5 * np.sin(0.05 * t) * a),
        0.025 * np.cos(0.05 * t) * a,
        -1.25e-3 * np.sin(0.05 * t) * a,
    )


@pytest.mark.parametrize("exact", [False, True])
def test_warm_started_cached_steps_equal_fresh_solves(exact):
    """Shifted warm starts, the model cache (the matrix sent only when the linearisation
    changes) and vector-only updates give the inputs of a QP built from scratch at each step,
    across reference switches (rest → slew → varying rate → rest)."""
    ctrl = _mpc(exact_stage0_jacobian=exact)
    ctrl.reset(0.0, 1)
    Rk, wk = so3.exp(np.array([0.9, -0.4, 0.3])), np.zeros(3)
    refs = [AttitudeReference.regulation(np.eye(3))] * 4
    refs += [_slew(k * T) for k in range(4, 8)] + [_wobble(k * T) for k in range(8, 12)]
    refs += [AttitudeReference.regulation(np.eye(3))] * 3
    for k, ref in enumerate(refs):
        st = AttitudeState(Rk[None], wk[None])
        u = ctrl.command(k * T, st, ref)
        fresh = _mpc(exact_stage0_jacobian=exact)
        fresh.reset(k * T, 1)
        np.testing.assert_allclose(u, fresh.command(k * T, st, ref), atol=1e-6, rtol=0)
        assert ctrl.diagnostics()["status"][0] == 1
        Rk, Pi = lgvi_step(Rk, J @ wk, u[0], u[0], T, J)
        wk = np.linalg.solve(J, Pi)


def test_failed_polish_is_retried_at_a_tighter_tolerance():
    from types import SimpleNamespace

    ctrl = _mpc()
    ctrl.reset(0.0, 1)
    st = AttitudeState(so3.exp(np.array([[0.4, -0.2, 0.1]])), np.array([[1e-3, 0.0, -2e-3]]))
    ref = AttitudeReference.regulation(np.eye(3))
    u_ok = ctrl.command(0.0, st, ref)
    qp = ctrl._qps[0]

    class FailOnce:  # reports one unsuccessful polish, otherwise the real solver
        def __init__(self, real):
            self.real, self.armed = real, True

        def __getattr__(self, name):
            return getattr(self.real, name)

        @property
        def info(self):
            i = self.real.info
            if self.armed:
                self.armed = False
                return SimpleNamespace(
                    status_val=i.status_val, status_polish=-1, iter=i.iter, run_time=i.run_time
                )
            return i

    qp._s = FailOnce(qp._s)
    u = ctrl.command(0.0, st, ref)
    assert qp.polish_retries == 1 and ctrl.diagnostics()["status"][0] == 1
    np.testing.assert_allclose(u, u_ok, atol=1e-7)
    assert qp.solver.settings.eps_abs == pytest.approx(1e-3)  # restored


@settings(max_examples=60, deadline=None)
@given(_vec3, st.floats(0.0, np.pi), _vec3, _vec3)
def test_fast_error_state_equals_error_state(axis, angle, wd, w):
    """The Python-float log/error path of the hot loop agrees with the validated functions,
    including near π (where it defers to so3.log)."""
    from liecontrol.control.mpc import _error_fast

    n = axis / max(np.linalg.norm(axis), 1e-9) if np.linalg.norm(axis) > 1e-6 else np.eye(3)[0]
    R_d = so3.exp(np.array([0.3, -1.0, 2.0]))
    R = R_d @ so3.exp(angle * n)
    x = _error_fast(R[None], 0.1 * w[None], R_d, 0.1 * wd)
    np.testing.assert_allclose(x[0], error_state(R, 0.1 * w, R_d, 0.1 * wd), atol=1e-12)


def test_extra_constraints_see_each_spacecraft_with_its_actuator_state():
    seen = []

    def extra(state):
        seen.append((state.h.copy(), state.actuator_state.copy()))
        return np.eye(3), -np.full(3, 50.0), np.full(3, 50.0)

    st = _mixed_states(7)
    B = st.batch_size
    h = np.arange(3 * B, dtype=float).reshape(B, 3)
    act = np.arange(4 * B, dtype=float).reshape(B, 4)
    ctrl = _mpc(horizon=3, extra_constraints=extra)
    ctrl.reset(0.0, B)
    ref = AttitudeReference.regulation(np.eye(3))
    ctrl.command(0.0, AttitudeState(st.R, st.omega, h, act), ref)
    assert len(seen) == B
    for b, (hb, ab) in enumerate(seen):
        assert np.array_equal(hb, h[b : b + 1]) and np.array_equal(ab, act[b : b + 1])


def test_non_finite_or_bad_states_raise_on_the_fast_path():
    ctrl = _mpc(horizon=2)
    ctrl.reset(0.0, 1)
    ref = AttitudeReference.regulation(np.eye(3))
    bad_R = np.eye(3)[None].copy()
    bad_R[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="^R"):
        ctrl.command(0.0, AttitudeState(bad_R, np.zeros((1, 3))), ref)
    with pytest.raises(ValueError, match="^R"):  # a reflection
        ctrl.command(0.0, AttitudeState(-np.eye(3)[None], np.zeros((1, 3))), ref)
    with pytest.raises(ValueError, match="^omega"):
        ctrl.command(0.0, AttitudeState(np.eye(3)[None], np.full((1, 3), np.inf)), ref)
    with pytest.raises(ValueError, match="^R_d"):
        ctrl.command(0.0, AttitudeState(np.eye(3)[None], np.zeros((1, 3))),
                     AttitudeReference(-np.eye(3), np.zeros(3), np.zeros(3)))  # fmt: skip


def test_batched_states_use_the_shared_fast_check_and_still_raise():
    """B > 1 goes through ``rotations_pass_fast`` too: a bad matrix anywhere in the batch still
    gets check_rotation_matrix's message."""
    ctrl = _mpc(horizon=2)
    ctrl.reset(0.0, 2)
    ref = AttitudeReference.regulation(np.eye(3))
    for bad, msg in ((np.diag([1.0, 1.0, -1.0]), "reflection"), (1.01 * np.eye(3), "orthonormal")):
        R = np.stack([np.eye(3), bad])
        with pytest.raises(ValueError, match=f"^R: .*{msg}"):
            ctrl.command(0.0, AttitudeState(R, np.zeros((2, 3))), ref)
    u = ctrl.command(0.0, AttitudeState(np.stack([np.eye(3)] * 2), np.zeros((2, 3))), ref)
    np.testing.assert_allclose(u, 0.0, atol=1e-9)
