"""Gymnasium environments for attitude control over the batched plant (optional extra
``[rl]``: ``pip install "liecontrol[rl]"``, i.e. ``gymnasium >= 1.0``).

``import spacecraft.envs`` registers (once) with Gymnasium:

- ``liecontrol/AttitudeSlew-v0``: SGCMG spacecraft, random rest-to-rest slews (Haar start);
- ``liecontrol/AttitudeSlewWheels-v0``: the same task on a reaction-wheel spacecraft;
- ``liecontrol/AttitudeTracking-v0``: Earth pointing under gravity-gradient and harmonic
  disturbance torques, SGCMG spacecraft.

Each id has a native vector entry point: ``gymnasium.make_vec(id, num_envs=N,
vectorization_mode="vector_entry_point")`` steps all ``N`` spacecraft as one batch.
Options, reward, termination, seeding and autoreset: :mod:`spacecraft.envs.attitude`; the
observation and action maps shared with :class:`PolicyController`:
:mod:`spacecraft.envs.observations`.
"""

from __future__ import annotations

try:
    import gymnasium as _gym
except ImportError as exc:  # pragma: no cover - depends on the installation
    raise ImportError(
        "spacecraft.envs needs gymnasium >= 1.0: pip install 'liecontrol[rl]'"
    ) from exc

from .attitude import RESET_OPTIONS, AttitudeEnv, AttitudeVectorEnv
from .core import AttitudeEnvConfig
from .observations import (
    ACTION_MODES,
    OBSERVATION_COMPONENTS,
    ObservationScales,
    action_to_torque,
    build_observation,
    check_action,
)
from .policy import PolicyController

__all__ = [
    "ENV_IDS",
    "RESET_OPTIONS",
    "ACTION_MODES",
    "OBSERVATION_COMPONENTS",
    "AttitudeEnv",
    "AttitudeEnvConfig",
    "AttitudeVectorEnv",
    "ObservationScales",
    "PolicyController",
    "action_to_torque",
    "build_observation",
    "check_action",
    "register_envs",
]

#: The registered ids and their default options.
ENV_IDS: dict[str, dict[str, object]] = {
    "liecontrol/AttitudeSlew-v0": {"task": "slew", "actuator": "sgcmg"},
    "liecontrol/AttitudeSlewWheels-v0": {"task": "slew", "actuator": "wheels"},
    "liecontrol/AttitudeTracking-v0": {"task": "tracking", "actuator": "sgcmg"},
}


def register_envs() -> None:
    """Register :data:`ENV_IDS` with Gymnasium (idempotent; done on import)."""
    for env_id, defaults in ENV_IDS.items():
        if env_id in _gym.registry:
            continue
        _gym.register(
            id=env_id,
            entry_point="spacecraft.envs.attitude:AttitudeEnv",
            vector_entry_point="spacecraft.envs.attitude:AttitudeVectorEnv",
            kwargs=dict(defaults),
        )


register_envs()
