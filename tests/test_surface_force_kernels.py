"""The compiled torques of the surface and magnetic sources (spacecraft.surface_forces):

- each kernel (aerodynamic, solar pressure with and without eclipse, residual dipole) equals the
  source's numpy ``__call__`` to 1e-12 of the torque's scale over random attitudes and times,
  both sides of the shadow and both atmosphere models;
- a low-orbit environment (the three torques and the gravity gradient in a SumOfDisturbances)
  runs in the fused loop and equals the numpy Python loop to 1e-12 — ideal actuator and SGCMG,
  one spacecraft and a batch.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import simulate_fused, simulate_python_loop

from liecontrol._jit import JIT_ENABLED
from liecontrol.control import GeometricPD
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft import IdealTorqueActuator, RigidBody, SgcmgActuator, SgcmgPyramid, Spacecraft
from spacecraft.disturbances import SumOfDisturbances
from spacecraft.environment import GravityGradientTorque
from spacecraft.geomagnetic import TiltedDipoleField
from spacecraft.orbit import CircularOrbit
from spacecraft.surface_forces import (
    AerodynamicTorque,
    Plate,
    ResidualDipoleTorque,
    SolarPressureTorque,
    box_plates,
)

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the kernels need numba")

J = np.array([[150.0, 3.0, -1.0], [3.0, 65.0, 2.0], [-1.0, 2.0, 111.0]])
ORBIT = CircularOrbit(n=0.0011, inclination=0.9, raan=0.4, arg_lat0=0.3)
BOX = box_plates((1.2, 0.8, 2.0), (0.05, -0.1, 0.2), absorption=0.6, specular=0.3, diffuse=0.1)
PLATES = (*BOX, Plate(3.0, (0.0, 0.6, 0.8), (0.1, 1.5, -0.3), 0.5, 0.4, 0.1))  # a tilted panel


def _sources():
    return {
        "aero-corotating": AerodynamicTorque(PLATES, ORBIT),
        "aero-inertial": AerodynamicTorque(PLATES, ORBIT, drag_coefficient=2.4, corotating=False),
        "srp": SolarPressureTorque(PLATES, ORBIT, epoch_jd=2460000.5),
        "srp-no-eclipse": SolarPressureTorque(PLATES, ORBIT, epoch_jd=2460000.5, eclipse=False),
        "dipole": ResidualDipoleTorque([0.3, -1.0, 2.0], ORBIT),
        "dipole-frozen": ResidualDipoleTorque(
            [1.0, 0.2, 0.0], ORBIT, TiltedDipoleField(earth_rate=0.0, greenwich0=0.7)
        ),
    }


@pytest.mark.parametrize("name", sorted(_sources()))
def test_each_kernel_is_the_numpy_torque(name):
    src = _sources()[name]
    spec = src.fused_kernel()
    assert spec.uses_attitude
    rng = np.random.default_rng(3)
    R = so3.random(rng, (16,))
    w = rng.normal(size=(16, 3))
    times = np.linspace(0.0, 2.0 * math.pi / ORBIT.n, 41)  # one orbit: lit and shadowed
    out = np.empty(3)
    zero = lit = 0
    for t in times:
        want = src(float(t), R, w)
        scale = max(np.abs(want).max(), 1e-300)
        for b in range(16):
            spec.torque(float(t), np.ascontiguousarray(R[b]), w[b], spec.params, out)
            np.testing.assert_allclose(out, want[b], rtol=0, atol=1e-12 * scale)
        if np.all(want == 0.0):
            zero += 1
        else:
            lit += 1
    assert lit > 0
    if name == "srp":
        assert zero > 0  # the shadow was crossed, and the kernel switched off with the numpy one
    if name == "srp-no-eclipse":
        assert zero == 0


def _environment():
    return SumOfDisturbances(
        {
            "gg": GravityGradientTorque(J, ORBIT),
            "aero": AerodynamicTorque(PLATES, ORBIT),
            "srp": SolarPressureTorque(PLATES, ORBIT),
            "dipole": ResidualDipoleTorque([0.3, -1.0, 2.0], ORBIT),
        }
    )


ACTUATORS = {
    "ideal": lambda: IdealTorqueActuator(max_torque=2.0),
    "sgcmg": lambda: SgcmgActuator(SgcmgPyramid(h0=10.0)),
}


@pytest.mark.parametrize("actuator", sorted(ACTUATORS))
@pytest.mark.parametrize("B", [1, 3])
def test_a_low_orbit_environment_runs_fused_and_equals_the_python_loop(actuator, B, monkeypatch):
    rng = np.random.default_rng(5)
    Jb = np.stack([J * (1.0 + 0.1 * i) for i in range(B)]) if B > 1 else J
    plant = Spacecraft(RigidBody(Jb), ACTUATORS[actuator](), disturbance=_environment())
    assert plant._kernel_plan is not None
    ref = ConstantAttitude(so3.random(rng, (B,)) if B > 1 else so3.random(rng))
    x0 = plant.initial_state(np.eye(3), 0.02 * rng.normal(size=(B, 3)))
    ctrl = GeometricPD(J, 10.0, 60.0)
    twin = Spacecraft(plant.body, plant.actuator, disturbance=plant.disturbance)
    object.__setattr__(twin, "_kernel_plan", None)  # the numpy sources at every stage
    # the run crosses the shadow's boundary (the solar torque switches off within it)
    srp = SolarPressureTorque(PLATES, ORBIT)
    shade = [srp.in_eclipse(float(t)) for t in range(0, 6000)]
    t_switch = next(t for t in range(1, 6000) if shade[t] != shade[t - 1])
    kw = dict(control_period=0.1, log_every=5, t0=t_switch - 10.0)
    t1 = t_switch + 20.0
    fast = simulate_fused(monkeypatch, plant, ctrl, ref, x0, t1, 0.05, **kw)
    slow = simulate_python_loop(monkeypatch, twin, ctrl, ref, x0, t1, 0.05, **kw)
    for name in ("t", "R", "omega", "u_cmd", "disturbance"):
        x, y = getattr(fast, name), getattr(slow, name)
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()))
    assert np.abs(fast.disturbance).max() > 0.0
