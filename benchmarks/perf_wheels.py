"""Reaction wheels in the compiled loop against the Python loop, in one process:
``python -m benchmarks.perf_wheels [--repeat N]``.

A four-wheel pyramid (:class:`spacecraft.actuators.ReactionWheelAssembly`, 0.2 N·m, 600 rad/s
per wheel) on the rotating-payload satellite's inertia under the constant + harmonic torque,
the large-angle geometric PD slewing 90° at dt = 0.1 s with control at every step; with and
without bearing friction (Coulomb, Stribeck, viscous). The Python loop is the same assembly
through a subclass (a subclass keeps the Python loop: it may change a formula). The SGCMG
pyramid with SR steering is the reference row. One spacecraft for 600 s (logging every step)
and a batch of 100 for 60 s (logging every 600th step); spacecraft-steps per CPU-second of
this process, best of ``--repeat`` alternated runs after a warm-up.
"""

from __future__ import annotations

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import os  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

__all__ = ["main", "wheel_rates"]


def wheel_rates(repeat: int = 3) -> dict[tuple[str, int], float]:
    """``{(configuration, batch): spacecraft-steps per CPU-second}`` (module docstring)."""
    from liecontrol.control import ConstantAttitude, GeometricPD
    from liecontrol.lie import so3
    from spacecraft import (
        ConstantHarmonicTorque,
        ReactionWheelAssembly,
        RigidBody,
        SgcmgActuator,
        Spacecraft,
        simulate,
    )
    from spacecraft.payload import PAYLOAD_SATELLITE_J as J

    class PythonWheels(ReactionWheelAssembly):
        """The same assembly through the Python loop."""

    friction = dict(coulomb_friction=0.002, viscous_friction=1e-4, stribeck_torque=0.004,
                    stribeck_speed=5.0)  # fmt: skip

    def wheels(cls: Any, **kw: Any) -> Any:
        return cls.pyramid(wheel_inertia=0.05, max_torque=0.2, max_speed=600.0, **kw)

    actuators = {
        "SGCMG + SR (compiled)": lambda: SgcmgActuator(),
        "wheels (compiled)": lambda: wheels(ReactionWheelAssembly),
        "wheels (Python loop)": lambda: wheels(PythonWheels),
        "wheels + friction (compiled)": lambda: wheels(ReactionWheelAssembly, **friction),
        "wheels + friction (Python loop)": lambda: wheels(PythonWheels, **friction),
    }
    target = ConstantAttitude(so3.exp(np.array([0.0, 0.0, np.pi / 2])))
    runs = {(k, B): make for k, make in actuators.items() for B in (1, 100)}
    best = dict.fromkeys(runs, np.inf)
    for i in range(repeat + 1):  # the first round warms up (compiles)
        for (k, B), make in runs.items():
            python = "Python" in k
            T = (600.0 if B == 1 else 60.0) / (10.0 if python else 1.0)
            plant = Spacecraft(RigidBody(J), make(), disturbance=ConstantHarmonicTorque())
            x0 = plant.initial_state(np.eye(3), batch=B)
            t0 = time.process_time()
            simulate(plant, GeometricPD(J, 20.0, 150.0, error="large_angle"), target, x0,
                     t_final=T, dt=0.1, log_every=1 if B == 1 else 600)  # fmt: skip
            if i:
                best[(k, B)] = min(best[(k, B)], (time.process_time() - t0) / (B * round(T / 0.1)))
    return {k: 1.0 / v for k, v in best.items()}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args(argv)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    rates = wheel_rates(a.repeat)
    print(f"spacecraft-steps per CPU-second, best of {a.repeat}; load {load:.1f}")
    for (k, B), v in rates.items():
        line = f"B={B:<4d} {k:34s} {v:10.3g}"
        if "(Python loop)" in k:
            fast = rates[(k.replace("Python loop", "compiled"), B)]
            line += f"   compiled × {fast / v:5.0f}"
        print(line)


if __name__ == "__main__":
    main()
