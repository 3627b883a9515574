"""A learned (or any) policy ``obs -> action`` as an attitude controller of the suite.

:class:`PolicyController` builds the observation from the state it is given (the true state or
an estimate) and the reference, calls the policy and maps its action to a torque with the same
computation the environments run at every step (that of
:func:`~spacecraft.envs.observations.build_observation` and
:func:`~spacecraft.envs.observations.action_to_torque`, without re-validating the arrays the
simulator has validated), so a policy trained in :mod:`spacecraft.envs` sees the same numbers
in a benchmark run. Register one in the benchmark with
:func:`benchmarks.policies.register_policy`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from liecontrol.control.base import (
    AttitudeController,
    AttitudeReference,
    AttitudeState,
    check_state_batch,
)

from .core import AttitudeEnvConfig
from .observations import _observe, _to_torque, check_action

__all__ = ["PolicyController"]


class PolicyController(AttitudeController):
    """Wrap ``policy`` (``(B, n_obs) float64 -> (B, 3)`` actions in ``[−1, 1]``) as a batched
    :class:`~liecontrol.control.base.AttitudeController`.

    Args:
        policy: the callable (a network's forward pass, a numpy linear map, ...). It is called
            once per control sample with the whole batch.
        config: the environment configuration the policy was trained with (observation
            components and scales, action mode, ``u_max``, residual scale, baseline tuning).
        baseline: the residual mode's baseline controller; default ``config.baseline()`` (the
            environment's geometric PD). The benchmark factory passes one tuned on the
            scenario's nominal inertia.

    A policy output of the wrong shape, non-finite or outside ``[−1, 1]`` raises
    ``ValueError`` (``policy: ...``). ``diagnostics()`` returns the last ``action`` ``(B, 3)``.
    """

    batched = True

    def __init__(
        self,
        policy: Callable[[np.ndarray], Any],
        config: AttitudeEnvConfig | None = None,
        baseline: AttitudeController | None = None,
    ) -> None:
        if not callable(policy):
            raise ValueError(f"policy: must be callable as policy(obs) -> action, got {policy!r}")
        if config is None:
            config = AttitudeEnvConfig()
        if not isinstance(config, AttitudeEnvConfig):
            raise ValueError(f"config: expected an AttitudeEnvConfig, got {type(config).__name__}")
        if baseline is not None and not isinstance(baseline, AttitudeController):
            raise ValueError(
                f"baseline: expected an AttitudeController, got {type(baseline).__name__}"
            )
        self.policy = policy
        self.config = config
        self.baseline = baseline if baseline is not None else config.baseline()
        self._scales = config.scales
        self._B = 0
        self._last = np.zeros((0, 3))

    def reset(self, t0: float, batch_size: int) -> None:
        self._B = int(batch_size)
        self._last = np.zeros((self._B, 3))
        self.baseline.reset(t0, batch_size)

    def observation(self, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """The policy's input ``(B, n_obs)`` for ``state`` and ``reference``."""
        R = np.asarray(state.R)
        omega_d = np.broadcast_to(reference.omega_d, (R.shape[0], 3))
        return _observe(
            self.config.observation,
            self._scales,
            R,
            np.asarray(state.omega),
            np.asarray(reference.R_d),
            omega_d,
            state.h,
            state.actuator_state,
        )

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        B = check_state_batch(np.asarray(state.R), np.asarray(state.omega), self._B)
        a = check_action(self.policy(self.observation(state, reference)), B, "policy")
        self._last = a
        cfg = self.config
        if cfg.action == "torque":
            return _to_torque(a, "torque", cfg.max_torque, None)
        u_pd = np.asarray(self.baseline.command(t, state, reference), dtype=np.float64)
        return _to_torque(a, "residual", cfg.residual_scale, u_pd)

    def diagnostics(self) -> dict[str, np.ndarray]:
        return {"action": self._last.copy()}
