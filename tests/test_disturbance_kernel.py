"""The disturbance kernel seam (spacecraft.disturbance_kernel) and the fused loop that calls it.

- the gravity-gradient torque and a user's @njit torque that reads the attitude and the rate run
  in the fused loop and equal the numpy Python loop (stage attitudes R exp(θ_s)) to 1e-12, with
  the ideal actuator and the SGCMG, one spacecraft and a batch with per-spacecraft inertias;
- the kernel equals the numpy gravity-gradient layer to 1e-12;
- a malformed kernel (signature, typing error, parameters, non-finite torque) raises before the
  loop, naming the disturbance and the argument;
- a subclass overriding ``__call__`` keeps the Python loop and ``simulate`` says so once;
- a ``SumOfDisturbances`` of sources with kernels (gravity gradient, the built-in time-only
  sources, a per-spacecraft constant torque, a user's torque, a nested sum) runs in the fused loop
  and equals the Python loop's sum bit for bit where the parts' kernels are the numpy formulas'
  operations, to 1e-12 otherwise; a sum with a source without kernel keeps the Python loop and
  the log line names that source; parts with different batch rows raise naming both;
- the full CMG model (VscmgActuator) takes the seam torque (the gravity gradient, a sum with a
  user's torque and per-spacecraft rows): its fused loop and the Python loop through its
  compiled step equal the numpy Python loop to 1e-12, the per-source log included.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import pytest
from conftest import simulate_fused, simulate_python_loop

from liecontrol._jit import JIT_ENABLED
from liecontrol.control import GeometricPD
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import IdealTorqueActuator, RigidBody, SgcmgActuator, SgcmgPyramid, Spacecraft
from spacecraft import _fused as fused_module
from spacecraft.disturbance_kernel import DisturbanceKernel
from spacecraft.disturbances import (
    ConstantHarmonicTorque,
    ConstantTorque,
    SumOfDisturbances,
    ZeroDisturbance,
)
from spacecraft.environment import GravityGradientTorque
from spacecraft.orbit import CircularOrbit
from spacecraft.simulator import simulate

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the fused loop needs numba")

J = np.array([[150.0, 3.0, -1.0], [3.0, 65.0, 2.0], [-1.0, 2.0, 111.0]])
ORBIT = CircularOrbit(n=0.0011, inclination=0.6, raan=0.3, arg_lat0=0.2)


def _numpy_plant(plant: Spacecraft) -> Spacecraft:
    """The same plant on the numpy route (no compiled step: the disturbance's ``__call__`` at
    the stage attitudes of liecontrol.integrators.rk)."""
    twin = Spacecraft(plant.body, plant.actuator, disturbance=plant.disturbance)
    object.__setattr__(twin, "_kernel_plan", None)
    return twin


_python_loop = simulate_python_loop
_fused = simulate_fused


def _assert_same(a, b):
    for name in ("t", "R", "omega", "u_cmd", "disturbance"):
        x, y = getattr(a, name), getattr(b, name)
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()))


# ------------------------------------------------------------------ a user's torque
if JIT_ENABLED:
    from numba import njit

    @njit
    def user_torque(t, R, omega, params, out):
        """A body-fixed magnetic-like torque k (Rᵀ e_z) × e_x − c ω (reads R and ω)."""
        k, c = params[0], params[1]
        b0, b1, b2 = R[2, 0], R[2, 1], R[2, 2]
        out[0] = -c * omega[0]
        out[1] = k * b2 - c * omega[1]
        out[2] = -k * b1 - c * omega[2] + 0.0 * b0

    @njit
    def bad_signature(t, R, omega, out):
        out[0] = 0.0

    @njit
    def typing_error(t, R, omega, params, out):
        out[0] = R + "x"

    @njit
    def nan_torque(t, R, omega, params, out):
        out[0] = np.nan
        out[1] = 0.0
        out[2] = 0.0


@dataclass(frozen=True)
class UserTorque:
    """The numpy twin of :func:`user_torque`, with the kernel through the public seam."""

    k: float = 2e-3
    c: float = 0.05
    torque: object = None
    params: object = None

    def __call__(self, t, R, omega):
        b = R[:, 2, :]
        out = -self.c * omega
        out[:, 1] += self.k * b[:, 2]
        out[:, 2] -= self.k * b[:, 1]
        return out

    def fused_kernel(self):
        params = np.array([self.k, self.c]) if self.params is None else self.params
        fn = user_torque if self.torque is None else self.torque
        return DisturbanceKernel(fn, params, uses_attitude=True)


def _setup(B, actuator, disturbance, per_spacecraft=False, seed=4):
    rng = np.random.default_rng(seed)
    Jb = np.stack([J * (1.0 + 0.1 * i) for i in range(B)]) if per_spacecraft else J
    plant = Spacecraft(RigidBody(Jb), actuator, disturbance=disturbance)
    ref = ConstantAttitude(so3.random(rng, (B,)) if B > 1 else so3.random(rng))
    x0 = plant.initial_state(np.eye(3), 0.02 * rng.normal(size=(B, 3)))
    return plant, GeometricPD(J, 10.0, 60.0), ref, x0


ACTUATORS = {
    "ideal": lambda: IdealTorqueActuator(max_torque=2.0),
    "sgcmg": lambda: SgcmgActuator(SgcmgPyramid(h0=10.0)),
}
SOURCES = {
    "gravity_gradient": lambda: GravityGradientTorque(J, ORBIT),
    "user": lambda: UserTorque(),
}


@pytest.mark.parametrize("source", sorted(SOURCES))
@pytest.mark.parametrize("actuator", sorted(ACTUATORS))
@pytest.mark.parametrize("B", [1, 3])
def test_fused_equals_the_numpy_python_loop(source, actuator, B, monkeypatch):
    plant, ctrl, ref, x0 = _setup(B, ACTUATORS[actuator](), SOURCES[source](), B > 1)
    assert plant._kernel_plan is not None
    kw = dict(control_period=0.1, log_every=5)
    fast = _fused(monkeypatch, plant, ctrl, ref, x0, 20.0, 0.05, **kw)
    slow = _python_loop(monkeypatch, _numpy_plant(plant), ctrl, ref, x0, 20.0, 0.05, **kw)
    _assert_same(fast, slow)
    # the Python loop's compiled step (the plant's kernel plan) is the same arithmetic
    step = _python_loop(monkeypatch, plant, ctrl, ref, x0, 20.0, 0.05, **kw)
    _assert_same(step, slow)
    assert np.abs(fast.disturbance).max() > 0.0


def test_the_kernel_is_the_numpy_gravity_gradient():
    gg = GravityGradientTorque(J, ORBIT)
    spec = gg.fused_kernel()
    rng = np.random.default_rng(0)
    R = so3.random(rng, (8,))
    w = rng.normal(size=(8, 3))
    for t in (0.0, 123.4, 5e3):
        ref = gg(t, R, w)
        out = np.empty(3)
        for b in range(8):
            spec.torque(t, np.ascontiguousarray(R[b]), w[b], spec.params, out)
            np.testing.assert_allclose(out, ref[b], rtol=1e-12, atol=1e-12 * np.abs(ref).max())


def _bad(**kw):
    return UserTorque(**kw)


@pytest.mark.parametrize(
    ("dist", "words"),
    [
        (_bad(torque=bad_signature if JIT_ENABLED else None), "does not compile"),
        (_bad(torque=typing_error if JIT_ENABLED else None), "does not compile"),
        (_bad(params=np.array([1, 2])), "dtype float64"),
        (_bad(params=np.zeros((2, 2, 2))), "shape"),
        (_bad(params=[1.0, 2.0]), "numpy float64 array"),
        (_bad(params=np.array([np.inf, 0.0])), "finite"),
    ],
)
def test_a_malformed_kernel_raises_naming_the_disturbance_and_the_argument(dist, words):
    with pytest.raises(ValueError, match=r"disturbance UserTorque: kernel (torque|params)") as e:
        Spacecraft(RigidBody(J), IdealTorqueActuator(), disturbance=dist)
    assert words in str(e.value)


def test_per_spacecraft_params_of_the_wrong_batch_raise(monkeypatch):
    plant, ctrl, ref, x0 = _setup(3, ACTUATORS["ideal"](), _bad(params=np.zeros((2, 2))))
    with pytest.raises(ValueError, match=r"disturbance UserTorque: kernel params .*\(3, n_p\)"):
        simulate(plant, ctrl, ref, x0, 1.0, 0.05)


def test_a_non_finite_torque_on_the_initial_state_raises_before_the_loop():
    plant, ctrl, ref, x0 = _setup(1, ACTUATORS["ideal"](), _bad(torque=nan_torque))
    with pytest.raises(ValueError, match=r"disturbance UserTorque: kernel torque nan_torque .*out"):
        simulate(plant, ctrl, ref, x0, 1.0, 0.05)


def test_a_non_finite_source_of_a_sum_is_named_by_its_key():
    dist = SumOfDisturbances(
        {
            "gg": GravityGradientTorque(J, ORBIT),
            "inner": SumOfDisturbances({"ok": UserTorque(), "bad": _bad(torque=nan_torque)}),
        }  # fmt: skip
    )
    plant, ctrl, ref, x0 = _setup(1, ACTUATORS["ideal"](), dist)
    with pytest.raises(
        ValueError,
        match=r"disturbance SumOfDisturbances, source 'inner': disturbance SumOfDisturbances, "
        r"source 'bad': disturbance UserTorque: kernel torque nan_torque .*out",
    ):
        simulate(plant, ctrl, ref, x0, 1.0, 0.05)


def test_a_fused_kernel_attribute_that_is_not_a_method_is_named(caplog):
    class NoKernel(UserTorque):
        fused_kernel = None

    plant, ctrl, ref, x0 = _setup(1, ACTUATORS["ideal"](), NoKernel())
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, ctrl, ref, x0, 0.5, 0.05)
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert (
        len(lines) == 1 and "NoKernel has no compiled kernel (its fused_kernel is None" in lines[0]
    )


class _Override(GravityGradientTorque):
    def __call__(self, t, R, omega):
        return 2.0 * super().__call__(t, R, omega)


class _Keeps(GravityGradientTorque):
    pass


def test_an_override_of_call_keeps_the_python_loop_and_says_so(caplog):
    plant, ctrl, ref, x0 = _setup(1, ACTUATORS["ideal"](), _Override(J, ORBIT))
    assert plant._kernel_plan is None
    assert _Keeps(J, ORBIT).fused_kernel() is not None
    keeps, *_ = _setup(1, ACTUATORS["ideal"](), _Keeps(J, ORBIT))
    assert keeps._kernel_plan is not None
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, ctrl, ref, x0, 0.5, 0.05)
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1
    assert "_Override overrides __call__()" in lines[0]
    assert "GravityGradientTorque.fused_kernel()" in lines[0]


def test_a_source_without_a_kernel_is_named_once(caplog):
    @dataclass(frozen=True)
    class PlainTorque:
        def __call__(self, t, R, omega):
            return np.zeros(omega.shape)

    plant, ctrl, ref, x0 = _setup(1, ACTUATORS["ideal"](), PlainTorque())
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, ctrl, ref, x0, 0.5, 0.05)
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1 and "the disturbance PlainTorque has no compiled kernel" in lines[0]


def test_hold_steps_takes_the_seam_torque():
    plant, _, _, x0 = _setup(2, ACTUATORS["ideal"](), SOURCES["user"]())
    twin = _numpy_plant(plant)
    u = np.array([[0.1, 0.0, -0.1], [0.0, 0.2, 0.0]])
    R, x, _ = fused_module.hold_steps(plant._kernel_plan, 4, 0.0, 0.05, x0.R, x0.packed(), u)
    Rn, xn = x0.R, x0.packed()
    for k in range(4):
        held = twin.actuator.command(u, xn[:, :3], xn[:, 3:], 0.05 * k)
        Rn, xn = twin.step_packed(0.05 * k, Rn, xn, held, 0.05)
    np.testing.assert_allclose(R, Rn, rtol=0, atol=1e-13)
    np.testing.assert_allclose(x, xn, rtol=0, atol=1e-13)


# ------------------------------------------------------------------ sums of sources
def _sum(B):
    rng = np.random.default_rng(9)
    bias = ConstantTorque(0.01 * rng.normal(size=(B, 3)) if B > 1 else [0.0, 0.01, -0.02])
    inner = SumOfDisturbances({"harmonic": ConstantHarmonicTorque(scale=0.5), "bias": bias})
    return SumOfDisturbances(
        {"gg": GravityGradientTorque(J, ORBIT), "user": UserTorque(), "inner": inner,
         "zero": ZeroDisturbance()}
    )  # fmt: skip


@pytest.mark.parametrize("actuator", sorted(ACTUATORS))
@pytest.mark.parametrize("B", [1, 3])
def test_a_sum_of_sources_with_kernels_runs_fused_and_equals_the_python_sum(
    actuator, B, monkeypatch
):
    plant, ctrl, ref, x0 = _setup(B, ACTUATORS[actuator](), _sum(B), B > 1)
    assert plant._kernel_plan is not None and plant._kernel_plan.dist_attitude
    kw = dict(control_period=0.1, log_every=5)
    fast = _fused(monkeypatch, plant, ctrl, ref, x0, 20.0, 0.05, **kw)
    slow = _python_loop(monkeypatch, _numpy_plant(plant), ctrl, ref, x0, 20.0, 0.05, **kw)
    _assert_same(fast, slow)
    assert np.abs(fast.disturbance).max() > 0.0
    # the per-source log (SimulationResult.disturbance_components) by the sources' own kernels
    assert list(fast.disturbance_components) == ["gg", "user", "inner", "zero"]
    for name, want in slow.disturbance_components.items():
        got = fast.disturbance_components[name]
        assert got.shape == want.shape
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_the_sum_kernel_adds_in_the_python_order_bit_for_bit():
    """Time-only parts (the kernels are the numpy formulas' operations): the compiled sum is the
    Python sum to the last bit, per spacecraft row."""
    B = 4
    rng = np.random.default_rng(2)
    dist = SumOfDisturbances(
        [ConstantHarmonicTorque(n=0.002, scale=1.7), ConstantTorque(rng.normal(size=(B, 3))),
         ConstantHarmonicTorque(), ConstantTorque([1e-3, 0.0, 3.0])]
    )  # fmt: skip
    spec = dist.fused_kernel()
    assert spec is not None and spec.params.shape == (B, 2 + 3 + 2 + 3)
    assert not spec.uses_attitude
    R = np.broadcast_to(np.eye(3), (B, 3, 3))
    w = np.zeros((B, 3))
    for t in (0.0, 17.25, 3.3e4):
        want = dist(t, R, w)
        out = np.empty(3)
        for b in range(B):
            spec.torque(t, np.eye(3), w[b], spec.params[b], out)
            assert np.array_equal(out, want[b])


def test_a_per_spacecraft_constant_torque_runs_fused(monkeypatch):
    rng = np.random.default_rng(1)
    plant, ctrl, ref, x0 = _setup(3, ACTUATORS["ideal"](), ConstantTorque(rng.normal(size=(3, 3))))
    assert plant._kernel_plan is not None
    fast = _fused(monkeypatch, plant, ctrl, ref, x0, 5.0, 0.05)
    slow = _python_loop(monkeypatch, _numpy_plant(plant), ctrl, ref, x0, 5.0, 0.05)
    _assert_same(fast, slow)


def test_a_sum_with_a_source_without_kernel_names_it_once(caplog):
    @dataclass(frozen=True)
    class PlainTorque:
        def __call__(self, t, R, omega):
            return np.zeros(omega.shape)

    dist = SumOfDisturbances({"gg": GravityGradientTorque(J, ORBIT), "plain": PlainTorque()})
    assert dist.fused_kernel() is None
    plant, ctrl, ref, x0 = _setup(1, ACTUATORS["ideal"](), dist)
    assert plant._kernel_plan is None
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        res = simulate(plant, ctrl, ref, x0, 0.5, 0.05)
    assert np.all(np.isfinite(res.omega))
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1
    assert "SumOfDisturbances source 'plain'" in lines[0]
    assert "PlainTorque has no compiled kernel" in lines[0]


def test_sum_parts_with_different_batch_rows_raise_naming_them():
    dist = SumOfDisturbances(
        {"a": ConstantTorque(np.zeros((2, 3))), "b": ConstantTorque(np.zeros((3, 3)))}
    )
    with pytest.raises(
        ValueError, match=r"SumOfDisturbances: .*different batch rows.*'a': 2.*'b': 3"
    ):
        dist.fused_kernel()


# ------------------------------------------------------------------ the rotating payload
def _payloads():
    import dataclasses

    from spacecraft.payload import ROTATING_PAYLOAD_EXAMPLE as P

    second = dataclasses.replace(
        P, mass=7.0, hinge=np.array([-0.4, 0.1, 0.3]), spin_rate=-3.1, phase=0.4
    )
    return (P, second)


def _ramped():
    """The two payloads of :func:`_payloads`, the second on a speed ramp (1.5 → −2 rad/s from
    t = 3 s over 4 s): before, during and after the ramp within a 10 s run."""
    import dataclasses

    from spacecraft.payload import SpinRamp

    first, second = _payloads()
    return (first, dataclasses.replace(second, spin_rate=SpinRamp(1.5, -2.0, 3.0, 4.0)))


@pytest.mark.parametrize("payloads", [_payloads, _ramped], ids=["constant", "ramp"])
def test_the_rotating_payload_kernel_is_the_numpy_torque(payloads):
    """Bit for bit (the kernel evaluates the NumPy formula's operations in its order), at times
    before, inside and after a ramp and on its two ends."""
    from spacecraft.payload import RotatingPayloadTorque

    src = RotatingPayloadTorque(payloads())
    spec = src.fused_kernel()
    assert spec is not None and not spec.uses_attitude
    rng = np.random.default_rng(8)
    w = 0.05 * rng.normal(size=(6, 3))
    R = np.broadcast_to(np.eye(3), (6, 3, 3))
    out = np.empty(3)
    times = (0.0, 0.37, 2.9999999, 3.0, 3.0000001, 5.2, 6.9999999, 7.0, 7.0000001, 12.5, 4.4e3)
    for t in times:
        want = src(t, R, w)
        for b in range(6):
            spec.torque(t, np.eye(3), w[b], spec.params, out)
            np.testing.assert_array_equal(out, want[b])
    if payloads is _ramped:  # the speed-change term acts only inside the ramp (ω̇_p ≠ 0)
        ramp = src.payloads[1]
        assert np.abs(ramp.torque_terms(5.0, np.zeros(3))["speed_change"]).max() > 0.0
        assert np.abs(ramp.torque_terms(8.0, np.zeros(3))["speed_change"]).max() == 0.0


def test_the_rotating_payload_runs_fused_and_a_user_profile_says_why_not(monkeypatch, caplog):
    import dataclasses

    from spacecraft.payload import ConstantSpin, RotatingPayloadTorque

    kw = dict(control_period=0.1, log_every=5)
    for payloads in (_payloads(), _ramped()):
        src = RotatingPayloadTorque(payloads)
        plant, ctrl, ref, x0 = _setup(2, ACTUATORS["sgcmg"](), src)
        assert plant._kernel_plan is not None
        fast = _fused(monkeypatch, plant, ctrl, ref, x0, 10.0, 0.05, **kw)
        slow = _python_loop(monkeypatch, _numpy_plant(plant), ctrl, ref, x0, 10.0, 0.05, **kw)
        _assert_same(fast, slow)

    class Wobble(ConstantSpin):  # a user's profile (a subclass may change the formula)
        def state(self, t):
            a, r, acc = super().state(t)
            return a + 0.01 * np.sin(t), r + 0.01 * np.cos(t), acc - 0.01 * np.sin(t)

    odd = dataclasses.replace(_payloads()[0], spin_rate=Wobble(2.0))
    src = RotatingPayloadTorque((_payloads()[1], odd))
    assert src.fused_kernel() is None
    plant, ctrl, ref, x0 = _setup(1, ACTUATORS["ideal"](), src)
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        res = simulate(plant, ctrl, ref, x0, 0.5, 0.05)
    lines = [r.getMessage() for r in caplog.records if r.name == "spacecraft.simulator"]
    assert len(lines) == 1 and "payload 1's spin profile Wobble" in lines[0]
    # the user's profile is what the Python loop flies (not the parent's constant rate)
    want = src.payloads[0].torque(0.25, np.zeros(3)) + odd.torque(0.25, np.zeros(3))
    np.testing.assert_allclose(src(0.25, None, np.zeros((1, 3)))[0], want, rtol=0, atol=1e-14)
    assert np.all(np.isfinite(res.omega))


# ------------------------------------------------------------- the full CMG model (VSCMG)
JB = np.diag([900.0, 800.0, 600.0])


def _vscmg_setup(B, disturbance, seed=6):
    """A plant flying the full CMG model (body inertia = the actuator's bus inertia, as the
    compiled step requires), a PD law, a reference and an initial state."""
    from spacecraft.cmg_dynamics import CmgInertias, GimbalServo, VscmgActuator
    from spacecraft.steering import SingularityRobust

    act = VscmgActuator(
        JB, CmgInertias(0.5, 0.25, (0.1, 0.1, 0.1)), SgcmgPyramid(h0=20.0), SingularityRobust(),
        servo=GimbalServo(5.0, 50.0),
    )  # fmt: skip
    plant = Spacecraft(RigidBody(JB), act, disturbance=disturbance)
    rng = np.random.default_rng(seed)
    ref = ConstantAttitude(so3.random(rng, (B,)) if B > 1 else so3.random(rng))
    x0 = plant.initial_state(so3.exp(0.3 * rng.normal(size=(B, 3))), 0.01 * rng.normal(size=(B, 3)))
    return plant, GeometricPD(JB, 20.0, 200.0), ref, x0


def _numpy_vscmg(plant: Spacecraft) -> Spacecraft:
    """The same plant with neither compiled step: the numpy derivatives at every stage."""
    twin = _numpy_plant(plant)
    object.__setattr__(twin, "_coupled_plan", None)
    return twin


def _vscmg_sum(B):
    rng = np.random.default_rng(3)
    parts = {
        "gg": GravityGradientTorque(JB, ORBIT),
        "harmonic": ConstantHarmonicTorque(scale=0.5),
        "user": UserTorque(k=0.05),
    }
    if B > 1:  # per-spacecraft parameter rows of the sum
        parts["bias"] = ConstantTorque(0.01 * rng.normal(size=(B, 3)))
    return SumOfDisturbances(parts)


def _assert_same_vscmg(a, b):
    _assert_same(a, b)
    for name in ("delta", "delta_dot", "wheel_speed", "gimbal_torque"):
        x, y = a.actuator[name], b.actuator[name]
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()))


VSCMG_SOURCES = {
    "gravity_gradient": lambda B: GravityGradientTorque(JB, ORBIT),
    "sum": _vscmg_sum,
}


@pytest.mark.parametrize("source", sorted(VSCMG_SOURCES))
@pytest.mark.parametrize("B", [1, 2])
def test_the_full_cmg_model_takes_the_seam_torque_fused_and_in_the_python_loop(
    source, B, monkeypatch
):
    plant, ctrl, ref, x0 = _vscmg_setup(B, VSCMG_SOURCES[source](B))
    assert plant._kernel_plan is None and plant._coupled_plan is not None
    vp = fused_module.vscmg_plan(plant)
    assert vp is not None and vp.dist == fused_module.K.DIST_KERNEL and vp.dist_attitude
    kw = dict(control_period=0.1, log_every=2)
    fast = _fused(monkeypatch, plant, ctrl, ref, x0, 4.0, 0.05, **kw)
    slow = _python_loop(monkeypatch, _numpy_vscmg(plant), ctrl, ref, x0, 4.0, 0.05, **kw)
    _assert_same_vscmg(fast, slow)
    assert np.abs(fast.disturbance).max() > 0.0
    # the Python loop through the plant's compiled step (the fused loop's step kernel)
    step = _python_loop(monkeypatch, plant, ctrl, ref, x0, 4.0, 0.05, **kw)
    _assert_same_vscmg(step, slow)
    if source == "sum":
        # the per-source log by the sources' own kernels
        assert list(fast.disturbance_components) == list(slow.disturbance_components)
        for name, want in slow.disturbance_components.items():
            got = fast.disturbance_components[name]
            assert got.shape == want.shape
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_the_full_cmg_model_raises_on_a_malformed_kernel():
    with pytest.raises(ValueError, match=r"disturbance UserTorque: kernel params"):
        _vscmg_setup(1, _bad(params=np.array([1, 2])))
