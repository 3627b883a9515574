"""Safe-mode Sun acquisition in the benchmark suite (issue 28): the sun-safe plant, its law,
its cell, requirements, dispersion, report and scenario file."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from benchmarks.controllers import (
    CONTROLLERS,
    DEFAULT_GAIN_RULE,
    get_controller,
    make_controller,
    quick_controllers,
)
from benchmarks.dispersion import (
    DEFAULT_DISPERSION,
    member_scenario,
    sun_acquisition_dispersion_note,
)
from benchmarks.metrics import judge
from benchmarks.requirements import Requirement, requirements_of
from benchmarks.runner import run_suite
from benchmarks.scenario_files import scenario_to_dict, scenarios_from_dict
from benchmarks.scenarios import SCENARIOS, SUITES, SunAcquisitionSpec, get_scenario

NAME = "safe-mode-sun-acquisition"
LAW = "sun-acquisition"


def test_scenario_is_in_full_not_quick_and_starts_tumbling_in_sunlight():
    assert NAME in {s.name for s in SUITES["full"].scenarios}
    assert NAME not in {s.name for s in SUITES["quick"].scenarios}
    s = SCENARIOS[NAME]
    assert s.plant == "sun-safe"
    assert 1.0 <= math.degrees(math.hypot(*s.initial_rate)) <= 2.0
    assert LAW not in quick_controllers()
    css = s.sun_acquisition.sun_sensors(s.orbit.circular_orbit())
    assert not css.sun(0.0)[1] and css.sun(2000.0)[1]  # sunlit start, eclipse within the run


def test_registry_keeps_the_law_and_attitude_controllers_apart():
    sun = get_scenario(NAME)
    for name, info in CONTROLLERS.items():
        ok, why = info.applies(sun)
        assert ok == (name == LAW), name
        if name != LAW:
            assert why in ("attitude controller", "SE(3) controller") or "mode scenarios" in why
    assert get_controller(LAW).plants == frozenset({"sun-safe"})
    for other in ("slew-90", "stabilisation", "proximity-approach", "detumble-sso"):
        ok, why = get_controller(LAW).applies(get_scenario(other))
        assert not ok and "mode scenarios only" in why


def test_cell_equals_a_direct_safe_mode_run():
    """run_suite's cell against benchmarks.safe_mode flown by hand from the same start with
    the common tuning rule's ω_n and ζ; 3800 s: acquisition, the whole eclipse and the exit."""
    from benchmarks.safe_mode import sun_acquisition_run

    s = get_scenario(NAME).with_duration(3800.0)
    res = run_suite(
        [s, get_scenario("step-5").with_duration(1.0)],
        [LAW, "geometric-pd-log"],
        executor="serial",
        progress=False,
    )
    assert res.outcome(s.name, "geometric-pd-log").status == "n/a"
    assert res.outcome("step-5", LAW).status == "n/a"
    o = res.outcome(s.name, LAW)
    assert o.status == "ok" and o.verdict == "success" and o.flags == (), o.error
    rule = DEFAULT_GAIN_RULE
    # the catalogue start is start 0 of seed 0; its sensor seed is the study's seed + 1
    d = sun_acquisition_run(
        1, 0, starts=(s.error0, s.omega0), t_final=3800.0, omega_n=rule.omega_n, zeta=rule.zeta
    )
    m = o.metrics
    for key in (
        "time_to_acquire_s",
        "sun_angle_error_deg",
        "peak_rate_eclipse_deg_s",
        "sun_angle_exit_deg",
        "reacquire_s",
    ):
        assert m[key] == pytest.approx(float(getattr(d, key)[0]), rel=1e-12, abs=1e-12), key
    assert (m["eclipse_entry_s"], m["eclipse_exit_s"]) == (d.eclipse_entry_s, d.eclipse_exit_s)
    assert 0 < m["time_to_acquire_s"] < d.eclipse_entry_s
    window = (d.t < d.eclipse_entry_s) & (d.t >= d.eclipse_entry_s - 300.0)
    rms = math.sqrt(float(np.mean(d.sun_angle_deg[window, 0] ** 2)))
    assert m["sun_angle_rms_deg"] == pytest.approx(rms, rel=1e-12)
    cell = res.cell(s.name, LAW)
    assert cell.verdict == "success" and cell.passed == cell.n == 1


def test_default_requirements_and_verdicts():
    s = get_scenario(NAME)
    reqs = requirements_of(s)
    assert [r.metric for r in reqs] == [
        "time_to_acquire_s",
        "sun_angle_rms_deg",
        "peak_rate_eclipse_deg_s",
        "reacquire_s",
    ]
    assert reqs[0] == Requirement("time_to_acquire_s", 0.5 * 1626.0)
    assert reqs[1].limit == 2.5 and reqs[3].limit == reqs[0].limit
    assert reqs[2].limit == pytest.approx(90.0 / (3703.0 - 1626.0))
    # a run that ends before the eclipse is not judged on it
    assert [r.metric for r in requirements_of(s.with_duration(900.0))] == [
        "time_to_acquire_s",
        "sun_angle_rms_deg",
    ]
    m = {"final_sun_angle_deg": 2.0, "final_rate_deg_s": 0.01, "time_to_acquire_s": math.nan}
    assert judge(s, m) == ("failed", ("sun-not-acquired",))
    m |= {"time_to_acquire_s": 200.0, "sun_angle_exit_deg": 20.0, "reacquire_s": math.nan}
    assert judge(s, m) == ("failed", ("sun-not-reacquired",))
    m["reacquire_s"] = 90.0
    assert judge(s, m) == ("success", ())
    m["final_rate_deg_s"] = math.inf
    assert judge(s, m) == ("failed", ("diverged",))


def test_members_draw_a_new_start_and_sensor_seed():
    s = get_scenario(NAME)
    assert member_scenario(s, 0, DEFAULT_DISPERSION) is s
    m1, m2 = (member_scenario(s, k, DEFAULT_DISPERSION) for k in (1, 2))
    for m in (m1, m2):
        assert 1.0 <= math.degrees(math.hypot(*m.initial_rate)) <= 2.0
        assert m.initial_rotvec != s.initial_rotvec
        assert m.sun_acquisition.seed != s.sun_acquisition.seed
    assert m1.initial_rotvec != m2.initial_rotvec
    assert m1.requirements == requirements_of(s)
    note = sun_acquisition_dispersion_note(s, DEFAULT_DISPERSION)
    assert "uniformly random attitude" in note and "[1, 2] deg/s" in note
    assert "own Sun-sensor/gyro noise seed" in note and "do not apply" in note
    assert sun_acquisition_dispersion_note(get_scenario("slew-90")) == ""


def test_report_renders_sun_acquisition_cells(tmp_path):
    from benchmarks.report import write_report

    s = get_scenario(NAME).with_duration(900.0)  # ends before the eclipse
    res = run_suite([s], [LAW, "geometric-pd-log"], executor="serial", progress=False, members=2)
    text = write_report(res, tmp_path).read_text(encoding="utf-8")
    assert "Sun acquisition: time until the Sun angle stays within the threshold" in text
    assert "Sun angle ≤ 5°" in text and "— (Sun 86° off, tumble ‖ω₀‖ 1.7°/s)" in text
    assert "t_acquire = " in text
    assert "— (run ends before the eclipse entry)" in text
    assert "own Sun-sensor/gyro noise seed" in text
    # the attitude tables leave the scenario out instead of showing empty columns
    settle = text.split("### Settling time")[1].split("###")[0] if "### Settling" in text else ""
    assert s.name not in settle
    assert "### Control effort" in text
    assert (tmp_path / "figures" / f"{s.name}.png").is_file()


def test_scenario_file_round_trip_and_bad_input():
    s = get_scenario(NAME)
    assert scenarios_from_dict({"scenario": [scenario_to_dict(s)]})[0] == s
    with pytest.raises(ValueError, match="^threshold_deg:"):
        SunAcquisitionSpec(threshold_deg=0.0)
    with pytest.raises(ValueError, match="^eclipse:"):
        SunAcquisitionSpec(eclipse="hold")
    with pytest.raises(ValueError, match="^rate_range_deg_s:"):
        SunAcquisitionSpec(rate_range_deg_s=(2.0, 1.0))
    with pytest.raises(ValueError, match="^sensor_noise:"):
        SunAcquisitionSpec(sensor_noise=-0.1)
    with pytest.raises(ValueError, match="^fov_half_angle_deg:"):
        SunAcquisitionSpec(fov_half_angle_deg=120.0)
    with pytest.raises(ValueError, match=r"^normals: no sensor is lit for .* body directions"):
        SunAcquisitionSpec(normals=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))
    with pytest.raises(ValueError, match=r"^normals: .* span only 2 .* unobservable"):
        SunAcquisitionSpec(normals=((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0)))
    with pytest.raises(ValueError, match="^sun_acquisition: needs the orbit"):
        dataclasses.replace(s, orbit=None)
    with pytest.raises(ValueError, match="^sun_acquisition: the safe-mode plant is an ideal"):
        dataclasses.replace(s, spacecraft=get_scenario("slew-90").spacecraft)
    with pytest.raises(ValueError, match="^sun_acquisition: the safe-mode plant does not model"):
        dataclasses.replace(s, disturbances=(get_scenario("stabilisation").disturbances[0],))
    with pytest.raises(ValueError, match="^sun_acquisition: the Sun-acquisition law needs"):
        make_controller(LAW, s.spacecraft)
