"""Rate- and torque-limited eigenaxis rotation (Wie & Lu's feedback logic).

B. Wie and J. Lu, "Feedback control logic for spacecraft eigenaxis rotations under slew rate and
control constraints", *Journal of Guidance, Control, and Dynamics* 18(6), 1995, pp. 1372–1379:
a quaternion feedback whose attitude term is saturated *inside* the rate feedback, with gains
proportional to the inertia, so that a rest-to-rest manoeuvre accelerates, coasts at the rate
limit and brakes about the eigenaxis. In the form implemented here (tracking form; regulation when
``ω_d = ω̇_d = 0``)::

    e_Ω = Ω − R̃ᵀ ω_d,          R̃ = R_dᵀ R,   q = (q₀, q_v) of R̃ with q₀ ≥ 0 (shortest way)
    s   = k q_v · min(1, c ω_max / (k ‖q_v‖))          (the saturated attitude term, ‖s‖ ≤ c ω_max)
    α   = −(s + c e_Ω)                                  (K = kJ, C = cJ: gains ∝ J)
    τ_fb = J α · min(1, min_i u_max,i / |(J α)_i|)     (vector scaling: the direction is kept)
    τ   = τ_fb + Ω × JΩ − J (Ω × R̃ᵀω_d − R̃ᵀω̇_d)

Assumptions (where the eigenaxis and the rate limit follow): the controller's ``J`` is the
plant's; the gyroscopic and reference terms are cancelled (with ``J`` known this turns the loop
into ``ė_Ω = α``); the manoeuvre starts at rest relative to the reference; the actuator delivers
the commanded torque within its per-axis box ``u_max`` (the law never asks for more: the feedback
is scaled as a vector, so the eigenaxis is kept even when the box is reached, at the price of
the time-optimal bang–bang); the error stays away from the antipode (``q₀ = 0``, where the
shortest way is not unique). Then ``e_Ω`` stays parallel to ``q_v``: from rest the rate rises as
a first-order lag toward ``−(k/c) s``, whose norm is at most ``ω_max`` — the coast rate of the
slew — and the rate limit is never exceeded. Below ``‖q_v‖ < c ω_max / k`` the law is the linear
quaternion PD ``α = −k q_v − c e_Ω``: small-angle natural frequency ``ω_n = √(k/2)`` and damping
``ζ = c / (2ω_n)`` on every axis (``q_v ≈ δθ/2``), which is how the common tuning protocol sets it
(:func:`wie_lu_gains`).

Wie & Lu saturate the attitude term per axis, with limits chosen from the initial error so that
the saturated term points along the initial eigenaxis; limits taken from the *current* ``q_v``
direction, as here (a vector saturation of ``k q_v`` at norm ``c ω_max``), give the same motion
along the eigenaxis and need no memory of the initial error (the law is static and ``reset``
keeps nothing). Only the structure and the gain scaling are taken from the paper; the tracking
terms (``ω_d``, ``ω̇_d``) are the usual feed-forward of the library's tracking laws.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._array_api import cross, namespace, safe_sqrt
from .._jit import JIT_ENABLED
from .._validation import as_array, check_inertia_3x3, check_positive_scalar
from ..lie import so3
from .array_law import ArrayLaw
from .base import (
    AttitudeController,
    AttitudeReference,
    AttitudeState,
    check_state_batch,
    finite_command,
    validated_rotation_and_rate,
)
from .kernel import ControllerKernel

__all__ = ["RateLimitedEigenaxis", "wie_lu_gains"]


def wie_lu_gains(omega_n: float, zeta: float) -> dict[str, float]:
    """``{"k": 2ω_n², "c": 2ζω_n}``: the small-angle closed loop of :class:`RateLimitedEigenaxis`
    (``δθ̈ + c δθ̇ + (k/2) δθ = 0``) with natural frequency ``omega_n`` [rad/s] and damping
    ``zeta``."""
    w = check_positive_scalar(omega_n, "omega_n")
    z = check_positive_scalar(zeta, "zeta")
    k, c = 2.0 * w * w, 2.0 * z * w
    if not (math.isfinite(k) and math.isfinite(c)):
        raise ValueError(f"omega_n: {w:g} rad/s with zeta {z:g} overflows the gains k = 2ω_n²")
    return {"k": k, "c": c}


def _box(u_max: object) -> np.ndarray | None:
    if u_max is None:
        return None
    if isinstance(u_max, bool):
        raise TypeError("u_max: expected a number, 3 numbers or None, got bool")
    a = as_array(u_max, "u_max")
    if a.shape not in ((), (3,)) or np.any(a <= 0.0):
        raise ValueError(f"u_max: expected a value > 0 or 3 of them, got {u_max!r}")
    out = np.array(np.broadcast_to(a, (3,)), dtype=np.float64)
    out.setflags(write=False)
    return out


def eigenaxis_torque(
    R: Any, w: Any, R_d: Any, w_d: Any, dw_d: Any, J: Any, k: Any, c: Any, max_rate: Any,
    u_max: Any = None,
) -> tuple[Any, dict[str, Any]]:  # fmt: skip
    """The law of the module docstring as a pure array function (NumPy ``(B, ...)`` batches or
    one spacecraft's JAX arrays, broadcasting): ``(τ, {"rate_saturated", "attitude_error_rad"})``.
    The one formula of :meth:`RateLimitedEigenaxis.command` and its array law."""
    xp = namespace(R, w, R_d, w_d, dw_d, k, c, max_rate)
    Rt = xp.swapaxes(R_d, -1, -2) @ R  # R̃ = R_dᵀR
    if xp is np:
        phi = np.asarray(so3.log(Rt), dtype=np.float64).reshape(Rt.shape[:-2] + (3,))
    else:
        phi = so3._log_angle_unchecked(Rt)[0]
    th = safe_sqrt(xp.sum(phi * phi, axis=-1), xp)
    scale = xp.where(th > 0.0, xp.sin(0.5 * th) / xp.where(th > 0.0, th, 1.0), 0.5)
    q_v = phi * scale[..., None]  # sin(θ/2)·â, q₀ = cos(θ/2) ≥ 0
    RtT = xp.swapaxes(Rt, -1, -2)
    w_dB = (RtT @ w_d[..., None])[..., 0]  # R̃ᵀω_d in body axes
    dw_dB = (RtT @ dw_d[..., None])[..., 0]
    e_w = w - w_dB
    nq = safe_sqrt(xp.sum(q_v * q_v, axis=-1), xp)
    lim = c * max_rate
    sat = xp.where(k * nq > lim, lim / xp.where(nq > 0.0, k * nq, 1.0), 1.0)
    s = k * q_v * sat[..., None]
    tau_fb = -(s + c * e_w) @ J.T
    if u_max is not None:
        m = xp.max(xp.abs(tau_fb) / u_max, axis=-1)
        tau_fb = tau_fb / xp.where(m > 1.0, m, 1.0)[..., None]
    ff = cross(w, w @ J.T) - (cross(w, w_dB) - dw_dB) @ J.T
    rows = {
        "rate_saturated": (sat < 1.0).astype(np.float64),
        "attitude_error_rad": 2.0 * xp.arcsin(xp.clip(nq, 0.0, 1.0)),
    }
    return tau_fb + ff, rows


def _eigenaxis_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """The diagnostics from the kernel's rows ``(..., 2)``."""
    return {"rate_saturated": rows[..., 0], "attitude_error_rad": rows[..., 1]}


class RateLimitedEigenaxis(AttitudeController):
    """Wie & Lu's rate- and torque-limited eigenaxis feedback (module docstring).

    Args:
        J: 3×3 inertia the controller assumes [kg·m²].
        k: attitude gain [1/s²] (``K = kJ``; per unit of the error quaternion's vector part).
        c: rate gain [1/s] (``C = cJ``).
        max_rate: slew-rate limit ``ω_max`` [rad/s] > 0.
        u_max: per-axis torque box [N·m] (scalar or 3 values), ``None`` = unlimited.

    Raises:
        ValueError: a gain, ``max_rate`` or ``u_max`` not finite and > 0, or ``J`` not an
            inertia (the message names it).
    """

    batched = True

    def __init__(
        self, J: object, k: float, c: float, max_rate: float, u_max: object = None
    ) -> None:
        J = check_inertia_3x3(J, "J").copy()
        J.setflags(write=False)
        self.J = J
        self.k = check_positive_scalar(k, "k")
        self.c = check_positive_scalar(c, "c")
        self.max_rate = check_positive_scalar(max_rate, "max_rate")
        self.u_max = _box(u_max)
        self._B: int | None = None
        self._diag: dict[str, np.ndarray] = {}

    def reset(self, t0: float, batch_size: int) -> None:
        """Stateless: remembers the batch size only."""
        self._B = int(batch_size)
        self._diag = {}

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m] (module docstring)."""
        R, w = validated_rotation_and_rate(state)
        B = check_state_batch(R, w, self._B if self._B is not None else R.shape[0])
        R_d = np.broadcast_to(np.asarray(reference.R_d, dtype=np.float64), (B, 3, 3))
        w_d = np.broadcast_to(np.asarray(reference.omega_d, dtype=np.float64), (B, 3))
        dw_d = np.broadcast_to(np.asarray(reference.omega_dot_d, dtype=np.float64), (B, 3))
        u, rows = eigenaxis_torque(
            R, w, R_d, w_d, dw_d, self.J, self.k, self.c, self.max_rate, self.u_max
        )
        self._diag = rows
        return finite_command(u, w)

    def array_law(self) -> ArrayLaw:
        """The law as a pure array function (:func:`eigenaxis_torque`) for the differentiable
        loop (:mod:`liecontrol.control.array_law`): gains ``(k, c)``, the slew-rate limit
        ``max_rate`` a further differentiable parameter; memoryless."""
        J, u_max = np.array(self.J), self.u_max
        defaults = {"max_rate": self.max_rate}

        def step(k, c, state, R, omega, R_d, omega_d, omega_dot_d, T, params=None):  # noqa: ANN001
            p = defaults if params is None else params
            u, rows = eigenaxis_torque(
                R, omega, R_d, omega_d, omega_dot_d, J, k, c, p["max_rate"], u_max
            )
            return u, state, rows

        return ArrayLaw(self.k, self.c, (), step, defaults)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.eigenaxis.rate_limited_eigenaxis_law`)
        for the simulator's fused loop, through the public seam :mod:`liecontrol.control.
        kernel`."""
        if not JIT_ENABLED:
            return None
        from .._kernels.eigenaxis import rate_limited_eigenaxis_law

        box = self.u_max if self.u_max is not None else np.ones(3)
        params = np.concatenate(
            [[self.k, self.c, self.max_rate, float(self.u_max is not None)], box, self.J.ravel()]
        )
        return ControllerKernel(
            rate_limited_eigenaxis_law, params, np.zeros((batch_size, 0)), 2,
            diagnostics=_eigenaxis_rows, finish=lambda state, diag: self._set_rows(diag),
        )  # fmt: skip

    def _set_rows(self, diag: np.ndarray) -> None:
        self._diag = {k: v.copy() for k, v in _eigenaxis_rows(diag).items()}

    def diagnostics(self) -> dict[str, np.ndarray]:
        """``rate_saturated`` (1 while the attitude term is at its rate-limit bound) and
        ``attitude_error_rad`` at the last sample."""
        return dict(self._diag)

    @property
    def coast_threshold(self) -> float:
        """Error angle [rad] above which the attitude term is saturated (the coast at
        ``max_rate``): ``2 asin(min(1, c ω_max / k))``."""
        return 2.0 * math.asin(min(1.0, self.c * self.max_rate / self.k))
