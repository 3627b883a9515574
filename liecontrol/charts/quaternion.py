"""Unit quaternions (Hamilton convention) as a chart of SO(3).

Storage order. Every function takes ``scalar_first: bool = True``:

* ``scalar_first=True`` (default, as in the source papers): ``q = (w, x, y, z)``;
* ``scalar_first=False``: ``q = (x, y, z, w)``, the order of
  ``scipy.spatial.transform.Rotation.as_quat()``.

The flag applies to every quaternion argument and every quaternion result of the call.
Quaternions are arrays of shape ``(..., 4)`` with any leading batch shape (broadcast between
arguments).

Conventions (``docs/design.md``):

* Hamilton product ``p ⊗ q = (p_w q_w − p_v·q_v, p_w q_v + q_w p_v + p_v × q_v)``;
* ``R = to_matrix(q)`` maps body → inertial, ``R = I + 2w v^ + 2 v^²`` (v the vector part);
  ``q`` and ``−q`` give the same R (double cover);
* kinematics ``q̇ = ½ q ⊗ (0, ω)`` with ω the body angular velocity (``Ṙ = R ω^``).

Unit norm. Functions that interpret q as a rotation (:func:`to_matrix`, :func:`to_rotvec`,
:func:`rotate`, :func:`slerp`, :func:`error`) require
``| |q| − 1 | ≤ norm_tol`` (default :data:`UNIT_TOL` = 1e-6) and raise ``ValueError`` otherwise,
so a drifting integrator is caught rather than silently rescaled; inside the tolerance they
renormalise so the result is exact to round-off. :func:`normalize` is the explicit fix.
Algebraic functions (:func:`multiply`, :func:`conjugate`, :func:`inverse`, :func:`kinematics`,
:func:`kinematics_matrix`, :func:`canonicalize`) accept any finite non-zero quaternion.
Zero or non-finite quaternions always raise ``ValueError`` naming the argument.
Norms are computed without overflow or underflow (``normalize(1e300·q)`` is ``q/|q|``), batch
shapes that do not broadcast raise naming the argument, ``scalar_first`` must be a bool and
``norm_tol`` a finite number > 0; a result that would overflow float64 (e.g. the product of two
quaternions of norm 1e200) raises instead of returning inf/NaN.

Sources: Shepperd, "Quaternion from rotation matrix", J. Guidance Control 1(3), 1978;
Solà, "Quaternion kinematics for the error-state Kalman filter", arXiv:1711.02508 (2017);
Shoemake, "Animating rotation with quaternion curves", SIGGRAPH 1985 (slerp).
"""

from __future__ import annotations

import numpy as np

from .._array_api import namespace
from .._validation import (
    as_array,
    broadcast_batch,
    check_bool,
    check_output_finite,
    check_rotation_matrix,
    check_tolerance,
    norm_last,
)
from ..lie.so3 import _shape_arg

__all__ = [
    "UNIT_TOL",
    "identity",
    "from_matrix",
    "to_matrix",
    "multiply",
    "conjugate",
    "inverse",
    "norm",
    "normalize",
    "canonicalize",
    "from_rotvec",
    "to_rotvec",
    "rotate",
    "kinematics",
    "kinematics_matrix",
    "error",
    "slerp",
]

#: Default tolerance on | |q| − 1 | for functions that need a unit quaternion.
UNIT_TOL = 1e-6

# Below this sin(θ/2) the rotation-vector factor θ / sin(θ/2) uses its Taylor series.
_SMALL_HALF_SINE = 1e-6
# Below this arc angle Ω slerp falls back to normalised linear interpolation (sin Ω ≈ 0).
_SLERP_LINEAR_ANGLE = 1e-12


# --------------------------------------------------------------------------- storage helpers


def _take(q: object, name: str, scalar_first: bool) -> np.ndarray:
    """Validate a quaternion argument and return it scalar-first (a new array when reordered)."""
    check_bool(scalar_first, "scalar_first")
    a = as_array(q, name, (4,))
    if np.any(np.all(a == 0.0, axis=-1)):
        raise ValueError(f"{name}: zero quaternion (norm 0) does not represent a rotation")
    if not scalar_first:
        a = np.roll(a, 1, axis=-1)
    return a


def _take_unit(q: object, name: str, scalar_first: bool, norm_tol: float) -> np.ndarray:
    """As :func:`_take`, also checking | |q| − 1 | ≤ norm_tol; returns the renormalised copy."""
    norm_tol = check_tolerance(norm_tol, "norm_tol")
    a = _take(q, name, scalar_first)
    n = norm_last(a)
    dev = np.abs(n - 1.0)
    worst = float(dev.max()) if dev.size else 0.0
    if worst > norm_tol:
        raise ValueError(
            f"{name}: not a unit quaternion (max | |q| − 1 | = {worst:.2e} > {norm_tol:.0e}); "
            "use quaternion.normalize(q) first"
        )
    return a / n[..., None]


def _give(q: np.ndarray, scalar_first: bool) -> np.ndarray:
    """Reorder an internal scalar-first result to the requested storage order."""
    return q if scalar_first else np.roll(q, -1, axis=-1)


def _mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product on scalar-first arrays (broadcasting); pure (NumPy or JAX)."""
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return namespace(p, q).stack(
        (
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ),
        axis=-1,
    )


def _canon(q: np.ndarray) -> np.ndarray:
    """Scalar-first canonical sign: w > 0, or w == 0 and the first non-zero of x, y, z > 0."""
    # The first non-zero component of (w, x, y, z) decides the sign; a non-zero q always has one.
    nz = q != 0.0
    first = np.argmax(nz, axis=-1)
    lead = np.take_along_axis(q, first[..., None], axis=-1)
    return np.where(lead < 0.0, -q, q)


# --------------------------------------------------------------------------- public API


def identity(batch_shape: tuple[int, ...] = (), scalar_first: bool = True) -> np.ndarray:
    """Identity quaternion(s) of shape ``batch_shape + (4,)``."""
    check_bool(scalar_first, "scalar_first")
    q = np.zeros(_shape_arg(batch_shape, "batch_shape") + (4,))
    q[..., 0 if scalar_first else 3] = 1.0
    return q


def from_matrix(R: object, scalar_first: bool = True) -> np.ndarray:
    """Unit quaternion of a rotation matrix (body → inertial), canonical sign (see
    :func:`canonicalize`).

    Shepperd's method: of 4w² = 1 + tr R, 4x² = 1 + 2R₀₀ − tr R, 4y² = 1 + 2R₁₁ − tr R,
    4z² = 1 + 2R₂₂ − tr R the largest is used for the pivot component, the others come from the
    off-diagonal sums/differences, e.g. for the w pivot 4w x = R₂₁ − R₁₂. The pivot is ≥ ½, so
    the result is accurate to round-off for every R, including half-turns (w = 0).
    ``R``: ``(..., 3, 3)``, validated as a rotation; returns ``(..., 4)``.
    """
    check_bool(scalar_first, "scalar_first")
    R = check_rotation_matrix(R, "R")
    r00, r01, r02 = R[..., 0, 0], R[..., 0, 1], R[..., 0, 2]
    r10, r11, r12 = R[..., 1, 0], R[..., 1, 1], R[..., 1, 2]
    r20, r21, r22 = R[..., 2, 0], R[..., 2, 1], R[..., 2, 2]
    tr = r00 + r11 + r22
    d = np.stack((tr, r00, r11, r22), axis=-1)
    k = np.argmax(d, axis=-1)
    # Unnormalised candidates, candidate k = 4·q_k·q (all four computed, one selected per item)
    cand = np.stack(
        (
            np.stack((1.0 + tr, r21 - r12, r02 - r20, r10 - r01), axis=-1),
            np.stack((r21 - r12, 1.0 + 2.0 * r00 - tr, r01 + r10, r02 + r20), axis=-1),
            np.stack((r02 - r20, r01 + r10, 1.0 + 2.0 * r11 - tr, r12 + r21), axis=-1),
            np.stack((r10 - r01, r02 + r20, r12 + r21, 1.0 + 2.0 * r22 - tr), axis=-1),
        ),
        axis=-2,
    )
    q = np.take_along_axis(cand, k[..., None, None], axis=-2)[..., 0, :]
    q = q / np.sqrt(np.sum(q * q, axis=-1, keepdims=True))
    return _give(_canon(q), scalar_first)


def to_matrix(q: object, scalar_first: bool = True, norm_tol: float = UNIT_TOL) -> np.ndarray:
    """Rotation matrix (body → inertial) of a unit quaternion: R = I + 2w v^ + 2 v^².

    ``q``: ``(..., 4)``; must satisfy | |q| − 1 | ≤ ``norm_tol`` (then renormalised) — raises
    ``ValueError`` otherwise. Returns ``(..., 3, 3)``.
    """
    q = _take_unit(q, "q", scalar_first, norm_tol)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1.0 - 2.0 * (yy + zz)
    R[..., 0, 1] = 2.0 * (xy - wz)
    R[..., 0, 2] = 2.0 * (xz + wy)
    R[..., 1, 0] = 2.0 * (xy + wz)
    R[..., 1, 1] = 1.0 - 2.0 * (xx + zz)
    R[..., 1, 2] = 2.0 * (yz - wx)
    R[..., 2, 0] = 2.0 * (xz - wy)
    R[..., 2, 1] = 2.0 * (yz + wx)
    R[..., 2, 2] = 1.0 - 2.0 * (xx + yy)
    return R


def multiply(p: object, q: object, scalar_first: bool = True) -> np.ndarray:
    """Hamilton product p ⊗ q (batch shapes broadcast); ``to_matrix(p ⊗ q) = R(p) R(q)``.
    Raises if |p|·|q| overflows float64."""
    a = _take(p, "p", scalar_first)
    b = _take(q, "q", scalar_first)
    broadcast_batch(("p", a.shape[:-1]), ("q", b.shape[:-1]))
    with np.errstate(over="ignore", invalid="ignore"):
        out = _mul(a, b)
    return _give(check_output_finite(out, "q", "the product p ⊗ q"), scalar_first)


def conjugate(q: object, scalar_first: bool = True) -> np.ndarray:
    """q* = (w, −v)."""
    a = _take(q, "q", scalar_first).copy()
    a[..., 1:] *= -1.0
    return _give(a, scalar_first)


def norm(q: object, scalar_first: bool = True) -> np.ndarray:
    """|q| (batch shape); rejects zero quaternions like every other function."""
    return norm_last(_take(q, "q", scalar_first))


def inverse(q: object, scalar_first: bool = True) -> np.ndarray:
    """q⁻¹ = q* / |q|² (equal to q* for unit q), as (q*/|q|)/|q| so that neither |q|² nor the
    division overflows; raises if |q| is so small that 1/|q| itself overflows."""
    a = _take(q, "q", scalar_first)
    n = norm_last(a)[..., None]
    with np.errstate(over="ignore"):
        inv = (a * np.array([1.0, -1.0, -1.0, -1.0]) / n) / n
    return _give(check_output_finite(inv, "q", "the inverse 1/|q|"), scalar_first)


def normalize(q: object, scalar_first: bool = True) -> np.ndarray:
    """q / |q| (|q| computed without overflow or underflow); raises ``ValueError``
    (``"q: zero quaternion ..."``) on zero norm."""
    a = _take(q, "q", scalar_first)
    return _give(a / norm_last(a)[..., None], scalar_first)


def canonicalize(q: object, scalar_first: bool = True) -> np.ndarray:
    """The sign representative of ±q with w > 0; when w = 0 exactly (half-turns), the first
    non-zero of (x, y, z) is made positive. Same convention as scipy's
    ``Rotation.as_quat(canonical=True)``. The norm is left unchanged.
    """
    return _give(_canon(_take(q, "q", scalar_first)), scalar_first)


def from_rotvec(theta: object, scalar_first: bool = True) -> np.ndarray:
    """q = (cos(|θ|/2), sin(|θ|/2) θ/|θ|) for a rotation vector θ ``(..., 3)``.

    Exact at θ = 0 (sin(|θ|/2)/|θ| via ``np.sinc``). The result has w ≥ 0 for |θ| ≤ π. For
    |θ| > 1e100 the axis–angle form (cos(|θ|/2), sin(|θ|/2) θ/|θ|) is used (no overflow).
    """
    check_bool(scalar_first, "scalar_first")
    th = as_array(theta, "theta", (3,))
    angle = norm_last(th)
    if angle.size and np.max(angle) > 1e100:
        n = th / np.where(angle > 0.0, angle, 1.0)[..., None]
        q = np.concatenate(
            (np.cos(0.5 * angle)[..., None], n * np.sin(0.5 * angle)[..., None]), axis=-1
        )
        return _give(q, scalar_first)
    return _give(_from_rotvec_unchecked(th, angle), scalar_first)


def _from_rotvec_unchecked(th: np.ndarray, angle: np.ndarray | None = None) -> np.ndarray:
    """Scalar-first :func:`from_rotvec` of a validated ``(..., 3)`` array with |θ| ≤ 1e100
    (the filters' tangent-space perturbations; ``angle`` = |θ| if the caller has it)."""
    if angle is None:
        angle = np.sqrt(np.sum(th * th, axis=-1))
    # sin(φ/2)/φ = ½ sinc(φ/2π) with numpy's normalised sinc, exact at φ = 0
    k = 0.5 * np.sinc(angle / (2.0 * np.pi))
    return np.concatenate((np.cos(0.5 * angle)[..., None], th * k[..., None]), axis=-1)


def to_rotvec(q: object, scalar_first: bool = True, norm_tol: float = UNIT_TOL) -> np.ndarray:
    """Rotation vector θ with |θ| ∈ [0, π] (the shortest one): θ = 2 atan2(|v|, w) v/|v| after
    choosing the sign of q with w ≥ 0. Taylor branch θ ≈ (2/w)(1 − |v|²/(3w²)) v near 0.
    At a half-turn (w = 0) either ±π·axis is valid; the one of the given sign of v is returned.
    """
    return _to_rotvec_unchecked(_take_unit(q, "q", scalar_first, norm_tol))


def _to_rotvec_unchecked(a: np.ndarray) -> np.ndarray:
    """:func:`to_rotvec` of validated scalar-first unit quaternions ``(..., 4)``."""
    a = np.where(a[..., :1] < 0.0, -a, a)
    w = a[..., 0]
    v = a[..., 1:]
    s = np.sqrt(np.sum(v * v, axis=-1))
    small = s < _SMALL_HALF_SINE
    s_safe = np.where(small, 1.0, s)
    w_safe = np.where(small, w, 1.0)
    factor = np.where(
        small,
        2.0 / w_safe * (1.0 - s * s / (3.0 * w_safe * w_safe)),
        2.0 * np.arctan2(s, w) / s_safe,
    )
    return v * factor[..., None]


def rotate(
    q: object, v: object, scalar_first: bool = True, norm_tol: float = UNIT_TOL
) -> np.ndarray:
    """R(q) v = v + 2w (u × v) + 2 u × (u × v) (u the vector part); batch shapes broadcast."""
    a = _take_unit(q, "q", scalar_first, norm_tol)
    vv = as_array(v, "v", (3,))
    broadcast_batch(("q", a.shape[:-1]), ("v", vv.shape[:-1]))
    w = a[..., :1]
    u = a[..., 1:]
    with np.errstate(over="ignore", invalid="ignore"):
        t = 2.0 * np.cross(u, vv)
        out = vv + w * t + np.cross(u, t)
    return check_output_finite(out, "v", "the rotated vector")


def kinematics(q: object, omega: object, scalar_first: bool = True) -> np.ndarray:
    """q̇ = ½ q ⊗ (0, ω) with ω the body angular velocity. Shapes broadcast."""
    a = _take(q, "q", scalar_first)
    w = as_array(omega, "omega", (3,))
    broadcast_batch(("q", a.shape[:-1]), ("omega", w.shape[:-1]))
    pure = np.concatenate((np.zeros(w.shape[:-1] + (1,)), w), axis=-1)
    with np.errstate(over="ignore", invalid="ignore"):
        out = 0.5 * _mul(a, pure)
    return _give(check_output_finite(out, "omega", "q̇ = ½ q ⊗ (0, ω)"), scalar_first)


def kinematics_matrix(q: object, scalar_first: bool = True) -> np.ndarray:
    """The 4×3 matrix ½Ξ(q) with q̇ = ½Ξ(q) ω, ``(..., 4) -> (..., 4, 3)``.

    Scalar-first, Ξ(q) = [[−x, −y, −z], [w, −z, y], [z, w, −x], [−y, x, w]]; with
    ``scalar_first=False`` the scalar row comes last. Ξ(q)ᵀ Ξ(q) = |q|² I₃ and Ξ(q)ᵀ q = 0.
    """
    a = _take(q, "q", scalar_first)
    w, x, y, z = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    rows = (
        np.stack((-x, -y, -z), axis=-1),
        np.stack((w, -z, y), axis=-1),
        np.stack((z, w, -x), axis=-1),
        np.stack((-y, x, w), axis=-1),
    )
    if not scalar_first:
        rows = rows[1:] + rows[:1]
    return 0.5 * np.stack(rows, axis=-2)


def error(
    q: object, q_d: object, scalar_first: bool = True, norm_tol: float = UNIT_TOL
) -> np.ndarray:
    """Attitude error quaternion q_e = q_d⁻¹ ⊗ q (the quaternion of R_dᵀ R), not canonicalised
    (the sign carries the unwinding information controllers may want). Shapes broadcast."""
    a = _take_unit(q, "q", scalar_first, norm_tol)
    d = _take_unit(q_d, "q_d", scalar_first, norm_tol)
    broadcast_batch(("q", a.shape[:-1]), ("q_d", d.shape[:-1]))
    d = d * np.array([1.0, -1.0, -1.0, -1.0])
    return _give(_mul(d, a), scalar_first)


def slerp(
    q0: object,
    q1: object,
    t: object,
    scalar_first: bool = True,
    norm_tol: float = UNIT_TOL,
) -> np.ndarray:
    """Spherical linear interpolation along the shorter arc (Shoemake 1985):
    q(t) = [sin((1−t)Ω) q₀ + sin(tΩ) q₁'] / sin Ω, with q₁' = ±q₁ chosen so that q₀·q₁' ≥ 0 and
    cos Ω = q₀·q₁'. t = 0 → q₀, t = 1 → q₁' (the same rotation as q₁); ``to_matrix(slerp)``
    equals the SO(3) geodesic ``R₀ exp(t log(R₀ᵀR₁))``. When q₀ ≈ ±q₁ normalised
    linear interpolation is used (Ω < 1e-12). ``t`` broadcasts against the batch shape.
    """
    a = _take_unit(q0, "q0", scalar_first, norm_tol)
    b = _take_unit(q1, "q1", scalar_first, norm_tol)
    tt = as_array(t, "t")
    broadcast_batch(("q0", a.shape[:-1]), ("q1", b.shape[:-1]), ("t", tt.shape))
    tt = tt[..., None]
    dot = np.sum(a * b, axis=-1, keepdims=True)
    b = np.where(dot < 0.0, -b, b)
    # Ω = 2 atan2(|a − b|, |a + b|) is accurate for small Ω, unlike arccos(a·b)
    omega = 2.0 * np.arctan2(
        np.sqrt(np.sum((a - b) ** 2, axis=-1, keepdims=True)),
        np.sqrt(np.sum((a + b) ** 2, axis=-1, keepdims=True)),
    )
    lin = omega < _SLERP_LINEAR_ANGLE
    s = np.where(lin, 1.0, np.sin(omega))
    c0 = np.where(lin, 1.0 - tt, np.sin((1.0 - tt) * omega) / s)
    c1 = np.where(lin, tt, np.sin(tt * omega) / s)
    out = c0 * a + c1 * b
    out = out / np.sqrt(np.sum(out * out, axis=-1, keepdims=True))
    return _give(out, scalar_first)
