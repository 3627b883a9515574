"""Minimum keep-out margin over a grid of initial rates and control periods (docs/constraints.md,
figure ``docs/figures/keep_out_sampled_margin.png``): the 120° slew of the benchmarks'
``keep-out-sun-slew`` scenario on the sgcmg-bus inertia, with ConstrainedGeometricPD (ideal
torque) and SampledSafeConstrainedPD (300 N·m per axis), 120 s at dt = 0.05 s.

Run: ``python tools/keep_out_sampled_grid.py`` (about a minute of CPU; needs matplotlib).
"""

from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from liecontrol.control.constrained import (
    ConstrainedGeometricPD,
    KeepOutCone,
    SampledSafeConstrainedPD,
    cone_margins_deg,
)
from liecontrol.control.reference import ConstantAttitude
from liecontrol.control.tuning import ClosedLoopSpec, tune_geometric_pd
from liecontrol.lie import so3
from spacecraft.actuators import IdealTorqueActuator
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.simulator import SimulationDiverged, simulate

J = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
cone = KeepOutCone((0.0, 0.0, 1.0), (0.104528, -0.861281, 0.497261), 20.0)
rates = np.array([0.0, 0.025, 0.05, 0.075, 0.1])
Ts = [0.05, 0.1, 0.2, 0.5, 1.0]
R0 = so3.exp(np.deg2rad(120.0) * np.array([1.0, 0, 0]))
out = {}
for law in ("barrier", "sampled-safe"):
    M = np.full((len(Ts), len(rates)), np.nan)
    U = M.copy()
    for i, T in enumerate(Ts):
        kw = tune_geometric_pd(J, ClosedLoopSpec(0.03, 0.9, T))
        kw.pop("error")
        if law == "barrier":
            ctl = ConstrainedGeometricPD(J, keep_out=(cone,), **kw)
            act = IdealTorqueActuator()
        else:
            ctl = SampledSafeConstrainedPD(
                J, keep_out=(cone,), max_torque=300.0, sample_period=T, **kw
            )
            act = IdealTorqueActuator(max_torque=300.0)
        plant = Spacecraft(RigidBody(J), act)
        st = plant.initial_state(
            np.broadcast_to(R0, (5, 3, 3)), omega0=-rates[:, None] * np.array([1.0, 0, 0])
        )
        try:
            res = simulate(plant, ctl, ConstantAttitude(np.eye(3)), st, 120.0, 0.05, T)
        except SimulationDiverged as e:
            res = e.result
        m = cone_margins_deg([cone], res.R)[..., 0]
        M[i] = np.nanmin(np.where(np.isfinite(m), m, np.nan), axis=0)
        U[i] = np.nanmax(np.abs(res.u_cmd), axis=(0, 2))
    out[law] = (M, U)
    print(law)
    print("min margin [deg] rows T", Ts, "cols rate", rates.tolist())
    print(np.round(M, 2))
    print("peak |u| N·m")
    print(np.array2string(U, precision=3))
fig, axs = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
for ax, law in zip(axs, out, strict=True):
    M = out[law][0]
    im = ax.imshow(
        np.clip(M, -20, 12), origin="lower", cmap="RdYlGn", vmin=-20, vmax=12, aspect="auto"
    )
    for i in range(len(Ts)):
        for j in range(len(rates)):
            ax.text(
                j,
                i,
                "div." if not np.isfinite(M[i, j]) else f"{M[i, j]:.1f}",
                ha="center",
                va="center",
                fontsize=8,
            )
    ax.set_xticks(range(len(rates)), [f"{r:g}" for r in rates])
    ax.set_yticks(range(len(Ts)), [f"{t:g}" for t in Ts])
    ax.set_xlabel("initial rate toward the cone [rad/s]")
    ax.set_title(
        {
            "barrier": "ConstrainedGeometricPD (ideal torque)",
            "sampled-safe": "SampledSafeConstrainedPD (300 N·m)",
        }[law],
        fontsize=9,
    )
axs[0].set_ylabel("control period [s]")
fig.colorbar(im, ax=axs, label="min margin [deg]")
fig.savefig(
    str(Path(__file__).resolve().parents[1] / "docs" / "figures" / "keep_out_sampled_margin.png"),
    dpi=110,
    bbox_inches="tight",
)
