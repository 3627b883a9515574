"""The rotation group SO(3): batched array functions (the fast path).

Conventions (``docs/design.md``): vectors are ``(..., 3)``, matrices ``(..., 3, 3)``; any leading
batch shape is accepted and broadcast; ``hat(w) @ v == cross(w, v)``;
``exp(w + δ) ≈ exp(w) exp(J_r(w) δ)`` and ``exp(w + δ) ≈ exp(J_l(w) δ) exp(w)``.

These functions check shapes but do not re-validate that their inputs are rotations: that is the
job of :func:`validate` (and of the :class:`liecontrol.lie.SO3` wrapper), so that the hot paths of
simulators and filters stay cheap.

Sources: Rodrigues' formula and the SO(3) Jacobians as in Barfoot, *State Estimation for
Robotics* (2017), §7.1; Solà, Deray & Atchuthan, *A micro Lie theory for state estimation in
robotics* (2018), App. B. The logarithm near π uses the symmetric part of R (SPEC §2).
"""

from __future__ import annotations

import numpy as np

from .._validation import as_array, check_rotation_matrix, check_shape_tail

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

# Below these angles the closed forms lose digits to cancellation; Taylor series take over.
_SMALL_SINC = 1e-2
_SMALL_JAC = 0.1
# Above this angle (cos θ < −0.5, θ > 2π/3) the log takes its axis from the symmetric part of R.
_LOG_SYMMETRIC_COS = -0.5


def _vec(w: object, name: str) -> np.ndarray:
    a = np.asarray(w, dtype=np.float64)
    check_shape_tail(a, name, (3,))
    return a


def _mat(R: object, name: str) -> np.ndarray:
    a = np.asarray(R, dtype=np.float64)
    check_shape_tail(a, name, (3, 3))
    return a


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


def identity(batch_shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity rotation(s) of shape ``batch_shape + (3, 3)``."""
    return np.broadcast_to(np.eye(3), tuple(batch_shape) + (3, 3)).copy()


def hat(w: object) -> np.ndarray:
    """Skew matrix ω^ with ω^ v = ω × v; ``(..., 3) -> (..., 3, 3)``."""
    w = _vec(w, "w")
    W = np.zeros(w.shape + (3,))
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    W[..., 0, 1] = -z
    W[..., 0, 2] = y
    W[..., 1, 0] = z
    W[..., 1, 2] = -x
    W[..., 2, 0] = -y
    W[..., 2, 1] = x
    return W


def vee(W: object) -> np.ndarray:
    """Inverse of :func:`hat`: ``(..., 3, 3) -> (..., 3)``.

    Reads the entries (W₂₁, W₀₂, W₁₀); for a matrix that is not exactly skew this is the vee of
    its skew part only if the caller skew-symmetrises first.
    """
    W = _mat(W, "W")
    return np.stack((W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]), axis=-1)


def exp(w: object) -> np.ndarray:
    """Rodrigues' formula R = cos θ I + (sin θ/θ) ω^ + ((1 − cos θ)/θ²) ω ωᵀ, θ = ‖ω‖.

    ``(..., 3) -> (..., 3, 3)``; Taylor branch near θ = 0.
    """
    w = _vec(w, "w")
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    theta = np.sqrt(x * x + y * y + z * z)
    a = _sinc(theta)
    half = 0.5 * _sinc(0.5 * theta)
    b = 2.0 * half * half  # (1 − cos θ)/θ², computed as 2 sin²(θ/2)/θ² to avoid cancellation
    c = np.cos(theta)
    bx, by, bz = b * x, b * y, b * z
    ax, ay, az = a * x, a * y, a * z
    bxy, bxz, byz = bx * y, bx * z, by * z
    R = np.empty(w.shape + (3,))
    R[..., 0, 0] = c + bx * x
    R[..., 0, 1] = bxy - az
    R[..., 0, 2] = bxz + ay
    R[..., 1, 0] = bxy + az
    R[..., 1, 1] = c + by * y
    R[..., 1, 2] = byz - ax
    R[..., 2, 0] = bxz - ay
    R[..., 2, 1] = byz + ax
    R[..., 2, 2] = c + bz * z
    return R


def _angle_parts(R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(v, sin θ, cos θ) with v = (R − Rᵀ)^∨ = 2 sin θ · axis."""
    v = np.stack(
        (R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]),
        axis=-1,
    )
    s = 0.5 * np.sqrt(np.sum(v * v, axis=-1))
    c = 0.5 * (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0)
    return v, s, c


def angle(R: object) -> np.ndarray:
    """Rotation angle θ ∈ [0, π] of R, as atan2(sin θ, cos θ) (accurate at 0 and π)."""
    R = _mat(R, "R")
    _, s, c = _angle_parts(R)
    return np.arctan2(s, c)


def log(R: object) -> np.ndarray:
    """Rotation vector ω = θ·axis with ‖ω‖ = θ ∈ [0, π] and exp(ω) = R; ``(..., 3, 3) -> (..., 3)``.

    For θ ≤ 2π/3: ω = θ/(2 sin θ) (R − Rᵀ)^∨ with a Taylor branch at 0. For larger angles the
    axis comes from the symmetric part, (R + Rᵀ)/2 − cos θ I = (1 − cos θ) n nᵀ, its sign from
    (R − Rᵀ)^∨ (SPEC §2): accurate to round-off up to and including θ = π. At exactly θ = π
    both ±π n are logarithms; the one returned is deterministic but arbitrary.
    """
    R = _mat(R, "R")
    v, s, c = _angle_parts(R)
    theta = np.arctan2(s, c)
    # θ/(2 sin θ) = 1 / (2 sinc θ); sinc θ ≥ 0.41 on the branch where it is used
    out = v * (0.5 / _sinc(theta))[..., None]
    big = c < _LOG_SYMMETRIC_COS
    if np.any(big):
        Rb = R[big]
        cb = c[big]
        vb = v[big]
        S = 0.5 * (Rb + np.swapaxes(Rb, -1, -2))
        S[..., 0, 0] -= cb
        S[..., 1, 1] -= cb
        S[..., 2, 2] -= cb
        diag = np.stack((S[..., 0, 0], S[..., 1, 1], S[..., 2, 2]), axis=-1)
        k = np.argmax(diag, axis=-1)
        col = np.take_along_axis(S, k[..., None, None], axis=-1)[..., 0]
        n = col / np.sqrt(np.sum(col * col, axis=-1, keepdims=True))
        sign = np.where(np.sum(n * vb, axis=-1) < 0.0, -1.0, 1.0)
        out[big] = n * (sign * theta[big])[..., None]
    return out


def right_jacobian(w: object) -> np.ndarray:
    """J_r(ω) = I − ((1 − cos θ)/θ²) ω^ + ((θ − sin θ)/θ³) ω^²."""
    w = _vec(w, "w")
    theta = np.linalg.norm(w, axis=-1)
    b, c = _jac_coeffs(theta)
    W = hat(w)
    return np.eye(3) - b[..., None, None] * W + c[..., None, None] * (W @ W)


def left_jacobian(w: object) -> np.ndarray:
    """J_l(ω) = J_r(−ω) = I + ((1 − cos θ)/θ²) ω^ + ((θ − sin θ)/θ³) ω^²."""
    return right_jacobian(-_vec(w, "w"))


def right_jacobian_inv(w: object) -> np.ndarray:
    """J_r(ω)⁻¹ = I + ½ ω^ + (1/θ² − cot(θ/2)/(2θ)) ω^²; defined for θ < 2π."""
    w = _vec(w, "w")
    theta = np.linalg.norm(w, axis=-1)
    d = _jac_inv_coeff(theta)
    W = hat(w)
    return np.eye(3) + 0.5 * W + d[..., None, None] * (W @ W)


def left_jacobian_inv(w: object) -> np.ndarray:
    """J_l(ω)⁻¹ = J_r(−ω)⁻¹ = I − ½ ω^ + (1/θ² − cot(θ/2)/(2θ)) ω^²."""
    return right_jacobian_inv(-_vec(w, "w"))


def adjoint(R: object) -> np.ndarray:
    """Ad_R = R (acting on so(3) ≅ ℝ³): R exp(ω) Rᵀ = exp(R ω)."""
    return np.array(_mat(R, "R"), copy=True)


def ad(w: object) -> np.ndarray:
    """ad_ω = ω^ (the Lie bracket [ω, η] = ω × η)."""
    return hat(w)


def compose(R1: object, R2: object) -> np.ndarray:
    """R₁ R₂ (batched, broadcasting)."""
    return _mat(R1, "R1") @ _mat(R2, "R2")


def inverse(R: object) -> np.ndarray:
    """R⁻¹ = Rᵀ."""
    return np.swapaxes(_mat(R, "R"), -1, -2).copy()


def act(R: object, p: object) -> np.ndarray:
    """R p for points ``(..., 3)``."""
    R = _mat(R, "R")
    p = _vec(p, "p")
    return np.einsum("...ij,...j->...i", R, p)


def distance(R1: object, R2: object) -> np.ndarray:
    """Geodesic (bi-invariant) distance θ(R₁ᵀR₂) ∈ [0, π] in radians."""
    R1 = _mat(R1, "R1")
    R2 = _mat(R2, "R2")
    return angle(np.swapaxes(R1, -1, -2) @ R2)


def interpolate(R0: object, R1: object, s: object) -> np.ndarray:
    """Geodesic interpolation R₀ exp(s log(R₀ᵀR₁)); s = 0 → R₀, s = 1 → R₁ (slerp)."""
    R0 = _mat(R0, "R0")
    R1 = _mat(R1, "R1")
    s = np.asarray(s, dtype=np.float64)
    d = log(np.swapaxes(R0, -1, -2) @ R1)
    return R0 @ exp(d * s[..., None])


def random(rng: np.random.Generator, size: int | tuple[int, ...] = ()) -> np.ndarray:
    """Haar-uniform random rotations of shape ``size + (3, 3)``.

    QR of a Gaussian matrix with the sign of R's diagonal absorbed is Haar on O(3) (Mezzadri
    2007); flipping the last column of the improper ones maps that coset onto SO(3) while keeping
    the measure (right multiplication by a fixed reflection).
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected numpy.random.Generator, got {type(rng).__name__}")
    size = (size,) if isinstance(size, (int, np.integer)) else tuple(size)
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
    (batch of) rotation matrices: orthonormal within ``atol`` and with determinant +1."""
    return check_rotation_matrix(R, name, atol)
