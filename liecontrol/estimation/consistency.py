"""Filter consistency: NEES, NIS and their χ² bounds.

A filter is *consistent* when its errors are as large as its covariance says (Bar-Shalom, Li &
Kirubarajan, "Estimation with Applications to Tracking and Navigation", Wiley 2001, §5.4):

- **NEES** (normalised estimation error squared) ``ε_k = e_kᵀ P_k⁻¹ e_k`` with ``e_k`` the error
  of the estimate in the covariance's coordinates (for the attitude filters the body-frame
  rotation vector ``Log(q̂⁻¹ ⊗ q)`` and the bias error); ``ε_k ~ χ²_n`` when the filter is
  consistent, ``n`` the number of error states;
- **NIS** (normalised innovation squared) ``ν_kᵀ S_k⁻¹ ν_k ~ χ²_m`` (``m`` measurement
  components), and the innovations of a consistent filter are white.

Time-average test of one run (Bar-Shalom et al. §5.4.2): the average of ``K`` independent
``χ²_n`` samples is ``χ²_{Kn}/K``; the two-sided 95 % region is
``[χ²_{Kn}(0.025)/K, χ²_{Kn}(0.975)/K]`` (:func:`chi2_mean_bounds`). Innovations are white, so
the NIS average uses ``K`` directly. NEES samples of successive steps are correlated (the error
changes on the filter's time constant, not from one step to the next), so :func:`time_average_test`
replaces ``K`` by the effective number of independent samples ``K_eff = K / τ``, with the
integrated autocorrelation time ``τ = 1 + 2 Σ_{l ≤ M} ρ_l`` over Sokal's automatic window
(:func:`effective_sample_size`; Sokal, "Monte Carlo methods in statistical mechanics: foundations
and new algorithms", in *Functional Integration*, Springer 1997) — the mean of ``K_eff``
χ²_n samples has the same mean and variance (an approximation: τ is itself estimated from the
run). Without that correction a consistent filter would fail the NEES test of a long run almost
surely.

:func:`in_interval_fraction` is the per-sample check: the fraction of samples inside the
two-sided 95 % interval of χ²_n (0.95 for a consistent filter, whatever the correlation).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.stats import chi2

from .._validation import as_array, as_int, as_scalar

__all__ = [
    "normalised_error_squared",
    "chi2_mean_bounds",
    "effective_sample_size",
    "in_interval_fraction",
    "time_average_test",
]


def normalised_error_squared(e: object, P: object) -> float:
    """``eᵀ P⁻¹ e`` for an error ``e`` (n,) and a symmetric positive definite ``P`` (n, n)
    (Cholesky solve; ``ValueError`` naming the argument for a wrong shape or a ``P`` that is
    not positive definite)."""
    e = as_array(e, "e")
    P = as_array(P, "P")
    if e.ndim != 1 or P.shape != (e.shape[0], e.shape[0]):
        raise ValueError(f"P: expected shape ({e.shape[0]}, {e.shape[0]}) for e {e.shape}, "
                         f"got {P.shape}")
    try:
        L = np.linalg.cholesky(0.5 * (P + P.T))
    except np.linalg.LinAlgError:
        raise ValueError("P: not positive definite") from None
    y = np.linalg.solve(L, e)
    return float(y @ y)


def _level(level: object) -> float:
    v = as_scalar(level, "level")
    if not 0.0 < v < 1.0:
        raise ValueError(f"level: expected a probability in (0, 1), got {v}")
    return v


def _samples(samples: object) -> np.ndarray:
    s = as_array(samples, "samples").ravel()
    if s.size == 0:
        raise ValueError("samples: expected at least one sample, got none")
    return s


def chi2_mean_bounds(K: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """Two-sided ``level`` region of the mean of ``K`` independent χ²_n samples:
    ``(χ²_{Kn}((1−level)/2)/K, χ²_{Kn}((1+level)/2)/K)``. ``K`` may be fractional (an effective
    sample count, ≥ 1)."""
    K = as_scalar(K, "K")
    if not K >= 1.0:
        raise ValueError(f"K: expected a sample count >= 1, got {K}")
    n = as_int(n, "n", 1)
    level = _level(level)
    a = 0.5 * (1.0 - level)
    dof = K * n
    return float(chi2.ppf(a, dof) / K), float(chi2.ppf(1.0 - a, dof) / K)


#: Sokal's window constant: the autocorrelation sum runs to the first lag M ≥ c·τ(M).
_SOKAL_C = 5.0


def effective_sample_size(samples: object) -> float:
    """``K / τ`` with ``τ = 1 + 2 Σ_{l=1}^{M} ρ_l`` the integrated autocorrelation time of the
    series ``samples`` (K,), ``ρ_l`` its sample autocorrelation and ``M`` Sokal's automatic
    window (the smallest lag with ``M ≥ 5 τ(M)``); clipped to ``[1, K]``. A constant series
    gives 1."""
    x = as_array(samples, "samples")
    if x.ndim != 1 or x.shape[0] < 1:
        raise ValueError(f"samples: expected a non-empty 1-D series, got shape {x.shape}")
    K = x.shape[0]
    scale = float(np.abs(x).max())
    d = x / scale if scale > 0.0 else x  # scale-free: no overflow for huge values
    d = d - d.mean()
    var = float(d @ d)
    if K < 3 or var <= 0.0:
        return 1.0 if var <= 0.0 else float(K)
    nfft = 1 << (2 * K - 1).bit_length()
    f = np.fft.rfft(d, nfft)
    acf = np.fft.irfft(f * np.conj(f), nfft)[:K] / var
    # τ(M) = 1 + 2 Σ_{l ≤ M} ρ_l with Sokal's automatic window: the smallest M ≥ 5 τ(M)
    tau_m = np.cumsum(np.concatenate(([1.0], 2.0 * acf[1:])))
    window = np.arange(K) >= _SOKAL_C * tau_m
    tau = float(tau_m[int(np.argmax(window))] if window.any() else tau_m[-1])
    return float(min(max(K / max(tau, 1.0), 1.0), K))


def in_interval_fraction(samples: object, n: int, level: float = 0.95) -> float:
    """Fraction of ``samples`` inside the two-sided ``level`` interval of χ²_n
    (finite, at least one)."""
    s = _samples(samples)
    n = as_int(n, "n", 1)
    a = 0.5 * (1.0 - _level(level))
    lo, hi = chi2.ppf(a, n), chi2.ppf(1.0 - a, n)
    return float(np.mean((s >= lo) & (s <= hi)))


def time_average_test(
    samples: Sequence[float] | np.ndarray, n: int, *, correlated: bool, level: float = 0.95
) -> tuple[float, float, float, bool]:
    """``(mean, lo, hi, inside)`` of the time-average test of one run.

    ``correlated=False`` (NIS): the bounds of :func:`chi2_mean_bounds` with ``K`` samples;
    ``correlated=True`` (NEES): with ``K_eff`` of :func:`effective_sample_size`. ``samples``:
    finite, at least one."""
    s = _samples(samples)
    if not isinstance(correlated, (bool, np.bool_)):
        raise TypeError(f"correlated: expected a bool, got {correlated!r}")
    K = effective_sample_size(s) if correlated else float(s.size)
    lo, hi = chi2_mean_bounds(K, n, level)
    m = float(s.mean())
    return m, lo, hi, bool(lo <= m <= hi)
