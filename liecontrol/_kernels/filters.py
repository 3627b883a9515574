"""Compiled kernels shared by the attitude filters (:mod:`liecontrol.estimation`) and the
simulator's compiled estimator hook (:mod:`spacecraft._fused_sensors`): the ZYX Euler angles of
a quaternion, the Cholesky factor of a symmetric matrix and the angle wrap. Here, outside the
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
