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
from benchmarks.scenarios import QUICK_SUITE, SGCMG_SPACECRAFT, get_scenario, rest_to_rest
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
    assert (
        "| controller | stabilisation | slew-90 | slew-179 | step-5 | fast-slew-rate-limited "
        "| proximity-approach |" in md
    )
    quick = quick_controllers()
    assert len(quick) >= 3 and "geometric-pd-log" in quick
    for c in quick:
        assert f"| `{c}` |" in md
    # a 4 s run cannot settle a 90° slew; the stabilisation has no unwinding ratio
    assert "not settled" in md and "n/a" in md and "FAILED" not in md
    n = len(QUICK_SUITE) * len(quick)  # every pair has a row; SE(3) vs attitude: "n/a"
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
    # every metric has a unit (SE(3) ones included) and every run a verdict
    assert all(doc["units"].values()), doc["units"]
    assert doc["units"]["final_position_error_m"] == "m"
    assert {r["verdict"] for r in doc["results"]} <= {
        "success", "degraded", "failed", "error", "not-applicable"
    }  # fmt: skip
    for s in ("stabilisation", "slew-90", "slew-179", "overview"):
        png = out / "figures" / f"{s}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"figures/{s}.png" in md


def test_horizon_scale_controller_subset_and_scenario_file(tmp_path):
    out = tmp_path / "r"
    f = tmp_path / "mine.toml"
    f.write_text(
        '[[scenario]]\nname = "mine"\nduration = 20.0\n[scenario.initial]\nangle_deg = 40\n',
        encoding="utf-8",
    )
    args = ["run", "--out", str(out), "--no-progress", "--no-figures", "--jobs", "1"]
    code = cli.main(
        args + ["--horizon-scale", "0.005", "--controllers", "geometric-pd-log,mrp-pd",
                "--suite", "quick", "--scenario-file", str(f)]
    )  # fmt: skip
    assert code == 0
    doc = _strict_json((out / "metrics.json").read_text(encoding="utf-8"))
    assert [s["name"] for s in doc["scenarios"]] == [s.name for s in QUICK_SUITE] + ["mine"]
    # 20 s × 0.005 = one step of dt = 0.1 s (a horizon shorter than a step is an error)
    assert [s["duration"] for s in doc["scenarios"]] == pytest.approx(
        [0.005 * s.duration for s in QUICK_SUITE] + [0.1]
    )
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
        make_controller("nope", SGCMG_SPACECRAFT)
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

    from benchmarks import reproductions

    mod = types.ModuleType("benchmarks.reproductions.fake_paper")
    mod.main = fake_main
    mod.CITATION = "Doe & Roe, “A fake paper”, Nowhere 1(1), 2000."
    mod.SUMMARY = "a fake reproduction"
    monkeypatch.setitem(__import__("sys").modules, "benchmarks.reproductions.fake_paper", mod)
    monkeypatch.setitem(reproductions.REPRODUCTIONS, "fake-paper", "fake_paper")
    out = tmp_path / "rep"
    assert cli.main(["reproduce", "fake-paper", "--out", str(out), "--quick"]) == 0
    assert cli.main(["reproduce", "fake-paper", "--out", str(out)]) == 1
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
        picked = ("slew-90", "slew-179", "proximity-approach")
        scenarios = [s.with_duration(2.0) for s in QUICK_SUITE if s.name in picked]
        res = run_suite(scenarios, ["exploding", "geometric-pd-log"], jobs=2, progress=False)
    finally:
        unregister("exploding")
    assert res.n_failed == 2 and res.executor == "process"
    bad = res.outcome("slew-90", "exploding")
    assert bad.status == "failed" and "boom: controller blew up" in bad.error
    good = res.outcome("slew-179", "geometric-pd-log")
    assert good.status == "ok" and good.metrics["initial_error_deg"] == pytest.approx(179.0)
    md = write_report(res, tmp_path, figures=True).read_text(encoding="utf-8")
    assert "the run raised FloatingPointError: boom" in md
    assert "## Errors (runs that raised)" in md and "FAILED" not in md


def test_batched_group_matches_single_runs():
    """A pair's result does not depend on which batch it runs in.

    Cause of the earlier flakiness: numpy evaluates a one-row product ``(1, k) @ (k, n)`` with
    a different BLAS kernel (a matrix-vector one) than a product with two or more rows, whose
    rows are bitwise the same whatever the batch size or position (measured with numpy 2.4 and
    OpenBLAS on x86-64 for 2–16 rows). The SGCMG actuator's momentum and gimbal-rate products
    are such products, so a batch of one differs from a batch of several by round-off at every
    step, and a closed loop started 179° from the target can amplify that; the old test
    compared the two at a fixed 1e-12.

    1. **Bitwise, by construction:** the group of six (three controllers × two scenarios) and
       the large-angle controller alone on the same two scenarios (a batch of two) run the
       same per-spacecraft arithmetic, so they must agree exactly.
    2. **Batch of one, at a tolerance derived from the condition of the case:** the condition
       number κ of each compared quantity (relative change over relative change of the initial
       attitude) is measured by perturbing the start by ε = 1e-9 in three directions; round-off
       of the one-row kernel is at most a few ulps per step, so the tolerance is
       100 · N_steps · ε_mach · max(1, κ).
    """
    sc = [get_scenario(n).with_duration(3.0) for n in ("slew-90", "slew-179")]
    names = ("geometric-pd-trace", "geometric-pd-log", "geometric-pd-large-angle")
    keys = ("final_error_deg", "peak_rate_deg_s", "effort_Nms", "peak_gimbal_rate_rad_s")
    ctrl = names[2]

    def values(res, scenario):
        o = res.outcome(scenario, ctrl)
        assert o.status == "ok", o.error
        return np.r_[[o.metrics[k] for k in keys], np.asarray(o.series["error_deg"])]

    group = run_suite(sc, names, executor=SerialExecutor(), progress=False)
    pair = run_suite(sc, [ctrl], executor=SerialExecutor(), progress=False)
    a = values(group, "slew-179")
    np.testing.assert_array_equal(a, values(pair, "slew-179"))
    np.testing.assert_array_equal(values(group, "slew-90"), values(pair, "slew-90"))

    base = sc[1]
    rv = np.asarray(base.initial_rotvec)
    axis = rv / np.linalg.norm(rv)
    eps = 1e-9
    ortho = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    dirs = np.array([axis, -axis, ortho / np.linalg.norm(ortho)])
    perturbed = [
        dataclasses.replace(base, name=f"slew-179-perturbed-{i}", initial_rotvec=tuple(rv + d))
        for i, d in enumerate(eps * np.linalg.norm(rv) * dirs)
    ]
    pert = run_suite([base, *perturbed], [ctrl], executor=SerialExecutor(), progress=False)
    np.testing.assert_array_equal(values(pert, "slew-179"), a)  # still the batched route
    scale = np.maximum(np.abs(a), 1e-300)
    kappa = np.max([np.abs(values(pert, p.name) - a) / scale / eps for p in perturbed], axis=0)
    n_steps = round(base.duration / base.dt)
    tol = 100 * n_steps * np.finfo(float).eps * np.maximum(1.0, kappa)
    single = run_suite([base], [ctrl], executor=SerialExecutor(), progress=False)
    b = values(single, "slew-179")
    rel = np.abs(b - a) / scale
    assert np.all(rel <= tol), (rel / tol).max()


def test_stacked_controller_equals_separate_controllers():
    rng = np.random.default_rng(3)
    from scipy.spatial.transform import Rotation

    R = Rotation.random(3, random_state=rng).as_matrix()
    w = rng.normal(scale=0.01, size=(3, 3))
    R_d = Rotation.random(2, random_state=rng).as_matrix()
    refs = (ConstantAttitude(R_d[0]), ConstantAttitude(R_d[1]))
    names = ("geometric-pd-trace", "geometric-pd-log")
    members = [TimedController(make_controller(n, SGCMG_SPACECRAFT)) for n in names]
    stacked = StackedController(members, [1, 2])
    stacked.reset(0.0, 3)
    ref = StackedReference(refs, (1, 2))
    u = stacked.command(0.0, AttitudeState(R, w), ref(0.0))
    for i, (n, sl) in enumerate(zip(names, (slice(0, 1), slice(1, 3)), strict=True)):
        c = make_controller(n, SGCMG_SPACECRAFT)
        c.reset(0.0, sl.stop - sl.start)
        np.testing.assert_allclose(u[sl], c.command(0.0, AttitudeState(R[sl], w[sl]), refs[i](0.0)))
        assert members[i].calls == 1 and members[i].mean_time_per_call > 0
    assert set(stacked.diagnostics()) >= {"e_R", "e_Omega"}
    assert stacked.diagnostics()["e_R"].shape == (3, 3)
    with pytest.raises(ValueError, match="^batch_size"):
        stacked.reset(0.0, 4)


def test_held_controller_samples_at_its_own_period():
    inner = TimedController(make_controller("geometric-pd-log", SGCMG_SPACECRAFT))
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
    # tuned to the scenario's control period (no own period); the payload controller's
    # feed-forward keeps its own 0.1 s hold
    assert get_controller("mpc-osqp").control_period is None
    assert get_controller("mrp-adrc").control_period is None
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
    assert sampled_for(sc, get_controller("payload-pid-ff")).control_period == 0.1
    assert sampled_for(sc, get_controller("mpc-osqp")) is sc
    slow = dataclasses.replace(get_controller("mpc-osqp"), control_period=1.0)
    assert sampled_for(sc, slow) is sc  # slower: held instead
    odd = dataclasses.replace(get_controller("mrp-adrc"), control_period=0.15)
    with pytest.raises(ValueError, match="^control_period: 'mrp-adrc' samples every 0.15 s"):
        sampled_for(sc, odd)
