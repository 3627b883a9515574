"""Single-run and batched throughput against Basilisk, measured in one process:
``python -m benchmarks.perf_basilisk [--repeat N] [--t-final T] [--batch B]``.

Loops (rest-to-rest 90° slew, 600 s at dt = 0.1 s, controller at every step; liecontrol logs
every step of a single run and every 600th of a batch, Basilisk records nothing):

- liecontrol: the SGCMG bus (four-CMG pyramid, singularity-robust steering; the momentum
  model) under the large-angle geometric PD, single run and a batch of ``--batch``; the same
  pyramid with the full VSCMG dynamics (:class:`spacecraft.cmg_dynamics.VscmgActuator`, Basilisk's
  rotor and gimbal inertias, a 5 rad/s gimbal servo: the like-for-like counterpart of Basilisk's
  loop, whose effector integrates the same dynamics); the ideal-torque plant under
  the geometric PD, under the MRP PD adapter (:class:`liecontrol.control.MrpPD`, the same law
  as Basilisk's ``mrpFeedback``) and under the quaternion PD adapter;
- Basilisk (``pip install bsk``, extra ``[crosscheck]``): a hub with four VSCMGs in the same
  pyramid driven by ``vscmgVelocitySteering`` + ``vscmgGimbalRateServo`` under ``mrpFeedback``;
  and a hub with an external torque under ``mrpFeedback``; both with ``simpleNav``,
  ``inertial3D`` and ``attTrackingError`` (Basilisk's standard attitude-control chain).

The two frameworks' loops alternate (``--repeat`` rounds) and every figure is the median of its
rounds; ratios are taken between medians of the same run. The BLAS/OpenMP thread counts are
pinned to 1 before numpy is imported. Compilation of the kernels is reported separately (the
first call after a cache clear) and excluded from the medians.
"""

from __future__ import annotations

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks._perf import sgcmg_bus_inertia, thread_settings  # noqa: E402

J_BUS = sgcmg_bus_inertia()
H0 = 300.0
WN, ZETA = 0.03, 0.9


def _target() -> np.ndarray:
    from liecontrol.lie import so3

    return so3.exp(np.array([0.0, 0.0, np.pi / 2]))


def _gains() -> tuple[float, float]:
    from liecontrol.control.geometric_pd import gains_from_bandwidth

    kR, kW = gains_from_bandwidth(J_BUS, WN, ZETA)
    return float(np.max(kR)), float(np.max(kW))


def liecontrol_loop(which: str, batch: int, t_final: float, dt: float) -> Callable[[], None]:
    """A closure running one liecontrol simulation of the named loop."""
    from liecontrol.control import ConstantAttitude, MrpPD, QuaternionPD
    from liecontrol.control.geometric_pd import GeometricPD
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

    kR, kW = _gains()
    if which.startswith("vscmg"):
        from spacecraft.cmg_dynamics import CmgInertias, GimbalServo, VscmgActuator

        # the rotor and gimbal inertias of the Basilisk loop below, a 5 rad/s gimbal servo
        act = VscmgActuator(
            J_BUS, CmgInertias(0.5, 0.25, (0.1, 0.1, 0.1)), SgcmgPyramid(h0=H0),
            SingularityRobust(), servo=GimbalServo(5.0, 50.0),
        )  # fmt: skip
    elif which.startswith("sgcmg"):
        act = SgcmgActuator(SgcmgPyramid(h0=H0), SingularityRobust())
    else:
        act = IdealTorqueActuator()
    plant = Spacecraft(RigidBody(J_BUS), act)
    if which.endswith("mrp-pd"):
        # σ ≈ θ/4 near the target: K = 4 k_R gives the same small-angle stiffness
        ctrl = MrpPD(J_BUS, 4.0 * kR, kW)
    elif which.endswith("quaternion-pd"):
        ctrl = QuaternionPD(J_BUS, 2.0 * kR, kW)  # q_v ≈ θ/2
    else:
        ctrl = GeometricPD(J_BUS, kR, kW)
    if batch == 1:
        ref = ConstantAttitude(_target())
    else:
        rng = np.random.default_rng(0)
        ref = ConstantAttitude(so3.exp(0.8 * rng.normal(size=(batch, 3))))
    s0 = plant.initial_state(np.eye(3), batch=batch)

    # a batch logs every 600th step (its full log would take gigabytes); one run every step
    log_every = 1 if batch == 1 else 600

    def run() -> None:
        simulate(plant, ctrl, ref, s0, t_final, dt, log_every=log_every)

    return run


def basilisk_loop(which: str, t_final: float, dt: float) -> Callable[[], None] | None:
    """A closure running one Basilisk simulation, or ``None`` without ``bsk``."""
    try:
        from Basilisk.architecture import messaging
        from Basilisk.fswAlgorithms import attTrackingError, inertial3D, mrpFeedback
        from Basilisk.simulation import extForceTorque, simpleNav
        from Basilisk.simulation import spacecraft as bsk_spacecraft
        from Basilisk.utilities import SimulationBaseClass, macros
    except ImportError:
        return None
    from liecontrol.interop.basilisk import to_sigma_BN

    kR, kW = _gains()
    steps = macros.sec2nano(dt)
    sigma_R0N = to_sigma_BN(_target(), np.zeros(3))[0]

    def build() -> tuple[object, int]:
        sim = SimulationBaseClass.SimBaseClass()
        proc = sim.CreateNewProcess("proc")
        # sense → control → dynamics within each step (higher priority runs first), so the
        # actuators read a command written in the same step, as simulate's loop does
        proc.addTask(sim.CreateNewTask("sense", steps), 300)
        proc.addTask(sim.CreateNewTask("fsw", steps), 200)
        proc.addTask(sim.CreateNewTask("dyn", steps), 100)
        sc = bsk_spacecraft.Spacecraft()
        sc.ModelTag = "sc"
        sc.hub.mHub = 500.0
        sc.hub.IHubPntBc_B = J_BUS.tolist()
        sc.hub.sigma_BNInit = [[0.0], [0.0], [0.0]]
        sc.hub.omega_BN_BInit = [[0.0], [0.0], [0.0]]
        sim.AddModelToTask("dyn", sc)
        nav = simpleNav.SimpleNav()
        nav.scStateInMsg.subscribeTo(sc.scStateOutMsg)
        sim.AddModelToTask("sense", nav)
        ref = inertial3D.inertial3D()
        ref.sigma_R0N = list(sigma_R0N)
        sim.AddModelToTask("fsw", ref)
        err = attTrackingError.attTrackingError()
        err.attNavInMsg.subscribeTo(nav.attOutMsg)
        err.attRefInMsg.subscribeTo(ref.attRefOutMsg)
        sim.AddModelToTask("fsw", err)
        ctl = mrpFeedback.mrpFeedback()
        ctl.K = 4.0 * kR
        ctl.P = kW
        ctl.Ki = -1.0
        ctl.guidInMsg.subscribeTo(err.attGuidOutMsg)
        cfg = messaging.VehicleConfigMsgPayload(ISCPntB_B=J_BUS.ravel().tolist())
        cfg_msg = messaging.VehicleConfigMsg().write(cfg)
        ctl.vehConfigInMsg.subscribeTo(cfg_msg)
        sim.AddModelToTask("fsw", ctl)
        keep = [cfg_msg]
        if which == "ideal":
            ext = extForceTorque.ExtForceTorque()
            ext.cmdTorqueInMsg.subscribeTo(ctl.cmdTorqueOutMsg)
            sc.addDynamicEffector(ext)
            sim.AddModelToTask("dyn", ext)
            keep.append(ext)
        else:
            keep += _basilisk_cmgs(sim, sc, nav, err, ctl, cfg_msg)
        sim.InitializeSimulation()
        sim.ConfigureStopTime(macros.sec2nano(t_final))
        return sim, keep

    if which != "ideal":
        try:
            build()
        except Exception as exc:  # noqa: BLE001 - reported: this Basilisk lacks the modules
            print(f"# Basilisk CMG loop unavailable: {exc!r}")
            return None

    def run() -> None:
        sim, _keep = build()
        sim.ExecuteSimulation()

    return run


def _basilisk_cmgs(sim, sc, nav, err, ctl, cfg_msg) -> list:  # noqa: ANN001
    """Four VSCMGs in the pyramid of :class:`spacecraft.sgcmg.SgcmgPyramid` (h0 = 300 N·m·s),
    velocity steering and the gimbal-rate servo of Basilisk."""
    from Basilisk.architecture import messaging
    from Basilisk.fswAlgorithms import vscmgGimbalRateServo, vscmgVelocitySteering
    from Basilisk.simulation import vscmgStateEffector

    from spacecraft import SgcmgPyramid

    cl = SgcmgPyramid(h0=H0)
    quarter = np.full(4, np.pi / 2)
    s0 = cl.unit_momenta(np.zeros(4))
    t0 = 0.5 * (cl.unit_momenta(quarter) - cl.unit_momenta(-quarter))
    g = cl.gimbal_axes()
    Iws, It, Ig = 0.5, 0.25, 0.1
    Om0 = H0 / Iws
    delta0 = np.array([np.pi / 4, -np.pi / 4, np.pi / 4, -np.pi / 4])
    eff = vscmgStateEffector.VSCMGStateEffector()
    eff.ModelTag = "vscmg"
    for i in range(4):
        c = messaging.VSCMGConfigMsgPayload()
        c.rGB_B = [[0.0], [0.0], [0.0]]
        c.gsHat0_B = [[v] for v in s0[:, i]]
        c.gtHat0_B = [[v] for v in t0[:, i]]
        c.ggHat_B = [[v] for v in g[:, i]]
        c.u_s_max = c.u_s_min = c.u_g_max = c.u_g_min = -1.0
        c.u_s_f = c.u_g_f = 0.0
        c.wheelLinearFrictionRatio = c.gimbalLinearFrictionRatio = -1.0
        c.u_g_current = 0.0
        c.Omega, c.gamma, c.gammaDot = Om0, float(delta0[i]), 0.0
        c.Omega_max = c.gammaDot_max = -1.0
        c.IW1, c.IW2, c.IW3 = Iws, It, It
        c.IG1, c.IG2, c.IG3 = Ig, Ig, Ig
        c.U_s = c.U_d = c.l = c.L = 0.0
        c.rGcG_G = [[0.0], [0.0], [0.0]]
        c.massW = c.massG = 1.0
        c.VSCMGModel = 0
        eff.AddVSCMG(c)
    sc.addStateEffector(eff)
    sim.AddModelToTask("dyn", eff)
    par = messaging.VSCMGArrayConfigMsgPayload()
    par.numVSCMG = 4
    par.Gs0Matrix_B = s0.T.ravel().tolist() + [0.0] * (3 * 36 - 12)
    par.Gt0Matrix_B = t0.T.ravel().tolist() + [0.0] * (3 * 36 - 12)
    par.GgMatrix_B = g.T.ravel().tolist() + [0.0] * (3 * 36 - 12)
    pad = [0.0] * 32
    par.IwsList = [Iws] * 4 + pad
    par.JsList = [Iws + Ig] * 4 + pad
    par.JtList = [It + Ig] * 4 + pad
    par.JgList = [It + Ig] * 4 + pad
    par.Omega0List = [Om0] * 4 + pad
    par.gamma0List = delta0.tolist() + pad
    par.gammaDot0List = [0.0] * 36
    par_msg = messaging.VSCMGArrayConfigMsg().write(par)
    steer = vscmgVelocitySteering.VscmgVelocitySteering()
    steer.vscmgParamsInMsg.subscribeTo(par_msg)
    steer.vehControlInMsg.subscribeTo(ctl.cmdTorqueOutMsg)
    steer.attNavInMsg.subscribeTo(nav.attOutMsg)
    steer.attGuideInMsg.subscribeTo(err.attGuidOutMsg)
    steer.speedsInMsg.subscribeTo(eff.speedOutMsg)
    sim.AddModelToTask("fsw", steer)
    servo = vscmgGimbalRateServo.VscmgGimbalRateServo()
    servo.vsmcgParamsInMsg.subscribeTo(par_msg)
    servo.vscmgRefStatesInMsg.subscribeTo(steer.vscmgRefStatesOutMsg)
    servo.attInMsg.subscribeTo(nav.attOutMsg)
    servo.speedsInMsg.subscribeTo(eff.speedOutMsg)
    sim.AddModelToTask("fsw", servo)
    eff.cmdsInMsg.subscribeTo(servo.cmdsOutMsg)
    return [eff, par_msg, steer, servo, cfg_msg]


def _time(fn: Callable[[], None]) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--t-final", type=float, default=600.0)
    ap.add_argument("--dt", type=float, default=0.1)
    ap.add_argument("--batch", type=int, default=1000)
    args = ap.parse_args(argv)
    n = round(args.t_final / args.dt)
    print(f"# {thread_settings()}; {n} steps per run; medians of {args.repeat} interleaved rounds")

    ours = {
        "sgcmg + geometric PD": liecontrol_loop("sgcmg", 1, args.t_final, args.dt),
        "ideal + geometric PD": liecontrol_loop("ideal", 1, args.t_final, args.dt),
        "full VSCMG model + geometric PD": liecontrol_loop("vscmg", 1, args.t_final, args.dt),
        "ideal + MrpPD adapter": liecontrol_loop("ideal-mrp-pd", 1, args.t_final, args.dt),
        "ideal + QuaternionPD adapter": liecontrol_loop(
            "ideal-quaternion-pd", 1, args.t_final, args.dt
        ),
        f"sgcmg + geometric PD, batch {args.batch}": liecontrol_loop(
            "sgcmg", args.batch, args.t_final, args.dt
        ),
    }
    theirs = {
        "Basilisk 4-VSCMG + mrpFeedback": basilisk_loop("cmg", args.t_final, args.dt),
        "Basilisk ext. torque + mrpFeedback": basilisk_loop("ideal", args.t_final, args.dt),
    }
    theirs = {k: v for k, v in theirs.items() if v is not None}
    if not theirs:
        print("# Basilisk not installed (pip install bsk): liecontrol figures only")
    compile_s = {k: _time(f) for k, f in ours.items()}  # first call: compile or load the cache
    samples: dict[str, list[float]] = {k: [] for k in [*ours, *theirs]}
    for _ in range(args.repeat):
        for k, f in [*ours.items(), *theirs.items()]:
            samples[k].append(_time(f))
    med = {k: statistics.median(v) for k, v in samples.items()}
    rate = {k: n * (args.batch if "batch" in k else 1) / med[k] for k in med}
    print(f"{'loop':44s} {'median s':>9s} {'steps/s':>12s}  first call s")
    for k in med:
        extra = f"  {compile_s[k]:.3f}" if k in compile_s else ""
        print(f"{k:44s} {med[k]:9.4f} {rate[k]:12.0f}{extra}")
    pairs = [
        ("sgcmg + geometric PD", "Basilisk 4-VSCMG + mrpFeedback"),
        ("ideal + geometric PD", "Basilisk ext. torque + mrpFeedback"),
        ("full VSCMG model + geometric PD", "Basilisk 4-VSCMG + mrpFeedback"),
        (f"sgcmg + geometric PD, batch {args.batch}", "Basilisk 4-VSCMG + mrpFeedback"),
    ]
    print("\nthroughput ratio: liecontrol steps/s ÷ Basilisk steps/s (> 1: liecontrol faster)")
    for a, b in pairs:
        if b in rate:
            print(f"  {a:40s} ÷ {b:36s} {rate[a] / rate[b]:7.2f}×")
    base = med["ideal + geometric PD"]
    print("cost per step relative to the geometric PD on the same plant (< 1: cheaper)")
    for k in ("ideal + MrpPD adapter", "ideal + QuaternionPD adapter"):
        print(f"  {k:40s} {med[k] / base:7.2f}×")

if __name__ == "__main__":
    main()
