"""Environment torques from surface forces and the residual magnetic dipole.

Three disturbance sources with the contract of :mod:`spacecraft.disturbances` (a callable
``source(t, R (B, 3, 3), omega (B, 3)) -> (B, 3)`` body torque about the centre of mass [N·m],
``R`` body → inertial). All read the attitude (``uses_attitude = True``) and take the spacecraft's
inertial position and velocity from a :class:`~spacecraft.orbit.CircularOrbit` (ECI axes, Z the
Earth's polar axis).

Flat plates. The spacecraft surface is a set of :class:`Plate` s: area A, outward unit normal n̂
and centre of pressure c (the plate's centroid, relative to the centre of mass, body axes). Each
plate sees the flow or the light only from its front side and self-shadowing between plates is
ignored (the usual flat-plate model: Wertz, *Spacecraft Attitude Determination and Control*,
Reidel 1978, §17.2; Markley & Crassidis, *Fundamentals of Spacecraft Attitude Determination and
Control*, Springer 2014, §3.3.6). The torque is τ = Σ c × F over the plates. :func:`box_plates`
builds the six faces of a box whose geometric centre sits ``offset`` from the centre of mass; a
box centred on the centre of mass has zero aerodynamic and solar torque, so ``offset`` is the
centre-of-pressure offset that makes the torque.

Aerodynamic (free-molecular flow, :class:`AerodynamicTorque`). With v the velocity of the
spacecraft relative to the atmosphere, v̂ = v/‖v‖ in body axes and cos θ = n̂·v̂, a plate facing the
flow (cos θ > 0) feels

    F = −½ ρ C_D ‖v‖² A cos θ v̂

(Markley & Crassidis eq. 3.164). The atmosphere co-rotates with the Earth by default:
v = ṙ − ω_E ẑ × r (ω_E the sidereal rate); ``corotating=False`` uses ṙ alone. The density ρ
comes from :class:`ExponentialAtmosphere`: Vallado's exponential model, ρ(h) = ρ₀ exp(−(h −
h₀)/H) with the base altitude h₀, nominal density ρ₀ and scale height H of the band holding h
(Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., Microcosm 2013, Table 8-4,
from CIRA-72). The model here covers the bands from 100 km up (below, the flow is not free
molecular and no circular orbit lasts); the 1000 km band extends above 1000 km. On a circular
orbit the altitude, hence ρ, is constant.

Solar radiation pressure (:class:`SolarPressureTorque`). With ŝ the unit vector to the Sun in
body axes, cos θ = n̂·ŝ and the plate's fractions of the incoming light absorbed (C_a), reflected
specularly (C_s) and diffusely (C_d), C_a + C_s + C_d = 1, a lit plate (cos θ > 0) feels

    F = −P A cos θ [(1 − C_s) ŝ + 2 (C_s cos θ + C_d/3) n̂]

(Markley & Crassidis eq. 3.167; Montenbruck & Gill, *Satellite Orbits*, Springer 2000, §3.4),
with P = P₀ (1 AU/d)², P₀ = 1361 W/m² / c = 4.54e-6 N/m² (the solar constant over the speed of
light) and d the Sun's distance. The Sun's position comes from :func:`sun_position_au`, the
low-precision formula of the *Astronomical Almanac* (about 0.01° over 1950–2050; Vallado
Algorithm 29; Montenbruck & Gill §3.3.2), evaluated at the Julian date ``epoch_jd + t/86400``;
the direction from the spacecraft is taken equal to the direction from the Earth (parallax below
1e-4 rad in low orbit). Eclipse: the cylindrical shadow model (:func:`in_cylindrical_shadow`)
switches the pressure off when r·ŝ < 0 and the distance of r from the Earth–Sun line is below
the Earth's radius (Montenbruck & Gill §3.4.2; the penumbra is ignored).

Residual dipole (:class:`ResidualDipoleTorque`). A body-fixed magnetic dipole m [A·m²] (stray
currents, magnetised parts) in the geomagnetic field B (body axes, from
:class:`spacecraft.geomagnetic.TiltedDipoleField` at the orbit position) feels τ = m × B
(Wertz §17.2; Markley & Crassidis §3.3.6.4).

Compiled: each source has a ``fused_kernel()`` (:mod:`spacecraft.disturbance_kernel`), so the
simulator's fused loop runs it — alone or inside a
:class:`~spacecraft.disturbances.SumOfDisturbances` — with the formulas above written out for
one spacecraft (:func:`aerodynamic_kernel`, :func:`solar_pressure_kernel`,
:func:`residual_dipole_kernel`; the tests hold them to the sources' ``__call__`` to 1e-12).
Each source's ``__call__`` is its ``torque_at(t, R)``, a pure function that also runs on JAX
values: the differentiable loop (:mod:`spacecraft.differentiable`) evaluates the same formula
at every RKMK4 stage (the eclipse switch is a ``where`` on the pressure).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from dataclasses import field as _dc_field
from typing import Any, ClassVar

import numpy as np

from liecontrol._array_api import cross, namespace
from liecontrol._jit import njit
from liecontrol._validation import as_array, as_scalar, check_bool, check_positive_scalar

from .disturbance_kernel import DisturbanceKernel
from .geomagnetic import EARTH_ROTATION_RATE, TiltedDipoleField
from .orbit import R_EARTH, CircularOrbit

__all__ = [
    "SOLAR_PRESSURE_1AU",
    "J2000_JD",
    "EXPONENTIAL_ATMOSPHERE_TABLE",
    "Plate",
    "box_plates",
    "ExponentialAtmosphere",
    "sun_position_au",
    "in_cylindrical_shadow",
    "aerodynamic_torque",
    "solar_pressure_torque",
    "AerodynamicTorque",
    "SolarPressureTorque",
    "ResidualDipoleTorque",
    "aerodynamic_kernel",
    "solar_pressure_kernel",
    "residual_dipole_kernel",
]

#: Solar radiation pressure at 1 AU, P₀ = 1361 W/m² / 299792458 m/s [N/m²].
SOLAR_PRESSURE_1AU = 1361.0 / 299792458.0
#: Julian date of the J2000.0 epoch (2000-01-01 12:00 TT).
J2000_JD = 2451545.0

#: Vallado's exponential atmosphere (4th ed., Table 8-4) from 100 km: rows of base altitude h₀
#: [km], nominal density ρ₀ [kg/m³], scale height H [km].
EXPONENTIAL_ATMOSPHERE_TABLE: tuple[tuple[float, float, float], ...] = (
    (100.0, 5.297e-7, 5.877),
    (110.0, 9.661e-8, 7.263),
    (120.0, 2.438e-8, 9.473),
    (130.0, 8.484e-9, 12.636),
    (140.0, 3.845e-9, 16.149),
    (150.0, 2.070e-9, 22.523),
    (180.0, 5.464e-10, 29.740),
    (200.0, 2.789e-10, 37.105),
    (250.0, 7.248e-11, 45.546),
    (300.0, 2.418e-11, 53.628),
    (350.0, 9.518e-12, 53.298),
    (400.0, 3.725e-12, 58.515),
    (450.0, 1.585e-12, 60.828),
    (500.0, 6.967e-13, 63.822),
    (600.0, 1.454e-13, 71.835),
    (700.0, 3.614e-14, 88.667),
    (800.0, 1.170e-14, 124.64),
    (900.0, 5.245e-15, 181.05),
    (1000.0, 3.019e-15, 268.00),
)


def _unit3(x: object, name: str) -> np.ndarray:
    v = as_array(x, name, (3,))
    if v.shape != (3,):
        raise ValueError(f"{name}: expected shape (3,), got {v.shape}")
    n = float(np.linalg.norm(v))
    if not n > 0.0 or not math.isfinite(n):
        raise ValueError(f"{name}: must be a non-zero finite vector, got {v.tolist()}")
    return v / n


def _fraction(x: object, name: str) -> float:
    v = as_scalar(x, name)
    if not 0.0 <= v <= 1.0:
        raise ValueError(f"{name}: must be in [0, 1], got {v}")
    return v


@dataclass(frozen=True)
class Plate:
    """One flat surface of the spacecraft (see the module docstring).

    Args:
        area: A [m²] (> 0).
        normal: outward normal, body axes (normalised here; non-zero).
        centre: centre of pressure (the plate's centroid) relative to the centre of mass, body
            axes [m].
        absorption, specular, diffuse: fractions C_a, C_s, C_d of the incident sunlight
            absorbed, reflected specularly and reflected diffusely; each in [0, 1], summing to 1
            (default: a black plate). Only the solar-pressure torque uses them.
    """

    area: float
    normal: np.ndarray
    centre: np.ndarray = _dc_field(default_factory=lambda: np.zeros(3))
    absorption: float = 1.0
    specular: float = 0.0
    diffuse: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "area", check_positive_scalar(self.area, "area"))
        n = _unit3(self.normal, "normal")
        n.setflags(write=False)
        object.__setattr__(self, "normal", n)
        c = as_array(self.centre, "centre", (3,))
        if c.shape != (3,):
            raise ValueError(f"centre: expected shape (3,), got {c.shape}")
        c = c.copy()
        c.setflags(write=False)
        object.__setattr__(self, "centre", c)
        total = 0.0
        for name in ("absorption", "specular", "diffuse"):
            v = _fraction(getattr(self, name), name)
            object.__setattr__(self, name, v)
            total += v
        if abs(total - 1.0) > 1e-9:
            raise ValueError(
                f"absorption: absorption + specular + diffuse must sum to 1, got "
                f"{self.absorption} + {self.specular} + {self.diffuse} = {total}"
            )


def box_plates(
    size: object,
    offset: object = (0.0, 0.0, 0.0),
    absorption: float = 1.0,
    specular: float = 0.0,
    diffuse: float = 0.0,
) -> tuple[Plate, ...]:
    """The six faces of a box with edge lengths ``size`` = (a_x, a_y, a_z) [m] (each > 0) whose
    geometric centre is at ``offset`` [m] from the centre of mass (body axes): face ±i has normal
    ±e_i, area = the product of the other two edges and centre ``offset ± (a_i/2) e_i``. All faces
    share the optical coefficients."""
    s = as_array(size, "size", (3,))
    if s.shape != (3,):
        raise ValueError(f"size: expected shape (3,), got {s.shape}")
    if not np.all(s > 0.0):
        raise ValueError(f"size: every edge must be > 0, got {s.tolist()}")
    if not math.isfinite(float(np.prod(s))):
        raise ValueError(f"size: the face areas overflow float64, got {s.tolist()}")
    o = as_array(offset, "offset", (3,))
    if o.shape != (3,):
        raise ValueError(f"offset: expected shape (3,), got {o.shape}")
    plates = []
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        for sign in (1.0, -1.0):
            e = np.zeros(3)
            e[i] = sign
            plates.append(
                Plate(
                    float(s[j] * s[k]),
                    e,
                    o + 0.5 * s[i] * e,
                    absorption=absorption,
                    specular=specular,
                    diffuse=diffuse,
                )
            )
    return tuple(plates)


def _check_plates(plates: object, name: str = "plates") -> tuple[Plate, ...]:
    if isinstance(plates, Plate):
        plates = (plates,)
    if isinstance(plates, (str, bytes)) or not isinstance(plates, Iterable):
        raise ValueError(f"{name}: expected a sequence of Plate, got {type(plates).__name__}")
    out = tuple(plates)
    if not out:
        raise ValueError(f"{name}: at least one Plate is required")
    for i, p in enumerate(out):
        if not isinstance(p, Plate):
            raise ValueError(f"{name}: item {i} is {type(p).__name__}, expected Plate")
    return out


@dataclass(frozen=True)
class _PlateArrays:
    """Plates stacked for the hot path: normals N (P, 3), centres C (P, 3), areas A (P,),
    c × n (P, 3), and the optical coefficients (P,)."""

    N: np.ndarray
    C: np.ndarray
    A: np.ndarray
    CxN: np.ndarray
    spec: np.ndarray
    diff: np.ndarray

    @classmethod
    def of(cls, plates: tuple[Plate, ...]) -> _PlateArrays:
        N = np.array([p.normal for p in plates])
        C = np.array([p.centre for p in plates])
        arrs = cls(
            N=N,
            C=C,
            A=np.array([p.area for p in plates]),
            CxN=np.cross(C, N),
            spec=np.array([p.specular for p in plates]),
            diff=np.array([p.diffuse for p in plates]),
        )
        for a in (arrs.N, arrs.C, arrs.A, arrs.CxN, arrs.spec, arrs.diff):
            a.setflags(write=False)
        return arrs


def _aero(P: _PlateArrays, vhat: Any, q: Any) -> Any:
    """−q Σ_p A_p max(n̂_p·v̂, 0) c_p × v̂ for unit flow directions ``vhat`` (..., 3), q = ½ρC_D‖v‖²
    (pure: NumPy or JAX)."""
    xp = namespace(vhat, q)
    w = xp.maximum(vhat @ P.N.T, 0.0) * P.A  # (..., P)
    return -q * cross(w @ P.C, vhat)


def _srp(P: _PlateArrays, s: Any, pressure: Any) -> Any:
    """Σ_p c_p × F_p for unit Sun directions ``s`` (..., 3) in body axes (pure: NumPy or JAX)."""
    xp = namespace(s, pressure)
    cos = xp.maximum(s @ P.N.T, 0.0)  # (..., P)
    wa = cos * P.A
    w1 = wa * (1.0 - P.spec)
    w2 = 2.0 * wa * (P.spec * cos + P.diff / 3.0)
    return -pressure * (cross(w1 @ P.C, s) + w2 @ P.CxN)


def aerodynamic_torque(
    plates: object, velocity: object, density: float, drag_coefficient: float = 2.2
) -> np.ndarray:
    """Free-molecular flat-plate torque Σ c × (−½ ρ C_D ‖v‖² A max(n̂·v̂, 0) v̂) [N·m].

    Args:
        plates: a :class:`Plate` or a sequence of them.
        velocity: velocity of the spacecraft relative to the atmosphere in body axes [m/s],
            ``(3,)`` or ``(..., 3)`` (a zero velocity gives zero torque).
        density: atmospheric density ρ [kg/m³] (≥ 0).
        drag_coefficient: C_D (> 0; 2.0–2.5 is typical of free-molecular flow, 2.2 default).
    """
    P = _PlateArrays.of(_check_plates(plates))
    v = as_array(velocity, "velocity", (3,))
    rho = as_scalar(density, "density")
    if rho < 0.0:
        raise ValueError(f"density: must be >= 0, got {rho}")
    cd = check_positive_scalar(drag_coefficient, "drag_coefficient")
    speed = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        vhat = np.where(speed > 0.0, v / np.where(speed > 0.0, speed, 1.0), 0.0)
    out = _aero(P, vhat, 0.5 * rho * cd * speed**2)
    if not np.all(np.isfinite(out)):
        raise ValueError("velocity: the torque overflows float64 (velocity too large)")
    return out


def solar_pressure_torque(
    plates: object, sun_direction: object, pressure: float = SOLAR_PRESSURE_1AU
) -> np.ndarray:
    """Flat-plate solar radiation torque Σ c × F, F = −P A cos θ [(1 − C_s) ŝ + 2(C_s cos θ +
    C_d/3) n̂] over lit plates (cos θ = n̂·ŝ > 0) [N·m].

    Args:
        plates: a :class:`Plate` or a sequence of them.
        sun_direction: direction to the Sun in body axes, ``(3,)`` or ``(..., 3)`` (normalised
            here; non-zero).
        pressure: P [N/m²] (≥ 0; 0 in eclipse).
    """
    P = _PlateArrays.of(_check_plates(plates))
    s = as_array(sun_direction, "sun_direction", (3,))
    n = np.linalg.norm(s, axis=-1, keepdims=True)
    if np.any(n <= 0.0):
        raise ValueError("sun_direction: must be non-zero")
    p = as_scalar(pressure, "pressure")
    if p < 0.0:
        raise ValueError(f"pressure: must be >= 0, got {p}")
    return _srp(P, s / n, p)


@dataclass(frozen=True)
class ExponentialAtmosphere:
    """Vallado's exponential atmosphere from 100 km (:data:`EXPONENTIAL_ATMOSPHERE_TABLE`):
    ρ(h) = scale · ρ₀ exp(−(h − h₀)/H) in the band [h₀, next h₀) holding h.

    Args:
        scale: multiplies the density (> 0; the table is a mean: solar activity moves the
            density at 500 km by a factor of ten either way).
    """

    scale: float = 1.0

    #: lowest altitude the model covers [m]
    min_altitude: ClassVar[float] = EXPONENTIAL_ATMOSPHERE_TABLE[0][0] * 1e3

    def __post_init__(self) -> None:
        object.__setattr__(self, "scale", check_positive_scalar(self.scale, "scale"))

    def density(self, altitude: object) -> np.ndarray | float:
        """ρ [kg/m³] at geometric ``altitude`` [m] (scalar or array, ≥ 100 km)."""
        h = as_array(altitude, "altitude")
        if np.any(h < self.min_altitude):
            raise ValueError(
                f"altitude: {float(np.min(h)) / 1e3:.6g} km is below the exponential "
                f"atmosphere's range (from {self.min_altitude / 1e3:.0f} km)"
            )
        base = np.array([r[0] for r in EXPONENTIAL_ATMOSPHERE_TABLE]) * 1e3
        i = np.searchsorted(base, h, side="right") - 1
        rho0 = np.array([r[1] for r in EXPONENTIAL_ATMOSPHERE_TABLE])[i]
        H = np.array([r[2] for r in EXPONENTIAL_ATMOSPHERE_TABLE])[i] * 1e3
        out = self.scale * rho0 * np.exp(-(h - base[i]) / H)
        return float(out) if out.ndim == 0 else out


def sun_position_au(jd: object) -> np.ndarray:
    """Geocentric position of the Sun in mean-equator (ECI) axes [AU] at Julian date ``jd``
    (scalar → ``(3,)``, ``(...,)`` → ``(..., 3)``), by the Astronomical Almanac's low-precision
    formula (d = jd − 2451545.0, angles in degrees):

        L = 280.460 + 0.9856474 d,   g = 357.528 + 0.9856003 d,
        λ = L + 1.915 sin g + 0.020 sin 2g,   ε = 23.439 − 4e-7 d,
        ρ = 1.00014 − 0.01671 cos g − 0.00014 cos 2g,
        r = ρ (cos λ, cos ε sin λ, sin ε sin λ).

    Accurate to about 0.01° in direction between 1950 and 2050 (Vallado §5.1, Algorithm 29).
    """
    d = as_array(jd, "jd") - J2000_JD
    if d.size == 0:
        raise ValueError("jd: empty array")
    g = np.deg2rad(357.528 + 0.9856003 * d)
    lam = np.deg2rad(280.460 + 0.9856474 * d + 1.915 * np.sin(g) + 0.020 * np.sin(2.0 * g))
    eps = np.deg2rad(23.439 - 4e-7 * d)
    rho = 1.00014 - 0.01671 * np.cos(g) - 0.00014 * np.cos(2.0 * g)
    sl = np.sin(lam)
    return rho[..., None] * np.stack((np.cos(lam), np.cos(eps) * sl, np.sin(eps) * sl), axis=-1)


def _sun_unit_and_distance(jd: Any) -> tuple[Any, Any]:
    """Hot path of :func:`sun_position_au` for one scalar date: (unit vector, distance [AU]).
    ``jd`` a Python float (``math``'s functions) or a JAX scalar (``jax.numpy``'s: the
    differentiable loop, :mod:`spacecraft.differentiable`), one formula."""
    if isinstance(jd, float):
        sin, cos, rad, stack = math.sin, math.cos, math.radians, np.array
    else:
        xp = namespace(jd)
        sin, cos, rad, stack = xp.sin, xp.cos, xp.radians, xp.stack
    d = jd - J2000_JD
    g = rad(357.528 + 0.9856003 * d)
    lam = rad(280.460 + 0.9856474 * d + 1.915 * sin(g) + 0.020 * sin(2.0 * g))
    eps = rad(23.439 - 4e-7 * d)
    rho = 1.00014 - 0.01671 * cos(g) - 0.00014 * cos(2.0 * g)
    sl = sin(lam)
    return stack([cos(lam), cos(eps) * sl, sin(eps) * sl]), rho


def in_cylindrical_shadow(
    r: object, sun_direction: object, earth_radius: float = R_EARTH
) -> np.ndarray | bool:
    """True where position ``r`` [m] ``(..., 3)`` (ECI) is in the Earth's cylindrical shadow:
    r·ŝ < 0 and ‖r − (r·ŝ) ŝ‖ < R_e, with ŝ the direction to the Sun (normalised here)."""
    r = as_array(r, "r", (3,))
    s = as_array(sun_direction, "sun_direction", (3,))
    sn = np.linalg.norm(s, axis=-1, keepdims=True)
    if np.any(sn <= 0.0):
        raise ValueError("sun_direction: must be non-zero")
    Re = check_positive_scalar(earth_radius, "earth_radius")
    s = s / sn
    along = np.sum(r * s, axis=-1)
    perp = np.linalg.norm(r - along[..., None] * s, axis=-1)
    out = (along < 0.0) & (perp < Re)
    return bool(out) if out.ndim == 0 else out


def _check_orbit(orbit: object) -> CircularOrbit:
    if not isinstance(orbit, CircularOrbit):
        raise ValueError(f"orbit: expected CircularOrbit, got {type(orbit).__name__}")
    return orbit


def _orbit_rv(o: CircularOrbit, t: Any, radius: float | None = None) -> tuple[Any, Any]:
    # hot path: position and velocity from the orbit-plane angle, no validation; a JAX ``t``
    # takes jax.numpy's cos/sin (the differentiable loop), a Python float math's
    u = o.arg_lat0 + o.n * t
    if isinstance(t, float):
        c, s = math.cos(u), math.sin(u)
    else:
        xp = namespace(t)
        c, s = xp.cos(u), xp.sin(u)
    e1, e2 = o._R_orb[:, 0], o._R_orb[:, 1]
    r = o.radius if radius is None else radius
    return r * (c * e1 + s * e2), (r * o.n) * (c * e2 - s * e1)


# ---------------------------------------------------------------- compiled torques (one spacecraft)
# Parameter rows (float64): the orbit as (n, u₀, radius, p̂ (3), q̂ (3)) — the plane's first two
# axes, CircularOrbit._R_orb[:, 0] and [:, 1] — then the source's constants, then the plates
# as columns of P entries: N (P×3), C (P×3), A (P), c × n (P×3), C_s (P), C_d (P).
_ORBIT_WIDTH = 9


def _orbit_params(o: CircularOrbit, radius: float) -> list[float]:
    return [o.n, o.arg_lat0, radius, *o._R_orb[:, 0], *o._R_orb[:, 1]]


def _plate_params(P: _PlateArrays) -> list[float]:
    return [*P.N.ravel(), *P.C.ravel(), *P.A, *P.CxN.ravel(), *P.spec, *P.diff]


@njit(inline="always")
def _orbit_position_velocity(
    p: np.ndarray, t: float
) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """r, ṙ on the circular orbit of the row ``p`` (layout above): :func:`_orbit_rv`."""
    u = p[1] + p[0] * t
    c = math.cos(u)
    s = math.sin(u)
    r = p[2]
    rn = r * p[0]
    return (
        r * (c * p[3] + s * p[6]), r * (c * p[4] + s * p[7]), r * (c * p[5] + s * p[8]),
        rn * (c * p[6] - s * p[3]), rn * (c * p[7] - s * p[4]), rn * (c * p[8] - s * p[5]),
    )  # fmt: skip


@njit(inline="always")
def _to_body(R: np.ndarray, u0: float, u1: float, u2: float) -> tuple[float, float, float]:
    """Rᵀ u: an inertial vector in body axes."""
    return (
        u0 * R[0, 0] + u1 * R[1, 0] + u2 * R[2, 0],
        u0 * R[0, 1] + u1 * R[1, 1] + u2 * R[2, 1],
        u0 * R[0, 2] + u1 * R[1, 2] + u2 * R[2, 2],
    )


@njit(inline="always")
def _facing(p: np.ndarray, N: int, i: int, h0: float, h1: float, h2: float) -> float:
    """max(n̂_i·h, 0): how much plate ``i`` (normals from ``p[N]``, 3 per plate) faces ``h``."""
    return max(h0 * p[N + 3 * i] + h1 * p[N + 3 * i + 1] + h2 * p[N + 3 * i + 2], 0.0)


@njit
def aerodynamic_kernel(
    t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
) -> None:
    """:class:`AerodynamicTorque` for one spacecraft: τ = −q‖v‖² (Σ_p A_p max(n̂_p·v̂, 0) c_p) × v̂
    with v̂ = Rᵀ v/‖v‖, v = ṙ − ω_E ẑ × r when co-rotating. ``params``: the orbit (9), then
    (co-rotating 0/1, ω_E, q = ½ρC_D, P), then the plates (module comment)."""
    r0, r1, _, v0, v1, v2 = _orbit_position_velocity(params, t)
    o = _ORBIT_WIDTH
    if params[o] != 0.0:
        wE = params[o + 1]
        v0 = v0 - wE * -r1
        v1 = v1 - wE * r0
    speed = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    u0 = v0 / speed
    u1 = v1 / speed
    u2 = v2 / speed
    h0, h1, h2 = _to_body(R, u0, u1, u2)
    qq = params[o + 2] * speed * speed
    n_p = int(params[o + 3])
    N = o + 4
    C = N + 3 * n_p
    A = C + 3 * n_p
    c0 = 0.0
    c1 = 0.0
    c2 = 0.0
    for i in range(n_p):
        w = _facing(params, N, i, h0, h1, h2) * params[A + i]
        c0 += w * params[C + 3 * i]
        c1 += w * params[C + 3 * i + 1]
        c2 += w * params[C + 3 * i + 2]
    out[0] = -qq * (c1 * h2 - c2 * h1)
    out[1] = -qq * (c2 * h0 - c0 * h2)
    out[2] = -qq * (c0 * h1 - c1 * h0)


@njit
def solar_pressure_kernel(
    t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
) -> None:
    """:class:`SolarPressureTorque` for one spacecraft: the Almanac's Sun
    (:func:`sun_position_au`), P = P₀/d², zero in the cylindrical shadow when eclipses are on,
    τ = −P (Σ_p w₁ c_p × ŝ + Σ_p w₂ c_p × n̂_p), w₁ = A cos θ (1 − C_s), w₂ = 2A cos θ (C_s cos θ +
    C_d/3), cos θ = max(n̂·ŝ, 0), ŝ = Rᵀ ŝ_I. ``params``: the orbit (9), then (epoch JD, P₀,
    eclipse 0/1, R_e, P), then the plates (module comment)."""
    o = _ORBIT_WIDTH
    d = params[o] + t / 86400.0 - J2000_JD
    g = math.radians(357.528 + 0.9856003 * d)
    lam = math.radians(280.460 + 0.9856474 * d + 1.915 * math.sin(g) + 0.020 * math.sin(2.0 * g))
    eps = math.radians(23.439 - 4e-7 * d)
    rho = 1.00014 - 0.01671 * math.cos(g) - 0.00014 * math.cos(2.0 * g)
    sl = math.sin(lam)
    s0 = math.cos(lam)
    s1 = math.cos(eps) * sl
    s2 = math.sin(eps) * sl
    pr = params[o + 1] / (rho * rho)
    if params[o + 2] != 0.0:
        r0, r1, r2, _, _, _ = _orbit_position_velocity(params, t)
        along = r0 * s0 + r1 * s1 + r2 * s2
        if along < 0.0:
            p0 = r0 - along * s0
            p1 = r1 - along * s1
            p2 = r2 - along * s2
            Re = params[o + 3]
            if p0 * p0 + p1 * p1 + p2 * p2 < Re * Re:
                pr = 0.0
    if pr == 0.0:
        out[0] = 0.0
        out[1] = 0.0
        out[2] = 0.0
        return
    b0, b1, b2 = _to_body(R, s0, s1, s2)
    n_p = int(params[o + 4])
    N = o + 5
    C = N + 3 * n_p
    A = C + 3 * n_p
    X = A + n_p
    S = X + 3 * n_p
    D = S + n_p
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    e0 = 0.0
    e1 = 0.0
    e2 = 0.0
    for i in range(n_p):
        cth = _facing(params, N, i, b0, b1, b2)
        wa = cth * params[A + i]
        w1 = wa * (1.0 - params[S + i])
        w2 = 2.0 * wa * (params[S + i] * cth + params[D + i] / 3.0)
        a0 += w1 * params[C + 3 * i]
        a1 += w1 * params[C + 3 * i + 1]
        a2 += w1 * params[C + 3 * i + 2]
        e0 += w2 * params[X + 3 * i]
        e1 += w2 * params[X + 3 * i + 1]
        e2 += w2 * params[X + 3 * i + 2]
    out[0] = -pr * ((a1 * b2 - a2 * b1) + e0)
    out[1] = -pr * ((a2 * b0 - a0 * b2) + e1)
    out[2] = -pr * ((a0 * b1 - a1 * b0) + e2)


@njit
def residual_dipole_kernel(
    t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
) -> None:
    """:class:`ResidualDipoleTorque` for one spacecraft: τ = m × Rᵀ B, B = B₀(a/r)³ [3 (m̂·r̂) r̂ −
    m̂] with m̂ = (sin β cos λ, sin β sin λ, −cos β), λ = λ₀ + θ_G0 + ω_E t. ``params``: the orbit
    (9, radius 1), then (B₀(a/r)³, λ₀ + θ_G0, ω_E, β, m (3))."""
    r0, r1, r2, _, _, _ = _orbit_position_velocity(params, t)
    o = _ORBIT_WIDTH
    lam = params[o + 1] + params[o + 2] * t
    st = math.sin(params[o + 3])
    m0 = st * math.cos(lam)
    m1 = st * math.sin(lam)
    m2 = -math.cos(params[o + 3])
    k = 3.0 * (m0 * r0 + m1 * r1 + m2 * r2)
    sc = params[o]
    B0 = sc * (k * r0 - m0)
    B1 = sc * (k * r1 - m1)
    B2 = sc * (k * r2 - m2)
    b0, b1, b2 = _to_body(R, B0, B1, B2)
    d0 = params[o + 4]
    d1 = params[o + 5]
    d2 = params[o + 6]
    out[0] = d1 * b2 - d2 * b1
    out[1] = d2 * b0 - d0 * b2
    out[2] = d0 * b1 - d1 * b0


@dataclass(frozen=True)
class AerodynamicTorque:
    """Aerodynamic torque of flat ``plates`` on a circular ``orbit`` (module docstring).

    Args:
        plates: a :class:`Plate` or a sequence of them (e.g. :func:`box_plates`).
        orbit: the :class:`~spacecraft.orbit.CircularOrbit`; its altitude above the equatorial
            radius must lie in the atmosphere model's range (from 100 km).
        drag_coefficient: C_D (> 0, default 2.2).
        atmosphere: the :class:`ExponentialAtmosphere`.
        corotating: the atmosphere turns with the Earth (v = ṙ − ω_E ẑ × r; default) or is at
            rest in inertial space (v = ṙ).
    """

    uses_attitude: ClassVar[bool] = True

    plates: tuple[Plate, ...]
    orbit: CircularOrbit
    drag_coefficient: float = 2.2
    atmosphere: ExponentialAtmosphere = _dc_field(default_factory=ExponentialAtmosphere)
    corotating: bool = True
    _P: _PlateArrays = _dc_field(init=False, repr=False, compare=False)
    _q: float = _dc_field(init=False, repr=False, compare=False)
    _radius: float = _dc_field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "plates", _check_plates(self.plates))
        _check_orbit(self.orbit)
        cd = check_positive_scalar(self.drag_coefficient, "drag_coefficient")
        object.__setattr__(self, "drag_coefficient", cd)
        if not isinstance(self.atmosphere, ExponentialAtmosphere):
            raise ValueError(
                f"atmosphere: expected ExponentialAtmosphere, got {type(self.atmosphere).__name__}"
            )
        object.__setattr__(self, "corotating", check_bool(self.corotating, "corotating"))
        h = self.orbit.altitude
        if h < self.atmosphere.min_altitude:
            raise ValueError(
                f"orbit: altitude {h / 1e3:.6g} km is below the atmosphere model's range "
                f"(from {self.atmosphere.min_altitude / 1e3:.0f} km)"
            )
        object.__setattr__(self, "_P", _PlateArrays.of(self.plates))
        object.__setattr__(self, "_q", 0.5 * cd * float(self.atmosphere.density(h)))
        object.__setattr__(self, "_radius", self.orbit.radius)

    @property
    def density(self) -> float:
        """ρ at the orbit's altitude [kg/m³]."""
        return float(self.atmosphere.density(self.orbit.altitude))

    def relative_velocity(self, t: float) -> np.ndarray:
        """Velocity relative to the atmosphere in inertial axes [m/s], ``(3,)``."""
        r, v = _orbit_rv(self.orbit, as_scalar(t, "t"), self._radius)
        if self.corotating:
            v = v - EARTH_ROTATION_RATE * np.array([-r[1], r[0], 0.0])
        return v

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        return self.torque_at(as_scalar(t, "t"), np.asarray(R))

    def torque_at(self, t: Any, R: Any) -> Any:
        """The torque ``(..., 3)`` at time ``t`` for attitudes ``R`` ``(..., 3, 3)`` (module
        docstring). Pure, NumPy or JAX (the differentiable loop, :mod:`spacecraft.
        differentiable`, evaluates it at every RKMK4 stage's attitude)."""
        xp = namespace(R, t)
        r, v = _orbit_rv(self.orbit, t, self._radius)
        if self.corotating:
            v = v - EARTH_ROTATION_RATE * xp.stack([-r[1], r[0], 0.0 * r[2]])
        speed = xp.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        vhat = (v / speed) @ R  # Rᵀ v̂ for each spacecraft, (..., 3)
        return _aero(self._P, vhat, self._q * speed * speed)

    def fused_kernel(self) -> DisturbanceKernel:
        """:func:`aerodynamic_kernel` and its parameters, shared by the batch
        (:mod:`spacecraft.disturbance_kernel`)."""
        head = [float(self.corotating), EARTH_ROTATION_RATE, self._q, len(self.plates)]
        params = _orbit_params(self.orbit, self._radius) + head + _plate_params(self._P)
        return DisturbanceKernel(aerodynamic_kernel, np.array(params, dtype=np.float64))


@dataclass(frozen=True)
class SolarPressureTorque:
    """Solar radiation pressure torque on flat ``plates`` with the Sun from the low-precision
    ephemeris and the cylindrical eclipse (module docstring).

    Args:
        plates: a :class:`Plate` or a sequence of them (optical coefficients per plate).
        orbit: the :class:`~spacecraft.orbit.CircularOrbit` (for the eclipse).
        epoch_jd: Julian date at t = 0 (default J2000.0, 2000-01-01 12:00).
        pressure: P₀ at 1 AU [N/m²] (> 0, default :data:`SOLAR_PRESSURE_1AU`); scaled by
            (1 AU/d)².
        eclipse: switch the torque off in the Earth's cylindrical shadow (default True).
    """

    uses_attitude: ClassVar[bool] = True

    plates: tuple[Plate, ...]
    orbit: CircularOrbit
    epoch_jd: float = J2000_JD
    pressure: float = SOLAR_PRESSURE_1AU
    eclipse: bool = True
    _P: _PlateArrays = _dc_field(init=False, repr=False, compare=False)
    _radius: float = _dc_field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "plates", _check_plates(self.plates))
        _check_orbit(self.orbit)
        object.__setattr__(self, "epoch_jd", as_scalar(self.epoch_jd, "epoch_jd"))
        object.__setattr__(self, "pressure", check_positive_scalar(self.pressure, "pressure"))
        object.__setattr__(self, "eclipse", check_bool(self.eclipse, "eclipse"))
        object.__setattr__(self, "_P", _PlateArrays.of(self.plates))
        object.__setattr__(self, "_radius", self.orbit.radius)

    def sun(self, t: float) -> tuple[np.ndarray, float]:
        """Unit direction to the Sun (inertial) and the pressure P at time ``t`` (0 in
        eclipse)."""
        t = as_scalar(t, "t")
        s, d = _sun_unit_and_distance(self.epoch_jd + t / 86400.0)
        p = self.pressure / (d * d)
        if self.eclipse:
            r, _ = _orbit_rv(self.orbit, t, self._radius)
            along = float(r @ s)
            if along < 0.0:
                perp = r - along * s
                if float(perp @ perp) < R_EARTH * R_EARTH:
                    p = 0.0
        return s, p

    def in_eclipse(self, t: float) -> bool:
        """Whether the spacecraft is in the cylindrical shadow at time ``t``."""
        t = as_scalar(t, "t")
        s = sun_position_au(self.epoch_jd + t / 86400.0)
        return bool(in_cylindrical_shadow(_orbit_rv(self.orbit, t)[0], s))

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        return self.torque_at(as_scalar(t, "t"), np.asarray(R))

    def torque_at(self, t: Any, R: Any) -> Any:
        """The torque ``(..., 3)`` at time ``t`` for attitudes ``R`` ``(..., 3, 3)`` (module
        docstring; zero in the shadow when ``eclipse``). Pure, NumPy or JAX (the differentiable
        loop, :mod:`spacecraft.differentiable`): the shadow is a ``where`` on the pressure."""
        xp = namespace(R, t)
        s, d = _sun_unit_and_distance(self.epoch_jd + t / 86400.0)
        p = self.pressure / (d * d)
        if self.eclipse:
            r, _ = _orbit_rv(self.orbit, t, self._radius)
            along = r[0] * s[0] + r[1] * s[1] + r[2] * s[2]
            perp = r - along * s
            shade = (along < 0.0) & (perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2]
                                     < R_EARTH * R_EARTH)  # fmt: skip
            p = xp.where(shade, 0.0, p)
        return _srp(self._P, s @ R, p)  # Rᵀ ŝ for each spacecraft, (..., 3)

    def fused_kernel(self) -> DisturbanceKernel:
        """:func:`solar_pressure_kernel` and its parameters, shared by the batch
        (:mod:`spacecraft.disturbance_kernel`)."""
        head = [self.epoch_jd, self.pressure, float(self.eclipse), R_EARTH, len(self.plates)]
        params = _orbit_params(self.orbit, self._radius) + head + _plate_params(self._P)
        return DisturbanceKernel(solar_pressure_kernel, np.array(params, dtype=np.float64))


@dataclass(frozen=True)
class ResidualDipoleTorque:
    """Residual magnetic dipole torque τ = m × B (B in body axes at the orbit position).

    Args:
        dipole: m, body axes [A·m²] ``(3,)`` (typically 0.1–10 A·m² on a small to large
            spacecraft).
        orbit: the :class:`~spacecraft.orbit.CircularOrbit` giving the position.
        field: the :class:`~spacecraft.geomagnetic.TiltedDipoleField` (IGRF 2020 dipole by
            default).
    """

    uses_attitude: ClassVar[bool] = True

    dipole: np.ndarray
    orbit: CircularOrbit
    field: TiltedDipoleField = _dc_field(default_factory=TiltedDipoleField)
    _B_scale: float = _dc_field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        m = as_array(self.dipole, "dipole", (3,))
        if m.shape != (3,):
            raise ValueError(f"dipole: expected shape (3,), got {m.shape}")
        m = m.copy()
        m.setflags(write=False)
        object.__setattr__(self, "dipole", m)
        _check_orbit(self.orbit)
        if not isinstance(self.field, TiltedDipoleField):
            raise ValueError(f"field: expected TiltedDipoleField, got {type(self.field).__name__}")
        # B₀ (a/r)³, constant on a circular orbit
        scale = self.field.strength * (self.field.radius / self.orbit.radius) ** 3
        object.__setattr__(self, "_B_scale", scale)

    def field_inertial(self, t: Any) -> Any:
        """B [T] at the orbit position at time ``t``, inertial axes ``(3,)``: the field's dipole
        formula B₀ (a/r)³ [3 (m̂·r̂) r̂ − m̂] written out for one scalar time (the hot path;
        the tests check it against :meth:`TiltedDipoleField.inertial`). ``t`` a float or a JAX
        scalar (the differentiable loop)."""
        if isinstance(t, (int, float, np.ndarray)):
            t = as_scalar(t, "t")
            sin, cos, stack = math.sin, math.cos, np.array
        else:
            xp = namespace(t)
            sin, cos, stack = xp.sin, xp.cos, xp.stack
        f = self.field
        lam = f.longitude + f.greenwich0 + f.earth_rate * t
        st = math.sin(f.tilt)
        m0, m1, m2 = st * cos(lam), st * sin(lam), -math.cos(f.tilt)
        rhat = _orbit_rv(self.orbit, t, 1.0)[0]  # unit position: radius 1
        k = 3.0 * (m0 * rhat[0] + m1 * rhat[1] + m2 * rhat[2])
        return self._B_scale * (k * rhat - stack([m0, m1, m2]))

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        return self.torque_at(as_scalar(t, "t"), np.asarray(R))

    def torque_at(self, t: Any, R: Any) -> Any:
        """m × Rᵀ B(t) ``(..., 3)`` for attitudes ``R`` ``(..., 3, 3)``. Pure, NumPy or JAX (the
        differentiable loop, :mod:`spacecraft.differentiable`)."""
        B = self.field_inertial(t) @ R  # Rᵀ B per spacecraft, (..., 3)
        return cross(self.dipole, B)

    def fused_kernel(self) -> DisturbanceKernel:
        """:func:`residual_dipole_kernel` and its parameters, shared by the batch
        (:mod:`spacecraft.disturbance_kernel`)."""
        f = self.field
        head = [self._B_scale, f.longitude + f.greenwich0, f.earth_rate, f.tilt]
        params = _orbit_params(self.orbit, 1.0) + head + [*self.dipole]
        return DisturbanceKernel(residual_dipole_kernel, np.array(params, dtype=np.float64))
