"""Closed-loop simulation throughput: ``python -m benchmarks.perf_closed_loop [--profile B]``.

SGCMG-bus spacecraft (SGCMG pyramid, SR steering) under the large-angle geometric PD, 90° rest-to-
rest at dt = 0.1 s (controller at every step):

- one spacecraft for ``--t-final`` s, logging every step and logging every 600th step:
  simulated steps per second;
- batches of ``--batch`` spacecraft (default 1000 and 10 000, random targets) for
  ``--batch-t-final`` s, logging every 600th step: spacecraft-steps per second.

Every figure is the best of ``--repeat`` runs (the machine is shared: the best run is the one
least disturbed by other jobs) and is given per wall-second and per CPU-second of this process
(``time.process_time``; with one BLAS/OpenMP thread the CPU figure is the per-core throughput).
The BLAS/OpenMP thread counts are set to 1 before numpy is imported unless the environment sets
them, and are printed.

``--profile B`` prints the cProfile top entries of a run with ``B`` spacecraft instead.
Reference point: a compiled C++ framework does ~48 000 steps/s single-run on this machine class
(a batch aims at ≥ 10× that per core, 480 000 spacecraft-steps/s, for Monte Carlo).
"""

from __future__ import annotations

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import cProfile  # noqa: E402
import pstats  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks._perf import sgcmg_bus_inertia, sgcmg_bus_pd_loop, thread_settings  # noqa: E402
from spacecraft import (  # noqa: E402
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
    simulate,
)

J_BUS = sgcmg_bus_inertia()



def _setup(batch: int, rng: np.random.Generator):
    plant = Spacecraft(
        RigidBody(J_BUS), SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust())
    )
    ctrl, ref = sgcmg_bus_pd_loop(batch, rng)
    return plant, ctrl, ref, plant.initial_state(np.eye(3), batch=batch)


def measure(
    batch: int, t_final: float, dt: float, log_every: int, repeat: int = 1
) -> tuple[float, float]:
    """Best-of-``repeat`` spacecraft-steps per wall-second and per CPU-second of this process
    (the two minima are taken separately)."""
    rng = np.random.default_rng(0)
    best_wall = best_cpu = np.inf
    for _ in range(repeat):
        plant, ctrl, ref, s0 = _setup(batch, rng)
        w, c = time.perf_counter(), time.process_time()
        simulate(plant, ctrl, ref, s0, t_final, dt, log_every=log_every)
        best_wall = min(best_wall, time.perf_counter() - w)
        best_cpu = min(best_cpu, time.process_time() - c)
    n = batch * round(t_final / dt)
    return n / best_wall, n / best_cpu


def profile(batch: int, t_final: float, dt: float, log_every: int, top: int = 25) -> None:
    plant, ctrl, ref, s0 = _setup(batch, np.random.default_rng(0))
    pr = cProfile.Profile()
    pr.enable()
    simulate(plant, ctrl, ref, s0, t_final, dt, log_every=log_every)
    pr.disable()
    pstats.Stats(pr).sort_stats("tottime").print_stats(top)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--t-final", type=float, default=300.0, help="single-run length [s]")
    p.add_argument("--batch-t-final", type=float, default=30.0, help="batch-run length [s]")
    p.add_argument("--dt", type=float, default=0.1)
    p.add_argument("--batch", type=int, nargs="+", default=[1000, 10000])
    p.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    p.add_argument("--profile", type=int, metavar="B", default=None)
    a = p.parse_args(argv)
    sparse = max(1, round(60.0 / a.dt))
    print(f"threads: {thread_settings()}")
    if a.profile is not None:
        tf = a.t_final if a.profile == 1 else a.batch_t_final
        profile(a.profile, tf, a.dt, sparse)
        return
    rows = [
        ("single spacecraft, log every step", measure(1, a.t_final, a.dt, 1, a.repeat)),
        (
            f"single spacecraft, log every {sparse}",
            measure(1, a.t_final, a.dt, sparse, a.repeat),
        ),
    ]
    for B in a.batch:
        # about the same number of spacecraft-steps per run whatever B
        tf = max(a.dt, a.batch_t_final * min(1.0, 1000.0 / B))
        rows.append((f"batch of {B}, log every {sparse}", measure(B, tf, a.dt, sparse, a.repeat)))
    print(f"{'case':40s} {'per wall-s':>12s} {'per CPU-s':>12s}  [spacecraft-steps]")
    for name, (wall, cpu) in rows:
        print(f"{name:40s} {wall:12.0f} {cpu:12.0f}")
    print("reference: Basilisk (C++) runs ~40 000-48 000 steps/s single-run on this machine")
    print("class; python -m benchmarks.perf_basilisk measures it in the same process")


if __name__ == "__main__":
    main()
