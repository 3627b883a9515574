"""Input validation shared by every public entry point (SPEC §9).

Every message starts with the argument's name and then says what is wrong, e.g.
``"R: not orthonormal (max |RᵀR − I| = 3.2e-02 > 1e-09)"``.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "as_array",
    "check_finite",
    "check_shape_tail",
    "check_rotation_matrix",
    "check_inertia",
    "check_inertia_3x3",
    "check_positive",
    "check_nonnegative",
    "ROTATION_ATOL",
]

#: Default tolerance on max |RᵀR − I| and |det R − 1| for a matrix to count as a rotation.
ROTATION_ATOL = 1e-9


def as_array(x: object, name: str, tail: tuple[int, ...] | None = None) -> np.ndarray:
    """Return ``x`` as a finite float64 array, checking the trailing shape if given.

    Never copies when ``x`` already is a float64 array (callers must not mutate the result).
    """
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: cannot be converted to a float array ({exc})") from None
    if tail is not None:
        check_shape_tail(a, name, tail)
    check_finite(a, name)
    return a


def check_finite(a: np.ndarray, name: str) -> None:
    """Raise if ``a`` holds NaN or inf."""
    if not np.all(np.isfinite(a)):
        bad = int(np.size(a) - np.count_nonzero(np.isfinite(a)))
        raise ValueError(f"{name}: contains {bad} non-finite value(s) (NaN or inf)")


def check_shape_tail(a: np.ndarray, name: str, tail: tuple[int, ...]) -> None:
    """Raise unless ``a.shape`` ends with ``tail``."""
    k = len(tail)
    if a.ndim < k or tuple(a.shape[a.ndim - k :]) != tuple(tail):
        want = "(..., " + ", ".join(str(t) for t in tail) + ")"
        raise ValueError(f"{name}: expected shape {want}, got {a.shape}")


def check_rotation_matrix(R: object, name: str = "R", atol: float = ROTATION_ATOL) -> np.ndarray:
    """Validate a (batch of) rotation matrices and return it as a float64 array."""
    a = as_array(R, name, (3, 3))
    err = np.abs(np.swapaxes(a, -1, -2) @ a - np.eye(3)).max(axis=(-2, -1))
    worst = float(err.max()) if err.size else 0.0
    if worst > atol:
        raise ValueError(f"{name}: not orthonormal (max |RᵀR − I| = {worst:.2e} > {atol:.0e})")
    det = np.linalg.det(a)
    if np.any(det < 0):
        raise ValueError(f"{name}: determinant is −1 (a reflection, not a rotation)")
    return a


def check_inertia(J: object, name: str = "J", rtol: float = 1e-9) -> np.ndarray:
    """Validate a 3×3 (or batched) inertia matrix: finite, symmetric, positive definite and
    satisfying the triangle inequality on its principal moments."""
    a = as_array(J, name, (3, 3))
    scale = np.abs(a).max(axis=(-2, -1))
    asym = np.abs(a - np.swapaxes(a, -1, -2)).max(axis=(-2, -1))
    if np.any(asym > rtol * np.maximum(scale, 1e-300)):
        raise ValueError(f"{name}: not symmetric (max |J − Jᵀ| = {float(asym.max()):.2e})")
    eig = np.linalg.eigvalsh(a)
    if np.any(eig <= 0):
        raise ValueError(
            f"{name}: not positive definite (smallest principal moment {float(eig.min()):.3e})"
        )
    # principal moments must satisfy J1 + J2 >= J3 for a physical body
    slack = eig[..., 0] + eig[..., 1] - eig[..., 2]
    if np.any(slack < -rtol * eig[..., 2]):
        raise ValueError(
            f"{name}: principal moments violate the triangle inequality "
            f"(J1 + J2 < J3 by {float(-slack.min()):.3e})"
        )
    return a


def check_inertia_3x3(J: object, name: str = "J") -> np.ndarray:
    """:func:`check_inertia` for exactly one inertia matrix: also rejects a batch (shape not
    ``(3, 3)``). Returns the validated float64 array (not a copy when ``J`` already is one)."""
    a = check_inertia(J, name)
    if a.shape != (3, 3):
        raise ValueError(f"{name}: expected shape (3, 3), got {a.shape}")
    return a


def check_positive(x: object, name: str) -> np.ndarray | float:
    """Validate a strictly positive finite scalar or array; scalars come back as float."""
    a = as_array(x, name)
    if np.any(a <= 0):
        raise ValueError(f"{name}: must be > 0, got {a if a.ndim == 0 else a.min()}")
    return float(a) if a.ndim == 0 else a


def check_nonnegative(x: object, name: str) -> np.ndarray | float:
    """Validate a non-negative finite scalar or array; scalars come back as float."""
    a = as_array(x, name)
    if np.any(a < 0):
        raise ValueError(f"{name}: must be >= 0, got {a if a.ndim == 0 else a.min()}")
    return float(a) if a.ndim == 0 else a
