"""The attitude plant: rigid body + actuator + disturbances, RKMK4-integrated (SPEC §5.1, §5.8).

State ``(R, ω, x_act)`` with ``R ∈ SO(3)`` (body → inertial), body rate ``ω`` and the actuator's
states ``x_act`` (gimbal angles for the SGCMG pyramid). Equations (SPEC §5.1):

    Ṙ = R ω^,
    J ω̇ = −ω × J ω + u(ω, x_act, held) + T_d(t, R, ω),
    ẋ_act = f_act(x_act, held),

with ``u`` the actuator's internal torque on the bus (for the CMG cluster ``u = −A(δ) δ̇ − ω ×
h(δ)``, which is the momentum form ``J ω̇ + ω × (J ω + h) = −ḣ + T_d``). ``held`` is the actuator
command held over the step (see :mod:`spacecraft.actuators`). The Lie-group integrator RKMK4
(SPEC §3.3) keeps ``R`` on SO(3) to round-off.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._validation import as_array, check_rotation_matrix
from liecontrol.integrators.rk import rkmk4_step, rkmk4_step_unchecked

from .actuators import Actuator
from .disturbances import DisturbanceSource
from .rigid_body import RigidBody

__all__ = ["PlantState", "Spacecraft"]


@dataclass(frozen=True)
class PlantState:
    """Plant state of ``B`` spacecraft.

    Attributes:
        R: ``(B, 3, 3)`` attitude, body → inertial.
        omega: ``(B, 3)`` body angular velocity [rad/s].
        x_act: ``(B, n)`` actuator states (``n = actuator.n_states``; gimbal angles [rad]).
    """

    R: np.ndarray
    omega: np.ndarray
    x_act: np.ndarray

    @property
    def batch_size(self) -> int:
        return int(self.R.shape[0])

    def packed(self) -> np.ndarray:
        """``(B, 3 + n)``: ``ω`` then ``x_act`` — the ℝⁿ part of the integrator's state."""
        return np.concatenate([self.omega, self.x_act], axis=-1)


@dataclass(frozen=True, eq=False)
class Spacecraft:
    """Rigid spacecraft with one actuator and optional disturbance torque (SPEC §5.1).

    Args:
        body: the rigid body (inertia).
        actuator: e.g. :class:`spacecraft.actuators.SgcmgActuator` or
            :class:`spacecraft.actuators.IdealTorqueActuator`.
        disturbance: a callable ``(t, R, omega) -> (B, 3)`` body torque [N·m], or ``None``.
    """

    body: RigidBody
    actuator: Actuator
    disturbance: DisturbanceSource | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.body, RigidBody):
            raise ValueError(f"body: expected a RigidBody, got {type(self.body).__name__}")
        for name in ("command", "state_derivative", "body_torque", "initial_state", "momentum"):
            if not callable(getattr(self.actuator, name, None)):
                raise ValueError(f"actuator: has no method {name}() (see spacecraft.actuators)")
        if self.disturbance is not None and not callable(self.disturbance):
            raise ValueError("disturbance: must be callable as (t, R, omega) -> (B, 3)")

    @property
    def n_act(self) -> int:
        return int(self.actuator.n_states)

    # -- states --------------------------------------------------------------------------------

    def initial_state(
        self,
        R0: object,
        omega0: object | None = None,
        x_act0: object | None = None,
        batch: int | None = None,
    ) -> PlantState:
        """Validated initial state.

        ``R0`` is ``(3, 3)`` or ``(B, 3, 3)``; ``omega0`` ``(3,)`` or ``(B, 3)`` (default zero);
        ``x_act0`` ``(n,)`` or ``(B, n)`` (default ``actuator.initial_state``). The batch size is
        ``batch`` if given, else the largest leading dimension found; single arrays broadcast.
        """
        R0 = check_rotation_matrix(R0, "R0")
        if R0.ndim not in (2, 3):
            raise ValueError(f"R0: expected shape (3, 3) or (B, 3, 3), got {R0.shape}")
        w0 = None if omega0 is None else as_array(omega0, "omega0", (3,))
        if w0 is not None and w0.ndim not in (1, 2):
            raise ValueError(f"omega0: expected shape (3,) or (B, 3), got {w0.shape}")
        n = self.n_act
        xa = None if x_act0 is None else as_array(x_act0, "x_act0", (n,))
        if xa is not None and xa.ndim not in (1, 2):
            raise ValueError(f"x_act0: expected shape ({n},) or (B, {n}), got {xa.shape}")
        sizes = {R0.shape[0]} if R0.ndim == 3 else set()
        sizes |= {a.shape[0] for a in (w0, xa) if a is not None and a.ndim == 2}
        if batch is not None:
            sizes.add(int(batch))
        if len(sizes) > 1:
            raise ValueError(f"R0: batch sizes of R0/omega0/x_act0/batch disagree: {sorted(sizes)}")
        B = sizes.pop() if sizes else 1
        if B < 1:
            raise ValueError(f"batch: must be >= 1, got {B}")
        R = np.broadcast_to(R0, (B, 3, 3)).copy()
        w = np.zeros((B, 3)) if w0 is None else np.broadcast_to(w0, (B, 3)).copy()
        if xa is None:
            xa = np.asarray(self.actuator.initial_state(B), dtype=np.float64)
            if xa.shape != (B, n):
                raise ValueError(
                    f"actuator: initial_state({B}) has shape {xa.shape}, expected {(B, n)}"
                )
        else:
            xa = np.broadcast_to(xa, (B, n)).copy()
        return PlantState(R=R, omega=w, x_act=xa)

    def check_state(self, state: PlantState, name: str = "initial_state") -> PlantState:
        """Validate a :class:`PlantState` (shapes, finiteness, rotation matrices)."""
        if not isinstance(state, PlantState):
            raise ValueError(f"{name}: expected a PlantState, got {type(state).__name__}")
        R = check_rotation_matrix(state.R, f"{name}.R")
        if R.ndim != 3:
            raise ValueError(f"{name}.R: expected shape (B, 3, 3), got {R.shape}")
        B = R.shape[0]
        w = as_array(state.omega, f"{name}.omega")
        if w.shape != (B, 3):
            raise ValueError(f"{name}.omega: expected shape {(B, 3)}, got {w.shape}")
        xa = as_array(state.x_act, f"{name}.x_act")
        if xa.shape != (B, self.n_act):
            raise ValueError(f"{name}.x_act: expected shape {(B, self.n_act)}, got {xa.shape}")
        return PlantState(R=R, omega=w, x_act=xa)

    # -- physics -------------------------------------------------------------------------------

    def actuator_momentum(self, state: PlantState) -> np.ndarray:
        """Stored actuator momentum ``h`` in body axes ``(B, 3)`` [N·m·s]."""
        return self.actuator.momentum(state.x_act)

    def inertial_momentum(self, state: PlantState) -> np.ndarray:
        """Total angular momentum in inertial axes ``R (J ω + h)`` ``(B, 3)`` [N·m·s] — constant
        without disturbance, whatever the controller and steering law do."""
        return self.body.inertial_momentum(state.R, state.omega, self.actuator_momentum(state))

    def disturbance_torque(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """External torque ``T_d`` ``(B, 3)`` [N·m] (zeros without a disturbance model)."""
        if self.disturbance is None:
            return np.zeros(omega.shape)
        return np.asarray(self.disturbance(t, R, omega), dtype=np.float64)

    def derivatives(
        self, t: float, R: np.ndarray, x: np.ndarray, held: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        """Right-hand side for RKMK4: ``(ω, ẋ)`` with ``Ṙ = R ω^`` and ``x = (ω, x_act)``.

        ``x`` is ``(B, 3 + n)``; returns body rate ``(B, 3)`` and ``ẋ = (ω̇, ẋ_act)``.
        """
        omega = x[:, :3]
        x_act = x[:, 3:]
        act = self.actuator
        tau = act.body_torque(omega, x_act, held)
        if self.disturbance is not None:
            tau = tau + self.disturbance(t, R, omega)
        x_dot = np.empty(x.shape)
        x_dot[:, :3] = self.body.angular_acceleration(omega, tau)
        if x.shape[1] > 3:
            x_dot[:, 3:] = act.state_derivative(x_act, held)
        return omega, x_dot

    def command(self, u_cmd: np.ndarray, state: PlantState, t: float) -> Any:
        """The actuator's hardware command for torque command ``u_cmd`` ``(B, 3)``."""
        return self.actuator.command(u_cmd, state.omega, state.x_act, t)

    def step_packed(
        self, t: float, R: np.ndarray, x: np.ndarray, held: Any, h: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """One RKMK4 step on packed arrays ``x = (ω, x_act)`` — the simulator's hot path: no
        validation, and a non-finite state is returned as is (the simulator checks)."""
        derivatives = self.derivatives

        def f(tt: float, RR: np.ndarray, xx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return derivatives(tt, RR, xx, held)

        return rkmk4_step_unchecked(f, t, R, x, h)

    def step(self, state: PlantState, held: Any, t: float, h: float) -> PlantState:
        """Advance ``state`` from ``t`` to ``t + h`` with the actuator command ``held`` fixed
        (``held = plant.command(u_cmd, state, t)``), by one RKMK4 step (SPEC §3.3).

        Validated (:func:`liecontrol.integrators.rk.rkmk4_step` checks ``t``, ``h``, the state
        and that the right-hand side stays finite, raising ``ValueError`` otherwise).
        """
        derivatives = self.derivatives

        def f(tt: float, RR: np.ndarray, xx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return derivatives(tt, RR, xx, held)

        R, x = rkmk4_step(f, t, state.R, state.packed(), h)
        return PlantState(R=R, omega=x[:, :3], x_act=x[:, 3:])
