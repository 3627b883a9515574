"""Attitude sensors: star tracker, rate gyro, two-vector (TRIAD) attitude.

Sampling. Every sensor has its own ``period`` [s] (> 0). The simulator calls
``sensor.measure(t, R, omega, rng)`` at each sensor sample time t_k = t₀ + k·period, with the
**true** state at t_k (R ``(B, 3, 3)`` body → inertial, ω ``(B, 3)`` body rate), and holds the
returned measurement (zero-order hold) until the next sample. The sample times are only hit
exactly when ``period`` is an integer multiple of the simulator step h; otherwise a sample is
taken at the first step at or after t_k (timing error < h). Every noise source draws from the
``numpy.random.Generator`` passed in, so a seeded generator reproduces a run.

Models:

* :class:`StarTracker`: R_m = R exp(m^) exp(δ^), δ ~ N(0, diag σ²) a small body-frame rotation
  (``noise_std`` σ per axis [rad]) and m a fixed mounting misalignment (rotation vector);
  output as a unit quaternion (scalar first, canonical sign), Euler angles (``seq``) or matrix.
* :class:`RateGyro`: ω_m = ω + b + η_v, η_v ~ N(0, σ_v²) white (σ_v = ``white_std``, or
  ``noise_density``/√period for a density in rad/s/√Hz), bias random walk
  b(t_{k+1}) = b(t_k) + σ_u √(t_{k+1} − t_k) N(0, I) (``bias_rw_std`` σ_u in rad/s^{3/2}), so
  std b(t) − b(0) = σ_u √t (Farrenkopf's model, sampled; Crassidis & Junkins, *Optimal
  Estimation of Dynamic Systems*, §7.2.1). The bias is state: :class:`GyroState`.
* :class:`TwoVectorAttitude`: two reference directions r₁, r₂ (inertial; e.g. gravity/sun and
  the geomagnetic field, Wang et al. 2015 §1.2) are measured in body axes, b_i = exp(δ_i^) Rᵀ r_i
  (δ_i ~ N(0, σ_i² I)), and the attitude is solved with TRIAD (:func:`triad`), returned as Euler
  angles (Wang et al. 2015 uses roll/pitch/yaw; with ``seq="ZYX"`` the angles are (ψ, θ, φ) in the
  order of ``liecontrol.charts.euler``) or a matrix.

TRIAD (Black 1964; Shuster & Oh, J. Guidance Control 4(1), 1981): with the orthonormal triads
t₁ = v₁/|v₁|, t₂ = (v₁ × v₂)/|v₁ × v₂|, t₃ = t₁ × t₂ built from the body pair (b) and the
reference pair (r), ``R = [t^r] [t^b]ᵀ`` (body → inertial); the first vector is trusted exactly.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from liecontrol._validation import (
    as_array,
    as_scalar,
    check_nonnegative,
    check_positive_scalar,
)
from liecontrol.charts import euler, quaternion
from liecontrol.lie import so3

__all__ = [
    "PARALLEL_TOL",
    "triad",
    "StarTracker",
    "GyroState",
    "RateGyro",
    "TwoVectorAttitude",
]

#: sin of the smallest angle between the two TRIAD directions that is accepted.
PARALLEL_TOL = 1e-6

_OUTPUTS = ("quaternion", "euler", "matrix")


def _check_rng(rng: object) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected numpy.random.Generator, got {type(rng).__name__}")
    return rng


def _sigma3(x: object, name: str) -> np.ndarray:
    s = as_array(x, name)
    if s.shape not in ((), (3,)):
        raise ValueError(f"{name}: expected a scalar or shape (3,), got {s.shape}")
    check_nonnegative(s, name)
    return np.broadcast_to(s, (3,)).copy()


def _batch_R(R: object) -> np.ndarray:
    R = as_array(R, "R", (3, 3))
    if R.ndim != 3:
        raise ValueError(f"R: expected shape (B, 3, 3), got {R.shape}")
    return R


def _format(R: np.ndarray, output: str, seq: str) -> np.ndarray:
    if output == "matrix":
        return R
    if output == "quaternion":
        return quaternion.from_matrix(R)
    return euler.from_matrix(R, seq)


def _check_output(output: str, seq: str, allowed: tuple[str, ...]) -> None:
    if output not in allowed:
        raise ValueError(f"output: expected one of {allowed}, got {output!r}")
    # seq is validated whatever the output form: a bad value is an error even when unused
    euler.to_matrix(np.zeros(3), seq)  # raises ValueError naming seq


def triad(b1: object, b2: object, r1: object, r2: object) -> np.ndarray:
    """Attitude R (body → inertial) from two directions measured in body axes (``b1``, ``b2``)
    and known in the reference frame (``r1``, ``r2``), all ``(..., 3)`` (broadcast; need not be
    unit). R maps b1 exactly onto r1's direction and the plane (b1, b2) onto (r1, r2).

    Raises ``ValueError`` naming the pair if a vector is zero or the two directions of a pair
    are parallel (sin angle < :data:`PARALLEL_TOL`): the attitude is then undetermined.
    """
    vs = {n: as_array(v, n, (3,)) for n, v in (("b1", b1), ("b2", b2), ("r1", r1), ("r2", r2))}

    def frame(n1: str, n2: str) -> np.ndarray:
        v1, v2 = vs[n1], vs[n2]
        n_1 = np.linalg.norm(v1, axis=-1)
        n_2 = np.linalg.norm(v2, axis=-1)
        for name, nn in ((n1, n_1), (n2, n_2)):
            if np.any(nn == 0.0):
                raise ValueError(f"{name}: zero vector, no direction")
        c = np.cross(v1, v2)
        nc = np.linalg.norm(c, axis=-1)
        s = nc / (n_1 * n_2)
        if np.any(s < PARALLEL_TOL):
            raise ValueError(
                f"{n1}: parallel to {n2} (sin angle = {float(np.min(s)):.1e} < {PARALLEL_TOL:.0e}),"
                " attitude undetermined"
            )
        t1 = v1 / n_1[..., None]
        t2 = c / nc[..., None]
        return np.stack((t1, t2, np.cross(t1, t2)), axis=-1)  # columns t1, t2, t3

    Tb = frame("b1", "b2")
    Tr = frame("r1", "r2")
    return Tr @ np.swapaxes(Tb, -1, -2)


@dataclass(frozen=True)
class StarTracker:
    """Star tracker: true attitude × misalignment × small random rotation.

    Args:
        noise_std: σ per body axis [rad], scalar or ``(3,)`` (≥ 0).
        output: ``"quaternion"`` ``(B, 4)`` scalar-first, ``"euler"`` ``(B, 3)`` (``seq``) or
            ``"matrix"`` ``(B, 3, 3)``.
        seq: Euler sequence for ``output="euler"`` (scipy notation).
        period: sample period [s] (> 0).
        misalignment: fixed mounting error as a rotation vector ``(3,)`` [rad] (Wang et al. 2016
            considers installation errors).
    """

    noise_std: float | np.ndarray = 0.0
    output: str = "quaternion"
    seq: str = "ZYX"
    period: float = 0.25
    misalignment: np.ndarray | None = None
    #: exp(m^) computed once (None for m = 0, where the product is skipped: R I = R exactly)
    _mis_R: np.ndarray | None = field(init=False, repr=False, compare=False, default=None)

    def __post_init__(self) -> None:
        object.__setattr__(self, "noise_std", _sigma3(self.noise_std, "noise_std"))
        _check_output(self.output, self.seq, _OUTPUTS)
        object.__setattr__(self, "period", check_positive_scalar(self.period, "period"))
        m = (
            np.zeros(3)
            if self.misalignment is None
            else as_array(self.misalignment, "misalignment")
        )
        if m.shape != (3,):
            raise ValueError(f"misalignment: expected shape (3,), got {m.shape}")
        m = m.copy()
        m.setflags(write=False)  # the cached exp(m^) below must not go stale
        object.__setattr__(self, "misalignment", m)
        mis = so3.exp(m) if m.any() else None
        if mis is not None:
            mis.setflags(write=False)
        object.__setattr__(self, "_mis_R", mis)

    def measure_matrix(self, R: object, rng: np.random.Generator) -> np.ndarray:
        """Noisy attitude matrices ``(B, 3, 3)``: R exp(m^) exp(δ^)."""
        R = _batch_R(R)
        rng = _check_rng(rng)
        delta = rng.standard_normal(R.shape[:-1]) * self.noise_std
        # exp(m^) is computed once at construction; for m = 0 it is I exactly and R I = R
        # bitwise, so the product is skipped (so3.exp costs ~25 µs per call at B = 1)
        if self._mis_R is not None:
            R = R @ self._mis_R
        return R @ so3.exp(delta)

    def measure(self, t: float, R: object, omega: object, rng: np.random.Generator) -> np.ndarray:
        """Measurement at sample time ``t`` in the configured ``output`` form (``t`` and
        ``omega`` ``(B, 3)`` are part of the sensor interface; a star tracker ignores them —
        ``omega`` may be ``None`` — but a given value is checked so that a wrong call is not
        silently accepted)."""
        as_scalar(t, "t")
        out = _format(self.measure_matrix(R, rng), self.output, self.seq)
        if omega is not None:
            w = as_array(omega, "omega", (3,))
            if w.shape != out.shape[:1] + (3,):
                raise ValueError(f"omega: expected shape {out.shape[:1] + (3,)}, got {w.shape}")
        return out


@dataclass(frozen=True)
class GyroState:
    """Rate-gyro state: ``bias`` ``(B, 3)`` [rad/s] and the time of the last sample (``None``
    before the first)."""

    bias: np.ndarray
    t_last: float | None = None


class RateGyro:
    """Rate gyro with white noise and a bias random walk; batched over B.

    Args:
        white_std: white-noise σ_v per sample [rad/s] (scalar or ``(3,)``), or
        noise_density: angle random walk [rad/s/√Hz], σ_v = density/√period (not both).
        bias_rw_std: bias random walk σ_u [rad/s^{3/2}] (scalar or ``(3,)``).
        initial_bias: ``(3,)`` or ``(B, 3)`` bias at the first sample [rad/s].
        initial_bias_std: σ of a random initial bias added to ``initial_bias`` at :meth:`reset`.
        period: sample period [s] (> 0).

    Parameters are fixed at construction. The bias lives in a :class:`GyroState`: the pure
    :meth:`step` maps (state, t, ω, rng) → (measurement, new state); :meth:`measure` (the
    simulator's entry point) does the same on the state the object holds, created by
    :meth:`reset` (or on the first call, from ``initial_bias``).
    """

    def __init__(
        self,
        white_std: float | np.ndarray | None = None,
        noise_density: float | np.ndarray | None = None,
        bias_rw_std: float | np.ndarray = 0.0,
        initial_bias: object = 0.0,
        initial_bias_std: float | np.ndarray = 0.0,
        period: float = 0.25,
    ) -> None:
        self.period = check_positive_scalar(period, "period")
        if white_std is not None and noise_density is not None:
            raise ValueError("white_std: give either white_std or noise_density, not both")
        if noise_density is not None:
            self.white_std = _sigma3(noise_density, "noise_density") / np.sqrt(self.period)
        else:
            self.white_std = _sigma3(0.0 if white_std is None else white_std, "white_std")
        self.bias_rw_std = _sigma3(bias_rw_std, "bias_rw_std")
        b0 = as_array(initial_bias, "initial_bias")
        if b0.ndim > 2 or (b0.ndim >= 1 and b0.shape[-1] != 3):
            raise ValueError(f"initial_bias: expected shape (3,) or (B, 3), got {b0.shape}")
        self.initial_bias = b0.copy()
        self.initial_bias_std = _sigma3(initial_bias_std, "initial_bias_std")
        self.state: GyroState | None = None

    def initial_state(self, batch_size: int, rng: np.random.Generator | None = None) -> GyroState:
        """Fresh state: bias = ``initial_bias`` (+ N(0, initial_bias_std²) if that is > 0)."""
        if int(batch_size) < 1:
            raise ValueError(f"batch_size: must be >= 1, got {batch_size}")
        try:
            b = np.broadcast_to(self.initial_bias, (int(batch_size), 3)).copy()
        except ValueError:
            raise ValueError(
                f"initial_bias: shape {self.initial_bias.shape} does not fit batch {batch_size}"
            ) from None
        if np.any(self.initial_bias_std > 0):
            b += _check_rng(rng).standard_normal(b.shape) * self.initial_bias_std
        return GyroState(bias=b, t_last=None)

    def reset(self, batch_size: int = 1, rng: np.random.Generator | None = None) -> GyroState:
        """Replace the held state with :meth:`initial_state` and return it."""
        self.state = self.initial_state(batch_size, rng)
        return self.state

    def step(
        self, state: GyroState, t: float, omega: object, rng: np.random.Generator
    ) -> tuple[np.ndarray, GyroState]:
        """Pure: advance the bias from ``state.t_last`` to ``t`` and measure ``omega``
        ``(B, 3)``; returns (ω_m ``(B, 3)``, new state). ``t`` must not decrease."""
        rng = _check_rng(rng)
        omega = as_array(omega, "omega", (3,))
        if omega.ndim != 2 or omega.shape[0] != state.bias.shape[0]:
            raise ValueError(
                f"omega: expected shape ({state.bias.shape[0]}, 3) to match the gyro state, "
                f"got {omega.shape} (call reset(batch_size))"
            )
        t = as_scalar(t, "t")
        bias = state.bias
        if state.t_last is not None:
            dt = t - state.t_last
            if dt < 0:
                raise ValueError(f"t: {t} is before the previous sample {state.t_last}")
            bias = bias + rng.standard_normal(bias.shape) * (self.bias_rw_std * np.sqrt(dt))
        meas = omega + bias + rng.standard_normal(omega.shape) * self.white_std
        return meas, replace(state, bias=bias, t_last=t)

    def measure(self, t: float, R: object, omega: object, rng: np.random.Generator) -> np.ndarray:
        """Measured body rate ``(B, 3)`` at sample time ``t``; advances the held state."""
        omega_a = as_array(omega, "omega", (3,))
        if self.state is None:
            self.reset(omega_a.shape[0] if omega_a.ndim == 2 else 1, rng)
        meas, self.state = self.step(self.state, t, omega_a, rng)
        return meas


def _direction(ref: object, name: str) -> np.ndarray | Callable[[float], np.ndarray]:
    if callable(ref):
        return ref
    v = as_array(ref, name)
    if v.shape != (3,):
        raise ValueError(f"{name}: expected shape (3,) or a callable t -> (3,), got {v.shape}")
    nv = np.linalg.norm(v)
    if nv == 0.0:
        raise ValueError(f"{name}: zero vector, no direction")
    return v / nv


@dataclass(frozen=True)
class TwoVectorAttitude:
    """Two-vector attitude sensor: two measured directions → TRIAD → attitude (
    Wang, Li et al. 2015 §1.2: gravity from accelerometers and the geomagnetic field from
    magnetometers).

    Args:
        ref1, ref2: reference directions in the inertial frame, ``(3,)`` or callables
            ``t -> (3,)`` (e.g. a sun or geomagnetic-field model); ``ref1`` is the trusted one.
        noise_std: angular noise σ of each measured direction [rad], scalar or a pair.
        seq: Euler sequence for ``output="euler"``.
        output: ``"euler"`` (default, as Wang et al. 2015) or ``"matrix"`` or ``"quaternion"``.
        period: sample period [s] (> 0).
    """

    ref1: object
    ref2: object
    noise_std: float | tuple[float, float] = 0.0
    seq: str = "ZYX"
    output: str = "euler"
    period: float = 1.0
    _sig: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        r1 = _direction(self.ref1, "ref1")
        r2 = _direction(self.ref2, "ref2")
        object.__setattr__(self, "ref1", r1)
        object.__setattr__(self, "ref2", r2)
        if not callable(r1) and not callable(r2):
            # refuse parallel references now rather than at the first sample
            s = float(np.linalg.norm(np.cross(r1, r2)))
            if s < PARALLEL_TOL:
                raise ValueError(
                    f"ref1: parallel to ref2 (sin angle = {s:.1e} < {PARALLEL_TOL:.0e}), "
                    "attitude undetermined"
                )
        sig = as_array(self.noise_std, "noise_std")
        if sig.shape not in ((), (2,)):
            raise ValueError(f"noise_std: expected a scalar or a pair, got shape {sig.shape}")
        check_nonnegative(sig, "noise_std")
        object.__setattr__(self, "_sig", np.broadcast_to(sig, (2,)).copy())
        _check_output(self.output, self.seq, _OUTPUTS)
        object.__setattr__(self, "period", check_positive_scalar(self.period, "period"))

    def references(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Unit reference directions (inertial) at ``t``."""
        out = []
        for name, r in (("ref1", self.ref1), ("ref2", self.ref2)):
            v = as_array(r(t), name, (3,)) if callable(r) else r
            out.append(v / np.linalg.norm(v, axis=-1, keepdims=True))
        return out[0], out[1]

    def body_vectors(
        self, t: float, R: object, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray]:
        """Measured unit directions b_i = exp(δ_i^) Rᵀ r_i, each ``(B, 3)``."""
        R = _batch_R(R)
        rng = _check_rng(rng)
        r1, r2 = self.references(t)
        out = []
        for r, s in ((r1, self._sig[0]), (r2, self._sig[1])):
            b = np.einsum("...ji,...j->...i", R, r)
            delta = rng.standard_normal(b.shape) * s
            out.append(np.einsum("...ij,...j->...i", so3.exp(delta), b))
        return out[0], out[1]

    def measure_matrix(self, t: float, R: object, rng: np.random.Generator) -> np.ndarray:
        """TRIAD attitude ``(B, 3, 3)`` from the noisy body directions."""
        b1, b2 = self.body_vectors(t, R, rng)
        r1, r2 = self.references(t)
        return triad(b1, b2, r1, r2)

    def measure(self, t: float, R: object, omega: object, rng: np.random.Generator) -> np.ndarray:
        """Measurement at sample time ``t`` in the configured ``output`` form."""
        return _format(self.measure_matrix(t, R, rng), self.output, self.seq)
