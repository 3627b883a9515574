"""Scaled unscented transform (Julier 2002; Van der Merwe 2004).

Weights for an n-dimensional state with parameters (α, β, κ):

    λ = α² (n + κ) − n,
    W₀ᵐ = λ / (n + λ),   W₀ᶜ = W₀ᵐ + 1 − α² + β,   Wᵢᵐ = Wᵢᶜ = 1 / (2 (n + λ)),  i = 1…2n.

Sigma points from a square root ``S`` (``P = S Sᵀ``, columns ``sⱼ``):

    χ₀ = x,   χⱼ = x + √(n+λ) sⱼ,   χ_{n+j} = x − √(n+λ) sⱼ.

The transform of y = g(x): ȳ = Σ Wᵢᵐ Yᵢ, P_y = Σ Wᵢᶜ (Yᵢ − ȳ)(Yᵢ − ȳ)ᵀ,
P_xy = Σ Wᵢᶜ (χᵢ − x)(Yᵢ − ȳ)ᵀ. It is exact for linear g (mean and covariance).

Julier's *modified form* (Julier, Uhlmann & Durrant-Whyte, IEEE TAC 45(3):477–482, 2000) takes
the covariance about the transformed central point instead of the mean,
P_y = Σ_{i≥1} Wᵢ (Yᵢ − Y₀)(Yᵢ − Y₀)ᵀ = P_y(standard, Wᶜ=Wᵐ) + (ȳ − Y₀)(ȳ − Y₀)ᵀ, which has only
positive weights and is therefore positive semi-definite for any α, κ with n + λ > 0
(``central=True`` below); the paper's ISTSRUKF uses it (*reconstructed*).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._validation import (
    _to_float_array,
    as_array,
    as_scalar,
    check_bool,
    check_output_finite,
    check_positive_scalar,
)

__all__ = ["UTWeights", "ut_weights", "sigma_points", "unscented_transform", "weighted_stats"]


@dataclass(frozen=True)
class UTWeights:
    """Scaled-UT weights; ``Wm``/``Wc`` have shape (2n+1,), ``gamma = √(n+λ)``."""

    n: int
    alpha: float
    beta: float
    kappa: float
    lam: float
    gamma: float
    Wm: np.ndarray
    Wc: np.ndarray


def ut_weights(
    n: int, alpha: float = 1.0, beta: float = 2.0, kappa: float | None = None
) -> UTWeights:
    """Julier's scaled weights (formulas in the module docstring); κ defaults to 3 − n.

    Raises ``ValueError`` for n < 1, α ≤ 0 or non-finite parameters, and when n + λ ≤ 0
    (sigma points would be imaginary).
    """
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n: must be a positive integer, got {n!r}")
    n = int(n)
    if kappa is None:
        kappa = 3.0 - n
    alpha = as_scalar(alpha, "alpha")
    beta = as_scalar(beta, "beta")
    kappa = as_scalar(kappa, "kappa")
    if alpha <= 0:
        raise ValueError(f"alpha: must be > 0, got {alpha}")
    lam = alpha * alpha * (n + kappa) - n
    if not math.isfinite(lam):
        name = "alpha" if not math.isfinite(alpha * alpha) else "kappa"
        raise ValueError(
            f"{name}: λ = α²(n + κ) − n overflows float64 (α={alpha}, κ={kappa}): too large"
        )
    if n + lam <= 0:
        raise ValueError(
            f"kappa: n + λ = α²(n + κ) must be > 0, got {n + lam:.3e} (n={n}, α={alpha}, κ={kappa})"
        )
    wi = 1.0 / (2.0 * (n + lam))
    Wm = np.full(2 * n + 1, wi)
    Wc = np.full(2 * n + 1, wi)
    Wm[0] = lam / (n + lam)
    Wc[0] = Wm[0] + 1.0 - alpha * alpha + beta
    if not (math.isfinite(Wc[0]) and math.isfinite(Wm[0])):
        raise ValueError(f"beta: W₀ᶜ = W₀ᵐ + 1 − α² + β is not finite (β={beta}): too large")
    Wm.setflags(write=False)
    Wc.setflags(write=False)
    return UTWeights(n, float(alpha), float(beta), float(kappa), float(lam),
                     float(np.sqrt(n + lam)), Wm, Wc)


def sigma_points(x: object, S: object, gamma: float) -> np.ndarray:
    """(2n+1, n) sigma points χ₀ = x, χ = x ± γ sⱼ (columns of the square root S).

    ``x`` (n,), ``S`` (n, n) finite real (lists accepted), ``gamma`` a finite number > 0;
    ``ValueError`` naming the argument otherwise, and if a sigma point overflows float64."""
    xv = as_array(x, "x")
    if xv.ndim != 1 or xv.shape[0] == 0:
        raise ValueError(f"x: expected shape (n,) with n >= 1, got {xv.shape}")
    n = xv.shape[0]
    Sv = as_array(S, "S")
    if Sv.shape != (n, n):
        raise ValueError(f"S: expected shape ({n}, {n}) like x, got {Sv.shape}")
    g = check_positive_scalar(gamma, "gamma")
    with np.errstate(over="ignore", invalid="ignore"):
        X = _sigma_points(xv, Sv, g)
    return check_output_finite(X, "S", "a sigma point x ± γ sⱼ")


def _sigma_points(x: np.ndarray, S: np.ndarray, gamma: float) -> np.ndarray:
    """:func:`sigma_points` without validation (the filters' hot path)."""
    cols = gamma * np.swapaxes(S, -1, -2)
    return np.concatenate((x[None, :], x[None, :] + cols, x[None, :] - cols), axis=0)


def weighted_stats(
    X: np.ndarray,
    Y: np.ndarray,
    w: UTWeights,
    x_ref: np.ndarray,
    y_mean: np.ndarray,
    central: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """(P_y, P_xy) from sigma points X (2n+1, n) and transformed points Y (2n+1, m).

    Standard form: deviations about (x_ref, y_mean) with weights Wᶜ. ``central=True``: Julier's
    modified form, deviations about (X₀, Y₀) with the positive weights Wᵢ, i ≥ 1.
    """
    if central:
        dX = X[1:] - X[0]
        dY = Y[1:] - Y[0]
        wc = w.Wc[1:]
    else:
        dX = X - x_ref
        dY = Y - y_mean
        wc = w.Wc
    Py = (dY * wc[:, None]).T @ dY
    Pxy = (dX * wc[:, None]).T @ dY
    return 0.5 * (Py + Py.T), Pxy


def unscented_transform(
    g: Callable[[np.ndarray], np.ndarray],
    x: object,
    P: object,
    alpha: float = 1.0,
    beta: float = 2.0,
    kappa: float | None = None,
    central: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scaled unscented transform of y = g(x), x ~ (x, P); returns (ȳ, P_y, P_xy).

    ``g`` maps a batch (N, n) to (N, m) — all 2n+1 sigma points go through one call.
    ``P`` must be symmetric positive definite (``ValueError`` naming ``P`` otherwise). A
    non-finite ``g`` output, or statistics that overflow float64 (e.g. ``P`` ~ 1e300), raise
    ``ValueError`` instead of returning inf/NaN.
    """
    if not callable(g):
        raise TypeError(f"g: expected a callable mapping (N, n) to (N, m), got {type(g).__name__}")
    central = check_bool(central, "central")
    xv = as_array(x, "x")
    if xv.ndim != 1 or xv.shape[0] == 0:
        raise ValueError(f"x: expected shape (n,) with n >= 1, got {xv.shape}")
    n = xv.shape[0]
    Pm = as_array(P, "P")
    if Pm.shape != (n, n):
        raise ValueError(f"P: expected shape ({n}, {n}) like x, got {Pm.shape}")
    S = cholesky_or_raise(Pm, "P")
    w = ut_weights(n, alpha, beta, kappa)
    with np.errstate(over="ignore", invalid="ignore"):
        X = _sigma_points(xv, S, w.gamma)
    check_output_finite(X, "P", "a sigma point x ± γ sⱼ")
    Y = _to_float_array(g(X), "g")
    if Y.ndim != 2 or Y.shape[0] != X.shape[0]:
        raise ValueError(f"g: must map ({X.shape[0]}, n) to ({X.shape[0]}, m), got {Y.shape}")
    if not np.all(np.isfinite(Y)):
        raise ValueError("g: returned non-finite values at the sigma points")
    with np.errstate(over="ignore", invalid="ignore"):
        ybar = w.Wm @ Y
        Py, Pxy = weighted_stats(X, Y, w, xv, ybar, central=central)
    for out in (ybar, Py, Pxy):
        check_output_finite(out, "P", "the transformed mean or covariance")
    return ybar, Py, Pxy


def cholesky_or_raise(P: np.ndarray, name: str) -> np.ndarray:
    """Lower Cholesky factor of a symmetric positive-definite P, else ``ValueError`` naming it."""
    asym = float(np.max(np.abs(P - P.T))) if P.size else 0.0
    scale = max(float(np.max(np.abs(P))), 1e-300)
    if asym > 1e-8 * scale:
        raise ValueError(f"{name}: not symmetric (max |P − Pᵀ| = {asym:.2e})")
    try:
        return np.linalg.cholesky(0.5 * (P + P.T))
    except np.linalg.LinAlgError:
        eig = float(np.linalg.eigvalsh(0.5 * (P + P.T)).min())
        raise ValueError(
            f"{name}: not positive definite (smallest eigenvalue {eig:.3e})"
        ) from None
