"""Active disturbance rejection control (ADRC) on MRP with a composite-measurement ESO
(Wu, Huang, Wei & Guo, "Active disturbance rejection control of attitude
for spacecraft", Control Theory & Applications, Beihang University).

Model (the paper's eqs. (4)–(5)): p = MRP of the body relative to the base frame (the orbit frame
in the paper), x₁ = p, x₂ = ṗ, x₃ = f (the total disturbance: model error, gyroscopic and frame
terms, external torques), so

    ẋ₁ = x₂,   ẋ₂ = x₃ + B τ,   ẋ₃ = a,   B = G(p) J⁻¹,

with τ the commanded body torque. (The paper's τ = −ḣ is the CMG torque and f contains
−ω × (Jω + h); our plants take the internal torque u = −ḣ − ω × h as the command, so here τ = u
and f contains −ω × Jω instead — the same ESO, a different but equally unknown f.)

Measurements (eqs. (6)–(9)): y_p = p + n_p, y_ω = ω + n_ω, and the rate-derived MRP derivative
G(y_p)(y_ω − C_bo ω_io) — supplied by :class:`~liecontrol.control.adapters.MrpChartAdapter` as
``s.y`` and ``s.y_dot`` (with ``s.y_dot = G(y_p)(y_ω − C_bo ω_io)`` exactly).

Composite ESO (eqs. (10)–(11)), per axis with diagonal gains:

    e = α(y_p − z₁) + β[G(y_p)(y_ω − C_bo ω_io) − z₂],
    ż₁ = z₂ + K₁ e,   ż₂ = z₃ + K₂ e + B τ,   ż₃ = K₃ e.

Error dynamics (eq. (13)) ė = F e + (0, 0, a), F = [[−K₁α, 1 − K₁β, 0], [−K₂α, −K₂β, 1],
[−K₃α, −K₃β, 0]], characteristic polynomial (eq. (16))

    s³ + (K₁α + K₂β) s² + (K₂α + K₃β) s + K₃α,

and the pole-placement tuner (eqs. (17)–(18)) :func:`eso_gains_from_poles`. β = 0 is the
attitude-sensor-only ESO the paper compares against.

Linear tracking differentiator (eq. (19)): v̇₁ = v₂, v̇₂ = −2r v₂ − r²(v₁ − p_d).
Attitude feedback controller (eq. (20)): τ₀ = k₁(v₁ − z₁) + k₂(v₂ − z₂), τ = B⁻¹(τ₀ − z₃),
B⁻¹ = J G(y_p)⁻¹ (G⁻¹ = 16 Gᵀ/(1 + pᵀp)², :func:`liecontrol.charts.mrp.kinematics_matrix_inv`).

Discretisation (*ours*; the paper simulates in continuous time with Simulink): the ESO and the TD
are linear, so between two control samples t_{k−1} → t_k they are propagated **exactly**
(matrix exponential of the augmented per-axis system, cached per step length — by scaling and
squaring of its Taylor series, a pure formula that JAX runs too, with the observer's gains as
differentiable parameters: :meth:`MrpADRCLaw.array_law`) with the input
B τ_{k−1} that the plant really held over the interval (zero-order hold) and the measurements
(and p_d) interpolated linearly between their samples at t_{k−1} and t_k (first-order hold —
a zero-order hold of the newest sample biases z₃ by O(h) while the attitude moves).
Any sampling period therefore keeps the ESO's discrete poles at exp(λ_i h) — stable for every h.
The paper does not say how the ESO starts: by default z(0) = (y_p(0), rate-derived ṗ(0) if
β > 0 else 0, 0) (``eso_init="measured"``), or z(0) = 0 (``"zero"``, used by the ADRC
reproduction, where p(0) = ṗ(0) = 0 and both coincide without noise). The TD starts at
v = (y_p(0), 0), so it arranges a smooth transition from the initial attitude to p_d.

Shadow set: :class:`MrpADRC` wraps the law in an
:class:`~liecontrol.control.adapters.MrpChartAdapter`; when the measured MRP switches to its
shadow the ESO states (z₁, z₂, z₃) and the held B τ are mapped with
:func:`~liecontrol.control.adapters.mrp_shadow_map` (z₃ maps like p̈, see there); when p_d
switches, the TD states (v₁, v₂). The law regulates p − p_d in ℝ³ (not a geodesic error), so
large manoeuvres are better posed with ``base="reference"`` (p is then the attitude error).

Paper parameters (:data:`PAPER`): K₁ = diag(20), K₂ = diag(100), K₃ = diag(800), k₁ = 0.3,
k₂ = 10, r = 0.02, α = 1, β = 0.5 (β = 0 for the comparison ESO).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._array_api import namespace
from .._kernels.adrc import N_DIAG as ADRC_DIAG
from .._kernels.adrc import N_STATE as ADRC_STATE
from .._kernels.adrc import mrp_adrc_law
from .._validation import (
    as_array,
    as_scalar,
    check_inertia_3x3,
    check_nonnegative,
    check_positive,
    check_positive_scalar,
)
from ..charts import mrp as _mrp
from .adapters import ChartArrayLaw, ChartState, MrpChartAdapter, mrp_shadow_map_unchecked
from .kernel import ControllerKernel

__all__ = [
    "ADRCParams",
    "PAPER",
    "MrpADRCLaw",
    "MrpADRC",
    "eso_error_matrix",
    "eso_characteristic_polynomial",
    "eso_gains_from_poles",
    "eso_poles",
]


def _gain3(k: object, name: str) -> np.ndarray:
    """A positive scalar or positive length-3 vector (the diagonal) → ``(3,)``."""
    a = as_array(k, name)
    if a.shape not in ((), (3,)):
        raise ValueError(f"{name}: expected a scalar or a length-3 diagonal, got shape {a.shape}")
    check_positive(a, name)
    return np.broadcast_to(a, (3,)).astype(np.float64).copy()


def _alpha_beta(alpha: object, beta: object) -> tuple[float, float]:
    a = check_nonnegative(as_scalar(alpha, "alpha"), "alpha")
    b = check_nonnegative(as_scalar(beta, "beta"), "beta")
    if a == 0.0 and b == 0.0:
        raise ValueError("alpha: alpha = beta = 0 leaves the ESO without any measurement")
    if a == 0.0:
        raise ValueError(
            "alpha: must be > 0 (alpha = 0 never corrects the attitude estimate: the ESO has a "
            "pole at s = 0)"
        )
    return float(a), float(b)


def eso_error_matrix(K1: object, K2: object, K3: object, alpha: float, beta: float) -> np.ndarray:
    """Per-axis error-dynamics matrix F of the paper's eq. (13)/(15), ``(3 axes, 3, 3)``:
    F = [[−K₁α, 1 − K₁β, 0], [−K₂α, −K₂β, 1], [−K₃α, −K₃β, 0]]."""
    k1, k2, k3 = _gain3(K1, "K1"), _gain3(K2, "K2"), _gain3(K3, "K3")
    a, b = _alpha_beta(alpha, beta)
    return _eso_blocks(k1, k2, k3, a, b)[0]


def _eso_blocks(K1: Any, K2: Any, K3: Any, alpha: float, beta: float) -> tuple[Any, Any]:
    """``(F, K)``: the per-axis error matrix F ``(3 axes, 3, 3)`` of :func:`eso_error_matrix`
    and the observer's gain column K = (K₁, K₂, K₃) ``(3 axes, 3, 1)``, from gains that are
    scalars or ``(3,)`` diagonals; pure (NumPy or JAX: the gains may be traced)."""
    xp = namespace(K1, K2, K3)
    k1, k2, k3 = (xp.broadcast_to(xp.asarray(k, dtype=np.float64), (3,)) for k in (K1, K2, K3))
    zero, one = xp.zeros(3), xp.ones(3)
    F = xp.stack(
        (
            xp.stack((-k1 * alpha, 1.0 - k1 * beta, zero), axis=-1),
            xp.stack((-k2 * alpha, -k2 * beta, one), axis=-1),
            xp.stack((-k3 * alpha, -k3 * beta, zero), axis=-1),
        ),
        axis=-2,
    )
    return F, xp.stack((k1, k2, k3), axis=-1)[..., None]


def _td_blocks(r: Any) -> tuple[Any, Any]:
    """``(A, B)`` of the linear tracking differentiator v̇₁ = v₂, v̇₂ = −2r v₂ − r²(v₁ − p_d)
    (input p_d); pure, ``r`` may be traced."""
    xp = namespace(r)
    r = xp.asarray(r, dtype=np.float64)
    zero, one = xp.zeros(()), xp.ones(())
    A = xp.stack((xp.stack((zero, one)), xp.stack((-r * r, -2.0 * r))))
    return A, xp.stack((zero, r * r))[:, None]


def eso_characteristic_polynomial(
    K1: object, K2: object, K3: object, alpha: float, beta: float
) -> np.ndarray:
    """Coefficients (highest power first) of s³ + (K₁α + K₂β)s² + (K₂α + K₃β)s + K₃α per axis
    (the paper's eq. (16)), ``(3 axes, 4)``."""
    k1, k2, k3 = _gain3(K1, "K1"), _gain3(K2, "K2"), _gain3(K3, "K3")
    a, b = _alpha_beta(alpha, beta)
    return np.stack((np.ones(3), k1 * a + k2 * b, k2 * a + k3 * b, k3 * a), axis=-1)


def eso_poles(K1: object, K2: object, K3: object, alpha: float, beta: float) -> np.ndarray:
    """Roots of :func:`eso_characteristic_polynomial`, ``(3 axes, 3)`` complex."""
    c = eso_characteristic_polynomial(K1, K2, K3, alpha, beta)
    return np.stack([np.roots(ci) for ci in c])


def eso_gains_from_poles(
    poles: object, alpha: float, beta: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ESO gains placing the per-axis poles (the paper's eqs. (17)–(18)).

    With the desired poles s = −λ₁, −λ₂, −λ₃ (``poles``: shape ``(3,)`` for the same poles on
    every axis or ``(3 axes, 3)``; real, or complex in conjugate pairs, all with negative real
    part) and c₂ = λ₁ + λ₂ + λ₃, c₁ = λ₁λ₂ + λ₁λ₃ + λ₂λ₃, c₀ = λ₁λ₂λ₃ (the coefficients of
    (s + λ₁)(s + λ₂)(s + λ₃)), the triangular system

        c₂ = K₁α + K₂β,   c₁ = K₂α + K₃β,   c₀ = K₃α

    gives K₃ = c₀/α, K₂ = (c₁ − βK₃)/α, K₁ = (c₂ − βK₂)/α. Returns ``(K1, K2, K3)``, each the
    ``(3,)`` diagonal. Raises ``ValueError`` (naming ``poles``) for poles with non-negative real
    parts, unpaired complex poles, or poles that would need a non-positive gain for this α, β
    (the paper requires positive-definite gains).
    """
    a, b = _alpha_beta(alpha, beta)
    try:
        P = np.asarray(poles, dtype=np.complex128)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"poles: cannot be converted to a complex array ({exc})") from None
    if P.shape == (3,):
        P = np.broadcast_to(P, (3, 3))
    if P.shape != (3, 3):
        raise ValueError(f"poles: expected shape (3,) or (3, 3), got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ValueError("poles: contains non-finite values")
    if np.any(P.real >= 0.0):
        raise ValueError(
            f"poles: every pole needs a negative real part, got max Re = {P.real.max():.3g}"
        )
    coeffs = np.stack([np.poly(p) for p in P])
    if np.any(np.abs(coeffs.imag) > 1e-9 * np.abs(coeffs).max()):
        raise ValueError("poles: complex poles must come in conjugate pairs")
    c = coeffs.real
    c2, c1, c0 = c[:, 1], c[:, 2], c[:, 3]
    K3 = c0 / a
    K2 = (c1 - b * K3) / a
    K1 = (c2 - b * K2) / a
    for name, K in (("K1", K1), ("K2", K2), ("K3", K3)):
        if np.any(K <= 0.0):
            raise ValueError(
                f"poles: these poles need {name} = {K.min():.4g} <= 0 with alpha = {a}, "
                f"beta = {b}; choose a smaller beta or other poles"
            )
    return K1, K2, K3


@dataclass(frozen=True)
class ADRCParams:
    """ADRC parameters. Gains are positive scalars or length-3 diagonals.

    Attributes:
        K1, K2, K3: ESO gains (diagonal).  k1, k2: AFC gains [1/s², 1/s].
        r: TD rate [1/s].  alpha, beta: composite-error weights (α > 0, β ≥ 0).
    """

    K1: Any = 20.0
    K2: Any = 100.0
    K3: Any = 800.0
    k1: Any = 0.3
    k2: Any = 10.0
    r: float = 0.02
    alpha: float = 1.0
    beta: float = 0.5

    def __post_init__(self) -> None:
        for name in ("K1", "K2", "K3", "k1", "k2"):
            v = _gain3(getattr(self, name), name)
            v.setflags(write=False)
            object.__setattr__(self, name, v)
        object.__setattr__(self, "r", check_positive_scalar(self.r, "r"))
        a, b = _alpha_beta(self.alpha, self.beta)
        object.__setattr__(self, "alpha", a)
        object.__setattr__(self, "beta", b)


#: Wu et al.'s parameters (composite ESO, β = 0.5).
PAPER = ADRCParams()


#: Taylor order of :func:`_expm` and the 1-norm its scaled argument is brought under: the
#: truncation error is below ‖X‖¹⁹/19! ≈ 5e-35 at ‖X‖ = 1/8.
_EXPM_ORDER = 18
_EXPM_THETA = 0.125
#: the array law's room for squarings beyond those of its nominal gains: gains tuned up to
#: 2⁶ = 64× their size keep the scaled norm under 1/8 (beyond, under 1 up to 512×: truncation
#: below 8e-18)
_ARRAY_SQUARINGS = 6


def _squarings(norm: float) -> int:
    """The number s of squarings that brings the 1-norm ``norm`` under :data:`_EXPM_THETA`."""
    return math.ceil(math.log2(norm / _EXPM_THETA)) if norm > _EXPM_THETA else 0


def _expm(A: Any, squarings: Any, max_squarings: int | None = None) -> Any:
    """exp(A) of ``(..., n, n)`` matrices by scaling and squaring of the Taylor series (Moler &
    Van Loan, "Nineteen dubious ways to compute the exponential of a matrix, twenty-five years
    later", SIAM Review 45(1), 2003, §3: methods 1 and 3): X = A/2ˢ, E = Σₖ≤₁₈ Xᵏ/k! by Horner's
    rule, then E ← E² s times. Pure (matrix products only): the same source runs on NumPy and on
    JAX, where ``A`` may depend on traced gains; there ``squarings`` may be traced too, at most
    the static ``max_squarings`` (each further product is selected with ``where``)."""
    X = A / 2.0**squarings
    eye = np.eye(A.shape[-1])
    E = eye
    for k in range(_EXPM_ORDER, 0, -1):
        E = eye + (X @ E) / float(k)
    if max_squarings is None:
        for _ in range(squarings):
            E = E @ E
        return E
    xp = namespace(A, squarings)
    for k in range(max_squarings):
        E = xp.where(k < squarings, E @ E, E)
    return E


def _hold_augmented(A: Any, B_foh: Any, B_zoh: Any) -> Any:
    """[[A, B_f, 0, B_z], [0, 0, I, 0], [0, 0, 0, 0], [0, 0, 0, 0]] (leading axes broadcast)."""
    xp = namespace(A, B_foh, B_zoh)
    n, p, q = A.shape[-1], B_foh.shape[-1], B_zoh.shape[-1]
    lead = A.shape[:-2]

    def zeros(r: int, c: int) -> Any:
        return xp.zeros(lead + (r, c))

    B_f, B_z = xp.broadcast_to(B_foh, lead + (n, p)), xp.broadcast_to(B_zoh, lead + (n, q))
    top = xp.concatenate((A, B_f, zeros(n, p), B_z), axis=-1)
    mid = xp.concatenate(
        (zeros(p, n + p), xp.broadcast_to(np.eye(p), lead + (p, p)), zeros(p, q)), axis=-1
    )
    return xp.concatenate((top, mid, zeros(p + q, n + 2 * p + q)), axis=-2)


def _hold_squarings(A: Any, B_foh: Any, B_zoh: Any, h: float) -> int:
    """The squarings :func:`_expm` needs for :func:`_hold_discretise` at concrete values."""
    M = np.asarray(_hold_augmented(A, B_foh, B_zoh)) * h
    return _squarings(float(np.abs(M).sum(axis=-2).max()))


def _hold_discretise(
    A: Any, B_foh: Any, B_zoh: Any, h: float, max_squarings: int | None = None
) -> tuple[Any, Any, Any, Any]:
    """Exact discretisation of ẋ = A x + B_f u(t) + B_z w over one step h, with u linear in t
    (first-order hold between u_{k−1} and u_k) and w constant (zero-order hold):

        x_k = Φ x_{k−1} + Γ₀ u_{k−1} + Γ₁ (u_k − u_{k−1})/h + Γ_z w,

    all blocks of exp(h·[[A, B_f, 0, B_z], [0, 0, I, 0], [0, 0, 0, 0], [0, 0, 0, 0]])
    (Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, §6.3: triangle hold),
    by :func:`_expm` with the squarings that bring the matrix's 1-norm under 1/8. Leading axes
    of A and the B's broadcast (one block per ESO axis). Pure: NumPy, or JAX with traced gains,
    where the number of squarings is computed from the traced norm and capped at the static
    ``max_squarings`` (required there)."""
    n, p = A.shape[-1], B_foh.shape[-1]
    M = _hold_augmented(A, B_foh, B_zoh) * h
    xp = namespace(M)
    if xp is np:
        E = _expm(M, _squarings(float(np.abs(M).sum(axis=-2).max())))
    else:
        norm = xp.max(xp.sum(xp.abs(M), axis=-2))
        big = norm > _EXPM_THETA
        s = xp.where(big, xp.ceil(xp.log2(xp.where(big, norm, 1.0) / _EXPM_THETA)), 0.0)
        E = _expm(M, xp.minimum(s, float(max_squarings)), max_squarings)
    return (
        E[..., :n, :n],
        E[..., :n, n : n + p],
        E[..., :n, n + p : n + 2 * p],
        E[..., :n, n + 2 * p :],
    )


_E2 = np.broadcast_to(np.array([[0.0], [1.0], [0.0]]), (3, 3, 1))


def _discrete_matrices(
    F: Any, K: Any, A_td: Any, B_td: Any, h: float, max_squarings: tuple[int, int] | None = None
) -> tuple[Any, ...]:
    """``(Φ, Γ₀, Γ₁/h, Γ_z, Φ_td, T₀, T₁/h)`` of the observer (measurement through K under a
    first-order hold, B τ into ż₂ under a zero-order hold) and of the differentiator over a
    step h; pure (:func:`_hold_discretise`; ``max_squarings`` for traced gains)."""
    s_eso, s_td = (None, None) if max_squarings is None else max_squarings
    Phi, G0, G1, Gz = _hold_discretise(F, K, _E2, h, s_eso)
    Phi_td, T0, T1, _ = _hold_discretise(A_td, B_td, np.zeros((2, 1)), h, s_td)
    return Phi, G0[..., 0], G1[..., 0] / h, Gz[..., 0], Phi_td, T0[:, 0], T1[:, 0] / h


# ------------------------------------------------------------------ the law's pure updates
# One source for the NumPy route (batched, state held by MrpADRCLaw) and the array law (one
# spacecraft, state carried by the scan).


def _adrc_first(y_p: Any, y_v: Any, z: Any, measured: bool, beta: float) -> tuple[Any, Any]:
    """``(z, v)`` at the first sample: v = (y_p, 0); z₁ = y_p, z₂ = ẏ (β > 0) or 0 with the
    measured start, z kept with the zero start."""
    xp = namespace(y_p, y_v, z)
    v = xp.stack((y_p, xp.zeros(y_p.shape)), axis=-1)
    if measured:
        z2 = y_v if beta > 0.0 else xp.zeros(y_p.shape)
        z = xp.stack((y_p, z2, z[..., 2]), axis=-1)
    return z, v


def _adrc_propagate(
    z: Any, v: Any, bu: Any, prev: tuple, meas: Any, p_d: Any, disc: tuple, alpha: float,
    beta: float,
) -> tuple[Any, Any]:  # fmt: skip
    """The observer and the differentiator over one control period (their exact hold
    discretisation ``disc``, :func:`_discrete_matrices`), from the previous sample's held
    measurements ``prev = (y_p, ẏ, p_d)``."""
    Phi, G0, G1, Gz, Phi_td, T0, T1 = disc
    y0, yd0, pd0 = prev
    m0 = alpha * y0 + beta * yd0
    z = (
        (Phi @ z[..., None])[..., 0]
        + G0 * m0[..., None]
        + G1 * (meas - m0)[..., None]
        + Gz * bu[..., None]
    )
    v = (Phi_td @ v[..., None])[..., 0] + T0 * pd0[..., None] + T1 * (p_d - pd0)[..., None]
    return z, v


def _adrc_output(
    z: Any, v: Any, y_p: Any, y_v: Any, k1: Any, k2: Any, alpha: float, beta: float, J: Any,
    J_inv: Any,
) -> tuple[Any, Any, dict[str, Any]]:  # fmt: skip
    """``(τ, B τ, diagnostics)``: τ₀ = k₁(v₁ − z₁) + k₂(v₂ − z₂), τ = J G(y_p)⁻¹(τ₀ − z₃) and
    the held B τ = G(y_p) J⁻¹ τ."""
    z1, z2, z3 = z[..., 0], z[..., 1], z[..., 2]
    v1, v2 = v[..., 0], v[..., 1]
    tau0 = k1 * (v1 - z1) + k2 * (v2 - z2)
    Ginv = _mrp._kinematics_matrix_inv_unchecked(y_p)
    tau = (Ginv @ (tau0 - z3)[..., None])[..., 0] @ J.T
    G = _mrp._kinematics_matrix_unchecked(y_p)
    bu = (G @ (tau @ J_inv.T)[..., None])[..., 0]
    e = alpha * (y_p - z1) + beta * (y_v - z2)
    diag = {"z1": z1, "z2": z2, "z3": z3, "v1": v1, "v2": v2, "tau0": tau0, "eso_error": e}
    return tau, bu, diag


def _adrc_shadow_switch(
    z: Any, v: Any, bu: Any, prev: tuple, has_t: Any, switched: Any, switched_d: Any
) -> tuple[Any, Any, Any, tuple]:
    """The observer's states and the held B τ (and the held measurements, after the first
    sample) mapped to the shadow set where the measured MRP ``switched``; the differentiator's
    states and the held p_d where p_d did (:func:`~liecontrol.control.adapters.mrp_shadow_map`:
    z₃ maps like p̈). A zero MRP state is left as it is (its shadow is at infinity). Pure: the
    maps are evaluated everywhere (on a stand-in where they do not apply) and selected."""
    xp = namespace(z, v, bu)
    one = np.ones(3)

    def mapped(p: Any, ok: Any) -> Any:
        return xp.where(ok[..., None], p, one)  # a finite stand-in where not ok

    z1, z2, z3 = z[..., 0], z[..., 1], z[..., 2]
    ok = switched & (xp.sum(z1 * z1, axis=-1) > 0.0)
    s1, s2, s3, D = mrp_shadow_map_unchecked(mapped(z1, ok), z2, z3)
    z = xp.where(ok[..., None, None], xp.stack((s1, s2, s3), axis=-1), z)
    bu = xp.where(ok[..., None], (D @ bu[..., None])[..., 0], bu)
    y0, yd0, pd0 = prev
    ok = switched & has_t & (xp.sum(y0 * y0, axis=-1) > 0.0)
    s1, s2, _, _ = mrp_shadow_map_unchecked(mapped(y0, ok), yd0)
    y0, yd0 = xp.where(ok[..., None], s1, y0), xp.where(ok[..., None], s2, yd0)
    v1, v2 = v[..., 0], v[..., 1]
    ok = switched_d & (xp.sum(v1 * v1, axis=-1) > 0.0)
    s1, s2, _, _ = mrp_shadow_map_unchecked(mapped(v1, ok), v2)
    v = xp.where(ok[..., None, None], xp.stack((s1, s2), axis=-1), v)
    ok = switched_d & has_t & (xp.sum(pd0 * pd0, axis=-1) > 0.0)
    safe = mapped(pd0, ok)
    pd0 = xp.where(ok[..., None], -safe / xp.sum(safe * safe, axis=-1, keepdims=True), pd0)
    return z, v, bu, (y0, yd0, pd0)


class MrpADRCLaw:
    """The ADRC chart law (TD + composite ESO + AFC) on MRP — see the module docstring.

    Wrap it with :class:`~liecontrol.control.adapters.MrpChartAdapter` (or use
    :class:`MrpADRC`). State arrays are ``(B, 3)``; ``batched = True``.

    Args:
        J: 3×3 inertia the controller assumes [kg·m²].
        params: :class:`ADRCParams` (default :data:`PAPER`).
        eso_init: ``"measured"`` (default: z₁(0) = y_p(0), z₂(0) = the rate-derived ṗ
            measurement if β > 0 else 0, z₃(0) = 0) or ``"zero"`` (z(0) = 0; the ESO then needs
            its convergence time before the first torques make sense when p(0) ≠ 0).
    """

    batched = True

    def __init__(self, J: object, params: ADRCParams = PAPER, eso_init: str = "measured") -> None:
        if eso_init not in ("measured", "zero"):
            raise ValueError(f"eso_init: expected 'measured' or 'zero', got {eso_init!r}")
        self.eso_init = eso_init
        J = check_inertia_3x3(J, "J")
        if not isinstance(params, ADRCParams):
            raise ValueError(f"params: expected ADRCParams, got {type(params).__name__}")
        self.J = J.copy()
        self.J.setflags(write=False)
        self.params = params
        P = params
        # inputs: m = α y_p + β ẏ_meas through K (first-order hold), B τ into ż₂ (zero-order)
        self._F, self._K = _eso_blocks(P.K1, P.K2, P.K3, P.alpha, P.beta)
        self._A_td, self._B_td = _td_blocks(P.r)
        self._J_inv = np.linalg.inv(self.J)
        self._cache: dict[float, tuple[np.ndarray, ...]] = {}
        self._t: float | None = None
        self.z: np.ndarray | None = None  # (B, 3 axes, 3): z1, z2, z3 per axis
        self.v: np.ndarray | None = None  # (B, 3 axes, 2): v1, v2
        self._bu: np.ndarray | None = None  # B τ held since the last sample, (B, 3)
        self._prev: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # y_p, ẏ, p_d
        self._diag: dict[str, np.ndarray] = {}

    def __repr__(self) -> str:
        return f"MrpADRCLaw(params={self.params!r})"

    def reset(self, t0: float, batch_size: int) -> None:
        self._t = None
        self.z = np.zeros((batch_size, 3, 3))
        self.v = None
        self._bu = np.zeros((batch_size, 3))
        self._prev = None
        self._diag = {}

    def _discrete(self, h: float) -> tuple[np.ndarray, ...]:
        key = round(h, 12)
        if key not in self._cache:
            if len(self._cache) > 64:  # variable sampling: keep the cache bounded
                self._cache.clear()
            self._cache[key] = _discrete_matrices(self._F, self._K, self._A_td, self._B_td, h)
        return self._cache[key]

    def on_shadow_switch(self, state_mask: np.ndarray, desired_mask: np.ndarray) -> None:
        """Map the ESO states (and the held B τ) where the measured MRP switched to its shadow,
        the TD states where p_d switched (:func:`~liecontrol.control.adapters.mrp_shadow_map`);
        the pure map :func:`_adrc_shadow_switch` (the array law's hook too)."""
        if self.z is None:
            return
        B = self.z.shape[0]
        has_t = self._prev is not None
        prev = self._prev if has_t else (np.zeros((B, 3)),) * 3
        v = self.v if self.v is not None else np.zeros((B, 3, 2))
        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            z, v, bu, prev = _adrc_shadow_switch(
                self.z, v, self._bu, prev, np.bool_(has_t), state_mask, desired_mask
            )
        self.z, self._bu = z, bu
        if self.v is not None:
            self.v = v
        if has_t:
            self._prev = prev

    def __call__(self, t: float, s: ChartState) -> np.ndarray:
        """Body torque ``(B, 3)`` from the chart state (``s.y`` = y_p, ``s.y_dot`` =
        G(y_p)(y_ω − C_bo ω_io), ``s.y_d`` = p_d)."""
        P = self.params
        y_p, y_v, p_d = s.y, s.y_dot, s.y_d
        B = y_p.shape[0]
        if self.z is None or self.z.shape[0] != B:
            raise RuntimeError("MrpADRCLaw: call reset(t0, batch_size) first")
        if self._t is None:
            self.z, self.v = _adrc_first(y_p, y_v, self.z, self.eso_init == "measured", P.beta)
        else:
            h = float(t) - self._t
            if h < 0.0:
                raise ValueError(f"t: {t} is before the previous sample {self._t}")
            if h > 0.0:
                meas = P.alpha * y_p + P.beta * y_v
                self.z, self.v = _adrc_propagate(
                    self.z, self.v, self._bu, self._prev, meas, p_d, self._discrete(h),
                    P.alpha, P.beta,
                )  # fmt: skip
        self._t = float(t)
        self._prev = (y_p.copy(), y_v.copy(), p_d.copy())
        tau, self._bu, diag = _adrc_output(
            self.z, self.v, y_p, y_v, P.k1, P.k2, P.alpha, P.beta, self.J, self._J_inv
        )
        self._diag = {k: np.array(a, copy=True) for k, a in diag.items()}
        return tau

    def array_law(self) -> ChartArrayLaw:
        """The law's pure form (:class:`~liecontrol.control.adapters.ChartArrayLaw`) for the
        differentiable loop: the gains ``(k₁, k₂)`` of the feedback, the observer's gains
        ``K1``, ``K2``, ``K3`` and the differentiator's rate ``r`` as further differentiable
        ``params``; the scan carries (z, v, held B τ, held y_p, ẏ, p_d, first-sample flag), and
        the adapter's shadow switch maps them (:func:`_adrc_shadow_switch`).

        The control period T is static in the scan, so the hold discretisation
        (:func:`_discrete_matrices`) is computed in the step from the (possibly traced) gains by
        the same pure scaling-and-squaring series as the NumPy route (:func:`_expm`), with its
        number of squarings computed from the traced gains as the NumPy route computes it
        (so at the nominal gains the matrices are the NumPy route's), capped at the nominal
        count plus :data:`_ARRAY_SQUARINGS` (gains up to 64× their nominal size). ``eso_init``
        and α, β stay as constructed (not differentiable)."""
        P = self.params
        alpha, beta = P.alpha, P.beta
        measured = self.eso_init == "measured"
        J, J_inv = np.array(self.J), np.array(self._J_inv)
        defaults = {"K1": P.K1.copy(), "K2": P.K2.copy(), "K3": P.K3.copy(), "r": float(P.r)}
        k1 = P.k1 if (P.k1 != P.k1[0]).any() else float(P.k1[0])
        k2 = P.k2 if (P.k2 != P.k2[0]).any() else float(P.k2[0])
        cache: dict[float, tuple[int, int]] = {}

        def squarings(T: float) -> tuple[int, int]:
            if T not in cache:
                cache[T] = (
                    _hold_squarings(self._F, self._K, _E2, T) + _ARRAY_SQUARINGS,
                    _hold_squarings(self._A_td, self._B_td, np.zeros((2, 1)), T) + _ARRAY_SQUARINGS,
                )
            return cache[T]

        def step(k1, k2, state, s, T, params=None):  # noqa: ANN001
            p = defaults if params is None else params
            F, K = _eso_blocks(p["K1"], p["K2"], p["K3"], alpha, beta)
            A_td, B_td = _td_blocks(p["r"])
            disc = _discrete_matrices(F, K, A_td, B_td, T, squarings(float(T)))
            z, v, bu, y0, yd0, pd0, has_t = state
            xp = namespace(s.y, z, *disc)
            y_p, y_v, p_d = s.y, s.y_dot, s.y_d
            meas = alpha * y_p + beta * y_v
            z_first, v_first = _adrc_first(y_p, y_v, z, measured, beta)
            z_next, v_next = _adrc_propagate(z, v, bu, (y0, yd0, pd0), meas, p_d, disc, alpha, beta)
            z = xp.where(has_t, z_next, z_first)
            v = xp.where(has_t, v_next, v_first)
            tau, bu, diag = _adrc_output(z, v, y_p, y_v, k1, k2, alpha, beta, J, J_inv)
            return tau, (z, v, bu, y_p, y_v, p_d, xp.ones_like(has_t)), diag

        def hook(state, switched, switched_d):  # noqa: ANN001
            z, v, bu, y0, yd0, pd0, has_t = state
            z, v, bu, (y0, yd0, pd0) = _adrc_shadow_switch(
                z, v, bu, (y0, yd0, pd0), has_t, switched, switched_d
            )
            return z, v, bu, y0, yd0, pd0, has_t

        state0 = (
            np.zeros((3, 3)), np.zeros((3, 2)), np.zeros(3), np.zeros(3), np.zeros(3),
            np.zeros(3), np.array(False),
        )  # fmt: skip
        return ChartArrayLaw(k1, k2, state0, step, defaults, on_shadow_switch=hook)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last ESO estimates ``z1, z2, z3``, TD outputs ``v1, v2``, ``tau0`` and the composite
        error ``eso_error``, each ``(B, 3)``."""
        return dict(self._diag)


class MrpADRC(MrpChartAdapter):
    """Wu et al.'s ADRC as an SO(3) controller: :class:`MrpADRCLaw` in an
    :class:`~liecontrol.control.adapters.MrpChartAdapter`.

    Args:
        J: 3×3 inertia the controller assumes [kg·m²].
        params: :class:`ADRCParams` (default :data:`PAPER`, the composite ESO with β = 0.5);
            ``ADRCParams(beta=0.0)`` is the attitude-sensor-only ESO.
        base: chart base frame — ``"reference"`` (p = attitude-error MRP, p_d = 0),
            ``"inertial"`` or a callable frame such as the orbit frame
            ``spacecraft.orbit.EarthPointingReference(orbit)`` (Wu, Huang, Wei & Guo).
        threshold: MRP shadow-switch threshold (≥ 1).
        eso_init: ESO initialisation, ``"measured"`` or ``"zero"`` (:class:`MrpADRCLaw`).

    ``diagnostics()`` gives the law's ``z1, z2, z3, v1, v2, tau0, eso_error`` and the adapter's
    ``chart_y`` (= y_p), ``chart_y_d``, ``chart_switched``.
    """

    def __init__(
        self,
        J: object,
        params: ADRCParams = PAPER,
        base: object = "reference",
        threshold: float = 1.0,
        eso_init: str = "measured",
    ) -> None:
        super().__init__(MrpADRCLaw(J, params, eso_init), base=base, threshold=threshold)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.adrc.mrp_adrc_law`) for the simulator's
        fused loop (:mod:`liecontrol.control.kernel`): the desired frame as base, this law,
        the observer discretised once for the run's control period."""
        law = self.law
        if (
            type(law) is not MrpADRCLaw
            or self.base != "reference"
            or control_period is None
            or self._batch is None
            or law.z is None
        ):
            return None
        B = int(batch_size)
        P = law.params
        Phi, G0, G1, Gz, Phi_td, T0, T1 = law._discrete(float(control_period))
        J = np.ascontiguousarray(law.J, dtype=np.float64)
        params = np.concatenate(
            [
                [min(float(self.threshold), 1e150) ** 2],
                J.ravel(),
                np.linalg.inv(J).ravel(),
                [P.alpha, P.beta],
                np.broadcast_to(P.k1, (3,)),
                np.broadcast_to(P.k2, (3,)),
                [1.0 if law.eso_init == "measured" else 0.0],
                *(np.ravel(a) for a in (Phi, G0, G1, Gz, Phi_td, T0, T1)),
                np.zeros(9),
            ]
        )
        state = np.zeros((B, ADRC_STATE))
        if self._p_prev is not None:
            state[:, 0:3] = self._p_prev
            state[:, 3] = 1.0
        if law._t is not None:
            state[:, 5] = 1.0
            state[:, 6] = law._t
            state[:, 25:28], state[:, 28:31], state[:, 31:34] = law._prev
        state[:, 7:16] = law.z.reshape(B, 9)
        if law.v is not None:
            state[:, 16:22] = law.v.reshape(B, 6)
        state[:, 22:25] = law._bu
        return ControllerKernel(mrp_adrc_law, params, state, ADRC_DIAG, _adrc_rows, self._finish)

    def _kernel_reason(self) -> str:
        return "a base other than the reference frame, a swapped law or no control period"

    def _finish(self, state: np.ndarray, diag: np.ndarray) -> None:
        """Chart memory, observer and differentiator states after a compiled run."""
        law = self.law
        B = state.shape[0]
        self._p_prev = state[:, 0:3].copy()
        self._pd_prev = np.zeros((B, 3))
        self.n_switches += int(state[:, 4].sum())
        law._t = float(state[0, 6]) if state[0, 5] != 0.0 else None
        law.z = state[:, 7:16].reshape(B, 3, 3).copy()
        law.v = state[:, 16:22].reshape(B, 3, 2).copy()
        law._bu = state[:, 22:25].copy()
        if law._t is not None:
            law._prev = (
                state[:, 25:28].copy(), state[:, 28:31].copy(), state[:, 31:34].copy()
            )  # fmt: skip
        d = _adrc_rows(diag)
        law._diag = {k: d[k] for k in ("z1", "z2", "z3", "v1", "v2", "tau0", "eso_error")}
        self._diag = d


def _adrc_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """The adapter's diagnostics from the kernel rows ``(..., 25)``."""
    names = ("z1", "z2", "z3", "v1", "v2", "tau0", "eso_error")
    out = {k: rows[..., 3 * i : 3 * i + 3].copy() for i, k in enumerate(names)}
    out.update(
        chart_y=rows[..., 21:24].copy(),
        chart_y_d=np.zeros(rows.shape[:-1] + (3,)),
        chart_switched=rows[..., 24] != 0.0,
    )
    return out
