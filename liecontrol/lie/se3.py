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

import numpy as np

from .._linalg import cross as _cross
from .._validation import (
    ROTATION_ATOL,
    as_array,
    check_positive_scalar,
    check_tolerance,
)
from . import so3
from .so3 import (
    _SMALL_JAC,
    ARRAY_ROTATION_ATOL,
    _axis_angle,
    _batch,
    _jac_coeffs,
    _jac_inv_coeff,
    _right_jacobian_inv,
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
    xi = _twist(xi)
    w = xi[..., :3]
    v = xi[..., 3:]
    # V v in axis–angle form, v + ((1 − cos θ)/θ) n × v + (1 − sin θ/θ) n × (n × v): bounded
    # coefficients, so long twists do not overflow
    theta, n = _axis_angle(w)
    b1, c1 = _unit_jac_coeffs(theta)
    nv = _cross(n, v)
    t = v + b1[..., None] * nv + c1[..., None] * _cross(n, nv)
    g = np.zeros(xi.shape[:-1] + (4, 4))
    g[..., :3, :3] = so3.exp(w)
    g[..., :3, 3] = t
    g[..., 3, 3] = 1.0
    return g


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
    return log_unchecked(_pose(g, "g"))


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
        x = theta * theta
        fact = np.cumprod(np.arange(1, 30, dtype=np.float64))  # fact[k-1] = k!
        k = np.arange(9)
        a1 = (-1.0) ** k / fact[2 * k + 2]
        a2 = (-1.0) ** k / fact[2 * k + 3]
        n = k + 2
        a3 = (-1.0) ** n * (n - 1) / fact[2 * n]
        s1 = np.zeros_like(x)
        s2 = np.zeros_like(x)
        s3 = np.zeros_like(x)
        for i in range(8, -1, -1):  # Horner over the 9 series terms (not over the batch)
            s1 = s1 * x + a1[i]
            s2 = s2 * x + a2[i]
            s3 = s3 * x + a3[i]
        c1 = np.where(small, s1, c1)
        c2 = np.where(small, s2, c2)
        c3 = np.where(small, s3, c3)
    return c1, c2, c3


def _q_left(w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The 3×3 Q block of the SE(3) left Jacobian (Barfoot eq. 7.86 with φ = ω, ρ = v).

    Written with P = θ N (N = n^, n = ω/θ): the coefficients are multiplied by the matching powers
    of θ (c₁θ, c₁θ², c₂θ², c₃θ³ are all bounded), so no product overflows for long ω.
    """
    theta, n = _axis_angle(w)
    t = np.minimum(theta, 1e50)  # the coefficients' argument; beyond it the limits apply
    c1, c2, c3 = _q_coeffs(t)
    big = theta > 1e50
    P = so3.hat(n)
    c1a = c1 * t  # multiplies N V + V N (one factor of P)
    c1 = c1 * t * t  # multiplies N V N
    c2 = c2 * t * t
    c3 = c3 * t * t * t
    if np.any(big):
        # θ → ∞ limits: c₁θ → 0, c₁θ² → 1, c₂θ² → ½, c₃θ³ → 0
        c1a = np.where(big, 0.0, c1a)
        c1 = np.where(big, 1.0, c1)
        c2 = np.where(big, 0.5, c2)
        c3 = np.where(big, 0.0, c3)
    V = so3.hat(v)
    PV = P @ V
    VP = V @ P
    PVP = PV @ P
    PPV = P @ PV
    VPP = VP @ P
    PVPP = PVP @ P
    PPVP = P @ PVP
    c1a = c1a[..., None, None]
    c1 = c1[..., None, None]
    c2 = c2[..., None, None]
    c3 = c3[..., None, None]
    return (
        0.5 * V
        + c1a * (PV + VP)
        + c1 * PVP
        + c2 * (PPV + VPP - 3.0 * PVP)
        + c3 * (PVPP + PPVP)
    )


def _blocks(A: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """[[A, 0], [Q, A]] as ``(..., 6, 6)``."""
    shape = np.broadcast_shapes(A.shape[:-2], Q.shape[:-2])
    J = np.zeros(shape + (6, 6))
    J[..., :3, :3] = A
    J[..., 3:, 3:] = A
    J[..., 3:, :3] = Q
    return J


def left_jacobian(xi: object) -> np.ndarray:
    """J_l(ξ) = [[J_l(ω), 0], [Q(ω, v), J_l(ω)]] (Barfoot eq. 7.85–7.86 reordered to (ω, v)),
    with exp(ξ + δ) ≈ exp(J_l(ξ) δ) exp(ξ). ``(..., 6) -> (..., 6, 6)``."""
    xi = _twist(xi)
    w, v = xi[..., :3], xi[..., 3:]
    return _blocks(so3.left_jacobian(w), _q_left(w, v))


def right_jacobian(xi: object) -> np.ndarray:
    """J_r(ξ) = J_l(−ξ), with exp(ξ + δ) ≈ exp(ξ) exp(J_r(ξ) δ)."""
    return left_jacobian(-_twist(xi))


def left_jacobian_inv(xi: object) -> np.ndarray:
    """J_l(ξ)⁻¹ = [[J⁻¹, 0], [−J⁻¹ Q J⁻¹, J⁻¹]] with J = J_l(ω) (block-triangular inverse);
    raises ``ValueError`` at the singular set ‖ω‖ = 2πk (see
    :func:`liecontrol.lie.so3.right_jacobian_inv`)."""
    return _left_jacobian_inv(_twist(xi))


def _left_jacobian_inv(xi: np.ndarray) -> np.ndarray:
    w, v = xi[..., :3], xi[..., 3:]
    Ji = _right_jacobian_inv(-w, "xi")  # raises naming xi at ‖ω‖ = 2πk
    with np.errstate(over="ignore", invalid="ignore"):  # checked just below
        B = -(Ji @ _q_left(w, v) @ Ji)
    if not np.all(np.isfinite(B)):
        # the entries grow like ‖ω‖²‖v‖: beyond float range the inverse is not representable
        raise ValueError(
            "xi: the SE(3) Jacobian inverse overflows float64 for this twist (its lower block "
            "grows like ‖ω‖²·‖v‖)"
        )
    return _blocks(Ji, B)


def right_jacobian_inv(xi: object) -> np.ndarray:
    """J_r(ξ)⁻¹ = J_l(−ξ)⁻¹; raises ``ValueError`` at the singular set ‖ω‖ = 2πk as
    :func:`liecontrol.lie.so3.right_jacobian_inv` does (same threshold)."""
    return _left_jacobian_inv(-_twist(xi))


def adjoint(g: object) -> np.ndarray:
    """Ad_g = [[R, 0], [p^ R, R]] (6×6, (ω, v) ordering): g exp(ξ^) g⁻¹ = exp((Ad_g ξ)^)."""
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
    g1 = _pose(g1, "g1")
    g2 = _pose(g2, "g2")
    _batch(("g1", g1.shape[:-2]), ("g2", g2.shape[:-2]))
    return g1 @ g2


def inverse(g: object) -> np.ndarray:
    """g⁻¹ = [[Rᵀ, −Rᵀ p], [0, 1]]."""
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
    dp = g2[..., :3, 3] - g1[..., :3, 3]
    return np.sqrt(theta * theta + np.sum(dp * dp, axis=-1) / (L * L))


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
