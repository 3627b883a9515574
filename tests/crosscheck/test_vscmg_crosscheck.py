"""Cross-check of the full CMG model (:mod:`spacecraft.cmg_dynamics`) against Basilisk's
``vscmgStateEffector`` (extra ``[crosscheck]``, package ``bsk``).

Both frameworks fly the same rigid hub with the same four-unit pyramid (gimbal axes, spin and
transverse axes at δ = 0, rotor and gimbal-frame inertias, initial gimbal angles, rotor speeds and
body rate) under the same prescribed, piecewise-constant gimbal-motor and spin-motor torques
(no controller, no servo), and the body rate, attitude, gimbal angles, gimbal rates and rotor
speeds are compared.

Where the models coincide and where they differ:

* Dynamics: Basilisk's balanced-wheel VSCMG (``VSCMGModel = 0``) with the units' mass centres at
  the hub's reference point is the same system of equations (Schaub & Junkins, *Analytical
  Mechanics of Space Systems*, VSCMG section): agreement is expected to round-off plus the
  integrators' difference.
* Integrators: Basilisk integrates the MRP attitude and the states with classical RK4, liecontrol
  RKMK4 on SO(3) with the same step. Both are 4th order: their difference is a truncation
  difference O((|ω| h)⁴) per unit time on the attitude, at most ~1e-13 rad here (|ω| ≲ 0.03 rad/s,
  h = 0.01 s); the rate and rotor states share the same stage formulas. Bound asserted: 1e-10.
* Not compared, because only one side models them: Basilisk's static/dynamic imbalance (jitter)
  models, unit masses with offsets, Coulomb friction; liecontrol's PI gimbal-rate servo, the
  constant-speed rotor option, gimbal stops and the stop guard. The test drives the motors
  open loop (``VscmgActuator.open_loop``) with ``variable_speed=True`` so that neither side's
  extras act.
* Logging: Basilisk writes the VSCMG speed message at the start of the step that ends a
  segment, so its gimbal angles/rates and rotor speeds are compared with liecontrol's state one
  step earlier (the hub's attitude and rate message is current).
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip(
    "Basilisk", reason="Basilisk not installed (pip install bsk, extra [crosscheck])"
)
vscmg_mod = pytest.importorskip(
    "Basilisk.simulation.vscmgStateEffector",
    reason="this Basilisk build has no vscmgStateEffector (pip install bsk, extra [crosscheck])",
)

from Basilisk.architecture import messaging  # noqa: E402
from Basilisk.simulation import spacecraft as bsk_spacecraft  # noqa: E402
from Basilisk.utilities import RigidBodyKinematics as rbk  # noqa: E402
from Basilisk.utilities import SimulationBaseClass, macros  # noqa: E402

from spacecraft.cmg_dynamics import CmgInertias, GimbalServo, VscmgActuator  # noqa: E402
from spacecraft.plant import Spacecraft  # noqa: E402
from spacecraft.rigid_body import RigidBody  # noqa: E402
from spacecraft.sgcmg import SgcmgPyramid  # noqa: E402

J = np.array([[1500.0, 10.0, -5.0], [10.0, 1200.0, 8.0], [-5.0, 8.0, 900.0]])
CLUSTER = SgcmgPyramid(h0=50.0)
INERTIAS = CmgInertias(wheel_spin=0.2, wheel_transverse=0.1, gimbal=(0.3, 0.4, 0.5))
DELTA0 = np.array([0.7, -0.8, 0.9, -0.6])
W0 = np.array([0.01, -0.02, 0.015])
DT = 0.01
SEGMENT = 1.0  # torques change every second


def _torques(seg: int) -> tuple[np.ndarray, np.ndarray]:
    """Gimbal and spin motor torques [N·m] of one constant segment."""
    i = np.arange(4)
    return 0.2 * np.sin(i + 0.7 * seg), 0.01 * np.cos(i + 0.3 * seg)


def _axes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    quarter = np.full(4, np.pi / 2)
    s0 = CLUSTER.unit_momenta(np.zeros(4))  # spin axes at δ = 0
    t0 = 0.5 * (CLUSTER.unit_momenta(quarter) - CLUSTER.unit_momenta(-quarter))  # g × s0
    return s0, t0, CLUSTER.gimbal_axes()


def _basilisk(n_seg: int) -> list[dict[str, np.ndarray]]:
    s0, t0, g = _axes()
    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("proc")
    proc.addTask(sim.CreateNewTask("task", macros.sec2nano(DT)))
    sc = bsk_spacecraft.Spacecraft()
    sc.ModelTag = "sc"
    sc.hub.mHub = 500.0
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = J.tolist()
    sc.hub.sigma_BNInit = [[0.0], [0.0], [0.0]]
    sc.hub.omega_BN_BInit = [[w] for w in W0]
    eff = vscmg_mod.VSCMGStateEffector()
    eff.ModelTag = "vscmg"
    Om0 = CLUSTER.h0 / INERTIAS.wheel_spin
    for i in range(4):
        c = messaging.VSCMGConfigMsgPayload()
        c.rGB_B = [[0.0], [0.0], [0.0]]
        c.gsHat0_B = [[v] for v in s0[:, i]]
        c.gtHat0_B = [[v] for v in t0[:, i]]
        c.ggHat_B = [[v] for v in g[:, i]]
        c.u_s_max = c.u_s_min = c.u_g_max = c.u_g_min = -1.0  # no limits
        c.u_s_f = c.u_g_f = 0.0  # no friction
        c.wheelLinearFrictionRatio = c.gimbalLinearFrictionRatio = -1.0
        c.u_g_current = 0.0
        c.Omega, c.gamma, c.gammaDot = Om0, float(DELTA0[i]), 0.0
        c.Omega_max = c.gammaDot_max = -1.0
        c.IW1 = INERTIAS.wheel_spin
        c.IW2 = c.IW3 = INERTIAS.wheel_transverse
        c.IG1, c.IG2, c.IG3 = INERTIAS.gimbal
        c.U_s = c.U_d = c.l = c.L = 0.0
        c.rGcG_G = [[0.0], [0.0], [0.0]]
        c.massW = c.massG = 1.0
        c.VSCMGModel = 0  # balanced wheels
        eff.AddVSCMG(c)
    sc.addStateEffector(eff)
    cmd = messaging.VSCMGArrayTorqueMsgPayload()
    msg = messaging.VSCMGArrayTorqueMsg()
    pad = [0.0] * (len(cmd.gimbalTorque) - 4)
    ug, us = _torques(0)
    cmd.gimbalTorque, cmd.wheelTorque = list(ug) + pad, list(us) + pad
    msg.write(cmd)
    eff.cmdsInMsg.subscribeTo(msg)
    sim.AddModelToTask("task", eff)
    sim.AddModelToTask("task", sc)
    sim.InitializeSimulation()
    out = []
    for seg in range(n_seg):
        ug, us = _torques(seg)
        cmd.gimbalTorque, cmd.wheelTorque = list(ug) + pad, list(us) + pad
        msg.write(cmd, macros.sec2nano(seg * SEGMENT))
        sim.ConfigureStopTime(macros.sec2nano((seg + 1) * SEGMENT))
        sim.ExecuteSimulation()
        p = sc.scStateOutMsg.read()
        q = eff.speedOutMsg.read()
        out.append(
            {
                "R": np.asarray(rbk.MRP2C(np.asarray(p.sigma_BN))).T,  # [BN]ᵀ: body → inertial
                "omega": np.asarray(p.omega_BN_B),
                "delta": np.asarray(q.gimbalAngles)[:4],
                "delta_dot": np.asarray(q.gimbalRates)[:4],
                "spin": np.asarray(q.wheelSpeeds)[:4],
            }
        )
    return out


def _liecontrol(n_seg: int) -> list[dict[str, np.ndarray]]:
    act = VscmgActuator(
        J, INERTIAS, CLUSTER, servo=GimbalServo(1.0, 1e6), delta0=DELTA0, variable_speed=True
    )
    plant = Spacecraft(RigidBody(J), act)
    st = plant.initial_state(np.eye(3), omega0=W0)
    R, x = st.R, st.packed()
    n = round(SEGMENT / DT)
    out = []
    t = 0.0
    for seg in range(n_seg):
        ug, us = _torques(seg)
        held = act.open_loop(ug[None], us[None])
        for k in range(n):
            if k == n - 1:
                # Basilisk's speedOutMsg is written before the step it ends on: one step behind
                cmg = {"delta": x[0, 3:7].copy(), "delta_dot": x[0, 7:11].copy(),
                       "spin": x[0, 11:15].copy()}  # fmt: skip
            R, x = plant.step_packed(t, R, x, held, DT)
            t += DT
        out.append({"R": R[0].copy(), "omega": x[0, :3].copy(), **cmg})
    return out


def test_open_loop_vscmg_pyramid_agrees_with_basilisk():
    n_seg = 10
    ref, ours = _basilisk(n_seg), _liecontrol(n_seg)
    moved = np.abs(ours[-1]["delta"] - DELTA0).max()
    assert moved > 0.1  # the gimbals really turned and momentum moved
    assert np.abs(ours[-1]["omega"] - W0).max() > 1e-3
    for a, b in zip(ref, ours, strict=True):
        np.testing.assert_allclose(b["omega"], a["omega"], rtol=0, atol=1e-10)
        np.testing.assert_allclose(b["R"], a["R"], rtol=0, atol=1e-10)
        np.testing.assert_allclose(b["delta"], a["delta"], rtol=0, atol=1e-10)
        np.testing.assert_allclose(b["delta_dot"], a["delta_dot"], rtol=0, atol=1e-10)
        np.testing.assert_allclose(b["spin"], a["spin"], rtol=1e-12, atol=1e-9)
