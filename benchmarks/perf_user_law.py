"""A user's ``@njit`` law through the kernel seam against its Python twin and the built-in
geometric PD, in one process: ``python -m benchmarks.perf_user_law [--repeat N] [--steering]
[--disturbance]``.

The controller is the one of ``docs/fast_controllers.md`` (a PI law on the rotation-vector error
with its integral as internal state; its code block is executed from the page, so the figures
are of exactly that code). One spacecraft, 600 s at dt = 0.1 s with control at every step,
logging every step, on an ideal torque actuator and on the SGCMG pyramid with SR steering;
simulated steps per CPU-second, best of ``--repeat`` alternated runs after a warm-up.

``--steering``: the page's steering law instead (``DampedLeastSquares`` and its kernel, through
:mod:`spacecraft.steering_kernel`) against the built-in singularity-robust law, and the built-in
SR formula handed over through the same seam (the seam's own cost): the SGCMG pyramid, a 180°
start under the geometric PD, one spacecraft for 600 s and a batch of 100 for 60 s at dt = 0.1 s,
spacecraft-steps per CPU-second.

``--disturbance``: the gravity-gradient torque, which flies the compiled loop through the public
disturbance seam (:mod:`spacecraft.disturbance_kernel`), against the same torque without its
kernel (the Python loop) and against the run without disturbance, and the benchmark's
``earth-pointing`` environment (gravity gradient + constant + harmonic torque, a
:class:`~spacecraft.disturbances.SumOfDisturbances` compiled as the sum of its sources' kernels)
and a low-orbit environment (gravity gradient, aerodynamic and solar pressure torques on a
box with an offset centre of pressure, a residual dipole: :mod:`spacecraft.surface_forces`) on
both routes: the SGCMG pyramid with SR steering, the geometric PD from a 90° start, one
spacecraft for 600 s at dt = 0.1 s.
"""

from __future__ import annotations

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import os  # noqa: E402
import re  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

__all__ = ["disturbance_rates", "main", "user_law_rates", "user_steering_rates"]

PAGE = Path(__file__).resolve().parents[1] / "docs" / "fast_controllers.md"


def _page_namespace() -> dict[str, Any]:
    """The definitions of the page's first code block (the controllers and ``pi_law``)."""
    block = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)[0]
    keep = block.split("slow = simulate(")[0]  # the definitions, not the page's own runs
    ns: dict[str, Any] = {"__name__": "fast_controllers_page"}
    exec(compile(keep, str(PAGE), "exec"), ns)  # noqa: S102 - the project's own page
    return ns


def user_law_rates(repeat: int = 5, t_final: float = 600.0) -> dict[str, dict[str, float]]:
    """``{actuator: {loop: steps per CPU-second}}`` (module docstring)."""
    from liecontrol.control import ConstantAttitude, GeometricPD
    from liecontrol.lie import so3
    from spacecraft import (
        IdealTorqueActuator,
        RigidBody,
        SgcmgActuator,
        SgcmgPyramid,
        SingularityRobust,
        Spacecraft,
        simulate,
    )

    ns = _page_namespace()
    J = np.diag([1200.0, 1000.0, 800.0])
    target = ConstantAttitude(so3.exp(np.array([0.0, 0.0, np.pi / 2])))
    out: dict[str, dict[str, float]] = {}
    for act_name, act in (
        ("ideal", IdealTorqueActuator()),
        ("sgcmg", SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust())),
    ):
        plant = Spacecraft(RigidBody(J), act)
        x0 = plant.initial_state(np.eye(3))
        ctrls = {
            "PIController (Python loop)": ns["PIController"](300.0, 1500.0, 5.0),
            "FastPIController (fused, user's @njit law)": ns["FastPIController"](
                300.0, 1500.0, 5.0
            ),
            "GeometricPD (fused, built-in)": GeometricPD(J, 300.0, 1500.0),
        }
        steps = round(t_final / 0.1)
        best = dict.fromkeys(ctrls, np.inf)
        for c in ctrls.values():
            simulate(plant, c, target, x0, t_final=10.0, dt=0.1)  # warm-up
        for _ in range(repeat):
            for k, c in ctrls.items():
                # the Python loop runs a tenth of the time: it is ~10× slower per step
                T = t_final / 10 if "Python" in k else t_final
                t0 = time.process_time()
                simulate(plant, c, target, x0, t_final=T, dt=0.1)
                best[k] = min(best[k], (time.process_time() - t0) / (steps * T / t_final))
        out[act_name] = {k: 1.0 / v for k, v in best.items()}
    return out


def _steering_namespace() -> dict[str, Any]:
    """The definitions of the page's steering block (the laws and ``damped_kernel``)."""
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
    block = next(b for b in blocks if "class DampedLeastSquares" in b)
    keep = block.split("J = np.diag")[0]
    ns: dict[str, Any] = {"__name__": "fast_controllers_steering"}
    exec(compile(keep, str(PAGE), "exec"), ns)  # noqa: S102 - the project's own page
    return ns


def user_steering_rates(repeat: int = 3) -> dict[int, dict[str, float]]:
    """``{batch: {law: spacecraft-steps per CPU-second}}`` (module docstring)."""
    from numba import njit

    from liecontrol.control import ConstantAttitude, GeometricPD, gains_from_bandwidth
    from spacecraft import RigidBody, SgcmgActuator, SgcmgPyramid, Spacecraft, simulate
    from spacecraft import _kernels as K
    from spacecraft.steering import PINV_EPS, SingularityRobust
    from spacecraft.steering_kernel import SteeringKernel

    @njit
    def sr_through_seam(t, A, hdot, delta, params, out):  # noqa: ANN001, ANN202
        K.steer_regularised(K.STEER_SR, params, t, A, hdot[0], hdot[1], hdot[2], out)

    class SeamSR(SingularityRobust):
        def fused_kernel(self, cluster: Any) -> SteeringKernel:
            p = np.array([self.lambda0, self.mu, PINV_EPS, 0.0, 0.0, 0.0, 0.0, 0.0])
            return SteeringKernel(sr_through_seam, p)

    ns = _steering_namespace()
    J = np.diag([1200.0, 1000.0, 800.0])
    k_R, k_Omega = gains_from_bandwidth(J, 0.03, 0.9)
    target = ConstantAttitude(np.eye(3))
    laws = {
        "DampedLeastSquares (Python loop)": ns["DampedLeastSquares"](5.0),
        "FastDampedLeastSquares (fused, user kernel)": ns["FastDampedLeastSquares"](5.0),
        "SingularityRobust (fused, built-in)": SingularityRobust(),
        "SingularityRobust through the seam": SeamSR(),
    }
    out: dict[int, dict[str, float]] = {}
    for B, T in ((1, 600.0), (100, 60.0)):
        plants = {
            k: Spacecraft(RigidBody(J), SgcmgActuator(SgcmgPyramid(h0=300.0), law))
            for k, law in laws.items()
        }
        best = dict.fromkeys(laws, np.inf)
        for _ in range(repeat):
            for k, plant in plants.items():
                x0 = plant.initial_state(np.diag([1.0, -1.0, -1.0]), batch=B)
                t0 = time.process_time()
                simulate(plant, GeometricPD(J, k_R, k_Omega), target, x0, t_final=T, dt=0.1,
                         control_period=0.1)  # fmt: skip
                best[k] = min(best[k], time.process_time() - t0)
        out[B] = {k: B * round(T / 0.1) / v for k, v in best.items()}
    return out


def disturbance_rates(repeat: int = 3, t_final: float = 600.0) -> dict[str, float]:
    """``{route: steps per CPU-second}`` (module docstring, ``--disturbance``)."""
    from liecontrol.control import ConstantAttitude, GeometricPD, gains_from_bandwidth
    from liecontrol.lie import so3
    from spacecraft import RigidBody, SgcmgActuator, SgcmgPyramid, Spacecraft, simulate
    from spacecraft.disturbances import ConstantHarmonicTorque, SumOfDisturbances
    from spacecraft.environment import GravityGradientTorque
    from spacecraft.orbit import CircularOrbit
    from spacecraft.surface_forces import (
        AerodynamicTorque,
        ResidualDipoleTorque,
        SolarPressureTorque,
        box_plates,
    )

    class PythonGravityGradient(GravityGradientTorque):
        fused_kernel = None  # the same torque through the Python loop

    class PythonSum(SumOfDisturbances):
        fused_kernel = None

    J = np.diag([1200.0, 1000.0, 800.0])
    orbit = CircularOrbit(n=0.0011, inclination=0.9)
    k_R, k_Omega = gains_from_bandwidth(J, 0.03, 0.9)
    target = ConstantAttitude(np.eye(3))
    dists = {
        "gravity gradient (fused, seam kernel)": GravityGradientTorque(J, orbit),
        "gravity gradient (Python loop)": PythonGravityGradient(J, orbit),
        "no disturbance (fused)": None,
        "GG + constant-harmonic sum (fused, sum kernel)": SumOfDisturbances(
            {"gg": GravityGradientTorque(J, orbit), "harmonic": ConstantHarmonicTorque()}
        ),
        "GG + constant-harmonic sum (Python loop)": PythonSum(
            {"gg": GravityGradientTorque(J, orbit), "harmonic": ConstantHarmonicTorque()}
        ),
    }
    leo = CircularOrbit.from_altitude(450e3, inclination=0.9)
    plates = box_plates((2.0, 1.5, 3.0), offset=(0.05, -0.02, 0.1), absorption=0.7, specular=0.2,
                        diffuse=0.1)  # fmt: skip
    env = {
        "gg": GravityGradientTorque(J, leo),
        "aero": AerodynamicTorque(plates, leo),
        "srp": SolarPressureTorque(plates, leo),
        "dipole": ResidualDipoleTorque([0.5, -0.3, 1.0], leo),
    }
    dists["LEO GG + aero + SRP + dipole (fused, sum kernel)"] = SumOfDisturbances(env)
    dists["LEO GG + aero + SRP + dipole (Python loop)"] = PythonSum(env)
    best = dict.fromkeys(dists, np.inf)
    steps = round(t_final / 0.1)
    for _ in range(repeat):
        for k, d in dists.items():
            plant = Spacecraft(RigidBody(J), SgcmgActuator(SgcmgPyramid(h0=300.0)), disturbance=d)
            x0 = plant.initial_state(so3.exp(np.array([np.pi / 2, 0.0, 0.0])))
            t0 = time.process_time()
            simulate(plant, GeometricPD(J, k_R, k_Omega), target, x0, t_final=t_final, dt=0.1)
            best[k] = min(best[k], time.process_time() - t0)
    return {k: steps / v for k, v in best.items()}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--steering", action="store_true", help="the page's steering law instead")
    p.add_argument("--disturbance", action="store_true", help="the gravity gradient's seam")
    a = p.parse_args(argv)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    if a.disturbance:
        rates = disturbance_rates(a.repeat)
        print(f"steps per CPU-second, best of {a.repeat}; load {load:.1f}")
        for k, v in rates.items():
            print(f"{k:48s} {v:10.3g}")
        return
    if a.steering:
        rates = user_steering_rates(a.repeat)
        print(f"spacecraft-steps per CPU-second, best of {a.repeat}; load {load:.1f}")
        for B, rows in rates.items():
            base = rows["SingularityRobust (fused, built-in)"]
            for k, v in rows.items():
                print(f"B={B:<4d} {k:44s} {v:10.3g}   cost × built-in SR: {base / v:5.2f}")
        return
    res = user_law_rates(a.repeat)
    print(f"simulated steps per CPU-second, best of {a.repeat}; load {load:.1f}")
    for act, rows in res.items():
        base = rows["GeometricPD (fused, built-in)"]
        for k, v in rows.items():
            print(f"{act:6s} {k:44s} {v / 1e3:9.0f} k   cost × built-in GPD: {base / v:5.2f}")


if __name__ == "__main__":
    main()
