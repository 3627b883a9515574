"""Kernel of the quaternion PD adapter (:class:`liecontrol.control.QuaternionPD` with the desired
frame as base): the error quaternion of R̃ = R_dᵀR with the adapter's sign handling, and the law
u = −k_p q_v − k_d e_Ω + ω × Jω − J(ω × ω_r − ω̇_r) (Wie & Barba 1985)."""

from __future__ import annotations

import numpy as np

from .._jit import njit
from .mrp_pd import quaternion9
from .so3 import matvec3

#: sign-mode codes
SIGN_CODES = {"switched": 0, "continuous": 1, "hysteretic": 2}


@njit
def quaternion_pd_one(
    sign_mode: int, hysteresis: float, J: np.ndarray, Kp: np.ndarray, Kd: np.ndarray,
    R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    q_prev: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """Torque ``u_out (3,)`` of one spacecraft. ``q_prev (4,)``: the previous sample's
    quaternion (or, at the first sample, the hint whose sign picks the first quaternion's),
    overwritten with this sample's. ``diag_out[:4]`` the quaternion used, ``diag_out[4]`` 1 if
    its sign was flipped at this sample (switched: against the previous one; hysteretic: w < −δ).
    Sign modes: 0 switched (w ≥ 0), 1 continuous, 2 hysteretic."""
    r = np.empty(9)
    for i in range(3):
        for j in range(3):
            r[3 * i + j] = R_d[0, i] * R[0, j] + R_d[1, i] * R[1, j] + R_d[2, i] * R[2, j]
    q0, q1, q2, q3 = quaternion9(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8])
    dot = q0 * q_prev[0] + q1 * q_prev[1] + q2 * q_prev[2] + q3 * q_prev[3]
    flip = False
    if sign_mode == 0:
        flip = dot < 0.0
    else:
        if dot < 0.0:
            q0, q1, q2, q3 = -q0, -q1, -q2, -q3
        if sign_mode == 2 and q0 < -hysteresis:
            q0, q1, q2, q3 = -q0, -q1, -q2, -q3
            flip = True
    wb0 = r[0] * w_d[0] + r[3] * w_d[1] + r[6] * w_d[2]
    wb1 = r[1] * w_d[0] + r[4] * w_d[1] + r[7] * w_d[2]
    wb2 = r[2] * w_d[0] + r[5] * w_d[1] + r[8] * w_d[2]
    db0 = r[0] * dw_d[0] + r[3] * dw_d[1] + r[6] * dw_d[2]
    db1 = r[1] * dw_d[0] + r[4] * dw_d[1] + r[7] * dw_d[2]
    db2 = r[2] * dw_d[0] + r[5] * dw_d[1] + r[8] * dw_d[2]
    x0, x1, x2 = w[0], w[1], w[2]
    e0, e1, e2 = x0 - wb0, x1 - wb1, x2 - wb2
    k0, k1, k2 = matvec3(Kp, q1, q2, q3)
    c0, c1, c2 = matvec3(Kd, e0, e1, e2)
    j0, j1, j2 = matvec3(J, x0, x1, x2)
    t0 = x1 * wb2 - x2 * wb1 - db0
    t1 = x2 * wb0 - x0 * wb2 - db1
    t2 = x0 * wb1 - x1 * wb0 - db2
    f0, f1, f2 = matvec3(J, t0, t1, t2)
    u_out[0] = (-k0 - c0) + ((x1 * j2 - x2 * j1) - f0)
    u_out[1] = (-k1 - c1) + ((x2 * j0 - x0 * j2) - f1)
    u_out[2] = (-k2 - c2) + ((x0 * j1 - x1 * j0) - f2)
    q_prev[0] = q0
    q_prev[1] = q1
    q_prev[2] = q2
    q_prev[3] = q3
    diag_out[0] = q0
    diag_out[1] = q1
    diag_out[2] = q2
    diag_out[3] = q3
    diag_out[4] = 1.0 if flip else 0.0


@njit
def quaternion_pd_batch(
    sign_mode: int, hysteresis: float, J: np.ndarray, Kp: np.ndarray, Kd: np.ndarray,
    R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    q_prev: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """:func:`quaternion_pd_one` over a batch."""
    for b in range(R.shape[0]):
        quaternion_pd_one(
            sign_mode, hysteresis, J, Kp, Kd, R[b], w[b], R_d[b], w_d[b], dw_d[b], q_prev[b],
            u_out[b], diag_out[b],
        )  # fmt: skip
