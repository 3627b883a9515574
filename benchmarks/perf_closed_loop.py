"""Closed-loop simulation throughput: ``python -m benchmarks.perf_closed_loop [--profile]``.

Seed-000 spacecraft (SGCMG pyramid, SR steering) under the large-angle geometric PD, 90° rest-to-
rest, 600 s at dt = 0.1 s (6000 RKMK4 steps, controller at every step):

- one spacecraft, logging every step and logging every 600th step: simulated steps per second;
- a batch of ``--batch`` spacecraft (default 1000, random targets), logging every 600th step:
  spacecraft-steps per second.

``--profile`` prints the cProfile top entries of the single-spacecraft run. Reference point: a
compiled C++ framework does ~48 000 steps/s single-run on this machine class.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

import numpy as np

from liecontrol.control import ConstantAttitude
from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
from liecontrol.lie import so3
from spacecraft import (
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
    simulate,
)

J_SEED000 = np.array(
    [[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]]
)


def _setup(batch: int, rng: np.random.Generator):
    plant = Spacecraft(
        RigidBody(J_SEED000), SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust())
    )
    k_R, k_W = gains_from_bandwidth(J_SEED000, 0.03, 0.9, error="large_angle", matrix=True)
    ctrl = GeometricPD(J_SEED000, k_R, k_W, error="large_angle")
    if batch == 1:
        R_d = so3.exp(np.deg2rad(90.0) * np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0))
    else:
        R_d = so3.exp(rng.normal(size=(batch, 3)) * 0.8)
    return plant, ctrl, ConstantAttitude(R_d), plant.initial_state(np.eye(3), batch=batch)


def measure(batch: int, t_final: float, dt: float, log_every: int, repeat: int = 1) -> float:
    """Best-of-``repeat`` spacecraft-steps per wall-second."""
    rng = np.random.default_rng(0)
    best = np.inf
    for _ in range(repeat):
        plant, ctrl, ref, s0 = _setup(batch, rng)
        t = time.perf_counter()
        simulate(plant, ctrl, ref, s0, t_final, dt, log_every=log_every)
        best = min(best, time.perf_counter() - t)
    n_steps = round(t_final / dt)
    return batch * n_steps / best


def profile(t_final: float, dt: float, top: int = 25) -> None:
    plant, ctrl, ref, s0 = _setup(1, np.random.default_rng(0))
    pr = cProfile.Profile()
    pr.enable()
    simulate(plant, ctrl, ref, s0, t_final, dt)
    pr.disable()
    pstats.Stats(pr).sort_stats("tottime").print_stats(top)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--t-final", type=float, default=600.0)
    p.add_argument("--dt", type=float, default=0.1)
    p.add_argument("--batch", type=int, default=1000)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--profile", action="store_true")
    a = p.parse_args(argv)
    if a.profile:
        profile(a.t_final, a.dt)
        return
    sparse = max(1, round(60.0 / a.dt))
    one_full = measure(1, a.t_final, a.dt, 1, a.repeat)
    one_sparse = measure(1, a.t_final, a.dt, sparse, a.repeat)
    many = measure(a.batch, a.t_final, a.dt, sparse, 1)
    print(f"single spacecraft, log every step : {one_full:9.0f} steps/s")
    print(f"single spacecraft, log every {sparse:<4d} : {one_sparse:9.0f} steps/s")
    print(f"batch of {a.batch}, log every {sparse:<4d}   : {many:9.0f} spacecraft-steps/s")
    print("reference: compiled C++ framework ~48 000 steps/s single-run")


if __name__ == "__main__":
    main()
