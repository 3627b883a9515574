"""Full (VS)CMG model: conservation, energy balance with motor work, the momentum-model limit,
the gimbal servo against its closed-form response, gimbal stops, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from liecontrol._jit import JIT_ENABLED
from liecontrol.integrators.rk import rkmk4_step_unchecked
from liecontrol.lie import so3
from spacecraft.actuators import FirstOrderServo, SgcmgActuator
from spacecraft.cmg_dynamics import (
    MINI_CMG,
    CmgInertias,
    GimbalServo,
    GimbalStops,
    VscmgActuator,
    VscmgCommand,
)
from spacecraft.disturbances import ConstantHarmonicTorque, ConstantTorque
from spacecraft.environment import GravityGradientTorque
from spacecraft.orbit import CircularOrbit
from spacecraft.plant import PlantState, Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.sgcmg import SgcmgPyramid
from spacecraft.steering import SingularityRobust

J_BUS = np.array([[1500.0, 12.0, -6.0], [12.0, 1200.0, 9.0], [-6.0, 9.0, 900.0]])
INERTIAS = CmgInertias(wheel_spin=0.2, wheel_transverse=0.5, gimbal=(1.0, 1.0, 1.5))


def _plant(act: VscmgActuator, **kw) -> Spacecraft:
    return Spacecraft(RigidBody(act.bus_inertia), act, **kw)


def _inertial_momentum(act: VscmgActuator, R: np.ndarray, x: np.ndarray) -> np.ndarray:
    # the one implementation of the total momentum (Spacecraft.inertial_momentum)
    return _plant(act).inertial_momentum(PlantState(R=R, omega=x[:, :3], x_act=x[:, 3:]))


def _run(plant, R, x, t_end, dt, u_of):
    act = plant.actuator
    t = 0.0
    for _ in range(round(t_end / dt)):
        held = act.command_unchecked(u_of(t, x), x[:, :3], x[:, 3:], t)
        R, x = plant.step_packed(t, R, x, held, dt)
        t += dt
    return R, x


@pytest.mark.slow
def test_momentum_and_energy_conserved_600s():
    """No external torque: R H (bus + gimbals + rotors) constant to 1e-9 relative over 600 s,
    and the kinetic energy changes by exactly the work of the gimbal and spin motors (T − W
    constant), under a changing closed-loop command through SR steering and the torque-limited PI
    servo. RKMK4 conserves R H only to its truncation error, 4th order in h λ_max with λ_max ≈
    0.84 rad/s the fastest servo/nutation mode here (2.7e-9 at h = 0.05 s, 1.7e-10 at 0.025 s)."""
    act = VscmgActuator(
        J_BUS, INERTIAS, SgcmgPyramid(h0=20.0), servo=GimbalServo(bandwidth=0.5, max_torque=5.0)
    )
    plant = _plant(act)
    rng = np.random.default_rng(3)
    st = plant.initial_state(so3.random(rng, 1), omega0=0.01 * rng.normal(size=(1, 3)))
    R, x = st.R, st.packed()
    H0 = _inertial_momentum(act, R, x)
    E0 = act.kinetic_energy(x[:, :3], x[:, 3:])
    phase = np.arange(3)

    def u_of(t, x):
        return -30.0 * x[:, :3] + 0.3 * np.sin(0.05 * t + phase)

    R, x = _run(plant, R, x, 600.0, 0.025, u_of)
    H = _inertial_momentum(act, R, x)
    rel = np.linalg.norm(H - H0, axis=-1) / np.linalg.norm(H0, axis=-1)
    assert rel.max() < 1e-9
    W = x[:, 3 + 16]
    E = act.kinetic_energy(x[:, :3], x[:, 3:])
    assert np.abs(W).max() > 1e-4  # the motors did work
    np.testing.assert_allclose(E - W, E0, rtol=1e-9)
    # momentum really moved between bus and cluster
    assert np.abs(act.momentum(x[:, 3:])).max() > 5.0


@pytest.mark.parametrize("kinematic", [False, True])
@pytest.mark.parametrize("variable_speed", [False, True])
def test_vector_field_conserves_momentum_and_balances_energy(kinematic, variable_speed):
    """Exact (step-free) check of the equations: along the vector field,
    d/dt H_B + ω × H_B = τ_ext and dT/dt = ωᵀτ_ext + Σ(u_g δ̇ + u_s Ω) (= the work-state rate),
    with d/dt by central differences of H_B and T along (ω̇, ẋ_act), at random states."""
    servo = FirstOrderServo(0.2) if kinematic else GimbalServo(3.0, 0.8)
    act = VscmgActuator(
        J_BUS, INERTIAS, SgcmgPyramid(h0=20.0), servo=servo, variable_speed=variable_speed
    )
    rng = np.random.default_rng(11)
    B = 5
    x = act.initial_state(B)
    x[:, 0:4] += rng.normal(size=(B, 4))
    x[:, 4:8] = 0.3 * rng.normal(size=(B, 4))
    x[:, 8:12] *= 1.0 + 0.1 * rng.normal(size=(B, 4))
    x[:, 12:16] = 0.1 * rng.normal(size=(B, 4))
    w = 0.05 * rng.normal(size=(B, 3))
    held = act.command(rng.normal(size=(B, 3)), w, x, 0.0)
    if not kinematic:
        held = act.open_loop(rng.normal(size=(B, 4)), rng.normal(size=(B, 4)), w)
    tau = rng.normal(size=(B, 3))
    d = act.coupled_derivatives(w, x, held, tau, act.bus_inertia)
    w_dot, x_dot = d[:, :3], d[:, 3:]

    def rate_of(f, eps=1e-3):
        # Richardson-extrapolated central differences along the flow: O(eps⁴) truncation, so a
        # large eps keeps the round-off of the large rotor energy small
        def c(e):
            return (f(w + e * w_dot, x + e * x_dot) - f(w - e * w_dot, x - e * x_dot)) / (2 * e)

        return (4.0 * c(eps / 2) - c(eps)) / 3.0

    H = act.total_momentum(w, x)
    lhs = rate_of(act.total_momentum) + np.cross(w, H)
    np.testing.assert_allclose(lhs, tau, atol=1e-8 * np.abs(H).max())
    power = x_dot[:, 16] + np.einsum("bi,bi->b", w, tau)
    np.testing.assert_allclose(rate_of(act.kinetic_energy), power, rtol=1e-8, atol=1e-9)


def test_external_torque_changes_momentum_by_its_integral():
    """d/dt (R H) = R T_d through the plant's coupled-actuator hook (trapezoid of R T_d)."""
    T = ConstantTorque([0.05, -0.02, 0.01])
    act = VscmgActuator(J_BUS, INERTIAS, SgcmgPyramid(h0=20.0), servo=GimbalServo(2.0, 5.0))
    plant = _plant(act, disturbance=T)
    st = plant.initial_state(np.eye(3), omega0=[0.01, -0.005, 0.002])
    R, x = st.R, st.packed()
    H0 = _inertial_momentum(act, R, x)
    dt, n = 0.02, 500
    held = act.open_loop(np.array([[0.02, -0.01, 0.015, 0.0]]))
    acc = np.zeros(3)
    prev = R[0] @ T.torque
    for k in range(n):
        R, x = plant.step_packed(k * dt, R, x, held, dt)
        cur = R[0] @ T.torque
        acc += 0.5 * dt * (prev + cur)
        prev = cur
    H = _inertial_momentum(act, R, x)
    np.testing.assert_allclose(H[0] - H0[0], acc, atol=1e-8)


def test_momentum_is_the_energy_gradient():
    """H = ∂T/∂ω (the mass matrix's first block row), by central differences of T."""
    act = VscmgActuator(J_BUS, INERTIAS, servo=GimbalServo(2.0, 5.0))
    rng = np.random.default_rng(0)
    x = act.initial_state(1)
    x[:, 0:4] += rng.normal(size=4)
    x[:, 4:8] = 0.3 * rng.normal(size=4)
    x[:, 8:12] *= 1.0 + 0.1 * rng.normal(size=4)
    w = 0.05 * rng.normal(size=(1, 3))
    H = act.total_momentum(w, x)
    eps = 1e-3  # T is quadratic in ω: central differences are exact up to round-off
    fd = np.zeros(3)
    for i in range(3):
        e = np.zeros((1, 3))
        e[0, i] = eps
        fd[i] = (act.kinetic_energy(w + e, x) - act.kinetic_energy(w - e, x))[0] / (2 * eps)
    np.testing.assert_allclose(H[0], fd, rtol=1e-8)


def _limit_run(eps: float | None) -> np.ndarray:
    """Body rates over 20 s under the same command: full model with inertias × eps (rotor
    momentum I_Ws Ω = h₀ kept), or the momentum model (eps None); both with a kinematic
    first-order gimbal servo τ = 0.1 s."""
    cluster = SgcmgPyramid(h0=50.0)
    servo = FirstOrderServo(0.1)
    if eps is None:
        act = SgcmgActuator(cluster, SingularityRobust(), servo=servo)
    else:
        act = VscmgActuator(J_BUS, INERTIAS.scaled(eps), cluster, SingularityRobust(), servo=servo)
    plant = Spacecraft(RigidBody(J_BUS), act)
    st = plant.initial_state(np.eye(3), omega0=[0.01, -0.01, 0.005])
    R, x = st.R, st.packed()
    out = []
    for k in range(400):
        t = 0.05 * k
        u = np.array([[0.4 * np.sin(0.3 * t), -0.3, 0.2 * np.cos(0.2 * t)]])
        held = act.command_unchecked(u, x[:, :3], x[:, 3:], t)
        R, x = plant.step_packed(t, R, x, held, 0.05)
        out.append(x[0, :3].copy())
    return np.array(out)


def test_full_model_tends_to_momentum_model_linearly_in_inertia():
    ref = _limit_run(None)
    d1 = np.abs(_limit_run(1e-2) - ref).max()
    d2 = np.abs(_limit_run(5e-3) - ref).max()
    assert 1e-9 < d1 < 1e-3 * np.abs(ref).max()
    # difference ∝ inertia: halving the inertias halves it
    assert d1 / d2 == pytest.approx(2.0, rel=0.05)


def test_servo_rate_step_matches_closed_form_pi_response():
    """On a bus so heavy it does not move, with a non-spinning rotor, the PI loop gives
    V/R = (2ζω_b s + ω_b²)/(s² + 2ζω_b s + ω_b²) (scipy step response); with a large step the
    torque saturates and δ̈ = u_max/J_g."""
    J = 1e9 * np.eye(3)
    inert = CmgInertias(1e-6, 0.5, (1.0, 1.0, 1.5))
    cluster = SgcmgPyramid(h0=1e-12)  # rotor momentum → spin rate ~1e-6 rad/s: no gyroscopics
    servo = GimbalServo(bandwidth=5.0, max_torque=100.0, damping=0.7)
    act = VscmgActuator(J, inert, cluster, servo=servo)
    plant = _plant(act)
    st = plant.initial_state(np.eye(3))
    R, x = st.R, st.packed()

    def held_for(r: float, x: np.ndarray) -> VscmgCommand:
        base = act.command_unchecked(np.zeros((1, 3)), x[:, :3], x[:, 3:], 0.0)
        return VscmgCommand(
            delta_dot_cmd=np.full((1, 4), r),
            omega=base.omega,
            saturated=base.saturated,
            stop_limited=base.stop_limited,
            h_dot_cmd=base.h_dot_cmd,
            gimbal_torque_ff=np.zeros((1, 4)),
            spin_torque=np.zeros((1, 4)),
        )

    dt, n = 0.005, 400
    held = held_for(0.1, x)
    rates = []
    for k in range(n):
        R, x = plant.step_packed(k * dt, R, x, held, dt)
        rates.append(x[0, 7])
    wb, z = 5.0, 0.7
    sys = signal.lti([2 * z * wb, wb**2], [1, 2 * z * wb, wb**2])
    _, y = signal.step(sys, T=dt * np.arange(n + 1))
    np.testing.assert_allclose(rates, 0.1 * y[1:], atol=1e-8)
    # saturation: a huge step → initial δ̈ = u_max / J_g and the flag is logged
    x0 = st.packed()
    held = held_for(1e3, x0)
    log = act.log(x0[:, 3:], held)
    assert log["torque_saturated"].all()
    _, x1 = plant.step_packed(0.0, st.R, x0, held, 1e-3)
    np.testing.assert_allclose(x1[0, 7:11] / 1e-3, 100.0 / inert.J_g, rtol=1e-6)


@pytest.mark.parametrize("servo", [GimbalServo(20.0, 20.0), FirstOrderServo(0.05)])
def test_gimbal_stops_never_exceeded(servo):
    """A constant large torque command drives the gimbals; with stops ±0.4 rad about δ₀ the
    angles never leave them, and the guard's action and any contact are logged."""
    delta0 = np.array([np.pi / 4, -np.pi / 4, np.pi / 4, -np.pi / 4])
    stops = GimbalStops(delta0 - 0.4, delta0 + 0.4, braking_acceleration=2.0, margin=0.01)
    act = VscmgActuator(J_BUS, INERTIAS, SgcmgPyramid(h0=50.0), servo=servo, stops=stops)
    plant = _plant(act)
    st = plant.initial_state(np.eye(3))
    R, x = st.R, st.packed()
    t, dt = 0.0, 0.01
    lo, hi = np.inf, -np.inf
    limited = False
    for k in range(3000):
        u = np.array([[30.0, -20.0, 25.0]]) * (1 if k < 1500 else -1)
        held = act.command_unchecked(u, x[:, :3], x[:, 3:], t)
        limited |= bool(act.log(x[:, 3:], held)["stop_limited"].any())
        R, x = plant.step_packed(t, R, x, held, dt)
        t += dt
        d = x[0, 3:7] - delta0
        lo, hi = min(lo, d.min()), max(hi, d.max())
    assert limited
    assert hi <= 0.4 and lo >= -0.4
    assert hi > 0.3 or lo < -0.3  # the gimbals really went to the stops


def test_bumper_penetration_bounded_and_logged():
    """Open-loop torque u into a stop: the spring-damper bumper holds the gimbal within
    p ≤ (u + √(u² + k J_g v²))/k (energy of the arriving gimbal; bus coupling is small here),
    and stop contact is logged."""
    delta0 = np.zeros(4)
    stops = GimbalStops(-1.0, 0.2, stiffness=2000.0, damping=150.0, contact="bumper")
    act = VscmgActuator(
        1e6 * np.eye(3),
        INERTIAS,
        SgcmgPyramid(h0=1e-3),
        servo=GimbalServo(5.0, 10.0),
        stops=stops,
        delta0=delta0,
    )
    plant = _plant(act)
    st = plant.initial_state(np.eye(3))
    R, x = st.R, st.packed()
    u = 0.5
    held = act.open_loop(np.full((1, 4), u))
    dt = 0.002
    pen, v_hit, contact = 0.0, 0.0, False
    for k in range(2000):
        if not contact:
            v_hit = x[0, 7]  # rate at the last sample before the first contact
        R, x = plant.step_packed(k * dt, R, x, held, dt)
        pen = max(pen, x[0, 3] - 0.2)
        contact |= bool(act.log(x[:, 3:], held)["stop_contact"].any())
    k_, Jg = stops.stiffness, INERTIAS.J_g
    bound = (u + np.sqrt(u**2 + k_ * Jg * v_hit**2)) / k_
    assert contact and 0.0 < pen <= 1.01 * bound
    # it rests at the static deflection u/k
    assert x[0, 3] - 0.2 == pytest.approx(u / k_, rel=1e-3)


def test_metrics_count_stop_contact_and_torque_saturation():
    from benchmarks.metrics import compute_metrics
    from liecontrol.control import ConstantAttitude
    from liecontrol.control.geometric_pd import GeometricPD
    from spacecraft.simulator import simulate

    delta0 = np.array([np.pi / 4, -np.pi / 4, np.pi / 4, -np.pi / 4])
    # a guard too weak for the motor (braking 50 rad/s², no margin): the bumpers get hit
    stops = GimbalStops(
        delta0 - 0.05, delta0 + 0.05, braking_acceleration=50.0, stiffness=1e3, margin=0.0
    )
    act = VscmgActuator(
        J_BUS, INERTIAS, SgcmgPyramid(h0=50.0), servo=GimbalServo(20.0, 0.5), stops=stops
    )
    plant = _plant(act)
    ctrl = GeometricPD(J_BUS, k_R=200.0, k_Omega=2000.0)
    st = plant.initial_state(so3.exp(np.array([0.3, -0.2, 0.1])))
    res = simulate(plant, ctrl, ConstantAttitude(np.eye(3)), st, 20.0, 0.05)
    m = compute_metrics(res)
    assert m.torque_saturation_time_s[0] > 0.0
    assert m.stop_contact_time_s[0] > 0.0
    flags = res.actuator["stop_contact"].any(axis=(1, 2))
    assert m.stop_contact_time_s[0] == pytest.approx(0.05 * flags[:-1].sum())


def test_mini_cmg_preset_builds_and_runs():
    J = np.diag([0.05, 0.06, 0.04])
    act = MINI_CMG.make(J)
    assert act.inertias.wheel_spin * act.spin_rate0 == pytest.approx(MINI_CMG.h0)
    plant = _plant(act)
    st = plant.initial_state(np.eye(3), omega0=[0.01, 0.0, -0.01])
    R, x = _run(plant, st.R, st.packed(), 2.0, 0.002, lambda t, x: -0.05 * x[:, :3])
    assert np.all(np.isfinite(x))
    assert MINI_CMG.source


def test_bad_input_names_the_argument():
    with pytest.raises(ValueError, match="^wheel_spin"):
        CmgInertias(-1.0, 0.5, (1, 1, 1))
    with pytest.raises(ValueError, match="^wheel_transverse"):
        CmgInertias(1.0, 0.0, (1, 1, 1))
    with pytest.raises(ValueError, match="^gimbal"):
        CmgInertias(1.0, 0.5, (1, 0, 1))
    with pytest.raises(ValueError, match="^lower"):
        GimbalStops(0.5, 0.5)
    with pytest.raises(ValueError, match="^lower"):
        GimbalStops([0, 0, 1, 0], 0.5)
    with pytest.raises(ValueError, match="^bandwidth"):
        GimbalServo(0.0, 1.0)
    with pytest.raises(ValueError, match="^bandwidth"):
        GimbalServo(-2.0, 1.0)
    with pytest.raises(ValueError, match="^max_torque"):
        GimbalServo(2.0, -1.0)
    with pytest.raises(ValueError, match="^delta0"):
        VscmgActuator(J_BUS, INERTIAS, stops=GimbalStops(-0.1, 0.1))
    with pytest.raises(ValueError, match="^bus_inertia"):
        VscmgActuator(-J_BUS, INERTIAS)
    with pytest.raises(ValueError, match="^inertias"):
        VscmgActuator(J_BUS, (1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match="^servo"):
        VscmgActuator(J_BUS, INERTIAS, servo="ideal")
    act = VscmgActuator(J_BUS, INERTIAS, servo=FirstOrderServo(0.1))
    with pytest.raises(ValueError, match="^gimbal_torque"):
        act.open_loop(np.zeros((1, 4)))
    # the plant's body inertia must be the actuator's bus inertia: rejected when the plant is
    # built (the actuator's check_plant hook), not at the first step
    with pytest.raises(ValueError, match="^bus_inertia"):
        Spacecraft(RigidBody(2 * J_BUS), act)
    with pytest.raises(ValueError, match="^bus_inertia"):
        Spacecraft(RigidBody(np.stack([J_BUS, J_BUS])), act)
    plant = Spacecraft(RigidBody(J_BUS.copy()), act)  # equal values, another array: accepted
    st = plant.initial_state(np.eye(3))
    held = act.command(np.zeros((1, 3)), st.omega, st.x_act, 0.0)
    # the coupled-dynamics hook still checks the inertia it is handed
    with pytest.raises(ValueError, match="^bus_inertia"):
        act.coupled_derivatives(st.omega, st.x_act, held, np.zeros((1, 3)), 2 * J_BUS)
    with pytest.raises(TypeError, match="^x_act"):
        act.state_derivative(st.x_act, held)


def _solve_packed(act: VscmgActuator, w, x, held, tau):
    """The numpy reference route (VscmgActuator._solve) packed like the kernel's outputs."""
    r = act._solve(w, x, held, tau)
    out = np.concatenate(
        [r["omega_dot"], x[:, 4:8], r["delta_ddot"], r["spin_dot"], r["z_dot"]]
        + [r["power"][:, None]],
        axis=1,
    )
    det = np.stack(
        [
            r["gimbal_torque"],
            r["spin_torque"],
            r["torque_saturated"].astype(float),
            r["gimbal_power"],
            r["stop_torque"],
        ],
        axis=1,
    )
    return out, det


@pytest.mark.parametrize("B", [1, 5])
@pytest.mark.parametrize("kinematic", [False, True])
@pytest.mark.parametrize("variable_speed", [False, True])
def test_kernel_equals_numpy_route(kinematic, variable_speed, B):
    """The compiled kernel (spacecraft._kernels_vscmg) gives the numpy route's derivatives, motor
    torques, saturation flags, powers and stop torques to 1e-12 — closed-loop and open-loop
    commands, gimbals inside and beyond their stops, torque limit active."""
    rng = np.random.default_rng(5)
    servo = FirstOrderServo(0.2) if kinematic else GimbalServo(3.0, 0.8)
    stops = GimbalStops(-0.5, 0.5, stiffness=300.0, damping=7.0, contact="bumper")
    act = VscmgActuator(
        J_BUS,
        INERTIAS,
        SgcmgPyramid(h0=20.0),
        servo=servo,
        variable_speed=variable_speed,
        stops=stops,
        delta0=np.zeros(4),
    )
    n_sat = n_stop = 0
    for _ in range(3):
        x = act.initial_state(B)
        x[:, 0:4] = rng.uniform(-0.7, 0.7, size=(B, 4))
        x[:, 0:2] = (0.62, -0.58)  # two gimbals pressing into their stops
        x[:, 4:8] = 0.3 * rng.normal(size=(B, 4))
        x[:, 8:12] *= 1.0 + 0.1 * rng.normal(size=(B, 4))
        x[:, 12:16] = 0.1 * rng.normal(size=(B, 4))
        w = 0.05 * rng.normal(size=(B, 3))
        tau = rng.normal(size=(B, 3))
        helds = [act.command(rng.normal(size=(B, 3)), w, x, 0.0)]
        if not kinematic:
            helds.append(act.open_loop(rng.normal(size=(B, 4)), rng.normal(size=(B, 4)), w))
        for h in helds:
            x_in, w_in = x.copy(), w.copy()
            out, det = act._kernel(w, x, h, tau)
            ref, ref_det = _solve_packed(act, w, x, h, tau)
            scale = np.abs(ref).max(axis=1, keepdims=True)
            np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-12 * scale.max())
            np.testing.assert_allclose(det, ref_det, rtol=1e-12, atol=1e-12 * np.abs(ref_det).max())
            # the public hook takes the kernel route for one spacecraft or with numba
            np.testing.assert_allclose(
                act.coupled_derivatives(w, x, h, tau, act.bus_inertia),
                ref,
                rtol=1e-12,
                atol=1e-12 * scale.max(),
            )
            np.testing.assert_array_equal(x, x_in)  # inputs untouched
            np.testing.assert_array_equal(w, w_in)
            n_sat += int(ref_det[:, 2].sum())
            n_stop += int(np.count_nonzero(ref_det[:, 4]))
    # the branches under test were exercised
    if not kinematic:
        assert n_sat > 0 and n_stop > 0


@pytest.mark.parametrize("B", [1, 5])
@pytest.mark.parametrize("feedforward", [False, True])
def test_command_kernel_equals_numpy_route(B, feedforward):
    """The steering inputs of a command sample — Jacobian ``I_Ws Ω t``, ``ḣ_cmd = −u − ω × h``
    and the servo's gyroscopic feed-forward — from the compiled kernel equal the numpy route's
    to 1e-12, and the whole command (through the steering law) agrees."""
    rng = np.random.default_rng(12)
    servo = GimbalServo(3.0, 0.8, gyro_feedforward=feedforward)
    act = VscmgActuator(J_BUS, INERTIAS, SgcmgPyramid(h0=20.0), servo=servo)
    x = act.initial_state(B)
    x[:, 0:4] += rng.normal(size=(B, 4))
    x[:, 4:8] = 0.3 * rng.normal(size=(B, 4))
    x[:, 8:12] *= 1.0 + 0.1 * rng.normal(size=(B, 4))
    w = 0.05 * rng.normal(size=(B, 3))
    u = rng.normal(size=(B, 3))
    got = act._command_inputs_kernel(u, w, x, feedforward)
    ref = act._command_inputs(u, w, x, feedforward)
    for a, b in zip(got, ref, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())
    assert np.abs(got[2]).max() > 0.0 if feedforward else not got[2].any()
    held = act.command(u, w, x, 0.0)
    np.testing.assert_allclose(held.h_dot_cmd, ref[1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(held.gimbal_torque_ff, ref[2], rtol=1e-12, atol=1e-14)
    assert not held.saturated.any()  # SR's output is within the rate limit here: unscaled
    dd = act.steering(ref[0], ref[1])
    np.testing.assert_allclose(held.delta_dot_cmd, dd, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("B", [1, 5])
@pytest.mark.parametrize(
    "disturbance",
    [
        None,
        ConstantTorque([0.01, -0.02, 0.005]),
        ConstantHarmonicTorque(n=0.1, scale=5.0),
        pytest.param(
            GravityGradientTorque(J_BUS, CircularOrbit(n=0.05, inclination=0.6)),
            marks=pytest.mark.skipif(not JIT_ENABLED, reason="the seam torque needs numba"),
        ),
    ],
)
def test_compiled_rkmk4_step_equals_numpy_step(B, disturbance):
    """The compiled RKMK4 step of a plant flying the full CMG model (VscmgActuator._rkmk4_kernel)
    equals the integrator of liecontrol.integrators run on the numpy derivatives (_solve) to
    1e-12, over ten closed-loop steps with stops and the torque-limited servo; a torque of the
    disturbance seam (the gravity gradient) at the stage attitudes R exp(θ_s)."""
    rng = np.random.default_rng(4)
    act = VscmgActuator(
        J_BUS,
        INERTIAS,
        SgcmgPyramid(h0=20.0),
        servo=GimbalServo(3.0, 0.8),
        stops=GimbalStops(-0.5, 0.5, stiffness=300.0, damping=7.0, contact="bumper"),
        delta0=np.zeros(4),
    )
    plant = _plant(act, disturbance=disturbance)
    step = act._rkmk4_kernel(plant)
    assert step is not None
    st = plant.initial_state(so3.random(rng, B), omega0=0.02 * rng.normal(size=(B, 3)))
    R, x = st.R, st.packed()
    x[:, 3:7] = rng.uniform(-0.6, 0.6, size=(B, 4))  # some gimbals beyond their stops
    Rk, xk = R, x
    t, h = 0.7, 0.05
    for _ in range(10):
        held = act.command_unchecked(-30.0 * x[:, :3], x[:, :3], x[:, 3:], t)

        def f(tt, _R, xx, held=held):
            tau = np.zeros((B, 3)) if disturbance is None else disturbance(tt, _R, xx[:, :3])
            return xx[:, :3], _solve_packed(act, xx[:, :3], xx[:, 3:], held, tau)[0]

        R, x = rkmk4_step_unchecked(f, t, R, x, h, stage_attitude=True)
        Rk, xk = step(t, Rk, xk, held, h)
        np.testing.assert_allclose(Rk, R, rtol=0, atol=1e-12)
        np.testing.assert_allclose(xk, x, rtol=1e-12, atol=1e-12 * np.abs(x).max())
        Rk, xk = R, x  # same start for the next step: compare one step at a time
        t += h


def test_compiled_rkmk4_step_declines_parts_without_a_kernel():
    """No compiled step for a disturbance without a kernel (here attitude-dependent) or for
    another plant's actuator."""
    act = VscmgActuator(J_BUS, INERTIAS, SgcmgPyramid(h0=20.0))
    assert act._rkmk4_kernel(_plant(act)) is not None

    def attitude_torque(t, R, omega):
        return 1e-3 * R[:, 2, :]

    assert act._rkmk4_kernel(_plant(act, disturbance=attitude_torque)) is None
    assert _plant(act, disturbance=attitude_torque).disturbance is attitude_torque
    other = VscmgActuator(J_BUS, INERTIAS, SgcmgPyramid(h0=20.0))
    assert other._rkmk4_kernel(_plant(act)) is None


def test_kernel_rows_are_independent_of_the_batch():
    """One spacecraft gives, bit for bit, the row it gives inside a batch (no cross-talk between
    batch entries in the batched kernel)."""
    rng = np.random.default_rng(8)
    act = VscmgActuator(J_BUS, INERTIAS, SgcmgPyramid(h0=20.0), servo=GimbalServo(3.0, 0.8))
    B = 4
    x = act.initial_state(B)
    x[:, 4:8] = 0.3 * rng.normal(size=(B, 4))
    w = 0.05 * rng.normal(size=(B, 3))
    tau = rng.normal(size=(B, 3))
    held = act.command(rng.normal(size=(B, 3)), w, x, 0.0)
    out, det = act._kernel(w, x, held, tau)
    for b in range(B):
        one_held = VscmgCommand(
            **{k: v[b : b + 1] if isinstance(v, np.ndarray) else v for k, v in vars(held).items()}
        )
        o1, d1 = act._kernel(w[b : b + 1], x[b : b + 1], one_held, tau[b : b + 1])
        np.testing.assert_array_equal(o1[0], out[b])
        np.testing.assert_array_equal(d1[0], det[b])


def test_log_single_equals_batched():
    """The logged motor torques, flags and powers of one spacecraft (kernel route) equal the
    batched route's."""
    rng = np.random.default_rng(2)
    act = VscmgActuator(J_BUS, INERTIAS, SgcmgPyramid(h0=20.0), servo=GimbalServo(3.0, 0.8))
    x = act.initial_state(1)
    x[:, 4:8] = 0.3 * rng.normal(size=4)
    w = 0.05 * rng.normal(size=(1, 3))
    held = act.command(rng.normal(size=(1, 3)), w, x, 0.0)
    two_held = VscmgCommand(
        **{k: np.repeat(v, 2, 0) if isinstance(v, np.ndarray) else v for k, v in vars(held).items()}
    )
    one, two = act.log(x, held), act.log(np.repeat(x, 2, 0), two_held)
    assert one["torque_saturated"].any()  # 0.8 N·m is exceeded here
    for k in ("gimbal_torque", "spin_torque", "gimbal_power", "torque_saturated"):
        np.testing.assert_allclose(one[k][0], two[k][0], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(
        act.body_torque(w, x, held)[0],
        act.body_torque(np.repeat(w, 2, 0), np.repeat(x, 2, 0), two_held)[0],
        rtol=1e-12,
        atol=1e-14,
    )
