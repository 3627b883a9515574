"""Tilted-dipole geomagnetic field, in inertial and body axes.

Model. The first-degree (n = 1) term of the IGRF spherical-harmonic expansion is a centred dipole;
its field at position r (|r| = r, r̂ = r/r) is

    B(r) = B₀ (a/r)³ [3 (m̂·r̂) r̂ − m̂]          [T]

with a the IGRF reference radius (6371.2 km), m̂ the unit dipole axis and B₀ its strength: the
field magnitude on the dipole's equator at r = a. On the dipole equator ‖B‖ = B₀ (a/r)³ pointing
along −m̂; over the dipole poles ‖B‖ = 2 B₀ (a/r)³ along ±r̂ (Wertz, *Spacecraft Attitude
Determination and Control*, Reidel 1978, appendix H; Markley & Crassidis,
*Fundamentals of Spacecraft Attitude Determination and Control*, Springer 2014, ch. 3).

Constants. From the IGRF-13 degree-1 Gauss coefficients at epoch 2020.0 (g₁⁰ = −29404.8 nT,
g₁¹ = −1450.9 nT, h₁¹ = 4652.5 nT): B₀ = √(g₁⁰² + g₁¹² + h₁¹²) = 29.806 μT, and the dipole axis
in Earth-fixed axes is m̂ = (g₁¹, h₁¹, g₁⁰)/B₀ — it points into the southern hemisphere (the
field points down, into the Earth, in the north), tilted ``tilt`` = arccos(−g₁⁰/B₀) = 9.41° from
the south pole, at east longitude ``longitude`` = atan2(h₁¹, g₁¹) = 107.32° (Wertz, appendix H).

Earth rotation. Inertial axes are ECI with Z the Earth's polar axis (as in
:mod:`spacecraft.orbit`). The Earth-fixed frame turns about Z at ``earth_rate`` (sidereal,
7.2921159e-5 rad/s) from the Greenwich angle ``greenwich0`` at t = 0, so the dipole axis in
inertial axes is m̂(t) = R_z(greenwich0 + earth_rate·t) m̂_ECEF. Set ``earth_rate = 0`` to freeze
the dipole in inertial space (a cheaper, slightly less realistic model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from liecontrol._validation import as_array, as_scalar, check_positive_scalar, norm_last

__all__ = [
    "IGRF_REFERENCE_RADIUS",
    "EARTH_ROTATION_RATE",
    "DIPOLE_STRENGTH_2020",
    "DIPOLE_TILT_2020",
    "DIPOLE_LONGITUDE_2020",
    "TiltedDipoleField",
]

#: IGRF reference radius a [m].
IGRF_REFERENCE_RADIUS = 6371.2e3
#: Earth's sidereal rotation rate [rad/s].
EARTH_ROTATION_RATE = 7.2921159e-5
_G10, _G11, _H11 = -29404.8e-9, -1450.9e-9, 4652.5e-9  # IGRF-13, epoch 2020.0 [T]
#: Dipole strength B₀ [T], IGRF-13 epoch 2020.0.
DIPOLE_STRENGTH_2020 = math.sqrt(_G10**2 + _G11**2 + _H11**2)
#: Angle between the dipole axis and the south geographic pole [rad], IGRF-13 2020.0.
DIPOLE_TILT_2020 = math.acos(-_G10 / DIPOLE_STRENGTH_2020)
#: East longitude of the dipole axis m̂ in Earth-fixed axes [rad], IGRF-13 2020.0.
DIPOLE_LONGITUDE_2020 = math.atan2(_H11, _G11)


@dataclass(frozen=True)
class TiltedDipoleField:
    """Centred tilted dipole B(r) = B₀ (a/r)³ [3 (m̂·r̂) r̂ − m̂] (see the module docstring).

    Args:
        strength: B₀ [T] (> 0), the field magnitude on the dipole equator at r = a.
        tilt: angle of m̂ from the south geographic pole (−Z) [rad], in [0, π].
        longitude: east longitude of m̂'s meridian in Earth-fixed axes [rad].
        greenwich0: Greenwich sidereal angle at t = 0 [rad].
        earth_rate: Earth rotation rate [rad/s] (≥ 0; 0 freezes the dipole in inertial axes).
        radius: reference radius a [m] (> 0).
    """

    strength: float = DIPOLE_STRENGTH_2020
    tilt: float = DIPOLE_TILT_2020
    longitude: float = DIPOLE_LONGITUDE_2020
    greenwich0: float = 0.0
    earth_rate: float = EARTH_ROTATION_RATE
    radius: float = IGRF_REFERENCE_RADIUS

    def __post_init__(self) -> None:
        object.__setattr__(self, "strength", check_positive_scalar(self.strength, "strength"))
        object.__setattr__(self, "radius", check_positive_scalar(self.radius, "radius"))
        tilt = as_scalar(self.tilt, "tilt")
        if not 0.0 <= tilt <= math.pi:
            raise ValueError(f"tilt: must be in [0, pi], got {tilt}")
        object.__setattr__(self, "tilt", tilt)
        for name in ("longitude", "greenwich0"):
            object.__setattr__(self, name, as_scalar(getattr(self, name), name))
        rate = as_scalar(self.earth_rate, "earth_rate")
        if rate < 0.0:
            raise ValueError(f"earth_rate: must be >= 0, got {rate}")
        object.__setattr__(self, "earth_rate", rate)

    def dipole_axis(self, t: object) -> np.ndarray:
        """Unit dipole axis m̂(t) in inertial axes; ``t`` scalar → ``(3,)``, ``(...,)`` →
        ``(..., 3)``."""
        lam = self.longitude + self.greenwich0 + self.earth_rate * as_array(t, "t")
        s = math.sin(self.tilt)
        # m̂ makes angle `tilt` with −Z: z-component −cos(tilt)
        return np.stack(
            (s * np.cos(lam), s * np.sin(lam), np.full(np.shape(lam), -math.cos(self.tilt))),
            axis=-1,
        )

    def inertial(self, t: object, r: object) -> np.ndarray:
        """Field B [T] in inertial axes at inertial position ``r`` ``(..., 3)`` [m] and time
        ``t`` (scalar or broadcasting with ``r``'s leading shape) → ``(..., 3)``."""
        r = as_array(r, "r", (3,))
        rn = norm_last(r)
        if np.any(rn <= 0.0):
            raise ValueError("r: zero position vector (the dipole field is singular there)")
        m = self.dipole_axis(t)
        rhat = r / rn[..., None]
        mr = np.sum(m * rhat, axis=-1, keepdims=True)
        scale = self.strength * (self.radius / rn) ** 3
        return scale[..., None] * (3.0 * mr * rhat - m)

    def body(self, t: object, R: object, r: object) -> np.ndarray:
        """Field in body axes Rᵀ B(r) [T], ``R`` ``(..., 3, 3)`` body → inertial."""
        R = as_array(R, "R", (3, 3))
        return np.einsum("...ji,...j->...i", R, self.inertial(t, r))
