"""Finite- and fixed-time geometric attitude control on SO(3): a nonsingular fast terminal
sliding mode built on an attitude error of the rotation group, not on a chart.

**Configuration error** (Lee, "Exponential stability of an attitude tracking control system on
SO(3) for large-angle rotational maneuvers", Systems & Control Letters 61(1), 2012; the form the
geometric-control survey of Jiang, Meng & Yang, Control and Decision 38(8), 2023, writes as its
eqs. (10)–(11)). With ``R̃ = R_dᵀR`` of angle ``θ ∈ [0, π]`` and axis
``â``,

    Ψ = 2 − √(1 + tr R̃) = 2 − 2 cos(θ/2),   e_R = (R̃ − R̃ᵀ)^∨ / (2√(1 + tr R̃)) = sin(θ/2) â,
    e_Ω = Ω − R̃ᵀΩ_d.

``e_R`` is the vector part of the unit quaternion of ``R̃`` taken with ``q₀ = cos(θ/2) ≥ 0``: a
function of ``R̃`` alone, so the law cannot unwind (no sign memory, no double cover). Its
kinematics are ``ė_R = E e_Ω``, ``E = ½(q₀ I + e_R^)``, and ``Ψ̇ = e_Rᵀ e_Ω``, ``θ̇ = âᵀ e_Ω``.

**Nonsingular fast terminal surface.** With ``x = ‖e_R‖ = sin(θ/2)``,

    s = e_Ω + α(e_R),   α(e_R) = (k₁ + k₂ g_r(x)) e_R,

    g_p(x) = x^(p−1)                              for x ≥ ε,
    g_p(x) = (2 − p) ε^(p−1) + (p − 1) ε^(p−2) x  for x < ε       (0 < p < 1).

Outside ``‖e_R‖ < ε`` the surface term is ``k₁e_R + k₂‖e_R‖^(r−1)e_R`` (the "fast terminal"
pair: linear far away, fractional power ``r`` near the target); inside it ``g`` is continued by
its tangent line (the C¹ continuation of Lu & Xia, "Adaptive attitude tracking control for rigid
spacecraft with finite-time convergence", Automatica 49(12), 2013), which keeps the Jacobian
``∂α/∂e_R`` bounded — the law is *nonsingular*: no ``‖e_R‖^(r−2)`` blows up as the error
vanishes. The norm (not the components) is raised to the power, so the surface does not depend
on the choice of body axes. On ``s = 0``,

    θ̇ = −h(θ),   h(θ) = sin(θ/2) (k₁ + k₂ g_r(sin(θ/2))),

which reaches ``‖e_R‖ = ε`` in finite time from any ``θ < π`` and then decays exponentially at
rate ≥ ½(k₁ + k₂ε^(r−1)) cos(θ/2). The time ``∫ dθ / h(θ)`` from ``θ = π`` is finite: the slide
phase has a bound independent of the initial attitude.

**Reaching law and control.** The torque makes ``s`` obey

    ṡ = −k_s(‖s‖) s,   k_s(y) = c₁ + c₂ g_ρ(y; ε_s) + c₃ y^(μ−1)   (0 < ρ < 1 < μ),

i.e. ``‖s‖`` decays as ``ẏ = −c₁y − c₂y^ρ − c₃y^μ`` above the boundary layer ``‖s‖ ≥ ε_s``
(finite time for ``c₃ = 0``; *fixed* time, bounded by ``1/(c₂(1−ρ)) + 1/(c₃(μ−1))`` whatever
``s(0)``, for ``c₃ > 0``: Polyakov, "Nonlinear feedback design for fixed-time stabilization of
linear control problems", IEEE TAC 57(8), 2012) and exponentially inside it. ``s/‖s‖ · ‖s‖^ρ``
replaces the sign function of classical sliding mode: it is continuous, and the layer ``ε_s``
(the same tangent-line continuation) makes it Lipschitz so that the sampled plant does not
chatter — **inside the layers the law is linear**, with the small-angle poles ``−½(k₁ + k₂ a_r)``
and ``−(c₁ + c₂ a_s)``, ``a_p = (2 − p)ε^(p−1)``. With the rigid body ``JΩ̇ + Ω × JΩ = M`` and
the error dynamics ``ė_Ω = Ω̇ + Ω × R̃ᵀΩ_d − R̃ᵀΩ̇_d``:

    M = Ω × JΩ − J(Ω × R̃ᵀΩ_d − R̃ᵀΩ̇_d) − J (∂α/∂e_R · E e_Ω + k_s(‖s‖) s),
    ∂α/∂e_R = (k₁ + k₂ g_r(x)) I + k₂ (g_r'(x)/x) e_R e_Rᵀ.

**Stability argument.** With the model exact, ``d‖s‖/dt = −k_s(‖s‖)‖s‖`` holds exactly (so
``V₁ = ½‖s‖²`` has ``V̇₁ = −k_s‖s‖² ≤ −2c₂ V₁^((1+ρ)/2)`` above the layer: finite-time), and
from ``θ̇ = âᵀe_Ω = âᵀs − h(θ)``, ``θ̇ ≤ ‖s‖ − h(θ)`` with ``θ ≤ π`` always. The comparison
system ``Θ̇ = y − h(Θ)``, ``ẏ = −k_s(y) y`` therefore bounds the angle from above; once
``y ≤ h(Θ)`` the set stays invariant (``h`` increases with ``θ``, ``y`` decreases), so the first
time ``Θ`` falls to a tolerance bounds the time after which ``θ`` stays below it
(:func:`convergence_time_bound`). The discontinuity of ``e_R`` at ``θ = π`` (where ``â`` flips)
is a measure-zero set, as for every continuous feedback on SO(3) (Bhat & Bernstein 2000); there
``θ̇ = −h(π) < 0`` whichever axis is picked, so the body leaves it at once.

**Assumptions of every bound in this module** (:func:`convergence_time_bound`,
:meth:`FixedTimeSO3.settling_bound`, :func:`reaching_time`, :func:`sliding_time`): the
controller's inertia is the plant's and there is no disturbance; the commanded torque is
delivered — unbounded torque: "whatever ``s(0)``" needs a torque growing with the initial rate
(e.g. a 14.7 kN·m peak on a 1000–1500 kg·m² body from a 1 rad/s start), so with an actuator
torque limit the bounds are not applicable (pass ``max_torque``: ``nan`` and a
:class:`BoundNotApplicable` warning); continuous-time control (a sampled law keeps the bound
only approximately, for ``T_s`` small against the layer's poles ``1/(c₁ + c₂ a_s)``). A start
already inside the tolerance that the comparison system keeps inside gets the bound 0.

The finite-time gains and survey family: Guo & Song, "Adaptive finite-time backstepping control
for attitude tracking of spacecraft based on rotation matrix", Chinese J. Aeronautics 27(2),
2014; Shi, Zhang, Zhou et al., "Global fixed-time attitude tracking control for the rigid
spacecraft with actuator saturation and faults", Acta Astronautica 155, 2019 (fixed-time
terminal sliding mode on SO(3)). The surface, the reaching law and the bound above are our own
combination of these ingredients, derived here.

Units: ``J`` [kg·m²], ``k₁, k₂, c₁`` [1/s], ``c₂`` [(rad/s)^(1−ρ)/s], ``c₃`` [(rad/s)^(1−μ)/s],
``ε`` [1] (a bound on sin(θ/2)), ``ε_s`` [rad/s], torque [N·m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import integrate

from .._array_api import cross, namespace, safe_sqrt
from .._jit import JIT_ENABLED
from .._kernels.finite_time import N_DIAG, finite_time_batch, finite_time_law, finite_time_one
from .._validation import (
    as_array,
    as_scalar,
    check_inertia_3x3,
    check_rotation_matrix,
    rotations_pass_fast,
)
from ..errors import _large_angle_error_unchecked
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
    "FiniteTimeParams",
    "FiniteTimeSO3",
    "FixedTimeSO3",
    "terminal_gain",
    "sliding_variable",
    "angle_decay_rate",
    "sliding_time",
    "reaching_time",
    "convergence_time_bound",
    "BoundNotApplicable",
]


def _real(x: object, name: str) -> float:
    v = as_scalar(x, name)
    return v


def _open_unit(x: object, name: str) -> float:
    v = _real(x, name)
    if not 0.0 < v < 1.0:
        raise ValueError(f"{name}: must be in (0, 1), got {v:g}")
    return v


def _positive(x: object, name: str) -> float:
    v = _real(x, name)
    if not v > 0.0:
        raise ValueError(f"{name}: must be > 0, got {v:g}")
    return v


def _nonnegative(x: object, name: str) -> float:
    v = _real(x, name)
    if v < 0.0:
        raise ValueError(f"{name}: must be >= 0, got {v:g}")
    return v


@dataclass(frozen=True)
class FiniteTimeParams:
    """Gains of the terminal sliding mode on SO(3) (module docstring).

    Attributes:
        k1: linear surface gain k₁ [1/s], ≥ 0.
        k2: terminal surface gain k₂ [1/s], > 0.
        r: surface power r ∈ (0, 1).
        eps: surface continuation radius ε ∈ (0, 1) on ‖e_R‖ = sin(θ/2).
        c1: linear reaching gain c₁ [1/s], ≥ 0.
        c2: terminal reaching gain c₂ [(rad/s)^(1−ρ)/s], > 0.
        rho: reaching power ρ ∈ (0, 1).
        eps_s: boundary layer ε_s [rad/s], > 0, of the reaching law.
        c3: fixed-time reaching gain c₃ [(rad/s)^(1−μ)/s], ≥ 0 (0: finite time only).
        mu: fixed-time power μ > 1.
    """

    k1: float
    k2: float
    r: float
    eps: float
    c1: float
    c2: float
    rho: float
    eps_s: float
    c3: float = 0.0
    mu: float = 1.5

    def __post_init__(self) -> None:
        for name, check in (
            ("k1", _nonnegative),
            ("k2", _positive),
            ("r", _open_unit),
            ("eps", _open_unit),
            ("c1", _nonnegative),
            ("c2", _positive),
            ("rho", _open_unit),
            ("eps_s", _positive),
            ("c3", _nonnegative),
            ("mu", _positive),
        ):
            object.__setattr__(self, name, check(getattr(self, name), name))
        if not self.mu > 1.0:
            raise ValueError(f"mu: must be > 1 (the fixed-time power), got {self.mu:g}")
        # the gains enter products with ε^(p−2): refuse what would overflow
        for name, v in (
            ("eps", self.eps ** (self.r - 2.0)),
            ("eps_s", self.eps_s ** (self.rho - 2.0)),
        ):
            if not math.isfinite(v * max(self.k2, self.c2)):
                raise ValueError(f"{name}: too small for the power and gain (ε^(p−2) overflows)")

    @property
    def fixed_time(self) -> bool:
        """``True`` when the reaching law has the fixed-time term (``c3 > 0``)."""
        return self.c3 > 0.0

    @property
    def small_angle_poles(self) -> tuple[float, float]:
        """``(λ, κ)``: inside both layers the loop is ``(d/dt + λ)(d/dt + κ) δθ = 0`` with
        ``λ = ½(k₁ + k₂ a_r)``, ``κ = c₁ + c₂ a_s``, ``a_p = (2 − p)ε^(p−1)`` [1/s]."""
        a_r = (2.0 - self.r) * self.eps ** (self.r - 1.0)
        a_s = (2.0 - self.rho) * self.eps_s ** (self.rho - 1.0)
        return 0.5 * (self.k1 + self.k2 * a_r), self.c1 + self.c2 * a_s


# ------------------------------------------------------------------------------- pure math


def _g(x: Any, p: Any, eps: Any) -> Any:
    """g_p(x): x^(p−1) above ε, its tangent line at ε below (module docstring). Pure, NumPy or
    JAX: the power is taken of ``max(x, ε)``, so the branch not taken (x < ε, where x^(p−1)
    blows up at 0) stays finite and so does its derivative."""
    xp = namespace(x, p, eps)
    if xp is np:
        x = np.asarray(x, dtype=np.float64)
    lin = (2.0 - p) * eps ** (p - 1.0) + (p - 1.0) * eps ** (p - 2.0) * x
    return xp.where(x >= eps, xp.maximum(x, eps) ** (p - 1.0), lin)


def _g_prime_over_x(x: Any, p: Any, eps: Any) -> Any:
    """g_p'(x)/x (0 at x = 0, where it multiplies e_R e_Rᵀ = 0). Pure, NumPy or JAX: the
    divisor is 1 where x = 0 and the power is of ``max(x, ε)`` (both branches finite)."""
    xp = namespace(x, p, eps)
    if xp is np:
        x = np.asarray(x, dtype=np.float64)
    safe = xp.where(x > 0.0, x, 1.0)
    out = xp.where(
        x >= eps,
        (p - 1.0) * xp.maximum(x, eps) ** (p - 3.0),
        (p - 1.0) * eps ** (p - 2.0) / safe,
    )
    return xp.where(x > 0.0, out, 0.0)


def terminal_gain(x: object, p: float, eps: float) -> np.ndarray:
    """The continued power gain ``g_p(x)`` of the module docstring: ``x^(p−1)`` for ``x ≥ ε``,
    the tangent line ``(2 − p)ε^(p−1) + (p − 1)ε^(p−2)x`` below (C¹ at ``ε``), so that
    ``g_p(x)·x`` is the fractional power ``x^p`` away from 0 and linear near it.

    Args:
        x: a non-negative magnitude, or a non-empty 1-D array of them.
        p: power in (0, 1).
        eps: continuation radius > 0.
    """
    p = _open_unit(p, "p")
    eps = _positive(eps, "eps")
    x = as_array(x, "x")
    if x.ndim > 1 or x.size == 0:
        raise ValueError(f"x: expected a scalar or a non-empty 1-D array, got shape {x.shape}")
    if np.any(x < 0.0):
        raise ValueError(f"x: must be >= 0 (a norm), got {float(x.min()):g}")
    return _g(x, p, eps)


def _h(theta: np.ndarray | float, prm: FiniteTimeParams) -> np.ndarray | float:
    x = np.sin(0.5 * np.asarray(theta, dtype=np.float64))
    return x * (prm.k1 + prm.k2 * _g(x, prm.r, prm.eps))


def _ks(y: np.ndarray | float, prm: FiniteTimeParams) -> np.ndarray:
    return _reaching_gain(
        np.asarray(y, dtype=np.float64), prm.c1, prm.c2, prm.rho, prm.eps_s,
        prm.c3 if prm.c3 > 0.0 else None, prm.mu,
    )  # fmt: skip


def _reaching_gain(
    y: Any, c1: Any, c2: Any, rho: Any, eps_s: Any, c3: Any = None, mu: Any = 1.5
) -> Any:
    """``k_s(y) = c₁ + c₂ g_ρ(y; ε_s) [+ c₃ y^(μ−1)]`` (module docstring); ``c3=None``: no
    fixed-time term — skipped rather than multiplied by 0, which would be NaN where
    ``y^(μ−1)`` overflows. Pure, NumPy or JAX: ``y^(μ−1)`` is taken of ``y`` or of 1 where
    ``y = 0`` (its derivative, infinite there for μ < 2, must not reach the gradient)."""
    xp = namespace(y, c1, c2, rho, eps_s, c3, mu)
    out = c1 + c2 * _g(y, rho, eps_s)
    if c3 is not None:
        pos = y > 0.0
        out = out + c3 * xp.where(pos, xp.where(pos, y, 1.0) ** (mu - 1.0), 0.0)
    return out


def _check_params(params: object) -> FiniteTimeParams:
    if not isinstance(params, FiniteTimeParams):
        raise TypeError(f"params: expected FiniteTimeParams, got {type(params).__name__}")
    return params


def angle_decay_rate(theta: object, params: FiniteTimeParams) -> np.ndarray:
    """``h(θ) = sin(θ/2)(k₁ + k₂ g_r(sin(θ/2)))`` [rad/s]: on the surface ``s = 0`` the
    attitude-error angle obeys ``θ̇ = −h(θ)`` exactly (module docstring)."""
    params = _check_params(params)
    th = as_array(theta, "theta")
    if np.any((th < 0.0) | (th > math.pi)):
        raise ValueError("theta: an attitude-error angle lies in [0, π]")
    return np.asarray(_h(th, params))


def _check_angle_pair(theta0: object, tol: object) -> tuple[float, float]:
    tol = _real(tol, "tol")
    if not 0.0 < tol < math.pi:
        raise ValueError(f"tol: must be in (0, π) [rad], got {tol:g}")
    theta0 = _real(theta0, "theta0")
    if not 0.0 <= theta0 <= math.pi:
        raise ValueError(f"theta0: an attitude-error angle lies in [0, π], got {theta0:g}")
    return theta0, tol


def sliding_time(params: FiniteTimeParams, theta0: float, tol: float) -> float:
    """Time [s] for the error angle to fall from ``theta0`` to ``tol`` on the surface ``s = 0``:
    ``∫_tol^θ₀ dθ / h(θ)`` (0 when ``θ₀ ≤ tol``). Finite for ``θ₀ = π``: the slide-phase bound
    independent of the initial attitude."""
    params = _check_params(params)
    theta0, tol = _check_angle_pair(theta0, tol)
    if theta0 <= tol:
        return 0.0
    brk = 2.0 * math.asin(params.eps)  # the kink of g at ‖e_R‖ = ε
    pts = [p for p in (brk,) if tol < p < theta0]
    val, _ = integrate.quad(
        lambda th: 1.0 / float(_h(th, params)),
        tol,
        theta0,
        points=pts or None,
        limit=200,
        epsabs=0.0,
        epsrel=1e-11,
    )
    return float(val)


def reaching_time(params: FiniteTimeParams, s0: float, s1: float) -> float:
    """Time [s] for ``‖s‖`` to fall from ``s0`` to ``s1`` under ``ẏ = −k_s(y) y``:
    ``∫_s1^s0 dy / (y k_s(y))``. ``s0 = inf`` is allowed with the fixed-time term (``c3 > 0``;
    the integral converges like ``∫ dy/(c₃ y^μ)``). ``s1 > 0``: inside the layer the decay is
    exponential, so ``‖s‖`` reaches 0 only asymptotically."""
    params = _check_params(params)
    s1 = _positive(s1, "s1")
    s0f = float(s0) if isinstance(s0, (int, float)) and not isinstance(s0, bool) else None
    if s0f is not None and math.isinf(s0f) and s0f > 0:
        if not params.fixed_time:
            raise ValueError(
                "s0: an unbounded initial sliding variable needs the fixed-time term (c3 > 0)"
            )
    else:
        s0f = _nonnegative(s0, "s0")
    if s0f <= s1:
        return 0.0
    return float(_y_integral(params, s1, s0f, lambda y: 1.0 / (y * float(_ks(y, params)))))


def _y_integral(prm: FiniteTimeParams, lo: float, hi: float, f) -> float:
    """∫_lo^hi f(y) dy split at the layer ε_s and, for hi = inf, at a finite point."""
    total = 0.0
    edges = [lo]
    if lo < prm.eps_s < hi:
        edges.append(prm.eps_s)
    if math.isinf(hi):
        mid = max(edges[-1], 1.0) * 2.0
        edges.append(mid)
    edges.append(hi)
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        if math.isinf(b):
            # y = a/u² maps (a, ∞) to (0, 1]: the tail ~ y^(−μ) becomes ~ u^(2μ−3), integrable
            def g(u: float, a: float = a) -> float:
                return f(a / (u * u)) * 2.0 * a / (u * u * u) if u > 0.0 else 0.0

            v, _ = integrate.quad(g, 0.0, 1.0, limit=200, epsabs=0.0, epsrel=1e-9)
        else:
            # y = e^v: the integrands span decades (s₀ up to ~1e8), smooth in log y
            def g(v: float) -> float:
                y = math.exp(v)
                return f(y) * y

            v, _ = integrate.quad(g, math.log(a), math.log(b), limit=200, epsabs=0.0, epsrel=1e-9)
        total += v
    return total


class BoundNotApplicable(UserWarning):
    """A convergence bound was asked for outside its assumptions (e.g. with a torque limit):
    the function returns ``nan`` ("no bound") and warns with this category."""


def _torque_limit_not_applicable(max_torque: object) -> bool:
    """``True`` (after a :class:`BoundNotApplicable` warning) when a torque limit is given."""
    if max_torque is None:
        return False
    a = as_array(max_torque, "max_torque")
    if np.any(a <= 0.0):
        raise ValueError(f"max_torque: must be > 0 [N·m], got {max_torque!r}")
    import warnings

    warnings.warn(
        "max_torque: the finite/fixed-time bound assumes the commanded torque is delivered "
        "(unbounded torque); with a torque limit the law saturates for large errors or rates "
        "and the bound is not applicable — returning nan",
        BoundNotApplicable,
        stacklevel=3,
    )
    return True


def convergence_time_bound(
    params: FiniteTimeParams,
    tol: float,
    theta0: float = math.pi,
    s0: float = math.inf,
    max_torque: object = None,
) -> float:
    """Upper bound [s] on the time after which the attitude-error angle stays ``≤ tol``, for a
    start at angle ``theta0`` with sliding variable ``‖s(0)‖ = s0`` (module docstring).

    Assumptions: the rigid-body model the law uses is exact (inertia, no disturbance), the
    commanded torque is delivered — **unbounded torque**: the reaching law ``ṡ = −k_s s``
    asks for a torque that grows with ``‖s‖`` (``~J c₃‖s‖^μ``), so "from any initial rate"
    means with an actuator that can deliver it —, continuous-time control (no sample period,
    no actuator lag). With ``max_torque`` given (a limit the actuator has), the bound is not
    applicable: a :class:`BoundNotApplicable` warning and ``nan``. A start already inside the
    tolerance whose comparison trajectory never leaves it gives 0.

    The comparison system ``Θ̇ = y − h(Θ)`` (``Θ ≤ π``), ``ẏ = −k_s(y)y`` from ``(θ₀, s₀)``:
    while ``y > h(π)`` the angle may grow, so ``Θ`` is bounded by
    ``min(π, θ₀ + ∫ y dt)`` (one quadrature); from then on the pair is integrated (RK45,
    ``rtol`` 1e-10) until ``Θ`` falls through ``tol``. The defaults ``θ₀ = π``, ``s₀ = ∞`` give
    the bound uniform in the initial condition, which exists only with the fixed-time term
    (``c3 > 0``).
    """
    params = _check_params(params)
    theta0, tol = _check_angle_pair(theta0, tol)
    if isinstance(s0, bool):
        raise TypeError("s0: expected a real number, got a bool")
    if _torque_limit_not_applicable(max_torque):
        return math.nan
    s0f = float(s0) if isinstance(s0, (int, float)) else None
    if s0f is not None and math.isinf(s0f) and s0f > 0:
        if not params.fixed_time:
            raise ValueError(
                "s0: a bound for any initial rate (s0 = inf) needs the fixed-time term (c3 > 0); "
                "give the start's ‖s(0)‖ (sliding_variable) for the finite-time law"
            )
    else:
        s0f = _nonnegative(s0, "s0")
    h_pi = float(_h(math.pi, params))
    t1, Th, y = 0.0, theta0, s0f
    if s0f > h_pi:
        t1 = reaching_time(params, s0f, h_pi)
        # ∫ y dt = ∫ dy / k_s(y) diverges for s₀ = ∞ (μ ≤ 2): then only Θ ≤ π is known
        grow = (
            math.inf
            if math.isinf(s0f)
            else _y_integral(params, h_pi, s0f, lambda v: 1.0 / float(_ks(v, params)))
        )
        Th, y = min(math.pi, theta0 + grow), h_pi
    if Th <= tol and y <= float(_h(Th, params)):
        return t1

    def rhs(_t: float, z: np.ndarray) -> list[float]:
        th, yy = min(max(z[0], 0.0), math.pi), max(z[1], 0.0)
        return [yy - float(_h(th, params)), -float(_ks(yy, params)) * yy]

    def crossed(_t: float, z: np.ndarray) -> float:
        return z[0] - tol

    crossed.terminal = True  # type: ignore[attr-defined]
    crossed.direction = -1.0  # type: ignore[attr-defined]
    # a horizon far beyond the slide and the layer's exponential phase
    lam, kap = params.small_angle_poles
    horizon = 10.0 * (sliding_time(params, math.pi, tol) + 40.0 / min(lam, kap) + 1.0)
    sol = integrate.solve_ivp(
        rhs, (0.0, horizon), [Th, y], events=crossed, rtol=1e-10, atol=1e-13, method="RK45"
    )
    if not sol.t_events[0].size and Th <= tol and float(np.max(sol.y[0])) <= tol:
        # started inside the tolerance and never left it (Θ peaks where y = h(Θ), then falls)
        return t1
    if not sol.t_events[0].size:
        raise ValueError(
            f"tol: the comparison system did not reach {tol:g} rad within {horizon:.3g} s"
        )
    return t1 + float(sol.t_events[0][0])


def _sliding_core(
    Rt: np.ndarray, w: np.ndarray, w_d_body: np.ndarray, prm: FiniteTimeParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(Ψ, e_R, e_Ω, gain k₁ + k₂g, s) for checked R̃ = R_dᵀR stacks."""
    Psi, e_R, e_W, gain, s, _ = _surface(Rt, w, w_d_body, prm.k1, prm.k2, prm.r, prm.eps)
    return Psi, e_R, e_W, gain, s


def _surface(
    Rt: Any, w: Any, w_d_body: Any, k1: Any, k2: Any, r: Any, eps: Any
) -> tuple[Any, Any, Any, Any, Any, Any]:
    """``(Ψ, e_R, e_Ω, k₁ + k₂ g_r(x), s, x)`` with ``x = ‖e_R‖`` and the surface
    ``s = e_Ω + (k₁ + k₂ g_r(x)) e_R`` (module docstring) of ``R̃ = R_dᵀR`` ``(..., 3, 3)``.
    Pure, NumPy or JAX; ``x`` by :func:`~liecontrol._array_api.safe_sqrt` (finite derivative
    at the target, where the tangent-line continuation makes ``g_r`` smooth)."""
    xp = namespace(Rt, w, w_d_body, k1, k2, r, eps)
    Psi, e_R = _large_angle_error_unchecked(Rt)
    e_W = w - w_d_body
    x = safe_sqrt(xp.sum(e_R * e_R, axis=-1), xp)
    gain = k1 + k2 * _g(x, r, eps)
    s = e_W + gain[..., None] * e_R
    return Psi, e_R, e_W, gain, s, x


def finite_time_torque(
    Rt: Any, w: Any, w_d_body: Any, dw_d_body: Any, J: Any, k1: Any, k2: Any, r: Any,
    eps: Any, c1: Any, c2: Any, rho: Any, eps_s: Any, c3: Any = None, mu: Any = 1.5,
) -> tuple[Any, dict[str, Any]]:  # fmt: skip
    """The terminal sliding-mode torque of :class:`FiniteTimeSO3` (module docstring)::

        M = Ω × JΩ − J(Ω × R̃ᵀΩ_d − R̃ᵀΩ̇_d) − J (∂α/∂e_R · E e_Ω + k_s(‖s‖) s),

    from ``R̃ = R_dᵀR`` ``(..., 3, 3)``, the body rate ``w`` and the desired rate and
    acceleration in body axes ``(..., 3)``; ``c3=None``: finite time (no fixed-time term).
    Returns ``(M, diagnostics)`` with ``Psi``, ``theta`` (``(...)``), ``e_R``, ``e_Omega``,
    ``s``. Pure, NumPy or JAX, broadcasting over leading axes; the norms by
    :func:`~liecontrol._array_api.safe_sqrt` and the powers by :func:`_g`,
    :func:`_g_prime_over_x` and :func:`_reaching_gain`, so derivatives are finite at
    ``e_R = 0`` and ``s = 0``. No validation: :meth:`FiniteTimeSO3.command` validates."""
    xp = namespace(Rt, w, w_d_body, dw_d_body, k1, k2, c2)
    Psi, e_R, e_W, gain, s, x = _surface(Rt, w, w_d_body, k1, k2, r, eps)
    # ė_R = E e_Ω, E = ½(q₀I + e_R^), q₀ = cos(θ/2) = 1 − Ψ/2
    q0 = 1.0 - 0.5 * Psi
    de_R = 0.5 * (q0[..., None] * e_W + _cross(e_R, e_W))
    gpx = k2 * _g_prime_over_x(x, r, eps)
    dalpha = gain[..., None] * de_R + (gpx * xp.sum(e_R * de_R, axis=-1))[..., None] * e_R
    y = safe_sqrt(xp.sum(s * s, axis=-1), xp)
    with np.errstate(over="ignore", invalid="ignore"):
        wdot = -dalpha - _reaching_gain(y, c1, c2, rho, eps_s, c3, mu)[..., None] * s
        M = _cross(w, w @ J.T) - (_cross(w, w_d_body) - dw_d_body) @ J.T + wdot @ J.T
    # Ψ = 4 sin²(θ/4); the safe square root keeps the derivative finite at θ = 0
    theta = 4.0 * xp.arcsin(safe_sqrt(xp.clip(0.25 * Psi, 0.0, 1.0), xp))
    return M, {"Psi": Psi, "theta": theta, "e_R": e_R, "e_Omega": e_W, "s": s}


def sliding_variable(
    R: object, omega: object, R_d: object, omega_d: object, params: FiniteTimeParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(s, e_R, e_Ω)`` each ``(..., 3)``: ``e_R = sin(θ/2)â`` of ``R̃ = R_dᵀR``,
    ``e_Ω = Ω − R̃ᵀΩ_d`` (``omega_d`` in the desired body frame) and the surface
    ``s = e_Ω + (k₁ + k₂ g_r(‖e_R‖)) e_R`` (module docstring)."""
    params = _check_params(params)
    R = check_rotation_matrix(R, "R")
    R_d = check_rotation_matrix(R_d, "R_d")
    w = as_array(omega, "omega", (3,))
    w_d = as_array(omega_d, "omega_d", (3,))
    try:
        shape = np.broadcast_shapes(R.shape[:-2], R_d.shape[:-2], w.shape[:-1], w_d.shape[:-1])
    except ValueError:
        raise ValueError(
            f"omega: batch shapes of R {R.shape[:-2]}, omega {w.shape[:-1]}, R_d "
            f"{R_d.shape[:-2]} and omega_d {w_d.shape[:-1]} do not broadcast"
        ) from None
    R = np.broadcast_to(R, shape + (3, 3))
    R_d = np.broadcast_to(R_d, shape + (3, 3))
    Rt = np.swapaxes(R_d, -1, -2) @ R
    w_d_body = (np.swapaxes(Rt, -1, -2) @ np.broadcast_to(w_d, shape + (3,))[..., None])[..., 0]
    w = np.broadcast_to(w, shape + (3,))
    _, e_R, e_W, _, s = _sliding_core(Rt, w, w_d_body, params)
    return s, e_R, e_W


_F64 = np.dtype(np.float64)


def _vec(x: object, name: str) -> np.ndarray:
    """``as_array(x, name, (3,))`` with a cheap first check for the common case (a finite
    float64 array with a trailing 3): the per-step validation must not dominate the law."""
    if (
        isinstance(x, np.ndarray)
        and x.dtype == _F64
        and x.ndim in (1, 2)
        and x.shape[-1] == 3
        and math.isfinite(sum(x.ravel().tolist()) if x.size <= 12 else float(x.sum()))
    ):
        return x
    return as_array(x, name, (3,))


def _sample(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The one reference sample of validated float64 ``a`` (given unbatched or with a batch
    axis of 1), contiguous for the kernel (no copy in the common case)."""
    if a.shape != shape:
        a = a.reshape(shape)
    return a if a.flags.c_contiguous else np.ascontiguousarray(a)


def _stack(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """A reference array broadcast to the batch ``shape``, contiguous for the kernel."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=np.float64), shape))


# the compiled kernels' cross product, NumPy or JAX (liecontrol._array_api.cross)
_cross = cross


# ------------------------------------------------------------------------------ controllers


def _finite_time_rows(d: np.ndarray) -> dict[str, np.ndarray]:
    """``Psi``, ``theta``, ``e_R``, ``e_Omega``, ``s`` from the kernel's rows ``(..., 11)``."""
    return {
        "Psi": d[..., 0],
        "theta": d[..., 1],
        "e_R": d[..., 2:5],
        "e_Omega": d[..., 5:8],
        "s": d[..., 8:11],
    }


class FiniteTimeSO3(AttitudeController):
    """Nonsingular fast terminal sliding mode on SO(3) (module docstring for equations,
    stability argument and sources).

    ``M = Ω × JΩ − J(Ω × R̃ᵀΩ_d − R̃ᵀΩ̇_d) − J(∂α/∂e_R · E e_Ω + k_s(‖s‖) s)``, with the
    large-angle error ``e_R = sin(θ/2)â`` of ``R̃ = R_dᵀR`` (no chart, no unwinding).

    Args:
        J: 3×3 inertia the controller assumes [kg·m²].
        k1, k2, r, eps, c1, c2, rho, eps_s, c3, mu: :class:`FiniteTimeParams` (``c3 = 0``:
            finite time; see :class:`FixedTimeSO3` for ``c3 > 0``).

    ``command`` returns ``(B, 3)``; ``diagnostics()`` gives the last ``Psi`` ``(B,)``,
    ``theta`` ``(B,)``, ``e_R``, ``e_Omega`` and ``s`` ``(B, 3)``.
    """

    batched = True

    def __init__(
        self,
        J: object,
        k1: float,
        k2: float,
        c2: float,
        r: float = 0.5,
        eps: float = 0.05,
        c1: float = 0.0,
        rho: float = 0.5,
        eps_s: float = 1e-3,
        c3: float = 0.0,
        mu: float = 1.5,
    ) -> None:
        J = check_inertia_3x3(J, "J")
        self.J = J.copy()
        self.J.setflags(write=False)
        self.params = FiniteTimeParams(
            k1=k1, k2=k2, r=r, eps=eps, c1=c1, c2=c2, rho=rho, eps_s=eps_s, c3=c3, mu=mu
        )
        # the kernel's parameter vector (liecontrol._kernels.finite_time.PARAM_NAMES), with the
        # tangent-line coefficients a_p = (2 − p)ε^(p−1), b_p = (p − 1)ε^(p−2) of g_r and g_ρ
        p = self.params
        self._kprm = np.array(
            [
                p.k1, p.k2, p.r, p.eps, p.c1, p.c2, p.rho, p.eps_s, p.c3, p.mu,
                (2.0 - p.r) * p.eps ** (p.r - 1.0),
                (p.r - 1.0) * p.eps ** (p.r - 2.0),
                (2.0 - p.rho) * p.eps_s ** (p.rho - 1.0),
                (p.rho - 1.0) * p.eps_s ** (p.rho - 2.0),
            ]
        )  # fmt: skip
        self._kprm.setflags(write=False)
        self._kJ = np.ascontiguousarray(self.J)
        self._batch: int | None = None
        self._diag: dict[str, np.ndarray] | np.ndarray = {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.params!r})"

    def reset(self, t0: float, batch_size: int) -> None:
        """Check ``t0`` and ``batch_size``; clear the diagnostics (the law has no state)."""
        if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)):
            raise ValueError(f"batch_size: expected a positive int, got {batch_size!r}")
        if batch_size < 1:
            raise ValueError(f"batch_size: must be >= 1, got {batch_size}")
        as_scalar(t0, "t0")
        self._batch = int(batch_size)
        self._diag = {}

    def convergence_time_bound(
        self, tol: float, theta0: float = math.pi, s0: float = math.inf, max_torque: object = None
    ) -> float:
        """:func:`convergence_time_bound` with this controller's gains (same assumptions:
        exact model, unbounded torque, continuous time; ``nan`` and a
        :class:`BoundNotApplicable` warning with a ``max_torque``)."""
        return convergence_time_bound(self.params, tol, theta0, s0, max_torque=max_torque)

    def _reference(self, reference: AttitudeReference, B: int) -> tuple[np.ndarray, ...]:
        if not isinstance(reference, AttitudeReference):
            raise TypeError(
                f"reference: expected AttitudeReference, got {type(reference).__name__}"
            )
        R_d = reference.R_d
        if not (isinstance(R_d, np.ndarray) and R_d.ndim in (2, 3) and rotations_pass_fast(R_d)):
            R_d = check_rotation_matrix(R_d, "R_d")
        w_d = _vec(reference.omega_d, "omega_d")
        dw_d = _vec(reference.omega_dot_d, "omega_dot_d")
        for name, a, nd in (("R_d", R_d, 2), ("omega_d", w_d, 1), ("omega_dot_d", dw_d, 1)):
            if a.ndim > nd + 1 or (a.ndim == nd + 1 and a.shape[0] != B):
                raise ValueError(f"{name}: expected one sample or a batch of {B}, got {a.shape}")
        return R_d, w_d, dw_d

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m]."""
        if self._batch is None:
            raise RuntimeError(f"{type(self).__name__}.command: call reset(t0, batch_size) first")
        as_scalar(t, "t")
        if not isinstance(state, AttitudeState):
            raise TypeError(f"state: expected AttitudeState, got {type(state).__name__}")
        R, w = state.R, state.omega
        if not (isinstance(R, np.ndarray) and R.ndim == 3 and rotations_pass_fast(R)):
            R = check_rotation_matrix(R, "R")
        w = _vec(w, "omega")
        B = check_state_batch(R, w, self._batch)
        R_d, w_d, dw_d = self._reference(reference, B)
        if B == 1 or JIT_ENABLED:
            return finite_command(self._command_kernel(R, w, R_d, w_d, dw_d), w)
        return finite_command(self._command_numpy(R, w, R_d, w_d, dw_d), w)

    def _command_numpy(
        self, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray
    ) -> np.ndarray:
        """:meth:`command` on stacked numpy arrays (validated input): the batched route without
        the compiler, and the reference the kernel is tested against."""
        B = R.shape[0]
        Rt = np.swapaxes(R_d, -1, -2) @ R  # (B, 3, 3) whether R_d is one sample or a batch
        RtT = np.swapaxes(Rt, -1, -2)
        w_d_body = (RtT @ np.broadcast_to(w_d, (B, 3))[..., None])[..., 0]
        dw_d_body = (RtT @ np.broadcast_to(dw_d, (B, 3))[..., None])[..., 0]
        M, self._diag = finite_time_torque(Rt, w, w_d_body, dw_d_body, self.J, *self._gains())
        return M

    def _gains(self) -> tuple:
        """``(k1, k2, r, eps, c1, c2, rho, eps_s, c3, mu)`` as :func:`finite_time_torque`
        takes them (``c3=None`` without the fixed-time term)."""
        p = self.params
        c3 = p.c3 if p.c3 > 0.0 else None
        return p.k1, p.k2, p.r, p.eps, p.c1, p.c2, p.rho, p.eps_s, c3, p.mu

    def _command_kernel(
        self, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray
    ) -> np.ndarray:
        """:meth:`command` through the compiled kernel
        (:func:`liecontrol._kernels.finite_time.finite_time_one`), one spacecraft at a time."""
        B = R.shape[0]
        M = np.empty((B, 3))
        diag = np.empty((B, N_DIAG))
        R = np.ascontiguousarray(R, dtype=np.float64)
        w = np.ascontiguousarray(w, dtype=np.float64)
        if B == 1:
            finite_time_one(
                self._kJ, self._kprm, R[0], w[0],
                _sample(R_d, (3, 3)), _sample(w_d, (3,)), _sample(dw_d, (3,)), M[0], diag[0],
            )  # fmt: skip
        else:
            finite_time_batch(
                self._kJ, self._kprm, R, w,
                _stack(R_d, (B, 3, 3)), _stack(w_d, (B, 3)), _stack(dw_d, (B, 3)), M, diag,
            )  # fmt: skip
        self._diag = diag  # the rows; diagnostics() splits them (not worth it on every step)
        return M

    def _kernel_args(self) -> tuple[np.ndarray, np.ndarray]:
        """``(J, parameter vector)`` of the compiled kernel."""
        return self._kJ, self._kprm

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel:
        """The compiled law (:func:`liecontrol._kernels.finite_time.finite_time_law`) for the
        simulator's fused loop, through the public seam :mod:`liecontrol.control.kernel`."""
        params = np.concatenate([self._kJ.ravel(), self._kprm])

        def finish(state: np.ndarray, diag: np.ndarray) -> None:
            self._diag = diag.copy()

        return ControllerKernel(
            finite_time_law, params, np.zeros((batch_size, 0)), N_DIAG, _finite_time_rows, finish
        )

    def array_law(self) -> ArrayLaw:
        """The law as a pure array function for the differentiable loop
        (:mod:`liecontrol.control.array_law`): :func:`finite_time_torque`, the function
        :meth:`command` evaluates (without the compiler); memoryless.

        Differentiable gains: ``k_R`` is the terminal surface gain ``k₂`` [1/s], ``k_Omega``
        the terminal reaching gain ``c₂``; further parameters (``params``): ``k1``, ``c1``, the
        powers ``r`` and ``rho``, the continuation radius ``eps`` and the boundary layer
        ``eps_s`` (and ``c3``, ``mu`` of the fixed-time term when ``c3 > 0``). The powers are
        taken of ``max(x, ε)`` and the norms by a safe square root, so the gradient is finite
        at the target (``e_R = 0``, ``s = 0``)."""
        J = np.array(self.J)
        k1, k2, r, eps, c1, c2, rho, eps_s, c3, mu = self._gains()
        params = {"k1": k1, "r": r, "eps": eps, "c1": c1, "rho": rho, "eps_s": eps_s}
        if c3 is not None:
            params.update(c3=c3, mu=mu)

        def step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T, *, params):  # noqa: ANN001
            xp = namespace(R, R_d)
            Rt = xp.swapaxes(R_d, -1, -2) @ R
            RtT = xp.swapaxes(Rt, -1, -2)
            w_d_body = (RtT @ omega_d[..., None])[..., 0]
            dw_d_body = (RtT @ omega_dot_d[..., None])[..., 0]
            p = params
            M, d = finite_time_torque(
                Rt, omega, w_d_body, dw_d_body, J, p["k1"], k_R, p["r"], p["eps"], p["c1"],
                k_Omega, p["rho"], p["eps_s"], p.get("c3"), p.get("mu", mu),
            )  # fmt: skip
            return M, state, d

        return ArrayLaw(k2, c2, (), step, params=params)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last ``Psi``, ``theta`` ``(B,)`` and ``e_R``, ``e_Omega``, ``s`` ``(B, 3)``."""
        d = self._diag
        if isinstance(d, np.ndarray):  # the kernel's rows (Ψ, θ, e_R, e_Ω, s)
            return _finite_time_rows(d)
        return dict(d)


class FixedTimeSO3(FiniteTimeSO3):
    """:class:`FiniteTimeSO3` with the fixed-time reaching term ``c₃‖s‖^(μ−1)s`` (``c3 > 0``
    required): the settling time has a bound independent of the initial attitude and rate,
    :meth:`settling_bound` (Polyakov 2012 for the reaching phase, the finite slide time from
    ``θ = π`` for the surface; module docstring)."""

    def __init__(
        self,
        J: object,
        k1: float,
        k2: float,
        c2: float,
        c3: float,
        r: float = 0.5,
        eps: float = 0.05,
        c1: float = 0.0,
        rho: float = 0.5,
        eps_s: float = 1e-3,
        mu: float = 1.5,
    ) -> None:
        c3 = _positive(c3, "c3")
        super().__init__(J, k1, k2, c2, r=r, eps=eps, c1=c1, rho=rho, eps_s=eps_s, c3=c3, mu=mu)

    def settling_bound(self, tol: float, max_torque: object = None) -> float:
        """Bound [s] valid for every initial attitude and rate: the time after which the error
        angle stays ``≤ tol`` (:func:`convergence_time_bound` at ``θ₀ = π``, ``s₀ = ∞``).

        Assumes unbounded torque (the reaching law's torque grows like ``J c₃ ‖s‖^μ`` with the
        initial rate), the exact model and continuous time. With the actuator's torque limit
        ``max_torque`` the bound is reported as not applicable: ``nan`` and a
        :class:`BoundNotApplicable` warning."""
        return convergence_time_bound(self.params, tol, max_torque=max_torque)
