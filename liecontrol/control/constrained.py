"""Pointing constraints on SO(3) and a barrier-shaped geometric attitude controller.

**Cones.** ``R`` maps body to inertial axes. A body-fixed unit axis ``b`` (a star-tracker
boresight, an antenna) points along ``R b`` in inertial axes; with an inertial unit direction
``s`` (the Sun, the Earth) its cosine is ``c(R) = (R b)·s = bᵀRᵀs``.

- :class:`KeepOutCone` (half-angle ``α``): admissible iff ``c(R) < cos α`` — the boresight stays
  more than ``α`` from ``s``. Margin ``∠(Rb, s) − α``.
- :class:`KeepInCone` (half-angle ``β``): admissible iff ``c(R) > cos β`` — the axis stays within
  ``β`` of ``s``. Margin ``β − ∠(Rb, s)``.

Margins are in degrees, positive inside the admissible set and negative when the constraint is
violated (:func:`cone_margins_deg`).

**Constrained controller** (:class:`ConstrainedGeometricPD`; Lee & Mesbahi, "Feedback control
for spacecraft reorientation under attitude constraints via convex potentials", IEEE Trans.
Aerospace and Electronic Systems, 2014; Kulumani & Lee, "Constrained geometric attitude
control on SO(3)", International Journal of Control, Automation and Systems, 2017). The
configuration potential multiplies an attractive potential by a logarithmic barrier::

    Ψ(R) = Ψ_A(R̃) · (1 + Σ_i β_i(R)),     R̃ = R_dᵀ R,
    Ψ_A = 2 − 2 cos(θ/2)                  (the large-angle error of Lee 2012, θ = ∠R̃)
    β_i = −w ln((cos α_i − c_i)/(1 + cos α_i))    keep-out, β_i ∈ [0, ∞)
    β_i = −w ln((c_i − cos β_i)/(1 − cos β_i))    keep-in,  β_i ∈ [0, ∞)

with ``w > 0`` the ``barrier_weight``. Each ``β_i`` is zero where the boresight is farthest from
the boundary and grows without bound at it. The configuration error is the body-frame gradient
of ``Ψ`` (``d/dε Ψ(R exp(ε ŵ))|₀ = e_C · w``)::

    e_C = (1 + Σ β_i) e_A + Ψ_A Σ ∇β_i,     e_A = sin(θ/2) · axis(R̃),
    ∇c_i = b_i × (Rᵀ s_i),   ∇β_i = w ∇c_i / (cos α_i − c_i)  (keep-out),
                             ∇β_i = −w ∇c_i / (c_i − cos β_i) (keep-in),

and the torque is the geometric PD's with ``e_C`` in place of ``e_R``::

    M = −K_R e_C − K_Ω e_Ω + Ω × JΩ − J (Ω^ RᵀR_d Ω_d − RᵀR_d Ω̇_d),   e_Ω = Ω − RᵀR_d Ω_d.

**Lyapunov argument** (regulation, ``Ω_d = 0``, controller ``J`` = plant ``J``, torque
delivered exactly): the closed loop is ``J Ω̇ = −K_R e_C − K_Ω Ω``. With scalar ``k_R`` take
``V = ½ ΩᵀJΩ + k_R Ψ(R)``; with the tuning's matrix form ``K_R = k J``, ``K_Ω = d J`` take
``V = ½ ΩᵀΩ + k Ψ``. Either way ``V̇ = −Ωᵀ K_Ω Ω ≤ 0`` (resp. ``−d ΩᵀΩ``), so ``V`` stays below
its initial value; since ``Ψ → ∞`` at every cone boundary, a trajectory that starts admissible
never reaches a boundary, and by LaSalle it converges to a critical point of ``Ψ``. ``R_d`` (if
admissible) is the unique global minimum (``Ψ = 0``).

**Known limits.** (1) The barriers create other critical points of ``Ψ`` (saddles "behind" a
cone, where the attractive and barrier gradients cancel, and the large-angle potential's maximum
at ``θ = π``); trajectories from the measure-zero set of starts on their stable manifolds stall
there, and starts near them converge slowly. (2) The guarantee is for continuous-time control
with the torque delivered: with actuator saturation, model error, or sampling — not only "long"
periods: a start approaching a cone fast enough crosses it at any practical period (a 120° slew
through a 20° Sun cone at 0.1 rad/s toward it, ω_n T_s = 0.003, crossed by 19.7°; at 1 s the run
diverged) — the barrier's torque, which grows like ``1/slack``, arrives late or clipped and the
boresight can cross the boundary. :class:`SampledSafeConstrainedPD` adds the sampled-data,
torque-bounded guarantee (a barrier on the braking-distance-augmented margin); here nothing is
hidden: :func:`cone_margins_deg` reports the negative margin and the controller keeps commanding
(the slack is floored at :data:`SLACK_FLOOR` so its push back out stays finite). (3) Near
``R_d`` the stiffness is ``(1 + Σ β_i(R_d))`` times the unconstrained PD's, i.e. the natural
frequency is scaled by ``√(1 + Σ β_i(R_d))`` (1 for a target far from every cone). (4) The
argument above is for regulation; with a moving reference the feed-forward is applied as in
:class:`~liecontrol.control.geometric_pd.GeometricPD` but the barrier guarantee is not claimed.

**Bad input.** A desired attitude outside the admissible set, or an initial attitude (the
state at the first ``command`` after ``reset``) outside it, raise ``ValueError`` naming
``R_d``/``R``, the cone and its margin.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._array_api import any_true, namespace
from .._kernels.constrained import (
    N_DIAG,
    N_DIAG_SAFE,
    N_STATE,
    constrained_pd_law,
    sampled_safe_pd_law,
)
from .._validation import as_array, as_int, as_scalar, check_inertia_3x3, check_rotation_matrix
from ..errors import _large_angle_error_unchecked
from .array_law import ArrayLaw
from .base import (
    AttitudeController,
    AttitudeReference,
    AttitudeState,
    check_state_batch,
    finite_command,
)
from .geometric_pd import _apply_gain, _as_matrix, _cross, check_gain
from .kernel import ControllerKernel

__all__ = [
    "KeepOutCone",
    "KeepInCone",
    "SLACK_FLOOR",
    "cone_margins_deg",
    "check_admissible",
    "check_cone_set",
    "constrained_potential",
    "ConstrainedGeometricPD",
]

#: Smallest normalised slack the barrier is evaluated at once an attitude is past a boundary
#: (only reachable when the torque is not delivered, e.g. saturation): keeps the command finite.
SLACK_FLOOR = 1e-6


def _unit(v: object, name: str) -> np.ndarray:
    a = as_array(v, name, (3,))
    if a.shape != (3,):
        raise ValueError(f"{name}: expected one 3-vector, got shape {a.shape}")
    n = float(np.linalg.norm(a))
    if not n > 1e-12:
        raise ValueError(f"{name}: must be a non-zero vector, got {a.tolist()}")
    u = a / n
    u.setflags(write=False)
    return u


@dataclass(frozen=True)
class _Cone:
    body_axis: tuple[float, float, float]
    inertial_direction: tuple[float, float, float]
    half_angle_deg: float

    def __post_init__(self) -> None:
        # stored as given, as tuples of floats (hashable, comparable: scenarios batch on them,
        # and a file round trip is exact); the unit arrays the formulas use are kept alongside
        b = _unit(self.body_axis, "body_axis")
        s = _unit(self.inertial_direction, "inertial_direction")
        object.__setattr__(self, "body_axis", tuple(as_array(self.body_axis, "").tolist()))
        object.__setattr__(
            self, "inertial_direction", tuple(as_array(self.inertial_direction, "").tolist())
        )
        object.__setattr__(self, "_b", b)
        object.__setattr__(self, "_s", s)
        a = as_scalar(self.half_angle_deg, "half_angle_deg")
        if not 0.0 < a < 180.0:
            raise ValueError(f"half_angle_deg: must be in (0, 180) degrees, got {a}")
        object.__setattr__(self, "half_angle_deg", a)

    @property
    def cos_half_angle(self) -> float:
        return math.cos(math.radians(self.half_angle_deg))

    def cosine(self, R: object) -> np.ndarray:
        """``c = bᵀRᵀs`` for ``R`` ``(..., 3, 3)`` (body → inertial); shape ``(...)``."""
        R = check_rotation_matrix(R, "R")
        return (R @ self._b) @ self._s

    def angle_deg(self, R: object) -> np.ndarray:
        """Angle between the boresight ``R b`` and ``s`` [deg]."""
        return np.degrees(np.arccos(np.clip(self.cosine(R), -1.0, 1.0)))

    def margin_deg(self, R: object) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError


@dataclass(frozen=True)
class KeepOutCone(_Cone):
    """The body axis ``body_axis`` must stay more than ``half_angle_deg`` from the inertial
    direction ``inertial_direction`` (``bᵀRᵀs < cos α``). The axes are stored as given and
    normalised for the formulas; the half-angle must be in (0°, 90°) (a keep-out cone of 90° or
    more would exclude a hemisphere or more: the barrier's potential is then not convex on the
    admissible set and the braking geometry of :class:`SampledSafeConstrainedPD` — favourable
    curvature below 90° — does not hold)."""

    kind = "keep_out"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.half_angle_deg < 90.0:
            raise ValueError(
                f"half_angle_deg: a keep-out cone must be narrower than 90°, got "
                f"{self.half_angle_deg}° (exclude the opposite direction with a keep-in cone)"
            )

    def margin_deg(self, R: object) -> np.ndarray:
        """``∠(Rb, s) − α`` [deg]: negative inside the cone."""
        return self.angle_deg(R) - self.half_angle_deg


@dataclass(frozen=True)
class KeepInCone(_Cone):
    """The body axis ``body_axis`` must stay within ``half_angle_deg`` of the inertial direction
    ``inertial_direction`` (``bᵀRᵀs > cos β``). The axes are stored as given and normalised
    for the formulas; the half-angle must be in (0°, 180°)."""

    kind = "keep_in"

    def margin_deg(self, R: object) -> np.ndarray:
        """``β − ∠(Rb, s)`` [deg]: negative outside the cone."""
        return self.half_angle_deg - self.angle_deg(R)


AttitudeCone = KeepOutCone | KeepInCone


def _cones(cones: object, name: str, cls: type) -> tuple:
    if isinstance(cones, _Cone):
        cones = (cones,)
    if not isinstance(cones, Sequence) or isinstance(cones, str):
        raise TypeError(
            f"{name}: expected a sequence of {cls.__name__}, got {type(cones).__name__}"
        )
    for i, c in enumerate(cones):
        if not isinstance(c, cls):
            raise TypeError(f"{name}: item {i} must be a {cls.__name__}, got {type(c).__name__}")
    return tuple(cones)


def check_cone_set(keep_out: Sequence[KeepOutCone], keep_in: Sequence[KeepInCone]) -> None:
    """Raise ``ValueError`` naming ``keep_in`` when the cones leave one body axis no admissible
    direction: a keep-in cone lying entirely inside a keep-out cone of the same body axis
    (``∠(s_in, s_out) + β ≤ α``), or two keep-in cones of the same body axis that do not overlap
    (``∠(s₁, s₂) ≥ β₁ + β₂``). (Cones on different body axes can also conflict; that is not
    detected here: the first ``command`` rejects an inadmissible ``R_d``.)"""
    outs = _cones(keep_out, "keep_out", KeepOutCone)
    ins = _cones(keep_in, "keep_in", KeepInCone)

    def ang(a: np.ndarray, b: np.ndarray) -> float:
        return math.degrees(math.acos(max(-1.0, min(1.0, float(a @ b)))))

    for j, ci in enumerate(ins):
        for i, co in enumerate(outs):
            if (
                ang(ci._b, co._b) < 1e-9
                and ang(ci._s, co._s) + ci.half_angle_deg <= co.half_angle_deg
            ):
                raise ValueError(
                    f"keep_in: keep-in cone {j} ({ci.half_angle_deg}° about "
                    f"{ci._s.round(4).tolist()}) lies inside keep-out cone {i} "
                    f"({co.half_angle_deg}° about {co._s.round(4).tolist()}) for the same body "
                    f"axis {ci._b.round(4).tolist()}: no admissible attitude"
                )
        for k in range(j):
            ck = ins[k]
            if (
                ang(ci._b, ck._b) < 1e-9
                and ang(ci._s, ck._s) >= ci.half_angle_deg + ck.half_angle_deg
            ):
                raise ValueError(
                    f"keep_in: keep-in cones {k} and {j} of body axis {ci._b.round(4).tolist()} "
                    "do not overlap: no admissible attitude"
                )


def cone_margins_deg(cones: Sequence[AttitudeCone], R: object) -> np.ndarray:
    """Margins ``(..., n)`` [deg] of the ``n`` cones at attitudes ``R`` ``(..., 3, 3)``: positive
    when admissible, negative when violated (see the module docstring)."""
    cones = _cones(cones, "cones", _Cone)
    R = check_rotation_matrix(R, "R")
    if not cones:
        return np.zeros(R.shape[:-2] + (0,))
    return np.stack([c.margin_deg(R) for c in cones], axis=-1)


def check_admissible(cones: Sequence[AttitudeCone], R: object, name: str = "R") -> None:
    """Raise ``ValueError`` naming ``name`` if any attitude of ``R`` violates (or touches) a
    cone."""
    if not isinstance(name, str):
        raise TypeError(f"name: expected a str, got {type(name).__name__}")
    cones = _cones(cones, "cones", _Cone)
    if not cones:
        return
    m = cone_margins_deg(cones, R).reshape(-1, len(cones))
    bad = np.argwhere(~(m > 0.0))
    if bad.size:
        k, i = (int(x) for x in bad[0])
        c = cones[i]
        where = "inside keep-out" if c.kind == "keep_out" else "outside keep-in"
        raise ValueError(
            f"{name}: attitude {k} is {where} cone {i} (body_axis {c._b.round(4).tolist()},"
            f" inertial_direction {c._s.round(4).tolist()}, half-angle "
            f"{c.half_angle_deg}°; margin {m[k, i]:.3f}°): the barrier is only defined on the "
            "admissible set"
        )


def _barrier_terms(R: Any, cones: tuple, w: Any) -> tuple[Any, Any, Any]:
    """``(Σβ_i (...), Σ∇β_i (..., 3), min normalised slack (...))`` at ``R`` ``(..., 3, 3)``.
    Pure, NumPy or JAX: the slack is floored at :data:`SLACK_FLOOR` before the logarithm and
    the division, so both stay finite (and differentiable) on and past a boundary."""
    xp = namespace(R, w)
    shape = R.shape[:-2]
    beta = xp.zeros(shape)
    grad = xp.zeros(shape + (3,))
    smin = xp.full(shape, np.inf)
    for cone in cones:
        s_body = xp.swapaxes(R, -1, -2) @ cone._s  # Rᵀs, (..., 3)
        c = s_body @ cone._b
        gc = _cross(xp.broadcast_to(cone._b, s_body.shape), s_body)  # ∇c = b × Rᵀs
        ca = cone.cos_half_angle
        if cone.kind == "keep_out":
            slack, scale, sign = ca - c, 1.0 + ca, 1.0
        else:
            slack, scale, sign = c - ca, 1.0 - ca, -1.0
        x = xp.maximum(slack / scale, SLACK_FLOOR)
        smin = xp.minimum(smin, slack / scale)
        beta = beta + -w * xp.log(x)
        # d/dε of −w ln(slack): keep-out slack' = −∇c·ω, keep-in slack' = +∇c·ω
        grad = grad + (sign * w / (x * scale))[..., None] * gc
    return beta, grad, smin


def constrained_potential(
    R: object,
    R_d: object,
    keep_out: Sequence[KeepOutCone] = (),
    keep_in: Sequence[KeepInCone] = (),
    barrier_weight: float = 0.5,
) -> tuple[np.ndarray, np.ndarray]:
    """``(Ψ (B,), e_C (B, 3))``: the barrier-shaped potential and its body-frame gradient (the
    configuration error) at attitudes ``R`` ``(B, 3, 3)`` or ``(3, 3)`` and desired ``R_d``
    ``(3, 3)`` or ``(B, 3, 3)`` (formulas in the module docstring). Attitudes must be
    admissible (``ValueError`` naming ``R`` otherwise)."""
    R = check_rotation_matrix(R, "R")
    R_d = check_rotation_matrix(R_d, "R_d")
    w = _weight(barrier_weight)
    cones = _cones(keep_out, "keep_out", KeepOutCone) + _cones(keep_in, "keep_in", KeepInCone)
    R3 = R.reshape(-1, 3, 3)
    check_admissible(cones, R3, "R")
    Rt = np.swapaxes(R_d, -1, -2) @ R3
    return _potential(R3, Rt, cones, w)[:2]


def _potential(R: Any, Rt: Any, cones: tuple, w: Any) -> tuple[Any, Any, Any]:
    """``(Ψ, e_C, min slack)`` of the module docstring at ``R``, ``R̃ = R_dᵀR`` ``(..., 3,
    3)``; pure, NumPy or JAX."""
    Psi_A, e_A = _large_angle_error_unchecked(Rt)
    beta, grad, smin = _barrier_terms(R, cones, w)
    Psi = Psi_A * (1.0 + beta)
    e_C = (1.0 + beta)[..., None] * e_A + Psi_A[..., None] * grad
    return Psi, e_C, smin


def _admissible(R: Any, cones: tuple) -> Any:
    """``(...)`` whether ``R`` ``(..., 3, 3)`` is strictly inside every cone's admissible set
    (:func:`check_admissible`'s test, margin > 0 in degrees, as the compiled kernel's); pure.
    A boolean: no derivative flows through it."""
    xp = namespace(R)
    ok = xp.ones(R.shape[:-2], dtype=bool)
    for cone in cones:
        c = (R @ cone._b) @ cone._s
        angle = xp.degrees(xp.arccos(xp.clip(c, -1.0, 1.0)))
        m = angle - cone.half_angle_deg if cone.kind == "keep_out" else cone.half_angle_deg - angle
        ok = ok & (m > 0.0)
    return ok


def constrained_pd_torque(
    R: Any, omega: Any, R_d: Any, omega_d: Any, omega_dot_d: Any, J: Any, k_R: Any,
    k_Omega: Any, cones: tuple, barrier_weight: Any,
) -> tuple[Any, Any, Any, Any, Any]:  # fmt: skip
    """The barrier-shaped geometric PD (module docstring; Lee & Mesbahi, IEEE TAES 2014;
    Kulumani & Lee, IJCAS 2017) as a pure array function::

        M = −K_R e_C − K_Ω e_Ω + Ω × JΩ − J (Ω^ RᵀR_d Ω_d − RᵀR_d Ω̇_d),   e_Ω = Ω − RᵀR_d Ω_d,

    ``e_C`` the body-frame gradient of ``Ψ = Ψ_A (1 + Σβ_i)``. Returns ``(M, Ψ, e_C, e_Ω,
    min normalised slack)``; arrays broadcast over leading axes (``R`` ``(..., 3, 3)``), NumPy
    or JAX; no validation (:class:`ConstrainedGeometricPD` is the validated object)."""
    xp = namespace(R, omega, R_d)
    Rt = xp.swapaxes(R_d, -1, -2) @ R
    RtT = xp.swapaxes(Rt, -1, -2)
    Psi, e_C, smin = _potential(R, Rt, cones, barrier_weight)
    w_d_body = (RtT @ omega_d[..., None])[..., 0]
    dw_d_body = (RtT @ omega_dot_d[..., None])[..., 0]
    e_W = omega - w_d_body
    ff = _cross(omega, omega @ J.T) - (_cross(omega, w_d_body) - dw_d_body) @ J.T
    M = ff - _apply_gain(k_R, e_C) - _apply_gain(k_Omega, e_W)
    return M, Psi, e_C, e_W, smin


def _weight(w: object) -> float:
    v = as_scalar(w, "barrier_weight")
    if not v > 0.0:
        raise ValueError(f"barrier_weight: must be > 0, got {v}")
    return v


class ConstrainedGeometricPD(AttitudeController):
    """Geometric PD on SO(3) shaped by logarithmic barriers on keep-out/keep-in cones (Lee &
    Mesbahi 2014; Kulumani & Lee 2017): ``M = −K_R e_C − K_Ω e_Ω + feed-forward`` with ``e_C``
    the gradient of ``Ψ_A (1 + Σ β_i)`` (module docstring: formulas, Lyapunov argument, limits).

    Args:
        J: 3×3 inertia the controller assumes [kg·m²].
        k_R: attitude gain (scalar, positive 3-vector or SPD 3×3; the Lyapunov argument needs a
            scalar or ``k J``, which :func:`liecontrol.control.tuning.tune_geometric_pd` with
            ``error="large_angle"`` gives).
        k_Omega: rate gain, same forms.
        keep_out: :class:`KeepOutCone` sequence.
        keep_in: :class:`KeepInCone` sequence.
        barrier_weight: ``w > 0`` in ``β = −w ln(slack)``: larger keeps the boresight farther
            from the boundaries, smaller lets it pass closer (stiffer near them).

    With no cones it is the large-angle :class:`~liecontrol.control.geometric_pd.GeometricPD`.
    The first ``command`` after ``reset`` raises ``ValueError`` naming ``R`` if a spacecraft
    starts outside the admissible set; ``R_d`` is checked at every command.
    ``diagnostics()``: ``Psi`` ``(B,)``, ``e_R`` (= ``e_C``) ``(B, 3)``, ``e_Omega`` ``(B, 3)``,
    ``min_slack`` ``(B,)`` (smallest normalised slack; ≤ 0 means a cone is violated).
    """

    batched = True

    def __init__(
        self,
        J: object,
        k_R: object,
        k_Omega: object,
        keep_out: Sequence[KeepOutCone] = (),
        keep_in: Sequence[KeepInCone] = (),
        barrier_weight: float = 0.5,
    ) -> None:
        J = check_inertia_3x3(J, "J")
        self.J = J.copy()
        self.J.setflags(write=False)
        self.k_R = check_gain(k_R, "k_R")
        self.k_Omega = check_gain(k_Omega, "k_Omega")
        self.keep_out = _cones(keep_out, "keep_out", KeepOutCone)
        self.keep_in = _cones(keep_in, "keep_in", KeepInCone)
        check_cone_set(self.keep_out, self.keep_in)
        self.barrier_weight = _weight(barrier_weight)
        self._cones = self.keep_out + self.keep_in
        self._batch: int | None = None
        self._first = True
        self._diag: dict[str, np.ndarray] = {}

    def __repr__(self) -> str:
        return (
            f"ConstrainedGeometricPD(keep_out={len(self.keep_out)}, keep_in={len(self.keep_in)}, "
            f"barrier_weight={self.barrier_weight})"
        )

    def reset(self, t0: float, batch_size: int) -> None:
        """Start a run: the next ``command`` checks that every spacecraft starts admissible."""
        batch = as_int(batch_size, "batch_size", minimum=1)
        as_scalar(t0, "t0")
        self._batch = batch
        self._first = True
        self._diag = {}

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m]."""
        if self._batch is None:
            raise RuntimeError("ConstrainedGeometricPD.command: call reset(t0, batch_size) first")
        as_scalar(t, "t")
        R = check_rotation_matrix(state.R, "R")
        w = as_array(state.omega, "omega", (3,))
        B = check_state_batch(R, w, self._batch)
        R_d = check_rotation_matrix(reference.R_d, "R_d")
        w_d = as_array(reference.omega_d, "omega_d", (3,))
        dw_d = as_array(reference.omega_dot_d, "omega_dot_d", (3,))
        for name, a, nd in (("R_d", R_d, 2), ("omega_d", w_d, 1), ("omega_dot_d", dw_d, 1)):
            if a.ndim > nd + 1 or (a.ndim == nd + 1 and a.shape[0] != B):
                raise ValueError(f"{name}: expected one sample or a batch of {B}, got {a.shape}")
        check_admissible(self._cones, R_d, "R_d")
        if self._first:
            check_admissible(self._cones, R, "R")
            self._first = False
        M, Psi, e_C, e_W, smin = constrained_pd_torque(
            R, w, R_d, w_d, dw_d, self.J, self.k_R, self.k_Omega, self._cones,
            self.barrier_weight,
        )  # fmt: skip
        self._diag = {"Psi": Psi, "e_R": e_C, "e_Omega": e_W, "min_slack": smin}
        return finite_command(M, w)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last ``Psi``, ``e_R``, ``e_Omega``, ``min_slack`` (empty before the first command)."""
        return dict(self._diag)

    def array_law(self) -> ArrayLaw:
        """The law as a pure array function (:func:`constrained_pd_torque`, which
        :meth:`command` calls) for the differentiable loop
        (:mod:`liecontrol.control.array_law`), with ``barrier_weight`` a further parameter
        (:attr:`ArrayLaw.params`). The state is one flag, the first sample done: an attitude
        outside the admissible set (``R_d`` at any sample, ``R`` at the first), which
        :meth:`command` refuses, gives a NaN torque, as the compiled kernel's, and the route
        reports the run as diverged."""
        J, cones = np.array(self.J), self._cones

        def step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T, *, params):  # noqa: ANN001
            (checked,) = state
            xp = namespace(R, omega)
            M, Psi, e_C, e_W, smin = constrained_pd_torque(
                R, omega, R_d, omega_d, omega_dot_d, J, k_R, k_Omega, cones,
                params["barrier_weight"],
            )  # fmt: skip
            ok = _admissible(R_d, cones) & (checked | _admissible(R, cones))
            M = xp.where(ok, M, np.nan)
            d = {"Psi": Psi, "e_R": e_C, "e_Omega": e_W, "min_slack": smin}
            return M, (xp.logical_or(checked, True),), d

        params = {"barrier_weight": self.barrier_weight}
        return ArrayLaw(self.k_R, self.k_Omega, (np.array(False),), step, params=params)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.constrained.constrained_pd_law`) for the
        simulator's fused loop (:mod:`liecontrol.control.kernel`)."""
        if self._batch is None:
            return None
        cones = [
            [*c._b, *c._s, c.cos_half_angle, 0.0 if c.kind == "keep_out" else 1.0,
             c.half_angle_deg]
            for c in self._cones
        ]  # fmt: skip
        J = np.ascontiguousarray(self.J, dtype=np.float64)
        params = np.concatenate(
            [
                [0.0],
                J.ravel(),
                np.zeros(27),
                _as_matrix(self.k_R).ravel(),
                _as_matrix(self.k_Omega).ravel(),
                [self.barrier_weight, SLACK_FLOOR, float(len(cones))],
                np.ravel(np.asarray(cones, dtype=np.float64)),
            ]
        )
        state = np.zeros((int(batch_size), 1))
        state[:, 0] = 0.0 if self._first else 1.0

        def finish(st: np.ndarray, diag: np.ndarray) -> None:
            self._first = bool(st[0, 0] == 0.0)
            self._diag = _constrained_rows(diag)

        return ControllerKernel(constrained_pd_law, params, state, 8, _constrained_rows, finish)


def _constrained_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """The controller's diagnostics from its kernel rows ``(..., 8)``."""
    return {
        "Psi": rows[..., 0].copy(),
        "e_R": rows[..., 1:4].copy(),
        "e_Omega": rows[..., 4:7].copy(),
        "min_slack": rows[..., 7].copy(),
    }


# ------------------------------------------------------------------ sampled-data safe constraints

__all__ += ["SampledSafeConstrainedPD", "UnrecoverableStartWarning", "braking_margins_deg"]


class UnrecoverableStartWarning(UserWarning):
    """A start from which the torque bound cannot be certified to stop the boresight before a
    cone at the controller's sample period (:func:`braking_margins_deg` < 0)."""


def _check_max_torque(u: object) -> np.ndarray:
    a = as_array(u, "max_torque")
    if a.ndim == 0:
        a = np.full(3, float(a))
    if a.shape != (3,):
        raise ValueError(f"max_torque: expected a scalar or shape (3,), got {a.shape}")
    if not np.all(a > 0.0):
        raise ValueError(f"max_torque: must be > 0 [N·m], got {a.tolist()}")
    a = a.copy()
    a.setflags(write=False)
    return a


def _approach_terms(R: Any, w: Any, J: np.ndarray, cone: _Cone) -> tuple[Any, Any, Any, Any]:
    """For one cone at ``(R, ω)`` ``(..., 3, 3), (..., 3)``: margin ``m`` [rad] ``(...)``,
    approach rate ``v = −ṁ`` ``(...)``, and the approach acceleration ``−m̈ = a_free + pᵀu``
    split into the torque-free part ``a_free`` ``(...)`` (gyroscopic and curvature terms) and
    ``p`` ``(..., 3)`` (``p = σ J⁻¹ g / sin φ``). Pure, NumPy or JAX: ``arccos`` is evaluated
    off ``|c| = 1`` (its derivative is infinite there; the values 0 and π are exact)."""
    xp = namespace(R, w)
    s_body = xp.swapaxes(R, -1, -2) @ cone._s  # Rᵀs
    c = xp.clip(s_body @ cone._b, -1.0, 1.0)
    inside = xp.abs(c) < 1.0
    phi = xp.where(inside, xp.arccos(xp.where(inside, c, 0.0)), xp.where(c > 0.0, 0.0, np.pi))
    sphi = xp.maximum(xp.sin(phi), 1e-9)
    b = xp.broadcast_to(cone._b, s_body.shape)
    g = _cross(b, s_body)  # ∇c: ċ = gᵀω
    c_dot = xp.sum(g * w, axis=-1)
    g_dot = _cross(b, _cross(s_body, w))  # d/dt(b × Rᵀs), Rᵀs' = Rᵀs × ω
    Jinv = np.linalg.inv(J)
    gyro = _cross(w, w @ J.T)  # ω × Jω
    Jg = g @ Jinv.T  # J⁻¹ g (J symmetric)
    # φ̇ = −ċ/sinφ,  φ̈ = −c̈/sinφ − ċ² cosφ/sin³φ,  c̈ = ġᵀω + gᵀJ⁻¹(u − ω × Jω)
    sigma = 1.0 if cone.kind == "keep_out" else -1.0  # keep-out m = φ − α, keep-in m = β − φ
    alpha = math.radians(cone.half_angle_deg)
    m = sigma * (phi - alpha)
    v = -sigma * (-c_dot / sphi)
    curv = (xp.sum(g_dot * w, axis=-1) - xp.sum(Jg * gyro, axis=-1)) / sphi
    curv = curv + c_dot**2 * c / sphi**3
    a_free = sigma * curv  # −m̈ = −σ φ̈ = σ(c̈/sinφ + ċ² cosφ/sin³φ)
    p = (sigma / sphi)[..., None] * Jg
    return m, v, a_free, p


def _braking_decel(a_free: Any, u_max: np.ndarray, lam_max: float, efficiency: float) -> Any:
    """Deceleration of the approach the torque bound certifies [rad/s²]: ``η u_min/λ_max(J)``
    less any adverse torque-free acceleration (``‖J⁻¹ĝ‖₁ ≥ 1/λ_max`` for every approach
    direction, so the bound holds while the geometry turns); floored, so the braking distance's
    division stays finite."""
    xp = namespace(a_free)
    return xp.maximum(efficiency * float(u_max.min()) / lam_max - xp.maximum(a_free, 0.0), 1e-12)


def _h(m: Any, v: Any, a_b: Any, T: float, buf: float) -> Any:
    """Braking-distance-augmented margin ``m − v₊T − v₊²/(2a_b) − buffer`` [rad]."""
    vp = namespace(m, v).maximum(v, 0.0)
    return m - vp * T - vp * vp / (2.0 * a_b) - buf


def _cone_certificates(
    R: Any, w: Any, J: np.ndarray, cones: Sequence[_Cone], umax: np.ndarray, lam_max: float,
    efficiency: float, T: float, buf: float,
) -> tuple[Any, ...]:  # fmt: skip
    """Per cone at ``(R, ω)``: ``(m, v, a_free, p, a_b, h, reach)`` — the double-integrator
    terms (:func:`_approach_terms`, :func:`_braking_decel`), the braking margin ``h`` [rad] and
    whether the cone is **out of reach** for the coming period (the filter leaves it alone).

    The distance to a cone, the angle φ to its axis, is singular on the axis (keep-in) and
    opposite it (keep-out): its torque-free curvature ``ċ²cosφ/sin³φ`` grows without bound
    there although the boundary is far (a boresight crossing a 75° keep-in cone's axis at
    0.03 rad/s certified a margin of −5·10⁹ degrees and braked at full torque 72° from the
    boundary). So a second, curvature-free certificate runs beside it, from the speed of the
    cone's direction in the body, ``ω_s = ‖Rᵀs × ω‖ ≥ |φ̇|``: treated as if all of it were
    approach along a geodesic (no curvature), ``h_s = m − ω_s T − ω_s²/(2a_s) − buffer`` with
    ``a_s = η u_min/λ_max − ‖J⁻¹(ω × Jω)‖``. The reported margin is ``max(h, h_s)`` (either
    certifies). The cone is out of reach when ``h_s`` stays ``≥ 0`` at the period's end for
    every command in the box: ``ω_s`` grows by at most ``A T`` with ``A = ‖u_max‖/λ_min +
    ‖J⁻¹(ω × Jω)‖ + ‖ω‖ ω_s`` (the direction's acceleration ``Rᵀs × ω̇ + (Rᵀs × ω) × ω``, the
    rate and gyroscopic term frozen at the sample as elsewhere in the filter) and ``m`` falls by
    at most ``ω_s T + ½AT²``."""
    xp = namespace(R, w)
    terms = [_approach_terms(R, w, J, c) for c in cones]
    m = xp.stack([x[0] for x in terms], axis=-1)
    v = xp.stack([x[1] for x in terms], axis=-1)
    a_free = xp.stack([x[2] for x in terms], axis=-1)
    p = xp.stack([x[3] for x in terms], axis=-2)  # (..., n, 3)
    a_b = _braking_decel(a_free, umax, lam_max, efficiency)
    s_body = xp.stack([xp.swapaxes(R, -1, -2) @ c._s for c in cones], axis=-2)  # (..., n, 3)
    w_n = w[..., None, :]
    ws = xp.sqrt(xp.sum(_cross(s_body, xp.broadcast_to(w_n, s_body.shape)) ** 2, axis=-1))
    gyro = (_cross(w, w @ J.T)) @ np.linalg.inv(J).T  # J⁻¹(ω × Jω)
    g_acc = xp.sqrt(xp.sum(gyro * gyro, axis=-1))[..., None]
    a_s = xp.maximum(efficiency * float(umax.min()) / lam_max - g_acc, 1e-12)
    u_acc = float(np.linalg.norm(umax)) / float(np.linalg.eigvalsh(J)[0])
    A = u_acc + g_acc + xp.sqrt(xp.sum(w * w, axis=-1))[..., None] * ws
    h = xp.maximum(_h(m, v, a_b, T, buf), _h(m, ws, a_s, T, buf))
    reach = _h(m - ws * T - 0.5 * A * T * T, ws + A * T, a_s, T, buf) >= 0.0
    return m, v, a_free, p, a_b, h, reach


def braking_margins_deg(
    cones: Sequence[AttitudeCone],
    R: object,
    omega: object,
    J: object,
    max_torque: object,
    sample_period: float,
    efficiency: float = 0.7,
    buffer_deg: float = 0.5,
) -> np.ndarray:
    """Braking-distance-augmented margins ``(B, n)`` [deg] of the ``n`` cones at ``(R, ω)``:
    ``m − v₊T − v₊²/(2a_b) − buffer``, ``m`` the geometric margin, ``v`` the rate at which the
    boresight approaches the boundary, ``T`` the sample period (one period may pass before a
    new command acts) and ``a_b`` the approach deceleration the torque bound certifies
    (:class:`SampledSafeConstrainedPD`), or the curvature-free margin from the speed of the
    cone's direction in the body where it is larger (far from the boundary, where the angle's
    curvature is unbounded: on a keep-in cone's axis, opposite a keep-out cone's). Negative:
    from this state the torque bound cannot be
    certified to stop the boresight before the boundary at this sample period (the
    unrecoverable set, up to the certificate's conservatism)."""
    cones = _cones(cones, "cones", _Cone)
    R = check_rotation_matrix(R, "R").reshape(-1, 3, 3)
    w = as_array(omega, "omega", (3,)).reshape(-1, 3)
    if w.shape[0] != R.shape[0]:
        if 1 not in (w.shape[0], R.shape[0]):
            raise ValueError(f"omega: batch {w.shape[0]} does not match R's {R.shape[0]}")
        B = max(w.shape[0], R.shape[0])
        R = np.broadcast_to(R, (B, 3, 3))
        w = np.broadcast_to(w, (B, 3))
    J = check_inertia_3x3(J, "J")
    u = _check_max_torque(max_torque)
    T = as_scalar(sample_period, "sample_period")
    if not T > 0.0:
        raise ValueError(f"sample_period: must be > 0 [s], got {T}")
    eta = _efficiency(efficiency)
    buf = math.radians(as_scalar(buffer_deg, "buffer_deg"))
    if not cones:
        return np.zeros((R.shape[0], 0))
    lam = float(np.linalg.eigvalsh(J)[-1])
    return np.degrees(_cone_certificates(R, w, J, cones, u, lam, eta, T, buf)[5])


def _efficiency(e: object) -> float:
    v = as_scalar(e, "efficiency")
    if not 0.0 < v <= 1.0:
        raise ValueError(f"efficiency: must be in (0, 1], got {v}")
    return v


def largest_approach_acceleration(m: Any, v: Any, a_b: Any, a_hi: Any, T: float, buf: float) -> Any:
    """The largest approach acceleration ``a`` held over one period ``T`` that keeps the
    braking-distance-augmented margin ``≥ 0`` at the period's end, within ``[min(−a_b, a_hi),
    a_hi]`` (``a_hi`` the largest the torque box can produce) [rad/s²]. Element-wise, NumPy or
    JAX.

    After the period ``m' = m − vT − ½aT²``, ``v' = v + aT`` and ``h'(a) = m' − v'₊T −
    v'₊²/(2a_b) − buffer`` decreases strictly with ``a``, so the answer is its root clipped to
    the interval. With ``C = m − vT − buffer`` and ``D = C + ½vT`` (``= h'`` at ``v' = 0``): for
    ``D ≤ 0`` the root has ``v' ≤ 0`` and ``h'`` is linear, ``a = 2C/T²``; for ``D > 0`` it has
    ``v' = y > 0`` solving ``y²/(2a_b) + (3/2)Ty − D = 0``, ``y = 2D/((3/2)T + √((9/4)T² +
    2D/a_b))`` (the form without cancellation), ``a = (y − v)/T``. Both branches meet at ``D =
    0`` (``a = −v/T``), so ``a`` is continuous in the state: the NumPy, compiled and JAX routes
    agree to rounding (a bisection to 2⁻³⁰ of the interval, used before, left a staircase whose
    steps the routes' last bits could flip) and the derivative is finite on both branches
    (``T > 0`` keeps the square root away from 0)."""
    xp = namespace(m, v, a_b, a_hi)
    C = m - v * T - buf
    D = C + 0.5 * v * T
    Dp = xp.maximum(D, 0.0)
    y = 2.0 * Dp / (1.5 * T + xp.sqrt(2.25 * T * T + 2.0 * Dp / a_b))
    root = xp.where(D > 0.0, (y - v) / T, 2.0 * C / (T * T))
    return xp.minimum(xp.maximum(root, xp.minimum(-a_b, a_hi)), a_hi)


def braking_filter(
    u: Any,
    R: Any,
    w: Any,
    J: np.ndarray,
    cones: Sequence[AttitudeCone],
    umax: np.ndarray,
    T: float,
    efficiency: float = 0.7,
    buffer_deg: float = 0.5,
    lam_max: float | None = None,
) -> tuple[Any, ...]:
    """The one-step safety filter of :class:`SampledSafeConstrainedPD` applied to any command
    ``u`` ``(..., 3)`` within the torque bound ``umax`` at ``(R, ω)`` ``(..., 3, 3), (..., 3)``:
    the command held over ``T`` keeps the predicted braking-distance-augmented margin of every
    cone ``≥ 0`` (equations and assumptions in the class docstring). Validated input only (the
    callers'); pure, NumPy or JAX (the array law flies it), leading axes broadcast. Returns
    ``(u, active (...), h (..., n) [rad], m (..., n) [rad], v (..., n), a_b (..., n))``: the
    filtered command, where the filter changed it, and the start-of-period margins the warning
    of an unrecoverable start is built from."""
    xp = namespace(u, R, w)
    if lam_max is None:
        lam_max = float(np.linalg.eigvalsh(J)[-1])
    buf = math.radians(buffer_deg)
    m, v, a_free, p, a_b, h0, reach = _cone_certificates(
        R, w, J, cones, umax, lam_max, efficiency, T, buf
    )
    active = xp.zeros(u.shape[:-1], dtype=bool)
    # largest admissible approach acceleration a* per cone (closed form, see the function); a
    # cone out of reach this period gets the box's largest, a_hi: it constrains nothing
    a_hi = a_free + xp.einsum("...nk,k->...n", xp.abs(p), umax)
    a_star = xp.where(reach, a_hi, largest_approach_acceleration(m, v, a_b, a_hi, T, buf))
    # sequential projection of the command onto pᵀu ≤ a* − a_free, most critical cone last
    # (a stable sort by −h, as the compiled kernel's)
    order = xp.argsort(-h0, axis=-1)
    room = a_star - a_free
    for j in range(len(cones)):
        idx = order[..., j : j + 1]
        pj = xp.take_along_axis(p, idx[..., None], axis=-2)[..., 0, :]
        lim = xp.take_along_axis(room, idx, axis=-1)[..., 0]
        excess = xp.sum(pj * u, axis=-1) - lim
        need = excess > 0.0
        if any_true(need, xp):
            # the floor guards the division where p vanishes (on the branch not taken)
            pn2 = xp.maximum(xp.sum(pj * pj, axis=-1), 1e-300)
            u = xp.where(need[..., None], u - (excess / pn2)[..., None] * pj, u)
            u = xp.clip(u, -umax, umax)
            active = active | need
    # still violated after clipping: full braking for the most critical cone
    acc = a_free + xp.einsum("...nk,...k->...n", p, u)
    viol = xp.any(~reach & (acc > a_star + 1e-12 * xp.abs(a_star)), axis=-1)
    if any_true(viol, xp):
        crit = order[..., -1:]
        pc = xp.take_along_axis(p, crit[..., None], axis=-2)[..., 0, :]
        brake = -xp.sign(pc) * umax
        u = xp.where(viol[..., None], brake, u)
        active = active | viol
    return u, active, h0, m, v, a_b


def check_recoverable(
    h: np.ndarray,
    m: np.ndarray,
    v: np.ndarray,
    a_b: np.ndarray,
    cones: Sequence[AttitudeCone],
    max_torque: np.ndarray,
    sample_period: float,
    efficiency: float,
    buffer_deg: float,
    strict: bool,
) -> None:
    """Warn (:class:`UnrecoverableStartWarning`) or, ``strict``, raise ``ValueError`` naming
    ``R`` for the first spacecraft whose braking margin ``h`` (:func:`braking_filter`) is
    negative: the message gives the cone, margin, approach rate and the stopping distance
    needed."""
    bad = np.argwhere(h < 0.0)
    if not bad.size:
        return
    k, i = (int(x) for x in bad[0])
    cone = tuple(cones)[i]
    vp = max(float(v[k, i]), 0.0)
    need = vp * sample_period + vp * vp / (2.0 * a_b[k, i])
    msg = (
        f"R: spacecraft {k} starts in the unrecoverable set of {cone.kind.replace('_', '-')} "
        f"cone {i}: margin {math.degrees(m[k, i]):.3g}° with the boresight approaching at "
        f"{vp:.3g} rad/s; stopping needs {math.degrees(need):.3g}° (+{buffer_deg:g}° "
        f"buffer) at the certified deceleration {a_b[k, i]:.3g} rad/s² "
        f"(max_torque {max_torque.min():.3g} N·m, efficiency {efficiency:g}) with "
        f"a {sample_period:g} s sample period — the cone cannot be guaranteed"
    )
    if strict:
        raise ValueError(msg)
    import warnings

    warnings.warn(msg, UnrecoverableStartWarning, stacklevel=4)


class SampledSafeConstrainedPD(AttitudeController):
    """Keep-out/keep-in control that keeps the margin positive at its sample period under a torque
    bound: :class:`ConstrainedGeometricPD` (the log barrier, which steers around the cones) as
    the nominal command, clipped to the torque bound, then a one-step safety filter on the
    braking-distance-augmented margin of every cone.

    **Why.** The log barrier's guarantee is continuous-time with the torque delivered: its push
    grows like ``1/slack``, so a sampled loop approaching a cone fast gets a huge, late,
    zero-order-held command (a 120° slew through a 20° Sun cone at 0.1 rad/s toward it crossed
    the cone by 19.7° at a 0.1 s period, with a 5.1 MN·m command).

    **Margin with braking.** Per cone, with the geometric margin ``m`` [rad] (``φ − α`` keep-out,
    ``β − φ`` keep-in, ``φ`` the boresight's angle to the cone axis), the approach rate
    ``v = −ṁ`` and its acceleration ``−m̈ = a_free + pᵀu`` (exact at the sample, from
    ``φ̈ = −c̈/sin φ − ċ² cos φ/sin³ φ``, ``c = bᵀRᵀs``, ``c̈ = ġᵀω + gᵀJ⁻¹(u − ω × Jω)``), the
    certified braking deceleration is ``a_b = η u_min/λ_max(J) − max(a_free, 0)`` (``u_min``
    the smallest per-axis limit; ``‖J⁻¹ĝ‖₁ ≥ 1/λ_max`` for every approach direction) and

        h = m − v₊ T − v₊²/(2 a_b) − buffer,

    the margin left if the boresight brakes at ``a_b`` starting one sample period ``T`` late.

    **Filter.** At each sample, the command held over ``T`` is chosen so that the predicted
    ``h`` after the period (double-integrator prediction of ``m``, ``v`` under the held
    approach acceleration) stays ``≥ 0``: the nominal command is kept if it does; otherwise its
    component along ``p`` is reduced to the largest admissible approach acceleration (the
    smallest change of the command), and if the torque bound cannot realise that, the command
    is full braking ``u = −u_max sign(p)`` for the most critical cone. For the double-integrator
    model ``{h ≥ 0}`` is forward invariant under full braking (``h`` grows by at least
    ``a_b T²`` per braking period while ``v > a_b T``), so a start with ``h ≥ 0`` never reaches
    the boundary. The admissible approach acceleration is the root of the end-of-period margin
    in closed form (:func:`largest_approach_acceleration`).

    **Far from a cone.** The angle to a cone's axis is not smooth on the axis (keep-in) or
    opposite it (keep-out), where the curvature term of ``−m̈`` is unbounded though the boundary
    is far; a curvature-free certificate from the speed of the cone's direction in the body
    (``ω_s = ‖Rᵀs × ω‖ ≥ |φ̇|``, counted as approach along a geodesic) runs beside it: the
    margin is the larger of the two, and a cone whose straight-line margin stays ``≥ 0`` over
    the period for every command in the box constrains nothing (equations in the module's
    ``_cone_certificates``).

    **Assumptions.** The model is exact (inertia, no disturbance) and the torque bound is the
    actuator's (per axis, delivered within a sample); the approach geometry is predicted from
    the sample (the curvature of a keep-out cone's distance is favourable below 90° and is
    dropped from the braking budget; ``η`` < 1 covers the turning of the approach direction
    within a period, the rate and gyroscopic term are frozen over a period in the out-of-reach
    test); the cones are separated (one critical cone at a time); no keep-in cone is so narrow
    that its boundary lies within one braking distance of its axis; ``v T`` covers one
    period of delay, not more (no computation delay beyond the zero-order hold). From a start
    with ``h < 0`` (:func:`braking_margins_deg`, the unrecoverable set up to the certificate's
    conservatism) the first ``command`` warns (:class:`UnrecoverableStartWarning`; ``strict``:
    ``ValueError``) and the filter brakes at full torque. Liveness (reaching ``R_d``) is the
    nominal barrier law's, with its known limits (:class:`ConstrainedGeometricPD`); the filter
    can slow it.

    Args:
        J, k_R, k_Omega, keep_out, keep_in, barrier_weight: as :class:`ConstrainedGeometricPD`.
        max_torque: per-axis torque bound ``|u_i| ≤ u_max`` [N·m] (scalar or ``(3,)``; the
            actuator's limit).
        sample_period: the control period ``T`` [s] the law runs at (the simulator's
            ``control_period``).
        efficiency: ``η`` ∈ (0, 1], the share of the torque bound counted on for braking
            (default 0.7).
        buffer_deg: margin kept in reserve [deg] (≥ 0, default 0.5).
        strict: raise instead of warning for an unrecoverable start.

    ``diagnostics()``: the nominal law's plus ``braking_margin`` ``(B,)`` [deg] (smallest ``h``
    over the cones), ``margin`` ``(B,)`` [deg] (smallest geometric margin) and ``filter_active``
    ``(B,)`` (the filter changed the nominal command).
    """

    batched = True

    def __init__(
        self,
        J: object,
        k_R: object,
        k_Omega: object,
        keep_out: Sequence[KeepOutCone] = (),
        keep_in: Sequence[KeepInCone] = (),
        barrier_weight: float = 0.5,
        *,
        max_torque: object,
        sample_period: float,
        efficiency: float = 0.7,
        buffer_deg: float = 0.5,
        strict: bool = False,
    ) -> None:
        self.nominal = ConstrainedGeometricPD(J, k_R, k_Omega, keep_out, keep_in, barrier_weight)
        self.J = self.nominal.J
        self.keep_out = self.nominal.keep_out
        self.keep_in = self.nominal.keep_in
        self.max_torque = _check_max_torque(max_torque)
        T = as_scalar(sample_period, "sample_period")
        if not T > 0.0:
            raise ValueError(f"sample_period: must be > 0 [s], got {T}")
        self.sample_period = T
        self.efficiency = _efficiency(efficiency)
        b = as_scalar(buffer_deg, "buffer_deg")
        if not b >= 0.0:
            raise ValueError(f"buffer_deg: must be >= 0, got {b}")
        self.buffer_deg = b
        if not isinstance(strict, bool):
            raise TypeError(f"strict: expected True or False, got {strict!r}")
        self.strict = strict
        self._lam_max = float(np.linalg.eigvalsh(self.J)[-1])
        self._first = True
        self._diag: dict[str, np.ndarray] = {}

    def __repr__(self) -> str:
        return (
            f"SampledSafeConstrainedPD(keep_out={len(self.keep_out)}, "
            f"keep_in={len(self.keep_in)}, max_torque={self.max_torque.tolist()}, "
            f"sample_period={self.sample_period})"
        )

    def reset(self, t0: float, batch_size: int) -> None:
        self.nominal.reset(t0, batch_size)
        self._first = True
        self._diag = {}

    def _unrecoverable(self, h: np.ndarray, m: np.ndarray, v: np.ndarray, a_b: np.ndarray) -> None:
        check_recoverable(
            h,
            m,
            v,
            a_b,
            self.keep_out + self.keep_in,
            self.max_torque,
            self.sample_period,
            self.efficiency,
            self.buffer_deg,
            self.strict,
        )

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m], within ``max_torque``."""
        u_nom = self.nominal.command(t, state, reference)
        R = np.asarray(state.R, dtype=np.float64).reshape(-1, 3, 3)
        w = np.asarray(state.omega, dtype=np.float64).reshape(-1, 3)
        umax = self.max_torque
        u = np.clip(u_nom, -umax, umax)
        T = self.sample_period
        cones = self.keep_out + self.keep_in
        if not cones:
            self._diag = dict(self.nominal.diagnostics())
            return u
        u, active, h0, m, v, a_b = braking_filter(
            u, R, w, self.J, cones, umax, T, self.efficiency, self.buffer_deg, self._lam_max
        )
        if self._first:
            self._first = False
            self._unrecoverable(h0, m, v, a_b)
        diag = dict(self.nominal.diagnostics())
        diag.update(
            braking_margin=np.degrees(h0.min(axis=-1)),
            margin=np.degrees(m.min(axis=-1)),
            filter_active=active,
        )
        self._diag = diag
        return finite_command(u, w)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last diagnostics (class docstring); empty before the first command."""
        return dict(self._diag)

    def array_law(self) -> ArrayLaw:
        """The law as a pure array function for the differentiable loop
        (:mod:`liecontrol.control.array_law`): the nominal barrier law's
        (:meth:`ConstrainedGeometricPD.array_law`), clipped to the torque box, then
        :func:`braking_filter` — the functions :meth:`command` calls — at ``sample_period``;
        the state is the nominal law's (its first-sample flag), ``barrier_weight`` a further
        parameter. The warning of an unrecoverable start (:func:`braking_margins_deg` < 0 at the
        first sample) is not issued on this route (the logged ``braking_margin`` shows it);
        ``strict``, which refuses such a start, is refused (``ValueError`` naming
        ``controller.strict``)."""
        if self.strict:
            raise ValueError(
                "controller.strict: the array law cannot refuse an unrecoverable start (it has "
                "no hook before the first sample); use strict=False and check "
                "braking_margins_deg, or the numba loop"
            )
        nom = self.nominal.array_law()
        cones = self.keep_out + self.keep_in
        J, umax, T = np.array(self.J), np.array(self.max_torque), self.sample_period
        eta, buf, lam = self.efficiency, self.buffer_deg, self._lam_max

        def step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T_loop, *, params):  # noqa: ANN001
            u, state, d = nom.step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d,
                                   T_loop, params=params)  # fmt: skip
            xp = namespace(u)
            u = xp.clip(u, -umax, umax)
            if not cones:
                return u, state, d
            u, active, h0, m, _, _ = braking_filter(u, R, omega, J, cones, umax, T, eta, buf, lam)
            d = {**d, "braking_margin": xp.degrees(h0.min(axis=-1)),
                 "margin": xp.degrees(m.min(axis=-1)), "filter_active": active}  # fmt: skip
            return u, state, d

        return ArrayLaw(nom.k_R, nom.k_Omega, nom.state0, step, params=dict(nom.params))

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.constrained.sampled_safe_pd_law`: the
        barrier law's kernel, then the filter's) for the simulator's fused loop
        (:mod:`liecontrol.control.kernel`). The filter runs at ``sample_period`` whatever the
        loop's period, as ``command`` does. An unrecoverable start is warned about (``strict``:
        refused) before the first step, by the kernel's ``preflight`` on the initial state, as
        ``command`` does at its first sample."""
        nom = self.nominal.fused_kernel(batch_size, control_period)
        if nom is None:
            return None
        cones = self.keep_out + self.keep_in
        n = len(cones)
        filt = np.concatenate(
            [
                self.max_torque,
                [self.sample_period, self.efficiency, math.radians(self.buffer_deg)],
                [self._lam_max],
                np.linalg.inv(self.J).ravel(),
                [1.0 if self.strict else 0.0],
                [float(np.linalg.norm(self.max_torque)) / float(np.linalg.eigvalsh(self.J)[0])],
                [math.radians(c.half_angle_deg) for c in cones],
            ]
        )
        B = int(batch_size)
        state = np.zeros((B, N_STATE + 1 + 4 * n))
        state[:, :N_STATE] = nom.state
        state[:, N_STATE] = 0.0 if self._first else 1.0
        first = self._first

        def rows(r: np.ndarray) -> dict[str, np.ndarray]:
            d = _constrained_rows(r[..., :N_DIAG])
            if n:
                d.update(
                    braking_margin=np.degrees(r[..., N_DIAG]),
                    margin=np.degrees(r[..., N_DIAG + 1]),
                    filter_active=r[..., N_DIAG + 2] != 0.0,
                )
            return d

        def finish(st: np.ndarray, diag: np.ndarray) -> None:
            nom.finish(st[:, :N_STATE], diag[:, :N_DIAG])
            self._first = bool(st[0, N_STATE] == 0.0)
            self._diag = rows(diag)

        def preflight(t0: float, R: np.ndarray, w: np.ndarray, reference: object) -> None:
            if not (first and n):
                return
            # the margins do not depend on the command: the braking filter on a zero one
            _, _, h0, m, v, a_b = braking_filter(
                np.zeros((B, 3)), R, w, self.J, cones, self.max_torque, self.sample_period,
                self.efficiency, self.buffer_deg, self._lam_max,
            )  # fmt: skip
            self._unrecoverable(h0, m, v, a_b)

        return ControllerKernel(
            sampled_safe_pd_law,
            np.concatenate([nom.params, filt]),
            state,
            N_DIAG_SAFE if n else N_DIAG,
            rows,
            finish,
            preflight=preflight,
        )
