"""Controllers (SPEC §6) behind the common seam of :mod:`liecontrol.control.base`."""

from .base import AttitudeController, AttitudeReference, AttitudeState
from .reference import ConstantAttitude

__all__ = ["AttitudeController", "AttitudeReference", "AttitudeState", "ConstantAttitude"]
