"""Compiled kernels of the reaction-wheel assembly (:class:`spacecraft.actuators.
ReactionWheelAssembly`): its command, the wheel torques of an integration stage and one RKMK4
step of a rigid spacecraft carrying it — the compiled twins of the assembly's NumPy methods
(``command_unchecked``, ``_torque``, ``body_torque``, ``state_derivative``), which stay the
reference the tests hold them to (1e-12) and the route without a compiler.

The assembly's parameters travel as one array ``wp (17, N)`` (:func:`wheel_params`): rows 0–2
the spin axes A, 3–5 A ∘ I_w (h = (A ∘ I_w) Ω), 6–8 the distribution A⁺ transposed (row 6 + k
holds A⁺[:, k]), then per wheel I_w, the torque limit, the speed limit, the Coulomb, viscous
and Stribeck friction, the Stribeck speed (1 where unused) and, in row 16, the scalars
(ε of the smoothed sign, the torque resolution q, friction on, Stribeck term on).

Model (the class docstring): ḣ_cmd = −(ω × h + u_cmd), τ_cmd = A⁺ ḣ_cmd, τ = clip(τ_cmd,
±τ_max) (with q > 0: clip(q·round(τ/q), ±τ_max), round half to even as NumPy's), a wheel at
|Ω| ≥ Ω_max that τ would speed up gets τ = 0 — in the command and again at every stage's
wheel speeds — plus the friction τ_f(Ω) = −[τ_c + (τ_s − τ_c) exp(−(Ω/ω_s)²)] tanh(Ω/ε) − c_v Ω;
I_w Ω̇ = τ + τ_f, body torque −(ω × h + A (τ + τ_f)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._jit import njit
from liecontrol._kernels.so3 import dexpinv_rkmk4, right_multiply_exp_into

from ._kernels import rigid_acceleration, stage_disturbance

#: rows of the parameter array (module docstring)
_AX, _AI, _PINV, _IW, _TMAX, _WMAX = 0, 3, 6, 9, 10, 11
_TC, _CV, _TS, _WS, _SCAL = 12, 13, 14, 15, 16
N_ROWS = 17


def wheel_params(act: Any) -> np.ndarray:
    """The parameter array ``(17, N)`` of a :class:`~spacecraft.actuators.ReactionWheelAssembly`
    (module docstring); needs N ≥ 4 for the scalar row, so 3 wheels get a fourth column of
    zeros that no kernel reads."""
    n = int(act.n_wheels)
    w = np.zeros((N_ROWS, max(n, 4)))
    w[_AX : _AX + 3, :n] = act.axes
    w[_AI : _AI + 3, :n] = act._AI
    w[_PINV : _PINV + 3, :n] = np.asarray(act._pinv).T
    w[_IW, :n] = act.wheel_inertia
    w[_TMAX, :n] = act.max_torque
    w[_WMAX, :n] = act.max_speed
    w[_TC, :n] = act.coulomb_friction
    w[_CV, :n] = act.viscous_friction
    w[_TS, :n] = act.stribeck_torque
    w[_WS, :n] = 1.0 if act.stribeck_speed is None else act.stribeck_speed
    stribeck = act.stribeck_speed is not None and bool(np.any(act.stribeck_torque > 0))
    w[_SCAL, :4] = (act.friction_smoothing, act.torque_lsb, float(act.has_friction), stribeck)
    return w


@dataclass(frozen=True)
class WheelPlan:
    """A plant flying the reaction-wheel assembly in the compiled loop: inertia ``J``/``J_inv``
    ``(1, 3, 3)`` shared or ``(B, 3, 3)``, the assembly's parameters ``wp`` and wheel count
    ``n``, the disturbance's plan (as :class:`spacecraft._fused.PlantKernel`'s fields)."""

    J: np.ndarray
    J_inv: np.ndarray
    wp: np.ndarray
    n: int
    friction: bool
    dist: int
    dist_params: np.ndarray
    dist_fn: Any
    dist_kparams: np.ndarray
    dist_attitude: bool
    disturbance: Any
    # momentum management: the offset of its block in the seam torque's row (−1: none)
    mm_at: int = -1

    def dist_rows(self, B: int) -> np.ndarray:
        """The seam torque's parameter rows for a batch of ``B`` (a fresh ``(B, n_p)`` array
        with momentum management: the loop writes each spacecraft's held dipole into it)."""
        from .disturbances import kernel_rows

        rows = kernel_rows(self.disturbance, self.dist_kparams, B)
        if self.mm_at >= 0:
            rows = np.ascontiguousarray(np.broadcast_to(rows, (B, rows.shape[1]))).copy()
        return rows


def wheel_support(plant: Any) -> tuple[WheelPlan | None, str]:
    """``(plan, "")`` for a plant flying a :class:`~spacecraft.actuators.ReactionWheelAssembly`
    (exact type: a subclass may change a formula) that the compiled loop runs, ``(None, why)``
    when a part keeps the Python loop, ``(None, "")`` for any other plant."""
    from .actuators import ReactionWheelAssembly
    from .disturbances import loop_disturbance_plan

    act = plant.actuator
    if type(act) is not ReactionWheelAssembly:
        return None, ""
    if plant.modes is not None:
        return None, ""  # the generic reasons apply (plant_reason)
    # with momentum management its torque composed after the disturbance's (the held dipole
    # written per step)
    mm = plant.momentum_management
    dk, at, why = loop_disturbance_plan(plant.disturbance, mm, plant.body.batch_size)
    if dk is None:
        return None, why if mm is not None else ""  # else plant_reason names the disturbance
    J3 = np.ascontiguousarray(plant.body.J.reshape(-1, 3, 3))
    Ji3 = np.ascontiguousarray(plant.body.J_inv.reshape(-1, 3, 3))
    plan = WheelPlan(
        J3, Ji3, wheel_params(act), int(act.n_wheels), bool(act.has_friction), dk[0],
        np.ascontiguousarray(dk[1], dtype=np.float64), dk[2], dk[3], dk[4], plant.disturbance,
        mm_at=at,
    )  # fmt: skip
    return plan, ""


@njit(inline="always")
def _gated(wp: np.ndarray, i: int, speed: float, tau: float) -> float:
    """τ of wheel ``i`` after the speed gate: 0 where |Ω| ≥ Ω_max and τ would speed it up."""
    if abs(speed) >= wp[_WMAX, i] and speed * tau > 0.0:
        return 0.0
    return tau


@njit(inline="always")
def friction_one(wp: np.ndarray, i: int, w: float) -> float:
    """The bearing friction τ_f of wheel ``i`` at speed ``w`` (module docstring)."""
    level = wp[_TC, i]
    if wp[_SCAL, 3] != 0.0:
        ts = wp[_TS, i]
        extra = ts - level if ts > 0.0 else 0.0
        r = w / wp[_WS, i]
        level = level + extra * math.exp(-(r * r))
    return -level * math.tanh(w / wp[_SCAL, 0]) - wp[_CV, i] * w


@njit(inline="always")
def wheel_command(
    wp: np.ndarray, n: int, u0: float, u1: float, u2: float, w0: float, w1: float, w2: float,
    speed: np.ndarray, held: np.ndarray,
) -> None:  # fmt: skip
    """The assembly's command for the body-torque request ``u`` at the body rate ``w`` and the
    wheel speeds ``speed (n,)`` into ``held (4n,)``: delivered τ, τ_cmd, torque-limit flag,
    speed-gate flag (``ReactionWheelAssembly.command_unchecked``)."""
    h0 = h1 = h2 = 0.0
    for j in range(n):
        s = speed[j]
        h0 += s * wp[_AI, j]
        h1 += s * wp[_AI + 1, j]
        h2 += s * wp[_AI + 2, j]
    d0 = -((w1 * h2 - w2 * h1) + u0)
    d1 = -((w2 * h0 - w0 * h2) + u1)
    d2 = -((w0 * h1 - w1 * h0) + u2)
    q = wp[_SCAL, 1]
    for i in range(n):
        tc = d0 * wp[_PINV, i] + d1 * wp[_PINV + 1, i] + d2 * wp[_PINV + 2, i]
        lim = wp[_TMAX, i]
        tau = min(max(tc, -lim), lim)
        if q > 0.0:
            tau = min(max(np.rint(tau / q) * q, -lim), lim)
        s = speed[i]
        closed = abs(s) >= wp[_WMAX, i] and s * tau > 0.0
        held[i] = 0.0 if closed else tau
        held[n + i] = tc
        held[2 * n + i] = 1.0 if abs(tc) > lim else 0.0
        held[3 * n + i] = 1.0 if closed else 0.0


@njit(inline="always")
def wheel_torques(
    wp: np.ndarray, n: int, friction: bool, held: np.ndarray, x: np.ndarray, xo: int,
    out: np.ndarray,
) -> tuple[float, float, float]:  # fmt: skip
    """The torque on each wheel ``out (n,)`` at the wheel speeds ``x[xo:xo + n]`` for the held
    command (gate, then friction: ``ReactionWheelAssembly._torque``) and the stored momentum
    h = (A ∘ I_w) Ω, returned."""
    h0 = h1 = h2 = 0.0
    for i in range(n):
        s = x[xo + i]
        tau = _gated(wp, i, s, held[i])
        if friction:
            tau = tau + friction_one(wp, i, s)
        out[i] = tau
        h0 += s * wp[_AI, i]
        h1 += s * wp[_AI + 1, i]
        h2 += s * wp[_AI + 2, i]
    return h0, h1, h2


@njit(inline="always")
def wheel_bus_torque(
    wp: np.ndarray, n: int, tau: np.ndarray, h0: float, h1: float, h2: float,
    w0: float, w1: float, w2: float,
) -> tuple[float, float, float]:  # fmt: skip
    """The assembly's torque on the bus −(ω × h + A τ) for the wheel torques ``tau (n,)``
    (``ReactionWheelAssembly.body_torque``)."""
    a0 = a1 = a2 = 0.0
    for i in range(n):
        a0 += tau[i] * wp[_AX, i]
        a1 += tau[i] * wp[_AX + 1, i]
        a2 += tau[i] * wp[_AX + 2, i]
    return -((w1 * h2 - w2 * h1) + a0), -((w2 * h0 - w0 * h2) + a1), -((w0 * h1 - w1 * h0) + a2)


@njit(inline="always")
def _wheel_field(
    wp: np.ndarray, n: int, friction: bool, J: np.ndarray, Jinv: np.ndarray,
    d: tuple[float, float, float], w0: float, w1: float, w2: float,
    held: np.ndarray, x: np.ndarray, xo: int, kx: np.ndarray, ko: int,
) -> tuple[float, float, float]:  # fmt: skip
    """ω̇ (returned) and the wheel accelerations ``kx[ko:ko + n]`` at the stage's rate ``w`` and
    wheel speeds ``x[xo:xo + n]`` under the external torque ``d``."""
    tau = kx[ko : ko + n]
    h0, h1, h2 = wheel_torques(wp, n, friction, held, x, xo, tau)
    b0, b1, b2 = wheel_bus_torque(wp, n, tau, h0, h1, h2, w0, w1, w2)
    for i in range(n):
        tau[i] = tau[i] / wp[_IW, i]
    d0, d1, d2 = d
    return rigid_acceleration(J, Jinv, w0, w1, w2, b0 + d0, b1 + d1, b2 + d2)


@njit(inline="always")
def wheel_rkmk4_step(
    wp: np.ndarray, n: int, friction: bool, J: np.ndarray, Jinv: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    t: float, R: np.ndarray, x: np.ndarray, held: np.ndarray,
    h: float, R_out: np.ndarray, x_out: np.ndarray, work: np.ndarray,
) -> None:  # fmt: skip
    """One RKMK4 step (Munthe-Kaas 1998; the tableau and chart of
    :func:`spacecraft._kernels.rkmk4_step`) of a rigid spacecraft with the wheel assembly:
    ``x = (ω, Ω)``, the command ``held`` (:func:`wheel_command`) fixed over the step, the gate
    and friction at every stage's wheel speeds. ``work`` (≥ 6n + 15): the four stages' wheel
    accelerations at 0, n, 2n, 3n, the stage's wheel speeds at 4n, the seam torque's scratch
    at 6n."""
    h2 = 0.5 * h
    k1, k2, k3, k4, xs, do = 0, n, 2 * n, 3 * n, 4 * n, 6 * n
    x0, x1, x2 = x[0], x[1], x[2]
    d = stage_disturbance(
        dist, dp, dfn, dpk, datt, t, R, 0.0, 0.0, 0.0, True, x0, x1, x2, work, do
    )  # fmt: skip
    a10, a11, a12 = _wheel_field(wp, n, friction, J, Jinv, d, x0, x1, x2, held, x, 3, work, k1)
    u0, u1, u2 = h2 * x0, h2 * x1, h2 * x2
    s0, s1, s2 = x0 + h2 * a10, x1 + h2 * a11, x2 + h2 * a12
    for i in range(n):
        work[xs + i] = x[3 + i] + h2 * work[k1 + i]
    d = stage_disturbance(
        dist, dp, dfn, dpk, datt, t + h2, R, u0, u1, u2, False, s0, s1, s2, work, do
    )  # fmt: skip
    a20, a21, a22 = _wheel_field(wp, n, friction, J, Jinv, d, s0, s1, s2, held, work, xs, work, k2)
    b0, b1, b2 = dexpinv_rkmk4(u0, u1, u2, s0, s1, s2)
    u0, u1, u2 = h2 * b0, h2 * b1, h2 * b2
    s0, s1, s2 = x0 + h2 * a20, x1 + h2 * a21, x2 + h2 * a22
    for i in range(n):
        work[xs + i] = x[3 + i] + h2 * work[k2 + i]
    d = stage_disturbance(
        dist, dp, dfn, dpk, datt, t + h2, R, u0, u1, u2, False, s0, s1, s2, work, do
    )  # fmt: skip
    a30, a31, a32 = _wheel_field(wp, n, friction, J, Jinv, d, s0, s1, s2, held, work, xs, work, k3)
    c0, c1, c2 = dexpinv_rkmk4(u0, u1, u2, s0, s1, s2)
    u0, u1, u2 = h * c0, h * c1, h * c2
    s0, s1, s2 = x0 + h * a30, x1 + h * a31, x2 + h * a32
    for i in range(n):
        work[xs + i] = x[3 + i] + h * work[k3 + i]
    d = stage_disturbance(
        dist, dp, dfn, dpk, datt, t + h, R, u0, u1, u2, False, s0, s1, s2, work, do
    )  # fmt: skip
    a40, a41, a42 = _wheel_field(wp, n, friction, J, Jinv, d, s0, s1, s2, held, work, xs, work, k4)
    e0, e1, e2 = dexpinv_rkmk4(u0, u1, u2, s0, s1, s2)
    h6 = h / 6.0
    x_out[0] = x0 + (((a20 + a30) * 2.0 + a10) + a40) * h6
    x_out[1] = x1 + (((a21 + a31) * 2.0 + a11) + a41) * h6
    x_out[2] = x2 + (((a22 + a32) * 2.0 + a12) + a42) * h6
    for i in range(n):
        x_out[3 + i] = (
            x[3 + i] + (((work[k2 + i] + work[k3 + i]) * 2.0 + work[k1 + i]) + work[k4 + i]) * h6
        )
    right_multiply_exp_into(
        R,
        h6 * (x0 + 2.0 * (b0 + c0) + e0),
        h6 * (x1 + 2.0 * (b1 + c1) + e1),
        h6 * (x2 + 2.0 * (b2 + c2) + e2),
        R_out,
    )
