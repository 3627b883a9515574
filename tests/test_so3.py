"""Tests for liecontrol.lie.so3 (SPEC §2): against scipy's Rotation, finite differences, SVD and
the Haar angle law, on random inputs (hypothesis) and on fixed grids near angles 0 and π."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import stats
from scipy.linalg import expm, polar
from scipy.spatial.transform import Rotation

from liecontrol.lie import so3

PI = np.pi
HYP = settings(max_examples=100, deadline=None)
HYP_SLOW = settings(max_examples=40, deadline=None)  # examples that call scipy.linalg.expm

# ---------------------------------------------------------------- fixed grids near 0 and π
_rng = np.random.default_rng(20240601)
_AXES = np.vstack([np.eye(3), -np.eye(3), np.ones(3) / np.sqrt(3.0), _rng.normal(size=(8, 3))])
_AXES /= np.linalg.norm(_AXES, axis=1, keepdims=True)
SMALL_ANGLES = np.concatenate([10.0 ** np.arange(-12.0, -3.5, 0.5), [0.0099, 0.01, 0.0999, 0.1]])
NEAR_PI_OFFSETS = np.array([1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-6, 1e-4, 1e-3, 0.02, 0.0447, 0.05])
MID_ANGLES = np.array([0.3, 1.0, 2.0, 2.5, 3.0])
W_SMALL = (SMALL_ANGLES[:, None, None] * _AXES[None]).reshape(-1, 3)
W_MID = (MID_ANGLES[:, None, None] * _AXES[None]).reshape(-1, 3)
W_NEAR_PI = ((PI - NEAR_PI_OFFSETS)[:, None, None] * _AXES[None]).reshape(-1, 3)
W_HALF_TURN = PI * _AXES
W_GRID = np.vstack([np.zeros((1, 3)), W_SMALL, W_MID, W_NEAR_PI])  # all with |w| < π − 1e-12


def _half_turn_matrices() -> np.ndarray:
    """Exact half-turns: diag(1, −1, −1) and permutations, plus 2nnᵀ − I about random axes."""
    exact = [np.diag(d) for d in ([1.0, -1, -1], [-1.0, 1, -1], [-1.0, -1, 1])]
    n = _AXES[:, :, None]
    general = 2.0 * n * np.swapaxes(n, -1, -2) - np.eye(3)
    return np.concatenate([np.array(exact), general])


HALF_TURNS = _half_turn_matrices()

unit = arrays(np.float64, 3, elements=st.floats(-1.0, 1.0)).filter(
    lambda a: np.linalg.norm(a) > 1e-3
)
angles = st.floats(0.0, PI - 1e-9)
vectors = arrays(np.float64, 3, elements=st.floats(-10.0, 10.0))


def _rotvec(axis: np.ndarray, theta: float) -> np.ndarray:
    return axis / np.linalg.norm(axis) * theta


def _rel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """‖a − b‖ / ‖b‖ rowwise, with absolute error when b = 0."""
    nb = np.linalg.norm(b, axis=-1)
    return np.linalg.norm(a - b, axis=-1) / np.where(nb > 0, nb, 1.0)


def _ortho_err(R: np.ndarray) -> float:
    return float(np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max())


# ---------------------------------------------------------------- hat / vee
@HYP
@given(vectors, vectors)
def test_hat_is_cross_product_and_vee_inverts_it(w, v):
    W = so3.hat(w)
    np.testing.assert_allclose(W @ v, np.cross(w, v), atol=1e-12)
    np.testing.assert_array_equal(W, -W.T)
    np.testing.assert_array_equal(so3.vee(W), w)


# ---------------------------------------------------------------- exp
def test_exp_matches_scipy_on_grids_and_random():
    rng = np.random.default_rng(1)
    w = np.vstack([W_GRID, W_HALF_TURN, rng.normal(size=(2000, 3)) * 3.0, [[0.0, 0.0, 2 * PI]]])
    ref = Rotation.from_rotvec(w).as_matrix()
    assert np.abs(so3.exp(w) - ref).max() <= 1e-13


@HYP_SLOW
@given(unit, st.floats(0.0, 4 * PI))
def test_exp_matches_scipy_and_expm(axis, theta):
    w = _rotvec(axis, theta)
    R = so3.exp(w)
    np.testing.assert_allclose(R, Rotation.from_rotvec(w).as_matrix(), rtol=0, atol=1e-13)
    np.testing.assert_allclose(R, expm(so3.hat(w)), rtol=0, atol=1e-12)
    assert _ortho_err(R) < 1e-14
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)


def test_exp_at_zero_is_exact_identity():
    np.testing.assert_array_equal(so3.exp(np.zeros(3)), np.eye(3))
    np.testing.assert_array_equal(so3.exp(np.array([1e-300, 0.0, 0.0]))[0], [1.0, 0.0, 0.0])


# ---------------------------------------------------------------- log
def test_log_exp_round_trip_on_grids():
    w = W_GRID
    assert np.linalg.norm(w, axis=1).max() <= PI - 1e-12
    assert _rel(so3.log(so3.exp(w)), w).max() <= 1e-12


@HYP
@given(unit, angles)
def test_log_exp_round_trip_random(axis, theta):
    w = _rotvec(axis, theta)
    assert _rel(so3.log(so3.exp(w)), w) <= 1e-12


def test_exp_log_round_trip_all_rotations_including_half_turns():
    rng = np.random.default_rng(2)
    R = np.concatenate(
        [
            HALF_TURNS,
            so3.exp(W_HALF_TURN),
            so3.exp(W_GRID),
            so3.random(rng, 3000),
            np.eye(3)[None],
        ]
    )
    w = so3.log(R)
    assert np.all(np.isfinite(w))
    assert np.linalg.norm(w, axis=1).max() <= PI + 1e-15
    assert np.abs(so3.exp(w) - R).max() <= 1e-12


def test_log_of_half_turns_has_angle_pi_and_the_right_axis():
    w = so3.log(HALF_TURNS)
    np.testing.assert_allclose(np.linalg.norm(w, axis=1), PI, rtol=0, atol=1e-15)
    n = w / PI
    # the axis is defined up to sign at θ = π
    np.testing.assert_allclose(
        np.abs(np.sum(n * np.vstack([np.eye(3), _AXES]), axis=1)), 1.0, atol=1e-15
    )


def test_log_matches_scipy_and_angle_is_accurate():
    rng = np.random.default_rng(3)
    R = so3.random(rng, 5000)
    np.testing.assert_allclose(so3.log(R), Rotation.from_matrix(R).as_rotvec(), rtol=0, atol=1e-13)
    w = np.vstack([W_GRID, W_HALF_TURN])
    th = np.linalg.norm(w, axis=1)
    np.testing.assert_allclose(so3.angle(so3.exp(w)), th, rtol=1e-12, atol=1e-15)


# ---------------------------------------------------------------- group axioms
@HYP
@given(unit, angles, unit, angles, unit, angles)
def test_group_axioms(a1, t1, a2, t2, a3, t3):
    R1, R2, R3 = (so3.exp(_rotvec(a, t)) for a, t in ((a1, t1), (a2, t2), (a3, t3)))
    lhs = so3.compose(so3.compose(R1, R2), R3)
    rhs = so3.compose(R1, so3.compose(R2, R3))
    np.testing.assert_allclose(lhs, rhs, atol=1e-14)
    np.testing.assert_allclose(so3.compose(R1, so3.inverse(R1)), np.eye(3), atol=1e-14)
    np.testing.assert_allclose(so3.compose(so3.identity(), R1), R1, atol=0)
    np.testing.assert_allclose(so3.inverse(so3.inverse(R1)), R1, atol=0)
    # one-parameter subgroup: exp(s w) exp(t w) = exp((s + t) w)
    w = _rotvec(a1, t1)
    np.testing.assert_allclose(so3.exp(0.3 * w) @ so3.exp(0.7 * w), so3.exp(w), atol=1e-14)
    p = np.array([0.3, -1.2, 2.0])
    np.testing.assert_allclose(so3.act(R1, so3.act(R2, p)), so3.act(R1 @ R2, p), atol=1e-13)


# ---------------------------------------------------------------- Jacobians
def _fd_right(w: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Columns (log(exp(w)ᵀ exp(w + h eᵢ)) − log(exp(w)ᵀ exp(w − h eᵢ)))/(2h)."""
    Rt = so3.exp(w).T
    E = h * np.eye(3)
    return ((so3.log(Rt @ so3.exp(w + E)) - so3.log(Rt @ so3.exp(w - E))) / (2 * h)).T


def _fd_left(w: np.ndarray, h: float = 1e-6) -> np.ndarray:
    Rt = so3.exp(w).T
    E = h * np.eye(3)
    return ((so3.log(so3.exp(w + E) @ Rt) - so3.log(so3.exp(w - E) @ Rt)) / (2 * h)).T


JAC_W = np.vstack(
    [
        1e-9 * _AXES[:3],
        0.0999 * _AXES[3:6],
        0.1001 * _AXES[6:9],
        W_MID,
        (PI - 1e-3) * _AXES[:4],
        2.0 * PI / 3 * _AXES[4:6],
    ]
)


@pytest.mark.parametrize("w", JAC_W, ids=lambda w: f"|w|={np.linalg.norm(w):.4g}")
def test_jacobians_against_finite_differences(w):
    np.testing.assert_allclose(so3.right_jacobian(w), _fd_right(w), atol=2e-8)
    np.testing.assert_allclose(so3.left_jacobian(w), _fd_left(w), atol=2e-8)
    I3 = np.eye(3)
    np.testing.assert_allclose(so3.right_jacobian(w) @ so3.right_jacobian_inv(w), I3, atol=1e-12)
    np.testing.assert_allclose(so3.left_jacobian(w) @ so3.left_jacobian_inv(w), I3, atol=1e-12)
    np.testing.assert_allclose(so3.left_jacobian(w), so3.right_jacobian(-w), atol=0)
    np.testing.assert_allclose(so3.left_jacobian(w), so3.right_jacobian(w).T, atol=1e-15)
    # J_l = R J_r (Ad_{exp w} J_r)
    np.testing.assert_allclose(so3.left_jacobian(w), so3.exp(w) @ so3.right_jacobian(w), atol=1e-14)


@HYP
@given(unit, st.floats(0.0, 3.0))
def test_jacobian_inverses_random(axis, theta):
    w = _rotvec(axis, theta)
    I3 = np.eye(3)
    np.testing.assert_allclose(so3.right_jacobian(w) @ so3.right_jacobian_inv(w), I3, atol=1e-12)
    np.testing.assert_allclose(so3.left_jacobian_inv(w) @ so3.left_jacobian(w), I3, atol=1e-12)


def test_jacobian_coefficients_continuous_at_series_switch():
    # the closed forms and the Taylor branches must agree where they meet
    axis = _AXES[-1]
    for th in (0.01, 0.1):
        lo, hi = so3.right_jacobian(axis * th * (1 - 1e-12)), so3.right_jacobian(axis * th)
        assert np.abs(lo - hi).max() < 1e-13
        lo, hi = so3.right_jacobian_inv(axis * th * (1 - 1e-12)), so3.right_jacobian_inv(axis * th)
        assert np.abs(lo - hi).max() < 1e-13


# ---------------------------------------------------------------- adjoint
@HYP_SLOW
@given(unit, angles, vectors, vectors)
def test_adjoint_identities(axis, theta, w, v):
    R = so3.exp(_rotvec(axis, theta))
    np.testing.assert_allclose(so3.exp(so3.adjoint(R) @ w), R @ so3.exp(w) @ R.T, atol=1e-12)
    # ad_w v = [w^, v^]^∨ = w × v
    bracket = so3.vee(so3.hat(w) @ so3.hat(v) - so3.hat(v) @ so3.hat(w))
    np.testing.assert_allclose(so3.ad(w) @ v, bracket, atol=1e-11)
    # Ad_{exp(w)} = expm(ad_w)
    np.testing.assert_allclose(so3.adjoint(so3.exp(w)), expm(so3.ad(w)), atol=1e-11)


# ---------------------------------------------------------------- distance / interpolation
@HYP
@given(unit, angles, unit, angles)
def test_distance_and_interpolation(a0, t0, a1, t1):
    R0 = so3.exp(_rotvec(a0, t0))
    w = _rotvec(a1, t1)
    R1 = R0 @ so3.exp(w)
    assert so3.distance(R0, R1) == pytest.approx(t1, abs=1e-12)
    # bi-invariance
    Q = so3.exp(np.array([0.3, -0.2, 1.1]))
    assert so3.distance(Q @ R0, Q @ R1) == pytest.approx(t1, abs=1e-12)
    assert so3.distance(R0 @ Q, R1 @ Q) == pytest.approx(t1, abs=1e-12)
    np.testing.assert_allclose(so3.interpolate(R0, R1, 0.0), R0, atol=1e-14)
    np.testing.assert_allclose(so3.interpolate(R0, R1, 1.0), R1, atol=1e-12)
    Rm = so3.interpolate(R0, R1, 0.25)
    np.testing.assert_allclose(Rm, R0 @ so3.exp(0.25 * w), atol=1e-12)
    assert so3.distance(R0, Rm) == pytest.approx(0.25 * t1, abs=1e-12)


# ---------------------------------------------------------------- batching
BATCHES = [(), (5,), (2, 3)]


@pytest.mark.parametrize("shape", BATCHES, ids=str)
def test_batched_calls_equal_one_by_one(shape):
    rng = np.random.default_rng(4)
    w = rng.normal(size=shape + (3,)) * 2.0
    v = rng.normal(size=shape + (3,))
    R = so3.random(rng, shape)
    R2 = so3.random(rng, shape)
    s = rng.uniform(size=shape)
    M = R + 1e-3 * rng.normal(size=shape + (3, 3))
    batched = {
        "hat": so3.hat(w),
        "vee": so3.vee(so3.hat(w)),
        "exp": so3.exp(w),
        "log": so3.log(R),
        "angle": so3.angle(R),
        "jl": so3.left_jacobian(w),
        "jr": so3.right_jacobian(w),
        "jli": so3.left_jacobian_inv(w),
        "jri": so3.right_jacobian_inv(w),
        "Ad": so3.adjoint(R),
        "ad": so3.ad(w),
        "compose": so3.compose(R, R2),
        "inverse": so3.inverse(R),
        "act": so3.act(R, v),
        "distance": so3.distance(R, R2),
        "interpolate": so3.interpolate(R, R2, s),
        "project": so3.project(M),
    }
    for key, value in batched.items():
        assert value.shape[: len(shape)] == shape, key
    for idx in np.ndindex(*shape):
        single = {
            "hat": so3.hat(w[idx]),
            "vee": so3.vee(so3.hat(w[idx])),
            "exp": so3.exp(w[idx]),
            "log": so3.log(R[idx]),
            "angle": so3.angle(R[idx]),
            "jl": so3.left_jacobian(w[idx]),
            "jr": so3.right_jacobian(w[idx]),
            "jli": so3.left_jacobian_inv(w[idx]),
            "jri": so3.right_jacobian_inv(w[idx]),
            "Ad": so3.adjoint(R[idx]),
            "ad": so3.ad(w[idx]),
            "compose": so3.compose(R[idx], R2[idx]),
            "inverse": so3.inverse(R[idx]),
            "act": so3.act(R[idx], v[idx]),
            "distance": so3.distance(R[idx], R2[idx]),
            "interpolate": so3.interpolate(R[idx], R2[idx], s[idx]),
            "project": so3.project(M[idx]),
        }
        for key, value in single.items():
            # one element takes the Python-float route: same formulas, entries summed in
            # another order (a few ulp on large entries)
            np.testing.assert_allclose(
                batched[key][idx], value, rtol=1e-14, atol=1e-15, err_msg=key
            )


def test_inputs_are_not_mutated_and_broadcasting_works():
    rng = np.random.default_rng(5)
    w = rng.normal(size=(4, 3))
    w0 = w.copy()
    R = so3.random(rng, 4)
    R0 = R.copy()
    so3.exp(w), so3.log(R), so3.project(R), so3.left_jacobian(w), so3.interpolate(R, R, 0.5)
    np.testing.assert_array_equal(w, w0)
    np.testing.assert_array_equal(R, R0)
    # one rotation against a batch
    assert so3.compose(R[0], R).shape == (4, 3, 3)
    assert so3.act(R[0], w).shape == (4, 3)
    # non-contiguous input views give the same numbers
    wt = np.asfortranarray(w)
    np.testing.assert_array_equal(so3.exp(wt), so3.exp(w))
    np.testing.assert_array_equal(so3.log(np.swapaxes(R, -1, -2)), -so3.log(R))


# ---------------------------------------------------------------- projection
def test_project_is_nearest_rotation_and_idempotent():
    rng = np.random.default_rng(6)
    R = so3.random(rng, 200)
    M = R + 0.05 * rng.normal(size=R.shape)
    P = so3.project(M)
    assert _ortho_err(P) < 1e-14
    assert np.all(np.linalg.det(P) > 0)
    # independent route: the orthogonal polar factor (nearest orthogonal matrix; det > 0 here)
    U = np.array([polar(m)[0] for m in M])
    np.testing.assert_allclose(P, U, atol=1e-13)
    np.testing.assert_allclose(so3.project(P), P, atol=1e-15)
    np.testing.assert_allclose(so3.project(R), R, atol=1e-14)
    # it beats every other candidate rotation in the Frobenius norm
    cand = so3.random(rng, 500)
    d_best = np.linalg.norm(M[0] - P[0])
    assert np.all(np.linalg.norm(M[0] - cand, axis=(-2, -1)) >= d_best)


def test_project_of_reflection_gives_a_rotation():
    M = np.diag([1.0, 1.0, -1.0]) + 1e-3
    P = so3.project(M)
    assert np.linalg.det(P) == pytest.approx(1.0)
    assert _ortho_err(P) < 1e-14


# ---------------------------------------------------------------- Haar sampling
def test_random_is_haar():
    rng = np.random.default_rng(7)
    R = so3.random(rng, 20000)
    assert R.shape == (20000, 3, 3)
    assert _ortho_err(R) < 1e-13
    assert np.all(np.linalg.det(R) > 0)
    theta = so3.angle(R)
    # Haar measure: angle density (1 − cos θ)/π, CDF (θ − sin θ)/π
    res = stats.kstest(theta, lambda t: (t - np.sin(t)) / PI)
    assert res.pvalue > 1e-3
    # the axis is uniform on the sphere and the mean rotation matrix is zero
    np.testing.assert_allclose(R.mean(axis=0), np.zeros((3, 3)), atol=0.03)
    axis = so3.log(R) / theta[:, None]
    res_z = stats.kstest(axis[:, 2], stats.uniform(-1, 2).cdf)
    assert res_z.pvalue > 1e-3
    # seeded: reproducible
    np.testing.assert_array_equal(
        so3.random(np.random.default_rng(8), (2, 3)), so3.random(np.random.default_rng(8), (2, 3))
    )


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("func", "arg", "name"),
    [
        (so3.exp, [1.0, np.nan, 0.0], "w"),
        (so3.exp, [1.0, 2.0], "w"),
        (so3.exp, [np.inf, 0.0, 0.0], "w"),
        (so3.hat, np.ones((2, 4)), "w"),
        (so3.log, np.full((3, 3), np.nan), "R"),
        (so3.log, np.eye(4), "R"),
        (so3.log, np.diag([np.inf, 1.0, 1.0]), "R"),
        (so3.left_jacobian, [0.1, np.nan, 0.2], "w"),
        (so3.project, np.full((3, 3), np.inf), "M"),
        (so3.vee, np.zeros(3), "W"),
        (so3.exp, "abc", "w"),
    ],
)
def test_bad_input_raises_naming_the_argument(func, arg, name):
    with pytest.raises(ValueError, match=rf"^{name}:"):
        func(arg)


def test_validate():
    R = so3.random(np.random.default_rng(9), 4)
    np.testing.assert_array_equal(so3.validate(R), R)
    bad = R.copy()
    bad[2, 0, 0] += 1e-6
    with pytest.raises(ValueError, match=r"^R: not orthonormal"):
        so3.validate(bad)
    with pytest.raises(ValueError, match=r"^R_d: .*reflection"):
        so3.validate(-R, name="R_d")
    with pytest.raises(ValueError, match=r"^R: contains 1 non-finite"):
        R2 = R.copy()
        R2[1, 1, 1] = np.nan
        so3.validate(R2)
    with pytest.raises(ValueError, match=r"^rng:"):
        so3.random(np.random.default_rng(0).integers, 3)


# ---------------------------------------------------------------- unchecked kernel (hot paths)


def test_log_angle_unchecked_is_log_and_its_angle_for_any_layout():
    """``_log_angle_unchecked`` returns log's vector bit for bit, θ = ‖ω‖ to round-off (θ checked
    against scipy's rotation-vector norm), and reads strided stacks (a transposed product, as the
    geometric PD forms it) without a different result."""
    W = np.vstack([W_SMALL, W_MID, W_NEAR_PI, PI * _AXES])
    R = so3.exp(W)
    phi, theta = so3._log_angle_unchecked(R)
    np.testing.assert_array_equal(phi, so3.log(R))
    np.testing.assert_allclose(theta, np.linalg.norm(phi, axis=-1), rtol=1e-15, atol=0)
    ref = np.linalg.norm(Rotation.from_matrix(R).as_rotvec(), axis=-1)
    np.testing.assert_allclose(theta, ref, rtol=1e-12, atol=1e-15)
    strided = np.ascontiguousarray(R.transpose(1, 0, 2)).transpose(1, 0, 2)
    assert not strided.flags.c_contiguous
    phi_s, theta_s = so3._log_angle_unchecked(strided)
    np.testing.assert_array_equal(phi_s, phi)
    np.testing.assert_array_equal(theta_s, theta)
    one_phi, one_theta = so3._log_angle_unchecked(R[3])
    assert one_phi.shape == (3,) and one_theta.shape == ()
    np.testing.assert_array_equal(one_phi, phi[3])


def test_log_floats_is_log_on_python_floats_and_defers_near_pi():
    """The one-matrix float kernel (geometric PD and MPC hot paths) agrees with log to round-off
    below log's symmetric-part switch (cos θ ≥ −0.999, θ ≤ π − 0.0447) and returns None above."""
    W = np.vstack([W_SMALL, W_MID, np.zeros((1, 3)), W_NEAR_PI, PI * _AXES])
    R = so3.exp(W)
    ref = so3.log(R)
    cos = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    for Ri, li, ci in zip(R, ref, cos, strict=True):
        out = so3._log_floats(*Ri.ravel().tolist())
        if ci < -0.999:
            assert out is None
        else:
            np.testing.assert_allclose(out, li, rtol=1e-15, atol=1e-300)
    assert so3._log_floats(*[np.nan] * 9) is None
