"""Closed-loop simulator: ZOH sampling, logging, batching, divergence, export, bad input (§5.8)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SEED000_J
from scipy.spatial.transform import Rotation

from liecontrol.charts import quaternion
from liecontrol.control import AttitudeController, AttitudeReference, ConstantAttitude
from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
from liecontrol.lie import so3
from spacecraft import (
    ConstantHarmonicTorque,
    ConstantTorque,
    IdealTorqueActuator,
    RateGyro,
    RigidBody,
    SgcmgActuator,
    SimulationDiverged,
    SimulationResult,
    SingularityRobust,
    Spacecraft,
    StarTracker,
    StarTrackerGyro,
    SumOfDisturbances,
    simulate,
)

J = SEED000_J


def _pd(error="large_angle", omega_n=0.03):
    k_R, k_W = gains_from_bandwidth(J, omega_n, 0.9, error=error, matrix=True)
    return GeometricPD(J, k_R, k_W, error=error)


def _cmg_plant(disturbance=None):
    return Spacecraft(RigidBody(J), SgcmgActuator(steering=SingularityRobust()), disturbance)


class Recording(AttitudeController):
    """Wraps a controller and records the times at which it is sampled."""

    def __init__(self, inner, batched=True):
        self.inner = inner
        self.batched = batched
        self.times: list[float] = []

    def reset(self, t0, batch_size):
        if not self.batched:
            assert batch_size == 1
        self.times = []
        self.inner.reset(t0, batch_size)

    def command(self, t, state, reference):
        if not self.batched:
            assert state.R.shape[0] == 1
        self.times.append(t)
        return self.inner.command(t, state, reference)

    def diagnostics(self):
        return self.inner.diagnostics()


class Constant(AttitudeController):
    """Returns a fixed torque, optionally NaN from time t_nan on (fault injection)."""

    def __init__(self, u, t_nan=np.inf):
        self.u = np.asarray(u, float)
        self.t_nan = t_nan

    def reset(self, t0, batch_size):
        self.B = batch_size

    def command(self, t, state, reference):
        u = np.broadcast_to(self.u, (self.B, 3)).copy()
        if t >= self.t_nan:
            u[:] = np.nan
        return u


class PositiveFeedback(AttitudeController):
    """Destabilising rate feedback u = +k ω (negative damping)."""

    def __init__(self, k):
        self.k = k

    def reset(self, t0, batch_size):
        pass

    def command(self, t, state, reference):
        return self.k * state.omega


def test_zoh_controller_sampled_at_its_period():
    plant = _cmg_plant()
    ctrl = Recording(_pd())
    Rd = so3.exp(np.array([0.0, 0.0, 0.5]))
    res = simulate(
        plant,
        ctrl,
        ConstantAttitude(Rd),
        plant.initial_state(np.eye(3)),
        20.0,
        0.1,
        control_period=0.5,
    )
    np.testing.assert_allclose(ctrl.times, np.arange(0.0, 20.0 + 1e-9, 0.5), atol=1e-12)
    assert res.n_samples == 201 and res.control_period == 0.5
    # u_cmd is piecewise constant on each control period and changes between periods
    blocks = res.u_cmd[:200, 0].reshape(40, 5, 3)
    assert np.all(blocks == blocks[:, :1])
    assert np.all(np.abs(np.diff(blocks[:, 0], axis=0)).max(axis=-1) > 0)
    # ... and equals the controller evaluated on the logged state at the sample times
    check = _pd()
    check.reset(0.0, 1)
    from liecontrol.control import AttitudeState

    for k in (0, 5, 100, 200):
        st = AttitudeState(R=res.R[k], omega=res.omega[k], h=res.actuator["h"][k])
        u = check.command(res.t[k], st, ConstantAttitude(Rd)(res.t[k]))
        np.testing.assert_allclose(res.u_cmd[k], u, rtol=1e-12, atol=1e-12)
    # the actuator is between: delivered torque tracks the command (SR law, far from singular)
    assert np.abs(res.u - res.u_cmd).max() < 0.01 * np.abs(res.u_cmd).max()


def test_logging_layout_and_log_every():
    plant = _cmg_plant(
        SumOfDisturbances({"seed": ConstantHarmonicTorque(), "bias": ConstantTorque([0, 0, 0.1])})
    )
    res = simulate(
        plant,
        _pd(),
        ConstantAttitude(np.eye(3)),
        plant.initial_state(np.eye(3), batch=2),
        2.0,
        0.1,
        log_every=7,
    )
    np.testing.assert_allclose(res.t, [0.0, 0.7, 1.4, 2.0])
    K, B = 4, 2
    assert res.R.shape == (K, B, 3, 3) and res.R_d.shape == (K, B, 3, 3)
    for a in (res.omega, res.omega_d, res.u_cmd, res.u, res.disturbance):
        assert a.shape == (K, B, 3)
    assert res.actuator["delta"].shape == (K, B, 4)
    assert res.actuator["saturated"].dtype == bool
    assert res.controller["e_R"].shape == (K, B, 3)
    assert set(res.disturbance_components) == {"seed", "bias"}
    np.testing.assert_allclose(
        res.disturbance, res.disturbance_components["seed"] + res.disturbance_components["bias"]
    )
    np.testing.assert_allclose(res.disturbance[0, 0], [0.02, 0.08, 0.12])


def test_attitude_error_angle_and_select():
    rng = np.random.default_rng(5)
    B = 4
    plant = _cmg_plant()
    Rd = so3.random(rng, B)
    res = simulate(
        plant, _pd(), ConstantAttitude(Rd), plant.initial_state(so3.random(rng, B)), 1.0, 0.1
    )
    ang = res.attitude_error_angle()
    assert ang.shape == (11, B)
    ref = Rotation.from_matrix((np.swapaxes(res.R_d, -1, -2) @ res.R).reshape(-1, 3, 3)).magnitude()
    np.testing.assert_allclose(ang.ravel(), ref, atol=1e-12)
    one = res.select(2)
    assert one.batch_size == 1
    np.testing.assert_array_equal(one.R[:, 0], res.R[:, 2])
    np.testing.assert_array_equal(one.actuator["delta"][:, 0], res.actuator["delta"][:, 2])
    np.testing.assert_array_equal(res.select(-1).omega[:, 0], res.omega[:, -1])
    with pytest.raises(ValueError, match="^b:"):
        res.select(4)


def test_batched_equals_per_spacecraft_runs():
    """B spacecraft with different initial states and targets in one run == B separate runs."""
    rng = np.random.default_rng(21)
    B = 3
    plant = _cmg_plant(ConstantHarmonicTorque())
    R0 = so3.random(rng, B)
    Rd = so3.random(rng, B)
    w0 = 0.01 * rng.normal(size=(B, 3))
    x0 = plant.actuator.initial_state(B) + 0.1 * rng.normal(size=(B, 4))
    batch = simulate(
        plant,
        _pd(),
        ConstantAttitude(Rd),
        plant.initial_state(R0, w0, x0),
        60.0,
        0.1,
        control_period=0.2,
        log_every=10,
    )
    for b in range(B):
        one = simulate(
            plant,
            _pd(),
            ConstantAttitude(Rd[b]),
            plant.initial_state(R0[b], w0[b], x0[b]),
            60.0,
            0.1,
            control_period=0.2,
            log_every=10,
        )
        sel = batch.select(b)
        for name in ("R", "omega", "u_cmd", "u", "disturbance"):
            np.testing.assert_allclose(getattr(sel, name), getattr(one, name), rtol=0, atol=1e-12)
        np.testing.assert_allclose(sel.actuator["delta"], one.actuator["delta"], rtol=0, atol=1e-12)


def test_unbatched_controller_is_stepped_per_spacecraft():
    rng = np.random.default_rng(4)
    B = 3
    plant = _cmg_plant()
    R0, Rd = so3.random(rng, B), so3.random(rng, B)
    ref = ConstantAttitude(Rd)
    a = simulate(plant, _pd(), ref, plant.initial_state(R0), 5.0, 0.1)
    rec = Recording(_pd(), batched=False)
    b = simulate(plant, rec, ref, plant.initial_state(R0), 5.0, 0.1)
    np.testing.assert_allclose(b.R, a.R, atol=1e-12)
    np.testing.assert_allclose(b.controller["e_R"], a.controller["e_R"], atol=1e-12)


def test_divergence_raises_with_partial_log():
    plant = Spacecraft(RigidBody(np.diag([10.0, 12.0, 14.0])), IdealTorqueActuator())
    state = plant.initial_state(np.eye(3), omega0=[0.1, -0.1, 0.05])
    with pytest.raises(SimulationDiverged) as info:
        simulate(
            plant,
            PositiveFeedback(1e4),
            ConstantAttitude(np.eye(3)),
            state,
            100.0,
            0.1,
            log_every=3,
        )
    err = info.value
    assert isinstance(err, RuntimeError)
    res = err.result
    assert 0.0 < err.time < 100.0
    assert res.n_samples >= 2 and res.t[-1] == pytest.approx(err.time - 0.1)
    assert np.isfinite(res.omega).all() and np.isfinite(res.R).all()
    assert np.all(np.diff(np.linalg.norm(res.omega[:, 0], axis=-1)) > 0)  # it was blowing up


def test_nan_command_is_caught_as_divergence():
    plant = _cmg_plant()
    with pytest.raises(SimulationDiverged) as info:
        simulate(
            plant,
            Constant([0.1, 0.0, 0.0], t_nan=1.0),
            ConstantAttitude(np.eye(3)),
            plant.initial_state(np.eye(3)),
            5.0,
            0.1,
        )
    assert info.value.time == pytest.approx(1.0)
    np.testing.assert_allclose(info.value.result.t, np.arange(10) * 0.1, atol=1e-12)


def test_nan_in_plant_is_caught_as_divergence():
    """A non-finite disturbance torque (a broken model) poisons the state: caught, not returned."""

    def broken(t, R, omega):
        return np.full(omega.shape, np.nan if t > 0.45 else 0.0)

    plant = _cmg_plant(broken)
    with pytest.raises(SimulationDiverged) as info:
        simulate(
            plant,
            _pd(),
            ConstantAttitude(np.eye(3)),
            plant.initial_state(np.eye(3)),
            5.0,
            0.1,
            log_every=100,
        )
    assert info.value.time == pytest.approx(0.5)
    np.testing.assert_allclose(info.value.result.t, [0.0, 0.4], atol=1e-12)


def test_csv_round_trip(tmp_path):
    plant = _cmg_plant(ConstantHarmonicTorque())
    res = simulate(
        plant,
        _pd(),
        ConstantAttitude(so3.exp(np.array([0.3, 0.0, 0.2]))),
        plant.initial_state(np.eye(3), batch=2),
        3.0,
        0.1,
        control_period=0.3,
    )
    path = tmp_path / "run.csv"
    res.to_csv(path, batch_index=1)
    back = SimulationResult.from_csv(path)
    one = res.select(1)
    assert back.dt == res.dt and back.control_period == res.control_period
    np.testing.assert_array_equal(back.t, res.t)
    for name in ("R", "omega", "R_d", "omega_d", "u_cmd", "u", "disturbance"):
        np.testing.assert_array_equal(getattr(back, name), getattr(one, name))
    assert set(back.actuator) == set(one.actuator)
    for k, v in one.actuator.items():
        np.testing.assert_array_equal(back.actuator[k], v)
        assert back.actuator[k].dtype == v.dtype
    for k, v in one.controller.items():
        np.testing.assert_array_equal(back.controller[k], v)
    pd = pytest.importorskip("pandas")
    # an exact parse: pandas ≥ 3.1 parses floats exactly by default and deprecates
    # float_precision; before 3.1 (3.0.3 measured) the default and the python engine are off by
    # an ulp, and "round_trip" is the exact parser
    major, minor = (int(v) for v in pd.__version__.split(".")[:2])
    exact = {} if (major, minor) >= (3, 1) else {"float_precision": "round_trip"}
    df = pd.read_csv(path, comment="#", **exact)
    frame = res.to_dataframe(batch_index=1)
    assert list(df.columns) == list(frame.columns)
    np.testing.assert_array_equal(df.to_numpy(float), frame.to_numpy(float))
    assert {"t", "R[0][2]", "actuator.delta[3]", "controller.Psi", "attitude_error"} <= set(
        df.columns
    )


def test_progress_bar_runs():
    plant = Spacecraft(RigidBody(np.diag([10.0, 12.0, 14.0])), IdealTorqueActuator())
    res = simulate(
        plant,
        Constant([0.0, 0.0, 0.0]),
        ConstantAttitude(np.eye(3)),
        plant.initial_state(np.eye(3)),
        1.0,
        0.1,
        progress=True,
    )
    assert res.n_samples == 11


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"dt": 0.0}, "dt"),
        ({"dt": -0.1}, "dt"),
        ({"dt": np.nan}, "dt"),
        ({"control_period": 0.15}, "control_period"),
        ({"control_period": 0.05}, "control_period"),
        ({"control_period": 0.0}, "control_period"),
        ({"t_final": 0.0}, "t_final"),
        ({"log_every": 0}, "log_every"),
        ({"log_every": 1.5}, "log_every"),
    ],
)
def test_bad_arguments(kwargs, name):
    plant = _cmg_plant()
    args = dict(t_final=1.0, dt=0.1)
    args.update(kwargs)
    with pytest.raises(ValueError, match=f"^{name}:"):
        simulate(plant, _pd(), ConstantAttitude(np.eye(3)), plant.initial_state(np.eye(3)), **args)


def test_bad_objects_and_shapes():
    plant = _cmg_plant()
    ref = ConstantAttitude(np.eye(3))
    s0 = plant.initial_state(np.eye(3))
    with pytest.raises(ValueError, match="^plant:"):
        simulate(None, _pd(), ref, s0, 1.0, 0.1)
    with pytest.raises(ValueError, match="^controller:"):
        simulate(plant, object(), ref, s0, 1.0, 0.1)
    with pytest.raises(ValueError, match="^reference:"):
        simulate(plant, _pd(), 3, s0, 1.0, 0.1)
    with pytest.raises(ValueError, match="^initial_state"):
        simulate(plant, _pd(), ref, (np.eye(3), np.zeros(3)), 1.0, 0.1)
    with pytest.raises(ValueError, match="^omega:"):  # a PlantState checks its own structure
        type(s0)(R=s0.R, omega=np.zeros((1, 4)), x_act=s0.x_act)
    bad = type(s0)(R=s0.R, omega=s0.omega, x_act=np.zeros((1, 3)))  # fits no SGCMG plant
    with pytest.raises(ValueError, match="^initial_state.x_act:"):
        simulate(plant, _pd(), ref, bad, 1.0, 0.1)

    class WrongShape(Constant):
        def command(self, t, state, reference):
            return np.zeros(3)

    with pytest.raises(ValueError, match="^controller:"):
        simulate(plant, WrongShape(np.zeros(3)), ref, s0, 1.0, 0.1)
    # a control period that is an integer multiple up to rounding is accepted
    res = simulate(plant, _pd(), ref, s0, 1.0, 0.1, control_period=0.30000000000000004)
    assert res.control_period == pytest.approx(0.3)


def test_reference_with_batched_arrays_is_logged():
    rng = np.random.default_rng(8)
    plant = _cmg_plant()
    Rd = so3.random(rng, 2)

    def ref(t):
        return AttitudeReference(R_d=Rd, omega_d=np.zeros((2, 3)), omega_dot_d=np.zeros((2, 3)))

    res = simulate(plant, _pd(), ref, plant.initial_state(np.eye(3), batch=2), 0.5, 0.1)
    np.testing.assert_array_equal(res.R_d[3], Rd)


# --------------------------------------------------------------- sensors in the loop (§5.7)
class RecordingSensor:
    """Noise-free sensor that records its sample times and returns ω (B, 3)."""

    def __init__(self, period):
        self.period = period
        self.times: list[float] = []

    def measure(self, t, R, omega, rng):
        self.times.append(t)
        return np.array(omega, copy=True)


def _sensor_plant():
    return Spacecraft(RigidBody(J), IdealTorqueActuator(), ConstantTorque([0.5, -0.3, 0.2]))


def test_multirate_sensors_sampled_and_held():
    """Each sensor is sampled at t0 + j·period on the true state and held (ZOH) in between."""
    plant = _sensor_plant()
    fast, slow = RecordingSensor(0.2), RecordingSensor(0.5)
    tracker = StarTracker(period=0.3, output="quaternion")
    res = simulate(
        plant,
        _pd(),
        ConstantAttitude(so3.exp(np.array([0.2, -0.1, 0.3]))),
        plant.initial_state(np.eye(3), omega0=[0.01, 0.02, -0.01], batch=2),
        3.0,
        0.1,
        t0=1.0,
        control_period=0.2,
        sensors={"fast": fast, "slow": slow, "tracker": tracker},
        rng=np.random.default_rng(0),
    )
    np.testing.assert_allclose(fast.times, 1.0 + 0.2 * np.arange(11), atol=1e-12)
    np.testing.assert_allclose(slow.times, 1.0 + 0.5 * np.arange(5), atol=1e-12)
    assert res.sensors["fast"].shape == (res.n_samples, 2, 3)
    assert res.sensors["tracker"].shape == (res.n_samples, 2, 4)
    k = np.arange(res.n_samples)  # log every step: row k is t = 1 + 0.1 k
    for name, every in (("fast", 2), ("slow", 5)):
        last = (k // every) * every  # the row of the most recent sample
        np.testing.assert_array_equal(res.sensors[name], res.omega[last])
    q_true = quaternion.from_matrix(res.R[(k // 3) * 3])
    np.testing.assert_allclose(res.sensors["tracker"], q_true, atol=1e-12)
    assert not res.estimate  # no measurement hook: the controller saw the truth


def test_star_tracker_gyro_hook_with_perfect_sensors_equals_truth():
    """Noise-free sensors at the control rate: the measured loop is the true-state loop."""
    plant = _sensor_plant()
    s0 = plant.initial_state(np.eye(3), omega0=[[0.0, 0.0, 0.0], [0.01, -0.02, 0.005]])
    args = (ConstantAttitude(so3.exp(np.array([0.4, 0.1, -0.2]))), s0)
    truth = simulate(plant, _pd(), *args, 20.0, 0.1, control_period=0.2)
    for output in ("quaternion", "matrix", "euler"):
        sensed = simulate(
            plant,
            _pd(),
            *args,
            20.0,
            0.1,
            control_period=0.2,
            sensors={
                "star_tracker": StarTracker(output=output, period=0.2),
                "gyro": RateGyro(period=0.2),
            },
            measurement=StarTrackerGyro(),
            rng=np.random.default_rng(1),
        )
        np.testing.assert_allclose(sensed.R, truth.R, atol=1e-10)
        np.testing.assert_allclose(sensed.u_cmd, truth.u_cmd, rtol=1e-8, atol=1e-10)
        rows = np.arange(0, sensed.n_samples, 2)
        np.testing.assert_allclose(sensed.estimate["R"][rows], truth.R[rows], atol=1e-10)
        np.testing.assert_allclose(sensed.estimate["omega"][rows], truth.omega[rows], atol=1e-15)


def test_star_tracker_gyro_reads_each_output_form_for_a_batch_of_three():
    """B = 3: Euler-angle rows (3, 3) are three attitudes, not one matrix; a quaternion batch
    (3, 4) and matrices (3, 3, 3) likewise read as the sensor wrote them (the form is decided
    by rank against the state's)."""
    from liecontrol.charts import euler
    from liecontrol.control.base import AttitudeState

    rng = np.random.default_rng(7)
    R = so3.exp(rng.normal(size=(3, 3)))
    truth = AttitudeState(R, rng.normal(size=(3, 3)) * 0.01)
    hook = StarTrackerGyro()
    for y in (R, quaternion.from_matrix(R), euler.from_matrix(R, "ZYX")):
        est = hook(0.0, {"star_tracker": y, "gyro": truth.omega}, truth)
        np.testing.assert_allclose(est.R, R, atol=1e-12)
    with pytest.raises(ValueError, match=r"^outputs: 'star_tracker' has shape \(3, 5\)"):
        hook(0.0, {"star_tracker": np.zeros((3, 5)), "gyro": truth.omega}, truth)


def test_noisy_sensors_are_seeded_and_felt_by_the_loop():
    plant = _sensor_plant()
    ref = ConstantAttitude(np.eye(3))
    s0 = plant.initial_state(np.eye(3), batch=3)

    def run(seed):
        sensors = {
            "star_tracker": StarTracker(noise_std=1e-4, period=0.5),
            "gyro": RateGyro(white_std=1e-5, bias_rw_std=1e-7, period=0.1),
        }
        return simulate(
            plant,
            _pd(omega_n=0.1),
            ref,
            s0,
            60.0,
            0.1,
            sensors=sensors,
            measurement=StarTrackerGyro(),
            rng=np.random.default_rng(seed),
            log_every=10,
        )

    a, b, c = run(5), run(5), run(6)
    np.testing.assert_array_equal(a.R, b.R)
    np.testing.assert_array_equal(a.sensors["gyro"], b.sensors["gyro"])
    assert np.abs(a.R - c.R).max() > 0
    # spacecraft in one batch draw different noise
    assert np.abs(a.sensors["gyro"][:, 0] - a.sensors["gyro"][:, 1]).max() > 0
    # the loop settles to the noise level (PD under a constant torque keeps a small offset)
    err = a.attitude_error_angle()[-20:]
    assert 1e-6 < err.min() and err.max() < 0.02
    # what the controller saw differs from the truth by the sensor noise
    diff = so3.angle(np.swapaxes(a.estimate["R"], -1, -2) @ a.R)
    assert 1e-6 < np.median(diff) < 1e-3


def test_sensor_arguments_validated():
    plant = _sensor_plant()
    base = (plant, _pd(), ConstantAttitude(np.eye(3)), plant.initial_state(np.eye(3)), 1.0, 0.1)
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="^sensors: 'gyro' period 0.15"):
        simulate(*base, sensors={"gyro": RateGyro(period=0.15)}, rng=rng)
    with pytest.raises(ValueError, match="^sensors:"):
        simulate(*base, sensors={"gyro": RateGyro(period=0.05)}, rng=rng)
    with pytest.raises(ValueError, match="^sensors:"):
        simulate(*base, sensors={"bad name": StarTracker(period=0.1)}, rng=rng)
    with pytest.raises(ValueError, match="^sensors:"):
        simulate(*base, sensors={"x": object()}, rng=rng)
    with pytest.raises(ValueError, match="^sensors:"):
        simulate(*base, sensors=[StarTracker()], rng=rng)
    with pytest.raises(ValueError, match="^rng:"):
        simulate(*base, sensors={"st": StarTracker(period=0.1)})
    with pytest.raises(ValueError, match="^rng:"):
        simulate(*base, rng=42)
    with pytest.raises(ValueError, match="^measurement:"):
        simulate(
            *base,
            sensors={"star_tracker": StarTracker(period=0.1)},
            rng=rng,
            measurement=StarTrackerGyro(),
        )
    with pytest.raises(ValueError, match="^measurement:"):
        simulate(*base, measurement="gyro")
    # a period equal to an integer multiple up to rounding is accepted
    res = simulate(*base, sensors={"g": RateGyro(period=0.30000000000000004)}, rng=rng)
    assert res.sensors["g"].shape == (11, 1, 3)


def test_unstable_measured_loop_diverges_with_sensor_log():
    """A deliberately unstable loop closed through the sensors raises SimulationDiverged with
    the partial log, sensor and estimate columns included."""
    plant = Spacecraft(RigidBody(np.diag([10.0, 12.0, 14.0])), IdealTorqueActuator())
    with pytest.raises(SimulationDiverged) as info:
        simulate(
            plant,
            PositiveFeedback(1e4),
            ConstantAttitude(np.eye(3)),
            plant.initial_state(np.eye(3), omega0=[0.1, -0.1, 0.05]),
            100.0,
            0.1,
            sensors={"star_tracker": StarTracker(period=0.2), "gyro": RateGyro(period=0.1)},
            measurement=StarTrackerGyro(),
            rng=np.random.default_rng(0),
        )
    res = info.value.result
    assert 0.0 < info.value.time < 100.0
    assert res.sensors["gyro"].shape[0] == res.n_samples >= 2
    assert np.isfinite(res.sensors["gyro"]).all() and np.isfinite(res.estimate["omega"]).all()


def test_csv_round_trip_with_sensors_and_estimate(tmp_path):
    plant = _sensor_plant()
    res = simulate(
        plant,
        _pd(),
        ConstantAttitude(np.eye(3)),
        plant.initial_state(np.eye(3)),
        1.0,
        0.1,
        sensors={
            "star_tracker": StarTracker(noise_std=1e-3, period=0.2),
            "gyro": RateGyro(white_std=1e-4, period=0.1),
        },
        measurement=StarTrackerGyro(),
        rng=np.random.default_rng(3),
    )
    path = tmp_path / "sensed.csv"
    res.to_csv(path)
    back = SimulationResult.from_csv(path)
    for k in ("star_tracker", "gyro"):
        np.testing.assert_array_equal(back.sensors[k], res.sensors[k])
    for k in ("R", "omega"):
        np.testing.assert_array_equal(back.estimate[k], res.estimate[k])
    assert "sensor.gyro[2]" in res.columns() and "estimate.R[2][2]" in res.columns()


def test_controller_sees_actuator_state_batched_and_per_spacecraft():
    plant = _cmg_plant()
    seen = []

    class Spy(Recording):
        def command(self, t, state, reference):
            seen.append(np.array(state.actuator_state, copy=True))
            return super().command(t, state, reference)

    for batched in (True, False):
        seen.clear()
        res = simulate(
            plant,
            Spy(_pd(), batched=batched),
            ConstantAttitude(so3.exp(np.array([0.2, 0.0, 0.1]))),
            plant.initial_state(np.eye(3), batch=2),
            1.0,
            0.1,
            control_period=0.5,
        )
        got = np.stack(seen) if batched else np.stack(seen).reshape(-1, 2, 4)
        np.testing.assert_array_equal(got, res.actuator["delta"][[0, 5, 10]])
