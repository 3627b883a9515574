"""Chart adapters (SPEC §1, §6 item 6): conversions, singularity ownership, sign and shadow
handling. Independent routes: scipy Rotation, finite differences, direct formulas."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from liecontrol.charts import euler, mrp
from liecontrol.charts import quaternion as quat
from liecontrol.control.adapters import (
    EulerChartAdapter,
    MrpChartAdapter,
    QuaternionChartAdapter,
    RotatingFrame,
    mrp_shadow_jacobian,
    mrp_shadow_map,
)
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.chart_baselines import MrpPD
from liecontrol.exceptions import ChartSingularityError
from liecontrol.lie import so3

J = np.array([[15.0, 1.0, -0.5], [1.0, 12.0, 0.8], [-0.5, 0.8, 10.0]])


class Recorder:
    """A chart law that returns a fixed linear function of the chart state and keeps it."""

    def __init__(self) -> None:
        self.switch_calls: list[tuple[np.ndarray, np.ndarray]] = []

    def reset(self, t0: float, batch_size: int) -> None:
        self.s = None

    def __call__(self, t, s):
        self.s = s
        return -2.0 * s.y[:, -3:] - 0.5 * s.omega_rel

    def on_shadow_switch(self, state_mask, desired_mask):
        self.switch_calls.append((state_mask, desired_mask))


def _traj(R0, w0, a0, base, t):
    """Body attitude R(t) = R0 exp(t w0 + ½t² a0): body rate w0 and acceleration a0 at t = 0."""
    return R0 @ so3.exp(t * w0 + 0.5 * t * t * a0)


def _ref(R_d, w_d=None, dw_d=None):
    w_d = np.zeros(3) if w_d is None else w_d
    dw_d = np.zeros(3) if dw_d is None else dw_d
    return AttitudeReference(R_d=R_d, omega_d=w_d, omega_dot_d=dw_d)


# --------------------------------------------------------------------------- MRP shadow maps


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(-2, 2), min_size=9, max_size=9),
)
def test_mrp_shadow_map_matches_finite_differences(v):
    p0, v0, a0 = np.array(v[:3]), np.array(v[3:6]), np.array(v[6:])
    if np.linalg.norm(p0) < 0.2:
        p0 = p0 + 0.5
    h = 1e-4

    def shadow_of(t):
        p = p0 + v0 * t + 0.5 * a0 * t * t
        return -p / (p @ p)

    ps, pd_s, pdd_s = mrp_shadow_map(p0, v0, a0)
    np.testing.assert_allclose(ps, shadow_of(0.0), rtol=1e-14)
    fd1 = (shadow_of(h) - shadow_of(-h)) / (2 * h)
    fd2 = (shadow_of(h) - 2 * shadow_of(0.0) + shadow_of(-h)) / h**2
    scale = 1.0 + np.abs(fd1).max()
    np.testing.assert_allclose(pd_s, fd1, atol=1e-6 * scale * (1 + np.abs(p0 @ p0) ** -2))
    scale2 = 1.0 + np.abs(fd2).max()
    np.testing.assert_allclose(pdd_s, fd2, atol=2e-4 * scale2 * (1 + np.abs(p0 @ p0) ** -3))


def test_mrp_shadow_jacobian_and_same_rotation():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(5, 3))
    D = mrp_shadow_jacobian(p)
    eps = 1e-7
    for i in range(3):
        dp = np.zeros(3)
        dp[i] = eps
        fd = (mrp.shadow(p + dp) - mrp.shadow(p - dp)) / (2 * eps)
        np.testing.assert_allclose(D[..., i], fd, atol=1e-6)
    np.testing.assert_allclose(mrp.to_matrix(mrp.shadow(p)), mrp.to_matrix(p), atol=1e-14)
    # the ESO's B = G J⁻¹ maps with D: G(p_s) = D(p) G(p)
    np.testing.assert_allclose(
        mrp.kinematics_matrix(mrp.shadow(p)), D @ mrp.kinematics_matrix(p), atol=1e-12
    )
    with pytest.raises(ValueError, match="^p:"):
        mrp_shadow_jacobian(np.zeros(3))


# --------------------------------------------------------------------------- MRP adapter


def test_mrp_same_physical_state_same_torque():
    """p and its shadow are the same attitude: the adapter gives the same torque."""
    rng = np.random.default_rng(2)
    p = rng.normal(size=(6, 3))
    p = p / np.linalg.norm(p, axis=1, keepdims=True) * rng.uniform(0.3, 0.95, (6, 1))
    w = rng.normal(size=(6, 3)) * 0.1
    ref = _ref(np.eye(3))
    torques = []
    for pp in (p, mrp.shadow(p)):
        c = MrpPD(J, 3.0, 4.0)
        c.reset(0.0, 6)
        torques.append(c.command(0.0, AttitudeState(mrp.to_matrix(pp), w), ref))
    np.testing.assert_allclose(torques[0], torques[1], atol=1e-12)
    # independent route: classical MRP law with scipy's MRP of the error (|σ| ≤ 1)
    sigma = Rotation.from_matrix(mrp.to_matrix(p)).as_mrp()
    ff = np.cross(w, w @ J.T)
    np.testing.assert_allclose(torques[0], -3.0 * sigma - 4.0 * w + ff, atol=1e-12)


def test_mrp_switch_across_half_turn_calls_hook_and_matches_fresh_adapter():
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    R1 = so3.exp(np.radians(178.0) * axis)[None]
    R2 = so3.exp(np.radians(182.0) * axis)[None]  # the error passes the half turn
    w = np.array([[0.01, 0.0, 0.0]])
    ref = _ref(np.eye(3))
    law = Recorder()
    c = MrpChartAdapter(law)
    c.reset(0.0, 1)
    c.command(0.0, AttitudeState(R1, w), ref)
    p1 = law.s.y.copy()
    u2 = c.command(0.1, AttitudeState(R2, w), ref)
    p2 = law.s.y.copy()
    assert law.s.switched[0] and c.n_switches == 1
    assert len(law.switch_calls) == 1 and law.switch_calls[0][0][0]
    assert np.linalg.norm(p1) < 1 and np.linalg.norm(p2) < 1
    np.testing.assert_allclose(p2, mrp.from_matrix(R2), atol=1e-14)
    fresh = MrpChartAdapter(Recorder())
    fresh.reset(0.0, 1)
    np.testing.assert_allclose(u2, fresh.command(0.1, AttitudeState(R2, w), ref), atol=1e-13)
    # hysteresis: |p| = tan(182°/4) ≈ 1.07 < 1.2 keeps the continuous (shadow) set
    law_h = Recorder()
    ch = MrpChartAdapter(law_h, threshold=1.2)
    ch.reset(0.0, 1)
    ch.command(0.0, AttitudeState(R1, w), ref)
    ch.command(0.1, AttitudeState(R2, w), ref)
    assert not law_h.s.switched[0] and law_h.switch_calls == []
    np.testing.assert_allclose(np.linalg.norm(law_h.s.y), np.tan(np.radians(182.0) / 4), rtol=1e-12)


def test_mrp_rates_and_orbit_base():
    """y_dot = G(p)(ω − C_bo ω_b) with p relative to a rotating base frame (seed 000 eq. (9))."""
    rng = np.random.default_rng(3)
    base = RotatingFrame(so3.exp(np.array([0.1, 0.2, 0.3])), np.array([0.0, -0.0011, 0.0]))
    B = 4
    R = so3.exp(rng.normal(size=(B, 3)) * 0.3)
    w = rng.normal(size=(B, 3)) * 0.01
    law = Recorder()
    c = MrpChartAdapter(law, base=base)
    c.reset(0.0, B)
    t = 50.0
    c.command(t, AttitudeState(R, w), base(t))
    Rb = base(t).R_d
    p = Rotation.from_matrix(Rb.T @ R).as_mrp()
    np.testing.assert_allclose(law.s.y, p, atol=1e-13)
    C_bo = np.swapaxes(Rb.T @ R, -1, -2)
    w_io = C_bo @ base.omega
    np.testing.assert_allclose(law.s.omega_base, w_io, atol=1e-15)
    np.testing.assert_allclose(law.s.y_dot, mrp.kinematics(p, w - w_io), atol=1e-14)
    # desired = the base itself → p_d = 0 and its derivatives vanish
    assert law.s.y_d.shape == (B, 3) and law.s.y_d_ddot.shape == (B, 3)
    np.testing.assert_allclose(law.s.y_d, 0.0, atol=1e-15)
    np.testing.assert_allclose(law.s.y_d_dot, 0.0, atol=1e-15)
    np.testing.assert_allclose(law.s.y_d_ddot, 0.0, atol=1e-9)
    # finite-difference check of y_dot along the true motion
    h = 1e-4
    ys = []
    for dt in (-h, h):
        R_t = R @ so3.exp(dt * w)
        ys.append(Rotation.from_matrix(base(t + dt).R_d.T @ R_t).as_mrp())
    np.testing.assert_allclose(law.s.y_dot, (ys[1] - ys[0]) / (2 * h), atol=1e-9)


# --------------------------------------------------------------------------- Euler adapter


def test_euler_adapter_coordinates_and_derivatives():
    rng = np.random.default_rng(4)
    B = 5
    R0 = so3.exp(rng.normal(size=(B, 3)) * 0.5)
    w0 = rng.normal(size=(B, 3)) * 0.05
    a0 = rng.normal(size=(B, 3)) * 0.01
    Rd0 = so3.exp(rng.normal(size=(B, 3)) * 0.5)
    wd0 = rng.normal(size=(B, 3)) * 0.05
    ad0 = rng.normal(size=(B, 3)) * 0.01
    base = RotatingFrame(np.eye(3), np.array([0.0, 0.0, 0.001]))
    law = Recorder()
    c = EulerChartAdapter(law, seq="ZYX", base=base)

    def sample(t):
        R = _traj(R0, w0, a0, None, t)
        Rd = _traj(Rd0, wd0, ad0, None, t)
        c.reset(0.0, B)
        c.command(t, AttitudeState(R, w0 + a0 * t), _ref(Rd, wd0 + ad0 * t, ad0))
        return law.s

    s0 = sample(0.0)
    Rb = base(0.0).R_d
    y_ref = Rotation.from_matrix(Rb.T @ R0).as_euler("ZYX")
    np.testing.assert_allclose(s0.y, y_ref, atol=1e-12)
    np.testing.assert_allclose(s0.y_d, Rotation.from_matrix(Rb.T @ Rd0).as_euler("ZYX"), atol=1e-12)
    h = 1e-4
    sp, sm = sample(h), sample(-h)
    np.testing.assert_allclose(s0.y_dot, (sp.y - sm.y) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(s0.y_d_dot, (sp.y_d - sm.y_d) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(s0.y_d_ddot, (sp.y_d - 2 * s0.y_d + sm.y_d) / h**2, atol=2e-6)


def test_torque_from_chart_acceleration_is_exact_inverse_dynamics():
    """u from the requested ÿ, applied to J ω̇ + ω × Jω = u, gives that ÿ (finite differences)."""
    rng = np.random.default_rng(5)
    B = 3
    R0 = so3.exp(rng.normal(size=(B, 3)) * 0.4)
    w0 = rng.normal(size=(B, 3)) * 0.05
    base = RotatingFrame(np.eye(3), np.array([0.0, -0.0011, 0.0]))
    ydd = rng.normal(size=(B, 3)) * 0.01
    for cls, kw in ((EulerChartAdapter, {"seq": "ZYX"}), (MrpChartAdapter, {})):
        law = Recorder()
        c = cls(law, base=base, **kw)
        c.reset(0.0, B)
        c.command(0.0, AttitudeState(R0, w0), base(0.0))
        u = law.s.torque_from_chart_acceleration(ydd, J)
        wdot = np.linalg.solve(J, (u - np.cross(w0, w0 @ J.T)).T).T
        h = 1e-4
        ys = []
        for t in (-h, 0.0, h):
            R_t = _traj(R0, w0, wdot, None, t)
            c2 = cls(law, base=base, **kw)
            c2.reset(0.0, B)
            c2.command(t, AttitudeState(R_t, w0 + wdot * t), base(t))
            ys.append(law.s.y)
        np.testing.assert_allclose((ys[2] - 2 * ys[1] + ys[0]) / h**2, ydd, atol=2e-6)


def test_euler_gimbal_lock_raises_for_state_and_reference():
    law = Recorder()
    c = EulerChartAdapter(law, seq="ZYX", lock_tol=1e-2)
    c.reset(0.0, 1)
    near = euler.to_matrix(np.array([[0.3, np.radians(89.8), 0.1]]), "ZYX")
    ok = euler.to_matrix(np.array([[0.3, np.radians(80.0), 0.1]]), "ZYX")
    w = np.zeros((1, 3))
    with pytest.raises(ChartSingularityError, match="^R: gimbal lock"):
        c.command(0.0, AttitudeState(near, w), _ref(np.eye(3)))
    with pytest.raises(ChartSingularityError, match="^R_d: gimbal lock"):
        c.command(0.0, AttitudeState(ok, w), _ref(near[0]))
    u = c.command(0.0, AttitudeState(ok, w), _ref(np.eye(3)))
    assert np.all(np.isfinite(u))


def test_euler_unwrap_gives_short_error_across_pi():
    law = Recorder()
    c = EulerChartAdapter(law, seq="ZYX")
    c.reset(0.0, 1)
    w = np.zeros((1, 3))
    for k, a_d in enumerate((np.radians(178.0), np.radians(-178.0))):  # the target wraps
        R = euler.to_matrix(np.array([[np.radians(179.0), 0.0, 0.0]]), "ZYX")
        Rd = euler.to_matrix(np.array([a_d, 0.0, 0.0]), "ZYX")
        c.command(float(k), AttitudeState(R, w), _ref(Rd))
        e = law.s.y - law.s.y_d
        assert abs(e[0, 0]) < np.radians(3.0)
    assert law.s.y_d[0, 0] == pytest.approx(np.radians(182.0))  # continuous in time


# --------------------------------------------------------------------------- quaternion adapter


def test_quaternion_sign_modes():
    axis = np.array([1.0, 2.0, -1.0]) / np.sqrt(6.0)
    R0 = so3.exp(np.radians(170.0) * axis)[None]
    q0 = quat.from_matrix(R0)
    w = np.zeros((1, 3))
    ref = _ref(np.eye(3))
    got = {}
    for mode in ("continuous", "switched", "hysteretic"):
        law = Recorder()
        c = QuaternionChartAdapter(law, sign_mode=mode, hysteresis=0.2, q_hint=-q0)
        c.reset(0.0, 1)
        c.command(0.0, AttitudeState(R0, w), ref)
        got[mode] = law.s.y[0].copy()
    np.testing.assert_allclose(got["continuous"], -q0[0], atol=1e-14)  # −q start kept
    np.testing.assert_allclose(got["switched"], q0[0], atol=1e-14)  # w ≥ 0
    np.testing.assert_allclose(got["hysteretic"], -q0[0], atol=1e-14)  # |w| = 0.087 < δ
    # hysteretic flips once w < −δ; continuous follows through w = 0 without flipping
    R_far = so3.exp(np.radians(120.0) * axis)[None]
    q_far = quat.from_matrix(R_far)
    law = Recorder()
    c = QuaternionChartAdapter(law, sign_mode="hysteretic", hysteresis=0.2, q_hint=-q_far)
    c.reset(0.0, 1)
    c.command(0.0, AttitudeState(R_far, w), ref)
    assert law.s.y[0, 0] > 0 and law.s.switched[0]
    law = Recorder()
    c = QuaternionChartAdapter(law, sign_mode="continuous")
    c.reset(0.0, 1)
    ws = []
    for k, ang in enumerate(np.radians([170.0, 179.0, 181.0, 190.0])):
        c.command(float(k), AttitudeState(so3.exp(ang * axis)[None], w), ref)
        ws.append(law.s.y[0, 0])
    assert ws[0] > 0 and ws[1] > 0 and ws[2] < 0 and ws[3] < 0
    np.testing.assert_allclose(ws, np.cos(np.radians([170.0, 179.0, 181.0, 190.0]) / 2), atol=1e-14)


def test_quaternion_rates_match_kinematics():
    rng = np.random.default_rng(6)
    R = so3.random(rng, 4)
    w = rng.normal(size=(4, 3))
    Rd = so3.random(rng, 4)
    wd = rng.normal(size=(4, 3))
    law = Recorder()
    c = QuaternionChartAdapter(law)
    c.reset(0.0, 4)
    c.command(0.0, AttitudeState(R, w), _ref(Rd, wd))
    q = law.s.y
    e_w = w - np.einsum("bji,bj->bi", Rd.transpose(0, 2, 1) @ R, wd)
    np.testing.assert_allclose(law.s.omega_rel, e_w, atol=1e-14)
    np.testing.assert_allclose(law.s.y_dot, quat.kinematics(q, e_w), atol=1e-14)
    np.testing.assert_allclose(
        np.abs(q), np.abs(quat.error(quat.from_matrix(R), quat.from_matrix(Rd))), atol=1e-12
    )


# --------------------------------------------------------------------------- bad input


def test_bad_input():
    law = Recorder()
    with pytest.raises(ValueError, match="^base:"):
        MrpChartAdapter(law, base="orbit")
    with pytest.raises(ValueError, match="^threshold:"):
        MrpChartAdapter(law, threshold=0.5)
    with pytest.raises(ValueError, match="^seq:"):
        EulerChartAdapter(law, seq="ZZX")
    with pytest.raises(ValueError, match="^lock_tol:"):
        EulerChartAdapter(law, lock_tol=0.0)
    with pytest.raises(ValueError, match="^sign_mode:"):
        QuaternionChartAdapter(law, sign_mode="other")
    with pytest.raises(ValueError, match="^hysteresis:"):
        QuaternionChartAdapter(law, sign_mode="hysteretic", hysteresis=1.5)
    with pytest.raises(ValueError, match="^law:"):
        MrpChartAdapter(object())

    class BadLaw(Recorder):
        def __call__(self, t, s):
            return np.full((s.batch_size, 3), np.nan)

    c = MrpChartAdapter(BadLaw())
    c.reset(0.0, 1)
    with pytest.raises(ValueError, match="^law:"):
        c.command(0.0, AttitudeState(np.eye(3)[None], np.zeros((1, 3))), _ref(np.eye(3)))
    c = MrpChartAdapter(Recorder())
    c.reset(0.0, 1)
    with pytest.raises(ValueError, match="^R:"):
        c.command(0.0, AttitudeState(2 * np.eye(3)[None], np.zeros((1, 3))), _ref(np.eye(3)))
    with pytest.raises(ValueError, match="^state:"):
        c.command(0.0, AttitudeState(np.stack([np.eye(3)] * 2), np.zeros((2, 3))), _ref(np.eye(3)))
