"""Strong-tracking UKF with multiple fading factors, Jacobian-free ("equivalent description")
form (*reconstructed*: the paper's eqs. (26)–(41) were lost in extraction; this
is the standard suboptimal-fading-factor STF of Zhou, Xi & Zhang (1999) with the multiple
factors of Qian et al. (2013) and the UT-based equivalent measurement matrix).

At step k+1, after the unfaded prediction P̄ = P_f + Q (P_f the spread of the propagated sigma
points) and a first unscented measurement transform giving ẑ, P_xz:

    γ = z − ẑ,   V₁ = γγᵀ,   V_{k+1} = (ρ V_k + γγᵀ) / (1 + ρ)               (forgetting ρ)
    H = (P̄⁻¹ P_xz)ᵀ                                   (equivalent measurement matrix, no Jacobian)
    N = V − β_s R − H Q Hᵀ,    M = P_f Hᵀ H             (M = F P Fᵀ Hᵀ H, n × n)
    c = tr N / Σᵢ αᵢ Mᵢᵢ,      μᵢ = max(1, αᵢ c)         (αᵢ ≥ 1 preset, β_s ≥ 1 softening)
    P_{k+1|k} = Λ^½ P_f Λ^½ + Q,   Λ = diag(μ)          (applied symmetrically: stays symmetric)

then the sigma points are redrawn from P_{k+1|k} and the ordinary UKF update follows.
tr(M) = tr(H P_f Hᵀ) equals tr(P_zz − R − H Q Hᵀ) of the unscented transform for a linear h.
When Σ αᵢ Mᵢᵢ ≤ 0 (no information on the states through h) c is set to 0, i.e. μ = 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_array, as_scalar
from .cholesky import chol_solve
from .ukf import UKF

__all__ = ["StrongTrackingParams", "FadingState", "fading_factors", "STUKF"]


@dataclass(frozen=True, eq=False)
class StrongTrackingParams:
    """Strong-tracking tuning: forgetting factor ρ ∈ (0, 1], softening β_s ≥ 1, preset αᵢ ≥ 1
    (scalar or one per covariance dimension; ``None`` = all ones)."""

    rho: float = 0.95
    softening: float = 3.0
    alphas: np.ndarray | float | None = None
    max_fading: float = 1e6

    def __post_init__(self) -> None:
        rho = as_scalar(self.rho, "rho")
        if not 0.0 < rho <= 1.0:
            raise ValueError(f"rho: forgetting factor must be in (0, 1], got {rho}")
        softening = as_scalar(self.softening, "softening")
        if not softening >= 1.0:
            raise ValueError(f"softening: must be >= 1, got {softening}")
        if self.alphas is not None:
            a = as_array(self.alphas, "alphas")
            if a.ndim > 1 or a.size == 0:
                raise ValueError(f"alphas: expected a scalar or a non-empty vector, got {a.shape}")
            if np.any(a < 1.0):
                raise ValueError(f"alphas: preset factors must be >= 1, got min {a.min()}")
        max_fading = as_scalar(self.max_fading, "max_fading")
        if not max_fading >= 1.0:
            raise ValueError(f"max_fading: must be >= 1, got {max_fading}")
        object.__setattr__(self, "rho", rho)
        object.__setattr__(self, "softening", softening)
        object.__setattr__(self, "max_fading", max_fading)

    def alpha_vector(self, n: int) -> np.ndarray:
        """The αᵢ as an (n,) array."""
        if self.alphas is None:
            return np.ones(n)
        a = as_array(self.alphas, "alphas")
        if a.ndim == 0:
            return np.full(n, float(a))
        if a.shape != (n,):
            raise ValueError(f"alphas: expected a scalar or shape ({n},), got {a.shape}")
        return np.array(a, dtype=np.float64)


@dataclass
class FadingState:
    """Running innovation covariance V_k of the strong-tracking filter."""

    V: np.ndarray | None = None
    steps: int = 0

    def __post_init__(self) -> None:
        if self.V is not None:
            V = as_array(self.V, "V")
            if V.ndim != 2 or V.shape[0] != V.shape[1] or V.size == 0:
                raise ValueError(f"V: expected a square (m, m) matrix or None, got {V.shape}")
            self.V = V
        if (
            isinstance(self.steps, (bool, np.bool_))
            or not isinstance(self.steps, (int, np.integer))
            or self.steps < 0
        ):
            raise ValueError(f"steps: must be an integer >= 0, got {self.steps!r}")


def fading_factors(
    gamma: np.ndarray,
    Pbar_chol: np.ndarray,
    Pf: np.ndarray,
    Pxz: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray,
    params: StrongTrackingParams,
    state: FadingState,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Multiple fading factors μ (n,) from the innovation γ (formulas in the module docstring).

    ``Pbar_chol`` is the lower Cholesky factor of P̄ = P_f + Q; ``state`` is updated in place
    (V recursion). Returns (μ, details) with details ``{"c", "V", "H"}``. Shapes (n states,
    m measurements): ``gamma`` (m,), ``Pbar_chol``/``Pf``/``Q`` (n, n), ``Pxz`` (n, m), ``R``
    (m, m); all finite and real (``ValueError`` naming the argument otherwise).
    """
    if not isinstance(params, StrongTrackingParams):
        raise TypeError(f"params: expected StrongTrackingParams, got {type(params).__name__}")
    if not isinstance(state, FadingState):
        raise TypeError(f"state: expected FadingState, got {type(state).__name__}")
    gamma = as_array(gamma, "gamma")
    if gamma.ndim != 1 or gamma.size == 0:
        raise ValueError(f"gamma: expected shape (m,), got {gamma.shape}")
    Pf = as_array(Pf, "Pf")
    if Pf.ndim != 2 or Pf.shape[0] != Pf.shape[1] or Pf.size == 0:
        raise ValueError(f"Pf: expected a square (n, n) matrix, got {Pf.shape}")
    n, m = Pf.shape[0], gamma.shape[0]
    for name, a, shape in (
        ("Pbar_chol", Pbar_chol, (n, n)),
        ("Pxz", Pxz, (n, m)),
        ("Q", Q, (n, n)),
        ("R", R, (m, m)),
    ):
        if as_array(a, name).shape != shape:
            raise ValueError(f"{name}: expected shape {shape}, got {np.shape(a)}")
    Pbar_chol, Pxz, Q, R = (np.asarray(a, dtype=np.float64) for a in (Pbar_chol, Pxz, Q, R))
    if np.any(np.diagonal(Pbar_chol) <= 0.0):
        raise ValueError("Pbar_chol: not a Cholesky factor (diagonal must be > 0)")
    if state.V is not None and np.shape(state.V) != (m, m):
        raise ValueError(f"state: V has shape {np.shape(state.V)}, expected ({m}, {m})")
    gg = np.outer(gamma, gamma)
    V = gg if state.V is None else (params.rho * state.V + gg) / (1.0 + params.rho)
    state.V = V
    state.steps += 1
    H = chol_solve(Pbar_chol, Pxz).T
    N = V - params.softening * R - H @ Q @ H.T
    M = Pf @ H.T @ H
    alphas = params.alpha_vector(Pf.shape[0])
    den = float(alphas @ np.diagonal(M))
    c = float(np.trace(N)) / den if den > 0.0 else 0.0
    mu = np.clip(alphas * c, 1.0, params.max_fading)
    return mu, {"c": c, "V": V, "H": H}


class STUKF(UKF):
    """Strong-tracking UKF (covariance form) with multiple fading factors applied symmetrically.

    Extra parameter: ``tracking`` (:class:`StrongTrackingParams`). ``diagnostics["fading"]``
    holds μ of the last update (all ones in a quiet steady state with a correct model).
    """

    name = "STF"

    def __init__(self, model: Any, x0: object, P0: object, *,
                 tracking: StrongTrackingParams | None = None, **kw: Any) -> None:
        # one outlier is gated, a second large innovation in a row is taken as a real change
        # of the dynamics and passed on to the fading factors (that is what they are for)
        kw.setdefault("gate_max_consecutive", 1)
        super().__init__(model, x0, P0, **kw)
        self.tracking = tracking if tracking is not None else StrongTrackingParams()
        self.tracking.alpha_vector(self.cov_dim)
        self._fading_state = FadingState()
        self._Q_last = np.zeros((model.n, model.n))

    def _predict(self, u: np.ndarray, dt: float) -> None:
        super()._predict(u, dt)
        self._Q_last = self.model.Q(dt)

    def _update(self, z: np.ndarray) -> None:
        Pbar = self._P
        Sbar = self._sqrt_or_repair(Pbar, "P")
        _, _, zm, dX, dZ = self._measure(self._x, Sbar)
        Wc = self.weights.Wc[:, None]
        Pxz = (dX * Wc).T @ dZ
        gamma = self.model.z_residual(z, zm)
        # χ² gate on the unfaded innovation, before the fading state sees it: an outlier must
        # be rejected, not turned into a covariance inflation (and it must leave V untouched)
        Pzz0 = (dZ * Wc).T @ dZ + self.model.R
        try:
            Sz0 = np.linalg.cholesky(0.5 * (Pzz0 + Pzz0.T))
        except np.linalg.LinAlgError:
            Sz0 = None  # a negative W₀ᶜ can make the unfaded P_zz indefinite: gate later
        if Sz0 is not None:
            self._gate(gamma, Sz0)
        mu, info = fading_factors(gamma, Sbar, self._Pf, Pxz, self._Q_last, self.model.R,
                                  self.tracking, self._fading_state)
        r = np.sqrt(mu)
        P = r[:, None] * self._Pf * r[None, :] + self._Q_last
        self._diag["fading"] = mu
        self._diag["fading_c"] = info["c"]
        self._gain_update(0.5 * (P + P.T), z)
