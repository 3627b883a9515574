"""Adaptive, disturbance-rejecting geometric attitude tracking on SO(3).

The controller estimates online the six inertia parameters and the coefficients of a disturbance
that is a constant plus harmonics of *known* frequencies (unknown amplitudes and phases), in the
spirit of Sanyal, Fosbury, Chaturvedi & Bernstein, "Inertia-free spacecraft attitude tracking
with disturbance rejection and almost global stabilization", Journal of Guidance, Control, and
Dynamics 32(4), 2009 (surveyed by Jiang, Meng & Yang, Control and Decision 38(8), 2023, §2.1),
with the composite-error structure of Lee, "Robust adaptive attitude tracking on SO(3) with an
application to a quadrotor UAV", IEEE Transactions on Control Systems Technology 21(5), 2013.
The update law below is derived here for this package's error functions (the derivation is in
this docstring and checked numerically by the tests); it is not a transcription of either paper.

Model. ``J ω̇ + ω × Jω = M + d(t)`` with ``J`` unknown (constant) and

    d(t) = Φ(t) φ,   Φ(t) = [I₃, sin(ν₁t) I₃, cos(ν₁t) I₃, …, sin(ν_K t) I₃, cos(ν_K t) I₃],

``ν_k`` known, ``φ ∈ R^{3(1+2K)}`` unknown (:func:`harmonic_regressor`,
:func:`disturbance_parameters`). Inertia enters linearly: ``J a = Y(a) θ`` with
``θ = (J₁₁, J₂₂, J₃₃, J₁₂, J₁₃, J₂₃)`` (:func:`inertia_regressor`).

Errors (globally defined on SO(3), no chart): ``R̃ = R_dᵀR``, ``(Ψ, e_R)`` one of the error
functions of :mod:`liecontrol.errors` (``"trace"`` by default: smooth everywhere, the weighted
trace error that Sanyal et al. use), ``e_Ω = ω − R̃ᵀω_d``, ``ė_R = E(R̃) e_Ω``
(:func:`error_rate_matrix`) and the composite error ``s = e_Ω + c e_R``. With
``α_d = R̃ᵀω̇_d − ω × R̃ᵀω_d`` (so that ``ė_Ω = ω̇ − α_d``) and the reference acceleration
``a_r = α_d − c E e_Ω``:

    J ṡ = M + d − W θ,      W = ω^ Y(ω) + Y(a_r)        (no acceleration is measured).

Control and update laws:

    M   = −K_s s − k_R e_R + W θ̂ − Φ(t) φ̂
    θ̂̇  = −γ_θ Wᵀ s,        φ̂̇ = γ_φ Φ(t)ᵀ s             (then projected, below).

Lyapunov function (``c_Ψ`` = :data:`liecontrol.errors.DERIVATIVE_FACTOR`, ``Ψ̇ = c_Ψ e_R·e_Ω``):

    V = ½ sᵀJ s + (k_R / c_Ψ) Ψ + |θ̂ − θ|² / (2γ_θ) + |φ̂ − φ|² / (2γ_φ),
    V̇ = −sᵀK_s s − c k_R |e_R|² ≤ 0.

(``sᵀ(−k_R e_R) + k_R e_R·e_Ω = −c k_R|e_R|²``; the parameter terms cancel by the choice of the
update laws.) ``V`` is bounded below and non-increasing, so ``s``, ``e_R`` and the estimates stay
bounded, and (Barbalat) ``s → 0`` and ``e_R → 0``: the tracking error converges to a critical
point of ``Ψ`` — ``R̃ = I`` from almost every initial condition for the trace error (four
isolated critical points, three of them unstable); for ``"large_angle"`` (``E`` grows like
``1/cos(θ/2)`` near 180°) and ``"log"`` (discontinuous at 180°) the argument holds on the region
``θ < π`` that the run never leaves. The estimates need not converge to the true values (that
needs persistent excitation); the torque they produce along the trajectory does.

Boundedness under unmodelled effects (projection). The matched, noise-free argument bounds the
estimates already; sensor noise, actuator saturation or an unmodelled disturbance break the
matching and a pure integrator-type update can drift. After every update step ``θ̂`` is projected
onto the ball ``|θ̂ − θ₀| ≤ ρ_θ`` (``θ₀`` the nominal inertia's parameters) and ``φ̂`` onto
``|φ̂| ≤ ρ_φ``. Euclidean projection onto a closed convex set that contains the true parameter
never increases ``|θ̂ − θ|`` (projection is non-expansive), so it keeps every term of ``V`` that
it touches from growing: ``V̇ ≤ −sᵀK_s s − c k_R|e_R|²`` survives, exactly, and the estimates
are bounded by construction whatever the measurements do. σ-modification
(``θ̂̇ = … − σ(θ̂ − θ₀)``) was not used: it bounds the estimates as well but adds
``−σ θ̃ᵀ(θ̂ − θ₀)/γ`` to ``V̇``, which destroys ``V̇ ≤ 0`` and leaves only ultimate
boundedness, and it biases the estimate away from the true value even without noise. The price of
projection is that the balls must contain the true parameters (``inertia_bound`` and
``disturbance_bound`` are design assumptions, like the known frequencies).

Sampling. ``command`` is called at the control period; each call first advances the estimates
over the time elapsed since the previous call with the update rates held from the previous sample
(explicit Euler on the zero-order-held integrand, the same discretisation as
:mod:`liecontrol.control.geometric_pid`), projects them, and then computes the torque with the
new estimates and stores the new rates. ``V`` is then non-increasing up to ``O(Δt²)`` per step
(checked numerically by the tests). Batched over ``B``: one estimator state per spacecraft.

Units: ``J`` [kg·m²], ``k_R`` [N·m], ``k_s`` [N·m·s/rad], ``c`` [1/s], ``γ_θ`` [kg·m²·s²],
``γ_φ`` [N·m·s²/rad], frequencies [rad/s], ``disturbance_bound`` [N·m].
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._array_api import any_true, cross, namespace, safe_sqrt
from .._kernels.adaptive import N_DIAG as AD_DIAG
from .._kernels.adaptive import N_STATE as AD_STATE
from .._kernels.adaptive import adaptive_law
from .._kernels.geometric_pd import ERROR_CODES
from .._validation import (
    as_array,
    as_scalar,
    check_inertia_3x3,
    check_positive_scalar,
    check_rotation_matrix,
    rotations_pass_fast,
)
from ..errors import _KERNELS, DEFAULT_G, DERIVATIVE_FACTOR, _check_kind, check_error_weight
from ..lie import so3
from .array_law import ArrayLaw
from .base import (
    AttitudeController,
    AttitudeReference,
    AttitudeState,
    check_state_batch,
    finite_command,
)
from .geometric_pd import _apply_gain, _as_matrix, check_gain
from .kernel import ControllerKernel

# adaptive_estimates_step and adaptive_torque, the unchecked formulas (NumPy or JAX arrays), are
# not part of __all__ (as geometric_pd_torque)
__all__ = [
    "AdaptiveGeometricSO3",
    "inertia_parameters",
    "inertia_from_parameters",
    "inertia_regressor",
    "harmonic_regressor",
    "disturbance_parameters",
    "error_rate_matrix",
]


# ------------------------------------------------------------------------------- pure functions


def inertia_parameters(J: object) -> np.ndarray:
    """``θ = (J₁₁, J₂₂, J₃₃, J₁₂, J₁₃, J₂₃)`` of a symmetric positive-definite inertia, ``(6,)``."""
    J = check_inertia_3x3(J, "J")
    return np.array([J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[0, 2], J[1, 2]])


def inertia_from_parameters(theta: object) -> np.ndarray:
    """The symmetric ``(..., 3, 3)`` matrix with parameters ``theta`` ``(..., 6)`` (the inverse
    of :func:`inertia_parameters`; an estimate need not be positive definite)."""
    return _J_matrix(as_array(theta, "theta", (6,)))


def _J_matrix(t: Any) -> Any:
    """The symmetric ``(..., 3, 3)`` matrix of the parameters ``(..., 6)``; NumPy or JAX."""
    xp = namespace(t)
    t0, t1, t2, t3, t4, t5 = (t[..., i] for i in range(6))
    rows = (xp.stack(r, axis=-1) for r in ((t0, t3, t4), (t3, t1, t5), (t4, t5, t2)))
    return xp.stack(tuple(rows), axis=-2)


def _regressor(a: np.ndarray) -> np.ndarray:
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    Y = np.zeros(a.shape[:-1] + (3, 6))
    Y[..., 0, 0], Y[..., 0, 3], Y[..., 0, 4] = a0, a1, a2
    Y[..., 1, 1], Y[..., 1, 3], Y[..., 1, 5] = a1, a0, a2
    Y[..., 2, 2], Y[..., 2, 4], Y[..., 2, 5] = a2, a0, a1
    return Y


def inertia_regressor(a: object) -> np.ndarray:
    """``Y(a)`` ``(..., 3, 6)`` with ``J a = Y(a) θ`` for every symmetric ``J`` with parameters
    ``θ = (J₁₁, J₂₂, J₃₃, J₁₂, J₁₃, J₂₃)``::

        Y(a) = [[a₁, 0,  0,  a₂, a₃, 0 ],
                [0,  a₂, 0,  a₁, 0,  a₃],
                [0,  0,  a₃, 0,  a₁, a₂]]
    """
    return _regressor(as_array(a, "a", (3,)))


def _check_frequencies(frequencies: object) -> np.ndarray:
    f = as_array(frequencies, "frequencies")
    if f.ndim != 1:
        raise ValueError(f"frequencies: expected a 1-D sequence [rad/s], got shape {f.shape}")
    if np.any(f <= 0.0):
        raise ValueError(
            f"frequencies: must be > 0 (the constant part is always modelled), got {f.tolist()}"
        )
    if np.unique(f).size != f.size:
        raise ValueError(f"frequencies: must be distinct, got {f.tolist()}")
    out = f.copy()
    out.setflags(write=False)
    return out


def _phi_basis(t: Any, nu: np.ndarray) -> Any:
    """``(1, sin ν₁t, cos ν₁t, …)`` — the scalar functions multiplying the I₃ blocks; ``t`` a
    float or a JAX scalar (the harmonic regressor reads the clock)."""
    xp = namespace(t)
    sc = xp.stack((xp.sin(nu * t), xp.cos(nu * t)), axis=-1).reshape(-1)
    return xp.concatenate((xp.ones(1), sc))


def harmonic_regressor(t: float, frequencies: object) -> np.ndarray:
    """``Φ(t)`` ``(3, 3(1+2K))``: ``[I₃, sin(ν₁t) I₃, cos(ν₁t) I₃, …]`` for the ``K`` known
    ``frequencies`` ν [rad/s], so that ``d(t) = Φ(t) φ`` (module docstring)."""
    t = as_scalar(t, "t")
    nu = _check_frequencies(frequencies)
    return np.kron(_phi_basis(t, nu)[None, :], np.eye(3))


def disturbance_parameters(
    constant: object, sine: object = None, cosine: object = None
) -> np.ndarray:
    """The coefficient vector ``φ`` of ``d(t) = c₀ + Σ_k (a_k sin ν_k t + b_k cos ν_k t)``.

    Args:
        constant: ``c₀`` ``(3,)`` [N·m].
        sine: ``a_k`` ``(K, 3)`` (``None``: zeros), cosine: ``b_k`` ``(K, 3)`` (``None``: zeros).

    Returns ``(3(1+2K),)`` in the column order of :func:`harmonic_regressor`.
    """
    c0 = as_array(constant, "constant")
    if c0.shape != (3,):
        raise ValueError(f"constant: expected shape (3,), got {c0.shape}")
    blocks = []
    for name, x in (("sine", sine), ("cosine", cosine)):
        if x is None:
            blocks.append(None)
            continue
        a = as_array(x, name)
        if a.ndim != 2 or a.shape[1] != 3:
            raise ValueError(f"{name}: expected shape (K, 3), got {a.shape}")
        blocks.append(a)
    K = next((b.shape[0] for b in blocks if b is not None), 0)
    a, b = (np.zeros((K, 3)) if x is None else x for x in blocks)
    if a.shape != b.shape:
        raise ValueError(f"cosine: shape {b.shape} differs from sine's {a.shape}")
    return np.concatenate([c0, np.stack((a, b), axis=1).ravel()])


def _rate_matrix(Rt: Any, e_R: Any, error: str, G: np.ndarray | None) -> Any:
    """:func:`error_rate_matrix` on checked arrays (``Rt`` ``(..., 3, 3)``, ``e_R`` its error).
    Pure, NumPy or JAX, for the trace and large-angle errors; the log error's ``J_r⁻¹`` is
    NumPy only (:func:`liecontrol.lie.so3.right_jacobian_inv` validates its argument)."""
    xp = namespace(Rt, e_R)
    RtT = xp.swapaxes(Rt, -1, -2)
    eye = np.eye(3)
    if error == "trace":
        A = RtT @ G
        return 0.5 * (xp.trace(A, axis1=-2, axis2=-1)[..., None, None] * eye - A)
    if error == "large_angle":
        tr = xp.trace(Rt, axis1=-2, axis2=-1)
        # √(1 + tr R̃) = 2 cos(θ/2) → 0 at 180°, where this error is not differentiable; the
        # floor keeps the root (and its derivative) finite there
        root = xp.sqrt(xp.maximum(1.0 + tr, 1e-300))
        num = tr[..., None, None] * eye - RtT + 2.0 * e_R[..., :, None] * e_R[..., None, :]
        return num / (2.0 * root)[..., None, None]
    return so3.right_jacobian_inv(e_R)


def error_rate_matrix(R_tilde: object, error: str = "trace", G: object = None) -> np.ndarray:
    """``E(R̃)`` ``(B, 3, 3)`` with ``ė_R = E(R̃) e_Ω`` along ``d/dt R̃ = R̃ e_Ω^``.

    - trace (``e_R = ½(GR̃ − R̃ᵀG)^∨``): ``E = ½(tr(R̃ᵀG) I − R̃ᵀG)`` — from
      ``(x^A + Aᵀx^)^∨ = (tr A · I − A) x`` with ``A = R̃ᵀG``;
    - large_angle (``e_R = (R̃ − R̃ᵀ)^∨ / (2√(1+tr R̃))``):
      ``E = (tr R̃ · I − R̃ᵀ + 2 e_R e_Rᵀ) / (2√(1+tr R̃))``, unbounded as θ → π;
    - log (``e_R = log(R̃)^∨``): ``E = J_r(e_R)⁻¹``.

    Args:
        R_tilde: ``(B, 3, 3)`` or ``(3, 3)`` relative rotation ``R_dᵀR``.
        error: ``"trace"``, ``"large_angle"`` or ``"log"``; G: trace weight (trace only).
    """
    error = _check_kind(error, "error")
    Rt = check_rotation_matrix(R_tilde, "R_tilde").reshape(-1, 3, 3)
    Gm = _check_G(G, error)
    e_R = _KERNELS[error](Rt, Gm)[1] if error == "trace" else _KERNELS[error](Rt)[1]
    return _rate_matrix(Rt, e_R, error, Gm)


def _check_G(G: object, error: str) -> np.ndarray | None:
    if G is not None and error != "trace":
        raise ValueError(f"G: only used by the 'trace' error function, not {error!r}")
    if error != "trace":
        return None
    return DEFAULT_G if G is None else check_error_weight(G).copy()


def _J_times(theta: Any, a: Any) -> Any:
    """``Y(a) θ`` (= ``Ĵ a``) row by row, without forming ``Y``: ``(..., 6)``, ``(..., 3)``."""
    xp = namespace(theta, a)
    t0, t1, t2, t3, t4, t5 = (theta[..., i] for i in range(6))
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    return xp.stack(
        (t0 * a0 + t3 * a1 + t4 * a2, t3 * a0 + t1 * a1 + t5 * a2, t4 * a0 + t5 * a1 + t2 * a2),
        axis=-1,
    )


def _regressor_T(a: Any, v: Any) -> Any:
    """``Y(a)ᵀ v`` ``(..., 6)`` for ``(..., 3)`` rows."""
    xp = namespace(a, v)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    v0, v1, v2 = v[..., 0], v[..., 1], v[..., 2]
    return xp.stack(
        (a0 * v0, a1 * v1, a2 * v2, a1 * v0 + a0 * v1, a2 * v0 + a0 * v2, a2 * v1 + a1 * v2),
        axis=-1,
    )


_F64 = np.dtype(np.float64)


def _vec3(x: object, name: str) -> np.ndarray:
    """A finite float64 ``(..., 3)`` array; the common case (already one) costs one sum."""
    if (
        isinstance(x, np.ndarray)
        and x.dtype == _F64
        and x.ndim in (1, 2)
        and x.shape[-1] == 3
        and np.isfinite(x.sum())
    ):
        return x
    return as_array(x, name, (3,))


def _project_ball(x: Any, centre: Any, radius: Any) -> tuple[Any, Any]:
    """Rows of ``x`` ``(..., n)`` projected onto the ball ``|x − centre| ≤ radius``; and which
    moved ``(...)``. Pure, NumPy or JAX: the norm is 0 at the centre (where the estimates
    start), so it is a :func:`~liecontrol._array_api.safe_sqrt` and the division is guarded
    on the rows that do not move."""
    xp = namespace(x, centre, radius)
    v = x - centre
    n = safe_sqrt(xp.einsum("...i,...i->...", v, v), xp)
    out = n > radius
    if not any_true(out, xp):
        return x, out
    scale = radius / xp.where(out, n, 1.0)
    return xp.where(out[..., None], centre + v * scale[..., None], x), out


def adaptive_estimates_step(
    theta: Any, rate_theta: Any, phi: Any, rate_phi: Any, dt: Any, theta0: Any,
    inertia_radius: Any, disturbance_bound: Any,
) -> tuple[Any, Any, Any, Any]:  # fmt: skip
    """The estimator step over ``dt`` [s] with the update rates held from the previous sample
    (explicit Euler on the zero-order-held integrand), then projected (module docstring)::

        θ̂ ← P_{|θ̂ − θ₀| ≤ ρ_θ}(θ̂ + Δt θ̂̇),      φ̂ ← P_{|φ̂| ≤ ρ_φ}(φ̂ + Δt φ̂̇).

    Returns ``(θ̂, φ̂, θ̂ projected, φ̂ projected)``; arrays broadcast over leading axes, NumPy or
    JAX (:meth:`AdaptiveGeometricSO3.command` and its array law call it)."""
    theta, th_proj = _project_ball(theta + dt * rate_theta, theta0, inertia_radius)
    phi, ph_proj = _project_ball(phi + dt * rate_phi, np.zeros(1), disturbance_bound)
    return theta, phi, th_proj, ph_proj


def adaptive_torque(
    Rt: Any, w: Any, w_d: Any, dw_d: Any, theta: Any, phi: Any, t: Any, k_R: Any, k_s: Any,
    c: Any, gamma_theta: Any, gamma_phi: Any, frequencies: np.ndarray, error: str,
    G: np.ndarray | None,
) -> tuple[Any, Any, Any, dict[str, Any]]:  # fmt: skip
    """The adaptive law at one control sample (module docstring; after Sanyal, Fosbury,
    Chaturvedi & Bernstein, JGCD 2009, and Lee, IEEE TCST 2013)::

        s = e_Ω + c e_R,   a_r = α_d − c E(R̃) e_Ω,   α_d = R̃ᵀω̇_d − ω × R̃ᵀω_d,
        M = −K_s s − k_R e_R + W θ̂ − Φ(t) φ̂,   W θ̂ = ω × Ĵω + Ĵ a_r,
        θ̂̇ = −γ_θ Wᵀ s = −γ_θ (Y(ω)ᵀ(s × ω) + Y(a_r)ᵀ s),   φ̂̇ = γ_φ Φ(t)ᵀ s,

    for ``R̃ = R_dᵀR`` ``(..., 3, 3)``, the rates ``(..., 3)``, the estimates ``θ̂`` ``(..., 6)``
    and ``φ̂`` ``(..., m)`` at the sample time ``t``. Returns ``(M, θ̂̇, φ̂̇, diagnostics)`` with
    ``Psi``, ``e_R``, ``e_Omega``, ``s``, ``d_hat``. NumPy or JAX arrays (the log error's
    ``E`` is NumPy only: :func:`_rate_matrix`); no validation."""
    xp = namespace(Rt, w, theta, phi, t)
    RtT = xp.swapaxes(Rt, -1, -2)
    Psi, e_R = _KERNELS["trace"](Rt, G) if error == "trace" else _KERNELS[error](Rt)
    if any_true(w_d != 0.0, xp) or any_true(dw_d != 0.0, xp):
        w_d_b = (RtT @ w_d[..., None])[..., 0]
        dw_d_b = (RtT @ dw_d[..., None])[..., 0]
        e_W = w - w_d_b
        alpha_d = dw_d_b - cross(w, w_d_b)
    else:
        # regulation: the reference terms are exact zeros (same values, fewer products)
        e_W = w
        alpha_d = xp.zeros_like(w)
    E = _rate_matrix(Rt, e_R, error, G)
    a_r = alpha_d - c * (E @ e_W[..., None])[..., 0]
    s = e_W + c * e_R
    # W θ̂ = ω × Ĵω + Ĵ a_r and Wᵀs = Y(ω)ᵀ(s × ω) + Y(a_r)ᵀs ((ω^Y)ᵀ = −Yᵀω^), evaluated
    # without forming the (..., 3, 6) regressor
    W_theta = cross(w, _J_times(theta, w)) + _J_times(theta, a_r)
    Wt_s = _regressor_T(w, cross(s, w)) + _regressor_T(a_r, s)
    basis = _phi_basis(t, frequencies)  # Φ(t) = basis ⊗ I₃
    phi3 = phi.reshape(phi.shape[:-1] + (-1, 3))
    d_hat = xp.einsum("k,...ki->...i", basis, phi3)
    M = W_theta - _apply_gain(k_s, s) - k_R * e_R - d_hat
    rate_theta = -gamma_theta * Wt_s
    rate_phi = gamma_phi * (basis[:, None] * s[..., None, :]).reshape(s.shape[:-1] + (-1,))
    diag = {"Psi": Psi, "e_R": e_R, "e_Omega": e_W, "s": s, "d_hat": d_hat}
    return M, rate_theta, rate_phi, diag


# ----------------------------------------------------------------------------------- controller


def _adaptive_rows(rows: np.ndarray, m: int) -> dict[str, np.ndarray]:
    """The controller's diagnostics (with ``J_hat``) from its kernel rows ``(..., 21 + m)``."""
    theta = rows[..., 13:19].copy()
    return {
        "Psi": rows[..., 0].copy(),
        "e_R": rows[..., 1:4].copy(),
        "e_Omega": rows[..., 4:7].copy(),
        "s": rows[..., 7:10].copy(),
        "d_hat": rows[..., 10:13].copy(),
        "theta_hat": theta,
        "phi_hat": rows[..., 19 : 19 + m].copy(),
        "theta_projected": rows[..., 19 + m] != 0.0,
        "phi_projected": rows[..., 20 + m] != 0.0,
        "J_hat": _J_matrix(theta),
    }


class AdaptiveGeometricSO3(AttitudeController):
    """Adaptive geometric tracking on SO(3): unknown inertia and constant + harmonic disturbance.

    ``M = −K_s s − k_R e_R + W θ̂ − Φ(t) φ̂``, ``θ̂̇ = −γ_θ Wᵀ s``, ``φ̂̇ = γ_φ Φᵀ s``, both
    projected on balls (module docstring: equations, Lyapunov function, discretisation; after
    Sanyal, Fosbury, Chaturvedi & Bernstein, JGCD 2009, and Lee, IEEE TCST 2013).

    Args:
        J: the nominal inertia [kg·m²]: the initial estimate ``θ̂(t₀)`` and the centre of the
            inertia ball.
        k_R: attitude gain [N·m], positive scalar (the Lyapunov function needs a scalar).
        k_s: gain on the composite error [N·m·s/rad]: positive scalar, positive 3-vector or SPD.
        c: weight of ``e_R`` in ``s = e_Ω + c e_R`` [1/s], > 0.
        gamma_theta: inertia adaptation gain [kg·m²·s²], > 0.
        gamma_phi: disturbance adaptation gain [N·m·s²/rad], > 0.
        frequencies: the known disturbance frequencies ν_k [rad/s] (empty: constant only).
        disturbance_bound: radius ``ρ_φ`` of the ball ``|φ̂| ≤ ρ_φ`` [N·m]; must contain the
            true coefficients.
        inertia_bound: radius of the inertia ball as a fraction of ``|θ₀|`` (default 0.5);
            must contain the true inertia.
        error: ``"trace"`` (default), ``"large_angle"`` or ``"log"``; G: trace weight.
        phi0: initial disturbance coefficients ``(3(1+2K),)`` (default zeros).

    ``diagnostics()``: ``Psi`` ``(B,)``, ``e_R``, ``e_Omega``, ``s``, ``d_hat`` (``Φφ̂``)
    ``(B, 3)``, ``theta_hat`` ``(B, 6)``, ``J_hat`` ``(B, 3, 3)``, ``phi_hat`` ``(B, m)``,
    ``theta_projected`` and ``phi_projected`` ``(B,)`` (the last update was projected).
    """

    batched = True

    def __init__(
        self,
        J: object,
        k_R: float,
        k_s: object,
        c: float,
        gamma_theta: float,
        gamma_phi: float,
        *,
        frequencies: object = (),
        disturbance_bound: float,
        inertia_bound: float = 0.5,
        error: str = "trace",
        G: object = None,
        phi0: object = None,
    ) -> None:
        J = check_inertia_3x3(J, "J")
        self.J = J.copy()
        self.J.setflags(write=False)
        self.k_R = check_positive_scalar(k_R, "k_R")
        self.k_s = check_gain(k_s, "k_s")
        self.c = check_positive_scalar(c, "c")
        self.gamma_theta = check_positive_scalar(gamma_theta, "gamma_theta")
        self.gamma_phi = check_positive_scalar(gamma_phi, "gamma_phi")
        if isinstance(frequencies, (tuple, list)) and len(frequencies) == 0:
            frequencies = np.zeros(0)
        self.frequencies = _check_frequencies(frequencies)
        self.disturbance_bound = check_positive_scalar(disturbance_bound, "disturbance_bound")
        self.inertia_bound = check_positive_scalar(inertia_bound, "inertia_bound")
        self.error = _check_kind(error, "error")
        self.G = _check_G(G, self.error)
        self.theta0 = inertia_parameters(self.J)
        self.theta0.setflags(write=False)
        self.inertia_radius = self.inertia_bound * float(np.linalg.norm(self.theta0))
        if not math.isfinite(self.inertia_radius):
            raise ValueError(
                "J: the inertia ball's radius inertia_bound·|θ₀| overflows float64 (J too large)"
            )
        m = 3 * (1 + 2 * self.frequencies.size)
        if phi0 is None:
            p0 = np.zeros(m)
        else:
            p0 = as_array(phi0, "phi0").copy()
            if p0.shape != (m,):
                raise ValueError(
                    f"phi0: expected shape ({m},) (3 constant + 6 per frequency), got {p0.shape}"
                )
            if np.linalg.norm(p0) > self.disturbance_bound:
                raise ValueError(
                    f"phi0: |phi0| = {np.linalg.norm(p0):.3g} lies outside disturbance_bound = "
                    f"{self.disturbance_bound:.3g}"
                )
        p0.setflags(write=False)
        self.phi0 = p0
        self._batch: int | None = None
        self._diag: dict[str, np.ndarray] = {}

    def __repr__(self) -> str:
        return (
            f"AdaptiveGeometricSO3(error={self.error!r}, k_R={self.k_R!r}, k_s={self.k_s!r}, "
            f"c={self.c!r}, gamma_theta={self.gamma_theta!r}, gamma_phi={self.gamma_phi!r}, "
            f"frequencies={self.frequencies.tolist()})"
        )

    @property
    def n_disturbance_parameters(self) -> int:
        """Length ``m = 3(1+2K)`` of ``φ``."""
        return self.phi0.size

    def reset(self, t0: float, batch_size: int) -> None:
        """Start every spacecraft's estimates from ``θ₀`` (the nominal ``J``) and ``phi0``."""
        if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)):
            raise ValueError(f"batch_size: expected a positive int, got {batch_size!r}")
        if batch_size < 1:
            raise ValueError(f"batch_size: must be >= 1, got {batch_size}")
        as_scalar(t0, "t0")
        B = int(batch_size)
        self._batch = B
        self._t_prev: float | None = None
        self.theta_hat = np.tile(self.theta0, (B, 1))
        self.phi_hat = np.tile(self.phi0, (B, 1))
        self._rate_theta = np.zeros((B, 6))
        self._rate_phi = np.zeros((B, self.phi0.size))
        self._diag = {}

    def _reference(self, reference: AttitudeReference, B: int) -> tuple[np.ndarray, ...]:
        R_d = reference.R_d
        if not (isinstance(R_d, np.ndarray) and R_d.ndim in (2, 3) and rotations_pass_fast(R_d)):
            R_d = check_rotation_matrix(R_d, "R_d")
        w_d = _vec3(reference.omega_d, "omega_d")
        dw_d = _vec3(reference.omega_dot_d, "omega_dot_d")
        out = []
        for name, a, nd in (("R_d", R_d, 2), ("omega_d", w_d, 1), ("omega_dot_d", dw_d, 1)):
            if a.ndim > nd + 1 or (a.ndim == nd + 1 and a.shape[0] != B):
                raise ValueError(f"{name}: expected one sample or a batch of {B}, got {a.shape}")
            out.append(a)  # one sample broadcasts against the batch in the products below
        return tuple(out)

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m]; advances the estimates to ``t`` first (ZOH, Euler)."""
        if self._batch is None:
            raise RuntimeError("AdaptiveGeometricSO3.command: call reset(t0, batch_size) first")
        t = as_scalar(t, "t")
        R, w = state.R, state.omega
        if not (isinstance(R, np.ndarray) and rotations_pass_fast(R)):
            R = check_rotation_matrix(R, "R")
        w = _vec3(w, "omega")
        B = check_state_batch(R, w, self._batch)
        R_d, w_d, dw_d = self._reference(reference, B)

        # estimator step over [t_prev, t] with the rates held from the previous sample
        th_proj = np.zeros(B, dtype=bool)
        ph_proj = np.zeros(B, dtype=bool)
        if self._t_prev is not None:
            dt = t - self._t_prev
            if dt < 0.0:
                raise ValueError(
                    f"t: {t!r} is earlier than the previous control sample {self._t_prev!r}"
                )
            self.theta_hat, self.phi_hat, th_proj, ph_proj = adaptive_estimates_step(
                self.theta_hat, self._rate_theta, self.phi_hat, self._rate_phi, dt,
                self.theta0, self.inertia_radius, self.disturbance_bound,
            )  # fmt: skip
        self._t_prev = t

        Rt = np.swapaxes(R_d, -1, -2) @ R  # R̃ = R_dᵀR
        M, self._rate_theta, self._rate_phi, diag = adaptive_torque(
            Rt, w, w_d, dw_d, self.theta_hat, self.phi_hat, t, self.k_R, self.k_s, self.c,
            self.gamma_theta, self.gamma_phi, self.frequencies, self.error, self.G,
        )  # fmt: skip
        if diag["e_Omega"] is w:
            diag["e_Omega"] = w.copy()  # regulation: e_Ω = ω, not the caller's array
        self._diag = {
            **diag,
            # the estimates are replaced, never updated in place, so no copies are needed
            "theta_hat": self.theta_hat,
            "phi_hat": self.phi_hat,
            "theta_projected": th_proj,
            "phi_projected": ph_proj,
        }
        return finite_command(M, w)

    def array_law(self) -> ArrayLaw:
        """The law as a pure array function for the differentiable loop
        (:mod:`liecontrol.control.array_law`): :func:`adaptive_estimates_step` and
        :func:`adaptive_torque`, the functions :meth:`command` calls, with the estimator state
        ``(started, t_prev, θ̂, θ̂̇, φ̂, φ̂̇)`` carried from one sample to the next from the reset
        state (``θ₀``, ``phi0``, zero rates). ``k_R`` is the attitude gain, ``k_Omega`` the
        composite-error gain ``k_s``; ``c``, ``gamma_theta`` and ``gamma_phi`` are further
        parameters (:attr:`ArrayLaw.params`); timed (the harmonic regressor reads the clock).
        ``ValueError`` naming ``controller.error`` for the log error (its ``E = J_r(e_R)⁻¹`` has
        no array form)."""
        if self.error == "log":
            raise ValueError(
                "controller.error: the array law supports 'trace' and 'large_angle' (the log "
                "error's E = J_r(e_R)⁻¹ has no array form), got 'log'"
            )
        theta0, radius, bound = np.array(self.theta0), self.inertia_radius, self.disturbance_bound
        nu, error = np.array(self.frequencies), self.error
        G = None if self.G is None else np.array(self.G)

        def step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T, *, params, t):  # noqa: ANN001
            started, t_prev, theta, rate_th, phi, rate_ph = state
            xp = namespace(R, theta, t)
            # the first sample has no previous one: no step (the rates start at zero)
            dt = xp.where(started, t - t_prev, 0.0)
            theta, phi, th_proj, ph_proj = adaptive_estimates_step(
                theta, rate_th, phi, rate_ph, dt, theta0, radius, bound
            )
            Rt = xp.swapaxes(R_d, -1, -2) @ R
            M, rate_th, rate_ph, d = adaptive_torque(
                Rt, omega, omega_d, omega_dot_d, theta, phi, t, k_R, k_Omega, params["c"],
                params["gamma_theta"], params["gamma_phi"], nu, error, G,
            )  # fmt: skip
            d = {**d, "theta_hat": theta, "phi_hat": phi, "J_hat": _J_matrix(theta)}
            d["theta_projected"] = th_proj & started
            d["phi_projected"] = ph_proj & started
            t_now = xp.asarray(t, dtype=t_prev.dtype)
            state = (xp.logical_or(started, True), t_now, theta, rate_th, phi, rate_ph)
            return M, state, d

        m = self.phi0.size
        state0 = (np.array(False), np.array(0.0), theta0, np.zeros(6), np.array(self.phi0),
                  np.zeros(m))  # fmt: skip
        params = {"c": self.c, "gamma_theta": self.gamma_theta, "gamma_phi": self.gamma_phi}
        return ArrayLaw(self.k_R, self.k_s, state0, step, params=params, timed=True)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.adaptive.adaptive_law`) for the
        simulator's fused loop (:mod:`liecontrol.control.kernel`), carrying the estimates."""
        if self._batch is None:
            return None
        B = int(batch_size)
        G = np.zeros((3, 3)) if self.G is None else np.asarray(self.G, dtype=np.float64)
        nu = self.frequencies
        params = np.concatenate(
            [
                [float(ERROR_CODES[self.error])],
                np.ascontiguousarray(self.J, dtype=np.float64).ravel(),
                np.zeros(18),
                G.ravel(),
                _as_matrix(self.k_s).ravel(),
                [self.k_R, self.c, self.gamma_theta, self.gamma_phi],
                self.theta0,
                [self.inertia_radius, self.disturbance_bound, float(nu.size)],
                nu,
            ]
        )
        m = self.phi0.size
        state = np.zeros((B, AD_STATE + 2 * m))
        if self._t_prev is not None:
            state[:, 0] = 1.0
            state[:, 1] = self._t_prev
        state[:, 2:8] = self.theta_hat
        state[:, 8:14] = self._rate_theta
        state[:, 14 : 14 + m] = self.phi_hat
        state[:, 14 + m :] = self._rate_phi

        def rows(r: np.ndarray) -> dict[str, np.ndarray]:
            return _adaptive_rows(r, m)

        return ControllerKernel(adaptive_law, params, state, AD_DIAG + m + 2, rows, self._finish)

    def _kernel_reason(self) -> str:
        return "a controller that was not reset"

    def _finish(self, state: np.ndarray, diag: np.ndarray) -> None:
        """Estimates, their rates and diagnostics after a compiled run."""
        m = self.phi0.size
        self._t_prev = float(state[0, 1]) if state[0, 0] != 0.0 else None
        self.theta_hat = state[:, 2:8].copy()
        self._rate_theta = state[:, 8:14].copy()
        self.phi_hat = state[:, 14 : 14 + m].copy()
        self._rate_phi = state[:, 14 + m :].copy()
        d = _adaptive_rows(diag, m)
        d.pop("J_hat")
        self._diag = d

    def diagnostics(self) -> dict[str, np.ndarray]:
        """The last sample's errors and estimates (class docstring); empty before a command."""
        out = dict(self._diag)
        if out:
            out["J_hat"] = _J_matrix(out["theta_hat"])
        return out

    def lyapunov(self, J_true: object, phi_true: object) -> np.ndarray:
        """``V`` ``(B,)`` of the module docstring at the last command, for a plant with inertia
        ``J_true`` and disturbance coefficients ``phi_true`` (``(m,)`` or ``(B, m)``) — an
        analysis tool: the controller itself never knows them."""
        if not self._diag:
            raise RuntimeError("AdaptiveGeometricSO3.lyapunov: no command since reset")
        J = check_inertia_3x3(J_true, "J_true")
        phi = as_array(phi_true, "phi_true")
        m = self.phi0.size
        if phi.shape not in ((m,), (self._batch, m)):
            raise ValueError(
                f"phi_true: expected shape ({m},) or ({self._batch}, {m}), got {phi.shape}"
            )
        d = self._diag
        s = d["s"]
        dth = d["theta_hat"] - inertia_parameters(J)
        dph = d["phi_hat"] - phi
        return (
            0.5 * np.einsum("bi,ij,bj->b", s, J, s)
            + self.k_R / DERIVATIVE_FACTOR[self.error] * d["Psi"]
            + 0.5 * np.einsum("bi,bi->b", dth, dth) / self.gamma_theta
            + 0.5 * np.einsum("bi,bi->b", dph, dph) / self.gamma_phi
        )
