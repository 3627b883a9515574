"""Compiled scalar kernels of the estimation filters' hot path (numba through
:func:`liecontrol._jit.njit`, plain Python without it).

For a 7-state filter numpy's per-call overhead (~1 µs per operation on arrays of 15 × 7
numbers) is most of the cost of a predict+update: the RK4 step of the gyroless model alone is
~80 array operations. These kernels do the same arithmetic in one call each. They never
validate: callers pass finite float64 arrays of the right shapes and check the returned flags.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .._kernels.filters import (
    _sigma_rows,
    _weighted_outer_sym,
    cholesky_sym,
    euler_mean_residuals,
)

# kernels shared with the simulator's compiled filters (liecontrol._kernels), re-exported
from .._kernels.filters import rpy_from_q as rpy_from_q  # the models' Euler angles
from .._kernels.filters import solve_lower_into as solve_lower_into
from .._kernels.filters import ukf_gain as ukf_gain


@njit
def _rhs_into(
    y: np.ndarray, torque: np.ndarray, J: np.ndarray, Jinv: np.ndarray, out: np.ndarray
) -> None:
    """ẋ = (½ q ⊗ (0, ω), J⁻¹(N − ω × Jω)) of one 7-state (the gyroless model's ``rhs``)."""
    qw, qx, qy, qz = y[0], y[1], y[2], y[3]
    wx, wy, wz = y[4], y[5], y[6]
    out[0] = -0.5 * (qx * wx + qy * wy + qz * wz)
    out[1] = 0.5 * (qw * wx + qy * wz - qz * wy)
    out[2] = 0.5 * (qw * wy - qx * wz + qz * wx)
    out[3] = 0.5 * (qw * wz + qx * wy - qy * wx)
    j0 = J[0, 0] * wx + J[0, 1] * wy + J[0, 2] * wz
    j1 = J[1, 0] * wx + J[1, 1] * wy + J[1, 2] * wz
    j2 = J[2, 0] * wx + J[2, 1] * wy + J[2, 2] * wz
    r0 = torque[0] - (wy * j2 - wz * j1)
    r1 = torque[1] - (wz * j0 - wx * j2)
    r2 = torque[2] - (wx * j1 - wy * j0)
    out[4] = Jinv[0, 0] * r0 + Jinv[0, 1] * r1 + Jinv[0, 2] * r2
    out[5] = Jinv[1, 0] * r0 + Jinv[1, 1] * r1 + Jinv[1, 2] * r2
    out[6] = Jinv[2, 0] * r0 + Jinv[2, 1] * r1 + Jinv[2, 2] * r2


@njit
def gyroless_rk4(
    X: np.ndarray, torque: np.ndarray, dt: float, J: np.ndarray, Jinv: np.ndarray
) -> tuple[np.ndarray, bool]:
    """One classical RK4 step of every row of ``X (N, 7)`` with the torque held, then the
    quaternion normalised; returns (Y, ok) with ok False when a quaternion norm is < 1e-12 or
    not finite (the model then raises its usual message)."""
    N = X.shape[0]
    Y = np.empty((N, 7))
    k1 = np.empty(7)
    k2 = np.empty(7)
    k3 = np.empty(7)
    k4 = np.empty(7)
    tmp = np.empty(7)
    h2 = 0.5 * dt
    h6 = dt / 6.0
    ok = True
    for i in range(N):
        y = X[i]
        _rhs_into(y, torque, J, Jinv, k1)
        for j in range(7):
            tmp[j] = y[j] + h2 * k1[j]
        _rhs_into(tmp, torque, J, Jinv, k2)
        for j in range(7):
            tmp[j] = y[j] + h2 * k2[j]
        _rhs_into(tmp, torque, J, Jinv, k3)
        for j in range(7):
            tmp[j] = y[j] + dt * k3[j]
        _rhs_into(tmp, torque, J, Jinv, k4)
        for j in range(7):
            Y[i, j] = y[j] + h6 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j])
        nrm = math.sqrt(Y[i, 0] ** 2 + Y[i, 1] ** 2 + Y[i, 2] ** 2 + Y[i, 3] ** 2)
        if not (nrm >= 1e-12 and nrm < math.inf):
            ok = False
        else:
            for j in range(4):
                Y[i, j] /= nrm
    return Y, ok


@njit
def ukf_predict_gyroless(
    x: np.ndarray,
    S: np.ndarray,
    torque: np.ndarray,
    dt: float,
    J: np.ndarray,
    Jinv: np.ndarray,
    Wm: np.ndarray,
    Wc: np.ndarray,
    gamma: float,
    qdiag: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """The additive UKF's time update on the gyroless 7-state model, fused: sigma points of
    (x, S Sᵀ), one RK4 step each (:func:`gyroless_rk4`), x⁻ = normalise(Σ Wᵐ Y),
    P_f = sym(Σ Wᶜ (Y − x⁻)(Y − x⁻)ᵀ); returns (x⁻, P_f, P_f + diag(qdiag), ok), ok False when
    a quaternion norm fails."""
    X = _sigma_rows(x, S, gamma)
    Y, ok = gyroless_rk4(X, torque, dt, J, Jinv)
    N = Y.shape[0]
    xm = np.zeros(7)
    for i in range(N):
        for k in range(7):
            xm[k] += Wm[i] * Y[i, k]
    nrm = math.sqrt(xm[0] ** 2 + xm[1] ** 2 + xm[2] ** 2 + xm[3] ** 2)
    if not (nrm >= 1e-12 and nrm < math.inf):
        ok = False
    else:
        for k in range(4):
            xm[k] /= nrm
    Pf = _weighted_outer_sym(Y, xm, Wc)
    P = Pf.copy()
    for k in range(7):
        P[k, k] += qdiag[k]
    return xm, Pf, P, ok


@njit
def ukf_measure_euler(
    x: np.ndarray, S: np.ndarray, Wm: np.ndarray, Wc: np.ndarray, gamma: float, R: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The additive UKF's measurement statistics for the Euler-angle measurement, fused: sigma
    points of (x, S Sᵀ), Z = rpy(q), ẑ = wrap(Z₀ + Σ Wᵐ wrap(Z − Z₀)), ΔZ = wrap(Z − ẑ),
    P_zz = sym(Σ Wᶜ ΔZ ΔZᵀ + R), P_xz = Σ Wᶜ (X − x) ΔZᵀ. Returns (ẑ, P_zz, P_xz)."""
    X = _sigma_rows(x, S, gamma)
    Z = rpy_from_q(X)
    N = X.shape[0]
    n = x.shape[0]
    zm, dZ = euler_mean_residuals(Z, Wm)
    Pzz = np.zeros((3, 3))
    Pxz = np.zeros((n, 3))
    for i in range(N):
        w = Wc[i]
        for a in range(3):
            wa = w * dZ[i, a]
            for b in range(3):
                Pzz[a, b] += wa * dZ[i, b]
        for a in range(n):
            wa = w * (X[i, a] - x[a])
            for b in range(3):
                Pxz[a, b] += wa * dZ[i, b]
    for a in range(3):
        for b in range(3):
            Pzz[a, b] += R[a, b]
    for a in range(3):
        for b in range(a + 1, 3):
            s = 0.5 * (Pzz[a, b] + Pzz[b, a])
            Pzz[a, b] = s
            Pzz[b, a] = s
    return zm, Pzz, Pxz


@njit
def cholesky_outer(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """(L, L Lᵀ, ok): :func:`cholesky_sym` of P and the covariance rebuilt from it."""
    L, ok = cholesky_sym(P)
    return L, L @ L.T, ok


@njit
def ukf_correct(
    x: np.ndarray, K: np.ndarray, nu: np.ndarray, P: np.ndarray, Pzz: np.ndarray
) -> tuple[np.ndarray, np.ndarray, bool]:
    """(x⁺, P⁺, ok): x⁺ = x + K ν with its quaternion part normalised (ok False when that norm
    is < 1e-12 or not finite) and P⁺ = sym(P − K P_zz Kᵀ)."""
    n = x.shape[0]
    xn = x + K @ nu
    nrm = math.sqrt(xn[0] ** 2 + xn[1] ** 2 + xn[2] ** 2 + xn[3] ** 2)
    ok = nrm >= 1e-12 and nrm < math.inf
    if ok:
        for k in range(4):
            xn[k] /= nrm
    Pn = P - K @ Pzz @ K.T
    for a in range(n):
        for b in range(a + 1, n):
            s = 0.5 * (Pn[a, b] + Pn[b, a])
            Pn[a, b] = s
            Pn[b, a] = s
    return xn, Pn, ok


@njit
def all_finite(a: np.ndarray, b: np.ndarray) -> bool:
    """True iff every entry of the 1-D arrays ``a`` and ``b`` is finite."""
    for v in a:
        if not math.isfinite(v):
            return False
    for v in b:
        if not math.isfinite(v):
            return False
    return True


@njit
def ukf_predict_gyroless_from_P(
    x: np.ndarray,
    P: np.ndarray,
    torque: np.ndarray,
    dt: float,
    J: np.ndarray,
    Jinv: np.ndarray,
    Wm: np.ndarray,
    Wc: np.ndarray,
    gamma: float,
    qdiag: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """:func:`cholesky_sym` of P then :func:`ukf_predict_gyroless` in one call; status 0 ok,
    1 the Cholesky factorisation failed (nothing computed: the caller repairs P), 2 a
    quaternion norm failed."""
    S, ok = cholesky_sym(P)
    if not ok:
        return x, P, P, 1
    xm, Pf, Pp, ok = ukf_predict_gyroless(x, S, torque, dt, J, Jinv, Wm, Wc, gamma, qdiag)
    return xm, Pf, Pp, 0 if ok else 2


@njit
def ukf_update_euler(
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    Wm: np.ndarray,
    Wc: np.ndarray,
    gamma: float,
    R: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray, int]:
    """:func:`cholesky_sym` of P, :func:`ukf_measure_euler`, :func:`cholesky_sym` of P_zz and
    :func:`ukf_gain` in one call: (P_zz, K, ν, NIS, S_z, status), status 0 ok, 1 the Cholesky
    of P failed, 2 that of P_zz failed (the caller then takes the step-by-step route, which
    repairs or raises)."""
    S, ok = cholesky_sym(P)
    if not ok:
        return P, P, z, 0.0, P, 1
    zm, Pzz, Pxz = ukf_measure_euler(x, S, Wm, Wc, gamma, R)
    Sz, ok = cholesky_sym(Pzz)
    if not ok:
        return P, P, z, 0.0, P, 2
    Pzz2, K, nu, nis = ukf_gain(Sz, Pxz, z, zm)
    return Pzz2, K, nu, nis, Sz, 0


@njit
def ukf_correct_outer(
    x: np.ndarray, K: np.ndarray, nu: np.ndarray, P: np.ndarray, Pzz: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """:func:`ukf_correct` then :func:`cholesky_outer` of the new covariance: (x⁺, L Lᵀ, P⁺,
    status), status 0 ok, 1 the quaternion norm failed, 2 the Cholesky of P⁺ failed (the
    caller repairs P⁺)."""
    xn, Pn, ok = ukf_correct(x, K, nu, P, Pzz)
    if not ok:
        return xn, Pn, Pn, 1
    L, ok = cholesky_sym(Pn)
    if not ok:
        return xn, Pn, Pn, 2
    return xn, L @ L.T, Pn, 0


@njit
def cholupdate_lower(L: np.ndarray, V: np.ndarray, sg: float) -> tuple[np.ndarray, float]:
    """Rank-1 updates (``sg`` = +1) or downdates (−1) of the lower factor ``L (n, n)`` by the
    columns of ``V (n, k)`` in sequence (the unbatched loop of ``cholesky.cholupdate``, same
    operations). Returns (L', worst): worst is +inf on success, else the first failing pivot
    r² (≤ 0); the columns after a failure are not applied."""
    n = L.shape[0]
    Lo = L.copy()
    worst = math.inf
    for j in range(V.shape[1]):
        x = V[:, j].copy()
        for k in range(n):
            lkk = Lo[k, k]
            xk = x[k]
            r2 = lkk * lkk + sg * xk * xk
            if not r2 > 0.0:
                if r2 < worst:  # Python's min(worst, r2): a NaN r² leaves worst unchanged
                    worst = r2
                break
            r = math.sqrt(r2)
            c = r / lkk
            s = xk / lkk
            Lo[k, k] = r
            for i in range(k + 1, n):
                li = (Lo[i, k] + sg * s * x[i]) / c
                x[i] = c * x[i] - s * li
                Lo[i, k] = li
        if worst <= 0.0:
            break
    return Lo, worst


@njit
def ukf_update_correct(
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    Wm: np.ndarray,
    Wc: np.ndarray,
    gamma: float,
    R: np.ndarray,
    gate: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, np.ndarray, int]:
    """The whole additive-UKF measurement update on the Euler-angle measurement:
    :func:`ukf_update_euler`, then — unless NIS > ``gate`` — :func:`ukf_correct_outer`.
    Returns (x⁺, P⁺ (= L Lᵀ), P⁺ before its Cholesky, P_zz, ν, NIS, S_z, status) with status
    0 ok; 1 / 2 the Cholesky of P / P_zz failed (nothing computed); 3 gated (NIS > gate,
    state untouched); 4 the quaternion norm failed; 5 the Cholesky of P⁺ failed."""
    Pzz, K, nu, nis, Sz, status = ukf_update_euler(x, P, z, Wm, Wc, gamma, R)
    if status != 0:
        return x, P, P, Pzz, nu, nis, Sz, status
    if nis > gate:
        return x, P, P, Pzz, nu, nis, Sz, 3
    xn, PP, Pn, st = ukf_correct_outer(x, K, nu, P, Pzz)
    return xn, PP, Pn, Pzz, nu, nis, Sz, 0 if st == 0 else st + 3
