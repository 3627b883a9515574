"""Environment torques (spacecraft.surface_forces): aerodynamic and solar-pressure torque of a
single plate against hand calculations, the Sun ephemeris against a published example, eclipse
entry/exit at the geometric orbit phase, residual dipole against m × B, scenario-file use and bad
input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.runner import build_disturbance
from benchmarks.scenario_files import ScenarioFileError, scenario_from_dict
from benchmarks.scenarios import DisturbanceSpec
from liecontrol.lie import so3
from spacecraft.geomagnetic import EARTH_ROTATION_RATE, TiltedDipoleField
from spacecraft.orbit import R_EARTH, CircularOrbit
from spacecraft.surface_forces import (
    J2000_JD,
    SOLAR_PRESSURE_1AU,
    AerodynamicTorque,
    ExponentialAtmosphere,
    Plate,
    ResidualDipoleTorque,
    SolarPressureTorque,
    aerodynamic_torque,
    box_plates,
    in_cylindrical_shadow,
    solar_pressure_torque,
    sun_position_au,
)

ORBIT = CircularOrbit(n=0.0011)  # equatorial, about 528 km
RNG_R = so3.exp(np.random.default_rng(7).normal(size=(4, 3)))
ZERO_W = np.zeros((4, 3))


# --- aerodynamic -------------------------------------------------------------------------------


def test_aero_single_plate_hand_calculation():
    # plate A = 2 m², n = +x, centre (0.1, 0.3, −0.2); flow v = (7000, 1000, 0) m/s
    plate = Plate(2.0, [1.0, 0.0, 0.0], [0.1, 0.3, -0.2])
    rho, cd = 3e-12, 2.2
    v = np.array([7000.0, 1000.0, 0.0])
    # F = −½ρ C_D A (n·v) v  (= −½ρC_D‖v‖²A cosθ v̂)
    F = -0.5 * rho * cd * 2.0 * 7000.0 * v
    expect = np.cross([0.1, 0.3, -0.2], F)
    np.testing.assert_allclose(aerodynamic_torque(plate, v, rho, cd), expect, rtol=1e-12)
    # the back of the plate sees no flow
    np.testing.assert_array_equal(aerodynamic_torque(plate, -v, rho, cd), np.zeros(3))
    np.testing.assert_array_equal(aerodynamic_torque(plate, np.zeros(3), rho, cd), np.zeros(3))


def test_aero_source_uses_orbit_velocity_and_table_density():
    plate = Plate(1.5, [0.0, 1.0, 0.0], [0.0, 0.0, 0.4])
    # hand density: the 500 km band of Vallado's table, ρ₀ = 6.967e-13, H = 63.822 km
    h_km = ORBIT.altitude / 1e3
    rho = 6.967e-13 * math.exp(-(h_km - 500.0) / 63.822)
    for corotating in (False, True):
        src = AerodynamicTorque((plate,), ORBIT, drag_coefficient=2.0, corotating=corotating)
        assert src.density == pytest.approx(rho, rel=1e-12)
        t = 321.0
        v = ORBIT.velocity(t)
        if corotating:
            v = v - np.cross([0.0, 0.0, EARTH_ROTATION_RATE], ORBIT.position(t))
        got = src(t, RNG_R, ZERO_W)
        for b in range(len(RNG_R)):
            vb = RNG_R[b].T @ v
            F = -0.5 * rho * 2.0 * 1.5 * max(vb[1], 0.0) * vb
            np.testing.assert_allclose(got[b], np.cross([0.0, 0.0, 0.4], F), rtol=1e-9, atol=1e-22)
    # co-rotation lowers the relative speed on a prograde equatorial orbit by ω_E r
    v_rel = AerodynamicTorque((plate,), ORBIT).relative_velocity(0.0)
    assert np.linalg.norm(v_rel) == pytest.approx(
        ORBIT.radius * (ORBIT.n - EARTH_ROTATION_RATE), rel=1e-12
    )


def test_box_centred_on_com_has_no_torque_and_offset_gives_cross_product():
    plates = box_plates([1.0, 2.0, 3.0])
    v = np.array([3.0, -4.0, 5.0])
    np.testing.assert_allclose(aerodynamic_torque(plates, v, 1e-12), 0.0, atol=1e-25)
    # with the box centre at d: τ = −q Σ_p A_p cosθ_p (d × v̂), Σ A cosθ = projected area
    d = np.array([0.1, -0.2, 0.3])
    vh = v / np.linalg.norm(v)
    proj = 6.0 * abs(vh[0]) + 3.0 * abs(vh[1]) + 2.0 * abs(vh[2])
    q = 0.5 * 1e-12 * 2.2 * (v @ v)
    np.testing.assert_allclose(
        aerodynamic_torque(box_plates([1.0, 2.0, 3.0], d), v, 1e-12),
        -q * proj * np.cross(d, vh),
        rtol=1e-12,
    )


def test_exponential_atmosphere_table_values():
    atm = ExponentialAtmosphere()
    assert atm.density(400e3) == pytest.approx(3.725e-12)
    assert atm.density(1000e3) == pytest.approx(3.019e-15)
    # continuity is not exact between bands (the table is a fit), but within a few per cent
    below, above = atm.density([499.999e3, 500e3])
    assert abs(below / above - 1.0) < 0.05
    assert ExponentialAtmosphere(scale=3.0).density(600e3) == pytest.approx(3 * 1.454e-13)


# --- solar radiation pressure -------------------------------------------------------------------


def test_srp_single_plate_hand_calculation_by_mechanism():
    ca, cs, cdf = 0.3, 0.5, 0.2
    plate = Plate(3.0, [0.0, 0.0, 1.0], [0.5, 0.0, 0.1], absorption=ca, specular=cs, diffuse=cdf)
    th = math.radians(30.0)
    s = np.array([math.sin(th), 0.0, math.cos(th)])
    n = np.array([0.0, 0.0, 1.0])
    P, A, c = 4.5e-6, 3.0, math.cos(th)
    # the three mechanisms separately (Wertz §17.2): absorbed light pushes along −ŝ, specular
    # reflection along −n̂ with twice the normal momentum, diffuse (Lambertian) along −(ŝ + ⅔n̂)
    F = -P * A * c * (ca * s + 2.0 * cs * c * n + cdf * (s + (2.0 / 3.0) * n))
    expect = np.cross([0.5, 0.0, 0.1], F)
    np.testing.assert_allclose(solar_pressure_torque(plate, s, P), expect, rtol=1e-12)
    np.testing.assert_array_equal(solar_pressure_torque(plate, -s, P), np.zeros(3))
    # a black plate at normal incidence: F = −P A ŝ exactly
    black = Plate(2.0, n, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(
        solar_pressure_torque(black, n, P), np.cross([1.0, 0.0, 0.0], -P * 2.0 * n), rtol=1e-14
    )


def test_sun_ephemeris_against_published_example():
    # Vallado, Fundamentals of Astrodynamics, Example 5-1: 2 April 2006 0h UT, JD 2453827.5,
    # r_sun = (0.9771945, 0.1924424, 0.0834308) AU
    np.testing.assert_allclose(
        sun_position_au(2453827.5), [0.9771945, 0.1924424, 0.0834308], atol=2e-5
    )
    # March 2000 equinox (2000-03-20 07:35 UT): the Sun crosses the equator at right ascension 0
    s = sun_position_au(2451623.816)
    s = s / np.linalg.norm(s)
    assert abs(math.degrees(math.asin(s[2]))) < 0.02 and s[0] > 0.9999
    # perihelion early January (≈ 0.983 AU), aphelion early July (≈ 1.017 AU)
    assert np.linalg.norm(sun_position_au(J2000_JD + 2.5)) == pytest.approx(0.9833, abs=2e-4)
    assert np.linalg.norm(sun_position_au(J2000_JD + 184.0)) == pytest.approx(1.0167, abs=2e-4)


def _orbit_through_sun(epoch_jd: float) -> tuple[CircularOrbit, float]:
    """A polar orbit whose plane holds the Sun direction at the epoch, and the Sun's argument of
    latitude in it (its declination)."""
    s = sun_position_au(epoch_jd)
    s = s / np.linalg.norm(s)
    alpha, delta = math.atan2(s[1], s[0]), math.asin(s[2])
    # R_orb = R_z(α) R_x(90°): e1 = (cos α, sin α, 0), e2 = ẑ, so ŝ = cos δ e1 + sin δ e2
    return CircularOrbit(n=0.0011, inclination=math.pi / 2, raan=alpha), delta


def test_eclipse_entry_and_exit_at_the_geometric_phase():
    epoch = J2000_JD + 100.0
    orbit, u_sun = _orbit_through_sun(epoch)
    plates = box_plates([2.0, 2.0, 2.0], [0.0, 0.0, 0.2])
    src = SolarPressureTorque(plates, orbit, epoch_jd=epoch)
    # shadow: within asin(R_e/r) of the anti-Sun point of the orbit
    half = math.asin(R_EARTH / orbit.radius)
    u_anti = u_sun + math.pi
    margin = math.radians(0.3)  # the Sun moves about 0.03° over half an orbit

    def t_at(u: float) -> float:
        return (u - orbit.arg_lat0) / orbit.n

    R = np.eye(3)[None]
    for du, shadow in ((0.0, True), (half - margin, True), (-(half - margin), True)):
        t = t_at(u_anti + du)
        assert src.in_eclipse(t) is shadow
        np.testing.assert_array_equal(src(t, R, np.zeros((1, 3))), np.zeros((1, 3)))
    for du in (half + margin, -(half + margin), math.pi):
        t = t_at(u_anti + du)
        assert src.in_eclipse(t) is False
        assert np.abs(src(t, R, np.zeros((1, 3)))).max() > 1e-8
    # with the eclipse off the torque is on in the shadow too
    off = SolarPressureTorque(plates, orbit, epoch_jd=epoch, eclipse=False)
    assert np.abs(off(t_at(u_anti), R, np.zeros((1, 3)))).max() > 1e-8


def test_orbit_normal_to_the_sun_never_eclipses():
    epoch = 2451623.816  # equinox: Sun along +X
    orbit = CircularOrbit(n=0.0011, inclination=math.pi / 2, raan=math.pi / 2)  # normal ≈ ±X
    t = np.linspace(0.0, orbit.period, 200)
    s = sun_position_au(epoch + t / 86400.0)
    assert not np.any(in_cylindrical_shadow(orbit.position(t), s))


def test_srp_source_matches_plate_formula_with_distance_scaling():
    epoch = J2000_JD + 30.0
    plate = Plate(2.0, [0.0, 1.0, 0.0], [0.3, 0.0, 0.0], absorption=0.6, specular=0.4, diffuse=0.0)
    orbit, u_sun = _orbit_through_sun(epoch)
    src = SolarPressureTorque((plate,), orbit, epoch_jd=epoch)
    t = (u_sun - orbit.arg_lat0) / orbit.n  # over the sub-solar point: lit
    rs = sun_position_au(epoch + t / 86400.0)
    d = np.linalg.norm(rs)
    got = src(t, RNG_R, ZERO_W)
    for b in range(len(RNG_R)):
        sb = RNG_R[b].T @ (rs / d)
        np.testing.assert_allclose(
            got[b], solar_pressure_torque(plate, sb, SOLAR_PRESSURE_1AU / d**2), rtol=1e-12
        )


# --- residual dipole ----------------------------------------------------------------------------


def test_residual_dipole_is_m_cross_b():
    m = np.array([0.5, -1.0, 2.0])
    orbit = CircularOrbit.from_altitude(530e3, inclination=math.radians(97.5), raan=0.4)
    fld = TiltedDipoleField()
    src = ResidualDipoleTorque(m, orbit, fld)
    for t in (0.0, 1234.5, 4000.0):
        B = fld.body(t, RNG_R, orbit.position(t))
        np.testing.assert_allclose(src(t, RNG_R, ZERO_W), np.cross(m, B), rtol=1e-12, atol=1e-20)
        np.testing.assert_allclose(
            src.field_inertial(t), fld.inertial(t, orbit.position(t)), rtol=1e-12, atol=1e-18
        )
    # size: ‖τ‖ ≤ ‖m‖ ‖B‖ and B is tens of µT in low orbit
    tau = src(0.0, RNG_R, ZERO_W)
    assert np.all(np.linalg.norm(tau, axis=1) < np.linalg.norm(m) * 6e-5)


# --- batch, scenario files ----------------------------------------------------------------------


@pytest.mark.parametrize("name", ["aerodynamic", "solar-pressure", "residual-dipole"])
def test_scenario_file_disturbances_build_and_batch(name):
    table = {
        "name": "env",
        "disturbance": [{"name": name, "altitude_km": 450.0, "inclination_deg": 51.6}],
    }
    sc = scenario_from_dict(table)
    src = build_disturbance(sc.disturbances, np.diag([10.0, 12.0, 14.0]))
    assert src.uses_attitude is True
    assert src.orbit.altitude == pytest.approx(450e3)
    assert src.orbit.inclination == pytest.approx(math.radians(51.6))
    t = 2500.0
    batch = src(t, RNG_R, ZERO_W)
    assert batch.shape == (4, 3) and np.all(np.isfinite(batch))
    for b in range(len(RNG_R)):
        np.testing.assert_allclose(src(t, RNG_R[b : b + 1], ZERO_W[:1])[0], batch[b], rtol=1e-14)


def test_scenario_orbit_passed_to_build_disturbance():
    orbit = CircularOrbit.from_altitude(600e3, inclination=1.0)
    src = build_disturbance((DisturbanceSpec("aerodynamic"),), np.eye(3), orbit=orbit)
    assert src.orbit is orbit
    src = build_disturbance(
        (DisturbanceSpec("residual-dipole", {"raan_deg": 30.0}),), np.eye(3), orbit=orbit
    )
    assert src.orbit.altitude == pytest.approx(600e3)
    assert src.orbit.raan == pytest.approx(math.radians(30.0))


# --- bad input ----------------------------------------------------------------------------------


def test_bad_input_is_a_clear_error():
    low = CircularOrbit.from_altitude(90e3)
    with pytest.raises(ValueError, match=r"^orbit: altitude 90 km is below"):
        AerodynamicTorque(box_plates([1.0, 1.0, 1.0]), low)
    with pytest.raises(ValueError, match=r"^altitude: 50 km is below"):
        ExponentialAtmosphere().density(50e3)
    with pytest.raises(ValueError, match=r"^area: must be > 0"):
        Plate(-1.0, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"^normal: must be a non-zero"):
        Plate(1.0, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"^specular: must be in \[0, 1\]"):
        Plate(1.0, [1.0, 0.0, 0.0], absorption=0.0, specular=1.2)
    with pytest.raises(ValueError, match=r"^absorption: absorption \+ specular \+ diffuse"):
        Plate(1.0, [1.0, 0.0, 0.0], absorption=0.5, specular=0.3, diffuse=0.1)
    with pytest.raises(ValueError, match=r"^size: every edge must be > 0"):
        box_plates([1.0, -2.0, 1.0])
    with pytest.raises(ValueError, match=r"^dipole: expected shape"):
        ResidualDipoleTorque([1.0, 2.0], ORBIT)
    with pytest.raises(ValueError, match=r"^plates: at least one"):
        SolarPressureTorque((), ORBIT)
    with pytest.raises(ValueError, match=r"^orbit: expected CircularOrbit"):
        SolarPressureTorque(box_plates([1.0, 1.0, 1.0]), 7e6)
    with pytest.raises(ValueError, match=r"^drag_coefficient: "):
        AerodynamicTorque(box_plates([1.0, 1.0, 1.0]), ORBIT, drag_coefficient=0.0)
    with pytest.raises(ValueError, match=r"^sun_direction: must be non-zero"):
        solar_pressure_torque(box_plates([1.0, 1.0, 1.0]), np.zeros(3))
    # scenario files: the error names the key
    for params, key in (
        ({"altitude_km": 80.0}, "altitude_km"),
        ({"size_y": -1.0}, "size_y"),
        ({"specular": 1.5}, "specular"),
    ):
        spec = DisturbanceSpec("aerodynamic" if key != "specular" else "solar-pressure", params)
        with pytest.raises(ValueError, match=rf"^{key}: "):
            build_disturbance((spec,), np.eye(3))
    with pytest.raises(ScenarioFileError, match="no parameter 'area'"):
        scenario_from_dict({"name": "x", "disturbance": [{"name": "aerodynamic", "area": 1.0}]})


def test_inputs_not_mutated():
    n = np.array([0.0, 3.0, 4.0])
    c = np.array([0.1, 0.2, 0.3])
    p = Plate(1.0, n, c)
    np.testing.assert_array_equal(n, [0.0, 3.0, 4.0])
    np.testing.assert_allclose(p.normal, [0.0, 0.6, 0.8])
    c[0] = 9.0
    assert p.centre[0] == 0.1


def test_closed_loop_run_from_a_scenario_table():
    from benchmarks.runner import run_suite

    sc = scenario_from_dict(
        {
            "name": "env-torques",
            "duration": 20.0,
            "dt": 0.5,
            "control_period": 0.5,
            "initial": {"angle_deg": 5.0, "axis": [0.0, 0.0, 1.0]},
            "orbit": {"altitude_km": 500.0, "inclination_deg": 97.5},
            "disturbance": [
                {"name": "aerodynamic", "altitude_km": 300.0, "offset_z": 0.5},
                {"name": "solar-pressure", "specular": 0.3},
                {"name": "residual-dipole", "x": 5.0},
            ],
        }
    )
    res = run_suite([sc], ["geometric-pd-large-angle"], executor="serial", progress=False)
    (run,) = res.outcomes
    assert run.status == "ok", run.error
    m = run.metrics
    # 20 s is short of settling; the loop is closed and the error is shrinking
    assert np.isfinite(m["final_error_deg"]) and m["final_error_deg"] < m["initial_error_deg"]


def test_scenario_orbit_reaches_the_environment_torques():
    from benchmarks.runner import build_plant

    sc = scenario_from_dict(
        {
            "name": "env-orbit",
            "orbit": {"altitude_km": 420.0, "inclination_deg": 51.6, "raan_deg": 10.0},
            "disturbance": [{"name": "aerodynamic"}],
        }
    )
    plant = build_plant(sc.spacecraft, sc.disturbances, orbit=sc.orbit.circular_orbit())
    o = plant.disturbance.orbit
    assert o.altitude == pytest.approx(420e3)
    assert (o.inclination, o.raan) == pytest.approx((math.radians(51.6), math.radians(10.0)))
