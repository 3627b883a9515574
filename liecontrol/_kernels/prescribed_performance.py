"""Kernel of the prescribed-performance controller on SO(3)
(:class:`liecontrol.control.PrescribedPerformance`; the law, the funnel and the virtual rate
with their sources are in :mod:`liecontrol.control.prescribed_performance`, whose numpy
functions are the reference this kernel is tested against). One spacecraft per call: the
geometric PD's errors and feed-forward (unit gains), the funnel ``ρ(τ)``, the virtual rate
``α``, ``α̇`` and ``Eᵀw``, and ``M = ff + J(α̇ − k₂ s − k_c ρ² Eᵀw)``, ``s = e_Ω − α``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .geometric_pd import geometric_pd_one
from .so3 import matvec3

#: width of the state row: has ρ₀, ρ₀, funnel violations so far
N_STATE = 3
#: width of the diagnostics row: Ψ, e_R (3), e_Ω (3), ε (3), α (3), s (3), ρ, violations,
#: edge saturated
N_DIAG = 19


@njit
def ppc_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, M_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """A law of the compiled-kernel seam (:mod:`liecontrol.control.kernel`). ``params (47,)``:
    the unit-gain geometric PD's 37 (large-angle error), then ρ_∞, l, ρ₀ (< 0: from the first
    error), margin, k₁, k₂, k_c, q_min, z_max and the funnel's start t₀; ``state``
    and ``diag_out`` as :data:`N_STATE`, :data:`N_DIAG`. An infeasible funnel at the first
    sample gives a NaN torque (the simulator then reports it)."""
    m = params[1:37].reshape((4, 3, 3))
    geometric_pd_one(0, m[0], m[1], m[2], m[3], R, w, R_d, w_d, dw_d, M_out, diag_out)
    rho_inf, decay, rho0_given, margin = params[37], params[38], params[39], params[40]
    k1, k2, kc, q_min, z_max, t0 = (
        params[41], params[42], params[43], params[44], params[45], params[46],
    )  # fmt: skip
    psi = diag_out[0]
    e = (diag_out[1], diag_out[2], diag_out[3])
    E = (diag_out[4], diag_out[5], diag_out[6])
    # with unit gains M_PD = ff − e_R − e_Ω: the exact feed-forward of the PD
    ff0 = M_out[0] + e[0] + E[0]
    ff1 = M_out[1] + e[1] + E[1]
    ff2 = M_out[2] + e[2] + E[2]
    tau = t - t0
    if state[0] == 0.0:
        m0 = max(abs(e[0]), abs(e[1]), abs(e[2]))
        if rho0_given < 0.0:
            rho0 = min(1.0, max(margin * m0, 2.0 * rho_inf))
        else:
            rho0 = rho0_given
        width = (rho0 - rho_inf) * math.exp(-decay * tau) + rho_inf
        state[0] = 1.0
        state[1] = rho0
        if m0 >= width:
            M_out[0] = math.nan
            M_out[1] = math.nan
            M_out[2] = math.nan
            return
    a = (state[1] - rho_inf) * math.exp(-decay * tau)
    r = a + rho_inf
    rd = -decay * a
    rdd = decay * decay * a
    q = 1.0 - 0.5 * psi
    # virtual rate (liecontrol.control.prescribed_performance.virtual_rate), per component
    c0 = e[1] * E[2] - e[2] * E[1]
    c1 = e[2] * E[0] - e[0] * E[2]
    c2 = e[0] * E[1] - e[1] * E[0]
    ed = (0.5 * (q * E[0] + c0), 0.5 * (q * E[1] + c1), 0.5 * (q * E[2] + c2))
    q_dot = -0.5 * (e[0] * E[0] + e[1] * E[1] + e[2] * E[2])
    eps = np.empty(3)
    wv = np.empty(3)
    wdv = np.empty(3)
    clipped = False
    for i in range(3):
        z = e[i] / r
        cl = abs(z) > z_max
        clipped = clipped or cl
        zc = min(max(z, -z_max), z_max)
        omz = 1.0 - zc * zc
        ep = math.atanh(zc)
        g = 1.0 / (r * omz)
        z_dot = 0.0 if cl else (ed[i] - zc * rd) / r
        eps_dot = z_dot / omz
        g_dot = g * (-rd / r + 2.0 * zc * z_dot / omz)
        eps[i] = ep
        wv[i] = g * ep
        wdv[i] = g_dot * ep + g * eps_dot
    x0 = e[1] * wv[2] - e[2] * wv[1]
    x1 = e[2] * wv[0] - e[0] * wv[2]
    x2 = e[0] * wv[1] - e[1] * wv[0]
    ETw = (0.5 * (q * wv[0] - x0), 0.5 * (q * wv[1] - x1), 0.5 * (q * wv[2] - x2))
    y0 = ed[1] * wv[2] - ed[2] * wv[1]
    y1 = ed[2] * wv[0] - ed[0] * wv[2]
    y2 = ed[0] * wv[1] - ed[1] * wv[0]
    v0 = e[1] * wdv[2] - e[2] * wdv[1]
    v1 = e[2] * wdv[0] - e[0] * wdv[2]
    v2 = e[0] * wdv[1] - e[1] * wdv[0]
    ETw_dot = (
        0.5 * (q_dot * wv[0] - y0 + q * wdv[0] - v0),
        0.5 * (q_dot * wv[1] - y1 + q * wdv[1] - v1),
        0.5 * (q_dot * wv[2] - y2 + q * wdv[2] - v2),
    )
    low = q < q_min
    qb = q_min if low else q
    qb_dot = 0.0 if low else q_dot
    ratio = rd / r
    acc = np.empty(3)
    outside = False
    for i in range(3):
        a_ff = 2.0 * ratio * e[i] / qb
        a_ff_dot = 2.0 * (
            (rdd / r - ratio * ratio) * e[i] / qb + ratio * ed[i] / qb
            - ratio * e[i] * qb_dot / (qb * qb)
        )  # fmt: skip
        alpha = a_ff - k1 * r * r * ETw[i]
        alpha_dot = a_ff_dot - k1 * (2.0 * r * rd * ETw[i] + r * r * ETw_dot[i])
        s = E[i] - alpha
        acc[i] = alpha_dot - k2 * s - kc * (r * r) * ETw[i]
        diag_out[7 + i] = eps[i]
        diag_out[10 + i] = alpha
        diag_out[13 + i] = s
        outside = outside or abs(e[i]) >= r
    u0, u1, u2 = matvec3(m[0], acc[0], acc[1], acc[2])
    M_out[0] = ff0 + u0
    M_out[1] = ff1 + u1
    M_out[2] = ff2 + u2
    if outside:
        state[2] += 1.0
    diag_out[16] = r
    diag_out[17] = state[2]
    diag_out[18] = 1.0 if clipped else 0.0
