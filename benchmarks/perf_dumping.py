"""Magnetic momentum dumping in the compiled loop against the Python loop, in one process:
``python -m benchmarks.perf_dumping [--repeat N] [--orbits K] [--actuator sgcmg|full]``.

The dumping example of docs/plant.md on the ``momentum-dumping`` scenario's orbit, rods,
disturbance and step: the SGCMG bus (4-SGCMG pyramid, SR steering) holding the Earth-pointing
attitude of a 530 km sun-synchronous orbit under the orbit-rate constant + harmonic torque, the
large-angle geometric PD at 0.03 rad/s, and :class:`spacecraft.momentum.CrossProductDumping`
with 3000 A·m² rods, for ``--orbits`` orbits at dt = 1 s (control and logging at every step, as
the suite's single runs). The same run without
dumping is the reference row. CPU seconds per run and µs per step, best of ``--repeat``
alternated runs after a warm-up.

``--actuator full`` flies the full CMG model instead (:class:`spacecraft.cmg_dynamics.
VscmgActuator`: the same pyramid and steering with rotor and gimbal inertia, its default gimbal
servo) at dt = 0.1 s, the step its servo needs; the dipole then comes from the cluster's momentum
relative to the bus, Σ (J_g δ̇ g + I_Ws Ω s).
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

#: the step [s] per actuator (the full CMG model's gimbal servo needs the shorter one)
DT = {"sgcmg": 1.0, "full": 0.1}


def dumping_costs(
    repeat: int = 3, orbits: float = 1.0, actuator: str = "sgcmg"
) -> tuple[dict[str, float], int]:
    """``({route: CPU seconds per run}, steps)`` (module docstring)."""
    import numpy as np

    from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
    from spacecraft import ConstantHarmonicTorque, RigidBody, SgcmgActuator, Spacecraft, simulate
    from spacecraft import simulator as sim
    from spacecraft.cmg_dynamics import CmgInertias, VscmgActuator
    from spacecraft.momentum import CrossProductDumping, Magnetorquers
    from spacecraft.orbit import CircularOrbit, EarthPointingReference
    from spacecraft.sgcmg import SgcmgPyramid
    from spacecraft.steering import SingularityRobust

    J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
    orbit = CircularOrbit.from_altitude(530e3, inclination=np.deg2rad(97.5))
    ref = EarthPointingReference(orbit)
    dumping = CrossProductDumping(orbit, magnetorquers=Magnetorquers(3000.0), gain=1e-3)
    if actuator not in DT:
        raise ValueError(f"actuator: expected one of {sorted(DT)}, got {actuator!r}")
    dt = DT[actuator]

    def cluster() -> object:
        if actuator == "sgcmg":
            return SgcmgActuator()
        pyramid = SgcmgPyramid()
        return VscmgActuator(
            J, CmgInertias(0.5, 0.25, (0.1, 0.1, 0.1)), pyramid, SingularityRobust()
        )

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plants = {
            m: Spacecraft(
                RigidBody(J),
                cluster(),
                ConstantHarmonicTorque(n=orbit.n),
                momentum_management=dumping if m else None,
            )  # fmt: skip
            for m in (True, False)
        }
    k_R, k_W = gains_from_bandwidth(J, 0.03, 0.9, error="large_angle", matrix=True)
    r0 = ref(0.0)
    t_final = dt * math.ceil(orbits * orbit.period / dt)

    def run(route: str) -> float:
        plant = plants[route != "no dumping, compiled"]
        real = sim.fused_supported
        if route == "dumping, Python loop":
            sim.fused_supported = lambda *a, **k: None
        try:
            c = time.process_time()
            simulate(
                plant, GeometricPD(J, k_R, k_W), ref, plant.initial_state(r0.R_d, r0.omega_d),
                t_final, dt,
            )  # fmt: skip
            return time.process_time() - c
        finally:
            sim.fused_supported = real

    routes = ("dumping, compiled", "dumping, Python loop", "no dumping, compiled")
    return best_of(run, routes, repeat), round(t_final / dt)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--orbits", type=float, default=1.0)
    p.add_argument("--actuator", choices=sorted(DT), default="sgcmg")
    a = p.parse_args(argv)
    best, steps = dumping_costs(a.repeat, a.orbits, a.actuator)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"momentum dumping ({a.actuator}), {steps} steps of {DT[a.actuator]:g} s, best of "
        f"{a.repeat}; load {load:.1f}"
    )
    print(f"{'route':<22} {'s per run':>10} {'µs/step':>9}")
    for r, v in best.items():
        print(f"{r:<22} {v:>10.3f} {1e6 * v / steps:>9.2f}")


if __name__ == "__main__":
    main()
