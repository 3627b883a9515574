"""Sensors and the measurement hook in the compiled closed loop (:mod:`spacecraft._fused`).

The built-in sensors — :class:`~spacecraft.sensors.StarTracker` (quaternion, Euler-angle or
matrix output, per-axis or boresight noise, mounting misalignment),
:class:`~spacecraft.sensors.TwoVectorAttitude` with fixed reference directions (measured
directions exp(δᵢ^) Rᵀ rᵢ, TRIAD; Euler-angle, matrix or quaternion output; Wang et al. 2015
§1.2), :class:`~spacecraft.sensors.RateGyro` (every term of its error model) and any of them
wrapped in a :class:`~spacecraft.sensors.TimedSensor` (latency, scheduled and random outages) —
and the :class:`~spacecraft.simulator.StarTrackerGyro` hook (reading a quaternion, a matrix or
Euler angles in its own ``seq``) run in the fused loop with the formulas of
:mod:`spacecraft._kernels_sensors` and :mod:`liecontrol._kernels.euler`, the same kernels the
numpy classes call (``FORM_QUAT``, ``FORM_MATRIX``, ``FORM_EULER`` outputs; the Euler
sequence's axes in ``s_int[:, I_SEQ:]``). Exact classes only: a subclass (which may override
``measure``) keeps the Python loop, as does any other sensor, a ``TwoVectorAttitude`` with a
time-varying reference, and an estimator hook on anything but a tracker's quaternion;
:func:`sensor_plan` says why. A degenerate TRIAD pair (parallel measured directions) stops the
compiled run, which the Python loop repeats (and raises there).

**Estimator hooks.** A measurement hook may hand the loop a filter through the protocol method
``fused_hook()``, returning an :class:`EstimatorHook` (an MEKF, :mod:`liecontrol._kernels.mekf`,
or a manifold UKF, :mod:`liecontrol._kernels.ukf`, on the gyro model), or ``None`` for a
configuration without a kernel; after the run the loop calls its ``fused_finish(...)`` with the
filters' final state and consistency log (:func:`finish_hook`). The method speaks for the class
that defines it and its subclasses that keep its ``__call__``.
:class:`benchmarks.runner.FilteredAttitude` implements it for both of its filters. The filter
is chosen when the loop is compiled: the loop's ``sensing`` argument is :data:`SENSING_UKF` (a
type of its own) for the UKF, and :func:`filter_predict` / :func:`filter_update` resolve to
one filter's kernels from that type, so each compiled loop contains one filter.

**The noise.** Every draw of these sensors is independent of the state: at each sample the
Python loop draws, in the order of the ``sensors`` mapping, for each sensor sampled at that step
and publishing, a uniform per spacecraft (``TimedSensor`` with ``outage_rate`` > 0), then the
sensor's normals, ``(B, 3)`` per call (a star tracker: δ; a two-vector sensor: δ₁, then δ₂; a
gyro: the bias walk's — not at its first sample — then the white noise's). :func:`draw_noise`
makes the same calls on the run's generator before the loop (runs of one kind merged into one
call: numpy's ``Generator.standard_normal`` and ``random`` fill arrays element by element from
the bit stream, so the values and the generator's final state are those of the Python loop's
calls) and lays each spacecraft's draws out in the order its run consumes them, so the compiled
loop, which runs one spacecraft after another, reads one cursor per spacecraft.

**Sampling.** A sensor with period P is called at every ``P/dt``-th step on the true state;
its output is held (zero-order hold) and logged as ``result.sensors[name]`` (with
``name + "_valid"`` for a ``TimedSensor``); the hook turns the held outputs into the attitude
and rate the law sees at each control sample (``result.estimate``).

**Timing.** A ``TimedSensor`` keeps the last ``lag + 1`` true states it was shown (a ring per
spacecraft) and publishes, every ``pub_every``-th call, the wrapped sensor's measurement of the
oldest; the times ``t + tol`` its outage test compares with and whether ``t`` is in a scheduled
outage are computed before the loop by the class itself (:meth:`~spacecraft.sensors.
TimedSensor.in_scheduled_outage`), the outage update by :func:`~spacecraft._kernels_sensors.
outage_step`.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._jit import JIT_ENABLED, njit
from liecontrol._kernels import euler as KE
from liecontrol._kernels import filters as EK
from liecontrol._kernels import mekf as MK
from liecontrol._kernels import ukf as UK
from liecontrol._kernels.so3 import log_of

from . import _kernels_sensors as KS

#: noise of a run held in memory at most (else the Python loop runs)
MAX_NOISE_BYTES = 512 * 2**20

# sensor kinds and output forms
KIND_STAR = 0
KIND_GYRO = 1
KIND_TWO_VECTOR = 2
FORM_QUAT = 0
FORM_MATRIX = 1
FORM_RATE = 2
FORM_EULER = 3

# columns of the integer table s_int (S, N_INT)
I_KIND, I_EVERY, I_PUB, I_LAG, I_OUT, I_LEN, I_VALID, I_STATE, I_PAR, I_PUBOFF, I_RATE = range(11)
I_FORM = 11
# the Euler sequence of FORM_EULER: intrinsic axes i, j, k and the extrinsic flag
I_SEQ = 12
N_INT = 16

#: the loop's scratch per spacecraft: output (9), measured matrix (9), the star tracker's (9),
#: the two-vector sensor's (6)
N_TMP = 33
#: sin of the smallest angle between the two TRIAD directions accepted (sensors.PARALLEL_TOL)
PARALLEL_TOL = 1e-6
#: gimbal-lock threshold of the Euler outputs (charts.euler.FROM_MATRIX_LOCK_TOL)
EULER_LOCK_TOL = 1e-12

# per-sensor state row: outage end, held flag, the ring of (t, R, ω), then the gyro's state
S_END, S_HELD, S_RING = 0, 1, 2
RING_ENTRY = 13
# gyro state after the ring: bias (3), filter (3), t_last, has t_last, has filter
G_BIAS, G_FILT, G_TLAST, G_HAS_T, G_HAS_F = 0, 3, 6, 7, 8
N_GYRO_STATE = 9

# parameters: star tracker (mis 9, per_axis, σ 3, Lᵀ 9, mis_on); gyro (CT 9, ct_on, bw_on, f_c,
# σ_u 3, σ_v 3, q 3); a TimedSensor's D and p after its wrapped sensor's
P_STAR = 23
P_GYRO = 21
# a TwoVectorAttitude's: r₁ (3), r₂ (3), σ₁, σ₂
P_TWO_VECTOR = 8

HOOK_NONE = 0
HOOK_STAR_TRACKER_GYRO = 1
HOOK_MEKF = 2
HOOK_UKF = 3

#: the compiled loop's ``sensing`` argument with the UKF hook (without sensors it is ``None``,
#: with them ``True``): a type of its own, so the loop is compiled for it separately and the
#: filter is chosen at compile time (:func:`filter_predict`), the other loops keeping their code
SENSING_UKF = (HOOK_UKF,)

# h_int: hook, attitude output, its form, rate output, attitude valid flag (-1: none), gyro bias
# in the sensor state (-1: none), the hook's Euler sequence (i, j, k, extrinsic)
N_HINT = 10
# the estimator hook's parameters: σ_v, σ_u, Σ (9), P₀ (36), gate threshold, gate's max run;
# the UKF's then its weights γ, Wᵐ (13), Wᶜ (13)
N_HPAR = 49
N_HPAR_UKF = N_HPAR + 27
# its state per spacecraft: x (7), P (36), t_last, has filter, z_last (3), ω_last (3), gated run
H_X, H_P, H_T, H_HAS, H_Z, H_W, H_RUN = 0, 7, 43, 44, 45, 48, 51
N_HSTATE = 52
# its log per control sample: t, attitude error [rad], NEES (3), NEES (6), NIS, gated (−1: no
# update), consistency sample written
N_HLOG = 7


@dataclass(frozen=True)
class EstimatorHook:
    """What a measurement hook's ``fused_hook()`` returns for the compiled loop: a
    multiplicative EKF (:mod:`liecontrol._kernels.mekf`) or a manifold UKF
    (:mod:`liecontrol._kernels.ukf`) on the gyro model between
    the star tracker (quaternion output) and the gyro, with the semantics of
    :class:`benchmarks.runner.FilteredAttitude`: it starts at the first control sample from
    the tracker's quaternion with zero bias and ``P0``; at each later one it predicts over the
    time since the last with the mean of the gyro readings at both ends and updates with the
    tracker's roll/pitch/yaw when they changed and are valid (χ² gate of ``gate_threshold``,
    at most ``gate_max`` rejections in a row); the law sees R(q̂) and ω̃ − b̂. After the run the
    loop calls the hook's ``fused_finish(...)`` with the filters' final state and log.

    Attributes:
        attitude, rate: sensor names (a ``StarTracker`` with quaternion output, a ``RateGyro``).
        sigma_v, sigma_u: the gyro model's noise densities; Sigma: the tracker's body-frame
            noise covariance ``(3, 3)``; P0: the initial error covariance ``(6, 6)``.
        gate_threshold, gate_max: the χ² gate.
        gyro: the gyro whose true bias enters the 6-state NEES (the ``rate`` sensor), or None.
        kind: ``"mekf"`` (:class:`~liecontrol.estimation.MEKF`) or ``"ukf"``
            (:class:`~liecontrol.estimation.ManifoldUKF`).
        weights: the UKF's unscented-transform weights ``(γ, Wᵐ (13,), Wᶜ (13,))`` (its
            :attr:`~liecontrol.estimation.ManifoldUKF.weights`); unused by the MEKF.
    """

    attitude: str
    rate: str
    sigma_v: float
    sigma_u: float
    Sigma: np.ndarray
    P0: np.ndarray
    gate_threshold: float
    gate_max: int
    gyro: Any = None
    kind: str = "mekf"
    weights: tuple[float, np.ndarray, np.ndarray] | None = None

    def __post_init__(self) -> None:
        if self.kind not in ("mekf", "ukf"):
            raise ValueError(f"kind: expected 'mekf' or 'ukf', got {self.kind!r}")
        if self.kind == "ukf":
            w = self.weights
            if (
                w is None or len(w) != 3 or np.shape(w[1]) != (13,) or np.shape(w[2]) != (13,)
                or not float(w[0]) > 0.0
            ):  # fmt: skip
                raise ValueError(
                    "weights: the UKF needs (γ > 0, Wᵐ (13,), Wᶜ (13,)) for its 6-dim error"
                )

    @property
    def filter_name(self) -> str:
        """The numpy filter's name (``MEKF`` or ``ManifoldUKF``)."""
        return "MEKF" if self.kind == "mekf" else "ManifoldUKF"


def _owner(cls: type, attr: str) -> type | None:
    for c in cls.__mro__:
        if attr in c.__dict__:
            return c
    return None


def _estimator_hook(measurement: Any) -> tuple[EstimatorHook | None, str]:
    """The hook's :class:`EstimatorHook` (``fused_hook()``), or ``(None, why)``. The method
    speaks for the class that defines it and its subclasses that keep its ``__call__``."""
    name = type(measurement).__name__
    fh = getattr(measurement, "fused_hook", None)
    if not callable(fh):
        return None, f"the measurement hook {name} has no compiled kernel (StarTrackerGyro has)"
    o_call, o_hook = _owner(type(measurement), "__call__"), _owner(type(measurement), "fused_hook")
    if o_call is None or o_hook is None or not issubclass(o_hook, o_call):
        return None, (
            f"the measurement hook {name} overrides __call__ below its fused_hook (its "
            "compiled kernel is its parent's)"
        )
    spec = fh()
    if not isinstance(spec, EstimatorHook):
        return None, f"the measurement hook {name} has no compiled kernel for this configuration"
    return spec, ""


@dataclass
class SensorPlan:
    """The sensors and the hook of a run, checked for the compiled loop (:func:`sensor_plan`)."""

    names: list[str]
    sensors: list[Any]  # as given (a TimedSensor or the bare sensor)
    inner: list[Any]  # the sensor that measures
    every: list[int]  # steps per call
    hook: int
    hook_att: int  # index of the attitude sensor (hook)
    hook_rate: int
    estimator: EstimatorHook | None = None
    hook_seq: str = "ZYX"  # StarTrackerGyro's Euler sequence (Euler-angle attitude outputs)


def _unwrap(sensor: Any) -> tuple[Any, Any, str]:
    """``(timed wrapper or None, inner sensor, why not)`` of one entry of ``sensors``."""
    from .sensors import RateGyro, StarTracker, TimedSensor, TwoVectorAttitude

    timed = None
    inner = sensor
    if type(sensor) is TimedSensor:
        timed, inner = sensor, sensor.sensor
    if type(inner) is StarTracker:
        return timed, inner, ""
    if type(inner) is TwoVectorAttitude:
        if callable(inner.ref1) or callable(inner.ref2):
            return None, None, "a TwoVectorAttitude with a time-varying reference direction " \
                "(the compiled loop has constant ones)"  # fmt: skip
        return timed, inner, ""
    if type(inner) is RateGyro:
        return timed, inner, ""
    return None, None, f"the sensor {type(inner).__name__} has no compiled kernel"


def sensor_plan(sensor_list: Any, measurement: Any) -> tuple[SensorPlan | None, str]:
    """``(plan, "")`` when the sensors ``(name, sensor, steps per call)`` and the hook run in
    the compiled loop, else ``(None, why)``."""
    from .simulator import StarTrackerGyro

    names, sensors, inner, every = [], [], [], []
    seen: set[int] = set()
    for name, sensor, ev in sensor_list:
        timed, s, why = _unwrap(sensor)
        if s is None:
            return None, f"sensor {name!r}: {why}"
        for obj in (timed, s):
            if obj is not None:
                if id(obj) in seen:
                    return None, (
                        f"sensor {name!r} shares its {type(obj).__name__} object with another "
                        "sensor (one state, two schedules)"
                    )
                seen.add(id(obj))
        names.append(name)
        sensors.append(sensor)
        inner.append(s)
        every.append(int(ev))
    hook, att, rate = HOOK_NONE, -1, -1
    est = None
    if measurement is not None:
        from .sensors import RateGyro, StarTracker, TwoVectorAttitude

        if type(measurement) is StarTrackerGyro:
            hook = HOOK_STAR_TRACKER_GYRO
        else:
            est, why = _estimator_hook(measurement)
            if est is None:
                return None, why
            hook = HOOK_MEKF if est.kind == "mekf" else HOOK_UKF
        att, rate = names.index(measurement.attitude), names.index(measurement.rate)
        attitude_types = (StarTracker,) if est is not None else (StarTracker, TwoVectorAttitude)
        if type(inner[att]) not in attitude_types:
            return None, (
                f"the measurement hook reads its attitude from a {type(inner[att]).__name__} "
                "(the compiled hook reads a StarTracker's, and StarTrackerGyro a "
                "TwoVectorAttitude's)"
            )
        if type(inner[rate]) is not RateGyro:
            return None, (
                f"the measurement hook reads its rate from a {type(inner[rate]).__name__} "
                "(the compiled hook reads a RateGyro's)"
            )
        if est is not None:
            if inner[att].output != "quaternion":
                return None, "the estimator hook reads a StarTracker's quaternion output"
            if est.gyro is not None and est.gyro is not inner[rate]:
                return None, "the estimator hook's gyro is not its rate sensor"
    seq = measurement.seq if hook == HOOK_STAR_TRACKER_GYRO else "ZYX"
    return SensorPlan(names, sensors, inner, every, hook, att, rate, est, seq), ""


@dataclass
class SensorArrays:
    """The arrays the compiled loop reads and writes for the sensors (:func:`prepare`)."""

    s_int: np.ndarray  # (S, N_INT) int64
    s_par: np.ndarray  # flat float64
    pub_thr: np.ndarray  # per publication: t + tol
    pub_sched: np.ndarray  # per publication: 1.0 in a scheduled outage
    noise: np.ndarray  # (B, C)
    state: np.ndarray  # (B, n_state)
    y: np.ndarray  # (B, n_y) held outputs (and valid flags)
    h_int: np.ndarray  # (N_HINT,) hook, attitude output, its form, rate output, valid, bias
    seen: np.ndarray  # (B, 12) the hook's last R (9) and ω (3)
    n_est: int  # 12 with a hook, else 0
    h_par: np.ndarray  # (N_HPAR or N_HPAR_UKF,) the estimator hook's parameters (else empty)
    h_state: np.ndarray  # (B, N_HSTATE) its state per spacecraft (else (B, 0))


def empty_arrays(B: int) -> SensorArrays:
    """The arrays of a run without sensors (the loop's sensor stage does nothing)."""
    return SensorArrays(
        np.zeros((0, N_INT), dtype=np.int64), np.zeros(0), np.zeros(0), np.zeros(0),
        np.zeros((B, 0)), np.zeros((B, 0)), np.zeros((B, 0)),
        np.zeros(N_HINT, dtype=np.int64), np.zeros((B, 12)), 0, np.zeros(0), np.zeros((B, 0)),
    )  # fmt: skip


def _draw_counts(plan: SensorPlan, n_steps: int) -> tuple[np.ndarray, ...]:
    """The draw events of the run in the Python loop's order: per event (step, sensor,
    uniforms per spacecraft, normals per spacecraft)."""
    from .sensors import RateGyro, TwoVectorAttitude

    ks, ss, us, ns = [], [], [], []
    for s, (sensor, inner, ev) in enumerate(zip(plan.sensors, plan.inner, plan.every, strict=True)):
        pub = getattr(sensor, "_every", 1) if sensor is not inner else 1
        rate = sensor is not inner and sensor.outage_rate > 0
        calls = n_steps // ev + 1
        c = np.arange(0, calls, pub)
        ks.append(c * ev)
        ss.append(np.full(c.shape, s))
        us.append(np.full(c.shape, 1 if rate else 0))
        n = np.full(c.shape, 3)
        if type(inner) is RateGyro:
            n = np.full(c.shape, 6)
            n[:1] = 3  # no bias walk at the first sample
        elif type(inner) is TwoVectorAttitude:
            n = np.full(c.shape, 6)  # δ₁, then δ₂
        ns.append(n)
    k, s, u, n = (np.concatenate(a) for a in (ks, ss, us, ns))
    order = np.lexsort((s, k))
    return k[order], s[order], u[order], n[order]


def draw_noise(plan: SensorPlan, rng: np.random.Generator, B: int, n_steps: int) -> np.ndarray:
    """Every draw of the run's sensors from ``rng``, in the Python loop's order, as ``(B, C)``:
    row b is spacecraft b's draws in the order its run consumes them (module docstring)."""
    _, _, u, n = _draw_counts(plan, n_steps)
    # the draw calls in stream order, each (B, width): per event its uniforms (width 1), then
    # its normals, one (B, 3) call each
    calls = np.stack((u, n // 3), axis=1).ravel()  # per event: [1 or 0 uniform calls, normals]
    kinds = np.repeat(np.tile(np.array([1, 0]), u.shape[0]), calls)  # 1: uniform, 0: normal
    widths = np.where(kinds == 1, 1, 3)
    C = int(widths.sum())
    if B * C * 8 * 3 > MAX_NOISE_BYTES:  # the stream, its index and the rows
        raise MemoryError
    stream = np.empty(B * C)
    # runs of one kind in one call (numpy fills element by element: the same stream)
    pos = 0
    m = widths.shape[0]
    change = np.flatnonzero(np.diff(kinds)) + 1
    bounds = np.concatenate(([0], change, [m]))
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        size = B * int(widths[a:b].sum())
        if kinds[a] == 1:
            stream[pos : pos + size] = rng.random(size)
        else:
            stream[pos : pos + size] = rng.standard_normal(size)
        pos += size
    # call e occupies stream[B c_e : B c_e + B w_e] as (B, w_e); row b gets its w_e values
    c = np.concatenate(([0], np.cumsum(widths)[:-1]))
    ev = np.repeat(np.arange(m), widths)
    col = np.arange(C)
    idx = (B * c[ev] + (col - c[ev]))[None, :] + np.arange(B)[:, None] * widths[ev][None, :]
    return stream[idx]


def prepare(
    plan: SensorPlan, rng: np.random.Generator, B: int, t0: float, dt: float, n_steps: int
) -> SensorArrays:
    """The loop's sensor arrays after the sensors' ``reset`` (done by the caller): parameters,
    initial states, the publication times' outage data and the noise (:func:`draw_noise`).
    Raises ``MemoryError`` when the noise would not fit (the Python loop then runs)."""
    from liecontrol.charts import euler

    from .sensors import StarTracker, TwoVectorAttitude, _time_tol

    S = len(plan.names)
    s_int = np.zeros((S, N_INT), dtype=np.int64)
    pars: list[np.ndarray] = []
    thr: list[np.ndarray] = []
    sched: list[np.ndarray] = []
    n_par = n_state = n_y = n_pub = 0
    init: list[tuple[int, Any]] = []
    for s, (sensor, inner, ev) in enumerate(zip(plan.sensors, plan.inner, plan.every, strict=True)):
        timed = sensor if sensor is not inner else None
        pub = timed._every if timed is not None else 1
        lag = timed._lag if timed is not None else 0
        seq_axes = (0, 0, 0, 0)
        if type(inner) in (StarTracker, TwoVectorAttitude):
            form = {"quaternion": FORM_QUAT, "matrix": FORM_MATRIX, "euler": FORM_EULER}[
                inner.output
            ]
            length = {FORM_QUAT: 4, FORM_MATRIX: 9, FORM_EULER: 3}[form]
            if form == FORM_EULER:
                i, j, k, ext = euler.kernel_axes(inner.seq)
                seq_axes = (i, j, k, int(ext))
            extra_state = 0
        if type(inner) is StarTracker:
            kind = KIND_STAR
            mis_on, mis, per_axis, sigma, LT = inner.kernel_args()
            p = np.concatenate(
                (mis.ravel(), [float(per_axis)], sigma, np.asarray(LT).ravel(), [float(mis_on)])
            )
        elif type(inner) is TwoVectorAttitude:
            kind = KIND_TWO_VECTOR
            r1, r2 = inner.references(t0)
            p = np.concatenate((r1, r2, np.asarray(inner._sig, dtype=np.float64)))
        else:
            kind = KIND_GYRO
            form = FORM_RATE
            length = 3
            ct_on, CT, bw_on, fc, rw, white, q = inner.kernel_args()
            p = np.concatenate(
                (np.asarray(CT).ravel(), [float(ct_on), float(bw_on), fc], rw, white, q)
            )
            extra_state = N_GYRO_STATE
        rate_on = timed is not None and timed.outage_rate > 0
        if timed is not None:
            dur = float(timed.outage_duration) if rate_on else 0.0
            prob = timed.outage_probability if rate_on else 0.0
            p = np.concatenate((p, [dur, prob]))
        # a TimedSensor's outage test per publication: t + tol and the scheduled outages, by
        # the class's own functions at the Python loop's times t = t0 + k·dt
        times: list[float] = []
        if timed is not None:
            calls = n_steps // ev + 1
            times = [t0 + int(k) * dt for k in np.arange(0, calls, pub) * ev]
        thr.append(np.array([t + _time_tol(t) for t in times]))
        if timed is not None and timed.outages:
            sched.append(np.array([float(timed.in_scheduled_outage(t)) for t in times]))
        else:
            sched.append(np.zeros(len(times)))
        state_len = S_RING + RING_ENTRY * (lag + 1) + extra_state
        s_int[s] = (
            kind, ev, pub, lag, n_y, length, n_y + length if timed is not None else -1,
            n_state, n_par, n_pub, int(rate_on), form, *seq_axes,
        )  # fmt: skip
        gyro_off = n_state + S_RING + RING_ENTRY * (lag + 1)
        init.append((gyro_off, inner if kind == KIND_GYRO else None))
        n_y += length + (1 if timed is not None else 0)
        n_state += state_len
        n_par += p.shape[0]
        n_pub += len(times)
        pars.append(p)
    state = np.zeros((B, n_state))
    for s in range(S):
        state[:, s_int[s, I_STATE] + S_END] = -np.inf
    for off, gyro in init:
        if gyro is not None:
            st = gyro.state
            state[:, off + G_BIAS : off + G_BIAS + 3] = st.bias
    h_int = np.full(N_HINT, -1, dtype=np.int64)
    h_par = np.zeros(0)
    h_state = np.zeros((B, 0))
    h_int[0] = plan.hook
    if plan.hook != HOOK_NONE:
        a, r = plan.hook_att, plan.hook_rate
        h_int[1:4] = (s_int[a, I_OUT], s_int[a, I_FORM], s_int[r, I_OUT])
        h_int[4] = s_int[a, I_VALID]
        if plan.hook == HOOK_STAR_TRACKER_GYRO:
            i, j, k, ext = euler.kernel_axes(plan.hook_seq)
            h_int[6:10] = (i, j, k, int(ext))
    est = plan.estimator
    if est is not None:
        r = plan.hook_rate
        if est.gyro is not None:
            lag = s_int[r, I_LAG]
            h_int[5] = s_int[r, I_STATE] + S_RING + RING_ENTRY * (lag + 1) + G_BIAS
        h_par = np.concatenate((
            [float(est.sigma_v), float(est.sigma_u)],
            np.asarray(est.Sigma, dtype=np.float64).ravel(),
            np.asarray(est.P0, dtype=np.float64).ravel(),
            [float(est.gate_threshold), float(est.gate_max)],
        ))  # fmt: skip
        if est.kind == "ukf" and est.weights is not None:
            g, Wm, Wc = est.weights
            h_par = np.concatenate((
                h_par, [float(g)], np.asarray(Wm, dtype=np.float64),
                np.asarray(Wc, dtype=np.float64),
            ))  # fmt: skip
        h_state = np.zeros((B, N_HSTATE))
    noise = draw_noise(plan, rng, B, n_steps)
    return SensorArrays(
        s_int, np.concatenate(pars) if pars else np.zeros(0), np.concatenate(thr),
        np.concatenate(sched), np.ascontiguousarray(noise), state, np.zeros((B, n_y)), h_int,
        np.zeros((B, 12)), 12 if plan.hook != HOOK_NONE else 0, h_par, h_state,
    )  # fmt: skip


@njit
def sense_stage(
    k: int, t: float, R: np.ndarray, w: np.ndarray, s_int: np.ndarray, s_par: np.ndarray,
    pub_thr: np.ndarray, pub_sched: np.ndarray, noise: np.ndarray, cur: int,
    st: np.ndarray, y: np.ndarray, tmp: np.ndarray,
) -> int:  # fmt: skip
    """The sensors of one spacecraft at step ``k`` (time ``t``, true ``R``, ``w``): each
    sensor due at this step records the state in its ring and, at a publication, measures the
    state ``lag`` calls old with the draws at ``noise[cur:]`` and updates its held output
    ``y`` (module docstring). ``st`` is the spacecraft's sensor state row, ``tmp`` scratch
    (≥ :data:`N_TMP`). Returns the cursor after the draws used, or −1 when a
    ``TwoVectorAttitude``'s measured directions are parallel (TRIAD undetermined: the Python
    loop, which raises, is run instead)."""
    for s in range(s_int.shape[0]):
        every = s_int[s, I_EVERY]
        if k % every != 0:
            continue
        c = k // every
        lag = s_int[s, I_LAG]
        slots = lag + 1
        so = int(s_int[s, I_STATE])
        e = so + S_RING + (c % slots) * RING_ENTRY
        st[e] = t
        for i in range(3):
            for j in range(3):
                st[e + 1 + 3 * i + j] = R[i, j]
            st[e + 10 + i] = w[i]
        pub = s_int[s, I_PUB]
        if c % pub != 0:
            continue
        j_pub = c // pub
        c0 = c - lag if c >= lag else 0
        o = so + S_RING + (c0 % slots) * RING_ENTRY
        t_m = st[o]
        R_m = st[o + 1 : o + 10].reshape((3, 3))
        w_m = st[o + 10 : o + 13]
        po = s_int[s, I_PAR]
        kind = s_int[s, I_KIND]
        n_par = P_STAR if kind == KIND_STAR else P_GYRO if kind == KIND_GYRO else P_TWO_VECTOR
        out_now = False
        valid_off = s_int[s, I_VALID]
        if valid_off >= 0:  # a TimedSensor: the outage model
            hit = False
            if s_int[s, I_RATE] != 0:
                hit = noise[cur] < s_par[po + n_par + 1]
                cur += 1
            pi = s_int[s, I_PUBOFF] + j_pub
            out_now, end = KS.outage_step(
                st[so + S_END], pub_thr[pi], t, s_par[po + n_par], hit, pub_sched[pi] != 0.0
            )
            st[so + S_END] = end
        ylen = s_int[s, I_LEN]
        out = tmp[:9]
        if kind != KIND_GYRO:
            Rm = tmp[9:18].reshape((3, 3))
            if kind == KIND_STAR:
                mis = s_par[po : po + 9].reshape((3, 3))
                LT = s_par[po + 13 : po + 22].reshape((3, 3))
                KS.star_tracker_into(
                    R_m, s_par[po + 22] != 0.0, mis, s_par[po + 9] != 0.0,
                    s_par[po + 10 : po + 13], LT, noise[cur : cur + 3],
                    tmp[18:27].reshape((3, 3)), Rm,
                )  # fmt: skip
                cur += 3
            else:
                sin_min = KS.two_vector_into(
                    R_m, s_par[po : po + 3], s_par[po + 3 : po + 6], s_par[po + 6],
                    s_par[po + 7], noise[cur : cur + 3], noise[cur + 3 : cur + 6], tmp[27:33],
                    Rm,
                )  # fmt: skip
                cur += 6
                if sin_min < PARALLEL_TOL:
                    return -1
            form = s_int[s, I_FORM]
            if form == FORM_QUAT:
                KS.quaternion_into(Rm, out)
            elif form == FORM_EULER:
                KE.from_matrix_into(
                    Rm, s_int[s, I_SEQ], s_int[s, I_SEQ + 1], s_int[s, I_SEQ + 2],
                    s_int[s, I_SEQ + 3] != 0, EULER_LOCK_TOL, out,
                )  # fmt: skip
            else:
                for i in range(9):
                    out[i] = tmp[9 + i]
        else:
            g = so + S_RING + RING_ENTRY * slots
            advance = st[g + G_HAS_T] != 0.0
            dt = t_m - st[g + G_TLAST] if advance else 0.0
            zb = noise[cur : cur + 3]
            if advance:
                cur += 3
            zw = noise[cur : cur + 3]
            cur += 3
            KS.gyro_sample_into(
                w_m, st[g + G_BIAS : g + G_BIAS + 3], st[g + G_FILT : g + G_FILT + 3], advance,
                dt, s_par[po + 9] != 0.0, s_par[po : po + 9].reshape((3, 3)),
                s_par[po + 10] != 0.0, s_par[po + 11], s_par[po + 12 : po + 15],
                s_par[po + 15 : po + 18], s_par[po + 18 : po + 21], st[g + G_HAS_F] == 0.0, zb,
                zw, out,
            )  # fmt: skip
            st[g + G_TLAST] = t_m
            st[g + G_HAS_T] = 1.0
            st[g + G_HAS_F] = s_par[po + 10]
        yo = s_int[s, I_OUT]
        if st[so + S_HELD] == 0.0 or not out_now:
            for i in range(ylen):
                y[yo + i] = out[i]
        st[so + S_HELD] = 1.0
        if valid_off >= 0:
            y[valid_off] = 1.0 if (c >= lag and not out_now) else 0.0
    return cur


def sensing_marker(plan: SensorPlan | None) -> Any:
    """The compiled loop's ``sensing`` argument: ``None`` without sensors, :data:`SENSING_UKF`
    with the UKF hook, else ``True``."""
    if plan is None:
        return None
    if plan.estimator is not None and plan.estimator.kind == "ukf":
        return SENSING_UKF
    return True


@njit
def _mekf_predict(x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, hp: np.ndarray) -> bool:
    """:func:`liecontrol._kernels.mekf.mekf_gyro_predict` with its arguments from ``h_par``."""
    return MK.mekf_gyro_predict(x, P, u, dt, hp[0], hp[1])


@njit
def _ukf_predict(x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, hp: np.ndarray) -> bool:
    """:func:`liecontrol._kernels.ukf.ukf_gyro_predict` with its arguments from ``h_par``."""
    w = N_HPAR + 1
    return UK.ukf_gyro_predict(
        x, P, u, dt, hp[0], hp[1], hp[N_HPAR], hp[w : w + 13], hp[w + 13 : w + 26]
    )


@njit
def _mekf_update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, hp: np.ndarray, may_gate: bool
) -> tuple[int, float]:
    """:func:`liecontrol._kernels.mekf.mekf_gyro_update` with its arguments from ``h_par``."""
    return MK.mekf_gyro_update(x, P, z, hp[2:11].reshape((3, 3)), hp[47], may_gate)


@njit
def _ukf_update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, hp: np.ndarray, may_gate: bool
) -> tuple[int, float]:
    """:func:`liecontrol._kernels.ukf.ukf_gyro_update` with its arguments from ``h_par``."""
    w = N_HPAR + 1
    return UK.ukf_gyro_update(
        x, P, z, hp[2:11].reshape((3, 3)), hp[47], may_gate, hp[N_HPAR], hp[w : w + 13],
        hp[w + 13 : w + 26],
    )  # fmt: skip


def filter_predict(
    sensing: Any, x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, hp: np.ndarray
) -> bool:
    """The estimator hook's time update: the UKF's for :data:`SENSING_UKF`, else the MEKF's.
    Compiled, the choice is made from ``sensing``'s type at compile time (an overload), so each
    loop contains one filter; as plain Python, at run time."""
    if isinstance(sensing, tuple):
        return _ukf_predict(x, P, u, dt, hp)
    return _mekf_predict(x, P, u, dt, hp)


def filter_update(
    sensing: Any, x: np.ndarray, P: np.ndarray, z: np.ndarray, hp: np.ndarray, may_gate: bool
) -> tuple[int, float]:
    """The estimator hook's measurement update (as :func:`filter_predict`): ``(code, NIS)``,
    code 0 accepted, 1 gated, 2 failure."""
    if isinstance(sensing, tuple):
        return _ukf_update(x, P, z, hp, may_gate)
    return _mekf_update(x, P, z, hp, may_gate)


if JIT_ENABLED:
    from numba.core import types as _types
    from numba.extending import overload as _overload

    @_overload(filter_predict)
    def _filter_predict_impl(
        sensing: Any, x: Any, P: Any, u: Any, dt: Any, hp: Any
    ) -> Callable[..., bool]:
        step = _ukf_predict if isinstance(sensing, _types.BaseTuple) else _mekf_predict

        # (numba wants the implementation's parameters, annotations included, as the typer's)
        def impl(sensing: Any, x: Any, P: Any, u: Any, dt: Any, hp: Any) -> bool:
            return step(x, P, u, dt, hp)

        return impl

    @_overload(filter_update)
    def _filter_update_impl(
        sensing: Any, x: Any, P: Any, z: Any, hp: Any, may_gate: Any
    ) -> Callable[..., tuple[int, float]]:
        step = _ukf_update if isinstance(sensing, _types.BaseTuple) else _mekf_update

        def impl(sensing: Any, x: Any, P: Any, z: Any, hp: Any, may_gate: Any) -> tuple[int, float]:
            return step(x, P, z, hp, may_gate)

        return impl


@njit
def hook_stage(
    h_int: np.ndarray, h_par: np.ndarray, hs: np.ndarray, y: np.ndarray, seen: np.ndarray,
    t: float, R: np.ndarray, st: np.ndarray, hlog: np.ndarray, ci: int, b: int, sensing: Any,
) -> bool:  # fmt: skip
    """The measurement hook of one spacecraft at a control sample (time ``t``, true attitude
    ``R``): ``seen[:9]`` the attitude it gives the law, ``seen[9:]`` the rate.

    * :class:`~spacecraft.simulator.StarTrackerGyro`: the held quaternion as a matrix (or the
      held matrix) and the held gyro rate;
    * the estimator hook (:class:`EstimatorHook`; its state row ``hs``, its log row
      ``hlog[ci, b]``): R(q̂) and ω̃ − b̂ after the filter's step — the MEKF's, or the UKF's
      with ``sensing`` :data:`SENSING_UKF` (:func:`filter_predict`). False when the filter's
      covariance lost positive definiteness (the Python loop then reruns the run).
    """
    a = h_int[1]
    r = h_int[3]
    Rs = seen[:9].reshape((3, 3))
    if h_int[0] == HOOK_STAR_TRACKER_GYRO:
        if h_int[2] == FORM_QUAT:
            KS.unit_quaternion_matrix_into(y[a : a + 4], Rs)
        elif h_int[2] == FORM_EULER:
            KE.to_matrix_into(y[a : a + 3], h_int[6], h_int[7], h_int[8], h_int[9] != 0, Rs)
        else:
            for i in range(9):
                seen[i] = y[a + i]
        for i in range(3):
            seen[9 + i] = y[r + i]
        return True
    # the estimator hook (benchmarks.runner.FilteredAttitude's semantics); both filters start
    # as the ManifoldFilter constructor does (mekf_gyro_init)
    q = np.empty(4)
    n = math.sqrt(y[a] * y[a] + y[a + 1] * y[a + 1] + y[a + 2] * y[a + 2] + y[a + 3] * y[a + 3])
    for i in range(4):
        q[i] = y[a + i] / n
    z = EK.rpy_from_q(q.reshape((1, 4)))[0]
    x = hs[H_X : H_X + 7]
    P = hs[H_P : H_P + 36].reshape((6, 6))
    row = hlog[ci, b]
    row[4] = math.nan
    row[5] = -1.0
    if hs[H_HAS] == 0.0:
        if not MK.mekf_gyro_init(y[a : a + 4], h_par[11:47].reshape((6, 6)), x, P):
            return False
        hs[H_HAS] = 1.0
    else:
        dt = t - hs[H_T]
        if dt > 0.0:
            w_mid = np.empty(3)
            for i in range(3):
                w_mid[i] = 0.5 * (hs[H_W + i] + y[r + i])
            if not filter_predict(sensing, x, P, w_mid, dt, h_par):
                return False
        fresh = z[0] != hs[H_Z] or z[1] != hs[H_Z + 1] or z[2] != hs[H_Z + 2]
        valid = h_int[4] < 0 or y[h_int[4]] != 0.0
        if fresh and valid:
            code, nis = filter_update(sensing, x, P, z, h_par, hs[H_RUN] < h_par[48])
            if code == 2:
                return False
            hs[H_RUN] = hs[H_RUN] + 1.0 if code == 1 else 0.0
            row[4] = nis
            row[5] = 1.0 if code == 1 else 0.0
    hs[H_T] = t
    for i in range(3):
        hs[H_Z + i] = z[i]
        hs[H_W + i] = y[r + i]
    nq = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
    for i in range(4):
        q[i] = x[i] / nq
    KS.unit_quaternion_matrix_into(q, Rs)
    for i in range(3):
        seen[9 + i] = y[r + i] - x[4 + i]
    # consistency: the attitude error Log(R̂ᵀ R) and its NEES (and with the bias, the 6-state)
    E = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            E[i, j] = Rs[0, i] * R[0, j] + Rs[1, i] * R[1, j] + Rs[2, i] * R[2, j]
    d0, d1, d2 = log_of(E)
    e = np.empty(6)
    e[0], e[1], e[2] = d0, d1, d2
    row[0] = t
    row[1] = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    row[2] = MK.spd_quadratic(P[:3, :3].copy(), e[:3].copy())
    row[3] = math.nan
    g = h_int[5]
    if g >= 0:
        for i in range(3):
            e[3 + i] = st[g + i] - x[4 + i]
        row[3] = MK.spd_quadratic(P.copy(), e)
    row[6] = 1.0
    return True


def finish(
    plan: SensorPlan, arrays: SensorArrays, log_y: np.ndarray, log_est: np.ndarray,
    log_dicts: dict[str, dict[str, np.ndarray]], B: int, n_steps: int,
) -> None:  # fmt: skip
    """After the compiled run: the sensors' log (``result.sensors``, ``result.estimate``) and
    the sensors' final state written back, as the Python loop leaves them (a gyro's bias and
    filter, a ``TimedSensor``'s history, held output, outage ends and ``valid``)."""
    from .sensors import GyroState, RateGyro

    s_int, st, y = arrays.s_int, arrays.state, arrays.y
    K = log_y.shape[0]
    for s, name in enumerate(plan.names):
        sensor, inner = plan.sensors[s], plan.inner[s]
        off, length, voff = s_int[s, I_OUT], s_int[s, I_LEN], s_int[s, I_VALID]
        shape = (3, 3) if s_int[s, I_FORM] == FORM_MATRIX else (length,)
        log_dicts["sensors"][name] = log_y[:, :, off : off + length].reshape((K, B) + shape)
        if voff >= 0:
            log_dicts["sensors"][name + "_valid"] = log_y[:, :, voff] != 0.0
        every, lag, pub = (int(v) for v in s_int[s, [I_EVERY, I_LAG, I_PUB]])
        so = int(s_int[s, I_STATE])
        slots = lag + 1
        calls = n_steps // every + 1
        last_pub_call = ((calls - 1) // pub) * pub
        if type(inner) is RateGyro:
            g = so + S_RING + RING_ENTRY * slots
            c0 = last_pub_call - lag if last_pub_call >= lag else 0
            t_last = float(st[0, so + S_RING + (c0 % slots) * RING_ENTRY])
            filt = None
            if inner.bandwidth is not None:
                filt = st[:, g + G_FILT : g + G_FILT + 3].copy()
            inner.state = GyroState(
                bias=st[:, g + G_BIAS : g + G_BIAS + 3].copy(), t_last=t_last, filtered=filt
            )
        if sensor is not inner:
            held = y[:, off : off + length].reshape((B,) + shape).copy()
            sensor._held = held
            sensor._calls = calls
            sensor._outage_end = st[:, so + S_END].copy()
            sensor.valid = y[:, voff] != 0.0
            hist: deque[tuple[float, np.ndarray, np.ndarray | None]] = deque(maxlen=slots)
            for c in range(max(0, calls - slots), calls):
                e = so + S_RING + (c % slots) * RING_ENTRY
                hist.append(
                    (float(st[0, e]), st[:, e + 1 : e + 10].reshape(B, 3, 3).copy(),
                     st[:, e + 10 : e + 13].copy())
                )  # fmt: skip
            sensor._history = hist
    if arrays.n_est:
        log_dicts["estimate"]["R"] = log_est[:, :, :9].reshape(K, B, 3, 3)
        log_dicts["estimate"]["omega"] = log_est[:, :, 9:12]


def hook_log(arrays: SensorArrays, n_steps: int, every_ctrl: int, B: int) -> np.ndarray:
    """The estimator hook's log ``(control samples, B, N_HLOG)`` (empty without one)."""
    if arrays.h_state.shape[1] == 0:
        return np.zeros((0, B, N_HLOG))
    return np.full((n_steps // every_ctrl + 1, B, N_HLOG), np.nan)


def finish_hook(plan: SensorPlan, arrays: SensorArrays, log: np.ndarray, measurement: Any) -> None:
    """After the compiled run: the estimator hook's final filters and consistency log handed
    to its ``fused_finish(t_last, x (B, 7), P (B, 6, 6), z_last (B, 3), w_last (B, 3),
    gated_run (B,), logs)``, ``logs`` one dict per spacecraft of lists (``t``, ``err``,
    ``nees``, ``nees_full`` — empty without the gyro — ``nis``, ``gated``)."""
    if plan.estimator is None:
        return
    hs = arrays.h_state
    B = hs.shape[0]
    rejected = int(np.sum(log[:, :, 5] == 1.0))
    if rejected:
        # the numpy filter warns at each rejection; the compiled run once, with the count
        logging.getLogger("liecontrol.estimation").warning(
            "%s (compiled loop): %d innovation(s) rejected by the χ² gate over the run "
            "(threshold %.4g; the prediction was kept)",
            plan.estimator.filter_name,
            rejected,
            plan.estimator.gate_threshold,
        )
    logs = []
    for b in range(B):
        rows = log[:, b]
        rows = rows[rows[:, 6] == 1.0]
        upd = rows[:, 5] >= 0.0
        logs.append(
            {
                "t": rows[:, 0].tolist(),
                "err": rows[:, 1].tolist(),
                "nees": rows[:, 2].tolist(),
                "nees_full": rows[:, 3].tolist() if plan.estimator.gyro is not None else [],
                "nis": rows[upd, 4].tolist(),
                "gated": rows[upd, 5].tolist(),
            }
        )
    measurement.fused_finish(
        float(hs[0, H_T]), hs[:, H_X : H_X + 7].copy(),
        hs[:, H_P : H_P + 36].reshape(B, 6, 6).copy(), hs[:, H_Z : H_Z + 3].copy(),
        hs[:, H_W : H_W + 3].copy(), hs[:, H_RUN].astype(int), logs,
    )  # fmt: skip
