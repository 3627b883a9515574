"""The results file: every time history of a suite / Monte Carlo run in one Parquet file with its
provenance — bit-for-bit round trips, units for every column and metric, the CLI's --histories,
bad input."""

from __future__ import annotations

import dataclasses
import json
import math
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

pytest.importorskip("pyarrow")

import liecontrol  # noqa: E402
from benchmarks import cli  # noqa: E402
from benchmarks.controllers import DEFAULT_GAIN_RULE, GainRule  # noqa: E402
from benchmarks.metrics import RUN_UNITS, UNITS, Metrics  # noqa: E402
from benchmarks.montecarlo import MonteCarloConfig, read_journal, run_montecarlo  # noqa: E402
from benchmarks.report import write_json  # noqa: E402
from benchmarks.results_file import (  # noqa: E402
    FORMAT,
    HISTORY_UNITS,
    history_unit,
    load_histories,
    provenance,
    write_histories,
)
from benchmarks.runner import run_suite  # noqa: E402
from benchmarks.scenarios import get_scenario  # noqa: E402

PAIR = ("geometric-pd-log", "mrp-pd")


@pytest.fixture(scope="module")
def suite():
    """2 controllers × 1 short SGCMG slew, with a non-default tuning spec."""
    sc = get_scenario("slew-30").with_duration(20.0)
    return run_suite(
        [sc], PAIR, suite="h", executor="serial", progress=False, keep_histories=True,
        gain_rule=GainRule(omega_n=0.05, zeta=0.8),
    )  # fmt: skip


@pytest.fixture(scope="module")
def mixed():
    """An SE(3) pair, a wheel plant, sensors with an estimator, and pairs that do not apply."""
    scs = [
        get_scenario("proximity-approach").with_duration(10.0),
        get_scenario("wheels-pyramid-slew-30").with_duration(10.0),
        get_scenario("estimator-mekf-slew-30").with_duration(4.0),  # sensors + estimate logs
    ]
    return run_suite(
        scs, ("geometric-pd-log", "se3-tracking"), executor="serial", progress=False,
        keep_histories=True,
    )  # fmt: skip


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _same_metrics(a: dict, b: dict) -> bool:
    if a.keys() != b.keys():
        return False
    for k in a:
        x, y = a[k], b[k]
        if isinstance(x, float) and math.isnan(x):
            if not (isinstance(y, float) and math.isnan(y)):
                return False
        elif x != y:
            return False
    return True


def test_suite_round_trips_bit_for_bit_with_provenance(suite, tmp_path):
    path = write_histories(suite, tmp_path / "h.parquet")
    h = load_histories(path)
    assert h.format == FORMAT
    assert [(r.scenario, r.controller) for r in h.runs] == [
        (o.scenario, o.controller) for o in suite.outcomes
    ]
    for o, r in zip(suite.outcomes, h.runs, strict=True):
        assert o.status == "ok" and o.histories
        assert o.histories.keys() == r.arrays.keys()
        for k, a in o.histories.items():
            assert _same_bits(a, r.arrays[k]), k
        assert r.arrays["R"].shape[1:] == (3, 3) and r.arrays["actuator.delta"].shape[1:] == (4,)
        assert r.info["status"] == "ok" and r.info["verdict"] == o.verdict
        assert r.info["flags"] == list(o.flags)
        assert _same_metrics(r.info["metrics"], o.metrics)
        assert all(r.info["metric_units"][k] for k in o.metrics)
    p = h.provenance
    assert p["kind"] == "suite" and p["suite"] == "h"
    assert p["versions"]["liecontrol"] == liecontrol.__version__
    assert {"numpy", "scipy", "pyarrow", "python"} <= p["versions"].keys()
    assert p["gain_rule"] == {"omega_n": 0.05, "zeta": 0.8}
    assert list(p["controllers"]) == list(PAIR)
    for c in PAIR:
        assert p["controllers"][c]["description"] == suite.descriptions[c]
    sc = suite.scenarios[0]
    assert p["scenarios"][0]["name"] == sc.name
    assert p["scenarios"][0]["duration"] == sc.duration
    # every scenario parameter is there, in plain JSON form
    assert p["scenarios"][0].keys() == {f.name for f in dataclasses.fields(sc)}
    # what was written is what the provenance function produces (bar the clock)
    fresh = json.loads(json.dumps(provenance(suite)))
    assert {k: v for k, v in fresh.items() if k != "created_utc"} == {
        k: v for k, v in p.items() if k != "created_utc"
    }


def test_suite_columns_against_independent_routes(suite, tmp_path):
    """The derived error angle against scipy; the flat table (pandas) against the arrays."""
    pd = pytest.importorskip("pandas")
    path = write_histories(suite, tmp_path / "h.parquet")
    o = suite.outcomes[0]
    H = o.histories
    E = np.swapaxes(H["R_d"], -1, -2) @ H["R"]
    np.testing.assert_allclose(
        H["attitude_error"], Rotation.from_matrix(E).magnitude(), rtol=0, atol=1e-12
    )
    df = pd.read_parquet(path)
    one = df[(df["scenario"] == o.scenario) & (df["controller"] == o.controller)]
    assert one["run"].unique().tolist() == [0]
    assert one["sample"].isna().all()
    np.testing.assert_array_equal(one["t"].to_numpy(), H["t"])
    np.testing.assert_array_equal(one["R[0][2]"].to_numpy(), H["R"][:, 0, 2])
    np.testing.assert_array_equal(one["actuator.delta[3]"].to_numpy(), H["actuator.delta"][:, 3])
    # the logged samples are the simulator's (once per control period), not the decimated series
    assert H["t"].shape[0] == round(20.0 / 0.2) + 1
    np.testing.assert_allclose(np.diff(H["t"]), 0.2, rtol=1e-12)


def test_histories_travel_back_from_worker_processes(suite):
    """The flag reaches the workers (the task's pickled form) and their histories are the
    serial run's (to round-off: two workers split the serial batch of two into batches of one,
    another arithmetic route)."""
    sc = get_scenario("slew-30").with_duration(20.0)
    par = run_suite(
        [sc], PAIR, executor="process", jobs=2, progress=False, keep_histories=True,
        gain_rule=GainRule(omega_n=0.05, zeta=0.8),
    )  # fmt: skip
    for a, b in zip(suite.outcomes, par.outcomes, strict=True):
        assert a.histories.keys() == b.histories.keys()
        for k, x in a.histories.items():
            assert x.dtype == b.histories[k].dtype and x.shape == b.histories[k].shape
            np.testing.assert_allclose(b.histories[k], x, rtol=1e-9, atol=1e-12, err_msg=k)


def test_mixed_plants_and_runs_without_samples(mixed, tmp_path):
    h = load_histories(write_histories(mixed, tmp_path / "m.parquet"))
    for o, r in zip(mixed.outcomes, h.runs, strict=True):
        assert o.histories.keys() == r.arrays.keys()
        for k, a in o.histories.items():
            assert _same_bits(a, r.arrays[k]), k
        if o.status == "n/a":
            assert r.arrays == {} and r.info["n_samples"] == 0
    pose = h.run("proximity-approach", "se3-tracking").arrays
    assert pose["g"].shape[1:] == (4, 4) and pose["wrench"].shape[1:] == (6,)
    assert pose["saturated"].dtype == bool
    wheels = h.run("wheels-pyramid-slew-30", "geometric-pd-log").arrays
    assert wheels["actuator.saturated"].dtype == bool
    assert wheels["actuator.wheel_speed"].shape[1:] == (4,)
    est = h.run("estimator-mekf-slew-30", "geometric-pd-log").arrays
    assert est["sensors.star_tracker"].shape[1:] == (4,) and est["estimate.R"].shape[1:] == (3, 3)
    with pytest.raises(ValueError, match=r"^scenario/controller/sample: 2 runs match"):
        h.run(scenario="proximity-approach")


def test_every_history_column_and_metric_has_a_unit(suite, mixed, tmp_path):
    for res in (suite, mixed):
        h = load_histories(write_histories(res, tmp_path / "u.parquet"))
        names = {n for r in h.runs for n in r.arrays}
        assert names == set(h.units)
        assert all(h.units[n] for n in names)
        write_json(res, tmp_path / "metrics.json")
        units = json.loads((tmp_path / "metrics.json").read_text())["units"]
        assert units and all(units.values()), units
    assert {f.name for f in dataclasses.fields(Metrics)} <= UNITS.keys()
    assert all(UNITS.values()) and all(RUN_UNITS.values()) and all(HISTORY_UNITS.values())
    assert history_unit("R[0][2]") == history_unit("R")
    assert history_unit("disturbance_components.gravity_gradient") == "N·m"
    with pytest.raises(TypeError, match="^name: expected a str"):
        history_unit(3.0)
    with pytest.raises(ValueError, match="^name: no unit"):
        history_unit("actuator.not_a_log")


def test_montecarlo_round_trips_bit_for_bit_with_provenance(tmp_path):
    cfg = MonteCarloConfig(n_samples=3, chunk_size=2, seed=11, duration=10.0)
    journal = tmp_path / "j.jsonl"
    res = run_montecarlo(
        ("geometric-pd-log",), cfg, executor="serial", progress=False, journal=journal,
        keep_histories=True,
    )  # fmt: skip
    assert sorted(res.histories) == [("geometric-pd-log", k) for k in range(3)]
    assert all("histories" not in r for r in res.records)
    assert all("histories" not in r for r in read_journal(journal)[1])  # journal stays JSON
    h = load_histories(write_histories(res, tmp_path / "mc.parquet"))
    assert [r.info["sample"] for r in h.runs] == [0, 1, 2]
    for r, rec in zip(h.runs, res.records, strict=True):
        a = res.histories[(rec["controller"], rec["sample"])]
        assert a.keys() == r.arrays.keys()
        for k in a:
            assert _same_bits(a[k], r.arrays[k]), k
        # the record's final state is the history's last sample
        assert r.arrays["R"][-1].ravel().tolist() == rec["final_R"]
        assert r.info["final_error_deg"] == rec["final_error_deg"]
    p = h.provenance
    assert p["kind"] == "montecarlo" and p["config"]["seed"] == 11
    assert p["config"]["n_samples"] == 3 and p["config"]["duration"] == 10.0
    assert p["gain_rule"] == dataclasses.asdict(DEFAULT_GAIN_RULE)
    assert "spawn_key" in p["seeding"]
    # the per-sample route gives the same histories as the batched one (to round-off)
    single = run_montecarlo(
        ("geometric-pd-log",), cfg, executor="serial", progress=False, batched=False,
        keep_histories=True,
    )  # fmt: skip
    for key, a in res.histories.items():
        np.testing.assert_allclose(single.histories[key]["R"], a["R"], rtol=0, atol=1e-9)


def test_cli_run_writes_the_histories_and_the_report_names_them(tmp_path, capsys):
    out = tmp_path / "rep"
    rc = cli.main(
        ["run", "--scenarios", "slew-30", "--controllers", ",".join(PAIR), "--t-final", "10",
         "--out", str(out), "--executor", "serial", "--no-progress", "--no-figures",
         "--histories"]
    )  # fmt: skip
    assert rc == 0
    h = load_histories(out / "histories.parquet")
    assert [r.controller for r in h.runs] == list(PAIR)
    assert h.runs[0].arrays["t"][-1] == pytest.approx(10.0)
    assert "histories.parquet" in (out / "report.md").read_text(encoding="utf-8")
    rc = cli.main(
        ["run", "--suite", "unwinding", "--out", str(tmp_path / "u"), "--histories"]
    )  # fmt: skip
    assert rc == 2
    assert "histories:" in capsys.readouterr().err


# --------------------------------------------------------------------------- bad input


def test_bad_input(suite, tmp_path):
    with pytest.raises(ValueError, match=r"^format: unknown results format 'netcdf'"):
        write_histories(suite, tmp_path / "x.nc", format="netcdf")
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    with pytest.raises(ValueError, match=r"^path: folder .* does not exist"):
        write_histories(suite, blocker / "h.parquet")
    with pytest.raises(ValueError, match=r"^path: .* is a folder"):
        write_histories(suite, tmp_path)
    with pytest.raises(TypeError, match=r"^path: "):
        write_histories(suite, 3)
    with pytest.raises(TypeError, match=r"^result: expected a SuiteResult"):
        write_histories({"runs": []}, tmp_path / "h.parquet")
    bare = run_suite(
        [get_scenario("slew-30").with_duration(2.0)], PAIR[:1], executor="serial", progress=False
    )
    with pytest.raises(ValueError, match=r"^result: has no time histories"):
        write_histories(bare, tmp_path / "h.parquet")
    assert not (tmp_path / "h.parquet").exists()
    with pytest.raises(TypeError, match=r"^keep_histories: "):
        run_suite([get_scenario("slew-30")], PAIR[:1], keep_histories="yes", progress=False)
    with pytest.raises(ValueError, match=r"^keep_histories: chunks resumed"):
        run_montecarlo(
            PAIR[:1], MonteCarloConfig(n_samples=1, chunk_size=1, duration=1.0),
            journal=tmp_path / "j.jsonl", resume=True, keep_histories=True, progress=False,
        )  # fmt: skip


def test_bad_files_to_load(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    with pytest.raises(ValueError, match=r"^path: no file"):
        load_histories(tmp_path / "missing.parquet")
    junk = tmp_path / "junk.parquet"
    junk.write_bytes(b"not parquet at all")
    with pytest.raises(ValueError, match=r"^path: .* is not a Parquet file"):
        load_histories(junk)
    plain = tmp_path / "plain.parquet"
    pq.write_table(pa.table({"run": [0], "t": [0.0]}), plain)
    with pytest.raises(ValueError, match=r"^path: .* is not a liecontrol histories file"):
        load_histories(plain)


def test_a_file_missing_a_column_is_refused(suite, tmp_path):
    """A table edited by another tool that lost a component: an error, not np.empty garbage."""
    import pyarrow.parquet as pq

    path = write_histories(suite, tmp_path / "h.parquet")
    table = pq.read_table(path)
    pq.write_table(table.drop_columns(["R[1][1]"]), path)
    with pytest.raises(ValueError, match=r"^path: .*'R' of shape \(3, 3\).* 8 of its 9"):
        load_histories(path)


def test_missing_pyarrow_is_a_clear_error(suite, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(ImportError, match=r"liecontrol\[results\]"):
        write_histories(suite, tmp_path / "h.parquet")
