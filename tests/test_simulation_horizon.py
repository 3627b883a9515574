"""The simulation horizon and divergence of both closed loops (issue 12, faults 2 and 5).

- a horizon shorter than one step is rejected (it used to run to ``dt``: ``simulate(t_final=1,
  dt=10)`` logged to 10 s); a horizon that is not a multiple of ``dt`` is rounded up to whole
  steps with a warning giving the real end time; a multiple ends exactly at ``t_final``;
- a scenario whose duration is shorter than its step is rejected when it is built (a file with
  ``dt = 5``, ``duration = 2`` used to run and exit 0);
- a non-converging LGVI step in :func:`simulate_pose` raises :class:`SimulationDiverged` with the
  time and the partial log (it used to escape as ``LGVIConvergenceError`` and lose the log).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from conftest import SEED000_J

from benchmarks.scenario_files import ScenarioFileError, scenarios_from_dict
from liecontrol.control import ConstantAttitude
from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
from liecontrol.control.se3_control import PoseController
from liecontrol.integrators.lgvi import LGVIConvergenceError
from spacecraft import (
    DockingReference,
    IdealTorqueActuator,
    OrbitingTarget,
    RigidBody,
    SE3Plant,
    SimulationDiverged,
    Spacecraft,
    simulate,
    simulate_pose,
)
from spacecraft.orbit import CircularOrbit

J = SEED000_J
M = 500.0
J_POSE = np.diag([300.0, 400.0, 350.0])


def _attitude_loop():
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    k_R, k_W = gains_from_bandwidth(J, 0.1, 0.9, matrix=True)
    ctrl = GeometricPD(J, k_R, k_W)
    return plant, ctrl, ConstantAttitude(np.eye(3)), plant.initial_state(np.eye(3))


@pytest.mark.parametrize(("t_final", "dt"), [(1.0, 10.0), (2.0, 5.0), (0.05, 0.1)])
def test_simulate_rejects_a_horizon_shorter_than_one_step(t_final, dt):
    plant, ctrl, ref, x0 = _attitude_loop()
    with pytest.raises(ValueError, match="^t_final: .*shorter than one step"):
        simulate(plant, ctrl, ref, x0, t_final=t_final, dt=dt)


def test_simulate_horizon_multiple_of_dt_ends_exactly_at_t_final():
    plant, ctrl, ref, x0 = _attitude_loop()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a multiple (up to round-off) must not warn
        res = simulate(plant, ctrl, ref, x0, t_final=0.3, dt=0.1)
        one = simulate(plant, ctrl, ref, x0, t_final=0.1, dt=0.1)
    assert res.t[-1] == pytest.approx(0.3) and res.n_samples == 4
    assert one.t.tolist() == pytest.approx([0.0, 0.1])


def test_simulate_horizon_not_a_multiple_warns_with_the_real_end():
    plant, ctrl, ref, x0 = _attitude_loop()
    with pytest.warns(UserWarning, match=r"^t_final: .*ends at t = 0\.3"):
        res = simulate(plant, ctrl, ref, x0, t_final=0.25, dt=0.1)
    assert res.t[-1] == pytest.approx(0.3)  # three whole steps, as announced


def test_simulate_rejects_an_absurd_number_of_steps():
    plant, ctrl, ref, x0 = _attitude_loop()
    with pytest.raises(ValueError, match="^t_final: .*more than the limit"):
        simulate(plant, ctrl, ref, x0, t_final=1e300, dt=0.1)


class _Hold(PoseController):
    """Zero wrench, then a huge torque from ``t_kick`` on (spins the LGVI out of convergence)."""

    def __init__(self, t_kick: float = np.inf) -> None:
        self.t_kick = t_kick

    def reset(self, t0, batch_size):
        pass

    def command(self, t, state, reference):
        u = np.zeros((state.batch_size, 6))
        if t >= self.t_kick:
            u[:, :3] = 1e7
        return u


def _pose_setup():
    ref = DockingReference(OrbitingTarget(CircularOrbit(n=0.0011)), np.eye(4))
    g0, xi0 = ref.offset_state(0.0, np.zeros((1, 3)), np.zeros((1, 3)))
    return ref, g0, xi0


def test_simulate_pose_rejects_a_horizon_shorter_than_one_step():
    ref, g0, xi0 = _pose_setup()
    with pytest.raises(ValueError, match="^t_final: .*shorter than one step"):
        simulate_pose(SE3Plant(M, J_POSE), _Hold(), ref, g0, xi0, t_final=1.0, dt=5.0)


def test_simulate_pose_lgvi_failure_is_a_divergence_with_the_partial_log():
    ref, g0, xi0 = _pose_setup()
    with pytest.raises(SimulationDiverged) as info:
        simulate_pose(SE3Plant(M, J_POSE), _Hold(t_kick=3.0), ref, g0, xi0, 10.0, 1.0)
    err = info.value
    assert isinstance(err.__cause__, LGVIConvergenceError)  # the real cause is chained
    assert err.time == pytest.approx(4.0)  # the step from t = 3 s failed
    # every sample up to the last finite state survives, and it is finite
    assert err.result.t.tolist() == pytest.approx([0.0, 1.0, 2.0, 3.0])
    assert np.isfinite(err.result.g).all() and np.isfinite(err.result.xi).all()


def test_simulate_pose_divergence_keeps_the_last_finite_state_between_log_rows():
    ref, g0, xi0 = _pose_setup()
    with pytest.raises(SimulationDiverged) as info:
        simulate_pose(SE3Plant(M, J_POSE), _Hold(t_kick=3.0), ref, g0, xi0, 10.0, 1.0, log_every=5)
    assert info.value.result.t.tolist() == pytest.approx([0.0, 3.0])


def _scenario_table(**over):
    table = {
        "name": "short",
        "description": "horizon shorter than the step",
        "duration": 2.0,
        "dt": 5.0,
        "control_period": 5.0,
        "initial": {"angle_deg": 10.0, "axis": [1.0, 0.0, 0.0]},
        "reference": {"kind": "constant"},
    }
    table.update(over)
    return {"scenario": [table]}


def test_scenario_with_duration_shorter_than_dt_is_rejected():
    with pytest.raises((ValueError, ScenarioFileError), match="duration: .*shorter than one step"):
        scenarios_from_dict(_scenario_table())
    (ok,) = scenarios_from_dict(_scenario_table(duration=10.0))
    assert ok.duration == 10.0 and ok.dt == 5.0
