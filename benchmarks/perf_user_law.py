"""A user's ``@njit`` law through the kernel seam against its Python twin and the built-in
geometric PD, in one process: ``python -m benchmarks.perf_user_law [--repeat N] [--steering]
[--disturbance] [--same-law]``.

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

``--same-law``: the page's geometric PD written by hand from :mod:`liecontrol.kernels`
(``MyGeometricPD``, the same arithmetic as the built-in ``GeometricPD``) against the built-in,
the large-angle error with matrix gains, a 90° rest-to-rest slew: what the seam costs a user's
law that does what a built-in law does (one spacecraft, 600 s at dt = 0.1 s, control and
logging at every step, steps per CPU-second).

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
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

__all__ = ["disturbance_rates", "main", "same_law_rates", "user_law_rates", "user_steering_rates"]

PAGE = Path(__file__).resolve().parents[1] / "docs" / "fast_controllers.md"


def _page_namespace(marker: str = "pi_law", stop: str = "slow = simulate(") -> dict[str, Any]:
    """The definitions of the page's code block that defines ``marker`` (default: the first
    block's controllers and ``pi_law``), up to the line ``stop`` (not the page's own runs)."""
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
    block = next(b for b in blocks if f"def {marker}(" in b)
    keep = block.split(stop)[0]
    ns: dict[str, Any] = {"__name__": "fast_controllers_page"}
    exec(compile(keep, str(PAGE), "exec"), ns)  # noqa: S102 - the project's own page
    return ns


def _rates_on_both_plants(
    controllers: Callable[[np.ndarray], dict[str, Any]], repeat: int, t_final: float
) -> dict[str, dict[str, float]]:
    """``{actuator: {name: steps per CPU-second}}`` of ``controllers(J)`` on the ideal torque
    actuator and the SGCMG pyramid with SR steering, a 90° rest-to-rest slew, alternated rounds
    after a warm-up; a name with ``Python`` flies a tenth of ``t_final`` (≈ 10× slower)."""
    from liecontrol.control import ConstantAttitude
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

    J = np.diag([1200.0, 1000.0, 800.0])
    target = ConstantAttitude(so3.exp(np.array([0.0, 0.0, np.pi / 2])))
    out: dict[str, dict[str, float]] = {}
    for act_name, act in (
        ("ideal", IdealTorqueActuator()),
        ("sgcmg", SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust())),
    ):
        plant = Spacecraft(RigidBody(J), act)
        x0 = plant.initial_state(np.eye(3))
        ctrls = controllers(J)
        steps = round(t_final / 0.1)
        best = dict.fromkeys(ctrls, np.inf)
        for c in ctrls.values():
            simulate(plant, c, target, x0, t_final=10.0, dt=0.1)  # warm-up
        for _ in range(repeat):
            for k, c in ctrls.items():
                T = t_final / 10 if "Python" in k else t_final
                t0 = time.process_time()
                simulate(plant, c, target, x0, t_final=T, dt=0.1)
                best[k] = min(best[k], (time.process_time() - t0) / (steps * T / t_final))
        out[act_name] = {k: 1.0 / v for k, v in best.items()}
    return out


def user_law_rates(repeat: int = 5, t_final: float = 600.0) -> dict[str, dict[str, float]]:
    """``{actuator: {loop: steps per CPU-second}}`` (module docstring)."""
    from liecontrol.control import GeometricPD

    ns = _page_namespace()
    return _rates_on_both_plants(
        lambda J: {
            "PIController (Python loop)": ns["PIController"](300.0, 1500.0, 5.0),
            "FastPIController (fused, user's @njit law)": ns["FastPIController"](
                300.0, 1500.0, 5.0
            ),
            "GeometricPD (fused, built-in)": GeometricPD(J, 300.0, 1500.0),
        },
        repeat,
        t_final,
    )


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


def same_law_rates(repeat: int = 5, t_final: float = 600.0) -> dict[str, dict[str, float]]:
    """``{actuator: {law: steps per CPU-second}}`` for ``--same-law`` (module docstring)."""
    from liecontrol.control import GeometricPD
    from liecontrol.control.geometric_pd import gains_from_bandwidth

    ns = _page_namespace("my_pd_law", "J = np.diag(")

    def controllers(J: np.ndarray) -> dict[str, Any]:
        K_R, K_W = gains_from_bandwidth(J, 0.05, 0.9, error="large_angle", matrix=True)
        return {
            "MyGeometricPD (user's law from liecontrol.kernels)": ns["MyGeometricPD"](J, K_R, K_W),
            "GeometricPD (built-in)": GeometricPD(J, K_R, K_W),
        }

    return _rates_on_both_plants(controllers, repeat, t_final)


def _print_per_actuator(
    rates: dict[str, dict[str, float]], base_name: str, repeat: int, load: float
) -> None:
    print(f"simulated steps per CPU-second, best of {repeat}; load {load:.1f}")
    for act, rows in rates.items():
        base = rows[base_name]
        for k, v in rows.items():
            print(f"{act:6s} {k:52s} {v / 1e3:9.0f} k   cost × {base_name}: {base / v:5.2f}")


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--steering", action="store_true", help="the page's steering law instead")
    p.add_argument("--disturbance", action="store_true", help="the gravity gradient's seam")
    p.add_argument(
        "--same-law", action="store_true", help="the page's geometric PD from liecontrol.kernels"
    )
    a = p.parse_args(argv)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    if a.same_law:
        _print_per_actuator(same_law_rates(a.repeat), "GeometricPD (built-in)", a.repeat, load)
        return
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
    _print_per_actuator(user_law_rates(a.repeat), "GeometricPD (fused, built-in)", a.repeat, load)


if __name__ == "__main__":
    main()
