"""Monte Carlo sweep of the benchmark suite: random initial conditions, success rate, executors.

Samples: initial attitudes uniform on SO(3) (Haar: ``scipy`` ``Rotation.random``), initial body
rates with a uniform random direction and magnitude ``U(0, max_rate_deg_s)``, and an inertia error
per sample: the plant's principal moments scaled by ``U(1 − inertia_error, 1 + inertia_error)``
each (principal axes kept; redrawn until the triangle inequality holds) while the controllers are
given the nominal inertia. Regulation to the identity, no external disturbance, the SGCMG-bus
spacecraft by default.

Seeding. Sample ``k`` draws from its own generator ``numpy.random.default_rng(SeedSequence(seed,
spawn_key=(k,)))`` (= ``SeedSequence(seed).spawn(n)[k]``) — first its inertia scale, then its
attitude, then its rate — so every sample is a pure function of ``(seed, k)``: the same whichever
executor runs it, in whichever order, and whatever the ``chunk_size``.

Chunks. The samples are split into chunks of ``chunk_size``, the unit of work. A batched chunk is
one vectorized simulation whose plant carries one true inertia per sample
(:class:`spacecraft.rigid_body.RigidBody` with ``J`` of shape ``(B, 3, 3)``).

Execution. One task = (controller, chunk). A controller registered with ``batched=True`` flies
the whole chunk in one vectorized simulation (batch axis = samples); others fly it sample by
sample. Tasks run on an executor (:mod:`benchmarks.executors`): serial, local processes or a
dask.distributed cluster (``--scheduler ADDRESS``) — the results are identical (same seeds); a
task that fails is reported (its samples are "failed" with the error), never dropped.

Journal. With ``journal=PATH`` each finished chunk's records are appended to a JSON-lines file as
the chunk completes (the CLI writes ``OUT/montecarlo.chunks.jsonl``), so an interrupted sweep
keeps its finished chunks; ``resume=True`` reruns only the missing ones (docs/montecarlo.md).

Success: the run completed and its final attitude error is ≤ ``success_deg``.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol._validation import as_scalar, check_inertia, check_positive_scalar

from .controllers import ControllerContext, ControllerInfo, available_controllers, get_controller
from .executors import Executor, TaskFailure, describe_exception, make_executor
from .histories import history_arrays
from .metrics import compute_metrics
from .scenarios import SGCMG_SPACECRAFT, SpacecraftSpec

__all__ = [
    "MonteCarloConfig",
    "ChunkSamples",
    "MonteCarloResult",
    "chunk_samples",
    "run_chunk",
    "run_montecarlo",
    "read_journal",
    "MonteCarloInterrupted",
    "measure_throughput",
    "write_montecarlo_report",
    "RECORD_METRICS",
]

#: Per-sample metrics kept in the records (see :mod:`benchmarks.metrics`).
RECORD_METRICS = (
    "initial_error_deg",
    "final_error_deg",
    "settling_time_s",
    "peak_rate_deg_s",
    "effort_Nms",
    "peak_gimbal_rate_rad_s",
    "min_singularity",
    "unwinding_ratio",
)


def _posint(v: Any, name: str) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
        raise ValueError(f"{name}: must be a positive integer, got {v!r}")
    return int(v)


@dataclass(frozen=True)
class MonteCarloConfig:
    """Monte Carlo parameters (module docstring).

    Attributes:
        n_samples: number of samples (rounded up to whole chunks).
        chunk_size: samples per chunk (the batch of a batched run; does not change the draws).
        seed: root seed.
        max_rate_deg_s: largest initial rate magnitude [deg/s].
        inertia_error: relative half-width of the principal-moment scaling, in [0, 1).
        duration, dt, control_period: horizon and steps [s].
        spacecraft: the plant hardware (nominal inertia = the controllers' model).
        success_deg: final-error threshold of a successful run [deg].
        log_period: logging period for the metrics [s] (a multiple of dt).
    """

    n_samples: int = 128
    chunk_size: int = 32
    seed: int = 0
    max_rate_deg_s: float = 0.5
    inertia_error: float = 0.2
    duration: float = 600.0
    dt: float = 0.1
    control_period: float = 0.2
    spacecraft: SpacecraftSpec = field(default_factory=lambda: SGCMG_SPACECRAFT)
    success_deg: float = 1.0
    log_period: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "n_samples", _posint(self.n_samples, "n_samples"))
        object.__setattr__(self, "chunk_size", _posint(self.chunk_size, "chunk_size"))
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)):
            raise ValueError(f"seed: must be an integer, got {self.seed!r}")
        if self.seed < 0:
            raise ValueError(f"seed: must be >= 0, got {self.seed}")
        for name in ("duration", "dt", "control_period", "success_deg", "log_period"):
            object.__setattr__(self, name, check_positive_scalar(getattr(self, name), name))
        r = as_scalar(self.max_rate_deg_s, "max_rate_deg_s")
        if not r >= 0:
            raise ValueError(f"max_rate_deg_s: must be finite and >= 0, got {self.max_rate_deg_s}")
        object.__setattr__(self, "max_rate_deg_s", r)
        e = as_scalar(self.inertia_error, "inertia_error")
        if not 0 <= e < 1:
            raise ValueError(f"inertia_error: must be in [0, 1), got {self.inertia_error}")
        object.__setattr__(self, "inertia_error", e)
        if not isinstance(self.spacecraft, SpacecraftSpec):
            raise TypeError(
                f"spacecraft: must be a SpacecraftSpec, got {type(self.spacecraft).__name__}"
            )
        for name in ("control_period", "log_period"):
            ratio = getattr(self, name) / self.dt
            if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
                raise ValueError(f"{name}: must be a positive integer multiple of dt={self.dt}")

    @property
    def n_chunks(self) -> int:
        return -(-self.n_samples // self.chunk_size)


@dataclass(frozen=True)
class ChunkSamples:
    """The draws of one chunk's ``n`` samples: ``inertia_scale`` (n, 3), the plant's true
    inertias ``J`` (n, 3, 3), ``R0`` (n, 3, 3), ``omega0`` (n, 3) and the global ``sample``
    indices (n,)."""

    chunk: int
    inertia_scale: np.ndarray
    J: np.ndarray
    R0: np.ndarray
    omega0: np.ndarray
    sample: np.ndarray


def _draw_sample(
    k: int, seed: int, e: float, lam: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sample ``k``'s raw draws from its own generator (module docstring: a pure function of
    ``(seed, k)``): principal-moment scale ``(3,)``, attitude quaternion ``(4,)`` (unnormalised
    normal draws, as ``scipy``'s ``Rotation.random``), rate direction ``(3,)`` and magnitude
    fraction ``()``. ``lam`` are the nominal principal moments, for the rejection."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(int(k),)))
    for _ in range(1000):  # rejection: a physical body needs the triangle inequality
        scale = rng.uniform(1.0 - e, 1.0 + e, size=3)
        m = np.sort(lam * scale)
        if m[0] + m[1] - m[2] >= -1e-9 * m[2]:  # the criterion of check_inertia
            break
    else:  # pragma: no cover - needs an inertia at the edge of the physical set
        raise ValueError("inertia_error: no physical inertia drawn in 1000 tries")
    return scale, rng.normal(size=4), rng.normal(size=3), rng.uniform(0.0, 1.0)


def chunk_samples(cfg: MonteCarloConfig, chunk: int) -> ChunkSamples:
    """Draw chunk ``chunk`` of ``cfg``: samples ``chunk·chunk_size …``, each deterministic in
    ``(seed, sample index)`` alone (so independent of ``chunk_size``)."""
    if not isinstance(cfg, MonteCarloConfig):
        raise ValueError(f"cfg: expected a MonteCarloConfig, got {type(cfg).__name__}")
    if isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)):
        raise ValueError(f"chunk: must be an integer, got {chunk!r}")
    if not 0 <= chunk < cfg.n_chunks:
        raise ValueError(f"chunk: must be in [0, {cfg.n_chunks}), got {chunk}")
    start = chunk * cfg.chunk_size
    n = min(cfg.chunk_size, cfg.n_samples - start)
    lam, V = np.linalg.eigh(cfg.spacecraft.J)
    # one generator per sample (a loop over the chunk for the raw draws, ~25 µs a sample):
    # what makes a sample's draws independent of the chunking; the rest is vectorized
    draws = [_draw_sample(k, cfg.seed, cfg.inertia_error, lam) for k in range(start, start + n)]
    scale, quat, direction, frac = (np.array(a) for a in zip(*draws, strict=True))
    # J = V diag(λ ∘ s) Vᵀ, principal axes kept (scenarios.scale_principal_moments, batched)
    J = np.einsum("ij,bj,kj->bik", V, lam * scale, V)
    J = check_inertia(0.5 * (J + np.swapaxes(J, -1, -2)), "inertia_error")
    R0 = Rotation.from_quat(quat).as_matrix()  # Haar: normalised 4-D normal draws
    direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
    omega0 = direction * (np.deg2rad(cfg.max_rate_deg_s) * frac)[:, None]
    return ChunkSamples(chunk, scale, J, R0, omega0, np.arange(start, start + n))


@dataclass(frozen=True)
class _ChunkTask:
    cfg: MonteCarloConfig
    controller: str
    info: ControllerInfo
    chunk: int
    batched: bool
    histories: bool = False  # attach each sample's full logged histories to its record

    def __reduce__(self) -> tuple:
        from .runner import pack_infos

        return (
            _rebuild_chunk,
            (
                self.cfg,
                self.controller,
                pack_infos({self.controller: self.info}),
                self.chunk,
                self.batched,
                self.histories,
            ),
        )


def _rebuild_chunk(cfg, controller, packed, chunk, batched, histories=False) -> _ChunkTask:  # noqa: ANN001
    from .runner import unpack_infos

    info = unpack_infos(packed)[controller]
    return _ChunkTask(cfg, controller, info, chunk, batched, histories)


def _simulate(cfg: MonteCarloConfig, info: ControllerInfo, s: ChunkSamples, idx: slice) -> Any:
    from liecontrol.control import ConstantAttitude
    from spacecraft.simulator import simulate

    from .runner import HeldController, TimedController, build_plant

    B = len(s.sample[idx])
    # the plant flies each sample's own inertia (one shared (3, 3) J for a single run, the
    # ordinary single-spacecraft route); the controllers get the nominal one (ctx.spacecraft)
    plant = build_plant(cfg.spacecraft, (), s.J[idx][0] if B == 1 else s.J[idx])
    ctx = ControllerContext(
        spacecraft=cfg.spacecraft,
        control_period=info.control_period or cfg.control_period,
        batch_size=B,
        q_hint=None,
    )
    timed = TimedController(info.factory(ctx))
    ctrl: Any = timed
    period = cfg.control_period
    if info.control_period is not None and info.control_period > period * (1 + 1e-9):
        ctrl = HeldController(timed, info.control_period)
    elif info.control_period is not None:
        period = info.control_period  # a controller that needs faster sampling gets it
    state = plant.initial_state(s.R0[idx], s.omega0[idx])
    t0 = time.perf_counter()
    res = simulate(
        plant,
        ctrl,
        ConstantAttitude(np.eye(3)),
        state,
        t_final=cfg.duration,
        dt=cfg.dt,
        control_period=period,
        log_every=int(round(cfg.log_period / cfg.dt)),
    )
    return res, time.perf_counter() - t0, timed.mean_time_per_call


def run_chunk(task: _ChunkTask) -> list[dict[str, Any]]:
    """Executor entry point: the records of one (controller, chunk); batched or per sample."""
    cfg, info = task.cfg, task.info
    s = chunk_samples(cfg, task.chunk)
    n = len(s.sample)
    parts = [slice(0, n)] if task.batched else [slice(i, i + 1) for i in range(n)]
    records: list[dict[str, Any]] = []
    for part in parts:
        base = {"controller": task.controller, "chunk": task.chunk, "batched": task.batched}
        try:
            res, wall, t_call = _simulate(cfg, info, s, part)
        except Exception as exc:  # noqa: BLE001 - failures are data in the report
            err = describe_exception(exc)
            for k in range(part.start, part.stop):
                rec = {**base, "sample": int(s.sample[k]), "status": "failed", "error": err}
                rec["inertia_scale"] = s.inertia_scale[k].tolist()
                records.append(rec)
            continue
        m = compute_metrics(res)
        B = part.stop - part.start
        steps = int(round(cfg.duration / cfg.dt))
        for b in range(B):
            k = part.start + b
            rec = {**base, "sample": int(s.sample[k]), "status": "ok", "error": None}
            rec["inertia_scale"] = s.inertia_scale[k].tolist()
            d = m.as_dict(b)
            rec.update({key: d[key] for key in RECORD_METRICS})
            rec["success"] = bool(d["final_error_deg"] <= cfg.success_deg)
            rec["initial_rate_deg_s"] = float(np.rad2deg(np.linalg.norm(s.omega0[k])))
            rec["final_R"] = res.R[-1, b].ravel().tolist()
            rec["final_omega"] = res.omega[-1, b].tolist()
            rec["sim_wall_time_s"] = wall
            rec["batch"] = B
            rec["steps_per_s"] = B * steps / wall if wall > 0 else float("nan")
            rec["controller_time_us"] = 1e6 * t_call / B
            if task.histories:  # moved to MonteCarloResult.histories by run_montecarlo
                rec["histories"] = history_arrays(res, b)
            records.append(rec)
    return records


@dataclass(frozen=True)
class MonteCarloResult:
    """Per-sample records (dicts, sample-major per controller) and the run's metadata."""

    config: MonteCarloConfig
    controllers: tuple[str, ...]
    records: tuple[dict[str, Any], ...]
    wall_time_s: float
    executor: str
    #: with ``keep_histories=True``: ``(controller, sample) → `` full logged histories
    #: (:func:`benchmarks.results_file.history_arrays`) of each completed sample
    histories: dict[tuple[str, int], dict[str, np.ndarray]] = field(default_factory=dict)

    @property
    def n_failed(self) -> int:
        return sum(r["status"] != "ok" for r in self.records)

    def of(self, controller: str) -> list[dict[str, Any]]:
        return [r for r in self.records if r["controller"] == controller]

    def success_rate(self, controller: str) -> float:
        rs = self.of(controller)
        return sum(bool(r.get("success")) for r in rs) / len(rs) if rs else float("nan")

    def values(self, controller: str, key: str) -> np.ndarray:
        """``key`` over the completed samples of ``controller`` (NaN kept)."""
        return np.array([r[key] for r in self.of(controller) if r["status"] == "ok"], dtype=float)


def run_montecarlo(
    controllers: Sequence[str] | None = None,
    cfg: MonteCarloConfig = MonteCarloConfig(),
    *,
    executor: Executor | str | None = None,
    jobs: int | None = None,
    scheduler: str | None = None,
    batched: bool | None = None,
    progress: bool = True,
    journal: str | Path | None = None,
    resume: bool = False,
    keep_histories: bool = False,
) -> MonteCarloResult:
    """Run the sweep for ``controllers`` (default: the attitude controllers of the quick suite).

    ``batched=None`` follows each controller's registration; ``False`` forces sample-by-sample
    runs (the reference path the batched one is checked against); ``True`` forces the batched
    path. Returns a :class:`MonteCarloResult` with one record per (controller, sample).

    ``journal``: a JSON-lines file to which each finished chunk's records are appended (and
    flushed) as it completes, so an interrupted sweep keeps what it finished
    (:func:`read_journal`). ``resume=True`` reuses the chunks already in ``journal`` (written for
    the same configuration, else ``ValueError``) and runs only the others; without it an
    existing journal is started afresh. An interruption (Ctrl-C) raises
    :class:`MonteCarloInterrupted` (a ``KeyboardInterrupt``) saying how many chunks were kept.

    ``keep_histories=True`` keeps every completed sample's full logged histories in
    :attr:`MonteCarloResult.histories` (for :func:`benchmarks.results_file.write_histories`);
    the journal does not hold them, so it cannot be combined with ``resume``.
    """
    if not isinstance(resume, (bool, np.bool_)):
        raise TypeError(f"resume: must be a bool, got {resume!r}")
    if not isinstance(keep_histories, (bool, np.bool_)):
        raise TypeError(f"keep_histories: must be a bool, got {keep_histories!r}")
    if keep_histories and resume:
        raise ValueError(
            "keep_histories: chunks resumed from a journal carry no histories; "
            "rerun without resume"
        )
    if resume and journal is None:
        raise ValueError("resume: needs a journal file to resume from")
    if journal is not None:
        _check_path(journal, "journal")
    from tqdm.auto import tqdm

    from .controllers import quick_controllers

    if controllers is None:
        controllers = tuple(
            c for c in quick_controllers() if cfg.spacecraft.actuator in get_controller(c).plants
        )
    controllers = tuple(controllers)
    if not controllers:
        raise ValueError("controllers: empty")
    infos = {c: get_controller(c) for c in controllers}
    for c, info in infos.items():
        if cfg.spacecraft.actuator not in info.plants:
            plant = cfg.spacecraft.actuator
            valid = [n for n in available_controllers() if plant in get_controller(n).plants]
            raise ValueError(
                f"controllers: {c!r} does not apply to the {plant} plant; valid: {', '.join(valid)}"
            )
    tasks = [
        _ChunkTask(
            cfg,
            c,
            infos[c],
            i,
            infos[c].batched if batched is None else bool(batched),
            bool(keep_histories),
        )
        for c in controllers
        for i in range(cfg.n_chunks)
    ]
    done: dict[tuple[str, int, bool], list[dict[str, Any]]] = {}
    header: dict[str, Any] = {}
    if journal is not None:
        header = _journal_header(cfg)
        if resume:  # checked before anything runs: a journal of another configuration
            done = _load_journal(Path(journal), header)
    todo = [t for t in tasks if (t.controller, t.chunk, t.batched) not in done]
    own = not isinstance(executor, Executor)
    # the executor first: a scheduler that cannot be reached leaves an existing journal alone
    ex = (
        executor
        if isinstance(executor, Executor)
        else make_executor(executor, jobs=jobs, scheduler=scheduler)
    )
    t0 = time.perf_counter()
    writer: _JournalWriter | None = None

    n_kept = 0  # chunks finished (and journaled) in this call

    def finished(i: int, value: Any) -> None:
        nonlocal n_kept
        if isinstance(value, TaskFailure):
            return  # executor-level failures are not kept: a resume reruns them
        if writer is not None:
            t = todo[i]
            writer.write(t.controller, t.chunk, t.batched, value)
        n_kept += 1

    try:
        if journal is not None:
            writer = _JournalWriter(Path(journal), header, append=resume and bool(done))
        with tqdm(
            total=len(tasks),
            initial=len(tasks) - len(todo),
            desc="monte carlo",
            unit="chunk",
            disable=not progress,
        ) as bar:
            results = ex.map(run_chunk, todo, on_done=lambda i: bar.update(1), on_result=finished)
    except KeyboardInterrupt as exc:
        if own:
            ex.close()
        kept = len(tasks) - len(todo) + n_kept
        if writer is not None:
            writer.close()
            with contextlib.suppress(ValueError):  # the file is the truth (a Ctrl-C can land
                # between a chunk's write and its count)
                kept = len({(e["controller"], e["chunk"]) for e in read_journal(journal)[1]})
        raise MonteCarloInterrupted(kept, len(tasks), journal) from exc
    finally:
        if own:
            ex.close()
        if writer is not None:
            writer.close()
    by_key = dict(zip(((t.controller, t.chunk, t.batched) for t in todo), results, strict=True))
    by_key.update(done)
    records: list[dict[str, Any]] = []
    for task in tasks:
        res = by_key[(task.controller, task.chunk, task.batched)]
        if isinstance(res, TaskFailure):
            s = chunk_samples(cfg, task.chunk)
            records += [
                {"controller": task.controller, "chunk": task.chunk, "batched": task.batched,
                 "sample": int(k), "status": "failed", "error": res.error}
                for k in s.sample
            ]  # fmt: skip
        else:
            records += res
    histories: dict[tuple[str, int], dict[str, np.ndarray]] = {}
    for i, rec in enumerate(records):
        if "histories" in rec:  # kept apart: the records stay plain JSON-able data
            rest = {k: v for k, v in rec.items() if k != "histories"}
            histories[(rec["controller"], rec["sample"])] = rec["histories"]
            records[i] = rest
    return MonteCarloResult(
        cfg, controllers, tuple(records), time.perf_counter() - t0, ex.name, histories
    )


class MonteCarloInterrupted(KeyboardInterrupt):
    """A sweep stopped by Ctrl-C: ``kept`` of ``total`` chunks are in ``journal`` (if any)."""

    def __init__(self, kept: int, total: int, journal: str | Path | None) -> None:
        super().__init__(f"interrupted after {kept} of {total} chunks")
        self.kept, self.total, self.journal = kept, total, journal


_JOURNAL_FORMAT = "liecontrol-montecarlo-journal/1"


def _check_path(v: Any, name: str) -> str | os.PathLike:
    if not isinstance(v, (str, os.PathLike)) or str(v) == "":
        raise TypeError(f"{name}: must be a file path (str or Path), got {v!r}")
    return v


def _journal_header(cfg: MonteCarloConfig) -> dict[str, Any]:
    import liecontrol

    # the dataclass repr is exact (floats print round-trip) and covers the spacecraft, so two
    # configurations with the same fingerprint draw and fly the same samples
    return {
        "format": _JOURNAL_FORMAT,
        "config": repr(cfg),
        "liecontrol": liecontrol.__version__,
    }


def _json_default(v: Any) -> Any:
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    raise TypeError(f"record: cannot store {type(v).__name__} in the journal")


class _JournalWriter:
    """Appends one JSON line per finished chunk, flushed and fsync'ed: what a crash or Ctrl-C
    leaves behind is every chunk reported done (the last line at worst cut short)."""

    def __init__(self, path: Path, header: dict[str, Any], *, append: bool) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._fh = open(path, "a" if append else "w", encoding="utf-8")  # noqa: SIM115
        if not append:
            self._line(header)

    def _line(self, obj: dict[str, Any]) -> None:
        # NaN/inf (e.g. an unsettled run's settling time) are written as the JSON extensions
        # NaN/Infinity, which json.loads reads back: a resumed sweep gets the same floats
        self._fh.write(json.dumps(obj, default=_json_default) + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def write(self, controller: str, chunk: int, batched: bool, records: list) -> None:
        # full time histories stay out of the journal (they go to the results file)
        records = [{k: v for k, v in r.items() if k != "histories"} for r in records]
        self._line({"controller": controller, "chunk": chunk, "batched": batched,
                    "records": records})  # fmt: skip

    def close(self) -> None:
        self._fh.close()


def read_journal(journal: str | Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The header and the chunk entries (``controller``, ``chunk``, ``batched``, ``records``) of
    a sweep's journal, in completion order. A last line cut short by a crash is skipped; any
    other malformed line raises ``ValueError`` naming the line."""
    p = Path(_check_path(journal, "journal"))
    if not p.is_file():
        raise ValueError(f"journal: no such file {str(p)!r}")
    lines = p.read_text(encoding="utf-8").splitlines()
    entries: list[dict[str, Any]] = []
    header: dict[str, Any] | None = None
    for n, line in enumerate(lines, start=1):
        try:
            obj = json.loads(line)
        except json.JSONDecodeError:
            if n == len(lines):  # a write cut short by the interruption
                break
            raise ValueError(f"journal: {p}: line {n} is not valid JSON") from None
        if header is None:
            if not isinstance(obj, dict) or obj.get("format") != _JOURNAL_FORMAT:
                raise ValueError(f"journal: {p} is not a Monte Carlo journal ({_JOURNAL_FORMAT})")
            header = obj
        elif not isinstance(obj, dict) or not {"controller", "chunk", "records"} <= obj.keys():
            raise ValueError(f"journal: {p}: line {n} is not a chunk entry")
        else:
            entries.append(obj)
    if header is None:
        raise ValueError(f"journal: {p} is empty")
    return header, entries


def _load_journal(path: Path, header: dict[str, Any]) -> dict[tuple, list[dict[str, Any]]]:
    if not path.exists():
        return {}
    old, entries = read_journal(path)
    for key in ("config", "liecontrol"):
        if old.get(key) != header[key]:
            raise ValueError(
                f"resume: {path} was written for another {key} ({str(old.get(key))[:200]}, "
                f"now {str(header[key])[:200]}); remove it or run without resume"
            )
    # keep only the complete entries and rewrite the file without a cut-short last line
    good = [json.dumps(old, default=_json_default)] + [
        json.dumps(e, default=_json_default) for e in entries
    ]
    path.write_text("\n".join(good) + "\n", encoding="utf-8")
    return {(e["controller"], e["chunk"], bool(e.get("batched"))): e["records"] for e in entries}


def measure_throughput(
    controller: str = "geometric-pd-large-angle",
    batch_sizes: Sequence[int] = (1, 256),
    *,
    n_steps: int = 600,
    cfg: MonteCarloConfig | None = None,
) -> list[dict[str, float]]:
    """Spacecraft-steps per second (one process) of ``controller`` on the SGCMG plant for each
    batch size: ``B × n_steps / wall``. Batch 1 is the single-run baseline."""
    info = get_controller(controller)
    rows = []
    for B in batch_sizes:
        B = _posint(B, "batch_sizes")
        c = (
            MonteCarloConfig(
                n_samples=B,
                chunk_size=B,
                duration=n_steps * 0.1,
                dt=0.1,
                control_period=0.1,
                log_period=0.1 * n_steps,
            )
            if cfg is None
            else cfg
        )
        s = chunk_samples(c, 0)
        _simulate(c, info, s, slice(0, 1))  # warm-up (imports, caches)
        _, wall, _ = _simulate(c, info, s, slice(0, B))
        rows.append({"batch": B, "wall_s": wall, "steps_per_s": B * n_steps / wall})
    return rows


# --------------------------------------------------------------------------- report


def _clean(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def write_montecarlo_report(
    result: MonteCarloResult, out_dir: str | Path, *, figures: bool = True
) -> Path:
    """``montecarlo.md`` (success rates, metric quantiles, failures), ``montecarlo.csv``/
    ``.json`` and histogram/box-plot figures; returns the Markdown path."""
    from .report import figures_section, fmt, markdown_table

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cfg = result.config
    keys = ["controller", "sample", "chunk", "batched", "status", "error", "success",
            "initial_rate_deg_s", *RECORD_METRICS, "controller_time_us", "steps_per_s"]  # fmt: skip
    with open(out / "montecarlo.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(keys)
        for r in result.records:
            w.writerow(["" if r.get(k) is None else r.get(k) for k in keys])
    doc = {
        "config": {k: v for k, v in asdict(cfg).items() if k != "spacecraft"},
        "executor": result.executor,
        "wall_time_s": result.wall_time_s,
        "records": [{k: _clean(v) for k, v in r.items()} for r in result.records],
    }
    (out / "montecarlo.json").write_text(
        json.dumps(doc, indent=2, allow_nan=False), encoding="utf-8"
    )
    figs = _figures(result, out / "figures") if figures else {}
    lines = [
        "# Monte Carlo benchmark",
        "",
        f"{cfg.n_samples} samples (chunks of {cfg.chunk_size}, seed {cfg.seed}): Haar-uniform "
        f"attitudes, rates up to {cfg.max_rate_deg_s:g} °/s, principal moments × U(1 ± "
        f"{cfg.inertia_error:g}) per sample (controllers: nominal inertia); regulation to the "
        f"identity over {cfg.duration:g} s "
        f"(dt {cfg.dt:g} s, control {cfg.control_period:g} s). Success: final error ≤ "
        f"{cfg.success_deg:g}°. Executor {result.executor}, wall time {result.wall_time_s:.1f} s.",
        "",
        "## Success rate and metric distributions (median [5 %, 95 %])",
        "",
    ]
    rows = []
    for c in result.controllers:
        rs = result.of(c)
        ok = [r for r in rs if r["status"] == "ok"]
        row = [f"`{c}`", f"{100 * result.success_rate(c):.1f} %", f"{len(rs) - len(ok)}"]
        for key in ("settling_time_s", "final_error_deg", "unwinding_ratio", "effort_Nms"):
            v = result.values(c, key)
            v = v[np.isfinite(v)]
            row.append(
                "n/a" if v.size == 0
                else f"{fmt(float(np.median(v)))} [{fmt(float(np.quantile(v, 0.05)))}, "
                f"{fmt(float(np.quantile(v, 0.95)))}]"
            )  # fmt: skip
        sps = result.values(c, "steps_per_s")
        row.append(fmt(float(np.median(sps))) if sps.size else "n/a")
        rows.append(row)
    lines += markdown_table(
        ["controller", "success", "errors (runs that raised)", "settling time [s]",
         "final error [deg]",
         "unwinding ratio", "∫‖u‖dt [N·m·s]", "spacecraft-steps/s"],
        rows,
    )  # fmt: skip
    failed = [r for r in result.records if r["status"] != "ok"]
    if failed:
        lines += ["", "## Errors (runs that raised)", ""]
        seen: set[tuple[str, str]] = set()
        for r in failed:
            key = (r["controller"], r["error"])
            if key in seen:
                continue
            seen.add(key)
            n = sum(1 for x in failed if (x["controller"], x["error"]) == key)
            lines.append(f"- `{r['controller']}` ({n} samples): {r['error']}")
    lines += figures_section(figs, out)
    path = out / "montecarlo.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _figures(result: MonteCarloResult, fig_dir: Path) -> dict[str, Path]:
    from .report import _plt, controller_colors, save_png

    plt = _plt()
    fig_dir.mkdir(parents=True, exist_ok=True)
    colors = controller_colors(result.controllers)
    out: dict[str, Path] = {}
    panels = (
        ("settling_time_s", "settling time to 0.1° [s]"),
        ("final_error_deg", "final error [deg] (log)"),
        ("unwinding_ratio", "unwinding ratio"),
        ("effort_Nms", "∫‖u‖dt [N·m·s]"),
    )
    fig, axes = plt.subplots(2, 2, figsize=(12, 7.5), constrained_layout=True)
    for ax, (key, label) in zip(axes.flat, panels, strict=True):
        data, labels = [], []
        for c in result.controllers:
            v = result.values(c, key)
            v = v[np.isfinite(v)]
            if key == "final_error_deg":
                v = np.log10(np.maximum(v, 1e-8))
            data.append(v if v.size else np.array([np.nan]))
            labels.append(c)
        bp = ax.boxplot(data, patch_artist=True, showfliers=True)
        for patch, c in zip(bp["boxes"], result.controllers, strict=True):
            patch.set_facecolor(colors[c])
        ax.set_xticks(range(1, len(labels) + 1), labels, rotation=35, ha="right", fontsize=7)
        ax.set_ylabel(label if key != "final_error_deg" else "log₁₀ final error [deg]")
        ax.grid(True, axis="y", alpha=0.3)
    fig.suptitle("Monte Carlo metric distributions (box plots)", fontsize=10)
    out["metric distributions (box plots)"] = save_png(fig, fig_dir / "boxplots.png")

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    for c in result.controllers:
        v = result.values(c, "settling_time_s")
        v = v[np.isfinite(v)]
        if v.size:
            axes[0].hist(v, bins=20, histtype="step", lw=1.3, label=c, color=colors[c])
    axes[0].set_xlabel("settling time to 0.1° [s]")
    axes[0].set_ylabel("samples")
    if axes[0].get_legend_handles_labels()[0]:
        axes[0].legend(fontsize=7)
    else:
        axes[0].text(0.5, 0.5, "no run settled", ha="center", transform=axes[0].transAxes)
    axes[0].grid(True, alpha=0.3)
    rates = [100 * result.success_rate(c) for c in result.controllers]
    axes[1].bar(range(len(rates)), rates, color=[colors[c] for c in result.controllers])
    axes[1].set_xticks(
        range(len(rates)), list(result.controllers), rotation=35, ha="right", fontsize=7
    )
    axes[1].set_ylabel(f"success rate [%] (final error ≤ {result.config.success_deg:g}°)")
    axes[1].set_ylim(0, 105)
    axes[1].grid(True, axis="y", alpha=0.3)
    path = save_png(fig, fig_dir / "histogram_success.png")
    out["settling-time histogram and success rate"] = path
    return out
