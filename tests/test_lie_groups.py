"""Tests for the object layer liecontrol.lie.SO3 / SE3: validation on construction (SPEC §9),
immutability, and agreement with the array functions."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from liecontrol.lie import SE3, SO3, se3, so3

HYP = settings(max_examples=60, deadline=None)
vec = arrays(np.float64, 3, elements=st.floats(-3.0, 3.0))


def test_import_paths_of_the_brief():
    import liecontrol.lie as lie

    w = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(lie.so3.log(lie.so3.exp(w)), w, rtol=1e-14)
    assert set(lie.__all__) == {"so3", "se3", "SO3", "SE3"}


@HYP
@given(vec, vec, vec)
def test_so3_wrapper_matches_array_functions(w1, w2, p):
    A, B = SO3.exp(w1), SO3.exp(w2)
    np.testing.assert_array_equal(A.as_matrix(), so3.exp(w1))
    np.testing.assert_allclose((A @ B).as_matrix(), so3.exp(w1) @ so3.exp(w2), atol=1e-15)
    np.testing.assert_allclose(A @ p, Rotation.from_rotvec(w1).apply(p), atol=1e-12)
    np.testing.assert_allclose(A.apply(p), so3.exp(w1) @ p, atol=1e-14)
    np.testing.assert_allclose((A @ A.inverse()).as_matrix(), np.eye(3), atol=1e-14)
    np.testing.assert_array_equal(A.log(), so3.log(so3.exp(w1)))
    np.testing.assert_array_equal(A.angle(), so3.angle(A.R))
    np.testing.assert_array_equal(A.adjoint(), A.R)
    assert A.distance(B) == pytest.approx(float(so3.distance(A.R, B.R)), abs=0)
    np.testing.assert_allclose(A.interpolate(B, 1.0).as_matrix(), B.as_matrix(), atol=1e-12)


@HYP
@given(vec, vec, vec, vec)
def test_se3_wrapper_matches_array_functions(w, v, p, x):
    xi = np.concatenate([w, v])
    g = SE3.exp(xi)
    h = SE3.from_rt(SO3.exp(p / 2.0), p)
    np.testing.assert_array_equal(g.as_matrix(), se3.exp(xi))
    np.testing.assert_allclose((g @ h).as_matrix(), se3.exp(xi) @ h.as_matrix(), atol=1e-14)
    np.testing.assert_allclose(g @ x, se3.act(g.g, x), atol=0)
    np.testing.assert_allclose((g @ g.inverse()).as_matrix(), np.eye(4), atol=1e-12)
    np.testing.assert_array_equal(g.log(), se3.log(g.g))
    np.testing.assert_array_equal(g.rotation().as_matrix(), g.g[:3, :3])
    np.testing.assert_array_equal(g.translation(), g.g[:3, 3])
    np.testing.assert_array_equal(g.adjoint(), se3.adjoint(g.g))
    assert g.distance(h, 2.0) == pytest.approx(float(se3.distance(g.g, h.g, 2.0)), abs=0)
    np.testing.assert_allclose(g.interpolate(h, 0.0).as_matrix(), g.as_matrix(), atol=1e-13)
    # from a plain rotation array as well
    np.testing.assert_array_equal(SE3.from_rt(so3.exp(p / 2.0), p).g, h.g)


def test_identity_random_batching_and_indexing():
    rng = np.random.default_rng(0)
    assert SO3.identity().batch_shape == ()
    np.testing.assert_array_equal(SO3.identity((2, 3)).R, np.broadcast_to(np.eye(3), (2, 3, 3, 3)))
    np.testing.assert_array_equal(SE3.identity((4,)).g, np.broadcast_to(np.eye(4), (4, 4, 4)))
    R = SO3.random(rng, (2, 3))
    assert R.batch_shape == (2, 3) and len(R) == 2
    assert R[1].batch_shape == (3,)
    np.testing.assert_array_equal(R[1, 2].R, R.R[1, 2])
    g = SE3.random(rng, 5, translation_scale=10.0)
    assert len(g) == 5 and g[2:4].batch_shape == (2,)
    np.testing.assert_array_equal(
        SO3.random(np.random.default_rng(1), 3).R, so3.random(np.random.default_rng(1), 3)
    )
    with pytest.raises(TypeError):
        len(SO3.identity())
    with pytest.raises(IndexError):
        R[0, 0, 0]
    # batch composition broadcasts one element against many
    assert (R[0, 0] @ R).batch_shape == (2, 3)
    assert (g @ np.zeros((5, 3))).shape == (5, 3)


def test_immutable_and_copies():
    M = so3.exp(np.array([0.3, 0.2, -0.1]))
    R = SO3(M)
    M[0, 0] = 5.0  # the caller's array is not aliased
    assert R.R[0, 0] != 5.0
    with pytest.raises(ValueError):
        R.R[0, 0] = 1.0  # read-only
    with pytest.raises(dataclasses.FrozenInstanceError):
        R.R = np.eye(3)
    out = R.as_matrix()
    out[0, 0] = 7.0
    assert R.R[0, 0] != 7.0
    g = SE3.exp(np.ones(6))
    with pytest.raises(ValueError):
        g.g[0, 3] = 1.0


def test_project_makes_a_valid_element():
    rng = np.random.default_rng(2)
    M = so3.random(rng, 3) + 1e-4 * rng.normal(size=(3, 3, 3))
    with pytest.raises(ValueError, match="^R: not orthonormal"):
        SO3(M)
    R = SO3.project(M)
    np.testing.assert_allclose(R.R, so3.project(M), atol=0)
    SO3.from_matrix(R.R)


@pytest.mark.parametrize(
    ("factory", "arg", "pattern"),
    [
        (SO3, np.ones((3, 3)), "^R: not orthonormal"),
        (SO3, np.diag([1.0, 1.0, -1.0]), "^R: .*reflection"),
        (SO3, np.full((3, 3), np.nan), "^R: contains 9 non-finite"),
        (SO3, np.eye(4), r"^R: expected shape \(\.\.\., 3, 3\)"),
        (SO3.from_matrix, [[1.0, 0.0], [0.0, 1.0]], "^R: expected shape"),
        (SE3, np.eye(3), r"^g: expected shape \(\.\.\., 4, 4\)"),
        (SE3, np.diag([1.0, 1.0, 1.0, 2.0]), "^g: last row"),
        (SE3, np.where(np.eye(4) > 0, np.inf, 0.0), "^g: contains"),
        (SE3.from_matrix, 2.0 * np.eye(4), "^g: not orthonormal"),
        (SO3.exp, [0.0, np.nan, 1.0], "^w:"),
        (SE3.exp, [0.0, 1.0, 1.0], "^xi:"),
    ],
)
def test_bad_input(factory, arg, pattern):
    with pytest.raises(ValueError, match=pattern):
        factory(arg)


def test_from_rt_validates_plain_rotation_arrays():
    with pytest.raises(ValueError, match="^R: not orthonormal"):
        SE3.from_rt(2.0 * np.eye(3), np.zeros(3))
    with pytest.raises(ValueError, match="^p:"):
        SE3.from_rt(np.eye(3), [0.0, np.nan, 0.0])


def test_mixing_groups_is_an_error():
    with pytest.raises(TypeError):
        SO3.identity() @ SE3.identity()
    with pytest.raises(TypeError):
        SE3.identity() @ SO3.identity()
