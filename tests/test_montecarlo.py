"""Monte Carlo sweep: sampling, executor independence, batched = per sample, the journal of
finished chunks (interrupt and resume). The real-cluster tests are in test_dask_cluster.py."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks import cli
from benchmarks.controllers import register, unregister
from benchmarks.executors import (
    DaskExecutor,
    ExecutorUnavailable,
    ProcessExecutor,
    SerialExecutor,
    TaskFailure,
    make_executor,
)
from benchmarks.montecarlo import (
    MonteCarloConfig,
    MonteCarloInterrupted,
    chunk_samples,
    read_journal,
    run_montecarlo,
    write_montecarlo_report,
)
from benchmarks.scenarios import SGCMG_SPACECRAFT, scale_principal_moments
from liecontrol.control import AttitudeController

CFG = MonteCarloConfig(n_samples=6, chunk_size=3, duration=20.0, seed=7)
NAMES = ("geometric-pd-large-angle", "mrp-pd")


def _key(records):
    return sorted(
        ((r["controller"], r["sample"]), r["final_R"], r["final_omega"], r["settling_time_s"])
        for r in records
    )


def _same(a, b):
    ka, kb = _key(a.records), _key(b.records)
    assert [k[0] for k in ka] == [k[0] for k in kb]
    for x, y in zip(ka, kb, strict=True):
        assert x[1] == y[1] and x[2] == y[2]  # bit-identical final states


def test_samples_are_seeded_haar_and_physical():
    cfg = MonteCarloConfig(n_samples=4000, chunk_size=4000, seed=1, max_rate_deg_s=0.5)
    s = chunk_samples(cfg, 0)
    # Haar: E[R] = 0 (each entry has variance 1/3, so the mean of 4000 is within ~0.03)
    assert np.abs(s.R0.mean(axis=0)).max() < 0.04
    angles = np.linalg.norm(
        np.stack([np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)) for R in s.R0[:2000]]), axis=0
    )
    assert angles.max() > np.deg2rad(170)
    rates = np.rad2deg(np.linalg.norm(s.omega0, axis=-1))
    assert rates.max() <= 0.5 and rates.min() >= 0
    # one inertia error per sample: U(1 ± 0.2) on each principal moment, physical, axes kept
    assert s.inertia_scale.shape == (4000, 3) and s.J.shape == (4000, 3, 3)
    assert np.all(np.abs(s.inertia_scale - 1) <= 0.2)
    # (not centred: draws breaking the triangle inequality are rejected, so the mean shifts)
    assert np.all(s.inertia_scale.min(axis=0) < 0.81) and np.all(s.inertia_scale.max(axis=0) > 1.19)
    lam = np.linalg.eigvalsh(s.J)
    assert np.all(lam[:, 0] + lam[:, 1] >= lam[:, 2])
    lam0, V = np.linalg.eigh(SGCMG_SPACECRAFT.J)
    np.testing.assert_allclose(
        np.einsum("ji,bjk,ki->bi", V, s.J, V), lam0 * s.inertia_scale, rtol=1e-12
    )
    for k in (0, 1, 3999):  # the scenarios' single-matrix route
        Jk = scale_principal_moments(SGCMG_SPACECRAFT.J, s.inertia_scale[k])
        np.testing.assert_allclose(s.J[k], Jk, rtol=0, atol=1e-12 * np.abs(Jk).max())
    again = chunk_samples(cfg, 0)
    np.testing.assert_array_equal(again.R0, s.R0)
    np.testing.assert_array_equal(again.J, s.J)
    c2 = MonteCarloConfig(n_samples=10, chunk_size=4)
    assert c2.n_chunks == 3 and len(chunk_samples(c2, 2).sample) == 2
    assert not np.array_equal(chunk_samples(c2, 0).R0[:2], chunk_samples(c2, 1).R0[:2])


@pytest.fixture(scope="module")
def serial():
    return run_montecarlo(NAMES, CFG, executor="serial", progress=False)


def test_serial_result_and_report(serial, tmp_path):
    assert len(serial.records) == 12 and serial.n_failed == 0
    for c in NAMES:
        assert 0.0 <= serial.success_rate(c) <= 1.0
        assert np.all(np.isfinite(serial.values(c, "final_error_deg")))
    path = write_montecarlo_report(serial, tmp_path, figures=True)
    md = path.read_text(encoding="utf-8")
    assert "| `mrp-pd` |" in md and "success" in md
    for f in ("boxplots.png", "histogram_success.png"):
        assert (tmp_path / "figures" / f).read_bytes()[:4] == b"\x89PNG"
    doc = json.loads((tmp_path / "montecarlo.json").read_text(), parse_constant=lambda c: 1 / 0)
    assert len(doc["records"]) == 12


def test_batched_path_equals_per_spacecraft_path(serial):
    single = run_montecarlo(NAMES, CFG, executor="serial", batched=False, progress=False)
    assert {r["batched"] for r in single.records} == {False}
    assert {r["batched"] for r in serial.records} == {True}
    a = {(r["controller"], r["sample"]): r for r in serial.records}
    for r in single.records:
        b = a[(r["controller"], r["sample"])]
        np.testing.assert_allclose(b["final_R"], r["final_R"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(b["final_omega"], r["final_omega"], rtol=0, atol=1e-12)
        for k in ("final_error_deg", "peak_rate_deg_s", "effort_Nms", "unwinding_ratio"):
            assert b[k] == pytest.approx(r[k], rel=1e-12, abs=1e-12)


def test_draws_and_results_do_not_depend_on_chunking(serial):
    """Every sample is seeded on its own: its draws are bitwise the same for any chunk_size,
    and so are the runs up to the batched/single round-off (1e-12)."""
    import dataclasses

    whole = chunk_samples(dataclasses.replace(CFG, chunk_size=6), 0)
    for size in (1, 2, 4):
        cfg = dataclasses.replace(CFG, chunk_size=size)
        parts = [chunk_samples(cfg, i) for i in range(cfg.n_chunks)]
        for name in ("inertia_scale", "J", "R0", "omega0", "sample"):
            got = np.concatenate([getattr(p, name) for p in parts])
            np.testing.assert_array_equal(got, getattr(whole, name))
    assert len({tuple(x) for x in whole.inertia_scale}) == 6  # one inertia error per sample
    other = run_montecarlo(
        NAMES, dataclasses.replace(CFG, chunk_size=4), executor="serial", progress=False
    )
    a = {(r["controller"], r["sample"]): r for r in serial.records}
    assert {r["chunk"] for r in other.records} == {0, 1} and len(other.records) == 12
    for r in other.records:
        b = a[(r["controller"], r["sample"])]
        assert r["inertia_scale"] == b["inertia_scale"]
        np.testing.assert_allclose(r["final_R"], b["final_R"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(r["final_omega"], b["final_omega"], rtol=0, atol=1e-12)


def test_process_and_dask_executors_give_identical_results(serial):
    distributed = pytest.importorskip("distributed")
    proc = run_montecarlo(NAMES, CFG, executor=ProcessExecutor(2), progress=False)
    _same(serial, proc)
    assert proc.executor == "process"
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=2, processes=True, dashboard_address=":0"
    ) as cluster:
        # by address, as the CLI does: the executor's client is not the default client, and
        # nothing may fall back on one (the "No clients found" failure of as_completed)
        with DaskExecutor(cluster.scheduler_address) as ex:
            with pytest.raises(ValueError, match="No clients found"):
                distributed.default_client()
            res = run_montecarlo(NAMES, CFG, executor=ex, progress=False)
        assert ex.client.status == "closed"
        with distributed.Client(cluster) as client:  # an existing client is used, not closed
            with DaskExecutor(client=client) as ex2:
                again = run_montecarlo(NAMES, CFG, executor=ex2, progress=False)
            assert client.status == "running"
    _same(serial, res)
    _same(serial, again)
    assert res.executor == "dask"


class _StopAfter(SerialExecutor):
    """Serial, but Ctrl-C (KeyboardInterrupt) after ``n`` finished tasks; counts the tasks."""

    def __init__(self, n=None):
        self.n, self.ran = n, 0

    def map(self, fn, payloads, on_done=None, on_result=None):
        def counted(p):
            if self.n is not None and self.ran == self.n:
                raise KeyboardInterrupt
            self.ran += 1
            return fn(p)

        return super().map(counted, payloads, on_done, on_result)


def _no_timing(records):
    skip = {"sim_wall_time_s", "steps_per_s", "controller_time_us"}
    return sorted(
        json.dumps({k: v for k, v in r.items() if k not in skip}, sort_keys=True) for r in records
    )


def test_journal_keeps_an_interrupted_sweep_and_resume_finishes_it(serial, tmp_path):
    journal = tmp_path / "out" / "montecarlo.chunks.jsonl"
    with pytest.raises(MonteCarloInterrupted) as info:
        run_montecarlo(NAMES, CFG, executor=_StopAfter(3), progress=False, journal=journal)
    assert isinstance(info.value, KeyboardInterrupt)
    assert (info.value.kept, info.value.total) == (3, 4)
    header, entries = read_journal(journal)
    assert header["config"] == repr(CFG) and len(entries) == 3
    # a crash in the middle of a write leaves a cut-short last line: skipped, then dropped
    with open(journal, "a", encoding="utf-8") as fh:
        fh.write('{"controller": "mrp-pd", "chu')
    assert len(read_journal(journal)[1]) == 3
    rest = _StopAfter()
    res = run_montecarlo(NAMES, CFG, executor=rest, progress=False, journal=journal, resume=True)
    assert rest.ran == 1  # only the chunk not in the journal
    # the same records as the uninterrupted sweep (JSON keeps floats exactly, NaN included)
    assert _no_timing(res.records) == _no_timing(serial.records)
    assert len(read_journal(journal)[1]) == 4
    # a resume with another configuration is refused; without resume the journal restarts
    other = MonteCarloConfig(n_samples=6, chunk_size=3, duration=20.0, seed=8)
    with pytest.raises(ValueError, match="^resume: .* was written for another config"):
        run_montecarlo(NAMES, other, executor="serial", progress=False, journal=journal,
                       resume=True)  # fmt: skip
    assert len(read_journal(journal)[1]) == 4  # untouched by the refusal
    again = _StopAfter()
    run_montecarlo(NAMES, CFG, executor=again, progress=False, journal=journal)
    assert again.ran == 4 and len(read_journal(journal)[1]) == 4


def test_journal_errors_name_the_problem(tmp_path):
    with pytest.raises(ValueError, match="^resume: needs a journal"):
        run_montecarlo(NAMES, CFG, executor="serial", progress=False, resume=True)
    with pytest.raises(ValueError, match="^journal: no such file"):
        read_journal(tmp_path / "nope.jsonl")
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"format": "something else"}\n', encoding="utf-8")
    with pytest.raises(ValueError, match="^journal: .* is not a Monte Carlo journal"):
        read_journal(bad)
    bad.write_text("", encoding="utf-8")
    with pytest.raises(ValueError, match="^journal: .* is empty"):
        read_journal(bad)
    run_montecarlo(("mrp-pd",), MonteCarloConfig(n_samples=1, chunk_size=1, duration=1.0),
                   executor="serial", progress=False, journal=bad)  # fmt: skip
    lines = bad.read_text(encoding="utf-8").splitlines()
    bad.write_text("\n".join([lines[0], "{not json", lines[1]]) + "\n", encoding="utf-8")
    with pytest.raises(ValueError, match="^journal: .*: line 2 is not valid JSON"):
        read_journal(bad)


def test_executors_report_each_result_as_it_finishes():
    seen = []
    for ex in (SerialExecutor(), ProcessExecutor(2)):
        seen.clear()
        out = ex.map(abs, [-1, -2, "x"], on_done=lambda i: seen.append(("done", i)),
                     on_result=lambda i, v: seen.append(("result", i, v)))  # fmt: skip
        assert out[:2] == [1, 2] and isinstance(out[2], TaskFailure)
        assert "TypeError" in out[2].error
        for i in range(3):  # the value first, then the progress tick
            assert seen.index(("result", i, out[i])) + 1 == seen.index(("done", i))


def test_executor_arguments_are_validated():
    with pytest.raises(ValueError, match="^jobs: must be a positive integer"):
        make_executor(jobs=0)
    with pytest.raises(ValueError, match="^jobs: must be a positive integer"):
        make_executor(jobs=1.5)
    assert make_executor(jobs=np.int64(2)).parallelism == 2
    with pytest.raises(ValueError, match="^timeout: must be a finite number > 0"):
        DaskExecutor("tcp://127.0.0.1:9", timeout=float("nan"))
    with pytest.raises(ValueError, match="^retries: must be an integer >= 0"):
        DaskExecutor("tcp://127.0.0.1:9", retries=-1)
    with pytest.raises(TypeError, match="^address: must be a string"):
        DaskExecutor(8786)


class _Boom(AttitudeController):
    def reset(self, t0, batch_size):
        pass

    def command(self, t, state, reference):
        if t > 1.0:
            raise FloatingPointError("boom: deliberately broken controller")
        return np.zeros((state.R.shape[0], 3))


def test_failed_runs_are_reported_not_dropped(tmp_path):
    register("boom", lambda ctx: _Boom(), description="broken on purpose")
    try:
        cfg = MonteCarloConfig(n_samples=4, chunk_size=2, duration=3.0)
        res = run_montecarlo(("boom", "geometric-pd-log"), cfg, executor="serial", progress=False)
    finally:
        unregister("boom")
    bad = res.of("boom")
    assert len(bad) == 4 and all(r["status"] == "failed" for r in bad)
    assert "boom: deliberately broken" in bad[0]["error"]
    assert res.success_rate("boom") == 0.0 and res.n_failed == 4
    assert all(r["status"] == "ok" for r in res.of("geometric-pd-log"))
    md = write_montecarlo_report(res, tmp_path, figures=False).read_text(encoding="utf-8")
    assert "## Errors (runs that raised)" in md and "`boom` (4 samples)" in md


def test_unreachable_scheduler_is_a_clear_error(tmp_path, capsys):
    pytest.importorskip("distributed")
    with pytest.raises(ExecutorUnavailable, match="^scheduler: cannot connect to the dask"):
        DaskExecutor("tcp://127.0.0.1:9", timeout=1.0)
    out = tmp_path / "mc"
    code = cli.main(
        [
            "run",
            "--suite",
            "montecarlo",
            "--scheduler",
            "tcp://127.0.0.1:9",
            "--out",
            str(out),
            "--scheduler-timeout",
            "1",
        ]  # fmt: skip
    )
    assert code == 2 and not out.exists()
    assert "cannot connect to the dask scheduler" in capsys.readouterr().err


def test_config_validation():
    with pytest.raises(ValueError, match="^n_samples"):
        MonteCarloConfig(n_samples=0)
    with pytest.raises(ValueError, match="^inertia_error"):
        MonteCarloConfig(inertia_error=1.0)
    with pytest.raises(ValueError, match="^log_period"):
        MonteCarloConfig(log_period=0.15)
    with pytest.raises(ValueError, match="^chunk: must be in"):
        chunk_samples(CFG, 5)
    with pytest.raises(ValueError, match="^name: unknown controller 'nope'; valid"):
        run_montecarlo(("nope",), CFG, progress=False)
    with pytest.raises(ValueError, match="^controllers: 'se3-tracking' does not apply"):
        run_montecarlo(("se3-tracking",), CFG, progress=False)
    assert MonteCarloConfig().spacecraft == SGCMG_SPACECRAFT
