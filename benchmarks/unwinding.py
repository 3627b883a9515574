"""Unwinding and large-angle test cases, runnable against any registered
controller.

No continuous feedback on SO(3) is globally asymptotically stable (Bhat & Bernstein 2000):
chart-based laws pay for continuity with *unwinding* (a quaternion law that treats q and −q as
different points drives a body starting at −q the long way round, through up to 2π − θ₀) or
give up continuity and *chatter* at the switching surface; geometric laws keep a measure-zero
set of bad starts and slow down near θ = π where their restoring torque vanishes (the trace and
log errors) or not (Lee's large-angle error). The cases:

- **q / −q pair**: the same physical start at ``pair_angle_deg`` about ``axis``, handed to the
  controllers as ``q`` and as ``−q`` (:attr:`benchmarks.scenarios.Scenario.quaternion_sign`;
  geometric laws cannot tell them apart, continuous quaternion laws can);
- **angle sweep**: rest-to-rest starts at ``sweep_angles_deg`` (150°, 170°, 179°, 179.9° and
  smaller ones for the settling-time curve) about the same axis;
- **Haar-random starts**: ``n_random`` attitudes uniform on SO(3) (``scipy`` ``Rotation.random``
  with ``numpy.random.default_rng(seed)``), at rest.

Verdict per (case, controller), in this order:

- ``"error"``: the run raised (error text kept; the same word as the suite's verdict);
- ``"chatters"``: at least ``chatter_reversals`` command reversals (:mod:`benchmarks.metrics`,
  ``command_reversals``: consecutive commands pointing in opposite directions while both are
  ≥ 5 % of the peak) — checked first, because a chattering body's rate jitter also inflates
  the path length;
- ``"diverges"``: the run ends at least 30° farther from the target than it started
  (:data:`benchmarks.metrics.DIVERGENCE_MARGIN_DEG`) — a long path then means moving away, not
  going the long way round;
- ``"unwinds"``: unwinding ratio ``∫‖e_Ω‖dt / θ₀ ≥ 1.5`` (travelled ≥ 1.5× the
  geodesic angle);
- ``"converges"``: final error ≤ ``converged_deg``;
- ``"not converged"`` otherwise (too slow for the horizon, or stuck).

Figures: settling time vs initial angle (where the trace/log errors slow down near 180° and the
large-angle error does not), the unwinding ratio of the q/−q pair, and ratio vs initial angle of
the random starts.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol._validation import as_array, as_int, check_positive_scalar

from .controllers import available_controllers, get_controller
from .executors import Executor
from .runner import RunOutcome, SuiteResult, run_suite
from .scenarios import SGCMG_SPACECRAFT, SLEW_AXIS, Scenario, SpacecraftSpec

__all__ = [
    "UnwindingConfig",
    "UnwindingRecord",
    "UnwindingResult",
    "VERDICTS",
    "unwinding_scenarios",
    "verdict",
    "run_unwinding",
    "write_unwinding_report",
]

VERDICTS = ("converges", "chatters", "unwinds", "diverges", "not converged", "error")


@dataclass(frozen=True)
class UnwindingConfig:
    """Cases and thresholds of the unwinding benchmark (module docstring).

    Attributes:
        pair_angle_deg: initial angle of the q/−q pair [deg] (90°: the long way is 270°, ratio 3).
        axis: body axis of the pair and the sweep (default (1, 1, 1)/√3).
        sweep_angles_deg: initial angles of the settling-time sweep [deg].
        n_random: number of Haar-random starts; seed: their generator's seed.
        duration, dt, control_period: simulation horizon and steps [s].
        spacecraft: the plant (default: the SGCMG bus).
        unwinding_threshold: the path-length ratio drawn as a reference line on the ratio
            figures (default 1.5); the verdict ``unwinds`` is the metric ``unwound`` (the error
            path crossed θ = π), not a ratio.
        chatter_reversals: command reversals from which a run chatters.
        converged_deg: final error below which a run has converged [deg].
    """

    pair_angle_deg: float = 90.0
    axis: tuple[float, float, float] = SLEW_AXIS
    sweep_angles_deg: tuple[float, ...] = (30.0, 90.0, 150.0, 170.0, 179.0, 179.9)
    n_random: int = 6
    seed: int = 0
    duration: float = 900.0
    dt: float = 0.1
    control_period: float = 0.2
    spacecraft: SpacecraftSpec = field(default_factory=lambda: SGCMG_SPACECRAFT)
    unwinding_threshold: float = 1.5
    chatter_reversals: int = 10
    converged_deg: float = 0.1

    def __post_init__(self) -> None:
        for name in (
            "pair_angle_deg",
            "duration",
            "dt",
            "control_period",
            "converged_deg",
            "unwinding_threshold",
        ):
            object.__setattr__(self, name, check_positive_scalar(getattr(self, name), name))
        if not 0.0 < self.pair_angle_deg < 180.0:
            raise ValueError(f"pair_angle_deg: must be in (0, 180), got {self.pair_angle_deg}")
        axis = as_array(self.axis, "axis")
        if axis.shape != (3,):
            raise ValueError(f"axis: expected a 3-vector, got shape {axis.shape}")
        if not float(np.abs(axis).max()) > 0.0:
            raise ValueError("axis: must be a non-zero vector (it is normalised)")
        with np.errstate(over="ignore"):
            if not np.isfinite(np.linalg.norm(axis)):
                axis = axis / float(np.abs(axis).max())  # a huge axis: scale before normalising
        object.__setattr__(self, "axis", tuple(float(v) for v in axis))
        angles = as_array(self.sweep_angles_deg, "sweep_angles_deg")
        if angles.ndim != 1:
            raise ValueError(f"sweep_angles_deg: expected a sequence of angles, got {angles.shape}")
        if np.any((angles <= 0.0) | (angles >= 180.0)):
            raise ValueError(
                f"sweep_angles_deg: every angle must be in (0, 180), got {angles.tolist()}"
            )
        object.__setattr__(self, "sweep_angles_deg", tuple(angles.tolist()))
        for name in ("n_random", "chatter_reversals", "seed"):
            object.__setattr__(self, name, as_int(getattr(self, name), name, 0))
        if not isinstance(self.spacecraft, SpacecraftSpec):
            raise ValueError(
                f"spacecraft: expected a SpacecraftSpec, got {type(self.spacecraft).__name__}"
            )


def unwinding_scenarios(cfg: UnwindingConfig = UnwindingConfig()) -> tuple[Scenario, ...]:
    """The cases of ``cfg`` as scenarios, tagged ``pair``, ``sweep`` or ``random``."""
    if not isinstance(cfg, UnwindingConfig):
        raise ValueError(f"cfg: expected an UnwindingConfig, got {type(cfg).__name__}")
    a = np.asarray(cfg.axis, dtype=np.float64)
    norm = np.linalg.norm(a)
    if a.shape != (3,) or not norm > 0:
        raise ValueError(f"axis: expected a non-zero 3-vector, got {cfg.axis!r}")
    a = a / norm
    common = dict(
        spacecraft=cfg.spacecraft,
        duration=cfg.duration,
        dt=cfg.dt,
        control_period=cfg.control_period,
    )
    rv = tuple(math.radians(cfg.pair_angle_deg) * a)
    out = [
        Scenario(
            name=f"q-{cfg.pair_angle_deg:g}",
            description=f"{cfg.pair_angle_deg:g}° start given as q (w ≥ 0)",
            initial_rotvec=rv,
            tags=("pair",),
            **common,
        ),
        Scenario(
            name=f"minus-q-{cfg.pair_angle_deg:g}",
            description=f"the same {cfg.pair_angle_deg:g}° start given as −q (w < 0)",
            initial_rotvec=rv,
            quaternion_sign=-1,
            tags=("pair",),
            **common,
        ),
    ]
    for ang in cfg.sweep_angles_deg:
        out.append(
            Scenario(
                name=f"angle-{ang:g}",
                description=f"rest-to-rest {ang:g}° about the sweep axis",
                initial_rotvec=tuple(math.radians(ang) * a),
                tags=("sweep",),
                **common,
            )
        )
    if cfg.n_random:
        rng = np.random.default_rng(cfg.seed)
        rots = Rotation.random(cfg.n_random, random_state=rng).as_rotvec()
        for i, r in enumerate(rots):
            out.append(
                Scenario(
                    name=f"random-{i}",
                    description=f"Haar-random start {i} (seed {cfg.seed})",
                    initial_rotvec=tuple(r),
                    tags=("random",),
                    **common,
                )
            )
    return tuple(out)


def verdict(outcome: RunOutcome, cfg: UnwindingConfig = UnwindingConfig()) -> str:
    """The verdict of one run (module docstring; one of :data:`VERDICTS`)."""
    if outcome.status != "ok":
        return "error"
    m = outcome.metrics
    rev = m.get("command_reversals", float("nan"))
    if not math.isnan(rev) and rev >= cfg.chatter_reversals:
        return "chatters"
    from .metrics import DIVERGENCE_MARGIN_DEG

    th0, thf = m.get("initial_error_deg", float("nan")), m.get("final_error_deg", float("nan"))
    if thf >= th0 + DIVERGENCE_MARGIN_DEG:
        return "diverges"
    # one flag, one meaning: the run crossed θ = π (benchmarks.metrics, ``unwound``); the path
    # ratio also grows with overshoot and detours, so it is drawn, not judged
    if m.get("unwound"):
        return "unwinds"
    if m.get("final_error_deg", float("inf")) <= cfg.converged_deg:
        return "converges"
    return "not converged"


@dataclass(frozen=True)
class UnwindingRecord:
    """One (case, controller) result."""

    case: str
    kind: str
    controller: str
    initial_angle_deg: float
    quaternion_sign: int
    verdict: str
    unwinding_ratio: float
    settling_time_s: float
    final_error_deg: float
    command_reversals: float
    error: str | None


@dataclass(frozen=True)
class UnwindingResult:
    """Records of every (case, controller) plus the underlying :class:`SuiteResult`."""

    config: UnwindingConfig
    records: tuple[UnwindingRecord, ...]
    suite: SuiteResult
    wall_time_s: float

    @property
    def controllers(self) -> tuple[str, ...]:
        return self.suite.controllers

    @property
    def n_failed(self) -> int:
        return sum(r.verdict == "error" for r in self.records)

    def record(self, case: str, controller: str) -> UnwindingRecord:
        for r in self.records:
            if r.case == case and r.controller == controller:
                return r
        raise KeyError((case, controller))

    def pair_verdicts(self, controller: str) -> tuple[str, str]:
        """Verdicts of the q and −q starts for ``controller``."""
        q, mq = (r for r in self.records if r.kind == "pair" and r.controller == controller)
        return (q.verdict, mq.verdict) if q.quaternion_sign > 0 else (mq.verdict, q.verdict)

    def unwinds(self, controller: str) -> bool:
        """Whether ``controller`` unwinds on any case."""
        return any(r.verdict == "unwinds" for r in self.records if r.controller == controller)


def run_unwinding(
    controllers: Sequence[str] | None = None,
    cfg: UnwindingConfig = UnwindingConfig(),
    *,
    executor: Executor | str | None = None,
    jobs: int | None = None,
    progress: bool = True,
) -> UnwindingResult:
    """Run the unwinding cases of ``cfg`` with ``controllers`` (default: every registered
    attitude controller; register your own with :func:`benchmarks.controllers.register`)."""
    if controllers is None:
        controllers = tuple(
            c
            for c in available_controllers()
            if cfg.spacecraft.actuator in get_controller(c).plants
        )
    controllers = tuple(controllers)
    for c in controllers:
        info = get_controller(c)
        if cfg.spacecraft.actuator not in info.plants:
            raise ValueError(f"controllers: {c!r} is not an attitude controller for this plant")
    t0 = time.perf_counter()
    scenarios = unwinding_scenarios(cfg)
    suite = run_suite(
        scenarios, controllers, suite="unwinding", executor=executor, jobs=jobs, progress=progress
    )
    by_name = {s.name: s for s in scenarios}
    records = []
    for o in suite.outcomes:
        s = by_name[o.scenario]
        m = o.metrics
        records.append(
            UnwindingRecord(
                case=s.name,
                kind=s.tags[0],
                controller=o.controller,
                initial_angle_deg=s.initial_error_deg,
                quaternion_sign=s.quaternion_sign,
                verdict=verdict(o, cfg),
                unwinding_ratio=float(m.get("unwinding_ratio", float("nan"))),
                settling_time_s=float(m.get("settling_time_s", float("nan"))),
                final_error_deg=float(m.get("final_error_deg", float("nan"))),
                command_reversals=float(m.get("command_reversals", float("nan"))),
                error=o.error,
            )
        )
    return UnwindingResult(cfg, tuple(records), suite, time.perf_counter() - t0)


# --------------------------------------------------------------------------- report


def _f(x: float, spec: str = ".3g") -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def write_unwinding_report(
    result: UnwindingResult, out_dir: str | Path, *, figures: bool = True
) -> Path:
    """``unwinding.md`` (verdict tables), ``unwinding.csv``/``.json`` and figures; returns the
    Markdown path."""
    import csv

    from .report import figures_section, markdown_table

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cfg = result.config
    recs = result.records
    fields = list(UnwindingRecord.__dataclass_fields__)
    with open(out / "unwinding.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(fields)
        for r in recs:
            w.writerow([getattr(r, k) if getattr(r, k) is not None else "" for k in fields])
    doc = {
        "config": {k: v for k, v in asdict(cfg).items() if k != "spacecraft"},
        "wall_time_s": result.wall_time_s,
        "records": [
            {
                k: (None if isinstance(v, float) and math.isnan(v) else v)
                for k, v in asdict(r).items()
            }
            for r in recs
        ],
    }
    (out / "unwinding.json").write_text(
        json.dumps(doc, indent=2, allow_nan=False), encoding="utf-8"
    )
    figs = _figures(result, out / "figures") if figures else {}

    cases = list(dict.fromkeys(r.case for r in recs))
    lines = [
        "# Unwinding and large-angle benchmark",
        "",
        f"{len(cases)} cases × {len(result.controllers)} controllers, {cfg.duration:g} s at "
        f"dt {cfg.dt:g} s (control {cfg.control_period:g} s), wall time "
        f"{result.wall_time_s:.1f} s. "
        "Unwinds: the error path crossed θ = π (the long way round); chatters: ≥ "
        f"{cfg.chatter_reversals} command reversals; converges: final error ≤ "
        f"{cfg.converged_deg:g}°.",
        "",
        "## Verdicts on the q / −q pair",
        "",
    ]
    rows = []
    for c in result.controllers:
        vq, vmq = result.pair_verdicts(c)
        rq = next(
            r for r in recs if r.kind == "pair" and r.controller == c and r.quaternion_sign > 0
        )
        rm = next(
            r for r in recs if r.kind == "pair" and r.controller == c and r.quaternion_sign < 0
        )
        rows.append(
            [f"`{c}`", vq, _f(rq.unwinding_ratio), vmq, _f(rm.unwinding_ratio),
             "yes" if result.unwinds(c) else "no"]
        )  # fmt: skip
    lines += markdown_table(
        ["controller", "q", "ratio (q)", "−q", "ratio (−q)", "unwinds anywhere"], rows
    )
    lines += ["", "## Verdict per case", ""]
    rows = []
    for c in result.controllers:
        row = [f"`{c}`"]
        for case in cases:
            r = result.record(case, c)
            cell = r.verdict
            if r.verdict == "converges" and not math.isnan(r.settling_time_s):
                cell += f" ({r.settling_time_s:.0f} s)"
            elif r.verdict == "unwinds":
                cell += f" (×{r.unwinding_ratio:.2f})"
            elif r.verdict == "chatters":
                cell += f" ({r.command_reversals:.0f} reversals)"
            row.append(cell)
        rows.append(row)
    lines += markdown_table(["controller"] + cases, rows)
    lines += ["", "## Unwinding ratio per case", ""]
    lines += markdown_table(
        ["controller"] + cases,
        [[f"`{c}`"] + [_f(result.record(k, c).unwinding_ratio) for k in cases]
         for c in result.controllers],
    )  # fmt: skip
    failed = [r for r in recs if r.verdict == "error"]
    if failed:
        lines += ["", "## Errors (runs that raised)", ""]
        lines += [f"- `{r.controller}` on `{r.case}`: {r.error}" for r in failed]
    lines += figures_section(figs, out)
    path = out / "unwinding.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _figures(result: UnwindingResult, fig_dir: Path) -> dict[str, Path]:
    from .report import _plt, controller_colors, save_png

    plt = _plt()
    fig_dir.mkdir(parents=True, exist_ok=True)
    colors = controller_colors(result.controllers)
    out: dict[str, Path] = {}
    recs = result.records

    sweep = [r for r in recs if r.kind == "sweep"]
    if sweep:
        fig, ax = plt.subplots(figsize=(10, 5), constrained_layout=True)
        horizon = result.config.duration
        for c in result.controllers:
            rs = sorted((r for r in sweep if r.controller == c), key=lambda r: r.initial_angle_deg)
            x = [r.initial_angle_deg for r in rs]
            y = [horizon * 1.05 if math.isnan(r.settling_time_s) else r.settling_time_s for r in rs]
            ax.plot(x, y, "o-", label=c, color=colors[c], lw=1.2, ms=4)
        ax.axhline(horizon, color="k", ls=":", lw=0.8)
        ax.text(
            ax.get_xlim()[0], horizon * 1.01, " horizon (points above: not settled)", fontsize=7
        )
        ax.set_xlabel("initial error angle θ₀ [deg]")
        ax.set_ylabel("settling time to 0.1° [s]")
        ax.set_title("settling time vs initial angle")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        out["settling time vs initial angle"] = save_png(fig, fig_dir / "settling_vs_angle.png")

    pair = [r for r in recs if r.kind == "pair"]
    if pair:
        fig, ax = plt.subplots(figsize=(9, 4.5), constrained_layout=True)
        C = len(result.controllers)
        x = np.arange(C)
        for k, (sign, lab) in enumerate(((1, "q"), (-1, "−q"))):
            vals = []
            for c in result.controllers:
                r = next(r for r in pair if r.controller == c and r.quaternion_sign == sign)
                vals.append(0.0 if math.isnan(r.unwinding_ratio) else r.unwinding_ratio)
            ax.bar(x + (k - 0.5) * 0.38, vals, width=0.38, label=lab)
        ax.axhline(result.config.unwinding_threshold, color="r", ls="--", lw=0.9,
                   label=f"ratio {result.config.unwinding_threshold:g} (reference)")
        ax.set_xticks(x, list(result.controllers), rotation=35, ha="right", fontsize=8)
        ax.set_ylabel("unwinding ratio (path / geodesic angle)")
        ax.set_title(f"q vs −q start at {result.config.pair_angle_deg:g}°")
        ax.legend(fontsize=8)
        ax.grid(True, axis="y", alpha=0.3)
        out["unwinding ratio, q vs −q"] = save_png(fig, fig_dir / "pair_unwinding_ratio.png")

    rnd = [r for r in recs if r.kind == "random"]
    if rnd:
        fig, ax = plt.subplots(figsize=(10, 4.5), constrained_layout=True)
        for c in result.controllers:
            rs = [r for r in rnd if r.controller == c and not math.isnan(r.unwinding_ratio)]
            ax.scatter(
                [r.initial_angle_deg for r in rs],
                [r.unwinding_ratio for r in rs],
                label=c,
                color=colors[c],
                s=14,
            )
        ax.axhline(result.config.unwinding_threshold, color="r", ls="--", lw=0.9)
        ax.set_xlabel("initial error angle θ₀ [deg]")
        ax.set_ylabel("unwinding ratio")
        ax.set_title("Haar-random starts")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        out["Haar-random starts"] = save_png(fig, fig_dir / "random_starts.png")
    return out
