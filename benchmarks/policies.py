"""Rank a policy (a trained network, a numpy linear map, any ``obs -> action`` callable) in the
benchmark next to the geometric controllers.

:func:`register_policy` wraps it in :class:`spacecraft.envs.PolicyController` — the observation
and action maps of the Gymnasium environments (:mod:`spacecraft.envs`) — and registers it with
:func:`benchmarks.controllers.register`. Call it from your own code or from a file given to
``python -m benchmarks run --plugin my_policy.py``::

    from benchmarks.policies import register_policy
    from spacecraft.envs import AttitudeEnvConfig
    register_policy("my-residual", my_policy, AttitudeEnvConfig(action="residual"))

Policies are never in the quick suite unless asked (``quick=True``); needs the ``[rl]`` extra.
``python -m benchmarks.policies`` runs the worked example (cross-entropy training on the vector
environment, then :func:`compare_policy` against the untuned geometric PD).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .controllers import ControllerContext, ControllerInfo, register

__all__ = ["register_policy", "policy_factory", "compare_policy"]


def policy_factory(
    policy: Callable[[np.ndarray], Any], config: Any
) -> Callable[[ControllerContext], Any]:
    """Factory of :class:`spacecraft.envs.PolicyController` for ``policy`` trained with
    ``config`` (:class:`spacecraft.envs.AttitudeEnvConfig`). The residual mode's baseline is the
    environment's geometric PD law (large-angle error, ``ω_n``, ``ζ`` of ``config``) tuned on
    the scenario's nominal inertia at the run's control period."""
    from liecontrol.control.geometric_pd import GeometricPD
    from liecontrol.control.tuning import ClosedLoopSpec, tune_geometric_pd
    from spacecraft.envs import AttitudeEnvConfig, PolicyController

    if not callable(policy):
        raise ValueError(f"policy: must be callable as policy(obs) -> action, got {policy!r}")
    if not isinstance(config, AttitudeEnvConfig):
        raise ValueError(f"config: expected an AttitudeEnvConfig, got {type(config).__name__}")

    def make(ctx: ControllerContext) -> Any:
        spec = ClosedLoopSpec(config.omega_n, config.zeta, ctx.control_period)
        baseline = GeometricPD(ctx.J, **tune_geometric_pd(ctx.J, spec, error="large_angle"))
        return PolicyController(policy, config, baseline=baseline)

    make.__doc__ = f"policy ({config.action} action on {', '.join(config.observation)})"
    return make


def register_policy(
    name: str,
    policy: Callable[[np.ndarray], Any],
    config: Any = None,
    *,
    description: str | None = None,
    quick: bool = False,
    replace: bool = False,
) -> ControllerInfo:
    """Register ``policy`` (trained with ``config``, default ``AttitudeEnvConfig()``) as the
    benchmark controller ``name``: applies to the plant of ``config.actuator`` only, sampled at
    ``config.action_period`` (the period it was trained at), family ``"learned"``."""
    from spacecraft.envs import AttitudeEnvConfig

    config = AttitudeEnvConfig() if config is None else config
    factory = policy_factory(policy, config)
    return register(
        name,
        factory,
        description=description or factory.__doc__,
        plants={config.actuator},
        control_period=config.action_period,
        quick=quick,
        family="learned",
        replace=replace,
    )


def compare_policy(
    policy: Callable[[np.ndarray], Any],
    config: Any = None,
    scenarios: tuple[str, ...] = ("slew-30", "slew-90", "slew-179"),
    baseline: str = "geometric-pd-large-angle",
    name: str = "learned-policy",
    report_dir: str | Path | None = None,
) -> list[dict[str, Any]]:
    """Run ``policy`` (registered as ``name`` for the call, then removed) and the registered
    controller ``baseline`` on the catalogue ``scenarios`` with
    :func:`benchmarks.runner.run_suite` (serial); one dict per pair with the verdict,
    settling time [s], final error [deg], effort [N·m·s] and peak torque [N·m]. With
    ``report_dir`` the full benchmark report (:func:`benchmarks.report.write_report`) is
    written there too."""
    from .controllers import CONTROLLERS, get_controller, unregister
    from .runner import run_suite
    from .scenarios import get_scenario

    get_controller(baseline)  # unknown names fail here, listing the valid ones
    if name in CONTROLLERS:
        raise ValueError(f"name: controller {name!r} is already registered")
    if isinstance(scenarios, str):
        raise ValueError(f"scenarios: expected a sequence of names, got {scenarios!r}")
    chosen = [get_scenario(s) for s in scenarios]
    register_policy(name, policy, config)
    try:
        res = run_suite(chosen, [baseline, name], executor="serial", progress=False)
    finally:
        unregister(name)
    if report_dir is not None:
        from .report import write_report

        write_report(res, Path(report_dir))
    keys = ("settling_time_s", "final_error_deg", "effort_Nms", "peak_torque_Nm")
    return [
        {
            "scenario": o.scenario,
            "controller": o.controller,
            "verdict": o.verdict,
            **{k: o.metrics.get(k, float("nan")) for k in keys},
        }
        for o in res.outcomes
    ]


def main(argv: list[str] | None = None) -> None:
    """``python -m benchmarks.policies [--iterations N] [--out W.npy]``: the worked example —
    train a linear residual policy with the cross-entropy method
    (:func:`spacecraft.envs.cem.train_cem`), print its learning curve, then rank it in the
    benchmark against the untuned geometric PD (:func:`compare_policy`)."""
    import argparse
    import time

    from spacecraft.envs import AttitudeEnvConfig
    from spacecraft.envs.cem import train_cem

    p = argparse.ArgumentParser(prog="python -m benchmarks.policies", description=main.__doc__)
    p.add_argument("--iterations", type=int, default=10)
    p.add_argument("--population", type=int, default=16)
    p.add_argument("--elite", type=int, default=4)
    p.add_argument("--episodes", type=int, default=8)
    p.add_argument("--steps", type=int, default=400, help="max_episode_steps (0.5 s each)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=None, help="save the learned W (.npy)")
    p.add_argument("--report", default=None, help="write the benchmark report to this folder")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    res = train_cem(
        iterations=args.iterations,
        population=args.population,
        elite=args.elite,
        episodes=args.episodes,
        sigma0=0.3,
        seed=args.seed,
        max_episode_steps=args.steps,
    )
    print(f"training: {time.perf_counter() - t0:.1f} s")
    print(f"baseline (W = 0) return: {res.baseline_return:.3f}")
    for i, (m, e) in enumerate(zip(res.mean_return, res.elite_return, strict=True)):
        print(f"iteration {i + 1:2d}: mean-policy return {m:.3f}  elite mean {e:.3f}")
    if args.out:
        np.save(args.out, res.policy.W)
    print("\nbenchmark (run_suite, serial):")
    rows = compare_policy(
        res.policy,
        AttitudeEnvConfig(action="residual"),
        name="cem-residual",
        report_dir=args.report,
    )
    for row in rows:
        print("  " + "  ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                               for k, v in row.items()))  # fmt: skip


if __name__ == "__main__":
    main()
