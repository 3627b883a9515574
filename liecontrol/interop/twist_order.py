"""Reorder SE(3) twists and 6×6 blocks between (ω, v) and (v, ω).

liecontrol orders se(3) twists ξ = (ω, v) — rotation first — in ``se3.exp``/``log``, the
adjoint, the Jacobians and the SE(3) controllers. Several libraries put the translation first:

| library | twist order | where it shows |
| --- | --- | --- |
| liecontrol | (ω, v) | ``se3.exp``, ``se3.adjoint``, ``SE3.log`` |
| scipy ``RigidTransform`` | (ω, v) | ``from_exp_coords`` / ``as_exp_coords`` |
| Lynch & Park, *Modern Robotics* | (ω, v) | the twist 𝒱 = (ω, v) and [Ad_T] of the book |
| jaxlie | (v, ω) | ``SE3.exp``/``log`` tangent, ``SE3.adjoint`` |
| Sophus | (v, ω) | ``SE3::exp``/``log`` (translation first) |
| spatialmath-python | (v, ω) | ``Twist3`` (``.v`` = S[:3], ``.w`` = S[3:]) |

With P the 6×6 block swap [[0, I], [I, 0]] (P = Pᵀ = P⁻¹), a twist converts as ξ' = P ξ and any
matrix acting on twists (adjoint, left/right Jacobian, covariance, gain) as M' = P M P: e.g.
liecontrol's Ad_g = [[R, 0], [p^R, R]] becomes jaxlie's [[R, p^R], [0, R]]. Both maps are
involutions, so the same function converts either way.
"""

from __future__ import annotations

import numpy as np

from .._validation import as_array

__all__ = [
    "TWIST_ORDER",
    "swap_twist",
    "swap_blocks",
    "to_v_omega",
    "to_omega_v",
    "matrix_to_v_omega",
    "matrix_to_omega_v",
]

#: Twist order by library: ``"omega_v"`` (rotation first) or ``"v_omega"``.
TWIST_ORDER: dict[str, str] = {
    "liecontrol": "omega_v",
    "scipy": "omega_v",
    "modern_robotics": "omega_v",
    "jaxlie": "v_omega",
    "sophus": "v_omega",
    "spatialmath": "v_omega",
}


def swap_twist(xi: object) -> np.ndarray:
    """ξ ``(..., 6)`` with its two 3-vector halves swapped (a new array): (ω, v) ⇄ (v, ω)."""
    a = as_array(xi, "xi", (6,))
    return np.concatenate([a[..., 3:], a[..., :3]], axis=-1)


def swap_blocks(M: object) -> np.ndarray:
    """P M P for ``(..., 6, 6)`` matrices (a new array): the 3×3 blocks [[A, B], [C, D]]
    become [[D, C], [B, A]] — the matrix in the other twist order."""
    a = as_array(M, "M", (6, 6))
    top = np.concatenate([a[..., 3:, 3:], a[..., 3:, :3]], axis=-1)
    bottom = np.concatenate([a[..., :3, 3:], a[..., :3, :3]], axis=-1)
    return np.concatenate([top, bottom], axis=-2)


def to_v_omega(xi: object) -> np.ndarray:
    """liecontrol's (ω, v) twist → (v, ω) for jaxlie / Sophus / spatialmath."""
    return swap_twist(xi)


def to_omega_v(xi: object) -> np.ndarray:
    """A (v, ω) twist (jaxlie / Sophus / spatialmath) → liecontrol's (ω, v)."""
    return swap_twist(xi)


def matrix_to_v_omega(M: object) -> np.ndarray:
    """A 6×6 matrix on (ω, v) twists (adjoint, Jacobian, covariance) → the (v, ω) one."""
    return swap_blocks(M)


def matrix_to_omega_v(M: object) -> np.ndarray:
    """A 6×6 matrix on (v, ω) twists → liecontrol's (ω, v) one."""
    return swap_blocks(M)
