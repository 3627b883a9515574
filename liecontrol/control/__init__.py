"""Controllers (SPEC §6) behind the common seams.

Attitude controllers implement :class:`~liecontrol.control.base.AttitudeController` (body torque);
pose controllers implement :class:`~liecontrol.control.se3_control.PoseController` (body wrench).
"""

from .base import AttitudeController, AttitudeReference, AttitudeState
from .geometric_pd import GeometricPD, gains_from_bandwidth
from .mpc import SO3MPC
from .reference import ConstantAttitude
from .se3_control import (
    BulloMurrayPD,
    ConstantPose,
    PoseController,
    PoseReference,
    PoseState,
    SE3TrackingController,
    pose_gains_from_bandwidth,
)

__all__ = [
    "AttitudeController",
    "AttitudeReference",
    "AttitudeState",
    "ConstantAttitude",
    "GeometricPD",
    "gains_from_bandwidth",
    "SO3MPC",
    "PoseController",
    "PoseReference",
    "PoseState",
    "ConstantPose",
    "BulloMurrayPD",
    "SE3TrackingController",
    "pose_gains_from_bandwidth",
]
