"""Registry of benchmark controllers with their metadata (SPEC §6, §8).

Adding a controller is one :func:`register` call::

    register("my-pd", lambda ctx: MyPD(ctx.J, ...), description="...", batched=True)

The factory receives a :class:`ControllerContext` — the controller's model inertia ``J`` (the
nominal one: with :class:`~benchmarks.scenarios.UncertaintySpec` the plant's true inertia
differs), the control period, the batch size it will be stepped with, the initial error
quaternion with the scenario's sign (``q_hint``, for the q/−q unwinding cases), the reference
trajectory and, for SE(3) scenarios, the :class:`~benchmarks.scenarios.ProximitySpec` and the
plant's gravity wrench — and returns a fresh controller
(:class:`liecontrol.control.AttitudeController` or, with ``plants={"se3"}``,
:class:`liecontrol.control.PoseController`). The metadata (:class:`ControllerInfo`) say whether
``command`` is vectorized over the batch (``batched``), which plants it applies to (``plants``:
``"sgcmg"``, ``"wheels"``, ``"ideal"`` attitude plants or ``"se3"``), scenario tags it must not
run on, its own sampling period (held between samples) and whether it is in the quick suite.

Gain rule (one rule for every controller so the comparison is fair; :class:`GainRule`): the
closed loop linearised about ``R = R_d`` is ``J δθ̈ + K_Ω δθ̇ + K_R S δθ = 0`` with ``S = s I`` the
error coordinate's slope (``s = 1`` log, ``½`` large-angle, ``½(tr G − g_max)`` trace, ``½`` for
the quaternion vector part, ``¼`` for the MRP); choosing

    K_R = ω_n² J / s,     K_Ω = 2 ζ ω_n J

(:func:`liecontrol.control.geometric_pd.gains_from_bandwidth` with ``matrix=True``) gives every
axis the same natural frequency ω_n and damping ratio ζ. The defaults ω_n = 0.03 rad/s, ζ = 0.9
keep the 179° slew's peak body momentum (linear estimate ≈ 0.37 ω_n θ₀ âᵀJâ ≈ 470 N·m·s about the
slew axis) inside the 4 × 300 N·m·s pyramid's momentum envelope, and settle a small error to 0.1°
in ≈ 5/(ζ ω_n) ≈ 3 min. Integral actions use ``K_I = (ω_n/5) K_R`` with a 0.3 N·m anti-windup
clamp (:data:`INTEGRAL_LIMIT`); the MPC's weights give the same bandwidth; seed 000's ADRC keeps
the paper's parameters.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._validation import check_positive

from .scenarios import ProximitySpec, Scenario, SpacecraftSpec

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
]

#: Plant tags of attitude scenarios (the actuator kinds of :class:`SpacecraftSpec`).
ATTITUDE_PLANTS: frozenset[str] = frozenset({"sgcmg", "wheels", "ideal"})


@dataclass(frozen=True)
class GainRule:
    """Linearised closed-loop natural frequency ``omega_n`` [rad/s] and damping ratio ``zeta``."""

    omega_n: float = 0.03
    zeta: float = 0.9

    def __post_init__(self) -> None:
        object.__setattr__(self, "omega_n", check_positive(self.omega_n, "omega_n"))
        object.__setattr__(self, "zeta", check_positive(self.zeta, "zeta"))


DEFAULT_GAIN_RULE = GainRule()
#: Anti-windup clamp of the integral torque of the PID variants [N·m]: ≈ 3× the constant part
#: of the seed-000 disturbance (|(0.02, 0.08, 0.02)| ≈ 0.085 N·m), which the integral must cancel.
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
    """

    spacecraft: SpacecraftSpec
    control_period: float
    batch_size: int = 1
    q_hint: np.ndarray | None = None
    reference: Callable[[float], Any] | None = None
    proximity: ProximitySpec | None = None
    gravity: Callable[[np.ndarray], np.ndarray] | None = None

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
        plants: plant tags it applies to (:data:`ATTITUDE_PLANTS` or ``{"se3"}``).
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

    def applies(self, scenario: Scenario) -> tuple[bool, str]:
        """``(True, "")`` or ``(False, reason)`` for ``scenario``."""
        if scenario.plant not in self.plants:
            return False, "SE(3) controller" if "se3" in self.plants else "attitude controller"
        hit = sorted(self.exclude_tags.intersection(scenario.tags))
        if hit:
            return False, self.notes or f"excluded for tag {hit[0]!r}"
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
    known = ATTITUDE_PLANTS | {"se3"}
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


def applicable(scenario: Scenario, names: tuple[str, ...] | None = None) -> tuple[str, ...]:
    """Names (default: all registered) that apply to ``scenario``."""
    names = available_controllers() if names is None else names
    return tuple(n for n in names if get_controller(n).applies(scenario)[0])


# --------------------------------------------------------------------------- built-in factories


def geometric_pd_factory(error: str, rule: GainRule = DEFAULT_GAIN_RULE) -> ControllerFactory:
    """Factory of a :class:`~liecontrol.control.geometric_pd.GeometricPD` with error function
    ``error`` and gains from ``rule`` (module docstring)."""

    def make(ctx: ControllerContext) -> Any:
        from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth

        k_R, k_Omega = gains_from_bandwidth(
            ctx.J, rule.omega_n, rule.zeta, error=error, matrix=True
        )
        return GeometricPD(ctx.J, k_R, k_Omega, error=error)

    make.__doc__ = f"GeometricPD(error={error!r}), ω_n={rule.omega_n} rad/s, ζ={rule.zeta}"
    return make


def _pd_gains(ctx: ControllerContext, slope: float, rule: GainRule) -> tuple[np.ndarray, ...]:
    J = ctx.J
    return rule.omega_n**2 * J / slope, 2.0 * rule.zeta * rule.omega_n * J


def _intrinsic_pid(ctx: ControllerContext, rule: GainRule = DEFAULT_GAIN_RULE) -> Any:
    """IntrinsicPID (log error, Maithripala & Berg), K_I = (ω_n/5) K_R, 0.3 N·m clamp."""
    from liecontrol.control.geometric_pid import IntrinsicPID, integral_gain

    k_R, k_W = _pd_gains(ctx, 1.0, rule)
    k_I = integral_gain(k_R, rule.omega_n / 5.0)
    return IntrinsicPID(ctx.J, k_R, k_W, k_I, error="log", integral_limit=INTEGRAL_LIMIT)


def _integral_pd(ctx: ControllerContext, rule: GainRule = DEFAULT_GAIN_RULE) -> Any:
    """IntegralPD (large-angle error, ∫(e_Ω + c e_R)), c = ω_n, K_I = (ω_n/5)K_R/c, 0.3 N·m cap."""
    from liecontrol.control.geometric_pid import IntegralPD, integral_gain

    k_R, k_W = _pd_gains(ctx, 0.5, rule)
    c = rule.omega_n
    k_I = integral_gain(k_R, rule.omega_n / 5.0, c=c)
    return IntegralPD(ctx.J, k_R, k_W, k_I, c=c, error="large_angle", integral_limit=INTEGRAL_LIMIT)


def _prescribed_performance(ctx: ControllerContext, rule: GainRule = DEFAULT_GAIN_RULE) -> Any:
    """PrescribedPerformance: funnel ρ_∞ = 0.002, decay 0.02 1/s, ppc_gains(ω_n, ζ)."""
    from liecontrol.control.prescribed_performance import PrescribedPerformance, ppc_gains

    k1, k2, kc = ppc_gains(rule.omega_n, rule.zeta)
    return PrescribedPerformance(ctx.J, rho_inf=0.002, decay=0.02, k1=k1, k2=k2, kc=kc)


def _mpc(ctx: ControllerContext, rule: GainRule = DEFAULT_GAIN_RULE) -> Any:
    """SO3MPC (OSQP), N = 20 × 1 s, |u_i| ≤ 50 N·m, weights ≈ the common bandwidth."""
    from liecontrol.control.mpc import SO3MPC

    # per axis, the continuous LQR of J θ̈ = u with cost q_ξθ² + q_ωω² + u² has the gains
    # k₁ = √q_ξ, k₂ = √(q_ω + 2J√q_ξ); matching k₁ = ω_n²J, k₂ = 2ζω_nJ (the common rule) on the
    # largest principal moment gives the weights below
    lam = float(np.linalg.eigvalsh(ctx.J)[-1])
    w = rule.omega_n
    q_xi = (w**2 * lam) ** 2
    q_w = (2.0 * rule.zeta * w * lam) ** 2 - 2.0 * w**2 * lam**2
    Q = [q_xi] * 3 + [max(q_w, 1e-6 * q_xi)] * 3
    return SO3MPC(ctx.J, horizon=20, dt=1.0, Q=Q, R=[1.0] * 3, u_max=50.0)


def _adrc(ctx: ControllerContext) -> Any:
    """MrpADRC (seed 000): MRP ESO + AFC with the paper's parameters, error-MRP chart."""
    from liecontrol.control.adrc import PAPER, MrpADRC

    return MrpADRC(ctx.J, PAPER, base="reference")


def _quaternion_pd(sign_mode: str, rule: GainRule = DEFAULT_GAIN_RULE) -> ControllerFactory:
    def make(ctx: ControllerContext) -> Any:
        from liecontrol.control.chart_baselines import QuaternionPD

        k_p, k_d = _pd_gains(ctx, 0.5, rule)
        return QuaternionPD(ctx.J, k_p, k_d, sign_mode=sign_mode, q_hint=ctx.q_hint)

    make.__doc__ = f"QuaternionPD(sign_mode={sign_mode!r}) on the error quaternion (Wie & Barba)"
    return make


def _mrp_pd(ctx: ControllerContext, rule: GainRule = DEFAULT_GAIN_RULE) -> Any:
    """MrpPD with shadow-set switching (Schaub & Junkins), K = 4ω_n²J, P = 2ζω_nJ."""
    from liecontrol.control.chart_baselines import MrpPD

    K, P = _pd_gains(ctx, 0.25, rule)
    return MrpPD(ctx.J, K, P)


def _tsm(ctx: ControllerContext) -> Any:
    """TerminalSlidingModeSO3 (seed 004): ZYX Euler error chart, T = 300 s, K = 1e-4 rad/s²."""
    from liecontrol.control.terminal_sliding_mode import TerminalSlidingModeSO3

    return TerminalSlidingModeSO3(ctx.J, T=300.0, K=1e-4, delta0=0.03, delta1=5.0, base="reference")


def _payload_pid_ff(ctx: ControllerContext) -> Any:
    """SmallAnglePIDWithFeedforward (seed 003): 0.02 Hz Euler PID + identified harmonic
    feed-forward at the seed-003 payload rate (90°/s), Δt_p = 0.1 s, Δt_c = 0.2 s, on from t = 0."""
    from liecontrol.control.payload_compensation import SmallAnglePIDWithFeedforward
    from spacecraft.payload import SEED003_SPIN_RATE

    return SmallAnglePIDWithFeedforward(
        ctx.J,
        payload_frequency=SEED003_SPIN_RATE,
        dt_c=0.2,
        dt_p=0.1,
        mode="identify",
        compensation_start=0.0,
    )


def _se3_gains(ctx: ControllerContext) -> dict[str, Any]:
    from liecontrol.control.se3_control import pose_gains_from_bandwidth

    px = ctx.proximity
    return pose_gains_from_bandwidth(px.mass, px.J, omega_att=0.1, omega_pos=0.05)


def _se3_tracking(ctx: ControllerContext) -> Any:
    """SE3TrackingController (split error, gravity feed-forward), ω_att 0.1, ω_pos 0.05 rad/s."""
    from liecontrol.control.se3_control import SE3TrackingController

    px = ctx.proximity
    return SE3TrackingController(px.mass, px.J, gravity=ctx.gravity, **_se3_gains(ctx))


def _bullo_murray(ctx: ControllerContext) -> Any:
    """BulloMurrayPD (survey Lemma 3, log error, gravity feed-forward, no Coriolis cancel)."""
    from liecontrol.control.se3_control import BulloMurrayPD

    px = ctx.proximity
    return BulloMurrayPD(
        px.mass, px.J, gravity=ctx.gravity, cancel_coriolis=False, **_se3_gains(ctx)
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
    register("prescribed-performance", _prescribed_performance, family="geometric")
    register("mpc-osqp", _mpc, batched=False, control_period=1.0, family="mpc")
    # the paper's ESO (gains up to 800) needs ≤ 0.1 s sampling: at 0.2 s the loop chatters
    register("mrp-adrc", _adrc, family="chart", control_period=0.1)
    for mode in ("continuous", "switched", "hysteretic"):
        # on the quick suite's q-starts the three sign modes fly the same trajectory
        register(
            f"quaternion-pd-{mode}",
            _quaternion_pd(mode),
            family="chart",
            quick=mode == "continuous",
        )
    register("mrp-pd", _mrp_pd, family="chart")
    register("euler-tsm", _tsm, family="chart")
    register(
        "payload-pid-ff",
        _payload_pid_ff,
        family="chart",
        control_period=0.1,
        quick=False,
        exclude_tags=("manoeuvre", "unwinding", "large-angle"),
        notes="small-angle Euler PID: for pointing and jitter, not for large slews",
    )
    register("se3-tracking", _se3_tracking, plants={"se3"}, family="se3")
    register("bullo-murray-pd", _bullo_murray, plants={"se3"}, family="se3")


_register_builtins()
