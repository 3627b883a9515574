"""Benchmark CLI, runner and report end to end on shortened horizons (SPEC §8)."""

from __future__ import annotations

import csv
import dataclasses
import json
import types

import numpy as np
import pytest

from benchmarks import cli
from benchmarks.controllers import CONTROLLERS, QUICK_CONTROLLERS, make_controller
from benchmarks.report import write_report
from benchmarks.runner import StackedController, StackedReference, TimedController, run_suite
from benchmarks.scenarios import (
    QUICK_SUITE,
    SEED000_SPACECRAFT,
    DisturbanceSpec,
    Scenario,
    get_suite,
    rest_to_rest,
)
from liecontrol.control import AttitudeController, AttitudeState, ConstantAttitude


def _strict_json(text: str) -> dict:
    def bad(name: str) -> None:
        raise AssertionError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=bad)


def test_run_quick_suite_end_to_end(tmp_path, capsys):
    out = tmp_path / "report"
    code = cli.main(
        ["run", "--suite", "quick", "--out", str(out), "--t-final", "4", "--no-progress"]
    )
    assert code == 0
    assert "report:" in capsys.readouterr().out
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "| controller | stabilisation | slew-90 | slew-179 |" in md
    for c in QUICK_CONTROLLERS:
        assert f"| `{c}` |" in md
    # a 4 s run cannot settle a 90° slew; the stabilisation has no unwinding ratio
    assert "not settled" in md and "n/a" in md and "FAILED" not in md

    with open(out / "metrics.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 9 and all(r["status"] == "ok" for r in rows)
    doc = _strict_json((out / "metrics.json").read_text(encoding="utf-8"))
    assert doc["suite"] == "quick" and len(doc["results"]) == 9
    by_name = {(r["scenario"], r["controller"]): r for r in doc["results"]}
    for row in rows:
        m = by_name[(row["scenario"], row["controller"])]["metrics"]
        assert float(row["initial_error_deg"]) == pytest.approx(m["initial_error_deg"])
    slew = by_name[("slew-179", "geometric-pd-log")]["metrics"]
    assert slew["initial_error_deg"] == pytest.approx(179.0, abs=1e-9)
    assert slew["settling_time_s"] is None  # NaN → null in strict JSON
    assert doc["units"]["settling_time_s"] == "s"
    for s in ("stabilisation", "slew-90", "slew-179"):
        png = out / "figures" / f"{s}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"figures/{s}.png" in md


def test_horizon_scale_and_controller_subset(tmp_path):
    out = tmp_path / "r"
    code = cli.main(
        [
            "run",
            "--out",
            str(out),
            "--horizon-scale",
            "0.005",
            "--no-progress",
            "--no-figures",
            "--jobs",
            "1",
            "--controllers",
            "geometric-pd-log",
        ]
    )
    assert code == 0
    doc = _strict_json((out / "metrics.json").read_text(encoding="utf-8"))
    assert {s["duration"] for s in doc["scenarios"]} == {3.0}
    assert {r["controller"] for r in doc["results"]} == {"geometric-pd-log"}
    assert not (out / "figures").exists()


def test_unknown_names_give_clear_errors(capsys):
    assert cli.main(["run", "--suite", "nope", "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert "unknown suite 'nope'" in err and "quick" in err
    assert cli.main(["run", "--controllers", "pid-9000", "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert "pid-9000" in err and "geometric-pd-log" in err
    assert cli.main(["reproduce", "no_such_paper", "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert "unknown reproduction 'no_such_paper'" in err and "valid reproductions" in err
    with pytest.raises(ValueError, match="^suite: unknown suite 'nope'; valid suites: quick"):
        get_suite("nope")
    with pytest.raises(ValueError, match="^name: unknown controller"):
        make_controller("nope", SEED000_SPACECRAFT)


def test_list(capsys):
    assert cli.main(["run", "--list"]) == 0
    text = capsys.readouterr().out
    for name in ("quick", "slew-179", "stabilisation", *QUICK_CONTROLLERS):
        assert name in text


def test_reproduce_dispatches_to_module_main(tmp_path, monkeypatch):
    calls = []

    def fake_main(out_dir, quick=False):
        calls.append((out_dir, quick))
        return 0 if quick else 1

    mod = types.ModuleType("benchmarks.reproductions.fake_seed")
    mod.main = fake_main
    monkeypatch.setitem(__import__("sys").modules, "benchmarks.reproductions.fake_seed", mod)
    monkeypatch.setattr(cli, "available_reproductions", lambda: ["fake_seed"])
    out = tmp_path / "rep"
    assert cli.main(["reproduce", "fake_seed", "--out", str(out), "--quick"]) == 0
    assert cli.main(["reproduce", "fake_seed", "--out", str(out)]) == 1
    assert calls == [(out, True), (out, False)] and out.is_dir()


class _Exploding(AttitudeController):
    def reset(self, t0, batch_size):
        self.n = 0

    def command(self, t, state, reference):
        self.n += 1
        if self.n > 3:
            raise FloatingPointError("boom: controller blew up on purpose")
        return np.zeros((state.R.shape[0], 3))


def test_failures_are_recorded_not_fatal(tmp_path, monkeypatch):
    monkeypatch.setitem(CONTROLLERS, "exploding", lambda sc: _Exploding())
    scenarios = [s.with_duration(2.0) for s in QUICK_SUITE[1:]]
    res = run_suite(scenarios, ["exploding", "geometric-pd-log"], jobs=1, progress=False)
    assert res.n_failed == 2
    bad = res.outcome("slew-90", "exploding")
    assert bad.status == "failed" and "boom: controller blew up" in bad.error
    good = res.outcome("slew-179", "geometric-pd-log")
    assert good.status == "ok" and good.metrics["initial_error_deg"] == pytest.approx(179.0)
    md = write_report(res, tmp_path, figures=True).read_text(encoding="utf-8")
    assert "FAILED: FloatingPointError: boom" in md and "## Failures" in md


def test_batched_group_matches_single_runs():
    sc = [s.with_duration(3.0) for s in QUICK_SUITE[1:]]
    both = run_suite(sc, QUICK_CONTROLLERS, jobs=1, progress=False)
    alone = run_suite(sc[1:], ["geometric-pd-large-angle"], jobs=1, progress=False)
    a = both.outcome("slew-179", "geometric-pd-large-angle")
    b = alone.outcome("slew-179", "geometric-pd-large-angle")
    for k in ("final_error_deg", "peak_rate_deg_s", "effort_Nms", "peak_gimbal_rate_rad_s"):
        assert a.metrics[k] == pytest.approx(b.metrics[k], rel=1e-12, abs=1e-15)
    np.testing.assert_array_equal(a.series["error_deg"], b.series["error_deg"])


def test_stacked_controller_equals_separate_controllers():
    rng = np.random.default_rng(3)
    from scipy.spatial.transform import Rotation

    R = Rotation.random(3, random_state=rng).as_matrix()
    w = rng.normal(scale=0.01, size=(3, 3))
    R_d = Rotation.random(2, random_state=rng).as_matrix()
    refs = (ConstantAttitude(R_d[0]), ConstantAttitude(R_d[1]))
    names = ("geometric-pd-trace", "geometric-pd-log")
    members = [TimedController(make_controller(n, SEED000_SPACECRAFT)) for n in names]
    stacked = StackedController(members, [1, 2])
    stacked.reset(0.0, 3)
    ref = StackedReference(refs, (1, 2))
    u = stacked.command(0.0, AttitudeState(R, w), ref(0.0))
    for i, (n, sl) in enumerate(zip(names, (slice(0, 1), slice(1, 3)), strict=True)):
        c = make_controller(n, SEED000_SPACECRAFT)
        c.reset(0.0, sl.stop - sl.start)
        np.testing.assert_allclose(u[sl], c.command(0.0, AttitudeState(R[sl], w[sl]), refs[i](0.0)))
        assert members[i].calls == 1 and members[i].mean_time_per_call > 0
    assert set(stacked.diagnostics()) >= {"e_R", "e_Omega"}
    assert stacked.diagnostics()["e_R"].shape == (3, 3)
    with pytest.raises(ValueError, match="^batch_size"):
        stacked.reset(0.0, 4)


def test_scenarios_are_validated_data():
    stab, s90, s179 = QUICK_SUITE
    assert stab.disturbance == DisturbanceSpec("seed000") and stab.initial_error_deg == 0.0
    assert s90.initial_error_deg == pytest.approx(90.0)
    assert s179.initial_error_deg == pytest.approx(179.0)
    # the slew axis (1,1,1)/√3 is not a principal axis of the seed-000 inertia
    a = np.array(s179.initial_rotvec) / np.linalg.norm(s179.initial_rotvec)
    Ja = SEED000_SPACECRAFT.J @ a
    assert np.linalg.norm(np.cross(Ja, a)) > 0.1 * np.linalg.norm(Ja)
    assert s90.batch_key() == s179.batch_key() != stab.batch_key()
    R0 = s179.R0
    again = Scenario.from_matrix("copy", "same start", R0)
    np.testing.assert_allclose(again.R0, R0, atol=1e-12)
    assert dataclasses.replace(s90, duration=5.0) == s90.with_duration(5.0)
    with pytest.raises(ValueError, match="^dt"):
        Scenario("x", "bad", dt=0.0)
    with pytest.raises(ValueError, match="^control_period"):
        Scenario("x", "bad", dt=0.1, control_period=0.05)
    with pytest.raises(ValueError, match="^name"):
        DisturbanceSpec("solar-wind")
    with pytest.raises(ValueError, match="^inertia"):
        dataclasses.replace(SEED000_SPACECRAFT, inertia=((1, 0, 0), (0, 1, 0), (0, 0, 3)))
    with pytest.raises(ValueError, match="^axis"):
        rest_to_rest(30.0, axis=(0.0, 0.0, 0.0))
