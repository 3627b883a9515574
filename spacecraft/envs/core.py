"""Configuration and the batched engine behind the attitude environments.

One :class:`AttitudeBatch` holds ``B`` spacecraft as one packed state and advances all of them
with one call of :meth:`spacecraft.plant.Spacecraft.step_packed` per integration step (the
simulator's own hot path): the single environment is ``B = 1``, the vector environment
``B = num_envs``. Each row has its own episode clock, step counter and random generator, so a
row of the vector environment follows exactly the episode a single environment seeded the same
way follows.

Plants (built here from :mod:`spacecraft` parts):

- ``"sgcmg"``: the four-gimbal pyramid of Wu, Huang, Wei & Guo (ADRC attitude control with an
  SGCMG pyramid; inertia ``[[15053, 3000, −1000], [3000, 6510, 2000], [−1000, 2000, 11122]]``
  kg·m², ``h₀ = 300`` N·m·s, β = 54.73°, gimbal rates ≤ 1 rad/s, pseudo-inverse steering with
  null motion, gimbals starting at (60°, −60°, 60°, −60°));
- ``"wheels"``: three orthogonal reaction wheels (0.1 kg·m², ≤ 1 N·m, ≤ 600 rad/s) on the
  rotating-payload bus of Wang, Chu, Zhang & Yuan (``diag(520, 450, 660)`` kg·m²).

Tasks: ``"slew"`` (rest-to-rest to ``R_d = I``; start error Haar-uniform, or angle uniform in
``angle_range_deg`` about a uniform axis) and ``"tracking"`` (Earth pointing: follow the LVLH
frame of a circular equatorial orbit of rate ``orbit_rate`` under the gravity-gradient torque
``3n² ĉ × Jĉ`` plus the constant + harmonic torque of Wu et al. scaled per episode by a factor
drawn from ``disturbance_scale``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from liecontrol._jit import JIT_ENABLED
from liecontrol._validation import as_array
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.geometric_pd import GeometricPD
from liecontrol.control.tuning import ClosedLoopSpec, tune_geometric_pd
from liecontrol.lie import so3
from spacecraft._fused import hold_steps

from ..actuators import ReactionWheelAssembly, SgcmgActuator
from ..plant import Spacecraft
from ..rigid_body import RigidBody
from ..sgcmg import SgcmgPyramid
from ..steering import PseudoInverseNullMotion
from .observations import (
    ACTION_MODES,
    ObservationScales,
    _attitude_error,
    _observe,
    _rate_error,
    _to_torque,
    check_components,
    observation_size,
)

__all__ = ["AttitudeEnvConfig", "SGCMG_INERTIA", "WHEEL_BUS_INERTIA"]

#: Inertia of the SGCMG spacecraft of Wu, Huang, Wei & Guo [kg·m²].
SGCMG_INERTIA = np.array(
    [[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]]
)
#: Inertia of the rotating-payload bus of Wang, Chu, Zhang & Yuan [kg·m²].
WHEEL_BUS_INERTIA = np.diag([520.0, 450.0, 660.0])

_TASKS = ("slew", "tracking")
_ACTUATORS = ("sgcmg", "wheels")
# per-actuator defaults: torque scale u_max [N·m] and momentum scale [N·m·s]
_U_MAX = {"sgcmg": 100.0, "wheels": 1.0}
_H_SCALE = {"sgcmg": 1000.0, "wheels": 60.0}


def _finite_positive(v: object, name: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
        raise ValueError(f"{name}: expected a number, got {v!r}")
    v = float(v)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name}: must be finite and > 0, got {v!r}")
    return v


def _finite_nonneg(v: object, name: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
        raise ValueError(f"{name}: expected a number, got {v!r}")
    v = float(v)
    if not (math.isfinite(v) and v >= 0.0):
        raise ValueError(f"{name}: must be finite and >= 0, got {v!r}")
    return v


def _pair(v: object, name: str, lo: float, hi: float) -> tuple[float, float]:
    a = as_array(v, name)  # finite real numbers (no NaN, complex, strings)
    if a.shape != (2,):
        raise ValueError(f"{name}: expected a pair (low, high), got shape {a.shape}")
    low, high = float(a[0]), float(a[1])
    if not lo <= low <= high <= hi:
        raise ValueError(f"{name}: expected {lo} <= low <= high <= {hi}, got ({low}, {high})")
    return low, high


@dataclass(frozen=True)
class AttitudeEnvConfig:
    """Everything an attitude environment is made of (the keyword options of
    ``gymnasium.make``; unknown keywords raise ``ValueError`` naming them).

    Attributes:
        task: ``"slew"`` or ``"tracking"`` (module docstring).
        actuator: ``"sgcmg"`` or ``"wheels"``.
        observation: observation components (:mod:`spacecraft.envs.observations`).
        action: ``"torque"`` (``u = u_max a``) or ``"residual"`` (``u = u_PD + r a``).
        max_torque: ``u_max`` [N·m] (default 100 for the SGCMG, 1 for the wheels).
        residual_scale: ``r`` [N·m] (default ``0.2 u_max``).
        dt: integration step [s] (RKMK4).
        action_period: time one action is held [s], a positive multiple of ``dt``.
        max_episode_steps: truncation horizon [actions].
        angle_range_deg: start error angle range [deg]; ``None`` = Haar-uniform start (slew)
            or (0, 20) (tracking).
        max_initial_rate: start body-rate error magnitude bound [rad/s] (uniform in the ball;
            default 0 for slews = rest-to-rest, 1e-3 for tracking).
        omega_n, zeta: small-angle closed loop of the baseline geometric PD (the residual
            mode's ``u_PD``; :func:`liecontrol.control.tuning.tune_geometric_pd`, large-angle
            error).
        settle_angle_deg, settle_rate: a slew terminates when ``θ <`` settle_angle and
            ``‖e_Ω‖ <`` settle_rate [rad/s].
        w_angle, w_rate, w_effort, w_saturation: reward weights (see the environment's
            docstring).
        rate_scale, momentum_scale: observation normalisations (``None``: 0.05 rad/s; 1000 or
            60 N·m·s).
        orbit_rate: orbit rate of the tracking task [rad/s].
        disturbance_scale: range of the per-episode factor on the harmonic torque (tracking).
    """

    task: str = "slew"
    actuator: str = "sgcmg"
    observation: tuple[str, ...] = ("rotvec", "rate")
    action: str = "torque"
    max_torque: float | None = None
    residual_scale: float | None = None
    dt: float = 0.1
    action_period: float = 0.5
    max_episode_steps: int = 800
    angle_range_deg: tuple[float, float] | None = None
    max_initial_rate: float | None = None
    omega_n: float = 0.03
    zeta: float = 0.9
    settle_angle_deg: float = 0.5
    settle_rate: float = 1e-3
    w_angle: float = 1.0
    w_rate: float = 0.1
    w_effort: float = 0.01
    w_saturation: float = 0.1
    rate_scale: float | None = None
    momentum_scale: float | None = None
    orbit_rate: float = 0.0011
    disturbance_scale: tuple[float, float] = (0.5, 1.5)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if self.task not in _TASKS:
            raise ValueError(f"task: expected one of {_TASKS}, got {self.task!r}")
        if self.actuator not in _ACTUATORS:
            raise ValueError(f"actuator: expected one of {_ACTUATORS}, got {self.actuator!r}")
        set_(self, "observation", check_components(self.observation))
        if self.action not in ACTION_MODES:
            raise ValueError(f"action: expected one of {ACTION_MODES}, got {self.action!r}")
        u_max = _U_MAX[self.actuator] if self.max_torque is None else self.max_torque
        set_(self, "max_torque", _finite_positive(u_max, "max_torque"))
        r = 0.2 * self.max_torque if self.residual_scale is None else self.residual_scale
        set_(self, "residual_scale", _finite_positive(r, "residual_scale"))
        for name in ("dt", "action_period", "omega_n", "zeta", "settle_angle_deg", "settle_rate",
                     "orbit_rate"):  # fmt: skip
            set_(self, name, _finite_positive(getattr(self, name), name))
        ratio = self.action_period / self.dt
        if round(ratio) < 1 or abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ValueError(
                f"action_period: must be a positive integer multiple of dt = {self.dt}, "
                f"got {self.action_period}"
            )
        n = self.max_episode_steps
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"max_episode_steps: expected an int >= 1, got {n!r}")
        set_(self, "max_episode_steps", int(n))
        rng_default = (0.0, 20.0) if self.task == "tracking" else None
        a = self.angle_range_deg if self.angle_range_deg is not None else rng_default
        set_(self, "angle_range_deg", None if a is None else _pair(a, "angle_range_deg", 0, 180))
        w0 = self.max_initial_rate
        w0 = (1e-3 if self.task == "tracking" else 0.0) if w0 is None else w0
        set_(self, "max_initial_rate", _finite_nonneg(w0, "max_initial_rate"))
        for name in ("w_angle", "w_rate", "w_effort", "w_saturation"):
            set_(self, name, _finite_nonneg(getattr(self, name), name))
        rs = 0.05 if self.rate_scale is None else self.rate_scale
        set_(self, "rate_scale", _finite_positive(rs, "rate_scale"))
        hs = _H_SCALE[self.actuator] if self.momentum_scale is None else self.momentum_scale
        set_(self, "momentum_scale", _finite_positive(hs, "momentum_scale"))
        set_(self, "disturbance_scale", _pair(self.disturbance_scale, "disturbance_scale", 0, 1e6))

    @classmethod
    def from_options(cls, defaults: dict[str, Any], options: dict[str, Any]) -> AttitudeEnvConfig:
        """The config of ``defaults`` updated by ``options``; an unknown option raises
        ``ValueError`` naming it (and listing the valid ones)."""
        valid = [f.name for f in fields(cls)]
        for key in options:
            if key not in valid:
                raise ValueError(f"{key}: unknown option; valid options: {', '.join(valid)}")
        return cls(**{**defaults, **options})

    @property
    def substeps(self) -> int:
        """Integration steps per action."""
        return round(self.action_period / self.dt)

    @property
    def scales(self) -> ObservationScales:
        return ObservationScales(
            rate=self.rate_scale, momentum=self.momentum_scale, speed=600.0, actuator=self.actuator
        )

    @property
    def inertia(self) -> np.ndarray:
        return (SGCMG_INERTIA if self.actuator == "sgcmg" else WHEEL_BUS_INERTIA).copy()

    def baseline(self) -> GeometricPD:
        """The baseline geometric PD (large-angle error, ``K_R = ω_n² J / ½``,
        ``K_Ω = 2ζω_n J``) sampled at ``action_period``."""
        J = self.inertia
        spec = ClosedLoopSpec(self.omega_n, self.zeta, self.action_period)
        return GeometricPD(J, **tune_geometric_pd(J, spec, error="large_angle"))

    def build_actuator(self) -> Any:
        if self.actuator == "sgcmg":
            cluster = SgcmgPyramid(h0=300.0, beta=math.radians(54.73), gimbal_rate_limit=1.0)
            return SgcmgActuator(
                cluster=cluster,
                steering=PseudoInverseNullMotion(cluster=cluster),
                delta0=np.radians([60.0, -60.0, 60.0, -60.0]),
            )
        return ReactionWheelAssembly.orthogonal(wheel_inertia=0.1, max_torque=1.0, max_speed=600.0)


class _EpisodeDisturbance:
    """Tracking-task disturbance on per-row episode clocks: gravity gradient of the circular
    equatorial orbit plus ``scale_i ×`` the constant + harmonic torque of Wu et al.

    The integrator is called with ``t = 0`` at the start of every step, so a stage at ``t``
    is at episode time ``clock_i + t`` for row ``i`` — the same floating-point sums for a row
    of a batch and for a single spacecraft."""

    uses_attitude = True

    def __init__(self, J: np.ndarray, n: float, clock: np.ndarray, scale: np.ndarray) -> None:
        self.J = J
        self._J_rows = tuple(map(tuple, np.asarray(J, dtype=np.float64).tolist()))
        self.n = n
        self.clock = clock  # views owned by the batch, updated in place
        self.scale = scale

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        # hot path (four calls per integration step): explicit components, no np.cross/stack
        n = self.n
        if self.clock.shape[0] == 1:
            return self._one(float(self.clock[0]) + t, R.reshape(3, 3).tolist())
        u = n * (self.clock + t)
        cu, su = np.cos(u)[:, None], np.sin(u)[:, None]
        R = R.reshape(-1, 3, 3)
        c = -(cu * R[:, 0, :] + su * R[:, 1, :])  # ĉ = Rᵀ(−r̂), r̂ = (cos u, sin u, 0)
        Jc = c @ self.J.T
        k3 = 3.0 * n * n
        out = np.empty(c.shape)
        out[:, 0] = k3 * (c[:, 1] * Jc[:, 2] - c[:, 2] * Jc[:, 1])
        out[:, 1] = k3 * (c[:, 2] * Jc[:, 0] - c[:, 0] * Jc[:, 2])
        out[:, 2] = k3 * (c[:, 0] * Jc[:, 1] - c[:, 1] * Jc[:, 0])
        s1, s2 = su[:, 0], np.sin(2.0 * u)
        k = self.scale
        common = k * (0.02 + 0.02 * s1 + 0.01 * s2)
        out[:, 0] += common
        out[:, 1] += k * (0.08 + 0.04 * s1 + 0.01 * s2)
        out[:, 2] += common
        return out

    def _one(self, tt: float, R: list) -> np.ndarray:
        """:meth:`__call__` for one spacecraft on Python floats (~10× cheaper than on
        1-element arrays; the same formulas, equal to round-off)."""
        n = self.n
        u = n * tt
        cu, su = math.cos(u), math.sin(u)
        c0, c1, c2 = (-(cu * R[0][k] + su * R[1][k]) for k in range(3))
        (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = self._J_rows
        d0 = j00 * c0 + j01 * c1 + j02 * c2
        d1 = j10 * c0 + j11 * c1 + j12 * c2
        d2 = j20 * c0 + j21 * c1 + j22 * c2
        k3 = 3.0 * n * n
        s1, s2 = su, math.sin(2.0 * u)
        k = float(self.scale[0])
        common = k * (0.02 + 0.02 * s1 + 0.01 * s2)
        return np.array(
            [
                [
                    k3 * (c1 * d2 - c2 * d1) + common,
                    k3 * (c2 * d0 - c0 * d2) + k * (0.08 + 0.04 * s1 + 0.01 * s2),
                    k3 * (c0 * d1 - c1 * d0) + common,
                ]
            ]
        )


def sample_episode(
    config: AttitudeEnvConfig, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, float]:
    """Start error rotation ``R_e0`` (desired → body), start rate error [rad/s] and disturbance
    factor of one episode — the fixed sequence of draws every row makes from its generator."""
    if config.angle_range_deg is None:
        R_e0 = so3.random(rng)
    else:
        lo, hi = config.angle_range_deg
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        R_e0 = so3.exp(math.radians(rng.uniform(lo, hi)) * axis)
    v = rng.standard_normal(3)
    v *= config.max_initial_rate * rng.uniform() ** (1.0 / 3.0) / np.linalg.norm(v)
    lo, hi = config.disturbance_scale
    return R_e0, v, float(rng.uniform(lo, hi))


class AttitudeBatch:
    """``B`` spacecraft of one :class:`AttitudeEnvConfig` stepped as one batch.

    Arrays (row ``i`` = spacecraft ``i``): ``R`` ``(B, 3, 3)``, packed state ``x`` ``(B, n_x)``
    (``ω``, actuator state), episode ``clock`` ``(B,)`` [s], ``steps`` ``(B,)``.
    """

    def __init__(self, config: AttitudeEnvConfig, batch: int) -> None:
        self.config = config
        self.B = int(batch)
        self.clock = np.zeros(self.B)
        self.dist_scale = np.ones(self.B)
        J = config.inertia
        disturbance = None
        if config.task == "tracking":
            disturbance = _EpisodeDisturbance(J, config.orbit_rate, self.clock, self.dist_scale)
        self.plant = Spacecraft(
            body=RigidBody(J), actuator=config.build_actuator(), disturbance=disturbance
        )
        self.actuator = self.plant.actuator
        self._command = getattr(self.actuator, "command_unchecked", self.actuator.command)
        self.a_sl = self.plant.act_slice
        self.baseline = config.baseline()
        self.baseline.reset(0.0, self.B)
        self.scales = config.scales
        self.n_obs = observation_size(config.observation, self.scales, self.plant.n_act)
        self.R = np.broadcast_to(np.eye(3), (self.B, 3, 3)).copy()
        self.x = np.zeros((self.B, self.plant.n_x))
        self.x[:, self.a_sl] = self.actuator.initial_state(self.B)
        self.steps = np.zeros(self.B, dtype=np.int64)
        self._x_act0 = self.actuator.initial_state(1)[0]

    # -- reference, observation ----------------------------------------------------------------

    def reference(self) -> tuple[np.ndarray, np.ndarray]:
        """``(R_d (B, 3, 3), ω_d (B, 3))`` at each row's episode time."""
        if self.config.task == "slew":
            return np.broadcast_to(np.eye(3), (self.B, 3, 3)), np.zeros((self.B, 3))
        n = self.config.orbit_rate
        u = n * self.clock
        c, s = np.cos(u), np.sin(u)
        R_d = np.zeros((self.B, 3, 3))
        # LVLH of the equatorial orbit: x_L = (−s, c, 0), y_L = (0, 0, −1), z_L = (−c, −s, 0)
        R_d[:, 0, 0], R_d[:, 1, 0] = -s, c
        R_d[:, 2, 1] = -1.0
        R_d[:, 0, 2], R_d[:, 1, 2] = -c, -s
        return R_d, np.broadcast_to(np.array([0.0, -n, 0.0]), (self.B, 3)).copy()

    def observe(self) -> np.ndarray:
        R_d, w_d = self.reference()
        xa = self.x[:, self.a_sl]
        h = self.actuator.momentum(xa)
        return _observe(
            self.config.observation, self.scales, self.R, self.x[:, :3], R_d, w_d, h, xa
        )

    # -- reset, step ---------------------------------------------------------------------------

    def reset_rows(self, rows: np.ndarray, rngs: list[np.random.Generator],
                   options: dict[str, Any] | None = None) -> None:  # fmt: skip
        """Start a new episode in each row of ``rows`` with that row's generator."""
        for i in rows:
            R_e0, dw, k = sample_episode(self.config, rngs[i])
            if options and "initial_rotvec" in options:
                R_e0 = so3.exp(options["initial_rotvec"])
            if options and "initial_rate_error" in options:
                dw = options["initial_rate_error"]
            self.clock[i] = 0.0
            self.steps[i] = 0
            self.dist_scale[i] = k
            R_d, w_d = self.reference()
            self.R[i] = R_d[i] @ R_e0
            # start rate: the reference's rate carried to the body, plus the sampled error
            self.x[i, :3] = R_e0.T @ w_d[i] + dw
            self.x[i, self.a_sl] = self._x_act0
            self.x[i, self.a_sl.stop :] = 0.0

    def torque(self, action: np.ndarray) -> np.ndarray:
        """Body torque command ``(B, 3)`` of validated actions ``(B, 3)``."""
        cfg = self.config
        if cfg.action == "torque":
            return _to_torque(action, "torque", cfg.max_torque, None)
        R_d, w_d = self.reference()
        xa = self.x[:, self.a_sl]
        st = AttitudeState.unchecked(
            R=self.R, omega=self.x[:, :3], h=self.actuator.momentum(xa), actuator_state=xa
        )
        ref = AttitudeReference.unchecked(R_d, w_d, np.zeros((self.B, 3)))
        u_pd = np.asarray(self.baseline.command(0.0, st, ref), dtype=np.float64)
        return _to_torque(action, "residual", cfg.residual_scale, u_pd)

    def step(self, action: np.ndarray) -> dict[str, np.ndarray]:
        """Hold the torque of ``action`` for ``action_period`` (the hardware command is
        recomputed at every integration step, as :func:`spacecraft.simulator.simulate` does);
        returns the reward terms and flags of each row."""
        cfg = self.config
        u = self.torque(action)
        saturated = np.zeros(self.B)
        R, x = self.R, self.x
        a_sl = self.a_sl
        kp = self.plant._kernel_plan
        if kp is not None and JIT_ENABLED and x.shape[1] == 3 + self.plant.n_act:
            # the plant's compiled command + RKMK4 kernels, all substeps in one call (the
            # same kernels the loop below calls one at a time)
            with np.errstate(over="ignore", invalid="ignore"):
                R, x, saturated = hold_steps(kp, cfg.substeps, 0.0, cfg.dt, R, x, u)
            self.clock += cfg.substeps * cfg.dt
        else:
            for _ in range(cfg.substeps):
                held = self._command(u, x[:, :3], x[:, a_sl], 0.0)
                sat = np.asarray(self.actuator.log(x[:, a_sl], held).get("saturated", False))
                saturated += np.broadcast_to(sat.reshape(self.B, -1).any(axis=1), (self.B,))
                with np.errstate(over="ignore", invalid="ignore"):
                    R, x = self.plant.step_packed(0.0, R, x, held, cfg.dt)
                self.clock += cfg.dt
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(R))):
            raise RuntimeError("state: the spacecraft state became non-finite")
        self.R, self.x = R, x
        self.steps += 1
        R_d, w_d = self.reference()
        R_e = _attitude_error(R, R_d)
        theta = so3.angle(R_e)
        e_w = np.linalg.norm(_rate_error(R_e, x[:, :3], w_d), axis=-1)
        effort = np.sum((u / cfg.max_torque) ** 2, axis=-1) / 3.0
        sat_frac = saturated / cfg.substeps
        reward = -(
            cfg.w_angle * theta / math.pi
            + cfg.w_rate * np.minimum(e_w / cfg.rate_scale, 10.0)
            + cfg.w_effort * effort
            + cfg.w_saturation * sat_frac
        )
        if cfg.task == "slew":
            terminated = (theta < math.radians(cfg.settle_angle_deg)) & (e_w < cfg.settle_rate)
        else:
            terminated = np.zeros(self.B, dtype=bool)
        truncated = (self.steps >= cfg.max_episode_steps) & ~terminated
        return {
            "reward": reward,
            "terminated": terminated,
            "truncated": truncated,
            "angle": theta,
            "rate_error": e_w,
            "effort": effort,
            "saturation": sat_frac,
            "torque": u,
        }
