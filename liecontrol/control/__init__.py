"""Controllers (SPEC §6) behind the common seam of :mod:`liecontrol.control.base`."""

from .base import AttitudeController, AttitudeReference, AttitudeState
from .geometric_pd import GeometricPD, gains_from_bandwidth
from .reference import ConstantAttitude

__all__ = [
    "AttitudeController",
    "AttitudeReference",
    "AttitudeState",
    "ConstantAttitude",
    "GeometricPD",
    "gains_from_bandwidth",
]
