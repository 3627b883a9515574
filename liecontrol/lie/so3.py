"""The rotation group SO(3): batched array functions (the fast path).

Conventions (``docs/design.md``): vectors are ``(..., 3)``, matrices ``(..., 3, 3)``; any leading
batch shape is accepted and broadcast; ``hat(w) @ v == cross(w, v)``;
``exp(w + δ) ≈ exp(w) exp(J_r(w) δ)`` and ``exp(w + δ) ≈ exp(J_l(w) δ) exp(w)``.

Every public function validates its arguments: real, finite, the right trailing shape, batch
shapes that broadcast, and for rotation arguments a cheap structural check (``max |RᵀR − I|`` and
``|det R − 1|``-sign within :data:`ARRAY_ROTATION_ATOL` = 1e-6, loose enough for rotations that
carry integration round-off, tight enough that ``2·I``, a reflection or the zero matrix raise
instead of returning a meaningless logarithm). :func:`validate` (and the
:class:`liecontrol.lie.SO3` wrapper) applies the strict tolerance ``1e-9``. Hot paths that have
validated their inputs already call the explicitly named unchecked variants
(:func:`log_unchecked`, :func:`angle_unchecked`), which are not part of ``__all__``.

Sources: Rodrigues' formula and the SO(3) Jacobians as in Barfoot, *State Estimation for
Robotics* (2017), §7.1; Solà, Deray & Atchuthan, *A micro Lie theory for state estimation in
robotics* (2018), App. B. The logarithm near π uses the symmetric part of R.
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import Any

import numpy as np

from .._array_api import any_true, is_numpy, namespace, safe_sqrt
from .._kernels.so3 import exp9 as _exp9
from .._kernels.so3 import log9 as _log9
from .._validation import (
    _to_float_array,
    as_array,
    broadcast_batch,
    check_finite,
    check_rotation_matrix,
    check_shape_tail,
    check_tolerance,
    norm_last,
    rotations_pass_fast,
)

__all__ = [
    "hat",
    "vee",
    "exp",
    "log",
    "angle",
    "left_jacobian",
    "right_jacobian",
    "left_jacobian_inv",
    "right_jacobian_inv",
    "adjoint",
    "ad",
    "compose",
    "inverse",
    "act",
    "distance",
    "interpolate",
    "random",
    "project",
    "validate",
    "identity",
]

_F64 = np.dtype(np.float64)

# Below these angles the closed forms lose digits to cancellation; Taylor series take over.
_SMALL_SINC = 1e-2
_SMALL_JAC = 0.1
# Above this angle (cos θ < −0.999, θ > π − 0.0447) the log takes its axis from the symmetric part
# of R: there (R − Rᵀ)^∨ = 2 sin θ n would lose more than ~1e-14 of relative accuracy in the axis.
_LOG_SYMMETRIC_COS = -0.999


#: Tolerance of the structural rotation check of the array functions (max |RᵀR − I|); the
#: strict check of :func:`validate` and of the object layer uses 1e-9.
ARRAY_ROTATION_ATOL = 1e-6

#: The Jacobian inverses are singular at θ = 2πk (k ≥ 1), where sin(θ/2) = 0: they raise where
#: |sin(θ/2)| ≤ JAC_INV_SINGULAR_SIN (i.e. |θ − 2πk| ≲ 2e-8). The entries grow like
#: θ/(2|sin(θ/2)|), so at the threshold they are ~3e8·θ and J·J⁻¹ − I is ~1e-8.
JAC_INV_SINGULAR_SIN = 1e-8


def _vec(w: object, name: str) -> np.ndarray:
    a = _to_float_array(w, name)
    check_shape_tail(a, name, (3,))
    check_finite(a, name)
    return a


def _mat(R: object, name: str) -> np.ndarray:
    """A finite real ``(..., 3, 3)`` array (no rotation check: for matrices that need not be
    rotations, e.g. the skew matrix of :func:`vee`)."""
    a = _to_float_array(R, name)
    check_shape_tail(a, name, (3, 3))
    check_finite(a, name)
    return a


def _rot(R: object, name: str) -> np.ndarray:
    """A (batch of) rotation matrices within :data:`ARRAY_ROTATION_ATOL` (cheap check first)."""
    if rotations_pass_fast(R, ARRAY_ROTATION_ATOL):
        return R  # type: ignore[return-value]
    # check_rotation_matrix converts (and accepts a scipy Rotation), checks shape and finiteness
    return check_rotation_matrix(R, name, ARRAY_ROTATION_ATOL)


_batch = broadcast_batch  # short local name


_norm = norm_last  # overflow-safe ‖w‖


def _axis_angle(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(θ, n) with θ = ‖w‖ (overflow-safe) and n = w/θ (n = 0 at θ = 0): the route for rotation
    vectors so long that the polynomial forms in w would overflow."""
    theta = _norm(w)
    safe = np.where(theta > 0.0, theta, 1.0)
    return theta, w / safe[..., None]


def _exp_axis_angle(w: np.ndarray) -> np.ndarray:
    """Rodrigues in axis–angle form, R = I + sin θ n^ + (1 − cos θ) n^², 1 − cos θ = 2 sin²(θ/2):
    every term bounded, so it cannot overflow for any finite w (libm reduces huge θ exactly)."""
    theta, n = _axis_angle(w)
    N = hat(n)
    s = np.sin(theta)[..., None, None]
    h = np.sin(0.5 * theta)
    c = (2.0 * h * h)[..., None, None]
    return np.eye(3) + s * N + c * (N @ N)


def _sinc(theta: np.ndarray) -> np.ndarray:
    """sin θ / θ, accurate at and near 0."""
    small = theta < _SMALL_SINC
    t = np.where(small, 1.0, theta)
    out = np.sin(t) / t
    if np.any(small):
        t2 = theta * theta
        out = np.where(small, 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0)), out)
    return out


def _jac_coeffs(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(1 − cos θ)/θ² and (θ − sin θ)/θ³, accurate at and near 0."""
    half = 0.5 * _sinc(0.5 * theta)
    b = 2.0 * half * half
    small = theta < _SMALL_JAC
    t = np.where(small, 1.0, theta)
    c = (t - np.sin(t)) / (t * t * t)
    if np.any(small):
        t2 = theta * theta
        series = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0
        c = np.where(small, series, c)
    return b, c


def _jac_inv_coeff(theta: np.ndarray) -> np.ndarray:
    """1/θ² − cot(θ/2)/(2θ): the W² coefficient of J⁻¹; finite on [0, 2π), exact zero-free at π."""
    small = theta < _SMALL_JAC
    t = np.where(small, 1.0, theta)
    half = 0.5 * t
    out = 1.0 / (t * t) - np.cos(half) / (2.0 * t * np.sin(half))
    if np.any(small):
        t2 = theta * theta
        series = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0
        out = np.where(small, series, out)
    return out


def _shape_arg(shape: object, name: str) -> tuple[int, ...]:
    """A batch-shape argument: a non-negative int or a tuple of them."""
    if isinstance(shape, (int, np.integer)) and not isinstance(shape, (bool, np.bool_)):
        shape = (shape,)
    try:
        out = tuple(shape)  # type: ignore[arg-type]
    except TypeError:
        raise TypeError(
            f"{name}: expected an int or a tuple of ints, got {type(shape).__name__}"
        ) from None
    for d in out:
        if isinstance(d, (bool, np.bool_)) or not isinstance(d, (int, np.integer)):
            raise TypeError(f"{name}: expected a tuple of ints, got an entry {d!r}")
        if d < 0:
            raise ValueError(f"{name}: dimensions must be >= 0, got {out}")
    return tuple(int(d) for d in out)


def identity(batch_shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity rotation(s) of shape ``batch_shape + (3, 3)``."""
    return np.broadcast_to(np.eye(3), _shape_arg(batch_shape, "batch_shape") + (3, 3)).copy()


def hat(w: object) -> np.ndarray:
    """Skew matrix ω^ with ω^ v = ω × v; ``(..., 3) -> (..., 3, 3)``."""
    if _one_vec(w):
        x, y, z = w.tolist()  # type: ignore[attr-defined]
        return np.array(((0.0, -z, y), (z, 0.0, -x), (-y, x, 0.0)))
    xp = namespace(w)
    return _hat(_vec(w, "w") if is_numpy(xp) else _traced(w, "w", (3,)), xp)


def _hat(w: Any, xp: ModuleType) -> Any:
    """:func:`hat` of a checked ``(..., 3)`` array of the namespace ``xp`` (pure)."""
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    o = xp.zeros_like(x)
    return xp.stack(
        (xp.stack((o, -z, y), axis=-1), xp.stack((z, o, -x), axis=-1),
         xp.stack((-y, x, o), axis=-1)),
        axis=-2,
    )  # fmt: skip


def _traced(a: Any, name: str, tail: tuple[int, ...]) -> Any:
    """A JAX array argument, checked for its trailing shape only: under ``jit``, ``vmap`` or
    ``grad`` its values are unknown when the program is built (finiteness and the rotation
    check are the NumPy layer's; a traced caller validates its inputs before tracing)."""
    if a.ndim < len(tail) or tuple(a.shape[a.ndim - len(tail) :]) != tail:
        want = ", ".join(map(str, tail))
        raise ValueError(f"{name}: expected shape (..., {want}), got {a.shape}")
    return a


def vee(W: object) -> np.ndarray:
    """Inverse of :func:`hat`: ``(..., 3, 3) -> (..., 3)``.

    Reads the entries (W₂₁, W₀₂, W₁₀). ``W`` must be skew-symmetric to round-off
    (max |W + Wᵀ| ≤ 1e-9 · max(1, max |W|)); skew-symmetrise (W − Wᵀ)/2 first otherwise.
    """
    xp = namespace(W)
    if not is_numpy(xp):
        return _vee(_traced(W, "W", (3, 3)), xp)
    W = _mat(W, "W")
    if W.size:
        asym = float(np.abs(W + np.swapaxes(W, -1, -2)).max())
        if asym > 1e-9 * max(1.0, float(np.abs(W).max())):
            raise ValueError(f"W: not skew-symmetric (max |W + Wᵀ| = {asym:.2e})")
    return _vee(W, np)


def _vee(W: Any, xp: ModuleType) -> Any:
    """:func:`vee` of a checked skew ``(..., 3, 3)`` array of the namespace ``xp`` (pure)."""
    return xp.stack((W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]), axis=-1)


def exp(w: object) -> np.ndarray:
    """Rodrigues' formula R = cos θ I + (sin θ/θ) ω^ + ((1 − cos θ)/θ²) ω ωᵀ, θ = ‖ω‖.

    ``(..., 3) -> (..., 3, 3)``. The coefficients come from a single t = tan(θ/4) through the
    half-angle identities sin(θ/2) = 2t/(1 + t²), cos(θ/2) = (1 − t²)/(1 + t²):

        sin θ/θ = g (1 − t²)/(1 + t²)²,   (1 − cos θ)/θ² = ½ (g/(1 + t²))²,   g = t/(θ/4),

    which has no cancellation anywhere (g → 1 smoothly at θ = 0, exact there) and costs one
    SIMD ``tan`` instead of ``sin`` and ``cos`` (numpy's float64 sin/cos are ~8× slower than tan).
    Agrees with scipy's ``Rotation.from_rotvec`` to a few ulp (tests).
    """
    if type(w) is np.ndarray and w.shape == (3,) and w.dtype == _F64:
        rows = _exp_rows(*w.tolist())
        if rows is not None:
            return np.array(rows)
    xp = namespace(w)
    if not is_numpy(xp):
        return _exp(_traced(w, "w", (3,)), xp)
    w = _vec(w, "w")
    with np.errstate(over="ignore"):  # an overflow to inf is caught just below
        big = w.size and not float(np.max(np.sum(w * w, axis=-1))) < 1e200
    if big:
        # ‖w‖ near or beyond overflow (‖w‖ > 1e100): the axis–angle form stays finite
        return _exp_axis_angle(w)
    return _exp(w, np)


def _exp(w: Any, xp: ModuleType) -> Any:
    """:func:`exp` of a checked ``(..., 3)`` array of the namespace ``xp`` (pure; see there
    for the tan(θ/4) form). Differentiable everywhere: θ = ‖w‖ is a guarded square root
    (:func:`liecontrol._array_api.safe_sqrt`) and g = (t + z)/(q + z), z = [q = 0], has the
    derivative of its limit (0) at θ = 0."""
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    t2 = x * x + y * y + z * z
    q = safe_sqrt(t2, xp) * 0.25
    t = xp.tan(q)
    # g = tan(θ/4)/(θ/4) → 1 at θ = 0: (t + z)/(q + z) with z = [θ = 0] leaves other entries exact
    zero = xp.where(q == 0.0, 1.0, 0.0)
    g = (t + zero) / (q + zero)
    t = t * t
    u = t + 1.0
    g = g / u  # g/(1 + t²) = sin(θ/2)/(θ/2)
    ch = (1.0 - t) / u  # cos(θ/2)
    a = ch * g  # sin θ/θ
    b = g * g * 0.5  # (1 − cos θ)/θ²
    c = 1.0 - b * t2  # cos θ = 1 − 2 sin²(θ/2)
    bx = b * x
    by = b * y
    bxy, az_ = bx * y, a * z
    bxz, ay_ = bx * z, a * y
    byz, ax_ = by * z, a * x
    return xp.stack(
        (
            xp.stack((c + bx * x, bxy - az_, bxz + ay_), axis=-1),
            xp.stack((bxy + az_, c + by * y, byz - ax_), axis=-1),
            xp.stack((bxz - ay_, byz + ax_, c + b * z * z), axis=-1),
        ),
        axis=-2,
    )


def _exp_rows(x: float, y: float, z: float) -> tuple[tuple[float, float, float], ...] | None:
    """:func:`exp` of one rotation vector as its rows, through the compiled Rodrigues kernel
    (:func:`liecontrol._kernels.so3.exp9`). ``None`` for a non-finite or very long vector
    (‖w‖ > 1e100), which the batched path handles (and raises for)."""
    if not x * x + y * y + z * z < 1e200:
        return None
    e = _exp9(x, y, z)
    return ((e[0], e[1], e[2]), (e[3], e[4], e[5]), (e[6], e[7], e[8]))


def _one_vec(w: object) -> bool:
    """True iff ``w`` is one finite float64 ``(3,)`` ndarray (the single-element route; anything
    else goes through the batched path, which converts or raises the usual message)."""
    if not (type(w) is np.ndarray and w.shape == (3,) and w.dtype == _F64):
        return False
    x, y, z = w.tolist()
    return math.isfinite(x) and math.isfinite(y) and math.isfinite(z)


def _one_rot(R: object) -> bool:
    """True iff ``R`` is one float64 ``(3, 3)`` ndarray passing the cheap rotation check of the
    array layer (:func:`_is_rotation9`)."""
    return _rotation_entries(R) is not None


def _rotation_entries(R: object) -> list[float] | None:
    """The nine entries of one float64 ``(3, 3)`` ndarray that passes the cheap rotation check of
    the array layer (:func:`rotations_pass_fast` at :data:`ARRAY_ROTATION_ATOL`), else ``None``
    (the caller then takes the general path, which converts or raises the usual message)."""
    if not (type(R) is np.ndarray and R.shape == (3, 3) and R.dtype == _F64):
        return None
    m = R.ravel().tolist()
    return m if _is_rotation9(*m) else None


def _is_rotation9(
    a: float, b: float, c: float, d: float, e: float, f: float, g: float, h: float, k: float
) -> bool:
    """The cheap rotation check of the array layer on the nine entries (row-major) of one
    matrix: max |RᵀR − I| ≤ :data:`ARRAY_ROTATION_ATOL` and det R ≥ 0 (NaN/inf fail)."""
    err = max(
        abs(a * a + d * d + g * g - 1.0),
        abs(b * b + e * e + h * h - 1.0),
        abs(c * c + f * f + k * k - 1.0),
        abs(a * b + d * e + g * h),
        abs(a * c + d * f + g * k),
        abs(b * c + e * f + h * k),
    )
    det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)
    # NaN/inf make both comparisons False
    return err <= ARRAY_ROTATION_ATOL and det >= 0.0


def _angle_parts(R: Any, xp: ModuleType = np) -> tuple[Any, Any, Any]:
    """(v, sin θ, cos θ) with v = (R − Rᵀ)^∨ = 2 sin θ · axis."""
    v = xp.stack(
        (R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]),
        axis=-1,
    )
    s = 0.5 * safe_sqrt(xp.sum(v * v, axis=-1), xp)
    c = 0.5 * (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0)
    return v, s, c


def angle(R: object) -> np.ndarray:
    """Rotation angle θ ∈ [0, π] of R, as atan2(sin θ, cos θ) (accurate at 0 and π)."""
    if not is_numpy(namespace(R)):
        return angle_unchecked(_traced(R, "R", (3, 3)))
    return angle_unchecked(_rot(R, "R"))


def angle_unchecked(R: Any) -> Any:
    """:func:`angle` without any check, for hot paths that have validated the finite float64
    ``(..., 3, 3)`` rotation array ``R`` themselves (not in ``__all__``); NumPy or JAX."""
    xp = namespace(R)
    _, s, c = _angle_parts(R, xp)
    return xp.arctan2(s, c)


def _log_near_pi(
    m: tuple[Any, ...], c: Any, v: tuple[Any, Any, Any], theta: Any, near: Any, xp: ModuleType
) -> Any:
    """Rotation vectors ``(..., 3)`` of rotations with angles ``theta`` near π, from the entries
    ``m`` (row-major), cos θ ``c`` and v = (R − Rᵀ)^∨; valid where ``near`` (elsewhere finite
    and unused).

    The axis comes from the symmetric part, (R + Rᵀ)/2 − cos θ I = (1 − cos θ) n nᵀ (its column
    with the largest diagonal entry, which is ≥ (1 − cos θ)/3), its sign from
    (R − Rᵀ)^∨ = 2 sin θ n. The column is chosen with ``where`` (first largest entry, as
    ``argmax``), and its norm is taken of 1 where not ``near``: near the identity the column is
    exactly 0 and 0/0 there would poison the derivative of the branch that is taken.
    """
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = m
    d0, d1, d2 = m00 - c, m11 - c, m22 - c
    s01, s02, s12 = 0.5 * (m01 + m10), 0.5 * (m02 + m20), 0.5 * (m12 + m21)
    k0 = (d0 >= d1) & (d0 >= d2)
    k1 = ~k0 & (d1 >= d2)
    c0 = xp.where(k0, d0, xp.where(k1, s01, s02))
    c1 = xp.where(k0, s01, xp.where(k1, d1, s12))
    c2 = xp.where(k0, s02, xp.where(k1, s12, d2))
    norm = xp.sqrt(xp.where(near, c0 * c0 + c1 * c1 + c2 * c2, 1.0))
    # at θ = π exactly n·v = 0 and both ±π n are logarithms: keep the sign of the column
    sign = xp.where(c0 * v[0] + c1 * v[1] + c2 * v[2] < 0.0, -1.0, 1.0)
    f = sign * theta / norm
    return xp.stack((c0 * f, c1 * f, c2 * f), axis=-1)


def log(R: object) -> np.ndarray:
    """Rotation vector ω = θ·axis with ‖ω‖ = θ ∈ [0, π] and exp(ω) = R; ``(..., 3, 3) -> (..., 3)``.

    θ = atan2(sin θ, cos θ) with 2 sin θ = ‖(R − Rᵀ)^∨‖ and 2 cos θ = tr R − 1 (accurate to
    round-off over [0, π]). For cos θ ≥ −0.999 (θ ≤ π − 0.0447), ω = θ/(2 sin θ) (R − Rᵀ)^∨,
    with θ/sin θ → 1 at θ = 0 (exact: no series needed since atan2(s, c)/s is accurate for tiny s).
    Nearer π the antisymmetric part is too small to give the axis to full relative accuracy, so
    the axis comes from the symmetric part, (R + Rᵀ)/2 − cos θ I = (1 − cos θ) n nᵀ, its sign
    from (R − Rᵀ)^∨: accurate to round-off up to and including θ = π. At exactly θ = π
    both ±π n are logarithms; the one returned is deterministic but arbitrary.
    """
    m = _rotation_entries(R)
    if m is not None:
        p = _log_floats(*m)
        if p is not None:
            return np.array(p)
    if not is_numpy(namespace(R)):
        return _log_angle_unchecked(_traced(R, "R", (3, 3)))[0]
    return _log_angle_unchecked(_rot(R, "R"))[0]


def log_unchecked(R: np.ndarray) -> np.ndarray:
    """:func:`log` without any check, for hot paths that have validated the finite float64
    ``(..., 3, 3)`` rotation array ``R`` themselves (not in ``__all__``)."""
    return _log_angle_unchecked(R)[0]


def _log_angle_unchecked(R: Any) -> tuple[Any, Any]:
    """:func:`log` and the angle θ, ``(..., 3)`` and ``(...)``, for an **already validated**
    finite float64 ``(..., 3, 3)`` array (no checks: callers on hot paths that have checked
    ``R`` themselves), NumPy or JAX. θ is the ``atan2`` angle of :func:`log` (‖ω‖ = θ to
    round-off).

    Pure and differentiable: sin θ is a guarded norm (its derivative at the identity is 0, not
    ∞·0), θ/(2 sin θ) is (θ + z)/(2(s + z)) with z = [s = 0], whose derivative at s = 0 is that
    of the limit, and the near-π branch is selected with ``where`` after being evaluated with
    a guarded norm everywhere (NumPy evaluates it only when some element takes it).
    """
    xp = namespace(R)
    m = tuple(R[..., i, j] for i in range(3) for j in range(3))
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = m
    v = (m21 - m12, m02 - m20, m10 - m01)
    s = safe_sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2], xp) * 0.5  # sin θ
    c = (m00 + m11 + m22 - 1.0) * 0.5  # cos θ
    theta = xp.arctan2(s, c)
    # θ/(2 sin θ) with the 0/0 at θ = 0 replaced by its limit ½: (θ + z)/(2(s + z)), z = [s = 0]
    zero = xp.where(s == 0.0, 1.0, 0.0)
    sz = s + zero
    k = (theta + zero) / (sz + sz)
    out = xp.stack((v[0] * k, v[1] * k, v[2] * k), axis=-1)
    near = c < _LOG_SYMMETRIC_COS
    if any_true(near, xp):
        out = xp.where(near[..., None], _log_near_pi(m, c, v, theta, near, xp), out)
    return out, theta


def _log_floats(
    m00: float, m01: float, m02: float,
    m10: float, m11: float, m12: float,
    m20: float, m21: float, m22: float,
) -> tuple[float, float, float] | None:  # fmt: skip
    """:func:`log` of one **already validated** rotation given by its entries, through the
    compiled kernel (:func:`liecontrol._kernels.so3.log9`, the same formula as the batched
    route). ``None`` where cos θ < −0.999 (or NaN), where callers take :func:`log` itself."""
    c = (m00 + m11 + m22 - 1.0) * 0.5  # cos θ
    if not c >= _LOG_SYMMETRIC_COS:
        return None
    return _log9(m00, m01, m02, m10, m11, m12, m20, m21, m22)


def _unit_jac_coeffs_one(theta: float) -> tuple[float, float]:
    """(1 − cos θ)/θ and 1 − sin θ/θ (the unit-axis SO(3) Jacobian coefficients) of one angle
    on Python floats (series below θ = 0.1, as the batched path)."""
    h = math.sin(0.5 * theta)
    b1 = 2.0 * h * h / theta if theta > 0.0 else 0.0
    if theta < _SMALL_JAC:
        t2 = theta * theta
        c1 = t2 * (1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0)
    else:
        c1 = 1.0 - math.sin(theta) / theta
    return b1, c1


def _axis_block(
    out: np.ndarray,
    n: tuple,
    c_i: np.ndarray | float,
    c_p: np.ndarray | float,
    c_nn: np.ndarray | float,
) -> None:
    """Write c_i I + c_p n^ + c_nn n nᵀ into ``out`` ``(..., 3, 3)`` entry by entry (the SO(3)
    Jacobians and their inverses have this form: J_l(ω) = I + b n^ + c n^², n^² = n nᵀ − I);
    ``n`` as its three components, arrays or Python floats."""
    nn = n
    b = [c_nn * nn[i] for i in range(3)]
    r = [c_p * nn[i] for i in range(3)]
    for i in range(3):
        out[..., i, i] = nn[i] * b[i] + c_i
        for j in range(i + 1, 3):
            sym = nn[i] * b[j]
            k = 3 - i - j
            sign = 1.0 if (j - i) % 3 == 1 else -1.0
            out[..., i, j] = sym - sign * r[k]
            out[..., j, i] = sym + sign * r[k]


def _jac_one(w: object, sign: float, inverse: bool) -> np.ndarray | None:
    """J_r(sign·ω) (or its inverse) of one float64 ``(3,)`` vector on Python floats, in the
    form c_i I + c_p n^ + c_nn n nᵀ (n^² = n nᵀ − I); ``None`` for anything else, a
    non-finite or very long vector, or the singular set of the inverse (the batched path
    handles or raises)."""
    if not (type(w) is np.ndarray and w.shape == (3,) and w.dtype == _F64):
        return None
    x, y, z = w.tolist()
    t2 = x * x + y * y + z * z
    if not t2 < 1e200:
        return None
    theta = math.sqrt(t2)
    s = sign / theta if theta > 0.0 else 0.0
    n = (x * s, y * s, z * s)
    out = np.empty((3, 3))
    if inverse:
        hd = _jac_inv_one(theta)
        if hd is None:
            return None
        h, d1 = hd
        _axis_block(out, n, 1.0 - d1, h, d1)
    else:
        b1, c1 = _unit_jac_coeffs_one(theta)
        _axis_block(out, n, 1.0 - c1, -b1, c1)
    return out


def _right_jacobian(w: np.ndarray) -> np.ndarray:
    """J_r of a validated ``(..., 3)`` array in axis–angle form (see :func:`right_jacobian`)."""
    theta, n = _axis_angle(w)
    N = hat(n)
    half = np.sin(0.5 * theta)
    safe = np.where(theta > 0.0, theta, 1.0)
    b1 = 2.0 * half * half / safe  # (1 − cos θ)/θ, exact 0 at θ = 0
    t = np.minimum(theta, _SMALL_JAC)  # the series argument (huge θ would overflow θ²)
    _, c = _jac_coeffs(t)
    c1 = np.where(theta < _SMALL_JAC, t * t * c, 1.0 - np.sin(theta) / safe)
    return np.eye(3) - b1[..., None, None] * N + c1[..., None, None] * (N @ N)


def right_jacobian(w: object) -> np.ndarray:
    """J_r(ω) = I − ((1 − cos θ)/θ²) ω^ + ((θ − sin θ)/θ³) ω^², θ = ‖ω‖.

    Evaluated as I − ((1 − cos θ)/θ) n^ + (1 − sin θ/θ) n^² with n = ω/θ (series below θ = 0.1),
    so every term is bounded and no ω (even ‖ω‖ = 1e300) overflows.
    """
    R = _jac_one(w, 1.0, False)
    return R if R is not None else _right_jacobian(_vec(w, "w"))


def left_jacobian(w: object) -> np.ndarray:
    """J_l(ω) = J_r(−ω) = I + ((1 − cos θ)/θ²) ω^ + ((θ − sin θ)/θ³) ω^²."""
    R = _jac_one(w, -1.0, False)
    return R if R is not None else _right_jacobian(-_vec(w, "w"))


def _right_jacobian_inv(w: np.ndarray, name: str) -> np.ndarray:
    """J_r⁻¹ of a validated ``(..., 3)`` array (see :func:`right_jacobian_inv`); ``name`` is the
    argument named in the error at the singular set."""
    theta, n, h, d1 = _jac_inv_parts(w, name)
    N = hat(n)
    return np.eye(3) + h[..., None, None] * N + d1[..., None, None] * (N @ N)


def _jac_inv_parts(
    w: np.ndarray, name: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(θ, n, θ/2, 1 − (θ/2) cot(θ/2)) of a validated ``(..., 3)`` array: J_r(ω)⁻¹ =
    I + (θ/2) n^ + d₁ n^² with d₁ the last entry (series below θ = 0.1). Raises ``ValueError``
    naming ``name`` at the singular set θ = 2πk (see :func:`right_jacobian_inv`)."""
    theta, n = _axis_angle(w)
    h = 0.5 * theta
    sh = np.sin(h)
    big = theta >= _SMALL_JAC
    sing = big & (np.abs(sh) <= JAC_INV_SINGULAR_SIN)
    if np.any(sing):
        th = float(theta[sing].flat[0]) if theta.ndim else float(theta)
        k = max(1, round(th / (2.0 * math.pi)))
        raise ValueError(
            f"{name}: the SO(3) Jacobian inverse is singular at rotation angle 2π·k; got "
            f"‖ω‖ = {th!r}, |sin(‖ω‖/2)| ≤ {JAC_INV_SINGULAR_SIN:.0e} (k = {k}). Reduce the "
            f"rotation vector to ‖ω‖ < 2π first (e.g. log(exp(ω)))"
        )
    safe_sh = np.where(big, sh, 1.0)
    # W² coefficient times θ²: 1 − (θ/2) cot(θ/2) (series θ² d(θ) below θ = 0.1)
    if theta.ndim == 0:
        t = np.minimum(theta, _SMALL_JAC)  # the series argument (huge θ would overflow θ²)
        d_small = t * t * _jac_inv_coeff(t)
        return theta, n, h, np.where(big, 1.0 - h * np.cos(h) / safe_sh, d_small)
    d1 = 1.0 - h * np.cos(h) / safe_sh
    small = np.flatnonzero(~big.ravel())
    if small.size:  # the series only where it is used (same formula as _jac_inv_coeff)
        t = theta.ravel()[small]
        t2 = t * t
        series = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0
        d1.ravel()[small] = t * t * series
    return theta, n, h, d1


def _jac_inv_one(theta: float) -> tuple[float, float] | None:
    """(θ/2, d₁) of :func:`_jac_inv_parts` for one angle on Python floats; ``None`` on the
    singular set (the batched path raises there)."""
    h = 0.5 * theta
    if theta >= _SMALL_JAC:
        sh = math.sin(h)
        if abs(sh) <= JAC_INV_SINGULAR_SIN:
            return None
        return h, 1.0 - h * math.cos(h) / sh
    t2 = theta * theta
    return h, t2 * (1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0)


def right_jacobian_inv(w: object) -> np.ndarray:
    """J_r(ω)⁻¹ = I + ½ ω^ + (1/θ² − cot(θ/2)/(2θ)) ω^², θ = ‖ω‖.

    Evaluated as I + (θ/2) n^ + (1 − (θ/2) cot(θ/2)) n^² with n = ω/θ (series below θ = 0.1).
    J_r is singular at θ = 2πk, k ≥ 1 (its eigenvalues off the axis have modulus
    2|sin(θ/2)|/θ), and J_r⁻¹'s entries grow like θ/(2|sin(θ/2)|) near there. Where
    |sin(θ/2)| ≤ :data:`JAC_INV_SINGULAR_SIN` = 1e-8 (|θ − 2πk| ≲ 2e-8) this raises
    ``ValueError``; outside, the result is the exact formula (``J_r(ω) J_r(ω)⁻¹ = I`` to round-off
    times that growth, e.g. ~1e-8 at the threshold).
    """
    R = _jac_one(w, 1.0, True)
    return R if R is not None else _right_jacobian_inv(_vec(w, "w"), "w")


def left_jacobian_inv(w: object) -> np.ndarray:
    """J_l(ω)⁻¹ = J_r(−ω)⁻¹ = I − ½ ω^ + (1/θ² − cot(θ/2)/(2θ)) ω^²; raises at the singular set
    θ = 2πk as :func:`right_jacobian_inv` does."""
    R = _jac_one(w, -1.0, True)
    return R if R is not None else _right_jacobian_inv(-_vec(w, "w"), "w")


def adjoint(R: object) -> np.ndarray:
    """Ad_R = R (acting on so(3) ≅ ℝ³): R exp(ω) Rᵀ = exp(R ω)."""
    return np.array(_rot(R, "R"), copy=True)


def ad(w: object) -> np.ndarray:
    """ad_ω = ω^ (the Lie bracket [ω, η] = ω × η)."""
    return hat(w)


def compose(R1: object, R2: object) -> np.ndarray:
    """R₁ R₂ (batched, broadcasting)."""
    if _one_rot(R1) and _one_rot(R2):
        return R1 @ R2  # type: ignore[operator]
    R1 = _rot(R1, "R1")
    R2 = _rot(R2, "R2")
    _batch(("R1", R1.shape[:-2]), ("R2", R2.shape[:-2]))
    return R1 @ R2


def inverse(R: object) -> np.ndarray:
    """R⁻¹ = Rᵀ."""
    if _one_rot(R):
        return R.T.copy()  # type: ignore[attr-defined]
    return np.swapaxes(_rot(R, "R"), -1, -2).copy()


def act(R: object, p: object) -> np.ndarray:
    """R p for points ``(..., 3)``."""
    if _one_rot(R) and _one_vec(p):
        return R @ p  # type: ignore[operator]
    R = _rot(R, "R")
    p = _vec(p, "p")
    _batch(("R", R.shape[:-2]), ("p", p.shape[:-1]))
    return np.einsum("...ij,...j->...i", R, p)


def distance(R1: object, R2: object) -> np.ndarray:
    """Geodesic (bi-invariant) distance θ(R₁ᵀR₂) ∈ [0, π] in radians."""
    R1 = _rot(R1, "R1")
    R2 = _rot(R2, "R2")
    _batch(("R1", R1.shape[:-2]), ("R2", R2.shape[:-2]))
    return angle_unchecked(np.swapaxes(R1, -1, -2) @ R2)


def interpolate(R0: object, R1: object, s: object) -> np.ndarray:
    """Geodesic interpolation R₀ exp(s log(R₀ᵀR₁)); s = 0 → R₀, s = 1 → R₁ (slerp)."""
    R0 = _rot(R0, "R0")
    R1 = _rot(R1, "R1")
    s = as_array(s, "s")
    _batch(("R0", R0.shape[:-2]), ("R1", R1.shape[:-2]), ("s", s.shape))
    d = log_unchecked(np.swapaxes(R0, -1, -2) @ R1)
    return R0 @ exp(d * s[..., None])


def random(rng: np.random.Generator, size: int | tuple[int, ...] = ()) -> np.ndarray:
    """Haar-uniform random rotations of shape ``size + (3, 3)``.

    QR of a Gaussian matrix with the sign of R's diagonal absorbed is Haar on O(3) (Mezzadri
    2007); flipping the last column of the improper ones maps that coset onto SO(3) while keeping
    the measure (right multiplication by a fixed reflection).
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected numpy.random.Generator, got {type(rng).__name__}")
    size = _shape_arg(size, "size")
    G = rng.standard_normal(size + (3, 3))
    Q, Rq = np.linalg.qr(G)
    d = np.sign(np.stack((Rq[..., 0, 0], Rq[..., 1, 1], Rq[..., 2, 2]), axis=-1))
    d[d == 0] = 1.0
    Q = Q * d[..., None, :]
    det = np.linalg.det(Q)
    Q[..., :, 2] *= np.sign(det)[..., None]
    return Q


def project(M: object) -> np.ndarray:
    """Nearest rotation to M in the Frobenius norm: U diag(1, 1, det(UVᵀ)) Vᵀ (SVD / polar)."""
    M = as_array(M, "M", (3, 3))
    U, _, Vt = np.linalg.svd(M)
    det = np.linalg.det(U @ Vt)
    U = U.copy()
    U[..., :, 2] *= det[..., None]
    return U @ Vt


def validate(R: object, name: str = "R", atol: float = 1e-9) -> np.ndarray:
    """Return R as a float array, raising ``ValueError`` naming ``name`` unless it is a finite
    (batch of) rotation matrices: orthonormal within ``atol`` and with determinant +1.
    ``atol`` must be a finite number > 0."""
    if not isinstance(name, str) or not name:
        raise TypeError(f"name: expected a non-empty str (the label for errors), got {name!r}")
    return check_rotation_matrix(R, name, check_tolerance(atol, "atol"))
