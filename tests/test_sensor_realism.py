"""Sensor and loop realism: star-tracker boresight noise, latency and outages; gyro scale
factor, misalignment, quantisation and bandwidth; wheel friction and torque quantisation; the
simulator's compute delay; their scenario-file keys. Each statistic against its model."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, signal

from benchmarks.scenario_files import ScenarioFileError, scenario_from_dict, scenario_to_dict
from benchmarks.scenarios import SensorSpec, SpacecraftSpec
from liecontrol.control import ConstantAttitude
from liecontrol.control.base import AttitudeController
from liecontrol.lie import so3
from spacecraft import RigidBody, Spacecraft, simulate
from spacecraft.actuators import IdealTorqueActuator, ReactionWheelAssembly, WheelCommand
from spacecraft.sensors import RateGyro, StarTracker, TimedSensor

J = np.diag([12.0, 10.0, 8.0])


# ---------------------------------------------------------------------------- star tracker
def test_boresight_cross_boresight_std_ratio_matches_the_model():
    """δ = log(R_m) of many seeded samples: std along the boresight / across it = σ_b/σ_c."""
    b = np.array([1.0, 2.0, 2.0]) / 3.0
    sc, sb = 2e-5, 1.6e-4  # ratio 8 (Liebe 2002: ≈ 7.5 for a 20° field of view)
    st = StarTracker(
        output="matrix", boresight=b, cross_boresight_std=sc, boresight_std=sb, period=0.1
    )
    N = 40_000
    Rm = st.measure(0.0, np.broadcast_to(np.eye(3), (N, 3, 3)), None, np.random.default_rng(3))
    d = so3.log(Rm)
    along = d @ b
    e1 = np.cross(b, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(b, e1)
    tol = 4.0 / math.sqrt(2 * N)  # relative std error of a sample std ≈ 1/√(2N)
    assert abs(along.std() / sb - 1.0) < tol
    for e in (e1, e2):
        assert abs((d @ e).std() / sc - 1.0) < tol
    ratio = along.std() / np.hypot((d @ e1).std(), (d @ e2).std()) * math.sqrt(2)
    assert abs(ratio / 8.0 - 1.0) < 2 * tol
    # the covariance property against the sample covariance
    np.testing.assert_allclose(np.cov(d.T), st.covariance, atol=6 * sb**2 / math.sqrt(N))
    np.testing.assert_allclose(
        st.covariance, sc**2 * (np.eye(3) - np.outer(b, b)) + sb**2 * np.outer(b, b), atol=1e-20
    )


def test_isotropic_boresight_model_equals_per_axis_model_bitwise():
    R = so3.exp(np.array([[0.3, -0.2, 0.1]]))
    a = StarTracker(noise_std=1e-4, output="matrix").measure_matrix(R, np.random.default_rng(1))
    b = StarTracker(
        cross_boresight_std=1e-4, boresight_std=1e-4, output="matrix"
    ).measure_matrix(R, np.random.default_rng(1))
    np.testing.assert_array_equal(a, b)


def test_star_tracker_bad_input_named():
    with pytest.raises(ValueError, match="^noise_std:"):
        StarTracker(noise_std=1e-4, boresight_std=1e-3)
    with pytest.raises(ValueError, match="^boresight:"):
        StarTracker(boresight=[1.0, 1.0, 0.0], boresight_std=1e-3)
    with pytest.raises(ValueError, match="^cross_boresight_std:"):
        StarTracker(cross_boresight_std=-1e-5)
    with pytest.raises(ValueError, match="^boresight_std:"):
        StarTracker(boresight_std=float("nan"))


# ---------------------------------------------------------------------------- latency, outages
def _rotating(t: float) -> np.ndarray:
    return so3.exp(np.array([[0.1, -0.05, 0.2]]) * t)


def test_latency_shifts_the_measurement_by_exactly_L():
    """Published at t_k (every P = 0.2 s) = the state at t_k − L (L = 0.3 s); called every
    gcd(P, L) = 0.1 s; before t₀ + L the state at t₀, flagged invalid."""
    ts = TimedSensor(StarTracker(output="matrix", period=0.2), latency=0.3)
    assert ts.period == pytest.approx(0.1) and ts.update_period == 0.2
    rng = np.random.default_rng(0)
    last_pub = None
    for k in range(40):
        t = 0.1 * k
        y = ts.measure(t, _rotating(t), None, rng)
        if k % 2 == 0:
            last_pub = t
        src = max(last_pub - 0.3, 0.0)
        np.testing.assert_allclose(y, _rotating(src), atol=1e-14)
        assert ts.valid.tolist() == [last_pub >= 0.3 - 1e-12]


def test_latency_in_the_loop_is_logged_with_the_valid_flag():
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    s0 = plant.initial_state(np.eye(3)[None], omega0=np.array([[0.02, -0.01, 0.03]]))
    sensors = {
        "st": TimedSensor(
            StarTracker(output="matrix", period=0.2), latency=0.4, outages=[(2.0, 2.6)]
        )
    }
    res = simulate(
        plant, _OpenLoop(lambda t: np.zeros(3)), ConstantAttitude(np.eye(3)), s0, 4.0, 0.1,
        sensors=sensors, rng=np.random.default_rng(0),
    )  # fmt: skip
    y, valid = res.sensors["st"][:, 0], res.sensors["st_valid"][:, 0]
    for k, t in enumerate(res.t):
        pub = 0.2 * math.floor(t / 0.2 + 1e-9)
        if 2.0 - 1e-9 <= pub < 2.6 - 1e-9:  # outage: the last output before it is held
            pub = 1.8
        want = res.R[int(round(max(pub - 0.4, 0.0) / 0.1)), 0]
        np.testing.assert_allclose(y[k], want, atol=1e-13)
        in_out = 2.0 - 1e-9 <= 0.2 * math.floor(t / 0.2 + 1e-9) < 2.6 - 1e-9
        assert bool(valid[k]) == (t >= 0.4 - 1e-9 and not in_out)


def test_random_outages_occur_at_the_poisson_rate_and_are_seeded():
    """Outage duration = one period: every publication is an independent Bernoulli(p),
    p = 1 − exp(−λP); the fraction flagged invalid estimates p."""
    lam, P, B, n = 0.5, 0.2, 40, 1000
    ts = TimedSensor(StarTracker(period=P), outage_rate=lam, outage_duration=P)
    R = np.broadcast_to(np.eye(3), (B, 3, 3))
    rng = np.random.default_rng(11)
    bad = 0
    for k in range(n):
        ts.measure(P * k, R, None, rng)
        bad += int((~ts.valid).sum())
    p = -math.expm1(-lam * P)
    assert abs(bad / (n * B) - p) < 4 * math.sqrt(p * (1 - p) / (n * B))
    ts2 = TimedSensor(StarTracker(period=P), outage_rate=lam, outage_duration=P)
    rng2 = np.random.default_rng(11)
    bad2 = 0
    for k in range(n):
        ts2.measure(P * k, R, None, rng2)
        bad2 += int((~ts2.valid).sum())
    assert bad2 == bad


def test_outage_holds_the_output():
    ts = TimedSensor(StarTracker(noise_std=1e-3, period=0.5), outages=[(1.0, 2.0)])
    rng = np.random.default_rng(0)
    R = np.eye(3)[None]
    ys = [ts.measure(0.5 * k, R, None, rng).copy() for k in range(6)]
    np.testing.assert_array_equal(ys[2], ys[1])  # t = 1.0: held
    np.testing.assert_array_equal(ys[3], ys[1])  # t = 1.5: held
    assert not np.array_equal(ys[4], ys[1])  # t = 2.0: fresh
    assert ts.valid.tolist() == [True]


def test_timed_sensor_bad_input_named():
    st = StarTracker(period=0.2)
    with pytest.raises(ValueError, match="^latency:"):
        TimedSensor(st, latency=-0.1)
    with pytest.raises(ValueError, match="^outages:"):
        TimedSensor(st, outages=[(2.0, 1.0)])
    with pytest.raises(ValueError, match="^outages:"):
        TimedSensor(st, outages=5)
    with pytest.raises(ValueError, match="^outage_rate: needs outage_duration"):
        TimedSensor(st, outage_rate=0.1)
    with pytest.raises(ValueError, match="^outage_duration:"):
        TimedSensor(st, outage_rate=0.1, outage_duration=0.0)
    with pytest.raises(ValueError, match="^outage_rate:"):
        TimedSensor(st, outage_rate=-1.0, outage_duration=1.0)
    with pytest.raises(ValueError, match="^sensor:"):
        TimedSensor(object())
    # a latency that is not a multiple of the step: the simulator names the sensor and dt
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    s0 = plant.initial_state(np.eye(3)[None])
    with pytest.raises(ValueError, match="^sensors:.*'st'.*dt"):
        simulate(
            plant, _OpenLoop(lambda t: np.zeros(3)), ConstantAttitude(np.eye(3)), s0, 1.0, 0.1,
            sensors={"st": TimedSensor(st, latency=0.05)}, rng=np.random.default_rng(0),
        )  # fmt: skip
    # latency 0.15 with period 0.2: the sensor's internal grid is gcd = 0.05 s, which the user
    # never set; the message names the latency and the period instead
    with pytest.raises(ValueError, match=r"^sensors: 'st' latency 0\.15 and period 0\.2 "):
        simulate(
            plant, _OpenLoop(lambda t: np.zeros(3)), ConstantAttitude(np.eye(3)), s0, 1.0, 0.1,
            sensors={"st": TimedSensor(st, latency=0.15)}, rng=np.random.default_rng(0),
        )  # fmt: skip


# ---------------------------------------------------------------------------- gyro
W = np.array([[0.1, -0.2, 0.05]])


def test_scale_factor_and_misalignment_on_a_constant_rate():
    s = np.array([1e-3, -2e-3, 5e-4])
    g = RateGyro(scale_factor=s, period=0.1)
    y = g.measure(0.0, None, W, np.random.default_rng(0))
    np.testing.assert_allclose(y, W * (1.0 + s), rtol=0, atol=1e-17)
    m = np.array([1e-3, -2e-3, 3e-3])  # small rotation: (I + m^) ω = ω + m × ω
    y = RateGyro(misalignment=m).measure(0.0, None, W, np.random.default_rng(0))
    np.testing.assert_allclose(y, W + np.cross(m, W), atol=1e-17)
    M = np.array([[0.0, 1e-3, 0.0], [2e-3, 0.0, 0.0], [0.0, -1e-3, 0.0]])  # non-orthogonal
    y = RateGyro(misalignment=M, scale_factor=s).measure(0.0, None, W, np.random.default_rng(0))
    np.testing.assert_allclose(y[0], (np.eye(3) + np.diag(s) + M) @ W[0], atol=1e-17)
    # the integrated angle error of a scale-factor error grows as s·ω·t
    g = RateGyro(scale_factor=s, period=0.1)
    rng = np.random.default_rng(0)
    ang = sum(g.measure(0.1 * k, None, W, rng) * 0.1 for k in range(100))
    np.testing.assert_allclose(ang - W * 10.0, s * W * 10.0, rtol=1e-9)


def test_quantisation_step():
    q = 1e-3
    g = RateGyro(quantization=q, white_std=3e-3, period=0.1)
    rng = np.random.default_rng(4)
    ys = np.concatenate([g.measure(0.1 * k, None, W, rng) for k in range(2000)])
    n = ys / q
    np.testing.assert_allclose(n, np.round(n), atol=1e-9)  # every output is a multiple of q
    levels = np.unique(np.round(n[:, 0]))
    assert len(levels) > 5 and np.diff(levels).min() == 1.0  # the finest spacing is one LSB
    # no noise: the output is the nearest level, within q/2 of the true rate
    q = 3e-3  # W is not on this grid
    y = RateGyro(quantization=q).measure(0.0, None, W, np.random.default_rng(0))
    np.testing.assert_allclose(y, np.round(W / q) * q, atol=1e-17)
    assert np.all(np.abs(y - W) <= q / 2) and not np.array_equal(y, W)


def test_low_pass_step_response_time_constant():
    """First-order low-pass of bandwidth f_c: y(t) = 1 − exp(−t/τ), τ = 1/(2π f_c), against
    scipy's continuous step response."""
    fc, P = 2.0, 0.01
    g = RateGyro(bandwidth=fc, period=P)
    rng = np.random.default_rng(0)
    g.measure(0.0, None, np.zeros((1, 3)), rng)  # steady state at rest
    t = P * np.arange(1, 101)
    y = np.array([g.measure(tk, None, np.ones((1, 3)), rng)[0, 0] for tk in t])
    tau = 1.0 / (2 * np.pi * fc)
    assert g.time_constant == pytest.approx(tau)
    _, y_ref = signal.step(signal.lti([1.0], [tau, 1.0]), T=np.concatenate([[0.0], t]))
    np.testing.assert_allclose(y, y_ref[1:], atol=1e-12)
    t63 = np.interp(1 - math.exp(-1), y, t)  # the 63.2 % time is τ
    assert abs(t63 - tau) < 1e-3 * tau


def test_gyro_defaults_unchanged_and_bad_input_named():
    a = RateGyro(white_std=1e-3, bias_rw_std=1e-5, period=0.1)
    b = RateGyro(white_std=1e-3, bias_rw_std=1e-5, period=0.1, scale_factor=0.0,
                 misalignment=np.zeros(3), quantization=0.0, bandwidth=None)  # fmt: skip
    ra, rb = np.random.default_rng(2), np.random.default_rng(2)
    for k in range(5):
        ya, yb = a.measure(0.1 * k, None, W, ra), b.measure(0.1 * k, None, W, rb)
        np.testing.assert_array_equal(ya, yb)
    for kw, key in (
        ({"scale_factor": -1.0}, "scale_factor"),
        ({"scale_factor": [0.1, 0.2]}, "scale_factor"),
        ({"misalignment": np.eye(3)}, "misalignment"),
        ({"misalignment": [1.0, 2.0]}, "misalignment"),
        ({"quantization": -1e-3}, "quantization"),
        ({"bandwidth": 0.0}, "bandwidth"),
    ):
        with pytest.raises(ValueError, match=f"^{key}:"):
            RateGyro(**kw)


# ---------------------------------------------------------------------------- wheel friction
def _friction_ref(w, tc, cv, ts, ws, eps):
    return -(tc + (ts - tc) * np.exp(-((w / ws) ** 2))) * np.tanh(w / eps) - cv * w


def test_friction_torque_law():
    tc, cv, ts, ws, eps = 2e-3, 1e-5, 5e-3, 3.0, 0.01
    act = ReactionWheelAssembly.orthogonal(
        coulomb_friction=tc, viscous_friction=cv, stribeck_torque=ts, stribeck_speed=ws
    )
    w = np.array([[-300.0, -2.0, 0.0], [0.004, 1.0, 500.0]])
    np.testing.assert_allclose(
        act.friction_torque(w), _friction_ref(w, tc, cv, ts, ws, eps), rtol=1e-14
    )
    np.testing.assert_array_equal(act.friction_torque(-w), -act.friction_torque(w))  # odd
    # far above ω_s and ε: Coulomb + viscous; at low speed the breakaway level τ_s
    assert act.friction_torque(np.array([400.0, 0, 0]))[0] == pytest.approx(-(tc + cv * 400))
    assert act.friction_torque(np.array([1.0, 0, 0]))[0] == pytest.approx(
        -(tc + (ts - tc) * math.exp(-1 / 9)) - cv, rel=1e-12
    )


def _zero_command(act: ReactionWheelAssembly, B: int = 1) -> WheelCommand:
    z = np.zeros((B, act.n_wheels))
    return WheelCommand(z, z, z.astype(bool), z.astype(bool), np.zeros((B, 3)))


def test_spin_down_follows_the_friction_law_and_dissipates_its_work():
    """A free wheel: I Ω̇ = τ_f(Ω). Viscous only: Ω₀ e^{−c t/I}; Coulomb only: Ω₀ − τ_c t/I.
    Energy lost ½I(Ω₀² − Ω²) = ∫ −τ_f Ω dt (quadrature of the solution)."""
    Iw, w0 = 0.01, 200.0
    held = None

    def run(act, T):
        nonlocal held
        held = _zero_command(act)
        f = lambda t, x: act.state_derivative(x[None], held)[0]  # noqa: E731
        return integrate.solve_ivp(f, (0, T), [w0, 0, 0], rtol=1e-11, atol=1e-11,
                                   dense_output=True)  # fmt: skip

    visc = ReactionWheelAssembly.orthogonal(wheel_inertia=Iw, viscous_friction=2e-5)
    sol = run(visc, 100.0)
    np.testing.assert_allclose(sol.y[0, -1], w0 * math.exp(-2e-5 * 100 / Iw), rtol=1e-8)
    coul = ReactionWheelAssembly.orthogonal(wheel_inertia=Iw, coulomb_friction=1e-3)
    sol = run(coul, 100.0)
    np.testing.assert_allclose(sol.y[0, -1], w0 - 1e-3 * 100 / Iw, rtol=1e-8)
    both = ReactionWheelAssembly.orthogonal(
        wheel_inertia=Iw, coulomb_friction=1e-3, viscous_friction=2e-5
    )
    sol = run(both, 150.0)
    t = np.linspace(0, 150.0, 20001)
    x = sol.sol(t)[0]
    power = -both.friction_torque(np.stack([x, 0 * x, 0 * x], -1))[:, 0] * x
    lost = integrate.simpson(power, x=t)
    np.testing.assert_allclose(lost, 0.5 * Iw * (w0**2 - x[-1] ** 2), rtol=1e-6)


def test_friction_is_internal_momentum_is_conserved_in_the_loop():
    act = ReactionWheelAssembly.pyramid(
        wheel_inertia=0.01, coulomb_friction=2e-3, viscous_friction=1e-5,
        initial_speeds=[300.0, -200.0, 100.0, 50.0],
    )  # fmt: skip
    plant = Spacecraft(RigidBody(J), act)

    def both_law(w):
        return _friction_ref(w, 2e-3, 1e-5, 2e-3, 1.0, 0.01)

    s0 = plant.initial_state(np.eye(3)[None], omega0=np.array([[0.01, 0.02, -0.01]]))
    res = simulate(plant, _OpenLoop(lambda t: np.zeros(3)), ConstantAttitude(np.eye(3)),
                   s0, 60.0, 0.05, log_every=100)  # fmt: skip
    H = np.einsum("kbij,kbj->kbi", res.R, res.omega @ J + res.actuator["h"])
    drift = np.abs(H - H[0]).max() / np.linalg.norm(H[0])
    assert drift < 1e-9
    f = res.actuator["friction_torque"]
    np.testing.assert_allclose(f, both_law(res.actuator["wheel_speed"]), rtol=1e-12)
    assert np.abs(f).min() > 1e-3  # every wheel feels friction all along


def test_torque_quantisation():
    q = 1e-3
    act = ReactionWheelAssembly.pyramid(wheel_inertia=0.01, max_torque=0.0105, torque_lsb=q)
    rng = np.random.default_rng(0)
    u = rng.normal(scale=0.01, size=(200, 3))
    held = act.command(u, np.zeros((200, 3)), np.zeros((200, 4)), 0.0)
    n = held.torque / q
    unclipped = np.abs(held.torque_cmd) < 0.0105 - q
    np.testing.assert_allclose(n[unclipped], np.round(n[unclipped]), atol=1e-9)
    assert np.all(np.abs(held.torque - held.torque_cmd)[unclipped] <= q / 2 + 1e-15)
    assert np.all(np.abs(held.torque) <= 0.0105)
    with pytest.raises(ValueError, match="^torque_lsb:"):
        ReactionWheelAssembly.pyramid(torque_lsb=-1.0)
    with pytest.raises(ValueError, match="^stribeck_torque: needs stribeck_speed"):
        ReactionWheelAssembly.pyramid(stribeck_torque=1e-3)
    with pytest.raises(ValueError, match="^stribeck_speed:"):
        ReactionWheelAssembly.pyramid(stribeck_torque=1e-3, stribeck_speed=-1.0)
    with pytest.raises(ValueError, match="^stribeck_torque:"):
        ReactionWheelAssembly.pyramid(coulomb_friction=2e-3, stribeck_torque=1e-3, stribeck_speed=1)
    with pytest.raises(ValueError, match="^viscous_friction:"):
        ReactionWheelAssembly.pyramid(viscous_friction=-1e-5)


# ---------------------------------------------------------------------------- compute delay
class _OpenLoop(AttitudeController):
    """Feed-forward torque u(t), the same for every spacecraft (ignores the state)."""

    def __init__(self, u):
        self.u = u

    def reset(self, t0, batch_size):
        pass

    def command(self, t, state, reference):
        return np.broadcast_to(self.u(t), state.omega.shape).copy()


def _u(t: float) -> np.ndarray:
    return np.array([math.sin(0.7 * t), 0.5 * math.cos(0.3 * t), -0.2]) * 0.05


@pytest.mark.parametrize(("dt", "period", "delay"), [(0.1, 0.1, 0.3), (0.05, 0.2, 0.15)])
def test_delay_shifts_the_response_by_exactly_tau(dt, period, delay):
    """The delayed run equals an undelayed run whose feed-forward command is u(t − τ) (0
    before τ): the trajectory and the applied command are shifted by exactly τ."""
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    s0 = plant.initial_state(so3.exp(np.array([[0.1, 0.2, -0.3]])), omega0=np.array([[0.01, 0, 0]]))
    ref = ConstantAttitude(np.eye(3))
    T = 6.0
    delayed = simulate(plant, _OpenLoop(_u), ref, s0, T, dt, control_period=period,
                       compute_delay=delay)  # fmt: skip

    def shifted(t):  # the command computed at the last control sample ≤ t − τ
        if t < delay - 1e-9:
            return np.zeros(3)
        return _u(period * math.floor((t - delay) / period + 1e-9))

    ref_run = simulate(plant, _OpenLoop(shifted), ref, s0, T, dt, control_period=dt)
    np.testing.assert_allclose(delayed.u_cmd, ref_run.u_cmd, atol=0, rtol=0)
    np.testing.assert_allclose(delayed.R, ref_run.R, atol=1e-14)
    np.testing.assert_allclose(delayed.omega, ref_run.omega, atol=1e-15)
    # and the logged command is the undelayed one, τ later
    plain = simulate(plant, _OpenLoop(_u), ref, s0, T, dt, control_period=period)
    n = round(delay / dt)
    np.testing.assert_array_equal(delayed.u_cmd[n:], plain.u_cmd[:-n])
    assert not np.any(delayed.u_cmd[:n])


def test_delay_with_a_compiled_capable_controller():
    """A geometric PD on an ideal actuator (a pair the compiled loop could run) still gets the
    delay: zero torque until τ, then the undelayed run's first command."""
    from liecontrol.control import GeometricPD

    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    s0 = plant.initial_state(so3.exp(np.array([[0.1, 0.2, -0.3]])))
    ctrl = GeometricPD(J, 2.0, 4.0)
    ref = ConstantAttitude(np.eye(3))
    d = simulate(plant, ctrl, ref, s0, 2.0, 0.1, compute_delay=0.3)
    a = simulate(plant, ctrl, ref, s0, 2.0, 0.1)
    assert not np.any(d.u_cmd[:3]) and np.any(a.u_cmd[0])
    np.testing.assert_array_equal(d.u_cmd[3], a.u_cmd[0])  # computed on the same state at t₀


def test_zero_delay_is_bit_identical():
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    s0 = plant.initial_state(so3.exp(np.array([[0.1, 0.2, -0.3]])))
    ref = ConstantAttitude(np.eye(3))
    a = simulate(plant, _OpenLoop(_u), ref, s0, 2.0, 0.1)
    b = simulate(plant, _OpenLoop(_u), ref, s0, 2.0, 0.1, compute_delay=0.0)
    np.testing.assert_array_equal(a.R, b.R)
    np.testing.assert_array_equal(a.u_cmd, b.u_cmd)


@pytest.mark.parametrize("bad", [0.15, -0.1, float("nan"), float("inf")])
def test_bad_compute_delay_named(bad):
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    s0 = plant.initial_state(np.eye(3)[None])
    with pytest.raises(ValueError, match="^compute_delay:"):
        simulate(plant, _OpenLoop(_u), ConstantAttitude(np.eye(3)), s0, 1.0, 0.1,
                 compute_delay=bad)  # fmt: skip
    with pytest.raises(TypeError, match="^compute_delay:"):
        simulate(plant, _OpenLoop(_u), ConstantAttitude(np.eye(3)), s0, 1.0, 0.1,
                 compute_delay=True)  # fmt: skip


@pytest.mark.parametrize("delay", [1.0, 1.5])
def test_compute_delay_not_shorter_than_the_run_is_rejected(delay):
    # 10 steps of 0.1 s: a delay of 1.0 s or more means no command ever reaches the actuator
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    s0 = plant.initial_state(np.eye(3)[None])
    with pytest.raises(ValueError, match="^compute_delay: must be shorter than the run"):
        simulate(plant, _OpenLoop(_u), ConstantAttitude(np.eye(3)), s0, 1.0, 0.1,
                 compute_delay=delay)  # fmt: skip
    # one step shorter is a valid run: the last step applies the first command
    r = simulate(plant, _OpenLoop(_u), ConstantAttitude(np.eye(3)), s0, 1.0, 0.1,
                 compute_delay=0.9)  # fmt: skip
    assert np.all(r.u_cmd[:-2] == 0.0) and np.any(r.u_cmd[-2] != 0.0)


# ---------------------------------------------------------------------------- scenario files
def _scenario(**tables):
    d = {"name": "realism", "duration": 10.0, "dt": 0.1}
    d.update(tables)
    return scenario_from_dict(d)


def test_scenario_file_keys_reach_the_models():
    from benchmarks.runner import build_actuator, build_sensors

    s = _scenario(
        sensors={
            "cross_boresight_arcsec": 2.0, "boresight_arcsec": 16.0, "boresight": [1.0, 0, 0],
            "star_tracker_latency": 0.3, "star_tracker_outages": [[5.0, 6.0]],
            "outage_rate": 0.01, "outage_duration": 2.0, "gyro_scale_factor": 1e-4,
            "gyro_misalignment": [1e-4, 0, 0], "gyro_quantization": 1e-6, "gyro_bandwidth": 10.0,
            "compute_delay": 0.2,
        },
        spacecraft={
            "actuator": "wheels", "wheel_coulomb_friction": 1e-3, "wheel_viscous_friction": 1e-6,
            "wheel_stribeck_torque": 2e-3, "wheel_stribeck_speed": 2.0, "wheel_torque_lsb": 1e-4,
        },
    )  # fmt: skip
    sensors, _, _ = build_sensors(s.sensors)
    st = sensors["star_tracker"]
    assert isinstance(st, TimedSensor) and st.latency == 0.3 and st.outages == ((5.0, 6.0),)
    assert st.sensor.boresight_std == pytest.approx(math.radians(16 / 3600))
    assert sensors["gyro"].bandwidth == 10.0 and sensors["gyro"].scale_factor[0] == 1e-4
    act = build_actuator(s.spacecraft)
    assert act.coulomb_friction[0] == 1e-3 and act.torque_lsb == 1e-4
    assert s.sensors.compute_delay == 0.2
    assert scenario_from_dict(scenario_to_dict(s)) == s  # the keys survive a round trip


@pytest.mark.parametrize(
    ("table", "key", "value"),
    [
        ("sensors", "compute_delay", 0.15),
        ("sensors", "star_tracker_latency", -0.1),
        ("sensors", "star_tracker_outages", [[3.0, 1.0]]),
        ("sensors", "outage_rate", 0.1),
        ("sensors", "gyro_bandwidth", 0.0),
        ("sensors", "gyro_scale_factor", -1.5),
        ("sensors", "boresight_arcsec", -1.0),
        ("spacecraft", "wheel_coulomb_friction", -1e-3),
        ("spacecraft", "wheel_stribeck_torque", 1e-3),
    ],
)
def test_bad_scenario_keys_are_named(table, key, value):
    with pytest.raises(ScenarioFileError) as err:
        _scenario(**{table: {key: value}})
    assert f".{key}:" in str(err.value) or f"{key} " in str(err.value)


def test_spec_defaults_leave_the_models_unchanged():
    from benchmarks.runner import build_sensors

    sensors, _, _ = build_sensors(SensorSpec())
    assert isinstance(sensors["star_tracker"], StarTracker)
    assert sensors["star_tracker"].cross_boresight_std is None
    assert SpacecraftSpec().wheel_coulomb_friction == 0.0
