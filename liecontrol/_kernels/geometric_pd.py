"""Kernel of the geometric PD family on SO(3) (:class:`liecontrol.control.GeometricPD`)::

    M = −K_R e_R − K_Ω e_Ω + Ω × JΩ − J (Ω × RᵀR_d Ω_d − RᵀR_d Ω̇_d),   e_Ω = Ω − RᵀR_d Ω_d,

with (Ψ, e_R) the large-angle (Lee 2012), logarithmic (Bullo & Murray 1995) or trace
(Koditschek 1989) error function of R̃ = R_dᵀR (definitions in :mod:`liecontrol.errors`).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .so3 import log9, matvec3

#: error-function codes of the kernel
ERROR_CODES = {"large_angle": 0, "log": 1, "trace": 2}


@njit
def half_sinc(theta: float) -> float:
    """sin(θ/2)/θ, with its Taylor polynomial below 1e-3."""
    if theta < 1e-3:
        t2 = theta * theta
        return 0.5 * (1.0 - t2 / 24.0 * (1.0 - t2 / 80.0))
    return math.sin(0.5 * theta) / theta


@njit
def geometric_pd_one(
    error: int,
    J: np.ndarray,
    kR: np.ndarray,
    kW: np.ndarray,
    G: np.ndarray,
    R: np.ndarray,
    w: np.ndarray,
    R_d: np.ndarray,
    w_d: np.ndarray,
    dw_d: np.ndarray,
    M_out: np.ndarray,
    diag_out: np.ndarray,
) -> None:
    """Torque ``M_out (3,)`` and diagnostics ``diag_out (7,) = (Ψ, e_R, e_Ω)`` of one spacecraft.
    ``J``, ``kR``, ``kW``, ``G`` are 3×3 (scalar gains as multiples of I)."""
    # T = Rᵀ R_d = R̃ᵀ, entries tij (scalars: no allocation on the hot path)
    t00 = R[0, 0] * R_d[0, 0] + R[1, 0] * R_d[1, 0] + R[2, 0] * R_d[2, 0]
    t01 = R[0, 0] * R_d[0, 1] + R[1, 0] * R_d[1, 1] + R[2, 0] * R_d[2, 1]
    t02 = R[0, 0] * R_d[0, 2] + R[1, 0] * R_d[1, 2] + R[2, 0] * R_d[2, 2]
    t10 = R[0, 1] * R_d[0, 0] + R[1, 1] * R_d[1, 0] + R[2, 1] * R_d[2, 0]
    t11 = R[0, 1] * R_d[0, 1] + R[1, 1] * R_d[1, 1] + R[2, 1] * R_d[2, 1]
    t12 = R[0, 1] * R_d[0, 2] + R[1, 1] * R_d[1, 2] + R[2, 1] * R_d[2, 2]
    t20 = R[0, 2] * R_d[0, 0] + R[1, 2] * R_d[1, 0] + R[2, 2] * R_d[2, 0]
    t21 = R[0, 2] * R_d[0, 1] + R[1, 2] * R_d[1, 1] + R[2, 2] * R_d[2, 1]
    t22 = R[0, 2] * R_d[0, 2] + R[1, 2] * R_d[1, 2] + R[2, 2] * R_d[2, 2]
    if error == 2:
        # (G R̃)_ij = Σ_m G_im R̃_mj with R̃_mj = T_jm; only the diagonal and the skew part used
        g00 = G[0, 0] * t00 + G[0, 1] * t01 + G[0, 2] * t02
        g11 = G[1, 0] * t10 + G[1, 1] * t11 + G[1, 2] * t12
        g22 = G[2, 0] * t20 + G[2, 1] * t21 + G[2, 2] * t22
        g01 = G[0, 0] * t10 + G[0, 1] * t11 + G[0, 2] * t12
        g02 = G[0, 0] * t20 + G[0, 1] * t21 + G[0, 2] * t22
        g10 = G[1, 0] * t00 + G[1, 1] * t01 + G[1, 2] * t02
        g12 = G[1, 0] * t20 + G[1, 1] * t21 + G[1, 2] * t22
        g20 = G[2, 0] * t00 + G[2, 1] * t01 + G[2, 2] * t02
        g21 = G[2, 0] * t10 + G[2, 1] * t11 + G[2, 2] * t12
        psi = (G[0, 0] + G[1, 1] + G[2, 2]) - (g00 + g11 + g22)
        e0 = 0.5 * (g21 - g12)
        e1 = 0.5 * (g02 - g20)
        e2 = 0.5 * (g10 - g01)
    else:
        # R̃ = Tᵀ: entry (i, j) is tji
        p0, p1, p2 = log9(t00, t10, t20, t01, t11, t21, t02, t12, t22)
        sq = p0 * p0 + p1 * p1 + p2 * p2
        if error == 1:
            psi = 0.5 * sq
            e0, e1, e2 = p0, p1, p2
        else:
            th = math.sqrt(sq)
            if th < 0.5 * math.pi:
                sq4 = math.sin(0.25 * th)
                psi = 4.0 * sq4 * sq4
            else:
                psi = 2.0 - 2.0 * math.cos(0.5 * th)
            hs = half_sinc(th)
            e0, e1, e2 = hs * p0, hs * p1, hs * p2
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
    j0, j1, j2 = matvec3(J, x0, x1, x2)
    c0 = x1 * wb2 - x2 * wb1 - db0
    c1 = x2 * wb0 - x0 * wb2 - db1
    c2 = x0 * wb1 - x1 * wb0 - db2
    k0, k1, k2 = matvec3(J, c0, c1, c2)
    f0 = (x1 * j2 - x2 * j1) - k0
    f1 = (x2 * j0 - x0 * j2) - k1
    f2 = (x0 * j1 - x1 * j0) - k2
    a0, a1, a2 = matvec3(kR, e0, e1, e2)
    b0, b1, b2 = matvec3(kW, E0, E1, E2)
    M_out[0] = f0 - a0 - b0
    M_out[1] = f1 - a1 - b1
    M_out[2] = f2 - a2 - b2
    diag_out[0] = psi
    diag_out[1] = e0
    diag_out[2] = e1
    diag_out[3] = e2
    diag_out[4] = E0
    diag_out[5] = E1
    diag_out[6] = E2


@njit
def geometric_pd_batch(
    error: int,
    J: np.ndarray,
    kR: np.ndarray,
    kW: np.ndarray,
    G: np.ndarray,
    R: np.ndarray,
    w: np.ndarray,
    R_d: np.ndarray,
    w_d: np.ndarray,
    dw_d: np.ndarray,
    M_out: np.ndarray,
    diag_out: np.ndarray,
) -> None:
    """:func:`geometric_pd_one` over a batch: ``R (B, 3, 3)``, ``w (B, 3)``; the reference
    arrays are ``(B, ...)`` (one sample broadcast by the caller)."""
    for b in range(R.shape[0]):
        geometric_pd_one(
            error, J, kR, kW, G, R[b], w[b], R_d[b], w_d[b], dw_d[b], M_out[b], diag_out[b]
        )
