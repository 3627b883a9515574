"""Where the batched fused loop's time goes: ``python -m benchmarks.perf_batch_floor [--batch B]``.

The benchmark loop of :mod:`benchmarks.perf_closed_loop` (SGCMG pyramid, SR steering, large-angle
geometric PD at every step, dt = 0.1 s, no disturbance) for a batch of ``--batch`` spacecraft.
The arguments :func:`spacecraft._fused._fused_loop` receives are captured from one
:func:`spacecraft.simulate` call; then compiled measurement harnesses (below; they call the
library kernels, they hold no formula of their own) run each part of one loop step over the batch
the way the fused loop does, ``--reps`` times:

- ``law (pointer)``: the controller's law through the seam's function pointer, per spacecraft,
  with the arrays as the fused loop passes them: views that own nothing
  (:func:`spacecraft._fused.unowned_view`), so no reference counting;
- ``law (pointer, owned views)``: the same with ordinary (reference-counted) views, as the loop
  passed them before: the price of numba's reference counting is the difference;
- ``law (direct)``: the same law called directly (numba dispatcher type, inlinable): the price
  of the pointer is the difference;
- ``empty law (pointer)``: a law that only writes its torque, through the pointer: the price of
  the call itself (ten array arguments, each a per-spacecraft view);
- ``law arithmetic``: the geometric PD's kernel (``geometric_pd_one``) called from the harness
  with ready 3×3 parameter arrays, where numba inlines it: the law without the seam's call and
  its parameter views;
- ``command``: the SGCMG command (momentum, Jacobian, SR steering, rate limit) per spacecraft,
  on unowned views as the loop (so is the step below);
  ``command (constant code)``: the same with the steering code a constant at the call site (no
  gain measured, so the fused loop keeps the runtime code there);
- ``RKMK4 step``: the integration step (4 field evaluations, dexp⁻¹, exp) per spacecraft, as
  the fused loop calls it (actuator and disturbance codes constants at the call site);
- ``RKMK4 step (runtime codes)``: the same with the codes as runtime values (the loop before
  its call sites were specialised): the price of runtime branching;
- ``finite check``: the non-finite state test over the batch;
- ``whole loop``: :func:`_fused_loop` itself (logging every 600th step; since the loop runs
  each spacecraft's steps before the next, it is not the sum of these batch-inner parts).

Figures are ns per spacecraft-step, best of ``--repeat`` timings (the machine is shared), per
CPU-second of this process; the parts and the whole are alternated in one process. The
arithmetic per spacecraft-step of the same loop (operation count) is printed with them: see
docs/performance.md, "The batched loop and its floor".
"""

from __future__ import annotations

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402
from numba.core import types  # noqa: E402

from benchmarks._perf import thread_settings  # noqa: E402
from benchmarks.perf_closed_loop import _setup  # noqa: E402
from liecontrol._kernels.geometric_pd import geometric_pd_one  # noqa: E402
from liecontrol.control import kernel as seam  # noqa: E402
from spacecraft import _fused, simulate  # noqa: E402
from spacecraft import _kernels as K  # noqa: E402
from spacecraft._fused import unowned_view  # noqa: E402

#: operation count per spacecraft-step of the benchmark loop (hand count of the kernels'
#: arithmetic: + − × ÷ each one flop; transcendental calls listed apart), docs/performance.md
FLOPS = {
    "geometric PD (large-angle, θ ≤ π/2)": (190, "1 sqrt, 2 div"),
    "SGCMG command (h, A, q, SR steering, rate limit)": (257, "4 sin/cos pairs, 1 exp"),
    "RKMK4: 3 × (h, Aδ̇) 104, 4 × (ω × h 12, Euler 42, +3)": (540, "8 sin/cos pairs"),
    "RKMK4: stage states, 3 dexp⁻¹, combination": (223, ""),
    "RKMK4: exp (Rodrigues, θ ≤ π/2 polynomials) and R·exp": (110, ""),
    "non-finite check": (16, ""),
}


def capture_args(batch: int, t_final: float) -> tuple[tuple, int]:
    """The arguments of one :func:`_fused_loop` call of the benchmark loop, and the law's
    position among them."""
    got: dict[str, Any] = {}
    orig = _fused._loop_entry

    def spy(args: tuple, law_index: int, *rest: Any, **kw: Any) -> Any:
        got["args"], got["law_index"] = args, law_index
        return orig(args, law_index, *rest, **kw)

    _fused._loop_entry = spy
    try:
        plant, ctrl, ref, s0 = _setup(batch, np.random.default_rng(0))
        simulate(plant, ctrl, ref, s0, t_final, 0.1, log_every=600)
    finally:
        _fused._loop_entry = orig
    return got["args"], got["law_index"]


# ----------------------------------------------------------------- measurement harnesses
@numba.njit
def _law_part(reps, law, R, x, ref_R, ref_w, ref_dw, cparams, cstate, u_cmd, diag, unowned):  # noqa: ANN001, ANN202
    if unowned:  # as the fused loop passes them: views without reference counts
        R, x, cparams = unowned_view(R), unowned_view(x), unowned_view(cparams)
        ref_R, ref_w, ref_dw = unowned_view(ref_R), unowned_view(ref_w), unowned_view(ref_dw)
        cstate, u_cmd, diag = unowned_view(cstate), unowned_view(u_cmd), unowned_view(diag)
    for _ in range(reps):
        for b in range(R.shape[0]):
            rb = b if ref_R.shape[1] > 1 else 0
            law(0.0, R[b], x[b, :3], ref_R[0, rb], ref_w[0, rb], ref_dw[0, rb], cparams,
                cstate[b], u_cmd[b], diag[b])  # fmt: skip


@numba.njit
def _empty_law(t, R, w, R_d, w_d, dw_d, params, state, M_out, diag_out):  # noqa: ANN001, ANN202
    M_out[0] = params[0]


@numba.njit
def _pd_part(reps, R, x, ref_R, ref_w, ref_dw, P, u_cmd, diag):  # noqa: ANN001, ANN202
    for _ in range(reps):
        for b in range(R.shape[0]):
            rb = b if ref_R.shape[1] > 1 else 0
            geometric_pd_one(0, P[0], P[1], P[2], P[3], R[b], x[b, :3], ref_R[0, rb],
                             ref_w[0, rb], ref_dw[0, rb], u_cmd[b], diag[b])  # fmt: skip


@numba.njit
def _command_part(reps, S0, C0, steer, sp, rate_limit, u_cmd, x, specialise):  # noqa: ANN001, ANN202
    B, n = x.shape
    held_own = np.zeros((B, n - 3))
    scratch = np.empty(3 + 3 * (n - 3) + B * 2 * (n - 3))
    trig_own = scratch[3 + 3 * (n - 3) :].reshape((B, 2, n - 3))
    # unowned views, as the fused loop uses (the owners live to the return)
    S0, C0, sp, u_cmd, x = (unowned_view(S0), unowned_view(C0), unowned_view(sp),
                            unowned_view(u_cmd), unowned_view(x))  # fmt: skip
    held, raw = unowned_view(held_own), unowned_view(scratch)
    hd = raw[:3]
    A = raw[3 : 3 + 3 * (n - 3)].reshape((3, n - 3))
    trig = raw[3 + 3 * (n - 3) :].reshape((B, 2, n - 3))
    s = 0
    for _ in range(reps):
        for b in range(B):
            if specialise and steer == K.STEER_SR:  # the SR code a constant at the call site
                s += K.sgcmg_command(
                    S0, C0, K.STEER_SR, sp, K.no_steering, rate_limit, u_cmd[b], x[b, :3],
                    x[b, 3:], 0.0, held[b], hd, A, trig[b, 0], trig[b, 1],
                )  # fmt: skip
            else:  # as the fused loop calls it
                s += K.sgcmg_command(
                    S0, C0, steer, sp, K.no_steering, rate_limit, u_cmd[b], x[b, :3], x[b, 3:],
                    0.0, held[b], hd, A, trig[b, 0], trig[b, 1],
                )  # fmt: skip
    return s, held_own, trig_own


@numba.njit
def _step_part(reps, act, J, J_inv, S0, C0, dist, dp, dfn, dpk, R, x, held, trig, dt, specialise):  # noqa: ANN001, ANN202
    B, n = x.shape
    R_own = np.empty_like(R)
    x_own = np.empty_like(x)
    work_own = np.empty(7 * n + 15)
    # unowned views, as the fused loop uses (the owners live to the return)
    J, J_inv, S0, C0, dp = (unowned_view(J), unowned_view(J_inv), unowned_view(S0),
                            unowned_view(C0), unowned_view(dp))  # fmt: skip
    R, x, held, trig = unowned_view(R), unowned_view(x), unowned_view(held), unowned_view(trig)
    R_next, x_next, work = unowned_view(R_own), unowned_view(x_own), unowned_view(work_own)
    for _ in range(reps):
        for b in range(B):
            for i in range(n - 3):
                work[5 * n + i] = trig[b, 0, i]
                work[6 * n + i] = trig[b, 1, i]
            if specialise and act == K.ACT_SGCMG and dist == K.DIST_NONE:  # as the fused loop
                K.rkmk4_step(
                    K.ACT_SGCMG, J[0], J_inv[0], S0, C0, K.DIST_NONE, dp, dfn, dpk[0], False, 0.0,
                    R[b], x[b], held[b], dt, R_next[b], x_next[b], work, True,
                )  # fmt: skip
            else:
                K.rkmk4_step(
                    act, J[0], J_inv[0], S0, C0, dist, dp, dfn, dpk[0], False, 0.0, R[b], x[b],
                    held[b], dt, R_next[b], x_next[b], work, True,
                )  # fmt: skip
    return R_own, x_own, work_own


@numba.njit
def _check_part(reps, R, x):  # noqa: ANN001, ANN202
    ok = 0
    for _ in range(reps):
        total = 0.0
        for b in range(R.shape[0]):
            for i in range(x.shape[1]):
                total += x[b, i]
            for i in range(3):
                for j in range(3):
                    total += R[b, i, j]
        ok += np.isfinite(total)
    return ok


def _with_law_pointer(disp: Any, args: tuple, law_index: int) -> Any:
    sig = tuple(
        types.FunctionType(seam.LAW_SIGNATURE) if i == law_index else numba.typeof(a)
        for i, a in enumerate(args)
    )
    disp.compile(sig)
    return disp.overloads[sig].entry_point


def _best(fn: Any, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        c = time.process_time()
        fn()
        best = min(best, time.process_time() - c)
    return best


def breakdown(batch: int, reps: int, repeat: int) -> dict[str, float]:
    """ns per spacecraft-step of each part (and the whole loop) at this batch size."""
    n_steps = reps
    args, li = capture_args(batch, n_steps * 0.1)
    (_, t0, dt, every, log_every, R, x, act, J, Ji, S0, C0, dist, dp, dfn, dpk, _datt, clip_on,
     clip, steer, sp, _steer_fn, limit, law, cparams, cstate, idx, ref_R, ref_w, ref_dw,
     *logs) = args  # fmt: skip
    R = np.ascontiguousarray(R)
    x = np.ascontiguousarray(x)
    u = np.zeros((batch, 3))
    diag = np.zeros((batch, int(logs[12].shape[1])))  # log_t … log_diag, then diag
    law_args = (reps, law, R, x, ref_R, ref_w, ref_dw, cparams, cstate, u, diag, True)
    assert cparams[0] == 0.0  # the large-angle error
    P = np.ascontiguousarray(cparams[1:37].reshape((4, 3, 3)))
    law_ptr = _with_law_pointer(_law_part, law_args, 1)
    empty_args = (reps, _empty_law, *law_args[2:])
    owned_args = (*law_args[:-1], False)
    law(0.0, R[0], x[0, :3], ref_R[0, 0], ref_w[0, 0], ref_dw[0, 0], cparams, cstate[0], u[0],
        diag[0])  # fmt: skip
    _, held, trig = _command_part(1, S0, C0, steer, sp, limit, u, x, False)
    loop = _fused._loop_entry(args, li)

    def whole() -> None:
        a = list(args)
        a[5], a[6] = R.copy(), x.copy()
        loop(*a)

    parts = {
        "law (pointer)": lambda: law_ptr(*law_args),
        "law (pointer, owned views)": lambda: law_ptr(*owned_args),
        "law (direct)": lambda: _law_part(*law_args),
        "empty law (pointer)": lambda: law_ptr(*empty_args),
        "law arithmetic": lambda: _pd_part(reps, R, x, ref_R, ref_w, ref_dw, P, u, diag),
        "command": lambda: _command_part(reps, S0, C0, steer, sp, limit, u, x, False),
        "command (constant code)": lambda: _command_part(
            reps, S0, C0, steer, sp, limit, u, x, True
        ),
        "RKMK4 step": lambda: _step_part(
            reps, act, J, Ji, S0, C0, dist, dp, dfn, dpk, R, x, held, trig, dt, True
        ),
        "RKMK4 step (runtime codes)": lambda: _step_part(
            reps, act, J, Ji, S0, C0, dist, dp, dfn, dpk, R, x, held, trig, dt, False
        ),
        "finite check": lambda: _check_part(reps, R, x),
        "whole loop": whole,
    }
    for f in parts.values():  # compile and warm
        f()
    out = {k: np.inf for k in parts}
    for _ in range(repeat):  # alternate the parts
        for k, f in parts.items():
            out[k] = min(out[k], _best(f, 1) / (reps * batch) * 1e9)
    return out


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--batch", type=int, nargs="+", default=[1000, 1])
    p.add_argument("--reps", type=int, default=300, help="loop steps per timing")
    p.add_argument("--repeat", type=int, default=5, help="best of this many alternated timings")
    a = p.parse_args(argv)
    print(f"threads: {thread_settings()}")
    for B in a.batch:
        reps = max(a.reps, a.reps * 1000 // B)
        res = breakdown(B, reps, a.repeat)
        skip = ("whole loop", "law (direct)", "law arithmetic", "empty law (pointer)",
                "law (pointer, owned views)",
                "command (constant code)", "RKMK4 step (runtime codes)")  # fmt: skip
        parts = sum(v for k, v in res.items() if k not in skip)
        print(f"batch {B}: ns per spacecraft-step (best of {a.repeat}, per CPU-s)")
        for k, v in res.items():
            print(f"  {k:28s} {v:8.1f}")
        print(f"  {'sum of parts (pointer law)':28s} {parts:8.1f}")
    total = sum(f for f, _ in FLOPS.values())
    print("operation count per spacecraft-step (+ − × ÷; transcendental calls apart):")
    for k, (f, tr) in FLOPS.items():
        print(f"  {k:56s} {f:5d}  {tr}")
    print(f"  {'total':56s} {total:5d}  12 sin/cos pairs, 1 exp, 1 sqrt")


if __name__ == "__main__":
    main()
