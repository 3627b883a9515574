"""Euler-angle outputs and the two-vector (TRIAD) sensor in the compiled closed loop.

- a :class:`~spacecraft.sensors.StarTracker` with Euler-angle output (a Tait–Bryan and a proper
  Euler sequence, intrinsic and extrinsic, behind latency and outages) and a
  :class:`~spacecraft.sensors.TwoVectorAttitude` (Euler, matrix and quaternion outputs), with
  and without the :class:`~spacecraft.simulator.StarTrackerGyro` hook, B = 1 and B = 3: the
  fused loop equals the Python loop to 1e-12 (states, torques, logged measurements), the
  generator ends in the same state, and the run is shown to be fused; B = 3 Euler rows
  ``(3, 3)`` are read as angles, not as a matrix;
- near gimbal lock of the sequence both routes agree (they call the same kernel,
  :mod:`liecontrol._kernels.euler`), which is checked against the numpy chart
  :func:`liecontrol.charts.euler.from_matrix` / ``to_matrix`` on all 24 sequences;
- the TRIAD kernel equals the formula written with numpy, and ``triad`` still refuses parallel
  pairs; the estimator hook refuses a non-quaternion attitude with its log line.
"""

from __future__ import annotations

import copy
import logging
import warnings

import numpy as np
import pytest

from liecontrol._jit import JIT_ENABLED
from liecontrol._kernels import euler as KE
from liecontrol.charts import euler
from liecontrol.lie import so3
from spacecraft._fused import fused_supported
from spacecraft._fused_sensors import EstimatorHook
from spacecraft.sensors import RateGyro, StarTracker, TimedSensor, TwoVectorAttitude, triad
from spacecraft.simulator import StarTrackerGyro
from tests.test_fused_sensors import _assert_same, _case, _fused, _python_loop

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the fused loop needs numba")


def _gyro():
    return RateGyro(white_std=1e-5, bias_rw_std=1e-6, initial_bias=[1e-4, 0, 0], period=0.1)


def _euler_tracker(seq: str):
    tracker = StarTracker(noise_std=np.array([1e-4, 2e-4, 5e-5]), output="euler", seq=seq,
                          period=0.2, misalignment=np.array([1e-3, -5e-4, 2e-4]))  # fmt: skip
    return {
        "star_tracker": TimedSensor(
            tracker, latency=0.2, outages=[(0.6, 1.0)], outage_rate=0.3, outage_duration=0.4
        ),  # fmt: skip
        "gyro": _gyro(),
    }


def _two_vector(output: str, seq: str = "ZYX"):
    sensor = TwoVectorAttitude(np.array([0.2, 0.1, 1.0]), np.array([1.0, -0.3, 0.2]),
                               (1e-3, 3e-3), seq=seq, output=output, period=0.2)  # fmt: skip
    return {"star_tracker": sensor, "gyro": _gyro()}


def _compare(sensors_fn, B: int, hook: bool, seq: str = "ZYX", t_final: float = 3.0):
    plant, ctrl, ref, x0 = _case("ideal", B=B)
    out = []
    for run in (_fused, _python_loop):
        rng = np.random.default_rng(7)
        res = run(
            plant, copy.deepcopy(ctrl), ref, x0, t_final, 0.05, sensors=sensors_fn(),
            measurement=StarTrackerGyro(seq=seq) if hook else None, rng=rng,
            control_period=0.1, log_every=2,
        )  # fmt: skip
        out.append((res, rng))
    (fa, ra), (py, rp) = out
    _assert_same(fa, py)
    assert ra.bit_generator.state == rp.bit_generator.state
    assert bool(fa.estimate) == hook
    return fa


@pytest.mark.parametrize("seq", ["ZYX", "ZXZ", "xyz", "yzy"])
@pytest.mark.parametrize("B", [1, 3])
@pytest.mark.parametrize("hook", [True, False])
def test_euler_star_tracker_fused_equals_python(seq, B, hook):
    fa = _compare(lambda: _euler_tracker(seq), B, hook, seq=seq)
    y = fa.sensors["star_tracker"]
    assert y.shape == (fa.n_samples, B, 3)  # angles, for B = 3 too (not (…, 3, 3) matrices)
    v = fa.sensors["star_tracker_valid"]
    assert v.any() and not v.all()
    if hook:
        # the hook read the angles as angles: its attitude is close to the truth
        err = np.linalg.norm(so3.log(np.swapaxes(fa.estimate["R"], -1, -2) @ fa.R), axis=-1)
        assert float(err[fa.t > 1.5].max()) < 0.05


@pytest.mark.parametrize("output", ["euler", "matrix", "quaternion"])
@pytest.mark.parametrize("B", [1, 3])
@pytest.mark.parametrize("hook", [True, False])
def test_two_vector_fused_equals_python(output, B, hook):
    fa = _compare(lambda: _two_vector(output), B, hook)
    shape = {"euler": (3,), "matrix": (3, 3), "quaternion": (4,)}[output]
    assert fa.sensors["star_tracker"].shape == (fa.n_samples, B) + shape


def test_two_vector_proper_euler_with_latency_and_hook_sequence():
    def sensors():
        s = _two_vector("euler", seq="ZXZ")
        s["star_tracker"] = TimedSensor(s["star_tracker"], latency=0.2, outage_rate=0.5,
                                        outage_duration=0.4)  # fmt: skip
        return s

    _compare(sensors, 3, True, seq="ZXZ")


def test_near_gimbal_lock_both_routes_agree():
    """A reference and start within 1e-7 rad of the ZYX lock (a2 = π/2) and of the ZXZ lock
    (a2 = 0), noise-free tracker: both routes give the same angles (bit for bit)."""
    for seq, a2 in (("ZYX", np.pi / 2 - 1e-7), ("ZXZ", 1e-7)):
        R0 = euler.to_matrix(np.array([0.4, a2, -0.3]), seq)

        def sensors(seq=seq):
            return {"star_tracker": StarTracker(output="euler", seq=seq, period=0.1),
                    "gyro": RateGyro(period=0.1)}  # fmt: skip

        plant, ctrl, ref, _ = _case("ideal", B=1)
        x0 = plant.initial_state(R0[None], np.zeros((1, 3)))
        res = []
        for run in (_fused, _python_loop):
            res.append(run(plant, copy.deepcopy(ctrl), ref, x0, 0.5, 0.05, sensors=sensors(),
                           rng=np.random.default_rng(1)))  # fmt: skip
        _assert_same(*res)
        y0 = res[0].sensors["star_tracker"][0, 0]
        np.testing.assert_array_equal(y0, res[1].sensors["star_tracker"][0, 0])
        # the chart agrees to the conditioning near lock: the angles reproduce R
        i, j, k, ext = euler.kernel_axes(seq)
        np.testing.assert_allclose(KE.to_matrix_batch(y0[None], i, j, k, ext)[0], R0, atol=1e-12)


def test_euler_kernels_match_the_chart_on_every_sequence():
    rng = np.random.default_rng(0)
    R = so3.exp(2.0 * rng.normal(size=(100, 3)))
    for seq in euler.SEQUENCES:
        i, j, k, ext = euler.kernel_axes(seq)
        a, lock = KE.from_matrix_batch(R, i, j, k, ext, euler.FROM_MATRIX_LOCK_TOL)
        np.testing.assert_allclose(a, euler.from_matrix(R, seq), atol=1e-13, err_msg=seq)
        assert not lock.any()
        np.testing.assert_allclose(
            KE.to_matrix_batch(a, i, j, k, ext), euler.to_matrix(a, seq), atol=1e-14
        )
        # at the lock itself: the same branch and choice (third angle 0) as the chart
        tb = euler.is_tait_bryan(seq)
        for a2 in (np.pi / 2, -np.pi / 2) if tb else (0.0, np.pi):
            Rl = euler.to_matrix(np.array([0.3, a2, -0.2]), seq)[None]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", euler.GimbalLockWarning)
                ref = euler.from_matrix(Rl, seq)
            got, lock = KE.from_matrix_batch(Rl, i, j, k, ext, euler.FROM_MATRIX_LOCK_TOL)
            assert lock.all(), seq
            np.testing.assert_allclose(got, ref, atol=1e-12, err_msg=seq)


def test_star_tracker_euler_output_warns_at_lock_as_the_chart():
    R = euler.to_matrix(np.array([0.3, np.pi / 2, 0.1]), "ZYX")[None]
    with pytest.warns(euler.GimbalLockWarning):
        StarTracker(output="euler").measure(0.0, R, None, np.random.default_rng(0))


def test_triad_kernel_equals_the_numpy_formula_and_refuses_parallel():
    rng = np.random.default_rng(2)
    b1, b2, r1, r2 = rng.normal(size=(4, 5, 3))

    def frame(v1, v2):
        t1 = v1 / np.linalg.norm(v1, axis=-1, keepdims=True)
        c = np.cross(v1, v2)
        t2 = c / np.linalg.norm(c, axis=-1, keepdims=True)
        return np.stack((t1, t2, np.cross(t1, t2)), axis=-1)

    want = frame(r1, r2) @ np.swapaxes(frame(b1, b2), -1, -2)
    np.testing.assert_allclose(triad(b1, b2, r1, r2), want, atol=1e-14)
    assert triad(b1[0], b2[0], r1[0], r2[0]).shape == (3, 3)
    with pytest.raises(ValueError, match="b1: parallel to b2"):
        triad(b1[0], 2.0 * b1[0], r1[0], r2[0])


class _Estimator:
    """A hook with an MEKF kernel (``fused_hook``) reading ``star_tracker`` and ``gyro``."""

    attitude = "star_tracker"
    rate = "gyro"

    def __call__(self, t, outputs, truth):
        return truth

    def fused_hook(self) -> EstimatorHook:
        return EstimatorHook(
            "star_tracker", "gyro", 1e-5, 1e-6, 1e-8 * np.eye(3), 1e-4 * np.eye(6), 16.0, 3
        )


def test_the_estimator_hook_refuses_a_non_quaternion_attitude():
    plant, ctrl, _, _ = _case("ideal")
    hook = _Estimator()
    two_vector = _two_vector("quaternion")["star_tracker"]
    for sensor in (StarTracker(output="euler", period=0.2), two_vector):
        why: list[str] = []
        sensors = [("star_tracker", sensor, 4), ("gyro", RateGyro(period=0.1), 2)]
        assert fused_supported(plant, ctrl, sensors, hook, False, reasons=why) is None
        assert why and ("quaternion output" in why[0] or "TwoVectorAttitude" in why[0]), why


def test_fused_sensor_forms_log_nothing_about_the_python_loop(caplog):
    plant, ctrl, ref, x0 = _case("ideal", B=2)
    from spacecraft.simulator import simulate

    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, copy.deepcopy(ctrl), ref, x0, 1.0, 0.05, sensors=_two_vector("euler"),
                 measurement=StarTrackerGyro(), rng=np.random.default_rng(3))  # fmt: skip
    assert not [r for r in caplog.records if "Python loop runs" in r.getMessage()]
