"""The JAX route against the fused numba loop: ``python -m benchmarks.perf_jax``.

Rigid body (``J = diag(10, 20, 30)`` kg·m²) + large-angle geometric PD (ω_n = 0.3 rad/s,
ζ = 0.9), regulation from Haar-random attitudes, dt = control period = 0.1 s, ``--t-final`` s
(default 60), one log row per control sample on both routes, for each ``--config``:
``ideal`` (ideal torque actuator) and ``sgcmg`` (four-SGCMG pyramid, h₀ = 300 N·m·s, with
singularity-robust steering and the 1 rad/s gimbal-rate limit, steered at every step):

- ``spacecraft.simulate`` (the fused numba loop) and
  :meth:`spacecraft.differentiable.JaxClosedLoop.run` (``jit(vmap(lax.scan))``, the batch
  padded to its bucket as a user's run is) for batches of ``--batch`` spacecraft (default 1,
  1000 and 10 000): spacecraft-steps per wall-second, best of ``--repeat`` runs after a warm-up
  (the machine may be shared: the best run is the least disturbed); the JAX route's first call
  minus its best run is its compile time (a hit in the persistent compilation cache, see
  ``docs/jax.md``, makes it small: set ``LIECONTROL_JAX_CACHE=off`` to time a cold compile);
- the gradient of the cost ∫θ² dt + 0.01 ∫‖u‖² dt with respect to (k_R, k_Ω) over
  ``--grad-batch`` starts (default 64): the time of ``value_and_grad`` in units of one compiled
  forward evaluation of the same cost;
- the memory of that gradient for the SGCMG loop with and without checkpointing of the scan's
  period body (``closed_loop(..., checkpoint=True)``): XLA's own count of the compiled
  program's temporary buffers (``memory_analysis().temp_size_in_bytes``, the peak working set
  beyond inputs and outputs; exact and independent of the machine's load), and its time.

With ``--controllers NAME …`` (or ``all``) it times, instead, each registered controller on
the benchmark's own plant — the ``slew-90`` scenario's SGCMG spacecraft, ``--batch`` members of
its dispersion (each its own start, rate and true inertia), the registry's controller for them,
the scenario's dt and control period, ``--t-final`` s — on both routes: the JAX route's cost per
spacecraft-step against the fused loop's, and against the JAX route's geometric PD (the spread
of the laws' cost on an accelerator-ready route), with each controller's compile time.

Both routes run on one thread (``NUMBA_NUM_THREADS=1``, XLA's CPU client single-threaded)
unless the environment sets otherwise, so the figures are per core. The JAX route needs
``pip install liecontrol[jax]``; on a machine with a GPU, JAX runs there unchanged (set
``JAX_PLATFORMS=cpu`` to compare on the CPU); the first line printed names the device JAX ran
on. Imports only numpy, scipy, numba, jax and this repository (run from the repository root
with ``PYTHONPATH=.``, no install needed).
"""

from __future__ import annotations

import os

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault(
    "XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
)

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks._perf import thread_settings  # noqa: E402
from liecontrol.control import GeometricPD, gains_from_bandwidth  # noqa: E402
from liecontrol.control.reference import ConstantAttitude  # noqa: E402
from liecontrol.lie import so3  # noqa: E402
from spacecraft import RigidBody, Spacecraft, simulate  # noqa: E402
from spacecraft.actuators import IdealTorqueActuator, SgcmgActuator  # noqa: E402
from spacecraft.differentiable import closed_loop, require_jax  # noqa: E402
from spacecraft.steering import SingularityRobust  # noqa: E402

J = np.diag([10.0, 20.0, 30.0])
DT = 0.1
CONFIGS = ("ideal", "sgcmg")


def _setup(t_final: float, config: str = "ideal"):
    kR, kW = gains_from_bandwidth(J, 0.3, 0.9)
    act = IdealTorqueActuator() if config == "ideal" else SgcmgActuator(None, SingularityRobust())
    plant = Spacecraft(RigidBody(J), act)
    ctrl = GeometricPD(J, kR, kW)
    ref = ConstantAttitude(np.eye(3))
    return plant, ctrl, ref, closed_loop(plant, ctrl, ref, t_final, DT)


def _best(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def measure(batch: int, t_final: float, repeat: int, config: str = "ideal") -> dict[str, float]:
    """Seconds per run of each route for ``batch`` spacecraft, and the JAX compile time."""
    plant, ctrl, ref, loop = _setup(t_final, config)
    rng = np.random.default_rng(batch)
    R0 = so3.random(rng, batch)
    state = plant.initial_state(R0)

    def fused() -> None:
        simulate(plant, ctrl, ref, state, t_final, DT, log_every=1)

    t = time.perf_counter()
    run = loop.run(R0)
    first = time.perf_counter() - t
    fused()  # numba's compile (or cache load) is not timed
    jax_s = _best(lambda: loop.run(R0), repeat)
    fused_s = _best(fused, repeat)
    assert not run.diverged.any()
    return {"fused": fused_s, "jax": jax_s, "compile": first - jax_s}


def gradient_cost(batch: int, t_final: float, repeat: int) -> dict[str, float]:
    """Seconds of one forward cost and of its value and gradient, both compiled."""
    jax = require_jax()
    _, ctrl, _, loop = _setup(t_final)
    rng = np.random.default_rng(7)
    R0, w0 = so3.random(rng, batch), np.zeros((batch, 3))
    kR, kW = np.float64(ctrl.k_R), np.float64(ctrl.k_Omega)
    with jax.enable_x64(True):
        forward = jax.jit(loop.cost)
        forward(kR, kW, R0, w0, 0.01).block_until_ready()
        f_s = _best(lambda: forward(kR, kW, R0, w0, 0.01).block_until_ready(), repeat)
    loop.value_and_grad(kR, kW, R0, w0, effort_weight=0.01)
    g_s = _best(lambda: loop.value_and_grad(kR, kW, R0, w0, effort_weight=0.01), repeat)
    return {"forward": f_s, "grad": g_s}


def gradient_memory(batch: int, t_final: float, repeat: int) -> dict[str, dict[str, float]]:
    """Temporary bytes and seconds of the SGCMG loop's compiled value-and-gradient, with and
    without checkpointing (control period 0.2 s = 2 steps)."""
    jax = require_jax()
    out = {}
    rng = np.random.default_rng(7)
    R0, w0 = so3.random(rng, batch), np.zeros((batch, 3))
    for ck in (False, True):
        kR, kW = gains_from_bandwidth(J, 0.3, 0.9)
        plant = Spacecraft(RigidBody(J), SgcmgActuator(None, SingularityRobust()))
        loop = closed_loop(plant, GeometricPD(J, kR, kW), ConstantAttitude(np.eye(3)), t_final,
                           DT, 2 * DT, checkpoint=ck)  # fmt: skip
        with jax.enable_x64(True):
            fn = jax.jit(jax.value_and_grad(loop.cost, argnums=(0, 1)))
            args = (np.float64(kR), np.float64(kW), R0, w0, 0.01)
            mem = fn.lower(*args).compile().memory_analysis()
            jax.block_until_ready(fn(*args))
            sec = _best(lambda fn=fn, args=args: jax.block_until_ready(fn(*args)), repeat)
        out["checkpoint" if ck else "stored"] = {"temp": float(mem.temp_size_in_bytes), "s": sec}
    return out


def controller_table(
    names: list[str], batch: int, t_final: float, repeat: int
) -> dict[str, dict[str, float]]:
    """Seconds per run of each route for each registered controller on ``slew-90``'s plant
    (``batch`` dispersed members), and the JAX compile time."""
    from benchmarks.controllers import ControllerContext, make_controller
    from benchmarks.gradient_tuning import training_batch
    from benchmarks.runner import build_reference
    from benchmarks.scenarios import get_scenario

    sc = get_scenario("slew-90").with_duration(t_final)
    members, plant, R0, w0 = training_batch(sc, batch, 1)
    ref = build_reference(sc)
    ctx = ControllerContext(spacecraft=sc.spacecraft, control_period=sc.control_period,
                            batch_size=batch, reference=ref,
                            q_hint=np.stack([m.initial_quaternion for m in members]))  # fmt: skip
    state = plant.initial_state(R0, w0)
    every = round(sc.control_period / sc.dt)
    out = {}
    for name in names:
        ctrl = make_controller(name, ctx)
        loop = closed_loop(plant, ctrl, ref, t_final, sc.dt, sc.control_period)

        def fused(ctrl=ctrl) -> None:
            simulate(plant, ctrl, ref, state, t_final, sc.dt, control_period=sc.control_period,
                     log_every=every)  # fmt: skip

        t = time.perf_counter()
        run = loop.run(R0, w0)
        first = time.perf_counter() - t
        fused()
        jax_s = _best(lambda loop=loop: loop.run(R0, w0), repeat)
        out[name] = {"fused": _best(fused, repeat), "jax": jax_s, "compile": first - jax_s,
                     "diverged": float(run.diverged.sum())}  # fmt: skip
    return out


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--batch", type=int, nargs="+", default=[1, 1000, 10_000])
    p.add_argument("--config", choices=CONFIGS, nargs="+", default=list(CONFIGS))
    p.add_argument("--t-final", type=float, default=60.0)
    p.add_argument("--grad-batch", type=int, default=64)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--controllers", nargs="+", default=None,
                   help="registry names (or 'all'): the per-controller table instead")  # fmt: skip
    a = p.parse_args(argv)
    jax = require_jax()
    steps = round(a.t_final / DT)
    dev = jax.devices()[0]
    print(f"jax {jax.__version__} ran on {jax.default_backend()}: {dev} ({dev.device_kind}); "
          f"{thread_settings()} NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}")  # fmt: skip
    if a.controllers is not None:
        _print_controllers(a)
        return
    print(f"{steps} steps of {DT} s; spacecraft-steps per second (best of {a.repeat})")
    print(f"{'config':>6} {'B':>6} {'fused numba':>12} {'JAX':>12} {'JAX/fused time':>15} "
          f"{'compile s':>10}")  # fmt: skip
    for config in a.config:
        for B in a.batch:
            r = measure(B, a.t_final, a.repeat, config)
            print(f"{config:>6} {B:>6} {B * steps / r['fused']:>12.3g} "
                  f"{B * steps / r['jax']:>12.3g} {r['jax'] / r['fused']:>15.2f} "
                  f"{r['compile']:>10.2f}", flush=True)  # fmt: skip
    g = gradient_cost(a.grad_batch, a.t_final, a.repeat)
    ratio = g["grad"] / g["forward"]
    print(f"gradient over {a.grad_batch} starts: forward {g['forward'] * 1e3:.1f} ms, value and "
          f"gradient {g['grad'] * 1e3:.1f} ms = {ratio:.2f} forward passes")  # fmt: skip
    m = gradient_memory(a.grad_batch, a.t_final, a.repeat)
    for k, v in m.items():
        print(f"SGCMG gradient over {a.grad_batch} starts, {k:>10}: XLA temporaries "
              f"{v['temp'] / 2**20:.1f} MiB, {v['s'] * 1e3:.1f} ms")  # fmt: skip


def _print_controllers(a: argparse.Namespace) -> None:
    from benchmarks.controllers import applicable, get_controller
    from benchmarks.scenarios import get_scenario

    sc = get_scenario("slew-90")
    names = a.controllers
    if names == ["all"]:
        names = [n for n in applicable(sc) if get_controller(n).batched]
    names = [n for n in names if n != "geometric-pd-large-angle"]
    B = a.batch[0]
    print(f"slew-90's SGCMG plant, {B} dispersed members, {a.t_final} s; ns per spacecraft-step "
          f"(best of {a.repeat}); 'vs PD': JAX cost over the JAX geometric PD's")  # fmt: skip
    print(f"{'controller':>28} {'fused ns':>9} {'JAX ns':>9} {'JAX/fused':>9} {'vs PD':>6} "
          f"{'compile s':>9}")  # fmt: skip
    steps = round(a.t_final / sc.dt)
    base = None
    for name in ["geometric-pd-large-angle", *names]:
        try:
            r = controller_table([name], B, a.t_final, a.repeat)[name]
        except ValueError as exc:  # no array law (the MPC): named, not timed
            print(f"{name:>28} not on the JAX route: {str(exc)[:70]}")
            continue
        f_ns, j_ns = (1e9 * r[k] / (B * steps) for k in ("fused", "jax"))
        base = j_ns if base is None else base
        print(f"{name:>28} {f_ns:>9.0f} {j_ns:>9.0f} {j_ns / f_ns:>9.2f} {j_ns / base:>6.2f} "
              f"{r['compile']:>9.1f}" + (f"  ({r['diverged']:.0f} diverged)" if r["diverged"]
                                         else ""), flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
