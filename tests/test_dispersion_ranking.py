"""Dispersed cells, requirements, Wilson verdicts, rankings with ties, aliases, flags."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import binomtest

from benchmarks.dispersion import DEFAULT_DISPERSION, DispersionSpec, member_scenario
from benchmarks.executors import ProcessExecutor
from benchmarks.metrics import compute_metrics, crossed_antipode, judge
from benchmarks.ranking import (
    CellSummary,
    cell_verdict,
    find_aliases,
    rank_cells,
    summarise_cell,
    wilson_interval,
)
from benchmarks.requirements import Requirement, default_requirements, pointing_errors
from benchmarks.runner import RunOutcome, run_suite
from benchmarks.scenarios import ProximitySpec, Scenario, get_scenario

SLEW = get_scenario("slew-90").with_duration(60.0)
PAIR = ["geometric-pd-large-angle", "mrp-pd"]


@pytest.fixture(scope="module")
def dispersed():
    return run_suite([SLEW], PAIR, members=3, progress=False, executor="serial")


def _same_outcome(a: RunOutcome, b: RunOutcome) -> None:
    assert a.status == b.status and a.verdict == b.verdict and a.flags == b.flags
    for k, v in a.metrics.items():
        if k in ("controller_time_us", "sim_wall_time_s"):
            continue
        w = b.metrics[k]
        assert (v == w) or (isinstance(v, float) and math.isnan(v) and math.isnan(w)), k
    for k, v in a.series.items():
        np.testing.assert_array_equal(v, b.series[k])


def test_member_zero_is_the_single_run_bit_for_bit(dispersed):
    single = run_suite([SLEW], PAIR, members=1, progress=False, executor="serial")
    for c in PAIR:
        _same_outcome(dispersed.outcome(SLEW.name, c), single.outcome(SLEW.name, c))
        assert dispersed.cell(SLEW.name, c).n == 3
        assert single.cell(SLEW.name, c).n == 1


def test_members_identical_on_serial_and_process_executors(dispersed):
    proc = run_suite([SLEW], PAIR, members=3, progress=False, executor=ProcessExecutor(2))
    key = lambda o: (o.controller, o.member)  # noqa: E731
    a, b = sorted(dispersed.member_outcomes, key=key), sorted(proc.member_outcomes, key=key)
    assert [key(o) for o in a] == [key(o) for o in b] and len(a) == 4
    for x, y in zip(a, b, strict=True):
        _same_outcome(x, y)


def test_members_identical_on_the_dask_executor(dispersed):
    distributed = pytest.importorskip("distributed")
    from benchmarks.executors import DaskExecutor

    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        DaskExecutor(cluster.scheduler_address) as ex,
    ):
        res = run_suite([SLEW], PAIR, members=3, progress=False, executor=ex)
    key = lambda o: (o.controller, o.member)  # noqa: E731
    for x, y in zip(
        sorted(dispersed.member_outcomes, key=key),
        sorted(res.member_outcomes, key=key),
        strict=True,
    ):
        _same_outcome(x, y)


def test_member_draws_depend_on_seed_name_and_index_only():
    d = DispersionSpec(attitude_angle_deg=3.0, rate_deg_s=0.01, inertia_moments=0.05, seed=7)
    m2 = member_scenario(SLEW, 2, d)
    again = member_scenario(SLEW, 2, d)
    assert m2 == again and m2.member == 2 and member_scenario(SLEW, 0, d) is SLEW
    other = member_scenario(dataclasses.replace(SLEW, name="other"), 2, d)
    assert other.initial_rotvec != m2.initial_rotvec
    seed8 = member_scenario(SLEW, 2, dataclasses.replace(d, seed=8))
    assert seed8.initial_rotvec != m2.initial_rotvec
    # the true inertia is a physical rigid body with the nominal kept by the controllers
    J = m2.true_inertia
    lam = np.linalg.eigvalsh(J)
    assert lam.min() > 0 and 2 * lam.max() <= lam.sum()
    assert m2.spacecraft == SLEW.spacecraft and not np.allclose(J, SLEW.true_inertia)
    # members are judged on the nominal scenario's requirements
    assert m2.requirements == default_requirements(SLEW)


def test_wilson_interval_matches_scipy():
    for n in (1, 2, 5, 8, 16, 33):
        for k in range(n + 1):
            ci = binomtest(k, n).proportion_ci(method="wilson")
            lo, hi = wilson_interval(k, n)
            assert lo == pytest.approx(ci.low, abs=1e-12)
            assert hi == pytest.approx(ci.high, abs=1e-12)


def test_cell_verdict_rule():
    assert cell_verdict(8, 8) == "success"
    assert cell_verdict(0, 8) == "failed"
    assert cell_verdict(1, 8) == "failed"  # Wilson upper bound 0.47 < ½
    assert cell_verdict(2, 8) == "degraded"
    assert cell_verdict(7, 8) == "degraded"
    assert cell_verdict(1, 1) == "success" and cell_verdict(0, 1) == "failed"
    assert cell_verdict(8, 8, nominal_error=True) == "error"


def _cell(name: str, k: int, n: int) -> CellSummary:
    return CellSummary("s", name, n, k, wilson_interval(k, n), cell_verdict(k, n), "success")


def test_ranking_shows_overlapping_intervals_as_ties():
    cells = [_cell("a", 8, 8), _cell("b", 7, 8), _cell("c", 0, 8), _cell("d", 1, 8)]
    ranks = {c.controller: r for r, c in rank_cells(cells)}
    assert ranks["a"] == ranks["b"] == 1  # 8/8 and 7/8 overlap: tied
    assert ranks["c"] == 3 and ranks["d"] == 3  # both below a and b, tied with each other


def test_rpe_pde_against_hand_computation():
    # two 10 s windows over [90, 110]: error vectors along x, hand means and deviations
    t = np.arange(90.0, 110.01, 1.0)
    ex = np.where(t < 100.0, 0.01 * (t - 90.0), 0.5)
    e = np.zeros((t.size, 1, 3))
    e[:, 0, 0] = ex
    rpe, pde = pointing_errors(t, e, 10.0, 90.0)
    w0 = ex[t < 100.0]
    w1 = ex[t >= 100.0]
    rpe_hand = max(np.abs(w0 - w0.mean()).max(), np.abs(w1 - w1.mean()).max())
    assert rpe[0] == pytest.approx(rpe_hand, abs=1e-15)
    assert pde[0] == pytest.approx(abs(w1.mean() - w0.mean()), abs=1e-15)
    with pytest.raises(ValueError, match="^window_s"):
        pointing_errors(t, e, 30.0, 90.0)


@dataclasses.dataclass
class _Log:
    t: np.ndarray
    R: np.ndarray
    omega: np.ndarray
    R_d: np.ndarray
    omega_d: np.ndarray
    u: np.ndarray
    actuator: dict = dataclasses.field(default_factory=dict)


def _log_from_angles(angles_deg: np.ndarray, axes: np.ndarray | None = None) -> _Log:
    """A log whose error rotation vector is angle·axis (axis x unless given per sample)."""
    K = angles_deg.size
    axis = np.tile([1.0, 0.0, 0.0], (K, 1)) if axes is None else axes
    rv = np.deg2rad(angles_deg)[:, None] * axis
    R = Rotation.from_rotvec(rv).as_matrix()[:, None]
    t = np.arange(K, dtype=float)
    w = np.gradient(rv, t, axis=0)[:, None]
    I = np.broadcast_to(np.eye(3), (K, 1, 3, 3))
    return _Log(t, R, w, I, np.zeros((K, 1, 3)), np.zeros((K, 1, 3)))


def _flags(log: _Log) -> tuple[str, ...]:
    m = compute_metrics(log, settle_threshold_deg=1.0).as_dict(0)
    sc = Scenario("x", "x", attitude_tolerance_deg=1.0)
    return judge(sc, m)[1]


def test_overshoot_without_unwinding():
    # 90° → through 0 to −30° along the axis (33 % overshoot) → 0: the short way
    a = np.concatenate([np.linspace(90, -30, 60), np.linspace(-30, 0, 30), np.zeros(20)])
    f = _flags(_log_from_angles(a))
    assert "overshoot" in f and "unwound" not in f


def test_unwinding_without_overshoot():
    # 90° the long way: 90 → 180 (crosses the antipode: the vector flips) → 0, no overshoot
    a = np.concatenate([np.linspace(90, 179, 40), -np.linspace(179, 0, 80), np.zeros(20)])
    f = _flags(_log_from_angles(a))
    assert "unwound" in f and "overshoot" not in f


def test_constraint_detour_is_neither_unwinding_nor_overshoot():
    # 120° slew bent around a cone: the axis swings 40° off and back, θ decreases throughout
    K = 120
    th = np.concatenate([np.linspace(120, 0, K - 20), np.zeros(20)])
    phi = np.deg2rad(40.0) * np.sin(np.linspace(0, np.pi, K))
    axes = np.stack([np.cos(phi), np.sin(phi), np.zeros(K)], axis=1)
    log = _log_from_angles(th, axes)
    m = compute_metrics(log, settle_threshold_deg=1.0).as_dict(0)
    assert m["unwinding_ratio"] > 1.0  # longer than the geodesic ...
    f = judge(Scenario("x", "x", attitude_tolerance_deg=1.0), m)[1]
    assert "unwound" not in f and "overshoot" not in f  # ... but neither flag


def test_crossed_antipode_ignores_a_touch_of_pi():
    a = np.concatenate([np.linspace(179.0, 179.99, 10), np.linspace(179.99, 0, 50)])
    rv = np.deg2rad(a)[:, None, None] * np.array([1.0, 0.0, 0.0])
    assert not crossed_antipode(rv)[0]


def test_alias_detection_on_the_three_pd_variants():
    sc = get_scenario("slew-90").with_duration(40.0)
    names = ["geometric-pd-large-angle", "quaternion-pd-continuous", "geometric-pd-trace"]
    res = run_suite([sc], names, progress=False, executor="serial")
    groups = find_aliases([res.outcome(sc.name, c) for c in names])
    assert groups == [("geometric-pd-large-angle", "quaternion-pd-continuous")]
    # suite-wide aliases are shown once in the report's tables and figures, named together
    from benchmarks.ranking_report import dealiased

    view = dealiased(res)
    assert view.controllers == ("geometric-pd-large-angle", "geometric-pd-trace")
    assert view.display_name(names[0]) == f"{names[0]} (= {names[1]})"
    assert len(view.outcomes) == len(res.outcomes)  # the data keep every run


def test_se3_saturation_raises_its_flag_and_dv_is_measured():
    sc = dataclasses.replace(
        get_scenario("proximity-approach").with_duration(60.0),
        proximity=ProximitySpec(max_force=20.0, max_torque=5.0, max_delta_v=10.0),
    )
    res = run_suite([sc], ["se3-tracking"], progress=False, executor="serial")
    o = res.outcome(sc.name, "se3-tracking")
    assert "actuator-saturated" in o.flags
    assert o.metrics["peak_force_N"] <= 20.0 * math.sqrt(3) + 1e-9
    # ΔV = ∫‖F‖dt / m with the delivered force
    assert o.metrics["delta_v_m_s"] == pytest.approx(o.metrics["force_effort_Ns"] / 500.0)
    assert o.metrics["max_range_ratio"] >= 1.0


def test_a_failed_member_never_contributes_a_settling_time():
    req = (Requirement("settling_time_s", 100.0),)
    ok = RunOutcome("s", "c", "ok", metrics={"settling_time_s": 50.0}, member=0)
    never = RunOutcome("s", "c", "ok", metrics={"settling_time_s": float("nan")}, member=1)
    raised = RunOutcome("s", "c", "failed", "SimulationDiverged", member=2)
    cell = summarise_cell(req, [ok, never, raised])
    assert cell.passed == 1 and cell.n == 3
    med, p95, worst = cell.values[req[0].text()]
    assert med == 50.0 and worst == 50.0  # only the settled member has a value
    assert cell.margins[req[0].text()][2] == math.inf  # the unsettled ones: worst margin ∞


def test_requirement_margins_and_bad_input():
    r = Requirement("overshoot_pct", 10.0)
    assert r.margin(5.0) == 0.5 and r.met(10.0) and not r.met(float("nan"))
    lo = Requirement("min_keep_out_margin_deg", 0.0, sense="min")
    assert lo.met(0.5) and not lo.met(-0.1) and math.isnan(lo.margin(0.5))
    with pytest.raises(ValueError, match="^metric"):
        Requirement("nope", 1.0)
    with pytest.raises(ValueError, match="^limit"):
        Requirement("rpe_deg")
    with pytest.raises(ValueError, match="^limit"):
        Requirement("overshoot_pct", -1.0)
    with pytest.raises(ValueError, match="^window_s"):
        Requirement("overshoot_pct", 1.0, window_s=5.0)
    with pytest.raises(ValueError, match="^requirements"):
        Scenario("x", "x", duration=50.0, requirements=(Requirement("rpe_deg", 1.0, window_s=10),))


def test_dispersion_bad_input_names_the_key():
    with pytest.raises(ValueError, match="^rate_deg_s"):
        DispersionSpec(rate_deg_s=-1.0)
    with pytest.raises(TypeError, match="^inertia_moments"):
        DispersionSpec(inertia_moments="big")
    with pytest.raises(ValueError, match="^seed"):
        DispersionSpec(seed=-1)
    with pytest.raises(ValueError, match="^members"):
        run_suite([SLEW], PAIR, members=0, progress=False)
    # a spread the hardware cannot have: a negative second moment of mass for some member
    wide = DispersionSpec(inertia_moments=3.0)
    with pytest.raises(ValueError, match="inertia_moments"):
        run_suite([SLEW], PAIR, members=16, dispersion=wide, progress=False, executor="serial")
    assert DEFAULT_DISPERSION.cmg_h0 == 0.0


def test_scenario_file_round_trip_of_dispersion_and_requirements(tmp_path):
    from benchmarks.scenario_files import ScenarioFileError, load_scenarios, scenario_to_dict

    text = """
[[scenario]]
name = "x"
duration = 200.0
[scenario.initial]
angle_deg = 10.0
axis = [1.0, 0.0, 0.0]
[scenario.dispersion]
attitude_angle_deg = 1.0
inertia_moments = 0.02
seed = 4
[[scenario.requirement]]
metric = "rpe_deg"
limit = 0.01
window_s = 5.0
"""
    p = tmp_path / "s.toml"
    p.write_text(text, encoding="utf-8")
    (sc,) = load_scenarios(p)
    assert sc.dispersion == DispersionSpec(attitude_angle_deg=1.0, inertia_moments=0.02, seed=4)
    assert sc.requirements == (Requirement("rpe_deg", 0.01, window_s=5.0),)
    d = scenario_to_dict(sc)
    assert d["requirement"][0]["metric"] == "rpe_deg" and d["dispersion"]["seed"] == 4
    cases = (
        (text.replace("inertia_moments = 0.02", "inertia_moment = 0.02"), "inertia_moment"),
        (text.replace("inertia_moments = 0.02", "inertia_moments = -0.02"), "inertia_moments"),
        (text.replace("limit = 0.01\n", ""), r"requirement\[0\]"),
        # a 5 s window does not fit in the final 10 % of a 20 s run
        (text.replace("duration = 200.0", "duration = 20.0"), "window_s"),
    )
    for broken, key in cases:
        p.write_text(broken, encoding="utf-8")
        with pytest.raises(ScenarioFileError, match=key):
            load_scenarios(p)


def test_bandwidth_sensitivity_marks_each_pair():
    from benchmarks.runner import bandwidth_sensitivity

    sc = get_scenario("step-5").with_duration(150.0)
    res = run_suite([sc], ["geometric-pd-log"], progress=False, executor="serial")
    out = bandwidth_sensitivity(res, executor="serial", near=None)  # every cell
    d = out.sensitivity[(sc.name, "geometric-pd-log")]
    assert set(d) == {0.9, 1.1} and all(isinstance(v, bool) for v in d.values())
    assert out.outcomes == res.outcomes  # the nominal runs are untouched
    # only the cells near a limit are re-run by default: this one settles well inside 150 s
    # unless its nominal worst margin is within 2× of 1
    from benchmarks.requirements import meets, requirements_of

    reqs = requirements_of(sc)
    vals = meets(reqs, res.outcome(sc.name, "geometric-pd-log").metrics)[1]
    worst = max(r.margin(vals[r.text()]) for r in reqs)
    near = bandwidth_sensitivity(res, executor="serial")
    assert ((sc.name, "geometric-pd-log") in near.sensitivity) == (0.5 <= worst <= 2.0)
    with pytest.raises(ValueError, match="^near"):
        bandwidth_sensitivity(res, near=0.5)


def test_report_has_the_dispersion_section_and_a_separate_cost_table(tmp_path):
    from benchmarks.report import write_report

    sc = get_scenario("slew-90").with_duration(40.0)
    res = run_suite([sc], PAIR, members=2, progress=False, executor="serial")
    md = write_report(res, tmp_path, figures=False).read_text(encoding="utf-8")
    assert "## Verdicts over the dispersion" in md and "Wilson 95 %" in md
    assert "### slew-90 over the dispersion" in md
    assert "### Controller cost per call" in md and "median of 7 blocks" in md
    assert "Controller wall time per control step" not in md  # not in the run cells any more
    import json

    doc = json.loads((tmp_path / "metrics.json").read_text(encoding="utf-8"))
    cell = next(c for c in doc["cells"] if c["controller"] == PAIR[0])
    assert cell["members"] == 2 and len(doc["member_results"]) == 2


def test_cli_rejects_bad_members_and_seed(capsys):
    from benchmarks import cli

    assert cli.main(["run", "--members", "0", "--out", "x"]) == 2
    assert "members: expected an integer >= 1" in capsys.readouterr().err
    assert cli.main(["run", "--dispersion-seed", "-1", "--out", "x"]) == 2
    assert "dispersion-seed" in capsys.readouterr().err


def test_report_helpers_name_a_wrong_argument():
    from benchmarks.controller_cost import controller_cost, cost_section
    from benchmarks.ranking_report import dealiased, dispersion_section, verdict_changes

    for fn in (dispersion_section, dealiased, verdict_changes, cost_section):
        with pytest.raises(TypeError, match="^result"):
            fn("not a result")
    with pytest.raises(TypeError, match="^name"):
        controller_cost(3, SLEW)
    with pytest.raises(ValueError, match="^name"):
        controller_cost("se3-tracking", SLEW)
    with pytest.raises(TypeError, match="^scenario"):
        controller_cost("geometric-pd-log", "slew-90")
    with pytest.raises(TypeError, match="^outcomes"):
        summarise_cell((Requirement("overshoot_pct", 1.0),), "runs")
    with pytest.raises(TypeError, match="^cells"):
        rank_cells([object()])
    with pytest.raises(TypeError, match="^outcomes"):
        find_aliases([object()])
    with pytest.raises(TypeError, match="^scenario"):
        default_requirements("slew-90")
