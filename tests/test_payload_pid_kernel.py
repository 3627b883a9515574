"""The rotating-payload PID with feed-forward (Wang, Chu, Zhang & Yuan 2016) in the compiled loop.

``SmallAnglePIDWithFeedforward.fused_kernel`` (kernel ``liecontrol._kernels.payload_pid``) must
give the Python loop's run to 1e-12 — states, commands, every diagnostic (the identifier's
amplitude, phase and residual included) — and leave the controller, its law, adapter and
identifier as the Python loop leaves them; configurations outside the kernel keep the Python
loop and say why; a start at gimbal lock gives the adapter's own error.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from conftest import simulate_fused, simulate_python_loop

from liecontrol._jit import JIT_ENABLED
from liecontrol.control.adapters import RotatingFrame
from liecontrol.control.payload_compensation import SmallAnglePIDWithFeedforward
from liecontrol.lie import so3
from spacecraft import (
    IdealTorqueActuator,
    RigidBody,
    SgcmgActuator,
    SgcmgPyramid,
    Spacecraft,
    simulate,
)
from spacecraft.disturbances import ConstantHarmonicTorque, SumOfDisturbances
from spacecraft.payload import RotatingPayload, RotatingPayloadTorque

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the fused loop needs numba")

J = np.diag([520.0, 450.0, 660.0])
WP = math.pi / 2  # 90°/s
N_ORB = 0.0011


def _payload(seed: int = 0) -> RotatingPayloadTorque:
    pay = RotatingPayload(
        mass=20.0, inertia=np.diag([2.0, 2.5, 3.0]), hinge=[0.3, -0.2, 0.8],
        com_offset=[0.05, 0.02, 0.1], spin_rate=WP, phase=0.3 * seed,
    )  # fmt: skip
    return RotatingPayloadTorque([pay])


def _case(B=2, actuator=None, disturbance=None, seed=2):
    plant = Spacecraft(RigidBody(J), actuator or IdealTorqueActuator(), disturbance or _payload())
    ref = RotatingFrame(np.eye(3), np.array([0.0, -N_ORB, 0.0]))
    rng = np.random.default_rng(seed)
    w0 = np.array([0.0, -N_ORB, 0.0]) + rng.normal(0.0, 1e-3, (B, 3))
    x0 = plant.initial_state(so3.exp(rng.normal(0.0, 0.02, (B, 3))), omega0=w0)
    return plant, ref, x0


def _assert_same(a, b, ctrl_a, ctrl_b):
    for name in ("t", "R", "omega", "R_d", "omega_d", "u_cmd", "u", "disturbance"):
        x, y = getattr(a, name), getattr(b, name)
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()))
    assert list(a.controller) == list(b.controller)
    for k, y in b.controller.items():
        x = a.controller[k]
        assert x.dtype == y.dtype and x.shape == y.shape, k
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-13, err_msg=k)  # NaN = NaN
    ia, ib = ctrl_a.identifier, ctrl_b.identifier
    np.testing.assert_allclose(ia.coefficients, ib.coefficients, rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(ia.covariance, ib.covariance, rtol=1e-10, atol=1e-13)
    assert (ia.n_updates, ia.n_repairs) == (ib.n_updates, ib.n_repairs)
    assert (ctrl_a._k_c, ctrl_a._k_p) == (ctrl_b._k_c, ctrl_b._k_p)
    for name in ("_u_last", "_u_pid", "_u_comp", "_u_int", "_w_pid", "_g_pid", "_residual"):
        np.testing.assert_allclose(getattr(ctrl_a, name), getattr(ctrl_b, name), rtol=1e-12,
                                   atol=1e-13, err_msg=name)  # fmt: skip
    np.testing.assert_allclose(ctrl_a.law._integral, ctrl_b.law._integral, rtol=1e-12, atol=1e-15)
    assert ctrl_a.law._t_last == ctrl_b.law._t_last and ctrl_a._t_pid == ctrl_b._t_pid
    for k, y in ctrl_b.diagnostics().items():
        np.testing.assert_allclose(ctrl_a.diagnostics()[k], y, rtol=1e-12, atol=1e-13, err_msg=k)


def _both(monkeypatch, make, case, t_final=40.0, dt=0.05, control_period=0.1, log_every=1):
    plant, ref, x0 = case
    runs = []
    for run in (simulate_fused, simulate_python_loop):
        ctrl = make()
        res = run(monkeypatch, plant, ctrl, ref, x0, t_final, dt,
                  control_period=control_period, log_every=log_every)  # fmt: skip
        runs.append((res, ctrl))
    (a, ca), (b, cb) = runs
    _assert_same(a, b, ca, cb)
    return b, cb


@pytest.mark.parametrize(
    "kw",
    [
        {},  # the benchmark's configuration: identify from the start, XYZ, Δt_c 0.2, Δt_p 0.1
        {"seq": "ZYX", "integral_limit": 0.02, "compensation_start": 15.0},
        {"mode": "off"},
        {"hold_correction": False, "include_bias": False, "forgetting": 0.99},
        {"extra_momentum": [0.0, 0.0, 3.0], "seq": "YXZ", "unwrap": False},
    ],
)
def test_payload_pid_in_the_fused_loop_equals_the_python_loop(kw, monkeypatch):
    kw = dict(kw)
    unwrap = kw.pop("unwrap", True)

    def make():
        c = SmallAnglePIDWithFeedforward(
            J, WP, dt_c=0.2, dt_p=0.1, **{"compensation_start": 0.0, **kw}
        )
        c.adapter.unwrap = unwrap
        return c

    res, ctrl = _both(monkeypatch, make, _case())
    if kw.get("mode") != "off":
        assert ctrl.identifier.n_updates > 100 and np.abs(res.controller["comp_torque"]).max() > 0


def test_injected_amplitudes_per_spacecraft_and_a_finer_control_period(monkeypatch):
    """``injected`` of shape (B, 3) lives in each spacecraft's state row; control every Δt_p/2
    (the PID and the feed-forward still refresh on their own grids)."""
    W = np.array([[0.02, 0.01, 0.03], [0.01, 0.02, 0.0]])
    beta = np.array([[0.3, -1.0, 2.0], [1.0, 0.0, -2.5]])

    def make():
        return SmallAnglePIDWithFeedforward(
            J, WP, dt_c=0.2, dt_p=0.1, mode="inject", injected=(W, beta), compensation_start=5.0
        )

    _both(monkeypatch, make, _case(), t_final=20.0, dt=0.025, control_period=0.05, log_every=3)


def test_cmg_plant_payload_and_orbit_torque_batch_of_one(monkeypatch):
    plant_dist = SumOfDisturbances({"payload": _payload(1), "orbit": ConstantHarmonicTorque()})
    act = SgcmgActuator(SgcmgPyramid(h0=20.0))

    def make():
        return SmallAnglePIDWithFeedforward(J, WP, dt_c=0.2, dt_p=0.1, compensation_start=10.0)

    _both(monkeypatch, make, _case(1, act, plant_dist, seed=4), t_final=30.0, dt=0.1)


def test_configurations_outside_the_kernel_keep_the_python_loop_and_say_why(caplog):
    plant, ref, x0 = _case(1)
    slow = SmallAnglePIDWithFeedforward(J, WP, dt_c=0.2, dt_p=0.1, gyro_momentum="controller")
    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        simulate(plant, slow, ref, x0, 0.4, 0.1, control_period=0.1)
    assert "gyro_momentum='controller'" in caplog.text
    # a control period longer than Δt_p: the Python loop runs and refuses it, as before
    coarse = SmallAnglePIDWithFeedforward(J, WP, dt_c=0.2, dt_p=0.1)
    with pytest.raises(ValueError, match="^t: .* exceeds dt_p"):
        simulate(plant, coarse, ref, x0, 1.0, 0.1, control_period=0.2)


def test_a_start_at_gimbal_lock_gives_the_adapters_own_error():
    from liecontrol.exceptions import ChartSingularityError

    plant, ref, _ = _case(1)
    x0 = plant.initial_state(so3.exp(np.array([0.0, math.pi / 2, 0.0])), omega0=[0.0, -N_ORB, 0])
    ctrl = SmallAnglePIDWithFeedforward(J, WP, dt_c=0.2, dt_p=0.1)
    with pytest.raises(ChartSingularityError, match="gimbal lock"):
        simulate(plant, ctrl, ref, x0, 1.0, 0.1, control_period=0.1)


def test_rates_matrix_kernel_equals_the_chart_for_every_sequence_near_lock():
    """``_kernels.euler.rates_matrix_into`` = ``charts.euler.rates_matrix`` (all 24 sequences,
    random angles and a2 within 1e-6 rad of the lock tolerance's edge) and returns det M."""
    from liecontrol._kernels.euler import rates_matrix_into
    from liecontrol.charts import euler

    rng = np.random.default_rng(7)
    seqs = [a + b + c for a in "xyz" for b in "xyz" for c in "xyz" if a != b and b != c]
    seqs += [s.upper() for s in seqs]
    assert len(seqs) == 24
    tol = 1e-2
    for seq in seqs:
        i, j, k, ext = euler.kernel_axes(seq)
        # the lock tolerance's edge, 1e-6 rad on the defined side: |cos a2| or |sin a2| > tol
        edge = math.acos(tol) - 1e-6 if i != k else math.asin(tol) + 1e-6
        a2s = list(rng.uniform(-1.4, 1.4, 20) + (0.0 if i != k else 1.6)) + [edge, -edge]
        for a2 in a2s:
            a = np.array([rng.uniform(-math.pi, math.pi), a2, rng.uniform(-math.pi, math.pi)])
            out = np.empty((3, 3))
            det = rates_matrix_into(a, i, j, k, ext, out)
            ref = euler.rates_matrix(a, seq, tol)
            np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())
            np.testing.assert_allclose(det * np.linalg.det(ref), 1.0, rtol=1e-9)


def test_covariance_test_of_the_kernel_is_eigvalsh_s():
    """``_positive_definite`` (leading minors, eigvalsh near the boundary) = the NumPy
    identifier's ``eigvalsh(P)[0] > 0`` on random, nearly singular, indefinite and zero
    covariances, p = 2 and 3."""
    from liecontrol._kernels.payload_pid import _positive_definite

    rng = np.random.default_rng(11)
    for p in (2, 3):
        cases = []
        for _ in range(300):
            Q = so3.random(rng)[:p, :p] if p == 3 else np.linalg.qr(rng.normal(size=(2, 2)))[0]
            lam = rng.choice([1.0, -1.0, 1e-12, -1e-12, 0.0, 1e-6], size=p) * 10 ** rng.uniform(
                -3, 6, size=p
            )
            cases.append((Q * lam) @ Q.T)
        cases += [np.zeros((p, p)), np.eye(p), -np.eye(p), np.diag([1.0] + [0.0] * (p - 1))]
        for S in cases:
            S = 0.5 * (S + S.T)
            P = np.zeros((3, 3))
            P[:p, :p] = S
            assert _positive_definite(P, p) == (np.linalg.eigvalsh(S)[0] > 0.0), S


def test_vectorised_reference_samples_equal_the_calls_and_a_bad_one_falls_back(monkeypatch, caplog):
    """``samples(times)`` of the Earth-pointing reference (shared and per-spacecraft offset) and
    of a rotating frame = their calls; the fused run through them = the Python loop; a
    ``samples`` that returns the wrong shape is logged and the reference sampled call by call."""
    from spacecraft.orbit import CircularOrbit, EarthPointingReference

    rng = np.random.default_rng(3)
    times = np.sort(rng.uniform(0.0, 6000.0, 40))
    orbit = CircularOrbit(inclination=0.9)
    refs = [
        EarthPointingReference(orbit),
        EarthPointingReference(orbit, so3.exp(rng.normal(0.0, 0.3, (2, 3)))),
        RotatingFrame(so3.random(rng), np.array([0.01, -0.02, 0.03]), t0=5.0),
    ]
    for ref in refs:
        R, w, dw = ref.samples(times)
        for k, t in enumerate(times):
            r = ref(t)
            np.testing.assert_allclose(R[k], r.R_d, rtol=0, atol=1e-15)
            np.testing.assert_allclose(w[k], r.omega_d, rtol=0, atol=1e-18)
            np.testing.assert_array_equal(dw[k], r.omega_dot_d)
    plant, _, _ = _case(2)
    R0 = refs[1].samples(np.zeros(1))[0][0] @ so3.exp(rng.normal(0.0, 0.02, (2, 3)))
    x0 = plant.initial_state(R0, omega0=refs[1].omega_d + rng.normal(0.0, 1e-3, (2, 3)))

    def make():
        return SmallAnglePIDWithFeedforward(J, WP, dt_c=0.2, dt_p=0.1, compensation_start=2.0)

    _both(monkeypatch, make, (plant, refs[1], x0), t_final=8.0)

    class BadSamples(EarthPointingReference):
        def samples(self, times):
            R, w, dw = super().samples(times)
            return R[:-1], w, dw

    with caplog.at_level(logging.INFO, logger="spacecraft.simulator"):
        _both(monkeypatch, make, (plant, BadSamples(orbit, refs[1].offset), x0), t_final=4.0)
    assert "BadSamples.samples() did not give valid arrays" in caplog.text


def test_slew_profile_and_constant_rate_samples_equal_their_calls():
    """``samples`` of the benchmark's other time-varying references: before, inside every
    segment, on every knot and after the eigenaxis profile (with and without a coast)."""
    from benchmarks.runner import ConstantRateReference
    from liecontrol.control.slew_profile import EigenaxisSlewProfile

    rng = np.random.default_rng(5)
    refs = [ConstantRateReference(so3.random(rng), np.array([0.01, -0.003, 0.02]), t0=3.0)]
    for rate in (0.02, 0.5):  # a coast, and a profile that never reaches its rate limit
        p = EigenaxisSlewProfile(
            so3.random(rng), so3.random(rng), max_rate=rate, max_accel=0.002, max_jerk=1e-4,
            t0=10.0,
        )  # fmt: skip
        refs.append(p)
    for ref in refs:
        knots = [10.0 + kn[0] for kn in getattr(ref, "_knots", ())]
        end = getattr(ref, "slew_time", 100.0) + 10.0
        times = np.concatenate([rng.uniform(-5.0, end + 20.0, 200), knots, [10.0, end]])
        R, w, dw = ref.samples(times)
        for k, t in enumerate(times):
            r = ref(t)
            np.testing.assert_allclose(R[k], r.R_d, rtol=0, atol=2e-15)
            np.testing.assert_allclose(w[k], r.omega_d, rtol=1e-13, atol=1e-18)
            np.testing.assert_allclose(dw[k], r.omega_dot_d, rtol=1e-13, atol=1e-18)


def test_stacked_reference_samples_equal_its_calls():
    """The suite's stacked batch: members with and without ``samples`` (a constant attitude of
    two rows, a user's callable), per-spacecraft offsets, sizes 2, 2, 1, 3."""
    from benchmarks.runner import ConstantRateReference, StackedReference
    from liecontrol.control.reference import ConstantAttitude
    from spacecraft.orbit import CircularOrbit, EarthPointingReference

    rng = np.random.default_rng(9)
    rate = ConstantRateReference(so3.random(rng), np.array([0.0, 0.01, -0.02]))
    members = [
        EarthPointingReference(CircularOrbit(), so3.random(rng, (2,))),
        ConstantAttitude(so3.random(rng, (2,))),
        lambda t: rate(t),  # a user's reference without samples
        rate,
    ]
    stack = StackedReference(members, [2, 2, 1, 3])
    assert stack.time_invariant is False
    assert StackedReference([members[1]], [2]).time_invariant is True
    times = np.linspace(0.0, 500.0, 7)
    R, w, dw = stack.samples(times)
    assert R.shape == (7, 8, 3, 3) and w.shape == dw.shape == (7, 8, 3)
    for k, t in enumerate(times):
        r = stack(t)
        np.testing.assert_allclose(R[k], r.R_d, rtol=0, atol=2e-15)
        np.testing.assert_allclose(w[k], r.omega_d, rtol=1e-13, atol=1e-18)
        np.testing.assert_array_equal(dw[k], r.omega_dot_d)


def test_a_weak_prior_gets_room_under_the_covariance_cap():
    """``initial_covariance`` ≥ 1e6 used to fail on the identifier's own default cap, naming an
    argument the caller never passed; the cap now follows the prior unless given."""
    ctrl = SmallAnglePIDWithFeedforward(J, WP, initial_covariance=1e7)
    assert ctrl.identifier.max_covariance == 1e10
    assert SmallAnglePIDWithFeedforward(J, WP).identifier.max_covariance == 1e6
    with pytest.raises(ValueError, match="^max_covariance"):
        SmallAnglePIDWithFeedforward(J, WP, initial_covariance=1e3, max_covariance=10.0)
