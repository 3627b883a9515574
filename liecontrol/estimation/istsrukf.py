"""ISTSRUKF — improved strong-tracking square-root UKF, the filter of Wang, Li, Zhang, Zhu & Li
(2015).

*Reconstructed*: the paper's step list (eqs. (42)–(60)) was lost in extraction; the text states
the three ingredients, implemented here as follows.

1. Strong tracking with multiple fading factors in the Jacobian-free equivalent form, applied
   symmetrically (two factor matrices Λ^½ · Λ^½), exactly as
   :mod:`liecontrol.estimation.stukf` but in square-root form:
   ``S_{k+1|k} = qr{[Λ^½ S_f, √Q]}``.
2. The covariance of propagated points is taken about the **central sigma point** (Julier,
   Uhlmann & Durrant-Whyte 2000, modified form, the paper's ref. [3])::

       S_f = qr{[√Wᵢ (Yᵢ − Y₀)]_{i=1…2n}},   S_z = qr{[√Wᵢ (Zᵢ − Z₀)]_{i=1…2n}, √R]},

   so only the positive weights Wᵢ = 1/(2(n+λ)) enter: no Cholesky downdate with a negative
   W₀ᶜ can fail (the paper's stated defect of the standard SRUKF, its eqs. (48)–(49)).
3. Joseph-form square-root measurement update with the equivalent H = (P⁻¹ P_xz)ᵀ
   (the paper's eq. (56); Kaminski, Bryson & Schmidt 1971)::

       S_{k+1} = qr{[(I − K H) S_{k+1|k},  K √R]},   K = (P_xz / S_zᵀ) / S_z,

   which is a sum of squares — positive semi-definite by construction, unlike the m
   successive downdates of the standard SRUKF.

The quaternion is normalised after each predict and update (the paper's eq. (9)).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .base import psd_sqrt, tri_solve_gain
from .cholesky import chol_solve, tria
from .stukf import FadingState, StrongTrackingParams, fading_factors
from .ukf import _AdditiveUT

__all__ = ["ISTSRUKF"]


class ISTSRUKF(_AdditiveUT):
    """Improved strong-tracking square-root UKF (see module docstring).

    Parameters as :class:`~liecontrol.estimation.ukf.UKF` plus ``tracking``
    (:class:`~liecontrol.estimation.stukf.StrongTrackingParams`).
    """

    name = "ISTSRUKF"
    square_root = True

    def __init__(self, model: Any, x0: object, P0: object, *,
                 tracking: StrongTrackingParams | None = None, **kw: Any) -> None:
        # one outlier is gated, a second large innovation in a row is taken as a real change
        # of the dynamics and passed on to the fading factors (that is what they are for)
        kw.setdefault("gate_max_consecutive", 1)
        super().__init__(model, x0, P0, **kw)
        self.tracking = tracking if tracking is not None else StrongTrackingParams()
        self.tracking.alpha_vector(self.cov_dim)
        self._fading_state = FadingState()
        n = int(model.n)
        self._Sf = np.zeros((n, n))
        self._SQ = np.zeros((n, n))
        self._Q_last = np.zeros((n, n))

    def _central_sqrt(self, D: np.ndarray, extra: np.ndarray | None) -> np.ndarray:
        """qr{[√Wᵢ (Dᵢ − D₀)]_{i≥1}, extra} — positive weights only."""
        w = self.weights.Wc[1:]
        A = ((D[1:] - D[0]) * np.sqrt(w)[:, None]).T
        if extra is not None:
            A = np.concatenate((A, extra), axis=1)
        return tria(A)

    def _sqrt_checked(self, S: np.ndarray, name: str) -> np.ndarray:
        """A QR factor with a zero pivot is singular: apply the PD policy."""
        if np.all(np.diagonal(S) > 0.0):
            return S
        return self._repair(S @ S.T, name, "zero pivot in the square root")

    def _predict(self, u: np.ndarray, dt: float) -> None:
        Y, xm = self._propagate(self._S, u, dt)
        Q = self.model.Q(dt)
        self._Q_last = Q
        self._SQ = psd_sqrt(Q)
        self._Sf = self._central_sqrt(Y, None)
        self._x = xm
        self._S = self._sqrt_checked(tria(np.concatenate((self._Sf, self._SQ), axis=1)), "S")

    def _update(self, z: np.ndarray) -> None:
        model = self.model
        # 1) unfaded innovation and equivalent H for the fading factors
        _, Z, zm, dX, _ = self._measure(self._x, self._S)
        Pxz = self._central_cross(dX, Z)
        gamma = model.z_residual(z, zm)
        # χ² gate on the unfaded innovation (central form, like S_z below), before the fading
        # state sees it: an outlier is rejected instead of inflating the covariance
        Sz0 = self._central_sqrt(model.z_residual(Z, Z[0]), psd_sqrt(model.R))
        if np.all(np.diagonal(Sz0) > 0.0):
            self._gate(gamma, Sz0)
        Pf = self._Sf @ self._Sf.T
        mu, info = fading_factors(gamma, self._S, Pf, Pxz, self._Q_last, model.R,
                                  self.tracking, self._fading_state)
        self._diag["fading"] = mu
        self._diag["fading_c"] = info["c"]
        # 2) faded prior in square-root form, sigma points redrawn from it
        Sp = tria(np.concatenate((np.sqrt(mu)[:, None] * self._Sf, self._SQ), axis=1))
        Sp = self._sqrt_checked(Sp, "S")
        _, Z, zm, dX, _ = self._measure(self._x, Sp)
        SR = psd_sqrt(model.R)
        Sz = self._sqrt_checked(self._central_sqrt(model.z_residual(Z, Z[0]), SR), "S_z")
        Pxz = self._central_cross(dX, Z)
        K = tri_solve_gain(Pxz, Sz)
        # equivalent measurement matrix H = (P⁻¹ P_xz)ᵀ from the faded prior
        H = chol_solve(Sp, Pxz).T
        nu = model.z_residual(z, zm)
        self._record_innovation(nu, Sz @ Sz.T, Sz)
        A = np.eye(model.n) - K @ H
        S = tria(np.concatenate((A @ Sp, K @ SR), axis=1))
        self._S = self._sqrt_checked(S, "S")
        self._x = model.normalize((self._x + K @ nu)[None, :])[0]

    def _central_cross(self, dX: np.ndarray, Z: np.ndarray) -> np.ndarray:
        """P_xz = Σ_{i≥1} Wᵢ (χᵢ − χ₀)(Zᵢ − Z₀)ᵀ (χ₀ = x so Δχ₀ = 0)."""
        w = self.weights.Wc[1:]
        dZ = self.model.z_residual(Z[1:], Z[0])
        return ((dX[1:] - dX[0]) * w[:, None]).T @ dZ
