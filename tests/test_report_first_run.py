"""A new user's report and first run (issue 27): the `list` command, one exit-status rule
everywhere, the "compiling kernels" notice, the report's words (``error`` is not ``failed``),
the scenario table's disturbance / steering / chaser columns, faults with their kind in
``metrics.json`` and in the report without figures, and the report's definitions (the slope
``s`` of ``K_R = ω_n²J/s``, why the trace PD measures 1.01–1.05 of the spec)."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from benchmarks import cli
from benchmarks.controllers import GainRule, get_controller
from benchmarks.report import _cell, _summary_cell, write_report
from benchmarks.runner import RunOutcome, run_suite
from benchmarks.scenarios import SCENARIOS, get_scenario
from benchmarks.tuning_report import _reading_notes

ROOT = Path(__file__).resolve().parents[1]


def _flat(text: str) -> str:
    return " ".join(text.split())


# ------------------------------------------------------------------ command line


def test_list_is_run_list(capsys):
    assert cli.main(["list"]) == 0
    listed = capsys.readouterr().out
    assert cli.main(["run", "--list"]) == 0
    assert capsys.readouterr().out == listed
    assert "suites:" in listed and "controllers:" in listed


def test_one_exit_status_rule_in_help_docs_and_code(capsys):
    rule = _flat(cli.EXIT_STATUS_RULE)
    for argv in (["--help"], ["run", "--help"]):
        with pytest.raises(SystemExit):
            cli.main(argv)
        assert rule in _flat(capsys.readouterr().out)
    docs = _flat((ROOT / "docs" / "benchmarks.md").read_text(encoding="utf-8"))
    assert rule in docs
    # the rule itself: failed verdicts do not change the status, a run that raised does
    assert "1 when some run raised (verdict 'error'" in rule
    assert "'failed' verdict" in rule and "is a finding, not a crash" in rule


def _compile_something_new(*_args):
    """A warm-up stand-in that makes numba compile (a fresh, uncached function)."""
    from numba import njit

    @njit(cache=False)
    def f(x):
        return 2.0 * x + 1.0

    assert f(1.0) == 3.0
    __import__("time").sleep(0.5)  # still warming up when the notice thread looks (every 0.1 s)


def test_compile_notice_when_numba_compiles(monkeypatch, capsys):
    from liecontrol._jit import JIT_ENABLED

    if not JIT_ENABLED:
        pytest.skip("numba is not in use: nothing is compiled, no notice")
    monkeypatch.setattr(cli, "COMPILE_NOTICE_AFTER_S", 0.0)
    monkeypatch.setattr(cli, "_warm_up_runs", _compile_something_new)
    cli._warm_up([get_scenario("step-5")], ["geometric-pd-log"], announce=True)
    err = capsys.readouterr().err
    assert f"compiling kernels (first run only, ≈{cli.COLD_COMPILE_S} s on 2 cores" in err
    assert "kernels ready after" in err


def test_no_compile_notice_without_compilation(monkeypatch, capsys):
    """Loading cached code (or a slow machine) is not announced as compiling."""
    monkeypatch.setattr(cli, "COMPILE_NOTICE_AFTER_S", 0.0)
    monkeypatch.setattr(cli, "_warm_up_runs", lambda *a: __import__("time").sleep(0.3))
    cli._warm_up([get_scenario("step-5")], ["geometric-pd-log"], announce=True)
    assert "compiling" not in capsys.readouterr().err


def test_no_compile_notice_when_not_asked(monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMPILE_NOTICE_AFTER_S", 0.0)
    monkeypatch.setattr(cli, "_warm_up_runs", _compile_something_new)
    cli._warm_up([get_scenario("step-5")], ["geometric-pd-log"], announce=False)  # --no-progress
    assert capsys.readouterr().err == ""


def test_warm_up_runs_the_selection_in_process():
    spent = cli._warm_up([get_scenario("step-5")], ["geometric-pd-log"], announce=False)
    assert spent >= 0.0


def test_the_compile_estimate_is_the_documented_measurement():
    docs = (ROOT / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    run_time = docs[docs.index("## Run time"):]
    run_time = run_time[: run_time.index("\n## ", 5)]
    assert f"≈{cli.COLD_COMPILE_S} s on 2 cores" in run_time
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    # one set of figures: the README points at it instead of typing its own
    assert "docs/benchmarks.md#run-time" in readme
    assert not re.search(r"about (a|\d+) minutes? on 2 cores", readme)


# ------------------------------------------------------------------ report words


def test_a_run_that_raised_reads_error_not_failed():
    o = dataclasses.replace(RunOutcome("slew-90", "boom", "failed", "FloatingPointError: boom"),
                            verdict="error")  # fmt: skip
    assert _cell(o, "effort_Nms") == "error"
    summary = _summary_cell(o)
    assert summary.startswith("**error**") and "FAILED" not in summary
    assert "the run raised FloatingPointError: boom" in summary


def test_slope_s_is_defined_in_the_controller_list():
    for error, slope in (("log", "s = 1"), ("large_angle", "s = ½"), ("trace", "s = 0.95")):
        desc = get_controller(f"geometric-pd-{error.replace('_', '-')}").description
        assert "K_R = ω_n²J/s" in desc and f"where {slope}" in desc


def test_the_trace_pd_off_spec_ratio_is_explained():
    notes = "\n".join(_reading_notes(SimpleNamespace(controllers=["geometric-pd-trace"]),
                                     GainRule()))  # fmt: skip
    assert "between 1.00 and 1.05 of the spec per axis instead of exactly 1.00, by design" in notes
    assert "0.95, 1.0 and 1.05" in notes


@pytest.fixture(scope="module")
def small_report(tmp_path_factory):
    fault = SCENARIOS["fault-gimbal-stuck-slew-90"]
    picked = [fault.with_duration(80.0), get_scenario("stabilisation").with_duration(20.0),
              get_scenario("proximity-approach").with_duration(20.0)]  # fmt: skip
    result = run_suite(picked, ["geometric-pd-log", "se3-tracking"], executor="serial",
                       progress=False)  # fmt: skip
    out = tmp_path_factory.mktemp("report")
    path = write_report(result, out, figures=False)
    return path.read_text(encoding="utf-8"), json.loads((out / "metrics.json").read_text())


def test_scenario_table_has_disturbance_steering_chaser_and_faults(small_report):
    md, _ = small_report
    table = md[md.index("## Scenarios"): md.index("## Controllers")]
    assert "| disturbance | faults |" in table
    assert "constant-harmonic: peak ‖τ_d‖" in table and "N·m" in table
    assert "steering `" in table
    assert re.search(r"SE\(3\) chaser, mass \d+ kg", table)
    assert "cmg-gimbal-stuck unit" in table  # the fault, named without any figure


def test_metrics_json_records_each_fault_with_its_kind(small_report):
    _, doc = small_report
    faults = next(s["faults"] for s in doc["scenarios"] if s["name"].startswith("fault-"))
    assert faults and all({"kind", "unit", "time"} <= set(f) for f in faults)
    assert faults[0]["kind"] == "cmg-gimbal-stuck"
