"""Adaptive fault-tolerant geometric attitude control on SO(3).

Fault model (the multiplicative/additive actuator fault of the fault-tolerant attitude control
literature; Yin, Xiao, Ding et al., "A review on recent development of spacecraft attitude
fault tolerant control system", IEEE Trans. Industrial Electronics 63(5), 2016)::

    J Ω̇ = −Ω × JΩ + E τ + d,      E = diag(ε₁, ε₂, ε₃),  0 < ε_min ≤ εᵢ ≤ 1,   ‖d‖ ≤ β,

``E`` the unknown effectiveness of the delivered torque (a partial loss of an actuator), ``d``
the lumped bias of the faulty units plus the external disturbance, of unknown bound ``β``.

Errors on SO(3) (no chart, so no unwinding): ``R̃ = R_dᵀR``, the log error ``x = log(R̃)^∨``
(‖x‖ = θ ∈ [0, π]) and ``e_Ω = Ω − R̃ᵀΩ_d``; with ``d/dt R̃ = R̃ e_Ω^`` the log error obeys
``ẋ = J_r⁻¹(x) e_Ω`` (J_r⁻¹(x) = I + ½x^ + (1 − (θ/2)cot(θ/2))/θ² x^², the inverse right
Jacobian of SO(3)), and ``xᵀJ_r⁻¹(x) = xᵀ``. The sliding variable, a first-order sliding
surface built on that configuration error (in the spirit of the Lie-group sliding surfaces of
Meng, Yang & Jiang, "Second-order sliding-mode on SO(3) and fault-tolerant spacecraft attitude
control", Automatica 149, 2023, and Shi, Zhou & Zhou, "Adaptive fault-tolerant attitude
tracking control of rigid spacecraft on Lie group with fixed-time convergence", Asian J.
Control 22(1), 2020 — here with linear rather than fixed-time convergence), is::

    s = e_Ω + λ x.

Control (per spacecraft)::

    v = Ω × JΩ − J(Ω^ R̃ᵀΩ_d − R̃ᵀΩ̇_d) − λ J J_r⁻¹(x) e_Ω − K s − β̂ s / (‖s‖ + σ),
    τ = k̂ ∘ v,

with adaptive laws (projection onto the boxes by clipping)::

    k̂̇ᵢ = −γ_k sᵢ vᵢ,         k̂ᵢ ∈ [1, k_max]      (k̂ᵢ estimates 1/εᵢ),
    β̂̇ = γ_β ‖s‖² / (‖s‖ + σ),  β̂ ∈ [0, β_max].

Stability (continuous time, constant E and β, inside the boxes). With
``J ṡ = E τ + d + (the terms v cancels) = v + Σᵢ εᵢ k̃ᵢ vᵢ eᵢ + d``, ``k̃ᵢ = k̂ᵢ − 1/εᵢ``, take
``V = ½ sᵀJs + Σᵢ εᵢ k̃ᵢ² / (2γ_k) + (β̂ − β)² / (2γ_β)``::

    V̇ = −sᵀKs − β̂‖s‖²/(‖s‖+σ) + sᵀd + Σᵢ εᵢ k̃ᵢ (sᵢvᵢ + k̂̇ᵢ/γ_k) + (β̂ − β) β̂̇/γ_β
       ≤ −sᵀKs + β‖s‖ − β‖s‖²/(‖s‖+σ) = −sᵀKs + β σ ‖s‖/(‖s‖+σ) ≤ −sᵀKs + β σ.

(The k̃ terms cancel by the adaptive law, the β̂ terms by β̂̇; projection onto a box containing
the true values only makes the bracket terms more negative.) So s, k̂, β̂ stay bounded and s is
uniformly ultimately bounded in ‖s‖ ≤ √(βσ/λ_min(K)) (σ → 0: s → 0 by Barbalat). On the
surface s = 0 the error obeys ẋ = −λ J_r⁻¹(x) x = −λ x, i.e. θ decays exponentially along the
geodesic — for every start with θ < π (almost-global: at θ = π the log picks one of the two
geodesics, the set of measure zero no continuous law on SO(3) can avoid). With a bounded
residual |s| ≤ s̄ the attitude error is bounded by θ ≤ s̄/λ. The adaptation needs no fault
detection: a loss of effectiveness shows as sᵢvᵢ < 0 and raises k̂ᵢ; a bias shows as a
persistent s and raises β̂.

**Which faults the proof covers.** The argument above needs ``E`` constant, **diagonal in body
axes** and inside the box (``1/k_max ≤ εᵢ ≤ 1``), and the lumped ``d`` bounded by ``β_max``:

* covered — a per-axis loss of effectiveness of an actuator whose units are the body axes (the
  ideal three-axis torquer's axis faults, three wheels along the body axes), with
  ``εᵢ ≥ 1/k_max``; an additive bias (a gimbal-rate or wheel-torque bias enters ``d``) with
  ``‖d‖ ≤ β_max``; a unit removed *and* reconfigured out by the steering (``E ≈ I`` again, up
  to the remaining cluster's singularities);
* **not covered** — a per-unit fault of a skewed cluster (the SGCMG pyramid, a wheel pyramid):
  the body-axis effect ``E = A(δ) diag(e) A(δ)⁺`` (``A`` the cluster Jacobian, ``e`` the
  per-unit efficiencies, ``A⁺`` the steering's right inverse) is non-diagonal, non-symmetric
  and turns with the gimbal angles (30 % on gimbal 0 of the pyramid at δ = 0: eigenvalues
  0.475, 1, 1), so the per-axis cancellation ``Σᵢ εᵢ k̃ᵢ sᵢvᵢ`` fails. What does hold: the
  eigenvalues of ``E`` lie in ``[min eᵢ, 1]`` for every ``δ`` (``A D A⁺`` has the spectrum of
  the compression of ``D`` to the row space of ``A``), so ``k_max ≥ 1/min eᵢ`` is necessary
  for k̂ to be able to compensate — :func:`fault_tolerant_gains` defaults to
  :data:`FAULT_FAMILY_K_MAX` = 3.5, covering unit efficiencies down to 0.29, hence the
  benchmark family's 30 % unit. Results of this law on such faults (the ``fault-efficiency-*``
  scenarios) are empirical, not a consequence of the proof;
  :func:`body_axis_effectiveness` computes ``E`` for a given cluster state.

The law needs no fault detection (the adaptation absorbs the fault); the benchmark runner's
steering reconfiguration for lost units is told the exact fault time (an oracle), which is not
part of this law.

**Adaptive boundary layer** (``adaptive_sigma=True``, the default of
:func:`fault_tolerant_gains`). A sampled relay of amplitude k̂β̂ held for T_s needs a boundary
layer at least as wide as the step it makes in s, σ ≥ k̂β̂ T_s/λ_min(J) — the balance condition
of Slotine & Li (*Applied Nonlinear Control*, Prentice Hall, 1991, §7.2) with the sample rate as
the bandwidth; a fixed σ̄ = k_max β_max T_s/λ_min(J) meets it for the worst case k̂ = k_max,
β̂ = β_max, and then with k̂ ≈ 1 leaves the robust term k_max times softer than the sampled loop
allows. The law interpolates::

    σ(t) = σ̄ (1 − (1 − k̂_∞/k_max) β̂/β_max),      k̂_∞ = max_i k̂_i,

σ̄ at β̂ = 0 (so the nominal small-angle loop, where β̂ has hardly moved, keeps its poles), the
balance width σ̄ k̂_∞/k_max at β̂ = β_max, and in between above the balance line σ̄ k̂_∞β̂/(k_max
β_max) (the chord of a line through the origin): the sampled robust gain k̂β̂/σ stays
≤ λ_min(J)/T_s. Since σ(t) ≤ σ̄ and the β̂ law uses the same σ(t), the Lyapunov bound above
holds unchanged with σ̄. Steady residual against a persistent ‖d‖ < k̂β̂ (linear region,
ignoring K, e_Ω = 0): ‖s‖ ≈ σ(t)‖d‖/(k̂β̂ − ‖d‖), θ ≈ ‖s‖/λ — it depends on T_s, λ (∝ ω_n),
λ_min(J), ‖d‖ and how far β̂ has grown towards β_max (through γ_β and the run length). In the
benchmark's fault family (SGCMG bus, λ_min(J) ≈ 4.8e3 kg·m², T_s = 0.2 s, ω_n = 0.03 rad/s,
β_max = 0.5 N·m, ‖d‖ ≤ 0.3 N·m) this gives the APE ≤ 0.1° the scenarios require (0.057–0.084°
measured, against 0.101–0.132° with the fixed σ̄; ``docs/faults.md``); it is a measured
property of those cells, not a consequence of the proof (the per-unit faults there are not
covered, below).

Sampling: each ``command(t, ...)`` first advances (k̂, β̂) over the time since the previous call
with the rates held from the previous sample (explicit Euler), then computes τ. With
``max_torque`` the output is clipped and k̂ is not adapted on a saturated sample (the delivered
torque then is not k̂ ∘ v).

Tuning (:func:`fault_tolerant_gains`): the small-angle nominal loop (k̂ = 1, β̂ = 0) is
``ṡ = −J⁻¹K s``, ``ẋ = −λx + s``: real poles at −‖J⁻¹K‖ and −λ. ``K = 1.15 ω_n J`` and
``λ = ω_n / 1.15`` put them at −1.15 ω_n and −0.87 ω_n: product ω_n², i.e. the spec's natural
frequency, with damping (1.15 + 1/1.15)/2 ≈ 1.01 (real poles, as for the terminal sliding
mode; two distinct poles rather than a double one, which a sampled record identifies poorly).
The initial torque of a rest-to-rest step θ₀ is then K λ θ₀ = ω_n² J θ₀, the geometric PD's.

Units: ``J`` [kg·m²], ``K`` [N·m·s/rad], ``lam`` [1/s], ``sigma`` [rad/s], ``beta_max`` [N·m],
``gamma_k`` [1/(N·m·rad/s)·1/s], ``gamma_beta`` [N·m/rad].
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._array_api import cross, namespace, safe_sqrt
from .._kernels.fault_tolerant import N_DIAG as FT_DIAG
from .._kernels.fault_tolerant import N_STATE as FT_STATE
from .._kernels.fault_tolerant import fault_tolerant_law
from .._validation import as_array, as_scalar, check_inertia_3x3, check_positive_scalar
from ..lie import so3
from .array_law import ArrayLaw
from .base import (
    AttitudeController,
    AttitudeReference,
    AttitudeState,
    check_state_batch,
    finite_command,
)
from .kernel import ControllerKernel

__all__ = [
    "AdaptiveFaultTolerantSO3",
    "fault_tolerant_gains",
    "inverse_right_jacobian_apply",
    "body_axis_effectiveness",
    "FAULT_FAMILY_K_MAX",
]

#: Default ``k_max`` of :func:`fault_tolerant_gains`: 1/k_max ≈ 0.29 is below the smallest
#: per-unit efficiency the benchmarks inject (30 %), and the body-axis effect of a per-unit
#: efficiency ``e`` has eigenvalues ≥ min e (module docstring).
FAULT_FAMILY_K_MAX = 3.5


# the compiled kernels' cross product, NumPy or JAX (liecontrol._array_api.cross)
_cross = cross


def _norm(v: Any, xp: Any) -> Any:
    """‖v‖ on the last axis: NumPy's norm, or a safe square root under JAX (a finite
    derivative at v = 0, where s vanishes at the target)."""
    return np.linalg.norm(v, axis=-1) if xp is np else safe_sqrt(xp.sum(v * v, axis=-1), xp)


def inverse_right_jacobian_apply(x: object, y: object) -> np.ndarray:
    """J_r⁻¹(x) y = y + ½ x × y + c(θ) x × (x × y), c = (1 − (θ/2) cot(θ/2))/θ², θ = ‖x‖ ≤ π:
    the rate of the log error, d/dt log(R̃)^∨ = J_r⁻¹(log(R̃)^∨) e_Ω when d/dt R̃ = R̃ e_Ω^.
    ``x``, ``y`` ``(..., 3)``; c → 1/12 as θ → 0 (series), c(π) = 1/π²."""
    xa = as_array(x, "x", (3,))
    ya = as_array(y, "y", (3,))
    th = np.linalg.norm(xa, axis=-1)
    if np.any(th > math.pi * (1.0 + 1e-9)):
        raise ValueError(f"x: expected ‖x‖ ≤ π (a log of SO(3)), got {float(th.max())!r}")
    return _jr_inv_apply(xa, ya)


def _jr_inv_apply(x: Any, y: Any) -> Any:
    """:func:`inverse_right_jacobian_apply` without checks; pure, NumPy or JAX. Both branches
    of c(θ) are finite everywhere: the closed form is evaluated at θ = 2 where the series is
    taken (θ < 1e-3), and for θ ≤ π its half-angle h ≤ π/2 keeps sin h > 0 (near π, cot h → 0:
    nothing singular there)."""
    xp = namespace(x, y)
    th = _norm(x, xp)
    small = th < 1e-3
    h = 0.5 * xp.where(small, 1.0, th)
    with np.errstate(divide="ignore", invalid="ignore"):
        c_big = (1.0 - h * xp.cos(h) / xp.sin(h)) / (4.0 * h * h)
    t2 = th * th
    c = xp.where(small, 1.0 / 12.0 + t2 / 720.0, c_big)
    xy = _cross(x, y)
    return y + 0.5 * xy + c[..., None] * _cross(x, xy)


def _gain_matrix(K: object, name: str) -> np.ndarray:
    """Scalar > 0 or a symmetric positive-definite (3, 3) matrix → (3, 3)."""
    a = as_array(K, name)
    if a.ndim == 0:
        v = float(a)
        if not v > 0.0:
            raise ValueError(f"{name}: must be > 0, got {v!r}")
        return v * np.eye(3)
    if a.shape != (3, 3):
        raise ValueError(f"{name}: expected a scalar or shape (3, 3), got {a.shape}")
    if not np.allclose(a, a.T, rtol=1e-9, atol=1e-12 * np.abs(a).max()):
        raise ValueError(f"{name}: must be symmetric")
    if np.linalg.eigvalsh(a).min() <= 0.0:
        raise ValueError(f"{name}: must be positive definite")
    return np.array(a)


def _boundary_layer(
    sigma: Any,
    k_hat: Any,
    beta_hat: Any,
    k_max: float,
    beta_max: float,
    adaptive: bool,
) -> Any:
    """σ(t) ``(B,)`` (or ``()`` for one spacecraft); the compiled kernel computes the same
    expression. Pure, NumPy or JAX."""
    xp = namespace(sigma, k_hat, beta_hat)
    if not adaptive or beta_max <= 0.0:
        return xp.zeros_like(beta_hat) + sigma
    return sigma * (1.0 - (1.0 - xp.max(k_hat, axis=-1) / k_max) * beta_hat / beta_max)


def adaptive_update(
    k_hat: Any, beta_hat: Any, k_dot: Any, beta_dot: Any, dt: Any, k_max: float,
    beta_max: float,
) -> tuple[Any, Any]:  # fmt: skip
    """One zero-order-hold step of the estimates with projection onto their boxes (module
    docstring): ``k̂ ← clip(k̂ + dt k̂̇, 1, k_max)``, ``β̂ ← clip(β̂ + dt β̂̇, 0, β_max)``, the
    rates held from the previous sample (explicit Euler). Pure, NumPy or JAX."""
    xp = namespace(k_hat, beta_hat, k_dot, beta_dot, dt)
    return (
        xp.clip(k_hat + dt * k_dot, 1.0, k_max),
        xp.clip(beta_hat + dt * beta_dot, 0.0, beta_max),
    )


def fault_tolerant_torque(
    Rt: Any, W: Any, Wd: Any, Wd_dot: Any, J: Any, K: Any, lam: Any, k_hat: Any,
    beta_hat: Any, sigma: Any, gamma_k: Any, gamma_beta: Any, max_torque: Any,
) -> tuple[Any, Any, Any, dict[str, Any]]:  # fmt: skip
    """The adaptive fault-tolerant law (module docstring) at one sample::

        s = e_Ω + λ x,   x = log(R̃)^∨,
        v = Ω × JΩ − J(Ω^ R̃ᵀΩ_d − R̃ᵀΩ̇_d) − λ J J_r⁻¹(x) e_Ω − K s − β̂ s / (‖s‖ + σ),
        τ = k̂ ∘ v   (clipped to ``max_torque`` when given),

    and the estimates' rates ``k̂̇ = −γ_k s ∘ v`` (0 on a saturated sample),
    ``β̂̇ = γ_β ‖s‖² / (‖s‖ + σ)``. ``R̃ = R_dᵀR`` ``(..., 3, 3)``, the rates ``(..., 3)``,
    ``K`` ``(3, 3)``, ``sigma`` the boundary layer σ(t) (:func:`_boundary_layer`). Returns
    ``(τ, k̂̇, β̂̇, diagnostics)``. Pure, NumPy or JAX, broadcasting over leading axes: the
    log and ‖s‖ with finite derivatives at the identity and near π."""
    xp = namespace(Rt, W, Wd, Wd_dot, K, lam, k_hat, beta_hat, sigma)
    x = so3.log_unchecked(Rt)
    RtT = xp.swapaxes(Rt, -1, -2)
    wd_b = (RtT @ Wd[..., None])[..., 0]  # R̃ᵀΩ_d
    e_W = W - wd_b
    s = e_W + lam * x
    JW = W @ J.T
    ff = _cross(W, JW) - (_cross(W, wd_b) - (RtT @ Wd_dot[..., None])[..., 0]) @ J.T
    x_dot = _jr_inv_apply(x, e_W)
    ns = _norm(s, xp)
    robust = (beta_hat / (ns + sigma))[..., None] * s
    v = ff - lam * (x_dot @ J.T) - s @ K.T - robust
    u = k_hat * v
    if max_torque is not None:
        sat = xp.any(xp.abs(u) > max_torque, axis=-1)
        u = xp.clip(u, -max_torque, max_torque)
    else:
        sat = xp.zeros(u.shape[:-1], dtype=bool)
    # a saturated sample's delivered torque is not k̂ ∘ v: no information on 1/ε
    k_dot = xp.where(sat[..., None], 0.0, -gamma_k * s * v)
    beta_dot = gamma_beta * ns * ns / (ns + sigma)
    diag = {"e_R": x, "e_Omega": e_W, "s": s, "k_hat": k_hat, "beta_hat": beta_hat,
            "saturated": sat, "sigma": sigma}  # fmt: skip
    return u, k_dot, beta_dot, diag


def _ft_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """The controller's diagnostics from its kernel rows ``(..., 15)``."""
    return {
        "e_R": rows[..., 0:3].copy(),
        "e_Omega": rows[..., 3:6].copy(),
        "s": rows[..., 6:9].copy(),
        "k_hat": rows[..., 9:12].copy(),
        "beta_hat": rows[..., 12].copy(),
        "saturated": rows[..., 13] != 0.0,
        "sigma": rows[..., 14].copy(),
    }


class AdaptiveFaultTolerantSO3(AttitudeController):
    """Adaptive fault-tolerant sliding law on SO(3) (module docstring: equations, Lyapunov
    argument, sources).

    Args:
        J: model inertia ``(3, 3)`` [kg·m²].
        K: sliding gain, scalar or SPD ``(3, 3)`` [N·m·s/rad].
        lam: sliding-surface slope λ > 0 [1/s].
        gamma_k: effectiveness adaptation gain ≥ 0 (0 disables it).
        gamma_beta: bias-bound adaptation gain ≥ 0 (0 disables it).
        sigma: boundary layer σ > 0 [rad/s] of the robust term.
        k_max: upper bound of k̂ = 1/ε̂ (≥ 1; 1/k_max is the smallest effectiveness handled).
        beta_max: upper bound of β̂ ≥ 0 [N·m].
        max_torque: optional per-axis output clip [N·m] (scalar or ``(3,)``).
        adaptive_sigma: shrink the boundary layer from ``sigma`` as β̂ grows (module docstring,
            "Adaptive boundary layer"); ``False``: σ fixed at ``sigma``.
    """

    batched = True

    def __init__(
        self,
        J: object,
        K: object,
        lam: float,
        gamma_k: float = 0.0,
        gamma_beta: float = 0.0,
        sigma: float = 1e-3,
        k_max: float = 4.0,
        beta_max: float = 1.0,
        max_torque: object = None,
        adaptive_sigma: bool = False,
    ) -> None:
        self.J = check_inertia_3x3(J, "J")
        self.K = _gain_matrix(K, "K")
        self.lam = check_positive_scalar(lam, "lam")
        for name, v in (("gamma_k", gamma_k), ("gamma_beta", gamma_beta), ("beta_max", beta_max)):
            x = as_scalar(v, name)
            if x < 0.0:
                raise ValueError(f"{name}: must be >= 0, got {v!r}")
            setattr(self, name, x)
        self.sigma = check_positive_scalar(sigma, "sigma")
        k = as_scalar(k_max, "k_max")
        if k < 1.0:
            raise ValueError(f"k_max: must be >= 1 (k̂ estimates 1/efficiency), got {k_max!r}")
        self.k_max = k
        if not isinstance(adaptive_sigma, (bool, np.bool_)):
            raise ValueError(f"adaptive_sigma: expected a bool, got {adaptive_sigma!r}")
        self.adaptive_sigma = bool(adaptive_sigma)
        if max_torque is None:
            self.max_torque = None
        else:
            m = as_array(max_torque, "max_torque")
            if m.shape not in ((), (3,)) or np.any(m <= 0.0):
                raise ValueError(
                    f"max_torque: expected a positive scalar or 3 positive values, got {m!r}"
                )
            self.max_torque = np.broadcast_to(m, (3,)).copy()
        self._batch: int | None = None

    def __repr__(self) -> str:
        return (
            f"AdaptiveFaultTolerantSO3(lam={self.lam!r}, gamma_k={self.gamma_k!r}, "
            f"gamma_beta={self.gamma_beta!r}, sigma={self.sigma!r}, k_max={self.k_max!r}, "
            f"beta_max={self.beta_max!r}, adaptive_sigma={self.adaptive_sigma!r})"
        )

    def reset(self, t0: float, batch_size: int) -> None:
        """Estimates to their nominal values (k̂ = 1, β̂ = 0) for ``batch_size`` spacecraft."""
        B = int(batch_size)
        if B < 1:
            raise ValueError(f"batch_size: must be >= 1, got {batch_size!r}")
        self._batch = B
        self._t_prev: float | None = None
        self.k_hat = np.ones((B, 3))
        self.beta_hat = np.zeros(B)
        self._kdot = np.zeros((B, 3))
        self._bdot = np.zeros(B)
        self._diag: dict[str, np.ndarray] = {}

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m]; advances (k̂, β̂) to ``t`` first (ZOH of their rates)."""
        if self._batch is None:
            raise RuntimeError("AdaptiveFaultTolerantSO3.command: call reset(t0, batch_size) first")
        t = as_scalar(t, "t")
        B = self._batch
        check_state_batch(state.R, state.omega, B)
        if self._t_prev is not None:
            dt = t - self._t_prev
            if dt < 0.0:
                raise ValueError(
                    f"t: {t!r} is earlier than the previous control sample {self._t_prev!r}"
                )
            self.k_hat, self.beta_hat = adaptive_update(
                self.k_hat, self.beta_hat, self._kdot, self._bdot, dt, self.k_max, self.beta_max
            )
        self._t_prev = t
        R = np.broadcast_to(state.R, (B, 3, 3))
        W = np.broadcast_to(state.omega, (B, 3))
        Rd = np.broadcast_to(reference.R_d, (B, 3, 3))
        Wd = np.broadcast_to(reference.omega_d, (B, 3))
        Wd_dot = np.broadcast_to(reference.omega_dot_d, (B, 3))
        Rt = np.swapaxes(Rd, -1, -2) @ R  # R̃ = R_dᵀR
        u, self._kdot, self._bdot, d = fault_tolerant_torque(
            Rt, W, Wd, Wd_dot, self.J, self.K, self.lam, self.k_hat, self.beta_hat,
            self.boundary_layer(), self.gamma_k, self.gamma_beta, self.max_torque,
        )  # fmt: skip
        self._diag = {**d, "k_hat": self.k_hat.copy(), "beta_hat": self.beta_hat.copy()}
        return finite_command(u, state.omega)

    def boundary_layer(self) -> np.ndarray:
        """The boundary layer σ(t) ``(B,)`` [rad/s] at the current estimates: ``sigma``, or with
        ``adaptive_sigma`` ``sigma · (1 − (1 − max_i k̂_i/k_max) β̂/β_max)`` (module docstring,
        "Adaptive boundary layer")."""
        if self._batch is None:
            raise RuntimeError("AdaptiveFaultTolerantSO3.boundary_layer: call reset first")
        return _boundary_layer(
            self.sigma, self.k_hat, self.beta_hat, self.k_max, self.beta_max, self.adaptive_sigma
        )

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.fault_tolerant.fault_tolerant_law`) for
        the simulator's fused loop (:mod:`liecontrol.control.kernel`), carrying (k̂, β̂)."""
        if self._batch is None:
            return None
        B = int(batch_size)
        mt = self.max_torque
        params = np.concatenate(
            [
                np.ascontiguousarray(self.J, dtype=np.float64).ravel(),
                np.ascontiguousarray(self.K, dtype=np.float64).ravel(),
                [self.lam, self.gamma_k, self.gamma_beta, self.sigma, self.k_max],
                [self.beta_max, 0.0 if mt is None else 1.0],
                np.zeros(3) if mt is None else mt,
                [1.0 if self.adaptive_sigma else 0.0],
            ]
        )
        state = np.zeros((B, FT_STATE))
        if self._t_prev is not None:
            state[:, 0] = 1.0
            state[:, 1] = self._t_prev
        state[:, 2:5] = self.k_hat
        state[:, 5] = self.beta_hat
        state[:, 6:9] = self._kdot
        state[:, 9] = self._bdot
        return ControllerKernel(fault_tolerant_law, params, state, FT_DIAG, _ft_rows, self._finish)

    def _kernel_reason(self) -> str:
        return "a controller that was not reset"

    def array_law(self) -> ArrayLaw:
        """The law as a pure array function for the differentiable loop
        (:mod:`liecontrol.control.array_law`): :func:`adaptive_update`,
        :func:`_boundary_layer` and :func:`fault_tolerant_torque` — the functions
        :meth:`command` calls — with the adaptive estimates carried by the scan.

        Differentiable gains: ``k_R`` is the surface slope λ [1/s], ``k_Omega`` the sliding
        gain ``K`` ``(3, 3)`` [N·m·s/rad]; further parameters (``params``): the adaptation
        gains ``gamma_k``, ``gamma_beta`` and the boundary layer ``sigma``. Timed: the scan
        carries ``(started, t_prev, k̂, β̂, k̂̇, β̂̇)`` and advances the estimates over the time
        since the previous sample, as :meth:`command` does (nothing at the first sample). The
        estimates start at their nominal values (k̂ = 1, β̂ = 0), as after :meth:`reset`."""
        J, k_max, b_max = np.array(self.J), self.k_max, self.beta_max
        adaptive, mt = self.adaptive_sigma, self.max_torque

        def step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T, *, params, t):  # noqa: ANN001
            xp = namespace(R, R_d, t)
            started, t_prev, k_hat, beta_hat, k_dot, beta_dot = state
            dt = xp.where(started, t - t_prev, 0.0)
            k_hat, beta_hat = adaptive_update(k_hat, beta_hat, k_dot, beta_dot, dt, k_max, b_max)
            sigma = _boundary_layer(params["sigma"], k_hat, beta_hat, k_max, b_max, adaptive)
            Rt = xp.swapaxes(R_d, -1, -2) @ R
            u, k_dot, beta_dot, d = fault_tolerant_torque(
                Rt, omega, omega_d, omega_dot_d, J, k_Omega, k_R, k_hat, beta_hat, sigma,
                params["gamma_k"], params["gamma_beta"], mt,
            )  # fmt: skip
            started = xp.ones((), dtype=bool)
            return u, (started, t, k_hat, beta_hat, k_dot, beta_dot), d

        state0 = (np.zeros((), dtype=bool), np.zeros(()), np.ones(3), np.zeros(()),
                  np.zeros(3), np.zeros(()))  # fmt: skip
        params = {"gamma_k": self.gamma_k, "gamma_beta": self.gamma_beta, "sigma": self.sigma}
        return ArrayLaw(self.lam, self.K.copy(), state0, step, params=params, timed=True)

    def _finish(self, state: np.ndarray, diag: np.ndarray) -> None:
        """Estimates, their rates and diagnostics after a compiled run."""
        self._t_prev = float(state[0, 1]) if state[0, 0] != 0.0 else None
        self.k_hat = state[:, 2:5].copy()
        self.beta_hat = state[:, 5].copy()
        self._kdot = state[:, 6:9].copy()
        self._bdot = state[:, 9].copy()
        self._diag = _ft_rows(diag)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last ``e_R`` (log error), ``e_Omega``, ``s``, ``k_hat`` ``(B, 3)``, ``beta_hat``,
        ``saturated`` ``(B,)`` (empty before the first command)."""
        return dict(self._diag)


def fault_tolerant_gains(
    J: object,
    omega_n: float,
    sample_period: float,
    beta_max: float = 0.5,
    k_max: float = FAULT_FAMILY_K_MAX,
    adapt_time: float | None = None,
    error_ref: float = 0.05,
) -> dict[str, object]:
    """Keywords of :class:`AdaptiveFaultTolerantSO3` for small-angle poles at −1.15 ω_n and
    −ω_n/1.15 (natural frequency ω_n, damping ≈ 1.01).

    ``K = 1.15 ω_n J``, ``λ = ω_n/1.15`` (see the module doc). The boundary layer keeps the
    robust term's linear gain ``k_max β_max/σ`` at ``λ_min(J)/T_s`` (a sampled loop with a
    gain ``g`` is stable for ``g T_s / J < 2``; with k̂ ≤ ``k_max`` the robust term's
    ``k̂ β̂/σ`` stays ≤ ``λ_min(J)/T_s``): ``σ = k_max β_max T_s / λ_min(J)``. ``k_max``
    defaults to :data:`FAULT_FAMILY_K_MAX` (unit efficiencies down to 0.29; module docstring
    for which faults the proof covers). The
    adaptation gains make k̂ move by ~1 and β̂ reach β_max within ``adapt_time`` (default
    1/ω_n) when the attitude error is ``error_ref`` (s_ref = λ · error_ref):
    ``γ_k = 1/(adapt_time · ‖K‖ s_ref²)``, ``γ_β = β_max/(adapt_time · s_ref)``; at the
    1e-3 rad of a small-angle test they act ≳ 50× slower, so the nominal loop keeps its
    poles (to a few per cent).
    """
    Jm = check_inertia_3x3(J, "J")
    w = check_positive_scalar(omega_n, "omega_n")
    T = check_positive_scalar(sample_period, "sample_period")
    bmax = check_positive_scalar(beta_max, "beta_max")
    kmax = as_scalar(k_max, "k_max")
    if kmax < 1.0:
        raise ValueError(f"k_max: must be >= 1, got {k_max!r}")
    ta = 1.0 / w if adapt_time is None else check_positive_scalar(adapt_time, "adapt_time")
    K = 1.15 * w * Jm
    lam = w / 1.15
    s_ref = lam * check_positive_scalar(error_ref, "error_ref")
    knorm = float(np.linalg.eigvalsh(K).max())
    return {
        "K": K,
        "lam": lam,
        "gamma_k": 1.0 / (ta * knorm * s_ref * s_ref),
        "gamma_beta": bmax / (ta * s_ref),
        "sigma": kmax * bmax * T / float(np.linalg.eigvalsh(Jm).min()),
        "k_max": kmax,
        "beta_max": bmax,
        "adaptive_sigma": True,
    }


def body_axis_effectiveness(
    A: object, efficiency: object, right_inverse: object = None
) -> np.ndarray:
    """Body-axis effect ``E = A diag(e) A⁺`` ``(..., 3, 3)`` of per-unit efficiencies ``e``
    ``(..., n)`` for a cluster with Jacobian (or unit torque directions) ``A`` ``(..., 3, n)``
    steered by the right inverse ``A⁺`` (default the Moore–Penrose one, ``Aᵀ(AAᵀ)⁻¹``; pass the
    steering's own ``(..., n, 3)`` otherwise): the torque delivered is ``E`` times the torque
    commanded. The fault-tolerant proof covers ``E`` diagonal only (module docstring); for a
    full-rank ``A`` and the Moore–Penrose inverse the eigenvalues of ``E`` lie in
    ``[min e, max e]``."""
    a = as_array(A, "A")
    if a.ndim < 2 or a.shape[-2] != 3 or a.shape[-1] < 3:
        raise ValueError(f"A: expected shape (..., 3, n) with n >= 3, got {a.shape}")
    e = as_array(efficiency, "efficiency")
    if e.shape[-1:] != a.shape[-1:] or np.any(e < 0.0) or np.any(e > 1.0):
        raise ValueError(
            f"efficiency: expected values in [0, 1] of shape (..., {a.shape[-1]}), got "
            f"shape {e.shape}"
        )
    if right_inverse is None:
        G = a @ np.swapaxes(a, -1, -2)
        if np.any(np.linalg.svd(G, compute_uv=False)[..., -1] <= 1e-12 * np.abs(G).max()):
            raise ValueError("A: rank-deficient (a singular cluster state has no right inverse)")
        Ap = np.swapaxes(a, -1, -2) @ np.linalg.inv(G)
    else:
        Ap = as_array(right_inverse, "right_inverse")
        if Ap.shape[-2:] != (a.shape[-1], 3):
            raise ValueError(
                f"right_inverse: expected shape (..., {a.shape[-1]}, 3), got {Ap.shape}"
            )
    return (a * e[..., None, :]) @ Ap
