"""Benchmark CLI, runner and report end to end on shortened horizons (SPEC §8)."""

from __future__ import annotations

import csv
import dataclasses
import json
import types

import numpy as np
import pytest

from benchmarks import cli
from benchmarks.controllers import (
    CONTROLLERS,
    ControllerContext,
    available_controllers,
    get_controller,
    make_controller,
    quick_controllers,
    register,
    unregister,
)
from benchmarks.executors import SerialExecutor
from benchmarks.report import write_report
from benchmarks.runner import (
    HeldController,
    StackedController,
    StackedReference,
    TimedController,
    run_suite,
    sampled_for,
)
from benchmarks.scenarios import QUICK_SUITE, SEED000_SPACECRAFT, rest_to_rest
from liecontrol.control import AttitudeController, AttitudeState, ConstantAttitude


def _strict_json(text: str) -> dict:
    def bad(name: str) -> None:
        raise AssertionError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=bad)


def test_run_quick_suite_end_to_end(tmp_path, capsys):
    """The README command on a shortened horizon: report, CSV, JSON and figures."""
    out = tmp_path / "report"
    code = cli.main(
        ["run", "--suite", "quick", "--out", str(out), "--t-final", "4", "--no-progress"]
    )
    assert code == 0
    assert "report:" in capsys.readouterr().out
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "| controller | stabilisation | slew-90 | slew-179 | proximity-approach |" in md
    quick = quick_controllers()
    assert len(quick) >= 3 and "geometric-pd-log" in quick
    for c in quick:
        assert f"| `{c}` |" in md
    # a 4 s run cannot settle a 90° slew; the stabilisation has no unwinding ratio
    assert "not settled" in md and "n/a" in md and "FAILED" not in md
    n = 4 * len(quick)  # every pair has a row; SE(3) vs attitude mismatches say "n/a"
    with open(out / "metrics.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == n
    scenarios = {s.name: s for s in QUICK_SUITE}
    for r in rows:  # "n/a" exactly where the controller does not apply (SE(3) vs attitude)
        applies, _ = get_controller(r["controller"]).applies(scenarios[r["scenario"]])
        assert r["status"] == ("ok" if applies else "n/a"), (r["scenario"], r["controller"])
    doc = _strict_json((out / "metrics.json").read_text(encoding="utf-8"))
    assert doc["suite"] == "quick" and len(doc["results"]) == n
    by_name = {(r["scenario"], r["controller"]): r for r in doc["results"]}
    for row in rows:
        if row["status"] != "ok":
            continue
        m = by_name[(row["scenario"], row["controller"])]["metrics"]
        assert float(row["initial_error_deg"]) == pytest.approx(m["initial_error_deg"])
    slew = by_name[("slew-179", "geometric-pd-log")]["metrics"]
    assert slew["initial_error_deg"] == pytest.approx(179.0, abs=1e-9)
    assert slew["settling_time_s"] is None  # NaN → null in strict JSON
    assert doc["units"]["settling_time_s"] == "s"
    for s in ("stabilisation", "slew-90", "slew-179", "overview"):
        png = out / "figures" / f"{s}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"figures/{s}.png" in md


def test_horizon_scale_controller_subset_and_scenario_file(tmp_path):
    out = tmp_path / "r"
    f = tmp_path / "mine.toml"
    f.write_text(
        '[[scenario]]\nname = "mine"\nduration = 2.0\n[scenario.initial]\nangle_deg = 40\n',
        encoding="utf-8",
    )
    args = ["run", "--out", str(out), "--no-progress", "--no-figures", "--jobs", "1"]
    code = cli.main(
        args + ["--horizon-scale", "0.005", "--controllers", "geometric-pd-log,mrp-pd",
                "--suite", "quick", "--scenario-file", str(f)]
    )  # fmt: skip
    assert code == 0
    doc = _strict_json((out / "metrics.json").read_text(encoding="utf-8"))
    assert [s["name"] for s in doc["scenarios"]] == [
        "stabilisation",
        "slew-90",
        "slew-179",
        "proximity-approach",
        "mine",
    ]
    assert [s["duration"] for s in doc["scenarios"]] == [3.0, 3.0, 3.0, 2.0, 0.01]
    assert {r["controller"] for r in doc["results"]} == {"geometric-pd-log", "mrp-pd"}
    assert not (out / "figures").exists()
    # a file alone runs only its scenarios
    assert cli.main(args + ["--scenario-file", str(f), "--controllers", "geometric-pd-log"]) == 0
    doc = _strict_json((out / "metrics.json").read_text(encoding="utf-8"))
    assert [s["name"] for s in doc["scenarios"]] == ["mine"] and doc["suite"] == "files"


def test_bad_input_gives_clear_errors(tmp_path, capsys):
    assert cli.main(["run", "--suite", "nope", "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert "unknown suite 'nope'" in err and "quick" in err
    assert cli.main(["run", "--controllers", "pid-9000", "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert "pid-9000" in err and "geometric-pd-log" in err
    assert cli.main(["run", "--scenarios", "slew-90,slew-9000", "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert "unknown scenario 'slew-9000'; valid scenarios: stabilisation" in err
    bad = tmp_path / "bad.toml"
    bad.write_text('[[scenario]]\nname = "b"\n[scenario.reference]\nknd = "x"\n')
    assert cli.main(["run", "--scenario-file", str(bad), "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert "scenario[0] (b).reference.knd: unknown key" in err
    assert cli.main(["run", "--jobs", "0", "--out", "x"]) == 2
    assert "jobs: must be >= 1" in capsys.readouterr().err
    assert cli.main(["reproduce", "no_such_paper", "--out", "x"]) == 2
    err = capsys.readouterr().err
    assert "unknown reproduction 'no_such_paper'" in err and "valid reproductions" in err
    assert cli.main(["throughput", "--controller", "nope"]) == 2
    assert "valid controllers" in capsys.readouterr().err
    with pytest.raises(ValueError, match="^name: unknown controller"):
        make_controller("nope", SEED000_SPACECRAFT)
    with pytest.raises(ValueError, match="^name: controller 'geometric-pd-log' is already"):
        register("geometric-pd-log", lambda ctx: None)
    with pytest.raises(ValueError, match="^plants"):
        register("x", lambda ctx: None, plants={"warp-drive"})
    with pytest.raises(ValueError, match="^controllers: duplicate"):
        run_suite(QUICK_SUITE, ["geometric-pd-log"] * 2, progress=False)


def test_list(capsys):
    assert cli.main(["run", "--list"]) == 0
    text = capsys.readouterr().out
    for name in ("quick", "full", "unwinding", "montecarlo", "slew-179", "proximity-approach"):
        assert name in text
    for c in available_controllers():
        assert c in text


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


def test_failures_are_recorded_not_fatal(tmp_path):
    register("exploding", lambda ctx: _Exploding(), description="explodes", batched=False)
    try:
        scenarios = [s.with_duration(2.0) for s in QUICK_SUITE[1:]]
        res = run_suite(scenarios, ["exploding", "geometric-pd-log"], jobs=2, progress=False)
    finally:
        unregister("exploding")
    assert res.n_failed == 2 and res.executor == "process"
    bad = res.outcome("slew-90", "exploding")
    assert bad.status == "failed" and "boom: controller blew up" in bad.error
    good = res.outcome("slew-179", "geometric-pd-log")
    assert good.status == "ok" and good.metrics["initial_error_deg"] == pytest.approx(179.0)
    md = write_report(res, tmp_path, figures=True).read_text(encoding="utf-8")
    assert "FAILED: FloatingPointError: boom" in md and "## Failures" in md


def test_batched_group_matches_single_runs():
    sc = [s.with_duration(3.0) for s in QUICK_SUITE[1:]]
    names = ("geometric-pd-trace", "geometric-pd-log", "geometric-pd-large-angle")
    both = run_suite(sc, names, executor=SerialExecutor(), progress=False)
    alone = run_suite(sc[1:], ["geometric-pd-large-angle"], jobs=1, progress=False)
    a = both.outcome("slew-179", "geometric-pd-large-angle")
    b = alone.outcome("slew-179", "geometric-pd-large-angle")
    # batch of two (vectorized route) vs batch of one (scalar route): round-off only
    for k in ("final_error_deg", "peak_rate_deg_s", "effort_Nms", "peak_gimbal_rate_rad_s"):
        assert a.metrics[k] == pytest.approx(b.metrics[k], rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(a.series["error_deg"], b.series["error_deg"], rtol=1e-11)


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


def test_held_controller_samples_at_its_own_period():
    inner = TimedController(make_controller("geometric-pd-log", SEED000_SPACECRAFT))
    held = HeldController(inner, 1.0)
    held.reset(0.0, 1)
    R = np.eye(3)[None]
    ref = ConstantAttitude(np.eye(3))(0.0)
    outs = [
        held.command(0.1 * k, AttitudeState(R, np.array([[0.0, 0.0, 0.01 * k]])), ref)
        for k in range(25)
    ]
    assert inner.calls == 3  # t = 0, 1, 2
    np.testing.assert_array_equal(outs[0], outs[9])
    assert not np.array_equal(outs[9], outs[10])


def test_registry_metadata_and_context():
    info = get_controller("quaternion-pd-continuous")
    assert info.batched and info.plants == frozenset({"sgcmg", "wheels", "ideal"})
    assert get_controller("mpc-osqp").control_period == 1.0
    assert not get_controller("mpc-osqp").batched
    assert get_controller("se3-tracking").plants == frozenset({"se3"})
    sc = rest_to_rest(120.0)
    ctx = ControllerContext.for_scenario(sc, batch_size=2)
    assert ctx.q_hint.shape == (2, 4) and ctx.J.shape == (3, 3)
    ok, why = get_controller("se3-tracking").applies(sc)
    assert not ok and "SE(3)" in why
    for name, i in CONTROLLERS.items():
        assert i.description and i.name == name
    # a controller that needs faster sampling flies the scenario at its own period
    assert sampled_for(sc, get_controller("mrp-adrc")).control_period == 0.1
    assert sampled_for(sc, get_controller("mpc-osqp")) is sc  # slower: held instead
    odd = dataclasses.replace(get_controller("mrp-adrc"), control_period=0.15)
    with pytest.raises(ValueError, match="^control_period: 'mrp-adrc' samples every 0.15 s"):
        sampled_for(sc, odd)
