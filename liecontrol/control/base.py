"""The controller seam: a controller sees a state and a reference, returns a torque.

All arrays are batched: the leading axis ``B`` indexes independent spacecraft; a single run is a
batch of one. See ``docs/design.md``.

The state and reference containers validate what they are given (finite real arrays of the
documented trailing shapes, rotations orthonormal within 1e-9, matching batch shapes) and raise
``ValueError`` naming the field. Simulators that build them every control step from already
validated arrays use :meth:`AttitudeState.unchecked` / :meth:`AttitudeReference.unchecked`.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass

import numpy as np

from .._validation import as_array, check_rotation_matrix, rotations_pass_fast

__all__ = [
    "AttitudeState",
    "AttitudeReference",
    "AttitudeController",
    "check_state_batch",
    "finite_command",
]


@dataclass(frozen=True)
class AttitudeState:
    """Attitude state handed to a controller (true state or an estimate).

    Attributes:
        R: ``(B, 3, 3)`` attitude, body → inertial.
        omega: ``(B, 3)`` body angular velocity [rad/s].
        h: ``(B, 3)`` stored actuator momentum in body axes [N·m·s], or ``None`` if unknown.
        actuator_state: ``(B, n)`` actuator internal states (e.g. CMG gimbal angles), or
            ``None``; for controllers that constrain the hardware (MPC gimbal-rate limits).
    """

    R: np.ndarray
    omega: np.ndarray
    h: np.ndarray | None = None
    actuator_state: np.ndarray | None = None

    def __post_init__(self) -> None:
        R = _rotation(self.R, "R")
        omega = as_array(self.omega, "omega", (3,))
        _same_batch("omega", omega.shape[:-1], R.shape[:-2])
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "omega", omega)
        if self.h is not None:
            h = as_array(self.h, "h", (3,))
            _same_batch("h", h.shape[:-1], R.shape[:-2])
            object.__setattr__(self, "h", h)
        if self.actuator_state is not None:
            a = as_array(self.actuator_state, "actuator_state")
            if a.ndim < 1 or a.shape[:1] != R.shape[:1]:
                raise ValueError(
                    f"actuator_state: expected shape (B, n) with B = {R.shape[:1]}, got {a.shape}"
                )
            object.__setattr__(self, "actuator_state", a)

    @classmethod
    def unchecked(
        cls,
        R: np.ndarray,
        omega: np.ndarray,
        h: np.ndarray | None = None,
        actuator_state: np.ndarray | None = None,
    ) -> AttitudeState:
        """Build without validation: for simulators that pass arrays they have validated (or
        produced themselves) at every control step. Garbage in, garbage out."""
        obj = object.__new__(cls)
        object.__setattr__(obj, "R", R)
        object.__setattr__(obj, "omega", omega)
        object.__setattr__(obj, "h", h)
        object.__setattr__(obj, "actuator_state", actuator_state)
        return obj

    @property
    def batch_size(self) -> int:
        return int(self.R.shape[0])


def _rotation(R: object, name: str) -> np.ndarray:
    """A finite float64 ``(..., 3, 3)`` rotation array (fast check first)."""
    if rotations_pass_fast(R):
        return R  # type: ignore[return-value]
    return check_rotation_matrix(R, name)


def _same_batch(name: str, shape: tuple[int, ...], ref: tuple[int, ...]) -> None:
    if tuple(shape) != tuple(ref):
        raise ValueError(f"{name}: batch shape {tuple(shape)} does not match R's {tuple(ref)}")


@dataclass(frozen=True)
class AttitudeReference:
    """Desired attitude trajectory sample.

    Attributes:
        R_d: ``(B, 3, 3)`` or ``(3, 3)`` desired attitude (desired body → inertial).
        omega_d: ``(B, 3)`` or ``(3,)`` desired angular velocity in the desired body frame.
        omega_dot_d: ``(B, 3)`` or ``(3,)`` its time derivative.
    """

    R_d: np.ndarray
    omega_d: np.ndarray
    omega_dot_d: np.ndarray

    def __post_init__(self) -> None:
        R = _rotation(self.R_d, "R_d")
        w = as_array(self.omega_d, "omega_d", (3,))
        dw = as_array(self.omega_dot_d, "omega_dot_d", (3,))
        # one sample (3,) may go with a batch of attitudes and vice versa: shapes broadcast
        for name, a in (("omega_d", w), ("omega_dot_d", dw)):
            try:
                np.broadcast_shapes(a.shape[:-1], R.shape[:-2])
            except ValueError:
                raise ValueError(
                    f"{name}: batch shape {a.shape[:-1]} does not broadcast against R_d's "
                    f"{R.shape[:-2]}"
                ) from None
        object.__setattr__(self, "R_d", R)
        object.__setattr__(self, "omega_d", w)
        object.__setattr__(self, "omega_dot_d", dw)

    @classmethod
    def unchecked(
        cls, R_d: np.ndarray, omega_d: np.ndarray, omega_dot_d: np.ndarray
    ) -> AttitudeReference:
        """Build without validation (arrays the caller has validated; see
        :meth:`AttitudeState.unchecked`)."""
        obj = object.__new__(cls)
        object.__setattr__(obj, "R_d", R_d)
        object.__setattr__(obj, "omega_d", omega_d)
        object.__setattr__(obj, "omega_dot_d", omega_dot_d)
        return obj

    @classmethod
    def regulation(cls, R_d: object) -> AttitudeReference:
        """A constant attitude with zero desired rate (rest-to-rest, stabilisation)."""
        R = as_array(R_d, "R_d", (3, 3))
        zero = np.zeros(R.shape[:-1])
        return cls(R_d=R, omega_d=zero, omega_dot_d=zero)


class AttitudeController(abc.ABC):
    """Common controller interface: ``reset`` once, then ``command`` at each control sample.

    Subclasses set ``batched = False`` when ``command`` only supports ``B == 1`` (stateful
    chart-based controllers may step per spacecraft; the runner then loops for them).
    """

    batched: bool = True

    @abc.abstractmethod
    def reset(self, t0: float, batch_size: int) -> None:
        """Clear internal state before a run starting at ``t0`` for ``batch_size`` spacecraft."""

    @abc.abstractmethod
    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque command ``(B, 3)`` [N·m]."""

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Controller internals to log at the last sample, as ``(B, ...)`` arrays."""
        return {}


def finite_command(u: np.ndarray, rate: object, name: str = "omega") -> np.ndarray:
    """Return the command ``u`` if it is finite, else raise ``ValueError`` naming the state's
    rate: with finite, validated gains and states only an overflow (e.g. ω × Jω with |ω| ~
    1e160) can make it non-finite, and a NaN torque must never reach an actuator.

    The check is one sum over ``u`` (inf/NaN propagate through it), cheap enough for every
    control step."""
    # one spacecraft: Python floats beat a numpy reduction's call overhead by ~10×
    total = sum(u.ravel().tolist()) if u.size <= 12 else float(u.sum())
    if not math.isfinite(total):
        r = np.asarray(rate, dtype=np.float64)
        big = float(np.abs(r).max()) if r.size else float("nan")
        raise ValueError(
            f"{name}: the command is not finite (max |{name}| = {big:.3g}; the gyroscopic and "
            "feedback terms overflow float64 for rates this large)"
        )
    return u


def check_state_batch(R: np.ndarray, omega: np.ndarray, batch_size: int) -> int:
    """Check that validated ``R`` ``(B, 3, 3)`` and ``omega`` ``(B, 3)`` of an
    :class:`AttitudeState` form one batch of the size given to ``reset``; return ``B``."""
    if R.ndim != 3 or omega.shape != (R.shape[0], 3):
        raise ValueError(
            f"state: expected R (B, 3, 3) and omega (B, 3), got {R.shape} and {omega.shape}"
        )
    B = R.shape[0]
    if B != batch_size:
        raise ValueError(f"state: batch size {B} differs from reset(batch_size={batch_size})")
    return B


_F64 = np.dtype(np.float64)


def _vectors_pass(x: object, shape: tuple[int, ...]) -> bool:
    """A float64 ndarray of exactly ``shape`` with finite entries (one reduction)."""
    if not (isinstance(x, np.ndarray) and x.dtype == _F64 and x.shape == shape):
        return False
    # a few entries: a Python sum is ~4× cheaper than a numpy reduction
    return math.isfinite(sum(x.ravel().tolist()) if x.size <= 16 else float(x.sum()))


def validated_rotation_and_rate(state: AttitudeState) -> tuple[np.ndarray, np.ndarray]:
    """``(R, ω)`` of a state, validated: the simulator's own arrays (finite float64
    ``(B, 3, 3)`` rotations and ``(B, 3)`` rates) pass the cheap checks once per sample;
    anything else is validated in full, with messages naming ``R`` or ``omega``."""
    R, w = state.R, state.omega
    if not (
        isinstance(R, np.ndarray)
        and R.ndim == 3
        and _vectors_pass(w, (R.shape[0], 3))
        and rotations_pass_fast(R)
    ):
        R = check_rotation_matrix(R, "R")
        w = as_array(w, "omega", (3,))
    return R, w
