"""Planned rest-to-rest eigenaxis slews: a jerk-limited bang–coast–bang reference.

A rest-to-rest slew from ``R_start`` to ``R_target`` about the fixed eigenaxis ``â`` (the shortest
rotation, ``θ â = log(R_targetᵀ R_start)``, ``0 < θ ≤ π``) flies the angle ``s(t)`` from 0 to θ
along a 7-segment S-curve (jerk ``+j, 0, −j, 0, −j, 0, +j``): the "smoothed bang–coast–bang" of
the time-optimal eigenaxis manoeuvre under a rate, an acceleration and a jerk limit
(B. Wie, *Space Vehicle Dynamics and Control*, 2nd ed., AIAA, 2008, §7.3; the segment algebra is
the classical jerk-limited point-to-point profile, e.g. L. Biagiotti and C. Melchiorri,
*Trajectory Planning for Automatic Machines and Robots*, Springer, 2008, §3.4):

- jerk phase ``T_j = a/j`` and acceleration phase ``T_a = T_j + v/a`` when ``v·j ≥ a²``;
  otherwise the acceleration limit is never reached: ``T_j = √(v/j)``, ``T_a = 2T_j``;
- coast ``T_v = θ/v − T_a``; if that is negative the rate limit is not reached and the peak
  rate ``v'`` solves ``v' T_a(v') = θ``: ``v' = a(−T_j + √(T_j² + 4θ/a))/2`` (acceleration limit
  reached) or ``v' = (θ√j/2)^(2/3)`` (it is not);
- slew time ``T = 2T_a + T_v``.

The reference is ``R_d(t) = R_target exp((θ − s(t)) â^)``, so in the desired body frame
``ω_d = −ṡ â`` and ``ω̇_d = −s̈ â`` (``â`` is fixed by ``exp(φ â^)``): every tracking controller
gets the rate and acceleration feed-forward; the torque the profile implies on a rigid body of
inertia ``J`` is ``τ_ff = J ω̇_d + ω_d × J ω_d`` (:meth:`EigenaxisSlewProfile.feedforward_torque`).
The acceleration limit of a torque-limited actuator about this axis is
:func:`eigenaxis_accel_limit`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._validation import as_array, as_scalar, check_inertia_3x3, check_rotation_matrix
from ..lie import so3
from .base import AttitudeReference

__all__ = ["EigenaxisSlewProfile", "scurve_timing", "eigenaxis_accel_limit"]


def _positive(x: object, name: str) -> float:
    v = as_scalar(x, name)
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name}: must be a finite number > 0, got {x!r}")
    return v


def _timing(theta: float, v: float, a: float, j: float) -> tuple[float, float, float, float]:
    """``(T_j, T_a, T_v, v_peak)`` of the S-curve (no validation)."""
    if theta <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if v * j >= a * a:
        tj, ta = a / j, a / j + v / a
    else:
        tj = math.sqrt(v / j)
        ta = 2.0 * tj
    tv = theta / v - ta
    if tv >= 0.0:
        return tj, ta, tv, v
    # the rate limit is not reached: the peak rate v' covers θ with no coast; the acceleration
    # limit is reached when θ ≥ 2a³/j² (the triangular-acceleration profile that just reaches a)
    if theta * j * j >= 2.0 * a * a * a:
        tj = a / j
        vp = 0.5 * a * (-tj + math.sqrt(tj * tj + 4.0 * theta / a))
        return tj, tj + vp / a, 0.0, vp
    vp = (0.5 * theta * math.sqrt(j)) ** (2.0 / 3.0)
    tj = math.sqrt(vp / j)
    return tj, 2.0 * tj, 0.0, vp


def scurve_timing(
    angle: float, max_rate: float, max_accel: float, max_jerk: float
) -> dict[str, float]:
    """Segment times of the jerk-limited rest-to-rest profile over ``angle`` [rad].

    Returns ``{"jerk_time": T_j, "accel_time": T_a, "coast_time": T_v, "peak_rate": v',
    "peak_accel": a', "duration": 2T_a + T_v}`` (seconds, rad/s, rad/s²).

    Raises:
        ValueError: ``angle`` < 0 or a limit ≤ 0 (the message names it).
    """
    theta = as_scalar(angle, "angle")
    if not math.isfinite(theta) or theta < 0.0:
        raise ValueError(f"angle: must be a finite number ≥ 0, got {angle!r}")
    v = _positive(max_rate, "max_rate")
    a = _positive(max_accel, "max_accel")
    j = _positive(max_jerk, "max_jerk")
    tj, ta, tv, vp = _timing(theta, v, a, j)
    return {
        "jerk_time": tj,
        "accel_time": ta,
        "coast_time": tv,
        "peak_rate": vp,
        "peak_accel": j * tj,
        "duration": 2.0 * ta + tv,
    }


def eigenaxis_accel_limit(J: object, axis: object, max_torque: object) -> float:
    """Largest angular acceleration [rad/s²] about the unit ``axis`` that a per-axis torque box
    ``max_torque`` [N·m] (scalar or 3 values) delivers at rest: ``min_i τ_i / |(J â)_i|``.

    The gyroscopic torque ``ω × Jω`` vanishes about an eigenaxis only for a principal axis; keep
    a margin on the acceleration limit for it (it is ``O(v²)``).
    """
    Jm = check_inertia_3x3(J, "J")
    ax = as_array(axis, "axis", (3,))
    n = float(np.linalg.norm(ax)) if ax.shape == (3,) else 0.0
    if not (math.isfinite(n) and n > 0.0):
        raise ValueError(f"axis: expected a finite non-zero 3-vector, got {axis!r}")
    ax = ax / n
    tau = as_array(max_torque, "max_torque")
    if tau.shape not in ((), (3,)) or np.any(tau <= 0.0):
        raise ValueError(f"max_torque: expected a value > 0 or 3 of them, got {max_torque!r}")
    tau = np.broadcast_to(tau, (3,))
    Ja = np.abs(Jm @ ax)
    with np.errstate(divide="ignore"):
        lim = np.where(Ja > 0.0, tau / np.where(Ja > 0.0, Ja, 1.0), np.inf)
    return float(lim.min())


@dataclass(frozen=True)
class EigenaxisSlewProfile:
    """Rest-to-rest eigenaxis slew reference ``t -> AttitudeReference`` (see the module text).

    Args:
        R_start: attitude at ``t0`` (body → inertial).
        R_target: attitude at ``t0 + duration`` and after.
        max_rate: body-rate limit about the eigenaxis [rad/s] > 0.
        max_accel: angular-acceleration limit [rad/s²] > 0 (torque/inertia about the axis,
            :func:`eigenaxis_accel_limit`).
        max_jerk: jerk limit [rad/s³] > 0.
        t0: start time [s].
        duration: requested slew time [s], or ``None`` for the shortest one within the limits;
            a longer one lowers the coast rate (bisection) so the slew ends at ``t0 + duration``.
            Shorter than the limits allow: ``ValueError`` naming ``duration``.

    Attributes (computed): ``angle`` θ [rad], ``axis`` â, ``slew_time`` T [s],
    ``peak_rate`` [rad/s], ``timing`` (:func:`scurve_timing` of the flown profile).
    """

    R_start: np.ndarray
    R_target: np.ndarray
    max_rate: float
    max_accel: float
    max_jerk: float
    t0: float = 0.0
    duration: float | None = None
    angle: float = field(init=False)
    axis: np.ndarray = field(init=False, repr=False)
    slew_time: float = field(init=False)
    peak_rate: float = field(init=False)
    timing: dict[str, float] = field(init=False, repr=False, compare=False)
    _knots: tuple[tuple[float, float, float, float, float], ...] = field(
        init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        Rs = check_rotation_matrix(self.R_start, "R_start")
        Rt = check_rotation_matrix(self.R_target, "R_target")
        if Rs.shape != (3, 3):
            raise ValueError(f"R_start: expected one (3, 3) rotation, got shape {Rs.shape}")
        if Rt.shape != (3, 3):
            raise ValueError(f"R_target: expected one (3, 3) rotation, got shape {Rt.shape}")
        v = _positive(self.max_rate, "max_rate")
        a = _positive(self.max_accel, "max_accel")
        j = _positive(self.max_jerk, "max_jerk")
        t0 = as_scalar(self.t0, "t0")
        if not math.isfinite(t0):
            raise ValueError(f"t0: must be finite, got {self.t0!r}")
        rv = np.asarray(so3.log(Rt.T @ Rs), dtype=np.float64)
        theta = float(np.linalg.norm(rv))
        axis = rv / theta if theta > 0.0 else np.array([1.0, 0.0, 0.0])
        tj, ta, tv, vp = _timing(theta, v, a, j)
        t_min = 2.0 * ta + tv
        if self.duration is not None:
            d = _positive(self.duration, "duration")
            if d < t_min * (1.0 - 1e-12):
                raise ValueError(
                    f"duration: {d:g} s is shorter than the {t_min:g} s the limits allow for "
                    f"this {math.degrees(theta):g}° slew (max_rate {v:g} rad/s, max_accel "
                    f"{a:g} rad/s², max_jerk {j:g} rad/s³)"
                )
            if theta > 0.0 and d > t_min:
                lo, hi = 0.0, vp  # total time decreases as the coast rate rises
                for _ in range(200):
                    mid = 0.5 * (lo + hi)
                    tj_, ta_, tv_, vp_ = _timing(theta, mid, a, j)
                    if 2.0 * ta_ + tv_ > d:
                        lo = mid
                    else:
                        hi = mid
                tj, ta, tv, vp = _timing(theta, hi, a, j)
            object.__setattr__(self, "duration", d)
        Rs, Rt = Rs.copy(), Rt.copy()
        Rs.setflags(write=False)
        Rt.setflags(write=False)
        axis.setflags(write=False)
        for name, val in (
            ("R_start", Rs),
            ("R_target", Rt),
            ("max_rate", v),
            ("max_accel", a),
            ("max_jerk", j),
            ("t0", t0),
            ("angle", theta),
            ("axis", axis),
            ("peak_rate", vp),
        ):
            object.__setattr__(self, name, val)
        # knots: (start time, jerk, s, ṡ, s̈) of each of the 7 segments, then the end
        jerks = (j, 0.0, -j, 0.0, -j, 0.0, j)
        lengths = (tj, ta - 2.0 * tj, tj, tv, tj, ta - 2.0 * tj, tj)
        knots = []
        t, s, sd, sdd = 0.0, 0.0, 0.0, 0.0
        for jk, L in zip(jerks, lengths, strict=True):
            L = max(L, 0.0)
            knots.append((t, jk, s, sd, sdd))
            s, sd, sdd = (
                s + sd * L + sdd * L * L / 2.0 + jk * L**3 / 6.0,
                sd + sdd * L + jk * L * L / 2.0,
                sdd + jk * L,
            )
            t += L
        object.__setattr__(self, "_knots", tuple(knots))
        object.__setattr__(self, "slew_time", t)
        object.__setattr__(
            self,
            "timing",
            {
                "jerk_time": tj,
                "accel_time": ta,
                "coast_time": tv,
                "peak_rate": vp,
                "peak_accel": j * tj,
                "duration": t,
            },
        )

    def angle_at(self, t: float) -> tuple[float, float, float, float]:
        """``(s, ṡ, s̈, s⃛)`` [rad, rad/s, rad/s², rad/s³]: the angle flown about ``axis`` at ``t``
        (0 before ``t0``, θ from ``t0 + slew_time`` on)."""
        tau = as_scalar(t, "t") - self.t0
        if not math.isfinite(tau):
            raise ValueError(f"t: must be finite, got {t!r}")
        if tau <= 0.0:
            return 0.0, 0.0, 0.0, 0.0
        if tau >= self.slew_time:
            return self.angle, 0.0, 0.0, 0.0
        k = 0
        for i, kn in enumerate(self._knots):
            if kn[0] <= tau:
                k = i
        t_k, jk, s, sd, sdd = self._knots[k]
        h = tau - t_k
        return (
            min(s + sd * h + sdd * h * h / 2.0 + jk * h**3 / 6.0, self.angle),
            sd + sdd * h + jk * h * h / 2.0,
            sdd + jk * h,
            jk,
        )

    def _angles_at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, ṡ, s̈)`` of :meth:`angle_at` at every time of a finite ``t`` ``(N,)``, the same
        arithmetic vectorised (the segment by search over the knots' start times)."""
        tau = t - self.t0
        starts = np.array([kn[0] for kn in self._knots])
        k = np.clip(np.searchsorted(starts, tau, side="right") - 1, 0, len(starts) - 1)
        kn = np.array(self._knots)[k]  # (N, 5): start, jerk, s, ṡ, s̈
        t_k, jk, s, sd, sdd = kn.T
        h = tau - t_k
        pos = np.minimum(s + sd * h + sdd * h * h / 2.0 + jk * h**3 / 6.0, self.angle)
        vel = sd + sdd * h + jk * h * h / 2.0
        acc = sdd + jk * h
        before, after = tau <= 0.0, tau >= self.slew_time
        pos = np.where(before, 0.0, np.where(after, self.angle, pos))
        vel = np.where(before | after, 0.0, vel)
        acc = np.where(before | after, 0.0, acc)
        return pos, vel, acc

    def samples(self, times: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reference at every time of ``times`` ``(N,)`` in one vectorised call (the
        sampling protocol of :mod:`liecontrol.control.reference`): ``(N, 3, 3)``, ``(N, 3)``,
        ``(N, 3)``, equal to ``self(times[k])`` sample by sample (to rounding)."""
        t = as_array(times, "times")
        if t.ndim != 1:
            raise ValueError(f"times: expected shape (N,), got {t.shape}")
        if not np.all(np.isfinite(t)):
            raise ValueError("times: must be finite")
        s, sd, sdd = self._angles_at(t)
        R_d = self.R_target @ so3.exp((self.angle - s)[:, None] * self.axis)
        return R_d, -sd[:, None] * self.axis, -sdd[:, None] * self.axis

    def __call__(self, t: float) -> AttitudeReference:
        s, sd, sdd, _ = self.angle_at(t)
        R_d = self.R_target @ so3.exp((self.angle - s) * self.axis)
        return AttitudeReference.unchecked(
            np.asarray(R_d, dtype=np.float64), -sd * self.axis, -sdd * self.axis
        )

    def feedforward_torque(self, t: float, J: object) -> np.ndarray:
        """Torque ``J ω̇_d + ω_d × J ω_d`` [N·m] that flies the profile on a rigid body of inertia
        ``J`` tracking it exactly (desired body axes)."""
        Jm = check_inertia_3x3(J, "J")
        ref = self(t)
        w = ref.omega_d
        return Jm @ ref.omega_dot_d + np.cross(w, Jm @ w)
