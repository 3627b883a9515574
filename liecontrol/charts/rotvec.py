"""Rotation vector (exponential coordinates, axis–angle) as a chart of SO(3).

θ ``(..., 3)`` with R = exp(θ^) (Rodrigues, :func:`liecontrol.lie.so3.exp`), R body → inertial.
:func:`from_matrix` returns the principal value |θ| ≤ π (:func:`liecontrol.lie.so3.log`).

Kinematics. With Ṙ = R ω^ (ω body) and d/dt exp(θ) = exp(θ) (J_r(θ) θ̇)^, ω = J_r(θ) θ̇, so
θ̇ = J_r(θ)⁻¹ ω with J_r⁻¹(θ) = I + ½ θ^ + (1/|θ|² − cot(|θ|/2)/(2|θ|)) (θ^)² (Barfoot 2017,
§7.1.5). Singularities of the chart:

* **|θ| = π (the principal chart's boundary)**: ±π·n are the same rotation, so the principal
  value jumps from π·n to −π·n as a trajectory crosses it. J_r⁻¹ itself is finite there
  (cot(π/2) = 0), so :func:`kinematics` is smooth across |θ| = π and a trajectory integrated
  in θ simply continues to |θ| > π; :func:`wrap` maps it back to |θ| ≤ π when wanted.
* **|θ| = 2π, 4π, …**: exp is singular (J_r(θ) is rank 1) and J_r⁻¹ blows up;
  :func:`kinematics` / :func:`kinematics_matrix` raise
  :class:`~liecontrol.exceptions.ChartSingularityError` when |θ| > π and
  |sin(|θ|/2)| < ``singular_tol`` (never NaN). Wrapping first avoids it altogether.

Sources: Barfoot, *State Estimation for Robotics* (2017), §7.1; Bullo & Murray, "Proportional
derivative (PD) control on the Euclidean group", 1995 (exponential coordinates).
"""

from __future__ import annotations

import numpy as np

from .._validation import (
    as_array,
    broadcast_batch,
    check_output_finite,
    check_rotation_matrix,
    check_tolerance,
    norm_last,
)
from ..exceptions import ChartSingularityError
from ..lie import so3

__all__ = [
    "SINGULAR_TOL",
    "from_matrix",
    "to_matrix",
    "wrap",
    "kinematics_matrix",
    "kinematics_matrix_inv",
    "kinematics",
]

#: Default |sin(|θ|/2)| below which (for |θ| > π) the rates are refused (|θ| near 2πk).
SINGULAR_TOL = 1e-6


def _theta(theta: object) -> np.ndarray:
    return as_array(theta, "theta", (3,))


def from_matrix(R: object) -> np.ndarray:
    """θ = log(R)^∨ with |θ| ≤ π (``so3.log``; at exactly π either sign of the axis)."""
    return so3.log(check_rotation_matrix(R, "R"))


def to_matrix(theta: object) -> np.ndarray:
    """R = exp(θ^) (Rodrigues, ``so3.exp``); any finite θ."""
    return so3.exp(_theta(theta))


def wrap(theta: object) -> np.ndarray:
    """The equivalent rotation vector with |θ| ≤ π: the angle |θ| is reduced to φ ∈ (−π, π]
    modulo 2π and the result is φ·θ/|θ| (φ < 0 flips the axis). Unchanged where |θ| ≤ π."""
    th = _theta(theta)
    n = norm_last(th)
    phi = np.pi - np.mod(np.pi - n, 2.0 * np.pi)
    inside = n <= np.pi
    scale = np.where(inside, 1.0, phi / np.where(inside, 1.0, n))
    return th * scale[..., None]


def _check_singular(th: np.ndarray, tol: float) -> None:
    n = norm_last(th)
    bad = (n > np.pi) & (np.abs(np.sin(0.5 * n)) < tol)
    if np.any(bad):
        worst = float(n[bad][0])
        raise ChartSingularityError(
            f"theta: rotation-vector chart singular at |theta| = {worst:.6g} ≈ 2πk (exp is "
            "singular there); wrap(theta) to |theta| <= π first"
        )


def kinematics_matrix(theta: object, singular_tol: float = SINGULAR_TOL) -> np.ndarray:
    """J_r(θ)⁻¹ with θ̇ = J_r(θ)⁻¹ ω, ``(..., 3) -> (..., 3, 3)``; raises
    :class:`ChartSingularityError` near |θ| = 2πk, k ≥ 1."""
    th = _theta(theta)
    _check_singular(th, check_tolerance(singular_tol, "singular_tol", upper=1.0))
    return so3._right_jacobian_inv(th, "theta")


def kinematics_matrix_inv(theta: object) -> np.ndarray:
    """J_r(θ) with ω = J_r(θ) θ̇ (defined everywhere)."""
    return so3.right_jacobian(_theta(theta))


def kinematics(theta: object, omega: object, singular_tol: float = SINGULAR_TOL) -> np.ndarray:
    """θ̇ = J_r(θ)⁻¹ ω (ω body angular velocity); shapes broadcast. See the module docstring for
    the behaviour at |θ| = π (smooth) and |θ| = 2πk (``ChartSingularityError``)."""
    Jinv = kinematics_matrix(theta, singular_tol)
    w = as_array(omega, "omega", (3,))
    broadcast_batch(("theta", Jinv.shape[:-2]), ("omega", w.shape[:-1]))
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.einsum("...ij,...j->...i", Jinv, w)
    return check_output_finite(out, "omega", "θ̇ = J_r(θ)⁻¹ ω")
