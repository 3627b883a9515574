"""Detumbling with magnetorquers: B-dot and the rate-feedback cross-product law.

Laws (Stickler & Alfriend, "Elementary magnetic attitude control system", *Journal of
Spacecraft and Rockets* 13(5), 1976; Markley & Crassidis, *Fundamentals of Spacecraft Attitude
Determination and Control*, Springer 2014, §7.5). Three rods along the body axes give the dipole
``m`` [A·m²] and the torque ``τ = m × B`` (``B`` the field in body axes):

- ``"bdot"``: ``m = −k_b Ḃ`` with ``Ḃ`` the finite difference of two magnetometer samples one
  control period apart. In body axes ``Ḃ = −ω × B + Rᵀ dB_I/dt``; for a tumble much faster than
  the orbit the first term dominates and ``m ≈ k_b ω × B``: no gyro needed.
- ``"cross-product"``: ``m = k (ω × B)/‖B‖²`` with a gyro's ``ω``: ``τ = −k (ω − (ω·B̂)B̂) =
  −k ω⊥`` exactly, so ``d/dt ½ωᵀJω = −k‖ω⊥‖² ≤ 0``.

Either dipole is scaled as a vector when a rod would exceed ``m_max`` (the direction, hence
``τ ⟂ B`` and the sign of the energy rate, is kept).

Averaged dynamics (the bound a gain implies). Over a tumble and an orbit the field direction in
body axes sweeps the sphere; with ``⟨I − B̂B̂ᵀ⟩ ≈ (2/3)I`` and the rods on a fraction ``d`` of the
time (the duty cycle), the unsaturated cross-product law averages to
``J ω̇ = −(2/3) d k ω`` — each principal rate decays as ``exp(−(2/3) d k t / J_i)``; B-dot is the
same with ``k = k_b ⟨‖B‖²⟩`` (:func:`averaged_detumble_time`). Saturation makes the decay
slower (linear at first); the rates settle near twice the orbit rate, where the field turns in
body axes, not at zero — the rate threshold must lie above that.

Magnetometer and time sharing. A rod's own field corrupts the magnetometer, so the two share
each control period ``T_c``: at ``t_k = k T_c`` the rods are off and the magnetometer samples
``B̃ = B + b + v`` (bias ``b``, white noise ``v`` of ``noise_std`` per axis); the law's dipole is
then on for ``duty_cycle · T_c`` and off for the rest. The rods' effect on the magnetometer while
on is not modelled (it is why they are off at the sample).

Metrics of :func:`simulate_detumble`: time to the rate threshold (the first time after which
``‖ω‖`` stays below it), rotational kinetic energy removed, and the rods' electrical energy
``Σᵢ ∫ P_i (mᵢ/m_max,i)² dt`` (resistive rods: power ∝ current² ∝ dipole²) with ``P_i`` the power
at full dipole.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from liecontrol._linalg import cross as _cross
from liecontrol._validation import as_array, check_inertia_3x3, check_positive_scalar

from .geomagnetic import TiltedDipoleField
from .orbit import CircularOrbit

__all__ = [
    "DETUMBLE_LAWS",
    "Magnetometer",
    "DetumbleLaw",
    "DetumbleResult",
    "simulate_detumble",
    "separation_tumble",
    "averaged_detumble_time",
]

#: Laws of :class:`DetumbleLaw`.
DETUMBLE_LAWS: tuple[str, ...] = ("bdot", "cross-product")


def _vec3(x: object, name: str) -> np.ndarray:
    a = as_array(x, name)
    if a.shape not in ((), (3,)):
        raise ValueError(f"{name}: expected a scalar or 3 values, got shape {a.shape}")
    return np.array(np.broadcast_to(a, (3,)), dtype=np.float64)


@dataclass(frozen=True)
class Magnetometer:
    """Three-axis magnetometer: ``B̃ = B + bias + noise`` [T], sampled at each control period's
    start (module docstring).

    Args:
        noise_std: white noise per axis [T] (≥ 0; 1e-7 T = 100 nT, a typical MEMS/AMR part).
        bias: constant bias [T], scalar or 3 values.
    """

    noise_std: float = 1e-7
    bias: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        s = as_array(self.noise_std, "noise_std")
        if s.shape != () or not float(s) >= 0.0:
            raise ValueError(f"noise_std: expected a finite scalar ≥ 0, got {self.noise_std!r}")
        object.__setattr__(self, "noise_std", float(s))
        object.__setattr__(self, "bias", tuple(float(v) for v in _vec3(self.bias, "bias")))

    def measure(self, B: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """A sample of the body-axis field ``B`` ``(..., 3)`` [T]."""
        B = as_array(B, "B", (3,))
        noise = rng.normal(scale=self.noise_std, size=B.shape) if self.noise_std > 0 else 0.0
        return B + np.asarray(self.bias) + noise


@dataclass(frozen=True)
class DetumbleLaw:
    """A magnetic detumbling law (module docstring).

    Args:
        gain: ``k_b`` [A·m²·s/T] for ``"bdot"``; ``k`` [N·m·s] for ``"cross-product"`` (> 0).
        m_max: per-rod dipole limit [A·m²] (scalar or 3 values, > 0).
        law: ``"bdot"`` or ``"cross-product"``.
        period: control period ``T_c`` [s] (> 0): one magnetometer sample and one dipole each.
        duty_cycle: fraction of ``T_c`` the rods are on, in (0, 1].
        gyro_noise_std: white noise of the gyro the cross-product law reads [rad/s] (≥ 0).
        rod_power: electrical power of one rod at full dipole [W] (> 0), for the energy metric.
    """

    gain: float
    m_max: object = 0.2
    law: str = "bdot"
    period: float = 1.0
    duty_cycle: float = 0.8
    gyro_noise_std: float = 0.0
    rod_power: float = 0.2
    _m_max: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "gain", check_positive_scalar(self.gain, "gain"))
        m = _vec3(self.m_max, "m_max")
        if not np.all(m > 0.0):
            raise ValueError(f"m_max: expected values > 0, got {self.m_max!r}")
        object.__setattr__(self, "_m_max", m)
        if not isinstance(self.law, str) or self.law not in DETUMBLE_LAWS:
            raise ValueError(f"law: expected one of {DETUMBLE_LAWS}, got {self.law!r}")
        object.__setattr__(self, "period", check_positive_scalar(self.period, "period"))
        d = as_array(self.duty_cycle, "duty_cycle")
        if d.shape != () or not 0.0 < float(d) <= 1.0:
            raise ValueError(f"duty_cycle: must be in (0, 1], got {self.duty_cycle!r}")
        object.__setattr__(self, "duty_cycle", float(d))
        g = as_array(self.gyro_noise_std, "gyro_noise_std")
        if g.shape != () or not float(g) >= 0.0:
            raise ValueError(f"gyro_noise_std: expected a scalar ≥ 0, got {self.gyro_noise_std!r}")
        object.__setattr__(self, "gyro_noise_std", float(g))
        object.__setattr__(self, "rod_power", check_positive_scalar(self.rod_power, "rod_power"))

    def dipole(
        self, B_meas: np.ndarray, B_prev: np.ndarray | None, omega_meas: np.ndarray
    ) -> np.ndarray:
        """Dipole ``(B, 3)`` [A·m²] from this and the previous magnetometer sample (B-dot; no
        previous sample: zero) or from the measured rate (cross-product), then saturated."""
        if self.law == "bdot":
            if B_prev is None:
                return np.zeros_like(B_meas)
            m = -self.gain * (B_meas - B_prev) / self.period
        else:
            nb = np.sum(B_meas * B_meas, axis=-1, keepdims=True)
            m = self.gain * np.cross(omega_meas, B_meas) / np.where(nb > 0.0, nb, 1.0)
        ratio = (np.abs(m) / self._m_max).max(axis=-1, keepdims=True)
        return m / np.maximum(ratio, 1.0)


@dataclass(frozen=True)
class DetumbleResult:
    """Logged detumble run of ``B`` spacecraft: ``t`` ``(K,)`` [s], ``omega`` ``(K, B, 3)``
    [rad/s], ``dipole`` ``(K, B, 3)`` [A·m²] (held over each step), ``time_to_threshold`` ``(B,)``
    [s] (NaN: not reached), ``kinetic_energy`` ``(K, B)`` [J], ``electrical_energy`` ``(B,)`` [J],
    ``threshold`` [rad/s]."""

    t: np.ndarray
    omega: np.ndarray
    dipole: np.ndarray
    time_to_threshold: np.ndarray
    kinetic_energy: np.ndarray
    electrical_energy: np.ndarray
    threshold: float


def separation_tumble(
    n: int, rate_range_deg_s: tuple[float, float] = (5.0, 10.0), seed: int = 0
) -> np.ndarray:
    """``(n, 3)`` body rates [rad/s] of a separation tumble: a uniform random axis and a rate
    uniform in ``rate_range_deg_s`` [°/s] (``default_rng(seed)``)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n: expected an integer ≥ 1, got {n!r}")
    if n > 10**7:
        raise ValueError(f"n: at most 1e7 tumbles, got {n}")
    rr = as_array(rate_range_deg_s, "rate_range_deg_s")
    if rr.shape != (2,):
        raise ValueError(f"rate_range_deg_s: expected (low, high), got shape {rr.shape}")
    lo, hi = float(rr[0]), float(rr[1])
    if not 0.0 <= lo <= hi:
        raise ValueError(
            f"rate_range_deg_s: expected (low, high), 0 ≤ low ≤ high, got {rate_range_deg_s!r}"
        )
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed: expected an integer, got {seed!r}")
    rng = np.random.default_rng(int(seed))
    axis = rng.standard_normal((int(n), 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    return axis * np.deg2rad(rng.uniform(lo, hi, size=(int(n), 1)))


def averaged_detumble_time(
    J: object, k: float, omega0: object, threshold: float, duty_cycle: float = 1.0
) -> float:
    """Time [s] at which the averaged unsaturated dynamics ``J ω̇ = −(2/3) d k ω`` (module
    docstring) bring ``‖ω‖`` from ``omega0`` ``(3,)`` below ``threshold`` [rad/s]: each principal
    component decays as ``exp(−(2/3) d k t/J_i)``; solved by bisection on the closed form.
    ``k`` [N·m·s]: the cross-product gain, or ``k_b ⟨‖B‖²⟩`` for B-dot."""
    Jm = check_inertia_3x3(J, "J")
    k = check_positive_scalar(k, "k")
    thr = check_positive_scalar(threshold, "threshold")
    d = check_positive_scalar(duty_cycle, "duty_cycle")
    if d > 1.0:
        raise ValueError(f"duty_cycle: must be in (0, 1], got {duty_cycle!r}")
    w0 = as_array(omega0, "omega0", (3,))
    if w0.shape != (3,):
        raise ValueError(f"omega0: expected shape (3,), got {w0.shape}")
    lam, V = np.linalg.eigh(Jm)
    c = V.T @ w0
    rate = (2.0 / 3.0) * d * k / lam

    def norm(t: float) -> float:
        return float(np.linalg.norm(c * np.exp(-rate * t)))

    if norm(0.0) <= thr:
        return 0.0
    hi = 1.0
    while norm(hi) > thr:
        hi *= 2.0
    lo = 0.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if norm(mid) > thr else (lo, mid)
    return hi


def _quat_mul_vec(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``½ q ⊗ (0, w)`` (scalar-first, body rate): the quaternion rate."""
    q0, qv = q[..., :1], q[..., 1:]
    return 0.5 * np.concatenate(
        (-np.sum(qv * w, axis=-1, keepdims=True), q0 * w + _cross(qv, w)), axis=-1
    )


def simulate_detumble(
    J: object,
    law: DetumbleLaw,
    omega0: object,
    t_final: float,
    *,
    threshold: float,
    orbit: CircularOrbit | None = None,
    field: TiltedDipoleField | None = None,
    magnetometer: Magnetometer | None = None,
    dt: float = 0.5,
    seed: int = 0,
    log_every: int = 10,
) -> DetumbleResult:
    """Rigid body ``J ω̇ + ω × Jω = m × B`` from the rates ``omega0`` ``(B, 3)`` (or ``(3,)``)
    at identity attitude, on ``orbit`` (default: 530 km, 97.5° — a sun-synchronous LEO) in
    ``field`` (default: the IGRF-2020 tilted dipole), with ``law`` and ``magnetometer``
    (default :class:`Magnetometer`), RK4 on (quaternion, ω) with step ``dt`` (``law.period``
    must be an integer multiple of it), until ``t_final``.

    Raises:
        ValueError: ``threshold`` ≤ 0, ``t_final`` or ``dt`` ≤ 0, a period that is not a
            multiple of ``dt``, or a wrong shape (the message names the argument).
    """
    Jm = check_inertia_3x3(J, "J")
    if not isinstance(law, DetumbleLaw):
        raise TypeError(f"law: expected a DetumbleLaw, got {type(law).__name__}")
    thr = check_positive_scalar(threshold, "threshold")
    T = check_positive_scalar(t_final, "t_final")
    h = check_positive_scalar(dt, "dt")
    ratio = law.period / h
    if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
        raise ValueError(f"dt: law.period {law.period:g} s must be an integer multiple of it")
    per = int(round(ratio))
    w = np.array(as_array(omega0, "omega0", (3,)), dtype=np.float64)
    w = w.reshape(-1, 3)
    if isinstance(log_every, bool) or not isinstance(log_every, (int, np.integer)) or log_every < 1:
        raise ValueError(f"log_every: expected an integer ≥ 1, got {log_every!r}")
    if orbit is None:
        orbit = CircularOrbit.from_altitude(530e3, inclination=math.radians(97.5))
    if not isinstance(orbit, CircularOrbit):
        raise TypeError(f"orbit: expected a CircularOrbit, got {type(orbit).__name__}")
    field = TiltedDipoleField() if field is None else field
    if not isinstance(field, TiltedDipoleField):
        raise TypeError(f"field: expected a TiltedDipoleField, got {type(field).__name__}")
    mag = Magnetometer() if magnetometer is None else magnetometer
    if not isinstance(mag, Magnetometer):
        raise TypeError(f"magnetometer: expected a Magnetometer, got {type(mag).__name__}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed: expected an integer, got {seed!r}")
    if not np.all(np.abs(w) < 1e3):
        raise ValueError(f"omega0: rates must be finite and below 1e3 rad/s, got {omega0!r}")
    steps_needed = T / h
    if steps_needed > 1e8:
        raise ValueError(f"t_final: {T:g} s is more than 1e8 steps of dt = {h:g} s")
    rng = np.random.default_rng(int(seed))
    Jinv = np.linalg.inv(Jm)
    nB = w.shape[0]
    q = np.tile([1.0, 0.0, 0.0, 0.0], (nB, 1))
    steps = int(math.ceil(T / h - 1e-9))
    # the inertial field along the orbit, once: at each step's start (magnetometer samples) and
    # midpoint (held over the step's RK4 stages: the orbit moves ≈ n·dt rad in a step)
    t_grid = np.arange(2 * steps + 1) * (h / 2)
    B_grid = field.inertial(t_grid, orbit.position(t_grid))

    def to_body(q_: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Rᵀv for the body → inertial rotation of the unit quaternion ``q_``."""
        q0, qv = q_[:, :1], q_[:, 1:]
        c = _cross(qv, v)
        return v - 2.0 * q0 * c + 2.0 * _cross(qv, c)

    def f(q_: np.ndarray, w_: np.ndarray, m: np.ndarray, B_I: np.ndarray) -> tuple:
        tau = _cross(m, to_body(q_, B_I))
        dw = (tau - _cross(w_, w_ @ Jm.T)) @ Jinv.T
        return _quat_mul_vec(q_, w_), dw

    ts, ws, ms = [0.0], [w.copy()], [np.zeros_like(w)]
    B_prev: np.ndarray | None = None
    m = np.zeros_like(w)
    m_cycle = m
    e_el = np.zeros(nB)
    P = law.rod_power
    for k in range(steps):
        if k % per == 0:  # rods off: sample the magnetometer, compute the next dipole
            B_meas = mag.measure(to_body(q, np.broadcast_to(B_grid[2 * k], (nB, 3))), rng)
            w_meas = w
            if law.gyro_noise_std > 0:
                w_meas = w + rng.normal(scale=law.gyro_noise_std, size=w.shape)
            m_cycle = law.dipole(B_meas, B_prev, w_meas)
            B_prev = B_meas
        # the rods are on for duty·T_c from the sample: a step partly inside that window gets
        # the dipole times its on-fraction (the same impulse m × B over the step)
        frac = min(max(law.duty_cycle * per - (k % per), 0.0), 1.0)
        m = m_cycle * frac
        e_el += P * np.sum((m_cycle / law._m_max) ** 2, axis=-1) * h * frac
        B_I = np.broadcast_to(B_grid[2 * k + 1], (nB, 3))
        k1 = f(q, w, m, B_I)
        k2 = f(q + h / 2 * k1[0], w + h / 2 * k1[1], m, B_I)
        k3 = f(q + h / 2 * k2[0], w + h / 2 * k2[1], m, B_I)
        k4 = f(q + h * k3[0], w + h * k3[1], m, B_I)
        q = q + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        w = w + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        if (k + 1) % log_every == 0 or k + 1 == steps:
            ts.append((k + 1) * h)
            ws.append(w.copy())
            ms.append(m.copy())
    t_arr, w_arr = np.array(ts), np.array(ws)
    wn = np.linalg.norm(w_arr, axis=-1)
    ttt = np.full(nB, np.nan)
    for b in range(nB):
        above = np.nonzero(wn[:, b] >= thr)[0]
        if above.size == 0:
            ttt[b] = 0.0
        elif above[-1] + 1 < t_arr.size:
            ttt[b] = t_arr[above[-1] + 1]
    ke = 0.5 * np.einsum("kbi,ij,kbj->kb", w_arr, Jm, w_arr)
    return DetumbleResult(t_arr, w_arr, np.array(ms), ttt, ke, e_el, thr)
