"""Kernel of the adaptive geometric tracking law on SO(3)
(:class:`liecontrol.control.AdaptiveGeometricSO3`; equations, Lyapunov function and sources in
:mod:`liecontrol.control.adaptive`, whose numpy route is the reference this kernel is tested
against), for the trace, large-angle and logarithmic error functions. One spacecraft per call::

    M = −K_s s − k_R e_R + W θ̂ − Φ(t) φ̂,   s = e_Ω + c e_R,   a_r = α_d − c E(R̃) e_Ω,
    W θ̂ = ω × Ĵω + Ĵ a_r,   θ̂̇ = −γ_θ (Y(ω)ᵀ(s × ω) + Y(a_r)ᵀ s),   φ̂̇ = γ_φ Φ(t)ᵀ s,

the estimates advanced from the previous sample with their rates held, then projected on their
balls. The errors ``(Ψ, e_R, e_Ω)`` come from the geometric PD kernel (zero gains).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .attitude import body_from_desired, desired_rates_in_body
from .geometric_pd import geometric_pd_one
from .so3 import matvec3

#: fixed part of the parameter vector (then the K frequencies)
N_PARAMS = 59
#: fixed part of the state row (then φ̂ (m) and its rate (m)): has previous, t_prev, θ̂ (6),
#: θ̂̇ (6)
N_STATE = 14
#: fixed part of the diagnostics row (then φ̂ (m) and the two projection flags): Ψ, e_R (3),
#: e_Ω (3), s (3), d̂ (3), θ̂ (6)
N_DIAG = 19


@njit
def _project(x: np.ndarray, centre: np.ndarray, radius: float) -> bool:
    """``x`` projected in place on the ball ``|x − centre| ≤ radius``; whether it moved."""
    n2 = 0.0
    for i in range(x.shape[0]):
        v = x[i] - centre[i]
        n2 += v * v
    n = math.sqrt(n2)
    if n > radius:
        for i in range(x.shape[0]):
            x[i] = centre[i] + (x[i] - centre[i]) * (radius / n)
        return True
    return False


@njit
def _J_times(th: np.ndarray, a0: float, a1: float, a2: float) -> tuple[float, float, float]:
    return (
        th[0] * a0 + th[3] * a1 + th[4] * a2,
        th[3] * a0 + th[1] * a1 + th[5] * a2,
        th[4] * a0 + th[5] * a1 + th[2] * a2,
    )


@njit
def adaptive_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, M_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """A law of the compiled-kernel seam (:mod:`liecontrol.control.kernel`). ``params``: the
    zero-gain geometric PD's 37 (error code 0 large-angle, 1 log or 2 trace, J, 0, 0, G), K_s (9),
    k_R, c, γ_θ, γ_φ, θ₀ (6), inertia radius, disturbance bound, K, then the K frequencies;
    ``state``: :data:`N_STATE` values, then φ̂ and its rate; ``diag_out``: :data:`N_DIAG`
    values, then φ̂, the two projection flags."""
    m9 = params[1:46].reshape((5, 3, 3))  # J, 0, 0, G, K_s
    k_R, c, g_th, g_ph = params[46], params[47], params[48], params[49]
    theta0 = params[50:56]
    radius, bound = params[56], params[57]
    nK = int(params[58])
    nu = params[59 : 59 + nK]
    m = 3 * (1 + 2 * nK)
    theta = state[2:8]
    rate_th = state[8:14]
    phi = state[14 : 14 + m]
    rate_ph = state[14 + m : 14 + 2 * m]
    th_proj = False
    ph_proj = False
    if state[0] != 0.0:
        dt = t - state[1]
        for i in range(6):
            theta[i] = theta[i] + dt * rate_th[i]
        th_proj = _project(theta, theta0, radius)
        for i in range(m):
            phi[i] = phi[i] + dt * rate_ph[i]
        ph_proj = _project(phi, np.zeros(m), bound)
    state[0] = 1.0
    state[1] = t
    geometric_pd_one(
        int(params[0]), m9[0], m9[1], m9[2], m9[3], R, w, R_d, w_d, dw_d, M_out, diag_out
    )
    psi = diag_out[0]
    e0, e1, e2 = diag_out[1], diag_out[2], diag_out[3]
    E0, E1, E2 = diag_out[4], diag_out[5], diag_out[6]
    T = body_from_desired(R, R_d)  # R̃ᵀ
    wb0, wb1, wb2, db0, db1, db2 = desired_rates_in_body(T, w_d, dw_d)
    x0, x1, x2 = w[0], w[1], w[2]
    # α_d = ω̇_d,body − ω × ω_d,body
    ad0 = db0 - (x1 * wb2 - x2 * wb1)
    ad1 = db1 - (x2 * wb0 - x0 * wb2)
    ad2 = db2 - (x0 * wb1 - x1 * wb0)
    # E(R̃) e_Ω (liecontrol.control.adaptive.error_rate_matrix)
    Er = np.empty((3, 3))
    if int(params[0]) == 2:
        G = m9[3]
        for i in range(3):
            for j in range(3):
                Er[i, j] = T[3 * i] * G[0, j] + T[3 * i + 1] * G[1, j] + T[3 * i + 2] * G[2, j]
        tr = Er[0, 0] + Er[1, 1] + Er[2, 2]
        for i in range(3):
            for j in range(3):
                Er[i, j] = 0.5 * ((tr if i == j else 0.0) - Er[i, j])
    elif int(params[0]) == 1:
        # J_r(e_R)⁻¹ = I + (θ/2) n^ + (1 − (θ/2)cot(θ/2)) n^² (lie.so3.right_jacobian_inv)
        th = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        sf = th if th > 0.0 else 1.0
        n0, n1, n2 = e0 / sf, e1 / sf, e2 / sf
        h = 0.5 * th
        if th >= 0.1:
            d = 1.0 - h * math.cos(h) / math.sin(h)
        else:
            t2 = th * th
            d = th * th * (1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0)
        N = np.array([[0.0, -n2, n1], [n2, 0.0, -n0], [-n1, n0, 0.0]])
        for i in range(3):
            for j in range(3):
                NN = N[i, 0] * N[0, j] + N[i, 1] * N[1, j] + N[i, 2] * N[2, j]
                Er[i, j] = ((1.0 if i == j else 0.0) + h * N[i, j]) + d * NN
    else:
        tr = T[0] + T[4] + T[8]
        root = math.sqrt(max(1.0 + tr, 1e-300))
        ee = (e0, e1, e2)
        for i in range(3):
            for j in range(3):
                num = (tr if i == j else 0.0) - T[3 * i + j] + 2.0 * ee[i] * ee[j]
                Er[i, j] = num / (2.0 * root)
    r0, r1, r2 = matvec3(Er, E0, E1, E2)
    ar0, ar1, ar2 = ad0 - c * r0, ad1 - c * r1, ad2 - c * r2
    s0, s1, s2 = E0 + c * e0, E1 + c * e1, E2 + c * e2
    j0, j1, j2 = _J_times(theta, x0, x1, x2)
    h0, h1, h2 = _J_times(theta, ar0, ar1, ar2)
    W0 = (x1 * j2 - x2 * j1) + h0
    W1 = (x2 * j0 - x0 * j2) + h1
    W2 = (x0 * j1 - x1 * j0) + h2
    # Wᵀs = Y(ω)ᵀ(s × ω) + Y(a_r)ᵀ s
    c0, c1, c2 = s1 * x2 - s2 * x1, s2 * x0 - s0 * x2, s0 * x1 - s1 * x0
    rate_th[0] = -g_th * (x0 * c0 + ar0 * s0)
    rate_th[1] = -g_th * (x1 * c1 + ar1 * s1)
    rate_th[2] = -g_th * (x2 * c2 + ar2 * s2)
    rate_th[3] = -g_th * ((x1 * c0 + x0 * c1) + (ar1 * s0 + ar0 * s1))
    rate_th[4] = -g_th * ((x2 * c0 + x0 * c2) + (ar2 * s0 + ar0 * s2))
    rate_th[5] = -g_th * ((x2 * c1 + x1 * c2) + (ar2 * s1 + ar1 * s2))
    # d̂ = Φ(t) φ̂ with the basis (1, sin ν₁t, cos ν₁t, …) and Φ̂̇ = γ_φ basis ⊗ s
    d0, d1, d2 = 0.0, 0.0, 0.0
    for k in range(1 + 2 * nK):
        if k == 0:
            bk = 1.0
        elif k % 2 == 1:
            bk = math.sin(nu[(k - 1) // 2] * t)
        else:
            bk = math.cos(nu[(k - 1) // 2] * t)
        d0 += bk * phi[3 * k]
        d1 += bk * phi[3 * k + 1]
        d2 += bk * phi[3 * k + 2]
        rate_ph[3 * k] = g_ph * (bk * s0)
        rate_ph[3 * k + 1] = g_ph * (bk * s1)
        rate_ph[3 * k + 2] = g_ph * (bk * s2)
    k0, k1, k2 = matvec3(m9[4], s0, s1, s2)
    M_out[0] = W0 - k0 - k_R * e0 - d0
    M_out[1] = W1 - k1 - k_R * e1 - d1
    M_out[2] = W2 - k2 - k_R * e2 - d2
    diag_out[0] = psi
    diag_out[7], diag_out[8], diag_out[9] = s0, s1, s2
    diag_out[10], diag_out[11], diag_out[12] = d0, d1, d2
    for i in range(6):
        diag_out[13 + i] = theta[i]
    for i in range(m):
        diag_out[N_DIAG + i] = phi[i]
    diag_out[N_DIAG + m] = 1.0 if th_proj else 0.0
    diag_out[N_DIAG + m + 1] = 1.0 if ph_proj else 0.0
