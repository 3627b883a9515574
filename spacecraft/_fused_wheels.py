"""The compiled closed loop of a spacecraft flying reaction wheels (:class:`spacecraft.actuators.
ReactionWheelAssembly`): :func:`spacecraft._fused._fused_loop`'s structure — the controller's
law through the seam at every control sample, the actuator's command and one RKMK4 step at
every step, a log row every ``log_every``-th step, each spacecraft's whole run before the next —
with the assembly's kernels (:mod:`spacecraft._kernels_wheels`). The sensors and the measurement
hook run in it as in the momentum model's loop (:mod:`spacecraft._fused_sensors`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from liecontrol._jit import njit, prange
from liecontrol.control import kernel as seam

from . import _fused_sensors as FS
from . import _kernels as K
from . import _kernels_momentum as KM
from ._entry import fn_entry, torque_signature
from ._fused import _finished, _log_components, _loop_result, prepare_run, unowned_view
from ._kernels_wheels import (
    _AI,
    WheelPlan,
    friction_one,
    wheel_bus_torque,
    wheel_command,
    wheel_rkmk4_step,
    wheel_torques,
)

#: rows of the wheel log ``log_whl (K, B, 4, N)`` and the flags ``log_flags (K, B, 2, N)``
_W_SPEED, _W_TORQUE, _W_CMD, _W_FRICTION = range(4)
_F_TORQUE, _F_SPEED = range(2)


@njit
def _one_wheels(
    b: int, n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    J: np.ndarray, J_inv: np.ndarray, wp: np.ndarray, nw: int, friction: bool,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    law: Any, cparams: np.ndarray, cstate: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_whl: np.ndarray, log_flags: np.ndarray, log_diag: np.ndarray, diag: np.ndarray,
    s_int: np.ndarray, s_par: np.ndarray, pub_thr: np.ndarray, pub_sched: np.ndarray,
    noise: np.ndarray, sst: np.ndarray, sy: np.ndarray, h_int: np.ndarray, seen: np.ndarray,
    log_y: np.ndarray, log_est: np.ndarray, h_par: np.ndarray, h_state: np.ndarray,
    log_hook: np.ndarray, sensing: Any, mm_at: int, log_mm: np.ndarray,
) -> tuple[int, float]:  # fmt: skip
    """The whole run of spacecraft ``b`` (as :func:`spacecraft._fused._one_spacecraft`):
    status 0 done, 1 non-finite state, 2 non-finite torque, 3/4 the sensors' failures; the
    final state written back into ``R[b]``, ``x[b]``."""
    n = x.shape[1]
    kb = 0 if J.shape[0] == 1 else b
    rb = b if ref_R.shape[1] > 1 else 0
    # views without an owner (spacecraft._fused.unowned_view: no reference counting in the
    # loop); the owners — the caller's arrays and ``buf`` — outlive them
    Jb = unowned_view(J[kb])
    Jib = unowned_view(J_inv[kb])
    wp = unowned_view(wp)
    dp = unowned_view(dp)
    dpb = unowned_view(dpk[0 if dpk.shape[0] == 1 else b])
    cparams = unowned_view(cparams)
    st = unowned_view(cstate[b])
    dg = unowned_view(diag[b])
    rR = unowned_view(ref_R)
    rw = unowned_view(ref_w)
    rdw = unowned_view(ref_dw)
    buf = np.empty(18 + 2 * n + 3 + 4 * nw + 6 * nw + 15 + nw + 3)
    raw = unowned_view(buf)
    Rc = raw[0:9].reshape((3, 3))
    Rn = raw[9:18].reshape((3, 3))
    o = 18
    xc = raw[o : o + n]
    xn = raw[o + n : o + 2 * n]
    o += 2 * n
    u_cmd = raw[o : o + 3]
    held = raw[o + 3 : o + 3 + 4 * nw]
    o += 3 + 4 * nw
    work = raw[o : o + 6 * nw + 15]
    o += 6 * nw + 15
    tq = raw[o : o + nw]  # the wheel torques at a log row
    dout = raw[o + nw : o + nw + 3]  # the seam torque's output at a log row
    for i in range(3):
        u_cmd[i] = 0.0
        for j in range(3):
            Rc[i, j] = R[b, i, j]
    for i in range(n):
        xc[i] = x[b, i]
    wc = xc[:3]
    wn = xn[:3]
    cur = 0
    if sensing is not None:
        hook = h_int[0]
        s_tmp = np.empty(FS.N_TMP)
        tmp = unowned_view(s_tmp)
        si = unowned_view(s_int)
        spar = unowned_view(s_par)
        pthr = unowned_view(pub_thr)
        psch = unowned_view(pub_sched)
        hi = unowned_view(h_int)
        nz = unowned_view(noise[b])
        stb = unowned_view(sst[b])
        yb = unowned_view(sy[b])
        sb = unowned_view(seen[b])
        Rs = sb[:9].reshape((3, 3))
        ws = sb[9:12]
        hp = unowned_view(h_par)
        hsb = h_state[b]
    rows = 0
    status = 0
    t = t0
    md0, md1, md2 = 0.0, 0.0, 0.0
    for k in range(n_steps + 1):
        t = t0 + k * dt
        r = ref_index[k]
        if sensing is not None:
            cur = FS.sense_stage(
                k, t, Rc, wc, si, spar, pthr, psch, nz, cur, stb, yb, tmp
            )  # fmt: skip
            if cur < 0:  # a degenerate TRIAD pair (the Python loop raises)
                status = 4
                break
        if k % every_ctrl == 0:
            hooked = False
            if sensing is not None:
                hooked = hook != FS.HOOK_NONE
            if hooked:
                if not FS.hook_stage(
                    hi, hp, hsb, yb, sb, t, Rc, stb, log_hook, k // every_ctrl, b, sensing
                ):
                    status = 3
                    break
                law(t, Rs, ws, rR[r, rb], rw[r, rb], rdw[r, rb], cparams, st, u_cmd, dg)
            else:
                law(t, Rc, wc, rR[r, rb], rw[r, rb], rdw[r, rb], cparams, st, u_cmd, dg)
            if not np.isfinite(u_cmd[0] + u_cmd[1] + u_cmd[2]):
                status = 2
                break
        wheel_command(
            wp, nw, u_cmd[0], u_cmd[1], u_cmd[2], xc[0], xc[1], xc[2], xc[3:], held
        )  # fmt: skip
        if mm_at >= 0:
            # momentum management (as spacecraft._fused._one_spacecraft): the dipole held over
            # this step from the wheels' momentum A I_w Ω; zero slots while the log reads the
            # disturbance
            mh0, mh1, mh2 = 0.0, 0.0, 0.0
            for j in range(nw):
                s = xc[3 + j]
                mh0 += s * wp[_AI, j]
                mh1 += s * wp[_AI + 1, j]
                mh2 += s * wp[_AI + 2, j]
            mp = dpb[mm_at:]
            md0, md1, md2 = KM.dipole(t, Rc, mh0, mh1, mh2, mp)
            KM.hold_dipole(mp, 0.0, 0.0, 0.0)
        if k % log_every == 0 or k == n_steps:
            for i in range(3):
                log_w[rows, b, i] = xc[i]
                log_wd[rows, b, i] = ref_w[r, rb, i]
                log_ucmd[rows, b, i] = u_cmd[i]
                for j in range(3):
                    log_R[rows, b, i, j] = Rc[i, j]
                    log_Rd[rows, b, i, j] = ref_R[r, rb, i, j]
            h0, h1, h2 = wheel_torques(wp, nw, friction, held, xc, 3, tq)
            u0, u1, u2 = wheel_bus_torque(wp, nw, tq, h0, h1, h2, xc[0], xc[1], xc[2])
            log_u[rows, b, 0] = u0
            log_u[rows, b, 1] = u1
            log_u[rows, b, 2] = u2
            if dist == K.DIST_KERNEL:
                dfn(t, Rc, wc, dpb, dout)
                d0, d1, d2 = dout[0], dout[1], dout[2]
            else:
                d0, d1, d2 = K.disturbance_at(dist, dp, t)
            log_dist[rows, b, 0] = d0
            log_dist[rows, b, 1] = d1
            log_dist[rows, b, 2] = d2
            for i in range(nw):
                s = xc[3 + i]
                log_whl[rows, b, _W_SPEED, i] = s
                log_whl[rows, b, _W_TORQUE, i] = held[i]
                log_whl[rows, b, _W_CMD, i] = held[nw + i]
                log_whl[rows, b, _W_FRICTION, i] = friction_one(wp, i, s) if friction else 0.0
                log_flags[rows, b, _F_TORQUE, i] = held[2 * nw + i] != 0.0
                log_flags[rows, b, _F_SPEED, i] = held[3 * nw + i] != 0.0
            for i in range(dg.shape[0]):
                log_diag[rows, b, i] = dg[i]
            if sensing is not None:
                for i in range(yb.shape[0]):
                    log_y[rows, b, i] = yb[i]
                for i in range(log_est.shape[2]):
                    log_est[rows, b, i] = sb[i]
            if mm_at >= 0:  # the management's log (the dipole held from t, m × B)
                KM.log_row(log_mm, rows, b, t, Rc, dpb[mm_at:], md0, md1, md2)
            rows += 1
        if k == n_steps:
            break
        if mm_at >= 0:
            KM.hold_dipole(dpb[mm_at:], md0, md1, md2)
        # the seam torque's own call site (as in _one_spacecraft): the built-in codes' step
        # compiles without the pointer call
        if dist == K.DIST_KERNEL:
            wheel_rkmk4_step(
                wp, nw, friction, Jb, Jib, K.DIST_KERNEL, dp, dfn, dpb, datt, t, Rc, xc, held,
                dt, Rn, xn, work,
            )  # fmt: skip
        else:
            wheel_rkmk4_step(
                wp, nw, friction, Jb, Jib, dist, dp, dfn, dpb, False, t, Rc, xc, held, dt, Rn,
                xn, work,
            )  # fmt: skip
        total = 0.0
        for i in range(n):
            total += xn[i]
        for i in range(3):
            for j in range(3):
                total += Rn[i, j]
        if not np.isfinite(total):
            status = 1
            break
        Rc, Rn = Rn, Rc
        xc, xn = xn, xc
        wc, wn = wn, wc
    R[b] = Rc
    x[b] = xc
    if buf.shape[0] == 0:  # the owner's last use (see _one_spacecraft)
        status = -1
    if sensing is not None:
        if s_tmp.shape[0] == 0:
            status = -1
    return status, t


@njit
def fused_loop_wheels(
    n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    J: np.ndarray, J_inv: np.ndarray, wp: np.ndarray, nw: int, friction: bool,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    law: Any, cparams: np.ndarray, cstate: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_t: np.ndarray, log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_whl: np.ndarray, log_flags: np.ndarray, log_diag: np.ndarray, diag: np.ndarray,
    s_int: np.ndarray, s_par: np.ndarray, pub_thr: np.ndarray, pub_sched: np.ndarray,
    noise: np.ndarray, sst: np.ndarray, sy: np.ndarray, h_int: np.ndarray, seen: np.ndarray,
    log_y: np.ndarray, log_est: np.ndarray, h_par: np.ndarray, h_state: np.ndarray,
    log_hook: np.ndarray, sensing: Any, mm_at: int, log_mm: np.ndarray,
) -> tuple[int, int, float]:  # fmt: skip
    """The closed loop with reaction wheels for ``B`` spacecraft (:func:`_one_wheels` each):
    ``(status, rows, t)`` as :func:`spacecraft._fused._fused_loop`."""
    B = R.shape[0]
    st = np.zeros(B, dtype=np.int64)
    tf = np.full(B, np.inf)
    for b in range(B):
        st[b], tf[b] = _one_wheels(
            b, n_steps, t0, dt, every_ctrl, log_every, R, x, J, J_inv, wp, nw, friction, dist,
            dp, dfn, dpk, datt, law, cparams, cstate, ref_index, ref_R, ref_w, ref_dw, log_R,
            log_w, log_Rd, log_wd, log_ucmd, log_u, log_dist, log_whl, log_flags, log_diag,
            diag, s_int, s_par, pub_thr, pub_sched, noise, sst, sy, h_int, seen, log_y,
            log_est, h_par, h_state, log_hook, sensing, mm_at, log_mm,
        )  # fmt: skip
    return _loop_result(st, tf, n_steps, t0, dt, log_every, log_t)


@njit(parallel=True)
def fused_loop_wheels_parallel(
    n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    J: np.ndarray, J_inv: np.ndarray, wp: np.ndarray, nw: int, friction: bool,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    law: Any, cparams: np.ndarray, cstate: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_t: np.ndarray, log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_whl: np.ndarray, log_flags: np.ndarray, log_diag: np.ndarray, diag: np.ndarray,
    s_int: np.ndarray, s_par: np.ndarray, pub_thr: np.ndarray, pub_sched: np.ndarray,
    noise: np.ndarray, sst: np.ndarray, sy: np.ndarray, h_int: np.ndarray, seen: np.ndarray,
    log_y: np.ndarray, log_est: np.ndarray, h_par: np.ndarray, h_state: np.ndarray,
    log_hook: np.ndarray, sensing: Any, mm_at: int, log_mm: np.ndarray,
) -> tuple[int, int, float]:  # fmt: skip
    """:func:`fused_loop_wheels` with the spacecraft spread over numba's threads (each
    spacecraft's arithmetic unchanged: bit-identical for any thread count)."""
    B = R.shape[0]
    st = np.zeros(B, dtype=np.int64)
    tf = np.full(B, np.inf)
    for i in prange(B):
        b = np.int64(i)
        s, tb = _one_wheels(
            b, n_steps, t0, dt, every_ctrl, log_every, R, x, J, J_inv, wp, nw, friction, dist,
            dp, dfn, dpk, datt, law, cparams, cstate, ref_index, ref_R, ref_w, ref_dw, log_R,
            log_w, log_Rd, log_wd, log_ucmd, log_u, log_dist, log_whl, log_flags, log_diag,
            diag, s_int, s_par, pub_thr, pub_sched, noise, sst, sy, h_int, seen, log_y,
            log_est, h_par, h_state, log_hook, sensing, mm_at, log_mm,
        )  # fmt: skip
        st[b] = s
        tf[b] = tb
    return _loop_result(st, tf, n_steps, t0, dt, log_every, log_t)


#: the law's and the seam torque's places in the loop's arguments
_LAW_ARG = 17
_TORQUE_ARG = 14


def run_fused_wheels(
    wp_plan: WheelPlan, spec: seam.ControllerKernel, splan: FS.SensorPlan | None, plant: Any,
    controller: Any, reference: Any, R0: np.ndarray, x0: np.ndarray, t0: float,
    n_steps: int, dt: float, every_ctrl: int, log_every: int, control_period: float,
    make_log: Any, notes: list[str] | None, workers: int, rng: Any, measurement: Any,
) -> Any:  # fmt: skip
    """:func:`spacecraft._fused.run_fused` for reaction wheels: the
    :class:`~spacecraft.simulator.SimulationResult` of :func:`fused_loop_wheels`, with the
    assembly's log keys (``ReactionWheelAssembly.log``), or ``None`` when the run must go
    through the Python loop (``notes`` says why)."""
    B = x0.shape[0]
    nw = wp_plan.n
    n_diag = int(spec.n_diag)
    f8 = np.float64

    def log_shapes(Kr: int, B: int, sa: Any) -> dict[str, tuple[tuple[int, ...], Any]]:
        return {
            "diag": ((Kr, B, n_diag), f8),
            "whl": ((Kr, B, 4, nw), f8),
            "flags": ((Kr, B, 2, nw), np.bool_),
            "y": ((Kr, B, sa.y.shape[1]), f8),
            "est": ((Kr, B, sa.n_est), f8),
            "mm": ((Kr if wp_plan.mm_at >= 0 else 0, B, 6), f8),  # dipole, magnetic torque
        }

    setup = prepare_run(
        wp_plan, spec, splan, controller, reference, R0, x0, t0, n_steps, dt, every_ctrl,
        log_every, make_log, notes, rng, measurement, log_shapes,
    )  # fmt: skip
    if setup is None:
        return None
    sa, log = setup.sa, setup.log
    ex = log.extra  # carved with the simulator's log (spacecraft._log_memory)
    diag = np.zeros((B, n_diag))
    log_diag, log_whl, log_flags = ex["diag"], ex["whl"], ex["flags"]
    log_y, log_est, log_mm = ex["y"], ex["est"], ex["mm"]
    log_hook = FS.hook_log(sa, n_steps, every_ctrl, B)
    args = (
        n_steps, float(t0), float(dt), every_ctrl, setup.log_every, setup.R0, setup.x0,
        wp_plan.J, wp_plan.J_inv, wp_plan.wp, nw, wp_plan.friction,
        wp_plan.dist, wp_plan.dist_params, wp_plan.dist_fn, setup.dpk, wp_plan.dist_attitude,
        spec.law, setup.cparams, setup.cstate, setup.index, setup.ref_R, setup.ref_w,
        setup.ref_dw,
        log.t, log.R, log.omega, log.R_d, log.omega_d, log.u_cmd, log.u, log.disturbance,
        log_whl, log_flags, log_diag, diag,
        sa.s_int, sa.s_par, sa.pub_thr, sa.pub_sched, sa.noise, sa.state, sa.y, sa.h_int,
        sa.seen, log_y, log_est, sa.h_par, sa.h_state, log_hook,
        FS.sensing_marker(splan), wp_plan.mm_at, log_mm,
    )  # fmt: skip
    parallel = workers > 1 and B > 1
    loop = fused_loop_wheels_parallel if parallel else fused_loop_wheels
    entry = fn_entry(loop, args, {_TORQUE_ARG: torque_signature(), _LAW_ARG: seam.LAW_SIGNATURE})
    if parallel:
        import numba

        previous = numba.get_num_threads()
        numba.set_num_threads(min(workers, B))
        try:
            status, rows, t_fail = entry(*args)
        finally:
            numba.set_num_threads(previous)
    else:
        status, rows, t_fail = entry(*args)
    if not _finished(status, t_fail, t0, controller, spec, notes):
        return None
    log.rows = rows
    d = log.dicts
    if splan is not None:
        FS.finish(splan, sa, log_y, log_est, d, B, n_steps)
        FS.finish_hook(splan, sa, log_hook, measurement)
    a = d["actuator"]  # the keys and order of ReactionWheelAssembly.log, contiguous as its
    flat = np.ascontiguousarray
    a["wheel_speed"] = flat(log_whl[:, :, _W_SPEED])
    a["wheel_torque"] = flat(log_whl[:, :, _W_TORQUE])
    a["wheel_torque_cmd"] = flat(log_whl[:, :, _W_CMD])
    a["torque_saturated"] = flat(log_flags[:, :, _F_TORQUE])
    a["speed_saturated"] = flat(log_flags[:, :, _F_SPEED])
    a["saturated"] = log_flags[:, :, _F_TORQUE] | log_flags[:, :, _F_SPEED]
    if wp_plan.friction:
        a["friction_torque"] = flat(log_whl[:, :, _W_FRICTION])
    if wp_plan.mm_at >= 0:  # after the assembly's own entries, as the Python loop puts them
        a["dipole"] = log_mm[:, :, :3]
        a["magnetic_torque"] = log_mm[:, :, 3:]
    d["controller"].update(spec.diagnostics(log_diag))
    spec.finish(setup.cstate, diag.copy())
    _log_components(wp_plan, log, rows, B)
    return log.result(dt, control_period, plant)
