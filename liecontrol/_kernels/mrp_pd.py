"""Kernel of the MRP PD adapter (:class:`liecontrol.control.MrpPD` with the desired frame as
base): the error MRP of R̃ = R_dᵀR with shadow-set switching and continuity memory, and the law
u = −K σ − P ω_rel + ff (Schaub & Junkins, *Analytical Mechanics of Space Systems*, MRP
feedback; the form of Basilisk's ``mrpFeedback`` without its integral term)."""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .attitude import body_from_desired, desired_rates_in_body, tracking_feedforward
from .so3 import matvec3

#: feed-forward codes: ω × Jω + tracking terms, ω_r × Jω + tracking terms, none
FEEDFORWARD_CODES = {"gyroscopic": 0, "reference": 1, "none": 2}


@njit
def error_quaternion(t: tuple) -> tuple[float, float, float, float]:
    """The quaternion of the attitude error R̃, given T = R̃ᵀ (:func:`attitude.body_from_desired`)."""
    return quaternion9(t[0], t[3], t[6], t[1], t[4], t[7], t[2], t[5], t[8])


@njit
def quaternion9(
    m00: float, m01: float, m02: float, m10: float, m11: float, m12: float,
    m20: float, m21: float, m22: float,
) -> tuple[float, float, float, float]:  # fmt: skip
    """Scalar-first unit quaternion of a rotation by Shepperd's method (the row of 4 q qᵀ with
    the largest diagonal entry), sign canonical: w > 0, or w = 0 and the first non-zero of
    x, y, z positive."""
    tr = m00 + m11 + m22
    d0 = 1.0 + tr
    d1 = 1.0 + 2.0 * m00 - tr
    d2 = 1.0 + 2.0 * m11 - tr
    d3 = 1.0 + 2.0 * m22 - tr
    if d0 >= d1 and d0 >= d2 and d0 >= d3:
        q0, q1, q2, q3 = d0, m21 - m12, m02 - m20, m10 - m01
    elif d1 >= d2 and d1 >= d3:
        q0, q1, q2, q3 = m21 - m12, d1, m01 + m10, m02 + m20
    elif d2 >= d3:
        q0, q1, q2, q3 = m02 - m20, m01 + m10, d2, m12 + m21
    else:
        q0, q1, q2, q3 = m10 - m01, m02 + m20, m12 + m21, d3
    n = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    q0, q1, q2, q3 = q0 / n, q1 / n, q2 / n, q3 / n
    lead = q0
    if lead == 0.0:
        lead = q1 if q1 != 0.0 else (q2 if q2 != 0.0 else q3)
    if lead < 0.0:
        return -q0, -q1, -q2, -q3
    return q0, q1, q2, q3


@njit
def mrp_pd_one(
    feedforward: int, threshold2: float, J: np.ndarray, K: np.ndarray, P: np.ndarray,
    R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    has_prev: bool, p_prev: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> bool:  # fmt: skip
    """Torque ``u_out (3,)`` of one spacecraft; ``diag_out[:3]`` the error MRP σ used (also
    written to ``p_prev`` for the next call), ``diag_out[3]`` 1 if it was switched to its
    shadow at this sample. Continuity: with a previous σ, the one of {σ, shadow(σ)} nearer to
    it is kept, then switched to the shadow when |σ|² > ``threshold2``. Returns the switch."""
    t = body_from_desired(R, R_d)
    q0, q1, q2, q3 = error_quaternion(t)
    p0, p1, p2 = q1 / (1.0 + q0), q2 / (1.0 + q0), q3 / (1.0 + q0)
    if has_prev:
        n2 = p0 * p0 + p1 * p1 + p2 * p2
        if n2 > 0.0:
            s0, s1, s2 = -p0 / n2, -p1 / n2, -p2 / n2
            a0, a1, a2 = p0 - p_prev[0], p1 - p_prev[1], p2 - p_prev[2]
            b0, b1, b2 = s0 - p_prev[0], s1 - p_prev[1], s2 - p_prev[2]
            if b0 * b0 + b1 * b1 + b2 * b2 < a0 * a0 + a1 * a1 + a2 * a2:
                p0, p1, p2 = s0, s1, s2
    switched = False
    n2c = p0 * p0 + p1 * p1 + p2 * p2
    if has_prev and n2c > threshold2:
        p0, p1, p2 = -p0 / n2c, -p1 / n2c, -p2 / n2c
        switched = True
    wb0, wb1, wb2, db0, db1, db2 = desired_rates_in_body(t, w_d, dw_d)
    x0, x1, x2 = w[0], w[1], w[2]
    e0, e1, e2 = x0 - wb0, x1 - wb1, x2 - wb2
    k0, k1, k2 = matvec3(K, p0, p1, p2)
    c0, c1, c2 = matvec3(P, e0, e1, e2)
    u0, u1, u2 = -k0 - c0, -k1 - c1, -k2 - c2
    if feedforward != 2:
        # gyroscopic: ω × Jω …; reference (Basilisk's default): ω_r × Jω …
        v0, v1, v2 = (x0, x1, x2) if feedforward == 0 else (wb0, wb1, wb2)
        f0, f1, f2 = tracking_feedforward(J, x0, x1, x2, v0, v1, v2, wb0, wb1, wb2, db0, db1, db2)
        u0, u1, u2 = u0 + f0, u1 + f1, u2 + f2
    u_out[0] = u0
    u_out[1] = u1
    u_out[2] = u2
    p_prev[0] = p0
    p_prev[1] = p1
    p_prev[2] = p2
    diag_out[0] = p0
    diag_out[1] = p1
    diag_out[2] = p2
    diag_out[3] = 1.0 if switched else 0.0
    return switched


@njit
def mrp_pd_batch(
    feedforward: int, threshold2: float, J: np.ndarray, K: np.ndarray, P: np.ndarray,
    R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    has_prev: bool, p_prev: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> int:  # fmt: skip
    """:func:`mrp_pd_one` over a batch; returns the number of shadow switches."""
    n = 0
    for b in range(R.shape[0]):
        n += mrp_pd_one(
            feedforward, threshold2, J, K, P, R[b], w[b], R_d[b], w_d[b], dw_d[b], has_prev,
            p_prev[b], u_out[b], diag_out[b],
        )  # fmt: skip
    return n


@njit
def mrp_pd_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """:func:`mrp_pd_one` as a law of the compiled-kernel seam
    (:mod:`liecontrol.control.kernel`): ``params (29,) = (feed-forward code, threshold², J, K,
    P)``; ``state (5,) = (previous σ (3), has a previous σ (0/1), shadow switches so far)``;
    diagnostics ``(4,) = (σ, switched)``."""
    m = params[2:29].reshape((3, 3, 3))  # J, K, P
    switched = mrp_pd_one(
        int(params[0]), params[1], m[0], m[1], m[2], R, w, R_d, w_d, dw_d, state[3] != 0.0,
        state[0:3], u_out, diag_out,
    )  # fmt: skip
    state[3] = 1.0
    if switched:
        state[4] += 1.0
