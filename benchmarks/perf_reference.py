"""A time-varying reference in the compiled loop, sampled three ways, in one process:
``python -m benchmarks.perf_reference [--repeat N]``.

The rotating-payload satellite (:data:`spacecraft.payload.PAYLOAD_SATELLITE_J`, the example
payload's torque, ideal torques) under the small-angle PID with payload feed-forward, holding
the Earth-pointing (LVLH) attitude of a circular orbit for 600 s at dt = 0.025 s with control
and logging at every step — the configuration of the rotating-payload reproduction, where the
reference is read at every step. The compiled loop samples the reference before it starts:

- ``samples``: through the reference's vectorised ``samples(times)`` (the sampling protocol of
  :mod:`liecontrol.control.reference`), one NumPy call for the whole run;
- ``call by call``: the same reference without ``samples`` (a subclass that hides it, as a
  user's reference without the method): one Python call per needed step, the samples validated
  together;
- ``Python loop``: the per-step Python loop (reference, controller, plant in Python).

Seconds of CPU time per run and µs per step, best of ``--repeat`` alternated runs after a
warm-up.
"""

from __future__ import annotations

from benchmarks._perf import best_of, pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import os  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

__all__ = ["main", "reference_costs"]

T_FINAL, DT = 600.0, 0.025


def reference_costs(repeat: int = 3) -> dict[str, float]:
    """``{route: CPU seconds per run}`` (module docstring)."""
    from liecontrol.control.payload_compensation import SmallAnglePIDWithFeedforward
    from spacecraft import IdealTorqueActuator, RigidBody, Spacecraft, simulate
    from spacecraft import simulator as sim
    from spacecraft.orbit import CircularOrbit, EarthPointingReference
    from spacecraft.payload import (
        PAYLOAD_SATELLITE_J,
        PAYLOAD_SPIN_RATE,
        ROTATING_PAYLOAD_EXAMPLE,
        RotatingPayloadTorque,
    )

    class CallByCall(EarthPointingReference):
        samples = None  # a reference without the sampling protocol

    orbit = CircularOrbit()
    fast, slow = EarthPointingReference(orbit), CallByCall(orbit)
    J = PAYLOAD_SATELLITE_J
    plant = Spacecraft(
        RigidBody(J), IdealTorqueActuator(), RotatingPayloadTorque([ROTATING_PAYLOAD_EXAMPLE])
    )
    x0 = plant.initial_state(fast(0.0).R_d, omega0=fast.omega_d)

    def run(route: str) -> float:
        ctrl = SmallAnglePIDWithFeedforward(
            J, PAYLOAD_SPIN_RATE, compensation_start=40.0, dt_c=0.25, dt_p=DT
        )
        ref: Any = slow if route == "call by call" else fast
        real = sim.fused_supported
        if route == "Python loop":
            sim.fused_supported = lambda *a, **k: None
        try:
            c = time.process_time()
            simulate(plant, ctrl, ref, x0, T_FINAL, DT, control_period=DT, log_every=1)
            return time.process_time() - c
        finally:
            sim.fused_supported = real

    best = best_of(run, ("samples", "call by call", "Python loop"), repeat)
    return best


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args(argv)
    best = reference_costs(a.repeat)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    steps = round(T_FINAL / DT)
    print(f"Earth-pointing reference, {steps} steps, best of {a.repeat}; load {load:.1f}")
    print(f"{'route':<14} {'s per run':>10} {'µs/step':>9} {'× samples':>10}")
    for r, v in best.items():
        print(f"{r:<14} {v:>10.3f} {1e6 * v / steps:>9.2f} {v / best['samples']:>10.1f}")


if __name__ == "__main__":
    main()
