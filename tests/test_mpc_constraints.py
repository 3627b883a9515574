"""CMG gimbal-rate and momentum-envelope constraints for the SO(3) MPC (SPEC §6 item 4, §5.2).

Independent routes: the constraint's affine gimbal-rate map against the plant's own actuator
(:class:`spacecraft.SgcmgActuator.command`, steering law + ḣ_cmd = −u − ω × h); the MPC's first
input checked through the public steering law; OSQP against the cvxpy/Clarabel formulation with
the constraints active; the envelope radius against reachability (least-squares inverse
kinematics of h(δ)), dense sampling of δ and the support-function bound.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize
from conftest import SEED000_J

from liecontrol.control import AttitudeReference, AttitudeState
from liecontrol.control.mpc import SO3MPC
from liecontrol.lie import so3
from spacecraft import PseudoInverse, SgcmgActuator, SgcmgPyramid, SingularityRobust
from spacecraft.mpc_constraints import (
    cmg_gimbal_rate_constraint,
    momentum_envelope_constraint,
    momentum_envelope_radius,
    stack_constraints,
    steering_map,
)
from spacecraft.steering import SteeringLaw

J = SEED000_J
CLUSTER = SgcmgPyramid(h0=300.0, beta=np.deg2rad(54.73), gimbal_rate_limit=1.0)
U_MAX = 20.0
RATE = 0.02  # rad/s: tight, the CMGs then deliver only ~10 N·m
DT = 1.0


def _mpc(backend: str, extra, horizon: int = 20) -> SO3MPC:
    return SO3MPC(
        J, horizon, DT, [200.0] * 3 + [2.0e5] * 3, [1.0] * 3, U_MAX,
        backend=backend, extra_constraints=extra,
    )  # fmt: skip


def _states() -> AttitudeState:
    """Two spacecraft with large attitude errors (the torque box would be active), small rates,
    gimbals at the zero-momentum set and at a generic non-singular set."""
    axes = np.array([[1.0, 2.0, 3.0], [-2.0, 0.5, 1.0]])
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    R = so3.exp(np.deg2rad([[60.0], [120.0]]) * axes)
    omega = np.array([[0.002, -0.001, 0.003], [-0.004, 0.002, 0.001]])
    delta = np.array([np.deg2rad([45.0, -45.0, 45.0, -45.0]), [0.4, -1.2, 1.5, 0.2]])
    return AttitudeState(R, omega, CLUSTER.momentum(delta), delta)


def _implied_rates(u: np.ndarray, st: AttitudeState, law=None) -> np.ndarray:
    """δ̇ the plant's steering law gives for the torque u (public, validated call)."""
    law = PseudoInverse() if law is None else law
    hdot = -u - np.cross(st.omega, CLUSTER.momentum(st.actuator_state))
    return law(CLUSTER.jacobian(st.actuator_state), hdot)


@pytest.mark.parametrize("law", [PseudoInverse(), SingularityRobust()], ids=["pinv", "sr"])
def test_gimbal_rate_map_matches_the_plant_actuator(law):
    rng = np.random.default_rng(0)
    con = cmg_gimbal_rate_constraint(CLUSTER, rate_limit=1.0, steering=law)
    act = SgcmgActuator(CLUSTER, law)
    for _ in range(5):
        delta = rng.uniform(-np.pi, np.pi, size=(1, 4))
        if CLUSTER.singularity_measure(delta)[0] < 0.3:
            continue
        w = 0.01 * rng.normal(size=(1, 3))
        u = 2.0 * rng.normal(size=(1, 3))
        st = AttitudeState(np.eye(3)[None], w, None, delta)
        C, lo, hi = con(st)
        offset = -0.5 * (lo + hi)
        np.testing.assert_allclose(hi - lo, 2.0)  # ±rate_limit about the offset
        plant = act.command(u, w, delta, 0.0).delta_dot[0]
        np.testing.assert_allclose(C @ u[0] + offset, plant, rtol=1e-9, atol=1e-12)


@pytest.fixture(scope="module")
def rate_limited():
    st = _states()
    con = cmg_gimbal_rate_constraint(CLUSTER, rate_limit=RATE)
    out = {}
    for backend in ("osqp", "cvxpy"):
        ctrl = _mpc(backend, con)
        ctrl.reset(0.0, st.batch_size)
        out[backend] = ctrl.command(0.0, st, AttitudeReference.regulation(np.eye(3)))
        d = ctrl.diagnostics()
        assert (d["status"] == 1).all() and not d["fallback_active"].any(), (backend, d)
    free = _mpc("osqp", None)
    free.reset(0.0, st.batch_size)
    out["free"] = free.command(0.0, st, AttitudeReference.regulation(np.eye(3)))
    return st, out


def test_first_input_respects_a_tight_gimbal_rate_limit(rate_limited):
    st, out = rate_limited
    # without the constraint the MPC asks for more than the gimbals may give
    assert np.abs(_implied_rates(out["free"], st)).max() > 2.0 * RATE
    rates = _implied_rates(out["osqp"], st)
    assert np.abs(rates).max() <= RATE * (1.0 + 1e-4)
    # the limit binds on every spacecraft (the constraint is active, not slack)
    assert np.allclose(np.abs(rates).max(axis=1), RATE, rtol=1e-4)
    assert np.abs(out["osqp"]).max() <= U_MAX


def test_osqp_and_cvxpy_agree_with_the_gimbal_rate_constraint_active(rate_limited):
    _, out = rate_limited
    np.testing.assert_allclose(out["osqp"], out["cvxpy"], atol=1e-4, rtol=0)


# ---------------------------------------------------------------------------------------------
# momentum envelope


def _reach(target: np.ndarray, starts: int = 12) -> float:
    """Smallest ‖h(δ) − target‖ / h₀ found by least squares from several starts."""
    rng = np.random.default_rng(1)
    best = np.inf
    for _ in range(starts):
        res = scipy.optimize.least_squares(
            lambda d: (CLUSTER.momentum(d) - target) / CLUSTER.h0,
            rng.uniform(-np.pi, np.pi, 4),
            jac=lambda d: CLUSTER.jacobian(d) / CLUSTER.h0,
            xtol=1e-14,
            ftol=1e-14,
            gtol=1e-14,
        )
        best = min(best, float(np.linalg.norm(res.fun)))
        if best < 1e-9:
            break
    return best


def test_envelope_radius_is_inscribed_and_attained_on_the_gimbal_axes():
    h0 = CLUSTER.h0
    r = momentum_envelope_radius(CLUSTER)
    assert 2.50 * h0 < r < 2.55 * h0
    G = CLUSTER.gimbal_axes().T
    # below the support-function bound along the gimbal axes (the dimples)
    support = h0 * np.sqrt(np.clip(1.0 - (G @ G[0]) ** 2, 0.0, None)).sum()
    assert r < support - 0.2 * h0
    # reachable: points inside the sphere (random directions) and r on the gimbal axis
    rng = np.random.default_rng(2)
    dirs = rng.normal(size=(8, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    for n in np.vstack([dirs, G[:2]]):
        assert _reach(0.98 * r * n) < 1e-9
    assert _reach(r * G[0]) < 1e-6
    # not reachable just beyond it on the gimbal axis
    assert _reach(1.02 * r * G[0], starts=30) > 1e-4
    # dense sampling agrees: the largest |h| within 1.5° of g₁ is about r (cone neighbours reach
    # slightly further)
    d = rng.uniform(-np.pi, np.pi, size=(400_000, 4))
    H = CLUSTER.momentum(d)
    nh = np.linalg.norm(H, axis=1)
    cone = H @ G[0] > np.cos(np.deg2rad(1.5)) * nh
    assert r * 0.99 < nh[cone].max() < r * 1.04


@pytest.mark.parametrize("shape", ["radial", "box"])
def test_envelope_constraint_limits_the_momentum_one_step_ahead(shape):
    r_env = momentum_envelope_radius(CLUSTER)
    rho = 0.9 * r_env
    # gimbal angles whose momentum is close to the sphere, along a generic direction
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    res = scipy.optimize.least_squares(
        lambda dd: (CLUSTER.momentum(dd) - 0.97 * rho * n) / CLUSTER.h0,
        np.array([0.5, -0.5, 0.5, -0.5]),
    )
    delta = res.x[None]
    h = CLUSTER.momentum(delta)
    # the attitude error asks for a torque along −n (which makes h grow along n)
    st = AttitudeState(so3.exp(np.deg2rad(40.0) * n)[None], np.zeros((1, 3)), h, delta)
    look = 4.0  # look-ahead Δt [s]
    con = momentum_envelope_constraint(CLUSTER, dt=look, margin=0.9, shape=shape)
    us = {}
    for backend in ("osqp", "cvxpy"):
        ctrl = _mpc(backend, stack_constraints(con, cmg_gimbal_rate_constraint(CLUSTER)), 8)
        ctrl.reset(0.0, 1)
        us[backend] = ctrl.command(0.0, st, AttitudeReference.regulation(np.eye(3)))[0]
        assert ctrl.diagnostics()["status"][0] == 1
    np.testing.assert_allclose(us["osqp"], us["cvxpy"], atol=1e-4, rtol=0)
    free = _mpc("osqp", None, 8)
    free.reset(0.0, 1)
    u_free = free.command(0.0, st, AttitudeReference.regulation(np.eye(3)))[0]
    h_next = h[0] - look * us["osqp"]  # ω = 0
    h_free = h[0] - look * u_free
    if shape == "radial":
        assert n @ h_free > rho  # unconstrained, the momentum would leave the sphere
        assert n @ h_next <= rho + 1e-5 and np.isclose(n @ h_next, rho, atol=1e-4)
    else:
        b = rho / np.sqrt(3.0)
        bound = np.maximum(b, np.abs(h[0]))
        assert np.any(np.abs(h_free) > bound + 1e-3)
        assert np.all(np.abs(h_next) <= bound + 1e-5)


def test_envelope_constraint_keeps_zero_torque_feasible_outside_the_sphere():
    con = momentum_envelope_constraint(CLUSTER, dt=DT, radius=100.0)
    h = np.array([[150.0, 0.0, 0.0]])  # already beyond ρ = 90
    w = np.array([[0.0, 0.01, 0.0]])
    for c in (con, momentum_envelope_constraint(CLUSTER, dt=DT, radius=100.0, shape="box")):
        C, lo, hi = c(AttitudeState(np.eye(3)[None], w, h))
        assert np.all(lo <= 0.0) and np.all(hi >= 0.0)  # u = 0 satisfies lo ≤ C·0 ≤ hi


# ---------------------------------------------------------------------------------------------
# bad input


class _Quadratic(SteeringLaw):
    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None):
        lin = PseudoInverse().steer(A, hdot_cmd, delta, t, cluster)
        return lin * np.linalg.norm(hdot_cmd, axis=-1, keepdims=True)


def test_bad_input_raises_value_error_naming_the_argument():
    with pytest.raises(ValueError, match="^rate_limit"):
        cmg_gimbal_rate_constraint(CLUSTER, rate_limit=0.0)
    with pytest.raises(ValueError, match="^steering"):
        cmg_gimbal_rate_constraint(CLUSTER, steering=lambda A, h: h)
    with pytest.raises(ValueError, match="^steering"):
        cmg_gimbal_rate_constraint(CLUSTER, steering=_Quadratic())
    with pytest.raises(ValueError, match="^cluster"):
        cmg_gimbal_rate_constraint(object())
    con = cmg_gimbal_rate_constraint(CLUSTER)
    with pytest.raises(ValueError, match="^state"):
        con(AttitudeState(np.eye(3)[None], np.zeros((1, 3))))
    with pytest.raises(ValueError, match="^state.actuator_state"):
        con(AttitudeState(np.eye(3)[None], np.zeros((1, 3)), None, np.zeros((1, 3))))
    for kw, name in (({"margin": 1.5}, "margin"), ({"shape": "ball"}, "shape"),
                     ({"dt": -1.0}, "dt"), ({"radius": -1.0}, "radius")):  # fmt: skip
        args = {"dt": DT, "radius": 700.0} | kw
        with pytest.raises(ValueError, match=f"^{name}"):
            momentum_envelope_constraint(CLUSTER, **args)
    env = momentum_envelope_constraint(CLUSTER, dt=DT, radius=700.0)
    with pytest.raises(ValueError, match="^state"):
        env(AttitudeState(np.eye(3)[None], np.zeros((1, 3))))
    with pytest.raises(ValueError, match="^constraints"):
        stack_constraints()
    S, s0 = steering_map(PseudoInverse(), CLUSTER, np.zeros(4) + 0.3)
    assert S.shape == (4, 3) and np.all(s0 == 0.0)
