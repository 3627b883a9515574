"""Magnetic momentum dumping that works or says why not (issue 25): the feasibility check warns
before the run where the rods cannot hold the secular disturbance, and the growth metric flags it
after the run."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
from spacecraft import ConstantHarmonicTorque, RigidBody, SgcmgActuator, Spacecraft, simulate
from spacecraft.momentum import (
    CrossProductDumping,
    DumpingInfeasibleWarning,
    Magnetorquers,
    check_dumping_feasibility,
    magnetic_dumping_feasibility,
    momentum_fraction,
    momentum_growth_per_orbit,
)
from spacecraft.orbit import CircularOrbit, EarthPointingReference

# the documented example (docs/plant.md): 530 km, 3000 A·m² rods, k = 1e-3, the sgcmg-bus
J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])


def _example(inclination_deg: float, max_dipole: float = 3000.0):
    orbit = CircularOrbit.from_altitude(530e3, inclination=np.deg2rad(inclination_deg))
    ref = EarthPointingReference(orbit)
    dumping = CrossProductDumping(
        orbit, magnetorquers=Magnetorquers(max_dipole), gain=1e-3, attitude=ref
    )
    return orbit, ref, dumping


@pytest.mark.parametrize("inc", [0.0, 10.0, 28.5])
def test_low_inclination_dumping_warned_before_the_run(inc):
    """At 0°–28.5° the field lies too close to the orbit normal: building the plant warns (the
    runs saturate the CMGs / lose the attitude), naming momentum_management."""
    orbit, _, dumping = _example(inc)
    with pytest.warns(DumpingInfeasibleWarning, match="^momentum_management"):
        Spacecraft(
            RigidBody(J), SgcmgActuator(), ConstantHarmonicTorque(n=orbit.n),
            momentum_management=dumping,
        )  # fmt: skip
    rep = magnetic_dumping_feasibility(dumping, ConstantHarmonicTorque(n=orbit.n), dumping.attitude)
    assert not rep.feasible and rep.authority_ratio < 1.0 and rep.deficit_torque > 0.0


@pytest.mark.parametrize("inc", [51.6, 97.5])
def test_feasible_inclinations_do_not_warn(inc):
    orbit, _, dumping = _example(inc)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Spacecraft(
            RigidBody(J), SgcmgActuator(), ConstantHarmonicTorque(n=orbit.n),
            momentum_management=dumping,
        )  # fmt: skip
    rep = magnetic_dumping_feasibility(dumping, ConstantHarmonicTorque(n=orbit.n), dumping.attitude)
    assert rep.feasible and rep.authority_ratio > 1.2
    assert 0.0 < rep.cyclic_momentum < 100.0  # the CMGs (h₀ = 300 N·m·s) hold the cyclic part


def test_rods_too_weak_warned():
    """200 A·m² rods at 97.5°: too weak for the 0.08 N·m secular torque — warned."""
    orbit, ref, dumping = _example(97.5, max_dipole=200.0)
    with pytest.warns(DumpingInfeasibleWarning):
        rep = check_dumping_feasibility(dumping, ConstantHarmonicTorque(n=orbit.n), ref)
    assert rep.authority_ratio < 0.2


def test_no_disturbance_is_feasible():
    orbit, ref, dumping = _example(0.0)
    rep = magnetic_dumping_feasibility(dumping, np.zeros(3), ref)
    assert rep.feasible and rep.deficit_torque == 0.0


def _run(inc: float, orbits: float = 1.2):
    orbit, ref, dumping = _example(inc)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DumpingInfeasibleWarning)
        plant = Spacecraft(
            RigidBody(J), SgcmgActuator(), ConstantHarmonicTorque(n=orbit.n),
            momentum_management=dumping,
        )  # fmt: skip
    k_R, k_W = gains_from_bandwidth(J, 0.03, 0.9, error="large_angle", matrix=True)
    r0 = ref(0.0)
    t_final = 10.0 * np.ceil(orbits * orbit.period / 10.0)
    res = simulate(
        plant, GeometricPD(J, k_R, k_W), ref, plant.initial_state(r0.R_d, r0.omega_d), t_final, 10.0
    )
    frac = momentum_fraction(plant.actuator, res.actuator["delta"][:, 0])
    return orbit, res.t, frac


def test_growth_metric_flags_failed_dumping_after_the_run():
    """After one orbit: the envelope fraction grows secularly at 0° (dumping cannot keep up) and
    not at 97.5°."""
    orbit, t, frac = _run(0.0)
    bad = float(momentum_growth_per_orbit(t, frac, orbit.period))
    orbit, t, frac = _run(97.5)
    good = float(momentum_growth_per_orbit(t, frac, orbit.period))
    assert bad > 0.1 and bad > 5.0 * good


def test_feasibility_bad_input():
    orbit, ref, dumping = _example(97.5)
    with pytest.raises(ValueError, match="^n_orbits"):
        magnetic_dumping_feasibility(dumping, np.zeros(3), ref, n_orbits=0.0)
    with pytest.raises(ValueError, match="^attitude"):
        magnetic_dumping_feasibility(dumping, np.zeros(3), None)
    with pytest.raises(ValueError, match="^dumping"):
        magnetic_dumping_feasibility(object(), np.zeros(3), ref)
    with pytest.raises(ValueError, match="^disturbance"):
        magnetic_dumping_feasibility(dumping, np.zeros(2), ref)
    with pytest.raises(ValueError, match="^period"):
        momentum_growth_per_orbit([0.0, 10.0], [0.1, 0.2], orbit.period)
    with pytest.raises(ValueError, match="^t"):
        momentum_growth_per_orbit([10.0, 0.0], [0.1, 0.2], orbit.period)
