"""The report's tuning section: how every controller of a run was tuned, and what it measures.

:func:`tuning_section` returns Markdown lines for :func:`benchmarks.report.write_report`: the
closed-loop spec (ω_n, ζ, sample period) the run was tuned to, the actuator limits the tuning
checked against, and per attitude controller its tuning in words and numbers and its *measured*
small-angle natural frequency and damping on each principal axis of the run's spacecraft
(:func:`liecontrol.control.tuning.measure_small_angle_response`: the controller flown on the
linearised ideal-torque plant, kicked by 1 mrad, poles identified from the response). The
measurement is what a reader should trust over the description: a controller whose loop is not
the spec shows it here.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from liecontrol.control.tuning import TuningInfeasible, measure_small_angle_response

from .controllers import (
    ATTITUDE_PLANTS,
    CONTROLLERS,
    DEFAULT_GAIN_RULE,
    SE3_OMEGA_ATT,
    SE3_OMEGA_POS,
    ControllerContext,
    GainRule,
    actuator_limits,
    get_controller,
)
from .scenarios import Scenario

__all__ = [
    "tuning_section",
    "measure_registered",
    "step_response",
    "not_equivalent",
    "EQUIVALENT_OVERSHOOT_PCT",
    "EQUIVALENT_TORQUE_RATIO",
]

#: A law is "not equivalent at small angles" when a 1° step overshoots by more than this [%]
#: (the spec's linear loop, ζ = 0.9, overshoots by 0.15 %) ...
EQUIVALENT_OVERSHOOT_PCT = 5.0
#: ... or commands more than this multiple of the spec's linear peak torque ω_n² (êᵀJê) θ.
EQUIVALENT_TORQUE_RATIO = 2.0
#: Cache of step responses: (controller, spacecraft, rule, period) → response dict.
_STEP_CACHE: dict[tuple, dict[str, float]] = {}

#: Cache of measurements: (controller, spacecraft, rule, period) → (ω_n, ζ, poles of axis 1).
_CACHE: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _md(text: str) -> str:
    """Escape the characters that break a Markdown table cell."""
    return str(text).replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ")


def _fmt(x: Any) -> str:
    a = np.asarray(x, dtype=float) if not isinstance(x, str) else None
    if a is None:
        return x
    if a.ndim == 0:
        return f"{float(a):.4g}"
    if a.shape == (3, 3):
        d = np.diag(a)
        off = np.abs(a - np.diag(d)).max()
        txt = "diag(" + ", ".join(f"{v:.3g}" for v in d) + ")"
        return txt + (" + off-diag." if off > 1e-12 * np.abs(a).max() else "")
    return "(" + ", ".join(f"{v:.3g}" for v in a.ravel()) + ")"


def describe_tuning(controller: Any) -> str:
    """Short numbers of a built controller's tuning (the attributes the families expose)."""
    parts = []
    law = getattr(controller, "law", controller)
    if hasattr(controller, "Q") and hasattr(controller, "N"):  # the MPC: weights, not gains
        return (
            f"Q = {_fmt(np.diag(controller.Q))}, R = {_fmt(controller.R)}, N = {controller.N}, "
            f"dt = {controller.dt:g} s, u_max = {_fmt(controller.u_max)} N·m"
        )
    for name in ("k_R", "k_Omega", "k_I", "c", "k1", "k2", "kc", "K", "P", "k_p", "k_d"):
        for obj in (controller, law):
            if hasattr(obj, name) and not callable(getattr(obj, name)):
                v = getattr(obj, name)
                if isinstance(v, (int, float, np.ndarray)):
                    parts.append(f"{name} = {_fmt(v)}")
                break
    funnel = getattr(controller, "funnel", None)
    if funnel is not None:
        parts.append(f"funnel ρ_∞ = {funnel.rho_inf:g}, l = {funnel.decay:.3g} 1/s")
    params = getattr(law, "params", None)
    if params is not None and hasattr(params, "K3"):
        parts.append(
            f"ESO K = ({_fmt(params.K1[0])}, {_fmt(params.K2[0])}, {_fmt(params.K3[0])}), "
            f"k₁ = {_fmt(params.k1[0])}, k₂ = {_fmt(params.k2[0])}, TD r = {params.r:.3g}"
        )
    tsm = getattr(law, "params", None)
    if tsm is not None and hasattr(tsm, "T") and hasattr(tsm, "C1"):
        parts.append(f"T = {tsm.T:.4g} s, C₁ = {_fmt(np.diag(tsm.C1))}, K = {tsm.K:.3g}")
    return "; ".join(parts)


def _poles_text(poles: np.ndarray) -> str:
    """Compact list of identified poles: conjugate pairs as ``a±bj``, sorted slowest first."""
    out, done = [], np.zeros(poles.size, dtype=bool)
    order = np.argsort(-poles.real)
    for i in order:
        if done[i]:
            continue
        p = poles[i]
        done[i] = True
        if abs(p.imag) > 1e-9 * max(abs(p), 1e-300):
            j = np.argmin(np.where(done, np.inf, np.abs(poles - np.conj(p))))
            done[j] = True
            out.append(f"{p.real:.3g}±{abs(p.imag):.2g}j")
        else:
            out.append(f"{p.real:.3g}")
    return ", ".join(out)


def measure_registered(
    name: str, scenario: Scenario, rule: GainRule | None = None
) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
    """``(controller, ω_n (3,), ζ (3,), poles of the first principal axis)``: registry controller
    ``name`` built for ``scenario``'s spacecraft under ``rule`` and measured on its small-angle
    loop at the control period it runs at (all identified poles are returned too: e.g. the slow
    integral pole of a PID, which the dominant pair leaves out). Raises
    :class:`~liecontrol.control.tuning.TuningInfeasible` if it cannot be tuned.
    """
    info = get_controller(name)
    rule = rule or DEFAULT_GAIN_RULE
    period = info.control_period or scenario.control_period or scenario.dt
    ctx = ControllerContext(spacecraft=scenario.spacecraft, control_period=period, rule=rule)
    ctrl = info.factory(ctx)
    key = (name, scenario.spacecraft, rule, period)
    if key not in _CACHE:
        # long enough for the dominant pair to decay (5 time constants 1/(ζω_n)); funnels
        # (prescribed performance) need their decay to settle before the kick
        tau = 1.0 / (min(rule.zeta, 1.0) * rule.omega_n)
        funnel = getattr(ctrl, "funnel", None)
        warm = 5.0 / funnel.decay if funnel is not None else 0.0
        r = measure_small_angle_response(ctrl, ctx.J, period, duration=5.0 * tau, warmup=warm)
        _CACHE[key] = (r.omega_n, r.zeta, r.poles[0])
    w, z, p = _CACHE[key]
    return ctrl, w.copy(), z.copy(), p.copy()


class _StepReference:
    """R_d = exp(pre^) until ``t_step``, then exp(post^) (at rest): a reference step."""

    def __init__(self, pre: np.ndarray, post: np.ndarray, t_step: float) -> None:
        from liecontrol.control import AttitudeReference
        from liecontrol.lie import so3

        self.t_step = t_step
        self._pre = AttitudeReference.regulation(so3.exp(pre))
        self._post = AttitudeReference.regulation(so3.exp(post))

    def __call__(self, t: float) -> Any:
        return self._post if t >= self.t_step - 1e-9 else self._pre


def step_response(name: str, scenario: Scenario, rule: GainRule | None = None) -> dict[str, float]:
    """A 1° step of registry controller ``name`` on ``scenario``'s spacecraft with an ideal,
    unlimited torque, at the control period it runs at, about the axis (1, 1, 1)/√3:

    - *from rest*: the spacecraft starts 1° off the target, at rest, the controller fresh;
    - *after warm-up*: the spacecraft starts 0.3° off about body x and the controller flies
      that kick for five time constants 5/(ζω_n) (funnels and observers settle, integrators
      charge), then the target steps by 1°.

    Returns ``overshoot_pct`` / ``warm_overshoot_pct`` (largest excursion past the target along
    the step axis, in % of the step) and ``torque_ratio`` / ``warm_torque_ratio`` (peak ‖u‖ over
    the spec's linear peak ω_n² (êᵀJê)·1°, which the PD family meets at 1.0)."""
    from scipy.spatial.transform import Rotation

    from spacecraft.actuators import IdealTorqueActuator
    from spacecraft.plant import Spacecraft
    from spacecraft.rigid_body import RigidBody
    from spacecraft.simulator import simulate

    info = get_controller(name)
    rule = rule or DEFAULT_GAIN_RULE
    period = info.control_period or scenario.control_period or scenario.dt
    key = (name, scenario.spacecraft, rule, period)
    if key in _STEP_CACHE:
        return dict(_STEP_CACHE[key])
    J = np.asarray(scenario.spacecraft.J)
    e = np.ones(3) / math.sqrt(3.0)
    step = math.radians(1.0)
    tau = 1.0 / (min(rule.zeta, 1.0) * rule.omega_n)
    span = math.ceil(5.0 * tau / period) * period  # whole control periods
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    u_spec = rule.omega_n**2 * float(e @ J @ e) * step
    out: dict[str, float] = {}
    for tag, t_step, R0 in (
        ("", 0.0, Rotation.from_rotvec(-step * e).as_matrix()),
        ("warm_", span, Rotation.from_rotvec(math.radians(0.3) * np.array([1.0, 0, 0]))
         .as_matrix()),
    ):  # fmt: skip
        ref = _StepReference(np.zeros(3), step * e, t_step) if t_step else _StepReference(
            np.zeros(3), np.zeros(3), 0.0
        )
        ctx = ControllerContext(spacecraft=scenario.spacecraft, control_period=period, rule=rule)
        ctrl = info.factory(ctx)
        dt = period  # the ideal rigid body needs no finer step at ω_n·T ≪ 1 (RK4)
        res = simulate(
            plant, ctrl, ref, plant.initial_state(R0[None]), t_final=t_step + span,
            dt=dt, control_period=period,
        )  # fmt: skip
        t = np.asarray(res.t)
        after = t >= t_step - 1e-9
        R = np.asarray(res.R)[after, 0]
        R_d = np.asarray(res.R_d)[after, 0]
        rv = Rotation.from_matrix(np.swapaxes(R_d, -1, -2) @ R).as_rotvec()
        axis = rv[0] / max(np.linalg.norm(rv[0]), 1e-300)
        over = max(0.0, -float((rv @ axis).min()))
        out[f"{tag}overshoot_pct"] = 100.0 * over / step
        out[f"{tag}torque_ratio"] = float(np.linalg.norm(np.asarray(res.u)[after, 0], axis=-1).max()
                                          / u_spec)  # fmt: skip
    _STEP_CACHE[key] = out
    return dict(out)


def not_equivalent(response: dict[str, float]) -> bool:
    """The step response leaves the spec's linear behaviour by more than the bounds
    (:data:`EQUIVALENT_OVERSHOOT_PCT`, :data:`EQUIVALENT_TORQUE_RATIO`), from rest or after
    warm-up."""
    if not isinstance(response, dict):
        raise TypeError(f"response: expected the dict of step_response, got {response!r}")
    vals = [response.get(k, 0.0) for k in
            ("overshoot_pct", "warm_overshoot_pct", "torque_ratio", "warm_torque_ratio")]
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
        raise TypeError(f"response: expected numbers, got {response!r}")
    over = max(response.get("overshoot_pct", 0.0), response.get("warm_overshoot_pct", 0.0))
    torque = max(response.get("torque_ratio", 0.0), response.get("warm_torque_ratio", 0.0))
    return not (over <= EQUIVALENT_OVERSHOOT_PCT and torque <= EQUIVALENT_TORQUE_RATIO)


def tuning_section(result: Any, *, measure: bool = True) -> list[str]:
    """Markdown lines of the tuning section of ``result`` (a
    :class:`~benchmarks.runner.SuiteResult`): spec, actuator limits and, per attitude controller,
    its tuning and (``measure=True``) its measured small-angle ω_n and ζ per principal axis on
    the first attitude scenario's spacecraft, as a ratio to the spec."""
    rule = getattr(result, "gain_rule", None) or DEFAULT_GAIN_RULE
    att = [s for s in result.scenarios if s.plant in ATTITUDE_PLANTS]
    lines = ["## Tuning", ""]
    if not att:
        lines += ["No attitude scenario in this run: nothing to tune.", ""]
        return lines
    sc = att[0]
    period = sc.control_period or sc.dt
    lim = actuator_limits(sc.spacecraft)
    lines += [
        "Every controller is tuned by `liecontrol.control.tuning` from the scenario's spacecraft "
        f"to one closed-loop spec: ω_n = {rule.omega_n:g} rad/s, ζ = {rule.zeta:g}, sampled at "
        "the scenario's control period. Its small-angle loop is then measured on the "
        f"spacecraft `{_md(sc.spacecraft.name)}` of scenario `{_md(sc.name)}` (ideal torque, "
        f"{period:g} s sampling unless the controller has its own period): the table gives the "
        "measured natural frequency and damping of the dominant pole pair on each principal "
        "axis, as ratios to the spec (1.00 = on spec), and every pole identified on the first "
        "axis (an integral's slow real pole, observer or funnel modes).",
        "",
        f"Actuator limits used by the tuning: torque {_fmt(lim.max_torque or math.inf)} N·m, "
        f"momentum {_fmt(lim.max_momentum or math.inf)} N·m·s"
        + (f", gimbal rate {lim.max_gimbal_rate:g} rad/s." if lim.max_gimbal_rate else "."),
        "",
        "| controller | tuning | parameters | ω/ω_n per axis | ζ/ζ_spec per axis "
        "| identified poles, 1st axis [1/s] | 1° step: overshoot, peak ‖u‖/spec (rest; "
        "after warm-up) | small-angle equivalence |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c in result.controllers:
        if c not in CONTROLLERS:
            # unregistered since the run (e.g. a plug-in's temporary entry): no factory to measure
            lines.append(
                f"| {_md(c)} | not in the registry any more: not measured | — | — | — | — "
                "| — | — |"
            )
            continue
        info = get_controller(c)
        if not (info.plants & ATTITUDE_PLANTS):
            continue
        desc = (
            result.descriptions.get(c, info.description) if hasattr(result, "descriptions") else ""
        )
        steptxt, eqtxt = "—", "—"
        try:
            if measure:
                ctrl, w, z, poles = measure_registered(c, sc, rule)
                wtxt = ", ".join(f"{v / rule.omega_n:.2f}" for v in w)
                ztxt = ", ".join(f"{v / rule.zeta:.2f}" for v in z)
                ptxt = _poles_text(poles)
                try:
                    r = step_response(c, sc, rule)
                    steptxt = (
                        f"{r['overshoot_pct']:.2g} %, {r['torque_ratio']:.2g}; "
                        f"{r['warm_overshoot_pct']:.2g} %, {r['warm_torque_ratio']:.2g}"
                    )
                    eqtxt = "**not equivalent at small angles**" if not_equivalent(r) else "yes"
                except Exception as exc:  # noqa: BLE001 - reported in the cell
                    steptxt = f"step failed: {type(exc).__name__}"
            else:
                ctx = ControllerContext(
                    spacecraft=sc.spacecraft,
                    control_period=info.control_period or period,
                    rule=rule,
                )
                ctrl, wtxt, ztxt, ptxt = info.factory(ctx), "—", "—", "—"
            params = describe_tuning(ctrl)
        except TuningInfeasible as exc:
            params, wtxt, ztxt, ptxt = f"not applicable: {exc}", "—", "—", "—"
        except Exception as exc:  # noqa: BLE001 - a user's controller must not sink the report
            params, wtxt, ztxt, ptxt = (
                f"measurement failed: {type(exc).__name__}: {exc}",
                "—",
                "—",
                "—",
            )
        shown = result.display_name(c) if hasattr(result, "display_name") else c
        lines.append(
            f"| {_md(shown)} | {_md(desc)} | {_md(params)} | {wtxt} | {ztxt} | {_md(ptxt)} "
            f"| {steptxt} | {eqtxt} |"
        )
    lines += ["", *_reading_notes(result, rule), ""]
    return lines


def _reading_notes(result: Any, rule: GainRule) -> list[str]:
    """What equal small-angle bandwidth does and does not make equal (shown under the table)."""
    notes = [
        "Equal poles are not equal behaviour when a law has modes the pole pair leaves out (an "
        "observer, a funnel, an integral): the step columns fly a 1° step about (1, 1, 1)/√3 on "
        "the ideal unlimited-torque body, from rest and after the law has flown a 0.3° kick "
        "for five time constants; peak ‖u‖ is divided by the spec's linear peak ω_n²(êᵀJê)·1°. A "
        f"law overshooting by more than {EQUIVALENT_OVERSHOOT_PCT:g} % (the spec's linear loop: "
        f"0.15 %) or above {EQUIVALENT_TORQUE_RATIO:g}× that torque is marked **not equivalent "
        "at small angles**, here and in the dispersion tables. We mark rather than retune: "
        "retuning an observer or a funnel to an overshoot bound would no longer be the "
        "published design the reproductions check.",
        "",
        "How to read this: equal small-angle poles make the *linear* responses comparable; they "
        "do not make large-angle behaviour equal, and three designs differ by construction:",
        "",
        "- `euler-tsm` is a prescribed-time design: its reference trajectory ends at T (set to "
        "the spec's settling time), so on large slews it plans the whole manoeuvre to finish by "
        "T and settles well before the PD family, which slows down with sin θ; its poles are "
        "real (ζ ≥ 1 by construction, hence ζ/ζ_spec = 1.11).",
        "- the PID family's integral adds a slow real pole at −ω_n/5 (time constant "
        f"{5.0 / rule.omega_n:.0f} s here): from an initial error its integral must unwind what "
        "it accumulated, which leaves a slow tail that a 400–600 s run may not finish.",
        "- `prescribed-performance` guarantees only its funnel floor ρ_∞ on each component of "
        "e_R; a floor looser than the scenario's tolerance lets it end outside the tolerance "
        "while inside its own guarantee.",
    ]
    if "geometric-pd-trace" in result.controllers:
        # checked on the quick suite's slew-179 history: ‖u‖ 0.54 N·m at t = 0 (log PD: 39),
        # θ still 178° at 60 s and 135° at 300 s, 5.8° at 500 s, 0.3° at 590 s
        notes.append(
            "- `geometric-pd-trace` uses the trace error Ψ = ½ tr(I − R_dᵀR), whose gradient "
            "e_R has ‖e_R‖ = sin θ: it vanishes at θ = π, so from a 179° start the restoring "
            "torque begins near zero (about 1/60 of its 90° value) and the spacecraft drifts "
            "away from the antipode only slowly; the slew then finishes late and may not settle "
            "in a 600 s run (`slew-179`), while the log, large-angle, quaternion and MRP PD "
            "laws, whose torque does not vanish near π, settle well within it."
        )
        notes.append(
            "- `geometric-pd-trace` measures between 1.00 and 1.05 of the spec per axis instead "
            "of exactly 1.00, by design: "
            "near the target its error is e_R ≈ S δθ with S = ½(tr G·I − G), whose "
            "eigenvalues for the default G = diag(0.9, 1.0, 1.1) are 0.95, 1.0 and 1.05 (the "
            "other error functions have one slope, S = s·I). The tuning puts the slowest "
            "direction exactly on spec (K_R = ω_n²J/s_min, K_Ω scaled by √(s_max/s_min) so no "
            "direction is under-damped); the other directions are then up to √(1.05/0.95) ≈ "
            "1.05 faster and better damped. A single gain matrix cannot put all three slopes "
            "on spec unless G is isotropic, and an isotropic G would make the trace error's "
            "critical points non-isolated (Koditschek, \"The application of total energy as "
            "a Lyapunov function for mechanical control systems\", Contemporary Mathematics "
            "97, AMS, 1989)."
        )
    if any(
        get_controller(c).plants == frozenset({"se3"})
        for c in result.controllers
        if c in CONTROLLERS
    ):
        k = rule.omega_n / DEFAULT_GAIN_RULE.omega_n
        notes.append(
            "- SE(3) controllers (not in the table) are tuned by "
            "`liecontrol.control.pose_gains_from_bandwidth` with attitude bandwidth "
            f"{SE3_OMEGA_ATT * k:g} rad/s and position bandwidth {SE3_OMEGA_POS * k:g} rad/s "
            "(scaled with ω_n); both use the same gains, so they differ only in their error and "
            "feed-forward terms."
        )
    return notes
