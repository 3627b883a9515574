"""Benchmark scenarios as data (SPEC §8.1): frozen dataclasses, no behaviour beyond conversions.

A :class:`Scenario` fixes the spacecraft (:class:`SpacecraftSpec`), the initial state, the
reference (:class:`ReferenceSpec`), the disturbance (:class:`DisturbanceSpec`), the duration and
the time steps. The runner (:mod:`benchmarks.runner`) turns a scenario into plant objects; every
scenario of a suite sharing spacecraft, disturbance and time grid is simulated in one batch.

The quick suite (:data:`QUICK_SUITE`) uses the seed-000 spacecraft (SPEC §6.1): inertia
``J = [[15053, 3000, −1000], [3000, 6510, 2000], [−1000, 2000, 11122]]`` kg·m², a pyramid of four
SGCMGs with ``h₀ = 300`` N·m·s, β = 54.73°, gimbal-rate limit 1 rad/s, initial gimbal angles
(45°, −45°, 45°, −45°) (zero stored momentum) and seed 000's steering law (pseudo-inverse with
null motion climbing the singularity measure).

- ``stabilisation``: SPEC §8.1 item 1 / §5.4 item 1. Start at the reference attitude at rest,
  hold it against the seed-000 constant + harmonic torque. The attitude is taken relative to the
  orbit frame and that frame is treated as inertial over the run (the orbit rate
  n = 0.0011 rad/s enters through the torque's harmonics only); the Earth-pointing (rotating)
  reference comes with the full catalogue.
- ``slew-90``, ``slew-179``: rest-to-rest manoeuvres of 90° and 179° about the fixed body axis
  ``(1, 1, 1)/√3`` — not a principal axis of this ``J`` (``J (1,1,1)ᵀ = (17053, 11510, 12122)``
  is not parallel to it), so the manoeuvre couples all three axes. Start at ``exp(θ â^)``,
  reference identity, no disturbance (the disturbance case is the stabilisation scenario; here
  the question is large-angle behaviour: settling, path length / unwinding, CMG singularity).

Durations 600 s, plant step 0.1 s, controller period 0.1 s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol._validation import as_array, check_inertia, check_positive, check_rotation_matrix

__all__ = [
    "SEED000_INERTIA",
    "SpacecraftSpec",
    "DisturbanceSpec",
    "ReferenceSpec",
    "Scenario",
    "SEED000_SPACECRAFT",
    "QUICK_SUITE",
    "SUITES",
    "get_suite",
    "rest_to_rest",
]

#: Seed-000 spacecraft inertia [kg·m²] (SPEC §6.1).
SEED000_INERTIA: tuple[tuple[float, float, float], ...] = (
    (15053.0, 3000.0, -1000.0),
    (3000.0, 6510.0, 2000.0),
    (-1000.0, 2000.0, 11122.0),
)

#: Manoeuvre axis of the quick suite: body (1, 1, 1)/√3, not a principal axis of the seed-000 J.
SLEW_AXIS: tuple[float, float, float] = tuple(float(x) for x in np.ones(3) / np.sqrt(3.0))


def _tuple3(x: object, name: str) -> tuple[float, float, float]:
    a = as_array(x, name, (3,))
    if a.shape != (3,):
        raise ValueError(f"{name}: expected shape (3,), got {a.shape}")
    return tuple(float(v) for v in a)


@dataclass(frozen=True)
class SpacecraftSpec:
    """The plant's hardware, as data.

    Attributes:
        name: label for reports.
        inertia: 3×3 inertia [kg·m²] (nested tuples).
        h0: rotor momentum of each SGCMG [N·m·s].
        beta_deg: pyramid skew angle [deg].
        gimbal_rate_limit: per-gimbal rate limit [rad/s].
        delta0_deg: initial gimbal angles [deg].
        steering: steering-law name understood by :func:`benchmarks.runner.build_steering`
            (``"pinv-null-motion"`` = seed 000's law, ``"pinv"``, ``"sr"``).
    """

    name: str = "seed000"
    inertia: tuple[tuple[float, ...], ...] = SEED000_INERTIA
    h0: float = 300.0
    beta_deg: float = 54.73
    gimbal_rate_limit: float = 1.0
    delta0_deg: tuple[float, ...] = (45.0, -45.0, 45.0, -45.0)
    steering: str = "pinv-null-motion"

    def __post_init__(self) -> None:
        J = check_inertia(self.inertia, "inertia")
        if J.shape != (3, 3):
            raise ValueError(f"inertia: expected shape (3, 3), got {J.shape}")
        object.__setattr__(self, "inertia", tuple(tuple(float(v) for v in row) for row in J))
        for name in ("h0", "beta_deg", "gimbal_rate_limit"):
            object.__setattr__(self, name, check_positive(getattr(self, name), name))
        d0 = as_array(self.delta0_deg, "delta0_deg", (4,))
        if d0.shape != (4,):
            raise ValueError(f"delta0_deg: expected shape (4,), got {d0.shape}")
        object.__setattr__(self, "delta0_deg", tuple(float(v) for v in d0))

    @property
    def J(self) -> np.ndarray:
        """Inertia as a ``(3, 3)`` array."""
        return np.array(self.inertia)


@dataclass(frozen=True)
class DisturbanceSpec:
    """External torque model by name: ``"none"`` or ``"seed000"`` (SPEC §5.4 item 1).

    ``params`` are keyword arguments of the model as ``(name, value)`` pairs (kept as a tuple so
    the spec stays hashable), e.g. ``(("scale", 2.0),)``.
    """

    name: str = "none"
    params: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        if self.name not in ("none", "seed000"):
            raise ValueError(f"name: unknown disturbance {self.name!r} (known: 'none', 'seed000')")
        object.__setattr__(self, "params", tuple((str(k), float(v)) for k, v in self.params))


@dataclass(frozen=True)
class ReferenceSpec:
    """A constant desired attitude ``R_d = exp(rotvec^)`` (regulation; rest-to-rest).

    Tracking references join in the full catalogue (``kind`` distinguishes them).
    """

    kind: str = "constant"
    rotvec: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if self.kind != "constant":
            raise ValueError(f"kind: unknown reference kind {self.kind!r} (known: 'constant')")
        object.__setattr__(self, "rotvec", _tuple3(self.rotvec, "rotvec"))

    @property
    def R_d(self) -> np.ndarray:
        return Rotation.from_rotvec(self.rotvec).as_matrix()


@dataclass(frozen=True)
class Scenario:
    """One benchmark case.

    Attributes:
        name: unique identifier (used in file names).
        description: one line for the report.
        spacecraft: the plant hardware.
        initial_rotvec: initial attitude as a rotation vector [rad] (body → inertial); use
            :meth:`from_matrix` to give a matrix.
        initial_rate: initial body rate [rad/s].
        reference: desired attitude.
        disturbance: external torque.
        duration: simulated time [s].
        dt: plant integration step [s].
        control_period: controller sampling period [s] (``None``: every step).
        tags: free labels (e.g. ``"large-angle"``) for selecting metrics in reports.
    """

    name: str
    description: str
    spacecraft: SpacecraftSpec = field(default_factory=SpacecraftSpec)
    initial_rotvec: tuple[float, float, float] = (0.0, 0.0, 0.0)
    initial_rate: tuple[float, float, float] = (0.0, 0.0, 0.0)
    reference: ReferenceSpec = field(default_factory=ReferenceSpec)
    disturbance: DisturbanceSpec = field(default_factory=DisturbanceSpec)
    duration: float = 600.0
    dt: float = 0.1
    control_period: float | None = 0.1
    tags: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.name or any(c in self.name for c in "/\\ "):
            raise ValueError(
                f"name: must be non-empty without spaces or slashes, got {self.name!r}"
            )
        object.__setattr__(self, "initial_rotvec", _tuple3(self.initial_rotvec, "initial_rotvec"))
        object.__setattr__(self, "initial_rate", _tuple3(self.initial_rate, "initial_rate"))
        object.__setattr__(self, "duration", check_positive(self.duration, "duration"))
        object.__setattr__(self, "dt", check_positive(self.dt, "dt"))
        if self.control_period is not None:
            cp = check_positive(self.control_period, "control_period")
            if cp < self.dt * (1 - 1e-9):
                raise ValueError(
                    f"control_period: {cp} is shorter than the plant step dt={self.dt}"
                )
            object.__setattr__(self, "control_period", cp)
        object.__setattr__(self, "tags", tuple(str(t) for t in self.tags))

    @classmethod
    def from_matrix(cls, name: str, description: str, R0: object, **kw: object) -> Scenario:
        """Build a scenario whose initial attitude is given as a rotation matrix."""
        R = check_rotation_matrix(R0, "R0")
        if R.shape != (3, 3):
            raise ValueError(f"R0: expected shape (3, 3), got {R.shape}")
        rv = Rotation.from_matrix(R).as_rotvec()
        return cls(name=name, description=description, initial_rotvec=tuple(rv), **kw)

    @property
    def R0(self) -> np.ndarray:
        """Initial attitude matrix ``(3, 3)``."""
        return Rotation.from_rotvec(self.initial_rotvec).as_matrix()

    @property
    def omega0(self) -> np.ndarray:
        return np.array(self.initial_rate)

    @property
    def initial_error_deg(self) -> float:
        """Geodesic angle between the initial and the desired attitude [deg]."""
        E = self.reference.R_d.T @ self.R0
        return float(np.rad2deg(Rotation.from_matrix(E).magnitude()))

    def with_duration(self, duration: float) -> Scenario:
        """The same scenario over another horizon (tests, quick looks)."""
        return dataclasses.replace(self, duration=duration)

    def batch_key(self) -> tuple:
        """Scenarios with equal keys can be simulated in one batch (same plant and time grid)."""
        return (self.spacecraft, self.disturbance, self.duration, self.dt, self.control_period)


def rest_to_rest(
    angle_deg: float,
    axis: tuple[float, float, float] = SLEW_AXIS,
    *,
    name: str | None = None,
    **kw: object,
) -> Scenario:
    """Rest-to-rest manoeuvre: start at ``exp(θ â^)``, at rest, reference identity."""
    a = np.asarray(_tuple3(axis, "axis"))
    n = np.linalg.norm(a)
    if n == 0:
        raise ValueError("axis: must be non-zero")
    rv = np.deg2rad(angle_deg) * a / n
    axis_txt = "(" + ", ".join(f"{v:.3g}" for v in a / n) + ")"
    return Scenario(
        name=name or f"slew-{angle_deg:g}",
        description=f"rest-to-rest {angle_deg:g}° about body axis {axis_txt}, no disturbance",
        initial_rotvec=tuple(rv),
        tags=("manoeuvre",),
        **kw,
    )


SEED000_SPACECRAFT = SpacecraftSpec()

#: SPEC §8.1 subset run by ``python -m benchmarks run --suite quick``.
QUICK_SUITE: tuple[Scenario, ...] = (
    Scenario(
        name="stabilisation",
        description="hold the orbit-frame attitude against the seed-000 disturbance (SPEC §5.4)",
        disturbance=DisturbanceSpec("seed000"),
        tags=("stabilisation",),
    ),
    rest_to_rest(90.0),
    rest_to_rest(179.0),
)

#: Suites by name.
SUITES: dict[str, tuple[Scenario, ...]] = {"quick": QUICK_SUITE}


def get_suite(name: str) -> tuple[Scenario, ...]:
    """The scenarios of suite ``name``; unknown names raise a ``ValueError`` listing the valid."""
    try:
        return SUITES[name]
    except KeyError:
        raise ValueError(
            f"suite: unknown suite {name!r}; valid suites: {', '.join(sorted(SUITES))}"
        ) from None
