"""Quaternion PD and MRP PD baselines (SPEC §6 item 6): independent torque formulas, the
unwinding of the continuous quaternion law on a −q start (SPEC §8.1/§8.2), bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from benchmarks.metrics import compute_metrics
from liecontrol.charts import quaternion as quat
from liecontrol.control import ConstantAttitude, GeometricPD
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.chart_baselines import MrpPD, QuaternionPD
from liecontrol.lie import so3
from spacecraft.actuators import IdealTorqueActuator
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.simulator import simulate

J = np.array([[12.0, 0.5, -0.3], [0.5, 10.0, 0.2], [-0.3, 0.2, 15.0]])


def _random_case(seed: int, B: int = 6):
    rng = np.random.default_rng(seed)
    R = so3.random(rng, B)
    w = rng.normal(size=(B, 3)) * 0.2
    Rd = so3.random(rng, B)
    wd = rng.normal(size=(B, 3)) * 0.1
    dwd = rng.normal(size=(B, 3)) * 0.01
    return R, w, AttitudeReference(R_d=Rd, omega_d=wd, omega_dot_d=dwd)


def _ff(R, w, ref):
    C = np.swapaxes(R, -1, -2) @ ref.R_d
    wd_b = np.einsum("bij,bj->bi", C, ref.omega_d)
    dwd_b = np.einsum("bij,bj->bi", C, ref.omega_dot_d)
    return np.cross(w, w @ J.T) - (np.cross(w, wd_b) - dwd_b) @ J.T, w - wd_b


def test_switched_quaternion_pd_equals_large_angle_geometric_pd():
    """Lee's large-angle error is sin(θ/2)·axis = q_v of the w ≥ 0 error quaternion."""
    R, w, ref = _random_case(0)
    qpd = QuaternionPD(J, 3.0, 2.0, sign_mode="switched")
    gpd = GeometricPD(J, 3.0, 2.0, error="large_angle")
    for c in (qpd, gpd):
        c.reset(0.0, R.shape[0])
    np.testing.assert_allclose(
        qpd.command(0.0, AttitudeState(R, w), ref),
        gpd.command(0.0, AttitudeState(R, w), ref),
        atol=1e-11,
    )


def test_quaternion_pd_formula_with_scipy_error_quaternion():
    R, w, ref = _random_case(1)
    q_e = Rotation.from_matrix(np.swapaxes(ref.R_d, -1, -2) @ R).as_quat()  # (x, y, z, w)
    q_e = np.where(q_e[:, 3:] < 0, -q_e, q_e)
    ff, e_w = _ff(R, w, ref)
    c = QuaternionPD(J, np.array([1.0, 2.0, 3.0]), 0.5, sign_mode="switched")
    c.reset(0.0, R.shape[0])
    u = c.command(0.0, AttitudeState(R, w), ref)
    np.testing.assert_allclose(u, -q_e[:, :3] * [1.0, 2.0, 3.0] - 0.5 * e_w + ff, atol=1e-11)


def test_mrp_pd_formula_with_scipy_mrp():
    R, w, ref = _random_case(2)
    sigma = Rotation.from_matrix(np.swapaxes(ref.R_d, -1, -2) @ R).as_mrp()  # |σ| ≤ 1
    ff, e_w = _ff(R, w, ref)
    K = np.diag([2.0, 3.0, 4.0])
    c = MrpPD(J, K, 1.5)
    c.reset(0.0, R.shape[0])
    u = c.command(0.0, AttitudeState(R, w), ref)
    np.testing.assert_allclose(u, -sigma @ K.T - 1.5 * e_w + ff, atol=1e-11)


def _unwinding_runs():
    """170° rest-to-rest, the initial attitude given as −q (SPEC §8.1 unwinding case)."""
    axis = np.array([1.0, 2.0, -1.0]) / np.sqrt(6.0)
    R0 = so3.exp(np.radians(170.0) * axis)
    q0 = quat.from_matrix(R0)
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    x0 = plant.initial_state(R0)
    wn = 0.5
    lam = float(np.linalg.eigvalsh(J)[-1])
    kp, kd = 2 * wn**2 * lam, 2 * wn * lam
    ctrls = {
        "continuous": QuaternionPD(J, kp, kd, "continuous", q_hint=-q0),
        "switched": QuaternionPD(J, kp, kd, "switched", q_hint=-q0),
        "geometric": GeometricPD(J, kp, kd),
        "mrp": MrpPD(J, 2 * kp, kd),
    }
    out = {}
    for name, c in ctrls.items():
        res = simulate(plant, c, ConstantAttitude(np.eye(3)), x0, 30.0, 0.05)
        rv = Rotation.from_matrix(res.R[:, 0]).as_rotvec()
        out[name] = (compute_metrics(res), res, rv @ axis)
    return out


def test_continuous_quaternion_pd_unwinds_on_minus_q_start():
    runs = _unwinding_runs()
    for name, (_m, res, _) in runs.items():
        assert np.degrees(res.attitude_error_angle()[-1, 0]) < 0.5, name  # all converge
    ratio = {k: float(v[0].unwinding_ratio[0]) for k, v in runs.items()}
    # the long way round is 190° for a 170° error: ratio 190/170 = 1.118 (no overshoot here)
    assert ratio["continuous"] == pytest.approx(190.0 / 170.0, abs=0.02)
    for name in ("switched", "geometric", "mrp"):
        assert ratio[name] == pytest.approx(1.0, abs=0.02), name
    # the continuous law rotates through the half turn (the rotation angle about the initial
    # axis passes π, i.e. the rotation vector flips), the others never do
    _, _, along = runs["continuous"]
    assert along.min() < 0.0 < along[0]
    for name in ("switched", "geometric", "mrp"):
        assert runs[name][2].min() > -1e-3, name


def test_bad_input():
    with pytest.raises(ValueError, match="^k_p:"):
        QuaternionPD(J, 0.0, 1.0)
    with pytest.raises(ValueError, match="^k_d:"):
        QuaternionPD(J, 1.0, -1.0)
    with pytest.raises(ValueError, match="^sign_mode:"):
        QuaternionPD(J, 1.0, 1.0, sign_mode="flip")
    with pytest.raises(ValueError, match="^K:"):
        MrpPD(J, [1.0, -1.0, 1.0], 1.0)
    with pytest.raises(ValueError, match="^P:"):
        MrpPD(J, 1.0, np.array([[1.0, 2.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))
    with pytest.raises(ValueError, match="^J:"):
        MrpPD(-J, 1.0, 1.0)
    with pytest.raises(ValueError, match="^threshold:"):
        MrpPD(J, 1.0, 1.0, threshold=0.9)
