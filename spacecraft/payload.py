"""Rotating payload disturbance torque and attitude-jitter estimate (Wang, Chu, Zhang & Yuan 2016).

*Reconstructed* model (Wang et al. 2016, eq. (3), its symbols rebuilt from the text: the paper's
equation images are missing). A payload rotor A is hinged at ``hinge`` r_A (from the satellite
centre of mass, body axes) and spins about its own z axis at ω_pz relative to the bus;
α = phase + ∫ω_pz dt and R_A = R_mount R_z(α) maps payload axes to body axes. With mass m_A,
inertia I_A about the
hinge in payload axes (products of inertia I_xz, I_yz), hinge-to-CoM vector ρ_A (payload axes),
ω_p = (0, 0, ω_pz) and r_c = r_A + R_A ρ_A, the torque on the bus is

    T_p = − R_A I_A ω̇_p                 (speed change,      T_pw)
          − ω × (R_A I_A ω_p)           (gyroscopic,        T_pg)
          − R_A (ω_p × I_A ω_p)         (dynamic imbalance, T_pd)
          − m_A r_c × r̈_c               (static imbalance,  T_ps)

with r̈_c = R_A (ω_p × (ω_p × ρ_A) + ω̇_p × ρ_A) (bus rotation neglected in r̈_c, as the paper).

Properties (Wang et al. 2016 §1.2, tested): T_pd = ω_pz² R_A (I_yz, −I_xz, 0) is perpendicular to
the spin axis, sinusoidal at ω_pz, amplitude ω_pz² √(I_xz² + I_yz²); T_ps is a three-axis sinusoid
at ω_pz with amplitude ∝ ω_pz² m_A √(ρ_x² + ρ_y²) that depends on r_A; several payloads add.

Jitter estimate (Wang et al. 2016 §1.3, eqs. (10)–(14)). The closed attitude loop of axis j is
approximated by G_j(s) = 1/(J_jj (s² + 2ξω_n s + ω_n²)); a torque T_w sin(ω_p t) gives the steady
attitude oscillation of amplitude φ_j = T_w |G_j(iω_p)| and rate amplitude ω_p φ_j; without
control (or ω_p ≫ ω_n, eq. (14)) φ_j ≈ T_w/(J_jj ω_p²).

Calibration (:data:`ROTATING_PAYLOAD_EXAMPLE`). The paper gives J = diag(520, 450, 660) kg·m²,
a 90°/s payload and the predicted open-loop jitter 0.0012°, 0.0010°, 0.0011° (x, y, z), but no
mass properties. We chose a plausible scanning-instrument rotor (25 kg, hinge 0.35/0.25/0.60 m
from the CoM, spin axis tilted 30° from body z towards −y, then 20° about body z) and fitted the
four imbalance parameters (I_xz, I_yz, ρ_x, ρ_y) with :func:`fit_payload_imbalance` so the
open-loop amplitudes match the published ones; see ``docs/environment.md`` for the numbers.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np
from scipy.optimize import least_squares

from liecontrol._array_api import namespace
from liecontrol._jit import njit
from liecontrol._validation import (
    as_array,
    as_int,
    as_scalar,
    check_inertia_3x3,
    check_nonnegative,
    check_positive,
    check_positive_scalar,
    check_rotation_matrix,
)

from .disturbance_kernel import DisturbanceKernel

__all__ = [
    "SpinProfile",
    "ConstantSpin",
    "SpinRamp",
    "RotatingPayload",
    "RotatingPayloadTorque",
    "JitterEstimate",
    "harmonic_phasor",
    "jitter_estimate",
    "closed_loop_gain",
    "fit_payload_imbalance",
    "PAYLOAD_SATELLITE_J",
    "PAYLOAD_SPIN_RATE",
    "PAYLOAD_PUBLISHED_JITTER_DEG",
    "ROTATING_PAYLOAD_EXAMPLE",
]

TERM_NAMES = ("speed_change", "gyroscopic", "dynamic_imbalance", "static_imbalance")


@runtime_checkable
class SpinProfile(Protocol):
    """Relative spin of a payload: ``state(t) -> (angle, rate, accel)`` arrays of ``t``'s shape
    (angle without the payload's ``phase``) [rad, rad/s, rad/s²]."""

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class ConstantSpin:
    """Constant spin rate ω_pz [rad/s]: angle ω_pz t, ω̇_pz = 0."""

    rate: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "rate", as_scalar(self.rate, "rate"))

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        xp = namespace(t)
        t = xp.asarray(t, dtype=xp.float64)
        return self.rate * t, xp.full(t.shape, self.rate), xp.zeros(t.shape)


@dataclass(frozen=True)
class SpinRamp:
    """Speed change: ``rate0`` until ``t_start``, constant acceleration to ``rate1`` over
    ``duration`` [s] (> 0), then ``rate1``. The angle is the exact integral of the rate."""

    rate0: float
    rate1: float
    t_start: float
    duration: float

    def __post_init__(self) -> None:
        for name in ("rate0", "rate1", "t_start"):
            object.__setattr__(self, name, as_scalar(getattr(self, name), name))
        object.__setattr__(self, "duration", check_positive_scalar(self.duration, "duration"))

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        # NumPy or jax.numpy (the JAX route traces it); the compiled route's
        # rotating_payload_kernel evaluates the same operations in the same order
        xp = namespace(t)
        t = xp.asarray(t, dtype=xp.float64)
        a = (self.rate1 - self.rate0) / self.duration
        tau = xp.clip(t - self.t_start, 0.0, self.duration)  # time spent ramping so far
        after = xp.maximum(t - self.t_start - self.duration, 0.0)
        before = xp.minimum(t, self.t_start)
        angle = self.rate0 * before + self.rate0 * tau + 0.5 * a * (tau * tau) + self.rate1 * after
        rate = self.rate0 + a * tau
        ramping = (t > self.t_start) & (t < self.t_start + self.duration)
        accel = xp.where(ramping, a, 0.0)
        return angle, rate, accel


def _probe_profile(profile: SpinProfile) -> None:
    """``ValueError`` naming ``spin_rate`` when a user's profile does not return three finite
    values of ``t``'s shape at t = 0 (checked once, when the payload is built, instead of an
    unpacking error or a NaN state in the middle of a simulation)."""
    name = type(profile).__name__
    try:
        out = profile.state(np.zeros(()))
    except Exception as exc:  # noqa: BLE001 - reported with the profile's name
        raise ValueError(
            f"spin_rate: the profile {name}'s state(t) raised at t = 0: "
            f"{type(exc).__name__}: {exc}"
        ) from exc
    if not isinstance(out, (tuple, list)) or len(out) != 3:
        got = f"{len(out)} values" if isinstance(out, (tuple, list)) else type(out).__name__
        raise ValueError(
            f"spin_rate: the profile {name}'s state(t) must return (angle, rate, accel), "
            f"got {got}"
        )
    for label, v in zip(("angle", "rate", "accel"), out, strict=True):
        a = np.asarray(v, dtype=np.float64)
        if a.shape != () or not np.isfinite(a):
            raise ValueError(
                f"spin_rate: the profile {name}'s state(t) at t = 0 gave a {label} that is "
                f"not one finite value (shape {a.shape}, {a.tolist()!r})"
            )


def _rz(alpha: np.ndarray) -> np.ndarray:
    c, s = np.cos(alpha), np.sin(alpha)
    z, o = np.zeros_like(alpha), np.ones_like(alpha)
    return np.stack(
        (np.stack((c, -s, z), -1), np.stack((s, c, z), -1), np.stack((z, z, o), -1)), -2
    )


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class RotatingPayload:
    """One rotating payload (*reconstructed* from Wang et al. 2016).

    Args:
        mass: m_A [kg] (≥ 0).
        inertia: I_A ``(3, 3)`` about the hinge in payload axes [kg·m²], symmetric positive
            definite; the off-diagonal (0, 2), (1, 2) entries are I_xz, I_yz. It must be
            consistent with ``mass`` and ``com_offset`` (the inertia about the CoM,
            I_A − m_A(|ρ|² I − ρρᵀ), positive semi-definite: parallel-axis theorem).
        hinge: r_A ``(3,)`` hinge position from the satellite CoM, body axes [m].
        com_offset: ρ_A ``(3,)`` hinge → payload CoM, payload axes [m].
        spin_rate: constant ω_pz [rad/s] or a :class:`SpinProfile` (speed changes).
        mount: R_mount ``(3, 3)`` rotation, payload axes at α = 0 → body axes.
        phase: α at t = 0 [rad].
    """

    mass: float
    inertia: np.ndarray
    hinge: np.ndarray
    com_offset: np.ndarray
    spin_rate: float | SpinProfile
    mount: np.ndarray | None = None
    phase: float = 0.0
    _profile: SpinProfile = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        m = check_nonnegative(self.mass, "mass")
        if not isinstance(m, float):
            raise ValueError(f"mass: expected a scalar, got shape {np.shape(self.mass)}")
        object.__setattr__(self, "mass", m)
        I_A = check_inertia_3x3(self.inertia, "inertia")
        for name in ("hinge", "com_offset"):
            v = as_array(getattr(self, name), name)
            if v.shape != (3,):
                raise ValueError(f"{name}: expected shape (3,), got {v.shape}")
            object.__setattr__(self, name, _readonly(v))
        rho = self.com_offset
        with np.errstate(over="ignore", invalid="ignore"):
            I_cm = I_A - m * (rho @ rho * np.eye(3) - np.outer(rho, rho))
        if not np.all(np.isfinite(I_cm)):
            raise ValueError(
                "com_offset: too large for this mass (m·|ρ|² overflows float64 in the "
                "parallel-axis inertia)"
            )
        lam = float(np.linalg.eigvalsh(0.5 * (I_cm + I_cm.T)).min())
        if lam < -1e-9 * max(float(np.abs(I_A).max()), 1e-300):
            raise ValueError(
                "inertia: inconsistent with mass and com_offset (inertia about the payload CoM "
                f"has a negative principal moment {lam:.3e}; parallel-axis theorem)"
            )
        object.__setattr__(self, "inertia", _readonly(I_A))
        M = np.eye(3) if self.mount is None else check_rotation_matrix(self.mount, "mount")
        if M.shape != (3, 3):
            raise ValueError(f"mount: expected shape (3, 3), got {M.shape}")
        object.__setattr__(self, "mount", _readonly(M))
        object.__setattr__(self, "phase", as_scalar(self.phase, "phase"))
        sp = self.spin_rate
        if isinstance(sp, SpinProfile):
            prof = sp
            if type(sp) not in (ConstantSpin, SpinRamp):
                _probe_profile(sp)
        else:
            try:
                rate = as_scalar(sp, "spin_rate")
            except ValueError as exc:
                raise ValueError(
                    f"{exc} (spin_rate is a constant rate [rad/s] or a SpinProfile: an object "
                    "with state(t) -> (angle, rate, accel))"
                ) from None
            prof = ConstantSpin(rate)
            object.__setattr__(self, "spin_rate", prof.rate)
        object.__setattr__(self, "_profile", prof)

    @property
    def constant_rate(self) -> float | None:
        """ω_pz if the spin rate is constant, else ``None``."""
        return self._profile.rate if isinstance(self._profile, ConstantSpin) else None

    def spin_state(self, t: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(α, ω_pz, ω̇_pz) at ``t`` (scalar or array)."""
        t = as_array(t, "t")
        ang, rate, acc = self._profile.state(t)
        return self.phase + ang, rate, acc

    def payload_to_body(self, t: object) -> np.ndarray:
        """R_A(t) = R_mount R_z(α(t)), ``t.shape + (3, 3)``."""
        alpha, _, _ = self.spin_state(t)
        return self.mount @ _rz(alpha)

    def torque_terms(self, t: object, omega: object) -> dict[str, np.ndarray]:
        """The four torque terms of the module docstring on the bus [N·m], body axes.

        ``t`` scalar or ``(...,)`` and ``omega`` (bus body rate) ``(..., 3)`` broadcast together;
        each term has shape ``broadcast(t.shape, omega.shape[:-1]) + (3,)``. Keys:
        ``speed_change``, ``gyroscopic``, ``dynamic_imbalance``, ``static_imbalance``.
        """
        omega = as_array(omega, "omega", (3,))
        t = as_array(t, "t")
        alpha, rate, acc = self.spin_state(t)
        R_A = self.mount @ _rz(alpha)
        I_A, rho, m = self.inertia, self.com_offset, self.mass
        zero = np.zeros_like(rate)
        w_p = np.stack((zero, zero, rate), axis=-1)  # payload axes
        wd_p = np.stack((zero, zero, acc), axis=-1)
        Iw = w_p @ I_A.T  # I_A ω_p (payload axes)
        shape = np.broadcast_shapes(t.shape, omega.shape[:-1]) + (3,)

        def body(v: np.ndarray) -> np.ndarray:
            return np.einsum("...ij,...j->...i", R_A, v)

        speed = -body(wd_p @ I_A.T)
        gyro = -np.cross(omega, body(Iw))
        dyn = -body(np.cross(w_p, Iw))
        rc = self.hinge + body(np.broadcast_to(rho, w_p.shape))
        rc_dd = body(np.cross(w_p, np.cross(w_p, rho)) + np.cross(wd_p, rho))
        stat = -m * np.cross(rc, rc_dd)
        terms = (speed, gyro, dyn, stat)
        return {k: np.broadcast_to(v, shape).copy() for k, v in zip(TERM_NAMES, terms, strict=True)}

    def torque(self, t: object, omega: object) -> np.ndarray:
        """Total payload torque T_p on the bus (sum of :meth:`torque_terms`)."""
        return sum(self.torque_terms(t, omega).values())

    def _float_params(self) -> tuple:
        """(mount columns 0, 1, 2; I_A[0:3, 2]; ρ; hinge; m) as Python floats, cached on first
        use (the fields are read-only arrays, so the copy cannot go stale)."""
        cached = self.__dict__.get("_floats")
        if cached is None:
            M = self.mount.tolist()
            cached = (
                tuple(r[0] for r in M),
                tuple(r[1] for r in M),
                tuple(r[2] for r in M),
                tuple(self.inertia[:, 2].tolist()),
                tuple(self.com_offset.tolist()),
                tuple(self.hinge.tolist()),
                self.mass,
            )
            object.__setattr__(self, "_floats", cached)
        return cached

    def torque_at(self, t: float, omega: np.ndarray) -> np.ndarray:
        """:meth:`torque` for a scalar ``t`` and ``omega`` ``(..., 3)``, inputs trusted (the
        plant has validated the state): the same four terms with 3-vector algebra on scalars —
        Python floats on the NumPy route (the plant calls the source at every integration
        stage), JAX scalars when ``t`` or ``omega`` is traced (the JAX route of
        :mod:`spacecraft.differentiable`, which flies the built-in spin profiles)."""
        xp = namespace(t, omega)
        if type(self._profile) is ConstantSpin:
            rate, acc = self._profile.rate, 0.0
            alpha = self.phase + rate * t
        elif xp is np:
            ang, r_, a_ = self._profile.state(np.float64(t))
            alpha, rate, acc = self.phase + float(ang), float(r_), float(a_)
        else:
            ang, rate, acc = self._profile.state(t)
            alpha = self.phase + ang
        cos, sin = (math.cos, math.sin) if xp is np else (xp.cos, xp.sin)
        c, s = cos(alpha), sin(alpha)
        # every 3-vector below is a tuple of Python floats (the parameters' float copies are
        # made once, _float_params): the same per-component IEEE operations in the same order
        # as on (3,) arrays, ~5× cheaper than ~20 numpy calls on 3-element arrays
        m0, m1, a2, (i02, i12, i22), (r0, r1, r2), hinge, m = self._float_params()
        # R_A = M R_z(α): only its first two columns change with α
        a0 = tuple(c * x + s * y for x, y in zip(m0, m1, strict=True))
        a1 = tuple(-s * x + c * y for x, y in zip(m0, m1, strict=True))
        Ie = tuple(  # R_A I_A e_z
            x * i02 + y * i12 + z * i22 for x, y, z in zip(a0, a1, a2, strict=True)
        )
        ez_x_Ie = tuple(x * (-i12) + y * i02 for x, y in zip(a0, a1, strict=True))
        rc = tuple(
            hh + x * r0 + y * r1 + z * r2 for hh, x, y, z in zip(hinge, a0, a1, a2, strict=True)
        )
        k0 = -rate * rate * r0 - acc * r1
        k1 = -rate * rate * r1 + acc * r0
        rdd = tuple(x * k0 + y * k1 for x, y in zip(a0, a1, strict=True))
        rc_x_rdd = (
            rc[1] * rdd[2] - rc[2] * rdd[1],
            rc[2] * rdd[0] - rc[0] * rdd[2],
            rc[0] * rdd[1] - rc[1] * rdd[0],
        )
        rr = rate * rate
        const = tuple(
            -acc * x - rr * y - m * z for x, y, z in zip(Ie, ez_x_Ie, rc_x_rdd, strict=True)
        )
        h = tuple(rate * x for x in Ie)
        if xp is np and np.shape(omega) == (1, 3):
            wx, wy, wz = omega[0].tolist()
            return np.array(
                [
                    [
                        const[0] - (wy * h[2] - wz * h[1]),
                        const[1] - (wz * h[0] - wx * h[2]),
                        const[2] - (wx * h[1] - wy * h[0]),
                    ]
                ]
            )
        wx, wy, wz = omega[..., 0], omega[..., 1], omega[..., 2]
        return xp.stack(
            (
                const[0] - (wy * h[2] - wz * h[1]),
                const[1] - (wz * h[0] - wx * h[2]),
                const[2] - (wx * h[1] - wy * h[0]),
            ),
            axis=-1,
        )


#: parameters per payload in :func:`rotating_payload_kernel`'s row
_PAYLOAD_WIDTH = 25
#: the spin profile's code in the row: constant rate, or a :class:`SpinRamp`
_SPIN_CONSTANT = 0.0
_SPIN_RAMP = 1.0


@njit(inline="always")
def _payload_component(
    params: np.ndarray, p: int, i: int, c: float, s: float, k0: float, k1: float
) -> tuple[float, float, float, float]:  # fmt: skip
    """Component ``i`` of R_A I_A e_z, e_z × I_A e_z (rotated), r_c and r̈_c for the payload whose
    row starts at ``p`` (:func:`rotating_payload_kernel`; R_A's first two columns from cos α,
    sin α)."""
    i02 = params[p + 11]
    i12 = params[p + 12]
    i22 = params[p + 13]
    m0 = params[p + 2 + i]
    m1 = params[p + 5 + i]
    a2 = params[p + 8 + i]
    a0 = c * m0 + s * m1
    a1 = -s * m0 + c * m1
    Ie = a0 * i02 + a1 * i12 + a2 * i22
    ex = a0 * (-i12) + a1 * i02
    rc = params[p + 17 + i] + a0 * params[p + 14] + a1 * params[p + 15] + a2 * params[p + 16]
    return Ie, ex, rc, a0 * k0 + a1 * k1


@njit
def rotating_payload_kernel(
    t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
) -> None:
    """:class:`RotatingPayloadTorque` for one spacecraft (the disturbance seam,
    :mod:`spacecraft.disturbance_kernel`): per payload the spin state of its profile — a
    constant rate, or :meth:`SpinRamp.state` in its order of operations — and the four terms of
    :meth:`RotatingPayload.torque_at` in its order of operations, summed over the payloads in
    their order. ``params = (count, then per payload: phase, ω_pz (a ramp's rate0), the
    mount's columns 0, 1, 2, I_A[:, 2], ρ, hinge, m, the profile's code (0 constant, 1 ramp),
    rate1, t_start, duration)``. Reads ``t`` and ``omega`` only."""
    n = int(params[0])
    w0 = omega[0]
    w1 = omega[1]
    w2 = omega[2]
    t0 = 0.0
    t1 = 0.0
    t2 = 0.0
    for k in range(n):
        p = 1 + _PAYLOAD_WIDTH * k
        if params[p + 21] == _SPIN_RAMP:
            rate0 = params[p + 1]
            rate1 = params[p + 22]
            t_start = params[p + 23]
            duration = params[p + 24]
            a = (rate1 - rate0) / duration
            tau = min(max(t - t_start, 0.0), duration)  # np.clip's order: max, then min
            after = max(t - t_start - duration, 0.0)
            before = min(t, t_start)
            angle = rate0 * before + rate0 * tau + 0.5 * a * (tau * tau) + rate1 * after
            rate = rate0 + a * tau
            acc = a if (t > t_start and t < t_start + duration) else 0.0
            alpha = params[p] + angle
        else:
            rate = params[p + 1]
            acc = 0.0
            alpha = params[p] + rate * t
        c = math.cos(alpha)
        s = math.sin(alpha)
        r0 = params[p + 14]
        r1 = params[p + 15]
        m = params[p + 20]
        k0 = -rate * rate * r0 - acc * r1
        k1 = -rate * rate * r1 + acc * r0
        rr = rate * rate
        Ie0, ex0, rc0, rd0 = _payload_component(params, p, 0, c, s, k0, k1)
        Ie1, ex1, rc1, rd1 = _payload_component(params, p, 1, c, s, k0, k1)
        Ie2, ex2, rc2, rd2 = _payload_component(params, p, 2, c, s, k0, k1)
        Ie = (Ie0, Ie1, Ie2)
        ex = (ex0, ex1, ex2)
        rc = (rc0, rc1, rc2)
        rdd = (rd0, rd1, rd2)
        x0 = rc[1] * rdd[2] - rc[2] * rdd[1]
        x1 = rc[2] * rdd[0] - rc[0] * rdd[2]
        x2 = rc[0] * rdd[1] - rc[1] * rdd[0]
        c0 = -acc * Ie[0] - rr * ex[0] - m * x0
        c1 = -acc * Ie[1] - rr * ex[1] - m * x1
        c2 = -acc * Ie[2] - rr * ex[2] - m * x2
        h0 = rate * Ie[0]
        h1 = rate * Ie[1]
        h2 = rate * Ie[2]
        g0 = c0 - (w1 * h2 - w2 * h1)
        g1 = c1 - (w2 * h0 - w0 * h2)
        g2 = c2 - (w0 * h1 - w1 * h0)
        if k == 0:
            t0, t1, t2 = g0, g1, g2
        else:
            t0 += g0
            t1 += g1
            t2 += g2
    out[0] = t0
    out[1] = t1
    out[2] = t2


@dataclass(frozen=True)
class RotatingPayloadTorque:
    """Disturbance source ``(t, R, omega) -> (B, 3)``: the sum of several payloads' torques."""

    payloads: Sequence[RotatingPayload]
    #: the torque depends on t and ω only: the plant may pass ``R=None`` in its RK stages
    uses_attitude: ClassVar[bool] = False

    def __post_init__(self) -> None:
        ps = (self.payloads,) if isinstance(self.payloads, RotatingPayload) else self.payloads
        if isinstance(ps, (str, bytes)) or not isinstance(ps, Iterable):
            raise ValueError(
                f"payloads: expected a RotatingPayload or a sequence of them, got "
                f"{type(ps).__name__}"
            )
        ps = tuple(ps)
        if len(ps) == 0:
            raise ValueError("payloads: at least one RotatingPayload is required")
        for i, p in enumerate(ps):
            if not isinstance(p, RotatingPayload):
                raise ValueError(f"payloads: entry {i} is {type(p).__name__}, not RotatingPayload")
        object.__setattr__(self, "payloads", ps)

    def torque_terms(self, t: float, omega: np.ndarray) -> dict[str, np.ndarray]:
        """Per-term torques summed over the payloads."""
        out: dict[str, np.ndarray] = {}
        for p in self.payloads:
            for k, v in p.torque_terms(t, omega).items():
                out[k] = out[k] + v if k in out else v
        return out

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        return self.torque_at(float(t), R, np.asarray(omega, dtype=np.float64))

    def torque_at(self, t: float, R: object, omega: np.ndarray) -> np.ndarray:
        """The summed torque ``omega.shape`` at a scalar time, inputs trusted: the one formula
        of the NumPy and JAX routes (:meth:`RotatingPayload.torque_at`; ``R`` is not read)."""
        total = self.payloads[0].torque_at(t, omega)
        for p in self.payloads[1:]:
            total = total + p.torque_at(t, omega)
        return total

    def fused_kernel(self) -> DisturbanceKernel | None:
        """:func:`rotating_payload_kernel` and its parameters, shared by the batch, when every
        payload spins at a constant rate or follows a :class:`SpinRamp`; ``None`` (the Python
        loop, :meth:`kernel_reason` says why) for another :class:`SpinProfile`."""
        if self.kernel_reason():
            return None
        row: list[float] = [float(len(self.payloads))]
        for p in self.payloads:
            m0, m1, a2, ie, rho, hinge, m = p._float_params()
            prof = p._profile
            if isinstance(prof, SpinRamp):
                spin = [prof.rate0]
                tail = [_SPIN_RAMP, prof.rate1, prof.t_start, prof.duration]
            else:
                spin = [prof.rate]
                tail = [_SPIN_CONSTANT, 0.0, 0.0, 1.0]
            row += [p.phase, *spin, *m0, *m1, *a2, *ie, *rho, *hinge, m, *tail]
        return DisturbanceKernel(
            rotating_payload_kernel, np.array(row, dtype=np.float64), uses_attitude=False
        )

    def kernel_reason(self) -> str:
        """Why the source has no compiled kernel (``""`` when it has one)."""
        for i, p in enumerate(self.payloads):
            if type(p._profile) not in (ConstantSpin, SpinRamp):
                return (
                    f"the disturbance RotatingPayloadTorque has no compiled kernel for payload "
                    f"{i}'s spin profile {type(p._profile).__name__} (ConstantSpin and SpinRamp "
                    "only)"
                )
        return ""


# ---------------------------------------------------------------------------------------------
# Jitter estimate


def harmonic_phasor(payload: RotatingPayload, n_samples: int = 16) -> tuple[np.ndarray, float]:
    """First-harmonic phasor P ``(3,)`` (complex) of the payload torque at a bus at rest, so that
    T(t) = Re[P e^{iα(t)}], and its frequency ω_pz [rad/s]; needs a constant spin rate.

    At ω = 0 and ω̇_p = 0 the torque is exactly a first harmonic of α, so the
    ``n_samples``-point DFT over one revolution is exact to round-off.
    """
    if not isinstance(payload, RotatingPayload):
        raise ValueError(f"payload: expected a RotatingPayload, got {type(payload).__name__}")
    n_samples = as_int(n_samples, "n_samples", 3)  # three points resolve a first harmonic
    if n_samples > 1_000_000:
        raise ValueError(f"n_samples: at most 1e6 (the DFT is exact from 3), got {n_samples}")
    rate = payload.constant_rate
    if rate is None or rate == 0.0:
        raise ValueError("payload: the jitter estimate needs a constant, non-zero spin rate")
    k = np.arange(n_samples)
    alpha = 2.0 * np.pi * k / n_samples
    t = (alpha - payload.phase) / rate
    T = payload.torque(t, np.zeros(3))
    P = 2.0 / n_samples * np.einsum("k,kj->j", np.exp(-1j * alpha), T)
    return P, abs(rate)


def closed_loop_gain(J_jj: object, omega: object, omega_n: float, zeta: float) -> np.ndarray:
    """|G_j(iω)| = 1/(J_jj |ω_n² − ω² + 2iξω_nω|) (Wang et al. 2016 eq. (10)); ω_n = 0 gives the
    open-loop 1/(J_jj ω²).

    ``J_jj`` > 0 and ``omega`` broadcast together; ``omega_n``, ``zeta`` ≥ 0 are scalars. The
    gain is infinite at an undamped resonance (ω = ω_n with ξ = 0, or ω = 0 open loop): that
    raises ``ValueError`` instead of returning inf.
    """
    J = as_array(J_jj, "J_jj")
    if J.size == 0 or np.any(J <= 0):
        raise ValueError("J_jj: expected positive moments of inertia")
    w = as_array(omega, "omega")
    wn = as_scalar(omega_n, "omega_n")
    if wn < 0:
        raise ValueError(f"omega_n: must be >= 0, got {wn}")
    z = as_scalar(zeta, "zeta")
    if z < 0:
        raise ValueError(f"zeta: must be >= 0, got {z}")
    try:
        np.broadcast_shapes(J.shape, w.shape)
    except ValueError:
        raise ValueError(
            f"omega: shape {w.shape} does not broadcast with J_jj's shape {J.shape}"
        ) from None
    return _closed_loop_gain(J, w, wn, z)


def _closed_loop_gain(J: np.ndarray, w: np.ndarray, wn: float, z: float) -> np.ndarray:
    """:func:`closed_loop_gain` on validated arrays. |ω_n² − ω² + 2iξω_nω| is formed with
    ``hypot`` of the real and imaginary parts (no complex arithmetic, no spurious overflow of
    the square); a huge ω_n or ω gives the correct limit 0."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        den = J * np.hypot(wn * wn - w * w, 2.0 * z * wn * w)
        gain = 1.0 / den
    if not np.all(np.isfinite(gain)):
        raise ValueError(
            "zeta: the gain is infinite at an undamped resonance (ω = ω_n with ζ = 0); give ζ > 0"
            if z == 0.0 and wn > 0.0
            else "omega: the open-loop gain 1/(J ω²) is infinite at ω = 0"
        )
    return gain


@dataclass(frozen=True)
class JitterEstimate:
    """Per-axis steady oscillation amplitudes (Wang et al. 2016 §1.3).

    Attributes:
        attitude, rate: closed-loop attitude [rad] and rate [rad/s] amplitudes ``(3,)``.
        open_loop_attitude, open_loop_rate: the same without control, T_w/(J_jj ω_p²) and
            T_w/(J_jj ω_p).
        torque_amplitude: ``(K, 3)`` per-axis torque amplitude of each distinct frequency.
        frequencies: ``(K,)`` the distinct frequencies ω_p [rad/s].
    """

    attitude: np.ndarray
    rate: np.ndarray
    open_loop_attitude: np.ndarray
    open_loop_rate: np.ndarray
    torque_amplitude: np.ndarray
    frequencies: np.ndarray


def jitter_estimate(
    source: RotatingPayload | Sequence[RotatingPayload] | object,
    J: object,
    omega_n: float = 0.0,
    zeta: float = 0.707,
    omega_p: float | None = None,
) -> JitterEstimate:
    """Steady attitude/rate oscillation amplitudes per body axis (Wang et al. 2016 eqs. (13)–(14)).

    φ_j = Σ_k T_w,kj |G_j(iω_k)|,   φ̇_j = Σ_k ω_k T_w,kj |G_j(iω_k)|,
    G_j(s) = 1/(J_jj (s² + 2ξω_n s + ω_n²)),  open loop: |G_j| = 1/(J_jj ω_k²).

    Args:
        source: a :class:`RotatingPayload`, a sequence of them (same-frequency payloads add as
            phasors; distinct frequencies add in amplitude — the peak over a long window), or
            per-axis torque amplitudes T_w ``(3,)`` [N·m] (then ``omega_p`` is required).
        J: inertia ``(3, 3)`` (its diagonal is used, as the paper) [kg·m²].
        omega_n: closed-loop natural frequency [rad/s] (≥ 0; 0 = no control).
        zeta: closed-loop damping ratio ξ (≥ 0).
        omega_p: disturbance frequency [rad/s] for amplitude input.
    """
    Jm = check_inertia_3x3(J, "J")
    Jd = np.diag(Jm).copy()
    omega_n = as_scalar(omega_n, "omega_n")
    if omega_n < 0:
        raise ValueError(f"omega_n: must be >= 0, got {omega_n}")
    zeta = as_scalar(zeta, "zeta")
    if zeta < 0:
        raise ValueError(f"zeta: must be >= 0, got {zeta}")
    if omega_p is not None:
        omega_p = check_positive_scalar(omega_p, "omega_p")
    if isinstance(source, RotatingPayload):
        source = [source]
    if isinstance(source, (list, tuple)) and source and isinstance(source[0], RotatingPayload):
        groups: list[tuple[float, np.ndarray]] = []
        for p in source:
            if not isinstance(p, RotatingPayload):
                raise ValueError(f"source: mixed entries ({type(p).__name__})")
            P, w = harmonic_phasor(p)
            for i, (wg, Pg) in enumerate(groups):
                if np.isclose(wg, w, rtol=1e-12, atol=0.0):
                    groups[i] = (wg, Pg + P)
                    break
            else:
                groups.append((w, P))
        freqs = np.array([g[0] for g in groups])
        Tw = np.array([np.abs(g[1]) for g in groups])
    else:
        Tw = as_array(source, "source")
        if Tw.shape != (3,):
            raise ValueError(f"source: expected torque amplitudes of shape (3,), got {Tw.shape}")
        if omega_p is None:
            raise ValueError("omega_p: required when source is a torque amplitude")
        freqs = np.array([omega_p])
        Tw = np.abs(Tw)[None, :]
    gain = _closed_loop_gain(Jd[None, :], freqs[:, None], omega_n, zeta)
    gain_ol = _closed_loop_gain(Jd[None, :], freqs[:, None], 0.0, 0.0)
    att = Tw * gain
    att_ol = Tw * gain_ol
    return JitterEstimate(
        attitude=att.sum(axis=0),
        rate=(att * freqs[:, None]).sum(axis=0),
        open_loop_attitude=att_ol.sum(axis=0),
        open_loop_rate=(att_ol * freqs[:, None]).sum(axis=0),
        torque_amplitude=Tw,
        frequencies=freqs,
    )


def fit_payload_imbalance(
    target_attitude: object,
    J: object,
    spin_rate: float,
    *,
    mass: float,
    principal_inertia: object,
    hinge: object,
    mount: object = None,
    com_offset_z: float = 0.0,
    x0: object = None,
) -> RotatingPayload:
    """Payload whose **open-loop** jitter amplitudes T_w,j/(J_jj ω_p²) match ``target_attitude``
    ``(3,)`` [rad], by fitting its imbalance (I_xz, I_yz, ρ_x, ρ_y) with the rest fixed.

    The torque phasor is linear in p = (I_xz, I_yz, ρ_x, ρ_y) (ρ_z fixed), so the per-axis
    amplitudes |(A p)_j| are fitted by nonlinear least squares on their relative errors
    (scipy ``least_squares``). Three equations, four unknowns: ``x0`` picks the solution.
    The diagonal of the payload inertia about the hinge is ``principal_inertia`` ``(3,)``.

    Raises ``ValueError`` (``target_attitude``) if no payload of this geometry reaches the
    targets within 1 % (e.g. a spin axis along a body axis forces equal amplitudes on the two
    perpendicular axes).
    """
    target = as_array(target_attitude, "target_attitude")
    if target.shape != (3,) or np.any(target <= 0):
        raise ValueError("target_attitude: expected 3 positive amplitudes [rad]")
    diag = as_array(principal_inertia, "principal_inertia")
    if diag.shape != (3,):
        raise ValueError(f"principal_inertia: expected shape (3,), got {diag.shape}")
    rate = check_positive(spin_rate, "spin_rate")

    def make(p: np.ndarray) -> RotatingPayload:
        I_A = np.diag(diag)
        I_A[0, 2] = I_A[2, 0] = p[0]
        I_A[1, 2] = I_A[2, 1] = p[1]
        return RotatingPayload(
            mass=mass,
            inertia=I_A,
            hinge=hinge,
            com_offset=np.array([p[2], p[3], com_offset_z]),
            spin_rate=rate,
            mount=mount,
        )

    def resid(p: np.ndarray) -> np.ndarray:
        est = jitter_estimate(make(p), J)
        return est.open_loop_attitude / target - 1.0

    start = np.array([1e-3, 1e-3, 1e-4, 1e-4]) if x0 is None else as_array(x0, "x0")
    sol = least_squares(resid, start, x_scale=np.array([1e-3, 1e-3, 1e-4, 1e-4]), xtol=1e-14)
    if np.max(np.abs(sol.fun)) > 1e-2:
        raise ValueError(
            "target_attitude: not reachable with this payload geometry "
            f"(best relative error {np.max(np.abs(sol.fun)):.2%})"
        )
    return make(sol.x)


# ---------------------------------------------------------------------------------------------
# The rotating-payload paper's case (Wang, Chu, Zhang & Yuan 2016)

#: Satellite inertia of Wang, Chu, Zhang & Yuan (2016) [kg·m²].
PAYLOAD_SATELLITE_J = np.diag([520.0, 450.0, 660.0])
#: Nominal payload rate of Wang, Chu, Zhang & Yuan (2016), 90°/s [rad/s].
PAYLOAD_SPIN_RATE = float(np.deg2rad(90.0))
#: Published predicted steady jitter amplitudes (x, y, z) [deg], Wang et al. 2016 §3.
PAYLOAD_PUBLISHED_JITTER_DEG = np.array([0.0012, 0.0010, 0.0011])


def _example_payload_mount() -> np.ndarray:
    # spin axis tilted 30° from body z towards −y (about x), then the mount turned 20° about z
    a, b = np.deg2rad(30.0), np.deg2rad(20.0)
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Rz = np.array([[np.cos(b), -np.sin(b), 0], [np.sin(b), np.cos(b), 0], [0, 0, 1]])
    return Rz @ Rx


#: Calibrated example rotating payload (see the module docstring and docs/environment.md): the
#: output of :func:`fit_payload_imbalance` for the published amplitudes, rounded to 4 significant
#: digits.
ROTATING_PAYLOAD_EXAMPLE = RotatingPayload(
    mass=25.0,
    inertia=np.array([[2.5, 0.0, -7.529e-3], [0.0, 2.5, 1.631e-2], [-7.529e-3, 1.631e-2, 1.8]]),
    hinge=np.array([0.35, 0.25, 0.60]),
    com_offset=np.array([1.037e-4, 5.452e-4, 0.2]),
    spin_rate=PAYLOAD_SPIN_RATE,
    mount=_example_payload_mount(),
)
