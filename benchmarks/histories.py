"""One spacecraft's full logged histories as arrays: the unit of data of the results file.

:func:`history_arrays` is what :func:`benchmarks.runner.run_suite` and
:func:`benchmarks.montecarlo.run_montecarlo` keep per run (``keep_histories=True``) and what
:mod:`benchmarks.results_file` writes; it depends on no other module of the suite, so the
engine (runner, Monte Carlo) and the writer do not import each other.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["history_arrays"]


def _per_spacecraft(a: Any, b: int, K: int) -> np.ndarray:
    """``a[:, b]`` of a ``(K, B, ...)`` log as a contiguous copy (a broadcast log expanded)."""
    a = np.asarray(a)
    return np.ascontiguousarray(a[:, b]).copy() if a.shape[0] == K else np.array(a[:, b])


def history_arrays(result: Any, b: int = 0) -> dict[str, np.ndarray]:
    """The full logged histories of spacecraft ``b`` of a simulation log, ``name → (K, ...)``
    arrays (copies; the batch axis removed), for the results file.

    ``result``: a :class:`spacecraft.simulator.SimulationResult` (``t``, ``R``, ``omega``,
    ``R_d``, ``omega_d``, ``u_cmd``, ``u``, ``disturbance``, the ``actuator.*``,
    ``disturbance_components.*``, ``modes.*``, ``sensors.*`` and ``estimate.*`` logs, and the
    derived geodesic ``attitude_error`` θ = ‖log(R_dᵀR)‖ [rad]) or a
    :class:`spacecraft.se3_plant.PoseSimulationResult` (``t``, ``g``, ``xi``, ``g_d``,
    ``xi_d``, ``wrench_cmd``, ``wrench``, ``saturated``, ``attitude_error``,
    ``position_error``, ``log_error``). Controller diagnostics are not included (module
    docstring).
    """
    if not (hasattr(result, "t") and (hasattr(result, "R") or hasattr(result, "g"))):
        raise TypeError(
            "result: expected a SimulationResult or PoseSimulationResult, got "
            f"{type(result).__name__}"
        )
    B = int(np.shape(result.g if hasattr(result, "g") else result.R)[1])
    if isinstance(b, (bool, np.bool_)) or not isinstance(b, (int, np.integer)):
        raise TypeError(f"b: expected an integer batch index, got {b!r}")
    if not 0 <= b < B:
        raise ValueError(f"b: index {b} out of range for a batch of {B}")
    b = int(b)
    t = np.array(result.t, dtype=np.float64)
    K = t.shape[0]
    out: dict[str, np.ndarray] = {"t": t}
    if hasattr(result, "g"):  # SE(3) pose log
        for name in (
            "g",
            "xi",
            "g_d",
            "xi_d",
            "wrench_cmd",
            "wrench",
            "saturated",
            "attitude_error",
            "position_error",
            "log_error",
        ):
            out[name] = _per_spacecraft(getattr(result, name), b, K)
        return out
    R = np.asarray(result.R)
    for name in ("R", "omega", "R_d", "omega_d", "u_cmd", "u", "disturbance"):
        a = np.asarray(getattr(result, name))
        if name in ("R_d", "omega_d"):  # a constant reference may be logged broadcast
            a = np.broadcast_to(a, (K, R.shape[1]) + a.shape[2:])
        out[name] = _per_spacecraft(a, b, K)
    for attr in ("actuator", "disturbance_components", "modes", "sensors", "estimate"):
        for key, arr in (getattr(result, attr, None) or {}).items():
            out[f"{attr}.{key}"] = _per_spacecraft(arr, b, K)
    from liecontrol.lie import so3

    out["attitude_error"] = so3.angle(np.swapaxes(out["R_d"], -1, -2) @ out["R"])
    return out
