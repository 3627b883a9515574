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
from .attitude import (
    body_from_desired,
    desired_rates_in_body,
    large_angle_error,
    tracking_feedforward,
)
from .so3 import matvec3

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
    t = body_from_desired(R, R_d)
    psi, th, e0, e1, e2 = large_angle_error(t)
    wb0, wb1, wb2, db0, db1, db2 = desired_rates_in_body(t, w_d, dw_d)
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
    f0, f1, f2 = tracking_feedforward(J, x0, x1, x2, x0, x1, x2, wb0, wb1, wb2, db0, db1, db2)
    u0, u1, u2 = matvec3(J, v0, v1, v2)
    M_out[0] = f0 + u0
    M_out[1] = f1 + u1
    M_out[2] = f2 + u2
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


@njit
def finite_time_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, M_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """:func:`finite_time_one` as a law of the compiled-kernel seam
    (:mod:`liecontrol.control.kernel`): ``params (23,) = (J row-major, the 14 values of
    PARAM_NAMES)``; stateless; diagnostics ``(11,)``."""
    J = params[0:9].reshape((3, 3))
    finite_time_one(J, params[9:23], R, w, R_d, w_d, dw_d, M_out, diag_out)
