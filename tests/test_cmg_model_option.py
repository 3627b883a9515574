"""The full CMG model as a scenario option (``SpacecraftSpec.cmg_model``), the mini-CMG CubeSat
preset, and the momentum-vs-full verdict study (:mod:`benchmarks.cmg_model_study`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from benchmarks.cmg_model_study import StudyRow, study_scenarios, verdict_table
from benchmarks.runner import build_actuator, build_plant, run_suite
from benchmarks.scenario_files import ScenarioFileError, scenario_from_dict, scenario_to_dict
from benchmarks.scenarios import (
    CUBESAT_3U_INERTIA,
    MINI_CMG_SPACECRAFT,
    SGCMG_SPACECRAFT,
    SpacecraftSpec,
)
from spacecraft.actuators import SgcmgActuator
from spacecraft.cmg_dynamics import MINI_CMG, GimbalServo, VscmgActuator


def _scenario(**tables):
    d = {"name": "cmg-model", "duration": 10.0, "dt": 0.05}
    d.update(tables)
    return scenario_from_dict(d)


def test_default_is_the_momentum_model():
    assert SpacecraftSpec().cmg_model == "momentum"
    assert isinstance(build_actuator(SGCMG_SPACECRAFT), SgcmgActuator)


def test_full_model_builds_a_vscmg_plant_with_the_spec_parameters():
    spec = dataclasses.replace(
        SGCMG_SPACECRAFT, cmg_model="full", gimbal_servo_bandwidth=12.0, gimbal_torque_limit=30.0,
        gimbal_gyro_feedforward=True, cmg_gimbal_inertia=(0.1, 0.2, 0.3),
    )  # fmt: skip
    true_J = 1.1 * spec.J
    plant = build_plant(spec, true_inertia=true_J)
    act = plant.actuator
    assert isinstance(act, VscmgActuator)
    # the full model's bus inertia is the plant body's (here the perturbed "true" one)
    np.testing.assert_array_equal(act.bus_inertia, plant.body.J)
    np.testing.assert_allclose(act.bus_inertia, true_J)
    assert isinstance(act.servo, GimbalServo)
    assert (act.servo.bandwidth, act.servo.max_torque) == (12.0, 30.0)
    assert act.servo.gyro_feedforward is True
    assert act.inertias.gimbal == (0.1, 0.2, 0.3)
    assert act.inertias.wheel_spin == spec.cmg_wheel_spin_inertia
    assert act.cluster.h0 == spec.h0 and act.rate_limit == spec.gimbal_rate_limit
    np.testing.assert_allclose(act.delta0, np.deg2rad(spec.delta0_deg))
    # the rotor speed follows from h0 = I_Ws Ω₀
    assert act.spin_rate0 == pytest.approx(spec.h0 / spec.cmg_wheel_spin_inertia)


def test_mini_cmg_preset_parameters():
    sp = MINI_CMG_SPACECRAFT
    # the 3U box: m (a² + c²)/12 with m = 4 kg, a = 0.1 m, c = 0.34 m, computed by hand
    assert CUBESAT_3U_INERTIA[0][0] == pytest.approx(4.0 * 0.1256 / 12.0)
    assert CUBESAT_3U_INERTIA[2][2] == pytest.approx(4.0 * 0.02 / 12.0)
    assert sp.cmg_model == "full" and sp.h0 == pytest.approx(MINI_CMG.h0)
    assert sp.cmg_wheel_spin_inertia == MINI_CMG.wheel_spin
    assert sp.cmg_gimbal_inertia == MINI_CMG.gimbal
    assert sp.gimbal_torque_limit == MINI_CMG.gimbal_torque_limit
    act = build_actuator(sp)
    assert isinstance(act, VscmgActuator)
    assert act.spin_rate0 == pytest.approx(10_000 * 2 * np.pi / 60)  # the preset's 10 000 rpm


def test_scenario_file_selects_the_full_model_and_round_trips():
    s = _scenario(spacecraft={"preset": "mini-cmg-3u", "gimbal_servo_bandwidth": 25.0})
    assert s.spacecraft.cmg_model == "full" and s.spacecraft.gimbal_servo_bandwidth == 25.0
    s2 = _scenario(spacecraft={"cmg_model": "full", "cmg_gimbal_inertia": [0.1, 0.1, 0.2]})
    act = build_actuator(s2.spacecraft)
    assert isinstance(act, VscmgActuator) and act.inertias.gimbal == (0.1, 0.1, 0.2)
    for sc in (s, s2):
        assert scenario_from_dict(scenario_to_dict(sc)) == sc


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("cmg_model", "vscmg-ish"),
        ("cmg_wheel_spin_inertia", 0.0),
        ("cmg_wheel_transverse_inertia", -1.0),
        ("cmg_gimbal_inertia", [0.1, 0.0, 0.1]),
        ("cmg_gimbal_inertia", [0.1, 0.1]),
        ("gimbal_servo_bandwidth", 0.0),
        ("gimbal_servo_damping", -0.5),
        ("gimbal_torque_limit", -2.0),
        ("gimbal_gyro_feedforward", "yes"),
    ],
)
def test_bad_full_model_keys_are_named(key, value):
    with pytest.raises(ScenarioFileError) as err:
        _scenario(spacecraft={key: value})
    assert f"scenario.spacecraft.{key}:" in str(err.value)
    with pytest.raises((ValueError, TypeError)) as err2:
        SpacecraftSpec(**{key: value})
    assert str(err2.value).startswith(key)


def test_full_model_needs_the_cmg_actuator():
    with pytest.raises(ValueError, match=r"^cmg_model: .*sgcmg"):
        SpacecraftSpec(actuator="wheels", cmg_model="full")


def _short(spec, model, dt, scale):
    return [s for s in study_scenarios(spec, model, dt, scale) if s.name == "slew-90"]


@pytest.mark.parametrize(
    ("spec", "dt"), [(SGCMG_SPACECRAFT, 0.1), (MINI_CMG_SPACECRAFT, 0.05)], ids=["bus", "mini"]
)
def test_short_closed_loop_run_per_preset(spec, dt):
    """slew-90 for 30 s with the MRP PD: both models run, the full one delivers the torque
    through a gimbal motor (logged, finite, within its limit) and turns the spacecraft the same
    way as the momentum model (same sign of progress, error within a factor of the momentum
    model's progress), and with the base-rate feed-forward it comes closer to it."""
    out = {}
    for model in ("momentum", "full", "full-ff"):
        res = run_suite(
            _short(spec, model, dt, 0.05), ["mrp-pd"], jobs=1, progress=False,
            keep_histories=True,
        )  # fmt: skip
        (o,) = res.outcomes
        assert o.status == "ok", o.error
        out[model] = o
    h = out["full"].histories
    tau = h["actuator.gimbal_torque"]
    limit = spec.gimbal_torque_limit
    assert np.all(np.isfinite(tau)) and np.max(np.abs(tau)) <= limit * (1 + 1e-12)
    assert np.max(np.abs(tau)) > 0.0
    e0 = out["momentum"].metrics["initial_error_deg"]
    progress = {m: e0 - o.metrics["final_error_deg"] for m, o in out.items()}
    assert progress["momentum"] > 0 and progress["full"] > 0.3 * progress["momentum"]
    # the feed-forward removes the base-rate load the PI servo otherwise lags behind
    gap = {m: abs(progress[m] - progress["momentum"]) for m in ("full", "full-ff")}
    assert gap["full-ff"] < gap["full"]


def test_study_scenarios_and_table():
    scs = study_scenarios(MINI_CMG_SPACECRAFT, "momentum", 0.05, 0.5)
    names = [s.name for s in scs]
    assert "slew-90" in names and "proximity-approach" not in names
    for s in scs:
        assert s.spacecraft.cmg_model == "momentum" and s.dt == 0.05
    slow = next(s for s in scs if s.name == "fast-slew-rate-limited")
    assert slow.spacecraft.gimbal_rate_limit == 0.02  # the scenario's own limit is kept
    stab = next(s for s in scs if s.name == "stabilisation")
    assert stab.disturbances[0].kwargs["scale"] == pytest.approx(MINI_CMG.h0 / 300.0)
    bus = study_scenarios(SGCMG_SPACECRAFT, "full", 0.1)
    assert next(s for s in bus if s.name == "stabilisation").disturbances[0].kwargs == {}
    with pytest.raises(ValueError, match="^model: "):
        study_scenarios(MINI_CMG_SPACECRAFT, "exact", 0.05)
    with pytest.raises(ValueError, match="^dt: "):
        study_scenarios(MINI_CMG_SPACECRAFT, "full", 0.03)
    with pytest.raises(ValueError, match="^spacecraft: "):
        study_scenarios(dataclasses.replace(SGCMG_SPACECRAFT, actuator="wheels"), "full", 0.1)
    nan = float("nan")
    rows = [
        StudyRow("bus", "slew-90", "pd", {"momentum": "success", "full": "degraded"},
                 {"momentum": 0.1, "full": 2.0}, {"momentum": nan, "full": 1.5},
                 {"momentum": nan, "full": 0.2}, {"momentum": nan, "full": 0.0}),
        StudyRow("bus", "step-5", "pd", {"momentum": "success", "full": "success"},
                 {"momentum": 0.1, "full": 0.1}, {"momentum": nan, "full": 1.0},
                 {"momentum": nan, "full": 0.1}, {"momentum": nan, "full": 0.0}),
    ]  # fmt: skip
    table = verdict_table(rows)
    assert "| bus | slew-90 | pd | success | **degraded** | 1.5 | 0.2 | 0 |" in table
    assert "step-5" not in table
    assert "step-5" in verdict_table(rows, only_changed=False)



def test_full_model_gimbal_rate_saturation_still_flags_the_actuator():
    """The full model logs a gimbal-motor torque-saturation time (finite, like the wheels');
    its gimbal-rate limit must still count as actuator saturation (on wheels the speed limit
    is momentum saturation instead, unchanged)."""
    from benchmarks.metrics import judge
    from benchmarks.scenarios import SCENARIOS

    m = {
        "initial_error_deg": 90.0, "final_error_deg": 0.001, "steady_error_max_deg": 0.002,
        "effort_Nms": 500.0, "unwound": False, "saturation_time_s": 12.0,
        "min_singularity": 1.05, "command_reversals": 2.0, "torque_saturation_time_s": 0.0,
        "wheel_speed_saturation_time_s": float("nan"),
    }  # fmt: skip
    att = SCENARIOS["slew-90"]
    full = dataclasses.replace(
        att, spacecraft=dataclasses.replace(att.spacecraft, cmg_model="full")
    )
    assert judge(full, m) == ("degraded", ("actuator-saturated",))
    assert judge(full, {**m, "saturation_time_s": 0.0}) == ("success", ())
    assert judge(full, {**m, "saturation_time_s": 0.0, "torque_saturation_time_s": 1.0})[0] == (
        "degraded"
    )
    wheels = dataclasses.replace(
        att, spacecraft=dataclasses.replace(att.spacecraft, actuator="wheels")
    )
    assert judge(wheels, m) == ("success", ())  # wheel speed time is not torque clipping
    assert judge(att, {**m, "torque_saturation_time_s": float("nan")})[1] == (
        "actuator-saturated",
    )


def test_study_script_writes_its_table(tmp_path, capsys):
    from benchmarks.cmg_model_study import main

    rc = main([
        "--out", str(tmp_path), "--duration-scale", "0.02", "--spacecraft", "mini-cmg-3u",
        "--models", "momentum", "full", "--controllers", "mrp-pd",
    ])  # fmt: skip
    assert rc == 0
    md = (tmp_path / "cmg_model_verdicts.md").read_text(encoding="utf-8")
    assert "| mini-cmg-3u | momentum | 5 |" in md and "| mini-cmg-3u | full | 5 |" in md
    lines = (tmp_path / "cmg_model_verdicts.csv").read_text(encoding="utf-8").splitlines()
    assert len(lines) == 1 + 5 * 2  # header + 5 scenarios × 2 models
    assert "wall time" in capsys.readouterr().out
