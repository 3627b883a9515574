"""The geometric laws that fly on the JAX route through their array laws
(liecontrol.control.array_law): GeometricPD with the trace error, AdaptiveGeometricSO3.

For each: the JAX route equals the fused numba loop (attitude 1e-12, torques and logged
diagnostics 1e-11, flags exactly) with the SGCMG cluster and with a saturating ideal actuator,
from 179.9° with non-zero rates; the carried state is exercised; gradients are finite from the
identity, near π and through a saturation switch; the registry's configuration gives the numba
run's metrics; unsupported options are refused naming the attribute."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from conftest import assert_same_outcomes, suite_on_both_routes

from liecontrol import errors
from liecontrol.control import GeometricPD, gains_from_bandwidth
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import RigidBody, Spacecraft, simulate
from spacecraft.actuators import IdealTorqueActuator, SgcmgActuator

J = np.diag([20.0, 25.0, 30.0])
J[0, 1] = J[1, 0] = 0.5
DT, PERIOD = 0.1, 0.2


@pytest.fixture
def jax():
    """JAX in float64 (the route's own entry points switch it on themselves)."""
    jax = pytest.importorskip("jax")
    with jax.enable_x64(True):
        yield jax


def _starts(seed: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Three starts (179.9°, 60°, 5° about random axes) with non-zero rates."""
    rng = np.random.default_rng(seed)
    ax = rng.normal(size=(3, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    R0 = so3.exp(ax * np.radians([179.9, 60.0, 5.0])[:, None])
    return R0, rng.normal(size=(3, 3)) * 0.01


_REF = ConstantAttitude(so3.exp(np.array([0.1, 0.2, 0.3])))


def _plant(actuator: str, max_torque: float = 1.0) -> Spacecraft:
    act = SgcmgActuator() if actuator == "sgcmg" else IdealTorqueActuator(max_torque=max_torque)
    return Spacecraft(RigidBody(J), act)


def _fly(ctrl, plant, t_final, R0, w0, ref=_REF, diag=(), flags=()):  # noqa: ANN001, ANN202
    """The JAX route's run and simulate's (fused numba) run, compared."""
    from spacecraft.differentiable import closed_loop

    want = simulate(plant, ctrl, ref, plant.initial_state(R0, w0), t_final, DT,
                    control_period=PERIOD, log_every=2)  # fmt: skip
    loop = closed_loop(plant, ctrl, ref, t_final, DT, PERIOD)
    run = loop.run(R0, w0)
    np.testing.assert_allclose(run.R, want.R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.omega, want.omega, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.u, want.u, rtol=0, atol=1e-11)
    np.testing.assert_allclose(run.u_cmd, want.u_cmd, rtol=0, atol=1e-11)
    for k, v in run.actuator.items():
        if v.dtype == bool:
            np.testing.assert_array_equal(v, want.actuator[k], err_msg=k)
        else:
            np.testing.assert_allclose(v, want.actuator[k], rtol=0, atol=1e-12, err_msg=k)
    for k in diag:
        np.testing.assert_allclose(run.controller[k], want.controller[k], rtol=0, atol=1e-11,
                                   err_msg=k)  # fmt: skip
    for k in flags:
        np.testing.assert_array_equal(run.controller[k], want.controller[k], err_msg=k)
    return loop, run, want


def _suite_equal(names: list[str], caplog, extra: tuple[str, ...] = ()) -> None:  # noqa: ANN001
    """run_suite on slew-90 (and the ``extra`` scenarios; 40 s, 2 members): the JAX route gives
    the numba run's metrics and verdicts, and flies every one of ``names`` (no fallback
    logged)."""
    from benchmarks.scenarios import get_scenario

    scs = [get_scenario(n).with_duration(40.0) for n in ("slew-90", *extra)]
    a, b = suite_on_both_routes(scs, names, caplog)
    assert "ran on the numba loop" not in caplog.text, caplog.text
    assert_same_outcomes(a, b)


def _grad_finite(loop, k_R, k_Omega) -> None:  # noqa: ANN001
    """Finite, non-zero gain gradients from the identity (with a rate), near π (179.9°) and
    from a start at exactly π."""
    R0 = so3.exp(np.array([[0.0, 0.0, 0.0], [0.0, np.radians(179.9), 0.0], [np.pi, 0.0, 0.0]]))
    R0 = _REF.R_d @ R0
    w0 = np.array([[0.01, -0.01, 0.02], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    v, gR, gW = loop.value_and_grad(k_R, k_Omega, R0, w0, effort_weight=0.01)
    assert np.isfinite(v) and np.isfinite(gR).all() and np.isfinite(gW).all()
    assert np.any(gR != 0.0) and np.any(gW != 0.0)


# ------------------------------------------------------------------------ GeometricPD, trace


def _trace_pd(G=None) -> GeometricPD:  # noqa: ANN001
    kR, kW = gains_from_bandwidth(J, 0.3, 0.9, error="trace", G=G)
    return GeometricPD(J * 1.05, kR, kW, error="trace", G=G)  # the model differs from the plant


@pytest.mark.parametrize("actuator", ["sgcmg", "ideal"])
def test_trace_pd_equals_fused_simulate(actuator, jax):
    G = np.diag([0.8, 1.0, 1.3])
    G[0, 2] = G[2, 0] = 0.05  # a weight that is not diagonal
    _, run, want = _fly(_trace_pd(G), _plant(actuator), 40.0, *_starts(),
                        diag=("Psi", "e_R", "e_Omega"))  # fmt: skip
    if actuator == "ideal":
        assert want.actuator["saturated"].any()  # the torque box is hit in the run
    # the trace error's potential from the 179.9° start (its maximum region) falls
    assert want.controller["Psi"][0, 0] > 2.0 > want.controller["Psi"][-1, 0]


def test_trace_error_is_pure_and_its_gradient_finite_at_the_antipodal_set(jax):
    """The trace error under jax.numpy gives NumPy's values; its derivative is finite at the
    identity, at π about G's eigenvectors (the saddles / the unstable maximum) and near π."""
    jnp = jax.numpy
    G = np.diag([0.9, 1.0, 1.1])
    rng = np.random.default_rng(0)
    Rt = np.concatenate([so3.random(rng, 5), so3.exp(np.pi * np.eye(3)), np.eye(3)[None]])
    for a, b in zip(errors._trace_error_unchecked(jnp.asarray(Rt), G),
                    errors._trace_error_unchecked(Rt, G), strict=True):  # fmt: skip
        np.testing.assert_allclose(np.asarray(a), b, rtol=0, atol=1e-15)

    def f(w):
        psi, e = errors._trace_error_unchecked(so3.exp(w), G)
        return psi + jnp.sum(e * e)

    g = jax.grad(f)
    for w in ([0.0, 0.0, 0.0], [np.pi, 0.0, 0.0], [0.0, 0.0, np.pi], [0.0, np.pi - 1e-3, 0.0],
              [1.0, 2.0, 0.3]):  # fmt: skip
        assert np.isfinite(np.asarray(g(jnp.asarray(w)))).all(), w
    # at the critical points the error vector vanishes (a saddle of Ψ at π about e_x)
    np.testing.assert_allclose(
        np.asarray(errors._trace_error_unchecked(so3.exp(jnp.array([np.pi, 0, 0])), G)[1]),
        0.0, atol=1e-15,
    )  # fmt: skip


@functools.lru_cache(maxsize=1)
def _trace_loop():
    from spacecraft.differentiable import closed_loop

    ctrl = _trace_pd()
    return closed_loop(_plant("ideal", 0.5), ctrl, _REF, 20.0, DT, PERIOD), ctrl


def test_trace_pd_gradient_finite_near_pi_and_through_saturation(jax):
    loop, ctrl = _trace_loop()
    R0, w0 = _starts()
    assert loop.run(R0, w0).actuator["saturated"].any()  # the saturation switch is crossed
    _grad_finite(loop, ctrl.k_R, ctrl.k_Omega)


def test_trace_pd_gradient_matches_central_differences(jax):
    loop, ctrl = _trace_loop()
    R0, w0 = _starts(5)
    kR, kW = ctrl.k_R, ctrl.k_Omega
    _, gR, gW = loop.value_and_grad(kR, kW, R0, w0, effort_weight=0.01)
    cost = jax.jit(loop.cost)
    for g, dR, dW in ((gR, 1e-5 * kR, 0.0), (gW, 0.0, 1e-5 * kW)):
        up = float(cost(kR + dR, kW + dW, R0, w0, effort_weight=0.01))
        down = float(cost(kR - dR, kW - dW, R0, w0, effort_weight=0.01))
        fd = (up - down) / (2.0 * (dR + dW))
        assert abs(fd - float(g)) <= 1e-6 * abs(float(g)), (fd, g)


def test_trace_pd_registry_configuration_flies(jax, caplog):
    _suite_equal(["geometric-pd-trace"], caplog)


# ------------------------------------------------------------------------ AdaptiveGeometricSO3

_NU = 0.05  # the harmonic disturbance's frequency [rad/s] (ConstantHarmonicTorque(n=_NU))


def _adaptive(error: str = "large_angle", bound: float = 0.3):  # noqa: ANN202
    from liecontrol.control.adaptive import AdaptiveGeometricSO3
    from liecontrol.control.tuning import ClosedLoopSpec, tune_adaptive_so3

    kw = tune_adaptive_so3(J * 1.1, ClosedLoopSpec(0.3, 0.9, PERIOD), disturbance_bound=bound,
                           frequencies=(_NU, 2.0 * _NU), error=error)  # fmt: skip
    kw["gamma_theta"] *= 50.0  # fast inertia adaptation: the estimates move within the run
    return AdaptiveGeometricSO3(J * 1.1, **kw)  # the nominal inertia is 10 % off


def _disturbed(actuator: str, max_torque: float = 1.0) -> Spacecraft:
    from spacecraft.disturbances import ConstantHarmonicTorque

    plant = _plant(actuator, max_torque)
    return Spacecraft(plant.body, plant.actuator, disturbance=ConstantHarmonicTorque(n=_NU,
                      scale=3.0))  # fmt: skip


_ADAPTIVE_DIAG = ("Psi", "e_R", "e_Omega", "s", "d_hat", "theta_hat", "phi_hat", "J_hat")
_ADAPTIVE_FLAGS = ("theta_projected", "phi_projected")


@pytest.mark.parametrize(("actuator", "error"), [("sgcmg", "large_angle"), ("ideal", "trace")])
def test_adaptive_equals_fused_simulate_and_its_estimates_move(actuator, error, jax):
    ctrl = _adaptive(error, bound=0.05)
    _, run, want = _fly(ctrl, _disturbed(actuator), 40.0, *_starts(), diag=_ADAPTIVE_DIAG,
                        flags=_ADAPTIVE_FLAGS)  # fmt: skip
    th, ph = want.controller["theta_hat"], want.controller["phi_hat"]
    # the estimates are carried by the scan and move: the inertia estimate leaves θ₀, the
    # disturbance estimate leaves 0 and reaches its ball (the projection acts)
    assert np.abs(th[-1] - ctrl.theta0).max() > 1e-3 * np.abs(ctrl.theta0).max()
    assert np.abs(ph[-1]).max() > 1e-3
    assert want.controller["phi_projected"].any()
    assert not want.controller["phi_projected"][0].any()  # nothing to project at the first
    if actuator == "ideal":
        assert want.actuator["saturated"].any()


def test_adaptive_gradient_finite_near_pi_and_through_saturation(jax):
    from spacecraft.differentiable import closed_loop

    ctrl = _adaptive("large_angle")
    loop = closed_loop(_disturbed("ideal", 0.5), ctrl, _REF, 20.0, DT, PERIOD)
    R0, w0 = _starts()
    assert loop.run(R0, w0).actuator["saturated"].any()  # the saturation switch is crossed
    # from R_d with a rate and from 179.9° (the large-angle E grows like 1/cos(θ/2) at π)
    R0 = _REF.R_d @ so3.exp(np.array([[0.0, 0.0, 0.0], [0.0, np.radians(179.9), 0.0]]))
    w0 = np.array([[0.01, -0.01, 0.02], [0.0, 0.0, 0.0]])
    v, gR, gW = loop.value_and_grad(ctrl.k_R, ctrl.k_s, R0, w0, effort_weight=0.01)
    assert np.isfinite(v) and np.isfinite(gR).all() and np.isfinite(gW).all()
    assert np.any(gR != 0.0) and np.any(gW != 0.0)


def test_adaptive_trace_gradient_finite_at_pi(jax):
    """The trace error is smooth at π: from exactly π too (the estimator's ball projection
    starts at its centre, where the norm's square root is guarded)."""
    from spacecraft.differentiable import closed_loop

    ctrl = _adaptive("trace")
    loop = closed_loop(_disturbed("ideal", 0.5), ctrl, _REF, 20.0, DT, PERIOD)
    _grad_finite(loop, ctrl.k_R, ctrl.k_s)


def test_adaptive_registry_configuration_flies(jax, caplog):
    _suite_equal(["adaptive-so3"], caplog)


def test_adaptive_log_error_is_refused_naming_the_attribute(jax):
    from spacecraft.differentiable import closed_loop

    with pytest.raises(ValueError, match=r"^controller\.error: .*'log'"):
        closed_loop(_plant("ideal"), _adaptive("log"), _REF, 10.0, DT, PERIOD)


# ------------------------------------------------------------------ keep-out / keep-in barriers


def _cones():  # noqa: ANN202
    """A 20° keep-out cone for the body x axis 0.6 rad from its target direction (the starts
    pass close to it) and a wide keep-in cone for the body z axis."""
    from liecontrol.control.constrained import KeepInCone, KeepOutCone

    x_d = so3.exp(np.array([0.0, 0.0, 0.6])) @ _REF.R_d @ np.array([1.0, 0.0, 0.0])
    return ((KeepOutCone((1.0, 0.0, 0.0), tuple(x_d), 20.0),),
            (KeepInCone((0.0, 0.0, 1.0), tuple(_REF.R_d[:, 2]), 170.0),))  # fmt: skip


def _keep_out_pd():  # noqa: ANN202
    from liecontrol.control.constrained import ConstrainedGeometricPD

    kR, kW = gains_from_bandwidth(J, 0.3, 0.9)
    keep_out, keep_in = _cones()
    return ConstrainedGeometricPD(J * 1.05, kR, kW, keep_out=keep_out, keep_in=keep_in)


@pytest.mark.parametrize("actuator", ["sgcmg", "ideal"])
def test_keep_out_pd_equals_fused_simulate(actuator, jax):
    from liecontrol.control.constrained import cone_margins_deg

    plant = _plant(actuator, 3.0)
    _, run, want = _fly(_keep_out_pd(), plant, 40.0, *_starts(),
                        diag=("Psi", "e_R", "e_Omega", "min_slack"))  # fmt: skip
    # the barrier acts: the 179.9° start passes within 1 % of the keep-out boundary, and
    # every attitude of the run stays admissible
    assert 0.0 < want.controller["min_slack"][:, 0].min() < 1e-2
    keep_out, keep_in = _cones()
    assert cone_margins_deg(keep_out + keep_in, run.R.reshape(-1, 3, 3)).min() > 0.0
    if actuator == "ideal":
        assert want.actuator["saturated"].any()


def test_keep_out_pd_gradient_finite_and_inadmissible_start_is_nan(jax):
    from spacecraft.differentiable import closed_loop

    ctrl = _keep_out_pd()
    loop = closed_loop(_plant("ideal", 3.0), ctrl, _REF, 20.0, DT, PERIOD)
    R0, w0 = _starts()
    assert loop.run(R0, w0).actuator["saturated"].any()  # the saturation switch is crossed
    # from R_d (inside the admissible set, barrier terms non-zero) with a rate, from the
    # 179.9° start (it passes the keep-out boundary closely), from the 60° one
    R0 = np.concatenate([_REF.R_d[None], R0[:2]])
    w0 = np.array([[0.01, -0.01, 0.02], *w0[:2]])
    v, gR, gW = loop.value_and_grad(ctrl.k_R, ctrl.k_Omega, R0, w0, effort_weight=0.01)
    assert np.isfinite(v) and np.isfinite(gR).all() and np.isfinite(gW).all()
    assert np.any(gR != 0.0) and np.any(gW != 0.0)
    # a start inside the keep-out cone, which command() refuses, is a NaN torque, as in the
    # compiled kernel: the route reports that member as diverged
    x = _cones()[0][0]._s
    b = np.cross([1.0, 0.0, 0.0], x)
    R_bad = so3.exp(np.arcsin(np.linalg.norm(b)) * b / np.linalg.norm(b))  # body x along s
    run = loop.run(np.stack([R_bad, _REF.R_d]), np.zeros((2, 3)))
    assert run.diverged.tolist() == [True, False]


def test_keep_out_registry_configuration_flies(jax, caplog):
    # keep-out-sun-slew: the scenario's Sun cone on the slew's path (slew-90 has no cones)
    _suite_equal(["geometric-keep-out"], caplog, ("keep-out-sun-slew",))


def _sampled(max_torque: float = 3.0, **kw):  # noqa: ANN202
    from liecontrol.control.constrained import SampledSafeConstrainedPD

    kR, kW = gains_from_bandwidth(J, 0.3, 0.9)
    keep_out, keep_in = _cones()
    return SampledSafeConstrainedPD(J * 1.05, kR, kW, keep_out, keep_in, max_torque=max_torque,
                                    sample_period=PERIOD, **kw)  # fmt: skip


_SAFE_DIAG = ("Psi", "e_R", "e_Omega", "min_slack", "braking_margin", "margin")


@pytest.mark.parametrize("actuator", ["sgcmg", "ideal"])
def test_sampled_safe_filter_equals_fused_simulate(actuator, jax):
    R0, w0 = _starts()
    w0 = w0 + np.array([0.0, 0.0, -0.05])  # turning toward the keep-out cone: the filter acts
    _, run, want = _fly(_sampled(), _plant(actuator, 3.0), 40.0, R0, w0, diag=_SAFE_DIAG,
                        flags=("filter_active",))  # fmt: skip
    assert want.controller["filter_active"].any()  # the safety filter changes the command
    assert want.controller["margin"].min() > 0.0
    if actuator == "ideal":
        assert want.actuator["saturated"].any()


def test_sampled_safe_gradient_finite_through_the_filter(jax):
    from spacecraft.differentiable import closed_loop

    ctrl = _sampled()
    loop = closed_loop(_plant("ideal", 3.0), ctrl, _REF, 20.0, DT, PERIOD)
    R0, w0 = _starts()
    w0 = w0 + np.array([0.0, 0.0, -0.05])
    run = loop.run(R0, w0)
    assert run.controller["filter_active"].any() and run.actuator["saturated"].any()
    R0 = np.concatenate([_REF.R_d[None], R0[:2]])
    w0 = np.array([[0.01, -0.01, 0.02], *w0[:2]])
    v, gR, gW = loop.value_and_grad(
        ctrl.nominal.k_R, ctrl.nominal.k_Omega, R0, w0, effort_weight=0.01
    )
    assert np.isfinite(v) and np.isfinite(gR).all() and np.isfinite(gW).all()
    assert np.any(gR != 0.0) and np.any(gW != 0.0)
    # the filter's arccos at a boresight exactly on a cone's axis (|c| = 1): finite derivative
    from liecontrol.control.constrained import braking_filter

    jnp = jax.numpy
    keep_out, keep_in = _cones()
    R_on_axis = _REF.R_d  # body z exactly along the keep-in cone's axis

    def f(w):
        u, *_ = braking_filter(jnp.ones(3), jnp.asarray(R_on_axis), w, J, keep_out + keep_in,
                               np.full(3, 3.0), PERIOD)  # fmt: skip
        return jnp.sum(u * u)

    assert np.isfinite(np.asarray(jax.grad(f)(jnp.asarray([0.01, 0.02, -0.03])))).all()


def test_sampled_safe_registry_configuration_flies(jax, caplog):
    _suite_equal(["geometric-keep-out-sampled"], caplog, ("keep-out-sun-slew",))


def test_sampled_safe_strict_is_refused_naming_the_attribute(jax):
    from spacecraft.differentiable import closed_loop

    with pytest.raises(ValueError, match=r"^controller\.strict: "):
        closed_loop(_plant("ideal", 3.0), _sampled(strict=True), _REF, 10.0, DT, PERIOD)
