"""The report's requirement-based section: verdicts over the dispersion, rankings with ties,
aliases, and what changed against the single-run rule (:mod:`benchmarks.ranking`)."""

from __future__ import annotations

import math
from typing import Any

from .dispersion import (
    DEFAULT_DISPERSION,
    DISPERSION_KEYS,
    detumble_dispersion_note,
    sun_acquisition_dispersion_note,
)
from .ranking import find_aliases, rank_cells
from .requirements import requirements_of

__all__ = [
    "dispersion_section",
    "alias_groups",
    "suite_aliases",
    "dealiased",
    "verdict_changes",
    "not_equivalent_controllers",
]


def _check_result(result: Any) -> None:
    from .runner import SuiteResult

    if not isinstance(result, SuiteResult):
        raise TypeError(
            "result: expected a SuiteResult (from benchmarks.runner.run_suite), got "
            f"{type(result).__name__}"
        )


def _f(x: float) -> str:
    if isinstance(x, float) and math.isinf(x):
        return "∞"
    if x != x:  # NaN
        return "—"
    return f"{x:.3g}"


def alias_groups(result: Any) -> dict[str, list[tuple[str, ...]]]:
    """Per scenario, the groups of controllers whose nominal runs coincide
    (:func:`benchmarks.ranking.find_aliases`)."""
    _check_result(result)
    out = {}
    for s in result.scenarios:
        groups = find_aliases([result.outcome(s.name, c) for c in result.controllers])
        if groups:
            out[s.name] = groups
    return out


def suite_aliases(result: Any) -> dict[str, tuple[str, ...]]:
    """Representative → aliases for controllers whose nominal runs coincide on *every* scenario
    where both ran (at least one): the same closed loop under several names suite-wide. Aliases
    on some scenarios only stay separate rows (the alias list names them per scenario)."""
    _check_result(result)
    per = alias_groups(result)
    ran = {
        c: {s.name for s in result.scenarios if result.outcome(s.name, c).status == "ok"}
        for c in result.controllers
    }
    together: dict[tuple[str, str], set[str]] = {}
    for sname, groups in per.items():
        for g in groups:
            for c in g[1:]:
                together.setdefault((g[0], c), set()).add(sname)
    out: dict[str, list[str]] = {}
    taken: set[str] = set()
    for (rep, c), where in together.items():
        both = ran[rep] & ran[c]
        if both and where >= both and rep not in taken and c not in taken:
            out.setdefault(rep, []).append(c)
            taken.add(c)
    return {k: tuple(v) for k, v in out.items()}


def dealiased(result: Any) -> Any:
    """``result`` without the controllers that are suite-wide aliases of another
    (:func:`suite_aliases`); the representative's :meth:`display_name` names them."""
    import dataclasses

    al = suite_aliases(result)
    if not al:
        return result
    gone = {c for v in al.values() for c in v}
    return dataclasses.replace(
        result, controllers=tuple(c for c in result.controllers if c not in gone), aliases=al
    )


def verdict_changes(result: Any) -> list[tuple[str, str, str, str]]:
    """``(scenario, controller, single-run verdict, cell verdict)`` where they differ."""
    _check_result(result)
    out = []
    for (s, c), cell in result.cells.items():
        if cell.verdict != cell.nominal_verdict:
            out.append((s, c, cell.nominal_verdict, cell.verdict))
    return out


def not_equivalent_controllers(result: Any) -> set[str]:
    """Attitude controllers whose 1° step leaves the spec's linear behaviour
    (:func:`benchmarks.tuning_report.not_equivalent`), measured on the first attitude
    scenario's spacecraft; a controller that cannot be measured is left unmarked."""
    _check_result(result)
    from .controllers import ATTITUDE_PLANTS, CONTROLLERS, get_controller
    from .tuning_report import not_equivalent, step_response

    att = [s for s in result.scenarios if s.plant in ATTITUDE_PLANTS]
    if not att:
        return set()
    out = set()
    for c in result.controllers:
        if c not in CONTROLLERS or not (get_controller(c).plants & ATTITUDE_PLANTS):
            continue
        try:
            if not_equivalent(step_response(c, att[0], getattr(result, "gain_rule", None))):
                out.add(c)
        except Exception:  # noqa: BLE001, S112 - the tuning section reports the failure
            continue
    return out


def _dispersion_text(s: Any) -> str:
    d = s.dispersion or DEFAULT_DISPERSION
    note = detumble_dispersion_note(s, d) or sun_acquisition_dispersion_note(s, d)
    if note:
        return note
    parts = [f"{k} {getattr(d, k):g}" for k in DISPERSION_KEYS if getattr(d, k) > 0]
    return ", ".join(parts) if parts else "none"


def dispersion_section(result: Any) -> list[str]:
    """Markdown lines of the section (empty when the result has no cells)."""
    _check_result(result)
    if not result.cells:
        return []
    n = result.members
    aliases = alias_groups(result)
    odd = not_equivalent_controllers(result)
    lines = [
        "## Verdicts over the dispersion",
        "",
        f"Every cell was flown as {n} member{'s' if n != 1 else ''}: member 0 is the nominal "
        "scenario (the runs of every other table), members 1 … N−1 are seeded draws of its "
        "dispersion (`benchmarks.dispersion`: initial attitude and rate, true inertia, SE(3) "
        "relative position, a detumble's separation tumble, a safe-mode start; CMG hardware "
        "and disturbance "
        "amplitude where a scenario states them). A member passes when it meets every "
        "requirement of the scenario (ECSS-E-ST-60-10C pointing errors: APE over the final 10 % "
        "of the run, RPE over a window; settling time, overshoot, momentum use, cone "
        "clearance, SE(3) range excursion and ΔV). *pass* is the count of passing members with "
        "its Wilson 95 % interval. Cell verdict: **success** when every member passes, "
        "**failed** when none does or the interval lies below ½, **degraded** otherwise, "
        "**error** when the nominal run raised. *rank*: 1 + the number of controllers whose "
        "interval lies wholly above this one's — equal ranks are ties that this many members "
        "cannot separate. *margin* = value / limit (lower bound: limit / value; ≤ 1 met; ∞: not "
        "measured, e.g. never settled) as median / 95th percentile / worst over the members. "
        "*single run*: the verdict of the flag-and-tolerance rule on member 0 alone. "
        "*nominal meets at ω_n × f*: the nominal scenario re-run with every controller re-tuned "
        "to ±10 % bandwidth, for the cells near a limit (some members pass and some not, or "
        "the nominal run's worst margin within 2× of 1; —: far from every limit, not re-run; "
        "n/a: it cannot be tuned to that bandwidth under the actuator limits) — a *knife edge* "
        "when the "
        "requirements hold at one bandwidth and not at its neighbour. "
        "† marks a law **not equivalent at small angles** (its 1° step overshoots or commands "
        "more than the spec's linear loop allows: see the tuning section), so equal tuning did "
        "not make it comparable.",
        "",
    ]
    if n > 1:
        half = 1.959963984540054 * math.sqrt(0.25 / n)
        lines += [
            f"With N = {n} a pass fraction near ½ is known to about ±{half:.2f} (normal "
            "approximation); all passing gives a lower bound of "
            f"{_wilson_lo(n):.2f}: two controllers are separated only when one passes nearly "
            "everywhere and the other nearly nowhere. Run with `--members 32` to halve the width.",
            "",
        ]
    for s in result.scenarios:
        cells = [result.cells[(s.name, c)] for c in result.controllers]
        reqs = requirements_of(s)
        first = reqs[0].text() if reqs else None
        ranked = rank_cells(cells, first)
        if not ranked:
            continue
        alias_of = {}
        for g in aliases.get(s.name, []):
            for c in g[1:]:
                alias_of[c] = g[0]
        lines += [
            f"### {s.name} over the dispersion",
            "",
            "Requirements: "
            + "; ".join(r.text() for r in reqs)
            + ". Dispersion: "
            + _dispersion_text(s)
            + ".",
            "",
        ]
        sens = getattr(result, "sensitivity", {}) or {}
        factors = sorted({f for d in sens.values() for f in d})
        head = ["rank", "controller", "pass", "verdict", "single run", "worst margin"]
        if factors:
            head.append("nominal meets at ω_n × " + " / ".join(f"{f:g}" for f in factors))
        head += [r.text() for r in reqs] + ["flags (fraction of members)"]
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for rank, cell in ranked:
            if cell.controller in alias_of:
                continue
            same = [c for c, rep in alias_of.items() if rep == cell.controller]
            name = f"`{cell.controller}`" + ("†" if cell.controller in odd else "") + (
                " (= " + ", ".join(f"`{c}`" for c in same) + ")" if same else ""
            )
            row = [
                str(rank),
                name,
                cell.interval_text(),
                cell.verdict,
                cell.nominal_verdict,
                _f(cell.worst_margin),
            ]
            if factors:
                d = sens.get((s.name, cell.controller), {})
                marks = [
                    "—" if f not in d else {True: "yes", False: "no", None: "n/a"}[d[f]]
                    for f in factors
                ]
                seen = {d[f] for f in factors if d.get(f) is not None} | {cell.nominal_passes}
                edge = len(seen) > 1
                row.append(" / ".join(marks) + (" (knife edge)" if edge else ""))
            for r in reqs:
                med, p95, worst = cell.margins.get(r.text(), (math.nan,) * 3)
                if all(x != x for x in (med, p95, worst)):
                    v = cell.values.get(r.text(), (math.nan,) * 3)
                    row.append(f"value {_f(v[0])} / {_f(v[1])} / {_f(v[2])}")
                else:
                    row.append(f"{_f(med)} / {_f(p95)} / {_f(worst)}")
            flags = ", ".join(f"{f} {x:.2f}" for f, x in cell.flag_fraction.items())
            row.append(flags or "—")
            lines.append("| " + " | ".join(row) + " |")
        lines.append("")
    if aliases:
        lines += [
            "### Aliases",
            "",
            "Controllers whose nominal runs are the same closed loop (attitude error, rate and "
            "torque histories equal to 1e-9 relative), listed once in the tables above under "
            "the first name:",
            "",
        ]
        for sname, groups in aliases.items():
            for g in groups:
                lines.append(f"- `{sname}`: " + " = ".join(f"`{c}`" for c in g))
        lines.append("")
    changes = verdict_changes(result)
    lines += [
        "### Single-run rule against the dispersion rule",
        "",
        f"{len(changes)} of {sum(c.verdict != 'not-applicable' for c in result.cells.values())} "
        "cell verdicts differ between the flag-and-tolerance rule on the nominal run and the "
        "requirement rule over the members" + (":" if changes else "."),
        "",
    ]
    for s, c, old, new in changes:
        lines.append(f"- `{s}` × `{c}`: {old} → {new}")
    lines.append("")
    return lines


def _wilson_lo(n: int) -> float:
    from .ranking import wilson_interval

    return wilson_interval(n, n)[0]
