"""Compiled kernels of the multiplicative EKF on the gyro model (:class:`~liecontrol.
estimation.mekf.MEKF` on :class:`~liecontrol.estimation.models.GyroAttitudeModel`), one filter
(state ``x = (q, b)`` ``(7,)``, error covariance ``P (6, 6)``), in place. The compiled closed
loop's estimator hook (:mod:`spacecraft._fused_sensors`) runs them; the numpy classes remain
the validated reference and the tests hold the two to 1e-12.

predict (ω̃ the gyro input held over ``dt``, ω = ω̃ − b)::

    Φ = [[Exp(−ω dt), −J_r(ω dt) dt], [0, I]],   q ← normalise(q ⊗ Exp(ω dt)),
    P ← Φ P Φᵀ + Q(dt), then ½(P + Pᵀ),
    Q = [[σ_v² dt + σ_u² dt³/3, −σ_u² dt²/2], [−σ_u² dt²/2, σ_u² dt]] ⊗ I₃

update (z the ZYX Euler angles (roll, pitch, yaw), H = [B(ẑ), 0] with B the Euler-rate matrix,
R = B Σ Bᵀ the body-frame tracker covariance Σ seen through the angles)::

    P_zz = H P Hᵀ + R = S_z S_zᵀ,  K = P Hᵀ P_zz⁻¹,  ν = wrap(z − ẑ),  NIS = |S_z⁻¹ ν|²,
    (χ² gate: NIS > threshold rejects, the prediction is kept)
    x ← x ⊞ K ν,  P ← (I − K H) P (I − K H)ᵀ + K R Kᵀ, refactored as S Sᵀ   (Joseph form)

A covariance that is not positive definite (Cholesky fails) returns a failure code: the numpy
filter would repair it per its policy, which the compiled loop leaves to the Python loop.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .filters import _wrap, cholesky_sym, rpy_from_q, symmetrised_into
from .so3 import exp9

#: below this angle the right Jacobian's coefficients use their series (as liecontrol.lie.so3)
_SMALL_JAC = 0.1


@njit(inline="always")
def quat_times_rotvec(q: np.ndarray, t0: float, t1: float, t2: float, out: np.ndarray) -> None:
    """``out = q ⊗ Exp(θ)`` (scalar first; Exp(θ) = (cos(|θ|/2), ½ sinc(|θ|/2π) θ), exact at
    θ = 0); ``out`` may alias ``q``."""
    angle = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    k = 0.5 * np.sinc(angle / (2.0 * np.pi))
    pw = math.cos(0.5 * angle)
    px, py, pz = t0 * k, t1 * k, t2 * k
    qw, qx, qy, qz = q[0], q[1], q[2], q[3]
    out[0] = qw * pw - qx * px - qy * py - qz * pz
    out[1] = qw * px + qx * pw + qy * pz - qz * py
    out[2] = qw * py - qx * pz + qy * pw + qz * px
    out[3] = qw * pz + qx * py - qy * px + qz * pw


@njit(inline="always")
def rpy_jacobian_into(phi: float, theta: float, B: np.ndarray) -> bool:
    """``B (3, 3)`` = ∂(φ, θ, ψ)/∂δθ = [[1, sφ tθ, cφ tθ], [0, cφ, −sφ], [0, sφ/cθ, cφ/cθ]];
    False at |cos θ| < 1e-9 (gimbal lock)."""
    c = math.cos(theta)
    if abs(c) < 1e-9:
        return False
    sp, cp, t = math.sin(phi), math.cos(phi), math.tan(theta)
    B[0, 0], B[0, 1], B[0, 2] = 1.0, sp * t, cp * t
    B[1, 0], B[1, 1], B[1, 2] = 0.0, cp, -sp
    B[2, 0], B[2, 1], B[2, 2] = 0.0, sp / c, cp / c
    return True


@njit(inline="always")
def right_jacobian_into(x: float, y: float, z: float, out: np.ndarray) -> None:
    """J_r(ω) = I − ((1 − cos θ)/θ) n^ + (1 − sin θ/θ) n^² (n = ω/θ; series below θ = 0.1)."""
    t2 = x * x + y * y + z * z
    theta = math.sqrt(t2)
    s = 1.0 / theta if theta > 0.0 else 0.0
    n0, n1, n2 = x * s, y * s, z * s
    h = math.sin(0.5 * theta)
    b1 = 2.0 * h * h / theta if theta > 0.0 else 0.0
    if theta < _SMALL_JAC:
        c1 = t2 * (1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0)
    else:
        c1 = 1.0 - math.sin(theta) / theta
    # c_i I + c_p n^ + c_nn n nᵀ with c_i = 1 − c1, c_p = −b1, c_nn = c1 (n^² = n nᵀ − I)
    ci, cp = 1.0 - c1, -b1
    out[0, 0] = n0 * (c1 * n0) + ci
    out[1, 1] = n1 * (c1 * n1) + ci
    out[2, 2] = n2 * (c1 * n2) + ci
    out[0, 1] = n0 * (c1 * n1) - cp * n2
    out[1, 0] = n0 * (c1 * n1) + cp * n2
    out[0, 2] = n0 * (c1 * n2) + cp * n1
    out[2, 0] = n0 * (c1 * n2) - cp * n1
    out[1, 2] = n1 * (c1 * n2) - cp * n0
    out[2, 1] = n1 * (c1 * n2) + cp * n0


@njit
def _sym_abat(A: np.ndarray, P: np.ndarray, out: np.ndarray) -> None:
    """``out = A P Aᵀ`` (A (m, n), P (n, n))."""
    m, n = A.shape
    T = np.zeros((m, n))
    for i in range(m):
        for j in range(n):
            s = 0.0
            for k in range(n):
                s += A[i, k] * P[k, j]
            T[i, j] = s
    for i in range(m):
        for j in range(m):
            s = 0.0
            for k in range(n):
                s += T[i, k] * A[j, k]
            out[i, j] = s


@njit
def _outer_lower(S: np.ndarray, out: np.ndarray) -> None:
    """``out = S Sᵀ``."""
    n = S.shape[0]
    for i in range(n):
        for j in range(n):
            s = 0.0
            for k in range(n):
                s += S[i, k] * S[j, k]
            out[i, j] = s


@njit(inline="always")
def add_gyro_process_noise(P: np.ndarray, dt: float, sigma_v: float, sigma_u: float) -> None:
    """``P += Q(dt)``, the gyro model's discrete noise of (δθ, δb) (module docstring; Farrenkopf,
    "Analytic steady-state accuracy solutions for two common spacecraft attitude estimators",
    JGCD 1(4), 1978; Crassidis & Junkins, *Optimal Estimation of Dynamic Systems*, §7.2.4)::

        Q = [[σ_v² dt + σ_u² dt³/3, −σ_u² dt²/2], [−σ_u² dt²/2, σ_u² dt]] ⊗ I₃
    """
    a = sigma_v**2 * dt + sigma_u**2 * dt**3 / 3.0
    c = -(sigma_u**2) * dt**2 / 2.0
    b = sigma_u**2 * dt
    for i in range(3):
        P[i, i] += a
        P[3 + i, 3 + i] += b
        P[i, 3 + i] += c
        P[3 + i, i] += c


@njit
def euler_noise_into(zh: np.ndarray, Sigma: np.ndarray, Bm: np.ndarray, Rk: np.ndarray) -> bool:
    """The Euler angles' noise covariance at the angles ``zh``: ``Bm`` = B(ẑ) (the Euler-rate
    matrix, :func:`rpy_jacobian_into`) and ``Rk`` = sym(B Σ Bᵀ), Σ the tracker's body-frame
    covariance (``GyroAttitudeModel.R_at``); False at gimbal lock."""
    if not rpy_jacobian_into(zh[0], zh[1], Bm):
        return False
    _sym_abat(Bm, Sigma, Rk)
    for i in range(3):
        for j in range(i + 1, 3):
            s = 0.5 * (Rk[i, j] + Rk[j, i])
            Rk[i, j] = s
            Rk[j, i] = s
    return True


@njit
def mekf_gyro_init(q: np.ndarray, P0: np.ndarray, x: np.ndarray, P: np.ndarray) -> bool:
    """A new filter at the quaternion ``q`` (normalised) with zero bias and ``P = S Sᵀ``, S the
    Cholesky factor of ``P0`` (as the numpy filter's constructor); False when P0 is not PD."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        x[i] = q[i] / n
    for i in range(4, 7):
        x[i] = 0.0
    S, ok = cholesky_sym(P0)
    if not ok:
        return False
    _outer_lower(S, P)
    return True


@njit
def mekf_gyro_predict(
    x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, sigma_v: float, sigma_u: float
) -> bool:
    """Time update of ``x``, ``P`` in place (module docstring); False when P is not PD."""
    _, ok = cholesky_sym(P)
    if not ok:
        return False
    w0, w1, w2 = u[0] - x[4], u[1] - x[5], u[2] - x[6]
    p0, p1, p2 = w0 * dt, w1 * dt, w2 * dt
    F = np.eye(6)
    e = exp9(-p0, -p1, -p2)
    Jr = np.empty((3, 3))
    right_jacobian_into(p0, p1, p2, Jr)
    for i in range(3):
        for j in range(3):
            F[i, j] = e[3 * i + j]
            F[i, 3 + j] = -Jr[i, j] * dt
    quat_times_rotvec(x, w0 * dt, w1 * dt, w2 * dt, x)
    n = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
    for i in range(4):
        x[i] = x[i] / n
    Pn = np.empty((6, 6))
    _sym_abat(F, P, Pn)
    add_gyro_process_noise(Pn, dt, sigma_v, sigma_u)
    symmetrised_into(Pn, P)
    return True


@njit
def mekf_gyro_update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, Sigma: np.ndarray, threshold: float,
    may_gate: bool,
) -> tuple[int, float]:  # fmt: skip
    """Measurement update of ``x``, ``P`` in place with the Euler angles ``z`` (module
    docstring). Returns ``(code, NIS)``: 0 accepted, 1 rejected by the χ² gate (NIS >
    ``threshold`` and ``may_gate``; nothing changed), 2 failure (P or P_zz not PD, gimbal
    lock)."""
    _, ok = cholesky_sym(P)
    if not ok:
        return 2, math.nan
    zh = rpy_from_q(x[:4].reshape((1, 4)))[0]
    Bm = np.empty((3, 3))
    Rk = np.empty((3, 3))
    # R = B Σ Bᵀ (symmetrised); H = [B, 0]: P Hᵀ = P[:, :3] Bᵀ, H P Hᵀ = B P₃₃ Bᵀ
    if not euler_noise_into(zh, Sigma, Bm, Rk):
        return 2, math.nan
    PHt = np.zeros((6, 3))
    for i in range(6):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += P[i, k] * Bm[j, k]
            PHt[i, j] = s
    Pzz = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += Bm[i, k] * PHt[k, j]
            Pzz[i, j] = s + Rk[i, j]
    Sz, ok = cholesky_sym(Pzz)
    if not ok:
        return 2, math.nan
    # K = P Hᵀ (S_z S_zᵀ)⁻¹: S_z Y = (P Hᵀ)ᵀ, S_zᵀ X = Y, K = Xᵀ
    Y = np.empty((3, 6))
    for c in range(6):
        for i in range(3):
            s = PHt[c, i]
            for k in range(i):
                s -= Sz[i, k] * Y[k, c]
            Y[i, c] = s / Sz[i, i]
    Kt = np.empty((3, 6))
    for c in range(6):
        for i in range(2, -1, -1):
            s = Y[i, c]
            for k in range(i + 1, 3):
                s -= Sz[k, i] * Kt[k, c]
            Kt[i, c] = s / Sz[i, i]
    nu = np.empty(3)
    for i in range(3):
        nu[i] = _wrap(z[i] - zh[i])
    y0 = nu[0] / Sz[0, 0]
    y1 = (nu[1] - Sz[1, 0] * y0) / Sz[1, 1]
    y2 = (nu[2] - Sz[2, 0] * y0 - Sz[2, 1] * y1) / Sz[2, 2]
    nis = y0 * y0 + y1 * y1 + y2 * y2
    if may_gate and nis > threshold:
        return 1, nis
    d = np.empty(6)
    for i in range(6):
        d[i] = Kt[0, i] * nu[0] + Kt[1, i] * nu[1] + Kt[2, i] * nu[2]
    quat_times_rotvec(x, d[0], d[1], d[2], x)
    for i in range(3):
        x[4 + i] += d[3 + i]
    # Joseph form: A = I − K H, P ← A P Aᵀ + K R Kᵀ
    A = np.eye(6)
    for i in range(6):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += Kt[k, i] * Bm[k, j]
            A[i, j] -= s
    Pn = np.empty((6, 6))
    _sym_abat(A, P, Pn)
    KRK = np.empty((6, 6))
    _sym_abat(Kt.T.copy(), Rk, KRK)
    for i in range(6):
        for j in range(6):
            Pn[i, j] += KRK[i, j]
    Ps = np.empty((6, 6))
    symmetrised_into(Pn, Ps)
    S, ok = cholesky_sym(Ps)
    if not ok:
        return 2, math.nan
    _outer_lower(S, P)
    return 0, nis


@njit
def spd_quadratic(P: np.ndarray, e: np.ndarray) -> float:
    """eᵀ P⁻¹ e through the Cholesky factor of P (NaN when P is not PD)."""
    L, ok = cholesky_sym(P)
    if not ok:
        return math.nan
    n = e.shape[0]
    y = np.empty(n)
    s2 = 0.0
    for i in range(n):
        s = e[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
        s2 += y[i] * y[i]
    return s2
