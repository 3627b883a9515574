"""Compiled law of :class:`liecontrol.control.eigenaxis.RateLimitedEigenaxis` (Wie & Lu's rate-
and torque-limited eigenaxis feedback) for the simulator's fused loop, through the public seam
:mod:`liecontrol.control.kernel`. The numpy ``command`` is the validated reference the tests hold
this kernel to (1e-12); the equations are in the controller's module docstring."""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .attitude import body_from_desired, desired_rates_in_body, error_log, tracking_feedforward
from .so3 import matvec3

#: ``params`` layout: ``(k, c, ω_max, has_box, u_max (3), J (9, row-major))``
N_PARAMS = 16


@njit
def rate_limited_eigenaxis_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, M_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """The law for one spacecraft: torque ``M_out (3,)``, diagnostics ``diag_out (2,) =
    (rate_saturated, attitude_error_rad)``; stateless."""
    k = params[0]
    c = params[1]
    J = params[7:16].reshape((3, 3))
    T = body_from_desired(R, R_d)
    p0, p1, p2 = error_log(T)
    th = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    scale = math.sin(0.5 * th) / th if th > 0.0 else 0.5
    q0, q1, q2 = p0 * scale, p1 * scale, p2 * scale  # sin(θ/2)·â
    wb0, wb1, wb2, db0, db1, db2 = desired_rates_in_body(T, w_d, dw_d)
    x0, x1, x2 = w[0], w[1], w[2]
    nq = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    lim = c * params[2]
    sat = lim / (k * nq) if k * nq > lim else 1.0
    v0 = k * q0 * sat + c * (x0 - wb0)
    v1 = k * q1 * sat + c * (x1 - wb1)
    v2 = k * q2 * sat + c * (x2 - wb2)
    a0, a1, a2 = matvec3(J, v0, v1, v2)
    a0, a1, a2 = -a0, -a1, -a2
    if params[3] > 0.0:
        m = max(abs(a0) / params[4], abs(a1) / params[5], abs(a2) / params[6])
        if m > 1.0:
            a0, a1, a2 = a0 / m, a1 / m, a2 / m
    f0, f1, f2 = tracking_feedforward(J, x0, x1, x2, x0, x1, x2, wb0, wb1, wb2, db0, db1, db2)
    M_out[0] = a0 + f0
    M_out[1] = a1 + f1
    M_out[2] = a2 + f2
    diag_out[0] = 1.0 if sat < 1.0 else 0.0
    diag_out[1] = 2.0 * math.asin(min(max(nq, 0.0), 1.0))
