"""Additive unscented Kalman filter on the 7-state (q, ω) with quaternion normalisation — the
baseline of Wang, Li, Zhang, Zhu & Li (2015) (Julier & Uhlmann 2004; the paper's eqs. (12)–(22)).

Predict (sigma points from the Cholesky factor of P, all 2n+1 propagated in one batched call)::

    χ = [x, x ± γ sⱼ],  Yᵢ = f(χᵢ, u, T_s),  x⁻ = normalise(Σ Wᵢᵐ Yᵢ),
    P⁻ = Σ Wᵢᶜ (Yᵢ − x⁻)(Yᵢ − x⁻)ᵀ + Q.

Update (sigma points redrawn from (x⁻, P⁻))::

    Zᵢ = h(χᵢ),  ẑ = Σ Wᵢᵐ Zᵢ (angle-wrapped),  P_zz = Σ Wᵢᶜ ΔZ ΔZᵀ + R,  P_xz = Σ Wᵢᶜ Δχ ΔZᵀ,
    K = P_xz P_zz⁻¹,  x = normalise(x⁻ + K ν),  P = P⁻ − K P_zz Kᵀ.

With a negative W₀ᶜ (small α) P⁻ or P can become indefinite: the base class's PD policy
applies (repair or raise).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _kernels as _k
from .base import DEFAULT_GATE_PROBABILITY, Filter, tri_solve_gain
from .models import GyrolessAttitudeModel
from .unscented import UTWeights, _sigma_points, ut_weights

__all__ = ["UKF"]


class _AdditiveUT(Filter):
    """Shared machinery of the additive (7-state) unscented filters."""

    _MODEL_ATTRS = (*Filter._MODEL_ATTRS, "Q", "z_mean", "z_residual")

    def __init__(
        self,
        model: Any,
        x0: object,
        P0: object,
        *,
        alpha: float = 1.0,
        beta: float = 2.0,
        kappa: float | None = None,
        pd_policy: str = "repair",
        gate_probability: float | None = DEFAULT_GATE_PROBABILITY,
        gate_max_consecutive: int = 10,
    ) -> None:
        super().__init__(
            model,
            x0,
            P0,
            pd_policy=pd_policy,
            gate_probability=gate_probability,
            gate_max_consecutive=gate_max_consecutive,
        )
        self.weights: UTWeights = ut_weights(int(model.n), alpha, beta, kappa)
        self._Pf = np.zeros((model.n, model.n))
        # The gyroless model (exactly that class: a subclass may override f or h) has fused
        # compiled kernels for the whole sigma-point pass; anything else goes through the
        # model's batched f/h. Same arithmetic either way (tests: equal to 1e-12).
        self._fused = type(model) is GyrolessAttitudeModel
        if self._fused:
            self._R = np.ascontiguousarray(model.R)
            # the diagonal of Q(dt) / dt, exactly as the model builds it
            self._qdiag = np.r_[np.full(4, model.sigma_q**2), np.full(3, model.sigma_w**2)]

    def _predict_fused(self, S: np.ndarray, u: np.ndarray, dt: float) -> None:
        """The time update on the gyroless model in one compiled call: x⁻, P_f = Σ Wᶜ (Y − x⁻)
        (Y − x⁻)ᵀ (symmetrised) and P⁻ = P_f + Q(dt) (Q diagonal, not rebuilt each step)."""
        m, w = self.model, self.weights
        xm, Pf, P, ok = _k.ukf_predict_gyroless(
            self._x, S, u, dt, m.J, m._Jinv, w.Wm, w.Wc, w.gamma, self._qdiag * dt
        )
        if not ok:
            raise ValueError("x: quaternion part has zero or non-finite norm")
        self._x = xm
        self._Pf = Pf
        self._P = P

    def _propagate(self, S: np.ndarray, u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Sigma points of (x, S S ᵀ) through f; returns (Y, normalised weighted mean)."""
        w = self.weights
        X = _sigma_points(self._x, S, w.gamma)
        Y = self.model.f(X, u, dt)
        xm = self.model.normalize((w.Wm @ Y)[None, :])[0]
        return Y, xm

    def _measure(self, x: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, ...]:
        """Sigma points of (x, S Sᵀ) through h: (X, Z, ẑ, ΔX, ΔZ) with ΔZ wrapped about ẑ."""
        w = self.weights
        X = _sigma_points(x, S, w.gamma)
        Z = self.model.h(X)
        zm = self.model.z_mean(Z, w.Wm)
        dZ = self.model.z_residual(Z, zm)
        return X, Z, zm, X - x, dZ


class UKF(_AdditiveUT):
    """Additive UKF with quaternion normalisation (the paper's baseline), covariance form.

    Parameters: ``model`` (e.g. :class:`~liecontrol.estimation.models.GyrolessAttitudeModel`),
    ``x0`` (7,), ``P0`` (7, 7) SPD, scaled-UT ``alpha`` (> 0), ``beta``, ``kappa`` (default
    3 − n), ``pd_policy`` ("repair" | "raise"), ``gate_probability`` (false-alarm probability of
    the χ² innovation gate, ``None`` = off) and ``gate_max_consecutive`` (see
    :mod:`liecontrol.estimation.base`).
    """

    name = "UKF"

    def _predict(self, u: np.ndarray, dt: float) -> None:
        if self._fused:
            m, w = self.model, self.weights
            xm, Pf, P, status = _k.ukf_predict_gyroless_from_P(
                self._x, self._P, u, dt, m.J, m._Jinv, w.Wm, w.Wc, w.gamma, self._qdiag * dt
            )
            if status == 0:
                self._x, self._Pf, self._P = xm, Pf, P
                return
            if status == 2:
                raise ValueError("x: quaternion part has zero or non-finite norm")
            # P failed its Cholesky factorisation: the PD policy repairs it (or raises)
            self._predict_fused(self._sqrt_or_repair(self._P, "P"), u, dt)
            return
        S = self._sqrt_or_repair(self._P, "P")
        Y, xm = self._propagate(S, u, dt)
        dY = Y - xm
        Pf = (dY * self.weights.Wc[:, None]).T @ dY
        self._Pf = 0.5 * (Pf + Pf.T)
        self._x = xm
        self._P = self._Pf + self.model.Q(dt)

    def _gain_update(self, P: np.ndarray, z: np.ndarray) -> None:
        """Standard UKF measurement update from prior (self._x, P)."""
        if self._fused:
            w = self.weights
            # the χ² gate inside the kernel: it stops before the correction when the gate would
            # reject (the same decision _record_innovation makes, which then raises _Gated)
            active = not self._gate_done and self._gated_run < self.gate_max_consecutive
            x, PP, Pn, Pzz, nu, nis, Sz, status = _k.ukf_update_correct(
                self._x, P, z, w.Wm, w.Wc, w.gamma, self._R,
                self.gate_threshold if active else np.inf,
            )  # fmt: skip
            if status in (0, 3, 4, 5):
                self._record_innovation(nu, Pzz, Sz, nis)  # raises _Gated for status 3
                if status == 4:
                    raise ValueError("x: quaternion part has zero or non-finite norm")
                self._x = x
                if status == 0:
                    self._P = PP
                else:  # P⁺ lost positive-definiteness: the PD policy repairs it (or raises)
                    S_new = self._sqrt_or_repair(Pn, "P")
                    self._P = S_new @ S_new.T
                return
            # a Cholesky failed inside: the step-by-step route below repairs (or raises)
        S = self._sqrt_or_repair(P, "P")
        if self._fused:
            w = self.weights
            zm, Pzz, Pxz = _k.ukf_measure_euler(self._x, S, w.Wm, w.Wc, w.gamma, self._R)
        else:
            _, _, zm, dX, dZ = self._measure(self._x, S)
            Wc = self.weights.Wc[:, None]
            Pzz = (dZ * Wc).T @ dZ + self.model.R
            Pzz = 0.5 * (Pzz + Pzz.T)
            Pxz = (dX * Wc).T @ dZ
        Sz = self._sqrt_or_repair(Pzz, "P_zz")
        if self._fused:
            Pzz, K, nu, nis = _k.ukf_gain(Sz, Pxz, z, zm)
            self._record_innovation(nu, Pzz, Sz, nis)
            x, Pn, ok = _k.ukf_correct(self._x, K, nu, P, Pzz)
            if not ok:
                raise ValueError("x: quaternion part has zero or non-finite norm")
            self._x = x
            # check now so that a loss of PD is handled where it happens
            _, PP, ok = _k.cholesky_outer(Pn)
            if ok:
                self._P = PP
                return
        else:
            nu = self.model.z_residual(z, zm)
            Pzz = Sz @ Sz.T
            K = tri_solve_gain(Pxz, Sz)
            self._record_innovation(nu, Pzz, Sz)
            self._x = self.model.normalize((self._x + K @ nu)[None, :])[0]
            Pn = P - K @ Pzz @ K.T
            Pn = 0.5 * (Pn + Pn.T)
        # check now so that a loss of PD is handled where it happens
        S_new = self._sqrt_or_repair(Pn, "P")
        self._P = S_new @ S_new.T

    def _update(self, z: np.ndarray) -> None:
        self._gain_update(self._P, z)
