"""Kernel of the terminal sliding mode on SO(3) (:class:`liecontrol.control.FiniteTimeSO3` and
:class:`~liecontrol.control.FixedTimeSO3`; equations, stability argument and sources in
:mod:`liecontrol.control.finite_time`)::

    M = Ω × JΩ − J(Ω × R̃ᵀΩ_d − R̃ᵀΩ̇_d) − J (∂α/∂e_R · E e_Ω + k_s(‖s‖) s),
    s = e_Ω + (k₁ + k₂ g_r(‖e_R‖)) e_R,   E = ½(q₀ I + e_R^),   q₀ = cos(θ/2),
    ∂α/∂e_R = (k₁ + k₂ g_r(x)) I + k₂ (g_r'(x)/x) e_R e_Rᵀ,
    k_s(y) = c₁ + c₂ g_ρ(y; ε_s) + c₃ y^(μ−1),

with the large-angle error ``(Ψ, e_R) = (2 − 2cos(θ/2), sin(θ/2) â)`` of ``R̃ = R_dᵀR`` computed
as in :mod:`liecontrol.errors` (the rotation vector of R̃, then the half-angle sinc), and
``g_p`` the power ``x^(p−1)`` continued below ``ε`` by its tangent line.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .geometric_pd import half_sinc
from .so3 import log9, matvec3

#: layout of the parameter vector the kernel reads (``FiniteTimeSO3._kernel_args``)
PARAM_NAMES = (
    "k1", "k2", "r", "eps", "c1", "c2", "rho", "eps_s", "c3", "mu",
    "a_r", "b_r", "a_s", "b_s",
)  # fmt: skip
#: columns of the diagnostics row: Ψ, θ, e_R (3), e_Ω (3), s (3)
N_DIAG = 11


@njit
def terminal_gain_one(x: float, p: float, eps: float, a: float, b: float) -> tuple[float, float]:
    """``(g_p(x), g_p'(x)/x)`` for one ``x ≥ 0``: ``x^(p−1)`` and ``(p−1)x^(p−3)`` for
    ``x ≥ ε``; below, the tangent line ``a + b x`` (``a = (2−p)ε^(p−1)``, ``b = (p−1)ε^(p−2)``)
    and ``b/x`` (0 at x = 0, where it multiplies e_R e_Rᵀ = 0)."""
    if x >= eps:
        g = x ** (p - 1.0)
        return g, (p - 1.0) * g / (x * x)  # x^(p−3) from the same power: one pow, not two
    if x > 0.0:
        return a + b * x, b / x
    return a + b * x, 0.0


@njit
def finite_time_one(
    J: np.ndarray,
    prm: np.ndarray,
    R: np.ndarray,
    w: np.ndarray,
    R_d: np.ndarray,
    w_d: np.ndarray,
    dw_d: np.ndarray,
    M_out: np.ndarray,
    diag_out: np.ndarray,
) -> None:
    """Torque ``M_out (3,)`` and diagnostics ``diag_out (11,) = (Ψ, θ, e_R, e_Ω, s)`` of one
    spacecraft; ``prm (14,)`` in the order of :data:`PARAM_NAMES`."""
    k1, k2, r, eps = prm[0], prm[1], prm[2], prm[3]
    c1, c2, rho, eps_s, c3, mu = prm[4], prm[5], prm[6], prm[7], prm[8], prm[9]
    a_r, b_r, a_s, b_s = prm[10], prm[11], prm[12], prm[13]
    # T = Rᵀ R_d = R̃ᵀ, entries tij
    t00 = R[0, 0] * R_d[0, 0] + R[1, 0] * R_d[1, 0] + R[2, 0] * R_d[2, 0]
    t01 = R[0, 0] * R_d[0, 1] + R[1, 0] * R_d[1, 1] + R[2, 0] * R_d[2, 1]
    t02 = R[0, 0] * R_d[0, 2] + R[1, 0] * R_d[1, 2] + R[2, 0] * R_d[2, 2]
    t10 = R[0, 1] * R_d[0, 0] + R[1, 1] * R_d[1, 0] + R[2, 1] * R_d[2, 0]
    t11 = R[0, 1] * R_d[0, 1] + R[1, 1] * R_d[1, 1] + R[2, 1] * R_d[2, 1]
    t12 = R[0, 1] * R_d[0, 2] + R[1, 1] * R_d[1, 2] + R[2, 1] * R_d[2, 2]
    t20 = R[0, 2] * R_d[0, 0] + R[1, 2] * R_d[1, 0] + R[2, 2] * R_d[2, 0]
    t21 = R[0, 2] * R_d[0, 1] + R[1, 2] * R_d[1, 1] + R[2, 2] * R_d[2, 1]
    t22 = R[0, 2] * R_d[0, 2] + R[1, 2] * R_d[1, 2] + R[2, 2] * R_d[2, 2]
    # large-angle error of R̃ = Tᵀ (entry (i, j) is tji): e_R = (sin(θ/2)/θ) log(R̃)^∨
    p0, p1, p2 = log9(t00, t10, t20, t01, t11, t21, t02, t12, t22)
    th = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    if th < 0.5 * math.pi:
        sq4 = math.sin(0.25 * th)
        psi = 4.0 * sq4 * sq4  # 4 sin²(θ/4): no cancellation at small θ
    else:
        psi = 2.0 - 2.0 * math.cos(0.5 * th)
    hs = half_sinc(th)
    e0, e1, e2 = hs * p0, hs * p1, hs * p2
    # desired rate and acceleration in the body frame
    a0, a1, a2 = w_d[0], w_d[1], w_d[2]
    wb0 = t00 * a0 + t01 * a1 + t02 * a2
    wb1 = t10 * a0 + t11 * a1 + t12 * a2
    wb2 = t20 * a0 + t21 * a1 + t22 * a2
    a0, a1, a2 = dw_d[0], dw_d[1], dw_d[2]
    db0 = t00 * a0 + t01 * a1 + t02 * a2
    db1 = t10 * a0 + t11 * a1 + t12 * a2
    db2 = t20 * a0 + t21 * a1 + t22 * a2
    x0, x1, x2 = w[0], w[1], w[2]
    E0, E1, E2 = x0 - wb0, x1 - wb1, x2 - wb2
    # surface s = e_Ω + (k₁ + k₂ g_r(‖e_R‖)) e_R
    xn = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    gx, gpx = terminal_gain_one(xn, r, eps, a_r, b_r)
    gain = k1 + k2 * gx
    s0, s1, s2 = E0 + gain * e0, E1 + gain * e1, E2 + gain * e2
    # ė_R = E e_Ω = ½(q₀ e_Ω + e_R × e_Ω), q₀ = cos(θ/2) = 1 − Ψ/2
    q0 = 1.0 - 0.5 * psi
    d0 = 0.5 * (q0 * E0 + (e1 * E2 - e2 * E1))
    d1 = 0.5 * (q0 * E1 + (e2 * E0 - e0 * E2))
    d2 = 0.5 * (q0 * E2 + (e0 * E1 - e1 * E0))
    proj = (k2 * gpx) * (e0 * d0 + e1 * d1 + e2 * d2)
    # reaching law k_s(‖s‖)
    y = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    gy, _ = terminal_gain_one(y, rho, eps_s, a_s, b_s)
    ks = c1 + c2 * gy
    if c3 > 0.0:
        ks += c3 * y ** (mu - 1.0)
    # desired closed-loop ω̇ − (feed-forward part): v = −∂α/∂e_R ė_R − k_s s
    v0 = -(gain * d0 + proj * e0) - ks * s0
    v1 = -(gain * d1 + proj * e1) - ks * s1
    v2 = -(gain * d2 + proj * e2) - ks * s2
    # M = ω × Jω − J(ω × ω_d,body − ω̇_d,body) + J v
    j0, j1, j2 = matvec3(J, x0, x1, x2)
    c0 = (x1 * wb2 - x2 * wb1) - db0
    c1_ = (x2 * wb0 - x0 * wb2) - db1
    c2_ = (x0 * wb1 - x1 * wb0) - db2
    k0, k1_, k2_ = matvec3(J, c0, c1_, c2_)
    u0, u1, u2 = matvec3(J, v0, v1, v2)
    M_out[0] = ((x1 * j2 - x2 * j1) - k0) + u0
    M_out[1] = ((x2 * j0 - x0 * j2) - k1_) + u1
    M_out[2] = ((x0 * j1 - x1 * j0) - k2_) + u2
    diag_out[0] = psi
    diag_out[1] = th
    diag_out[2] = e0
    diag_out[3] = e1
    diag_out[4] = e2
    diag_out[5] = E0
    diag_out[6] = E1
    diag_out[7] = E2
    diag_out[8] = s0
    diag_out[9] = s1
    diag_out[10] = s2


@njit
def finite_time_batch(
    J: np.ndarray,
    prm: np.ndarray,
    R: np.ndarray,
    w: np.ndarray,
    R_d: np.ndarray,
    w_d: np.ndarray,
    dw_d: np.ndarray,
    M_out: np.ndarray,
    diag_out: np.ndarray,
) -> None:
    """:func:`finite_time_one` over a batch: ``R (B, 3, 3)``, ``w (B, 3)``; the reference arrays
    are ``(B, ...)`` (one sample broadcast by the caller)."""
    for b in range(R.shape[0]):
        finite_time_one(J, prm, R[b], w[b], R_d[b], w_d[b], dw_d[b], M_out[b], diag_out[b])
