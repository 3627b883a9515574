"""The rigid-motion group SE(3): batched array functions (the fast path).

Conventions (``docs/design.md``): group elements are homogeneous matrices ``(..., 4, 4)``
``g = [[R, p], [0, 1]]`` (R body → reference, p the body origin in the reference frame); twists are
``(..., 6)`` with **rotation first**, ``ξ = (ω, v)``, ``hat(ξ) = [[ω^, v], [0, 0]]``. The same
ordering holds for every 6×6 matrix here (adjoints and Jacobians, blocks ``[[ωω, ωv], [vω, vv]]``).
Jacobians: ``exp(ξ + δ) ≈ exp(J_l(ξ) δ) exp(ξ)`` and ``exp(ξ + δ) ≈ exp(ξ) exp(J_r(ξ) δ)``.

As in :mod:`liecontrol.lie.so3`, every public function validates: real, finite, the trailing
shape, batch shapes that broadcast, and for poses a cheap structural check (rotation block within
``so3.ARRAY_ROTATION_ATOL`` = 1e-6 of a rotation, last row (0, 0, 0, 1) within the same
tolerance); :func:`validate` (and the :class:`liecontrol.lie.SE3` wrapper) applies the strict
1e-9. Hot paths that validated already call :func:`inverse_unchecked` /
:func:`adjoint_unchecked` (not in ``__all__``). Long twists (‖ω‖ up to 1e300) are evaluated in
axis–angle form, so nothing overflows to inf/NaN.

Sources: Barfoot, *State Estimation for Robotics* (2017), §7.1.9 (exp/log with V = J_l(ω)) and
eq. (7.86) (the Q block of the Jacobian, rewritten here for the (ω, v) ordering); Solà, Deray &
Atchuthan, *A micro Lie theory for state estimation in robotics* (2018), App. D.
"""

from __future__ import annotations

import math

import numpy as np

from .._linalg import cross as _cross
from .._validation import (
    ROTATION_ATOL,
    as_array,
    check_output_finite,
    check_positive_scalar,
    check_tolerance,
    norm_last,
)
from . import so3
from .so3 import (
    _SMALL_JAC,
    ARRAY_ROTATION_ATOL,
    _axis_angle,
    _axis_block,
    _batch,
    _jac_coeffs,
    _jac_inv_coeff,
    _jac_inv_parts,
    _unit_jac_coeffs_one,
)

__all__ = [
    "hat",
    "vee",
    "exp",
    "log",
    "left_jacobian",
    "right_jacobian",
    "left_jacobian_inv",
    "right_jacobian_inv",
    "adjoint",
    "ad",
    "coadjoint",
    "compose",
    "inverse",
    "act",
    "distance",
    "interpolate",
    "random",
    "from_rt",
    "rotation",
    "translation",
    "identity",
    "validate",
]

# Below this rotation angle the Q-block coefficients switch to their Taylor series: the closed
# forms cancel like θ⁵ (the third coefficient loses ~eps/θ⁴ relative accuracy).
_SMALL_Q = 1.0


def _twist(xi: object, name: str = "xi") -> np.ndarray:
    return as_array(xi, name, (6,))


def _pose(g: object, name: str = "g") -> np.ndarray:
    """A finite real ``(..., 4, 4)`` array whose rotation block is a rotation and whose last row
    is (0, 0, 0, 1), both within ``so3.ARRAY_ROTATION_ATOL``."""
    a = as_array(g, name, (4, 4))
    so3._rot(a[..., :3, :3], name)
    if a.size:
        row = float(np.abs(a[..., 3, :] - _LAST_ROW).max())
        if row > ARRAY_ROTATION_ATOL:
            raise ValueError(f"{name}: last row is not (0, 0, 0, 1) (max deviation {row:.2e})")
    return a


_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])
_F64 = np.dtype(np.float64)
_F = np.ndarray | float  # a coefficient: a batch array or one Python float
_Vec = tuple  # the three components of a vector (arrays or Python floats)


def identity(batch_shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity pose(s) of shape ``batch_shape + (4, 4)``."""
    return np.broadcast_to(np.eye(4), so3._shape_arg(batch_shape, "batch_shape") + (4, 4)).copy()


def from_rt(R: object, p: object) -> np.ndarray:
    """g = [[R, p], [0, 1]] from rotations ``(..., 3, 3)`` and translations ``(..., 3)``
    (broadcast against each other). ``R`` must be a rotation (the cheap check of the array
    layer, tolerance ``so3.ARRAY_ROTATION_ATOL``)."""
    R = so3._rot(R, "R")
    p = as_array(p, "p", (3,))
    shape = _batch(("R", R.shape[:-2]), ("p", p.shape[:-1]))
    g = np.zeros(shape + (4, 4))
    g[..., :3, :3] = R
    g[..., :3, 3] = p
    g[..., 3, 3] = 1.0
    return g


def rotation(g: object) -> np.ndarray:
    """The rotation block R of g, ``(..., 3, 3)`` (a copy)."""
    return _pose(g)[..., :3, :3].copy()


def translation(g: object) -> np.ndarray:
    """The translation p of g, ``(..., 3)`` (a copy)."""
    return _pose(g)[..., :3, 3].copy()


def hat(xi: object) -> np.ndarray:
    """ξ = (ω, v) ↦ ξ^ = [[ω^, v], [0, 0]]; ``(..., 6) -> (..., 4, 4)``."""
    if type(xi) is np.ndarray and xi.shape == (6,) and xi.dtype == _F64:
        x, y, z, a, b, c = xi.tolist()
        if math.isfinite(x + y + z + a + b + c):
            return np.array(
                ((0.0, -z, y, a), (z, 0.0, -x, b), (-y, x, 0.0, c), (0.0, 0.0, 0.0, 0.0))
            )
    xi = _twist(xi)
    X = np.zeros(xi.shape[:-1] + (4, 4))
    X[..., :3, :3] = so3.hat(xi[..., :3])
    X[..., :3, 3] = xi[..., 3:]
    return X


def vee(X: object) -> np.ndarray:
    """Inverse of :func:`hat`: ``(..., 4, 4) -> (..., 6)`` reading ω from the skew block
    (entries (2,1), (0,2), (1,0)) and v from the last column. ``X`` must be an se(3) matrix to
    round-off: skew upper-left block and zero last row (≤ 1e-9 · max(1, max |X|))."""
    X = as_array(X, "X", (4, 4))
    if X.size:
        W = X[..., :3, :3]
        tol = 1e-9 * max(1.0, float(np.abs(X).max()))
        asym = float(np.abs(W + np.swapaxes(W, -1, -2)).max())
        if asym > tol:
            raise ValueError(f"X: rotation block not skew-symmetric (max |W + Wᵀ| = {asym:.2e})")
        row = float(np.abs(X[..., 3, :]).max())
        if row > tol:
            raise ValueError(f"X: last row is not zero (max |entry| = {row:.2e})")
    W = X[..., :3, :3]
    w = np.stack((W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]), axis=-1)
    return np.concatenate((w, X[..., :3, 3]), axis=-1)


def exp(xi: object) -> np.ndarray:
    """exp(ξ^) = [[exp(ω), V v], [0, 1]] with V = J_l(ω) the SO(3) left Jacobian.

    V v = v + ((1 − cos θ)/θ²) ω × v + ((θ − sin θ)/θ³) ω × (ω × v) (Barfoot §7.1.9), Taylor
    branches near θ = 0 inside the coefficients. ``(..., 6) -> (..., 4, 4)``.
    """
    if type(xi) is np.ndarray and xi.shape == (6,) and xi.dtype == _F64:
        g1 = _exp_one(*xi.tolist())
        if g1 is not None:
            return g1
    xi = _twist(xi)
    w = xi[..., :3]
    v = xi[..., 3:]
    # V v in axis–angle form, v + ((1 − cos θ)/θ) n × v + (1 − sin θ/θ) n × (n × v): bounded
    # coefficients, so long twists do not overflow
    theta, n = _axis_angle(w)
    b1, c1 = _unit_jac_coeffs(theta)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is named just below
        nv = _cross(n, v)
        t = v + b1[..., None] * nv + c1[..., None] * _cross(n, nv)
    check_output_finite(t, "xi", "the translation V v")
    g = np.zeros(xi.shape[:-1] + (4, 4))
    g[..., :3, :3] = so3.exp(w)
    g[..., :3, 3] = t
    g[..., 3, 3] = 1.0
    return g


def _exp_one(x: float, y: float, z: float, v0: float, v1: float, v2: float) -> np.ndarray | None:
    """:func:`exp` of one twist on Python floats (numpy's per-call overhead dominates for one
    element): the same formulas as the batched path. ``None`` for a non-finite or very long ω
    (the batched path handles or rejects it)."""
    rows = so3._exp_rows(x, y, z)
    if rows is None:
        return None
    theta = math.sqrt(x * x + y * y + z * z)
    if theta > 0.0:
        n0, n1, n2 = x / theta, y / theta, z / theta
        h = math.sin(0.5 * theta)
        b1 = 2.0 * h * h / theta
    else:
        n0 = n1 = n2 = b1 = 0.0
    if theta < _SMALL_JAC:
        t2 = theta * theta
        c1 = t2 * (1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0)
    else:
        c1 = 1.0 - math.sin(theta) / theta
    # n × v and n × (n × v)
    a0, a1, a2 = n1 * v2 - n2 * v1, n2 * v0 - n0 * v2, n0 * v1 - n1 * v0
    b0, b1_, b2 = n1 * a2 - n2 * a1, n2 * a0 - n0 * a2, n0 * a1 - n1 * a0
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rows
    t0, t1, t2 = v0 + b1 * a0 + c1 * b0, v1 + b1 * a1 + c1 * b1_, v2 + b1 * a2 + c1 * b2
    if not (math.isfinite(t0) and math.isfinite(t1) and math.isfinite(t2)):
        return None  # a non-finite v, or an overflow: the batched path names xi
    return np.array(
        (
            (r00, r01, r02, t0),
            (r10, r11, r12, t1),
            (r20, r21, r22, t2),
            (0.0, 0.0, 0.0, 1.0),
        )
    )


def _pose_rotation(g: object) -> tuple[float, ...] | None:
    """The nine rotation entries (row-major) of one float64 ``(4, 4)`` ndarray that passes the
    cheap pose check of the array layer (rotation block within ``so3.ARRAY_ROTATION_ATOL``,
    finite translation, last row (0, 0, 0, 1) within the same tolerance), else ``None`` (the
    caller takes the general path, which converts or raises the usual message)."""
    if not (type(g) is np.ndarray and g.shape == (4, 4) and g.dtype == _F64):
        return None
    r00, r01, r02, p0, r10, r11, r12, p1, r20, r21, r22, p2, l0, l1, l2, l3 = g.ravel().tolist()
    m = (r00, r01, r02, r10, r11, r12, r20, r21, r22)
    tol = ARRAY_ROTATION_ATOL
    # each comparison separately: a NaN makes its own comparison False
    ok = (
        so3._is_rotation9(*m)
        and math.isfinite(p0 + p1 + p2)
        and abs(l0) <= tol
        and abs(l1) <= tol
        and abs(l2) <= tol
        and abs(l3 - 1.0) <= tol
    )
    return m if ok else None


def _log_one(g: object) -> np.ndarray | None:
    """:func:`log` of one float64 ``(4, 4)`` pose on Python floats, or ``None`` when ``g`` is not
    such an array, fails the cheap pose check of the array layer, or has a rotation angle
    near π (cos θ < −0.999): the general path then handles it or raises the usual message."""
    if not (type(g) is np.ndarray and g.shape == (4, 4) and g.dtype == _F64):
        return None
    m = _pose_rotation(g)
    if m is None:
        return None
    p0, p1, p2 = g[:3, 3].tolist()  # type: ignore[index]
    w = so3._log_floats(*m)
    if w is None:
        return None
    w0, w1, w2 = w
    theta = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if theta < _SMALL_JAC:
        t2 = theta * theta
        d = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0
    else:
        half = 0.5 * theta
        d = 1.0 / (theta * theta) - math.cos(half) / (2.0 * theta * math.sin(half))
    # w × p and w × (w × p)
    a0, a1, a2 = w1 * p2 - w2 * p1, w2 * p0 - w0 * p2, w0 * p1 - w1 * p0
    b0, b1, b2 = w1 * a2 - w2 * a1, w2 * a0 - w0 * a2, w0 * a1 - w1 * a0
    return np.array(
        (w0, w1, w2, p0 - 0.5 * a0 + d * b0, p1 - 0.5 * a1 + d * b1, p2 - 0.5 * a2 + d * b2)
    )


def _unit_jac_coeffs(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(1 − cos θ)/θ and 1 − sin θ/θ (the SO(3) Jacobian's coefficients times θ and θ²), accurate
    at 0 (series) and finite for every θ."""
    h = np.sin(0.5 * theta)
    safe = np.where(theta > 0.0, theta, 1.0)
    b1 = 2.0 * h * h / safe
    t = np.minimum(theta, _SMALL_JAC)
    _, c = _jac_coeffs(t)
    c1 = np.where(theta < _SMALL_JAC, t * t * c, 1.0 - np.sin(theta) / safe)
    return b1, c1


def log(g: object) -> np.ndarray:
    """ξ = (ω, v) with exp(ξ^) = g: ω = log(R) (‖ω‖ ∈ [0, π], exact at π through
    :func:`liecontrol.lie.so3.log`), v = J_l(ω)⁻¹ p with
    J_l(ω)⁻¹ p = p − ½ ω × p + (1/θ² − cot(θ/2)/(2θ)) ω × (ω × p) (finite up to θ = π).
    ``(..., 4, 4) -> (..., 6)``.
    """
    out = _log_one(g)
    return out if out is not None else log_unchecked(_pose(g, "g"))


def log_unchecked(g: np.ndarray) -> np.ndarray:
    """:func:`log` without any check, for hot paths that validated the finite float64
    ``(..., 4, 4)`` pose array ``g`` themselves (not in ``__all__``)."""
    w = so3.log_unchecked(g[..., :3, :3])
    p = g[..., :3, 3]
    theta = np.sqrt(np.sum(w * w, axis=-1))
    d = _jac_inv_coeff(theta)
    wp = _cross(w, p)
    v = p - 0.5 * wp + d[..., None] * _cross(w, wp)
    return np.concatenate((w, v), axis=-1)


def _q_series() -> tuple[tuple[float, float, float], ...]:
    """The Taylor coefficients of :func:`_q_coeffs` (9 terms each), highest order first (the
    order Horner's rule uses)."""
    fact = np.cumprod(np.arange(1, 30, dtype=np.float64))  # fact[k-1] = k!
    k = np.arange(9)
    a1 = (-1.0) ** k / fact[2 * k + 2]
    a2 = (-1.0) ** k / fact[2 * k + 3]
    n = k + 2
    a3 = (-1.0) ** n * (n - 1) / fact[2 * n]
    return tuple(zip(a1[::-1].tolist(), a2[::-1].tolist(), a3[::-1].tolist(), strict=True))


_Q_SERIES = _q_series()


def _q_coeffs(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Barfoot's Q coefficients (θ − sin θ)/θ³, (θ² + 2cos θ − 2)/(2θ⁴),
    (2θ − 3 sin θ + θ cos θ)/(2θ⁵); their series are Σₖ (−1)ᵏ θ²ᵏ/(2k+3)!, Σₖ (−1)ᵏ θ²ᵏ/(2k+4)!
    and Σₙ₌₂ (−1)ⁿ (n−1) θ²ⁿ⁻⁴/(2n+1)! (used below θ = 1 with terms to θ¹⁶). Only for θ ≤ 1e50
    (see :func:`_q_left` for the scaled form used for longer twists)."""
    small = theta < _SMALL_Q
    t = np.where(small, 1.0, theta)
    s, co = np.sin(t), np.cos(t)
    t2 = t * t
    c1 = (t - s) / (t2 * t)
    c2 = (t2 + 2.0 * co - 2.0) / (2.0 * t2 * t2)
    c3 = (2.0 * t - 3.0 * s + t * co) / (2.0 * t2 * t2 * t)
    if np.any(small):
        # the series only on the elements that use it (0-d input: the whole "batch")
        sub = theta if theta.ndim == 0 else theta[small]
        x = sub * sub
        s1 = np.zeros_like(x)
        s2 = np.zeros_like(x)
        s3 = np.zeros_like(x)
        for a1, a2, a3 in _Q_SERIES:  # Horner over the 9 series terms (not over the batch)
            s1 = s1 * x + a1
            s2 = s2 * x + a2
            s3 = s3 * x + a3
        if theta.ndim == 0:
            return s1, s2, s3
        c1[small] = s1
        c2[small] = s2
        c3[small] = s3
    return c1, c2, c3


def _q_scaled_one(theta: float) -> tuple[float, float, float, float]:
    """:func:`_q_scaled` of one angle on Python floats (same formulas and branches)."""
    if theta > 1e50:
        return 0.0, 1.0, 0.5, 0.0
    t = theta
    if t < _SMALL_Q:
        x = t * t
        c1 = c2 = c3 = 0.0
        for a1, a2, a3 in _Q_SERIES:
            c1 = c1 * x + a1
            c2 = c2 * x + a2
            c3 = c3 * x + a3
    else:
        s, co = math.sin(t), math.cos(t)
        t2 = t * t
        c1 = (t - s) / (t2 * t)
        c2 = (t2 + 2.0 * co - 2.0) / (2.0 * t2 * t2)
        c3 = (2.0 * t - 3.0 * s + t * co) / (2.0 * t2 * t2 * t)
    return c1 * t, c1 * t * t, c2 * t * t, c3 * t * t * t


def _q_scaled(theta: np.ndarray) -> tuple[np.ndarray, ...]:
    """Barfoot's Q coefficients times the powers of θ that keep them bounded for every θ:
    (c₁θ, c₁θ², c₂θ², c₃θ³), with the θ → ∞ limits (0, 1, ½, 0) beyond θ = 1e50."""
    t = np.minimum(theta, 1e50)  # the coefficients' argument; beyond it the limits apply
    c1, c2, c3 = _q_coeffs(t)
    c1a = c1 * t
    c1 = c1 * t * t
    c2 = c2 * t * t
    c3 = c3 * t * t * t
    big = theta > 1e50
    if np.any(big):
        c1a = np.where(big, 0.0, c1a)
        c1 = np.where(big, 1.0, c1)
        c2 = np.where(big, 0.5, c2)
        c3 = np.where(big, 0.0, c3)
    return c1a, c1, c2, c3


def _lin_block(out: np.ndarray, n: _Vec, v: _Vec, kv: _F, kvn: _F, kp: _F, knn: _F, ki: _F) -> None:
    """Write into ``out`` ``(..., 3, 3)`` the matrix (r)^ + kvn (v nᵀ + n vᵀ) + s (knn n nᵀ + ki I)
    with r = kv v + kp s n, s = n·v; ``n``, ``v`` given as their three components and every
    argument either ``(...)`` arrays or Python floats (one implementation for both routes).

    Every 3×3 matrix that is linear in v and built from the unit axis n alone (an equivariant
    map, like the Q block and −J⁻¹ Q J⁻¹) is a combination of v^, v nᵀ + n vᵀ, n (n × v)ᵀ −
    (n × v) nᵀ = v^ − s n^, s n^, s n nᵀ and s I; the reductions use n^² = n nᵀ − I,
    n^ v^ = v nᵀ − s I, v^ n^ = n vᵀ − s I and n^ v^ n^ = −s n^ (‖n‖ = 1). Entry by entry on
    ``(...)`` arrays: no stacked 3×3 temporaries (they cost more than the arithmetic).
    """
    nn, vv = n, v
    s = nn[0] * vv[0] + nn[1] * vv[1] + nn[2] * vv[2]
    ks = kp * s
    r = [kv * vv[i] + ks * nn[i] for i in range(3)]
    a = [kvn * nn[i] for i in range(3)]
    bs = knn * s
    b = [bs * nn[i] for i in range(3)]
    d = ki * s
    for i in range(3):
        for j in range(i, 3):
            sym = vv[i] * a[j]
            sym += vv[j] * a[i]
            sym += nn[i] * b[j]
            if i == j:
                sym += d
                out[..., i, i] = sym
            else:
                k = 3 - i - j
                sign = 1.0 if (j - i) % 3 == 1 else -1.0  # (r)^_ij = −ε_ijk r_k
                out[..., i, j] = sym - sign * r[k]
                out[..., j, i] = sym + sign * r[k]


def _q_left(w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The 3×3 Q block of the SE(3) left Jacobian (Barfoot eq. 7.86 with φ = ω, ρ = v).

    Barfoot's form Q = ½V + c₁(PV + VP + PVP) + c₂(P²V + VP² − 3PVP) + c₃(PVP² + P²VP) (V = v^,
    P = ω^) reduces, with n = ω/θ and the identities of :func:`_lin_block`, to the closed form

        Q = −e v^ + c₁θ (v nᵀ + n vᵀ) + (c₁θ² − 2c₂θ²)(v^ − s n^) − 2c₃θ³ s n nᵀ − 2f s I,

    e = c₁θ² − c₂θ² − ½, f = c₁θ − c₃θ³, s = n·v: no 3×3 products, and every coefficient is
    bounded for every θ (so long ω cannot overflow).
    """
    theta, n = _axis_angle(w)
    c1a, c1, c2, c3 = _q_scaled(theta)
    Q = np.empty(np.broadcast_shapes(w.shape, v.shape)[:-1] + (3, 3))
    _lin_block(Q, _comp(n), _comp(v), *_q_block_coeffs(c1a, c1, c2, c3))
    return Q


def _comp(a: np.ndarray) -> _Vec:
    """The three components of a ``(..., 3)`` array, as ``(...)`` views."""
    return a[..., 0], a[..., 1], a[..., 2]


def _q_block_coeffs(c1a: _F, c1: _F, c2: _F, c3: _F) -> tuple[_F, ...]:
    """The :func:`_lin_block` coefficients of Barfoot's Q (see :func:`_q_left`)."""
    e = c1 - c2 - 0.5
    knu = c1 - 2.0 * c2
    return knu - e, c1a, -knu, -2.0 * c3, -2.0 * (c1a - c3)


def _q_inv_block_coeffs(h: _F, d1: _F, c1a: _F, c1: _F, c2: _F, c3: _F) -> tuple[_F, ...]:
    """The :func:`_lin_block` coefficients of −J⁻¹ Q J⁻¹ (see :func:`_left_jacobian_inv`)."""
    e = c1 - c2 - 0.5
    f = c1a - c3
    a = 1.0 - d1
    a2h2 = a * a - h * h
    kv = e * a2h2 - 4.0 * a * f * h
    kvn = h * (0.5 - c2) - a * c1a
    ku = a * (c2 - 0.5) - h * c1a - kv
    ki = 2.0 * f * a2h2 + 2.0 * a * e * h
    knn = -2.0 * a * a * f + 2.0 * a * (c3 - e * h + f) + 2.0 * f * h * h + h * (2.0 * c2 - 1.0)
    return kv - ku, kvn, ku, knn, ki


def _blocks(A: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """[[A, 0], [Q, A]] as ``(..., 6, 6)``."""
    shape = np.broadcast_shapes(A.shape[:-2], Q.shape[:-2])
    J = np.zeros(shape + (6, 6))
    J[..., :3, :3] = A
    J[..., 3:, 3:] = A
    J[..., 3:, :3] = Q
    return J


def _jacobian_6x6(shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A zero ``shape + (6, 6)`` array and views of its upper-left and lower-left blocks."""
    J = np.zeros(shape + (6, 6))
    return J, J[..., :3, :3], J[..., 3:, :3]


def left_jacobian(xi: object) -> np.ndarray:
    """J_l(ξ) = [[J_l(ω), 0], [Q(ω, v), J_l(ω)]] (Barfoot eq. 7.85–7.86 reordered to (ω, v)),
    with exp(ξ + δ) ≈ exp(J_l(ξ) δ) exp(ξ). ``(..., 6) -> (..., 6, 6)``.

    Both blocks in closed form (see :func:`_q_left`); J_l(ω) = (1 − c) I + b n^ + c n nᵀ with
    b = (1 − cos θ)/θ, c = 1 − sin θ/θ."""
    J = _jacobian_one(xi, 1.0, False)
    return J if J is not None else _left_jacobian(_twist(xi))


def _left_jacobian(xi: np.ndarray) -> np.ndarray:
    w, v = xi[..., :3], xi[..., 3:]
    theta, n = _axis_angle(w)
    b1, c1 = _unit_jac_coeffs(theta)
    J, A, B = _jacobian_6x6(xi.shape[:-1])
    nc = _comp(n)
    _axis_block(A, nc, 1.0 - c1, b1, c1)
    J[..., 3:, 3:] = A
    _lin_block(B, nc, _comp(v), *_q_block_coeffs(*_q_scaled(theta)))
    return J


def _jacobian_one(xi: object, sign: float, inverse: bool) -> np.ndarray | None:
    """J_l(sign·ξ) (or its inverse) of one float64 ``(6,)`` twist on Python floats (the same
    closed forms as the batched path); ``None`` for anything else, a non-finite or very long
    twist, the singular set of the inverse or an overflow (the batched path handles or
    raises)."""
    if not (type(xi) is np.ndarray and xi.shape == (6,) and xi.dtype == _F64):
        return None
    x, y, z, v0, v1, v2 = xi.tolist()
    if sign < 0.0:
        x, y, z, v0, v1, v2 = -x, -y, -z, -v0, -v1, -v2
    t2 = x * x + y * y + z * z
    if not (t2 < 1e200 and math.isfinite(v0 + v1 + v2)):
        return None
    theta = math.sqrt(t2)
    n = (x / theta, y / theta, z / theta) if theta > 0.0 else (0.0, 0.0, 0.0)
    q = _q_scaled_one(theta)
    J = np.zeros((6, 6))
    A = J[:3, :3]
    if inverse:
        hd = so3._jac_inv_one(theta)
        if hd is None:
            return None
        h, d1 = hd
        _axis_block(A, n, 1.0 - d1, -h, d1)
        _lin_block(J[3:, :3], n, (v0, v1, v2), *_q_inv_block_coeffs(h, d1, *q))
        if not np.isfinite(J).all():
            return None
    else:
        b1, c1 = _unit_jac_coeffs_one(theta)
        _axis_block(A, n, 1.0 - c1, b1, c1)
        _lin_block(J[3:, :3], n, (v0, v1, v2), *_q_block_coeffs(*q))
    J[3:, 3:] = A
    return J


def right_jacobian(xi: object) -> np.ndarray:
    """J_r(ξ) = J_l(−ξ), with exp(ξ + δ) ≈ exp(ξ) exp(J_r(ξ) δ)."""
    J = _jacobian_one(xi, -1.0, False)
    return J if J is not None else _left_jacobian(-_twist(xi))


def left_jacobian_inv(xi: object) -> np.ndarray:
    """J_l(ξ)⁻¹ = [[J⁻¹, 0], [−J⁻¹ Q J⁻¹, J⁻¹]] with J = J_l(ω) (block-triangular inverse);
    raises ``ValueError`` at the singular set ‖ω‖ = 2πk (see
    :func:`liecontrol.lie.so3.right_jacobian_inv`). Closed form, see :func:`_left_jacobian_inv`."""
    J = _jacobian_one(xi, 1.0, True)
    return J if J is not None else _left_jacobian_inv(_twist(xi))


def _left_jacobian_inv(xi: np.ndarray) -> np.ndarray:
    """J_l(ξ)⁻¹ in closed form. With h = θ/2, a = 1 − d₁ (d₁ = 1 − h cot h), J_l(ω)⁻¹ =
    a I − h n^ + d₁ n nᵀ, and multiplying out B = −J⁻¹ Q J⁻¹ (Q as in :func:`_q_left`) and
    reducing with the identities of :func:`_lin_block` gives

        B = (k_v − k_u) v^ + k_vn (v nᵀ + n vᵀ) + k_u s n^ + s (k_nn n nᵀ + k_I I),
        k_v = e (a² − h²) − 4 a f h,            k_vn = −a c₁θ + h (½ − c₂θ²),
        k_u = −k_v + a (c₂θ² − ½) − h c₁θ,      k_I = 2 f (a² − h²) + 2 a e h,
        k_nn = −2 a² f + 2 a (c₃θ³ − e h + f) + 2 f h² + h (2 c₂θ² − 1),

    (e, f as in :func:`_q_left`); checked against the product −J⁻¹ Q J⁻¹ and finite
    differences in the tests."""
    w, v = xi[..., :3], xi[..., 3:]
    # J_l(ω)⁻¹ = J_r(−ω)⁻¹ = I + h (−n)^ + d₁ n^²; raises naming xi at ‖ω‖ = 2πk
    theta, nm, h, d1 = _jac_inv_parts(-w, "xi")
    nc = _comp(-nm)
    with np.errstate(over="ignore", invalid="ignore"):  # checked just below
        J, A, B = _jacobian_6x6(xi.shape[:-1])
        _lin_block(B, nc, _comp(v), *_q_inv_block_coeffs(h, d1, *_q_scaled(theta)))
    if not np.isfinite(J).all():  # (contiguous: cheaper than the strided block alone)
        # the entries grow like ‖ω‖²‖v‖: beyond float range the inverse is not representable
        raise ValueError(
            "xi: the SE(3) Jacobian inverse overflows float64 for this twist (its lower block "
            "grows like ‖ω‖²·‖v‖)"
        )
    _axis_block(A, nc, 1.0 - d1, -h, d1)
    J[..., 3:, 3:] = A
    return J


def right_jacobian_inv(xi: object) -> np.ndarray:
    """J_r(ξ)⁻¹ = J_l(−ξ)⁻¹; raises ``ValueError`` at the singular set ‖ω‖ = 2πk as
    :func:`liecontrol.lie.so3.right_jacobian_inv` does (same threshold)."""
    J = _jacobian_one(xi, -1.0, True)
    return J if J is not None else _left_jacobian_inv(-_twist(xi))


def adjoint(g: object) -> np.ndarray:
    """Ad_g = [[R, 0], [p^ R, R]] (6×6, (ω, v) ordering): g exp(ξ^) g⁻¹ = exp((Ad_g ξ)^)."""
    if _pose_rotation(g) is not None:
        return adjoint_unchecked(g)  # type: ignore[arg-type]
    return adjoint_unchecked(_pose(g))


def adjoint_unchecked(g: np.ndarray) -> np.ndarray:
    """:func:`adjoint` without any check (validated float64 poses; not in ``__all__``)."""
    R = g[..., :3, :3]
    return _blocks(R, so3.hat(g[..., :3, 3]) @ R)


def ad(xi: object) -> np.ndarray:
    """ad_ξ = [[ω^, 0], [v^, ω^]]: ad_ξ η = (ξ^ η^ − η^ ξ^)^∨ (the Lie bracket)."""
    xi = _twist(xi)
    return _blocks(so3.hat(xi[..., :3]), so3.hat(xi[..., 3:]))


def coadjoint(g: object) -> np.ndarray:
    """Ad*_g = (Ad_{g⁻¹})ᵀ = [[R, p^ R], [0, R]] acting on wrenches μ = (moment, force).

    It moves a wrench given in the body frame of g to the reference frame
    (m' = R m + p × R f, f' = R f) and keeps the pairing: ⟨Ad*_g μ, Ad_g ξ⟩ = ⟨μ, ξ⟩.
    """
    g = _pose(g)
    R = g[..., :3, :3]
    shape = g.shape[:-2]
    A = np.zeros(shape + (6, 6))
    A[..., :3, :3] = R
    A[..., 3:, 3:] = R
    A[..., :3, 3:] = so3.hat(g[..., :3, 3]) @ R
    return A


def compose(g1: object, g2: object) -> np.ndarray:
    """g₁ g₂ (batched, broadcasting)."""
    if _pose_rotation(g1) is not None and _pose_rotation(g2) is not None:
        return g1 @ g2  # type: ignore[operator]
    g1 = _pose(g1, "g1")
    g2 = _pose(g2, "g2")
    _batch(("g1", g1.shape[:-2]), ("g2", g2.shape[:-2]))
    return g1 @ g2


def inverse(g: object) -> np.ndarray:
    """g⁻¹ = [[Rᵀ, −Rᵀ p], [0, 1]]."""
    if _pose_rotation(g) is not None:
        return inverse_unchecked(g)  # type: ignore[arg-type]
    return inverse_unchecked(_pose(g))


def inverse_unchecked(g: np.ndarray) -> np.ndarray:
    """:func:`inverse` without any check (validated float64 poses; not in ``__all__``)."""
    Rt = np.swapaxes(g[..., :3, :3], -1, -2)
    out = np.zeros(g.shape)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, g[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def act(g: object, x: object) -> np.ndarray:
    """g · x = R x + p for points ``(..., 3)``."""
    if _pose_rotation(g) is not None and so3._one_vec(x):
        return g[:3, :3] @ x + g[:3, 3]  # type: ignore[index, operator]
    g = _pose(g)
    x = as_array(x, "x", (3,))
    _batch(("g", g.shape[:-2]), ("x", x.shape[:-1]))
    return np.einsum("...ij,...j->...i", g[..., :3, :3], x) + g[..., :3, 3]


def distance(g1: object, g2: object, length_scale: float = 1.0) -> np.ndarray:
    """Left-invariant distance √(θ² + (‖p₂ − p₁‖/L)²) with θ = angle(R₁ᵀR₂) ∈ [0, π], L =
    ``length_scale`` (the length that counts as one radian).

    It is the product metric on SO(3) × ℝ³ (not the screw-motion length), invariant under
    g ↦ h g for every h; ‖p₂ − p₁‖ = ‖translation(g₁⁻¹ g₂)‖.
    """
    g1 = _pose(g1, "g1")
    g2 = _pose(g2, "g2")
    _batch(("g1", g1.shape[:-2]), ("g2", g2.shape[:-2]))
    L = check_positive_scalar(length_scale, "length_scale")
    theta = so3.angle_unchecked(np.swapaxes(g1[..., :3, :3], -1, -2) @ g2[..., :3, :3])
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is named just below
        dp = g2[..., :3, 3] - g1[..., :3, 3]
        # norm_last and hypot: no overflow of the squares for translations up to ~1e308
        d = np.hypot(theta, norm_last(dp) / L)
    return check_output_finite(d, "g2", "the distance (‖p₂ − p₁‖ / length_scale)")


def interpolate(g0: object, g1: object, s: object) -> np.ndarray:
    """Screw-motion geodesic g₀ exp(s log(g₀⁻¹ g₁)); s = 0 → g₀, s = 1 → g₁ (the rotation part
    is SO(3) slerp; the origin moves along a helix about the screw axis)."""
    g0 = _pose(g0, "g0")
    g1 = _pose(g1, "g1")
    s = as_array(s, "s")
    _batch(("g0", g0.shape[:-2]), ("g1", g1.shape[:-2]), ("s", s.shape))
    d = log_unchecked(inverse_unchecked(g0) @ g1)
    return g0 @ exp(d * s[..., None])


def random(
    rng: np.random.Generator,
    size: int | tuple[int, ...] = (),
    translation_scale: float = 1.0,
) -> np.ndarray:
    """Random poses ``size + (4, 4)``: R Haar-uniform on SO(3) (:func:`so3.random`), p with
    i.i.d. N(0, ``translation_scale``²) components (SE(3) has no Haar probability measure)."""
    scale = check_positive_scalar(translation_scale, "translation_scale")
    R = so3.random(rng, size)
    p = scale * rng.standard_normal(R.shape[:-2] + (3,))
    return from_rt(R, p)


def validate(g: object, name: str = "g", atol: float = ROTATION_ATOL) -> np.ndarray:
    """Return g as a float array, raising ``ValueError`` naming ``name`` unless it is a finite
    (batch of) rigid motions: rotation block orthonormal within ``atol`` with det +1, and last
    row (0, 0, 0, 1) within ``atol`` (a finite number > 0)."""
    if not isinstance(name, str) or not name:
        raise TypeError(f"name: expected a non-empty str (the label for errors), got {name!r}")
    atol = check_tolerance(atol, "atol")
    g = as_array(g, name, (4, 4))
    so3.validate(g[..., :3, :3], f"{name}", atol)
    row = np.abs(g[..., 3, :] - np.array([0.0, 0.0, 0.0, 1.0]))
    worst = float(row.max()) if row.size else 0.0
    if worst > atol:
        raise ValueError(f"{name}: last row is not (0, 0, 0, 1) (max deviation {worst:.2e})")
    return g
