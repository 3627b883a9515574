"""CMG hardware limits as linear MPC input constraints.

:class:`liecontrol.control.mpc.SO3MPC` accepts ``extra_constraints(state) -> (C, lo, hi)``,
imposing ``lo ≤ C u_k ≤ hi`` on every stage's body torque ``u_k``. This module builds such
callables for the SGCMG pyramid from the current actuator state (``AttitudeState.actuator_state``:
the gimbal angles δ, ``(1, 4)`` or ``(1, 8)`` with a first-order servo).

**Gimbal-rate limit** (:func:`cmg_gimbal_rate_constraint`). The plant realises a torque command
``u`` through ``ḣ_cmd = −u − ω × h`` and the steering law ``δ̇ = S(δ) ḣ_cmd + s₀(δ)``
— for the Moore–Penrose law ``S = A⁺ = Aᵀ(AAᵀ)⁻¹``, ``s₀ = 0``; every law of
:mod:`spacecraft.steering` is affine in ``ḣ_cmd`` at fixed δ and t (SR inverse: λ depends on δ
only; null motion: ``s₀ = k(I − A⁺A)∇m``), so ``(S, s₀)`` are read off the law itself by
probing it with ``ḣ = 0, e₁, e₂, e₃`` (exact for an affine law; checked at construction). Then

    δ̇ = −S u + (s₀ − S (ω × h)),     |δ̇_i| ≤ r   ⇔   −r − o ≤ −S u ≤ r − o,  o = s₀ − S(ω × h),

four two-sided rows, exact at the sample instant. Over the horizon the MPC keeps δ, ω, h frozen
(the gimbals move by ≤ r T per step): later stages are a first-order approximation; only the
first input is applied.

**Momentum envelope** (:func:`momentum_envelope_constraint`). Keep the stored momentum one step
ahead, ``h⁺ = h + Δt ḣ = h − Δt (u + ω × h)``, inside the sphere of radius ``ρ = margin · r_env``
inscribed in the momentum envelope. ``‖h⁺‖ ≤ ρ`` is a second-order cone, not a QP constraint;
it is linearised (*our choice*) either as

- ``shape="radial"`` (default): the tangent half-space ``n·h⁺ ≤ max(ρ, n·g)`` with ``n = h/‖h‖``,
  ``g = h⁺(u = 0)`` — one row, it stops the growth of ``‖h‖`` along its current direction; an
  outer approximation (``‖h⁺‖`` may exceed ρ by O((Δt‖u‖)²/ρ) tangentially); or
- ``shape="box"``: the cube inscribed in the sphere, ``|h⁺_i| ≤ max(ρ/√3, |g_i|)`` — three rows,
  inside the sphere (conservative: 58 % of ρ along the axes).

The ``max(·, g)`` terms keep ``u = 0`` feasible when h is already outside (then the constraint
forbids further growth instead of demanding an immediate return, which could make the QP
infeasible against the torque box).

**Envelope radius** (:func:`momentum_envelope_radius`, *numerical*). The radial extent of the
reachable momentum set {h(δ)} in direction n is ``ρ(n) = max t s.t. h(δ) = t n``, solved by SLSQP
(multi-start, analytic Jacobians); ``r_env = min_n ρ(n)`` over the gimbal axes ±gᵢ and a
Fibonacci set of 64 other directions. The minimum sits on the gimbal axes, at the bottom of the
envelope's dimples (the unit whose gimbal axis is n contributes no momentum along n): for
β = 54.73° ``r_env = 2.5225 h₀``, well below the support-function bound
h₀ Σ √(1 − (gᵢ·n)²) = 2.83 h₀ there and the 3.0–3.27 h₀ elsewhere. It assumes the reachable set
is star-shaped about 0 (it is filled for the pyramid; checked against dense sampling in the
tests).

Sources: B. Wie, *Space Vehicle Dynamics and Control*, 2nd ed., §7.5 (SGCMG
momentum envelopes and singular surfaces); Kalabić et al. 2017 (constrained MPC on SO(3)).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np
import scipy.optimize

from liecontrol._validation import as_array, as_scalar, check_positive, check_positive_scalar
from liecontrol.control.base import AttitudeState

from .sgcmg import SgcmgPyramid
from .steering import PseudoInverse, SteeringLaw

__all__ = [
    "cmg_gimbal_rate_constraint",
    "momentum_envelope_constraint",
    "momentum_envelope_radius",
    "stack_constraints",
    "steering_map",
]

Constraint = Callable[[AttitudeState], tuple[np.ndarray, np.ndarray, np.ndarray]]


def _check_cluster(cluster: object) -> SgcmgPyramid:
    for a in ("jacobian", "momentum", "gimbal_axes", "h0", "gimbal_rate_limit"):
        if not hasattr(cluster, a):
            raise ValueError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
    return cluster  # type: ignore[return-value]


def steering_map(
    law: SteeringLaw, cluster: SgcmgPyramid, delta: np.ndarray, t: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """``(S (4, 3), s0 (4,))`` with ``law(A(δ), ḣ) = S ḣ + s0`` for the affine law at ``δ``.

    Probes the law with ``ḣ = 0`` and ``ḣ = h₀ e_j`` (one batched call; exact for an affine law).
    """
    if not isinstance(law, SteeringLaw):
        raise ValueError(f"law: expected a SteeringLaw, got {type(law).__name__}")
    if not isinstance(cluster, SgcmgPyramid):
        raise ValueError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
    d = as_array(delta, "delta", (4,))
    if d.shape != (4,):
        raise ValueError(f"delta: expected shape (4,), got {d.shape}")
    t = as_scalar(t, "t")
    A = cluster.jacobian(d)
    H = np.vstack([np.zeros(3), cluster.h0 * np.eye(3)])
    out = law.steer(
        np.ascontiguousarray(np.broadcast_to(A, (4, 3, 4))),
        H,
        np.ascontiguousarray(np.broadcast_to(d, (4, 4))),
        t,
        cluster,
    )
    s0 = out[0]
    S = (out[1:] - s0).T / cluster.h0
    return S, s0


def _gimbal_angles(state: AttitudeState) -> np.ndarray:
    act = state.actuator_state
    if act is None:
        raise ValueError(
            "state: actuator_state (gimbal angles) is None; the CMG constraints need them"
        )
    a = as_array(act, "state.actuator_state")
    if a.ndim != 2 or a.shape[0] != 1 or a.shape[1] < 4:
        raise ValueError(
            f"state.actuator_state: expected (1, 4) gimbal angles (or (1, 8) with servo rates), "
            f"got {a.shape}"
        )
    return a[0, :4]


def cmg_gimbal_rate_constraint(
    cluster: SgcmgPyramid,
    rate_limit: float | None = None,
    steering: SteeringLaw | None = None,
    t: float = 0.0,
) -> Constraint:
    """``f(state) -> (C (4, 3), lo (4,), hi (4,))``: the steered gimbal rates of the torque ``u``
    stay within ``±rate_limit`` (module docstring): ``δ̇ = C u + o``, ``|δ̇_i| ≤ r``.

    Args:
        cluster: the :class:`SgcmgPyramid` (its Jacobian, momentum, default rate limit).
        rate_limit: ``r`` [rad/s] > 0 (default: ``cluster.gimbal_rate_limit``).
        steering: the plant's steering law (default :class:`PseudoInverse`, the Moore–Penrose
            law); must be affine in ``ḣ_cmd`` at fixed δ (all laws of
            :mod:`spacecraft.steering` are), which is checked here at a generic δ.
        t: time passed to time-varying laws (the dither of the generalized SR inverse; the
            constraint callable itself has no time argument).

    The returned callable reads ``state.actuator_state[0, :4]`` (gimbal angles) and
    ``state.omega[0]``; ``h = h(δ)`` from the cluster.
    """
    cluster = _check_cluster(cluster)
    r = float(check_positive(cluster.gimbal_rate_limit if rate_limit is None else rate_limit,
                             "rate_limit"))  # fmt: skip
    law = PseudoInverse() if steering is None else steering
    if not isinstance(law, SteeringLaw):
        raise ValueError(f"steering: expected a SteeringLaw, got {type(steering).__name__}")
    t = as_scalar(t, "t")
    # affinity check at a generic, non-singular gimbal set
    d_chk = np.array([0.3, -1.1, 2.0, 0.7])
    S, s0 = steering_map(law, cluster, d_chk, t)
    hdot = cluster.h0 * np.array([0.37, -0.81, 0.52])
    direct = law.steer(cluster.jacobian(d_chk)[None], hdot[None], d_chk[None], t, cluster)[0]
    if not np.allclose(direct, S @ hdot + s0, rtol=1e-8, atol=1e-10 * r):
        raise ValueError("steering: the law is not affine in h_dot_cmd at fixed gimbal angles")

    def constraint(state: AttitudeState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        delta = _gimbal_angles(state)
        w = as_array(state.omega, "state.omega", (3,)).reshape(3)
        Sd, s0d = steering_map(law, cluster, delta, t)
        off = s0d - Sd @ np.cross(w, cluster.momentum(delta))
        return -Sd, -r - off, r - off

    return constraint


@functools.lru_cache(maxsize=16)
def _envelope_radius(h0: float, beta: float) -> float:
    cl = SgcmgPyramid(h0=h0, beta=beta)
    G = cl.gimbal_axes().T
    S, C = cl._S, cl._C  # unit momenta = S sin δ + C cos δ (columns)

    def rho(n: np.ndarray, extra_starts: int) -> float:
        P = np.linalg.svd(n[None])[2][1:]  # (2, 3) basis of n's orthogonal complement
        a, b = n @ S, n @ C
        base = np.arctan2(a, b)  # the support-function maximiser of each unit
        starts = [base]
        k = int(np.argmax(np.abs(G @ n)))  # the unit whose gimbal axis is nearest to n
        for j in range(1, extra_starts + 1):
            s = base.copy()
            s[k] += 2.0 * np.pi * j / (extra_starts + 1)
            starts.append(s)
        best = 0.0
        for x0 in starts:
            res = scipy.optimize.minimize(
                lambda d: -(n @ cl.momentum(d)) / h0,
                x0,
                jac=lambda d: -(n @ cl.jacobian(d)) / h0,
                constraints=[
                    {
                        "type": "eq",
                        "fun": lambda d: P @ cl.momentum(d) / h0,
                        "jac": lambda d: P @ cl.jacobian(d) / h0,
                    }
                ],
                method="SLSQP",
                options={"ftol": 1e-12, "maxiter": 200},
            )
            h = cl.momentum(res.x)
            if np.linalg.norm(P @ h) <= 1e-8 * h0:
                best = max(best, float(n @ h))
        return best

    # directions: the gimbal axes (both signs: the envelope dimples) and a Fibonacci sphere
    m = 64
    i = np.arange(m) + 0.5
    z = 1.0 - 2.0 * i / m
    phi = np.pi * (1.0 + 5.0**0.5) * i
    fib = np.column_stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z])
    radii = [rho(s * g, 7) for g in G for s in (1.0, -1.0)]
    radii += [rho(n, 1) for n in fib]
    return float(min(radii))


def momentum_envelope_radius(cluster: SgcmgPyramid) -> float:
    """Radius ``r_env`` [N m s] of the largest origin-centred sphere inside the cluster's
    reachable momentum set (module docstring; *numerical*, ~1 s on first call, then cached)."""
    cluster = _check_cluster(cluster)
    return _envelope_radius(float(cluster.h0), float(cluster.beta))


def momentum_envelope_constraint(
    cluster: SgcmgPyramid,
    dt: float,
    radius: float | None = None,
    margin: float = 0.9,
    shape: str = "radial",
) -> Constraint:
    """``f(state) -> (C, lo, hi)`` keeping ``h⁺ = h − Δt (u + ω × h)`` inside the sphere of
    radius ``margin · radius`` (module docstring), linearised as ``shape``.

    Args:
        cluster: the :class:`SgcmgPyramid` (``h(δ)``; default radius).
        dt: look-ahead ``Δt`` > 0 [s] (typically the MPC period).
        radius: envelope sphere radius [N m s] (default :func:`momentum_envelope_radius`).
        margin: factor in (0, 1] applied to the radius.
        shape: ``"radial"`` (one tangent half-space) or ``"box"`` (the inscribed cube).

    ``h`` is ``h(δ)`` from ``state.actuator_state`` when present, else ``state.h``.
    """
    cluster = _check_cluster(cluster)
    dt = check_positive_scalar(dt, "dt")
    margin = check_positive_scalar(margin, "margin")
    if margin > 1.0:
        raise ValueError(f"margin: must lie in (0, 1], got {margin}")
    if shape not in ("radial", "box"):
        raise ValueError(f"shape: expected 'radial' or 'box', got {shape!r}")
    R0 = momentum_envelope_radius(cluster) if radius is None else radius
    rho = margin * float(check_positive(R0, "radius"))

    def constraint(state: AttitudeState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if state.actuator_state is not None:
            h = cluster.momentum(_gimbal_angles(state))
        elif state.h is not None:
            h = as_array(state.h, "state.h", (3,)).reshape(3)
        else:
            raise ValueError("state: neither actuator_state nor h is given (momentum unknown)")
        w = as_array(state.omega, "state.omega", (3,)).reshape(3)
        g = h - dt * np.cross(w, h)  # h⁺ at u = 0;  h⁺ = g − Δt u
        if shape == "box":
            b = np.maximum(rho / np.sqrt(3.0), np.abs(g))
            # −b ≤ g − Δt u ≤ b
            return -dt * np.eye(3), -b - g, b - g
        nh = float(np.linalg.norm(h))
        n = h / nh if nh > 1e-12 * cluster.h0 else np.zeros(3)
        ng = float(n @ g)
        # n·(g − Δt u) ≤ max(ρ, n·g)
        return (-dt * n)[None], np.array([-np.inf]), np.array([max(rho, ng) - ng])

    return constraint


def stack_constraints(*constraints: Constraint) -> Constraint:
    """One ``f(state) -> (C, lo, hi)`` imposing all the given constraints (rows stacked)."""
    if not constraints or not all(callable(c) for c in constraints):
        raise ValueError("constraints: expected one or more callables f(state) -> (C, lo, hi)")

    def stacked(state: AttitudeState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        parts = [c(state) for c in constraints]
        return (
            np.vstack([np.atleast_2d(p[0]) for p in parts]),
            np.concatenate([np.atleast_1d(p[1]) for p in parts]),
            np.concatenate([np.atleast_1d(p[2]) for p in parts]),
        )

    return stacked
