"""Rank a policy (a trained network, a numpy linear map, any ``obs -> action`` callable) in the
benchmark next to the geometric controllers.

:func:`register_policy` wraps it in :class:`spacecraft.envs.PolicyController` — the observation
and action maps of the Gymnasium environments (:mod:`spacecraft.envs`) — and registers it with
:func:`benchmarks.controllers.register`. Call it from your own code or from a file given to
``python -m benchmarks run --plugin my_policy.py``::

    from benchmarks.policies import register_policy
    from spacecraft.envs import AttitudeEnvConfig
    register_policy("my-residual", my_policy, AttitudeEnvConfig(action="residual"))

Policies are never in the quick suite unless asked (``quick=True``); needs the ``[rl]`` extra.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .controllers import ControllerContext, ControllerInfo, register

__all__ = ["register_policy", "policy_factory"]


def policy_factory(
    policy: Callable[[np.ndarray], Any], config: Any
) -> Callable[[ControllerContext], Any]:
    """Factory of :class:`spacecraft.envs.PolicyController` for ``policy`` trained with
    ``config`` (:class:`spacecraft.envs.AttitudeEnvConfig`). The residual mode's baseline is the
    environment's geometric PD law (large-angle error, ``ω_n``, ``ζ`` of ``config``) tuned on
    the scenario's nominal inertia at the run's control period."""
    from liecontrol.control.geometric_pd import GeometricPD
    from liecontrol.control.tuning import ClosedLoopSpec, tune_geometric_pd
    from spacecraft.envs import AttitudeEnvConfig, PolicyController

    if not callable(policy):
        raise ValueError(f"policy: must be callable as policy(obs) -> action, got {policy!r}")
    if not isinstance(config, AttitudeEnvConfig):
        raise ValueError(f"config: expected an AttitudeEnvConfig, got {type(config).__name__}")

    def make(ctx: ControllerContext) -> Any:
        spec = ClosedLoopSpec(config.omega_n, config.zeta, ctx.control_period)
        baseline = GeometricPD(ctx.J, **tune_geometric_pd(ctx.J, spec, error="large_angle"))
        return PolicyController(policy, config, baseline=baseline)

    make.__doc__ = f"policy ({config.action} action on {', '.join(config.observation)})"
    return make


def register_policy(
    name: str,
    policy: Callable[[np.ndarray], Any],
    config: Any = None,
    *,
    description: str | None = None,
    quick: bool = False,
    replace: bool = False,
) -> ControllerInfo:
    """Register ``policy`` (trained with ``config``, default ``AttitudeEnvConfig()``) as the
    benchmark controller ``name``: applies to the plant of ``config.actuator`` only, sampled at
    ``config.action_period`` (the period it was trained at), family ``"learned"``."""
    from spacecraft.envs import AttitudeEnvConfig

    config = AttitudeEnvConfig() if config is None else config
    factory = policy_factory(policy, config)
    return register(
        name,
        factory,
        description=description or factory.__doc__,
        plants={config.actuator},
        control_period=config.action_period,
        quick=quick,
        family="learned",
        replace=replace,
    )
