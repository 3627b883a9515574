"""How much the full CMG model changes the quick suite's verdicts.

Run ``python -m benchmarks.cmg_model_study --out DIR`` (a few minutes of CPU; ``--duration-scale``
shortens every scenario). The quick suite's SGCMG attitude scenarios are flown by every quick
attitude controller on two spacecraft:

- ``sgcmg-bus`` — the bus of Wu, Huang, Wei & Guo (four h₀ = 300 N·m·s SGCMGs), at the suite's
  step dt = 0.1 s;
- ``mini-cmg-3u`` — a 3U CubeSat with the mini-CMG pyramid
  :data:`spacecraft.cmg_dynamics.MINI_CMG` (:data:`benchmarks.scenarios.MINI_CMG_SPACECRAFT`), at
  dt = 0.05 s because its gimbal loop (servo bandwidth 30 rad/s) is faster,

each with three cluster models: ``momentum`` (:class:`spacecraft.actuators.SgcmgActuator`, the
suite's default: gimbal rates realised over each step, no gimbal or rotor inertia), ``full``
(:class:`spacecraft.cmg_dynamics.VscmgActuator`: gimbal-frame and rotor inertia, the
gimbal-acceleration reaction, a torque-limited PI gimbal-rate servo that must fight the base-rate
torque I_Ws Ω ω_t) and ``full-ff`` (the same servo with the base-rate torque fed forward). Both
models of one spacecraft use the same step, so a verdict change is the model's doing.

Why the full model changes the delivered torque: the base-rate torque couples the gimbal to the
bus. A gimbal turning at δ̇ puts h₀δ̇ on the bus; the bus rate it creates loads the gimbal motor
with h₀ω_t, i.e. a spring of stiffness ≈ h₀²/J_B on the gimbal angle. Against a ramp of that
spring a PI rate loop (K_i = ω_b² J_g) keeps a steady rate error ≈ (h₀²/J_B)/(ω_b² J_g) of the
commanded rate — about 0.4 on the mini-CMG CubeSat and 0.1–0.3 on the large bus — so the
cluster delivers less torque than commanded; the feed-forward removes most of it.

Writes ``DIR/cmg_model_verdicts.md`` (the verdict-change table, counts, peak gimbal torque and
power) and ``DIR/cmg_model_verdicts.csv`` (every run). Peaks are over the logged samples (the
command samples, at most every 0.5 s), not every integration step.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liecontrol._validation import check_positive_scalar

from .controllers import get_controller, quick_controllers
from .runner import run_suite
from .scenarios import (
    DISTURBANCES,
    MINI_CMG_SPACECRAFT,
    QUICK_SUITE,
    SGCMG_SPACECRAFT,
    DisturbanceSpec,
    Scenario,
    SpacecraftSpec,
)

__all__ = [
    "MODELS",
    "STUDY_SPACECRAFT",
    "StudyRow",
    "study_scenarios",
    "run_study",
    "verdict_table",
    "main",
]

#: Cluster models compared: name → the :class:`SpacecraftSpec` fields it sets.
MODELS: dict[str, dict[str, object]] = {
    "momentum": {"cmg_model": "momentum"},
    "full": {"cmg_model": "full", "gimbal_gyro_feedforward": False},
    "full-ff": {"cmg_model": "full", "gimbal_gyro_feedforward": True},
}
#: Spacecraft flown: name → (spec, integration step [s]).
STUDY_SPACECRAFT: dict[str, tuple[SpacecraftSpec, float]] = {
    "sgcmg-bus": (dataclasses.replace(SGCMG_SPACECRAFT, name="sgcmg-bus"), 0.1),
    "mini-cmg-3u": (MINI_CMG_SPACECRAFT, 0.05),
}


@dataclass(frozen=True)
class StudyRow:
    """One (spacecraft, scenario, controller) with its verdict and gimbal-motor peaks per model
    (``nan`` peaks for the momentum model, which has no gimbal motor)."""

    spacecraft: str
    scenario: str
    controller: str
    verdicts: dict[str, str]
    final_error_deg: dict[str, float]
    peak_gimbal_torque_Nm: dict[str, float]
    peak_gimbal_power_W: dict[str, float]
    torque_saturation_time_s: dict[str, float]
    flags: dict[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)

    @property
    def changed(self) -> bool:
        """Any model's verdict differs from the momentum model's."""
        if "momentum" not in self.verdicts:
            return False
        ref = self.verdicts["momentum"]
        return any(v != ref for v in self.verdicts.values())


def study_scenarios(
    spacecraft: SpacecraftSpec, model: str, dt: float, duration_scale: float = 1.0
) -> list[Scenario]:
    """The quick suite's SGCMG attitude scenarios on ``spacecraft`` with the cluster ``model``
    (a key of :data:`MODELS`), integration step ``dt`` [s] and durations × ``duration_scale``.
    Disturbances with a ``scale`` parameter (the constant-harmonic torque of Wu et al.) are
    scaled by ``spacecraft.h0 / scenario h0`` (a 0.085 N·m disturbance would swamp mini-CMGs)."""
    if not isinstance(spacecraft, SpacecraftSpec):
        raise TypeError(f"spacecraft: expected a SpacecraftSpec, got {type(spacecraft).__name__}")
    if spacecraft.actuator != "sgcmg":
        raise ValueError(f"spacecraft: needs actuator 'sgcmg', got {spacecraft.actuator!r}")
    if model not in MODELS:
        raise ValueError(f"model: unknown model {model!r}; valid: {', '.join(MODELS)}")
    dt = check_positive_scalar(dt, "dt")
    duration_scale = check_positive_scalar(duration_scale, "duration_scale")
    sp = dataclasses.replace(spacecraft, **MODELS[model])  # type: ignore[arg-type]
    out = []
    for s in QUICK_SUITE:
        if s.plant != "sgcmg" or s.proximity is not None:
            continue
        # keep the scenario's own gimbal-rate limit (e.g. the slow-gimbal scenario's)
        sc_sp = dataclasses.replace(sp, gimbal_rate_limit=min(
            sp.gimbal_rate_limit, s.spacecraft.gimbal_rate_limit
        ))
        # a disturbance sized for the scenario's CMGs is scaled with the rotor momentum h₀, so it
        # loads the study spacecraft's cluster as much (same disturbance/capacity ratio)
        ratio = sp.h0 / s.spacecraft.h0
        dist = tuple(
            DisturbanceSpec(d.name, {**d.kwargs, "scale": d.kwargs.get("scale", 1.0) * ratio})
            if ratio != 1.0 and "scale" in DISTURBANCES.get(d.name, ())
            else d
            for d in s.disturbances
        )
        period = s.control_period or s.dt
        if not math.isclose(period / dt, round(period / dt), rel_tol=0.0, abs_tol=1e-9):
            raise ValueError(f"dt: must divide the control period {period} s, got {dt}")
        duration = round(s.duration * duration_scale / period) * period
        out.append(
            dataclasses.replace(
                s,
                spacecraft=sc_sp,
                disturbances=dist,
                dt=dt,
                control_period=period,
                duration=max(duration, period),
            )
        )
    return out


def _peak(h: dict[str, np.ndarray], key: str) -> float:
    a = h.get(f"actuator.{key}")
    return float(np.max(np.abs(a))) if a is not None and a.size else float("nan")


def run_study(
    spacecraft: Sequence[str] = tuple(STUDY_SPACECRAFT),
    models: Sequence[str] = tuple(MODELS),
    controllers: Sequence[str] | None = None,
    duration_scale: float = 1.0,
    jobs: int = 1,
) -> list[StudyRow]:
    """Fly every study scenario with every controller on each of ``spacecraft`` (keys of
    :data:`STUDY_SPACECRAFT`) under each of ``models``; one :class:`StudyRow` per pair.
    ``controllers``: default the quick suite's attitude controllers that apply to SGCMG plants."""
    for name in spacecraft:
        if name not in STUDY_SPACECRAFT:
            raise ValueError(
                f"spacecraft: unknown {name!r}; valid: {', '.join(STUDY_SPACECRAFT)}"
            )
    for m in models:
        if m not in MODELS:
            raise ValueError(f"models: unknown model {m!r}; valid: {', '.join(MODELS)}")
    if controllers is None:
        controllers = [c for c in quick_controllers() if "sgcmg" in get_controller(c).plants]
    rows: dict[tuple[str, str, str], dict[str, dict]] = {}
    for sc_name in spacecraft:
        spec, dt = STUDY_SPACECRAFT[sc_name]
        for m in models:
            res = run_suite(
                study_scenarios(spec, m, dt, duration_scale),
                list(controllers),
                suite=f"cmg-{sc_name}-{m}",
                jobs=jobs,
                progress=False,
                keep_histories=True,
            )
            for o in res.outcomes:
                r = rows.setdefault((sc_name, o.scenario, o.controller), {})
                h = o.histories
                r[m] = {
                    "verdict": o.verdict,
                    "flags": o.flags,
                    "final": float(o.metrics.get("final_error_deg", float("nan"))),
                    "tau": _peak(h, "gimbal_torque"),
                    "pow": _peak(h, "gimbal_power"),
                    "sat": float(o.metrics.get("torque_saturation_time_s", float("nan"))),
                }
    out = []
    for (sc_name, scen, ctrl), per in rows.items():
        out.append(
            StudyRow(
                sc_name,
                scen,
                ctrl,
                {m: per[m]["verdict"] for m in per},
                {m: per[m]["final"] for m in per},
                {m: per[m]["tau"] for m in per},
                {m: per[m]["pow"] for m in per},
                {m: per[m]["sat"] for m in per},
                {m: per[m]["flags"] for m in per},
            )
        )
    return out


def _fmt(x: float) -> str:
    return "–" if not np.isfinite(x) else f"{x:.3g}"


def verdict_table(rows: Sequence[StudyRow], only_changed: bool = True) -> str:
    """Markdown table: spacecraft, scenario, controller, the verdict per model (``a → b`` marked
    where it differs from the momentum model's), peak gimbal torque and power of the full model."""
    models = [m for m in MODELS if any(m in r.verdicts for r in rows)]
    head = ["spacecraft", "scenario", "controller", *models, "peak u_g full [N·m]",
            "peak P_g full [W]", "u_g sat. full [s]"]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        if only_changed and not r.changed:
            continue
        ref = r.verdicts.get("momentum", "")
        cells = [
            (f"**{r.verdicts[m]}**" if r.verdicts[m] != ref else r.verdicts[m])
            if m in r.verdicts
            else ""
            for m in models
        ]
        lines.append(
            "| "
            + " | ".join(
                [r.spacecraft, r.scenario, r.controller, *cells,
                 _fmt(r.peak_gimbal_torque_Nm.get("full", float("nan"))),
                 _fmt(r.peak_gimbal_power_W.get("full", float("nan"))),
                 _fmt(r.torque_saturation_time_s.get("full", float("nan")))]  # fmt: skip
            )
            + " |"
        )
    return "\n".join(lines)


def _summary(rows: Sequence[StudyRow]) -> str:
    lines = ["| spacecraft | model | runs | success | degraded | failed | other | changed |",
             "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for sc_name in dict.fromkeys(r.spacecraft for r in rows):
        sub = [r for r in rows if r.spacecraft == sc_name]
        for m in MODELS:
            v = [r.verdicts[m] for r in sub if m in r.verdicts]
            if not v:
                continue
            n = {k: sum(x == k for x in v) for k in ("success", "degraded", "failed")}
            other = len(v) - sum(n.values())
            ch = sum(r.verdicts[m] != r.verdicts.get("momentum") for r in sub if m in r.verdicts)
            lines.append(
                f"| {sc_name} | {m} | {len(v)} | {n['success']} | {n['degraded']} | "
                f"{n['failed']} | {other} | {ch} |"
            )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.cmg_model_study", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, type=Path, help="output directory")
    p.add_argument("--duration-scale", type=float, default=1.0,
                   help="multiply every scenario's duration (default 1)")
    p.add_argument("--spacecraft", nargs="+", default=list(STUDY_SPACECRAFT),
                   choices=list(STUDY_SPACECRAFT))
    p.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    p.add_argument("--controllers", nargs="+", default=None)
    p.add_argument("--jobs", type=int, default=1)
    a = p.parse_args(argv)
    t0 = time.perf_counter()
    rows = run_study(a.spacecraft, a.models, a.controllers, a.duration_scale, a.jobs)
    wall = time.perf_counter() - t0
    a.out.mkdir(parents=True, exist_ok=True)
    cmd = "python -m benchmarks.cmg_model_study " + " ".join(argv or [])
    md = (
        f"# Full vs momentum CMG model: quick-suite verdicts\n\n`{cmd.strip()}` "
        f"({wall:.0f} s)\n\n{_summary(rows)}\n\nVerdict changes (bold: differs from the "
        f"momentum model):\n\n{verdict_table(rows)}\n\nAll runs:\n\n"
        f"{verdict_table(rows, only_changed=False)}\n"
    )
    (a.out / "cmg_model_verdicts.md").write_text(md, encoding="utf-8")
    with open(a.out / "cmg_model_verdicts.csv", "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["spacecraft", "scenario", "controller", "model", "verdict", "final_error_deg",
                    "peak_gimbal_torque_Nm", "peak_gimbal_power_W", "torque_saturation_time_s",
                    "flags"])
        for r in rows:
            for m in r.verdicts:
                w.writerow([r.spacecraft, r.scenario, r.controller, m, r.verdicts[m],
                            r.final_error_deg[m], r.peak_gimbal_torque_Nm[m],
                            r.peak_gimbal_power_W[m], r.torque_saturation_time_s[m],
                            " ".join(r.flags.get(m, ()))])
    print(_summary(rows))
    print()
    print(verdict_table(rows))
    print(f"\nwall time {wall:.1f} s; wrote {a.out / 'cmg_model_verdicts.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
