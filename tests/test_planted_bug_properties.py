"""Properties that catch the one-line bugs that once passed every test (issue 26).

Each test states a property over a family of cases built so that the likely wrong versions
disagree with it, rather than one example:

- every gimbal stays within its rate limit, with commands built so that each gimbal in turn is
  the fastest (a peak-rate scan that skips a gimbal lets it run at twice the limit);
- the fused closed loop equals the per-step Python loop in every logged array, saturation and
  diagnostic flag, for every actuator, every kind of limit and every controller with a kernel
  (a clip test with ``>`` instead of ``>=`` flags no sample at all);
- the adaptive law's inertia update equals −Γ(Y(ω)ᵀ(s×ω) + Y(a_r)ᵀs), term by term, with Y the
  public regressor and W = ω^Y(ω) + Y(a_r) formed as a matrix;
- leader–follower consensus on graphs where followers have in-degree > 1 and non-unit weights,
  against the module docstring's law written out per member;
- the SO(3) kernels against the numpy API over dense log-spaced angles near 0, π/2 and π, on
  both sides of every series or branch switch, to the documented 1e-12.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from liecontrol._kernels import attitude as katt
from liecontrol._kernels import so3 as kso3
from liecontrol.control import GeometricPD
from liecontrol.control.adaptive import (
    AdaptiveGeometricSO3,
    error_rate_matrix,
    harmonic_regressor,
    inertia_regressor,
)
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.chart_baselines import MrpPD, QuaternionPD
from liecontrol.control.consensus import (
    AttitudeConsensus,
    CommunicationGraph,
    LeaderFollowerConsensus,
)
from liecontrol.control.fault_tolerant import AdaptiveFaultTolerantSO3
from liecontrol.control.finite_time import FiniteTimeSO3, FixedTimeSO3
from liecontrol.control.geometric_pid import IntegralPD, IntrinsicPID
from liecontrol.control.prescribed_performance import PrescribedPerformance
from liecontrol.control.reference import ConstantAttitude
from liecontrol.errors import large_angle_error
from liecontrol.lie import so3
from spacecraft import (
    GeneralizedSingularityRobust,
    IdealTorqueActuator,
    PseudoInverse,
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
    simulate,
)
from spacecraft import simulator as simulator_module
from spacecraft.steering import PseudoInverseNullMotion

J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])


# ============================================================== SGCMG gimbal-rate limit
def _steering_laws(cluster: SgcmgPyramid) -> dict[str, object]:
    return {
        "pinv": PseudoInverse(),
        "pinv_null": PseudoInverseNullMotion(cluster=cluster),
        "sr": SingularityRobust(),
        "gsr": GeneralizedSingularityRobust(),
        # a plain callable has no kernel: the numpy route of the actuator
        "python": lambda A, hdot_cmd: SingularityRobust()(A, hdot_cmd),
    }


def _commands(cluster, free_act, rng, limit, t, saturate):
    """Rows (u, ω, δ) whose unlimited steering rates have gimbal ``k`` the fastest for
    k = 0, 1, 2, 3 in turn (eight rows each), above ``limit`` (``saturate``) or below it, and
    those unlimited rates (``free_act`` is the same actuator with an unreachable limit)."""
    U, W, D, F, K = [], [], [], [], []
    for k in range(4):
        found = tries = 0
        while found < 8:
            tries += 1
            assert tries < 2000, f"no command with gimbal {k} fastest"
            d = rng.uniform(-np.pi, np.pi, 4)
            c = 0.4 * rng.normal(size=4)
            c[k] = rng.choice([-1.0, 1.0]) * (1.0 + abs(c[k]))
            factor = rng.uniform(1.2, 6.0) if saturate else rng.uniform(0.1, 0.9)
            hd = cluster.jacobian(d) @ (c * factor * limit / np.abs(c).max())
            w = 0.02 * rng.normal(size=3)
            u = -np.cross(w, cluster.momentum(d)) - hd  # ḣ_cmd = −(ω × h + u) = hd
            free = free_act.command(u[None], w[None], d[None], t).delta_dot[0]
            peak = np.abs(free).max()
            if np.argmax(np.abs(free)) != k or (peak > 1.05 * limit) != saturate:
                continue
            if not saturate and peak > 0.95 * limit:
                continue
            U.append(u), W.append(w), D.append(d), F.append(free), K.append(k)
            found += 1
    return tuple(np.array(a) for a in (U, W, D, F, K))


@pytest.mark.parametrize("law", ["pinv", "pinv_null", "sr", "gsr", "python"])
def test_every_gimbal_stays_within_its_rate_limit_when_each_in_turn_is_fastest(law):
    """δ̇ = δ̇_free · min(1, L / max|δ̇_free|): every gimbal ≤ L, the direction kept, the flag set
    exactly when the free rates exceed L — batched and one spacecraft at a time."""
    limit, t = 0.7, 1.3
    cluster = SgcmgPyramid(h0=300.0, gimbal_rate_limit=limit)
    act = SgcmgActuator(cluster, _steering_laws(cluster)[law])
    free_cluster = SgcmgPyramid(h0=300.0, gimbal_rate_limit=1e12)
    free_act = SgcmgActuator(free_cluster, _steering_laws(free_cluster)[law])
    rng = np.random.default_rng(26)
    for saturate in (True, False):
        U, W, D, F, K = _commands(cluster, free_act, rng, limit, t, saturate)
        peak = np.abs(F).max(axis=1)
        expected = F * np.minimum(1.0, limit / peak)[:, None]
        batched = act.command(U, W, D, t)
        singles = [act.command(U[i : i + 1], W[i : i + 1], D[i : i + 1], t) for i in range(len(U))]
        for dd, sat in (
            (batched.delta_dot, batched.saturated),
            (np.concatenate([s.delta_dot for s in singles]),
             np.concatenate([s.saturated for s in singles])),
        ):  # fmt: skip
            assert np.all(np.abs(dd) <= limit * (1.0 + 4e-16)), (law, np.abs(dd).max(axis=0))
            np.testing.assert_allclose(dd, expected, rtol=1e-12, atol=1e-15 * limit)
            np.testing.assert_array_equal(sat, np.full(len(U), saturate))
            if saturate:  # the fastest gimbal runs exactly at the limit
                np.testing.assert_allclose(np.abs(dd[np.arange(len(U)), K]), limit, rtol=1e-15)


# ============================================================== fused vs Python loop
def _actuators() -> dict[str, object]:
    def cmg(law):
        cl = SgcmgPyramid(h0=300.0, gimbal_rate_limit=0.25)
        law = law(cluster=cl) if law is PseudoInverseNullMotion else law()
        return SgcmgActuator(cl, law, delta0=np.deg2rad([45.0, -45.0, 45.0, -45.0]))

    return {
        "ideal-unlimited": IdealTorqueActuator(),
        "ideal-scalar-limit": IdealTorqueActuator(max_torque=40.0),
        "ideal-axis-limits": IdealTorqueActuator(max_torque=np.array([30.0, 80.0, 50.0])),
        "sgcmg-pinv": cmg(PseudoInverse),
        "sgcmg-pinv-null": cmg(PseudoInverseNullMotion),
        "sgcmg-sr": cmg(SingularityRobust),
        "sgcmg-gsr": cmg(GeneralizedSingularityRobust),
    }


def _controllers() -> dict[str, object]:
    kR, kW = np.diag([300.0, 200.0, 250.0]), 1200.0
    return {
        "geometric-pd-large-angle": GeometricPD(J, kR, kW, error="large_angle"),
        "geometric-pd-log": GeometricPD(J, kR, kW, error="log"),
        "geometric-pd-trace": GeometricPD(J, kR, kW, error="trace", G=np.diag([1.0, 1.1, 1.2])),
        "mrp-pd": MrpPD(J, 300.0, 1200.0),
        "quaternion-pd": QuaternionPD(J, 300.0, 1200.0),
        "finite-time": FiniteTimeSO3(J, 0.02, 0.1, 0.5),
        "fixed-time": FixedTimeSO3(J, 0.02, 0.1, 0.5, 0.01),
        "adaptive-trace": AdaptiveGeometricSO3(
            J, 40.0, 300.0, 0.7, 2e4, 3.0, frequencies=[0.05], disturbance_bound=1e3
        ),
        "adaptive-large-angle": AdaptiveGeometricSO3(
            J, 40.0, 300.0, 0.7, 2e4, 3.0, disturbance_bound=1e3, error="large_angle"
        ),
        "intrinsic-pid": IntrinsicPID(J, kR, kW, 20.0),
        "integral-pd": IntegralPD(J, kR, kW, 20.0),
        "prescribed-performance": PrescribedPerformance(J, 0.1, 0.02),
        "fault-tolerant": AdaptiveFaultTolerantSO3(J, 300.0, 0.5, gamma_k=0.1, gamma_beta=0.1),
    }


def _assert_identical_logs(a, b, what):
    for name in ("t", "R", "omega", "R_d", "omega_d", "u_cmd", "u", "disturbance"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-12, atol=1e-12,
                                   err_msg=f"{what}: {name}")  # fmt: skip
    for group in ("actuator", "controller"):
        da, db = getattr(a, group), getattr(b, group)
        assert sorted(da) == sorted(db), (what, group, sorted(da), sorted(db))
        for k in da:
            x, y = np.asarray(da[k]), np.asarray(db[k])
            assert x.dtype == y.dtype and x.shape == y.shape, (what, group, k)
            if x.dtype == bool:  # flags: every sample, exactly
                np.testing.assert_array_equal(x, y, err_msg=f"{what}: {group}[{k!r}]")
            else:
                np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12,
                                           err_msg=f"{what}: {group}[{k!r}]")  # fmt: skip


@pytest.mark.parametrize("actuator", list(_actuators()))
def test_fused_loop_equals_python_loop_in_every_flag_for_every_actuator_and_controller(
    actuator, monkeypatch
):
    """Three spacecraft: one at the reference (never limited), two far from it (limited at
    first); every controller with a kernel (the geometric PD family, the chart baselines, the
    finite/fixed-time, adaptive, integral, prescribed-performance and fault-tolerant laws);
    the fused run must take the compiled route."""
    rng = np.random.default_rng(11)
    R_d = so3.exp(np.array([0.3, -0.2, 0.1]))
    R0 = np.stack([R_d, R_d @ so3.exp(np.array([0.0, 2.5, 0.4])), so3.random(rng)])
    fused_calls = []
    real_run_fused = simulator_module.run_fused

    def counting(*a, **k):
        out = real_run_fused(*a, **k)
        fused_calls.append(out is not None)
        return out

    for name, ctrl in _controllers().items():
        act = _actuators()[actuator]
        plant = Spacecraft(RigidBody(J), act)
        x0 = plant.initial_state(R0, np.array([[0.0, 0.0, 0.0], [0.01, -0.02, 0.0], [0.0] * 3]))
        args = (plant, ctrl, ConstantAttitude(R_d), x0, 8.0, 0.1)
        kw = {"control_period": 0.2, "log_every": 1}
        with monkeypatch.context() as m:
            m.setattr(simulator_module, "run_fused", counting)
            fused = simulate(*args, **kw)
        assert fused_calls and fused_calls[-1], f"{actuator}/{name} did not run fused"
        with monkeypatch.context() as m:
            m.setattr(simulator_module, "fused_supported", lambda *a, **k: None)
            python = simulate(*args, **kw)
        _assert_identical_logs(fused, python, f"{actuator}/{name}")
        sat = python.actuator.get("saturated")
        if actuator == "ideal-unlimited":
            assert sat is None
        else:  # the property is not vacuous: limited and free samples both occur
            assert sat.any() and not sat.all(), (actuator, name)
            if actuator != "sgcmg-pinv-null":  # (null motion moves the gimbals at rest too)
                assert not sat[:, 0].any()  # the spacecraft at the reference: never limited


# ============================================================== adaptive inertia update
@pytest.mark.parametrize("error", ["trace", "large_angle", "log"])
def test_adaptive_inertia_update_is_minus_gamma_W_transpose_s_term_by_term(error):
    """θ̂(t₁) = θ̂(t₀) − Δt γ Wᵀs and φ̂(t₁) = φ̂(t₀) + Δt γ_φ Φᵀs from the first sample's
    diagnostics, with W = ω^Y(ω) + Y(a_r) formed from the public regressor, and Wᵀs also
    as Y(ω)ᵀ(s × ω) + Y(a_r)ᵀs — all six inertia components, for a batch of distinct states."""
    rng = np.random.default_rng(3)
    B, c, gamma, gphi, nu = 5, 0.7, 2.5e4, 3.0, np.array([0.05, 0.3])
    G = np.diag([1.0, 1.1, 1.2]) if error == "trace" else None
    ctrl = AdaptiveGeometricSO3(
        J, 40.0, np.diag([300.0, 200.0, 250.0]), c, gamma, gphi, frequencies=nu,
        disturbance_bound=1e9, inertia_bound=1e6, error=error, G=G,
    )  # fmt: skip
    ctrl.reset(0.0, B)
    R = so3.exp(rng.uniform(-1.0, 1.0, (B, 3)))
    w = 0.3 * rng.normal(size=(B, 3))
    R_d = so3.exp(rng.uniform(-1.0, 1.0, (B, 3)))
    w_d, dw_d = 0.2 * rng.normal(size=(B, 3)), 0.05 * rng.normal(size=(B, 3))
    t0, dt = 0.4, 0.05
    ref = AttitudeReference(R_d=R_d, omega_d=w_d, omega_dot_d=dw_d)
    ctrl.command(t0, AttitudeState(R=R, omega=w), ref)
    d0 = ctrl.diagnostics()
    theta0, phi0 = d0["theta_hat"].copy(), d0["phi_hat"].copy()
    ctrl.command(t0 + dt, AttitudeState(R=R, omega=w), ref)
    d1 = ctrl.diagnostics()
    assert not d1["theta_projected"].any() and not d1["phi_projected"].any()

    for b in range(B):
        Rt = R_d[b].T @ R[b]
        wb, dwb = Rt.T @ w_d[b], Rt.T @ dw_d[b]
        e_W = w[b] - wb
        np.testing.assert_allclose(d0["e_Omega"][b], e_W, rtol=1e-12, atol=1e-15)
        E = error_rate_matrix(Rt, error, G)[0]  # checked against finite differences elsewhere
        a_r = dwb - np.cross(w[b], wb) - c * E @ e_W
        s = d0["s"][b]
        W = so3.hat(w[b]) @ inertia_regressor(w[b]) + inertia_regressor(a_r)
        Wts = W.T @ s
        np.testing.assert_allclose(
            Wts,
            inertia_regressor(w[b]).T @ np.cross(s, w[b]) + inertia_regressor(a_r).T @ s,
            rtol=1e-12, atol=1e-12 * np.abs(Wts).max(),
        )  # fmt: skip
        step = theta0[b] - dt * gamma * Wts
        for i in range(6):  # term by term: an index slip moves one component
            assert d1["theta_hat"][b, i] == pytest.approx(step[i], rel=1e-12, abs=1e-9), (b, i)
        Phi = harmonic_regressor(t0, nu)
        np.testing.assert_allclose(
            d1["phi_hat"][b], phi0[b] + dt * gphi * Phi.T @ s, rtol=1e-12, atol=1e-12
        )


# ============================================================== leader–follower consensus
def _weighted_graph(rng, n):
    """A directed graph on n members: member 0 leads; every follower receives from 2 or 3
    others (in-degree > 1) with weights in [0.2, 3]."""
    A = np.zeros((n, n))
    for i in range(1, n):
        others = [j for j in range(n) if j != i]
        for j in rng.choice(others, size=min(len(others), rng.integers(2, 4)), replace=False):
            A[i, j] = rng.uniform(0.2, 3.0)
    A[0, 1] = 1.7  # the leader hears a neighbour too (it must ignore it)
    return CommunicationGraph(A, leaders=(0,))


@pytest.mark.parametrize("seed", range(4))
def test_leader_follower_law_on_graphs_with_in_degree_above_one(seed):
    """τ_i from the module docstring written out per member: e_R,i = −(1/d_i) Σ_j a_ij φ_ij,
    ω̄_i = (1/d_i) Σ_j a_ij R_iᵀR_jΩ_j (d_i = Σ_j a_ij), and the leader's tracking law."""
    rng = np.random.default_rng(100 + seed)
    n = 6
    graph = _weighted_graph(rng, n)
    assert (np.count_nonzero(graph.adjacency[1:], axis=1) >= 2).all()
    Jm = np.stack([J * rng.uniform(0.8, 1.2) for _ in range(n)])
    Jm = 0.5 * (Jm + np.swapaxes(Jm, -1, -2))
    kR, kW = 30.0, np.diag([90.0, 70.0, 80.0])
    ctrl = LeaderFollowerConsensus(graph, Jm, kR, kW)
    ctrl.reset(0.0, n)
    R = so3.exp(rng.uniform(-0.8, 0.8, (n, 3)))
    w = 0.05 * rng.normal(size=(n, 3))
    R_d = so3.exp(np.array([0.2, -0.1, 0.3]))
    w_d, dw_d = np.array([0.01, 0.0, -0.02]), np.array([0.001, 0.002, 0.0])
    tau = ctrl.command(0.0, AttitudeState(R=R, omega=w), AttitudeReference(R_d, w_d, dw_d))
    A = graph.adjacency
    for i in range(n):
        if i == 0:
            RtRd = R[i].T @ R_d
            e_R = so3.log(RtRd.T)
            wbar, ff = RtRd @ w_d, RtRd @ dw_d
        else:
            d_i = A[i].sum()
            e_R = -sum(A[i, j] * so3.log(R[i].T @ R[j]) for j in range(n) if A[i, j]) / d_i
            wbar = sum(A[i, j] * (R[i].T @ R[j] @ w[j]) for j in range(n) if A[i, j]) / d_i
            ff = np.zeros(3)
        e_W = w[i] - wbar
        ref = (-kR * e_R - kW @ e_W + np.cross(w[i], Jm[i] @ w[i])
               - Jm[i] @ (np.cross(w[i], wbar) - ff))  # fmt: skip
        np.testing.assert_allclose(tau[i], ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())
        np.testing.assert_allclose(ctrl.diagnostics()["e_R"][i], e_R, rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("seed", range(3))
def test_leaderless_consensus_on_weighted_graphs(seed):
    """τ_i = Ω_i × J_iΩ_i + k_R Σ_j a_ij φ_ij − k_Ω Ω_i with non-unit weights, in-degree > 1."""
    rng = np.random.default_rng(200 + seed)
    n = 5
    graph = _weighted_graph(rng, n)
    ctrl = AttitudeConsensus(graph, J, 25.0, 80.0)
    ctrl.reset(0.0, n)
    R = so3.exp(rng.uniform(-0.8, 0.8, (n, 3)))
    w = 0.05 * rng.normal(size=(n, 3))
    tau = ctrl.command(0.0, AttitudeState(R=R, omega=w), AttitudeReference.regulation(np.eye(3)))
    A = graph.adjacency
    for i in range(n):
        coupling = sum(A[i, j] * so3.log(R[i].T @ R[j]) for j in range(n) if A[i, j])
        ref = np.cross(w[i], J @ w[i]) + 25.0 * coupling - 80.0 * w[i]
        np.testing.assert_allclose(tau[i], ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


# ============================================================== kernels vs numpy, dense angles
#: the switch points of the SO(3) kernels: half_sinc's series (θ = 1e-3), Ψ's sine/cosine form
#: (θ = π/2), log's symmetric-part branch (cos θ = −0.999)
_SWITCHES = (1e-3, 0.5 * math.pi, math.acos(kso3.LOG_SYMMETRIC_COS))


def _dense_angles() -> np.ndarray:
    near0 = np.logspace(-14.0, -0.5, 500)
    near_pi = math.pi - np.logspace(-12.0, -0.5, 500)
    around = [
        x * (1.0 + s * e) for x in _SWITCHES for s in (-1.0, 1.0) for e in (0.0, 1e-15, 1e-12,
                                                                            1e-9, 1e-6, 1e-3)
    ]  # fmt: skip
    ths = np.concatenate([[0.0], near0, near_pi, np.linspace(0.0, math.pi, 101), around])
    return np.unique(np.clip(ths, 0.0, math.pi))


def _axes(n: int) -> np.ndarray:
    v = np.random.default_rng(5).normal(size=(n, 3))
    v[:3] = np.eye(3)  # coordinate axes: the symmetric branch's column choice at its edges
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_log_and_exp_kernels_equal_numpy_over_dense_angles_near_0_and_pi():
    ths = _dense_angles()
    axes = _axes(ths.size)
    for th, n in zip(ths, axes, strict=True):
        w = th * n
        R = so3.exp(w)
        out = np.empty((3, 3))
        kso3.exp_into(*w.tolist(), out)
        np.testing.assert_allclose(out, R, rtol=0, atol=1e-15, err_msg=f"exp, θ = {th!r}")
        np.testing.assert_allclose(
            kso3.log_of(R), so3.log(R), rtol=0, atol=1e-12, err_msg=f"log, θ = {th!r}"
        )
        # the kernel's own branch switch, from the other side's entries: a rotation whose
        # cos θ is exactly the threshold, ± one ulp
    c = kso3.LOG_SYMMETRIC_COS
    for cc in (np.nextafter(c, -1.0), c, np.nextafter(c, 1.0)):
        for n in axes[:20]:
            R = so3.exp(math.acos(cc) * n)
            np.testing.assert_allclose(kso3.log_of(R), so3.log(R), rtol=0, atol=1e-12)


def test_half_sinc_and_large_angle_error_kernels_over_dense_angles():
    """sin(θ/2)/θ needs no series for accuracy at θ > 0 (sin of a small argument and the
    division are each correctly rounded): the kernel matches it to a few ulps on both sides of
    its series switch; Lee's error (Ψ, e_R) matches the numpy route to 1e-12 relative."""
    ths = _dense_angles()
    pos = ths[ths > 0.0]
    got = np.array([katt.half_sinc(t) for t in pos])
    np.testing.assert_allclose(got, np.sin(0.5 * pos) / pos, rtol=8e-16, atol=0)
    assert katt.half_sinc(0.0) == 0.5
    axes = _axes(ths.size)
    for th, n in zip(ths, axes, strict=True):
        R = so3.exp(th * n)
        T = tuple(R.T.ravel().tolist())  # T = R̃ᵀ with R̃ = R (R_d = I)
        psi, theta, *e_R = katt.large_angle_error(T)
        Psi_ref, e_ref = large_angle_error(R, np.eye(3))
        assert psi == pytest.approx(float(Psi_ref), rel=1e-12, abs=1e-300), th
        np.testing.assert_allclose(e_R, e_ref, rtol=1e-12, atol=1e-15 * th, err_msg=f"θ = {th}")


# ============================================================== the routes without numba
@pytest.mark.parametrize(
    "make",
    [
        lambda: GeometricPD(J, np.diag([300.0, 200.0, 250.0]), 1200.0, error="large_angle"),
        lambda: GeometricPD(J, 300.0, np.diag([900.0, 1200.0, 1000.0]), error="log"),
        lambda: GeometricPD(J, 300.0, 1200.0, error="trace", G=np.diag([1.0, 1.1, 1.2])),
        lambda: FiniteTimeSO3(J, 0.02, 0.1, 0.5),
        lambda: FixedTimeSO3(J, 0.02, 0.1, 0.5, 0.01),
    ],
    ids=["gpd-large-angle", "gpd-log", "gpd-trace", "finite-time", "fixed-time"],
)
def test_batched_numpy_route_equals_the_kernel_route(make, monkeypatch):
    """Without numba a batch runs the controller's numpy expressions instead of its kernel:
    the same torque and diagnostics for a tracking reference (ω_d, ω̇_d ≠ 0) and for regulation
    (where the numpy route skips the zero feed-forward terms)."""
    import importlib

    rng = np.random.default_rng(17)
    B = 6
    R = so3.exp(rng.uniform(-2.0, 2.0, (B, 3)))
    w = 0.1 * rng.normal(size=(B, 3))
    R_d = so3.exp(rng.uniform(-2.0, 2.0, (B, 3)))
    refs = [
        AttitudeReference(R_d, 0.05 * rng.normal(size=(B, 3)), 0.01 * rng.normal(size=(B, 3))),
        AttitudeReference(R_d, np.zeros((B, 3)), np.zeros((B, 3))),
    ]
    ctrl = make()
    module = importlib.import_module(type(ctrl).__module__)
    assert hasattr(module, "JIT_ENABLED")
    for ref in refs:
        out = {}
        for jit in (True, False):
            monkeypatch.setattr(module, "JIT_ENABLED", jit)
            c = make()
            c.reset(0.0, B)
            M = c.command(0.0, AttitudeState(R=R, omega=w), ref)
            out[jit] = (M, c.diagnostics())
        np.testing.assert_allclose(out[False][0], out[True][0], rtol=1e-10, atol=1e-9)
        for k, v in out[True][1].items():
            np.testing.assert_allclose(out[False][1][k], v, rtol=1e-10, atol=1e-12, err_msg=k)
