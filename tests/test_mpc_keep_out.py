"""Pointing cones in the OSQP MPC: linearisation, backends, slack report, closed loop."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.constrained import (
    KeepInCone,
    KeepOutCone,
    UnrecoverableStartWarning,
    cone_margins_deg,
)
from liecontrol.control.mpc import SLACK_TOLERANCE, SO3MPC, _cone_rows, _cone_table
from liecontrol.lie import so3

J = np.diag([15053.0, 6510.0, 11122.0])
SUN = (0.104528, -0.861281, 0.497261)  # the keep-out-sun-slew Sun direction
KO = (KeepOutCone((0.0, 0.0, 1.0), SUN, 20.0),)
KI = (KeepInCone((0.0, 1.0, 0.0), (0.0, 0.5, 0.866025), 75.0),)


def _cos(R: np.ndarray, b: np.ndarray, s: np.ndarray) -> np.ndarray:
    """σ-free cosine bᵀRᵀs per stage and cone by a direct route: (R b)·s."""
    return np.einsum("kij,cj,ci->kc", R, b, s)


def test_cone_gradient_matches_finite_differences() -> None:
    rng = np.random.default_rng(3)
    b, s, sig, h = _cone_table(KO, KI, 0.0)
    N = 4
    R_ref = so3.exp(rng.normal(size=(N, 3)))
    xi_bar = 0.8 * rng.normal(size=(N, 3))
    G, rhs = _cone_rows(R_ref, xi_bar, b, s, sig, h)

    def f(xi: np.ndarray) -> np.ndarray:
        return sig * _cos(R_ref @ so3.exp(xi), b, s)

    eps = 1e-6
    G_fd = np.empty_like(G)
    for i in range(3):
        d = np.zeros(3)
        d[i] = eps
        G_fd[:, :, i] = (f(xi_bar + d) - f(xi_bar - d)) / (2 * eps)
    np.testing.assert_allclose(G, G_fd, atol=1e-8)
    # at the linearisation point the row reads exactly σ c(ξ̄) ≤ h
    lhs = np.einsum("kcj,kj->kc", G, xi_bar) - rhs
    np.testing.assert_allclose(lhs, f(xi_bar) - h, atol=1e-14)
    # the half-angle bounds: keep-out cos α, keep-in −cos β
    np.testing.assert_allclose(h, [np.cos(np.radians(20.0)), -np.cos(np.radians(75.0))])


def _state_near_cone() -> tuple[AttitudeState, AttitudeReference]:
    # on the 120° slew about body x, ~24° from the Sun and moving toward it
    R = so3.exp(np.radians(84.0) * np.array([1.0, 0.0, 0.0]))
    w = np.radians([-0.6, 0.0, 0.0])
    return (
        AttitudeState(R[None], w[None]),
        AttitudeReference(np.eye(3), np.zeros(3), np.zeros(3)),
    )


def _mpc(backend: str, u_max: float = 100.0, **kw) -> SO3MPC:
    Q = np.diag([1e3] * 3 + [1e5] * 3)
    return SO3MPC(J, 10, 0.5, Q, np.full(3, 1.0), u_max, backend=backend, **kw)


@pytest.mark.parametrize("slack_weight", [0.01, 1.0])
def test_osqp_matches_cvxpy_with_active_cone(slack_weight: float) -> None:
    # 0.01: a soft penalty (the slack is used), which OSQP solves to the interior-point
    # answer; 1.0 (the default, an exact penalty: no slack) is badly conditioned for ADMM —
    # OSQP's answer there was 24 N·m off Clarabel's while reporting "solved"; the KKT
    # certificate rejects such an answer and the step is re-solved (docs/mpc.md), so the
    # backend's torque is the minimiser's either way
    st, ref = _state_near_cone()
    u, slack = {}, {}
    for backend in ("osqp", "cvxpy"):
        c = _mpc(backend, keep_out=KO, keep_in=KI, slack_weight=slack_weight)
        c.reset(0.0, 1)
        u[backend] = c.command(0.0, st, ref)[0]
        d = c.diagnostics()
        assert d["status"][0] == 1 and not d["fallback_active"][0]
        if backend == "osqp":
            assert d["kkt_torque_bound"][0] <= c.kkt_tolerance
        slack[backend] = d["cone_slack_max"][0]
    free = _mpc("osqp")
    free.reset(0.0, 1)
    u_free = free.command(0.0, st, ref)[0]
    # the cone is active: the constrained torque is not the unconstrained one
    assert np.linalg.norm(u["osqp"] - u_free) > 5.0
    scale = np.linalg.norm(u["cvxpy"])
    assert np.linalg.norm(u["osqp"] - u["cvxpy"]) <= 1e-6 * scale
    if slack_weight < 1.0:
        assert slack["cvxpy"] > SLACK_TOLERANCE
        np.testing.assert_allclose(slack["osqp"], slack["cvxpy"], rtol=1e-5)
    else:
        assert slack["cvxpy"] < SLACK_TOLERANCE and slack["osqp"] < SLACK_TOLERANCE


def test_uncertified_cone_answer_is_resolved_not_used(caplog: pytest.LogCaptureFixture) -> None:
    """OSQP's answer on the exact-penalty cone QP, forced loose (no polishing, eps 0.1), is
    rejected by the certificate: the step is re-solved, logged and reported; its torque is
    the interior point's."""
    st, ref = _state_near_cone()
    loose = {"eps_abs": 0.1, "eps_rel": 0.1, "polishing": False}
    c = _mpc("osqp", keep_out=KO, keep_in=KI, solver_settings=loose)
    c.reset(0.0, 1)
    with caplog.at_level(logging.INFO, logger="liecontrol.control.mpc"):
        u = c.command(0.0, st, ref)[0]
    d = c.diagnostics()
    assert d["osqp_status"][0] == 1 and d["resolved"][0] and d["status"][0] == 1
    assert "answer failed the KKT check" in caplog.text
    ref_c = _mpc("cvxpy", keep_out=KO, keep_in=KI)
    ref_c.reset(0.0, 1)
    np.testing.assert_allclose(u, ref_c.command(0.0, st, ref)[0], atol=1e-5)
    # the same answer with the check switched off is used as it stands, and is far off
    off = _mpc("osqp", keep_out=KO, keep_in=KI, solver_settings=loose, kkt_tolerance=np.inf)
    off.reset(0.0, 1)
    assert np.linalg.norm(off.command(0.0, st, ref)[0] - u) > 1.0


def test_without_cones_the_qp_is_unchanged() -> None:
    st, ref = _state_near_cone()
    a, b = _mpc("osqp"), _mpc("osqp", keep_out=(), keep_in=())
    for c in (a, b):
        c.reset(0.0, 1)
    np.testing.assert_array_equal(a.command(0.0, st, ref), b.command(0.0, st, ref))
    assert "cone_slack_max" not in b.diagnostics()
    assert b.solver_settings == a.solver_settings


def test_slack_is_reported_and_logged(caplog: pytest.LogCaptureFixture) -> None:
    # 1° outside the cone's boundary, rushing into it, with little torque: no feasible plan
    R = so3.exp(np.radians(79.0) * np.array([1.0, 0.0, 0.0]))
    c = _mpc("osqp", u_max=2.0, keep_out=KO)
    c.reset(0.0, 1)
    st = AttitudeState(R[None], np.radians([[-2.0, 0.0, 0.0]]))
    ref = AttitudeReference(np.eye(3), np.zeros(3), np.zeros(3))
    # the safety filter sees the same start: no braking can keep it out (warned, not silent)
    with (
        caplog.at_level(logging.WARNING, logger="liecontrol.control.mpc"),
        pytest.warns(UnrecoverableStartWarning, match="keep-out cone 0"),
    ):
        c.command(0.0, st, ref)
    d = c.diagnostics()
    assert d["status"][0] == 1
    assert d["cone_slack_used"][0] and d["cone_slack_max"][0] > SLACK_TOLERANCE
    assert any("cone constraints relaxed" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"keep_out": KO[0]}, "keep_out"),
        ({"keep_out": KI}, "keep_out"),
        ({"keep_in": [1.0, 2.0]}, "keep_in"),
        ({"slack_weight": 0.0}, "slack_weight"),
        ({"cone_tightening_deg": -1.0}, "cone_tightening_deg"),
        ({"cone_tightening_deg": 90.0}, "cone_tightening_deg"),
    ],
)
def test_bad_cone_arguments(kw: dict, match: str) -> None:
    with pytest.raises(ValueError, match=f"^{match}"):
        _mpc("osqp", **kw)


@pytest.mark.slow
def test_closed_loop_keeps_out_of_the_cones() -> None:
    from benchmarks.runner import run_suite
    from benchmarks.scenarios import get_scenario

    names = ("keep-out-sun-slew", "keep-out-corridor", "keep-in-keep-out")
    res = run_suite([get_scenario(n) for n in names], ["mpc-keep-out"], jobs=1, progress=False)
    for o in res.outcomes:
        assert o.status == "ok", o.error
        assert o.metrics["min_keep_out_margin_deg"] >= 0.0, o.scenario
        if o.scenario == "keep-in-keep-out":
            assert o.metrics["min_keep_in_margin_deg"] >= 0.0
        assert "constraint-violated" not in o.flags
        assert o.verdict == "success", (o.scenario, o.verdict, o.flags)
    # and the margin check is not vacuous: the constraint-blind MPC enters the Sun cone
    blind = run_suite([get_scenario(names[0])], ["mpc-osqp"], jobs=1, progress=False)
    assert blind.outcomes[0].metrics["min_keep_out_margin_deg"] < 0.0


def test_margins_helper_agrees_with_the_rows() -> None:
    # the linearised keep-out row at ξ̄ is the cone's margin sign (independent module)
    b, s, sig, h = _cone_table(KO, (), 0.0)
    R = so3.exp(np.radians(np.array([[70.0, 0, 0], [120.0, 0, 0]])))
    G, rhs = _cone_rows(np.broadcast_to(np.eye(3), (2, 3, 3)), so3.log(R), b, s, sig, h)
    slack = rhs - np.einsum("kcj,kj->kc", G, so3.log(R))  # h − σ c(R): ≥ 0 iff admissible
    margin = cone_margins_deg(KO, R)
    assert np.array_equal(slack > 0, margin > 0)
