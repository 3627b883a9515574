"""Common filter interface for ``liecontrol.estimation``.

Every filter exposes::

    f.predict(u, dt)          # time update with input u held over dt
    f.update(z) -> bool       # measurement update; False when the measurement was rejected
    f.step(u, dt, z) -> bool  # predict then update
    f.x, f.P, f.S             # state (stored form), covariance, lower square root (P = S Sᵀ)
    f.innovation              # last innovation ν = z − ẑ (wrapped), or None
    f.innovation_cov          # its predicted covariance P_zz, or None
    f.diagnostics             # per-step dict: "fading" (μ per state), "repaired",
                              # "update_rejected", "reason", "nis", "gated",
                              # "gate_threshold"

Bad input: a wrong ``z``/``u`` shape, ``dt ≤ 0``, non-PD initial covariance →
``ValueError`` naming the argument. A non-finite measurement is **rejected**: the update is
skipped, the prediction kept, the reason logged (``logging`` logger ``liecontrol.estimation``)
and returned in ``diagnostics``. A covariance that loses positive-definiteness is repaired
(``pd_policy="repair"``, default: nearest PD matrix, flagged in ``diagnostics["repaired"]``) or
raises :class:`~liecontrol.estimation.cholesky.NotPositiveDefiniteError`
(``pd_policy="raise"``); NaN never propagates silently.

Repair (``pd_policy="repair"``): the covariance itself is checked before it is used (not only
derived matrices such as P_zz, whose repair would hide the cause); an indefinite symmetric
covariance is replaced by U |Λ| Uᵀ with every eigenvalue at least ``1e-12 ·`` the largest
(:func:`~liecontrol.estimation.cholesky.nearest_pd_sqrt` with ``mirror=True``: a sign error in
one variance is undone exactly, round-off negativity is lifted to the floor). A covariance that
cannot be repaired (non-finite) raises :class:`NotPositiveDefiniteError` naming ``P``; so does a
filter whose state or covariance diverges inside a step (the message names the covariance and
the step, with the model's own error attached).

Innovation gating (every filter): the normalised innovation squared NIS = νᵀ P_zz⁻¹ ν of an
update is compared with the χ²_m quantile of probability ``1 − gate_probability`` (default
``gate_probability=1e-6``: a consistent filter rejects one good measurement in a million; for
m = 3 the threshold is 30.7). A measurement above it is rejected (``update`` returns False, the
prediction is kept, ``diagnostics["gated"]`` and ``["update_rejected"]`` are True, the reason
names the NIS and the threshold, and a warning is logged). After ``gate_max_consecutive``
(default 10) consecutive rejections the next measurement is accepted regardless (and logged), so
a filter that is really lost can recover instead of locking out. ``gate_probability=None``
disables the gate. The strong-tracking filters gate on the *unfaded* innovation, before the
fading factors see it (an outlier must not inflate the covariance), with
``gate_max_consecutive=1`` by default: an isolated outlier is rejected, a second large
innovation in a row is a real change of the dynamics and goes on to the fading factors.
"""

from __future__ import annotations

import abc
import logging
import math
from typing import Any

import numpy as np
from scipy.stats import chi2

from .._validation import _to_float_array, as_array, as_scalar, check_positive_scalar
from . import _kernels as _k
from .cholesky import NotPositiveDefiniteError, chol_solve, nearest_pd_sqrt, solve_lower
from .unscented import cholesky_or_raise

__all__ = ["Filter", "ManifoldFilter", "logger", "psd_sqrt", "DEFAULT_GATE_PROBABILITY"]

logger = logging.getLogger("liecontrol.estimation")

_PD_POLICIES = ("repair", "raise")

#: Default false-alarm probability of the χ² innovation gate.
DEFAULT_GATE_PROBABILITY = 1e-6


class _Gated(Exception):
    """Internal: the innovation failed the χ² gate (raised before the state is touched)."""

    def __init__(self, nis: float) -> None:
        super().__init__(nis)
        self.nis = nis


def psd_sqrt(Q: object) -> np.ndarray:
    """A square root A with A Aᵀ = Q for a symmetric PSD Q (Cholesky, or eigen when singular).

    ``Q``: a finite real square matrix (lists accepted), symmetric to ``1e-9`` relative;
    ``ValueError`` naming ``Q`` otherwise, or if it has an eigenvalue below
    ``−1e-12 · max(1, max |eigenvalue|)`` (not positive semi-definite)."""
    Q = as_array(Q, "Q")
    if Q.ndim != 2 or Q.shape[0] != Q.shape[1] or Q.shape[0] == 0:
        raise ValueError(f"Q: expected a non-empty square matrix (n, n), got shape {Q.shape}")
    scale = float(np.abs(Q).max())
    asym = float(np.abs(Q - Q.T).max())
    if asym > 1e-9 * max(scale, 1e-300):
        raise ValueError(f"Q: not symmetric (max |Q − Qᵀ| = {asym:.2e})")
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
    #: Attributes a model must have (checked by the constructor: ``TypeError`` naming ``model``).
    _MODEL_ATTRS: tuple[str, ...] = ("n", "m", "f", "h", "normalize")

    def __init__(
        self,
        model: Any,
        x0: object,
        P0: object,
        *,
        pd_policy: str = "repair",
        gate_probability: float | None = DEFAULT_GATE_PROBABILITY,
        gate_max_consecutive: int = 10,
    ) -> None:
        if not isinstance(pd_policy, str) or pd_policy not in _PD_POLICIES:
            raise ValueError(f"pd_policy: must be one of {_PD_POLICIES}, got {pd_policy!r}")
        missing = [a for a in self._MODEL_ATTRS if not hasattr(model, a)]
        if missing:
            raise TypeError(
                f"model: expected a filter model (e.g. GyrolessAttitudeModel or "
                f"GyroAttitudeModel), got {type(model).__name__} without "
                + ", ".join(repr(a) for a in missing)
            )
        self.model = model
        self.pd_policy = pd_policy
        if gate_probability is None:
            self.gate_probability: float | None = None
            self.gate_threshold = np.inf
        else:
            p = as_scalar(gate_probability, "gate_probability")
            if not 0.0 < p < 1.0:
                raise ValueError(f"gate_probability: must be in (0, 1) or None, got {p}")
            self.gate_probability = p
            # χ²_m quantile of 1 − p: NIS of a consistent filter exceeds it with probability p
            self.gate_threshold = float(chi2.isf(p, int(model.m)))
        if (
            isinstance(gate_max_consecutive, bool)
            or not isinstance(gate_max_consecutive, (int, np.integer))
            or gate_max_consecutive < 1
        ):
            raise ValueError(
                f"gate_max_consecutive: must be an integer >= 1, got {gate_max_consecutive!r}"
            )
        self.gate_max_consecutive = int(gate_max_consecutive)
        self._gated_run = 0  # consecutive gated updates
        self._gate_done = False  # the current update already passed the gate (strong tracking)
        n = int(model.n)
        x = as_array(x0, "x0")
        if x.shape != (n,):
            raise ValueError(f"x0: expected shape ({n},), got {x.shape}")
        try:
            self._x = model.normalize(x[None, :])[0]
        except ValueError as exc:  # the model names its own argument "x"
            raise ValueError(f"x0: {str(exc).removeprefix('x: ')}") from None
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
        # μ = 1 (no fading) shared by every step's diagnostics (read-only; the property copies)
        self._no_fading = np.ones(k)
        self._no_fading.flags.writeable = False
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
        dt = check_positive_scalar(dt, "dt")
        if type(u) is np.ndarray and u.shape == (3,) and u.dtype == np.float64:
            uu = u  # the common case, checked on Python floats (numpy's checks cost µs here)
            if not all(math.isfinite(c) for c in u.tolist()):
                uu = as_array(u, "u")  # raises the usual message
        else:
            uu = as_array(u, "u")
        if uu.shape != (3,):
            raise ValueError(f"u: expected shape (3,), got {uu.shape}")
        self._reset_diag()
        try:
            self._guarded(self._predict, "predict", uu, dt)
        except NotPositiveDefiniteError:
            raise
        except ValueError as exc:
            if not str(exc).startswith("x: "):
                raise
            # the state was finite before the step and the covariance is intact (_guarded
            # checked it): the input drove the model out of its range (e.g. u = 1e300)
            raise ValueError(
                f"u: the time update with u = {uu.tolist()} over dt = {dt:g} s gives an invalid "
                f"state ({str(exc).removeprefix('x: ')}); the input (or dt) is out of the "
                "model's range"
            ) from None
        self._check_finite("predict")

    def update(self, z: object) -> bool:
        """Measurement update; returns False (and keeps the prediction) if z is rejected."""
        m = int(self.model.m)
        zz = _to_float_array(z, "z")
        if zz.shape != (m,):
            raise ValueError(f"z: expected shape ({m},), got {zz.shape}")
        self._diag["update_rejected"] = False
        self._diag["reason"] = ""
        if not all(math.isfinite(c) for c in zz.tolist()):
            reason = f"z: non-finite measurement {zz.tolist()} rejected; prediction kept"
            logger.warning("%s: %s", self.name, reason)
            self._diag["update_rejected"] = True
            self._diag["reason"] = reason
            return False
        self._gate_done = False
        try:
            self._guarded(self._update, "update", zz)
        except _Gated as g:
            self._gated_run += 1
            reason = (
                f"nu: innovation rejected by the χ² gate (NIS = {g.nis:.4g} > "
                f"{self.gate_threshold:.4g}, the χ²_{m} quantile of 1 − {self.gate_probability:g});"
                f" prediction kept ({self._gated_run} in a row)"
            )
            logger.warning("%s: %s", self.name, reason)
            self._diag["update_rejected"] = True
            self._diag["gated"] = True
            self._diag["nis"] = g.nis
            self._diag["reason"] = reason
            return False
        self._gated_run = 0
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
            "fading": self._no_fading,
            "repaired": False,
            "update_rejected": False,
            "reason": "",
            "nis": np.nan,
            "gated": False,
            "gate_threshold": self.gate_threshold,
        }

    def _guarded(self, step: Any, where: str, *args: Any) -> None:
        """Run a predict/update body; a ValueError from inside (typically the model refusing a
        diverged state, e.g. a non-finite quaternion) is re-raised as
        :class:`NotPositiveDefiniteError` naming the covariance when the covariance is what
        broke (non-finite or not positive definite), so the error names the real cause."""
        try:
            step(*args)
        except (_Gated, NotPositiveDefiniteError):
            raise
        except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
            cov = self._S if self.square_root else self._P
            ok = bool(np.all(np.isfinite(cov)))
            if ok and not self.square_root:
                try:
                    np.linalg.cholesky(0.5 * (cov + cov.T))
                except np.linalg.LinAlgError:
                    ok = False
            if ok:
                raise
            raise NotPositiveDefiniteError(
                f"P: {self.name} diverged during {where}: the covariance is no longer a finite "
                f"positive-definite matrix ({type(exc).__name__}: {exc})"
            ) from exc

    def _gate(self, nu: np.ndarray, Sz: np.ndarray, nis: float | None = None) -> float:
        """NIS = |S_z⁻¹ ν|² and the χ² gate (raises :class:`_Gated` before the state changes);
        after ``gate_max_consecutive`` rejections in a row the measurement passes (logged).
        ``nis`` given: already computed by the caller (a fused kernel) from the same S_z, ν."""
        if nis is None:
            y = solve_lower(Sz, nu)
            nis = float(y @ y)
        if not self._gate_done and nis > self.gate_threshold:
            if self._gated_run < self.gate_max_consecutive:
                raise _Gated(nis)
            logger.warning(
                "%s: NIS = %.4g exceeds the gate %.4g after %d rejections in a row; accepted "
                "to let the filter recover",
                self.name, nis, self.gate_threshold, self._gated_run,
            )
        self._gate_done = True
        return nis

    def _record_innovation(
        self, nu: np.ndarray, Pzz: np.ndarray, Sz: np.ndarray | None, nis: float | None = None
    ) -> None:
        if Sz is None:
            Sz = np.linalg.cholesky(Pzz)
        nis = self._gate(nu, Sz, nis)
        self._innovation = nu
        self._innovation_cov = Pzz
        self._diag["nis"] = nis

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
        try:
            S = nearest_pd_sqrt(P, mirror=True)
        except (ValueError, np.linalg.LinAlgError) as exc:
            raise NotPositiveDefiniteError(
                f"{name}: could not be repaired in {self.name} ({why}; {exc})"
            ) from exc
        if not (np.all(np.isfinite(S)) and np.all(np.diagonal(S) > 0.0)):
            raise NotPositiveDefiniteError(f"{name}: could not be repaired in {self.name} ({why})")
        return S

    def _valid_P(self) -> np.ndarray:
        """The covariance ``self._P`` checked (Cholesky) before it is used; repaired or raised
        per the PD policy, so a broken P is named as such (not as a derived matrix)."""
        P = self._P
        try:
            np.linalg.cholesky(P)
            return P
        except np.linalg.LinAlgError:
            S = self._repair(P, "P", "Cholesky of the covariance failed")
            self._P = S @ S.T
            return self._P

    def _sqrt_or_repair(self, P: np.ndarray, name: str) -> np.ndarray:
        # Cholesky of ½(P + Pᵀ) in one compiled call (numpy's costs ~10 µs of overhead per
        # 7×7 matrix); it fails exactly where LAPACK's potrf does (a pivot ≤ 0 or NaN)
        L, ok = _k.cholesky_sym(np.ascontiguousarray(P, dtype=np.float64))
        return L if ok else self._repair(P, name, "Cholesky failed")

    def _check_finite(self, where: str) -> None:
        cov = self._S if self.square_root else self._P
        if _k.all_finite(cov.ravel(), self._x):
            return  # the common case in one compiled call; the checks below name the culprit
        if not np.isfinite(cov).all():
            raise NotPositiveDefiniteError(
                f"P: non-finite covariance after {where} in {self.name} (the filter diverged)"
            )
        if not np.isfinite(self._x).all():
            raise NotPositiveDefiniteError(
                f"x: non-finite state after {where} in {self.name} (the filter diverged)"
            )


class ManifoldFilter(Filter):
    """A :class:`Filter` whose state lives on a manifold: the covariance is over the ``model.d``
    error coordinates and errors are ``x_true ⊟ x̂`` (the model's ``normalize``/``boxminus``)."""

    _MODEL_ATTRS = (*Filter._MODEL_ATTRS, "d", "boxplus", "boxminus")

    @property
    def cov_dim(self) -> int:
        return int(self.model.d)

    def error(self, x_true: object) -> np.ndarray:
        """x_true ⊟ x̂ (rotation-vector attitude error, body frame)."""
        xt = self.model.normalize(np.asarray(x_true, dtype=np.float64)[None, :])
        return self.model.boxminus(xt, self._x[None, :])[0]
