"""Run scenarios × controllers and collect metrics (SPEC §8).

Batching: every (scenario, controller) pair is one spacecraft of a batched simulation. Pairs whose
scenarios share the plant and time grid (:meth:`Scenario.batch_key`) run together in a single
:func:`spacecraft.simulator.simulate` call: a :class:`StackedController` hands each pair its
slice of the batch (one controller instance per pair, so stateful controllers stay independent)
and a :class:`StackedReference` stacks the pairs' references. Groups run in parallel over local
processes (``jobs``); if a batched group raises, its pairs are re-run one by one so a failure is
recorded against the pair that caused it and the others still produce metrics.

Controller wall time (SPEC §8.2) is measured by :class:`TimedController`, a proxy implementing
the controller interface that times ``command()`` alone: mean wall time per call, per spacecraft.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from liecontrol.control import AttitudeController, AttitudeReference, AttitudeState

from .controllers import make_controller
from .metrics import compute_metrics, error_angle, rate_error
from .scenarios import DisturbanceSpec, Scenario, SpacecraftSpec

__all__ = [
    "RunOutcome",
    "SuiteResult",
    "TimedController",
    "StackedController",
    "StackedReference",
    "build_steering",
    "build_plant",
    "build_reference",
    "run_suite",
    "MAX_SERIES_POINTS",
]

#: Time series kept per run for the figures are decimated to at most this many samples.
MAX_SERIES_POINTS = 3000


# --------------------------------------------------------------------------- controller proxies


class TimedController(AttitudeController):
    """Proxy that forwards the controller interface and times ``command()`` alone.

    ``mean_time_per_call`` [s] and ``calls`` after a run; ``batched`` mirrors the inner one.
    """

    def __init__(self, inner: AttitudeController) -> None:
        self.inner = inner
        self.batched = bool(getattr(inner, "batched", True))
        self.total_time = 0.0
        self.calls = 0

    def reset(self, t0: float, batch_size: int) -> None:
        self.total_time = 0.0
        self.calls = 0
        self.inner.reset(t0, batch_size)

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        t_start = time.perf_counter()
        out = self.inner.command(t, state, reference)
        self.total_time += time.perf_counter() - t_start
        self.calls += 1
        return out

    def diagnostics(self) -> dict[str, np.ndarray]:
        return self.inner.diagnostics()

    @property
    def mean_time_per_call(self) -> float:
        return self.total_time / self.calls if self.calls else float("nan")


def _slice_ref(a: np.ndarray, sl: slice, core_ndim: int) -> np.ndarray:
    a = np.asarray(a)
    return a[sl] if a.ndim > core_ndim else a


class StackedController(AttitudeController):
    """Several controllers sharing one batch: member ``i`` drives spacecraft ``slices[i]``.

    Members with ``batched = False`` are stepped one spacecraft at a time within their slice.
    ``diagnostics()`` concatenates the keys every member reports with equal trailing shapes.
    """

    batched = True

    def __init__(self, members: Sequence[AttitudeController], sizes: Sequence[int]) -> None:
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
            m.reset(t0, n if getattr(m, "batched", True) else 1)

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        out = np.empty((state.R.shape[0], 3))
        for m, sl in zip(self.members, self.slices, strict=True):
            sub_ref = AttitudeReference(
                R_d=_slice_ref(reference.R_d, sl, 2),
                omega_d=_slice_ref(reference.omega_d, sl, 1),
                omega_dot_d=_slice_ref(reference.omega_dot_d, sl, 1),
            )
            h = None if state.h is None else state.h[sl]
            if getattr(m, "batched", True):
                out[sl] = m.command(t, AttitudeState(state.R[sl], state.omega[sl], h), sub_ref)
            else:
                for b in range(sl.start, sl.stop):
                    one = slice(b - sl.start, b - sl.start + 1)
                    ref_b = AttitudeReference(
                        R_d=_slice_ref(sub_ref.R_d, one, 2),
                        omega_d=_slice_ref(sub_ref.omega_d, one, 1),
                        omega_dot_d=_slice_ref(sub_ref.omega_dot_d, one, 1),
                    )
                    hb = None if h is None else h[one]
                    st = AttitudeState(state.R[b : b + 1], state.omega[b : b + 1], hb)
                    out[b : b + 1] = m.command(t, st, ref_b)
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


@dataclass(frozen=True)
class StackedReference:
    """Reference of a stacked batch: ``references[i](t)`` broadcast over ``sizes[i]`` spacecraft."""

    references: tuple[Callable[[float], AttitudeReference], ...]
    sizes: tuple[int, ...]

    def __call__(self, t: float) -> AttitudeReference:
        R_d, w_d, dw_d = [], [], []
        for ref, n in zip(self.references, self.sizes, strict=True):
            r = ref(t)
            R_d.append(np.broadcast_to(r.R_d, (n, 3, 3)))
            w_d.append(np.broadcast_to(r.omega_d, (n, 3)))
            dw_d.append(np.broadcast_to(r.omega_dot_d, (n, 3)))
        return AttitudeReference(
            R_d=np.concatenate(R_d), omega_d=np.concatenate(w_d), omega_dot_d=np.concatenate(dw_d)
        )


# --------------------------------------------------------------------------- plant from data


def build_steering(spec: SpacecraftSpec, cluster: Any) -> Any:
    """Steering law named by ``spec.steering``: ``"pinv-null-motion"`` (seed 000),
    ``"pinv"``, ``"sr"`` (singularity-robust)."""
    from spacecraft.steering import PseudoInverse, PseudoInverseNullMotion, SingularityRobust

    laws = {
        "pinv-null-motion": lambda: PseudoInverseNullMotion(cluster=cluster),
        "pinv": PseudoInverse,
        "sr": SingularityRobust,
    }
    try:
        return laws[spec.steering]()
    except KeyError:
        raise ValueError(
            f"steering: unknown steering law {spec.steering!r}; valid: {', '.join(sorted(laws))}"
        ) from None


def build_disturbance(spec: DisturbanceSpec) -> Any:
    """Disturbance source for ``spec`` (``None`` for ``"none"``)."""
    if spec.name == "none":
        return None
    from spacecraft.disturbances import Seed000Disturbance

    return Seed000Disturbance(**dict(spec.params))


def build_plant(spec: SpacecraftSpec, disturbance: DisturbanceSpec) -> Any:
    """The :class:`spacecraft.plant.Spacecraft` described by ``spec`` and ``disturbance``."""
    from spacecraft.actuators import SgcmgActuator
    from spacecraft.plant import Spacecraft
    from spacecraft.rigid_body import RigidBody
    from spacecraft.sgcmg import SgcmgPyramid

    cluster = SgcmgPyramid(
        h0=spec.h0, beta=float(np.deg2rad(spec.beta_deg)), gimbal_rate_limit=spec.gimbal_rate_limit
    )
    actuator = SgcmgActuator(
        cluster=cluster,
        steering=build_steering(spec, cluster),
        delta0=np.deg2rad(np.array(spec.delta0_deg)),
    )
    return Spacecraft(
        body=RigidBody(spec.J), actuator=actuator, disturbance=build_disturbance(disturbance)
    )


def build_reference(scenario: Scenario) -> Callable[[float], AttitudeReference]:
    from liecontrol.control import ConstantAttitude

    return ConstantAttitude(scenario.reference.R_d)


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class RunOutcome:
    """Result of one (scenario, controller) pair.

    Attributes:
        scenario, controller: names.
        status: ``"ok"`` or ``"failed"``.
        error: exception text when failed.
        metrics: :meth:`benchmarks.metrics.Metrics.as_dict` plus ``controller_time_us`` (mean
            wall time of one ``command()`` call per spacecraft [µs]) and ``sim_wall_time_s``
            (wall time of the simulation this pair was batched in, shared by the batch).
        series: decimated time series for the figures: ``t`` [s], ``error_deg``,
            ``rate_deg_s`` (‖ω − RᵀR_dω_d‖), ``gimbal_rate_rad_s`` (max_i |δ̇_i|),
            ``singularity`` (m); empty when nothing was logged.
    """

    scenario: str
    controller: str
    status: str
    error: str | None = None
    metrics: dict[str, Any] = field(default_factory=dict)
    series: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass(frozen=True)
class SuiteResult:
    """All outcomes of a suite run, in scenario-major order."""

    suite: str
    scenarios: tuple[Scenario, ...]
    controllers: tuple[str, ...]
    outcomes: tuple[RunOutcome, ...]
    wall_time_s: float

    def outcome(self, scenario: str, controller: str) -> RunOutcome:
        for o in self.outcomes:
            if o.scenario == scenario and o.controller == controller:
                return o
        raise KeyError((scenario, controller))

    @property
    def n_failed(self) -> int:
        return sum(o.status != "ok" for o in self.outcomes)


def _series(result: Any, b: int) -> dict[str, np.ndarray]:
    """Decimated per-spacecraft series for the figures."""
    t = np.asarray(result.t)
    K = t.shape[0]
    if K == 0:
        return {}
    idx = np.unique(np.linspace(0, K - 1, min(K, MAX_SERIES_POINTS)).astype(int))
    R = np.asarray(result.R)[idx, b]
    R_d = np.broadcast_to(np.asarray(result.R_d), np.asarray(result.R).shape)[idx, b]
    w = np.asarray(result.omega)[idx, b]
    w_d = np.broadcast_to(np.asarray(result.omega_d), np.asarray(result.omega).shape)[idx, b]
    out = {
        "t": t[idx],
        "error_deg": np.rad2deg(error_angle(R, R_d)),
        "rate_deg_s": np.rad2deg(np.linalg.norm(rate_error(R, w, R_d, w_d), axis=-1)),
    }
    act = getattr(result, "actuator", None) or {}
    if "delta_dot" in act:
        out["gimbal_rate_rad_s"] = np.abs(np.asarray(act["delta_dot"])[idx, b]).max(axis=-1)
    if "singularity" in act:
        out["singularity"] = np.asarray(act["singularity"])[idx, b]
    return out


def _error_text(exc: BaseException) -> str:
    where = getattr(exc, "time", None)
    text = f"{type(exc).__name__}: {exc}".strip()
    if where is not None and "t=" not in text and "t = " not in text:
        text += f" (at t={float(where):.3g} s)"
    return " ".join(text.split())


def _simulate_pairs(
    pairs: Sequence[tuple[Scenario, str]], progress: bool
) -> list[RunOutcome]:
    """Simulate ``pairs`` (same :meth:`Scenario.batch_key`) as one batch; raises on failure."""
    from spacecraft.simulator import simulate

    sc0 = pairs[0][0]
    plant = build_plant(sc0.spacecraft, sc0.disturbance)
    timed = [TimedController(make_controller(c, s.spacecraft)) for s, c in pairs]
    ctrl = StackedController(timed, [1] * len(pairs))
    ref = StackedReference(tuple(build_reference(s) for s, _ in pairs), (1,) * len(pairs))
    state = plant.initial_state(
        np.stack([s.R0 for s, _ in pairs]), np.stack([s.omega0 for s, _ in pairs])
    )
    t_start = time.perf_counter()
    result = simulate(
        plant,
        ctrl,
        ref,
        state,
        t_final=sc0.duration,
        dt=sc0.dt,
        control_period=sc0.control_period,
        progress=progress,
    )
    wall = time.perf_counter() - t_start
    metrics = compute_metrics(result)
    outcomes = []
    for b, ((s, c), tc) in enumerate(zip(pairs, timed, strict=True)):
        m = metrics.as_dict(b)
        m["controller_time_us"] = 1e6 * tc.mean_time_per_call
        m["sim_wall_time_s"] = wall
        outcomes.append(RunOutcome(s.name, c, "ok", None, m, _series(result, b)))
    return outcomes


def _run_group(pairs: Sequence[tuple[Scenario, str]], progress: bool) -> list[RunOutcome]:
    """Run a batch group; on failure isolate the failing pairs by re-running them one by one."""
    try:
        return _simulate_pairs(pairs, progress)
    except Exception as exc:  # noqa: BLE001 - failures are data in a benchmark report
        if len(pairs) > 1:
            out: list[RunOutcome] = []
            for p in pairs:
                out.extend(_run_group([p], False))
            return out
        s, c = pairs[0]
        partial = getattr(exc, "result", None)
        series: dict[str, np.ndarray] = {}
        if partial is not None:
            try:
                series = _series(partial, 0)
            except Exception:  # noqa: BLE001 - a broken partial log must not hide the error
                series = {}
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" [{tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}]" if tb else ""
        return [RunOutcome(s.name, c, "failed", _error_text(exc) + where, {}, series)]


def run_suite(
    scenarios: Sequence[Scenario],
    controllers: Sequence[str],
    *,
    suite: str = "custom",
    jobs: int | None = None,
    progress: bool = True,
) -> SuiteResult:
    """Run every scenario with every controller.

    Args:
        scenarios: the scenarios (see :mod:`benchmarks.scenarios`).
        controllers: registered controller names (:mod:`benchmarks.controllers`).
        suite: label stored in the result.
        jobs: worker processes (default: ``min(#batch groups, os.cpu_count())``; 1 runs
            in-process).
        progress: show a tqdm bar over the (scenario, controller) runs.

    Returns:
        :class:`SuiteResult` with one :class:`RunOutcome` per pair (scenario-major order).
    """
    from tqdm.auto import tqdm

    scenarios = tuple(scenarios)
    controllers = tuple(controllers)
    if not scenarios:
        raise ValueError("scenarios: empty")
    if not controllers:
        raise ValueError("controllers: empty")
    names = [s.name for s in scenarios]
    if len(set(names)) != len(names):
        raise ValueError(f"scenarios: duplicate names in {names}")
    for c in controllers:  # fail fast on unknown names, before any simulation
        make_controller(c, scenarios[0].spacecraft)

    groups: dict[tuple, list[tuple[Scenario, str]]] = {}
    for s in scenarios:
        for c in controllers:
            groups.setdefault(s.batch_key(), []).append((s, c))
    group_list = list(groups.values())
    if jobs is None:
        jobs = min(len(group_list), os.cpu_count() or 1)
    if jobs < 1:
        raise ValueError(f"jobs: must be >= 1, got {jobs}")

    t_start = time.perf_counter()
    outcomes: list[RunOutcome] = []
    n_runs = sum(len(g) for g in group_list)
    with tqdm(total=n_runs, desc=f"suite {suite}", unit="run", disable=not progress) as bar:
        if jobs == 1 or len(group_list) == 1:
            for g in group_list:
                bar.set_postfix_str(g[0][0].name)
                outcomes.extend(_run_group(g, False))
                bar.update(len(g))
        else:
            with ProcessPoolExecutor(max_workers=jobs) as pool:
                futures = {pool.submit(_run_group, g, False): g for g in group_list}
                for fut in as_completed(futures):
                    outcomes.extend(fut.result())
                    bar.update(len(futures[fut]))
    pair_names = [(s.name, c) for s in scenarios for c in controllers]
    order = {p: i for i, p in enumerate(pair_names)}
    outcomes.sort(key=lambda o: order[(o.scenario, o.controller)])
    return SuiteResult(
        suite=suite,
        scenarios=scenarios,
        controllers=controllers,
        outcomes=tuple(outcomes),
        wall_time_s=time.perf_counter() - t_start,
    )
