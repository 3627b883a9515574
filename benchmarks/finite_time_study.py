"""Finite/fixed-time sliding mode on SO(3) against the geometric PD and the Euler-angle terminal
sliding mode: the unwinding and large-angle cases, and the convergence-time claim.

Run ``python -m benchmarks.finite_time_study`` (about 70 s of CPU; ``--quick`` for a smoke
run). Two tables are printed:

1. **Unwinding / large angle** — the cases of :mod:`benchmarks.unwinding` (q/−q pair, angle
   sweep to 179°, Haar-random starts) on the SGCMG bus, every law tuned by the zoo's protocol
   (:data:`benchmarks.controllers.DEFAULT_GAIN_RULE`): verdict counts, worst unwinding ratio and
   worst settling time.
2. **Convergence-time claim** — Haar-sampled starts (seeded; half at rest, half tumbling) on the
   exact rigid body with an unlimited ideal torque actuator (the setting the theory assumes), the
   same spec: for each law the time after which the error stays below ``tol`` and the time it
   claims — none for the asymptotic PD, the prescribed time ``T`` for the Euler terminal sliding
   mode (Liu, Tang & Yu 2008), :func:`liecontrol.control.finite_time.convergence_time_bound` per
   start for the finite-time law and the initial-condition-free
   :meth:`~liecontrol.control.finite_time.FixedTimeSO3.settling_bound` for the fixed-time law.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol._validation import as_int, as_scalar, check_positive_scalar
from liecontrol.control import ConstantAttitude
from liecontrol.control.finite_time import FiniteTimeSO3, FixedTimeSO3, sliding_variable
from liecontrol.control.geometric_pd import GeometricPD
from liecontrol.control.terminal_sliding_mode import TerminalSlidingModeSO3
from liecontrol.control.tuning import (
    ClosedLoopSpec,
    tune_euler_tsm,
    tune_finite_time_so3,
    tune_geometric_pd,
)
from liecontrol.lie import so3

from .controllers import DEFAULT_GAIN_RULE
from .scenarios import SGCMG_SPACECRAFT
from .unwinding import UnwindingConfig, run_unwinding

__all__ = [
    "STUDY_CONTROLLERS",
    "ClaimRow",
    "SAMPLING_ALLOWANCE",
    "convergence_claim",
    "unwinding_table",
    "main",
]

#: the claims are continuous-time statements; the sampled loop (zero-order hold every ``dt``) is
#: allowed to settle this many sample periods later (measured lag on rest starts, where the
#: finite-time bound is exact: 2.2–3.0 periods at dt = 0.1 s, 2.5–3.0 at dt = 0.02 s)
SAMPLING_ALLOWANCE = 4

#: registry names compared (the PD and the Euler TSM are the zoo's baselines)
STUDY_CONTROLLERS = ("geometric-pd-large-angle", "euler-tsm", "finite-time-so3", "fixed-time-so3")


@dataclass(frozen=True)
class ClaimRow:
    """One law in the convergence-time table (times in s; ``nan`` where no claim exists):
    worst ``settle − claim`` over the starts, and how many settled by ``claim +``
    :data:`SAMPLING_ALLOWANCE` ``· dt``."""

    controller: str
    settle_max: float
    settle_median: float
    claim_max: float
    worst_excess: float
    met: int
    n: int
    failed: int
    path_ratio_max: float


def _laws(J: np.ndarray, spec: ClosedLoopSpec) -> dict[str, object]:
    return {
        "geometric-pd-large-angle": GeometricPD(J, **tune_geometric_pd(J, spec, "large_angle")),
        "euler-tsm": TerminalSlidingModeSO3(J, **tune_euler_tsm(J, spec), base="reference"),
        "finite-time-so3": FiniteTimeSO3(J, **tune_finite_time_so3(J, spec)),
        "fixed-time-so3": FixedTimeSO3(J, **tune_finite_time_so3(J, spec, fixed_time=True)),
    }


def convergence_claim(
    n_starts: int = 12,
    seed: int = 19,
    tol_deg: float = 0.1,
    rate_std: float = 0.01,
    dt: float = 0.1,
    max_torque: float | None = None,
) -> list[ClaimRow]:
    """The convergence-time table (module docstring): ``n_starts`` Haar-uniform attitudes from
    ``numpy.random.default_rng(seed)``, the second half with N(0, ``rate_std``²) body rates
    [rad/s], ideal torque actuator, control period ``dt``; a start's settling time is the first
    logged time after which the angle stays ≤ ``tol_deg``. ``max_torque`` [N·m] (> 0, per axis;
    default ``None``: unlimited, the setting the theory assumes) limits the ideal actuator; the
    finite/fixed-time bounds assume unbounded torque, so with a limit they are passed
    ``max_torque`` and reported as not applicable (``nan``, a
    :class:`~liecontrol.control.finite_time.BoundNotApplicable` warning each)."""
    n_starts = as_int(n_starts, "n_starts", 2)
    seed = as_int(seed, "seed", 0)
    tol_deg = check_positive_scalar(tol_deg, "tol_deg")
    if tol_deg >= 180.0:
        raise ValueError(f"tol_deg: must be < 180, got {tol_deg:g}")
    rate_std = as_scalar(rate_std, "rate_std")
    if rate_std < 0.0:
        raise ValueError(f"rate_std: must be >= 0, got {rate_std:g}")
    dt = check_positive_scalar(dt, "dt")
    if max_torque is not None:
        max_torque = check_positive_scalar(max_torque, "max_torque")
    from spacecraft import simulate
    from spacecraft.actuators import IdealTorqueActuator
    from spacecraft.plant import Spacecraft
    from spacecraft.rigid_body import RigidBody

    J = SGCMG_SPACECRAFT.J
    spec = ClosedLoopSpec(DEFAULT_GAIN_RULE.omega_n, DEFAULT_GAIN_RULE.zeta, dt)
    rng = np.random.default_rng(seed)
    R0 = Rotation.random(n_starts, random_state=rng).as_matrix()
    w0 = np.zeros((n_starts, 3))
    w0[n_starts // 2 :] = rng.normal(scale=rate_std, size=(n_starts - n_starts // 2, 3))
    theta0 = so3.angle(R0)
    tol = math.radians(tol_deg)
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(max_torque))
    laws = _laws(J, spec)
    claims: dict[str, np.ndarray] = {
        "geometric-pd-large-angle": np.full(n_starts, np.nan),
        "euler-tsm": np.full(n_starts, laws["euler-tsm"].law.params.T),  # type: ignore[attr-defined]
    }
    for name in ("finite-time-so3", "fixed-time-so3"):
        c = laws[name]
        s0 = sliding_variable(R0, w0, np.eye(3), np.zeros(3), c.params)[0]  # type: ignore[attr-defined]
        claims[name] = np.array(
            [
                c.convergence_time_bound(  # type: ignore[attr-defined]
                    tol, theta0[b], float(np.linalg.norm(s0[b])), max_torque=max_torque
                )
                if name == "finite-time-so3"
                else c.settling_bound(tol, max_torque=max_torque)  # type: ignore[attr-defined]
                for b in range(n_starts)
            ]
        )
    finite_claims = np.concatenate([v[np.isfinite(v)] for v in claims.values()])
    # with a torque limit only the Euler TSM's prescribed T may remain: the horizon follows it
    horizon = dt * math.ceil(1.5 * float(finite_claims.max(initial=60.0)) / dt)
    rows = []
    for name, law in laws.items():
        settle, ratio, failed = np.full(n_starts, np.inf), np.full(n_starts, np.nan), 0
        for b in range(n_starts):
            try:
                res = simulate(
                    plant,
                    law,  # type: ignore[arg-type]
                    ConstantAttitude(np.eye(3)),
                    plant.initial_state(R0[b : b + 1], w0[b : b + 1]),
                    horizon,
                    dt,
                )
            except ValueError:  # the Euler chart's gimbal-lock guard (ChartSingularityError)
                failed += 1
                continue
            err = res.attitude_error_angle()[:, 0]
            above = np.nonzero(err > tol)[0]
            if above.size == 0:
                settle[b] = 0.0
            elif above[-1] + 1 < err.size:
                settle[b] = res.t[above[-1] + 1]
            w = np.linalg.norm(res.omega[:, 0], axis=-1)
            ratio[b] = float(np.sum(0.5 * (w[1:] + w[:-1]) * np.diff(res.t))) / theta0[b]
        cl = claims[name]
        rows.append(
            ClaimRow(
                controller=name,
                settle_max=float(settle.max()),
                settle_median=float(np.median(settle)),
                claim_max=float(np.nanmax(cl)) if np.isfinite(cl).any() else math.nan,
                worst_excess=float(np.nanmax(settle - cl)) if np.isfinite(cl).any() else math.nan,
                met=int(np.sum(settle <= cl + SAMPLING_ALLOWANCE * dt))
                if np.isfinite(cl).any()
                else 0,
                n=n_starts,
                failed=failed,
                path_ratio_max=float(np.nanmax(ratio)) if np.isfinite(ratio).any() else math.nan,
            )
        )
    return rows


def unwinding_table(cfg: UnwindingConfig) -> list[tuple[str, str, float, float]]:
    """``(controller, verdict counts, worst unwinding ratio, worst settling time [s])`` on the
    unwinding cases of ``cfg`` (:func:`benchmarks.unwinding.run_unwinding`)."""
    if not isinstance(cfg, UnwindingConfig):
        raise TypeError(f"cfg: expected UnwindingConfig, got {type(cfg).__name__}")
    res = run_unwinding(STUDY_CONTROLLERS, cfg, progress=False)
    out = []
    for c in STUDY_CONTROLLERS:
        recs = [r for r in res.records if r.controller == c]
        counts: dict[str, int] = {}
        for r in recs:
            counts[r.verdict] = counts.get(r.verdict, 0) + 1
        verdicts = ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
        ratio = max((r.unwinding_ratio for r in recs), default=math.nan)
        settle = max((r.settling_time_s for r in recs), default=math.nan)
        out.append((c, verdicts, ratio, settle))
    return out


def _fmt(x: float) -> str:
    return "—" if not math.isfinite(x) else f"{x:.1f}"


def _fmt2(x: float) -> str:
    return "—" if not math.isfinite(x) else f"{x:+.2f}"


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.finite_time_study", description=__doc__)
    p.add_argument("--quick", action="store_true", help="fewer cases (smoke run)")
    p.add_argument(
        "--max-torque",
        type=float,
        default=None,
        help="per-axis torque limit [N·m] of the claim table's ideal actuator (default: "
        "unlimited); with a limit the finite/fixed-time bounds are reported as not applicable",
    )
    args = p.parse_args(argv)
    if args.quick:
        cfg = UnwindingConfig(sweep_angles_deg=(179.0,), n_random=1, duration=600.0)
        n = 4
    else:
        cfg = UnwindingConfig(sweep_angles_deg=(150.0, 179.0, 179.9), n_random=3, duration=600.0)
        n = 12
    print(
        f"Unwinding / large angle (SGCMG bus, ω_n = {DEFAULT_GAIN_RULE.omega_n} rad/s, "
        f"ζ = {DEFAULT_GAIN_RULE.zeta}; q/−q pair at {cfg.pair_angle_deg:g}°, sweep "
        f"{', '.join(f'{a:g}°' for a in cfg.sweep_angles_deg)}, {cfg.n_random} Haar starts)\n"
    )
    print("| controller | verdicts | worst unwinding ratio | worst settling [s] |")
    print("|---|---|---|---|")
    for c, v, r, s in unwinding_table(cfg):
        print(f"| {c} | {v} | {r:.2f} | {_fmt(s)} |")
    lim = "unlimited" if args.max_torque is None else f"limited to {args.max_torque:g} N·m"
    print(
        f"\nConvergence-time claim ({n} Haar starts, half tumbling; exact rigid body, ideal "
        f"torque {lim}; tolerance 0.1°)\n"
    )
    print(
        "| controller | settle max [s] | settle median [s] | claimed max [s] | "
        "worst settle − claim [s] | met claim (+4 T_s) | chart failures | "
        "worst ∫‖ω‖dt/θ₀ |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in convergence_claim(n_starts=n, max_torque=args.max_torque):
        met = f"{r.met}/{r.n}" if math.isfinite(r.claim_max) else "no claim"
        print(
            f"| {r.controller} | {_fmt(r.settle_max)} | {_fmt(r.settle_median)} | "
            f"{_fmt(r.claim_max)} | {_fmt2(r.worst_excess)} | {met} | {r.failed} | "
            f"{r.path_ratio_max:.2f} |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
