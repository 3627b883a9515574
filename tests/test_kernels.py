"""The compiled kernels (issue 11) against independent numpy routes, and the fused simulation
loop against the per-step Python loop.

- each kernel equals a numpy reference written here from the public API (so3, the cluster's
  momentum and Jacobian, explicit linear solves) to 1e-12, over batch shapes (), (5,), (2, 3)
  and near θ = 0 and π;
- the fused loop equals the Python loop (which calls the same kernels one at a time) for every
  registered attitude controller on every quick scenario, and a user's own Python controller
  runs through the Python loop with the same result;
- without numba the package imports, warns once, and gives the same numbers.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from liecontrol._kernels import so3 as kso3
from liecontrol._kernels.geometric_pd import ERROR_CODES, geometric_pd_one
from liecontrol.control import GeometricPD
from liecontrol.control.base import AttitudeController, AttitudeReference, AttitudeState
from liecontrol.control.reference import ConstantAttitude
from liecontrol.errors import large_angle_error, log_error, trace_error
from liecontrol.integrators.rk import rkmk4_step_unchecked
from liecontrol.lie import so3
from spacecraft import (
    ConstantHarmonicTorque,
    GeneralizedSingularityRobust,
    IdealTorqueActuator,
    PseudoInverse,
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
    simulate,
)
from spacecraft import _kernels as K
from spacecraft import simulator as simulator_module
from spacecraft.steering import PINV_EPS

J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
SHAPES = [(), (5,), (2, 3)]


def _rotvecs(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Rotation vectors over the whole ball, with some at 0, tiny, and within 1e-6 of π."""
    w = so3.log(so3.random(rng, shape))
    flat = w.reshape(-1, 3)
    if flat.shape[0] >= 3:
        flat[0] = 0.0
        flat[1] *= 1e-9 / np.linalg.norm(flat[1])
        flat[2] *= (np.pi - 1e-7) / np.linalg.norm(flat[2])
    return flat.reshape(shape + (3,))


# ------------------------------------------------------------------------------------ SO(3)
@pytest.mark.parametrize("shape", SHAPES)
def test_exp_and_log_kernels_equal_the_numpy_api(shape):
    rng = np.random.default_rng(0)
    w = _rotvecs(rng, shape)
    R_ref = so3.exp(w)
    for idx in np.ndindex(*shape):
        out = np.empty((3, 3))
        kso3.exp_into(*w[idx].tolist(), out)
        np.testing.assert_allclose(out, R_ref[idx], rtol=0, atol=1e-15)
        np.testing.assert_allclose(kso3.log_of(R_ref[idx]), so3.log(R_ref[idx]), atol=1e-12)


def test_half_angle_polynomials_of_exp_equal_libm_to_an_ulp():
    """sin r / r and cos r from z = r² (fdlibm's kernels) against libm over [0, π/4], and
    exp's two routes (polynomials for θ ≤ π/2, libm beyond) against the numpy API near 0,
    at the switch and up to π."""
    r = np.concatenate([np.linspace(0.0, np.pi / 4, 200_001), 10.0 ** np.linspace(-12, -1, 1001)])
    sinc, cos = np.array([kso3.sinc_cos_of_square(v * v) for v in r[::37]]).T
    rr = r[::37]
    ref_sinc = np.where(rr > 0, np.sin(rr) / np.where(rr > 0, rr, 1.0), 1.0)
    np.testing.assert_allclose(sinc, ref_sinc, rtol=4.5e-16, atol=0)  # 2 ulp
    np.testing.assert_allclose(cos, np.cos(rr), rtol=4.5e-16, atol=0)  # 2 ulp
    assert kso3.sinc_cos_of_square(0.0) == (1.0, 1.0)
    rng = np.random.default_rng(12)
    axes = rng.normal(size=(3000, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    th = np.concatenate(
        [10.0 ** rng.uniform(-15, 0, 1000), np.pi / 2 + rng.uniform(-1e-9, 1e-9, 1000),
         rng.uniform(0.0, np.pi, 1000)]
    )  # fmt: skip
    w = axes * th[:, None]
    R_ref = so3.exp(w)
    out = np.empty((3, 3))
    for b in range(w.shape[0]):
        kso3.exp_into(*w[b].tolist(), out)
        # the libm route's diagonal c + b w_i² cancels near π (the same before the polynomials)
        np.testing.assert_allclose(
            out, R_ref[b], rtol=0, atol=1e-15 if th[b] <= np.pi / 2 else 2e-15
        )
    kso3.exp_into(0.0, 0.0, 0.0, out)
    assert np.array_equal(out, np.eye(3))
    kso3.exp_into(np.nan, 0.0, 0.0, out)
    assert np.isnan(out).all()


@settings(max_examples=80, deadline=None)
@given(
    st.floats(0.0, np.pi, allow_nan=False),
    st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 1e-3),
)
def test_log_kernel_round_trip_near_zero_and_pi(theta, axis):
    n = np.asarray(axis) / np.linalg.norm(axis)
    for th in (theta, 1e-12 * theta, np.pi - 1e-9 * theta):
        R = so3.exp(th * n)
        w = np.array(kso3.log_of(R))
        np.testing.assert_allclose(so3.exp(w), R, atol=2e-15)
        assert np.linalg.norm(w) <= np.pi + 1e-15


def test_dexpinv_kernel_is_the_truncated_right_jacobian_inverse():
    rng = np.random.default_rng(1)
    for _ in range(50):
        th = 1e-2 * rng.normal(size=3)
        v = rng.normal(size=3)
        exact = so3.right_jacobian_inv(th) @ v
        # dexp⁻¹ in the left-trivialised form of RKMK equals J_r⁻¹ to O(θ⁴)
        np.testing.assert_allclose(kso3.dexpinv_rkmk4(*th, *v), exact, atol=1e-7 * np.abs(v).max())


# -------------------------------------------------------------------------------- steering
def _steer_reference(law, A, h, t):
    """δ̇ = Aᵀ(AAᵀ + λ s² E + ε tr(AAᵀ)/3 I)⁻¹ ḣ by an explicit numpy solve."""
    n = A.shape[-1]
    M = A @ A.T
    s2 = np.trace(M) / n
    m2 = max(np.linalg.det(M), 0.0) / s2**3
    if isinstance(law, PseudoInverse):
        lam, E, eps = 0.0, np.eye(3), law.eps
    else:
        lam = law.lambda0 * np.exp(-law.mu * m2) * s2
        E = law.dither_matrix(t) if isinstance(law, GeneralizedSingularityRobust) else np.eye(3)
        eps = PINV_EPS
    return A.T @ np.linalg.solve(M + lam * E + eps * np.trace(M) / 3 * np.eye(3), h)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize(
    "law", [PseudoInverse(), SingularityRobust(), GeneralizedSingularityRobust()], ids=repr
)
def test_steering_kernels_equal_an_explicit_solve(law, shape):
    cl = SgcmgPyramid(h0=300.0)
    rng = np.random.default_rng(2)
    delta = rng.uniform(-np.pi, np.pi, size=shape + (4,))
    flat = delta.reshape(-1, 4)
    if flat.shape[0] >= 2:
        flat[0] = [np.pi / 2, 0.0, -np.pi / 2, 0.0]  # the 4h internal singularity
        flat[1] = [np.pi / 2] * 4  # elliptic external singularity (saturated)
    _, A = cl.momentum_and_jacobian(delta)
    h = 50.0 * rng.normal(size=shape + (3,))
    got = law(A, h, t=0.7)
    for idx in np.ndindex(*shape):
        ref = _steer_reference(law, A[idx], h[idx], 0.7)
        np.testing.assert_allclose(got[idx], ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())


# ----------------------------------------------------------------------- SGCMG and the plant
def _cluster_torque(cl, w, delta, dd):
    h, A = cl.momentum_and_jacobian(delta)
    return -(A @ dd) - np.cross(w, h)


def test_cmg_torque_and_command_kernels_equal_the_cluster_model():
    cl = SgcmgPyramid(h0=300.0)
    act = SgcmgActuator(cl, SingularityRobust())
    rng = np.random.default_rng(3)
    B = 7
    delta = rng.uniform(-4.0, 4.0, size=(B, 4))
    w = 0.02 * rng.normal(size=(B, 3))
    u = 30.0 * rng.normal(size=(B, 3))
    held = act.command(u, w, delta, 0.3)
    tau = act.body_torque(w, delta, held)
    for b in range(B):
        h, A = cl.momentum_and_jacobian(delta[b])
        hd = -(np.cross(w[b], h) + u[b])
        np.testing.assert_allclose(held.h_dot_cmd[b], hd, rtol=1e-13, atol=1e-12)
        dd = _steer_reference(SingularityRobust(), A, hd, 0.3)
        peak = np.abs(dd).max()
        if peak > cl.gimbal_rate_limit:
            dd *= cl.gimbal_rate_limit / peak
        assert held.saturated[b] == (peak > cl.gimbal_rate_limit)
        np.testing.assert_allclose(held.delta_dot[b], dd, rtol=1e-9, atol=1e-13)
        np.testing.assert_allclose(
            tau[b], _cluster_torque(cl, w[b], delta[b], held.delta_dot[b]), rtol=1e-12, atol=1e-12
        )


def test_cluster_momentum_and_rate_term_equals_the_cluster_model():
    """(h, A δ̇) of :func:`K.cmg_momentum_and_rate_term` (shared by RK stages 2 and 3) and the
    bus torque assembled from it against the numpy cluster model to 1e-13, at random angles and
    at angles near 0 and ±π."""
    cl = SgcmgPyramid(h0=300.0)
    act = SgcmgActuator(cl, SingularityRobust())
    rng = np.random.default_rng(13)
    deltas = np.concatenate(
        [rng.uniform(-4.0, 4.0, (20, 4)), rng.uniform(-1e-9, 1e-9, (5, 4)),
         np.pi + rng.uniform(-1e-9, 1e-9, (5, 4)), -np.pi + rng.uniform(-1e-9, 1e-9, (5, 4))]
    )  # fmt: skip
    for delta in deltas:
        dd = rng.normal(size=4)
        w = 0.05 * rng.normal(size=3)
        trig = np.concatenate([np.sin(delta), np.cos(delta)])
        h0, h1, h2, r0, r1, r2 = K.cmg_momentum_and_rate_term(act._S0, act._C0, trig, 0, 4, dd)
        h, A = cl.momentum_and_jacobian(delta)
        scale = cl.h0 * (1.0 + np.abs(dd).sum())
        np.testing.assert_allclose([h0, h1, h2], h, rtol=0, atol=1e-13 * cl.h0)
        np.testing.assert_allclose([r0, r1, r2], A @ dd, rtol=0, atol=1e-13 * scale)
        tau = K.cmg_bus_torque_from((h0, h1, h2, r0, r1, r2), *w)
        np.testing.assert_allclose(
            tau, _cluster_torque(cl, w, delta, dd), rtol=0, atol=1e-13 * scale
        )


@pytest.mark.parametrize("per_spacecraft_J", [False, True])
@pytest.mark.parametrize("which", ["sgcmg", "ideal"])
def test_plant_step_kernel_equals_rkmk4_on_a_numpy_field(which, per_spacecraft_J):
    rng = np.random.default_rng(4)
    B = 5
    Js = np.stack([J * (1 + 0.1 * b) for b in range(B)]) if per_spacecraft_J else J
    cl = SgcmgPyramid(h0=300.0)
    act = SgcmgActuator(cl) if which == "sgcmg" else IdealTorqueActuator()
    dist = ConstantHarmonicTorque(scale=10.0)
    plant = Spacecraft(RigidBody(Js), act, dist)
    assert plant._kernel_plan is not None
    R = so3.exp(rng.normal(size=(B, 3)))
    x = np.concatenate([0.05 * rng.normal(size=(B, 3)), rng.normal(size=(B, plant.n_act))], 1)
    held = act.command(20.0 * rng.normal(size=(B, 3)), x[:, :3], x[:, 3:], 0.0)
    Jb = np.broadcast_to(Js, (B, 3, 3))

    def field(t, RR, xx):
        w = xx[:, :3]
        if which == "sgcmg":
            tau = np.stack(
                [_cluster_torque(cl, w[b], xx[b, 3:], held.delta_dot[b]) for b in range(B)]
            )
        else:
            tau = held
        tau = tau + dist.torque_at(t)
        wdot = np.linalg.solve(Jb, (tau - np.cross(w, np.einsum("bij,bj->bi", Jb, w)))[..., None])
        xd = wdot[..., 0] if which == "ideal" else np.concatenate([wdot[..., 0], held.delta_dot], 1)
        return w, xd

    R_ref, x_ref = rkmk4_step_unchecked(field, 2.0, R, x, 0.1)
    R_new, x_new = plant.step_packed(2.0, R, x, held, 0.1)
    np.testing.assert_allclose(R_new, R_ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(x_new, x_ref, rtol=1e-12, atol=1e-15)


# --------------------------------------------------------------------------- geometric PD
def test_algebraic_large_angle_error_equals_the_numpy_layer_near_0_pi_half_and_pi():
    """The square-root route of the large-angle error (cos θ ≥ 0) and its fallback (θ > π/2)
    against :func:`liecontrol.errors.large_angle_error` (atan2 and sines) to 1e-13."""
    from liecontrol._kernels import attitude as kattitude
    from liecontrol._kernels.attitude import body_from_desired, large_angle_error_algebraic

    rng = np.random.default_rng(11)
    axes = rng.normal(size=(400, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    thetas = np.concatenate(
        [
            10.0 ** rng.uniform(-12, 0, 100),  # near 0
            rng.uniform(0.0, np.pi, 100),
            np.pi / 2 + rng.uniform(-1e-6, 1e-6, 100),  # the switch at cos θ = 0
            np.pi - 10.0 ** rng.uniform(-9, -1, 100),  # near π (fallback)
        ]
    )
    R_d = so3.random(rng, (400,))
    R = R_d @ so3.exp(axes * thetas[:, None])
    for b in range(400):
        Psi, e_R = large_angle_error(R[b], R_d[b])
        t = body_from_desired(R[b], R_d[b])
        got = large_angle_error_algebraic(t)
        np.testing.assert_allclose(got, [Psi, *e_R], rtol=1e-13, atol=1e-15)
        # the same R̃ through the angle route: relative agreement, even at θ = 1e-12
        psi, _, *e = kattitude.large_angle_error(t)
        np.testing.assert_allclose(got, [psi, *e], rtol=1e-13, atol=0.0)
    # at the identity exactly zero
    assert large_angle_error_algebraic(body_from_desired(np.eye(3), np.eye(3))) == (0.0,) * 4


@pytest.mark.parametrize("shape", [(), (5,), (2, 3)])
@pytest.mark.parametrize("error", ["large_angle", "log", "trace"])
def test_geometric_pd_kernel_equals_the_law_in_numpy(error, shape):
    rng = np.random.default_rng(5)
    R = so3.exp(_rotvecs(rng, shape))
    R_d = so3.random(rng, shape)
    w, w_d, dw_d = (0.1 * rng.normal(size=shape + (3,)) for _ in range(3))
    kR, kW = np.diag([300.0, 200.0, 250.0]), 900.0
    G = np.diag([1.0, 1.1, 1.2])
    ctrl = GeometricPD(J, kR, kW, error=error, G=G if error == "trace" else None)
    err, Jk, kRk, kWk, Gk = ctrl._kernel_args()
    assert err == ERROR_CODES[error]
    for idx in np.ndindex(*shape):
        Rt = R_d[idx].T @ R[idx]
        if error == "trace":
            Psi, e_R = trace_error(R[idx], R_d[idx], G)
        else:
            Psi, e_R = {"log": log_error, "large_angle": large_angle_error}[error](R[idx], R_d[idx])
        wb = Rt.T @ w_d[idx]
        e_W = w[idx] - wb
        ff = np.cross(w[idx], J @ w[idx]) - J @ (np.cross(w[idx], wb) - Rt.T @ dw_d[idx])
        M_ref = ff - kR @ e_R - kW * e_W
        M, diag = np.empty(3), np.empty(7)
        geometric_pd_one(err, Jk, kRk, kWk, Gk, R[idx], w[idx], R_d[idx], w_d[idx], dw_d[idx],
                         M, diag)  # fmt: skip
        np.testing.assert_allclose(M, M_ref, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(diag, [Psi, *e_R, *e_W], rtol=1e-12, atol=1e-12)


def test_geometric_pd_batched_command_equals_one_spacecraft_at_a_time():
    rng = np.random.default_rng(6)
    B = 6
    R, R_d = so3.random(rng, (B,)), so3.random(rng, (B,))
    w = 0.1 * rng.normal(size=(B, 3))
    ctrl = GeometricPD(J, 300.0, 900.0)
    ctrl.reset(0.0, B)
    ref = AttitudeReference(R_d=R_d, omega_d=np.zeros((B, 3)), omega_dot_d=np.zeros((B, 3)))
    M = ctrl.command(0.0, AttitudeState(R=R, omega=w), ref)
    one = GeometricPD(J, 300.0, 900.0)
    one.reset(0.0, 1)
    for b in range(B):
        r = AttitudeReference.regulation(R_d[b])
        np.testing.assert_array_equal(
            one.command(0.0, AttitudeState(R=R[b : b + 1], omega=w[b : b + 1]), r), M[b : b + 1]
        )


# ---------------------------------------------------------------------- the fused loop
def _python_loop(monkeypatch, *args, **kwargs):
    """``simulate`` with the fused loop switched off (the per-step Python loop)."""
    with monkeypatch.context() as m:
        m.setattr(simulator_module, "fused_supported", lambda *a, **k: None)
        return simulate(*args, **kwargs)


def _assert_same_result(a, b):
    for name in ("t", "R", "omega", "R_d", "omega_d", "u_cmd", "u", "disturbance"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-12, atol=1e-12)
    for group in ("actuator", "controller", "sensors", "estimate"):
        da, db = getattr(a, group), getattr(b, group)
        assert sorted(da) == sorted(db), group
        for k in da:
            if k.endswith("time"):
                continue  # wall-clock diagnostics (an MPC's solve time) differ run to run
            assert da[k].dtype == db[k].dtype and da[k].shape == db[k].shape, (group, k)
            np.testing.assert_allclose(da[k], db[k], rtol=1e-12, atol=1e-12)


def _quick_pairs():
    from benchmarks.controllers import available_controllers, get_controller
    from benchmarks.scenarios import get_suite

    for s in get_suite("quick").scenarios:
        if s.plant != "sgcmg":
            continue
        for c in available_controllers():
            if get_controller(c).applies(s)[0]:
                yield s, c


def test_fused_loop_equals_python_loop_for_every_controller_on_every_quick_scenario(monkeypatch):
    from benchmarks.controllers import ControllerContext, get_controller
    from benchmarks.runner import build_plant, build_reference, initial_state

    fused_runs = 0
    for s, c in _quick_pairs():
        s = s.with_duration(30.0)
        plant = build_plant(s.spacecraft, s.disturbances, s.true_inertia)
        ref = build_reference(s)
        R0, w0 = initial_state(s)
        x0 = plant.initial_state(R0[None], w0[None])
        info = get_controller(c)
        ctx = ControllerContext(
            spacecraft=s.spacecraft,
            control_period=s.control_period,
            batch_size=1,
            q_hint=s.initial_quaternion[None],
            reference=ref,
        )
        args = (plant, info.factory(ctx), ref, x0, s.duration, s.dt)
        kw = {"control_period": s.control_period}
        from spacecraft._fused import fused_supported

        fused_runs += fused_supported(plant, args[1], [], None, False) is not None
        _assert_same_result(simulate(*args, **kw), _python_loop(monkeypatch, *args, **kw))
    assert fused_runs >= 3  # the geometric PD family runs fused


def test_fused_batch_and_user_controller_fallback(monkeypatch):
    rng = np.random.default_rng(7)
    B = 4
    act = SgcmgActuator(SgcmgPyramid(h0=300.0))
    plant = Spacecraft(RigidBody(J), act, ConstantHarmonicTorque())
    R_d = so3.random(rng, (B,))
    ref = ConstantAttitude(R_d)
    x0 = plant.initial_state(np.eye(3), batch=B)
    pd = GeometricPD(J, 400.0, 3000.0)
    fused = simulate(plant, pd, ref, x0, 60.0, 0.1, control_period=0.2, log_every=3)
    _assert_same_result(
        fused, _python_loop(monkeypatch, plant, pd, ref, x0, 60.0, 0.1, control_period=0.2,
                            log_every=3)
    )  # fmt: skip

    class UserPD(AttitudeController):
        """A user's own Python controller: wraps the library law (no kernel of its own)."""

        def __init__(self):
            self.inner = GeometricPD(J, 400.0, 3000.0)

        def reset(self, t0, batch_size):
            self.inner.reset(t0, batch_size)

        def command(self, t, state, reference):
            return self.inner.command(t, state, reference)

    user = simulate(plant, UserPD(), ref, x0, 60.0, 0.1, control_period=0.2, log_every=3)
    for name in ("R", "omega", "u_cmd", "u"):
        np.testing.assert_array_equal(getattr(user, name), getattr(fused, name))


def test_fused_loop_reports_divergence_like_the_python_loop():
    """A run that fails goes through the Python loop, which raises with the partial log."""
    from spacecraft.simulator import SimulationDiverged

    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    x0 = plant.initial_state(np.eye(3), np.array([[1e140, 0.0, 3e140]]))
    with pytest.raises((SimulationDiverged, ValueError)) as info:
        simulate(plant, GeometricPD(J, 1.0, 1.0), ConstantAttitude(np.eye(3)), x0, 10.0, 0.1)
    if isinstance(info.value, SimulationDiverged):
        assert info.value.result.n_samples >= 1


# ---------------------------------------------------------------------- without numba
def test_without_numba_the_package_warns_once_and_gives_the_same_numbers():
    script = textwrap.dedent(
        """
        import sys, warnings
        sys.modules["numba"] = None  # import numba -> ImportError
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            import numpy as np
            import liecontrol, spacecraft
            from liecontrol._jit import JIT_ENABLED
            from liecontrol.control import GeometricPD
            from liecontrol.control.reference import ConstantAttitude
            from liecontrol.lie import so3
            from spacecraft import RigidBody, SgcmgActuator, SgcmgPyramid, Spacecraft, simulate
        msgs = [str(w.message) for w in caught if "numba is unavailable" in str(w.message)]
        assert not JIT_ENABLED and len(msgs) == 1, msgs
        J = np.diag([1200.0, 1000.0, 800.0])
        plant = Spacecraft(RigidBody(J), SgcmgActuator(SgcmgPyramid(h0=300.0)))
        r = simulate(plant, GeometricPD(J, 300.0, 1500.0),
                     ConstantAttitude(so3.exp(np.array([0.0, 0.0, 1.5]))),
                     plant.initial_state(np.eye(3)), 20.0, 0.1)
        np.save(sys.argv[1], r.omega)
        """
    )
    out = os.path.join(os.environ.get("TMPDIR", "/tmp"), f"nojit_{os.getpid()}.npy")
    subprocess.run([sys.executable, "-c", script, out], check=True, timeout=300)
    J2 = np.diag([1200.0, 1000.0, 800.0])
    plant = Spacecraft(RigidBody(J2), SgcmgActuator(SgcmgPyramid(h0=300.0)))
    r = simulate(plant, GeometricPD(J2, 300.0, 1500.0),
                 ConstantAttitude(so3.exp(np.array([0.0, 0.0, 1.5]))),
                 plant.initial_state(np.eye(3)), 20.0, 0.1)  # fmt: skip
    np.testing.assert_allclose(np.load(out), r.omega, rtol=1e-12, atol=1e-15)
    os.remove(out)


def test_kernels_never_see_unvalidated_input():
    """Bad input is refused at the public boundary with the argument's name."""
    ctrl = GeometricPD(J, 1.0, 1.0)
    ctrl.reset(0.0, 1)
    bad = np.eye(3)[None].copy()
    bad[0, 0, 0] = 2.0
    with pytest.raises(ValueError, match="^R"):
        ctrl.command(0.0, AttitudeState.unchecked(bad, np.zeros((1, 3))),
                     AttitudeReference.regulation(np.eye(3)))  # fmt: skip
    with pytest.raises(ValueError, match="^A"):
        SingularityRobust()(np.full((3, 4), np.nan), np.zeros(3))
    assert K.ACT_SGCMG != K.ACT_IDEAL


# ------------------------------------------------------------------------- MRP PD adapter
@pytest.mark.parametrize("feedforward", ["gyroscopic", "reference", "none"])
def test_mrp_pd_kernel_equals_the_adapter_route_through_shadow_switches(feedforward, monkeypatch):
    """The compiled MrpPD (chart conversion + law) against the generic adapter route (a
    subclass takes it), on runs that cross 180° so that the shadow set switches."""
    from liecontrol.control import MrpPD

    class AdapterRoute(MrpPD):
        """A subclass: MrpPD's numpy adapter route."""

    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    R0 = so3.exp(np.array([[0.0, 0.0, 3.0], [0.0, 3.05, 0.0], [1.7, 1.7, 1.0]]))
    w0 = np.array([[0.0, 0.0, 0.08], [0.0, 0.06, 0.0], [0.02, 0.02, 0.05]])
    x0 = plant.initial_state(R0, w0)
    ref = ConstantAttitude(np.eye(3))
    args = (ref, x0, 120.0, 0.1)
    fast = MrpPD(J, 40.0, 900.0, feedforward=feedforward)
    slow = AdapterRoute(J, 40.0, 900.0, feedforward=feedforward)
    a = simulate(plant, fast, *args, control_period=0.2)
    b = simulate(plant, slow, *args, control_period=0.2)
    assert slow.n_switches > 0 and fast.n_switches == slow.n_switches
    _assert_same_result(a, b)
    c = _python_loop(monkeypatch, plant, MrpPD(J, 40.0, 900.0, feedforward=feedforward),
                     *args, control_period=0.2)  # fmt: skip
    _assert_same_result(a, c)


# ------------------------------------------------------------------ quaternion PD adapter
@pytest.mark.parametrize("sign_mode", ["continuous", "switched", "hysteretic"])
def test_quaternion_pd_kernel_equals_the_adapter_route(sign_mode, monkeypatch):
    """The compiled QuaternionPD (error quaternion, its sign handling, the law) against the
    generic adapter route (a subclass takes it), across 180° and with a −q hint (unwinding)."""
    from liecontrol.control import QuaternionPD

    class AdapterRoute(QuaternionPD):
        """A subclass: QuaternionPD's numpy adapter route."""

    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    R0 = so3.exp(np.array([[0.0, 0.0, 3.0], [0.0, 3.05, 0.0], [1.7, 1.7, 1.0]]))
    w0 = np.array([[0.0, 0.0, 0.08], [0.0, 0.06, 0.0], [0.02, 0.02, 0.05]])
    x0 = plant.initial_state(R0, w0)
    from liecontrol.charts import quaternion as quat

    hint = -quat.from_matrix(R0)  # the −q start of the unwinding benchmark
    ref = ConstantAttitude(np.eye(3))
    runs = []
    for cls in (QuaternionPD, AdapterRoute):
        ctrl = cls(J, 40.0, 900.0, sign_mode=sign_mode, q_hint=hint)
        runs.append(simulate(plant, ctrl, ref, x0, 120.0, 0.1, control_period=0.2))
    _assert_same_result(*runs)
    assert runs[0].controller["chart_switched"].any() == (sign_mode != "continuous")
    seam = _python_loop(
        monkeypatch, plant, QuaternionPD(J, 40.0, 900.0, sign_mode=sign_mode, q_hint=hint),
        ref, x0, 120.0, 0.1, control_period=0.2,
    )  # fmt: skip
    _assert_same_result(runs[0], seam)


@pytest.mark.parametrize("which", ["sgcmg", "ideal-limited"])
def test_held_substeps_kernel_equals_command_and_step_one_at_a_time(which):
    """spacecraft._fused.hold_steps (the environments' substeps) against the actuator's command
    and the plant's step called once per substep."""
    from spacecraft._fused import hold_steps

    act = SgcmgActuator(SgcmgPyramid(h0=300.0)) if which == "sgcmg" else IdealTorqueActuator(2.0)
    plant = Spacecraft(RigidBody(J), act)
    rng = np.random.default_rng(8)
    B = 4
    R = so3.random(rng, (B,))
    x = np.concatenate([0.02 * rng.normal(size=(B, 3)), rng.normal(size=(B, plant.n_act))], 1)
    u = 3.0 * rng.normal(size=(B, 3))
    R1, x1, sat = hold_steps(plant._kernel_plan, 5, 0.0, 0.1, R, x, u)
    R2, x2, count = R, x, np.zeros(B)
    for _ in range(5):
        held = act.command(u, x2[:, :3], x2[:, 3:], 0.0)
        s = np.asarray(act.log(x2[:, 3:], held).get("saturated", np.zeros(B, bool)))
        count += s.reshape(B, -1).any(axis=1)
        R2, x2 = plant.step_packed(0.0, R2, x2, held, 0.1)
    np.testing.assert_allclose(R1, R2, rtol=0, atol=1e-15)
    np.testing.assert_allclose(x1, x2, rtol=1e-13, atol=1e-15)
    np.testing.assert_array_equal(sat, count)
    assert which == "sgcmg" or sat.any()
