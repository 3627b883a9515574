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
  Optional scale-factor error, misalignment, first-order bandwidth and output quantisation.
* :class:`StarTracker` also has a boresight noise model (tilt σ_c, roll σ_b); any sensor can be
  wrapped in :class:`TimedSensor` for update latency and outages (held output, ``valid`` flag).
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

import math
import warnings
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any

import numpy as np

from liecontrol._kernels import euler as _ke
from liecontrol._validation import (
    as_array,
    as_int,
    as_scalar,
    check_nonnegative,
    check_positive_scalar,
)
from liecontrol.charts import euler, quaternion
from liecontrol.lie import so3

from . import _kernels_sensors as _ks

__all__ = [
    "PARALLEL_TOL",
    "triad",
    "StarTracker",
    "GyroState",
    "RateGyro",
    "TwoVectorAttitude",
    "TimedSensor",
]

#: sin of the smallest angle between the two TRIAD directions that is accepted.
PARALLEL_TOL = 1e-6

_OUTPUTS = ("quaternion", "euler", "matrix")

#: placeholders of the kernels' unused matrix arguments (read only)
_EYE3 = np.eye(3)
_ZERO33 = np.zeros((3, 3))
_EYE3.setflags(write=False)
_ZERO33.setflags(write=False)


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


def euler_angles(R: np.ndarray, seq: str) -> np.ndarray:
    """Euler angles ``(B, 3)`` of measured attitudes ``R (B, 3, 3)`` in sequence ``seq``: the
    compiled kernel :func:`liecontrol._kernels.euler.from_matrix_into` (the method and ranges of
    :func:`liecontrol.charts.euler.from_matrix`, against which it is tested), which the fused
    loop calls too; a :class:`~liecontrol.charts.euler.GimbalLockWarning` at lock, as the chart."""
    i, j, k, ext = euler.kernel_axes(seq)
    out, lock = _ke.from_matrix_batch(
        np.ascontiguousarray(R), i, j, k, ext, euler.FROM_MATRIX_LOCK_TOL
    )
    if np.any(lock):
        warnings.warn(
            f"R: gimbal lock in sequence {seq!r} for {int(np.count_nonzero(lock))} matrix(es); "
            "only a1 ± a3 is determined, the third angle was set to 0",
            euler.GimbalLockWarning,
            stacklevel=3,
        )
    return out


def _format(R: np.ndarray, output: str, seq: str) -> np.ndarray:
    if output == "matrix":
        return R
    if output == "quaternion":
        return quaternion.from_matrix(R)
    return euler_angles(R, seq)


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

    def frame(n1: str, n2: str) -> None:
        v1, v2 = vs[n1], vs[n2]
        n_1 = np.linalg.norm(v1, axis=-1)
        n_2 = np.linalg.norm(v2, axis=-1)
        for name, nn in ((n1, n_1), (n2, n_2)):
            if np.any(nn == 0.0):
                raise ValueError(f"{name}: zero vector, no direction")
        nc = np.linalg.norm(np.cross(v1, v2), axis=-1)
        s = nc / (n_1 * n_2)
        if np.any(s < PARALLEL_TOL):
            raise ValueError(
                f"{n1}: parallel to {n2} (sin angle = {float(np.min(s)):.1e} < {PARALLEL_TOL:.0e}),"
                " attitude undetermined"
            )

    frame("b1", "b2")
    frame("r1", "r2")
    # the compiled kernel (spacecraft._kernels_sensors.triad_into), as the fused loop
    shape = np.broadcast_shapes(*(v.shape for v in vs.values()))
    flat = [np.ascontiguousarray(np.broadcast_to(v, shape).reshape(-1, 3)) for v in vs.values()]
    out, _ = _ks.triad_batch(*flat)
    return out.reshape(shape[:-1] + (3, 3))


@dataclass(frozen=True)
class StarTracker:
    """Star tracker: true attitude × misalignment × small random rotation.

    Noise δ (a rotation vector in the sensor axes, which are the body axes up to the mounting
    ``misalignment``) is zero-mean Gaussian with one of two covariances:

    * per body axis, Σ = diag(σ²) (``noise_std``), or
    * a **boresight** model, Σ = σ_c² (I − b bᵀ) + σ_b² b bᵀ with b the unit ``boresight``:
      σ_c (``cross_boresight_std``) for the two tilts of the line of sight and σ_b
      (``boresight_std``) for the roll about it. A star tracker measures the line of sight
      through the star centroids directly, but the roll only through the stars' spread across
      the field of view, so σ_b > σ_c: Liebe ("Accuracy performance of star trackers — a
      tutorial", IEEE Trans. Aerospace and Electronic Systems 38(2), 2002) gives
      σ_b/σ_c ≈ 1/(0.3825·FOV[rad]), i.e. 6 to 10 for fields of view of 25° to 15°.
      Sampled as δ = L z, z ~ N(0, I), with L = σ_c (I − b bᵀ) + σ_b b bᵀ the symmetric square
      root of Σ (both terms are orthogonal projectors).

    Update latency and outages (held output, ``valid`` flag) are added by wrapping the tracker
    in a :class:`TimedSensor`.

    Args:
        noise_std: σ per body axis [rad], scalar or ``(3,)`` (≥ 0).
        output: ``"quaternion"`` ``(B, 4)`` scalar-first, ``"euler"`` ``(B, 3)`` (``seq``) or
            ``"matrix"`` ``(B, 3, 3)``.
        seq: Euler sequence for ``output="euler"`` (scipy notation).
        period: sample period [s] (> 0).
        misalignment: fixed mounting error as a rotation vector ``(3,)`` [rad] (Wang et al. 2016
            considers installation errors).
        boresight: unit line of sight ``(3,)`` in sensor axes (default +z when a boresight
            σ is given).
        cross_boresight_std: σ_c of each tilt of the line of sight [rad] (≥ 0).
        boresight_std: σ_b of the roll about the line of sight [rad] (≥ 0). Either of the two
            selects the boresight model (the other defaults to 0); not together with
            ``noise_std``.
    """

    noise_std: float | np.ndarray = 0.0
    output: str = "quaternion"
    seq: str = "ZYX"
    period: float = 0.25
    misalignment: np.ndarray | None = None
    boresight: np.ndarray | None = None
    cross_boresight_std: float | None = None
    boresight_std: float | None = None
    #: exp(m^) computed once (None for m = 0, where the product is skipped: R I = R exactly)
    _mis_R: np.ndarray | None = field(init=False, repr=False, compare=False, default=None)
    #: Lᵀ of the boresight model (None: the per-axis model)
    _LT: np.ndarray | None = field(init=False, repr=False, compare=False, default=None)

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
        self._init_boresight()

    def _init_boresight(self) -> None:
        b = np.array([0.0, 0.0, 1.0]) if self.boresight is None else self.boresight
        b = as_array(b, "boresight")
        if b.shape != (3,):
            raise ValueError(f"boresight: expected shape (3,), got {b.shape}")
        nb = float(np.linalg.norm(b))
        if abs(nb - 1.0) > 1e-9:
            raise ValueError(f"boresight: expected a unit vector, got norm {nb:.6g}")
        b = b / nb
        b.setflags(write=False)
        object.__setattr__(self, "boresight", b)
        if self.cross_boresight_std is None and self.boresight_std is None:
            return
        sc = 0.0 if self.cross_boresight_std is None else self.cross_boresight_std
        sb = 0.0 if self.boresight_std is None else self.boresight_std
        sc = float(check_nonnegative(as_scalar(sc, "cross_boresight_std"), "cross_boresight_std"))
        sb = float(check_nonnegative(as_scalar(sb, "boresight_std"), "boresight_std"))
        if np.any(self.noise_std > 0):
            raise ValueError(
                "noise_std: give either noise_std (per body axis) or "
                "cross_boresight_std/boresight_std (boresight model), not both"
            )
        P = np.outer(b, b)
        L = sc * (np.eye(3) - P) + sb * P  # symmetric: L = Lᵀ
        L.setflags(write=False)
        object.__setattr__(self, "cross_boresight_std", sc)
        object.__setattr__(self, "boresight_std", sb)
        object.__setattr__(self, "_LT", L)

    @property
    def covariance(self) -> np.ndarray:
        """Covariance Σ ``(3, 3)`` of the noise rotation vector δ [rad²]."""
        if self._LT is None:
            return np.diag(self.noise_std**2)
        return self._LT @ self._LT

    def measure_matrix(self, R: object, rng: np.random.Generator) -> np.ndarray:
        """Noisy attitude matrices ``(B, 3, 3)``: R exp(m^) exp(δ^)."""
        R = _batch_R(R)
        rng = _check_rng(rng)
        z = rng.standard_normal(R.shape[:-1])
        # the compiled kernel (spacecraft._kernels_sensors.star_tracker_into), as the fused loop
        return _ks.star_tracker_batch(np.ascontiguousarray(R), *self.kernel_args(), z)

    def kernel_args(self) -> tuple[bool, np.ndarray, bool, np.ndarray, np.ndarray]:
        """``(mis_on, exp(m^), per_axis, σ, Lᵀ)``: the parameters of
        :func:`spacecraft._kernels_sensors.star_tracker_into` (exp(m^) is computed once at
        construction; for m = 0 it is skipped, R I = R bitwise)."""
        mis = _EYE3 if self._mis_R is None else self._mis_R
        LT = _ZERO33 if self._LT is None else self._LT
        return self._mis_R is not None, mis, self._LT is None, self.noise_std, LT

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
    """Rate-gyro state: ``bias`` ``(B, 3)`` [rad/s], the time of the last sample (``None``
    before the first) and the low-pass filter output ``filtered`` ``(B, 3)`` [rad/s] (``None``
    before the first sample or without a ``bandwidth``)."""

    bias: np.ndarray
    t_last: float | None = None
    filtered: np.ndarray | None = None


def _misalignment_matrix(m: object) -> np.ndarray:
    M = as_array(m, "misalignment")
    if M.shape == (3,):
        return so3.hat(M)  # a small rotation: (I + m^) ω ≈ exp(m^) ω
    if M.shape != (3, 3):
        raise ValueError(f"misalignment: expected shape (3,) or (3, 3), got {M.shape}")
    if np.any(np.diag(M) != 0.0):
        raise ValueError(
            "misalignment: the diagonal must be zero (axis gains are scale_factor's), "
            f"got {np.diag(M).tolist()}"
        )
    return M.copy()


class RateGyro:
    """Rate gyro: scale factor, misalignment, bandwidth, bias random walk, white noise and
    quantisation; batched over B.

    Measurement at sample t_k (the standard error model of a strapdown gyro, e.g. Titterton &
    Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., IEE 2004, §8.2)::

        ω_s = (I + S + M) ω                       S = diag(s) scale-factor error,
                                                  M misalignment / non-orthogonality
        y_k = α y_{k−1} + (1 − α) ω_s(t_k),       α = exp(−2π f_c (t_k − t_{k−1}))
        ω_m = Q(y_k + b(t_k) + η_v),              Q(x) = q·round(x/q)  (LSB q)

    The first-order low-pass (bandwidth f_c) is the exact discretisation of ẏ = 2π f_c (ω_s − y)
    for ω_s held at its sampled value over each interval; it starts in steady state
    (y₀ = ω_s(t₀)). Noise: η_v ~ N(0, σ_v²) white (σ_v = ``white_std``, or
    ``noise_density``/√period for a density in rad/s/√Hz), bias random walk
    b(t_{k+1}) = b(t_k) + σ_u √(t_{k+1} − t_k) N(0, I) (``bias_rw_std`` σ_u in rad/s^{3/2}), so
    std b(t) − b(0) = σ_u √t (Farrenkopf's model, sampled; Crassidis & Junkins, *Optimal
    Estimation of Dynamic Systems*, §7.2.1). Each term at its default (0 / ``None``) is skipped,
    so the default gyro is exactly ω + b + η_v.

    Args:
        white_std: white-noise σ_v per sample [rad/s] (scalar or ``(3,)``), or
        noise_density: angle random walk [rad/s/√Hz], σ_v = density/√period (not both).
        bias_rw_std: bias random walk σ_u [rad/s^{3/2}] (scalar or ``(3,)``).
        initial_bias: ``(3,)`` or ``(B, 3)`` bias at the first sample [rad/s].
        initial_bias_std: σ of a random initial bias added to ``initial_bias`` at :meth:`reset`.
        period: sample period [s] (> 0).
        scale_factor: relative scale-factor error s per axis (scalar or ``(3,)``, each > −1;
            100 ppm = 1e-4).
        misalignment: ``(3,)`` small rotation vector m (M = m^) or a ``(3, 3)`` matrix with
            zero diagonal (general non-orthogonality of the sensing axes) [rad].
        quantization: LSB q of the output per axis [rad/s] (scalar or ``(3,)``, ≥ 0; 0: none).
        bandwidth: −3 dB bandwidth f_c of the first-order low-pass [Hz] (> 0), or ``None``.

    Parameters are fixed at construction. The bias and filter live in a :class:`GyroState`: the
    pure :meth:`step` maps (state, t, ω, rng) → (measurement, new state); :meth:`measure` (the
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
        scale_factor: float | np.ndarray = 0.0,
        misalignment: object = None,
        quantization: float | np.ndarray = 0.0,
        bandwidth: float | None = None,
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
        sf = as_array(scale_factor, "scale_factor")
        if sf.shape not in ((), (3,)):
            raise ValueError(f"scale_factor: expected a scalar or shape (3,), got {sf.shape}")
        if np.any(sf <= -1.0):
            raise ValueError(f"scale_factor: must be > -1 (a gain 1 + s > 0), got {sf.min()}")
        self.scale_factor = np.broadcast_to(sf, (3,)).copy()
        self.misalignment = (
            np.zeros((3, 3)) if misalignment is None else _misalignment_matrix(misalignment)
        )
        self.quantization = _sigma3(quantization, "quantization")
        if bandwidth is not None:
            bandwidth = check_positive_scalar(bandwidth, "bandwidth")
        self.bandwidth: float | None = bandwidth
        C = np.eye(3) + np.diag(self.scale_factor) + self.misalignment
        #: (I + S + M)ᵀ, or None when it is I (the product is skipped: bitwise the old model)
        self._CT: np.ndarray | None = None if np.array_equal(C, np.eye(3)) else C.T.copy()
        self.state: GyroState | None = None

    @property
    def time_constant(self) -> float | None:
        """τ = 1/(2π f_c) of the low-pass [s] (``None`` without a bandwidth)."""
        return None if self.bandwidth is None else 1.0 / (2.0 * np.pi * self.bandwidth)

    def initial_state(self, batch_size: int, rng: np.random.Generator | None = None) -> GyroState:
        """Fresh state: bias = ``initial_bias`` (+ N(0, initial_bias_std²) if that is > 0)."""
        batch_size = as_int(batch_size, "batch_size", 1)
        try:
            b = np.broadcast_to(self.initial_bias, (batch_size, 3)).copy()
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
        """Pure: advance the bias (and filter) from ``state.t_last`` to ``t`` and measure
        ``omega`` ``(B, 3)``; returns (ω_m ``(B, 3)``, new state). ``t`` must not decrease."""
        rng = _check_rng(rng)
        omega = as_array(omega, "omega", (3,))
        if omega.ndim != 2 or omega.shape[0] != state.bias.shape[0]:
            raise ValueError(
                f"omega: expected shape ({state.bias.shape[0]}, 3) to match the gyro state, "
                f"got {omega.shape} (call reset(batch_size))"
            )
        t = as_scalar(t, "t")
        dt = 0.0
        advance = state.t_last is not None
        zb = None
        if advance:
            dt = t - state.t_last
            if dt < 0:
                raise ValueError(f"t: {t} is before the previous sample {state.t_last}")
            zb = rng.standard_normal(state.bias.shape)  # the bias walk's draw, then the white
        zw = rng.standard_normal(omega.shape)
        bias = np.array(state.bias, dtype=np.float64)  # a copy: the state is immutable
        first = state.filtered is None
        filtered = np.zeros(omega.shape) if first else np.array(state.filtered, dtype=np.float64)
        # the compiled kernel (spacecraft._kernels_sensors.gyro_sample_into), as the fused loop
        meas = _ks.gyro_sample_batch(
            np.ascontiguousarray(omega, dtype=np.float64), bias, filtered, advance, float(dt),
            *self.kernel_args(), first, np.zeros(omega.shape) if zb is None else zb, zw,
        )  # fmt: skip
        if self.bandwidth is None:
            filtered = None
        return meas, replace(state, bias=bias, t_last=t, filtered=filtered)

    def kernel_args(
        self,
    ) -> tuple[bool, np.ndarray, bool, float, np.ndarray, np.ndarray, np.ndarray]:
        """``(ct_on, (I + S + M)ᵀ, bw_on, f_c, σ_u, σ_v, q)`` of
        :func:`spacecraft._kernels_sensors.gyro_sample_into` (the filter's first-sample flag
        and the draws follow in its call)."""
        ct = self._CT is not None
        bw = self.bandwidth is not None
        return (
            ct, self._CT if ct else _EYE3, bw, float(self.bandwidth) if bw else 0.0,
            self.bias_rw_std, self.white_std, self.quantization,
        )  # fmt: skip

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
        z1 = rng.standard_normal(R.shape[:-1])
        z2 = rng.standard_normal(R.shape[:-1])
        # the compiled kernel (spacecraft._kernels_sensors.body_vector_into), as the fused loop
        return _ks.body_vectors_batch(
            np.ascontiguousarray(R), r1, r2, float(self._sig[0]), float(self._sig[1]), z1, z2
        )

    def measure_matrix(self, t: float, R: object, rng: np.random.Generator) -> np.ndarray:
        """TRIAD attitude ``(B, 3, 3)`` from the noisy body directions."""
        b1, b2 = self.body_vectors(t, R, rng)
        r1, r2 = self.references(t)
        return triad(b1, b2, r1, r2)

    def measure(self, t: float, R: object, omega: object, rng: np.random.Generator) -> np.ndarray:
        """Measurement at sample time ``t`` in the configured ``output`` form."""
        return _format(self.measure_matrix(t, R, rng), self.output, self.seq)


def _as_fraction(x: float, name: str) -> Fraction:
    """``x`` [s] as a fraction with a denominator ≤ 10⁹ (0.1 → 1/10); the exact grid on which
    the simulator's relative tolerance (1e-9) of "a multiple of dt" also works."""
    f = Fraction(x).limit_denominator(10**9)
    if x > 0 and abs(float(f) - x) > 1e-9 * x:
        raise ValueError(f"{name}: {x!r} s is not a ratio of integers up to 1e9")
    return f


def _frac_gcd(a: Fraction, b: Fraction) -> Fraction:
    """Largest g with a/g and b/g integers (gcd of two positive rationals)."""
    den = a.denominator * b.denominator // math.gcd(a.denominator, b.denominator)
    return Fraction(math.gcd(int(a * den), int(b * den)), den)


def _check_outages(outages: object) -> tuple[tuple[float, float], ...]:
    try:
        pairs = [tuple(p) for p in outages]  # type: ignore[union-attr]
    except TypeError:
        raise ValueError(
            f"outages: expected a sequence of (start, end) pairs [s], got {outages!r}"
        ) from None
    out = []
    for i, p in enumerate(pairs):
        if len(p) != 2:
            raise ValueError(f"outages: entry {i} must be a (start, end) pair, got {p!r}")
        a = as_scalar(p[0], f"outages[{i}][0]")
        b = as_scalar(p[1], f"outages[{i}][1]")
        if not b > a:
            raise ValueError(f"outages: entry {i} needs start < end, got ({a!r}, {b!r})")
        out.append((a, b))
    return tuple(out)


def _time_tol(t: float) -> float:
    """Tolerance of a comparison of simulation times (the simulator's relative 1e-9)."""
    return 1e-9 * max(1.0, abs(t))


class TimedSensor:
    """Update latency and outages for any sensor (:class:`StarTracker`, :class:`RateGyro`,
    :class:`TwoVectorAttitude` or one with the same ``measure``/``period`` interface).

    **Latency** L: the output published at t_k = t₀ + k·P (P the wrapped sensor's ``period``)
    is the wrapped sensor's measurement of the true state at t_k − L (image exposure and
    on-board processing take time; a star tracker's quaternion is typically 50–200 ms old when
    it reaches the controller). The wrapper remembers the true states it is shown, so it is
    called on the finer grid g = gcd(P, L) — its own ``period`` is g, which the simulator
    requires to be a multiple of its step, i.e. P and L must both be multiples of dt. Before
    t₀ + L there is no delayed state yet: the output is the measurement of the state at t₀,
    flagged invalid.

    **Outages** (blinding by the Sun or Moon, loss of track): during an outage the previous
    output is held and ``valid`` is ``False``. Scheduled ``outages`` are half-open intervals
    [start, end) of simulation time (every spacecraft); random outages start at each
    publication with probability 1 − exp(−λP) (a Poisson process of rate λ =
    ``outage_rate`` sampled at the publications, independently per spacecraft) and last
    ``outage_duration`` D. The random draws come from the ``rng`` passed to :meth:`measure`
    (one uniform per spacecraft per publication, drawn only when λ > 0), so a seeded run is
    reproducible. The wrapped sensor is still called during an outage (its internal state —
    a gyro's bias — keeps evolving and the noise stream is the same with or without outages).

    Args:
        sensor: the sensor to wrap.
        latency: L ≥ 0 [s].
        outages: sequence of (start, end) pairs [s], start < end.
        outage_rate: λ ≥ 0 [1/s].
        outage_duration: D > 0 [s] (required when ``outage_rate`` > 0).

    Attributes:
        valid: ``(B,)`` bool of the last output (``None`` before the first call). The simulator
            logs it as ``result.sensors[name + "_valid"]``.
    """

    def __init__(
        self,
        sensor: Any,
        latency: float = 0.0,
        outages: object = (),
        outage_rate: float = 0.0,
        outage_duration: float | None = None,
    ) -> None:
        if not callable(getattr(sensor, "measure", None)):
            raise ValueError("sensor: has no measure(t, R, omega, rng) method")
        update = check_positive_scalar(getattr(sensor, "period", None), "sensor.period")
        self.sensor = sensor
        self.latency = float(check_nonnegative(as_scalar(latency, "latency"), "latency"))
        self.outages = _check_outages(outages)
        self.outage_rate = float(
            check_nonnegative(as_scalar(outage_rate, "outage_rate"), "outage_rate")
        )
        if outage_duration is not None:
            outage_duration = check_positive_scalar(outage_duration, "outage_duration")
        elif self.outage_rate > 0:
            raise ValueError("outage_rate: needs outage_duration (> 0 s)")
        self.outage_duration = outage_duration
        self.update_period = update
        fP = _as_fraction(update, "sensor.period")
        if self.latency > 0:
            g = _frac_gcd(fP, _as_fraction(self.latency, "latency"))
        else:
            g = fP
        self.period = float(g)
        self._every = int(fP / g)  # calls per publication
        self._lag = int(_as_fraction(self.latency, "latency") / g) if self.latency > 0 else 0
        if self._lag > 10**9:
            raise ValueError(
                f"latency: {self.latency!r} s is {self._lag} sensor calls of {float(g)!r} s, "
                "more than the limit of 1e9"
            )
        self.valid: np.ndarray | None = None
        self._reset_buffers()

    @property
    def outage_probability(self) -> float:
        """p = 1 − exp(−λP): the chance that a random outage starts at a publication."""
        return float(-np.expm1(-self.outage_rate * self.update_period))

    def _reset_buffers(self) -> None:
        self._calls = 0
        self._history: deque[tuple[float, np.ndarray, np.ndarray | None]] = deque(
            maxlen=self._lag + 1
        )
        self._held: np.ndarray | None = None
        self._outage_end: np.ndarray | None = None
        self.valid = None

    def reset(self, batch_size: int = 1, rng: np.random.Generator | None = None) -> None:
        """Forget the history, the held output and the outage state; reset the wrapped sensor
        (if it has a ``reset``)."""
        as_int(batch_size, "batch_size", 1)
        self._reset_buffers()
        if callable(getattr(self.sensor, "reset", None)):
            self.sensor.reset(batch_size, rng)

    def in_scheduled_outage(self, t: float) -> bool:
        """Whether ``t`` falls in one of the scheduled ``outages``."""
        t = as_scalar(t, "t")
        e = _time_tol(t)  # t is k·dt in floating point: 2.0 may arrive as 1.9999999999999998
        return any(a - e <= t < b - e for a, b in self.outages)

    def measure(self, t: float, R: object, omega: object, rng: np.random.Generator) -> np.ndarray:
        """Called every ``period`` (g) with the true state at ``t``; returns the held output,
        refreshed at the publication times."""
        t = as_scalar(t, "t")
        rng = _check_rng(rng)
        R = _batch_R(R)
        w = None if omega is None else as_array(omega, "omega", (3,)).copy()
        # copies: the simulator hands over its own arrays, which later steps replace
        self._history.append((t, R.copy(), w))
        k = self._calls
        self._calls += 1
        if k % self._every:
            return self._held
        B = R.shape[0]
        fresh = k >= self._lag  # the state at t − L has been seen
        # the deque keeps the last lag + 1 states: its oldest is the state at t − L once that
        # has been seen, and the state at t₀ before
        t_m, R_m, w_m = self._history[0]
        if self._outage_end is None or self._outage_end.shape != (B,):
            self._outage_end = np.full(B, -np.inf)
        else:
            self._outage_end = self._outage_end.copy()  # updated in place below
        if self.outage_rate > 0:
            hit = rng.random(B) < self.outage_probability
            duration = float(self.outage_duration)
        else:
            hit = np.zeros(B, dtype=bool)
            duration = 0.0
        # the compiled kernel (spacecraft._kernels_sensors.outage_step), as the fused loop
        out_now = _ks.outage_batch(
            self._outage_end, t + _time_tol(t), t, duration, hit, self.in_scheduled_outage(t)
        )
        y = np.asarray(self.sensor.measure(t_m, R_m, w_m, rng))
        if self._held is None:
            held = y.copy()  # nothing to hold yet: the first output stands (flagged if invalid)
        else:
            keep = out_now.reshape((B,) + (1,) * (y.ndim - 1))
            held = np.where(keep, self._held, y)
        self._held = held
        self.valid = fresh & ~out_now
        return held
