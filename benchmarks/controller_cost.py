"""What one controller call costs, measured apart from the suite's runs.

Timing a controller inside a suite run mixes it with the batch it was stacked in, the machine's
load at that moment and whether its kernels were compiled yet: the same law measured 1743 µs in
one column and 85.5 µs in the next. :func:`controller_cost` measures it on its own: the
registry's controller built for one spacecraft of a scenario, reset, called ``warmup`` times
(compilation, caches), then ``repeats`` blocks of ``calls`` calls on a fixed state 10° off the
target; the result is the median over the blocks of the mean time per call. It is still a wall
time on a shared machine: compare orders of magnitude.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from .controllers import ATTITUDE_PLANTS, ControllerContext, GainRule, get_controller

__all__ = ["controller_cost", "cost_section"]


def controller_cost(
    name: str,
    scenario: Any,
    rule: GainRule | None = None,
    *,
    warmup: int = 20,
    repeats: int = 7,
    calls: int = 30,
) -> float:
    """Median wall time of one ``command`` call [µs] of registry controller ``name`` on one
    spacecraft of ``scenario`` (module docstring)."""
    from liecontrol._validation import as_int
    from liecontrol.control import AttitudeState, ConstantAttitude
    from liecontrol.lie import so3

    if not isinstance(name, str):
        raise TypeError(f"name: expected a registered controller name, got {name!r}")
    if not all(hasattr(scenario, a) for a in ("spacecraft", "control_period", "dt")):
        raise TypeError(f"scenario: expected a Scenario, got {type(scenario).__name__}")
    if rule is not None and not isinstance(rule, GainRule):
        raise TypeError(f"rule: expected a GainRule or None, got {type(rule).__name__}")
    warmup = as_int(warmup, "warmup", 0)
    repeats = as_int(repeats, "repeats", 1)
    calls = as_int(calls, "calls", 1)
    info = get_controller(name)
    if not (info.plants & ATTITUDE_PLANTS):
        raise ValueError(f"name: {name!r} is not an attitude controller")
    period = info.control_period or scenario.control_period or scenario.dt
    ref = ConstantAttitude(np.eye(3))
    kw = {} if rule is None else {"rule": rule}
    ctx = ControllerContext(
        spacecraft=scenario.spacecraft, control_period=period, batch_size=1, reference=ref, **kw
    )
    ctrl = info.factory(ctx)
    ctrl.reset(0.0, 1)
    R = so3.exp(np.deg2rad(10.0) * np.array([[1.0, 1.0, 1.0]]) / math.sqrt(3.0))
    state = AttitudeState(R=R, omega=np.zeros((1, 3)))
    t = 0.0
    for _ in range(warmup):
        ctrl.command(t, state, ref(t))
        t += period
    blocks = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            ctrl.command(t, state, ref(t))
            t += period
        blocks.append((time.perf_counter() - t0) / calls)
    return 1e6 * float(np.median(blocks))


def cost_section(result: Any) -> list[str]:
    """Markdown lines: one row per attitude controller of ``result``, measured on the first
    attitude scenario's spacecraft."""
    if not all(hasattr(result, a) for a in ("scenarios", "controllers")):
        raise TypeError(f"result: expected a SuiteResult, got {type(result).__name__}")
    att = [s for s in result.scenarios if s.plant in ATTITUDE_PLANTS]
    if not att:
        return []
    sc = att[0]
    lines = [
        "### Controller cost per call",
        "",
        f"Measured apart from the runs (`benchmarks.controller_cost`): one spacecraft of "
        f"`{sc.name}`, {20} warm-up calls, then the median of 7 blocks of 30 calls; a wall time on "
        "this machine, so compare orders of magnitude. The suite's batched runs do not time "
        "controllers (their `controller_time_us` in metrics.json is the batch's call time "
        "divided among its spacecraft, kept for reference only).",
        "",
        "| controller | µs per call |",
        "|---|---|",
    ]
    for c in result.controllers:
        try:
            info = get_controller(c)
        except (KeyError, ValueError):
            continue
        if not (info.plants & ATTITUDE_PLANTS):
            continue
        try:
            us = controller_cost(c, sc, getattr(result, "gain_rule", None))
            cell = f"{us:.3g}"
        except Exception as exc:  # noqa: BLE001 - reported in the cell
            cell = f"not measured: {type(exc).__name__}"
        lines.append(f"| `{c}` | {cell} |")
    lines.append("")
    return lines
