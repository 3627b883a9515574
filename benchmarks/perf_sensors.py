"""Sensors in the loop, compiled and not: ``python -m benchmarks.perf_sensors [--repeat 3]``.

The SGCMG-bus spacecraft (SGCMG pyramid, SR steering) under the large-angle geometric PD at
every step, with a star tracker and a rate gyro (:func:`benchmarks.runner.build_sensors` of the
default :class:`benchmarks.scenarios.SensorSpec`: 10″ tracker, gyro noise and bias walk, both
sampled every 0.2 s), ``--t-final`` s at dt = ``--dt``, logging every ``--log-every`` steps:

* ``raw``: the controller sees the raw measurements through
  :class:`spacecraft.simulator.StarTrackerGyro` — fused (:mod:`spacecraft._fused_sensors`) and
  forced through the Python loop, interleaved in one process;
* ``mekf``: the MEKF hook :class:`benchmarks.runner.FilteredAttitude` between the sensors and
  the controller — fused (its compiled filter, :mod:`liecontrol._kernels.mekf`) and
  in the Python loop;
* ``ukf``: the same hook with the manifold UKF (``estimator="ukf"``; compiled:
  :mod:`liecontrol._kernels.ukf`);
* ``two-vector``: the tracker replaced by a :class:`spacecraft.sensors.TwoVectorAttitude`
  (two fixed reference directions, 1 mrad per direction, TRIAD, ZYX Euler-angle output — Wang
  et al. 2015's sensor) read by ``StarTrackerGyro``; ``tracker-euler``: the tracker with
  ZYX Euler-angle output (compiled: :mod:`liecontrol._kernels.euler`).

Spacecraft-steps per CPU-second of this process (``time.process_time``, best of ``--repeat``
rounds; the machine may be shared, so CPU time, and both routes alternate within each round).
The first call of each route is made before timing (compilation and caches).
"""

from __future__ import annotations

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks._perf import sgcmg_bus_inertia, sgcmg_bus_pd_loop, thread_settings  # noqa: E402
from benchmarks.runner import build_sensors  # noqa: E402
from benchmarks.scenarios import SensorSpec  # noqa: E402
from spacecraft import (  # noqa: E402
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
    simulate,
)
from spacecraft import simulator as simulator_module  # noqa: E402
from spacecraft.sensors import StarTracker, TwoVectorAttitude  # noqa: E402

_HOOKS = ("none", "mekf", "ukf", "two-vector", "tracker-euler")


def _sensors(estimator: str) -> tuple[Any, Any, np.random.Generator]:
    """The run's sensors, hook and generator (fresh)."""
    if estimator not in ("two-vector", "tracker-euler"):
        return build_sensors(SensorSpec(estimator=estimator))
    spec = SensorSpec()
    sensors, hook, rng = build_sensors(spec)
    if estimator == "two-vector":
        sensors["star_tracker"] = TwoVectorAttitude(
            np.array([0.0, 0.0, -1.0]), np.array([1.0, 0.0, 0.5]), 1e-3, output="euler",
            period=spec.period,
        )  # fmt: skip
    else:
        sensors["star_tracker"] = StarTracker(
            noise_std=spec.attitude_noise_rad, output="euler", period=spec.period
        )
    return sensors, hook, rng


def _setup(batch: int, estimator: str) -> tuple[Any, ...]:
    plant = Spacecraft(
        RigidBody(sgcmg_bus_inertia()), SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust())
    )
    ctrl, ref = sgcmg_bus_pd_loop(batch, np.random.default_rng(0))
    return plant, ctrl, ref, plant.initial_state(np.eye(3), batch=batch), estimator


def run_once(
    setup: tuple[Any, ...], t_final: float, dt: float, log_every: int, python: bool
) -> float:
    """CPU seconds of one run (sensors and generator built fresh, outside the timing)."""
    plant, ctrl, ref, s0, estimator = setup
    sensors, hook, rng = _sensors(estimator)
    real = simulator_module.fused_supported
    if python:
        simulator_module.fused_supported = lambda *a, **k: None
    try:
        c = time.process_time()
        simulate(plant, ctrl, ref, s0, t_final, dt, log_every=log_every, sensors=sensors,
                 measurement=hook, rng=rng)  # fmt: skip
        return time.process_time() - c
    finally:
        simulator_module.fused_supported = real


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--t-final", type=float, default=600.0, help="horizon [s] (default 600)")
    p.add_argument("--dt", type=float, default=0.1, help="step [s] (default 0.1)")
    p.add_argument("--log-every", type=int, default=10, help="log every N steps (default 10)")
    p.add_argument("--batch", type=int, nargs="+", default=[1, 100], help="batch sizes")
    p.add_argument("--repeat", type=int, default=3, help="rounds, best taken (default 3)")
    p.add_argument(
        "--estimator", nargs="+", default=["none", "mekf", "ukf"], choices=list(_HOOKS),
        help="none: StarTrackerGyro; mekf / ukf: the MEKF / manifold UKF hook (the Python "
        "loop's filters cost ~0.3-0.5 ms per filter step: B = 100 takes minutes per run); "
        "two-vector / tracker-euler: StarTrackerGyro on a TwoVectorAttitude / a tracker with "
        "Euler-angle output",
    )  # fmt: skip
    a = p.parse_args(argv)
    steps = round(a.t_final / a.dt)
    print(f"{a.t_final:g} s at dt = {a.dt:g} s ({steps} steps), log every {a.log_every}; "
          f"{thread_settings()}; best of {a.repeat}")  # fmt: skip
    print(f"{'hook':<13} {'B':>5} {'route':<8} {'CPU s':>9} {'steps/s':>12} {'vs Python':>10}")
    for estimator in a.estimator:
        for B in a.batch:
            setup = _setup(B, estimator)
            run_once(setup, 20 * a.dt, a.dt, a.log_every, python=False)  # compile / warm up
            best = {"fused": np.inf, "python": np.inf}
            for _ in range(a.repeat):
                for route in best:
                    cpu = run_once(setup, a.t_final, a.dt, a.log_every, python=route == "python")
                    best[route] = min(best[route], cpu)
            name = "raw" if estimator == "none" else estimator
            for route, cpu in best.items():
                ratio = best["python"] / cpu
                print(f"{name:<13} {B:>5} {route:<8} {cpu:>9.3f} {B * steps / cpu:>12.4g} "
                      f"{ratio:>9.1f}x", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
