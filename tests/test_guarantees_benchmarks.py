"""Issue 25 in the benchmark suite: thruster momentum unloading and the ``dumping-insufficient``
flag, the sampled-data-safe keep-out law in the registry, detector-triggered fault
reconfiguration, and the bad-input errors of the new keys. Short runs only (seconds each)."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

import benchmarks.fault_scenarios  # noqa: F401  (registers the fault family)
from benchmarks.controllers import ControllerContext, get_controller
from benchmarks.metrics import DUMPING_INSUFFICIENT_GROWTH, FLAGS, judge
from benchmarks.runner import build_plant, build_reference, run_suite
from benchmarks.scenario_files import ScenarioFileError, scenario_from_dict, scenario_to_dict
from benchmarks.scenarios import MomentumManagementSpec, Scenario, get_scenario
from liecontrol.control.constrained import SampledSafeConstrainedPD
from spacecraft.actuators import SgcmgActuator
from spacecraft.faults import GimbalStuck, fault_detection_report, with_faults
from spacecraft.fdi import ResidualCusum
from spacecraft.momentum import DumpingInfeasibleWarning
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.thrusters import G0, ThrusterUnloading


def _low_inclination(name: str, dt: float = 2.0, orbits: float = 2.1) -> Scenario:
    """The catalogue's 10° pair on a coarser grid (2 s steps and control period, a 2 s minimum
    on-time) over ``orbits`` orbits: a few seconds of CPU."""
    sc = get_scenario(name)
    mm = sc.momentum_management
    if mm.kind == "thrusters":
        mm = dataclasses.replace(mm, min_on_time=dt, pulse_period=10.0 * dt)
    duration = dt * math.ceil(orbits * sc.orbit.period / dt)
    return dataclasses.replace(
        sc, dt=dt, control_period=dt, duration=duration, momentum_management=mm
    )


def test_thrusters_kind_builds_the_documented_layout():
    un = MomentumManagementSpec("thrusters").unloading()
    assert isinstance(un, ThrusterUnloading)
    assert un.layout.n == 12  # six couples
    # 2 N·m about each signed axis (1 N at 1 m, two thrusters per couple)
    np.testing.assert_allclose(np.abs(un.layout.axis_torques).max(axis=1), 2.0)
    assert MomentumManagementSpec("thrusters").build(None) is not None


def test_thrusters_hold_at_low_inclination_where_magnetorquers_warn_and_are_flagged():
    mag = _low_inclination("momentum-dumping-low-inclination")
    thr = _low_inclination("momentum-thrusters-low-inclination")
    assert mag.orbit.inclination_deg == thr.orbit.inclination_deg == 10.0
    # the pre-run check of the magnetorquer scenario warns when its plant is built ...
    with pytest.warns(DumpingInfeasibleWarning, match="magnetorquers cannot hold"):
        build_plant(
            mag.spacecraft,
            mag.disturbances,
            None,
            mag.momentum_management.build(mag.orbit, build_reference(mag)),
        )
    # ... the thruster one does not
    with warnings.catch_warnings():
        warnings.simplefilter("error", DumpingInfeasibleWarning)
        res_thr = run_suite(
            [thr], ["geometric-pd-large-angle"], progress=False, executor="serial"
        )
    with pytest.warns(DumpingInfeasibleWarning):
        res_mag = run_suite(
            [mag], ["geometric-pd-large-angle"], progress=False, executor="serial"
        )
    o_thr, o_mag = res_thr.outcomes[0], res_mag.outcomes[0]
    assert o_thr.status == o_mag.status == "ok", (o_thr.error, o_mag.error)
    m_thr, m_mag = o_thr.metrics, o_mag.metrics
    # magnetorquers: the envelope fraction climbs, the run is flagged
    assert m_mag["momentum_growth_per_orbit"] >= DUMPING_INSUFFICIENT_GROWTH
    assert "dumping-insufficient" in o_mag.flags
    assert math.isnan(m_mag["propellant_kg_per_orbit"])
    # thrusters: held, not flagged, propellant near the secular torque's impulse
    assert abs(m_thr["momentum_growth_per_orbit"]) < DUMPING_INSUFFICIENT_GROWTH
    assert "dumping-insufficient" not in o_thr.flags
    assert m_thr["peak_momentum_fraction"] < 0.3
    minimum = 0.0812 * thr.orbit.period / (1.0 * 220.0 * G0)  # ‖T̄‖ P / (L I_sp g₀)
    assert 0.8 * minimum < m_thr["propellant_kg_per_orbit"] < 2.0 * minimum


def test_dumping_insufficient_flag_on_a_constructed_metrics_dict():
    assert "dumping-insufficient" in FLAGS
    sc = get_scenario("momentum-dumping")
    base = {
        "steady_error_max_deg": 0.01,
        "initial_error_deg": 0.0,
        "final_error_deg": 0.01,
        "effort_Nms": 1.0,
    }
    verdict, flags = judge(sc, {**base, "momentum_growth_per_orbit": 0.2})
    assert verdict == "degraded" and flags == ("dumping-insufficient",)
    assert judge(sc, {**base, "momentum_growth_per_orbit": DUMPING_INSUFFICIENT_GROWTH})[1] == (
        "dumping-insufficient",
    )
    for ok in (0.01, -0.3, float("nan")):
        assert judge(sc, {**base, "momentum_growth_per_orbit": ok}) == ("success", ())
    assert judge(sc, base) == ("success", ())  # scenarios without the metric: not checked


def test_registered_sampled_safe_law_keeps_the_keep_out_margin_positive():
    sc = get_scenario("keep-out-sun-slew")
    ctrl = get_controller("geometric-keep-out-sampled").factory(
        ControllerContext.for_scenario(sc)
    )
    assert isinstance(ctrl, SampledSafeConstrainedPD)
    assert ctrl.sample_period == pytest.approx(sc.control_period or sc.dt)
    res = run_suite(
        [sc.with_duration(120.0), get_scenario("keep-in-keep-out").with_duration(120.0)],
        ["geometric-keep-out-sampled"],
        progress=False,
        executor="serial",
    )
    for o in res.outcomes:
        assert o.status == "ok", o.error
        assert o.metrics["min_keep_out_margin_deg"] > 0.0
        assert "constraint-violated" not in o.flags
    assert res.outcomes[1].metrics["min_keep_in_margin_deg"] > 0.0


def test_detector_triggered_reconfiguration_after_the_fault_within_the_stated_delay():
    """Unit level: a stuck gimbal under a steady momentum-rate command is isolated after the
    fault, within 3× the detector's stated mean delay (plus the one-sample report lag), with no
    alarm before; the steering drops that gimbal only from then on."""
    T, t_fault = 0.1, 2.0
    plant = Spacecraft(RigidBody(np.diag([100.0, 120.0, 90.0])), SgcmgActuator())
    faulty = with_faults(plant, (GimbalStuck(1, t_fault),), reconfiguration="detector")
    act = faulty.actuator
    det = act.detector
    assert isinstance(det, ResidualCusum)
    x = act.initial_state(1)
    u = np.array([[0.3, -0.2, 0.25]])
    w = np.zeros((1, 3))
    rates = []
    for k in range(80):
        # what the (reconfigured) steering commands at this sample, before the fault acts on it
        # (read before the wrapper's call, which updates the detector with this sample)
        rates.append(act.inner.command_unchecked(u, w, x, k * T).delta_dot[0].copy())
        act.command_unchecked(u, w, x, k * T)
    t_alarm = act.detection_time[0]
    assert np.isnan(t_alarm[[0, 2, 3]]).all()  # only the stuck gimbal is flagged
    c_rms = float(np.sqrt(np.mean(np.square(np.array(rates)[: int(t_fault / T), 1]))))
    stated = det.expected_delay(c_rms, loss=1.0) * T  # mean delay [s]
    delay, false_alarms = fault_detection_report(act.faults, act.detection_time)
    assert false_alarms[0] == 0.0
    assert 0.0 < delay[0] <= 3.0 * stated + T
    k_alarm = int(round(t_alarm[1] / T))
    rates = np.array(rates)
    assert np.all(rates[k_alarm:, 1] == 0.0)  # the isolated gimbal is commanded 0 from then on
    assert np.all(rates[int(t_fault / T) : k_alarm, 1] != 0.0)  # not before the alarm


def test_fault_scenarios_report_detection_delay_and_false_alarms():
    sc = get_scenario("fault-gimbal-stuck-slew-90").with_duration(60.0)
    assert sc.reconfiguration == "detector"
    oracle = dataclasses.replace(sc, name="oracle-twin", reconfiguration="oracle")
    res = run_suite(
        [sc, oracle], ["geometric-pd-large-angle"], progress=False, executor="serial"
    )
    det, orc = res.outcomes
    assert 0.0 < det.metrics["fault_detection_delay_s"] <= 2.0
    assert det.metrics["false_alarms"] == 0.0
    assert math.isnan(orc.metrics["fault_detection_delay_s"])
    assert math.isnan(orc.metrics["false_alarms"])


@pytest.mark.parametrize(
    ("kw", "key"),
    [
        # every thruster on the +x side firing along +y: no torque about ±x or −z
        ({"positions": [[1.0, 0.0, 0.0]] * 2, "directions": [[0.0, 1.0, 0.0]] * 2}, "positions"),
        ({"min_on_time": 5.0, "pulse_period": 2.0}, "min_on_time"),
        ({"thrust": -1.0}, "thrust"),
        ({"positions": [[1.0, 0.0, 0.0]]}, "directions"),
    ],
)
def test_bad_thruster_input_names_the_key(kw, key):
    with pytest.raises(ValueError) as err:
        MomentumManagementSpec("thrusters", **kw)
    assert str(err.value).startswith(key)
    d = {
        "name": "thr",
        "duration": 100.0,
        "dt": 1.0,
        "spacecraft": {"name": "sgcmg-bus"},
        "momentum_management": {"kind": "thrusters", **kw},
    }
    with pytest.raises(ScenarioFileError) as ferr:
        scenario_from_dict(d)
    assert f"momentum_management.{key}" in str(ferr.value)


def test_bad_momentum_and_fdi_input_names_the_key():
    with pytest.raises(ValueError, match="^thrust"):
        MomentumManagementSpec("magnetorquer", thrust=1.0)
    with pytest.raises(ValueError, match="^kind"):
        MomentumManagementSpec("rockets")
    for h in (0.0, -1.0):
        with pytest.raises(ValueError, match="^threshold"):
            ResidualCusum(4, 1e-4, threshold=h)
    with pytest.raises(ValueError, match="^noise_std"):
        ResidualCusum(4, 0.0)
    with pytest.raises(ValueError, match="^reconfiguration"):
        dataclasses.replace(get_scenario("fault-bias-slew-90"), reconfiguration="psychic")
    plant = Spacecraft(RigidBody(np.eye(3) * 100.0), SgcmgActuator())
    with pytest.raises(ValueError, match="^reconfiguration"):
        with_faults(plant, (GimbalStuck(1, 1.0),), reconfiguration="psychic")
    with pytest.raises(ValueError, match="^compensate"):
        with_faults(plant, (GimbalStuck(1, 1.0),), compensate=True, reconfiguration="detector")
    with pytest.raises(ValueError, match="^detector"):
        with_faults(plant, (GimbalStuck(1, 1.0),), detector=ResidualCusum(3, 1e-4))
    # a thruster minimum on-time below the integration step
    with pytest.raises(ValueError, match="^momentum_management"):
        dataclasses.replace(
            get_scenario("momentum-thrusters-low-inclination"),
            momentum_management=MomentumManagementSpec("thrusters", min_on_time=0.5),
        )


def test_scenario_files_take_the_thruster_kind_and_the_reconfiguration_trigger():
    d = {
        "name": "thr-file",
        "duration": 100.0,
        "dt": 1.0,
        "control_period": 1.0,
        "momentum_management": {"kind": "thrusters", "thrust": 0.5, "gain": 0.002},
        "fault": [{"kind": "cmg-gimbal-stuck", "unit": 1, "time": 50.0}],
        "reconfiguration": "oracle",
    }
    sc = scenario_from_dict(d)
    mm = sc.momentum_management
    assert mm.kind == "thrusters" and mm.thrust == 0.5 and mm.min_on_time is None
    assert sc.reconfiguration == "oracle"
    assert scenario_from_dict(scenario_to_dict(sc)) == sc
    assert scenario_from_dict({**d, "reconfiguration": "detector"}).reconfiguration == "detector"
    with pytest.raises(ScenarioFileError) as err:
        scenario_from_dict({**d, "reconfiguration": "psychic"})
    assert "reconfiguration" in str(err.value)
    with pytest.raises(ScenarioFileError) as err:
        scenario_from_dict({**d, "momentum_management": {"kind": "magnetorquer", "isp": 300.0}})
    assert "momentum_management.isp" in str(err.value)


def test_finite_time_study_reports_the_bounds_as_not_applicable_under_a_torque_limit():
    from benchmarks.finite_time_study import convergence_claim
    from liecontrol.control.finite_time import BoundNotApplicable

    with pytest.warns(BoundNotApplicable):
        rows = {r.controller: r for r in convergence_claim(n_starts=2, max_torque=5.0, dt=0.5)}
    for law in ("finite-time-so3", "fixed-time-so3"):
        assert math.isnan(rows[law].claim_max)  # no claim: the bound assumes unbounded torque
    with pytest.raises(ValueError, match="^max_torque"):
        convergence_claim(n_starts=2, max_torque=-1.0)
