"""Command line of the benchmark suite (SPEC §8)::

    python -m benchmarks run --suite quick --out report/ [--t-final S | --horizon-scale X]
                             [--controllers a,b] [--jobs N] [--no-progress] [--no-figures]
    python -m benchmarks run --list
    python -m benchmarks reproduce NAME --out DIR [--quick]
    python -m benchmarks reproduce --list

``run`` exits 0 when every run completed (failed runs are recorded in the report and give exit
code 1). ``reproduce`` imports ``benchmarks.reproductions.<NAME>`` and returns its
``main(out_dir, quick)`` exit code (0 when every row passes).
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import pkgutil
import sys
import time
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main", "build_parser", "available_reproductions"]


def available_reproductions() -> list[str]:
    """Module names of the ``benchmarks.reproductions`` package (private ``_x`` excluded)."""
    from . import reproductions

    return sorted(
        m.name
        for m in pkgutil.iter_modules(reproductions.__path__)
        if not m.name.startswith("_")
    )


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m benchmarks",
        description="liecontrol benchmark suite: scenarios × controllers → metrics and report.",
    )
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("run", help="run a suite of scenarios × controllers and write a report")
    r.add_argument("--suite", default="quick", help="suite name (default: quick)")
    r.add_argument("--out", type=Path, default=Path("report"), help="report folder")
    horizon = r.add_mutually_exclusive_group()
    horizon.add_argument(
        "--t-final", type=float, default=None, help="override every scenario's duration [s]"
    )
    horizon.add_argument(
        "--horizon-scale", type=float, default=None, help="multiply every scenario's duration"
    )
    r.add_argument(
        "--controllers",
        default=None,
        help="comma-separated controller names (default: the suite's controllers)",
    )
    r.add_argument("--jobs", type=int, default=None, help="worker processes (default: auto)")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    r.add_argument("--list", action="store_true", help="list suites, scenarios and controllers")

    rep = sub.add_parser("reproduce", help="reproduce a seed paper's published results")
    rep.add_argument("name", nargs="?", help="reproduction name (see --list)")
    rep.add_argument("--out", type=Path, default=None, help="output folder")
    rep.add_argument("--quick", action="store_true", help="shortened run (tests, smoke checks)")
    rep.add_argument("--list", action="store_true", help="list the available reproductions")
    return p


def _print_listing() -> None:
    from .controllers import available_controllers
    from .scenarios import SUITES

    print("suites:")
    for name, scenarios in sorted(SUITES.items()):
        print(f"  {name}:")
        for s in scenarios:
            print(f"    {s.name:16s} {s.description} ({s.duration:g} s, dt {s.dt:g} s)")
    print("controllers:")
    for c in available_controllers():
        print(f"  {c}")
    print("reproductions:")
    for r in available_reproductions() or ["(none yet)"]:
        print(f"  {r}")


def _cmd_run(args: argparse.Namespace) -> int:
    from .controllers import QUICK_CONTROLLERS, available_controllers
    from .report import write_report
    from .runner import run_suite
    from .scenarios import get_suite

    if args.list:
        _print_listing()
        return 0
    try:
        scenarios = get_suite(args.suite)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.t_final is not None:
        if not args.t_final > 0:
            print(f"error: --t-final must be > 0, got {args.t_final}", file=sys.stderr)
            return 2
        scenarios = tuple(s.with_duration(args.t_final) for s in scenarios)
    elif args.horizon_scale is not None:
        if not args.horizon_scale > 0:
            print(f"error: --horizon-scale must be > 0, got {args.horizon_scale}", file=sys.stderr)
            return 2
        scenarios = tuple(
            dataclasses.replace(s, duration=s.duration * args.horizon_scale) for s in scenarios
        )
    controllers = QUICK_CONTROLLERS
    if args.controllers:
        controllers = tuple(c.strip() for c in args.controllers.split(",") if c.strip())
        unknown = [c for c in controllers if c not in available_controllers()]
        if unknown:
            print(
                f"error: unknown controller(s) {', '.join(unknown)}; valid controllers: "
                f"{', '.join(available_controllers())}",
                file=sys.stderr,
            )
            return 2
    if args.jobs is not None and args.jobs < 1:
        print(f"error: --jobs must be >= 1, got {args.jobs}", file=sys.stderr)
        return 2

    t0 = time.perf_counter()
    result = run_suite(
        scenarios, controllers, suite=args.suite, jobs=args.jobs, progress=not args.no_progress
    )
    path = write_report(result, args.out, figures=not args.no_figures)
    print(
        f"report: {path} ({len(result.outcomes)} runs, {result.n_failed} failed, "
        f"{time.perf_counter() - t0:.1f} s)"
    )
    return 0 if result.n_failed == 0 else 1


def _cmd_reproduce(args: argparse.Namespace) -> int:
    names = available_reproductions()
    valid = ", ".join(names) if names else "(none available yet)"
    if args.list:
        print("reproductions: " + valid)
        return 0
    if not args.name:
        print(f"error: reproduce needs a NAME; valid reproductions: {valid}", file=sys.stderr)
        return 2
    if args.name not in names:
        print(
            f"error: unknown reproduction {args.name!r}; valid reproductions: {valid}",
            file=sys.stderr,
        )
        return 2
    module = importlib.import_module(f"benchmarks.reproductions.{args.name}")
    entry = getattr(module, "main", None)
    if not callable(entry):
        print(
            f"error: benchmarks.reproductions.{args.name} has no main(out_dir, quick) function",
            file=sys.stderr,
        )
        return 2
    out = args.out if args.out is not None else Path("reproductions") / args.name
    out.mkdir(parents=True, exist_ok=True)
    return int(entry(out, quick=args.quick))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m benchmarks`` and ``liecontrol-bench``; returns the exit code."""
    args = build_parser().parse_args(None if argv is None else list(argv))
    if args.command == "run":
        return _cmd_run(args)
    return _cmd_reproduce(args)
