"""Full (variable-speed) control-moment-gyro dynamics: gimbal-frame and rotor inertia, a
torque-limited gimbal-rate servo, gimbal-angle stops.

The momentum model of :class:`spacecraft.actuators.SgcmgActuator` (the default, fast path)
treats the cluster as a momentum source ``h(δ)`` whose gimbals turn at the commanded rate. This
module keeps what that model drops: each unit is a gimbal frame carrying a symmetric rotor, with

* gimbal axis ``g`` fixed in the bus, spin axis ``s(δ)``, transverse axis ``t = g × s``
  (``ṡ = δ̇ t``, ``ṫ = −δ̇ s``);
* rotor spin inertia ``I_Ws`` and transverse inertia ``I_Wt``; gimbal-frame inertias
  ``(I_Gs, I_Gt, I_Gg)``; combined ``J_s = I_Gs + I_Ws``, ``J_t = I_Gt + I_Wt``,
  ``J_g = I_Gg + I_Wt``;
* rotor spin rate ``Ω`` relative to the gimbal frame (``I_Ws Ω₀ = h₀`` of the cluster),
  gimbal motor torque ``u_g`` and spin motor torque ``u_s``.

Equations of motion (Schaub & Junkins, *Analytical Mechanics of Space Systems*, 4th ed., AIAA
2018, ch. 4, VSCMG section; the same equations are documented for Basilisk's
``vscmgStateEffector`` with balanced wheels; derived again here from the angular momentum of
each gimbal and rotor, with ``ω_s = sᵀω``, ``ω_t = tᵀω``, ``ω_g = gᵀω``)::

    H = J_B ω + Σᵢ [J_s ω_s s + J_t ω_t t + J_g (ω_g + δ̇) g + I_Ws Ω s]       (body axes)
    Ḣ_B + ω × H = L                                                           (bus + cluster)
    J_g (gᵀω̇ + δ̈) = u_g + (J_s − J_t) ω_s ω_t + I_Ws Ω ω_t                    (each gimbal)
    I_Ws (sᵀω̇ + Ω̇) = u_s − I_Ws δ̇ ω_t                                         (each rotor)

Written out, the bus equation is ``[J_B + Σ (J_s s sᵀ + J_t t tᵀ + J_g g gᵀ)] ω̇ + Σ J_g g δ̈ +
Σ I_Ws s Ω̇ = L − ω × H − Σ δ̇ [(J_s − J_t)(ω_t s + ω_s t) + I_Ws Ω t]``: the mass matrix of
``(ω, δ̇, Ω)`` is not block-diagonal (the gimbal and rotor accelerations react on the bus), so
the plant asks this actuator for the coupled accelerations (:meth:`VscmgActuator.
coupled_derivatives`), solving one 3×3 system per spacecraft after eliminating δ̈ and Ω̇.
``J_B`` (``bus_inertia``) is the spacecraft inertia without the gimbal frames' and rotors' own
rotational inertia (their masses as point masses included): the total inertia is
``J_B + Σ (J_s s sᵀ + J_t t tᵀ + J_g g gᵀ)``, which changes with δ. Kinetic energy::

    T = ½ ωᵀ J_tot(δ) ω + Σ [J_g ω_g δ̇ + ½ J_g δ̇² + I_Ws ω_s Ω + ½ I_Ws Ω²],
    Ṫ = ωᵀ L + Σ (u_g δ̇ + u_s Ω)                      (power of the motors and external torque)

— the work of the motors is integrated as an actuator state, so the energy balance is a test.

Gimbal drive, either

* :class:`GimbalServo` — the motor torque is the input: a PI loop on the commanded gimbal rate
  (gains from a bandwidth and the gimbal inertia), clipped to the motor torque limit, with
  conditional-integration anti-windup; the gimbal acceleration then follows from the coupled
  dynamics (base-rate and gyroscopic torques fight the motor), or
* :class:`spacecraft.actuators.FirstOrderServo` — a kinematic rate loop: ``δ̈ = (δ̇_cmd − δ̇)/τ``
  is imposed and the torque the motor must supply is computed (and logged). As the gimbal and
  rotor inertias go to zero with ``I_Ws Ω = h₀`` fixed, this tends to ``SgcmgActuator(servo=
  FirstOrderServo(τ))`` with a difference proportional to the inertia.

Rotor: constant speed (default; the spin motor holds ``Ω̇ = 0`` and its torque is computed) or
``variable_speed=True`` (the spin torque is an input, zero unless given by an open-loop command).

Gimbal stops (:class:`GimbalStops`, e.g. a cable wrap of ±n turns), a hard limit in three
layers: (1) steering that knows the stops — the law is wrapped in
:class:`spacecraft.steering.StopAware`, which weights gimbals heading into a nearby stop down so
the others take the torque (``stop_aware=True``, the default); (2) the rate command is shaped
near a stop — the outward rate is limited to the braking curve ``√(2 a_b d)`` with ``d`` the
distance left after the servo lag, so it reaches zero at the stop (inward motion is never
limited; logged as ``stop_limited``); (3) the stop itself is a rigid contact
(``contact="hard"``, the default): after every integration step a gimbal found beyond its stop
is put back on it and a gimbal on its stop moving outward is stopped by a plastic impact whose
reaction goes into the bus, the total angular momentum kept exactly and the dissipated energy
booked as work of the stops (:meth:`VscmgActuator.enforce_stops`). So ``lower ≤ δ ≤ upper``
holds at every step end — every logged sample — whatever the steering, the servo's torque
limit or the base-rate torque do (a PI rate loop does not hold zero rate against a base-rate
torque: only the contact does). ``contact="bumper"`` instead models the stop as a stiff
spring-damper acting beyond the limit inside the stages (penetration allowed). Contact and
torque saturation are logged (``stop_contact``: a gimbal on a stop; ``torque_saturated``) and
counted by :mod:`benchmarks.metrics` (``stop_contact_time_s``).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from liecontrol._jit import JIT_ENABLED
from liecontrol._validation import (
    as_array,
    check_bool,
    check_inertia_3x3,
    check_nonnegative,
    check_positive,
)

from ._kernels_vscmg import (
    DET_GIMBAL_POWER,
    DET_GIMBAL_TORQUE,
    DET_SATURATED,
    DET_SPIN_TORQUE,
    N_PAR,
    vscmg_command_inputs_batch,
    vscmg_command_inputs_one,
    vscmg_derivatives_batch,
    vscmg_derivatives_one,
    vscmg_rkmk4_step_batch,
)
from .actuators import Actuator, FirstOrderServo
from .rigid_body import _cross

__all__ = [
    "CmgInertias",
    "GimbalServo",
    "GimbalStops",
    "VscmgCommand",
    "VscmgActuator",
    "MiniCmgPreset",
    "MINI_CMG",
]

_TWO_PI = 2.0 * math.pi


def _pos(v: object, name: str) -> float:
    a = check_positive(v, name)
    if not isinstance(a, float):
        raise ValueError(f"{name}: must be a scalar, got shape {np.shape(a)}")
    return a


def _per_gimbal(v: object, name: str) -> np.ndarray:
    a = as_array(v, name)
    if a.ndim == 0:
        return np.full(4, float(a))
    if a.shape != (4,):
        raise ValueError(f"{name}: expected a scalar or shape (4,), got shape {a.shape}")
    return a.copy()


@dataclass(frozen=True)
class CmgInertias:
    """Inertias of one CMG unit (the same for all four) [kg·m²].

    Args:
        wheel_spin: rotor inertia about its spin axis ``I_Ws`` (> 0).
        wheel_transverse: rotor inertia about a transverse axis ``I_Wt`` (> 0).
        gimbal: gimbal-frame inertia about ``(s, t, g)``: ``(I_Gs, I_Gt, I_Gg)`` (each > 0).
    """

    wheel_spin: float
    wheel_transverse: float
    gimbal: tuple[float, float, float]

    def __post_init__(self) -> None:
        object.__setattr__(self, "wheel_spin", _pos(self.wheel_spin, "wheel_spin"))
        object.__setattr__(
            self, "wheel_transverse", _pos(self.wheel_transverse, "wheel_transverse")
        )
        g = as_array(self.gimbal, "gimbal")
        if g.shape != (3,):
            raise ValueError(f"gimbal: expected 3 inertias (I_Gs, I_Gt, I_Gg), got shape {g.shape}")
        if np.any(g <= 0):
            raise ValueError(f"gimbal: inertias must be > 0, got {g.tolist()}")
        object.__setattr__(self, "gimbal", tuple(float(v) for v in g))

    @property
    def J_s(self) -> float:
        """Gimbal frame + rotor about the spin axis, ``I_Gs + I_Ws``."""
        return self.gimbal[0] + self.wheel_spin

    @property
    def J_t(self) -> float:
        """Gimbal frame + rotor about the transverse axis, ``I_Gt + I_Wt``."""
        return self.gimbal[1] + self.wheel_transverse

    @property
    def J_g(self) -> float:
        """Gimbal frame + rotor about the gimbal axis, ``I_Gg + I_Wt``."""
        return self.gimbal[2] + self.wheel_transverse

    def scaled(self, factor: float) -> CmgInertias:
        """All inertias times ``factor`` (> 0)."""
        f = _pos(factor, "factor")
        return CmgInertias(
            self.wheel_spin * f, self.wheel_transverse * f, tuple(v * f for v in self.gimbal)
        )


@dataclass(frozen=True)
class GimbalServo:
    """Torque-limited PI gimbal-rate servo::

        e = δ̇_cmd − δ̇,   u_g = sat_{±u_max}(K_p e + K_i z [+ u_ff]),   ż = e
        K_p = 2 ζ ω_b J_g,   K_i = ω_b² J_g,

    i.e. on the bare gimbal ``J_g δ̈ = u_g`` the loop has natural frequency ``ω_b`` and damping
    ``ζ`` (a standard PI rate loop; Wie, *Space Vehicle Dynamics and Control*, 2nd ed., AIAA
    2008, §7.3). While the torque is saturated and the error would drive it further, ``z`` is
    frozen (conditional-integration anti-windup). With ``gyro_feedforward`` the servo adds the
    gyroscopic/base-rate torque ``−(J_s − J_t) ω_s ω_t − I_Ws Ω ω_t`` it can compute from the
    body rate at the command sample.

    Args:
        bandwidth: ω_b > 0 [rad/s].
        max_torque: motor torque limit > 0 [N·m].
        damping: ζ > 0 (default 1).
        gyro_feedforward: add the base-rate torque feed-forward (default ``False``).
    """

    bandwidth: float
    max_torque: float
    damping: float = 1.0
    gyro_feedforward: bool = False

    def __post_init__(self) -> None:
        for name in ("bandwidth", "max_torque", "damping"):
            object.__setattr__(self, name, _pos(getattr(self, name), name))
        object.__setattr__(
            self, "gyro_feedforward", check_bool(self.gyro_feedforward, "gyro_feedforward")
        )

    @property
    def lag(self) -> float:
        """Effective rate-loop lag ``2ζ/ω_b`` [s] (used by the stop guard)."""
        return 2.0 * self.damping / self.bandwidth


@dataclass(frozen=True)
class GimbalStops:
    """Hard gimbal-angle limits ``lower < δ < upper`` [rad] (scalar or per gimbal ``(4,)``).

    Args:
        lower, upper: the stops (``lower < upper`` elementwise).
        braking_acceleration: ``a_b > 0`` [rad/s²] of the command's braking curve.
        stiffness: bumper stiffness ``k > 0`` [N·m/rad] beyond a stop (``contact="bumper"``
            with a :class:`GimbalServo`).
        damping: bumper damping ``c ≥ 0`` [N·m·s/rad] (only while pressing into the stop).
        margin: ``≥ 0`` [rad]: the guard brakes to ``stop − margin`` (room for the motion
            during the held command step; the braking curve is exact only in continuous time).
        contact: ``"hard"`` (default): the stop is a rigid constraint — at every step end a
            gimbal beyond a stop is put back on it and one moving outward is stopped by a
            plastic impact whose reaction goes into the bus, keeping the total momentum
            (:meth:`VscmgActuator.enforce_stops`); ``lower ≤ δ ≤ upper`` then holds at every
            step end. ``"bumper"``: a stiff spring-damper (``stiffness``, ``damping``) acts
            beyond the stop inside the integration stages and the gimbal may penetrate
            (bounded by the bumper; choose ``dt`` so that ``dt·√(k/J_g)`` stays well inside
            RK4's stability region, else the integrator's momentum error grows).
    """

    lower: float | np.ndarray
    upper: float | np.ndarray
    braking_acceleration: float = 2.0
    stiffness: float = 1.0e4
    damping: float = 50.0
    margin: float = 0.01
    contact: str = "hard"

    def __post_init__(self) -> None:
        lo, hi = _per_gimbal(self.lower, "lower"), _per_gimbal(self.upper, "upper")
        bad = np.flatnonzero(lo >= hi)
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"lower: must be < upper for every gimbal, got lower[{i}] = {lo[i]:.6g} >= "
                f"upper[{i}] = {hi[i]:.6g}"
            )
        for a in (lo, hi):
            a.setflags(write=False)
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)
        for name in ("braking_acceleration", "stiffness"):
            object.__setattr__(self, name, _pos(getattr(self, name), name))
        for name in ("damping", "margin"):
            v = check_nonnegative(getattr(self, name), name)
            if not isinstance(v, float):
                raise ValueError(f"{name}: must be a scalar, got shape {np.shape(v)}")
            object.__setattr__(self, name, v)
        if self.contact not in ("hard", "bumper"):
            raise ValueError(f"contact: expected 'hard' or 'bumper', got {self.contact!r}")
        if np.any(hi - lo <= 2.0 * self.margin):
            raise ValueError(
                f"margin: {self.margin:.6g} rad leaves no travel between the stops "
                f"(smallest range {float(np.min(hi - lo)):.6g} rad)"
            )

    @classmethod
    def cable_wrap(
        cls, turns: float, center: float | np.ndarray = 0.0, **kwargs: Any
    ) -> GimbalStops:
        """Stops of a gimbal with a cable wrap of ``±turns`` revolutions about ``center``."""
        n = _pos(turns, "turns")
        c = np.broadcast_to(as_array(center, "center"), (4,))
        return cls(lower=c - _TWO_PI * n, upper=c + _TWO_PI * n, **kwargs)

    def check_angles(self, delta: np.ndarray, name: str) -> None:
        """Raise (naming ``name``) if any angle lies outside ``[lower, upper]``."""
        out = (delta < self.lower) | (delta > self.upper)
        if np.any(out):
            i = np.argwhere(out)[0]
            raise ValueError(
                f"{name}: gimbal {int(i[-1])} angle {float(delta[tuple(i)]):.6g} rad lies "
                f"outside its stops [{self.lower[i[-1]]:.6g}, {self.upper[i[-1]]:.6g}]"
            )

    def guard(self, rate_cmd: np.ndarray, delta: np.ndarray, rate: np.ndarray, lag: float):
        """Shape a rate command near the stops (see module doc); returns ``(rate, limited)``."""
        a2 = 2.0 * self.braking_acceleration
        d_up = self.upper - self.margin - delta - lag * np.abs(rate)
        d_lo = delta - self.lower - self.margin - lag * np.abs(rate)
        v_up = np.sqrt(a2 * np.maximum(d_up, 0.0))
        v_lo = np.sqrt(a2 * np.maximum(d_lo, 0.0))
        out = np.clip(rate_cmd, -v_lo, v_up)
        return out, out != rate_cmd


@dataclass(frozen=True)
class VscmgCommand:
    """What :class:`VscmgActuator` holds over one integration step.

    Attributes:
        delta_dot_cmd: ``(B, 4)`` commanded gimbal rates (after rate limit and stop guard).
        omega: ``(B, 3)`` body rate at the command sample (feed-forward and logging).
        saturated: ``(B,)`` whether the rate limit scaled the steering output.
        stop_limited: ``(B, 4)`` whether the stop guard changed the command.
        h_dot_cmd: ``(B, 3)`` momentum rate asked of the steering law.
        gimbal_torque_ff: ``(B, 4)`` feed-forward (or, with ``open_loop``, the whole) gimbal
            motor torque [N·m].
        spin_torque: ``(B, 4)`` spin motor torque (used with ``variable_speed``) [N·m].
        open_loop: ``True``: no rate loop, the gimbal motors apply ``gimbal_torque_ff`` (clipped
            to the servo's limit) — prescribed-torque runs (:meth:`VscmgActuator.open_loop`).
    """

    delta_dot_cmd: np.ndarray
    omega: np.ndarray
    saturated: np.ndarray
    stop_limited: np.ndarray
    h_dot_cmd: np.ndarray
    gimbal_torque_ff: np.ndarray
    spin_torque: np.ndarray
    open_loop: bool = False


def _default_steering() -> Any:
    from .steering import SingularityRobust

    return SingularityRobust()


class VscmgActuator(Actuator):
    """Four-CMG pyramid with full gimbal/rotor dynamics (see module doc).

    State ``x_act`` ``(B, 17)``: gimbal angles δ, gimbal rates δ̇, rotor spin rates Ω (relative
    to the gimbal), the servo integrator z (each ``(B, 4)``), and the work ``W`` done by the
    gimbal motors, spin motors and stops ``(B, 1)``.

    Per step: ``ḣ_cmd = −u_cmd − ω × h`` with ``h`` the cluster momentum relative to the bus
    (:meth:`momentum`), ``δ̇_cmd = steering(A, ḣ_cmd)`` with ``A`` the columns
    ``I_Ws Ω_i t_i``, clipped to the rate limit and shaped by the stop guard; held over the step.
    Inside the stages the plant calls :meth:`coupled_derivatives`.

    Args:
        bus_inertia: ``J_B`` ``(3, 3)`` [kg·m²] — must equal the plant body's ``J`` (checked).
        inertias: :class:`CmgInertias` of each unit.
        cluster: an :class:`spacecraft.sgcmg.SgcmgPyramid` (geometry, ``h₀ = I_Ws Ω₀``, rate
            limit); default ``SgcmgPyramid()``.
        steering: steering law as for :class:`~spacecraft.actuators.SgcmgActuator`
            (default :class:`spacecraft.steering.SingularityRobust`).
        servo: :class:`GimbalServo` or :class:`~spacecraft.actuators.FirstOrderServo`.
        stops: :class:`GimbalStops` or ``None`` (free gimbals, slip rings). With stops the
            gimbal angles stay inside them at every step end (contact,
            :meth:`enforce_stops`).
        stop_aware: with ``stops``, wrap the steering law in
            :class:`spacecraft.steering.StopAware` (weights gimbals heading into a nearby stop
            down; default ``True``).
        delta0: initial gimbal angles ``(4,)`` [rad] (default the zero-momentum set).
        variable_speed: rotor spin torque as an input (``True``) or speed held (``False``).
    """

    n_states = 17

    def __init__(
        self,
        bus_inertia: object,
        inertias: CmgInertias,
        cluster: Any = None,
        steering: Any = None,
        servo: GimbalServo | FirstOrderServo | None = None,
        stops: GimbalStops | None = None,
        delta0: object = (np.pi / 4, -np.pi / 4, np.pi / 4, -np.pi / 4),
        variable_speed: bool = False,
        stop_aware: bool = True,
    ) -> None:
        from .sgcmg import SgcmgPyramid
        from .steering import SteeringLaw, _saturate_unchecked

        J = check_inertia_3x3(bus_inertia, "bus_inertia")
        J = np.array(J, dtype=np.float64)
        J.setflags(write=False)
        if not isinstance(inertias, CmgInertias):
            raise ValueError(f"inertias: expected CmgInertias, got {type(inertias).__name__}")
        if cluster is None:
            cluster = SgcmgPyramid()
        if not isinstance(cluster, SgcmgPyramid):
            raise ValueError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
        if steering is None:
            steering = _default_steering()
        if not callable(steering):
            raise ValueError("steering: must be callable as law(A, h_dot_cmd, ...)")
        if servo is None:
            servo = GimbalServo(bandwidth=20.0, max_torque=10.0)
        if not isinstance(servo, GimbalServo | FirstOrderServo):
            raise ValueError(
                f"servo: expected a GimbalServo or FirstOrderServo, got {type(servo).__name__}"
            )
        if stops is not None and not isinstance(stops, GimbalStops):
            raise ValueError(f"stops: expected GimbalStops or None, got {type(stops).__name__}")
        d0 = as_array(delta0, "delta0")
        if d0.shape != (4,):
            raise ValueError(f"delta0: expected shape (4,), got {d0.shape}")
        if stops is not None:
            stops.check_angles(d0, "delta0")
        d0 = d0.copy()
        d0.setflags(write=False)
        self.stop_aware = check_bool(stop_aware, "stop_aware")
        if stops is not None and self.stop_aware:
            from .steering import StopAware

            if not isinstance(steering, SteeringLaw):
                raise ValueError(
                    "steering: stop-aware steering needs a SteeringLaw (spacecraft.steering); "
                    "pass stop_aware=False for a plain callable"
                )
            # weight gimbals heading into a stop from the braking distance at the rate limit
            v = float(cluster.gimbal_rate_limit)
            span = float(np.min(stops.upper - stops.lower))
            zone = min(max(0.2, v * v / (2.0 * stops.braking_acceleration)), 0.25 * span)
            steering = StopAware(steering, stops.lower, stops.upper, zone=zone)
        self.bus_inertia = J
        self._checked_J: Any = J  # last plant inertia found equal (identity check thereafter)
        self.inertias = inertias
        self.cluster = cluster
        self.steering = steering
        self.servo = servo
        self.stops = stops
        self.delta0 = d0
        self.variable_speed = check_bool(variable_speed, "variable_speed")
        self.rate_limit = float(cluster.gimbal_rate_limit)
        self.spin_rate0 = float(cluster.h0) / inertias.wheel_spin  # Ω₀ = h₀ / I_Ws
        self._kinematic = isinstance(servo, FirstOrderServo)
        self._lag = servo.time_constant if self._kinematic else servo.lag
        self._G = np.array(cluster.gimbal_axes())  # (3, 4), fixed in the bus
        self._G.setflags(write=False)
        self._GGt = self._G @ self._G.T
        self._Jbg = J + inertias.J_g * self._GGt
        self._w8 = np.array([inertias.J_s] * 4 + [inertias.J_t] * 4)
        quarter = np.full(4, np.pi / 2)
        # s(δ) = S sin δ + C cos δ column-wise (a unit's spin axis turns about its gimbal axis)
        self._S = 0.5 * (cluster.unit_momenta(quarter) - cluster.unit_momenta(-quarter))
        self._C = cluster.unit_momenta(np.zeros(4))
        self._saturate = _saturate_unchecked
        # constant arguments of the compiled kernel (spacecraft._kernels_vscmg)
        if self._kinematic:
            kp = ki = umax = 0.0
        else:
            kp = 2.0 * servo.damping * servo.bandwidth * inertias.J_g
            ki = servo.bandwidth**2 * inertias.J_g
            umax = servo.max_torque
        par = np.zeros(N_PAR)
        I = inertias
        par[:8] = (I.J_s, I.J_t, I.J_g, I.wheel_spin, kp, ki, umax, self._lag)
        # the bumper acts inside the stages only with contact="bumper"; hard stops are enforced
        # after each step (enforce_stops)
        self._bumper = stops is not None and stops.contact == "bumper"
        if stops is not None:
            par[8:10] = (stops.stiffness, stops.damping)
            par[10:14] = stops.lower
            par[14:18] = stops.upper
        geometry = np.concatenate([J, self._S, self._C, self._G], axis=1)  # [J_B | S | C | G]
        self._kargs = (self._kinematic, self.variable_speed, self._bumper, par, geometry)
        self._held_cache: tuple = (None, None)
        self._steer = steering.steer if isinstance(steering, SteeringLaw) else None
        try:
            params = inspect.signature(steering).parameters
        except (TypeError, ValueError):
            params = {}
        takes_kwargs = any(p.kind is p.VAR_KEYWORD for p in params.values())
        self._steer_kw = tuple(k for k in ("delta", "t", "cluster") if takes_kwargs or k in params)

    def __repr__(self) -> str:
        return (
            f"VscmgActuator(inertias={self.inertias!r}, cluster={self.cluster!r}, "
            f"servo={self.servo!r}, stops={self.stops!r}, variable_speed={self.variable_speed})"
        )

    # -- geometry ------------------------------------------------------------------------------

    def _axes(self, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Spin and transverse axes ``s, t`` ``(B, 3, 4)`` (columns per unit)."""
        sn, cs = np.sin(delta)[:, None, :], np.cos(delta)[:, None, :]
        s = self._S * sn + self._C * cs
        t = self._S * cs - self._C * sn  # ∂s/∂δ = g × s
        return s, t

    @staticmethod
    def _split(x_act: np.ndarray) -> tuple[np.ndarray, ...]:
        return x_act[:, 0:4], x_act[:, 4:8], x_act[:, 8:12], x_act[:, 12:16]

    def initial_state(self, batch: int) -> np.ndarray:
        """``(batch, 17)``: δ₀, zero gimbal rates, Ω₀ = h₀/I_Ws, zero integrator and work."""
        x = np.zeros((int(batch), self.n_states))
        x[:, 0:4] = self.delta0
        x[:, 8:12] = self.spin_rate0
        return x

    def momentum(self, x_act: np.ndarray) -> np.ndarray:
        """Cluster momentum relative to the bus ``Σ (J_g δ̇ g + I_Ws Ω s)`` ``(B, 3)`` [N·m·s]
        (the total is ``J_tot(δ) ω`` plus this)."""
        delta, rate, spin, _ = self._split(x_act)
        s, _t = self._axes(delta)
        h = (self.inertias.J_g * rate) @ self._G.T
        return h + (s @ (self.inertias.wheel_spin * spin)[..., None])[..., 0]

    def total_momentum(self, omega: np.ndarray, x_act: np.ndarray) -> np.ndarray:
        """Total angular momentum of bus + cluster in body axes ``H`` ``(B, 3)`` [N·m·s]."""
        delta, rate, spin, _ = self._split(x_act)
        s, t = self._axes(delta)
        return np.einsum("bij,bj->bi", self._total_inertia(s, t), omega) + self.momentum(x_act)

    def kinetic_energy(self, omega: np.ndarray, x_act: np.ndarray) -> np.ndarray:
        """Kinetic energy of bus + cluster ``T`` ``(B,)`` [J] (module doc)."""
        delta, rate, spin, _ = self._split(x_act)
        s, t = self._axes(delta)
        I = self.inertias
        Jt = self._total_inertia(s, t)
        w_s = np.einsum("bij,bi->bj", s, omega)
        w_g = omega @ self._G
        T = 0.5 * np.einsum("bi,bij,bj->b", omega, Jt, omega)
        T += (I.J_g * w_g * rate + 0.5 * I.J_g * rate**2).sum(-1)
        T += (I.wheel_spin * w_s * spin + 0.5 * I.wheel_spin * spin**2).sum(-1)
        return T

    def _total_inertia(self, s: np.ndarray, t: np.ndarray) -> np.ndarray:
        I = self.inertias
        return (
            self.bus_inertia
            + I.J_s * (s @ s.transpose(0, 2, 1))
            + I.J_t * (t @ t.transpose(0, 2, 1))
            + I.J_g * self._GGt
        )

    # -- gimbal stops: contact ------------------------------------------------------------------

    @property
    def post_step(self) -> Callable[[np.ndarray], np.ndarray] | None:
        """The hook :class:`spacecraft.plant.Spacecraft` applies to the packed state ``(ω,
        x_act)`` after every integration step: :meth:`enforce_stops` with stops, else ``None``."""
        st = self.stops
        return self.enforce_stops if st is not None and st.contact == "hard" else None

    def enforce_stops(self, x: np.ndarray) -> np.ndarray:
        """Gimbal-stop contact as a hard constraint on the packed state ``x`` ``(B, 3 + 17)``
        = ``(ω, x_act)`` at the end of a step; returns ``x`` (a modified copy where a gimbal
        touched a stop).

        A gimbal found beyond a stop is put back on it, and a gimbal on a stop moving outward is
        stopped (a perfectly plastic impact): ``δ̇ᵢ = 0``. The impulse is internal, so the total
        angular momentum ``H`` (:meth:`total_momentum`) is kept exactly and the reaction goes
        into the bus: the bus rate change ``Δω`` solves
        ``[J_tot(δ) − Σ_free J_g g gᵀ (− Σ I_Ws s sᵀ with variable_speed)] Δω = H − H(δ, ω,
        δ̇ with the stopped gimbals at rest)``: the free gimbals' motors (torque-limited, no
        impulse) keep each free gimbal's inertial rate ``gᵀω + δ̇`` (with the kinematic
        :class:`~spacecraft.actuators.FirstOrderServo` they keep ``δ̇``), the spin motors keep
        ``Ω`` (a variable-speed rotor keeps ``sᵀω + Ω``). The kinetic energy the impact
        dissipates is booked as (negative) work of the stops in the work state ``W``, so the
        energy balance ``T − W = const`` still holds. Logged as ``stop_contact`` (a gimbal on a
        stop), counted by :mod:`benchmarks.metrics` as ``stop_contact_time_s``.

        Inside a step, the stiff bumper of :class:`GimbalStops` acts on any penetration (the
        RK stages see a smooth force); the projection makes ``lower ≤ δ ≤ upper`` hold exactly at
        every step end, hence at every logged sample.
        """
        st = self.stops
        if st is None or st.contact != "hard":
            return x
        d = x[:, 3:7]
        r = x[:, 7:11]
        hi, lo = st.upper, st.lower
        hit_hi = (d > hi) | ((d >= hi) & (r > 0.0))
        hit_lo = (d < lo) | ((d <= lo) & (r < 0.0))
        hit = hit_hi | hit_lo
        rows = np.flatnonzero(hit.any(axis=-1))
        if rows.size == 0:
            return x
        x = np.array(x, dtype=np.float64, copy=True)
        w = x[rows, :3]
        xa = x[rows, 3:]
        H = self.total_momentum(w, xa)
        T0 = self.kinetic_energy(w, xa)
        xa2 = xa.copy()
        xa2[:, 0:4] = np.clip(xa[:, 0:4], lo, hi)
        rate = xa2[:, 4:8]
        stopped = (hit_hi[rows] & (rate > 0.0)) | (hit_lo[rows] & (rate < 0.0))
        rate[stopped] = 0.0
        s, t = self._axes(xa2[:, 0:4])
        M = self._total_inertia(s, t)
        I = self.inertias
        if not self._kinematic:
            free = (~stopped).astype(np.float64)
            M = M - I.J_g * np.einsum("ik,bk,jk->bij", self._G, free, self._G)
        if self.variable_speed:
            M = M - I.wheel_spin * (s @ s.transpose(0, 2, 1))
        dH = H - self.total_momentum(w, xa2)
        dw = np.linalg.solve(M, dH[..., None])[..., 0]
        if not self._kinematic:
            rate -= np.where(stopped, 0.0, dw @ self._G)
        if self.variable_speed:
            xa2[:, 8:12] -= np.einsum("bij,bi->bj", s, dw)
        w2 = w + dw
        xa2[:, 16] += self.kinetic_energy(w2, xa2) - T0
        x[rows, :3] = w2
        x[rows, 3:] = xa2
        return x

    # -- command -------------------------------------------------------------------------------

    def command(self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float) -> Any:
        """Validated :meth:`command_unchecked` (see :meth:`Actuator.command`)."""
        _, _, x, _ = self._check_command(u_cmd, omega, x_act, t)
        with np.errstate(over="ignore", invalid="ignore"):
            h = self.momentum(x)
        # no physical gimbal angle, rate or rotor speed comes near 1e100; beyond that the
        # steering algebra (squares of the Jacobian) overflows and the fault is x_act's
        if not np.all(np.isfinite(h)) or np.abs(x).max() > 1e100:
            raise ValueError(
                "x_act: the cluster momentum of these gimbal rates and rotor speeds overflows "
                f"float64 (max |x_act| = {float(np.abs(x).max()):.3g})"
            )
        return self._validated_command(u_cmd, omega, x_act, t)

    def command_unchecked(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float
    ) -> VscmgCommand:
        """:meth:`command` without validation (the simulator's per-step call)."""
        delta, rate, spin, _ = self._split(x_act)
        feedforward = not self._kinematic and self.servo.gyro_feedforward
        if JIT_ENABLED or x_act.shape[0] == 1:
            A, h_dot_cmd, ff = self._command_inputs_kernel(u_cmd, omega, x_act, feedforward)
        else:
            A, h_dot_cmd, ff = self._command_inputs(u_cmd, omega, x_act, feedforward)
        if self._steer is not None:
            dd = self._steer(A, h_dot_cmd, delta, float(t), self.cluster)
        else:
            kw = {"delta": delta, "t": t, "cluster": self.cluster}
            dd = np.asarray(
                self.steering(A, h_dot_cmd, **{k: kw[k] for k in self._steer_kw}),
                dtype=np.float64,
            )
        dd, saturated = self._saturate(np.asarray(dd, dtype=np.float64), self.rate_limit)
        if self.stops is not None:
            dd, limited = self.stops.guard(dd, delta, rate, self._lag)
        else:
            limited = np.zeros(dd.shape, dtype=bool)
        return VscmgCommand(
            delta_dot_cmd=dd,
            omega=np.array(omega, dtype=np.float64),
            saturated=saturated,
            stop_limited=limited,
            h_dot_cmd=h_dot_cmd,
            gimbal_torque_ff=ff,
            spin_torque=np.zeros(dd.shape),
        )

    def _command_inputs(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, feedforward: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Steering Jacobian ``A`` ``(B, 3, 4)`` (columns ``I_Ws Ω t``), ``ḣ_cmd = −u_cmd −
        ω × h`` ``(B, 3)`` and gimbal torque feed-forward ``(B, 4)`` (zeros without
        ``feedforward``): the numpy reference of :meth:`_command_inputs_kernel`."""
        delta, _rate, spin, _ = self._split(x_act)
        _s, tr = self._axes(delta)
        A = tr * (self.inertias.wheel_spin * spin)[:, None, :]
        h_dot_cmd = _cross(omega, self.momentum(x_act))
        h_dot_cmd += u_cmd
        np.negative(h_dot_cmd, out=h_dot_cmd)
        ff = -self._gyro_torque(omega, delta, spin) if feedforward else np.zeros(delta.shape)
        return A, h_dot_cmd, ff

    def _command_inputs_kernel(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, feedforward: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Steering Jacobian ``A`` ``(B, 3, 4)``, ``ḣ_cmd`` ``(B, 3)`` and gimbal torque
        feed-forward ``(B, 4)`` through the compiled kernel
        (:func:`spacecraft._kernels_vscmg.vscmg_command_inputs_one`)."""
        _, _, _, par, M = self._kargs
        B = x_act.shape[0]
        A = np.empty((B, 3, 4))
        hdot = np.empty((B, 3))
        ff = np.empty((B, 4))
        if B == 1:
            vscmg_command_inputs_one(
                feedforward, par, M, omega[0], x_act[0], u_cmd[0], A[0], hdot[0], ff[0]
            )
        else:
            vscmg_command_inputs_batch(feedforward, par, M, omega, x_act, u_cmd, A, hdot, ff)
        return A, hdot, ff

    def open_loop(
        self, gimbal_torque: object, spin_torque: object | None = None, omega: object | None = None
    ) -> VscmgCommand:
        """A held command applying prescribed motor torques ``(B, 4)`` [N·m] (no rate loop;
        with a :class:`GimbalServo` only; the gimbal torque is clipped to its limit and the spin
        torque acts only with ``variable_speed``)."""
        if self._kinematic:
            raise ValueError(
                "gimbal_torque: open-loop torques need a GimbalServo (the FirstOrderServo "
                "prescribes the gimbal acceleration)"
            )
        ug = as_array(gimbal_torque, "gimbal_torque")
        if ug.ndim != 2 or ug.shape[1] != 4:
            raise ValueError(f"gimbal_torque: expected shape (B, 4), got {ug.shape}")
        us = np.zeros(ug.shape) if spin_torque is None else as_array(spin_torque, "spin_torque")
        if us.shape != ug.shape:
            raise ValueError(f"spin_torque: expected shape {ug.shape}, got {us.shape}")
        w = np.zeros((ug.shape[0], 3)) if omega is None else as_array(omega, "omega")
        if w.shape != (ug.shape[0], 3):
            raise ValueError(f"omega: expected shape {(ug.shape[0], 3)}, got {w.shape}")
        z = np.zeros(ug.shape)
        B = ug.shape[0]
        return VscmgCommand(
            delta_dot_cmd=z,
            omega=w.copy(),
            saturated=np.zeros(B, dtype=bool),
            stop_limited=np.zeros(ug.shape, dtype=bool),
            h_dot_cmd=np.zeros((B, 3)),
            gimbal_torque_ff=ug.copy(),
            spin_torque=us.copy(),
            open_loop=True,
        )

    # -- dynamics ------------------------------------------------------------------------------

    def _gyro_torque(self, omega: np.ndarray, delta: np.ndarray, spin: np.ndarray) -> np.ndarray:
        """``(J_s − J_t) ω_s ω_t + I_Ws Ω ω_t`` ``(B, 4)``: the gimbal-axis torque of base rate
        and rotor momentum (right-hand side of the gimbal equation)."""
        s, t = self._axes(delta)
        I = self.inertias
        w_s = np.einsum("bij,bi->bj", s, omega)
        w_t = np.einsum("bij,bi->bj", t, omega)
        return (I.J_s - I.J_t) * w_s * w_t + I.wheel_spin * spin * w_t

    def _motor_torque(
        self, delta: np.ndarray, rate: np.ndarray, z: np.ndarray, held: VscmgCommand
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Servo motor torque, saturation flags, integrator derivative, stop torque
        (:class:`GimbalServo` only)."""
        sv = self.servo
        umax = sv.max_torque
        if held.open_loop:
            raw = held.gimbal_torque_ff
            e = np.zeros(rate.shape)
        else:
            Jg = self.inertias.J_g
            e = held.delta_dot_cmd - rate
            raw = (2.0 * sv.damping * sv.bandwidth * Jg) * e + (sv.bandwidth**2 * Jg) * z
            raw = raw + held.gimbal_torque_ff
        u = np.clip(raw, -umax, umax)
        sat = np.abs(raw) > umax
        # conditional integration: freeze z while saturated and the error pushes further
        z_dot = np.where(sat & (e * raw > 0.0), 0.0, e)
        u_stop = np.zeros(rate.shape)
        st = self.stops
        if st is not None and self._bumper:
            over = delta - st.upper
            under = st.lower - delta
            push_up = np.maximum(st.stiffness * over + st.damping * rate, 0.0)
            push_lo = np.maximum(st.stiffness * under - st.damping * rate, 0.0)
            u_stop = np.where(over > 0.0, -push_up, 0.0) + np.where(under > 0.0, push_lo, 0.0)
        return u, sat, z_dot, u_stop

    def _solve(
        self, omega: np.ndarray, x_act: np.ndarray, held: VscmgCommand, tau_ext: np.ndarray
    ) -> dict[str, np.ndarray]:
        """The coupled accelerations and the motor torques (module doc), all ``(B, ...)``."""
        delta, rate, spin, z = self._split(x_act)
        I = self.inertias
        Js, Jt, Jg, Iw = I.J_s, I.J_t, I.J_g, I.wheel_spin
        G = self._G
        s, t = self._axes(delta)
        st = np.concatenate([s, t], axis=-1)  # (B, 3, 8): one product gives ω_s and ω_t
        wst = (omega[:, None, :] @ st)[:, 0, :]
        w_s, w_t = wst[:, :4], wst[:, 4:]
        Jtot = (st * self._w8) @ st.transpose(0, 2, 1)
        Jtot += self._Jbg  # J_B + J_g Σ g gᵀ
        # bus right-hand side: L − ω × H − Σ δ̇ [(J_s − J_t)(ω_t s + ω_s t) + I_Ws Ω t], with
        # H = J_tot ω + Σ (J_g δ̇ g + I_Ws Ω s)
        zero = np.zeros(spin.shape)
        H = (Jtot @ omega[..., None])[..., 0]
        H += (Jg * rate) @ G.T
        H += (st @ np.concatenate([Iw * spin, zero], axis=-1)[..., None])[..., 0]
        c8 = np.concatenate([(Js - Jt) * rate * w_t, rate * ((Js - Jt) * w_s + Iw * spin)], -1)
        f_w = tau_ext - _cross(omega, H)
        f_w -= (st @ c8[..., None])[..., 0]
        f_d = (Js - Jt) * w_s * w_t + Iw * spin * w_t  # gimbal: J_g(gᵀω̇ + δ̈) = u_g + f_d
        f_O = -Iw * rate * w_t  # rotor: I_Ws(sᵀω̇ + Ω̇) = u_s + f_O
        Meff = Jtot.copy()
        rhs = f_w
        out: dict[str, np.ndarray] = {}
        if self._kinematic:
            dd_ddot = (held.delta_dot_cmd - rate) / self._lag
            rhs = rhs - (Jg * dd_ddot) @ G.T
            z_dot = np.zeros(rate.shape)
            u_stop = np.zeros(rate.shape)
            sat = np.zeros(rate.shape, dtype=bool)
        else:
            u_g, sat, z_dot, u_stop = self._motor_torque(delta, rate, z, held)
            Meff -= Jg * self._GGt
            rhs = rhs - (u_g + u_stop + f_d) @ G.T
        if self.variable_speed:
            u_s = held.spin_torque
            Meff -= Iw * (s @ s.transpose(0, 2, 1))
            rhs = rhs - (s @ (u_s + f_O)[..., None])[..., 0]
        w_dot = np.linalg.solve(Meff, rhs[..., None])[..., 0]
        gw = w_dot @ G
        sw = (w_dot[:, None, :] @ s)[:, 0, :]
        if self._kinematic:
            u_g = Jg * (gw + dd_ddot) - f_d
        else:
            dd_ddot = (u_g + u_stop + f_d) / Jg - gw
        if self.variable_speed:
            spin_dot = (u_s + f_O) / Iw - sw
        else:
            spin_dot = np.zeros(spin.shape)
            u_s = Iw * sw - f_O
        out.update(
            omega_dot=w_dot,
            delta_ddot=dd_ddot,
            spin_dot=spin_dot,
            z_dot=z_dot,
            gimbal_torque=u_g,
            stop_torque=u_stop,
            spin_torque=u_s,
            torque_saturated=sat,
            power=((u_g + u_stop) * rate + u_s * spin).sum(-1),
            gimbal_power=u_g * rate,
        )
        return out

    def check_plant(self, body: Any) -> None:
        """Raise ``ValueError`` naming ``bus_inertia`` unless the plant body's ``J`` is this
        actuator's ``bus_inertia``: the coupled equations of motion take the bus inertia
        ``J_B`` as the body's. :class:`spacecraft.plant.Spacecraft` calls this hook when it is
        built, so a mismatch fails there and not at the first integration step."""
        J = np.asarray(getattr(body, "J", None))
        if J.shape != (3, 3) or not np.array_equal(J, self.bus_inertia):
            raise ValueError(
                "bus_inertia: differs from the plant body's J "
                f"(bus_inertia diagonal {np.diag(self.bus_inertia).tolist()}, body.J of shape "
                f"{J.shape}); build the actuator with bus_inertia=body.J (the inertia without "
                "the gimbal frames and rotors; one shared (3, 3) inertia)"
            )
        self._checked_J = body.J

    def coupled_derivatives(
        self,
        omega: np.ndarray,
        x_act: np.ndarray,
        held: VscmgCommand,
        tau_ext: np.ndarray,
        body_inertia: np.ndarray,
    ) -> np.ndarray:
        """``(ω̇, ẋ_act)`` ``(B, 3 + 17)`` of the coupled bus + cluster dynamics under the
        external torque ``tau_ext`` ``(B, 3)`` (disturbance, magnetic dumping, …): the hook
        :class:`spacecraft.plant.Spacecraft` calls instead of ``body_torque`` +
        ``state_derivative``. ``body_inertia`` is the plant's ``body.J`` (must be
        ``bus_inertia``)."""
        if body_inertia is not self._checked_J:
            if not np.array_equal(body_inertia, self.bus_inertia):
                raise ValueError(
                    "bus_inertia: differs from the plant body's J; build the actuator with "
                    "bus_inertia=body.J (the inertia without the gimbal frames and rotors)"
                )
            self._checked_J = body_inertia
        if JIT_ENABLED or omega.shape[0] == 1:
            return self._kernel(omega, x_act, held, tau_ext)[0]
        r = self._solve(omega, x_act, held, tau_ext)
        out = np.empty((omega.shape[0], 3 + self.n_states))
        out[:, 0:3] = r["omega_dot"]
        out[:, 3:7] = x_act[:, 4:8]
        out[:, 7:11] = r["delta_ddot"]
        out[:, 11:15] = r["spin_dot"]
        out[:, 15:19] = r["z_dot"]
        out[:, 19] = r["power"]
        return out

    def _kernel(
        self, omega: np.ndarray, x_act: np.ndarray, held: VscmgCommand, tau_ext: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The coupled derivatives ``(B, 20)`` and the per-gimbal details ``(B, 5, 4)`` (motor
        torque, spin torque, saturation flag, gimbal power, stop torque) through the compiled
        kernel :func:`spacecraft._kernels_vscmg.vscmg_derivatives_one` (the same equations as
        :meth:`_solve`, its numpy reference; tested equal to it)."""
        kin, var, has_stops, par, M = self._kargs
        B = omega.shape[0]
        out = np.empty((B, 3 + self.n_states))
        det = np.empty((B, 5, 4))
        ol = bool(held.open_loop)
        hp = self._held_packed(held)
        if B == 1:
            vscmg_derivatives_one(
                kin, var, ol, has_stops, par, M, omega[0], x_act[0], hp[0], tau_ext[0], out[0],
                det[0],
            )  # fmt: skip
        else:
            vscmg_derivatives_batch(
                kin, var, ol, has_stops, par, M, omega, x_act, hp, tau_ext, out, det
            )
        return out, det

    def _held_packed(self, held: VscmgCommand) -> np.ndarray:
        """The held command as the kernels take it, ``(B, 3, 4)`` = (rate command, gimbal
        feed-forward torque, spin torque); cached for the four RK stages of a step."""
        h, packed = self._held_cache
        if h is not held:
            packed = np.stack([held.delta_dot_cmd, held.gimbal_torque_ff, held.spin_torque], 1)
            self._held_cache = (held, packed)
        return packed

    def _rkmk4_kernel(self, plant: Any) -> Callable[..., tuple[np.ndarray, np.ndarray]] | None:
        """The compiled RKMK4 step of ``plant`` (a :class:`spacecraft.plant.Spacecraft` flying
        this actuator) as ``step(t, R, x, held, h) -> (R, x)`` on packed states — the step of
        :meth:`~spacecraft.plant.Spacecraft.step_packed`'s numpy route through
        :func:`spacecraft._kernels_vscmg.vscmg_rkmk4_step_batch`, the step of the fused loop —
        or ``None`` when a part has no kernel (structural modes, momentum management, a
        disturbance with neither a time-only code of :mod:`spacecraft._kernels` nor a torque of
        the seam :mod:`spacecraft.disturbance_kernel`, a body inertia that is not
        ``bus_inertia``). A malformed seam kernel raises ``ValueError`` naming the disturbance
        (as for the momentum model's plan)."""
        if plant.actuator is not self or plant.modes is not None:
            return None
        if plant.momentum_management is not None:
            return None
        J = np.asarray(plant.body.J)
        if J.shape != (3, 3) or not np.array_equal(J, self.bus_inertia):
            return None
        from ._entry import fn_entry, torque_signature
        from .disturbances import disturbance_plan, kernel_rows

        dk, _ = disturbance_plan(plant.disturbance, plant.body.batch_size)
        if dk is None:
            return None
        dist, dp, dfn, dpk, datt = dk
        disturbance = plant.disturbance
        kin, var, has_stops, par, M = self._kargs

        def step(
            t: float, R: np.ndarray, x: np.ndarray, held: VscmgCommand, h: float
        ) -> tuple[np.ndarray, np.ndarray]:
            R = np.ascontiguousarray(R)  # the seam torque takes C-contiguous attitudes
            x = np.ascontiguousarray(x)
            R_out = np.empty(R.shape)
            x_out = np.empty(x.shape)
            args = (
                kin, var, bool(held.open_loop), has_stops, par, M, dist, dp, dfn,
                kernel_rows(disturbance, dpk, x.shape[0]), datt, float(t), R, x,
                self._held_packed(held), float(h), R_out, x_out,
            )  # fmt: skip
            entry = (
                fn_entry(vscmg_rkmk4_step_batch, args, {8: torque_signature()})
                if JIT_ENABLED
                else None
            )
            (entry or vscmg_rkmk4_step_batch)(*args)  # without numba: the kernel as Python
            return R_out, x_out

        return step

    def state_derivative(self, x_act: np.ndarray, held: Any) -> np.ndarray:
        """Not defined without the body rate: the gimbal and rotor accelerations are coupled to
        the bus acceleration. The plant calls :meth:`coupled_derivatives` instead."""
        raise TypeError(
            "x_act: the full CMG model's state derivative needs the body rate and external "
            "torque; call coupled_derivatives(omega, x_act, held, tau_ext, body_inertia)"
        )

    def body_torque(self, omega: np.ndarray, x_act: np.ndarray, held: Any) -> np.ndarray:
        """Torque the cluster exerts on the bus, ``J_B ω̇ + ω × J_B ω`` with ``ω̇`` the coupled
        acceleration under no external torque ``(B, 3)`` [N·m] (logged as ``u``)."""
        zero = np.zeros(omega.shape)
        if JIT_ENABLED or omega.shape[0] == 1:
            w_dot = self._kernel(omega, x_act, held, zero)[0][:, :3]
        else:
            w_dot = self._solve(omega, x_act, held, zero)["omega_dot"]
        J = self.bus_inertia
        return w_dot @ J.T + _cross(omega, omega @ J.T)

    def log(self, x_act: np.ndarray, held: VscmgCommand) -> dict[str, np.ndarray]:
        """Gimbal angles/rates/commands, rotor speeds, motor torques and power, work, and the
        flags ``saturated`` (rate limit), ``torque_saturated``, ``stop_contact``, ``stop_limited``
        (torques evaluated at the command sample's body rate with no external torque)."""
        delta, rate, spin, _ = self._split(x_act)
        zero = np.zeros(held.omega.shape)
        if JIT_ENABLED or x_act.shape[0] == 1:
            det = self._kernel(held.omega, x_act, held, zero)[1]
            r = {
                "gimbal_torque": det[:, DET_GIMBAL_TORQUE],
                "spin_torque": det[:, DET_SPIN_TORQUE],
                "gimbal_power": det[:, DET_GIMBAL_POWER],
                "torque_saturated": det[:, DET_SATURATED] > 0.5,
            }
        else:
            r = self._solve(held.omega, x_act, held, zero)
        if self.stops is not None:
            contact = (delta >= self.stops.upper) | (delta <= self.stops.lower)
        else:
            contact = np.zeros(delta.shape, dtype=bool)
        return {
            "delta": delta.copy(),
            "delta_dot": rate.copy(),
            "delta_dot_cmd": held.delta_dot_cmd,
            "wheel_speed": spin.copy(),
            "gimbal_torque": r["gimbal_torque"],
            "spin_torque": r["spin_torque"],
            "gimbal_power": r["gimbal_power"],
            "actuator_work": x_act[:, 16].copy(),
            "saturated": held.saturated,
            "torque_saturated": r["torque_saturated"],
            "stop_contact": contact,
            "stop_limited": held.stop_limited,
        }

    def derived_log(self, log: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Singularity measure ``(K, B)`` of the logged gimbal angles."""
        if "delta" not in log:
            return {}
        return {"singularity": self.cluster.singularity_measure(log["delta"])}


@dataclass(frozen=True)
class MiniCmgPreset:
    """Parameters of a small-satellite mini-CMG pyramid (see :data:`MINI_CMG`).

    ``make(bus_inertia, **kwargs)`` builds the :class:`VscmgActuator`."""

    h0: float
    wheel_spin: float
    wheel_transverse: float
    gimbal: tuple[float, float, float]
    gimbal_rate_limit: float
    gimbal_torque_limit: float
    beta: float
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        from .sgcmg import SgcmgPyramid

        # validated through the objects they build (messages name the field)
        inert = CmgInertias(self.wheel_spin, self.wheel_transverse, self.gimbal)
        cl = SgcmgPyramid(h0=self.h0, beta=self.beta, gimbal_rate_limit=self.gimbal_rate_limit)
        object.__setattr__(self, "wheel_spin", inert.wheel_spin)
        object.__setattr__(self, "wheel_transverse", inert.wheel_transverse)
        object.__setattr__(self, "gimbal", inert.gimbal)
        for name in ("h0", "beta", "gimbal_rate_limit"):
            object.__setattr__(self, name, float(getattr(cl, name)))
        object.__setattr__(
            self, "gimbal_torque_limit", _pos(self.gimbal_torque_limit, "gimbal_torque_limit")
        )
        if not isinstance(self.source, str):
            raise ValueError(f"source: expected a string, got {type(self.source).__name__}")

    def inertias(self) -> CmgInertias:
        return CmgInertias(self.wheel_spin, self.wheel_transverse, self.gimbal)

    def make(self, bus_inertia: object, **kwargs: Any) -> VscmgActuator:
        """The preset's actuator (keyword arguments as :class:`VscmgActuator`'s; default servo
        a :class:`GimbalServo` at 30 rad/s and the preset's torque limit)."""
        from .sgcmg import SgcmgPyramid

        cluster = SgcmgPyramid(h0=self.h0, beta=self.beta, gimbal_rate_limit=self.gimbal_rate_limit)
        kwargs.setdefault("servo", GimbalServo(bandwidth=30.0, max_torque=self.gimbal_torque_limit))
        return VscmgActuator(bus_inertia, self.inertias(), cluster=cluster, **kwargs)


def _disc_rotor(radius: float, thickness: float, density: float, rpm: float) -> tuple:
    """Spin and transverse inertia of a solid disc rotor [kg·m²] and its momentum [N·m·s] at
    ``rpm``: m = ρ π r² b, I_s = ½ m r², I_t = m (3 r² + b²)/12, h = I_s Ω."""
    m = density * math.pi * radius**2 * thickness
    i_s = 0.5 * m * radius**2
    i_t = m * (3.0 * radius**2 + thickness**2) / 12.0
    return i_s, i_t, i_s * rpm * _TWO_PI / 60.0


_I_S, _I_T, _H0 = _disc_rotor(radius=0.02, thickness=0.008, density=7850.0, rpm=10_000.0)

#: Small-satellite mini-CMG pyramid (microsatellite class, units of ~1U size): a solid steel
#: disc rotor of radius 20 mm and thickness 8 mm at 10 000 rpm (I_Ws ≈ 1.6e-5 kg·m²,
#: I_Wt ≈ 8.3e-6 kg·m², h₀ ≈ 0.0165 N·m·s), a gimbal frame of (1.0, 1.0, 1.2)e-5 kg·m², gimbal
#: rate limit 2 rad/s, gimbal motor torque 5 mN·m, skew angle 54.73°. The numbers are computed
#: here from the stated rotor geometry (not copied from a datasheet); the device class — a
#: pyramid of four mini-CMGs inside 1U — is the one studied by N. Baker, *Feasibility and design
#: of miniaturized Control Moment Gyroscope for a 3-axis stabilized Micro Satellite*, MSc
#: thesis, Luleå University of Technology, 2016.
MINI_CMG = MiniCmgPreset(
    h0=_H0,
    wheel_spin=_I_S,
    wheel_transverse=_I_T,
    gimbal=(1.0e-5, 1.0e-5, 1.2e-5),
    gimbal_rate_limit=2.0,
    gimbal_torque_limit=5.0e-3,
    beta=float(np.deg2rad(54.73)),
    source=(
        "computed from a steel disc rotor r = 20 mm, b = 8 mm at 10 000 rpm and a gimbal frame "
        "of (1, 1, 1.2)e-5 kg m^2; device class (four mini-CMGs in 1U) as in N. Baker, MSc "
        "thesis, Lulea University of Technology, 2016"
    ),
)
