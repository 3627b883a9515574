"""The last silent inputs of issue 27: each raises ``ValueError``/``TypeError`` whose message
starts with the argument's name (the project convention), instead of returning a plausible
number, a non-finite one, or surfacing an anonymous numpy/LinAlg/Attribute error."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks import metrics, report, scenarios
from liecontrol.control.mpc import SO3MPC
from liecontrol.control.payload_compensation import HarmonicIdentifier
from liecontrol.errors import angular_velocity_error
from liecontrol.estimation import (
    ISTSRUKF,
    MEKF,
    SRUKF,
    STUKF,
    UKF,
    GyrolessAttitudeModel,
    ManifoldUKF,
    cholupdate,
    ut_weights,
)
from liecontrol.integrators.rk import rk4_step, rkmk4_step
from liecontrol.lie import se3
from liecontrol.lie.groups import SE3

I3 = np.eye(3)
NOT_ROTATIONS = {
    "scaled": 2.0 * I3,
    "reflection": np.diag([1.0, 1.0, -1.0]),
    "zero": np.zeros((3, 3)),
    "random": np.random.default_rng(0).random((3, 3)),
}


# ------------------------------------------------------------------ benchmarks.metrics


@pytest.mark.parametrize("bad", NOT_ROTATIONS.values(), ids=NOT_ROTATIONS.keys())
def test_error_angle_wants_rotations(bad):
    with pytest.raises(ValueError, match="^R:"):
        metrics.error_angle(bad, I3)
    with pytest.raises(ValueError, match="^R_d:"):
        metrics.error_angle(I3, bad)


@pytest.mark.parametrize("bad", NOT_ROTATIONS.values(), ids=NOT_ROTATIONS.keys())
def test_rate_error_wants_rotations(bad):
    w = np.array([0.1, 0.0, 0.0])
    with pytest.raises(ValueError, match="^R:"):
        metrics.rate_error(bad, w, I3, w)
    with pytest.raises(ValueError, match="^R_d:"):
        metrics.rate_error(I3, w, bad, w)


def test_metrics_still_accept_rotations_with_round_off():
    R = I3 + 1e-9 * np.random.default_rng(1).standard_normal((3, 3))  # a long run's drift
    assert metrics.error_angle(R, I3) < 1e-8


def test_trapezoid_wants_non_decreasing_time():
    with pytest.raises(ValueError, match="^t: must be non-decreasing"):
        metrics.trapezoid(np.ones(3), np.array([2.0, 1.0, 0.0]))
    assert metrics.trapezoid(np.ones(3), np.array([0.0, 1.0, 1.0])) == pytest.approx(1.0)


# ------------------------------------------------------------------ Lie groups, integrators


@pytest.mark.parametrize("xi", [[0, 0, 0, np.inf, 0, 0], [np.inf, 0, 0, 0, 0, 0],
                                [0.3, 0, 0, 0, -np.inf, 0]])  # fmt: skip
def test_se3_exp_of_an_infinite_twist(xi):
    xi = np.array(xi, dtype=float)
    with pytest.raises(ValueError, match="^xi"):
        se3.exp(xi)
    with pytest.raises(ValueError, match="^xi"):
        SE3.exp(xi)
    with pytest.raises(ValueError, match="^xi"):
        se3.exp(np.stack([xi, xi]))


def test_se3_exp_of_a_huge_twist_is_finite_or_named():
    g = se3.exp(np.array([0.0, 0.0, 0.0, 1e300, 0.0, 0.0]))
    assert np.all(np.isfinite(g)) and g[0, 3] == 1e300
    with pytest.raises(ValueError, match="^xi"):  # V v overflows: (0.84 + 0.46) · 1.7e308
        se3.exp(np.array([1.0, 0.0, 0.0, 0.0, 1.7e308, -1.7e308]))


def test_se3_distance_of_a_huge_translation():
    g = np.eye(4)
    g[0, 3] = 1e300
    assert se3.distance(np.eye(4), g) == pytest.approx(1e300)
    assert SE3(g).distance(SE3(np.eye(4))) == pytest.approx(1e300)
    g2 = np.eye(4)
    g2[0, 3] = -1.7e308
    g[0, 3] = 1.7e308
    with pytest.raises(ValueError, match="^g2"):
        se3.distance(g2, g)


def test_rkmk4_step_with_a_huge_step():
    def f(t, R, x):
        return np.broadcast_to([0.1, 0.2, 0.3], x.shape[:-1] + (3,)), x

    with pytest.raises(ValueError, match="^h"):
        rkmk4_step(f, 0.0, I3, np.ones(2), 1e300)
    R1, x1 = rkmk4_step(f, 0.0, I3, np.ones(2), 0.1)
    assert np.all(np.isfinite(R1)) and np.all(np.isfinite(x1))


def test_rk4_step_with_a_huge_step():
    with pytest.raises(ValueError, match="^h"):
        rk4_step(lambda t, y: y * y, 0.0, np.ones(2), 1e300)


# ------------------------------------------------------------------ estimation


def test_ut_weights_with_huge_alpha():
    with pytest.raises(ValueError, match="^alpha"):
        ut_weights(7, 1e300)
    w = ut_weights(7, 1.0, 1e300)  # a huge β only weighs the central point: finite
    assert np.all(np.isfinite(w.Wc))


S3 = np.linalg.cholesky(np.diag([1.0, 2.0, 3.0]))


@pytest.mark.parametrize("v", [np.ones(4), np.ones((2, 4)), np.ones((5, 3, 2)), np.ones((5, 3))])
def test_cholupdate_names_v_for_a_mismatched_v(v):
    with pytest.raises(ValueError, match="^v:"):
        cholupdate(np.stack([S3, S3]), v)


def test_cholupdate_broadcasts_one_vector_over_a_batch():
    out = cholupdate(np.stack([S3, S3]), np.ones(3))
    np.testing.assert_allclose(out[1], cholupdate(S3, np.ones(3)))


@pytest.mark.parametrize("sign", [np.array([1.0, -1.0]), np.array([1.0]), 0.5, True, "1"])
def test_cholupdate_sign_must_be_plus_or_minus_one(sign):
    with pytest.raises(ValueError, match="^sign:"):
        cholupdate(S3, np.ones(3), sign)


MODEL = GyrolessAttitudeModel(np.diag([10.0, 12.0, 15.0]), sigma_z=2e-3)
X0 = np.r_[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
FILTERS = [(UKF, 7), (SRUKF, 7), (STUKF, 7), (ISTSRUKF, 7), (ManifoldUKF, 6), (MEKF, 6)]


@pytest.mark.parametrize(("cls", "k"), FILTERS, ids=[c.__name__ for c, _ in FILTERS])
def test_filters_name_x0_model_and_u(cls, k):
    P0 = 1e-4 * np.eye(k)
    with pytest.raises(ValueError, match="^x0:"):
        cls(MODEL, np.ones(5), P0)
    with pytest.raises(ValueError, match="^x0: quaternion"):
        cls(MODEL, np.zeros(7), P0)
    for bad in ("model", object(), np.eye(3)):
        with pytest.raises(TypeError, match="^model:"):
            cls(bad, X0, P0)
    f = cls(MODEL, X0, P0)
    with pytest.raises(ValueError, match="^u:"):
        f.predict(np.array([1e300, 0.0, 0.0]), 1.0)
    np.testing.assert_array_equal(f.x, X0)  # the failed step left the filter as it was
    f.predict(np.zeros(3), 1.0)  # and it still works
    with pytest.raises(ValueError, match="^u:"):
        f.predict(np.zeros(4), 1.0)


# ------------------------------------------------------------------ controllers, errors


def test_harmonic_identifier_batch_size_none():
    with pytest.raises(ValueError, match="^batch_size"):
        HarmonicIdentifier(1.0, batch_size=None)


def test_angular_velocity_error_names_the_argument_that_does_not_broadcast():
    R2 = np.stack([I3, I3])
    with pytest.raises(ValueError, match="^omega:"):
        angular_velocity_error(R2, np.zeros((3, 3)), I3, np.zeros(3))
    with pytest.raises(ValueError, match="^omega_d:"):
        angular_velocity_error(R2, np.zeros(3), I3, np.zeros((3, 3)))


def test_scale_principal_moments_names_its_arguments():
    J = np.diag([1.0, 2.0, 2.5])
    with pytest.raises(ValueError, match="^J:"):
        scenarios.scale_principal_moments(np.stack([J, J]), [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="^scale:"):
        scenarios.scale_principal_moments(J, np.ones((2, 3)))


MPC = dict(J=np.diag([10.0, 12.0, 15.0]), horizon=5, dt=0.1, Q=np.eye(6), R=np.eye(3), u_max=1.0)


@pytest.mark.parametrize(
    ("name", "value"),
    [("dt", 1e-300), ("R", 1e300 * np.eye(3)), ("J", np.diag([1e300] * 3)), ("horizon", 10**9)],
)
def test_so3mpc_names_what_makes_the_riccati_equation_fail(name, value):
    with pytest.raises(ValueError, match=f"^{name}:"):
        SO3MPC(**{**MPC, name: value})


# ------------------------------------------------------------------ report writers


@pytest.mark.parametrize(
    "call",
    [
        lambda p: report.write_report(None, p),
        lambda p: report.write_csv(None, p / "m.csv"),
        lambda p: report.write_json("result", p / "m.json"),
        lambda p: report.write_figures([], p),
        lambda p: report.write_sweep_report({0.03: None}, p),
    ],
    ids=["write_report", "write_csv", "write_json", "write_figures", "write_sweep_report"],
)
def test_report_writers_want_a_suite_result(call, tmp_path):
    with pytest.raises(TypeError, match="^result"):
        call(tmp_path)
