"""Process and measurement models for attitude estimation (Wang, Li, Zhang, Zhu & Li 2015).

Two models, both with state stored as a 7-vector and every function batched over a leading
dimension ``(N, ·)`` so that all 2n+1 sigma points go through one call:

* :class:`GyrolessAttitudeModel` — the paper's model. State ``x = (q₀, q₁, q₂, q₃, ω_x, ω_y, ω_z)``
  (scalar-first Hamilton quaternion, body → inertial; body rates). Continuous dynamics
  ``q̇ = ½ q ⊗ (0, ω)``, ``J ω̇ = −ω × Jω + N`` with the known control torque ``N = u`` held over
  the step, discretised with one classical RK4 step of length T_s and the quaternion normalised
  after the step (the paper's eqs. (5), (9), (11)).
* :class:`GyroAttitudeModel` — gyro-equipped variant. State ``x = (q, b)`` with ``b`` the gyro
  bias; input ``u = ω̃`` (gyro reading); ``q_{k+1} = q ⊗ exp((ω̃ − b) T_s)`` (exact for a rate
  held over the step), ``b`` a random walk (Farrenkopf's discrete noise, see :meth:`Q_err`).

Measurement (both): Euler angles ``z = (φ, θ, ψ)`` = (roll, pitch, yaw) of the aerospace 3-2-1
sequence (scipy ``"ZYX"``, ``R = Rz(ψ) Ry(θ) Rx(φ)``), as delivered by the two-vector attitude
solution (the paper's eq. (7)), with additive white noise of covariance ``R``::

    φ = atan2(2(q₀q₁ + q₂q₃), 1 − 2(q₁² + q₂²))
    θ = asin(2(q₀q₂ − q₃q₁))
    ψ = atan2(2(q₀q₃ + q₁q₂), 1 − 2(q₂² + q₃²))

Angle residuals are wrapped to (−π, π]. Pitch ±90° is the chart's singularity; ``h`` clips the
asin argument so it never returns NaN, and scenarios keep |θ| well below 90°.

Manifold interface (for :class:`~liecontrol.estimation.manifold_ukf.ManifoldUKF` and
:class:`~liecontrol.estimation.mekf.MEKF`): the error is ``δ = (δθ, δv)`` (6-vector) with the
attitude perturbed on the right (body frame), ``x ⊞ δ = (q ⊗ Exp(δθ), v + δv)`` and
``y ⊟ x = (Log(q_x⁻¹ ⊗ q_y), v_y − v_x)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._validation import (
    as_array,
    as_scalar,
    check_inertia_3x3,
    check_nonnegative,
    norm_last,
)
from ..charts import quaternion as quat
from ..integrators.rk import rk4_step_unchecked
from ..lie import so3
from . import _kernels as _k

__all__ = [
    "GyrolessAttitudeModel",
    "GyroAttitudeModel",
    "euler_rpy_from_quaternion",
    "euler_rpy_jacobian",
    "wrap_angle",
    "quat_boxplus",
    "quat_boxminus",
]


def wrap_angle(a: object) -> np.ndarray:
    """Wrap angles to (−π, π]; ``a`` any finite real array (lists and scalars accepted)."""
    return _wrap_angle(as_array(a, "a"))


def _wrap_angle(a: np.ndarray) -> np.ndarray:
    """:func:`wrap_angle` without validation (the models' residuals: validated upstream)."""
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


def euler_rpy_from_quaternion(q: object) -> np.ndarray:
    """(roll, pitch, yaw) of the ZYX sequence from (..., 4) scalar-first quaternions.

    The quaternion is normalised first (additive-UKF sigma points are not unit; the norm is
    computed without overflow). Checked in the tests against
    ``scipy.spatial.transform.Rotation.as_euler("ZYX")``. ``q`` must be finite, real, of shape
    ``(..., 4)`` and non-zero (``ValueError`` naming ``q``).
    """
    q = as_array(q, "q", (4,))
    if np.any(np.all(q == 0.0, axis=-1)):
        raise ValueError("q: zero quaternion (norm 0) does not represent a rotation")
    return _rpy_from_q(q / norm_last(q)[..., None])


def _rpy_from_q(q: np.ndarray) -> np.ndarray:
    """:func:`euler_rpy_from_quaternion` without validation (hot path: every sigma point)."""
    qn = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = qn[..., 0], qn[..., 1], qn[..., 2], qn[..., 3]
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return np.stack((roll, pitch, yaw), axis=-1)


def euler_rpy_jacobian(rpy: object) -> np.ndarray:
    """∂(φ, θ, ψ)/∂δθ for a body-frame perturbation R exp(δθ^): the 3-2-1 Euler-rate matrix

    B = [[1, sφ tθ, cφ tθ], [0, cφ, −sφ], [0, sφ/cθ, cφ/cθ]]  (Euler rates = B ω_body).

    Shape (..., 3) -> (..., 3, 3). Singular at |cos θ| < 1e-9 (gimbal lock): ``ValueError``.
    """
    rpy = as_array(rpy, "rpy", (3,))
    phi, th = rpy[..., 0], rpy[..., 1]
    c = np.cos(th)
    if np.any(np.abs(c) < 1e-9):
        raise ValueError("rpy: pitch at ±90° (Euler ZYX gimbal lock), Jacobian undefined")
    sp, cp, t = np.sin(phi), np.cos(phi), np.tan(th)
    zero, one = np.zeros_like(phi), np.ones_like(phi)
    return np.stack(
        (
            np.stack((one, sp * t, cp * t), axis=-1),
            np.stack((zero, cp, -sp), axis=-1),
            np.stack((zero, sp / c, cp / c), axis=-1),
        ),
        axis=-2,
    )


def quat_boxplus(q: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
    """q ⊗ Exp(δθ) (right, body-frame perturbation), batched."""
    return quat.multiply(q, quat.from_rotvec(dtheta))


def quat_boxminus(q_y: np.ndarray, q_x: np.ndarray) -> np.ndarray:
    """Log(q_x⁻¹ ⊗ q_y) ∈ ℝ³ (shortest rotation vector), batched."""
    dq = quat.multiply(quat.conjugate(q_x), q_y)
    return quat.to_rotvec(quat.normalize(dq))


def _boxplus_q(q: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
    """:func:`quat_boxplus` without validation (the models' ⊞, called on every sigma batch)."""
    return quat._mul(q, quat._from_rotvec_unchecked(dtheta))


def _boxminus_q(q_y: np.ndarray, q_x: np.ndarray) -> np.ndarray:
    """:func:`quat_boxminus` without validation (the models' ⊟)."""
    dq = quat._mul(q_x * np.array([1.0, -1.0, -1.0, -1.0]), q_y)
    return quat._to_rotvec_unchecked(dq / np.linalg.norm(dq, axis=-1, keepdims=True))


def _rk4(f, y: np.ndarray, h: float) -> np.ndarray:
    """One classical RK4 step of an autonomous ``f`` (batched). The unchecked variant
    is used because this is the filters' hot path and the inputs are validated upstream."""
    return rk4_step_unchecked(lambda t, yy: f(yy), 0.0, y, h)


class _EulerMeasurement:
    """Shared Euler-angle measurement (roll, pitch, yaw) with angle-aware residual and mean."""

    m: int = 3
    sigma_z: np.ndarray

    @property
    def R(self) -> np.ndarray:
        """Measurement noise covariance diag(σ_z²) (3×3)."""
        return np.diag(self.sigma_z**2)

    def R_at(self, x: np.ndarray) -> np.ndarray:
        """Measurement noise covariance at the state ``x`` (7,) (3×3).

        Without a body-frame sensor covariance (``sigma_body`` ``None``) this is :attr:`R`.
        With one — the covariance Σ of the small rotation δ of a star tracker's output,
        R_m = R exp(δ^) — the Euler angles carry z + B(z) δ to first order (B the 3-2-1
        Euler-rate matrix of :func:`euler_rpy_jacobian`), so their noise covariance is
        ``B(z) Σ B(z)ᵀ`` at ``z = h(x)``: anisotropic (a boresight model) and growing as
        1/cos θ with the pitch. :class:`~liecontrol.estimation.mekf.MEKF` and
        :class:`~liecontrol.estimation.manifold_ukf.ManifoldUKF` use it at the prior mean.
        """
        sb = getattr(self, "sigma_body", None)
        if sb is None:
            return self.R
        B = euler_rpy_jacobian(_rpy_from_q(np.asarray(x, dtype=np.float64)[:4]))
        Rk = B @ sb @ B.T
        return 0.5 * (Rk + Rk.T)

    def h(self, x: np.ndarray) -> np.ndarray:
        """Euler angles (roll, pitch, yaw) of the attitude in x, (N, 7) -> (N, 3)."""
        if x.ndim == 2 and x.dtype == np.float64:
            return _k.rpy_from_q(x)  # the sigma-point batch: one compiled call
        return _rpy_from_q(x[..., :4])

    def z_residual(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """a − b wrapped to (−π, π] per angle."""
        return _wrap_angle(a - b)

    def z_mean(self, Z: np.ndarray, Wm: np.ndarray) -> np.ndarray:
        """Weighted mean of angle sets taken relative to Z[0] so that ±π wrap does not bias it."""
        return _wrap_angle(Z[0] + Wm @ _wrap_angle(Z - Z[0]))

    def normalize(self, x: np.ndarray) -> np.ndarray:
        """Unit-normalise the quaternion part (the paper's eq. (9)); other components untouched."""
        q = x[..., :4]
        nrm = np.linalg.norm(q, axis=-1, keepdims=True)
        if np.any(nrm < 1e-12) or not np.all(np.isfinite(nrm)):
            raise ValueError("x: quaternion part has zero or non-finite norm")
        return np.concatenate((q / nrm, x[..., 4:]), axis=-1)

    def boxplus(self, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """x ⊞ δ = (q ⊗ Exp(δθ), v + δv)."""
        return np.concatenate((_boxplus_q(x[..., :4], d[..., :3]), x[..., 4:] + d[..., 3:]),
                              axis=-1)

    def boxminus(self, y: np.ndarray, x: np.ndarray) -> np.ndarray:
        """y ⊟ x = (Log(q_x⁻¹ ⊗ q_y), v_y − v_x)."""
        return np.concatenate((_boxminus_q(y[..., :4], x[..., :4]), y[..., 4:] - x[..., 4:]),
                              axis=-1)

    def measurement_jacobian(self, x: np.ndarray) -> np.ndarray:
        """∂z/∂δ (3×6) at x for the right perturbation: [B(φ, θ), 0]."""
        B = euler_rpy_jacobian(self.h(x))
        return np.concatenate((B, np.zeros(B.shape[:-1] + (3,))), axis=-1)


def _sigma3(v: object, name: str) -> np.ndarray:
    a = as_array(v, name)
    if a.shape not in ((), (1,), (3,)):
        raise ValueError(f"{name}: expected a scalar or shape (3,), got {a.shape}")
    a = np.broadcast_to(a, (3,)).astype(np.float64)
    check_nonnegative(a, name)
    return a


def _sigma(v: object, name: str, positive: bool = False) -> float:
    """A noise density: a finite real scalar ≥ 0 (> 0 if ``positive``)."""
    x = as_scalar(v, name)
    if x < 0.0 or (positive and x == 0.0):
        raise ValueError(f"{name}: must be {'> 0' if positive else '>= 0'}, got {x}")
    return x


@dataclass(frozen=True, eq=False)
class GyrolessAttitudeModel(_EulerMeasurement):
    """Gyroless model of Wang, Li, Zhang, Zhu & Li (2015): state (q, ω), input the known torque N.

    Parameters
    ----------
    J : (3, 3) inertia used by the filter [kg m²].
    sigma_q : additive quaternion process-noise density (UKF family) [1/√s]; Q_q = σ_q² T_s I₄.
    sigma_w : rate process-noise density [rad/s/√s]; Q_ω = σ_w² T_s I₃ (also the manifold/MEKF
        rate noise).
    sigma_theta : attitude process-noise density of the manifold filters [rad/√s]; defaults to
        2 σ_q (δθ ≈ 2 δq_v for small errors).
    sigma_z : Euler-angle noise std (scalar or 3) [rad].
    """

    J: np.ndarray
    sigma_q: float = 1e-6
    sigma_w: float = 1e-5
    sigma_z: np.ndarray = field(default_factory=lambda: np.full(3, 2e-3))
    sigma_theta: float | None = None
    n: int = field(default=7, init=False)
    d: int = field(default=6, init=False)

    def __post_init__(self) -> None:
        J = check_inertia_3x3(self.J, "J")
        object.__setattr__(self, "J", J.copy())
        object.__setattr__(self, "_Jinv", np.linalg.inv(J))
        object.__setattr__(self, "sigma_q", _sigma(self.sigma_q, "sigma_q"))
        object.__setattr__(self, "sigma_w", _sigma(self.sigma_w, "sigma_w"))
        object.__setattr__(self, "sigma_z", _sigma3(self.sigma_z, "sigma_z"))
        if np.any(self.sigma_z <= 0):
            raise ValueError("sigma_z: must be > 0 (measurement noise covariance must be PD)")
        st = 2.0 * self.sigma_q if self.sigma_theta is None else self.sigma_theta
        object.__setattr__(self, "sigma_theta", _sigma(st, "sigma_theta"))

    def rhs(self, x: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """Continuous dynamics ẋ = (½ q ⊗ (0, ω), J⁻¹(N − ω × Jω)), batched (N, 7)."""
        qw, qx, qy, qz = x[..., 0], x[..., 1], x[..., 2], x[..., 3]
        w = x[..., 4:]
        wx, wy, wz = x[..., 4], x[..., 5], x[..., 6]
        out = np.empty(np.broadcast_shapes(x.shape, np.shape(torque)[:-1] + (7,)))
        # ½ q ⊗ (0, ω) and ω × Jω written out: np.stack / np.cross overheads dominate otherwise
        out[..., 0] = -0.5 * (qx * wx + qy * wy + qz * wz)
        out[..., 1] = 0.5 * (qw * wx + qy * wz - qz * wy)
        out[..., 2] = 0.5 * (qw * wy - qx * wz + qz * wx)
        out[..., 3] = 0.5 * (qw * wz + qx * wy - qy * wx)
        Jw = w @ self.J.T
        c = np.empty_like(Jw)
        c[..., 0] = wy * Jw[..., 2] - wz * Jw[..., 1]
        c[..., 1] = wz * Jw[..., 0] - wx * Jw[..., 2]
        c[..., 2] = wx * Jw[..., 1] - wy * Jw[..., 0]
        out[..., 4:] = (torque - c) @ self._Jinv.T
        return out

    def f(self, x: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        """One RK4 step of length dt with the torque u held, then q normalised (the paper's
        eq. (11))."""
        torque = np.asarray(u, dtype=np.float64)
        if x.ndim == 2 and x.shape[1] == 7 and x.dtype == np.float64 and torque.shape == (3,):
            # the filters' case (all sigma points, one torque): one compiled call, same arithmetic
            y, ok = _k.gyroless_rk4(x, torque, float(dt), self.J, self._Jinv)
            if not ok:
                raise ValueError("x: quaternion part has zero or non-finite norm")
            return y
        y = _rk4(lambda yy: self.rhs(yy, torque), x, dt)
        return self.normalize(y)

    def Q(self, dt: float) -> np.ndarray:
        """Additive process noise for the 7-state UKF family: diag(σ_q² I₄, σ_w² I₃) dt."""
        return np.diag(np.r_[np.full(4, self.sigma_q**2), np.full(3, self.sigma_w**2)] * dt)

    def Q_err(self, dt: float) -> np.ndarray:
        """Process noise of the 6-dim error (δθ, δω): diag(σ_θ² I₃, σ_w² I₃) dt."""
        return np.diag(np.r_[np.full(3, self.sigma_theta**2), np.full(3, self.sigma_w**2)] * dt)


@dataclass(frozen=True, eq=False)
class GyroAttitudeModel(_EulerMeasurement):
    """Gyro-equipped model: state (q, b), input the gyro reading ω̃ (Farrenkopf gyro model).

    ω̃ = ω + b + η_v, ḃ = η_u; σ_v [rad/√s] angle random walk, σ_u [rad/s/√s] rate random walk.

    ``sigma_body`` (optional, 3×3 symmetric positive definite [rad²]): the covariance of the star
    tracker's attitude noise as a body-frame rotation vector (e.g.
    :attr:`spacecraft.sensors.StarTracker.covariance`). Given, the Euler-angle noise covariance
    is state dependent, :meth:`R_at` = B(z) Σ B(z)ᵀ, instead of the isotropic diag(σ_z²).
    """

    sigma_v: float = 1e-4
    sigma_u: float = 1e-6
    sigma_z: np.ndarray = field(default_factory=lambda: np.full(3, 2e-3))
    sigma_body: np.ndarray | None = None
    n: int = field(default=7, init=False)
    d: int = field(default=6, init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma_v", _sigma(self.sigma_v, "sigma_v", positive=True))
        object.__setattr__(self, "sigma_u", _sigma(self.sigma_u, "sigma_u"))
        object.__setattr__(self, "sigma_z", _sigma3(self.sigma_z, "sigma_z"))
        if np.any(self.sigma_z <= 0):
            raise ValueError("sigma_z: must be > 0 (measurement noise covariance must be PD)")
        if self.sigma_body is not None:
            S = as_array(self.sigma_body, "sigma_body")
            if S.shape != (3, 3):
                raise ValueError(f"sigma_body: expected shape (3, 3), got {S.shape}")
            if np.abs(S - S.T).max() > 1e-9 * max(float(np.abs(S).max()), 1e-300):
                raise ValueError("sigma_body: not symmetric")
            if not np.linalg.eigvalsh(S).min() > 0.0:
                raise ValueError("sigma_body: must be positive definite (a noise covariance)")
            S = 0.5 * (S + S.T)
            S.setflags(write=False)
            object.__setattr__(self, "sigma_body", S)

    def f(self, x: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        """q ⊗ Exp((ω̃ − b) dt), b unchanged."""
        w = np.asarray(u, dtype=np.float64) - x[..., 4:]
        q = quat.normalize(quat_boxplus(x[..., :4], w * dt))
        return np.concatenate((q, x[..., 4:]), axis=-1)

    def Q_err(self, dt: float) -> np.ndarray:
        """Discrete noise of (δθ, δb) (Farrenkopf / Crassidis & Junkins §7.2.4):
        [[σ_v² dt + σ_u² dt³/3, −σ_u² dt²/2], [−σ_u² dt²/2, σ_u² dt]] ⊗ I₃."""
        a = self.sigma_v**2 * dt + self.sigma_u**2 * dt**3 / 3.0
        c = -(self.sigma_u**2) * dt**2 / 2.0
        b = self.sigma_u**2 * dt
        I3 = np.eye(3)
        return np.block([[a * I3, c * I3], [c * I3, b * I3]])

    def error_transition(self, x: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        """Φ of the error (δθ, δb) over one step (right perturbation):
        δθ⁺ = Exp(−ω dt) δθ − J_r(ω dt) dt δb, δb⁺ = δb, with ω = ω̃ − b."""
        w = np.asarray(u, dtype=np.float64) - x[4:]
        phi = w * dt
        F = np.eye(6)
        F[:3, :3] = so3.exp(-phi)
        F[:3, 3:] = -so3.right_jacobian(phi) * dt
        return F
