"""No silent failure in the plant and benchmark layers (issue 12): the named examples of each
class of fault, and the formulas changed to stay finite checked against an independent route."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.metrics import compute_metrics, settling_time, trapezoid
from benchmarks.runner import run_suite
from benchmarks.scenarios import SpacecraftSpec
from benchmarks.unwinding import UnwindingConfig
from spacecraft import (
    CircularOrbit,
    FlexibleModes,
    GeneralizedSingularityRobust,
    PseudoInverse,
    PseudoInverseNullMotion,
    RateGyro,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    StarTracker,
    StarTrackerGyro,
    jitter_estimate,
)
from spacecraft.orbit import two_body_acceleration
from spacecraft.payload import closed_loop_gain
from spacecraft.steering import jacobian_singularity_measure, pseudo_inverse

CLUSTER = SgcmgPyramid()
DELTA = np.array([0.785, -0.785, 0.785, -0.785])
A = CLUSTER.jacobian(DELTA)


@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: FlexibleModes([[2.0, 0.0, 0.5]], frequencies=[1e300]), "frequencies"),
        (lambda: CircularOrbit(n=np.array([0.001, 0.002])), "n"),
        (lambda: RateGyro(period=np.array([0.1, 0.2])), "period"),
        (lambda: StarTracker(period=np.array([0.1, 0.2])), "period"),
        (lambda: StarTrackerGyro(attitude=""), "attitude"),
        (lambda: SingularityRobust(lambda0="abc"), "lambda0"),
        (lambda: SgcmgActuator(cluster="pyramid"), "cluster"),
        (lambda: UnwindingConfig(axis=(0.0, 0.0, 0.0)), "axis"),
        (lambda: SpacecraftSpec(beta_deg=90.0), "beta_deg"),
        (lambda: run_suite(["slew-90"]), "scenarios"),
        (lambda: compute_metrics(None), "result"),
        (lambda: jitter_estimate(np.ones(3), np.diag([1.0, 2.0, 3.0]), 2.0, 0.0, 2.0), "zeta"),
    ],
)
def test_named_faults_raise_naming_the_argument(make, name):
    with pytest.raises((ValueError, TypeError)) as info:
        make()
    assert str(info.value).startswith(f"{name}:"), str(info.value)


@pytest.mark.parametrize(
    "law",
    [
        PseudoInverse(),
        SingularityRobust(),
        GeneralizedSingularityRobust(),
        PseudoInverseNullMotion(cluster=CLUSTER),
    ],
)
def test_steering_laws_never_return_nan_for_a_huge_command(law):
    """Either the rates overflow float64 on the way (a clear error naming ``hdot_cmd``) or they
    are finite and realise the command (the LAPACK route of the null-motion law solves it)."""
    h = np.array([1e300, 0.0, 0.0])
    try:
        out = law(A, h, DELTA)
    except ValueError as exc:
        assert str(exc).startswith("hdot_cmd: the gimbal rates overflow"), str(exc)
    else:
        assert np.all(np.isfinite(out))
        np.testing.assert_allclose(A @ out, h, rtol=1e-9, atol=1e-9 * np.abs(h).max())


@pytest.mark.parametrize("law", [PseudoInverse(), SingularityRobust()])
def test_steering_laws_are_homogeneous_in_the_jacobian_scale(law):
    """A huge Jacobian is solved at unit scale: δ̇(cA) = δ̇(A)/c for PI and SR (their damping
    scales with s² ∝ c²); an independent check of the rescaled route against the plain one."""
    h = np.array([0.1, -0.2, 0.3])
    c = 1e200
    np.testing.assert_allclose(law(c * A, h) * c, law(A, h), rtol=1e-12)


def test_pseudo_inverse_and_measure_of_a_huge_jacobian():
    c = 1e250
    np.testing.assert_allclose(pseudo_inverse(c * A) * c, np.linalg.pinv(A), rtol=1e-8)
    np.testing.assert_allclose(
        jacobian_singularity_measure(c * A), jacobian_singularity_measure(A), rtol=1e-12
    )


def test_two_body_acceleration_is_finite_and_scales_as_inverse_square():
    r = np.array([7.0e6, 1.0e5, -2.0e5])
    a = two_body_acceleration(r)
    np.testing.assert_allclose(a, -3.986004418e14 * r / np.linalg.norm(r) ** 3, rtol=1e-13)
    np.testing.assert_allclose(two_body_acceleration(1e3 * r), a / 1e6, rtol=1e-13)
    far = two_body_acceleration(1e200 * r)  # |r|³ overflows; the unit-vector form does not
    assert np.all(np.isfinite(far)) and np.all(np.abs(far) < 1e-300)


def test_closed_loop_gain_matches_the_complex_formula_and_rejects_resonance():
    w = np.array([0.1, 1.0, 3.0])
    J, wn, z = 2.0, 1.2, 0.3
    complex_form = 1.0 / (J * np.abs(wn**2 - w**2 + 2j * z * wn * w))
    np.testing.assert_allclose(closed_loop_gain(J, w, wn, z), complex_form, rtol=1e-14)
    with pytest.raises(ValueError, match="^zeta: the gain is infinite"):
        closed_loop_gain(J, np.array([wn]), wn, 0.0)
    with pytest.raises(ValueError, match="^omega: the open-loop gain"):
        closed_loop_gain(J, np.array([0.0]), 0.0, 0.0)


def test_metrics_helpers_accept_lists_and_check_shapes():
    assert trapezoid([0.0, 1.0, 4.0], [0.0, 1.0, 2.0]) == pytest.approx(0.5 + 2.5)
    t = [0.0, 1.0, 2.0, 3.0]
    # crosses 1.0 between t = 1 (err 5) and t = 2 (err 0.5): linear interpolation
    assert settling_time(t, [10.0, 5.0, 0.5, 0.2], 1.0) == pytest.approx(1.0 + 4.0 / 4.5)
    with pytest.raises(ValueError, match="^t: expected shape"):
        trapezoid([0.0, 1.0, 4.0], [0.0, 1.0])
    with pytest.raises(ValueError, match="^threshold:"):
        settling_time(t, [10.0, 5.0, 0.5, 0.2], "abc")
