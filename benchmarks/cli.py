"""Command line of the benchmark suite::

    python -m benchmarks run --suite quick --out report/        # the README's main command
    python -m benchmarks run --suite full|unwinding|montecarlo --out DIR
        [--controllers a,b] [--scenarios a,b] [--scenario-file FILE ...]
        [--t-final S | --horizon-scale X]
        [--jobs N] [--executor serial|process|dask] [--scheduler tcp://host:8786]
        [--samples N] [--chunk-size N] [--seed S] [--resume]  (montecarlo)
        [--no-progress] [--no-figures] [--sweep-bandwidth W1,W2,...]
        [--plugin MODULE_OR_FILE.py ...]
    python -m benchmarks run --list          # suites, scenarios, controllers, reproductions
    python -m benchmarks list [--plugin ...] # the same listing
    python -m benchmarks throughput [--controller NAME] [--batch 1,256] [--steps N]
    python -m benchmarks reproduce NAME --out DIR [--quick] [--plugin ...]
    python -m benchmarks reproduce --list    # each paper reproduction with its citation

(Installed, the same command is ``liecontrol-bench``; usage and help name whichever was
invoked.) ``run`` ends with one line counting the verdicts (e.g. ``57 runs + 21 not-applicable:
32 success, 8 degraded, 17 failed, 0 error``). It exits 0 when every run completed — a
``failed`` verdict (the controller missed the scenario's tolerance) is a finding, not a crash —
1 when some run raised (verdict ``error``; it is in the report with its error; the rule:
:data:`EXIT_STATUS_RULE`), 2 for bad
arguments (unknown names are listed with the valid ones; a malformed scenario
file names the offending key; an unreachable dask scheduler is reported before anything runs; a
selection in which no controller applies to any scenario says why). ``--plugin`` (repeatable)
imports a module by name or a ``.py`` file before anything else, so the code in it can call
:func:`benchmarks.controllers.register` or :func:`benchmarks.scenarios.register_scenario`; a
plug-in that fails to import or registers a taken name is reported in one line (exit 2).
Plug-ins reach the ``process`` executor's workers (forked after the import), not remote dask
workers. Output piped into a reader that stops early (``--list | head``) ends quietly.
``--scenario-file`` adds the file's scenarios (TOML, or YAML when PyYAML is installed) to the
suite given with ``--suite``, or runs them alone when ``--suite`` is not given. ``reproduce``
runs the paper reproduction NAME (:mod:`benchmarks.reproductions`; ``--list`` describes each
with its citation) and returns its ``main(out_dir, quick)`` exit code (0 when it ran: the
verdicts in its table are findings, not errors).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import importlib
import importlib.util
import os
import sys
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

#: Members per cell of ``run`` (``--members``): see docs/benchmarks.md for what N buys.
DEFAULT_MEMBERS = 8

__all__ = [
    "main",
    "build_parser",
    "program_name",
    "available_reproductions",
    "load_plugins",
    "PluginError",
]

#: Plug-in files already imported in this process (resolved path → module): loading the same
#: file twice must not register its controllers twice.
_LOADED_FILES: dict[Path, ModuleType] = {}


class PluginError(ValueError):
    """A ``--plugin`` that could not be imported (the message names it and the problem)."""


def available_reproductions() -> list[str]:
    """Names of the paper reproductions (:mod:`benchmarks.reproductions`)."""
    from . import reproductions

    return reproductions.available()


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def load_plugins(specs: Sequence[str]) -> list[ModuleType]:
    """Import every ``--plugin``: a path ending in ``.py`` (or containing a path separator) is
    executed as a module; anything else is imported by module name (``importlib``). Raises
    :class:`PluginError` with one line ``plugin NAME: Type: message`` when one fails (missing
    file, syntax error, an exception at import such as a duplicate registration)."""
    modules = []
    for spec in specs:
        is_file = spec.endswith(".py") or "/" in spec or os.sep in spec
        try:
            if is_file:
                path = Path(spec).resolve()
                if path in _LOADED_FILES:
                    modules.append(_LOADED_FILES[path])
                    continue
                if not path.is_file():
                    raise FileNotFoundError(f"no such file {spec}")
                name = f"liecontrol_plugin_{path.stem}_{len(_LOADED_FILES)}"
                mspec = importlib.util.spec_from_file_location(name, path)
                if mspec is None or mspec.loader is None:
                    raise ImportError(f"cannot import {spec} as a Python module")
                module = importlib.util.module_from_spec(mspec)
                sys.modules[name] = module  # dataclasses and pickling look modules up here
                try:
                    mspec.loader.exec_module(module)
                except BaseException:
                    sys.modules.pop(name, None)
                    raise
                _LOADED_FILES[path] = module
            else:
                module = importlib.import_module(spec)
        except Exception as exc:  # noqa: BLE001 - any failure of user code becomes one line
            raise PluginError(f"plugin {spec}: {_one_line(exc)}") from exc
        modules.append(module)
    return modules


#: The exit-status rule of ``run``, word for word in ``--help`` and docs/benchmarks.md (a test
#: checks both): the verdicts ``failed`` (did not converge) and ``error`` (the run raised) are
#: two different words, and only ``error`` changes the exit status.
EXIT_STATUS_RULE = (
    "0 when every run completed, whatever its verdict (a 'failed' verdict — the controller "
    "missed the scenario's tolerance — is a finding, not a crash); 1 when some run raised "
    "(verdict 'error', listed with its message in the report); 2 for bad arguments; "
    "130 when a Monte Carlo run is interrupted (its finished chunks are kept for --resume)."
)

#: The console script installed by ``pip install`` (``[project.scripts]`` in pyproject.toml).
CONSOLE_SCRIPT = "liecontrol-bench"


def program_name(argv0: str | None = None) -> str:
    """How the user invoked us, for usage and help text: ``liecontrol-bench`` when ``argv0``
    (default ``sys.argv[0]``) is that console script (any folder, a Windows ``.exe``/``-script.py``
    suffix allowed), else ``python -m benchmarks`` (``argv0`` is then ``.../__main__.py``, or a
    test runner when :func:`main` is called from Python)."""
    if argv0 is None:
        argv0 = sys.argv[0] if sys.argv else ""
    if not isinstance(argv0, str):
        raise TypeError(f"argv0: expected a str or None, got {type(argv0).__name__}")
    base = os.path.basename(argv0).lower()
    for suffix in (".exe", "-script.py", ".py"):
        base = base.removesuffix(suffix)
    return CONSOLE_SCRIPT if base == CONSOLE_SCRIPT else "python -m benchmarks"


def build_parser(prog: str | None = None) -> argparse.ArgumentParser:
    """The argument parser; ``prog`` (default :func:`program_name`) is the command shown in
    usage and help."""
    if prog is not None and not isinstance(prog, str):
        raise TypeError(f"prog: expected a str or None, got {type(prog).__name__}")
    p = argparse.ArgumentParser(
        prog=program_name() if prog is None else prog,
        description="liecontrol benchmark suite: scenarios × controllers → metrics and report.",
        epilog="exit status of run: " + EXIT_STATUS_RULE,
    )
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser(
        "run",
        help="run a suite and write a report folder",
        description="Run a suite and write a report folder. Exit status: " + EXIT_STATUS_RULE,
    )
    r.add_argument("--suite", default=None, help="quick (default), full, unwinding, montecarlo")
    r.add_argument("--out", type=Path, default=Path("report"), help="report folder")
    r.add_argument(
        "--scenario-file",
        action="append",
        type=Path,
        default=[],
        help="TOML/YAML scenario file (repeatable)",
    )
    horizon = r.add_mutually_exclusive_group()
    horizon.add_argument("--t-final", type=float, default=None, help="every run's duration [s]")
    horizon.add_argument(
        "--horizon-scale", type=float, default=None, help="multiply every scenario's duration"
    )
    r.add_argument("--controllers", default=None, help="comma-separated controller names")
    r.add_argument(
        "--scenarios", default=None, help="comma-separated catalogue scenario names (not a suite)"
    )
    r.add_argument("--jobs", type=int, default=None, help="worker processes (default: CPUs)")
    r.add_argument("--executor", choices=("serial", "process", "dask"), default=None)
    r.add_argument("--scheduler", default=None, help="dask scheduler address (tcp://host:port)")
    r.add_argument(
        "--scheduler-timeout",
        type=float,
        default=10.0,
        help="seconds to wait for the dask scheduler, and again for its first worker",
    )
    r.add_argument("--samples", type=int, default=None, help="Monte Carlo samples")
    r.add_argument("--chunk-size", type=int, default=None, help="Monte Carlo batch size")
    r.add_argument("--seed", type=int, default=None, help="Monte Carlo / unwinding seed")
    r.add_argument(
        "--resume",
        action="store_true",
        help="Monte Carlo: keep the chunks in OUT/montecarlo.chunks.jsonl, run only the rest",
    )
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    r.add_argument(
        "--histories",
        action="store_true",
        help="also write every run's full time histories with their provenance to "
        "OUT/histories.parquet (needs pyarrow: pip install 'liecontrol[results]')",
    )
    r.add_argument(
        "--sweep-bandwidth",
        default=None,
        metavar="W1,W2,...",
        help="run the selection once per closed-loop natural frequency ω_n [rad/s] (every "
        "controller re-tuned to it) and write sweep.md with each controller's front over ω_n",
    )
    r.add_argument(
        "--members",
        type=int,
        default=None,
        metavar="N",
        help="dispersed members per (scenario, controller) cell; member 0 is the nominal run "
        f"(default {DEFAULT_MEMBERS}; 1: the single nominal run)",
    )
    r.add_argument(
        "--dispersion-seed",
        type=int,
        default=0,
        metavar="S",
        help="seed of the members' draws (benchmarks.dispersion)",
    )
    r.add_argument(
        "--backend",
        choices=("numba", "jax"),
        default="numba",
        help="simulate's route for the attitude batches: the fused numba loop (default) or the "
        "JAX route where the batch's configuration has one (pip install liecontrol[jax]; the "
        "others stay on numba, each with a log line)",
    )
    r.add_argument(
        "--no-sensitivity",
        action="store_true",
        help="skip the re-runs at ω_n × 0.9 and × 1.1 that show which cell verdicts sit on a "
        "knife edge",
    )
    r.add_argument("--list", action="store_true", help="list suites, scenarios and controllers")
    r.add_argument(
        "--plugin",
        action="append",
        default=[],
        metavar="MODULE_OR_FILE.py",
        help="import user code that registers controllers/scenarios first (repeatable)",
    )

    ls = sub.add_parser(
        "list",
        help="list suites, scenarios, controllers and reproductions (same as run --list)",
        description="List suites, scenarios, controllers and reproductions (the same listing as "
        "run --list).",
    )
    ls.add_argument(
        "--plugin",
        action="append",
        default=[],
        metavar="MODULE_OR_FILE.py",
        help="import user code that registers controllers/scenarios first (repeatable)",
    )

    t = sub.add_parser("throughput", help="Monte Carlo throughput: batched vs single runs")
    t.add_argument("--controller", default="geometric-pd-large-angle")
    t.add_argument("--batch", default="1,256", help="comma-separated batch sizes")
    t.add_argument("--steps", type=int, default=600, help="plant steps per run (dt = 0.1 s)")

    rep = sub.add_parser("reproduce", help="reproduce a source paper's published results")
    rep.add_argument("name", nargs="?", help="reproduction name (see --list)")
    rep.add_argument("--out", type=Path, default=None, help="output folder")
    rep.add_argument("--quick", action="store_true", help="shortened run (tests, smoke checks)")
    rep.add_argument("--list", action="store_true", help="list the reproductions and papers")
    rep.add_argument(
        "--plugin",
        action="append",
        default=[],
        metavar="MODULE_OR_FILE.py",
        help="import user code first (repeatable)",
    )
    return p


def _print_listing() -> None:
    from .controllers import CONTROLLERS
    from .scenarios import SCENARIOS, SUITES

    print("suites:")
    for name, suite in SUITES.items():
        print(f"  {name:12s} {suite.description}")
        for s in suite.scenarios:
            print(f"      {s.name}")
    print("scenarios:")
    for s in SCENARIOS.values():
        print(f"  {s.name:22s} [{s.plant}] {s.description} ({s.duration:g} s, dt {s.dt:g} s)")
    print("controllers:")
    for c, info in CONTROLLERS.items():
        flags = ("batched" if info.batched else "per-spacecraft") + (
            ", quick" if info.quick else ""
        )
        print(f"  {c:26s} [{', '.join(sorted(info.plants))}; {flags}] {info.description}")
    print("reproductions:")
    _print_reproductions("  ")


def _print_reproductions(indent: str) -> None:
    from . import reproductions

    for name in reproductions.available():
        mod = reproductions.load(name)
        print(f"{indent}{name:26s} {mod.SUMMARY}")
        print(f"{indent}{'':26s} {mod.CITATION}")


def _error(msg: str) -> int:
    print(f"error: {msg}", file=sys.stderr)
    return 2


def _horizon(args: argparse.Namespace, duration: float) -> float:
    """The run length [s] asked for by ``--t-final`` (absolute) or ``--horizon-scale`` (× the
    default ``duration``); ``duration`` itself when neither is given."""
    if args.t_final is not None:
        return args.t_final
    if args.horizon_scale is not None:
        return duration * args.horizon_scale
    return duration


def _check_selection(scenarios: Sequence, controllers: Sequence[str] | None) -> None:
    """``ValueError`` (one line, saying why) when no selected controller applies to any selected
    scenario, so nothing would run."""
    from .controllers import available_controllers, get_controller

    if not scenarios:
        raise ValueError("nothing to run: the selection has no scenario")
    names = tuple(available_controllers()) if controllers is None else tuple(controllers)
    if not names:
        raise ValueError("nothing to run: the selection has no controller")
    why: dict[str, list[str]] = {}
    for c in names:
        info = get_controller(c)
        for s in scenarios:
            ok, reason = info.applies(s)
            if ok:
                return
            why.setdefault(reason or "does not apply", []).append(
                f"{c} (plants: {', '.join(sorted(info.plants))}) on {s.name} (plant: {s.plant})"
            )
    parts = [
        f"{', '.join(pairs[:3])}{' …' if len(pairs) > 3 else ''}: {reason}"
        for reason, pairs in why.items()
    ]
    raise ValueError(
        "nothing to run: no selected controller applies to any selected scenario ("
        + "; ".join(parts)
        + ")"
    )


def _runs(n: int) -> str:
    return f"{n} run" if n == 1 else f"{n} runs"


def _count(values: Iterable[str]) -> dict[str, int]:
    counts: dict[str, int] = {}
    for v in values:
        counts[v] = counts.get(v, 0) + 1
    return counts


def _verdict_summary(outcomes: Iterable) -> str:
    """``"57 runs + 21 not-applicable: 32 success, 9 degraded, 16 failed, 0 error"`` from the
    outcomes' verdicts (:func:`benchmarks.metrics.judge`); a verdict outside those five (a
    plug-in's own) is appended with its count."""
    unjudged = {"n/a": "not-applicable", "failed": "error"}  # a verdict not yet set
    counts = _count(o.verdict or unjudged.get(o.status, "unjudged") for o in outcomes)
    n_na = counts.pop("not-applicable", 0)
    main = ("success", "degraded", "failed", "error")
    parts = [f"{counts.get(v, 0)} {v}" for v in main]
    parts += [f"{n} {v}" for v, n in sorted(counts.items()) if v not in main]
    head = _runs(sum(counts.values())) + (f" + {n_na} not-applicable" if n_na else "")
    return f"{head}: {', '.join(parts)}"


#: Cold-cache compile time of the quick suite's kernels, shown in the "compiling kernels"
#: message: measured with ``liecontrol-bench run --suite quick`` and an empty numba cache on
#: a shared 2-core development machine (docs/benchmarks.md, "Run time").
COLD_COMPILE_S = 70

#: The warm-up says "compiling kernels" once numba has started compiling (a cache miss, seen
#: through numba's "numba:compile" event) and the warm-up has run this long [s]: a short
#: compile (a user's uncached law) stays quiet, and loading cached code never triggers it.
COMPILE_NOTICE_AFTER_S = 1.0


def _compile_counter(counter: list[int]) -> Any:
    """A context manager counting numba's compilations (cache misses) into ``counter[0]``;
    without numba's event API every elapsed second counts as compiling."""
    try:
        from numba.core import event as ev
    except Exception:  # noqa: BLE001 - an old or broken numba: fall back to the time alone
        counter[0] = 1
        return contextlib.nullcontext()

    class _Count(ev.Listener):
        def on_start(self, event: Any) -> None:
            counter[0] += 1

        def on_end(self, event: Any) -> None:
            pass

    return ev.install_listener("numba:compile", _Count())


def _warm_up_runs(scenarios: Sequence, controllers: Sequence[str] | None) -> None:
    """The warm-up's runs: ``scenarios`` × ``controllers`` in this process (serial)."""
    from .executors import make_executor
    from .runner import run_suite

    with make_executor("serial") as ex:
        run_suite(scenarios, controllers, suite="warm-up", executor=ex, progress=False)


def _warm_up(scenarios: Sequence, controllers: Sequence[str] | None, announce: bool) -> float:
    """Compile — or load from numba's disk cache — the per-step kernels the selection uses,
    in this process and before the progress bar starts: one run of a few control periods per
    kind of scenario (plant, actuator, steering law, estimator, faults) with every selected
    controller. When numba compiles (a cache miss: the first run, or the first after an
    upgrade or an edit of a kernel) and the warm-up lasts :data:`COMPILE_NOTICE_AFTER_S`, it
    says so on stderr (``announce``) instead of leaving the bar at 0, then how long it took.
    The forked workers of the ``process`` executor inherit the compiled code, so they do not
    compile it again each. Returns the seconds spent; any failure is left to the real run to
    report."""
    import threading

    from liecontrol._jit import JIT_ENABLED

    if not JIT_ENABLED:
        return 0.0
    kinds: dict[tuple, object] = {}
    for s in scenarios:
        sp = getattr(s, "spacecraft", None)
        sensors = getattr(s, "sensors", None)
        key = (s.plant, getattr(sp, "actuator", None), getattr(sp, "steering", None),
               getattr(sensors, "estimator", None), bool(getattr(s, "faults", ())))  # fmt: skip
        kinds.setdefault(key, s)
    short = []
    for s in kinds.values():
        try:
            step = s.control_period or s.dt
            short.append(s.with_duration(min(s.duration, 3 * step)))
        except (ValueError, AttributeError, TypeError):
            continue
    if not short:
        return 0.0
    compiles = [0]
    said: list[bool] = []
    done = threading.Event()
    t0 = time.perf_counter()

    def watch() -> None:
        while not done.wait(0.1):
            if compiles[0] and time.perf_counter() - t0 >= COMPILE_NOTICE_AFTER_S:
                said.append(True)
                print(
                    f"compiling kernels (first run only, ≈{COLD_COMPILE_S} s on 2 cores; "
                    "cached for later runs) …",
                    file=sys.stderr,
                    flush=True,
                )
                return

    watcher = threading.Thread(target=watch, name="compile-notice", daemon=True)
    with _compile_counter(compiles):
        if announce:
            watcher.start()
        try:
            _warm_up_runs(short, controllers)
        except Exception:  # noqa: BLE001 - the real run reports any problem with its context
            pass
        finally:
            done.set()
            if announce:
                watcher.join()
    spent = time.perf_counter() - t0
    if said:
        print(f"kernels ready after {spent:.0f} s", file=sys.stderr, flush=True)
    return spent


def _cmd_run(args: argparse.Namespace) -> int:
    from .controllers import get_controller, quick_controllers
    from .executors import ExecutorUnavailable, make_executor
    from .scenario_files import load_scenarios
    from .scenarios import get_scenario, get_suite

    if args.list:
        _print_listing()
        return 0
    picked = args.scenarios is not None
    suite_name = args.suite or ("files" if args.scenario_file else "custom" if picked else "quick")
    try:
        scenarios: tuple = ()
        if picked:
            scenarios = tuple(
                get_scenario(n.strip()) for n in args.scenarios.split(",") if n.strip()
            )
        elif args.suite is not None or not args.scenario_file:
            scenarios = get_suite(args.suite or "quick").scenarios
        for f in args.scenario_file:
            scenarios = scenarios + tuple(load_scenarios(f))
        names = [s.name for s in scenarios]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"scenario-file: duplicate scenario names {dup}")
        controllers = None
        if args.controllers:
            controllers = tuple(c.strip() for c in args.controllers.split(",") if c.strip())
            for c in controllers:
                get_controller(c)
        elif suite_name == "quick":
            controllers = quick_controllers()
        if args.jobs is not None and args.jobs < 1:
            raise ValueError(f"jobs: must be >= 1, got {args.jobs}")
        if args.t_final is not None and not args.t_final > 0:
            raise ValueError(f"t-final: must be > 0, got {args.t_final}")
        if args.horizon_scale is not None and not args.horizon_scale > 0:
            raise ValueError(f"horizon-scale: must be > 0, got {args.horizon_scale}")
        if suite_name not in ("unwinding", "montecarlo"):
            _check_selection(scenarios, controllers)
    except ValueError as exc:
        return _error(str(exc))
    if args.t_final is not None or args.horizon_scale is not None:
        try:  # a horizon shorter than a scenario's step is rejected by the scenario
            scenarios = tuple(s.with_duration(_horizon(args, s.duration)) for s in scenarios)
        except ValueError as exc:
            return _error(str(exc))

    try:
        executor = make_executor(
            args.executor,
            jobs=args.jobs,
            scheduler=args.scheduler,
            timeout=args.scheduler_timeout,
        )
    except (ExecutorUnavailable, ValueError) as exc:
        return _error(str(exc))
    t0 = time.perf_counter()
    figures = not args.no_figures
    progress = not args.no_progress
    keep = bool(getattr(args, "histories", False))
    members = DEFAULT_MEMBERS if args.members is None else args.members
    if members < 1:
        return _error(f"members: expected an integer >= 1, got {members}")
    if args.dispersion_seed < 0:
        return _error(f"dispersion-seed: expected an integer >= 0, got {args.dispersion_seed}")
    if args.backend == "jax":  # checked before anything runs
        from spacecraft.differentiable import require_jax

        try:
            require_jax()
        except ImportError as exc:
            return _error(f"backend: {exc}")
    if keep:  # checked before anything runs
        from .results_file import require_pyarrow

        if suite_name == "unwinding":
            return _error("histories: not available for the unwinding suite")
        if getattr(args, "resume", False):
            return _error(
                "histories: --resume reuses journaled chunks, which carry no histories; "
                "rerun without --resume"
            )
        try:
            require_pyarrow()
        except ImportError as exc:
            return _error(f"histories: {exc}")
    with executor:
        if suite_name == "unwinding":
            from . import unwinding

            kw = {} if args.seed is None else {"seed": args.seed}
            cfg = unwinding.UnwindingConfig(**kw)
            cfg = dataclasses.replace(cfg, duration=_horizon(args, cfg.duration))
            res = unwinding.run_unwinding(controllers, cfg, executor=executor, progress=progress)
            path = unwinding.write_unwinding_report(res, args.out, figures=figures)
            counts = _count(r.verdict for r in res.records)
            # the unwinding table's own verdicts; "error" means the run raised, as in the suite
            summary = (
                _runs(len(res.records))
                + ": "
                + ", ".join(f"{counts.get(v, 0)} {v}" for v in unwinding.VERDICTS)
            )
            n_failed = res.n_failed
        elif suite_name == "montecarlo":
            from . import montecarlo

            kw = {
                k: v
                for k, v in (
                    ("n_samples", args.samples),
                    ("chunk_size", args.chunk_size),
                    ("seed", args.seed),
                )
                if v is not None
            }
            try:
                cfg = montecarlo.MonteCarloConfig(**kw)
            except ValueError as exc:
                return _error(str(exc))
            cfg = dataclasses.replace(cfg, duration=_horizon(args, cfg.duration))
            journal = args.out / "montecarlo.chunks.jsonl"
            try:
                res = montecarlo.run_montecarlo(
                    controllers,
                    cfg,
                    executor=executor,
                    progress=progress,
                    journal=journal,
                    resume=args.resume,
                    keep_histories=keep,
                )
            except montecarlo.MonteCarloInterrupted as exc:
                print(
                    f"interrupted: {exc.kept} of {exc.total} chunks saved in {journal}; "
                    "run the same command with --resume to finish",
                    file=sys.stderr,
                )
                return 130
            except ValueError as exc:  # a journal written for another configuration
                return _error(str(exc))
            path = montecarlo.write_montecarlo_report(res, args.out, figures=figures)
            if keep:
                from .results_file import write_histories_with_report

                write_histories_with_report(res, args.out, path)
            n_failed = res.n_failed
            summary = f"{_runs(len(res.records))}, {n_failed} error"
        else:
            from .report import write_report, write_sweep_report
            from .runner import run_suite

            if args.sweep_bandwidth:
                from .controllers import GainRule

                try:
                    ws = [float(w) for w in args.sweep_bandwidth.split(",") if w.strip()]
                    if not ws or len(set(ws)) != len(ws):
                        raise ValueError("expected distinct comma-separated values")
                    rules = {w: GainRule(omega_n=w) for w in ws}
                except ValueError as exc:
                    return _error(f"sweep-bandwidth: {args.sweep_bandwidth!r}: {exc}")
                _warm_up(scenarios, controllers, progress)
                sweep = {}
                for w, rule in rules.items():
                    sweep[w] = run_suite(
                        scenarios, controllers, suite=f"{suite_name} (ω_n = {w:g} rad/s)",
                        executor=executor, progress=progress, gain_rule=rule,
                        keep_histories=keep, members=members, dispersion_seed=args.dispersion_seed,
                        backend=args.backend,
                    )  # fmt: skip
                    sub = write_report(
                        sweep[w], args.out / f"omega_n-{w:g}", figures=figures, progress=progress
                    )
                    if keep:
                        from .results_file import write_histories_with_report

                        write_histories_with_report(sweep[w], sub.parent, sub)
                path = write_sweep_report(sweep, args.out, figures=figures)
                summary = _verdict_summary(o for r in sweep.values() for o in r.outcomes)
                n_failed = sum(r.n_failed for r in sweep.values())
            else:
                _warm_up(scenarios, controllers, progress)
                result = run_suite(
                    scenarios, controllers, suite=suite_name, executor=executor,
                    progress=progress, keep_histories=keep, members=members,
                    dispersion_seed=args.dispersion_seed, backend=args.backend,
                )  # fmt: skip
                if not args.no_sensitivity:
                    from .runner import bandwidth_sensitivity

                    result = bandwidth_sensitivity(result, executor=executor, progress=progress)
                path = write_report(result, args.out, figures=figures, progress=progress)
                if keep:
                    from .results_file import write_histories_with_report

                    write_histories_with_report(result, args.out, path)
                summary = _verdict_summary(result.outcomes)
                if result.members > 1:
                    cells = _count(
                        c.verdict for c in result.cells.values() if c.verdict != "not-applicable"
                    )
                    print(
                        f"cell verdicts over {result.members} members (requirements, Wilson "
                        "95 %): "
                        + ", ".join(
                            f"{cells.get(v, 0)} {v}"
                            for v in ("success", "degraded", "failed", "error")
                        )
                    )
                n_failed = result.n_failed
    print(
        f"report: {path} ({summary}; total wall time {time.perf_counter() - t0:.1f} s "
        f"including report and figures, executor {executor.name})"
    )
    # n_failed counts runs that raised (status "failed", verdict "error"), not failed verdicts
    return 0 if n_failed == 0 else 1


def _cmd_throughput(args: argparse.Namespace) -> int:
    from .controllers import get_controller
    from .montecarlo import measure_throughput

    try:
        get_controller(args.controller)
        batches = [int(b) for b in args.batch.split(",") if b.strip()]
        if not batches or min(batches) < 1:
            raise ValueError(f"batch: expected positive integers, got {args.batch!r}")
        if args.steps < 1:
            raise ValueError(f"steps: must be >= 1, got {args.steps}")
    except ValueError as exc:
        return _error(str(exc))
    rows = measure_throughput(args.controller, batches, n_steps=args.steps)
    print(f"controller {args.controller}, SGCMG plant, dt 0.1 s, {args.steps} steps, 1 process")
    print(f"{'batch':>6s} {'wall [s]':>9s} {'spacecraft-steps/s':>19s} {'speed-up':>9s}")
    base = rows[0]["steps_per_s"]
    for r in rows:
        print(
            f"{r['batch']:6d} {r['wall_s']:9.3f} {r['steps_per_s']:19.0f} "
            f"{r['steps_per_s'] / base:9.1f}"
        )
    return 0


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from . import reproductions

    if args.list:
        print(f"reproductions ({program_name()} reproduce NAME --out DIR [--quick]):")
        _print_reproductions("  ")
        return 0
    valid = ", ".join(reproductions.available())
    if not args.name:
        return _error(f"reproduce needs a NAME; valid reproductions: {valid}")
    try:
        module = reproductions.load(args.name)
    except ValueError as exc:
        return _error(str(exc).removeprefix("name: "))
    entry = getattr(module, "main", None)
    if not callable(entry):
        return _error(f"{module.__name__} has no main(out_dir, quick) function")
    out = args.out if args.out is not None else Path("reproductions") / args.name
    out.mkdir(parents=True, exist_ok=True)
    print(f"{args.name}: {module.CITATION}", flush=True)
    return int(entry(out, quick=args.quick))


def _dispatch(args: argparse.Namespace) -> int:
    if getattr(args, "plugin", None):
        try:
            load_plugins(args.plugin)
        except PluginError as exc:
            return _error(str(exc))
    if args.command == "run":
        return _cmd_run(args)
    if args.command == "list":
        _print_listing()
        return 0
    if args.command == "throughput":
        return _cmd_throughput(args)
    return _cmd_reproduce(args)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m benchmarks`` and ``liecontrol-bench``; returns the exit code.

    A reader that closes our stdout early (``... --list | head``) is not an error: the rest of
    the output is dropped without a ``BrokenPipeError`` traceback."""
    args = build_parser().parse_args(None if argv is None else list(argv))
    try:
        code = _dispatch(args)
        sys.stdout.flush()
    except BrokenPipeError:
        # Python's documented recipe: point stdout at devnull so the interpreter's final flush
        # at exit does not raise again and print "Exception ignored ... BrokenPipeError"
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    return code
