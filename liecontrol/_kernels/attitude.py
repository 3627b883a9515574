"""Attitude-tracking pieces shared by the controller kernels: the relative rotation, the desired
rates carried into the body frame, the large-angle error and the tracking feed-forward."""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .so3 import log9, matvec3


@njit(inline="always")
def body_from_desired(R: np.ndarray, R_d: np.ndarray) -> tuple[float, ...]:
    """Entries (row-major) of T = Rᵀ R_d = R̃ᵀ, with R̃ = R_dᵀ R the attitude error: T maps
    desired-frame vectors into the body frame; R̃'s entry (i, j) is T's (j, i)."""
    return (
        R[0, 0] * R_d[0, 0] + R[1, 0] * R_d[1, 0] + R[2, 0] * R_d[2, 0],
        R[0, 0] * R_d[0, 1] + R[1, 0] * R_d[1, 1] + R[2, 0] * R_d[2, 1],
        R[0, 0] * R_d[0, 2] + R[1, 0] * R_d[1, 2] + R[2, 0] * R_d[2, 2],
        R[0, 1] * R_d[0, 0] + R[1, 1] * R_d[1, 0] + R[2, 1] * R_d[2, 0],
        R[0, 1] * R_d[0, 1] + R[1, 1] * R_d[1, 1] + R[2, 1] * R_d[2, 1],
        R[0, 1] * R_d[0, 2] + R[1, 1] * R_d[1, 2] + R[2, 1] * R_d[2, 2],
        R[0, 2] * R_d[0, 0] + R[1, 2] * R_d[1, 0] + R[2, 2] * R_d[2, 0],
        R[0, 2] * R_d[0, 1] + R[1, 2] * R_d[1, 1] + R[2, 2] * R_d[2, 1],
        R[0, 2] * R_d[0, 2] + R[1, 2] * R_d[1, 2] + R[2, 2] * R_d[2, 2],
    )


@njit(inline="always")
def error_log(t: tuple) -> tuple[float, float, float]:
    """log(R̃)^∨ of the attitude error, given T = R̃ᵀ (:func:`body_from_desired`)."""
    return log9(t[0], t[3], t[6], t[1], t[4], t[7], t[2], t[5], t[8])


@njit(inline="always")
def half_sinc(theta: float) -> float:
    """sin(θ/2)/θ, with its Taylor polynomial below 1e-3."""
    if theta < 1e-3:
        t2 = theta * theta
        return 0.5 * (1.0 - t2 / 24.0 * (1.0 - t2 / 80.0))
    return math.sin(0.5 * theta) / theta


@njit(inline="always")
def large_angle_error(t: tuple) -> tuple[float, float, float, float, float]:
    """Lee's large-angle error of R̃ given T = R̃ᵀ: ``(Ψ, θ, e_R)`` with Ψ = 2 − 2 cos(θ/2)
    (as 4 sin²(θ/4) below π/2: no cancellation) and e_R = (sin(θ/2)/θ) log(R̃)^∨."""
    p0, p1, p2 = error_log(t)
    th = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    if th < 0.5 * math.pi:
        sq4 = math.sin(0.25 * th)
        psi = 4.0 * sq4 * sq4
    else:
        psi = 2.0 - 2.0 * math.cos(0.5 * th)
    hs = half_sinc(th)
    return psi, th, hs * p0, hs * p1, hs * p2


@njit(inline="always")
def large_angle_error_algebraic(t: tuple) -> tuple[float, float, float, float]:
    """``(Ψ, e_R)`` of :func:`large_angle_error` without the angle, by square roots alone while
    cos θ ≥ 0 (θ ≤ π/2): with v = (R̃ − R̃ᵀ)^∨ (‖v‖ = 2 sin θ) and 1 + tr R̃ = 4 cos²(θ/2),

        e_R = (sin(θ/2)/θ) log(R̃)^∨ = sin(θ/2)/(2 sin θ) v = v / (2 √(1 + tr R̃)),
        Ψ = 2 − 2 cos(θ/2) = 2 ‖e_R‖² / (1 + cos(θ/2)),   cos(θ/2) = ½ √(1 + tr R̃)

    (‖e_R‖ = sin(θ/2); the last form has no cancellation at small θ). Equal to the angle route
    to a few ulp (no atan2, sin or cos: one square root and one division). For θ > π/2, where
    1 + tr R̃ → 0 at π cancels, and for a non-finite R̃, :func:`large_angle_error` itself."""
    # R̃'s entry (i, j) is T's (j, i): T = t (row-major)
    tr = t[0] + t[4] + t[8]
    if tr >= 1.0:  # cos θ = (tr − 1)/2 ≥ 0
        q = math.sqrt(1.0 + tr)
        k = 0.5 / q
        e0 = (t[5] - t[7]) * k
        e1 = (t[6] - t[2]) * k
        e2 = (t[1] - t[3]) * k
        psi = 2.0 * (e0 * e0 + e1 * e1 + e2 * e2) / (1.0 + 0.5 * q)
        return psi, e0, e1, e2
    psi, _, e0, e1, e2 = large_angle_error(t)
    return psi, e0, e1, e2


@njit(inline="always")
def desired_rates_in_body(
    t: tuple, w_d: np.ndarray, dw_d: np.ndarray
) -> tuple[float, float, float, float, float, float]:
    """``(RᵀR_d ω_d, RᵀR_d ω̇_d)``: the desired rate and acceleration in body axes."""
    a0, a1, a2 = w_d[0], w_d[1], w_d[2]
    b0, b1, b2 = dw_d[0], dw_d[1], dw_d[2]
    return (
        t[0] * a0 + t[1] * a1 + t[2] * a2,
        t[3] * a0 + t[4] * a1 + t[5] * a2,
        t[6] * a0 + t[7] * a1 + t[8] * a2,
        t[0] * b0 + t[1] * b1 + t[2] * b2,
        t[3] * b0 + t[4] * b1 + t[5] * b2,
        t[6] * b0 + t[7] * b1 + t[8] * b2,
    )


@njit(inline="always")
def tracking_feedforward(
    J: np.ndarray, x0: float, x1: float, x2: float, v0: float, v1: float, v2: float,
    wb0: float, wb1: float, wb2: float, db0: float, db1: float, db2: float,
) -> tuple[float, float, float]:  # fmt: skip
    """v × Jω − J(ω × ω_r − ω̇_r) with ω_r, ω̇_r the desired rate and acceleration in body axes;
    v = ω gives the geometric PD's exact-cancellation feed-forward."""
    j0, j1, j2 = matvec3(J, x0, x1, x2)
    c0 = x1 * wb2 - x2 * wb1 - db0
    c1 = x2 * wb0 - x0 * wb2 - db1
    c2 = x0 * wb1 - x1 * wb0 - db2
    k0, k1, k2 = matvec3(J, c0, c1, c2)
    return (v1 * j2 - v2 * j1) - k0, (v2 * j0 - v0 * j2) - k1, (v0 * j1 - v1 * j0) - k2
