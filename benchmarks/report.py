"""Report folder of a suite run: ``report.md``, ``metrics.csv``, ``metrics.json`` and PNG
figures (matplotlib, Agg backend).

``report.md`` holds the scenarios with their tolerances, the verdict rules, a summary table
(controllers × scenarios: the verdict of :func:`benchmarks.metrics.judge` and its flags, with
the settling time or the final error), the Pareto fronts, and one controllers × scenarios table
per metric — actuator metrics only over the scenarios whose plant has that actuator (gimbal
metrics on SGCMG plants, wheel metrics on wheel plants, force on SE(3)). Cells of runs that
raised (verdict ``error``) say ``error`` and the exception text is listed under "Errors"; the
word ``failed`` is kept for the verdict "did not converge" (one word per meaning). A pair
whose controller does not apply to the scenario reads ``does not apply`` (the summary says
why). Metrics not defined for a run (NaN) read ``n/a``; a NaN settling time reads
``not settled``. No cell is ever empty.

Figures: per scenario the time histories (panels chosen by the plant, every panel with its time
axis) and a Pareto figure (performance vs control effort and vs peak actuator use, one marker
per controller, verdict by fill), plus ``overview.png`` coloured by verdict. Controllers are told
apart by a colour-blind-safe palette (Okabe & Ito) combined with line styles and markers.
:func:`write_sweep_report` writes the bandwidth sweep (``--sweep-bandwidth``). Exact metric
definitions: :mod:`benchmarks.metrics` and ``docs/benchmarks.md``.
"""

from __future__ import annotations

import csv
import json
import math
import platform
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from .controller_cost import cost_section
from .metrics import (
    CHATTER_REVERSALS,
    DESCRIPTIONS,
    MOMENTUM_SATURATED_FRACTION,
    NEAR_SINGULAR_M,
    RUN_UNITS,
    UNITS,
    VERDICTS,
)
from .ranking_report import dealiased, dispersion_section
from .requirements import meets, requirements_of
from .runner import RunOutcome, SuiteResult
from .tuning_report import tuning_section

__all__ = [
    "TABLE_METRICS",
    "POSE_METRICS",
    "DETUMBLE_METRICS",
    "SUN_ACQUISITION_METRICS",
    "ATTITUDE_OR_POSE",
    "METRIC_PLANTS",
    "NOT_APPLICABLE",
    "PALETTE",
    "VERDICT_COLORS",
    "write_report",
    "write_csv",
    "write_json",
    "write_figures",
    "write_pareto_figure",
    "write_sweep_report",
    "pareto_front",
    "performance",
    "peak_actuator_use",
    "controller_colors",
    "controller_styles",
    "fmt",
    "markdown_table",
    "figures_section",
]

#: (field, column title) of the per-metric tables, in order.
TABLE_METRICS: tuple[tuple[str, str], ...] = (
    ("settling_time_s", "Settling time to the scenario's attitude tolerance [s]"),
    ("steady_error_max_deg", "Steady-state error (max over final 10 %) [deg]"),
    ("peak_rate_deg_s", "Peak rate ‖ω − RᵀR_dω_d‖ [deg/s]"),
    ("overshoot_deg", "Overshoot past the target along the approach axis [deg]"),
    ("effort_Nms", "Control effort ∫‖u‖dt [N·m·s]"),
    ("peak_torque_Nm", "Peak torque ‖u‖ [N·m]"),
    ("saturation_time_s", "Time with an actuator limit active [s]"),
    ("peak_gimbal_rate_rad_s", "SGCMG: peak gimbal rate [rad/s]"),
    ("peak_gimbal_rate_frac", "SGCMG: peak gimbal rate / limit [-]"),
    ("min_singularity", f"SGCMG: minimum singularity measure m [-] (< {NEAR_SINGULAR_M}: flagged)"),
    ("peak_momentum_Nms", "Peak stored actuator momentum ‖h‖ [N·m·s]"),
    ("peak_momentum_fraction",
     f"Peak momentum fraction (SGCMG: ‖h‖ / envelope along ĥ; wheels: max |Ω_i|/Ω_max; "
     f"≥ {MOMENTUM_SATURATED_FRACTION}: momentum-saturated) [-]"),
    ("peak_wheel_speed_frac", "Wheels: peak wheel speed / speed limit [-]"),
    ("wheel_speed_saturation_time_s", "Wheels: time at the speed limit (momentum saturated) [s]"),
    ("torque_saturation_time_s", "Wheels: time with a wheel torque clipped [s]"),
    ("unwinding_ratio", "Path-length ratio (path angle / geodesic angle; a cost: unwinding is "
     "the crossing of θ = π) [-]"),
    ("command_reversals", f"Command reversals (≥ {CHATTER_REVERSALS}: chattering) [-]"),
)
#: Extra tables when a suite has SE(3) runs.
POSE_METRICS: tuple[tuple[str, str], ...] = (
    ("final_position_error_m", "SE(3): final position error [m]"),
    ("steady_position_error_max_m", "SE(3): position error, max over final 10 % [m]"),
    ("position_settling_time_s", "SE(3): position settling time to the tolerance [s]"),
    ("peak_force_N", "SE(3): peak force ‖F‖ [N]"),
    ("force_effort_Ns", "SE(3): force effort ∫‖F‖dt [N·s]"),
)
#: Extra tables when a suite has detumble runs (plant ``magnetorquer``).
DETUMBLE_METRICS: tuple[tuple[str, str], ...] = (
    ("time_to_detumble_s", "Detumble: time until ‖ω‖ stays below the threshold [s]"),
    ("averaged_detumble_time_s", "Detumble: time the gain implies (averaged dynamics) [s]"),
    ("final_rate_deg_s", "Detumble: final rate ‖ω‖ [deg/s]"),
    ("electrical_energy_J", "Detumble: rod electrical energy [J]"),
    ("peak_dipole_frac", "Detumble: peak rod dipole / limit [-]"),
)
#: Extra tables when a suite has Sun-acquisition runs (plant ``sun-safe``).
SUN_ACQUISITION_METRICS: tuple[tuple[str, str], ...] = (
    ("time_to_acquire_s", "Sun acquisition: time until the Sun angle stays within the "
     "threshold [s]"),
    ("sun_angle_rms_deg", "Sun acquisition: RMS Sun angle over the window before the eclipse "
     "[deg]"),
    ("sun_angle_error_deg", "Sun acquisition: max Sun angle over the window before the eclipse "
     "[deg]"),
    ("peak_rate_eclipse_deg_s", "Sun acquisition: peak rate ‖ω‖ in the eclipse [deg/s]"),
    ("sun_angle_exit_deg", "Sun acquisition: Sun angle at the eclipse exit [deg]"),
    ("reacquire_s", "Sun acquisition: time to re-acquire after the eclipse exit [s]"),
)  # fmt: skip
#: Plant tags of the attitude and SE(3) scenarios: the plants of a metric that
#: :data:`METRIC_PLANTS` does not list (the attitude-error metrics).
ATTITUDE_OR_POSE = frozenset({"sgcmg", "wheels", "ideal", "se3"})
#: Plants on which a metric is defined (tables show only those scenarios); absent:
#: :data:`ATTITUDE_OR_POSE`.
METRIC_PLANTS: dict[str, frozenset[str]] = {
    "saturation_time_s": frozenset({"sgcmg", "wheels", "ideal"}),
    "peak_gimbal_rate_rad_s": frozenset({"sgcmg"}),
    "peak_gimbal_rate_frac": frozenset({"sgcmg"}),
    "min_singularity": frozenset({"sgcmg"}),
    "peak_momentum_Nms": frozenset({"sgcmg", "wheels"}),
    "peak_momentum_fraction": frozenset({"sgcmg", "wheels"}),
    "peak_wheel_speed_frac": frozenset({"wheels"}),
    "wheel_speed_saturation_time_s": frozenset({"wheels"}),
    "torque_saturation_time_s": frozenset({"wheels"}),
    "command_reversals": frozenset({"sgcmg", "wheels", "ideal"}),
    "final_position_error_m": frozenset({"se3"}),
    "steady_position_error_max_m": frozenset({"se3"}),
    "position_settling_time_s": frozenset({"se3"}),
    "peak_force_N": frozenset({"se3"}),
    "force_effort_Ns": frozenset({"se3"}),
    **{key: frozenset({"magnetorquer"}) for key, _ in DETUMBLE_METRICS},
    **{key: frozenset({"sun-safe"}) for key, _ in SUN_ACQUISITION_METRICS},
    # the safe-mode plant is an ideal torque box: its torque tables are measured too
    "effort_Nms": ATTITUDE_OR_POSE | {"sun-safe"},
    "peak_torque_Nm": ATTITUDE_OR_POSE | {"sun-safe"},
}
#: Cell text of a pair whose controller does not apply to the scenario.
NOT_APPLICABLE = "does not apply"
#: Okabe & Ito's colour-blind-safe palette (yellow left out: unreadable on white).
PALETTE: tuple[str, ...] = (
    "#000000",
    "#E69F00",
    "#56B4E9",
    "#009E73",
    "#0072B2",
    "#D55E00",
    "#CC79A7",
)
_LINESTYLES = ("-", "--", ":", "-.")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "h", "*", "p", "d")
#: Fill colour of each verdict (overview, Pareto legend).
VERDICT_COLORS: dict[str, str] = {
    "success": "#009E73",
    "degraded": "#E69F00",
    "failed": "#D55E00",
    "error": "#CC79A7",
    "not-applicable": "#d9d9d9",
}
#: Values below this are drawn at it on log axes (the panel says so).
LOG_FLOOR = 1e-6

CSV_LEAD = ("scenario", "controller", "status", "verdict", "flags", "error")


def _esc(text: str, limit: int | None = None) -> str:
    s = " ".join(str(text).split()).replace("|", "\\|")
    if limit is not None and len(s) > limit:
        s = s[: limit - 1] + "…"
    return s


def fmt(x: Any) -> str:
    """Compact number formatting for tables (NaN/None → ``n/a``)."""
    if x is not None and not isinstance(x, (bool, int, float, np.integer, np.floating)):
        if not (isinstance(x, np.ndarray) and x.shape == () and np.isrealobj(x)):
            raise TypeError(f"x: expected a real number or None, got {x!r}")
    return _fmt(x)


def markdown_table(header: list[str], rows: list[list[str]]) -> list[str]:
    """Lines of a Markdown table (cells escaped); every row has one cell per header entry."""
    if isinstance(header, str) or not isinstance(header, (list, tuple)):
        raise TypeError(f"header: expected a list of strings, got {type(header).__name__}")
    if isinstance(rows, str) or not isinstance(rows, (list, tuple)):
        raise TypeError(f"rows: expected a list of rows, got {type(rows).__name__}")
    for i, r in enumerate(rows):
        if isinstance(r, str) or not isinstance(r, (list, tuple)) or len(r) != len(header):
            raise ValueError(
                f"rows: row {i} must be a list of {len(header)} cells (one per header entry), "
                f"got {r!r}"
            )
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


#: Table cells that hold a settling time: a failed run shows its verdict there instead.
SETTLING_KEYS = frozenset({"settling_time_s", "position_settling_time_s"})


def _cell(o: RunOutcome, key: str) -> str:
    if o.status == "n/a":
        return NOT_APPLICABLE
    if o.status != "ok":
        return "error"  # the run raised (verdict error); "failed" means did not converge
    if key in SETTLING_KEYS and o.verdict == "failed":
        # the settling time of a failed run is a last entry into the band that the final-10 %
        # window contradicts: show the verdict and where the error ended, as the summary does
        return _summary_cell(o)
    v = o.metrics.get(key, float("nan"))
    if key == "settling_time_s" and isinstance(v, float) and math.isnan(v):
        return f"not settled ({_fmt(o.metrics.get('final_error_deg'))}° at end)"
    unset = v is None or (isinstance(v, float) and math.isnan(v))
    if key == "position_settling_time_s" and unset:
        return f"not settled ({_fmt(o.metrics.get('final_position_error_m'))} m at end)"
    if key == "time_to_detumble_s" and unset:
        return f"not reached ({_fmt(o.metrics.get('final_rate_deg_s'))}°/s at end)"
    if key == "time_to_acquire_s" and unset:
        return f"not acquired ({_fmt(o.metrics.get('final_sun_angle_deg'))}° at end)"
    if key == "reacquire_s" and unset:
        exit_ = o.metrics.get("sun_angle_exit_deg")
        exited = isinstance(exit_, (int, float)) and math.isfinite(exit_)
        return "not re-acquired" if exited else "— (run ends before the eclipse exit)"
    if key in ("peak_rate_eclipse_deg_s", "sun_angle_exit_deg") and unset:
        return "— (run ends before the eclipse " + ("exit)" if "exit" in key else "entry)")
    if key == "command_reversals" and isinstance(v, (int, float)) and math.isfinite(v):
        return str(int(round(v)))
    s = _fmt(v)
    if key == "unwinding_ratio" and o.metrics.get("unwound"):
        s += " **unwound**"
    return s


def _verdict_text(o: RunOutcome) -> str:
    flags = f" ({', '.join(o.flags)})" if o.flags else ""
    return f"**{o.verdict or '?'}**{flags}"


def _summary_cell(o: RunOutcome) -> str:
    if o.status == "n/a":
        # the reason is written in full: a cut mid-word ("not for lar…") misleads
        return f"not-applicable: {NOT_APPLICABLE} ({_esc(o.error or '')})"
    if o.status != "ok":
        return f"{_verdict_text(o)}: the run raised " + _esc(o.error or "", 90)
    m = o.metrics
    if "time_to_acquire_s" in m:
        ta = float(m["time_to_acquire_s"])
        if math.isfinite(ta):
            txt = f"t_acquire = {_fmt(ta)} s, RMS {_fmt(m.get('sun_angle_rms_deg'))}°"
            tr = m.get("reacquire_s")
            if isinstance(tr, (int, float)) and math.isfinite(tr):
                txt += f", re-acquired {_fmt(tr)} s after the eclipse"
        else:
            txt = f"Sun {_fmt(m.get('final_sun_angle_deg'))}° off at end (not acquired)"
        return f"{_verdict_text(o)}; {txt}"
    if "time_to_detumble_s" in m:
        td = float(m["time_to_detumble_s"])
        if math.isfinite(td):
            txt = f"t_detumble = {_fmt(td)} s"
        else:
            txt = f"‖ω‖_f = {_fmt(m.get('final_rate_deg_s'))}°/s (threshold not reached)"
        return f"{_verdict_text(o)}; {txt}, E = {_fmt(m.get('electrical_energy_J'))} J"
    ts = float(m.get("settling_time_s", float("nan")))
    converged = o.verdict != "failed" and "attitude-not-converged" not in o.flags
    att = "attitude " if "final_position_error_m" in m else ""
    if converged and math.isfinite(ts):
        txt = f"{att}t_s = {_fmt(ts)} s"
    else:
        # a settling time of a run that did not converge is the last crossing into the
        # tolerance, not a settling time: show where the error ended and how far it swung
        txt = f"θ_f = {_fmt(m.get('final_error_deg'))}°"
        if "steady_error_max_deg" in m:
            txt += f" (max {_fmt(m.get('steady_error_max_deg'))}° over the final 10 %)"
    if "final_position_error_m" in m:
        tp = m.get("position_settling_time_s")
        tp = float("nan") if tp is None else float(tp)
        pos_ok = converged and "position-not-converged" not in o.flags
        if pos_ok and math.isfinite(tp):
            txt += f"; position t_s = {_fmt(tp)} s"
        else:
            txt += "; position not settled"
        txt += f", ‖Δp‖_f = {_fmt(m['final_position_error_m'])} m"
    return f"{_verdict_text(o)}; {txt}"


def _table(
    result: SuiteResult,
    cell: Callable[[RunOutcome], str],
    plants: frozenset[str] | None = None,
) -> list[str]:
    scs = [s for s in result.scenarios if plants is None or s.plant in plants]
    names = [s.name for s in scs]
    rows = []
    for c in result.controllers:
        label = f"`{c}`" + "".join(f" (= `{a}`)" for a in getattr(result, "aliases", {}).get(c, ()))
        rows.append([label] + [cell(result.outcome(s, c)) for s in names])
    lines = [
        "| controller | " + " | ".join(names) + " |",
        "|---|" + "---|" * len(names),
    ]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return lines


# --------------------------------------------------------------------------- Pareto


def _check_run(scenario: Any, metrics: Any) -> None:
    if getattr(scenario, "plant", None) not in ATTITUDE_OR_POSE | {"magnetorquer", "sun-safe"}:
        raise TypeError(f"scenario: expected a Scenario, got {type(scenario).__name__}")
    if not isinstance(metrics, Mapping):
        raise TypeError(f"metrics: expected a mapping of metrics, got {type(metrics).__name__}")


def performance(scenario: Any, metrics: Mapping[str, Any]) -> tuple[float, str]:
    """The performance axis of the Pareto figure: SE(3) — the position settling time [s];
    attitude — the settling time [s] when the scenario starts outside its attitude tolerance (a
    manoeuvre), else the RMS attitude error over the final 10 % [deg] (regulation: nothing to
    settle); detumble — the time to detumble [s]. Returns ``(value, label)``; a run that does
    not settle gives NaN."""
    _check_run(scenario, metrics)
    if scenario.plant == "sun-safe":
        v = metrics.get("time_to_acquire_s")
        return (float("nan") if v is None else float(v)), "time to acquire the Sun [s]"
    if scenario.plant == "magnetorquer":
        v = metrics.get("time_to_detumble_s")
        return (float("nan") if v is None else float(v)), "time to detumble [s]"
    if scenario.plant == "se3":
        v = metrics.get("position_settling_time_s")
        return (float("nan") if v is None else float(v)), "position settling time [s]"
    if scenario.initial_error_deg > scenario.attitude_tolerance_deg:
        return float(metrics.get("settling_time_s", float("nan"))), "settling time [s]"
    return float(metrics.get("steady_error_rms_deg", float("nan"))), "steady RMS error [deg]"


def peak_actuator_use(scenario: Any, metrics: Mapping[str, Any]) -> tuple[float, str]:
    """Peak actuator use by plant: SGCMG — peak gimbal rate / limit; wheels — peak wheel speed
    / limit; ideal torque — peak ‖u‖ [N·m]; SE(3) — peak ‖F‖ [N]; magnetorquers — peak rod
    dipole / limit. Returns ``(value, label)``."""
    _check_run(scenario, metrics)
    key, label = {
        "sgcmg": ("peak_gimbal_rate_frac", "peak gimbal rate / limit [-]"),
        "wheels": ("peak_wheel_speed_frac", "peak wheel speed / limit [-]"),
        "ideal": ("peak_torque_Nm", "peak torque ‖u‖ [N·m]"),
        "se3": ("peak_force_N", "peak force ‖F‖ [N]"),
        "magnetorquer": ("peak_dipole_frac", "peak rod dipole / limit [-]"),
        "sun-safe": ("peak_torque_Nm", "peak torque ‖u‖ [N·m]"),
    }[scenario.plant]
    v = metrics.get(key)
    return (float("nan") if v is None else float(v)), label


def _effort(scenario: Any, metrics: Mapping[str, Any]) -> tuple[float, str]:
    """Control effort of the Pareto figure: ∫‖u‖dt [N·m·s]; SE(3): ∫‖F‖dt [N·s] (the force
    dominates the approach's cost); detumble: the rods' electrical energy [J]."""
    if scenario.plant == "magnetorquer":
        v = metrics.get("electrical_energy_J")
        return (float("nan") if v is None else float(v)), "rod electrical energy [J]"
    if scenario.plant == "se3":
        v = metrics.get("force_effort_Ns")
        return (float("nan") if v is None else float(v)), "force effort ∫‖F‖dt [N·s]"
    v = metrics.get("effort_Nms")
    return (float("nan") if v is None else float(v)), "control effort ∫‖u‖dt [N·m·s]"


def _scale_axis(ax: Any, values: Sequence[float], axis: str = "x") -> str:
    """Log scale when the finite ``values`` span more than a decade, else linear; at most five
    ticks either way (narrow ranges of large numbers must not crowd the labels). Returns the
    suffix for the axis label."""
    from matplotlib.ticker import MaxNLocator

    v = [x for x in values if math.isfinite(x) and x > 0]
    log = bool(v) and max(v) / min(v) > 10.0
    if log:
        from matplotlib.ticker import LogFormatterSciNotation, LogLocator, NullFormatter

        (ax.set_xscale if axis == "x" else ax.set_yscale)("log")
        ax_ = ax.xaxis if axis == "x" else ax.yaxis
        # minor-tick labels of a log axis spanning a few decades collide
        ax_.set_minor_formatter(NullFormatter())
        if max(v) / min(v) < 1e3:
            # one or two decades may hold a single power of ten: label 1, 2, 5 × 10^k too,
            # so the axis always shows at least two labelled ticks
            ax_.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
            ax_.set_major_formatter(LogFormatterSciNotation(labelOnlyBase=False))
        return " (log)"
    loc = ax.xaxis if axis == "x" else ax.yaxis
    loc.set_major_locator(MaxNLocator(5))
    ax.ticklabel_format(axis=axis, style="sci", scilimits=(-3, 4), useOffset=True)
    return ""


def _axis_fraction(values: Sequence[float]) -> Callable[[float], float]:
    """Map a value to its fraction of the span of ``values`` on the scale
    :func:`_scale_axis` picks (log beyond a decade), to find markers that overlap on screen."""
    v = [x for x in values if math.isfinite(x)]
    pos = [x for x in v if x > 0]
    if pos and len(pos) == len(v) and max(pos) / min(pos) > 10.0:
        lo, hi = math.log(min(pos)), math.log(max(pos))
        return lambda x: (math.log(x) - lo) / (hi - lo)
    if not v or max(v) == min(v):
        return lambda x: 0.0
    lo, hi = min(v), max(v)
    return lambda x: (x - lo) / (hi - lo)


#: Relative tolerance of the Pareto comparison: values within 1 % are equivalent.
PARETO_REL_TOL = 0.01


def pareto_front(
    points: Mapping[str, tuple[float, float]],
    *,
    rel_tol: float = 0.0,
    abs_tol: tuple[float, float] = (0.0, 0.0),
) -> list[str]:
    """Names whose ``(x, y)`` no other point dominates (both minimised), sorted by ``x``.

    Two values a, b of one axis are equivalent when ``|a − b| ≤ max(abs_tol, rel_tol·max(|a|,
    |b|))``. A point is dominated when another is better beyond that tolerance in one axis and
    not worse beyond it in the other; so identical (or equivalent) points are either both on
    the front or both off it. With zero tolerances this is the classical strict definition.
    Non-finite points are never on the front."""
    if not isinstance(points, Mapping):
        raise TypeError(f"points: expected a mapping name -> (x, y), got {type(points).__name__}")
    rel_tol = float(rel_tol)
    if not (math.isfinite(rel_tol) and rel_tol >= 0):
        raise ValueError(f"rel_tol: must be a finite number >= 0, got {rel_tol}")
    try:
        atol = tuple(float(a) for a in abs_tol)
    except (TypeError, ValueError):
        raise TypeError(f"abs_tol: expected two numbers, got {abs_tol!r}") from None
    if len(atol) != 2 or not all(math.isfinite(a) and a >= 0 for a in atol):
        raise ValueError(f"abs_tol: must be two finite numbers >= 0, got {abs_tol!r}")
    pts = {}
    for k, v in points.items():
        try:
            x, y = (float(c) for c in v)
        except (TypeError, ValueError):
            raise ValueError(f"points: {k!r} must map to two numbers (x, y), got {v!r}") from None
        if math.isfinite(x) and math.isfinite(y):
            pts[k] = (x, y)

    def better(a: float, b: float, i: int) -> bool:  # a beats b beyond the tolerance
        return b - a > max(atol[i], rel_tol * max(abs(a), abs(b)))

    front = []
    for k, (x, y) in pts.items():
        dominated = any(
            (better(x2, x, 0) and not better(y, y2, 1))
            or (better(y2, y, 1) and not better(x, x2, 0))
            for k2, (x2, y2) in pts.items()
            if k2 != k
        )
        if not dominated:
            front.append(k)
    return sorted(front, key=lambda k: (pts[k][0], pts[k][1]))


def _narrow_axis(values: Sequence[float], rel: float = 5e-3) -> bool:
    """True when all finite ``values`` lie within ``rel`` (relative to the largest)."""
    v = [abs(float(a)) for a in values if math.isfinite(a)]
    if len(v) < 2:
        return False
    return max(v) - min(v) <= rel * max(v)


def _pareto_points(
    result: SuiteResult, scenario: Any
) -> tuple[dict[str, tuple[float, float, float]], str, str]:
    """``{controller: (performance, effort, peak use)}`` over completed, converged runs."""
    out: dict[str, tuple[float, float, float]] = {}
    perf_label, use_label = "", ""
    for c in result.controllers:
        o = result.outcome(scenario.name, c)
        if o.status != "ok":
            continue
        perf, perf_label = performance(scenario, o.metrics)
        if o.verdict == "failed" and _is_settling(scenario):
            # a failed manoeuvre has no settling time: drawn on the "did not settle" line; a
            # failed regulation run keeps its real steady error on the real axis
            perf = float("nan")
        use, use_label = peak_actuator_use(scenario, o.metrics)
        out[c] = (perf, _effort(scenario, o.metrics)[0], use)
    return out, perf_label, use_label


def front_eligible(result: SuiteResult, scenario: Any, controller: str) -> bool:
    """A nominal run may stand on a Pareto front only when it meets every requirement of the
    scenario (:mod:`benchmarks.requirements`) and its single-run verdict is ``success`` (no
    saturation, unwinding, overshoot … flag): a degraded or failed run is drawn, distinguishable,
    but never on the front."""
    o = result.outcome(scenario.name, controller)
    return o.verdict == "success" and meets(requirements_of(scenario), o.metrics)[0]


def _fronts(result: SuiteResult, scenario: Any) -> tuple[list[str], list[str]]:
    """Pareto fronts (performance vs effort, performance vs peak actuator use) among the runs
    that may stand on one (:func:`front_eligible`). Values within :data:`PARETO_REL_TOL`
    (settling times also within one control period) are equivalent."""
    pts, _, _ = _pareto_points(result, scenario)
    ok = {c: v for c, v in pts.items() if front_eligible(result, scenario, c)}
    period = getattr(scenario, "control_period", None) or getattr(scenario, "dt", 0.0)
    perf_abs = float(period) if _is_settling(scenario) else 0.0
    kw = {"rel_tol": PARETO_REL_TOL, "abs_tol": (0.0, perf_abs)}
    effort = pareto_front({c: (v[1], v[0]) for c, v in ok.items()}, **kw)
    use = pareto_front({c: (v[2], v[0]) for c, v in ok.items()}, **kw)
    return effort, use


def _is_settling(scenario: Any) -> bool:
    """True when the performance axis of ``scenario`` is a settling time (not an RMS error)."""
    return bool(performance(scenario, {"settling_time_s": 0.0,
                                        "position_settling_time_s": 0.0,
                                        "steady_error_rms_deg": 0.0})[1].endswith("[s]"))


def _front_cell(result: SuiteResult, scenario: Any, front: list[str], axis: int) -> str:
    pts, _, _ = _pareto_points(result, scenario)
    vals = [v[axis] for c, v in pts.items() if front_eligible(result, scenario, c)]
    names = ", ".join(f"`{c}`" for c in front) or "none"
    if _narrow_axis(vals):
        lo, hi = min(vals), max(vals)
        return (f"{names} (cost {_fmt(lo)}–{_fmt(hi)}: within 0.5 %, not a separating axis; "
                "the front is decided by performance alone)")
    return names


def _wrap_title(text: str, width_in: float, fontsize: float) -> str:
    """``text`` wrapped (at spaces; existing line breaks kept) to lines that fit ``width_in``
    inches at ``fontsize`` points: a long scenario description must not run past the
    figure's edges, where the saved PNG would cut it."""
    import textwrap

    chars = max(20, int(width_in * 72.0 / (0.6 * fontsize)))
    return "\n".join(textwrap.fill(line, chars) if line else line for line in text.split("\n"))


def _fault_text(scenario: Any) -> str:
    """``""``, or the scenario's actuator faults for a figure title (time-history panels also
    draw each fault time as a red dashed line)."""
    faults = getattr(scenario, "faults", ())
    if not faults:
        return ""
    parts = [f"{f.kind} unit {f.unit} at {f.time:g} s" for f in faults]
    return "\nfault: " + "; ".join(parts) + " (red dashed)"


def write_pareto_figure(result: SuiteResult, scenario: Any, path: Path) -> Path | None:
    """Performance vs control effort and vs peak actuator use for ``scenario``: one marker per
    controller (its colour and shape), filled for ``success``, hollow for ``degraded``, hollow
    with a grey cross for ``failed``; runs that did not settle are drawn at the top edge
    (marked). Coincident markers stay at their true position (no sideways jitter: an axis
    may be a ratio whose value matters), drawn as concentric markers of decreasing size so
    each one shows, and labelled "n overlapping" inside the axes. The legend shows each
    controller with a filled marker; the verdict
    encoding has its own grey entries. The Pareto front (with the tie tolerance of
    :func:`pareto_front`) of the runs that meet every requirement with a ``success`` verdict
    (:func:`front_eligible`) is drawn as a step line."""
    _check_result(result)
    plt = _plt()

    pts, perf_label, use_label = _pareto_points(result, scenario)
    if not pts:
        return None
    styles = controller_styles(result.controllers)
    finite = [v[0] for v in pts.values() if math.isfinite(v[0])]
    top = (max(finite) * 1.15 if finite else 1.0) or 1.0
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    fronts = _fronts(result, scenario)
    any_unsettled = False
    effort_label = _effort(scenario, {})[1]
    for ax, j, xlabel, front in (
        (axes[0], 1, effort_label, fronts[0]),
        (axes[1], 2, use_label, fronts[1]),
    ):
        # groups of (near-)coincident markers: drawn concentrically at the true position
        # (largest underneath) and labelled with how many overlap
        drawn = [(c, v[j], v[0] if math.isfinite(v[0]) else top) for c, v in pts.items()
                 if math.isfinite(v[j])]
        nx = _axis_fraction([d[1] for d in drawn])
        ny = _axis_fraction([d[2] for d in drawn])
        groups: list[list[tuple[str, float, float]]] = []
        for item in drawn:
            for g in groups:
                # markers closer than ~2 % of the axis span in both directions overlap
                if (abs(nx(item[1]) - nx(g[0][1])) <= 0.02
                        and abs(ny(item[2]) - ny(g[0][2])) <= 0.02):
                    g.append(item)
                    break
            else:
                groups.append([item])
        for g in groups:
            for n, (c, x, y) in enumerate(g):
                o = result.outcome(scenario.name, c)
                st = styles[c]
                any_unsettled |= not math.isfinite(pts[c][0])
                # the first of a group is the largest; at most 24 pt larger than a lone marker
                size = 9.0 + min(5.0, 24.0 / max(1, len(g) - 1)) * (len(g) - 1 - n)
                filled = o.verdict == "success"
                ax.plot(
                    [x], [y], linestyle="none", marker=st["marker"], markersize=size,
                    markeredgecolor=st["color"], markeredgewidth=1.6,
                    markerfacecolor=st["color"] if filled else "none", zorder=2 + 0.01 * n,
                )  # fmt: skip
                if o.verdict in ("failed", "error"):
                    ax.plot([x], [y], linestyle="none", marker="x", color="0.45",
                            markersize=size + 3, zorder=2.5 + 0.01 * n)  # fmt: skip
        multi = [g for g in groups if len(g) > 1]
        for gi, g in enumerate(multi):
            if len(g) > 1:
                # the label points into the axes (left of a marker in the right half, below
                # one in the top half) so it never spills over the frame; neighbouring
                # labels alternate their distance
                fx, fy = nx(g[0][1]), ny(g[0][2])
                big = 9.0 + min(5.0, 24.0 / max(1, len(g) - 1)) * (len(g) - 1)  # largest marker
                dx = (0.5 * big + 6.0) * (1.0 if fx <= 0.5 else -1.0)
                dy = (8.0 + 10.0 * (gi % 2)) * (1.0 if fy <= 0.5 else -1.6)
                ax.annotate(f"{len(g)} overlapping", (g[0][1], g[0][2]),
                            xytext=(dx, dy), ha="left" if dx > 0 else "right",
                            va="bottom" if dy > 0 else "top", textcoords="offset points",
                            fontsize=7, color="0.25")  # fmt: skip
        fp = [(pts[c][j], pts[c][0]) for c in front]
        if len(fp) > 1:
            xs, ys = zip(*sorted(fp), strict=True)
            ax.step(xs, ys, where="post", color="0.3", lw=1.0, ls="--")
        if any_unsettled:
            ax.axhline(top, color="0.6", lw=0.8, ls=":")
            ax.set_title("markers on the dotted top line did not settle", fontsize=8)
        ax.autoscale_view()
        if _narrow_axis([v[j] for v in pts.values()]):
            xlabel += " — all within 0.5 %: not a separating axis"
        xlabel += _scale_axis(ax, [v[j] for v in pts.values()], "x")
        _scale_axis(ax, [v[0] for v in pts.values()] + [top], "y")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(perf_label)
        ax.grid(True, alpha=0.3)
    from matplotlib.lines import Line2D

    # controller identity: its colour and shape, always filled; the verdict encoding is
    # explained only by the grey entries below
    ident = [
        Line2D([], [], ls="none", marker=styles[c]["marker"], markersize=8,
               color=styles[c]["color"], markerfacecolor=styles[c]["color"],
               label=result.display_name(c))
        for c in pts
    ]  # fmt: skip
    extra = [
        Line2D([], [], ls="none", marker="o", color="0.3", markerfacecolor="0.3",
               label="verdict success: filled"),
        Line2D([], [], ls="none", marker="o", color="0.3", markerfacecolor="none",
               label="verdict degraded: hollow"),
        Line2D([], [], ls="none", marker="x", color="0.45", label="verdict failed: ×"),
        Line2D([], [], color="0.3", lw=1.0, ls="--", label="Pareto front"),
    ]  # fmt: skip
    fig.legend(
        handles=ident + extra,
        loc="outside right center",
        fontsize=7,
    )
    fig.suptitle(
        _wrap_title(f"{scenario.name}: Pareto view (lower-left is better)"
                    f"{_fault_text(scenario)}", 0.95 * fig.get_figwidth(), 10),
        fontsize=10,
    )  # fmt: skip
    return save_png(fig, path)


def _tolerance_text(s: Any) -> str:
    if s.plant == "sun-safe":
        return f"Sun angle ≤ {s.sun_acquisition.threshold_deg:g}°"
    if s.plant == "magnetorquer":
        return f"‖ω‖ < {s.detumble.threshold_deg_s:g}°/s"
    if s.plant == "se3":
        return f"θ ≤ {s.attitude_tolerance_deg:g}°, ‖Δp‖ ≤ {s.position_tolerance_m:g} m"
    return f"θ ≤ {s.attitude_tolerance_deg:g}°"


def _plant_text(s: Any) -> str:
    if s.plant == "sun-safe":
        sa, o = s.sun_acquisition, s.orbit
        box = s.spacecraft.max_torque
        return (
            f"safe mode: {len(sa.normals)} coarse Sun sensors ({sa.fov_half_angle_deg:g}° "
            f"half-FOV, {sa.sensor_noise:g} noise, albedo-free) + gyro ({sa.gyro_noise:g} rad/s "
            f"noise, {sa.gyro_bias:g} rad/s bias 1σ), no star tracker; ideal torque "
            f"{'unlimited' if box is None else f'≤ {box:g} N·m per axis'}"
            f"{', gravity gradient' if sa.gravity_gradient else ''}; {o.altitude_km:g} km, "
            f"{o.inclination_deg:g}° orbit; eclipse: {sa.eclipse}"
        )
    if s.plant == "magnetorquer":
        d, o = s.detumble, s.orbit
        return (
            f"3 magnetorquer rods ≤ {d.max_dipole:g} A·m² on {d.duty_cycle:.0%} of each "
            f"period; magnetometer {d.magnetometer_noise:g} T noise; {o.altitude_km:g} km, "
            f"{o.inclination_deg:g}° orbit, tilted dipole; damping gain k {d.gain:g} N·m·s"
        )
    if s.plant == "se3":
        px = s.proximity
        if px is None:
            return "SE(3) chaser"
        lim = [f"‖F_i‖ ≤ {px.max_force:g} N" if px.max_force else "force unlimited",
               f"‖τ_i‖ ≤ {px.max_torque:g} N·m" if px.max_torque else "torque unlimited"]
        return f"SE(3) chaser, mass {px.mass:g} kg, " + ", ".join(lim) + " per axis"
    sp = s.spacecraft
    if sp.actuator == "sgcmg":
        txt = (f"SGCMG pyramid h₀ {sp.h0:g} N·m·s, δ̇ ≤ {sp.gimbal_rate_limit:g} rad/s, "
               f"steering `{sp.steering}`")  # fmt: skip
    elif sp.actuator == "wheels":
        n = 4 if sp.wheel_layout == "pyramid" else 3
        txt = (
            f"{n} wheels ({sp.wheel_layout}), ≤ {sp.wheel_max_torque:g} N·m, "
            f"≤ {sp.wheel_max_speed:g} rad/s"
        )
    else:
        txt = "ideal torque" + (f" ≤ {sp.max_torque:g} N·m" if sp.max_torque else "")
    if s.sensors is not None:
        est = s.sensors.estimator
        txt += "; sensed" + ("" if est == "none" else f" via {est.upper()}")
    return txt


def _initial_text(s: Any) -> str:
    """The scenario table's initial error [deg]; a detumble starts at the identity attitude,
    so its cell gives the tumble rate instead (saying so); a Sun acquisition gives the initial
    Sun angle and the tumble."""
    if s.plant == "sun-safe":
        from .safe_mode import _sun_angles

        sa = s.sun_acquisition
        css = sa.sun_sensors(s.orbit.circular_orbit())
        start = SimpleNamespace(t=np.zeros(1), R=s.error0[None, None], omega=s.omega0[None, None])
        ang = float(_sun_angles(start, css, np.asarray(sa.body_axis))[1][0, 0])
        return (
            f"— (Sun {ang:.0f}° off, tumble ‖ω₀‖ "
            f"{math.degrees(math.hypot(*s.initial_rate)):.1f}°/s)"
        )
    if s.plant == "magnetorquer":
        return f"— (tumble ‖ω₀‖ {math.degrees(math.hypot(*s.initial_rate)):.1f}°/s)"
    return f"{s.initial_error_deg:.1f}"


def _disturbance_text(s: Any) -> str:
    """The scenario's disturbances by name (with their parameters) and their size: the peak
    ‖τ_d‖ over the run at the initial attitude and rate (attitude-dependent torques change as
    the spacecraft turns), computed from the same models the runs use."""
    ds = tuple(getattr(s, "disturbances", ()) or ())
    if s.plant == "sun-safe":
        return "gravity gradient" if s.sun_acquisition.gravity_gradient else "none"
    if s.plant == "se3" or not ds:
        return "none"
    names = " + ".join(
        d.name + (f" ({', '.join(f'{k} {v:g}' for k, v in d.params)})" if d.params else "")
        for d in ds
    )
    try:
        from liecontrol.lie import so3

        from .runner import build_disturbance

        orbit = s.orbit.circular_orbit() if getattr(s, "orbit", None) is not None else None
        src = build_disturbance(ds, s.spacecraft.J, orbit=orbit)
        R0 = so3.exp(np.asarray(s.initial_rotvec, dtype=float))[None]
        w0 = np.asarray(s.initial_rate, dtype=float)[None]
        peak = max(float(np.linalg.norm(src(float(t), R0, w0)))
                   for t in np.linspace(0.0, s.duration, 121))  # fmt: skip
    except Exception:  # noqa: BLE001 - the size is a courtesy; the name is always shown
        return names
    return f"{names}: peak ‖τ_d‖ {_fmt(peak)} N·m"


def _faults_cell(s: Any) -> str:
    """The scenario's actuator faults as table text (kind, unit, time), or "none"."""
    faults = getattr(s, "faults", ())
    if not faults:
        return "none"
    return "; ".join(f"{f.kind} unit {f.unit} at {f.time:g} s" for f in faults)


VERDICT_RULES = (
    "Verdicts (`benchmarks.metrics.judge`): **success** — every error channel of the scenario "
    "(attitude; position on SE(3)) within its tolerance over the final 10 % of the run, no "
    "divergence, no unwinding, no actuator limit reached and no near-singular gimbal set; "
    "**degraded** — converged, but flagged `unwound`, `actuator-saturated` (any time with a "
    "gimbal-rate, wheel-torque or torque-box limit active), `momentum-saturated` (wheels: a "
    "wheel at its speed limit, or peak |Ω_i|/Ω_max ≥ "
    f"{MOMENTUM_SATURATED_FRACTION}; SGCMG: stored momentum ≥ "
    f"{MOMENTUM_SATURATED_FRACTION:.0%} of the cluster's momentum envelope in its direction — "
    "see the peak momentum fraction table), `near-singular` (SGCMG singularity measure m < "
    f"{NEAR_SINGULAR_M}) or "
    f"`chattering` (≥ {CHATTER_REVERSALS} command reversals); **failed** — an error channel "
    "out of tolerance (`attitude-not-converged`, `position-not-converged`) or `diverged` (ends "
    "at least 30° farther from the target than it started, or a non-finite state); "
    "**error** — the run raised (its message is listed under Errors); "
    "**not-applicable** — the controller is not defined for that plant. Detumble scenarios "
    "(plant `magnetorquer`) have their own rule: **success** when ‖ω‖ stays below the "
    "threshold before the run ends, **failed** (`rate-not-damped`) when it does not, or "
    "`diverged` on a non-finite state. Sun-acquisition scenarios (plant `sun-safe`) too: "
    "**success** when the Sun angle stays within the threshold from some time before the "
    "eclipse and again after its exit, **failed** (`sun-not-acquired`, "
    "`sun-not-reacquired`) when it does not, or `diverged`."
)


SETTLING_NOTE = (
    "How to read this: the settling time t_s is the first time the attitude error enters the "
    "scenario's tolerance band and stays inside it to the end of the run; the verdict looks "
    "only at the final 10 % of the run (the maximum error there must be within the "
    "tolerance). Both use the same band, so a run that enters it for good only inside the "
    "final window (after 90 % of the run) has a last entry into the band and still fails: "
    "it has not settled within the run. A failed run therefore never shows a settling time "
    "— every settling-time cell of a failed run shows its verdict and final error instead."
)


#: Relative band around the median settling time inside which a step-5 run is "in the spread".
SPREAD_BAND = 0.30


def _spread_lines(result: SuiteResult) -> list[str]:
    """Settling-time spread on every ``step-5`` scenario (named or tagged): at equal tuning
    the controllers should settle within ±30 % of the median; the outliers are named."""
    out: list[str] = []
    for s in result.scenarios:
        if s.name != "step-5" and "step-5" not in getattr(s, "tags", ()):
            continue
        ts = {}
        for c in result.controllers:
            o = result.outcome(s.name, c)
            v = float(o.metrics.get("settling_time_s", float("nan"))) if o.status == "ok" else (
                float("nan"))
            if o.status == "ok" and o.verdict != "failed" and math.isfinite(v):
                ts[c] = v
        if not ts:
            continue
        med = float(np.median(list(ts.values())))
        if med <= 0:
            continue
        outside = [c for c, v in ts.items() if abs(v / med - 1.0) > SPREAD_BAND]
        lo, hi = min(ts.values()) / med, max(ts.values()) / med
        line = (f"Spread on `{s.name}`: median settling time {_fmt(med)} s over {len(ts)} "
                f"settled run{'s' if len(ts) != 1 else ''}; min/median {_fmt(lo)}, "
                f"max/median {_fmt(hi)}. ")
        if outside:
            parts = []
            for c in outside:
                why = ""
                if "pid" in c:
                    why = " (the integral mode of a PID at about −ω_n/5 decays slowly)"
                parts.append(f"`{c}` {_fmt(ts[c] / med)}×{why}")
            line += f"Outside ±{SPREAD_BAND:.0%}: " + "; ".join(parts) + "."
        else:
            line += f"All settled runs lie within ±{SPREAD_BAND:.0%} of the median."
        unsettled = [c for c in result.controllers
                     if result.outcome(s.name, c).status == "ok" and c not in ts]
        if unsettled:
            line += (" Not settled (left out of the median): "
                     + ", ".join(f"`{c}`" for c in unsettled) + ".")
            if any("pid" in c for c in unsettled):
                line += (" A PID's integral mode near −ω_n/5 decays about five times slower "
                         "than the PD modes, so at equal ω_n it is the slowest to settle.")
        out += ["", line]
    return out


def _check_result(result: Any, name: str = "result") -> None:
    """``TypeError`` naming ``name`` unless ``result`` is a
    :class:`~benchmarks.runner.SuiteResult`."""
    if not isinstance(result, SuiteResult):
        raise TypeError(
            f"{name}: expected a SuiteResult (from benchmarks.runner.run_suite), got "
            f"{type(result).__name__}"
        )


def _check_out_dir(out_dir: Any, name: str = "out_dir") -> Path:
    if not isinstance(out_dir, (str, Path)):
        raise TypeError(f"{name}: expected a path (str or Path), got {type(out_dir).__name__}")
    return Path(out_dir)


def write_report(
    result: SuiteResult, out_dir: Path, *, figures: bool = True, progress: bool = False
) -> Path:
    """Write the whole report folder; returns the path of ``report.md``. ``progress``: show a
    tqdm bar (stderr) over the report's steps — each scenario's figures, the overview and
    the tuning section (which measures every controller's small-angle loop)."""
    _check_result(result)
    out_dir = _check_out_dir(out_dir)
    if not isinstance(progress, bool):
        raise TypeError(f"progress: expected a bool, got {type(progress).__name__}")
    from tqdm.auto import tqdm

    n_steps = 1 + (len(result.scenarios) + 1 if figures else 0)
    bar = tqdm(total=n_steps, desc="report and figures", unit="step", disable=not progress)

    def tick(name: str) -> None:
        bar.set_postfix_str(name, refresh=False)
        bar.update(1)

    try:
        return _write_report(result, out_dir, figures, tick)
    finally:
        bar.close()


def _write_report(
    result: SuiteResult, out_dir: Path, figures: bool, tick: Callable[[str], None]
) -> Path:
    out_dir.mkdir(parents=True, exist_ok=True)
    write_csv(result, out_dir / "metrics.csv")
    write_json(result, out_dir / "metrics.json")
    # the data files keep every controller; tables and figures show a suite-wide alias once
    full, result = result, dealiased(result)
    figs = write_figures(result, out_dir / "figures", progress=tick) if figures else {}
    counts = {v: sum(o.verdict == v for o in result.outcomes) for v in VERDICTS}

    lines = [
        f"# Benchmark report — suite `{result.suite}`",
        "",
        f"Generated {time.strftime('%Y-%m-%d %H:%M:%S')} on Python {platform.python_version()}, "
        f"numpy {np.__version__}; simulation wall time {result.wall_time_s:.1f} s (report "
        "and figures not included); "
        f"{len(result.outcomes)} pairs: "
        + ", ".join(f"{n} {v}" for v, n in counts.items())
        + f"; executor: {result.executor}.",
        "",
        "Metric definitions: `docs/benchmarks.md` / `benchmarks.metrics`. Angles are the "
        "geodesic error θ between R and R_d; NaN metrics read *n/a* (not defined for that "
        "run, e.g. gimbal metrics on a wheel plant), a run whose final error is above the "
        "scenario's tolerance is *not settled*, *does not apply* marks a controller that is not "
        "defined for that plant (SE(3) vs attitude).",
        "",
        VERDICT_RULES,
        "",
        "## Scenarios",
        "",
        "Plant: actuator with its limits (SGCMG: steering law; SE(3): chaser mass and thrust "
        "limits); disturbance: the external torque models with their peak ‖τ_d‖ over the run at "
        "the initial attitude; faults: actuator faults (kind, unit, time).",
        "",
        "| scenario | description | plant | disturbance | faults | initial error [deg] "
        "| tolerance | duration [s] | dt [s] | control period [s] |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in result.scenarios:
        lines.append(
            f"| {s.name} | {_esc(s.description)} | {_esc(_plant_text(s))} "
            f"| {_esc(_disturbance_text(s))} | {_esc(_faults_cell(s))} "
            f"| {_initial_text(s)} | {_tolerance_text(s)} | {s.duration:g} "
            f"| {s.dt:g} | {s.control_period if s.control_period is not None else s.dt:g} |"
        )
    lines += ["", "## Controllers", ""]
    for c in result.controllers:
        lines.append(f"- `{c}`: {_esc(result.descriptions.get(c, ''))}")
    lines += [""]
    lines += dispersion_section(full)
    lines += tuning_section(result)
    tick("tuning")
    lines += [
        "## Summary",
        "",
        "Verdict (flags); t_s: settling time to the attitude tolerance, θ_f: final attitude "
        "error when it does not settle, ‖Δp‖_f: final position error (SE(3)).",
        "",
        SETTLING_NOTE,
        "",
    ]
    lines += _table(result, _summary_cell)
    lines += _spread_lines(result)
    lines += [
        "",
        "## Pareto fronts",
        "",
        "Per scenario, the controllers no other controller beats in both performance (settling "
        "time; for regulation scenarios the steady RMS error) and cost — control effort ∫‖u‖dt, "
        "or peak actuator use (gimbal rate or wheel speed as a fraction of its limit; torque or "
        "force on ideal and SE(3) plants; detumble: time to detumble against the rods' energy "
        "and peak dipole / limit). Only success/degraded runs compete. Ties: two values "
        f"within {PARETO_REL_TOL:.0%} (settling times also within one control period) are "
        "equivalent; a controller is off the front only if another is better beyond that "
        "tolerance on one axis and not worse beyond it on the other, so identical runs are both "
        "on or both off. Figures: `figures/<scenario>-pareto.png`.",
        "",
        "| scenario | front: performance vs effort | front: performance vs peak actuator use |",
        "|---|---|---|",
    ]
    for s in result.scenarios:
        f_eff, f_use = _fronts(result, s)
        lines.append(
            f"| {s.name} | {_front_cell(result, s, f_eff, 1)} "
            f"| {_front_cell(result, s, f_use, 2)} |"
        )
    tables = list(TABLE_METRICS)
    if any(s.plant == "se3" for s in result.scenarios):
        tables += list(POSE_METRICS)
    if any(s.plant == "magnetorquer" for s in result.scenarios):
        tables += list(DETUMBLE_METRICS)
    if any(s.plant == "sun-safe" for s in result.scenarios):
        tables += list(SUN_ACQUISITION_METRICS)
    for key, title in tables:
        plants = METRIC_PLANTS.get(key, ATTITUDE_OR_POSE)
        if plants is not None and not any(s.plant in plants for s in result.scenarios):
            continue
        lines += ["", f"### {title}", ""]
        if plants is not None and any(s.plant not in plants for s in result.scenarios):
            lines += [f"Scenarios whose plant has no such quantity are left out. "
                      f"{_esc(DESCRIPTIONS.get(key, ''))}.", ""]  # fmt: skip
        lines += _table(result, lambda o, k=key: _cell(o, k), plants)
    lines += ["", *cost_section(result)]
    failed = [o for o in result.outcomes if o.status == "failed"]
    if failed:
        lines += ["", "## Errors (runs that raised)", ""]
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
    """One row per (scenario, controller): status, verdict, flags (``;``-separated), error,
    then the metrics (empty cells for runs that raised, ``nan`` for undefined metrics)."""
    _check_result(result)
    keys = _metric_keys(result)
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(list(CSV_LEAD) + keys)
        for o in result.outcomes:
            row = [o.scenario, o.controller, o.status, o.verdict, ";".join(o.flags), o.error or ""]
            row += [o.metrics.get(k, "") for k in keys]
            w.writerow(row)


def _json_value(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def _scenario_json(s: Any) -> dict[str, Any]:
    """``dataclasses.asdict`` of a scenario, with each fault in its scenario-file form (its
    ``kind`` is a class attribute, which ``asdict`` would drop)."""
    import dataclasses

    d = dataclasses.asdict(s)
    if "faults" in d:
        d["faults"] = [
            f.as_dict() if hasattr(f, "as_dict")
            else {"kind": getattr(f, "kind", type(f).__name__), **dataclasses.asdict(f)}
            for f in getattr(s, "faults", ())
        ]  # fmt: skip
    return d


def write_json(result: SuiteResult, path: Path) -> None:
    """Everything in ``metrics.csv`` plus units, scenarios (with their tolerances) and run
    metadata (NaN → null)."""
    _check_result(result)

    keys = _metric_keys(result)
    units = {**UNITS, **RUN_UNITS}
    doc = {
        "suite": result.suite,
        "wall_time_s": result.wall_time_s,
        "units": {k: units.get(k, "") for k in keys},
        "verdict_rules": VERDICT_RULES,
        "scenarios": [_scenario_json(s) for s in result.scenarios],
        "controllers": list(result.controllers),
        "results": [
            {
                "scenario": o.scenario,
                "controller": o.controller,
                "status": o.status,
                "verdict": o.verdict,
                "flags": list(o.flags),
                "error": o.error,
                "metrics": {k: _json_value(o.metrics[k]) for k in keys if k in o.metrics},
            }
            for o in result.outcomes
        ],
        "members": result.members,
        "member_results": [
            {
                "scenario": o.scenario,
                "controller": o.controller,
                "member": o.member,
                "status": o.status,
                "verdict": o.verdict,
                "flags": list(o.flags),
                "error": o.error,
                "metrics": {k: _json_value(o.metrics[k]) for k in keys if k in o.metrics},
            }
            for o in result.member_outcomes
        ],
        "cells": [
            {
                "scenario": c.scenario,
                "controller": c.controller,
                "members": c.n,
                "passed": c.passed,
                "wilson95": [_json_value(c.interval[0]), _json_value(c.interval[1])],
                "verdict": c.verdict,
                "single_run_verdict": c.nominal_verdict,
                "worst_margin": _json_value(c.worst_margin),
                "margins": {k: [_json_value(x) for x in v] for k, v in c.margins.items()},
                "flag_fraction": c.flag_fraction,
            }
            for c in result.cells.values()
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


def controller_styles(names: Sequence[str]) -> dict[str, dict[str, str]]:
    """``{name: {"color", "ls", "marker"}}``: the colour cycles through :data:`PALETTE`, the
    line style changes every len(PALETTE) controllers and every controller has its own marker,
    so up to 28 controllers are distinct without relying on colour alone."""
    if isinstance(names, str) or not all(isinstance(c, str) for c in names):
        raise TypeError(f"names: expected a sequence of controller names, got {names!r}")
    n = len(PALETTE)
    return {
        c: {
            "color": PALETTE[i % n],
            "ls": _LINESTYLES[(i // n) % len(_LINESTYLES)],
            "marker": _MARKERS[i % len(_MARKERS)],
        }
        for i, c in enumerate(names)
    }


def controller_colors(names: Sequence[str]) -> dict[str, Any]:
    """A colour per controller (:func:`controller_styles`' colour), stable for a given list."""
    return {c: st["color"] for c, st in controller_styles(names).items()}


#: Time-history panels: (series key, y label, log scale, plants, reference line).
_PANELS: tuple[tuple[str, str, bool, frozenset[str], tuple[float, str] | None], ...] = (
    ("error_deg", "attitude error θ [deg]", True, frozenset({"sgcmg", "wheels", "ideal", "se3"}),
     None),
    ("rate_deg_s", "‖ω − RᵀR_dω_d‖ [deg/s]", True, frozenset({"sgcmg", "wheels", "ideal", "se3"}),
     None),
    ("gimbal_rate_rad_s", "max |δ̇ᵢ| [rad/s]", False, frozenset({"sgcmg"}), None),
    ("singularity", "singularity measure m [-]", False, frozenset({"sgcmg"}),
     (NEAR_SINGULAR_M, "near-singular")),
    ("wheel_speed_frac", "max |Ωᵢ| / Ω_max [-]", False, frozenset({"wheels"}), (1.0, "limit")),
    ("momentum_Nms", "stored momentum ‖h‖ [N·m·s]", False, frozenset({"wheels"}), None),
    ("sun_angle_deg", "Sun angle (body axis to Sun) [deg]", True, frozenset({"sun-safe"}), None),
    ("torque_Nm", "torque ‖u‖ [N·m]", False, frozenset({"ideal", "sun-safe"}), None),
    ("position_error_m", "position error ‖p − p_d‖ [m]", True, frozenset({"se3"}), None),
    ("force_N", "force ‖F‖ [N]", False, frozenset({"se3"}), None),
    ("body_rate_deg_s", "body rate ‖ω‖ [deg/s]", True, frozenset({"magnetorquer", "sun-safe"}),
     None),
    ("dipole_Am2", "rod dipole ‖m‖ [A·m²]", False, frozenset({"magnetorquer"}), None),
    ("kinetic_energy_J", "kinetic energy ½ωᵀJω [J]", True, frozenset({"magnetorquer"}), None),
)  # fmt: skip


def _ticking(items: Sequence[Any], tick: Callable[[str], None] | None) -> Any:
    """Yield ``items``; after each one (also when the loop body ``continue``-s) call
    ``tick(name)`` when given (the report's progress bar)."""
    for item in items:
        yield item
        if tick is not None:
            tick(str(getattr(item, "name", item)))


def write_figures(
    result: SuiteResult, fig_dir: Path, *, progress: Callable[[str], None] | None = None
) -> dict[str, Path]:
    """Per scenario: the time histories (all controllers overlaid; panels chosen by the plant:
    attitude and rate error on every plant, gimbal rate and singularity measure on SGCMG
    plants, wheel speed and momentum on wheel plants, torque on ideal ones, position error and
    force on SE(3); every panel with its own time axis; log panels say where they clip) and
    the Pareto figure; plus ``overview.png``, the verdict map. Returns ``{name: path}``.
    ``progress``: called with the scenario's name after each scenario's figures, and with
    ``"overview"`` at the end (the command line's progress bar)."""
    _check_result(result)
    fig_dir = _check_out_dir(fig_dir, "fig_dir")
    if progress is not None and not callable(progress):
        raise TypeError(f"progress: expected a callable or None, got {type(progress).__name__}")
    plt = _plt()
    fig_dir.mkdir(parents=True, exist_ok=True)
    styles = controller_styles(result.controllers)
    out: dict[str, Path] = {}
    for s in _ticking(result.scenarios, progress):
        runs = [result.outcome(s.name, c) for c in result.controllers]
        runs = [o for o in runs if o.status != "n/a" and "t" in o.series]
        if not runs:
            continue
        panels = [p for p in _PANELS if s.plant in p[3] and any(p[0] in o.series for o in runs)]
        # line style per trace: the suite-wide style, except that a figure whose traces are all
        # broken lines draws its first trace solid, so dashed-over-solid shows coinciding traces
        fig_ls = {o.controller: styles[o.controller]["ls"] for o in runs}
        if all(ls not in ("-", "solid") for ls in fig_ls.values()):
            fig_ls[runs[0].controller] = "-"
        ncol = 2
        nrow = max(1, math.ceil(len(panels) / ncol))
        fig, axes = plt.subplots(
            nrow, ncol, figsize=(12, 3.4 * nrow + 0.8), constrained_layout=True, squeeze=False
        )
        for ax, (key, label, log, _, ref) in zip(axes.flat, panels, strict=False):
            clipped = False
            for o in runs:
                if key not in o.series:
                    continue
                y = np.asarray(o.series[key], dtype=float)
                if log:
                    clipped |= bool(np.any(y < LOG_FLOOR))
                    y = np.maximum(y, LOG_FLOOR)
                t = np.asarray(o.series["t"], dtype=float)
                st = styles[o.controller]
                name = result.display_name(o.controller)
                lab = name if o.status == "ok" else f"{name} (error)"
                # identical traces (two controllers flying the same dynamics) must not hide
                # one another: solid lines lie underneath, broken lines are drawn over them
                # and the markers of trace k are shifted by k samples
                k = runs.index(o)
                ls = fig_ls[o.controller]
                solid = ls in ("-", "solid")
                every = max(1, len(t) // 8)
                ax.plot(
                    t, y, label=lab, lw=1.8 if solid else 1.1, color=st["color"], ls=ls,
                    marker=st["marker"], markersize=4,
                    markevery=(min(k * max(1, every // len(runs)), len(t) - 1), every),
                    zorder=2 if solid else 3,
                )  # fmt: skip
            if log:
                ax.set_yscale("log")
            if key == "error_deg":
                ax.axhline(s.attitude_tolerance_deg, color="0.4", ls=":", lw=0.9)
            if key == "position_error_m":
                ax.axhline(s.position_tolerance_m, color="0.4", ls=":", lw=0.9)
            if key == "body_rate_deg_s" and s.plant == "magnetorquer":
                ax.axhline(s.detumble.threshold_deg_s, color="0.4", ls=":", lw=0.9)
            if key == "sun_angle_deg":
                ax.axhline(s.sun_acquisition.threshold_deg, color="0.4", ls=":", lw=0.9)
            if ref is not None:
                ax.axhline(ref[0], color="0.4", ls=":", lw=0.9)
            title = label
            if log and clipped:
                title += f"  (log; values < {LOG_FLOOR:g} drawn at {LOG_FLOOR:g})"
            elif key in ("error_deg", "position_error_m"):
                title += "  (dotted: tolerance)"
            elif key == "body_rate_deg_s" and s.plant == "magnetorquer":
                title += "  (dotted: detumble threshold)"
            elif key == "sun_angle_deg":
                title += "  (dotted: acquisition threshold)"
            ax.set_title(_wrap_title(title, 0.9 * fig.get_figwidth() / ncol, 8), fontsize=8)
            ax.set_ylabel(label, fontsize=8)
            ax.set_xlabel("t [s]", fontsize=8)
            ax.grid(True, alpha=0.3)
            for f in getattr(s, "faults", ()):  # the fault times (red dashed)
                ax.axvline(f.time, color="tab:red", ls="--", lw=0.9)
        for ax in axes.flat[len(panels) :]:
            ax.set_visible(False)
        handles, labels = axes[0, 0].get_legend_handles_labels()
        if handles:
            fig.legend(handles, labels, loc="outside right center", fontsize=7)
        fig.suptitle(_wrap_title(f"{s.name}: {s.description}{_fault_text(s)}",
                                 0.95 * fig.get_figwidth(), 10), fontsize=10)  # fmt: skip
        out[s.name] = save_png(fig, fig_dir / f"{s.name}.png")
        pareto = write_pareto_figure(result, s, fig_dir / f"{s.name}-pareto.png")
        if pareto is not None:
            out[f"{s.name} (Pareto)"] = pareto
    path = _overview_figure(result, fig_dir / "overview.png")
    if path is not None:
        out["overview"] = path
    if progress is not None:
        progress("overview")
    return out


def _overview_figure(result: SuiteResult, path: Path) -> Path | None:
    """Verdict map controllers × scenarios, coloured by verdict; the cell text is the
    settling time [s] for success/degraded runs, the first flag for failed ones."""
    plt = _plt()
    import matplotlib.colors as mcolors
    from matplotlib.patches import Patch

    C, S = len(result.controllers), len(result.scenarios)
    if C == 0 or S == 0:
        return None
    order = list(VERDICTS)
    val = np.zeros((C, S))
    text = [["" for _ in range(S)] for _ in range(C)]
    for i, c in enumerate(result.controllers):
        for j, s in enumerate(result.scenarios):
            o = result.outcome(s.name, c)
            v = o.verdict or ("not-applicable" if o.status == "n/a" else "error")
            val[i, j] = order.index(v)
            if o.status == "n/a":
                text[i][j] = "—"
            elif o.status != "ok":
                text[i][j] = "error"
            else:
                ts = o.metrics.get("settling_time_s", float("nan"))
                if s.plant == "se3":  # the pose settles when the position does
                    ts = o.metrics.get("position_settling_time_s", float("nan"))
                if s.plant == "magnetorquer":  # a detumble "settles" when the rate does
                    ts = o.metrics.get("time_to_detumble_s", float("nan"))
                if s.plant == "sun-safe":  # safe mode "settles" when it acquires the Sun
                    ts = o.metrics.get("time_to_acquire_s", float("nan"))
                short = {"attitude-not-converged": "no conv.", "position-not-converged": "pos.",
                         "diverged": "diverged", "rate-not-damped": "not damped",
                         "sun-not-acquired": "no Sun",
                         "sun-not-reacquired": "no re-acq."}  # fmt: skip
                if v == "failed":
                    text[i][j] = short.get(o.flags[0], o.flags[0]) if o.flags else "failed"
                elif isinstance(ts, float) and math.isfinite(ts):
                    text[i][j] = f"{ts:.0f}"
                else:
                    text[i][j] = v
                if v == "degraded":
                    text[i][j] += "*"
    cmap = mcolors.ListedColormap([VERDICT_COLORS[v] for v in order])
    fig, ax = plt.subplots(
        figsize=(max(6.5, 3.0 + 0.8 * S), 1.6 + 0.38 * C), constrained_layout=True
    )
    ax.imshow(val, cmap=cmap, vmin=-0.5, vmax=len(order) - 0.5, aspect="auto")
    for i in range(C):
        for j in range(S):
            ax.text(j, i, text[i][j], ha="center", va="center", fontsize=7)
    ax.set_xticks(range(S), [s.name for s in result.scenarios], rotation=40, ha="right", fontsize=8)
    ax.set_yticks(range(C), [result.display_name(c) for c in result.controllers], fontsize=8)
    ax.set_title(
        _wrap_title(
            "single-run verdict of each nominal run (the cell verdicts over the members are in "
            "report.md); number: settling time [s] (SE(3): position; detumble: time to "
            "detumble; Sun acquisition: time to acquire); *: degraded (flags "
            "in report.md); —: does not apply\n"
            "failed cells name the first flag: 'no conv.' attitude not converged, 'pos.' "
            "position not converged; 'error': the run raised",
            0.95 * fig.get_figwidth(),
            8,
        ),
        fontsize=8,
    )
    ax.legend(
        handles=[Patch(color=VERDICT_COLORS[v], label=v) for v in order],
        loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7,
    )  # fmt: skip
    return save_png(fig, path)


# --------------------------------------------------------------------------- bandwidth sweep


def write_sweep_report(
    results: Mapping[float, SuiteResult], out_dir: Path, *, figures: bool = True
) -> Path:
    """Bandwidth sweep (``--sweep-bandwidth``): ``results`` maps each closed-loop natural
    frequency ω_n [rad/s] to the suite run tuned to it. Writes ``sweep.md`` (per scenario a
    controllers × ω_n table of verdict, performance and effort) and per scenario
    ``figures/<scenario>-sweep.png``: performance vs control effort with one line per
    controller through its ω_n points (verdict by fill, as in the Pareto figure), so
    controllers are compared at equal aggressiveness. Returns the path of ``sweep.md``."""
    if not isinstance(results, Mapping):
        raise TypeError(
            f"results: expected a mapping ω_n -> SuiteResult, got {type(results).__name__}"
        )
    if not results:
        raise ValueError("results: empty sweep")
    for w, r in results.items():
        _check_result(r, f"results[{w!r}]")
    plt = _plt()
    out_dir = _check_out_dir(out_dir)
    fig_dir = out_dir / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    ws = sorted(results)
    first = results[ws[0]]
    styles = controller_styles(first.controllers)
    lines = [
        "# Bandwidth sweep",
        "",
        "Every controller re-tuned to each closed-loop natural frequency ω_n (same damping); "
        "one full report per ω_n in `omega_n-<value>/`. Cells: verdict, performance (settling "
        "time [s], or steady RMS error [deg] for regulation scenarios), effort ∫‖u‖dt [N·m·s].",
        "",
        VERDICT_RULES,
    ]
    figs: dict[str, Path] = {}
    for s in first.scenarios:
        lines += ["", f"## {s.name}", ""]
        header = ["controller"] + [f"ω_n = {w:g} rad/s" for w in ws]
        rows = []
        fig, ax = plt.subplots(figsize=(9, 5), constrained_layout=True)
        plotted = False
        perf_label, eff_label = "", ""
        for c in first.controllers:
            row = [f"`{c}`"]
            xs, ys = [], []
            for w in ws:
                o = results[w].outcome(s.name, c)
                if o.status == "n/a":
                    row.append(NOT_APPLICABLE)
                    continue
                if o.status != "ok":
                    row.append(f"{o.verdict}")
                    continue
                perf, perf_label = performance(s, o.metrics)
                if o.verdict == "failed" and _is_settling(s):
                    perf = float("nan")  # a failed run has no settling time (as in the Pareto)
                eff, eff_label = _effort(s, o.metrics)
                shown = "not settled" if math.isnan(perf) and _is_settling(s) else _fmt(perf)
                row.append(f"{o.verdict}; {shown}; {_fmt(eff)}")
                if math.isfinite(perf) and math.isfinite(eff):
                    xs.append(eff)
                    ys.append(perf)
                    st = styles[c]
                    ax.plot(
                        [eff], [perf], ls="none", marker=st["marker"], markersize=8,
                        markeredgecolor=st["color"],
                        markerfacecolor=st["color"] if o.verdict == "success" else "none",
                    )  # fmt: skip
                    ax.annotate(f"{w:g}", (eff, perf), fontsize=6, xytext=(3, 3),
                                textcoords="offset points")  # fmt: skip
            rows.append(row)
            if xs:
                st = styles[c]
                ax.plot(xs, ys, color=st["color"], ls=st["ls"], marker=st["marker"],
                        markersize=0.1, lw=1.1, label=c)  # fmt: skip
                plotted = True
        lines += markdown_table(header, rows)
        if plotted and figures:
            xs_all = [x for line in ax.get_lines() for x in np.atleast_1d(line.get_xdata())]
            ax.set_xlabel(eff_label + _scale_axis(ax, [float(x) for x in xs_all], "x"))
            ax.set_ylabel(perf_label)
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=7, loc="best")
            ax.set_title(
                _wrap_title(
                    f"{s.name}: each controller over ω_n (labels: ω_n [rad/s]; filled: "
                    "success, hollow: degraded; failed runs left out)",
                    0.9 * fig.get_figwidth(),
                    9,
                ),
                fontsize=9,
            )
            figs[f"{s.name} (sweep)"] = save_png(fig, fig_dir / f"{s.name}-sweep.png")
        else:
            plt.close(fig)
    lines += figures_section(figs, out_dir)
    path = out_dir / "sweep.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
