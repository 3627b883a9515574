"""Gymnasium environments for spacecraft attitude control over the batched plant.

:class:`AttitudeEnv` (one spacecraft) and :class:`AttitudeVectorEnv` (``num_envs`` spacecraft
stepped as one batch by :class:`~spacecraft.envs.core.AttitudeBatch` — one plant call per
integration step for all of them, not one environment per spacecraft).

Step: the action ``a ∈ [−1, 1]³`` becomes a body torque command (``"torque"``: ``u = u_max a``;
``"residual"``: ``u = u_PD + r a`` with the baseline geometric PD), held for ``action_period``
seconds over ``action_period / dt`` RKMK4 steps of the plant; the actuator (gimbal-rate or
wheel torque/speed limits, steering) turns it into the torque it can deliver.

Reward (after the step; ``θ`` the attitude-error angle, ``e_Ω`` the body-rate error,
``s`` the fraction of integration steps where the actuator saturated)::

    r = −( w_angle θ/π + w_rate min(‖e_Ω‖/rate_scale, 10) + w_effort ‖u/u_max‖²/3 + w_saturation s )

Termination: a slew terminates when ``θ < settle_angle_deg`` and ``‖e_Ω‖ < settle_rate``
(settled); tracking never terminates. Truncation: after ``max_episode_steps`` actions (the
environments truncate themselves; the registrations set no ``TimeLimit``). Constraint margins
(keep-out cones, momentum envelopes) are not part of the reward yet.

Seeding: ``reset(seed=s)`` seeds the episode generator (``gymnasium.utils.seeding.np_random``);
the vector environment seeds row ``i`` with ``s + i`` (Gymnasium's convention), so row ``i``
follows exactly the episodes of a single environment seeded with ``s + i``.

Autoreset (vector environment): **next-step** (Gymnasium 1.x's default,
``AutoresetMode.NEXT_STEP``). The step that ends an episode returns that episode's final
observation, reward and flags; the following ``step`` call ignores that row's action, resets the
row and returns its first observation with reward 0 and both flags ``False``.

Bad input raises ``ValueError`` naming the argument: unknown constructor options, unknown
``reset`` options, actions of the wrong shape, non-finite or outside ``[−1, 1]`` (wrap with
``gymnasium.wrappers.ClipAction`` to clip), ``num_envs ≤ 0``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from liecontrol._validation import as_array

from .core import AttitudeBatch, AttitudeEnvConfig
from .observations import check_action

__all__ = ["AttitudeEnv", "AttitudeVectorEnv", "RESET_OPTIONS"]

#: Keys ``reset(options=...)`` accepts: ``initial_rotvec`` (the start error ``log(R_dᵀR)``,
#: 3 floats [rad]) and ``initial_rate_error`` (start body-rate error, 3 floats [rad/s]).
RESET_OPTIONS: tuple[str, ...] = ("initial_rotvec", "initial_rate_error")


def _check_reset_options(options: object) -> dict[str, Any] | None:
    if options is None:
        return None
    if not isinstance(options, dict):
        raise ValueError(f"options: expected a dict or None, got {type(options).__name__}")
    out = {}
    for key, value in options.items():
        if key not in RESET_OPTIONS:
            raise ValueError(
                f"options: unknown key {key!r}; valid keys: {', '.join(RESET_OPTIONS)}"
            )
        a = as_array(value, key)
        if a.shape != (3,):
            raise ValueError(f"{key}: expected shape (3,), got {a.shape}")
        out[key] = a.copy()
    return out


def _render_frame(R: np.ndarray, R_d: np.ndarray, size: int = 320) -> np.ndarray:
    """RGB ``(size, size, 3)`` uint8 image: body triad (solid; x red, y green, z blue) and
    target triad (dashed) in an isometric view of the inertial frame (matplotlib, Agg)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(size / 80, size / 80), dpi=80)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    colors = ("tab:red", "tab:green", "tab:blue")
    for k in range(3):
        ax.plot(*np.stack((np.zeros(3), R_d[:, k])).T, color=colors[k], ls="--", lw=1.5)
        ax.plot(*np.stack((np.zeros(3), R[:, k])).T, color=colors[k], lw=3.0)
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(-1.0, 1.0)
    ax.set_axis_off()
    canvas.draw()
    img = np.asarray(canvas.buffer_rgba())[..., :3]
    return np.ascontiguousarray(img)


class AttitudeEnv(gym.Env):
    """One spacecraft (module docstring). Keyword options: the fields of
    :class:`~spacecraft.envs.core.AttitudeEnvConfig` plus ``render_mode``
    (``None`` or ``"rgb_array"``).

    ``info`` of ``step``: ``angle`` [rad], ``rate_error`` [rad/s], ``effort``, ``saturation``,
    ``torque`` (the commanded body torque [N·m]) and ``time`` [s]."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, render_mode: str | None = None, **options: Any) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: expected None or 'rgb_array', got {render_mode!r}")
        self.render_mode = render_mode
        self.config = AttitudeEnvConfig.from_options({}, options)
        self._batch = AttitudeBatch(self.config, 1)
        n = self._batch.n_obs
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(n,), dtype=np.float64)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float64)
        self._rngs: list[np.random.Generator] = [seeding.np_random(None)[0]]
        self._ready = False

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        opts = _check_reset_options(options)
        super().reset(seed=seed)
        self._rngs[0] = self.np_random
        self._batch.reset_rows(np.array([0]), self._rngs, opts)
        self._ready = True
        return self._batch.observe()[0], {"time": 0.0}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if not self._ready:
            raise RuntimeError("step: call reset() first (or after the episode ended)")
        a = check_action(action, None)
        out = self._batch.step(a[None, :])
        terminated, truncated = bool(out["terminated"][0]), bool(out["truncated"][0])
        if terminated or truncated:
            self._ready = False
        info = {k: out[k][0] for k in ("angle", "rate_error", "effort", "saturation", "torque")}
        info["time"] = float(self._batch.clock[0])
        return self._batch.observe()[0], float(out["reward"][0]), terminated, truncated, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            return None
        R_d, _ = self._batch.reference()
        return _render_frame(self._batch.R[0], np.asarray(R_d[0]))


class AttitudeVectorEnv(VectorEnv):
    """``num_envs`` spacecraft stepped as one batch, next-step autoreset (module docstring).
    Keyword options as :class:`AttitudeEnv`. ``info`` of ``step`` holds the same keys as the
    single environment's, as ``(num_envs, ...)`` arrays (for a row that was just reset, ``time``
    is 0 and the other entries describe the discarded step).

    ``reset(seed=s)`` seeds row ``i`` with ``s + i``; a list of ``num_envs`` seeds (ints or
    ``None``) seeds the rows one by one."""

    metadata = {"render_modes": ["rgb_array"], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, render_mode: str | None = None, **options: Any) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)):
            raise ValueError(f"num_envs: expected an int >= 1, got {num_envs!r}")
        if num_envs < 1:
            raise ValueError(f"num_envs: must be >= 1, got {num_envs}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: expected None or 'rgb_array', got {render_mode!r}")
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.config = AttitudeEnvConfig.from_options({}, options)
        try:
            self._batch = AttitudeBatch(self.config, self.num_envs)
        except (MemoryError, ValueError) as exc:
            raise ValueError(
                f"num_envs: {self.num_envs} spacecraft do not fit in memory ({exc})"
            ) from None
        n = self._batch.n_obs
        self.single_observation_space = spaces.Box(-np.inf, np.inf, shape=(n,), dtype=np.float64)
        self.single_action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float64)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._rngs = [seeding.np_random(None)[0] for _ in range(self.num_envs)]
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._ready = False

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        opts = _check_reset_options(options)
        if seed is not None:
            if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
                seeds = [int(seed) + i for i in range(self.num_envs)]
            elif isinstance(seed, (list, tuple)) and len(seed) == self.num_envs:
                seeds = list(seed)
            else:
                raise ValueError(
                    f"seed: expected an int or a list of {self.num_envs} seeds, got {seed!r}"
                )
            self._rngs = [seeding.np_random(s)[0] for s in seeds]
        self._batch.reset_rows(np.arange(self.num_envs), self._rngs, opts)
        self._autoreset[:] = False
        self._ready = True
        return self._batch.observe(), {"time": self._batch.clock.copy()}

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._ready:
            raise RuntimeError("step: call reset() first")
        a = check_action(actions, self.num_envs, "actions")
        done_rows = np.flatnonzero(self._autoreset)
        if done_rows.size:
            # rows whose episode ended at the previous step: their actions are ignored, the
            # integration below still runs on the whole batch (one code path), then they are
            # reset and report their first observation
            a = a.copy()
            a[done_rows] = 0.0
        out = self._batch.step(a)
        reward = out["reward"]
        terminated, truncated = out["terminated"], out["truncated"]
        if done_rows.size:
            self._batch.reset_rows(done_rows, self._rngs)
            reward[done_rows] = 0.0
            terminated[done_rows] = False
            truncated[done_rows] = False
        self._autoreset = terminated | truncated
        info = {k: out[k] for k in ("angle", "rate_error", "effort", "saturation", "torque")}
        info["time"] = self._batch.clock.copy()
        return self._batch.observe(), reward, terminated, truncated, info

    def render(self) -> tuple[np.ndarray, ...] | None:
        if self.render_mode is None:
            return None
        R_d, _ = self._batch.reference()
        R = self._batch.R
        return tuple(_render_frame(R[i], np.asarray(R_d[i])) for i in range(self.num_envs))
