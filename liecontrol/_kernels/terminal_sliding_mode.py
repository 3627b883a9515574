"""Kernel of the Euler-angle terminal sliding mode of Liu, Tang & Yu (2008) as an SO(3)
controller (:class:`liecontrol.control.terminal_sliding_mode.TerminalSlidingModeSO3`) for the
aerospace sequence ``"ZYX"`` with the desired frame as the chart's base (the attitude error's
Euler angles, y_d = 0). Equations and sources in :mod:`liecontrol.control.terminal_sliding_mode`
and :mod:`liecontrol.charts.euler`, whose numpy route is the reference this kernel is tested
against. One spacecraft per call:

- the error's Euler angles ``a`` (``charts.euler.from_matrix``), the gimbal-lock guard (a NaN
  torque: the simulator then reports the adapter's own error);
- ȧ = B ω_rel and ä = B(ω̇_rel − Ṁȧ) with ω̇_rel at zero torque (``_accel_core``, ``_drift``);
- the time-shaping polynomial p(t) from the first sample's error, its derivatives, the surface
  σ = C₁(e − p) + C₂(ė − ṗ) and u = −B⁻¹{b − p̈ + C₂⁻¹C₁(ė − ṗ) + S_δ(F + D + K)}, torque J u.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit

#: state row: has the initial conditions, their time, e₀ (3), ė₀ (3), ë₀ (3)
N_STATE = 11
#: diagnostics row: σ, e, ė, p, u (3 each), chart y (3)
N_DIAG = 18
#: parameter vector length
N_PARAMS = 98


@njit
def _wrap(x: float) -> float:
    """To (−π, π] (``charts.euler._wrap``)."""
    return math.pi - (math.pi - x) % (2.0 * math.pi)


@njit
def _mv(M: np.ndarray, x0: float, x1: float, x2: float) -> tuple[float, float, float]:
    return (
        M[0, 0] * x0 + M[0, 1] * x1 + M[0, 2] * x2,
        M[1, 0] * x0 + M[1, 1] * x1 + M[1, 2] * x2,
        M[2, 0] * x0 + M[2, 1] * x1 + M[2, 2] * x2,
    )


@njit
def tsm_zyx_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """A law of the compiled-kernel seam (:mod:`liecontrol.control.kernel`). ``params (98,)``:
    J, J⁻¹, C₁, C₂, C₂⁻¹C₁ (9 each), T, δ₀, δ₁, F + D + K, the adapter's and the law's lock
    tolerances, then the shaping coefficients of p, ṗ, p̈ (3 × 6, 3 × 5, 3 × 4); ``state`` and
    ``diag_out`` as :data:`N_STATE`, :data:`N_DIAG`."""
    mats = params[0:45].reshape((5, 3, 3))
    J, Ji, C1, C2, CC = mats[0], mats[1], mats[2], mats[3], mats[4]
    T, delta0, delta1, gain = params[45], params[46], params[47], params[48]
    lock_chart, lock_law = params[49], params[50]
    S0 = params[51:69].reshape((3, 6))
    S1 = params[69:84].reshape((3, 5))
    S2 = params[84:96].reshape((3, 4))
    # R̃ = R_dᵀR and the base rates in body axes (C_bo ω_b = R̃ᵀω_d, C_bo ω̇_b = R̃ᵀω̇_d)
    Rt = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            Rt[r, c] = R_d[0, r] * R[0, c] + R_d[1, r] * R[1, c] + R_d[2, r] * R[2, c]
    wb0 = Rt[0, 0] * w_d[0] + Rt[1, 0] * w_d[1] + Rt[2, 0] * w_d[2]
    wb1 = Rt[0, 1] * w_d[0] + Rt[1, 1] * w_d[1] + Rt[2, 1] * w_d[2]
    wb2 = Rt[0, 2] * w_d[0] + Rt[1, 2] * w_d[1] + Rt[2, 2] * w_d[2]
    db0 = Rt[0, 0] * dw_d[0] + Rt[1, 0] * dw_d[1] + Rt[2, 0] * dw_d[2]
    db1 = Rt[0, 1] * dw_d[0] + Rt[1, 1] * dw_d[1] + Rt[2, 1] * dw_d[2]
    db2 = Rt[0, 2] * dw_d[0] + Rt[1, 2] * dw_d[1] + Rt[2, 2] * dw_d[2]
    # ZYX angles of R̃ (intrinsic axes i, j, k = 2, 1, 0; charts.euler.from_matrix)
    a2 = math.atan2(-Rt[2, 0], math.hypot(Rt[2, 2], Rt[2, 1]))
    a1 = _wrap(math.atan2(Rt[1, 0], Rt[0, 0]) - math.atan2(0.0, 1.0))
    c1, s1 = math.cos(a1), math.sin(a1)
    c2, s2 = math.cos(a2), math.sin(a2)
    # M = R_Y(a2)ᵀ R_Z(a1)ᵀ R̃ (rows 1, 2 of column 1), a3 = angle of M about x
    P1 = (-s1, c1, 0.0)  # row 1 of R_Yᵀ R_Zᵀ
    P2 = (s2 * c1, s2 * s1, c2)  # row 2
    m21 = P2[0] * Rt[0, 1] + P2[1] * Rt[1, 1] + P2[2] * Rt[2, 1]
    m11 = P1[0] * Rt[0, 1] + P1[1] * Rt[1, 1] + P1[2] * Rt[2, 1]
    a3 = math.atan2(m21, m11)
    if abs(math.cos(a2)) < lock_chart:
        u_out[0] = math.nan
        u_out[1] = math.nan
        u_out[2] = math.nan
        return
    # ω_rel and ω̇_rel at zero torque: −J⁻¹(ω × Jω) + ω_rel × C_bo ω_b − C_bo ω̇_b
    x0, x1, x2 = w[0], w[1], w[2]
    j0, j1, j2 = _mv(J, x0, x1, x2)
    g0, g1, g2 = _mv(Ji, -(x1 * j2 - x2 * j1), -(x2 * j0 - x0 * j2), -(x0 * j1 - x1 * j0))
    r0, r1, r2 = x0 - wb0, x1 - wb1, x2 - wb2
    f0 = (g0 + (r1 * wb2 - r2 * wb1)) - db0
    f1 = (g1 + (r2 * wb0 - r0 * wb2)) - db1
    f2 = (g2 + (r0 * wb1 - r1 * wb0)) - db2
    # terminal_sliding_mode._accel_core for (i, j, k) = (2, 1, 0)
    ca, sa = math.cos(-a3), math.sin(-a3)  # R_x(a3)ᵀ = R_x(−a3)
    cb, sb = math.cos(-a2), math.sin(-a2)
    q0, q1, q2 = sb, 0.0, cb  # R_y(a2)ᵀ e_z
    m1 = (q0, ca * q1 - sa * q2, sa * q1 + ca * q2)
    m2 = (0.0, ca, sa)  # column y of R_x(a3)ᵀ
    m3 = (1.0, 0.0, 0.0)
    rr1 = (
        m2[1] * m3[2] - m2[2] * m3[1],
        m2[2] * m3[0] - m2[0] * m3[2],
        m2[0] * m3[1] - m2[1] * m3[0],
    )
    rr2 = (
        m3[1] * m1[2] - m3[2] * m1[1],
        m3[2] * m1[0] - m3[0] * m1[2],
        m3[0] * m1[1] - m3[1] * m1[0],
    )
    rr3 = (
        m1[1] * m2[2] - m1[2] * m2[1],
        m1[2] * m2[0] - m1[0] * m2[2],
        m1[0] * m2[1] - m1[1] * m2[0],
    )
    det = m1[0] * rr1[0] + m1[1] * rr1[1] + m1[2] * rr1[2]
    if abs(det) < lock_law:
        u_out[0] = math.nan
        u_out[1] = math.nan
        u_out[2] = math.nan
        return
    B = np.empty((3, 3))
    for c in range(3):
        B[0, c] = rr1[c] / det
        B[1, c] = rr2[c] / det
        B[2, c] = rr3[c] / det
    d0, d1, d2 = _mv(B, r0, r1, r2)
    # Ṁȧ = d1 ṁ1 + d2 ṁ2: ṁ1 = −d3 e_x × m1 − d2 R_x(a3)ᵀ(e_y × R_y(a2)ᵀ e_z), ṁ2 = −d3 e_x × m2
    ex1 = (0.0, -m1[2], m1[1])  # e_x × m1
    ex2 = (0.0, -m2[2], m2[1])
    ey = (q2, 0.0, -q0)  # e_y × (q0, q1, q2)
    v1 = ey[0]
    v2 = ca * ey[1] - sa * ey[2]
    v3 = sa * ey[1] + ca * ey[2]
    dm1 = (-d2 * ex1[0] - d1 * v1, -d2 * ex1[1] - d1 * v2, -d2 * ex1[2] - d1 * v3)
    dm2 = (-d2 * ex2[0], -d2 * ex2[1], -d2 * ex2[2])
    b0, b1, b2 = _mv(
        B,
        f0 - (d0 * dm1[0] + d1 * dm2[0]),
        f1 - (d0 * dm1[1] + d1 * dm2[1]),
        f2 - (d0 * dm1[2] + d1 * dm2[2]),
    )
    # errors (y_d = 0: e = wrap(a), ė = ȧ), the initial conditions at the first sample
    e = (_wrap(a1), _wrap(a2), _wrap(a3))
    ed = (d0, d1, d2)
    bb = (b0, b1, b2)
    if state[0] == 0.0:
        state[0] = 1.0
        state[1] = t
        for c in range(3):
            state[2 + c] = e[c]
            state[5 + c] = ed[c]
            state[8 + c] = bb[c]
    tau = t - state[1]
    p = np.zeros(3)
    pd = np.zeros(3)
    pdd = np.zeros(3)
    if not tau > T:
        x = tau / T
        W = np.empty((3, 3))
        for ell in range(3):
            s0 = 0.0
            for m in range(6):
                s0 += S0[ell, m] * math.pow(x, float(m))
            s1d = 0.0
            for m in range(5):
                s1d += S1[ell, m] * math.pow(x, float(m))
            s2d = 0.0
            for m in range(4):
                s2d += S2[ell, m] * math.pow(x, float(m))
            sc = 1.0 if ell == 0 else (T if ell == 1 else T * T)
            W[ell, 0] = s0 * sc
            W[ell, 1] = (s1d / T) * sc
            W[ell, 2] = (s2d / (T * T)) * sc
        for c in range(3):
            E0, E1, E2 = state[2 + c], state[5 + c], state[8 + c]
            p[c] = E0 * W[0, 0] + E1 * W[1, 0] + E2 * W[2, 0]
            pd[c] = E0 * W[0, 1] + E1 * W[1, 1] + E2 * W[2, 1]
            pdd[c] = E0 * W[0, 2] + E1 * W[1, 2] + E2 * W[2, 2]
    # σ = C₁(e − p) + C₂(ė − ṗ), S_δ = C₂ᵀσ/(‖C₂ᵀσ‖ + δ₀ + δ₁‖e‖)
    k0, k1, k2 = _mv(C1, e[0] - p[0], e[1] - p[1], e[2] - p[2])
    h0, h1, h2 = _mv(C2, ed[0] - pd[0], ed[1] - pd[1], ed[2] - pd[2])
    sg = (k0 + h0, k1 + h1, k2 + h2)
    cs0 = C2[0, 0] * sg[0] + C2[1, 0] * sg[1] + C2[2, 0] * sg[2]
    cs1 = C2[0, 1] * sg[0] + C2[1, 1] * sg[1] + C2[2, 1] * sg[2]
    cs2 = C2[0, 2] * sg[0] + C2[1, 2] * sg[1] + C2[2, 2] * sg[2]
    delta = delta0 + delta1 * math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    den = math.sqrt(cs0 * cs0 + cs1 * cs1 + cs2 * cs2) + delta
    l0, l1, l2 = _mv(CC, ed[0] - pd[0], ed[1] - pd[1], ed[2] - pd[2])
    vv0 = ((bb[0] - 0.0) - pdd[0]) + l0 + (cs0 / den) * gain
    vv1 = ((bb[1] - 0.0) - pdd[1]) + l1 + (cs1 / den) * gain
    vv2 = ((bb[2] - 0.0) - pdd[2]) + l2 + (cs2 / den) * gain
    # u = −B⁻¹ v = −[m1 m2 m3] v (B = M⁻¹)
    u0 = -(m1[0] * vv0 + m2[0] * vv1 + m3[0] * vv2)
    u1 = -(m1[1] * vv0 + m2[1] * vv1 + m3[1] * vv2)
    u2 = -(m1[2] * vv0 + m2[2] * vv1 + m3[2] * vv2)
    t0_, t1_, t2_ = _mv(J, u0, u1, u2)
    u_out[0] = t0_
    u_out[1] = t1_
    u_out[2] = t2_
    uu = (u0, u1, u2)
    ya = (a1, a2, a3)
    for c in range(3):
        diag_out[c] = sg[c]
        diag_out[3 + c] = e[c]
        diag_out[6 + c] = ed[c]
        diag_out[9 + c] = p[c]
        diag_out[12 + c] = uu[c]
        diag_out[15 + c] = ya[c]
