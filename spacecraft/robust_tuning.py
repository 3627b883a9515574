"""Gradient-based robust tuning of the geometric PD on requirements (``liecontrol[jax]``).

The closed loop of :mod:`spacecraft.differentiable` is differentiable in the controller's gains,
so a cost built from a run's *requirements* over a batch of dispersed members can be minimised
by gradient descent. For members b = 1 … B (each its own initial attitude, rate and true
inertia) and the K control samples t_k of the run:

    C(K_R, K_Ω) = mean_b [ Σ_k θ_bk² T / θ_ref,b²  +  w_u Σ_k ‖u_bk‖² T
                           + w_p Σ_r max(0, log(v_br / (m · ℓ_r)))² ],

with θ the error angle of R_dᵀR, θ_ref,b = max(θ_b0, APE bound) (the first term is a time [s]:
how long the member's error takes to decay), u the bus torque, and for each requirement r with
bound ℓ_r the member's value v_br — the requirement itself, evaluated on the control samples
(:class:`TuningRequirements`): APE = max θ over the pointing interval; settling: max θ after
the settling deadline against the settling band (the metric "first time after which θ stays in
the band" is ≤ the deadline exactly when this max is ≤ the band); overshoot = 100 · max_k
max(0, −φ_k·n₀)/θ₀ [%] with φ = log(R_dᵀR)^∨ and n₀ the start's error axis; momentum use =
max_k ‖h_k‖/σ(ĥ_k) (:func:`spacecraft.momentum.sgcmg_momentum_fraction`). m ≤ 1 is a design
margin: the penalty starts at m·ℓ (settling: at the deadline t₀ + m(t_s − t₀), a margin in the
requirement's own unit, time), so gains tuned on B members keep a margin for members they have
not seen. The penalty is on the log of the ratio: a settling error decays like e^{−σt},
so its ratio to the band changes by orders of magnitude over a modest gain change while its
log is linear in the decay rate σ (the ratio itself made the cost too steep for any fixed
step). The maxima are exact (their gradient is the sub-gradient at the arg-max), not
smoothed: a smoothed max reads a different value than the requirement does.

Gains are full symmetric positive-definite matrices, parameterised about the start gains
K₀ = L₀L₀ᵀ (Cholesky) as K_R = c² L_R M_R M_Rᵀ L_Rᵀ, K_Ω = c z L_Ω M_Ω M_Ωᵀ L_Ωᵀ: c scales the
bandwidth (the same motion c times faster), z the damping, and M is lower-triangular with
diag(M) = exp(m_ii) (``"cholesky"``: 14 parameters), diagonal (``"diagonal"``: 8) or the
identity (``"scalar"``: c and z alone). Every step is a positive-definite gain, the parameters
are dimensionless and start at 0.

Adam (Kingma & Ba, "Adam: a method for stochastic optimization", ICLR 2015) minimises C, on the
bandwidth and damping scales alone for the first half of the steps and on every parameter for
the second: a requirement on time asks for c and one on overshoot for z, while Adam's
per-coordinate steps on all parameters at once move the damping of each axis together and jump
between the overshoot hump and the slow tail (the settling error is the larger of the two, a
kink). One safeguard: a step that raises the cost is rejected and retried at half the rate,
which recovers by 1.5× per accepted step up to ``learning_rate``. The result is the evaluation
of lowest cost among those whose training members all meet every requirement at the design
margin (m·ℓ); if none does, among those meeting the bounds ℓ themselves; else the lowest cost.
(A penalty method settles slightly past where its penalty starts: a larger ``penalty_weight``
keeps it closer to m·ℓ, at the price of a rougher cost.)

What this does not promise: the requirements are met on the members the gains were tuned on;
whether they hold for others is an empirical question — check on held-out members drawn with
other seeds (``python -m benchmarks.gradient_tuning`` does, through the benchmark suite's own
runner and metrics). The sampled requirements read the control samples, not every integration
step: a peak between two samples is missed (the suite's metrics, on the logged steps, are the
judge).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from liecontrol._validation import check_nonnegative, check_positive_scalar
from liecontrol.lie import so3

from .differentiable import JaxClosedLoop, _initial, require_jax
from .momentum import sgcmg_momentum_fraction

# gains_from_parameters, requirement_values and requirement_cost are the pure (traceable)
# formulas: documented, importable, unvalidated (not in __all__, like the numpy layer's
# *_unchecked functions); tune_requirements is the validated entry point

__all__ = [
    "PARAMETERIZATIONS",
    "TuningRequirements",
    "RobustTuningResult",
    "tune_requirements",
]

#: Gain parameterisations: the number of parameters in all (bandwidth and damping scales, then
#: the shape of K_R and of K_Ω).
PARAMETERIZATIONS: dict[str, int] = {"cholesky": 14, "diagonal": 8, "scalar": 2}
_SHAPE = {"cholesky": 6, "diagonal": 3, "scalar": 0}
_TRIL = np.tril_indices(3, -1)


@dataclass(frozen=True)
class TuningRequirements:
    """Requirements the tuned loop must meet (``None``: not required).

    Attributes:
        ape_deg: APE bound [deg]: max error angle over the pointing interval.
        pointing_from: start of the pointing interval [s] (absolute time); default the last
            10 % of the run (ECSS-E-ST-60-10C's steady state as :mod:`benchmarks.requirements`
            takes it).
        settling_deg: settling band [deg]; with ``settling_by`` [s] (absolute time): the error
            stays in the band from then on.
        overshoot_pct: overshoot bound [% of the initial error angle].
        momentum_fraction: bound on the SGCMG cluster's momentum use ‖h‖/σ(ĥ) (SGCMG only).
        design_margin: m ∈ (0, 1]: each penalty starts at m × its bound.
    """

    ape_deg: float | None = None
    pointing_from: float | None = None
    settling_deg: float | None = None
    settling_by: float | None = None
    overshoot_pct: float | None = None
    momentum_fraction: float | None = None
    design_margin: float = 0.8

    def __post_init__(self) -> None:
        for name in ("ape_deg", "settling_deg", "overshoot_pct", "momentum_fraction"):
            v = getattr(self, name)
            if v is not None:
                object.__setattr__(self, name, check_positive_scalar(v, name))
        for name in ("pointing_from", "settling_by"):
            v = getattr(self, name)
            if v is not None:
                object.__setattr__(self, name, float(check_nonnegative(v, name)))
        if (self.settling_deg is None) != (self.settling_by is None):
            raise ValueError(
                "settling_deg, settling_by: give both (the band and the deadline) or neither"
            )
        m = check_positive_scalar(self.design_margin, "design_margin")
        if m > 1.0:
            raise ValueError(f"design_margin: must be in (0, 1], got {m!r}")
        object.__setattr__(self, "design_margin", m)

    @property
    def names(self) -> tuple[str, ...]:
        """The requirements set, in the order of :func:`requirement_values`' columns."""
        keys = ("ape_deg", "settling_deg", "overshoot_pct", "momentum_fraction")
        return tuple(k for k in keys if getattr(self, k) is not None)

    def limits(self) -> np.ndarray:
        """The bounds, ``(len(names),)``, in the order of :attr:`names`."""
        return np.array([float(getattr(self, k)) for k in self.names])


def _param_count(parameterization: str) -> int:
    if parameterization not in PARAMETERIZATIONS:
        raise ValueError(
            f"parameterization: expected one of {tuple(PARAMETERIZATIONS)}, got "
            f"{parameterization!r}"
        )
    return PARAMETERIZATIONS[parameterization]


def _factor(K: Any, name: str) -> np.ndarray:
    """The Cholesky factor L₀ of a gain (a positive scalar is k I, a diagonal (3,) diag(k))."""
    K = np.asarray(K, dtype=np.float64)
    if K.ndim == 0:
        K = float(check_positive_scalar(float(K), name)) * np.eye(3)
    elif K.shape == (3,):
        if not (np.all(np.isfinite(K)) and np.all(K > 0.0)):
            raise ValueError(f"{name}: a diagonal gain must be finite and positive, got {K}")
        K = np.diag(K)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise ValueError(
            f"{name}: expected a positive scalar, a positive diagonal (3,) or a finite (3, 3) "
            "matrix"
        )
    if not np.allclose(K, K.T, rtol=1e-12, atol=0.0):
        raise ValueError(f"{name}: must be symmetric to tune it as a positive-definite matrix")
    try:
        return np.linalg.cholesky(K)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name}: must be positive definite") from None


def gains_from_parameters(
    params: Any, L_R: np.ndarray, L_W: np.ndarray, parameterization: str = "cholesky"
) -> tuple[Any, Any]:
    """``(K_R, K_Ω)`` = (c² L_R M_R M_Rᵀ L_Rᵀ, c z L_W M_W M_Wᵀ L_Wᵀ) from the parameter vector
    ``params`` = (log c, log z, M_R's, M_Ω's) (:data:`PARAMETERIZATIONS` entries; module
    docstring); pure (NumPy or JAX): zero parameters give the start gains. c scales the
    bandwidth and z the damping: J θ̈ + K_Ω θ̇ + K_R e(R) = 0 with K_R·c², K_Ω·c is the same
    motion c times faster (the gyroscopic term scales alike), so the first parameter is the
    direction a requirement on time asks for, the second the overshoot's."""
    from liecontrol._array_api import namespace

    xp = namespace(params)
    _param_count(parameterization)
    n = _SHAPE[parameterization]
    scale = (xp.exp(2.0 * params[0]), xp.exp(params[0] + params[1]))
    out = []
    for L, p, k in ((L_R, params[2 : 2 + n], scale[0]), (L_W, params[2 + n : 2 + 2 * n], scale[1])):
        C = L
        if n:
            M = xp.diag(xp.exp(p[:3]))
            if parameterization == "cholesky":
                low = xp.zeros((3, 3))
                low = low.at[_TRIL].set(p[3:]) if xp is not np else _set_tril(p[3:])
                M = M + low
            C = L @ M
        out.append(k * (C @ xp.swapaxes(C, -1, -2)))
    return out[0], out[1]


def _set_tril(v: np.ndarray) -> np.ndarray:
    out = np.zeros((3, 3))
    out[_TRIL] = v
    return out


def requirement_values(
    loop: JaxClosedLoop, out: dict[str, Any], requirements: TuningRequirements
) -> dict[str, Any]:
    """One member's values (pure JAX) from its :meth:`JaxClosedLoop.rollout` log ``out``:
    ``angle`` = Σ θ_k² T / θ_ref² [s], ``effort`` = Σ ‖u_k‖² T, and each requirement of
    :attr:`TuningRequirements.names` in its unit (module docstring)."""
    jax = require_jax()
    jnp = jax.numpy
    Rs, us = out["R"], out["u"]
    R_d = jnp.asarray(loop.R_d)
    Rt = jnp.swapaxes(R_d, -1, -2) @ Rs
    phi, theta = so3._log_angle_unchecked(Rt)
    t = loop.times
    T = loop.control_period
    r = requirements
    deg = 180.0 / math.pi
    ape_rad = math.radians(r.ape_deg) if r.ape_deg is not None else 0.0
    theta_ref = jnp.maximum(theta[0], ape_rad if ape_rad > 0 else 1e-6)
    vals: dict[str, Any] = {
        "angle": jnp.sum(theta[:-1] * theta[:-1]) * T / (theta_ref * theta_ref),
        "effort": jnp.sum(us[:-1] * us[:-1]) * T,
    }
    if r.ape_deg is not None:
        start = t[-1] - 0.1 * (t[-1] - t[0]) if r.pointing_from is None else r.pointing_from
        k0 = _first_at(t, start, "pointing_from")
        vals["ape_deg"] = jnp.max(theta[k0:]) * deg
    if r.settling_deg is not None:
        k0 = _first_at(t, r.settling_by, "settling_by")
        # the band's own unit: settled iff this max ≤ settling_deg
        vals["settling_deg"] = jnp.max(theta[k0:]) * deg
        # the margin is on the requirement's own quantity, time: settled by t₀ + m(t_s − t₀)
        # (a margin on the band would be worth only ln(1/m)/σ seconds)
        early = t[0] + r.design_margin * (r.settling_by - t[0])
        vals["settling_deg_early"] = jnp.max(theta[_first_at(t, early, "settling_by") :]) * deg
    if r.overshoot_pct is not None:
        n0 = phi[0] / jnp.maximum(theta[0], 1e-12)
        past = jnp.maximum(-(phi @ n0), 0.0)
        vals["overshoot_pct"] = 100.0 * jnp.max(past) / jnp.maximum(theta[0], 1e-12)
    if r.momentum_fraction is not None:
        if loop.cluster is None:
            raise ValueError("requirements.momentum_fraction: the plant has no SGCMG cluster")
        h, _ = loop.cluster._momentum_and_jacobian(out["x"][:, 3:])
        G = np.asarray(loop.cluster.gimbal_axes(), dtype=np.float64)
        vals["momentum_fraction"] = jnp.max(sgcmg_momentum_fraction(G, loop.cluster.h0, h))
    return vals


def _first_at(t: np.ndarray, start: float, name: str) -> int:
    k = int(np.searchsorted(t, start - 1e-9 * max(1.0, abs(start))))
    if k >= t.shape[0]:
        raise ValueError(f"requirements.{name}: {start!r} s is after the run's end {t[-1]!r} s")
    return k


def requirement_cost(
    loop: JaxClosedLoop,
    params: Any,
    R0: Any,
    x0: Any,
    J: Any,
    J_inv: Any,
    L_R: np.ndarray,
    L_W: np.ndarray,
    requirements: TuningRequirements,
    parameterization: str = "cholesky",
    effort_weight: float = 0.0,
    penalty_weight: float = 1000.0,
    tuned: dict[str, np.ndarray] | None = None,
    gain_shapes: tuple[tuple[int, ...], tuple[int, ...]] = ((3, 3), (3, 3)),
) -> tuple[Any, dict[str, Any]]:
    """``(C, per-member values)`` of the module docstring's cost over the batch ``R0``
    ``(B, 3, 3)``, packed states ``x0`` and inertias ``J``, ``J_inv`` ``(B, 3, 3)``; pure JAX,
    differentiable in ``params``. ``tuned``: the loop parameters tuned as well (name → start
    value): their log-ratios to the start follow the gains' in ``params``
    (:func:`loop_parameters_from_vector`). ``gain_shapes``: the forms the law takes its gains
    in (:func:`gain_form`)."""
    jax = require_jax()
    jnp = jax.numpy
    n = _param_count(parameterization)
    k_R, k_W = gains_from_parameters(params[:n], L_R, L_W, parameterization)
    k_R, k_W = _in_form(k_R, gain_shapes[0]), _in_form(k_W, gain_shapes[1])
    extra = loop_parameters_from_vector(params[n:], tuned or {})

    def member(R, x, Jb, Jib, c0):  # noqa: ANN001, ANN202 - traced
        out = loop.rollout(k_R, k_W, R, x, Jb, Jib, extra or None, c0)
        return requirement_values(loop, out, requirements)

    vals = jax.vmap(member)(R0, x0, J, J_inv, loop.law.initial_states(R0.shape[0]))
    total = vals["angle"] + effort_weight * vals["effort"]
    for _name, key, bound in _margin_bounds(requirements):
        # log of the ratio: an error that decays like e^{-σt} then gives a penalty quadratic in
        # σ (the ratio itself, ∝ e^{-σt}, varies by orders of magnitude over a gain step)
        excess = jnp.maximum(jnp.log(jnp.maximum(vals[key], 1e-300) / bound), 0.0)
        total = total + penalty_weight * excess * excess
    return jnp.mean(total), vals


def gain_form(shape: tuple[int, ...], parameterization: str) -> tuple[int, ...]:
    """The form the tuned gain is handed to the law in: the start gain's own (``()`` a scalar,
    ``(3,)`` a diagonal, ``(3, 3)`` a matrix) unless the parameterisation needs more — a
    diagonal for ``"diagonal"``, a full matrix for ``"cholesky"`` — so a law whose gains are
    scalars or diagonals (the chart laws' k₁, k₂) is tuned in its own terms."""
    need = {"scalar": 0, "diagonal": 1, "cholesky": 2}[parameterization]
    have = {(): 0, (3,): 1, (3, 3): 2}[tuple(shape)]
    return ((), (3,), (3, 3))[max(need, have)]


def _in_form(K: Any, shape: tuple[int, ...]) -> Any:
    """The (3, 3) gain of :func:`gains_from_parameters` as a scalar, a diagonal or itself."""
    if shape == ():
        return K[0, 0]
    if shape == (3,):
        return K[(0, 1, 2), (0, 1, 2)]
    return K


def loop_parameters_from_vector(v: Any, start: dict[str, np.ndarray]) -> dict[str, Any]:
    """The tuned loop parameters ``name → start · exp(v_i)`` from the vector ``v`` (the
    entries of each parameter in turn, in the order of ``start``); pure (NumPy or JAX).
    Positive parameters on a log scale: steps relative to their size, never a sign change."""
    out, i = {}, 0
    for name, v0 in start.items():
        a = np.asarray(v0, dtype=np.float64)
        out[name] = a * _exp(v[i : i + a.size]).reshape(a.shape)
        i += a.size
    return out


def _exp(v: Any) -> Any:
    from liecontrol._array_api import namespace

    return namespace(v).exp(v)


def _margin_bounds(requirements: TuningRequirements) -> list[tuple[str, str, float]]:
    """``(requirement, value key, bound)`` of each penalty: m·ℓ, except settling, whose
    margin is on the deadline (the value ``settling_deg_early`` against the band itself)."""
    m = requirements.design_margin
    out = []
    for name in requirements.names:
        if name == "settling_deg":
            out.append((name, "settling_deg_early", float(requirements.settling_deg)))
        else:
            out.append((name, name, m * float(getattr(requirements, name))))
    return out


@dataclass(frozen=True)
class RobustTuningResult:
    """Outcome of :func:`tune_requirements`.

    Attributes:
        k_R, k_Omega: the chosen gains, in the form the law was flown with (:func:`gain_form`:
            ``(3, 3)`` symmetric positive definite, a positive diagonal ``(3,)`` or a scalar).
        step: the Adam step they come from (0: the start gains).
        feasible: whether every training member meets every requirement with them.
        within_margin: whether every training member meets every requirement at the design
            margin (m·ℓ) with them.
        requirements: the :class:`TuningRequirements` tuned for.
        loop_params: the tuned loop parameters' chosen values (``tune``; empty without).
        history: per evaluation (``steps + 1`` rows, the start first): ``cost``, ``angle``
            (batch mean, [s]), ``effort``, ``accepted`` (1: the step was taken, 0: rejected
            and retried at half the rate), for each requirement the worst member's value
            (``worst_<name>``) and its ratio to the penalty's start (``margin_<key>``: ≤ 1
            within the design margin; settling's key is ``settling_deg_early``).
        params: ``(steps + 1, n)`` the parameter vector of each evaluation (the gains', then the
            log-ratios of the ``tune`` parameters to their start).
    """

    k_R: np.ndarray
    k_Omega: np.ndarray
    step: int
    feasible: bool
    within_margin: bool
    requirements: TuningRequirements
    history: dict[str, np.ndarray]
    params: np.ndarray
    loop_params: dict[str, Any] = field(default_factory=dict)


def tune_requirements(
    loop: JaxClosedLoop,
    R0: object,
    omega0: object | None = None,
    requirements: TuningRequirements | None = None,
    *,
    k_R: Any = None,
    k_Omega: Any = None,
    parameterization: str = "cholesky",
    steps: int = 30,
    learning_rate: float = 0.05,
    effort_weight: float = 0.0,
    penalty_weight: float = 1000.0,
    tune: tuple[str, ...] = (),
) -> RobustTuningResult:
    """Tune the controller's gains on ``requirements`` over the dispersed batch ``R0``
    ``(B, 3, 3)``, ``omega0`` ``(B, 3)`` (the plant's per-member inertias, if it has them, go
    with them) by Adam on the cost of the module docstring, from ``k_R``/``k_Omega`` (default
    the controller's; scalars or symmetric positive-definite matrices). ``tune``: further
    parameters of the loop to tune with them (names of :attr:`JaxClosedLoop.params`: an
    observer's bandwidth, the steering law's ``"steering.lambda0"``), positive, on a log scale
    from their current values; they join the gains' shape parameters in the second half.

    Raises ``FloatingPointError`` naming the term whose value or gradient is non-finite (a
    diverging member, gains out of range), ``ValueError`` for bad arguments.
    """
    jax = require_jax()
    if not isinstance(loop, JaxClosedLoop):
        raise ValueError(f"loop: expected a JaxClosedLoop, got {type(loop).__name__}")
    if loop.member_refs:
        raise ValueError(
            "loop: its reference gives each member its own samples; tuning flies one reference "
            "for the whole batch (a requirement's pointing interval is the scenario's)"
        )
    if requirements is None:
        raise ValueError("requirements: give the TuningRequirements to tune for")
    if not isinstance(requirements, TuningRequirements):
        raise ValueError(
            f"requirements: expected TuningRequirements, got {type(requirements).__name__}"
        )
    if not requirements.names:
        raise ValueError("requirements: none set (every bound is None)")
    n = _param_count(parameterization)
    if isinstance(tune, str) or not all(isinstance(k, str) for k in tune):
        raise ValueError(f"tune: expected a tuple of parameter names, got {tune!r}")
    available = loop.params
    start: dict[str, np.ndarray] = {}
    for name in tune:
        if name not in available:
            raise ValueError(
                f"tune: {name!r} is not a parameter of the loop (it has {sorted(available)})"
            )
        v0 = np.asarray(available[name], dtype=np.float64)
        if not (v0 > 0.0).all():
            raise ValueError(
                f"tune: {name!r} starts at {available[name]!r}; a tuned parameter must be "
                "positive (it is tuned on a log scale)"
            )
        start[name] = v0
    n_all = n + sum(v.size for v in start.values())
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ValueError(f"steps: expected a positive int, got {steps!r}")
    learning_rate = check_positive_scalar(learning_rate, "learning_rate")
    effort_weight = float(check_nonnegative(effort_weight, "effort_weight"))
    penalty_weight = float(check_nonnegative(penalty_weight, "penalty_weight"))
    K_R0 = loop.k_R if k_R is None else k_R
    K_W0 = loop.k_Omega if k_Omega is None else k_Omega
    L_R, L_W = _factor(K_R0, "k_R"), _factor(K_W0, "k_Omega")
    shapes = (gain_form(np.shape(K_R0), parameterization),
              gain_form(np.shape(K_W0), parameterization))  # fmt: skip
    R0, w0 = _initial(R0, omega0)
    x0 = loop._pack(w0)
    J, J_inv = loop.inertias(R0.shape[0])
    J, J_inv = np.ascontiguousarray(J), np.ascontiguousarray(J_inv)
    names = requirements.names
    limits = requirements.limits()

    def cost(p):  # noqa: ANN001, ANN202 - traced
        return requirement_cost(
            loop, p, R0, x0, J, J_inv, L_R, L_W, requirements, parameterization,
            effort_weight, penalty_weight, start, shapes,
        )  # fmt: skip

    rows: dict[str, list[float]] = {k: [] for k in ("cost", "angle", "effort", "accepted")}
    rows.update({f"worst_{k}": [] for k in names})
    margin_keys = [(key, bound) for _, key, bound in _margin_bounds(requirements)]
    rows.update({f"margin_{key}": [] for key, _ in margin_keys})
    trail = []
    b1, b2, eps = 0.9, 0.999, 1e-8
    with jax.enable_x64(True):
        fn = jax.jit(jax.value_and_grad(cost, has_aux=True))

        def evaluate(p: np.ndarray) -> tuple[float, np.ndarray]:
            (value, vals), grad = fn(p)
            value, grad = float(value), np.asarray(grad)
            vals = {k: np.asarray(v) for k, v in vals.items()}
            if not (math.isfinite(value) and np.isfinite(grad).all()):
                _raise_non_finite(vals, grad, p)
            trail.append(p.copy())
            rows["cost"].append(value)
            rows["angle"].append(float(vals["angle"].mean()))
            rows["effort"].append(float(vals["effort"].mean()))
            for k in names:
                rows[f"worst_{k}"].append(float(vals[k].max()))
            for key, bound in margin_keys:
                rows[f"margin_{key}"].append(float(vals[key].max()) / bound)
            return value, grad

        params = np.zeros(n_all)
        value, grad = evaluate(params)
        rows["accepted"].append(1.0)
        m_ = np.zeros_like(params)
        v_ = np.zeros_like(params)
        lr, t = learning_rate, 0
        update = True
        # coarse to fine: bandwidth and damping alone for the first half, then every parameter
        # (Adam's per-coordinate steps on every shape parameter from the start jump across the
        # settling error's kink; the two scales alone descend smoothly)
        mask = np.zeros(n_all)
        mask[:2] = 1.0
        first = steps // 2 if n_all > 2 else steps
        for i in range(steps):
            if i == first:
                mask[:] = 1.0
                m_, v_, t, lr, update = np.zeros(n_all), np.zeros(n_all), 0, learning_rate, True
            if update:
                t += 1
                g = grad * mask
                m_ = b1 * m_ + (1.0 - b1) * g
                v_ = b2 * v_ + (1.0 - b2) * g * g
                direction = (m_ / (1.0 - b1**t)) / (np.sqrt(v_ / (1.0 - b2**t)) + eps)
            trial = params - lr * direction
            v_trial, g_trial = evaluate(trial)
            # a step that raises the cost is rejected and retried at half the rate (the cost's
            # maxima make it rough: a full Adam step can jump past a requirement's ridge)
            update = v_trial <= value
            rows["accepted"].append(float(update))
            if update:
                params, value, grad = trial, v_trial, g_trial
                lr = min(learning_rate, 1.5 * lr)
            else:
                lr *= 0.5
    history = {k: np.array(v) for k, v in rows.items()}
    worst = np.stack([history[f"worst_{k}"] for k in names], axis=1)
    ok = np.all(worst <= limits, axis=1)
    inside = np.all(np.stack([history[f"margin_{k}"] for k, _ in margin_keys], 1) <= 1.0, 1)
    cost_ = history["cost"]
    pool = inside if inside.any() else ok if ok.any() else np.ones_like(ok)
    best = int(np.argmin(np.where(pool, cost_, np.inf)))
    K_R, K_W = gains_from_parameters(trail[best][:n], L_R, L_W, parameterization)
    K_R, K_W = 0.5 * (K_R + K_R.T), 0.5 * (K_W + K_W.T)
    chosen = loop_parameters_from_vector(trail[best][n:], start)
    return RobustTuningResult(
        k_R=_in_form(K_R, shapes[0]), k_Omega=_in_form(K_W, shapes[1]), step=best,
        feasible=bool(ok[best]),
        within_margin=bool(inside[best]),
        requirements=requirements, history=history, params=np.stack(trail),
        loop_params={k: float(v) if v.ndim == 0 else v for k, v in chosen.items()},
    )  # fmt: skip


def _raise_non_finite(vals: dict[str, np.ndarray], grad: np.ndarray, params: np.ndarray) -> None:
    """``FloatingPointError`` naming the first non-finite term (its value over the members), or
    the gradient."""
    for k, v in vals.items():
        if not np.isfinite(v).all():
            bad = np.flatnonzero(~np.isfinite(v)).tolist()
            raise FloatingPointError(
                f"cost: the {k!r} term is not finite for members {bad} at parameters "
                f"{np.round(params, 6).tolist()} (a diverging member, or gains out of range)"
            )
    raise FloatingPointError(
        f"cost: the gradient is not finite at parameters {np.round(params, 6).tolist()} "
        f"(entries {np.flatnonzero(~np.isfinite(grad)).tolist()})"
    )
