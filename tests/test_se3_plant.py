"""Tests for spacecraft.se3_plant (SPEC §5.6): gravity field, plant integration, chaser/target
reference, actuator limits, simulator plumbing and bad input.

Independent routes: finite differences of the potential (force and torque), orbit.py's inertial
gravity, rotation invariance of the field (x × f + R τ = 0), the two integrators against each
other, finite differences of g_d(t) for the reference twist.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from liecontrol.control.se3_control import PoseController, PoseReference
from liecontrol.lie import se3, so3
from spacecraft.orbit import CircularOrbit, gravity_acceleration
from spacecraft.se3_plant import (
    DockingReference,
    IdealWrenchActuator,
    OrbitingTarget,
    SE3Plant,
    SimulationDiverged,
    full_body_gravity,
    full_body_potential,
    simulate_pose,
)

M = 500.0
J = np.array([[300.0, 5.0, -3.0], [5.0, 400.0, 2.0], [-3.0, 2.0, 350.0]])
ORBIT = CircularOrbit(n=0.0011)


def _random_pose(rng, B=4):
    R = so3.random(rng, (B,))
    p = rng.normal(size=(B, 3))
    p *= (7.0e6 + 1e5 * rng.normal(size=(B, 1))) / np.linalg.norm(p, axis=-1, keepdims=True)
    return R, p


@pytest.mark.parametrize("J2", [0.0, 1.08263e-3])
def test_gravity_in_body_axes_is_Rt_times_inertial(J2):
    rng = np.random.default_rng(0)
    R, p = _random_pose(rng)
    plant = SE3Plant(M, J, J2=J2)
    w = plant.gravity_wrench(se3.from_rt(R, p))
    f, tau = full_body_gravity(R, p, M, J, J2=J2)
    assert np.allclose(w[:, 3:], np.einsum("bji,bj->bi", R, f), rtol=1e-14, atol=0)
    assert np.array_equal(w[:, :3], tau)
    # without the gravity-gradient coupling it is exactly m Rᵀ a(p) of spacecraft.orbit
    plain = SE3Plant(M, J, J2=J2, gravity_gradient=False).gravity_wrench(se3.from_rt(R, p))
    a = gravity_acceleration(p, J2=J2)
    assert np.allclose(plain[:, 3:], M * np.einsum("bji,bj->bi", R, a), rtol=1e-14, atol=0)
    assert np.all(plain[:, :3] == 0)
    # the inertia-dependent force terms are tiny next to the point-mass force
    assert np.abs(w[:, 3:] - plain[:, 3:]).max() < 1e-9 * np.abs(plain[:, 3:]).max()


def test_gravity_gradient_torque_matches_spec_formula():
    """τ = 3n²(ĉ × Jĉ) with n² = μ/r³ and ĉ the nadir in body axes (SPEC §5.3)."""
    R = so3.exp(np.array([0.3, -0.2, 0.5]))
    p = ORBIT.position(100.0)
    _, tau = full_body_gravity(R, p, M, J, mu=ORBIT.mu)
    c = ORBIT.nadir_in_body(R, 100.0)
    assert np.allclose(tau, 3 * ORBIT.n**2 * np.cross(c, J @ c), rtol=1e-12)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 10_000))
def test_force_and_torque_are_minus_gradients_of_the_potential(seed):
    rng = np.random.default_rng(seed)
    R, p = _random_pose(rng, 1)
    R, p = R[0], p[0]
    mu = 3.986004418e14
    f, tau = full_body_gravity(R, p, M, J, mu=mu, J2=1.08e-3)

    def U(RR, pp):
        return float(full_body_potential(RR, pp, M, J, mu=mu, J2=1.08e-3))

    hp = 1.0
    grad = np.array([(U(R, p + hp * e) - U(R, p - hp * e)) / (2 * hp) for e in np.eye(3)])
    assert np.allclose(f, -grad, rtol=1e-6, atol=1e-9 * np.abs(f).max())
    # δU along R exp(ε η^) is −τ·η; near a small body (μ = 1e3, r ≈ 10 m) so that the
    # attitude-dependent part of U is not lost to round-off next to −μm/r
    q = 10.0 * p / np.linalg.norm(p)
    _, tau = full_body_gravity(R, q, M, J, mu=1e3)

    def Us(RR):
        return float(full_body_potential(RR, q, M, J, mu=1e3))

    hr = 1e-5
    dU = np.array(
        [(Us(R @ so3.exp(hr * e)) - Us(R @ so3.exp(-hr * e))) / (2 * hr) for e in np.eye(3)]
    )
    assert np.allclose(tau, -dU, rtol=1e-6, atol=1e-7 * np.abs(tau).max())


def test_field_is_rotation_invariant_total_torque_zero():
    rng = np.random.default_rng(3)
    R, p = _random_pose(rng, 5)
    # near a small body (r ≈ 10 m) the torque is not swamped by round-off in p × f
    p = 10.0 * p / np.linalg.norm(p, axis=-1, keepdims=True)
    f, tau = full_body_gravity(R, p, M, J, mu=1e3)
    total = np.cross(p, f) + np.einsum("bij,bj->bi", R, tau)
    assert np.abs(total).max() < 1e-12 * np.abs(tau).max()


def _free_orbit_state():
    R0 = so3.exp(np.array([[0.1, 0.2, 0.3]]))
    p0 = ORBIT.position(0.0)[None]
    v_in = ORBIT.velocity(0.0)[None] * 1.02
    xi0 = np.concatenate(([[0.01, -0.004, 0.006]], np.einsum("bji,bj->bi", R0, v_in)), axis=-1)
    return se3.from_rt(R0, p0), xi0


def test_lgvi_and_rkmk4_plants_agree_and_conserve():
    """Free tumbling body on an orbit, 300 s: both integrators keep energy and total angular
    momentum (the LGVI to round-off) and agree with each other."""
    g0, xi0 = _free_orbit_state()
    zero = np.zeros((1, 6))
    out = {}
    tol_H = {"lgvi": 1e-12, "rkmk4": 1e-9}
    for method in ("lgvi", "rkmk4"):
        plant = SE3Plant(M, J, method=method)
        g, xi = g0, xi0
        for k in range(300):
            g, xi = plant.step(k * 1.0, g, xi, zero, 1.0)
        out[method] = (g, xi)
        E0, E1 = plant.energy(g0, xi0), plant.energy(g, xi)
        H0, H1 = plant.angular_momentum(g0, xi0), plant.angular_momentum(g, xi)
        assert abs(E1 - E0) < 1e-8 * abs(E0)
        assert np.abs(H1 - H0).max() < tol_H[method] * np.linalg.norm(H0)
    (ga, xa), (gb, xb) = out["lgvi"], out["rkmk4"]
    # the 2nd-order LGVI's along-track phase error ~ (nh)² n t r / 24 ≈ 0.1–0.5 m here (7e6 m
    # orbit): the two agree to ~1e-7 of the radius
    assert np.abs(ga[0, :3, 3] - gb[0, :3, 3]).max() < 1.0
    assert so3.distance(ga[0, :3, :3], gb[0, :3, :3]) < 3e-4  # (hω)² ω t / 12
    assert np.abs(xa[0, :3] - xb[0, :3]).max() < 1e-6
    va, vb = ga[0, :3, :3] @ xa[0, 3:], gb[0, :3, :3] @ xb[0, 3:]  # inertial velocities
    assert np.abs(va - vb).max() < 2e-3


def test_plant_thrust_matches_newton_in_free_space():
    """Constant body force on a non-rotating body, negligible gravity: p(t) = p₀ + ½ (R F/m) t²
    (both integrators are exact on this quadratic)."""
    g0 = se3.from_rt(so3.exp(np.array([[0.4, 0.0, 0.2]])), np.array([[1e3, 0.0, 0.0]]))
    xi0 = np.zeros((1, 6))
    u = np.array([[0.0, 0.0, 0.0, 10.0, -5.0, 2.0]])
    a = g0[0, :3, :3] @ u[0, 3:] / M
    for method in ("lgvi", "rkmk4"):
        plant = SE3Plant(M, J, mu=1e-20, method=method)
        g, xi = g0, xi0
        for k in range(20):
            g, xi = plant.step(0.1 * k, g, xi, u, 0.1)
        assert np.allclose(g[0, :3, 3], g0[0, :3, 3] + 0.5 * a * 2.0**2, rtol=0, atol=1e-11)
        assert np.allclose(g[0, :3, :3] @ xi[0, 3:], a * 2.0, rtol=0, atol=1e-12)
        assert np.allclose(g[0, :3, :3], g0[0, :3, :3], atol=1e-15)
        # the same wrench as a body disturbance d(t, g, ξ) gives the same motion
        dist = SE3Plant(M, J, mu=1e-20, method=method, disturbance=lambda t, gg, x: u + 0 * x)
        gd, xd = g0, xi0
        for k in range(20):
            gd, xd = dist.step(0.1 * k, gd, xd, np.zeros((1, 6)), 0.1)
        assert np.allclose(gd, g, atol=1e-11) and np.allclose(xd, xi, atol=1e-12)


def test_actuator_limits_clip_per_axis():
    act = IdealWrenchActuator(max_torque=1.0, max_force=[10.0, 20.0, 30.0])
    u = np.array([[2.0, -0.5, -3.0, 15.0, -25.0, 5.0]])
    applied, sat = act.apply(u)
    assert np.array_equal(applied, [[1.0, -0.5, -1.0, 10.0, -20.0, 5.0]])
    assert np.array_equal(sat, [[True, False, True, True, True, False]])
    with pytest.raises(ValueError, match="^max_force:"):
        IdealWrenchActuator(max_force=-1.0)
    with pytest.raises(ValueError, match="^max_torque:"):
        IdealWrenchActuator(max_torque=[1.0, 2.0])


def test_target_and_docking_reference_kinematics():
    target = OrbitingTarget(ORBIT)
    g_rel = se3.from_rt(so3.exp(np.array([0.0, 0.0, np.pi])), np.array([-5.0, 0.3, 0.1]))
    ref = DockingReference(target, g_rel)
    t, h = 1234.0, 1e-2
    gT = target.pose(t)
    assert np.allclose(gT[:3, 3], ORBIT.position(t))
    # target body velocity rotated to inertial is the orbit velocity
    assert np.allclose(gT[:3, :3] @ target.twist[3:], ORBIT.velocity(t), rtol=1e-12)
    # ξ_d = (g_d⁻¹ ġ_d)^∨ by central differences
    gd_dot = (ref(t + h).g_d - ref(t - h).g_d) / (2 * h)
    xi_fd = se3.vee(se3.inverse(ref(t).g_d) @ gd_dot)
    assert np.allclose(xi_fd, ref(t).xi_d, rtol=1e-6, atol=1e-7)
    assert np.allclose(ref(t).g_d, gT @ g_rel)
    # offset states move rigidly with the desired frame
    g, xi = ref.offset_state(t, np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 0.0]]))
    assert np.allclose(g[0], ref(t).g_d) and np.allclose(xi[0], ref.xi_d)


class _Recorder(PoseController):
    def __init__(self, bad_at: float | None = None):
        self.calls: list[float] = []
        self.bad_at = bad_at

    def reset(self, t0, batch_size):
        self.calls = []

    def command(self, t, state, reference):
        self.calls.append(t)
        u = np.zeros((state.batch_size, 6))
        if self.bad_at is not None and t >= self.bad_at:
            u[:] = np.nan
        return u


def test_simulate_pose_zero_order_hold_and_logging():
    ref = DockingReference(OrbitingTarget(ORBIT), np.eye(4))
    g0, xi0 = ref.offset_state(0.0, np.zeros((2, 3)), np.zeros((2, 3)))
    ctrl = _Recorder()
    res = simulate_pose(
        SE3Plant(M, J, method="rkmk4"),
        ctrl,
        ref,
        g0,
        xi0,
        t_final=10.0,
        dt=0.5,
        control_period=2.0,
        log_every=4,
    )
    assert np.allclose(ctrl.calls, np.arange(0.0, 10.0, 2.0))
    assert np.allclose(res.t, np.arange(0.0, 10.5, 2.0))
    assert res.g.shape == (6, 2, 4, 4) and res.log_error.shape == (6, 2, 6)
    # the target's own orbit: the free chaser at the target pose stays with it
    assert res.position_error.max() < 1e-6


def test_simulate_pose_diverged_keeps_partial_log():
    ref = DockingReference(OrbitingTarget(ORBIT), np.eye(4))
    g0, xi0 = ref.offset_state(0.0, np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(SimulationDiverged) as exc:
        simulate_pose(SE3Plant(M, J), _Recorder(bad_at=3.0), ref, g0, xi0, 10.0, 1.0)
    assert exc.value.time == pytest.approx(3.0)
    assert exc.value.result.t[-1] == pytest.approx(3.0)


def test_bad_input_names_the_argument():
    with pytest.raises(ValueError, match="^n:"):
        OrbitingTarget(CircularOrbit(n=0.0))
    with pytest.raises(ValueError, match="^n:"):
        CircularOrbit(n=-1e-3)
    with pytest.raises(ValueError, match="^m:"):
        SE3Plant(0.0, J)
    with pytest.raises(ValueError, match="^J:"):
        SE3Plant(M, -J)
    with pytest.raises(ValueError, match="^mu:"):
        SE3Plant(M, J, mu=0.0)
    with pytest.raises(ValueError, match="^method:"):
        SE3Plant(M, J, method="euler")
    with pytest.raises(ValueError, match="^g_rel:"):
        DockingReference(OrbitingTarget(ORBIT), 2 * np.eye(4))
    with pytest.raises(ValueError, match="^orbit:"):
        OrbitingTarget("leo")
    plant = SE3Plant(M, J)
    g0, xi0 = np.eye(4)[None] + 0, np.zeros((1, 6))
    g0[0, 0, 3] = 7e6
    ref = PoseReference.regulation(np.eye(4))

    def r(t):
        return ref

    with pytest.raises(ValueError, match="^dt:"):
        simulate_pose(plant, _Recorder(), r, g0, xi0, 1.0, 0.0)
    with pytest.raises(ValueError, match="^control_period:"):
        simulate_pose(plant, _Recorder(), r, g0, xi0, 1.0, 0.1, control_period=0.25)
    with pytest.raises(ValueError, match="^t_final:"):
        simulate_pose(plant, _Recorder(), r, g0, xi0, -1.0, 0.1)
    with pytest.raises(ValueError, match="^controller:"):
        simulate_pose(plant, object(), r, g0, xi0, 1.0, 0.1)
    with pytest.raises(ValueError, match="^xi0:"):
        simulate_pose(plant, _Recorder(), r, g0, xi0[0], 1.0, 0.1)
    with pytest.raises(ValueError, match="^wrench:"):
        plant.step(0.0, g0, xi0, np.zeros((1, 3)), 0.1)
