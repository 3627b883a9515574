"""Flexible appendage modes in hybrid coordinates (SPEC §5.4, *reconstructed*)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from liecontrol.control import AttitudeController, ConstantAttitude
from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
from liecontrol.lie import so3
from spacecraft import (
    ConstantTorque,
    FlexibleModes,
    IdealTorqueActuator,
    PlantState,
    RigidBody,
    SgcmgActuator,
    SimulationResult,
    SingularityRobust,
    Spacecraft,
    simulate,
)

J = np.diag([520.0, 450.0, 660.0])  # seed 003 bus
# three modes of two solar-array wings: strong enough to shift the frequencies visibly
B3 = np.array([[6.0, 1.0, 0.5], [0.5, 5.0, -1.0], [1.0, -0.5, 4.0]])
LAM3 = np.array([0.8, 1.9, 3.1])


class Zero(AttitudeController):
    def reset(self, t0, batch_size):
        self.B = batch_size

    def command(self, t, state, reference):
        return np.zeros((self.B, 3))


def _modal_plant(Bc=B3, lam=LAM3, zeta=0.01, disturbance=None, actuator=None):
    modes = FlexibleModes(Bc, lam, zeta)
    return Spacecraft(RigidBody(J), actuator or IdealTorqueActuator(), disturbance, modes)


def _run(plant, state, t_final, dt, controller=None, **kw):
    return simulate(
        plant, controller or Zero(), ConstantAttitude(np.eye(3)), state, t_final, dt, **kw
    )


# ------------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"coupling": np.ones((2, 2)), "frequencies": [1.0, 2.0]}, "coupling"),
        ({"coupling": np.ones(3), "frequencies": [1.0]}, "coupling"),
        ({"coupling": np.ones((2, 3)), "frequencies": [1.0]}, "frequencies"),
        ({"coupling": np.ones((2, 3)), "frequencies": [1.0, -2.0]}, "frequencies"),
        ({"coupling": np.ones((2, 3)), "frequencies": [1.0, 0.0]}, "frequencies"),
        ({"coupling": np.ones((2, 3)), "frequencies": [1.0, 2.0], "damping": -0.1}, "damping"),
        ({"coupling": np.ones((2, 3)), "frequencies": [1.0, 2.0], "damping": [0.1]}, "damping"),
        ({"coupling": [[np.nan, 0, 0]], "frequencies": [1.0]}, "coupling"),
    ],
)
def test_modes_validate(kwargs, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        FlexibleModes(**kwargs)


def test_coupling_too_strong_for_the_body_is_rejected():
    too_strong = np.array([[30.0, 0.0, 0.0]])  # BᵀB = 900 > J_xx = 520
    with pytest.raises(ValueError, match="^coupling:"):
        Spacecraft(RigidBody(J), IdealTorqueActuator(), modes=FlexibleModes(too_strong, [1.0]))
    with pytest.raises(ValueError, match="^modes:"):
        Spacecraft(RigidBody(J), IdealTorqueActuator(), modes="three modes")
    plant = _modal_plant()
    with pytest.raises(ValueError, match="^q0:"):
        plant.initial_state(np.eye(3), q0=np.zeros(2))
    with pytest.raises(ValueError, match="^R0:"):
        plant.initial_state(np.eye(3), q0=np.zeros((2, 3)), q_dot0=np.zeros((4, 3)))
    rigid = Spacecraft(RigidBody(J), IdealTorqueActuator())
    with pytest.raises(ValueError, match="^q0:"):
        rigid.initial_state(np.eye(3), q0=[0.1])
    with pytest.raises(ValueError, match=r"^q:"):  # a PlantState checks its own structure
        PlantState(np.eye(3)[None], np.zeros((1, 3)), np.zeros((1, 0)), q=[1.0])
    with pytest.raises(ValueError, match=r"^initial_state\.q:"):  # the plant's mode count
        one_mode = PlantState(np.eye(3)[None], np.zeros((1, 3)), np.zeros((1, 0)), q=[[1.0]])
        plant.check_state(one_mode)


def test_state_layout_and_defaults():
    plant = _modal_plant(actuator=SgcmgActuator(steering=SingularityRobust()))
    assert plant.n_modes == 3 and plant.n_x == 3 + 4 + 6
    s = plant.initial_state(np.eye(3), q0=[0.1, 0.2, 0.3], batch=2)
    np.testing.assert_array_equal(s.q, [[0.1, 0.2, 0.3]] * 2)
    np.testing.assert_array_equal(s.q_dot, np.zeros((2, 3)))
    x = s.packed()
    assert x.shape == (2, 13)
    np.testing.assert_array_equal(x[:, plant.q_slice], s.q)
    np.testing.assert_array_equal(x[:, plant.act_slice], s.x_act)
    # a PlantState without modal fields means "undeformed, at rest"
    bare = plant.check_state(PlantState(s.R, s.omega, s.x_act))
    np.testing.assert_array_equal(bare.q, np.zeros((2, 3)))


# ---------------------------------------------------------------------------------- physics
vec = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array)


@settings(max_examples=40, deadline=None)
@given(w=vec, q=vec, qd=vec, tau=vec)
def test_accelerations_solve_the_coupled_mass_matrix(w, q, qd, tau):
    """(ω̇, q̈) from the Schur complement equal a dense solve of [[J, Bᵀ], [B, I]]."""
    modes = FlexibleModes(B3, LAM3, [0.01, 0.02, 0.05])
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(), modes=modes)
    w = 0.3 * w
    tau = 5.0 * tau
    wd, qdd = modes.accelerations(
        w[None], q[None], qd[None], tau[None], plant.body.J, plant._Js_inv
    )
    M = modes.mass_matrix(J)
    rhs = np.concatenate(
        [
            tau - np.cross(w, J @ w + B3.T @ qd),
            -2.0 * modes.damping * LAM3 * qd - LAM3**2 * q,
        ]
    )
    sol = np.linalg.solve(M, rhs)
    np.testing.assert_allclose(wd[0], sol[:3], rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(qdd[0], sol[3:], rtol=1e-10, atol=1e-13)


def test_single_spacecraft_fast_path_matches_batched_path():
    modes = FlexibleModes(B3, LAM3, [0.01, 0.02, 0.05])
    plant = Spacecraft(RigidBody(J + 100.0 * np.ones((3, 3))), IdealTorqueActuator(), modes=modes)
    rng = np.random.default_rng(5)
    w, q, qd, tau = (rng.normal(size=(4, 3)) for _ in range(4))
    wd, qdd = modes.accelerations(w, q, qd, tau, plant.body.J, plant._Js_inv)
    for b in range(4):
        s = slice(b, b + 1)
        wd1, qdd1 = modes.accelerations(w[s], q[s], qd[s], tau[s], plant.body.J, plant._Js_inv)
        np.testing.assert_allclose(wd1, wd[s], rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(qdd1, qdd[s], rtol=1e-13, atol=1e-15)


def test_matches_solve_ivp_on_the_full_equations():
    """RKMK4 plant vs scipy's DOP853 on quaternion kinematics + the dense mass matrix."""
    T = np.array([0.5, -0.3, 0.2])
    plant = _modal_plant(zeta=0.02, disturbance=ConstantTorque(T))
    modes = plant.modes
    M = modes.mass_matrix(J)
    w0 = np.array([0.05, -0.03, 0.04])
    q0 = np.array([0.05, -0.02, 0.01])
    R0 = so3.exp(np.array([0.3, -0.2, 0.5]))

    def f(t, y):
        quat, w, q, qd = y[:4], y[4:7], y[7:10], y[10:13]
        rhs = np.concatenate(
            [
                T - np.cross(w, J @ w + B3.T @ qd),
                -2 * modes.damping * LAM3 * qd - LAM3**2 * q,
            ]
        )
        acc = np.linalg.solve(M, rhs)
        x, yy, z, s = quat  # scipy (x, y, z, w); q̇ = ½ q ⊗ (0, ω)
        qdot = 0.5 * np.array(
            [
                s * w[0] + yy * w[2] - z * w[1],
                s * w[1] + z * w[0] - x * w[2],
                s * w[2] + x * w[1] - yy * w[0],
                -(x * w[0] + yy * w[1] + z * w[2]),
            ]
        )
        return np.concatenate([qdot, acc[:3], qd, acc[3:]])

    y0 = np.concatenate([Rotation.from_matrix(R0).as_quat(), w0, q0, np.zeros(3)])
    ref = solve_ivp(f, (0.0, 20.0), y0, method="DOP853", rtol=1e-11, atol=1e-13)
    res = _run(plant, plant.initial_state(R0, w0, q0=q0), 20.0, 0.02, log_every=1000)
    R_ref = Rotation.from_quat(ref.y[:4, -1]).as_matrix()
    assert so3.angle(R_ref.T @ res.R[-1, 0]) < 1e-7
    np.testing.assert_allclose(res.omega[-1, 0], ref.y[4:7, -1], atol=1e-8)
    np.testing.assert_allclose(res.modes["q"][-1, 0], ref.y[7:10, -1], atol=1e-7)
    np.testing.assert_allclose(res.modes["q_dot"][-1, 0], ref.y[10:13, -1], atol=1e-7)


def test_uncontrolled_total_momentum_is_conserved():
    """No external torque: R (Jω + Bᵀq̇ + h) constant, with modes ringing and the CMG
    cluster moving under a controller (internal torques only)."""
    plant = _modal_plant(actuator=SgcmgActuator(steering=SingularityRobust()), zeta=0.005)
    k_R, k_W = gains_from_bandwidth(J, 0.2, 0.8, error="large_angle", matrix=True)
    ctrl = GeometricPD(J, k_R, k_W, error="large_angle")
    s0 = plant.initial_state(
        np.eye(3), omega0=[[0.02, -0.01, 0.03], [-0.01, 0.0, 0.02]], q0=[0.1, -0.05, 0.08]
    )
    res = simulate(
        plant, ctrl, ConstantAttitude(so3.exp(np.array([0.0, 0.0, 0.3]))), s0, 30.0, 0.05
    )
    h = res.actuator["h"]
    H_body = res.omega @ J + res.modes["q_dot"] @ B3 + h
    H = np.einsum("kbij,kbj->kbi", res.R, H_body)
    assert np.abs(res.actuator["delta_dot"]).max() > 1e-3  # the cluster really moved
    assert np.abs(res.modes["q_dot"]).max() > 1e-2  # and the modes really rang
    np.testing.assert_allclose(H, np.broadcast_to(H[0], H.shape), rtol=0, atol=1e-9)
    # with the modes' momentum left out the balance fails: the appendage carries momentum
    H_rigid = np.einsum("kbij,kbj->kbi", res.R, res.omega @ J + h)
    assert np.abs(H_rigid - H_rigid[0]).max() > 1e-2


def test_energy_dissipated_by_modal_damping():
    """Free spacecraft: E(t) − E(0) = −∫ 2 q̇ᵀ ζΛ q̇ dt (gyroscopic terms do no work)."""
    zeta = np.array([0.02, 0.01, 0.03])
    plant = _modal_plant(zeta=zeta)
    s0 = plant.initial_state(np.eye(3), omega0=[0.05, -0.04, 0.03], q0=[0.1, -0.05, 0.08])
    res = _run(plant, s0, 40.0, 0.01)
    K = res.n_samples
    states = PlantState(
        R=res.R.reshape(K, 3, 3),
        omega=res.omega[:, 0],
        x_act=np.zeros((K, 0)),
        q=res.modes["q"][:, 0],
        q_dot=res.modes["q_dot"][:, 0],
    )
    E = plant.mechanical_energy(states)
    qd = res.modes["q_dot"][:, 0]
    power = 2.0 * np.einsum("ki,i,ki->k", qd, zeta * LAM3, qd)
    dissipated = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * 0.01)])
    assert dissipated[-1] > 0.02 * E[0]  # a real loss, not round-off
    np.testing.assert_allclose(E - E[0], -dissipated, rtol=0, atol=1e-4 * dissipated[-1])
    assert np.all(np.diff(E) <= 1e-12 * E[0])


def test_clamped_mode_is_the_damped_oscillator():
    """A huge bus inertia clamps the body: each mode is q̈ + 2ζλq̇ + λ²q = 0 exactly."""
    lam, zeta, q0 = 2.0, 0.05, 0.3
    big = np.diag([1e12, 1e12, 1e12])
    plant = Spacecraft(
        RigidBody(big), IdealTorqueActuator(), modes=FlexibleModes([[1.0, 0.0, 0.0]], [lam], zeta)
    )
    res = _run(plant, plant.initial_state(np.eye(3), q0=[q0]), 10.0, 0.01)
    wd = lam * np.sqrt(1 - zeta**2)
    t = res.t
    exact = q0 * np.exp(-zeta * lam * t) * (np.cos(wd * t) + zeta * lam / wd * np.sin(wd * t))
    np.testing.assert_allclose(res.modes["q"][:, 0, 0], exact, atol=2e-8)  # RK4, (λh)⁴ ~ 2e-7


def test_modal_energy_decays_at_the_set_damping():
    """Weak coupling, one mode: the modal energy envelope decays as exp(−2ζλt)."""
    lam, zeta = 2.0, 0.02
    plant = _modal_plant(Bc=[[0.5, 0.3, 0.2]], lam=[lam], zeta=zeta)
    res = _run(plant, plant.initial_state(np.eye(3), q0=[0.2]), 60.0, 0.02)
    E = res.modes["energy"][:, 0, 0]
    assert res.modes["energy"].shape == (res.n_samples, 1, 1)
    slope = np.polyfit(res.t, np.log(E), 1)[0]
    assert slope == pytest.approx(-2.0 * zeta * lam, rel=0.03)


def _linear_frequencies(modes):
    """Damped natural frequencies of the linearised free spacecraft (angle θ, q), from the
    eigenvalues of its first-order form — independent of FlexibleModes' own formulas."""
    N = modes.n_modes
    M = modes.mass_matrix(J)
    K = np.zeros_like(M)
    C = np.zeros_like(M)
    K[3:, 3:] = np.diag(modes.frequencies**2)
    C[3:, 3:] = np.diag(2 * modes.damping * modes.frequencies)
    n = 3 + N
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -np.linalg.solve(M, K)
    A[n:, n:] = -np.linalg.solve(M, C)
    ev = scipy.linalg.eigvals(A)
    return np.sort(np.abs(ev.imag[ev.imag > 1e-6]))


def _spectrum(signal, dt, pad=16):
    """Hann-windowed, zero-padded amplitude spectrum of ``signal`` (cubic trend removed: the
    rigid body's response to a torque step is a polynomial in t), frequencies in rad/s."""
    k = np.linspace(-1.0, 1.0, signal.shape[0])
    y = signal - np.polyval(np.polyfit(k, signal, 3), k)
    Y = np.abs(np.fft.rfft(y * np.hanning(y.size), n=pad * y.size))
    return 2 * np.pi * np.fft.rfftfreq(pad * y.size, dt), Y


def _peak_near(w, Y, f, band=0.15):
    """Frequency of the spectral maximum within ±``band`` of ``f``, and whether it stands out
    (10× the median of the spectrum between 0.3 rad/s and 5 rad/s: the modes' range)."""
    m = (w > (1 - band) * f) & (w < (1 + band) * f)
    i = np.argmax(np.where(m, Y, -np.inf))
    floor = np.median(Y[(w > 0.3) & (w < 5.0)])
    return w[i], Y[i] > 10 * floor


def _check_peaks(signals, dt, freqs, rtol):
    for f in freqs:
        found = []
        for sig in signals.T:
            w, Y = _spectrum(sig, dt)
            wp, strong = _peak_near(w, Y, f)
            if strong:
                found.append(wp)
        assert found, f"no spectral peak near {f:.3f} rad/s"
        np.testing.assert_allclose(found, f, rtol=rtol)


def test_step_torque_excites_the_set_frequencies():
    """Weak coupling: the body-rate spectrum after a torque step peaks at λ_i (within 2 %)."""
    plant = _modal_plant(Bc=0.3 * B3, zeta=0.003, disturbance=ConstantTorque([0.1, -0.08, 0.05]))
    res = _run(plant, plant.initial_state(np.eye(3)), 200.0, 0.05)
    _check_peaks(res.omega[:, 0], 0.05, LAM3, rtol=0.02)  # what a gyro would see


def test_strong_coupling_shifts_to_the_free_free_frequencies():
    """Strong coupling: modal peaks sit at the linearised free-free frequencies (independent
    eigen-analysis), and FlexibleModes.free_free_frequencies agrees with it."""
    plant = _modal_plant(Bc=2.0 * B3, zeta=0.003, disturbance=ConstantTorque([0.1, -0.08, 0.05]))
    expected = _linear_frequencies(plant.modes)
    np.testing.assert_allclose(plant.modes.free_free_frequencies(J), expected, rtol=1e-4)
    assert np.all(expected > LAM3 * 1.05)  # a visible shift
    res = _run(plant, plant.initial_state(np.eye(3)), 200.0, 0.05)
    _check_peaks(res.modes["q"][:, 0], 0.05, expected, rtol=0.005)
    _check_peaks(res.omega[:, 0], 0.05, expected, rtol=0.005)


def test_batched_modes_and_csv_round_trip(tmp_path):
    plant = _modal_plant(disturbance=ConstantTorque([0.2, 0.0, -0.1]))
    q0 = np.array([[0.1, 0.0, 0.0], [0.0, -0.1, 0.05]])
    res = _run(plant, plant.initial_state(np.eye(3), q0=q0), 3.0, 0.1)
    for b in range(2):
        one = _run(plant, plant.initial_state(np.eye(3), q0=q0[b]), 3.0, 0.1)
        np.testing.assert_allclose(res.modes["q"][:, b], one.modes["q"][:, 0], atol=1e-13)
    path = tmp_path / "modes.csv"
    res.to_csv(path, batch_index=1)
    back = SimulationResult.from_csv(path)
    for key in ("q", "q_dot", "energy"):
        np.testing.assert_array_equal(back.modes[key][:, 0], res.modes[key][:, 1])
