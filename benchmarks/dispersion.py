"""Dispersed scenarios: what varies from one flight to the next, as a seeded model.

A scenario's single run answers "does this controller meet the requirements from *this* start on
*this* spacecraft?". A requirement is met by a design only when it holds over the spread of
conditions the spacecraft will meet: initial attitude and rate after the previous mode,
inertia known to a few percent with its principal axes to a degree or two, CMG rotor momentum
and pyramid geometry, disturbance amplitude, sensor noise. :class:`DispersionSpec` models that
spread; :func:`member_scenario` draws member ``k`` of a cell as an ordinary
:class:`~benchmarks.scenarios.Scenario`:

- member 0 is the nominal scenario itself (its run is bit-identical to the single run);
- member ``k ≥ 1`` is drawn from ``numpy.random.default_rng(SeedSequence((seed, crc32(name),
  k)))`` — independent of the number of members, of the executor and of the other scenarios,
  so the same seed gives the same member everywhere.

Each key is a one-sigma (Gaussian) spread, 0 meaning "not dispersed":

=======================  ==========================================================================
key                      member ``k`` draws
=======================  ==========================================================================
``attitude_angle_deg``   the initial error angle θ₀ + N(0, σ²) (kept in [0°, 179.9°]; a start at
                         rest on the target gets a uniformly random axis)
``attitude_axis_deg``    the initial error axis tilted by N(0, σ²) about a uniformly random
                         perpendicular
``rate_deg_s``           the initial body-rate error + N(0, σ² I₃) [deg/s]
``inertia_moments``      each principal second moment of mass P_i = ∫x_i²dm × (1 + N(0, σ²)),
                         so the true moments J_i = P_j + P_k stay physical (the controllers
                         keep the nominal inertia: this is a model error)
``inertia_axes_deg``     the true principal axes rotated by exp(ξ^), ξ ~ N(0, σ² I₃) [deg]
``cmg_h0``               the SGCMG rotor momentum h₀ × (1 + N(0, σ²))
``cmg_beta_deg``         the pyramid skew angle β + N(0, σ²) [deg]
``disturbance_scale``    every disturbance's amplitude × (1 + N(0, σ²)) (constant-harmonic,
                         rotating-payload, constant, residual-dipole; aerodynamic through its
                         density; gravity gradient follows the true inertia)
``position_m``           SE(3): the chaser's initial relative position + N(0, σ² I₃) [m]
=======================  ==========================================================================

``sensor_seeds`` (default true) gives each member its own sensor-noise seed (member 0 keeps the
scenario's). The CMG keys describe the *as-built* hardware that the steering law is calibrated
to (the law sees the drawn h₀ and β); an uncalibrated misalignment, which the steering would not
know, is not modelled.

Detumble scenarios (``scenario.detumble``) start at the identity attitude from a separation
tumble, so the attitude keys and ``rate_deg_s`` do not apply there: member ``k ≥ 1`` draws a new
tumble instead — a uniformly random axis and a rate uniform in the spec's ``rate_range_deg_s`` —
with the inertia keys as above and its own magnetometer/gyro noise seed (``sensor_seeds``);
:func:`detumble_dispersion_note` says so for the report.

Sun-acquisition scenarios (``scenario.sun_acquisition``) start from a tumble at an arbitrary
attitude, so member ``k ≥ 1`` draws a new start rather than a spread about the nominal one: a
uniformly random (Haar) attitude and a tumble about a uniformly random axis at a rate uniform
in the spec's ``rate_range_deg_s`` — the starts of :mod:`benchmarks.safe_mode` — with the
inertia keys as above and its own Sun-sensor/gyro noise seed (``sensor_seeds``); the attitude
keys and ``rate_deg_s`` do not apply (:func:`sun_acquisition_dispersion_note`).

A draw that makes the plant unphysical (a non-positive moment or one that breaks the triangle
inequality, a skew angle outside (0°, 90°), a non-positive h₀) raises ``ValueError`` naming the
key and the member: such a spread is too wide for the hardware it describes.
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol._validation import as_int

from .requirements import requirements_of

__all__ = [
    "DispersionSpec",
    "DEFAULT_DISPERSION",
    "DISPERSION_KEYS",
    "MAX_MEMBERS",
    "member_scenario",
    "member_scenarios",
    "detumble_dispersion_note",
    "sun_acquisition_dispersion_note",
]

#: The float keys of :class:`DispersionSpec` (one-sigma spreads, ≥ 0), in table order.
DISPERSION_KEYS: tuple[str, ...] = (
    "attitude_angle_deg",
    "attitude_axis_deg",
    "rate_deg_s",
    "inertia_moments",
    "inertia_axes_deg",
    "cmg_h0",
    "cmg_beta_deg",
    "disturbance_scale",
    "position_m",
)

#: The largest number of members a cell may have (a guard against a mistyped count).
MAX_MEMBERS = 100_000
#: Disturbance parameters that scale its amplitude, by disturbance name.
_AMPLITUDE_PARAMS: dict[str, tuple[str, ...]] = {
    "constant-harmonic": ("scale",),
    "rotating-payload": ("scale",),
    "constant": ("x", "y", "z"),
    "residual-dipole": ("x", "y", "z"),
    "aerodynamic": ("density_scale",),
}
#: The defaults of the amplitude parameters when a spec leaves them out.
_AMPLITUDE_DEFAULTS: dict[str, float] = {"scale": 1.0, "density_scale": 1.0}
_MAX_ANGLE = math.radians(179.9)


@dataclass(frozen=True)
class DispersionSpec:
    """One-sigma spreads of a scenario's members (module docstring: what each key draws).

    Attributes:
        attitude_angle_deg: spread of the initial error angle [deg].
        attitude_axis_deg: spread of the initial error axis' tilt [deg].
        rate_deg_s: spread of each initial body-rate component [deg/s].
        inertia_moments: relative spread of each principal second moment of mass.
        inertia_axes_deg: spread of the principal axes' rotation [deg].
        cmg_h0: relative spread of the SGCMG rotor momentum.
        cmg_beta_deg: spread of the pyramid skew angle [deg].
        disturbance_scale: relative spread of every disturbance's amplitude.
        position_m: SE(3): spread of each initial relative position component [m].
        sensor_seeds: each member ``k ≥ 1`` gets its own sensor-noise seed.
        seed: the dispersion's seed (with the scenario's name and the member index).

    Every spread is ≥ 0 (0: that quantity is not dispersed).
    """

    attitude_angle_deg: float = 0.0
    attitude_axis_deg: float = 0.0
    rate_deg_s: float = 0.0
    inertia_moments: float = 0.0
    inertia_axes_deg: float = 0.0
    cmg_h0: float = 0.0
    cmg_beta_deg: float = 0.0
    disturbance_scale: float = 0.0
    position_m: float = 0.0
    sensor_seeds: bool = True
    seed: int = 0

    def __post_init__(self) -> None:
        for key in DISPERSION_KEYS:
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise TypeError(f"{key}: expected a number (a one-sigma spread), got {v!r}")
            v = float(v)
            if not math.isfinite(v) or v < 0.0:
                raise ValueError(f"{key}: must be a finite spread >= 0, got {v!r}")
            object.__setattr__(self, key, v)
        if not isinstance(self.sensor_seeds, (bool, np.bool_)):
            raise TypeError(f"sensor_seeds: expected a bool, got {self.sensor_seeds!r}")
        object.__setattr__(self, "sensor_seeds", bool(self.sensor_seeds))
        object.__setattr__(self, "seed", as_int(self.seed, "seed", 0))

    @property
    def is_zero(self) -> bool:
        """No key spreads anything (members then differ at most by their sensor noise)."""
        return all(getattr(self, k) == 0.0 for k in DISPERSION_KEYS)

    def rng(self, scenario_name: str, member: int) -> np.random.Generator:
        """The generator of ``member`` of ``scenario_name`` (independent of everything else)."""
        key = zlib.crc32(scenario_name.encode())
        return np.random.default_rng(np.random.SeedSequence((self.seed, key, int(member))))


#: The spread of a scenario that states none: a few degrees of initial attitude, a few
#: thousandths of a degree per second of residual rate (what a rate-damping mode leaves), ±5 %
#: second moments of mass with the principal axes known to 2°, and ±5 m of relative position on
#: SE(3) — what the members of one batch can differ in (per-spacecraft state and inertia).
#: CMG hardware and disturbance amplitude stay nominal: such a draw changes the plant and needs a
#: simulation of its own per member (8× the quick suite's cost); scenarios that need them state
#: them (``agile-slew-uncertain``).
DEFAULT_DISPERSION = DispersionSpec(
    attitude_angle_deg=2.0,
    attitude_axis_deg=5.0,
    rate_deg_s=0.005,
    inertia_moments=0.05,
    inertia_axes_deg=2.0,
    position_m=5.0,
)


def _tilt(axis: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``axis`` rotated by N(0, σ²) about a uniformly random perpendicular."""
    a = rng.standard_normal(3)
    perp = a - (a @ axis) * axis
    perp /= np.linalg.norm(perp)
    angle = sigma * rng.standard_normal()
    return Rotation.from_rotvec(angle * perp).apply(axis)


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


def _initial_rotvec(rv0: np.ndarray, d: DispersionSpec, rng: np.random.Generator) -> np.ndarray:
    theta0 = float(np.linalg.norm(rv0))
    axis = rv0 / theta0 if theta0 > 0 else _unit(rng)
    if d.attitude_axis_deg > 0:
        axis = _tilt(axis, math.radians(d.attitude_axis_deg), rng)
    theta = theta0
    if d.attitude_angle_deg > 0:
        theta = abs(theta0 + math.radians(d.attitude_angle_deg) * rng.standard_normal())
    return min(theta, _MAX_ANGLE) * axis


def _true_inertia(J: np.ndarray, d: DispersionSpec, k: int, rng: np.random.Generator):
    from liecontrol._validation import check_inertia

    moments, axes = np.linalg.eigh(J)
    if d.inertia_moments > 0:
        # the second moments of mass P_i = ∫x_i² dm = (J_j + J_k − J_i)/2 are what a mass
        # budget error changes; any positive P gives a physical J_i = P_j + P_k
        P = 0.5 * (moments.sum() - 2.0 * moments)
        P = P * (1.0 + d.inertia_moments * rng.standard_normal(3))
        if P.min() < 0:
            raise ValueError(
                f"inertia_moments: spread {d.inertia_moments} drew second moments of mass "
                f"{np.round(P, 6).tolist()} for member {k}; a negative one is no rigid body "
                "(each principal moment must be > 0 and at most the sum of the other two)"
            )
        moments = P.sum() - P
    if d.inertia_axes_deg > 0:
        axes = (
            Rotation.from_rotvec(
                math.radians(d.inertia_axes_deg) * rng.standard_normal(3)
            ).as_matrix()
            @ axes
        )
    J_true = axes @ np.diag(moments) @ axes.T
    J_true = 0.5 * (J_true + J_true.T)
    check_inertia(J_true, "inertia_moments")
    return tuple(tuple(float(x) for x in row) for row in J_true)


def _scaled_disturbances(specs: tuple, scale: float) -> tuple:
    out = []
    for s in specs:
        keys = _AMPLITUDE_PARAMS.get(s.name, ())
        if not keys:
            out.append(s)
            continue
        kw = s.kwargs
        if s.name in ("constant", "residual-dipole") and not any(k in kw for k in keys):
            kw = {"x": 1.0, "y": 0.0, "z": 0.0} if s.name == "residual-dipole" else kw
        for k in keys:
            if k in kw or k in _AMPLITUDE_DEFAULTS:
                kw[k] = kw.get(k, _AMPLITUDE_DEFAULTS.get(k, 0.0)) * scale
        out.append(dataclasses.replace(s, params=tuple(kw.items())))
    return tuple(out)


def member_scenario(scenario: Any, member: int, dispersion: DispersionSpec | None = None) -> Any:
    """Member ``member`` of ``scenario``'s dispersed cell (``dispersion`` defaults to the
    scenario's own :attr:`~benchmarks.scenarios.Scenario.dispersion`, else no spread).

    Member 0 is ``scenario`` itself. A member ``k ≥ 1`` is the scenario with its draw applied
    and :attr:`~benchmarks.scenarios.Scenario.member` set to ``k``.
    """
    if not dataclasses.is_dataclass(scenario) or not hasattr(scenario, "batch_key"):
        raise TypeError(f"scenario: expected a Scenario, got {type(scenario).__name__}")
    k = as_int(member, "member", 0)
    d = scenario.dispersion if dispersion is None else dispersion
    if d is None:
        d = DispersionSpec()
    if not isinstance(d, DispersionSpec):
        raise TypeError(f"dispersion: expected a DispersionSpec, got {type(d).__name__}")
    if k == 0:
        return scenario
    rng = d.rng(scenario.name, k)
    # a member is judged on the nominal scenario's requirements (a drawn start of a pointing
    # scenario may be a degree off, which would make the defaults those of a manoeuvre)
    kw: dict[str, Any] = {"member": k, "requirements": requirements_of(scenario)}
    px = scenario.proximity
    det = getattr(scenario, "detumble", None)
    sa = getattr(scenario, "sun_acquisition", None)
    if sa is not None:
        q = rng.standard_normal(4)
        # a normalised Gaussian 4-vector is a Haar-uniform unit quaternion
        kw["initial_rotvec"] = tuple(Rotation.from_quat(q / np.linalg.norm(q)).as_rotvec())
        lo, hi = sa.rate_range_deg_s
        kw["initial_rate"] = tuple(_unit(rng) * math.radians(rng.uniform(lo, hi)))
        if d.inertia_moments > 0 or d.inertia_axes_deg > 0:
            kw["member_inertia"] = _true_inertia(np.asarray(scenario.true_inertia), d, k, rng)
        if d.sensor_seeds:
            seed = int(rng.integers(0, 2**31 - 1))
            kw["sun_acquisition"] = dataclasses.replace(sa, seed=seed)
    elif det is not None:
        lo, hi = det.rate_range_deg_s
        axis = _unit(rng)
        kw["initial_rate"] = tuple(axis * math.radians(rng.uniform(lo, hi)))
        if d.inertia_moments > 0 or d.inertia_axes_deg > 0:
            kw["member_inertia"] = _true_inertia(np.asarray(scenario.true_inertia), d, k, rng)
        if d.sensor_seeds:
            seed = int(rng.integers(0, 2**31 - 1))
            kw["detumble"] = dataclasses.replace(det, seed=seed)
    elif px is not None:
        rv = _initial_rotvec(np.array(px.initial_rotvec), d, rng)
        pos = np.array(px.initial_position) + d.position_m * rng.standard_normal(3)
        kw["proximity"] = dataclasses.replace(
            px, initial_rotvec=tuple(rv), initial_position=tuple(pos)
        )
    else:
        kw["initial_rotvec"] = tuple(_initial_rotvec(np.array(scenario.initial_rotvec), d, rng))
        rate = np.array(scenario.initial_rate) + math.radians(d.rate_deg_s) * rng.standard_normal(3)
        kw["initial_rate"] = tuple(rate)
        if d.inertia_moments > 0 or d.inertia_axes_deg > 0:
            kw["member_inertia"] = _true_inertia(np.asarray(scenario.true_inertia), d, k, rng)
        sp = scenario.spacecraft
        if sp.actuator == "sgcmg" and (d.cmg_h0 > 0 or d.cmg_beta_deg > 0):
            h0 = sp.h0 * (1.0 + d.cmg_h0 * rng.standard_normal())
            beta = sp.beta_deg + d.cmg_beta_deg * rng.standard_normal()
            if h0 <= 0:
                raise ValueError(f"cmg_h0: spread {d.cmg_h0} drew h0 = {h0:g} for member {k}")
            if not 0.0 < beta < 90.0:
                raise ValueError(
                    f"cmg_beta_deg: spread {d.cmg_beta_deg} drew β = {beta:g}° for member {k}"
                )
            kw["spacecraft"] = dataclasses.replace(sp, h0=h0, beta_deg=beta)
        if d.disturbance_scale > 0 and scenario.disturbances:
            s = 1.0 + d.disturbance_scale * rng.standard_normal()
            kw["disturbances"] = _scaled_disturbances(scenario.disturbances, s)
        if scenario.sensors is not None and d.sensor_seeds:
            seed = int(rng.integers(0, 2**31 - 1))
            kw["sensors"] = dataclasses.replace(scenario.sensors, seed=seed)
    return dataclasses.replace(scenario, **kw)


def _note_args(scenario: Any, dispersion: Any) -> DispersionSpec:
    """The spread a dispersion note describes (``dispersion``, else the scenario's, else
    none), after checking the arguments."""
    if not dataclasses.is_dataclass(scenario) or not hasattr(scenario, "batch_key"):
        raise TypeError(f"scenario: expected a Scenario, got {type(scenario).__name__}")
    if dispersion is not None and not isinstance(dispersion, DispersionSpec):
        raise TypeError(f"dispersion: expected a DispersionSpec, got {type(dispersion).__name__}")
    return dispersion or getattr(scenario, "dispersion", None) or DispersionSpec()


def detumble_dispersion_note(scenario: Any, dispersion: DispersionSpec | None = None) -> str:
    """What the members of a detumble scenario draw (``""`` for any other scenario): the text
    the report shows instead of the attitude keys, which do not apply there."""
    d = _note_args(scenario, dispersion)
    det = getattr(scenario, "detumble", None)
    if det is None:
        return ""
    lo, hi = det.rate_range_deg_s
    parts = [f"tumble: uniform random axis, rate uniform in [{lo:g}, {hi:g}] deg/s"]
    kept = ("inertia_moments", "inertia_axes_deg")
    parts += [f"{key} {getattr(d, key):g}" for key in kept if getattr(d, key) > 0]
    if d.sensor_seeds:
        parts.append("own magnetometer/gyro noise seed")
    skipped = [key for key in DISPERSION_KEYS if getattr(d, key) > 0 and key not in kept]
    note = ", ".join(parts)
    if skipped:
        note += (f" ({', '.join(skipped)} do not apply: a detumble starts at the identity "
                 "attitude from its drawn tumble)")  # fmt: skip
    return note


def sun_acquisition_dispersion_note(
    scenario: Any, dispersion: DispersionSpec | None = None
) -> str:
    """What the members of a Sun-acquisition scenario draw (``""`` for any other scenario):
    the text the report shows instead of the attitude keys, which do not apply there."""
    d = _note_args(scenario, dispersion)
    sa = getattr(scenario, "sun_acquisition", None)
    if sa is None:
        return ""
    lo, hi = sa.rate_range_deg_s
    parts = [
        f"new start: uniformly random attitude, tumble about a uniform random axis at a rate "
        f"uniform in [{lo:g}, {hi:g}] deg/s"
    ]
    kept = ("inertia_moments", "inertia_axes_deg")
    parts += [f"{key} {getattr(d, key):g}" for key in kept if getattr(d, key) > 0]
    if d.sensor_seeds:
        parts.append("own Sun-sensor/gyro noise seed")
    skipped = [key for key in DISPERSION_KEYS if getattr(d, key) > 0 and key not in kept]
    note = ", ".join(parts)
    if skipped:
        note += (f" ({', '.join(skipped)} do not apply: a safe-mode start is drawn whole, not "
                 "spread about the nominal one)")  # fmt: skip
    return note


def member_scenarios(scenario: Any, n: int, dispersion: DispersionSpec | None = None) -> list:
    """Members ``0 … n−1`` of ``scenario`` (:func:`member_scenario`); ``n ≥ 1``."""
    n = as_int(n, "n", 1)
    if n > MAX_MEMBERS:
        raise ValueError(f"n: at most {MAX_MEMBERS} members, got {n}")
    return [member_scenario(scenario, k, dispersion) for k in range(n)]
