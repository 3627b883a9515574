"""Report folder of a suite run (SPEC §8.4): ``report.md``, ``metrics.csv``, ``metrics.json`` and
PNG figures (matplotlib, Agg backend).

``report.md`` holds a summary table (controllers × scenarios: settling time or why not) and one
controllers × scenarios table per metric; cells of failed runs say ``FAILED`` and the error text
is listed below. A pair whose controller does not apply to the scenario (status ``"n/a"``: an
SE(3) controller on an attitude plant and vice versa) reads ``does not apply`` (the summary says
why). Metrics not defined for a run (NaN, e.g. the unwinding ratio when the run starts at the
reference) read ``n/a``; a NaN settling time reads ``not settled``. No cell is ever empty.
Figures: one per scenario (all controllers overlaid) and a controllers × scenarios overview of
the settling time. Exact definitions: :mod:`benchmarks.metrics` and ``docs/benchmarks.md``.
"""

from __future__ import annotations

import csv
import json
import math
import platform
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .metrics import UNITS
from .runner import RunOutcome, SuiteResult

__all__ = [
    "TABLE_METRICS",
    "POSE_METRICS",
    "NOT_APPLICABLE",
    "write_report",
    "write_csv",
    "write_json",
    "write_figures",
    "fmt",
    "markdown_table",
    "figures_section",
]

#: (field, column title) of the per-metric tables, in order (SPEC §8.2).
TABLE_METRICS: tuple[tuple[str, str], ...] = (
    ("settling_time_s", "Settling time to 0.1° [s]"),
    ("steady_error_max_deg", "Steady-state error (max over final 10 %) [deg]"),
    ("peak_rate_deg_s", "Peak rate ‖ω − RᵀR_dω_d‖ [deg/s]"),
    ("overshoot_deg", "Overshoot along the initial error axis [deg]"),
    ("effort_Nms", "∫‖u‖dt [N·m·s]"),
    ("peak_gimbal_rate_rad_s", "Peak gimbal rate [rad/s]"),
    ("min_singularity", "Minimum singularity measure m"),
    ("saturation_time_s", "Time in gimbal-rate saturation [s]"),
    ("unwinding_ratio", "Unwinding ratio (path angle / geodesic angle; ≥ 1.5 unwound)"),
    ("controller_time_us", "Controller wall time per control step and spacecraft [µs]"),
)
#: Extra tables when a suite has SE(3) runs.
POSE_METRICS: tuple[tuple[str, str], ...] = (
    ("final_position_error_m", "SE(3): final position error [m]"),
    ("position_settling_time_s", "SE(3): position settling time to 0.1 m [s]"),
    ("peak_force_N", "SE(3): peak force ‖F‖ [N]"),
)
#: Cell text of a pair whose controller does not apply to the scenario.
NOT_APPLICABLE = "does not apply"

CSV_LEAD = ("scenario", "controller", "status", "error")


def _esc(text: str, limit: int | None = None) -> str:
    s = " ".join(str(text).split()).replace("|", "\\|")
    if limit is not None and len(s) > limit:
        s = s[: limit - 1] + "…"
    return s


def fmt(x: Any) -> str:
    """Compact number formatting for tables (NaN/None → ``n/a``)."""
    return _fmt(x)


def markdown_table(header: list[str], rows: list[list[str]]) -> list[str]:
    """Lines of a Markdown table (cells escaped)."""
    lines = ["| " + " | ".join(_esc(h) for h in header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_esc(c) for c in r) + " |" for r in rows]
    return lines


def figures_section(figs: dict[str, Path], root: Path) -> list[str]:
    """Markdown lines of a "Figures" section embedding ``figs`` (``{title: path}``) with paths
    relative to ``root`` (the report's folder); no lines when there are no figures."""
    if not figs:
        return []
    lines = ["", "## Figures", ""]
    for name, path in figs.items():
        rel = Path(path).relative_to(root).as_posix()
        lines += [f"### {name}", "", f"![{name}]({rel})", ""]
    return lines


def _fmt(x: Any) -> str:
    if isinstance(x, bool):
        return "yes" if x else "no"
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    x = float(x)
    if x == 0:
        return "0"
    ax = abs(x)
    if ax >= 1e4 or ax < 1e-3:
        return f"{x:.3g}"
    if ax >= 100:
        return f"{x:.0f}"
    return f"{x:#.3g}"  # '#' keeps trailing zeros: 1.00, not 1


def _cell(o: RunOutcome, key: str) -> str:
    if o.status == "n/a":
        return NOT_APPLICABLE
    if o.status != "ok":
        return "FAILED"
    v = o.metrics.get(key, float("nan"))
    if key == "settling_time_s" and isinstance(v, float) and math.isnan(v):
        return f"not settled ({_fmt(o.metrics.get('final_error_deg'))}° at end)"
    s = _fmt(v)
    if key == "unwinding_ratio" and o.metrics.get("unwound"):
        s += " **unwound**"
    return s


def _summary_cell(o: RunOutcome) -> str:
    if o.status == "n/a":
        return f"{NOT_APPLICABLE} ({_esc(o.error or '', 60)})"
    if o.status != "ok":
        return "FAILED: " + _esc(o.error or "", 90)
    m = o.metrics
    ts = m["settling_time_s"]
    if math.isnan(ts):
        txt = f"not settled; θ_f = {_fmt(m['final_error_deg'])}°"
    else:
        txt = f"settled in {_fmt(ts)} s"
    if m.get("unwound"):
        txt += ", unwound"
    if "final_position_error_m" in m:
        txt += f"; position error {_fmt(m['final_position_error_m'])} m"
    return txt


def _table(result: SuiteResult, cell: Callable[[RunOutcome], str]) -> list[str]:
    names = [s.name for s in result.scenarios]
    rows = []
    for c in result.controllers:
        rows.append([f"`{c}`"] + [cell(result.outcome(s, c)) for s in names])
    lines = [
        "| controller | " + " | ".join(names) + " |",
        "|---|" + "---|" * len(names),
    ]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return lines


def write_report(result: SuiteResult, out_dir: Path, *, figures: bool = True) -> Path:
    """Write the whole report folder; returns the path of ``report.md``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_csv(result, out_dir / "metrics.csv")
    write_json(result, out_dir / "metrics.json")
    figs = write_figures(result, out_dir / "figures") if figures else {}

    lines = [
        f"# Benchmark report — suite `{result.suite}`",
        "",
        f"Generated {time.strftime('%Y-%m-%d %H:%M:%S')} on Python {platform.python_version()}, "
        f"numpy {np.__version__}; suite wall time {result.wall_time_s:.1f} s; "
        f"{len(result.outcomes)} pairs: {result.n_ok} ok, {result.n_failed} failed, "
        f"{len(result.outcomes) - result.n_ok - result.n_failed} do not apply; "
        f"executor: {result.executor}.",
        "",
        "Metric definitions: `docs/benchmarks.md` / `benchmarks.metrics`. Angles are the "
        "geodesic error θ between R and R_d; NaN metrics read *n/a* (not defined for that "
        "run), a run whose final error is above 0.1° is *not settled*, *does not apply* marks a "
        "controller that is not defined for that plant (SE(3) vs attitude).",
        "",
        "## Scenarios",
        "",
        "| scenario | description | initial error [deg] | duration [s] | dt [s] "
        "| control period [s] |",
        "|---|---|---|---|---|---|",
    ]
    for s in result.scenarios:
        lines.append(
            f"| {s.name} | {_esc(s.description)} | {s.initial_error_deg:.1f} | {s.duration:g} "
            f"| {s.dt:g} | {s.control_period if s.control_period is not None else s.dt:g} |"
        )
    lines += ["", "## Controllers", ""]
    for c in result.controllers:
        lines.append(f"- `{c}`: {_esc(result.descriptions.get(c, ''))}")
    lines += ["", "## Summary", ""]
    lines += _table(result, _summary_cell)
    tables = list(TABLE_METRICS)
    if any("final_position_error_m" in o.metrics for o in result.outcomes):
        tables += list(POSE_METRICS)
    for key, title in tables:
        lines += ["", f"### {title}", ""]
        lines += _table(result, lambda o, k=key: _cell(o, k))
    failed = [o for o in result.outcomes if o.status == "failed"]
    if failed:
        lines += ["", "## Failures", ""]
        for o in failed:
            lines.append(f"- `{o.controller}` on `{o.scenario}`: {_esc(o.error or '')}")
    lines += figures_section(figs, out_dir)
    path = out_dir / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _metric_keys(result: SuiteResult) -> list[str]:
    keys = list(UNITS)
    for o in result.outcomes:
        for k in o.metrics:
            if k not in keys:
                keys.append(k)
    return keys


def write_csv(result: SuiteResult, path: Path) -> None:
    """One row per (scenario, controller); empty metric cells for failed runs, ``nan`` for
    undefined metrics."""
    keys = _metric_keys(result)
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(list(CSV_LEAD) + keys)
        for o in result.outcomes:
            row = [o.scenario, o.controller, o.status, o.error or ""]
            row += [o.metrics.get(k, "") for k in keys]
            w.writerow(row)


def _json_value(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def write_json(result: SuiteResult, path: Path) -> None:
    """Everything in ``metrics.csv`` plus units, scenarios and run metadata (NaN → null)."""
    import dataclasses

    keys = _metric_keys(result)
    units = dict(UNITS)
    units.update({"controller_time_us": "µs", "sim_wall_time_s": "s"})
    doc = {
        "suite": result.suite,
        "wall_time_s": result.wall_time_s,
        "units": {k: units.get(k, "") for k in keys},
        "scenarios": [dataclasses.asdict(s) for s in result.scenarios],
        "controllers": list(result.controllers),
        "results": [
            {
                "scenario": o.scenario,
                "controller": o.controller,
                "status": o.status,
                "error": o.error,
                "metrics": {k: _json_value(o.metrics[k]) for k in keys if k in o.metrics},
            }
            for o in result.outcomes
        ],
    }
    path.write_text(json.dumps(doc, indent=2, allow_nan=False) + "\n", encoding="utf-8")


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(fig: Any, path: Path) -> Path:
    """Save a report figure (90 dpi) and close it (figures are not reused); return ``path``."""
    fig.savefig(path, dpi=90)
    _plt().close(fig)
    return path


def controller_colors(names: Sequence[str]) -> dict[str, Any]:
    """A distinct colour per controller (tab20), stable for a given list."""
    import matplotlib

    cmap = matplotlib.colormaps["tab20"]
    return {n: cmap(i % 20) for i, n in enumerate(names)}


def write_figures(result: SuiteResult, fig_dir: Path) -> dict[str, Path]:
    """One 2×2 PNG per scenario, all controllers overlaid: attitude error (log scale), rate
    error norm, max gimbal rate and singularity measure (SE(3): position error), plus
    ``overview.png``, the settling-time map controllers × scenarios. Returns
    ``{name: path}``."""
    plt = _plt()
    fig_dir = Path(fig_dir)
    fig_dir.mkdir(parents=True, exist_ok=True)
    all_panels = (
        ("error_deg", "attitude error θ [deg]", True),
        ("rate_deg_s", "‖ω − RᵀR_dω_d‖ [deg/s]", True),
        ("gimbal_rate_rad_s", "max |δ̇ᵢ| [rad/s]", False),
        ("singularity", "singularity measure m", False),
        ("position_error_m", "position error ‖p − p_d‖ [m]", True),
    )
    colors = controller_colors(result.controllers)
    out: dict[str, Path] = {}
    for s in result.scenarios:
        runs = [result.outcome(s.name, c) for c in result.controllers]
        runs = [o for o in runs if o.status != "n/a" and "t" in o.series]
        if not runs:
            continue
        keys = [p for p in all_panels if any(p[0] in o.series for o in runs)][:4]
        fig, axes = plt.subplots(2, 2, figsize=(12, 7.5), sharex=True, constrained_layout=True)
        for ax, (key, label, log) in zip(axes.flat, keys, strict=False):
            for o in runs:
                if key not in o.series:
                    continue
                y = np.asarray(o.series[key], dtype=float)
                if log:
                    y = np.maximum(y, 1e-6)  # log axis: clip exact zeros
                lab = o.controller if o.status == "ok" else f"{o.controller} (failed)"
                ax.plot(o.series["t"], y, label=lab, lw=1.1, color=colors[o.controller])
            if log:
                ax.set_yscale("log")
            if key == "error_deg":
                ax.axhline(0.1, color="k", ls=":", lw=0.8)
            ax.set_ylabel(label)
            ax.grid(True, alpha=0.3)
        for ax in axes.flat[len(keys) :]:
            ax.set_visible(False)
        for ax in axes[1]:
            ax.set_xlabel("t [s]")
        handles, labels = axes[0, 0].get_legend_handles_labels()
        if handles:
            fig.legend(handles, labels, loc="outside right center", fontsize=7)
        fig.suptitle(f"{s.name}: {s.description}", fontsize=10)
        out[s.name] = save_png(fig, fig_dir / f"{s.name}.png")
    path = _overview_figure(result, fig_dir / "overview.png")
    if path is not None:
        out["overview"] = path
    return out


def _overview_figure(result: SuiteResult, path: Path) -> Path | None:
    """Heat map of the settling time / duration: green fast, red not settled, grey n/a."""
    plt = _plt()
    import matplotlib.colors as mcolors

    C, S = len(result.controllers), len(result.scenarios)
    val = np.full((C, S), np.nan)
    text = [["" for _ in range(S)] for _ in range(C)]
    for i, c in enumerate(result.controllers):
        for j, s in enumerate(result.scenarios):
            o = result.outcome(s.name, c)
            if o.status == "n/a":
                text[i][j] = "—"
            elif o.status != "ok":
                val[i, j], text[i][j] = 1.2, "fail"
            else:
                ts = o.metrics.get("settling_time_s", float("nan"))
                if isinstance(ts, float) and math.isnan(ts):
                    val[i, j], text[i][j] = 1.1, "no"
                else:
                    val[i, j], text[i][j] = float(ts) / s.duration, f"{float(ts):.0f}"
    if np.all(np.isnan(val)):
        return None
    fig, ax = plt.subplots(
        figsize=(max(5.5, 2.5 + 0.75 * S), 1.2 + 0.38 * C), constrained_layout=True
    )
    cmap = mcolors.LinearSegmentedColormap.from_list("settle", ["#2e7d32", "#fdd835", "#c62828"])
    cmap = cmap.with_extremes(bad="#d0d0d0")
    ax.imshow(np.ma.masked_invalid(val), cmap=cmap, vmin=0.0, vmax=1.2, aspect="auto")
    for i in range(C):
        for j in range(S):
            ax.text(j, i, text[i][j], ha="center", va="center", fontsize=7)
    ax.set_xticks(range(S), [s.name for s in result.scenarios], rotation=40, ha="right", fontsize=8)
    ax.set_yticks(range(C), list(result.controllers), fontsize=8)
    ax.set_title(
        "settling time to 0.1° [s]\n(no: not settled, fail: failed, —: does not apply)", fontsize=9
    )
    return save_png(fig, path)
