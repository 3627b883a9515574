"""Compiled kernels of the manifold UKF on the gyro model (:class:`~liecontrol.estimation.
manifold_ukf.ManifoldUKF` on :class:`~liecontrol.estimation.models.GyroAttitudeModel`), one
filter (state ``x = (q, b)`` ``(7,)``, error covariance ``P (6, 6)``), in place. The compiled
closed loop's estimator hook (:mod:`spacecraft._fused_sensors`) runs them; the numpy class remains
the validated reference and the tests hold the two to 1e-12.

USQUE-style error-state UKF (Crassidis & Markley, "Unscented filtering for spacecraft attitude
estimation", JGCD 26(4), 2003) with the scaled unscented transform's weights (Julier, "The
scaled unscented transformation", ACC 2002; γ, Wᵐ, Wᶜ from :func:`liecontrol.estimation.
ut_weights`, passed in). ``x ⊞ δ = (q ⊗ Exp(δθ), b + δb)``, ``y ⊟ x = (Log(q_x⁻¹ ⊗ q_y),
b_y − b_x)``; Δ the sigma offsets 0, ±γ sⱼ (sⱼ the columns of the Cholesky factor of P).

predict (ω̃ the gyro input held over ``dt``)::

    Yᵢ = f(x ⊞ Δᵢ),  f(q, b) = (normalise(q ⊗ Exp((ω̃ − b) dt)), b),
    x⁻ = Y₀ ⊞ Σ Wᵢᵐ (Yᵢ ⊟ Y₀),   P⁻ = sym(Σ Wᵢᶜ (Yᵢ ⊟ x⁻)(Yᵢ ⊟ x⁻)ᵀ + Q(dt))

update (z the ZYX Euler angles, R = B(ẑ) Σ B(ẑ)ᵀ at the prior mean as ``GyroAttitudeModel.
R_at``)::

    Zᵢ = rpy(x ⊞ Δᵢ),  ẑ = wrap(Z₀ + Σ Wᵢᵐ wrap(Zᵢ − Z₀)),  ΔZᵢ = wrap(Zᵢ − ẑ),
    P_zz = Σ Wᵢᶜ ΔZᵢ ΔZᵢᵀ + R = S_z S_zᵀ,  P_xz = Σ Wᵢᶜ Δᵢ ΔZᵢᵀ,  K = P_xz P_zz⁻¹,
    ν = wrap(z − ẑ),  NIS = |S_z⁻¹ ν|²  (χ² gate: NIS > threshold rejects, the prediction is kept),
    x ← x ⊞ K ν,  P ← S Sᵀ with S the Cholesky factor of sym(P − K P_zz Kᵀ)

A covariance that is not positive definite (P, P_zz or the updated P: Cholesky fails) returns a
failure code: the numpy filter would repair it per its policy, which the compiled loop leaves to
the Python loop. Initialisation is the MEKF's (:func:`liecontrol._kernels.mekf.mekf_gyro_init`:
both are :class:`~liecontrol.estimation.base.ManifoldFilter` constructors).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .filters import (
    _sigma_rows,
    _weighted_outer_sym,
    cholesky_sym,
    euler_mean_residuals,
    rpy_from_q,
    symmetrised_into,
    ukf_gain,
)
from .mekf import _outer_lower, add_gyro_process_noise, euler_noise_into, quat_times_rotvec

#: below this |sin(angle/2)| the quaternion log uses its series (as liecontrol.charts.quaternion)
_SMALL_HALF_SINE = 1e-6


@njit(inline="always")
def quat_boxminus_into(qy: np.ndarray, qx: np.ndarray, out: np.ndarray) -> None:
    """``out[:3] = Log(q_x⁻¹ ⊗ q_y)`` (the models' ⊟ on the attitude): the product normalised,
    its sign chosen with w ≥ 0, then θ = 2 atan2(|v|, w) v/|v| (series (2/w)(1 − |v|²/(3w²)) v
    below |v| = 1e-6), as ``liecontrol.charts.quaternion._to_rotvec_unchecked``."""
    pw, px, py, pz = qx[0], -qx[1], -qx[2], -qx[3]
    qw, qxx, qyy, qzz = qy[0], qy[1], qy[2], qy[3]
    w = pw * qw - px * qxx - py * qyy - pz * qzz
    v0 = pw * qxx + px * qw + py * qzz - pz * qyy
    v1 = pw * qyy - px * qzz + py * qw + pz * qxx
    v2 = pw * qzz + px * qyy - py * qxx + pz * qw
    n = math.sqrt(w * w + v0 * v0 + v1 * v1 + v2 * v2)
    w, v0, v1, v2 = w / n, v0 / n, v1 / n, v2 / n
    if w < 0.0:
        w, v0, v1, v2 = -w, -v0, -v1, -v2
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if s < _SMALL_HALF_SINE:
        f = 2.0 / w * (1.0 - s * s / (3.0 * w * w))
    else:
        f = 2.0 * math.atan2(s, w) / s
    out[0] = v0 * f
    out[1] = v1 * f
    out[2] = v2 * f


@njit(inline="always")
def _boxplus_into(x: np.ndarray, d: np.ndarray, out: np.ndarray) -> None:
    """``out = x ⊞ d = (q ⊗ Exp(d[:3]), b + d[3:])`` (``out`` may alias ``x``)."""
    quat_times_rotvec(x, d[0], d[1], d[2], out)
    for i in range(3):
        out[4 + i] = x[4 + i] + d[3 + i]


@njit
def ukf_gyro_predict(
    x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, sigma_v: float, sigma_u: float,
    gamma: float, Wm: np.ndarray, Wc: np.ndarray,
) -> bool:  # fmt: skip
    """Time update of ``x``, ``P`` in place (module docstring); False when P is not PD."""
    S, ok = cholesky_sym(P)
    if not ok:
        return False
    D = _sigma_rows(np.zeros(6), S, gamma)
    N = D.shape[0]
    Y = np.empty((N, 7))
    for i in range(N):
        yi = Y[i]
        _boxplus_into(x, D[i], yi)
        w0, w1, w2 = u[0] - yi[4], u[1] - yi[5], u[2] - yi[6]
        quat_times_rotvec(yi, w0 * dt, w1 * dt, w2 * dt, yi)
        n = math.sqrt(yi[0] * yi[0] + yi[1] * yi[1] + yi[2] * yi[2] + yi[3] * yi[3])
        for k in range(4):
            yi[k] = yi[k] / n
    # the mean: Y₀ ⊞ Σ Wᵐ (Yᵢ ⊟ Y₀), the weighted sum in the sigma points' order
    E = np.empty((N, 6))
    for i in range(N):
        quat_boxminus_into(Y[i], Y[0], E[i])
        for k in range(3):
            E[i, 3 + k] = Y[i, 4 + k] - Y[0, 4 + k]
    m = np.zeros(6)
    for i in range(N):
        for k in range(6):
            m[k] += Wm[i] * E[i, k]
    xm = np.empty(7)
    _boxplus_into(Y[0], m, xm)
    for i in range(N):
        quat_boxminus_into(Y[i], xm, E[i])
        for k in range(3):
            E[i, 3 + k] = Y[i, 4 + k] - xm[4 + k]
    Pn = _weighted_outer_sym(E, np.zeros(6), Wc)
    add_gyro_process_noise(Pn, dt, sigma_v, sigma_u)
    for i in range(7):
        x[i] = xm[i]
    symmetrised_into(Pn, P)
    return True


@njit
def ukf_gyro_update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, Sigma: np.ndarray, threshold: float,
    may_gate: bool, gamma: float, Wm: np.ndarray, Wc: np.ndarray,
) -> tuple[int, float]:  # fmt: skip
    """Measurement update of ``x``, ``P`` in place with the Euler angles ``z`` (module
    docstring). Returns ``(code, NIS)``: 0 accepted, 1 rejected by the χ² gate (NIS >
    ``threshold`` and ``may_gate``; nothing changed), 2 failure (P, P_zz or the updated P not
    PD, gimbal lock)."""
    S, ok = cholesky_sym(P)
    if not ok:
        return 2, math.nan
    D = _sigma_rows(np.zeros(6), S, gamma)
    N = D.shape[0]
    X = np.empty((N, 7))
    for i in range(N):
        _boxplus_into(x, D[i], X[i])
    Z = rpy_from_q(X)
    zm, dZ = euler_mean_residuals(Z, Wm)
    # R = B Σ Bᵀ at the prior mean (the model's R_at)
    zh = rpy_from_q(x[:4].reshape((1, 4)))[0]
    Bm = np.empty((3, 3))
    Rk = np.empty((3, 3))
    if not euler_noise_into(zh, Sigma, Bm, Rk):
        return 2, math.nan
    Pzz = np.zeros((3, 3))
    Pxz = np.zeros((6, 3))
    for i in range(N):
        w = Wc[i]
        for a in range(3):
            wa = w * dZ[i, a]
            for b in range(3):
                Pzz[a, b] += wa * dZ[i, b]
        for a in range(6):
            wa = w * D[i, a]
            for b in range(3):
                Pxz[a, b] += wa * dZ[i, b]
    for a in range(3):
        for b in range(3):
            Pzz[a, b] += Rk[a, b]
    Sz, ok = cholesky_sym(Pzz)
    if not ok:
        return 2, math.nan
    Pzz, K, nu, nis = ukf_gain(Sz, Pxz, z, zm)
    if may_gate and nis > threshold:
        return 1, nis
    d = np.empty(6)
    for i in range(6):
        d[i] = K[i, 0] * nu[0] + K[i, 1] * nu[1] + K[i, 2] * nu[2]
    _boxplus_into(x, d, x)
    # P − K P_zz Kᵀ, symmetrised, refactored as S Sᵀ
    KP = np.empty((6, 3))
    for i in range(6):
        for j in range(3):
            KP[i, j] = K[i, 0] * Pzz[0, j] + K[i, 1] * Pzz[1, j] + K[i, 2] * Pzz[2, j]
    Pn = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            Pn[i, j] = P[i, j] - (KP[i, 0] * K[j, 0] + KP[i, 1] * K[j, 1] + KP[i, 2] * K[j, 2])
    Ps = np.empty((6, 6))
    symmetrised_into(Pn, Ps)
    S, ok = cholesky_sym(Ps)
    if not ok:
        return 2, math.nan
    _outer_lower(S, P)
    return 0, nis
