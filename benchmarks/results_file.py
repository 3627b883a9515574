"""Every time history of a suite or Monte Carlo run in one columnar file, with its provenance.

:func:`write_histories` writes a :class:`~benchmarks.runner.SuiteResult` (from
``run_suite(..., keep_histories=True)``) or a :class:`~benchmarks.montecarlo.MonteCarloResult`
(from ``run_montecarlo(..., keep_histories=True)``) to one Parquet file; :func:`load_histories`
reads it back in one call, bit for bit, as a :class:`Histories` (arrays per run, provenance,
units). The CLI writes it with ``run --histories`` (``OUT/histories.parquet``).

Why Parquet (through pyarrow) rather than netCDF (through xarray): the runs of one suite differ in
length (each scenario has its own horizon and logging period) and in columns (an SGCMG run logs
gimbal angles, a wheel run wheel speeds, an SE(3) run poses and wrenches), which a long ("tidy")
table holds as it is — one row per (run, sample), a column absent from a run is null there —
whereas netCDF wants one rectangular grid per variable (padding, or one group per run). pyarrow
is a single wheel with no dependency but numpy, where netCDF needs xarray, pandas and a netCDF or
HDF5 back end; and a Parquet file opens directly in pandas (``pandas.read_parquet``), polars,
DuckDB (``SELECT * FROM 'histories.parquet'``), Spark, R's ``arrow`` and MATLAB's
``parquetread``. The price is that multi-dimensional series are flattened into scalar columns —
``R[0][2]`` is the (0, 2) entry of R(t), the naming of
:meth:`spacecraft.simulator.SimulationResult.columns` — and :func:`load_histories` puts the
shapes back from the file's metadata.

Layout. Columns ``run`` (int32, index into the runs), ``scenario`` and ``controller``
(dictionary-encoded strings), ``sample`` (Monte Carlo sample index; null in a suite), ``t`` [s],
then one float64 (or bool) column per scalar component of every logged quantity. The
file's key-value metadata holds, under ``liecontrol``, one JSON document: ``format``
(:data:`FORMAT`), ``provenance`` (package and library versions, the run's kind, the suite or
the Monte Carlo configuration with its seeds, the scenarios with all their parameters, the
controllers with their descriptions and the closed-loop spec ``gain_rule`` they were tuned to),
``units`` (every history column's unit; :data:`HISTORY_UNITS`), and ``runs`` (per run: scenario,
controller, sample, status, error, verdict, flags, metrics with their units, and each array's
shape and dtype). NaN metrics are written as JSON ``NaN`` (Python's ``json`` reads them).

What is kept: the *full* logged histories — every sample the simulator logged (the suite logs
once per control period, at most every 0.5 s; the Monte Carlo every ``log_period``), not the
decimated series a :class:`~benchmarks.runner.RunOutcome` keeps for the figures — of the plant
and its references: attitude, rates, desired attitude and rates, commanded and delivered torque,
external torque (and its components), actuator states, flexible modes, sensor outputs and the
estimate the controller was given; SE(3) runs the poses, twists and wrenches. Controller
diagnostics are left out: their names and units belong to each controller (see its
``diagnostics()``). Histories are kept only when asked for (``keep_histories=True``), since a
full suite's histories are tens of megabytes that would otherwise travel back from every worker.

pyarrow is an optional dependency (``pip install 'liecontrol[results]'``), imported only when a
file is written or read.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import platform
import re
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .histories import history_arrays  # re-exported: the results file's unit of data

__all__ = [
    "DEFAULT_NAME",
    "FORMAT",
    "FORMATS",
    "HISTORY_UNITS",
    "Histories",
    "RunHistory",
    "history_arrays",
    "history_unit",
    "load_histories",
    "provenance",
    "require_pyarrow",
    "write_histories",
    "write_histories_with_report",
]

#: Format tag stored in every file (bumped if the layout changes).
FORMAT = "liecontrol-histories/1"
#: Results formats :func:`write_histories` knows.
FORMATS = ("parquet",)
_META_KEY = b"liecontrol"

#: Unit of each logged quantity (a column ``name[i][j]`` has the unit of ``name``). ``-`` is
#: dimensionless; an SE(3) pose or twist mixes units by block, written ``(rotation; translation)``.
HISTORY_UNITS: dict[str, str] = {
    "t": "s",
    # attitude runs (spacecraft.simulator.SimulationResult)
    "R": "- (rotation matrix, body to inertial)",
    "omega": "rad/s",
    "R_d": "- (rotation matrix, desired body to inertial)",
    "omega_d": "rad/s",
    "u_cmd": "N·m",
    "u": "N·m",
    "disturbance": "N·m",
    "attitude_error": "rad",
    "actuator.delta": "rad",
    "actuator.delta_dot": "rad/s",
    "actuator.delta_dot_cmd": "rad/s",
    "actuator.singularity": "-",
    "actuator.saturated": "bool",
    "actuator.h": "N·m·s",
    "actuator.wheel_speed": "rad/s",
    "actuator.wheel_torque": "N·m",
    "actuator.wheel_torque_cmd": "N·m",
    "actuator.torque_saturated": "bool",
    "actuator.speed_saturated": "bool",
    "modes.q": "kg^(1/2)·m (mass-normalised modal coordinate)",
    "modes.q_dot": "kg^(1/2)·m/s",
    "modes.energy": "J",
    "sensors.star_tracker": "- (unit quaternion, scalar first)",
    "sensors.gyro": "rad/s",
    "sensors.star_tracker_valid": "- (bool: a fresh output, not held through an outage)",
    "estimate.R": "- (rotation matrix, body to inertial)",
    "estimate.omega": "rad/s",
    # SE(3) runs (spacecraft.se3_plant.PoseSimulationResult)
    "g": "(-; m) (pose matrix: rotation block; position column)",
    "g_d": "(-; m) (pose matrix: rotation block; position column)",
    "xi": "(rad/s; m/s) (body twist: angular; linear)",
    "xi_d": "(rad/s; m/s) (body twist: angular; linear)",
    "wrench_cmd": "(N·m; N) (torque; force)",
    "wrench": "(N·m; N) (torque; force)",
    "saturated": "bool",
    "position_error": "m",
    "log_error": "(rad; m) (log(g_d⁻¹g)^∨: rotation; translation)",
}
_PREFIX_UNITS = {"disturbance_components.": "N·m"}  # one column per named disturbance source


def history_unit(name: str) -> str:
    """Unit of the logged quantity ``name`` (``"R"``, ``"actuator.delta"``; a flat column name
    such as ``"R[0][2]"`` is reduced to its quantity). ``ValueError`` for a quantity this module
    does not know (a new actuator's log key belongs in :data:`HISTORY_UNITS`)."""
    if not isinstance(name, str):
        raise TypeError(f"name: expected a str, got {type(name).__name__}")
    base = name.split("[", 1)[0]
    if base in HISTORY_UNITS:
        return HISTORY_UNITS[base]
    for prefix, unit in _PREFIX_UNITS.items():
        if base.startswith(prefix):
            return unit
    raise ValueError(f"name: no unit known for the logged quantity {base!r}")


# --------------------------------------------------------------------------- provenance


def _jsonable(v: Any) -> Any:
    """JSON form of provenance values: dataclasses and mappings as dicts, arrays and tuples as
    lists, numpy scalars as Python ones (NaN kept: Python's json writes and reads it)."""
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return {f.name: _jsonable(getattr(v, f.name)) for f in dataclasses.fields(v)}
    if isinstance(v, Mapping):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, np.ndarray):
        return _jsonable(v.tolist())
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.floating):
        return float(v)
    if isinstance(v, (str, int, float, bool)) or v is None:
        return v
    if callable(v):
        return f"{getattr(v, '__module__', '?')}.{getattr(v, '__qualname__', repr(v))}"
    return repr(v)


def _versions() -> dict[str, str]:
    from importlib import metadata

    import scipy

    import liecontrol

    try:
        pkg = metadata.version("liecontrol")
    except metadata.PackageNotFoundError:  # a source tree that is not installed
        pkg = liecontrol.__version__
    out = {
        "liecontrol": pkg,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
    }
    # pyarrow is the writer; a provenance record without it is still complete
    with contextlib.suppress(metadata.PackageNotFoundError):
        out["pyarrow"] = metadata.version("pyarrow")
    return out


def _controllers(names: Any, descriptions: Mapping[str, str] | None) -> dict[str, Any]:
    from .controllers import get_controller

    out: dict[str, Any] = {}
    for c in names:
        entry: dict[str, Any] = {}
        try:
            info = get_controller(c)
        except (KeyError, ValueError):  # registered at run time in another process
            info = None
        if info is not None:
            entry.update(
                description=info.description,
                control_period=info.control_period,
                batched=info.batched,
            )
        if descriptions and c in descriptions:
            entry["description"] = descriptions[c]
        out[c] = entry
    return out


def provenance(result: Any) -> dict[str, Any]:
    """What produced ``result`` (a ``SuiteResult`` or ``MonteCarloResult``), as JSON-ready data:
    library versions, platform, creation time (UTC), the run's kind, the suite name or the
    Monte Carlo configuration (root seed and sampling ranges), every scenario with all its
    parameters (its noise seed among them), the controllers with their descriptions, and the
    closed-loop spec ``gain_rule`` (ω_n [rad/s], ζ) the controllers were tuned to."""
    from .controllers import DEFAULT_GAIN_RULE
    from .montecarlo import MonteCarloResult
    from .runner import SuiteResult

    base = {
        "versions": _versions(),
        "platform": platform.platform(),
        "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    if isinstance(result, SuiteResult):
        rule = result.gain_rule or DEFAULT_GAIN_RULE
        return {
            **base,
            "kind": "suite",
            "suite": result.suite,
            "executor": result.executor,
            "wall_time_s": result.wall_time_s,
            "gain_rule": _jsonable(rule),
            "controllers": _controllers(result.controllers, result.descriptions),
            "scenarios": [_jsonable(s) for s in result.scenarios],
        }
    if isinstance(result, MonteCarloResult):
        return {
            **base,
            "kind": "montecarlo",
            "executor": result.executor,
            "wall_time_s": result.wall_time_s,
            # the Monte Carlo factories get ControllerContext's default rule
            "gain_rule": _jsonable(DEFAULT_GAIN_RULE),
            "controllers": _controllers(result.controllers, None),
            "config": _jsonable(result.config),
            "seeding": "sample k draws from numpy.random.default_rng("
            "SeedSequence(config.seed, spawn_key=(k,)))",
        }
    raise TypeError(
        f"result: expected a SuiteResult or MonteCarloResult, got {type(result).__name__}"
    )


# --------------------------------------------------------------------------- runs


def _runs(result: Any) -> list[tuple[dict[str, Any], dict[str, np.ndarray]]]:
    """``[(info, arrays)]`` of every run, in the result's order; ``ValueError`` if the result
    was produced without histories."""
    from .metrics import RUN_UNITS, UNITS
    from .montecarlo import MonteCarloResult

    units = {**UNITS, **RUN_UNITS}
    out: list[tuple[dict[str, Any], dict[str, np.ndarray]]] = []
    if isinstance(result, MonteCarloResult):
        if not result.histories and result.records:
            raise ValueError(
                "result: has no time histories; run run_montecarlo(..., keep_histories=True)"
            )
        for rec in result.records:
            arrays = result.histories.get((rec["controller"], rec["sample"]), {})
            info = {k: _jsonable(v) for k, v in rec.items()}
            info["scenario"] = "montecarlo"
            info["metric_units"] = {k: units[k] for k in rec if k in units}
            out.append((info, arrays))
        return out
    if not any(o.histories for o in result.outcomes) and any(
        o.status == "ok" for o in result.outcomes
    ):
        raise ValueError("result: has no time histories; run run_suite(..., keep_histories=True)")
    for o in result.outcomes:
        info = {
            "scenario": o.scenario,
            "controller": o.controller,
            "sample": None,
            "status": o.status,
            "error": o.error,
            "verdict": o.verdict,
            "flags": list(o.flags),
            "metrics": _jsonable(o.metrics),
            "metric_units": {k: units[k] for k in o.metrics if k in units},
        }
        out.append((info, o.histories))
    return out


def _flat(arrays: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``name → (K,)`` scalar columns (``R[0][2]``), row-major over the trailing axes."""
    cols: dict[str, np.ndarray] = {}
    for name, a in arrays.items():
        if a.ndim == 1:
            cols[name] = a
            continue
        flat = a.reshape(a.shape[0], -1)
        for j, idx in enumerate(np.ndindex(*a.shape[1:])):
            cols[name + "".join(f"[{i}]" for i in idx)] = flat[:, j]
    return cols


def require_pyarrow() -> tuple[Any, Any]:
    """``(pyarrow, pyarrow.parquet)``; ``ImportError`` saying how to install them."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as exc:
        raise ImportError(
            "results files need pyarrow: pip install 'liecontrol[results]' (or pyarrow)"
        ) from exc
    return pa, pq


def _check_format(format: Any) -> str:
    if not isinstance(format, str) or format.lower() not in FORMATS:
        raise ValueError(
            f"format: unknown results format {format!r}; supported: {', '.join(FORMATS)}"
        )
    return format.lower()


def _check_path(path: Any) -> Path:
    if not isinstance(path, (str, os.PathLike)) or not os.fspath(path):
        raise TypeError(f"path: expected a file path (str or os.PathLike), got {path!r}")
    return Path(path)


def write_histories(result: Any, path: str | os.PathLike, *, format: str = "parquet") -> Path:
    """Write every run's full time histories of ``result`` with their provenance to ``path``.

    Args:
        result: a ``SuiteResult`` from ``run_suite(..., keep_histories=True)`` or a
            ``MonteCarloResult`` from ``run_montecarlo(..., keep_histories=True)``.
        path: the file to write (its folder must exist; an existing file is replaced — the new
            file is written beside it and moved into place, so a failed write leaves it alone).
        format: ``"parquet"`` (the only one; module docstring for why).

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        ValueError: ``format`` unknown; ``path`` cannot be written (the OS error is quoted);
            ``result`` holds no histories.
        TypeError: ``result`` is not a suite or Monte Carlo result; ``path`` is not a path.
        ImportError: pyarrow is not installed.
    """
    from .montecarlo import MonteCarloResult
    from .runner import SuiteResult

    _check_format(format)
    path = _check_path(path)
    if not isinstance(result, (SuiteResult, MonteCarloResult)):
        raise TypeError(
            f"result: expected a SuiteResult or MonteCarloResult, got {type(result).__name__}"
        )
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise ValueError(f"path: {path} is a folder; give a file name (e.g. histories.parquet)")
    if not folder.is_dir():
        raise ValueError(f"path: folder {folder} does not exist")
    pa, pq = require_pyarrow()
    runs = _runs(result)
    prov = provenance(result)

    columns: dict[str, list[Any]] = {}
    run_idx, scen, ctrl, sample = [], [], [], []
    units: dict[str, str] = {}
    meta_runs = []
    for i, (info, arrays) in enumerate(runs):
        for name in arrays:
            units[name] = history_unit(name)
        K = int(arrays["t"].shape[0]) if "t" in arrays else 0
        meta_runs.append(
            {
                **info,
                "n_samples": K,
                "arrays": {
                    n: {"shape": list(a.shape[1:]), "dtype": a.dtype.str} for n, a in arrays.items()
                },
            }
        )
        if not K:
            continue
        run_idx.append(np.full(K, i, dtype=np.int32))
        scen += [info["scenario"]] * K
        ctrl += [info["controller"]] * K
        sample.append(np.full(K, -1 if info["sample"] is None else int(info["sample"])))
        flat = _flat(arrays)
        for name in columns.keys() - flat.keys():  # an earlier run's column: null here
            columns[name].append(pa.nulls(K, type=columns[name][0].type))
        for name, col in flat.items():
            arr = pa.array(col)
            if name not in columns:  # a new column: null in the earlier runs
                before = sum(len(r) for r in run_idx[:-1])
                columns[name] = [pa.nulls(before, type=arr.type)] if before else []
            columns[name].append(arr)
    n_rows = sum(len(r) for r in run_idx)
    sample_all = np.concatenate(sample) if sample else np.zeros(0, dtype=np.int64)
    table = {
        "run": pa.array(np.concatenate(run_idx) if run_idx else np.zeros(0, np.int32)),
        "scenario": pa.array(scen, type=pa.string()).dictionary_encode(),
        "controller": pa.array(ctrl, type=pa.string()).dictionary_encode(),
        "sample": pa.array(sample_all, mask=sample_all < 0, type=pa.int64()),
    }
    for name, chunks in columns.items():
        table[name] = pa.concat_arrays(chunks) if chunks else pa.nulls(n_rows, pa.float64())
    doc = {"format": FORMAT, "provenance": prov, "units": units, "runs": meta_runs}
    tab = pa.table(table).replace_schema_metadata(
        {_META_KEY: json.dumps(doc, allow_nan=True).encode("utf-8")}
    )
    # written beside the target and moved into place: a failed write leaves an old file alone
    # (an ordinary open, so the file gets the user's umask permissions)
    tmp = folder / f".{path.name}.{os.getpid()}.tmp"
    try:
        pq.write_table(tab, str(tmp))
        os.replace(tmp, path)
    except OSError as exc:
        raise ValueError(f"path: cannot write {path}: {exc.strerror or exc}") from exc
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


#: File name the CLI (``run --histories``) writes into the report folder.
DEFAULT_NAME = "histories.parquet"


def write_histories_with_report(
    result: Any, out_dir: str | os.PathLike, report: str | os.PathLike | None = None
) -> Path:
    """Write ``OUT/histories.parquet`` (:func:`write_histories`) and, when ``report`` (a
    Markdown file) is given, append a section saying what the file holds and how to load it.
    Returns the histories file's path."""
    path = write_histories(result, Path(out_dir) / DEFAULT_NAME)
    if report is not None:
        n = sum(1 for _, arrays in _runs(result) if arrays)
        note = (
            "\n## Time histories\n\n"
            f"`{DEFAULT_NAME}` (beside this report) holds the full logged time histories of "
            f"the {n} runs that logged samples, one Parquet table with the provenance (versions, "
            "seeds, scenarios, controllers and their tuning) and every column's unit in its "
            "metadata. Load it with `benchmarks.results_file.load_histories(path)`, or as a "
            "table with `pandas.read_parquet(path)`.\n"
        )
        with open(report, "a", encoding="utf-8") as f:
            f.write(note)
    return path


# --------------------------------------------------------------------------- loading


@dataclass(frozen=True)
class RunHistory:
    """One run of a results file.

    Attributes:
        info: ``scenario``, ``controller``, ``sample`` (Monte Carlo; else ``None``), ``status``,
            ``error``, ``verdict`` and ``flags`` (suite), the metrics (suite: ``metrics``; Monte
            Carlo: the record's keys) with ``metric_units``, ``n_samples``.
        arrays: ``name → (K, ...)`` histories as written (``t``, ``R`` (K, 3, 3), ...), empty
            for a run that logged nothing (``"n/a"``, or failed before its first sample).
    """

    info: dict[str, Any]
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def scenario(self) -> str:
        return self.info["scenario"]

    @property
    def controller(self) -> str:
        return self.info["controller"]


@dataclass(frozen=True)
class Histories:
    """A loaded results file: :attr:`runs` in the written order, :attr:`provenance`, the unit
    of every history quantity (:attr:`units`), and the :attr:`format` tag."""

    runs: tuple[RunHistory, ...]
    provenance: dict[str, Any]
    units: dict[str, str]
    format: str = FORMAT

    def run(
        self, scenario: str | None = None, controller: str | None = None, sample: int | None = None
    ) -> RunHistory:
        """The single run matching every given field (``ValueError`` for none or several)."""
        hits = [
            r
            for r in self.runs
            if (scenario is None or r.info["scenario"] == scenario)
            and (controller is None or r.info["controller"] == controller)
            and (sample is None or r.info.get("sample") == sample)
        ]
        if len(hits) != 1:
            keys = sorted({(r.scenario, r.controller) for r in self.runs})
            raise ValueError(
                f"scenario/controller/sample: {len(hits)} runs match "
                f"({scenario!r}, {controller!r}, {sample!r}); the file holds {keys}"
            )
        return hits[0]


_COL_RE = re.compile(r"^(.*?)((?:\[\d+\])*)$")


def load_histories(path: str | os.PathLike) -> Histories:
    """Read a file written by :func:`write_histories` back (arrays bit for bit, their shapes and
    dtypes, provenance, units). ``ValueError`` naming ``path`` if it is missing or is not such
    a file; ``ImportError`` without pyarrow."""
    path = _check_path(path)
    if not path.is_file():
        raise ValueError(f"path: no file {path}")
    pa, pq = require_pyarrow()
    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowInvalid) as exc:
        raise ValueError(f"path: {path} is not a Parquet file ({exc})") from exc
    raw = (table.schema.metadata or {}).get(_META_KEY)
    if raw is None:
        raise ValueError(f"path: {path} is not a liecontrol histories file (no metadata)")
    doc = json.loads(raw.decode("utf-8"))
    if doc.get("format") != FORMAT:
        raise ValueError(f"path: {path} has format {doc.get('format')!r}, expected {FORMAT!r}")
    run_col = table.column("run").to_numpy()
    order = np.argsort(run_col, kind="stable")
    bounds = np.searchsorted(run_col[order], np.arange(len(doc["runs"]) + 1))
    runs = []
    col_names = [n for n in table.column_names if n not in ("run", "scenario", "controller")]
    by_base: dict[str, list[tuple[tuple[int, ...], str]]] = {}
    for n in col_names:
        base, idx = _COL_RE.match(n).groups()
        by_base.setdefault(base, []).append((tuple(int(i) for i in re.findall(r"\d+", idx)), n))
    for i, meta in enumerate(doc["runs"]):
        rows = order[bounds[i] : bounds[i + 1]]
        sub = table.take(pa.array(rows)) if len(rows) else None
        arrays: dict[str, np.ndarray] = {}
        for name, spec in meta.pop("arrays").items():
            shape = tuple(spec["shape"])
            a = np.empty((len(rows),) + shape, dtype=np.dtype(spec["dtype"]))
            if sub is not None:  # a run that logged no sample has no rows
                parts = [(ix, c) for ix, c in by_base.get(name, []) if len(ix) == len(shape)]
                if len(parts) != math.prod(shape):  # never leave np.empty garbage in an array
                    raise ValueError(
                        f"path: {path}: run {i} lists {name!r} of shape {shape}, but the table "
                        f"has {len(parts)} of its {math.prod(shape)} columns"
                    )
                for index, col in parts:
                    a[(slice(None),) + index] = sub.column(col).to_numpy()
            arrays[name] = a
        runs.append(RunHistory(meta, arrays))
    return Histories(tuple(runs), doc["provenance"], doc["units"], doc["format"])
