"""Prescribed-performance attitude control on SO(3).

**Funnel.** Each component of Lee's large-angle error vector ``e_R`` (``|e_R,i| ≤ 1``)
must stay inside

    |e_i(t)| < ρ(t),     ρ(t) = (ρ₀ − ρ_∞) e^{−l (t − t₀)} + ρ_∞,     0 < ρ_∞ < ρ₀ ≤ 1, l > 0

(Bechlioulis & Rovithakis, "Robust adaptive control of feedback linearizable MIMO nonlinear
systems with prescribed performance", IEEE TAC 53(9), 2008). ``ρ₀`` is either given (and then
checked against the error at the first control sample) or chosen there per spacecraft as
``ρ₀ = min(1, max(margin · max_i |e_i(0)|, 2ρ_∞))``; a funnel that does not contain the initial
error raises ``ValueError`` (e.g. a 180° error about a body axis, where ``|e_i| = 1``).

**Error transformation.** ``z = e_R / ρ`` and ``ε = T(z) = ½ ln((1 + z)/(1 − z)) = artanh z``
component-wise (:func:`transform`), a bijection ``(−1, 1) → ℝ``: a bounded ``ε`` means the funnel
is never left.

**Control law** (backstepping on the transformed error with the rate loop; derived for this
package — *reconstructed* from the cited PPC and geometric-control ingredients, not copied from one
paper). ``e_R`` is the vector part of the error quaternion of ``R̃ = R_dᵀR`` with
``q₀ = cos(θ/2) ≥ 0``, so ``ė_R = E e_Ω`` with ``E = ½(q₀ I + e_R^)`` and ``q̇₀ = −½ e_R·e_Ω``;
``E e_R = ½ q₀ e_R`` and ``E Eᵀ = ¼(I − e_R e_Rᵀ)`` (eigenvalues ¼, ¼q₀²). With
``γ_i = 1/(ρ(1 − z_i²))`` and ``w = γ ⊙ ε``, ``ε̇ = γ ⊙ (E e_Ω − (ρ̇/ρ) e_R)``. Virtual rate and
torque:

    α = 2 (ρ̇/ρ) e_R / max(q₀, q_min) − k₁ ρ² Eᵀ w,          s = e_Ω − α,
    M = Ω × JΩ − J(Ω^ R̃ᵀΩ_d − R̃ᵀΩ̇_d) + J (α̇ − k₂ s − k_c ρ² Eᵀ w),

with ``α̇`` evaluated analytically (:func:`virtual_rate`). On ``J Ω̇ + Ω × JΩ = M + d``,
``V = ½ k_c ρ² ‖ε‖² + ½ ‖s‖²`` gives (for ``q₀ ≥ q_min``)

    V̇ = k_c ρ ρ̇ ‖ε‖² − k₁ k_c ρ⁴ ‖Eᵀw‖² − k₂ ‖s‖² + sᵀ J⁻¹ d,

with ``ρ̇ ≤ 0``; since ``‖Eᵀw‖ ≥ (q₀/2)‖ε‖/ρ₀`` and ``ρ ≥ ρ_∞``, V is ultimately bounded for a
bounded disturbance, so ``ε`` is bounded and **``|e_i(t)| < ρ(t)`` for all t** — under the
assumptions of the analysis: continuous-time control (here sampled with a zero-order hold, so the
sample period must be short against the loop), the actuator delivers the commanded torque (no
saturation), the controller's ``J`` is the plant's (a mismatch acts as a state-dependent
disturbance) and the error stays away from θ = π (``q₀ > 0``). For ``q₀ < q_min`` the ``1/q₀``
feed-forward is regularised; the leftover term is sign-indefinite but of lower order in ``w``
than the ``−k₁k_cρ⁴‖Eᵀw‖²`` barrier term, which still dominates near the funnel boundary.

Linearisation at ``R = R_d`` (``e_R ≈ θ/2``, ``ρ̇ = 0``): every axis obeys
``θ̈ + (k₂ + k₁/4) θ̇ + (k₂ k₁/4 + k_c/4) θ = 0`` independently of J; :func:`ppc_gains` picks
``k₁, k₂, k_c`` for a natural frequency and damping ratio. Near the funnel boundary the effective
gain grows without bound — that is the mechanism of the guarantee.

**Never NaN.** If numerically ``|z_i|`` exceeds ``z_max`` (< 1) it is saturated there (finite,
large restoring torque); every sample with ``|e_i| ≥ ρ`` counts as a funnel violation and both
are reported by :meth:`PrescribedPerformance.diagnostics`.

Units: ``J`` [kg·m²], ``k₁``, ``k₂`` [1/s], ``k_c`` [1/s²], ``l`` [1/s], ``ρ`` dimensionless
(``e_R`` is ``sin(θ/2)`` times the axis), torque [N·m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._array_api import namespace
from .._kernels.prescribed_performance import N_DIAG as PPC_DIAG
from .._kernels.prescribed_performance import N_STATE as PPC_STATE
from .._kernels.prescribed_performance import ppc_law
from .._validation import (
    as_array,
    as_scalar,
    check_inertia_3x3,
    check_positive,
    check_positive_scalar,
)
from .array_law import ArrayLaw
from .base import AttitudeController, AttitudeReference, AttitudeState, finite_command
from .geometric_pd import GeometricPD, _cross, geometric_pd_torque
from .kernel import ControllerKernel

__all__ = [
    "Funnel",
    "PrescribedPerformance",
    "ppc_gains",
    "transform",
    "transform_inverse",
    "transform_derivative",
    "virtual_rate",
]


# ----------------------------------------------------------------------------------------------
# pure functions


def transform(z: object) -> np.ndarray:
    """Error transformation ``ε = ½ ln((1 + z)/(1 − z)) = artanh z`` for ``|z| < 1``.

    Odd, strictly increasing, ``T(0) = 0``, ``T'(z) = 1/(1 − z²)``, ``T(z) → ±∞`` as ``z → ±1``.
    Raises ``ValueError`` for ``|z| ≥ 1`` (outside the funnel).
    """
    a = as_array(z, "z")
    if np.any(np.abs(a) >= 1.0):
        raise ValueError(
            f"z: must satisfy |z| < 1 (inside the funnel), got max |z| = {float(np.abs(a).max())!r}"
        )
    return np.arctanh(a)


def transform_inverse(eps: object) -> np.ndarray:
    """Inverse of :func:`transform`: ``z = tanh ε`` (maps ℝ onto (−1, 1))."""
    return np.tanh(as_array(eps, "eps"))


def transform_derivative(z: object) -> np.ndarray:
    """``dε/dz = 1/(1 − z²)`` for ``|z| < 1``."""
    a = as_array(z, "z")
    if np.any(np.abs(a) >= 1.0):
        raise ValueError(f"z: must satisfy |z| < 1, got max |z| = {float(np.abs(a).max())!r}")
    return 1.0 / (1.0 - a * a)


@dataclass(frozen=True)
class Funnel:
    """Performance funnel ``ρ(τ) = (ρ₀ − ρ_∞) e^{−lτ} + ρ_∞`` (τ = time since the start).

    Attributes:
        rho_inf: steady-state bound ρ_∞, ``0 < ρ_∞ < 1``.
        decay: rate ``l`` [1/s] > 0.
        rho0: initial width ``ρ_∞ < ρ₀ ≤ 1``, or ``None`` to choose it from the initial error
            (``ρ₀ = min(1, max(margin · max|e_i(0)|, 2ρ_∞))``).
        margin: factor > 1 of the automatic choice.
    """

    rho_inf: float
    decay: float
    rho0: float | None = None
    margin: float = 1.25

    def __post_init__(self) -> None:
        rho_inf = check_positive(self.rho_inf, "rho_inf")
        if not isinstance(rho_inf, float) or rho_inf >= 1.0:
            raise ValueError(f"rho_inf: must be a scalar in (0, 1), got {self.rho_inf!r}")
        decay = check_positive(self.decay, "decay")
        if not isinstance(decay, float):
            raise ValueError("decay: must be a scalar [1/s]")
        margin = check_positive(self.margin, "margin")
        if not isinstance(margin, float) or margin <= 1.0:
            raise ValueError(f"margin: must be a scalar > 1, got {self.margin!r}")
        if self.rho0 is not None:
            rho0 = check_positive(self.rho0, "rho0")
            if not isinstance(rho0, float):
                raise ValueError("rho0: must be a scalar")
            if rho0 <= rho_inf:
                raise ValueError(
                    f"rho0: the funnel must shrink, need rho_inf < rho0, got rho0 = {rho0!r} <= "
                    f"rho_inf = {rho_inf!r}"
                )
            if rho0 > 1.0:
                raise ValueError(
                    f"rho0: must be <= 1 (the bound of the large-angle error), got {rho0!r}"
                )
            object.__setattr__(self, "rho0", rho0)
        object.__setattr__(self, "rho_inf", rho_inf)
        object.__setattr__(self, "decay", decay)
        object.__setattr__(self, "margin", margin)

    def initial_width(self, e0: object, tau: float = 0.0) -> np.ndarray:
        """``ρ₀`` per spacecraft ``(B,)`` for initial errors ``e0`` ``(B, 3)`` sampled ``tau``
        seconds after the funnel's start; raises ``ValueError`` if the funnel would not contain
        them (``max_i |e_i| ≥ ρ(tau)``)."""
        e0 = as_array(e0, "e0", (3,))
        m0 = np.abs(e0).max(axis=-1)
        rho0 = funnel_initial_width(m0, self.rho_inf, self.margin, self.rho0)
        width = self.rho(tau, rho0)[0]
        bad = m0 >= width
        if np.any(bad):
            b = int(np.argmax(bad))
            raise ValueError(
                f"rho0: funnel infeasible at t = 0 for spacecraft {b}: max_i |e_R,i(0)| = "
                f"{m0[b]:.6g} >= rho = {width[b]:.6g} (the large-angle error components are at "
                f"most 1; an error of 180° about a body axis cannot be enclosed)"
            )
        return rho0

    def rho(self, tau: object, rho0: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(ρ, ρ̇, ρ̈)`` at ``tau`` for widths ``rho0`` (broadcast)."""
        return funnel_rho(as_array(tau, "tau"), as_array(rho0, "rho0"), self.rho_inf, self.decay)


def funnel_rho(tau: Any, rho0: Any, rho_inf: Any, decay: Any) -> tuple[Any, Any, Any]:
    """``(ρ, ρ̇, ρ̈)`` of the funnel ``ρ(τ) = (ρ₀ − ρ_∞) e^{−lτ} + ρ_∞`` (Bechlioulis &
    Rovithakis, IEEE TAC 2008) at ``τ`` seconds after its start; pure, NumPy or JAX,
    broadcasting. No validation: :meth:`Funnel.rho` is the checked entry point."""
    xp = namespace(tau, rho0, rho_inf, decay)
    a = (rho0 - rho_inf) * xp.exp(-decay * tau)
    return a + rho_inf, -decay * a, decay * decay * a


def funnel_initial_width(m0: Any, rho_inf: Any, margin: Any, rho0: float | None) -> Any:
    """The funnel's initial width for the largest initial error component ``m0 = max_i
    |e_R,i(0)|``: the given ``rho0``, or ``min(1, max(margin · m0, 2ρ_∞))`` (module
    docstring); pure, NumPy or JAX, broadcasting over ``m0``. Feasibility (``m0 < ρ``) is the
    caller's check."""
    xp = namespace(m0, rho_inf, margin)
    if rho0 is None:
        return xp.minimum(1.0, xp.maximum(margin * m0, 2.0 * rho_inf))
    return xp.full(xp.shape(m0), rho0)


def ppc_gains(omega_n: float, zeta: float = 0.9, outer: float = 0.25) -> tuple[float, float, float]:
    """``(k₁, k₂, k_c)`` giving every axis the linearised natural frequency ``omega_n`` [rad/s]
    and damping ``zeta`` (module docstring): outer-loop rate ``λ₁ = outer · ω_n``, ``k₁ = 4λ₁``,
    ``k₂ = 2ζω_n − λ₁``, ``k_c = 4(ω_n² − k₂λ₁)``. Needs ``k₂ > 0`` and ``k_c > 0``."""
    omega_n = check_positive_scalar(omega_n, "omega_n")
    zeta = check_positive_scalar(zeta, "zeta")
    outer = check_positive_scalar(outer, "outer")
    lam = outer * omega_n
    k2 = 2.0 * zeta * omega_n - lam
    if not math.isfinite(omega_n * omega_n * max(1.0, zeta)):
        raise ValueError(f"omega_n: the gains (∝ ω_n²) overflow float64 (ω_n = {omega_n:.3g})")
    if not math.isfinite(k2 * lam):
        raise ValueError(f"outer: the gains (∝ outer·ω_n²) overflow float64 (outer = {outer:.3g})")
    kc = 4.0 * (omega_n**2 - k2 * lam)
    if k2 <= 0.0 or kc <= 0.0:
        raise ValueError(
            f"outer: {outer!r} gives non-positive gains (k2 = {k2:.3g}, kc = {kc:.3g}) for "
            f"zeta = {zeta!r}; use a smaller outer ratio"
        )
    return 4.0 * lam, k2, kc


@dataclass(frozen=True)
class VirtualRate:
    """Outputs of :func:`virtual_rate` (all ``(B, 3)`` except ``z_clipped`` ``(B, 3)`` bool)."""

    alpha: np.ndarray
    alpha_dot: np.ndarray
    ETw: np.ndarray
    eps: np.ndarray
    z: np.ndarray
    z_clipped: np.ndarray


def virtual_rate(
    e_R: Any,
    q0: Any,
    e_Omega: Any,
    rho: Any,
    rho_dot: Any,
    rho_ddot: Any,
    k1: Any,
    q_min: float = 0.1,
    z_max: float = 0.999,
) -> VirtualRate:
    """Virtual rate ``α``, its time derivative ``α̇`` along ``ė_R = E e_Ω`` and ``Eᵀw``.

    ``α = 2(ρ̇/ρ) e_R / max(q₀, q_min) − k₁ ρ² Eᵀ w`` (module docstring). Inputs: ``e_R``,
    ``e_Omega`` ``(..., 3)``; ``q0 = cos(θ/2)`` and ``rho``, ``rho_dot``, ``rho_ddot``
    ``(...)`` (a batch ``(B,)``, or scalars for one spacecraft). Components with
    ``|z| > z_max`` are saturated at ``±z_max`` (their ``ż`` is taken as 0). No validation
    (hot path). Pure, NumPy or JAX: every division is by ``ρ > 0``, ``1 − z_c² ≥ 1 − z_max²``
    or ``max(q₀, q_min)``, so values and derivatives stay finite at ``e_R = 0`` and near π.
    """
    xp = namespace(e_R, q0, e_Omega, rho, rho_dot, k1)
    r = rho[..., None]
    rd = rho_dot[..., None]
    rdd = rho_ddot[..., None]
    q = q0[..., None]
    e_dot = 0.5 * (q * e_Omega + _cross(e_R, e_Omega))
    q_dot = -0.5 * xp.sum(e_R * e_Omega, axis=-1, keepdims=True)

    z = e_R / r
    clipped = xp.abs(z) > z_max
    zc = xp.clip(z, -z_max, z_max)
    omz = 1.0 - zc * zc
    eps = xp.arctanh(zc)
    g = 1.0 / (r * omz)
    z_dot = xp.where(clipped, 0.0, (e_dot - zc * rd) / r)
    eps_dot = z_dot / omz
    g_dot = g * (-rd / r + 2.0 * zc * z_dot / omz)
    w = g * eps
    w_dot = g_dot * eps + g * eps_dot
    ETw = 0.5 * (q * w - _cross(e_R, w))
    ETw_dot = 0.5 * (q_dot * w - _cross(e_dot, w) + q * w_dot - _cross(e_R, w_dot))

    low = q < q_min
    qb = xp.where(low, q_min, q)
    qb_dot = xp.where(low, 0.0, q_dot)
    ratio = rd / r
    a_ff = 2.0 * ratio * e_R / qb
    a_ff_dot = 2.0 * (
        (rdd / r - ratio * ratio) * e_R / qb + ratio * e_dot / qb - ratio * e_R * qb_dot / (qb * qb)
    )
    alpha = a_ff - k1 * r * r * ETw
    alpha_dot = a_ff_dot - k1 * (2.0 * r * rd * ETw + r * r * ETw_dot)
    return VirtualRate(alpha=alpha, alpha_dot=alpha_dot, ETw=ETw, eps=eps, z=z, z_clipped=clipped)


def ppc_torque(
    e_R: Any, e_Omega: Any, Psi: Any, ff: Any, J: Any, rho: Any, rho_dot: Any, rho_ddot: Any,
    k1: Any, k2: Any, kc: Any, q_min: float, z_max: float,
) -> tuple[Any, VirtualRate, Any, Any]:  # fmt: skip
    """The prescribed-performance torque from the large-angle error (module docstring)::

        s = e_Ω − α,   M = ff + J (α̇ − k₂ s − k_c ρ² Eᵀw),   q₀ = 1 − Ψ/2 = cos(θ/2),

    with ``α``, ``α̇``, ``Eᵀw`` of :func:`virtual_rate` and ``ff = Ω × JΩ − J(Ω^ R̃ᵀΩ_d −
    R̃ᵀΩ̇_d)`` the geometric PD's feed-forward. Returns ``(M, virtual rate, s, outside)``,
    ``outside`` whether some ``|e_R,i| ≥ ρ`` (a funnel violation). Pure, NumPy or JAX,
    broadcasting over leading axes (``e_R`` ``(..., 3)``, ``Psi``, ``rho``… ``(...)``)."""
    xp = namespace(e_R, e_Omega, Psi, ff, rho, k2, kc)
    q0 = 1.0 - 0.5 * Psi  # large-angle Ψ = 2 − 2cos(θ/2)
    vr = virtual_rate(e_R, q0, e_Omega, rho, rho_dot, rho_ddot, k1, q_min=q_min, z_max=z_max)
    s = e_Omega - vr.alpha
    acc = vr.alpha_dot - k2 * s - kc * (rho * rho)[..., None] * vr.ETw
    outside = xp.any(xp.abs(e_R) >= rho[..., None], axis=-1)
    return ff + acc @ J.T, vr, s, outside


# ----------------------------------------------------------------------------------------------
# controller


class PrescribedPerformance(AttitudeController):
    """Prescribed-performance controller on SO(3) (module docstring).

    Args:
        J: 3×3 inertia the controller assumes [kg·m²].
        rho_inf: steady-state funnel width ρ_∞ (on each component of ``e_R``), ``0 < ρ_∞ < 1``.
        decay: funnel rate ``l`` [1/s] > 0.
        rho0: initial width (``ρ_∞ < ρ₀ ≤ 1``) or ``None`` (default) to choose it from the
            initial error with ``margin``.
        k1, k2, kc: gains [1/s], [1/s], [1/s²] (:func:`ppc_gains`); default
            ``ppc_gains(0.03, 0.9)``.
        margin: factor > 1 of the automatic ρ₀.
        q_min: floor of ``cos(θ/2)`` in the feed-forward, in (0, 1).
        z_max: saturation of ``|e_i/ρ|`` inside the transformation, in (0, 1).

    ``command`` returns ``(B, 3)``. ``diagnostics()``: ``Psi`` ``(B,)``, ``e_R``, ``e_Omega``,
    ``eps`` (transformed error), ``alpha`` (virtual rate), ``s`` ``(B, 3)``, ``rho`` ``(B,)``,
    ``funnel_violations`` ``(B,)`` (cumulative count of samples with some ``|e_i| ≥ ρ``) and
    ``edge_saturated`` ``(B,)`` (this sample clipped ``|z|`` at ``z_max``). After the first
    ``command`` the attribute ``rho0`` holds the funnel's initial width per spacecraft ``(B,)``.
    """

    batched = True

    def __init__(
        self,
        J: object,
        rho_inf: float,
        decay: float,
        *,
        rho0: float | None = None,
        k1: float | None = None,
        k2: float | None = None,
        kc: float | None = None,
        margin: float = 1.25,
        q_min: float = 0.1,
        z_max: float = 0.999,
    ) -> None:
        J = check_inertia_3x3(J, "J")
        self.funnel = Funnel(rho_inf=rho_inf, decay=decay, rho0=rho0, margin=margin)
        default = ppc_gains(0.03, 0.9)
        gains = []
        for name, k, d in (("k1", k1, default[0]), ("k2", k2, default[1]), ("kc", kc, default[2])):
            v = d if k is None else check_positive(k, name)
            if not isinstance(v, float):
                raise ValueError(f"{name}: must be a positive scalar")
            gains.append(v)
        self.k1, self.k2, self.kc = gains
        for name, v in (("q_min", q_min), ("z_max", z_max)):
            x = check_positive(v, name)
            if not isinstance(x, float) or x >= 1.0:
                raise ValueError(f"{name}: must be a scalar in (0, 1), got {v!r}")
        self.q_min = float(q_min)
        self.z_max = float(z_max)
        # unit-gain PD: validates state and reference and yields e_R, e_Ω and the feed-forward
        self._pd = GeometricPD(J, 1.0, 1.0, error="large_angle")
        self.J = self._pd.J
        self._batch: int | None = None

    def __repr__(self) -> str:
        f = self.funnel
        return (
            f"PrescribedPerformance(rho_inf={f.rho_inf!r}, decay={f.decay!r}, rho0={f.rho0!r}, "
            f"k1={self.k1:.4g}, k2={self.k2:.4g}, kc={self.kc:.4g})"
        )

    def reset(self, t0: float, batch_size: int) -> None:
        """Start the funnel at ``t0``; ρ₀ is fixed at the first ``command``."""
        self._pd.reset(t0, batch_size)
        self._batch = int(batch_size)
        self._t0 = as_scalar(t0, "t0")
        self.rho0: np.ndarray | None = None
        self._violations = np.zeros(self._batch, dtype=np.int64)
        self._diag: dict[str, np.ndarray] = {}

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m]."""
        if self._batch is None:
            raise RuntimeError("PrescribedPerformance.command: call reset(t0, batch_size) first")
        t = as_scalar(t, "t")
        tau = t - self._t0
        if tau < 0.0:
            raise ValueError(f"t: {t!r} is before the funnel's start t0 = {self._t0!r}")
        M_pd = self._pd.command(t, state, reference)
        d = self._pd.diagnostics()
        Psi, e_R, e_W = d["Psi"], d["e_R"], d["e_Omega"]
        # with unit gains M_PD = ff − e_R − e_Ω: recover the exact feed-forward
        # ff = Ω × JΩ − J(Ω^ R̃ᵀΩ_d − R̃ᵀΩ̇_d) of the PD instead of recomputing it
        ff = M_pd + e_R + e_W
        if self.rho0 is None:
            self.rho0 = self.funnel.initial_width(e_R, tau)
        rho, rho_dot, rho_ddot = self.funnel.rho(tau, self.rho0)
        M, vr, s, outside = ppc_torque(
            e_R, e_W, Psi, ff, self.J, rho, rho_dot, rho_ddot, self.k1, self.k2, self.kc,
            self.q_min, self.z_max,
        )  # fmt: skip
        self._violations = self._violations + outside
        d.update(
            eps=vr.eps,
            alpha=vr.alpha,
            s=s,
            rho=rho,
            funnel_violations=self._violations.copy(),
            edge_saturated=np.any(vr.z_clipped, axis=-1),
        )
        self._diag = d
        return finite_command(M, state.omega)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.prescribed_performance.ppc_law`) for the
        simulator's fused loop (:mod:`liecontrol.control.kernel`); state: ρ₀, violations."""
        if self._batch is None:
            return None
        f = self.funnel
        B = int(batch_size)
        params = np.concatenate(
            [
                self._pd.fused_kernel(B).params,
                [f.rho_inf, f.decay, -1.0 if f.rho0 is None else f.rho0, f.margin],
                [self.k1, self.k2, self.kc, self.q_min, self.z_max, self._t0],
            ]
        )
        state = np.zeros((B, PPC_STATE))
        if self.rho0 is not None:
            state[:, 0] = 1.0
            state[:, 1] = self.rho0
        state[:, 2] = self._violations
        return ControllerKernel(ppc_law, params, state, PPC_DIAG, _ppc_rows, self._finish)

    def _kernel_reason(self) -> str:
        return "a controller that was not reset"

    def array_law(self) -> ArrayLaw:
        """The law as a pure array function for the differentiable loop
        (:mod:`liecontrol.control.array_law`): the unit-gain geometric PD's errors and
        feed-forward (:func:`~liecontrol.control.geometric_pd.geometric_pd_torque`), the funnel
        (:func:`funnel_initial_width`, :func:`funnel_rho`) and :func:`ppc_torque` — the
        functions :meth:`command` calls.

        Differentiable gains: ``k_R`` is ``k_c`` [1/s²] (the stiffness on the transformed
        error), ``k_Omega`` is ``k₂`` [1/s] (the rate loop); further parameters (``params``):
        ``k1`` [1/s] and the funnel's ``rho_inf`` and ``decay`` [1/s]. Timed (the funnel reads
        the clock). The scan carries ``(started, ρ₀, t_start, violations)``: the funnel starts
        at the first sample (simulate resets the controller at its ``t0``, which is the first
        sample's time), where ρ₀ is chosen from the error as :meth:`Funnel.initial_width`
        does; a funnel that does not contain that error gives a NaN torque there (the route
        flags the member as diverged; :meth:`command` raises ``ValueError``), as the compiled
        kernel does."""
        f = self.funnel
        J = np.array(self.J)
        given, margin, q_min, z_max = f.rho0, f.margin, self.q_min, self.z_max

        def step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T, *, params, t):  # noqa: ANN001
            xp = namespace(R, omega, t)
            started, rho0, t_start, violations = state
            k1, rho_inf, decay = params["k1"], params["rho_inf"], params["decay"]
            M_pd, Psi, e_R, e_W = geometric_pd_torque(
                R, omega, R_d, omega_d, omega_dot_d, J, 1.0, 1.0, "large_angle"
            )
            ff = M_pd + e_R + e_W  # the PD's exact feed-forward (as command recovers it)
            m0 = xp.max(xp.abs(e_R), axis=-1)
            rho0 = xp.where(started, rho0, funnel_initial_width(m0, rho_inf, margin, given))
            t_start = xp.where(started, t_start, t)
            rho, rho_dot, rho_ddot = funnel_rho(t - t_start, rho0, rho_inf, decay)
            infeasible = xp.logical_not(started) & (m0 >= rho)
            M, vr, s, outside = ppc_torque(
                e_R, e_W, Psi, ff, J, rho, rho_dot, rho_ddot, k1, k_Omega, k_R, q_min, z_max
            )
            M = xp.where(infeasible, xp.nan, M)
            violations = violations + xp.where(infeasible, 0, outside.astype(violations.dtype))
            d = {"Psi": Psi, "e_R": e_R, "e_Omega": e_W, "eps": vr.eps, "alpha": vr.alpha,
                 "s": s, "rho": rho, "funnel_violations": violations,
                 "edge_saturated": xp.any(vr.z_clipped, axis=-1)}  # fmt: skip
            return M, (xp.ones((), dtype=bool), rho0, t_start, violations), d

        state0 = (np.zeros((), dtype=bool), np.zeros(()), np.zeros(()), np.zeros((), np.int64))
        params = {"k1": self.k1, "rho_inf": f.rho_inf, "decay": f.decay}
        return ArrayLaw(self.kc, self.k2, state0, step, params=params, timed=True)

    def _finish(self, state: np.ndarray, diag: np.ndarray) -> None:
        """Funnel width, violation counts and diagnostics after a compiled run."""
        if state[0, 0] != 0.0:
            self.rho0 = state[:, 1].copy()
        self._violations = state[:, 2].astype(np.int64)
        self._pd._set_diagnostics(diag[:, :7].copy())
        self._diag = _ppc_rows(diag)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last-sample internals (see the class docstring); empty before the first command."""
        return dict(self._diag)


def _ppc_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """The controller's diagnostics from its kernel rows ``(..., 19)``."""
    return {
        "Psi": rows[..., 0].copy(),
        "e_R": rows[..., 1:4].copy(),
        "e_Omega": rows[..., 4:7].copy(),
        "eps": rows[..., 7:10].copy(),
        "alpha": rows[..., 10:13].copy(),
        "s": rows[..., 13:16].copy(),
        "rho": rows[..., 16].copy(),
        "funnel_violations": rows[..., 17].astype(np.int64),
        "edge_saturated": rows[..., 18] != 0.0,
    }
