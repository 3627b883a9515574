"""Where benchmark tasks run (SPEC §8.4): in-process, local processes or a dask.distributed
cluster — the same tasks, the same results.

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
  cloudpickle, so they may carry controller factories defined at run time. An unreachable
  scheduler raises :class:`ExecutorUnavailable` before any task is submitted.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
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
]


@dataclass(frozen=True)
class TaskFailure:
    """A task that raised (or whose worker was lost): ``error`` is ``"Type: message [where]"``."""

    error: str


class ExecutorUnavailable(ValueError):
    """The requested executor cannot run tasks (e.g. the dask scheduler is unreachable)."""


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
    """Base class: ``map(fn, payloads, on_done=None) -> list`` (see the module docstring).

    ``on_done(index)`` is called as each task finishes (progress bars). Executors are context
    managers; :meth:`close` releases workers/connections they own.
    """

    name = "executor"
    #: how many tasks can run at once (callers split work into at least this many tasks)
    parallelism = 1

    def map(
        self,
        fn: Callable[[Any], Any],
        payloads: Sequence[Any],
        on_done: Callable[[int], None] | None = None,
    ) -> list[Any]:
        raise NotImplementedError

    def close(self) -> None:
        """Release resources (default: nothing to release)."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class SerialExecutor(Executor):
    """Run every task in this process, in order."""

    name = "serial"

    def map(self, fn, payloads, on_done=None):  # noqa: D102 - see Executor.map
        out = []
        for i, p in enumerate(payloads):
            out.append(_guarded(fn, p))
            if on_done is not None:
                on_done(i)
        return out


class ProcessExecutor(Executor):
    """Local process pool of ``max_workers`` (default: CPU count)."""

    name = "process"

    def __init__(self, max_workers: int | None = None) -> None:
        if max_workers is not None and (
            isinstance(max_workers, bool) or int(max_workers) != max_workers or max_workers < 1
        ):
            raise ValueError(f"max_workers: must be a positive integer, got {max_workers!r}")
        self.max_workers = int(max_workers) if max_workers else _cpu_count()
        self.parallelism = self.max_workers

    def map(self, fn, payloads, on_done=None):  # noqa: D102 - see Executor.map
        payloads = list(payloads)
        out: list[Any] = [None] * len(payloads)
        if not payloads:
            return out
        ctx = multiprocessing.get_context("fork") if sys.platform != "win32" else None
        workers = min(self.max_workers, len(payloads))
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
            futures = {pool.submit(_guarded, fn, p): i for i, p in enumerate(payloads)}
            for fut in as_completed(futures):
                i = futures[fut]
                try:
                    out[i] = fut.result()
                except Exception as exc:  # noqa: BLE001 - e.g. BrokenProcessPool: keep the row
                    out[i] = TaskFailure(f"worker lost: {describe_exception(exc)}")
                if on_done is not None:
                    on_done(i)
        return out


class DaskExecutor(Executor):
    """Tasks on a dask.distributed cluster.

    Args:
        address: scheduler address (``"tcp://host:8786"``), or ``None`` with ``client``.
        client: an existing ``distributed.Client`` (not closed by :meth:`close`).
        timeout: seconds to wait for the connection.
    """

    name = "dask"

    def __init__(self, address: str | None = None, *, client: Any = None, timeout: float = 10.0):
        if (address is None) == (client is None):
            raise ValueError("address: give exactly one of a scheduler address or a client")
        try:
            import distributed
        except ImportError as exc:  # pragma: no cover - dask is a dev dependency
            raise ExecutorUnavailable(
                "scheduler: dask.distributed is not installed (pip install 'dask[distributed]')"
            ) from exc
        self._own = client is None
        if client is None:
            try:
                client = distributed.Client(address, timeout=timeout, set_as_default=False)
            except Exception as exc:  # noqa: BLE001 - OSError, TimeoutError, ValueError ...
                raise ExecutorUnavailable(
                    f"scheduler: cannot connect to the dask scheduler at {address!r} within "
                    f"{timeout:g} s ({type(exc).__name__}: {exc}); no task was run"
                ) from None
        self.client = client
        self.address = address or getattr(getattr(client, "scheduler", None), "address", "")
        try:
            self.parallelism = max(1, int(sum(client.nthreads().values())))
        except Exception:  # noqa: BLE001 - an informational figure only
            self.parallelism = 1

    def map(self, fn, payloads, on_done=None):  # noqa: D102 - see Executor.map
        from distributed import as_completed as dask_completed

        payloads = list(payloads)
        out: list[Any] = [None] * len(payloads)
        if not payloads:
            return out
        futures = [self.client.submit(_guarded, fn, p, pure=False) for p in payloads]
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in dask_completed(futures):
            i = index[fut.key]
            try:
                out[i] = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker or a cancelled task
                out[i] = TaskFailure(f"dask task failed: {describe_exception(exc)}")
            if on_done is not None:
                on_done(i)
        return out

    def close(self) -> None:
        if self._own:
            self.client.close()


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
    if kind is None:
        kind = "dask" if scheduler else ("serial" if jobs == 1 else "process")
    if kind == "serial":
        return SerialExecutor()
    if kind == "process":
        return ProcessExecutor(jobs)
    if kind == "dask":
        if not scheduler:
            raise ValueError("scheduler: the dask executor needs a scheduler address")
        return DaskExecutor(scheduler, timeout=timeout)
    raise ValueError(f"kind: unknown executor {kind!r}; valid: serial, process, dask")
