"""Single-element fast routes of so3/se3 and the closed-form SE(3) Jacobians.

The one-element routes (Python floats) must equal the batched numpy path, keep its validation
messages and never touch the caller's array; the closed-form SE(3) Jacobians must equal
Barfoot's stacked-product form and the finite-difference Jacobians of exp.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from liecontrol.lie import se3, so3

PI = np.pi
HYP = settings(max_examples=60, deadline=None)

unit = st.tuples(*[st.floats(-1.0, 1.0)] * 3).map(np.array).filter(
    lambda a: np.linalg.norm(a) > 1e-3
).map(lambda a: a / np.linalg.norm(a))
vec3 = st.tuples(*[st.floats(-5.0, 5.0)] * 3).map(np.array)
# angles near 0, in the middle and near π (the branches of every coefficient)
angle = st.one_of(
    st.floats(0.0, 1e-6), st.floats(0.0, 0.2), st.floats(0.2, 3.0), st.floats(PI - 1e-3, PI)
)


def _rotvecs() -> np.ndarray:
    rng = np.random.default_rng(3)
    n = rng.standard_normal((40, 3))
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    th = np.r_[0.0, 1e-300, 1e-12, 1e-8, 1e-4, 0.05, 0.099, 0.1, 0.5, 1.0, 2.0, 3.0,
               PI - 1e-9, PI, 4.0, 7.0, 50.0, 1e6, 1e90, rng.uniform(0, 2 * PI, 21)]
    return n * th[:, None]


def test_so3_exp_single_equals_batched():
    W = _rotvecs()
    for w in W:
        one = so3.exp(w)
        assert one.shape == (3, 3)
        np.testing.assert_allclose(one, so3.exp(w[None])[0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(
        np.array([so3.exp(w) for w in W[:-2]]), Rotation.from_rotvec(W[:-2]).as_matrix(),
        rtol=0, atol=1e-13,
    )


def test_so3_log_single_equals_batched_near_0_and_pi():
    rng = np.random.default_rng(4)
    Rs = np.concatenate((so3.random(rng, 30), so3.exp(_rotvecs()[:-3])))
    for R in Rs:
        one = so3.log(R)
        assert one.shape == (3,)
        np.testing.assert_allclose(one, so3.log(R[None])[0], rtol=0, atol=1e-15)


def test_se3_exp_log_single_equal_batched():
    rng = np.random.default_rng(5)
    W = _rotvecs()
    xi = np.concatenate((W, 3.0 * rng.standard_normal(W.shape)), axis=-1)
    for x in xi:
        g = se3.exp(x)
        np.testing.assert_allclose(g, se3.exp(x[None])[0], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(se3.log(g), se3.log(g[None])[0], rtol=1e-13, atol=1e-13)


@HYP
@given(unit, angle, vec3)
def test_se3_log_inverts_exp_on_the_fast_route(n, th, v):
    xi = np.r_[n * th, v]
    np.testing.assert_allclose(se3.log(se3.exp(xi)), xi, rtol=0, atol=1e-9)


def test_fast_routes_keep_the_validation_messages_and_do_not_mutate():
    bad = np.eye(3) * 2.0
    with pytest.raises(ValueError, match=r"^R: not orthonormal"):
        so3.log(bad)
    refl = np.diag([1.0, 1.0, -1.0])
    with pytest.raises(ValueError, match=r"^R: determinant"):
        so3.log(refl)
    with pytest.raises(ValueError, match=r"^R: contains"):
        so3.log(np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match=r"^w: contains"):
        so3.exp(np.array([np.nan, 0.0, 0.0]))
    with pytest.raises(ValueError, match=r"^xi: contains"):
        se3.exp(np.array([0.0, np.inf, 0.0, 1.0, 2.0, 3.0]))
    g = se3.exp(np.array([0.1, 0.2, 0.3, 1.0, 2.0, 3.0]))
    g_row = g.copy()
    g_row[3, 0] = 0.1
    with pytest.raises(ValueError, match=r"^g: last row"):
        se3.log(g_row)
    g_nan = g.copy()
    g_nan[0, 3] = np.nan
    with pytest.raises(ValueError, match=r"^g: contains"):
        se3.log(g_nan)
    w = np.array([0.3, -0.2, 0.1])
    w0 = w.copy()
    g0 = g.copy()
    so3.exp(w)
    so3.log(so3.exp(w))
    se3.log(g)
    assert np.array_equal(w, w0) and np.array_equal(g, g0)
    # lists still go through the general path
    np.testing.assert_allclose(so3.exp([0.3, -0.2, 0.1]), so3.exp(w), atol=0)


# ------------------------------------------------------------- closed-form SE(3) Jacobians
def _q_product(w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Barfoot's Q block as the stacked products (the independent reference)."""
    theta = np.linalg.norm(w, axis=-1)
    n = w / np.where(theta > 0, theta, 1.0)[..., None]
    c1a, c1, c2, c3 = se3._q_scaled(theta)
    P, V = so3.hat(n), so3.hat(v)
    PV, VP = P @ V, V @ P
    PVP = PV @ P
    c = [x[..., None, None] for x in (c1a, c1, c2, c3)]
    return (0.5 * V + c[0] * (PV + VP) + c[1] * PVP + c[2] * (P @ PV + VP @ P - 3.0 * PVP)
            + c[3] * (PVP @ P + P @ PVP))


def _jl_product(xi: np.ndarray) -> np.ndarray:
    w, v = xi[..., :3], xi[..., 3:]
    J = np.zeros(xi.shape[:-1] + (6, 6))
    A = so3.left_jacobian(w)
    J[..., :3, :3] = A
    J[..., 3:, 3:] = A
    J[..., 3:, :3] = _q_product(w, v)
    return J


def _jl_inv_product(xi: np.ndarray) -> np.ndarray:
    w, v = xi[..., :3], xi[..., 3:]
    Ai = so3.left_jacobian_inv(w)
    J = np.zeros(xi.shape[:-1] + (6, 6))
    J[..., :3, :3] = Ai
    J[..., 3:, 3:] = Ai
    J[..., 3:, :3] = -(Ai @ _q_product(w, v) @ Ai)
    return J


@pytest.mark.parametrize("shape", [(), (5,), (2, 3)])
def test_closed_form_jacobians_equal_products(shape):
    rng = np.random.default_rng(6)
    xi = rng.standard_normal(shape + (6,)) * 1.5
    np.testing.assert_allclose(
        se3._q_left(xi[..., :3], xi[..., 3:]), _q_product(xi[..., :3], xi[..., 3:]), atol=1e-13
    )
    for fn, ref in (
        (se3.left_jacobian, _jl_product),
        (se3.right_jacobian, lambda x: _jl_product(-x)),
        (se3.left_jacobian_inv, _jl_inv_product),
        (se3.right_jacobian_inv, lambda x: _jl_inv_product(-x)),
    ):
        out = fn(xi)
        assert out.shape == shape + (6, 6)
        np.testing.assert_allclose(out, ref(xi), rtol=0, atol=1e-12 * max(1.0, np.abs(out).max()))


@HYP
@given(unit, angle, vec3)
def test_closed_form_jacobians_near_0_and_pi(n, th, v):
    xi = np.r_[n * th, v]
    J = se3.left_jacobian(xi)
    Ji = se3.left_jacobian_inv(xi)
    scale = max(1.0, float(np.abs(Ji).max()))
    np.testing.assert_allclose(J, _jl_product(xi), rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(Ji, _jl_inv_product(xi), rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(Ji @ J, np.eye(6), rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(
        se3.right_jacobian_inv(xi) @ se3.right_jacobian(xi), np.eye(6), atol=1e-12 * scale
    )


@pytest.mark.parametrize("th", [1e-7, 0.05, 1.0, 3.0, PI - 1e-6])
def test_jacobians_match_finite_differences(th):
    """exp(ξ + δ) ≈ exp(J_l δ) exp(ξ) and ≈ exp(ξ) exp(J_r δ): central differences of
    log(exp(ξ + ε e_k) exp(ξ)⁻¹) (and the right analogue) give the columns."""
    rng = np.random.default_rng(7)
    n = rng.standard_normal(3)
    xi = np.r_[th * n / np.linalg.norm(n), rng.standard_normal(3)]
    g_inv = se3.inverse(se3.exp(xi))
    eps = 1e-6
    Jl = np.zeros((6, 6))
    Jr = np.zeros((6, 6))
    for k in range(6):
        d = np.zeros(6)
        d[k] = eps
        gp, gm = se3.exp(xi + d), se3.exp(xi - d)
        Jl[:, k] = (se3.log(gp @ g_inv) - se3.log(gm @ g_inv)) / (2 * eps)
        Jr[:, k] = (se3.log(g_inv @ gp) - se3.log(g_inv @ gm)) / (2 * eps)
    np.testing.assert_allclose(se3.left_jacobian(xi), Jl, atol=1e-8)
    np.testing.assert_allclose(se3.right_jacobian(xi), Jr, atol=1e-8)
    np.testing.assert_allclose(se3.left_jacobian_inv(xi) @ Jl, np.eye(6), atol=1e-8)


def test_jacobian_inverse_errors_unchanged():
    with pytest.raises(ValueError, match=r"^xi: the SO\(3\) Jacobian inverse is singular"):
        se3.right_jacobian_inv(np.r_[2 * PI, 0.0, 0.0, 1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"^xi: the SE\(3\) Jacobian inverse overflows"):
        se3.left_jacobian_inv(np.r_[1e200, 0.0, 0.0, 0.0, 1e200, 0.0])
    # very long twists stay finite in the forward Jacobian
    assert np.all(np.isfinite(se3.left_jacobian(np.r_[1e300, 0.0, 0.0, 1.0, 2.0, 3.0])))


def test_single_element_jacobians_equal_batched():
    """The Python-float routes of the so3/se3 Jacobians (one element) equal the batched route,
    over every branch: θ = 0, series, closed form, near π and 2π, very long vectors."""
    rng = np.random.default_rng(8)
    W = np.concatenate((_rotvecs(), rng.standard_normal((3, 3)) * (2 * PI - 1e-3)))
    V = 3.0 * rng.standard_normal(W.shape)
    for w, v in zip(W, V, strict=True):
        for fn in (so3.left_jacobian, so3.right_jacobian):
            one, many = fn(w), fn(w[None])[0]
            np.testing.assert_allclose(one, many, rtol=1e-14, atol=1e-15)
        for fn in (se3.left_jacobian, se3.right_jacobian):
            xi = np.r_[w, v]
            np.testing.assert_allclose(fn(xi), fn(xi[None])[0], rtol=1e-13, atol=1e-14)
        if np.linalg.norm(w) < 7.0:  # the inverses: below the second singular angle 4π
            for fn in (so3.left_jacobian_inv, so3.right_jacobian_inv):
                one, many = fn(w), fn(w[None])[0]
                np.testing.assert_allclose(one, many, rtol=1e-13, atol=1e-14 * np.abs(one).max())
            for fn in (se3.left_jacobian_inv, se3.right_jacobian_inv):
                xi = np.r_[w, v]
                one, many = fn(xi), fn(xi[None])[0]
                np.testing.assert_allclose(one, many, rtol=1e-13, atol=1e-14 * np.abs(one).max())
    with pytest.raises(ValueError, match=r"^w: the SO\(3\) Jacobian inverse is singular"):
        so3.right_jacobian_inv(np.array([0.0, 2 * PI, 0.0]))
    with pytest.raises(ValueError, match=r"^w: contains"):
        so3.left_jacobian(np.array([0.0, np.nan, 0.0]))
    with pytest.raises(ValueError, match=r"^xi: contains"):
        se3.left_jacobian(np.array([0.0, 0.0, 0.0, np.nan, 0.0, 0.0]))


def test_single_element_group_operations_equal_batched_and_validate():
    rng = np.random.default_rng(9)
    R1, R2 = so3.random(rng, 2)
    g1, g2 = se3.random(rng, 2)
    w, p = rng.standard_normal(3), rng.standard_normal(3)
    xi = rng.standard_normal(6)
    pairs = [
        (so3.hat(w), so3.hat(w[None])[0]),
        (so3.compose(R1, R2), so3.compose(R1[None], R2[None])[0]),
        (so3.inverse(R1), so3.inverse(R1[None])[0]),
        (so3.act(R1, p), so3.act(R1[None], p[None])[0]),
        (se3.hat(xi), se3.hat(xi[None])[0]),
        (se3.compose(g1, g2), se3.compose(g1[None], g2[None])[0]),
        (se3.inverse(g1), se3.inverse(g1[None])[0]),
        (se3.adjoint(g1), se3.adjoint(g1[None])[0]),
        (se3.act(g1, p), se3.act(g1[None], p[None])[0]),
    ]
    for one, many in pairs:
        np.testing.assert_allclose(one, many, rtol=1e-15, atol=1e-15)
    bad_row = g1.copy()
    bad_row[3, 1] = np.nan  # a NaN after a zero in the last row must not be missed
    for fn in (se3.inverse, se3.adjoint, se3.log):
        with pytest.raises(ValueError, match=r"^g: contains"):
            fn(bad_row)
    with pytest.raises(ValueError, match=r"^g2: contains"):
        se3.compose(g1, bad_row)
    with pytest.raises(ValueError, match=r"^R2: not orthonormal"):
        so3.compose(R1, 2.0 * R2)
    with pytest.raises(ValueError, match=r"^p: contains"):
        so3.act(R1, np.array([0.0, np.inf, 0.0]))
    with pytest.raises(ValueError, match=r"^w: contains"):
        so3.hat(np.array([0.0, np.nan, 0.0]))
    with pytest.raises(ValueError, match=r"^xi: contains"):
        se3.hat(np.r_[0.0, 0.0, 0.0, 0.0, np.nan, 0.0])
