"""Magnetic momentum dumping in the compiled loop against the Python loop, in one process:
``python -m benchmarks.perf_dumping [--repeat N] [--orbits K]``.

The dumping example of docs/plant.md on the ``momentum-dumping`` scenario's orbit, rods,
disturbance and step: the SGCMG bus (4-SGCMG pyramid, SR steering) holding the Earth-pointing
attitude of a 530 km sun-synchronous orbit under the orbit-rate constant + harmonic torque, the
large-angle geometric PD at 0.03 rad/s, and :class:`spacecraft.momentum.CrossProductDumping`
with 3000 A·m² rods, for ``--orbits`` orbits at dt = 1 s (control and logging at every step, as
the suite's single runs). The same run without
dumping is the reference row. CPU seconds per run and µs per step, best of ``--repeat``
alternated runs after a warm-up.
"""

from __future__ import annotations

from benchmarks._perf import best_of, pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import math  # noqa: E402
import os  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

__all__ = ["dumping_costs", "main"]

DT = 1.0


def dumping_costs(repeat: int = 3, orbits: float = 1.0) -> tuple[dict[str, float], int]:
    """``({route: CPU seconds per run}, steps)`` (module docstring)."""
    import numpy as np

    from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
    from spacecraft import ConstantHarmonicTorque, RigidBody, SgcmgActuator, Spacecraft, simulate
    from spacecraft import simulator as sim
    from spacecraft.momentum import CrossProductDumping, Magnetorquers
    from spacecraft.orbit import CircularOrbit, EarthPointingReference

    J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
    orbit = CircularOrbit.from_altitude(530e3, inclination=np.deg2rad(97.5))
    ref = EarthPointingReference(orbit)
    dumping = CrossProductDumping(orbit, magnetorquers=Magnetorquers(3000.0), gain=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plants = {
            m: Spacecraft(
                RigidBody(J),
                SgcmgActuator(),
                ConstantHarmonicTorque(n=orbit.n),
                momentum_management=dumping if m else None,
            )  # fmt: skip
            for m in (True, False)
        }
    k_R, k_W = gains_from_bandwidth(J, 0.03, 0.9, error="large_angle", matrix=True)
    r0 = ref(0.0)
    t_final = DT * math.ceil(orbits * orbit.period / DT)

    def run(route: str) -> float:
        plant = plants[route != "no dumping, compiled"]
        real = sim.fused_supported
        if route == "dumping, Python loop":
            sim.fused_supported = lambda *a, **k: None
        try:
            c = time.process_time()
            simulate(
                plant, GeometricPD(J, k_R, k_W), ref, plant.initial_state(r0.R_d, r0.omega_d),
                t_final, DT,
            )  # fmt: skip
            return time.process_time() - c
        finally:
            sim.fused_supported = real

    routes = ("dumping, compiled", "dumping, Python loop", "no dumping, compiled")
    return best_of(run, routes, repeat), round(t_final / DT)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--orbits", type=float, default=1.0)
    a = p.parse_args(argv)
    best, steps = dumping_costs(a.repeat, a.orbits)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"momentum dumping, {steps} steps of {DT:g} s, best of {a.repeat}; load {load:.1f}")
    print(f"{'route':<22} {'s per run':>10} {'µs/step':>9}")
    for r, v in best.items():
        print(f"{r:<22} {v:>10.3f} {1e6 * v / steps:>9.2f}")


if __name__ == "__main__":
    main()
