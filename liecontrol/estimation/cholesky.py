"""Square-root covariance helpers: Cholesky rank-1 update/downdate and QR "triangularisation".

scipy has no ``cholupdate``; the square-root UKF needs it (Van der Merwe & Wan, "The square-root
unscented Kalman filter for state and parameter-estimation", ICASSP 2001, eqs. 19–28).

All square roots here are **lower triangular** ``S`` with ``P = S Sᵀ``.

* :func:`cholupdate` — ``S' = chol(S Sᵀ + σ v vᵀ)`` for one or several vectors ``v`` applied in
  sequence, ``σ = ±1`` (a negative weight is passed as ``sign=-1`` with ``v`` scaled by
  ``sqrt(|w|)``). The classical O(n²) rotation algorithm (Golub & Van Loan, *Matrix
  Computations*, 4th ed., §6.5.4; Seeger, "Low rank updates for the Cholesky decomposition",
  2004), vectorised over leading batch dimensions; the loop runs over the matrix index only.
* :func:`tria` — lower-triangular ``S`` with ``S Sᵀ = A Aᵀ`` for a wide matrix ``A`` (``n × m``,
  ``m ≥ n``) via the QR decomposition of ``Aᵀ`` (the "qr{·}" of the SRUKF papers).

A downdate that would make the matrix indefinite raises :class:`NotPositiveDefiniteError`
(loss of positive-definiteness is repaired by the caller or raised, never NaN).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dtrtrs

from .._validation import as_array, broadcast_batch, check_bool, check_positive_scalar
from . import _kernels as _k

__all__ = [
    "NotPositiveDefiniteError",
    "cholupdate",
    "tria",
    "nearest_pd_sqrt",
    "solve_lower",
    "chol_solve",
]


class NotPositiveDefiniteError(ValueError):
    """A covariance (or its square root) is not positive definite where it must be."""


def cholupdate(S: object, v: object, sign: float = 1.0) -> np.ndarray:
    """Rank-1 Cholesky update (``sign=+1``) or downdate (``sign=-1``) of a lower factor.

    Parameters
    ----------
    S : (..., n, n) lower-triangular with positive diagonal, ``P = S Sᵀ``.
    v : (..., n) one vector, or (..., n, k) ``k`` vectors (columns) applied in sequence.
    sign : +1 or -1.

    Returns
    -------
    S' : (..., n, n) lower triangular, positive diagonal, ``S' S'ᵀ = S Sᵀ + sign Σ_j v_j v_jᵀ``.

    For each column v, with r = sqrt(S_kk² + σ x_k²), c = r/S_kk, s = x_k/S_kk:
    ``S'_kk = r``, ``S'_{i>k,k} = (S_ik + σ s x_i)/c``, ``x_i ← c x_i − s S'_ik``.
    Raises :class:`NotPositiveDefiniteError` (message starts with ``"S:"``) when a downdate
    would make the result indefinite.
    """
    L = np.array(as_array(S, "S"), dtype=np.float64, copy=True)
    if L.ndim < 2 or L.shape[-1] != L.shape[-2]:
        raise ValueError(f"S: expected a square (..., n, n) array, got shape {L.shape}")
    if (
        isinstance(sign, (bool, np.bool_))
        or not isinstance(sign, (int, float, np.integer, np.floating))
        or sign not in (1, -1)
    ):
        raise ValueError(f"sign: must be the number +1 or -1, got {sign!r}")
    n = L.shape[-1]
    V = as_array(v, "v")
    # one vector per batch element (..., n) unless the last two axes read as (n, k) columns
    if V.shape == L.shape[:-1] or (
        V.ndim >= 1 and V.shape[-1] == n and (V.ndim < 2 or V.shape[-2] != n)
    ):
        V = V[..., None]
    if V.ndim < 2 or V.shape[-2] != n:
        raise ValueError(f"v: expected shape (..., {n}) or (..., {n}, k), got {V.shape}")
    batch = broadcast_batch(("S", L.shape[:-2]), ("v", V.shape[:-2]))
    L = np.array(np.broadcast_to(L, batch + (n, n)), copy=True)
    V = np.array(np.broadcast_to(V, batch + V.shape[-2:]), copy=True)
    if np.any(np.diagonal(L, axis1=-2, axis2=-1) <= 0.0):
        raise ValueError("S: diagonal must be > 0 (not a Cholesky factor)")
    sg = float(sign)
    if L.ndim == 2:
        return _cholupdate_single(L, V, sg)
    worst = np.inf
    for j in range(V.shape[-1]):
        x = V[..., :, j]
        for k in range(n):
            lkk = L[..., k, k]
            xk = x[..., k]
            r2 = lkk * lkk + sg * xk * xk
            # failures are collected and reported once (avoids a reduction per pivot)
            worst = np.minimum(worst, np.min(r2)) if sg < 0 else worst
            r = np.sqrt(np.where(r2 > 0.0, r2, 1.0))
            c = r / lkk
            s = xk / lkk
            L[..., k, k] = r
            if k + 1 < n:
                col = (L[..., k + 1 :, k] + sg * s[..., None] * x[..., k + 1 :]) / c[..., None]
                x[..., k + 1 :] = c[..., None] * x[..., k + 1 :] - s[..., None] * col
                L[..., k + 1 :, k] = col
    if not (worst > 0.0) or not np.all(np.isfinite(L)):
        raise NotPositiveDefiniteError(
            f"S: Cholesky downdate makes the matrix indefinite (smallest pivot r² = {worst:.3e})"
        )
    return L


def _cholupdate_single(L: np.ndarray, V: np.ndarray, sg: float) -> np.ndarray:
    """Unbatched path of :func:`cholupdate`: one compiled call (n is small: per-element numpy
    calls would dominate)."""
    out, worst = _k.cholupdate_lower(L, V, sg)
    if worst <= 0.0 or worst != worst:
        raise NotPositiveDefiniteError(
            f"S: Cholesky downdate makes the matrix indefinite (pivot r² = {worst:.3e} ≤ 0)"
        )
    if not np.isfinite(out).all():
        raise NotPositiveDefiniteError("S: Cholesky update produced non-finite entries")
    return out


def tria(A: object) -> np.ndarray:
    """Lower-triangular S with ``S Sᵀ = A Aᵀ`` and non-negative diagonal (QR of ``Aᵀ``).

    ``A`` : (..., n, m) with m ≥ n. Batched over leading dimensions (numpy's stacked QR).
    """
    a = as_array(A, "A")
    if a.ndim < 2 or a.shape[-2] == 0:
        raise ValueError(f"A: expected shape (..., n, m) with n >= 1, got {a.shape}")
    n, m = a.shape[-2], a.shape[-1]
    if m < n:
        # pad with zero columns so the QR of Aᵀ gives an n×n triangle
        a = np.concatenate((a, np.zeros(a.shape[:-1] + (n - m,))), axis=-1)
    r = np.linalg.qr(np.swapaxes(a, -1, -2), mode="r")
    S = np.swapaxes(r[..., :n, :n], -1, -2)
    # QR leaves signs arbitrary; flip columns so the diagonal is non-negative
    d = np.sign(np.diagonal(S, axis1=-2, axis2=-1))
    d = np.where(d == 0.0, 1.0, d)
    return S * d[..., None, :]


def nearest_pd_sqrt(P: object, floor: float = 1e-12, mirror: bool = False) -> np.ndarray:
    """Repair: lower Cholesky factor of the symmetric part of ``P`` with its eigenvalues clipped
    at ``floor · max(1, max |eigenvalue|)`` (Higham's nearest symmetric PSD matrix, then made
    strictly PD). With ``mirror=True`` a negative eigenvalue λ is replaced by ``max(|λ|, floor
    · …)`` instead (U |Λ| Uᵀ): a covariance whose variance changed sign is restored exactly,
    where clipping would leave an (over-confident) near-zero variance. Used by the filters'
    ``pd_policy="repair"``.

    ``P``: finite real ``(..., n, n)`` (lists accepted); ``floor`` a finite number in (0, 1).
    Raises :class:`NotPositiveDefiniteError` if the result is still not positive definite.
    """
    a = as_array(P, "P")
    if a.ndim < 2 or a.shape[-1] != a.shape[-2] or a.shape[-1] == 0:
        raise ValueError(f"P: expected a non-empty square (..., n, n) array, got shape {a.shape}")
    fl = check_positive_scalar(floor, "floor")
    if not fl < 1.0:
        raise ValueError(f"floor: must be < 1 (a relative eigenvalue floor), got {fl}")
    mirror = check_bool(mirror, "mirror")
    sym = 0.5 * (a + np.swapaxes(a, -1, -2))
    w, U = np.linalg.eigh(sym)
    lo = fl * np.maximum(1.0, np.max(np.abs(w), axis=-1, keepdims=True))
    w = np.maximum(np.abs(w) if mirror else w, lo)
    fixed = (U * w[..., None, :]) @ np.swapaxes(U, -1, -2)
    try:
        S = np.linalg.cholesky(0.5 * (fixed + np.swapaxes(fixed, -1, -2)))
    except np.linalg.LinAlgError:
        raise NotPositiveDefiniteError(
            "P: not positive definite even after the eigenvalue repair (ill-conditioned)"
        ) from None
    return S


def solve_lower(L: np.ndarray, B: np.ndarray, transpose: bool = False) -> np.ndarray:
    """Solve L X = B (or Lᵀ X = B with ``transpose``) for a lower-triangular 2-D ``L``.

    Small systems (n ≤ 16, the filters' case) use row-wise substitution in a compiled kernel
    (numpy's row-wise version otherwise): LAPACK's threaded ``trsm`` (behind scipy's
    ``solve_triangular``/``dtrtrs``) was measured to take milliseconds per 7×7 call on a loaded
    machine through thread contention. Larger systems call LAPACK ``dtrtrs``.
    """
    n = L.shape[0]
    if n <= 16 and 1 <= B.ndim <= 2 and B.shape[0] == n and B.dtype == L.dtype == np.float64:
        # one compiled call (numpy's row-wise substitution costs ~1 µs per row in overhead)
        X, ok = _k.solve_lower_into(L, B.reshape(n, -1), transpose is True)
        if not ok:
            raise NotPositiveDefiniteError("L: singular triangular factor (zero pivot)")
        return X.reshape(B.shape)
    d = np.diagonal(L)
    if np.any(d == 0.0):
        raise NotPositiveDefiniteError("L: singular triangular factor (zero pivot)")
    if n > 16:
        X, _ = dtrtrs(L, B, lower=1, trans=1 if transpose else 0)
        return X
    X = np.array(B, dtype=np.float64, copy=True)
    if transpose:
        U = L.T
        for i in range(n - 1, -1, -1):
            if i + 1 < n:
                X[i] -= U[i, i + 1 :] @ X[i + 1 :]
            X[i] /= d[i]
    else:
        for i in range(n):
            if i:
                X[i] -= L[i, :i] @ X[:i]
            X[i] /= d[i]
    return X


def chol_solve(L: np.ndarray, B: np.ndarray) -> np.ndarray:
    """(L Lᵀ)⁻¹ B by two triangular solves."""
    return solve_lower(L, solve_lower(L, B), transpose=True)
