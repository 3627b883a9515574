"""Where benchmark tasks run: in-process, local processes or a dask.distributed cluster — the
same tasks, the same results.

An executor maps a module-level function over a list of task payloads and returns one entry
per payload, **in payload order**: the function's return value, or a :class:`TaskFailure`
carrying the error text when the task raised or its worker died. Nothing is dropped: the
callers (:mod:`benchmarks.runner`, :mod:`benchmarks.montecarlo`) turn a failure into "failed"
rows of the report. Tasks must be deterministic functions of their payload (seeds travel in the
payload), so the results do not depend on the executor.

- :class:`SerialExecutor`: a loop in this process (tests, debugging, ``--jobs 1``).
- :class:`ProcessExecutor`: :class:`concurrent.futures.ProcessPoolExecutor` (``fork`` start on
  POSIX, so controllers registered at run time are known to the workers).
- :class:`DaskExecutor`: a ``dask.distributed.Client`` connected to ``address`` (``--scheduler
  tcp://host:8786``), or wrapping an existing client / ``LocalCluster``. Payloads are shipped with
  cloudpickle, so they may carry controller factories defined at run time.

The dask executor never relies on a *default* client: every call goes through its own client
(``as_completed(..., loop=client.loop)``), which it closes on every exit path. Before any task is
submitted it checks, within ``timeout`` seconds each, that the scheduler answers (a bad address
or a closed port fails at once), that at least one worker has joined, and that every worker
imports the same ``liecontrol`` version as this process; any of these failing raises
:class:`ExecutorUnavailable` with one line that starts with ``scheduler:``. Each task checks the
version again on the worker that runs it (a worker that joins later is caught too). A worker that
dies mid-task does not lose the task: the scheduler reruns it on another worker (and ``retries``
reruns a task whose transport failed); a task that raises is a :class:`TaskFailure`.
"""

from __future__ import annotations

import asyncio
import contextlib
import multiprocessing
import operator
import os
import socket
import sys
import traceback
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Any

__all__ = [
    "TaskFailure",
    "ExecutorUnavailable",
    "Executor",
    "SerialExecutor",
    "ProcessExecutor",
    "DaskExecutor",
    "make_executor",
    "worker_environment",
]


@dataclass(frozen=True)
class TaskFailure:
    """A task that raised (or whose worker was lost): ``error`` is ``"Type: message [where]"``."""

    error: str


class ExecutorUnavailable(ValueError):
    """The requested executor cannot run tasks (unreachable scheduler, no workers, a worker with
    another package version); the message is one line starting with ``scheduler:``."""


def describe_exception(exc: BaseException) -> str:
    """One-line ``"Type: message (at t=… s) [file:line]"`` text of ``exc`` for reports."""
    text = f"{type(exc).__name__}: {exc}".strip()
    where_t = getattr(exc, "time", None)
    if where_t is not None and "t=" not in text and "t = " not in text:
        with contextlib.suppress(TypeError, ValueError):  # a non-numeric .time: no suffix
            text += f" (at t={float(where_t):.3g} s)"
    tb = traceback.extract_tb(exc.__traceback__)
    if tb:
        text += f" [{tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}]"
    return " ".join(text.split())


def _guarded(fn: Callable[[Any], Any], payload: Any) -> Any:
    try:
        return fn(payload)
    except Exception as exc:  # noqa: BLE001 - a failed task is data for the report
        return TaskFailure(describe_exception(exc))


class Executor:
    """Base class: ``map(fn, payloads, on_done=None, on_result=None) -> list`` (module docstring).

    ``on_done(index)`` is called as each task finishes (progress bars); ``on_result(index,
    value)``, called just before it, receives the task's value (or its :class:`TaskFailure`) —
    what incremental writers need. Executors are context managers; :meth:`close` releases the
    workers/connections they own.
    """

    name = "executor"
    #: how many tasks can run at once (callers split work into at least this many tasks)
    parallelism = 1

    def map(
        self,
        fn: Callable[[Any], Any],
        payloads: Sequence[Any],
        on_done: Callable[[int], None] | None = None,
        on_result: Callable[[int, Any], None] | None = None,
    ) -> list[Any]:
        raise NotImplementedError

    def close(self) -> None:
        """Release resources (default: nothing to release)."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _notify(
    i: int,
    value: Any,
    on_done: Callable[[int], None] | None,
    on_result: Callable[[int, Any], None] | None,
) -> None:
    if on_result is not None:
        on_result(i, value)
    if on_done is not None:
        on_done(i)


class SerialExecutor(Executor):
    """Run every task in this process, in order."""

    name = "serial"

    def map(self, fn, payloads, on_done=None, on_result=None):  # noqa: D102 - see Executor.map
        out = []
        for i, p in enumerate(payloads):
            out.append(_guarded(fn, p))
            _notify(i, out[-1], on_done, on_result)
        return out


class ProcessExecutor(Executor):
    """Local process pool of ``max_workers`` (default: CPU count)."""

    name = "process"

    def __init__(self, max_workers: int | None = None) -> None:
        if max_workers is not None:
            max_workers = _posint_or_raise(max_workers, "max_workers")
        self.max_workers = int(max_workers) if max_workers else _cpu_count()
        self.parallelism = self.max_workers

    def map(self, fn, payloads, on_done=None, on_result=None):  # noqa: D102 - see Executor.map
        payloads = list(payloads)
        out: list[Any] = [None] * len(payloads)
        if not payloads:
            return out
        ctx = multiprocessing.get_context("fork") if sys.platform != "win32" else None
        workers = min(self.max_workers, len(payloads))
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
        try:
            futures = {pool.submit(_guarded, fn, p): i for i, p in enumerate(payloads)}
            for fut in as_completed(futures):
                i = futures[fut]
                try:
                    out[i] = fut.result()
                except Exception as exc:  # noqa: BLE001 - e.g. BrokenProcessPool: keep the row
                    out[i] = TaskFailure(f"worker lost: {describe_exception(exc)}")
                _notify(i, out[i], on_done, on_result)
        finally:
            # an interrupted map (Ctrl-C, an error in a callback) drops the queued tasks instead
            # of running them all before returning
            pool.shutdown(wait=True, cancel_futures=True)
        return out


# --------------------------------------------------------------------------- dask


def _make_probe() -> Callable[[], dict[str, Any]]:
    # defined in a function so that cloudpickle ships it *by value*: the check then also runs
    # on a worker where ``benchmarks`` itself does not import (and reports that)
    def worker_environment() -> dict[str, Any]:
        """What :class:`DaskExecutor` compares between this process and every worker: the
        Python version, the versions of ``liecontrol``, ``numpy`` and ``scipy``, and whether
        the packages the tasks need (``liecontrol``, ``spacecraft``, ``benchmarks``) import
        (``import_error``: the first failure, else ``None``)."""
        import importlib
        import platform

        env: dict[str, Any] = {"python": platform.python_version(), "import_error": None}
        for mod in ("liecontrol", "numpy", "scipy", "spacecraft", "benchmarks"):
            try:
                m = importlib.import_module(mod)
            except Exception as exc:  # noqa: BLE001 - reported, not raised: runs on a worker
                env[mod] = None
                if env["import_error"] is None:
                    env["import_error"] = f"import {mod}: {type(exc).__name__}: {exc}"
            else:
                env[mod] = getattr(m, "__version__", "installed")
        return env

    return worker_environment


worker_environment = _make_probe()


def _version_problems(local: dict[str, Any], workers: dict[str, dict[str, Any]]) -> list[str]:
    """Refusals, one line each: a process (keyed by its description) that cannot import the
    packages, or that runs another ``liecontrol`` version than ``local``."""
    bad = []
    for addr, env in sorted(workers.items()):
        if env.get("import_error"):
            bad.append(f"{addr} cannot run the tasks ({env['import_error']})")
        elif env.get("liecontrol") != local["liecontrol"]:
            bad.append(
                f"{addr} has liecontrol {env.get('liecontrol')}, this process has "
                f"{local['liecontrol']}"
            )
    return bad


def _run_checked(fn: Callable[[Any], Any], payload: Any, version: str) -> Any:
    """The task as run on a worker: refuse (a :class:`TaskFailure`) on a ``liecontrol`` version
    other than the client's — a worker that joined after the up-front check — else run it."""
    try:
        import liecontrol

        have = getattr(liecontrol, "__version__", None)
    except Exception as exc:  # noqa: BLE001 - a worker without the package: a failed task
        return TaskFailure(f"worker cannot import liecontrol: {describe_exception(exc)}")
    if have != version:
        return TaskFailure(
            f"VersionMismatch: this worker has liecontrol {have}, the client has {version}; "
            "install the same version on every worker"
        )
    return _guarded(fn, payload)


async def _identity(address: str, timeout: float) -> dict[str, Any]:
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def _probe_scheduler(address: str, timeout: float) -> None:
    """Fail fast, with one line, before a ``Client`` exists: a malformed address, a closed port
    (a plain TCP connect is refused at once, where dask's own connect retries until its
    timeout) and a peer that does not answer dask's ``identity`` request within ``timeout``."""
    from distributed.comm.addressing import get_address_host_port, parse_address

    def fail(why: str) -> ExecutorUnavailable:
        return ExecutorUnavailable(
            f"scheduler: cannot connect to the dask scheduler at {address!r} ({why}); "
            "no task was run"
        )

    try:
        scheme, _ = parse_address(address)
        host, port = get_address_host_port(address) if scheme == "tcp" else (None, None)
    except (ValueError, TypeError) as exc:
        raise fail(f"{exc}; expected tcp://HOST:PORT") from None
    if host is not None:
        try:
            socket.create_connection((host, port), timeout=timeout).close()
        except OSError as exc:
            raise fail(f"{type(exc).__name__}: {exc.strerror or exc}") from None
    # the identity round trip runs on a private event loop in a private thread: safe from a
    # caller that already has a running loop (a notebook)
    with ThreadPoolExecutor(1) as pool:
        fut = pool.submit(asyncio.run, asyncio.wait_for(_identity(address, timeout), timeout))
        try:
            reply = fut.result()
        except (TimeoutError, asyncio.TimeoutError):
            raise fail(f"no dask answer within {timeout:g} s") from None
        except Exception as exc:  # noqa: BLE001 - OSError, CommClosedError, ValueError ...
            raise fail(f"{type(exc).__name__}: {exc}") from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        raise fail(f"the peer is not a dask scheduler: {str(reply)[:80]!r}")


def _open_client(address: str, timeout: float) -> Any:
    """``distributed.Client(address)``; a constructor that fails is shut down here, so that its
    ``__del__`` does not print a traceback at exit (and does not wait 2 × timeout)."""
    import distributed

    client = distributed.Client.__new__(distributed.Client)
    try:
        client.__init__(address, timeout=timeout, set_as_default=False)
    except Exception as exc:  # noqa: BLE001 - any failure of the connection
        client.status = "closed"  # makes Client.__del__ a no-op
        with contextlib.suppress(Exception):
            client._loop_runner.stop()
        raise ExecutorUnavailable(
            f"scheduler: cannot connect to the dask scheduler at {address!r} within "
            f"{timeout:g} s ({type(exc).__name__}: {exc}); no task was run"
        ) from None
    return client


class DaskExecutor(Executor):
    """Tasks on a dask.distributed cluster (module docstring: checks, retries, failures).

    Args:
        address: scheduler address (``"tcp://host:8786"``), or ``None`` with ``client``.
        client: an existing ``distributed.Client`` (not closed by :meth:`close`).
        timeout: seconds to wait for the connection, and again for the first worker.
        retries: times dask reruns a task whose run raised outside the task's own error
            handling (a task killed with its worker is rerun by the scheduler anyway, up to
            dask's ``distributed.scheduler.allowed-failures``).
        check_versions: refuse workers whose ``liecontrol`` version differs from this
            process's, or which cannot import the packages (:func:`worker_environment`).
    """

    name = "dask"

    def __init__(
        self,
        address: str | None = None,
        *,
        client: Any = None,
        timeout: float = 10.0,
        retries: int = 2,
        check_versions: bool = True,
    ):
        if (address is None) == (client is None):
            raise ValueError("address: give exactly one of a scheduler address or a client")
        if address is not None and not isinstance(address, str):
            raise TypeError(f"address: must be a string, got {type(address).__name__}")
        timeout = _check_timeout(timeout)
        if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
            raise ValueError(f"retries: must be an integer >= 0, got {retries!r}")
        try:
            import distributed  # noqa: F401 - availability check
        except ImportError as exc:  # pragma: no cover - dask is a dev dependency
            raise ExecutorUnavailable(
                "scheduler: dask.distributed is not installed (pip install 'dask[distributed]')"
            ) from exc
        self.timeout = float(timeout)
        self.retries = retries
        self._own = client is None
        self._closed = False
        if client is None:
            _probe_scheduler(address, self.timeout)
            client = _open_client(address, self.timeout)
        self.client = client
        self.address = address or getattr(getattr(client, "scheduler", None), "address", "")
        import liecontrol

        self.version = liecontrol.__version__
        try:
            self._wait_for_workers()
            self.worker_versions: dict[str, dict[str, Any]] = (
                self.check_versions() if check_versions else {}
            )
        except BaseException:
            self.close()
            raise
        try:
            self.parallelism = max(1, int(sum(client.nthreads().values())))
        except Exception:  # noqa: BLE001 - an informational figure only
            self.parallelism = 1

    def _wait_for_workers(self) -> None:
        try:
            self.client.wait_for_workers(1, timeout=self.timeout)
        except (TimeoutError, asyncio.TimeoutError):
            raise ExecutorUnavailable(
                f"scheduler: no dask worker joined the scheduler at {self.address!r} within "
                f"{self.timeout:g} s (--scheduler-timeout); start workers with "
                f"`dask worker {self.address}`; no task was run"
            ) from None

    def check_versions(self) -> dict[str, dict[str, Any]]:
        """Each worker's :func:`worker_environment` (by address); raises
        :class:`ExecutorUnavailable` when a worker or the scheduler (which unpickles the tasks)
        cannot import the packages or has another ``liecontrol`` version. A worker with another
        numpy/scipy/Python version is a warning (results may differ in the last bits)."""
        local = worker_environment()
        # a hung worker must not hang the check; a worker's first imports take seconds
        wait = max(30.0, 3 * self.timeout)
        try:
            workers = self.client.run(worker_environment, callback_timeout=wait)
            # the scheduler unpickles the submitted tasks too, so it needs the packages as well
            sched = self.client.run_on_scheduler(worker_environment, callback_timeout=wait)
        except Exception as exc:  # noqa: BLE001 - e.g. a worker that cannot unpickle
            raise ExecutorUnavailable(
                f"scheduler: the version check on the cluster at {self.address!r} failed "
                f"({type(exc).__name__}: {exc}); no task was run"
            ) from None
        bad = _version_problems(local, {"the scheduler": sched}) + _version_problems(
            local, {f"worker {a}": env for a, env in workers.items()}
        )
        if bad:
            more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
            raise ExecutorUnavailable(
                f"scheduler: {bad[0]}{more}; every worker needs the same liecontrol version "
                "installed; no task was run"
            )
        for addr, env in sorted(workers.items()):
            diff = [k for k in ("python", "numpy", "scipy") if env.get(k) != local[k]]
            if diff:
                warnings.warn(
                    f"worker {addr} differs from this process in "
                    + ", ".join(f"{k} {env.get(k)} vs {local[k]}" for k in diff)
                    + ": results may differ from a local run in the last bits",
                    RuntimeWarning,
                    stacklevel=2,
                )
        return workers

    def map(self, fn, payloads, on_done=None, on_result=None):  # noqa: D102 - see Executor.map
        from distributed import as_completed as dask_completed

        payloads = list(payloads)
        out: list[Any] = [None] * len(payloads)
        if not payloads:
            return out
        client = self.client
        futures = [
            client.submit(_run_checked, fn, p, self.version, pure=False, retries=self.retries)
            for p in payloads
        ]
        index = {f.key: i for i, f in enumerate(futures)}
        pending = dict(zip(index, futures, strict=True))
        try:
            # the executor's own loop: no dependence on a default client (set_as_default=False)
            for fut in dask_completed(futures, loop=client.loop):
                i = index[fut.key]
                try:
                    out[i] = fut.result()
                except Exception as exc:  # noqa: BLE001 - KilledWorker, a cancelled task ...
                    out[i] = TaskFailure(f"dask task failed: {describe_exception(exc)}")
                pending.pop(fut.key, None)
                fut.release()  # the result is here: free the cluster's copy
                _notify(i, out[i], on_done, on_result)
        finally:
            if pending:  # interrupted: do not leave the rest running on the cluster
                with contextlib.suppress(Exception):
                    client.cancel(list(pending.values()))
        return out

    def close(self) -> None:
        """Close the client this executor opened (idempotent; an existing client is kept)."""
        if self._closed:
            return
        self._closed = True
        if self._own:
            with contextlib.suppress(Exception):  # closing must not mask the original error
                self.client.close(timeout=max(2.0, self.timeout))


def _check_timeout(v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < float("inf"):
        raise ValueError(f"timeout: must be a finite number > 0, got {v!r}")
    return float(v)


def _posint_or_raise(v: Any, name: str) -> int:
    try:
        n = operator.index(v)  # int and numpy integers; not floats, strings or bools
    except TypeError:
        n = None
    if n is None or isinstance(v, bool) or n < 1:
        raise ValueError(f"{name}: must be a positive integer, got {v!r}")
    return n


def _cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        return os.cpu_count() or 1


def make_executor(
    kind: str | None = None,
    *,
    jobs: int | None = None,
    scheduler: str | None = None,
    timeout: float = 10.0,
) -> Executor:
    """``"serial"``, ``"process"`` or ``"dask"``; default: dask if ``scheduler`` is given, else
    serial for ``jobs == 1`` and a process pool otherwise. ``timeout``: dask connection [s]."""
    if jobs is not None:
        jobs = _posint_or_raise(jobs, "jobs")
    timeout = _check_timeout(timeout)
    if scheduler is not None and not isinstance(scheduler, str):
        raise TypeError(f"scheduler: must be an address string, got {type(scheduler).__name__}")
    if kind is None:
        kind = "dask" if scheduler else ("serial" if jobs == 1 else "process")
    if scheduler is not None and kind != "dask":
        raise ValueError(
            f"scheduler: a scheduler address is only used by the dask executor, not {kind!r}"
        )
    if kind == "serial":
        return SerialExecutor()
    if kind == "process":
        return ProcessExecutor(jobs)
    if kind == "dask":
        if not scheduler:
            raise ValueError("scheduler: the dask executor needs a scheduler address")
        return DaskExecutor(scheduler, timeout=timeout)
    raise ValueError(f"kind: unknown executor {kind!r}; valid: serial, process, dask")
