"""The JAX route flies the funnel and sliding-mode laws: PrescribedPerformance (timed; the
funnel's width and start carried by the scan), FiniteTimeSO3 / FixedTimeSO3 (fractional powers
kept differentiable at the target) and AdaptiveFaultTolerantSO3 (adaptive estimates carried by
the scan). For each: the fused numba loop's trajectory, torques and diagnostics to round-off
with the SGCMG cluster and with a saturating ideal actuator from 179.9° and non-zero rates;
finite gradients from the identity, near π and through saturation; the registry's
configuration in the benchmark suite; unsupported options named.

JAX is an optional extra (``liecontrol[jax]``): these tests skip without it."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from conftest import assert_same_outcomes

from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import RigidBody, Spacecraft, simulate
from spacecraft.actuators import IdealTorqueActuator, SgcmgActuator

J0 = np.diag([20.0, 25.0, 30.0])
REF = ConstantAttitude(so3.exp(np.array([0.1, 0.2, 0.3])))


@pytest.fixture
def jax():
    """JAX in float64 (the route's own entry points switch it on themselves)."""
    jax = pytest.importorskip("jax")
    with jax.enable_x64(True):
        yield jax


def _starts(n: int = 3, seed: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """``n`` starts about random axes: 179.9°, 60°, 5° (…) from the reference, non-zero rates."""
    rng = np.random.default_rng(seed)
    ax = rng.normal(size=(n, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    angles = np.radians([179.9, 60.0, 5.0, 120.0][:n])
    return REF.R_d @ so3.exp(ax * angles[:, None]), rng.normal(size=(n, 3)) * 0.01


def _plant(actuator: str, max_torque: float = 1.0) -> Spacecraft:
    act = SgcmgActuator() if actuator == "sgcmg" else IdealTorqueActuator(max_torque=max_torque)
    return Spacecraft(RigidBody(J0), act)


def _compare(ctrl, actuator: str, t0: float = 0.0, max_torque: float = 1.0, u_scale=False):
    """The JAX route against the fused numba simulate: attitude to 1e-12, torques and the
    controller's diagnostics to 1e-11 (flags and counts exactly). Returns (numba run, loop)."""
    from spacecraft.differentiable import closed_loop

    plant = _plant(actuator, max_torque)
    R0, w0 = _starts()
    t_final = t0 + 40.0
    kw = dict(control_period=0.2, log_every=2, t0=t0)
    want = simulate(plant, ctrl, REF, plant.initial_state(R0, w0), t_final, 0.1, **kw)
    loop = closed_loop(plant, ctrl, REF, t_final, 0.1, 0.2, t0=t0)
    run = loop.run(R0, w0)
    np.testing.assert_allclose(run.t, want.t, rtol=1e-15)
    np.testing.assert_allclose(run.R, want.R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.omega, want.omega, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.u, want.u, rtol=0, atol=1e-11)  # delivered (after saturation)
    # a command far beyond the actuator (the funnel's edge) is compared relative to its size
    scale = max(1.0, float(np.abs(want.u_cmd).max())) if u_scale else 1.0
    np.testing.assert_allclose(run.u_cmd, want.u_cmd, rtol=0, atol=1e-11 * scale)
    assert run.controller.keys() == want.controller.keys()
    for k, v in want.controller.items():
        if v.dtype.kind in "biu":
            np.testing.assert_array_equal(run.controller[k], v, err_msg=k)
        else:
            np.testing.assert_allclose(run.controller[k], v, rtol=0, atol=1e-11, err_msg=k)
    for k, v in run.actuator.items():
        if v.dtype == bool:
            np.testing.assert_array_equal(v, want.actuator[k], err_msg=k)
        else:
            np.testing.assert_allclose(v, want.actuator[k], rtol=0, atol=1e-12, err_msg=k)
    assert not run.diverged.any()
    return want, loop


def _gradients_finite(loop, kR, kW) -> None:
    """value_and_grad finite (and non-zero) from the identity at rest, from near π, and from
    the saturating start batch; exactly zero at rest at R_d."""
    R0, w0 = _starts(2)
    ident = np.stack([REF.R_d] * 2)
    near_pi = REF.R_d @ so3.exp(np.array([[0.0, 0.0, np.radians(179.9)], [np.radians(179.9),
                                          0.0, 0.0]]))  # fmt: skip
    sat = loop.run(near_pi, w0).actuator["saturated"]
    assert (sat[1:] != sat[:-1]).any()  # the saturation switch is crossed in the run
    for R, w in ((ident, np.zeros((2, 3))), (ident, np.full((2, 3), 0.01)), (near_pi, w0),
                 (R0, w0)):  # fmt: skip
        v, gR, gW = loop.value_and_grad(kR, kW, R, w, effort_weight=0.01)
        assert np.isfinite([v]).all() and np.isfinite(gR).all() and np.isfinite(gW).all()
        if w.any() or R is not ident:
            assert np.any(gR != 0.0) and np.any(gW != 0.0)
        else:
            assert v == 0.0 and np.all(gR == 0.0) and np.all(gW == 0.0)


def _suite_equals_numba(name: str, caplog) -> None:
    """The registry's configuration of ``name`` on slew-90 (40 s, 2 members): the JAX route's
    metrics equal the numba loop's to round-off, same verdicts, no fallback logged."""
    import logging

    from benchmarks.runner import run_suite
    from benchmarks.scenarios import get_scenario

    scs = [get_scenario("slew-90").with_duration(40.0)]
    a = run_suite(scs, [name], members=2, executor="serial", progress=False)
    with caplog.at_level(logging.INFO, logger="benchmarks.runner"):
        b = run_suite(scs, [name], members=2, executor="serial", progress=False, backend="jax")
    assert "ran on the numba loop" not in caplog.text, caplog.text
    assert_same_outcomes(a, b)


# ------------------------------------------------------------------------ prescribed performance


@functools.lru_cache(maxsize=1)
def _ppc():
    from liecontrol.control.prescribed_performance import PrescribedPerformance, ppc_gains

    k1, k2, kc = ppc_gains(0.3, 0.9)
    return PrescribedPerformance(J0 * 1.05, 0.01, 0.1, k1=k1, k2=k2, kc=kc)


@pytest.mark.parametrize("actuator", ["sgcmg", "ideal"])
def test_prescribed_performance_equals_fused_simulate(actuator, jax):
    """The funnel's width (chosen per spacecraft at the first sample), its start (the first
    sample, here t₀ = 3 s) and the violation count ride in the scan; with a 0.5 N·m box the
    179.9° member leaves the funnel and hits the transformation's edge clip. (At the edge the
    law's gain, ∝ 1/(ρ(1 − z²))², amplifies the last-bit differences of the two compilers'
    exp/artanh: a run whose z grazes z_max at a sample may flip that sample's clip.)"""
    ctrl = _ppc()
    want, _ = _compare(ctrl, actuator, t0=3.0, max_torque=0.5, u_scale=actuator == "ideal")
    rho = want.controller["rho"]
    assert len(set(np.round(rho[0], 12))) == 3  # ρ₀ chosen per spacecraft from its error
    assert rho[0, 0] > rho[0, 1] > rho[0, 2] and (np.diff(rho, axis=0) <= 0.0).all()  # shrinks
    if actuator == "ideal":
        assert want.actuator["saturated"].any()
        assert want.controller["funnel_violations"][-1, 0] > 0  # the counter moves
        assert want.controller["edge_saturated"].any()


@functools.lru_cache(maxsize=1)
def _ppc_loop():
    from spacecraft.differentiable import closed_loop

    return closed_loop(_plant("ideal", 3.0), _ppc(), REF, 20.0, 0.1, 0.2)


def test_prescribed_performance_gradient_finite_and_matches_differences(jax):
    """Gradients in k_c (k_R) and k₂ (k_Ω) finite from the identity, near π and through the
    saturation; they match central differences; the funnel's params are differentiable."""
    loop = _ppc_loop()
    ctrl = _ppc()
    _gradients_finite(loop, ctrl.kc, ctrl.k2)
    R0, w0 = _starts(2, seed=5)
    R0 = so3.exp(so3.log(R0) * 0.5)  # moderate errors: a smooth cost (no funnel contact)
    _, gR, gW = loop.value_and_grad(ctrl.kc, ctrl.k2, R0, w0, effort_weight=0.01)
    cost = jax.jit(loop.cost)
    kc, k2 = ctrl.kc, ctrl.k2
    for g, dR, dW in ((gR, 1e-5 * kc, 0.0), (gW, 0.0, 1e-5 * k2)):
        up = float(cost(kc + dR, k2 + dW, R0, w0, effort_weight=0.01))
        down = float(cost(kc - dR, k2 - dW, R0, w0, effort_weight=0.01))
        fd = (up - down) / (2.0 * (dR + dW))
        assert abs(fd - float(g)) <= 1e-6 * abs(float(g)), (fd, g)
    # the further parameters (k₁, ρ_∞, l) through rollout's params
    jnp = jax.numpy
    x0 = jnp.asarray(w0[0])

    def final_error(p):
        out = loop.rollout(kc, k2, jnp.asarray(R0[0]), x0, params=p)
        return jnp.sum(out["controller/e_R"][-1] ** 2)

    p0 = {k: jnp.asarray(v) for k, v in loop.law.params.items()}
    assert set(p0) == {"k1", "rho_inf", "decay"}
    g = jax.grad(final_error)(p0)
    assert all(np.isfinite(float(v)) and float(v) != 0.0 for v in g.values()), g


def test_prescribed_performance_suite_backend_jax_equals_numba(jax, caplog):
    _suite_equals_numba("prescribed-performance", caplog)


def test_prescribed_performance_infeasible_funnel_is_a_nan_torque(jax):
    """A given ρ₀ that does not contain the first error: the compiled kernel's NaN torque
    (the route flags the member as diverged; command() raises ValueError)."""
    from liecontrol.control.prescribed_performance import PrescribedPerformance
    from spacecraft.differentiable import closed_loop

    ctrl = PrescribedPerformance(J0, 0.01, 0.1, rho0=0.2)
    R0 = REF.R_d @ so3.exp(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.1]]))  # |e_z| ≈ 0.48, 0.05
    run = closed_loop(_plant("ideal"), ctrl, REF, 4.0, 0.1, 0.2).run(R0)
    assert run.diverged.tolist() == [True, False]
    assert np.isnan(run.u_cmd[0, 0]).all() and np.isfinite(run.u_cmd[:, 1]).all()


# ------------------------------------------------------------------ finite- and fixed-time SO(3)


@functools.lru_cache(maxsize=2)
def _sliding(fixed: bool):
    from liecontrol.control.finite_time import FiniteTimeSO3, FixedTimeSO3
    from liecontrol.control.tuning import ClosedLoopSpec, tune_finite_time_so3

    kw = tune_finite_time_so3(J0, ClosedLoopSpec(0.3, 0.9, 0.2), fixed_time=fixed)
    return (FixedTimeSO3 if fixed else FiniteTimeSO3)(J0 * 1.05, **kw)


@pytest.mark.parametrize("fixed", [False, True], ids=["finite", "fixed"])
@pytest.mark.parametrize("actuator", ["sgcmg", "ideal"])
def test_finite_and_fixed_time_equal_fused_simulate(actuator, fixed, jax):
    """The runs reach the layers: ‖e_R‖ below ε (the tangent-line continuation of g_r) and
    ‖s‖ below ε_s (the boundary layer), where the fractional powers would be singular."""
    ctrl = _sliding(fixed)
    want, _ = _compare(ctrl, actuator)
    p = ctrl.params
    x = np.linalg.norm(want.controller["e_R"], axis=-1)
    y = np.linalg.norm(want.controller["s"], axis=-1)
    assert (x > p.eps).any() and (x < p.eps).any()
    assert (y > p.eps_s).any() and (y < p.eps_s).any()
    if actuator == "ideal":
        assert want.actuator["saturated"].any()


@pytest.mark.parametrize("fixed", [False, True], ids=["finite", "fixed"])
def test_finite_and_fixed_time_gradients_finite_at_the_target(fixed, jax):
    """Gradients in k₂ (k_R) and c₂ (k_Ω) finite from the identity (e_R = 0, s = 0: the
    fractional powers' derivatives at 0), near π and through saturation; and the law's
    derivative in the state itself at e_R = 0 and s = 0."""
    from liecontrol.control.array_law import array_law_of
    from spacecraft.differentiable import closed_loop

    ctrl = _sliding(fixed)
    loop = closed_loop(_plant("ideal", 0.5), ctrl, REF, 20.0, 0.1, 0.2)
    _gradients_finite(loop, ctrl.params.k2, ctrl.params.c2)
    jnp = jax.numpy
    law = array_law_of(ctrl)
    assert set(law.params) >= {"k1", "r", "eps", "c1", "rho", "eps_s"}
    assert ("c3" in law.params) == fixed
    I3, z3 = jnp.eye(3), jnp.zeros(3)

    def torque(w, p):
        M, _, _ = law.call(law.k_R, law.k_Omega, (), I3 @ so3.exp(w), w, I3, z3, z3, 0.2, p)
        return jnp.sum(M * M) + jnp.sum(M)

    p0 = {k: jnp.asarray(v) for k, v in law.params.items()}
    for w in (z3, jnp.full(3, 1e-9), jnp.array([0.0, 0.0, np.pi - 1e-3])):
        gw, gp = jax.grad(torque, argnums=(0, 1))(w, p0)
        assert np.isfinite(np.asarray(gw)).all(), w
        assert all(np.isfinite(float(v)) for v in gp.values()), (w, gp)


@pytest.mark.parametrize("name", ["finite-time-so3", "fixed-time-so3"])
def test_finite_and_fixed_time_suite_backend_jax_equals_numba(name, jax, caplog):
    _suite_equals_numba(name, caplog)


# --------------------------------------------------------------------- adaptive fault tolerant


def _fault_tolerant(which: int):
    from liecontrol.control.fault_tolerant import AdaptiveFaultTolerantSO3, fault_tolerant_gains

    kw = fault_tolerant_gains(J0, 0.3, 0.2, beta_max=0.5)
    if which == 1:  # its own torque clip (k̂ frozen on a saturated sample), a fixed layer
        kw.update(max_torque=0.8, adaptive_sigma=False)
    return AdaptiveFaultTolerantSO3(J0 * 1.05, **kw)


@pytest.mark.parametrize("which", [0, 1], ids=["adaptive-sigma", "own-clip"])
@pytest.mark.parametrize("actuator", ["sgcmg", "ideal"])
def test_fault_tolerant_equals_fused_simulate(actuator, which, jax):
    """The adaptive estimates (k̂, β̂), their held rates and the previous sample's time ride in
    the scan (here from t₀ = 3 s): both move in the run, and so does the adaptive layer σ(t)."""
    want, _ = _compare(_fault_tolerant(which), actuator, t0=3.0)
    c = want.controller
    assert (np.abs(c["k_hat"][-1] - 1.0) > 1e-6).any()  # k̂ adapted
    assert (c["beta_hat"][-1] > 1e-3).all() and (np.diff(c["beta_hat"], axis=0) >= 0.0).all()
    if which == 0:
        assert np.ptp(c["sigma"], axis=0).min() > 0.0  # σ(t) follows the estimates
    else:
        assert c["saturated"].any() and not c["saturated"].all()  # k̂ frozen, then adapted


def test_fault_tolerant_gradient_finite_and_matches_differences(jax):
    """Gradients in λ (k_R) and K (k_Ω, 3×3) finite from the identity, near π (the log's and
    J_r⁻¹'s guarded branches) and through saturation, matching central differences; the
    adaptation gains and the layer are differentiable params."""
    from spacecraft.differentiable import closed_loop

    ctrl = _fault_tolerant(0)
    loop = closed_loop(_plant("ideal", 1.0), ctrl, REF, 20.0, 0.1, 0.2)
    _gradients_finite(loop, ctrl.lam, ctrl.K)
    R0, w0 = _starts(2, seed=5)
    R0 = so3.exp(so3.log(R0) * 0.3)
    _, gR, gW = loop.value_and_grad(ctrl.lam, ctrl.K, R0, w0, effort_weight=0.01)
    cost = jax.jit(loop.cost)

    def c(lam, K):
        return float(cost(lam, K, R0, w0, effort_weight=0.01))

    dR = 1e-5 * ctrl.lam
    fd = (c(ctrl.lam + dR, ctrl.K) - c(ctrl.lam - dR, ctrl.K)) / (2.0 * dR)
    assert abs(fd - float(gR)) <= 1e-6 * abs(float(gR)), (fd, gR)
    dK = np.zeros((3, 3))
    dK[1, 1] = 1e-5 * ctrl.K[1, 1]
    fd = (c(ctrl.lam, ctrl.K + dK) - c(ctrl.lam, ctrl.K - dK)) / (2.0 * dK[1, 1])
    assert abs(fd - float(gW[1, 1])) <= 1e-6 * abs(float(gW[1, 1])), (fd, gW)
    jnp = jax.numpy
    p0 = {k: jnp.asarray(v) for k, v in loop.law.params.items()}
    assert set(p0) == {"gamma_k", "gamma_beta", "sigma"}

    def final(p):
        out = loop.rollout(ctrl.lam, ctrl.K, jnp.asarray(R0[0]), jnp.asarray(w0[0]), params=p)
        return jnp.sum(out["controller/s"][-1] ** 2)

    g = jax.grad(final)(p0)
    assert all(np.isfinite(float(v)) for v in g.values()), g
    # (β̂ reaches its box here, so γ_β's derivative is 0 through the projection)
    assert float(g["gamma_k"]) != 0.0 and float(g["sigma"]) != 0.0, g


def test_fault_tolerant_suite_backend_jax_equals_numba(jax, caplog):
    _suite_equals_numba("fault-tolerant-so3", caplog)


# ------------------------------------------------------------------------------------ bad input


def test_subclasses_with_their_own_command_are_refused_naming_the_controller(jax):
    """None of these laws has an option the array law refuses (every configuration flies);
    a subclass whose command is not its parent's law is refused by the seam, naming it."""
    from liecontrol.control.array_law import array_law_of

    for ctrl in (_ppc(), _sliding(False), _sliding(True), _fault_tolerant(1)):
        law = array_law_of(ctrl)
        assert law.params and all(np.isfinite(v).all() for v in law.params.values())

        class Own(type(ctrl)):
            def command(self, t, state, reference):
                return 2.0 * super().command(t, state, reference)

        own = Own.__new__(Own)
        own.__dict__.update(ctrl.__dict__)
        with pytest.raises(ValueError, match=r"^controller: Own overrides command\(\)"):
            array_law_of(own)
