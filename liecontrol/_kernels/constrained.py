"""Kernel of the keep-out/keep-in geometric PD on SO(3)
(:class:`liecontrol.control.constrained.ConstrainedGeometricPD`; logarithmic barriers after Lee &
Mesbahi 2014 and Kulumani & Lee 2017 — formulas in :mod:`liecontrol.control.constrained`, whose
numpy route is the reference this kernel is tested against). One spacecraft per call::

    M = ff − K_R e_C − K_Ω e_Ω,   e_C = (1 + Σβ_i) e_A + Ψ_A Σ∇β_i,   Ψ = Ψ_A (1 + Σβ_i),
    β_i = −w ln(max(slack_i/scale_i, floor)),

with (Ψ_A, e_A) the large-angle error and ff the geometric PD's feed-forward. An attitude outside
the admissible set (``R_d`` at any sample, ``R`` at the first) gives a NaN torque: the simulator
then reports the controller's own error.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .geometric_pd import geometric_pd_one
from .so3 import matvec3

#: diagnostics row: Ψ, e_R (= e_C, 3), e_Ω (3), min normalised slack
N_DIAG = 8
#: state row: R checked (the first sample's admissibility test done)
N_STATE = 1
#: values per cone in the parameter vector: b (3), s (3), cos(half angle), kind (0 keep-out,
#: 1 keep-in), half angle [deg]
PER_CONE = 9


@njit
def _margin_ok(R: np.ndarray, cone: np.ndarray) -> bool:
    """The admissibility test of ``constrained.check_admissible`` for one cone: margin > 0."""
    rb0 = R[0, 0] * cone[0] + R[0, 1] * cone[1] + R[0, 2] * cone[2]
    rb1 = R[1, 0] * cone[0] + R[1, 1] * cone[1] + R[1, 2] * cone[2]
    rb2 = R[2, 0] * cone[0] + R[2, 1] * cone[1] + R[2, 2] * cone[2]
    c = rb0 * cone[3] + rb1 * cone[4] + rb2 * cone[5]
    angle = math.degrees(math.acos(min(max(c, -1.0), 1.0)))
    margin = angle - cone[8] if cone[7] == 0.0 else cone[8] - angle
    return margin > 0.0


@njit
def constrained_pd_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, M_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """A law of the compiled-kernel seam (:mod:`liecontrol.control.kernel`). ``params``: the
    zero-gain large-angle geometric PD's 37, K_R (9), K_Ω (9), the barrier weight w, the slack
    floor, the number of cones, then :data:`PER_CONE` values per cone."""
    m = params[1:55].reshape((6, 3, 3))  # J, 0, 0, G, K_R, K_Ω
    wt, floor, n_cones = params[55], params[56], int(params[57])
    nan = False
    for i in range(n_cones):
        cone = params[58 + PER_CONE * i : 58 + PER_CONE * (i + 1)]
        if not _margin_ok(R_d, cone):
            nan = True
        if state[0] == 0.0 and not _margin_ok(R, cone):
            nan = True
    state[0] = 1.0
    if nan:
        M_out[0] = math.nan
        M_out[1] = math.nan
        M_out[2] = math.nan
        return
    geometric_pd_one(0, m[0], m[1], m[2], m[3], R, w, R_d, w_d, dw_d, M_out, diag_out)
    psi_a = diag_out[0]
    ea = (diag_out[1], diag_out[2], diag_out[3])
    beta = 0.0
    g0, g1, g2 = 0.0, 0.0, 0.0
    smin = math.inf
    for i in range(n_cones):
        cone = params[58 + PER_CONE * i : 58 + PER_CONE * (i + 1)]
        b0, b1, b2 = cone[0], cone[1], cone[2]
        s0 = R[0, 0] * cone[3] + R[1, 0] * cone[4] + R[2, 0] * cone[5]  # Rᵀs
        s1 = R[0, 1] * cone[3] + R[1, 1] * cone[4] + R[2, 1] * cone[5]
        s2 = R[0, 2] * cone[3] + R[1, 2] * cone[4] + R[2, 2] * cone[5]
        c = s0 * b0 + s1 * b1 + s2 * b2
        gc0, gc1, gc2 = b1 * s2 - b2 * s1, b2 * s0 - b0 * s2, b0 * s1 - b1 * s0
        ca = cone[6]
        if cone[7] == 0.0:
            slack, scale, sign = ca - c, 1.0 + ca, 1.0
        else:
            slack, scale, sign = c - ca, 1.0 - ca, -1.0
        x = max(slack / scale, floor)
        smin = min(smin, slack / scale)
        beta += -wt * math.log(x)
        k = sign * wt / (x * scale)
        g0 += k * gc0
        g1 += k * gc1
        g2 += k * gc2
    e0 = (1.0 + beta) * ea[0] + psi_a * g0
    e1 = (1.0 + beta) * ea[1] + psi_a * g1
    e2 = (1.0 + beta) * ea[2] + psi_a * g2
    a0, a1, a2 = matvec3(m[4], e0, e1, e2)
    k0, k1, k2 = matvec3(m[5], diag_out[4], diag_out[5], diag_out[6])
    M_out[0] = M_out[0] - a0 - k0
    M_out[1] = M_out[1] - a1 - k1
    M_out[2] = M_out[2] - a2 - k2
    diag_out[0] = psi_a * (1.0 + beta)
    diag_out[1] = e0
    diag_out[2] = e1
    diag_out[3] = e2
    diag_out[7] = smin
