"""Kernel of the integral controllers on SO(3) (:class:`liecontrol.control.IntrinsicPID`,
:class:`~liecontrol.control.IntegralPD`; law, zero-order-hold integration and anti-windup in
:mod:`liecontrol.control.geometric_pid`): the geometric PD torque of
:func:`~liecontrol._kernels.geometric_pd.geometric_pd_one` plus ``−K_I z``, with

- the integral ``z`` advanced by ``(t − t_prev) f_prev`` (the previous sample's integrand held),
  skipped where conditional integration freezes it, then clamped to ``‖K_I z‖ ≤ limit``;
- the output clipped to the torque box (saturation flag ``|u_raw_i| > limit_i``);
- the new integrand ``f = Γ(e_Ω, z) + e_R`` (intrinsic PID of Maithripala & Berg, with the
  survey's or the Levi-Civita connection) or ``f = e_Ω + c e_R`` (integral PD of Goodarzi,
  Lee & Lee 2013).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .geometric_pd import geometric_pd_one
from .so3 import matvec3

#: integrand codes: intrinsic PID with the survey's connection, with the Levi-Civita one,
#: integral PD
INTEGRAND_CODES = {"survey": 0, "levi_civita": 1, "integral_pd": 2}
#: width of the state row: has-previous flag, t_prev, z (3), f_prev (3), u_raw_prev (3),
#: sat_prev (3)
N_STATE = 14
#: width of the diagnostics row: Ψ, e_R (3), e_Ω (3), z (3), u_I (3), saturated, frozen, clamped
N_DIAG = 16


@njit
def _cross(a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> tuple:
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit
def geometric_pid_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """One control sample of the integral controllers, a law of the compiled-kernel seam
    (:mod:`liecontrol.control.kernel`). ``params (72,)``: the geometric PD's 37 (see
    :func:`~liecontrol._kernels.geometric_pd.geometric_pd_law`), then ``K_I`` (9), the integral
    limit (< 0: none), torque-limit flag, torque limit (3), conditional flag, integrand code,
    ``c``, ``J⁻¹`` (9) and ``J`` (9) of the connection; ``state (14,)`` and
    ``diag_out (16,)`` as :data:`N_STATE`, :data:`N_DIAG`."""
    m = params[1:46].reshape((5, 3, 3))  # J, K_R, K_Ω, G, K_I
    geometric_pd_one(int(params[0]), m[0], m[1], m[2], m[3], R, w, R_d, w_d, dw_d, u_out, diag_out)
    KI = m[4]
    int_limit = params[46]
    tl_on = params[47] != 0.0
    conditional = params[51] != 0.0
    code = int(params[52])
    c = params[53]
    mc = params[54:72].reshape((2, 3, 3))
    Ji = mc[0]
    Jc = mc[1]
    frozen = False
    clamped = False
    z0, z1, z2 = state[2], state[3], state[4]
    if state[0] != 0.0:
        dt = t - state[1]
        s0, s1, s2 = dt * state[5], dt * state[6], dt * state[7]
        if tl_on and conditional:
            d0, d1, d2 = matvec3(KI, s0, s1, s2)
            d0, d1, d2 = -d0, -d1, -d2
            frozen = (
                (state[11] != 0.0 and d0 * state[8] > 0.0)
                or (state[12] != 0.0 and d1 * state[9] > 0.0)
                or (state[13] != 0.0 and d2 * state[10] > 0.0)
            )
            if frozen:
                s0, s1, s2 = 0.0, 0.0, 0.0
        z0, z1, z2 = z0 + s0, z1 + s1, z2 + s2
        if int_limit >= 0.0:
            k0, k1, k2 = matvec3(KI, z0, z1, z2)
            n = math.sqrt(k0 * k0 + k1 * k1 + k2 * k2)
            clamped = n > int_limit
            if clamped:
                scale = int_limit / n
                z0, z1, z2 = z0 * scale, z1 * scale, z2 * scale
    state[0] = 1.0
    state[1] = t
    i0, i1, i2 = matvec3(KI, z0, z1, z2)
    i0, i1, i2 = -i0, -i1, -i2
    r0, r1, r2 = u_out[0] + i0, u_out[1] + i1, u_out[2] + i2
    sat = False
    u0, u1, u2 = r0, r1, r2
    for i in range(3):
        state[11 + i] = 0.0
    if tl_on:
        lim = params[48:51]
        for i, v in ((0, r0), (1, r1), (2, r2)):
            if abs(v) > lim[i]:
                state[11 + i] = 1.0
                sat = True
        u0 = min(max(r0, -lim[0]), lim[0])
        u1 = min(max(r1, -lim[1]), lim[1])
        u2 = min(max(r2, -lim[2]), lim[2])
    u_out[0] = u0
    u_out[1] = u1
    u_out[2] = u2
    state[8], state[9], state[10] = r0, r1, r2
    state[2], state[3], state[4] = z0, z1, z2
    e0, e1, e2 = diag_out[1], diag_out[2], diag_out[3]
    E0, E1, E2 = diag_out[4], diag_out[5], diag_out[6]
    if code == 2:
        f0, f1, f2 = E0 + c * e0, E1 + c * e1, E2 + c * e2
    else:
        # Γ(ω, η) = ½(ω × η − J⁻¹(Jη × ω + Jω × η)) with ω = e_Ω, η = z
        a0, a1, a2 = _cross(E0, E1, E2, z0, z1, z2)
        p0, p1, p2 = matvec3(Jc, z0, z1, z2)
        q0, q1, q2 = matvec3(Jc, E0, E1, E2)
        b0, b1, b2 = _cross(p0, p1, p2, E0, E1, E2)
        c0, c1, c2 = _cross(q0, q1, q2, z0, z1, z2)
        m0, m1, m2 = matvec3(Ji, b0 + c0, b1 + c1, b2 + c2)
        g0, g1, g2 = 0.5 * (a0 - m0), 0.5 * (a1 - m1), 0.5 * (a2 - m2)
        if code == 1:
            g0, g1, g2 = -g0, -g1, -g2
        f0, f1, f2 = g0 + e0, g1 + e1, g2 + e2
    state[5], state[6], state[7] = f0, f1, f2
    diag_out[7] = z0
    diag_out[8] = z1
    diag_out[9] = z2
    diag_out[10] = i0
    diag_out[11] = i1
    diag_out[12] = i2
    diag_out[13] = 1.0 if sat else 0.0
    diag_out[14] = 1.0 if frozen else 0.0
    diag_out[15] = 1.0 if clamped else 0.0
