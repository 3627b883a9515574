"""The ``keep-out-sun-slew-rate`` scenario (issue 25): the Sun-cone slew started with a body rate
that carries the boresight toward the cone, so the constraint laws are compared where the
sampled-data guarantee matters."""

from __future__ import annotations

import numpy as np

from benchmarks.requirements import requirements_of
from benchmarks.runner import initial_state
from benchmarks.scenario_files import scenario_from_dict, scenario_to_dict
from benchmarks.scenarios import KEEP_OUT_APPROACH_RATE, SCENARIOS, SUITES
from liecontrol.lie import so3


def _torque_free(J: np.ndarray, R: np.ndarray, w: np.ndarray, t: float, h: float = 0.01):
    """Attitudes of the free rigid body (J ω̇ = −ω × Jω, Ṙ = R ω^) every ``h`` up to ``t``,
    RK4 on ω and the exponential map on R (independent of the package's simulator)."""
    Ji = np.linalg.inv(J)

    def f(x):
        return -Ji @ np.cross(x, J @ x)

    out = [R]
    for _ in range(int(round(t / h))):
        k1 = f(w)
        k2 = f(w + 0.5 * h * k1)
        k3 = f(w + 0.5 * h * k2)
        k4 = f(w + h * k3)
        w_next = w + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        R = R @ so3.exp(0.5 * h * (w + w_next))
        w = w_next
        out.append(R)
    return np.stack(out)


def test_initial_rate_points_toward_the_cone():
    s = SCENARIOS["keep-out-sun-slew-rate"]
    base = SCENARIOS["keep-out-sun-slew"]
    # the plain Sun-cone slew with only the initial rate added
    assert s.initial_rotvec == base.initial_rotvec and s.keep_out == base.keep_out
    assert s.initial_rate == KEEP_OUT_APPROACH_RATE
    assert np.linalg.norm(s.initial_rate) == 0.05
    assert s in SUITES["full"].scenarios and s not in SUITES["quick"].scenarios
    R0, w0 = initial_state(s)
    np.testing.assert_allclose(w0, s.initial_rate)
    cone = s.keep_out[0]
    m0 = float(cone.margin_deg(R0))
    assert m0 > 30.0  # outside the cone at the start
    # under zero torque the margin shrinks from the first instant and the cone is reached
    # within the first 20 s (the sampled laws must brake from 0.05 rad/s before then)
    Rs = _torque_free(s.true_inertia, R0, np.asarray(w0, dtype=float), 20.0)
    m = cone.margin_deg(Rs)
    assert np.all(np.diff(m[:500]) < 0.0)
    assert m.min() < 0.0
    # the rate carries the body along the slew: the attitude error shrinks at first too
    err = np.linalg.norm(so3.log(Rs[100]))
    assert err < np.linalg.norm(s.initial_rotvec)


def test_requirements_and_round_trip():
    s = SCENARIOS["keep-out-sun-slew-rate"]
    req = {r.metric: r for r in requirements_of(s)}
    assert req["min_keep_out_margin_deg"].limit == 0.0
    assert req["min_keep_out_margin_deg"].sense == "min"
    assert req["steady_error_max_deg"].limit == s.attitude_tolerance_deg
    assert scenario_from_dict(scenario_to_dict(s)) == s
