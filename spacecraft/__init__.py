"""spacecraft: the plant (rigid body, actuators, disturbances, simulator) — SPEC §5."""

from .actuators import Actuator, CmgCommand, IdealTorqueActuator, SgcmgActuator
from .disturbances import (
    ConstantTorque,
    DisturbanceSource,
    Seed000Disturbance,
    SumOfDisturbances,
    ZeroDisturbance,
)
from .plant import PlantState, Spacecraft
from .rigid_body import RigidBody
from .sgcmg import SgcmgPyramid
from .simulator import SimulationDiverged, SimulationResult, simulate
from .steering import (
    PseudoInverse,
    PseudoInverseNullMotion,
    SingularityRobust,
    saturate_gimbal_rates,
)

__all__ = [
    "Actuator",
    "CmgCommand",
    "ConstantTorque",
    "DisturbanceSource",
    "IdealTorqueActuator",
    "PlantState",
    "PseudoInverse",
    "PseudoInverseNullMotion",
    "RigidBody",
    "Seed000Disturbance",
    "SgcmgActuator",
    "SgcmgPyramid",
    "SimulationDiverged",
    "SimulationResult",
    "SingularityRobust",
    "Spacecraft",
    "SumOfDisturbances",
    "ZeroDisturbance",
    "saturate_gimbal_rates",
    "simulate",
]
