"""Kernel of the adaptive fault-tolerant sliding law on SO(3)
(:class:`liecontrol.control.fault_tolerant.AdaptiveFaultTolerantSO3`; equations, Lyapunov
argument and sources in :mod:`liecontrol.control.fault_tolerant`, whose numpy route is the
reference this kernel is tested against). One spacecraft per call::

    s = e_Ω + λ x,  x = log(R̃)^∨,  v = ff − λ J J_r⁻¹(x) e_Ω − K s − β̂ s/(‖s‖ + σ),
    u = k̂ ∘ v (clipped per axis),  k̂̇ = −γ_k s ∘ v (0 when clipped),  β̂̇ = γ_β ‖s‖²/(‖s‖ + σ),
    σ = σ̄ (1 − (1 − max_i k̂_i/k_max) β̂/β_max) with the adaptive boundary layer, else σ̄,

the estimates advanced from the previous sample with their rates held and clipped to
``[1, k_max]``, ``[0, β_max]``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .attitude import body_from_desired, desired_rates_in_body, error_log, tracking_feedforward
from .so3 import matvec3

#: state row: has a previous sample, its time, k̂ (3), β̂, k̂̇ (3), β̂̇
N_STATE = 10
#: diagnostics row: e_R (3), e_Ω (3), s (3), k̂ (3), β̂, saturated, σ(t)
N_DIAG = 15


@njit
def fault_tolerant_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """A law of the compiled-kernel seam (:mod:`liecontrol.control.kernel`). ``params (30,)``:
    J (9), K (9), λ, γ_k, γ_β, σ, k_max, β_max, torque-limit flag, limit (3), adaptive-σ flag;
    ``state`` and ``diag_out`` as :data:`N_STATE`, :data:`N_DIAG`."""
    m = params[0:18].reshape((2, 3, 3))
    J = m[0]
    K = m[1]
    lam, gamma_k, gamma_b, sigma = params[18], params[19], params[20], params[21]
    k_max, b_max, limit_on = params[22], params[23], params[24] != 0.0
    if state[0] != 0.0:
        dt = t - state[1]
        for i in range(3):
            state[2 + i] = min(max(state[2 + i] + dt * state[6 + i], 1.0), k_max)
        state[5] = min(max(state[5] + dt * state[9], 0.0), b_max)
    state[0] = 1.0
    state[1] = t
    tt = body_from_desired(R, R_d)
    x0, x1, x2 = error_log(tt)
    wb0, wb1, wb2, db0, db1, db2 = desired_rates_in_body(tt, w_d, dw_d)
    W0, W1, W2 = w[0], w[1], w[2]
    e0, e1, e2 = W0 - wb0, W1 - wb1, W2 - wb2
    s0, s1, s2 = e0 + lam * x0, e1 + lam * x1, e2 + lam * x2
    f0, f1, f2 = tracking_feedforward(J, W0, W1, W2, W0, W1, W2, wb0, wb1, wb2, db0, db1, db2)
    # J_r⁻¹(x) e_Ω = e_Ω + ½ x × e_Ω + c(θ) x × (x × e_Ω)
    th = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    if th < 1e-3:
        c = 1.0 / 12.0 + th * th / 720.0
    else:
        h = 0.5 * th
        c = (1.0 - h * math.cos(h) / math.sin(h)) / (4.0 * h * h)
    y0, y1, y2 = x1 * e2 - x2 * e1, x2 * e0 - x0 * e2, x0 * e1 - x1 * e0
    z0, z1, z2 = x1 * y2 - x2 * y1, x2 * y0 - x0 * y2, x0 * y1 - x1 * y0
    d0, d1, d2 = e0 + 0.5 * y0 + c * z0, e1 + 0.5 * y1 + c * z1, e2 + 0.5 * y2 + c * z2
    a0, a1, a2 = matvec3(J, d0, d1, d2)
    k0, k1, k2 = matvec3(K, s0, s1, s2)
    ns = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    beta = state[5]
    if params[28] != 0.0 and b_max > 0.0:
        kk = max(state[2], state[3], state[4])
        sigma = sigma * (1.0 - (1.0 - kk / k_max) * beta / b_max)
    g = beta / (ns + sigma)
    v = (
        f0 - lam * a0 - k0 - g * s0,
        f1 - lam * a1 - k1 - g * s1,
        f2 - lam * a2 - k2 - g * s2,
    )
    s = (s0, s1, s2)
    sat = False
    for i in range(3):
        u = state[2 + i] * v[i]
        if limit_on:
            lim = params[25 + i]
            if abs(u) > lim:
                sat = True
            u = min(max(u, -lim), lim)
        u_out[i] = u
    for i in range(3):
        state[6 + i] = 0.0 if sat else -gamma_k * s[i] * v[i]
    state[9] = gamma_b * ns * ns / (ns + sigma)
    diag_out[0], diag_out[1], diag_out[2] = x0, x1, x2
    diag_out[3], diag_out[4], diag_out[5] = e0, e1, e2
    diag_out[6], diag_out[7], diag_out[8] = s0, s1, s2
    diag_out[9], diag_out[10], diag_out[11] = state[2], state[3], state[4]
    diag_out[12] = beta
    diag_out[13] = 1.0 if sat else 0.0
    diag_out[14] = sigma
