"""SO(3) kernels on one element: exp (Rodrigues), log, dexp⁻¹ truncated for RKMK4, and the
matrix helpers the other kernels share. Formulas as in :mod:`liecontrol.lie.so3`."""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit

#: θ/2 floor in exp (avoids 0/0 at θ = 0; sin(x)/x is exactly 1 for tiny x)
_TINY = 1e-300
#: below this cos θ, log takes the axis from the symmetric part (as liecontrol.lie.so3.log)
LOG_SYMMETRIC_COS = -0.999


# fdlibm's minimax coefficients of __kernel_sin and __kernel_cos on |r| ≤ π/4 (relative error of
# the polynomials below 2⁻⁵⁸): sin r = r (1 + z (S1 + … + z⁵ S6)), cos r = 1 − z/2 + z² (C1 + …
# + z⁵ C6), z = r²; both even in r, so the half-angle sinc and cosine of exp need no √z
_S1 = -1.66666666666666324348e-01
_S2 = 8.33333333332248946124e-03
_S3 = -1.98412698298579493134e-04
_S4 = 2.75573137070700676789e-06
_S5 = -2.50507602534068634195e-08
_S6 = 1.58969099521155010221e-10
_C1 = 4.16666666666666019037e-02
_C2 = -1.38888888888741095749e-03
_C3 = 2.48015872894767294178e-05
_C4 = -2.75573143513906633035e-07
_C5 = 2.08757232129817482790e-09
_C6 = -1.13596475577881948265e-11
#: θ² up to which exp9 evaluates sin(θ/2)/(θ/2) and cos(θ/2) by the polynomials: θ ≤ π/2
EXP_POLY_THETA2 = (0.5 * math.pi) ** 2


@njit(inline="always")
def sinc_cos_of_square(z: float) -> tuple[float, float]:
    """``(sin r / r, cos r)`` from ``z = r²`` for ``0 ≤ z ≤ (π/4)²``: fdlibm's kernels (above),
    cos in its compensated form w + ((1 − w) − z/2 + z² C(z)), w = 1 − z/2, each within 1 ulp.
    Only additions and multiplications: no square root, no libm call, exactly (1, 1) at z = 0."""
    sinc = 1.0 + z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    hz = 0.5 * z
    w = 1.0 - hz
    pc = _C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6))))
    return sinc, w + (((1.0 - w) - hz) + (z * z) * pc)


@njit(inline="always")
def exp9(w0: float, w1: float, w2: float) -> tuple[float, ...]:
    """Entries (row-major) of exp(w^), Rodrigues in the half-angle form
    R = I + a w^ + b w^², a = sin θ/θ = q cos(θ/2), b = (1 − cos θ)/θ² = ½ q² with
    q = sin(θ/2)/(θ/2), accurate for every θ (no cancellation near 0). For θ ≤ π/2 (an
    integration step's increment, always) q and cos(θ/2) are even polynomials in (θ/2)² = θ²/4
    (:func:`sinc_cos_of_square`): no square root, sine or cosine on the step's critical path;
    beyond, libm's sin and cos of θ/2. Non-finite w gives NaN entries."""
    a2 = w0 * w0 + w1 * w1 + w2 * w2
    if a2 <= EXP_POLY_THETA2:
        q, ch = sinc_cos_of_square(0.25 * a2)
    else:
        if not a2 < math.inf:
            n = math.nan
            return n, n, n, n, n, n, n, n, n
        half = max(0.5 * math.sqrt(a2), _TINY)
        q = math.sin(half) / half
        ch = math.cos(half)
    a = q * ch
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
    return (
        c + bx * w0, bxy - az, bxz + ay,
        bxy + az, c + by * w1, byz - ax,
        bxz - ay, byz + ax, c + b * w2 * w2,
    )  # fmt: skip


@njit
def exp_into(w0: float, w1: float, w2: float, out: np.ndarray) -> None:
    """``out (3, 3) = exp(w^)`` (:func:`exp9`)."""
    e = exp9(w0, w1, w2)
    for i in range(3):
        for j in range(3):
            out[i, j] = e[3 * i + j]


@njit(inline="always")
def right_multiply_exp_into(
    R: np.ndarray, w0: float, w1: float, w2: float, out: np.ndarray
) -> None:
    """``out = R exp(w^)`` (out must not alias R)."""
    e = exp9(w0, w1, w2)
    for i in range(3):
        r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
        out[i, 0] = r0 * e[0] + r1 * e[3] + r2 * e[6]
        out[i, 1] = r0 * e[1] + r1 * e[4] + r2 * e[7]
        out[i, 2] = r0 * e[2] + r1 * e[5] + r2 * e[8]


@njit
def log_of(R: np.ndarray) -> tuple[float, float, float]:
    """Rotation vector of one rotation ``R (3, 3)``; see :func:`log9`."""
    return log9(R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2])


@njit(inline="always")
def log9(
    m00: float, m01: float, m02: float, m10: float, m11: float, m12: float,
    m20: float, m21: float, m22: float,
) -> tuple[float, float, float]:  # fmt: skip
    """Rotation vector (θ ∈ [0, π]) of the rotation with entries ``mij``: θ/(2 sin θ) (R − Rᵀ)^∨
    with θ = atan2(sin θ, cos θ) for cos θ ≥ −0.999; nearer π the axis from the symmetric part,
    (R + Rᵀ)/2 − cos θ I = (1 − cos θ) n nᵀ (its column with the largest diagonal entry), the
    sign from (R − Rᵀ)^∨."""
    v0 = m21 - m12
    v1 = m02 - m20
    v2 = m10 - m01
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2) * 0.5
    c = (m00 + m11 + m22 - 1.0) * 0.5
    theta = math.atan2(s, c)
    if c >= LOG_SYMMETRIC_COS:
        k = 0.5 if s == 0.0 else theta / (s + s)
        return v0 * k, v1 * k, v2 * k
    d0 = m00 - c
    d1 = m11 - c
    d2 = m22 - c
    if d0 >= d1 and d0 >= d2:
        c0, c1, c2 = d0, 0.5 * (m10 + m01), 0.5 * (m20 + m02)
    elif d1 >= d2:
        c0, c1, c2 = 0.5 * (m01 + m10), d1, 0.5 * (m21 + m12)
    else:
        c0, c1, c2 = 0.5 * (m02 + m20), 0.5 * (m12 + m21), d2
    norm = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    sign = -1.0 if (c0 * v0 + c1 * v1 + c2 * v2) < 0.0 else 1.0
    f = sign * theta / norm
    return c0 * f, c1 * f, c2 * f


@njit(inline="always")
def dexpinv_rkmk4(
    t0: float, t1: float, t2: float, w0: float, w1: float, w2: float
) -> tuple[float, float, float]:
    """θ̇ of R exp(θ̂) for the body rate w, truncated after the θ² term: w + ½ θ × w +
    (1/12) θ × (θ × w) — the right-trivialised dexp⁻¹ (dexp⁻¹ at −θ in the left-trivialised
    convention w − ½[θ, w] + (1/12)[θ, [θ, w]]), enough for a fourth-order RKMK step (Iserles et
    al., Acta Numerica 2000)."""
    tw = (t0 * w0 + t1 * w1 + t2 * w2) / 12.0
    c = 1.0 - (t0 * t0 + t1 * t1 + t2 * t2) / 12.0
    return (
        c * w0 + 0.5 * (t1 * w2 - t2 * w1) + t0 * tw,
        c * w1 + 0.5 * (t2 * w0 - t0 * w2) + t1 * tw,
        c * w2 + 0.5 * (t0 * w1 - t1 * w0) + t2 * tw,
    )


@njit(inline="always")
def matvec3(A: np.ndarray, x0: float, x1: float, x2: float) -> tuple[float, float, float]:
    """``A x`` for a 3×3 ``A``."""
    return (
        A[0, 0] * x0 + A[0, 1] * x1 + A[0, 2] * x2,
        A[1, 0] * x0 + A[1, 1] * x1 + A[1, 2] * x2,
        A[2, 0] * x0 + A[2, 1] * x1 + A[2, 2] * x2,
    )
