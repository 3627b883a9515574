"""Model predictive control on SO(3) (Kalabić et al. 2017 style).

Error state (log error): with ``R̃ = R_dᵀR``,

    x = (ξ, e_Ω) ∈ ℝ⁶,   ξ = log(R̃)^∨,   e_Ω = Ω − R̃ᵀΩ_d,

so that exactly ``d/dt R̃ = R̃ e_Ω^`` and ``ξ̇ = J_r(ξ)⁻¹ e_Ω``. The QP decision variables are the
**full** body torques ``u_0 … u_{N−1}`` (zero-order held over the MPC period ``T``), so the box
``|u_i| ≤ u_max`` is the real torque limit.

Prediction model (*reconstructed*; the structure follows Kalabić, Gupta, Di Cairano, Bloch &
Kolmanovsky, "MPC on manifolds with an application to the control of spacecraft attitude on
SO(3)", Automatica 76 (2017) 293–300: discrete Lie-group dynamics, error linearised in the Lie
algebra about the reference). The discrete dynamics are the rigid-body LGVI (
Lee, Leok & McClamroch 2005) with step ``T`` and the held torque ``M_k = M_{k+1} = u_k``:

    T (Π_k + (T/2) u_k)^ = F_k J_d − J_d F_kᵀ,   R_{k+1} = R_k F_k,
    Π_{k+1} = F_kᵀ (Π_k + (T/2) u_k) + (T/2) u_k.

*Stage 0* is predicted with the **nonlinear** LGVI from the measured state, at the nominal torque
``ū = clip(u_ref,0)``: ``x_1 = x_1(ū) + B_0 (u_0 − ū)``. The affine term carries the exact
gyroscopic coupling ``Ω × JΩ`` of the current (possibly large) rate. ``B_0`` is, by default, the
reference linearisation's (below), which keeps the QP matrix constant for regulation; with
``exact_stage0_jacobian=True`` it is the exact derivative at the measured state: with
``G = Π_0 + (T/2)ū`` and ``K(F) = (tr(F J_d) I − F J_d) F`` (the derivative of
``(F J_d − J_d Fᵀ)^∨`` under ``F → F exp(δf^)``), ``δf = K⁻¹ (T²/2) δu`` and

    dξ_1 = J_r(ξ_1)⁻¹ δf,
    de_Ω1 = J⁻¹ [(FᵀG)^ δf + (T/2)(Fᵀ + I) δu] − (R̃_1ᵀΩ_d,1)^ δf.

*Stages k ≥ 1* use the LGVI linearised about the reference (the Kalabić et al. approach): with
reference knots ``Ω_d,k`` and reference steps ``F_k = R_d,kᵀR_d,k+1`` (from ``reference_preview``
or, by default, extrapolated from the current sample with constant ``Ω̇_d``), the LGVI equation
read backwards gives ``G_k = (F_k J_d − J_d F_kᵀ)^∨ / T`` (no Newton solve), the reference
torque ``u_ref,k = (2/T)(G_k − JΩ_d,k)`` (the discrete analogue of the feed-forward
``JΩ̇_d + Ω_d × JΩ_d``) and the momentum defect ``d_k = F_kᵀG_k + (T/2)u_ref,k − JΩ_d,k+1``
(zero for regulation). For right perturbations ``R = R_d exp(ζ^)``, ``Π = JΩ_d + δΠ``:

    δf = K(F_k)⁻¹ T (δΠ_k + (T/2) δu_k),
    ζ_{k+1} = F_kᵀ ζ_k + δf,
    δΠ_{k+1} = (F_kᵀG_k)^ δf + F_kᵀ δΠ_k + (T/2)(F_kᵀ + I) δu_k + d_k,

and ``x = S_k (ζ, δΠ)`` with ``S_k = [[I, 0], [−Ω_d,k^, J⁻¹]]`` gives
``x_{k+1} = A_k x_k + B_k (u_k − u_ref,k) + c_k``. At rest (``Ω_d ≡ 0``) this is the exact
zero-order-hold double integrator ``A = [[I, T I], [0, I]]``, ``B = [[T²/2 J⁻¹], [T J⁻¹]]``.

QP (horizon ``N``):

    min Σ_{k=1}^{N−1} x_kᵀ Q x_k + x_Nᵀ P x_N + Σ_{k=0}^{N−1} (u_k − u_ref,k)ᵀ R (u_k − u_ref,k)
    s.t. the model above, −u_max ≤ u_k ≤ u_max, lo ≤ C u_k ≤ hi (optional, every stage),

with ``P`` (default) the solution of the discrete algebraic Riccati equation of the rest model
(``scipy.linalg.solve_discrete_are``): the unconstrained infinite-horizon cost-to-go for
regulation (for tracking, the rest model's is used as an approximation). The optional
``extra_constraints(state) -> (C, lo, hi)`` is evaluated at the current state (e.g. a CMG
momentum-rate or gimbal-rate limit mapped through the cluster Jacobian, provided by the
spacecraft side) and imposed on every stage.

Backends: ``"osqp"`` builds the sparse (non-condensed) QP once per spacecraft and each step only
updates the numerical values that changed in place (``q``, ``l``, ``u``; ``Ax`` only when the
linearisation changed) and warm-starts from the previous solution shifted by one stage;
``"cvxpy"`` is the readable reference formulation with ``cp.Parameter``s (DPP: compiled once),
solved by Clarabel (an interior-point method: an independent route to the same minimiser).

Pointing cones (``keep_out``/``keep_in``): with ``c(R) = bᵀRᵀs`` and stage ``k``'s attitude
``R_k = R_d,k exp(ξ_k^)`` linearised about the previous plan ``ξ̄_k`` (shifted by one stage),
``c(R_k) ≈ c̄_k + (b × R̄_kᵀs)·J_r(ξ̄_k)(ξ_k − ξ̄_k)`` (:func:`_cone_rows`); each cone gives the
row ``G_k ξ_k − s_k ≤ h_k`` with a slack ``s_k ≥ 0`` costing ``ρ s_k + ρ s_k²``,
``ρ = slack_weight · λ_max(P)`` (an exact penalty: the slack is zero whenever the linearised
cones can be met). The rows change every step (a KKT refactorisation per step); slack use is in
``diagnostics()`` (``cone_slack_max``, ``cone_slack_used``) and its onset is logged.

Certificate: an OSQP answer is used only if its KKT certificate (``_OsqpQP.certificate``: the
duality gap with primal violations charged at the multipliers' price, turned into a bound on
every planned torque's distance from the minimiser by the strong convexity in ``u``) is within
``kkt_tolerance``; otherwise — and for any status but *solved* (optionally *solved
inaccurate*) — the same QP is re-solved by Clarabel (interior point, then an exact KKT solve on
its active set) and that answer must pass the same certificate. Re-solved steps are in
``diagnostics()`` and their onset is logged.

Braking filter: with cones, the torque goes through the braking-margin filter of
:class:`~liecontrol.control.constrained.SampledSafeConstrainedPD` at the MPC period and box
(``safety_filter``): the linearised rows hold only at the samples over the horizon, which can be
shorter than a fast approach's stopping time; a start the box cannot stop warns first.

Failure: a step neither solver certifies, or a solver exception, hands the step to the
fallback controller (default :class:`GeometricPD` built from the same ``J``), whose torque is
clipped to the box; the status code, the fallback flag and a warning on the
``liecontrol.control.mpc`` logger record it.
"""

from __future__ import annotations

import copy
import logging
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from .._validation import (
    as_array,
    as_scalar,
    check_inertia_3x3,
    check_output_finite,
    check_positive,
    check_positive_scalar,
    check_rotation_matrix,
    check_spd,
    rotations_pass_fast,
)
from ..integrators.lgvi import lgvi_step_unchecked
from ..lie import so3
from .base import AttitudeController, AttitudeReference, AttitudeState, check_state_batch
from .constrained import KeepInCone, KeepOutCone, braking_filter, check_recoverable
from .geometric_pd import GeometricPD, gains_from_bandwidth

__all__ = [
    "SO3MPC",
    "STATUS_NAMES",
    "error_state",
    "reference_model",
    "stage0_model",
    "rest_model",
    "check_weight",
]

_log = logging.getLogger(__name__)

#: Status codes of :meth:`SO3MPC.diagnostics` ``"status"`` (both backends use the same codes).
STATUS_NAMES: dict[int, str] = {
    0: "not run",
    1: "solved",
    2: "solved inaccurate",
    -3: "primal infeasible",
    -4: "primal infeasible inaccurate",
    -5: "dual infeasible / unbounded",
    -6: "dual infeasible inaccurate",
    -7: "maximum iterations reached",
    -8: "time limit reached",
    -9: "non convex",
    -10: "interrupted",
    -11: "unsolved",
    -12: "update rejected (invalid problem data)",
    -13: "not converged (KKT certificate failed)",
    -99: "solver exception",
}

_CVXPY_STATUS = {
    "optimal": 1,
    "optimal_inaccurate": 2,
    "infeasible": -3,
    "infeasible_inaccurate": -4,
    "unbounded": -5,
    "unbounded_inaccurate": -6,
    "user_limit": -7,
}

#: OSQP's infinity (bounds beyond it are rejected).
_OSQP_INF = 1e30

# Tuned on benchmarks/perf_mpc.py (docs/mpc.md): a loose ADMM tolerance followed by polishing
# (an equality-constrained KKT solve on the guessed active set) gives the exact minimiser — it
# agrees with the interior-point reference to ~1e-8 N·m — in ~15 instead of ~40 ADMM iterations;
# should polishing fail (wrong active-set guess), the step goes on to eps × 1e-2
# (_OsqpQP.solve). Termination is checked every 5 iterations (default 25: most warm-started
# solves need 10–20), and rho is adapted on a fixed iteration count (OSQP's default ties it to
# the measured setup time, which makes the iterates depend on the machine's load).
_OSQP_DEFAULTS: dict[str, Any] = {
    "eps_abs": 1e-3,
    "eps_rel": 1e-3,
    "max_iter": 4000,
    "polishing": True,
    "check_termination": 5,
    "adaptive_rho_interval": 25,
    "warm_starting": True,
    "verbose": False,
}

#: OSQP iteration cap when pointing cones are given. ADMM on the exact-penalty cone QP often
#: stalls far from the minimiser: measured on the three keep-out scenarios, answers it reported
#: "solved" after 20 000 iterations were still off by up to 26 N·m, and a quarter of the steps
#: fail the KKT certificate whatever the cap. Such a step is re-solved by Clarabel (about a
#: millisecond), so iterating beyond the default cap only costs time.
_OSQP_CONE_MAX_ITER = 4000

#: Tolerance factor of the re-solve after a failed polish (see _OSQP_DEFAULTS).
_POLISH_RETRY_FACTOR = 1e-2

# Clarabel's default gap tolerance (1e-8, relative to a large objective) leaves ~5e-5 N·m in the
# torques of this badly scaled QP (inertia ~1e4); tighter tolerances make the reference
# formulation an accurate yardstick.
_CVXPY_DEFAULTS: dict[str, Any] = {
    "solver": "CLARABEL",
    "tol_gap_abs": 1e-10,
    "tol_gap_rel": 1e-10,
    "tol_feas": 1e-10,
    "tol_ktratio": 1e-8,
}


# ------------------------------------------------------------------------------------------------
# small fast kernels (no validation: callers validate)


def _hat(w: np.ndarray) -> np.ndarray:
    W = np.zeros(w.shape + (3,))
    W[..., 0, 1] = -w[..., 2]
    W[..., 0, 2] = w[..., 1]
    W[..., 1, 0] = w[..., 2]
    W[..., 1, 2] = -w[..., 0]
    W[..., 2, 0] = -w[..., 1]
    W[..., 2, 1] = w[..., 0]
    return W


def _skew_vee(M: np.ndarray) -> np.ndarray:
    """(M − Mᵀ)^∨ / 1 for a matrix whose skew part is wanted (M − Mᵀ is exactly skew)."""
    return np.stack(
        (M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]),
        axis=-1,
    )


def _mv(A: np.ndarray, v: np.ndarray) -> np.ndarray:
    return (A @ v[..., None])[..., 0]


def _dgdf(F: np.ndarray, Jd: np.ndarray) -> np.ndarray:
    """K(F) = (tr(F J_d) I − F J_d) F: δ(F J_d − J_d Fᵀ)^∨ = K δf for F → F exp(δf^)."""
    A = F @ Jd
    tr = np.trace(A, axis1=-2, axis2=-1)
    return (tr[..., None, None] * np.eye(3) - A) @ F


def _jd(J: np.ndarray) -> np.ndarray:
    return 0.5 * np.trace(J) * np.eye(3) - J


# ------------------------------------------------------------------------------------------------
# public pure functions: the error coordinates and the prediction model


def error_state(R: object, omega: object, R_d: object, omega_d: object) -> np.ndarray:
    """``x = (log(R_dᵀR)^∨, Ω − R̃ᵀΩ_d)``, ``(..., 6)`` (module docstring)."""
    R = check_rotation_matrix(R, "R")
    R_d = check_rotation_matrix(R_d, "R_d")
    w = as_array(omega, "omega", (3,))
    w_d = as_array(omega_d, "omega_d", (3,))
    return _error_unchecked(R, w, R_d, w_d)


def _error_unchecked(R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray) -> np.ndarray:
    Rt = np.swapaxes(R_d, -1, -2) @ R
    xi = so3.log_unchecked(Rt)  # R and R_d were checked by the caller
    e_w = w - _mv(np.swapaxes(Rt, -1, -2), w_d)
    return np.concatenate(np.broadcast_arrays(xi, e_w), axis=-1)


def reference_model(
    J: np.ndarray, dt: float, omega_d: np.ndarray, F_ref: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """LGVI linearised about the reference (module docstring), vectorised over the stages.

    Args:
        J: ``(3, 3)`` inertia. dt: MPC period ``T``.
        omega_d: ``(n + 1, 3)`` reference rates at the knots ``k = 0 … n``.
        F_ref: ``(n, 3, 3)`` reference steps ``R_d,kᵀR_d,k+1``.

    Returns:
        ``A (n, 6, 6)``, ``B (n, 6, 3)``, ``u_ref (n, 3)``, ``c (n, 6)`` with
        ``x_{k+1} = A_k x_k + B_k (u_k − u_ref,k) + c_k``.

    Raises ``ValueError`` naming the argument for an invalid inertia, ``dt ≤ 0``, shapes that do
    not match, non-rotations in ``F_ref``, or a model that overflows float64.
    """
    J = check_inertia_3x3(J, "J")
    dt = check_positive_scalar(dt, "dt")
    F = check_rotation_matrix(F_ref, "F_ref")
    if F.ndim != 3 or F.shape[0] < 1:
        raise ValueError(f"F_ref: expected shape (n, 3, 3) with n >= 1, got {F.shape}")
    w = as_array(omega_d, "omega_d")
    if w.shape != (F.shape[0] + 1, 3):
        raise ValueError(f"omega_d: expected shape ({F.shape[0] + 1}, 3), got {w.shape}")
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        out = _reference_model(J, dt, w, F)
    for a in out:
        check_output_finite(a, "dt", "the linearised model")
    return out


def _reference_model(
    J: np.ndarray, dt: float, omega_d: np.ndarray, F_ref: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`reference_model` without validation (the controller's own, valid data)."""
    n = F_ref.shape[0]
    Jd = _jd(J)
    Jinv = np.linalg.inv(J)
    T = dt
    G = _skew_vee(F_ref @ Jd) / T  # F J_d − J_d Fᵀ = M − Mᵀ with M = F J_d
    Pi = omega_d @ J.T
    u_ref = (2.0 / T) * (G - Pi[:-1])
    Ft = np.swapaxes(F_ref, -1, -2)
    d = _mv(Ft, G) + 0.5 * T * u_ref - Pi[1:]
    Kinv = np.linalg.inv(_dgdf(F_ref, Jd))
    FtG_hat = _hat(_mv(Ft, G))
    # (ζ, δΠ) dynamics: δf = T K⁻¹ δΠ + (T²/2) K⁻¹ δu, then x = S (ζ, δΠ) with
    # S_k = [[I, 0], [−Ω_d,k^, J⁻¹]] and S_k⁻¹ = [[I, 0], [J Ω_d,k^, J]]; the products
    # A_k = S_{k+1} Â_k S_k⁻¹ and B_k = S_{k+1} B̂_k written out blockwise (3×3 products only)
    Wd = _hat(omega_d)
    W0, W1 = Wd[:-1], Wd[1:]
    X = T * (Kinv @ J)  # ζ-row of Â S⁻¹ acting on the rate block
    Mb = T * FtG_hat @ Kinv + Ft  # δΠ → δΠ block of Â
    MJ = Jinv @ (Mb @ J)
    A = np.empty((n, 6, 6))
    A_tl = Ft + X @ W0
    A[:, :3, :3] = A_tl
    A[:, :3, 3:] = X
    A[:, 3:, :3] = MJ @ W0 - W1 @ A_tl
    A[:, 3:, 3:] = MJ - W1 @ X
    B = np.empty((n, 6, 3))
    B_top = 0.5 * T * T * Kinv
    B[:, :3] = B_top
    B[:, 3:] = Jinv @ (0.5 * T * T * FtG_hat @ Kinv + 0.5 * T * (Ft + np.eye(3))) - W1 @ B_top
    c = np.zeros((n, 6))
    c[:, 3:] = d @ Jinv.T  # S_{k+1} (0, d_k) = (0, J⁻¹ d_k)
    return A, B, u_ref, c


def rest_model(J: object, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` of :func:`reference_model` at rest (``Ω_d ≡ 0``): the ZOH double integrator.
    Validates ``J`` and ``dt`` as :func:`reference_model` does."""
    A, B, _, _ = reference_model(J, dt, np.zeros((2, 3)), np.eye(3)[None])
    return A[0], B[0]


def stage0_model(
    J: np.ndarray,
    dt: float,
    R: np.ndarray,
    omega: np.ndarray,
    R_d1: np.ndarray,
    omega_d1: np.ndarray,
    u_bar: np.ndarray,
    jacobian: bool = True,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Nonlinear LGVI prediction of stage 0 and its exact input Jacobian (module docstring).

    One spacecraft: ``R (3, 3)``, ``omega (3,)``, next reference knot ``R_d1 (3, 3)``,
    ``omega_d1 (3,)``, nominal torque ``u_bar (3,)``. Returns ``x1 (6,)`` (the error state at
    ``t + T`` under ``u_bar``) and ``B0 (6, 3)`` with ``x_1 ≈ x1 + B0 (u_0 − u_bar)`` (``None``
    if ``jacobian=False``).
    """
    J = check_inertia_3x3(J, "J")
    dt = check_positive(dt, "dt")
    if not isinstance(dt, float):
        raise ValueError("dt: must be a scalar")
    R = check_rotation_matrix(R, "R")
    R_d1 = check_rotation_matrix(R_d1, "R_d1")
    for name, a in (("R", R), ("R_d1", R_d1)):
        if a.shape != (3, 3):
            raise ValueError(f"{name}: expected shape (3, 3), got {a.shape}")
    vecs = []
    for name, v in (("omega", omega), ("omega_d1", omega_d1), ("u_bar", u_bar)):
        a = as_array(v, name, (3,))
        if a.shape != (3,):
            raise ValueError(f"{name}: expected shape (3,), got {a.shape}")
        vecs.append(a)
    w, wd1, ub = vecs
    return _stage0(J, np.linalg.inv(J), dt, R, w, R_d1, wd1, ub, bool(jacobian))


def _stage0(J, Jinv, dt, R, omega, R_d1, omega_d1, u_bar, jacobian):
    """:func:`stage0_model` on validated input (the unchecked LGVI step: the hot path)."""
    T = dt
    Pi0 = J @ omega
    R1, Pi1 = lgvi_step_unchecked(R, Pi0, u_bar, u_bar, T, J, Jinv)
    Rt = R_d1.T @ R1
    xi = _log_one(Rt)
    wd_body = Rt.T @ omega_d1
    x1 = np.empty(6)
    x1[:3] = xi
    x1[3:] = Jinv @ Pi1 - wd_body
    if not jacobian:
        return x1, None
    F = R.T @ R1
    G = Pi0 + 0.5 * T * u_bar
    Kinv = np.linalg.inv(_dgdf(F, _jd(J)))
    dfdu = 0.5 * T * T * Kinv
    dPi = _hat(F.T @ G) @ dfdu + 0.5 * T * (F.T + np.eye(3))
    B0 = np.empty((6, 3))
    B0[:3] = so3.right_jacobian_inv(xi) @ dfdu
    B0[3:] = Jinv @ dPi - _hat(wd_body) @ dfdu
    return x1, B0


def _log_one(M: np.ndarray) -> np.ndarray:
    """``so3.log`` of one checked rotation ``(3, 3)`` on Python floats (``so3._log_floats``);
    nearer π than ``so3``'s switch to the symmetric-part axis it defers to ``so3.log``."""
    p = so3._log_floats(*M.ravel().tolist())
    return so3.log(M) if p is None else np.array(p)


def _error_fast(R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray) -> np.ndarray:
    """:func:`error_state` on validated ``(B, …)`` input, ``(B, 6)``; one spacecraft with one
    reference sample on the Python-float log."""
    if R.shape[0] != 1 or R_d.size != 9:
        return _error_unchecked(R, w, R_d, w_d)
    Rt = R_d.reshape(3, 3).T @ R[0]
    out = np.empty((1, 6))
    out[0, :3] = _log_one(Rt)
    out[0, 3:] = w[0] - Rt.T @ w_d.reshape(3)
    return out


def check_weight(W: object, name: str, n: int) -> np.ndarray:
    """A symmetric positive-definite ``n × n`` weight (a positive ``(n,)`` vector means its
    diagonal). Raises ``ValueError`` naming ``name`` otherwise."""
    a = as_array(W, name)
    if a.shape == (n,):
        check_positive(a, name)
        return np.diag(a)
    if a.shape != (n, n):
        raise ValueError(f"{name}: expected shape ({n},) or ({n}, {n}), got {a.shape}")
    # a relative floor: an eigenvalue at round-off level of the largest counts as singular
    check_spd(a, name, symbol="W", pd_rtol=1e-12)
    return 0.5 * (a + a.T)


# ------------------------------------------------------------------------------------------------
# QP backends (one instance per spacecraft)


class _Model:
    """One linearisation over the horizon, with everything the QP needs precomputed once.

    ``ct`` holds ``c̃_k = c_k − B_k u_ref,k`` (so ``x_{k+1} = A_k x_k + B_k u_k + c̃_k``; row 0 is
    replaced each step by the stage-0 prediction), ``q_u = −(R u_ref,k)`` stacked (the linear
    cost), ``u_bar = clip(u_ref,0)`` the stage-0 nominal torque. Immutable once built: the QPs
    recognise an unchanged model by identity and then skip the matrix update.
    """

    __slots__ = ("A", "B", "u_ref", "ct", "q_u", "u_bar", "ws", "F")

    def __init__(self, A, B, u_ref, c, ws, F, Rw, u_max):
        self.A, self.B, self.u_ref, self.ws, self.F = A, B, u_ref, ws, F
        self.ct = c - _mv(B, u_ref)
        self.q_u = -(u_ref @ Rw).ravel()
        self.u_bar = np.clip(u_ref[0], -u_max, u_max)


class _OsqpQP:
    """Sparse QP in z = (x_1 … x_N, u_0 … u_{N−1}); structure fixed at construction.

    Constraint rows: dynamics (6N, equality), input box (3N), extra (mN). Every entry of the
    A_k, B_k and C blocks is structurally present (even if zero at build time), so the values can
    be replaced in place with ``update(Ax=...)`` (same sparsity pattern: OSQP refactorises the
    KKT matrix numerically, no new symbolic analysis).

    Per step only what changed is sent: ``l``/``u`` (the stage-0 prediction is always new),
    ``q`` when the reference torque changed, ``Ax`` when the linearisation (or the extra
    constraint matrix, or the exact stage-0 Jacobian) changed — the only case that costs a KKT
    refactorisation. The previous solution, shifted by one stage, is the warm start of both the
    primal and the dual iterates when the controller advanced by exactly one period.

    The hot path talks to OSQP's compiled solver object (``OSQP._solver``) directly: the Python
    wrapper's ``solve`` copies every info field into a namespace (~80 µs per call, measured);
    if that attribute is missing (another osqp version) the public API is used.
    """

    def __init__(
        self,
        N: int,
        Q: np.ndarray,
        R: np.ndarray,
        P: np.ndarray,
        m: int,
        settings: dict,
        u_max: np.ndarray,
        nc: int = 0,
        slack_weights: tuple[float, float] = (0.0, 0.0),
        torque_tol: float | None = None,
        resolve: bool = False,
        accept_inaccurate: bool = False,
    ) -> None:
        import osqp

        self.N, self.m, self.nc = N, m, nc
        nx, nu, ns = 6 * N, 3 * N, nc * N
        self.nx, self.nu, self.ns = nx, nu, ns
        Hx = sp.block_diag([Q] * (N - 1) + [P]) if N > 1 else sp.csc_matrix(P)
        blocks = [Hx, sp.kron(sp.eye(N), R)]
        if ns:
            # the cvxpy cost is twice OSQP's ½zᵀHz + qᵀz: ρ₁ Σs + ρ₂ Σs² ↔ H = ρ₂ I, q = ρ₁/2
            blocks.append(slack_weights[1] * sp.eye(ns))
        H = sp.block_diag(blocks, format="csc")
        self.R = R
        # the certificate's data (certificate, _clarabel): H, H⁻¹ blockwise, λ_min(R)
        self._H = H.tocsr()
        self._H_upper = sp.triu(H, format="csc")
        inv_blocks = [np.linalg.inv(Q)] * (N - 1) + [np.linalg.inv(P)]
        inv_blocks += [np.linalg.inv(R)] * N
        if ns:
            inv_blocks.append(sp.eye(ns) / slack_weights[1])
        self._Hinv = sp.block_diag(inv_blocks, format="csr")
        self._lam_R = float(np.linalg.eigvalsh(R)[0])
        self.torque_tol, self.resolve = torque_tol, bool(resolve)
        self.accept_inaccurate = bool(accept_inaccurate)
        self.osqp_status = 0
        self.resolved = False
        self.resolves = 0
        self.torque_bound = np.nan
        # COO triplets of the constraint matrix; `slots` remembers where each block lives
        rows: list[np.ndarray] = []
        cols: list[np.ndarray] = []
        vals: list[np.ndarray] = []
        slot_A: list[slice] = []
        slot_B: list[slice] = []
        slot_C: list[slice] = []
        count = 0

        def add(r0: int, c0: int, block: np.ndarray) -> slice:
            nonlocal count
            nr, nc = block.shape
            rr, cc = np.meshgrid(np.arange(nr), np.arange(nc), indexing="ij")
            rows.append((r0 + rr).ravel())
            cols.append((c0 + cc).ravel())
            vals.append(block.ravel())
            s = slice(count, count + nr * nc)
            count += nr * nc
            return s

        for k in range(N):
            add(6 * k, 6 * k, np.eye(6))
            if k >= 1:
                slot_A.append(add(6 * k, 6 * (k - 1), np.ones((6, 6))))
            slot_B.append(add(6 * k, nx + 3 * k, np.ones((6, 3))))
        r_box = 6 * N
        for k in range(N):
            add(r_box + 3 * k, nx + 3 * k, np.eye(3))
        r_ext = r_box + 3 * N
        for k in range(N):
            if m:
                slot_C.append(add(r_ext + m * k, nx + 3 * k, np.ones((m, 3))))
        # cone rows a_kᵀ ξ_{k+1} − s_k ≤ h_k (one per cone and stage), then s ≥ 0
        r_cone = r_ext + m * N
        r_slack = r_cone + ns
        slot_G: list[slice] = []
        for k in range(nc and N):
            slot_G.append(add(r_cone + nc * k, 6 * k, np.ones((nc, 3))))
            for j in range(nc):
                add(r_cone + nc * k + j, nx + nu + nc * k + j, -np.ones((1, 1)))
                add(r_slack + nc * k + j, nx + nu + nc * k + j, np.ones((1, 1)))
        self.r_ext, self.r_cone, self.r_slack = r_ext, r_cone, r_slack
        self.vals = np.concatenate(vals)
        r = np.concatenate(rows)
        c = np.concatenate(cols)
        self.n_con = r_slack + ns
        ids = np.arange(1, count + 1, dtype=np.float64)
        Aid = sp.csc_matrix((ids, (r, c)), shape=(self.n_con, nx + nu + ns))
        Aid.sort_indices()
        self._A_struct = (Aid.indices.copy(), Aid.indptr.copy(), Aid.shape)
        # position p of the CSC data holds COO entry order[p]
        self.order = Aid.data.astype(np.int64) - 1

        def idx(slots: list[slice]) -> np.ndarray:
            return np.array([np.arange(s.start, s.stop) for s in slots], dtype=np.int64)

        self.idx_A = idx(slot_A)
        self.idx_B = idx(slot_B)
        self.idx_C = idx(slot_C).ravel() if m else np.zeros(0, dtype=np.int64)
        self.idx_G = idx(slot_G) if ns else np.zeros((0, 0), dtype=np.int64)
        self.l = np.zeros(self.n_con)
        self.u = np.zeros(self.n_con)
        self.l[r_box:r_ext] = np.tile(-u_max, N)
        self.u[r_box:r_ext] = np.tile(u_max, N)
        self.l[r_cone:r_slack] = -_OSQP_INF
        self.u[r_slack:] = _OSQP_INF
        self.q = np.zeros(nx + nu + ns)
        self.q[nx + nu :] = 0.5 * slack_weights[0]
        self.slack: np.ndarray | None = None  # (N, nc) of the last accepted solution
        self.xi_plan: np.ndarray | None = None  # (N, 3) predicted ξ_1 … ξ_N, last solution
        Aid.data = self.vals[self.order]
        self.solver = osqp.OSQP()
        # osqp ≥ 1.0 raises on invalid data; older versions return a non-zero exit code
        try:
            rc = self.solver.setup(H, self.q, Aid, self.l, self.u, **settings)
        except Exception as exc:
            raise RuntimeError(f"SO3MPC: OSQP setup rejected the QP ({exc!r})") from exc
        if rc not in (None, 0):  # pragma: no cover - another osqp version
            raise RuntimeError(f"SO3MPC: OSQP setup rejected the QP (exit code {rc})")
        self._polish = bool(self.solver.settings.polishing)
        self._eps = (float(self.solver.settings.eps_abs), float(self.solver.settings.eps_rel))
        self.polish_retries = 0
        self._s = getattr(self.solver, "_solver", None)
        if self._s is not None and not all(
            hasattr(self._s, a) for a in ("solve", "update_data_vec", "update_data_mat", "info")
        ):  # pragma: no cover - another osqp version
            self._s = None
        self._model: _Model | None = None
        self._C: np.ndarray | None = None
        self._B0_set = False
        self._mat_dirty = False
        self._q_dirty = False
        # the shifted-warm-start index maps: z_k ← z_{k+1}, the last stage repeated
        self._x_shift = np.concatenate(
            [_shift_index(N, 6), nx + _shift_index(N, 3), nx + nu + _shift_index(N, nc)]
        )
        self._y_shift = np.concatenate(
            [
                _shift_index(N, 6),
                r_box + _shift_index(N, 3),
                r_ext + _shift_index(N, m),
                r_cone + _shift_index(N, nc),
                r_slack + _shift_index(N, nc),
            ]
        )
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    def set_data(
        self,
        model: _Model,
        c0: np.ndarray,
        B0: np.ndarray | None,
        extra: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
        cones: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        N, nx, vals = self.N, self.nx, self.vals
        if model is not self._model:
            if N > 1:
                vals[self.idx_A] = -model.A[1:].reshape(N - 1, 36)
            vals[self.idx_B] = -model.B.reshape(N, 18)
            self.l[6:nx] = self.u[6:nx] = model.ct[1:].ravel()
            self.q[nx : nx + self.nu] = model.q_u
            self._model = model
            self._mat_dirty = self._q_dirty = True
            self._B0_set = False
        if B0 is not None:
            vals[self.idx_B[0]] = -B0.ravel()
            self._mat_dirty = self._B0_set = True
        elif self._B0_set:
            vals[self.idx_B[0]] = -model.B[0].ravel()
            self._mat_dirty, self._B0_set = True, False
        self.l[:6] = c0
        self.u[:6] = c0
        if extra is not None:
            C, lo, hi = extra
            if self._C is None or not np.array_equal(C, self._C):
                vals[self.idx_C] = np.tile(C.ravel(), N)
                self._C = C.copy()
                self._mat_dirty = True
            # OSQP treats ±1e30 as infinite; it rejects larger magnitudes
            self.l[self.r_ext : self.r_cone] = np.tile(np.maximum(lo, -_OSQP_INF), N)
            self.u[self.r_ext : self.r_cone] = np.tile(np.minimum(hi, _OSQP_INF), N)
        if cones is not None:
            # the linearisation moves every step: the rows change, so the KKT is refactorised
            G, h = cones
            vals[self.idx_G] = G.reshape(N, -1)
            self.u[self.r_cone : self.r_slack] = h.ravel()
            self._mat_dirty = True

    def _retry(self, info: Any) -> Any:
        """Polishing failed (its active-set guess from the loose ADMM iterate was wrong):
        iterate on, warm-started, to ``eps × _POLISH_RETRY_FACTOR`` and polish again. The
        reported iterations and run time are the sum of both solves."""
        s = self._s
        ea, er = self._eps
        f = _POLISH_RETRY_FACTOR
        self.polish_retries += 1
        self.solver.update_settings(eps_abs=ea * f, eps_rel=er * f)
        try:
            rc = s.solve()
        finally:
            self.solver.update_settings(eps_abs=ea, eps_rel=er)
        if rc:
            return _SolveInfo(_STATUS_EXCEPTION, info.iter, info.run_time)  # status -99
        second = s.info
        return _SolveInfo(
            second.status_val, info.iter + second.iter, info.run_time + second.run_time
        )

    def warm_start_shifted(self) -> None:
        """Warm-start from the last solution shifted by one stage (receding horizon)."""
        if self._last is None:
            return
        x, y = self._last
        if self._s is not None:
            if self._s.warm_start(x[self._x_shift], y[self._y_shift]):
                self._last = None  # rejected: this step starts cold (OSQP kept no warm start)
        else:  # pragma: no cover - another osqp version
            self.solver.warm_start(x=x[self._x_shift], y=y[self._y_shift])

    def _osqp(self) -> tuple[int, np.ndarray | None, np.ndarray | None, int, float]:
        """One OSQP solve of the current data: ``(status, x, y, iterations, run time)``."""
        s = self._s
        Ax = self.vals[self.order] if self._mat_dirty else None
        q = self.q if self._q_dirty else None
        if s is None:  # pragma: no cover - another osqp version
            kw = {"l": self.l, "u": self.u} | ({} if q is None else {"q": q})
            self.solver.update(**kw, **({} if Ax is None else {"Ax": Ax}))
            res = self.solver.solve(raise_error=False)
            info, x, y = res.info, res.x, res.y
        else:
            # a non-zero exit code means OSQP rejected the data and kept the previous problem:
            # solving would answer a different QP, so the step fails (the caller falls back)
            rc = s.update_data_vec(q, self.l, self.u)
            if rc:
                return self._rejected("update_data_vec", rc)
            if Ax is not None:
                rc = s.update_data_mat(None, None, Ax, None)
                if rc:
                    return self._rejected("update_data_mat", rc)
            rc = s.solve()
            if rc:
                _log.warning("SO3MPC: OSQP solve returned exit code %d", rc)
                return -_STATUS_EXCEPTION, None, None, 0, 0.0
            info = s.info
            if self._polish and info.status_val == 1 and info.status_polish != 1:
                info = self._retry(info)
            sol = s.solution
            x, y = sol.x, sol.y
        self._mat_dirty = self._q_dirty = False
        sv = int(info.status_val)
        return sv if sv in (1, 2) else -sv, x, y, int(info.iter), float(info.run_time)

    def solve(self) -> tuple[int, np.ndarray | None, int, float]:
        """OSQP, its answer checked by :meth:`certificate`; an answer that fails it (or a
        failed status) is re-solved by Clarabel on the same data when ``resolve`` is set.
        Returns ``(status, u (N, 3) or None, iterations, run time)`` of the answer used
        (iterations and time summed over both solvers); ``osqp_status``, ``resolved`` and
        ``torque_bound`` keep the details."""
        self.resolved = False
        self.torque_bound = np.nan
        status, x, y, iters, rtime = self._osqp()
        self.osqp_status = status
        if status == -_STATUS_REJECTED:
            return status, None, iters, rtime
        finite = x is not None and y is not None and bool(np.all(np.isfinite(x)))
        tol = self.torque_tol
        if tol is not None:
            accept = status == 1 or (status == 2 and self.accept_inaccurate)
            bound = self.certificate(x, y)[2] if accept and finite else np.inf
            if not bound <= tol:
                if accept:
                    status = -_STATUS_UNCERTIFIED
                if self.resolve:
                    st2, x2, y2, it2, rt2 = self._clarabel()
                    iters, rtime = iters + it2, rtime + rt2
                    b2 = self.certificate(x2, y2)[2] if st2 == 1 else np.inf
                    if b2 <= tol:
                        status, x, y, bound, finite = 1, x2, y2, b2, True
                        self.resolved = True
                        self.resolves += 1
            self.torque_bound = bound
        if not finite or status not in (1, 2):
            self._last = None
            return status, None, iters, rtime
        self._last = (x, y)
        nx, nu = self.nx, self.nu
        u = x[nx : nx + nu].reshape(self.N, 3)
        if self.ns:
            self.slack = np.maximum(x[nx + nu :].reshape(self.N, self.nc), 0.0)
            self.xi_plan = x[:nx].reshape(self.N, 6)[:, :3].copy()
        return status, u, iters, rtime

    def _matrix(self) -> sp.csc_matrix:
        """The current constraint matrix ``A`` (CSC, the structure OSQP was set up with)."""
        return sp.csc_matrix((self.vals[self.order], *self._A_struct[:2]), self._A_struct[2])

    def certificate(self, x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
        """KKT residuals of ``(x, y)`` on the unscaled QP ``min ½xᵀHx + qᵀx, l ≤ Ax ≤ u``:
        ``(primal residual ‖Ax − Π(Ax)‖∞, dual residual ‖Hx + q + Aᵀy‖∞, torque bound)``.

        The torque bound is ``sqrt(2 Δ / λ_min(R))`` with ``Δ = Σ y₊|u − Ax| + Σ y₋|Ax − l| +
        ½ rᵀH⁻¹r`` (``r`` the dual residual, multipliers on infinite bounds dropped, each
        ``|u − Ax|``, ``|Ax − l|`` less a round-off floor ``1e-9 (1 + |bound|)``): for
        ``x`` feasible, ``Δ`` is the duality gap ``f(x) − g(y)`` (Lagrangian dual ``g``), and
        strong convexity gives ``½ δuᵀRδu ≤ f(x) − f* ≤ Δ`` for the distance ``δu`` of every
        planned torque from the minimiser's (Boyd & Vandenberghe, *Convex Optimization*,
        Cambridge University Press, 2004, §5.5 and §9.1.2). The absolute values charge any
        primal infeasibility at the multipliers' prices, so a nearly feasible iterate whose
        multipliers are large (the exact-penalty cone rows) does not pass on a small residual.
        """
        A = self._matrix()
        Ax = A @ x
        l, u = self.l, self.u
        r_prim = float(np.max(np.abs(Ax - np.clip(Ax, l, u)), initial=0.0))
        fin_u, fin_l = u < _OSQP_INF, l > -_OSQP_INF
        yp = np.where(fin_u, np.maximum(y, 0.0), 0.0)
        ym = np.where(fin_l, np.maximum(-y, 0.0), 0.0)
        r = self._H @ x + self.q + A.T @ (yp - ym)
        # an active bound met to round-off times a multiplier of ~1e8 (the exact penalty) is
        # no error of the solver: deviations within the feasibility floor are not charged
        dev_u = np.where(fin_u, np.abs(u - Ax), 0.0)
        dev_l = np.where(fin_l, np.abs(Ax - l), 0.0)
        dev_u = np.maximum(dev_u - _KKT_FEAS_FLOOR * (1.0 + np.abs(np.where(fin_u, u, 0.0))), 0.0)
        dev_l = np.maximum(dev_l - _KKT_FEAS_FLOOR * (1.0 + np.abs(np.where(fin_l, l, 0.0))), 0.0)
        gap = float(yp @ dev_u + ym @ dev_l + 0.5 * r @ (self._Hinv @ r))
        bound = float(np.sqrt(2.0 * max(gap, 0.0) / self._lam_R))
        return r_prim, float(np.max(np.abs(r), initial=0.0)), bound

    def _clarabel(self) -> tuple[int, np.ndarray | None, np.ndarray | None, int, float]:
        """The same QP by Clarabel (interior point, an independent route to the minimiser):
        ``(status, x, y in OSQP's sign convention, iterations, solve time)``."""
        try:
            import clarabel
        except ImportError:  # pragma: no cover - clarabel comes with cvxpy
            _log.warning("SO3MPC: clarabel is not installed; no re-solve")
            return -_STATUS_EXCEPTION, None, None, 0, 0.0
        A = self._matrix()
        l, u = self.l, self.u
        eq = l == u
        up = (u < _OSQP_INF) & ~eq
        lo = (l > -_OSQP_INF) & ~eq
        # l ≤ Ax ≤ u as Clarabel's Ax + s = b: equalities in the zero cone, each finite
        # inequality bound as a row of the non-negative orthant
        Ac = sp.vstack([A[eq], A[up], -A[lo]], format="csc")
        b = np.concatenate([l[eq], u[up], -l[lo]])
        cones = [
            clarabel.ZeroConeT(int(eq.sum())),
            clarabel.NonnegativeConeT(int(up.sum() + lo.sum())),
        ]
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        for k, v in _CLARABEL_TOLERANCES.items():
            setattr(settings, k, v)
        try:
            sol = clarabel.DefaultSolver(self._H_upper, self.q, Ac, b, cones, settings).solve()
        except Exception as exc:  # a failed re-solve leaves the step to the fallback
            _log.warning("SO3MPC: Clarabel re-solve raised %r", exc)
            return -_STATUS_EXCEPTION, None, None, 0, 0.0
        status = _CLARABEL_STATUS.get(str(sol.status), -11)
        x, z, sl = np.array(sol.x), np.array(sol.z), np.array(sol.s)
        ne, nu = int(eq.sum()), int(up.sum())
        y = np.zeros(l.size)
        y[eq] = z[:ne]
        y[up] += z[ne : ne + nu]
        y[lo] -= z[ne + nu :]
        if status == 1:
            # an interior point stops ~1e-6 inside the active bounds (its complementarity gap),
            # which the certificate must charge at the multipliers' price; the exact KKT solve
            # on the active set it identifies (z > s) is the vertex it converges to
            act = eq.copy()
            act[np.flatnonzero(up)[z[ne : ne + nu] > sl[ne : ne + nu]]] = True
            on_lo = np.flatnonzero(lo)[z[ne + nu :] > sl[ne + nu :]]
            act[on_lo] = True
            b_act = np.where(np.isin(np.arange(l.size), on_lo), l, u)[act]
            polished = self._active_set_solve(A, act, b_act)
            if polished is not None and (
                self.certificate(*polished)[2] < self.certificate(x, y)[2]
            ):
                x, y = polished
        return status, x, y, int(sol.iterations), float(sol.solve_time)

    def _active_set_solve(
        self, A: sp.csc_matrix, act: np.ndarray, b_act: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """``(x, y)`` of ``min ½xᵀHx + qᵀx`` s.t. ``A_act x = b_act`` (``None`` if singular)."""
        import scipy.sparse.linalg as spla

        Aa = A[act]
        m = Aa.shape[0]
        K = sp.bmat([[self._H, Aa.T], [Aa, None]], format="csc")
        rhs = np.concatenate([-self.q, b_act])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a singular KKT (degenerate active set): no polish
            sol = spla.spsolve(K, rhs)
        if not np.all(np.isfinite(sol)):
            return None
        n = self._H.shape[0]
        y = np.zeros(act.size)
        y[act] = sol[n : n + m]
        return sol[:n], y

    def _rejected(self, call: str, rc: int) -> tuple[int, None, None, int, float]:
        """An update OSQP refused (exit code ``rc``): nothing is solved, the warm start is
        dropped and the data are re-sent in full next step."""
        _log.warning("SO3MPC: OSQP %s rejected the problem data (exit code %d)", call, rc)
        self._last = None
        self._mat_dirty = self._q_dirty = True
        return -_STATUS_REJECTED, None, None, 0, 0.0


_STATUS_EXCEPTION = 99
_STATUS_REJECTED = 12
_STATUS_UNCERTIFIED = 13

#: Relative feasibility floor of the KKT certificate: a bound met within ``1e-9 (1 + |b|)`` counts
#: as met (round-off of an exact solve; OSQP's loose iterates miss active bounds by ~1e-5).
_KKT_FEAS_FLOOR = 1e-9

#: Clarabel's status names (``str(SolverStatus)``) as :data:`STATUS_NAMES` codes.
_CLARABEL_STATUS = {
    "Solved": 1,
    "AlmostSolved": 2,
    "PrimalInfeasible": -3,
    "AlmostPrimalInfeasible": -4,
    "DualInfeasible": -5,
    "AlmostDualInfeasible": -6,
    "MaxIterations": -7,
    "MaxTime": -8,
}

# the re-solve must be the accurate one: the same tolerances as the cvxpy reference backend
_CLARABEL_TOLERANCES = {
    "tol_gap_abs": 1e-10,
    "tol_gap_rel": 1e-10,
    "tol_feas": 1e-10,
    "tol_ktratio": 1e-8,
}


class _SolveInfo:
    """The OSQP info fields the controller reads."""

    __slots__ = ("status_val", "iter", "run_time")

    def __init__(self, status_val: int, it: int, run_time: float) -> None:
        self.status_val, self.iter, self.run_time = status_val, it, run_time


def _shift_index(N: int, n: int) -> np.ndarray:
    """Indices that shift a stacked ``(N, n)`` vector by one stage, the last stage repeated."""
    k = np.minimum(np.arange(N) + 1, N - 1)
    return (n * k[:, None] + np.arange(n)).ravel()


class _CvxpyQP:
    """The same QP written readably with ``cp.Parameter``s (DPP, compiled on the first solve)."""

    def __init__(
        self,
        N: int,
        Q: np.ndarray,
        R: np.ndarray,
        P: np.ndarray,
        m: int,
        settings: dict,
        u_max: np.ndarray,
        nc: int = 0,
        slack_weights: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        import cvxpy as cp

        self.N, self.m, self.nc = N, m, nc
        x = cp.Variable((N, 6), name="x")  # x_1 … x_N
        u = cp.Variable((N, 3), name="u")  # u_0 … u_{N−1}
        self.A = [cp.Parameter((6, 6), name=f"A{k}") for k in range(1, N)]
        self.B = [cp.Parameter((6, 3), name=f"B{k}") for k in range(N)]
        self.c = cp.Parameter((N, 6), name="c")
        self.u_ref = cp.Parameter((N, 3), name="u_ref")
        self.u_max = cp.Parameter(3, nonneg=True, name="u_max")
        # sum_squares(L z) = zᵀ W z with W = L Lᵀ: DPP (quad_form of a parameter-affine argument
        # is not)
        Lq, Lp, Lr = (np.linalg.cholesky(W).T for W in (Q, P, R))
        cost = cp.sum_squares(Lp @ x[N - 1])
        cost += sum(cp.sum_squares(Lq @ x[k]) for k in range(N - 1))
        cost += sum(cp.sum_squares(Lr @ (u[k] - self.u_ref[k])) for k in range(N))
        cons = [x[0] == self.B[0] @ u[0] + self.c[0]]
        cons += [
            x[k] == self.A[k - 1] @ x[k - 1] + self.B[k] @ u[k] + self.c[k] for k in range(1, N)
        ]
        cons += [cp.abs(u[k]) <= self.u_max for k in range(N)]
        if m:
            self.C = cp.Parameter((m, 3), name="C")
            self.lo = cp.Parameter(m, name="lo")
            self.hi = cp.Parameter(m, name="hi")
            cons += [self.C @ u[k] >= self.lo for k in range(N)]
            cons += [self.C @ u[k] <= self.hi for k in range(N)]
        self.slack: np.ndarray | None = None
        self.xi_plan: np.ndarray | None = None
        self.s = None
        if nc:
            # linearised cones: G_k ξ_{k+1} − s_k ≤ h_k, s ≥ 0, penalty ρ₁ Σs + ρ₂ Σs²
            s = cp.Variable((N, nc), nonneg=True, name="s")
            self.G = [cp.Parameter((nc, 3), name=f"G{k}") for k in range(N)]
            self.h = cp.Parameter((N, nc), name="h")
            cons += [self.G[k] @ x[k, :3] - s[k] <= self.h[k] for k in range(N)]
            cost += slack_weights[0] * cp.sum(s) + slack_weights[1] * cp.sum_squares(s)
            self.s, self.x = s, x
        self.u = u
        self.problem = cp.Problem(cp.Minimize(cost), cons)
        if not self.problem.is_dpp():  # pragma: no cover - a bug in this file
            raise RuntimeError("SO3MPC: the cvxpy formulation is not DPP")
        self.settings = dict(settings)
        self.solver_name = self.settings.pop("solver", "CLARABEL")
        self.u_max.value = u_max

    def set_data(self, model: _Model, c0, B0, extra, cones=None) -> None:
        for k in range(1, self.N):
            self.A[k - 1].value = model.A[k]
        for k in range(self.N):
            self.B[k].value = model.B[k]
        if B0 is not None:
            self.B[0].value = B0
        c = model.ct.copy()
        c[0] = c0
        self.c.value = c
        self.u_ref.value = model.u_ref
        if extra is not None:
            self.C.value, self.lo.value, self.hi.value = extra
        if cones is not None:
            G, h = cones
            for k in range(self.N):
                self.G[k].value = G[k]
            self.h.value = h

    def warm_start_shifted(self) -> None:
        """Interior-point solver: no warm start."""

    def solve(self) -> tuple[int, np.ndarray | None, int, float]:
        self.problem.solve(solver=self.solver_name, **self.settings)
        status = _CVXPY_STATUS.get(self.problem.status, -11)
        stats = self.problem.solver_stats
        it = int(stats.num_iters) if stats is not None and stats.num_iters is not None else 0
        st = float(stats.solve_time) if stats is not None and stats.solve_time else 0.0
        u = None if self.u.value is None else np.array(self.u.value)
        if self.nc and u is not None and self.s.value is not None:
            self.slack = np.maximum(np.array(self.s.value), 0.0)
            self.xi_plan = np.array(self.x.value)[:, :3]
        return status, u, it, st


# ------------------------------------------------------------------------------------------------


def _real(x: object, name: str) -> np.ndarray:
    """A real float array (NaN/inf allowed: checked by the caller), complex rejected."""
    a = np.asarray(x)
    if a.dtype.kind == "c" or a.dtype.kind in "USVO":
        raise ValueError(f"{name}: lo/hi must be real numbers, got dtype {a.dtype}")
    return a.astype(np.float64)


def _check_int(v: object, name: str, minimum: int) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < minimum:
        raise ValueError(f"{name}: must be an integer >= {minimum}, got {v!r}")
    return int(v)


#: Default KKT tolerance of :class:`SO3MPC` relative to the smallest torque limit: an OSQP answer
#: is used only if its certified distance from the QP's minimiser (``_OsqpQP.certificate``) is
#: below ``KKT_TORQUE_RTOL · min(u_max)`` in every planned torque.
KKT_TORQUE_RTOL = 1e-3

#: Slack (cosine units) above which a step counts as having relaxed a cone constraint: the
#: OSQP primal tolerance (1e-3) — smaller slacks are solver round-off, not a relaxation.
SLACK_TOLERANCE = 1e-3


def _check_cones(cones: object, name: str, cls: type) -> tuple:
    if isinstance(cones, (cls, str, bytes)) or not isinstance(cones, (Sequence, np.ndarray)):
        raise ValueError(f"{name}: expected a sequence of {cls.__name__}, got {cones!r}")
    out = tuple(cones)
    for i, c in enumerate(out):
        if not isinstance(c, cls):
            raise ValueError(f"{name}: item {i} is not a {cls.__name__}: {c!r}")
    return out


def _cone_table(keep_out: tuple, keep_in: tuple, tau: float) -> tuple[np.ndarray, ...]:
    """``(b (nc, 3), s (nc, 3), σ (nc,), h (nc,))``: every cone as ``σ bᵀRᵀs ≤ h`` with the
    half-angle tightened by ``tau`` degrees (keep-out ``σ = +1``, ``h = cos(α + τ)``; keep-in
    ``σ = −1``, ``h = −cos(β − τ)``)."""
    cones = list(keep_out) + list(keep_in)
    if not cones:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0)
    b = np.array([c._b for c in cones])
    s = np.array([c._s for c in cones])
    sig = np.array([1.0] * len(keep_out) + [-1.0] * len(keep_in))
    ang = np.array(
        [min(c.half_angle_deg + tau, 179.999) for c in keep_out]
        + [max(c.half_angle_deg - tau, 1e-3) for c in keep_in]
    )
    return b, s, sig, sig * np.cos(np.radians(ang))


def _cone_rows(
    R_ref: np.ndarray,
    xi_bar: np.ndarray,
    b: np.ndarray,
    s: np.ndarray,
    sig: np.ndarray,
    h: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Cone constraints linearised in the predicted error ``ξ_k`` about ``ξ̄_k``.

    With ``R_k = R_ref,k exp(ξ_k^)`` and ``ξ_k = ξ̄_k + δ``, ``exp((ξ̄ + δ)^) ≈ exp(ξ̄^)
    exp((J_r(ξ̄) δ)^)``; with ``R̄ = R_ref exp(ξ̄^)`` and ``exp(η^)ᵀ ≈ I − η^``,

        c(R) = bᵀRᵀs ≈ c̄ + ηᵀ (b × R̄ᵀs),   η = J_r(ξ̄) δ,

    so ``σ c ≤ h`` becomes ``G ξ ≤ h − σ c̄ + G ξ̄`` with ``G = σ (J_r(ξ̄)ᵀ (b × R̄ᵀs))ᵀ``.
    Returns ``G (N, nc, 3)`` and the right-hand side ``(N, nc)``.
    """
    Rbar = R_ref @ so3.exp(xi_bar)
    Jr = so3.right_jacobian(xi_bar)
    st = np.einsum("kji,cj->kci", Rbar, s)  # R̄_kᵀ s_c
    cbar = np.einsum("ci,kci->kc", b, st)
    grad = np.cross(b[None], st)  # ∂c/∂η (body-frame gradient, as in constrained.py)
    G = sig[None, :, None] * np.einsum("kij,kci->kcj", Jr, grad)
    rhs = h[None] - sig[None] * cbar + np.einsum("kcj,kj->kc", G, xi_bar)
    return G, rhs


class SO3MPC(AttitudeController):
    """Linear MPC on the Lie-algebra error of the LGVI (module docstring).

    Args:
        J: ``(3, 3)`` inertia the controller assumes [kg·m²].
        horizon: number of stages ``N ≥ 1``.
        dt: MPC sample time ``T`` > 0 [s] (the controller should be sampled at this period).
        Q: error-state weight, SPD ``(6, 6)`` or positive ``(6,)`` (on ``(ξ [rad], e_Ω [rad/s])``).
        R: input weight, SPD ``(3, 3)`` or positive ``(3,)`` [1/(N·m)²].
        u_max: torque limit, positive scalar or ``(3,)`` [N·m]: ``|u_i| ≤ u_max_i``.
        P: terminal weight SPD ``(6, 6)``; default: the DARE solution of the rest model.
        backend: ``"osqp"`` (sparse QP updated in place, warm-started) or ``"cvxpy"``
            (``cp.Parameter`` formulation, Clarabel).
        extra_constraints: optional ``f(state) -> (C (m, 3), lo (m,), hi (m,))`` evaluated at
            the current single-spacecraft state (an :class:`AttitudeState` with ``B = 1``);
            imposes ``lo ≤ C u_k ≤ hi`` on every stage; ``m`` must not change between calls.
        reference_preview: optional ``t -> AttitudeReference`` giving the reference at the future
            knots ``t + kT`` (default: extrapolate from the current sample with constant
            ``Ω̇_d``).
        fallback: controller used when the QP fails (default: :class:`GeometricPD` with
            ``gains_from_bandwidth(J, 0.1/T, 1.0, matrix=True)``); its torque is clipped to the
            box. One deep copy per spacecraft.
        solver_settings: backend options (OSQP settings, or ``cvxpy`` ``solve`` keywords incl.
            ``solver=``), merged over the defaults.
        accept_inaccurate: also accept *solved inaccurate* (default: fall back).
        exact_stage0_jacobian: use the exact input Jacobian ``B_0`` of the nonlinear stage-0
            prediction instead of the reference linearisation's (the affine term is the
            nonlinear prediction either way). Changes the QP matrix every step, so OSQP
            refactorises its KKT system every step (slower); the difference is second order
            (``δu`` × state error).
        keep_out, keep_in: pointing cones (:class:`~liecontrol.control.constrained.KeepOutCone`,
            :class:`~liecontrol.control.constrained.KeepInCone`), linearised about the predicted
            trajectory and imposed on every stage with a slack (module docstring, *Pointing
            cones*). Default: none (the QP is then exactly the unconstrained one).
        slack_weight: exact-penalty weight of the cone slack, relative to ``λ_max(P)``
            (linear and quadratic); > 0.
        cone_tightening_deg: the cones' half-angles are tightened by this much in the QP
            (keep-out ``α + τ``, keep-in ``β − τ``), in [0, 90).
        kkt_tolerance: certified torque accuracy [N·m] an OSQP answer must meet (module
            docstring, *Certificate*); default ``KKT_TORQUE_RTOL · min(u_max)``; ``math.inf``
            takes OSQP's status as it stands. OSQP backend only.
        resolve: re-solve a step whose OSQP answer fails the certificate with Clarabel
            (default ``True``; ``False``: the fallback controller takes the step).
        safety_filter: with cones, pass the torque through the braking-margin filter at
            ``dt`` and ``u_max`` and warn (``UnrecoverableStartWarning``) at the first command
            from a start the box cannot stop before a cone (default ``True``).

    Batch handling: ``batched = True``; ``command`` loops over the ``B`` spacecraft internally
    (OSQP: one QP instance each, so every spacecraft keeps its own warm start; cvxpy: one
    compiled problem shared by the batch).

    ``diagnostics()``: ``status`` ``(B,)`` int (codes in :data:`STATUS_NAMES`); ``solve_time``
    ``(B,)`` [s] (solver-reported: OSQP run time incl. polishing, or cvxpy's solver time);
    ``iterations`` ``(B,)``; ``fallback_active`` ``(B,)`` bool; ``fallback_count`` ``(B,)``
    (cumulative since ``reset``); ``xi`` and ``e_Omega`` ``(B, 3)`` (error state at the sample);
    ``osqp_status``, ``resolved``, ``resolve_count``, ``kkt_torque_bound`` [N·m] (OSQP backend:
    the certificate); with cones ``cone_slack_max``, ``cone_slack_used`` and, with the filter,
    ``filter_active``, ``braking_margin`` [deg].
    """

    batched = True

    def __init__(
        self,
        J: object,
        horizon: int,
        dt: float,
        Q: object,
        R: object,
        u_max: object,
        P: object = None,
        backend: str = "osqp",
        extra_constraints: Callable[[AttitudeState], tuple] | None = None,
        reference_preview: Callable[[float], AttitudeReference] | None = None,
        fallback: AttitudeController | None = None,
        solver_settings: dict | None = None,
        accept_inaccurate: bool = False,
        exact_stage0_jacobian: bool = False,
        keep_out: Sequence[KeepOutCone] = (),
        keep_in: Sequence[KeepInCone] = (),
        slack_weight: float = 1.0,
        cone_tightening_deg: float = 1.0,
        kkt_tolerance: float | None = None,
        resolve: bool = True,
        safety_filter: bool = True,
    ) -> None:
        J = check_inertia_3x3(J, "J")
        self.J = J.copy()
        self.J.setflags(write=False)
        self.N = _check_int(horizon, "horizon", 1)
        if self.N > 100_000:  # the QP holds N states and inputs: beyond this it cannot be built
            raise ValueError(f"horizon: {self.N} steps is larger than any feasible MPC horizon")
        dt = check_positive(dt, "dt")
        if not isinstance(dt, float):
            raise ValueError("dt: must be a scalar")
        self.dt = dt
        self.Q = check_weight(Q, "Q", 6)
        self.R = check_weight(R, "R", 3)
        um = as_array(u_max, "u_max")
        if um.shape not in ((), (3,)):
            raise ValueError(f"u_max: expected a scalar or shape (3,), got {um.shape}")
        check_positive(um, "u_max")
        self.u_max = np.broadcast_to(um, (3,)).copy()
        A0, B0 = rest_model(self.J, dt)
        if P is None:
            try:
                # a failing solve warns on its way (overflow, QZ): the error below says it all;
                # the warnings of a solve that succeeds are passed on
                with warnings.catch_warnings(record=True) as caught, np.errstate(all="ignore"):
                    warnings.simplefilter("always")
                    P = scipy.linalg.solve_discrete_are(A0, B0, self.Q, self.R)
                for w in caught:
                    warnings.warn(w.message, w.category, stacklevel=2)
            except (np.linalg.LinAlgError, ValueError) as exc:
                # the torque has no numerical effect on the model: name the likeliest cause
                culprit = ("J" if float(np.max(self.J)) > 1e100
                           else "R" if float(np.max(self.R)) > 1e100 else "dt")  # fmt: skip
                raise ValueError(
                    f"{culprit}: the terminal weight P (discrete Riccati equation of the "
                    f"linearised model with dt = {dt:g}) has no finite solution ({exc}); the "
                    "control is numerically ineffective (dt too small, J or R too large) — "
                    "change them or pass P"
                ) from None
            P = 0.5 * (P + P.T)
        self.P = check_weight(P, "P", 6)
        if backend not in ("osqp", "cvxpy"):
            raise ValueError(f"backend: expected 'osqp' or 'cvxpy', got {backend!r}")
        self.backend = backend
        if extra_constraints is not None and not callable(extra_constraints):
            raise ValueError("extra_constraints: must be callable as f(state) -> (C, lo, hi)")
        self.extra_constraints = extra_constraints
        if reference_preview is not None and not callable(reference_preview):
            raise ValueError("reference_preview: must be callable as f(t) -> AttitudeReference")
        self.reference_preview = reference_preview
        if fallback is None:
            k_R, k_W = gains_from_bandwidth(self.J, 0.1 / dt, 1.0, matrix=True)
            fallback = GeometricPD(self.J, k_R, k_W)
        for name in ("reset", "command"):
            if not callable(getattr(fallback, name, None)):
                raise ValueError(f"fallback: has no method {name}() (an AttitudeController)")
        self.fallback = fallback
        if solver_settings is not None and not isinstance(solver_settings, dict):
            raise ValueError("solver_settings: must be a dict or None")
        base = dict(_OSQP_DEFAULTS if backend == "osqp" else _CVXPY_DEFAULTS)
        if backend == "cvxpy" and solver_settings and "solver" in solver_settings:
            base = {}  # the Clarabel tolerances below are not other solvers' keywords
        if backend == "osqp" and (keep_out or keep_in):
            base["max_iter"] = _OSQP_CONE_MAX_ITER  # a stalled solve goes to the re-solve
        self.solver_settings = {**base, **(solver_settings or {})}
        self.accept_inaccurate = bool(accept_inaccurate)
        self.exact_stage0_jacobian = bool(exact_stage0_jacobian)
        self.keep_out = _check_cones(keep_out, "keep_out", KeepOutCone)
        self.keep_in = _check_cones(keep_in, "keep_in", KeepInCone)
        self.slack_weight = check_positive_scalar(slack_weight, "slack_weight")
        tau = as_scalar(cone_tightening_deg, "cone_tightening_deg")
        if not 0.0 <= tau < 90.0:
            raise ValueError(f"cone_tightening_deg: must be in [0, 90) degrees, got {tau}")
        self.cone_tightening_deg = tau
        if kkt_tolerance is None:
            self.kkt_tolerance = KKT_TORQUE_RTOL * float(self.u_max.min())
        elif isinstance(kkt_tolerance, (int, float, np.floating)) and kkt_tolerance == np.inf:
            self.kkt_tolerance = np.inf  # the check switched off: OSQP's status is taken as is
        else:
            self.kkt_tolerance = check_positive_scalar(kkt_tolerance, "kkt_tolerance")
        if not isinstance(resolve, (bool, np.bool_)):
            raise ValueError(f"resolve: must be True or False, got {resolve!r}")
        self.resolve = bool(resolve)
        if not isinstance(safety_filter, (bool, np.bool_)):
            raise ValueError(f"safety_filter: must be True or False, got {safety_filter!r}")
        self.safety_filter = bool(safety_filter) and bool(self.keep_out or self.keep_in)
        self._lam_max = float(np.linalg.eigvalsh(self.J)[-1])
        self._filter_first = True
        self._cones = _cone_table(self.keep_out, self.keep_in, tau)
        # exact-penalty weights in the cost's own scale: λ_max(P) is the cost of a unit
        # terminal error, so the slack (in cosine units) costs slack_weight times that
        lam = float(np.linalg.eigvalsh(self.P)[-1])
        self._slack_weights = (self.slack_weight * lam, self.slack_weight * lam)
        # rest-model stages are constant: built once (regulation never recomputes them)
        self._rest = self._build_model(
            np.zeros((self.N + 1, 3)), np.broadcast_to(np.eye(3), (self.N, 3, 3))
        )
        self._checked_R_d: np.ndarray | None = None
        self._Jinv = np.linalg.inv(self.J)
        self._Jinv.setflags(write=False)
        self._model_cache: _Model | None = None
        self._model_key: bytes | None = None
        self._qps: list[Any] = []
        self._fallbacks: list[Any] = []
        self._batch: int | None = None
        self._diag: dict[str, np.ndarray] = {}
        self._fallback_count: np.ndarray = np.zeros(0, dtype=np.int64)
        self._resolve_count: np.ndarray = np.zeros(0, dtype=np.int64)
        self._resolve_on: list[bool] = []
        self._t_last: list[float] = []
        self._t0 = 0.0
        self._plans: list[np.ndarray | None] = []
        self._slack_on: list[bool] = []
        self._slack_max = np.zeros(0)

    def __repr__(self) -> str:
        return (
            f"SO3MPC(backend={self.backend!r}, horizon={self.N}, dt={self.dt}, "
            f"u_max={self.u_max.tolist()})"
        )

    def __deepcopy__(self, memo: dict) -> SO3MPC:
        # solver objects (C extensions) are not copyable: a copy starts un-reset
        new = copy.copy(self)
        new._qps = []
        new._fallbacks = []
        new._batch = None
        new._diag = {}
        new._fallback_count = np.zeros(0, dtype=np.int64)
        new._resolve_count = np.zeros(0, dtype=np.int64)
        new._resolve_on = []
        new._t_last = []
        new._plans = []
        new._slack_on = []
        new._slack_max = np.zeros(0)
        new.fallback = copy.deepcopy(self.fallback, memo)
        return new

    # -- interface --------------------------------------------------------------------------

    def reset(self, t0: float, batch_size: int) -> None:
        """Clear warm starts, counters and diagnostics; QPs are (re)built on the first command."""
        batch_size = _check_int(batch_size, "batch_size", 1)
        self._t0 = as_scalar(t0, "t0")
        self._batch = batch_size
        self._qps = [None] * batch_size
        self._fallbacks = []
        for _ in range(batch_size):
            fb = copy.deepcopy(self.fallback)
            fb.reset(self._t0, 1)
            self._fallbacks.append(fb)
        self._fallback_count = np.zeros(batch_size, dtype=np.int64)
        self._resolve_count = np.zeros(batch_size, dtype=np.int64)
        self._resolve_on = [False] * batch_size
        self._diag = {}
        self._t_last = [-np.inf] * batch_size
        self._plans = [None] * batch_size
        self._slack_on = [False] * batch_size
        self._slack_max = np.zeros(batch_size)
        self._filter_first = True

    def _new_qp(self, m: int) -> Any:
        cls = _OsqpQP if self.backend == "osqp" else _CvxpyQP
        nc = len(self._cones[0])
        kw = {"nc": nc, "slack_weights": self._slack_weights} if nc else {}
        if self.backend == "osqp":
            tol = None if self.kkt_tolerance == np.inf else self.kkt_tolerance
            kw |= {
                "torque_tol": tol,
                "resolve": self.resolve,
                "accept_inaccurate": self.accept_inaccurate,
            }
        return cls(self.N, self.Q, self.R, self.P, m, self.solver_settings, self.u_max, **kw)

    def _cone_data(
        self, b: int, R_d: np.ndarray, model: _Model, xi1: np.ndarray, shift: bool
    ) -> tuple[np.ndarray, np.ndarray]:
        """The cone rows of spacecraft ``b``'s QP: ``G (N, nc, 3)``, ``h (N, nc)`` (class
        docstring), linearised about the last plan shifted by one stage (or, without one, about
        the stage-0 prediction ``xi1`` held over the horizon)."""
        N = self.N
        plan = self._plans[b]
        if plan is not None and shift:
            xi_bar = plan[np.minimum(np.arange(N) + 1, N - 1)]
        else:
            xi_bar = np.broadcast_to(xi1, (N, 3))
        # reference knots R_d,k+1 = R_d F_0 … F_k (the rest model's F are identities)
        Rk = np.empty((N, 3, 3))
        acc = R_d
        for k in range(N):
            acc = acc @ model.F[k]
            Rk[k] = acc
        return _cone_rows(Rk, xi_bar, *self._cones)

    def _build_model(self, ws: np.ndarray, F: np.ndarray) -> _Model:
        A, Bm, u_ref, c = _reference_model(self.J, self.dt, ws, F)  # valid by construction
        return _Model(A, Bm, u_ref, c, ws, F, self.R, self.u_max)

    def _model(
        self, t: float, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray, b: int
    ) -> _Model:
        """The linearisation along the reference over the horizon (knot rates ``(N + 1, 3)``,
        steps ``F_k (N, 3, 3)``), cached: regulation and constant-rate references reuse one
        model object, so the QP matrix is not touched (no KKT refactorisation)."""
        N, T = self.N, self.dt
        cached = self._model_cache
        if self.reference_preview is not None:
            Rs = [R_d]
            ws_l = [w_d]
            for k in range(1, N + 1):
                ref = self.reference_preview(t + k * T)
                Rk = check_rotation_matrix(ref.R_d, "reference_preview")
                wk = as_array(ref.omega_d, "reference_preview", (3,))
                Rs.append(Rk[b] if Rk.ndim == 3 else Rk)
                ws_l.append(wk[b] if wk.ndim == 2 else wk)
            Rs_a = np.stack(Rs)
            F = np.swapaxes(Rs_a[:-1], -1, -2) @ Rs_a[1:]
            ws = np.stack(ws_l)
            if cached is not None and np.array_equal(ws, cached.ws) and np.array_equal(F, cached.F):
                return cached
            model = self._build_model(ws, F)
            self._model_cache = model
            return model
        # extrapolation with constant Ω̇_d: the model is a function of (Ω_d, Ω̇_d) only
        key = w_d.tobytes() + dw_d.tobytes()
        if cached is not None and key == self._model_key:
            return cached
        if not (w_d.any() or dw_d.any()):
            model = self._rest
        else:
            ws = w_d + T * np.arange(N + 1)[:, None] * dw_d
            model = self._build_model(ws, so3.exp(0.5 * T * (ws[:-1] + ws[1:])))
        self._model_cache, self._model_key = model, key
        return model

    def _extra(self, state_b: AttitudeState, m_expected: int | None):
        out = self.extra_constraints(state_b)
        try:
            C, lo, hi = out
        except (TypeError, ValueError):
            raise ValueError("extra_constraints: must return (C, lo, hi)") from None
        C = as_array(C, "extra_constraints", (3,))
        if C.ndim != 2:
            raise ValueError(f"extra_constraints: C must have shape (m, 3), got {C.shape}")
        m = C.shape[0]
        try:
            lo = np.broadcast_to(_real(lo, "extra_constraints"), (m,))
            hi = np.broadcast_to(_real(hi, "extra_constraints"), (m,))
        except ValueError as exc:
            if str(exc).startswith("extra_constraints"):
                raise
            raise ValueError(
                f"extra_constraints: lo and hi must be scalars or shape ({m},)"
            ) from None
        if np.isnan(lo).any() or np.isnan(hi).any():
            raise ValueError("extra_constraints: lo/hi contain NaN")
        # an empty interval makes the QP infeasible by construction; OSQP would reject the data
        # (and, unchecked, keep solving the previous problem): a user error, reported as such
        bad = (lo > hi) | (lo == np.inf) | (hi == -np.inf)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"extra_constraints: lower bound exceeds upper bound in row {i} "
                f"({lo[i]!r} > {hi[i]!r}); every row needs lo <= hi"
            )
        if m_expected is not None and m != m_expected:
            raise ValueError(f"extra_constraints: number of rows changed from {m_expected} to {m}")
        return C, lo, hi

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Full body torque ``(B, 3)`` [N·m]; ``|u_i| ≤ u_max_i`` always (fallback included)."""
        if self._batch is None:
            raise RuntimeError("SO3MPC.command: call reset(t0, batch_size) first")
        R = state.R
        if not rotations_pass_fast(R):
            R = check_rotation_matrix(R, "R")
        w = as_array(state.omega, "omega", (3,))
        B = check_state_batch(R, w, self._batch)
        R_d = reference.R_d
        # a read-only array owning its data (ConstantAttitude's R_d) cannot change: checked once
        if not (isinstance(R_d, np.ndarray) and R_d is self._checked_R_d):
            if not rotations_pass_fast(R_d):
                R_d = check_rotation_matrix(R_d, "R_d")
            if not R_d.flags.writeable and R_d.base is None:
                self._checked_R_d = R_d
        w_d = as_array(reference.omega_d, "omega_d", (3,))
        dw_d = as_array(reference.omega_dot_d, "omega_dot_d", (3,))
        for name, a, nd in (("R_d", R_d, 2), ("omega_d", w_d, 1), ("omega_dot_d", dw_d, 1)):
            if a.ndim > nd + 1 or (a.ndim == nd + 1 and a.shape[0] != B):
                raise ValueError(f"{name}: expected one sample or a batch of {B}, got {a.shape}")
        t = as_scalar(t, "t")
        out = np.empty((B, 3))
        status = np.zeros(B, dtype=np.int64)
        iters = np.zeros(B, dtype=np.int64)
        stime = np.zeros(B)
        fb_on = np.zeros(B, dtype=bool)
        first = np.zeros(B, dtype=np.int64)
        resolved = np.zeros(B, dtype=bool)
        bound = np.full(B, np.nan)
        x0s = _error_fast(R, w, R_d, w_d)
        for b in range(B):
            Rd_b = R_d[b] if R_d.ndim == 3 else R_d
            wd_b = w_d[b] if w_d.ndim == 2 else w_d
            dwd_b = dw_d[b] if dw_d.ndim == 2 else dw_d
            u_b, status[b], iters[b], stime[b] = self._solve_one(
                t, b, R[b], w[b], Rd_b, wd_b, dwd_b, state
            )
            first[b], resolved[b], bound[b] = self._check_report(t, b, status[b])
            if u_b is None:
                fb_on[b] = True
                self._fallback_count[b] += 1
                ref_b = AttitudeReference.unchecked(Rd_b, wd_b, dwd_b)  # checked above
                st_b = _one_state(state, b)
                u_fb = np.asarray(self._fallbacks[b].command(t, st_b, ref_b), dtype=np.float64)
                u_b = np.clip(u_fb.reshape(3), -self.u_max, self.u_max)
                _log.warning(
                    "SO3MPC: QP %s (status %d) at t=%.6g for spacecraft %d; fallback %s used",
                    STATUS_NAMES.get(int(status[b]), "?"),
                    status[b],
                    t,
                    b,
                    type(self.fallback).__name__,
                )
            out[b] = u_b
        self._diag = {
            "status": status,
            "solve_time": stime,
            "iterations": iters,
            "fallback_active": fb_on,
            "fallback_count": self._fallback_count.copy(),
            "osqp_status": first,
            "resolved": resolved,
            "resolve_count": self._resolve_count.copy(),
            "kkt_torque_bound": bound,
            "xi": x0s[:, :3],
            "e_Omega": x0s[:, 3:],
        }
        if self._cones[0].size:
            smax = np.where(fb_on, 0.0, self._slack_max)
            self._diag["cone_slack_max"] = smax
            self._diag["cone_slack_used"] = smax > SLACK_TOLERANCE
        if self.safety_filter:
            # the QP's cones hold only as linearised rows at the samples over a short horizon;
            # the braking filter bounds what the held torque can do before the next sample
            cones = self.keep_out + self.keep_in
            out, active, h, m, v, a_b = braking_filter(
                out, R, w, self.J, cones, self.u_max, self.dt, lam_max=self._lam_max
            )
            if self._filter_first:
                self._filter_first = False
                check_recoverable(h, m, v, a_b, cones, self.u_max, self.dt, 0.7, 0.5, False)
            self._diag["filter_active"] = active
            self._diag["braking_margin"] = np.degrees(h.min(axis=-1))
        return out

    def _solve_one(self, t, b, R, w, R_d, w_d, dw_d, state):
        """Linearise, update and solve one spacecraft's QP: ``(u or None, status, iters, time)``."""
        model = self._model(t, R_d, w_d, dw_d, b)
        u_bar = model.u_bar
        x1, B0 = _stage0(
            self.J,
            self._Jinv,
            self.dt,
            R,
            w,
            R_d @ model.F[0],
            model.ws[1],
            u_bar,
            self.exact_stage0_jacobian,
        )
        c0 = x1 - (model.B[0] if B0 is None else B0) @ u_bar
        extra = None
        qp = self._qps[b]
        if self.extra_constraints is not None:
            extra = self._extra(_one_state(state, b), None if qp is None else qp.m)
        if qp is None:
            m = 0 if extra is None else extra[0].shape[0]
            if self.backend == "cvxpy" and b > 0 and self._qps[0] is not None:
                # no warm start to keep: the batch shares one compiled problem
                qp = self._qps[0]
                if qp.m != m:
                    raise ValueError(
                        f"extra_constraints: number of rows changed from {qp.m} to {m}"
                    )
            else:
                qp = self._new_qp(m)
            self._qps[b] = qp
        t_last = self._t_last[b]
        self._t_last[b] = t
        consecutive = abs(t - t_last - self.dt) <= 1e-9 * self.dt
        cones = None
        if self._cones[0].size:
            cones = self._cone_data(b, R_d, model, x1[:3], consecutive)
            self._plans[b] = None  # set again below from an accepted solution
        try:
            qp.set_data(model, c0, B0, extra, cones)
            # receding horizon: one period later, the last plan shifted by a stage is the best
            # guess of the new one (primal and dual)
            if consecutive:
                qp.warm_start_shifted()
            status, u, iters, stime = qp.solve()
        except Exception as exc:  # solver errors must not stop the loop: fall back, log it
            _log.warning("SO3MPC: solver raised %r", exc)
            return None, -99, 0, 0.0
        ok = status == 1 or (status == 2 and self.accept_inaccurate)
        if not ok or u is None or not np.all(np.isfinite(u[0])):
            return None, status if status != 1 else -11, iters, stime
        if cones is not None:
            self._record_slack(t, b, qp)
        # the solver's tolerance may overshoot the box by ~eps: the limit is a hard one
        return np.clip(u[0], -self.u_max, self.u_max), status, iters, stime

    def _check_report(self, t: float, b: int, status: int) -> tuple[int, bool, float]:
        """OSQP's own status, whether Clarabel's re-solve was used and the accepted answer's
        certified torque bound for spacecraft ``b``. The onset of a run of re-solved steps is
        a warning when OSQP stopped short of "solved" (an INFO line when it reported "solved" but
        its answer missed the certificate, routine on the cone QP, where a warning per onset
        would flood every suite run), its end an INFO line (one line per run, not per step: the
        certificate can fail for hundreds of steps in a row); each step is in
        ``diagnostics()`` and counted in ``resolve_count``. An answer neither solver certifies
        is the fallback's, which warns on every step."""
        qp = self._qps[b]
        if self.backend != "osqp" or qp is None:
            return status, False, np.nan
        first, resolved = int(qp.osqp_status), bool(qp.resolved)
        if resolved:
            self._resolve_count[b] += 1
            if not self._resolve_on[b]:
                # OSQP stopped short (iteration or time limit, inaccurate): a warning; OSQP said
                # "solved" but its answer missed the certificate (routine on the cone QP): an INFO
                # line — the torque used is certified either way and counted in diagnostics()
                _log.log(
                    logging.WARNING if first != 1 else logging.INFO,
                    "SO3MPC: OSQP %s (status %d) at t=%.6g for spacecraft %d; re-solved by "
                    "Clarabel (certified within %.2g N·m), and so on while OSQP's answers fail",
                    STATUS_NAMES.get(first, "?") if first != 1 else "answer failed the KKT check",
                    first,
                    t,
                    b,
                    qp.torque_bound,
                )
        elif self._resolve_on[b]:
            _log.info(
                "SO3MPC: OSQP's answers certified again at t=%.6g for spacecraft %d (%d steps "
                "re-solved so far)",
                t,
                b,
                self._resolve_count[b],
            )
        self._resolve_on[b] = resolved
        return first, resolved, float(qp.torque_bound)

    def _record_slack(self, t: float, b: int, qp: Any) -> None:
        """Keep the plan for the next linearisation; report the slack (log on its onset)."""
        self._plans[b] = None if qp.xi_plan is None else qp.xi_plan.copy()
        smax = 0.0 if qp.slack is None else float(qp.slack.max())
        self._slack_max[b] = smax
        used = smax > SLACK_TOLERANCE
        if used and not self._slack_on[b]:
            _log.warning(
                "SO3MPC: cone constraints relaxed at t=%.6g for spacecraft %d (max slack %.3g "
                "in cosine units): the linearised cones are infeasible over the horizon",
                t,
                b,
                smax,
            )
        elif self._slack_on[b] and not used:
            _log.info("SO3MPC: cone slack back to zero at t=%.6g for spacecraft %d", t, b)
        self._slack_on[b] = used

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last step's solver status, timing, iterations, fallback flags, error state (and,
        with cones, ``cone_slack_max``/``cone_slack_used``)."""
        return dict(self._diag)


def _one_state(state: AttitudeState, b: int) -> AttitudeState:
    """Spacecraft ``b`` of a batched state, as a batch of one (all fields, incl. the actuator's)."""
    sl = slice(b, b + 1)
    h, act = state.h, state.actuator_state
    return AttitudeState.unchecked(  # slices of a validated state
        np.asarray(state.R)[sl],
        np.asarray(state.omega)[sl],
        None if h is None else np.asarray(h)[sl],
        None if act is None else np.asarray(act)[sl],
    )
