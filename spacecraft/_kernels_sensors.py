"""Compiled kernels of the sensors' per-sample models (:mod:`spacecraft.sensors`) and of the
:class:`spacecraft.simulator.StarTrackerGyro` hook: the one implementation of each formula.
The numpy classes draw the noise from the run's ``numpy.random.Generator`` and call the batched
kernels here; the compiled closed loop (:mod:`spacecraft._fused`) calls the per-spacecraft
kernels on noise drawn beforehand in the same order, so both routes do the same arithmetic.

Kernels never validate: callers pass finite float64 arrays of the right shapes.
"""

from __future__ import annotations

import math

import numpy as np

from liecontrol._jit import njit
from liecontrol._kernels.mrp_pd import quaternion9
from liecontrol._kernels.so3 import exp9, right_multiply_exp_into


@njit(inline="always")
def star_tracker_into(
    R: np.ndarray, mis_on: bool, mis: np.ndarray, per_axis: bool, sigma: np.ndarray,
    LT: np.ndarray, z: np.ndarray, tmp: np.ndarray, out: np.ndarray,
) -> None:  # fmt: skip
    """``out = R exp(m^) exp(δ^)`` of one spacecraft (``R``, ``mis``, ``LT``, ``tmp``, ``out``
    ``(3, 3)``; ``tmp`` scratch), δ = σ ∘ z per body axis (``per_axis``) or δ = zᵀ Lᵀ (the
    boresight model, L = σ_c (I − b bᵀ) + σ_b b bᵀ), z ~ N(0, I) the draw ``(3,)``; the
    mounting product is skipped for m = 0 (``mis_on`` False: R I = R exactly)."""
    if per_axis:
        d0 = z[0] * sigma[0]
        d1 = z[1] * sigma[1]
        d2 = z[2] * sigma[2]
    else:
        d0 = z[0] * LT[0, 0] + z[1] * LT[1, 0] + z[2] * LT[2, 0]
        d1 = z[0] * LT[0, 1] + z[1] * LT[1, 1] + z[2] * LT[2, 1]
        d2 = z[0] * LT[0, 2] + z[1] * LT[1, 2] + z[2] * LT[2, 2]
    if mis_on:
        for i in range(3):
            r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
            for j in range(3):
                tmp[i, j] = r0 * mis[0, j] + r1 * mis[1, j] + r2 * mis[2, j]
        right_multiply_exp_into(tmp, d0, d1, d2, out)
    else:
        right_multiply_exp_into(R, d0, d1, d2, out)


@njit
def star_tracker_batch(
    R: np.ndarray, mis_on: bool, mis: np.ndarray, per_axis: bool, sigma: np.ndarray,
    LT: np.ndarray, Z: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """:func:`star_tracker_into` of every spacecraft: ``R (B, 3, 3)``, draws ``Z (B, 3)``;
    returns the measured matrices ``(B, 3, 3)``."""
    out = np.empty(R.shape)
    tmp = np.empty((3, 3))
    for b in range(R.shape[0]):
        star_tracker_into(R[b], mis_on, mis, per_axis, sigma, LT, Z[b], tmp, out[b])
    return out


@njit(inline="always")
def quaternion_into(R: np.ndarray, q: np.ndarray) -> None:
    """``q (4,)``: the scalar-first unit quaternion of ``R (3, 3)``, canonical sign (Shepperd's
    method, :func:`liecontrol._kernels.mrp_pd.quaternion9`, the kernel of
    :func:`liecontrol.charts.quaternion.from_matrix`)."""
    q0, q1, q2, q3 = quaternion9(
        R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2]
    )
    q[0] = q0
    q[1] = q1
    q[2] = q2
    q[3] = q3


@njit(inline="always")
def unit_quaternion_matrix_into(q: np.ndarray, out: np.ndarray) -> None:
    """``out (3, 3)`` = R(q) of a scalar-first quaternion ``q (4,)`` normalised first:
    R = I + 2w v^ + 2 v^² with q = (w, v) (Hamilton, design.md)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    w, x, y, z = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    out[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    out[0, 1] = 2.0 * (x * y - w * z)
    out[0, 2] = 2.0 * (x * z + w * y)
    out[1, 0] = 2.0 * (x * y + w * z)
    out[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    out[1, 2] = 2.0 * (y * z - w * x)
    out[2, 0] = 2.0 * (x * z - w * y)
    out[2, 1] = 2.0 * (y * z + w * x)
    out[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@njit
def unit_quaternion_matrix_batch(q: np.ndarray) -> np.ndarray:
    """:func:`unit_quaternion_matrix_into` of every row of ``q (B, 4)``; ``(B, 3, 3)``."""
    out = np.empty((q.shape[0], 3, 3))
    for b in range(q.shape[0]):
        unit_quaternion_matrix_into(q[b], out[b])
    return out


@njit(inline="always")
def gyro_sample_into(
    omega: np.ndarray, bias: np.ndarray, filt: np.ndarray, advance: bool, dt: float,
    ct_on: bool, CT: np.ndarray, bw_on: bool, bandwidth: float, rw_std: np.ndarray,
    white_std: np.ndarray, quant: np.ndarray, filt_first: bool, zb: np.ndarray,
    zw: np.ndarray, out: np.ndarray,
) -> None:  # fmt: skip
    """One rate-gyro sample of one spacecraft (:class:`spacecraft.sensors.RateGyro`), in place:

    * bias walk (``advance``: not the first sample) b ← b + σ_u √Δt z_b;
    * ω_s = (I + S + M) ω (``ct_on``; ``CT`` its transpose, ω_s = ωᵀ CT);
    * low-pass (``bw_on``) y ← α y + (1 − α) ω_s, α = exp(−2π f_c Δt), or y = ω_s at the first
      sample (``filt_first``: the filter starts in steady state); ω_s ← y;
    * ``out`` = ω_s + b + σ_v z_w, then quantised per axis where q > 0, q·round(x/q)
      (round half to even, as numpy).

    ``bias``, ``filt`` ``(3,)`` are the state (updated); ``zb``, ``zw`` the draws ``(3,)``."""
    if advance:
        s = math.sqrt(dt)
        for i in range(3):
            bias[i] = bias[i] + zb[i] * (rw_std[i] * s)
    w0, w1, w2 = omega[0], omega[1], omega[2]
    if ct_on:
        s0 = w0 * CT[0, 0] + w1 * CT[1, 0] + w2 * CT[2, 0]
        s1 = w0 * CT[0, 1] + w1 * CT[1, 1] + w2 * CT[2, 1]
        s2 = w0 * CT[0, 2] + w1 * CT[1, 2] + w2 * CT[2, 2]
        w0, w1, w2 = s0, s1, s2
    if bw_on:
        if filt_first:
            filt[0], filt[1], filt[2] = w0, w1, w2
        else:
            alpha = math.exp(-2.0 * math.pi * bandwidth * dt)
            beta = 1.0 - alpha
            filt[0] = alpha * filt[0] + beta * w0
            filt[1] = alpha * filt[1] + beta * w1
            filt[2] = alpha * filt[2] + beta * w2
        w0, w1, w2 = filt[0], filt[1], filt[2]
    out[0] = w0 + bias[0] + zw[0] * white_std[0]
    out[1] = w1 + bias[1] + zw[1] * white_std[1]
    out[2] = w2 + bias[2] + zw[2] * white_std[2]
    for i in range(3):
        if quant[i] > 0.0:
            out[i] = np.round(out[i] / quant[i]) * quant[i]


@njit
def gyro_sample_batch(
    omega: np.ndarray, bias: np.ndarray, filt: np.ndarray, advance: bool, dt: float,
    ct_on: bool, CT: np.ndarray, bw_on: bool, bandwidth: float, rw_std: np.ndarray,
    white_std: np.ndarray, quant: np.ndarray, filt_first: bool, ZB: np.ndarray,
    ZW: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """:func:`gyro_sample_into` of every spacecraft (``omega``, ``bias``, ``filt``, ``ZB``,
    ``ZW`` ``(B, 3)``; ``bias`` and ``filt`` updated in place); returns ω_m ``(B, 3)``."""
    out = np.empty(omega.shape)
    for b in range(omega.shape[0]):
        gyro_sample_into(
            omega[b], bias[b], filt[b], advance, dt, ct_on, CT, bw_on, bandwidth, rw_std,
            white_std, quant, filt_first, ZB[b], ZW[b], out[b],
        )  # fmt: skip
    return out


@njit(inline="always")
def outage_step(
    end: float, thr: float, t: float, duration: float, hit: bool, scheduled: bool
) -> tuple[bool, float]:
    """One publication of :class:`spacecraft.sensors.TimedSensor`'s outage model for one
    spacecraft: a random outage starts when none is running (``end ≤ thr``, thr = t + the
    time tolerance) and the draw ``hit`` (u < p = 1 − exp(−λP)); it ends at t + D. Returns
    (in an outage now: end > thr or ``scheduled``, the new end)."""
    if hit and end <= thr:
        end = t + duration
    return (end > thr) or scheduled, end


@njit
def outage_batch(
    end: np.ndarray, thr: float, t: float, duration: float, hit: np.ndarray, scheduled: bool
) -> np.ndarray:
    """:func:`outage_step` of every spacecraft (``end (B,)`` updated in place); ``(B,)`` bool."""
    out = np.empty(end.shape[0], dtype=np.bool_)
    for b in range(end.shape[0]):
        out[b], end[b] = outage_step(end[b], thr, t, duration, hit[b], scheduled)
    return out


@njit(inline="always")
def triad_into(
    b1: np.ndarray, b2: np.ndarray, r1: np.ndarray, r2: np.ndarray, out: np.ndarray
) -> float:
    """TRIAD (Black 1964; Shuster & Oh, J. Guidance Control 4(1), 1981) of one pair:
    ``out (3, 3)`` = [t^r] [t^b]ᵀ with the triads t₁ = v₁/|v₁|, t₂ = (v₁ × v₂)/|v₁ × v₂|,
    t₃ = t₁ × t₂ of the body pair (b) and the reference pair (r). Returns the smaller sin of
    the angle within a pair (|v₁ × v₂| / (|v₁| |v₂|)); 0 for a zero vector, when ``out`` is
    not a rotation (the caller refuses a value below ``PARALLEL_TOL``)."""
    Tb = np.empty((3, 3))
    Tr = np.empty((3, 3))
    s_min = 1.0
    for p in range(2):
        v1 = b1 if p == 0 else r1
        v2 = b2 if p == 0 else r2
        T = Tb if p == 0 else Tr
        n1 = math.sqrt(v1[0] * v1[0] + v1[1] * v1[1] + v1[2] * v1[2])
        n2 = math.sqrt(v2[0] * v2[0] + v2[1] * v2[1] + v2[2] * v2[2])
        c0 = v1[1] * v2[2] - v1[2] * v2[1]
        c1 = v1[2] * v2[0] - v1[0] * v2[2]
        c2 = v1[0] * v2[1] - v1[1] * v2[0]
        nc = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        if n1 == 0.0 or n2 == 0.0 or nc == 0.0:
            s_min = 0.0
            nc = 1.0 if nc == 0.0 else nc
            n1 = 1.0 if n1 == 0.0 else n1
        else:
            s_min = min(s_min, nc / (n1 * n2))
        T[0, 0], T[1, 0], T[2, 0] = v1[0] / n1, v1[1] / n1, v1[2] / n1
        T[0, 1], T[1, 1], T[2, 1] = c0 / nc, c1 / nc, c2 / nc
        T[0, 2] = T[1, 0] * T[2, 1] - T[2, 0] * T[1, 1]
        T[1, 2] = T[2, 0] * T[0, 1] - T[0, 0] * T[2, 1]
        T[2, 2] = T[0, 0] * T[1, 1] - T[1, 0] * T[0, 1]
    for i in range(3):
        for j in range(3):
            out[i, j] = Tr[i, 0] * Tb[j, 0] + Tr[i, 1] * Tb[j, 1] + Tr[i, 2] * Tb[j, 2]
    return s_min


@njit
def triad_batch(
    b1: np.ndarray, b2: np.ndarray, r1: np.ndarray, r2: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`triad_into` of every row of ``b1, b2, r1, r2 (N, 3)``: ``(R (N, 3, 3), sin
    (N,))``."""
    out = np.empty((b1.shape[0], 3, 3))
    s = np.empty(b1.shape[0])
    for n in range(b1.shape[0]):
        s[n] = triad_into(b1[n], b2[n], r1[n], r2[n], out[n])
    return out, s


@njit(inline="always")
def body_vector_into(
    R: np.ndarray, r: np.ndarray, sigma: float, z: np.ndarray, out: np.ndarray
) -> None:
    """One measured direction of :class:`spacecraft.sensors.TwoVectorAttitude` for one
    spacecraft: ``out (3,)`` = exp(δ^) Rᵀ r, δ = σ z (z ~ N(0, I) the draw ``(3,)``; exp by
    Rodrigues, :func:`liecontrol._kernels.so3.exp9`)."""
    v0 = R[0, 0] * r[0] + R[1, 0] * r[1] + R[2, 0] * r[2]
    v1 = R[0, 1] * r[0] + R[1, 1] * r[1] + R[2, 1] * r[2]
    v2 = R[0, 2] * r[0] + R[1, 2] * r[1] + R[2, 2] * r[2]
    e = exp9(z[0] * sigma, z[1] * sigma, z[2] * sigma)
    out[0] = e[0] * v0 + e[1] * v1 + e[2] * v2
    out[1] = e[3] * v0 + e[4] * v1 + e[5] * v2
    out[2] = e[6] * v0 + e[7] * v1 + e[8] * v2


@njit
def body_vectors_batch(
    R: np.ndarray, r1: np.ndarray, r2: np.ndarray, s1: float, s2: float, Z1: np.ndarray,
    Z2: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """:func:`body_vector_into` of both directions of every spacecraft (``R (B, 3, 3)``,
    draws ``Z1``, ``Z2`` ``(B, 3)``): ``(b1, b2)``, each ``(B, 3)``."""
    b1 = np.empty((R.shape[0], 3))
    b2 = np.empty((R.shape[0], 3))
    for b in range(R.shape[0]):
        body_vector_into(R[b], r1, s1, Z1[b], b1[b])
        body_vector_into(R[b], r2, s2, Z2[b], b2[b])
    return b1, b2


@njit(inline="always")
def two_vector_into(
    R: np.ndarray, r1: np.ndarray, r2: np.ndarray, s1: float, s2: float, z1: np.ndarray,
    z2: np.ndarray, tmp: np.ndarray, out: np.ndarray,
) -> float:  # fmt: skip
    """One :class:`spacecraft.sensors.TwoVectorAttitude` sample of one spacecraft: the TRIAD
    attitude ``out (3, 3)`` (:func:`triad_into`) of b_i = exp(σ_i z_i^) Rᵀ r_i
    (:func:`body_vector_into`; Wang et al. 2015 §1.2); ``tmp`` ≥ 6 scratch. Returns TRIAD's
    smaller sin (the caller refuses a value below ``PARALLEL_TOL``)."""
    b1 = tmp[0:3]
    b2 = tmp[3:6]
    body_vector_into(R, r1, s1, z1, b1)
    body_vector_into(R, r2, s2, z2, b2)
    return triad_into(b1, b2, r1, r2, out)
