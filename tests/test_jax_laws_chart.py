"""The chart-based controllers on the JAX route (liecontrol.control.adapters' array laws): the
adapters' pure chart conversion with its memory (MRP shadow set, quaternion sign and hysteresis)
carried by the scan, composed with the chart laws' pure steps; the same trajectories, torques,
diagnostics and switches as the fused numba loop, finite gradients through the switches, and
clear refusals. JAX is an optional extra: these tests skip without it."""

from __future__ import annotations

import numpy as np
import pytest

from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import RigidBody, Spacecraft, simulate
from spacecraft.actuators import IdealTorqueActuator

J = np.diag([10.0, 20.0, 30.0])
J[0, 1] = J[1, 0] = 0.5
AXIS = np.array([0.0, 0.6, 0.8])
REF = ConstantAttitude(so3.exp(np.array([0.2, -0.1, 0.3])))


@pytest.fixture
def jax():
    jax = pytest.importorskip("jax")
    with jax.enable_x64(True):
        yield jax


def _registry(name: str, q_hint=None):
    from benchmarks.controllers import ControllerContext, make_controller
    from benchmarks.scenarios import SpacecraftSpec

    spec = SpacecraftSpec(name="t", inertia=tuple(map(tuple, J)), actuator="ideal")
    return make_controller(name, ControllerContext(spacecraft=spec, control_period=0.2,
                                                   q_hint=q_hint))  # fmt: skip


def _plant() -> Spacecraft:
    return Spacecraft(RigidBody(J), IdealTorqueActuator())


def _starts() -> tuple[np.ndarray, np.ndarray]:
    """179.9° from the reference turning on through 180° (a shadow switch, a sign flip), 120°
    and 5° with small random rates, and a start at the reference."""
    rng = np.random.default_rng(1)
    ax = np.vstack([AXIS, rng.normal(size=(2, 3)), [1.0, 0.0, 0.0]])
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    R0 = REF.R_d @ so3.exp(ax * np.radians([179.9, 120.0, 5.0, 0.0])[:, None])
    w0 = np.vstack([AXIS * 0.08, rng.normal(size=(2, 3)) * 0.01, np.zeros(3)])
    return R0, w0


def _assert_same_run(run, want, keys) -> None:
    np.testing.assert_allclose(run.R, want.R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.omega, want.omega, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.u_cmd, want.u_cmd, rtol=0, atol=1e-11)
    assert set(keys) <= set(run.controller)
    for k in keys:
        a, b = np.asarray(run.controller[k]), np.asarray(want.controller[k])
        assert a.shape == b.shape, k
        if b.dtype == bool:
            np.testing.assert_array_equal(a, b, err_msg=k)
        else:
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-11, err_msg=k)


@pytest.mark.parametrize(
    "name",
    ["mrp-pd", "quaternion-pd-continuous", "quaternion-pd-switched", "quaternion-pd-hysteretic"],
)
def test_registry_chart_pds_equal_fused_simulate_through_the_switches(name, jax):
    """The registered chart PDs on the JAX route equal the fused loop (their compiled kernels),
    switches included: the 179.9° start turns through 180°, where the MRP switches to its shadow
    set, the switched quaternion's sign flips, and the hysteretic one flips once w < −δ."""
    from spacecraft.differentiable import closed_loop

    R0, w0 = _starts()
    ctrl = _registry(name)
    plant = _plant()
    want = simulate(plant, ctrl, REF, plant.initial_state(R0, w0), 60.0, 0.1,
                    control_period=0.2, log_every=2)  # fmt: skip
    loop = closed_loop(plant, _registry(name), REF, 60.0, 0.1, 0.2)
    run = loop.run(R0, w0)
    keys = ["chart_y", "chart_y_d", "chart_switched"] + (["q_w"] if "quaternion" in name else [])
    _assert_same_run(run, want, keys)
    switched = want.controller["chart_switched"]
    if name == "quaternion-pd-continuous":
        assert not switched.any()  # the continuous sign never flips: w < 0 past 180°
        assert (want.controller["q_w"][:, 0] < -1e-3).any()
    else:
        assert switched[:, 0].any() and not switched[:, 1:].any(), name
    if name == "quaternion-pd-hysteretic":
        # the flip waits until w < −δ: the quaternion ran on past 180° first
        k = int(np.argmax(switched[:, 0]))
        q_w = want.controller["q_w"][:, 0]
        assert q_w[k - 1] < -0.1 and q_w[k] > ctrl.hysteresis
    # the gradient through the carried sign/shadow memory is finite
    v, gR, gW = loop.value_and_grad(loop.k_R, loop.k_Omega, R0, w0, effort_weight=0.01)
    assert np.isfinite(v) and np.isfinite(gR).all() and np.isfinite(gW).all()


def test_mrp_pd_gain_gradient_matches_central_differences(jax):
    from liecontrol.control import MrpPD
    from spacecraft.differentiable import closed_loop

    R0, w0 = _starts()
    loop = closed_loop(_plant(), MrpPD(J, 2.0, 8.0), REF, 20.0, 0.1, 0.2)
    v, gK, gP = loop.value_and_grad(2.0, 8.0, R0[1:], w0[1:], effort_weight=0.01)
    h = 1e-5

    def cost(K, P):
        with jax.enable_x64(True):
            return float(loop.cost(K, P, R0[1:], w0[1:], effort_weight=0.01))

    np.testing.assert_allclose(gK, (cost(2.0 + h, 8.0) - cost(2.0 - h, 8.0)) / (2 * h), rtol=1e-5)
    np.testing.assert_allclose(gP, (cost(2.0, 8.0 + h) - cost(2.0, 8.0 - h)) / (2 * h), rtol=1e-5)


@pytest.mark.parametrize("which", ["mrp", "quaternion"])
def test_adapters_numpy_route_equals_array_route_with_the_inertial_base(which, jax):
    """The generic adapters (no compiled kernel: the adapter's NumPy route) with the inertial
    frame as base, tracking a slewing reference: the desired chart point moves (its continuity
    memory, its rates and accelerations), and both routes run the one pure conversion."""
    from liecontrol.control.adapters import MrpChartAdapter, QuaternionChartAdapter, RotatingFrame
    from liecontrol.control.chart_baselines import MrpPDLaw, QuaternionPDLaw
    from spacecraft.differentiable import closed_loop

    if which == "mrp":
        ctrl = MrpChartAdapter(MrpPDLaw(J, 2.0, 8.0, feedforward="reference"), base="inertial")
    else:
        ctrl = QuaternionChartAdapter(QuaternionPDLaw(J, 2.0, 8.0), base="inertial",
                                      sign_mode="hysteretic")  # fmt: skip
    # the desired frame turns past 180° from the base: its MRP switches, its quaternion goes on
    ref = RotatingFrame(np.eye(3), np.array([0.0, 0.12, 0.16]))
    R0, w0 = _starts()
    plant = _plant()
    want = simulate(plant, ctrl, ref, plant.initial_state(R0, w0), 30.0, 0.1,
                    control_period=0.2, log_every=2)  # fmt: skip
    run = closed_loop(plant, ctrl, ref, 30.0, 0.1, 0.2).run(R0, w0)
    _assert_same_run(run, want, ["chart_y", "chart_y_d", "chart_switched"])
    assert np.abs(want.controller["chart_y_d"]).max() > 0.5


class _ScaledMrpLaw:
    """A user's own chart law: u = −k σ − c ω_rel on the MRP, NumPy and array forms."""

    batched = True

    def __init__(self, k: float, c: float) -> None:
        self.k, self.c = k, c

    def reset(self, t0, batch_size):
        pass

    def __call__(self, t, s):
        return -self.k * s.y - self.c * s.omega_rel

    def array_law(self):
        from liecontrol.control.adapters import ChartArrayLaw

        def step(k, c, state, s, T):
            (n,) = state
            return -k * s.y - c * s.omega_rel, (n + s.switched,), {"switches": n + s.switched}

        return ChartArrayLaw(self.k, self.c, (np.array(0.0),), step)


def test_a_users_chart_law_flies_with_its_state(jax):
    """A user's chart law in an MrpChartAdapter flies: its own state (here a switch counter)
    rides in the scan after the adapter's memory."""
    from liecontrol.control.adapters import MrpChartAdapter
    from spacecraft.differentiable import closed_loop

    R0, w0 = _starts()
    plant = _plant()
    want = simulate(
        plant,
        MrpChartAdapter(_ScaledMrpLaw(2.0, 8.0)),
        REF,
        plant.initial_state(R0, w0),
        20.0,
        0.1,
        control_period=0.2,
        log_every=2,
    )
    run = closed_loop(plant, MrpChartAdapter(_ScaledMrpLaw(2.0, 8.0)), REF, 20.0, 0.1, 0.2).run(
        R0, w0)  # fmt: skip
    _assert_same_run(run, want, ["chart_y", "chart_switched"])
    counts = run.controller["switches"]
    np.testing.assert_array_equal(counts[-1], want.controller["chart_switched"].sum(axis=0))
    assert counts[-1, 0] >= 1


def test_chart_array_laws_refuse_what_they_cannot_fly(jax):
    from liecontrol.control import QuaternionPD
    from liecontrol.control.adapters import MrpChartAdapter, RotatingFrame
    from liecontrol.control.chart_baselines import MrpPDLaw
    from spacecraft.differentiable import closed_loop

    plant = _plant()

    class NoArray:
        def reset(self, t0, batch_size):
            pass

        def __call__(self, t, s):
            return -s.y

    with pytest.raises(ValueError, match=r"^controller\.law: NoArray has no array_law"):
        closed_loop(plant, MrpChartAdapter(NoArray()), REF, 10.0, 0.1)

    class Doubled(MrpPDLaw):  # its own __call__, its parent's array_law
        def __call__(self, t, s):
            return 2.0 * super().__call__(t, s)

    with pytest.raises(ValueError, match=r"^controller\.law: Doubled overrides __call__"):
        closed_loop(plant, MrpChartAdapter(Doubled(J, 1.0, 1.0)), REF, 10.0, 0.1)
    frame = RotatingFrame(np.eye(3), np.array([0.0, 0.0, 0.01]))
    with pytest.raises(ValueError, match=r"^controller\.base: "):
        closed_loop(plant, MrpChartAdapter(MrpPDLaw(J, 1.0, 1.0), base=frame), REF, 10.0, 0.1)
    hints = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
    loop = closed_loop(plant, QuaternionPD(J, 1.0, 1.0, q_hint=hints), REF, 10.0, 0.1)
    with pytest.raises(ValueError, match=r"^member_state0: .* for 2 spacecraft, the batch has 3"):
        loop.run(_starts()[0][:3])
    # one hint repeated for the batch is one hint
    same = QuaternionPD(J, 1.0, 1.0, q_hint=np.tile([0.0, 1.0, 0.0, 0.0], (3, 1)))
    assert closed_loop(plant, same, REF, 10.0, 0.1).law.state0[0].tolist() == [0, 1, 0, 0]

    class Q(QuaternionPD):  # a subclass with its own command does not fly its parent's law
        def command(self, t, state, reference):
            return 2.0 * super().command(t, state, reference)

    with pytest.raises(ValueError, match=r"^controller: Q overrides command\(\)"):
        closed_loop(plant, Q(J, 1.0, 1.0), REF, 10.0, 0.1)


def test_registry_mrp_adrc_equals_fused_simulate_through_the_shadow_switch(jax):
    """mrp-adrc: the observer, the differentiator and the held B τ carried by the scan, mapped
    to the shadow set at the switch, the hold discretisation computed in the step by the NumPy
    route's own series — the fused loop's (compiled kernel's) run, every diagnostic."""
    from spacecraft.differentiable import closed_loop

    R0, w0 = _starts()
    plant = _plant()
    want = simulate(plant, _registry("mrp-adrc"), REF, plant.initial_state(R0, w0), 60.0, 0.1,
                    control_period=0.2, log_every=2)  # fmt: skip
    loop = closed_loop(plant, _registry("mrp-adrc"), REF, 60.0, 0.1, 0.2)
    run = loop.run(R0, w0)
    keys = ["z1", "z2", "z3", "v1", "v2", "tau0", "eso_error", "chart_y", "chart_switched"]
    _assert_same_run(run, want, keys)
    assert want.controller["chart_switched"][:, 0].sum() == 1
    v, g1, g2 = loop.value_and_grad(loop.k_R, loop.k_Omega, R0, w0, effort_weight=0.01)
    assert np.isfinite(v) and np.isfinite(g1).all() and np.isfinite(g2).all()


def test_mrp_adrc_observer_gains_are_differentiable_params(jax):
    """The ESO gains and the TD rate are the array law's params: the closed loop's cost is
    differentiable in them (here the observer bandwidth scale c: K₁c, K₂c², K₃c³ — the poles
    at c·ω_o), through the discretisation's traced series and squarings; the derivative matches
    central differences, and at c = 1 the run is the nominal one."""
    import dataclasses

    from liecontrol.control.array_law import ArrayLaw
    from spacecraft.differentiable import closed_loop

    jnp = jax.numpy
    R0, w0 = _starts()
    loop = closed_loop(_plant(), _registry("mrp-adrc"), REF, 20.0, 0.1, 0.2)
    law = loop.law
    assert set(law.params) == {"K1", "K2", "K3", "r"}
    P = law.params

    def cost(c):
        params = {"K1": P["K1"] * c, "K2": P["K2"] * c**2, "K3": P["K3"] * c**3, "r": P["r"]}
        tuned = ArrayLaw(law.k_R, law.k_Omega, law.state0,
                         lambda *a: law.step(*a, params=params), params={})  # fmt: skip
        lp = dataclasses.replace(loop, law=tuned)
        J, J_inv = lp.inertias(2)
        terms = jax.vmap(lp.cost_terms, in_axes=(None, None, 0, 0, 0, 0))(
            lp.k_R, lp.k_Omega, jnp.asarray(R0[1:3]), jnp.asarray(w0[1:3]), J, J_inv
        )
        return jnp.mean(terms["angle"] + 0.01 * terms["effort"])

    f = jax.jit(jax.value_and_grad(cost))
    v1, g1 = f(1.0)
    with jax.enable_x64(True):
        nominal = loop.cost(loop.k_R, loop.k_Omega, R0[1:3], w0[1:3], effort_weight=0.01)
    np.testing.assert_allclose(float(v1), float(nominal), rtol=1e-13)
    h = 1e-4
    fd = (float(f(1.0 + h)[0]) - float(f(1.0 - h)[0])) / (2 * h)
    assert np.isfinite(float(g1)) and float(g1) != 0.0
    np.testing.assert_allclose(float(g1), fd, rtol=1e-5)


def test_hold_discretisation_series_equals_scipy_expm_and_runs_traced(jax):
    """The pure scaling-and-squaring series of the ADRC's hold discretisation equals scipy's
    expm (Padé) to round-off, and under JAX with traced gains (traced number of squarings) it
    gives the NumPy route's matrices."""
    from scipy.linalg import expm

    from liecontrol.control import adrc

    for P, h in ((adrc.PAPER, 0.1), (adrc.PAPER, 2.0), (adrc.ADRCParams(K1=0.4, K2=0.07, K3=0.003,
                                                                        r=0.15), 0.2)):  # fmt: skip
        F, K = adrc._eso_blocks(P.K1, P.K2, P.K3, P.alpha, P.beta)
        M = adrc._hold_augmented(F, K, adrc._E2) * h
        s = adrc._hold_squarings(F, K, adrc._E2, h)
        E = adrc._expm(M, s)
        ref = expm(M)
        assert np.abs(E - ref).max() <= 1e-12 * np.abs(ref).max()
        want = adrc._discrete_matrices(F, K, *adrc._td_blocks(P.r), h)

        def traced(k3, P=P, h=h, s=s):
            F, K = adrc._eso_blocks(P.K1, P.K2, k3, P.alpha, P.beta)
            return adrc._discrete_matrices(F, K, *adrc._td_blocks(jax.numpy.asarray(P.r)), h,
                                           (s + 6, 12))  # fmt: skip

        got = jax.jit(traced)(jax.numpy.asarray(P.K3))
        for a, b in zip(got, want, strict=True):
            # XLA's products round differently, and up to 14 squarings amplify it
            np.testing.assert_allclose(np.asarray(a), b, rtol=0, atol=1e-12 * np.abs(b).max())


class _EulerPD:
    """A user's Euler-angle law, u = −k (y − y_d) − c (ẏ − ẏ_d) mapped through Mᵀ (the rates
    matrix's transpose: a torque from an angle-space force), NumPy and array forms."""

    batched = True

    def __init__(self, k: float, c: float) -> None:
        self.k, self.c = k, c

    def reset(self, t0, batch_size):
        pass

    @staticmethod
    def _u(k, c, s):
        f = -k * (s.y - s.y_d) - c * (s.y_dot - s.y_d_dot)
        B = s.chart.rates_matrix(s.y)  # ẏ = B ω: the force's torque is Bᵀ f
        return (np.swapaxes(B, -1, -2) @ f[..., None])[..., 0]

    def __call__(self, t, s):
        return self._u(self.k, self.c, s)

    def array_law(self):
        from liecontrol.control.adapters import ChartArrayLaw

        return ChartArrayLaw(self.k, self.c, (), lambda k, c, st, s, T: (self._u(k, c, s), st, {}))


@pytest.mark.parametrize("base", ["reference", "inertial"])
def test_euler_adapter_flies_and_flags_gimbal_lock(base, jax):
    """The Euler adapter's pure conversion (angles, unwrap memory, rates): a user's Euler law
    flies with the NumPy route's values; where the NumPy route raises ChartSingularityError at
    gimbal lock, the array law reports ``chart_lock`` and the member is flagged diverged."""
    from liecontrol.control.adapters import EulerChartAdapter
    from liecontrol.exceptions import ChartSingularityError
    from spacecraft.differentiable import closed_loop

    rng = np.random.default_rng(3)
    ax = rng.normal(size=(3, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    R0 = REF.R_d @ so3.exp(ax * np.radians([40.0, 20.0, 5.0])[:, None])
    w0 = rng.normal(size=(3, 3)) * 0.01
    plant = _plant()
    ref = REF if base == "reference" else ConstantAttitude(so3.exp(np.array([0.0, 0.0, 3.0])))

    def ctrl():
        return EulerChartAdapter(_EulerPD(20.0, 60.0), seq="ZYX", base=base)

    want = simulate(plant, ctrl(), ref, plant.initial_state(R0, w0), 30.0, 0.1,
                    control_period=0.2, log_every=2)  # fmt: skip
    run = closed_loop(plant, ctrl(), ref, 30.0, 0.1, 0.2).run(R0, w0)
    _assert_same_run(run, want, ["chart_y", "chart_y_d"])
    assert not run.controller["chart_lock"].any() and not run.diverged.any()
    # a start at gimbal lock (a2 = 90° about the body's y axis, relative to the base)
    base_R = REF.R_d if base == "reference" else np.eye(3)
    R_lock = base_R @ so3.exp(np.array([0.0, np.pi / 2, 0.0]))[None]
    with pytest.raises(ChartSingularityError, match="^R: gimbal lock"):
        simulate(plant, ctrl(), ref, plant.initial_state(R_lock, np.zeros((1, 3))), 1.0, 0.1)
    run = closed_loop(plant, ctrl(), ref, 1.0, 0.1).run(np.concatenate([R_lock, R0[:1]]))
    assert run.controller["chart_lock"][0].tolist() == [True, False]
    assert np.isnan(run.u_cmd[0, 0]).all() and np.isfinite(run.u_cmd[0, 1]).all()
    # the NaN torque's first step makes the state non-finite at the next logged time
    assert run.diverged.tolist() == [True, False] and run.diverged_at[0] == 0.1


@pytest.mark.parametrize("mode", ["continuous", "hysteretic"])
def test_per_spacecraft_sign_hints_fly_as_per_member_initial_memory(mode, jax):
    """A dispersed batch's quaternion PD with one sign hint per spacecraft (the suite's
    members; a −q hint for the unwinding start): each member starts from its own hint, as in
    the fused loop; the gradient through the per-member memory is finite."""
    from liecontrol.charts import quaternion
    from liecontrol.control import QuaternionPD
    from spacecraft.differentiable import closed_loop

    R0, w0 = _starts()
    q0 = quaternion.from_matrix(REF.R_d.T @ R0)
    hints = q0 * np.array([-1.0, 1.0, 1.0, 1.0])[:, None]  # the first member unwinds
    kR, kW = 0.1 * J, 0.6 * J
    ctrl = QuaternionPD(J, kR, kW, sign_mode=mode, q_hint=hints)
    plant = _plant()
    want = simulate(plant, ctrl, REF, plant.initial_state(R0, w0), 30.0, 0.1,
                    control_period=0.2, log_every=2)  # fmt: skip
    loop = closed_loop(plant, ctrl, REF, 30.0, 0.1, 0.2)
    assert loop.law.member_state0 is not None
    y0 = want.controller["chart_y"][0]
    assert y0[0, 0] < 0.0 and (y0[1:, 0] >= 0.0).all()  # each member's own sign at the start
    _assert_same_run(loop.run(R0, w0), want, ["chart_y", "chart_switched"])
    v, gR, gW = loop.value_and_grad(kR, kW, R0, w0, effort_weight=0.01)
    assert np.isfinite(v) and np.isfinite(gR).all() and np.isfinite(gW).all()
