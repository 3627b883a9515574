"""Manifold UKF on SO(3) × ℝ³ (USQUE-style; beyond the paper).

The covariance lives on the 6-dim error δ = (δθ, δv) with the attitude error a rotation vector
in the body-frame tangent space of SO(3): x ⊞ δ = (q ⊗ Exp(δθ), v + δv) (see
:mod:`liecontrol.estimation.models`). No quaternion normalisation constraint enters the
covariance — the sigma points are unit quaternions by construction (Crassidis & Markley,
"Unscented filtering for spacecraft attitude estimation", JGCD 26(4), 2003; Hauberg et al.,
"Unscented Kalman filtering on Riemannian manifolds", 2013).

Predict::

    Xᵢ = x ⊞ Δᵢ  (Δ = 0, ±γ sⱼ),   Yᵢ = f(Xᵢ, u, T_s)    (one batched call)
    x⁻ = Y₀ ⊞ Σ Wᵢᵐ (Yᵢ ⊟ Y₀),   P⁻ = Σ Wᵢᶜ (Yᵢ ⊟ x⁻)(Yᵢ ⊟ x⁻)ᵀ + Q_err

Update::

    Xᵢ = x⁻ ⊞ Δᵢ,  Zᵢ = h(Xᵢ),  P_zz, P_xz = Σ Wᵢᶜ Δᵢ ΔZᵢᵀ,  δ = K ν,
    x = x⁻ ⊞ δ,  P = P⁻ − K P_zz Kᵀ

(the reset of the covariance to the new tangent space, a factor J_r(δθ) ≈ I + O(δθ), is
neglected, as in USQUE).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .base import DEFAULT_GATE_PROBABILITY, ManifoldFilter, tri_solve_gain
from .unscented import UTWeights, _sigma_points, ut_weights

__all__ = ["ManifoldUKF"]


class ManifoldUKF(ManifoldFilter):
    """UKF with tangent-space attitude sigma points (covariance dimension ``model.d``).

    ``model`` must provide ``n, d, m, f, h, boxplus, boxminus, Q_err, R, z_mean, z_residual,
    normalize`` (both models in :mod:`liecontrol.estimation.models` do). ``P0`` is d × d.
    """

    name = "ManifoldUKF"

    def __init__(self, model: Any, x0: object, P0: object, *, alpha: float = 1.0,
                 beta: float = 2.0, kappa: float | None = None,
                 pd_policy: str = "repair",
                 gate_probability: float | None = DEFAULT_GATE_PROBABILITY,
                 gate_max_consecutive: int = 10) -> None:
        super().__init__(model, x0, P0, pd_policy=pd_policy, gate_probability=gate_probability,
                         gate_max_consecutive=gate_max_consecutive)
        self.weights: UTWeights = ut_weights(int(model.d), alpha, beta, kappa)

    def _predict(self, u: np.ndarray, dt: float) -> None:
        w = self.weights
        m = self.model
        S = self._sqrt_or_repair(self._P, "P")
        D = _sigma_points(np.zeros(m.d), S, w.gamma)
        Y = m.f(m.boxplus(self._x[None, :], D), u, dt)
        E = m.boxminus(Y, Y[:1])
        xm = m.boxplus(Y[:1], (w.Wm @ E)[None, :])
        E = m.boxminus(Y, xm)
        P = (E * w.Wc[:, None]).T @ E + m.Q_err(dt)
        self._x = xm[0]
        self._P = 0.5 * (P + P.T)

    def _update(self, z: np.ndarray) -> None:
        w = self.weights
        m = self.model
        S = self._sqrt_or_repair(self._P, "P")
        D = _sigma_points(np.zeros(m.d), S, w.gamma)
        Z = m.h(m.boxplus(self._x[None, :], D))
        zm = m.z_mean(Z, w.Wm)
        dZ = m.z_residual(Z, zm)
        Wc = w.Wc[:, None]
        R_at = getattr(m, "R_at", None)  # state-dependent noise (MEKF's note), else R
        Pzz = (dZ * Wc).T @ dZ + (m.R if R_at is None else R_at(self._x))
        Sz = self._sqrt_or_repair(Pzz, "P_zz")
        Pzz = Sz @ Sz.T
        Pxz = (D * Wc).T @ dZ
        K = tri_solve_gain(Pxz, Sz)
        nu = m.z_residual(z, zm)
        self._record_innovation(nu, Pzz, Sz)
        self._x = m.boxplus(self._x[None, :], (K @ nu)[None, :])[0]
        P = self._P - K @ Pzz @ K.T
        S_new = self._sqrt_or_repair(0.5 * (P + P.T), "P")
        self._P = S_new @ S_new.T
