"""Controllers (SPEC §6) behind the common seams.

Attitude controllers implement :class:`~liecontrol.control.base.AttitudeController` (body torque);
pose controllers implement :class:`~liecontrol.control.se3_control.PoseController` (body wrench).
"""

from .base import AttitudeController, AttitudeReference, AttitudeState
from .geometric_pd import GeometricPD, gains_from_bandwidth
from .geometric_pid import IntegralPD, IntrinsicPID, integral_gain
from .mpc import SO3MPC
from .prescribed_performance import PrescribedPerformance, ppc_gains
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
    "IntrinsicPID",
    "IntegralPD",
    "integral_gain",
    "PrescribedPerformance",
    "ppc_gains",
    "PoseController",
    "PoseReference",
    "PoseState",
    "ConstantPose",
    "BulloMurrayPD",
    "SE3TrackingController",
    "pose_gains_from_bandwidth",
]
