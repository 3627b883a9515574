"""Per-step cost of every registered attitude controller in the simulator's loop, against the
large-angle geometric PD, in one process: ``python -m benchmarks.perf_controllers [--scenario
NAME] [--t-final T] [--repeat N]``.

Each controller is built by the registry for the scenario (its tuned gains), on the scenario's
plant, and flies ``simulate`` from the scenario's initial state for ``--t-final`` seconds at the
scenario's step and control period, logging every step, as the suite does. The figure is the
best of ``--repeat`` CPU times per simulated step (``time.process_time``), after one warm-up run
(compilation and cache loading are not counted); the ratio is to ``geometric-pd-large-angle``
timed in the same rounds (the Python-loop controllers in rounds of their own). A run's cost per
step includes the plant's, which depends on the trajectory the law flies (the steering's near-
singular branch, the rate limit), so the column ``law ns`` also times the compiled law alone:
200 000 calls through the seam's function pointer on the scenario's initial state, as the fused
loop calls it. The column ``loop`` says whether the run took the compiled loop (``fused``) or
the Python loop, and why not. The MPC laws stay in the Python loop by design: their OSQP solve
is a Python call.
"""

from __future__ import annotations

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import os  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

__all__ = ["controller_step_costs", "law_call_ns", "main"]

BASELINE = "geometric-pd-large-angle"


def _run(name: str, scenario: Any, t_final: float, log_every: int = 1) -> tuple[Any, str]:
    """A closure running one simulation of controller ``name`` on ``scenario``; and the loop
    it takes."""
    from benchmarks.controllers import ControllerContext, get_controller
    from benchmarks.runner import build_plant, build_reference, initial_state
    from spacecraft import simulate
    from spacecraft._fused import fused_supported

    info = get_controller(name)
    plant = build_plant(scenario.spacecraft, scenario.disturbances)
    ref = build_reference(scenario)
    period = info.control_period or scenario.control_period or scenario.dt
    R0, w0 = initial_state(scenario)
    state = plant.initial_state(R0, w0)
    ctx = ControllerContext(
        spacecraft=scenario.spacecraft,
        control_period=period,
        batch_size=1,
        reference=ref,
        keep_out=scenario.keep_out,  # a constraint law without its cones is another law
        keep_in=scenario.keep_in,
    )
    ctrl = info.factory(ctx)
    ctrl.reset(0.0, 1)
    why: list[str] = []
    ok = fused_supported(plant, ctrl, None, None, False, control_period=period, reasons=why)
    loop = "fused" if ok is not None else f"Python: {why[0] if why else '?'}"

    def once() -> None:
        simulate(
            plant, ctrl, ref, state, t_final, scenario.dt, control_period=period,
            log_every=log_every,
        )  # fmt: skip

    return once, loop


def controller_step_costs(
    scenario_name: str = "stabilisation", t_final: float = 60.0, repeat: int = 5,
    names: list[str] | None = None, sequential: bool = False, log_every: int = 1,
) -> dict[str, tuple[float, float, str]]:  # fmt: skip
    """``{controller: (µs per simulated step, ratio to the baseline, loop)}`` (module
    docstring); controllers that do not apply to the scenario's plant are left out."""
    from benchmarks.controllers import applicable
    from benchmarks.scenarios import get_scenario

    sc = get_scenario(scenario_name)
    names = list(names) if names is not None else [n for n in applicable(sc) if n != BASELINE]
    names = [BASELINE] + [n for n in names if n != BASELINE]
    runs = {n: _run(n, sc, t_final, log_every) for n in names}
    n_steps = round(t_final / sc.dt)
    best = dict.fromkeys(names, np.inf)
    for fn, _ in runs.values():
        fn()  # warm-up: compilation, cache loading
    # rounds alternate the fused controllers; the Python-loop ones (the MPC: 200× slower, its
    # allocations churn the caches) are timed in their own rounds after them
    fused = [n for n in names if runs[n][1] == "fused"]
    for group in (fused, [n for n in names if n not in fused]):
        # sequential: each controller's runs back to back, so its log's memory is reused
        # (interleaved rounds hand every run fresh pages: their first-touch faults scale with
        # the diagnostics' width and are counted in the run's CPU time)
        order = [[n] * repeat for n in group] if sequential else [group] * repeat
        for chunk in order:
            for n in chunk:
                c = time.process_time()
                runs[n][0]()
                best[n] = min(best[n], time.process_time() - c)
    base = best[BASELINE]
    return {n: (1e6 * best[n] / n_steps, best[n] / base, runs[n][1]) for n in names}


def law_call_ns(name: str, scenario_name: str = "stabilisation", calls: int = 200_000) -> float:
    """CPU ns per call of controller ``name``'s compiled law on the scenario's initial state
    (NaN for a controller without a kernel)."""
    import numba
    from numba.core import types

    from benchmarks.controllers import ControllerContext, get_controller
    from benchmarks.runner import build_reference, initial_state
    from benchmarks.scenarios import get_scenario
    from liecontrol.control import kernel as seam

    sc = get_scenario(scenario_name)
    info = get_controller(name)
    ref = build_reference(sc)
    period = info.control_period or sc.control_period or sc.dt
    ctx = ControllerContext(
        spacecraft=sc.spacecraft, control_period=period, batch_size=1, reference=ref,
        keep_out=sc.keep_out, keep_in=sc.keep_in,
    )  # fmt: skip
    ctrl = info.factory(ctx)
    ctrl.reset(0.0, 1)
    hook = getattr(ctrl, "fused_kernel", None)
    spec = hook(1, period) if callable(hook) else None
    if spec is None:
        return float("nan")
    R0, w0 = initial_state(sc)
    r = ref(0.0)
    args = [
        np.ascontiguousarray(np.reshape(R0, (3, 3))), np.ascontiguousarray(np.reshape(w0, 3)),
        np.ascontiguousarray(np.broadcast_to(r.R_d, (3, 3))),
        np.ascontiguousarray(np.broadcast_to(r.omega_d, (3,))),
        np.ascontiguousarray(np.broadcast_to(r.omega_dot_d, (3,))),
        np.ascontiguousarray(spec.params, dtype=np.float64),
        np.ascontiguousarray(spec.state[0], dtype=np.float64).copy(), np.zeros(3),
        np.zeros(int(spec.n_diag)),
    ]  # fmt: skip
    sig = (types.intp, types.FunctionType(seam.LAW_SIGNATURE)) + tuple(
        numba.typeof(a) for a in args
    )
    loop = _law_loop()
    loop.compile(sig)
    entry = loop.overloads[sig].entry_point
    entry(1000, spec.law, *args)
    best = np.inf
    for _ in range(3):
        c = time.process_time()
        entry(calls, spec.law, *args)
        best = min(best, time.process_time() - c)
    return 1e9 * best / calls


def _law_loop() -> Any:
    """A compiled loop calling a law ``n`` times as the fused loop does (unowned views)."""
    import numba

    from spacecraft._fused import unowned_view

    @numba.njit
    def loop(n, law, R, w, Rd, wd, dwd, P, st, u, dg):  # noqa: ANN001, ANN202
        R, w, Rd, wd, dwd = (unowned_view(R), unowned_view(w), unowned_view(Rd),
                             unowned_view(wd), unowned_view(dwd))  # fmt: skip
        P, st, u, dg = unowned_view(P), unowned_view(st), unowned_view(u), unowned_view(dg)
        s = 0.0
        for k in range(n):
            law(0.1 * k, R, w, Rd, wd, dwd, P, st, u, dg)
            s += u[0]
        return s

    return loop


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", default="stabilisation")
    p.add_argument("--t-final", type=float, default=60.0)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument(
        "--log-every", type=int, default=1,
        help="log one row every N steps (default 1, as the suite's single runs)",
    )  # fmt: skip
    p.add_argument(
        "--sequential", action="store_true",
        help="time each controller's runs back to back instead of in alternating rounds",
    )  # fmt: skip
    a = p.parse_args(argv)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    res = controller_step_costs(
        a.scenario, a.t_final, a.repeat, sequential=a.sequential, log_every=a.log_every
    )
    how = "back to back" if a.sequential else "alternating rounds"
    print(
        f"scenario {a.scenario}, {a.t_final:g} s, logging every {a.log_every} step(s), best of "
        f"{a.repeat} CPU times ({how}); "
        f"load {load:.1f}"
    )
    laws = {n: law_call_ns(n, a.scenario) for n in res}
    print(f"{'controller':32s} {'µs/step':>9s} {'× GPD':>7s} {'law ns':>8s} {'× GPD':>7s}  loop")
    for n, (us, ratio, loop) in res.items():
        lr = laws[n] / laws[BASELINE]
        print(f"{n:32s} {us:9.2f} {ratio:7.2f} {laws[n]:8.1f} {lr:7.2f}  {loop}")


if __name__ == "__main__":
    main()
