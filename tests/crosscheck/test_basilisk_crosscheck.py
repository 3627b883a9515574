"""Cross-check against Basilisk itself (extra ``[crosscheck]``, package ``bsk``): liecontrol's
conversions against ``Basilisk.utilities.RigidBodyKinematics`` and ``MrpPD``'s feed-forward
options against Basilisk's ``mrpFeedback`` flight-software module run for one update."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip(
    "Basilisk", reason="Basilisk not installed (pip install bsk, extra [crosscheck])"
)

from Basilisk.utilities import RigidBodyKinematics as rbk  # noqa: E402

from liecontrol.charts import mrp, quaternion  # noqa: E402
from liecontrol.control.base import AttitudeReference, AttitudeState  # noqa: E402
from liecontrol.control.chart_baselines import MrpPD  # noqa: E402
from liecontrol.interop import basilisk as bsk  # noqa: E402
from liecontrol.lie import so3  # noqa: E402

ROT = so3.random(np.random.default_rng(0), 25)


def test_mrp_ep_prv_against_rigid_body_kinematics():
    for R in ROT:
        C = R.T  # [BN]
        sigma, _ = bsk.to_sigma_BN(R, np.zeros(3))
        np.testing.assert_allclose(sigma, rbk.C2MRP(C), atol=1e-12)
        np.testing.assert_allclose(bsk.from_sigma_BN(rbk.C2MRP(C), np.zeros(3))[0], R, atol=1e-12)
        beta = np.asarray(rbk.C2EP(C))
        q = quaternion.from_matrix(R)
        # ±β is the same attitude; Basilisk's C2EP picks β₀ ≥ 0 like our canonical form
        np.testing.assert_allclose(bsk.ep_to_quat(beta), q, atol=1e-12)
        np.testing.assert_allclose(np.asarray(rbk.EP2C(bsk.quat_to_ep(q))), C, atol=1e-12)
        np.testing.assert_allclose(bsk.prv_to_rotvec(rbk.C2PRV(C)), so3.log(R), atol=1e-10)
        np.testing.assert_allclose(np.asarray(rbk.MRP2C(sigma)), bsk.dcm_BN(R), atol=1e-12)


def test_mrp_kinematics_against_dmrp():
    rng = np.random.default_rng(1)
    for R in ROT[:10]:
        w = rng.normal(size=3)
        sigma = mrp.from_matrix(R)
        np.testing.assert_allclose(mrp.kinematics(sigma, w), rbk.dMRP(sigma, w), atol=1e-13)


@pytest.mark.parametrize("euler_set", list(bsk.EULER_SETS))
def test_euler_sets_against_rigid_body_kinematics(euler_set: str):
    to_angles = getattr(rbk, f"C2Euler{euler_set}")
    to_dcm = getattr(rbk, f"euler{euler_set}2C")
    for R in ROT:
        ours = bsk.matrix_to_euler(R, euler_set)
        # both give the same attitude; the angles agree away from gimbal lock
        np.testing.assert_allclose(np.asarray(to_dcm(ours)), R.T, atol=1e-12)
        np.testing.assert_allclose(ours, np.asarray(to_angles(R.T)), atol=1e-9)
        np.testing.assert_allclose(bsk.euler_to_matrix(ours, euler_set), R, atol=1e-12)


J = np.array([[12.0, 0.5, -0.3], [0.5, 10.0, 0.2], [-0.3, 0.2, 15.0]])


def _basilisk_torque(sigma_BR, omega_BR_B, omega_RN_B, domega_RN_B, K, P, law_type):
    from Basilisk.architecture import messaging
    from Basilisk.fswAlgorithms import mrpFeedback
    from Basilisk.utilities import SimulationBaseClass, macros

    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("proc")
    proc.addTask(sim.CreateNewTask("task", macros.sec2nano(0.5)))
    mod = mrpFeedback.mrpFeedback()
    mod.ModelTag = "mrpFeedback"
    sim.AddModelToTask("task", mod)
    mod.K, mod.P, mod.Ki, mod.integralLimit = K, P, -1.0, 0.0  # Ki < 0: no integral term
    mod.controlLawType = law_type
    guid = messaging.AttGuidMsgPayload()
    guid.sigma_BR = list(sigma_BR)
    guid.omega_BR_B = list(omega_BR_B)
    guid.omega_RN_B = list(omega_RN_B)
    guid.domega_RN_B = list(domega_RN_B)
    guid_msg = messaging.AttGuidMsg().write(guid)
    veh = messaging.VehicleConfigMsgPayload()
    veh.ISCPntB_B = list(J.ravel())
    veh_msg = messaging.VehicleConfigMsg().write(veh)
    mod.guidInMsg.subscribeTo(guid_msg)
    mod.vehConfigInMsg.subscribeTo(veh_msg)
    rec = mod.cmdTorqueOutMsg.recorder()
    sim.AddModelToTask("task", rec)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(0)
    sim.ExecuteSimulation()
    return np.asarray(rec.torqueRequestBody)[-1]


@pytest.mark.parametrize(("feedforward", "law_type"), [("reference", 0), ("gyroscopic", 1)])
def test_mrp_pd_reproduces_mrp_feedback_module(feedforward: str, law_type: int):
    rng = np.random.default_rng(2)
    K, P = 2.5, 7.0
    for _ in range(3):
        R = so3.random(rng)
        R_d = R @ so3.exp(rng.uniform(-0.6, 0.6, 3))
        w, w_d, dw_d = (rng.normal(size=3) * s for s in (0.3, 0.1, 0.02))
        C = R.T @ R_d  # [BR]
        sigma_BR = bsk.to_sigma_BN(R_d.T @ R, w)[0]
        want = _basilisk_torque(sigma_BR, w - C @ w_d, C @ w_d, C @ dw_d, K, P, law_type)
        c = MrpPD(J, K, P, feedforward=feedforward)
        c.reset(0.0, 1)
        ref = AttitudeReference(R_d=R_d[None], omega_d=w_d[None], omega_dot_d=dw_d[None])
        u = c.command(0.0, AttitudeState(R[None], w[None]), ref)[0]
        np.testing.assert_allclose(u, want, atol=1e-10)
