"""6-DOF rigid-body plant on SE(3), chaser/target proximity operations, pose simulator.

Plant (Jiang, Meng & Yang 2023 eqs. 1–6), pose g = [[R, p], [0, 1]] (R body → inertial, p inertial
position),
body twist ξ = (ω, v) (rotation first)::

    ġ = g ξ^                         (Ṙ = R ω^, ṗ = R v)
    J ω̇ = −ω × Jω + τ + τ_g + d_ω
    m v̇ = −ω × m v + F + F_g + d_v,

(τ, F) the applied body wrench (after the actuator), (d_ω, d_v) a body disturbance wrench and
(τ_g, F_g) gravity in body axes. Gravity is the MacCullagh (second-order) full-body field of a
point-mass central body, optionally with the J2 zonal term on the orbit (Earth's pole = inertial
Z; :mod:`spacecraft.orbit`). With r = |p|, ĉ = Rᵀp/r (body axes), J_I = R J Rᵀ::

    U(p, R) = m U₀(p) + m U₂(p) − μ tr J/(2r³) + 3μ ĉᵀJĉ/(2r³)            (potential energy)
    f_g = m (a₀ + a₂)(p) − (3/2) μ tr J p/r⁵ − 3μ J_I p/r⁵ + (15/2) μ (pᵀJ_I p) p/r⁷   (= −∂U/∂p)
    τ_g = 3μ/r³ ĉ × Jĉ                                     (gravity-gradient torque)
    F_g = Rᵀ f_g                                           (gravity in body axes)

(``gravity_gradient=False`` keeps only the point-mass/J2 force m (a₀ + a₂) and no torque).
The torque and the inertia-dependent force come from one potential, so the field is invariant
under rotations about the centre (for J2 = 0) and the total angular momentum p × m ṗ + R Jω is a
constant of the free motion — what the SE(3) LGVI conserves to round-off. Source: Lee, Leok &
McClamroch (2007), §2 (full body potential truncated at second order); Schaub & Junkins,
*Analytical Mechanics of Space Systems*, §4.4 (gravity gradient).

Integrators (``method=``): ``"lgvi"`` — :class:`liecontrol.integrators.lgvi_se3.SE3RigidBodyLGVI`
with the held wrench rotated to inertial axes (f = R F + R d_v + f_g, M = τ + d_ω + τ_g; the
disturbance is evaluated at the start of the step and held); ``"rkmk4"`` — RKMK4 on SE(3) × ℝ⁶
(:mod:`liecontrol.integrators.rkmk_se3`) with x = ξ.

Chaser/target pair: the target flies the circular orbit of :class:`spacecraft.orbit.CircularOrbit`
(point-mass field, radius from n) with its body frame = LVLH: g_T(t) = (C(t), r_T(t)), body twist
ξ_T = ((0, −n, 0), (r n, 0, 0)) (constant). A docking pose g_rel relative to the target body frame
gives the reference g_d(t) = g_T(t) g_rel, ξ_d = Ad_{g_rel⁻¹} ξ_T (constant), ξ̇_d = 0
(:class:`DockingReference`). The analytic target orbit is exact only for the point-mass field:
with J2 or gravity-gradient forces on the chaser, the reference is not a free trajectory and the
controller absorbs the difference.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from liecontrol._linalg import cross as _cross
from liecontrol._linalg import matvec as _mv
from liecontrol._validation import (
    as_array,
    as_int,
    as_scalar,
    check_inertia_3x3,
    check_positive,
    check_positive_scalar,
)
from liecontrol.control.se3_control import (
    PoseController,
    PoseReference,
    PoseState,
    coriolis_wrench_unchecked,
)
from liecontrol.integrators.lgvi import LGVIConvergenceError
from liecontrol.integrators.lgvi_se3 import SE3RigidBodyLGVI
from liecontrol.integrators.rkmk_se3 import rkmk4_se3_step_unchecked
from liecontrol.lie import se3, so3

from .orbit import MU_EARTH, R_EARTH, CircularOrbit, gravity_potential, j2_acceleration

# the attitude simulator's exception (callers catch one type for both loops) and horizon rule
from .simulator import SimulationDiverged, _horizon_steps

__all__ = [
    "SE3Plant",
    "IdealWrenchActuator",
    "OrbitingTarget",
    "DockingReference",
    "PoseSimulationResult",
    "simulate_pose",
    "full_body_gravity",
    "full_body_potential",
    "SimulationDiverged",
]

_METHODS = ("lgvi", "rkmk4")
#: relative tolerance on control_period / dt being an integer (as spacecraft.simulator)
_PERIOD_RTOL = 1e-9

Disturbance = Callable[[float, np.ndarray, np.ndarray], np.ndarray]


def _mtv(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...ji,...j->...i", A, b)


def _check_gravity_args(
    R: object,
    p: object,
    m: object,
    J: object,
    mu: object,
    J2: object,
    R_e: object,
    gravity_gradient: object,
) -> tuple:
    """The arguments of :func:`full_body_gravity`/:func:`full_body_potential`, validated."""
    R = so3.validate(R, "R")
    p = as_array(p, "p", (3,))
    if np.any(np.all(p == 0.0, axis=-1)):
        raise ValueError("p: zero position vector (gravity is singular at the centre)")
    try:
        np.broadcast_shapes(R.shape[:-2], p.shape[:-1])
    except ValueError:
        raise ValueError(
            f"p: batch shape {p.shape[:-1]} does not broadcast with R's {R.shape[:-2]}"
        ) from None
    m = check_positive_scalar(m, "m")
    J = check_inertia_3x3(J, "J")
    mu = check_positive_scalar(mu, "mu")
    J2 = as_scalar(J2, "J2")
    R_e = check_positive_scalar(R_e, "R_e")
    if not isinstance(gravity_gradient, (bool, np.bool_)):
        raise TypeError(f"gravity_gradient: expected True or False, got {gravity_gradient!r}")
    return R, p, m, J, mu, J2, R_e, bool(gravity_gradient)


def _finite_gravity(out: np.ndarray, what: str, m: float, J: np.ndarray, mu: float) -> None:
    """Raise naming the argument that made a gravity result overflow (finite inputs)."""
    if np.all(np.isfinite(out)):
        return
    for name, v in (("m", m), ("J", float(np.abs(J).max())), ("mu", mu)):
        if v > 1e100:
            raise ValueError(f"{name}: too large, the {what} overflows float64 ({name} = {v:.3g})")
    raise ValueError(f"p: the {what} overflows float64 (|p| too large or too small)")


def full_body_gravity(
    R: np.ndarray,
    p: np.ndarray,
    m: float,
    J: np.ndarray,
    mu: float = MU_EARTH,
    J2: float = 0.0,
    R_e: float = R_EARTH,
    gravity_gradient: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Gravity on a rigid body: inertial force f_g ``(..., 3)`` [N] and body torque τ_g
    ``(..., 3)`` [N·m] (module docstring). ``R`` ``(..., 3, 3)`` rotations, ``p`` ``(..., 3)``
    inertial positions (not 0), ``m`` > 0, ``J`` an inertia, ``mu`` > 0, ``R_e`` > 0 — all
    validated; a result that overflows float64 raises ``ValueError``."""
    args = _check_gravity_args(R, p, m, J, mu, J2, R_e, gravity_gradient)
    with np.errstate(over="ignore", invalid="ignore"):
        f, tau = _full_body_gravity(*args)
    _finite_gravity(f, "gravity force", args[2], args[3], args[4])
    _finite_gravity(tau, "gravity torque", args[2], args[3], args[4])
    return f, tau


def _full_body_gravity(
    R: np.ndarray,
    p: np.ndarray,
    m: float,
    J: np.ndarray,
    mu: float = MU_EARTH,
    J2: float = 0.0,
    R_e: float = R_EARTH,
    gravity_gradient: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`full_body_gravity` without validation (the plant's hot path)."""
    p = np.asarray(p, dtype=np.float64)
    r = np.sqrt(np.sum(p * p, axis=-1))[..., None]
    if np.any(r <= 0.0):
        raise ValueError("p: zero position vector (gravity is singular at the centre)")
    # point mass inline (the simulator's hot path); J2 from spacecraft.orbit
    f = (-mu * m) * p / r**3
    if J2 != 0.0:
        f = f + m * j2_acceleration(p, mu, J2, R_e)
    if not gravity_gradient:
        return f, np.zeros(f.shape)
    R = np.asarray(R, dtype=np.float64)
    c = _mtv(R, p) / r  # unit position in body axes
    Jc = c @ J.T
    JIp = _mv(R, Jc) * r  # J_I p = R J Rᵀ p
    cJc = np.sum(c * Jc, axis=-1)[..., None]  # pᵀJ_I p / r²
    k = mu / r**5
    f = f - 1.5 * k * np.trace(J) * p - 3.0 * k * JIp + 7.5 * k * cJc * p
    tau = (3.0 * mu) / r**3 * _cross(c, Jc)
    return f, tau


def full_body_potential(
    R: np.ndarray,
    p: np.ndarray,
    m: float,
    J: np.ndarray,
    mu: float = MU_EARTH,
    J2: float = 0.0,
    R_e: float = R_EARTH,
    gravity_gradient: bool = True,
) -> np.ndarray:
    """Potential energy U(p, R) [J] of :func:`full_body_gravity`'s field, ``(...)``
    (arguments validated as there)."""
    args = _check_gravity_args(R, p, m, J, mu, J2, R_e, gravity_gradient)
    with np.errstate(over="ignore", invalid="ignore"):
        U = _full_body_potential(*args)
    _finite_gravity(U, "potential", args[2], args[3], args[4])
    return U


def _full_body_potential(
    R: np.ndarray,
    p: np.ndarray,
    m: float,
    J: np.ndarray,
    mu: float = MU_EARTH,
    J2: float = 0.0,
    R_e: float = R_EARTH,
    gravity_gradient: bool = True,
) -> np.ndarray:
    """:func:`full_body_potential` on validated arguments."""
    U = m * gravity_potential(p, mu, J2, R_e)
    if not gravity_gradient:
        return U
    R = np.asarray(R, dtype=np.float64)
    r = np.linalg.norm(p, axis=-1)
    c = _mtv(R, p) / r[..., None]
    cJc = np.einsum("...i,ij,...j->...", c, J, c)
    return U - mu * np.trace(J) / (2.0 * r**3) + 1.5 * mu * cJc / r**3


@dataclass(frozen=True)
class IdealWrenchActuator:
    """Ideal wrench actuator with optional per-axis limits (body-axis thrusters and torquers).

    Each torque component is clipped to ±``max_torque`` [N·m] and each force component to
    ±``max_force`` [N] (scalars or 3-vectors, ``None`` = unlimited).
    """

    max_torque: float | np.ndarray | None = None
    max_force: float | np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("max_torque", "max_force"):
            val = getattr(self, name)
            if val is None:
                continue
            a = np.array(check_positive(val, name), dtype=np.float64)
            if a.shape not in ((), (3,)):
                raise ValueError(f"{name}: expected a scalar or shape (3,), got {a.shape}")
            a = np.broadcast_to(a, (3,)).copy()
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def limits(self) -> np.ndarray:
        """Per-axis limits ``(6,)`` (inf where unlimited)."""
        tl = np.full(3, np.inf) if self.max_torque is None else self.max_torque
        fl = np.full(3, np.inf) if self.max_force is None else self.max_force
        return np.concatenate((tl, fl))

    def apply(self, wrench: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(applied wrench (B, 6), saturated flags (B, 6) bool)``."""
        lim = self.limits
        applied = np.clip(wrench, -lim, lim)
        return applied, applied != wrench


@dataclass(frozen=True)
class SE3Plant:
    """Rigid-body 6-DOF plant in a central gravity field (module docstring).

    Args:
        m: mass [kg] > 0; J: 3×3 inertia [kg·m²].
        mu: gravitational parameter [m³/s²] > 0 (Earth by default; a small body for hovering).
        J2, R_e: zonal coefficient (0 = point mass) and reference radius [m].
        gravity_gradient: include the gravity-gradient torque and the matching force terms.
        method: ``"lgvi"`` (SE(3) Lie-group variational integrator) or ``"rkmk4"``.
        actuator: :class:`IdealWrenchActuator` (default: unlimited).
        disturbance: ``d(t, g, ξ) -> (B, 6)`` body disturbance wrench (d_ω, d_v), or ``None``.
    """

    m: float
    J: np.ndarray
    mu: float = MU_EARTH
    J2: float = 0.0
    R_e: float = R_EARTH
    gravity_gradient: bool = True
    method: str = "lgvi"
    actuator: IdealWrenchActuator = field(default_factory=IdealWrenchActuator)
    disturbance: Disturbance | None = None
    _lgvi: SE3RigidBodyLGVI = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        m = as_array(self.m, "m")
        if m.ndim != 0:
            raise ValueError(f"m: must be a scalar, got shape {m.shape}")
        object.__setattr__(self, "m", check_positive_scalar(m, "m"))
        J = check_inertia_3x3(self.J, "J")
        J = J.copy()
        J.setflags(write=False)
        object.__setattr__(self, "J", J)
        object.__setattr__(self, "mu", check_positive_scalar(self.mu, "mu"))
        J2 = as_scalar(self.J2, "J2")
        if J2 < 0:
            raise ValueError(f"J2: must be >= 0, got {J2}")
        object.__setattr__(self, "J2", J2)
        object.__setattr__(self, "R_e", check_positive_scalar(self.R_e, "R_e"))
        if not isinstance(self.gravity_gradient, bool):
            raise ValueError(f"gravity_gradient: must be a bool, got {self.gravity_gradient!r}")
        if self.method not in _METHODS:
            raise ValueError(f"method: must be one of {_METHODS}, got {self.method!r}")
        if not isinstance(self.actuator, IdealWrenchActuator):
            raise ValueError(
                f"actuator: expected IdealWrenchActuator, got {type(self.actuator).__name__}"
            )
        if self.disturbance is not None and not callable(self.disturbance):
            raise ValueError("disturbance: must be callable as d(t, g, xi) -> (B, 6) or None")
        object.__setattr__(self, "_lgvi", SE3RigidBodyLGVI(self.m, J))

    # -- gravity -------------------------------------------------------------------------------

    def gravity_inertial(self, R: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(f_g inertial [N], τ_g body [N·m]), each ``(..., 3)`` (unchecked: the plant's
        hot path; :func:`full_body_gravity` is the validated form)."""
        return _full_body_gravity(
            R, p, self.m, self.J, self.mu, self.J2, self.R_e, self.gravity_gradient
        )

    def gravity_wrench(self, g: np.ndarray) -> np.ndarray:
        """Gravity in body axes (τ_g, F_g = Rᵀ f_g), ``(..., 4, 4) -> (..., 6)``; usable as a
        controller's ``gravity`` feed-forward. ``g`` is validated (rigid motions, p ≠ 0)."""
        g = se3.validate(g, "g")
        with np.errstate(over="ignore", invalid="ignore"):
            out = self._gravity_wrench(g)
        _finite_gravity(out, "gravity wrench", self.m, self.J, self.mu)
        return out

    def _gravity_wrench(self, g: np.ndarray) -> np.ndarray:
        """:meth:`gravity_wrench` unchecked (the integrator's stages)."""
        R = g[..., :3, :3]
        f, tau = self.gravity_inertial(R, g[..., :3, 3])
        return np.concatenate((tau, _mtv(R, f)), axis=-1)

    def potential_energy(self, g: np.ndarray) -> np.ndarray:
        """U(p, R) [J], ``(...)``."""
        g = se3.validate(g, "g")
        return _full_body_potential(
            g[..., :3, :3],
            g[..., :3, 3],
            self.m,
            self.J,
            self.mu,
            self.J2,
            self.R_e,
            self.gravity_gradient,
        )

    def energy(self, g: np.ndarray, xi: np.ndarray) -> np.ndarray:
        """Total energy ½ ωᵀJω + ½ m|v|² + U [J], ``(...)``."""
        xi = as_array(xi, "xi", (6,))
        w, v = xi[..., :3], xi[..., 3:]
        with np.errstate(over="ignore", invalid="ignore"):
            kin = 0.5 * np.sum(w * (w @ self.J.T), -1) + 0.5 * self.m * np.sum(v * v, -1)
        if not np.all(np.isfinite(kin)):
            raise ValueError("xi: the kinetic energy overflows float64 (|ξ| too large)")
        return kin + self.potential_energy(g)

    def angular_momentum(self, g: np.ndarray, xi: np.ndarray) -> np.ndarray:
        """Total inertial angular momentum about the centre p × m R v + R Jω, ``(..., 3)``."""
        g = se3.validate(g, "g")
        xi = as_array(xi, "xi", (6,))
        R, p = g[..., :3, :3], g[..., :3, 3]
        return _cross(p, self.m * _mv(R, xi[..., 3:])) + _mv(R, xi[..., :3] @ self.J.T)

    # -- dynamics ------------------------------------------------------------------------------

    def _disturbance(self, t: float, g: np.ndarray, xi: np.ndarray) -> np.ndarray | None:
        if self.disturbance is None:
            return None
        d = np.asarray(self.disturbance(t, g, xi), dtype=np.float64)
        if d.shape != xi.shape or not np.isfinite(d).all():
            raise ValueError(f"disturbance: returned shape {d.shape} or non-finite values")
        return d

    def xi_dot(self, t: float, g: np.ndarray, xi: np.ndarray, wrench: np.ndarray) -> np.ndarray:
        """ξ̇ = I⁻¹(ad_ξᵀIξ + u + w_g(g) + d) for an applied body wrench u ``(..., 6)``."""
        total = coriolis_wrench_unchecked(xi, self.m, self.J) + wrench + self._gravity_wrench(g)
        d = self._disturbance(t, g, xi)
        if d is not None:
            total = total + d
        return np.concatenate(
            (np.linalg.solve(self.J, total[..., :3, None])[..., 0], total[..., 3:] / self.m),
            axis=-1,
        )

    def _step(
        self, t: float, g: np.ndarray, xi: np.ndarray, wrench: np.ndarray, dt: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """One unchecked step with the applied wrench held (the simulator's hot path)."""
        if self.method == "rkmk4":

            def f(tt: float, gg: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                return x, self.xi_dot(tt, gg, x, wrench)

            return rkmk4_se3_step_unchecked(f, t, g, xi, dt)
        R, p = g[..., :3, :3], g[..., :3, 3]
        body = wrench
        d = self._disturbance(t, g, xi)
        if d is not None:
            body = body + d

        def fm(tt: float, RR: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            f_g, tau_g = self.gravity_inertial(RR, x)
            return f_g + _mv(RR, body[..., 3:]), tau_g + body[..., :3]

        Pi = xi[..., :3] @ self.J.T
        gamma = self.m * _mv(R, xi[..., 3:])
        R1, p1, Pi1, gamma1 = self._lgvi.step(t, R, p, Pi, gamma, dt, force_and_moment=fm)
        g1 = se3.from_rt(R1, p1)
        xi1 = np.concatenate(
            (np.linalg.solve(self.J, Pi1[..., None])[..., 0], _mtv(R1, gamma1) / self.m), axis=-1
        )
        return g1, xi1

    def check_state(
        self, g: object, xi: object, names: tuple[str, str] = ("g", "xi")
    ) -> tuple[np.ndarray, np.ndarray]:
        """Validate a batched state ``g (B, 4, 4)``, ``xi (B, 6)``; ``names`` are the names
        the messages use (the caller's argument names)."""
        ng, nx = names
        g = se3.validate(g, ng)
        xi = as_array(xi, nx, (6,))
        if g.ndim != 3:
            raise ValueError(f"{ng}: expected shape (B, 4, 4), got {g.shape}")
        if xi.shape != (g.shape[0], 6):
            raise ValueError(
                f"{nx}: expected shape ({g.shape[0]}, 6) with {ng} {g.shape}, got {xi.shape}"
            )
        return g, xi

    def step(
        self, t: float, g: np.ndarray, xi: np.ndarray, wrench: np.ndarray, dt: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Advance ``(g, ξ)`` by ``dt`` with the body wrench command held (through the
        actuator). Returns ``(g_next (B, 4, 4), xi_next (B, 6))``."""
        g, xi = self.check_state(g, xi)
        u = as_array(wrench, "wrench", (6,))
        if u.shape != xi.shape:
            raise ValueError(f"wrench: expected shape {xi.shape}, got {u.shape}")
        dt = check_positive_scalar(dt, "dt")
        applied, _ = self.actuator.apply(u)
        return self._step(float(t), g, xi, applied, dt)


# -- chaser/target pair ------------------------------------------------------------------------


@dataclass(frozen=True)
class OrbitingTarget:
    """A target whose body frame is the LVLH frame of a circular orbit (module docstring)."""

    orbit: CircularOrbit = field(default_factory=CircularOrbit)

    def __post_init__(self) -> None:
        if not isinstance(self.orbit, CircularOrbit):
            raise ValueError(f"orbit: expected CircularOrbit, got {type(self.orbit).__name__}")

    def pose(self, t: float) -> np.ndarray:
        """g_T(t) = (C(t), r_T(t)), ``(4, 4)``."""
        t = as_scalar(t, "t")
        return se3.from_rt(self.orbit.lvlh_attitude(t), self.orbit.position(t))

    @property
    def twist(self) -> np.ndarray:
        """Body twist ξ_T = ((0, −n, 0), (r n, 0, 0)) (constant), ``(6,)``."""
        o = self.orbit
        return np.array([0.0, -o.n, 0.0, o.radius * o.n, 0.0, 0.0])


@dataclass(frozen=True)
class DockingReference:
    """Reference ``t -> PoseReference`` for holding the pose ``g_rel`` relative to the target body
    (LVLH) frame: g_d = g_T(t) g_rel, ξ_d = Ad_{g_rel⁻¹} ξ_T, ξ̇_d = 0.

    Args:
        target: the :class:`OrbitingTarget`.
        g_rel: ``(4, 4)`` docking pose (chaser body → target body; position in target axes [m]).
    """

    target: OrbitingTarget
    g_rel: np.ndarray

    def __post_init__(self) -> None:
        if not isinstance(self.target, OrbitingTarget):
            raise ValueError(f"target: expected OrbitingTarget, got {type(self.target).__name__}")
        g = se3.validate(self.g_rel, "g_rel")
        if g.shape != (4, 4):
            raise ValueError(f"g_rel: expected shape (4, 4), got {g.shape}")
        g = g.copy()
        g.setflags(write=False)
        object.__setattr__(self, "g_rel", g)

    @property
    def xi_d(self) -> np.ndarray:
        """Desired body twist Ad_{g_rel⁻¹} ξ_T, ``(6,)``."""
        return se3.adjoint(se3.inverse(self.g_rel)) @ self.target.twist

    def __call__(self, t: float) -> PoseReference:
        xi_d = self.xi_d
        return PoseReference(g_d=self.target.pose(t) @ self.g_rel, xi_d=xi_d, xi_dot_d=np.zeros(6))

    def offset_state(
        self, t: float, rotvec: object, position: object
    ) -> tuple[np.ndarray, np.ndarray]:
        """A chaser state displaced from the docking pose and moving rigidly with the desired
        frame (ξ̃ = 0): g = g_d(t) (exp(rotvec^), position) with ``rotvec (B, 3)`` [rad] and
        ``position (B, 3)`` [m] in desired-frame axes; ξ = Ad_{δ⁻¹} ξ_d.
        Returns ``(g (B, 4, 4), xi (B, 6))``."""
        w = as_array(rotvec, "rotvec", (3,))
        d = as_array(position, "position", (3,))
        if w.ndim != 2 or d.shape != w.shape:
            raise ValueError(
                f"position: expected shape {w.shape} like rotvec (B, 3), got {d.shape}"
            )
        delta = se3.from_rt(so3.exp(w), d)
        g = self(t).g_d @ delta
        xi = _mv(se3.adjoint(se3.inverse(delta)), self.xi_d)
        return g, xi


# -- simulator ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class PoseSimulationResult:
    """Logged pose loop: ``K`` samples of ``B`` bodies.

    Attributes:
        t: ``(K,)`` sample times [s].
        g: ``(K, B, 4, 4)`` poses; ``g_d`` the desired ones.
        xi: ``(K, B, 6)`` body twists; ``xi_d`` the desired ones.
        wrench_cmd: ``(K, B, 6)`` controller command held from ``t`` on.
        wrench: ``(K, B, 6)`` wrench applied (after actuator limits).
        saturated: ``(K, B, 6)`` bool, where a limit was active.
        attitude_error: ``(K, B)`` angle of R_dᵀR [rad].
        position_error: ``(K, B)`` |p − p_d| [m].
        log_error: ``(K, B, 6)`` log(g_d⁻¹ g)^∨.
        controller: diagnostics ``(K, B, ...)``.
        dt: plant step [s]; ``control_period`` the controller's sampling period [s].
    """

    t: np.ndarray
    g: np.ndarray
    xi: np.ndarray
    g_d: np.ndarray
    xi_d: np.ndarray
    wrench_cmd: np.ndarray
    wrench: np.ndarray
    saturated: np.ndarray
    attitude_error: np.ndarray
    position_error: np.ndarray
    log_error: np.ndarray
    controller: dict[str, np.ndarray]
    dt: float
    control_period: float

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])


class _PoseLog:
    def __init__(self, K: int, B: int) -> None:
        self.t = np.full(K, np.nan)
        self.g = np.zeros((K, B, 4, 4))
        self.xi = np.zeros((K, B, 6))
        self.g_d = np.zeros((K, B, 4, 4))
        self.xi_d = np.zeros((K, B, 6))
        self.cmd = np.zeros((K, B, 6))
        self.u = np.zeros((K, B, 6))
        self.sat = np.zeros((K, B, 6), dtype=bool)
        self.ctrl: dict[str, np.ndarray] = {}
        self.k = 0

    def record(self, t, g, xi, ref, cmd, u, sat, diag) -> None:
        k = self.k
        self.t[k] = t
        self.g[k], self.xi[k] = g, xi
        self.g_d[k] = np.broadcast_to(ref.g_d, g.shape)
        self.xi_d[k] = np.broadcast_to(ref.xi_d, xi.shape)
        self.cmd[k], self.u[k], self.sat[k] = cmd, u, sat
        K = self.t.shape[0]
        for name, val in diag.items():
            val = np.asarray(val)
            if name not in self.ctrl:
                self.ctrl[name] = np.zeros((K,) + val.shape, dtype=val.dtype)
            if self.ctrl[name].shape[1:] == val.shape:
                self.ctrl[name][k] = val
        self.k += 1

    def result(self, dt: float, period: float) -> PoseSimulationResult:
        n = self.k
        g, g_d = self.g[:n], self.g_d[:n]
        Rt = np.swapaxes(g_d[..., :3, :3], -1, -2) @ g[..., :3, :3]
        return PoseSimulationResult(
            t=self.t[:n], g=g, xi=self.xi[:n], g_d=g_d, xi_d=self.xi_d[:n],
            wrench_cmd=self.cmd[:n], wrench=self.u[:n], saturated=self.sat[:n],
            attitude_error=so3.angle(Rt),
            position_error=np.linalg.norm(g[..., :3, 3] - g_d[..., :3, 3], axis=-1),
            log_error=se3.log(se3.inverse(g_d) @ g) if n else np.zeros((0,) + g.shape[1:2] + (6,)),
            controller={k: v[:n] for k, v in self.ctrl.items()},
            dt=dt, control_period=period,
        )  # fmt: skip


def simulate_pose(
    plant: SE3Plant,
    controller: PoseController,
    reference: Callable[[float], PoseReference],
    g0: np.ndarray,
    xi0: np.ndarray,
    t_final: float,
    dt: float,
    control_period: float | None = None,
    log_every: int = 1,
    t0: float = 0.0,
) -> PoseSimulationResult:
    """Fixed-step pose loop (the SE(3) counterpart of :func:`spacecraft.simulator.simulate`).

    From ``t_k = t0 + k dt``: every ``control_period / dt`` steps the controller is sampled,
    ``u = controller.command(t_k, PoseState(g, ξ), reference(t_k))``, and held (zero-order hold);
    the actuator limits it; the plant advances one step (``plant.method``). Every ``log_every``
    steps (and at the end) a row is logged: the state at ``t_k`` and the wrench applied from
    ``t_k`` on. A non-finite state, an arithmetic error or a non-converging implicit (LGVI) step
    raises :class:`SimulationDiverged` with ``.time`` and the partial log ``.result`` (the last
    finite state included), the original error chained as the cause.

    Args:
        plant: the :class:`SE3Plant`.
        controller: a :class:`PoseController` (``reset(t0, B)`` is called first).
        reference: ``t -> PoseReference``.
        g0: ``(B, 4, 4)`` initial poses.
        xi0: ``(B, 6)`` initial body twists.
        t_final: end time [s], at least one step after ``t0``; not a multiple of ``dt`` →
            rounded up to whole steps with a ``UserWarning`` (as
            :func:`spacecraft.simulator.simulate`).
        dt: plant step [s] > 0.
        control_period: a positive integer multiple of ``dt`` (default ``dt``).
        log_every: log every this many steps (positive integer).
        t0: start time [s].
    """
    if not isinstance(plant, SE3Plant):
        raise ValueError(f"plant: expected SE3Plant, got {type(plant).__name__}")
    if not isinstance(controller, PoseController):
        raise ValueError(f"controller: expected a PoseController, got {type(controller).__name__}")
    if not callable(reference):
        raise ValueError("reference: must be callable as reference(t) -> PoseReference")
    g, xi = plant.check_state(g0, xi0, ("g0", "xi0"))
    dt = check_positive_scalar(dt, "dt")
    t0, t_final, n_steps = _horizon_steps(t0, t_final, dt)
    period = (
        dt if control_period is None else check_positive_scalar(control_period, "control_period")
    )
    ratio = period / dt
    every = round(ratio)
    if every < 1 or abs(ratio - every) > _PERIOD_RTOL * ratio:
        raise ValueError(
            f"control_period: must be a positive integer multiple of dt = {dt!r}, got {period!r}"
        )
    log_every = as_int(log_every, "log_every", 1)

    B = g.shape[0]
    K = n_steps // log_every + 1 + (1 if n_steps % log_every else 0)
    log = _PoseLog(K, B)
    controller.reset(t0, B)
    cmd = u = sat = diag = ref = None
    for k in range(n_steps + 1):
        t = t0 + k * dt
        if k % every == 0 or k == n_steps:
            ref = reference(t)
            if k < n_steps or cmd is None:
                # the integrator's own arrays: no re-validation at every control step
                state = PoseState.unchecked(g, xi)
                cmd = np.asarray(controller.command(t, state, ref), dtype=np.float64)
                if cmd.shape != (B, 6):
                    raise ValueError(
                        f"controller: command returned shape {cmd.shape}, expected {(B, 6)}"
                    )
                u, sat = plant.actuator.apply(cmd)
                diag = controller.diagnostics()
        logged = k % log_every == 0 or k == n_steps
        if logged:
            log.record(t, g, xi, ref, cmd, u, sat, diag)
        if k == n_steps:
            break
        if not np.isfinite(u).all():
            if not logged:
                log.record(t, g, xi, ref, cmd, u, sat, diag)  # keep the last finite state
            raise SimulationDiverged(
                f"simulate_pose: non-finite wrench command at t = {t!r}", t, log.result(dt, period)
            )
        failure: BaseException | None = None
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                # a diverging state overflows inside the step: reported below, not warned
                g_new, xi_new = plant._step(t, g, xi, u, dt)
        except (ArithmeticError, ValueError, LGVIConvergenceError) as exc:
            # overflow/domain errors in scalar math, or the implicit LGVI step failing to
            # converge (h‖ω‖ too large): the run diverged at this step
            failure = exc
        if failure is not None or not (np.isfinite(g_new).all() and np.isfinite(xi_new).all()):
            if not logged:
                log.record(t, g, xi, ref, cmd, u, sat, diag)  # keep the last finite state
            t_bad = t0 + (k + 1) * dt
            why = "became non-finite" if failure is None else f"failed ({failure!r})"
            raise SimulationDiverged(
                f"simulate_pose: state {why} at t = {t_bad:.6g} s (step {k + 1} of {n_steps})",
                t_bad,
                log.result(dt, period),
            ) from failure
        g, xi = g_new, xi_new
    return log.result(dt, period)
