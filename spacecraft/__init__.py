"""spacecraft: the plant (rigid body, flexible modes, actuators, disturbances, environment,
sensors, simulator)."""

from .actuators import (
    Actuator,
    CmgCommand,
    FirstOrderServo,
    IdealTorqueActuator,
    ReactionWheelAssembly,
    SgcmgActuator,
    WheelCommand,
    orthogonal_wheel_axes,
    pyramid_wheel_axes,
)
from .disturbances import (
    ConstantHarmonicTorque,
    ConstantTorque,
    DisturbanceSource,
    SumOfDisturbances,
    ZeroDisturbance,
)
from .environment import GravityGradientTorque
from .flexible import FlexibleModes
from .geomagnetic import TiltedDipoleField
from .momentum import CrossProductDumping, Magnetorquers, momentum_fraction
from .orbit import CircularOrbit, EarthPointingReference
from .payload import (
    PAYLOAD_SATELLITE_J,
    ROTATING_PAYLOAD_EXAMPLE,
    ConstantSpin,
    RotatingPayload,
    RotatingPayloadTorque,
    SpinProfile,
    SpinRamp,
    jitter_estimate,
)
from .plant import PlantState, Spacecraft
from .rigid_body import RigidBody, perturbed_inertia
from .se3_plant import (
    DockingReference,
    IdealWrenchActuator,
    OrbitingTarget,
    SE3Plant,
    simulate_pose,
)
from .sensors import RateGyro, StarTracker, TwoVectorAttitude, triad
from .sgcmg import SgcmgPyramid
from .simulator import SimulationDiverged, SimulationResult, StarTrackerGyro, simulate
from .steering import (
    GeneralizedSingularityRobust,
    PseudoInverse,
    PseudoInverseNullMotion,
    SingularityRobust,
    saturate_gimbal_rates,
)
from .surface_forces import (
    AerodynamicTorque,
    ExponentialAtmosphere,
    Plate,
    ResidualDipoleTorque,
    SolarPressureTorque,
    box_plates,
)

__all__ = [
    "FirstOrderServo",
    "ReactionWheelAssembly",
    "WheelCommand",
    "orthogonal_wheel_axes",
    "pyramid_wheel_axes",
    "DockingReference",
    "IdealWrenchActuator",
    "OrbitingTarget",
    "SE3Plant",
    "simulate_pose",
    "GeneralizedSingularityRobust",
    "Actuator",
    "CircularOrbit",
    "CrossProductDumping",
    "Magnetorquers",
    "momentum_fraction",
    "TiltedDipoleField",
    "CmgCommand",
    "ConstantTorque",
    "DisturbanceSource",
    "EarthPointingReference",
    "FlexibleModes",
    "GravityGradientTorque",
    "AerodynamicTorque",
    "ExponentialAtmosphere",
    "Plate",
    "ResidualDipoleTorque",
    "SolarPressureTorque",
    "box_plates",
    "IdealTorqueActuator",
    "PlantState",
    "PseudoInverse",
    "PseudoInverseNullMotion",
    "RateGyro",
    "RigidBody",
    "RotatingPayload",
    "RotatingPayloadTorque",
    "ConstantSpin",
    "SpinRamp",
    "SpinProfile",
    "PAYLOAD_SATELLITE_J",
    "ROTATING_PAYLOAD_EXAMPLE",
    "ConstantHarmonicTorque",
    "SgcmgActuator",
    "SgcmgPyramid",
    "SimulationDiverged",
    "SimulationResult",
    "SingularityRobust",
    "Spacecraft",
    "StarTracker",
    "StarTrackerGyro",
    "SumOfDisturbances",
    "TwoVectorAttitude",
    "ZeroDisturbance",
    "jitter_estimate",
    "perturbed_inertia",
    "saturate_gimbal_rates",
    "simulate",
    "triad",
]
