"""Circular orbit, LVLH frame, Earth-pointing reference and point-mass/J2 gravity.

Orbit. A circular orbit of radius r and rate n, related by Kepler's third law n = √(μ/r³)
(μ = :data:`MU_EARTH` = 3.986004418e14 m³/s², WGS-84/EGM-96 value). The orbit plane is placed in
the inertial (ECI) frame by ``inclination`` and ``raan`` (``R_orb = R_z(raan) R_x(inclination)``)
and the spacecraft's argument of latitude is u(t) = ``arg_lat0`` + n t, so

    r(t) = r R_orb (cos u, sin u, 0),   ĥ = R_orb e_z   (orbit normal).

LVLH frame: z_L = −r̂ (nadir), y_L = −ĥ (opposite the orbit normal), x_L = y_L × z_L
(= the velocity direction on a circular orbit). ``C(t) = [x_L y_L z_L]`` maps LVLH → inertial;
the frame turns at the orbit rate about −y_L: Ċ = C ω_L^ with ω_L = (0, −n, 0) (LVLH axes).

Earth-pointing reference. The desired body frame is the LVLH frame rotated by a constant
``offset`` (desired body → LVLH): R_d(t) = C(t) O, ω_d = Oᵀ ω_L (constant, desired body axes),
ω̇_d = 0; indeed Ṙ_d = C ω_L^ O = R_d (Oᵀ ω_L)^.

Gravity (per unit mass, inertial position r, Earth's polar axis = inertial Z):

    two-body:  U₀ = −μ/|r|,                           a₀ = −∇U₀ = −μ r/|r|³
    J2:        U₂ = (μ J₂ R_e² / (2|r|³)) (3 z²/|r|² − 1),
               a₂ = −∇U₂ = −(3/2) μ J₂ R_e²/|r|⁵ · (x (1 − 5z²/|r|²), y (1 − 5z²/|r|²),
                                                   z (3 − 5z²/|r|²))

(Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., §8.6.1; Montenbruck & Gill,
*Satellite Orbits*, §3.2). The SE(3) plant uses :func:`gravity_acceleration`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from liecontrol._validation import (
    as_array,
    as_scalar,
    check_positive_scalar,
    check_rotation_matrix,
    norm_last,
)
from liecontrol.control.base import AttitudeReference

__all__ = [
    "MU_EARTH",
    "J2_EARTH",
    "R_EARTH",
    "CircularOrbit",
    "EarthPointingReference",
    "two_body_acceleration",
    "two_body_potential",
    "j2_acceleration",
    "j2_potential",
    "gravity_acceleration",
    "gravity_potential",
]

#: Earth's gravitational parameter μ [m³/s²] (EGM-96 / WGS-84).
MU_EARTH = 3.986004418e14
#: Earth's second zonal harmonic J2 (EGM-96, unnormalised).
J2_EARTH = 1.08263e-3
#: Earth's equatorial radius [m] (WGS-84).
R_EARTH = 6378137.0


def _rx(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class CircularOrbit:
    """A circular Keplerian orbit.

    Args:
        n: orbit rate [rad/s] (> 0; default 0.0011, the low orbit of the ADRC and
            rotating-payload papers).
        mu: gravitational parameter [m³/s²] (> 0); with ``n`` it fixes the radius
            r = (μ/n²)^(1/3) through n = √(μ/r³). Use :meth:`from_radius` to give r instead.
        inclination, raan: orientation of the orbit plane in the inertial frame [rad].
        arg_lat0: argument of latitude at t = 0 [rad].
    """

    n: float = 0.0011
    mu: float = MU_EARTH
    inclination: float = 0.0
    raan: float = 0.0
    arg_lat0: float = 0.0
    _R_orb: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "n", check_positive_scalar(self.n, "n"))
        object.__setattr__(self, "mu", check_positive_scalar(self.mu, "mu"))
        for name in ("inclination", "raan", "arg_lat0"):
            object.__setattr__(self, name, as_scalar(getattr(self, name), name))
        R_orb = _rz(self.raan) @ _rx(self.inclination)
        R_orb.setflags(write=False)
        object.__setattr__(self, "_R_orb", R_orb)

    @classmethod
    def from_radius(cls, radius: float, mu: float = MU_EARTH, **kwargs: float) -> CircularOrbit:
        """The circular orbit of radius ``radius`` [m]: n = √(μ/r³)."""
        r = check_positive_scalar(radius, "radius")
        m = check_positive_scalar(mu, "mu")
        return cls(n=float(np.sqrt(m / r**3)), mu=m, **kwargs)

    @classmethod
    def from_altitude(
        cls,
        altitude: float,
        inclination: float = 0.0,
        raan: float = 0.0,
        arg_lat0: float = 0.0,
        mu: float = MU_EARTH,
        earth_radius: float = R_EARTH,
    ) -> CircularOrbit:
        """The circular orbit ``altitude`` [m] (> 0) above a spherical Earth of radius
        ``earth_radius`` (WGS-84 equatorial by default), inclination and RAAN in radians:
        r = R_e + altitude, n = √(μ/r³)."""
        alt = check_positive_scalar(altitude, "altitude")
        R_e = check_positive_scalar(earth_radius, "earth_radius")
        return cls.from_radius(
            R_e + alt, mu=mu, inclination=inclination, raan=raan, arg_lat0=arg_lat0
        )

    @property
    def altitude(self) -> float:
        """Height above the WGS-84 equatorial radius, r − R_e [m]."""
        return self.radius - R_EARTH

    @property
    def radius(self) -> float:
        """Orbit radius r = (μ/n²)^(1/3) [m]."""
        return float((self.mu / self.n**2) ** (1.0 / 3.0))

    @property
    def period(self) -> float:
        """Orbit period 2π/n [s]."""
        return float(2.0 * np.pi / self.n)

    @property
    def normal(self) -> np.ndarray:
        """Unit orbit normal ĥ (inertial)."""
        return self._R_orb[:, 2].copy()

    def _u(self, t: object) -> np.ndarray:
        return self.arg_lat0 + self.n * as_array(t, "t")

    def position(self, t: object) -> np.ndarray:
        """Inertial position r(t) [m]; ``t`` scalar or ``(...,)`` → ``(..., 3)``."""
        u = self._u(t)
        p = np.stack((np.cos(u), np.sin(u), np.zeros_like(u)), axis=-1)
        return self.radius * p @ self._R_orb.T

    def velocity(self, t: object) -> np.ndarray:
        """Inertial velocity ṙ(t) = n ĥ × r [m/s]; ``(..., 3)``."""
        u = self._u(t)
        p = np.stack((-np.sin(u), np.cos(u), np.zeros_like(u)), axis=-1)
        return self.radius * self.n * p @ self._R_orb.T

    def lvlh_attitude(self, t: object) -> np.ndarray:
        """C(t) = [x_L y_L z_L], LVLH → inertial; ``t`` scalar → ``(3, 3)``, ``(...,)`` →
        ``(..., 3, 3)``. z_L = −r̂, y_L = −ĥ, x_L = y_L × z_L (the velocity direction)."""
        u = self._u(t)
        c, s = np.cos(u), np.sin(u)
        zero = np.zeros_like(u)
        # columns in the orbit-plane frame: x_L = (−s, c, 0), y_L = (0, 0, −1), z_L = (−c, −s, 0)
        C_orb = np.stack(
            (
                np.stack((-s, zero, -c), axis=-1),
                np.stack((c, zero, -s), axis=-1),
                np.stack((zero, zero - 1.0, zero), axis=-1),
            ),
            axis=-2,
        )
        return self._R_orb @ C_orb

    @property
    def lvlh_rate(self) -> np.ndarray:
        """Angular velocity of the LVLH frame in LVLH axes, ω_L = (0, −n, 0) [rad/s]."""
        return np.array([0.0, -self.n, 0.0])

    def nadir_in_body(self, R: object, t: float) -> np.ndarray:
        """Unit nadir vector in body axes, ĉ = Rᵀ(−r̂(t)); ``R`` ``(..., 3, 3)`` (body →
        inertial) → ``(..., 3)``."""
        R = as_array(R, "R", (3, 3))
        nadir = -self.position(t) / self.radius
        return np.einsum("...ji,...j->...i", R, nadir)


@dataclass(frozen=True)
class EarthPointingReference:
    """Earth-pointing attitude reference: desired body = LVLH rotated by ``offset``.

    R_d(t) = C(t) O,  ω_d = Oᵀ (0, −n, 0) (desired body axes),  ω̇_d = 0.

    Args:
        orbit: the :class:`CircularOrbit`.
        offset: ``(3, 3)`` or ``(B, 3, 3)`` rotation O, desired body → LVLH (identity = body
            axes aligned with LVLH: z to nadir, x along the velocity).

    Calling it with ``t`` returns a :class:`liecontrol.control.AttitudeReference`.
    """

    orbit: CircularOrbit
    offset: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.orbit, CircularOrbit):
            raise ValueError(f"orbit: expected CircularOrbit, got {type(self.orbit).__name__}")
        O = np.eye(3) if self.offset is None else check_rotation_matrix(self.offset, "offset")
        if O.ndim not in (2, 3):
            raise ValueError(f"offset: expected shape (3, 3) or (B, 3, 3), got {O.shape}")
        O = O.copy()
        O.setflags(write=False)
        object.__setattr__(self, "offset", O)

    @property
    def omega_d(self) -> np.ndarray:
        """Desired angular velocity Oᵀ ω_L in desired body axes, ``(3,)`` or ``(B, 3)``."""
        return np.einsum("...ji,j->...i", self.offset, self.orbit.lvlh_rate)

    def __call__(self, t: float) -> AttitudeReference:
        R_d = self.orbit.lvlh_attitude(float(t)) @ self.offset
        w = self.omega_d
        return AttitudeReference(R_d=R_d, omega_d=w, omega_dot_d=np.zeros_like(w))

    def samples(self, times: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reference at every time of ``times`` ``(N,)`` in one vectorised call (the
        simulator's compiled loop samples a time-varying reference up front: the sampling
        protocol of :mod:`liecontrol.control.reference`): ``(R_d, ω_d, ω̇_d)`` of shapes
        ``(N, 3, 3)``, ``(N, 3)``, ``(N, 3)`` — ``(N, B, …)`` for a per-spacecraft offset —
        equal to ``self(times[k])`` sample by sample."""
        t = as_array(times, "times")
        if t.ndim != 1:
            raise ValueError(f"times: expected shape (N,), got {t.shape}")
        C = self.orbit.lvlh_attitude(t)  # (N, 3, 3)
        O = self.offset
        R_d = C @ O if O.ndim == 2 else C[:, None] @ O
        w = np.broadcast_to(self.omega_d, t.shape + self.omega_d.shape)
        return R_d, w, np.zeros(w.shape)


def _r_norm(r: object) -> tuple[np.ndarray, np.ndarray]:
    r = as_array(r, "r", (3,))
    rn = norm_last(r)  # overflow-safe: |r| of a 1e300 position is 1e300·|r̂|, not inf
    if np.any(rn <= 0.0):
        raise ValueError("r: zero position vector (gravity is singular at the centre)")
    return r, rn


def two_body_potential(r: object, mu: float = MU_EARTH) -> np.ndarray:
    """Point-mass gravitational potential energy per unit mass U₀ = −μ/|r| [J/kg]; ``(...,)``."""
    mu = check_positive_scalar(mu, "mu")
    _, rn = _r_norm(r)
    return -mu / rn


def two_body_acceleration(r: object, mu: float = MU_EARTH) -> np.ndarray:
    """Point-mass gravity a₀ = −μ r/|r|³ [m/s²] for inertial positions ``(..., 3)``."""
    mu = check_positive_scalar(mu, "mu")
    r, rn = _r_norm(r)
    rn = rn[..., None]
    with np.errstate(under="ignore", over="ignore"):
        # unit vector first, then 1/r² in two divisions: no overflow of r³ for a huge |r|
        return -mu * (r / rn) / rn / rn


def j2_potential(
    r: object, mu: float = MU_EARTH, J2: float = J2_EARTH, R_e: float = R_EARTH
) -> np.ndarray:
    """J2 part of the potential energy per unit mass, U₂ = μJ₂R_e²/(2|r|³)·(3z²/|r|² − 1)."""
    mu = check_positive_scalar(mu, "mu")
    R_e = check_positive_scalar(R_e, "R_e")
    J2 = as_scalar(J2, "J2")
    r, rn = _r_norm(r)
    z2 = (r[..., 2] / rn) ** 2
    with np.errstate(under="ignore", over="ignore", invalid="ignore"):
        q = R_e / rn
        out = 0.5 * (mu / rn) * J2 * q * q * (3.0 * z2 - 1.0)
    return _j2_finite(out, J2, R_e)


def j2_acceleration(
    r: object, mu: float = MU_EARTH, J2: float = J2_EARTH, R_e: float = R_EARTH
) -> np.ndarray:
    """J2 **perturbation** a₂ = −∇U₂ [m/s²] (inertial, Earth's pole = Z); ``(..., 3)``.

    a₂ = −(3/2) μ J₂ R_e²/|r|⁵ (x(1 − 5ẑ²), y(1 − 5ẑ²), z(3 − 5ẑ²)), ẑ = z/|r|.
    Add :func:`two_body_acceleration` for the full field (or use :func:`gravity_acceleration`).
    """
    mu = check_positive_scalar(mu, "mu")
    R_e = check_positive_scalar(R_e, "R_e")
    J2 = as_scalar(J2, "J2")
    r, rn = _r_norm(r)
    z2 = (r[..., 2] / rn) ** 2
    with np.errstate(under="ignore", over="ignore", invalid="ignore"):
        q = R_e / rn
        k = -1.5 * (mu / rn) / rn * J2 * q * q  # μJ₂R_e²/r⁴ without forming r⁵
        f = np.stack((1.0 - 5.0 * z2, 1.0 - 5.0 * z2, 3.0 - 5.0 * z2), axis=-1)
        out = k[..., None] * (r / rn[..., None]) * f
    return _j2_finite(out, J2, R_e)


def _j2_finite(out: np.ndarray, J2: float, R_e: float) -> np.ndarray:
    """``out`` if finite, else a ``ValueError`` naming the argument that made it overflow
    (the position and μ alone cannot: both enter as bounded ratios)."""
    if not np.all(np.isfinite(out)):
        name, v = ("R_e", R_e) if R_e > 1e100 else ("J2", J2)
        raise ValueError(f"{name}: the J2 term overflows float64 ({name} = {v:.3g})")
    return out


def gravity_potential(
    r: object, mu: float = MU_EARTH, J2: float = 0.0, R_e: float = R_EARTH
) -> np.ndarray:
    """U₀ + U₂ (J2 = 0: point mass only) [J/kg]."""
    return two_body_potential(r, mu) + j2_potential(r, mu, J2, R_e)


def gravity_acceleration(
    r: object, mu: float = MU_EARTH, J2: float = 0.0, R_e: float = R_EARTH
) -> np.ndarray:
    """Total gravity a₀ + a₂ (J2 = 0: point mass only) [m/s²]; ``(..., 3)``."""
    return two_body_acceleration(r, mu) + j2_acceleration(r, mu, J2, R_e)
