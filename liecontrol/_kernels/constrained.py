"""Kernel of the keep-out/keep-in geometric PD on SO(3)
(:class:`liecontrol.control.constrained.ConstrainedGeometricPD`; logarithmic barriers after Lee &
Mesbahi 2014 and Kulumani & Lee 2017 — formulas in :mod:`liecontrol.control.constrained`, whose
numpy route is the reference this kernel is tested against). One spacecraft per call::

    M = ff − K_R e_C − K_Ω e_Ω,   e_C = (1 + Σβ_i) e_A + Ψ_A Σ∇β_i,   Ψ = Ψ_A (1 + Σβ_i),
    β_i = −w ln(max(slack_i/scale_i, floor)),

with (Ψ_A, e_A) the large-angle error and ff the geometric PD's feed-forward. An attitude outside
the admissible set (``R_d`` at any sample, ``R`` at the first) gives a NaN torque: the simulator
then reports the controller's own error.

The sampled-data safe law (:class:`liecontrol.control.constrained.SampledSafeConstrainedPD`) is
this law clipped to the torque box, then :func:`braking_filter_one`: the one-step filter on the
braking-distance-augmented margin, for one spacecraft. Its batched numpy twin
(``constrained.braking_filter``, also the MPC's filter) is the validated reference; the tests
hold the two equal (``tests/test_sampled_safe_kernel.py``).
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


#: diagnostics row of the sampled-data safe law: the barrier law's :data:`N_DIAG`, then the
#: smallest braking margin h [rad], the smallest geometric margin m [rad], filter active (0/1)
N_DIAG_SAFE = N_DIAG + 3
#: the filter's block after the barrier law's parameters: u_max (3), T, η, buffer [rad],
#: λ_max(J), J⁻¹ (9), strict (0/1), ‖u_max‖/λ_min(J), then the half angle [rad] of each cone
FILTER_HEAD = 18
#: columns of the filter's work array, one row per cone
_H, _M, _V, _AB, _AF, _P, _AS, _RE = 0, 1, 2, 3, 4, 5, 8, 9
N_WORK = 10


@njit
def _h_one(m: float, v: float, a_b: float, T: float, buf: float) -> float:
    vp = max(v, 0.0)
    return m - vp * T - vp * vp / (2.0 * a_b) - buf


@njit(inline="always")
def largest_approach_acceleration_one(
    m: float, v: float, a_b: float, a_hi: float, T: float, buf: float
) -> float:
    """``constrained.largest_approach_acceleration`` for one cone (same operations, same
    order): the root of the end-of-period braking margin in the approach acceleration, clipped
    to ``[min(−a_b, a_hi), a_hi]``."""
    C = m - v * T - buf
    D = C + 0.5 * v * T
    Dp = max(D, 0.0)
    y = 2.0 * Dp / (1.5 * T + math.sqrt(2.25 * T * T + 2.0 * Dp / a_b))
    root = (y - v) / T if D > 0.0 else 2.0 * C / (T * T)
    return min(max(root, min(-a_b, a_hi)), a_hi)


@njit
def braking_filter_one(
    u: np.ndarray, R: np.ndarray, w: np.ndarray, J: np.ndarray, cones: np.ndarray,
    filt: np.ndarray, work: np.ndarray,
) -> bool:  # fmt: skip
    """``constrained.braking_filter`` for one spacecraft: filters the command ``u (3,)`` (within
    the box) in place and returns whether it changed it. ``cones (n, PER_CONE)`` as in the
    barrier law's parameters, ``filt`` the block of :data:`FILTER_HEAD` + n values, ``work (n,
    N_WORK)`` receives per cone h, m, v, a_b [rad, rad/s, rad/s²] (columns 0–3; the warning of
    an unrecoverable start is built from them) and scratch. The operations follow the numpy
    route's order, so the two agree to rounding."""
    n = cones.shape[0]
    T, eta, buf, lam = filt[3], filt[4], filt[5], filt[6]
    Ji = filt[7:16].reshape((3, 3))
    umin = min(min(filt[0], filt[1]), filt[2])
    w0, w1, w2 = w[0], w[1], w[2]
    jw0, jw1, jw2 = matvec3(J, w0, w1, w2)
    gy0, gy1, gy2 = w1 * jw2 - w2 * jw1, w2 * jw0 - w0 * jw2, w0 * jw1 - w1 * jw0
    # the curvature-free certificate's terms (constrained._cone_certificates)
    r0, r1, r2 = matvec3(Ji, gy0, gy1, gy2)
    g_acc = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    a_s = max(eta * umin / lam - g_acc, 1e-12)
    w_norm = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    for i in range(n):
        cone = cones[i]
        b0, b1, b2 = cone[0], cone[1], cone[2]
        s0 = R[0, 0] * cone[3] + R[1, 0] * cone[4] + R[2, 0] * cone[5]  # Rᵀs
        s1 = R[0, 1] * cone[3] + R[1, 1] * cone[4] + R[2, 1] * cone[5]
        s2 = R[0, 2] * cone[3] + R[1, 2] * cone[4] + R[2, 2] * cone[5]
        c = min(max(s0 * b0 + s1 * b1 + s2 * b2, -1.0), 1.0)
        phi = math.acos(c)
        sphi = max(math.sin(phi), 1e-9)
        g0, g1, g2 = b1 * s2 - b2 * s1, b2 * s0 - b0 * s2, b0 * s1 - b1 * s0
        c_dot = g0 * w0 + g1 * w1 + g2 * w2
        x0, x1, x2 = s1 * w2 - s2 * w1, s2 * w0 - s0 * w2, s0 * w1 - s1 * w0
        d0, d1, d2 = b1 * x2 - b2 * x1, b2 * x0 - b0 * x2, b0 * x1 - b1 * x0
        q0, q1, q2 = matvec3(Ji, g0, g1, g2)
        sigma = 1.0 if cone[7] == 0.0 else -1.0
        row = work[i]
        row[_M] = sigma * (phi - filt[FILTER_HEAD + i])
        row[_V] = -sigma * (-c_dot / sphi)
        curv = ((d0 * w0 + d1 * w1 + d2 * w2) - (q0 * gy0 + q1 * gy1 + q2 * gy2)) / sphi
        curv = curv + c_dot * c_dot * c / sphi**3.0
        a_free = sigma * curv
        row[_AF] = a_free
        k = sigma / sphi
        row[_P] = k * q0
        row[_P + 1] = k * q1
        row[_P + 2] = k * q2
        a_b = max(eta * umin / lam - max(a_free, 0.0), 1e-12)
        row[_AB] = a_b
        m = row[_M]
        ws = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)  # ‖Rᵀs × ω‖
        row[_H] = max(_h_one(m, row[_V], a_b, T, buf), _h_one(m, ws, a_s, T, buf))
        acc = filt[17] + g_acc + w_norm * ws
        reach = _h_one(m - ws * T - 0.5 * acc * T * T, ws + acc * T, a_s, T, buf) >= 0.0
        row[_RE] = 1.0 if reach else 0.0
        # largest admissible approach acceleration: h after one period ≥ 0 (closed form); a
        # cone out of reach this period gets the box's largest, a_hi (it constrains nothing)
        a_hi = a_free + (abs(row[_P]) * filt[0] + abs(row[_P + 1]) * filt[1]
                         + abs(row[_P + 2]) * filt[2])  # fmt: skip
        if reach:
            row[_AS] = a_hi
        else:
            row[_AS] = largest_approach_acceleration_one(m, row[_V], a_b, a_hi, T, buf)
    # sequential projection, most critical cone (smallest h) last: a stable sort by −h, as
    # numpy's argsort does on so few values
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        j = i
        while j > 0 and -work[order[j - 1], _H] > -work[i, _H]:
            order[j] = order[j - 1]
            j -= 1
        order[j] = i
    active = False
    for j in range(n):
        row = work[order[j]]
        p0, p1, p2 = row[_P], row[_P + 1], row[_P + 2]
        excess = (p0 * u[0] + p1 * u[1] + p2 * u[2]) - (row[_AS] - row[_AF])
        if excess > 0.0:
            f = excess / max(p0 * p0 + p1 * p1 + p2 * p2, 1e-300)
            u[0] = min(max(u[0] - f * p0, -filt[0]), filt[0])
            u[1] = min(max(u[1] - f * p1, -filt[1]), filt[1])
            u[2] = min(max(u[2] - f * p2, -filt[2]), filt[2])
            active = True
    # the box cannot realise a*: full braking for the most critical cone
    viol = False
    for i in range(n):
        row = work[i]
        acc = row[_AF] + (row[_P] * u[0] + row[_P + 1] * u[1] + row[_P + 2] * u[2])
        if row[_RE] == 0.0 and acc > row[_AS] + 1e-12 * abs(row[_AS]):
            viol = True
    if viol:
        row = work[order[n - 1]]
        for k in range(3):
            u[k] = -np.sign(row[_P + k]) * filt[k]
        active = True
    return active


@njit
def sampled_safe_pd_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """A law of the compiled-kernel seam: :func:`constrained_pd_law` (its parameters first),
    clipped to the box, then :func:`braking_filter_one` (the filter's block after them).
    ``state``: the barrier law's, the first sample done (0/1), then the first sample's h, m,
    v, a_b per cone (the unrecoverable-start warning is built from them after the run; a
    strict controller gets a NaN torque there, and the simulator its Python error)."""
    n = int(params[57])
    n_nom = 58 + PER_CONE * n
    constrained_pd_law(
        t, R, w, R_d, w_d, dw_d, params[:n_nom], state[:N_STATE], u_out, diag_out[:N_DIAG]
    )
    if not (math.isfinite(u_out[0]) and math.isfinite(u_out[1]) and math.isfinite(u_out[2])):
        return
    filt = params[n_nom:]
    for k in range(3):
        u_out[k] = min(max(u_out[k], -filt[k]), filt[k])
    if n == 0:
        return
    work = np.empty((n, N_WORK))
    active = braking_filter_one(
        u_out, R, w, params[1:10].reshape((3, 3)), params[58:n_nom].reshape((n, PER_CONE)),
        filt, work,
    )  # fmt: skip
    hmin, mmin = math.inf, math.inf
    for i in range(n):
        hmin = min(hmin, work[i, _H])
        mmin = min(mmin, work[i, _M])
    if state[N_STATE] == 0.0:
        state[N_STATE] = 1.0
        first = state[N_STATE + 1 :].reshape((n, 4))
        for i in range(n):
            for k in range(4):
                first[i, k] = work[i, k]
        if filt[16] != 0.0 and hmin < 0.0:
            u_out[0] = math.nan
            u_out[1] = math.nan
            u_out[2] = math.nan
            return
    diag_out[N_DIAG] = hmin
    diag_out[N_DIAG + 1] = mmin
    diag_out[N_DIAG + 2] = 1.0 if active else 0.0
