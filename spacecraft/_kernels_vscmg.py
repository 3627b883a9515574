"""Compiled kernels of the full (variable-speed) CMG dynamics of :mod:`spacecraft.cmg_dynamics`:

- :func:`vscmg_derivatives_one`: the coupled bus + gimbal + rotor accelerations of one
  spacecraft, with the torque-limited PI gimbal servo (conditional-integration anti-windup), the
  stop bumpers and the motor power — the one scalar implementation of the per-stage formulas;
- :func:`vscmg_command_inputs_one`: what the steering law needs at a command sample (torque
  Jacobian, momentum-rate command, gyroscopic feed-forward);
- :func:`vscmg_rkmk4_step_batch`: a whole RKMK4 step of the plant under a time-only disturbance
  or a torque of the disturbance seam :mod:`spacecraft.disturbance_kernel` (its pointer called
  at every stage, :func:`spacecraft._kernels.stage_disturbance`).

:meth:`spacecraft.cmg_dynamics.VscmgActuator._solve` and ``_command_inputs`` stay as the batched
numpy reference and the route for batches without a compiler; the tests hold the kernels to them
(1e-12) and the step to :func:`liecontrol.integrators.rk.rkmk4_step_unchecked`.

Equations (Schaub & Junkins, *Analytical Mechanics of Space Systems*, 4th ed., AIAA 2018,
ch. 4, VSCMG section), per unit with spin axis ``s``, transverse axis ``t``, gimbal axis ``g``,
``ω_s = sᵀω``, ``ω_t = tᵀω``, ``ω_g = gᵀω``::

    [J_B + Σ (J_s s sᵀ + J_t t tᵀ + J_g g gᵀ)] ω̇ + Σ J_g g δ̈ + Σ I_Ws s Ω̇
        = L − ω × H − Σ δ̇ [(J_s − J_t)(ω_t s + ω_s t) + I_Ws Ω t]
    J_g (gᵀω̇ + δ̈) = u_g + f_δ,   f_δ = (J_s − J_t) ω_s ω_t + I_Ws Ω ω_t
    I_Ws (sᵀω̇ + Ω̇) = u_s + f_Ω,   f_Ω = −I_Ws δ̇ ω_t

With a torque servo ``u_g`` is known and δ̈ is eliminated (``J_g g gᵀ`` leaves the mass
matrix, ``(u_g + u_stop + f_δ) g`` moves to the right-hand side); with the kinematic servo δ̈ is
imposed and ``u_g`` follows. With a variable-speed rotor ``u_s`` is known and Ω̇ is eliminated
likewise; at constant speed Ω̇ = 0 and ``u_s`` follows. What remains is one symmetric positive
definite 3×3 system for ω̇, solved by its adjugate.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from liecontrol._jit import njit
from liecontrol._kernels.so3 import dexpinv_rkmk4, right_multiply_exp_into

from ._kernels import DIST_KERNEL, disturbance_at, stage_disturbance, steer_regularised

#: ``par`` layout of :func:`vscmg_derivatives_one` (then the stops: lower ``par[_LO:_LO + 4]``,
#: upper ``par[_HI:_HI + 4]``)
PAR_JS, PAR_JT, PAR_JG, PAR_IW, PAR_KP, PAR_KI, PAR_UMAX, PAR_LAG, PAR_KSTOP, PAR_CSTOP = range(10)
_LO = 10
_HI = 14
N_PAR = 18
#: column offsets of the geometry ``M (3, 15) = [J_B | S | C | G]``
_S = 3
_C = 7
_G = 11
#: rows of the held command ``(3, 4)``: rate command, gimbal feed-forward torque, spin torque
HELD_CMD, HELD_FF, HELD_SPIN = range(3)
#: rows of the ``details`` output ``(5, 4)``
DET_GIMBAL_TORQUE, DET_SPIN_TORQUE, DET_SATURATED, DET_GIMBAL_POWER, DET_STOP_TORQUE = range(5)


@njit
def vscmg_derivatives_one(
    kinematic: bool,
    variable_speed: bool,
    open_loop: bool,
    has_stops: bool,
    par: np.ndarray,
    M: np.ndarray,
    w: np.ndarray,
    xa: np.ndarray,
    held: np.ndarray,
    tau: np.ndarray,
    out: np.ndarray,
    details: np.ndarray,
) -> None:
    """``(ω̇, ẋ_act)`` of one spacecraft into ``out (20,)`` = (ω̇, δ̇, δ̈, Ω̇, ż, Ẇ), and the
    per-gimbal motor torque, spin torque, torque-saturation flag (1.0/0.0), gimbal power and stop
    torque into ``details (5, 4)``.

    ``par (18,)``: ``(J_s, J_t, J_g, I_Ws, K_p, K_i, u_max, τ, k_stop, c_stop)`` (``τ`` the
    kinematic servo's time constant; servo/stop entries unused where they do not apply) and the
    lower and upper stops (4 each); ``M (3, 15) = [J_B | S | C | G]``: the bus inertia, ``S, C``
    with ``s(δ) = S sin δ + C cos δ``, ``t(δ) = S cos δ − C sin δ``, and the gimbal axes ``G``;
    ``w (3,)`` the body rate; ``xa (17,)`` = (δ, δ̇, Ω, z, W); ``held (3, 4)`` the held rate
    command, gimbal feed-forward (or open-loop) torque and spin torque; ``tau (3,)`` the external
    torque. (Few array arguments on purpose: each costs call overhead in compiled code.)"""
    Js = par[PAR_JS]
    Jt = par[PAR_JT]
    Jg = par[PAR_JG]
    Iw = par[PAR_IW]
    kp = par[PAR_KP]
    ki = par[PAR_KI]
    umax = par[PAR_UMAX]
    lag = par[PAR_LAG]
    k_stop = par[PAR_KSTOP]
    c_stop = par[PAR_CSTOP]
    dJ = Js - Jt
    # with a variable-speed rotor I_Ws s sᵀ leaves the mass matrix (Ω̇ eliminated)
    a_s = Js - Iw if variable_speed else Js
    w0 = w[0]
    w1 = w[1]
    w2 = w[2]
    # mass matrix (symmetric: 6 entries) starting from J_B, and H starting from J_B ω
    m00 = M[0, 0]
    m01 = M[0, 1]
    m02 = M[0, 2]
    m11 = M[1, 1]
    m12 = M[1, 2]
    m22 = M[2, 2]
    H0 = M[0, 0] * w0 + M[0, 1] * w1 + M[0, 2] * w2
    H1 = M[1, 0] * w0 + M[1, 1] * w1 + M[1, 2] * w2
    H2 = M[2, 0] * w0 + M[2, 1] * w1 + M[2, 2] * w2
    c0 = c1 = c2 = 0.0  # Σ δ̇ [(J_s − J_t) ω_t s + ((J_s − J_t) ω_s + I_Ws Ω) t]
    r0 = r1 = r2 = 0.0  # the known generalized forces moved to the right-hand side
    for i in range(4):
        d = xa[i]
        rate = xa[4 + i]
        spin = xa[8 + i]
        sn = math.sin(d)
        cs = math.cos(d)
        s0, s1, s2 = _spin_axis(M, i, sn, cs)
        t0 = M[0, _S + i] * cs - M[0, _C + i] * sn
        t1 = M[1, _S + i] * cs - M[1, _C + i] * sn
        t2 = M[2, _S + i] * cs - M[2, _C + i] * sn
        g0 = M[0, _G + i]
        g1 = M[1, _G + i]
        g2 = M[2, _G + i]
        ws = s0 * w0 + s1 * w1 + s2 * w2
        wt = t0 * w0 + t1 * w1 + t2 * w2
        wg = g0 * w0 + g1 * w1 + g2 * w2
        a = Js * ws + Iw * spin
        b = Jt * wt
        e = Jg * (wg + rate)
        H0 += a * s0 + b * t0 + e * g0
        H1 += a * s1 + b * t1 + e * g1
        H2 += a * s2 + b * t2 + e * g2
        p = dJ * rate * wt
        q = rate * (dJ * ws + Iw * spin)
        c0 += p * s0 + q * t0
        c1 += p * s1 + q * t1
        c2 += p * s2 + q * t2
        m00 += a_s * s0 * s0 + Jt * t0 * t0
        m01 += a_s * s0 * s1 + Jt * t0 * t1
        m02 += a_s * s0 * s2 + Jt * t0 * t2
        m11 += a_s * s1 * s1 + Jt * t1 * t1
        m12 += a_s * s1 * s2 + Jt * t1 * t2
        m22 += a_s * s2 * s2 + Jt * t2 * t2
        f_d = dJ * ws * wt + Iw * spin * wt
        f_O = -Iw * rate * wt
        u_g = 0.0
        u_stop = 0.0
        sat = False
        z_dot = 0.0
        if kinematic:
            # δ̈ imposed by the first-order rate loop: J_g g gᵀ stays in the mass matrix
            dd = (held[HELD_CMD, i] - rate) / lag
            m00 += Jg * g0 * g0
            m01 += Jg * g0 * g1
            m02 += Jg * g0 * g2
            m11 += Jg * g1 * g1
            m12 += Jg * g1 * g2
            m22 += Jg * g2 * g2
            k = Jg * dd
        else:
            dd = 0.0
            if open_loop:
                raw = held[HELD_FF, i]
                err = 0.0
            else:
                err = held[HELD_CMD, i] - rate
                raw = kp * err + ki * xa[12 + i] + held[HELD_FF, i]
            u_g = min(max(raw, -umax), umax)
            sat = abs(raw) > umax
            # conditional integration: z frozen while saturated and the error pushes further
            if not (sat and err * raw > 0.0):
                z_dot = err
            if has_stops:
                over = d - par[_HI + i]
                under = par[_LO + i] - d
                if over > 0.0:
                    u_stop = -max(k_stop * over + c_stop * rate, 0.0)
                elif under > 0.0:
                    u_stop = max(k_stop * under - c_stop * rate, 0.0)
            k = u_g + u_stop + f_d
        r0 += k * g0
        r1 += k * g1
        r2 += k * g2
        if variable_speed:
            ks = held[HELD_SPIN, i] + f_O
            r0 += ks * s0
            r1 += ks * s1
            r2 += ks * s2
        out[7 + i] = dd  # final for the kinematic servo; the torque servo's δ̈ follows below
        out[15 + i] = z_dot
        details[DET_GIMBAL_TORQUE, i] = u_g
        details[DET_SATURATED, i] = 1.0 if sat else 0.0
        details[DET_STOP_TORQUE, i] = u_stop
    # right-hand side L − ω × H − c − r
    b0 = tau[0] - (w1 * H2 - w2 * H1) - c0 - r0
    b1 = tau[1] - (w2 * H0 - w0 * H2) - c1 - r1
    b2 = tau[2] - (w0 * H1 - w1 * H0) - c2 - r2
    # symmetric positive definite 3×3 (J_B plus positive semidefinite terms): adjugate solve
    A00 = m11 * m22 - m12 * m12
    A01 = m02 * m12 - m01 * m22
    A02 = m01 * m12 - m02 * m11
    A11 = m00 * m22 - m02 * m02
    A12 = m01 * m02 - m00 * m12
    A22 = m00 * m11 - m01 * m01
    inv = 1.0 / (m00 * A00 + m01 * A01 + m02 * A02)
    a0 = (A00 * b0 + A01 * b1 + A02 * b2) * inv
    a1 = (A01 * b0 + A11 * b1 + A12 * b2) * inv
    a2 = (A02 * b0 + A12 * b1 + A22 * b2) * inv
    out[0] = a0
    out[1] = a1
    out[2] = a2
    power = 0.0
    for i in range(4):
        # the axes again (four sines and cosines are cheaper than carrying scratch arrays)
        d = xa[i]
        rate = xa[4 + i]
        spin = xa[8 + i]
        sn = math.sin(d)
        cs = math.cos(d)
        s0, s1, s2 = _spin_axis(M, i, sn, cs)
        t0 = M[0, _S + i] * cs - M[0, _C + i] * sn
        t1 = M[1, _S + i] * cs - M[1, _C + i] * sn
        t2 = M[2, _S + i] * cs - M[2, _C + i] * sn
        ws = s0 * w0 + s1 * w1 + s2 * w2
        wt = t0 * w0 + t1 * w1 + t2 * w2
        f_d = dJ * ws * wt + Iw * spin * wt
        f_O = -Iw * rate * wt
        gw = M[0, _G + i] * a0 + M[1, _G + i] * a1 + M[2, _G + i] * a2
        sw = s0 * a0 + s1 * a1 + s2 * a2
        u_stop = details[DET_STOP_TORQUE, i]
        if kinematic:
            u_g = Jg * (gw + out[7 + i]) - f_d
        else:
            u_g = details[DET_GIMBAL_TORQUE, i]
            out[7 + i] = (u_g + u_stop + f_d) / Jg - gw
        if variable_speed:
            u_s = held[HELD_SPIN, i]
            out[11 + i] = (u_s + f_O) / Iw - sw
        else:
            u_s = Iw * sw - f_O
            out[11 + i] = 0.0
        out[3 + i] = rate
        power += (u_g + u_stop) * rate + u_s * spin
        details[DET_GIMBAL_TORQUE, i] = u_g
        details[DET_SPIN_TORQUE, i] = u_s
        details[DET_GIMBAL_POWER, i] = u_g * rate
    out[19] = power


@njit
def vscmg_derivatives_batch(
    kinematic: bool,
    variable_speed: bool,
    open_loop: bool,
    has_stops: bool,
    par: np.ndarray,
    M: np.ndarray,
    w: np.ndarray,
    xa: np.ndarray,
    held: np.ndarray,
    tau: np.ndarray,
    out: np.ndarray,
    details: np.ndarray,
) -> None:
    """:func:`vscmg_derivatives_one` over a batch: ``w, tau (B, 3)``, ``xa (B, 17)``,
    ``held (B, 3, 4)``, ``out (B, 20)``, ``details (B, 5, 4)``."""
    for b in range(w.shape[0]):
        vscmg_derivatives_one(
            kinematic, variable_speed, open_loop, has_stops, par, M,
            w[b], xa[b], held[b], tau[b], out[b], details[b],
        )  # fmt: skip


@njit(inline="always")
def _spin_axis(M: np.ndarray, i: int, sn: float, cs: float) -> tuple[float, float, float]:
    """Unit ``i``'s spin axis ``s = S sin δ + C cos δ`` from sin δ, cos δ."""
    return (
        M[0, _S + i] * sn + M[0, _C + i] * cs,
        M[1, _S + i] * sn + M[1, _C + i] * cs,
        M[2, _S + i] * sn + M[2, _C + i] * cs,
    )


@njit(inline="always")
def _unit_momentum(
    M: np.ndarray, i: int, e: float, hw: float, s0: float, s1: float, s2: float
) -> tuple[float, float, float]:
    """Unit ``i``'s share of the cluster momentum relative to the bus, ``J_g δ̇ g + I_Ws Ω s``,
    from ``e = J_g δ̇``, ``hw = I_Ws Ω`` and its spin axis ``s`` at the current angle."""
    return (
        e * M[0, _G + i] + hw * s0,
        e * M[1, _G + i] + hw * s1,
        e * M[2, _G + i] + hw * s2,
    )


@njit(inline="always")
def vscmg_momentum_one(
    par: np.ndarray, M: np.ndarray, xa: np.ndarray
) -> tuple[float, float, float]:
    """The cluster momentum relative to the bus ``h = Σ (J_g δ̇ g + I_Ws Ω s)`` of one
    spacecraft's actuator state ``xa`` (δ, δ̇, Ω, …) — the ``h`` of
    :func:`vscmg_command_inputs_one` and of :meth:`spacecraft.cmg_dynamics.VscmgActuator.
    momentum` (the numpy layer; equal to rounding: its sums are matrix products). ``par``,
    ``M`` as for :func:`vscmg_derivatives_one`."""
    Jg = par[PAR_JG]
    Iw = par[PAR_IW]
    h0 = h1 = h2 = 0.0
    for i in range(4):
        sn = math.sin(xa[i])
        cs = math.cos(xa[i])
        s0, s1, s2 = _spin_axis(M, i, sn, cs)
        c0, c1, c2 = _unit_momentum(M, i, Jg * xa[4 + i], Iw * xa[8 + i], s0, s1, s2)
        h0 += c0
        h1 += c1
        h2 += c2
    return h0, h1, h2


@njit
def vscmg_command_inputs_one(
    feedforward: bool,
    par: np.ndarray,
    M: np.ndarray,
    w: np.ndarray,
    xa: np.ndarray,
    u_cmd: np.ndarray,
    A_out: np.ndarray,
    hdot_out: np.ndarray,
    ff_out: np.ndarray,
) -> None:
    """What the steering law needs at a command sample, for one spacecraft: the torque Jacobian
    ``A_out (3, 4)`` with columns ``I_Ws Ω t`` (``∂h/∂δ`` at the current rotor speeds), the
    momentum-rate command ``hdot_out (3,) = −u_cmd − ω × h`` with ``h = Σ (J_g δ̇ g + I_Ws Ω s)``
    the cluster momentum relative to the bus, and with ``feedforward`` the servo's gimbal torque
    feed-forward ``ff_out (4,) = −[(J_s − J_t) ω_s ω_t + I_Ws Ω ω_t]`` (else zeros). ``par``,
    ``M`` as for :func:`vscmg_derivatives_one`."""
    Js = par[PAR_JS]
    Jt = par[PAR_JT]
    Jg = par[PAR_JG]
    Iw = par[PAR_IW]
    w0 = w[0]
    w1 = w[1]
    w2 = w[2]
    h0 = h1 = h2 = 0.0
    for i in range(4):
        sn = math.sin(xa[i])
        cs = math.cos(xa[i])
        s0, s1, s2 = _spin_axis(M, i, sn, cs)
        t0 = M[0, _S + i] * cs - M[0, _C + i] * sn
        t1 = M[1, _S + i] * cs - M[1, _C + i] * sn
        t2 = M[2, _S + i] * cs - M[2, _C + i] * sn
        hw = Iw * xa[8 + i]
        c0, c1, c2 = _unit_momentum(M, i, Jg * xa[4 + i], hw, s0, s1, s2)
        h0 += c0
        h1 += c1
        h2 += c2
        A_out[0, i] = t0 * hw
        A_out[1, i] = t1 * hw
        A_out[2, i] = t2 * hw
        if feedforward:
            ws = s0 * w0 + s1 * w1 + s2 * w2
            wt = t0 * w0 + t1 * w1 + t2 * w2
            ff_out[i] = -((Js - Jt) * ws * wt + hw * wt)
        else:
            ff_out[i] = 0.0
    hdot_out[0] = -(u_cmd[0] + (w1 * h2 - w2 * h1))
    hdot_out[1] = -(u_cmd[1] + (w2 * h0 - w0 * h2))
    hdot_out[2] = -(u_cmd[2] + (w0 * h1 - w1 * h0))


@njit(inline="always")
def vscmg_command_one(
    feedforward: bool, par: np.ndarray, M: np.ndarray, steer: int, sp: np.ndarray,
    rate_limit: float, w: np.ndarray, xa: np.ndarray, u_cmd: np.ndarray, t: float,
    A: np.ndarray, hdot: np.ndarray, held: np.ndarray,
) -> bool:  # fmt: skip
    """The full CMG model's hardware command of one spacecraft (the compiled route of
    :meth:`spacecraft.cmg_dynamics.VscmgActuator.command_unchecked` without stops):
    :func:`vscmg_command_inputs_one`, a regularised steering law
    (:func:`spacecraft._kernels.steer_regularised`, code ``steer`` with parameters ``sp``) on
    ``A`` and ``ḣ_cmd``, and the uniform scaling to the gimbal-rate limit. Writes the held
    command ``held (3, 4)`` (rate command, gimbal feed-forward torque, zero spin torque); ``A``
    ``(3, 4)`` and ``hdot`` ``(3,)`` are scratch. Returns whether the rates were scaled."""
    ff = held[HELD_FF]
    vscmg_command_inputs_one(feedforward, par, M, w, xa, u_cmd, A, hdot, ff)
    dd = held[HELD_CMD]
    steer_regularised(steer, sp, t, A, hdot[0], hdot[1], hdot[2], dd)
    for i in range(4):
        held[HELD_SPIN, i] = 0.0
    peak = 0.0
    for i in range(4):
        peak = max(peak, abs(dd[i]))
    if peak > rate_limit:
        scale = rate_limit / peak
        for i in range(4):
            dd[i] = dd[i] * scale
        return True
    return False


@njit
def vscmg_command_inputs_batch(
    feedforward: bool,
    par: np.ndarray,
    M: np.ndarray,
    w: np.ndarray,
    xa: np.ndarray,
    u_cmd: np.ndarray,
    A_out: np.ndarray,
    hdot_out: np.ndarray,
    ff_out: np.ndarray,
) -> None:
    """:func:`vscmg_command_inputs_one` over a batch: ``A_out (B, 3, 4)``, the rest ``(B, ...)``."""
    for b in range(w.shape[0]):
        vscmg_command_inputs_one(
            feedforward, par, M, w[b], xa[b], u_cmd[b], A_out[b], hdot_out[b], ff_out[b]
        )


@njit
def vscmg_rkmk4_step_batch(
    kinematic: bool, variable_speed: bool, open_loop: bool, has_stops: bool, par: np.ndarray,
    M: np.ndarray, dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool, t: float,
    R: np.ndarray, x: np.ndarray, held: np.ndarray, h: float, R_out: np.ndarray,
    x_out: np.ndarray,
) -> None:  # fmt: skip
    """One RKMK4 step (Munthe-Kaas 1998; the tableau of :func:`spacecraft._kernels.rkmk4_step`:
    classical RK4 on the chart θ, dexp⁻¹ truncated at fourth order, R_{k+1} = R exp(h/6 (K₁ +
    2K₂ + 2K₃ + K₄))) of a batch flying the full CMG cluster: ``R (B, 3, 3)``, ``x = (ω, x_act)
    (B, 20)``, the held command ``held (B, 3, 4)``, the disturbance: a time-only code ``(dist,
    dp)`` (codes of :mod:`spacecraft._kernels`), or for ``DIST_KERNEL`` the seam's torque ``dfn``
    with the parameter rows ``dpk`` ``(1, n_p)`` shared or ``(B, n_p)``, called per spacecraft
    at each stage's time, attitude R exp(θ_s) (θ₁ = 0, θ₂ = h/2 K₁, θ₃ = h/2 K₂, θ₄ = h K₃;
    formed only when ``datt``, else R) and rate (:func:`spacecraft._kernels.
    stage_disturbance`); ``par``, ``M`` as for :func:`vscmg_derivatives_one`.

    Stage-major: each RK stage is evaluated for the whole batch before the next, so the
    spacecraft are independent work inside a stage (a spacecraft-major loop chains the four
    stages' latencies — sines, divisions — one spacecraft after the other)."""
    B, n = x.shape
    h2 = 0.5 * h
    d = np.empty((4, B, n))
    xs = np.empty((B, n))
    k = np.empty((B, 4, 3))  # the chart velocities K₁..K₄
    # the external torque, then the seam torque's scratch (stage attitude, rate, output)
    sc = np.empty(18)
    tau = sc[:3]
    det = np.empty((5, 4))
    seam = dist == DIST_KERNEL  # else one time-only torque per stage for the whole batch
    pshared = dpk.shape[0] == 1
    # stage 1 at (t, x): K₁ = ω
    if not seam:
        tau[0], tau[1], tau[2] = disturbance_at(dist, dp, t)
    for b in range(B):
        xb = x[b]
        if seam:
            tau[0], tau[1], tau[2] = stage_disturbance(
                dist, dp, dfn, dpk[0 if pshared else b], datt, t, R[b], 0.0, 0.0, 0.0, True,
                xb[0], xb[1], xb[2], sc, 3,
            )  # fmt: skip
        vscmg_derivatives_one(
            kinematic, variable_speed, open_loop, has_stops, par, M,
            xb[0:3], xb[3:], held[b], tau, d[0, b], det,
        )  # fmt: skip
        for i in range(3):
            k[b, 0, i] = xb[i]
        for i in range(n):
            xs[b, i] = xb[i] + h2 * d[0, b, i]
    # stages 2–4: at θ = c h K_{j−1}, K_j = dexp⁻¹_θ(ω_j)
    for j in range(1, 4):
        cj = h if j == 3 else h2  # the chart step (and time offset) of this stage
        cn = h if j == 2 else h2  # the state step to the next stage
        if not seam:
            tau[0], tau[1], tau[2] = disturbance_at(dist, dp, t + cj)
        for b in range(B):
            xb = xs[b]
            if seam:
                # the stage attitude R exp(c h K_{j−1}): the chart argument of dexp⁻¹ below
                tau[0], tau[1], tau[2] = stage_disturbance(
                    dist, dp, dfn, dpk[0 if pshared else b], datt, t + cj, R[b],
                    cj * k[b, j - 1, 0], cj * k[b, j - 1, 1], cj * k[b, j - 1, 2], False,
                    xb[0], xb[1], xb[2], sc, 3,
                )  # fmt: skip
            vscmg_derivatives_one(
                kinematic, variable_speed, open_loop, has_stops, par, M,
                xb[0:3], xb[3:], held[b], tau, d[j, b], det,
            )  # fmt: skip
            k[b, j, 0], k[b, j, 1], k[b, j, 2] = dexpinv_rkmk4(
                cj * k[b, j - 1, 0], cj * k[b, j - 1, 1], cj * k[b, j - 1, 2], xb[0], xb[1], xb[2]
            )
            if j < 3:
                for i in range(n):
                    xs[b, i] = x[b, i] + cn * d[j, b, i]
    h6 = h / 6.0
    for b in range(B):
        for i in range(n):
            sum_d = ((d[1, b, i] + d[2, b, i]) * 2.0 + d[0, b, i]) + d[3, b, i]
            x_out[b, i] = x[b, i] + sum_d * h6
        right_multiply_exp_into(
            R[b],
            h6 * (k[b, 0, 0] + 2.0 * (k[b, 1, 0] + k[b, 2, 0]) + k[b, 3, 0]),
            h6 * (k[b, 0, 1] + 2.0 * (k[b, 1, 1] + k[b, 2, 1]) + k[b, 3, 1]),
            h6 * (k[b, 0, 2] + 2.0 * (k[b, 1, 2] + k[b, 2, 2]) + k[b, 3, 2]),
            R_out[b],
        )
