"""What planning buys each controller: a slew flown as a step vs as a planned profile.

``step`` is a catalogue rest-to-rest scenario (a constant target, the whole angle as the initial
error); ``planned`` is its ``-planned`` twin (``slew-90-planned``): the same start and target,
with the jerk-limited eigenaxis profile of
:class:`liecontrol.control.slew_profile.EigenaxisSlewProfile` and its rate/acceleration
feed-forward as the reference. The suite's ``settling_time_s`` is measured against the
reference (0 for a profile tracked from the start), so this study measures the time to the
*target*: the first time after which the attitude stays within ``tol_deg`` of the final
``R_d``. Per controller and variant: that time, the peak tracking error ‖log(R_dᵀR)‖ against
the variant's own reference, the peak gimbal rate and the effort ∫‖u‖ dt.

Run: ``python -m benchmarks.planned_slews [--controllers a,b] [--slews slew-90,slew-150|all]
[--out table.md]``; the twins in the catalogue: ``slew-90-planned``, ``slew-150-planned``,
``slew-120-random-axis-planned`` (:func:`benchmarks.scenarios.planned_twin`).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from liecontrol.lie import so3

__all__ = ["planned_vs_step", "format_table", "main"]


def _time_to_target(t: np.ndarray, R: np.ndarray, R_target: np.ndarray, tol_deg: float) -> float:
    ang = np.degrees(np.linalg.norm(so3.log(np.swapaxes(R_target, -1, -2) @ R), axis=-1))
    out = np.nonzero(ang > tol_deg)[0]
    if out.size == 0:
        return float(t[0])
    if out[-1] + 1 >= t.size:
        return math.nan
    return float(t[out[-1] + 1])


def planned_vs_step(
    controllers: Sequence[str] | None = None,
    step: str = "slew-90",
    planned: str = "slew-90-planned",
    tol_deg: float = 0.1,
) -> list[dict[str, Any]]:
    """Rows ``{controller, variant, time_to_target_s, peak_tracking_error_deg,
    peak_gimbal_rate_rad_s, effort_Nms, verdict}`` for every controller (default: every
    registered attitude controller that applies to both) on ``step`` and ``planned``.

    Raises:
        ValueError: ``tol_deg`` not > 0, or an unknown scenario or controller name.
    """
    from .controllers import CONTROLLERS, get_controller
    from .runner import run_suite
    from .scenarios import get_scenario

    if not (isinstance(tol_deg, (int, float)) and math.isfinite(tol_deg) and tol_deg > 0):
        raise ValueError(f"tol_deg: must be a finite number > 0, got {tol_deg!r}")
    scs = []
    for key, name in (("step", step), ("planned", planned)):
        try:
            scs.append(get_scenario(name))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{key}: {exc}") from None
    if controllers is None:
        controllers = [n for n, i in CONTROLLERS.items() if all(i.applies(s)[0] for s in scs)]
    if isinstance(controllers, str) or not isinstance(controllers, Sequence):
        raise ValueError(f"controllers: expected a sequence of names or None, got {controllers!r}")
    for c in controllers:
        try:
            get_controller(c)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"controllers: {exc}") from None
    res = run_suite(
        scs, list(controllers), jobs=1, executor="serial", progress=False, keep_histories=True
    )
    rows = []
    for o in res.outcomes:
        if o.status != "ok":
            rows.append({"controller": o.controller, "variant": o.scenario, "verdict": o.status})
            continue
        h = o.histories
        t, R, R_d = h["t"], h["R"], h["R_d"]
        dd = h.get("actuator.delta_dot")
        u = h["u_cmd"]
        rows.append(
            {
                "controller": o.controller,
                "variant": "planned" if o.scenario == planned else "step",
                "time_to_target_s": _time_to_target(t, R, R_d[-1], tol_deg),
                "peak_tracking_error_deg": float(np.degrees(h["attitude_error"]).max()),
                "peak_gimbal_rate_rad_s": float(np.abs(dd).max()) if dd is not None else math.nan,
                "effort_Nms": float(np.trapezoid(np.linalg.norm(u, axis=-1), t)),
                "verdict": o.verdict or o.status,
            }
        )
    return rows


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    """A Markdown table of :func:`planned_vs_step`'s rows (one line per controller)."""
    if isinstance(rows, (str, bytes)) or not isinstance(rows, Sequence):
        raise TypeError(f"rows: expected a sequence of dicts, got {type(rows).__name__}")
    by: dict[str, dict[str, dict[str, Any]]] = {}
    for i, r in enumerate(rows):
        if not isinstance(r, dict) or r.get("variant") not in ("step", "planned"):
            raise ValueError(
                f"rows: item {i} must be a dict with 'controller' and 'variant' (step|planned), "
                f"got {r!r}"
            )
        by.setdefault(str(r.get("controller")), {})[r["variant"]] = r

    def f(r: dict[str, Any] | None, k: str, fmt: str) -> str:
        v = None if r is None else r.get(k)
        return "—" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)

    lines = [
        "| controller | to target (0.1°) step / planned [s] | peak tracking error step / "
        "planned [°] | peak gimbal rate step / planned [rad/s] | effort step / planned [N·m·s] |",
        "|---|---|---|---|---|",
    ]
    for c, v in by.items():
        s, p = v.get("step"), v.get("planned")
        lines.append(
            f"| `{c}` | {f(s, 'time_to_target_s', '.0f')} / {f(p, 'time_to_target_s', '.0f')} "
            f"| {f(s, 'peak_tracking_error_deg', '.3g')} / "
            f"{f(p, 'peak_tracking_error_deg', '.3g')} "
            f"| {f(s, 'peak_gimbal_rate_rad_s', '.3g')} / {f(p, 'peak_gimbal_rate_rad_s', '.3g')} "
            f"| {f(s, 'effort_Nms', '.0f')} / {f(p, 'effort_Nms', '.0f')} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Command line: print (or write with ``--out``) the table of :func:`planned_vs_step`."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--controllers", default=None, help="comma-separated names (default: all)")
    ap.add_argument("--out", default=None, help="write the Markdown table here")
    ap.add_argument(
        "--slews", default="slew-90", help="comma-separated step scenarios with a -planned twin "
        "(default slew-90; 'all' for every twin in the catalogue)",
    )  # fmt: skip
    a = ap.parse_args(argv)
    names = None if a.controllers is None else [c for c in a.controllers.split(",") if c]
    if a.slews == "all":
        from .scenarios import SCENARIOS

        steps = [n[: -len("-planned")] for n in SCENARIOS if n.endswith("-planned")]
    else:
        steps = [x for x in a.slews.split(",") if x]
    parts = []
    for step in steps:
        parts.append(f"### {step} vs {step}-planned\n\n")
        parts.append(format_table(planned_vs_step(names, step=step, planned=f"{step}-planned")))
        parts.append("\n")
    table = "".join(parts)
    if a.out:
        with open(a.out, "w", encoding="utf-8") as fh:
            fh.write(table)
    print(table, end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
