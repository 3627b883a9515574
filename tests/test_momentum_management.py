"""Momentum management: inclined orbit, tilted-dipole field, magnetorquers with cross-product
dumping, momentum-envelope fractions, and the plant seam that runs the dumping law."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spacecraft.actuators import ReactionWheelAssembly, SgcmgActuator
from spacecraft.disturbances import ConstantHarmonicTorque
from spacecraft.geomagnetic import (
    DIPOLE_STRENGTH_2020,
    DIPOLE_TILT_2020,
    EARTH_ROTATION_RATE,
    IGRF_REFERENCE_RADIUS,
    TiltedDipoleField,
)
from spacecraft.momentum import (
    CrossProductDumping,
    Magnetorquers,
    momentum_fraction,
    sgcmg_momentum_capacity,
)
from spacecraft.orbit import MU_EARTH, R_EARTH, CircularOrbit, EarthPointingReference
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody

A = IGRF_REFERENCE_RADIUS
SGCMG_BUS_J = np.array(
    [[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]]
)


# ----------------------------------------------------------------------------- orbit


def test_orbit_from_altitude_kepler_and_plane() -> None:
    o = CircularOrbit.from_altitude(530e3, inclination=np.deg2rad(97.5), raan=np.deg2rad(30.0))
    r = R_EARTH + 530e3
    assert o.n == pytest.approx(math.sqrt(MU_EARTH / r**3), rel=1e-12)
    assert o.period / 60.0 == pytest.approx(95.24, abs=0.01)  # hand: 2π√(r³/μ)
    assert o.altitude == pytest.approx(530e3, rel=1e-9)
    # the normal makes the inclination with Z, and its node line is at the RAAN
    assert math.degrees(math.acos(o.normal[2])) == pytest.approx(97.5, abs=1e-9)
    t = np.linspace(0.0, o.period, 7)
    p, v = o.position(t), o.velocity(t)
    assert np.allclose(p @ o.normal, 0.0, atol=1e-6)
    assert np.allclose(np.linalg.norm(v, axis=-1), o.n * r, rtol=1e-12)
    # velocity is the time derivative of the position (central difference)
    e = 1e-3
    assert np.allclose((o.position(t + e) - o.position(t - e)) / (2 * e), v, rtol=1e-7)


@pytest.mark.parametrize("alt", [0.0, -10.0, float("nan")])
def test_orbit_bad_altitude(alt: float) -> None:
    with pytest.raises(ValueError, match="^altitude"):
        CircularOrbit.from_altitude(alt)


# ----------------------------------------------------------------------------- field


def test_field_against_dipole_formula_equator_and_pole() -> None:
    f = TiltedDipoleField(strength=3e-5, tilt=0.0, earth_rate=0.0)  # m̂ = −Z
    B_eq = f.inertial(0.0, [A, 0.0, 0.0])
    assert np.allclose(B_eq, [0.0, 0.0, 3e-5], rtol=1e-12, atol=1e-18)  # north, magnitude B₀
    B_np = f.inertial(0.0, [0.0, 0.0, A])
    assert np.allclose(B_np, [0.0, 0.0, -6e-5], rtol=1e-12, atol=1e-18)  # down, 2 B₀
    # 1/r³ law
    assert np.linalg.norm(f.inertial(0.0, [0.0, 2 * A, 0.0])) == pytest.approx(3e-5 / 8)


def test_field_is_minus_gradient_of_dipole_potential() -> None:
    # an independent route: B = −∇V, V = B₀ a³ (m̂·r)/|r|³, by central differences
    rng = np.random.default_rng(0)
    f = TiltedDipoleField(tilt=0.7, longitude=1.1, greenwich0=0.3)
    t = 1234.5
    m = f.dipole_axis(t)

    def V(r: np.ndarray) -> float:
        return f.strength * A**3 * float(m @ r) / float(np.linalg.norm(r)) ** 3

    for _ in range(5):
        r = rng.normal(size=3)
        r *= (R_EARTH + 530e3) / np.linalg.norm(r)
        e = 1.0
        grad = np.array([(V(r + e * u) - V(r - e * u)) / (2 * e) for u in np.eye(3)])
        assert np.allclose(f.inertial(t, r), -grad, rtol=1e-6, atol=1e-14)


def test_field_constants_and_earth_rotation() -> None:
    assert DIPOLE_STRENGTH_2020 == pytest.approx(29.806e-6, rel=1e-4)
    assert math.degrees(DIPOLE_TILT_2020) == pytest.approx(9.41, abs=0.01)
    f = TiltedDipoleField()
    m0, m1 = f.dipole_axis(0.0), f.dipole_axis(3600.0)
    assert np.linalg.norm(m0) == pytest.approx(1.0)
    assert m0[2] == pytest.approx(-math.cos(DIPOLE_TILT_2020))  # points south
    # one hour of Earth rotation turns the axis by ω_E·3600 about Z
    Rz = Rotation.from_rotvec([0.0, 0.0, EARTH_ROTATION_RATE * 3600.0]).as_matrix()
    assert np.allclose(m1, Rz @ m0, atol=1e-14)


def test_field_body_axes() -> None:
    f = TiltedDipoleField()
    R = Rotation.random(4, random_state=1).as_matrix()
    r = np.array([7e6, 1e5, -2e5])
    Bb = f.body(10.0, R, r)
    assert np.allclose(Bb, np.einsum("bji,j->bi", R, f.inertial(10.0, r)), atol=1e-18)


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"strength": 0.0}, "strength"),
        ({"tilt": 4.0}, "tilt"),
        ({"tilt": -0.1}, "tilt"),
        ({"earth_rate": -1e-5}, "earth_rate"),
        ({"radius": -1.0}, "radius"),
    ],
)
def test_field_bad_input(kw: dict, name: str) -> None:
    with pytest.raises(ValueError, match=f"^{name}"):
        TiltedDipoleField(**kw)


def test_field_zero_position() -> None:
    with pytest.raises(ValueError, match="^r"):
        TiltedDipoleField().inertial(0.0, [0.0, 0.0, 0.0])


# ----------------------------------------------------------------------------- dumping law


def _dumping(max_dipole: float = 200.0, gain: float = 1e-3) -> CrossProductDumping:
    orbit = CircularOrbit.from_altitude(530e3, inclination=np.deg2rad(97.5))
    return CrossProductDumping(orbit, magnetorquers=Magnetorquers(max_dipole), gain=gain)


def test_torque_perpendicular_to_field_saturated_or_not() -> None:
    rng = np.random.default_rng(2)
    for max_dipole in (1e9, 200.0):
        d = _dumping(max_dipole)
        for t in rng.uniform(0.0, 6000.0, 5):
            R = Rotation.random(8, random_state=rng.integers(1 << 30)).as_matrix()
            h = rng.normal(scale=300.0, size=(8, 3))
            m = d.dipole(t, R, h)
            B = d.field_body(t, R)
            tau = d.torque(t, R, m)
            cos = np.sum(tau * B, -1) / (np.linalg.norm(tau, axis=-1) * np.linalg.norm(B, axis=-1))
            assert np.all(np.abs(cos) < 1e-12)
            assert np.all(np.abs(m) <= max_dipole * (1 + 1e-12))


def test_unsaturated_torque_removes_perpendicular_momentum() -> None:
    # hand form of the law: τ = (k Δh × B/‖B‖²) × B = −k (Δh − (Δh·B̂)B̂)
    d = _dumping(max_dipole=1e12, gain=2e-3)
    R = Rotation.random(3, random_state=5).as_matrix()
    h = np.array([[100.0, -50.0, 20.0], [0.0, 300.0, 0.0], [-5.0, 1.0, 2.0]])
    B = d.field_body(100.0, R)
    Bh = B / np.linalg.norm(B, axis=-1, keepdims=True)
    expected = -2e-3 * (h - np.sum(h * Bh, -1, keepdims=True) * Bh)
    assert np.allclose(d.torque(100.0, R, d.dipole(100.0, R, h)), expected, rtol=1e-10)


def test_saturation_keeps_direction() -> None:
    mt = Magnetorquers([100.0, 200.0, 300.0])
    m = np.array([400.0, -100.0, 50.0])
    s = mt.saturate(m)
    assert np.allclose(s, m / 4.0)
    assert np.allclose(mt.saturate([10.0, 10.0, 10.0]), [10.0, 10.0, 10.0])


@pytest.mark.parametrize("bad", [0.0, -200.0, [100.0, 0.0, 100.0], float("inf")])
def test_bad_dipole_limit(bad: object) -> None:
    with pytest.raises(ValueError, match="^max_dipole"):
        Magnetorquers(bad)


def test_bad_dumping_arguments() -> None:
    orbit = CircularOrbit()
    with pytest.raises(ValueError, match="^gain"):
        CrossProductDumping(orbit, gain=0.0)
    with pytest.raises(ValueError, match="^orbit"):
        CrossProductDumping("leo")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="^h_target"):
        CrossProductDumping(orbit, h_target=[1.0, 2.0])
    with pytest.raises(ValueError, match="^momentum_management"):
        Spacecraft(RigidBody(np.eye(3)), SgcmgActuator(), momentum_management=object())


# ----------------------------------------------------------------------------- envelope


def test_sgcmg_capacity_hand_values_and_sampling() -> None:
    act = SgcmgActuator()
    G = act.cluster.gimbal_axes
    G = np.asarray(G() if callable(G) else G)
    beta, h0 = act.cluster.beta, act.cluster.h0
    # along the pyramid axis every unit gives h₀ sin β; along x, 2 h₀ cos β + 2 h₀
    cap = sgcmg_momentum_capacity(G, h0, [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    assert cap == pytest.approx([4 * h0 * math.sin(beta), 2 * h0 * (math.cos(beta) + 1.0)])
    # it is the maximum of d·h over gimbal angles (sampled bound from below)
    rng = np.random.default_rng(3)
    d = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    h = act.cluster.momentum(rng.uniform(-np.pi, np.pi, (200_000, 4)))
    best = float((h @ d).max())
    c = float(sgcmg_momentum_capacity(G, h0, d))
    assert best <= c * (1 + 1e-12)
    assert best > 0.99 * c


def test_momentum_fraction_wheels_and_bad_actuator() -> None:
    rw = ReactionWheelAssembly.orthogonal(max_speed=600.0)
    x = np.array([[300.0, -600.0, 0.0], [0.0, 0.0, 60.0]])
    assert np.allclose(momentum_fraction(rw, x), [1.0, 0.1])
    from spacecraft.actuators import IdealTorqueActuator

    with pytest.raises(ValueError, match="^actuator"):
        momentum_fraction(IdealTorqueActuator(), np.zeros((1, 0)))


# ----------------------------------------------------------------------------- plant seam


def test_magnetic_torque_changes_inertial_momentum() -> None:
    # without disturbance the only external torque is m × B: ΔH_inertial = ∫ R (m × B) dt
    d = _dumping(max_dipole=3000.0)
    plant = Spacecraft(RigidBody(SGCMG_BUS_J), SgcmgActuator(), momentum_management=d)
    R0 = Rotation.random(random_state=7).as_matrix()
    st = plant.initial_state(R0, [0.001, -0.002, 0.0005], x_act0=[0.3, -0.6, 0.8, -0.2])
    held = plant.command(np.zeros((1, 3)), st, 0.0)
    H0 = plant.inertial_momentum(st)
    t, h = 50.0, 0.5
    m = plant.held_dipole(t, st.R, st.x_act)
    st1 = plant.step(st, held, t, h)
    tau0 = np.einsum("bij,bj->bi", st.R, d.torque(t, st.R, m))
    tau1 = np.einsum("bij,bj->bi", st1.R, d.torque(t + h, st1.R, m))
    dH = plant.inertial_momentum(st1) - H0
    assert np.linalg.norm(tau0) > 1e-3  # the test exercises a real torque
    assert np.allclose(dH, 0.5 * h * (tau0 + tau1), rtol=1e-4, atol=1e-9)
    # the packed hot path agrees with the validated step
    R2, x2 = plant.step_packed(t, st.R, st.packed(), held, h)
    assert np.allclose(R2, st1.R, atol=1e-14) and np.allclose(x2, st1.packed(), atol=1e-12)


def _five_orbits(dumping: CrossProductDumping | None, dt: float) -> tuple[float, float, float]:
    from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
    from spacecraft.simulator import simulate

    orbit = CircularOrbit.from_altitude(530e3, inclination=np.deg2rad(97.5))
    plant = Spacecraft(
        RigidBody(SGCMG_BUS_J),
        SgcmgActuator(),
        ConstantHarmonicTorque(n=orbit.n),
        momentum_management=dumping,
    )
    ref = EarthPointingReference(orbit)
    k_R, k_W = gains_from_bandwidth(SGCMG_BUS_J, 0.03, 0.9, error="large_angle", matrix=True)
    r0 = ref(0.0)
    t_final = dt * math.ceil(5 * orbit.period / dt)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate(
            plant,
            GeometricPD(SGCMG_BUS_J, k_R, k_W),
            ref,
            plant.initial_state(r0.R_d, r0.omega_d),
            t_final,
            dt,
            log_every=3,
        )
    frac = momentum_fraction(plant.actuator, res.actuator["delta"][:, 0])
    dip = res.actuator.get("dipole")
    avg = float(np.linalg.norm(dip[:, 0], axis=-1).mean()) if dip is not None else 0.0
    return float(frac.max()), float(frac[-1]), avg


def test_dumping_bounds_momentum_over_five_orbits() -> None:
    # the 0.08 N·m orbit-normal bias needs ~0.08/‖B‖ ≈ 2.5e3 A·m² of dipole: 3000 per rod
    peak, final, avg = _five_orbits(_dumping(max_dipole=3000.0), dt=10.0)
    assert peak < 0.3
    assert final < 0.15
    assert 0.0 < avg < 3000.0 * math.sqrt(3)
    # without dumping the cluster reaches its envelope (a finer step: at the envelope the
    # steering's gimbal rates grow and a 10 s step would not resolve them)
    peak_none, _, _ = _five_orbits(None, dt=2.0)
    assert peak_none > 0.95


# ----------------------------------------------------------------------------- scenario files


def _file(orbit: dict | None, mm: dict | None, reference: dict | None = None) -> dict:
    sc: dict = {"name": "dump", "reference": reference or {"kind": "earth-pointing"}}
    if orbit is not None:
        sc["orbit"] = orbit
    if mm is not None:
        sc["momentum_management"] = mm
    return {"scenario": [sc]}


def test_scenario_keys_and_earth_pointing_rate_from_orbit() -> None:
    from benchmarks.scenario_files import scenario_to_dict, scenarios_from_dict
    from benchmarks.scenarios import OrbitSpec

    orbit = {"altitude_km": 530.0, "inclination_deg": 97.5, "raan_deg": 10.0}
    mm = {"kind": "magnetorquer", "max_dipole": 200.0, "gain": 0.001}
    (sc,) = scenarios_from_dict(_file(orbit, mm))
    assert sc.orbit == OrbitSpec(530.0, 97.5, 10.0)
    assert sc.momentum_management.max_dipole == 200.0
    assert sc.reference.n == pytest.approx(CircularOrbit.from_altitude(530e3).n, rel=1e-12)
    # n set explicitly wins
    (sc2,) = scenarios_from_dict(_file(orbit, mm, {"kind": "earth-pointing", "n": 0.0012}))
    assert sc2.reference.n == 0.0012
    # round trip
    (back,) = scenarios_from_dict({"scenario": [scenario_to_dict(sc)]})
    assert back == sc


def test_runner_reference_follows_the_scenario_orbit_plane() -> None:
    from benchmarks.runner import build_reference
    from benchmarks.scenario_files import scenarios_from_dict

    orbit = {"altitude_km": 530.0, "inclination_deg": 97.5, "raan_deg": 40.0}
    (sc,) = scenarios_from_dict(_file(orbit, None))
    R_d = build_reference(sc)(300.0).R_d
    o = CircularOrbit.from_altitude(530e3, np.deg2rad(97.5), np.deg2rad(40.0))
    assert np.allclose(R_d, o.lvlh_attitude(300.0), atol=1e-12)


@pytest.mark.parametrize(
    ("orbit", "mm", "key"),
    [
        ({"altitude_km": 0.0}, None, "orbit.altitude_km"),
        ({"altitude_km": -5.0}, None, "orbit.altitude_km"),
        ({"altitude_km": 500.0}, {"max_dipole": 0.0}, "momentum_management.max_dipole"),
        ({"altitude_km": 500.0}, {"max_dipole": -1.0}, "momentum_management.max_dipole"),
        ({"altitude_km": 500.0}, {"kind": "thruster"}, "momentum_management.kind"),
        ({"altitude_km": 500.0}, {"gain": 0.0}, "momentum_management.gain"),
        ({"altitude_km": 500.0, "ecc": 0.1}, None, "orbit"),
        (None, {"kind": "magnetorquer"}, "momentum_management"),
    ],
)
def test_scenario_bad_keys_name_the_key(orbit: dict | None, mm: dict | None, key: str) -> None:
    from benchmarks.scenario_files import ScenarioFileError, scenarios_from_dict

    with pytest.raises(ScenarioFileError) as exc:
        scenarios_from_dict(_file(orbit, mm))
    assert f"scenario[0] (dump).{key}" in str(exc.value)


def test_catalogue_pair_differs_only_by_dumping() -> None:
    from benchmarks.runner import build_plant
    from benchmarks.scenarios import SCENARIOS, SUITES

    on, off = SCENARIOS["momentum-dumping"], SCENARIOS["momentum-no-dumping"]
    assert on in SUITES["full"].scenarios and off in SUITES["full"].scenarios
    assert on.duration >= 5 * on.orbit.period
    assert on.momentum_management.kind == "magnetorquer"
    assert off.momentum_management.kind == "none"
    assert build_plant(on.spacecraft, momentum_management=on.momentum_management.build(on.orbit))
    assert off.momentum_management.build(off.orbit) is None


def test_dumping_field_fast_route_matches_the_field_model() -> None:
    orbit = CircularOrbit.from_altitude(
        600e3, inclination=1.2, raan=0.4, arg_lat0=0.3
    )
    field = TiltedDipoleField(tilt=0.5, longitude=2.0, greenwich0=0.1)
    d = CrossProductDumping(orbit, field=field)
    for t in (0.0, 123.4, 5000.0, 5000.0):  # the repeated time comes from the memo
        expected = field.inertial(t, orbit.position(t))
        assert np.allclose(d.field_body(t, np.eye(3)[None])[0], expected, rtol=1e-12, atol=0)


def test_judge_flags_momentum_saturation_from_the_fraction() -> None:
    from benchmarks.metrics import MOMENTUM_SATURATED_FRACTION, judge
    from benchmarks.scenarios import SCENARIOS

    sc = SCENARIOS["momentum-dumping"]
    base = {
        "steady_error_max_deg": 0.01,
        "initial_error_deg": 0.0,
        "final_error_deg": 0.01,
        "effort_Nms": 1.0,
    }
    ok = judge(sc, {**base, "peak_momentum_fraction": 0.5})
    assert ok == ("success", ())
    verdict, flags = judge(sc, {**base, "peak_momentum_fraction": MOMENTUM_SATURATED_FRACTION})
    assert verdict == "degraded" and flags == ("momentum-saturated",)
