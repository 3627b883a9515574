"""Kernel of the geometric PD family on SO(3) (:class:`liecontrol.control.GeometricPD`)::

    M = −K_R e_R − K_Ω e_Ω + Ω × JΩ − J (Ω × RᵀR_d Ω_d − RᵀR_d Ω̇_d),   e_Ω = Ω − RᵀR_d Ω_d,

with (Ψ, e_R) the large-angle (Lee 2012), logarithmic (Bullo & Murray 1995) or trace
(Koditschek 1989) error function of R̃ = R_dᵀR (definitions in :mod:`liecontrol.errors`).
"""

from __future__ import annotations

import numpy as np

from .._jit import njit
from .attitude import (
    body_from_desired,
    desired_rates_in_body,
    error_log,
    large_angle_error_algebraic,
    tracking_feedforward,
)
from .so3 import matvec3

#: error-function codes of the kernel
ERROR_CODES = {"large_angle": 0, "log": 1, "trace": 2}


@njit(inline="always")
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
    t = body_from_desired(R, R_d)
    if error == 2:
        # (G R̃)_ij = Σ_m G_im R̃_mj with R̃_mj = T_jm; only the diagonal and the skew part used
        g00 = G[0, 0] * t[0] + G[0, 1] * t[1] + G[0, 2] * t[2]
        g11 = G[1, 0] * t[3] + G[1, 1] * t[4] + G[1, 2] * t[5]
        g22 = G[2, 0] * t[6] + G[2, 1] * t[7] + G[2, 2] * t[8]
        g01 = G[0, 0] * t[3] + G[0, 1] * t[4] + G[0, 2] * t[5]
        g02 = G[0, 0] * t[6] + G[0, 1] * t[7] + G[0, 2] * t[8]
        g10 = G[1, 0] * t[0] + G[1, 1] * t[1] + G[1, 2] * t[2]
        g12 = G[1, 0] * t[6] + G[1, 1] * t[7] + G[1, 2] * t[8]
        g20 = G[2, 0] * t[0] + G[2, 1] * t[1] + G[2, 2] * t[2]
        g21 = G[2, 0] * t[3] + G[2, 1] * t[4] + G[2, 2] * t[5]
        psi = (G[0, 0] + G[1, 1] + G[2, 2]) - (g00 + g11 + g22)
        e0 = 0.5 * (g21 - g12)
        e1 = 0.5 * (g02 - g20)
        e2 = 0.5 * (g10 - g01)
    elif error == 1:
        e0, e1, e2 = error_log(t)
        psi = 0.5 * (e0 * e0 + e1 * e1 + e2 * e2)
    else:
        psi, e0, e1, e2 = large_angle_error_algebraic(t)
    wb0, wb1, wb2, db0, db1, db2 = desired_rates_in_body(t, w_d, dw_d)
    x0, x1, x2 = w[0], w[1], w[2]
    E0, E1, E2 = x0 - wb0, x1 - wb1, x2 - wb2
    f0, f1, f2 = tracking_feedforward(J, x0, x1, x2, x0, x1, x2, wb0, wb1, wb2, db0, db1, db2)
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


@njit
def geometric_pd_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, M_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """:func:`geometric_pd_one` as a law of the compiled-kernel seam
    (:mod:`liecontrol.control.kernel`): ``params (37,) = (error code, J, K_R, K_Ω, G)``, the
    3×3 matrices row-major; stateless; diagnostics ``(7,)``."""
    m = params[1:37].reshape((4, 3, 3))  # one reshape, four views: cheaper than four
    geometric_pd_one(int(params[0]), m[0], m[1], m[2], m[3], R, w, R_d, w_d, dw_d, M_out, diag_out)
