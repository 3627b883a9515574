"""Wall time of one MPC control step: ``python -m benchmarks.perf_mpc``.

One control step = ``SO3MPC.command`` for one spacecraft: error state, stage-0 LGVI prediction,
linearisation along the reference, QP update and solve (SPEC §6 item 4, §8.2 "wall time per
control step"). Horizon N = 20, 6 error states, 3 inputs, MPC period 1 s, seed-000 inertia,
|u_i| ≤ 20 N·m. The states are a recorded closed-loop trajectory (ideal rigid body integrated
with the LGVI at the MPC period) of a 90° rest-to-rest manoeuvre (regulation) and of a slewing
reference (tracking, time-varying A_k, B_k); each backend steps through the same states in
order, so warm starts are as in closed loop. Prints median and 95th percentile per backend, the
cvxpy/OSQP ratio, and GeometricPD's per-step time for reference. Wall-clock numbers depend on
the machine and its load.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from liecontrol.control import AttitudeReference, AttitudeState, GeometricPD, gains_from_bandwidth
from liecontrol.control.mpc import SO3MPC
from liecontrol.integrators import lgvi_step
from liecontrol.lie import so3

J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
DT = 1.0
N = 20
U_MAX = 20.0
Q = [200.0] * 3 + [2.0e5] * 3
R = [1.0] * 3


def _mpc(backend: str) -> SO3MPC:
    return SO3MPC(J, N, DT, Q, R, U_MAX, backend=backend)


def _slew(t: float) -> AttitudeReference:
    """Constant-rate slew about a fixed axis (ω_d = 0.01 rad/s)."""
    w = 0.01 * np.array([0.0, 0.6, 0.8])
    return AttitudeReference(so3.exp(t * w), w, np.zeros(3))


def _record(kind: str, steps: int) -> list[tuple[float, AttitudeState, AttitudeReference]]:
    """States of a closed loop flown by the OSQP MPC on the ideal rigid body (LGVI at DT)."""
    if kind == "regulation":
        ref_fn = lambda t: AttitudeReference.regulation(np.eye(3))  # noqa: E731
        Rk = so3.exp(np.deg2rad(90.0) * np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0))
        wk = np.zeros(3)
    else:
        ref_fn = _slew
        Rk = so3.exp(np.array([0.3, -0.2, 0.1]))
        wk = np.zeros(3)
    ctrl = _mpc("osqp")
    ctrl.reset(0.0, 1)
    out = []
    for k in range(steps):
        t = k * DT
        st = AttitudeState(Rk[None], wk[None])
        ref = ref_fn(t)
        out.append((t, st, ref))
        u = ctrl.command(t, st, ref)[0]
        Rk, Pi = lgvi_step(Rk, J @ wk, u, u, DT, J)
        wk = np.linalg.solve(J, Pi)
    return out


def _time(ctrl, states, repeat: int) -> np.ndarray:
    times = []
    for _ in range(repeat):
        ctrl.reset(0.0, 1)
        for t, st, ref in states:
            t0 = time.perf_counter()
            ctrl.command(t, st, ref)
            times.append(time.perf_counter() - t0)
    return np.array(times)


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=120, help="control steps per recorded run")
    p.add_argument("--repeat", type=int, default=3, help="passes over the recorded states")
    args = p.parse_args(argv)
    k_R, k_W = gains_from_bandwidth(J, 0.03, 0.9, matrix=True)
    results: dict[str, dict[str, float]] = {}
    for kind in ("regulation", "tracking"):
        states = _record(kind, args.steps)
        row: dict[str, float] = {}
        for name, ctrl in (
            ("osqp", _mpc("osqp")),
            ("cvxpy", _mpc("cvxpy")),
            ("geometric_pd", GeometricPD(J, k_R, k_W)),
        ):
            ctrl.reset(0.0, 1)
            ctrl.command(*states[0])  # first call builds/compiles the QP: not a control step
            ts = _time(ctrl, states, args.repeat)
            row[f"{name} median [ms]"] = 1e3 * float(np.median(ts))
            row[f"{name} p95 [ms]"] = 1e3 * float(np.percentile(ts, 95))
        row["cvxpy/osqp median ratio"] = row["cvxpy median [ms]"] / row["osqp median [ms]"]
        results[kind] = row
    print(
        f"MPC control step, N = {N}, 6 states, 3 inputs, T = {DT} s "
        f"({args.steps} steps × {args.repeat} passes)"
    )
    header = f"{'':<28}" + "".join(f"{k:>14}" for k in results)
    print(header)
    for key in results["regulation"]:
        print(f"{key:<28}" + "".join(f"{results[k][key]:>14.3f}" for k in results))
    return results


if __name__ == "__main__":
    main()
