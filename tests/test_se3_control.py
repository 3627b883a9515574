"""Tests for liecontrol.control.se3_control (SPEC §6 item 5; seed 002 Lemma 3, eqs. 15–16) and
the proximity-approach scenario of spacecraft.se3_plant.

Independent routes: finite differences of g̃(t) and ξ̃(t) along smooth trajectories (error
kinematics and dynamics), finite differences of the split potential (gradient), the survey's
literal Lemma 3 term at g_d = I, the closed-loop identity I ξ̃̇ = −P − K_d ξ̃ along the plant's
own flow, and closed-loop runs with documented tolerances.

Documented tolerances (docking, m = 500 kg, J ≈ diag(300, 400, 350) kg·m², n = 0.0011 rad/s,
ω_att = 0.1 rad/s, ω_pos = 0.05 rad/s, ζ = 1, control period 1 s, from 150° / ~100 m):
after 400 s, RKMK4 (dt = 1 s): |Δp| < 1 mm, angle < 1e-6 rad; LGVI (dt = 0.5 s): |Δp| < 3 cm
(the 2nd-order integrator's O(h²) orbital velocity bias seen by the damping term),
angle < 1e-6 rad. Hold over a quarter orbit: |Δp| < 1 mm, angle < 1e-6 rad (RKMK4 dt = 2 s).
Bullo–Murray hover (ω_att = 0.2, ω_pos = 0.1 rad/s, 200 s): |Δp| < 1 mm, angle < 1e-6 rad.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from liecontrol.control.se3_control import (
    BulloMurrayPD,
    ConstantPose,
    PoseReference,
    PoseState,
    SE3TrackingController,
    coriolis_wrench,
    pose_errors,
    pose_gains_from_bandwidth,
)
from liecontrol.integrators.rkmk_se3 import rkmk4_se3_step_unchecked
from liecontrol.lie import se3, so3
from spacecraft.orbit import CircularOrbit
from spacecraft.se3_plant import DockingReference, OrbitingTarget, SE3Plant, simulate_pose

M = 500.0
J = np.array([[300.0, 4.0, -2.0], [4.0, 400.0, 3.0], [-2.0, 3.0, 350.0]])
GAINS = pose_gains_from_bandwidth(M, J, omega_att=0.1, omega_pos=0.05)
ORBIT = CircularOrbit(n=0.0011)
TARGET = OrbitingTarget(ORBIT)
# chaser 5 m behind the target (along −x_LVLH), turned 180° about z: docking ports face each other
G_REL = se3.from_rt(so3.exp(np.array([0.0, 0.0, np.pi])), np.array([-5.0, 0.0, 0.0]))
DOCK = DockingReference(TARGET, G_REL)
AXIS = np.array([1.0, 2.0, -1.0]) / np.sqrt(6.0)
ROT0 = (np.deg2rad(150.0) * AXIS)[None]
POS0 = (100.0 * np.array([0.6, -0.5, 0.62]) / np.linalg.norm([0.6, -0.5, 0.62]))[None]


def _traj(c0, c1, c2):
    """Smooth pose trajectory g(t) = exp(c0 + t c1 + t² c2) and its body twist by differences."""

    def g(t):
        return se3.exp(c0 + t * c1 + t * t * c2)

    def xi(t, h=1e-5):
        return se3.vee(se3.inverse(g(t)) @ (g(t + h) - g(t - h)) / (2 * h))

    return g, xi


def _coeffs(rng):
    return rng.normal(size=6), 0.5 * rng.normal(size=6), 0.2 * rng.normal(size=6)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000))
def test_error_kinematics_and_dynamics_eqs_15_16(seed):
    """d/dt g̃ = g̃ ξ̃^ and ξ̃̇ = ξ̇ + ad_ξ̃ η − Ad_{g̃⁻¹} ξ̇_d (seed 002 eqs. 15–16, corrected)."""
    rng = np.random.default_rng(seed)
    g, xi = _traj(*_coeffs(rng))
    gd, xid = _traj(*_coeffs(rng))
    t, h = 0.3, 1e-4

    def errs(s):
        return pose_errors(g(s), xi(s), gd(s), xid(s))

    gt, xt, eta = errs(t)
    gt_dot = (errs(t + h)[0] - errs(t - h)[0]) / (2 * h)
    assert np.allclose(gt_dot, gt @ se3.hat(xt), atol=1e-6)
    xt_dot = (errs(t + h)[1] - errs(t - h)[1]) / (2 * h)
    xi_dot = (xi(t + h) - xi(t - h)) / (2 * h)
    xid_dot = (xid(t + h) - xid(t - h)) / (2 * h)
    predicted = xi_dot + se3.ad(xt) @ eta - se3.adjoint(se3.inverse(gt)) @ xid_dot
    assert np.allclose(xt_dot, predicted, atol=1e-5)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000))
def test_split_proportional_term_is_the_potential_gradient(seed):
    """P·δ = d/dε V_p(g̃ exp(εδ)) with V_p = ½ φᵀK_Rφ + ½ tᵀK_p t (matrix gains)."""
    rng = np.random.default_rng(seed)
    K_R = np.diag([2.0, 3.0, 5.0]) + 0.5
    K_p = np.diag([1.0, 0.5, 2.0])
    ctrl = SE3TrackingController(M, J, K_R, K_p, 1.0, 1.0)
    g = se3.random(rng, (1,), 10.0)
    g_d = se3.random(rng, (1,), 10.0)
    ref = PoseReference.regulation(g_d)
    ctrl.command(0.0, PoseState(g, np.zeros((1, 6))), ref)
    P = ctrl.diagnostics()["proportional"][0]

    def V(gg):
        gt = se3.inverse(g_d) @ gg
        phi = so3.log(gt[..., :3, :3])[0]
        t = gt[0, :3, 3]
        return 0.5 * phi @ K_R @ phi + 0.5 * t @ K_p @ t

    h = 1e-6
    grad = [(V(g @ se3.exp(h * e)) - V(g @ se3.exp(-h * e))) / (2 * h) for e in np.eye(6)]
    assert np.allclose(P, grad, rtol=1e-6, atol=1e-6)


def test_bullo_murray_split_is_survey_lemma3_at_identity():
    """g_d = I, ξ_d = 0: u = −ad_ξᵀIξ − (K_ω log R, Rᵀ K_v p) − K_d ξ − w_g (seed 002 Lemma 3)."""
    rng = np.random.default_rng(5)
    g = se3.random(rng, (3,), 5.0)
    xi = rng.normal(size=(3, 6))
    grav = rng.normal(size=(3, 6))
    c = BulloMurrayPD(M, J, 2.0, 0.7, 30.0, 9.0, gravity=lambda gg: grav, error="split")
    u = c.command(0.0, PoseState(g, xi), PoseReference.regulation(np.eye(4)))
    R, p = g[:, :3, :3], g[:, :3, 3]
    lemma3 = np.concatenate((2.0 * so3.log(R), 0.7 * np.einsum("bji,bj->bi", R, p)), axis=-1)
    Kd = np.diag([30.0] * 3 + [9.0] * 3)
    expected = -coriolis_wrench(xi, M, J) - lemma3 - xi @ Kd - grav
    assert np.allclose(u, expected, atol=1e-12)
    # the "log" variant uses the exponential coordinates log(g_d⁻¹ g) = log(g)
    c2 = BulloMurrayPD(M, J, 2.0, 0.7, 30.0, 9.0, cancel_coriolis=False)
    u2 = c2.command(0.0, PoseState(g, xi), PoseReference.regulation(np.eye(4)))
    assert np.allclose(u2, -se3.log(g) * np.array([2.0] * 3 + [0.7] * 3) - xi @ Kd, atol=1e-12)


def test_tracking_closed_loop_error_dynamics_along_plant_flow():
    """With the controller's wrench held, the plant's ξ̃ obeys I ξ̃̇ = −P − K_d ξ̃ (exact model)."""
    plant = SE3Plant(M, J, method="rkmk4")
    ctrl = SE3TrackingController(M, J, gravity=plant.gravity_wrench, **GAINS)
    t = 50.0
    g, xi = DOCK.offset_state(t, ROT0, POS0)
    xi = xi + np.array([[0.01, -0.02, 0.005, 0.3, -0.1, 0.2]])
    ref = DOCK(t)
    u = ctrl.command(t, PoseState(g, xi), ref)
    P = ctrl.diagnostics()["proportional"]
    xt0 = ctrl.diagnostics()["xi_tilde"]

    def f(tt, gg, x):
        return x, plant.xi_dot(tt, gg, x, u)

    h = 1e-3
    sp = rkmk4_se3_step_unchecked(f, t, g, xi, h)
    sm = rkmk4_se3_step_unchecked(f, t, g, xi, -h)
    xtp = pose_errors(sp[0], sp[1], DOCK(t + h).g_d, DOCK.xi_d)[1]
    xtm = pose_errors(sm[0], sm[1], DOCK(t - h).g_d, DOCK.xi_d)[1]
    xt_dot = (xtp - xtm) / (2 * h)
    Kd = np.zeros((6, 6))
    Kd[:3, :3], Kd[3:, 3:] = GAINS["k_omega"], GAINS["k_v"] * np.eye(3)
    I6 = np.zeros((6, 6))
    I6[:3, :3], I6[3:, 3:] = J, M * np.eye(3)
    lhs = xt_dot @ I6.T
    rhs = -P - xt0 @ Kd.T
    assert np.allclose(lhs, rhs, rtol=1e-5, atol=1e-5 * np.abs(rhs).max())


@pytest.mark.parametrize(
    ("method", "dt", "pos_tol", "ang_tol"), [("rkmk4", 1.0, 1e-3, 1e-6), ("lgvi", 0.5, 3e-2, 1e-6)]
)
def test_proximity_approach_converges_from_150_deg_and_100_m(method, dt, pos_tol, ang_tol):
    plant = SE3Plant(M, J, method=method)
    ctrl = SE3TrackingController(M, J, gravity=plant.gravity_wrench, **GAINS)
    g0, xi0 = DOCK.offset_state(0.0, ROT0, POS0)
    res = simulate_pose(plant, ctrl, DOCK, g0, xi0, 400.0, dt=dt, control_period=1.0,
                        log_every=int(10 / dt))  # fmt: skip
    assert res.attitude_error[0, 0] == pytest.approx(np.deg2rad(150.0))
    assert res.position_error[0, 0] == pytest.approx(100.0)
    assert res.attitude_error[-1, 0] < ang_tol
    assert res.position_error[-1, 0] < pos_tol
    # attitude: monotone approach in the Lyapunov sense (angle never grows by more than ZOH noise)
    ang = res.attitude_error[:, 0]
    assert np.all(np.diff(ang) < 1e-3)
    # the docking pose relative to the target's LVLH frame, read back from the chaser's state
    g_rel = se3.inverse(TARGET.pose(res.t[-1])) @ res.g[-1, 0]
    assert np.allclose(g_rel[:3, 3], [-5.0, 0.0, 0.0], atol=pos_tol)


def test_hold_against_gravity_in_target_orbit_frame():
    """Start at the docking pose: a quarter orbit later it is still held; without the gravity
    feed-forward the same controller loses the pose by kilometres."""
    plant = SE3Plant(M, J, method="rkmk4")
    g0, xi0 = DOCK.offset_state(0.0, np.zeros((1, 3)), np.zeros((1, 3)))
    T4 = 2.0 * round(ORBIT.period / 4 / 2.0)  # a quarter orbit, a whole number of 2 s steps
    ctrl = SE3TrackingController(M, J, gravity=plant.gravity_wrench, **GAINS)
    res = simulate_pose(plant, ctrl, DOCK, g0, xi0, T4, dt=2.0, control_period=2.0, log_every=25)
    assert res.position_error.max() < 1e-3
    assert res.attitude_error.max() < 1e-6
    # the force it holds is the small differential one (5 m from the target), not m·g ≈ 4 kN
    assert np.abs(res.wrench[1:, 0, 3:]).max() < 0.1
    no_ff = SE3TrackingController(M, J, gravity=None, **GAINS)
    bad = simulate_pose(plant, no_ff, DOCK, g0, xi0, 100.0, dt=2.0, control_period=2.0,
                        log_every=25)  # fmt: skip
    assert bad.position_error[-1, 0] > 1000.0


def test_bullo_murray_pd_hover_near_small_body():
    """Lemma 3 regulation (inertially fixed pose near an asteroid, μ = 4.46e5 m³/s², r = 20 km),
    from 150° / 100 m, both error forms; gravity compensation removes the static offset."""
    plant = SE3Plant(M, J, mu=4.46e5, method="rkmk4")
    gains = pose_gains_from_bandwidth(M, J, omega_att=0.2, omega_pos=0.1)
    g_d = se3.from_rt(so3.exp(np.array([0.2, 0.1, -0.3])), np.array([2.0e4, 0.0, 0.0]))
    ref = ConstantPose(g_d)
    g0 = g_d @ se3.from_rt(so3.exp(ROT0), POS0)
    xi0 = np.zeros((1, 6))
    for error in ("log", "split"):
        ctrl = BulloMurrayPD(M, J, gravity=plant.gravity_wrench, error=error, **gains)
        res = simulate_pose(plant, ctrl, ref, g0, xi0, 200.0, dt=0.5, control_period=0.5,
                            log_every=40)  # fmt: skip
        assert res.attitude_error[-1, 0] < 1e-6
        assert res.position_error[-1, 0] < 1e-3
    no_g = BulloMurrayPD(M, J, gravity=None, **gains)
    res = simulate_pose(plant, no_g, ref, g0, xi0, 200.0, dt=0.5, control_period=0.5,
                        log_every=40)  # fmt: skip
    offset = M * 4.46e5 / 2.0e4**2 / gains["k_p"]  # m a_g / k_p
    assert res.position_error[-1, 0] == pytest.approx(offset, rel=0.05)


def test_batched_command_equals_per_element():
    rng = np.random.default_rng(11)
    plant = SE3Plant(M, J)
    g, xi = DOCK.offset_state(10.0, 0.5 * rng.normal(size=(4, 3)), 50 * rng.normal(size=(4, 3)))
    xi = xi + 0.01 * rng.normal(size=(4, 6))
    for cls in (SE3TrackingController, BulloMurrayPD):
        c = cls(M, J, gravity=plant.gravity_wrench, **GAINS)
        u = c.command(10.0, PoseState(g, xi), DOCK(10.0))
        for b in range(4):
            ub = c.command(10.0, PoseState(g[b : b + 1], xi[b : b + 1]), DOCK(10.0))
            assert np.allclose(u[b], ub[0], rtol=1e-12, atol=1e-9)


def test_bad_input_names_the_argument():
    with pytest.raises(ValueError, match="^k_R:"):
        SE3TrackingController(M, J, -1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="^k_v:"):
        BulloMurrayPD(M, J, 1.0, 1.0, 1.0, np.array([[1.0, 2.0], [2.0, 1.0]]))
    with pytest.raises(ValueError, match="^k_p:"):
        BulloMurrayPD(M, J, 1.0, np.diag([1.0, -1.0, 1.0]), 1.0, 1.0)
    with pytest.raises(ValueError, match="^m:"):
        SE3TrackingController(0.0, J, 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="^J:"):
        SE3TrackingController(M, np.eye(2), 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="^error:"):
        BulloMurrayPD(M, J, 1.0, 1.0, 1.0, 1.0, error="quat")
    with pytest.raises(ValueError, match="^gravity:"):
        BulloMurrayPD(M, J, 1.0, 1.0, 1.0, 1.0, gravity=3.0)
    with pytest.raises(ValueError, match="^omega_pos:"):
        pose_gains_from_bandwidth(M, J, 0.1, 0.0)
    with pytest.raises(ValueError, match="^g_d:"):
        ConstantPose(np.zeros((4, 4)))
    c = SE3TrackingController(M, J, **GAINS)
    ok = PoseReference.regulation(np.eye(4))
    # the container validates on construction; an unchecked one reaches the controller's checks
    with pytest.raises(ValueError, match="^g:"):
        PoseState(2 * np.eye(4)[None], np.zeros((1, 6)))
    with pytest.raises(ValueError, match="^state.g:"):
        c.command(0.0, PoseState.unchecked(2 * np.eye(4)[None], np.zeros((1, 6))), ok)
    with pytest.raises(ValueError, match="^xi:"):
        PoseState(np.eye(4)[None], np.zeros((2, 6)))
    with pytest.raises(ValueError, match="^state.xi:"):
        c.command(0.0, PoseState.unchecked(np.eye(4)[None], np.zeros((2, 6))), ok)
    with pytest.raises(ValueError, match="^reference.g_d:"):
        c.command(0.0, PoseState(np.eye(4)[None], np.zeros((1, 6))),
                  PoseReference(np.ones((4, 4)), np.zeros(6), np.zeros(6)))  # fmt: skip
