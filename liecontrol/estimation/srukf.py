"""Square-root UKF (Van der Merwe & Wan, ICASSP 2001, additive-noise form).

Propagates the lower Cholesky factor S (P = S Sᵀ) directly::

    S⁻ = qr{[√W₁ᶜ (Y_{1:2n} − x⁻), √Q]},          S⁻ = cholupdate(S⁻, Y₀ − x⁻, W₀ᶜ)
    S_z = qr{[√W₁ᶜ (Z_{1:2n} − ẑ), √R]},           S_z = cholupdate(S_z, Z₀ − ẑ, W₀ᶜ)
    K = (P_xz / S_zᵀ) / S_z                          (two triangular solves)
    S = cholupdate(S⁻, K S_z, −1)                    (m successive rank-1 downdates)

``cholupdate(S, v, w)`` adds ``w v vᵀ``; a negative W₀ᶜ is a downdate. A downdate that fails
(the matrix would become indefinite) triggers the PD policy: ``"repair"`` recomputes the
dense covariance and takes the nearest PD factor; ``"raise"`` raises
:class:`~liecontrol.estimation.cholesky.NotPositiveDefiniteError`. Quaternion normalised as in
:class:`~liecontrol.estimation.ukf.UKF`.
"""

from __future__ import annotations

import numpy as np

from .base import psd_sqrt, tri_solve_gain
from .cholesky import NotPositiveDefiniteError, cholupdate, tria
from .ukf import _AdditiveUT

__all__ = ["SRUKF"]


def _weighted_sqrt(dY: np.ndarray, Wc: np.ndarray, noise_sqrt: np.ndarray) -> np.ndarray:
    """qr{[√Wᵢ ΔY_{1:2n}, √Noise]} then the signed rank-1 term of ΔY₀ (W₀ may be negative).

    Raises NotPositiveDefiniteError when the zeroth-point downdate fails.
    """
    A = np.concatenate(((dY[1:] * np.sqrt(Wc[1:])[:, None]).T, noise_sqrt), axis=1)
    S = tria(A)
    S = _ensure_positive_diag(S)
    w0 = Wc[0]
    if w0 != 0.0:
        S = cholupdate(S, np.sqrt(abs(w0)) * dY[0], 1.0 if w0 > 0 else -1.0)
    return S


def _ensure_positive_diag(S: np.ndarray) -> np.ndarray:
    d = np.diagonal(S)
    if np.any(d <= 0.0):
        raise NotPositiveDefiniteError("S: square root has a zero pivot (rank-deficient)")
    return S


class SRUKF(_AdditiveUT):
    """Square-root UKF; same parameters as :class:`~liecontrol.estimation.ukf.UKF`."""

    name = "SRUKF"
    square_root = True

    def _dense_fallback(self, dY: np.ndarray, Wc: np.ndarray, noise: np.ndarray, name: str,
                        why: str) -> np.ndarray:
        P = (dY * Wc[:, None]).T @ dY + noise
        return self._repair(P, name, why)

    def _predict(self, u: np.ndarray, dt: float) -> None:
        w = self.weights
        Y, xm = self._propagate(self._S, u, dt)
        dY = Y - xm
        Q = self.model.Q(dt)
        try:
            S = _weighted_sqrt(dY, w.Wc, psd_sqrt(Q))
        except NotPositiveDefiniteError as exc:
            S = self._dense_fallback(dY, w.Wc, Q, "S", str(exc))
        self._x = xm
        self._S = S

    def _update(self, z: np.ndarray) -> None:
        w = self.weights
        _, _, zm, dX, dZ = self._measure(self._x, self._S)
        R = self.model.R
        try:
            Sz = _weighted_sqrt(dZ, w.Wc, psd_sqrt(R))
        except NotPositiveDefiniteError as exc:
            Sz = self._dense_fallback(dZ, w.Wc, R, "S_z", str(exc))
        Pxz = (dX * w.Wc[:, None]).T @ dZ
        K = tri_solve_gain(Pxz, Sz)
        nu = self.model.z_residual(z, zm)
        self._record_innovation(nu, Sz @ Sz.T, Sz)
        U = K @ Sz
        try:
            S = cholupdate(self._S, U, -1.0)
        except NotPositiveDefiniteError as exc:
            S = self._repair(self._S @ self._S.T - U @ U.T, "S", str(exc))
        self._x = self.model.normalize((self._x + K @ nu)[None, :])[0]
        self._S = S
