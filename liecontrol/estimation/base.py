"""Common filter interface for ``liecontrol.estimation`` (SPEC §7, §9).

Every filter exposes::

    f.predict(u, dt)          # time update with input u held over dt
    f.update(z) -> bool       # measurement update; False when the measurement was rejected
    f.step(u, dt, z) -> bool  # predict then update
    f.x, f.P, f.S             # state (stored form), covariance, lower square root (P = S Sᵀ)
    f.innovation              # last innovation ν = z − ẑ (wrapped), or None
    f.innovation_cov          # its predicted covariance P_zz, or None
    f.diagnostics             # per-step dict: "fading" (μ per state), "repaired",
                              # "update_rejected", "reason", "nis"

Bad input (SPEC §9): a wrong ``z``/``u`` shape, ``dt ≤ 0``, non-PD initial covariance →
``ValueError`` naming the argument. A non-finite measurement is **rejected**: the update is
skipped, the prediction kept, the reason logged (``logging`` logger ``liecontrol.estimation``)
and returned in ``diagnostics``. A covariance that loses positive-definiteness is repaired
(``pd_policy="repair"``, default: nearest PD matrix, flagged in ``diagnostics["repaired"]``) or
raises :class:`~liecontrol.estimation.cholesky.NotPositiveDefiniteError`
(``pd_policy="raise"``); NaN never propagates silently.
"""

from __future__ import annotations

import abc
import logging
from typing import Any

import numpy as np

from .._validation import as_array, check_positive
from .cholesky import NotPositiveDefiniteError, chol_solve, nearest_pd_sqrt, solve_lower
from .unscented import cholesky_or_raise

__all__ = ["Filter", "ManifoldFilter", "logger", "psd_sqrt"]

logger = logging.getLogger("liecontrol.estimation")

_PD_POLICIES = ("repair", "raise")


def psd_sqrt(Q: np.ndarray) -> np.ndarray:
    """A square root A with A Aᵀ = Q for a symmetric PSD Q (Cholesky, or eigen when singular)."""
    try:
        return np.linalg.cholesky(Q)
    except np.linalg.LinAlgError:
        w, U = np.linalg.eigh(0.5 * (Q + Q.T))
        if w.min() < -1e-12 * max(1.0, abs(w.max())):
            raise ValueError(f"Q: not positive semi-definite (eigenvalue {w.min():.3e})") from None
        return U * np.sqrt(np.maximum(w, 0.0))


def tri_solve_gain(Pxz: np.ndarray, Sz: np.ndarray) -> np.ndarray:
    """K = P_xz (S_z S_zᵀ)⁻¹ by two triangular solves (Van der Merwe & Wan 2001, eq. 27)."""
    return chol_solve(Sz, np.ascontiguousarray(Pxz.T)).T


class Filter(abc.ABC):
    """Base class: validation, rejection of bad measurements, PD repair policy, diagnostics.

    Subclasses implement :meth:`_predict` and :meth:`_update` and store their covariance either
    as ``self._P`` (covariance form) or ``self._S`` (square-root form).
    """

    name: str = "filter"
    square_root: bool = False

    def __init__(self, model: Any, x0: object, P0: object, *, pd_policy: str = "repair") -> None:
        if pd_policy not in _PD_POLICIES:
            raise ValueError(f"pd_policy: must be one of {_PD_POLICIES}, got {pd_policy!r}")
        self.model = model
        self.pd_policy = pd_policy
        n = int(model.n)
        x = as_array(x0, "x0")
        if x.shape != (n,):
            raise ValueError(f"x0: expected shape ({n},), got {x.shape}")
        self._x = model.normalize(x[None, :])[0]
        k = self.cov_dim
        P = as_array(P0, "P0")
        if P.shape != (k, k):
            raise ValueError(f"P0: expected shape ({k}, {k}), got {P.shape}")
        S = cholesky_or_raise(P, "P0")
        self._S = S
        self._P = S @ S.T
        self._innovation: np.ndarray | None = None
        self._innovation_cov: np.ndarray | None = None
        self._diag: dict[str, Any] = {}
        self._reset_diag()

    # ------------------------------------------------------------------ public interface
    @property
    def cov_dim(self) -> int:
        """Dimension of the covariance (state dim for additive filters, error dim otherwise)."""
        return int(self.model.n)

    @property
    def x(self) -> np.ndarray:
        """Current state estimate (a copy)."""
        return self._x.copy()

    @property
    def P(self) -> np.ndarray:
        """Current covariance (a copy; S Sᵀ for square-root filters)."""
        if self.square_root:
            return self._S @ self._S.T
        return self._P.copy()

    @property
    def S(self) -> np.ndarray:
        """Lower square root of the covariance (Cholesky of P for covariance-form filters)."""
        if self.square_root:
            return self._S.copy()
        return self._sqrt_or_repair(self._P, "P")

    @property
    def innovation(self) -> np.ndarray | None:
        """Last innovation ν = z − ẑ (angle-wrapped), None before the first accepted update."""
        return None if self._innovation is None else self._innovation.copy()

    @property
    def innovation_cov(self) -> np.ndarray | None:
        """Predicted innovation covariance P_zz of the last accepted update."""
        return None if self._innovation_cov is None else self._innovation_cov.copy()

    @property
    def diagnostics(self) -> dict[str, Any]:
        """Per-step diagnostics of the last predict/update (copied)."""
        return {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in self._diag.items()}

    def predict(self, u: object, dt: float) -> None:
        """Time update over ``dt`` with the input ``u`` (torque or gyro reading, shape (3,))."""
        dt = check_positive(dt, "dt")
        uu = as_array(u, "u")
        if uu.shape != (3,):
            raise ValueError(f"u: expected shape (3,), got {uu.shape}")
        self._reset_diag()
        self._predict(uu, float(dt))
        self._check_finite("predict")

    def update(self, z: object) -> bool:
        """Measurement update; returns False (and keeps the prediction) if z is rejected."""
        m = int(self.model.m)
        try:
            zz = np.asarray(z, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"z: cannot be converted to a float array ({exc})") from None
        if zz.shape != (m,):
            raise ValueError(f"z: expected shape ({m},), got {zz.shape}")
        self._diag["update_rejected"] = False
        self._diag["reason"] = ""
        if not np.all(np.isfinite(zz)):
            reason = f"z: non-finite measurement {zz.tolist()} rejected; prediction kept"
            logger.warning("%s: %s", self.name, reason)
            self._diag["update_rejected"] = True
            self._diag["reason"] = reason
            return False
        self._update(zz)
        self._check_finite("update")
        return True

    def step(self, u: object, dt: float, z: object) -> bool:
        """predict(u, dt) then update(z)."""
        self.predict(u, dt)
        diag = dict(self._diag)
        ok = self.update(z)
        # keep predict-time flags (e.g. a repair during predict) in the step's diagnostics
        self._diag["repaired"] = bool(self._diag["repaired"] or diag["repaired"])
        return ok

    def error(self, x_true: object) -> np.ndarray:
        """Estimation error in covariance coordinates: x_true ⊟ x̂ (manifold) or x_true − x̂."""
        xt = as_array(x_true, "x_true")
        return xt - self._x

    def nees(self, x_true: object) -> float:
        """Normalised estimation error squared eᵀ P⁻¹ e."""
        e = self.error(x_true)
        S = self.S
        y = solve_lower(S, e)
        return float(y @ y)

    # ------------------------------------------------------------------ helpers
    @abc.abstractmethod
    def _predict(self, u: np.ndarray, dt: float) -> None: ...

    @abc.abstractmethod
    def _update(self, z: np.ndarray) -> None: ...

    def _reset_diag(self) -> None:
        self._diag = {
            "fading": np.ones(self.cov_dim),
            "repaired": False,
            "update_rejected": False,
            "reason": "",
            "nis": np.nan,
        }

    def _record_innovation(self, nu: np.ndarray, Pzz: np.ndarray, Sz: np.ndarray | None) -> None:
        self._innovation = nu
        self._innovation_cov = Pzz
        if Sz is None:
            Sz = np.linalg.cholesky(Pzz)
        y = solve_lower(Sz, nu)
        self._diag["nis"] = float(y @ y)

    def _repair(self, P: np.ndarray, name: str, why: str) -> np.ndarray:
        """Apply the PD policy to a covariance that failed; returns a lower square root."""
        if self.pd_policy == "raise":
            raise NotPositiveDefiniteError(
                f"{name}: lost positive-definiteness in {self.name} ({why})"
            )
        if not np.all(np.isfinite(P)):
            raise NotPositiveDefiniteError(f"{name}: non-finite covariance in {self.name} ({why})")
        logger.warning("%s: %s lost positive-definiteness (%s); repaired", self.name, name, why)
        self._diag["repaired"] = True
        return nearest_pd_sqrt(P)

    def _sqrt_or_repair(self, P: np.ndarray, name: str) -> np.ndarray:
        try:
            return np.linalg.cholesky(0.5 * (P + P.T))
        except np.linalg.LinAlgError:
            return self._repair(P, name, "Cholesky failed")

    def _check_finite(self, where: str) -> None:
        cov = self._S if self.square_root else self._P
        if not (np.all(np.isfinite(self._x)) and np.all(np.isfinite(cov))):
            raise NotPositiveDefiniteError(
                f"x: non-finite state or covariance after {where} in {self.name}"
            )


class ManifoldFilter(Filter):
    """A :class:`Filter` whose state lives on a manifold: the covariance is over the ``model.d``
    error coordinates and errors are ``x_true ⊟ x̂`` (the model's ``normalize``/``boxminus``)."""

    @property
    def cov_dim(self) -> int:
        return int(self.model.d)

    def error(self, x_true: object) -> np.ndarray:
        """x_true ⊟ x̂ (rotation-vector attitude error, body frame)."""
        xt = self.model.normalize(np.asarray(x_true, dtype=np.float64)[None, :])
        return self.model.boxminus(xt, self._x[None, :])[0]
