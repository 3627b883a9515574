"""The tuning protocol (liecontrol.control.tuning) and the registry's use of it.

Every registered attitude controller, tuned for a spacecraft through the public API, must show
the spec's small-angle poles (within 15 % on every principal axis) when measured through the
controller seam; formulas are checked against independent routes (closed-form second-order
response, scipy's continuous Riccati solver, the ESO's characteristic polynomial, brute-force
momentum envelopes); bad input raises errors naming the argument.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from benchmarks.controllers import (
    ATTITUDE_PLANTS,
    CONTROLLERS,
    DEFAULT_GAIN_RULE,
    ControllerContext,
    GainRule,
    actuator_limits,
    get_controller,
    register,
    unregister,
)
from benchmarks.scenarios import SGCMG_SPACECRAFT, Scenario, SpacecraftSpec, rest_to_rest
from liecontrol.control import GeometricPD, MrpADRC
from liecontrol.control.adrc import PAPER, eso_poles
from liecontrol.control.tuning import (
    ActuatorLimits,
    ClosedLoopSpec,
    TuningInfeasible,
    check_actuator,
    measure_small_angle_response,
    required_actuation,
    step_peaks,
    tune_euler_tsm,
    tune_geometric_pd,
    tune_integral_pd,
    tune_intrinsic_pid,
    tune_mpc,
    tune_mrp_adrc,
    tune_small_angle_pid,
)

#: A 1000 kg·m² wheel bus (a user's spacecraft, nothing like the benchmark's).
BUS = SpacecraftSpec(
    name="bus-1000",
    inertia=((1000.0, 0.0, 0.0), (0.0, 800.0, 0.0), (0.0, 0.0, 1200.0)),
    actuator="wheels",
)

ATTITUDE = [n for n, i in CONTROLLERS.items() if i.plants & ATTITUDE_PLANTS]


def _measure(name: str, sc: SpacecraftSpec, rule: GainRule):
    info = get_controller(name)
    period = info.control_period or 0.2
    ctx = ControllerContext(spacecraft=sc, control_period=period, rule=rule)
    ctrl = info.factory(ctx)
    tau = 1.0 / (min(rule.zeta, 1.0) * rule.omega_n)
    funnel = getattr(ctrl, "funnel", None)
    warm = 5.0 / funnel.decay if funnel is not None else 0.0
    return measure_small_angle_response(ctrl, ctx.J, period, duration=5.0 * tau, warmup=warm)


# the spec is not the benchmark default here: the tuning must follow the rule it is given
# (and a faster loop keeps the test short)
@pytest.mark.parametrize(
    ("sc", "rule"),
    [(SGCMG_SPACECRAFT, GainRule(0.1, 0.9)), (BUS, GainRule(0.08, 0.95))],
    ids=["benchmark-spacecraft", "wheel-bus-1000"],
)
def test_every_attitude_controller_meets_the_spec(sc, rule):
    measured = {}
    for name in ATTITUDE:
        try:
            r = _measure(name, sc, rule)
        except TuningInfeasible as exc:
            # the per-axis Euler PID refuses a strongly coupled inertia instead of missing it
            assert name == "payload-pid-ff" and str(exc).startswith("J:"), (name, exc)
            assert np.abs(sc.J - np.diag(np.diag(sc.J))).max() > 0
            continue
        measured[name] = (r.omega_n / rule.omega_n, r.zeta / rule.zeta)
    assert len(measured) >= len(ATTITUDE) - 1
    # adaptive-so3: its Lyapunov design needs a scalar k_R and γ_φ, so only the axis of largest
    # inertia is placed on the spec (the others are faster), and its harmonic estimates add
    # lightly damped modes near ±i·n that the identification may report as the dominant pair
    # (tune_adaptive_so3; its own pole placement is checked in tests/test_adaptive.py)
    measured.pop("adaptive-so3", None)
    for name, (w, z) in measured.items():
        assert np.all(np.abs(w - 1.0) < 0.15), (name, w)
        # TSM: real poles only, so damping ≥ 1 (exact for ζ ≥ 1, 1/0.9 = 1.11 at ζ = 0.9)
        assert np.all(np.abs(z - 1.0) < 0.15), (name, z)


def test_measurement_detects_a_mistuned_controller():
    # scalar gains from the largest principal moment: the other axes are faster
    J = SGCMG_SPACECRAFT.J
    k_R, k_W = 0.03**2 * np.linalg.eigvalsh(J)[-1], 2 * 0.9 * 0.03 * np.linalg.eigvalsh(J)[-1]
    r = measure_small_angle_response(GeometricPD(J, k_R, k_W, error="log"), J, 0.2, duration=200)
    lam = np.linalg.eigvalsh(J)
    np.testing.assert_allclose(r.omega_n, 0.03 * np.sqrt(lam[-1] / lam), rtol=0.02)
    np.testing.assert_allclose(r.zeta, 0.9 * np.sqrt(lam[-1] / lam), rtol=0.03)


@pytest.mark.parametrize("zeta", [0.6, 1.0, 1.4])
def test_step_peaks_against_the_matrix_exponential(zeta):
    w = 0.05
    a, v, ts = step_peaks(w, zeta)
    A = np.array([[0.0, 1.0], [-w * w, -2 * zeta * w]])
    t = np.linspace(0.0, 30.0 / (min(zeta, 1.0) * w), 3001)
    Phi = scipy.linalg.expm(A * (t[1] - t[0]))  # exact one-step map, applied repeatedly
    x = np.empty((t.size, 2))
    x[0] = (1.0, 0.0)
    for k in range(1, t.size):
        x[k] = Phi @ x[k - 1]
    assert a == pytest.approx(np.abs(x @ A[1]).max(), rel=1e-6)
    assert v == pytest.approx(np.abs(x[:, 1]).max(), rel=1e-4)
    last = t[np.nonzero(np.abs(x[:, 0]) > 0.02)[0][-1]]
    assert ts == pytest.approx(last, abs=2 * (t[1] - t[0]))


def test_mpc_weights_give_the_spec_by_continuous_lqr():
    J = SGCMG_SPACECRAFT.J
    spec = ClosedLoopSpec(0.03, 0.9, 0.2)
    kw = tune_mpc(J, spec, ActuatorLimits(50.0))
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [np.zeros((3, 6))]])
    B = np.vstack([np.zeros((3, 3)), np.linalg.inv(J)])
    P = scipy.linalg.solve_continuous_are(A, B, kw["Q"], kw["R"])
    K = np.linalg.solve(kw["R"], B.T @ P)
    np.testing.assert_allclose(K[:, :3], 0.03**2 * J, rtol=1e-6, atol=1e-9 * np.abs(J).max())
    np.testing.assert_allclose(K[:, 3:], 2 * 0.9 * 0.03 * J, rtol=1e-6)
    np.testing.assert_array_equal(kw["u_max"], [50.0] * 3)
    with pytest.raises(TuningInfeasible, match="^zeta:"):
        tune_mpc(J, ClosedLoopSpec(0.03, 0.5, 0.2), None)


def test_pid_and_adrc_pole_placement():
    J = BUS.J
    spec = ClosedLoopSpec(0.05, 0.8, 0.2)
    want = np.sort_complex(np.append(np.roots([1, 2 * 0.8 * 0.05, 0.05**2]), -0.2 * 0.05))
    Jinv = np.linalg.inv(J)
    # gains ∝ J, so J⁻¹K is a multiple of I: one axis, states (z, θ, θ̇)
    pid = {k: (Jinv @ v)[0, 0] for k, v in tune_intrinsic_pid(J, spec).items() if k != "error"}
    A = [[0, 1, 0], [0, 0, 1], [-pid["k_I"], -pid["k_R"], -pid["k_Omega"]]]  # ż = e_R = θ
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A)), want, atol=1e-10)
    kw = tune_integral_pd(J, spec)
    g = {k: (Jinv @ kw[k])[0, 0] for k in ("k_R", "k_Omega", "k_I")}
    c, s = kw["c"], 0.5
    # ż = e_Ω + c e_R = θ̇ + c s θ;  θ̈ = −K_R s θ − K_Ω θ̇ − K_I z
    A = [[0, c * s, 1], [0, 0, 1], [-g["k_I"], -g["k_R"] * s, -g["k_Omega"]]]
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A)), want, atol=1e-10)
    params = tune_mrp_adrc(J, spec)["params"]
    np.testing.assert_allclose(
        eso_poles(params.K1, params.K2, params.K3, params.alpha, params.beta), -0.25, atol=2e-4
    )
    assert params.k1[0] == pytest.approx(0.05**2) and params.k2[0] == pytest.approx(0.08)


def test_tsm_prescribed_time_matches_the_spec_settling():
    spec = ClosedLoopSpec(0.03, 0.9, 0.2)
    kw = tune_euler_tsm(np.eye(3), spec)
    tau = spec.settling_time / kw["T"]
    assert 1 - 10 * tau**3 + 15 * tau**4 - 6 * tau**5 == pytest.approx(0.02, abs=1e-9)
    assert kw["C1"] == pytest.approx(0.03) and kw["K"] / kw["delta0"] == pytest.approx(0.03)
    over = tune_euler_tsm(np.eye(3), ClosedLoopSpec(0.03, 1.25, 0.2))
    lam, kap = over["C1"], over["K"] / over["delta0"]
    assert lam * kap == pytest.approx(0.03**2) and lam + kap == pytest.approx(2 * 1.25 * 0.03)


def test_actuator_limits_against_brute_force():
    lim = actuator_limits(SpacecraftSpec(actuator="wheels", wheel_max_torque=0.5))
    assert lim.max_torque == (0.5, 0.5, 0.5) and lim.max_momentum == pytest.approx((60.0,) * 3)
    from spacecraft.sgcmg import SgcmgPyramid

    sc = SGCMG_SPACECRAFT
    cl = SgcmgPyramid(sc.h0, math.radians(sc.beta_deg), sc.gimbal_rate_limit)
    h_min = actuator_limits(sc).max_momentum[0]
    # along any direction the reachable momentum is the sum of each CMG's best gimbal angle
    d = np.linspace(-np.pi, np.pi, 721)
    rng = np.random.default_rng(3)
    for a in rng.normal(size=(5, 3)):
        a /= np.linalg.norm(a)
        best = sum(
            (cl.unit_momenta(np.outer(d, np.eye(4)[i]))[..., :, i] @ a).max() for i in range(4)
        )
        assert sc.h0 * best >= h_min * (1 - 1e-3)
    # and the pseudo-inverse box is within the gimbal-rate limit at the initial gimbals
    A = cl.jacobian(np.deg2rad(sc.delta0_deg))
    u = actuator_limits(sc).max_torque[0]
    corners = np.array(np.meshgrid(*[[-u, u]] * 3)).reshape(3, -1).T
    assert np.abs(corners @ np.linalg.pinv(A).T).max() <= sc.gimbal_rate_limit * (1 + 1e-9)


def test_user_spacecraft_is_retuned_not_the_papers():
    ctx = ControllerContext(spacecraft=BUS, control_period=0.2)
    adrc = get_controller("mrp-adrc").factory(ctx)
    assert isinstance(adrc, MrpADRC)
    p = adrc.law.params
    assert not np.allclose(p.K3, PAPER.K3) and not np.allclose(p.k1, PAPER.k1)
    assert p.k1[0] == pytest.approx(DEFAULT_GAIN_RULE.omega_n**2)
    pd = get_controller("geometric-pd-log").factory(ctx)
    np.testing.assert_allclose(pd.k_R, 0.03**2 * BUS.J)
    fast = get_controller("geometric-pd-log").factory(
        ControllerContext(spacecraft=BUS, control_period=0.2, rule=GainRule(0.06, 0.9))
    )
    np.testing.assert_allclose(fast.k_R, 4 * pd.k_R)


def test_infeasible_pairs_are_not_applicable_with_the_reason():
    slow = rest_to_rest(5.0, name="slow-sampling", dt=1.0, control_period=5.0)
    ok, why = get_controller("geometric-pd-log").applies(slow)
    assert not ok and "sample_period" in why
    weak = rest_to_rest(
        90.0, name="weak-wheels", spacecraft=SpacecraftSpec(name="weak", actuator="wheels")
    )
    info = get_controller("mrp-pd")
    ok, why = info.applies(weak)  # 4.3× the 60 N·m·s the wheels store
    assert not ok and "peak momentum" in why
    ok, why = info.applies(weak, GainRule(0.02, 0.9))  # 6.2× the 1 N·m the wheels give
    assert not ok and "peak torque" in why
    assert info.applies(weak, GainRule(0.015, 0.9)) == (True, "")  # a gentler spec fits


def test_run_suite_passes_the_gain_rule_to_every_factory():
    from benchmarks.runner import run_suite

    seen = []

    def factory(ctx):
        seen.append(ctx.rule)
        return GeometricPD(ctx.J, **tune_geometric_pd(ctx.J, ClosedLoopSpec(0.05, 1.0, 0.2)))

    register("test-rule-probe", factory)
    try:
        sc = Scenario(name="probe", description="probe", duration=2.0)
        res = run_suite(
            [sc],
            ["test-rule-probe"],
            executor="serial",
            progress=False,
            gain_rule=GainRule(0.05, 1.0),
        )
    finally:
        unregister("test-rule-probe")
    assert res.outcomes[0].status == "ok"
    assert seen and all(r == GainRule(0.05, 1.0) for r in seen)
    assert res.gain_rule == GainRule(0.05, 1.0)


def test_tuning_section_reports_measured_bandwidth():
    from benchmarks.runner import SuiteResult
    from benchmarks.tuning_report import tuning_section

    sc = rest_to_rest(5.0, name="tiny", spacecraft=BUS)
    res = SuiteResult("t", (sc,), ("mrp-pd", "euler-tsm"), (), 0.0, gain_rule=GainRule(0.1, 1.0))
    text = "\n".join(tuning_section(res))
    assert "ω_n = 0.1 rad/s" in text and "| mrp-pd |" in text and "| euler-tsm |" in text
    row = next(line for line in text.splitlines() if line.startswith("| mrp-pd |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert [float(v) for v in cells[3].split(",")] == pytest.approx([1.0] * 3, abs=0.05)


@pytest.mark.parametrize(
    ("kwargs", "match", "exc"),
    [
        ({"omega_n": 0.0, "zeta": 0.9, "sample_period": 0.1}, "^omega_n: must be > 0", ValueError),
        ({"omega_n": -1, "zeta": 0.9, "sample_period": 0.1}, "^omega_n:", ValueError),
        ({"omega_n": 0.03, "zeta": 0.0, "sample_period": 0.1}, "^zeta: must be > 0", ValueError),
        ({"omega_n": float("nan"), "zeta": 0.9, "sample_period": 0.1}, "^omega_n:", ValueError),
        ({"omega_n": [0.03, 0.04], "zeta": 0.9, "sample_period": 0.1}, "^omega_n:", TypeError),
        ({"omega_n": True, "zeta": 0.9, "sample_period": 0.1}, "^omega_n:", TypeError),
        ({"omega_n": 0.03, "zeta": 0.9, "sample_period": 0.0}, "^sample_period:", ValueError),
        ({"omega_n": 0.03, "zeta": 0.9, "sample_period": 5.0}, "^sample_period:", TuningInfeasible),
    ],
)
def test_spec_bad_input(kwargs, match, exc):
    with pytest.raises(exc, match=match):
        ClosedLoopSpec(**kwargs)


def test_other_bad_input():
    spec = ClosedLoopSpec(0.03, 0.9, 0.2)
    with pytest.raises(ValueError, match="^max_torque:"):
        ActuatorLimits(max_torque=-1.0)
    with pytest.raises(ValueError, match="^max_momentum:"):
        ActuatorLimits(max_torque=1.0, max_momentum=[1.0, 2.0])
    with pytest.raises(TypeError, match="^spec:"):
        tune_geometric_pd(np.eye(3), (0.03, 0.9, 0.2))
    with pytest.raises(TypeError, match="^limits:"):
        check_actuator(np.eye(3), spec, {"max_torque": 1.0}, [0.1, 0, 0])
    with pytest.raises(TuningInfeasible, match="^omega_n: .* peak momentum"):
        check_actuator(1e4 * np.eye(3), spec, ActuatorLimits(None, 1.0), [1.0, 0, 0])
    with pytest.raises(TuningInfeasible, match="^J:"):
        tune_small_angle_pid(SGCMG_SPACECRAFT.J, spec)
    with pytest.raises(TypeError, match="^controller:"):
        measure_small_angle_response(object(), np.eye(3), 0.2, duration=10.0)
    with pytest.raises(ValueError, match="^duration:"):
        measure_small_angle_response(GeometricPD(np.eye(3), 1.0, 1.0), np.eye(3), 0.2, duration=0.4)
    with pytest.raises(ValueError, match="^observer_ratio:"):
        tune_mrp_adrc(np.eye(3), spec, observer_ratio=1.0)
    tau, h = required_actuation(np.eye(3), spec, [0.0, 0.0, 0.0])
    assert h == 0.0 and not tau.any()
    J = np.diag([1.0, 2.0, 3.0])
    Jc = J.copy()
    tune_intrinsic_pid(J, spec)
    np.testing.assert_array_equal(J, Jc)  # the user's input is not modified


def test_step5_settling_spread():
    """5° rest-to-rest on the benchmark spacecraft (SGCMG): every controller tuned to the same
    spec settles within ±30 % of the median, except the intrinsic PID whose empty integrator
    must unwind what it accumulates during the approach (its integral mode has residue
    1/(1 − 2ζr + r²) ≈ 1.5 in a response from an initial error: a slow tail at −ω_n/5)."""
    from benchmarks.runner import run_suite

    sc = rest_to_rest(5.0, name="step-5-test", duration=320.0, dt=0.2, control_period=0.2)
    names = [n for n in ATTITUDE if get_controller(n).applies(sc)[0]]
    res = run_suite([sc], names, jobs=2, progress=False)
    ts = {o.controller: o.metrics["settling_time_s"] for o in res.outcomes if o.status == "ok"}
    assert set(ts) == set(names)
    # the adaptive law's disturbance estimate integrates s = e_Ω + c e_R over the approach and
    # unwinds it through its pole at −ω_n/4, the same slow tail as the intrinsic PID's
    slow = ("geometric-pid-intrinsic", "adaptive-so3")
    regular = {n: t for n, t in ts.items() if n not in slow}
    med = float(np.median(list(regular.values())))
    for n, t in regular.items():
        assert abs(t / med - 1.0) <= 0.30, (n, t, med)
    for n in slow:
        assert math.isnan(ts[n]) or ts[n] > med, (n, ts[n], med)
