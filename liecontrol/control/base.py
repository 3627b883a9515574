"""The controller seam (SPEC §1, §6): a controller sees a state and a reference, returns a torque.

All arrays are batched: the leading axis ``B`` indexes independent spacecraft; a single run is a
batch of one. See ``docs/design.md``.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np

from .._validation import as_array

__all__ = ["AttitudeState", "AttitudeReference", "AttitudeController", "check_state_batch"]


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

    @property
    def batch_size(self) -> int:
        return int(self.R.shape[0])


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
