"""The simulator's fast routes agree with the reference routes they replace (performance work,
issue 7): float single-spacecraft stages, skipped stage attitudes, the SGCMG trig cache and
tan-based sin/cos, the row-layout steering algebra, the column-wise rate limit, the float
payload torque and the cached star-tracker misalignment."""

from __future__ import annotations

import numpy as np
import pytest

from liecontrol.integrators.rk import rkmk4_step_unchecked
from liecontrol.lie import so3
from spacecraft import (
    ROTATING_PAYLOAD_EXAMPLE,
    CircularOrbit,
    CmgCommand,
    ConstantHarmonicTorque,
    GeneralizedSingularityRobust,
    GravityGradientTorque,
    IdealTorqueActuator,
    PseudoInverse,
    PseudoInverseNullMotion,
    RigidBody,
    RotatingPayloadTorque,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
    StarTracker,
    SumOfDisturbances,
)
from spacecraft.rigid_body import _cross
from spacecraft.steering import _SMALL_BATCH, _apply_right_inverse_small, _saturate_unchecked

J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])


def _field(t, R, x):
    """A nonlinear time-varying field that ignores R: ω = x[:3],
    ẋ = (cos t · x[3:6] − 0.1 ω, −½ ω ∘ ω reversed)."""
    w = x[:, :3]
    d = np.concatenate([np.cos(t) * x[:, 3:6] - 0.1 * w, -0.5 * w * w[:, ::-1]], axis=1)
    return w, d


def test_skipping_stage_attitudes_is_bitwise_identical_when_f_ignores_R():
    rng = np.random.default_rng(0)
    R = so3.exp(rng.normal(size=(5, 3)))
    x = rng.normal(size=(5, 6))
    a = rkmk4_step_unchecked(_field, 0.3, R, x, 0.1)
    b = rkmk4_step_unchecked(_field, 0.3, R, x, 0.1, stage_attitude=False)
    for u, v in zip(a, b, strict=True):
        np.testing.assert_array_equal(u, v)


@pytest.mark.parametrize(
    "disturbance",
    [
        None,
        ConstantHarmonicTorque(),
        SumOfDisturbances(
            {"s": ConstantHarmonicTorque(), "p": RotatingPayloadTorque([ROTATING_PAYLOAD_EXAMPLE])}
        ),
        GravityGradientTorque(J, CircularOrbit()),
    ],
)
@pytest.mark.parametrize(
    "actuator", [SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust()), IdealTorqueActuator()]
)
def test_single_spacecraft_float_step_is_bitwise_the_array_route(actuator, disturbance):
    plant = Spacecraft(RigidBody(J), actuator, disturbance)
    rng = np.random.default_rng(2)
    R = so3.exp(rng.normal(size=(1, 3)))
    x = np.concatenate([0.02 * rng.normal(size=(1, 3)), rng.normal(size=(1, plant.n_act))], 1)
    held = actuator.command(rng.normal(size=(1, 3)), x[:, :3], x[:, 3:], 0.0)

    def f(tt, RR, xx):
        return plant.derivatives(tt, RR, xx, held)

    # the reference always forms the stage attitudes; the plant skips them unless the
    # disturbance reads R (gravity gradient), with bitwise the same result
    assert plant._stage_attitude == isinstance(disturbance, GravityGradientTorque)
    R_ref, x_ref = rkmk4_step_unchecked(f, 1.0, R, x, 0.1)
    # the compiled step where the plant has one (tests/test_kernels.py holds it to an
    # independent numpy field); the array route bitwise otherwise
    exact = plant._kernel_plan is None
    for n in (1, 3):
        R_new, x_new = plant.step_packed(
            1.0, np.repeat(R, n, axis=0), np.repeat(x, n, axis=0), _rows(held, n), 0.1
        )
        if exact:
            np.testing.assert_array_equal(R_new, np.repeat(R_ref, n, axis=0))
            np.testing.assert_array_equal(x_new, np.repeat(x_ref, n, axis=0))
        else:
            np.testing.assert_allclose(R_new, np.repeat(R_ref, n, axis=0), rtol=0, atol=1e-14)
            np.testing.assert_allclose(x_new, np.repeat(x_ref, n, axis=0), rtol=1e-13, atol=1e-15)


def _rows(held, n):
    """The held command repeated for n identical spacecraft."""
    if isinstance(held, CmgCommand):
        return CmgCommand(
            np.repeat(held.delta_dot, n, axis=0),
            np.repeat(held.saturated, n, axis=0),
            np.repeat(held.h_dot_cmd, n, axis=0),
        )
    return np.repeat(held, n, axis=0)


@pytest.mark.parametrize(
    "law", [SingularityRobust(), PseudoInverse(), GeneralizedSingularityRobust()]
)
def test_single_spacecraft_command_matches_batched_command(law):
    act = SgcmgActuator(SgcmgPyramid(h0=300.0), law)
    rng = np.random.default_rng(3)
    for _ in range(20):
        delta = rng.uniform(-4.0, 4.0, size=(2, 4))
        w = 0.02 * rng.normal(size=(2, 3))
        u = 30.0 * rng.normal(size=(2, 3))
        # each row alone gives the batched command's row
        ref = act.command(u, w, delta, 0.7)
        for b in range(2):
            s = slice(b, b + 1)
            one = act.command(u[s], w[s], delta[s], 0.7)
            np.testing.assert_allclose(one.h_dot_cmd, ref.h_dot_cmd[s], rtol=1e-13, atol=1e-12)
            np.testing.assert_allclose(one.delta_dot, ref.delta_dot[s], rtol=1e-11, atol=1e-14)
            np.testing.assert_array_equal(one.saturated, ref.saturated[s])


def test_kernel_route_is_skipped_for_laws_without_one():
    cl = SgcmgPyramid(h0=300.0)
    # the null-motion law has a kernel (tests/test_kernels.py); a subclass never does
    assert SgcmgActuator(cl, PseudoInverseNullMotion(cluster=cl))._steer_kernel is not None

    class Custom(SingularityRobust):  # overrides steer only: must keep the array route
        def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None):
            return 2.0 * super().steer(A, hdot_cmd, delta, t, cluster)

    act = SgcmgActuator(cl, Custom())
    assert act._steer_kernel is None
    d = np.array([[0.3, -0.2, 1.0, 0.5]])
    u, w = np.array([[5.0, -3.0, 1.0]]), np.zeros((1, 3))
    base = SgcmgActuator(cl, SingularityRobust()).command(u, w, d, 0.0).delta_dot
    np.testing.assert_allclose(act.command(u, w, d, 0.0).delta_dot, 2.0 * base, rtol=1e-14)


def test_trig_cache_and_tan_form_match_sin_cos_and_never_go_stale():
    act = SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust())
    rng = np.random.default_rng(4)
    B = 600
    w = 0.02 * rng.normal(size=(B, 3))
    dd = rng.normal(size=(B, 4))
    held = CmgCommand(dd, np.zeros(B, bool), np.zeros((B, 3)))

    def reference(delta):
        h, A = act.cluster.momentum_and_jacobian(delta)
        return -(_cross(w, h) + (A @ dd[..., None])[..., 0])

    delta = rng.uniform(-50.0, 50.0, size=(B, 4))  # large angles: tan(δ/2) range reduction
    delta[0] = [0.0, np.pi, -np.pi, np.pi / 2]
    for _ in range(3):  # miss, then hits on the same values
        np.testing.assert_allclose(act.body_torque(w, delta, held), reference(delta), atol=1e-11)
    np.testing.assert_allclose(act.momentum(delta), act.cluster.momentum(delta), atol=1e-12)
    delta[5, 2] += 1e-3  # the caller mutates its array: the cache holds a copy, so no stale hit
    np.testing.assert_allclose(act.body_torque(w, delta, held), reference(delta), atol=1e-11)
    h = act.momentum(delta)
    h += 1.0  # the returned momentum is the caller's own
    np.testing.assert_allclose(act.momentum(delta), act.cluster.momentum(delta), atol=1e-12)
    bad = delta.copy()
    bad[7, 1] = np.nan
    with np.errstate(invalid="ignore"):
        assert np.isnan(act.body_torque(w, bad, held)[7]).all()


@pytest.mark.parametrize("law", [SingularityRobust(), GeneralizedSingularityRobust()])
def test_row_layout_steering_matches_lapack_route(law):
    cl = SgcmgPyramid(h0=300.0)
    rng = np.random.default_rng(5)
    B = _SMALL_BATCH + 50
    delta = rng.uniform(-np.pi, np.pi, size=(B, 4))
    delta[:3] = [np.pi / 2, 0.0, -np.pi / 2, 0.0]  # a singular configuration of the pyramid
    _, A = cl.momentum_and_jacobian(delta)
    hd = 30.0 * rng.normal(size=(B, 3))
    big = law.steer(A, hd, delta, 1.3, cl)
    small = np.concatenate([law.steer(A[i : i + 1], hd[i : i + 1], delta[i : i + 1], 1.3, cl)
                            for i in range(B)])  # fmt: skip
    np.testing.assert_allclose(big, small, rtol=1e-9, atol=1e-12)
    # the actuator hands its Jacobian over as a transposed view: same result as a copy
    act = SgcmgActuator(cl, law)
    u, w = rng.normal(size=(B, 3)), 0.01 * rng.normal(size=(B, 3))
    via_act = act.command(u, w, delta, 1.3).h_dot_cmd
    np.testing.assert_allclose(via_act, -(_cross(w, cl.momentum(delta)) + u), atol=1e-12)


def test_pinv_row_layout_matches_small_route():
    rng = np.random.default_rng(6)
    A = rng.normal(size=(_SMALL_BATCH + 10, 3, 4))
    R = rng.normal(size=(_SMALL_BATCH + 10, 3, 2))
    from spacecraft.steering import _apply_right_inverse

    np.testing.assert_allclose(
        _apply_right_inverse(A, R, 0.0), _apply_right_inverse_small(A, R, 0.0, 1e-12), rtol=1e-9
    )


def test_column_wise_rate_limit_equals_reduction():
    rng = np.random.default_rng(7)
    dd = 2.0 * rng.normal(size=(_SMALL_BATCH + 20, 4))
    dd[3, 1] = np.nan
    out, sat = _saturate_unchecked(dd, 1.0)
    peak = np.abs(dd).max(axis=-1)
    flag = peak > 1.0
    np.testing.assert_array_equal(sat, flag)
    ref = dd * np.where(flag, 1.0 / np.where(flag, peak, 1.0), 1.0)[:, None]
    np.testing.assert_array_equal(out, ref)


def test_payload_float_torque_equals_torque_terms():
    src = RotatingPayloadTorque([ROTATING_PAYLOAD_EXAMPLE])
    rng = np.random.default_rng(8)
    for B in (1, 4):
        for t in (0.0, 2.7, 91.3):
            w = 0.01 * rng.normal(size=(B, 3))
            ref = ROTATING_PAYLOAD_EXAMPLE.torque(t, w)
            np.testing.assert_allclose(src(t, None, w), ref, rtol=1e-12, atol=1e-15)


def test_star_tracker_cached_misalignment():
    """R exp(m^) exp(δ^) with exp(m^) computed once (the compiled kernel of both simulator
    routes, spacecraft._kernels_sensors.star_tracker_into: its Rodrigues sin/cos form and
    so3.exp's tan form agree to a few ulp); m = 0 skips the product, R I = R exactly."""
    rng = np.random.default_rng(9)
    R = so3.exp(rng.normal(size=(3, 3)))
    m = np.array([1e-3, -2e-3, 5e-4])
    st = StarTracker(noise_std=1e-4, output="matrix", misalignment=m)
    got = st.measure(0.0, R, None, np.random.default_rng(1))
    delta = np.random.default_rng(1).standard_normal((3, 3)) * 1e-4
    np.testing.assert_allclose(got, R @ so3.exp(m) @ so3.exp(delta), rtol=0, atol=1e-15)
    assert st.kernel_args()[1] is st._mis_R
    st0 = StarTracker(noise_std=1e-4, output="matrix")
    got0 = st0.measure(0.0, R, None, np.random.default_rng(1))
    np.testing.assert_allclose(got0, R @ so3.exp(delta), rtol=0, atol=1e-15)
    assert st0.kernel_args()[0] is False


@pytest.mark.parametrize("disturbance", [None, ConstantHarmonicTorque()])
@pytest.mark.parametrize("B", [3, 600])  # 600: the column-wise cross product (≥ 512 rows)
def test_per_spacecraft_inertia_step_is_bitwise_the_single_step(disturbance, B):
    """Every spacecraft of a batched-J step is bitwise its own single-spacecraft step."""
    from spacecraft import perturbed_inertia

    rng = np.random.default_rng(3)
    Js = perturbed_inertia(J, rng, 0.2, axis_std=0.1, size=B)
    actuator = SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust())
    plant = Spacecraft(RigidBody(Js), actuator, disturbance)
    assert plant._kernel_plan is not None
    R = so3.exp(rng.normal(size=(B, 3)))
    x = np.concatenate([0.02 * rng.normal(size=(B, 3)), rng.normal(size=(B, 4))], 1)
    held = actuator.command(rng.normal(size=(B, 3)), x[:, :3], x[:, 3:], 0.0)
    R_new, x_new = plant.step_packed(1.0, R, x, held, 0.1)
    for b in (0, 1, B - 1):
        s = slice(b, b + 1)
        one = Spacecraft(RigidBody(Js[b]), actuator, disturbance)
        held_b = CmgCommand(held.delta_dot[s], held.saturated[s], held.h_dot_cmd[s])
        R1, x1 = one.step_packed(1.0, R[s], x[s], held_b, 0.1)
        np.testing.assert_array_equal(R_new[s], R1)
        np.testing.assert_array_equal(x_new[s], x1)
