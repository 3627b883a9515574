"""Kernel of the MRP ADRC (:class:`liecontrol.control.adrc.MrpADRC` with the desired frame as
base; tracking differentiator, composite extended-state observer and feedback after Wu, Huang,
Wei & Guo — equations and sources in :mod:`liecontrol.control.adrc`, whose numpy route is the
reference this kernel is tested against). One spacecraft per control sample:

- the error MRP with continuity and shadow switching (:func:`~.mrp_pd.mrp_pd_one`), its rate
  ṗ = G(p) ω_rel, and on a switch the observer states and the held measurements mapped to the
  shadow set (ṗ_s = D ṗ, p̈_s = D p̈ + Ḋ ṗ);
- the observer and differentiator advanced over the control period by their exact
  hold discretisation (matrices computed once by the controller for the run's period);
- τ₀ = k₁(v₁ − z₁) + k₂(v₂ − z₂), τ = J G(p)⁻¹(τ₀ − z₃), and the held B τ = G(p) J⁻¹ τ.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .attitude import body_from_desired, desired_rates_in_body
from .mrp_pd import mrp_pd_one

#: state row: σ_prev (3), has σ_prev, switches, has a previous sample, its time, z (3 axes × 3),
#: v (3 axes × 2), B τ held (3), previous (y_p, ẏ_p, p_d) (9)
N_STATE = 34
#: diagnostics row: z₁, z₂, z₃, v₁, v₂, τ₀, ESO error (3 each), σ (3), switched
N_DIAG = 25
#: parameter vector length (the last 9 entries are zeros: the chart kernel's null gains, kept in
#: the parameters so that the law allocates nothing per call)
N_PARAMS = 99


@njit
def _shadow(p0: float, p1: float, p2: float) -> tuple:
    """``(p_s (3), D (9))`` of a non-zero MRP (``adapters.mrp_shadow_map``/``_jacobian``)."""
    n2 = p0 * p0 + p1 * p1 + p2 * p2
    n = math.sqrt(n2)
    u0, u1, u2 = p0 / n, p1 / n, p2 / n
    return (
        -p0 / n2, -p1 / n2, -p2 / n2,
        (-1.0 + 2.0 * u0 * u0) / n / n, (2.0 * u0 * u1) / n / n, (2.0 * u0 * u2) / n / n,
        (2.0 * u1 * u0) / n / n, (-1.0 + 2.0 * u1 * u1) / n / n, (2.0 * u1 * u2) / n / n,
        (2.0 * u2 * u0) / n / n, (2.0 * u2 * u1) / n / n, (-1.0 + 2.0 * u2 * u2) / n / n,
    )  # fmt: skip


@njit
def _map_derivatives(p: np.ndarray, pd: np.ndarray, pdd: np.ndarray, with_second: bool) -> None:
    """``(p, ṗ[, p̈])`` mapped to the shadow set in place (``adapters.mrp_shadow_map``)."""
    s = _shadow(p[0], p[1], p[2])
    D = s[3:]
    n2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    ppd = p[0] * pd[0] + p[1] * pd[1] + p[2] * pd[2]
    pdpd = pd[0] * pd[0] + pd[1] * pd[1] + pd[2] * pd[2]
    q0 = D[0] * pd[0] + D[1] * pd[1] + D[2] * pd[2]
    q1 = D[3] * pd[0] + D[4] * pd[1] + D[5] * pd[2]
    q2 = D[6] * pd[0] + D[7] * pd[1] + D[8] * pd[2]
    if with_second:
        a0 = D[0] * pdd[0] + D[1] * pdd[1] + D[2] * pdd[2]
        a1 = D[3] * pdd[0] + D[4] * pdd[1] + D[5] * pdd[2]
        a2 = D[6] * pdd[0] + D[7] * pdd[1] + D[8] * pdd[2]
        n4 = n2 * n2
        n6 = n2 * n2 * n2
        pdd[0] = a0 + ((4.0 * ppd * pd[0] + 2.0 * pdpd * p[0]) / n4 - 8.0 * ppd * ppd * p[0] / n6)
        pdd[1] = a1 + ((4.0 * ppd * pd[1] + 2.0 * pdpd * p[1]) / n4 - 8.0 * ppd * ppd * p[1] / n6)
        pdd[2] = a2 + ((4.0 * ppd * pd[2] + 2.0 * pdpd * p[2]) / n4 - 8.0 * ppd * ppd * p[2] / n6)
    pd[0], pd[1], pd[2] = q0, q1, q2
    p[0], p[1], p[2] = s[0], s[1], s[2]


@njit
def mrp_adrc_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """A law of the compiled-kernel seam (:mod:`liecontrol.control.kernel`). ``params (90,)``:
    threshold², J (9), J⁻¹ (9), α, β, k₁ (3), k₂ (3), measured-init flag, Φ (3 × 3 × 3),
    Γ₀ (3 × 3), Γ₁/h (3 × 3), Γ_z (3 × 3), Φ_td (2 × 2), T₀ (2), T₁/h (2), zeros (9);
    ``state`` and ``diag_out`` as :data:`N_STATE`, :data:`N_DIAG`."""
    mats = params[1:19].reshape((2, 3, 3))
    J = mats[0]
    Ji = mats[1]
    alpha, beta = params[19], params[20]
    k1 = params[21:24]
    k2 = params[24:27]
    measured = params[27] != 0.0
    Phi = params[28:55].reshape((3, 3, 3))
    G0 = params[55:64].reshape((3, 3))
    G1 = params[64:73].reshape((3, 3))
    Gz = params[73:82].reshape((3, 3))
    Ptd = params[82:86].reshape((2, 2))
    T0 = params[86:88]
    T1 = params[88:90]
    z = state[7:16].reshape((3, 3))
    v = state[16:22].reshape((3, 2))
    bu = state[22:25]
    y_prev = state[25:28]
    yd_prev = state[28:31]
    pd_prev = state[31:34]
    # the chart: σ with continuity and shadow switching (the MRP PD kernel with no gains)
    zero = params[90:99].reshape((3, 3))
    switched = mrp_pd_one(
        2, params[0], J, zero, zero, R, w, R_d, w_d, dw_d, state[3] != 0.0, state[0:3],
        u_out, diag_out[21:25],
    )  # fmt: skip
    state[3] = 1.0
    p0, p1, p2 = state[0], state[1], state[2]
    T = body_from_desired(R, R_d)
    wb0, wb1, wb2, _, _, _ = desired_rates_in_body(T, w_d, dw_d)
    r0, r1, r2 = w[0] - wb0, w[1] - wb1, w[2] - wb2
    # ṗ = G(p) ω_rel = ½[(1 − pᵀp)/2 ω + p × ω + p (pᵀω)]
    n2 = p0 * p0 + p1 * p1 + p2 * p2
    pw = p0 * r0 + p1 * r1 + p2 * r2
    y0 = 0.5 * (0.5 * (1.0 - n2) * r0 + (p1 * r2 - p2 * r1) + p0 * pw)
    y1 = 0.5 * (0.5 * (1.0 - n2) * r1 + (p2 * r0 - p0 * r2) + p1 * pw)
    y2 = 0.5 * (0.5 * (1.0 - n2) * r2 + (p0 * r1 - p1 * r0) + p2 * pw)
    has_t = state[5] != 0.0
    if switched:
        state[4] += 1.0
        # the observer's states (and the held B τ) and the held measurements follow the switch
        zp = np.array([z[0, 0], z[1, 0], z[2, 0]])
        if zp[0] * zp[0] + zp[1] * zp[1] + zp[2] * zp[2] > 0.0:
            D = _shadow(zp[0], zp[1], zp[2])[3:]
            zd = np.array([z[0, 1], z[1, 1], z[2, 1]])
            zdd = np.array([z[0, 2], z[1, 2], z[2, 2]])
            _map_derivatives(zp, zd, zdd, True)
            for a in range(3):
                z[a, 0], z[a, 1], z[a, 2] = zp[a], zd[a], zdd[a]
            b0 = D[0] * bu[0] + D[1] * bu[1] + D[2] * bu[2]
            b1 = D[3] * bu[0] + D[4] * bu[1] + D[5] * bu[2]
            b2 = D[6] * bu[0] + D[7] * bu[1] + D[8] * bu[2]
            bu[0], bu[1], bu[2] = b0, b1, b2
        if has_t and y_prev[0] ** 2 + y_prev[1] ** 2 + y_prev[2] ** 2 > 0.0:
            _map_derivatives(y_prev, yd_prev, yd_prev, False)
    m = (alpha * p0 + beta * y0, alpha * p1 + beta * y1, alpha * p2 + beta * y2)
    pv = (p0, p1, p2)
    yv = (y0, y1, y2)
    if not has_t:
        for a in range(3):
            v[a, 0] = pv[a]
            v[a, 1] = 0.0
            if measured:
                z[a, 0] = pv[a]
                z[a, 1] = yv[a] if beta > 0.0 else 0.0
    else:
        h = t - state[6]
        if h > 0.0:
            for a in range(3):
                m0 = alpha * y_prev[a] + beta * yd_prev[a]
                x0 = Phi[a, 0, 0] * z[a, 0] + Phi[a, 0, 1] * z[a, 1] + Phi[a, 0, 2] * z[a, 2]
                x1 = Phi[a, 1, 0] * z[a, 0] + Phi[a, 1, 1] * z[a, 1] + Phi[a, 1, 2] * z[a, 2]
                x2 = Phi[a, 2, 0] * z[a, 0] + Phi[a, 2, 1] * z[a, 1] + Phi[a, 2, 2] * z[a, 2]
                dm = m[a] - m0
                z[a, 0] = x0 + G0[a, 0] * m0 + G1[a, 0] * dm + Gz[a, 0] * bu[a]
                z[a, 1] = x1 + G0[a, 1] * m0 + G1[a, 1] * dm + Gz[a, 1] * bu[a]
                z[a, 2] = x2 + G0[a, 2] * m0 + G1[a, 2] * dm + Gz[a, 2] * bu[a]
                v0 = Ptd[0, 0] * v[a, 0] + Ptd[0, 1] * v[a, 1]
                v1 = Ptd[1, 0] * v[a, 0] + Ptd[1, 1] * v[a, 1]
                dp = 0.0 - pd_prev[a]  # p_d = 0 with the desired frame as base
                v[a, 0] = v0 + T0[0] * pd_prev[a] + T1[0] * dp
                v[a, 1] = v1 + T0[1] * pd_prev[a] + T1[1] * dp
    state[5] = 1.0
    state[6] = t
    for a in range(3):
        y_prev[a] = pv[a]
        yd_prev[a] = yv[a]
        pd_prev[a] = 0.0
    for a in range(3):
        diag_out[15 + a] = k1[a] * (v[a, 0] - z[a, 0]) + k2[a] * (v[a, 1] - z[a, 1])
    x = (diag_out[15] - z[0, 2], diag_out[16] - z[1, 2], diag_out[17] - z[2, 2])
    # τ = J G(p)⁻¹(τ₀ − z₃), G⁻¹ = 8[½ c a I − a pa^ + pa paᵀ] (charts.mrp.kinematics_matrix_inv)
    n = math.sqrt(n2)
    if n > 1.0:
        tt = 1.0 / n
        t2 = tt * tt
        c = (t2 - 1.0) / (t2 + 1.0)
        s = t2 / (1.0 + t2)
    else:
        t2 = n * n
        c = (1.0 - t2) / (1.0 + t2)
        s = 1.0 / (1.0 + t2)
    q0, q1, q2 = p0 * s, p1 * s, p2 * s
    h0 = 0.5 * (c * s)
    Gi = (
        8.0 * (h0 + q0 * q0), 8.0 * (-s * -q2 + q0 * q1), 8.0 * (-s * q1 + q0 * q2),
        8.0 * (-s * q2 + q1 * q0), 8.0 * (h0 + q1 * q1), 8.0 * (-s * -q0 + q1 * q2),
        8.0 * (-s * -q1 + q2 * q0), 8.0 * (-s * q0 + q2 * q1), 8.0 * (h0 + q2 * q2),
    )  # fmt: skip
    g0 = Gi[0] * x[0] + Gi[1] * x[1] + Gi[2] * x[2]
    g1 = Gi[3] * x[0] + Gi[4] * x[1] + Gi[5] * x[2]
    g2 = Gi[6] * x[0] + Gi[7] * x[1] + Gi[8] * x[2]
    u0 = J[0, 0] * g0 + J[0, 1] * g1 + J[0, 2] * g2
    u1 = J[1, 0] * g0 + J[1, 1] * g1 + J[1, 2] * g2
    u2 = J[2, 0] * g0 + J[2, 1] * g1 + J[2, 2] * g2
    # B τ = G(p) J⁻¹ τ, G = ½[(1 − pᵀp)/2 I + p^ + p pᵀ]
    j0 = Ji[0, 0] * u0 + Ji[0, 1] * u1 + Ji[0, 2] * u2
    j1 = Ji[1, 0] * u0 + Ji[1, 1] * u1 + Ji[1, 2] * u2
    j2 = Ji[2, 0] * u0 + Ji[2, 1] * u1 + Ji[2, 2] * u2
    d = 0.5 * (1.0 - n2)
    G = (
        0.5 * (d + p0 * p0), 0.5 * (-p2 + p0 * p1), 0.5 * (p1 + p0 * p2),
        0.5 * (p2 + p1 * p0), 0.5 * (d + p1 * p1), 0.5 * (-p0 + p1 * p2),
        0.5 * (-p1 + p2 * p0), 0.5 * (p0 + p2 * p1), 0.5 * (d + p2 * p2),
    )  # fmt: skip
    bu[0] = G[0] * j0 + G[1] * j1 + G[2] * j2
    bu[1] = G[3] * j0 + G[4] * j1 + G[5] * j2
    bu[2] = G[6] * j0 + G[7] * j1 + G[8] * j2
    u_out[0] = u0
    u_out[1] = u1
    u_out[2] = u2
    for a in range(3):
        diag_out[a] = z[a, 0]
        diag_out[3 + a] = z[a, 1]
        diag_out[6 + a] = z[a, 2]
        diag_out[9 + a] = v[a, 0]
        diag_out[12 + a] = v[a, 1]
        diag_out[18 + a] = alpha * (pv[a] - z[a, 0]) + beta * (yv[a] - z[a, 1])
