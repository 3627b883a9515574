"""SO(3) kernels on one element: exp (Rodrigues), log, dexp⁻¹ truncated for RKMK4, and the
matrix helpers the other kernels share. Formulas as in :mod:`liecontrol.lie.so3`."""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit

#: θ/2 floor in exp: sin(x)/x is exactly 1 below it in float64
_TINY = 1e-20
#: below this cos θ, log takes the axis from the symmetric part (as liecontrol.lie.so3.log)
LOG_SYMMETRIC_COS = -0.999


@njit
def exp_into(w0: float, w1: float, w2: float, out: np.ndarray) -> None:
    """``out (3, 3) = exp(w^)``, Rodrigues in the half-angle form
    R = I + a w^ + b w^², a = sin θ/θ, b = (1 − cos θ)/θ² = ½ (sin(θ/2)/(θ/2))²,
    accurate for every θ (no cancellation near 0). Non-finite w gives an all-NaN matrix."""
    a2 = w0 * w0 + w1 * w1 + w2 * w2
    if not a2 < math.inf:
        for i in range(3):
            for j in range(3):
                out[i, j] = math.nan
        return
    half = max(0.5 * math.sqrt(a2), _TINY)
    q = math.sin(half) / half
    a = q * math.cos(half)
    b = 0.5 * q * q
    c = 1.0 - b * a2
    bx = b * w0
    by = b * w1
    bxy = bx * w1
    bxz = bx * w2
    byz = by * w2
    ax = a * w0
    ay = a * w1
    az = a * w2
    out[0, 0] = c + bx * w0
    out[0, 1] = bxy - az
    out[0, 2] = bxz + ay
    out[1, 0] = bxy + az
    out[1, 1] = c + by * w1
    out[1, 2] = byz - ax
    out[2, 0] = bxz - ay
    out[2, 1] = byz + ax
    out[2, 2] = c + b * w2 * w2


@njit
def log_of(R: np.ndarray) -> tuple[float, float, float]:
    """Rotation vector of one rotation ``R (3, 3)`` (θ ∈ [0, π]): θ/(2 sin θ) (R − Rᵀ)^∨ with
    θ = atan2(sin θ, cos θ) for cos θ ≥ −0.999; nearer π the axis from the symmetric part,
    (R + Rᵀ)/2 − cos θ I = (1 − cos θ) n nᵀ (its column with the largest diagonal entry), the
    sign from (R − Rᵀ)^∨."""
    v0 = R[2, 1] - R[1, 2]
    v1 = R[0, 2] - R[2, 0]
    v2 = R[1, 0] - R[0, 1]
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2) * 0.5
    c = (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) * 0.5
    theta = math.atan2(s, c)
    if c >= LOG_SYMMETRIC_COS:
        k = 0.5 if s == 0.0 else theta / (s + s)
        return v0 * k, v1 * k, v2 * k
    d0 = R[0, 0] - c
    d1 = R[1, 1] - c
    d2 = R[2, 2] - c
    k = 0
    if d1 > d0:
        k = 1
    if d2 > (d1 if k == 1 else d0):
        k = 2
    c0 = 0.5 * (R[0, k] + R[k, 0])
    c1 = 0.5 * (R[1, k] + R[k, 1])
    c2 = 0.5 * (R[2, k] + R[k, 2])
    if k == 0:
        c0 = d0
    elif k == 1:
        c1 = d1
    else:
        c2 = d2
    norm = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    sign = -1.0 if (c0 * v0 + c1 * v1 + c2 * v2) < 0.0 else 1.0
    f = sign * theta / norm
    return c0 * f, c1 * f, c2 * f


@njit
def dexpinv_rkmk4(
    t0: float, t1: float, t2: float, w0: float, w1: float, w2: float
) -> tuple[float, float, float]:
    """dexp⁻¹_θ(w) truncated after the θ² term — w − ½[θ, w] + (1/12)[θ, [θ, w]], enough for a
    fourth-order RKMK step (Iserles et al., Acta Numerica 2000)."""
    tw = (t0 * w0 + t1 * w1 + t2 * w2) / 12.0
    c = 1.0 - (t0 * t0 + t1 * t1 + t2 * t2) / 12.0
    return (
        c * w0 + 0.5 * (t1 * w2 - t2 * w1) + t0 * tw,
        c * w1 + 0.5 * (t2 * w0 - t0 * w2) + t1 * tw,
        c * w2 + 0.5 * (t0 * w1 - t1 * w0) + t2 * tw,
    )


@njit
def matmul3_into(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:
    """``out = A B`` for 3×3 (out must not alias A or B)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit
def matvec3(A: np.ndarray, x0: float, x1: float, x2: float) -> tuple[float, float, float]:
    """``A x`` for a 3×3 ``A``."""
    return (
        A[0, 0] * x0 + A[0, 1] * x1 + A[0, 2] * x2,
        A[1, 0] * x0 + A[1, 1] * x1 + A[1, 2] * x2,
        A[2, 0] * x0 + A[2, 1] * x1 + A[2, 2] * x2,
    )
