"""Actuator faults as data, a fault-injecting actuator wrapper and reconfigured CMG steering.

Faults (small frozen dataclasses, one per kind, each acting on one *unit* from ``time`` on):

========================  ==================================================================
``cmg-gimbal-stuck``      :class:`GimbalStuck`: the gimbal of CMG ``unit`` stops, δ̇ᵢ = 0 (its
                          rotor keeps spinning: the stuck unit still stores h₀ hᵢ(δᵢ) and adds
                          to the gyroscopic term ω × h, but produces no output torque A δ̇).
``wheel-failed``          :class:`WheelFailed`: wheel ``unit`` gets no motor torque, τᵢ = 0; it
                          coasts at the speed it had (no bearing friction is modelled on a
                          failed wheel) and keeps its momentum.
``actuator-efficiency``   :class:`EfficiencyLoss`: loss of effectiveness, the unit delivers
                          ``efficiency`` × its command (0 ≤ efficiency ≤ 1; 0 = dead).
``actuator-bias``         :class:`ActuatorBias`: an additive bias on the unit's command.
========================  ==================================================================

This is the usual multiplicative/additive actuator fault model of the fault-tolerant attitude
control literature (Yin, Xiao, Ding et al., "A review on recent development of spacecraft
attitude fault tolerant control system", IEEE Trans. Industrial Electronics 63(5), 2016):
``u_actual,ᵢ = eᵢ(t) u_cmd,ᵢ + bᵢ(t)`` with ``eᵢ`` the effectiveness (0 for a stuck gimbal or a
failed wheel) and ``bᵢ`` the bias, applied here to the *hardware* command of each unit:

- SGCMG pyramid (:class:`~spacecraft.actuators.SgcmgActuator`): units 0–3 are the gimbals,
  the command is the gimbal rate δ̇ᵢ [rad/s] (``bias`` in rad/s);
- reaction wheels (:class:`~spacecraft.actuators.ReactionWheelAssembly`): units are the
  wheels, the command is the motor torque τᵢ [N·m] (``bias`` in N·m);
- ideal torque actuator: units 0–2 are the body axes, the command is the torque [N·m]
  (efficiency and bias only: an ideal actuator has no gimbals or wheels to lose).

:class:`FaultyActuator` wraps any of these and applies the faults at the start of the first
simulator step whose time ``t ≥ time`` (a fault at ``time`` acts from the step starting at
``time`` when ``time`` is on the step grid, else from the next one). Before that it passes the
inner actuator's command through untouched, so a run equals the fault-free run bitwise up to
the fault. Because the *same* modified command drives the unit's state and the bus torque,
momentum exchange stays exact: a fault changes what the cluster delivers, never the physics.

Reconfiguration (:class:`ReconfiguredSteering`): after a gimbal sticks, the steering law is
told which gimbals remain and steers with the reduced Jacobian A_r = A[:, healthy]
(3 × n_r). What remains controllable (Meng, Yang & Jiang, "Attitude control reconfigurability
analysis of 4-CMGs pyramid configuration spacecraft", ASCC 2019; Gui, Jin & Xu, "Local
controllability and stabilization of spacecraft attitude by two single-gimbal control moment
gyros", Chinese J. Aeronautics 26(5), 2013):

- 3 of 4 pyramid CMGs: still three-axis controllable, but A_r is square, so it is singular
  wherever det A_r(δ) = 0 (a surface in gimbal space, not isolated points), there is no null
  space left to steer away from it, and the momentum envelope shrinks;
  :func:`reduced_singularity_measure` gives m_r = √det(Â_r Â_rᵀ) = |det A_r| / h₀³ and
  :func:`singular_fraction` how much more often the reduced cluster is near-singular;
- 2 CMGs (or 2 wheels): **underactuated** — only two independent torque directions at any
  instant. Small-time local controllability can survive (Gui, Jin & Xu 2013) but no smooth
  static feedback stabilises the attitude; this module refuses such a configuration
  (``ValueError``) unless ``allow_underactuated=True``, and then warns and steers least-squares.
- 3 of 4 pyramid wheels: A_r spans ℝ³ (any three pyramid axes are independent), so full
  three-axis control remains with the torque capability reduced; :class:`FaultyActuator`
  with ``reconfigure=True`` redistributes τ = A_r⁺ ḣ_cmd over the healthy wheels.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._validation import as_int, as_scalar, check_positive_scalar

from .actuators import (
    Actuator,
    CmgCommand,
    IdealTorqueActuator,
    ReactionWheelAssembly,
    SgcmgActuator,
    WheelCommand,
)
from .sgcmg import SgcmgPyramid
from .steering import SingularityRobust, SteeringLaw

__all__ = [
    "FAULT_KINDS",
    "ActuatorFault",
    "GimbalStuck",
    "WheelFailed",
    "EfficiencyLoss",
    "ActuatorBias",
    "make_fault",
    "check_faults",
    "fault_units",
    "MAX_UNITS",
    "FaultyActuator",
    "ReconfiguredSteering",
    "reduced_singularity_measure",
    "singular_fraction",
    "Reconfigurability",
    "reconfigurability",
    "with_faults",
    "RECONFIGURATION_MODES",
    "FDI_NOISE_STD",
    "FDI_MIN_BIAS",
    "default_detector",
]

#: The fault kinds, as written in scenario files (``[[scenario.fault]] kind = ...``).
FAULT_KINDS: tuple[str, ...] = (
    "cmg-gimbal-stuck",
    "wheel-failed",
    "actuator-efficiency",
    "actuator-bias",
)

# a fault at ``time`` is active at the step starting at t ≥ time; the step times t0 + k dt
# carry rounding, so a fault on the grid is not missed by one ulp
_TIME_RTOL = 1e-9

#: What triggers the reconfiguration (:func:`with_faults`, :class:`ReconfiguredSteering`):
#: ``"oracle"`` — the steering/distribution is told the lost units at the exact fault time
#: (perfect isolation, zero delay: an idealisation, kept for comparison); ``"detector"`` — the
#: units whose loss test a residual detector (:class:`spacecraft.fdi.ResidualCusum`) raises are
#: taken offline from the sample after its alarm (delay and false alarms included; a bias alarm
#: is reported, not acted on — as the oracle is told lost units only).
RECONFIGURATION_MODES: tuple[str, ...] = ("oracle", "detector")
#: Standard deviation of the simulated unit-rate measurement of the default detector, per
#: actuator kind: gimbal-rate tachometer 1e-4 rad/s (SGCMG), delivered wheel motor torque
#: 1e-3 N·m (wheels; from the wheel-speed derivative), ideal axes 1e-3 N·m. Assumed sensor
#: classes, not a datasheet.
FDI_NOISE_STD: dict[str, float] = {"sgcmg": 1e-4, "wheels": 1e-3, "ideal": 1e-3}
#: Smallest unit bias the default detector tests for (``None``: no bias test): half the
#: benchmark family's 1 mrad/s gimbal-rate bias.
FDI_MIN_BIAS: dict[str, float | None] = {"sgcmg": 5e-4, "wheels": None, "ideal": None}


@dataclass(frozen=True)
class ActuatorFault:
    """A fault on actuator unit ``unit`` (0-based) from ``time`` [s] on (base class)."""

    unit: int
    time: float

    kind = ""  # set by each subclass (a class attribute, not a field)

    def __post_init__(self) -> None:
        if type(self) is ActuatorFault:
            raise TypeError(
                "ActuatorFault: abstract; use GimbalStuck, WheelFailed, EfficiencyLoss or "
                "ActuatorBias (or make_fault(kind, ...))"
            )
        object.__setattr__(self, "unit", as_int(self.unit, "unit", 0))
        t = as_scalar(self.time, "time")
        if t < 0.0:
            raise ValueError(f"time: must be >= 0, got {self.time!r}")
        object.__setattr__(self, "time", t)

    def active(self, t: float) -> bool:
        """Whether the fault acts on the step starting at ``t``."""
        return t >= self.time - _TIME_RTOL * max(1.0, abs(self.time))

    @property
    def removes_unit(self) -> bool:
        """The unit delivers nothing from ``time`` on (stuck gimbal, failed wheel, efficiency 0)."""
        return False

    def as_dict(self) -> dict[str, Any]:
        """Scenario-file form (``kind``, ``unit``, ``time`` and the kind's own parameter)."""
        return {"kind": self.kind, **dataclasses.asdict(self)}


@dataclass(frozen=True)
class GimbalStuck(ActuatorFault):
    """``cmg-gimbal-stuck``: gimbal ``unit`` of the SGCMG pyramid stops (δ̇ = 0) at ``time``."""

    kind = "cmg-gimbal-stuck"

    @property
    def removes_unit(self) -> bool:
        return True


@dataclass(frozen=True)
class WheelFailed(ActuatorFault):
    """``wheel-failed``: wheel ``unit`` gets no motor torque from ``time`` on (it coasts)."""

    kind = "wheel-failed"

    @property
    def removes_unit(self) -> bool:
        return True


@dataclass(frozen=True)
class EfficiencyLoss(ActuatorFault):
    """``actuator-efficiency``: unit ``unit`` delivers ``efficiency`` × its command, 0 ≤
    efficiency ≤ 1 (loss of effectiveness; 0 = the unit is dead)."""

    efficiency: float = 0.5
    kind = "actuator-efficiency"

    def __post_init__(self) -> None:
        super().__post_init__()
        e = as_scalar(self.efficiency, "efficiency")
        if not 0.0 <= e <= 1.0:
            raise ValueError(f"efficiency: must lie in [0, 1], got {self.efficiency!r}")
        object.__setattr__(self, "efficiency", e)

    @property
    def removes_unit(self) -> bool:
        return self.efficiency == 0.0


@dataclass(frozen=True)
class ActuatorBias(ActuatorFault):
    """``actuator-bias``: ``bias`` is added to unit ``unit``'s command from ``time`` on (gimbal
    rate [rad/s] for a CMG, motor torque [N·m] for a wheel, torque [N·m] for an ideal axis)."""

    bias: float = 0.0
    kind = "actuator-bias"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "bias", as_scalar(self.bias, "bias"))


_BY_KIND: dict[str, type[ActuatorFault]] = {
    "cmg-gimbal-stuck": GimbalStuck,
    "wheel-failed": WheelFailed,
    "actuator-efficiency": EfficiencyLoss,
    "actuator-bias": ActuatorBias,
}


def make_fault(
    kind: str,
    unit: int,
    time: float,
    efficiency: float | None = None,
    bias: float | None = None,
) -> ActuatorFault:
    """The fault of ``kind`` (one of :data:`FAULT_KINDS`); ``efficiency`` is required for
    ``actuator-efficiency``, ``bias`` for ``actuator-bias``, and refused for the other kinds."""
    if not isinstance(kind, str) or kind not in _BY_KIND:
        raise ValueError(f"kind: unknown fault kind {kind!r}; valid: {', '.join(FAULT_KINDS)}")
    if kind == "actuator-efficiency":
        if efficiency is None:
            raise ValueError("efficiency: required for an 'actuator-efficiency' fault")
        if bias is not None:
            raise ValueError("bias: does not apply to an 'actuator-efficiency' fault")
        return EfficiencyLoss(unit, time, efficiency)
    if efficiency is not None:
        raise ValueError(f"efficiency: does not apply to a {kind!r} fault")
    if kind == "actuator-bias":
        if bias is None:
            raise ValueError("bias: required for an 'actuator-bias' fault")
        return ActuatorBias(unit, time, bias)
    if bias is not None:
        raise ValueError(f"bias: does not apply to a {kind!r} fault")
    return _BY_KIND[kind](unit, time)


# kinds each actuator accepts, and its number of units
def _actuator_units(actuator: object, name: str = "actuator") -> tuple[str, int, frozenset[str]]:
    both = frozenset({"actuator-efficiency", "actuator-bias"})
    if isinstance(actuator, SgcmgActuator):
        return "sgcmg", 4, both | {"cmg-gimbal-stuck"}
    if isinstance(actuator, ReactionWheelAssembly):
        return "wheels", actuator.n_wheels, both | {"wheel-failed"}
    if isinstance(actuator, IdealTorqueActuator):
        return "ideal", 3, both
    raise ValueError(
        f"{name}: faults apply to SgcmgActuator, ReactionWheelAssembly or "
        f"IdealTorqueActuator, got {type(actuator).__name__}"
    )


_PLANT_UNITS = {"sgcmg": 4, "ideal": 3}
_PLANT_KINDS = {
    "sgcmg": {"cmg-gimbal-stuck", "actuator-efficiency", "actuator-bias"},
    "wheels": {"wheel-failed", "actuator-efficiency", "actuator-bias"},
    "ideal": {"actuator-efficiency", "actuator-bias"},
}


def check_faults(
    faults: object,
    actuator: str,
    n_units: int,
    duration: float | None = None,
    name: str = "faults",
) -> tuple[ActuatorFault, ...]:
    """Validate ``faults`` (a fault or a sequence of them) for an ``actuator`` kind
    (``"sgcmg"``, ``"wheels"`` or ``"ideal"``) with ``n_units`` units and, if given, a run of
    ``duration`` [s]: each unit must exist, each kind suit the actuator, each time lie in
    ``[0, duration]``. Messages start with ``name[i].<field>``."""
    if isinstance(faults, ActuatorFault):
        faults = (faults,)
    if isinstance(faults, (str, Mapping)) or not isinstance(faults, Iterable):
        raise ValueError(f"{name}: expected a sequence of ActuatorFault, got {faults!r}")
    out = tuple(faults)
    if not isinstance(actuator, str) or actuator not in _PLANT_KINDS:
        raise ValueError(f"actuator: expected one of {sorted(_PLANT_KINDS)}, got {actuator!r}")
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: expected a non-empty label, got {name!r}")
    n = _n_units(n_units)
    if duration is not None:
        duration = check_positive_scalar(duration, "duration")
    for i, f in enumerate(out):
        if not isinstance(f, ActuatorFault):
            raise ValueError(f"{name}[{i}]: expected an ActuatorFault, got {type(f).__name__}")
        if f.kind not in _PLANT_KINDS[actuator]:
            raise ValueError(
                f"{name}[{i}].kind: {f.kind!r} does not apply to the {actuator!r} actuator "
                f"(valid: {', '.join(sorted(_PLANT_KINDS[actuator]))})"
            )
        if f.unit >= n:
            raise ValueError(
                f"{name}[{i}].unit: unit {f.unit} does not exist; the {actuator!r} actuator has "
                f"units 0..{n - 1}"
            )
        if duration is not None and f.time > float(duration):
            raise ValueError(
                f"{name}[{i}].time: {f.time!r} s is outside the run [0, {float(duration)!r}] s"
            )
    return out


#: Largest number of units an actuator may have here (the built-in ones have 3 or 4).
MAX_UNITS = 64


def _n_units(n_units: object) -> int:
    n = as_int(n_units, "n_units", 1)
    if n > MAX_UNITS:
        raise ValueError(f"n_units: at most {MAX_UNITS} units, got {n}")
    return n


def fault_units(faults: Sequence[ActuatorFault], t: float, n_units: int) -> tuple[int, ...]:
    """The units still delivering at time ``t`` [s] (not stuck, failed or at efficiency 0)
    among ``n_units``, given ``faults`` (a fault or a sequence of them)."""
    n = _n_units(n_units)
    if isinstance(faults, ActuatorFault):
        faults = (faults,)
    if isinstance(faults, (str, Mapping)) or not isinstance(faults, Iterable):
        raise ValueError(f"faults: expected a sequence of ActuatorFault, got {faults!r}")
    faults = tuple(faults)
    for i, f in enumerate(faults):
        if not isinstance(f, ActuatorFault):
            raise ValueError(f"faults[{i}]: expected an ActuatorFault, got {type(f).__name__}")
    return _alive(faults, as_scalar(t, "t"), n)


def _alive(faults: Sequence[ActuatorFault], t: float, n: int) -> tuple[int, ...]:
    dead = {f.unit for f in faults if f.removes_unit and f.active(t)}
    return tuple(i for i in range(n) if i not in dead)


def _fault_map(
    faults: Sequence[ActuatorFault], t: float, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-unit (gain, offset, dead) at ``t`` — command ↦ gain·command + offset, dead units
    deliver 0 — and the ``(n_faults,)`` active flags."""
    gain = np.ones(n)
    offset = np.zeros(n)
    dead = np.zeros(n, dtype=bool)
    act = np.zeros(len(faults), dtype=bool)
    for j, f in enumerate(faults):
        if not f.active(t):
            continue
        act[j] = True
        if isinstance(f, EfficiencyLoss):
            gain[f.unit] *= f.efficiency
        elif isinstance(f, ActuatorBias):
            offset[f.unit] += f.bias
        if f.removes_unit:
            dead[f.unit] = True
    gain[dead] = 0.0
    offset[dead] = 0.0
    return gain, offset, dead, act


class FaultyActuator(Actuator):
    """An actuator with faults: wraps ``inner`` (SGCMG pyramid, reaction wheels or ideal torque)
    and modifies its per-unit hardware command from each fault's time on (see the module doc).

    Per step: ``held = inner.command(...)``; if a fault is active, the unit commands become
    ``gain ∘ command + offset`` (gimbal rates δ̇ for the CMGs, motor torques τ for the wheels,
    axis torques for the ideal actuator) and dead units deliver 0; the inner actuator's
    dynamics then run on that command. With a :class:`~spacecraft.actuators.FirstOrderServo`
    a stuck gimbal also stops at once (its servo rate state is held at 0).

    Args:
        inner: the healthy actuator.
        faults: a fault or a sequence of :class:`ActuatorFault`. An empty sequence is allowed
            and means "no faults" (as an empty ``faults`` list of a scenario): the healthy
            actuator with the same log columns (``fault_active`` of width 0) — the baseline a
            faulty run is compared against.
        reconfigure: reaction wheels only — after a wheel fault, redistribute the momentum-rate
            command over the healthy wheels (τ_r = A_r⁺ ḣ_cmd, then the same torque and speed
            limits). (CMG steering is reconfigured by the steering law:
            :class:`ReconfiguredSteering`.)
        allow_underactuated: permit faults that leave fewer than three independent torque
            directions (then a ``UserWarning``); default: ``ValueError``.
        compensate: with ``reconfigure``, also invert the known efficiency and bias of the
            healthy wheels (``False``: only the lost wheels are known).
        detector: a :class:`spacecraft.fdi.ResidualCusum` over the ``n_units`` units, or
            ``None``. Each command, the unit commands ``c`` (gimbal rates, wheel motor torques,
            axis torques) and the delivered ones plus white noise of the detector's
            ``noise_std`` (the simulated tachometer / wheel-speed-derivative measurement) update
            it; with ``reconfigure`` (wheels) the distribution then drops the units whose loss
            test it has raised, per spacecraft, instead of the lost ones known from the fault
            list (the
            ``"detector"`` trigger of :data:`RECONFIGURATION_MODES`; ``compensate`` must be
            ``False``). A new run (time going back, or another batch size) resets it.
        seed: seed of the measurement noise (reset with the detector).

    Logged: everything the inner actuator logs, plus ``fault_active`` ``(B, n_faults)`` bool;
    derived (SGCMG): ``singularity_remaining`` ``(K, B)``, the singularity measure of the
    gimbals still turning at each logged time (= ``singularity`` before any gimbal sticks).
    With a detector, :attr:`detection_time` ``(B, n_units)`` holds each unit's first alarm time
    [s] (NaN: none); :func:`fault_detection_report` turns it into delay and false alarms.
    """

    def __init__(
        self,
        inner: Actuator,
        faults: ActuatorFault | Sequence[ActuatorFault],
        reconfigure: bool = False,
        allow_underactuated: bool = False,
        compensate: bool = True,
        detector: Any = None,
        seed: int = 0,
    ) -> None:
        kind, n, _ = _actuator_units(inner, "inner")
        self.faults = check_faults(faults, kind, n)
        if not isinstance(reconfigure, bool):
            raise ValueError(f"reconfigure: expected a bool, got {reconfigure!r}")
        if not isinstance(compensate, bool):
            raise ValueError(f"compensate: expected a bool, got {compensate!r}")
        self.compensate = compensate
        if not isinstance(allow_underactuated, bool):
            raise ValueError(f"allow_underactuated: expected a bool, got {allow_underactuated!r}")
        if reconfigure and kind != "wheels":
            raise ValueError(
                "reconfigure: applies to reaction wheels; reconfigure CMG steering with "
                "ReconfiguredSteering"
            )
        self.inner = inner
        self.kind = kind
        self.n_units = n
        self.reconfigure = reconfigure
        self.n_states = inner.n_states
        self._servo = kind == "sgcmg" and inner.n_states == 8
        rep = reconfigurability(inner, self.faults)
        if not rep.three_axis:
            if not allow_underactuated:
                raise ValueError(f"faults: {rep.note} (pass allow_underactuated=True to run it)")
            warnings.warn(rep.note, UserWarning, stacklevel=2)
        self._command = getattr(inner, "command_unchecked", inner.command)
        self.detector = _check_detector(detector, n)
        if self.detector is not None and reconfigure and compensate:
            raise ValueError(
                "compensate: a detector isolates units, it does not estimate their efficiency "
                "or bias; pass compensate=False with a detector"
            )
        self.seed = as_int(seed, "seed", 0)
        self._det_t: float | None = None
        self._times: list[float] = []
        self._rng = np.random.default_rng(self.seed)

    def __repr__(self) -> str:
        return f"FaultyActuator({self.inner!r}, faults={self.faults!r})"

    # ------------------------------------------------------------------ fault detection
    def _new_run(self, t: float, B: int) -> None:
        """Reset the detector at the start of a run (time going back or a new batch size)."""
        det = self.detector
        if det is None:
            return
        if self._det_t is None or t < self._det_t or det.statistic.shape[0] != B:
            det.reset(B)
            self._times = []
            self._det_t = None
            self._rng = np.random.default_rng(self.seed)

    def _isolated(self, B: int) -> np.ndarray | None:
        """``(B, n_units)`` units the detector has isolated, or ``None`` (none / no detector)."""
        det = self.detector
        if det is None or det.alarm_sample.shape[0] != B:
            return None
        iso = det.alarm_hypothesis == 0  # the loss test: the unit delivers too little
        return iso if iso.any() else None

    def _detect(self, t: float, commanded: np.ndarray, delivered: np.ndarray) -> None:
        det = self.detector
        if det is None or (self._det_t is not None and t == self._det_t):
            return
        noise = self._rng.normal(scale=det.noise_std, size=commanded.shape)
        det.update(commanded, delivered + noise)
        self._times.append(t)
        self._det_t = t

    @property
    def detection_time(self) -> np.ndarray:
        """``(B, n_units)`` time [s] of each unit's first detector alarm in the last run: the
        time of the command after the alarming sample — the measured rate of the command held
        from ``t`` is known at the next command, which is also the first one the isolation acts
        on (NaN: no alarm, or one on the run's last sample; an empty ``(0, n_units)`` array
        without a detector)."""
        det = self.detector
        if det is None:
            return np.zeros((0, self.n_units))
        k = det.alarm_sample
        times = np.asarray(self._times + [np.nan], dtype=np.float64)
        return np.where(k >= 0, times[np.clip(k + 1, 0, len(self._times))], np.nan)

    def _unit_commands(self, held: Any) -> np.ndarray:
        if self.kind == "sgcmg":
            return held.delta_dot
        if self.kind == "wheels":
            return held.torque
        return held

    def initial_state(self, batch: int) -> np.ndarray:
        return self.inner.initial_state(batch)

    def momentum(self, x_act: np.ndarray) -> np.ndarray:
        return self.inner.momentum(x_act)

    def command(self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float) -> Any:
        """Validated :meth:`command_unchecked` (the inner actuator's checks, then the faults)."""
        u, w, x, tt = self._check_command(u_cmd, omega, x_act, t)
        held = self.command_unchecked(u, w, x, tt)
        self._check_held(held.inner, u)
        return held

    def command_unchecked(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float
    ) -> Any:
        """The inner command, with the faults active at ``t`` applied to the unit commands
        (and, with a detector, its update and the isolated units' redistribution)."""
        B = u_cmd.shape[0]
        self._new_run(t, B)  # before the inner command: the steering reads the detector
        held = self._command(u_cmd, omega, x_act, t)
        active = any(f.active(t) for f in self.faults)
        iso = self._isolated(B) if self.reconfigure else None
        if not active and iso is None:
            if self.detector is not None:
                c = self._unit_commands(held)
                self._detect(t, c, c)
            return _Held(held, None, np.zeros((B, len(self.faults)), dtype=bool))
        gain, offset, dead, act = _fault_map(self.faults, t, self.n_units)
        flags = np.broadcast_to(act, (B, len(self.faults)))
        if self.kind == "sgcmg":
            c = held.delta_dot
            dd = c * gain + offset
            new = CmgCommand(delta_dot=dd, saturated=held.saturated, h_dot_cmd=held.h_dot_cmd)
            out = dd
        elif self.kind == "wheels":
            if self.reconfigure:
                known = dead if self.detector is None else iso
                c, out = self._redistribute(held, x_act, gain, offset, dead, known)
            else:
                c = held.torque
                out = c * gain + offset
            new = dataclasses.replace(held, torque=out)
        else:
            c = held
            new = out = held * gain + offset
        self._detect(t, c, out)
        return _Held(new, dead if self._servo and dead.any() else None, flags)

    def _redistribute(
        self,
        held: WheelCommand,
        x_act: np.ndarray,
        gain: np.ndarray,
        offset: np.ndarray,
        dead: np.ndarray,
        known: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Healthy-wheel distribution: the delivered torques x = A_r⁺ ḣ_cmd (minimum norm over
        the wheels known to be healthy — ``known`` lost: ``(n,)`` or per spacecraft
        ``(B, n)``; ``None``: none), then the command c with gain·c + offset = x, then the
        limits. Returns ``(c, gain·c + offset)``: the command and what the wheels deliver."""
        rw: ReactionWheelAssembly = self.inner  # type: ignore[assignment]
        B = held.torque_cmd.shape[0]
        kn = np.zeros((B, self.n_units), dtype=bool) if known is None else known
        kn = np.broadcast_to(kn, (B, self.n_units))
        x = np.zeros(held.torque_cmd.shape)
        c = np.zeros_like(x)
        for pattern in {tuple(r) for r in kn}:
            rows = np.all(kn == np.array(pattern), axis=1)
            ok = ~np.array(pattern, dtype=bool)
            A_r = rw.axes[:, ok]
            xr = np.zeros((int(rows.sum()), self.n_units))
            xr[:, ok] = held.h_dot_cmd[rows] @ np.linalg.pinv(A_r).T
            x[rows] = xr
            if self.compensate:
                c[np.ix_(rows, ok)] = (xr[:, ok] - offset[ok]) / gain[ok]
            else:
                c[np.ix_(rows, ok)] = xr[:, ok]
        c = np.clip(c, -rw.max_torque, rw.max_torque)
        c[rw._speed_gate(x_act, c * gain + offset)] = 0.0
        return c, c * gain + offset

    def _masked(self, x_act: np.ndarray, held: _Held) -> np.ndarray:
        """Servo state with the stuck gimbals' actual rates at 0."""
        if held.dead is None:
            return x_act
        x = x_act.copy()
        x[:, 4:][:, held.dead] = 0.0
        return x

    def state_derivative(self, x_act: np.ndarray, held: _Held) -> np.ndarray:
        if held.dead is None:
            return self.inner.state_derivative(x_act, held.inner)
        out = self.inner.state_derivative(self._masked(x_act, held), held.inner)
        out[:, :4][:, held.dead] = 0.0  # the stuck gimbal angle stays
        out[:, 4:][:, held.dead] = 0.0  # and so does its (zeroed) rate
        return out

    def body_torque(self, omega: np.ndarray, x_act: np.ndarray, held: _Held) -> np.ndarray:
        return self.inner.body_torque(omega, self._masked(x_act, held), held.inner)

    def log(self, x_act: np.ndarray, held: _Held) -> dict[str, np.ndarray]:
        out = dict(self.inner.log(self._masked(x_act, held), held.inner))
        out["fault_active"] = held.flags
        return out

    def derived_log(self, log: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        out = dict(self.inner.derived_log(log))
        if self.kind == "sgcmg" and "delta" in log:
            out["singularity_remaining"] = self._remaining_measure(log)
        return out

    def _remaining_measure(self, log: dict[str, np.ndarray]) -> np.ndarray:
        delta = log["delta"]
        flags = log["fault_active"]  # (K, B, n_faults)
        removing = np.array([f.removes_unit for f in self.faults], dtype=bool)
        m = np.array(self.inner.cluster.singularity_measure(delta), dtype=np.float64)
        if not removing.any():
            return m
        dead_rows = flags[..., removing]  # which removing faults are active per sample
        units = np.array([f.unit for f in self.faults])[removing]
        for pattern in {tuple(r) for r in dead_rows.reshape(-1, dead_rows.shape[-1])}:
            if not any(pattern):
                continue
            dead = sorted({int(u) for u, on in zip(units, pattern, strict=True) if on})
            sel = np.all(dead_rows == np.array(pattern), axis=-1)
            m[sel] = reduced_singularity_measure(self.inner.cluster, delta[sel], dead)
        return m


@dataclass(frozen=True)
class _Held:
    """What :class:`FaultyActuator` holds over a step: the inner actuator's (modified) command,
    the stuck gimbals whose servo rate is masked (``None``: none), the active-fault flags."""

    inner: Any
    dead: np.ndarray | None
    flags: np.ndarray


# ----------------------------------------------------------------------- reconfigured steering
@dataclass(frozen=True)
class ReconfiguredSteering(SteeringLaw):
    """Steering told which gimbals remain: the nominal ``law`` while all are healthy, then
    ``reduced_law`` on the reduced Jacobian A_r = A[:, healthy] (3 × n_r)::

        x = reduced_law(A_r, ḣ_cmd),      δ̇_cmd,ᵢ = (xᵢ − bᵢ) / eᵢ  (healthy i),  δ̇_cmd,ⱼ = 0
        (stuck j),

    where, with ``compensate=True``, the known efficiency eᵢ and bias bᵢ of the faults are
    inverted so that the gimbals *turn* at x (A_r x = ḣ_cmd where the reduced cluster can
    realise it). The default ``reduced_law`` is the singularity-robust inverse: with 3 of 4
    gimbals A_r is square and there is no null space for null motion, so bounded rates near
    det A_r = 0 are what is left. Before the first fault the call is exactly ``law``'s
    (bitwise).

    Args:
        law: the nominal steering law (all gimbals healthy).
        faults: the faults the law is told about (only SGCMG kinds).
        reduced_law: the law used on A_r (default :class:`~spacecraft.steering.SingularityRobust`).
        n_units: number of gimbals (4 for the pyramid).
        compensate: invert the known efficiency/bias of the faulty gimbals.
        allow_underactuated: permit fewer than 3 healthy gimbals (warns; then least squares).
        reconfiguration: what triggers it (:data:`RECONFIGURATION_MODES`): ``"oracle"``
            (default) — the lost gimbals of ``faults`` from their exact fault time;
            ``"detector"`` — per spacecraft, the gimbals whose *loss* test ``detector`` has
            raised (its latched alarms, updated by the :class:`FaultyActuator` sharing it: a
            gimbal delivering half its command or less — stuck, or the family's 30 % unit) are
            dropped from the sample after the alarm; a bias alarm is reported, not acted on
            (as the oracle, which is told lost units only: the controller rejects a bias);
            ``faults`` is then not used to steer and ``compensate`` must be ``False`` (the
            detector does not estimate efficiency or bias).
        detector: the shared :class:`spacecraft.fdi.ResidualCusum` (``"detector"`` only).
    """

    law: SteeringLaw
    faults: tuple[ActuatorFault, ...] = ()
    reduced_law: SteeringLaw = dataclasses.field(default_factory=SingularityRobust)
    n_units: int = 4
    compensate: bool = True
    allow_underactuated: bool = False
    reconfiguration: str = "oracle"
    detector: Any = dataclasses.field(default=None, compare=False)

    def __post_init__(self) -> None:
        for name in ("law", "reduced_law"):
            if not isinstance(getattr(self, name), SteeringLaw):
                raise ValueError(
                    f"{name}: expected a SteeringLaw, got {type(getattr(self, name)).__name__}"
                )
        n = _n_units(self.n_units)
        object.__setattr__(self, "n_units", n)
        object.__setattr__(self, "faults", check_faults(self.faults, "sgcmg", n))
        for name in ("compensate", "allow_underactuated"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name}: expected a bool, got {getattr(self, name)!r}")
        if self.reconfiguration not in RECONFIGURATION_MODES:
            raise ValueError(
                f"reconfiguration: expected one of {RECONFIGURATION_MODES}, got "
                f"{self.reconfiguration!r}"
            )
        if self.reconfiguration == "detector":
            if self.detector is None:
                raise ValueError("detector: reconfiguration='detector' needs a ResidualCusum")
            _check_detector(self.detector, n)
            if self.compensate:
                raise ValueError(
                    "compensate: a detector isolates units, it does not estimate their "
                    "efficiency or bias; pass compensate=False with reconfiguration='detector'"
                )
        elif self.detector is not None:
            raise ValueError("detector: applies to reconfiguration='detector' only")
        left = _alive(self.faults, math.inf, n)
        if len(left) < 3:
            msg = (
                f"faults: only {len(left)} of {n} gimbals remain ({list(left)}): the cluster is "
                "underactuated (two torque directions at most at any instant)"
            )
            if not self.allow_underactuated:
                raise ValueError(msg + "; pass allow_underactuated=True to steer least-squares")
            warnings.warn(msg, UserWarning, stacklevel=3)

    def _active(self, t: float) -> bool:
        return any(f.active(t) for f in self.faults)

    def _steer_detected(self, A, hdot_cmd, delta, t, cluster) -> np.ndarray:
        """``"detector"``: the nominal law where nothing is isolated, the reduced law without
        the isolated gimbals elsewhere (per spacecraft)."""
        det = self.detector
        A = np.asarray(A, dtype=np.float64)
        B = A.shape[0] if A.ndim == 3 else 1
        iso = det.alarm_hypothesis == 0 if det.alarm_sample.shape[0] == B else None
        if iso is None or not iso.any():
            return self.law.steer(A, hdot_cmd, delta, t, cluster)
        A3 = A.reshape(B, 3, -1)
        hd = np.asarray(hdot_cmd, dtype=np.float64).reshape(B, 3)
        out = np.array(self.law.steer(A, hdot_cmd, delta, t, cluster), dtype=np.float64)
        out = out.reshape(B, -1)
        for pattern in {tuple(r) for r in iso if r.any()}:
            rows = np.all(iso == np.array(pattern), axis=1)
            ok = np.flatnonzero(~np.array(pattern, dtype=bool))
            o = np.zeros((int(rows.sum()), self.n_units))
            if ok.size:
                A_r = np.ascontiguousarray(A3[rows][..., ok])
                o[:, ok] = self.reduced_law.steer(A_r, hd[rows], None, t, None)
            out[rows] = o
        return out.reshape(A.shape[:-2] + (A.shape[-1],))

    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        if self.reconfiguration == "detector":
            return self._steer_detected(A, hdot_cmd, delta, t, cluster)
        if not self._active(t):
            return self.law.steer(A, hdot_cmd, delta, t, cluster)
        gain, offset, dead, _ = _fault_map(self.faults, t, self.n_units)
        if not dead.any():
            # no unit lost (efficiency/bias only): the nominal law on the full Jacobian
            out = np.array(self.law.steer(A, hdot_cmd, delta, t, cluster), dtype=np.float64)
            if self.compensate:
                out = (out - offset) / gain
            return out
        ok = np.flatnonzero(~dead)
        out = np.zeros(A.shape[:-2] + (A.shape[-1],))
        if ok.size:
            A_r = np.ascontiguousarray(A[..., ok])
            out[..., ok] = self.reduced_law.steer(A_r, hdot_cmd, None, t, None)
        if self.compensate:
            out[..., ok] = (out[..., ok] - offset[ok]) / gain[ok]
        return out


def _check_detector(detector: Any, n: int) -> Any:
    """``detector`` (a :class:`spacecraft.fdi.ResidualCusum` over ``n`` units) or ``None``."""
    if detector is None:
        return None
    from .fdi import ResidualCusum

    if not isinstance(detector, ResidualCusum):
        raise ValueError(f"detector: expected a ResidualCusum, got {type(detector).__name__}")
    if detector.n_units != n:
        raise ValueError(f"detector: expected n_units = {n}, got {detector.n_units}")
    return detector


def default_detector(actuator: Actuator, false_alarm_samples: float = 1.0e6) -> Any:
    """The residual CUSUM (:class:`spacecraft.fdi.ResidualCusum`) of :func:`with_faults`'s
    ``"detector"`` trigger for ``actuator``: one statistic per unit and hypothesis, noise
    :data:`FDI_NOISE_STD` and bias test :data:`FDI_MIN_BIAS` of its kind, ``min_loss`` 0.5 (a
    unit delivering half its command or less: a stuck gimbal, a failed wheel, the family's 30 %
    unit), threshold ``h = ln(n_stats · false_alarm_samples)`` — at most one false alarm per
    ``false_alarm_samples`` samples and spacecraft (Lorden's bound, :mod:`spacecraft.fdi`)."""
    from .fdi import ResidualCusum

    kind, n, _ = _actuator_units(actuator)
    return ResidualCusum(
        n,
        FDI_NOISE_STD[kind],
        min_loss=0.5,
        min_bias=FDI_MIN_BIAS[kind],
        false_alarm_samples=false_alarm_samples,
    )


def fault_detection_report(
    faults: Sequence[ActuatorFault], detection_time: object
) -> tuple[np.ndarray, np.ndarray]:
    """Detection delay and false alarms per spacecraft from a detector's first alarm times
    ``detection_time`` ``(B, n_units)`` [s] (NaN: no alarm; :attr:`FaultyActuator.
    detection_time`): ``delay`` ``(B,)`` — the first alarm on a faulty unit at or after its
    fault, minus the earliest fault time (NaN: the fault was not detected, or no fault);
    ``false_alarms`` ``(B,)`` — units alarmed that carry no fault, or alarmed before their
    fault struck."""
    try:
        T = np.asarray(detection_time, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f"detection_time: expected a real (B, n_units) array, got {detection_time!r}"
        ) from None
    if T.ndim != 2 or np.isinf(T).any() or (T < 0.0).any():
        raise ValueError("detection_time: expected (B, n_units) times >= 0 or NaN (no alarm)")
    if not isinstance(faults, (list, tuple)):
        raise ValueError(f"faults: expected a sequence of ActuatorFault, got {faults!r}")
    fs = tuple(faults)
    for f in fs:
        if not isinstance(f, ActuatorFault) or not 0 <= f.unit < T.shape[1]:
            raise ValueError(f"faults: expected ActuatorFault items on units < {T.shape[1]}")
    onset = np.full(T.shape[1], np.inf)
    for f in fs:
        onset[f.unit] = min(onset[f.unit], f.time)
    alarmed = np.isfinite(T)
    faulty = np.isfinite(onset)[None, :]
    tol = _TIME_RTOL * np.maximum(1.0, np.where(np.isfinite(onset), np.abs(onset), 1.0))
    early = alarmed & (T < (onset - tol)[None, :])
    false_alarms = np.sum(alarmed & (~faulty | early), axis=1).astype(np.float64)
    hit = alarmed & faulty & ~early
    first = np.where(hit, T, np.inf).min(axis=1)
    t0 = float(onset.min()) if np.isfinite(onset).any() else np.nan
    delay = np.where(np.isfinite(first), first - t0, np.nan)
    return delay, false_alarms


def reduced_singularity_measure(
    cluster: SgcmgPyramid, delta: object, failed: Iterable[int]
) -> np.ndarray:
    """Singularity measure of the gimbals still turning: m_r = √det(Â_r Â_rᵀ), Â_r = A_r / h₀
    with A_r the Jacobian columns of the healthy gimbals, shape ``delta.shape[:-1]``. For
    3 healthy gimbals m_r = |det A_r| / h₀³; with fewer than 3 it is 0 (rank ≤ 2)."""
    if not isinstance(cluster, SgcmgPyramid):
        raise ValueError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
    if isinstance(failed, (str, bytes)) or not isinstance(failed, Iterable):
        raise ValueError(f"failed: expected a sequence of gimbal indices, got {failed!r}")
    failed = list(failed)
    if any(np.ndim(i) != 0 for i in failed):
        raise ValueError(f"failed: expected a flat sequence of gimbal indices, got {failed!r}")
    idx = [as_int(i, "failed", 0) for i in failed]
    if len(set(idx)) != len(idx):
        raise ValueError(f"failed: a gimbal is listed twice, got {idx}")
    bad = sorted(idx)
    if bad and bad[-1] > 3:
        raise ValueError(f"failed: gimbal {bad[-1]} does not exist (units 0..3)")
    A = cluster.jacobian(delta)
    ok = [i for i in range(A.shape[-1]) if i not in bad]
    if len(ok) < 3:
        return np.zeros(A.shape[:-2])
    A_r = A[..., ok] / cluster.h0
    a, b, c = A_r[..., 0, :], A_r[..., 1, :], A_r[..., 2, :]
    g = [[(p * q).sum(-1) for q in (a, b, c)] for p in (a, b, c)]
    det = (
        g[0][0] * (g[1][1] * g[2][2] - g[1][2] * g[2][1])
        - g[0][1] * (g[1][0] * g[2][2] - g[1][2] * g[2][0])
        + g[0][2] * (g[1][0] * g[2][1] - g[1][1] * g[2][0])
    )
    return np.sqrt(np.maximum(det, 0.0))


def singular_fraction(
    cluster: SgcmgPyramid,
    failed: Iterable[int],
    threshold: float = 0.1,
    n_samples: int = 20000,
    rng: np.random.Generator | None = None,
) -> float:
    """Fraction of gimbal configurations (δ uniform on [−π, π)⁴, seeded) whose singularity
    measure of the healthy gimbals is below ``threshold``: how often the (reduced) cluster is
    near-singular. ``failed = ()`` gives the healthy cluster's fraction for comparison."""
    t = as_scalar(threshold, "threshold")
    if t <= 0.0:
        raise ValueError(f"threshold: must be > 0, got {threshold!r}")
    n = as_int(n_samples, "n_samples", 1)
    if n > 10**7:
        raise ValueError(f"n_samples: at most 10**7 samples, got {n}")
    if rng is None:
        rng = np.random.default_rng(0)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
    delta = rng.uniform(-math.pi, math.pi, size=(n, 4))
    m = reduced_singularity_measure(cluster, delta, failed)
    return float(np.mean(m < t))


@dataclass(frozen=True)
class Reconfigurability:
    """What remains after the faults (:func:`reconfigurability`).

    Attributes:
        actuator: ``"sgcmg"``, ``"wheels"`` or ``"ideal"``.
        n_units: units of the healthy actuator.
        remaining: the units that still deliver torque after every fault has occurred.
        rank: the rank of the remaining torque directions (3: three-axis; for CMGs the generic
            rank, reached away from the reduced cluster's singular surface).
        three_axis: whether three-axis control remains.
        note: a plain statement of what remains controllable.
    """

    actuator: str
    n_units: int
    remaining: tuple[int, ...]
    rank: int
    three_axis: bool
    note: str


def reconfigurability(actuator: Actuator, faults: object) -> Reconfigurability:
    """What ``actuator`` can still do after ``faults`` have all occurred (see module doc)."""
    kind, n, _ = _actuator_units(actuator)
    fs = check_faults(faults, kind, n)
    left = _alive(fs, math.inf, n)
    lost = n - len(left)
    if kind == "wheels":
        rank = int(np.linalg.matrix_rank(actuator.axes[:, list(left)])) if left else 0
    elif kind == "sgcmg":
        rank = min(3, len(left))
    else:
        rank = len(left)
    three = rank == 3
    what = {"sgcmg": "gimbals", "wheels": "wheels", "ideal": "torque axes"}[kind]
    if lost == 0:
        note = f"all {n} {what} remain: full three-axis control"
    elif not three:
        note = (
            f"only {len(left)} of {n} {what} remain ({list(left)}), spanning {rank} torque "
            "direction(s): the attitude is underactuated — no smooth static feedback "
            "stabilises it; three-axis pointing is not guaranteed"
        )
    elif kind == "sgcmg" and len(left) == 3:
        note = (
            f"3 of 4 gimbals remain ({list(left)}): three-axis control remains, but the 3×3 "
            "Jacobian is singular on a whole surface det A_r(δ) = 0 with no null space to "
            "avoid it, and the momentum envelope shrinks"
        )
    else:
        note = (
            f"{len(left)} of {n} {what} remain ({list(left)}): three-axis control remains "
            "with reduced torque and momentum capability"
        )
    return Reconfigurability(kind, n, left, rank, three, note)


def with_faults(
    plant: Any,
    faults: object,
    reconfigure: bool = True,
    compensate: bool = False,
    allow_underactuated: bool = False,
    reconfiguration: str = "oracle",
    detector: Any = None,
) -> Any:
    """``plant`` (a :class:`spacecraft.plant.Spacecraft`) with ``faults`` injected: its actuator
    wrapped in :class:`FaultyActuator`. With ``reconfigure`` (default) an SGCMG actuator is
    rebuilt with :class:`ReconfiguredSteering` over its own steering law and wheels redistribute
    over the healthy ones. ``reconfiguration`` (:data:`RECONFIGURATION_MODES`) says what
    triggers it: ``"oracle"`` (default) — the steering is told which units are *lost* (a stuck
    gimbal or a dead wheel) at the exact fault time, perfect isolation with zero delay;
    ``"detector"`` — a residual CUSUM (``detector``, default :func:`default_detector`) shared by
    the steering and the wrapper isolates units from the commanded vs measured unit rates; a
    unit whose loss test alarms (it delivers half its command or less) is dropped from the
    sample after the alarm, per spacecraft, a bias alarm is reported only (its alarm times:
    :attr:`FaultyActuator.detection_time`). ``compensate`` (oracle only) also tells it
    the size of an efficiency loss or a bias (default ``False``: those stay unknown, for the
    controller to reject — the benchmark's setting). ``faults = ()`` returns ``plant``
    unchanged."""
    from .plant import Spacecraft

    if not isinstance(plant, Spacecraft):
        raise ValueError(f"plant: expected a Spacecraft, got {type(plant).__name__}")
    if not isinstance(reconfigure, bool):
        raise ValueError(f"reconfigure: expected a bool, got {reconfigure!r}")
    if reconfiguration not in RECONFIGURATION_MODES:
        raise ValueError(
            f"reconfiguration: expected one of {RECONFIGURATION_MODES}, got {reconfiguration!r}"
        )
    act = plant.actuator
    kind, n, _ = _actuator_units(act)
    fs = check_faults(faults, kind, n)
    if not fs:
        return plant
    if reconfiguration == "detector":
        detector = default_detector(act) if detector is None else _check_detector(detector, n)
        if compensate:
            raise ValueError(
                "compensate: a detector isolates units, it does not estimate their efficiency "
                "or bias; pass compensate=False with reconfiguration='detector'"
            )
    elif detector is not None:
        raise ValueError("detector: applies to reconfiguration='detector' only")
    if reconfigure and kind == "sgcmg":
        if not isinstance(act.steering, SteeringLaw):
            raise ValueError(
                "plant: reconfiguring needs the CMG steering to be a SteeringLaw, got "
                f"{type(act.steering).__name__}"
            )
        if not isinstance(compensate, bool):
            raise ValueError(f"compensate: expected a bool, got {compensate!r}")
        steering = ReconfiguredSteering(
            act.steering,
            fs,
            n_units=n,
            compensate=compensate,
            allow_underactuated=allow_underactuated,
            reconfiguration=reconfiguration,
            detector=detector,
        )
        act = SgcmgActuator(act.cluster, steering, act.delta0, act.servo)
    wrapped = FaultyActuator(
        act,
        fs,
        reconfigure=reconfigure and kind == "wheels",
        allow_underactuated=allow_underactuated,
        compensate=compensate,
        detector=detector,
    )
    return dataclasses.replace(plant, actuator=wrapped)
