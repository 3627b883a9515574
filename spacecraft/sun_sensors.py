"""Coarse Sun sensors, the Sun vector they give, and the safe-mode measurement hook.

Sensor model. A coarse Sun sensor is a photodiode (or a small solar cell) whose current follows
the cosine of the Sun's incidence angle within its field of view (Markley & Crassidis,
*Fundamentals of Spacecraft Attitude Determination and Control*, Springer, 2014; Wertz
(ed.), *Spacecraft Attitude Determination and Control*, Reidel, 1978, §6.1). With ``n̂_i`` the
unit normal of sensor ``i`` and ``ŝ = Rᵀ s_I`` the Sun in body axes, the output, normalised to 1
at normal incidence, is

    y_i = max(0, n̂_iᵀŝ) · [angle(n̂_i, ŝ) < fov] · lit + v_i,   v_i ~ N(0, σ²),  clipped at 0,

with ``lit`` = 0 in the Earth's cylindrical shadow (:func:`spacecraft.surface_forces.
in_cylindrical_shadow`, penumbra ignored). **Albedo-free**: the Earth's reflected light, which
in low orbit adds up to ≈ 0.3 of the direct signal on sensors that see the Earth, is not
modelled, and neither are the sensors' scale-factor spread and ageing. The Sun's direction is the
low-precision ephemeris of :func:`spacecraft.surface_forces.sun_position_au` at the Julian date
``epoch_jd + t/86400`` (the parallax of the orbit, < 1e-4 rad, is ignored).

Sun vector (:func:`estimate_sun_vector`). Over the *lit* sensors (``y_i >`` ``threshold``) the
least-squares solution of ``N_L ŝ = y_L`` of minimum norm (pseudo-inverse), normalised; its
norm before normalising is the measured intensity (≈ 1 in sunlight), and an estimate whose
intensity is below ``min_intensity`` (a noise spike lighting a sensor in eclipse) is rejected.
A dark sensor's direction carries no Sun component in this estimate: exact for sensors in
opposite pairs with 90° fields of view (a dark sensor then faces away from the Sun), an error of
at most ``asin(threshold)`` per Sun component below the threshold, and larger where a field of view
narrower than 90° leaves the Sun in front of a sensor that does not see it. No lit sensor:
no estimate (``valid`` False) — eclipse, or a gap in the coverage.

Coverage. :class:`CoarseSunSensors` refuses a set that leaves Sun directions unobservable: normals
that do not span 3-D (the missing axis is named), or directions of the sphere that no sensor
lights at full noise-free output above ``threshold`` (the message gives the uncovered fraction
and representative body directions). ``allow_gaps=True`` accepts such a set on purpose.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from liecontrol._validation import as_array, as_scalar, check_bool, check_positive_scalar
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.sun_acquisition import DirectionMeasurement
from liecontrol.lie import so3

from .orbit import CircularOrbit
from .surface_forces import J2000_JD, in_cylindrical_shadow, sun_position_au

__all__ = [
    "CUBE_NORMALS",
    "CoarseSunSensors",
    "SunPointingReference",
    "SunSensorGyro",
    "estimate_sun_vector",
    "sun_sensor_coverage",
]

#: Six sensors on the faces of a cube (±x, ±y, ±z): full coverage with 90° fields of view.
CUBE_NORMALS: tuple[tuple[float, float, float], ...] = (
    (1.0, 0.0, 0.0),
    (-1.0, 0.0, 0.0),
    (0.0, 1.0, 0.0),
    (0.0, -1.0, 0.0),
    (0.0, 0.0, 1.0),
    (0.0, 0.0, -1.0),
)


def _fibonacci_sphere(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    return np.stack((r * np.cos(phi), r * np.sin(phi), z), axis=-1)


def _check_normals(normals: object) -> np.ndarray:
    N = as_array(normals, "normals")
    if N.ndim != 2 or N.shape[1] != 3 or N.shape[0] < 1:
        raise ValueError(f"normals: expected shape (n, 3) with n ≥ 1, got {N.shape}")
    if N.shape[0] > 1000:
        raise ValueError(f"normals: at most 1000 sensors, got {N.shape[0]}")
    nn = np.linalg.norm(N, axis=1)
    if not np.all(nn > 0.0):
        raise ValueError(f"normals: row {int(np.argmin(nn))} is zero (no direction)")
    return N / nn[:, None]


def sun_sensor_coverage(
    normals: object, fov_half_angle: float = 0.5 * math.pi, threshold: float = 0.03
) -> dict[str, object]:
    """How well the sensors of unit ``normals`` ``(n, 3)`` cover the sphere of Sun directions:
    ``{"span_rank", "null_axes" (rank < 3: unit body axes no normal has a component along),
    "uncovered_fraction" (of 4000 Fibonacci directions lighting no sensor above
    ``threshold``), "uncovered" (up to 4 representative uncovered directions, each the middle
    of a 30° cap of the gap)}``."""
    N = _check_normals(normals)
    fov = _check_fov(fov_half_angle)
    thr = _check_threshold(threshold)
    _, sv, Vt = np.linalg.svd(N)
    rank = int(np.sum(sv > 1e-9 * sv[0]))
    null_axes = [tuple(float(x) for x in np.round(v, 6)) for v in Vt[rank:]]
    D = _fibonacci_sphere(4000)
    c = D @ N.T
    seen = (c > max(thr, math.cos(fov))).any(axis=1)
    miss = D[~seen]
    reps: list[tuple[float, ...]] = []
    left = miss
    while left.shape[0] and len(reps) < 4:
        # the uncovered direction farthest from every lit normal first: the centre of a gap
        c = left[int(np.argmin((left @ N.T).max(axis=1)))]
        for _ in range(5):  # mean shift: to the middle of the gap's cap of 30°
            near = left @ c >= math.cos(math.radians(30.0))
            m = left[near].mean(axis=0)
            c = m / np.linalg.norm(m)
        reps.append(tuple(float(x) for x in np.round(c, 2)))
        left = left[left @ c < math.cos(math.radians(30.0))]
    return {
        "span_rank": rank,
        "null_axes": null_axes,
        "uncovered_fraction": float(miss.shape[0]) / D.shape[0],
        "uncovered": reps,
    }


def _check_fov(fov: object) -> float:
    f = as_scalar(fov, "fov_half_angle")
    if not 0.0 < f <= 0.5 * math.pi:
        raise ValueError(f"fov_half_angle: expected a value in (0, π/2] rad, got {fov!r}")
    return f


def _check_threshold(thr: object) -> float:
    t = as_scalar(thr, "threshold")
    if not 0.0 <= t < 1.0:
        raise ValueError(f"threshold: expected a value in [0, 1) of full scale, got {thr!r}")
    return t


def estimate_sun_vector(
    outputs: object, normals: object, threshold: float = 0.03, min_intensity: float = 0.3
) -> tuple[np.ndarray, np.ndarray]:
    """Sun unit vector in body axes ``(B, 3)`` and ``valid`` ``(B,)`` from sensor ``outputs``
    ``(B, n)`` (or ``(n,)``) of sensors with unit ``normals`` ``(n, 3)``: the minimum-norm
    least-squares solution over the lit sensors (``output > threshold``), normalised (module
    docstring). Rows with no lit sensor, or an intensity below ``min_intensity`` (in [0, 1)):
    ``valid`` False and a zero vector."""
    N = _check_normals(normals)
    y = as_array(outputs, "outputs")
    if y.ndim not in (1, 2) or y.shape[-1] != N.shape[0]:
        raise ValueError(f"outputs: expected shape (B, {N.shape[0]}), got {y.shape}")
    thr = _check_threshold(threshold)
    imin = as_scalar(min_intensity, "min_intensity")
    if not 0.0 <= imin < 1.0:
        raise ValueError(f"min_intensity: expected a value in [0, 1), got {min_intensity!r}")
    y = y.reshape(-1, N.shape[0])
    W = (y > thr).astype(np.float64)
    # pinv(N_Lᵀ N_L) N_Lᵀ y_L = pinv(N_L) y_L: the minimum-norm solution, batched
    A = np.einsum("bi,ij,ik->bjk", W, N, N)
    rhs = np.einsum("bi,bi,ij->bj", W, y, N)
    s = np.einsum("bjk,bk->bj", np.linalg.pinv(A, rcond=1e-9, hermitian=True), rhs)
    ns = np.linalg.norm(s, axis=-1)
    valid = (W.sum(axis=1) > 0) & (ns > 0.0) & (ns >= imin)
    s = np.where(valid[:, None], s / np.where(valid, ns, 1.0)[:, None], 0.0)
    return s, valid


@dataclass(frozen=True)
class CoarseSunSensors:
    """A set of cosine-response Sun sensors (module docstring), sampled every ``period``.

    Args:
        normals: unit normals ``(n, 3)`` in body axes (normalised here; default
            :data:`CUBE_NORMALS`).
        orbit: the :class:`~spacecraft.orbit.CircularOrbit` (the eclipse).
        fov_half_angle: half-angle of each sensor's field of view [rad], in (0, π/2].
        noise_std: white noise σ per sensor, in full-scale units (≥ 0; 0.01 = 1 %).
        threshold: output above which a sensor counts as lit, in [0, 1) (3σ of the default
            noise: a dark sensor lights on noise in ≈ 0.1 % of samples).
        min_intensity: least intensity of a valid estimate, in [0, 1)
            (:func:`estimate_sun_vector`).
        epoch_jd: Julian date at t = 0 (default J2000.0).
        period: sample period [s] (> 0).
        allow_gaps: accept a set that leaves Sun directions unobservable.

    Raises:
        ValueError: ``normals: …`` when the set leaves directions unobservable (which: the
            axes the normals miss, or the uncovered fraction and representative directions),
            unless ``allow_gaps``; other bad values name their argument.
    """

    orbit: CircularOrbit
    normals: object = CUBE_NORMALS
    fov_half_angle: float = 0.5 * math.pi
    noise_std: float = 0.01
    threshold: float = 0.03
    min_intensity: float = 0.3
    epoch_jd: float = J2000_JD
    period: float = 0.5
    allow_gaps: bool = False
    _N: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.orbit, CircularOrbit):
            raise ValueError(f"orbit: expected a CircularOrbit, got {type(self.orbit).__name__}")
        N = _check_normals(self.normals)
        N.setflags(write=False)
        object.__setattr__(self, "_N", N)
        object.__setattr__(self, "normals", tuple(tuple(float(x) for x in r) for r in N))
        object.__setattr__(self, "fov_half_angle", _check_fov(self.fov_half_angle))
        s = as_scalar(self.noise_std, "noise_std")
        if not s >= 0.0:
            raise ValueError(f"noise_std: expected a value ≥ 0, got {self.noise_std!r}")
        object.__setattr__(self, "noise_std", s)
        object.__setattr__(self, "threshold", _check_threshold(self.threshold))
        imin = as_scalar(self.min_intensity, "min_intensity")
        if not 0.0 <= imin < 1.0:
            raise ValueError(
                f"min_intensity: expected a value in [0, 1), got {self.min_intensity!r}"
            )
        object.__setattr__(self, "min_intensity", imin)
        object.__setattr__(self, "epoch_jd", as_scalar(self.epoch_jd, "epoch_jd"))
        object.__setattr__(self, "period", check_positive_scalar(self.period, "period"))
        object.__setattr__(self, "allow_gaps", check_bool(self.allow_gaps, "allow_gaps"))
        if self.allow_gaps:
            return
        cov = sun_sensor_coverage(N, self.fov_half_angle, self.threshold)
        if cov["span_rank"] < 3:
            raise ValueError(
                f"normals: the {N.shape[0]} sensor normals span only {cov['span_rank']} "
                f"dimension(s): the Sun component along {cov['null_axes']} (body axes) is "
                "unobservable"
            )
        if cov["uncovered_fraction"] > 0.0:
            dirs = ", ".join(
                "(" + ", ".join(f"{x:.2f}" for x in d) + ")"
                for d in cov["uncovered"]  # type: ignore[attr-defined]
            )
            raise ValueError(
                f"normals: no sensor is lit for {100 * cov['uncovered_fraction']:.1f} % of Sun "
                f"directions (fov_half_angle {math.degrees(self.fov_half_angle):.3g}°, threshold "
                f"{self.threshold:g}); unobservable around body directions {dirs} "
                "(allow_gaps=True to accept)"
            )

    @property
    def unit_normals(self) -> np.ndarray:
        """``(n, 3)`` unit normals (read-only)."""
        return self._N

    def sun(self, t: float) -> tuple[np.ndarray, bool]:
        """Inertial unit Sun direction ``(3,)`` and whether the spacecraft is in eclipse at
        ``t`` [s]."""
        t = as_scalar(t, "t")
        s = sun_position_au(self.epoch_jd + t / 86400.0)
        s = s / np.linalg.norm(s)
        return s, bool(in_cylindrical_shadow(self.orbit.position(t), s))

    def measure(self, t: float, R: object, omega: object, rng: np.random.Generator) -> np.ndarray:
        """Outputs ``(B, n)`` (full-scale units) at sample time ``t`` for attitudes ``R``
        ``(B, 3, 3)`` (``omega`` unused)."""
        R = as_array(R, "R", (3, 3)).reshape(-1, 3, 3)
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng: expected numpy.random.Generator, got {type(rng).__name__}")
        s_I, dark = self.sun(t)
        y = np.zeros((R.shape[0], self._N.shape[0]))
        if not dark:
            c = np.einsum("bji,j->bi", R, s_I) @ self._N.T
            y = np.where(c > math.cos(self.fov_half_angle) - 1e-15, np.maximum(c, 0.0), 0.0)
        if self.noise_std > 0.0:
            y = np.maximum(y + rng.normal(scale=self.noise_std, size=y.shape), 0.0)
        return y


def _align(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation ``(B, 3, 3)`` of least angle taking unit ``a`` ``(B, 3)`` onto unit ``b``
    (about ``a × b``; antiparallel: a half-turn about an axis ⟂ ``a``)."""
    a = np.broadcast_to(a, np.broadcast_shapes(a.shape, b.shape))
    b = np.broadcast_to(b, a.shape)
    axis = np.cross(a, b)
    s = np.linalg.norm(axis, axis=-1)
    c = np.sum(a * b, axis=-1)
    ang = np.arctan2(s, c)
    # antiparallel (or nearly): any axis ⟂ a
    e = np.where(np.abs(a[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    perp = np.cross(a, e)
    perp /= np.linalg.norm(perp, axis=-1, keepdims=True)
    u = np.where((s > 1e-12)[..., None], axis / np.where(s > 1e-12, s, 1.0)[..., None], perp)
    return so3.exp(u * ang[..., None])


@dataclass(frozen=True)
class SunPointingReference:
    """Reference ``t -> AttitudeReference`` that points ``body_axis`` at the Sun: ``R_d`` is the
    least rotation taking ``b`` to the Sun's inertial direction (its roll about the Sun line is
    arbitrary; :class:`~liecontrol.control.sun_acquisition.SunAcquisitionLaw` ignores it),
    ``ω_d = ω̇_d = 0`` (the Sun moves ≈ 2e-7 rad/s).

    Args:
        sensors: the :class:`CoarseSunSensors` whose ephemeris and epoch are used.
        body_axis: ``(3,)`` body axis to point at the Sun (normalised; non-zero).
    """

    sensors: CoarseSunSensors
    body_axis: object = (0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        if not isinstance(self.sensors, CoarseSunSensors):
            raise ValueError(
                f"sensors: expected CoarseSunSensors, got {type(self.sensors).__name__}"
            )
        b = as_array(self.body_axis, "body_axis")
        nb = float(np.linalg.norm(b)) if b.shape == (3,) else 0.0
        if not nb > 0.0:
            raise ValueError(f"body_axis: expected a non-zero (3,) vector, got {self.body_axis!r}")
        object.__setattr__(self, "body_axis", tuple(float(x) for x in b / nb))

    def __call__(self, t: float) -> AttitudeReference:
        s, _ = self.sensors.sun(t)
        R_d = _align(np.asarray(self.body_axis)[None], s[None])[0]
        return AttitudeReference.unchecked(R_d, np.zeros(3), np.zeros(3))


class SunSensorGyro:
    """Measurement hook for :func:`spacecraft.simulate`: the Sun vector of
    :func:`estimate_sun_vector` from the held outputs of the sensor named ``sun`` and the rate
    from the gyro named ``rate``, as a
    :class:`~liecontrol.control.sun_acquisition.DirectionMeasurement` (no star tracker).

    Its ``R`` is a coarse attitude: the least rotation taking the measured Sun vector onto the
    ephemeris Sun (the roll about the Sun line is unknown to coarse sensors), held while no
    sensor is lit (identity before the first estimate).

    Args:
        sensors: the :class:`CoarseSunSensors` (normals, threshold, ephemeris).
        sun: name of the Sun-sensor set in ``simulate(..., sensors=...)``.
        rate: name of the rate gyro.
    """

    def __init__(self, sensors: CoarseSunSensors, sun: str = "sun", rate: str = "gyro") -> None:
        if not isinstance(sensors, CoarseSunSensors):
            raise ValueError(f"sensors: expected CoarseSunSensors, got {type(sensors).__name__}")
        for name, v in (("sun", sun), ("rate", rate)):
            if not isinstance(v, str) or not v.isidentifier():
                raise ValueError(f"{name}: expected a sensor name (an identifier), got {v!r}")
        self.sensors, self.sun, self.rate = sensors, sun, rate
        self._R: np.ndarray | None = None

    def required(self) -> tuple[str, ...]:
        """Sensor names this hook reads."""
        return (self.sun, self.rate)

    def reset(self, t0: float, batch_size: int) -> None:
        self._R = np.tile(np.eye(3), (int(batch_size), 1, 1))

    def __call__(
        self, t: float, outputs: Mapping[str, np.ndarray], truth: AttitudeState
    ) -> DirectionMeasurement:
        cs = self.sensors
        s_b, valid = estimate_sun_vector(
            outputs[self.sun], cs.unit_normals, cs.threshold, cs.min_intensity
        )
        omega = np.asarray(outputs[self.rate], dtype=np.float64)
        B = omega.shape[0]
        if s_b.shape[0] != B:
            raise ValueError(
                f"outputs: {self.sun!r} has {s_b.shape[0]} rows, {self.rate!r} has {B}"
            )
        if self._R is None or self._R.shape[0] != B:
            self.reset(t, B)
        assert self._R is not None
        if valid.any():
            s_I, _ = cs.sun(t)
            R_new = _align(np.where(valid[:, None], s_b, s_I), np.broadcast_to(s_I, (B, 3)))
            self._R = np.where(valid[:, None, None], R_new, self._R)
        return DirectionMeasurement.unchecked(
            R=self._R.copy(),
            omega=omega,
            h=truth.h,
            actuator_state=truth.actuator_state,
            direction=s_b,
            valid=valid,
        )
