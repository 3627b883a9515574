"""The MPC keep-out law's held-out check (geodesic through the Sun cone, initial rates toward it
0–0.1 rad/s, control periods 0.05–1 s) and the margin-grid benchmark (benchmarks.constraint_
margins) against a direct simulation."""

from __future__ import annotations

import logging
import warnings

import numpy as np
import pytest

from benchmarks import constraint_margins as cm
from liecontrol.control.constrained import UnrecoverableStartWarning
from liecontrol.control.mpc import SO3MPC
from liecontrol.control.reference import ConstantAttitude
from liecontrol.control.tuning import ActuatorLimits, ClosedLoopSpec, tune_mpc
from spacecraft.actuators import IdealTorqueActuator
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.simulator import simulate

SUN_DIR = np.array([0.104528, -0.861281, 0.497261])


def _margin_deg(R: np.ndarray) -> np.ndarray:
    """Angle between the boresight R e_z and the Sun, less the 20° half-angle (own route)."""
    z = R[..., :, 2]
    c = np.clip(z @ (SUN_DIR / np.linalg.norm(SUN_DIR)), -1.0, 1.0)
    return np.degrees(np.arccos(c)) - 20.0


def _mpc(T: float, **kw) -> SO3MPC:
    spec = ClosedLoopSpec(cm.OMEGA_N, cm.ZETA, T)
    return SO3MPC(cm.J, **tune_mpc(cm.J, spec, ActuatorLimits(cm.U_MAX)), keep_out=(cm.SUN,), **kw)


def _run(ctrl, T: float, v: float, t_final: float = 30.0):
    plant = Spacecraft(RigidBody(cm.J), IdealTorqueActuator(max_torque=cm.U_MAX))
    st = plant.initial_state(cm.R0[None], omega0=np.array([[-v, 0.0, 0.0]]))
    return simulate(plant, ctrl, ConstantAttitude(np.eye(3)), st, t_final, 0.05, T)


@pytest.mark.slow
@pytest.mark.parametrize("T", [0.05, 0.1, 0.2, 0.5, 1.0])
def test_mpc_keep_out_holds_the_margin_over_the_grid(T, caplog):
    """Rates 0, 0.05, 0.1 rad/s toward the cone: the MPC keeps the margin positive at every
    logged step, within the torque box, and warns of no start (they are all recoverable)."""
    for v in (0.0, 0.05, 0.1):
        with warnings.catch_warnings(), caplog.at_level(logging.ERROR):
            warnings.simplefilter("error", UnrecoverableStartWarning)
            res = _run(_mpc(T), T, v)
        assert _margin_deg(res.R).min() > 0.0, (T, v)
        assert np.abs(res.u_cmd).max() <= cm.U_MAX * (1.0 + 1e-12)
        assert res.controller["fallback_count"][-1, 0] == 0


def test_mpc_without_the_filter_crosses_and_the_filter_brakes(caplog):
    """The counter-example the filter exists for: at 0.1 rad/s toward the cone and a 0.1 s
    period the QP's linearised cones alone (N = 10, a 1 s horizon) let the boresight into the
    cone; with the filter (default) the margin stays positive and the filter acted."""
    with caplog.at_level(logging.ERROR):
        bare = _run(_mpc(0.1, safety_filter=False), 0.1, 0.1, t_final=20.0)
        safe = _run(_mpc(0.1), 0.1, 0.1, t_final=20.0)
    assert _margin_deg(bare.R).min() < 0.0
    assert _margin_deg(safe.R).min() > 0.0
    assert safe.controller["filter_active"].any()


def test_mpc_warns_before_an_unrecoverable_start(caplog):
    """0.3 rad/s toward the cone with 300 N·m cannot be stopped in the 40° left: the first
    command warns, naming R, before the run goes on."""
    c = _mpc(1.0)
    plant = Spacecraft(RigidBody(cm.J), IdealTorqueActuator(max_torque=cm.U_MAX))
    st = plant.initial_state(cm.R0[None], omega0=np.array([[-0.3, 0.0, 0.0]]))
    with (
        caplog.at_level(logging.ERROR),
        pytest.warns(UnrecoverableStartWarning, match="^R: spacecraft 0 starts in the unrec"),
    ):
        simulate(plant, c, ConstantAttitude(np.eye(3)), st, 2.0, 0.05, 1.0)


def test_margin_grid_matches_a_direct_simulation():
    """A 2 × 2 grid (sampled-safe law; rates 0, 0.1; periods 0.5, 1 s; 20 s): the cells are
    in (period, rate) order, and each minimum margin and peak torque equals that of a direct
    simulation with the margin computed by another route."""
    from liecontrol.control.constrained import SampledSafeConstrainedPD
    from liecontrol.control.tuning import tune_geometric_pd

    cells = cm.margin_grid(["sampled-safe"], [0.0, 0.1], [0.5, 1.0], t_final=20.0)
    assert [(c.period, c.rate) for c in cells] == [(0.5, 0.0), (0.5, 0.1), (1.0, 0.0), (1.0, 0.1)]
    for c in cells:
        g = tune_geometric_pd(cm.J, ClosedLoopSpec(0.03, 0.9, c.period), error="large_angle")
        ctrl = SampledSafeConstrainedPD(
            cm.J,
            g["k_R"],
            g["k_Omega"],
            keep_out=(cm.SUN,),
            max_torque=300.0,
            sample_period=c.period,
        )
        res = _run(ctrl, c.period, c.rate, t_final=20.0)
        assert c.min_margin_deg == pytest.approx(_margin_deg(res.R).min(), abs=1e-9)
        assert c.peak_torque == pytest.approx(np.abs(res.u_cmd).max(), rel=1e-12)
        assert not c.warned and not c.diverged
    # the start toward the cone comes closer than the start from rest, at both periods
    assert cells[1].min_margin_deg < cells[0].min_margin_deg
    assert cells[3].min_margin_deg < cells[2].min_margin_deg


def test_margin_grid_bad_input():
    with pytest.raises(ValueError, match="^periods"):
        cm.margin_grid(["barrier"], [0.0], [0.0])
    with pytest.raises(ValueError, match="^rates"):
        cm.margin_grid(["barrier"], [-0.1], [1.0])
    with pytest.raises(ValueError, match="^laws"):
        cm.margin_grid(["pid"], [0.0], [1.0])


def test_the_grid_is_written_as_csv_and_drawn(tmp_path):
    import csv

    from benchmarks.constraint_margins import LAWS, MarginCell, plot, write_csv

    cells = [
        MarginCell(law, T, w, 1.0 - 10.0 * w - T, 50.0, False, False)
        for law in LAWS
        for T in (0.1, 0.5)
        for w in (0.0, 0.05)
    ]
    write_csv(cells, tmp_path / "grid.csv")
    rows = list(csv.DictReader(open(tmp_path / "grid.csv", newline="")))
    assert len(rows) == len(cells)
    assert {r["law"] for r in rows} == set(LAWS)
    got = sorted(float(r["min_margin_deg"]) for r in rows)
    assert got == sorted(c.min_margin_deg for c in cells)
    plot(cells, tmp_path / "grid.png")
    assert (tmp_path / "grid.png").stat().st_size > 10_000
