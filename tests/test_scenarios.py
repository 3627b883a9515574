"""Scenario catalogue and scenario files (SPEC §8.1): data, validation, errors naming the key."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from benchmarks import scenario_files as sf
from benchmarks.runner import build_plant, build_reference, initial_state
from benchmarks.scenarios import (
    QUICK_SUITE,
    SCENARIOS,
    SGCMG_SPACECRAFT,
    SUITES,
    DisturbanceSpec,
    ReferenceSpec,
    Scenario,
    UncertaintySpec,
    get_scenario,
    get_suite,
    register_scenario,
    rest_to_rest,
    scale_principal_moments,
    unregister_scenario,
)
from liecontrol.lie import so3

EXAMPLES = Path(__file__).resolve().parents[1] / "benchmarks" / "data"


def test_catalogue_covers_spec_8_1():
    tags = {t for s in SCENARIOS.values() for t in s.tags}
    assert {
        "stabilisation",
        "manoeuvre",
        "unwinding",
        "tracking",
        "uncertainty",
        "jitter",
        "se3",
    } <= tags
    angles = {round(s.initial_error_deg, 3) for s in SCENARIOS.values() if "manoeuvre" in s.tags}
    assert {30.0, 90.0, 150.0, 179.0, 120.0} <= angles
    assert [s.name for s in QUICK_SUITE] == [
        "stabilisation",
        "slew-90",
        "slew-179",
        "step-5",
        "fast-slew-rate-limited",
        "proximity-approach",
    ]
    assert get_suite("full").scenarios == tuple(SCENARIOS.values())
    assert SCENARIOS["proximity-approach"].plant == "se3"
    assert SCENARIOS["payload-jitter"].plant == "wheels"
    assert SCENARIOS["slew-90"].plant == "sgcmg"
    # the q / −q pair: same physical start, opposite chart points
    q, mq = SCENARIOS["unwinding-q"], SCENARIOS["unwinding-minus-q"]
    np.testing.assert_array_equal(q.R0, mq.R0)
    np.testing.assert_allclose(q.initial_quaternion, -mq.initial_quaternion)
    assert q.initial_quaternion[0] > 0
    # the slew axis (1,1,1)/√3 is not a principal axis of the seed-000 inertia
    a = np.array(SCENARIOS["slew-179"].initial_rotvec) / np.deg2rad(179.0)
    Ja = SGCMG_SPACECRAFT.J @ a
    assert np.linalg.norm(np.cross(Ja, a)) > 0.1 * np.linalg.norm(Ja)
    # the random axis is what its comment says
    v = np.random.default_rng(2026).normal(size=3)
    np.testing.assert_allclose(
        np.array(SCENARIOS["slew-120-random-axis"].initial_rotvec) / np.deg2rad(120),
        v / np.linalg.norm(v),
        atol=1e-8,
    )


def test_initial_quaternion_matches_scipy_and_sign():
    s = rest_to_rest(150.0, (0.0, 1.0, 0.0))
    x, y, z, w = Rotation.from_matrix(s.R0).as_quat()
    np.testing.assert_allclose(np.abs(s.initial_quaternion), np.abs([w, x, y, z]), atol=1e-12)
    assert s.initial_quaternion[0] > 0
    neg = dataclasses.replace(s, quaternion_sign=-1)
    np.testing.assert_allclose(neg.initial_quaternion, -s.initial_quaternion)


def test_scaled_inertia_keeps_axes_and_scales_moments():
    J = SGCMG_SPACECRAFT.J
    Jt = scale_principal_moments(J, [1.2, 1.2, 0.8])
    lam, V = np.linalg.eigh(J)
    np.testing.assert_allclose(V.T @ Jt @ V, np.diag(lam * [1.2, 1.2, 0.8]), atol=1e-9)
    np.testing.assert_allclose(scale_principal_moments(J, [1, 1, 1]), J, atol=1e-9)
    sc = SCENARIOS["inertia-uncertainty"]
    np.testing.assert_allclose(sc.true_inertia, Jt)
    assert np.allclose(build_plant(sc.spacecraft, sc.disturbances, sc.true_inertia).body.J, Jt)
    with pytest.raises(ValueError, match="^scale: principal moments violate"):
        scale_principal_moments(J, [1.2, 0.8, 1.2])
    with pytest.raises(ValueError, match="^uncertainty: inertia_scale"):
        Scenario("x", "bad", uncertainty=UncertaintySpec((1.2, 0.8, 1.2)))


def test_initial_state_is_relative_to_the_reference():
    sc = SCENARIOS["earth-pointing"]
    ref = build_reference(sc)(0.0)
    R0, w0 = initial_state(sc)
    np.testing.assert_allclose(so3.log(ref.R_d.T @ R0), sc.initial_rotvec, atol=1e-12)
    e_w = w0 - R0.T @ ref.R_d @ ref.omega_d
    np.testing.assert_allclose(e_w, sc.initial_rate, atol=1e-15)
    # the constant-rate reference solves Ṙ_d = R_d ω_d^ (central difference)
    r = build_reference(SCENARIOS["slew-tracking"])
    h = 1e-3
    dR = (r(5.0 + h).R_d - r(5.0 - h).R_d) / (2 * h)
    np.testing.assert_allclose(dR, r(5.0).R_d @ so3.hat(r(5.0).omega_d), atol=1e-9)


def test_bad_scenarios_name_the_argument():
    with pytest.raises(ValueError, match="^dt"):
        Scenario("x", "bad", dt=0.0)
    with pytest.raises(ValueError, match="^control_period"):
        Scenario("x", "bad", dt=0.1, control_period=0.15)
    with pytest.raises(ValueError, match="^name: unknown disturbance 'solar-wind'"):
        DisturbanceSpec("solar-wind")
    with pytest.raises(ValueError, match="^params: 'constant-harmonic' has no parameter 'q'"):
        DisturbanceSpec("constant-harmonic", {"q": 1.0})
    with pytest.raises(ValueError, match="^kind: unknown reference kind"):
        ReferenceSpec("lvlh")
    with pytest.raises(ValueError, match="^quaternion_sign"):
        Scenario("x", "bad", quaternion_sign=0)
    with pytest.raises(ValueError, match="^inertia"):
        dataclasses.replace(SGCMG_SPACECRAFT, inertia=((1, 0, 0), (0, 1, 0), (0, 0, 3)))
    with pytest.raises(ValueError, match="^actuator: unknown actuator 'jets'"):
        dataclasses.replace(SGCMG_SPACECRAFT, actuator="jets")
    with pytest.raises(ValueError, match="^axis"):
        rest_to_rest(30.0, axis=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="^name: unknown suite 'nope'; valid suites: full"):
        get_suite("nope")
    with pytest.raises(ValueError, match="^name: unknown scenario 'nope'; valid .*slew-90"):
        get_scenario("nope")


def test_register_scenario_adds_to_suites(monkeypatch):
    monkeypatch.setattr("benchmarks.scenarios.SCENARIOS", dict(SCENARIOS))
    monkeypatch.setattr("benchmarks.scenarios.SUITES", dict(SUITES))
    from benchmarks import scenarios as mod

    s = rest_to_rest(42.0, name="my-42")
    register_scenario(s, suites=("full", "quick"))
    assert mod.SCENARIOS["my-42"] is s
    assert mod.SUITES["quick"].scenarios[-1] is s and mod.SUITES["full"].scenarios[-1] is s
    with pytest.raises(ValueError, match="^scenario: 'my-42' is already registered"):
        register_scenario(s)
    with pytest.raises(ValueError, match="^suites: unknown suite"):
        register_scenario(rest_to_rest(43.0), suites=("nope",))
    unregister_scenario("my-42")
    assert "my-42" not in mod.SCENARIOS
    assert all(
        x.name != "my-42" for x in mod.SUITES["quick"].scenarios + mod.SUITES["full"].scenarios
    )


def test_example_files_load():
    toml = sf.load_scenarios(EXAMPLES / "example.toml")
    assert [s.name for s in toml] == ["slew-120-x", "minus-q-135", "earth-pointing-ideal"]
    a, b, c = toml
    assert a.duration == 600.0 and a.control_period == 0.2
    assert a.initial_error_deg == pytest.approx(120.0)
    np.testing.assert_allclose(a.initial_rotvec, [np.deg2rad(120), 0, 0])
    assert a.disturbances == (DisturbanceSpec("constant-harmonic"),)
    # a w < 0 quaternion is the −q start of the same rotation
    assert b.quaternion_sign == -1 and b.initial_error_deg == pytest.approx(135.0, abs=1e-6)
    np.testing.assert_allclose(b.initial_rotvec, [0, 0, np.deg2rad(135)], atol=1e-7)
    assert c.plant == "ideal" and c.spacecraft.max_torque == 5.0 and c.duration == 600.0
    assert c.reference.kind == "earth-pointing" and c.uncertainty.inertia_scale == (0.8, 1.2, 1.1)
    pytest.importorskip("yaml")
    yml = sf.load_scenarios(EXAMPLES / "example.yaml")
    assert [s.name for s in yml] == ["slew-45-random", "slewing-reference"]
    assert yml[1].reference.rate == pytest.approx((0.0, np.deg2rad(0.1), 0.0))


def test_round_trip_through_the_file_schema(tmp_path):
    for s in SCENARIOS.values():
        again = sf.scenario_from_dict(sf.scenario_to_dict(s))
        assert again == s, s.name
    pytest.importorskip("yaml")
    import yaml

    p = tmp_path / "all.yaml"
    p.write_text(yaml.safe_dump({"scenario": [sf.scenario_to_dict(s) for s in QUICK_SUITE]}))
    assert tuple(sf.load_scenarios(p)) == QUICK_SUITE


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        (
            '[[scenario]]\nname = "a"\nfoo = 1\n',
            r"scenario\[0\] \(a\)\.foo: unknown key; valid: name",
        ),
        (
            '[[scenario]]\nname = "a"\n[scenario.reference]\nkind = "lvlh"\n',
            r"scenario\[0\] \(a\)\.reference\.kind: unknown reference kind 'lvlh'",
        ),
        (
            '[[scenario]]\nname = "a"\n[scenario.initial]\nangle_deg = 30\naxis = [1, 2]\n',
            r"scenario\[0\] \(a\)\.initial\.axis: expected 3 finite numbers",
        ),
        (
            '[[scenario]]\nname = "a"\ndt = -1.0\n',
            r"scenario\[0\] \(a\)\.dt: must be > 0",
        ),
        (
            '[[scenario]]\nname = "a"\n[[scenario.disturbance]]\nname = "wind"\n',
            r"scenario\[0\] \(a\)\.disturbance\[0\]\.name: unknown disturbance 'wind'",
        ),
        (
            '[[scenario]]\nname = "a"\n[[scenario.disturbance]]\n'
            'name = "constant-harmonic"\nscale = "x"\n',
            r"scenario\[0\] \(a\)\.disturbance\[0\]\.scale: expected a number",
        ),
        (
            '[[scenario]]\nname = "a"\n[scenario.spacecraft]\nh0 = 0\n',
            r"scenario\[0\] \(a\)\.spacecraft\.h0: must be > 0",
        ),
        (
            '[[scenario]]\nname = "a"\n[scenario.spacecraft]\npreset = "hubble"\n',
            r"scenario\[0\] \(a\)\.spacecraft\.preset: unknown preset 'hubble'; valid: sgcmg-bus",
        ),
        ('[[scenario]]\ndescription = "x"\n', r"scenario\[0\]\.name: missing"),
        ("[defaults]\ndt = 0.1\n", r"scenario: no \[\[scenario\]\] table found"),
        ('[[scenario]]\nname = "a"\n[[scenario]]\nname = "a"\n', r"scenario: duplicate names"),
        ('[[scenario]\nname = "a"\n', r"invalid TOML"),
        (
            '[[scenario]]\nname = "a"\n[scenario.uncertainty]\ninertia_scale = [1.2, 0.8, 1.2]\n',
            r"scenario\[0\] \(a\)\.uncertainty: inertia_scale",
        ),
    ],
)
def test_malformed_files_point_to_the_key(tmp_path, text, pattern):
    p = tmp_path / "bad.toml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(sf.ScenarioFileError, match=f"^path: {p}: .*{pattern}"):
        sf.load_scenarios(p)


def test_file_level_errors(tmp_path):
    with pytest.raises(sf.ScenarioFileError, match="no such file"):
        sf.load_scenarios(tmp_path / "missing.toml")
    p = tmp_path / "x.json"
    p.write_text("{}")
    with pytest.raises(sf.ScenarioFileError, match="unknown format '.json'"):
        sf.load_scenarios(p)
    with pytest.raises(
        sf.ScenarioFileError, match=r"^scenario\.initial\.rotvec_deg: give one attitude form"
    ):
        sf.scenario_from_dict(
            {"name": "a", "initial": {"rotvec": [0, 0, 0], "rotvec_deg": [0, 0, 0]}}
        )
    s = sf.scenario_from_dict({"name": "q", "initial": {"quaternion": [0.0, 0.0, 0.0, 1.0]}})
    assert s.initial_error_deg == pytest.approx(180.0) and math.isclose(
        abs(s.initial_rotvec[2]), math.pi
    )


@pytest.mark.parametrize(
    "step", ["slew-90", "slew-150", "slew-120-random-axis"], ids=lambda s: f"{s}-planned"
)
def test_each_planned_twin_flies_its_step_scenarios_start_and_target(step):
    from benchmarks.runner import build_reference, initial_state
    from benchmarks.scenarios import get_scenario

    st, pl = get_scenario(step), get_scenario(f"{step}-planned")
    R_step, w_step = initial_state(st)
    R_plan, w_plan = initial_state(pl)
    np.testing.assert_allclose(R_plan, R_step, atol=1e-15)
    np.testing.assert_array_equal(w_plan, w_step)
    ref = build_reference(pl)
    end = ref(pl.duration)
    np.testing.assert_allclose(end.R_d, build_reference(st)(st.duration).R_d, atol=1e-15)
    np.testing.assert_allclose(end.omega_d, 0.0, atol=0.0)
    assert ref.slew_time < 0.5 * pl.duration  # the slew ends well inside the run
    assert "planned" in pl.tags and pl.plant == st.plant
