"""Compiled routes of the simulator: the plant's kernel plan (which per-step kernels a plant
can run on) and the fused closed loop.

A plant has a kernel plan when its parts all have kernels (:mod:`spacecraft._kernels`): a rigid
body (shared or per-spacecraft inertia, no flexible modes, no momentum management), an
actuator with a kernel (:func:`spacecraft.actuators.actuator_kernel`: the ideal torque actuator,
or the SGCMG pyramid with the ideal gimbal servo and a steering law with a kernel: a built-in
law's, :func:`spacecraft.steering.steering_kernel`, or a user's through the seam
:mod:`spacecraft.steering_kernel`, called through a function pointer) and a disturbance with a
kernel: a built-in time-only code (:func:`spacecraft.disturbances.disturbance_kernel`: none, a
constant torque, the constant + harmonic torque) or a torque of the public disturbance seam
:mod:`spacecraft.disturbance_kernel` (``disturbance.fused_kernel()``: the gravity gradient, a
user's own torque), called through a function pointer at every RKMK4 stage with the stage
attitude (``DIST_KERNEL``; the built-in codes keep their own call sites, no pointer call). The
full CMG model's loop takes the same disturbances (the seam's torque at every stage of its own
step, :func:`spacecraft._kernels_vscmg.vscmg_rkmk4_step_batch`) and the built-in regularised
steering laws only. Each of those functions lives next to the classes it describes; this module
imports none of them at import time, and neither they nor the classes import this module at
import time (no import circle).

:func:`run_fused` runs a whole :func:`spacecraft.simulator.simulate` call in compiled code when,
in addition, the controller supplies a compiled law through the public seam
:mod:`liecontrol.control.kernel` (``controller.fused_kernel(B)``), the sensors and the
measurement hook (if any) have kernels (:mod:`spacecraft._fused_sensors`: the built-in star
tracker — quaternion, Euler-angle or matrix output —, the two-vector (TRIAD) sensor with fixed
references, rate gyro and ``TimedSensor``, the ``StarTrackerGyro`` hook and an MEKF or
manifold-UKF hook through ``fused_hook``) and no progress bar or compute delay is used. The loop
knows no controller class: it calls the law it is given through a function pointer (a numba
first-class function of the documented signature), carries the law's internal state array and
logs its diagnostics rows, so one compiled loop (cached on disk) serves the built-in laws and a
user's own alike. It produces the same :class:`~spacecraft.simulator.SimulationResult` as the
per-step Python loop, which calls the same kernels one at a time. Anything else — a controller
without a kernel, a disturbance without a kernel (or a ``SumOfDisturbances`` with a source
without one), a user's sensor — runs through that loop, and :func:`fused_supported` reports
why.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from liecontrol._jit import JIT_ENABLED, njit, prange
from liecontrol.control import kernel as seam

from . import _fused_sensors as FS
from . import _kernels as K
from . import _kernels_momentum as KM
from ._entry import fn_entry as _fn_entry
from ._entry import torque_signature as _torque_sig
from ._kernels_vscmg import (
    vscmg_command_one,
    vscmg_derivatives_one,
    vscmg_momentum_one,
    vscmg_rkmk4_step_batch,
)
from ._kernels_wheels import WheelPlan, wheel_support

#: reference samples held in memory by the fused loop at most (else the Python loop runs)
_MAX_REFERENCE_BYTES = 256 * 2**20


def _unowned_view_impl() -> Any:
    """``unowned_view(a)``: the C-contiguous array ``a`` as a view that owns nothing (numba's
    ``carray`` on its data pointer): views and arguments made from it carry no reference count.
    The caller keeps an owner of the memory alive for as long as the view is used."""
    if not JIT_ENABLED:
        return None
    from numba import carray, types
    from numba.core import cgutils
    from numba.extending import intrinsic

    @intrinsic
    def _address_to_pointer(typingctx: Any, address: Any) -> Any:
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.inttoptr(args[0], cgutils.voidptr_t)

        return types.voidptr(types.uintp), codegen

    @njit(inline="always")
    def unowned_view(a: np.ndarray) -> np.ndarray:
        return carray(_address_to_pointer(a.ctypes.data), a.shape, a.dtype)

    return unowned_view


unowned_view = _unowned_view_impl()


@dataclass(frozen=True)
class PlantKernel:
    """The kernel parameters of a plant (see the module docstring)."""

    act: int
    J: np.ndarray  # (1, 3, 3) shared or (B, 3, 3)
    J_inv: np.ndarray
    S0: np.ndarray  # (3, 4) h0 × unit momenta at δ = π/2 (SGCMG), else (3, 0)
    C0: np.ndarray  # (3, 4) h0 × unit momenta at δ = 0
    dist: int
    dist_params: np.ndarray
    clip: np.ndarray | None  # ideal actuator: per-axis |u| limit (3,)
    steer: int
    steer_params: np.ndarray
    rate_limit: float
    steer_fn: Any = None  # a user's steering kernel (STEER_KERNEL), else K.no_steering
    # the seam's torque (spacecraft.disturbance_kernel) for dist == DIST_KERNEL, else the
    # placeholder no_torque; its checked parameters (1, n_p) or (B, n_p); whether it reads R
    dist_fn: Any = None
    dist_kparams: np.ndarray = field(default_factory=lambda: np.zeros((1, 0)))
    dist_attitude: bool = False
    disturbance: Any = None
    # momentum management in the compiled loop (momentum_plan): the offset of the magnetic
    # torque's block in the seam torque's row, whose held dipole the loop writes (−1: none)
    mm_at: int = -1

    def dist_rows(self, B: int) -> np.ndarray:
        """The seam torque's parameter rows for a batch of ``B`` (:func:`dist_rows`); with
        momentum management a fresh ``(B, n_p)`` array: the loop writes each spacecraft's
        held dipole into its row."""
        rows = dist_rows(self.disturbance, self.dist_kparams, B)
        if self.mm_at >= 0:
            rows = np.ascontiguousarray(np.broadcast_to(rows, (B, rows.shape[1]))).copy()
        return rows

    def step(
        self, t: float, R: np.ndarray, x: np.ndarray, held: np.ndarray, h: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """One RKMK4 step of the batch ``R (B, 3, 3)``, ``x (B, n)``, held command ``(B, m)``."""
        R_out = np.empty(R.shape)
        x_out = np.empty(x.shape)
        args = (
            self.act, self.J, self.J_inv, self.S0, self.C0, self.dist, self.dist_params,
            self.dist_fn, self.dist_rows(x.shape[0]), self.dist_attitude,
            float(t), np.ascontiguousarray(R), np.ascontiguousarray(x),
            np.ascontiguousarray(held), float(h), R_out, x_out,
        )  # fmt: skip
        step = _fn_entry(K.rkmk4_step_batch, args, {7: _torque_sig()}) if JIT_ENABLED else None
        (step or K.rkmk4_step_batch)(*args)  # without numba: the kernel as Python
        return R_out, x_out


def dist_rows(disturbance: Any, p: np.ndarray, B: int) -> np.ndarray:
    """The seam torque's parameter rows ``p (B', n_p)`` for a batch of ``B``
    (:func:`spacecraft.disturbances.kernel_rows`: ``ValueError`` naming the disturbance when
    per-spacecraft rows do not match the batch)."""
    from .disturbances import kernel_rows

    return kernel_rows(disturbance, p, B)


@njit
def _hold_steps(
    n_sub: int, t: float, dt: float, R: np.ndarray, x: np.ndarray, u: np.ndarray,
    act: int, J: np.ndarray, J_inv: np.ndarray, S0: np.ndarray, C0: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    clip_on: bool, clip: np.ndarray,
    steer: int, sp: np.ndarray, steer_fn: Any, rate_limit: float, saturated: np.ndarray,
) -> None:  # fmt: skip
    """``n_sub`` steps of the batch under the torque command ``u (B, 3)`` held throughout (the
    actuator's hardware command recomputed at every step, as the simulator does); ``R``, ``x``
    advance in place and ``saturated[b]`` counts the steps whose command was limited."""
    B, n = x.shape
    shared = J.shape[0] == 1
    held = np.empty(3 if act == K.ACT_IDEAL else n - 3)
    hd = np.empty(3)
    at_limit = np.zeros(3, dtype=np.bool_)
    work = np.empty(7 * n + 15)
    A = np.empty((3, max(n - 3, 1)))
    # the command's sin/cos of the gimbal angles land where the step's first stage reads them
    sn = work[5 * n : 5 * n + max(n - 3, 1)]
    cs = work[6 * n : 6 * n + max(n - 3, 1)]
    R_next = np.empty((3, 3))
    x_next = np.empty(n)
    for b in range(B):
        kb = 0 if shared else b
        pb = 0 if dpk.shape[0] == 1 else b
        for _ in range(n_sub):
            if act == K.ACT_SGCMG:
                limited = K.sgcmg_command(
                    S0, C0, steer, sp, steer_fn, rate_limit, u[b], x[b, :3], x[b, 3:], t, held,
                    hd, A, sn, cs,
                )  # fmt: skip
            else:
                limited = K.ideal_command(u[b], clip_on, clip, held, at_limit)
            if limited:
                saturated[b] += 1.0
            K.rkmk4_step(
                act, J[kb], J_inv[kb], S0, C0, dist, dp, dfn, dpk[pb], datt, t, R[b], x[b], held,
                dt, R_next, x_next, work, act == K.ACT_SGCMG,
            )  # fmt: skip
            R[b] = R_next
            x[b] = x_next


def hold_steps(
    pk: PlantKernel, n_sub: int, t: float, dt: float, R: np.ndarray, x: np.ndarray,
    u: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """``n_sub`` compiled steps of a plant with a :class:`PlantKernel` under a held torque
    command; returns ``(R, x, steps with a limited command per spacecraft)``."""
    R = np.array(R, dtype=np.float64)
    x = np.array(x, dtype=np.float64)
    sat = np.zeros(x.shape[0])
    clip = pk.clip if pk.clip is not None else np.zeros(3)
    args = (
        int(n_sub), float(t), float(dt), R, x, np.ascontiguousarray(u, dtype=np.float64),
        pk.act, pk.J, pk.J_inv, pk.S0, pk.C0, pk.dist, pk.dist_params, pk.dist_fn,
        pk.dist_rows(x.shape[0]), pk.dist_attitude, pk.clip is not None,
        clip, pk.steer, pk.steer_params, _steer_fn(pk), pk.rate_limit, sat,
    )  # fmt: skip
    run = (
        _fn_entry(_hold_steps, args, {13: _torque_sig(), 20: _steering_sig()})
        if JIT_ENABLED
        else None
    )
    (run or _hold_steps)(*args)  # without numba: the kernel as Python
    return R, x, sat


def _steer_fn(pk: PlantKernel) -> Any:
    return K.no_steering if pk.steer_fn is None else pk.steer_fn


def _steering_sig() -> Any:
    from .steering_kernel import STEERING_SIGNATURE

    return STEERING_SIGNATURE


def _disturbance_plan(
    plant: Any,
) -> tuple[tuple[int, np.ndarray, Any, np.ndarray, bool] | None, str]:
    """``((code, code params, torque, kernel params (B', n_p), uses attitude), "")`` of the
    plant's disturbance — a built-in time-only code (:func:`spacecraft.disturbances.
    disturbance_kernel`) or a torque of the seam (:mod:`spacecraft.disturbance_kernel`, checked
    here: ``ValueError`` naming the disturbance and the argument) — else ``(None, why)``
    (:func:`spacecraft.disturbances.disturbance_plan` for the plant's batch)."""
    from .disturbances import disturbance_plan

    return disturbance_plan(plant.disturbance, plant.body.batch_size)


def plant_kernel(plant: Any) -> PlantKernel | None:
    """The :class:`PlantKernel` of a :class:`spacecraft.plant.Spacecraft`, or ``None`` when a
    part has no kernel (a malformed disturbance kernel raises ``ValueError``)."""
    from .actuators import actuator_kernel

    if plant.modes is not None or plant.momentum_management is not None:
        return None
    if not JIT_ENABLED and plant.disturbance is not None:
        from .disturbances import disturbance_kernel

        if disturbance_kernel(plant.disturbance) is None:
            return None
    ak = actuator_kernel(plant.actuator)
    if ak is None:
        return None
    dist, _ = _disturbance_plan(plant)
    if dist is None:
        return None
    return _plant_kernel_of(plant, ak, dist)


def _plant_kernel_of(
    plant: Any, ak: tuple, dist: tuple[int, np.ndarray, Any, np.ndarray, bool], mm_at: int = -1
) -> PlantKernel:
    """The :class:`PlantKernel` of ``plant`` from its actuator's kernel ``ak`` and a
    disturbance plan ``(code, code params, torque, kernel params, uses attitude)``."""
    code, clip, steer, sp, limit, S0, C0, steer_fn = ak
    J3 = np.ascontiguousarray(plant.body.J.reshape(-1, 3, 3))
    Ji3 = np.ascontiguousarray(plant.body.J_inv.reshape(-1, 3, 3))
    return PlantKernel(
        code, J3, Ji3, S0, C0, dist[0], dist[1], clip, steer, sp, float(limit),
        steer_fn=steer_fn, dist_fn=dist[2], dist_kparams=dist[3], dist_attitude=dist[4],
        disturbance=plant.disturbance, mm_at=mm_at,
    )  # fmt: skip


def momentum_plan(plant: Any) -> tuple[PlantKernel | None, str]:
    """The momentum model's plan (ideal torques or the SGCMG cluster) with the plant's momentum
    management in the compiled loop: its torque of the seam composed after the plant's
    disturbance (:func:`spacecraft.disturbances.managed_disturbance_plan`; magnetic dumping:
    m × B with the held dipole in its row, :mod:`spacecraft._kernels_momentum`). ``(None,
    why)`` when a part has no kernel (``why`` empty: the generic reasons of
    :func:`plant_reason` apply)."""
    from .actuators import actuator_kernel
    from .disturbances import loop_disturbance_plan

    if plant.modes is not None:
        return None, ""
    ak = actuator_kernel(plant.actuator)
    if ak is None:
        return None, ""
    dk, at, why = loop_disturbance_plan(
        plant.disturbance, plant.momentum_management, plant.body.batch_size
    )
    if dk is None:
        return None, why
    return _plant_kernel_of(plant, ak, dk, at), ""


def plant_reason(plant: Any) -> str:
    """Why a plant has no kernel plan, in words (the simulator's log line)."""
    from .actuators import actuator_kernel
    from .disturbances import disturbance_kernel

    if plant.modes is not None:
        return "the plant's flexible modes have no compiled kernel"
    if plant.momentum_management is not None:
        return (
            f"the plant's momentum management {type(plant.momentum_management).__name__} is "
            f"not compiled with the actuator {type(plant.actuator).__name__}"
        )
    if disturbance_kernel(plant.disturbance) is None:
        if not JIT_ENABLED:
            return f"the disturbance {type(plant.disturbance).__name__} has no compiled kernel"
        from .disturbance_kernel import resolve

        spec, why = resolve(plant.disturbance)
        if spec is None:
            return why
    if actuator_kernel(plant.actuator) is None:
        from .actuators import steering_reason

        act = plant.actuator
        why = steering_reason(act)
        if why:
            return why
        steering = getattr(act, "steering", None)
        extra = "" if steering is None else f" with steering {type(steering).__name__}"
        return f"the actuator {type(act).__name__}{extra} has no compiled kernel"
    return "the plant has no compiled kernel"


@dataclass(frozen=True)
class ControllerPlan:
    """A controller's checked kernel: the law and the arrays the loop starts from."""

    spec: seam.ControllerKernel
    params: np.ndarray
    state: np.ndarray


@njit
def _one_spacecraft(
    b: int, n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    act: int, J: np.ndarray, J_inv: np.ndarray, S0: np.ndarray, C0: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    clip_on: bool, clip: np.ndarray,
    steer: int, sp: np.ndarray, steer_fn: Any, rate_limit: float,
    law: Any, cparams: np.ndarray, cstate: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_act: np.ndarray, log_sat: np.ndarray, log_hm: np.ndarray, log_diag: np.ndarray,
    diag: np.ndarray,
    s_int: np.ndarray, s_par: np.ndarray, pub_thr: np.ndarray, pub_sched: np.ndarray,
    noise: np.ndarray, sst: np.ndarray, sy: np.ndarray, h_int: np.ndarray, seen: np.ndarray,
    log_y: np.ndarray, log_est: np.ndarray, h_par: np.ndarray, h_state: np.ndarray,
    log_hook: np.ndarray, sensing: Any, mm_at: int, log_mm: np.ndarray,
) -> tuple[int, float]:  # fmt: skip
    """The whole run of spacecraft ``b`` (the loop's body, see :func:`_fused_loop`): every step
    of one spacecraft before the next, its state, command and scratch in locals and views made
    once, so the law's call and the step read the same few cache lines throughout. Returns
    ``(status, t)`` as the loop does. The final state is written back into ``R[b]``, ``x[b]``."""
    n = x.shape[1]
    m = n - 3
    mm = max(m, 1)
    n_held = 3 if act == K.ACT_IDEAL else m
    kb = 0 if J.shape[0] == 1 else b
    rb = b if ref_R.shape[1] > 1 else 0
    # Every array of the run as a view without an owner (unowned_view): numba then skips the
    # reference counting it does for each view it makes and each array it passes (atomic
    # operations that cost as much as the geometric PD's arithmetic per law call). The owners
    # outlive every view: the caller's arrays the whole call, and ``buf`` (the run's own
    # state and scratch, one allocation) is used after the loop.
    Jb = unowned_view(J[kb])
    Jib = unowned_view(J_inv[kb])
    S0 = unowned_view(S0)
    C0 = unowned_view(C0)
    sp = unowned_view(sp)
    dp = unowned_view(dp)
    dpb = unowned_view(dpk[0 if dpk.shape[0] == 1 else b])
    clip = unowned_view(clip)
    cparams = unowned_view(cparams)
    st = unowned_view(cstate[b])
    dg = unowned_view(diag[b])
    buf = np.empty(18 + 2 * n + 3 + n_held + 3 + 7 * n + 15 + 3 * mm + 2 * mm)
    raw = unowned_view(buf)
    Rc = raw[0:9].reshape((3, 3))
    Rn = raw[9:18].reshape((3, 3))
    o = 18
    xc = raw[o : o + n]
    xn = raw[o + n : o + 2 * n]
    o += 2 * n
    u_cmd = raw[o : o + 3]
    held = raw[o + 3 : o + 3 + n_held]
    hd = raw[o + 3 + n_held : o + 6 + n_held]
    o += 6 + n_held
    work = raw[o : o + 7 * n + 15]
    dout = work[7 * n + 12 : 7 * n + 15]  # the seam torque's output at a log row
    o += 7 * n + 15
    A = raw[o : o + 3 * mm].reshape((3, mm))
    scratch = raw[o + 3 * mm : o + 5 * mm]
    sat_own = np.zeros(3 if act == K.ACT_IDEAL else 1, dtype=np.bool_)
    sat = unowned_view(sat_own)
    for i in range(3):
        u_cmd[i] = 0.0
        for j in range(3):
            Rc[i, j] = R[b, i, j]
    for i in range(n):
        xc[i] = x[b, i]
    for i in range(n_held):
        held[i] = 0.0
    wc = xc[:3]
    wn = xn[:3]
    rR = unowned_view(ref_R)
    rw = unowned_view(ref_w)
    rdw = unowned_view(ref_dw)
    # the command's sin/cos of the gimbal angles land where the step's first stage reads them
    sn = work[5 * n : 5 * n + mm]
    cs = work[6 * n : 6 * n + mm]
    # the sensors and the measurement hook (spacecraft._fused_sensors; empty arrays without)
    # (``sensing`` is None without sensors: numba prunes every ``sensing`` branch at compile
    # time, so the loop without sensors compiles to the loop without this code; with the UKF
    # hook it is FS.SENSING_UKF, which selects the filter at compile time)
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
        if act == K.ACT_SGCMG:
            sat[0] = K.sgcmg_command(
                S0, C0, steer, sp, steer_fn, rate_limit, u_cmd, wc, xc[3:], t, held, hd, A, sn,
                cs,
            )  # fmt: skip
        else:
            K.ideal_command(u_cmd, clip_on, clip, held, sat)
        if mm_at >= 0:
            # momentum management: the dipole held over this step, from the state at its start
            # (Plant.held_dipole); its slots stay zero while the log reads the disturbance, so
            # the composed torque gives the plant's disturbance alone there (m = 0 adds 0)
            if act == K.ACT_SGCMG:
                mh0, mh1, mh2, _ = K.cmg_momentum_and_measure(
                    S0, C0, xc[3:], A, scratch[:m], scratch[m : 2 * m]
                )
            else:
                mh0, mh1, mh2 = 0.0, 0.0, 0.0
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
            u0, u1, u2 = K.actuator_torque(act, S0, C0, xc[0], xc[1], xc[2], xc, 3, held, scratch)
            log_u[rows, b, 0] = u0
            log_u[rows, b, 1] = u1
            log_u[rows, b, 2] = u2
            if act == K.ACT_SGCMG:
                # the cluster's momentum and singularity measure of the logged angles (else the
                # numpy pass over the whole log afterwards, SgcmgActuator.derived_log, costs as
                # much as the loop); A is free until the next command rewrites it
                h0, h1, h2, mm_ = K.cmg_momentum_and_measure(
                    S0, C0, xc[3:], A, scratch[:m], scratch[m : 2 * m]
                )
                log_hm[rows, b, 0] = h0
                log_hm[rows, b, 1] = h1
                log_hm[rows, b, 2] = h2
                log_hm[rows, b, 3] = mm_
            if dist == K.DIST_KERNEL:
                dfn(t, Rc, wc, dpb, dout)
                d0, d1, d2 = dout[0], dout[1], dout[2]
            else:
                d0, d1, d2 = K.disturbance_at(dist, dp, t)
            log_dist[rows, b, 0] = d0
            log_dist[rows, b, 1] = d1
            log_dist[rows, b, 2] = d2
            for i in range(m):
                log_act[rows, b, i] = xc[3 + i]
            for i in range(n_held):
                log_act[rows, b, m + i] = held[i]
            for i in range(sat.shape[0]):
                log_sat[rows, b, i] = sat[i]
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
        # call sites with the actuator (and the common disturbance) code as constants: the
        # inlined step is specialised per configuration (a quarter of its cost is runtime
        # branching otherwise, docs/performance.md); the arithmetic is the same
        if dist == K.DIST_KERNEL:
            # a torque of the seam (spacecraft.disturbance_kernel) through its pointer: its own
            # call sites, so the built-in codes' steps below compile as before
            if act == K.ACT_SGCMG:
                K.rkmk4_step(
                    K.ACT_SGCMG, Jb, Jib, S0, C0, K.DIST_KERNEL, dp, dfn, dpb, datt, t, Rc, xc,
                    held, dt, Rn, xn, work, True,
                )  # fmt: skip
            else:
                K.rkmk4_step(
                    K.ACT_IDEAL, Jb, Jib, S0, C0, K.DIST_KERNEL, dp, dfn, dpb, datt, t, Rc, xc,
                    held, dt, Rn, xn, work, False,
                )  # fmt: skip
        elif act == K.ACT_SGCMG:
            if dist == K.DIST_NONE:
                K.rkmk4_step(
                    K.ACT_SGCMG, Jb, Jib, S0, C0, K.DIST_NONE, dp, dfn, dpb, False, t, Rc, xc,
                    held, dt, Rn, xn, work, True,
                )  # fmt: skip
            else:
                K.rkmk4_step(
                    K.ACT_SGCMG, Jb, Jib, S0, C0, dist, dp, dfn, dpb, False, t, Rc, xc, held, dt,
                    Rn, xn, work, True,
                )  # fmt: skip
        else:
            K.rkmk4_step(
                K.ACT_IDEAL, Jb, Jib, S0, C0, dist, dp, dfn, dpb, False, t, Rc, xc, held, dt, Rn,
                xn, work, False,
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
    if buf.shape[0] == 0 or sat_own.shape[0] == 0:  # the owners' last use (see above)
        status = -1
    if sensing is not None:
        if s_tmp.shape[0] == 0:
            status = -1
    return status, t


@njit
def _fused_loop(
    n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    act: int, J: np.ndarray, J_inv: np.ndarray, S0: np.ndarray, C0: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    clip_on: bool, clip: np.ndarray,
    steer: int, sp: np.ndarray, steer_fn: Any, rate_limit: float,
    law: Any, cparams: np.ndarray, cstate: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_t: np.ndarray, log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_act: np.ndarray, log_sat: np.ndarray, log_hm: np.ndarray, log_diag: np.ndarray,
    diag: np.ndarray,
    s_int: np.ndarray, s_par: np.ndarray, pub_thr: np.ndarray, pub_sched: np.ndarray,
    noise: np.ndarray, sst: np.ndarray, sy: np.ndarray, h_int: np.ndarray, seen: np.ndarray,
    log_y: np.ndarray, log_est: np.ndarray, h_par: np.ndarray, h_state: np.ndarray,
    log_hook: np.ndarray, sensing: Any, mm_at: int, log_mm: np.ndarray,
) -> tuple[int, int, float]:  # fmt: skip
    """The closed loop of :func:`spacecraft.simulator.simulate` for ``B`` spacecraft: the
    controller's ``law`` (a first-class function of :data:`liecontrol.control.kernel.
    LAW_SIGNATURE`) at every ``every_ctrl``-th step (zero-order hold) with its parameters
    ``cparams`` and its internal state rows ``cstate (B, n_s)`` (carried in place), the
    actuator's command, a log row every ``log_every``-th step and at the end, one RKMK4 step.
    The spacecraft are independent, so each runs all its steps before the next
    (:func:`_one_spacecraft`). Returns ``(status, rows, t)``: status 0 = done, 1 = state
    non-finite, 2 = non-finite torque, at the earliest time ``t`` over the batch."""
    B = R.shape[0]
    st = np.zeros(B, dtype=np.int64)
    tf = np.full(B, np.inf)
    for b in range(B):
        st[b], tf[b] = _one_spacecraft(
            b, n_steps, t0, dt, every_ctrl, log_every, R, x, act, J, J_inv, S0, C0, dist, dp,
            dfn, dpk, datt, clip_on, clip, steer, sp, steer_fn, rate_limit, law, cparams, cstate,
            ref_index, ref_R, ref_w, ref_dw, log_R, log_w, log_Rd, log_wd, log_ucmd, log_u,
            log_dist, log_act, log_sat, log_hm, log_diag, diag, s_int, s_par, pub_thr, pub_sched,
            noise, sst, sy, h_int, seen, log_y, log_est, h_par, h_state, log_hook,
            sensing, mm_at, log_mm,
        )  # fmt: skip
    return _loop_result(st, tf, n_steps, t0, dt, log_every, log_t)


@njit(parallel=True)
def _fused_loop_parallel(
    n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    act: int, J: np.ndarray, J_inv: np.ndarray, S0: np.ndarray, C0: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    clip_on: bool, clip: np.ndarray,
    steer: int, sp: np.ndarray, steer_fn: Any, rate_limit: float,
    law: Any, cparams: np.ndarray, cstate: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_t: np.ndarray, log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_act: np.ndarray, log_sat: np.ndarray, log_hm: np.ndarray, log_diag: np.ndarray,
    diag: np.ndarray,
    s_int: np.ndarray, s_par: np.ndarray, pub_thr: np.ndarray, pub_sched: np.ndarray,
    noise: np.ndarray, sst: np.ndarray, sy: np.ndarray, h_int: np.ndarray, seen: np.ndarray,
    log_y: np.ndarray, log_est: np.ndarray, h_par: np.ndarray, h_state: np.ndarray,
    log_hook: np.ndarray, sensing: Any, mm_at: int, log_mm: np.ndarray,
) -> tuple[int, int, float]:  # fmt: skip
    """:func:`_fused_loop` with the spacecraft spread over numba's threads (``prange``): each
    spacecraft's run is the same arithmetic in the same order, so the results are bit-identical
    to the serial loop's for any thread count."""
    B = R.shape[0]
    st = np.zeros(B, dtype=np.int64)
    tf = np.full(B, np.inf)
    for i in prange(B):
        # prange's index may be unsigned: with an int it would unify to float
        b = np.int64(i)
        s, tb = _one_spacecraft(
            b, n_steps, t0, dt, every_ctrl, log_every, R, x, act, J, J_inv, S0, C0, dist, dp,
            dfn, dpk, datt, clip_on, clip, steer, sp, steer_fn, rate_limit, law, cparams, cstate,
            ref_index, ref_R, ref_w, ref_dw, log_R, log_w, log_Rd, log_wd, log_ucmd, log_u,
            log_dist, log_act, log_sat, log_hm, log_diag, diag, s_int, s_par, pub_thr, pub_sched,
            noise, sst, sy, h_int, seen, log_y, log_est, h_par, h_state, log_hook,
            sensing, mm_at, log_mm,
        )  # fmt: skip
        st[b] = s
        tf[b] = tb
    return _loop_result(st, tf, n_steps, t0, dt, log_every, log_t)


@njit(inline="always")
def _loop_result(
    st: np.ndarray, tf: np.ndarray, n_steps: int, t0: float, dt: float, log_every: int,
    log_t: np.ndarray,
) -> tuple[int, int, float]:  # fmt: skip
    """Fill the log's time column; ``(status, rows, t)`` of the loop from each spacecraft's
    ``(status, time)``: the earliest failure, at one time the law's (2, before the step)
    first."""
    status, t_fail = 0, np.inf
    for b in range(st.shape[0]):
        if st[b] != 0 and (tf[b] < t_fail or (tf[b] == t_fail and st[b] == 2)):
            status, t_fail = st[b], tf[b]
    rows = 0
    for k in range(n_steps + 1):
        if k % log_every == 0 or k == n_steps:
            log_t[rows] = t0 + k * dt
            rows += 1
    if status != 0:
        return status, rows, t_fail
    return 0, rows, t0 + n_steps * dt


@dataclass(frozen=True)
class VscmgPlan:
    """The kernel parameters of a plant flying the full CMG model
    (:class:`spacecraft.cmg_dynamics.VscmgActuator`) in the fused loop: no gimbal stops, a
    regularised steering law with a kernel, a disturbance with a kernel (a built-in time-only
    code or a torque of the seam :mod:`spacecraft.disturbance_kernel`, as for
    :class:`PlantKernel`), the body's inertia the actuator's bus inertia (:func:`vscmg_plan`);
    magnetic dumping composed with the disturbance as in :func:`momentum_plan` (``mm_at``)."""

    kinematic: bool
    variable_speed: bool
    feedforward: bool
    par: np.ndarray
    M: np.ndarray  # (3, 15) = [J_B | S | C | G]
    dist: int
    dist_params: np.ndarray
    steer: int
    steer_params: np.ndarray
    rate_limit: float
    # the seam's torque for dist == DIST_KERNEL (else no_torque), its checked parameters
    # (1, n_p) or (B, n_p), whether it reads R (as PlantKernel)
    dist_fn: Any = None
    dist_kparams: np.ndarray = field(default_factory=lambda: np.zeros((1, 0)))
    dist_attitude: bool = False
    disturbance: Any = None
    # momentum management (as PlantKernel.mm_at): the magnetic torque's block in the row
    mm_at: int = -1

    def dist_rows(self, B: int) -> np.ndarray:
        """The seam torque's parameter rows for a batch of ``B`` (:func:`dist_rows`; with
        momentum management one fresh row per spacecraft, as :meth:`PlantKernel.dist_rows`)."""
        rows = dist_rows(self.disturbance, self.dist_kparams, B)
        if self.mm_at >= 0:
            rows = np.ascontiguousarray(np.broadcast_to(rows, (B, rows.shape[1]))).copy()
        return rows


def _vscmg_support(plant: Any) -> tuple[VscmgPlan | None, str]:
    """``(plan, "")`` or ``(None, why)`` for a plant flying the full CMG model; ``(None, "")``
    for any other plant (a malformed disturbance kernel raises ``ValueError``,
    :func:`_disturbance_plan`)."""
    from .cmg_dynamics import VscmgActuator
    from .steering import steering_kernel

    act = plant.actuator
    if type(act) is not VscmgActuator:
        return None, ""
    if plant.modes is not None:
        return None, ""  # the generic reasons apply (plant_reason)
    if act.stops is not None:
        return None, "the full CMG model with gimbal stops has no compiled loop (stop contact)"
    from .disturbances import loop_disturbance_plan

    # magnetic dumping as a torque of the seam after the disturbance (as momentum_plan)
    mm = plant.momentum_management
    dk, mm_at, why = loop_disturbance_plan(plant.disturbance, mm, plant.body.batch_size)
    if dk is None:
        return None, why if mm is not None else ""  # else plant_reason names the disturbance
    J = np.asarray(plant.body.J)
    if J.shape != (3, 3) or not np.array_equal(J, act.bus_inertia):
        return None, "the full CMG model's body inertia differs from its bus_inertia"
    sk = steering_kernel(act.steering, act.cluster)
    if sk is None or sk[0] == K.STEER_PINV_NULL:
        return None, (
            f"the full CMG model's steering {type(act.steering).__name__} has no compiled "
            "kernel on this actuator (pseudo-inverse, SR and GSR have)"
        )
    kin, var, _bumper, par, M = act._kargs
    ff = (not kin) and bool(act.servo.gyro_feedforward)
    plan = VscmgPlan(
        bool(kin), bool(var), ff, np.ascontiguousarray(par), np.ascontiguousarray(M), dk[0],
        np.ascontiguousarray(dk[1], dtype=np.float64), sk[0], np.ascontiguousarray(sk[1]),
        float(act.rate_limit), dist_fn=dk[2], dist_kparams=dk[3], dist_attitude=dk[4],
        disturbance=plant.disturbance, mm_at=mm_at,
    )  # fmt: skip
    return plan, ""


def vscmg_plan(plant: Any) -> VscmgPlan | None:
    """The :class:`VscmgPlan` of a plant flying the full CMG model, or ``None``."""
    return _vscmg_support(plant)[0]


#: rows of the full CMG model's per-gimbal log in the fused loop (``log_vs (K, B, 8, 4)``)
_VS_DELTA, _VS_RATE, _VS_CMD, _VS_SPIN, _VS_GT, _VS_ST, _VS_POWER, _VS_TSAT = range(8)


@njit
def _one_vscmg(
    b: int, n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    kin: bool, var: bool, ff: bool, par: np.ndarray, M: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    steer: int, sp: np.ndarray, rate_limit: float,
    law: Any, cparams: np.ndarray, cstate: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_vs: np.ndarray, log_work: np.ndarray, log_sat: np.ndarray, log_diag: np.ndarray,
    diag: np.ndarray,
    s_int: np.ndarray, s_par: np.ndarray, pub_thr: np.ndarray, pub_sched: np.ndarray,
    noise: np.ndarray, sst: np.ndarray, sy: np.ndarray, h_int: np.ndarray, seen: np.ndarray,
    log_y: np.ndarray, log_est: np.ndarray, h_par: np.ndarray, h_state: np.ndarray,
    log_hook: np.ndarray, sensing: Any, mm_at: int, log_mm: np.ndarray,
) -> tuple[int, float]:  # fmt: skip
    """The whole run of spacecraft ``b`` flying the full CMG model (as :func:`_one_spacecraft`
    for the momentum model): the law at every ``every_ctrl``-th step, the cluster's command
    (:func:`spacecraft._kernels_vscmg.vscmg_command_one`) and one RKMK4 step
    (:func:`~spacecraft._kernels_vscmg.vscmg_rkmk4_step_batch` on this spacecraft) at every
    step, the log's torques from the coupled derivatives under no external torque, as
    :meth:`~spacecraft.cmg_dynamics.VscmgActuator.body_torque` and ``log`` compute them. The
    disturbance is a time-only code ``(dist, dp)`` or the seam's torque ``dfn`` with this
    spacecraft's row of ``dpk`` (``datt``: it reads the stage attitudes), as in
    :func:`_one_spacecraft`."""
    n = x.shape[1]
    rb = b if ref_R.shape[1] > 1 else 0
    par = unowned_view(par)
    M = unowned_view(M)
    dp = unowned_view(dp)
    # this spacecraft's parameter row of the seam torque, as the step's (1, n_p) rows
    pb = 0 if dpk.shape[0] == 1 else b
    dpk1 = unowned_view(dpk)[pb : pb + 1]
    dpb = dpk1[0]
    sp = unowned_view(sp)
    cparams = unowned_view(cparams)
    st = unowned_view(cstate[b])
    dg = unowned_view(diag[b])
    rR = unowned_view(ref_R)
    rw = unowned_view(ref_w)
    rdw = unowned_view(ref_dw)
    buf = np.empty(18 + 2 * n + 3 + 12 + 12 + 3 + 3 + n + 20 + 3)
    raw = unowned_view(buf)
    Rc = raw[0:9].reshape((1, 3, 3))
    Rn = raw[9:18].reshape((1, 3, 3))
    o = 18
    xc = raw[o : o + n].reshape((1, n))
    xn = raw[o + n : o + 2 * n].reshape((1, n))
    o += 2 * n
    u_cmd = raw[o : o + 3]
    held = raw[o + 3 : o + 15].reshape((1, 3, 4))
    A = raw[o + 15 : o + 27].reshape((3, 4))
    hdot = raw[o + 27 : o + 30]
    zero = raw[o + 30 : o + 33]
    out = raw[o + 33 : o + 33 + n]
    det = raw[o + 33 + n : o + 53 + n].reshape((5, 4))
    dout = raw[o + 53 + n : o + 56 + n]  # the seam torque's output at a log row
    for i in range(3):
        u_cmd[i] = 0.0
        zero[i] = 0.0
        for j in range(3):
            Rc[0, i, j] = R[b, i, j]
    for i in range(n):
        xc[0, i] = x[b, i]
    # the sensors and the measurement hook (as in _one_spacecraft)
    # (``sensing`` is None without sensors: numba prunes every ``sensing`` branch at compile
    # time, so the loop without sensors compiles to the loop without this code)
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
    status = 0
    rows = 0
    t = t0
    sat = False
    md0, md1, md2 = 0.0, 0.0, 0.0
    for k in range(n_steps + 1):
        t = t0 + k * dt
        r = ref_index[k]
        xb = xc[0]
        if sensing is not None:
            cur = FS.sense_stage(
                k, t, Rc[0], xb[:3], si, spar, pthr, psch, nz, cur, stb, yb, tmp
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
                    hi, hp, hsb, yb, sb, t, Rc[0], stb, log_hook, k // every_ctrl, b, sensing
                ):
                    status = 3
                    break
                law(t, Rs, ws, rR[r, rb], rw[r, rb], rdw[r, rb], cparams, st, u_cmd, dg)
            else:
                law(t, Rc[0], xb[:3], rR[r, rb], rw[r, rb], rdw[r, rb], cparams, st, u_cmd, dg)
            if not np.isfinite(u_cmd[0] + u_cmd[1] + u_cmd[2]):
                status = 2
                break
        sat = vscmg_command_one(
            ff, par, M, steer, sp, rate_limit, xb[:3], xb[3:], u_cmd, t, A, hdot, held[0]
        )  # fmt: skip
        if mm_at >= 0:
            # momentum management (as _one_spacecraft): the dipole held over this step from the
            # cluster's momentum at its start (Plant.held_dipole); zero while the log reads
            # the disturbance
            mh0, mh1, mh2 = vscmg_momentum_one(par, M, xb[3:])
            mp = dpb[mm_at:]
            md0, md1, md2 = KM.dipole(t, Rc[0], mh0, mh1, mh2, mp)
            KM.hold_dipole(mp, 0.0, 0.0, 0.0)
        if k % log_every == 0 or k == n_steps:
            Rb = Rc[0]
            for i in range(3):
                log_w[rows, b, i] = xb[i]
                log_wd[rows, b, i] = ref_w[r, rb, i]
                log_ucmd[rows, b, i] = u_cmd[i]
                for j in range(3):
                    log_R[rows, b, i, j] = Rb[i, j]
                    log_Rd[rows, b, i, j] = ref_R[r, rb, i, j]
            vscmg_derivatives_one(kin, var, False, False, par, M, xb[:3], xb[3:], held[0], zero,
                                  out, det)  # fmt: skip
            w0, w1, w2 = xb[0], xb[1], xb[2]
            a0, a1, a2 = out[0], out[1], out[2]
            # J ω̇ + ω × J ω (the bus inertia is M's first three columns)
            jw0 = w0 * M[0, 0] + w1 * M[0, 1] + w2 * M[0, 2]
            jw1 = w0 * M[1, 0] + w1 * M[1, 1] + w2 * M[1, 2]
            jw2 = w0 * M[2, 0] + w1 * M[2, 1] + w2 * M[2, 2]
            log_u[rows, b, 0] = (a0 * M[0, 0] + a1 * M[0, 1] + a2 * M[0, 2]) + (w1 * jw2 - w2 * jw1)
            log_u[rows, b, 1] = (a0 * M[1, 0] + a1 * M[1, 1] + a2 * M[1, 2]) + (w2 * jw0 - w0 * jw2)
            log_u[rows, b, 2] = (a0 * M[2, 0] + a1 * M[2, 1] + a2 * M[2, 2]) + (w0 * jw1 - w1 * jw0)
            if dist == K.DIST_KERNEL:
                dfn(t, Rb, xb[:3], dpb, dout)
                d0, d1, d2 = dout[0], dout[1], dout[2]
            else:
                d0, d1, d2 = K.disturbance_at(dist, dp, t)
            log_dist[rows, b, 0] = d0
            log_dist[rows, b, 1] = d1
            log_dist[rows, b, 2] = d2
            for i in range(4):
                log_vs[rows, b, _VS_DELTA, i] = xb[3 + i]
                log_vs[rows, b, _VS_RATE, i] = xb[7 + i]
                log_vs[rows, b, _VS_CMD, i] = held[0, 0, i]
                log_vs[rows, b, _VS_SPIN, i] = xb[11 + i]
                log_vs[rows, b, _VS_GT, i] = det[0, i]
                log_vs[rows, b, _VS_ST, i] = det[1, i]
                log_vs[rows, b, _VS_POWER, i] = det[3, i]
                log_vs[rows, b, _VS_TSAT, i] = det[2, i]
            log_work[rows, b] = xb[19]
            log_sat[rows, b] = sat
            for i in range(dg.shape[0]):
                log_diag[rows, b, i] = dg[i]
            if sensing is not None:
                for i in range(yb.shape[0]):
                    log_y[rows, b, i] = yb[i]
                for i in range(log_est.shape[2]):
                    log_est[rows, b, i] = sb[i]
            if mm_at >= 0:  # the management's log (the dipole held from t, m × B)
                KM.log_row(log_mm, rows, b, t, Rb, dpb[mm_at:], md0, md1, md2)
            rows += 1
        if k == n_steps:
            break
        if mm_at >= 0:
            KM.hold_dipole(dpb[mm_at:], md0, md1, md2)
        if dist == K.DIST_KERNEL:
            # a torque of the seam through its pointer: its own call site (as _one_spacecraft)
            vscmg_rkmk4_step_batch(
                kin, var, False, False, par, M, K.DIST_KERNEL, dp, dfn, dpk1, datt, t, Rc, xc,
                held, dt, Rn, xn,
            )  # fmt: skip
        else:
            vscmg_rkmk4_step_batch(
                kin, var, False, False, par, M, dist, dp, dfn, dpk1, False, t, Rc, xc, held, dt,
                Rn, xn,
            )  # fmt: skip
        total = 0.0
        for i in range(n):
            total += xn[0, i]
        for i in range(3):
            for j in range(3):
                total += Rn[0, i, j]
        if not np.isfinite(total):
            status = 1
            break
        Rc, Rn = Rn, Rc
        xc, xn = xn, xc
    R[b] = Rc[0]
    x[b] = xc[0]
    if buf.shape[0] == 0:  # the owner's last use (see _one_spacecraft)
        status = -1
    if sensing is not None:
        if s_tmp.shape[0] == 0:
            status = -1
    return status, t


@njit
def _fused_loop_vscmg(
    n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    kin: bool, var: bool, ff: bool, par: np.ndarray, M: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    steer: int, sp: np.ndarray, rate_limit: float,
    law: Any, cparams: np.ndarray, cstate: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_t: np.ndarray, log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_vs: np.ndarray, log_work: np.ndarray, log_sat: np.ndarray, log_diag: np.ndarray,
    diag: np.ndarray,
    s_int: np.ndarray, s_par: np.ndarray, pub_thr: np.ndarray, pub_sched: np.ndarray,
    noise: np.ndarray, sst: np.ndarray, sy: np.ndarray, h_int: np.ndarray, seen: np.ndarray,
    log_y: np.ndarray, log_est: np.ndarray, h_par: np.ndarray, h_state: np.ndarray,
    log_hook: np.ndarray, sensing: Any, mm_at: int, log_mm: np.ndarray,
) -> tuple[int, int, float]:  # fmt: skip
    """:func:`_fused_loop` for the full CMG model (:func:`_one_vscmg` per spacecraft)."""
    B = R.shape[0]
    st = np.zeros(B, dtype=np.int64)
    tf = np.full(B, np.inf)
    for b in range(B):
        st[b], tf[b] = _one_vscmg(
            b, n_steps, t0, dt, every_ctrl, log_every, R, x, kin, var, ff, par, M, dist, dp,
            dfn, dpk, datt, steer, sp, rate_limit, law, cparams, cstate, ref_index, ref_R, ref_w,
            ref_dw, log_R, log_w, log_Rd, log_wd, log_ucmd, log_u, log_dist, log_vs, log_work,
            log_sat, log_diag, diag, s_int, s_par, pub_thr, pub_sched, noise, sst, sy, h_int,
            seen, log_y, log_est, h_par, h_state, log_hook,
            sensing, mm_at, log_mm,
        )  # fmt: skip
    return _loop_result(st, tf, n_steps, t0, dt, log_every, log_t)


@njit(parallel=True)
def _fused_loop_vscmg_parallel(
    n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    kin: bool, var: bool, ff: bool, par: np.ndarray, M: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    steer: int, sp: np.ndarray, rate_limit: float,
    law: Any, cparams: np.ndarray, cstate: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_t: np.ndarray, log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_vs: np.ndarray, log_work: np.ndarray, log_sat: np.ndarray, log_diag: np.ndarray,
    diag: np.ndarray,
    s_int: np.ndarray, s_par: np.ndarray, pub_thr: np.ndarray, pub_sched: np.ndarray,
    noise: np.ndarray, sst: np.ndarray, sy: np.ndarray, h_int: np.ndarray, seen: np.ndarray,
    log_y: np.ndarray, log_est: np.ndarray, h_par: np.ndarray, h_state: np.ndarray,
    log_hook: np.ndarray, sensing: Any, mm_at: int, log_mm: np.ndarray,
) -> tuple[int, int, float]:  # fmt: skip
    """:func:`_fused_loop_vscmg` over numba's threads (bit-identical)."""
    B = R.shape[0]
    st = np.zeros(B, dtype=np.int64)
    tf = np.full(B, np.inf)
    for i in prange(B):
        b = np.int64(i)
        s, tb = _one_vscmg(
            b, n_steps, t0, dt, every_ctrl, log_every, R, x, kin, var, ff, par, M, dist, dp,
            dfn, dpk, datt, steer, sp, rate_limit, law, cparams, cstate, ref_index, ref_R, ref_w,
            ref_dw, log_R, log_w, log_Rd, log_wd, log_ucmd, log_u, log_dist, log_vs, log_work,
            log_sat, log_diag, diag, s_int, s_par, pub_thr, pub_sched, noise, sst, sy, h_int,
            seen, log_y, log_est, h_par, h_state, log_hook,
            sensing, mm_at, log_mm,
        )  # fmt: skip
        st[b] = s
        tf[b] = tb
    return _loop_result(st, tf, n_steps, t0, dt, log_every, log_t)


def _loop_entry(
    args: tuple, law_index: int, parallel: bool = False, vscmg: bool = False
) -> Callable[..., Any]:
    """The compiled :func:`_fused_loop` (``parallel``: :func:`_fused_loop_parallel`; ``vscmg``:
    the full CMG model's :func:`_fused_loop_vscmg`) for these argument types with the law typed
    as a first-class function of the seam's signature, the disturbance torque (argument 14) as
    one of :data:`spacecraft.disturbance_kernel.TORQUE_SIGNATURE` and, for the momentum model,
    the steering kernel (two places before the law) as one of
    :data:`spacecraft.steering_kernel.STEERING_SIGNATURE` (compiled once, cached on disk)."""
    if vscmg:
        loop = _fused_loop_vscmg_parallel if parallel else _fused_loop_vscmg
        return _fn_entry(loop, args, {14: _torque_sig(), law_index: seam.LAW_SIGNATURE})
    loop = _fused_loop_parallel if parallel else _fused_loop
    pointers = {14: _torque_sig(), law_index - 2: _steering_sig(), law_index: seam.LAW_SIGNATURE}
    return _fn_entry(loop, args, pointers)


def fused_supported(
    plant: Any,
    controller: Any,
    sensors: Any,
    measurement: Any,
    progress: bool,
    *,
    batch_size: int = 1,
    control_period: float | None = None,
    reasons: list[str] | None = None,
    **extra: Any,
) -> tuple[PlantKernel | VscmgPlan | WheelPlan, seam.ControllerKernel, FS.SensorPlan | None] | None:
    """``(plant kernel, controller kernel, sensor plan)`` when :func:`run_fused` applies — for
    a :class:`~spacecraft._kernels_wheels.WheelPlan`, :func:`spacecraft._fused_wheels.
    run_fused_wheels` — (the
    sensor plan ``None`` without sensors and hook: :func:`spacecraft._fused_sensors.
    sensor_plan`), else ``None`` — and then, when ``reasons`` is given, one sentence appended
    to it saying which part keeps the Python loop."""

    def no(why: str) -> None:
        if reasons is not None:
            reasons.append(why)

    if not JIT_ENABLED:
        return no("numba is not available (or LIECONTROL_DISABLE_JIT is set)")
    splan = None
    if sensors or measurement is not None:
        splan, why = FS.sensor_plan(sensors or (), measurement)
        if splan is None:
            return no(why)
    if progress:
        return no("the progress bar needs the Python loop")
    for name, v in extra.items():
        if v not in (None, 0, 0.0):
            return no(f"{name} = {v!r} needs the Python loop")
    pk = plant._kernel_plan
    if pk is None:
        why = ""
        if plant.momentum_management is not None:
            pk, why = momentum_plan(plant)
        if pk is None and not why:
            pk, why = _vscmg_support(plant)
            if pk is None and not why:
                pk, why = wheel_support(plant)  # reaction wheels (spacecraft._fused_wheels)
        if pk is None:
            return no(why or plant_reason(plant))
    spec, why = seam.resolve(controller, batch_size, control_period)
    if spec is None:
        return no(why)
    return pk, spec, splan


def _reference_samples(
    reference: Any, times: np.ndarray, needed: np.ndarray, B: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The reference at the step times where the loop reads it (``needed``), deduplicated and
    validated: ``(index per step, R_d (N, B', 3, 3), ω_d, ω̇_d)`` with B' = 1 when every sample
    is one attitude for the whole batch. ``None`` when a sample is not a valid reference (the
    Python loop then raises the controller's own error) or the samples would not fit."""
    from liecontrol._validation import check_rotation_matrix

    index = np.zeros(times.shape[0], dtype=np.int64)
    many = getattr(reference, "samples", None)
    if callable(many) and getattr(reference, "time_invariant", False) is not True:
        got = _vectorised_samples(many, times, needed, B)
        if got is not None:
            return got
        # the reference's own calls stay the ground truth: sampled one by one below
        logging.getLogger("spacecraft.simulator").info(
            "simulate: %s.samples() did not give valid arrays of the documented shapes "
            "(liecontrol.control.reference); the reference is sampled call by call",
            type(reference).__name__,
        )
    uniq: list[Any] = []
    last = None
    # a reference that declares itself time-invariant (ConstantAttitude) is sampled once: the
    # Python calls at every step cost as much as a compiled step of one spacecraft
    steps = np.flatnonzero(needed).tolist()
    if getattr(reference, "time_invariant", False) is True:
        steps = steps[:1]
    try:
        for k in steps:
            ref = reference(float(times[k]))
            if ref is not last:
                uniq.append(ref)
                last = ref
            index[k] = len(uniq) - 1
        R_l = [np.asarray(r.R_d, dtype=np.float64) for r in uniq]
        w_l = [np.asarray(r.omega_d, dtype=np.float64) for r in uniq]
        dw_l = [np.asarray(r.omega_dot_d, dtype=np.float64) for r in uniq]
        if all(len({a.shape for a in lst}) == 1 for lst in (R_l, w_l, dw_l)):
            # samples of one shape (the usual case): validated at once, not ~15 µs each
            got = _checked_stack(np.stack(R_l), np.stack(w_l), np.stack(dw_l), B)
            return None if got is None else (index, *got)
        arrays = []
        for r in uniq:
            R_d = check_rotation_matrix(r.R_d, "R_d")
            w_d = np.asarray(r.omega_d, dtype=np.float64)
            dw_d = np.asarray(r.omega_dot_d, dtype=np.float64)
            for a, nd in ((R_d, 2), (w_d, 1), (dw_d, 1)):
                if a.ndim not in (nd, nd + 1) or (a.ndim == nd + 1 and a.shape[0] != B):
                    return None
                if not np.all(np.isfinite(a)):
                    return None
            arrays.append((R_d, w_d, dw_d))
    except Exception:  # noqa: BLE001 - the Python loop reproduces (and reports) the failure
        return None
    batched = any(R.ndim == 3 or w.ndim == 2 or d.ndim == 2 for R, w, d in arrays)
    Bp = B if batched else 1
    if len(uniq) * Bp * 15 * 8 > _MAX_REFERENCE_BYTES:
        return None
    R_s = np.empty((len(uniq), Bp, 3, 3))
    w_s = np.empty((len(uniq), Bp, 3))
    dw_s = np.empty((len(uniq), Bp, 3))
    for i, (R_d, w_d, dw_d) in enumerate(arrays):
        R_s[i] = np.broadcast_to(R_d, (Bp, 3, 3))
        w_s[i] = np.broadcast_to(w_d, (Bp, 3))
        dw_s[i] = np.broadcast_to(dw_d, (Bp, 3))
    return index, R_s, w_s, dw_s


def _vectorised_samples(
    many: Any, times: np.ndarray, needed: np.ndarray, B: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """:func:`_reference_samples` through the reference's ``samples(times)`` (the sampling
    protocol of :mod:`liecontrol.control.reference`): one call for every needed step, the
    arrays validated at once; ``None`` (the Python loop reports the failure) for anything
    else than valid arrays of the documented shapes."""
    steps = np.flatnonzero(needed)
    try:
        R_d, w_d, dw_d = many(times[steps].copy())
        R_d = np.asarray(R_d, dtype=np.float64)
        w_d = np.asarray(w_d, dtype=np.float64)
        dw_d = np.asarray(dw_d, dtype=np.float64)
    except Exception:  # noqa: BLE001 - the Python loop reproduces (and reports) the failure
        return None
    if R_d.shape[:1] != steps.shape:
        return None
    got = _checked_stack(R_d, w_d, dw_d, B)
    if got is None:
        return None
    index = np.zeros(times.shape[0], dtype=np.int64)
    index[steps] = np.arange(steps.shape[0])
    return (index, *got)


def _checked_stack(
    R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray, B: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """N reference samples stacked on a leading axis — ``R_d`` ``(N, 3, 3)`` or ``(N, B, 3,
    3)``, ``ω_d``, ``ω̇_d`` ``(N, 3)`` or ``(N, B, 3)`` — validated at once (rotations, finite,
    shapes) and laid out as the loop reads them, ``(N, B', …)``; ``None`` if invalid or too
    large."""
    from liecontrol._validation import check_rotation_matrix

    N = R_d.shape[0]
    try:
        R_d = check_rotation_matrix(R_d, "R_d")
    except Exception:  # noqa: BLE001 - the Python loop reproduces (and reports) the failure
        return None
    if R_d.shape not in ((N, 3, 3), (N, B, 3, 3)):
        return None
    for a in (w_d, dw_d):
        if a.shape not in ((N, 3), (N, B, 3)) or not np.all(np.isfinite(a)):
            return None
    batched = R_d.ndim == 4 or w_d.ndim == 3 or dw_d.ndim == 3
    Bp = B if batched else 1
    if N * Bp * 15 * 8 > _MAX_REFERENCE_BYTES:
        return None
    R_s = np.ascontiguousarray(np.broadcast_to(R_d.reshape(N, -1, 3, 3), (N, Bp, 3, 3)))
    w_s = np.ascontiguousarray(np.broadcast_to(w_d.reshape(N, -1, 3), (N, Bp, 3)))
    dw_s = np.ascontiguousarray(np.broadcast_to(dw_d.reshape(N, -1, 3), (N, Bp, 3)))
    return R_s, w_s, dw_s


@dataclass(frozen=True)
class RunSetup:
    """What every compiled loop starts from (:func:`prepare_run`): the reference samples at the
    steps that need them, the initial state as float64 copies, the controller's checked
    parameters and state rows, the log (``Kr`` rows), the sensors' arrays, the seam torque's
    parameter rows and the log stride (capped at the run)."""

    index: np.ndarray
    ref_R: np.ndarray
    ref_w: np.ndarray
    ref_dw: np.ndarray
    R0: np.ndarray
    x0: np.ndarray
    cparams: np.ndarray
    cstate: np.ndarray
    Kr: int
    sa: Any
    log: Any
    dpk: np.ndarray
    log_every: int


def prepare_run(
    pk: Any, spec: seam.ControllerKernel, splan: FS.SensorPlan | None, controller: Any,
    reference: Any, R0: np.ndarray, x0: np.ndarray, t0: float, n_steps: int, dt: float,
    every_ctrl: int, log_every: int, make_log: Callable[..., Any],
    notes: list[str] | None, rng: np.random.Generator | None, measurement: Any,
    log_shapes: Callable[[int, int, Any], dict[str, tuple[tuple[int, ...], Any]]],
) -> RunSetup | None:  # fmt: skip
    """The part of :func:`run_fused` before the loop, shared by every plant's compiled loop
    (``pk`` a :class:`PlantKernel`, :class:`VscmgPlan` or the wheels' plan: anything with the
    disturbance fields and ``dist_rows``); ``None`` when the run must go through the Python
    loop (``notes`` says why). ``make_log(rows, B, extra)`` builds the simulator's log with the
    loop's own log arrays ``extra = log_shapes(rows, B, sensor_arrays)`` in the same
    allocation (:mod:`spacecraft._log_memory`)."""
    B = x0.shape[0]
    steps = np.arange(n_steps + 1)
    times = t0 + steps * dt
    # log_every beyond the run logs only the first and last steps (and must not overflow int64)
    log_every = min(log_every, n_steps + 1)
    needed = (steps % every_ctrl == 0) | (steps % log_every == 0)
    needed[-1] = True
    refs = _reference_samples(reference, times, needed, B)
    if refs is None:
        if notes is not None:
            notes.append("the reference could not be sampled for the compiled loop")
        return None
    index, ref_R, ref_w, ref_dw = refs
    R0 = np.array(R0, dtype=np.float64)
    x0 = np.array(x0, dtype=np.float64)
    # the first control sample (k = 0, before any step) is the probe of a non-finite torque
    cparams, cstate = seam.check(controller, spec, B, None)
    if spec.preflight is not None:
        # what command() would say of the initial state at its first sample, before any step
        spec.preflight(float(t0), R0, x0[:, :3], reference(float(t0)))
    Kr = n_steps // log_every + 1 + (1 if n_steps % log_every else 0)
    if splan is None:
        sa = FS.empty_arrays(B)
    else:
        for sensor in splan.sensors:
            if callable(getattr(sensor, "reset", None)):
                sensor.reset(B, rng)
        if measurement is not None and callable(getattr(measurement, "reset", None)):
            measurement.reset(t0, B)
        try:
            sa = FS.prepare(splan, rng, B, float(t0), float(dt), n_steps)
        except MemoryError:
            if notes is not None:
                notes.append("the sensors' noise of this run does not fit in memory")
            return None
    log = make_log(Kr, B, log_shapes(Kr, B, sa))
    dpk = pk.dist_rows(B)
    if pk.dist == K.DIST_KERNEL:
        # the torque once on the initial state, before any step (spacecraft.disturbance_kernel)
        from .disturbance_kernel import DisturbanceKernel, check

        spec_d = DisturbanceKernel(pk.dist_fn, dpk[0], pk.dist_attitude)
        check(pk.disturbance, spec_d, None, (float(t0), R0[0], x0[0, :3]))
    return RunSetup(
        index, ref_R, ref_w, ref_dw, R0, x0, cparams, cstate, Kr, sa, log, dpk, log_every
    )


def run_fused(
    plan: tuple[PlantKernel | VscmgPlan, seam.ControllerKernel, FS.SensorPlan | None],
    plant: Any,
    controller: Any,
    reference: Any,
    R0: np.ndarray,
    x0: np.ndarray,
    t0: float,
    n_steps: int,
    dt: float,
    every_ctrl: int,
    log_every: int,
    control_period: float,
    make_log: Callable[[int, int], Any],
    notes: list[str] | None = None,
    workers: int = 1,
    rng: np.random.Generator | None = None,
    measurement: Any = None,
) -> Any:
    """The whole run in :func:`_fused_loop`; returns the
    :class:`~spacecraft.simulator.SimulationResult`, or ``None`` when the run must go through
    the Python loop instead (an invalid reference, or a run that fails: the Python loop
    reports the failure with its partial log; ``notes`` then gets one sentence why).
    ``make_log(rows, B)`` builds the simulator's log. Raises ``ValueError`` naming the
    controller and the argument when its kernel is malformed (:func:`liecontrol.control.
    kernel.check`).

    With sensors (``plan[2]``), the sensors are reset (``reset(B, rng)``, then the hook's
    ``reset(t0, B)``, as the Python loop does) and their noise is drawn from ``rng`` before the
    loop (:func:`spacecraft._fused_sensors.draw_noise`); a caller that falls back to the Python
    loop restores ``rng``'s state first."""
    pk, spec = plan[0], plan[1]
    splan = plan[2] if len(plan) > 2 else None
    B, n = x0.shape
    n_diag = int(spec.n_diag)
    f8, b1 = np.float64, np.bool_

    def log_shapes(Kr: int, B: int, sa: Any) -> dict[str, tuple[tuple[int, ...], Any]]:
        common = {
            "diag": ((Kr, B, n_diag), f8),
            "y": ((Kr, B, sa.y.shape[1]), f8),
            "est": ((Kr, B, sa.n_est), f8),
        }
        if isinstance(pk, VscmgPlan):
            return {
                **common,
                "vs": ((Kr, B, 8, 4), f8),
                "work": ((Kr, B), f8),
                "sat": ((Kr, B), b1),
                "mm": ((Kr if pk.mm_at >= 0 else 0, B, 6), f8),
            }
        n_held = 3 if pk.act == K.ACT_IDEAL else n - 3
        return {
            **common,
            "act": ((Kr, B, (n - 3) + n_held), f8),
            "sat": ((Kr, B, 3 if pk.act == K.ACT_IDEAL else 1), b1),
            # h (3), singularity measure
            "hm": ((Kr, B, 4 if pk.act == K.ACT_SGCMG else 0), f8),
            # dipole, magnetic torque
            "mm": ((Kr if pk.mm_at >= 0 else 0, B, 6), f8),
        }

    setup = prepare_run(
        pk, spec, splan, controller, reference, R0, x0, t0, n_steps, dt, every_ctrl, log_every,
        make_log, notes, rng, measurement, log_shapes,
    )  # fmt: skip
    if setup is None:
        return None
    index, ref_R, ref_w, ref_dw = setup.index, setup.ref_R, setup.ref_w, setup.ref_dw
    R0, x0, cparams, cstate = setup.R0, setup.x0, setup.cparams, setup.cstate
    Kr, sa, log, dpk, log_every = setup.Kr, setup.sa, setup.log, setup.dpk, setup.log_every
    if isinstance(pk, VscmgPlan):
        return _run_vscmg(
            pk, spec, plant, controller, index, ref_R, ref_w, ref_dw, R0, x0, t0, n_steps, dt,
            every_ctrl, log_every, control_period, log, Kr, cparams, cstate, notes, workers, sa,
            splan, measurement, dpk,
        )  # fmt: skip
    ex = log.extra
    log_act, log_sat, log_hm, log_mm = ex["act"], ex["sat"], ex["hm"], ex["mm"]
    log_diag, log_y, log_est = ex["diag"], ex["y"], ex["est"]
    diag = np.zeros((B, n_diag))
    log_hook = FS.hook_log(sa, n_steps, every_ctrl, B)
    clip = pk.clip if pk.clip is not None else np.zeros(3)
    args = (
        n_steps, float(t0), float(dt), every_ctrl, log_every, R0, x0,
        pk.act, pk.J, pk.J_inv, pk.S0, pk.C0, pk.dist, pk.dist_params, pk.dist_fn, dpk,
        pk.dist_attitude, pk.clip is not None, clip, pk.steer, pk.steer_params, _steer_fn(pk),
        pk.rate_limit,
        spec.law, cparams, cstate, index, ref_R, ref_w, ref_dw,
        log.t, log.R, log.omega, log.R_d, log.omega_d, log.u_cmd, log.u, log.disturbance,
        log_act, log_sat, log_hm, log_diag, diag,
        sa.s_int, sa.s_par, sa.pub_thr, sa.pub_sched, sa.noise, sa.state, sa.y, sa.h_int,
        sa.seen, log_y, log_est, sa.h_par, sa.h_state, log_hook,
        FS.sensing_marker(splan), pk.mm_at, log_mm,
    )  # fmt: skip
    status, rows, t_fail = _call_loop(args, 23, workers, B, vscmg=False)
    if not _finished(status, t_fail, t0, controller, spec, notes):
        return None
    log.rows = rows
    d = log.dicts
    if splan is not None:
        FS.finish(splan, sa, log_y, log_est, d, B, n_steps)
        FS.finish_hook(splan, sa, log_hook, measurement)
    if pk.act == K.ACT_SGCMG:
        d["actuator"]["delta"] = log_act[:, :, : n - 3]
        d["actuator"]["delta_dot"] = log_act[:, :, n - 3 :]
        d["actuator"]["saturated"] = log_sat[:, :, 0]
    elif pk.clip is not None:
        d["actuator"]["saturated"] = log_sat
    if pk.mm_at >= 0:  # after the actuator's own entries, as the Python loop puts them
        d["actuator"]["dipole"] = log_mm[:, :, :3]
        d["actuator"]["magnetic_torque"] = log_mm[:, :, 3:]
    if pk.act == K.ACT_SGCMG:  # in SgcmgActuator.derived_log's order
        d["actuator"]["singularity"] = log_hm[:, :, 3]
        d["actuator"]["h"] = log_hm[:, :, :3]
    d["controller"].update(spec.diagnostics(log_diag))
    spec.finish(cstate, diag.copy())
    _log_components(pk, log, rows, B)
    return log.result(dt, control_period, plant)


@njit
def _torque_rows(
    torque: Any, params: np.ndarray, t: np.ndarray, R: np.ndarray, omega: np.ndarray,
    out: np.ndarray,
) -> None:  # fmt: skip
    """``out[k, b] = torque(t[k], R[k, b], omega[k, b], params[b])`` (``params`` one shared row
    or one per spacecraft): a seam torque over the log's rows."""
    Rk = np.empty((3, 3))
    wk = np.empty(3)
    o = np.empty(3)
    for k in range(out.shape[0]):
        for b in range(out.shape[1]):
            for i in range(3):
                wk[i] = omega[k, b, i]
                for j in range(3):
                    Rk[i, j] = R[k, b, i, j]
            torque(t[k], Rk, wk, params[0 if params.shape[0] == 1 else b], o)
            for i in range(3):
                out[k, b, i] = o[i]


def _log_components(pk: PlantKernel | VscmgPlan, log: Any, rows: int, B: int) -> None:
    """A seam disturbance's per-source log (:func:`_component_rows`) into the log's
    ``disturbance_components``."""
    if pk.dist == K.DIST_KERNEL:
        comps = _component_rows(pk.disturbance, log, rows, B)
        if comps:
            log.dicts["disturbance_components"].update(comps)


def _component_rows(dist: Any, log: Any, rows: int, B: int) -> dict[str, np.ndarray]:
    """The log of each source of a :class:`~spacecraft.disturbances.SumOfDisturbances` by name
    (the Python loop's ``disturbance_components``, :meth:`SumOfDisturbances.components` at every
    log row): each source's own kernel at the logged time, attitude and rate, after the run."""
    from .disturbance_kernel import check, resolve
    from .disturbances import SumOfDisturbances

    if not isinstance(dist, SumOfDisturbances):
        return {}
    t = np.ascontiguousarray(log.t[:rows])
    R = np.ascontiguousarray(log.R[:rows])
    w = np.ascontiguousarray(log.omega[:rows])
    out: dict[str, np.ndarray] = {}
    for name, src in dist.sources.items():
        spec, _ = resolve(src)  # every source has one: the sum's kernel was built from them
        params = check(src, spec, B)
        comp = np.empty((rows, B, 3))
        args = (spec.torque, params, t, R, w, comp)
        _fn_entry(_torque_rows, args, {0: _torque_sig()})(*args)
        out[name] = comp
    return out


def _call_loop(args: tuple, law_index: int, workers: int, B: int, vscmg: bool) -> Any:
    """Run the compiled loop on ``args``: over ``workers`` threads (numba's, this thread's
    setting restored after) when more than one and more than one spacecraft."""
    if workers > 1 and B > 1:
        import numba

        entry = _loop_entry(args, law_index, parallel=True, vscmg=vscmg)
        previous = numba.get_num_threads()
        numba.set_num_threads(min(workers, B))  # this thread's setting only (numba's rule)
        try:
            return entry(*args)
        finally:
            numba.set_num_threads(previous)
    return _loop_entry(args, law_index, vscmg=vscmg)(*args)


def _finished(
    status: int, t_fail: float, t0: float, controller: Any, spec: seam.ControllerKernel,
    notes: list[str] | None,
) -> bool:  # fmt: skip
    """Whether the compiled run finished; a law's non-finite torque at the first sample raises,
    another failure adds its sentence to ``notes`` (the run is repeated in the Python loop)."""
    if status == 2 and t_fail == t0:
        raise seam.non_finite_error(controller, spec, t0)
    if status != 0:
        if notes is not None:
            what = "the state became non-finite" if status == 1 else (
                f"controller {type(controller).__name__}'s compiled law returned a non-finite "
                "torque"
            ) if status not in (3, 4) else (
                "the estimator hook's covariance lost positive definiteness (the numpy filter "
                "repairs it)"
            ) if status == 3 else (
                "a TwoVectorAttitude's measured directions were parallel (TRIAD undetermined)"
            )  # fmt: skip
            notes.append(f"{what} at t = {t_fail!r}; the run is repeated in the Python loop")
        return False
    return True


def _run_vscmg(
    vp: VscmgPlan, spec: seam.ControllerKernel, plant: Any, controller: Any,
    index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    R0: np.ndarray, x0: np.ndarray, t0: float, n_steps: int, dt: float, every_ctrl: int,
    log_every: int, control_period: float, log: Any, Kr: int, cparams: np.ndarray,
    cstate: np.ndarray, notes: list[str] | None, workers: int, sa: FS.SensorArrays,
    splan: FS.SensorPlan | None, measurement: Any, dpk: np.ndarray,
) -> Any:  # fmt: skip
    """:func:`run_fused` for the full CMG model (:func:`_fused_loop_vscmg`); ``dpk`` the seam
    torque's parameter rows for the batch."""
    B = x0.shape[0]
    diag = np.zeros((B, int(spec.n_diag)))
    ex = log.extra  # carved with the simulator's log (run_fused's log_shapes)
    log_diag, log_vs, log_work, log_sat = ex["diag"], ex["vs"], ex["work"], ex["sat"]
    log_y, log_est, log_mm = ex["y"], ex["est"], ex["mm"]
    log_hook = FS.hook_log(sa, n_steps, every_ctrl, B)
    args = (
        n_steps, float(t0), float(dt), every_ctrl, log_every, R0, x0,
        vp.kinematic, vp.variable_speed, vp.feedforward, vp.par, vp.M, vp.dist, vp.dist_params,
        vp.dist_fn, dpk, vp.dist_attitude, vp.steer, vp.steer_params, vp.rate_limit,
        spec.law, cparams, cstate, index, ref_R, ref_w, ref_dw,
        log.t, log.R, log.omega, log.R_d, log.omega_d, log.u_cmd, log.u, log.disturbance,
        log_vs, log_work, log_sat, log_diag, diag,
        sa.s_int, sa.s_par, sa.pub_thr, sa.pub_sched, sa.noise, sa.state, sa.y, sa.h_int,
        sa.seen, log_y, log_est, sa.h_par, sa.h_state, log_hook,
        FS.sensing_marker(splan), vp.mm_at, log_mm,
    )  # fmt: skip
    status, rows, t_fail = _call_loop(args, 20, workers, B, vscmg=True)
    if not _finished(status, t_fail, t0, controller, spec, notes):
        return None
    log.rows = rows
    if splan is not None:
        FS.finish(splan, sa, log_y, log_est, log.dicts, B, n_steps)
        FS.finish_hook(splan, sa, log_hook, measurement)
    a = log.dicts["actuator"]
    a["delta"] = log_vs[:, :, _VS_DELTA]
    a["delta_dot"] = log_vs[:, :, _VS_RATE]
    a["delta_dot_cmd"] = log_vs[:, :, _VS_CMD]
    a["wheel_speed"] = log_vs[:, :, _VS_SPIN]
    a["gimbal_torque"] = log_vs[:, :, _VS_GT]
    a["spin_torque"] = log_vs[:, :, _VS_ST]
    a["gimbal_power"] = log_vs[:, :, _VS_POWER]
    a["actuator_work"] = log_work
    a["saturated"] = log_sat
    a["torque_saturated"] = log_vs[:, :, _VS_TSAT] > 0.5
    a["stop_contact"] = np.zeros((Kr, B, 4), dtype=np.bool_)
    a["stop_limited"] = np.zeros((Kr, B, 4), dtype=np.bool_)
    if vp.mm_at >= 0:  # after the actuator's own entries, as the Python loop puts them
        a["dipole"] = log_mm[:, :, :3]
        a["magnetic_torque"] = log_mm[:, :, 3:]
    log.dicts["controller"].update(spec.diagnostics(log_diag))
    spec.finish(cstate, diag.copy())
    _log_components(vp, log, rows, B)
    return log.result(dt, control_period, plant)
