"""(ω, v) ⇄ (v, ω) reordering: involution, and consistency with the adjoint and Jacobians —
the swapped matrices must be the (v, ω) formulas (jaxlie's adjoint [[R, p^R], [0, R]], the
(v, ω) exponential written out here) acting on swapped twists."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from liecontrol.interop import twist_order as to
from liecontrol.lie import se3, so3


def _twists(seed: int, n: int = 10) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.concatenate([rng.uniform(-2, 2, (n, 3)), rng.uniform(-3, 3, (n, 3))], axis=-1)


def _hat_v_omega(x: np.ndarray) -> np.ndarray:
    """se(3) matrix of a (v, ω) twist, written independently of liecontrol."""
    v, w = x[:3], x[3:]
    X = np.zeros((4, 4))
    X[:3, :3] = [[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]
    X[:3, 3] = v
    return X


def test_swaps_are_involutions_and_do_not_mutate():
    xi = _twists(0)
    xi0 = xi.copy()
    sw = to.to_v_omega(xi)
    np.testing.assert_array_equal(sw[:, :3], xi[:, 3:])
    np.testing.assert_array_equal(to.to_omega_v(sw), xi)
    M = np.random.default_rng(1).normal(size=(4, 6, 6))
    M0 = M.copy()
    np.testing.assert_array_equal(to.matrix_to_omega_v(to.matrix_to_v_omega(M)), M)
    np.testing.assert_array_equal(xi, xi0)
    np.testing.assert_array_equal(M, M0)
    # P M P with the explicit permutation matrix
    P = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])
    np.testing.assert_array_equal(to.swap_blocks(M), P @ M @ P)


def test_adjoint_in_v_omega_order_is_jaxlies_formula():
    g = se3.exp(_twists(2))
    Ad_swapped = to.matrix_to_v_omega(se3.adjoint(g))
    for G, A in zip(g, Ad_swapped, strict=True):
        R, p = G[:3, :3], G[:3, 3]
        want = np.block([[R, so3.hat(p) @ R], [np.zeros((3, 3)), R]])
        np.testing.assert_allclose(A, want, atol=1e-12)


def test_swapped_adjoint_acts_on_swapped_twists():
    xi = _twists(3)
    g = se3.exp(_twists(4))
    ad_xi = np.einsum("bij,bj->bi", se3.adjoint(g), xi)
    np.testing.assert_allclose(
        to.to_v_omega(ad_xi),
        np.einsum("bij,bj->bi", to.matrix_to_v_omega(se3.adjoint(g)), to.to_v_omega(xi)),
        atol=1e-12,
    )


def test_exp_and_left_jacobian_in_v_omega_order():
    xi = _twists(5)
    for x in xi:
        y = to.to_v_omega(x)
        # the same group element from the (v, ω) hat and scipy's expm
        np.testing.assert_allclose(expm(_hat_v_omega(y)), se3.exp(x), atol=1e-10)
    # left Jacobian, (v, ω) order, by central differences of exp in (v, ω) coordinates:
    # exp(y + ε e_k) exp(y)⁻¹ ≈ exp(ε J_l e_k)
    y = to.to_v_omega(xi[0])
    eps = 1e-6
    cols = []
    for k in range(6):
        e = np.zeros(6)
        e[k] = eps
        gp = expm(_hat_v_omega(y + e)) @ np.linalg.inv(expm(_hat_v_omega(y)))
        gm = expm(_hat_v_omega(y - e)) @ np.linalg.inv(expm(_hat_v_omega(y)))
        cols.append(to.to_v_omega((se3.log(gp) - se3.log(gm)) / (2 * eps)))
    J_fd = np.stack(cols, axis=-1)
    np.testing.assert_allclose(to.matrix_to_v_omega(se3.left_jacobian(xi[0])), J_fd, atol=1e-6)


def test_table_and_bad_input():
    assert to.TWIST_ORDER["liecontrol"] == "omega_v"
    assert {to.TWIST_ORDER[k] for k in ("jaxlie", "sophus", "spatialmath")} == {"v_omega"}
    with pytest.raises(ValueError, match=r"^xi: expected shape \(\.\.\., 6\)"):
        to.to_v_omega(np.zeros(5))
    with pytest.raises(ValueError, match=r"^M: expected shape \(\.\.\., 6, 6\)"):
        to.matrix_to_v_omega(np.zeros((6, 5)))
    with pytest.raises(ValueError, match=r"^xi: contains 1 non-finite"):
        to.to_omega_v([0.0, 0.0, np.nan, 0.0, 0.0, 0.0])
