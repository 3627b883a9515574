"""SGCMG pyramid geometry, Jacobian and singularity measure (SPEC §5.2)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from spacecraft.sgcmg import MEASURE_FLOOR, SgcmgPyramid, adjugate_sym3, det_sym3

P = SgcmgPyramid()
SEED000_DELTA0 = np.deg2rad([45.0, -45.0, 45.0, -45.0])
angles = st.floats(-2 * np.pi, 2 * np.pi, allow_nan=False, allow_infinity=False)
delta_st = st.tuples(angles, angles, angles, angles).map(np.array)


def spec_unit_momenta(delta: np.ndarray, beta: float) -> np.ndarray:
    """SPEC §5.2 written out literally, one unit at a time (independent route)."""
    c, s = np.cos(beta), np.sin(beta)
    d1, d2, d3, d4 = delta
    h1 = [-c * np.sin(d1), np.cos(d1), s * np.sin(d1)]
    h2 = [-np.cos(d2), -c * np.sin(d2), s * np.sin(d2)]
    h3 = [c * np.sin(d3), -np.cos(d3), s * np.sin(d3)]
    h4 = [np.cos(d4), c * np.sin(d4), s * np.sin(d4)]
    return np.array([h1, h2, h3, h4]).T


def singular_configuration(u: np.ndarray, signs: np.ndarray, cluster: SgcmgPyramid) -> np.ndarray:
    """Gimbal angles of the singular set for singular direction u (Margulies & Aubrun 1978):
    each hᵢ points along ±(projection of u onto the plane normal to gᵢ), so every torque axis
    aᵢ = gᵢ × hᵢ is normal to u."""
    g = cluster.gimbal_axes()
    h_zero = cluster.unit_momenta(np.zeros(4))
    a_zero = cluster.jacobian(np.zeros(4)) / cluster.h0
    proj = u[:, None] - g * (g.T @ u)[None, :]
    proj = proj * signs[None, :]
    return np.arctan2((proj * a_zero).sum(0), (proj * h_zero).sum(0))


# ---------------------------------------------------------------------------- geometry
def test_unit_momenta_match_spec_formulas():
    rng = np.random.default_rng(0)
    for beta in (P.beta, 0.3, 1.2):
        cl = SgcmgPyramid(beta=beta)
        for d in rng.uniform(-4, 4, (20, 4)):
            np.testing.assert_allclose(cl.unit_momenta(d), spec_unit_momenta(d, beta), atol=1e-15)


def test_unit_momenta_are_rotations_about_gimbal_axes():
    rng = np.random.default_rng(1)
    g = P.gimbal_axes()
    np.testing.assert_allclose(np.linalg.norm(g, axis=0), 1.0, atol=1e-15)
    h_zero = P.unit_momenta(np.zeros(4))
    for d in rng.uniform(-4, 4, (10, 4)):
        H = P.unit_momenta(d)
        A = P.jacobian(d) / P.h0
        for i in range(4):
            rot = Rotation.from_rotvec(d[i] * g[:, i])
            np.testing.assert_allclose(H[:, i], rot.apply(h_zero[:, i]), atol=1e-14)
            np.testing.assert_allclose(A[:, i], np.cross(g[:, i], H[:, i]), atol=1e-14)
            np.testing.assert_allclose(g[:, i], np.cross(H[:, i], A[:, i]), atol=1e-14)


def test_momentum_zero_at_seed000_initial_angles():
    np.testing.assert_allclose(P.momentum(SEED000_DELTA0), 0.0, atol=1e-12)
    np.testing.assert_allclose(P.momentum([0.0, 0.0, 0.0, 0.0]), 0.0, atol=1e-12)


def test_momentum_is_h0_times_sum_and_envelope_along_z():
    rng = np.random.default_rng(2)
    d = rng.uniform(-4, 4, (7, 4))
    np.testing.assert_allclose(P.momentum(d), P.h0 * P.unit_momenta(d).sum(-1), rtol=1e-15)
    # all gimbals at +90°: every unit along +z, |h| = 4 h₀ sin β (momentum envelope)
    h = P.momentum(np.full(4, np.pi / 2))
    np.testing.assert_allclose(h, [0.0, 0.0, 4 * P.h0 * np.sin(P.beta)], atol=1e-10)


def test_jacobian_matches_central_differences():
    rng = np.random.default_rng(3)
    eps = 1e-6
    for d in rng.uniform(-4, 4, (10, 4)):
        fd = np.stack(
            [(P.momentum(d + eps * e) - P.momentum(d - eps * e)) / (2 * eps) for e in np.eye(4)],
            axis=-1,
        )
        np.testing.assert_allclose(P.jacobian(d), fd, atol=1e-6 * P.h0)


def test_momentum_and_jacobian_agree_with_separate_calls():
    d = np.random.default_rng(4).uniform(-4, 4, (2, 5, 4))
    h, A = P.momentum_and_jacobian(d)
    assert h.shape == (2, 5, 3) and A.shape == (2, 5, 3, 4)
    np.testing.assert_allclose(h, P.momentum(d), rtol=1e-15, atol=1e-12)
    np.testing.assert_allclose(A, P.jacobian(d), rtol=1e-15, atol=1e-12)


# ---------------------------------------------------------------------------- singularity measure
def test_adjugate_and_determinant_of_symmetric_3x3():
    rng = np.random.default_rng(5)
    X = rng.normal(size=(20, 3, 3))
    M = X + np.swapaxes(X, -1, -2)
    adj = adjugate_sym3(M)
    np.testing.assert_allclose(det_sym3(M), np.linalg.det(M), atol=1e-12)
    np.testing.assert_allclose(adj @ M, det_sym3(M)[:, None, None] * np.eye(3), atol=1e-12)


def test_measure_equals_product_of_singular_values():
    d = np.random.default_rng(6).uniform(-4, 4, (50, 4))
    sv = np.linalg.svd(P.jacobian(d) / P.h0, compute_uv=False)
    np.testing.assert_allclose(P.singularity_measure(d), sv.prod(-1), atol=1e-13)
    # Hadamard / AM–GM bound for four unit columns: m ≤ (4/3)^{3/2}
    assert np.all(P.singularity_measure(d) <= (4 / 3) ** 1.5 + 1e-12)


def test_measure_is_independent_of_h0():
    d = np.random.default_rng(7).uniform(-4, 4, (5, 4))
    np.testing.assert_allclose(
        SgcmgPyramid(h0=1.0).singularity_measure(d), P.singularity_measure(d), rtol=1e-14
    )


@settings(max_examples=60, deadline=None)
@given(delta_st)
def test_measure_gradient_matches_finite_differences(d):
    m = P.singularity_measure(d)
    if m < 0.05:  # m is not differentiable at the singular set; test away from it
        return
    eps = 1e-6
    fd = np.array(
        [
            (P.singularity_measure(d + eps * e) - P.singularity_measure(d - eps * e)) / (2 * eps)
            for e in np.eye(4)
        ]
    )
    m2, grad = P.singularity_measure_and_gradient(d)
    np.testing.assert_allclose(grad, fd, atol=1e-7)
    np.testing.assert_allclose(P.singularity_measure_gradient(d), grad, rtol=0, atol=0)
    assert m2 == pytest.approx(m, rel=1e-12, abs=1e-14)  # two code paths: round-off only


KNOWN_SINGULAR = np.deg2rad(
    [
        [90.0, 90.0, 90.0, 90.0],  # saturation (elliptic) singularity at the envelope, along +z
        [-90.0, -90.0, -90.0, -90.0],  # the same along −z
        [-90.0, 0.0, 90.0, 0.0],  # internal singularity, singular direction x, |h| = 2 c h₀
        [0.0, 90.0, 0.0, -90.0],  # internal singularity, singular direction y
    ]
)


def test_known_singular_configurations():
    m, grad = P.singularity_measure_and_gradient(KNOWN_SINGULAR)
    np.testing.assert_allclose(m, 0.0, atol=1e-7)
    assert np.all(np.isfinite(grad))
    np.testing.assert_allclose(
        np.linalg.norm(P.momentum(KNOWN_SINGULAR[2])), 2 * np.cos(P.beta) * P.h0, rtol=1e-12
    )


def test_constructed_singular_set_has_zero_measure():
    """Singular surfaces from the theory (random directions u and sign patterns ε): m ≈ 0 and u
    is orthogonal to every torque axis; non-singular neighbours have m > 0."""
    rng = np.random.default_rng(8)
    for _ in range(40):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        signs = rng.choice([-1.0, 1.0], size=4)
        d = singular_configuration(u, signs, P)
        m, grad = P.singularity_measure_and_gradient(d)
        assert m < 1e-6
        assert np.all(np.isfinite(grad))
        np.testing.assert_allclose(u @ P.jacobian(d), 0.0, atol=1e-9 * P.h0)
        assert P.singularity_measure(d + 0.05 * rng.normal(size=4)) > m


def test_gradient_finite_and_small_near_and_at_singularity():
    d_sing = KNOWN_SINGULAR[2]
    for scale in (0.0, 1e-14, 1e-10, 1e-6):
        d = d_sing + scale * np.array([1.0, -0.5, 0.3, 0.7])
        m, grad = P.singularity_measure_and_gradient(d)
        assert np.all(np.isfinite(grad)) and np.isfinite(m)
        assert np.linalg.norm(grad) < 10.0
        if m < MEASURE_FLOOR:  # below the floor the gradient fades linearly with m
            assert np.linalg.norm(grad) <= 3.0 * m / MEASURE_FLOOR + 1e-6


def test_leading_dims_and_batch_equals_elementwise():
    d = np.random.default_rng(9).uniform(-4, 4, (3, 4, 4))
    m, g = P.singularity_measure_and_gradient(d)
    assert m.shape == (3, 4) and g.shape == (3, 4, 4)
    assert P.unit_momenta(d).shape == (3, 4, 3, 4)
    for i in range(3):
        for j in range(4):
            mi, gi = P.singularity_measure_and_gradient(d[i, j])
            assert mi == pytest.approx(m[i, j], rel=1e-14)
            np.testing.assert_allclose(gi, g[i, j], rtol=1e-12, atol=1e-14)


def test_inputs_not_mutated():
    d = np.array([0.1, 0.2, 0.3, 0.4])
    d0 = d.copy()
    P.momentum_and_jacobian(d)
    P.singularity_measure_and_gradient(d)
    np.testing.assert_array_equal(d, d0)


# ---------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"h0": 0.0}, "h0"),
        ({"h0": -1.0}, "h0"),
        ({"h0": np.nan}, "h0"),
        ({"beta": 0.0}, "beta"),
        ({"beta": np.pi / 2}, "beta"),
        ({"beta": "x"}, "beta"),
        ({"gimbal_rate_limit": 0.0}, "gimbal_rate_limit"),
        ({"gimbal_rate_limit": np.inf}, "gimbal_rate_limit"),
    ],
)
def test_bad_parameters_raise(kwargs, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        SgcmgPyramid(**kwargs)


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((2, 5)), [0.0, np.nan, 0.0, 0.0], "abc"])
def test_bad_delta_raises(bad):
    for f in (P.momentum, P.jacobian, P.singularity_measure, P.singularity_measure_gradient):
        with pytest.raises(ValueError, match="^delta:"):
            f(bad)


def test_frozen():
    with pytest.raises(AttributeError):
        P.h0 = 1.0  # type: ignore[misc]
