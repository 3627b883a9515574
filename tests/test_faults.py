"""Actuator faults (spacecraft.faults): each kind applied at its time, reconfigured steering,
what remains controllable, bad input."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liecontrol.control.base import AttitudeReference
from liecontrol.control.geometric_pd import GeometricPD
from spacecraft.actuators import (
    FirstOrderServo,
    IdealTorqueActuator,
    ReactionWheelAssembly,
    SgcmgActuator,
)
from spacecraft.faults import (
    ActuatorBias,
    EfficiencyLoss,
    FaultyActuator,
    GimbalStuck,
    ReconfiguredSteering,
    WheelFailed,
    check_faults,
    fault_units,
    make_fault,
    reconfigurability,
    reduced_singularity_measure,
    singular_fraction,
    with_faults,
)
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.sgcmg import SgcmgPyramid
from spacecraft.simulator import simulate
from spacecraft.steering import PseudoInverse, SingularityRobust

J = np.array([[1500.0, 30.0, -10.0], [30.0, 1200.0, 20.0], [-10.0, 20.0, 1000.0]])
R0 = Rotation.from_rotvec([0.4, -0.3, 0.25]).as_matrix()
T_FAULT = 6.0  # on the 0.1 s grid: the fault acts from the step starting at 6.0 s
DT = 0.1


def _ref(t: float) -> AttitudeReference:
    return AttitudeReference.regulation(np.eye(3))


def _run(actuator, t_final: float = 12.0):
    plant = Spacecraft(RigidBody(J), actuator)
    ctrl = GeometricPD(J, 40.0, 300.0)
    return simulate(plant, ctrl, _ref, plant.initial_state(R0), t_final=t_final, dt=DT)


def _split(res):
    """Index of the first logged sample at which the fault acts."""
    k = int(np.flatnonzero(res.t >= T_FAULT - 1e-9)[0])
    assert abs(res.t[k] - T_FAULT) < 1e-9
    return k


def _same_before(faulty, healthy, k):
    # bitwise: the wrapper passes the command through untouched before the fault time
    for a, b in ((faulty.R, healthy.R), (faulty.omega, healthy.omega), (faulty.u, healthy.u)):
        assert np.array_equal(a[: k + 1][:-1], b[: k + 1][:-1])
    assert np.array_equal(faulty.R[k], healthy.R[k])
    # after it the runs differ
    assert not np.array_equal(faulty.omega[-1], healthy.omega[-1])


def _cmg(**kw):
    return SgcmgActuator(steering=SingularityRobust(), **kw)


def test_gimbal_stuck_at_its_time():
    f = GimbalStuck(2, T_FAULT)
    faulty = _run(FaultyActuator(_cmg(), [f]))
    healthy = _run(FaultyActuator(_cmg(), []))
    k = _split(faulty)
    _same_before(faulty, healthy, k)
    a = faulty.actuator
    assert not a["fault_active"][:k].any() and a["fault_active"][k:].all()
    assert np.all(a["delta_dot"][:k, 0, 2] != 0.0)
    assert np.all(a["delta_dot"][k:, 0, 2] == 0.0)
    assert np.all(a["delta"][k:, 0, 2] == a["delta"][k, 0, 2])  # the angle stays exactly
    # the other gimbals keep turning
    assert np.all(np.abs(a["delta_dot"][k:-1, 0, [0, 1, 3]]).max(axis=0) > 1e-4)
    # the remaining-gimbal measure switches to |det A_r|/h0³ at the fault
    cl = SgcmgPyramid()
    m_r = reduced_singularity_measure(cl, a["delta"][k:, 0], [2])
    np.testing.assert_allclose(a["singularity_remaining"][k:, 0], m_r, rtol=1e-12)
    np.testing.assert_allclose(a["singularity_remaining"][:k], a["singularity"][:k], rtol=0)


def test_healthy_wrapper_matches_the_bare_actuator():
    # the empty-fault wrapper runs the generic plant route; the bare actuator may run a
    # compiled one: equal to round-off
    bare = _run(_cmg())
    wrapped = _run(FaultyActuator(_cmg(), []))
    # an empty fault list is documented as "no faults": accepted, no fault columns
    assert wrapped.actuator["fault_active"].shape == (len(wrapped.t), 1, 0)
    np.testing.assert_allclose(wrapped.omega, bare.omega, rtol=0, atol=1e-12)
    np.testing.assert_allclose(wrapped.R, bare.R, rtol=0, atol=1e-12)


def test_gimbal_stuck_with_a_servo_stops_at_once():
    f = GimbalStuck(0, T_FAULT)
    res = _run(FaultyActuator(_cmg(servo=FirstOrderServo(0.5)), [f]))
    k = _split(res)
    d = res.actuator["delta"][:, 0, 0]
    assert np.all(d[k:] == d[k])
    assert np.all(res.actuator["delta_dot"][k:, 0, 0] == 0.0)


def test_stuck_gimbal_conserves_total_momentum():
    # the stuck rotor keeps its momentum: R (Jω + h) is conserved (no external torque)
    res = _run(FaultyActuator(_cmg(), [GimbalStuck(1, T_FAULT)]), t_final=20.0)
    H = np.einsum("kij,kj->ki", res.R[:, 0], res.omega[:, 0] @ J.T + res.actuator["h"][:, 0])
    np.testing.assert_allclose(H, H[:1].repeat(len(H), 0), rtol=0, atol=1e-8 * 300)


def test_wheel_failed_coasts():
    rw = ReactionWheelAssembly.pyramid(wheel_inertia=0.1, max_torque=1.0)
    faulty = _run(FaultyActuator(rw, [WheelFailed(3, T_FAULT)]))
    healthy = _run(FaultyActuator(rw, []))
    k = _split(faulty)
    _same_before(faulty, healthy, k)
    a = faulty.actuator
    assert np.all(a["wheel_torque"][k:, 0, 3] == 0.0)
    assert np.abs(a["wheel_torque"][:k, 0, 3]).max() > 1e-3
    w = a["wheel_speed"][:, 0, 3]
    assert np.all(w[k:] == w[k])  # coasting at the speed it had


@pytest.mark.parametrize("eta", [0.0, 0.3, 1.0])
def test_efficiency_on_an_ideal_axis(eta):
    f = EfficiencyLoss(1, T_FAULT, eta)
    if eta == 0.0:  # a dead axis: underactuated, refused unless allowed (then a warning)
        with pytest.warns(UserWarning, match="underactuated"):
            act = FaultyActuator(IdealTorqueActuator(), [f], allow_underactuated=True)
    else:
        act = FaultyActuator(IdealTorqueActuator(), [f])
    res = _run(act)
    k = _split(res)
    np.testing.assert_array_equal(res.u[:k], res.u_cmd[:k])
    np.testing.assert_array_equal(res.u[k:, :, [0, 2]], res.u_cmd[k:, :, [0, 2]])
    np.testing.assert_allclose(res.u[k:, :, 1], eta * res.u_cmd[k:, :, 1], rtol=1e-15)


def test_bias_on_an_ideal_axis_and_a_wheel():
    res = _run(FaultyActuator(IdealTorqueActuator(), [ActuatorBias(0, T_FAULT, 0.05)]))
    k = _split(res)
    np.testing.assert_array_equal(res.u[:k], res.u_cmd[:k])
    np.testing.assert_allclose(res.u[k:, :, 0], res.u_cmd[k:, :, 0] + 0.05, rtol=0, atol=1e-15)
    rw = ReactionWheelAssembly.pyramid(wheel_inertia=0.1, max_torque=5.0)
    res = _run(FaultyActuator(rw, [ActuatorBias(1, T_FAULT, 0.02), EfficiencyLoss(2, 0.0, 0.5)]))
    a = res.actuator
    k = _split(res)
    # efficiency from t = 0 on wheel 2: delivered = 0.5 × the distributed command (no clipping)
    assert np.abs(a["wheel_torque_cmd"][:, 0, 2]).max() < 5.0
    np.testing.assert_allclose(a["wheel_torque"][:, 0, 2], 0.5 * a["wheel_torque_cmd"][:, 0, 2])
    np.testing.assert_allclose(
        a["wheel_torque"][k:, 0, 1], a["wheel_torque_cmd"][k:, 0, 1] + 0.02, atol=1e-15
    )
    np.testing.assert_array_equal(a["wheel_torque"][:k, 0, 1], a["wheel_torque_cmd"][:k, 0, 1])


def test_cmg_efficiency_and_bias_scale_the_gimbal_rate():
    inner = _cmg()
    fa = FaultyActuator(inner, [EfficiencyLoss(0, 1.0, 0.25), ActuatorBias(3, 1.0, 0.01)])
    rng = np.random.default_rng(3)
    u = rng.normal(size=(5, 3))
    w = rng.normal(size=(5, 3)) * 0.01
    x = rng.uniform(-2, 2, size=(5, 4))
    ref = inner.command(u, w, x, 2.0).delta_dot
    held = fa.command(u, w, x, 2.0)
    dd = held.inner.delta_dot
    np.testing.assert_allclose(dd[:, 0], 0.25 * ref[:, 0], rtol=1e-15)
    np.testing.assert_allclose(dd[:, 3], ref[:, 3] + 0.01, rtol=1e-15)
    np.testing.assert_array_equal(dd[:, 1:3], ref[:, 1:3])
    before = fa.command(u, w, x, 0.5)
    np.testing.assert_array_equal(before.inner.delta_dot, ref)
    # the bus torque follows the modified rates: −A δ̇ − ω × h (independent route)
    h, A = inner.cluster.momentum_and_jacobian(x)
    tau = -(A @ dd[..., None])[..., 0] - np.cross(w, h)
    np.testing.assert_allclose(fa.body_torque(w, x, held), tau, rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------------- reconfiguration
def test_reconfigured_steering_realises_the_torque():
    cl = SgcmgPyramid()
    law = ReconfiguredSteering(PseudoInverse(), (GimbalStuck(1, 0.0),), reduced_law=PseudoInverse())
    rng = np.random.default_rng(0)
    delta = rng.uniform(-math.pi, math.pi, size=(400, 4))
    A = cl.jacobian(delta)
    m_r = reduced_singularity_measure(cl, delta, [1])
    ok = m_r > 0.2  # where the 3 remaining gimbals span the torque space well
    assert ok.sum() > 100
    hdot = rng.normal(size=(400, 3)) * 50.0
    dd = law(A[ok], hdot[ok], t=1.0)
    assert np.all(dd[:, 1] == 0.0)
    np.testing.assert_allclose((A[ok] @ dd[..., None])[..., 0], hdot[ok], rtol=0, atol=1e-6)
    # the un-reconfigured pseudo-inverse keeps commanding gimbal 1: with it stuck the torque
    # misses by the stuck column's share
    dd0 = PseudoInverse()(A[ok], hdot[ok])
    dd0[:, 1] = 0.0
    miss = np.linalg.norm((A[ok] @ dd0[..., None])[..., 0] - hdot[ok], axis=-1)
    assert np.median(miss / np.linalg.norm(hdot[ok], axis=-1)) > 0.05


def test_reconfigured_steering_compensates_known_efficiency_and_bias():
    cl = SgcmgPyramid()
    faults = (EfficiencyLoss(0, 0.0, 0.4), ActuatorBias(2, 0.0, 0.003))
    law = ReconfiguredSteering(PseudoInverse(), faults, reduced_law=PseudoInverse())
    delta = np.array([[0.3, -0.8, 1.1, 0.2]])
    A = cl.jacobian(delta)
    hd = np.array([[3.0, -2.0, 1.0]])
    cmd = law(A, hd, t=0.0)
    delivered = cmd.copy()
    delivered[:, 0] *= 0.4
    delivered[:, 2] += 0.003
    np.testing.assert_allclose((A @ delivered[..., None])[..., 0], hd, atol=1e-6)


def test_reconfigured_steering_is_the_nominal_law_before_the_fault():
    cl = SgcmgPyramid()
    law = ReconfiguredSteering(SingularityRobust(), (GimbalStuck(1, 5.0),))
    delta = np.array([[0.3, -0.8, 1.1, 0.2]])
    A = cl.jacobian(delta)
    hd = np.array([[3.0, -2.0, 1.0]])
    np.testing.assert_array_equal(law(A, hd, t=4.9), SingularityRobust()(A, hd, t=4.9))
    assert not np.array_equal(law(A, hd, t=5.0), SingularityRobust()(A, hd, t=5.0))


def test_closed_loop_with_reconfiguration_delivers_the_commanded_torque():
    plant = Spacecraft(RigidBody(J), _cmg())
    faulty = with_faults(plant, [GimbalStuck(2, T_FAULT)])
    assert isinstance(faulty.actuator.inner.steering, ReconfiguredSteering)
    plain = with_faults(plant, [GimbalStuck(2, T_FAULT)], reconfigure=False)
    errs = []
    for p in (faulty, plain):
        res = simulate(p, GeometricPD(J, 40.0, 300.0), _ref, p.initial_state(R0), 12.0, DT)
        k = _split(res)
        e = np.linalg.norm(res.u[k:] - res.u_cmd[k:], axis=-1)
        errs.append(e.max() / np.linalg.norm(res.u_cmd[k:], axis=-1).max())
    assert errs[0] < 0.01 < 0.05 < errs[1], errs  # SR damping: a small residual


def test_wheels_reconfigure_over_the_healthy_three():
    rw = ReactionWheelAssembly.pyramid(wheel_inertia=0.1, max_torque=5.0)
    plant = with_faults(Spacecraft(RigidBody(J), rw), [WheelFailed(0, 0.0)])
    res = simulate(plant, GeometricPD(J, 4.0, 30.0), _ref, plant.initial_state(R0), 5.0, DT)
    assert np.all(res.actuator["wheel_torque"][:, 0, 0] == 0.0)
    # ω × h is fed forward by the assembly, so the delivered torque is the command
    np.testing.assert_allclose(res.u, res.u_cmd, rtol=0, atol=1e-9)


def test_what_remains_controllable():
    cmg = _cmg()
    r = reconfigurability(cmg, [GimbalStuck(0, 1.0)])
    assert r.three_axis and r.remaining == (1, 2, 3) and "singular" in r.note
    r2 = reconfigurability(cmg, [GimbalStuck(0, 1.0), GimbalStuck(3, 2.0)])
    assert not r2.three_axis and r2.rank == 2 and "underactuated" in r2.note
    rw = ReactionWheelAssembly.pyramid()
    assert reconfigurability(rw, [WheelFailed(1, 0.0)]).three_axis
    ortho = ReactionWheelAssembly.orthogonal()
    assert not reconfigurability(ortho, [WheelFailed(1, 0.0)]).three_axis
    with pytest.raises(ValueError, match="^faults: only 2 of 3 wheels"):
        FaultyActuator(ortho, [WheelFailed(1, 0.0)])
    with pytest.warns(UserWarning, match="underactuated"):
        FaultyActuator(ortho, [WheelFailed(1, 0.0)], allow_underactuated=True)
    with pytest.raises(ValueError, match="^faults: only 2 of 4 gimbals"):
        ReconfiguredSteering(SingularityRobust(), (GimbalStuck(0, 1.0), GimbalStuck(1, 1.0)))
    assert fault_units([GimbalStuck(0, 1.0), EfficiencyLoss(2, 3.0, 0.0)], 2.0, 4) == (1, 2, 3)


def test_reduced_cluster_is_singular_more_often():
    cl = SgcmgPyramid()
    rng = np.random.default_rng(1)
    healthy = singular_fraction(cl, (), rng=rng)
    reduced = singular_fraction(cl, (1,), rng=np.random.default_rng(1))
    assert reduced > 5 * healthy
    # m_r = |det A_r| / h0³ for three gimbals (independent route)
    delta = rng.uniform(-3, 3, size=(50, 4))
    A = cl.jacobian(delta)[..., [0, 2, 3]] / cl.h0
    np.testing.assert_allclose(
        reduced_singularity_measure(cl, delta, [1]), np.abs(np.linalg.det(A)), atol=1e-12
    )
    # no gimbal lost: the cluster's own measure
    np.testing.assert_allclose(
        reduced_singularity_measure(cl, delta, []), cl.singularity_measure(delta), atol=1e-12
    )


# ---------------------------------------------------------------------------------- bad input
def test_bad_input():
    with pytest.raises(ValueError, match="^kind: unknown fault kind"):
        make_fault("gimbal-melted", 0, 1.0)
    with pytest.raises(ValueError, match="^efficiency: must lie in"):
        make_fault("actuator-efficiency", 0, 1.0, efficiency=1.5)
    with pytest.raises(ValueError, match="^efficiency: required"):
        make_fault("actuator-efficiency", 0, 1.0)
    with pytest.raises(ValueError, match="^bias: does not apply"):
        make_fault("wheel-failed", 0, 1.0, bias=0.1)
    with pytest.raises(ValueError, match="^time: must be >= 0"):
        GimbalStuck(0, -1.0)
    with pytest.raises(ValueError, match="^unit"):
        GimbalStuck(-1, 1.0)
    with pytest.raises(ValueError, match=r"^faults\[0\]\.unit: unit 4 does not exist"):
        FaultyActuator(_cmg(), [GimbalStuck(4, 1.0)])
    with pytest.raises(ValueError, match=r"^faults\[1\]\.kind: 'wheel-failed' does not apply"):
        FaultyActuator(_cmg(), [GimbalStuck(0, 1.0), WheelFailed(0, 1.0)])
    with pytest.raises(ValueError, match=r"^faults\[0\]\.time: 700.0 s is outside the run"):
        check_faults([GimbalStuck(0, 700.0)], "sgcmg", 4, duration=600.0)
    with pytest.raises(TypeError, match="^ActuatorFault: abstract"):
        from spacecraft.faults import ActuatorFault

        ActuatorFault(0, 1.0)
    with pytest.raises(ValueError, match="^inner: faults apply to"):
        FaultyActuator(object(), [])
    with pytest.raises(ValueError, match="^reconfigure: applies to reaction wheels"):
        FaultyActuator(_cmg(), [], reconfigure=True)
    with pytest.raises(ValueError, match="^failed: gimbal 5 does not exist"):
        reduced_singularity_measure(SgcmgPyramid(), np.zeros(4), [5])
    with pytest.raises(ValueError, match="^plant: expected a Spacecraft"):
        with_faults(_cmg(), [])
    f = [GimbalStuck(0, 1.0)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        FaultyActuator(_cmg(), f)
    assert f == [GimbalStuck(0, 1.0)]  # the user's list is not modified
    assert make_fault("actuator-bias", 1, 2.0, bias=0.1).as_dict() == {
        "kind": "actuator-bias",
        "unit": 1,
        "time": 2.0,
        "bias": 0.1,
    }


def test_validated_command_and_more_bad_input():
    fa = FaultyActuator(_cmg(), [GimbalStuck(0, 0.0)])
    with pytest.raises(ValueError, match="^u_cmd: expected shape"):
        fa.command(np.zeros(3), np.zeros((1, 3)), np.zeros((1, 4)), 1.0)
    held = fa.command(np.ones((1, 3)), np.zeros((1, 3)), np.zeros((1, 4)), 1.0)
    assert held.inner.delta_dot[0, 0] == 0.0 and held.flags.tolist() == [[True]]
    with pytest.raises(ValueError, match="^n_units: at most"):
        fault_units([], 0.0, 10**9)
    with pytest.raises(ValueError, match="^t:"):
        fault_units([], float("nan"), 4)
    with pytest.raises(ValueError, match="^duration:"):
        check_faults([], "sgcmg", 4, duration=-1.0)
    with pytest.raises(ValueError, match="^failed: a gimbal is listed twice"):
        reduced_singularity_measure(SgcmgPyramid(), np.zeros(4), [1, 1])


# ------------------------------------------------------------------------ benchmark plumbing
def test_faults_in_scenarios_files_and_the_runner():
    from benchmarks.fault_scenarios import fault_scenarios
    from benchmarks.metrics import judge
    from benchmarks.runner import run_suite
    from benchmarks.scenario_files import (
        ScenarioFileError,
        scenario_from_dict,
        scenario_to_dict,
        scenarios_from_dict,
    )
    from benchmarks.scenarios import rest_to_rest

    table = {
        "name": "x",
        "duration": 200.0,
        "fault": [
            {"kind": "cmg-gimbal-stuck", "unit": 2, "time": 100.0},
            {"kind": "actuator-efficiency", "unit": 1, "time": 50.0, "efficiency": 0.5},
        ],
    }
    sc = scenarios_from_dict({"scenario": [table]})[0]
    assert sc.faults == (GimbalStuck(2, 100.0), EfficiencyLoss(1, 50.0, 0.5))
    assert scenario_from_dict(scenario_to_dict(sc)) == sc
    for key, value, msg in (
        ("unit", 7, r"fault\[1\]\.unit: unit 7 does not exist"),
        ("time", 300.0, r"fault\[1\]\.time: 300.0 s is outside the run"),
        ("efficiency", 2.0, r"fault\[1\]\.efficiency: must lie in \[0, 1\]"),
        ("kind", "melted", r"fault\[1\]\.kind: unknown fault kind"),
    ):
        bad = {**table, "fault": [table["fault"][0], {**table["fault"][1], key: value}]}
        with pytest.raises(ScenarioFileError, match=msg):
            scenarios_from_dict({"scenario": [bad]})
    # the verdict flag (informational) and the shortened horizon
    assert judge(sc, {"steady_error_max_deg": 0.0})[1][-1] == "fault-injected"
    assert sc.with_duration(60.0).faults == (EfficiencyLoss(1, 50.0, 0.5),)
    assert len(fault_scenarios()) == 8
    # the runner injects the fault: a 40 s slew whose gimbal 1 sticks at 20 s
    run = rest_to_rest(30.0, name="stuck", duration=40.0, faults=(GimbalStuck(1, 20.0),))
    res = run_suite([run], ["geometric-pd-large-angle"], jobs=1, progress=False)
    o = res.outcome("stuck", "geometric-pd-large-angle")
    assert o.status == "ok" and "fault-injected" in o.flags
