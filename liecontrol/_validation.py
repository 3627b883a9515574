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
    "check_spd",
    "rotations_pass_fast",
    "check_positive",
    "check_nonnegative",
    "ROTATION_ATOL",
]

#: Default tolerance on max |RᵀR − I| and |det R − 1| for a matrix to count as a rotation.
ROTATION_ATOL = 1e-9

_F64 = np.dtype(np.float64)


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


def rotations_pass_fast(R: object, atol: float = ROTATION_ATOL) -> bool:
    """True iff ``R`` is already a float64 ndarray of shape ``(..., 3, 3)`` that
    :func:`check_rotation_matrix` would accept unchanged (finite, ``max |RᵀR − I| ≤ atol``,
    ``det ≥ 0``).

    The cheap test for controller hot paths (called at every control sample): ``False`` means
    "run :func:`check_rotation_matrix`", which raises the usual message (or converts, e.g. a
    list). NaN/inf make the comparisons False, so they are rejected too. The determinant is the
    triple product instead of ``np.linalg.det`` (a matrix within ``atol`` of orthonormal has
    ``det ≈ ±1``, so the sign is unambiguous); one matrix runs on Python floats, where numpy's
    per-call overhead would dominate.
    """
    if not (
        isinstance(R, np.ndarray) and R.dtype == _F64 and R.ndim >= 2 and R.shape[-2:] == (3, 3)
    ):
        return False
    if R.size == 9:
        a, b, c, d, e, f, g, h, k = R.ravel().tolist()
        # columns' Gram matrix RᵀR − I and det R = c0 · (c1 × c2)
        err = max(
            abs(a * a + d * d + g * g - 1.0),
            abs(b * b + e * e + h * h - 1.0),
            abs(c * c + f * f + k * k - 1.0),
            abs(a * b + d * e + g * h),
            abs(a * c + d * f + g * k),
            abs(b * c + e * f + h * k),
        )
        det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)
        return err <= atol and det >= 0.0
    if R.size == 0:
        return True
    # the nine entries as contiguous rows (one copy), then the Gram matrix RᵀR − I and the
    # determinant entry-wise: ~2× cheaper than a stacked matmul of 3×3 matrices
    a, b, c, d, e, f, g, h, k = R.reshape(-1, 9).T.copy()
    err = np.abs(a * a + d * d + g * g - 1.0)
    for x in (
        b * b + e * e + h * h - 1.0,
        c * c + f * f + k * k - 1.0,
        a * b + d * e + g * h,
        a * c + d * f + g * k,
        b * c + e * f + h * k,
    ):
        np.maximum(err, np.abs(x, out=x), out=err)  # NaN propagates, so it is rejected below
    if not err.max() <= atol:
        return False
    det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)
    return bool(np.all(det >= 0.0))


def check_spd(
    M: object, name: str, *, symbol: str = "M", what: str = "", pd_rtol: float = 0.0
) -> np.ndarray:
    """Check that ``M`` is a finite, symmetric (``max |M − Mᵀ| ≤ 1e-9 max |M|``), positive-definite
    square matrix (smallest eigenvalue ``> pd_rtol ·`` largest); return its eigenvalues in
    ascending order (``np.linalg.eigvalsh``).

    Messages: ``"{name}: {what}not symmetric (max |{symbol} − {symbol}ᵀ| = …)"`` and
    ``"{name}: {what}not positive definite (smallest eigenvalue …)"``; ``what`` qualifies the
    matrix (e.g. ``"gain matrix "``), ``symbol`` names it in the formula.
    """
    a = as_array(M, name)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"{name}: expected a square matrix (n, n), got shape {a.shape}")
    scale = float(np.abs(a).max()) if a.size else 0.0
    asym = float(np.abs(a - a.T).max()) if a.size else 0.0
    if asym > 1e-9 * max(scale, 1e-300):
        raise ValueError(f"{name}: {what}not symmetric (max |{symbol} − {symbol}ᵀ| = {asym:.2e})")
    eig = np.linalg.eigvalsh(a)
    if eig.size and eig[0] <= pd_rtol * max(float(eig[-1]), 1e-300):
        raise ValueError(f"{name}: {what}not positive definite (smallest eigenvalue {eig[0]:.3e})")
    return eig


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
    a = as_array(J, name)
    # the shape first: a single-matrix API says "(3, 3)", not check_inertia's "(..., 3, 3)"
    if a.shape != (3, 3):
        raise ValueError(f"{name}: expected shape (3, 3), got {a.shape}")
    return check_inertia(a, name)


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
