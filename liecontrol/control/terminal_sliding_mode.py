"""Terminal sliding mode on Euler angles with feedback linearisation (Liu, Tang & Yu 2008).

Source: Liu Luhua, Tang Guojian, Yu Menglun, "Space RVD terminal approach to attitude tracking
by terminal sliding mode control", J. National Univ. of Defense Technology 30(2), 2008,
eqs. (1)–(19); the feedback linearisation follows Isidori's relative-degree construction.

**Feedback linearisation** (the paper's §2, eqs. (9)–(12)). Output y = a = (a1, a2, a3), the Euler
angles of the body (R body → inertial, any of scipy's 12 sequences; the paper uses the 3-2-1
sequence ``"ZYX"``). With ω = M(a) ȧ (:func:`liecontrol.charts.euler.rates_matrix_inv`) and
B(a) = M(a)⁻¹ (ȧ = B ω), differentiating ω = M ȧ once more gives

    ä = B(a) (ω̇ − Ṁ(a, ȧ) ȧ),      ω̇ = J⁻¹(−ω × Jω + L),

so with the control input u = J⁻¹L (angular-acceleration input; for principal J this is the
paper's u = (L_x/J_x, L_y/J_y, L_z/J_z)) the output has relative degree (2, 2, 2) and

    ÿ = b(x) + A(x) u,   A = B(a) = ∂ẏ/∂ω,   b = L_f²h = B(a) (J⁻¹(−ω × Jω) − Ṁ(a, ȧ) ȧ).

This holds for a **general full (symmetric positive-definite) inertia J**, not only principal.
For an intrinsic sequence of axes (i, j, k), M = [R_kᵀ(a3) R_jᵀ(a2) e_i, R_kᵀ(a3) e_j, e_k] and
Ṁ ȧ = ȧ1 (−ȧ3 e_k × m1 − ȧ2 R_kᵀ(e_j × R_jᵀ e_i)) + ȧ2 (−ȧ3 e_k × m2) (m1, m2 the first two
columns); an extrinsic sequence is the reversed intrinsic one with reversed angles. For ``"ZYX"``
and principal J this reproduces the paper's closed form eq. (12) (tested).

**Time-shaping polynomial** (the paper's eqs. (16), (18)–(19)). With τ = t/T,

    p(t) = e₀(1 − 10τ³ + 15τ⁴ − 6τ⁵) + ė₀T(τ − 6τ³ + 8τ⁴ − 3τ⁵)
           + ë₀T²(τ²/2 − 1.5τ³ + 1.5τ⁴ − 0.5τ⁵)   for 0 ≤ t ≤ T,   p(t) = 0 for t > T,

the coefficients being the paper's R = M⁻¹S (eq. (19)): p, ṗ, p̈ equal e, ė, ë at t = 0 and vanish
at t = T.

**Sliding surface and control** (the paper's eqs. (14)–(17), smoothed as in its §3.2). e = y − y_d
(first and third angles wrapped to (−π, π]),

    σ = C₁(e − p) + C₂(ė − ṗ)                    (σ(0) = 0 by construction of p),
    u = −A⁻¹{ b − ÿ_d − p̈ + C₂⁻¹C₁(ė − ṗ) + S_δ (F + D + K) },
    S_δ = C₂ᵀσ / (‖C₂ᵀσ‖ + δ),   δ = δ₀ + δ₁‖e‖,

and the body torque is L = J u. With ÿ = b + Δb + Au + d, ‖Δb‖ ≤ F, ‖d‖ ≤ D and the unsmoothed
unit vector, V = ½σᵀσ gives V̇ ≤ −K‖C₂ᵀσ‖ < 0 (the paper's §3.2), so the state stays on σ = 0
from t = 0 and e(t) follows the homogeneous solution that ends at 0 at t = T; with the smoothing the
error stays in a boundary layer of width ≈ δ·(F + D)/(F + D + K).

*Reconstructed / our choices* (the paper leaves them open):

- ë₀ is the **drift** error acceleration ë₀ = b(x₀) − ÿ_d(t₀) (what the error acceleration is
  with u = 0), which makes the commanded torque start at exactly 0 (no initial jump);
- the paper's "‖C_n^Tσ‖₊" is read as ‖C₂ᵀσ‖ + δ;
- F, D, K are constants (the paper gives no values).

Gimbal lock: B(a) and b contain 1/cos a2 (Tait–Bryan) or 1/sin a2 (proper Euler); the law raises
:class:`~liecontrol.exceptions.ChartSingularityError` when |cos a2| (|sin a2|) < ``lock_tol``,
never NaN. Near lock (not at it) b grows like 1/cos²a2 and so does the torque: the SO(3) adapter
refuses earlier with its own, wider guard.

Units: J [kg·m²], angles [rad], T [s], C₁ [1/s relative to C₂], δ₀ [rad/s], δ₁ [1/s],
F, D, K [rad/s²], torque [N·m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._array_api import cross, is_numpy, namespace, safe_sqrt
from .._kernels.terminal_sliding_mode import N_DIAG as TSM_DIAG
from .._kernels.terminal_sliding_mode import N_STATE as TSM_STATE
from .._kernels.terminal_sliding_mode import tsm_zyx_law
from .._linalg import matvec as _mv
from .._validation import (
    as_array,
    as_scalar,
    check_inertia_3x3,
    check_nonnegative,
    check_output_finite,
    check_positive,
    check_rotation_matrix,
    check_tolerance,
)
from ..charts.euler import LOCK_TOL, _elem, _parse, from_matrix, rates_matrix
from .adapters import ChartArrayLaw, EulerChartAdapter
from .base import finite_command
from .kernel import ControllerKernel

__all__ = [
    "TSMParams",
    "TerminalSlidingMode",
    "TerminalSlidingModeSO3",
    "euler_angle_acceleration",
    "euler_feedback_linearisation",
    "euler_reference",
    "time_shaping_polynomial",
    "sliding_surface",
    "tsm_control",
    "wrap_error",
    "SHAPING_COEFFICIENTS",
]

#: The paper's r_jl (eq. (19), R = M⁻¹S with M = [[1,1,1],[3,4,5],[6,12,20]],
#: S = [[−1,−1,−0.5],[0,−1,−1],[0,0,−1]]): the coefficient of e^{(l)}(0) T^l τ^{j+3} in p(t).
SHAPING_COEFFICIENTS: np.ndarray = np.array(
    [[-10.0, -6.0, -1.5], [15.0, 8.0, 1.5], [-6.0, -3.0, -0.5]]
)
SHAPING_COEFFICIENTS.setflags(write=False)


# -- feedback linearisation ---------------------------------------------------------------------


def _unit(k: int) -> np.ndarray:
    e = np.zeros(3)
    e[k] = 1.0
    return e


def _accel_core(a: Any, w: Any, wd: Any, seq: str, lock_tol: float) -> tuple[Any, Any, Any]:
    """(B, ȧ, ä) without input validation (hot path): ȧ = Bω, ä = B(ω̇ − Ṁȧ).

    One pass for M, B and Ṁȧ (module docstring). An extrinsic "ijk" is the intrinsic "KJI" with
    reversed angles: computed on the reversed angles, then B's rows and ȧ, ä are reversed back.
    Pure (NumPy or JAX). NumPy arrays at gimbal lock raise the chart's
    :class:`~liecontrol.exceptions.ChartSingularityError`; JAX arrays cannot raise (the Euler
    adapter's array law flags the lock, ``chart_lock``, and gives no torque), so there the
    determinant is only kept off 0.
    """
    xp = namespace(a, w, wd)
    (i, j, k), ext = _parse(seq)
    ar = a[..., ::-1] if ext else a
    ek, ej = _unit(k), _unit(j)
    Rk3T = _elem(k, -ar[..., 2])  # R_k(a3)ᵀ
    Rj2T_ei = _elem(j, -ar[..., 1])[..., :, i]  # R_j(a2)ᵀ e_i
    m1 = _mv(Rk3T, Rj2T_ei)
    m2 = Rk3T[..., :, j]
    m3 = xp.broadcast_to(ek, m1.shape)
    r1, r2, r3 = cross(m2, m3), cross(m3, m1), cross(m1, m2)
    det = xp.sum(m1 * r1, axis=-1)  # = ±cos a2 (Tait–Bryan) or ±sin a2 (proper Euler)
    if is_numpy(xp):
        if np.any(np.abs(det) < lock_tol):
            rates_matrix(a, seq, lock_tol)  # raises the chart's own ChartSingularityError
    else:
        det = xp.where(det == 0.0, 1.0, det)
    B = xp.stack((r1, r2, r3), axis=-2) / det[..., None, None]
    adot = _mv(B, w)
    # Ṁȧ: d/da R_k(a)ᵀ = −ê_k R_k(a)ᵀ gives the two terms of ṁ1 and the one of ṁ2 (m3 fixed)
    d1, d2, d3 = adot[..., 0:1], adot[..., 1:2], adot[..., 2:3]
    dm1 = -d3 * cross(ek, m1) - d2 * _mv(Rk3T, cross(ej, Rj2T_ei))
    dm2 = -d3 * cross(ek, m2)
    addot = _mv(B, wd - (d1 * dm1 + d2 * dm2))
    if ext:
        return B[..., ::-1, :], adot[..., ::-1], addot[..., ::-1]
    return B, adot, addot


def euler_angle_acceleration(
    angles: object,
    omega: object,
    omega_dot: object,
    seq: str = "ZYX",
    lock_tol: float = LOCK_TOL,
) -> tuple[np.ndarray, np.ndarray]:
    """Euler-angle rates and accelerations from body rate and body angular acceleration.

    ȧ = B(a) ω,  ä = B(a) (ω̇ − Ṁ(a, ȧ) ȧ)   (differentiate ω = M(a) ȧ; module docstring).

    Args:
        angles: ``(..., 3)`` Euler angles [rad] of ``seq``.
        omega: ``(..., 3)`` body angular velocity [rad/s].
        omega_dot: ``(..., 3)`` its time derivative [rad/s²].
        seq: scipy Euler sequence (default ``"ZYX"``, aerospace 3-2-1).
        lock_tol: gimbal-lock threshold on |cos a2| (|sin a2|).

    Returns:
        ``(adot, addot)``, each ``(..., 3)`` (batch shapes broadcast).

    Raises:
        ChartSingularityError: at gimbal lock.
    """
    a = as_array(angles, "angles", (3,))
    w = as_array(omega, "omega", (3,))
    wd = as_array(omega_dot, "omega_dot", (3,))
    _parse(seq)
    lock_tol = check_tolerance(lock_tol, "lock_tol", upper=1.0)
    with np.errstate(over="ignore", invalid="ignore"):
        _, adot, addot = _accel_core(a, w, wd, seq, lock_tol)
    check_output_finite(adot, "omega", "the Euler-angle rate B(a) ω")
    check_output_finite(addot, "omega_dot", "the Euler-angle acceleration")
    return np.broadcast_arrays(adot, addot)


def _drift(
    w: Any,
    J: np.ndarray,
    J_inv: np.ndarray,
    omega_base: Any | None,
    omega_dot_base: Any | None,
) -> tuple[Any, Any]:
    """(ω_rel, ω̇_rel at u = 0): J⁻¹(−ω × Jω) + ω_rel × C_bo ω_b − C_bo ω̇_b (module docstring);
    pure."""
    drift = -cross(w, w @ J.T) @ J_inv.T
    w_rel = w
    if omega_base is not None:
        w_rel = w - omega_base
        drift = drift + cross(w_rel, omega_base)
    if omega_dot_base is not None:
        drift = drift - omega_dot_base
    return w_rel, drift


def euler_feedback_linearisation(
    angles: object,
    omega: object,
    J: object,
    seq: str = "ZYX",
    lock_tol: float = LOCK_TOL,
    omega_base: object | None = None,
    omega_dot_base: object | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Feedback-linearised Euler-angle dynamics ÿ = b + A u with u = J⁻¹L (the paper's
    eqs. (10)–(12)).

    A = B(a) (= ∂ẏ/∂ω = ∂ÿ/∂u), b = L_f²h = B(a)(J⁻¹(−ω × Jω) − Ṁ(a, ȧ) ȧ), for a general
    full inertia ``J`` (principal J gives the paper's u = (L_x/J_x, L_y/J_y, L_z/J_z)).

    Euler angles relative to a rotating base frame (extension, not in the paper): with the base's
    inertial rate ``omega_base`` = C_bo ω_b and ``omega_dot_base`` = C_bo ω̇_b in body axes,
    ω_rel = ω − C_bo ω_b, ẏ = B ω_rel and ω̇_rel = ω̇ + ω_rel × C_bo ω_b − C_bo ω̇_b, so
    b = B(J⁻¹(−ω × Jω) + ω_rel × C_bo ω_b − C_bo ω̇_b − Ṁ ẏ) and A = B as before.

    Args:
        angles: ``(..., 3)`` Euler angles [rad] of ``seq`` (of the body relative to the base).
        omega: ``(..., 3)`` inertial body angular velocity, body axes [rad/s].
        J: ``(3, 3)`` inertia [kg·m²] (symmetric positive definite).
        seq: scipy Euler sequence (default ``"ZYX"``, the paper's 3-2-1).
        lock_tol: gimbal-lock threshold on |cos a2| (|sin a2|).
        omega_base, omega_dot_base: ``(..., 3)`` or ``None`` (inertial base).

    Returns:
        ``(A, b)``: ``(..., 3, 3)`` and ``(..., 3)`` (batch shapes broadcast).

    Raises:
        ValueError: bad shapes, non-finite input, invalid ``J`` or ``seq``.
        ChartSingularityError: at gimbal lock (instead of NaN/inf).
    """
    J = check_inertia_3x3(J, "J")
    a = as_array(angles, "angles", (3,))
    w = as_array(omega, "omega", (3,))
    wb = None if omega_base is None else as_array(omega_base, "omega_base", (3,))
    dwb = None if omega_dot_base is None else as_array(omega_dot_base, "omega_dot_base", (3,))
    _parse(seq)
    lock_tol = check_tolerance(lock_tol, "lock_tol", upper=1.0)
    with np.errstate(over="ignore", invalid="ignore"):
        w_rel, drift = _drift(w, J, np.linalg.inv(J), wb, dwb)
        B, _, b = _accel_core(a, w_rel, drift, seq, lock_tol)
    # ω × Jω grows like |ω|²: beyond ~1e150 rad/s the drift is not representable
    check_output_finite(b, "omega", "the drift term b (∝ |ω|²)")
    A = np.broadcast_to(B, b.shape + (3,)).copy()
    return A, b


def euler_reference(
    R_d: object,
    omega_d: object,
    omega_dot_d: object,
    seq: str = "ZYX",
    lock_tol: float = LOCK_TOL,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Euler-angle reference (y_d, ẏ_d, ÿ_d) of an SO(3) reference (R_d, ω_d, ω̇_d) — ω_d in the
    desired body frame — by :func:`liecontrol.charts.euler.from_matrix` and
    :func:`euler_angle_acceleration`. Raises ChartSingularityError if R_d is at gimbal lock."""
    R_d = check_rotation_matrix(R_d, "R_d")
    omega_d = as_array(omega_d, "omega_d", (3,))
    omega_dot_d = as_array(omega_dot_d, "omega_dot_d", (3,))
    lock_tol = check_tolerance(lock_tol, "lock_tol", upper=1.0)
    a_d = from_matrix(R_d, seq, warn=False)
    try:
        ad, add = euler_angle_acceleration(a_d, omega_d, omega_dot_d, seq, lock_tol)
    except ValueError as exc:
        # re-name the arguments of the inner call after this function's own
        msg = str(exc)
        for inner, outer in (("omega_dot:", "omega_dot_d:"), ("omega:", "omega_d:")):
            if msg.startswith(inner):
                raise ValueError(outer + msg[len(inner) :]) from None
        raise
    return np.broadcast_to(a_d, ad.shape).copy(), ad, add


# -- time shaping ---------------------------------------------------------------------------------


def _shape_coefficients() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients of τ^m in the shape functions P_l(τ) (rows l = 0, 1, 2) and in their first
    and second τ-derivatives: the Taylor part τ^l / l!, then the paper's r_jl on τ^{j+3}."""
    C = np.zeros((3, 6))
    for ell in range(3):
        C[ell, ell] = 1.0 / math.factorial(ell)
        C[ell, 3:] = SHAPING_COEFFICIENTS[:, ell]
    D1 = C[:, 1:] * np.arange(1, 6)
    D2 = D1[:, 1:] * np.arange(1, 5)
    return C, D1, D2


_C0, _C1, _C2 = _shape_coefficients()


def _shape_core(t: Any, T: float, e0: Any, e1: Any, e2: Any) -> tuple[Any, Any, Any]:
    """p, ṗ, p̈ without validation; ``t`` (array, ≥ 0) broadcasts against ``e0.shape[:-1]``.
    Pure for one time (a 0-d ``t``, the controller's case: NumPy or JAX)."""
    scale = np.array([1.0, T, T * T])
    if t.ndim == 0:
        # one time for the whole batch (the controller's case): a 3×3 weight matrix
        # W[l, d] = d^d/dt^d of (T^l P_l(t/T)), then (p, ṗ, p̈) = [e0 e1 e2] W; zero after T
        xp = namespace(t, e0, e1, e2)
        active = t <= T
        # the polynomial at a safe τ where it is not used (its powers stay bounded)
        pw = (xp.where(active, t, 0.0) / T) ** np.arange(6)
        W = xp.stack((_C0 @ pw, (_C1 @ pw[:5]) / T, (_C2 @ pw[:4]) / (T * T)), axis=-1)
        W = W * scale[:, None]
        E = xp.stack(xp.broadcast_arrays(e0, e1, e2), axis=-1)  # (..., 3, l)
        out = xp.where(active, E @ W, 0.0)
        return out[..., 0], out[..., 1], out[..., 2]
    tau = np.minimum(t / T, 1.0)[..., None]
    powers = tau ** np.arange(6)  # (..., 6): τ^0 … τ^5
    active = (t <= T)[..., None]
    res = []
    for coeffs, deriv in ((_C0, 0), (_C1, 1), (_C2, 2)):
        S = (powers[..., : coeffs.shape[1]] @ coeffs.T) * scale  # (..., 3): P_l T^l
        v = (e0 * S[..., 0:1] + e1 * S[..., 1:2] + e2 * S[..., 2:3]) / T**deriv
        res.append(np.where(active, v, 0.0))
    return res[0], res[1], res[2]


def time_shaping_polynomial(
    t: object, T: float, e0: object, edot0: object, eddot0: object
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The paper's time-shaping function p(t) and its first two time derivatives (eq. (16)).

    p(t) = e₀P₀(τ) + ė₀T P₁(τ) + ë₀T² P₂(τ), τ = t/T, for 0 ≤ t ≤ T; 0 for t > T (module
    docstring). p(0) = e₀, ṗ(0) = ė₀, p̈(0) = ë₀; p = ṗ = p̈ = 0 at t = T.

    Args:
        t: time since the start [s], ≥ 0: a scalar, or an array broadcasting against the batch
            shape of ``e0`` (``e0.shape[:-1]``).
        T: prescribed convergence time [s], > 0.
        e0, edot0, eddot0: ``(..., 3)`` initial error, rate and acceleration.

    Returns:
        ``(p, pdot, pddot)``, each with the broadcast shape ``(..., 3)``.

    Raises:
        ValueError: ``T ≤ 0``, ``t < 0``, non-finite input or shape mismatch.
    """
    T = check_positive(T, "T")
    if not isinstance(T, float):
        raise ValueError("T: must be a scalar")
    t = np.asarray(check_nonnegative(t, "t"), dtype=np.float64)
    e0 = as_array(e0, "e0", (3,))
    e1 = as_array(edot0, "edot0", (3,))
    e2 = as_array(eddot0, "eddot0", (3,))
    return _shape_core(t, T, e0, e1, e2)


# -- sliding surface and control ------------------------------------------------------------------


def wrap_error(e: object) -> np.ndarray:
    """Wrap angle differences to (−π, π] (Euler angles a1, a3 live on circles)."""
    return _wrap_unchecked(as_array(e, "e"))


def _wrap_unchecked(e: Any) -> Any:
    """:func:`wrap_error` without validation; pure."""
    return np.pi - namespace(e).mod(np.pi - e, 2.0 * np.pi)


def _apply(C: np.ndarray, x: np.ndarray) -> np.ndarray:
    return x @ C.T


def sliding_surface(
    e: object, edot: object, p: object, pdot: object, C1: object, C2: object
) -> np.ndarray:
    """σ = C₁(e − p) + C₂(ė − ṗ) (the paper's eq. (15) for n = 2), ``(..., 3)``; ``C1, C2`` 3×3."""
    C1 = np.asarray(C1, dtype=np.float64)
    C2 = np.asarray(C2, dtype=np.float64)
    e, edot = as_array(e, "e", (3,)), as_array(edot, "edot", (3,))
    p, pdot = as_array(p, "p", (3,)), as_array(pdot, "pdot", (3,))
    return _apply(C1, e - p) + _apply(C2, edot - pdot)


def tsm_control(
    e: np.ndarray,
    edot: np.ndarray,
    p: np.ndarray,
    pdot: np.ndarray,
    pddot: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    yddot_d: np.ndarray,
    params: TSMParams,
) -> tuple[np.ndarray, np.ndarray]:
    """The paper's eq. (17) with the smoothed switching term:

    u = −A⁻¹{ b − ÿ_d − p̈ + C₂⁻¹C₁(ė − ṗ) + S_δ (F + D + K) },
    S_δ = C₂ᵀσ / (‖C₂ᵀσ‖ + δ), δ = δ₀ + δ₁‖e‖.

    Arrays ``(..., 3)`` (``A`` ``(..., 3, 3)``); returns ``(u, sigma)``. No validation (hot path;
    :class:`TerminalSlidingMode` validates).
    """
    P = params
    return _tsm_core(e, edot, p, pdot, pddot, A, b, yddot_d, P.C1, P.C2, P.C2invC1, P.delta0,
                     P.delta1, P.gain)  # fmt: skip


def _tsm_core(
    e: Any, edot: Any, p: Any, pdot: Any, pddot: Any, A: Any, b: Any, yddot_d: Any, C1: Any,
    C2: Any, C2invC1: Any, delta0: Any, delta1: Any, gain: Any,
) -> tuple[Any, Any]:  # fmt: skip
    """:func:`tsm_control` on the parameters' values (pure, NumPy or JAX: the norms are the
    guarded square root, finite derivatives at σ = 0 and e = 0)."""
    xp = namespace(e, edot, A, b, C1, C2, gain)
    sigma = _apply(C1, e - p) + _apply(C2, edot - pdot)
    c2s = _apply(xp.swapaxes(C2, -1, -2), sigma)
    delta = delta0 + delta1 * safe_sqrt(xp.sum(e * e, axis=-1, keepdims=True), xp)
    s_delta = c2s / (safe_sqrt(xp.sum(c2s * c2s, axis=-1, keepdims=True), xp) + delta)
    v = b - yddot_d - pddot + _apply(C2invC1, edot - pdot) + s_delta * gain
    u = -xp.linalg.solve(A, v[..., None])[..., 0]
    return u, sigma


def _check_weight(C: object, name: str) -> np.ndarray:
    """Positive scalar, positive (3,) (diagonal) or symmetric positive-definite 3×3 → 3×3."""
    a = as_array(C, name)
    if a.ndim == 0 or a.shape == (3,):
        check_positive(a, name)
        return np.diag(np.broadcast_to(a, (3,))).astype(np.float64)
    if a.shape != (3, 3):
        raise ValueError(f"{name}: expected a scalar, shape (3,) or (3, 3), got {a.shape}")
    if np.abs(a - a.T).max() > 1e-12 * max(float(np.abs(a).max()), 1e-300):
        raise ValueError(f"{name}: not symmetric")
    lo = float(np.linalg.eigvalsh(a)[0])
    if lo <= 0:
        raise ValueError(f"{name}: must be positive definite (smallest eigenvalue {lo:.3e})")
    return a.copy()


@dataclass(frozen=True)
class TSMParams:
    """Terminal-sliding-mode parameters (the paper's §3).

    Attributes:
        T: prescribed convergence time [s], > 0.
        C1, C2: surface weights, positive scalar / (3,) / SPD 3×3 (stored 3×3); the sliding
            dynamics ė − ṗ = −C₂⁻¹C₁(e − p) are stable because C₂⁻¹C₁ has positive eigenvalues.
        delta0: smoothing floor δ₀ [rad/s], > 0 (paper: 0.03).
        delta1: smoothing slope δ₁ [1/s], ≥ 0 (seed 5).
        F: bound on ‖Δb‖ (model error) [rad/s²], ≥ 0.
        D: bound on ‖d‖ (external disturbance) [rad/s²], ≥ 0.
        K: reaching gain [rad/s²], > 0.
        C2invC1: derived C₂⁻¹C₁ (not an argument).
    """

    T: float
    C1: np.ndarray
    C2: np.ndarray
    delta0: float
    delta1: float
    F: float
    D: float
    K: float
    C2invC1: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("T", "delta0", "K"):
            v = check_positive(getattr(self, name), name)
            if not isinstance(v, float):
                raise ValueError(f"{name}: must be a scalar")
            object.__setattr__(self, name, v)
        for name in ("delta1", "F", "D"):
            v = check_nonnegative(getattr(self, name), name)
            if not isinstance(v, float):
                raise ValueError(f"{name}: must be a scalar")
            object.__setattr__(self, name, v)
        for name in ("C1", "C2"):
            C = _check_weight(getattr(self, name), name)
            C.setflags(write=False)
            object.__setattr__(self, name, C)
        G = np.linalg.solve(self.C2, self.C1)
        G.setflags(write=False)
        object.__setattr__(self, "C2invC1", G)

    @property
    def gain(self) -> float:
        """F + D + K, the switching-term magnitude."""
        return self.F + self.D + self.K


class TerminalSlidingMode:
    """Chart-level terminal sliding mode law on Euler angles (Liu, Tang & Yu 2008).

    Works on Euler angles of ``seq`` directly (no SO(3) objects): ``command(t, angles, omega,
    angles_d, rates_d, accels_d)`` returns the body torque L = J u. The first ``command`` after
    :meth:`reset` fixes the shaping polynomial's initial conditions e₀ = e(t₀), ė₀ = ė(t₀),
    ë₀ = b(x₀) − ÿ_d(t₀) (module docstring). Use
    :class:`TerminalSlidingModeSO3` (this law inside
    :class:`~liecontrol.control.adapters.EulerChartAdapter`) for an SO(3)
    :class:`~liecontrol.control.base.AttitudeController`.

    Args:
        J: ``(3, 3)`` inertia the controller assumes [kg·m²] (full inertia allowed).
        T: prescribed time [s] (> 0).
        C1, C2, delta0, delta1, F, D, K: see :class:`TSMParams` (defaults: the paper's C₁ = C₂ =
            I, δ₀ = 0.03, δ₁ = 5; F = D = 0; K = 0.5 rad/s² as in our terminal-sliding-mode
            reproduction).
        seq: Euler sequence (default ``"ZYX"``, the paper's 3-2-1).
        lock_tol: |cos a2| (|sin a2|) below which :class:`ChartSingularityError` is raised.
    """

    def __init__(
        self,
        J: object,
        T: float,
        C1: object = 1.0,
        C2: object = 1.0,
        delta0: float = 0.03,
        delta1: float = 5.0,
        F: float = 0.0,
        D: float = 0.0,
        K: float = 0.5,
        seq: str = "ZYX",
        lock_tol: float = LOCK_TOL,
    ) -> None:
        J = check_inertia_3x3(J, "J")
        self.J = J.copy()
        self.J.setflags(write=False)
        self._J_inv = np.linalg.inv(self.J)
        self.params = TSMParams(T=T, C1=C1, C2=C2, delta0=delta0, delta1=delta1, F=F, D=D, K=K)
        _parse(seq)
        self.seq = seq
        self.lock_tol = check_tolerance(lock_tol, "lock_tol", upper=1.0)
        self._t0: float | None = None
        self._init: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._diag: dict[str, np.ndarray] = {}

    #: command() handles any batch vectorized (chart-law protocol of the adapters)
    batched = True

    def __repr__(self) -> str:
        p = self.params
        return (
            f"TerminalSlidingMode(T={p.T}, delta0={p.delta0}, delta1={p.delta1}, F={p.F}, "
            f"D={p.D}, K={p.K}, seq={self.seq!r})"
        )

    def reset(self, t0: float, batch_size: int | None = None) -> None:
        """Forget the shaping polynomial's initial conditions; the next command at time ``t``
        restarts the prescribed-time manoeuvre from ``t`` (normally ``t0``)."""
        self._t0 = None
        self._init = None
        self._diag = {}

    @property
    def initial_conditions(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(e₀, ė₀, ë₀) captured at the first command after reset, or ``None``."""
        return self._init

    def command(
        self,
        t: float,
        angles: object,
        omega: object,
        angles_d: object,
        rates_d: object,
        accels_d: object,
        omega_base: object | None = None,
        omega_dot_base: object | None = None,
    ) -> np.ndarray:
        """Body torque ``(..., 3)`` [N·m].

        Args:
            t: time [s].
            angles: ``(..., 3)`` Euler angles of the body relative to the base frame [rad].
            omega: ``(..., 3)`` inertial body angular velocity, body axes [rad/s].
            angles_d, rates_d, accels_d: ``(..., 3)`` or ``(3,)`` reference y_d, ẏ_d, ÿ_d.
            omega_base, omega_dot_base: the base frame's inertial rate and its derivative in
                body axes (C_bo ω_b, C_bo ω̇_b); ``None`` = inertial base (the paper's case).
                With a rotating base ω_rel = ω − C_bo ω_b and ω̇_rel = ω̇ + ω_rel × C_bo ω_b
                − C_bo ω̇_b, so b = B(J⁻¹(−ω × Jω) + ω_rel × C_bo ω_b − C_bo ω̇_b − Ṁ ẏ).

        Raises:
            ChartSingularityError: state at gimbal lock.
            ValueError: bad shapes / non-finite input, or ``t`` before the capture time.
        """
        t = as_scalar(t, "t")
        a = as_array(angles, "angles", (3,))
        w = as_array(omega, "omega", (3,))
        y_d = as_array(angles_d, "angles_d", (3,))
        yd_d = as_array(rates_d, "rates_d", (3,))
        ydd_d = as_array(accels_d, "accels_d", (3,))
        wb = None if omega_base is None else as_array(omega_base, "omega_base", (3,))
        dwb = None if omega_dot_base is None else as_array(omega_dot_base, "omega_dot_base", (3,))
        w_rel, drift = _drift(w, self.J, self._J_inv, wb, dwb)
        A, ydot, b = _accel_core(a, w_rel, drift, self.seq, self.lock_tol)
        e = wrap_error(a - y_d)
        edot = ydot - yd_d
        e, edot = np.broadcast_arrays(e, edot)
        if self._init is None or self._init[0].shape != e.shape:
            self._t0 = t
            self._init = (e.copy(), edot.copy(), np.broadcast_to(b - ydd_d, e.shape).copy())
        assert self._t0 is not None
        if t < self._t0:
            raise ValueError(f"t: {t} is before the manoeuvre start {self._t0} (call reset)")
        p, pdot, pddot = _shape_core(np.asarray(t - self._t0), self.params.T, *self._init)
        u, sigma = tsm_control(e, edot, p, pdot, pddot, A, b, ydd_d, self.params)
        self._diag = {"sigma": sigma, "e": e, "edot": edot, "p": p, "u": u}
        return finite_command(u @ self.J.T, omega)

    def __call__(self, t: float, s: Any) -> np.ndarray:
        """Chart-law protocol of :mod:`liecontrol.control.adapters`: ``s`` is a ``ChartState``
        of an Euler chart whose sequence must equal ``self.seq``."""
        seq = getattr(s.chart, "seq", None)
        if seq != self.seq:
            raise ValueError(f"s: chart sequence {seq!r} differs from the law's {self.seq!r}")
        return self.command(
            t, s.y, s.omega, s.y_d, s.y_d_dot, s.y_d_ddot, s.omega_base, s.omega_dot_base
        )

    def array_law(self) -> ChartArrayLaw:
        """The law's pure form for the differentiable loop (the chart-law protocol of
        :mod:`liecontrol.control.adapters`, composed by the Euler adapter): the same pure
        functions :meth:`command` calls (:func:`_drift`, :func:`_accel_core`, the wrap, the
        shaping polynomial, :func:`_tsm_core`). The differentiable gains are the surface weights
        ``C₁`` (as ``k_R``) and ``C₂`` (as ``k_Omega``), 3×3; ``K``, ``delta0``, ``delta1`` are
        further ``params``. Timed: the scan carries (started, t₀, e₀, ė₀, ë₀), captured at the
        first sample as :meth:`command` captures them; T, F, D stay as constructed."""
        P = self.params
        J, J_inv, seq, T = np.array(self.J), np.array(self._J_inv), self.seq, P.T
        fixed = P.F + P.D
        defaults = {"K": P.K, "delta0": P.delta0, "delta1": P.delta1}

        def step(C1, C2, state, s, T_ctrl, params=None, t=None):  # noqa: ANN001
            p = defaults if params is None else params
            if getattr(s.chart, "seq", seq) != seq:
                raise ValueError(
                    f"s: chart sequence {s.chart.seq!r} differs from the law's {seq!r}"
                )
            started, t0, e0, e1, e2 = state
            xp = namespace(s.y, s.omega, t)
            w_rel, drift = _drift(s.omega, J, J_inv, s.omega_base, s.omega_dot_base)
            A, ydot, b = _accel_core(s.y, w_rel, drift, seq, self.lock_tol)
            e = _wrap_unchecked(s.y - s.y_d)
            edot = ydot - s.y_d_dot
            t0 = xp.where(started, t0, t)
            e0 = xp.where(started, e0, e)
            e1 = xp.where(started, e1, edot)
            e2 = xp.where(started, e2, b - s.y_d_ddot)
            pp, pdot, pddot = _shape_core(t - t0, T, e0, e1, e2)
            C2invC1 = xp.linalg.solve(C2, C1)
            u, sigma = _tsm_core(e, edot, pp, pdot, pddot, A, b, s.y_d_ddot, C1, C2, C2invC1,
                                 p["delta0"], p["delta1"], fixed + p["K"])  # fmt: skip
            diag = {"sigma": sigma, "e": e, "edot": edot, "p": pp, "u": u}
            return u @ J.T, (xp.ones_like(started), t0, e0, e1, e2), diag

        z = np.zeros(3)
        state0 = (np.array(False), np.array(0.0), z, z, z)
        return ChartArrayLaw(np.array(P.C1), np.array(P.C2), state0, step, defaults, timed=True)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last σ, e, ė, p and u = J⁻¹L, each ``(..., 3)``."""
        return dict(self._diag)


class TerminalSlidingModeSO3(EulerChartAdapter):
    """SO(3) :class:`~liecontrol.control.base.AttitudeController`: :class:`TerminalSlidingMode`
    wrapped by :class:`~liecontrol.control.adapters.EulerChartAdapter`.

    The adapter converts (R, ω) and (R_d, ω_d, ω̇_d) into Euler angles of ``seq`` of the body
    relative to ``base`` (``"inertial"`` = the paper's choice; ``"reference"`` makes the chart the
    attitude error, y_d = 0; or a callable rotating frame such as an orbit frame) and refuses
    states/references within ``lock_tol`` of gimbal lock with ChartSingularityError.

    Args:
        J, T, C1, C2, delta0, delta1, F, D, K: as :class:`TerminalSlidingMode`.
        seq: Euler sequence (default ``"ZYX"``).
        base: base frame of the chart (default ``"inertial"``).
        lock_tol: adapter's gimbal-lock guard on |cos a2| (|sin a2|), default 1e-2 (|a2| > 89.4°
            for ``"ZYX"``); the law itself refuses below 1e-6.

    The prescribed-time manoeuvre starts at the first ``command`` after ``reset``;
    ``diagnostics()`` gives σ, e, ė, p, u and the adapter's ``chart_y``, ``chart_y_d``.
    """

    def __init__(
        self,
        J: object,
        T: float,
        C1: object = 1.0,
        C2: object = 1.0,
        delta0: float = 0.03,
        delta1: float = 5.0,
        F: float = 0.0,
        D: float = 0.0,
        K: float = 0.5,
        seq: str = "ZYX",
        base: object = "inertial",
        lock_tol: float = 1e-2,
    ) -> None:
        law = TerminalSlidingMode(J, T, C1, C2, delta0, delta1, F, D, K, seq=seq)
        super().__init__(law, seq=seq, base=base, lock_tol=lock_tol)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.terminal_sliding_mode.tsm_zyx_law`) for
        the simulator's fused loop (:mod:`liecontrol.control.kernel`): sequence ``"ZYX"``, the
        desired frame as base, this law; the state carries the shaping polynomial's initial
        conditions."""
        law = self.law
        if (
            type(law) is not TerminalSlidingMode
            or law.seq != "ZYX"
            or self.chart.seq != "ZYX"
            or self.base != "reference"
            or self._batch is None
        ):
            return None
        P = law.params
        params = np.concatenate(
            [
                *(np.ravel(a) for a in (law.J, law._J_inv, P.C1, P.C2, P.C2invC1)),
                [P.T, P.delta0, P.delta1, P.gain, self.chart.lock_tol, law.lock_tol],
                _C0.ravel(),
                _C1.ravel(),
                _C2.ravel(),
                [0.0, 0.0],
            ]
        )
        B = int(batch_size)
        state = np.zeros((B, TSM_STATE))
        if law._init is not None:
            if law._init[0].shape != (B, 3):
                return None
            state[:, 0] = 1.0
            state[:, 1] = law._t0
            state[:, 2:5], state[:, 5:8], state[:, 8:11] = law._init
        return ControllerKernel(tsm_zyx_law, params, state, TSM_DIAG, _tsm_rows, self._finish)

    def _kernel_reason(self) -> str:
        return "a sequence other than 'ZYX', a base other than the reference frame or a swapped law"

    def _finish(self, state: np.ndarray, diag: np.ndarray) -> None:
        """The law's initial conditions, the chart memory and diagnostics after a compiled run."""
        law = self.law
        if state[0, 0] != 0.0:
            law._t0 = float(state[0, 1])
            law._init = (state[:, 2:5].copy(), state[:, 5:8].copy(), state[:, 8:11].copy())
        d = _tsm_rows(diag)
        law._diag = {k: d[k] for k in ("sigma", "e", "edot", "p", "u")}
        self._y_d_prev = self._identity_coords(state.shape[0])
        self._diag = d


def _tsm_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """The adapter's diagnostics from the kernel rows ``(..., 18)``."""
    names = ("sigma", "e", "edot", "p", "u")
    out = {k: rows[..., 3 * i : 3 * i + 3].copy() for i, k in enumerate(names)}
    out.update(
        chart_y=rows[..., 15:18].copy(),
        chart_y_d=np.zeros(rows.shape[:-1] + (3,)),
        chart_switched=np.zeros(rows.shape[:-1], dtype=bool),
    )
    return out
