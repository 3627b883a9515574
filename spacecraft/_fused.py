"""Compiled routes of the simulator: the plant's kernel plan (which per-step kernels a plant
can run on) and the fused closed loop.

A plant has a kernel plan when its parts all have kernels (:mod:`spacecraft._kernels`): a rigid
body (shared or per-spacecraft inertia, no flexible modes, no momentum management), an
:class:`~spacecraft.actuators.IdealTorqueActuator` or an
:class:`~spacecraft.actuators.SgcmgActuator` with the ideal gimbal servo and a pseudo-inverse,
singularity-robust or generalized singularity-robust steering law, and no disturbance, a
:class:`~spacecraft.disturbances.ConstantTorque` (one torque for the batch) or a
:class:`~spacecraft.disturbances.ConstantHarmonicTorque`. Exact types only: a subclass may
override the formulas, so it keeps the numpy route.

:func:`run_fused` runs a whole :func:`spacecraft.simulator.simulate` call in compiled code when,
in addition, the controller has a kernel (:class:`liecontrol.control.GeometricPD`) and no
sensors, measurement hook, progress bar or compute delay are used. It produces the same
:class:`~spacecraft.simulator.SimulationResult` as the per-step Python loop, which calls the
same kernels one at a time. Anything else — a user's own Python controller, a Python
disturbance — runs through that loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._jit import JIT_ENABLED, njit
from liecontrol._kernels.finite_time import finite_time_one
from liecontrol._kernels.geometric_pd import geometric_pd_one
from liecontrol._kernels.mrp_pd import mrp_pd_one
from liecontrol._kernels.quaternion_pd import quaternion_pd_one

from . import _kernels as K

#: reference samples held in memory by the fused loop at most (else the Python loop runs)
_MAX_REFERENCE_BYTES = 256 * 2**20


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

    def step(
        self, t: float, R: np.ndarray, x: np.ndarray, held: np.ndarray, h: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """One RKMK4 step of the batch ``R (B, 3, 3)``, ``x (B, n)``, held command ``(B, m)``."""
        R_out = np.empty(R.shape)
        x_out = np.empty(x.shape)
        K.rkmk4_step_batch(
            self.act, self.J, self.J_inv, self.S0, self.C0, self.dist, self.dist_params,
            float(t), R, x, held, float(h), R_out, x_out,
        )  # fmt: skip
        return R_out, x_out


@njit
def _hold_steps(
    n_sub: int, t: float, dt: float, R: np.ndarray, x: np.ndarray, u: np.ndarray,
    act: int, J: np.ndarray, J_inv: np.ndarray, S0: np.ndarray, C0: np.ndarray,
    dist: int, dp: np.ndarray, clip_on: bool, clip: np.ndarray,
    steer: int, sp: np.ndarray, rate_limit: float, saturated: np.ndarray,
) -> None:  # fmt: skip
    """``n_sub`` steps of the batch under the torque command ``u (B, 3)`` held throughout (the
    actuator's hardware command recomputed at every step, as the simulator does); ``R``, ``x``
    advance in place and ``saturated[b]`` counts the steps whose command was limited."""
    B, n = x.shape
    shared = J.shape[0] == 1
    held = np.empty(3 if act == K.ACT_IDEAL else n - 3)
    hd = np.empty(3)
    work = np.empty(7 * n)
    A = np.empty((3, max(n - 3, 1)))
    # the command's sin/cos of the gimbal angles land where the step's first stage reads them
    sn = work[5 * n : 5 * n + max(n - 3, 1)]
    cs = work[6 * n : 6 * n + max(n - 3, 1)]
    R_next = np.empty((3, 3))
    x_next = np.empty(n)
    for b in range(B):
        kb = 0 if shared else b
        for _ in range(n_sub):
            if act == K.ACT_SGCMG:
                if K.sgcmg_command(
                    S0, C0, steer, sp, rate_limit, u[b], x[b, :3], x[b, 3:], t, held, hd, A,
                    sn, cs,
                ):  # fmt: skip
                    saturated[b] += 1.0
            else:
                limited = False
                for i in range(3):
                    v = u[b, i]
                    if clip_on:
                        v = min(max(v, -clip[i]), clip[i])
                        limited = limited or abs(v) >= clip[i]
                    held[i] = v
                if limited:
                    saturated[b] += 1.0
            K.rkmk4_step(
                act, J[kb], J_inv[kb], S0, C0, dist, dp, t, R[b], x[b], held, dt, R_next,
                x_next, work, act == K.ACT_SGCMG,
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
    _hold_steps(
        int(n_sub), float(t), float(dt), R, x, np.ascontiguousarray(u, dtype=np.float64),
        pk.act, pk.J, pk.J_inv, pk.S0, pk.C0, pk.dist, pk.dist_params, pk.clip is not None,
        clip, pk.steer, pk.steer_params, pk.rate_limit, sat,
    )  # fmt: skip
    return R, x, sat


def steering_kernel(law: Any, cluster: Any = None) -> tuple[int, np.ndarray] | None:
    """``(code, params)`` of a steering law with a kernel, else ``None``. The null-motion law
    needs the ``cluster`` (an :class:`~spacecraft.sgcmg.SgcmgPyramid`) it steers."""
    from .sgcmg import MEASURE_FLOOR
    from .steering import (
        PINV_EPS,
        GeneralizedSingularityRobust,
        PseudoInverse,
        PseudoInverseNullMotion,
        SingularityRobust,
    )

    kind = type(law)
    if kind is PseudoInverse:
        return K.STEER_PINV, np.array([0.0, 0.0, law.eps, 0.0, 0.0, 0.0, 0.0, 0.0])
    if kind is SingularityRobust:
        return K.STEER_SR, np.array([law.lambda0, law.mu, PINV_EPS, 0.0, 0.0, 0.0, 0.0, 0.0])
    if kind is GeneralizedSingularityRobust:
        p = [law.lambda0, law.mu, PINV_EPS, law.epsilon0, law.omega_eps, *law.phases]
        return K.STEER_GSR, np.array(p, dtype=np.float64)
    if kind is PseudoInverseNullMotion and cluster is not None:
        head = [law.k, law.eps, MEASURE_FLOOR, 0.0, 0.0, 0.0, 0.0, 0.0]
        unit = np.concatenate([np.ravel(cluster._S), np.ravel(cluster._C)])
        return K.STEER_PINV_NULL, np.concatenate([np.array(head), unit])
    return None


def _disturbance_kernel(dist: Any) -> tuple[int, np.ndarray] | None:
    from .disturbances import ConstantHarmonicTorque, ConstantTorque

    if dist is None:
        return K.DIST_NONE, np.zeros(3)
    if type(dist) is ConstantHarmonicTorque:
        return K.DIST_CONSTANT_HARMONIC, np.array([dist.n, dist.scale, 0.0])
    if type(dist) is ConstantTorque and np.shape(dist.torque) == (3,):
        return K.DIST_CONSTANT, np.array(dist.torque, dtype=np.float64)
    return None


def plant_kernel(plant: Any) -> PlantKernel | None:
    """The :class:`PlantKernel` of a :class:`spacecraft.plant.Spacecraft`, or ``None`` when a
    part has no kernel."""
    from .actuators import IdealTorqueActuator, SgcmgActuator

    if plant.modes is not None or plant.momentum_management is not None:
        return None
    dist = _disturbance_kernel(plant.disturbance)
    if dist is None:
        return None
    act = plant.actuator
    clip = None
    steer, sp, limit = K.STEER_PINV, np.zeros(8), np.inf
    S0 = C0 = np.zeros((3, 0))
    if type(act) is IdealTorqueActuator:
        code = K.ACT_IDEAL
        if act.max_torque is not None:
            clip = np.broadcast_to(np.asarray(act.max_torque, dtype=np.float64), (3,)).copy()
    elif type(act) is SgcmgActuator:
        if act.servo != "ideal" or act._fast is None:
            return None
        s = steering_kernel(act.steering, act.cluster)
        if s is None:
            return None
        code = K.ACT_SGCMG
        steer, sp = s
        limit = act.rate_limit
        S0, C0 = np.ascontiguousarray(act._S0), np.ascontiguousarray(act._C0)
    else:
        return None
    J = plant.body.J
    J_inv = plant.body.J_inv
    J3 = np.ascontiguousarray(J.reshape(-1, 3, 3))
    Ji3 = np.ascontiguousarray(J_inv.reshape(-1, 3, 3))
    return PlantKernel(code, J3, Ji3, S0, C0, dist[0], dist[1], clip, steer, sp, float(limit))


#: controller kinds of the fused loop
CTRL_GEOMETRIC_PD = 0
CTRL_MRP_PD = 1
CTRL_FINITE_TIME = 2
CTRL_QUATERNION_PD = 3
#: width of the diagnostics rows the fused loop logs (the widest controller's)
_DIAG_WIDTH = 11


def controller_kernel(controller: Any) -> tuple | None:
    """``(kind, code, threshold², J, gain 1, gain 2, G)`` of a controller with a kernel
    (:class:`~liecontrol.control.GeometricPD`: error code, K_R, K_Ω, G;
    :class:`~liecontrol.control.MrpPD`: feed-forward code, threshold², K, P), else ``None``."""
    from liecontrol.control.chart_baselines import MrpPD, QuaternionPD
    from liecontrol.control.finite_time import FiniteTimeSO3, FixedTimeSO3
    from liecontrol.control.geometric_pd import GeometricPD

    zero3, none = np.zeros((3, 3)), np.zeros(1)
    if type(controller) is GeometricPD:
        err, J, kR, kW, G = controller._kernel_args()
        return CTRL_GEOMETRIC_PD, err, 0.0, J, kR, kW, G, none
    if type(controller) is MrpPD and controller._kernel_applies():
        ff, thr2, J, K, P = controller._kernel_args()
        return CTRL_MRP_PD, ff, thr2, J, K, P, zero3, none
    if type(controller) is QuaternionPD and controller._kernel_applies():
        mode, hyst, J, Kp, Kd = controller._kernel_args()
        return CTRL_QUATERNION_PD, mode, hyst, J, Kp, Kd, zero3, none
    if type(controller) in (FiniteTimeSO3, FixedTimeSO3):
        J, prm = controller._kernel_args()
        return CTRL_FINITE_TIME, 0, 0.0, J, zero3, zero3, zero3, prm
    return None


@njit
def _fused_loop(
    n_steps: int, t0: float, dt: float, every_ctrl: int, log_every: int,
    R: np.ndarray, x: np.ndarray,
    act: int, J: np.ndarray, J_inv: np.ndarray, S0: np.ndarray, C0: np.ndarray,
    dist: int, dp: np.ndarray, clip_on: bool, clip: np.ndarray,
    steer: int, sp: np.ndarray, rate_limit: float,
    ckind: int, code: int, thr2: float, cJ: np.ndarray, k1: np.ndarray, k2: np.ndarray,
    G: np.ndarray, cprm: np.ndarray, p_prev: np.ndarray,
    ref_index: np.ndarray, ref_R: np.ndarray, ref_w: np.ndarray, ref_dw: np.ndarray,
    log_t: np.ndarray, log_R: np.ndarray, log_w: np.ndarray, log_Rd: np.ndarray,
    log_wd: np.ndarray, log_ucmd: np.ndarray, log_u: np.ndarray, log_dist: np.ndarray,
    log_act: np.ndarray, log_sat: np.ndarray, log_diag: np.ndarray, diag: np.ndarray,
) -> tuple[int, int, int]:  # fmt: skip
    """The closed loop of :func:`spacecraft.simulator.simulate` for ``B`` spacecraft: control at
    every ``every_ctrl``-th step (zero-order hold), the actuator's command, a log row every
    ``log_every``-th step and at the end, one RKMK4 step. Returns ``(status, rows, switches)``:
    status 0 = done, 1 = state non-finite, 2 = non-finite torque; the MRP shadow switches.
    The MRP controller's continuity memory ``p_prev`` starts empty (first sample) and is left
    holding its last σ."""
    B = R.shape[0]
    n = x.shape[1]
    n_held = 3 if act == K.ACT_IDEAL else n - 3
    shared = J.shape[0] == 1
    u_cmd = np.zeros((B, 3))
    held = np.zeros((B, n_held))
    hd = np.empty(3)
    # saturation flags as logged: per axis (ideal actuator), one per spacecraft (SGCMG)
    sat = np.zeros((B, 3 if act == K.ACT_IDEAL else 1), dtype=np.bool_)
    R_next = np.empty((B, 3, 3))
    x_next = np.empty((B, n))
    work = np.empty(7 * n)
    A = np.empty((3, max(n - 3, 1)))
    scratch = np.empty(2 * max(n - 3, 1))
    # sin/cos of every spacecraft's gimbal angles from its command, reused by its step
    trig = np.empty((B, 2, max(n - 3, 1)))
    rows = 0
    n_switch = 0
    for k in range(n_steps + 1):
        t = t0 + k * dt
        r = ref_index[k]
        if k % every_ctrl == 0:
            for b in range(B):
                rb = b if ref_R.shape[1] > 1 else 0
                if ckind == CTRL_FINITE_TIME:
                    finite_time_one(
                        cJ, cprm, R[b], x[b, :3], ref_R[r, rb], ref_w[r, rb], ref_dw[r, rb],
                        u_cmd[b], diag[b],
                    )  # fmt: skip
                elif ckind == CTRL_QUATERNION_PD:
                    quaternion_pd_one(
                        code, thr2, cJ, k1, k2, R[b], x[b, :3], ref_R[r, rb], ref_w[r, rb],
                        ref_dw[r, rb], p_prev[b], u_cmd[b], diag[b],
                    )  # fmt: skip
                elif ckind == CTRL_MRP_PD:
                    n_switch += mrp_pd_one(
                        code, thr2, cJ, k1, k2, R[b], x[b, :3], ref_R[r, rb], ref_w[r, rb],
                        ref_dw[r, rb], k > 0, p_prev[b], u_cmd[b], diag[b],
                    )  # fmt: skip
                else:
                    geometric_pd_one(
                        code, cJ, k1, k2, G, R[b], x[b, :3], ref_R[r, rb], ref_w[r, rb],
                        ref_dw[r, rb], u_cmd[b], diag[b],
                    )  # fmt: skip
                tot = u_cmd[b, 0] + u_cmd[b, 1] + u_cmd[b, 2]
                if not np.isfinite(tot):
                    return 2, rows, n_switch
        for b in range(B):
            if act == K.ACT_SGCMG:
                sat[b, 0] = K.sgcmg_command(
                    S0, C0, steer, sp, rate_limit, u_cmd[b], x[b, :3], x[b, 3:], t, held[b], hd,
                    A, trig[b, 0], trig[b, 1],
                )  # fmt: skip
            else:
                for i in range(3):
                    v = u_cmd[b, i]
                    if clip_on:
                        v = min(max(v, -clip[i]), clip[i])
                        sat[b, i] = abs(v) >= clip[i]
                    held[b, i] = v
        if k % log_every == 0 or k == n_steps:
            log_t[rows] = t
            for b in range(B):
                rb = b if ref_R.shape[1] > 1 else 0
                for i in range(3):
                    log_w[rows, b, i] = x[b, i]
                    log_wd[rows, b, i] = ref_w[r, rb, i]
                    log_ucmd[rows, b, i] = u_cmd[b, i]
                    for j in range(3):
                        log_R[rows, b, i, j] = R[b, i, j]
                        log_Rd[rows, b, i, j] = ref_R[r, rb, i, j]
                u0, u1, u2 = K.actuator_torque(
                    act, S0, C0, x[b, 0], x[b, 1], x[b, 2], x[b], 3, held[b], scratch
                )
                log_u[rows, b, 0] = u0
                log_u[rows, b, 1] = u1
                log_u[rows, b, 2] = u2
                d0, d1, d2 = K.disturbance_at(dist, dp, t)
                log_dist[rows, b, 0] = d0
                log_dist[rows, b, 1] = d1
                log_dist[rows, b, 2] = d2
                for i in range(n - 3):
                    log_act[rows, b, i] = x[b, 3 + i]
                for i in range(n_held):
                    log_act[rows, b, n - 3 + i] = held[b, i]
                for i in range(sat.shape[1]):
                    log_sat[rows, b, i] = sat[b, i]
                for i in range(diag.shape[1]):
                    log_diag[rows, b, i] = diag[b, i]
            rows += 1
        if k == n_steps:
            break
        for b in range(B):
            kb = 0 if shared else b
            ready = act == K.ACT_SGCMG
            if ready:
                for i in range(n - 3):
                    work[5 * n + i] = trig[b, 0, i]
                    work[6 * n + i] = trig[b, 1, i]
            K.rkmk4_step(
                act, J[kb], J_inv[kb], S0, C0, dist, dp, t, R[b], x[b], held[b], dt,
                R_next[b], x_next[b], work, ready,
            )  # fmt: skip
        total = 0.0
        for b in range(B):
            for i in range(n):
                total += x_next[b, i]
            for i in range(3):
                for j in range(3):
                    total += R_next[b, i, j]
        if not np.isfinite(total):
            return 1, rows, n_switch
        R, R_next = R_next, R
        x, x_next = x_next, x
    return 0, rows, n_switch


def fused_supported(
    plant: Any, controller: Any, sensors: Any, measurement: Any, progress: bool, **extra: Any
) -> tuple[PlantKernel, tuple] | None:
    """The plant and controller kernels when :func:`run_fused` applies, else ``None``."""
    if not JIT_ENABLED or sensors or measurement is not None or progress:
        return None
    if any(v not in (None, 0, 0.0) for v in extra.values()):
        return None
    pk = plant._kernel_plan
    if pk is None:
        return None
    ck = controller_kernel(controller)
    if ck is None:
        return None
    return pk, ck


def _reference_samples(
    reference: Any, times: np.ndarray, needed: np.ndarray, B: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The reference at the step times where the loop reads it (``needed``), deduplicated and
    validated: ``(index per step, R_d (N, B', 3, 3), ω_d, ω̇_d)`` with B' = 1 when every sample
    is one attitude for the whole batch. ``None`` when a sample is not a valid reference (the
    Python loop then raises the controller's own error) or the samples would not fit."""
    from liecontrol._validation import check_rotation_matrix

    index = np.zeros(times.shape[0], dtype=np.int64)
    uniq: list[Any] = []
    last = None
    try:
        for k in np.flatnonzero(needed).tolist():
            ref = reference(float(times[k]))
            if ref is not last:
                uniq.append(ref)
                last = ref
            index[k] = len(uniq) - 1
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


def run_fused(
    plan: tuple[PlantKernel, tuple],
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
) -> Any:
    """The whole run in :func:`_fused_loop`; returns the
    :class:`~spacecraft.simulator.SimulationResult`, or ``None`` when the run must go through
    the Python loop instead (an invalid reference, or a run that fails: the Python loop
    reports the failure with its partial log)."""
    from .simulator import _Log

    pk, (ckind, code, thr2, cJ, k1, k2, G, cprm) = plan
    B, n = x0.shape
    steps = np.arange(n_steps + 1)
    times = t0 + steps * dt
    # log_every beyond the run logs only the first and last steps (and must not overflow int64)
    log_every = min(log_every, n_steps + 1)
    needed = (steps % every_ctrl == 0) | (steps % log_every == 0)
    needed[-1] = True
    refs = _reference_samples(reference, times, needed, B)
    if refs is None:
        return None
    index, ref_R, ref_w, ref_dw = refs
    Kr = n_steps // log_every + 1 + (1 if n_steps % log_every else 0)
    log = _Log(Kr, B)
    n_held = 3 if pk.act == K.ACT_IDEAL else n - 3
    log_act = np.empty((Kr, B, (n - 3) + n_held))
    n_sat = 3 if pk.act == K.ACT_IDEAL else 1
    log_sat = np.empty((Kr, B, n_sat), dtype=np.bool_)
    diag = np.zeros((B, _DIAG_WIDTH))
    log_diag = np.empty((Kr, B, _DIAG_WIDTH))
    clip = pk.clip if pk.clip is not None else np.zeros(3)
    # chart memory: MRP σ (3) or the quaternion (4), starting from the controller's own hint
    p_prev = controller._first_hint(B) if ckind == CTRL_QUATERNION_PD else np.zeros((B, 4))
    status, rows, n_switch = _fused_loop(
        n_steps, float(t0), float(dt), every_ctrl, log_every,
        np.array(R0, dtype=np.float64), np.array(x0, dtype=np.float64),
        pk.act, pk.J, pk.J_inv, pk.S0, pk.C0, pk.dist, pk.dist_params, pk.clip is not None,
        clip, pk.steer, pk.steer_params, pk.rate_limit,
        ckind, code, thr2, cJ, k1, k2, G, cprm, p_prev, index, ref_R, ref_w, ref_dw,
        log.t, log.R, log.omega, log.R_d, log.omega_d, log.u_cmd, log.u, log.disturbance,
        log_act, log_sat, log_diag, diag,
    )  # fmt: skip
    if status != 0:
        return None
    log.rows = rows
    d = log.dicts
    if pk.act == K.ACT_SGCMG:
        d["actuator"]["delta"] = log_act[:, :, : n - 3]
        d["actuator"]["delta_dot"] = log_act[:, :, n - 3 :]
        d["actuator"]["saturated"] = log_sat[:, :, 0]
    elif pk.clip is not None:
        d["actuator"]["saturated"] = log_sat
    if ckind == CTRL_QUATERNION_PD:
        d["controller"].update(
            q_w=log_diag[:, :, 0], chart_y=log_diag[:, :, 0:4],
            chart_y_d=np.broadcast_to([1.0, 0.0, 0.0, 0.0], (rows, B, 4)).copy(),
            chart_switched=log_diag[:, :, 4] != 0.0,
        )  # fmt: skip
        controller._set_kernel_state(diag, p_prev)
    elif ckind == CTRL_FINITE_TIME:
        d["controller"].update(
            Psi=log_diag[:, :, 0], theta=log_diag[:, :, 1], e_R=log_diag[:, :, 2:5],
            e_Omega=log_diag[:, :, 5:8], s=log_diag[:, :, 8:11],
        )  # fmt: skip
        controller._diag = diag.copy()
    elif ckind == CTRL_MRP_PD:
        d["controller"].update(
            chart_y=log_diag[:, :, 0:3],
            chart_y_d=np.zeros((rows, B, 3)),
            chart_switched=log_diag[:, :, 3] != 0.0,
        )
        controller.n_switches += n_switch
        controller._set_kernel_state(diag, p_prev[:, :3].copy())
    else:
        d["controller"].update(
            Psi=log_diag[:, :, 0], e_R=log_diag[:, :, 1:4], e_Omega=log_diag[:, :, 4:7]
        )
        controller._set_diagnostics(diag[:, :7])
    return log.result(dt, control_period, plant)
