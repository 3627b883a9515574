"""Kernel of the small-angle Euler PID with rotating-payload feed-forward of Wang, Chu, Zhang &
Yuan (2016) (:class:`liecontrol.control.payload_compensation.SmallAnglePIDWithFeedforward`) for
the compiled loop's law seam (:mod:`liecontrol.control.kernel`). Equations, sampling contract
and sources in :mod:`liecontrol.control.payload_compensation`, whose NumPy route is the
reference this kernel is tested against. One spacecraft per call, in the order of
``SmallAnglePIDWithFeedforward.command``:

- ∫u dt since the last PID sample grows by the held torque times the gap;
- at the first call of each Δt_c grid cell, a PID sample: the Euler angles of R_dᵀR for any
  Tait–Bryan sequence (:func:`liecontrol._kernels.euler.from_matrix_into`, the adapter's
  unwrap, the gimbal-lock guard as a NaN torque: the simulator then reports the adapter's own
  error), ẏ = B(y) ω_rel, the PID with its rectangle-rule integral, ω × (Jω + h_x); then the
  identification residual over the interval and one recursive-least-squares step
  (``HarmonicIdentifier.update``: shared regressor, covariance repair and trace cap — every
  spacecraft carries its own copy of the covariance, which depends on time only, so the copies
  equal the NumPy route's one);
- at the first call of each Δt_p grid cell, the feed-forward −Ŵ/sinc · sin(ω_p(t + Δt_p/2) + β̂).

Kernels never validate: :meth:`SmallAnglePIDWithFeedforward.fused_kernel` builds the parameters.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from .euler import from_matrix_into, rates_matrix_into

#: slack on the sample-grid index (``payload_compensation._GRID_EPS``)
GRID_EPS = 1e-6

# parameter vector
P_T0, P_DTC, P_DTP, P_WP, P_GAIN, P_SHIFT, P_START, P_MODE = 0, 1, 2, 3, 4, 5, 6, 7
P_NP, P_LAMBDA, P_P0, P_PMAX, P_ILIM, P_LOCK, P_UNWRAP, P_FMLOCK = 8, 9, 10, 11, 12, 13, 14, 15
P_J, P_KP, P_KI, P_KD, P_HX, P_PERM, P_YD, P_AXES = 16, 25, 28, 31, 34, 37, 40, 43
#: parameter vector length
N_PARAMS = 47
#: mode codes
MODE_IDENTIFY, MODE_INJECT, MODE_OFF = 0.0, 1.0, 2.0

# state row (a flag before each value that may be "none yet": the seam wants a finite state)
S_HKC, S_KC, S_HKP, S_KP, S_HTCALL, S_TCALL, S_HTPID, S_TPID = 0, 1, 2, 3, 4, 5, 6, 7
S_HTLAST, S_TLAST, S_HRES, S_HASYD, S_YD = 8, 9, 10, 11, 12
S_INT, S_ULAST, S_UPID, S_UCOMP, S_UINT, S_WPID, S_GPID, S_RES = 15, 18, 21, 24, 27, 30, 33, 36
S_THETA, S_P, S_NUPD, S_NREP, S_W, S_BETA, S_DIAG = 39, 48, 57, 58, 59, 62, 65
#: state row length: the law's, the identifier's and the controller's memory, the injected
#: amplitude/phase of this spacecraft, and the last PID sample's diagnostics (21)
N_STATE = 86
#: diagnostics row: att_error, rate_error, integral, pid_torque, gyro_torque, chart_y, chart_y_d,
#: comp_torque, W_hat, beta_hat, residual (3 each)
N_DIAG = 33


@njit
def _pid_sample(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray,
    params: np.ndarray, state: np.ndarray,
) -> bool:  # fmt: skip
    """The PID part (``EulerChartAdapter.command`` of ``SmallAnglePIDLaw``) and the
    identification step of ``_pid_sample``; False at gimbal lock (nothing changed)."""
    J = params[P_J : P_J + 9].reshape((3, 3))
    # R_rel = R_dᵀR, ω_base = R_relᵀω_d, ω_rel = ω − ω_base (chart_sample with the desired base)
    Rr = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            Rr[r, c] = R_d[0, r] * R[0, c] + R_d[1, r] * R[1, c] + R_d[2, r] * R[2, c]
    wr0 = w[0] - (Rr[0, 0] * w_d[0] + Rr[1, 0] * w_d[1] + Rr[2, 0] * w_d[2])
    wr1 = w[1] - (Rr[0, 1] * w_d[0] + Rr[1, 1] * w_d[1] + Rr[2, 1] * w_d[2])
    wr2 = w[2] - (Rr[0, 2] * w_d[0] + Rr[1, 2] * w_d[1] + Rr[2, 2] * w_d[2])
    i, j, k = int(params[P_AXES]), int(params[P_AXES + 1]), int(params[P_AXES + 2])
    ext = params[P_AXES + 3] != 0.0
    y = np.empty(3)
    from_matrix_into(Rr, i, j, k, ext, params[P_FMLOCK], y)
    if abs(math.cos(y[1])) < params[P_LOCK]:
        return False
    yd = (params[P_YD], params[P_YD + 1], params[P_YD + 2])
    if params[P_UNWRAP] != 0.0:
        two_pi = 2.0 * np.pi
        yd0, yd2 = yd[0], yd[2]
        if state[S_HASYD] != 0.0:
            yd0 = yd0 + np.round((state[S_YD] - yd0) / two_pi) * two_pi
            yd2 = yd2 + np.round((state[S_YD + 2] - yd2) / two_pi) * two_pi
        e0, e2 = y[0] - yd0, y[2] - yd2
        y[0] = yd0 + (e0 - two_pi * np.round(e0 / two_pi))
        y[2] = yd2 + (e2 - two_pi * np.round(e2 / two_pi))
        yd = (yd0, yd[1], yd2)
    Bm = Rr  # R_rel is not read again: its storage takes B(y)
    rates_matrix_into(y, i, j, k, ext, Bm)
    ydot = (
        Bm[0, 0] * wr0 + Bm[0, 1] * wr1 + Bm[0, 2] * wr2,
        Bm[1, 0] * wr0 + Bm[1, 1] * wr1 + Bm[1, 2] * wr2,
        Bm[2, 0] * wr0 + Bm[2, 1] * wr1 + Bm[2, 2] * wr2,
    )
    state[S_HASYD] = 1.0
    for c in range(3):
        state[S_YD + c] = yd[c]
    # SmallAnglePIDLaw.__call__
    dt = t - state[S_TLAST] if state[S_HTLAST] != 0.0 else 0.0
    state[S_HTLAST] = 1.0
    state[S_TLAST] = t
    lim = params[P_ILIM]
    d = S_DIAG
    hx = params[P_HX : P_HX + 3]
    jw0 = (J[0, 0] * w[0] + J[0, 1] * w[1] + J[0, 2] * w[2]) + hx[0]
    jw1 = (J[1, 0] * w[0] + J[1, 1] * w[1] + J[1, 2] * w[2]) + hx[1]
    jw2 = (J[2, 0] * w[0] + J[2, 1] * w[1] + J[2, 2] * w[2]) + hx[2]
    gyro = (w[1] * jw2 - w[2] * jw1, w[2] * jw0 - w[0] * jw2, w[0] * jw1 - w[1] * jw0)
    for a in range(3):
        p = int(params[P_PERM + a])
        e = y[p] - yd[p]
        ed = ydot[p] - 0.0
        z = state[S_INT + a] + dt * e
        if lim >= 0.0:
            z = min(max(z, -lim), lim)
        state[S_INT + a] = z
        pid = -((params[P_KP + a] * e + params[P_KI + a] * z) + params[P_KD + a] * ed)
        state[S_UPID + a] = pid + gyro[a]
        state[d + a] = e
        state[d + 3 + a] = ed
        state[d + 6 + a] = z
        state[d + 9 + a] = pid
        state[d + 12 + a] = gyro[a]
        state[d + 15 + a] = y[a]
        state[d + 18 + a] = yd[a]
    # the identification residual over [t_pid, t] (g with the same gyroscopic momentum)
    if params[P_MODE] == MODE_IDENTIFY and state[S_HTPID] != 0.0 and t > state[S_TPID]:
        t_pid = state[S_TPID]
        span = t - t_pid
        dw0 = w[0] - state[S_WPID]
        dw1 = w[1] - state[S_WPID + 1]
        dw2 = w[2] - state[S_WPID + 2]
        res = (
            ((J[0, 0] * dw0 + J[0, 1] * dw1 + J[0, 2] * dw2) / span
             + 0.5 * (state[S_GPID] + gyro[0])) - state[S_UINT] / span,
            ((J[1, 0] * dw0 + J[1, 1] * dw1 + J[1, 2] * dw2) / span
             + 0.5 * (state[S_GPID + 1] + gyro[1])) - state[S_UINT + 1] / span,
            ((J[2, 0] * dw0 + J[2, 1] * dw1 + J[2, 2] * dw2) / span
             + 0.5 * (state[S_GPID + 2] + gyro[2])) - state[S_UINT + 2] / span,
        )  # fmt: skip
        _rls_update(t_pid, t, res, params, state)
        state[S_HRES] = 1.0
        for r in range(3):
            state[S_RES + r] = res[r]
    state[S_HTPID] = 1.0
    state[S_TPID] = t
    for r in range(3):
        state[S_WPID + r] = w[r]
        state[S_GPID + r] = gyro[r]
        state[S_UINT + r] = 0.0
    return True


@njit
def _positive_definite(P: np.ndarray, p: int) -> bool:
    """``np.linalg.eigvalsh(P)[0] > 0`` for the symmetric leading p×p block of ``P (3, 3)``
    (``HarmonicIdentifier.update``'s test) without an eigen-solver on the hot path: Sylvester's
    leading minors d_k, each scaled by sᵏ with s = Σ|P_ij| ≥ the spectral radius. When every
    |d_k|/sᵏ ≥ 1e-9 the answer is certain — all positive: λ_min ≥ d_p/s^(p−1) ≥ 1e-9 s; the
    first negative one: by interlacing λ_min ≤ −1e-9 s — while eigvalsh's rounding is ~1e-16 s;
    otherwise ``eigvalsh`` itself decides."""
    s = 0.0
    for r in range(p):
        for c in range(p):
            s += abs(P[r, c])
    if s == 0.0:
        return False
    d1 = P[0, 0]
    d2 = P[0, 0] * P[1, 1] - P[0, 1] * P[1, 0]
    d3 = 0.0
    if p == 3:
        d3 = (
            P[0, 0] * (P[1, 1] * P[2, 2] - P[1, 2] * P[2, 1])
            - P[0, 1] * (P[1, 0] * P[2, 2] - P[1, 2] * P[2, 0])
            + P[0, 2] * (P[1, 0] * P[2, 1] - P[1, 1] * P[2, 0])
        )
    scaled = (d1 / s, d2 / (s * s), d3 / (s * s * s))
    for q in range(p):
        d = scaled[q]
        if abs(d) < 1e-9:
            return np.linalg.eigvalsh(P[:p, :p].copy())[0] > 0.0
        if d < 0.0:
            return False
    return True


@njit
def _rls_update(t0: float, t1: float, y: tuple, params: np.ndarray, state: np.ndarray) -> None:
    """``HarmonicIdentifier.update``: regressor of interval averages, RLS with forgetting,
    symmetrisation, repair of a covariance that is not positive definite, trace cap. The
    covariance lives in the state row as a 3×3 block (its last row and column zero when the
    bias is not fitted, p = 2); scalars, no allocation on this path."""
    p = int(params[P_NP])
    w = params[P_WP]
    lam = params[P_LAMBDA]
    span = w * (t1 - t0)
    if span < 1e-6:
        tm = 0.5 * (t0 + t1)
        f0, f1 = math.sin(w * tm), math.cos(w * tm)
    else:
        f0 = (math.cos(w * t0) - math.cos(w * t1)) / span
        f1 = (math.sin(w * t1) - math.sin(w * t0)) / span
    f2 = 1.0 if p == 3 else 0.0
    P = state[S_P : S_P + 9].reshape((3, 3))
    g0 = P[0, 0] * f0 + P[0, 1] * f1 + P[0, 2] * f2
    g1 = P[1, 0] * f0 + P[1, 1] * f1 + P[1, 2] * f2
    g2 = P[2, 0] * f0 + P[2, 1] * f1 + P[2, 2] * f2
    den = lam + (f0 * g0 + f1 * g1 + f2 * g2)
    k0, k1, k2 = g0 / den, g1 / den, g2 / den
    for a in range(3):
        o = S_THETA + 3 * a
        err = y[a] - (state[o] * f0 + state[o + 1] * f1 + state[o + 2] * f2)
        state[o] = state[o] + err * k0
        state[o + 1] = state[o + 1] + err * k1
        state[o + 2] = state[o + 2] + err * k2
    k = (k0, k1, k2)
    g = (g0, g1, g2)
    ok = True  # P ← ½(Q + Qᵀ), Q = (P − K (Pφ)ᵀ)/λ, pair by pair in place
    for r in range(3):
        for c in range(r, 3):
            v = 0.5 * ((P[r, c] - k[r] * g[c]) / lam + (P[c, r] - k[c] * g[r]) / lam)
            P[r, c] = v
            P[c, r] = v
            if not math.isfinite(v):
                ok = False
    if not ok or not _positive_definite(P, p):
        for r in range(3):
            for c in range(3):
                P[r, c] = params[P_P0] if r == c and r < p else 0.0
        state[S_NREP] += 1.0
    tr = P[0, 0] + P[1, 1] + P[2, 2]
    if tr > params[P_PMAX] * p:
        sc = params[P_PMAX] * p / tr
        for r in range(3):
            for c in range(3):
                P[r, c] = P[r, c] * sc
    state[S_NUPD] += 1.0


@njit(inline="always")
def _amplitude_phase(params: np.ndarray, state: np.ndarray, a: int) -> tuple[float, float]:
    mode = params[P_MODE]
    if mode == MODE_INJECT:
        return state[S_W + a], state[S_BETA + a]
    if mode == MODE_IDENTIFY:
        ta, tb = state[S_THETA + 3 * a], state[S_THETA + 3 * a + 1]
        return math.hypot(ta, tb), math.atan2(tb, ta)
    return 0.0, 0.0


@njit
def payload_pid_ff_law(
    t: float, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray,
    params: np.ndarray, state: np.ndarray, u_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """A law of the compiled-kernel seam (:mod:`liecontrol.control.kernel`); ``params``,
    ``state``, ``diag_out`` as :data:`N_PARAMS`, :data:`N_STATE`, :data:`N_DIAG`."""
    if state[S_HTCALL] != 0.0:
        gap = t - state[S_TCALL]
        for a in range(3):
            state[S_UINT + a] += state[S_ULAST + a] * gap
    t0 = params[P_T0]
    k_c = float(math.floor((t - t0) / params[P_DTC] + GRID_EPS))
    if state[S_HKC] == 0.0 or k_c != state[S_KC]:
        if not _pid_sample(t, R, w, R_d, w_d, params, state):
            for a in range(3):
                u_out[a] = math.nan
            return
        state[S_HKC] = 1.0
        state[S_KC] = k_c
    k_p = float(math.floor((t - t0) / params[P_DTP] + GRID_EPS))
    if state[S_HKP] == 0.0 or k_p != state[S_KP]:
        state[S_HKP] = 1.0
        state[S_KP] = k_p
        on = params[P_MODE] != MODE_OFF and not t < params[P_START]
        for a in range(3):
            if on:
                W, beta = _amplitude_phase(params, state, a)
                arg = params[P_WP] * (t + params[P_SHIFT]) + beta
                state[S_UCOMP + a] = -params[P_GAIN] * W * math.sin(arg)
            else:
                state[S_UCOMP + a] = 0.0
    for a in range(3):
        u = state[S_UPID + a] + state[S_UCOMP + a]
        state[S_ULAST + a] = u
        u_out[a] = u
    state[S_HTCALL] = 1.0
    state[S_TCALL] = t
    for q in range(21):
        diag_out[q] = state[S_DIAG + q]
    for a in range(3):
        W, beta = _amplitude_phase(params, state, a)
        diag_out[21 + a] = state[S_UCOMP + a]
        diag_out[24 + a] = W
        diag_out[27 + a] = beta
        diag_out[30 + a] = state[S_RES + a] if state[S_HRES] != 0.0 else math.nan
