"""Fixed-step multi-rate closed-loop simulator.

One step of length ``dt`` from ``t_k = t0 + k dt``:

0. every sensor whose period divides ``k dt`` (``k`` a multiple of ``sensor.period / dt``) is
   sampled, ``y = sensor.measure(t_k, R, ω, rng)`` on the true state, and its output is held
   (zero-order hold) until its next sample;
1. if ``k`` is a multiple of ``control_period / dt``: the controller is sampled,
   ``u_cmd = controller.command(t_k, state, reference(t_k))`` and held (zero-order hold) until
   its next sample. ``state`` is the true ``AttitudeState(R, ω, h)``, or, with a
   ``measurement`` hook, ``measurement(t_k, held sensor outputs, truth)`` (e.g.
   :class:`StarTrackerGyro`: attitude from the star tracker, rate from the gyro). Sensors
   sampled at ``t_k`` are seen by the controller at ``t_k`` (no extra latency);
2. the actuator turns the held torque command into its hardware command (for the SGCMG cluster:
   steering law + gimbal-rate limit), held over the step; with ``compute_delay`` τ the command
   computed at t_k reaches this stage at t_k + τ (a FIFO of pending commands, zero before);
3. the plant ``(R, ω, x_act)`` is advanced with RKMK4 (:meth:`spacecraft.plant.Spacecraft.step`);
4. a non-finite state (or a non-finite torque command, or an arithmetic error inside the
   integration step — overflow, ``math`` domain error — chained as the cause) stops the run
   with :class:`SimulationDiverged` (partial log attached).

Every ``log_every`` steps (and at the final time) one row is logged: the state at ``t_k`` (with
flexible modes: ``q``, ``q̇`` and the modal energies), the held sensor outputs, the state the
controller was given and the commands applied from ``t_k`` on. Batched: ``B`` spacecraft run in
lock-step in one set of arrays; controllers with ``batched = False`` are stepped per spacecraft
(one deep copy each).
"""

from __future__ import annotations

import copy
import logging
import math
import re
import warnings
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from liecontrol._kernels import euler as _ke
from liecontrol._validation import as_int, as_scalar, check_positive_scalar
from liecontrol.charts import euler
from liecontrol.control.base import AttitudeController, AttitudeReference, AttitudeState
from liecontrol.control.kernel import NonFiniteTorque
from liecontrol.lie import so3

from ._fused import fused_supported, run_fused
from ._fused_wheels import run_fused_wheels
from ._kernels_sensors import unit_quaternion_matrix_batch
from ._kernels_wheels import WheelPlan
from ._log_memory import carve
from .disturbances import SumOfDisturbances
from .plant import PlantState, Spacecraft

#: the simulator's logger: one line per run that keeps the Python loop, naming the part
_logger = logging.getLogger("spacecraft.simulator")

__all__ = ["SimulationDiverged", "SimulationResult", "StarTrackerGyro", "simulate"]

#: relative tolerance on control_period / dt being an integer
_PERIOD_RTOL = 1e-9

#: longest run accepted: a longer horizon is a mistake (e.g. ``t_final`` in ms), not a plan
_MAX_STEPS = 10**10

_COLUMN_RE = re.compile(r"^(.*?)((?:\[\d+\])*)$")
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

#: dictionary groups of the log: (SimulationResult attribute, CSV column prefix)
_DICT_GROUPS = (
    ("actuator", "actuator"),
    ("controller", "controller"),
    ("disturbance_components", "disturbance"),
    ("modes", "modes"),
    ("sensors", "sensor"),
    ("estimate", "estimate"),
)


class SimulationDiverged(RuntimeError):
    """The plant state became non-finite.

    Attributes:
        time: simulation time [s] at which the non-finite state appeared.
        result: :class:`SimulationResult` with every row logged before that time, plus the last
            finite state.
    """

    def __init__(self, message: str, time: float, result: SimulationResult) -> None:
        super().__init__(message)
        self.time = time
        self.result = result


@dataclass(frozen=True)
class SimulationResult:
    """Logged closed-loop run: ``K`` samples of ``B`` spacecraft (numpy arrays).

    Attributes:
        t: ``(K,)`` sample times [s].
        R: ``(K, B, 3, 3)`` attitude (body → inertial).
        omega: ``(K, B, 3)`` body rate [rad/s].
        R_d: ``(K, B, 3, 3)`` desired attitude.
        omega_d: ``(K, B, 3)`` desired rate (desired body frame) [rad/s].
        u_cmd: ``(K, B, 3)`` controller torque command held from ``t`` on [N·m].
        u: ``(K, B, 3)`` internal torque the actuator delivers on the bus at ``t`` [N·m].
        disturbance: ``(K, B, 3)`` external torque at ``t`` [N·m].
        actuator: actuator log, ``(K, B, ...)`` arrays — SGCMG: ``delta`` (K,B,4) [rad],
            ``delta_dot`` (K,B,4) [rad/s], ``singularity`` (K,B), ``saturated`` (K,B) bool,
            ``h`` (K,B,3) [N·m·s].
        controller: controller diagnostics at the last control sample, ``(K, B, ...)``.
        dt: integration step [s].
        control_period: controller sampling period [s].
        disturbance_components: per-source torques ``(K, B, 3)`` when the plant's disturbance
            is a :class:`spacecraft.disturbances.SumOfDisturbances`, else empty.
        modes: with flexible modes: ``q``, ``q_dot`` ``(K, B, N)`` and the per-mode energy
            ``energy`` ``(K, B, N)`` [J] (``½(q̇² + λ²q²)``), else empty.
        sensors: each sensor's held output ``(K, B, ...)`` by name, else empty.
        estimate: with a ``measurement`` hook, the state the controller was last given:
            ``R`` ``(K, B, 3, 3)``, ``omega`` ``(K, B, 3)``; else empty (it saw the truth).
    """

    t: np.ndarray
    R: np.ndarray
    omega: np.ndarray
    R_d: np.ndarray
    omega_d: np.ndarray
    u_cmd: np.ndarray
    u: np.ndarray
    disturbance: np.ndarray
    actuator: dict[str, np.ndarray]
    controller: dict[str, np.ndarray]
    dt: float
    control_period: float
    disturbance_components: dict[str, np.ndarray] = field(default_factory=dict)
    modes: dict[str, np.ndarray] = field(default_factory=dict)
    sensors: dict[str, np.ndarray] = field(default_factory=dict)
    estimate: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    @property
    def batch_size(self) -> int:
        return int(self.R.shape[1])

    def attitude_error_angle(self) -> np.ndarray:
        """Geodesic angle between ``R`` and ``R_d``, ``θ = ‖log(R_dᵀ R)‖`` ∈ [0, π], ``(K, B)``
        [rad] (atan2 form: accurate near 0 and π)."""
        return so3.angle(np.swapaxes(self.R_d, -1, -2) @ self.R)

    def select(self, b: int) -> SimulationResult:
        """Spacecraft ``b`` alone, as a batch of one (arrays are views)."""
        B = self.batch_size
        b = int(b)
        if not -B <= b < B:
            raise ValueError(f"b: index {b} out of range for a batch of {B}")
        b %= B
        s = slice(b, b + 1)

        def sel(d: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
            return {k: v[:, s] for k, v in d.items()}

        return replace(
            self,
            R=self.R[:, s],
            omega=self.omega[:, s],
            R_d=self.R_d[:, s],
            omega_d=self.omega_d[:, s],
            u_cmd=self.u_cmd[:, s],
            u=self.u[:, s],
            disturbance=self.disturbance[:, s],
            **{attr: sel(getattr(self, attr)) for attr, _ in _DICT_GROUPS},
        )

    # -- export --------------------------------------------------------------------------------

    def _groups(self) -> list[tuple[str, np.ndarray]]:
        out = [
            ("R", self.R),
            ("omega", self.omega),
            ("R_d", self.R_d),
            ("omega_d", self.omega_d),
            ("u_cmd", self.u_cmd),
            ("u", self.u),
            ("disturbance", self.disturbance),
        ]
        for attr, prefix in _DICT_GROUPS:
            out += [(f"{prefix}.{k}", v) for k, v in getattr(self, attr).items()]
        return out

    def columns(self, batch_index: int = 0) -> dict[str, np.ndarray]:
        """Flat ``name -> (K,)`` columns for spacecraft ``batch_index``: ``t``, then each array
        with its trailing indices in brackets (``R[0][2]``, ``omega[1]``,
        ``actuator.delta[3]``), then the derived ``attitude_error`` [rad]."""
        one = self.select(batch_index)
        cols: dict[str, np.ndarray] = {"t": self.t}
        for name, arr in one._groups():
            a = arr[:, 0]
            tail = a.shape[1:]
            flat = a.reshape(a.shape[0], -1)
            for j, idx in enumerate(np.ndindex(*tail)):
                cols[name + "".join(f"[{i}]" for i in idx)] = flat[:, j]
        cols["attitude_error"] = one.attitude_error_angle()[:, 0]
        return cols

    def to_dataframe(self, batch_index: int = 0) -> Any:
        """A pandas ``DataFrame`` of :meth:`columns` (pandas is optional, imported here)."""
        try:
            import pandas as pd
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ImportError(
                "to_dataframe() needs pandas (pip install pandas); to_csv() works without it"
            ) from exc
        return pd.DataFrame(self.columns(batch_index))

    def to_csv(self, path: str | Path, batch_index: int = 0) -> None:
        """Write spacecraft ``batch_index`` to CSV (no pandas needed).

        Line 1 is a ``#`` comment with ``dt``, ``control_period`` and the boolean columns; line
        2 the column names of :meth:`columns`; then one row per sample at full precision
        (``%.17g``: floats round-trip exactly). Read back with :meth:`from_csv` (or
        ``pandas.read_csv(path, comment="#")``).
        """
        cols = self.columns(batch_index)
        bools = sorted({_COLUMN_RE.match(k).group(1) for k, v in cols.items() if v.dtype == bool})
        data = np.column_stack([v.astype(np.float64) for v in cols.values()])
        with open(path, "w", encoding="utf-8") as f:
            f.write(
                f"# liecontrol SimulationResult dt={self.dt!r} "
                f"control_period={self.control_period!r} bool={';'.join(bools)}\n"
            )
            f.write(",".join(cols) + "\n")
            np.savetxt(f, data, delimiter=",", fmt="%.17g")

    @classmethod
    def from_csv(cls, path: str | Path) -> SimulationResult:
        """Read a file written by :meth:`to_csv` back (a batch of one)."""
        with open(path, encoding="utf-8") as f:
            meta = f.readline()
            names = f.readline().strip().split(",")
            data = np.loadtxt(f, delimiter=",", ndmin=2)
        m = re.match(
            r"# liecontrol SimulationResult dt=(\S+) control_period=(\S+) bool=(\S*)", meta
        )
        if m is None or data.shape[1] != len(names):
            raise ValueError(f"path: {path} is not a SimulationResult CSV")
        bools = set(filter(None, m.group(3).split(";")))
        K = data.shape[0]
        groups: dict[str, list[tuple[tuple[int, ...], np.ndarray]]] = {}
        for j, name in enumerate(names):
            base, idx = _COLUMN_RE.match(name).groups()
            index = tuple(int(i) for i in re.findall(r"\d+", idx))
            groups.setdefault(base, []).append((index, data[:, j]))
        arrays: dict[str, np.ndarray] = {}
        for base, entries in groups.items():
            if base in ("t", "attitude_error"):
                continue
            if entries[0][0]:
                shape = tuple(max(e[0][d] for e in entries) + 1 for d in range(len(entries[0][0])))
            else:
                shape = ()
            a = np.empty((K, 1) + shape)
            for index, col in entries:
                a[(slice(None), 0) + index] = col
            arrays[base] = a.astype(bool) if base in bools else a
        sub: dict[str, dict[str, np.ndarray]] = {prefix: {} for _, prefix in _DICT_GROUPS}
        for key, arr in arrays.items():
            prefix, dot, rest = key.partition(".")
            if dot and prefix in sub:
                sub[prefix][rest] = arr
        return cls(
            t=groups["t"][0][1].copy(),
            R=arrays["R"],
            omega=arrays["omega"],
            R_d=arrays["R_d"],
            omega_d=arrays["omega_d"],
            u_cmd=arrays["u_cmd"],
            u=arrays["u"],
            disturbance=arrays["disturbance"],
            dt=float(m.group(1)),
            control_period=float(m.group(2)),
            **{attr: sub[prefix] for attr, prefix in _DICT_GROUPS},
        )


class _Log:
    """Preallocated ``(K, B, ...)`` log arrays filled row by row, in one allocation with the
    compiled loop's own log arrays ``extra`` (``{name: (shape, dtype)}``, in ``self.extra``):
    :mod:`spacecraft._log_memory`."""

    def __init__(
        self, K: int, B: int, extra: Mapping[str, tuple[tuple[int, ...], Any]] | None = None
    ) -> None:
        self.K, self.B = K, B
        f8 = np.float64
        shapes: dict[str, tuple[tuple[int, ...], Any]] = {
            "t": ((K,), f8),
            "R": ((K, B, 3, 3), f8),
            "omega": ((K, B, 3), f8),
            "R_d": ((K, B, 3, 3), f8),
            "omega_d": ((K, B, 3), f8),
            "u_cmd": ((K, B, 3), f8),
            "u": ((K, B, 3), f8),
            "disturbance": ((K, B, 3), f8),
        }
        extra = dict(extra or {})
        arrays = carve({**shapes, **{f"extra.{k}": v for k, v in extra.items()}})
        self.t = arrays["t"]
        self.R = arrays["R"]
        self.omega = arrays["omega"]
        self.R_d = arrays["R_d"]
        self.omega_d = arrays["omega_d"]
        self.u_cmd = arrays["u_cmd"]
        self.u = arrays["u"]
        self.disturbance = arrays["disturbance"]
        self.extra = {k: arrays[f"extra.{k}"] for k in extra}
        self.dicts: dict[str, dict[str, np.ndarray]] = {attr: {} for attr, _ in _DICT_GROUPS}
        self.rows = 0

    def put_dict(self, which: str, row: int, values: dict[str, Any]) -> None:
        store = self.dicts[which]
        for key, v in values.items():
            arr = store.get(key)
            if arr is None:
                v = np.asarray(v)
                arr = np.zeros(
                    (self.K,) + np.broadcast_shapes(v.shape, (self.B,) + v.shape[1:]), dtype=v.dtype
                )
                if arr.dtype.kind == "f":
                    arr[:row] = np.nan  # rows before the key first appeared
                store[key] = arr
            arr[row] = v

    def result(self, dt: float, control_period: float, plant: Spacecraft) -> SimulationResult:
        n = self.rows
        d = {w: {k: v[:n] for k, v in s.items()} for w, s in self.dicts.items()}
        derived = getattr(plant.actuator, "derived_log", None)
        if derived is not None and n > 0:
            d["actuator"].update(derived(d["actuator"]))
        if plant.modes is not None and "q" in d["modes"]:
            m = d["modes"]
            m["energy"] = plant.modes.modal_energy(m["q"], m["q_dot"])
        return SimulationResult(
            t=self.t[:n],
            R=self.R[:n],
            omega=self.omega[:n],
            R_d=self.R_d[:n],
            omega_d=self.omega_d[:n],
            u_cmd=self.u_cmd[:n],
            u=self.u[:n],
            disturbance=self.disturbance[:n],
            dt=dt,
            control_period=control_period,
            **d,
        )


class _PerSpacecraft:
    """Steps an unbatched controller (``batched = False``) once per spacecraft."""

    def __init__(self, controller: AttitudeController, B: int) -> None:
        self.controllers = [controller] + [copy.deepcopy(controller) for _ in range(B - 1)]

    def reset(self, t0: float, batch_size: int) -> None:
        for c in self.controllers:
            c.reset(t0, 1)

    def command(self, t: float, state: AttitudeState, ref: AttitudeReference) -> np.ndarray:
        out = []
        for b, c in enumerate(self.controllers):
            s = slice(b, b + 1)
            act = state.actuator_state
            st = AttitudeState.unchecked(  # slices of a state the caller built
                R=state.R[s],
                omega=state.omega[s],
                h=None if state.h is None else state.h[s],
                actuator_state=None if act is None else act[s],
            )
            rf = AttitudeReference.unchecked(
                R_d=ref.R_d[s] if np.ndim(ref.R_d) == 3 else ref.R_d,
                omega_d=ref.omega_d[s] if np.ndim(ref.omega_d) == 2 else ref.omega_d,
                omega_dot_d=ref.omega_dot_d[s]
                if np.ndim(ref.omega_dot_d) == 2
                else ref.omega_dot_d,
            )
            out.append(np.asarray(c.command(t, st, rf), dtype=np.float64).reshape(-1, 3))
        return np.concatenate(out, axis=0)

    def diagnostics(self) -> dict[str, np.ndarray]:
        diags = [c.diagnostics() for c in self.controllers]
        if not diags[0]:
            return {}
        return {k: np.concatenate([np.asarray(d[k]) for d in diags], axis=0) for k in diags[0]}


def _check_controller(controller: Any) -> None:
    for name in ("reset", "command"):
        if not callable(getattr(controller, name, None)):
            raise ValueError(f"controller: has no method {name}() (see liecontrol.control.base)")


# -- sensors in the loop -----------------------------------------------------------------------


@dataclass(frozen=True)
class StarTrackerGyro:
    """Measurement hook: attitude from one attitude sensor, rate from a gyro.

    ``hook(t, outputs, truth) -> AttitudeState(R, omega, h)`` with ``R`` from
    ``outputs[attitude]`` and ``omega`` from ``outputs[rate]`` (the held, i.e. zero-order-held,
    sensor outputs) and ``h``, ``actuator_state`` from ``truth`` (the actuator's own telemetry,
    e.g. gimbal encoders). The attitude output may be a matrix ``(B, 3, 3)``, a scalar-first
    quaternion ``(B, 4)`` or Euler angles ``(B, 3)`` in sequence ``seq`` — the forms of
    :class:`spacecraft.sensors.StarTracker` and :class:`spacecraft.sensors.TwoVectorAttitude`.
    No filtering: a raw-measurement loop (an estimator from :mod:`liecontrol.estimation` can be
    wrapped as any callable with the same signature).

    Args:
        attitude: name of the attitude sensor in ``simulate(..., sensors=...)``.
        rate: name of the rate gyro.
        seq: Euler sequence for ``(B, 3)`` attitude outputs (scipy notation).
    """

    attitude: str = "star_tracker"
    rate: str = "gyro"
    seq: str = "ZYX"

    def __post_init__(self) -> None:
        for name in ("attitude", "rate"):
            v = getattr(self, name)
            if not isinstance(v, str) or not _NAME_RE.match(v):
                # the names key simulate()'s sensors mapping, whose keys are identifiers
                raise ValueError(
                    f"{name}: expected a sensor name (an identifier: letters, digits, _), got {v!r}"
                )
        euler.to_matrix(np.zeros(3), self.seq)  # validates seq

    def required(self) -> tuple[str, ...]:
        """Sensor names this hook reads (checked by :func:`simulate`)."""
        return (self.attitude, self.rate)

    def __call__(
        self, t: float, outputs: Mapping[str, np.ndarray], truth: AttitudeState
    ) -> AttitudeState:
        y = np.asarray(outputs[self.attitude])
        # the form by rank against the state's, not by the trailing shape alone: a batch of 3
        # Euler-angle rows (3, 3) is not a matrix (the state's R is (3, 3, 3) then)
        vector = y.ndim == truth.omega.ndim
        if y.ndim == truth.R.ndim and y.shape[-2:] == (3, 3):
            R = y
        elif vector and y.shape[-1] == 4:
            R = _unit_quaternion_to_matrix(y)
        elif vector and y.shape[-1] == 3:
            # the compiled kernel of charts.euler.to_matrix, as the fused loop's hook
            i, j, k, ext = euler.kernel_axes(self.seq)
            a = np.ascontiguousarray(y, dtype=np.float64).reshape(-1, 3)
            R = _ke.to_matrix_batch(a, i, j, k, ext).reshape(y.shape[:-1] + (3, 3))
        else:
            raise ValueError(
                f"outputs: {self.attitude!r} has shape {y.shape}, not an attitude "
                "(B, 3, 3) matrix, (B, 4) quaternion or (B, 3) Euler angles"
            )
        omega = np.asarray(outputs[self.rate], dtype=np.float64)
        if omega.shape != truth.omega.shape or R.shape != truth.R.shape:
            raise ValueError(
                f"outputs: {self.rate!r} {omega.shape} / {self.attitude!r} {R.shape} do not "
                f"match the state's (B, 3) / (B, 3, 3) shapes {truth.omega.shape}, "
                f"{truth.R.shape}"
            )
        # every control sample: the cheap checks (shapes above, finiteness here) instead of
        # AttitudeState's full validation; R is a rotation by construction of the sensors'
        # output forms (normalised quaternion, Euler angles, or R exp(δ^))
        if not (_finite(omega) and _finite(R)):
            raise ValueError(f"outputs: {self.attitude!r} or {self.rate!r} is not finite")
        return AttitudeState.unchecked(
            R=R, omega=omega, h=truth.h, actuator_state=truth.actuator_state
        )


def _finite(a: np.ndarray) -> bool:
    """No NaN/inf in ``a``: one reduction (a NaN/inf anywhere makes the sum non-finite); for a
    single spacecraft's few entries a Python sum, ~4× cheaper than the numpy reduction."""
    return math.isfinite(sum(a.ravel().tolist()) if a.size <= 32 else a.sum())


def _unit_quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """R (body → inertial) of scalar-first quaternions ``(B, 4)``, normalised first (a sensor's
    output is unit up to round-off); the hook runs at every control sample, so this skips
    :func:`liecontrol.charts.quaternion.to_matrix`'s validation. The compiled kernel
    :func:`spacecraft._kernels_sensors.unit_quaternion_matrix_into` (the fused loop's):
    R = I + 2w v^ + 2 v^² with q = (w, v) (Hamilton, design.md)."""
    return unit_quaternion_matrix_batch(np.ascontiguousarray(q, dtype=np.float64))


def _horizon_steps(t0: object, t_final: object, dt: float) -> tuple[float, float, int]:
    """Validate the horizon ``[t0, t_final]`` for a fixed step ``dt`` (already checked > 0) and
    return ``(t0, t_final, n_steps)``.

    Rules (shared by :func:`simulate` and :func:`spacecraft.se3_plant.simulate_pose`):

    - a horizon shorter than one step is rejected: it would silently run (and log) to ``dt``,
      an arbitrary multiple of what was asked;
    - a horizon that is an integer multiple of ``dt`` (relative tolerance 1e-9, the rule of
      ``control_period`` and the sensor periods) runs ``(t_final − t0)/dt`` steps and ends at
      ``t_final`` exactly;
    - otherwise the run is rounded up to ``ceil((t_final − t0)/dt)`` whole steps (a fixed-step
      loop cannot stop between steps) and a ``UserWarning`` names the time it really ends at.
      Rounding up rather than rejecting because physical horizons (one orbital period ``2π/n``)
      are rarely multiples of the step; the overshoot is less than one step and is announced.
    """
    t0 = as_scalar(t0, "t0")
    t_final = as_scalar(t_final, "t_final")
    span = t_final - t0
    if not span > 0.0:
        raise ValueError(f"t_final: must be > t0 = {t0!r}, got {t_final!r}")
    ratio = span / dt
    if not math.isfinite(ratio) or ratio > _MAX_STEPS:
        raise ValueError(
            f"t_final: horizon t_final − t0 = {span!r} s is {ratio:.3g} steps of dt = {dt!r} s, "
            f"more than the limit of {_MAX_STEPS:.0e}"
        )
    if ratio < 1.0 - _PERIOD_RTOL:
        raise ValueError(
            f"t_final: horizon t_final − t0 = {span!r} s is shorter than one step dt = {dt!r} s"
        )
    n = round(ratio)
    if abs(ratio - n) > _PERIOD_RTOL * ratio:
        n = math.ceil(ratio)
        warnings.warn(
            f"t_final: horizon t_final − t0 = {span!r} s is not an integer multiple of "
            f"dt = {dt!r} s ({ratio!r} steps); the run takes {n} steps and ends at "
            f"t = {t0 + n * dt!r} s (pass that t_final to silence this warning)",
            UserWarning,
            stacklevel=3,
        )
    return t0, t_final, n


def _check_sensors(
    sensors: Mapping[str, Any] | None, dt: float
) -> tuple[tuple[str, Any, int], ...]:
    """Validate ``sensors`` and return ``(name, sensor, steps per sample)`` triples.

    Rule: every sensor's ``period`` must be a positive integer multiple of ``dt`` within a
    relative tolerance of 1e-9 (as ``control_period``), so sample times fall on steps.
    """
    if sensors is None:
        return ()
    if not isinstance(sensors, Mapping):
        raise ValueError(
            f"sensors: expected a mapping name -> sensor, got {type(sensors).__name__}"
        )
    out = []
    for name, sensor in sensors.items():
        if not isinstance(name, str) or not _NAME_RE.match(name):
            raise ValueError(
                f"sensors: name {name!r} must be an identifier (letters, digits, _): it names "
                "the log columns"
            )
        if not callable(getattr(sensor, "measure", None)):
            raise ValueError(f"sensors: {name!r} has no measure(t, R, omega, rng) method")
        period = getattr(sensor, "period", None)
        try:
            period = float(period)
        except (TypeError, ValueError):
            raise ValueError(f"sensors: {name!r} has no numeric period (got {period!r})") from None
        if not math.isfinite(period) or period <= 0:
            raise ValueError(f"sensors: {name!r} period must be finite and > 0, got {period!r}")
        ratio = period / dt
        every = round(ratio)
        if every < 1 or abs(ratio - every) > _PERIOD_RTOL * ratio:
            latency = getattr(sensor, "latency", None)
            update = getattr(sensor, "update_period", None)
            if isinstance(latency, float) and latency > 0 and isinstance(update, float):
                # a TimedSensor is called every gcd(update period, latency): name what the user
                # set, not that internal grid
                raise ValueError(
                    f"sensors: {name!r} latency {latency!r} and period {update!r} must both be "
                    f"integer multiples of dt = {dt!r} (the sensor is sampled every "
                    f"gcd(period, latency) = {period!r} s, ratio {ratio!r} to dt)"
                )
            raise ValueError(
                f"sensors: {name!r} period {period!r} is not a positive integer multiple of "
                f"dt = {dt!r} (ratio {ratio!r})"
            )
        out.append((name, sensor, every))
    return tuple(out)


def _check_workers(workers: Any) -> int:
    """``workers`` as an int in [1, the threads numba may use]."""
    from liecontrol._jit import max_threads

    workers = as_int(workers, "workers", 1)
    most = max_threads()
    if most is not None:
        if workers > most:
            raise ValueError(
                f"workers: at most {most} threads (numba.config.NUMBA_NUM_THREADS, set by the "
                f"NUMBA_NUM_THREADS environment variable), got {workers}"
            )
    return workers


def simulate(
    plant: Spacecraft,
    controller: AttitudeController,
    reference: Callable[[float], AttitudeReference],
    initial_state: PlantState,
    t_final: float,
    dt: float,
    control_period: float | None = None,
    log_every: int = 1,
    progress: bool = False,
    t0: float = 0.0,
    sensors: Mapping[str, Any] | None = None,
    measurement: Callable[[float, Mapping[str, np.ndarray], AttitudeState], AttitudeState]
    | None = None,
    rng: np.random.Generator | None = None,
    compute_delay: float = 0.0,
    workers: int = 1,
    backend: str = "numba",
) -> SimulationResult:
    """Run the closed loop from ``t0`` to ``t_final`` with fixed step ``dt``.

    Args:
        plant: the :class:`spacecraft.plant.Spacecraft` (rigid or with flexible modes).
        controller: an :class:`liecontrol.control.base.AttitudeController`; ``reset(t0, B)`` is
            called first (controllers with ``batched = False`` are deep-copied per spacecraft).
        reference: callable ``t -> AttitudeReference`` (e.g. ``ConstantAttitude(R_d)``); one
            with the attribute ``time_invariant = True`` (as ``ConstantAttitude``) is sampled
            once by the compiled loop.
        initial_state: :class:`PlantState` of ``B`` spacecraft (``plant.initial_state(...)``).
        t_final: final time [s], at least one step after ``t0`` (a shorter horizon is
            rejected). An integer multiple of ``dt`` (relative tolerance 1e-9) ends exactly at
            ``t_final``; otherwise the run takes ``ceil((t_final − t0)/dt)`` steps and a
            ``UserWarning`` gives the later end time.
        dt: integration step [s] > 0.
        control_period: controller sampling period [s], a positive integer multiple of ``dt``
            (relative tolerance 1e-9); default ``dt``. Zero-order hold in between.
        log_every: log one row every ``log_every`` steps (the final time is always logged).
        progress: show a tqdm progress bar.
        t0: initial time [s].
        sensors: mapping ``name -> sensor`` (e.g. :class:`spacecraft.sensors.StarTracker`,
            :class:`~spacecraft.sensors.RateGyro`); each has ``measure(t, R, omega, rng)`` and a
            ``period`` that must be a positive integer multiple of ``dt`` (relative tolerance
            1e-9), and optionally ``reset(batch_size, rng)`` (called first). Sampled at
            ``t0 + j·period`` on the true state, zero-order hold in between, logged in
            ``result.sensors``.
        measurement: hook ``(t, held sensor outputs, truth: AttitudeState) -> AttitudeState``
            turning the sensor outputs into what the controller sees (e.g.
            :class:`StarTrackerGyro`), called at each control sample; optional ``reset(t0, B)``
            and ``required() -> names``. Default: the controller sees the true state. The
            built-in sensors (:class:`~spacecraft.sensors.StarTracker` with quaternion or matrix
            output, :class:`~spacecraft.sensors.RateGyro`, either in a
            :class:`~spacecraft.sensors.TimedSensor`), :class:`StarTrackerGyro` and a hook
            whose ``fused_hook()`` gives an MEKF or a manifold UKF
            (:class:`spacecraft._fused_sensors.EstimatorHook`) run in the compiled loop, with
            the noise drawn from ``rng`` in the Python loop's order (the same result).
        rng: seeded ``numpy.random.Generator`` for the sensor noise (required with sensors).
        compute_delay: τ ≥ 0 [s], a non-negative integer multiple of ``dt`` (relative tolerance
            1e-9): the torque the controller computes at t_k reaches the actuator at t_k + τ
            (on-board computation and bus transfer); zero torque is applied before the first
            delayed command arrives. ``result.u_cmd`` logs the command applied from ``t`` on
            (computed at ``t − τ``). Default 0: applied at once, as without the argument.
            A delay not shorter than the run (no command would arrive) is rejected.
        workers: threads over which the compiled loop spreads the batch's spacecraft (numba's
            threading layer; each spacecraft's run is the same arithmetic in the same order, so
            the result is bit-identical for any count). Default 1: one thread. Opt-in because a
            process that has run a parallel region must not ``fork`` and use it again under
            GNU OpenMP (the ``process`` executor of :mod:`benchmarks` forks): use it in a main
            program, or with ``spawn``. At most ``numba.config.NUMBA_NUM_THREADS``; ignored
            (with the log line) when the run takes the Python loop.
        backend: ``"numba"`` (default): the compiled loop where plant and controller have
            kernels, else the Python loop. ``"jax"``: the same formulas run as one compiled JAX
            program (:func:`spacecraft.differentiable.simulate_jax`; needs
            ``pip install liecontrol[jax]``, else ``ImportError``), returning the same fields;
            for the configurations it supports (``ValueError`` naming the part otherwise):
            geometric PD, ideal torque actuator or SGCMG pyramid with singularity-robust
            steering, no disturbance, sensors or delay, logging at control samples.

    Returns:
        :class:`SimulationResult`.

    Raises:
        ValueError: bad arguments (message starts with the argument's name).
        SimulationDiverged: the state became non-finite; ``.result`` holds the log so far.
    """
    if backend != "numba":
        if backend != "jax":
            raise ValueError(f"backend: expected 'numba' or 'jax', got {backend!r}")
        from .differentiable import simulate_jax

        return simulate_jax(
            plant, controller, reference, initial_state, t_final, dt, control_period, log_every,
            t0, progress=progress, sensors=sensors, measurement=measurement, rng=rng,
            compute_delay=compute_delay, workers=workers,
        )  # fmt: skip
    if not isinstance(plant, Spacecraft):
        raise ValueError(f"plant: expected a Spacecraft, got {type(plant).__name__}")
    _check_controller(controller)
    if not callable(reference):
        raise ValueError("reference: must be callable as reference(t) -> AttitudeReference")
    state = plant.check_state(initial_state, "initial_state")
    dt = check_positive_scalar(dt, "dt")
    t0, t_final, n_steps = _horizon_steps(t0, t_final, dt)
    if control_period is None:
        control_period = dt
    control_period = check_positive_scalar(control_period, "control_period")
    ratio = control_period / dt
    every_ctrl = round(ratio)
    if every_ctrl < 1 or abs(ratio - every_ctrl) > _PERIOD_RTOL * ratio:
        raise ValueError(
            f"control_period: must be a positive integer multiple of dt = {dt!r}, "
            f"got {control_period!r} (ratio {ratio!r})"
        )
    compute_delay = as_scalar(compute_delay, "compute_delay")
    delay_steps = round(compute_delay / dt)
    if compute_delay < 0.0 or abs(compute_delay - delay_steps * dt) > _PERIOD_RTOL * max(
        compute_delay, dt
    ):
        raise ValueError(
            f"compute_delay: must be a non-negative integer multiple of dt = {dt!r}, "
            f"got {compute_delay!r} (ratio {compute_delay / dt!r})"
        )
    if delay_steps >= n_steps:
        # like a t_final shorter than one step: a run in which no command ever reaches the
        # actuator is an input mistake, not a meaningful open-loop run
        raise ValueError(
            f"compute_delay: must be shorter than the run, got {compute_delay!r} s for "
            f"{n_steps} step(s) of dt = {dt!r} from t0 = {t0!r} (no command would reach the "
            "actuator)"
        )
    log_every = as_int(log_every, "log_every", 1)
    workers = _check_workers(workers)
    sensor_list = _check_sensors(sensors, dt)
    if sensor_list and not isinstance(rng, np.random.Generator):
        raise ValueError(
            f"rng: a seeded numpy.random.Generator is required with sensors, got {rng!r}"
        )
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected numpy.random.Generator, got {type(rng).__name__}")
    if measurement is not None:
        if not callable(measurement):
            raise ValueError("measurement: must be callable as (t, outputs, truth) -> state")
        required = getattr(measurement, "required", None)
        names = {n for n, _, _ in sensor_list}
        for need in required() if callable(required) else ():
            if need not in names:
                raise ValueError(f"measurement: needs sensor {need!r}, sensors has {sorted(names)}")

    B = state.batch_size
    K = n_steps // log_every + 1 + (1 if n_steps % log_every else 0)
    try:
        log = _Log(K, B)
    except (MemoryError, ValueError):
        raise ValueError(
            f"log_every: a log of {K} rows × {B} spacecraft does not fit in memory "
            f"({n_steps} steps logged every {log_every}); log less often"
        ) from None

    ctrl: Any = controller
    if not getattr(controller, "batched", True) and B > 1:
        ctrl = _PerSpacecraft(controller, B)
    ctrl.reset(t0, B)
    # the whole loop in compiled code when plant and controller have kernels
    # (spacecraft._fused, liecontrol.control.kernel); the Python loop below runs the same
    # kernels one call at a time. Whichever part keeps the Python loop is logged once.
    # (a compute delay runs in the Python loop below: its command queue)
    reasons: list[str] = []
    fused = fused_supported(
        plant, ctrl, sensor_list, measurement, progress, batch_size=B,
        control_period=control_period, reasons=reasons, compute_delay=compute_delay,
    )  # fmt: skip
    # the fused loop draws the sensors' noise before it runs: a fallback starts from the same
    # generator state
    rng_state = rng.bit_generator.state if (fused is not None and rng is not None) else None
    if fused is not None:
        try:
            if isinstance(fused[0], WheelPlan):
                result = run_fused_wheels(
                    fused[0], fused[1], fused[2], plant, ctrl, reference, state.R,
                    state.packed(), t0, n_steps, dt, every_ctrl, log_every, control_period, _Log,
                    reasons, workers, rng, measurement,
                )  # fmt: skip
            else:
                result = run_fused(
                    fused, plant, ctrl, reference, state.R, state.packed(), t0, n_steps, dt,
                    every_ctrl, log_every, control_period, _Log, reasons, workers=workers, rng=rng,
                    measurement=measurement,
                )  # fmt: skip
        except NonFiniteTorque:
            # the controller's own (Python) command at the first sample: a built-in law raises
            # its precise error there (e.g. an infeasible funnel); else the kernel's error stands
            ctrl.reset(t0, B)
            x0 = state.packed()
            x_act = x0[:, plant.act_slice]
            h0 = plant.actuator.momentum(x_act)
            ctrl.command(t0, AttitudeState(state.R, x0[:, :3], h0, x_act), reference(t0))
            raise
        if result is not None:
            # DEBUG, not INFO: the fused loop is the normal case; INFO is for a slow run's cause
            _logger.debug("simulate: the compiled loop ran (%d spacecraft, %d steps)", B, n_steps)
            return result
        ctrl.reset(t0, B)  # a failing run is repeated below, which reports the failure
        if rng_state is not None:
            rng.bit_generator.state = rng_state
    if reasons:
        why = reasons[0]
        if ctrl is not controller and why.startswith(f"controller {type(ctrl).__name__} "):
            why = (
                f"controller {type(controller).__name__} is unbatched (batched = False: one "
                "Python copy per spacecraft)"
            )
        if workers > 1:
            why += f" (workers = {workers} applies to the compiled loop only: one thread runs)"
        _logger.info("simulate: the Python loop runs: %s", why)
    for _, sensor, _ in sensor_list:
        if callable(getattr(sensor, "reset", None)):
            sensor.reset(B, rng)
    if measurement is not None and callable(getattr(measurement, "reset", None)):
        measurement.reset(t0, B)

    actuator = plant.actuator
    a_sl = plant.act_slice
    has_modes = plant.modes is not None
    q_sl, qd_sl = plant.q_slice, plant.q_dot_slice
    has_diag = callable(getattr(ctrl, "diagnostics", None))
    has_mm = getattr(plant, "momentum_management", None) is not None
    components = (
        plant.disturbance.components if isinstance(plant.disturbance, SumOfDisturbances) else None
    )
    outputs: dict[str, np.ndarray] = {}
    seen: AttitudeState | None = None

    def record(t: float, R: np.ndarray, x: np.ndarray, held: Any, u_cmd: np.ndarray) -> None:
        row = log.rows
        omega = x[:, :3]
        x_act = x[:, a_sl]
        ref = reference(t)
        log.t[row] = t
        log.R[row] = R
        log.omega[row] = omega
        log.R_d[row] = ref.R_d
        log.omega_d[row] = ref.omega_d
        log.u_cmd[row] = u_cmd
        log.u[row] = actuator.body_torque(omega, x_act, held)
        log.disturbance[row] = plant.disturbance_torque(t, R, omega)
        log.put_dict("actuator", row, actuator.log(x_act, held))
        if has_mm:
            log.put_dict("actuator", row, plant.momentum_management_log(t, R, x_act))
        if has_diag:
            log.put_dict("controller", row, ctrl.diagnostics())
        if components is not None:
            log.put_dict("disturbance_components", row, components(t, R, omega))
        if has_modes:
            log.put_dict("modes", row, {"q": x[:, q_sl], "q_dot": x[:, qd_sl]})
        if outputs:
            log.put_dict("sensors", row, outputs)
        if seen is not None:
            log.put_dict("estimate", row, {"R": seen.R, "omega": seen.omega})
        log.rows = row + 1

    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_steps, unit="step", desc="simulate")
    bar_chunk = max(1, n_steps // 200)

    R = state.R
    x = state.packed()
    u_cmd = np.zeros((B, 3))
    # compute delay: commands wait in a FIFO of (first step applied, torque)
    u_applied = u_cmd
    pending: deque[tuple[int, np.ndarray]] = deque()
    step = plant.step_packed
    # the state is validated once above and checked finite after every step, so the built-in
    # actuators' unchecked command runs here (user actuators without one: their command)
    act_command = getattr(actuator, "command_unchecked", actuator.command)
    try:
        for k in range(n_steps + 1):
            t = t0 + k * dt
            for name, sensor, every in sensor_list:
                if k % every == 0:
                    outputs[name] = np.asarray(sensor.measure(t, R, x[:, :3], rng))
                    valid = getattr(sensor, "valid", None)  # e.g. sensors.TimedSensor's flag
                    if valid is not None:
                        outputs[name + "_valid"] = np.array(valid, dtype=bool)
            if k % every_ctrl == 0:
                omega = x[:, :3]
                h = actuator.momentum(x[:, a_sl])
                # the integrator's own arrays: no re-validation at every control step
                st = AttitudeState.unchecked(R=R, omega=omega, h=h, actuator_state=x[:, a_sl])
                if measurement is not None:
                    st = measurement(t, outputs, st)
                    seen = st
                u = ctrl.command(t, st, reference(t))
                u_cmd = np.asarray(u, dtype=np.float64)
                if u_cmd.shape != (B, 3):
                    raise ValueError(
                        f"controller: command() returned shape {u_cmd.shape}, expected {(B, 3)}"
                    )
                if not _finite(u_cmd):
                    raise SimulationDiverged(
                        f"controller returned a non-finite torque at t = {t:.6g} s",
                        time=t,
                        result=log.result(dt, control_period, plant),
                    )
                if delay_steps:
                    # a copy: a controller may reuse its output buffer at the next sample
                    pending.append((k + delay_steps, u_cmd.copy()))
            if delay_steps:
                while pending and pending[0][0] <= k:
                    u_applied = pending.popleft()[1]
            else:
                u_applied = u_cmd
            held = act_command(u_applied, x[:, :3], x[:, a_sl], t)
            logged = k % log_every == 0 or k == n_steps
            if logged:
                record(t, R, x, held, u_applied)
            if k == n_steps:
                break
            failure: BaseException | None = None
            try:
                with np.errstate(over="ignore", invalid="ignore"):
                    # a diverging state overflows inside the stages: reported below, not warned
                    R_next, x_next = step(t, R, x, held, dt)
            except (ArithmeticError, ValueError) as exc:
                # scalar math on an overflowed stage (math.sin(inf): "math domain error")
                failure = exc
            # one reduction per array: a NaN/inf anywhere makes the sum non-finite
            if failure is not None or not (_finite(x_next) and _finite(R_next)):
                if not logged:
                    record(t, R, x, held, u_applied)  # keep the last finite state
                t_bad = t0 + (k + 1) * dt
                why = "became non-finite" if failure is None else f"failed ({failure!r})"
                raise SimulationDiverged(
                    f"state {why} at t = {t_bad:.6g} s (step {k + 1} of {n_steps})",
                    time=t_bad,
                    result=log.result(dt, control_period, plant),
                ) from failure
            R, x = R_next, x_next
            if bar is not None and (k + 1) % bar_chunk == 0:
                bar.update(bar_chunk)
    finally:
        if bar is not None:
            bar.close()
    return log.result(dt, control_period, plant)
