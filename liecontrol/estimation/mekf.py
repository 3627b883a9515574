"""Multiplicative extended Kalman filter (MEKF) — the industry baseline.

Error state δ = (δθ, δv) with q_true = q̂ ⊗ Exp(δθ) (body-frame rotation vector); for the
gyro-equipped model v is the gyro bias (Lefferts, Markley & Shuster, "Kalman filtering for
spacecraft attitude estimation", JGCD 5(5), 1982; Markley & Crassidis, *Fundamentals of
Spacecraft Attitude Determination and Control*, 2014, §6.2)::

    predict:  x⁻ = f(x, u, T_s),   P⁻ = Φ P Φᵀ + Q_err
    update:   H = ∂h/∂δ at x⁻,  K = P⁻Hᵀ (H P⁻ Hᵀ + R)⁻¹,  δ = K ν,  x = x⁻ ⊞ δ,
              P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ        (Joseph form)

R is ``model.R_at(x⁻)`` when the model has it (a state-dependent noise covariance, e.g. a star
tracker's body-frame noise seen through the Euler angles), else ``model.R``.

Φ comes from ``model.error_transition(x, u, dt)`` when the model provides it (the gyro model:
Φ = [[Exp(−ω T_s), −J_r(ω T_s) T_s], [0, I]]); otherwise it is computed by central finite
differences through ⊞/⊟ with all 2d perturbed states propagated in one batched call (e.g. the
gyroless model). H = ``model.measurement_jacobian(x)`` = [B(φ, θ), 0] for Euler angles.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import as_array, check_output_finite, check_positive_scalar
from .base import ManifoldFilter, tri_solve_gain

__all__ = ["MEKF", "numerical_error_transition"]


def numerical_error_transition(model: Any, x: object, u: object, dt: float,
                               eps: float = 1e-6) -> np.ndarray:
    """Φ ≈ ∂(f(x ⊞ δ) ⊟ f(x))/∂δ by central differences (d × d).

    ``model`` needs ``n, d, f, boxplus, boxminus``; ``x`` (n,), ``u`` (3,) (lists accepted),
    ``dt > 0`` and the step ``eps > 0`` are validated (``ValueError`` naming them); a
    non-finite result raises instead of being returned."""
    for attr in ("n", "d", "f", "boxplus", "boxminus"):
        if not hasattr(model, attr):
            raise TypeError(f"model: has no attribute {attr!r} (a manifold filter model)")
    d = int(model.d)
    x = as_array(x, "x")
    if x.shape != (int(model.n),):
        raise ValueError(f"x: expected shape ({int(model.n)},), got {x.shape}")
    u = as_array(u, "u")
    dt = check_positive_scalar(dt, "dt")
    eps = check_positive_scalar(eps, "eps")
    E = np.concatenate((np.eye(d), -np.eye(d)), axis=0) * eps
    X = model.boxplus(np.broadcast_to(x, (2 * d, x.shape[0])), E)
    Y = model.f(np.concatenate((x[None, :], X), axis=0), u, dt)
    D = model.boxminus(Y[1:], Y[:1])
    return check_output_finite(((D[:d] - D[d:]) / (2.0 * eps)).T, "eps", "the difference quotient")


class MEKF(ManifoldFilter):
    """Multiplicative EKF; ``model`` as for :class:`~liecontrol.estimation.manifold_ukf.ManifoldUKF`
    plus ``measurement_jacobian`` (and optionally ``error_transition``). ``P0`` is d × d."""

    name = "MEKF"

    def _predict(self, u: np.ndarray, dt: float) -> None:
        m = self.model
        self._valid_P()  # a broken P is repaired (or raised) here, where it is the cause
        if hasattr(m, "error_transition"):
            F = m.error_transition(self._x, u, dt)
        else:
            F = numerical_error_transition(m, self._x, u, dt)
        self._x = m.f(self._x[None, :], u, dt)[0]
        P = F @ self._P @ F.T + m.Q_err(dt)
        self._P = 0.5 * (P + P.T)

    def _update(self, z: np.ndarray) -> None:
        m = self.model
        self._valid_P()
        H = m.measurement_jacobian(self._x)
        zhat = m.h(self._x[None, :])[0]
        # state-dependent measurement noise when the model has one (GyroAttitudeModel with a
        # body-frame star-tracker covariance: R = B Σ Bᵀ at the prior), else the constant R
        R_at = getattr(m, "R_at", None)
        Rk = m.R if R_at is None else R_at(self._x)
        Pzz = H @ self._P @ H.T + Rk
        Sz = self._sqrt_or_repair(0.5 * (Pzz + Pzz.T), "P_zz")
        Pzz = Sz @ Sz.T
        K = tri_solve_gain(self._P @ H.T, Sz)
        nu = m.z_residual(z, zhat)
        self._record_innovation(nu, Pzz, Sz)
        self._x = m.boxplus(self._x[None, :], (K @ nu)[None, :])[0]
        A = np.eye(m.d) - K @ H
        P = A @ self._P @ A.T + K @ Rk @ K.T
        S_new = self._sqrt_or_repair(0.5 * (P + P.T), "P")
        self._P = S_new @ S_new.T
