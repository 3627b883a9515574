"""One tuning protocol for every attitude-controller family: a closed-loop spec in, gains out.

**The protocol.** A :class:`ClosedLoopSpec` fixes what every controller's *small-angle* closed
loop must look like — natural frequency ``ω_n`` [rad/s], damping ratio ``ζ`` and the sample
period ``T_s`` at which the controller is called — and :class:`ActuatorLimits` what the hardware
can deliver. One function per family (``tune_*``) turns ``(J, spec)`` into that family's
parameters, returned as a ``dict`` of constructor keywords, so that near ``R = R_d`` every
principal axis of the *full* inertia ``J`` obeys

    δθ̈ + 2ζω_n δθ̇ + ω_n² δθ = 0

(or, for laws with an extra integral/observer state, has that pole pair as its dominant pair
and the extra poles elsewhere, stated per family). Linearising ``J δθ̈ = u(δθ, δθ̇)`` about
``R = R_d``: a PD law on an error coordinate with slope ``s`` (``e ≈ s δθ``: ``s = 1`` for the
logarithm, ``½`` for Lee's large-angle error and the quaternion vector part, ``¼`` for the
modified Rodrigues parameters) gives ``J δθ̈ + K_d δθ̇ + K_p s δθ = 0``, so ``K_p = ω_n² J / s``,
``K_d = 2ζω_n J`` put every axis at ``(ω_n, ζ)`` whatever ``J`` is (matrix gains; scalar gains
would only fit the largest principal moment). :func:`measure_small_angle_response` checks any
controller — including a user's own — against the spec through the public
:class:`~liecontrol.control.base.AttitudeController` seam.

**Sampling rule.** A law designed in continuous time and called every ``T_s`` with a
zero-order hold behaves, for ``ω_n T_s ≪ 1``, like the continuous loop with an extra delay of
about ``T_s/2``: its equivalent continuous poles ``ln(z)/T_s`` move by roughly ``ζ ω_n T_s / 2``
relative (computed exactly for the sampled double integrator: 4.9 % in ``ω_n`` and 1.9 % in
``ζ`` at ``ω_n T_s = 0.1``, ``ζ = 0.9``; 10.8 % and 4.2 % at 0.2). :data:`MAX_OMEGA_T` = 0.1
keeps that discretisation error at ≤ 5 %, a third of the 15 % tolerance within which the
benchmark checks that the measured poles meet the spec; a slower sample period is refused with
:class:`TuningInfeasible` naming ``sample_period``.

**Actuator rule.** :func:`check_actuator` estimates, from the linear closed loop, the torque and
the momentum the spec's response to a rest-to-rest step of the given size needs (for a
second-order loop started at rest, the peak acceleration is ``ω_n² θ₀`` at ``t = 0`` and the
peak rate ``ω_n θ₀ ρ(ζ)`` with ``ρ(0.9) ≈ 0.39``, see :func:`step_peaks`) and raises
:class:`TuningInfeasible` when either exceeds the actuator's torque limit or momentum storage
by more than :data:`ACTUATOR_MARGIN` = 4. Up to that margin the actuator saturates for part of
the transient — the slew is torque- or rate-limited and lasts longer than the spec's, which is
what an actuator-limited benchmark is meant to show. Beyond it the saturated phase would take
≳ 4× the spec's time scale: the closed loop is then the actuator's, not the tuned controller's,
and the pair is reported as not applicable instead.

Per family (sources in each function's docstring): geometric PD
(:func:`tune_geometric_pd`), intrinsic PID and integral PD (:func:`tune_intrinsic_pid`,
:func:`tune_integral_pd`), prescribed performance (:func:`tune_prescribed_performance`), MPC by
LQR matching (:func:`tune_mpc`), MRP ADRC by Gao's bandwidth parameterisation
(:func:`tune_mrp_adrc`), Euler terminal sliding mode (:func:`tune_euler_tsm`), finite/fixed-time
sliding mode on SO(3) (:func:`tune_finite_time_so3`), quaternion and
MRP PD (:func:`tune_quaternion_pd`, :func:`tune_mrp_pd`), the small-angle Euler PID
(:func:`tune_small_angle_pid`).
"""

from __future__ import annotations

import copy
import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_array, check_inertia_3x3, check_positive
from ..lie import so3
from .base import AttitudeController, AttitudeReference, AttitudeState

__all__ = [
    "MAX_OMEGA_T",
    "ACTUATOR_MARGIN",
    "INTEGRAL_RATIO",
    "ADRC_OBSERVER_RATIO",
    "MAX_AXIS_COUPLING",
    "UNLIMITED_TORQUE",
    "TuningInfeasible",
    "ClosedLoopSpec",
    "ActuatorLimits",
    "step_peaks",
    "required_actuation",
    "check_actuator",
    "tune_geometric_pd",
    "tune_intrinsic_pid",
    "tune_integral_pd",
    "tune_adaptive_so3",
    "ADAPTIVE_INERTIA_RATE",
    "tune_prescribed_performance",
    "tune_mpc",
    "tune_mrp_adrc",
    "tune_euler_tsm",
    "tune_quaternion_pd",
    "tune_mrp_pd",
    "tune_small_angle_pid",
    "tune_finite_time_so3",
    "measure_small_angle_response",
]

#: Largest ``ω_n · T_s`` accepted by :class:`ClosedLoopSpec` (module docstring: ≤ 5 % pole shift).
MAX_OMEGA_T = 0.1
#: A spec whose linear step response needs more than this multiple of the actuator's torque
#: limit or momentum storage is refused (module docstring).
ACTUATOR_MARGIN = 4.0
#: Integral pole of the PID family at ``−INTEGRAL_RATIO · ω_n`` (slower than the pair, so the
#: transient is the pair's and the integral only removes the constant disturbance).
INTEGRAL_RATIO = 0.2
#: Torque box of the MPC when the actuator has no torque limit (inactive, but finite for the QP).
UNLIMITED_TORQUE = 1e9
#: Observer-to-controller bandwidth ratio ``k = ω_o/ω_c`` of the ADRC (Gao 2003 recommends
#: 3–10; 5 keeps the observer well separated from the loop and ``ω_o T_s ≤ 0.5`` under
#: :data:`MAX_OMEGA_T`).
ADRC_OBSERVER_RATIO = 5.0


class TuningInfeasible(ValueError):
    """The spec cannot be met (sample period too long, actuator too weak, family limitation).

    The message starts with the name of the offending value, like every ``ValueError`` here.
    """


def _scalar(x: object, name: str) -> float:
    if isinstance(x, bool):
        raise TypeError(f"{name}: expected a real number, got bool")
    a = np.asarray(x) if not isinstance(x, np.ndarray) else x
    if a.ndim != 0:
        raise TypeError(f"{name}: expected a scalar, got an array of shape {a.shape}")
    try:
        v = float(a)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected a real number, got {type(x).__name__}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name}: must be finite, got {v}")
    return v


def _positive(x: object, name: str) -> float:
    v = _scalar(x, name)
    if v <= 0.0:
        raise ValueError(f"{name}: must be > 0, got {v:g}")
    return v


@dataclass(frozen=True)
class ClosedLoopSpec:
    """The small-angle closed loop every controller is tuned to.

    Attributes:
        omega_n: natural frequency ω_n [rad/s], > 0.
        zeta: damping ratio ζ, > 0.
        sample_period: controller sample period T_s [s], > 0, with ``ω_n T_s ≤``
            :data:`MAX_OMEGA_T` (module docstring), else :class:`TuningInfeasible`.
    """

    omega_n: float
    zeta: float
    sample_period: float

    def __post_init__(self) -> None:
        w = _positive(self.omega_n, "omega_n")
        z = _positive(self.zeta, "zeta")
        T = _positive(self.sample_period, "sample_period")
        object.__setattr__(self, "omega_n", w)
        object.__setattr__(self, "zeta", z)
        object.__setattr__(self, "sample_period", T)
        if w * T > MAX_OMEGA_T * (1.0 + 1e-12):
            raise TuningInfeasible(
                f"sample_period: {T:g} s is too long for omega_n = {w:g} rad/s "
                f"(omega_n·T_s = {w * T:.3g} > {MAX_OMEGA_T}; sample at ≤ {MAX_OMEGA_T / w:.4g} s "
                "or lower omega_n)"
            )

    @property
    def settling_time(self) -> float:
        """2 % settling time of the spec's response to a step from rest [s] (:func:`step_peaks`)."""
        return step_peaks(self.omega_n, self.zeta)[2]


def _per_axis(x: object, name: str) -> tuple[float, float, float] | None:
    if x is None:
        return None
    if isinstance(x, bool):
        raise TypeError(f"{name}: expected a number or 3 numbers, got bool")
    a = as_array(x, name)
    if a.shape not in ((), (3,)):
        raise ValueError(f"{name}: expected a scalar or shape (3,), got {a.shape}")
    check_positive(a, name)
    b = np.broadcast_to(a, (3,))
    return (float(b[0]), float(b[1]), float(b[2]))


@dataclass(frozen=True)
class ActuatorLimits:
    """What the actuator can deliver, in body axes.

    Attributes:
        max_torque: per-axis torque limit [N·m] (scalar or 3 values), ``None`` = unlimited.
        max_momentum: momentum storage [N·m·s] (scalar: the same in every direction, the
            smallest radius of the momentum envelope; or 3 per-axis values), ``None`` = unlimited.
        max_gimbal_rate: gimbal-rate limit of a CMG cluster [rad/s] (informative: it is
            already folded into ``max_torque`` by whoever derives the limits), ``None`` if none.
    """

    max_torque: Any = None
    max_momentum: Any = None
    max_gimbal_rate: Any = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "max_torque", _per_axis(self.max_torque, "max_torque"))
        object.__setattr__(self, "max_momentum", _per_axis(self.max_momentum, "max_momentum"))
        if self.max_gimbal_rate is not None:
            object.__setattr__(
                self, "max_gimbal_rate", _positive(self.max_gimbal_rate, "max_gimbal_rate")
            )


# ----------------------------------------------------------------------------- actuator check


def step_peaks(omega_n: float, zeta: float, fraction: float = 0.02) -> tuple[float, float, float]:
    """``(a, v, t_s)`` of ``θ̈ + 2ζω_n θ̇ + ω_n² θ = 0`` from ``θ(0) = 1``, ``θ̇(0) = 0``:
    peak ``|θ̈|``, peak ``|θ̇|`` and the settling time to ``fraction`` (the last time
    ``|θ| > fraction``; default 2 %).

    Evaluated from the closed-form solution (under-, critically or over-damped) on a grid of
    6001 points over ``30/(min(ζ, 1) ω_n)``; scale ``a, v`` by the step size θ₀.
    """
    w = _positive(omega_n, "omega_n")
    z = _positive(zeta, "zeta")
    for name, v in (("omega_n", w), ("zeta", z)):
        if v > 1e6:  # the time grid spans 30/(ζω): beyond this it underflows
            raise ValueError(f"{name}: {v:g} is out of range (≤ 1e6)")
    f = _positive(fraction, "fraction")
    if f >= 1.0:
        raise ValueError(f"fraction: must be in (0, 1), got {f:g}")
    return _step_peaks(w, z, f)


@functools.lru_cache(maxsize=256)
def _step_peaks(w: float, z: float, f: float) -> tuple[float, float, float]:
    t = np.linspace(0.0, 30.0 / (min(z, 1.0) * w), 6001)
    if abs(z - 1.0) < 1e-6:  # critically damped: double pole −ω
        e = np.exp(-w * t)
        th, thd = (1.0 + w * t) * e, -w * w * t * e
    elif z < 1.0:
        wd = w * math.sqrt(1.0 - z * z)
        e = np.exp(-z * w * t)
        th = e * (np.cos(wd * t) + (z * w / wd) * np.sin(wd * t))
        thd = -(w * w / wd) * e * np.sin(wd * t)
    else:
        r = math.sqrt(z * z - 1.0)
        s1, s2 = -w * (z - r), -w * (z + r)
        e1, e2 = np.exp(s1 * t), np.exp(s2 * t)
        th = (s2 * e1 - s1 * e2) / (s2 - s1)
        thd = s1 * s2 * (e1 - e2) / (s2 - s1)
    acc = -2.0 * z * w * thd - w * w * th
    above = np.nonzero(np.abs(th) > f)[0]
    ts = float(t[above[-1] + 1]) if above.size and above[-1] + 1 < t.size else float("nan")
    return float(np.abs(acc).max()), float(np.abs(thd).max()), ts


def required_actuation(
    J: object, spec: ClosedLoopSpec, step_rotvec: object
) -> tuple[np.ndarray, float]:
    """Linear estimate of the per-axis peak torque ``(3,)`` [N·m] and the peak body momentum
    [N·m·s] of the spec's response to a rest-to-rest step ``step_rotvec`` (rotation vector of
    the initial error, [rad]): ``|J â| a θ₀`` and ``‖J â‖ v θ₀`` with ``(a, v)`` from
    :func:`step_peaks` (the loop obeys the spec along the step axis â). For large steps this
    over-estimates (saturating error functions ask for less); it is a screening bound."""
    J = check_inertia_3x3(J, "J")
    _check_spec(spec)
    r = as_array(step_rotvec, "step_rotvec", (3,))
    if r.shape != (3,):
        raise ValueError(f"step_rotvec: expected shape (3,), got {r.shape}")
    theta = float(np.linalg.norm(r))
    if theta > math.pi + 1e-9:
        raise ValueError(f"step_rotvec: a rotation vector has angle ≤ π, got {theta:g} rad")
    if theta == 0.0:
        return np.zeros(3), 0.0
    a_hat = r / theta
    a, v, _ = step_peaks(spec.omega_n, spec.zeta)
    Ja = J @ a_hat
    tau, h = np.abs(Ja) * a * theta, float(np.linalg.norm(Ja)) * v * theta
    if not (np.all(np.isfinite(tau)) and math.isfinite(h)):
        raise ValueError("J: the required torque/momentum overflows (inertia out of range)")
    return tau, h


def check_actuator(
    J: object,
    spec: ClosedLoopSpec,
    limits: ActuatorLimits | None,
    step_rotvec: object,
    margin: float = ACTUATOR_MARGIN,
) -> None:
    """Raise :class:`TuningInfeasible` when the spec's step response (:func:`required_actuation`)
    needs more than ``margin`` times ``limits.max_momentum`` or ``limits.max_torque`` (on some
    axis; module docstring). ``limits=None``: nothing to check."""
    if limits is not None and not isinstance(limits, ActuatorLimits):
        raise TypeError(f"limits: expected ActuatorLimits or None, got {type(limits).__name__}")
    margin = _positive(margin, "margin")
    tau, h = required_actuation(J, spec, step_rotvec)
    if limits is None:
        return
    deg = float(np.rad2deg(np.linalg.norm(np.asarray(step_rotvec, dtype=np.float64))))
    if limits.max_momentum is not None:
        h_max = min(limits.max_momentum)
        if h > margin * h_max:
            raise TuningInfeasible(
                f"omega_n: {spec.omega_n:g} rad/s needs a peak momentum of {h:.4g} N·m·s for "
                f"this {deg:.3g}° step, {h / h_max:.3g}× what the actuator stores "
                f"({h_max:.4g} N·m·s; margin {margin:g}×)"
            )
    if limits.max_torque is not None:
        lim = np.asarray(limits.max_torque)
        ratio = tau / lim
        k = int(np.argmax(ratio))
        if ratio[k] > margin:
            raise TuningInfeasible(
                f"omega_n: {spec.omega_n:g} rad/s needs a peak torque of {tau[k]:.4g} N·m on "
                f"axis {k} for this {deg:.3g}° step, {ratio[k]:.3g}× the limit {lim[k]:.4g} N·m "
                f"(margin {margin:g}×)"
            )


def _check_spec(spec: object) -> ClosedLoopSpec:
    if not isinstance(spec, ClosedLoopSpec):
        raise TypeError(f"spec: expected ClosedLoopSpec, got {type(spec).__name__}")
    return spec


# ----------------------------------------------------------------------------- families


def tune_geometric_pd(
    J: object, spec: ClosedLoopSpec, error: str = "large_angle", G: object = None
) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.geometric_pd.GeometricPD`:
    ``K_R = ω_n² J / s``, ``K_Ω = 2ζω_n J`` with the error function's slope ``s``
    (:func:`~liecontrol.control.geometric_pd.gains_from_bandwidth` with ``matrix=True``; Lee,
    Leok & McClamroch, "Geometric tracking control of a quadrotor UAV on SE(3)", CDC 2010, for
    the law). The trace error with a non-isotropic ``G`` has per-direction slopes; the slowest
    direction then gets ``(ω_n, ζ)`` and the others are faster."""
    from .geometric_pd import gains_from_bandwidth

    spec = _check_spec(spec)
    k_R, k_W = gains_from_bandwidth(J, spec.omega_n, spec.zeta, error=error, G=G, matrix=True)
    out: dict[str, Any] = {"k_R": k_R, "k_Omega": k_W, "error": error}
    if G is not None:
        out["G"] = G
    return out


def _pid_coefficients(spec: ClosedLoopSpec, integral_ratio: float) -> tuple[float, float, float]:
    """``(a₂, a₁, a₀)`` of ``(s² + 2ζω s + ω²)(s + p)``, ``p = integral_ratio · ω``."""
    w, z = spec.omega_n, spec.zeta
    r = _positive(integral_ratio, "integral_ratio")
    if r > 10.0:
        raise ValueError(f"integral_ratio: must be ≤ 10 (integral pole ≤ 10 ω_n), got {r:g}")
    p = r * w
    return 2.0 * z * w + p, w * w + 2.0 * z * w * p, w * w * p


def tune_intrinsic_pid(
    J: object, spec: ClosedLoopSpec, integral_ratio: float = INTEGRAL_RATIO
) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.geometric_pid.IntrinsicPID` (log error; the
    intrinsic PID of Maithripala & Berg, "An intrinsic PID controller for mechanical systems on
    Lie groups", Automatica 54, 2015).

    Linearised per axis (``ż = e_R ≈ δθ``): ``J s³ + K_Ω s² + K_R s + K_I = 0``. Matching
    ``(s² + 2ζω_n s + ω_n²)(s + p)`` with the integral pole ``p = integral_ratio · ω_n``:
    ``K_Ω = (2ζω_n + p) J``, ``K_R = (ω_n² + 2ζω_n p) J``, ``K_I = ω_n² p J`` — the spec's pair
    stays exactly in place and the integral adds one slower real pole.
    """
    J = check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    a2, a1, a0 = _pid_coefficients(spec, integral_ratio)
    return {"k_R": a1 * J, "k_Omega": a2 * J, "k_I": a0 * J, "error": "log"}


def tune_integral_pd(
    J: object,
    spec: ClosedLoopSpec,
    integral_ratio: float = INTEGRAL_RATIO,
    c: float | None = None,
) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.geometric_pid.IntegralPD` (large-angle error,
    ``ż = e_Ω + c e_R``; Goodarzi, Lee & Lee, "Geometric nonlinear PID control of a quadrotor
    UAV on SE(3)", ECC 2013).

    Linearised per axis with slope ``s = ½``: ``J s³ + K_Ω s² + (s K_R + K_I) s + c s K_I = 0``
    (the integral of ``e_Ω`` adds ``K_I`` to the stiffness). Matching
    ``(s² + 2ζω_n s + ω_n²)(s + p)``, ``p = integral_ratio · ω_n``, with ``c = ω_n`` (default):
    ``K_I = ω_n² p J / (c s)``, ``K_R = ((ω_n² + 2ζω_n p) J − K_I)/s``, ``K_Ω = (2ζω_n + p) J``.
    """
    J = check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    c = spec.omega_n if c is None else _positive(c, "c")
    s = 0.5
    a2, a1, a0 = _pid_coefficients(spec, integral_ratio)
    k_I = a0 / (c * s)
    k_R = (a1 - k_I) / s
    if k_R <= 0.0:
        raise TuningInfeasible(
            f"c: {c:g} 1/s leaves a non-positive attitude gain for this spec; choose c > "
            f"{a0 / (s * a1):.3g}"
        )
    return {"k_R": k_R * J, "k_Omega": a2 * J, "k_I": k_I * J, "c": c, "error": "large_angle"}


#: Default inertia adaptation gain ``γ_θ = ADAPTIVE_INERTIA_RATE · λ_max(J) / ω_n²`` of
#: :func:`tune_adaptive_so3` (dimensionless; ~1 lets a slew of ~1 rad re-learn a sizeable fraction
#: of ``J`` within one spec time constant).
ADAPTIVE_INERTIA_RATE = 0.5


def tune_adaptive_so3(
    J: object,
    spec: ClosedLoopSpec,
    disturbance_bound: float,
    frequencies: object = (),
    integral_ratio: float = 0.1,
    inertia_rate: float = ADAPTIVE_INERTIA_RATE,
    inertia_bound: float = 0.5,
    error: str = "trace",
) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.adaptive.AdaptiveGeometricSO3` (adaptive
    geometric tracking after Sanyal, Fosbury, Chaturvedi & Bernstein, JGCD 32(4), 2009, and
    Lee, IEEE TCST 21(5), 2013).

    Linearised about ``R = R_d`` on the principal axis of largest inertia ``j = λ_max(J)``, with
    ``K_s = κ J``, slope ``σ`` of the error (``e_R ≈ σ δθ``), ``u = cσ`` and the constant
    disturbance estimate acting like an integral state, the loop is

        p³ + (u + κ) p² + (κu + (σ k_R + γ_φ)/j) p + γ_φ u / j.

    Matching ``(p² + 2ζω_n p + ω_n²)(p + q)``, ``q = integral_ratio · ω_n``:
    ``κ = 2ζω_n + q − u``, ``γ_φ = j ω_n² q / u``, ``k_R = j(ω_n² + 2ζω_n q − κu − ω_n² q/u)/σ``;
    ``u`` is chosen to maximise ``k_R`` (the Lyapunov decrease ``c k_R|e_R|²``), a root of
    ``2u³ − (2ζω_n + q)u² + ω_n² q = 0``. Axes of smaller inertia are faster and stay stable
    (scalar ``k_R`` and ``γ_φ``). The Lyapunov argument holds for any positive gains; this only
    places the small-angle poles. ``γ_θ = inertia_rate · j / ω_n²``.

    Raises :class:`TuningInfeasible` (``integral_ratio``) when no ``u`` gives ``k_R > 0``
    (for ζ = 0.9: ``integral_ratio`` above ≈ 0.27).
    """
    from .adaptive import _check_frequencies
    from .geometric_pd import linear_error_slope

    J = check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    if isinstance(frequencies, (tuple, list)) and len(frequencies) == 0:
        frequencies = np.zeros(0)
    frequencies = tuple(_check_frequencies(frequencies).tolist())
    r = _positive(integral_ratio, "integral_ratio")
    rate = _positive(inertia_rate, "inertia_rate")
    w, z = spec.omega_n, spec.zeta
    sigma = linear_error_slope(error, None, "min")
    j = float(np.linalg.eigvalsh(J)[-1])
    q = r * w
    # k_R(u)·σ/j = ω² + 2ζωq − (2ζω + q − u)u − ω²q/u, stationary where its u-derivative is 0
    roots = np.roots([2.0, -(2.0 * z * w + q), 0.0, w * w * q])
    cands = [x.real for x in roots if abs(x.imag) < 1e-12 and 0.0 < x.real < 2.0 * z * w + q]
    best = None
    for u in cands:
        kR = j * (w * w + 2.0 * z * w * q - (2.0 * z * w + q - u) * u - w * w * q / u) / sigma
        if best is None or kR > best[1]:
            best = (u, kR)
    if best is None or best[1] <= 0.0:
        raise TuningInfeasible(
            f"integral_ratio: {r:g} leaves no positive attitude gain k_R at zeta = {z:g}; "
            "use a smaller ratio (slower disturbance estimation)"
        )
    u, k_R = best
    return {
        "k_R": k_R,
        "k_s": (2.0 * z * w + q - u) * J,
        "c": u / sigma,
        "gamma_theta": rate * j / (w * w),
        "gamma_phi": j * w * w * q / u,
        "frequencies": frequencies,
        "disturbance_bound": _positive(disturbance_bound, "disturbance_bound"),
        "inertia_bound": _positive(inertia_bound, "inertia_bound"),
        "error": error,
    }


def tune_prescribed_performance(
    J: object,
    spec: ClosedLoopSpec,
    rho_inf: float = 0.002,
    decay_ratio: float = 0.25,
    margin: float = 3.0,
    outer: float = 0.25,
) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.prescribed_performance.PrescribedPerformance`
    (funnel of Bechlioulis & Rovithakis, IEEE TAC 53(9), 2008).

    The law's linearisation at ``R = R_d`` with a steady funnel is
    ``θ̈ + (k₂ + k₁/4) θ̇ + (k₂k₁/4 + k_c/4) θ = 0`` on every axis, independent of ``J``:
    :func:`~liecontrol.control.prescribed_performance.ppc_gains` gives ``(k₁, k₂, k_c)`` for
    ``(ω_n, ζ)``. During a transient the funnel adds to that loop: its feed-forward
    ``2(ρ̇/ρ)e_R`` raises the outer-loop rate by ≈ the decay ``l`` while ``ρ ≫ ρ_∞``, and the
    error transformation raises the gain by ``artanh(z)/(z(1 − z²))`` at ``z = e/ρ``. So the
    funnel is made wide and slow: it starts at ``margin = 3`` times the initial error (gain
    excess ≤ 17 % at the start) and decays at ``l = decay_ratio · ζω_n`` with
    ``decay_ratio = ¼`` (measured on a 5° step of the benchmark spacecraft: settles in 121 s
    against the linear spec's 157 s; with the law's default margin 1.25 and ``l = ζω_n/2``,
    88 s). It still bounds the error by construction; it binds only if the response falls
    well behind the spec. ``rho_inf`` is the steady bound on each component of ``e_R``
    (≈ half the angle in rad).
    """
    from .prescribed_performance import ppc_gains

    check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    k1, k2, kc = ppc_gains(spec.omega_n, spec.zeta, outer)
    decay = _positive(decay_ratio, "decay_ratio") * spec.zeta * spec.omega_n
    m = _positive(margin, "margin")
    if m <= 1.0:
        raise ValueError(f"margin: must be > 1 (the funnel must contain the error), got {m:g}")
    return {
        "rho_inf": _positive(rho_inf, "rho_inf"),
        "decay": decay,
        "margin": m,
        "k1": k1,
        "k2": k2,
        "kc": kc,
    }


def tune_mpc(
    J: object,
    spec: ClosedLoopSpec,
    limits: ActuatorLimits | None,
    horizon: int = 10,
) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.mpc.SO3MPC` by LQR matching on all three axes.

    With the acceleration ``a = J⁻¹u`` the rest model is three identical double integrators;
    the weight ``R = J⁻²`` (full 3×3, i.e. the cost ``‖J⁻¹u‖²``) makes the cost isotropic in
    ``a``, and ``Q = diag(q_ξ I, q_ω I)`` gives per axis the continuous LQR gains
    ``k₁ = √q_ξ``, ``k₂ = √(q_ω + 2√q_ξ)`` (the Riccati equation of ``ẍ = a``; e.g. Anderson &
    Moore, *Optimal Control: Linear Quadratic Methods*, 1990). Matching ``k₁ = ω_n²``,
    ``k₂ = 2ζω_n``: ``q_ξ = ω_n⁴``, ``q_ω = 2ω_n²(2ζ² − 1)`` — so **ζ ≥ 1/√2** (an LQR loop of a
    double integrator is never less damped; smaller ζ raises :class:`TuningInfeasible`). The
    MPC samples at ``T_s`` (its ``dt``) with the Riccati terminal cost, so without active
    constraints it is the sampled LQR, within ``O(ω_n T_s)`` of the continuous one. The whole
    cost is scaled by ``λ_max(J)²`` (numerics only). Torque box: ``limits.max_torque``
    (``None``/no limit: an inactive box of :data:`UNLIMITED_TORQUE`). The fallback used if a
    QP fails is the spec's geometric PD (log error).
    """
    from .geometric_pd import GeometricPD

    J = check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    if limits is not None and not isinstance(limits, ActuatorLimits):
        raise TypeError(f"limits: expected ActuatorLimits or None, got {type(limits).__name__}")
    # no torque limit: an inactive box (the QP needs finite bounds)
    u_max = (
        np.full(3, UNLIMITED_TORQUE)
        if limits is None or limits.max_torque is None
        else (np.array(limits.max_torque))
    )
    if isinstance(horizon, bool) or not isinstance(horizon, (int, np.integer)) or horizon < 1:
        raise ValueError(f"horizon: must be a positive integer, got {horizon!r}")
    w, z = spec.omega_n, spec.zeta
    if z < 1.0 / math.sqrt(2.0) - 1e-12:
        raise TuningInfeasible(
            f"zeta: {z:g} < 1/√2 cannot be matched by an LQR weight (MPC); use zeta ≥ 0.7072"
        )
    lam = float(np.linalg.eigvalsh(J)[-1])
    q_xi = w**4
    q_w = max(2.0 * w * w * (2.0 * z * z - 1.0), 1e-9 * w * w)
    Jn = np.linalg.inv(J / lam)  # λ J⁻¹: the cost scaled by λ² (numerics only)
    R = Jn @ Jn
    R = 0.5 * (R + R.T)
    with np.errstate(over="ignore"):
        Q = lam * lam * np.diag([q_xi] * 3 + [q_w] * 3)
    if not (np.all(np.isfinite(Q)) and np.all(np.isfinite(R))):
        raise ValueError("J: the LQR weights overflow (inertia or omega_n out of range)")
    fb = tune_geometric_pd(J, spec, error="log")
    return {
        "horizon": int(horizon),
        "dt": spec.sample_period,
        "Q": Q,
        "R": R,
        "u_max": u_max,
        "fallback": GeometricPD(J, fb["k_R"], fb["k_Omega"], error="log"),
    }


def tune_mrp_adrc(
    J: object,
    spec: ClosedLoopSpec,
    observer_ratio: float = ADRC_OBSERVER_RATIO,
    alpha: float = 1.0,
    beta: float = 0.5,
) -> dict[str, Any]:
    """Keywords (``params``) of :class:`~liecontrol.control.adrc.MrpADRC` by Gao's bandwidth
    parameterisation (Z. Gao, "Scaling and bandwidth-parameterization based controller
    tuning", American Control Conference, 2003).

    The law makes the MRP error ``p`` (``p ≈ δθ/4``) obey ``p̈ = τ₀ − z₃ + f ≈ τ₀`` once the ESO
    has estimated the total disturbance ``f``, and ``τ₀ = −k₁ p − k₂ ṗ``: the controller gains
    ``k₁ = ω_c²``, ``k₂ = 2ζω_c`` with the controller bandwidth ``ω_c = ω_n`` give the spec
    (Gao's ``k₂ = 2ω_c`` is the case ζ = 1). The observer bandwidth is
    ``ω_o = observer_ratio · ω_c`` and all three ESO poles sit at ``−ω_o``
    (:func:`~liecontrol.control.adrc.eso_gains_from_poles` with the composite weights α, β of
    Wu, Huang, Wei & Guo's ESO). With the ESO exact, the loop's poles are the controller's pair
    plus the observer's triple (separation). The tracking differentiator runs at ``r = ω_o`` so
    that it does not slow the response below the spec's.
    """
    from .adrc import ADRCParams, eso_gains_from_poles

    check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    k = _positive(observer_ratio, "observer_ratio")
    if not 1.0 < k <= 100.0:
        raise ValueError(
            f"observer_ratio: must be in (1, 100] (observer faster than the loop), got {k:g}"
        )
    w_o = k * spec.omega_n
    if w_o * spec.sample_period > 5.0 * MAX_OMEGA_T * (1.0 + 1e-12):
        raise TuningInfeasible(
            f"sample_period: {spec.sample_period:g} s is too long for the ADRC observer "
            f"bandwidth {w_o:g} rad/s (ω_o·T_s = {w_o * spec.sample_period:.3g} > "
            f"{5 * MAX_OMEGA_T:g})"
        )
    try:
        K1, K2, K3 = eso_gains_from_poles([-w_o] * 3, alpha, beta)
    except ValueError as exc:
        raise TuningInfeasible(f"observer_ratio: {exc}") from None
    params = ADRCParams(
        K1=K1,
        K2=K2,
        K3=K3,
        k1=spec.omega_n**2,
        k2=2.0 * spec.zeta * spec.omega_n,
        r=w_o,
        alpha=alpha,
        beta=beta,
    )
    return {"params": params}


def tune_euler_tsm(
    J: object, spec: ClosedLoopSpec, delta0: float = 0.03, settle_fraction: float = 0.02
) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.terminal_sliding_mode.TerminalSlidingModeSO3`
    (Liu, Tang & Yu, "Space RVD terminal approach to attitude tracking by terminal sliding mode
    control", J. National Univ. of Defense Technology 30(2), 2008).

    Small-angle loop: after the prescribed time (``p ≡ 0``) and inside the smoothing layer
    (``‖σ‖ ≪ δ₀``, ``δ₁ = 0``) the law gives ``ë = −λ ė − κ(λ e + ė)`` with ``C₁ = λI``,
    ``C₂ = I`` and ``κ = K/δ₀``: poles ``−λ`` and ``−κ``, real, so the damping is ≥ 1. For
    ``ζ ≥ 1`` they are placed exactly (``λ, κ = ω_n(ζ ∓ √(ζ² − 1))``); for ``ζ < 1`` the
    nearest achievable loop is the double pole ``−ω_n`` (damping 1; at the benchmark's ζ = 0.9
    that is 11 % more damped). The prescribed time ``T`` is the one at which the law's quintic
    shaping polynomial has fallen to ``settle_fraction`` (its ``τ`` solves
    ``1 − 10τ³ + 15τ⁴ − 6τ⁵ = settle_fraction``) equal to the spec's settling time to the same
    fraction (:func:`step_peaks`), so a slew settles when the spec's linear loop would.
    """
    check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    d0 = _positive(delta0, "delta0")
    frac = _positive(settle_fraction, "settle_fraction")
    if frac >= 1.0:
        raise ValueError(f"settle_fraction: must be in (0, 1), got {frac:g}")
    w, z = spec.omega_n, spec.zeta
    if z > 1.0:
        r = math.sqrt(z * z - 1.0)
        lam, kap = w * (z - r), w * (z + r)
    else:
        lam = kap = w
    # quintic 1 − 10τ³ + 15τ⁴ − 6τ⁵ is monotone on [0, 1]: bisection for its frac-crossing
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        val = 1.0 - 10.0 * mid**3 + 15.0 * mid**4 - 6.0 * mid**5
        lo, hi = (mid, hi) if val > frac else (lo, mid)
    tau = 0.5 * (lo + hi)
    t_s = step_peaks(w, z, frac)[2]
    return {
        "T": t_s / tau,
        "C1": lam,
        "C2": 1.0,
        "delta0": d0,
        "delta1": 0.0,
        "K": kap * d0,
    }


def tune_finite_time_so3(
    J: object,
    spec: ClosedLoopSpec,
    fixed_time: bool = False,
    terminal_share: float = 0.5,
    r: float = 0.5,
    rho: float = 0.5,
    eps: float = 0.05,
    layer_ratio: float = 0.05,
) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.finite_time.FiniteTimeSO3` (or, with
    ``fixed_time=True``, :class:`~liecontrol.control.finite_time.FixedTimeSO3`): the
    nonsingular fast terminal sliding mode on SO(3) (Guo & Song, Chinese J. Aeronautics 27(2),
    2014; Polyakov, IEEE TAC 57(8), 2012, for the fixed-time term).

    Small-angle loop: inside the surface layer ``‖e_R‖ < ε`` and the reaching layer
    ``‖s‖ < ε_s`` the law is linear, ``s ≈ δθ̇ + λδθ`` and ``ṡ = −κs`` with
    ``λ = ½(k₁ + k₂a_r)``, ``κ = c₁ + c₂a_s``, ``a_p = (2 − p)ε^(p−1)``: poles ``−λ, −κ``, real,
    so (as for :func:`tune_euler_tsm`) ``ζ ≥ 1`` is placed exactly
    (``λ, κ = ω_n(ζ ∓ √(ζ² − 1))``) and ``ζ < 1`` gets the double pole ``−ω_n``. The inertia
    cancels (the law commands ``J ė_Ω``). ``terminal_share`` of each pole comes from the
    fractional term (``k₂a_r = 2λ·share``, ``c₂a_s = κ·share``), the rest from the linear one.
    The reaching layer is ``ε_s = layer_ratio·h(π)`` with ``h(π) = k₁ + k₂`` the sliding
    variable of a rest start at 180°. Fixed time: ``c₃ = κ·share / h(π)^(μ−1)`` (μ = 1.5), so
    the ``‖s‖^μ`` term equals the fractional one's linear share at ``‖s‖ = h(π)`` and only
    dominates for tumbling starts.

    Beyond the layers the fractional gains are *smaller* than their small-angle values
    (``x^(p−1) ≤ a_p``): with the same small-angle poles the finite-time law is slower than a
    linear surface at large angles, and its advantage is the finite-time (not asymptotic)
    arrival at the layer and, with ``c₃``, a settling bound for any initial rate.
    """
    check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    share = _positive(terminal_share, "terminal_share")
    if share > 1.0:
        raise ValueError(f"terminal_share: must be in (0, 1], got {share:g}")
    for name, v in (("r", r), ("rho", rho), ("eps", eps), ("layer_ratio", layer_ratio)):
        x = _positive(v, name)
        if x >= 1.0:
            raise ValueError(f"{name}: must be in (0, 1), got {x:g}")
    if not isinstance(fixed_time, (bool, np.bool_)):
        raise TypeError(f"fixed_time: expected a bool, got {type(fixed_time).__name__}")
    w, z = spec.omega_n, spec.zeta
    if z > 1.0:
        q = math.sqrt(z * z - 1.0)
        lam, kap = w * (z - q), w * (z + q)
    else:
        lam = kap = w
    a_r = (2.0 - r) * eps ** (r - 1.0)
    k2 = 2.0 * lam * share / a_r
    k1 = 2.0 * lam * (1.0 - share)
    h_pi = k1 + k2
    eps_s = layer_ratio * h_pi
    a_s = (2.0 - rho) * eps_s ** (rho - 1.0)
    c2 = kap * share / a_s
    c1 = kap * (1.0 - share)
    out: dict[str, Any] = {
        "k1": k1,
        "k2": k2,
        "c2": c2,
        "r": r,
        "eps": eps,
        "c1": c1,
        "rho": rho,
        "eps_s": eps_s,
    }
    if fixed_time:
        mu = 1.5
        out["c3"] = kap * share / h_pi ** (mu - 1.0)
        out["mu"] = mu
    return out


def tune_quaternion_pd(J: object, spec: ClosedLoopSpec) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.chart_baselines.QuaternionPD` (Wie & Barba,
    "Quaternion feedback for spacecraft large angle maneuvers", JGCD 8(3), 1985): the vector
    part ``q_v ≈ δθ/2`` has slope ½, so ``k_p = 2ω_n² J``, ``k_d = 2ζω_n J``."""
    J = check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    return {"k_p": spec.omega_n**2 * J / 0.5, "k_d": 2.0 * spec.zeta * spec.omega_n * J}


def tune_mrp_pd(J: object, spec: ClosedLoopSpec) -> dict[str, Any]:
    """Keywords of :class:`~liecontrol.control.chart_baselines.MrpPD` (Schaub & Junkins,
    *Analytical Mechanics of Space Systems*): the MRP ``σ ≈ δθ/4`` has slope ¼, so
    ``K = 4ω_n² J``, ``P = 2ζω_n J``."""
    J = check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    return {"K": spec.omega_n**2 * J / 0.25, "P": 2.0 * spec.zeta * spec.omega_n * J}


#: Largest inertia coupling ``|J_ij|/√(J_ii J_jj)`` (i ≠ j) for which per-axis (diagonal) gains
#: are accepted (:func:`tune_small_angle_pid`).
MAX_AXIS_COUPLING = 0.05


def tune_small_angle_pid(
    J: object, spec: ClosedLoopSpec, integral_ratio: float = INTEGRAL_RATIO
) -> dict[str, Any]:
    """Keywords (``gains``) of the small-angle Euler PID
    :class:`~liecontrol.control.payload_compensation.SmallAnglePIDWithFeedforward`:
    :func:`~liecontrol.control.payload_compensation.pid_gains` places each body axis j at
    ``J_jj (s + rω_n)(s² + 2ζω_n s + ω_n²)``, ``r = integral_ratio`` (the spec's pair plus the
    integral pole, as for the geometric PID family).

    Those gains are per body axis, so they can only give every axis the spec when ``J`` is
    (nearly) diagonal: an inertia whose coupling ``max_{i≠j} |J_ij|/√(J_ii J_jj)`` exceeds
    :data:`MAX_AXIS_COUPLING` raises :class:`TuningInfeasible` (the coupled modes then move
    by far more than the discretisation error, e.g. 0.36 ω_n on one axis at coupling 0.30).
    """
    from .payload_compensation import pid_gains

    J = check_inertia_3x3(J, "J")
    spec = _check_spec(spec)
    d = np.sqrt(np.diag(J))
    C = np.abs(J) / np.outer(d, d)
    np.fill_diagonal(C, 0.0)
    if C.max() > MAX_AXIS_COUPLING:
        raise TuningInfeasible(
            f"J: per-axis PID gains cannot give every axis the spec for a non-diagonal inertia "
            f"(coupling |J_ij|/√(J_ii J_jj) = {C.max():.3g} > {MAX_AXIS_COUPLING})"
        )
    k_p, k_i, k_d = pid_gains(
        J, spec.omega_n / (2.0 * math.pi), spec.zeta, _positive(integral_ratio, "integral_ratio")
    )
    return {"gains": (k_p, k_i, k_d)}


# ----------------------------------------------------------------------------- measurement


@dataclass(frozen=True)
class SmallAngleResponse:
    """Measured dominant small-angle closed loop, one entry per principal axis of J.

    Attributes:
        omega_n: ``(3,)`` natural frequency of the dominant pole pair [rad/s].
        zeta: ``(3,)`` its damping ratio.
        axes: ``(3, 3)`` the principal axes (columns) along which the loop was kicked.
        poles: per axis, every identified continuous-time pole ``ln(z)/T_s`` [1/s].
    """

    omega_n: np.ndarray
    zeta: np.ndarray
    axes: np.ndarray
    poles: tuple[np.ndarray, ...]


def _modes(y: np.ndarray, T: float, max_order: int, rtol: float) -> tuple[np.ndarray, np.ndarray]:
    """Poles ``s`` and amplitudes ``c`` of ``y_j ≈ Σ c_i e^{s_i jT}`` by the matrix-pencil
    method (Hua & Sarkar, IEEE TASSP 38(5), 1990): an SVD-truncated Hankel pencil."""
    n = y.size
    L = max(2, min(n // 3, 40))
    H = np.lib.stride_tricks.sliding_window_view(y, L + 1)
    U, S, Vh = np.linalg.svd(H, full_matrices=False)
    order = int(np.sum(S > rtol * S[0])) if S[0] > 0 else 0
    order = max(1, min(order, max_order, L))
    V = Vh[:order].T  # (L+1, order)
    V1, V2 = V[:-1], V[1:]
    z = np.linalg.eigvals(np.linalg.pinv(V1) @ V2)
    z = z[np.abs(z) > 1e-12]
    # amplitudes by least squares on the Vandermonde basis
    j = np.arange(n)
    Z = z[None, :] ** j[:, None]
    c = np.linalg.lstsq(Z, y.astype(complex), rcond=None)[0]
    s = np.log(z.astype(complex)) / T
    return s, c


def _dominant_pair(
    s: np.ndarray, c: np.ndarray, n: int, T: float, record_energy: float
) -> tuple[float, float]:
    """``(ω_n, ζ)`` of the most energetic pole pair (a conjugate pair, or two real poles)."""
    z = np.exp(s * T)
    r2 = np.abs(z) ** 2
    energy = np.abs(c) ** 2 * np.where(
        np.abs(1.0 - r2) > 1e-12, (1.0 - r2**n) / np.where(r2 == 1.0, 1.0, 1.0 - r2), n
    )
    is_complex = np.abs(s.imag) > 1e-9 * np.maximum(np.abs(s), 1e-300)
    # candidate pairs: each complex pole with positive imaginary part (its conjugate is listed
    # too) carries the pair's energy; real poles pair with the next most energetic real pole
    pairs = []  # (energy, ω_n, ζ)
    for i in np.nonzero(is_complex & (s.imag > 0))[0]:
        pairs.append((2.0 * energy[i], abs(s[i]), -s[i].real / abs(s[i])))
    ridx = np.nonzero(~is_complex & (s.real < 0))[0]
    ridx = ridx[np.argsort(-energy[ridx])]
    for a_i, b_i in zip(ridx[0::2], ridx[1::2], strict=False):
        a, b = s[a_i].real, s[b_i].real
        w = math.sqrt(a * b)
        pairs.append((energy[a_i] + energy[b_i], w, -(a + b) / (2.0 * w)))
    best = None
    if pairs:
        # dominant = the slowest-decaying pair among those carrying ≥ 1 % of the record's
        # energy (fast observer or filter modes decay first; near-multiple fast poles get large
        # cancelling amplitudes in the fit, so they are not compared with each other)
        sig = [p for p in pairs if p[0] >= 1e-2 * record_energy] or pairs
        best = min(sig, key=lambda p: p[1] * p[2])
    if best is None:  # a single real mode: first-order dominant behaviour
        i = int(np.argmax(energy))
        return abs(s[i]), 1.0 if s[i].real < 0 else -1.0
    return float(best[1]), float(best[2])


def measure_small_angle_response(
    controller: AttitudeController,
    J: object,
    sample_period: float,
    *,
    duration: float,
    warmup: float = 0.0,
    amplitude: float = 1e-3,
    max_order: int = 8,
    rtol: float = 1e-7,
) -> SmallAngleResponse:
    """Measure the dominant natural frequency and damping of ``controller``'s small-angle loop.

    For each principal axis ``v_k`` of ``J``: a deep copy of ``controller`` is ``reset(0, 1)``
    and flown on the ideal-torque rigid body linearised about ``R = R_d = I`` (``J δθ̈ = u``,
    propagated exactly over each sample period with the zero-order-held command; the controller
    sees ``R = exp(δθ^)`` and ``ω = δθ̇`` and is called every ``sample_period`` through
    :meth:`AttitudeController.command`); after ``warmup`` seconds at rest (time for funnels or
    observers to settle) the attitude is kicked by ``amplitude`` [rad] about ``v_k`` and the
    response ``v_k·δθ`` recorded for ``duration`` seconds. The poles of the sampled record are
    identified by the matrix-pencil method; ``(ω_n, ζ)`` are those of the slowest-decaying pole
    pair that carries ≥ 1 % of the record's energy — a complex-conjugate pair, or two real poles
    taken in order of energy (so for an over-damped loop with a further slow real pole, e.g. an
    integral, the pair reported is the two most energetic real poles; a lone slow real pole of
    an under-damped loop is listed in ``poles`` but not paired). ``amplitude`` must be small
    enough for the law to be linear (e.g. inside a
    prescribed-performance funnel) and large against solver tolerances.

    Args:
        controller: any :class:`~liecontrol.control.base.AttitudeController` (not modified).
        J: ``(3, 3)`` inertia of the plant [kg·m²].
        sample_period: controller sample period [s].
        duration: record length after the kick [s] (a few periods of the slowest mode).
        warmup: time at rest before the kick [s].
        amplitude: attitude kick [rad].
        max_order: largest model order of the identification.
        rtol: relative singular-value threshold of the identification's order selection.
    """
    if not callable(getattr(controller, "command", None)) or not callable(
        getattr(controller, "reset", None)
    ):
        raise TypeError(
            f"controller: expected an AttitudeController (reset, command), got "
            f"{type(controller).__name__}"
        )
    J = check_inertia_3x3(J, "J")
    T = _positive(sample_period, "sample_period")
    dur = _positive(duration, "duration")
    warm = _scalar(warmup, "warmup")
    if warm < 0.0:
        raise ValueError(f"warmup: must be ≥ 0, got {warm:g}")
    amp = _positive(amplitude, "amplitude")
    if isinstance(max_order, bool) or not isinstance(max_order, (int, np.integer)) or max_order < 2:
        raise ValueError(f"max_order: must be an integer ≥ 2, got {max_order!r}")
    rtol = _positive(rtol, "rtol")
    # at least one sample at rest: the kick perturbs a running loop (a law that plans from its
    # first sample, like the prescribed-time sliding mode, would otherwise plan for the kick)
    if T > 1e4:
        raise ValueError(f"sample_period: {T:g} s is out of range (≤ 1e4 s)")
    for name, v in (("duration", dur), ("warmup", warm)):
        if v / T > 1e6:  # each sample is one controller call
            raise ValueError(f"{name}: {v:g} s is more than 1e6 sample periods of {T:g} s")
    n_w = max(1, int(math.ceil(warm / T - 1e-9)))
    n = int(math.ceil(dur / T - 1e-9))
    if n < 12:
        raise ValueError(f"duration: {dur:g} s gives {n} samples; need ≥ 12 sample periods")
    _, V = np.linalg.eigh(J)
    Jinv = np.linalg.inv(J)
    # one batch of three spacecraft, spacecraft k kicked about principal axis k (a controller
    # that steps one spacecraft at a time, ``batched = False``, gets three runs instead)
    runs = [(0, 1, 2)] if getattr(controller, "batched", True) else [(0,), (1,), (2,)]
    y = np.empty((3, n + 1))
    for ks in runs:
        B = len(ks)
        ctrl = copy.deepcopy(controller)
        ctrl.reset(0.0, B)
        ref = AttitudeReference.regulation(np.broadcast_to(np.eye(3), (B, 3, 3)).copy())
        th, om = np.zeros((B, 3)), np.zeros((B, 3))
        kick = amp * V[:, list(ks)].T
        for j in range(n_w + n + 1):
            if j == n_w:
                th = th + kick
            if j >= n_w:
                for b, k in enumerate(ks):
                    y[k, j - n_w] = V[:, k] @ th[b] / amp
            state = AttitudeState(R=so3.exp(th), omega=om.copy())
            u = np.asarray(ctrl.command(j * T, state, ref), dtype=np.float64).reshape(B, 3)
            if not np.all(np.isfinite(u)):
                raise ValueError(f"controller: returned a non-finite torque at t = {j * T:g} s")
            a = u @ Jinv.T
            th = th + T * om + 0.5 * T * T * a
            om = om + T * a
    w_out, z_out, poles = np.empty(3), np.empty(3), []
    # identify on at most ~400 samples: decimating by d keeps every decay rate (|z|^d) and the
    # slow modes' frequencies (fast modes may alias in frequency, never in decay)
    d = max(1, int(math.ceil((n + 1) / 400)))
    for k in range(3):
        yk = y[k, ::d]
        s, c = _modes(yk, T * d, int(max_order), rtol)
        w_out[k], z_out[k] = _dominant_pair(s, c, yk.size, T * d, float(yk @ yk))
        poles.append(s)
    return SmallAngleResponse(omega_n=w_out, zeta=z_out, axes=V, poles=tuple(poles))
