"""Shared set-up of the closed-loop performance scripts (``perf_closed_loop``, ``perf_plant``).

Call :func:`pin_blas_threads` before numpy is imported: the BLAS/OpenMP runtimes read their
thread counts once, at load, and one thread per process makes the CPU-time figures per-core
throughput. This module therefore imports numpy only inside its functions.
"""

from __future__ import annotations

import os
import sys
from typing import Any

__all__ = [
    "THREAD_VARS",
    "pin_blas_threads",
    "thread_settings",
    "sgcmg_bus_inertia",
    "sgcmg_bus_pd_loop",
]

#: thread-count variables of the BLAS/OpenMP runtimes numpy may use
THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
_numpy_preloaded = False


def pin_blas_threads() -> None:
    """Set each of :data:`THREAD_VARS` to 1 unless the environment already sets it."""
    global _numpy_preloaded
    _numpy_preloaded = "numpy" in sys.modules
    for name in THREAD_VARS:
        os.environ.setdefault(name, "1")


def thread_settings() -> str:
    """The thread-count variables in effect, e.g. ``OPENBLAS_NUM_THREADS=1 ...``."""
    s = " ".join(f"{v}={os.environ.get(v, 'unset')}" for v in THREAD_VARS)
    if _numpy_preloaded:
        s += " (numpy was imported before the pinning: the runtime may not have applied them)"
    return s


def sgcmg_bus_inertia() -> Any:
    """The SGCMG-bus inertia [kg·m²]."""
    import numpy as np

    return np.array(
        [[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]]
    )


def sgcmg_bus_pd_loop(batch: int, rng: Any) -> tuple[Any, Any]:
    """``(controller, reference)`` of the benchmark loop: the large-angle geometric PD on the
    SGCMG-bus inertia (ω_n = 0.03 rad/s, ζ = 0.9) and a 90° target for one spacecraft or random
    targets (rotation vectors ~ N(0, 0.8²)) for a batch."""
    import numpy as np

    from liecontrol.control import ConstantAttitude
    from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
    from liecontrol.lie import so3

    J = sgcmg_bus_inertia()
    k_R, k_W = gains_from_bandwidth(J, 0.03, 0.9, error="large_angle", matrix=True)
    ctrl = GeometricPD(J, k_R, k_W, error="large_angle")
    if batch == 1:
        R_d = so3.exp(np.deg2rad(90.0) * np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0))
    else:
        R_d = so3.exp(rng.normal(size=(batch, 3)) * 0.8)
    return ctrl, ConstantAttitude(R_d)


def best_of(run: Any, routes: tuple[str, ...], repeat: int) -> dict[str, float]:
    """``{route: min of run(route)}`` over ``repeat`` rounds that alternate the routes, after
    one warm-up call each (compilation, cache loading): the perf scripts' timing protocol."""
    for r in routes:
        run(r)
    best = dict.fromkeys(routes, float("inf"))
    for _ in range(repeat):
        for r in routes:
            best[r] = min(best[r], run(r))
    return best
