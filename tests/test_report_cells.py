"""Report text: summary cells, tolerant Pareto fronts, step-5 spread line."""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import pytest

from benchmarks.report import _cell, _spread_lines, _summary_cell, pareto_front
from benchmarks.runner import RunOutcome


def _brute_front(pts, rel):
    """Independent route: dominance checked pair by pair with explicit bands."""
    out = []
    for k, (x, y) in pts.items():
        dom = False
        for k2, (x2, y2) in pts.items():
            if k2 == k:
                continue
            tx = rel * max(abs(x), abs(x2))
            ty = rel * max(abs(y), abs(y2))
            x_better, y_better = x2 < x - tx, y2 < y - ty
            x_worse, y_worse = x2 > x + tx, y2 > y + ty
            if (x_better and not y_worse) or (y_better and not x_worse):
                dom = True
        if not dom:
            out.append(k)
    return sorted(out)


def test_pareto_front_tolerance_ties():
    # identical points are both on the front or both off it
    pts = {"geo": (65.05, 10.0), "quat": (65.05, 10.0), "slow": (65.02, 30.0)}
    assert pareto_front(pts, rel_tol=0.01) == ["geo", "quat"]
    # effort spread of 0.1 %: the faster controller wins despite a hair more effort
    assert pareto_front({"a": (65.10, 10.0), "b": (65.02, 10.5)}, rel_tol=0.01) == ["a"]
    # strict (zero tolerance) keeps both
    assert sorted(pareto_front({"a": (65.10, 10.0), "b": (65.02, 10.5)})) == ["a", "b"]
    # absolute tolerance on y: one control period
    assert sorted(
        pareto_front({"a": (1.0, 10.0), "b": (2.0, 10.05)}, abs_tol=(0.0, 0.1))
    ) == ["a"]
    assert sorted(pareto_front({"a": (2.0, 10.0), "b": (1.0, 10.05)}, abs_tol=(0.0, 0.1))) == [
        "b"
    ]
    with pytest.raises(ValueError, match="^rel_tol:"):
        pareto_front(pts, rel_tol=-1.0)
    with pytest.raises(ValueError, match="^abs_tol:"):
        pareto_front(pts, abs_tol=(0.0,))


def test_pareto_front_matches_brute_force():
    vals = [1.0, 1.005, 1.02, 2.0]
    pts = {f"p{i}": xy for i, xy in enumerate(itertools.product(vals, vals))}
    assert sorted(pareto_front(pts, rel_tol=0.01)) == _brute_front(pts, 0.01)


def _o(**kw):
    base = dict(scenario="s", controller="c", status="ok")
    base.update(kw)
    return RunOutcome(**base)


def test_failed_run_never_shows_settling_time():
    o = _o(verdict="failed", flags=("attitude-not-converged",),
           metrics={"settling_time_s": 293.0, "final_error_deg": 0.3,
                    "steady_error_max_deg": 0.9})  # fmt: skip
    cell = _summary_cell(o)
    assert "t_s" not in cell and "293" not in cell
    assert "θ_f = 0.300°" in cell and "0.900°" in cell
    ok = _o(verdict="success", metrics={"settling_time_s": 12.0, "final_error_deg": 0.01})
    assert "t_s = 12.0 s" in _summary_cell(ok)


def test_se3_summary_shows_position_settling():
    m = {"settling_time_s": 99.4, "final_error_deg": 0.01, "final_position_error_m": 0.02,
         "position_settling_time_s": 200.0}  # fmt: skip
    assert "position t_s = 200 s" in _summary_cell(_o(verdict="success", metrics=m))
    m2 = dict(m, position_settling_time_s=float("nan"))
    cell = _summary_cell(_o(verdict="degraded", metrics=m2))
    assert "position not settled" in cell
    assert _cell(_o(verdict="degraded", metrics=m2), "position_settling_time_s").startswith(
        "not settled"
    )


def test_small_cells():
    reason = "not for large-angle manoeuvres of a wheel plant with a long explanation " * 2
    cell = _summary_cell(_o(status="n/a", error=reason))
    assert reason.strip() in cell
    assert _cell(_o(verdict="success", metrics={"command_reversals": 12.0}),
                 "command_reversals") == "12"  # fmt: skip


def test_spread_line_names_outliers():
    sc = SimpleNamespace(name="step-5", tags=())
    ts = {"a": 10.0, "b": 11.0, "c": 9.5, "intrinsic-pid": 20.0}
    outs = {c: _o(controller=c, verdict="success", metrics={"settling_time_s": v})
            for c, v in ts.items()}  # fmt: skip
    res = SimpleNamespace(scenarios=[sc], controllers=list(ts),
                          outcome=lambda s, c: outs[c])  # fmt: skip
    text = " ".join(_spread_lines(res))
    assert "median settling time 10.5 s" in text
    assert "`intrinsic-pid` 1.90×" in text and "integral mode" in text
    assert "`a`" not in text.split("Outside")[1]


def test_settling_table_cells_of_a_failed_run_show_the_verdict():
    # a failed run that entered the band for good inside the final window (t_s = 549 s of a
    # 600 s run, 0.105° max over the final 10 %): every settling-time cell shows the verdict
    m = {"settling_time_s": 548.79, "final_error_deg": 0.09, "steady_error_max_deg": 0.105,
         "final_position_error_m": 0.5, "position_settling_time_s": 300.0}  # fmt: skip
    failed = _o(verdict="failed", flags=("attitude-not-converged",), metrics=m)
    for key in ("settling_time_s", "position_settling_time_s"):
        cell = _cell(failed, key)
        assert cell.startswith("**failed** (attitude-not-converged)")
        assert "549" not in cell and "300" not in cell and "t_s" not in cell
        assert "θ_f = 0.0900°" in cell and "0.105°" in cell
    # a converged run keeps its number, and other metrics of a failed run are unchanged
    ok = _o(verdict="degraded", flags=("actuator-saturated",), metrics=m)
    assert _cell(ok, "settling_time_s") == "549"
    assert _cell(ok, "position_settling_time_s") == "300"
    assert _cell(failed, "steady_error_max_deg") == "0.105"


def test_report_legend_says_what_momentum_saturated_means_per_actuator():
    from benchmarks.metrics import MOMENTUM_SATURATED_FRACTION
    from benchmarks.report import METRIC_PLANTS, SETTLING_NOTE, TABLE_METRICS, VERDICT_RULES

    legend = VERDICT_RULES.split("`momentum-saturated`")[1].split("`near-singular`")[0]
    assert "wheels:" in legend and "speed limit" in legend
    assert "SGCMG:" in legend and "momentum envelope" in legend
    assert f"{MOMENTUM_SATURATED_FRACTION:.0%}" in legend
    # the quantity behind the flag is a table on both actuator plants
    assert "peak_momentum_fraction" in dict(TABLE_METRICS)
    assert METRIC_PLANTS["peak_momentum_fraction"] == frozenset({"sgcmg", "wheels"})
    assert "final 10 %" in SETTLING_NOTE and "stays" in SETTLING_NOTE
