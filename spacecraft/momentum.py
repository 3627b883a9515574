"""Momentum management: magnetorquers with cross-product dumping, and momentum-envelope fractions.

Magnetorquers. Three rods along the body axes, each with a dipole limit |mᵢ| ≤ m_max,i [A·m²],
produce the body torque τ_m = m × B (B the geomagnetic field in body axes, :mod:`spacecraft.
geomagnetic`), always perpendicular to B: a magnetorquer cannot act along the field.

Cross-product law. With Δh = h − h_target (stored actuator momentum minus its target, body axes)

    m = k (Δh × B)/‖B‖²,   so   τ_m = m × B = −k (Δh − (Δh·B̂) B̂) = −k Δh⊥,

the external torque removes the part of Δh perpendicular to B at the rate k [1/s]; the parallel
part is dumped later, as B turns along the orbit (Sidi, *Spacecraft Dynamics and Control*,
Cambridge 1997, ch. 7; Markley & Crassidis, *Fundamentals of Spacecraft Attitude Determination
and Control*, Springer 2014, ch. 7). (Written with Δh = h_target − h the same law reads
m = k (B × Δh)/‖B‖².) The attitude controller keeps the attitude, so it moves the momentum the
external torque removes out of the actuator: the stored momentum follows ḣ ≈ τ_d − k Δh⊥.
Saturation: when a rod would exceed its limit the whole dipole is scaled by the same factor
s = min(1, minᵢ m_max,i/|mᵢ|), which keeps its direction (and the torque ⟂ B).

The law runs inside the plant (:class:`spacecraft.plant.Spacecraft` ``momentum_management``):
the dipole is computed from the state at the start of each integration step and held over it,
as magnetorquer electronics hold a commanded current; the torque m × B(t, R) is re-evaluated at
every integration stage with the stage's time and attitude. The controller's torque still goes
to the primary actuator (CMGs or wheels).

Gain. k = ``gain`` [1/s] is the inverse time constant of the dumping of Δh⊥. The default
1e-3 s⁻¹ (a 1000 s time constant, ≈ 1/6 of a 95-min orbit) dumps within an orbit without
fighting the attitude loop (bandwidth ≫ 1e-3 rad/s); the dipole saturates whenever
k‖Δh‖/‖B‖ > m_max.

Envelope fractions (:func:`momentum_fraction`): stored momentum over the actuator's capacity.
For a single-gimbal CMG cluster (the SGCMG pyramid) each unit's momentum turns in the plane
normal to its gimbal axis gᵢ, so the most momentum the cluster can store along a unit direction
d is σ(d) = max_δ d·h(δ) = h₀ Σᵢ √(1 − (d·gᵢ)²) (each unit's momentum turned as far along d as
its plane allows; the support function of the momentum envelope). The fraction is ‖h‖/σ(ĥ), the
envelope in the momentum direction. The envelope's true radius along d is at most σ(d): for the
isotropic pyramid (radius found by constrained optimisation over the gimbal angles, 8 sampled
directions) the two agree to 0.2 % when d is more than ~35° from every gimbal axis, and σ is
2.6 % larger at 22°, 4.6 % at 15° and 6.2 % at 12° from one, where the fraction reads low by as
much. For reaction wheels, maxᵢ |Ωᵢ|/Ω_max,i — the fraction of the
wheel nearest its speed limit (the exact gauge of h in the momentum box for three orthogonal
wheels).

Feasibility (:func:`magnetic_dumping_feasibility`, :func:`check_dumping_feasibility`). A
magnetorquer acts only perpendicular to B, so whether it can hold a disturbance is a property of
the orbit, the attitude profile and the rods — checked before the run. Over ``n_orbits`` (the
field turns with the Earth, so one orbit is not the period), with the attitude ``R(t)`` the
controller holds, the secular disturbance is the inertial mean ``T̄ = ⟨R T_d⟩``; the stored
momentum stays bounded only if the magnetic torque's inertial mean can be ``−T̄``. Along any
unit direction ``d`` the rods (box ``|m_b,i| ≤ m_max,i`` in body axes) give at most
``cap(d) = ⟨Σᵢ m_max,i |(Rᵀ(B × d))ᵢ|⟩`` (maximise ``dᵀ(R m_b × B) = m_bᵀRᵀ(B × d)`` at each
instant), so ``cap(d) ≥ dᵀ(−T̄)`` for every ``d`` is **necessary**; ``authority_ratio =
min_d cap(d)/dᵀ(−T̄)`` (over a sphere of directions) below 1 means the momentum grows along
that ``d`` at least at ``dᵀ(−T̄) − cap(d)``: dumping fails, whatever the law. **Sufficient**
(for an ideal law): the constant inertial demand ``v = −⟨P⊥⟩⁻¹T̄`` (``P⊥ = I − B̂B̂ᵀ``) realised
by ``m = B × v/‖B‖²`` has ``⟨m × B⟩ = −T̄``; ``dipole_ratio = m_max / max_t |m_b,i|``. Between
the two the outcome depends on the law. Assumptions: the attitude follows the given profile
(the attitude loop holds it), the disturbance model is the one given, the tilted-dipole field.
The cross-product law's gain ``k`` and the CMG momentum capacity (which must hold the cyclic
part, reported as ``cyclic_momentum``) are not part of the necessary test. At low inclination
the field lies close to the orbit normal, along which an Earth-pointing spacecraft's dominant
secular torque then acts — the classic infeasible case.

After a run, :func:`momentum_growth_per_orbit` measures the secular growth of the stored
momentum (or its envelope fraction) from orbit means; a positive growth flags dumping that does
not keep up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from dataclasses import field as _dc_field

import numpy as np

from liecontrol._array_api import namespace, safe_sqrt
from liecontrol._validation import as_array, check_positive, check_positive_scalar

from .geomagnetic import TiltedDipoleField
from .orbit import CircularOrbit

__all__ = [
    "Magnetorquers",
    "CrossProductDumping",
    "sgcmg_momentum_capacity",
    "momentum_fraction",
    "DumpingFeasibility",
    "DumpingInfeasibleWarning",
    "magnetic_dumping_feasibility",
    "check_dumping_feasibility",
    "momentum_growth_per_orbit",
]


@dataclass(frozen=True)
class Magnetorquers:
    """Three magnetic torque rods along the body axes.

    Args:
        max_dipole: dipole limit per rod m_max [A·m²] (> 0), scalar or ``(3,)``.
    """

    max_dipole: float | np.ndarray = 200.0

    def __post_init__(self) -> None:
        m = np.asarray(check_positive(self.max_dipole, "max_dipole"), dtype=np.float64)
        if m.shape not in ((), (3,)):
            raise ValueError(f"max_dipole: expected a scalar or shape (3,), got {m.shape}")
        m = np.broadcast_to(m, (3,)).copy()
        m.setflags(write=False)
        object.__setattr__(self, "max_dipole", m)

    def saturate(self, m: object) -> np.ndarray:
        """``m`` ``(..., 3)`` scaled by min(1, minᵢ m_max,i/|mᵢ|): within every rod's limit, same
        direction."""
        m = as_array(m, "m", (3,))
        return self._saturate(m)

    def _saturate(self, m: np.ndarray) -> np.ndarray:
        ratio = (np.abs(m) / self.max_dipole).max(axis=-1, keepdims=True)
        return m / np.maximum(ratio, 1.0)

    @staticmethod
    def torque(m: object, B: object) -> np.ndarray:
        """Body torque m × B [N·m] of dipole ``m`` [A·m²] in field ``B`` [T], ``(..., 3)``."""
        return np.cross(as_array(m, "m", (3,)), as_array(B, "B", (3,)))


@dataclass(frozen=True)
class CrossProductDumping:
    """Cross-product momentum dumping with magnetorquers (see the module docstring).

    m = sat(k (Δh × B)/‖B‖²),  Δh = h − h_target,  τ_m = m × B.

    Args:
        orbit: the :class:`spacecraft.orbit.CircularOrbit` giving the position r(t).
        field: the geomagnetic field model (default :class:`~spacecraft.geomagnetic.
            TiltedDipoleField`, IGRF-13 2020.0 dipole).
        magnetorquers: the rods (default 200 A·m² per rod).
        gain: k [1/s] (> 0).
        h_target: target stored momentum ``(3,)`` [N·m·s] in body axes (default zero).
        attitude: the attitude profile the controller will hold (a callable ``t ->
            AttitudeReference`` such as :class:`spacecraft.orbit.EarthPointingReference`,
            ``t -> (3, 3)``, or a constant ``(3, 3)``), or ``None``. When given,
            :class:`spacecraft.plant.Spacecraft` runs :meth:`preflight` with its disturbance when
            it is built: a :class:`DumpingInfeasibleWarning` before the run if the rods cannot
            hold the secular disturbance (:func:`magnetic_dumping_feasibility`).
    """

    orbit: CircularOrbit
    field: TiltedDipoleField = _dc_field(default_factory=TiltedDipoleField)
    magnetorquers: Magnetorquers = _dc_field(default_factory=Magnetorquers)
    gain: float = 1e-3
    h_target: np.ndarray | None = None
    # inertial field by time: the RK stages evaluate t, t + h/2 (twice) and t + h, and the next
    # step starts at t + h (a per-instance memo of a pure function of t, bounded below)
    _memo: dict = _dc_field(init=False, repr=False, compare=False, default_factory=dict)
    attitude: object = _dc_field(default=None, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.orbit, CircularOrbit):
            raise ValueError(f"orbit: expected a CircularOrbit, got {type(self.orbit).__name__}")
        if not isinstance(self.field, TiltedDipoleField):
            raise ValueError(
                f"field: expected a TiltedDipoleField, got {type(self.field).__name__}"
            )
        if not isinstance(self.magnetorquers, Magnetorquers):
            raise ValueError(
                f"magnetorquers: expected Magnetorquers, got {type(self.magnetorquers).__name__}"
            )
        object.__setattr__(self, "gain", check_positive_scalar(self.gain, "gain"))
        ht = np.zeros(3) if self.h_target is None else as_array(self.h_target, "h_target")
        if ht.shape != (3,):
            raise ValueError(f"h_target: expected shape (3,), got {ht.shape}")
        ht = ht.copy()
        ht.setflags(write=False)
        object.__setattr__(self, "h_target", ht)
        a = self.attitude
        if a is not None and not callable(a):
            from liecontrol._validation import check_rotation_matrix

            R = check_rotation_matrix(a, "attitude")
            if R.shape != (3, 3):
                raise ValueError(
                    f"attitude: expected a callable t -> AttitudeReference or one (3, 3) "
                    f"attitude, got shape {R.shape}"
                )
            R = R.copy()
            R.setflags(write=False)
            object.__setattr__(self, "attitude", R)

    def preflight(self, disturbance: object) -> DumpingFeasibility | None:
        """:func:`check_dumping_feasibility` of ``disturbance`` (a torque model or ``None``: no
        disturbance) along :attr:`attitude`; ``None`` without an attitude profile."""
        if self.attitude is None:
            return None
        d = np.zeros(3) if disturbance is None else disturbance
        return check_dumping_feasibility(self, d, self.attitude)

    def field_body(self, t: float, R: np.ndarray) -> np.ndarray:
        """Geomagnetic field in body axes ``(B, 3)`` [T] at time ``t`` for attitudes ``R``
        ``(B, 3, 3)``."""
        memo = self._memo
        key = float(t)
        B_in = memo.get(key)
        if B_in is None:
            B_in = self._field_inertial(key)
            if len(memo) >= 8:
                memo.clear()
            memo[key] = B_in
        return np.matmul(B_in, R)  # (Rᵀ B)_i = Σ_j B_j R_ji

    def _field_inertial(self, t: float) -> np.ndarray:
        """``field.inertial(t, orbit.position(t))`` on Python floats (the same formulas; ~10×
        cheaper than the validated array route for one time, tested against it)."""
        o, f = self.orbit, self.field
        u = o.arg_lat0 + o.n * t
        cu, su = math.cos(u), math.sin(u)
        Ro = o._R_orb
        rx = Ro[0, 0] * cu + Ro[0, 1] * su
        ry = Ro[1, 0] * cu + Ro[1, 1] * su
        rz = Ro[2, 0] * cu + Ro[2, 1] * su  # r̂ (unit: orthonormal columns)
        lam = f.longitude + f.greenwich0 + f.earth_rate * t
        st = math.sin(f.tilt)
        mx, my, mz = st * math.cos(lam), st * math.sin(lam), -math.cos(f.tilt)
        mr3 = 3.0 * (mx * rx + my * ry + mz * rz)
        k = f.strength * (f.radius / o.radius) ** 3
        return np.array([k * (mr3 * rx - mx), k * (mr3 * ry - my), k * (mr3 * rz - mz)])

    def dipole(self, t: float, R: np.ndarray, h: np.ndarray) -> np.ndarray:
        """Commanded dipole ``(B, 3)`` [A·m²] for stored momentum ``h`` ``(B, 3)``."""
        Bb = self.field_body(t, R)
        b2 = np.sum(Bb * Bb, axis=-1, keepdims=True)
        dh = np.asarray(h, dtype=np.float64) - self.h_target
        m = self.gain * _cross(dh, Bb) / b2  # ‖B‖ ≥ ~2e-5 T anywhere in low orbit
        return self.magnetorquers._saturate(m)

    def torque(self, t: float, R: np.ndarray, m: np.ndarray) -> np.ndarray:
        """Magnetic torque m × B(t, R) ``(B, 3)`` [N·m] (perpendicular to B)."""
        return _cross(m, self.field_body(t, R))

    def log(self, t: float, R: np.ndarray, h: np.ndarray) -> dict[str, np.ndarray]:
        """Per-sample log entries: the dipole held from ``t`` and its torque at ``t``."""
        m = self.dipole(t, R, h)
        return {"dipole": m, "magnetic_torque": self.torque(t, R, m)}

    def fused_kernel(self) -> object:
        """The magnetic torque as a torque of the disturbance seam
        (:func:`spacecraft._kernels_momentum.magnetic_torque`, a
        :class:`~spacecraft.disturbance_kernel.DisturbanceKernel` reading the attitude) whose
        parameter row carries the field, the law and the held dipole (zero here: the compiled
        loop writes each step's dipole, :func:`spacecraft._kernels_momentum.dipole`, into it).
        ``None`` without numba, for a subclass that overrides the law or with rods of a
        subclass of :class:`Magnetorquers` (its saturation may differ)."""
        from liecontrol._jit import JIT_ENABLED

        from . import _kernels_momentum as KM
        from .disturbance_kernel import DisturbanceKernel

        cls = type(self)
        if (
            not JIT_ENABLED
            or type(self.magnetorquers) is not Magnetorquers
            or any(
                getattr(cls, m) is not getattr(CrossProductDumping, m)
                for m in ("dipole", "torque", "field_body", "_field_inertial", "log")
            )
        ):
            return None
        o, f = self.orbit, self.field
        Ro = o._R_orb
        row = np.zeros(KM.N_PARAMS)
        row[KM.P_ARG], row[KM.P_N] = o.arg_lat0, o.n
        row[KM.P_RO : KM.P_RO + 6] = (Ro[0, 0], Ro[0, 1], Ro[1, 0], Ro[1, 1], Ro[2, 0], Ro[2, 1])
        row[KM.P_LAM], row[KM.P_RATE] = f.longitude + f.greenwich0, f.earth_rate
        row[KM.P_ST], row[KM.P_MZ] = math.sin(f.tilt), -math.cos(f.tilt)
        row[KM.P_K] = f.strength * (f.radius / o.radius) ** 3
        row[KM.P_GAIN] = self.gain
        row[KM.P_MMAX : KM.P_MMAX + 3] = self.magnetorquers.max_dipole
        row[KM.P_HT : KM.P_HT + 3] = self.h_target
        return DisturbanceKernel(
            KM.magnetic_torque, row, uses_attitude=True, name="magnetic_torque"
        )


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a × b of ``(B, 3)`` arrays (cheaper than ``np.cross`` for a few rows)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def _gimbal_axes(cluster: object) -> np.ndarray:
    g = cluster.gimbal_axes
    return np.asarray(g() if callable(g) else g, dtype=np.float64)


def sgcmg_momentum_capacity(gimbal_axes: object, h0: float, direction: object) -> np.ndarray:
    """Momentum capacity σ(d) = h₀ Σᵢ √(1 − (d·gᵢ)²) [N·m·s] of a single-gimbal CMG cluster
    along ``direction`` d ``(..., 3)`` (normalised here), gimbal axes ``(3, n)`` as columns and
    rotor momentum ``h0`` (see the module docstring). Returns ``(...,)``."""
    G = as_array(gimbal_axes, "gimbal_axes")
    if G.ndim != 2 or G.shape[0] != 3 or G.shape[1] < 1:
        raise ValueError(f"gimbal_axes: expected shape (3, n), got {G.shape}")
    if not np.allclose(np.linalg.norm(G, axis=0), 1.0, atol=1e-9):
        raise ValueError("gimbal_axes: the columns must be unit vectors")
    h0 = check_positive_scalar(h0, "h0")
    d = as_array(direction, "direction", (3,))
    dn = np.linalg.norm(d, axis=-1, keepdims=True)
    if np.any(dn == 0.0):
        raise ValueError("direction: zero vector")
    return _capacity_unchecked(G, h0, d / dn)


def _capacity_unchecked(G: object, h0: float, d: object) -> object:
    """σ(d) for a unit ``d`` ``(..., 3)``, unvalidated and pure (NumPy or JAX arrays; the
    guarded √ keeps the derivative finite where d is along a gimbal axis)."""
    xp = namespace(d)
    c = d @ G
    return h0 * safe_sqrt(xp.maximum(1.0 - c * c, 0.0), xp).sum(-1)


def sgcmg_momentum_fraction(gimbal_axes: object, h0: float, h: object) -> object:
    """‖h‖/σ(ĥ) for cluster momenta ``h`` ``(..., 3)`` [N·m·s] (0 where h = 0), the SGCMG
    fraction of :func:`momentum_fraction`; unvalidated and pure: the same source runs on JAX
    arrays (:mod:`spacecraft.robust_tuning` differentiates it), with finite derivatives at
    h = 0."""
    xp = namespace(h)
    n2 = (h * h).sum(-1)
    hn = safe_sqrt(n2, xp)
    # at h = 0 any direction gives the fraction 0; x̂ keeps the division and σ finite there
    safe = xp.where((hn > 0.0)[..., None], h / xp.where(hn > 0.0, hn, 1.0)[..., None],
                    np.array([1.0, 0.0, 0.0]))  # fmt: skip
    return hn / _capacity_unchecked(gimbal_axes, h0, safe)


def momentum_fraction(actuator: object, x_act: object) -> np.ndarray:
    """Stored momentum over the actuator's envelope (see the module docstring) for actuator
    states ``x_act`` ``(..., n)``: SGCMG pyramid ‖h‖/ρ(ĥ); reaction wheels maxᵢ |Ωᵢ|/Ω_max,i.
    Returns ``(...,)``; a ``ValueError`` for an actuator that stores no momentum."""
    from .actuators import ReactionWheelAssembly, SgcmgActuator

    xa = as_array(x_act, "x_act")
    if isinstance(actuator, (SgcmgActuator, ReactionWheelAssembly)):
        n = int(actuator.n_states)
        if xa.ndim < 1 or xa.shape[-1] != n:
            raise ValueError(f"x_act: expected shape (..., {n}), got {xa.shape}")
    if isinstance(actuator, SgcmgActuator):
        h = actuator.momentum(xa.reshape(-1, xa.shape[-1])).reshape(xa.shape[:-1] + (3,))
        return sgcmg_momentum_fraction(_gimbal_axes(actuator.cluster), actuator.cluster.h0, h)
    if isinstance(actuator, ReactionWheelAssembly):
        lim = np.broadcast_to(np.asarray(actuator.max_speed, dtype=np.float64), xa.shape[-1:])
        return np.max(np.abs(xa) / lim, axis=-1)
    raise ValueError(
        f"actuator: {type(actuator).__name__} stores no momentum (expected SgcmgActuator or "
        "ReactionWheelAssembly)"
    )


class DumpingInfeasibleWarning(UserWarning):
    """Magnetic momentum dumping cannot hold the secular disturbance on this orbit and attitude
    profile (the necessary authority test of :func:`magnetic_dumping_feasibility` fails)."""


@dataclass(frozen=True)
class DumpingFeasibility:
    """Result of :func:`magnetic_dumping_feasibility` (module docstring).

    Attributes:
        feasible: ``authority_ratio ≥ 1`` (the necessary condition holds).
        authority_ratio: ``min_d cap(d) / dᵀ(−T̄)`` over sampled directions (necessary: ≥ 1;
            capped at :data:`RATIO_CAP`, e.g. without a secular disturbance).
        dipole_ratio: ``m_max / (largest rod dipole of the constant-demand program)``
            (sufficient for an ideal law: ≥ 1; capped likewise).
        secular_torque: ``T̄`` ``(3,)`` [N·m], inertial axes.
        worst_direction: the unit ``d`` ``(3,)`` of ``authority_ratio`` (inertial axes).
        deficit_torque: ``max(0, dᵀ(−T̄) − cap(d))`` at that direction [N·m]: the least rate at
            which the stored momentum grows along it.
        cyclic_momentum: peak norm of the stored momentum the periodic part of the disturbance
            alone would accumulate ``max_t ‖∫(R T_d − T̄) dt‖`` [N·m·s] (the actuator must hold
            it; dumping cannot remove it within an orbit).
        note: a sentence for a warning or a report.
    """

    feasible: bool
    authority_ratio: float
    dipole_ratio: float
    secular_torque: np.ndarray
    worst_direction: np.ndarray
    deficit_torque: float
    cyclic_momentum: float
    note: str


def _sphere(n: int) -> np.ndarray:
    """``n`` unit vectors spread over the sphere (Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    th = math.pi * (1.0 + math.sqrt(5.0)) * i
    return np.stack((np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)), axis=-1)


def _attitude_at(attitude: object, t: float) -> np.ndarray:
    from liecontrol._validation import check_rotation_matrix

    a = attitude(t) if callable(attitude) else attitude
    R = check_rotation_matrix(getattr(a, "R_d", a), "attitude")
    if R.shape != (3, 3):
        raise ValueError(f"attitude: expected a (3, 3) attitude (or R_d) per time, got {R.shape}")
    return R


#: ratios of :class:`DumpingFeasibility` are capped here (no secular demand: "unbounded")
RATIO_CAP = 1.0e6
#: largest torque [N·m] a disturbance model may give to the check (beyond it: an input error)
_TORQUE_MAX = 1.0e12


def magnetic_dumping_feasibility(
    dumping: CrossProductDumping,
    disturbance: object,
    attitude: object,
    n_orbits: float = 4.0,
    samples_per_orbit: int = 240,
    n_directions: int = 600,
) -> DumpingFeasibility:
    """Whether magnetorquer dumping can hold ``disturbance`` on ``dumping``'s orbit along the
    attitude profile ``attitude`` (module docstring for the tests and their assumptions).

    Args:
        dumping: the :class:`CrossProductDumping` (orbit, field, rods).
        disturbance: the external torque model, a callable ``(t, R, omega) -> (B, 3)`` body
            torque [N·m] (e.g. :class:`spacecraft.disturbances.ConstantHarmonicTorque`), or a
            constant body torque ``(3,)``.
        attitude: the attitude the controller holds: a callable ``t -> AttitudeReference``
            (e.g. :class:`spacecraft.orbit.EarthPointingReference`) or ``t -> (3, 3)``, or one
            constant ``(3, 3)`` attitude (inertial pointing).
        n_orbits: horizon in orbits (> 0; the field turns with the Earth).
        samples_per_orbit: time samples per orbit (≥ 16).
        n_directions: directions ``d`` of the necessary test (≥ 50).
    """
    if not isinstance(dumping, CrossProductDumping):
        raise ValueError(f"dumping: expected a CrossProductDumping, got {type(dumping).__name__}")
    n_orbits = check_positive_scalar(n_orbits, "n_orbits")
    if n_orbits > 1000.0:
        raise ValueError(f"n_orbits: at most 1000 orbits, got {n_orbits:g}")
    for name, v, lo, hi in (
        ("samples_per_orbit", samples_per_orbit, 16, 100_000),
        ("n_directions", n_directions, 50, 100_000),
    ):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
            raise ValueError(f"{name}: expected an int in [{lo}, {hi}], got {v!r}")
    if n_orbits * samples_per_orbit > 1_000_000:
        raise ValueError(
            f"n_orbits: {n_orbits:g} orbits × {samples_per_orbit} samples exceed 1e6 samples"
        )
    if attitude is None:
        raise ValueError("attitude: the attitude profile is needed (e.g. EarthPointingReference)")
    period = dumping.orbit.period
    N = max(int(round(n_orbits * samples_per_orbit)), 16)
    ts = np.arange(N) * (n_orbits * period / N)
    Rs = np.stack([_attitude_at(attitude, float(t)) for t in ts])
    B_in = np.stack([dumping._field_inertial(float(t)) for t in ts])
    if callable(disturbance):
        Td = np.stack(
            [np.asarray(disturbance(float(t), R[None], np.zeros((1, 3))), dtype=np.float64)[0]
             for t, R in zip(ts, Rs, strict=True)]
        )  # fmt: skip
    else:
        c = as_array(disturbance, "disturbance")
        if c.shape != (3,):
            raise ValueError(f"disturbance: expected a callable or shape (3,), got {c.shape}")
        Td = np.broadcast_to(c, (N, 3))
    if Td.shape != (N, 3) or not np.all(np.abs(Td) <= _TORQUE_MAX):
        raise ValueError(
            f"disturbance: expected finite torques (N, 3) below {_TORQUE_MAX:g} N·m, got "
            f"shape {Td.shape}"
        )
    T_in = np.einsum("kij,kj->ki", Rs, Td)
    T_bar = T_in.mean(axis=0)
    # cyclic part: the momentum the periodic disturbance alone stores
    dt = n_orbits * period / N
    cyc = np.cumsum(T_in - T_bar, axis=0) * dt
    cyc = cyc - cyc.mean(axis=0)
    cyclic = float(np.linalg.norm(cyc, axis=-1).max())
    m_max = dumping.magnetorquers.max_dipole
    # necessary: cap(d) ≥ dᵀ(−T̄) for every direction d
    tn = float(np.linalg.norm(T_bar))
    if tn == 0.0:
        return DumpingFeasibility(
            True, RATIO_CAP, RATIO_CAP, T_bar, np.zeros(3), 0.0, cyclic,
            "no secular disturbance: nothing to dump beyond the cyclic momentum",
        )  # fmt: skip
    D = np.vstack([_sphere(int(n_directions)), -T_bar / tn])
    demand = D @ (-T_bar)
    BxD = np.cross(B_in[:, None, :], D[None, :, :])  # (N, n_d, 3)
    body = np.einsum("kji,kdj->kdi", Rs, BxD)
    cap = (np.abs(body) * m_max).sum(axis=-1).mean(axis=0)
    pos = demand > 1e-12 * tn
    ratios = np.full(D.shape[0], np.inf)
    ratios[pos] = cap[pos] / demand[pos]
    j = int(np.argmin(ratios))
    authority = float(min(ratios[j], RATIO_CAP))
    deficit = float(max(0.0, demand[j] - cap[j]))
    # sufficient: the constant inertial demand through the averaged projector
    b = B_in / np.linalg.norm(B_in, axis=-1, keepdims=True)
    P = np.eye(3) - np.einsum("ki,kj->ij", b, b) / N
    v = -np.linalg.solve(P, T_bar)
    m_in = np.cross(B_in, v) / np.sum(B_in * B_in, axis=-1, keepdims=True)
    m_b = np.einsum("kji,kj->ki", Rs, m_in)
    need = float((np.abs(m_b) / m_max).max())
    dip = RATIO_CAP if need <= 1.0 / RATIO_CAP else 1.0 / need
    inc = math.degrees(dumping.orbit.inclination)
    feasible = authority >= 1.0
    if feasible:
        note = (
            f"magnetic dumping authority {authority:.2f}x the secular disturbance "
            f"({tn:.3g} N·m) at {inc:.1f}° inclination (necessary test passes; "
            f"constant-demand program needs {1.0 / dip:.2f}x the rod limit)"
        )
    else:
        note = (
            f"momentum_management: magnetorquers cannot hold the secular disturbance "
            f"({tn:.3g} N·m inertial mean) at {inc:.1f}° inclination: along "
            f"d = {np.round(D[j], 3).tolist()} they give at most {authority:.2f}x the demand, "
            f"so the stored momentum grows by at least {deficit:.3g} N·m·s per second "
            f"({deficit * period:.3g} N·m·s per orbit) until the actuator saturates — more "
            "dipole, another orbit/attitude, or thruster unloading needed"
        )
    return DumpingFeasibility(feasible, authority, dip, T_bar, D[j].copy(), deficit, cyclic, note)


def check_dumping_feasibility(
    dumping: CrossProductDumping, disturbance: object, attitude: object, **kwargs: object
) -> DumpingFeasibility:
    """:func:`magnetic_dumping_feasibility`, warning (:class:`DumpingInfeasibleWarning`) when
    the necessary test fails — call it before the run."""
    import warnings

    rep = magnetic_dumping_feasibility(dumping, disturbance, attitude, **kwargs)
    if not rep.feasible:
        warnings.warn(rep.note, DumpingInfeasibleWarning, stacklevel=2)
    return rep


def momentum_growth_per_orbit(t: object, value: object, period: float) -> np.ndarray:
    """Secular growth per orbit of a stored-momentum measure (e.g. the envelope fraction of
    :func:`momentum_fraction`, or ‖h‖) logged at times ``t`` ``(K,)``, ``value`` ``(K,)`` or
    ``(K, B)``: the least-squares slope of the value against time over the whole run, times
    ``period`` (the orbit period [s]). A run at least one orbit long is required (the cyclic
    part then averages out to within its amplitude over the run length). Positive: dumping does
    not keep up (a flag after the run; compare with the margin to saturation)."""
    tt = as_array(t, "t")
    if tt.ndim != 1 or tt.shape[0] < 2 or not np.all(np.diff(tt) > 0.0):
        raise ValueError(f"t: expected increasing times (K,) with K >= 2, got shape {tt.shape}")
    v = as_array(value, "value")
    period = check_positive_scalar(period, "period")
    if v.ndim not in (1, 2) or v.shape[0] != tt.shape[0]:
        raise ValueError(
            f"value: expected ({tt.shape[0]},) or ({tt.shape[0]}, B) to match t, got {v.shape}"
        )
    if tt[-1] - tt[0] < period:
        raise ValueError(
            f"period: the run in t ({tt[-1] - tt[0]:.6g} s) is shorter than one orbit "
            f"({period:.6g} s)"
        )
    tc = tt - tt.mean()
    vv = v.reshape(v.shape[0], -1)
    slope = (tc @ (vv - vv.mean(axis=0))) / float(tc @ tc)
    return (slope * period).reshape(v.shape[1:])
