"""Run scenarios × controllers and collect metrics.

Matrix: every registered controller (or the ones asked for) × every scenario. A pair whose
controller does not apply to the scenario (an SE(3) controller on an attitude plant, an attitude
controller on the SE(3) plant, an excluded tag) is recorded with status ``"n/a"`` and the reason —
never silently left out.

Batching: pairs whose scenarios share the plant and time grid (:meth:`Scenario.batch_key`) form
one task, simulated in a single :func:`spacecraft.simulator.simulate` call: a
:class:`StackedController` hands each controller its slice of the batch — one instance for all
the pairs of a ``batched`` controller (its ``command`` is vectorized), one instance per pair
otherwise — and a :class:`StackedReference` stacks the references. If a batched task raises, its
pairs are re-run one by one so the failure is recorded against the pair that caused it (with the
error text) and the others still produce metrics. SE(3) pairs run one by one with
:func:`spacecraft.se3_plant.simulate_pose`.

Tasks run on an executor (:mod:`benchmarks.executors`): in-process, local processes (default)
or a dask.distributed cluster; results are identical whichever runs them.

Controller wall time is measured by :class:`TimedController`, a proxy that times
``command()`` alone; the reported ``controller_time_us`` is the mean time of one call divided by
the number of spacecraft it served (per spacecraft per control step).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import time
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from liecontrol._validation import (
    as_array,
    as_int,
    as_scalar,
    check_inertia,
    check_positive_scalar,
    check_rotation_matrix,
)
from liecontrol.control import AttitudeController, AttitudeReference, AttitudeState

from .controllers import (
    DEFAULT_GAIN_RULE,
    ControllerContext,
    ControllerInfo,
    GainRule,
    get_controller,
)
from .dispersion import MAX_MEMBERS, DispersionSpec, member_scenario
from .executors import Executor, TaskFailure, describe_exception, make_executor
from .histories import history_arrays
from .metrics import compute_metrics, error_angle, judge, rate_error, settling_time, trapezoid
from .ranking import CellSummary, summarise_cell
from .requirements import pointing_window, requirements_of
from .scenarios import DisturbanceSpec, ReferenceSpec, Scenario, SensorSpec, SpacecraftSpec

_LOG = logging.getLogger(__name__)

__all__ = [
    "RunOutcome",
    "SuiteResult",
    "TimedController",
    "HeldController",
    "StackedController",
    "StackedReference",
    "ConstantRateReference",
    "build_steering",
    "build_actuator",
    "build_disturbance",
    "build_plant",
    "build_reference",
    "build_sensors",
    "FilteredAttitude",
    "initial_state",
    "with_verdict",
    "run_suite",
    "run_group",
    "detumble_inputs",
    "detumble_metrics",
    "MAX_SERIES_POINTS",
]

#: Time series kept per run for the figures are decimated to at most this many samples.
MAX_SERIES_POINTS = 2000


# --------------------------------------------------------------------------- controller proxies


class TimedController(AttitudeController):
    """Proxy that forwards the controller interface and times ``command()`` alone.

    ``mean_time_per_call`` [s] and ``calls`` after a run; ``batched`` mirrors the inner one.
    """

    def __init__(self, inner: Any) -> None:
        _check_controller_like(inner, "inner")
        self.inner = inner
        self.batched = bool(getattr(inner, "batched", True))
        self.total_time = 0.0
        self.calls = 0

    def reset(self, t0: float, batch_size: int) -> None:
        self.total_time = 0.0
        self.calls = 0
        self.inner.reset(t0, batch_size)

    def command(self, t: float, state: Any, reference: Any) -> np.ndarray:
        t_start = time.perf_counter()
        out = self.inner.command(t, state, reference)
        self.total_time += time.perf_counter() - t_start
        self.calls += 1
        return out

    def diagnostics(self) -> dict[str, np.ndarray]:
        d = getattr(self.inner, "diagnostics", None)
        return d() if callable(d) else {}

    @property
    def mean_time_per_call(self) -> float:
        return self.total_time / self.calls if self.calls else float("nan")


class HeldController(AttitudeController):
    """Samples ``inner`` every ``period`` seconds and holds its command in between (zero-order
    hold), for controllers with their own sampling period (e.g. the MPC at 1 s) inside a loop
    sampled faster. ``calls`` of an inner :class:`TimedController` count real samples only."""

    def __init__(self, inner: Any, period: float) -> None:
        _check_controller_like(inner, "inner")
        self.inner = inner
        self.period = check_positive_scalar(period, "period")
        self.batched = bool(getattr(inner, "batched", True))
        self._t_next = -math.inf
        self._held: np.ndarray | None = None

    def reset(self, t0: float, batch_size: int) -> None:
        self._t_next = -math.inf
        self._held = None
        self.inner.reset(t0, batch_size)

    def command(self, t: float, state: Any, reference: Any) -> np.ndarray:
        # 1e-9 relative slack: sample times are t0 + k·dt in floating point
        if self._held is None or t >= self._t_next - 1e-9 * max(1.0, abs(t)):
            self._held = np.asarray(self.inner.command(t, state, reference), dtype=np.float64)
            self._t_next = t + self.period
        return self._held.copy()

    def diagnostics(self) -> dict[str, np.ndarray]:
        d = getattr(self.inner, "diagnostics", None)
        return d() if callable(d) else {}


def _slice_ref(a: np.ndarray, sl: slice, core_ndim: int) -> np.ndarray:
    a = np.asarray(a)
    return a[sl] if a.ndim > core_ndim else a


class StackedController(AttitudeController):
    """Several controllers sharing one batch: member ``i`` drives spacecraft ``slices[i]``.

    Members with ``batched = False`` are stepped one spacecraft at a time within their slice.
    ``diagnostics()`` concatenates the keys every member reports with equal trailing shapes.
    """

    batched = True

    def __init__(self, members: Sequence[Any], sizes: Sequence[int]) -> None:
        members, sizes = _check_stack(members, "members", sizes)
        for i, m in enumerate(members):
            _check_controller_like(m, f"members[{i}]")
        if len(members) != len(sizes) or not members:
            raise ValueError("members: need one batch size per member and at least one member")
        if any(int(n) < 1 for n in sizes):
            raise ValueError(f"sizes: every member needs >= 1 spacecraft, got {list(sizes)}")
        self.members = list(members)
        self.sizes = [int(n) for n in sizes]
        edges = np.cumsum([0] + self.sizes)
        self.slices = [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]
        self.batch_size = int(edges[-1])

    def reset(self, t0: float, batch_size: int) -> None:
        if batch_size != self.batch_size:
            raise ValueError(
                f"batch_size: the stacked controller covers {self.batch_size} spacecraft, "
                f"got {batch_size}"
            )
        for m, n in zip(self.members, self.sizes, strict=True):
            if not getattr(m, "batched", True) and n != 1:
                raise ValueError("sizes: an unbatched member must drive exactly one spacecraft")
            m.reset(t0, n)

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        out = np.empty((state.R.shape[0], 3))
        for m, sl in zip(self.members, self.slices, strict=True):
            sub_ref = AttitudeReference(
                R_d=_slice_ref(reference.R_d, sl, 2),
                omega_d=_slice_ref(reference.omega_d, sl, 1),
                omega_dot_d=_slice_ref(reference.omega_dot_d, sl, 1),
            )
            h = None if state.h is None else state.h[sl]
            out[sl] = m.command(t, AttitudeState(state.R[sl], state.omega[sl], h), sub_ref)
        return out

    def diagnostics(self) -> dict[str, np.ndarray]:
        diags = [m.diagnostics() for m in self.members]
        keys = set(diags[0]).intersection(*diags[1:]) if diags else set()
        out: dict[str, np.ndarray] = {}
        for k in sorted(keys):
            parts = [np.asarray(d[k]) for d in diags]
            if all(p.ndim >= 1 and p.shape[1:] == parts[0].shape[1:] for p in parts):
                out[k] = np.concatenate(parts, axis=0)
        return out


class StackedReference:
    """Reference of a stacked batch: ``references[i](t)`` broadcast over ``sizes[i]`` spacecraft.

    When every member is a :class:`liecontrol.control.ConstantAttitude` the stacked sample is
    computed once and returned (read-only) at every call: the loop's hot path."""

    def __init__(
        self, references: Sequence[Callable[[float], AttitudeReference]], sizes: Sequence[int]
    ) -> None:
        references, sizes = _check_stack(references, "references", sizes)
        for i, r in enumerate(references):
            if not callable(r):
                raise ValueError(f"references[{i}]: must be callable as reference(t)")
        from liecontrol.control import ConstantAttitude

        self.references = tuple(references)
        self.sizes = tuple(int(n) for n in sizes)
        if len(self.references) != len(self.sizes) or not self.references:
            raise ValueError("references: need one size per reference and at least one")
        self._const: AttitudeReference | None = None
        if all(isinstance(r, ConstantAttitude) for r in self.references):
            self._const = self._stack(0.0)
            for a in (self._const.R_d, self._const.omega_d, self._const.omega_dot_d):
                a.setflags(write=False)

    def _stack(self, t: float) -> AttitudeReference:
        R_d, w_d, dw_d = [], [], []
        for ref, n in zip(self.references, self.sizes, strict=True):
            r = ref(t)
            R_d.append(np.broadcast_to(r.R_d, (n, 3, 3)))
            w_d.append(np.broadcast_to(r.omega_d, (n, 3)))
            dw_d.append(np.broadcast_to(r.omega_dot_d, (n, 3)))
        return AttitudeReference(
            R_d=np.concatenate(R_d), omega_d=np.concatenate(w_d), omega_dot_d=np.concatenate(dw_d)
        )

    def __call__(self, t: float) -> AttitudeReference:
        return self._const if self._const is not None else self._stack(t)

    @property
    def time_invariant(self) -> bool:
        """Every member is a constant attitude (the simulator then samples the stack once)."""
        return self._const is not None

    def samples(self, times: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stacked reference at every time of ``times`` ``(N,)``: ``(N, B, 3, 3)``,
        ``(N, B, 3)``, ``(N, B, 3)`` (the sampling protocol of
        :mod:`liecontrol.control.reference`); each member through its own ``samples`` where it
        has one, else called at every time."""
        t = as_array(times, "times")
        if t.ndim != 1:
            raise ValueError(f"times: expected shape (N,), got {t.shape}")
        N = t.shape[0]
        parts: list[tuple[np.ndarray, ...]] = []
        for ref, n in zip(self.references, self.sizes, strict=True):
            many = getattr(ref, "samples", None)
            if callable(many):
                got = tuple(np.asarray(a, dtype=np.float64) for a in many(t))
            else:
                rs = [ref(float(tk)) for tk in t]
                got = tuple(
                    np.stack([np.broadcast_to(getattr(r, k), getattr(rs[0], k).shape) for r in rs])
                    for k in ("R_d", "omega_d", "omega_dot_d")
                )
            R_d, w_d, dw_d = got
            parts.append(
                (
                    np.broadcast_to(R_d.reshape(N, -1, 3, 3), (N, n, 3, 3)),
                    np.broadcast_to(w_d.reshape(N, -1, 3), (N, n, 3)),
                    np.broadcast_to(dw_d.reshape(N, -1, 3), (N, n, 3)),
                )
            )
        R_d, w_d, dw_d = (np.concatenate(a, axis=1) for a in zip(*parts, strict=True))
        return R_d, w_d, dw_d


@dataclass(frozen=True)
class ConstantRateReference:
    """Slewing reference ``R_d(t) = R_d0 exp((t − t0) ω_d^)``, constant desired body rate
    ``ω_d`` [rad/s], ``ω̇_d = 0`` (the exact solution of ``Ṙ_d = R_d ω_d^``)."""

    R_d0: np.ndarray
    omega_d: np.ndarray
    t0: float = 0.0

    def __post_init__(self) -> None:
        R = check_rotation_matrix(self.R_d0, "R_d0")
        if R.shape != (3, 3):
            raise ValueError(f"R_d0: expected shape (3, 3), got {R.shape}")
        w = as_array(self.omega_d, "omega_d")
        if w.shape != (3,):
            raise ValueError(f"omega_d: expected shape (3,), got {w.shape}")
        object.__setattr__(self, "R_d0", R)
        object.__setattr__(self, "omega_d", w)
        object.__setattr__(self, "t0", as_scalar(self.t0, "t0"))

    def __call__(self, t: float) -> AttitudeReference:
        from liecontrol.lie import so3

        w = np.asarray(self.omega_d, dtype=np.float64)
        R_d = np.asarray(self.R_d0) @ so3.exp((float(t) - self.t0) * w)
        return AttitudeReference(R_d=R_d, omega_d=w, omega_dot_d=np.zeros(3))

    def samples(self, times: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reference at every time of ``times`` ``(N,)`` in one vectorised call (the
        sampling protocol of :mod:`liecontrol.control.reference`): ``(N, 3, 3)``, ``(N, 3)``,
        ``(N, 3)``, equal to ``self(times[k])`` sample by sample."""
        from liecontrol.lie import so3

        t = as_array(times, "times")
        if t.ndim != 1:
            raise ValueError(f"times: expected shape (N,), got {t.shape}")
        w = np.asarray(self.omega_d, dtype=np.float64)
        R_d = np.asarray(self.R_d0) @ so3.exp((t - self.t0)[:, None] * w)
        return R_d, np.broadcast_to(w, t.shape + (3,)), np.zeros(t.shape + (3,))


# --------------------------------------------------------------------------- plant from data


def _need(obj: Any, cls: type, name: str) -> None:
    """Raise ``"{name}: expected a {cls}, got …"`` unless ``obj`` is a ``cls``."""
    if not isinstance(obj, cls):
        raise ValueError(f"{name}: expected a {cls.__name__}, got {type(obj).__name__} {obj!r}")


def _check_controller_like(obj: Any, name: str) -> None:
    """Raise naming ``name`` unless ``obj`` has the controller interface (reset, command)."""
    for method in ("reset", "command"):
        if not callable(getattr(obj, method, None)):
            raise ValueError(
                f"{name}: expected a controller (reset/command methods), got "
                f"{type(obj).__name__} without {method}()"
            )


def build_steering(spec: SpacecraftSpec, cluster: Any) -> Any:
    """Steering law named by ``spec.steering``: ``"pinv-null-motion"`` (Wu, Huang, Wei & Guo),
    ``"pinv"``, ``"sr"`` (singularity-robust), ``"gsr"`` (generalized SR, Wie),
    ``"local-gradient"`` (null motion with step control), ``"sda"`` (singular-direction
    avoidance, Ford & Hall); each with its default parameters."""
    from spacecraft.steering import (
        GeneralizedSingularityRobust,
        LocalGradient,
        PseudoInverse,
        PseudoInverseNullMotion,
        SingularDirectionAvoidance,
        SingularityRobust,
    )

    _need(spec, SpacecraftSpec, "spec")
    laws = {
        "pinv-null-motion": lambda: PseudoInverseNullMotion(cluster=cluster),
        "pinv": PseudoInverse,
        "sr": SingularityRobust,
        "gsr": GeneralizedSingularityRobust,
        "local-gradient": lambda: LocalGradient(cluster=cluster),
        "sda": SingularDirectionAvoidance,
    }
    try:
        return laws[spec.steering]()
    except KeyError:
        raise ValueError(
            f"steering: unknown steering law {spec.steering!r}; valid: {', '.join(sorted(laws))}"
        ) from None


def build_actuator(spec: SpacecraftSpec, bus_inertia: Any = None) -> Any:
    """The actuator of ``spec.actuator``: SGCMG pyramid, orthogonal wheels or ideal torque.

    With ``spec.cmg_model == "full"`` the SGCMG pyramid is a
    :class:`spacecraft.cmg_dynamics.VscmgActuator` on ``bus_inertia`` (the plant body's inertia,
    default ``spec.J``), with a torque-limited PI gimbal-rate servo."""
    from spacecraft.actuators import IdealTorqueActuator, ReactionWheelAssembly, SgcmgActuator
    from spacecraft.sgcmg import SgcmgPyramid

    _need(spec, SpacecraftSpec, "spec")
    J_bus = spec.J if bus_inertia is None else check_inertia(bus_inertia, "bus_inertia")
    if spec.actuator == "sgcmg":
        cluster = SgcmgPyramid(
            h0=spec.h0,
            beta=float(np.deg2rad(spec.beta_deg)),
            gimbal_rate_limit=spec.gimbal_rate_limit,
        )
        if spec.cmg_model == "full":
            from spacecraft.cmg_dynamics import CmgInertias, GimbalServo, VscmgActuator

            return VscmgActuator(
                J_bus,
                CmgInertias(
                    spec.cmg_wheel_spin_inertia,
                    spec.cmg_wheel_transverse_inertia,
                    spec.cmg_gimbal_inertia,
                ),
                cluster=cluster,
                steering=build_steering(spec, cluster),
                servo=GimbalServo(
                    bandwidth=spec.gimbal_servo_bandwidth,
                    max_torque=spec.gimbal_torque_limit,
                    damping=spec.gimbal_servo_damping,
                    gyro_feedforward=spec.gimbal_gyro_feedforward,
                ),
                delta0=np.deg2rad(np.array(spec.delta0_deg)),
            )
        return SgcmgActuator(
            cluster=cluster,
            steering=build_steering(spec, cluster),
            delta0=np.deg2rad(np.array(spec.delta0_deg)),
        )
    if spec.actuator == "wheels":
        make = (
            ReactionWheelAssembly.pyramid
            if spec.wheel_layout == "pyramid"
            else ReactionWheelAssembly.orthogonal
        )
        return make(
            wheel_inertia=spec.wheel_inertia,
            max_torque=spec.wheel_max_torque,
            max_speed=spec.wheel_max_speed,
            coulomb_friction=spec.wheel_coulomb_friction,
            viscous_friction=spec.wheel_viscous_friction,
            stribeck_torque=spec.wheel_stribeck_torque,
            stribeck_speed=spec.wheel_stribeck_speed,
            torque_lsb=spec.wheel_torque_lsb,
        )
    return IdealTorqueActuator(max_torque=spec.max_torque)


def _environment_torque(name: str, kw: dict[str, float], orbit: Any) -> Any:
    """An environment torque of :mod:`spacecraft.surface_forces` from a disturbance spec's
    parameters (see :class:`~benchmarks.scenarios.DisturbanceSpec`); errors name the key."""
    from spacecraft import surface_forces as sf
    from spacecraft.orbit import CircularOrbit

    if orbit is not None:
        _need(orbit, CircularOrbit, "orbit")
    base = CircularOrbit(n=0.0011) if orbit is None else orbit
    if {"altitude_km", "inclination_deg", "raan_deg"} & kw.keys():
        alt = kw.get("altitude_km", base.altitude / 1e3)
        if not alt > 0.0:
            raise ValueError(f"altitude_km: must be > 0, got {alt}")
        base = CircularOrbit.from_altitude(
            alt * 1e3,
            inclination=math.radians(kw.get("inclination_deg", math.degrees(base.inclination))),
            raan=math.radians(kw.get("raan_deg", math.degrees(base.raan))),
        )
    if name == "residual-dipole":
        m = [kw.get("x", 1.0), kw.get("y", 0.0), kw.get("z", 0.0)]
        return sf.ResidualDipoleTorque(m, base)
    size = [kw.get(k, 2.0) for k in ("size_x", "size_y", "size_z")]
    for k, v in zip(("size_x", "size_y", "size_z"), size, strict=True):
        if not v > 0.0:
            raise ValueError(f"{k}: must be > 0, got {v}")
    offset = [kw.get("offset_x", 0.0), kw.get("offset_y", 0.0), kw.get("offset_z", 0.2)]
    optical = {k: kw[k] for k in ("absorption", "specular", "diffuse") if k in kw}
    for k, v in optical.items():
        if not 0.0 <= v <= 1.0:
            raise ValueError(f"{k}: must be in [0, 1], got {v}")
    if optical and "absorption" not in optical:  # absorption defaults to the rest of the light
        rest = optical.get("specular", 0.0) + optical.get("diffuse", 0.0)
        if rest > 1.0:
            raise ValueError(f"specular: specular + diffuse = {rest} exceeds 1 (diffuse included)")
        optical["absorption"] = 1.0 - rest
    plates = sf.box_plates(size, offset, **optical)
    if name == "aerodynamic":
        if base.altitude < sf.ExponentialAtmosphere.min_altitude:
            raise ValueError(
                f"altitude_km: {base.altitude / 1e3:.6g} km is below the atmosphere model's "
                f"range (from {sf.ExponentialAtmosphere.min_altitude / 1e3:.0f} km)"
            )
        return sf.AerodynamicTorque(
            plates,
            base,
            drag_coefficient=kw.get("drag_coefficient", 2.2),
            atmosphere=sf.ExponentialAtmosphere(kw.get("density_scale", 1.0)),
        )
    return sf.SolarPressureTorque(plates, base, epoch_jd=kw.get("epoch_jd", sf.J2000_JD))


def build_disturbance(
    specs: Sequence[DisturbanceSpec], true_J: np.ndarray, orbit: Any = None
) -> Any:
    """Disturbance source of ``specs`` (``None`` when empty; summed when several).
    Gravity gradient uses the plant's **true** inertia ``true_J``. The environment torques
    (``aerodynamic``, ``solar-pressure``, ``residual-dipole``) fly ``orbit`` (a
    :class:`spacecraft.orbit.CircularOrbit`, e.g. the scenario's) unless their own orbit keys
    say otherwise."""
    from spacecraft.disturbances import ConstantHarmonicTorque, ConstantTorque, SumOfDisturbances

    if isinstance(specs, (str, DisturbanceSpec)) or not isinstance(specs, Iterable):
        raise ValueError(f"specs: expected a sequence of DisturbanceSpec, got {specs!r}")
    specs = tuple(specs)
    for i, spec in enumerate(specs):
        _need(spec, DisturbanceSpec, f"specs[{i}]")
    true_J = check_inertia(true_J, "true_J")  # (3, 3) or per spacecraft (B, 3, 3)
    if orbit is not None:
        from spacecraft.orbit import CircularOrbit

        _need(orbit, CircularOrbit, "orbit")
    sources: dict[str, Any] = {}
    for i, spec in enumerate(specs):
        kw = spec.kwargs
        if spec.name == "constant-harmonic":
            src: Any = ConstantHarmonicTorque(**kw)
        elif spec.name == "gravity-gradient":
            from spacecraft.environment import GravityGradientTorque
            from spacecraft.orbit import CircularOrbit

            src = GravityGradientTorque(true_J, CircularOrbit(n=kw.get("n", 0.0011)))
        elif spec.name == "constant":
            src = ConstantTorque([kw.get("x", 0.0), kw.get("y", 0.0), kw.get("z", 0.0)])
        elif spec.name in ("aerodynamic", "solar-pressure", "residual-dipole"):
            src = _environment_torque(spec.name, kw, orbit)
        else:  # "rotating-payload"
            import dataclasses

            from spacecraft.payload import ROTATING_PAYLOAD_EXAMPLE, RotatingPayloadTorque

            payload = ROTATING_PAYLOAD_EXAMPLE
            if kw.get("scale", 1.0) != 1.0:
                payload = dataclasses.replace(
                    payload, mass=payload.mass * kw["scale"], inertia=payload.inertia * kw["scale"]
                )
            src = RotatingPayloadTorque((payload,))
        sources[f"{spec.name}" if spec.name not in sources else f"{spec.name}-{i}"] = src
    if not sources:
        return None
    if len(sources) == 1:
        return next(iter(sources.values()))
    return SumOfDisturbances(sources)


def build_plant(
    spec: SpacecraftSpec,
    disturbances: Sequence[DisturbanceSpec] | DisturbanceSpec = (),
    true_inertia: np.ndarray | None = None,
    momentum_management: Any = None,
    orbit: Any = None,
) -> Any:
    """The :class:`spacecraft.plant.Spacecraft` of ``spec`` with ``disturbances``; its inertia is
    ``true_inertia`` when given (model uncertainty), else the nominal ``spec.J``.
    ``momentum_management``: the plant's momentum-management object (e.g.
    :class:`spacecraft.momentum.CrossProductDumping`, see
    :meth:`benchmarks.scenarios.MomentumManagementSpec.build`) or ``None``. ``orbit``: the
    scenario's :class:`spacecraft.orbit.CircularOrbit` (or ``None``), flown by the environment
    torques (:func:`build_disturbance`)."""
    from spacecraft.plant import Spacecraft
    from spacecraft.rigid_body import RigidBody

    _need(spec, SpacecraftSpec, "spec")
    if isinstance(disturbances, DisturbanceSpec):
        disturbances = (disturbances,)
    if isinstance(disturbances, str) or not isinstance(disturbances, Iterable):
        raise ValueError(
            f"disturbances: expected a DisturbanceSpec or a sequence of them, got {disturbances!r}"
        )
    disturbances = tuple(disturbances)
    for i, d in enumerate(disturbances):
        _need(d, DisturbanceSpec, f"disturbances[{i}]")
    J = spec.J if true_inertia is None else check_inertia(true_inertia, "true_inertia")
    return Spacecraft(
        body=RigidBody(J),
        actuator=build_actuator(spec, J),
        disturbance=build_disturbance(tuple(disturbances), J, orbit=orbit),
        momentum_management=momentum_management,
    )


def build_reference(spec: ReferenceSpec | Scenario) -> Callable[[float], AttitudeReference]:
    """Reference trajectory of a :class:`ReferenceSpec` (or of a scenario's; an
    ``earth-pointing`` reference of a scenario with an ``orbit`` follows that orbit's plane at
    the reference's rate ``n``)."""
    orbit_spec = None
    if isinstance(spec, Scenario):
        orbit_spec = spec.orbit
        spec = spec.reference
    _need(spec, ReferenceSpec, "spec")
    if spec.kind == "constant":
        from liecontrol.control import ConstantAttitude

        return ConstantAttitude(spec.R_d)
    if spec.kind == "earth-pointing":
        from spacecraft.orbit import CircularOrbit, EarthPointingReference

        if orbit_spec is None:
            return EarthPointingReference(CircularOrbit(n=spec.n), offset=spec.R_d)
        orbit = dataclasses.replace(orbit_spec.circular_orbit(), n=spec.n)
        return EarthPointingReference(orbit, offset=spec.R_d)
    if spec.kind == "eigenaxis-profile":
        from liecontrol.control.slew_profile import EigenaxisSlewProfile
        from liecontrol.lie import so3

        R_t = spec.R_d
        return EigenaxisSlewProfile(
            R_t @ so3.exp(np.array(spec.slew_rotvec)),
            R_t,
            max_rate=spec.max_rate,
            max_accel=spec.max_accel,
            max_jerk=spec.max_jerk,
        )
    return ConstantRateReference(spec.R_d, np.array(spec.rate))


class FilteredAttitude:
    """Measurement hook (``simulate(..., measurement=...)``) that runs an attitude filter per
    spacecraft between the sensors and the controller: at each control sample it predicts
    over the time since the last sample with the mean of the gyro readings at its two ends
    (the trapezoidal rule: exact for a rate that varies linearly over the step, as it does
    under a held torque, where the end reading alone is off by α·Δt/2 and the bias estimate
    absorbs that during a slew) and updates with the star tracker's roll/pitch/yaw (a held
    output — an outage, a slower tracker — or one flagged invalid is not used); the controller
    gets ``R(q̂)`` and ``ω̃ − b̂``.

    The filter (:class:`liecontrol.estimation.MEKF` or
    :class:`liecontrol.estimation.ManifoldUKF`) runs on
    :class:`liecontrol.estimation.GyroAttitudeModel` (state: attitude quaternion and gyro bias;
    Lefferts, Markley & Shuster 1982) with the sensors' noise levels: σ_v, σ_u the gyro's, and
    the tracker's body-frame noise covariance Σ (per-axis or boresight model) seen through the
    Euler angles, ``R = B(z) Σ B(z)ᵀ`` (``GyroAttitudeModel.R_at``). It starts at the first
    star-tracker sample with zero bias and ``P₀ = blockdiag(Σ, σ_b² I₃)``.

    Consistency (:mod:`liecontrol.estimation.consistency`): after every filter step the NEES
    of the attitude error (3 states, against the true attitude handed to the hook) and — with
    ``gyro`` — of attitude and bias (6 states, against the gyro's true bias), and at every
    star-tracker update the NIS and whether the χ² gate rejected it, are logged per spacecraft;
    :meth:`consistency` summarises them as run metrics.

    Args:
        spec: the scenario's :class:`~benchmarks.scenarios.SensorSpec` (``estimator`` ``"mekf"``
            or ``"ukf"``).
        attitude, rate: sensor names in ``simulate(..., sensors=...)``.
        gyro: the simulated :class:`spacecraft.sensors.RateGyro` (its ``state.bias`` is the
            truth of the bias NEES), or ``None`` (attitude NEES only).
    """

    def __init__(
        self,
        spec: SensorSpec,
        attitude: str = "star_tracker",
        rate: str = "gyro",
        gyro: Any = None,
    ):
        _need(spec, SensorSpec, "spec")
        for name, v in (("attitude", attitude), ("rate", rate)):
            if not isinstance(v, str) or not v.isidentifier():
                raise ValueError(f"{name}: expected a sensor name (an identifier), got {v!r}")
        if spec.estimator not in ("mekf", "ukf"):
            raise ValueError(f"spec: estimator must be 'mekf' or 'ukf', got {spec.estimator!r}")
        if gyro is not None and not (
            callable(getattr(gyro, "measure", None)) and hasattr(gyro, "state")
        ):
            raise ValueError(
                f"gyro: expected a rate gyro with a bias state (spacecraft.sensors.RateGyro) or "
                f"None, got {type(gyro).__name__}"
            )
        self.spec = spec
        self.attitude, self.rate = attitude, rate
        self.gyro = gyro
        self._filters: list[Any] = []
        self._t_last: float | None = None
        self._z_last: np.ndarray | None = None
        self._w_last: np.ndarray | None = None
        self._log: list[dict[str, list[float]]] = []

    def required(self) -> tuple[str, ...]:
        return (self.attitude, self.rate)

    def reset(self, t0: float, batch_size: int) -> None:
        self._filters = []
        self._t_last = None
        self._z_last = None
        self._w_last = None
        self._log = [
            {"nees": [], "nees_full": [], "nis": [], "gated": [], "t": [], "err": []}
            for _ in range(batch_size)
        ]

    def tracker_covariance(self) -> np.ndarray:
        """Σ (3×3) [rad²] of the star tracker's body-frame noise rotation (per-axis σ² I₃ or
        the boresight model σ_c²(I − bbᵀ) + σ_b² bbᵀ), floored at (1e-7 rad)² per axis so the
        filter's noise covariance stays positive definite for a noiseless sensor."""
        sp = self.spec
        if sp.cross_boresight_arcsec is not None or sp.boresight_arcsec is not None:
            sc = sp.arcsec_to_rad(sp.cross_boresight_arcsec) or 0.0
            sb = sp.arcsec_to_rad(sp.boresight_arcsec) or 0.0
            b = np.asarray(sp.boresight, dtype=np.float64)
            bb = np.outer(b, b)
            S = sc**2 * (np.eye(3) - bb) + sb**2 * bb
        else:
            S = sp.attitude_noise_rad**2 * np.eye(3)
        return S + 1e-14 * np.eye(3)

    def _model(self) -> Any:
        from liecontrol.estimation import GyroAttitudeModel

        S = self.tracker_covariance()
        return GyroAttitudeModel(
            sigma_v=max(self.spec.gyro_noise_density, 1e-9),
            sigma_u=self.spec.gyro_bias_rw,
            sigma_z=np.full(3, np.sqrt(np.max(np.diag(S)))),
            sigma_body=S,
        )

    def __call__(self, t: float, outputs: Any, truth: AttitudeState) -> AttitudeState:
        from liecontrol.charts import quaternion as quat
        from liecontrol.estimation import euler_rpy_from_quaternion

        q_meas = np.asarray(outputs[self.attitude], dtype=np.float64)  # (B, 4) scalar-first
        w_meas = np.asarray(outputs[self.rate], dtype=np.float64)  # (B, 3)
        valid = outputs.get(self.attitude + "_valid")  # a TimedSensor's flag (None: always)
        z = euler_rpy_from_quaternion(q_meas)
        B = q_meas.shape[0]
        if len(self._log) != B:
            self.reset(float(t), B)
        if not self._filters:
            model = self._model()
            P0 = self._initial_covariance(model)
            cls = self._filter_class()
            self._filters = [
                cls(model, np.concatenate([q_meas[b], np.zeros(3)]), P0) for b in range(B)
            ]
        else:
            dt = float(t) - float(self._t_last)
            w_mid = w_meas if self._w_last is None else 0.5 * (self._w_last + w_meas)
            # a star-tracker sample held over several control samples (or through an outage of
            # that spacecraft's tracker) is used once
            for b, f in enumerate(self._filters):
                if dt > 0.0:
                    f.predict(w_mid[b], dt)
                fresh = self._z_last is None or not np.array_equal(z[b], self._z_last[b])
                if fresh and (valid is None or bool(valid[b])):
                    accepted = f.update(z[b])
                    nis = f.diagnostics["nis"]
                    if np.isfinite(nis):
                        self._log[b]["nis"].append(float(nis))
                        self._log[b]["gated"].append(0.0 if accepted else 1.0)
        self._t_last = float(t)
        self._z_last = z
        self._w_last = w_meas.copy()
        xs = np.stack([f.x for f in self._filters])
        R = quat.to_matrix(xs[:, :4] / np.linalg.norm(xs[:, :4], axis=-1, keepdims=True))
        self._log_errors(float(t), truth, R, xs[:, 4:])
        return AttitudeState(
            R=R, omega=w_meas - xs[:, 4:], h=truth.h, actuator_state=truth.actuator_state
        )

    def fused_hook(self) -> Any:
        """This hook for the simulator's compiled loop
        (:class:`spacecraft._fused_sensors.EstimatorHook`): both filters have kernels, the
        MEKF (:mod:`liecontrol._kernels.mekf`) and the UKF (:mod:`liecontrol._kernels.ukf`,
        with the filter's default unscented weights)."""
        from spacecraft._fused_sensors import EstimatorHook

        model = self._model()
        P0 = self._initial_covariance(model)
        probe = self._filter_class()(model, np.r_[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], P0)
        w = getattr(probe, "weights", None)
        return EstimatorHook(
            self.attitude, self.rate, float(model.sigma_v), float(model.sigma_u),
            np.array(model.sigma_body), P0, float(probe.gate_threshold),
            int(probe.gate_max_consecutive), self.gyro, kind=self.spec.estimator,
            weights=None if w is None else (float(w.gamma), w.Wm.copy(), w.Wc.copy()),
        )  # fmt: skip

    def _filter_class(self) -> Any:
        """The spec's filter class (:class:`~liecontrol.estimation.MEKF` or
        :class:`~liecontrol.estimation.ManifoldUKF`)."""
        from liecontrol.estimation import MEKF, ManifoldUKF

        return MEKF if self.spec.estimator == "mekf" else ManifoldUKF

    def fused_finish(
        self, t_last: float, x: np.ndarray, P: np.ndarray, z_last: np.ndarray,
        w_last: np.ndarray, gated_run: np.ndarray, logs: list[dict[str, list[float]]],
    ) -> None:  # fmt: skip
        """After a compiled run: the filters, the last sample and the consistency log as the
        Python loop leaves them (:meth:`fused_hook`)."""
        cls = self._filter_class()
        model = self._model()
        self._filters = []
        for b in range(x.shape[0]):
            f = cls(model, x[b], P[b])
            f._x, f._P = x[b].copy(), P[b].copy()
            f._gated_run = int(gated_run[b])
            self._filters.append(f)
        self._t_last = t_last
        self._z_last = z_last
        self._w_last = w_last
        self._log = logs

    def _initial_covariance(self, model: Any) -> np.ndarray:
        """P₀ = blockdiag(Σ, σ_b² I₃): the first estimate is the tracker's output (its error
        is the tracker noise Σ); σ_b, the initial bias uncertainty, is 10× the largest
        configured bias, at least 1e-5 rad/s."""
        sb = max(10.0 * float(np.max(np.abs(self.spec.gyro_bias))), 1e-5)
        P0 = np.zeros((6, 6))
        P0[:3, :3] = model.sigma_body
        P0[3:, 3:] = sb**2 * np.eye(3)
        return P0

    def _log_errors(
        self, t: float, truth: AttitudeState, R_hat: np.ndarray, b_hat: np.ndarray
    ) -> None:
        """Append each filter's attitude error angle and NEES against the true attitude (and
        the gyro's true bias): the error is the filters' ``x_true ⊟ x̂``, body-frame
        ``Log(R̂ᵀR)`` and ``b − b̂``."""
        from liecontrol.lie import so3

        E = np.swapaxes(R_hat, -1, -2) @ np.asarray(truth.R, dtype=np.float64)
        dtheta = so3.log_unchecked(E)
        st = getattr(self.gyro, "state", None)
        db = None if st is None else np.asarray(st.bias, dtype=np.float64) - b_hat
        for b, f in enumerate(self._filters):
            P = f.P
            log = self._log[b]
            log["t"].append(t)
            log["err"].append(float(np.linalg.norm(dtheta[b])))
            log["nees"].append(float(dtheta[b] @ np.linalg.solve(P[:3, :3], dtheta[b])))
            if db is not None:
                e = np.concatenate([dtheta[b], db[b]])
                log["nees_full"].append(float(e @ np.linalg.solve(P, e)))

    def consistency(self, b: int, since: float | None = None) -> dict[str, float]:
        """Run metrics of spacecraft ``b``'s filter consistency (module
        :mod:`liecontrol.estimation.consistency`; NaN where there were no samples):
        ``estimation_error_max_deg``, the largest attitude estimation error angle at or after
        ``since`` (the pointing interval: the floor the pointing error cannot beat; NaN
        without ``since``),
        ``nees_mean`` (attitude, 3 states) with ``nees_in_bounds`` (1.0 when inside the
        two-sided 95 % χ² region of its time average, over the effective number of independent
        samples, ``nees_effective_samples``) and ``nees_in_bounds_fraction`` (share of samples
        inside χ²₃'s two-sided 95 % interval), ``nees_full_mean`` (attitude and bias, 6
        states), ``nis_mean`` with ``nis_in_bounds`` (over the K updates: innovations are white),
        ``filter_updates`` and ``filter_rejections`` (updates the χ² gate rejected)."""
        from liecontrol.estimation.consistency import (
            effective_sample_size,
            in_interval_fraction,
            time_average_test,
        )

        log = self._log[b]
        nan = float("nan")
        out: dict[str, float] = {}
        for key, n, corr in (("nees", 3, True), ("nees_full", 6, True), ("nis", 3, False)):
            s = log[key]
            if s:
                m, _, _, inside = time_average_test(s, n, correlated=corr)
                out[f"{key}_mean"] = m
                if key != "nees_full":
                    out[f"{key}_in_bounds"] = 1.0 if inside else 0.0
            else:
                out[f"{key}_mean"] = nan
                if key != "nees_full":
                    out[f"{key}_in_bounds"] = nan
        out["nees_in_bounds_fraction"] = (
            in_interval_fraction(log["nees"], 3) if log["nees"] else nan
        )
        out["nees_effective_samples"] = effective_sample_size(log["nees"]) if log["nees"] else nan
        out["filter_updates"] = float(len(log["gated"]))
        out["filter_rejections"] = float(sum(log["gated"]))
        tt, err = np.asarray(log["t"]), np.asarray(log["err"])
        if since is None:
            sel = np.zeros(tt.shape, dtype=bool)
        else:
            sel = tt >= float(since) - 1e-9 * max(1.0, abs(float(since)))
        out["estimation_error_max_deg"] = float(np.degrees(err[sel].max())) if sel.any() else nan
        return out


def _check_stack(items: Any, name: str, sizes: Any) -> tuple[list, list[int]]:
    """``(items, sizes)`` of a stacked batch as lists, validated: non-empty, one positive
    integer size per item (messages name ``name`` or ``sizes``)."""
    if isinstance(items, str) or not isinstance(items, Iterable):
        raise ValueError(f"{name}: expected a sequence, got {type(items).__name__}")
    items = list(items)
    if isinstance(sizes, str) or not isinstance(sizes, Iterable):
        raise ValueError(f"sizes: expected a sequence of batch sizes, got {sizes!r}")
    sizes = [as_int(n, "sizes", 1) for n in np.asarray(sizes, dtype=object).ravel()]
    if not items or len(sizes) != len(items):
        raise ValueError(
            f"sizes: expected one batch size per entry of {name} ({len(items)}), got {len(sizes)}"
        )
    if sum(sizes) > 10**7:
        raise ValueError(f"sizes: a stacked batch of {sum(sizes)} spacecraft is too large")
    return items, sizes


def build_sensors(spec: SensorSpec) -> tuple[dict[str, Any], Any, np.random.Generator]:
    """``(sensors, measurement hook, rng)`` for ``simulate`` from a
    :class:`~benchmarks.scenarios.SensorSpec`: a quaternion star tracker and a rate gyro both
    sampled every ``spec.period``; the hook is :class:`spacecraft.simulator.StarTrackerGyro`
    (raw measurements) or :class:`FilteredAttitude`; ``rng = default_rng(spec.seed)``."""
    from spacecraft.sensors import RateGyro, StarTracker, TimedSensor
    from spacecraft.simulator import StarTrackerGyro

    _need(spec, SensorSpec, "spec")
    boresight_model = spec.cross_boresight_arcsec is not None or spec.boresight_arcsec is not None
    tracker: Any = StarTracker(
        noise_std=0.0 if boresight_model else spec.attitude_noise_rad,
        output="quaternion",
        period=spec.period,
        boresight=np.array(spec.boresight),
        cross_boresight_std=spec.arcsec_to_rad(spec.cross_boresight_arcsec),
        boresight_std=spec.arcsec_to_rad(spec.boresight_arcsec),
    )
    if spec.star_tracker_latency > 0 or spec.star_tracker_outages or spec.outage_rate > 0:
        tracker = TimedSensor(
            tracker,
            latency=spec.star_tracker_latency,
            outages=spec.star_tracker_outages,
            outage_rate=spec.outage_rate,
            outage_duration=spec.outage_duration,
        )
    sensors = {
        "star_tracker": tracker,
        "gyro": RateGyro(
            noise_density=spec.gyro_noise_density,
            bias_rw_std=spec.gyro_bias_rw,
            initial_bias=np.array(spec.gyro_bias),
            period=spec.period,
            scale_factor=np.array(spec.gyro_scale_factor),
            misalignment=np.array(spec.gyro_misalignment),
            quantization=spec.gyro_quantization,
            bandwidth=spec.gyro_bandwidth,
        ),
    }
    hook: Any = (
        StarTrackerGyro()
        if spec.estimator == "none"
        else FilteredAttitude(spec, gyro=sensors["gyro"])
    )
    return sensors, hook, np.random.default_rng(spec.seed)


def initial_state(scenario: Scenario, t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``(R₀, ω₀)`` of an attitude scenario: ``R₀ = R_d(t₀) exp(initial_rotvec^)``,
    ``ω₀ = initial_rate + R₀ᵀR_d(t₀) ω_d(t₀)`` (the scenario stores errors)."""
    _need(scenario, Scenario, "scenario")
    t0 = as_scalar(t0, "t0")
    ref = build_reference(scenario)(t0)
    R_d = np.asarray(ref.R_d, dtype=np.float64)
    R0 = R_d @ scenario.error0
    w0 = scenario.omega0 + R0.T @ R_d @ np.asarray(ref.omega_d, dtype=np.float64)
    return R0, w0


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class RunOutcome:
    """Result of one (scenario, controller) pair.

    Attributes:
        scenario, controller: names.
        status: ``"ok"``, ``"failed"`` or ``"n/a"`` (the controller does not apply).
        error: exception text when failed; the reason when n/a.
        metrics: :meth:`benchmarks.metrics.Metrics.as_dict` plus ``controller_time_us`` (mean
            wall time of ``command()`` per spacecraft per control step [µs]) and
            ``sim_wall_time_s`` (wall time of the simulation this pair was batched in); SE(3)
            runs add ``final_position_error_m``, ``peak_force_N``, ``position_settling_time_s``.
        series: decimated time series for the figures: ``t`` [s], ``error_deg``,
            ``rate_deg_s`` (‖ω − RᵀR_dω_d‖), ``torque_Nm`` (‖u‖); SGCMG: ``gimbal_rate_rad_s``
            (max_i |δ̇_i|), ``singularity`` (m); wheels: ``wheel_speed_frac``
            (max_i |Ω_i|/Ω_max), ``momentum_Nms`` (‖h‖); SE(3): ``position_error_m``,
            ``force_N``; empty when nothing was logged.
        verdict: :func:`benchmarks.metrics.judge`'s verdict (``success``, ``degraded``,
            ``failed``, ``error``, ``not-applicable``); ``""`` until judged (:func:`run_suite`
            judges every outcome).
        flags: the judge's flags (``actuator-saturated``, ``unwound`` ...).
        histories: with ``run_suite(..., keep_histories=True)``, the full logged histories
            (:func:`benchmarks.results_file.history_arrays`: ``t``, ``R`` (K, 3, 3), ...),
            written to one file by :func:`benchmarks.results_file.write_histories`; else empty.
        member: the dispersion member (0: the nominal scenario; :mod:`benchmarks.dispersion`).
    """

    scenario: str
    controller: str
    status: str
    error: str | None = None
    metrics: dict[str, Any] = field(default_factory=dict)
    series: dict[str, np.ndarray] = field(default_factory=dict)
    verdict: str = ""
    flags: tuple[str, ...] = ()
    histories: dict[str, np.ndarray] = field(default_factory=dict)
    member: int = 0


def with_verdict(outcome: RunOutcome, scenario: Scenario) -> RunOutcome:
    """``outcome`` with :attr:`RunOutcome.verdict`/``flags`` set by
    :func:`benchmarks.metrics.judge` against ``scenario``'s tolerances."""
    import dataclasses

    verdict, flags = judge(scenario, outcome.metrics, status=outcome.status, error=outcome.error)
    return dataclasses.replace(outcome, verdict=verdict, flags=flags)


@dataclass(frozen=True)
class SuiteResult:
    """All outcomes of a suite run, in scenario-major order."""

    suite: str
    scenarios: tuple[Scenario, ...]
    controllers: tuple[str, ...]
    outcomes: tuple[RunOutcome, ...]
    wall_time_s: float
    executor: str = "serial"
    descriptions: dict[str, str] = field(default_factory=dict)
    gain_rule: GainRule | None = None  # the spec the run was tuned to (None: the default)
    members: int = 1
    member_outcomes: tuple[RunOutcome, ...] = ()
    cells: dict[tuple[str, str], CellSummary] = field(default_factory=dict)
    # (scenario, controller) → {ω_n factor: the nominal run meets every requirement; None: the
    # controller cannot be tuned to that bandwidth} (:func:`bandwidth_sensitivity`)
    sensitivity: dict[tuple[str, str], dict[float, bool | None]] = field(default_factory=dict)
    # representative → controllers whose runs coincide with it on every scenario (set by
    # :func:`benchmarks.ranking_report.dealiased` for the report's tables and figures)
    aliases: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def display_name(self, controller: str) -> str:
        """``controller`` with the aliases it stands for, e.g. ``"a (= b)"``."""
        same = self.aliases.get(controller, ())
        return f"{controller} (= {', '.join(same)})" if same else controller

    def outcome(self, scenario: str, controller: str) -> RunOutcome:
        """The nominal (member 0) outcome of a pair."""
        for o in self.outcomes:
            if o.scenario == scenario and o.controller == controller:
                return o
        raise KeyError((scenario, controller))

    def cell(self, scenario: str, controller: str) -> CellSummary:
        """The pair's :class:`benchmarks.ranking.CellSummary` over its members."""
        return self.cells[(scenario, controller)]

    def member_runs(self, scenario: str, controller: str) -> list[RunOutcome]:
        """Every member's outcome of a pair, member 0 first."""
        rest = [
            o for o in self.member_outcomes if o.scenario == scenario and o.controller == controller
        ]
        return [self.outcome(scenario, controller), *sorted(rest, key=lambda o: o.member)]

    @property
    def n_failed(self) -> int:
        return sum(o.status == "failed" for o in self.outcomes)

    @property
    def n_ok(self) -> int:
        return sum(o.status == "ok" for o in self.outcomes)


def _decimate(K: int) -> np.ndarray:
    return np.unique(np.linspace(0, K - 1, min(K, MAX_SERIES_POINTS)).astype(int))


def _series(result: Any, b: int, wheel_max_speed: float | None = None) -> dict[str, np.ndarray]:
    """Decimated per-spacecraft series for the figures."""
    t = np.asarray(result.t)
    K = t.shape[0]
    if K == 0:
        return {}
    idx = _decimate(K)
    R = np.asarray(result.R)[idx, b]
    R_d = np.broadcast_to(np.asarray(result.R_d), np.asarray(result.R).shape)[idx, b]
    w = np.asarray(result.omega)[idx, b]
    w_d = np.broadcast_to(np.asarray(result.omega_d), np.asarray(result.omega).shape)[idx, b]
    out = {
        "t": t[idx],
        "error_deg": np.rad2deg(error_angle(R, R_d)),
        "rate_deg_s": np.rad2deg(np.linalg.norm(rate_error(R, w, R_d, w_d), axis=-1)),
        "torque_Nm": np.linalg.norm(np.asarray(result.u)[idx, b], axis=-1),
    }
    act = getattr(result, "actuator", None) or {}
    if "delta_dot" in act:
        out["gimbal_rate_rad_s"] = np.abs(np.asarray(act["delta_dot"])[idx, b]).max(axis=-1)
    if "singularity" in act:
        out["singularity"] = np.asarray(act["singularity"])[idx, b]
    if "wheel_speed" in act and wheel_max_speed is not None:
        ws = np.abs(np.asarray(act["wheel_speed"])[idx, b])
        out["wheel_speed_frac"] = (ws / np.asarray(wheel_max_speed, dtype=np.float64)).max(-1)
    if "wheel_speed" in act and "h" in act:
        out["momentum_Nms"] = np.linalg.norm(np.asarray(act["h"])[idx, b], axis=-1)
    return out


# --------------------------------------------------------------------------- one task


@dataclass(frozen=True)
class GroupTask:
    """Payload of one executor task: pairs sharing a batch key, and the controllers' metadata
    (shipped with the task so run-time registrations reach remote workers; factories that the
    standard pickle cannot serialise — closures, lambdas — travel by value with cloudpickle)."""

    pairs: tuple[tuple[Scenario, str], ...]
    infos: dict[str, ControllerInfo]
    rule: GainRule | None = None  # closed-loop spec the factories tune to (None: default)
    histories: bool = False  # keep the full logged histories in the outcomes
    backend: str = "numba"  # simulate's backend for the batches it supports (run_suite)

    def __reduce__(self) -> tuple:
        return (
            _rebuild_task,
            (self.pairs, pack_infos(self.infos), self.rule, self.histories, self.backend),
        )


def pack_infos(infos: dict[str, ControllerInfo]) -> dict[str, tuple[str, Any]]:
    """Picklable form of controller metadata: ``("obj", info)`` when pickle handles it,
    ``("cloudpickle", bytes)`` otherwise, ``("name", name)`` as a last resort (the worker's own
    registry is used)."""
    import pickle

    out: dict[str, tuple[str, Any]] = {}
    for name, info in infos.items():
        with contextlib.suppress(Exception):  # closures, lambdas, local classes: next route
            pickle.dumps(info)
            out[name] = ("obj", info)
            continue
        try:
            import cloudpickle

            out[name] = ("cloudpickle", cloudpickle.dumps(info))
        except Exception:  # noqa: BLE001 - not serialisable at all
            out[name] = ("name", name)
    return out


def unpack_infos(packed: dict[str, tuple[str, Any]]) -> dict[str, ControllerInfo]:
    """Inverse of :func:`pack_infos`."""
    out = {}
    for name, (kind, val) in packed.items():
        if kind == "obj":
            out[name] = val
        elif kind == "cloudpickle":
            import cloudpickle

            out[name] = cloudpickle.loads(val)
        else:
            out[name] = get_controller(val)
    return out


def _rebuild_task(
    pairs: tuple,
    packed: dict[str, tuple[str, Any]],
    rule: GainRule | None = None,
    histories: bool = False,
    backend: str = "numba",
) -> GroupTask:
    return GroupTask(pairs, unpack_infos(packed), rule, histories, backend)


def _members(
    pairs: Sequence[tuple[Scenario, str]], infos: dict[str, ControllerInfo]
) -> list[tuple[str, list[int]]]:
    """Group pair indices into controller instances: one per batched controller, one per pair
    otherwise. Returns ``[(controller name, [pair indices])]`` in spacecraft order."""
    out: list[tuple[str, list[int]]] = []
    by_ctrl: dict[str, list[int]] = {}
    for i, (_, c) in enumerate(pairs):
        by_ctrl.setdefault(c, []).append(i)
    for c, idx in by_ctrl.items():
        if infos[c].batched:
            out.append((c, idx))
        else:
            out.extend((c, [i]) for i in idx)
    return out


def _make_member(
    info: ControllerInfo,
    scenarios: Sequence[Scenario],
    ref: Any,
    rule: GainRule | None = None,
) -> TimedController:
    sc0 = scenarios[0]
    ctx = ControllerContext(
        spacecraft=sc0.spacecraft,
        control_period=info.control_period or sc0.control_period or sc0.dt,
        batch_size=len(scenarios),
        q_hint=np.stack([s.initial_quaternion for s in scenarios]),
        reference=ref,
        rule=rule or DEFAULT_GAIN_RULE,
        keep_out=sc0.keep_out,
        keep_in=sc0.keep_in,
    )
    ctrl = info.factory(ctx)
    timed = TimedController(ctrl)
    base = sc0.control_period or sc0.dt
    if info.control_period is not None and info.control_period > base * (1 + 1e-9):
        return HeldController(timed, info.control_period)  # type: ignore[return-value]
    return timed


def _log_every(s: Scenario) -> int:
    """Log once per control period (the command changes only there), at most every 0.5 s."""
    period = min(s.control_period or s.dt, max(0.5, s.dt))
    return max(1, int(round(period / s.dt)))


def _simulate_attitude(
    pairs: Sequence[tuple[Scenario, str]],
    infos: dict[str, ControllerInfo],
    rule: GainRule | None = None,
    histories: bool = False,
    backend: str = "numba",
) -> list[RunOutcome]:
    """Simulate ``pairs`` (same :meth:`Scenario.batch_key`) as one batch; raises on failure.
    ``backend="jax"``: through :func:`spacecraft.simulate`'s JAX route where the batch's
    configuration has one (one controller instance, no sensors), else the numba loop and one
    log line (logger ``benchmarks.runner``) saying why."""
    from spacecraft.simulator import simulate

    sc0 = pairs[0][0]
    mm = sc0.momentum_management
    groups = _members(pairs, infos)
    order = [i for _, idx in groups for i in idx]
    # drawn members of one batch may differ in their true inertia: one per spacecraft then
    inertias = [pairs[i][0].true_inertia for i in order]
    same = all(np.array_equal(inertias[0], J) for J in inertias[1:])
    plant = build_plant(
        sc0.spacecraft,
        sc0.disturbances,
        inertias[0] if same else np.stack(inertias),
        # the reference is the attitude profile the magnetorquers' pre-run feasibility check uses
        None if mm is None else mm.build(sc0.orbit, build_reference(sc0)),
        orbit=None if sc0.orbit is None else sc0.orbit.circular_orbit(),
    )
    if sc0.faults:  # one batch shares its faults (Scenario.batch_key)
        from spacecraft.faults import with_faults

        # steering told the lost units only: at the fault time ("oracle") or from the residual
        # detector's isolation ("detector", the default)
        plant = with_faults(plant, sc0.faults, reconfiguration=sc0.reconfiguration)
    members, refs, sizes = [], [], []
    for c, idx in groups:
        scs = [pairs[i][0] for i in idx]
        ref_list = [build_reference(s) for s in scs]
        ref = (
            ref_list[0]
            if len(ref_list) == 1
            else StackedReference(tuple(ref_list), (1,) * len(ref_list))
        )
        members.append(_make_member(infos[c], scs, ref, rule))
        refs.extend(ref_list)
        sizes.append(len(idx))
    # one controller instance with a compiled kernel flies the fused loop (the timing proxy and
    # the stack would keep the Python loop); its runs then have no per-call time in the log —
    # the report measures controller cost apart (benchmarks.controller_cost)
    only = members[0] if len(members) == 1 else None
    fusable = isinstance(only, TimedController) and callable(
        getattr(only.inner, "fused_kernel", None)
    )
    ctrl = only.inner if fusable else StackedController(members, sizes)
    ref = StackedReference(tuple(refs), (1,) * len(refs))
    starts = [initial_state(pairs[i][0]) for i in order]
    state = plant.initial_state(np.stack([r for r, _ in starts]), np.stack([w for _, w in starts]))
    sense: dict[str, Any] = {}
    if sc0.sensors is not None:
        sensors, hook, rng = build_sensors(sc0.sensors)
        sense = {"sensors": sensors, "measurement": hook, "rng": rng}
        if sc0.sensors.compute_delay > 0:
            sense["compute_delay"] = sc0.sensors.compute_delay
    route = {}
    run_ctrl = ctrl
    if backend == "jax":
        # one controller (its law, not the timing proxy) flies the JAX route, with or without
        # a compiled kernel: the route asks it for its array law
        single = only.inner if isinstance(only, TimedController) else None
        why = _jax_refusal(single, sense)
        if why is None:
            route = {"backend": "jax"}
            if len({repr(pairs[i][0].reference) for i in order}) == 1:
                # one reference for the batch (members differ in start, rate, inertia): one
                # set of samples; else each member's own, through vmap with its state
                ref = build_reference(pairs[order[0]][0])
            run_ctrl = single
        else:
            _LOG.info("backend='jax': %s; %s ran on the numba loop", why, _group_name(pairs))
    t_start = time.perf_counter()
    kw = dict(t_final=sc0.duration, dt=sc0.dt, control_period=sc0.control_period,
              log_every=_log_every(sc0), **sense)  # fmt: skip
    try:
        result = simulate(plant, run_ctrl, ref, state, **kw, **route)
    except ValueError as exc:
        if not route:
            raise
        # a part the JAX route does not fly (it names it): the numba loop runs the batch
        _LOG.info("backend='jax': %s; %s ran on the numba loop", exc, _group_name(pairs))
        ref = StackedReference(tuple(refs), (1,) * len(refs))
        result = simulate(plant, ctrl, ref, state, **kw)
    wall = time.perf_counter() - t_start
    sp = sc0.spacecraft
    limits = {
        "gimbal_rate_limit": sp.gimbal_rate_limit if sp.actuator == "sgcmg" else None,
        "wheel_max_speed": sp.wheel_max_speed if sp.actuator == "wheels" else None,
    }
    # the settling threshold is each scenario's attitude tolerance (one pass per distinct one)
    by_tol = {
        (tol, win): compute_metrics(
            result,
            settle_threshold_deg=tol,
            keep_out=sc0.keep_out,  # one batch shares its cones (Scenario.batch_key)
            keep_in=sc0.keep_in,
            momentum_actuator=plant.actuator,
            rpe_window_s=win,
            **limits,
        )
        for tol, win in {(s.attitude_tolerance_deg, pointing_window(s)) for s, _ in pairs}
    }
    outcomes: dict[int, RunOutcome] = {}
    b = 0
    for m, (c, idx) in zip(members, groups, strict=True):
        timed = m.inner if isinstance(m, HeldController) else m
        per_sc = timed.mean_time_per_call / len(idx)
        for i in idx:
            s_i = pairs[i][0]
            mm = by_tol[(s_i.attitude_tolerance_deg, pointing_window(s_i))].as_dict(b)
            mm["controller_time_us"] = 1e6 * per_sc
            mm["sim_wall_time_s"] = wall
            if s_i.momentum_management is not None:
                mm.update(_momentum_management_metrics(result, plant.actuator, s_i, b))
            if s_i.faults:
                mm.update(_fault_detection_metrics(plant.actuator, s_i, b))
            if callable(getattr(sense.get("measurement"), "consistency", None)):
                # filter NEES/NIS and the estimation error over the pointing interval
                mm.update(sense["measurement"].consistency(b, since=0.9 * s_i.duration))
            series = _series(result, b, limits["wheel_max_speed"])
            hist = history_arrays(result, b) if histories else {}
            outcomes[i] = RunOutcome(
                s_i.name, c, "ok", None, mm, series, histories=hist, member=s_i.member
            )
            b += 1
    return [outcomes[i] for i in range(len(pairs))]


def _group_name(pairs: Sequence[tuple[Scenario, str]]) -> str:
    names = sorted({f"{s.name} × {c}" for s, c in pairs})
    return ", ".join(names[:3]) + (f" (+{len(names) - 3})" if len(names) > 3 else "")


def _jax_refusal(single: Any, sense: dict) -> str | None:
    """Why a batch cannot take the JAX route (``None`` when it can, as far as the runner can
    tell: the plant and controller are checked by :func:`spacecraft.differentiable.closed_loop`,
    which names what it does not fly). ``single``: the batch's one controller, or ``None``."""
    if single is None:
        return "the batch stacks several controllers"
    if sense:
        return "sensors in the loop"
    return None


def _momentum_management_metrics(
    result: Any, actuator: Any, scenario: Scenario, b: int
) -> dict[str, float]:
    """Momentum-management metrics of spacecraft ``b``: ``momentum_growth_per_orbit`` — the
    secular growth per orbit of the stored momentum's envelope fraction
    (:func:`spacecraft.momentum.momentum_growth_per_orbit`, least-squares slope × orbit period)
    from the end of the first orbit (the initial build-up of the cyclic momentum left out) to
    the first sample at :data:`benchmarks.metrics.MOMENTUM_SATURATED_FRACTION` (the fraction
    cannot grow past the envelope: a saturated run would dilute the slope) or the end; when
    that leaves less than an orbit, from the start, and under an orbit still, the chord slope;
    NaN without an orbit or for a run under two orbits. ``propellant_kg`` and
    ``propellant_kg_per_orbit`` of thruster unloading (NaN for the other kinds)."""
    from spacecraft.momentum import momentum_fraction, momentum_growth_per_orbit

    from .metrics import MOMENTUM_SATURATED_FRACTION

    out = {
        "momentum_growth_per_orbit": math.nan,
        "propellant_kg": math.nan,
        "propellant_kg_per_orbit": math.nan,
    }
    t = np.asarray(result.t, dtype=np.float64)
    period = None if scenario.orbit is None else scenario.orbit.period
    act = result.actuator
    key = "delta" if "delta" in act else ("wheel_speed" if "wheel_speed" in act else None)
    inner = getattr(actuator, "inner", actuator)  # a FaultyActuator wraps the cluster
    if period is not None and key is not None and t[-1] - t[0] >= 2.0 * period:
        frac = momentum_fraction(inner, np.asarray(act[key])[:, b : b + 1])[:, 0]
        sat = np.flatnonzero(frac >= MOMENTUM_SATURATED_FRACTION)
        end = int(sat[0]) if sat.size else t.size - 1
        start = int(np.searchsorted(t, t[0] + period))
        if t[end] - t[min(start, end)] < period:
            start = 0
        if t[end] - t[start] >= period:
            growth = momentum_growth_per_orbit(t[start : end + 1], frac[start : end + 1], period)
        else:  # saturated within the first orbit: the chord
            growth = (frac[end] - frac[start]) * period / max(t[end] - t[start], 1e-300)
        out["momentum_growth_per_orbit"] = float(growth)
    if "propellant_kg" in act:
        used = float(np.asarray(act["propellant_kg"])[-1, b])
        out["propellant_kg"] = used
        if period is not None and t[-1] > t[0]:
            out["propellant_kg_per_orbit"] = used * period / (t[-1] - t[0])
    return out


def _fault_detection_metrics(actuator: Any, scenario: Scenario, b: int) -> dict[str, float]:
    """``fault_detection_delay_s`` (first alarm on a faulty unit after the fault minus the fault
    time; NaN: not detected) and ``false_alarms`` (units alarmed without a fault or before it)
    of spacecraft ``b`` from the residual detector of a ``"detector"`` run (NaN for
    ``"oracle"``: no detector)."""
    from spacecraft.faults import fault_detection_report

    times = getattr(actuator, "detection_time", None)
    if times is None or times.shape[0] <= b:
        return {"fault_detection_delay_s": math.nan, "false_alarms": math.nan}
    delay, false_alarms = fault_detection_report(scenario.faults, times[b : b + 1])
    return {"fault_detection_delay_s": float(delay[0]), "false_alarms": float(false_alarms[0])}


def _pose_metrics(
    res: Any,
    attitude_tol_deg: float = 0.1,
    position_tol_m: float = 0.1,
    mass: float | None = None,
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Attitude metrics of the pose log (via a duck-typed attitude log whose actuator reports
    the torque limits' ``saturated`` flags, so ``actuator-saturated`` is judged as on SO(3)) plus
    position ones: final and steady-state (max over the final 10 %) position error, position
    settling time to ``position_tol_m`` (first time after which ‖p − p_d‖ stays below it,
    interpolated as the attitude's; NaN if the last sample is above), peak force, the time with
    a force component at its limit, the range excursion ``max_t ‖p − p_d‖ / ‖p₀ − p_d‖`` and —
    with the chaser's ``mass`` — ΔV = ∫‖F‖/m dt of the delivered force."""

    @dataclass(frozen=True)
    class _AttitudeView:
        t: np.ndarray
        R: np.ndarray
        omega: np.ndarray
        R_d: np.ndarray
        omega_d: np.ndarray
        u: np.ndarray
        actuator: dict = field(default_factory=dict)

    g, g_d = np.asarray(res.g), np.asarray(res.g_d)
    sat = np.asarray(getattr(res, "saturated", np.zeros((len(res.t), 1, 6), dtype=bool)))
    view = _AttitudeView(
        t=np.asarray(res.t),
        R=g[..., :3, :3],
        omega=np.asarray(res.xi)[..., :3],
        R_d=g_d[..., :3, :3],
        omega_d=np.asarray(res.xi_d)[..., :3],
        u=np.asarray(res.wrench)[..., :3],
        actuator={"saturated": sat[..., :3]},
    )
    m = compute_metrics(view, settle_threshold_deg=attitude_tol_deg).as_dict(0)
    t_all = np.asarray(res.t)
    force_sat = sat[..., 3:].reshape(len(t_all), -1).any(axis=-1)
    m["force_saturation_time_s"] = float(np.sum(force_sat[:-1] * np.diff(t_all)))
    # actuator-saturated covers both halves of the wrench
    m["saturation_time_s"] = float(
        np.sum((sat.reshape(len(t_all), -1).any(axis=-1))[:-1] * np.diff(t_all))
    )
    pos = np.asarray(res.position_error)[:, 0]
    t = np.asarray(res.t)
    ts = float(settling_time(t, pos[:, None], position_tol_m)[0])
    win = t >= t[-1] - 0.1 * (t[-1] - t[0]) - 1e-12 * max(abs(t[-1]), 1.0)
    force = np.linalg.norm(np.asarray(res.wrench)[:, 0, 3:], axis=-1)
    m["final_position_error_m"] = float(pos[-1])
    m["steady_position_error_max_m"] = float(pos[win].max())
    m["position_settling_time_s"] = ts
    m["peak_force_N"] = float(force.max())
    m["force_effort_Ns"] = float(trapezoid(force, t))
    m["delta_v_m_s"] = float(trapezoid(force, t)) / mass if mass else float("nan")
    m["max_range_ratio"] = float(pos.max() / pos[0]) if pos[0] > 0 else float("nan")
    idx = _decimate(t.shape[0])
    series = {
        "t": t[idx],
        "error_deg": np.rad2deg(np.asarray(res.attitude_error)[idx, 0]),
        "rate_deg_s": np.rad2deg(
            np.linalg.norm(
                rate_error(*(a[idx, 0] for a in (view.R, view.omega, view.R_d, view.omega_d))),
                axis=-1,
            )
        ),
        "torque_Nm": np.linalg.norm(view.u[idx, 0], axis=-1),
        "position_error_m": pos[idx],
        "force_N": force[idx],
    }
    return m, series


def _timed_pose(inner: Any) -> Any:
    """A :class:`TimedController` that is also a ``PoseController`` (``simulate_pose`` checks)."""
    from liecontrol.control import PoseController

    class TimedPoseController(TimedController, PoseController):
        """The timing proxy, registered as a pose controller (wrench seam)."""

    return TimedPoseController(inner)


def _simulate_pose_pair(
    scenario: Scenario,
    name: str,
    info: ControllerInfo,
    rule: GainRule | None = None,
    histories: bool = False,
) -> RunOutcome:
    from liecontrol.lie import se3, so3
    from spacecraft.orbit import CircularOrbit
    from spacecraft.se3_plant import (
        DockingReference,
        IdealWrenchActuator,
        OrbitingTarget,
        SE3Plant,
        simulate_pose,
    )

    px = scenario.proximity
    plant = SE3Plant(
        px.mass,
        px.J,
        method="rkmk4",
        actuator=IdealWrenchActuator(max_torque=px.max_torque, max_force=px.max_force),
    )
    target = OrbitingTarget(CircularOrbit(n=px.n))
    g_rel = se3.from_rt(so3.exp(np.array(px.dock_rotvec)), np.array(px.dock_position))
    dock = DockingReference(target, g_rel)
    g0, xi0 = dock.offset_state(0.0, np.array([px.initial_rotvec]), np.array([px.initial_position]))
    ctx = ControllerContext(
        spacecraft=scenario.spacecraft,
        control_period=info.control_period or scenario.control_period or scenario.dt,
        batch_size=1,
        reference=dock,
        proximity=px,
        gravity=plant.gravity_wrench,
        rule=rule or DEFAULT_GAIN_RULE,
    )
    timed = _timed_pose(info.factory(ctx))
    t_start = time.perf_counter()
    res = simulate_pose(
        plant,
        timed,
        dock,
        g0,
        xi0,
        t_final=scenario.duration,
        dt=scenario.dt,
        control_period=scenario.control_period,
    )
    wall = time.perf_counter() - t_start
    m, series = _pose_metrics(
        res, scenario.attitude_tolerance_deg, scenario.position_tolerance_m, mass=px.mass
    )
    m["controller_time_us"] = 1e6 * timed.mean_time_per_call
    m["sim_wall_time_s"] = wall
    hist = history_arrays(res, 0) if histories else {}
    return RunOutcome(
        scenario.name, name, "ok", None, m, series, histories=hist, member=scenario.member
    )


def detumble_inputs(scenario: Scenario, law: Any) -> dict[str, Any]:
    """The arguments of :func:`spacecraft.detumble.simulate_detumble` for a detumble
    ``scenario`` flown with ``law`` (a :class:`spacecraft.detumble.DetumbleLaw`): the true
    inertia, the tumble, the run length, the threshold, the orbit, the magnetometer, the step,
    the noise seed and every step logged (the log holds each step's duty-weighted dipole: a
    sparser log could sample only the partly-on steps and understate the peak dipole)."""
    from spacecraft.detumble import Magnetometer

    _need(scenario, Scenario, "scenario")
    det = scenario.detumble
    if det is None:
        raise ValueError(f"scenario: {scenario.name!r} is not a detumble scenario (no detumble)")
    return {
        "J": scenario.true_inertia,
        "law": law,
        "omega0": np.asarray(scenario.initial_rate, dtype=np.float64),
        "t_final": scenario.duration,
        "threshold": det.threshold,
        "orbit": scenario.orbit.circular_orbit(),
        "magnetometer": Magnetometer(noise_std=det.magnetometer_noise, bias=det.magnetometer_bias),
        "dt": scenario.dt,
        "seed": det.seed,
        "log_every": 1,
    }


def detumble_metrics(
    res: Any, J: Any, law: Any, gain: float, b: int = 0
) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """Metrics and figure series of spacecraft ``b`` of a
    :class:`spacecraft.detumble.DetumbleResult` (``benchmarks.metrics.DESCRIPTIONS``):
    ``time_to_detumble_s``, ``initial_rate_deg_s``, ``final_rate_deg_s``,
    ``electrical_energy_J``, ``kinetic_energy_removed_J``, ``peak_dipole_frac`` and
    ``averaged_detumble_time_s``, the time the averaged damping ``gain`` [N·m·s] implies from
    the same tumble (:func:`spacecraft.detumble.averaged_detumble_time`; ``J`` the inertia,
    ``law`` the :class:`~spacecraft.detumble.DetumbleLaw` for its rod limits and duty cycle)."""
    from spacecraft.detumble import averaged_detumble_time

    w = np.asarray(res.omega)[:, b]
    rate = np.rad2deg(np.linalg.norm(w, axis=-1))
    ke = np.asarray(res.kinetic_energy)[:, b]
    m = np.asarray(res.dipole)[:, b]
    avg = averaged_detumble_time(J, gain, w[0], res.threshold, law.duty_cycle)
    # a logged step holds the commanded dipole times its on-fraction, at most this much
    t = np.asarray(res.t)
    dt = float(t[1] - t[0]) if t.size > 1 else law.period
    on = min(law.duty_cycle * max(1.0, round(law.period / dt)), 1.0)
    metrics = {
        "time_to_detumble_s": float(res.time_to_threshold[b]),
        "initial_rate_deg_s": float(rate[0]),
        "final_rate_deg_s": float(rate[-1]),
        "electrical_energy_J": float(res.electrical_energy[b]),
        "kinetic_energy_removed_J": float(ke[0] - ke[-1]),
        "peak_dipole_frac": float((np.abs(m) / law._m_max).max() / on),
        "averaged_detumble_time_s": float(avg),
    }
    idx = _decimate(rate.shape[0])
    series = {
        "t": np.asarray(res.t)[idx],
        "body_rate_deg_s": rate[idx],
        "dipole_Am2": np.linalg.norm(m[idx], axis=-1),
        "kinetic_energy_J": ke[idx],
    }
    return metrics, series


def _simulate_detumble_pair(
    scenario: Scenario,
    name: str,
    info: ControllerInfo,
    rule: GainRule | None = None,
    histories: bool = False,
) -> RunOutcome:
    """One detumble run: the law ``info`` builds for the scenario, through
    :func:`spacecraft.detumble.simulate_detumble` (the whole loop: no controller proxy, so no
    ``controller_time_us``)."""
    from spacecraft.detumble import DetumbleLaw, simulate_detumble

    ctx = ControllerContext(
        spacecraft=scenario.spacecraft,
        control_period=info.control_period or scenario.control_period or scenario.dt,
        rule=rule or DEFAULT_GAIN_RULE,
        detumble=scenario.detumble,
        orbit=scenario.orbit,
    )
    law = info.factory(ctx)
    if not isinstance(law, DetumbleLaw):
        raise TypeError(
            f"factory: {name!r} returned {type(law).__name__} on a detumble scenario; expected "
            "a spacecraft.detumble.DetumbleLaw"
        )
    kw = detumble_inputs(scenario, law)
    t_start = time.perf_counter()
    res = simulate_detumble(**kw)
    wall = time.perf_counter() - t_start
    m, series = detumble_metrics(res, kw["J"], law, scenario.detumble.gain)
    m["sim_wall_time_s"] = wall
    hist: dict[str, np.ndarray] = {}
    if histories:
        hist = {
            "t": np.asarray(res.t),
            "omega": np.asarray(res.omega)[:, 0],
            "dipole": np.asarray(res.dipole)[:, 0],
            "kinetic_energy": np.asarray(res.kinetic_energy)[:, 0],
        }
    return RunOutcome(
        scenario.name, name, "ok", None, m, series, histories=hist, member=scenario.member
    )


def _sun_acquisition_run(
    scenario: Scenario, law: Any
) -> tuple[Any, dict[str, np.ndarray], dict[str, Any]]:
    """Fly a Sun-acquisition ``scenario`` with ``law`` through the safe-mode machinery
    (:func:`benchmarks.safe_mode._fly`): the true inertia under the spacecraft's torque box,
    the spec's Sun sensors and gyro through the ``SunSensorGyro`` hook, the noise seed of the
    spec, a log every 5 s. Returns the result, the per-run metrics of
    :mod:`benchmarks.safe_mode` and the geometry (``css``, ``t``, Sun angle, rate, eclipse)."""
    from .safe_mode import _eclipse_window, _fly, _metrics, _sun_angles

    sa = scenario.sun_acquisition
    if sa is None:
        raise ValueError(f"scenario: {scenario.name!r} is not a Sun-acquisition scenario")
    css = sa.sun_sensors(scenario.orbit.circular_orbit())
    b = np.asarray(sa.body_axis)
    res = _fly(
        law,
        scenario.error0[None],
        scenario.omega0[None],
        J=scenario.true_inertia,
        css=css,
        gyro=sa.gyro(),
        body_axis=b,
        max_torque=scenario.spacecraft.max_torque,
        t_final=scenario.duration,
        dt=scenario.dt,
        control_period=scenario.control_period or scenario.dt,
        log_every=max(1, int(round(5.0 / scenario.dt))),
        seed=sa.seed,
        gravity_gradient=sa.gravity_gradient,
    )
    entry, exit_ = _eclipse_window(css)
    t, ang, rate, ecl = _sun_angles(res, css, b)
    m = _metrics(t, ang, rate, ecl, entry, exit_, sa.threshold_deg, sa.window_s)
    geo = {"t": t, "angle": ang, "rate": rate, "eclipse": ecl, "entry": entry, "exit": exit_}
    return res, {k: v[0] for k, v in m.items()}, geo


def _simulate_sun_acquisition_pair(
    scenario: Scenario,
    name: str,
    info: ControllerInfo,
    rule: GainRule | None = None,
    histories: bool = False,
) -> RunOutcome:
    """One Sun-acquisition run (one spacecraft; the law is not timed: its cost is that of a
    PD). Metrics: :data:`benchmarks.metrics.DESCRIPTIONS` (``time_to_acquire_s`` …)."""
    ctx = ControllerContext(
        spacecraft=scenario.spacecraft,
        control_period=info.control_period or scenario.control_period or scenario.dt,
        rule=rule or DEFAULT_GAIN_RULE,
        orbit=scenario.orbit,
        sun_acquisition=scenario.sun_acquisition,
    )
    law = info.factory(ctx)
    _check_controller_like(law, "factory")
    t_start = time.perf_counter()
    res, per_run, geo = _sun_acquisition_run(scenario, law)
    wall = time.perf_counter() - t_start
    t, ang, rate = geo["t"], geo["angle"][:, 0], geo["rate"][:, 0]
    u = np.linalg.norm(np.asarray(res.u)[:, 0], axis=-1)
    m = {k: float(v) for k, v in per_run.items()}
    m.update(
        initial_sun_angle_deg=float(ang[0]),
        final_sun_angle_deg=float(ang[-1]),
        initial_rate_deg_s=float(rate[0]),
        final_rate_deg_s=float(rate[-1]),
        eclipse_entry_s=float(geo["entry"]),
        eclipse_exit_s=float(geo["exit"]),
        peak_torque_Nm=float(u.max()),
        effort_Nms=float(np.trapezoid(u, t)),
        sim_wall_time_s=wall,
    )
    idx = _decimate(t.size)
    series = {
        "t": t[idx],
        "sun_angle_deg": ang[idx],
        "body_rate_deg_s": rate[idx],
        "torque_Nm": u[idx],
        "eclipse": geo["eclipse"][idx].astype(np.float64),
    }
    hist = history_arrays(res, 0) if histories else {}
    return RunOutcome(
        scenario.name, name, "ok", None, m, series, histories=hist, member=scenario.member
    )


def _failed(s: Scenario, c: str, exc: BaseException, histories: bool = False) -> RunOutcome:
    partial = getattr(exc, "result", None)
    series: dict[str, np.ndarray] = {}
    hist: dict[str, np.ndarray] = {}
    if partial is not None and hasattr(partial, "R"):
        try:
            series = _series(partial, 0)
            hist = history_arrays(partial, 0) if histories else {}
        except Exception:  # noqa: BLE001 - a broken partial log must not hide the error
            series, hist = {}, {}
    return RunOutcome(
        s.name, c, "failed", describe_exception(exc), {}, series, histories=hist, member=s.member
    )


def run_group(task: GroupTask) -> list[RunOutcome]:
    """Run one task (executor entry point): one batch; on failure isolate the failing pairs by
    re-running them one by one. Never raises for a controller/plant failure."""
    pairs, infos = task.pairs, task.infos
    one_by_one = {
        "se3": _simulate_pose_pair,
        "magnetorquer": _simulate_detumble_pair,
        "sun-safe": _simulate_sun_acquisition_pair,
    }
    run_pair = one_by_one.get(pairs[0][0].plant)
    if run_pair is not None:
        out = []
        for s, c in pairs:
            try:
                out.append(run_pair(s, c, infos[c], task.rule, task.histories))
            except Exception as exc:  # noqa: BLE001 - failures are data in a benchmark report
                out.append(_failed(s, c, exc, task.histories))
        return out
    try:
        return _simulate_attitude(pairs, infos, task.rule, task.histories, task.backend)
    except Exception as exc:  # noqa: BLE001 - failures are data in a benchmark report
        if len(pairs) > 1:
            res: list[RunOutcome] = []
            for p in pairs:
                res.extend(
                    run_group(GroupTask((p,), infos, task.rule, task.histories, task.backend))
                )
            return res
        s, c = pairs[0]
        return [_failed(s, c, exc, task.histories)]


def run_suite(
    scenarios: Sequence[Scenario],
    controllers: Sequence[str] | None = None,
    *,
    suite: str = "custom",
    jobs: int | None = None,
    executor: Executor | str | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    gain_rule: GainRule | None = None,
    keep_histories: bool = False,
    members: int = 1,
    dispersion: DispersionSpec | None = None,
    dispersion_seed: int | None = None,
    pairs: Collection[tuple[str, str]] | None = None,
    backend: str = "numba",
) -> SuiteResult:
    """Run every scenario with every controller (pairs that do not apply are ``"n/a"``), each
    pair as a cell of ``members`` dispersed members.

    Args:
        scenarios: the scenarios (see :mod:`benchmarks.scenarios`).
        controllers: registered controller names (default: all registered).
        suite: label stored in the result.
        jobs: worker processes of the default process executor (1: in-process).
        executor: an :class:`~benchmarks.executors.Executor` or ``"serial"``, ``"process"``,
            ``"dask"``; default from ``jobs``/``scheduler`` (:func:`make_executor`).
        scheduler: dask scheduler address (dispatches the tasks to that cluster).
        progress: show a tqdm bar over the runs.
        gain_rule: the closed-loop spec (ω_n, ζ) every controller factory tunes to (through
            :attr:`ControllerContext.rule`); ``None``: :data:`DEFAULT_GAIN_RULE`.
        keep_histories: keep every run's full logged histories in
            :attr:`RunOutcome.histories`, for :func:`benchmarks.results_file.write_histories`.
        members: members per cell (≥ 1): member 0 is the scenario itself, members ``1 … N−1``
            are drawn by :func:`benchmarks.dispersion.member_scenario` and batched apart from it.
        dispersion: the spread of every scenario's members (``None``: each scenario's own
            :attr:`~benchmarks.scenarios.Scenario.dispersion`, else
            :data:`benchmarks.dispersion.DEFAULT_DISPERSION`).
        dispersion_seed: replaces the seed of every scenario's dispersion (``None``: keep it).
        pairs: run only these ``(scenario name, controller name)`` pairs; the others are
            recorded ``"n/a"`` with the reason "not selected" (``None``: every pair).
        backend: ``"numba"`` (default, the fused loop) or ``"jax"``: the attitude batches
            whose configuration the JAX route flies (:mod:`spacecraft.differentiable`: the
            geometric PD and integral laws on the ideal or SGCMG actuator, no disturbance or
            sensors) run through ``simulate(..., backend="jax")``, the others on the numba
            loop with one log line each saying why (logger ``benchmarks.runner``). Same
            metrics to round-off; slower on the CPU (a compile per batch). Needs
            ``liecontrol[jax]`` (``ImportError`` naming it).

    Returns:
        :class:`SuiteResult` with one nominal :class:`RunOutcome` per pair (scenario-major
        order) in ``outcomes``, the drawn members' in ``member_outcomes``, and a
        :class:`benchmarks.ranking.CellSummary` per pair in ``cells``.
    """
    from tqdm.auto import tqdm

    from .controllers import available_controllers

    if backend not in ("numba", "jax"):
        raise ValueError(f"backend: expected 'numba' or 'jax', got {backend!r}")
    if backend == "jax":
        from spacecraft.differentiable import require_jax

        require_jax()

    if isinstance(scenarios, (str, Scenario)) or not isinstance(scenarios, Iterable):
        raise ValueError(
            f"scenarios: expected a sequence of Scenario objects, got {type(scenarios).__name__}"
        )
    scenarios = tuple(scenarios)
    for i, sc in enumerate(scenarios):
        if not isinstance(sc, Scenario):
            hint = (
                f" (a scenario name: use benchmarks.scenarios.get_scenario({sc!r}))"
                if isinstance(sc, str)
                else ""
            )
            raise ValueError(
                f"scenarios: entry {i} is {type(sc).__name__} {sc!r}, not a Scenario{hint}"
            )
    if controllers is not None and (
        isinstance(controllers, str) or not isinstance(controllers, (tuple, list))
    ):
        raise ValueError(f"controllers: expected a sequence of names, got {controllers!r}")
    controllers = tuple(available_controllers() if controllers is None else controllers)
    if not isinstance(suite, str) or not suite:
        raise ValueError(f"suite: expected a non-empty label (str), got {suite!r}")
    if not scenarios:
        raise ValueError("scenarios: empty")
    if not controllers:
        raise ValueError("controllers: empty")
    names = [s.name for s in scenarios]
    if len(set(names)) != len(names):
        raise ValueError(f"scenarios: duplicate names in {names}")
    if len(set(controllers)) != len(controllers):
        raise ValueError(f"controllers: duplicate names in {list(controllers)}")
    if jobs is not None:
        jobs = as_int(jobs, "jobs", 1)
    if not (executor is None or isinstance(executor, Executor)) and executor not in (
        "serial",
        "process",
        "dask",
    ):
        raise ValueError(
            f"executor: expected an Executor or one of 'serial', 'process', 'dask', got "
            f"{executor!r}"
        )
    infos = {c: get_controller(c) for c in controllers}  # unknown names fail here, listed
    if gain_rule is not None and not isinstance(gain_rule, GainRule):
        raise TypeError(f"gain_rule: expected GainRule or None, got {type(gain_rule).__name__}")
    if not isinstance(keep_histories, (bool, np.bool_)):
        raise TypeError(f"keep_histories: expected a bool, got {keep_histories!r}")
    members = as_int(members, "members", 1)
    if members > MAX_MEMBERS:
        raise ValueError(f"members: at most {MAX_MEMBERS} per cell, got {members}")
    if dispersion is not None and not isinstance(dispersion, DispersionSpec):
        raise TypeError(
            f"dispersion: expected a DispersionSpec or None, got {type(dispersion).__name__}"
        )
    from .dispersion import DEFAULT_DISPERSION

    # every member is drawn before anything runs (a spread too wide for the plant fails here)
    drawn: dict[str, list[Scenario]] = {}
    for s in scenarios:
        d = dispersion or s.dispersion or DEFAULT_DISPERSION
        if dispersion_seed is not None:
            d = dataclasses.replace(d, seed=as_int(dispersion_seed, "dispersion_seed", 0))
        try:
            drawn[s.name] = [member_scenario(s, k, d) for k in range(members)]
        except ValueError as exc:
            raise ValueError(f"dispersion: scenario {s.name!r}: {exc}") from None

    if pairs is not None:
        bad = isinstance(pairs, str) or not isinstance(pairs, Collection)
        if not bad:
            bad = not all(
                isinstance(p, tuple) and len(p) == 2 and all(isinstance(x, str) for x in p)
                for p in pairs
            )
        if bad:
            raise TypeError(
                f"pairs: expected (scenario name, controller name) tuples, got {pairs!r}"
            )
        pairs = set(pairs)
    outcomes: dict[tuple[str, str, int], RunOutcome] = {}
    groups: dict[tuple, list[tuple[Scenario, str]]] = {}
    for s in scenarios:
        for c in controllers:
            if pairs is not None and (s.name, c) not in pairs:
                outcomes[(s.name, c, 0)] = RunOutcome(s.name, c, "n/a", "not selected")
                continue
            ok, why = infos[c].applies(s, gain_rule)
            if not ok:
                outcomes[(s.name, c, 0)] = RunOutcome(s.name, c, "n/a", why)
                continue
            for s_k in drawn[s.name]:
                s_run = sampled_for(s_k, infos[c])
                # one controller per batch: a law with a compiled kernel then flies the fused
                # loop (a stack of several laws cannot), and its batch does not depend on which
                # other controllers were selected
                key = s_run.batch_key() + (c,)
                if s.plant in ("se3", "magnetorquer", "sun-safe") or s.sensors is not None:
                    # SE(3), detumble, Sun acquisition: one pair per run; sensors: every
                    # controller sees the same noise
                    key = key + (c, s.name, s_k.member)
                groups.setdefault(key, []).append((s_run, c))
    own = not isinstance(executor, Executor)
    nominal = [g for g in groups.values() if g[0][0].member == 0]
    drawn_groups = [g for g in groups.values() if g[0][0].member > 0]
    n_split = None
    if isinstance(executor, Executor):
        ex = executor
    else:
        if jobs is None and executor in (None, "process") and not scheduler:
            jobs = max(1, min(len(groups), _cpu_count()))
            n_split = max(1, min(len(nominal), _cpu_count()))  # as a single-member run's
        ex = make_executor(executor, jobs=jobs, scheduler=scheduler)
    # only the nominal groups are split for parallelism, exactly as in a single-member run (so
    # member 0 is that run bit for bit); the drawn members' groups are never split, so their
    # batches — and results — do not depend on the executor or its number of workers
    chunks = _split_groups(nominal, n_split or ex.parallelism) + drawn_groups
    # largest tasks first: better packing over the workers
    tasks = sorted(
        (
            GroupTask(
                tuple(g), {c: infos[c] for _, c in g}, gain_rule, bool(keep_histories), backend
            )
            for g in chunks
        ),
        key=lambda tk: -len(tk.pairs) * tk.pairs[0][0].duration / tk.pairs[0][0].dt,
    )
    t_start = time.perf_counter()
    n_runs = sum(len(t.pairs) for t in tasks)
    try:
        with tqdm(total=n_runs, desc=f"suite {suite}", unit="run", disable=not progress) as bar:
            results = ex.map(run_group, tasks, on_done=lambda i: bar.update(len(tasks[i].pairs)))
    finally:
        if own:
            ex.close()
    for task, res in zip(tasks, results, strict=True):
        if isinstance(res, TaskFailure):
            for s, c in task.pairs:
                outcomes[(s.name, c, s.member)] = RunOutcome(
                    s.name, c, "failed", res.error, member=s.member
                )
        else:
            for o in res:
                outcomes[(o.scenario, o.controller, o.member)] = o
    ordered = tuple(
        with_verdict(outcomes[(s.name, c, 0)], s) for s in scenarios for c in controllers
    )
    extra = tuple(
        with_verdict(outcomes[(s.name, c, s_k.member)], s_k)
        for s in scenarios
        for c in controllers
        if outcomes[(s.name, c, 0)].status != "n/a"
        for s_k in drawn[s.name][1:]
    )
    cells: dict[tuple[str, str], CellSummary] = {}
    by_pair: dict[tuple[str, str], list[RunOutcome]] = {}
    for o in extra:
        by_pair.setdefault((o.scenario, o.controller), []).append(o)
    nominal = {(o.scenario, o.controller): o for o in ordered}
    for s in scenarios:
        reqs = requirements_of(s)
        for c in controllers:
            runs = [nominal[(s.name, c)], *by_pair.get((s.name, c), [])]
            cells[(s.name, c)] = summarise_cell(reqs, runs)
    return SuiteResult(
        suite=suite,
        scenarios=scenarios,
        controllers=controllers,
        outcomes=ordered,
        wall_time_s=time.perf_counter() - t_start,
        executor=ex.name,
        gain_rule=gain_rule,
        members=members,
        member_outcomes=extra,
        cells=cells,
        descriptions={
            c: infos[c].description
            + (
                f" (sampled every {infos[c].control_period:g} s)"
                if infos[c].control_period is not None
                else ""
            )
            for c in controllers
        },
    )


#: The bandwidth factors :func:`bandwidth_sensitivity` re-tunes to (ω_n × 0.9 and × 1.1).
SENSITIVITY_FACTORS: tuple[float, ...] = (0.9, 1.1)
#: :func:`bandwidth_sensitivity` re-runs the cells whose worst margin lies within this factor of 1.
SENSITIVITY_NEAR = 2.0


def bandwidth_sensitivity(
    result: SuiteResult,
    factors: Sequence[float] = SENSITIVITY_FACTORS,
    *,
    executor: Executor | str | None = None,
    progress: bool = False,
    near: float | None = SENSITIVITY_NEAR,
) -> SuiteResult:
    """``result`` with :attr:`SuiteResult.sensitivity` filled: the nominal scenario of every
    cell *near a limit* re-run with its controller re-tuned to ``ω_n × factor`` (ζ kept), and
    whether that run meets every requirement of the scenario (``None`` where the controller
    cannot be tuned to that bandwidth). A cell whose verdict is decided by a knife edge shows it
    here: its requirements hold at one bandwidth and not at the neighbour.

    A cell is near a limit when some members pass and some do not, or the nominal run's worst
    margin lies within a factor ``near`` of 1 (``[1/near, near]``; unmeasured counts as far); the
    other cells are not re-run (``None``: every cell). :data:`SENSITIVITY_NEAR` = 2: a ±10 %
    bandwidth change moves settling times and steady errors by tens of percent, not by 2×."""
    from .requirements import meets

    if near is not None:
        near = float(check_positive_scalar(near, "near"))
        if near < 1.0:
            raise ValueError(f"near: expected a factor >= 1, got {near}")
    rule = result.gain_rule or DEFAULT_GAIN_RULE
    sens: dict[tuple[str, str], dict[float, bool | None]] = {}
    live = list(result.controllers)

    def close(key: tuple[str, str], cell: CellSummary) -> bool:
        if cell.verdict in ("not-applicable", "error"):
            return False
        if near is None or 0 < cell.passed < cell.n:
            return True
        # the nominal run's worst margin: the verdict a ±10 % retune could flip is its own
        reqs = requirements_of(scenario_of[key[0]])
        values = meets(reqs, result.outcome(*key).metrics)[1]
        w = max((r.margin(values[r.text()]) for r in reqs), default=math.nan)
        return math.isfinite(w) and 1.0 / near <= w <= near

    scenario_of = {s.name: s for s in result.scenarios}
    chosen = {k for k, cell in result.cells.items() if close(k, cell)}
    if not chosen:
        return dataclasses.replace(result, sensitivity={})
    for f in factors:
        f = float(check_positive_scalar(f, "factors"))
        scaled = GainRule(omega_n=rule.omega_n * f, zeta=rule.zeta)
        sub = run_suite(
            result.scenarios, live, suite=f"{result.suite} (ω_n × {f:g})", executor=executor,
            progress=progress, gain_rule=scaled, pairs=chosen,
        )  # fmt: skip
        for s in result.scenarios:
            reqs = requirements_of(s)
            for c in live:
                if (s.name, c) not in chosen:
                    continue
                o = sub.outcome(s.name, c)
                # None: the controller cannot be tuned to that bandwidth on this scenario
                ok = None if o.status == "n/a" else o.status == "ok" and meets(reqs, o.metrics)[0]
                sens.setdefault((s.name, c), {})[f] = ok
    return dataclasses.replace(result, sensitivity=sens)


def _split_groups(
    groups: list[list[tuple[Scenario, str]]], n: int
) -> list[list[tuple[Scenario, str]]]:
    """Split the largest batch groups along controller boundaries until there are ``n`` tasks
    (or nothing left to split), so every worker gets work. Which batch a pair runs in does not
    change its result beyond round-off (vectorized vs single-spacecraft arithmetic)."""
    groups = [list(g) for g in groups]
    while groups and len(groups) < n:
        sizes = [len({c for _, c in g}) for g in groups]
        i = int(np.argmax([len(g) if k > 1 else 0 for g, k in zip(groups, sizes, strict=True)]))
        if sizes[i] < 2:
            break
        ctrls = list(dict.fromkeys(c for _, c in groups[i]))
        first = set(ctrls[: len(ctrls) // 2])
        a = [p for p in groups[i] if p[1] in first]
        b = [p for p in groups[i] if p[1] not in first]
        groups[i : i + 1] = [a, b]
    return groups


def sampled_for(scenario: Scenario, info: ControllerInfo) -> Scenario:
    """The scenario as ``info``'s controller flies it: a controller registered with a sampling
    period *shorter* than the scenario's (e.g. a high-gain observer) is sampled at its own
    period — the pair then runs in its own batch; a longer one is held by
    :class:`HeldController` inside the scenario's loop."""
    import dataclasses

    own, base = info.control_period, scenario.control_period or scenario.dt
    if own is None or own >= base * (1 - 1e-9):
        return scenario
    ratio = own / scenario.dt
    if round(ratio) < 1 or abs(ratio - round(ratio)) > 1e-9 * ratio:
        raise ValueError(
            f"control_period: {info.name!r} samples every {own} s, not a multiple of scenario "
            f"{scenario.name!r}'s step dt = {scenario.dt} s"
        )
    return dataclasses.replace(scenario, control_period=own)


def _cpu_count() -> int:
    import os

    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        return os.cpu_count() or 1
