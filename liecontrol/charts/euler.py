"""Euler angles for all 12 sequences, scipy notation.

``seq`` is a 3-letter string over ``x, y, z`` with no two consecutive letters equal:

* upper case = **intrinsic** (rotating axes): ``"ZYX"`` is the aerospace 3-2-1 sequence,
  R = Rz(a1) Ry(a2) Rx(a3) — a1 about body z, then a2 about the new y, then a3 about the new x;
* lower case = **extrinsic** (fixed axes): ``"xyz"`` means R = Rz(a3) Ry(a2) Rx(a1).
  An extrinsic sequence equals the reversed intrinsic one with the angles reversed:
  ``"xyz"`` with (a1, a2, a3) ≡ ``"ZYX"`` with (a3, a2, a1).

Tait–Bryan sequences (three different axes, e.g. ``"ZYX"``, ``"XYZ"``) have a2 ∈ [−π/2, π/2]
and gimbal lock at a2 = ±π/2 (cos a2 = 0). Proper Euler sequences (first axis = last, e.g.
``"ZXZ"``) have a2 ∈ [0, π] and gimbal lock at a2 = 0 or π (sin a2 = 0). a1, a3 ∈ (−π, π].
This is scipy's ``Rotation.as_euler`` convention, against which the tests check.

``R = to_matrix(angles, seq)`` maps body → inertial. Angle rates: with ω the body angular
velocity (Ṙ = R ω^), ω = M(a) ȧ where, for an intrinsic sequence of axes (i, j, k),
M(a) = [R_k(a3)ᵀ R_j(a2)ᵀ e_i,  R_k(a3)ᵀ e_j,  e_k] (columns), so ȧ = B(a) ω with
B(a) = M(a)⁻¹. det M = ±cos a2 (Tait–Bryan) or ±sin a2 (proper Euler): B(a) does not exist at
gimbal lock, and :func:`rates_matrix` / :func:`kinematics` raise
:class:`~liecontrol.exceptions.ChartSingularityError` there (never NaN);
:func:`rates_matrix_inv` (= M) is defined everywhere.

Sources: Shuster, "A survey of attitude representations", J. Astronaut. Sci. 41(4), 1993, §§4–5;
Schaub & Junkins, *Analytical Mechanics of Space Systems*, §3.4 (Euler-angle kinematic
differential equations, e.g. the 3-2-1 B(θ)).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from .._array_api import cross, namespace
from .._validation import (
    as_array,
    broadcast_batch,
    check_bool,
    check_output_finite,
    check_rotation_matrix,
    check_tolerance,
)
from ..exceptions import ChartSingularityError

__all__ = [
    "SEQUENCES",
    "LOCK_TOL",
    "FROM_MATRIX_LOCK_TOL",
    "GimbalLockWarning",
    "from_matrix",
    "to_matrix",
    "rates_matrix",
    "rates_matrix_inv",
    "kinematics",
    "near_gimbal_lock",
    "is_tait_bryan",
    "kernel_axes",
]

#: The 12 intrinsic and 12 extrinsic sequences.
SEQUENCES: tuple[str, ...] = tuple(
    s
    for base in ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ")
    for s in (base, base.lower())
)

#: Default |cos a2| (Tait–Bryan) or |sin a2| (proper Euler) below which rates are refused.
LOCK_TOL = 1e-6
#: Default threshold for :func:`from_matrix` to take the gimbal-lock branch (a3 := 0). Small on
#: purpose: outside the branch R is reproduced to round-off however close to lock; inside it
#: the error is ≤ π·lock_tol (the discarded coupling between a3 and |cos a2| or |sin a2|).
FROM_MATRIX_LOCK_TOL = 1e-12

_AXIS = {"x": 0, "y": 1, "z": 2}


class GimbalLockWarning(UserWarning):
    """:func:`from_matrix` met a gimbal-locked matrix and set the third angle to 0."""


def _parse(seq: object) -> tuple[tuple[int, int, int], bool]:
    """Validate ``seq``; return (intrinsic axis indices, extrinsic flag)."""
    if not isinstance(seq, str) or len(seq) != 3:
        raise ValueError(f"seq: expected a 3-letter string such as 'ZYX' or 'xyz', got {seq!r}")
    if not (seq.isupper() or seq.islower()) or any(c not in _AXIS for c in seq.lower()):
        raise ValueError(
            f"seq: {seq!r} must use only x, y, z, all upper case (intrinsic) or all lower case "
            "(extrinsic)"
        )
    s = seq.lower()
    if s[0] == s[1] or s[1] == s[2]:
        raise ValueError(f"seq: {seq!r} repeats an axis in consecutive rotations")
    axes = tuple(_AXIS[c] for c in s)
    extrinsic = seq.islower()
    if extrinsic:
        axes = axes[::-1]
    return axes, extrinsic  # type: ignore[return-value]


def kernel_axes(seq: str) -> tuple[int, int, int, bool]:
    """``(i, j, k, extrinsic)``: the intrinsic axis indices of ``seq`` and its extrinsic flag,
    the sequence as the compiled kernels of :mod:`liecontrol._kernels.euler` take it."""
    (i, j, k), ext = _parse(seq)
    return i, j, k, ext


def is_tait_bryan(seq: str) -> bool:
    """True for three distinct axes (gimbal lock at a2 = ±π/2), False for proper Euler."""
    axes, _ = _parse(seq)
    return axes[0] != axes[2]


def _angles(angles: object) -> np.ndarray:
    return as_array(angles, "angles", (3,))


def _elem(axis: int, a: Any) -> Any:
    """Elementary rotation about coordinate axis ``axis`` by angle(s) ``a``; pure."""
    xp = namespace(a)
    c, s = xp.cos(a), xp.sin(a)
    m, n = (axis + 1) % 3, (axis + 2) % 3
    if xp is np:
        # NumPy: filled in place (a fresh local array, so still pure to the caller): the
        # nested stack below costs ~10× more per call on the chart adapters' hot path
        out = np.zeros(np.shape(a) + (3, 3))
        out[..., axis, axis] = 1.0
        out[..., m, m] = c
        out[..., n, n] = c
        out[..., n, m] = s
        out[..., m, n] = -s
        return out
    o, one = xp.zeros_like(a), xp.ones_like(a)
    M = [[o, o, o], [o, o, o], [o, o, o]]
    M[axis][axis] = one
    M[m][m] = c
    M[n][n] = c
    M[n][m] = s
    M[m][n] = -s
    return xp.stack([xp.stack(row, axis=-1) for row in M], axis=-2)


def _angle_about(M: Any, axis: int) -> Any:
    """Angle a of a rotation M ≈ R_axis(a): from M e_m = cos a e_m + sin a e_n."""
    m, n = (axis + 1) % 3, (axis + 2) % 3
    return namespace(M).arctan2(M[..., n, m], M[..., m, m])


def _wrap(a: Any) -> Any:
    """Wrap to (−π, π]."""
    return np.pi - namespace(a).mod(np.pi - a, 2.0 * np.pi)


def _mT(M: Any) -> Any:
    return namespace(M).swapaxes(M, -1, -2)


def to_matrix(angles: object, seq: str) -> np.ndarray:
    """R(a) for ``angles`` ``(..., 3)`` = (a1, a2, a3) in radians; intrinsic ``"IJK"``:
    R = R_I(a1) R_J(a2) R_K(a3); extrinsic ``"ijk"``: R = R_k(a3) R_j(a2) R_i(a1)."""
    (i, j, k), ext = _parse(seq)
    a = _angles(angles)
    if ext:
        a = a[..., ::-1]
    return _elem(i, a[..., 0]) @ _elem(j, a[..., 1]) @ _elem(k, a[..., 2])


def from_matrix(
    R: object, seq: str, lock_tol: float = FROM_MATRIX_LOCK_TOL, warn: bool = True
) -> np.ndarray:
    """Euler angles (a1, a2, a3) of rotation matrices ``(..., 3, 3)`` in the ranges of the module
    docstring (scipy's).

    Method, for the intrinsic axes (i, j, k): a2 from the i-th row (atan2 form, accurate near
    lock); a1 from the direction of the k-th column about axis i; a3 from the residual
    R_j(a2)ᵀ R_i(a1)ᵀ R = R_k(a3), which keeps R reproduced to round-off even near lock.

    Gimbal lock (|cos a2| resp. |sin a2| < ``lock_tol``, default 1e-12): only a1 ± a3 is
    determined; the documented choice is **a3 = 0** (the third angle of ``seq`` as written, for
    intrinsic and extrinsic sequences alike, as scipy) and a :class:`GimbalLockWarning` is issued
    when ``warn``; R is then reproduced to ≤ π·lock_tol. Just outside the branch a1 and a3 are
    individually ill-conditioned (only a1 ± a3 is well determined) but still reproduce R; use
    :func:`near_gimbal_lock` to detect the neighbourhood.
    """
    R = check_rotation_matrix(R, "R")
    _parse(seq)
    lock_tol = check_tolerance(lock_tol, "lock_tol", upper=1.0)
    warn = check_bool(warn, "warn")
    out, lock = _from_matrix_unchecked(R, seq, lock_tol)
    if warn and np.any(lock):
        warnings.warn(
            f"R: gimbal lock in sequence {seq!r} for {int(np.count_nonzero(lock))} matrix(es); "
            "only a1 ± a3 is determined, the third angle was set to 0",
            GimbalLockWarning,
            stacklevel=2,
        )
    return out


def _from_matrix_unchecked(R: Any, seq: str, lock_tol: float) -> tuple[Any, Any]:
    """``(angles, lock)`` of :func:`from_matrix` for checked rotations, pure (NumPy or JAX):
    both branches evaluated, the lock branch selected where |cos a2| (|sin a2|) < lock_tol."""
    xp = namespace(R)
    (i, j, k), ext = _parse(seq)
    tb = i != k
    if tb:
        eps = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
        a2 = xp.arctan2(eps * R[..., i, k], xp.hypot(R[..., i, i], R[..., i, j]))
        lock = xp.abs(xp.cos(a2)) < lock_tol
        d = np.zeros(3)
        d[k] = 1.0
    else:
        kk = 3 - i - j
        eps = 1.0 if (i, j, kk) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
        a2 = xp.arctan2(xp.hypot(R[..., i, j], R[..., i, kk]), R[..., i, i])
        lock = xp.abs(xp.sin(a2)) < lock_tol
        d = np.zeros(3)
        d[kk] = -eps  # direction of R_j(a2) e_i ⟂ e_i, for sin a2 > 0
    m, n = (i + 1) % 3, (i + 2) % 3
    a1 = _wrap(xp.arctan2(R[..., n, k], R[..., m, k]) - np.arctan2(d[n], d[m]))
    Ri1 = _elem(i, a1)
    Rj2 = _elem(j, a2)
    a3 = _angle_about(_mT(Rj2) @ _mT(Ri1) @ R, k)
    if xp is not np or np.any(lock):
        if ext:
            # the extrinsic third angle is the intrinsic first: R = R_j(a2) R_k(a3')
            a1 = xp.where(lock, 0.0, a1)
            a3 = xp.where(lock, _angle_about(_mT(Rj2) @ R, k), a3)
        else:
            a1 = xp.where(lock, _angle_about(R @ _mT(Rj2), i), a1)
            a3 = xp.where(lock, 0.0, a3)
    out = xp.stack((a1, a2, a3), axis=-1)
    if ext:
        out = out[..., ::-1]
        return (out.copy() if xp is np else out), lock
    return out, lock


def near_gimbal_lock(angles: object, seq: str, tol: float = LOCK_TOL) -> np.ndarray:
    """Boolean (batch shape): |cos a2| < tol for Tait–Bryan, |sin a2| < tol for proper Euler."""
    (i, _, k), _ = _parse(seq)
    a = _angles(angles)
    tol = check_tolerance(tol, "tol", upper=1.0)
    f = np.cos if i != k else np.sin
    return np.abs(f(a[..., 1])) < tol


def _rates_matrix_inv_intrinsic(a: Any, axes: tuple[int, int, int]) -> Any:
    xp = namespace(a)
    i, j, k = axes
    Rk3T = _mT(_elem(k, a[..., 2]))
    Rj2T = _mT(_elem(j, a[..., 1]))
    c1 = (Rk3T @ Rj2T)[..., :, i]
    c2 = Rk3T[..., :, j]
    c3 = xp.broadcast_to(np.eye(3)[:, k], c1.shape)
    return xp.stack((c1, c2, c3), axis=-1)


def rates_matrix_inv(angles: object, seq: str) -> np.ndarray:
    """M(a) with ω = M(a) ȧ (ω the body rate), ``(..., 3) -> (..., 3, 3)``; defined everywhere."""
    return _rates_matrix_inv_unchecked(_angles(angles), seq)


def _rates_matrix_inv_unchecked(a: Any, seq: str) -> Any:
    """:func:`rates_matrix_inv` of checked angles, pure (NumPy or JAX)."""
    axes, ext = _parse(seq)
    if ext:
        M = _rates_matrix_inv_intrinsic(a[..., ::-1], axes)[..., ::-1]
        return M.copy() if namespace(a) is np else M
    return _rates_matrix_inv_intrinsic(a, axes)


def _rates_matrix_unchecked(a: Any, seq: str) -> Any:
    """B = M⁻¹ of :func:`rates_matrix` without the gimbal-lock check, pure (NumPy or JAX): not
    finite at the lock itself, so the caller guards it (the chart adapter's array law reports
    the lock and poisons the torque)."""
    M = _rates_matrix_inv_unchecked(a, seq)
    c1, c2, c3 = M[..., :, 0], M[..., :, 1], M[..., :, 2]
    rows = namespace(a).stack((cross(c2, c3), cross(c3, c1), cross(c1, c2)), axis=-2)
    det = (c1 * rows[..., 0, :]).sum(axis=-1)
    return rows / det[..., None, None]


def rates_matrix(angles: object, seq: str, lock_tol: float = LOCK_TOL) -> np.ndarray:
    """B(a) with ȧ = B(a) ω (ω the body rate), ``(..., 3) -> (..., 3, 3)``; B = M⁻¹ computed
    from the cross products of M's columns (rows c₂×c₃, c₃×c₁, c₁×c₂ over det M).

    Raises :class:`ChartSingularityError` when |cos a2| (Tait–Bryan) or |sin a2| (proper Euler)
    < ``lock_tol`` for any batch element. E.g. ``"ZYX"``:
    B = (1/cos a2) [[0, sin a3, cos a3], [0, cos a3 cos a2, −sin a3 cos a2],
    [cos a2, sin a3 sin a2, cos a3 sin a2]] (Schaub & Junkins eq. 3.57).
    """
    a = _angles(angles)
    lock_tol = check_tolerance(lock_tol, "lock_tol", upper=1.0)
    lock = near_gimbal_lock(a, seq, lock_tol)
    if np.any(lock):
        (i, _, k), _ = _parse(seq)
        which = "cos" if i != k else "sin"
        f = np.cos if i != k else np.sin
        worst = float(np.abs(f(a[..., 1])).min())
        raise ChartSingularityError(
            f"angles: gimbal lock in sequence {seq!r} (|{which} a2| = {worst:.2e} < "
            f"lock_tol = {lock_tol:.0e}); Euler-angle rates are undefined there — use another "
            "chart or sequence"
        )
    return _rates_matrix_unchecked(a, seq)


def kinematics(angles: object, omega: object, seq: str, lock_tol: float = LOCK_TOL) -> np.ndarray:
    """ȧ = B(a) ω (ω the body angular velocity); raises :class:`ChartSingularityError` at gimbal
    lock (see :func:`rates_matrix`). Batch shapes broadcast."""
    B = rates_matrix(angles, seq, lock_tol)
    w = as_array(omega, "omega", (3,))
    broadcast_batch(("angles", B.shape[:-2]), ("omega", w.shape[:-1]))
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.einsum("...ij,...j->...i", B, w)
    return check_output_finite(out, "omega", "the angle rates B(a) ω")
