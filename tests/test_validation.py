"""Bad input → ValueError naming the argument (SPEC §9), for the shared validators."""

import numpy as np
import pytest
from conftest import SEED000_J

from liecontrol._validation import (
    as_array,
    check_inertia,
    check_inertia_3x3,
    check_nonnegative,
    check_positive,
    check_rotation_matrix,
    check_spd,
    rotations_pass_fast,
)
from liecontrol.control import AttitudeReference, ConstantAttitude
from liecontrol.control.base import check_state_batch

J_SEED000 = SEED000_J


def test_rotation_accepts_rotations_and_batches():
    R = np.broadcast_to(np.eye(3), (2, 4, 3, 3))
    assert check_rotation_matrix(R, "R").shape == (2, 4, 3, 3)


@pytest.mark.parametrize(
    ("M", "fragment"),
    [
        (np.eye(3) * 1.01, "not orthonormal"),
        (np.diag([1.0, 1.0, -1.0]), "reflection"),
        (np.full((3, 3), np.nan), "non-finite"),
        (np.eye(4), "expected shape"),
        ("abc", "cannot be converted"),
    ],
)
def test_rotation_rejects(M, fragment):
    with pytest.raises(ValueError, match=rf"^R_target: .*{fragment}"):
        check_rotation_matrix(M, "R_target")


def test_inertia_accepts_seed000():
    out = check_inertia(J_SEED000, "J")
    np.testing.assert_array_equal(out, J_SEED000)


@pytest.mark.parametrize(
    ("J", "fragment"),
    [
        (np.array([[1.0, 0.1, 0], [0, 1, 0], [0, 0, 1]]), "not symmetric"),
        (np.diag([1.0, -1.0, 1.0]), "not positive definite"),
        (np.diag([1.0, 1.0, 3.0]), "triangle inequality"),
        (np.diag([1.0, np.inf, 1.0]), "non-finite"),
    ],
)
def test_inertia_rejects(J, fragment):
    with pytest.raises(ValueError, match=rf"^J_plant: .*{fragment}"):
        check_inertia(J, "J_plant")


def test_inertia_3x3_is_check_inertia_for_one_matrix():
    np.testing.assert_array_equal(check_inertia_3x3(J_SEED000, "J"), check_inertia(J_SEED000))
    with pytest.raises(ValueError, match=r"^J_est: expected shape \(3, 3\), got \(2, 3, 3\)"):
        check_inertia_3x3(np.stack([J_SEED000, J_SEED000]), "J_est")
    with pytest.raises(ValueError, match="^J: not positive definite"):
        check_inertia_3x3(np.diag([1.0, -1.0, 1.0]))


def test_inertia_3x3_checks_the_shape_before_the_physics():
    # a (2, 2) matrix gets the single-matrix message, not check_inertia's "(..., 3, 3)"
    with pytest.raises(ValueError, match=r"^inertia: expected shape \(3, 3\), got \(2, 2\)"):
        check_inertia_3x3(np.eye(2), "inertia")


def _accepted(R):
    try:
        check_rotation_matrix(R, "R")
    except ValueError:
        return False
    return True


def _rotation_cases():
    """Rotations near and past the tolerance, reflections, non-finite, batches, other dtypes."""
    rng = np.random.default_rng(7)
    q = rng.normal(size=(6, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    Rs = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )
    cases = [Rs[0], Rs, Rs[:1], Rs.reshape(2, 3, 3, 3), Rs[:0], np.eye(3)]
    for eps in (3e-10, 2e-9):  # inside and outside ROTATION_ATOL = 1e-9 on RᵀR − I
        P = Rs.copy()
        P[2, 0, 1] += eps
        cases += [P, P[2]]
    F = Rs.copy()
    F[4] = F[4] @ np.diag([1.0, 1.0, -1.0])
    cases += [F, F[4], -np.eye(3)]
    for bad in (np.nan, np.inf):
        N = Rs.copy()
        N[1, 2, 2] = bad
        cases += [N, N[1]]
    return cases


@pytest.mark.parametrize("R", _rotation_cases())
def test_rotations_pass_fast_accepts_exactly_what_the_full_check_accepts(R):
    assert rotations_pass_fast(R) == _accepted(R)


@pytest.mark.parametrize(
    "R",
    [np.eye(3).tolist(), np.eye(3, dtype=np.float32), np.eye(3, dtype=int), np.eye(4), "abc"],
)
def test_rotations_pass_fast_defers_anything_not_a_float64_stack(R):
    # False only means "run check_rotation_matrix" (which converts or raises)
    assert rotations_pass_fast(R) is False


def test_check_spd_eigenvalues_and_messages():
    A = np.array([[2.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 3.0]])
    np.testing.assert_allclose(check_spd(A, "W"), np.sort(np.linalg.eigvals(A).real))
    with pytest.raises(ValueError, match=r"^K_x: gain matrix not symmetric \(max \|K − Kᵀ\|"):
        check_spd(A + np.triu(np.ones((3, 3)), 1), "K_x", symbol="K", what="gain matrix ")
    with pytest.raises(ValueError, match=r"^G: not positive definite \(smallest eigenvalue"):
        check_spd(np.diag([1.0, 0.0, 2.0]), "G")
    # a relative floor rejects an eigenvalue at round-off level of the largest
    check_spd(np.diag([1e-13, 1.0]), "W")
    with pytest.raises(ValueError, match=r"^W: not positive definite"):
        check_spd(np.diag([1e-13, 1.0]), "W", pd_rtol=1e-12)
    with pytest.raises(ValueError, match=r"^W: expected a square matrix"):
        check_spd(np.ones((2, 3)), "W")


def test_state_batch_checks_shapes_and_reset_size():
    R, w = np.broadcast_to(np.eye(3), (4, 3, 3)), np.zeros((4, 3))
    assert check_state_batch(R, w, 4) == 4
    with pytest.raises(ValueError, match=r"^state: batch size 4 differs from reset\(batch_size=2"):
        check_state_batch(R, w, 2)
    with pytest.raises(ValueError, match=r"^state: expected R \(B, 3, 3\) and omega \(B, 3\)"):
        check_state_batch(R, np.zeros((3, 3)), 4)
    with pytest.raises(ValueError, match="^state: expected"):
        check_state_batch(np.eye(3), np.zeros(3), 1)


def test_positive_and_nonnegative():
    assert check_positive(0.1, "dt") == 0.1
    assert check_nonnegative(0.0, "zeta") == 0.0
    with pytest.raises(ValueError, match="^dt: must be > 0"):
        check_positive(0.0, "dt")
    with pytest.raises(ValueError, match="^zeta: must be >= 0"):
        check_nonnegative([0.1, -0.2], "zeta")
    with pytest.raises(ValueError, match="^dt: contains 1 non-finite"):
        check_positive(np.nan, "dt")


def test_as_array_does_not_mutate_or_copy_needlessly():
    a = np.arange(6.0).reshape(2, 3)
    b = as_array(a, "a", (3,))
    assert b is a
    with pytest.raises(ValueError, match=r"^a: expected shape \(\.\.\., 4\)"):
        as_array(a, "a", (4,))


def test_constant_reference_validates_and_is_read_only():
    ref = ConstantAttitude(np.eye(3))
    sample = ref(12.0)
    assert isinstance(sample, AttitudeReference)
    np.testing.assert_array_equal(sample.omega_d, np.zeros(3))
    with pytest.raises(ValueError):
        sample.R_d[0, 0] = 2.0
    with pytest.raises(ValueError, match="^R_d: not orthonormal"):
        ConstantAttitude(np.eye(3) * 2.0)


@pytest.mark.parametrize("value", [None, [1.0, None, 2.0]])
def test_none_is_named_as_none_not_as_a_non_finite_value(value):
    with pytest.raises(ValueError, match=r"^speed: expected real numbers, got None"):
        as_array(value, "speed")
