"""The Monte Carlo sweep on a real dask cluster: a ``dask scheduler`` and ``dask worker``
processes on 127.0.0.1 (free ports, one thread each, no dashboard), driven through the CLI's
``--scheduler`` path exactly as a user with several machines would.

Shows: results equal the serial executor's bit for bit; a worker killed mid-sweep loses
nothing; an interrupted sweep keeps its finished chunks and ``--resume`` completes it; a
scheduler without workers, a worker with another ``liecontrol`` version, a malformed or closed
address each give one clear line and exit code 2. Every process started here is killed (its
whole process group) in a ``finally``, also when a test fails.
"""

from __future__ import annotations

import json
import math
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import pytest

distributed = pytest.importorskip("distributed")

from benchmarks import cli  # noqa: E402 - after the importorskip
from benchmarks.executors import (  # noqa: E402
    DaskExecutor,
    ExecutorUnavailable,
    TaskFailure,
    _run_checked,
    worker_environment,
)
from benchmarks.montecarlo import MonteCarloConfig, read_journal, run_montecarlo  # noqa: E402

NAMES = ("geometric-pd-large-angle", "mrp-pd")
SAMPLES, CHUNK, T_FINAL, SEED = 8, 2, 20.0, 5
CFG = MonteCarloConfig(n_samples=SAMPLES, chunk_size=CHUNK, duration=T_FINAL, seed=SEED)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class _Processes:
    """Subprocesses in their own sessions (process groups), killed group-wise: a ``dask
    worker`` is a nanny plus its worker process, and both must go."""

    def __init__(self, logs: Path) -> None:
        self.logs = logs
        self.procs: dict[str, subprocess.Popen] = {}

    def start(self, name: str, argv: list[str]) -> subprocess.Popen:
        log = open(self.logs / f"{name}.log", "wb")  # noqa: SIM115 - closed with the process
        p = subprocess.Popen(
            argv, stdout=log, stderr=subprocess.STDOUT, start_new_session=True, cwd=self.logs
        )
        log.close()  # the child holds its own descriptor
        self.procs[name] = p
        return p

    def kill(self, name: str) -> None:
        p = self.procs.pop(name, None)
        if p is None:
            return
        if p.poll() is None:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        p.wait(timeout=30)

    def kill_all(self) -> None:
        for name in list(self.procs):
            self.kill(name)


def _scheduler_argv(port: int) -> list[str]:
    return [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
            "--port", str(port), "--no-dashboard"]  # fmt: skip


def _worker_argv(address: str, name: str, logs: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "distributed.cli.dask_worker", address, "--name", name,
            "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1",
            "--local-directory", str(logs), *extra]  # fmt: skip


def _wait_for(
    predicate, timeout: float = 60.0, what: str = "condition", poll: float = 0.05
) -> None:
    t0 = time.monotonic()
    while not predicate():
        if time.monotonic() - t0 > timeout:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(poll)


def _workers_by_name(client) -> dict[str, str]:
    return {w["name"]: a for a, w in client.scheduler_info(n_workers=-1)["workers"].items()}


@dataclass
class Cluster:
    address: str
    procs: _Processes
    client: object  # a watcher client of the tests (not the one under test)
    logs: Path

    def n_workers(self) -> int:
        return len(self.client.scheduler_info(n_workers=-1)["workers"])

    def other_clients(self) -> set[str]:
        ids = self.client.run_on_scheduler(lambda dask_scheduler: list(dask_scheduler.clients))
        return set(ids) - {"fire-and-forget", self.client.id}

    def n_tasks(self) -> int:
        return self.client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    logs = tmp_path_factory.mktemp("dask")
    procs = _Processes(logs)
    client = None
    try:
        port = _free_port()
        address = f"tcp://127.0.0.1:{port}"
        procs.start("scheduler", _scheduler_argv(port))
        for name in ("w1", "w2"):
            procs.start(name, _worker_argv(address, name, logs))
        _wait_for(lambda: _can_connect(port), what="the scheduler to listen")
        client = distributed.Client(address, timeout=30, set_as_default=False)
        client.wait_for_workers(2, timeout=90)
        yield Cluster(address, procs, client, logs)
    finally:
        if client is not None:
            client.close()
        procs.kill_all()


def _can_connect(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1).close()
    except OSError:
        return False
    return True


@pytest.fixture(scope="module")
def serial():
    return run_montecarlo(NAMES, CFG, executor="serial", progress=False)


def _cli_args(address: str, out: Path, *extra: str) -> list[str]:
    return ["run", "--suite", "montecarlo", "--controllers", ",".join(NAMES),
            "--samples", str(SAMPLES), "--chunk-size", str(CHUNK), "--t-final", str(T_FINAL),
            "--seed", str(SEED), "--scheduler", address, "--out", str(out), "--no-progress",
            "--no-figures", *extra]  # fmt: skip


def _records_by_sample(records) -> dict:
    return {(r["controller"], r["sample"]): r for r in records}


_TIMING = {"sim_wall_time_s", "steps_per_s", "controller_time_us"}


def _assert_bitwise_equal(records, reference) -> None:
    """Same (controller, sample) set; every simulated value identical (timings excluded)."""
    got, ref = _records_by_sample(records), _records_by_sample(reference)
    assert got.keys() == ref.keys()
    for key, r in ref.items():
        g = got[key]
        assert g["status"] == "ok" and r["status"] == "ok", (key, g.get("error"))
        for field in r.keys() - _TIMING:
            a, b = g[field], r[field]
            if isinstance(b, float) and not math.isfinite(b):  # e.g. never settled: the
                # report's JSON stores a non-finite float as null
                assert a is None or a == b or (a != a and b != b), (key, field, a, b)
            else:
                assert a == b, (key, field, a, b)


def test_cli_on_a_real_cluster_equals_serial_bit_for_bit(cluster, serial, tmp_path):
    out = tmp_path / "mc"
    assert cli.main(_cli_args(cluster.address, out)) == 0
    doc = json.loads((out / "montecarlo.json").read_text(encoding="utf-8"))
    assert doc["executor"] == "dask" and len(doc["records"]) == SAMPLES * len(NAMES)
    _assert_bitwise_equal(doc["records"], serial.records)
    # the journal has every chunk once, and the same records
    header, entries = read_journal(out / "montecarlo.chunks.jsonl")
    assert header["liecontrol"] and len(entries) == CFG.n_chunks * len(NAMES)
    assert len({(e["controller"], e["chunk"]) for e in entries}) == len(entries)
    _assert_bitwise_equal([r for e in entries for r in e["records"]], serial.records)
    # the CLI's client is gone and left no task behind
    _wait_for(lambda: not cluster.other_clients() and cluster.n_tasks() == 0, 30, "cleanup")


def test_a_worker_killed_mid_sweep_loses_nothing(cluster, tmp_path):
    """A third worker is killed (nanny and worker, SIGKILL) while it runs a chunk: the
    scheduler reruns its chunks on the others and every sample is in the result."""
    cfg = MonteCarloConfig(n_samples=12, chunk_size=1, duration=90.0, seed=11)
    reference = run_montecarlo(("mrp-pd",), cfg, executor="serial", progress=False)
    cluster.procs.start("doomed", _worker_argv(cluster.address, "doomed", cluster.logs))
    _wait_for(lambda: "doomed" in _workers_by_name(cluster.client), 90, "the third worker")
    doomed = _workers_by_name(cluster.client)["doomed"]
    in_flight: list = []

    def kill_when_busy() -> None:
        # poll the scheduler until the doomed worker is running a chunk, then kill it
        t0 = time.monotonic()
        while time.monotonic() - t0 < 60:
            busy = cluster.client.processing(workers=[doomed]).get(doomed, [])
            if busy:
                in_flight.extend(busy)
                cluster.procs.kill("doomed")
                return
            time.sleep(0.02)

    killer = threading.Thread(target=kill_when_busy, daemon=True)
    try:
        with DaskExecutor(cluster.address, timeout=30) as ex:
            killer.start()
            res = run_montecarlo(("mrp-pd",), cfg, executor=ex, progress=False)
        killer.join(timeout=60)
    finally:
        cluster.procs.kill("doomed")
    assert in_flight, "the worker was never seen running a chunk"
    assert len(res.records) == 12 and res.n_failed == 0
    _assert_bitwise_equal(res.records, reference.records)
    _wait_for(lambda: cluster.n_workers() == 2, 30, "the dead worker's removal")


def test_interrupted_sweep_keeps_its_chunks_and_resume_finishes(cluster, serial, tmp_path):
    """Ctrl-C (SIGINT) to a running ``python -m benchmarks`` keeps the finished chunks in the
    journal (exit 130, one line); ``--resume`` runs only the others and the result equals an
    uninterrupted run's."""
    out = tmp_path / "mc"
    journal = out / "montecarlo.chunks.jsonl"
    # one chunk per sample, ~0.1-0.3 s each: time to interrupt after two of the twelve
    cfg = MonteCarloConfig(n_samples=12, chunk_size=1, duration=90.0, seed=SEED)
    args = _cli_args(cluster.address, out)
    for opt, value in (("--controllers", "mrp-pd"), ("--samples", "12"), ("--chunk-size", "1"),
                       ("--t-final", "90")):  # fmt: skip
        args[args.index(opt) + 1] = value
    p = subprocess.Popen(
        [sys.executable, "-m", "benchmarks", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # a child of a shell without job control inherits SIGINT ignored: restore the default
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        _wait_for(
            lambda: journal.exists() and len(journal.read_text().splitlines()) >= 3,
            120,
            "two finished chunks",
            poll=0.01,  # interrupt well before the other ten are done
        )
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 130, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith("interrupted: ") and "--resume" in err
    _, kept = read_journal(journal)
    total = cfg.n_chunks
    assert 2 <= len(kept) < total
    assert f"interrupted: {len(kept)} of {total} chunks" in err
    # the interrupted client cancelled what it had left and is gone
    _wait_for(lambda: not cluster.other_clients() and cluster.n_tasks() == 0, 30, "cleanup")

    assert cli.main([*args, "--resume"]) == 0
    _, entries = read_journal(journal)
    assert len(entries) == total
    assert len({(e["controller"], e["chunk"]) for e in entries}) == total  # none run twice
    doc = json.loads((out / "montecarlo.json").read_text(encoding="utf-8"))
    # the kept chunks came from the journal (their wall times too), not from a rerun
    walls = {(r["controller"], r["sample"]): r["sim_wall_time_s"] for r in doc["records"]}
    for e in kept:
        for r in e["records"]:
            assert walls[(r["controller"], r["sample"])] == r["sim_wall_time_s"]
    reference = run_montecarlo(("mrp-pd",), cfg, executor="serial", progress=False)
    _assert_bitwise_equal(doc["records"], reference.records)


@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
def test_worker_with_another_liecontrol_version_is_refused(cluster, tmp_path, capsys):
    """A worker whose ``liecontrol.__version__`` differs (set by a ``--preload`` script) makes
    the CLI refuse the cluster before any task runs: one line, exit 2, nothing written."""
    fake = tmp_path / "fake_version.py"
    fake.write_text("import liecontrol\nliecontrol.__version__ = '0.0.0+fake'\n", "utf-8")
    argv = _worker_argv(cluster.address, "fake", cluster.logs, "--preload", str(fake))
    cluster.procs.start("fake", argv)
    try:
        _wait_for(lambda: "fake" in _workers_by_name(cluster.client), 90, "the fake worker")
        fake_addr = _workers_by_name(cluster.client)["fake"]
        out = tmp_path / "mc"
        assert cli.main(_cli_args(cluster.address, out)) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1, err
        assert err.startswith(f"error: scheduler: worker {fake_addr} has liecontrol 0.0.0+fake")
        assert "same liecontrol version" in err and "no task was run" in err
        assert not out.exists()
    finally:
        cluster.procs.kill("fake")
    _wait_for(lambda: not cluster.other_clients() and cluster.n_workers() == 2, 30, "cleanup")


def test_task_on_a_worker_with_another_version_is_a_failed_task(monkeypatch):
    """The per-task check (a worker that joined after the up-front check)."""
    import liecontrol

    assert _run_checked(abs, -3, liecontrol.__version__) == 3
    monkeypatch.setattr(liecontrol, "__version__", "0.0.0+fake")
    got = _run_checked(abs, -3, "0.1.0")
    assert isinstance(got, TaskFailure)
    assert got.error.startswith("VersionMismatch: this worker has liecontrol 0.0.0+fake")


def test_version_check_rules():
    """What the up-front check refuses (another liecontrol, a process that cannot import the
    packages, on a worker or on the scheduler) and what it only warns about (numpy & co.)."""
    local = worker_environment()
    assert local["liecontrol"] == __import__("liecontrol").__version__
    assert local["import_error"] is None and local["benchmarks"] is not None

    def check(workers, scheduler=local):
        fake = SimpleNamespace(
            address="tcp://h:1",
            timeout=10.0,
            client=SimpleNamespace(
                run=lambda fn, **kw: workers, run_on_scheduler=lambda fn, **kw: scheduler
            ),
        )
        return DaskExecutor.check_versions(fake)

    assert check({"tcp://a:1": local, "tcp://b:1": dict(local)}).keys() == {
        "tcp://a:1",
        "tcp://b:1",
    }
    old = {**local, "liecontrol": "0.0.1"}
    refused = r"^scheduler: worker tcp://b:1 has liecontrol 0\.0\.1, this process has .*"
    with pytest.raises(ExecutorUnavailable, match=refused + r" \(and 1 more\); every worker"):
        check({"tcp://a:1": local, "tcp://b:1": old, "tcp://c:1": old})
    with pytest.raises(ExecutorUnavailable, match="^scheduler: the scheduler has liecontrol 0.0.1"):
        check({"tcp://a:1": local}, scheduler=old)
    broken = {**local, "import_error": "import spacecraft: ModuleNotFoundError: nope"}
    cannot = r"^scheduler: worker tcp://a:1 cannot run the tasks \(import spacecraft: "
    with pytest.raises(ExecutorUnavailable, match=cannot + "ModuleNotFoundError: nope"):
        check({"tcp://a:1": broken})
    with pytest.warns(RuntimeWarning, match="worker tcp://a:1 differs from this process in numpy"):
        check({"tcp://a:1": {**local, "numpy": "1.0.0"}})


@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
def test_scheduler_without_workers_is_one_clear_line(tmp_path, capsys):
    procs = _Processes(tmp_path)
    try:
        port = _free_port()
        procs.start("lonely", _scheduler_argv(port))
        _wait_for(lambda: _can_connect(port), 60, "the scheduler to listen")
        address = f"tcp://127.0.0.1:{port}"
        out = tmp_path / "mc"
        code = cli.main(_cli_args(address, out, "--scheduler-timeout", "1"))
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1, err
        head = f"error: scheduler: no dask worker joined the scheduler at '{address}'"
        assert err.startswith(head)
        assert "--scheduler-timeout" in err and f"dask worker {address}" in err
        assert not out.exists()
        with distributed.Client(address, timeout=30, set_as_default=False) as watcher:
            clients = watcher.run_on_scheduler(lambda dask_scheduler: list(dask_scheduler.clients))
            assert set(clients) == {"fire-and-forget", watcher.id}  # the CLI's client is gone
    finally:
        procs.kill_all()


@pytest.mark.parametrize("address", ["not-a-url", "closed-port"])
def test_bad_address_is_one_line_exit_2_and_no_client_traceback(address, tmp_path):
    """In a fresh interpreter, so that a ``Client.__del__`` traceback at exit would show."""
    if address == "closed-port":
        address = f"tcp://127.0.0.1:{_free_port()}"
    out = tmp_path / "mc"
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "benchmarks",
            "run",
            "--suite",
            "montecarlo",
            "--scheduler",
            address,
            "--out",
            str(out),
        ],  # fmt: skip
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 2, p.stderr
    assert p.stderr.count("\n") == 1, p.stderr  # no "Exception ignored in Client.__del__"
    head = f"error: scheduler: cannot connect to the dask scheduler at '{address}'"
    assert p.stderr.startswith(head)
    assert "no task was run" in p.stderr and not out.exists()
