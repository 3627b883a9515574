"""The attitude plant: rigid body + actuator + disturbances (+ flexible modes), RKMK4-integrated
.

State ``(R, ω, x_act[, q, q̇])`` with ``R ∈ SO(3)`` (body → inertial), body rate ``ω``, the
actuator's states ``x_act`` (gimbal angles for the SGCMG pyramid) and, with flexible appendages
(:class:`spacecraft.flexible.FlexibleModes`), the modal coordinates ``q`` and rates ``q̇``.
Rigid equations:

    Ṙ = R ω^,
    J ω̇ = −ω × J ω + u(ω, x_act, held) + T_d(t, R, ω),
    ẋ_act = f_act(x_act, held),

with ``u`` the actuator's internal torque on the bus (for the CMG cluster ``u = −A(δ) δ̇ − ω ×
h(δ)``, which is the momentum form ``J ω̇ + ω × (J ω + h) = −ḣ + T_d``). ``held`` is the actuator
command held over the step (see :mod:`spacecraft.actuators`). With flexible modes the body
equation becomes the hybrid-coordinate pair (see :mod:`spacecraft.flexible`),
solved through the Schur complement ``J − BᵀB`` precomputed here. The Lie-group integrator RKMK4
 keeps ``R`` on SO(3) to round-off.

Packed ℝⁿ state of the integrator (:meth:`PlantState.packed`): ``(ω, x_act, q, q̇)``, i.e. columns
``[0:3]``, ``Spacecraft.act_slice``, ``Spacecraft.q_slice``, ``Spacecraft.q_dot_slice``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from liecontrol._jit import JIT_ENABLED
from liecontrol._validation import as_array, as_int, check_rotation_matrix
from liecontrol.integrators.rk import rkmk4_step, rkmk4_step_unchecked

from .actuators import Actuator
from .disturbances import DisturbanceSource
from .flexible import FlexibleModes
from .rigid_body import RigidBody

__all__ = ["PlantState", "Spacecraft"]


def _held_array(held: Any) -> np.ndarray:
    """The held command as the kernels take it: the torque ``(B, 3)`` of the ideal actuator,
    the gimbal rates ``(B, 4)`` of the SGCMG cluster."""
    a = held if isinstance(held, np.ndarray) else held.delta_dot
    return np.ascontiguousarray(a, dtype=np.float64)


def _total_momentum_hook(actuator: object) -> Any:
    """``total_momentum(omega, x_act)`` of an actuator that carries its own inertia (the full
    CMG model), looking through fault wrappers (``inner``); ``None`` for a momentum source."""
    for _ in range(4):
        fn = getattr(actuator, "total_momentum", None)
        if callable(fn):
            return fn
        actuator = getattr(actuator, "inner", None)
        if actuator is None:
            return None
    return None


def _reads_attitude(source: object) -> bool:
    """Whether a disturbance source may read its ``R`` argument (``uses_attitude``, see
    :mod:`spacecraft.disturbances`); ``True`` when it does not say (the safe default)."""
    return bool(getattr(source, "uses_attitude", True))


@dataclass(frozen=True)
class PlantState:
    """Plant state of ``B`` spacecraft.

    Attributes:
        R: ``(B, 3, 3)`` attitude, body → inertial.
        omega: ``(B, 3)`` body angular velocity [rad/s].
        x_act: ``(B, n)`` actuator states (``n = actuator.n_states``; gimbal angles [rad]).
        q: ``(B, N)`` modal coordinates of the flexible appendages [√(kg)·m], or ``None``
            (no modes; for a plant with modes ``None`` means undeformed, ``q = 0``).
        q_dot: ``(B, N)`` modal rates, or ``None`` (zero).
    """

    R: np.ndarray
    omega: np.ndarray
    x_act: np.ndarray
    q: np.ndarray | None = None
    q_dot: np.ndarray | None = None

    def __post_init__(self) -> None:
        # structure only (finite real arrays, consistent batch): whether R is a rotation and
        # x_act/q fit a plant is checked by Spacecraft.check_state, which knows the plant
        R = as_array(self.R, "R")
        if R.ndim != 3 or R.shape[1:] != (3, 3):
            raise ValueError(f"R: expected shape (B, 3, 3), got {R.shape}")
        B = R.shape[0]
        w = as_array(self.omega, "omega")
        if w.shape != (B, 3):
            raise ValueError(f"omega: expected shape {(B, 3)}, got {w.shape}")
        xa = as_array(self.x_act, "x_act")
        if xa.ndim != 2 or xa.shape[0] != B:
            raise ValueError(f"x_act: expected shape ({B}, n_states), got {xa.shape}")
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "omega", w)
        object.__setattr__(self, "x_act", xa)
        for name in ("q", "q_dot"):
            v = getattr(self, name)
            if v is None:
                continue
            a = as_array(v, name)
            if a.ndim != 2 or a.shape[0] != B:
                raise ValueError(f"{name}: expected shape ({B}, n_modes), got {a.shape}")
            object.__setattr__(self, name, a)

    @property
    def batch_size(self) -> int:
        return int(self.R.shape[0])

    def packed(self) -> np.ndarray:
        """``(B, 3 + n [+ 2N])``: ``ω``, ``x_act``, then ``q`` and ``q̇`` if present — the ℝⁿ
        part of the integrator's state."""
        parts = [self.omega, self.x_act]
        if self.q is not None or self.q_dot is not None:
            ref = self.q if self.q is not None else self.q_dot
            parts.append(np.zeros(ref.shape) if self.q is None else self.q)
            parts.append(np.zeros(ref.shape) if self.q_dot is None else self.q_dot)
        return np.concatenate(parts, axis=-1)


@dataclass(frozen=True, eq=False)
class Spacecraft:
    """Rigid spacecraft with one actuator, optional disturbance torque and optional flexible
    appendage modes.

    Args:
        body: the rigid body (inertia ``J`` of the whole spacecraft; with per-spacecraft
            inertias ``J`` ``(B, 3, 3)`` every state of this plant has batch size ``B``, and
            flexible ``modes`` are not supported).
        actuator: e.g. :class:`spacecraft.actuators.SgcmgActuator` or
            :class:`spacecraft.actuators.IdealTorqueActuator`. An actuator may define
            ``check_plant(body)``, called here to reject a body it cannot drive (e.g.
            :class:`spacecraft.cmg_dynamics.VscmgActuator` whose ``bus_inertia`` is not
            ``body.J``).
        disturbance: a callable ``(t, R, omega) -> (B, 3)`` body torque [N·m], or ``None``.
        modes: :class:`spacecraft.flexible.FlexibleModes`, or ``None`` (rigid). Validated
            against ``body``: ``J − BᵀB`` must be positive definite.
        momentum_management: e.g. :class:`spacecraft.momentum.CrossProductDumping`, or
            ``None``. An object with ``dipole(t, R, h) -> (B, 3)`` (computed from the state at
            the start of each step and held over it) and ``torque(t, R, m) -> (B, 3)`` (an
            external body torque added at every integration stage); it runs alongside the
            actuator, which still takes the controller's torque. If it has ``preflight(
            disturbance)`` it is called here (the magnetic dumping feasibility check, which
            warns before the run when the rods cannot hold the disturbance).
    """

    body: RigidBody
    actuator: Actuator
    disturbance: DisturbanceSource | None = None
    modes: FlexibleModes | None = None
    momentum_management: Any = None
    _Js_inv: np.ndarray | None = field(init=False, repr=False, default=None)
    _slices: tuple = field(init=False, repr=False, default=())
    _stage_attitude: bool = field(init=False, repr=False, compare=False, default=True)
    _kernel_plan: Any = field(init=False, repr=False, compare=False, default=None)
    _coupled_plan: Any = field(init=False, repr=False, compare=False, default=None)
    _post_step: Any = field(init=False, repr=False, compare=False, default=None)

    def __post_init__(self) -> None:
        if not isinstance(self.body, RigidBody):
            raise ValueError(f"body: expected a RigidBody, got {type(self.body).__name__}")
        for name in ("command", "state_derivative", "body_torque", "initial_state", "momentum"):
            if not callable(getattr(self.actuator, name, None)):
                raise ValueError(f"actuator: has no method {name}() (see spacecraft.actuators)")
        if self.disturbance is not None and not callable(self.disturbance):
            raise ValueError("disturbance: must be callable as (t, R, omega) -> (B, 3)")
        mm = self.momentum_management
        if mm is not None and not all(callable(getattr(mm, n, None)) for n in ("dipole", "torque")):
            raise ValueError(
                "momentum_management: must have methods dipole(t, R, h) and torque(t, R, m) "
                f"(e.g. spacecraft.momentum.CrossProductDumping), got {type(mm).__name__}"
            )
        # momentum management that knows the attitude profile checks, before any run, that it
        # can hold the secular disturbance (spacecraft.momentum.magnetic_dumping_feasibility)
        preflight = getattr(mm, "preflight", None)
        if callable(preflight):
            preflight(self.disturbance)
        # optional actuator hook: an actuator whose model constrains the body (the full CMG
        # model takes body.J as its bus inertia) rejects a mismatch here, not at step 1
        check_plant = getattr(self.actuator, "check_plant", None)
        if callable(check_plant):
            check_plant(self.body)
        if self.modes is not None:
            if not isinstance(self.modes, FlexibleModes):
                raise ValueError(
                    f"modes: expected FlexibleModes or None, got {type(self.modes).__name__}"
                )
            if self.body.batch_size is not None:
                raise ValueError(
                    "modes: flexible modes need one body inertia shared by the batch (body.J of "
                    f"shape (3, 3)), got per-spacecraft inertias of shape {self.body.J.shape}"
                )
            Js_inv = np.linalg.inv(self.modes.schur_inertia(self.body.J))
            Js_inv = 0.5 * (Js_inv + Js_inv.T)
            Js_inv.setflags(write=False)
            object.__setattr__(self, "_Js_inv", Js_inv)
        a, N = 3 + self.n_act, self.n_modes
        object.__setattr__(self, "_slices", (slice(3, a), slice(a, a + N), slice(a + N, a + 2 * N)))
        # only the disturbance reads the attitude inside the RK stages: if it does not, the
        # integrator may skip the stage attitudes R e^θ (:meth:`step_packed`)
        object.__setattr__(
            self,
            "_stage_attitude",
            (self.disturbance is not None and _reads_attitude(self.disturbance))
            or self.momentum_management is not None,
        )
        # an actuator with a hard constraint on its state (the full CMG model's gimbal stops)
        # projects the packed state (ω, x_act) after every step (:meth:`step_packed`)
        post = getattr(self.actuator, "post_step", None)
        object.__setattr__(self, "_post_step", post if callable(post) else None)
        # the compiled RKMK4 step when every part has a kernel (:meth:`step_packed`)
        from ._fused import plant_kernel

        object.__setattr__(self, "_kernel_plan", plant_kernel(self))
        # a coupled actuator (full CMG dynamics) may bring its own compiled RKMK4 step
        coupled_step = getattr(self.actuator, "_rkmk4_kernel", None)
        if self._kernel_plan is None and coupled_step is not None:
            object.__setattr__(self, "_coupled_plan", coupled_step(self))

    @property
    def n_act(self) -> int:
        return int(self.actuator.n_states)

    @property
    def n_modes(self) -> int:
        """Number of flexible modes ``N`` (0 for a rigid spacecraft)."""
        return 0 if self.modes is None else self.modes.n_modes

    @property
    def n_x(self) -> int:
        """Width of the packed ℝⁿ state ``(ω, x_act, q, q̇)``: ``3 + n_act + 2 N``."""
        return 3 + self.n_act + 2 * self.n_modes

    @property
    def act_slice(self) -> slice:
        """Columns of ``x_act`` in the packed state."""
        return self._slices[0]

    @property
    def q_slice(self) -> slice:
        """Columns of ``q`` in the packed state (empty without modes)."""
        return self._slices[1]

    @property
    def q_dot_slice(self) -> slice:
        """Columns of ``q̇`` in the packed state (empty without modes)."""
        return self._slices[2]

    def unpack(self, R: np.ndarray, x: np.ndarray) -> PlantState:
        """:class:`PlantState` of the packed arrays (views into ``x``)."""
        if self.modes is None:
            return PlantState(R=R, omega=x[:, :3], x_act=x[:, self.act_slice])
        return PlantState(
            R=R,
            omega=x[:, :3],
            x_act=x[:, self.act_slice],
            q=x[:, self.q_slice],
            q_dot=x[:, self.q_dot_slice],
        )

    # -- states --------------------------------------------------------------------------------

    def initial_state(
        self,
        R0: object,
        omega0: object | None = None,
        x_act0: object | None = None,
        batch: int | None = None,
        q0: object | None = None,
        q_dot0: object | None = None,
    ) -> PlantState:
        """Validated initial state.

        ``R0`` is ``(3, 3)`` or ``(B, 3, 3)``; ``omega0`` ``(3,)`` or ``(B, 3)`` (default zero);
        ``x_act0`` ``(n,)`` or ``(B, n)`` (default ``actuator.initial_state``); with flexible
        modes ``q0`` and ``q_dot0`` ``(N,)`` or ``(B, N)`` (default zero). The batch size is
        ``batch`` if given, else the largest leading dimension found, else the body's number of
        per-spacecraft inertias (``body.J`` ``(B, 3, 3)``), which it must equal; single arrays
        broadcast.
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
        N = self.n_modes
        modal = {}
        for name, v in (("q0", q0), ("q_dot0", q_dot0)):
            if v is None:
                modal[name] = None
                continue
            if N == 0:
                raise ValueError(f"{name}: the spacecraft has no flexible modes")
            a = as_array(v, name, (N,))
            if a.ndim not in (1, 2):
                raise ValueError(f"{name}: expected shape ({N},) or (B, {N}), got {a.shape}")
            modal[name] = a
        sizes = {R0.shape[0]} if R0.ndim == 3 else set()
        arrays = (w0, xa, modal["q0"], modal["q_dot0"])
        sizes |= {a.shape[0] for a in arrays if a is not None and a.ndim == 2}
        if batch is not None:
            sizes.add(as_int(batch, "batch", 1))
        if len(sizes) > 1:
            raise ValueError(
                f"R0: batch sizes of R0/omega0/x_act0/q0/q_dot0/batch disagree: {sorted(sizes)}"
            )
        B_body = self.body.batch_size
        if B_body is not None and sizes and B_body not in sizes:
            given = (("R0", R0 if R0.ndim == 3 else None), ("omega0", w0), ("x_act0", xa),
                     ("q0", modal["q0"]), ("q_dot0", modal["q_dot0"]))  # fmt: skip
            batched = [n for n, a in given if a is not None and a.ndim > 1]
            name = "batch" if batch is not None else batched[0]
            raise ValueError(
                f"{name}: batch size {sizes.pop()} does not match the body's {B_body} "
                f"per-spacecraft inertias (body.J of shape {self.body.J.shape})"
            )
        B = sizes.pop() if sizes else (1 if B_body is None else B_body)
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
        if N == 0:
            return PlantState(R=R, omega=w, x_act=xa)
        q, qd = (
            np.zeros((B, N)) if a is None else np.broadcast_to(a, (B, N)).copy()
            for a in (modal["q0"], modal["q_dot0"])
        )
        return PlantState(R=R, omega=w, x_act=xa, q=q, q_dot=qd)

    def check_state(self, state: PlantState, name: str = "initial_state") -> PlantState:
        """Validate a :class:`PlantState` (shapes, finiteness, rotation matrices). With flexible
        modes, missing ``q``/``q_dot`` are filled with zeros."""
        if not isinstance(state, PlantState):
            raise ValueError(f"{name}: expected a PlantState, got {type(state).__name__}")
        R = check_rotation_matrix(state.R, f"{name}.R")
        if R.ndim != 3:
            raise ValueError(f"{name}.R: expected shape (B, 3, 3), got {R.shape}")
        B = R.shape[0]
        B_body = self.body.batch_size
        if B_body is not None and B != B_body:
            raise ValueError(
                f"{name}.R: batch size {B} does not match the body's {B_body} per-spacecraft "
                f"inertias (body.J of shape {self.body.J.shape})"
            )
        w = as_array(state.omega, f"{name}.omega")
        if w.shape != (B, 3):
            raise ValueError(f"{name}.omega: expected shape {(B, 3)}, got {w.shape}")
        xa = as_array(state.x_act, f"{name}.x_act")
        if xa.shape != (B, self.n_act):
            raise ValueError(f"{name}.x_act: expected shape {(B, self.n_act)}, got {xa.shape}")
        N = self.n_modes
        if N == 0:
            for attr in ("q", "q_dot"):
                v = getattr(state, attr)
                if v is not None and np.size(v) > 0:
                    raise ValueError(f"{name}.{attr}: the spacecraft has no flexible modes")
            return PlantState(R=R, omega=w, x_act=xa)
        modal = []
        for attr in ("q", "q_dot"):
            v = getattr(state, attr)
            a = np.zeros((B, N)) if v is None else as_array(v, f"{name}.{attr}")
            if a.shape != (B, N):
                raise ValueError(f"{name}.{attr}: expected shape {(B, N)}, got {a.shape}")
            modal.append(a)
        return PlantState(R=R, omega=w, x_act=xa, q=modal[0], q_dot=modal[1])

    # -- physics -------------------------------------------------------------------------------

    def actuator_momentum(self, state: PlantState) -> np.ndarray:
        """Stored actuator momentum ``h`` in body axes ``(B, 3)`` [N·m·s]."""
        return self.actuator.momentum(state.x_act)

    def body_frame_momentum(self, state: PlantState) -> np.ndarray:
        """Total angular momentum of bus, actuator and appendages in body axes ``(B, 3)``
        [N·m·s].

        ``J ω + Bᵀ q̇ + h`` for an actuator modelled as a momentum source ``h`` (ideal torque,
        reaction wheels, the SGCMG momentum model: ``J`` is then the whole spacecraft's
        inertia). An actuator that carries its own inertia — the full CMG model
        :class:`spacecraft.cmg_dynamics.VscmgActuator`, whose gimbal frames and rotors are not
        in ``body.J`` (the bus inertia ``J_B``) — defines ``total_momentum(omega, x_act)``,
        which is used instead: ``J_tot(δ) ω + Σ (J_g δ̇ g + I_Ws Ω s)``. This is the one
        implementation of the total momentum; tests, metrics and docs call it (or
        :meth:`inertial_momentum`).
        """
        total = _total_momentum_hook(self.actuator)
        if total is not None:
            H = np.asarray(total(state.omega, state.x_act), dtype=np.float64)
        else:
            H = self.body.body_momentum(state.omega, self.actuator_momentum(state))
        if self.modes is not None and state.q_dot is not None:
            H = H + self.modes.momentum(state.q_dot)
        return H

    def inertial_momentum(self, state: PlantState) -> np.ndarray:
        """Total angular momentum in inertial axes ``R H`` ``(B, 3)`` [N·m·s], with ``H`` the
        body-axis total of :meth:`body_frame_momentum` (bus, actuator with its own gimbal and
        rotor inertia where it has them, flexible appendages).

        Constant under these assumptions: no external torque (no disturbance, no momentum
        management), and up to the integrator's truncation error (RKMK4 conserves ``R H`` to
        ``O((h λ)⁴)`` per unit time, ``λ`` the fastest mode of the plant), whatever the
        controller and steering law do. Gimbal-stop contact of the full CMG model exchanges
        momentum between gimbal and bus and keeps the total.
        """
        return np.einsum("...ij,...j->...i", state.R, self.body_frame_momentum(state))

    def mechanical_energy(self, state: PlantState) -> np.ndarray:
        """Body + appendage energy ``½ωᵀJω + ωᵀBᵀq̇ + ½|q̇|² + ½qᵀΛ²q`` ``(B,)`` [J] (without
        the actuator's rotor energy). Without actuator torque and disturbance it only decreases,
        by ``2 q̇ᵀζΛq̇`` per second (:mod:`spacecraft.flexible`)."""
        E = self.body.kinetic_energy(state.omega)
        if self.modes is not None and state.q is not None:
            qd = state.q_dot
            E = E + np.einsum("...i,...i->...", state.omega, self.modes.momentum(qd))
            E = E + self.modes.modal_energy(state.q, qd).sum(axis=-1)
        return E

    def disturbance_torque(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """External torque ``T_d`` ``(B, 3)`` [N·m] (zeros without a disturbance model)."""
        if self.disturbance is None:
            return np.zeros(omega.shape)
        return np.asarray(self.disturbance(t, R, omega), dtype=np.float64)

    def derivatives(
        self, t: float, R: np.ndarray, x: np.ndarray, held: Any, dipole: Any = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Right-hand side for RKMK4: ``(ω, ẋ)`` with ``Ṙ = R ω^`` and ``x = (ω, x_act, q, q̇)``.

        ``x`` is ``(B, n_x)``; returns body rate ``(B, 3)`` and ``ẋ = (ω̇, ẋ_act, q̇, q̈)``.
        ``dipole``: the held momentum-management dipole ``(B, 3)`` (its torque
        ``momentum_management.torque(t, R, dipole)`` is added), or ``None``.
        """
        omega = x[:, :3]
        act = self.actuator
        modes = self.modes
        x_act = x[:, 3:] if modes is None else x[:, self._slices[0]]
        coupled = getattr(act, "coupled_derivatives", None)
        if coupled is not None:
            # an actuator whose state accelerations couple with the bus's (the full CMG model,
            # spacecraft.cmg_dynamics) returns (ω̇, ẋ_act) itself, given the external torque
            if modes is not None:
                raise ValueError("modes: not supported with an actuator coupled to the bus")
            tau = np.zeros(omega.shape)
            if self.disturbance is not None:
                tau = tau + self.disturbance(t, R, omega)
            if dipole is not None:
                tau = tau + self.momentum_management.torque(t, R, dipole)
            return omega, coupled(omega, x_act, held, tau, self.body.J)
        tau = act.body_torque(omega, x_act, held)
        if self.disturbance is not None:
            tau = tau + self.disturbance(t, R, omega)
        if dipole is not None:
            tau = tau + self.momentum_management.torque(t, R, dipole)
        x_dot = np.empty(x.shape)
        if modes is None:
            x_dot[:, :3] = self.body.angular_acceleration_unchecked(omega, tau)
        else:
            _, q_sl, qd_sl = self._slices
            q_dot = x[:, qd_sl]
            w_dot, q_ddot = modes.accelerations(
                omega, x[:, q_sl], q_dot, tau, self.body.J, self._Js_inv
            )
            x_dot[:, :3] = w_dot
            x_dot[:, q_sl] = q_dot
            x_dot[:, qd_sl] = q_ddot
        if x_act.shape[1] > 0:
            x_dot[:, 3 : 3 + x_act.shape[1]] = act.state_derivative(x_act, held)
        return omega, x_dot

    def command(self, u_cmd: np.ndarray, state: PlantState, t: float) -> Any:
        """The actuator's hardware command for torque command ``u_cmd`` ``(B, 3)``."""
        return self.actuator.command(u_cmd, state.omega, state.x_act, t)

    def step_packed(
        self, t: float, R: np.ndarray, x: np.ndarray, held: Any, h: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """One RKMK4 step on packed arrays ``x = (ω, x_act, q, q̇)`` — the simulator's hot path:
        no validation, and a non-finite state is returned as is (the simulator checks)."""
        # only the disturbance reads the attitude: without one that does, the integrator skips
        # the stage attitudes R e^θ and passes R=None (same result, three exponentials and 3×3
        # products fewer per step)
        stage_attitude = self._stage_attitude
        m = None
        if self.momentum_management is not None:
            m = self.held_dipole(t, R, x[:, self.act_slice])
        kp = self._kernel_plan
        if kp is not None and (JIT_ENABLED or x.shape[0] == 1):
            # without numba the kernel runs as Python: only worth it for one spacecraft
            R1, x1 = kp.step(t, R, x, _held_array(held), h)
            return (R1, x1) if self._post_step is None else (R1, self._post_step(x1))
        cp = self._coupled_plan
        post = self._post_step
        if cp is not None and (JIT_ENABLED or x.shape[0] == 1):
            R1, x1 = cp(t, R, x, held, h)
            return (R1, x1) if post is None else (R1, post(x1))
        derivatives = self.derivatives

        def f(tt: float, RR: np.ndarray, xx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return derivatives(tt, RR, xx, held, m)

        R1, x1 = rkmk4_step_unchecked(f, t, R, x, h, stage_attitude=stage_attitude)
        return (R1, x1) if post is None else (R1, post(x1))

    def held_dipole(self, t: float, R: np.ndarray, x_act: np.ndarray) -> np.ndarray | None:
        """The momentum-management dipole ``(B, 3)`` held over the step from ``t`` (from the
        actuator's stored momentum), or ``None`` without momentum management."""
        mm = self.momentum_management
        if mm is None:
            return None
        return np.asarray(mm.dipole(t, R, self.actuator.momentum(x_act)), dtype=np.float64)

    def momentum_management_log(
        self, t: float, R: np.ndarray, x_act: np.ndarray
    ) -> dict[str, np.ndarray]:
        """Log entries at ``t``: the management's own ``log(t, R, h)`` where it has one, else
        ``dipole`` held from ``t`` and its ``magnetic_torque`` ``(B, 3)`` (empty without momentum
        management)."""
        mm = self.momentum_management
        if mm is None:
            return {}
        own = getattr(mm, "log", None)
        if callable(own):  # the management's own entries (thrusters: torque, valves, propellant)
            return dict(own(t, R, self.actuator.momentum(x_act)))
        m = self.held_dipole(t, R, x_act)
        return {"dipole": m, "magnetic_torque": mm.torque(t, R, m)}

    def step(self, state: PlantState, held: Any, t: float, h: float) -> PlantState:
        """Advance ``state`` from ``t`` to ``t + h`` with the actuator command ``held`` fixed
        (``held = plant.command(u_cmd, state, t)``), by one RKMK4 step.

        Validated (:func:`liecontrol.integrators.rk.rkmk4_step` checks ``t``, ``h``, the state
        and that the right-hand side stays finite, raising ``ValueError`` otherwise).
        """
        derivatives = self.derivatives
        state = self.check_state(state, "state")
        m = self.held_dipole(t, state.R, state.x_act)

        def f(tt: float, RR: np.ndarray, xx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return derivatives(tt, RR, xx, held, m)

        R, x = rkmk4_step(f, t, state.R, state.packed(), h)
        if self._post_step is not None:
            x = self._post_step(x)
        return self.unpack(R, x)
