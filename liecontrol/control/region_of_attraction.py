"""Regions of attraction of the geometric PD controllers (Jiang, Meng & Yang 2023, Lemmas 1–4).

Setting: rigid body ``J Ω̇ + Ω × JΩ = M`` under :class:`~liecontrol.control.GeometricPD` with the
exact inertia and no disturbance, so that the closed loop is ``J ė_Ω = −k_R e_R − K_Ω e_Ω``,
``d/dt R̃ = R̃ e_Ω^``. For a scalar ``k_R`` the function

    V = ½ e_Ωᵀ J e_Ω + (k_R / c) Ψ,     V̇ = −e_Ωᵀ K_Ω e_Ω ≤ 0,

(``c`` = :data:`liecontrol.errors.DERIVATIVE_FACTOR`) is a Lyapunov function. Let ``Ψ*`` be the
smallest value of ``Ψ`` on the undesired critical points / non-smooth set of the error function
(:func:`critical_level`): large-angle ``Ψ* = 2`` (θ = π), log ``Ψ* = π²/2`` (θ = π), trace
``Ψ* = 2(g₁ + g₂)`` (rotation by π about the eigenvector of the largest eigenvalue g₃ of G).
If ``V(0) < (k_R / c) Ψ*`` then ``Ψ(t) ≤ (c / k_R) V(0) < Ψ*`` for all t, and by LaSalle the
state converges to ``R = R_d``, ``e_Ω = 0``. Bounding ``½ e_ΩᵀJe_Ω ≤ ½ λ_max(J) ‖e_Ω‖²`` gives the
sufficient condition in the survey's form

    ‖e_Ω(0)‖² < 2 k_R (Ψ* − Ψ(0)) / (c λ_max(J)),

which for the large-angle error is Lemma 4 exactly and for the log error is Lemma 2 with
``λ_min(K_p) > λ_max(J) ‖ω(0)‖² / (π² − θ(0)²)`` (the survey states it with ``J`` normalised to
the identity, its control law (9) being written at acceleration level).

Reconstructed parts (the survey states the inequalities without proof, part of the text was lost
in extraction):

- the Lyapunov function above and the resulting ``λ_max(J)`` factor in Lemma 2 for a non-unit
  inertia (the survey's eq. (9) carries ``J⁻¹`` in front of the torque, i.e. unit inertia);
- Lemma 2 with a matrix gain: the survey writes ``λ_min(K_p)``; the Lyapunov argument here only
  covers scalar gains (``e_R · K_R e_Ω`` is not a time derivative for a general matrix) and the
  matrix form is evaluated as stated in the survey;
- Lemma 3 (SE(3), Bullo–Murray): with a block-diagonal ``K_d`` the rotational subsystem of the
  closed loop does not depend on the translation, so the condition is Lemma 2 on the attitude
  block (the survey's garbled "for all ω(0)" is read that way);
- Lemma 1: the eigenvalue order in ``λ' = λ₂ + λ₃ − λ₁`` (ascending here, the only order that
  makes ``λ' > 0`` for every positive-definite P);
- the trace-form region (:func:`sufficient_condition` with ``kind="trace"``), not in the survey,
  follows from the same argument with ``c = 2``.

The survey's Lemma 4 also claims exponential stability, which in Lee 2012 needs an additional
cross term in V and a gain condition on ``k_Ω``; only the attraction part is checked here.

Sources: Jiang, Meng & Yang, Control and Decision 38(8), 2023, Lemmas 1–4 and eqs. (7)–(11);
Koditschek 1989; Bullo & Murray 1995;
T. Lee, Systems & Control Letters 61 (2012), Prop. 1.
"""

from __future__ import annotations

import numpy as np

from .._validation import (
    as_array,
    check_inertia_3x3,
    check_positive,
    check_positive_scalar,
)
from ..errors import DEFAULT_G, DERIVATIVE_FACTOR, _check_kind, check_error_weight

__all__ = [
    "critical_level",
    "lyapunov_function",
    "lyapunov_condition",
    "sufficient_condition",
    "psi_bound",
    "rate_bound",
    "lemma1_condition",
    "lemma1_lyapunov",
    "lemma2_condition",
    "lemma3_condition",
    "lemma4_condition",
]


def _inertia(J: object) -> np.ndarray:
    J = check_inertia_3x3(J, "J")
    return J


def _scalar_gain(k: object, name: str) -> float:
    a = as_array(k, name)
    if a.ndim != 0:
        raise ValueError(
            f"{name}: the Lyapunov bound needs a scalar gain (got shape {a.shape}); "
            "the matrix form is only available in lemma2_condition, as the survey states it"
        )
    return float(check_positive(a, name))


def _inputs(Psi0: object, e_Omega0: object) -> tuple[np.ndarray, np.ndarray]:
    Psi0 = as_array(Psi0, "Psi0")
    if np.any(Psi0 < 0):
        raise ValueError(f"Psi0: must be >= 0, got {float(Psi0.min())}")
    e = as_array(e_Omega0, "e_Omega0", (3,))
    return Psi0, np.sum(e * e, axis=-1)


def critical_level(kind: str, G: object = None) -> float:
    """``Ψ*``: the value of Ψ that a trajectory must not reach (see module docstring).

    large_angle: 2; log: π²/2; trace: ``2(g₁ + g₂)`` with ``g₁ ≤ g₂ ≤ g₃`` the eigenvalues of G
    (at the rotation by π about the ``g₃`` eigenvector, ``I − R̃ = 2(I − n nᵀ)``).
    """
    kind = _check_kind(kind)
    if kind == "large_angle":
        return 2.0
    if kind == "log":
        return 0.5 * np.pi**2
    g = np.linalg.eigvalsh(DEFAULT_G if G is None else check_error_weight(G))
    return float(2.0 * (g[0] + g[1]))


def lyapunov_function(
    kind: str, Psi: object, e_Omega: object, J: object, k_R: object
) -> np.ndarray:
    """``V = ½ e_Ωᵀ J e_Ω + (k_R / c) Ψ`` (batched; ``Psi (...)``, ``e_Omega (..., 3)``)."""
    kind = _check_kind(kind)
    J = _inertia(J)
    k_R = _scalar_gain(k_R, "k_R")
    Psi = as_array(Psi, "Psi")
    e = as_array(e_Omega, "e_Omega", (3,))
    return 0.5 * np.einsum("...i,ij,...j->...", e, J, e) + (k_R / DERIVATIVE_FACTOR[kind]) * Psi


def lyapunov_condition(
    kind: str, Psi0: object, e_Omega0: object, J: object, k_R: object, G: object = None
) -> np.ndarray:
    """``V(0) < (k_R / c) Ψ*``: the (tightest) sublevel-set region of attraction, batched bool."""
    V0 = lyapunov_function(kind, Psi0, e_Omega0, J, k_R)
    return V0 < (_scalar_gain(k_R, "k_R") / DERIVATIVE_FACTOR[kind]) * critical_level(kind, G)


def sufficient_condition(
    kind: str, Psi0: object, e_Omega0: object, J: object, k_R: object, G: object = None
) -> np.ndarray:
    """Survey-form condition ``Ψ(0) < Ψ*`` and
    ``‖e_Ω(0)‖² < 2 k_R (Ψ* − Ψ(0)) / (c λ_max(J))`` (implies :func:`lyapunov_condition`)."""
    kind = _check_kind(kind)
    J = _inertia(J)
    k_R = _scalar_gain(k_R, "k_R")
    Psi0, e2 = _inputs(Psi0, e_Omega0)
    star = critical_level(kind, G)
    lam = float(np.linalg.eigvalsh(J)[-1])
    c = DERIVATIVE_FACTOR[kind]
    return (Psi0 < star) & (e2 < 2.0 * k_R * (star - Psi0) / (c * lam))


def psi_bound(kind: str, Psi0: object, e_Omega0: object, J: object, k_R: object) -> np.ndarray:
    """Upper bound ``(c / k_R) V(0)`` on ``Ψ(t)`` for all ``t ≥ 0`` along the ideal closed loop."""
    kind = _check_kind(kind)
    V0 = lyapunov_function(kind, Psi0, e_Omega0, J, k_R)
    return DERIVATIVE_FACTOR[kind] / _scalar_gain(k_R, "k_R") * V0


def rate_bound(kind: str, Psi0: object, e_Omega0: object, J: object, k_R: object) -> np.ndarray:
    """Upper bound ``√(2 V(0) / λ_min(J))`` on ``‖e_Ω(t)‖`` for all ``t ≥ 0`` (ideal loop)."""
    V0 = lyapunov_function(kind, Psi0, e_Omega0, J, k_R)
    lam = float(np.linalg.eigvalsh(_inertia(J))[0])
    return np.sqrt(2.0 * V0 / lam)


def lemma1_condition(P: object) -> bool:
    """Survey Lemma 1 (Koditschek): P symmetric positive definite with three distinct eigenvalues
    and ``(λ₁+λ₂)(λ₁+λ₃)(λ₂+λ₃) ≠ 0``. Returns ``False`` when P violates this; raises
    ``ValueError`` only for malformed input (not 3×3, non-finite)."""
    a = as_array(P, "P")
    if a.shape != (3, 3):
        raise ValueError(f"P: expected shape (3, 3), got {a.shape}")
    try:
        check_error_weight(a, "P")
    except ValueError:
        return False
    lam = np.linalg.eigvalsh(a)
    return bool((lam[0] + lam[1]) * (lam[0] + lam[2]) * (lam[1] + lam[2]) != 0.0)


def lemma1_lyapunov(Psi_trace: object, P: object) -> np.ndarray:
    """Survey eq. (7): ``V(R̃) = tr(P(I − R̃)) / λ'`` with ``λ' = λ₂ + λ₃ − λ₁`` (eigenvalues of P
    in ascending order — *reconstructed* order), from the trace error ``Ψ = tr(P(I − R̃))`` of
    :func:`liecontrol.errors.trace_error` with ``G = P``."""
    lam = np.linalg.eigvalsh(check_error_weight(P, "P"))
    Psi = as_array(Psi_trace, "Psi_trace")
    return Psi / float(lam[1] + lam[2] - lam[0])


def lemma2_condition(Psi0: object, e_Omega0: object, k_R: object, J: object = None) -> np.ndarray:
    """Survey Lemma 2 (Bullo–Murray, log error): ``tr R̃(0) ≠ −1`` (θ(0) < π) and

        λ_min(K_p) > λ_max(J) ‖e_Ω(0)‖² / (π² − θ(0)²),     θ(0)² = 2 Ψ(0)

    with ``Ψ(0)`` the log error. ``J=None`` is the survey's statement (unit inertia,
    acceleration-level gains); with ``J`` the gains are torque-level (*reconstructed*, see the
    module docstring). ``k_R`` may be a scalar or a symmetric 3×3 matrix (``λ_min`` as in the
    survey; the proof here covers scalar gains). Batched bool.
    """
    lam_J = 1.0 if J is None else float(np.linalg.eigvalsh(_inertia(J))[-1])
    K = as_array(k_R, "k_R")
    if K.ndim == 0:
        k_min = check_positive_scalar(K, "k_R")
    elif K.shape == (3, 3):
        if float(np.abs(K - K.T).max()) > 1e-9 * max(float(np.abs(K).max()), 1e-300):
            raise ValueError("k_R: gain matrix not symmetric")
        k_min = float(np.linalg.eigvalsh(K)[0])
        if k_min <= 0:
            raise ValueError(f"k_R: gain matrix not positive definite (λ_min = {k_min:.3e})")
    else:
        raise ValueError(f"k_R: expected a scalar or shape (3, 3), got {K.shape}")
    Psi0, e2 = _inputs(Psi0, e_Omega0)
    theta2 = 2.0 * Psi0
    margin = np.pi**2 - theta2
    # written without division so that θ(0) = π gives False rather than inf/NaN
    return (margin > 0) & (k_min * margin > lam_J * e2)


def lemma3_condition(Psi0: object, omega0: object, K_omega: object, J: object = None) -> np.ndarray:
    """Survey Lemma 3 (Bullo–Murray PD on SE(3)): ``R(0) ≠ −1`` in the sense ``θ(0) < π`` and
    ``λ_min(K_ω) > ‖ω(0)‖² / (π² − ‖log R(0)‖²)`` — Lemma 2 on the attitude block (*reconstructed*
    reading: with a block-diagonal ``K_d`` the rotational closed loop is independent of the
    translation). ``Psi0`` is the log error of the attitude part, ``omega0 (..., 3)``."""
    return lemma2_condition(Psi0, omega0, K_omega, J)


def lemma4_condition(Psi0: object, e_Omega0: object, J: object, k_R: object) -> np.ndarray:
    """Survey Lemma 4 (Lee 2012, large-angle error):

        Ψ(0) < 2   and   ‖e_Ω(0)‖² < (2 / λ_max(J)) k_R (2 − Ψ(0)),

    with ``Ψ`` the large-angle error; scalar ``k_R`` [N·m]. Batched bool."""
    return sufficient_condition("large_angle", Psi0, e_Omega0, J, k_R)
