"""Unwinding / large-angle module (SPEC §0 item 3, §8.1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.runner import RunOutcome
from benchmarks.unwinding import (
    UnwindingConfig,
    run_unwinding,
    unwinding_scenarios,
    verdict,
    write_unwinding_report,
)

GEOMETRIC = ("geometric-pd-log", "geometric-pd-large-angle", "geometric-pd-trace")


@pytest.fixture(scope="module")
def pair_result():
    # the q/−q pair only, coarse steps: the long way from −q at 90° is 270° (ratio 3)
    cfg = UnwindingConfig(
        sweep_angles_deg=(), n_random=0, duration=250.0, dt=0.5, control_period=0.5
    )
    names = ("quaternion-pd-continuous", "quaternion-pd-switched", "mrp-pd") + GEOMETRIC
    return run_unwinding(names, cfg, executor="serial", progress=False)


def test_q_minus_q_pair_flags_continuous_quaternion_pd_only(pair_result):
    r = pair_result
    q_v, mq_v = r.pair_verdicts("quaternion-pd-continuous")
    assert mq_v == "unwinds" and q_v != "unwinds"
    minus = r.record("minus-q-90", "quaternion-pd-continuous")
    # the long way round from −q at 90°: about (360° − 90°)/90° = 3 within 250 s
    assert 2.5 < minus.unwinding_ratio < 3.2
    for c in GEOMETRIC + ("quaternion-pd-switched", "mrp-pd"):
        assert not r.unwinds(c), c
        for case in ("q-90", "minus-q-90"):
            rec = r.record(case, c)
            assert rec.unwinding_ratio < 1.1 and rec.verdict in ("converges", "not converged")
    # geometric laws cannot tell q from −q: identical runs
    for c in GEOMETRIC:
        assert r.record("q-90", c).final_error_deg == r.record("minus-q-90", c).final_error_deg


def test_report_files(pair_result, tmp_path):
    md = write_unwinding_report(pair_result, tmp_path, figures=True).read_text(encoding="utf-8")
    assert "| `quaternion-pd-continuous` |" in md and "unwinds" in md
    assert (tmp_path / "figures" / "pair_unwinding_ratio.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "unwinding.csv").read_text().count("\n") == len(pair_result.records) + 1


def test_cases_and_sweep_figure(tmp_path):
    cfg = UnwindingConfig(
        sweep_angles_deg=(150.0, 179.9), n_random=2, duration=6.0, dt=0.5, control_period=0.5
    )
    scs = unwinding_scenarios(cfg)
    assert [s.name for s in scs] == [
        "q-90", "minus-q-90", "angle-150", "angle-179.9", "random-0", "random-1"
    ]  # fmt: skip
    assert scs[1].quaternion_sign == -1 and np.array_equal(scs[0].R0, scs[1].R0)
    assert scs[3].initial_error_deg == pytest.approx(179.9)
    again = unwinding_scenarios(cfg)
    assert [s.initial_rotvec for s in again] == [s.initial_rotvec for s in scs]  # seeded
    res = run_unwinding(("geometric-pd-log",), cfg, executor="serial", progress=False)
    assert {r.kind for r in res.records} == {"pair", "sweep", "random"}
    write_unwinding_report(res, tmp_path, figures=True)
    for f in ("settling_vs_angle.png", "random_starts.png"):
        assert (tmp_path / "figures" / f).stat().st_size > 1000


def _outcome(**m):
    base = {"unwinding_ratio": 1.0, "command_reversals": 0.0, "final_error_deg": 0.01}
    base.update(m)
    return RunOutcome("c", "x", "ok", None, base)


def test_verdict_rules():
    cfg = UnwindingConfig()
    assert verdict(_outcome(), cfg) == "converges"
    assert verdict(_outcome(unwound=True, unwinding_ratio=1.6), cfg) == "unwinds"
    # a long path alone (overshoot, a detour) is not unwinding: the path must cross θ = π
    assert verdict(_outcome(unwinding_ratio=1.6), cfg) == "converges"
    assert verdict(_outcome(command_reversals=12.0), cfg) == "chatters"
    # chattering inflates the path length: it takes precedence over unwinding
    assert verdict(_outcome(command_reversals=12.0, unwound=True), cfg) == "chatters"
    assert verdict(_outcome(final_error_deg=3.0), cfg) == "not converged"
    # moving away is not unwinding (an untuned law ending 132° off from a 60° start)
    away = _outcome(initial_error_deg=60.0, final_error_deg=132.0, unwinding_ratio=4.0)
    assert verdict(away, cfg) == "diverges"
    assert verdict(_outcome(unwinding_ratio=math.nan, final_error_deg=0.0), cfg) == "converges"
    assert verdict(RunOutcome("c", "x", "failed", "boom"), cfg) == "error"


def test_bad_config_and_controllers():
    with pytest.raises(ValueError, match="^pair_angle_deg"):
        UnwindingConfig(pair_angle_deg=180.0)
    with pytest.raises(ValueError, match="^sweep_angles_deg"):
        UnwindingConfig(sweep_angles_deg=(0.0,))
    with pytest.raises(ValueError, match="^n_random"):
        UnwindingConfig(n_random=-1)
    with pytest.raises(ValueError, match="^name: unknown controller 'nope'; valid controllers"):
        run_unwinding(("nope",), UnwindingConfig(), progress=False)
    with pytest.raises(ValueError, match="^controllers: 'se3-tracking' is not an attitude"):
        run_unwinding(("se3-tracking",), UnwindingConfig(), progress=False)
