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
there, and starts near them converge slowly. (2) The guarantee needs the torque to be delivered:
with actuator saturation (or model error, or a long sample period) the barrier's torque — which
grows like ``1/slack`` — is clipped and the boresight can cross the boundary; nothing is hidden
then: :func:`cone_margins_deg` reports the negative margin and the controller keeps commanding
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

import numpy as np

from .._validation import as_array, as_int, as_scalar, check_inertia_3x3, check_rotation_matrix
from ..errors import _large_angle_error_unchecked
from .base import (
    AttitudeController,
    AttitudeReference,
    AttitudeState,
    check_state_batch,
    finite_command,
)
from .geometric_pd import _apply_gain, _cross, check_gain

__all__ = [
    "KeepOutCone",
    "KeepInCone",
    "SLACK_FLOOR",
    "cone_margins_deg",
    "check_admissible",
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
    normalised for the formulas; the half-angle must be in (0°, 180°)."""

    kind = "keep_out"

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


def _barrier_terms(
    R: np.ndarray, cones: tuple, w: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Σβ_i (B,), Σ∇β_i (B, 3), min normalised slack (B,))`` at ``R`` ``(B, 3, 3)``."""
    B = R.shape[0]
    beta = np.zeros(B)
    grad = np.zeros((B, 3))
    smin = np.full(B, np.inf)
    for cone in cones:
        s_body = np.swapaxes(R, -1, -2) @ cone._s  # Rᵀs, (B, 3)
        c = s_body @ cone._b
        gc = _cross(np.broadcast_to(cone._b, s_body.shape), s_body)  # ∇c = b × Rᵀs
        ca = cone.cos_half_angle
        if cone.kind == "keep_out":
            slack, scale, sign = ca - c, 1.0 + ca, 1.0
        else:
            slack, scale, sign = c - ca, 1.0 - ca, -1.0
        x = np.maximum(slack / scale, SLACK_FLOOR)
        smin = np.minimum(smin, slack / scale)
        beta += -w * np.log(x)
        # d/dε of −w ln(slack): keep-out slack' = −∇c·ω, keep-in slack' = +∇c·ω
        grad += (sign * w / (x * scale))[:, None] * gc
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


def _potential(
    R: np.ndarray, Rt: np.ndarray, cones: tuple, w: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    Psi_A, e_A = _large_angle_error_unchecked(Rt)
    beta, grad, smin = _barrier_terms(R, cones, w)
    Psi = Psi_A * (1.0 + beta)
    e_C = (1.0 + beta)[:, None] * e_A + Psi_A[:, None] * grad
    return Psi, e_C, smin


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
        Rt = np.swapaxes(R_d, -1, -2) @ R
        RtT = np.swapaxes(Rt, -1, -2)
        Psi, e_C, smin = _potential(R, Rt, self._cones, self.barrier_weight)
        J = self.J
        w_d_body = (RtT @ w_d[..., None])[..., 0]
        dw_d_body = (RtT @ dw_d[..., None])[..., 0]
        e_W = w - w_d_body
        ff = _cross(w, w @ J.T) - (_cross(w, w_d_body) - dw_d_body) @ J.T
        M = ff - _apply_gain(self.k_R, e_C) - _apply_gain(self.k_Omega, e_W)
        self._diag = {"Psi": Psi, "e_R": e_C, "e_Omega": e_W, "min_slack": smin}
        return finite_command(M, w)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last ``Psi``, ``e_R``, ``e_Omega``, ``min_slack`` (empty before the first command)."""
        return dict(self._diag)
