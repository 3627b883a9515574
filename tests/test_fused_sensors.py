"""Sensors and the measurement hook in the compiled closed loop (spacecraft._fused_sensors).

- star tracker + rate gyro (noise, bias walk, scale factor, misalignment, bandwidth,
  quantisation), latency, scheduled and random outages, with and without the
  ``StarTrackerGyro`` hook, over a batch with ``log_every > 1`` and ``control_period > dt``, on
  the SGCMG pyramid, the full CMG model and the ideal actuator: the fused loop equals the
  Python loop to 1e-12 (in fact bit for bit: the same kernels on the same draws), logs
  included; so do two threads and one;
- the generator ends in the same state, the sensors end in the same state (gyro bias, a
  ``TimedSensor``'s history, held output and ``valid``), and a second run with the same seed
  gives the same result;
- configurations without a compiled kernel (a user's sensor, a subclass, a ``TwoVectorAttitude``
  with a time-varying reference, another hook) take the Python loop, say so in one log line,
  and give the same results as the forced Python loop;
- the inputs (initial state, reference) are never mutated.
"""

from __future__ import annotations

import copy
import logging

import numpy as np
import pytest

from liecontrol._jit import JIT_ENABLED
from liecontrol.control import GeometricPD
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import (
    IdealTorqueActuator,
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
)
from spacecraft import simulator as simulator_module
from spacecraft._fused import fused_supported
from spacecraft.sensors import RateGyro, StarTracker, TimedSensor, TwoVectorAttitude
from spacecraft.simulator import StarTrackerGyro, simulate

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the fused loop needs numba")

J = np.array([[150.0, 3.0, -1.0], [3.0, 65.0, 2.0], [-1.0, 2.0, 111.0]])


def _python_loop(*args, **kwargs):
    """``simulate`` forced through the Python loop."""
    real = simulator_module.fused_supported
    simulator_module.fused_supported = lambda *a, **k: None
    try:
        return simulate(*args, **kwargs)
    finally:
        simulator_module.fused_supported = real


def _fused(*args, **kwargs):
    """``simulate`` that must run (and finish) in the fused loop."""
    ran = []
    names = ("run_fused", "run_fused_wheels")  # the momentum/full CMG models' loop, the wheels'
    real = {name: getattr(simulator_module, name) for name in names}

    def spying(fn):
        def spy(*a, **k):
            out = fn(*a, **k)
            ran.append(out is not None)
            return out

        return spy

    for name in names:
        setattr(simulator_module, name, spying(real[name]))
    try:
        res = simulate(*args, **kwargs)
    finally:
        for name in names:
            setattr(simulator_module, name, real[name])
    assert ran == [True]
    return res


def _close(a, b):
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)


def _assert_same(a, b):
    """Every logged field equal to 1e-12 (keys, shapes and dtypes identical)."""
    for name in ("t", "R", "omega", "R_d", "omega_d", "u_cmd", "u", "disturbance"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-12, atol=1e-12)
    for group in ("actuator", "controller", "sensors", "estimate"):
        da, db = getattr(a, group), getattr(b, group)
        assert sorted(da) == sorted(db), group
        for k in db:
            assert da[k].dtype == db[k].dtype and da[k].shape == db[k].shape, (group, k)
            if db[k].dtype == bool:
                np.testing.assert_array_equal(da[k], db[k])
            else:
                np.testing.assert_allclose(da[k], db[k], rtol=1e-12, atol=1e-12, err_msg=k)


def _plant(actuator: str) -> Spacecraft:
    if actuator == "vscmg":
        from spacecraft.cmg_dynamics import CmgInertias, GimbalServo, VscmgActuator

        act = VscmgActuator(
            J, CmgInertias(0.5, 0.25, (0.1, 0.1, 0.1)), SgcmgPyramid(h0=10.0),
            SingularityRobust(), servo=GimbalServo(5.0, 50.0),
        )  # fmt: skip
        return Spacecraft(RigidBody(J), act)
    if actuator == "wheels":
        from spacecraft import ReactionWheelAssembly

        act = ReactionWheelAssembly.pyramid(
            wheel_inertia=0.02, max_torque=0.5, max_speed=300.0, coulomb_friction=1e-3,
            viscous_friction=1e-5,
        )  # fmt: skip
        return Spacecraft(RigidBody(J), act)
    if actuator == "sgcmg":
        return Spacecraft(RigidBody(J), SgcmgActuator(SgcmgPyramid(h0=10.0), SingularityRobust()))
    return Spacecraft(RigidBody(J), IdealTorqueActuator(max_torque=2.0))


def _case(actuator: str = "ideal", B: int = 3, seed: int = 4):
    rng = np.random.default_rng(seed)
    plant = _plant(actuator)
    ref = ConstantAttitude(so3.exp(0.6 * rng.normal(size=(B, 3))))
    x0 = plant.initial_state(so3.exp(0.3 * rng.normal(size=(B, 3))), 0.02 * rng.normal(size=(B, 3)))
    return plant, GeometricPD(J, 8.0, 50.0), ref, x0


def _full_sensors(output: str = "quaternion", boresight: bool = False):
    """Every term of both models: latency, scheduled and random outages on the tracker; bias
    walk, initial bias, scale factor, misalignment, bandwidth and quantisation on the gyro."""
    if boresight:
        tracker = StarTracker(
            output=output, period=0.4, cross_boresight_std=2e-5, boresight_std=2e-4,
            boresight=np.array([0.0, 0.6, 0.8]), misalignment=np.array([1e-3, -5e-4, 2e-4]),
        )  # fmt: skip
    else:
        tracker = StarTracker(noise_std=np.array([1e-4, 2e-4, 5e-5]), output=output, period=0.4)
    return {
        "star_tracker": TimedSensor(
            tracker,
            latency=0.2,
            outages=[(1.0, 2.2), (5.0, 5.4)],
            outage_rate=0.3,
            outage_duration=0.8,
        ),  # fmt: skip
        "gyro": RateGyro(
            white_std=np.array([1e-5, 2e-5, 1.5e-5]),
            bias_rw_std=1e-6,
            initial_bias=[1e-4, 0, 0],
            initial_bias_std=5e-5,
            period=0.1,
            scale_factor=[1e-3, -2e-3, 5e-4],
            misalignment=[1e-3, 0.0, -2e-3],
            bandwidth=4.0,
            quantization=1e-6,
        ),  # fmt: skip
    }


def _both(plant, ctrl, ref, x0, t_final=8.0, dt=0.05, sensors_fn=_full_sensors, hook=True,
          seed=11, **kw):  # fmt: skip
    """(fused result, Python result, their sensors, their generators)."""
    out = []
    for run in (_fused, _python_loop):
        sensors = sensors_fn()
        rng = np.random.default_rng(seed)
        res = run(
            plant, copy.deepcopy(ctrl), ref, x0, t_final, dt, sensors=sensors,
            measurement=StarTrackerGyro() if hook else None, rng=rng, **kw,
        )  # fmt: skip
        out.append((res, sensors, rng))
    return out


@pytest.mark.parametrize("actuator", ["ideal", "sgcmg", "vscmg", "wheels"])
@pytest.mark.parametrize("hook", [True, False])
def test_sensors_in_the_fused_loop_equal_the_python_loop(actuator, hook):
    """Batch of 3, control period 2 dt, log every 3rd step: every field, the sensors' log and
    the estimate equal; the generator and the sensors end in the same state."""
    plant, ctrl, ref, x0 = _case(actuator)
    (fa, sa, ra), (py, sp, rp) = _both(
        plant, ctrl, ref, x0, hook=hook, control_period=0.1, log_every=3
    )
    _assert_same(fa, py)
    assert set(fa.sensors) == {"star_tracker", "star_tracker_valid", "gyro"}
    assert fa.sensors["star_tracker"].shape == (fa.n_samples, 3, 4)
    assert bool(fa.estimate) == hook
    # the outages happened, and the tracker was valid at times (the test exercises both)
    v = fa.sensors["star_tracker_valid"]
    assert v.any() and not v.all()
    assert ra.bit_generator.state == rp.bit_generator.state
    ga, gp = sa["gyro"].state, sp["gyro"].state
    np.testing.assert_array_equal(ga.bias, gp.bias)
    # bit for bit where the Python loop steps the plant with the same kernels; the wheels'
    # Python loop runs the assembly's NumPy methods (BLAS sums): the states agree to rounding
    same = np.testing.assert_array_equal if actuator != "wheels" else _close
    same(ga.filtered, gp.filtered)
    assert ga.t_last == gp.t_last
    ta, tp = sa["star_tracker"], sp["star_tracker"]
    np.testing.assert_array_equal(ta.valid, tp.valid)
    same(ta._held, tp._held)
    np.testing.assert_array_equal(ta._outage_end, tp._outage_end)
    assert ta._calls == tp._calls
    assert [h[0] for h in ta._history] == [h[0] for h in tp._history]
    for (_, Ra, wa), (_, Rp, wp) in zip(ta._history, tp._history, strict=True):
        same(Ra, Rp)
        same(wa, wp)


@pytest.mark.parametrize("output", ["quaternion", "matrix"])
def test_boresight_misaligned_tracker_and_matrix_output(output):
    plant, ctrl, ref, x0 = _case("ideal", B=4)
    (fa, _, _), (py, _, _) = _both(
        plant, ctrl, ref, x0, t_final=4.0, sensors_fn=lambda: _full_sensors(output, True),
        control_period=0.2, log_every=2,
    )  # fmt: skip
    _assert_same(fa, py)
    assert fa.estimate["R"].shape == (fa.n_samples, 4, 3, 3)


def test_plain_sensors_single_spacecraft_and_same_seed_same_result():
    """Untimed sensors on one spacecraft (log every step, control every step); a second
    fused run with the same seed is identical."""

    def plain():
        return {
            "star_tracker": StarTracker(noise_std=1e-4, period=0.25),
            "gyro": RateGyro(white_std=1e-5, bias_rw_std=1e-7, period=0.05),
        }

    plant, ctrl, ref, x0 = _case("sgcmg", B=1)
    (fa, _, _), (py, _, _) = _both(plant, ctrl, ref, x0, t_final=5.0, sensors_fn=plain)
    _assert_same(fa, py)
    (fb, _, _), _ = _both(plant, ctrl, ref, x0, t_final=5.0, sensors_fn=plain)
    _assert_same(fb, fa)
    np.testing.assert_array_equal(fb.R, fa.R)


def test_inputs_are_not_mutated():
    plant, ctrl, ref, x0 = _case("sgcmg")
    R0, packed0, Rd0 = x0.R.copy(), x0.packed().copy(), ref.R_d.copy()
    sensors = _full_sensors()
    tracker = sensors["star_tracker"].sensor
    mis0 = tracker.misalignment.copy()
    _fused(plant, ctrl, ref, x0, 2.0, 0.05, sensors=sensors, measurement=StarTrackerGyro(),
           rng=np.random.default_rng(1))  # fmt: skip
    np.testing.assert_array_equal(x0.R, R0)
    np.testing.assert_array_equal(x0.packed(), packed0)
    np.testing.assert_array_equal(ref.R_d, Rd0)
    np.testing.assert_array_equal(tracker.misalignment, mis0)


class _MyGyro(RateGyro):
    """A subclass: it may override ``measure``, so it keeps the Python loop."""


class _EchoRate:
    """A user's sensor: the true rate, no noise."""

    period = 0.1

    def measure(self, t, R, omega, rng):
        return np.array(omega, dtype=np.float64)


def _two_vector_moving():
    return TwoVectorAttitude(lambda t: np.array([np.cos(0.1 * t), np.sin(0.1 * t), 0.0]),
                             np.array([0, 0, 1.0]), 1e-4, period=0.2)  # fmt: skip


@pytest.mark.parametrize(
    ("sensors_fn", "hook", "words"),
    [
        (lambda: {"star_tracker": StarTracker(period=0.2), "gyro": _MyGyro(period=0.1)}, True,
         "_MyGyro has no compiled kernel"),
        (lambda: {"star_tracker": StarTracker(period=0.2), "gyro": _EchoRate()}, True,
         "_EchoRate has no compiled kernel"),
        (lambda: {"star_tracker": _two_vector_moving(), "gyro": RateGyro(period=0.1)}, True,
         "time-varying reference direction"),
    ],
)  # fmt: skip
def test_unsupported_sensors_take_the_python_loop_with_the_same_result(
    sensors_fn, hook, words, caplog
):
    plant, ctrl, ref, x0 = _case("ideal", B=2)
    hook_obj = StarTrackerGyro() if hook else None
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        a = simulate(plant, copy.deepcopy(ctrl), ref, x0, 2.0, 0.05, sensors=sensors_fn(),
                     measurement=hook_obj, rng=np.random.default_rng(3))  # fmt: skip
    lines = [r.getMessage() for r in caplog.records if "Python loop runs" in r.getMessage()]
    assert len(lines) == 1 and words in lines[0], lines
    b = _python_loop(plant, copy.deepcopy(ctrl), ref, x0, 2.0, 0.05, sensors=sensors_fn(),
                     measurement=hook_obj, rng=np.random.default_rng(3))  # fmt: skip
    _assert_same(a, b)


def test_a_python_hook_and_a_shared_sensor_keep_the_python_loop():
    plant, ctrl, _, _ = _case("ideal")
    sensors = [("star_tracker", StarTracker(period=0.2), 4), ("gyro", RateGyro(period=0.1), 2)]

    def hook(t, outputs, truth):
        return truth

    why: list[str] = []
    assert fused_supported(plant, ctrl, sensors, hook, False, reasons=why) is None
    assert "the measurement hook function has no compiled kernel" in why[0]
    g = RateGyro(period=0.1)
    why = []
    shared = [("a", g, 2), ("b", TimedSensor(g, latency=0.1), 2)]
    assert fused_supported(plant, ctrl, shared, None, False, reasons=why) is None
    assert "shares its RateGyro object" in why[0]
    assert fused_supported(plant, ctrl, sensors, StarTrackerGyro(), False) is not None


def test_workers_give_the_same_bits():
    """The batch over two threads: each spacecraft's draws are its own row, so the result is
    bit-identical to one thread."""
    plant, ctrl, ref, x0 = _case("ideal", B=4)
    out = []
    for workers in (1, 2):
        out.append(
            _fused(
                plant,
                copy.deepcopy(ctrl),
                ref,
                x0,
                3.0,
                0.05,
                sensors=_full_sensors(),
                measurement=StarTrackerGyro(),
                rng=np.random.default_rng(5),
                control_period=0.1,
                workers=workers,
            )  # fmt: skip
        )
    for name in ("R", "omega", "u_cmd"):
        np.testing.assert_array_equal(getattr(out[0], name), getattr(out[1], name))
    for k in out[0].sensors:
        np.testing.assert_array_equal(out[0].sensors[k], out[1].sensors[k])


# ---------------------------------------------------------------- the MEKF hook, compiled
def _mekf_spec(estimator="mekf"):
    from benchmarks.scenarios import SensorSpec

    return SensorSpec(
        estimator=estimator, star_tracker_latency=0.2, outage_rate=0.05, outage_duration=2.0,
        star_tracker_outages=((4.0, 5.0),), gyro_bias=(1e-4, -5e-5, 2e-5),
    )  # fmt: skip


def _mekf_both(actuator, B=3, t_final=12.0, estimator="mekf", **kw):
    """(fused, hook, rng), (Python, hook, rng) with the benchmarks' MEKF hook (``simulate``'s
    own choice instead of the fused run for the UKF)."""
    from benchmarks.runner import build_sensors

    plant, ctrl, ref, x0 = _case(actuator, B=B)
    out = []
    for run in (_fused if estimator == "mekf" else simulate, _python_loop):
        sensors, hook, rng = build_sensors(_mekf_spec(estimator))
        res = run(plant, copy.deepcopy(ctrl), ref, x0, t_final, 0.1, sensors=sensors,
                  measurement=hook, rng=rng, **kw)  # fmt: skip
        out.append((res, hook, rng))
    return out


@pytest.mark.parametrize("actuator", ["sgcmg", "ideal", "wheels"])
def test_mekf_hook_in_the_fused_loop_equals_the_python_loop(actuator, caplog):
    """The MEKF between the sensors (latency, outages, gyro bias) and the law, over a batch with
    control_period > dt and log_every > 1: the log, the estimate, the filters' final state and
    their consistency log (NEES, NIS, gate) equal the Python loop's to 1e-12."""
    with caplog.at_level(logging.WARNING, logger="liecontrol.estimation"):
        (fa, ha, ra), (py, hp, rp) = _mekf_both(actuator, control_period=0.2, log_every=3)
    _assert_same(fa, py)
    rejected = sum(sum(hp._log[b]["gated"]) for b in range(3))
    compiled = [r.getMessage() for r in caplog.records if "(compiled loop)" in r.getMessage()]
    assert len(compiled) == (1 if rejected else 0)
    if rejected:  # the gate acted (the SGCMG case): the compiled run says so once, with the count
        assert f"{int(rejected)} innovation(s) rejected" in compiled[0]
    assert ra.bit_generator.state == rp.bit_generator.state
    # the wheels' Python loop steps the NumPy assembly (BLAS sums): its states differ from the
    # compiled loop's in the last bits, which the filter's gated updates carry into the NIS
    rtol = 1e-12 if actuator != "wheels" else 1e-10
    for b in range(3):
        for key, vp in hp._log[b].items():
            va = ha._log[b][key]
            assert len(va) == len(vp) > 0, key
            np.testing.assert_allclose(va, vp, rtol=rtol, atol=1e-12, err_msg=key)
        np.testing.assert_allclose(ha._filters[b].x, hp._filters[b].x, rtol=rtol, atol=1e-15)
        np.testing.assert_allclose(ha._filters[b].P, hp._filters[b].P, rtol=rtol, atol=1e-20)
        ca, cp = ha.consistency(b, since=6.0), hp.consistency(b, since=6.0)
        assert sorted(ca) == sorted(cp)
        for k in cp:
            np.testing.assert_allclose(ca[k], cp[k], rtol=1e-10, err_msg=k)
    assert ha._t_last == hp._t_last
    np.testing.assert_allclose(ha._w_last, hp._w_last, rtol=1e-12, atol=1e-15)


def test_mekf_hook_without_the_gyro_truth():
    """(The UKF hook's tests are in tests/test_fused_ukf.py.)"""
    from benchmarks.runner import FilteredAttitude

    hook = FilteredAttitude(_mekf_spec())  # gyro=None: attitude NEES only
    spec = hook.fused_hook()
    assert spec is not None and spec.gyro is None and spec.kind == "mekf"


def test_a_hook_that_overrides_call_below_fused_hook_keeps_the_python_loop():
    from benchmarks.runner import FilteredAttitude

    class Mine(FilteredAttitude):
        def __call__(self, t, outputs, truth):
            return super().__call__(t, outputs, truth)

    plant, ctrl, _, _ = _case("ideal")
    sensors = [("star_tracker", StarTracker(period=0.2), 2), ("gyro", RateGyro(period=0.1), 1)]
    why: list[str] = []
    hook = Mine(_mekf_spec())
    assert fused_supported(plant, ctrl, sensors, hook, False, reasons=why) is None
    assert "overrides __call__ below its fused_hook" in why[0]
    assert fused_supported(plant, ctrl, sensors, FilteredAttitude(_mekf_spec()), False)
