"""spacecraft: the plant (rigid body, flexible modes, actuators, disturbances, environment,
sensors, simulator) — SPEC §5."""

from .actuators import Actuator, CmgCommand, IdealTorqueActuator, SgcmgActuator
from .disturbances import (
    ConstantTorque,
    DisturbanceSource,
    Seed000Disturbance,
    SumOfDisturbances,
    ZeroDisturbance,
)
from .environment import GravityGradientTorque
from .flexible import FlexibleModes
from .orbit import CircularOrbit, EarthPointingReference
from .payload import (
    SEED003_J,
    SEED003_PAYLOAD,
    RotatingPayload,
    RotatingPayloadTorque,
    jitter_estimate,
)
from .plant import PlantState, Spacecraft
from .rigid_body import RigidBody, perturbed_inertia
from .sensors import RateGyro, StarTracker, TwoVectorAttitude, triad
from .sgcmg import SgcmgPyramid
from .simulator import SimulationDiverged, SimulationResult, StarTrackerGyro, simulate
from .steering import (
    PseudoInverse,
    PseudoInverseNullMotion,
    SingularityRobust,
    saturate_gimbal_rates,
)

__all__ = [
    "Actuator",
    "CircularOrbit",
    "CmgCommand",
    "ConstantTorque",
    "DisturbanceSource",
    "EarthPointingReference",
    "FlexibleModes",
    "GravityGradientTorque",
    "IdealTorqueActuator",
    "PlantState",
    "PseudoInverse",
    "PseudoInverseNullMotion",
    "RateGyro",
    "RigidBody",
    "RotatingPayload",
    "RotatingPayloadTorque",
    "SEED003_J",
    "SEED003_PAYLOAD",
    "Seed000Disturbance",
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
