"""Minimum keep-out margin of each constraint law over initial rates toward the cone × control
periods (docs/constraints.md, "Margin grid per law").

The case is the catalogue's ``keep-out-sun-slew`` geometry: a 120° slew about body x of the
SGCMG bus inertia whose geodesic takes the body-z boresight through the centre of a 20° Sun
cone (initial margin 40.2°), the target the identity. Every law runs on the same plant — the
rigid body with an ideal torque actuator clipped to 300 N·m per axis — tuned for ω_n =
0.03 rad/s, ζ = 0.9 at the control period, from an initial rate ``v`` about −x (straight back
along the slew, toward the cone), for 120 s; every integration step (0.05 s, or the period if
shorter) is logged and the margin is taken over all of them (inside the held periods too):

* ``barrier`` — :class:`~liecontrol.control.constrained.ConstrainedGeometricPD` (the log
  barrier, continuous-time guarantee with the torque delivered);
* ``sampled-safe`` — :class:`~liecontrol.control.constrained.SampledSafeConstrainedPD` (the
  barrier law through the braking-margin filter at the period, 300 N·m bound);
* ``mpc-keep-out`` — :class:`~liecontrol.control.mpc.SO3MPC` with the cone, tuned as the
  registry's ``mpc-keep-out`` (``tune_mpc``, N = 10, the barrier law as the QP fallback), its
  torque through the same braking filter.

A start the law flags before running (``UnrecoverableStartWarning``) is recorded as
``warned``; a run the simulator stops (``SimulationDiverged``) keeps its margin up to the stop
and is recorded as ``diverged``.

Run ``python -m benchmarks.constraint_margins`` (about 3.5 minutes of CPU on the default grid,
most of it the MPC at the short periods) to write ``docs/figures/constraint_margins.csv`` and
``docs/figures/constraint_margins.png``; ``--rates``, ``--periods``, ``--t-final`` and
``--out`` change the grid and the destination.
"""

from __future__ import annotations

import argparse
import csv
import logging
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liecontrol.control.constrained import (
    ConstrainedGeometricPD,
    KeepOutCone,
    SampledSafeConstrainedPD,
    UnrecoverableStartWarning,
    cone_margins_deg,
)
from liecontrol.control.mpc import SO3MPC
from liecontrol.control.reference import ConstantAttitude
from liecontrol.control.tuning import (
    ActuatorLimits,
    ClosedLoopSpec,
    tune_geometric_pd,
    tune_mpc,
)
from liecontrol.lie import so3
from spacecraft.actuators import IdealTorqueActuator
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.simulator import SimulationDiverged, simulate

__all__ = [
    "LAWS",
    "MarginCell",
    "margin_grid",
    "run_cell",
    "write_csv",
    "plot",
    "main",
]

#: SGCMG-bus inertia of the catalogue's constraint scenarios [kg·m²].
J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
#: The keep-out-sun-slew Sun cone on the body-z boresight.
SUN = KeepOutCone((0.0, 0.0, 1.0), (0.104528, -0.861281, 0.497261), 20.0)
#: Start: 120° about body x (the geodesic to the identity crosses the cone's centre).
R0 = so3.exp(np.radians(120.0) * np.array([1.0, 0.0, 0.0]))
#: Per-axis torque bound of the plant and of the laws that take one [N·m].
U_MAX = 300.0
OMEGA_N, ZETA = 0.03, 0.9
DT = 0.05  # integration step [s]

LAWS = ("barrier", "sampled-safe", "mpc-keep-out")
DEFAULT_RATES = (0.0, 0.05, 0.1)
DEFAULT_PERIODS = (0.01, 0.05, 0.1, 0.2, 0.5, 1.0)


@dataclass(frozen=True)
class MarginCell:
    """One (law, control period, initial rate) run: the smallest margin over every logged
    step [deg], the peak torque command [N·m], and whether the law warned before running or
    the simulation stopped."""

    law: str
    period: float
    rate: float
    min_margin_deg: float
    peak_torque: float
    warned: bool
    diverged: bool


def _controller(law: str, T: float):
    spec = ClosedLoopSpec(OMEGA_N, ZETA, T)
    g = tune_geometric_pd(J, spec, error="large_angle")
    k_R, k_W = g["k_R"], g["k_Omega"]
    if law == "barrier":
        return ConstrainedGeometricPD(J, k_R, k_W, keep_out=(SUN,))
    if law == "sampled-safe":
        return SampledSafeConstrainedPD(
            J, k_R, k_W, keep_out=(SUN,), max_torque=U_MAX, sample_period=T
        )
    if law == "mpc-keep-out":
        kw = tune_mpc(J, spec, ActuatorLimits(max_torque=U_MAX))
        kw["fallback"] = ConstrainedGeometricPD(J, k_R, k_W, keep_out=(SUN,))
        return SO3MPC(J, **kw, keep_out=(SUN,))
    raise ValueError(f"law: expected one of {LAWS}, got {law!r}")


def run_cell(law: str, period: float, rate: float, t_final: float = 120.0):
    """Simulate one cell; returns ``(MarginCell, SimulationResult)`` (the result is the
    partial one when the simulation diverged)."""
    ctrl = _controller(law, float(period))
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(max_torque=U_MAX))
    st = plant.initial_state(R0[None], omega0=np.array([[-float(rate), 0.0, 0.0]]))
    diverged = False
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnrecoverableStartWarning)
        try:
            dt = min(DT, float(period))  # the period must be a multiple of the step
            res = simulate(plant, ctrl, ConstantAttitude(np.eye(3)), st, t_final, dt, period)
        except SimulationDiverged as exc:
            res, diverged = exc.result, True
    warned = any(issubclass(w.category, UnrecoverableStartWarning) for w in caught)
    m = cone_margins_deg((SUN,), res.R)[..., 0]
    u = np.asarray(res.u_cmd)
    cell = MarginCell(
        law,
        float(period),
        float(rate),
        float(np.nanmin(np.where(np.isfinite(m), m, np.nan))),
        float(np.nanmax(np.abs(np.where(np.isfinite(u), u, np.nan)))),
        warned,
        diverged,
    )
    return cell, res


def margin_grid(
    laws: Sequence[str] = LAWS,
    rates: Sequence[float] = DEFAULT_RATES,
    periods: Sequence[float] = DEFAULT_PERIODS,
    t_final: float = 120.0,
) -> list[MarginCell]:
    """Every (law, period, rate) cell, in that order."""
    for name, xs in (("rates", rates), ("periods", periods)):
        if not len(xs):
            raise ValueError(f"{name}: needs at least one value")
    if any(not r >= 0.0 for r in rates):
        raise ValueError(f"rates: must be >= 0 [rad/s], got {list(rates)}")
    if any(not T > 0.0 for T in periods):
        raise ValueError(f"periods: must be > 0 [s], got {list(periods)}")
    bad = [law for law in laws if law not in LAWS]
    if bad:
        raise ValueError(f"laws: unknown {bad}; expected some of {LAWS}")
    # the MPC logs every re-solved or relaxed step; the grid reports its own summary
    logging.getLogger("liecontrol.control.mpc").setLevel(logging.ERROR)
    return [run_cell(law, T, v, t_final)[0] for law in laws for T in periods for v in rates]


def write_csv(cells: Sequence[MarginCell], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["law", "period_s", "rate_rad_s", "min_margin_deg", "peak_torque_Nm", "warned",
             "diverged"]
        )  # fmt: skip
        for c in cells:
            w.writerow(
                [c.law, c.period, c.rate, f"{c.min_margin_deg:.4f}", f"{c.peak_torque:.1f}",
                 int(c.warned), int(c.diverged)]
            )  # fmt: skip


def plot(cells: Sequence[MarginCell], path: Path) -> None:
    """One panel per law: minimum margin against the initial rate, one line per period."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    laws = [law for law in LAWS if any(c.law == law for c in cells)]
    fig, axes = plt.subplots(1, len(laws), figsize=(4.2 * len(laws), 3.6), sharey=True)
    axes = np.atleast_1d(axes)
    periods = sorted({c.period for c in cells})
    for ax, law in zip(axes, laws, strict=True):
        for T in periods:
            cs = sorted((c for c in cells if c.law == law and c.period == T), key=lambda c: c.rate)
            ax.plot([c.rate for c in cs], [c.min_margin_deg for c in cs], "o-", label=f"{T:g} s")
            for c in cs:
                if c.diverged or c.warned:
                    ax.annotate("D" if c.diverged else "W", (c.rate, c.min_margin_deg))
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_title(law)
        ax.set_xlabel("initial rate toward the cone [rad/s]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("minimum keep-out margin [deg]")
    axes[-1].legend(title="control period", fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _floats(text: str, name: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"{name}: expected comma-separated numbers, got {text!r}") from None


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.constraint_margins", description=__doc__)
    p.add_argument("--rates", default=",".join(map(str, DEFAULT_RATES)))
    p.add_argument("--periods", default=",".join(map(str, DEFAULT_PERIODS)))
    p.add_argument("--laws", default=",".join(LAWS))
    p.add_argument("--t-final", type=float, default=120.0)
    p.add_argument("--out", default="docs/figures", help="folder for the CSV and the PNG")
    a = p.parse_args(argv)
    cells = margin_grid(
        [x for x in a.laws.split(",") if x],
        _floats(a.rates, "rates"),
        _floats(a.periods, "periods"),
        a.t_final,
    )
    out = Path(a.out)
    write_csv(cells, out / "constraint_margins.csv")
    plot(cells, out / "constraint_margins.png")
    for c in cells:
        flag = " diverged" if c.diverged else (" warned" if c.warned else "")
        print(f"{c.law:13s} T={c.period:<5g} v={c.rate:<6g} min margin {c.min_margin_deg:8.2f}°"
              f"  peak {c.peak_torque:7.1f} N·m{flag}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
