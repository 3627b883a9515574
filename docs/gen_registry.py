"""Markdown generated from the benchmark registry for the docs site.

The docs build (``docs/hooks.py``) replaces a marker ``<!-- registry:NAME -->`` on a page by
``render(NAME)``, so suite sizes, scenario lists, controller lists and the reproductions'
citations are read from :mod:`benchmarks` at build time instead of being typed (typed counts go
stale as soon as someone registers a scenario or a controller).

Run ``python docs/gen_registry.py NAME`` to print one block, or without an argument to list the
names.
"""

from __future__ import annotations

import sys
from collections.abc import Callable

__all__ = ["GENERATORS", "render", "suite_counts"]


def _cell(text: object) -> str:
    """A Markdown table cell: pipes escaped, newlines folded."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _table(header: list[str], rows: list[list[object]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def suite_counts() -> dict[str, dict[str, int]]:
    """For each suite: its scenarios (or cases / samples), controllers, pairs that run and
    pairs recorded as "does not apply", exactly as ``liecontrol-bench run --suite NAME`` selects
    them (the quick suite runs the quick controllers; the unwinding suite every attitude
    controller on its cases; the Monte Carlo suite the quick attitude controllers on its
    samples)."""
    from benchmarks.controllers import (
        applicable,
        available_controllers,
        get_controller,
        quick_controllers,
    )
    from benchmarks.montecarlo import MonteCarloConfig
    from benchmarks.scenarios import SUITES
    from benchmarks.unwinding import UnwindingConfig, unwinding_scenarios

    out: dict[str, dict[str, int]] = {}
    for name in ("quick", "full"):
        scenarios = SUITES[name].scenarios
        names = quick_controllers() if name == "quick" else tuple(available_controllers())
        runs = sum(len(applicable(s, names)) for s in scenarios)
        out[name] = {
            "scenarios": len(scenarios),
            "controllers": len(names),
            "runs": runs,
            "not_applicable": len(scenarios) * len(names) - runs,
        }
    ucfg = UnwindingConfig()
    cases = unwinding_scenarios(ucfg)
    unames = tuple(
        c for c in available_controllers() if ucfg.spacecraft.actuator in get_controller(c).plants
    )
    uruns = sum(len(applicable(s, unames)) for s in cases)
    out["unwinding"] = {
        "scenarios": len(cases),
        "controllers": len(unames),
        "runs": uruns,
        "not_applicable": len(cases) * len(unames) - uruns,
        "duration_s": int(ucfg.duration),
    }
    mcfg = MonteCarloConfig()
    mnames = tuple(
        c for c in quick_controllers() if mcfg.spacecraft.actuator in get_controller(c).plants
    )
    out["montecarlo"] = {
        "scenarios": mcfg.n_samples,
        "controllers": len(mnames),
        "runs": mcfg.n_samples * len(mnames),
        "not_applicable": 0,
        "duration_s": int(mcfg.duration),
    }
    return out


def _suites() -> str:
    from benchmarks.scenarios import SUITES

    counts = suite_counts()
    what = {
        "quick": "{scenarios} scenarios × {controllers} quick controllers",
        "full": "{scenarios} scenarios × {controllers} controllers",
        "unwinding": "{scenarios} cases × {controllers} attitude controllers, {duration_s} s each",
        "montecarlo": "{scenarios} samples × {controllers} controllers, {duration_s} s each",
    }
    rows = []
    for name, suite in SUITES.items():
        c = counts.get(name)
        if c is None:  # a suite registered by a user: count what the registry says
            size = f"{len(suite.scenarios)} scenarios"
            runs = "—"
        else:
            size = what[name].format(**c)
            runs = f"{c['runs']}" + (
                f" (+ {c['not_applicable']} does not apply)" if c["not_applicable"] else ""
            )
        rows.append([f"`{name}`", suite.description, size, runs])
    return _table(["suite (`liecontrol-bench run --suite NAME`)", "what", "size", "runs"], rows)


def _scenarios() -> str:
    from benchmarks.scenarios import SCENARIOS, SUITES

    rows = []
    for s in SCENARIOS.values():
        suites = [n for n, st in SUITES.items() if any(x.name == s.name for x in st.scenarios)]
        rows.append(
            [f"`{s.name}`", ", ".join(suites), s.plant, f"{s.duration:g}", f"{s.dt:g}",
             s.description]
        )
    return _table(["scenario", "suites", "plant", "duration [s]", "dt [s]", "description"], rows)


def _controllers() -> str:
    from benchmarks.controllers import CONTROLLERS

    rows = []
    for name, info in CONTROLLERS.items():
        rows.append(
            [f"`{name}`", info.family, ", ".join(sorted(info.plants)),
             "yes" if info.batched else "no", "yes" if info.quick else "no", info.description]
        )
    return _table(["name", "family", "plants", "batched", "quick", "description"], rows)


def _reproductions() -> str:
    from benchmarks import reproductions

    rows = []
    for name in reproductions.available():
        mod = reproductions.load(name)
        rows.append([f"`{name}`", mod.SUMMARY, str(mod.CITATION)])
    return _table(["reproduction", "what it checks", "paper"], rows)


def _paper_citations() -> str:
    from benchmarks import reproductions

    lines = []
    for name in reproductions.available():
        mod = reproductions.load(name)
        lines.append(
            f"- {mod.CITATION} Reproduced by "
            f"`liecontrol-bench reproduce {name} --out DIR`."
        )
    return "\n".join(lines)


#: Marker name → generator of its Markdown.
GENERATORS: dict[str, Callable[[], str]] = {
    "suites": _suites,
    "scenarios": _scenarios,
    "controllers": _controllers,
    "reproductions": _reproductions,
    "paper-citations": _paper_citations,
}


def render(name: str) -> str:
    """The Markdown block for marker ``name``; unknown names raise a ``ValueError`` listing
    the valid ones."""
    if name not in GENERATORS:
        raise ValueError(
            f"name: unknown registry block {name!r}; valid: {', '.join(sorted(GENERATORS))}"
        )
    return GENERATORS[name]()


if __name__ == "__main__":
    if len(sys.argv) < 2:
        print("\n".join(GENERATORS))
    else:
        print(render(sys.argv[1]))
