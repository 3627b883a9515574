"""Safe-mode Sun acquisition: rate damping and pointing of a body axis at a measured direction.

Law (reduced-attitude PD on the sphere; Chaturvedi, Sanyal & McClamroch, "Rigid-body attitude
control", *IEEE Control Systems Magazine* 31(3), 2011, §"Reduced attitude"; the rate-damping +
Sun-pointing structure of safe modes that fly on coarse Sun sensors and gyros, Markley &
Crassidis, *Fundamentals of Spacecraft Attitude Determination and Control*, Springer, 2014)::

    τ = k_p (b × ŝ) − k_d ω

with ``b`` the body axis to point at the Sun (e.g. the solar-array normal), ``ŝ`` the unit Sun
vector in body axes and ``ω`` the body rate. With ``V = k_p (1 − bᵀŝ) + ½ ωᵀJω`` and
``ŝ̇ = ŝ × ω`` (the Sun is fixed in inertial space over an acquisition: it moves ≈ 2e-7 rad/s),
``V̇ = −k_d ‖ω‖²``: the energy never increases, whatever ``J`` (the gyroscopic term does no
work, so the law needs no inertia model) and the rate is damped while the axis swings to the Sun.
``ŝ = b`` is the stable equilibrium; ``ŝ = −b`` (Sun behind) is a saddle, left by any
perturbation. The rotation about the Sun line is not controlled (a reduced attitude): it is
only damped. Small-angle loop about ``ŝ = b``: ``J_i φ̈ + k_d φ̇ + k_p φ = 0`` on each transverse
axis (:func:`sun_acquisition_gains`).

Where ``ŝ`` comes from. A :class:`DirectionMeasurement` (a state that carries a measured
``direction`` and a ``valid`` flag, e.g. built by ``spacecraft.sun_sensors.SunSensorGyro`` from
coarse Sun sensors and a gyro) gives it directly; any other state (true state, a star-tracker
estimate) gives ``ŝ = Rᵀ R_d b``: the reference's ``R_d`` says where ``b`` should point
(``R_d b`` in inertial axes) and its roll about that line is ignored.

Eclipse (no valid direction): ``eclipse="damp"`` — rate damping only, ``τ = −k_d ω``: the
rate decays and the attitude holds wherever it was; ``eclipse="propagate"`` — the last valid
``ŝ`` is carried forward with the measured rate, ``ŝ(t + Δ) = exp(−Δ ω^) ŝ(t)``, and the
pointing term stays on (it then drifts with the gyro's bias). Before any valid direction,
``"propagate"`` damps too.

Torque limit: with ``max_torque`` the command is scaled as a vector into the per-axis box (the
direction is kept); the energy argument above holds while the box is not reached, and after it
the damping term still dominates at high rates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._linalg import cross as _cross
from .._validation import as_array, check_inertia_3x3, check_positive_scalar
from ..lie import so3
from .base import (
    AttitudeController,
    AttitudeReference,
    AttitudeState,
    check_state_batch,
    finite_command,
    validated_rotation_and_rate,
)

__all__ = [
    "ECLIPSE_MODES",
    "DirectionMeasurement",
    "SunAcquisitionLaw",
    "sun_acquisition_gains",
]

#: What :class:`SunAcquisitionLaw` does without a valid Sun direction.
ECLIPSE_MODES: tuple[str, ...] = ("damp", "propagate")


@dataclass(frozen=True)
class DirectionMeasurement(AttitudeState):
    """A state that carries a measured unit direction (the Sun) in body axes.

    Attributes (beyond :class:`AttitudeState`'s):
        direction: ``(B, 3)`` measured direction in body axes (normalised by the law; ignored
            where not ``valid``).
        valid: ``(B,)`` bool: whether ``direction`` holds a measurement (False in eclipse or
            when no sensor is lit); ``None``: all valid.

    ``R`` should be what the spacecraft knows of its attitude; a law that reads ``direction``
    does not use it.
    """

    direction: np.ndarray | None = None
    valid: np.ndarray | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        B = self.R.shape[:-2]
        if self.direction is None:
            raise ValueError("direction: expected a (B, 3) array, got None")
        d = as_array(self.direction, "direction", (3,))
        if d.shape[:-1] != B:
            raise ValueError(f"direction: batch shape {d.shape[:-1]} does not match R's {B}")
        object.__setattr__(self, "direction", d)
        if self.valid is not None:
            v = np.asarray(self.valid)
            if v.dtype != bool or v.shape != B:
                raise ValueError(f"valid: expected a bool array of shape {B}, got {v!r}")
            object.__setattr__(self, "valid", v)

    @classmethod
    def unchecked(  # type: ignore[override]
        cls,
        R: np.ndarray,
        omega: np.ndarray,
        h: np.ndarray | None = None,
        actuator_state: np.ndarray | None = None,
        direction: np.ndarray | None = None,
        valid: np.ndarray | None = None,
    ) -> DirectionMeasurement:
        """Build without validation (a measurement hook's own arrays, every control sample)."""
        obj = object.__new__(cls)
        for k, v in (
            ("R", R),
            ("omega", omega),
            ("h", h),
            ("actuator_state", actuator_state),
            ("direction", direction),
            ("valid", valid),
        ):
            object.__setattr__(obj, k, v)
        return obj


def sun_acquisition_gains(J: object, omega_n: float, zeta: float) -> dict[str, float]:
    """``{"k_p": λ_max ω_n², "k_d": 2ζω_n λ_max}`` with ``λ_max`` the largest principal moment
    of ``J``: the small-angle loop ``J_i φ̈ + k_d φ̇ + k_p φ = 0`` then has natural frequency
    ``ω_n`` and damping ``ζ`` about the largest axis, and ``ω_n√(λ_max/J_i)``,
    ``ζ√(λ_max/J_i)`` (faster, better damped) about the others."""
    Jm = check_inertia_3x3(J, "J")
    wn = check_positive_scalar(omega_n, "omega_n")
    z = check_positive_scalar(zeta, "zeta")
    lam = float(np.linalg.eigvalsh(Jm)[-1])
    k_p, k_d = lam * wn * wn, 2.0 * z * wn * lam
    if not (math.isfinite(k_p) and math.isfinite(k_d)):
        raise ValueError(
            f"omega_n: the gains overflow float64 (omega_n = {wn:.3g}, zeta = {z:.3g})"
        )
    return {"k_p": k_p, "k_d": k_d}


def _box(x: object, name: str) -> np.ndarray | None:
    if x is None:
        return None
    a = as_array(x, name)
    if a.shape not in ((), (3,)) or not np.all(a > 0.0):
        raise ValueError(f"{name}: expected a scalar or 3 values, each > 0, got {x!r}")
    return np.array(np.broadcast_to(a, (3,)), dtype=np.float64)


class SunAcquisitionLaw(AttitudeController):
    """Rate damping + Sun pointing ``τ = k_p (b × ŝ) − k_d ω`` (module docstring).

    Args:
        k_p: pointing gain [N·m] (> 0).
        k_d: rate-damping gain [N·m·s] (> 0).
        body_axis: ``b``, the body axis to point at the Sun ``(3,)`` (normalised; non-zero).
        max_torque: per-axis torque box [N·m] (scalar or 3 values, > 0) or ``None``.
        eclipse: ``"damp"`` or ``"propagate"`` (:data:`ECLIPSE_MODES`).

    Diagnostics: ``sun_angle`` ``(B,)`` [rad], the angle between ``b`` and the ``ŝ`` the law
    used (NaN when it had none), and ``sun_valid`` ``(B,)``.
    """

    def __init__(
        self,
        k_p: float,
        k_d: float,
        body_axis: object = (0.0, 0.0, 1.0),
        max_torque: object = None,
        eclipse: str = "damp",
    ) -> None:
        self.k_p = check_positive_scalar(k_p, "k_p")
        self.k_d = check_positive_scalar(k_d, "k_d")
        b = as_array(body_axis, "body_axis")
        if b.shape != (3,):
            raise ValueError(f"body_axis: expected shape (3,), got {b.shape}")
        nb = float(np.linalg.norm(b))
        if not nb > 0.0 or not math.isfinite(nb):
            raise ValueError(f"body_axis: expected a finite non-zero vector, got {body_axis!r}")
        self.body_axis = b / nb
        self.max_torque = _box(max_torque, "max_torque")
        if not isinstance(eclipse, str) or eclipse not in ECLIPSE_MODES:
            raise ValueError(f"eclipse: expected one of {ECLIPSE_MODES}, got {eclipse!r}")
        self.eclipse = eclipse
        self._B = 1
        self._s: np.ndarray | None = None
        self._have = np.zeros(1, dtype=bool)
        self._t_last: float | None = None
        self._diag: dict[str, np.ndarray] = {}

    def reset(self, t0: float, batch_size: int) -> None:
        self._B = int(batch_size)
        self._s = np.tile(self.body_axis, (self._B, 1))
        self._have = np.zeros(self._B, dtype=bool)
        self._t_last = None
        self._diag = {}

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        R, w = validated_rotation_and_rate(state)
        B = check_state_batch(R, w, self._B)
        b = self.body_axis
        d = getattr(state, "direction", None)
        if d is None:
            # where R_d puts b, seen from the body: Rᵀ (R_d b)
            target = np.asarray(reference.R_d) @ b
            s = np.einsum("...ji,...j->...i", R, np.broadcast_to(target, (B, 3)))
            valid = np.ones(B, dtype=bool)
        else:
            d = np.asarray(d, dtype=np.float64)
            nd = np.linalg.norm(d, axis=-1)
            v = getattr(state, "valid", None)
            valid = np.ones(B, dtype=bool) if v is None else np.asarray(v, dtype=bool)
            valid = valid & (nd > 0.0) & np.isfinite(nd)
            s = np.where(valid[:, None], d / np.where(valid, nd, 1.0)[:, None], 0.0)
        point = valid.copy()
        assert self._s is not None
        if self.eclipse == "propagate" and not valid.all():
            if self._t_last is not None:
                # the Sun is fixed inertially: ṡ = s × ω, held ω over the control period
                dt = float(t) - self._t_last
                self._s = np.einsum("bij,bj->bi", so3.exp(-dt * w), self._s)
            fill = ~valid & self._have
            s = np.where(fill[:, None], self._s, s)
            point |= fill
        tau = np.where(point[:, None], self.k_p * _cross(b, s), 0.0) - self.k_d * w
        if self.max_torque is not None:
            ratio = (np.abs(tau) / self.max_torque).max(axis=-1, keepdims=True)
            tau = tau / np.maximum(ratio, 1.0)
        self._s = np.where(point[:, None], s, self._s)
        self._have = self._have | point
        self._t_last = float(t)
        ang = np.arccos(np.clip(s @ b, -1.0, 1.0))
        self._diag = {"sun_angle": np.where(point, ang, np.nan), "sun_valid": valid}
        return finite_command(tau, w)

    def diagnostics(self) -> dict[str, np.ndarray]:
        return dict(self._diag)
