"""Gradient-tuned geometric PD against the fair-tuning protocol's gains, judged by the suite.

For each scenario: the protocol's large-angle geometric PD (the registry's
``geometric-pd-large-angle``, tuned to the suite's (ω_n, ζ)) is the start; its full gain matrices
are tuned by :func:`spacecraft.robust_tuning.tune_requirements` on the scenario's own
requirements (:func:`benchmarks.requirements.requirements_of`) over ``train`` dispersed members
(:mod:`benchmarks.dispersion`, seed ``train_seed``), through the JAX route. Both gain sets are
then flown by the suite's own runner — numba loop, metrics, requirements and cell verdicts — on
``held_out`` members drawn with another seed, which the tuning never saw.

    python -m benchmarks.gradient_tuning [--scenarios slew-90 slew-179] [--train 16]
        [--held-out 64] [--steps 30] [--out DIR]

writes ``DIR/gradient_tuning.md`` (the table), ``DIR/gradient_tuning.json`` and
``DIR/gradient_tuning.png`` (the tuning history). Needs JAX (``pip install liecontrol[jax]``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from liecontrol._validation import as_int

from .controllers import ControllerContext, get_controller, register, unregister
from .dispersion import DEFAULT_DISPERSION, MAX_MEMBERS, member_scenario
from .requirements import requirements_of
from .runner import build_plant, build_reference, initial_state, run_suite
from .scenarios import Scenario, get_scenario

__all__ = [
    "PROTOCOL",
    "TUNED",
    "scenario_requirements",
    "protocol_controller",
    "training_batch",
    "tune_scenario",
    "held_out_cells",
    "main",
]

#: The registry's name of the start (the fair-tuning protocol's gains).
PROTOCOL = "geometric-pd-large-angle"
#: The name the tuned gains are flown under by the suite.
TUNED = "geometric-pd-gradient-tuned"
_SUPPORTED = ("steady_error_max_deg", "settling_time_s", "overshoot_pct", "peak_momentum_fraction")


def _need_scenario(x: Any, name: str = "scenario") -> None:
    if not isinstance(x, Scenario):
        raise ValueError(
            f"{name}: expected a benchmarks.scenarios.Scenario, got {type(x).__name__}"
        )


def scenario_requirements(scenario: Scenario, design_margin: float = 0.8) -> Any:
    """The scenario's requirements as :class:`spacecraft.robust_tuning.TuningRequirements`
    (APE over the same pointing interval; settling in the runner's band, the scenario's attitude
    tolerance; overshoot; momentum use). A requirement the tuner has no value for raises
    ``ValueError`` naming it."""
    from spacecraft.robust_tuning import TuningRequirements

    _need_scenario(scenario)
    kw: dict[str, Any] = {"design_margin": design_margin}
    for r in requirements_of(scenario):
        if r.metric not in _SUPPORTED or r.sense != "max":
            raise ValueError(
                f"scenario {scenario.name!r}: requirement {r.name or r.metric!r} has no "
                f"differentiable value here (supported: {', '.join(_SUPPORTED)})"
            )
        if r.metric == "steady_error_max_deg":
            kw["ape_deg"] = r.limit
        elif r.metric == "settling_time_s":
            kw["settling_deg"] = float(scenario.attitude_tolerance_deg)
            kw["settling_by"] = r.limit
        elif r.metric == "overshoot_pct":
            kw["overshoot_pct"] = r.limit
        else:
            kw["momentum_fraction"] = r.limit
    return TuningRequirements(**kw)


def protocol_controller(scenario: Scenario, members: Sequence[Scenario]) -> Any:
    """The registry's ``geometric-pd-large-angle`` as the suite builds it for ``members``."""
    _need_scenario(scenario)
    if isinstance(members, (str, bytes)) or not isinstance(members, Sequence) or not members:
        raise ValueError("members: expected a non-empty sequence of Scenario objects")
    for i, m in enumerate(members):
        _need_scenario(m, f"members[{i}]")
    info = get_controller(PROTOCOL)
    ctx = ControllerContext(
        spacecraft=scenario.spacecraft,
        control_period=scenario.control_period or scenario.dt,
        batch_size=len(members),
        q_hint=np.stack([s.initial_quaternion for s in members]),
        reference=build_reference(scenario),
    )
    return info.factory(ctx)


def training_batch(
    scenario: Scenario, n: int, seed: int
) -> tuple[list, Any, np.ndarray, np.ndarray]:
    """Members ``1 … n`` of ``scenario`` drawn with ``seed`` (the scenario's dispersion, else
    the default): ``(members, plant with their true inertias, R0, ω0)``."""
    _need_scenario(scenario)
    n = as_int(n, "n", 1)
    if n > MAX_MEMBERS:
        raise ValueError(f"n: at most {MAX_MEMBERS} members, got {n}")
    seed = as_int(seed, "seed", 0)
    d = dataclasses.replace(scenario.dispersion or DEFAULT_DISPERSION, seed=seed)
    members = [member_scenario(scenario, k, d) for k in range(1, n + 1)]
    J = np.stack([m.true_inertia for m in members])
    if scenario.disturbances or scenario.faults or scenario.sensors is not None:
        raise ValueError(
            f"scenario {scenario.name!r}: the JAX route flies neither disturbances, faults nor "
            "sensors"
        )
    plant = build_plant(scenario.spacecraft, (), J)
    starts = [initial_state(m) for m in members]
    return members, plant, np.stack([r for r, _ in starts]), np.stack([w for _, w in starts])


def tune_scenario(
    scenario: Scenario,
    train: int = 16,
    train_seed: int = 1,
    steps: int = 30,
    learning_rate: float = 0.05,
    parameterization: str = "cholesky",
    design_margin: float = 0.8,
    checkpoint: bool = True,
) -> tuple[Any, Any]:
    """Tune the protocol's gains on ``scenario``'s requirements over ``train`` members:
    ``(RobustTuningResult, protocol controller)``."""
    from spacecraft.differentiable import closed_loop
    from spacecraft.robust_tuning import tune_requirements

    members, plant, R0, w0 = training_batch(scenario, train, train_seed)
    ctrl = protocol_controller(scenario, members)
    loop = closed_loop(
        plant, ctrl, build_reference(scenario), scenario.duration, scenario.dt,
        scenario.control_period, checkpoint=checkpoint,
    )  # fmt: skip
    req = scenario_requirements(scenario, design_margin)
    result = tune_requirements(
        loop, R0, w0, req, parameterization=parameterization, steps=steps,
        learning_rate=learning_rate,
    )  # fmt: skip
    return result, ctrl


def held_out_cells(
    scenario: Scenario, k_R: np.ndarray, k_Omega: np.ndarray, members: int, seed: int
) -> dict[str, Any]:
    """Both gain sets through :func:`benchmarks.runner.run_suite` on ``members`` members of
    ``scenario`` drawn with ``seed``: ``{controller: CellSummary}`` (the tuned gains registered
    as :data:`TUNED` for the run, then removed)."""
    from liecontrol.control.geometric_pd import GeometricPD

    K_R, K_W = np.array(k_R), np.array(k_Omega)

    def make(ctx: ControllerContext) -> Any:
        return GeometricPD(ctx.J, K_R, K_W, error="large_angle")

    make.__doc__ = "GeometricPD(large_angle) with the gradient-tuned full gain matrices"
    register(TUNED, make, description=make.__doc__, family="geometric", quick=False, replace=True)
    try:
        res = run_suite(
            [scenario], [PROTOCOL, TUNED], members=members, dispersion_seed=seed,
            executor="serial", progress=False,
        )  # fmt: skip
    finally:
        unregister(TUNED)
    return {c: res.cell(scenario.name, c) for c in (PROTOCOL, TUNED)}


def _cell_row(scenario: str, label: str, cell: Any) -> str:
    def v(key: str, i: int = 0) -> str:
        for name, stats in cell.values.items():
            if key in name:
                return f"{stats[i]:.3g}"
        return "—"

    return (
        f"| {scenario} | {label} | {cell.interval_text()} | {v('settling')} / {v('settling', 2)} "
        f"| {v('overshoot')} / {v('overshoot', 2)} | {v('momentum')} / {v('momentum', 2)} "
        f"| {cell.worst_margin:.3g} |"
    )


def _figure(histories: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.0))
    styles = ("-", "--", ":", "-.")
    for name, res in histories.items():
        h = res.history
        ev = np.arange(h["cost"].shape[0])
        (line,) = axes[0].semilogy(ev, h["cost"], label=f"{name}: cost")
        c = line.get_color()
        axes[0].semilogy(ev, h["angle"], "--", color=c, label=f"{name}: ∫θ²dt/θ₀² [s]")
        for ax in axes:
            ax.axvline(res.step, color=c, lw=0.8, alpha=0.7)
        keys = [k for k in h if k.startswith("margin_")]
        for key, st in zip(keys, styles, strict=False):
            label = key[len("margin_") :].replace("_deg_early", " (by m·deadline)")
            axes[1].plot(ev, h[key], st, color=c, label=f"{name}: {label.replace('_', ' ')}")
    half = next(iter(histories.values())).history["cost"].shape[0] // 2
    for ax in axes:
        ax.axvline(half, color="0.5", lw=0.8, ls=":")
        ax.set_xlabel("evaluation (a spike: a rejected step, retried at half the rate)")
    axes[0].set_title("cost, mean over the training members", fontsize=10)
    axes[1].axhline(1.0, color="k", lw=0.8)
    axes[1].set_ylim(0.0, 1.6)
    axes[1].set_title("worst training member / penalty start (≤ 1: within margin)", fontsize=10)
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=6, ncol=2)
    fig.suptitle("gradient tuning: solid vertical = chosen gains, dotted = bandwidth/damping "
                 "scales only before, every gain entry after", fontsize=9)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.gradient_tuning", description=__doc__)
    p.add_argument("--scenarios", nargs="+", default=["slew-90", "slew-179"])
    p.add_argument("--train", type=int, default=16, help="training members per scenario")
    p.add_argument("--held-out", type=int, default=64, help="held-out members per scenario")
    p.add_argument("--train-seed", type=int, default=1)
    p.add_argument("--held-out-seed", type=int, default=2)
    p.add_argument("--steps", type=int, default=30)
    p.add_argument("--learning-rate", type=float, default=0.05)
    p.add_argument("--parameterization", default="cholesky")
    p.add_argument("--design-margin", type=float, default=0.8)
    p.add_argument("--out", default="results/gradient_tuning")
    a = p.parse_args(argv)
    if a.train_seed == a.held_out_seed:
        p.error("--held-out-seed must differ from --train-seed (held-out members are unseen)")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    lines = [
        "| scenario | gains | members meeting every requirement [95 % interval] | settling "
        "[s] median / worst | overshoot [%] median / worst | momentum use median / worst | "
        "worst margin |",
        "|---|---|---|---|---|---|---|",
    ]
    record: dict[str, Any] = {"args": vars(a), "scenarios": {}}
    tuned: dict[str, Any] = {}
    for name in a.scenarios:
        sc = get_scenario(name)
        t = time.perf_counter()
        res, ctrl = tune_scenario(
            sc, a.train, a.train_seed, a.steps, a.learning_rate, a.parameterization,
            a.design_margin,
        )  # fmt: skip
        t_tune = time.perf_counter() - t
        tuned[name] = res
        cells = held_out_cells(sc, res.k_R, res.k_Omega, a.held_out, a.held_out_seed)
        lines.append(_cell_row(name, "protocol (ω_n = 0.03, ζ = 0.9)", cells[PROTOCOL]))
        lines.append(_cell_row(name, f"gradient-tuned (step {res.step})", cells[TUNED]))
        record["scenarios"][name] = {
            "tuning_s": t_tune,
            "step": res.step,
            "feasible_on_training": res.feasible,
            "k_R_protocol": np.asarray(ctrl.k_R).tolist(),
            "k_Omega_protocol": np.asarray(ctrl.k_Omega).tolist(),
            "k_R": res.k_R.tolist(),
            "k_Omega": res.k_Omega.tolist(),
            "history": {k: v.tolist() for k, v in res.history.items()},
            "held_out": {
                c: {
                    "passed": cell.passed,
                    "n": cell.n,
                    "interval": list(cell.interval),
                    "values": {k: list(v) for k, v in cell.values.items()},
                    "worst_margin": cell.worst_margin,
                }  # fmt: skip
                for c, cell in cells.items()
            },
        }
        print(f"{name}: tuned in {t_tune:.1f} s (step {res.step}, feasible {res.feasible})")
    _figure(tuned, out / "gradient_tuning.png")
    text = "\n".join(lines)
    (out / "gradient_tuning.md").write_text(text + "\n")
    (out / "gradient_tuning.json").write_text(json.dumps(record, indent=1, default=_json))
    print(text)
    print(f"wrote {out / 'gradient_tuning.md'}, .json, .png")
    return 0


def _json(x: Any) -> Any:
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    raise TypeError(type(x).__name__)


if __name__ == "__main__":
    raise SystemExit(main())
