"""Plant physics: rigid body, disturbances, actuator seam, momentum exchange (SPEC §5.1–5.4)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SEED000_J
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from liecontrol.lie import so3
from spacecraft import (
    CmgCommand,
    ConstantHarmonicTorque,
    ConstantTorque,
    IdealTorqueActuator,
    PlantState,
    PseudoInverse,
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
    SumOfDisturbances,
    ZeroDisturbance,
)
from spacecraft.rigid_body import _cross

J_SEED = SEED000_J
J_SMALL = np.array([[10.0, 1.0, -0.5], [1.0, 14.0, 0.8], [-0.5, 0.8, 17.0]])

vec3 = st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3).map(np.array)
vec4 = st.lists(st.floats(-np.pi, np.pi), min_size=4, max_size=4).map(np.array)


# ------------------------------------------------------------------------------- rigid body
def test_rigid_body_validates_inertia():
    with pytest.raises(ValueError, match="^J:"):
        RigidBody(np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))  # asymmetric
    with pytest.raises(ValueError, match="^J:"):
        RigidBody(np.diag([1.0, 1.0, 3.0]))  # triangle inequality
    with pytest.raises(ValueError, match="^J:"):
        RigidBody(np.diag([1.0, -1.0, 1.0]))
    with pytest.raises(ValueError, match="^J:"):
        RigidBody(np.zeros((2, 2)))
    body = RigidBody(J_SEED)
    np.testing.assert_allclose(body.J_inv @ body.J, np.eye(3), atol=1e-13)
    assert not body.J.flags.writeable


@settings(max_examples=50, deadline=None)
@given(a=vec3, b=vec3)
def test_cross_matches_numpy(a, b):
    np.testing.assert_allclose(_cross(a[None], b[None])[0], np.cross(a, b), atol=1e-15)


@settings(max_examples=50, deadline=None)
@given(w=vec3, h=vec3, hdot=vec3, td=vec3)
def test_momentum_form_equals_internal_torque_form(w, h, hdot, td):
    """J ω̇ + ω × (Jω + h) = −ḣ + T_d  ⇔  J ω̇ + ω × Jω = u + T_d with u = −ḣ − ω × h."""
    body = RigidBody(J_SEED)
    h = 300.0 * h
    a1 = body.angular_acceleration_momentum(w, h, hdot, td)
    u = -hdot - np.cross(w, h)
    a2 = body.angular_acceleration(w[None], (u + td)[None])[0]
    np.testing.assert_allclose(a1, a2, rtol=1e-12, atol=1e-15)
    # and Euler's equation itself, solved by numpy
    a3 = np.linalg.solve(J_SEED, -np.cross(w, J_SEED @ w + h) - hdot + td)
    np.testing.assert_allclose(a1, a3, rtol=1e-10, atol=1e-15)


# ----------------------------------------------------------------------------- disturbances
def test_seed000_disturbance_values():
    n = 0.0011
    d = ConstantHarmonicTorque(n=n)
    R = np.broadcast_to(np.eye(3), (2, 3, 3))
    w = np.zeros((2, 3))
    np.testing.assert_allclose(d(0.0, R, w), [[0.02, 0.08, 0.02]] * 2, atol=1e-15)
    t = np.pi / (2 * n)  # sin nt = 1, sin 2nt = 0
    np.testing.assert_allclose(d(t, R, w), [[0.04, 0.12, 0.04]] * 2, atol=1e-15)
    t = np.pi / (4 * n)  # sin nt = √2/2, sin 2nt = 1
    s = np.sqrt(0.5)
    expect = [0.02 + 0.02 * s + 0.01, 0.08 + 0.04 * s + 0.01, 0.02 + 0.02 * s + 0.01]
    scaled = ConstantHarmonicTorque(n=n, scale=3.0)(t, R, w)[1]
    np.testing.assert_allclose(scaled, 3 * np.array(expect))
    with pytest.raises(ValueError, match="^n:"):
        ConstantHarmonicTorque(n=0.0)


def test_disturbances_compose():
    rng = np.random.default_rng(0)
    R = so3.random(rng, 4)
    w = rng.normal(size=(4, 3))
    bias = ConstantTorque([0.1, -0.2, 0.3])
    per_sc = ConstantTorque(rng.normal(size=(4, 3)))
    seed = ConstantHarmonicTorque()
    total = SumOfDisturbances(
        {"bias": bias, "per_sc": per_sc, "seed": seed, "zero": ZeroDisturbance()}
    )
    comps = total.components(123.0, R, w)
    assert set(comps) == {"bias", "per_sc", "seed", "zero"}
    np.testing.assert_allclose(total(123.0, R, w), sum(comps.values()), atol=1e-15)
    np.testing.assert_allclose(comps["per_sc"], per_sc.torque)
    assert np.all(comps["zero"] == 0)
    unnamed = SumOfDisturbances([bias, seed])
    assert set(unnamed.sources) == {"d0", "d1"}
    with pytest.raises(ValueError, match="^sources:"):
        SumOfDisturbances({})
    with pytest.raises(ValueError, match="^sources:"):
        SumOfDisturbances({"x": 3.0})
    with pytest.raises(ValueError, match="^torque:"):
        ConstantTorque([1.0, 2.0])


# ------------------------------------------------------------------------------- actuators
@pytest.fixture(scope="module")
def cmg():
    return SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust())


@settings(max_examples=40, deadline=None)
@given(delta=vec4, ddot=vec4, w=vec3)
def test_cmg_body_torque_is_minus_hdot_minus_omega_cross_h(delta, ddot, w):
    """u = −ḣ − ω × h, with ḣ from a central finite difference of the cluster's h(δ)."""
    act = SgcmgActuator(SgcmgPyramid(h0=300.0), PseudoInverse())
    cl = act.cluster
    ddot = 0.3 * ddot
    w = 0.05 * w
    held = CmgCommand(delta_dot=ddot[None], saturated=np.zeros(1, bool), h_dot_cmd=np.zeros((1, 3)))
    eps = 1e-6
    hdot_fd = (cl.momentum(delta + eps * ddot) - cl.momentum(delta - eps * ddot)) / (2 * eps)
    u = act.body_torque(w[None], delta[None], held)[0]
    np.testing.assert_allclose(u, -hdot_fd - np.cross(w, cl.momentum(delta)), atol=1e-6)
    np.testing.assert_allclose(act.momentum(delta[None])[0], cl.momentum(delta), atol=1e-12)


def test_cmg_delivers_commanded_torque_away_from_singularity():
    act = SgcmgActuator(SgcmgPyramid(), PseudoInverse())
    rng = np.random.default_rng(1)
    delta = act.initial_state(5) + 0.2 * rng.normal(size=(5, 4))
    w = 0.01 * rng.normal(size=(5, 3))
    u_cmd = rng.normal(size=(5, 3))
    held = act.command(u_cmd, w, delta, 0.0)
    assert not held.saturated.any()
    np.testing.assert_allclose(act.body_torque(w, delta, held), u_cmd, atol=1e-9)
    np.testing.assert_array_equal(act.state_derivative(delta, held), held.delta_dot)
    log = act.log(delta, held)
    assert set(log) == {"delta", "delta_dot", "saturated"}
    derived = act.derived_log({k: v[None] for k, v in log.items()})  # a log with K = 1
    assert derived["singularity"].shape == (1, 5) and derived["h"].shape == (1, 5, 3)
    np.testing.assert_allclose(derived["h"][0], act.cluster.momentum(delta), atol=1e-12)
    np.testing.assert_allclose(
        derived["singularity"][0], act.cluster.singularity_measure(delta), atol=1e-15
    )


def test_cmg_rate_limit_saturates_and_flags(cmg):
    delta = cmg.initial_state(2)
    u_cmd = np.array([[0.0, 0.0, 0.0], [2000.0, -1500.0, 800.0]])  # N·m: far beyond 1 rad/s
    held = cmg.command(u_cmd, np.zeros((2, 3)), delta, 0.0)
    assert held.saturated.tolist() == [False, True]
    assert np.abs(held.delta_dot).max() <= cmg.rate_limit * (1 + 1e-12)
    np.testing.assert_allclose(np.abs(held.delta_dot[1]).max(), cmg.rate_limit)


def test_cmg_default_gimbals_store_no_momentum(cmg):
    np.testing.assert_allclose(cmg.momentum(cmg.initial_state(3)), 0.0, atol=1e-12)
    with pytest.raises(ValueError, match="^delta0:"):
        SgcmgActuator(delta0=[0.0, 1.0])
    with pytest.raises(ValueError, match="^steering:"):
        SgcmgActuator(steering=3)


def test_ideal_actuator_and_saturation():
    act = IdealTorqueActuator()
    u = np.array([[1.0, -2.0, 3.0]])
    held = act.command(u, np.zeros((1, 3)), np.zeros((1, 0)), 0.0)
    u[0, 0] = 99.0  # the held command must not alias the controller's array
    np.testing.assert_array_equal(
        act.body_torque(np.zeros((1, 3)), np.zeros((1, 0)), held), [[1, -2, 3]]
    )
    sat = IdealTorqueActuator(max_torque=1.5)
    held = sat.command(np.array([[1.0, -2.0, 3.0]]), np.zeros((1, 3)), np.zeros((1, 0)), 0.0)
    np.testing.assert_array_equal(held, [[1.0, -1.5, 1.5]])
    assert sat.log(np.zeros((1, 0)), held)["saturated"].tolist() == [[False, True, True]]
    with pytest.raises(ValueError, match="^max_torque:"):
        IdealTorqueActuator(max_torque=-1.0)


# ------------------------------------------------------------------------------------ plant
def test_initial_state_broadcasting_and_validation():
    plant = Spacecraft(RigidBody(J_SEED), SgcmgActuator())
    s = plant.initial_state(np.eye(3), omega0=np.zeros((4, 3)))
    assert s.R.shape == (4, 3, 3) and s.omega.shape == (4, 3) and s.x_act.shape == (4, 4)
    np.testing.assert_allclose(s.x_act[2], np.deg2rad([45, -45, 45, -45]))
    assert plant.initial_state(np.eye(3), batch=3).batch_size == 3
    with pytest.raises(ValueError, match="^R0:"):
        plant.initial_state(np.eye(3) * 1.1)
    with pytest.raises(ValueError, match="^R0:"):
        plant.initial_state(np.eye(3)[None].repeat(2, 0), omega0=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="^omega0:"):
        plant.initial_state(np.eye(3), omega0=np.zeros(4))
    with pytest.raises(ValueError, match="^x_act0:"):
        plant.initial_state(np.eye(3), x_act0=np.zeros(3))
    bad = PlantState(R=np.eye(3)[None], omega=np.zeros((1, 3)), x_act=np.zeros((1, 3)))
    with pytest.raises(ValueError, match="^initial_state.x_act:"):
        plant.check_state(bad)
    with pytest.raises(ValueError, match="^body:"):
        Spacecraft(J_SEED, SgcmgActuator())
    with pytest.raises(ValueError, match="^actuator:"):
        Spacecraft(RigidBody(J_SEED), object())
    with pytest.raises(ValueError, match="^disturbance:"):
        Spacecraft(RigidBody(J_SEED), SgcmgActuator(), disturbance=1.0)


def test_momentum_exchange_conserves_inertial_momentum():
    """Key physics check (SPEC §5.1): without external torque the total inertial momentum
    R (Jω + h) is constant whatever the gimbals do — here under a random, changing torque command
    through the SR steering law, plus constant-rate gimbal motion with zero command."""
    rng = np.random.default_rng(7)
    act = SgcmgActuator(SgcmgPyramid(), SingularityRobust())
    plant = Spacecraft(RigidBody(J_SEED), act)
    B = 3
    state = plant.initial_state(so3.random(rng, B), omega0=0.02 * rng.normal(size=(B, 3)))
    H0 = plant.inertial_momentum(state)
    dt = 0.1
    for k in range(400):
        u_cmd = 20.0 * rng.normal(size=(B, 3))
        held = plant.command(u_cmd, state, k * dt)
        state = plant.step(state, held, k * dt, dt)
    H = plant.inertial_momentum(state)
    assert np.abs(H - H0).max() < 1e-9 * np.abs(H0).max() + 1e-9
    # the momentum really was exchanged: the wheels' share changed by O(h0)
    assert np.abs(plant.actuator_momentum(state)).max() > 30.0
    # orthonormality kept by RKMK4
    assert np.abs(np.swapaxes(state.R, -1, -2) @ state.R - np.eye(3)).max() < 1e-13


def test_external_torque_changes_momentum_by_its_integral():
    """d/dt R(Jω + h) = R T_d: compare with a trapezoid integral of R T_d over the samples."""
    rng = np.random.default_rng(3)
    T = ConstantTorque([0.5, -0.2, 0.1])
    plant = Spacecraft(RigidBody(J_SMALL), IdealTorqueActuator(), disturbance=T)
    state = plant.initial_state(so3.random(rng), omega0=[0.05, -0.02, 0.03])
    dt, n = 0.01, 1000
    H0 = plant.inertial_momentum(state)
    zero = np.zeros((1, 3))
    samples = [state.R[0] @ T.torque]
    for k in range(n):
        state = plant.step(state, plant.command(zero, state, k * dt), k * dt, dt)
        samples.append(state.R[0] @ T.torque)
    integral = np.trapezoid(np.array(samples), dx=dt, axis=0)
    np.testing.assert_allclose(plant.inertial_momentum(state)[0] - H0[0], integral, atol=2e-5)


def _quat_rhs(t, y, J, Jinv):
    q, w = y[:4], y[4:]
    qw, qv = q[0], q[1:]
    dq = 0.5 * np.concatenate([[-qv @ w], qw * w + np.cross(qv, w)])  # q̇ = ½ q ⊗ (0, ω)
    dw = Jinv @ (-np.cross(w, J @ w))
    return np.concatenate([dq, dw])


def test_torque_free_body_matches_quaternion_solve_ivp():
    """Torque-free tumbling: RKMK4 plant vs a dense scipy solve on quaternions (independent)."""
    rng = np.random.default_rng(11)
    R0 = so3.random(rng)
    w0 = np.array([0.3, -0.2, 0.25])
    plant = Spacecraft(RigidBody(J_SMALL), IdealTorqueActuator(), ZeroDisturbance())
    state = plant.initial_state(R0, omega0=w0)
    dt, n = 0.05, 400
    zero = np.zeros((1, 3))
    for k in range(n):
        state = plant.step(state, plant.command(zero, state, k * dt), k * dt, dt)
    q0 = Rotation.from_matrix(R0).as_quat(scalar_first=True)
    sol = solve_ivp(
        _quat_rhs,
        (0, n * dt),
        np.concatenate([q0, w0]),
        args=(J_SMALL, np.linalg.inv(J_SMALL)),
        method="DOP853",
        rtol=1e-13,
        atol=1e-13,
    )
    yT = sol.y[:, -1]
    R_ref = Rotation.from_quat(yT[:4] / np.linalg.norm(yT[:4]), scalar_first=True).as_matrix()
    assert so3.angle(R_ref.T @ state.R[0]) < 1e-7
    np.testing.assert_allclose(state.omega[0], yT[4:], atol=1e-8)
    # energy of the torque-free body is conserved (RKMK4: to integration accuracy)
    body = plant.body
    assert abs(body.kinetic_energy(state.omega)[0] - body.kinetic_energy(w0)) < 1e-9


def test_single_body_fast_paths_match_batched_paths():
    """B = 1 runs on Python floats (speed); it must agree with the numpy path for B > 1."""
    rng = np.random.default_rng(2)
    body = RigidBody(J_SEED)
    act = SgcmgActuator(SgcmgPyramid(), SingularityRobust())
    w = 0.05 * rng.normal(size=(2, 3))
    tau = rng.normal(size=(2, 3))
    delta = rng.uniform(-np.pi, np.pi, size=(2, 4))
    held = CmgCommand(
        delta_dot=rng.normal(size=(2, 4)), saturated=np.zeros(2, bool), h_dot_cmd=np.zeros((2, 3))
    )
    batched_acc = body.angular_acceleration(w, tau)
    batched_tau = act.body_torque(w, delta, held)
    for b in range(2):
        s = slice(b, b + 1)
        one = CmgCommand(held.delta_dot[s], held.saturated[s], held.h_dot_cmd[s])
        np.testing.assert_allclose(
            body.angular_acceleration(w[s], tau[s]), batched_acc[s], rtol=1e-14, atol=1e-18
        )
        np.testing.assert_allclose(
            act.body_torque(w[s], delta[s], one), batched_tau[s], rtol=1e-13, atol=1e-12
        )


# ---------------------------------------------------------------- parameter uncertainty (§5.4)
J_003 = np.diag([520.0, 450.0, 660.0])


def test_perturbed_inertia_statistics_and_reproducibility():
    from spacecraft import perturbed_inertia

    rng = np.random.default_rng(11)
    J_rot = so3.exp(np.array([0.3, -0.5, 0.8])) @ J_003 @ so3.exp(np.array([0.3, -0.5, 0.8])).T
    Js = perturbed_inertia(J_rot, rng, scale_std=0.05, size=4000)
    assert Js.shape == (4000, 3, 3)
    np.testing.assert_allclose(Js, np.swapaxes(Js, -1, -2), atol=0)
    lam_true, Q = np.linalg.eigh(J_rot)
    # no axis error: J_hat keeps J's principal axes, each moment scaled by 1 + N(0, 0.05²)
    ratios = np.einsum("ji,bjk,ki->bi", Q, Js, Q) / lam_true
    off = np.einsum("ji,bjk,kl->bil", Q, Js, Q) - ratios[:, :, None] * np.eye(3) * lam_true
    assert np.abs(off).max() < 1e-9 * lam_true.max()
    np.testing.assert_allclose(ratios.mean(axis=0), 1.0, atol=0.005)
    np.testing.assert_allclose(ratios.std(axis=0), 0.05, rtol=0.05)
    # same seed, same draws; a single draw is (3, 3) and a valid inertia
    a = perturbed_inertia(J_003, np.random.default_rng(3), 0.1, axis_std=0.05)
    b = perturbed_inertia(J_003, np.random.default_rng(3), 0.1, axis_std=0.05)
    np.testing.assert_array_equal(a, b)
    RigidBody(a)


def test_perturbed_inertia_axis_error_and_scale():
    from spacecraft import perturbed_inertia

    rng = np.random.default_rng(4)
    Js = perturbed_inertia(J_003, rng, axis_std=0.02, size=500)
    # a pure axis rotation keeps the principal moments (scipy-independent check: eigvalsh)
    np.testing.assert_allclose(np.linalg.eigvalsh(Js), np.broadcast_to([450, 520, 660], (500, 3)))
    # and the misalignment angle is ~ axis_std·√3 on average (Maxwell χ with 3 d.o.f.)
    _, V = np.linalg.eigh(Js)
    ang = np.arccos(np.clip(np.abs(V[:, 2, 2]), 0.0, 1.0))  # tilt of the z principal axis
    assert 0.01 < np.median(ang) < 0.05
    np.testing.assert_allclose(perturbed_inertia(J_003, rng, scale=1.1), 1.1 * J_003)
    # large errors are truncated to physical inertias, never returned unphysical
    wild = perturbed_inertia(np.diag([1.0, 1.0, 1.9]), rng, scale_std=0.5, size=300)
    RigidBody(wild[0])
    lam = np.linalg.eigvalsh(wild)
    assert np.all(lam > 0) and np.all(lam[:, 0] + lam[:, 1] >= lam[:, 2] * (1 - 1e-9))


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"J": np.diag([1.0, 1.0, 3.0])}, "J"),
        ({"rng": 3}, "rng"),
        ({"scale_std": -0.1}, "scale_std"),
        ({"scale_std": 1.0}, "scale_std"),
        ({"axis_std": np.nan}, "axis_std"),
        ({"scale": 0.0}, "scale"),
        ({"scale": [1.0, 2.0]}, "scale"),
        ({"size": 0}, "size"),
        ({"max_tries": 0}, "max_tries"),
    ],
)
def test_perturbed_inertia_bad_input(kwargs, name):
    from spacecraft import perturbed_inertia

    args = {"J": J_003, "rng": np.random.default_rng(0)}
    args.update(kwargs)
    with pytest.raises(ValueError, match=f"^{name}:"):
        perturbed_inertia(**args)


def test_controller_with_perturbed_inertia_still_regulates():
    """Parameter uncertainty in the loop: a PD designed on a 15 %-wrong inertia (seeded draw)
    still brings the true plant to the target."""
    from liecontrol.control import ConstantAttitude
    from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
    from spacecraft import perturbed_inertia, simulate

    J_hat = perturbed_inertia(J_003, np.random.default_rng(9), 0.15, axis_std=0.1)
    assert np.abs(J_hat - J_003).max() > 0.05 * 660
    k_R, k_W = gains_from_bandwidth(J_hat, 0.2, 0.9, error="large_angle", matrix=True)
    ctrl = GeometricPD(J_hat, k_R, k_W, error="large_angle")
    plant = Spacecraft(RigidBody(J_003), IdealTorqueActuator())
    R_d = so3.exp(np.array([0.5, -0.3, 0.4]))
    res = simulate(plant, ctrl, ConstantAttitude(R_d), plant.initial_state(np.eye(3)), 60.0, 0.1)
    assert res.attitude_error_angle()[-1, 0] < 1e-3


# --------------------------------------------------------- per-spacecraft inertia (issue 7)
def _inertias(B: int, seed: int = 21) -> np.ndarray:
    from spacecraft import perturbed_inertia

    return perturbed_inertia(J_SEED, np.random.default_rng(seed), 0.2, axis_std=0.1, size=B)


def test_per_spacecraft_inertia_is_validated_each():
    Js = _inertias(5)
    body = RigidBody(Js)
    assert body.batch_size == 5 and RigidBody(J_SEED).batch_size is None
    assert body.J.shape == body.J_inv.shape == (5, 3, 3)
    np.testing.assert_allclose(body.J_inv @ Js, np.broadcast_to(np.eye(3), (5, 3, 3)), atol=1e-13)
    assert not body.J.flags.writeable and not body.J_inv.flags.writeable
    bad = Js.copy()
    bad[3] = np.diag([1.0, 1.0, 3.0])  # triangle inequality
    with pytest.raises(ValueError, match=r"^J\[3\]: principal moments violate"):
        RigidBody(bad)
    bad = Js.copy()
    bad[1, 0, 1] += 50.0  # asymmetric
    with pytest.raises(ValueError, match=r"^J\[1\]: not symmetric"):
        RigidBody(bad)
    bad = Js.copy()
    bad[4] = -bad[4]
    with pytest.raises(ValueError, match=r"^J\[4\]: not positive definite"):
        RigidBody(bad)
    for shape in ((0, 3, 3), (2, 2, 3, 3)):
        with pytest.raises(ValueError, match=r"^J: expected shape \(3, 3\) or \(B, 3, 3\)"):
            RigidBody(np.zeros(shape))
    with pytest.raises(ValueError, match="^J:"):
        RigidBody(np.full((2, 3, 3), np.nan))
    # never mutates its input
    Js_copy = Js.copy()
    RigidBody(Js)
    np.testing.assert_array_equal(Js, Js_copy)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), B=st.integers(1, 7))
def test_per_spacecraft_body_equals_one_body_per_spacecraft(seed, B):
    """Each spacecraft of a (B, 3, 3) body behaves as RigidBody(J[b]) alone; ω̇ is also checked
    against an independent route (np.linalg.solve of J ω̇ = τ − ω × Jω)."""
    rng = np.random.default_rng(seed)
    Js = _inertias(B, seed)
    body = RigidBody(Js)
    w = 0.1 * rng.normal(size=(B, 3))
    tau = rng.normal(size=(B, 3))
    h = 50.0 * rng.normal(size=(B, 3))
    acc = body.angular_acceleration(w, tau)
    ref = np.linalg.solve(Js, (tau - np.cross(w, np.einsum("bij,bj->bi", Js, w)))[..., None])
    np.testing.assert_allclose(acc, ref[..., 0], rtol=1e-10, atol=1e-15)
    H = body.body_momentum(w, h)
    E = body.kinetic_energy(w)
    mom = body.angular_acceleration_momentum(w, h, tau, -tau)
    for b in range(B):
        one = RigidBody(Js[b])
        s = slice(b, b + 1)
        np.testing.assert_allclose(acc[s], one.angular_acceleration(w[s], tau[s]), rtol=1e-13)
        np.testing.assert_allclose(H[b], one.body_momentum(w[b], h[b]), rtol=1e-13, atol=1e-12)
        assert E[b] == pytest.approx(float(one.kinetic_energy(w[b])), rel=1e-13)
        # componentwise relative error is meaningless for a component that cancels: scale by
        # the vector
        scale = float(np.abs(mom[b]).max())
        np.testing.assert_allclose(
            mom[b], one.angular_acceleration_momentum(w[b], h[b], tau[b], -tau[b]),
            rtol=1e-12, atol=1e-12 * scale,
        )  # fmt: skip
    # with a batch of one the single-spacecraft kernel route is taken, same numbers
    one = RigidBody(Js[:1])
    assert one._J1 is not None
    np.testing.assert_allclose(one.angular_acceleration(w[:1], tau[:1]), acc[:1], rtol=1e-14)


def _flight(J, B, rng_seed=5, disturbance=None, t_final=30.0):
    from liecontrol.control import ConstantAttitude
    from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
    from spacecraft import simulate

    rng = np.random.default_rng(rng_seed)
    R0 = so3.random(rng, B)
    w0 = 0.005 * rng.normal(size=(B, 3))
    k_R, k_W = gains_from_bandwidth(J_SEED, 0.1, 0.9, error="large_angle", matrix=True)
    ctrl = GeometricPD(J_SEED, k_R, k_W, error="large_angle")  # nominal model J
    act = SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust())
    plant = Spacecraft(RigidBody(J), act, disturbance)
    return plant, R0, w0, lambda p, R, w: simulate(
        p, ctrl, ConstantAttitude(np.eye(3)), p.initial_state(R, w), t_final, 0.1,
        control_period=0.2,
    )  # fmt: skip


def test_batched_inertia_simulation_equals_per_spacecraft_runs():
    """Issue 7: a batch with one true inertia per spacecraft flies exactly (1e-12) as the
    spacecraft flown one by one, each with its own J, under a controller with the nominal J."""
    B = 4
    Js = _inertias(B)
    plant, R0, w0, fly = _flight(Js, B, disturbance=ConstantHarmonicTorque())
    res = fly(plant, R0, w0)
    assert np.abs(res.omega[-1]).max() > 0  # a real manoeuvre, not a trivial rest
    for b in range(B):
        one = Spacecraft(RigidBody(Js[b]), plant.actuator, plant.disturbance)
        r1 = fly(one, R0[b], w0[b])
        np.testing.assert_allclose(res.R[:, b], r1.R[:, 0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(res.omega[:, b], r1.omega[:, 0], rtol=0, atol=1e-12)
        d, d1 = res.actuator["delta"][:, b], r1.actuator["delta"][:, 0]
        np.testing.assert_allclose(d, d1, rtol=0, atol=1e-12)
    # the inertias matter: the shared nominal J gives a different flight
    shared, *_ = _flight(J_SEED, B)
    assert np.abs(fly(shared, R0, w0).omega[-1] - res.omega[-1]).max() > 1e-6


def test_per_spacecraft_inertia_conserves_each_inertial_momentum():
    """Physics of the batched-J plant (independent of the per-spacecraft comparison): without
    external torque each spacecraft's R (J_b ω + h) stays constant under momentum exchange."""
    rng = np.random.default_rng(8)
    B = 3
    Js = _inertias(B, 2)
    plant = Spacecraft(RigidBody(Js), SgcmgActuator(SgcmgPyramid(), SingularityRobust()))
    state = plant.initial_state(so3.random(rng, B), omega0=0.02 * rng.normal(size=(B, 3)))
    H0 = plant.inertial_momentum(state)
    np.testing.assert_allclose(
        H0,
        np.einsum("bij,bj->bi", state.R, np.einsum("bij,bj->bi", Js, state.omega)
                  + plant.actuator_momentum(state)),
        rtol=1e-13,
    )  # fmt: skip
    for k in range(200):
        held = plant.command(20.0 * rng.normal(size=(B, 3)), state, 0.1 * k)
        state = plant.step(state, held, 0.1 * k, 0.1)
    H = plant.inertial_momentum(state)
    assert np.abs(H - H0).max() < 1e-9 * np.abs(H0).max() + 1e-9
    assert plant.mechanical_energy(state).shape == (B,)


def test_per_spacecraft_inertia_batch_must_match():
    from liecontrol.control import ConstantAttitude
    from liecontrol.control.geometric_pd import GeometricPD
    from spacecraft import FlexibleModes, simulate

    Js = _inertias(4)
    plant = Spacecraft(RigidBody(Js), IdealTorqueActuator())
    assert plant.initial_state(np.eye(3)).batch_size == 4  # the body fixes B
    assert plant.initial_state(so3.random(np.random.default_rng(0), 4)).batch_size == 4
    with pytest.raises(ValueError, match=r"^R0: batch size 3 does not match the body's 4"):
        plant.initial_state(np.eye(3)[None].repeat(3, 0))
    with pytest.raises(ValueError, match="^omega0: batch size 2 does not match"):
        plant.initial_state(np.eye(3), omega0=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="^batch: batch size 5 does not match"):
        plant.initial_state(np.eye(3), batch=5)
    shared = Spacecraft(RigidBody(J_SEED), IdealTorqueActuator())
    wrong = shared.initial_state(np.eye(3), batch=2)
    with pytest.raises(ValueError, match=r"^initial_state\.R: batch size 2 does not match"):
        simulate(plant, GeometricPD(J_SEED, 1.0, 1.0), ConstantAttitude(np.eye(3)), wrong, 1.0, 0.1)
    with pytest.raises(ValueError, match=r"^state\.R: batch size 2 does not match"):
        plant.step(wrong, np.zeros((2, 3)), 0.0, 0.1)
    modes = FlexibleModes([[2.0, 0.0, 0.5]], frequencies=[1.2])
    with pytest.raises(ValueError, match=r"^modes: flexible modes need one body inertia shared"):
        Spacecraft(RigidBody(Js), IdealTorqueActuator(), modes=modes)
    Spacecraft(RigidBody(Js[0]), IdealTorqueActuator(), modes=modes)  # shared J: fine
