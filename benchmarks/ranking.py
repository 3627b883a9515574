"""Cell verdicts over a dispersion, with confidence; rankings with ties; aliases.

A *cell* is one (scenario, controller) pair flown as ``N`` members
(:mod:`benchmarks.dispersion`). Each member either meets every requirement of the scenario
(:mod:`benchmarks.requirements`) or not; a member whose simulation raised does not. With ``k``
of ``N`` members meeting them, the cell reports the pass fraction ``k/N`` with its Wilson score
interval at 95 % (E. B. Wilson, "Probable inference, the law of succession, and statistical
inference", Journal of the American Statistical Association 22, 1927):

    p̃ = (k + z²/2) / (N + z²),   half-width = z √(k(N − k)/N + z²/4) / (N + z²),   z = 1.95996…

**Cell verdict** (:func:`cell_verdict`), from the pass count:

- ``not-applicable`` — the controller does not apply to the scenario;
- ``error`` — the nominal member (member 0) raised: the cell has no baseline run;
- ``success`` — every member meets every requirement (``k = N``);
- ``failed`` — no member does (``k = 0``), or the interval lies below one half (most members
  fail, with 95 % confidence);
- ``degraded`` — otherwise: the requirements hold for some of the dispersion only.

**Ranking** (:func:`rank_cells`): controllers of a scenario are ordered by pass fraction, then
by the median of the scenario's first requirement's margin (lower is better); a controller's
*rank* is one plus the number of controllers whose interval lies entirely above its own, so
controllers whose intervals overlap share a rank — shown as tied.

**Aliases** (:func:`find_aliases`): controllers whose nominal runs of a scenario have identical
histories (attitude error, rate and torque within 1e-9 relative) are the same closed loop under
several names; the report lists each group once.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .requirements import Requirement, meets

__all__ = [
    "CellSummary",
    "Z95",
    "wilson_interval",
    "cell_verdict",
    "summarise_cell",
    "rank_cells",
    "find_aliases",
    "ALIAS_RTOL",
]

#: The two-sided 95 % standard normal quantile.
Z95 = 1.959963984540054
#: Relative tolerance under which two runs' histories count as identical.
ALIAS_RTOL = 1e-9


def wilson_interval(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion ``k/n`` (module docstring).

    Raises:
        ValueError: ``n < 1`` or ``k`` outside ``[0, n]``.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n: expected an integer >= 1, got {n!r}")
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k <= n:
        raise ValueError(f"k: expected an integer in [0, {n}], got {k!r}")
    n, k = int(n), int(k)
    if isinstance(z, bool) or not isinstance(z, (int, float, np.integer, np.floating)):
        raise TypeError(f"z: expected a positive finite quantile, got {z!r}")
    if not (math.isfinite(float(z)) and z > 0):
        raise ValueError(f"z: expected a positive finite quantile, got {z!r}")
    z2 = float(z) * float(z)
    centre = (k + 0.5 * z2) / (n + z2)
    half = z * math.sqrt(k * (n - k) / n + 0.25 * z2) / (n + z2)
    return max(0.0, centre - half), min(1.0, centre + half)


def cell_verdict(k: int, n: int, nominal_error: bool = False) -> str:
    """The cell verdict of ``k`` passing members out of ``n`` (module docstring)."""
    lo, hi = wilson_interval(k, n)
    if nominal_error:
        return "error"
    if k == n:
        return "success"
    if k == 0 or hi < 0.5:
        return "failed"
    return "degraded"


@dataclass(frozen=True)
class CellSummary:
    """One (scenario, controller) cell over its members.

    Attributes:
        scenario: the scenario's name.
        controller: the controller's name.
        n: members flown.
        passed: members meeting every requirement.
        interval: Wilson 95 % interval of ``passed / n``.
        verdict: :func:`cell_verdict`.
        nominal_verdict: the single-run verdict of member 0 (:func:`benchmarks.metrics.judge`,
            flags and tolerance).
        margins: per requirement text, ``(median, p95, worst)`` of its margin over the members
            (NaN where the ratio is not defined).
        values: the same statistics of the requirement's value.
        worst_margin: the largest margin over requirements and members (> 1: violated).
        flag_fraction: per flag, the fraction of members that raised it.
        nominal_passes: member 0 meets every requirement.
    """

    scenario: str
    controller: str
    n: int
    passed: int
    interval: tuple[float, float]
    verdict: str
    nominal_verdict: str
    margins: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    values: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    worst_margin: float = float("nan")
    flag_fraction: dict[str, float] = field(default_factory=dict)
    nominal_passes: bool = False

    @property
    def fraction(self) -> float:
        return self.passed / self.n if self.n else float("nan")

    def interval_text(self) -> str:
        lo, hi = self.interval
        return f"{self.passed}/{self.n} [{lo:.2f}, {hi:.2f}]"


def _stats(x: np.ndarray, worst: str) -> tuple[float, float, float]:
    """(median, 95th percentile on the bad side, worst) of the non-NaN values (sample values,
    no interpolation, so an infinite margin stays infinite); NaN when there are none."""
    x = np.asarray(x, dtype=np.float64)
    f = x[~np.isnan(x)]
    if f.size == 0:
        return (float("nan"),) * 3
    q = 95 if worst == "max" else 5
    med = float(np.percentile(f, 50, method="inverted_cdf"))
    p = float(np.percentile(f, q, method="inverted_cdf"))
    return med, p, float(f.max() if worst == "max" else f.min())


def summarise_cell(requirements: Sequence[Requirement], outcomes: Sequence[Any]) -> CellSummary:
    """Summarise one cell's member outcomes (:class:`benchmarks.runner.RunOutcome`, member 0
    first, all of one scenario and controller)."""
    if isinstance(requirements, (str, Requirement)) or not isinstance(requirements, Sequence):
        raise TypeError(f"requirements: expected a sequence of Requirement, got {requirements!r}")
    if isinstance(outcomes, str) or not isinstance(outcomes, Sequence):
        raise TypeError(f"outcomes: expected a sequence of RunOutcome, got {outcomes!r}")
    if not outcomes:
        raise ValueError("outcomes: empty (a cell has at least its nominal member)")
    for o in outcomes:
        if not all(hasattr(o, a) for a in ("status", "metrics", "flags", "scenario")):
            raise TypeError(f"outcomes: expected RunOutcome items, got {type(o).__name__}")
    if len({(o.scenario, o.controller) for o in outcomes}) > 1:
        raise ValueError("outcomes: members of one (scenario, controller) cell expected")
    o0 = outcomes[0]
    if o0.status == "n/a":
        return CellSummary(
            o0.scenario, o0.controller, 0, 0, (0.0, 1.0), "not-applicable", "not-applicable"
        )
    n = len(outcomes)
    passed = 0
    first_ok = False
    vals: dict[str, list[float]] = {r.text(): [] for r in requirements}
    marg: dict[str, list[float]] = {r.text(): [] for r in requirements}
    flags: dict[str, int] = {}
    for o in outcomes:
        ok_run = o.status == "ok"
        ok, v = meets(requirements, o.metrics if ok_run else {})
        passed += int(ok and ok_run)
        if o is o0:
            first_ok = bool(ok and ok_run)
        for r in requirements:
            x = v[r.text()]
            vals[r.text()].append(x)
            m = r.margin(x)
            # an unmeasured value (NaN: not settled, raised) is the worst margin there is
            marg[r.text()].append(math.inf if math.isnan(x) else m)
        for f in o.flags:
            flags[f] = flags.get(f, 0) + 1
    margins = {t: _stats(np.array(m, dtype=np.float64), "max") for t, m in marg.items()}
    values = {
        r.text(): _stats(np.array(vals[r.text()]), "max" if r.sense == "max" else "min")
        for r in requirements
    }
    finite = [w for (_, _, w) in margins.values() if not math.isnan(w)]
    return CellSummary(
        scenario=o0.scenario,
        controller=o0.controller,
        n=n,
        passed=passed,
        interval=wilson_interval(passed, n),
        verdict=cell_verdict(passed, n, nominal_error=o0.status != "ok"),
        nominal_verdict=o0.verdict,
        margins=margins,
        values=values,
        worst_margin=max(finite) if finite else float("nan"),
        flag_fraction={f: c / n for f, c in sorted(flags.items())},
        nominal_passes=first_ok,
    )


def rank_cells(
    cells: Sequence[CellSummary], first_requirement: str | None = None
) -> list[tuple[int, CellSummary]]:
    """``[(rank, cell)]`` best first for the applicable cells of one scenario (module docstring:
    equal ranks are ties)."""
    if isinstance(cells, str) or not isinstance(cells, Sequence):
        raise TypeError(f"cells: expected a sequence of CellSummary, got {cells!r}")
    for c in cells:
        if not isinstance(c, CellSummary):
            raise TypeError(f"cells: expected CellSummary items, got {type(c).__name__}")
    if first_requirement is not None and not isinstance(first_requirement, str):
        raise TypeError(f"first_requirement: expected a str or None, got {first_requirement!r}")
    live = [c for c in cells if c.verdict != "not-applicable"]

    def key(c: CellSummary) -> tuple[float, float]:
        med = c.margins.get(first_requirement, (math.nan,))[0] if first_requirement else math.nan
        return (-c.fraction, med if not math.isnan(med) else math.inf)

    live.sort(key=key)
    out = []
    for c in live:
        better = sum(1 for d in live if d.interval[0] > c.interval[1])
        out.append((1 + better, c))
    return out


def find_aliases(
    outcomes: Sequence[Any], keys: Sequence[str] = ("error_deg", "rate_deg_s", "torque_Nm")
) -> list[tuple[str, ...]]:
    """Groups (≥ 2) of controllers whose nominal outcomes of one scenario have identical series
    (each of ``keys`` within :data:`ALIAS_RTOL` of its peak), in the outcomes' order; the first
    name of a group is its representative."""
    if isinstance(outcomes, str) or not isinstance(outcomes, Sequence):
        raise TypeError(f"outcomes: expected a sequence of RunOutcome, got {outcomes!r}")
    if isinstance(keys, str) or not all(isinstance(k, str) for k in keys):
        raise TypeError(f"keys: expected a sequence of series names, got {keys!r}")
    for o in outcomes:
        if not all(hasattr(o, a) for a in ("status", "series", "controller")):
            raise TypeError(f"outcomes: expected RunOutcome items, got {type(o).__name__}")
    runs = [o for o in outcomes if o.status == "ok" and o.series]
    groups: list[list[Any]] = []
    for o in runs:
        for g in groups:
            if _same(g[0].series, o.series, keys):
                g.append(o)
                break
        else:
            groups.append([o])
    return [tuple(o.controller for o in g) for g in groups if len(g) > 1]


def _same(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray], keys: Sequence[str]) -> bool:
    for k in keys:
        x, y = a.get(k), b.get(k)
        if x is None or y is None:
            return False
        x, y = np.asarray(x), np.asarray(y)
        if x.shape != y.shape:
            return False
        scale = max(float(np.abs(x).max(initial=0.0)), float(np.abs(y).max(initial=0.0)), 1e-300)
        if not np.all(np.abs(x - y) <= ALIAS_RTOL * scale):
            return False
    t_a, t_b = a.get("t"), b.get("t")
    return t_a is not None and t_b is not None and np.array_equal(t_a, t_b)
