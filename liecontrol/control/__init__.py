"""Controllers behind the common seams.

Attitude controllers implement :class:`~liecontrol.control.base.AttitudeController` (body torque);
pose controllers implement :class:`~liecontrol.control.se3_control.PoseController` (body wrench).
"""

from .adapters import (
    ChartAdapter,
    ChartState,
    EulerChartAdapter,
    MrpChartAdapter,
    QuaternionChartAdapter,
    RotatingFrame,
)
from .adaptive import AdaptiveGeometricSO3
from .adrc import ADRCParams, MrpADRC, eso_gains_from_poles
from .base import AttitudeController, AttitudeReference, AttitudeState
from .chart_baselines import MrpPD, QuaternionPD
from .consensus import (
    AttitudeConsensus,
    CommunicationGraph,
    LeaderFollowerConsensus,
    PoseFormation,
)
from .constrained import ConstrainedGeometricPD, KeepInCone, KeepOutCone
from .eigenaxis import RateLimitedEigenaxis, wie_lu_gains
from .finite_time import FiniteTimeSO3, FixedTimeSO3
from .geometric_pd import GeometricPD, gains_from_bandwidth
from .geometric_pid import IntegralPD, IntrinsicPID, integral_gain
from .mpc import SO3MPC
from .payload_compensation import HarmonicIdentifier, SmallAnglePIDWithFeedforward, pid_gains
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
from .slew_profile import EigenaxisSlewProfile, eigenaxis_accel_limit, scurve_timing
from .terminal_sliding_mode import TerminalSlidingMode, TerminalSlidingModeSO3
from .tuning import (
    ActuatorLimits,
    ClosedLoopSpec,
    TuningInfeasible,
    measure_small_angle_response,
)

__all__ = [
    "AttitudeController",
    "AttitudeReference",
    "AttitudeState",
    "ConstantAttitude",
    "EigenaxisSlewProfile",
    "eigenaxis_accel_limit",
    "scurve_timing",
    "RateLimitedEigenaxis",
    "wie_lu_gains",
    "GeometricPD",
    "gains_from_bandwidth",
    "SO3MPC",
    "IntrinsicPID",
    "IntegralPD",
    "AdaptiveGeometricSO3",
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
    "ChartAdapter",
    "ChartState",
    "EulerChartAdapter",
    "MrpChartAdapter",
    "QuaternionChartAdapter",
    "RotatingFrame",
    "ADRCParams",
    "MrpADRC",
    "eso_gains_from_poles",
    "MrpPD",
    "QuaternionPD",
    "HarmonicIdentifier",
    "SmallAnglePIDWithFeedforward",
    "pid_gains",
    "TerminalSlidingMode",
    "TerminalSlidingModeSO3",
    "FiniteTimeSO3",
    "FixedTimeSO3",
    "ClosedLoopSpec",
    "ActuatorLimits",
    "TuningInfeasible",
    "measure_small_angle_response",
    "ConstrainedGeometricPD",
    "KeepOutCone",
    "KeepInCone",
    "CommunicationGraph",
    "AttitudeConsensus",
    "LeaderFollowerConsensus",
    "PoseFormation",
]
