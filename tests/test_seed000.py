"""Seed 000 reproduction (SPEC §6.1, §8.3) on the shortened horizon: every published-claim row
of the table passes, the files and figures are written."""

from __future__ import annotations

import csv
import json

import pytest

from benchmarks.reproductions import seed000


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("seed000")
    code = seed000.main(out, quick=True)
    with open(out / "table.csv", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    return code, out, {r["claim"]: r for r in rows}


def test_exit_code_and_outputs(quick_run):
    code, out, rows = quick_run
    assert code == 0
    for name in (
        "table.md",
        "results.json",
        "eso_errors.png",
        "eso_estimates.png",
        "attitude_gimbals.png",
    ):
        assert (out / name).stat().st_size > 0, name
    payload = json.loads((out / "results.json").read_text())
    assert payload["duration"] == 60.0
    assert {r["result"] for r in rows.values()} <= {"PASS", "INFO"}


@pytest.mark.parametrize(
    "claim",
    [
        "parameters as SPEC §6.1",
        "both ESOs: high steady accuracy (attitude estimate)",
        "both ESOs: high steady accuracy (pointing)",
        "composite ESO converges faster",
        "composite ESO: smaller error (transient)",
        "composite ESO: smaller error (steady, with noise)",
        "attitude and rate stay small (composite)",
        "gimbal rates < 0.02 rad/s (composite)",
        "singularity measure stays large",
    ],
)
def test_published_claim_passes(quick_run, claim):
    _, _, rows = quick_run
    assert rows[claim]["result"] == "PASS", rows[claim]["measured"]


def test_summary_numbers_are_consistent(quick_run):
    _, out, _ = quick_run
    s = json.loads((out / "results.json").read_text())["summary"]
    comp, sens = s["0.5"], s["0.0"]
    assert comp["t_conv_f_s"] < sens["t_conv_f_s"]
    assert comp["peak_gimbal_rate"] < 0.02
    assert comp["peak_gimbal_rate"] < sens["peak_gimbal_rate"]  # the gyro lowers the noise
    assert comp["min_singularity"] > 0.5
