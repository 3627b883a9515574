"""Wall time of one MPC control step: ``python -m benchmarks.perf_mpc``.

One control step = ``SO3MPC.command`` for one spacecraft: input checks, error state, stage-0 LGVI
prediction, linearisation along the reference, QP update and solve (§8.2 "wall
time per control step"). Horizon N = 20, 6 error states, 3 inputs, MPC period 1 s, SGCMG-bus
inertia, |u_i| ≤ 20 N·m. The states are recorded closed loops (ideal rigid body integrated with
the LGVI at the MPC period, flown by the OSQP MPC), each backend steps through the same states in
order, so warm starts are as in closed loop:

- ``regulation``: 90° rest-to-rest (constant QP matrix);
- ``tracking``: constant-rate slew (time-varying A_k, B_k, but the same every step: constant
  QP matrix);
- ``tracking_varying``: a slew whose rate varies sinusoidally (Ω̇_d ≠ 0): the linearisation and
  the QP matrix change every step (OSQP refactorises its KKT matrix every step);
- ``gimbal_rate``: regulation with the CMG gimbal-rate constraint of
  :func:`spacecraft.mpc_constraints.cmg_gimbal_rate_constraint` (4 more rows per stage, the
  constraint matrix follows the gimbal angles: refactorisation every step).

Reported per scenario: median and 95th percentile of the wall time (``perf_counter``) and of
the thread CPU time (``thread_time``: on a loaded machine the wall-time tail is dominated by
the OS scheduler preempting the process — 4 ms time slices — which CPU time does not count),
OSQP's median iterations, the cvxpy formulation's wall time, the cvxpy/OSQP ratio of the medians
and GeometricPD's per-step time for reference. The first command after ``reset`` (it builds /
compiles the QP) is not timed. Wall-clock numbers depend on the machine and its load.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from liecontrol.control import AttitudeReference, AttitudeState, GeometricPD, gains_from_bandwidth
from liecontrol.control.mpc import SO3MPC
from liecontrol.integrators import lgvi_step
from liecontrol.lie import so3
from spacecraft import SgcmgActuator, SgcmgPyramid
from spacecraft.mpc_constraints import cmg_gimbal_rate_constraint

J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
DT = 1.0
N = 20
U_MAX = 20.0
Q = [200.0] * 3 + [2.0e5] * 3
R = [1.0] * 3
CLUSTER = SgcmgPyramid(h0=300.0, gimbal_rate_limit=1.0)
GIMBAL_RATE = 0.03  # rad/s: binds during the large-angle part of the manoeuvre
SCENARIOS = ("regulation", "tracking", "tracking_varying", "gimbal_rate")


def _extra(kind: str):
    return cmg_gimbal_rate_constraint(CLUSTER, GIMBAL_RATE) if kind == "gimbal_rate" else None


def _mpc(backend: str, kind: str = "regulation") -> SO3MPC:
    return SO3MPC(J, N, DT, Q, R, U_MAX, backend=backend, extra_constraints=_extra(kind))


def _slew(t: float) -> AttitudeReference:
    """Constant-rate slew about a fixed axis (ω_d = 0.01 rad/s)."""
    w = 0.01 * np.array([0.0, 0.6, 0.8])
    return AttitudeReference(so3.exp(t * w), w, np.zeros(3))


def _wobble(t: float) -> AttitudeReference:
    """R_d = exp(φ(t) a), φ = 0.5 sin(0.02 t): rate and acceleration vary every step."""
    a = np.array([0.0, 0.6, 0.8])
    return AttitudeReference(
        so3.exp(0.5 * np.sin(0.02 * t) * a),
        0.01 * np.cos(0.02 * t) * a,
        -2e-4 * np.sin(0.02 * t) * a,
    )


def _regulation(t: float) -> AttitudeReference:
    return AttitudeReference.regulation(np.eye(3))


def _record(kind: str, steps: int) -> list[tuple[float, AttitudeState, AttitudeReference]]:
    """States of a closed loop flown by the OSQP MPC on the ideal rigid body (LGVI at DT); for
    ``gimbal_rate`` the gimbal angles follow the plant's steering law (Euler steps of δ̇)."""
    ref_fn = {"tracking": _slew, "tracking_varying": _wobble}.get(kind, _regulation)
    if kind in ("regulation", "gimbal_rate"):
        Rk = so3.exp(np.deg2rad(90.0) * np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0))
    else:
        Rk = so3.exp(np.array([0.3, -0.2, 0.1]))
    wk = np.zeros(3)
    act = SgcmgActuator(CLUSTER)
    delta = np.deg2rad([[45.0, -45.0, 45.0, -45.0]])
    ctrl = _mpc("osqp", kind)
    ctrl.reset(0.0, 1)
    out = []
    for k in range(steps):
        t = k * DT
        gimbals = delta.copy() if kind == "gimbal_rate" else None
        h = CLUSTER.momentum(delta) if kind == "gimbal_rate" else None
        st = AttitudeState(Rk[None], wk[None], h, gimbals)
        ref = ref_fn(t)
        out.append((t, st, ref))
        u = ctrl.command(t, st, ref)[0]
        if kind == "gimbal_rate":
            delta = delta + DT * act.command(u[None], wk[None], delta, t).delta_dot
        Rk, Pi = lgvi_step(Rk, J @ wk, u, u, DT, J)
        wk = np.linalg.solve(J, Pi)
    return out


def _time(ctrl, states, repeat: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wall and thread-CPU time [s] of each timed step, and the solver iterations."""
    wall, cpu, its = [], [], []
    for _ in range(repeat):
        ctrl.reset(0.0, 1)
        ctrl.command(*states[0])  # builds/compiles the QP: not a control step
        for t, st, ref in states[1:]:
            c0 = time.thread_time()
            t0 = time.perf_counter()
            ctrl.command(t, st, ref)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.thread_time() - c0)
            its.append(ctrl.diagnostics().get("iterations", np.zeros(1))[0])
    return np.array(wall), np.array(cpu), np.array(its)


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=120, help="control steps per recorded run")
    p.add_argument("--repeat", type=int, default=3, help="passes over the recorded states")
    p.add_argument("--scenarios", nargs="+", default=list(SCENARIOS), choices=SCENARIOS)
    args = p.parse_args(argv)
    k_R, k_W = gains_from_bandwidth(J, 0.03, 0.9, matrix=True)
    results: dict[str, dict[str, float]] = {}
    for kind in args.scenarios:
        states = _record(kind, args.steps)
        row: dict[str, float] = {}
        for name, ctrl in (
            ("osqp", _mpc("osqp", kind)),
            ("cvxpy", _mpc("cvxpy", kind)),
            ("geometric_pd", GeometricPD(J, k_R, k_W)),
        ):
            wall, cpu, its = _time(ctrl, states, args.repeat)
            row[f"{name} median [ms]"] = 1e3 * float(np.median(wall))
            row[f"{name} p95 [ms]"] = 1e3 * float(np.percentile(wall, 95))
            if name == "osqp":
                row["osqp cpu median [ms]"] = 1e3 * float(np.median(cpu))
                row["osqp cpu p95 [ms]"] = 1e3 * float(np.percentile(cpu, 95))
                row["osqp iterations median"] = float(np.median(its))
        row["cvxpy/osqp median ratio"] = row["cvxpy median [ms]"] / row["osqp median [ms]"]
        results[kind] = row
    print(
        f"MPC control step, N = {N}, 6 states, 3 inputs, T = {DT} s "
        f"({args.steps - 1} timed steps × {args.repeat} passes)"
    )
    first = next(iter(results.values()))
    print(f"{'':<28}" + "".join(f"{k:>18}" for k in results))
    for key in first:
        print(f"{key:<28}" + "".join(f"{results[k][key]:>18.3f}" for k in results))
    return results


if __name__ == "__main__":
    main()
