"""Safe-mode Sun acquisition: coarse Sun sensors, the Sun-vector estimate, the rate-damping +
Sun-pointing law, and the scenario that starts tumbling in sunlight and crosses an eclipse."""

from __future__ import annotations

import math

import numpy as np
import pytest

from liecontrol.control import ConstantAttitude
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.sun_acquisition import (
    DirectionMeasurement,
    SunAcquisitionLaw,
    sun_acquisition_gains,
)
from liecontrol.lie import so3
from spacecraft.orbit import CircularOrbit
from spacecraft.sun_sensors import (
    CUBE_NORMALS,
    CoarseSunSensors,
    SunPointingReference,
    SunSensorGyro,
    estimate_sun_vector,
    sun_sensor_coverage,
)

ORBIT = CircularOrbit.from_altitude(530e3, inclination=math.radians(51.6), raan=math.radians(270))
J = np.diag([12.0, 10.0, 8.0])
Z = np.array([0.0, 0.0, 1.0])


def _unit(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


# --------------------------------------------------------------------------- sensors, estimate


def test_cube_estimate_is_exact_without_noise_and_threshold():
    rng = np.random.default_rng(1)
    s = _unit(rng, 200)
    N = np.array(CUBE_NORMALS)
    y = np.maximum(s @ N.T, 0.0)
    est, valid = estimate_sun_vector(y, N, threshold=0.0, min_intensity=0.0)
    assert valid.all()
    np.testing.assert_allclose(est, s, atol=1e-12)
    # a threshold drops components below it: the error is at most asin(threshold)
    est, valid = estimate_sun_vector(y, N, threshold=0.03)
    err = np.arccos(np.clip(np.sum(est * s, axis=1), -1, 1))
    assert valid.all() and err.max() <= math.asin(0.03 * math.sqrt(2)) + 1e-12


def test_sensor_outputs_follow_the_cosine_law_and_go_dark_in_eclipse():
    css = CoarseSunSensors(ORBIT, noise_std=0.0)
    s_I, dark = css.sun(0.0)
    assert not dark and css.sun(2500.0)[1]  # lit at the start, in the shadow later
    R = so3.exp(_unit(np.random.default_rng(2), 5) * 1.3)
    y = css.measure(0.0, R, np.zeros((5, 3)), np.random.default_rng(0))
    s_b = np.einsum("bji,j->bi", R, s_I)
    np.testing.assert_allclose(y, np.maximum(s_b @ np.array(CUBE_NORMALS).T, 0.0), atol=1e-15)
    assert not css.measure(2500.0, R, None, np.random.default_rng(0)).any()
    # a narrow field of view: a sensor 40° off the Sun does not see it with a 30° half-angle
    narrow = CoarseSunSensors(
        ORBIT, normals=[[0, 0, 1.0]], fov_half_angle=math.radians(30), noise_std=0.0,
        allow_gaps=True,
    )  # fmt: skip
    R40 = so3.exp(np.radians(40.0) * np.cross(Z, s_I) / np.linalg.norm(np.cross(Z, s_I)))
    R_on = SunPointingReference(narrow, Z)(0.0).R_d
    assert narrow.measure(0.0, R_on[None], None, np.random.default_rng(0))[0, 0] == (
        pytest.approx(1.0)
    )
    assert narrow.measure(0.0, (R_on @ R40.T)[None], None, np.random.default_rng(0))[0, 0] == 0.0
    # noise alone (in eclipse) never makes a valid estimate: the intensity check rejects it
    noisy = CoarseSunSensors(ORBIT, noise_std=0.02)
    y = noisy.measure(2500.0, np.tile(np.eye(3), (2000, 1, 1)), None, np.random.default_rng(3))
    assert (y > noisy.threshold).any()
    assert not estimate_sun_vector(y, noisy.unit_normals, noisy.threshold)[1].any()


def test_unobservable_sensor_sets_name_the_directions():
    # four sensors in the x-y plane: the z component is never seen
    with pytest.raises(
        ValueError, match=r"^normals: the 4 sensor normals span only 2 .*0\.0, 1\.0"
    ):
        CoarseSunSensors(ORBIT, normals=CUBE_NORMALS[:4])
    # three sensors on +x, +y, +z: the octant around (−1, −1, −1)/√3 is dark
    with pytest.raises(
        ValueError,
        match=r"^normals: no sensor is lit for 1\d\.\d % .*\(-0\.[56]\d, -0\.[56]\d, -0\.[56]\d\)",
    ):
        CoarseSunSensors(ORBIT, normals=[CUBE_NORMALS[0], CUBE_NORMALS[2], CUBE_NORMALS[4]])
    # the cube with 30° fields of view leaves gaps between the faces
    with pytest.raises(ValueError, match=r"^normals: no sensor is lit for \d+\.\d % .*fov_half"):
        CoarseSunSensors(ORBIT, fov_half_angle=math.radians(30.0))
    cov = sun_sensor_coverage(CUBE_NORMALS)
    assert cov["span_rank"] == 3 and cov["uncovered_fraction"] == 0.0
    # deliberately partial: accepted with allow_gaps
    CoarseSunSensors(ORBIT, normals=CUBE_NORMALS[:4], allow_gaps=True)


@pytest.mark.parametrize(
    ("kw", "key"),
    [
        ({"fov_half_angle": 0.0}, "fov_half_angle"),
        ({"fov_half_angle": 2.0}, "fov_half_angle"),
        ({"noise_std": -0.1}, "noise_std"),
        ({"threshold": 1.0}, "threshold"),
        ({"min_intensity": -0.5}, "min_intensity"),
        ({"period": 0.0}, "period"),
        ({"normals": [[0.0, 0.0, 0.0]]}, "normals"),
        ({"normals": [1.0, 0.0, 0.0]}, "normals"),
    ],
)
def test_sun_sensor_bad_input_names_the_key(kw, key):
    with pytest.raises(ValueError, match=f"^{key}:"):
        CoarseSunSensors(ORBIT, **kw)


# --------------------------------------------------------------------------- the law


def test_gains_set_the_small_angle_loop():
    g = sun_acquisition_gains(J, 0.02, 0.9)
    assert g["k_p"] == pytest.approx(12.0 * 0.02**2)
    assert g["k_d"] == pytest.approx(2 * 0.9 * 0.02 * 12.0)


def test_energy_never_increases_on_the_true_state():
    from spacecraft import IdealTorqueActuator, RigidBody, Spacecraft, simulate

    rng = np.random.default_rng(4)
    R0 = so3.exp(_unit(rng, 8) * rng.uniform(0.5, 3.1, (8, 1)))
    w0 = _unit(rng, 8) * math.radians(2.0)
    g = sun_acquisition_gains(J, 0.02, 0.9)
    law = SunAcquisitionLaw(**g, body_axis=Z)
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    res = simulate(
        plant, law, ConstantAttitude(np.eye(3)), plant.initial_state(R0, w0), 1500.0, 0.5,
        log_every=4,
    )  # fmt: skip
    s = res.R[..., 2, :]  # Rᵀ e_z: where the reference puts b (= e_z), in body axes
    V = g["k_p"] * (1.0 - s[..., 2]) + 0.5 * np.einsum("kbi,ij,kbj->kb", res.omega, J, res.omega)
    assert np.all(np.diff(V, axis=0) <= 1e-12 * V[0].max())
    assert np.degrees(np.arccos(s[-1, :, 2])).max() < 1.0


def test_eclipse_modes_damp_or_propagate_the_last_sun_vector():
    w = np.array([[0.01, -0.02, 0.005]])
    ref = AttitudeReference.regulation(np.eye(3))
    s0 = np.array([[0.6, 0.0, 0.8]])
    lit = DirectionMeasurement(np.eye(3)[None], w, direction=s0, valid=np.array([True]))
    dark = DirectionMeasurement(
        np.eye(3)[None], w, direction=np.zeros((1, 3)), valid=np.array([False])
    )  # noqa: E501
    damp = SunAcquisitionLaw(0.05, 0.4, body_axis=Z)
    damp.reset(0.0, 1)
    np.testing.assert_allclose(damp.command(0.0, lit, ref), 0.05 * np.cross(Z, s0) - 0.4 * w)
    np.testing.assert_allclose(damp.command(0.5, dark, ref), -0.4 * w)
    assert math.isnan(damp.diagnostics()["sun_angle"][0])
    prop = SunAcquisitionLaw(0.05, 0.4, body_axis=Z, eclipse="propagate")
    prop.reset(0.0, 1)
    prop.command(0.0, lit, ref)
    s1 = so3.exp(-2.0 * w[0]) @ s0[0]  # ṡ = s × ω over 2 s
    np.testing.assert_allclose(prop.command(2.0, dark, ref), 0.05 * np.cross(Z, s1) - 0.4 * w)
    # no Sun yet: propagation has nothing to carry, it damps
    fresh = SunAcquisitionLaw(0.05, 0.4, eclipse="propagate")
    fresh.reset(0.0, 1)
    np.testing.assert_allclose(fresh.command(0.0, dark, ref), -0.4 * w)
    # the torque box scales the command as a vector
    boxed = SunAcquisitionLaw(0.05, 0.4, body_axis=Z, max_torque=0.001)
    boxed.reset(0.0, 1)
    u = boxed.command(0.0, lit, ref)
    full = 0.05 * np.cross(Z, s0) - 0.4 * w
    assert np.abs(u).max() == pytest.approx(0.001)
    np.testing.assert_allclose(u / np.linalg.norm(u), full / np.linalg.norm(full))


def test_law_bad_input_names_the_key():
    for kw, key in (
        ({"k_p": 0.0}, "k_p"),
        ({"k_d": -1.0}, "k_d"),
        ({"body_axis": [0, 0, 0]}, "body_axis"),
        ({"max_torque": [1.0, -1.0, 1.0]}, "max_torque"),
        ({"eclipse": "hold"}, "eclipse"),
    ):
        args = {"k_p": 1.0, "k_d": 1.0, **kw}
        with pytest.raises(ValueError, match=f"^{key}:"):
            SunAcquisitionLaw(**args)
    with pytest.raises(ValueError, match="^direction:"):
        DirectionMeasurement(np.eye(3)[None], np.zeros((1, 3)), direction=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="^valid:"):
        DirectionMeasurement(
            np.eye(3)[None], np.zeros((1, 3)), direction=np.zeros((1, 3)), valid=np.ones(1)
        )


def test_hook_gives_a_coarse_attitude_consistent_with_the_sun():
    css = CoarseSunSensors(ORBIT, noise_std=0.0, threshold=0.0)
    hook = SunSensorGyro(css, "sun", "gyro")
    hook.reset(0.0, 3)
    R = so3.exp(_unit(np.random.default_rng(5), 3))
    y = css.measure(0.0, R, None, np.random.default_rng(0))
    truth = AttitudeState(R, np.zeros((3, 3)))
    m = hook(0.0, {"sun": y, "gyro": np.ones((3, 3)) * 1e-3}, truth)
    s_I = css.sun(0.0)[0]
    np.testing.assert_allclose(m.direction, np.einsum("bji,j->bi", R, s_I), atol=1e-12)
    np.testing.assert_allclose(
        np.einsum("bij,bj->bi", m.R, m.direction), np.tile(s_I, (3, 1)), atol=1e-12
    )  # noqa: E501
    assert m.valid.all() and hook.required() == ("sun", "gyro")


# --------------------------------------------------------------------------- the scenario


def test_acquires_the_sun_from_every_start_and_holds_through_the_eclipse():
    from benchmarks.safe_mode import format_table, sun_acquisition_run

    run = sun_acquisition_run(20, seed=0)
    # every start: within 5° of the Sun before the eclipse, and stays there
    assert np.all(np.isfinite(run.time_to_acquire_s))
    assert run.time_to_acquire_s.max() < run.eclipse_entry_s - 300.0
    assert run.sun_angle_error_deg.max() < 3.5  # coarse: the 3 % threshold, noise, gyro bias
    # in the shadow: no Sun, rate damping only; the rate stays small (gyro bias, gravity
    # gradient) and the axis drifts slowly
    ecl = run.eclipse
    assert ecl.any() and run.rate_deg_s[ecl].max() < 0.05
    assert np.all(run.rate_deg_s[ecl] < 0.05)
    # and the Sun is found again after the exit
    assert np.all(np.isfinite(run.reacquire_s)) and run.reacquire_s.max() < 400.0
    assert "| damp | 20 |" in format_table({"damp": run})
    with pytest.raises(ValueError, match="^t_final:"):
        sun_acquisition_run(1, t_final=2000.0)
    with pytest.raises(ValueError, match="^eclipse:"):
        sun_acquisition_run(1, eclipse="hold")
