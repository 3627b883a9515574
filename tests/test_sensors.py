"""Sensors (SPEC §5.7): star tracker, rate gyro, TRIAD two-vector attitude."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from liecontrol.charts import quaternion
from liecontrol.lie import so3
from spacecraft.sensors import GyroState, RateGyro, StarTracker, TwoVectorAttitude, triad


def test_star_tracker_noise_statistics():
    sig = np.array([1e-4, 2e-4, 5e-5])
    st_ = StarTracker(noise_std=sig, output="matrix")
    R = so3.random(np.random.default_rng(0), 1)
    N = 20000
    Rm = st_.measure(0.0, np.broadcast_to(R, (N, 3, 3)), np.zeros((N, 3)), np.random.default_rng(1))
    d = so3.log(np.swapaxes(R, -1, -2) @ Rm)  # body-frame error rotation vectors
    assert np.all(np.abs(d.mean(axis=0)) < 4 * sig / np.sqrt(N))
    np.testing.assert_allclose(d.std(axis=0), sig, rtol=0.03)
    # seeded: reproducible
    a = st_.measure(0.0, R, np.zeros((1, 3)), np.random.default_rng(5))
    b = st_.measure(0.0, R, np.zeros((1, 3)), np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)


def test_star_tracker_outputs_and_misalignment():
    rng = np.random.default_rng(2)
    R = so3.random(rng, 6)
    w = np.zeros((6, 3))
    q = StarTracker(output="quaternion").measure(0.0, R, w, rng)
    q_sp = Rotation.from_matrix(R).as_quat()[:, [3, 0, 1, 2]]  # scalar first
    np.testing.assert_allclose(np.abs(np.sum(q * q_sp, axis=1)), 1.0, atol=1e-14)
    e = StarTracker(output="euler", seq="ZYX").measure(0.0, R, w, rng)
    np.testing.assert_allclose(e, Rotation.from_matrix(R).as_euler("ZYX"), atol=1e-12)
    m = np.array([1e-3, -2e-3, 5e-4])
    Rm = StarTracker(output="matrix", misalignment=m).measure(0.0, R, w, rng)
    np.testing.assert_allclose(Rm, R @ Rotation.from_rotvec(m).as_matrix(), atol=1e-15)
    assert quaternion.to_matrix(q).shape == (6, 3, 3)


def test_gyro_white_noise_and_bias_random_walk_growth():
    B, K, period = 4000, 100, 0.5
    sig_u = 1e-5  # rad/s^(3/2)
    density = 2e-4  # rad/s/√Hz
    gyro = RateGyro(
        noise_density=density, bias_rw_std=sig_u, initial_bias=[1e-3, 0, -1e-3], period=period
    )
    np.testing.assert_allclose(gyro.white_std, density / np.sqrt(period))
    rng = np.random.default_rng(7)
    state = gyro.initial_state(B)
    omega = np.tile([0.01, -0.02, 0.03], (B, 1))
    biases, errors = [], []
    for k in range(K):
        meas, new = gyro.step(state, k * period, omega, rng)
        errors.append(meas - omega - new.bias)
        biases.append(new.bias)
        state = new
    biases = np.array(biases)  # (K, B, 3)
    drift = biases - biases[0]
    t = np.arange(K) * period
    std = drift.std(axis=1).mean(axis=1)  # per time, averaged over axes
    for k in (25, 50, 99):
        assert std[k] == pytest.approx(sig_u * np.sqrt(t[k]), rel=0.05)
    # ∝ √t: the fitted exponent of std vs t is ½
    slope = np.polyfit(np.log(t[10:]), np.log(std[10:]), 1)[0]
    assert slope == pytest.approx(0.5, abs=0.03)
    np.testing.assert_allclose(biases[0], np.broadcast_to([1e-3, 0, -1e-3], (B, 3)))
    err = np.array(errors).reshape(-1, 3)
    assert np.all(np.abs(err.mean(axis=0)) < 4 * gyro.white_std / np.sqrt(err.shape[0]))
    np.testing.assert_allclose(err.std(axis=0), gyro.white_std, rtol=0.02)


def test_gyro_held_state_and_purity():
    gyro = RateGyro(white_std=1e-4, bias_rw_std=1e-4, initial_bias_std=1e-3, period=1.0)
    s0 = gyro.reset(3, np.random.default_rng(0))
    b0 = s0.bias.copy()
    w = np.zeros((3, 3))
    m1 = gyro.measure(0.0, None, w, np.random.default_rng(1))
    m2 = gyro.measure(1.0, None, w, np.random.default_rng(2))
    assert m1.shape == m2.shape == (3, 3)
    assert isinstance(gyro.state, GyroState) and gyro.state.t_last == 1.0
    np.testing.assert_array_equal(s0.bias, b0)  # old states are never mutated
    # pure step: same state + same seed → same output
    a, sa = gyro.step(s0, 2.0, w, np.random.default_rng(3))
    b, sb = gyro.step(s0, 2.0, w, np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(sa.bias, sb.bias)
    # auto-initialisation on the first measure() call, batch size from omega
    g2 = RateGyro(white_std=0.0, initial_bias=[1.0, 2.0, 3.0])
    np.testing.assert_array_equal(
        g2.measure(0.0, None, w, np.random.default_rng(0)), np.tile([1.0, 2.0, 3.0], (3, 1))
    )
    with pytest.raises(ValueError, match="^t:"):
        gyro.measure(0.5, None, w, np.random.default_rng(4))
    with pytest.raises(ValueError, match="^omega:"):
        gyro.measure(3.0, None, np.zeros((2, 3)), np.random.default_rng(4))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_triad_recovers_attitude_without_noise(seed):
    rng = np.random.default_rng(seed)
    R = so3.random(rng, 5)
    r1 = rng.standard_normal((5, 3))
    r2 = rng.standard_normal((5, 3))
    b1 = np.einsum("bji,bj->bi", R, r1) * 3.0  # scale does not matter
    b2 = np.einsum("bji,bj->bi", R, r2)
    np.testing.assert_allclose(triad(b1, b2, r1, r2), R, atol=1e-9)


def test_triad_first_vector_exact_with_inconsistent_pair():
    rng = np.random.default_rng(11)
    R = so3.random(rng)
    r1, r2 = np.array([1.0, 0.2, 0.0]), np.array([0.0, 1.0, 1.0])
    b1 = R.T @ r1
    b2 = so3.exp([0.01, -0.02, 0.015]) @ R.T @ r2  # corrupted second vector
    Rt = triad(b1, b2, r1, r2)
    np.testing.assert_allclose(Rt @ b1, r1, atol=1e-14)
    np.testing.assert_allclose(Rt.T @ Rt, np.eye(3), atol=1e-14)
    assert np.linalg.det(Rt) == pytest.approx(1.0)


def test_triad_parallel_and_zero_raise():
    with pytest.raises(ValueError, match="^b1: parallel"):
        triad([[1.0, 0, 0], [1, 0, 0]], [[0, 1.0, 0], [2, 0, 0]], [1.0, 0, 0], [0, 1.0, 0])
    with pytest.raises(ValueError, match="^r1: parallel"):
        triad([1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [0, 0, -3.0])
    with pytest.raises(ValueError, match="^b2: zero"):
        triad([1.0, 0, 0], [0, 0, 0], [1.0, 0, 0], [0, 1.0, 0])
    with pytest.raises(ValueError, match="^r2:"):
        triad([1.0, 0, 0], [0, 1.0, 0], [1.0, 0, 0], [0, 1.0])


def test_two_vector_attitude_euler_and_noise():
    g = np.array([0.0, 0.0, -9.81])  # gravity (accelerometer)
    B_field = np.array([2.0e-5, 0.0, 4.0e-5])  # geomagnetic field (magnetometer)
    rng = np.random.default_rng(3)
    R = so3.random(rng, 8)
    w = np.zeros((8, 3))
    exact = TwoVectorAttitude(g, B_field, seq="ZYX").measure(0.0, R, w, rng)
    np.testing.assert_allclose(exact, Rotation.from_matrix(R).as_euler("ZYX"), atol=1e-10)
    # noisy: attitude error of the order of the direction noise
    sig = 1e-3
    N = 4000
    sensor = TwoVectorAttitude(g, B_field, noise_std=sig, output="matrix", period=1.0)
    R1 = np.broadcast_to(R[0], (N, 3, 3))
    Rm = sensor.measure(0.0, R1, np.zeros((N, 3)), np.random.default_rng(9))
    err = so3.log(np.swapaxes(R1, -1, -2) @ Rm)
    rms = np.sqrt(np.mean(np.sum(err**2, axis=1)))
    assert sig < rms < 4 * sig
    assert np.all(np.abs(err.mean(axis=0)) < 5 * err.std(axis=0) / np.sqrt(N))
    # time-varying references (callables)
    tv = TwoVectorAttitude(
        lambda t: [np.cos(t), np.sin(t), 0.0], lambda t: [0, 0, 1.0], output="matrix"
    )
    np.testing.assert_allclose(tv.measure(2.0, R, w, rng), R, atol=1e-12)


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda: StarTracker(period=0.0), "period"),
        (lambda: StarTracker(period=-1.0), "period"),
        (lambda: StarTracker(noise_std=-1e-4), "noise_std"),
        (lambda: StarTracker(noise_std=[1e-4, np.nan, 0]), "noise_std"),
        (lambda: StarTracker(output="rotvec"), "output"),
        (lambda: StarTracker(output="euler", seq="XXY"), "seq"),
        (lambda: StarTracker(misalignment=[0.0, 1.0]), "misalignment"),
        (lambda: RateGyro(period=0.0), "period"),
        (lambda: RateGyro(white_std=1e-4, noise_density=1e-4), "white_std"),
        (lambda: RateGyro(bias_rw_std=-1.0), "bias_rw_std"),
        (lambda: RateGyro(initial_bias=[1.0, 2.0]), "initial_bias"),
        (lambda: RateGyro(noise_density=[1.0, 2.0]), "noise_density"),
        (lambda: TwoVectorAttitude([1.0, 0, 0], [2.0, 0, 0]), "ref1"),
        (lambda: TwoVectorAttitude([0.0, 0, 0], [1.0, 0, 0]), "ref1"),
        (lambda: TwoVectorAttitude([1.0, 0, 0], [0, 1.0, 0], period=-0.1), "period"),
        (lambda: TwoVectorAttitude([1.0, 0, 0], [0, 1.0, 0], noise_std=(1, 2, 3)), "noise_std"),
    ],
)
def test_bad_construction(make, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        make()


def test_bad_measure_inputs():
    st_ = StarTracker()
    with pytest.raises(ValueError, match="^rng:"):
        st_.measure(0.0, np.eye(3)[None], np.zeros((1, 3)), 42)
    with pytest.raises(ValueError, match="^R:"):
        st_.measure(0.0, np.eye(3), np.zeros(3), np.random.default_rng(0))
    with pytest.raises(ValueError, match="^batch_size:"):
        RateGyro().reset(0)
