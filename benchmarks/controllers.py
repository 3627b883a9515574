"""Registry of benchmark controllers with their metadata and their tuning.

Adding a controller is one :func:`register` call::

    register("my-pd", lambda ctx: MyPD(ctx.J, ...), description="...", batched=True)

The factory receives a :class:`ControllerContext` — the controller's model inertia ``J`` (the
nominal one: with :class:`~benchmarks.scenarios.UncertaintySpec` the plant's true inertia
differs), the control period, the batch size it will be stepped with, the initial error
quaternion with the scenario's sign (``q_hint``, for the q/−q unwinding cases), the reference
trajectory, the closed-loop spec to tune to (``rule``) and, for SE(3) scenarios, the
:class:`~benchmarks.scenarios.ProximitySpec` and the plant's gravity wrench — and returns a fresh
controller (:class:`liecontrol.control.AttitudeController` or, with ``plants={"se3"}``,
:class:`liecontrol.control.PoseController`). The metadata (:class:`ControllerInfo`) say whether
``command`` is vectorized over the batch (``batched``), which plants it applies to (``plants``:
``"sgcmg"``, ``"wheels"``, ``"ideal"`` attitude plants or ``"se3"``), scenario tags it must not
run on, its own sampling period if its design needs one and whether it is in the quick suite.

Tuning (one protocol for every controller, so the comparison is at equal aggressiveness): every
built-in attitude factory calls :mod:`liecontrol.control.tuning` — the public layer users call on
their own spacecraft — with the scenario's spacecraft (:func:`actuator_limits`) and the spec
:func:`spec_for` = (:class:`GainRule` ω_n, ζ; the scenario's control period). Each family's
small-angle closed loop then has natural frequency ω_n and damping ζ on all three principal axes
of the full inertia (checked by ``tests/test_tuning.py`` with
:func:`liecontrol.control.tuning.measure_small_angle_response`). Nothing is carried over from a
paper's tuning: the ADRC gets Gao's bandwidth parameterisation, the terminal sliding mode a
prescribed time from the spec's settling time, the MPC LQR-matched weights and the actuator's
torque box. A spec a controller cannot meet — the sample period too long for ω_n, an actuator
that cannot deliver the step's torque or momentum, a family limitation — raises
:class:`~liecontrol.control.tuning.TuningInfeasible`, and :meth:`ControllerInfo.applies` then
reports the pair as not applicable with that reason.

The defaults ω_n = 0.03 rad/s, ζ = 0.9 keep the 179° slew's peak body momentum (linear estimate
≈ 0.39 ω_n θ₀ ‖Jâ‖ ≈ 570 N·m·s about the slew axis) inside the 4 × 300 N·m·s pyramid's momentum
envelope (≥ 850 N·m·s in every direction), and settle a small error to 2 % in ≈ 157 s. Integral
actions place their extra pole at −ω_n/5 with a 0.3 N·m anti-windup clamp
(:data:`INTEGRAL_LIMIT`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._validation import as_array, as_int, check_positive, check_positive_scalar
from liecontrol.control.constrained import KeepInCone, KeepOutCone
from liecontrol.control.tuning import (
    ActuatorLimits,
    ClosedLoopSpec,
    TuningInfeasible,
    check_actuator,
)

from .scenarios import (
    MODE_PLANTS,
    DetumbleSpec,
    OrbitSpec,
    ProximitySpec,
    Scenario,
    SpacecraftSpec,
    SunAcquisitionSpec,
)

__all__ = [
    "ATTITUDE_PLANTS",
    "GainRule",
    "DEFAULT_GAIN_RULE",
    "ControllerContext",
    "ControllerFactory",
    "ControllerInfo",
    "CONTROLLERS",
    "register",
    "unregister",
    "get_controller",
    "make_controller",
    "available_controllers",
    "quick_controllers",
    "applicable",
    "geometric_pd_factory",
    "actuator_limits",
    "spec_for",
    "tuned_spec",
    "INTEGRAL_LIMIT",
    "mean_field_squared",
]

#: Plant tags of attitude scenarios (the actuator kinds of :class:`SpacecraftSpec`).
ATTITUDE_PLANTS: frozenset[str] = frozenset({"sgcmg", "wheels", "ideal"})


@dataclass(frozen=True)
class GainRule:
    """Linearised closed-loop natural frequency ``omega_n`` [rad/s] and damping ratio ``zeta``."""

    omega_n: float = 0.03
    zeta: float = 0.9

    def __post_init__(self) -> None:
        object.__setattr__(self, "omega_n", check_positive_scalar(self.omega_n, "omega_n"))
        object.__setattr__(self, "zeta", check_positive_scalar(self.zeta, "zeta"))


DEFAULT_GAIN_RULE = GainRule()
#: Anti-windup clamp of the integral torque of the PID variants [N·m]: ≈ 3× the constant part
#: of the ADRC paper's disturbance (|(0.02, 0.08, 0.02)| ≈ 0.085 N·m), which the integral must
#: cancel.
INTEGRAL_LIMIT = 0.3


@dataclass(frozen=True)
class ControllerContext:
    """What a controller factory is told about the run.

    Attributes:
        spacecraft: the nominal spacecraft (attitude scenarios).
        control_period: the period at which ``command`` will be called [s].
        batch_size: number of spacecraft the controller instance is stepped with.
        q_hint: ``(B, 4)`` initial error quaternion (scalar-first) with the scenario's sign
            (``−q`` for the unwinding case), or ``None``.
        reference: the reference trajectory ``t -> AttitudeReference`` (or ``PoseReference``).
        proximity: the SE(3) scenario data, or ``None``.
        gravity: the SE(3) plant's gravity wrench ``g -> (B, 6)`` (feed-forward), or ``None``.
        rule: the closed-loop spec every factory tunes to (:class:`GainRule`; the runner's
            ``gain_rule``, e.g. a bandwidth sweep).
        keep_out: the scenario's keep-out pointing cones (constraint-aware controllers use
            them; the others ignore them and are judged by the same margins).
        keep_in: the scenario's keep-in pointing cones.
        detumble: the detumble scenario's rods and sensors (:class:`DetumbleSpec`), or ``None``.
        orbit: the scenario's orbit (:class:`OrbitSpec`), or ``None``.
        sun_acquisition: the Sun-acquisition scenario's sensors and law settings
            (:class:`SunAcquisitionSpec`), or ``None``.
    """

    spacecraft: SpacecraftSpec
    control_period: float
    batch_size: int = 1
    q_hint: np.ndarray | None = None
    reference: Callable[[float], Any] | None = None
    proximity: ProximitySpec | None = None
    gravity: Callable[[np.ndarray], np.ndarray] | None = None
    rule: GainRule = DEFAULT_GAIN_RULE
    keep_out: tuple[KeepOutCone, ...] = ()
    keep_in: tuple[KeepInCone, ...] = ()
    detumble: DetumbleSpec | None = None
    orbit: OrbitSpec | None = None
    sun_acquisition: SunAcquisitionSpec | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.spacecraft, SpacecraftSpec):
            raise ValueError(
                f"spacecraft: expected a SpacecraftSpec, got {type(self.spacecraft).__name__}"
            )
        object.__setattr__(
            self, "control_period", check_positive_scalar(self.control_period, "control_period")
        )
        object.__setattr__(self, "batch_size", as_int(self.batch_size, "batch_size", 1))
        if self.q_hint is not None:
            q = as_array(self.q_hint, "q_hint")
            if q.shape != (self.batch_size, 4):
                raise ValueError(f"q_hint: expected shape ({self.batch_size}, 4), got {q.shape}")
            object.__setattr__(self, "q_hint", q)
        for name in ("reference", "gravity"):
            if getattr(self, name) is not None and not callable(getattr(self, name)):
                raise ValueError(f"{name}: must be callable or None")
        if self.proximity is not None and not isinstance(self.proximity, ProximitySpec):
            raise ValueError(
                f"proximity: expected a ProximitySpec or None, got {type(self.proximity).__name__}"
            )
        if not isinstance(self.rule, GainRule):
            raise ValueError(f"rule: expected a GainRule, got {type(self.rule).__name__}")
        for name, cls in (("keep_out", KeepOutCone), ("keep_in", KeepInCone)):
            v = getattr(self, name)
            if isinstance(v, str) or not isinstance(v, (tuple, list)):
                raise ValueError(f"{name}: expected a sequence of {cls.__name__}, got {v!r}")
            if not all(isinstance(c, cls) for c in v):
                raise ValueError(f"{name}: every item must be a {cls.__name__}, got {v!r}")
            object.__setattr__(self, name, tuple(v))
        for name, cls in (
            ("detumble", DetumbleSpec),
            ("orbit", OrbitSpec),
            ("sun_acquisition", SunAcquisitionSpec),
        ):
            v = getattr(self, name)
            if v is not None and not isinstance(v, cls):
                raise ValueError(f"{name}: expected a {cls.__name__} or None, got {v!r}")

    @property
    def J(self) -> np.ndarray:
        """The controller's model inertia ``(3, 3)`` [kg·m²] (nominal; SE(3): the chaser's)."""
        return self.proximity.J if self.proximity is not None else self.spacecraft.J

    @classmethod
    def for_scenario(cls, scenario: Scenario, batch_size: int = 1, **kw: Any) -> ControllerContext:
        """Context of ``scenario`` with ``batch_size`` copies of its initial quaternion."""
        q = np.broadcast_to(scenario.initial_quaternion, (batch_size, 4)).copy()
        return cls(
            spacecraft=scenario.spacecraft,
            control_period=scenario.control_period or scenario.dt,
            batch_size=batch_size,
            q_hint=q,
            proximity=scenario.proximity,
            keep_out=scenario.keep_out,
            keep_in=scenario.keep_in,
            detumble=scenario.detumble,
            orbit=scenario.orbit,
            sun_acquisition=scenario.sun_acquisition,
            **kw,
        )


ControllerFactory = Callable[[ControllerContext], Any]


@dataclass(frozen=True)
class ControllerInfo:
    """A registered controller: factory plus metadata.

    Attributes:
        name: registry key.
        factory: ``factory(ctx: ControllerContext) -> controller``.
        description: one line for the report.
        batched: ``command`` is vectorized over the batch (one instance steps ``B`` spacecraft);
            ``False``: the runner makes one instance per spacecraft.
        plants: plant tags it applies to (:data:`ATTITUDE_PLANTS`, ``{"se3"}`` or a mode plant
            of :data:`benchmarks.scenarios.MODE_PLANTS`, e.g. ``{"magnetorquer"}``).
        exclude_tags: scenario tags it does not apply to (with the reason in ``notes``).
        control_period: own sampling period [s], or ``None`` (the scenario's). Longer than the
            scenario's: sampled at its own period and held in between; shorter: the pair is
            simulated with this period (a multiple of the scenario's ``dt``).
        quick: part of the quick suite.
        family: grouping label for reports (``"geometric"``, ``"chart"``, ``"mpc"``, ``"se3"``).
        notes: why it does not apply where it does not (shown in the report).
    """

    name: str
    factory: ControllerFactory
    description: str = ""
    batched: bool = True
    plants: frozenset[str] = ATTITUDE_PLANTS
    exclude_tags: frozenset[str] = frozenset()
    control_period: float | None = None
    quick: bool = True
    family: str = "geometric"
    notes: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"name: expected a non-empty str, got {self.name!r}")
        if not callable(self.factory):
            raise ValueError(f"factory: must be callable as factory(ctx), got {self.factory!r}")
        for name in ("description", "family", "notes"):
            if not isinstance(getattr(self, name), str):
                raise ValueError(f"{name}: expected a str, got {getattr(self, name)!r}")
        for name in ("plants", "exclude_tags"):
            v = getattr(self, name)
            if isinstance(v, str) or not isinstance(v, (set, frozenset, tuple, list)):
                raise ValueError(f"{name}: expected a set of tags, got {v!r}")
            if not all(isinstance(x, str) for x in v):
                raise ValueError(f"{name}: every tag must be a str, got {sorted(map(repr, v))}")
            object.__setattr__(self, name, frozenset(v))
        if self.control_period is not None:
            object.__setattr__(
                self,
                "control_period",
                check_positive_scalar(self.control_period, "control_period"),
            )

    def applies(self, scenario: Scenario, rule: GainRule | None = None) -> tuple[bool, str]:
        """``(True, "")`` or ``(False, reason)`` for ``scenario`` tuned to ``rule`` (default
        :data:`DEFAULT_GAIN_RULE`): wrong plant, an excluded tag, or a factory that raises
        :class:`~liecontrol.control.tuning.TuningInfeasible` for this scenario (the reason is
        its message). Other factory errors are left for the run to record."""
        if scenario.plant not in self.plants:
            if "se3" in self.plants:
                return False, "SE(3) controller"
            if self.plants & set(MODE_PLANTS):
                return False, f"{'/'.join(sorted(self.plants))} law (mode scenarios only)"
            return False, "attitude controller"
        hit = sorted(self.exclude_tags.intersection(scenario.tags))
        if hit:
            return False, self.notes or f"excluded for tag {hit[0]!r}"
        q = np.asarray(scenario.initial_quaternion, dtype=np.float64).reshape(1, 4)
        ctx = ControllerContext(
            spacecraft=scenario.spacecraft,
            control_period=self.control_period or scenario.control_period or scenario.dt,
            q_hint=q,
            proximity=scenario.proximity,
            rule=rule or DEFAULT_GAIN_RULE,
            keep_out=scenario.keep_out,
            keep_in=scenario.keep_in,
            detumble=scenario.detumble,
            orbit=scenario.orbit,
            sun_acquisition=scenario.sun_acquisition,
        )
        try:
            self.factory(ctx)
        except TuningInfeasible as exc:
            return False, f"cannot be tuned: {exc}"
        except Exception:  # noqa: BLE001 - not a tuning verdict: the run records the error
            return True, ""
        return True, ""


#: All registered controllers, by name (insertion order = report order).
CONTROLLERS: dict[str, ControllerInfo] = {}


def register(
    name: str,
    factory: ControllerFactory,
    *,
    description: str | None = None,
    batched: bool = True,
    plants: frozenset[str] | set[str] | tuple[str, ...] = ATTITUDE_PLANTS,
    exclude_tags: tuple[str, ...] | frozenset[str] = (),
    control_period: float | None = None,
    quick: bool = True,
    family: str = "geometric",
    notes: str = "",
    replace: bool = False,
) -> ControllerInfo:
    """Register ``factory`` under ``name`` with its metadata (see :class:`ControllerInfo`)."""
    if not isinstance(name, str) or not name or any(c in name for c in " ,/\\|"):
        raise ValueError(f"name: must be non-empty without spaces, commas or slashes: {name!r}")
    if not callable(factory):
        raise ValueError("factory: must be callable as factory(ctx: ControllerContext)")
    if name in CONTROLLERS and not replace:
        raise ValueError(f"name: controller {name!r} is already registered (replace=True)")
    plants = frozenset(plants)
    known = ATTITUDE_PLANTS | {"se3"} | set(MODE_PLANTS)
    if not plants or not plants <= known:
        raise ValueError(f"plants: expected a non-empty subset of {sorted(known)}, got {plants}")
    if control_period is not None:
        control_period = float(check_positive(control_period, "control_period"))
    if description is None:
        doc = (getattr(factory, "__doc__", None) or "").strip().splitlines()
        description = doc[0] if doc else name
    info = ControllerInfo(
        name=name,
        factory=factory,
        description=description,
        batched=bool(batched),
        plants=plants,
        exclude_tags=frozenset(exclude_tags),
        control_period=control_period,
        quick=bool(quick),
        family=family,
        notes=notes,
    )
    CONTROLLERS[name] = info
    return info


def unregister(name: str) -> None:
    """Remove ``name`` from the registry (tests, replacing a built-in)."""
    get_controller(name)
    del CONTROLLERS[name]


def available_controllers() -> list[str]:
    """Registered names, in registration order."""
    return list(CONTROLLERS)


def quick_controllers() -> tuple[str, ...]:
    """The controllers of the quick suite."""
    return tuple(n for n, i in CONTROLLERS.items() if i.quick)


def get_controller(name: str) -> ControllerInfo:
    """Metadata of ``name``; unknown names raise a ``ValueError`` listing the valid ones."""
    try:
        return CONTROLLERS[name]
    except KeyError:
        raise ValueError(
            f"name: unknown controller {name!r}; valid controllers: "
            f"{', '.join(available_controllers())}"
        ) from None


def make_controller(name: str, ctx: ControllerContext | SpacecraftSpec) -> Any:
    """A fresh controller ``name`` for ``ctx`` (a bare :class:`SpacecraftSpec` means a single
    spacecraft at a 0.1 s control period)."""
    info = get_controller(name)
    if isinstance(ctx, SpacecraftSpec):
        ctx = ControllerContext(spacecraft=ctx, control_period=0.1)
    if not isinstance(ctx, ControllerContext):
        raise ValueError(f"ctx: expected ControllerContext, got {type(ctx).__name__}")
    return info.factory(ctx)


def applicable(
    scenario: Scenario, names: tuple[str, ...] | None = None, rule: GainRule | None = None
) -> tuple[str, ...]:
    """Names (default: all registered) that apply to ``scenario`` (tuned to ``rule``)."""
    if not isinstance(scenario, Scenario):
        raise ValueError(f"scenario: expected a Scenario, got {type(scenario).__name__}")
    if rule is not None and not isinstance(rule, GainRule):
        raise ValueError(f"rule: expected a GainRule or None, got {type(rule).__name__}")
    if isinstance(names, str):
        raise ValueError(f"names: expected a sequence of controller names, got {names!r}")
    names = available_controllers() if names is None else names
    if isinstance(names, str) or not isinstance(names, (tuple, list)):
        raise TypeError(f"names: expected a tuple of controller names, got {type(names).__name__}")
    return tuple(n for n in names if get_controller(n).applies(scenario, rule)[0])


# --------------------------------------------------------------------------- tuning inputs


def actuator_limits(spacecraft: SpacecraftSpec) -> ActuatorLimits:
    """What ``spacecraft``'s actuator can deliver, for the tuning protocol.

    - ``"sgcmg"``: torque box ``δ̇_max / max_i Σ_j |A⁺_ij|`` — the largest per-axis torque that
      the pseudo-inverse steering delivers from the initial gimbal angles without exceeding the
      gimbal-rate limit (``A`` the cluster Jacobian); momentum: the smallest radius of the
      saturation envelope, ``min_â h₀ Σ_i √(1 − (â·g_i)²)`` over 4003 directions
      (``g_i`` the gimbal axes); the gimbal-rate limit.
    - ``"wheels"`` (wheel spin axes ``W``, orthogonal or pyramid): torque box
      ``τ_w / max_i Σ_j |W⁺_ij|`` (the pseudo-inverse distribution within each wheel's torque
      limit), momentum ``min_â h_w Σ_i |â·w_i|`` with ``h_w = I_w Ω_max`` (the smallest radius of
      the wheels' momentum envelope).
    - ``"ideal"``: its ``max_torque`` (``None``: unlimited), no momentum limit.
    """
    if not isinstance(spacecraft, SpacecraftSpec):
        raise TypeError(f"spacecraft: expected SpacecraftSpec, got {type(spacecraft).__name__}")
    return _actuator_limits(spacecraft)


_LIMITS_CACHE: dict[SpacecraftSpec, ActuatorLimits] = {}


def _fibonacci_sphere(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors (Fibonacci lattice), ``(n, 3)``."""
    i = np.arange(n) + 0.5
    phi, th = np.arccos(1.0 - 2.0 * i / n), np.pi * (1.0 + 5.0**0.5) * i
    return np.stack((np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)), 1)


#: Directions over which momentum envelopes are minimised (plus the body axes, where the
#: orthogonal wheels' envelope has its minimum).
_DIRECTIONS = np.concatenate((np.eye(3), _fibonacci_sphere(4000)))


def _actuator_limits(sc: SpacecraftSpec) -> ActuatorLimits:
    if sc in _LIMITS_CACHE:
        return _LIMITS_CACHE[sc]
    if sc.actuator == "sgcmg":
        from spacecraft.sgcmg import SgcmgPyramid

        cl = SgcmgPyramid(
            h0=sc.h0, beta=float(np.deg2rad(sc.beta_deg)), gimbal_rate_limit=sc.gimbal_rate_limit
        )
        A = cl.jacobian(np.deg2rad(np.array(sc.delta0_deg)))
        u_max = sc.gimbal_rate_limit / float(np.abs(np.linalg.pinv(A)).sum(axis=1).max())
        g = _DIRECTIONS @ cl.gimbal_axes()
        env = sc.h0 * np.sqrt(np.clip(1.0 - g**2, 0.0, None)).sum(1)
        out = ActuatorLimits(u_max, float(env.min()), sc.gimbal_rate_limit)
    elif sc.actuator == "wheels":
        from spacecraft.actuators import orthogonal_wheel_axes, pyramid_wheel_axes

        layout = getattr(sc, "wheel_layout", "orthogonal")
        W = pyramid_wheel_axes() if layout == "pyramid" else orthogonal_wheel_axes()
        u_max = sc.wheel_max_torque / float(np.abs(np.linalg.pinv(W)).sum(axis=1).max())
        h_w = sc.wheel_inertia * sc.wheel_max_speed
        out = ActuatorLimits(u_max, float((h_w * np.abs(_DIRECTIONS @ W).sum(1)).min()))
    else:
        out = ActuatorLimits(sc.max_torque)
    _LIMITS_CACHE[sc] = out
    return out


def spec_for(ctx: ControllerContext) -> ClosedLoopSpec:
    """The closed-loop spec of ``ctx``: its rule's (ω_n, ζ) at its control period (raises
    :class:`~liecontrol.control.tuning.TuningInfeasible` if the period is too long for ω_n)."""
    if not isinstance(ctx, ControllerContext):
        raise ValueError(f"ctx: expected a ControllerContext, got {type(ctx).__name__}")
    return ClosedLoopSpec(ctx.rule.omega_n, ctx.rule.zeta, ctx.control_period)


def _step_rotvec(ctx: ControllerContext) -> np.ndarray:
    """Rotation vector of the largest initial error in the batch (from ``q_hint``)."""
    if ctx.q_hint is None:
        return np.zeros(3)
    q = np.asarray(ctx.q_hint, dtype=np.float64).reshape(-1, 4)
    q = q * np.where(q[:, :1] < 0.0, -1.0, 1.0)  # the physical rotation: w ≥ 0
    v = np.linalg.norm(q[:, 1:], axis=1)
    ang = 2.0 * np.arctan2(v, q[:, 0])
    k = int(np.argmax(ang))
    return q[k, 1:] * (ang[k] / v[k]) if v[k] > 0 else np.zeros(3)


def tuned_spec(ctx: ControllerContext) -> tuple[ClosedLoopSpec, ActuatorLimits]:
    """``(spec, limits)`` for an attitude factory: :func:`spec_for` checked against the
    spacecraft's :func:`actuator_limits` for the scenario's initial error (a rest-to-rest step of
    that size; :func:`liecontrol.control.tuning.check_actuator`)."""
    if not isinstance(ctx, ControllerContext):
        raise ValueError(f"ctx: expected a ControllerContext, got {type(ctx).__name__}")
    spec = spec_for(ctx)
    limits = actuator_limits(ctx.spacecraft)
    check_actuator(ctx.J, spec, limits, _step_rotvec(ctx))
    return spec, limits


# --------------------------------------------------------------------------- built-in factories


def geometric_pd_factory(error: str) -> ControllerFactory:
    """Factory of a :class:`~liecontrol.control.geometric_pd.GeometricPD` with error function
    ``error``, tuned by :func:`liecontrol.control.tuning.tune_geometric_pd`."""
    from liecontrol.errors import ATTITUDE_ERRORS as _errors

    if not isinstance(error, str) or error not in _errors:
        # checked now, not when the factory is first called inside a benchmark run
        raise ValueError(f"error: expected one of {tuple(_errors)}, got {error!r}")

    def make(ctx: ControllerContext) -> Any:
        from liecontrol.control.geometric_pd import GeometricPD
        from liecontrol.control.tuning import tune_geometric_pd

        spec, _ = tuned_spec(ctx)
        return GeometricPD(ctx.J, **tune_geometric_pd(ctx.J, spec, error=error))

    slope = {
        "log": "s = 1 (e_R ≈ δθ)",
        "large_angle": "s = ½ (e_R = sin(θ/2)·axis ≈ ½δθ)",
        "trace": "s = 0.95, the smallest slope of e_R ≈ ½(tr G·I − G)δθ, G = diag(0.9, 1, 1.1)",
    }.get(error, "s = the error function's small-angle slope")
    extra = " · √(s_max/s_min)" if error == "trace" else ""
    make.__doc__ = (
        f"GeometricPD(error={error!r}): K_R = ω_n²J/s, K_Ω = 2ζω_nJ{extra}, where {slope}"
    )
    return make


def _geometric_keep_out(ctx: ControllerContext) -> Any:
    """Barrier-shaped large-angle geometric PD on the scenario's pointing cones (plain PD
    without cones)"""
    from liecontrol.control.constrained import ConstrainedGeometricPD
    from liecontrol.control.tuning import tune_geometric_pd

    spec, _ = tuned_spec(ctx)
    gains = tune_geometric_pd(ctx.J, spec, error="large_angle")
    del gains["error"]  # the attractive part is always the large-angle potential
    return ConstrainedGeometricPD(ctx.J, keep_out=ctx.keep_out, keep_in=ctx.keep_in, **gains)


def _geometric_keep_out_sampled(ctx: ControllerContext) -> Any:
    """SampledSafeConstrainedPD: ``geometric-keep-out``'s barrier PD (same tuned gains) with the
    sampled-data safety filter at the control period and the actuator's torque box (unlimited
    ideal torque: the PD's own torque at a π error, ω_n²·λ_max(J)·π, as the bound)"""
    from liecontrol.control.constrained import SampledSafeConstrainedPD
    from liecontrol.control.tuning import tune_geometric_pd

    spec, limits = tuned_spec(ctx)
    gains = tune_geometric_pd(ctx.J, spec, error="large_angle")
    del gains["error"]
    u_max = limits.max_torque
    if u_max is None:
        u_max = spec.omega_n**2 * float(np.linalg.eigvalsh(ctx.J)[-1]) * math.pi
    return SampledSafeConstrainedPD(
        ctx.J,
        keep_out=ctx.keep_out,
        keep_in=ctx.keep_in,
        max_torque=u_max,
        sample_period=ctx.control_period,
        **gains,
    )


def _intrinsic_pid(ctx: ControllerContext) -> Any:
    """IntrinsicPID (log error, Maithripala & Berg): (ω_n, ζ) poles + integral pole at −ω_n/5."""
    from liecontrol.control.geometric_pid import IntrinsicPID
    from liecontrol.control.tuning import tune_intrinsic_pid

    spec, _ = tuned_spec(ctx)
    return IntrinsicPID(ctx.J, **tune_intrinsic_pid(ctx.J, spec), integral_limit=INTEGRAL_LIMIT)


def _integral_pd(ctx: ControllerContext) -> Any:
    """IntegralPD (large-angle error, ∫(e_Ω + c e_R), c = ω_n): integral pole at −ω_n/5."""
    from liecontrol.control.geometric_pid import IntegralPD
    from liecontrol.control.tuning import tune_integral_pd

    spec, _ = tuned_spec(ctx)
    return IntegralPD(ctx.J, **tune_integral_pd(ctx.J, spec), integral_limit=INTEGRAL_LIMIT)


#: Radius of the adaptive law's disturbance-coefficient ball [N·m]: 1.5× the norm of the
#: constant + harmonic coefficients of the ADRC paper's disturbance (≈ 0.0995 N·m), which the
#: ball must contain. The ball also caps the estimate's excursion during a slew (∫s dt there is
#: ~ the slew angle), whose unwinding otherwise dominates the slew's settling: measured on the
#: quick suite, 0.3 N·m left slew-90 at 0.24-0.39° after 600 s, 0.15 N·m settles it.
ADAPTIVE_DISTURBANCE_BOUND = 0.15
#: Disturbance pole of the adaptive law at −0.25 ω_n (the largest that keeps k_R > 0 at ζ = 0.9
#: is ≈ 0.27): at −0.1 ω_n the estimate's slow unwinding left step-5 at 0.27° after 400 s.
ADAPTIVE_INTEGRAL_RATIO = 0.25


def _adaptive_so3(ctx: ControllerContext) -> Any:
    """AdaptiveGeometricSO3 (large-angle error): inertia + constant/orbit-rate-harmonic
    disturbance estimated online, disturbance pole at −ω_n/4."""
    from liecontrol.control.adaptive import AdaptiveGeometricSO3
    from liecontrol.control.tuning import tune_adaptive_so3
    from spacecraft.disturbances import ConstantHarmonicTorque

    spec, _ = tuned_spec(ctx)
    # the known frequencies: the catalogue's harmonic disturbance at the orbit rate n and 2n
    n = ConstantHarmonicTorque().n
    kw = tune_adaptive_so3(
        ctx.J,
        spec,
        disturbance_bound=ADAPTIVE_DISTURBANCE_BOUND,
        frequencies=(n, 2.0 * n),
        integral_ratio=ADAPTIVE_INTEGRAL_RATIO,
        error="large_angle",
    )
    return AdaptiveGeometricSO3(ctx.J, **kw)


def _prescribed_performance(ctx: ControllerContext) -> Any:
    """PrescribedPerformance: funnel ρ_∞ = 0.002, 3× the initial error, decaying at ζω_n/4."""
    from liecontrol.control.prescribed_performance import PrescribedPerformance
    from liecontrol.control.tuning import tune_prescribed_performance

    spec, _ = tuned_spec(ctx)
    return PrescribedPerformance(ctx.J, **tune_prescribed_performance(ctx.J, spec))


def _mpc(ctx: ControllerContext) -> Any:
    """SO3MPC (OSQP), N = 10 at the control period, LQR-matched Q/R, the actuator's torque box."""
    from liecontrol.control.mpc import SO3MPC
    from liecontrol.control.tuning import tune_mpc

    spec, limits = tuned_spec(ctx)
    return SO3MPC(ctx.J, **tune_mpc(ctx.J, spec, limits))


def _mpc_keep_out(ctx: ControllerContext) -> Any:
    """SO3MPC (OSQP) tuned as ``mpc-osqp``, with the scenario's pointing cones linearised about
    the predicted trajectory at every step (slack-relaxed; plain ``mpc-osqp`` without cones)"""
    from liecontrol.control.constrained import ConstrainedGeometricPD
    from liecontrol.control.mpc import SO3MPC
    from liecontrol.control.tuning import tune_geometric_pd, tune_mpc

    spec, limits = tuned_spec(ctx)
    cones = {"keep_out": ctx.keep_out, "keep_in": ctx.keep_in}
    kw = tune_mpc(ctx.J, spec, limits)
    if ctx.keep_out or ctx.keep_in:
        # a step whose QP fails (iteration cap) must not hand over to a law blind to the cones
        gains = tune_geometric_pd(ctx.J, spec, error="large_angle")
        kw["fallback"] = ConstrainedGeometricPD(ctx.J, gains["k_R"], gains["k_Omega"], **cones)
    return SO3MPC(ctx.J, **kw, **cones)


def _adrc(ctx: ControllerContext) -> Any:
    """MrpADRC (Wu, Huang, Wei & Guo's ESO), Gao bandwidth tuning: ω_c = ω_n, ω_o = 5ω_c."""
    from liecontrol.control.adrc import MrpADRC
    from liecontrol.control.tuning import tune_mrp_adrc

    spec, _ = tuned_spec(ctx)
    return MrpADRC(ctx.J, **tune_mrp_adrc(ctx.J, spec), base="reference")


def _quaternion_pd(sign_mode: str) -> ControllerFactory:
    def make(ctx: ControllerContext) -> Any:
        from liecontrol.control.chart_baselines import QuaternionPD
        from liecontrol.control.tuning import tune_quaternion_pd

        spec, _ = tuned_spec(ctx)
        return QuaternionPD(
            ctx.J, **tune_quaternion_pd(ctx.J, spec), sign_mode=sign_mode, q_hint=ctx.q_hint
        )

    make.__doc__ = (
        f"QuaternionPD(sign_mode={sign_mode!r}) on the error quaternion (Wie & Barba), "
        "k_p = 2ω_n²J, k_d = 2ζω_nJ"
    )
    return make


def _mrp_pd(ctx: ControllerContext) -> Any:
    """MrpPD with shadow-set switching (Schaub & Junkins), K = 4ω_n²J, P = 2ζω_nJ."""
    from liecontrol.control.chart_baselines import MrpPD
    from liecontrol.control.tuning import tune_mrp_pd

    spec, _ = tuned_spec(ctx)
    return MrpPD(ctx.J, **tune_mrp_pd(ctx.J, spec))


def _tsm(ctx: ControllerContext) -> Any:
    """TerminalSlidingModeSO3 (Liu, Tang & Yu), ZYX Euler: T = the 2 % settling time, poles −ω_n."""
    from liecontrol.control.terminal_sliding_mode import TerminalSlidingModeSO3
    from liecontrol.control.tuning import tune_euler_tsm

    spec, _ = tuned_spec(ctx)
    return TerminalSlidingModeSO3(ctx.J, **tune_euler_tsm(ctx.J, spec), base="reference")


def _finite_time(fixed: bool) -> ControllerFactory:
    def make(ctx: ControllerContext) -> Any:
        from liecontrol.control.finite_time import FiniteTimeSO3, FixedTimeSO3
        from liecontrol.control.tuning import tune_finite_time_so3

        spec, _ = tuned_spec(ctx)
        cls = FixedTimeSO3 if fixed else FiniteTimeSO3
        return cls(ctx.J, **tune_finite_time_so3(ctx.J, spec, fixed_time=fixed))

    make.__doc__ = (
        f"{'FixedTimeSO3' if fixed else 'FiniteTimeSO3'}: nonsingular fast terminal sliding mode "
        "on Lee's large-angle SO(3) error, small-angle poles at the closed-loop spec (ω_n, ζ)"
    )
    return make


#: Upper bound of the fault-tolerant law's disturbance-bound estimate β̂ [N·m]: the catalogue's
#: constant + harmonic torque (≈ 0.1 N·m) plus the fault family's 1 mrad/s gimbal-rate bias
#: (≈ 0.3 N·m on a 300 N·m·s rotor), with margin.
FAULT_TOLERANT_BETA_MAX = 0.5


def _fault_tolerant(ctx: ControllerContext) -> Any:
    """AdaptiveFaultTolerantSO3: sliding law on the SO(3) log error with adaptive effectiveness
    and disturbance bound; small-angle poles −1.15 ω_n, −ω_n/1.15."""
    from liecontrol.control.fault_tolerant import AdaptiveFaultTolerantSO3, fault_tolerant_gains

    spec, _ = tuned_spec(ctx)
    kw = fault_tolerant_gains(
        ctx.J, spec.omega_n, spec.sample_period, beta_max=FAULT_TOLERANT_BETA_MAX
    )
    return AdaptiveFaultTolerantSO3(ctx.J, **kw)


#: Slew-rate limit of ``eigenaxis-rate-limited`` on an actuator with no momentum limit [rad/s].
EIGENAXIS_DEFAULT_RATE = 0.02


def _eigenaxis_rate_limited(ctx: ControllerContext) -> Any:
    """RateLimitedEigenaxis (Wie & Lu 1995): k = 2ω_n², c = 2ζω_n (gains ∝ J), slew rate ≤ half
    the momentum envelope over λ_max(J), feedback scaled into the actuator's torque box"""
    from liecontrol.control.eigenaxis import RateLimitedEigenaxis, wie_lu_gains

    spec, limits = tuned_spec(ctx)
    J = np.asarray(ctx.J, dtype=np.float64)
    rate = EIGENAXIS_DEFAULT_RATE
    if limits.max_momentum is not None:
        rate = 0.5 * min(limits.max_momentum) / float(np.linalg.eigvalsh(J).max())
    return RateLimitedEigenaxis(
        J, max_rate=rate, u_max=limits.max_torque, **wie_lu_gains(spec.omega_n, spec.zeta)
    )


def _payload_pid_ff(ctx: ControllerContext) -> Any:
    """SmallAnglePIDWithFeedforward (Wang, Chu, Zhang & Yuan): Euler PID + payload feed-forward.

    PID at the closed-loop spec (diagonal inertia only), identified harmonic feed-forward at the
    payload rate (90°/s), Δt_p = 0.1 s, Δt_c = 0.2 s, on from t = 0."""
    from liecontrol.control.payload_compensation import SmallAnglePIDWithFeedforward
    from liecontrol.control.tuning import tune_small_angle_pid
    from spacecraft.payload import PAYLOAD_SPIN_RATE

    spec, _ = tuned_spec(ctx)
    return SmallAnglePIDWithFeedforward(
        ctx.J,
        payload_frequency=PAYLOAD_SPIN_RATE,
        dt_c=0.2,
        dt_p=0.1,
        mode="identify",
        compensation_start=0.0,
        **tune_small_angle_pid(ctx.J, spec),
    )


#: SE(3) pose-loop bandwidths at the default rule [rad/s]; a rule with another ω_n scales both.
SE3_OMEGA_ATT, SE3_OMEGA_POS = 0.1, 0.05


def _se3_gains(ctx: ControllerContext) -> dict[str, Any]:
    from liecontrol.control.se3_control import pose_gains_from_bandwidth

    px = ctx.proximity
    k = ctx.rule.omega_n / DEFAULT_GAIN_RULE.omega_n
    return pose_gains_from_bandwidth(
        px.mass, px.J, omega_att=SE3_OMEGA_ATT * k, omega_pos=SE3_OMEGA_POS * k
    )


def _se3_tracking(ctx: ControllerContext) -> Any:
    """SE3TrackingController (split error, gravity feed-forward), ω_att 0.1, ω_pos 0.05 rad/s."""
    from liecontrol.control.se3_control import SE3TrackingController

    px = ctx.proximity
    return SE3TrackingController(px.mass, px.J, gravity=ctx.gravity, **_se3_gains(ctx))


def _bullo_murray(ctx: ControllerContext) -> Any:
    """BulloMurrayPD (survey Lemma 3 as written: log error, gravity feed-forward, ad* cancel)."""
    from liecontrol.control.se3_control import BulloMurrayPD

    px = ctx.proximity
    return BulloMurrayPD(px.mass, px.J, gravity=ctx.gravity, **_se3_gains(ctx))


@functools.lru_cache(maxsize=32)
def mean_field_squared(orbit: OrbitSpec) -> float:
    """``⟨‖B‖²⟩`` [T²] over one period of ``orbit`` in the IGRF-2020 tilted dipole
    (:class:`spacecraft.geomagnetic.TiltedDipoleField`; 400 samples): the factor that turns
    B-dot's gain into the cross-product law's averaged damping (:mod:`spacecraft.detumble`)."""
    from spacecraft.geomagnetic import TiltedDipoleField

    if not isinstance(orbit, OrbitSpec):
        raise ValueError(f"orbit: expected an OrbitSpec, got {type(orbit).__name__}")
    circ = orbit.circular_orbit()
    t = np.linspace(0.0, circ.period, 400)
    B = TiltedDipoleField().inertial(t, circ.position(t))
    return float(np.mean(np.sum(B * B, axis=-1)))


def _detumble_law(law: str) -> ControllerFactory:
    """Factory of the detumble law ``law`` (``"bdot"`` or ``"cross-product"``) for a detumble
    scenario. Both get the scenario's damping gain ``k`` (B-dot as ``k/⟨‖B‖²⟩``), so their
    averaged dynamics ``J ω̇ = −(2/3) d k ω`` are equal — the detumble form of the common
    tuning; the closed-loop spec ``ctx.rule`` (ω_n, ζ) has no meaning for them and is
    ignored."""

    def make(ctx: ControllerContext) -> Any:
        from spacecraft.detumble import DetumbleLaw

        det = ctx.detumble
        if det is None or ctx.orbit is None:
            raise ValueError(
                f"detumble: the {law!r} detumble law needs a detumble scenario's DetumbleSpec "
                "and orbit (ControllerContext.detumble and .orbit)"
            )
        gain = det.gain if law == "cross-product" else det.gain / mean_field_squared(ctx.orbit)
        return DetumbleLaw(
            gain,
            m_max=det.max_dipole,
            law=law,
            period=ctx.control_period,
            duty_cycle=det.duty_cycle,
            # B-dot ignores the gyro; the same noise draws keep both laws' magnetometer
            # samples identical for a member
            gyro_noise_std=det.gyro_noise,
            rod_power=det.rod_power,
        )

    make.__doc__ = f"{law} detumble law (spacecraft.detumble.DetumbleLaw)"
    return make


def _sun_acquisition_law(ctx: ControllerContext) -> Any:
    """Rate damping + Sun pointing ``τ = k_p (b × ŝ) − k_d ω`` for a Sun-acquisition scenario
    (:class:`liecontrol.control.sun_acquisition.SunAcquisitionLaw`), tuned by the common
    protocol: :func:`~liecontrol.control.sun_acquisition.sun_acquisition_gains` with the rule's
    ω_n and ζ on the nominal inertia, so the small-angle loop about the largest principal axis
    (the slowest) has exactly the closed-loop spec every attitude controller is tuned to; the
    spec's body axis and eclipse mode, the spacecraft's torque box."""
    from liecontrol.control.sun_acquisition import SunAcquisitionLaw, sun_acquisition_gains

    sa = ctx.sun_acquisition
    if sa is None:
        raise ValueError(
            "sun_acquisition: the Sun-acquisition law needs a Sun-acquisition scenario's "
            "SunAcquisitionSpec (ControllerContext.sun_acquisition)"
        )
    return SunAcquisitionLaw(
        **sun_acquisition_gains(ctx.J, ctx.rule.omega_n, ctx.rule.zeta),
        body_axis=sa.body_axis,
        max_torque=ctx.spacecraft.max_torque,
        eclipse=sa.eclipse,
    )


def _register_builtins() -> None:
    for err in ("trace", "log", "large_angle"):
        register(
            f"geometric-pd-{err.replace('_', '-')}",
            geometric_pd_factory(err),
            family="geometric",
        )
    register("geometric-pid-intrinsic", _intrinsic_pid, family="geometric")
    register("geometric-integral-pd", _integral_pd, family="geometric")
    register(
        "geometric-keep-out",
        _geometric_keep_out,
        description="large-angle geometric PD with log barriers on the scenario's pointing cones",
        family="geometric",
        quick=False,
    )
    register(
        "geometric-keep-out-sampled",
        _geometric_keep_out_sampled,
        description="geometric-keep-out with a sampled-data safety filter on the braking-distance "
        "margin at the control period and the torque box",
        family="geometric",
        quick=False,
    )
    register("prescribed-performance", _prescribed_performance, family="geometric")
    register("adaptive-so3", _adaptive_so3, family="geometric", quick=False)
    register("mpc-osqp", _mpc, batched=False, family="mpc")
    register(
        "mpc-keep-out",
        _mpc_keep_out,
        description="OSQP MPC with the scenario's pointing cones linearised along the prediction",
        batched=False,
        family="mpc",
        quick=False,
    )
    register(
        "eigenaxis-rate-limited",
        _eigenaxis_rate_limited,
        description="Wie & Lu's rate- and torque-limited eigenaxis quaternion feedback",
        family="chart",
        quick=False,
    )
    register("mrp-adrc", _adrc, family="chart")
    for mode in ("continuous", "switched", "hysteretic"):
        # on the quick suite's q-starts the three sign modes fly the same trajectory
        register(
            f"quaternion-pd-{mode}",
            _quaternion_pd(mode),
            family="chart",
            quick=mode == "continuous",
        )
    register("mrp-pd", _mrp_pd, family="chart")
    # adaptive fault-tolerant sliding law on SO(3): full suite only
    register("fault-tolerant-so3", _fault_tolerant, family="geometric", quick=False)
    register("euler-tsm", _tsm, family="chart")
    # finite/fixed-time sliding mode on SO(3): full suite only (the quick suite stays as it is)
    register("finite-time-so3", _finite_time(False), family="geometric", quick=False)
    register("fixed-time-so3", _finite_time(True), family="geometric", quick=False)
    register(
        "payload-pid-ff",
        _payload_pid_ff,
        family="chart",
        # the feed-forward of the 90°/s payload harmonic needs a 0.1 s hold (its own design)
        control_period=0.1,
        quick=False,
        exclude_tags=("manoeuvre", "unwinding", "large-angle"),
        notes="small-angle Euler PID: for pointing and jitter, not for large slews",
    )
    register("se3-tracking", _se3_tracking, plants={"se3"}, family="se3")
    # Measured on proximity-approach: 3.34e3 m final position error, = n²r/ω_pos² with
    # r = (μ/n²)^(1/3) ≈ 6.9e6 m; with cancel_coriolis=True the same law ends within 2 mm.
    register(
        "bullo-murray-pd",
        _bullo_murray,
        description="Bullo-Murray PD on SE(3) (Jiang, Meng & Yang 2023, Lemma 3 as written: "
        "log error, gravity feed-forward and the -ad*_ξ Iξ cancellation, whose force part -ω×mv "
        "is the centripetal term of riding the target's orbit; without it the position spring "
        "would carry m·n²·r and hold ≈ n²r/ω_pos² ≈ 3.3 km off the docking pose)",
        plants={"se3"},
        family="se3",
    )
    # detumble laws: the magnetorquer plant of the detumble scenarios only (full suite)
    register(
        "detumble-bdot",
        _detumble_law("bdot"),
        description="B-dot m = −k_b Ḃ from magnetometer differences, no gyro (Stickler & "
        "Alfriend 1976), k_b = k/⟨‖B‖²⟩",
        plants={"magnetorquer"},
        family="detumble",
        quick=False,
    )
    register(
        "detumble-cross-product",
        _detumble_law("cross-product"),
        description="rate-feedback cross-product m = k (ω × B)/‖B‖² with a gyro (Markley & "
        "Crassidis 2014, §7.5)",
        plants={"magnetorquer"},
        family="detumble",
        quick=False,
    )
    # safe mode: the sun-safe plant of the Sun-acquisition scenario only (full suite)
    register(
        "sun-acquisition",
        _sun_acquisition_law,
        description="rate damping + Sun pointing τ = k_p (b × ŝ) − k_d ω on coarse Sun sensors "
        "and a gyro (Chaturvedi, Sanyal & McClamroch 2011, reduced attitude)",
        plants={"sun-safe"},
        family="safe-mode",
        quick=False,
    )


_register_builtins()
