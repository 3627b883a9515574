"""Compiled kernels shared by the attitude filters (:mod:`liecontrol.estimation`) and the
simulator's compiled estimator hook (:mod:`spacecraft._fused_sensors`): the ZYX Euler angles of
a quaternion, the Cholesky factor of a symmetric matrix, the angle wrap, triangular solves and
the unscented transform's sigma points, weighted covariance and Kalman gain (Julier 2002; Van der
Merwe & Wan, "The square-root unscented Kalman filter for state and parameter-estimation",
ICASSP 2001, eq. 27). Here, outside the
:mod:`liecontrol.estimation` package, so that the simulator's loop uses them without importing
the filters (and scipy). Kernels never validate.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit


@njit
def rpy_from_q(X: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (ZYX) of the normalised quaternion part of every row of ``X (N, ≥4)``."""
    N = X.shape[0]
    Z = np.empty((N, 3))
    for i in range(N):
        nrm = math.sqrt(X[i, 0] ** 2 + X[i, 1] ** 2 + X[i, 2] ** 2 + X[i, 3] ** 2)
        w = X[i, 0] / nrm
        x = X[i, 1] / nrm
        y = X[i, 2] / nrm
        z = X[i, 3] / nrm
        Z[i, 0] = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
        Z[i, 1] = math.asin(min(1.0, max(-1.0, 2.0 * (w * y - z * x))))
        Z[i, 2] = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return Z


@njit
def cholesky_sym(P: np.ndarray) -> tuple[np.ndarray, bool]:
    """Lower Cholesky factor of ½(P + Pᵀ) (n × n); ok False when a pivot is not > 0 (or NaN),
    where LAPACK's ``potrf`` (behind ``numpy.linalg.cholesky``) fails too."""
    n = P.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        s = P[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return L, False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            a = 0.5 * (P[i, j] + P[j, i])
            for k in range(j):
                a -= L[i, k] * L[j, k]
            L[i, j] = a / d
    return L, True


@njit
def _wrap(a: float) -> float:
    """a wrapped to (−π, π] as π − mod(π − a, 2π) (numpy's ``mod`` and Python's ``%`` agree:
    fmod, then the divisor's sign)."""
    return math.pi - (math.pi - a) % (2.0 * math.pi)


@njit
def symmetrised_into(Pn: np.ndarray, out: np.ndarray) -> None:
    """``out = (Pn + Pnᵀ)/2`` (square; ``out`` may not alias ``Pn``): a covariance update's
    round-off asymmetry removed before it is stored or factored."""
    n = Pn.shape[0]
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.5 * (Pn[i, j] + Pn[j, i])


@njit
def euler_mean_residuals(Z: np.ndarray, Wm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The weighted mean of Euler-angle sigma points ``Z (N, 3)`` on the circle and their
    residuals: ẑ = wrap(Z₀ + Σ Wᵢᵐ wrap(Zᵢ − Z₀)), ΔZᵢ = wrap(Zᵢ − ẑ) (the models' ``z_mean``
    and ``z_residual``)."""
    N = Z.shape[0]
    zm = np.empty(3)
    for k in range(3):
        acc = 0.0
        for i in range(N):
            acc += Wm[i] * _wrap(Z[i, k] - Z[0, k])
        zm[k] = _wrap(Z[0, k] + acc)
    dZ = np.empty((N, 3))
    for i in range(N):
        for k in range(3):
            dZ[i, k] = _wrap(Z[i, k] - zm[k])
    return zm, dZ


@njit
def solve_lower_into(L: np.ndarray, B: np.ndarray, transpose: bool) -> tuple[np.ndarray, bool]:
    """(X, ok) with L X = B (or Lᵀ X = B) for lower-triangular ``L (n, n)`` and ``B (n, m)``;
    ok False (X meaningless) when L has a zero diagonal entry."""
    n = L.shape[0]
    m = B.shape[1]
    X = B.copy()
    for i in range(n):
        if L[i, i] == 0.0:
            return X, False
    if transpose:
        for i in range(n - 1, -1, -1):
            for c in range(m):
                s = X[i, c]
                for k in range(i + 1, n):
                    s -= L[k, i] * X[k, c]
                X[i, c] = s / L[i, i]
    else:
        for i in range(n):
            for c in range(m):
                s = X[i, c]
                for k in range(i):
                    s -= L[i, k] * X[k, c]
                X[i, c] = s / L[i, i]
    return X, True


@njit
def _sigma_rows(x: np.ndarray, S: np.ndarray, gamma: float) -> np.ndarray:
    """(2n+1, n) sigma points x, x + γ sⱼ, x − γ sⱼ (sⱼ the columns of S)."""
    n = x.shape[0]
    X = np.empty((2 * n + 1, n))
    for k in range(n):
        X[0, k] = x[k]
    for j in range(n):
        for k in range(n):
            c = gamma * S[k, j]
            X[1 + j, k] = x[k] + c
            X[1 + n + j, k] = x[k] - c
    return X


@njit
def _weighted_outer_sym(Y: np.ndarray, ym: np.ndarray, Wc: np.ndarray) -> np.ndarray:
    """½(P + Pᵀ) with P = Σᵢ Wᶜᵢ (Yᵢ − ȳ)(Yᵢ − ȳ)ᵀ."""
    N, n = Y.shape
    D = np.empty((N, n))
    for i in range(N):
        for k in range(n):
            D[i, k] = Y[i, k] - ym[k]
    P = np.zeros((n, n))
    for i in range(N):
        w = Wc[i]
        for a in range(n):
            wa = w * D[i, a]
            for b in range(n):
                P[a, b] += wa * D[i, b]
    for a in range(n):
        for b in range(a + 1, n):
            s = 0.5 * (P[a, b] + P[b, a])
            P[a, b] = s
            P[b, a] = s
    return P


@njit
def ukf_gain(
    Sz: np.ndarray, Pxz: np.ndarray, z: np.ndarray, zm: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(P_zz, K, ν, NIS) with P_zz = S_z S_zᵀ, K = P_xz P_zz⁻¹ by two triangular solves
    (Van der Merwe & Wan 2001, eq. 27), ν = wrap(z − ẑ) and NIS = |S_z⁻¹ ν|²; ``Sz``
    lower-triangular with a positive diagonal."""
    m = Sz.shape[0]
    n = Pxz.shape[0]
    nu = np.empty(m)
    for k in range(m):
        nu[k] = _wrap(z[k] - zm[k])
    yv, _ = solve_lower_into(Sz, nu.reshape(m, 1), False)
    nis = 0.0
    for k in range(m):
        nis += yv[k, 0] * yv[k, 0]
    Pzz = Sz @ Sz.T
    Y, _ = solve_lower_into(Sz, np.ascontiguousarray(Pxz.T), False)
    X, _ = solve_lower_into(Sz, Y, True)
    K = np.empty((n, m))
    for a in range(n):
        for b in range(m):
            K[a, b] = X[b, a]
    return Pzz, K, nu, nis
