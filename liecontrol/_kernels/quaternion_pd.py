"""Kernel of the quaternion PD adapter (:class:`liecontrol.control.QuaternionPD` with the desired
frame as base): the error quaternion of R̃ = R_dᵀR with the adapter's sign handling, and the law
u = −k_p q_v − k_d e_Ω + ω × Jω − J(ω × ω_r − ω̇_r) (Wie & Barba 1985)."""

from __future__ import annotations

import numpy as np

from .._jit import njit
from .attitude import body_from_desired, desired_rates_in_body, tracking_feedforward
from .mrp_pd import error_quaternion
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
    t = body_from_desired(R, R_d)
    q0, q1, q2, q3 = error_quaternion(t)
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
    wb0, wb1, wb2, db0, db1, db2 = desired_rates_in_body(t, w_d, dw_d)
    x0, x1, x2 = w[0], w[1], w[2]
    e0, e1, e2 = x0 - wb0, x1 - wb1, x2 - wb2
    k0, k1, k2 = matvec3(Kp, q1, q2, q3)
    c0, c1, c2 = matvec3(Kd, e0, e1, e2)
    f0, f1, f2 = tracking_feedforward(J, x0, x1, x2, x0, x1, x2, wb0, wb1, wb2, db0, db1, db2)
    u_out[0] = (-k0 - c0) + f0
    u_out[1] = (-k1 - c1) + f1
    u_out[2] = (-k2 - c2) + f2
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


@njit
def quaternion_pd_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """:func:`quaternion_pd_one` as a law of the compiled-kernel seam
    (:mod:`liecontrol.control.kernel`): ``params (29,) = (sign-mode code, hysteresis, J, k_p,
    k_d)``; ``state (4,)`` the previous quaternion (or the first sample's hint); diagnostics
    ``(5,) = (q, flipped)``."""
    m = params[2:29].reshape((3, 3, 3))  # J, k_p, k_d
    quaternion_pd_one(
        int(params[0]), params[1], m[0], m[1], m[2], R, w, R_d, w_d, dw_d, state, u_out, diag_out
    )
