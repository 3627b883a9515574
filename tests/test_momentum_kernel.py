"""Magnetic momentum dumping (``CrossProductDumping``) in the compiled loop.

The kernels (``spacecraft._kernels_momentum``) equal the NumPy methods bit for bit; a run with
dumping in the compiled loop equals the Python loop to 1e-12 — states, commands, disturbance,
the dipole and magnetic-torque log, the cluster's log — with ideal torques and the SGCMG
cluster, with and without a disturbance, saturated dipoles included; what the loop does not
compile keeps the Python loop and says why. The full CMG model (``VscmgActuator``) too: the
dipole from its momentum relative to the bus.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest
from conftest import simulate_fused, simulate_python_loop

from liecontrol._jit import JIT_ENABLED
from liecontrol.control import GeometricPD
from liecontrol.lie import so3
from spacecraft import (
    ConstantHarmonicTorque,
    IdealTorqueActuator,
    ReactionWheelAssembly,
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    Spacecraft,
    simulate,
)
from spacecraft import _kernels_momentum as KM
from spacecraft.environment import GravityGradientTorque
from spacecraft.momentum import CrossProductDumping, Magnetorquers
from spacecraft.orbit import CircularOrbit, EarthPointingReference

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the fused loop needs numba")

J = np.diag([1500.0, 1200.0, 1000.0])
ORBIT = CircularOrbit.from_altitude(530e3, inclination=np.deg2rad(97.5), raan=0.4)


def _dumping(max_dipole=3000.0, gain=2e-3, h_target=None):
    return CrossProductDumping(
        ORBIT, magnetorquers=Magnetorquers(max_dipole), gain=gain, h_target=h_target
    )


def test_kernels_equal_the_numpy_methods_bit_for_bit():
    rng = np.random.default_rng(1)
    mm = _dumping([50.0, 80.0, 60.0], gain=5e-3, h_target=[1.0, -2.0, 0.5])
    row = mm.fused_kernel().params.copy()
    saturated = 0
    for _ in range(300):
        t, R = rng.uniform(0.0, 2e4), so3.random(rng)
        h = rng.normal(0.0, 1.0, 3) * 10 ** rng.uniform(-2.5, 1.0)
        m_ref = mm.dipole(t, R[None], h[None])[0]
        m = np.array(KM.dipole(t, R, h[0], h[1], h[2], row))
        np.testing.assert_array_equal(m, m_ref)
        saturated += bool(np.isclose(np.abs(m / mm.magnetorquers.max_dipole).max(), 1.0))
        row[KM.P_DIPOLE :] = m_ref
        out = np.zeros(3)
        KM.magnetic_torque(t, R, np.zeros(3), row, out)
        np.testing.assert_array_equal(out, mm.torque(t, R[None], m_ref[None])[0])
    assert 50 < saturated < 300  # both branches of the saturation


def _run_both(monkeypatch, plant, B=2, t_final=600.0, dt=1.0, **kw):
    rng = np.random.default_rng(4)
    ref = EarthPointingReference(ORBIT)
    r0 = ref(0.0)
    x_act0 = None
    if isinstance(plant.actuator, SgcmgActuator):
        x_act0 = np.array([0.3, -0.6, 0.8, -0.2]) + rng.normal(0.0, 0.1, (B, 4))
    x0 = plant.initial_state(
        r0.R_d @ so3.exp(rng.normal(0.0, 0.02, (B, 3))),
        r0.omega_d + rng.normal(0.0, 1e-4, (B, 3)),
        x_act0=x_act0,
    )
    ctrl = GeometricPD(J, 40.0, 800.0)
    fast = simulate_fused(monkeypatch, plant, ctrl, ref, x0, t_final, dt, **kw)
    slow = simulate_python_loop(monkeypatch, plant, ctrl, ref, x0, t_final, dt, **kw)
    for name in ("t", "R", "omega", "R_d", "omega_d", "u_cmd", "u", "disturbance"):
        y = getattr(slow, name)
        np.testing.assert_allclose(
            getattr(fast, name), y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()),
            err_msg=name,
        )  # fmt: skip
    assert list(fast.actuator) == list(slow.actuator)
    for k, y in slow.actuator.items():
        x = fast.actuator[k]
        assert x.dtype == y.dtype and x.shape == y.shape, k
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()),
                                   err_msg=k)  # fmt: skip
    return slow


@pytest.mark.parametrize(
    "make",
    [
        # SGCMG cluster under the orbit-rate torque, the benchmark's dumping configuration
        lambda: Spacecraft(
            RigidBody(J),
            SgcmgActuator(SgcmgPyramid(h0=50.0)),
            ConstantHarmonicTorque(n=ORBIT.n),
            momentum_management=_dumping(),
        ),
        # small rods: the dipole saturates most of the time; gravity gradient reads R
        lambda: Spacecraft(
            RigidBody(J),
            SgcmgActuator(SgcmgPyramid(h0=50.0)),
            GravityGradientTorque(J, ORBIT),
            momentum_management=_dumping(20.0, gain=1e-2, h_target=[0.0, 5.0, 0.0]),
        ),
        # ideal torques, no disturbance (magnetic torque alone: h = 0, h_target drives it)
        lambda: Spacecraft(
            RigidBody(J),
            IdealTorqueActuator(max_torque=0.5),
            momentum_management=_dumping(h_target=[2.0, 0.0, -1.0]),
        ),
    ],
)
def test_dumping_in_the_compiled_loop_equals_the_python_loop(make, monkeypatch):
    slow = _run_both(monkeypatch, make(), control_period=2.0, log_every=3)
    m = slow.actuator["dipole"]
    assert np.abs(m).max() > 1.0 and np.abs(slow.actuator["magnetic_torque"]).max() > 0.0


def test_batch_of_one_per_spacecraft_inertia_and_workers(monkeypatch):
    Js = np.stack([J, 1.1 * J])
    plant = Spacecraft(
        RigidBody(Js), SgcmgActuator(SgcmgPyramid(h0=50.0)), ConstantHarmonicTorque(n=ORBIT.n),
        momentum_management=_dumping(),
    )  # fmt: skip
    _run_both(monkeypatch, plant, B=2, t_final=300.0, workers=2)
    one = Spacecraft(
        RigidBody(J), SgcmgActuator(SgcmgPyramid(h0=50.0)), momentum_management=_dumping()
    )
    _run_both(monkeypatch, one, B=1, t_final=300.0)


@pytest.mark.parametrize("friction", [False, True])
def test_dumping_with_reaction_wheels_equals_the_python_loop(friction, monkeypatch):
    """Four wheels in a pyramid: the dipole from the wheels' momentum A I_w Ω, the wheels'
    log keys then the management's."""
    kw = {"coulomb_friction": 2e-3, "viscous_friction": 1e-5} if friction else {}
    wheels = ReactionWheelAssembly.pyramid(
        wheel_inertia=0.1,
        max_torque=0.3,
        max_speed=600.0,
        initial_speeds=[50.0, -80.0, 20.0, 0.0],
        **kw,
    )
    plant = Spacecraft(
        RigidBody(J), wheels, ConstantHarmonicTorque(n=ORBIT.n),
        momentum_management=_dumping(h_target=[0.0, 0.0, 5.0]),
    )  # fmt: skip
    slow = _run_both(monkeypatch, plant, B=2, t_final=400.0, log_every=2)
    keys = list(slow.actuator)
    assert keys.index("dipole") == keys.index("saturated") + (2 if friction else 1)
    assert np.abs(slow.actuator["dipole"]).max() > 1.0


def _full_cmg_plant(disturbance, management, variable_speed=False):
    from spacecraft.cmg_dynamics import CmgInertias, VscmgActuator
    from spacecraft.steering import SingularityRobust

    act = VscmgActuator(J, CmgInertias(0.5, 0.25, (0.1, 0.1, 0.1)), SgcmgPyramid(h0=50.0),
                        SingularityRobust(), variable_speed=variable_speed)  # fmt: skip
    return Spacecraft(RigidBody(J), act, disturbance, momentum_management=management)


@pytest.mark.parametrize(
    "case",
    [
        # the benchmark's dumping configuration on the full CMG model (kinematic servo)
        dict(disturbance=ConstantHarmonicTorque(n=ORBIT.n), management=_dumping()),
        # gravity gradient (reads R), small rods: the dipole saturates
        dict(disturbance=GravityGradientTorque(J, ORBIT),
             management=_dumping(20.0, gain=1e-2, h_target=[0.0, 5.0, 0.0])),
        # no disturbance, the variable-speed rotors
        dict(disturbance=None, management=_dumping(h_target=[2.0, 0.0, -1.0]),
             variable_speed=True),
    ],
)  # fmt: skip
def test_dumping_with_the_full_cmg_model_equals_the_python_loop(case, monkeypatch):
    """The full CMG model: the dipole from the cluster's momentum relative to the bus
    Σ (J_g δ̇ g + I_Ws Ω s) (``VscmgActuator.momentum``), the actuator's log keys then the
    management's; one run with two workers."""
    plant = _full_cmg_plant(**case)
    # the gimbal servo's time scale wants a step of 0.1 s (at 1 s the Python loop diverges too)
    slow = _run_both(monkeypatch, plant, B=2, t_final=60.0, dt=0.1, control_period=0.2, log_every=3)
    keys = list(slow.actuator)
    assert keys.index("dipole") == keys.index("stop_limited") + 1
    assert np.abs(slow.actuator["dipole"]).max() > 1.0
    assert np.abs(slow.actuator["magnetic_torque"]).max() > 0.0
    _run_both(monkeypatch, plant, B=2, t_final=20.0, dt=0.1, workers=2)


def test_full_cmg_momentum_kernel_equals_the_numpy_layer():
    from spacecraft._kernels_vscmg import vscmg_momentum_one

    rng = np.random.default_rng(7)
    act = _full_cmg_plant(None, None).actuator
    par, M = act._kargs[3], act._kargs[4]
    for _ in range(200):
        xa = act.initial_state(1)[0]
        xa[0:4] = rng.uniform(-7.0, 7.0, 4)
        xa[4:8] = rng.normal(0.0, 0.5, 4)
        xa[8:12] *= rng.uniform(0.5, 1.5, 4)
        ref = act.momentum(xa[None])[0]
        np.testing.assert_allclose(
            np.array(vscmg_momentum_one(par, M, xa)), ref, rtol=0, atol=1e-13 * np.abs(ref).max()
        )


def test_what_the_loop_does_not_compile_keeps_the_python_loop_and_says_why(caplog):
    from spacecraft.cmg_dynamics import CmgInertias, VscmgActuator
    from spacecraft.steering import SingularityRobust
    from spacecraft.thrusters import ThrusterLayout, ThrusterUnloading

    class OwnLaw(CrossProductDumping):
        def dipole(self, t, R, h):
            return 0.5 * super().dipole(t, R, h)

    ref = EarthPointingReference(ORBIT)
    r0 = ref(0.0)
    full = VscmgActuator(J, CmgInertias(0.5, 0.25, (0.1, 0.1, 0.1)), SgcmgPyramid(h0=20.0),
                         SingularityRobust())  # fmt: skip

    class ClipRods(Magnetorquers):  # per-rod clipping: another saturation
        def _saturate(self, m):
            return np.clip(m, -self.max_dipole, self.max_dipole)

    clipped = CrossProductDumping(ORBIT, magnetorquers=ClipRods(30.0))
    cases = [
        (Spacecraft(RigidBody(J), IdealTorqueActuator(), momentum_management=OwnLaw(ORBIT)),
         "momentum management OwnLaw has no compiled kernel"),
        (Spacecraft(RigidBody(J), IdealTorqueActuator(), momentum_management=clipped),
         "momentum management CrossProductDumping has no compiled kernel"),
        (Spacecraft(RigidBody(J), SgcmgActuator(SgcmgPyramid(h0=50.0)), momentum_management=
                    ThrusterUnloading(ThrusterLayout.pairs(1.0))),
         "momentum management ThrusterUnloading has no compiled kernel"),
        (Spacecraft(RigidBody(J), full, momentum_management=
                    ThrusterUnloading(ThrusterLayout.pairs(1.0))),
         "momentum management ThrusterUnloading has no compiled kernel"),
    ]  # fmt: skip
    for plant, words in cases:
        caplog.clear()
        x0 = plant.initial_state(r0.R_d, r0.omega_d)
        with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
            simulate(plant, GeometricPD(J, 40.0, 800.0), ref, x0, 3.0, 1.0)
        assert words in caplog.text, caplog.text
