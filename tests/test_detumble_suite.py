"""Detumble scenarios in the benchmark suite (issue 28): the magnetorquer plant, its two laws,
their cells, requirements, dispersion and report."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from benchmarks.controllers import CONTROLLERS, get_controller, quick_controllers
from benchmarks.dispersion import member_scenario
from benchmarks.metrics import judge
from benchmarks.requirements import Requirement, requirements_of
from benchmarks.runner import run_suite
from benchmarks.scenario_files import scenario_to_dict, scenarios_from_dict
from benchmarks.scenarios import (
    DETUMBLE_TUMBLE,
    SCENARIOS,
    SUITES,
    DetumbleSpec,
    Scenario,
    get_scenario,
)

LAWS = ("detumble-bdot", "detumble-cross-product")


def _short(name: str = "detumble-sso", threshold_deg_s: float = 8.0, duration: float = 1200.0):
    """The catalogue scenario over ``duration`` with a threshold the tumble (9.46 °/s) crosses
    within it, so a cheap run still detumbles."""
    s = get_scenario(name)
    det = dataclasses.replace(s.detumble, threshold_deg_s=threshold_deg_s)
    return dataclasses.replace(s, detumble=det).with_duration(duration)


def _direct(scenario: Scenario, law: str):
    """The same run built by hand from spacecraft.detumble, independently of the runner."""
    from spacecraft.detumble import DetumbleLaw, Magnetometer, simulate_detumble
    from spacecraft.geomagnetic import TiltedDipoleField
    from spacecraft.orbit import CircularOrbit

    det = scenario.detumble
    orbit = CircularOrbit.from_altitude(
        scenario.orbit.altitude_km * 1e3, inclination=math.radians(scenario.orbit.inclination_deg)
    )
    t = np.linspace(0.0, orbit.period, 400)
    B = TiltedDipoleField().inertial(t, orbit.position(t))
    B2 = float(np.mean(np.sum(B * B, axis=-1)))
    gain = det.gain if law == "cross-product" else det.gain / B2
    dl = DetumbleLaw(
        gain, m_max=0.2, law=law, period=2.0, duty_cycle=0.8, gyro_noise_std=1e-5, rod_power=0.2
    )
    return simulate_detumble(
        scenario.spacecraft.J,
        dl,
        np.array(DETUMBLE_TUMBLE),
        scenario.duration,
        threshold=math.radians(det.threshold_deg_s),
        orbit=orbit,
        magnetometer=Magnetometer(noise_std=1e-7, bias=(4e-7, -2e-7, 3e-7)),
        dt=1.0,
        seed=3,
        log_every=1,
    )


def test_detumble_scenarios_are_in_full_not_quick():
    full = {s.name for s in SUITES["full"].scenarios}
    quick = {s.name for s in SUITES["quick"].scenarios}
    for name in ("detumble-sso", "detumble-iss"):
        assert name in full and name not in quick
        assert SCENARIOS[name].plant == "magnetorquer"
    assert {SCENARIOS["detumble-sso"].orbit.inclination_deg,
            SCENARIOS["detumble-iss"].orbit.inclination_deg} == {97.5, 51.6}  # fmt: skip
    assert not set(LAWS) & set(quick_controllers())


def test_registry_keeps_detumble_laws_and_attitude_controllers_apart():
    det = get_scenario("detumble-sso")
    for name, info in CONTROLLERS.items():
        ok, why = info.applies(det)
        assert ok == ("magnetorquer" in info.plants), name
        if not ok and info.plants <= {"sun-safe"}:  # another mode's law
            assert "mode scenarios only" in why
        elif not ok:
            assert why == ("SE(3) controller" if "se3" in info.plants else "attitude controller")
    for law in LAWS:
        assert get_controller(law).plants == frozenset({"magnetorquer"})
        for other in ("slew-90", "proximity-approach", "stabilisation"):
            ok, why = get_controller(law).applies(get_scenario(other))
            assert not ok and "mode scenarios only" in why


def test_detumble_cell_equals_a_direct_simulation():
    s = _short()
    res = run_suite(
        [s, get_scenario("step-5").with_duration(1.0)],
        [*LAWS, "geometric-pd-log"],
        executor="serial",
        progress=False,
    )
    assert res.outcome("step-5", LAWS[0]).status == "n/a"
    assert res.outcome(s.name, "geometric-pd-log").status == "n/a"
    for name, law in zip(LAWS, ("bdot", "cross-product"), strict=True):
        o = res.outcome(s.name, name)
        assert o.status == "ok" and o.verdict == "success" and o.flags == ()
        d = _direct(s, law)
        m = o.metrics
        assert m["time_to_detumble_s"] == d.time_to_threshold[0]
        assert 0 < m["time_to_detumble_s"] < s.duration
        assert m["electrical_energy_J"] == d.electrical_energy[0]
        assert m["final_rate_deg_s"] == pytest.approx(
            math.degrees(np.linalg.norm(d.omega[-1, 0])), rel=1e-12
        )
        assert m["kinetic_energy_removed_J"] == pytest.approx(
            d.kinetic_energy[0, 0] - d.kinetic_energy[-1, 0], rel=1e-12
        )
        assert 0 < m["peak_dipole_frac"] <= 1.0 + 1e-12
        cell = res.cell(s.name, name)
        assert cell.verdict == "success" and cell.passed == cell.n == 1


def test_not_reaching_the_threshold_fails_the_run_and_the_requirement():
    s = get_scenario("detumble-iss")
    (req,) = requirements_of(s)
    assert req == Requirement("time_to_detumble_s", min(s.orbit.period, 0.8 * s.duration))
    assert req.limit == pytest.approx(5714.16, abs=0.01)
    metrics = {"time_to_detumble_s": math.nan, "final_rate_deg_s": 1.5, "electrical_energy_J": 9.0}
    assert judge(s, metrics) == ("failed", ("rate-not-damped",))
    metrics["time_to_detumble_s"] = 4000.0
    assert judge(s, metrics) == ("success", ())
    metrics["final_rate_deg_s"] = math.nan
    assert judge(s, metrics) == ("failed", ("diverged",))


def test_members_draw_a_new_tumble_and_the_report_says_what_does_not_apply():
    from benchmarks.dispersion import DEFAULT_DISPERSION, detumble_dispersion_note

    s = get_scenario("detumble-sso")
    assert member_scenario(s, 0, DEFAULT_DISPERSION) is s
    m1 = member_scenario(s, 1, DEFAULT_DISPERSION)
    assert m1.initial_rotvec == (0.0, 0.0, 0.0)
    assert 5.0 <= math.degrees(math.hypot(*m1.initial_rate)) <= 10.0
    assert m1.initial_rate != s.initial_rate and m1.detumble.seed != s.detumble.seed
    assert m1.member_inertia is not None
    note = detumble_dispersion_note(s, DEFAULT_DISPERSION)
    assert "rate uniform in [5, 10] deg/s" in note
    assert "attitude_angle_deg" in note and "do not apply" in note
    assert detumble_dispersion_note(get_scenario("slew-90")) == ""


def test_report_renders_detumble_cells(tmp_path):
    from benchmarks.report import write_report

    s = _short(duration=300.0)  # 300 s does not reach 8 °/s for every law: both verdicts show
    res = run_suite([s], [*LAWS, "geometric-pd-log"], executor="serial", progress=False, members=2)
    path = write_report(res, tmp_path)
    text = path.read_text(encoding="utf-8")
    assert "## Summary" in text and "Detumble: time until ‖ω‖ stays below the threshold" in text
    assert "tumble ‖ω₀‖ 9.5°/s" in text and "‖ω‖ < 8°/s" in text
    # the attitude tables leave the detumble scenario out instead of showing empty columns
    settle = text.split("### Settling time")[1].split("###")[0] if "### Settling" in text else ""
    assert s.name not in settle
    for o in res.outcomes:
        if o.controller in LAWS:
            assert ("t_detumble = " if o.verdict == "success" else "threshold not reached") in text
    assert "do not apply: a detumble starts at the identity attitude" in text
    assert (tmp_path / "figures" / f"{s.name}.png").is_file()
    assert (tmp_path / "figures" / f"{s.name}-pareto.png").is_file()


def test_scenario_file_round_trip_and_bad_input():
    s = get_scenario("detumble-iss")
    assert scenarios_from_dict({"scenario": [scenario_to_dict(s)]})[0] == s
    with pytest.raises(ValueError, match="^threshold_deg_s:"):
        DetumbleSpec(threshold_deg_s=0.0)
    with pytest.raises(ValueError, match="^duty_cycle:"):
        DetumbleSpec(duty_cycle=1.5)
    with pytest.raises(ValueError, match="^rate_range_deg_s:"):
        DetumbleSpec(rate_range_deg_s=(10.0, 5.0))
    with pytest.raises(ValueError, match="^detumble: needs the orbit"):
        dataclasses.replace(s, orbit=None)
    with pytest.raises(ValueError, match="^detumble: the detumble plant does not model"):
        dataclasses.replace(s, disturbances=(get_scenario("stabilisation").disturbances[0],))
    with pytest.raises(ValueError, match="^initial_rotvec: a detumble run starts"):
        dataclasses.replace(s, initial_rotvec=(0.1, 0.0, 0.0))
    from benchmarks.controllers import make_controller

    with pytest.raises(ValueError, match="^detumble: the 'bdot' detumble law needs"):
        make_controller("detumble-bdot", s.spacecraft)  # no DetumbleSpec, no orbit
