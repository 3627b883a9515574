"""Steering laws for the SGCMG cluster: momentum-rate command → gimbal rates.

Every law is a small frozen dataclass called as::

    delta_dot = law(A, hdot_cmd, delta=None, t=0.0, cluster=None)

with ``A`` the cluster Jacobian ∂h/∂δ, shape ``(..., 3, n)`` (n = 4 for the pyramid) [N m s/rad],
``hdot_cmd`` the commanded momentum rate ``(..., 3)`` [N m], ``delta`` the gimbal angles
``(..., n)`` (needed by laws that use the singularity-measure gradient), ``t`` the time (for
time-varying laws such as the generalized SR inverse with dither, which will use the same
signature) and ``cluster`` the :class:`~spacecraft.sgcmg.SgcmgPyramid` whose Jacobian ``A`` is.
The plant should pass all of them; each law uses what it needs. Results are ``(..., n)``
[rad/s] and finite for every finite input, including exact singularities.

Laws:

- :class:`PseudoInverse`: δ̇ = Aᵀ(AAᵀ + ε̄ I)⁻¹ ḣ_cmd with ε̄ = ε tr(AAᵀ)/3, ε = 1e-12 (a
  Tikhonov floor, our choice): the Moore–Penrose solution up to a relative error ≈ ε̄/λ_min(AAᵀ)
  (< 1e-10 for the pyramid when m ≳ 0.3), and at an exact singularity the minimum-norm
  least-squares solution (the unrealisable component of ḣ_cmd along the singular direction is
  dropped), so never NaN/inf. Near a singularity the rates are bounded only by
  |ḣ_cmd|/(2√ε̄) ≈ 1.4e3 |ḣ_cmd|/h₀ — the plant's rate limit then applies. Exactly at a
  singularity the rounding residue (~1e-14 h₀) of the zero singular value is amplified by
  1/ε̄, a noise of ~1e-3 |ḣ_cmd|/h₀ in δ̇.
- :class:`PseudoInverseNullMotion` (Wu et al.'s law): δ̇ = A⁺ḣ_cmd + k (I − A⁺A) ∇_δ m; the
  second term lies in the null space of A (produces no torque) and climbs m.
- :class:`SingularityRobust` (Nakamura–Hanafusa / Bedrossian): δ̇ = Âᵀ(ÂÂᵀ + λI)⁻¹ ḣ_cmd / s
  = Aᵀ(AAᵀ + λ s² I)⁻¹ ḣ_cmd, λ = λ₀ exp(−μ m²), with the dimensionless Jacobian Â = A/s and
  s = √(‖A‖²_F / n) the RMS column norm. For the SGCMG pyramid every column of A has norm h₀, so
  s = h₀ exactly and m = √det(ÂÂᵀ) is the singularity measure used here; λ₀ is therefore
  dimensionless and the defaults do not depend on h₀.

- :class:`GeneralizedSingularityRobust` (Wie 2005): δ̇ = Aᵀ(AAᵀ + λ s² E(t))⁻¹ ḣ_cmd with the
  time-varying off-diagonal dither E (see the class); unlike the SR inverse it drives the
  gimbals off (and through) a singularity whose singular direction ḣ_cmd is aligned with.

Hot path: every law has an unchecked entry point ``law.steer(A, hdot_cmd, delta, t, cluster)``
(float64 arrays of matching batch shapes, no validation, no broadcasting) used by
:class:`spacecraft.actuators.SgcmgActuator` at every step; ``law(...)`` validates its arguments
and then calls it. For one spacecraft (batch size 1) the 3×3 solve runs on Python floats
(Cramer's rule, ~5× faster than numpy on 1-element arrays), with LAPACK for a determinant too
small to trust. Likewise :func:`_saturate_unchecked` behind :func:`saturate_gimbal_rates`.

Array API: the singularity-robust law's formula (:func:`_measure_and_scale`,
:func:`_apply_right_inverse_small`) and the uniform rate limit (:func:`_saturate_unchecked`) are
pure functions of the array namespace (:mod:`liecontrol._array_api`). Given ``jax.numpy``
arrays, :meth:`SingularityRobust.steer` and the rate limit run that same source under
``jit``/``vmap``/``grad`` (the JAX route of the closed loop, :mod:`spacecraft.differentiable`);
the NumPy shortcuts (compiled kernel, Python floats for one spacecraft, the row layout of large
batches) are taken for NumPy arrays only, with the same results as before.

A law of your own: subclass :class:`SteeringLaw` (its ``steer``); to fly the simulator's
compiled loop as the built-in laws do, give it a ``fused_kernel(cluster)`` returning a
numba-compiled kernel (:mod:`spacecraft.steering_kernel`, guide in ``docs/fast_controllers.md``).
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass

import numpy as np

from liecontrol._array_api import is_numpy, namespace, safe_sqrt
from liecontrol._jit import JIT_ENABLED
from liecontrol._validation import as_array, as_scalar
from spacecraft._kernels import steer_batch
from spacecraft.sgcmg import SgcmgPyramid

__all__ = [
    "SteeringLaw",
    "PseudoInverse",
    "PseudoInverseNullMotion",
    "SingularityRobust",
    "GeneralizedSingularityRobust",
    "pseudo_inverse",
    "singularity_robust_inverse",
    "jacobian_singularity_measure",
    "saturate_gimbal_rates",
    "PINV_EPS",
]

#: Relative Tikhonov floor ε of the "exact" pseudo-inverse: ε̄ = ε tr(AAᵀ)/3.
PINV_EPS = 1e-12

# Batches up to this size use matmul + LAPACK (np.linalg.solve); larger ones the closed form.
# Measured for _apply_right_inverse (µs, LAPACK / closed): B=1 33/85, B=128 80/161,
# B=300 160/157, B=1000 475/205.
_SMALL_BATCH = 256
# Closed-form results are trusted only if det(M) ≥ this × (tr M / 3)³ (relative rounding error
# of the cofactor determinant ≲ 1e-5); the rest go through LU with partial pivoting.
_DET_REL_TRUST = 1e-10


# ---------------------------------------------------------------------------- linear algebra
def _solve_spd3(M: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve M X = rhs for symmetric positive-definite ``M (..., 3, 3)``, ``rhs (..., 3, k)``.

    NumPy: LU with partial pivoting (LAPACK, batched). JAX: Cramer's rule on the symmetric 3×3
    (adjugate from the upper triangle, elementwise), the compiled kernel's formula
    (:func:`spacecraft._kernels._regularised_multiplier`; callers regularise M, so det > 0):
    XLA's batched LU custom call inside the closed loop's scan stopped making progress (0 % CPU,
    no return) for batches of 8 192 and more on the CPU (jax 0.10.2), and an elementwise
    solve is what a vmapped 3×3 wants on an accelerator anyway."""
    xp = namespace(M, rhs)
    if xp is np:
        return np.linalg.solve(M, rhs)
    a, b, c = M[..., 0, 0], M[..., 0, 1], M[..., 0, 2]
    d, e, f = M[..., 1, 1], M[..., 1, 2], M[..., 2, 2]
    c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
    c11, c12, c22 = a * f - c * c, b * c - a * e, a * d - b * b
    det = a * c00 + b * c01 + c * c02
    adj = xp.stack(
        (xp.stack((c00, c01, c02), -1), xp.stack((c01, c11, c12), -1),
         xp.stack((c02, c12, c22), -1)), -2,
    )  # fmt: skip
    return (adj @ rhs) / det[..., None, None]


def _gram_entries(A: np.ndarray) -> tuple[np.ndarray, ...]:
    """Upper triangle (M00, M01, M02, M11, M12, M22) of M = AAᵀ, each ``(...)``."""
    r0, r1, r2 = A[..., 0, :], A[..., 1, :], A[..., 2, :]
    return (
        (r0 * r0).sum(-1),
        (r0 * r1).sum(-1),
        (r0 * r2).sum(-1),
        (r1 * r1).sum(-1),
        (r1 * r2).sum(-1),
        (r2 * r2).sum(-1),
    )


def _floor(tr3: np.ndarray, lam: np.ndarray | float, eps: float) -> np.ndarray:
    """λ + ε tr(M)/3; the ε floor keeps M + ·I positive definite at rank deficiency, and 1 is
    used when the sum is 0 (only if A = 0, where Aᵀx = 0 whatever x)."""
    reg = lam + eps * tr3
    return namespace(reg).where(reg > 0.0, reg, 1.0)


def _off_matrix(off: tuple[float, float, float]) -> np.ndarray:
    """Symmetric 3×3 with zero diagonal and upper entries (0,1), (0,2), (1,2) = ``off``
    (floats, or JAX scalars: pure)."""
    e01, e02, e12 = off
    xp = namespace(e01, e02, e12)
    if is_numpy(xp):
        return np.array([[0.0, e01, e02], [e01, 0.0, e12], [e02, e12, 0.0]])
    z = xp.zeros_like(e01)
    return xp.stack([xp.stack([z, e01, e02]), xp.stack([e01, z, e12]), xp.stack([e02, e12, z])])


def _apply_right_inverse_small(
    A: np.ndarray,
    R: np.ndarray,
    lam: np.ndarray | float,
    eps: float,
    off: tuple[float, float, float] | None = None,
) -> np.ndarray:
    xp = namespace(A, R, lam)
    M = A @ xp.swapaxes(A, -1, -2)
    reg = _floor(xp.trace(M, axis1=-2, axis2=-1) / 3.0, lam, eps)
    Mr = M + reg[..., None, None] * np.eye(3)
    if off is not None:
        Mr = Mr + xp.asarray(lam)[..., None, None] * _off_matrix(off)
    return xp.swapaxes(A, -1, -2) @ _solve_spd3(Mr, R)


def _batch_rows(A: np.ndarray) -> np.ndarray:
    """``A (..., p, q)`` as ``(p, q, N)`` C-contiguous (N = batch size): every entry becomes a
    contiguous ``(N,)`` row, so the closed-form 3×3 algebra below runs on unit-stride arrays.
    Free (a view) when ``A`` is itself a moved-axis view of such an array, as
    :class:`spacecraft.actuators.SgcmgActuator` passes its Jacobian."""
    A2 = A.reshape((-1,) + A.shape[-2:])
    return np.ascontiguousarray(A2.transpose(1, 2, 0))


def _gram_rows(At: np.ndarray) -> tuple[np.ndarray, ...]:
    """:func:`_gram_entries` of ``A`` given as :func:`_batch_rows` ``(3, n, N)``: the same sums
    in the same order (((p₀ + p₁) + p₂) + …), each on contiguous ``(N,)`` rows — ~5× cheaper
    than reducing the short last axis of ``(N, n)`` slices."""
    n = At.shape[1]
    out = []
    for r, q in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)):
        a, b = At[r], At[q]
        g = a[0] * b[0]
        for i in range(1, n):
            g += a[i] * b[i]
        out.append(g)
    return tuple(out)


def _measure_from_gram(g: tuple[np.ndarray, ...], n: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_measure_and_scale` from the Gram entries (same arithmetic)."""
    a, b, c, d, e, f = g
    det = a * (d * f - e * e) + b * (c * e - b * f) + c * (b * e - c * d)
    s2 = (a + d + f) / n
    s2_safe = np.where(s2 > 0.0, s2, 1.0)
    return np.sqrt(np.maximum(det, 0.0) / (s2_safe * s2_safe * s2_safe)), s2


def _apply_right_inverse(
    A: np.ndarray,
    R: np.ndarray,
    lam: np.ndarray | float = 0.0,
    eps: float = PINV_EPS,
    off: tuple[float, float, float] | None = None,
    rows: tuple[np.ndarray, tuple[np.ndarray, ...]] | None = None,
) -> np.ndarray:
    """Aᵀ(AAᵀ + λ E + ε tr(AAᵀ)/3 I)⁻¹ R for ``A (..., 3, n)``, ``R (..., 3, k)`` → ``(..., n, k)``.

    ``E`` is the identity, or (``off`` given) the unit-diagonal symmetric matrix with upper
    off-diagonal entries ``off = (E01, E02, E12)`` (the generalized SR dither, shared by the
    whole batch). Small batches: batched matmul + LAPACK. Large batches: Cramer's rule on the
    symmetric 3×3 in elementwise form on contiguous per-entry rows (:func:`_batch_rows`;
    measured ~2× faster than LAPACK at B = 1000 in row-wise slices, and again ~3× faster in
    this layout), with the LAPACK route for the elements whose cofactor determinant is too
    small to trust. ``rows``: ``(_batch_rows(A), _gram_rows(...))`` if the caller has them.
    """
    batch = A.shape[:-2]
    N = int(np.prod(batch, dtype=np.int64))
    if N <= _SMALL_BATCH:
        return _apply_right_inverse_small(A, R, lam, eps, off)
    if rows is None:
        At = _batch_rows(A)
        g = _gram_rows(At)
    else:
        At, g = rows
    a, b, c, d, e, f = g
    if not np.isscalar(lam):
        lam = np.broadcast_to(lam, batch).reshape(N)
    tr3 = (a + d + f) / 3.0
    reg = _floor(tr3, lam, eps)
    a, d, f = a + reg, d + reg, f + reg
    if off is not None:
        b = b + lam * off[0]
        c = c + lam * off[1]
        e = e + lam * off[2]
    c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
    c11, c12, c22 = a * f - c * c, b * c - a * e, a * d - b * b
    det = a * c00 + b * c01 + c * c02
    tr3 = tr3 + reg
    ok = det >= _DET_REL_TRUST * tr3 * tr3 * tr3
    inv_det = 1.0 / np.where(ok, det, 1.0)
    Rt = _batch_rows(np.broadcast_to(R, batch + R.shape[-2:]))  # (3, k, N)
    R0, R1, R2 = Rt[0], Rt[1], Rt[2]
    x0 = (c00 * R0 + c01 * R1 + c02 * R2) * inv_det  # (k, N)
    x1 = (c01 * R0 + c11 * R1 + c12 * R2) * inv_det
    x2 = (c02 * R0 + c12 * R1 + c22 * R2) * inv_det
    out = At[0][:, None, :] * x0 + At[1][:, None, :] * x1 + At[2][:, None, :] * x2  # (n, k, N)
    # back to the batch-leading layout, contiguous (the callers slice and scale it)
    out = np.ascontiguousarray(out.transpose(2, 0, 1))
    if not np.all(ok):
        bad = ~ok
        A_flat = A.reshape((N,) + A.shape[-2:])
        lam_bad = np.broadcast_to(lam, (N,))[bad]
        R_bad = np.broadcast_to(R, batch + R.shape[-2:]).reshape((N,) + R.shape[-2:])[bad]
        out[bad] = _apply_right_inverse_small(A_flat[bad], R_bad, lam_bad, eps, off)
    return out.reshape(batch + out.shape[1:])


# ---------------------------------------------------------------------------- compiled route
def _steer_kernel(law: SteeringLaw, A: np.ndarray, hdot_cmd: np.ndarray, t: float) -> np.ndarray:
    """δ̇ of the pseudo-inverse / SR / GSR laws through their compiled kernel
    (:func:`spacecraft._kernels.steer_regularised`), element by element over the batch."""
    code, params = steering_kernel(law)
    n = A.shape[-1]
    batch = A.shape[:-2]
    A2 = np.ascontiguousarray(A.reshape((-1, 3, n)), dtype=np.float64)
    q = np.ascontiguousarray(np.broadcast_to(hdot_cmd, batch + (3,)).reshape(-1, 3))
    out = np.empty((A2.shape[0], n))
    steer_batch(code, params, float(t), A2, q, out)
    return out.reshape(batch + (n,))


def _use_kernel(law: SteeringLaw, A: np.ndarray) -> bool:
    """The compiled route applies: a law of exactly this class (a subclass may override the
    formula), and numba is on (or a single spacecraft, where the Python kernel still wins)."""
    return type(law) in _KERNEL_LAWS and (JIT_ENABLED or A.ndim == 2 or A.shape[0] == 1)


def _check_jacobian(A: object) -> np.ndarray:
    a = as_array(A, "A")
    if a.ndim < 2 or a.shape[-2] != 3:
        raise ValueError(f"A: expected shape (..., 3, n), got {a.shape}")
    return a


def _check_eps(eps: float) -> float:
    e = as_scalar(eps, "eps")
    if not 0.0 < e < 1.0:
        raise ValueError(f"eps: must lie in (0, 1), got {eps}")
    return e


def pseudo_inverse(A: object, eps: float = PINV_EPS) -> np.ndarray:
    """A⁺ = Aᵀ(AAᵀ + ε̄I)⁻¹, ε̄ = ε tr(AAᵀ)/3, shape ``(..., n, 3)`` for ``A (..., 3, n)``.

    The Moore–Penrose inverse of a full-row-rank A up to a relative error ~ε̄/λ_min(AAᵀ); at a
    rank-deficient A it tends to the minimum-norm least-squares inverse (finite).
    """
    a = _check_jacobian(A)
    eps = _check_eps(eps)
    a, c = _rescaled(a)
    out = _apply_right_inverse(a, np.broadcast_to(np.eye(3), a.shape[:-2] + (3, 3)), 0.0, eps)
    return out if c is None else out / c


def singularity_robust_inverse(A: object, lam: object, eps: float = PINV_EPS) -> np.ndarray:
    """SR inverse Aᵀ(AAᵀ + λI)⁻¹, ``(..., n, 3)`` (Nakamura–Hanafusa 1986).

    ``lam`` ≥ 0 (scalar or batch-shaped ``(...)``) is in the units of AAᵀ (for the SGCMG:
    [N m s]²; the :class:`SingularityRobust` law passes λ h₀²). The tiny floor ε tr(AAᵀ)/3 of
    :func:`pseudo_inverse` is added so λ = 0 at a singularity stays finite.
    """
    a = _check_jacobian(A)
    eps = _check_eps(eps)
    lam = as_array(lam, "lam")
    if lam.size == 0:
        raise ValueError(f"lam: expected a scalar or a batch-shaped array, got shape {lam.shape}")
    if np.any(lam < 0):
        raise ValueError(f"lam: must be >= 0, got {lam.min()}")
    try:
        batch = np.broadcast_shapes(a.shape[:-2], lam.shape)
    except ValueError:
        raise ValueError(
            f"lam: shape {lam.shape} does not broadcast with A's batch shape {a.shape[:-2]}"
        ) from None
    a = np.broadcast_to(a, batch + a.shape[-2:])
    a, c = _rescaled(a)
    if c is not None:
        lam = lam / (c[..., 0, 0] * c[..., 0, 0])  # Aᵀ(AAᵀ + λI)⁻¹ = Âᵀ(ÂÂᵀ + λ/c²)⁻¹ / c
    out = _apply_right_inverse(a, np.broadcast_to(np.eye(3), batch + (3, 3)), lam, eps)
    return out if c is None else out / c


def jacobian_singularity_measure(A: object) -> np.ndarray:
    """m = √det(ÂÂᵀ), Â = A/s, s = √(‖A‖²_F/n) (RMS column norm), shape ``(...)``.

    For the SGCMG pyramid s = h₀, so this equals ``SgcmgPyramid.singularity_measure``.
    """
    a = _check_jacobian(A)
    return _measure_and_scale(_rescaled(a)[0])[0]  # m is scale-invariant


def _rescaled(a: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """``(a / c, c)`` with ``c = max |a|`` per matrix ``(..., 1, 1)`` when the Gram matrix
    ``a aᵀ`` would overflow (entries beyond ~1e150), else ``(a, None)``: the inverses and the
    singularity measure are then computed on the unit-scale matrix (exactly, up to rounding)."""
    if a.size == 0 or float(np.abs(a).max()) < 1e150:
        return a, None
    c = np.abs(a).max(axis=(-2, -1), keepdims=True)
    c = np.where(c > 0.0, c, 1.0)
    return a / c, c


def _measure_and_scale(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(m, s²) with s² = ‖A‖²_F/n and m = √det(AAᵀ)/s³ (0 for A = 0). Pure (NumPy or JAX):
    the square root is :func:`~liecontrol._array_api.safe_sqrt`, √x for x > 0 and 0 at an
    exact singularity (det = 0) with a finite derivative there."""
    xp = namespace(A)
    a, b, c, d, e, f = _gram_entries(A)
    det = a * (d * f - e * e) + b * (c * e - b * f) + c * (b * e - c * d)
    s2 = (a + d + f) / A.shape[-1]
    s2_safe = xp.where(s2 > 0.0, s2, 1.0)
    return safe_sqrt(xp.maximum(det, 0.0) / (s2_safe * s2_safe * s2_safe), xp), s2


def _measure_scale_rows(
    A: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, tuple[np.ndarray, ...]] | None]:
    """(m, s², rows) for the SR laws: large batches compute the Gram entries once in the row
    layout and hand them on to :func:`_apply_right_inverse` (``rows``); small batches ``None``.
    Same values as :func:`_measure_and_scale`."""
    if int(np.prod(A.shape[:-2], dtype=np.int64)) <= _SMALL_BATCH:
        return (*_measure_and_scale(A), None)
    At = _batch_rows(A)
    g = _gram_rows(At)
    m, s2 = _measure_from_gram(g, A.shape[-1])
    shape = A.shape[:-2]
    return m.reshape(shape), s2.reshape(shape), (At, g)


def saturate_gimbal_rates(delta_dot: object, limit: object) -> tuple[np.ndarray, np.ndarray]:
    """Uniformly scale each spacecraft's gimbal-rate vector so that max|δ̇ᵢ| ≤ limit.

    δ̇_sat = δ̇ · min(1, limit / max_i |δ̇ᵢ|): the whole vector is scaled by one factor, so its
    direction — and hence the direction of the delivered torque A δ̇ — is kept (clipping each
    gimbal separately would change the torque direction). Returns ``(delta_dot_sat, saturated)``
    with ``saturated`` a boolean ``(...)`` flag per spacecraft (True where scaling happened).
    ``limit`` > 0 is a scalar or broadcastable to the batch shape ``(...)``. Validates, then
    calls :func:`_saturate_unchecked` (the simulator's hot path).
    """
    dd = as_array(delta_dot, "delta_dot")
    if dd.ndim < 1 or dd.shape[-1] == 0:
        raise ValueError(f"delta_dot: expected shape (..., n) with n >= 1, got {dd.shape}")
    lim = as_array(limit, "limit")
    if lim.size == 0 or np.any(lim <= 0):
        raise ValueError(f"limit: must be > 0, got {lim.min() if lim.size else 'an empty array'}")
    try:
        ok = np.broadcast_shapes(dd.shape[:-1], lim.shape) == dd.shape[:-1]
    except ValueError:
        ok = False
    if not ok:
        raise ValueError(
            f"limit: shape {lim.shape} does not broadcast with delta_dot's batch shape "
            f"{dd.shape[:-1]}"
        ) from None
    return _saturate_unchecked(dd, float(lim) if lim.ndim == 0 else lim)


def _saturate_unchecked(dd: np.ndarray, lim: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`saturate_gimbal_rates` without validation: ``dd`` float64 ``(..., n)``, ``lim`` a
    positive float or a positive array broadcastable to ``(...)``. Same arithmetic (one IEEE
    division and one product per element) on both routes, so the results are identical.

    Pure for JAX arrays (the last route): the divide is guarded (lim / 1 where no scaling
    happens) so that its derivative stays finite at δ̇ = 0, and the scale is continuous (= 1)
    at the switch peak = lim, where its derivative jumps but stays finite."""
    xp = namespace(dd, lim)
    numpy = is_numpy(xp)
    if numpy and isinstance(lim, float) and dd.size == dd.shape[-1]:
        # one spacecraft: a Python max over ≤ 4 floats instead of three numpy reductions
        peak = max(map(abs, dd.reshape(-1).tolist()), default=0.0)
        flag = peak > lim
        out = dd * (lim / peak) if flag else dd.copy()
        return out, np.full(dd.shape[:-1], flag)
    a = xp.abs(dd)
    if numpy and a.ndim == 2 and a.shape[0] > _SMALL_BATCH:
        # column-wise maxima: reducing the short last axis of a long (B, n) array is ~5× slower
        # (max is exact and np.maximum propagates NaN like max, so the result is the same)
        peak = a[:, 0].copy()
        for j in range(1, a.shape[1]):
            np.maximum(peak, a[:, j], out=peak)
    else:
        peak = a.max(axis=-1)
    saturated = peak > lim
    scale = xp.where(saturated, lim / xp.where(saturated, peak, 1.0), 1.0)
    return dd * scale[..., None], xp.broadcast_to(saturated, peak.shape).copy()


# ---------------------------------------------------------------------------- laws
def _check_inputs(A: object, hdot_cmd: object) -> tuple[np.ndarray, np.ndarray]:
    a = _check_jacobian(A)
    h = as_array(hdot_cmd, "hdot_cmd", (3,))
    if a.shape[:-2] != h.shape[:-1]:
        try:
            shape = np.broadcast_shapes(a.shape[:-2], h.shape[:-1])
        except ValueError:
            raise ValueError(
                f"hdot_cmd: batch shape {h.shape[:-1]} does not broadcast with A's {a.shape[:-2]}"
            ) from None
        a = np.broadcast_to(a, shape + a.shape[-2:])
        h = np.broadcast_to(h, shape + (3,))
    return a, h


def _check_optional(a: np.ndarray, delta: object, cluster: object) -> np.ndarray | None:
    """Validate the optional ``delta`` (gimbal angles ``(..., n)`` matching ``A``) and
    ``cluster`` arguments of a law's public call; laws that ignore them still reject junk."""
    if cluster is not None and not isinstance(cluster, SgcmgPyramid):
        raise ValueError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
    if delta is None:
        return None
    d = as_array(delta, "delta")
    if d.shape != a.shape[:-2] + a.shape[-1:]:
        raise ValueError(
            f"delta: shape {d.shape} does not match A's {a.shape} (expected "
            f"{a.shape[:-2] + a.shape[-1:]})"
        )
    return d


def _finite_rates(out: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``out`` if finite; else raise naming ``hdot_cmd`` (finite inputs, non-finite rates:
    |ḣ_cmd|/h₀ overflowed float64 inside the solve)."""
    if not np.all(np.isfinite(out)):
        raise ValueError(
            f"hdot_cmd: the gimbal rates overflow float64 (max |hdot_cmd| = "
            f"{float(np.abs(h).max()):.3g}; the rates scale like |hdot_cmd|/h0)"
            if h.size and float(np.abs(h).max()) > 1e150
            else "A: entries too large or too small, the gimbal rates overflow float64"
        )
    return out


def _check_float(v: object, name: str, lo: float = 0.0, hi: float = np.inf) -> float:
    x = as_scalar(v, name)  # a finite real scalar, else a message naming the argument
    if not lo <= x < hi:
        raise ValueError(f"{name}: must be finite and in [{lo}, {hi}), got {v!r}")
    return x


class SteeringLaw(abc.ABC):
    """Interface of a steering law: ``law(A, hdot_cmd, delta, t, cluster) -> delta_dot``.

    Subclasses implement :meth:`steer` (unchecked); ``__call__`` validates ``A`` and
    ``hdot_cmd`` (broadcasting their batch shapes), then calls it.
    """

    def __call__(
        self,
        A: np.ndarray,
        hdot_cmd: np.ndarray,
        delta: np.ndarray | None = None,
        t: float = 0.0,
        cluster: SgcmgPyramid | None = None,
    ) -> np.ndarray:
        """Gimbal rates δ̇ ``(..., n)`` [rad/s] realising ḣ_cmd as closely as the law allows."""
        a, h = _check_inputs(A, hdot_cmd)
        _check_optional(a, delta, cluster)
        # PI, SR and GSR are homogeneous of degree −1 in A (their damping scales with s² ∝ c²),
        # so a huge A is solved at unit scale and the rates divided by its scale c
        a, c = _rescaled(a)
        out = self.steer(a, h, delta, as_scalar(t, "t"), cluster)
        return _finite_rates(out if c is None else out / c[..., 0], h)

    @abc.abstractmethod
    def steer(
        self,
        A: np.ndarray,
        hdot_cmd: np.ndarray,
        delta: np.ndarray | None = None,
        t: float = 0.0,
        cluster: SgcmgPyramid | None = None,
    ) -> np.ndarray:
        """Unchecked entry point (hot path): ``A`` float64 ``(..., 3, n)``, ``hdot_cmd`` float64
        ``(..., 3)`` with the same batch shape, ``t`` a float; no validation."""


@dataclass(frozen=True)
class PseudoInverse(SteeringLaw):
    """Moore–Penrose steering δ̇ = Aᵀ(AAᵀ)⁻¹ ḣ_cmd, with the relative floor
    ``eps`` (see :func:`pseudo_inverse`) so that exact singularities give finite rates."""

    eps: float = PINV_EPS

    def __post_init__(self) -> None:
        object.__setattr__(self, "eps", _check_eps(self.eps))

    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        if not is_numpy(namespace(A, hdot_cmd)):
            # JAX arrays: the small-batch formula (pure), batched by vmap or broadcasting
            return _apply_right_inverse_small(A, hdot_cmd[..., None], 0.0, self.eps)[..., 0]
        if _use_kernel(self, A):
            return _steer_kernel(self, A, hdot_cmd, t)
        return _apply_right_inverse(A, hdot_cmd[..., None], 0.0, self.eps)[..., 0]


@dataclass(frozen=True)
class PseudoInverseNullMotion(SteeringLaw):
    """Pseudo-inverse plus null motion (Wu et al.'s law)::

        δ̇ = A⁺ ḣ_cmd + k (I − A⁺A) ∇_δ m,

    ∇_δ m from :meth:`SgcmgPyramid.singularity_measure_and_gradient` (m with Â = A/h₀, so k is
    in rad/s per unit of |∇m| [1/rad]). A (I − A⁺A) = 0, so the null term adds no torque, and
    ∇mᵀ(I − A⁺A)∇m = |(I − A⁺A)∇m|² ≥ 0, so it never decreases m to first order. Wu et al. do
    not give k (*reconstructed* default 0.01 rad/s: keeps the null-motion rates at the paper's
    scale of < 0.02 rad/s). ``delta`` is required; ``cluster`` is taken from the call or, if
    not given there, from the field (``A`` must be that cluster's Jacobian at ``delta``).
    """

    k: float = 0.01
    cluster: SgcmgPyramid | None = None
    eps: float = PINV_EPS

    def __post_init__(self) -> None:
        object.__setattr__(self, "k", _check_float(self.k, "k"))
        object.__setattr__(self, "eps", _check_eps(self.eps))
        if self.cluster is not None and not isinstance(self.cluster, SgcmgPyramid):
            raise ValueError(f"cluster: expected an SgcmgPyramid, got {type(self.cluster)}")

    def __call__(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        if cluster is not None and not isinstance(cluster, SgcmgPyramid):
            raise ValueError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
        cl = cluster if cluster is not None else self.cluster
        if cl is None:
            raise ValueError("cluster: PseudoInverseNullMotion needs the SgcmgPyramid")
        if self.cluster is not None and cluster is not None and cluster != self.cluster:
            raise ValueError("cluster: differs from the law's own cluster")
        if delta is None:
            raise ValueError("delta: PseudoInverseNullMotion needs the gimbal angles")
        a, h = _check_inputs(A, hdot_cmd)
        d = as_array(delta, "delta", (4,))
        if d.shape != a.shape[:-2] + a.shape[-1:]:
            raise ValueError(
                f"delta: shape {np.shape(delta)} does not match A's {a.shape} (expected "
                f"{a.shape[:-2] + a.shape[-1:]})"
            )
        return _finite_rates(self.steer(a, h, d, as_scalar(t, "t"), cl), h)

    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        cl = cluster if cluster is not None else self.cluster
        _, grad = cl._measure_and_gradient(delta)
        # One solve for both right-hand sides: A⁺ḣ_cmd and A⁺(A ∇m).
        xp = namespace(A, hdot_cmd, grad)
        rhs = xp.stack([hdot_cmd, (A * grad[..., None, :]).sum(-1)], axis=-1)
        # JAX arrays: the small-batch formula (pure), batched by vmap or broadcasting
        apply = _apply_right_inverse if is_numpy(xp) else _apply_right_inverse_small
        x = apply(A, rhs, 0.0, self.eps)
        return x[..., 0] + self.k * (grad - x[..., 1])


@dataclass(frozen=True)
class SingularityRobust(SteeringLaw):
    """Singularity-robust inverse (Nakamura & Hanafusa 1986; Bedrossian 1990)::

        δ̇ = Aᵀ(AAᵀ + λ s² I)⁻¹ ḣ_cmd,  λ = λ₀ exp(−μ m²),

    with s = √(‖A‖²_F/n) (= h₀ for the pyramid) and m = √det(ÂÂᵀ), Â = A/s, i.e. the SR
    inverse of the dimensionless Jacobian: λ₀, μ are dimensionless. Defaults λ₀ = 0.01, μ = 10:
    λ ≈ 1e-2 at m = 0, 8e-4 at m = 0.5, 5e-7 at m = 1 (the pyramid's m ≤ 1.54), so the law is
    ≈ the pseudo-inverse away from singularities and bounded (|δ̇| ≤ |ḣ|/(2 s √λ)) near them.
    Trades a torque error for bounded rates; it does not escape an exact singularity whose
    singular direction ḣ_cmd is aligned with (use :class:`GeneralizedSingularityRobust`).
    """

    lambda0: float = 0.01
    mu: float = 10.0

    def __post_init__(self) -> None:
        for name in ("lambda0", "mu"):
            object.__setattr__(self, name, _check_float(getattr(self, name), name))

    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        xp = namespace(A, hdot_cmd)
        if not is_numpy(xp):
            # JAX arrays: the small-batch formula below (pure), batched by vmap or broadcasting
            m, s2 = _measure_and_scale(A)
            lam = self.lambda0 * xp.exp(-self.mu * m * m) * s2
            return _apply_right_inverse_small(A, hdot_cmd[..., None], lam, PINV_EPS)[..., 0]
        if _use_kernel(self, A):
            return _steer_kernel(self, A, hdot_cmd, t)
        m, s2, rows = _measure_scale_rows(A)
        lam = self.lambda0 * np.exp(-self.mu * m * m) * s2
        return _apply_right_inverse(A, hdot_cmd[..., None], lam, PINV_EPS, rows=rows)[..., 0]


@dataclass(frozen=True)
class GeneralizedSingularityRobust(SteeringLaw):
    """Generalized singularity-robust inverse with a deterministic dither (Wie 2005)::

        δ̇ = Aᵀ(AAᵀ + λ s² E(t))⁻¹ ḣ_cmd,   λ = λ₀ exp(−μ m²),

              ⎡ 1   ε₃  ε₂ ⎤
        E  =  ⎢ ε₃  1   ε₁ ⎥,   εᵢ = ε₀ sin(ω_ε t + φᵢ),
              ⎣ ε₂  ε₁  1  ⎦

    with s, m as in :class:`SingularityRobust` (λ₀ dimensionless; Wie writes λ for the
    normalised Jacobian, which is λ s² here). Why it escapes: at a singularity with
    singular direction u (Aᵀu = 0) and ḣ_cmd ∥ u, the SR inverse returns δ̇ = 0 (the gimbals
    never move); the off-diagonal εᵢ couple u into the range of A, so (AAᵀ + λE)⁻¹u has a
    component in range(A) of order εᵢ/σ² and δ̇ ≠ 0: the gimbals move, m grows and the
    momentum passes through. The price is a small, bounded, deliberate torque error
    (λE ≠ 0 everywhere, ~λ₀ exp(−μ m²) relative), which vanishes away from singularities.

    |εᵢ| ≤ ε₀ < ½ keeps E positive definite (Gershgorin: λ_min(E) ≥ 1 − 2ε₀), so AAᵀ + λE is
    always invertible and δ̇ is finite for every finite input (never NaN). ``t`` [s] must be
    passed (the plant passes the simulation time).

    Defaults are the values usually quoted from Wie (2005): λ₀ = 0.01, μ = 10, ε₀ = 0.01,
    ω_ε = π/2 rad/s, φ = (0, π/2, π) (*not re-checked against the paper's text here*; the
    structure of E and λ is the paper's, its normalisation by s² is ours).

    Args:
        lambda0: λ₀ ≥ 0 (dimensionless).
        mu: μ ≥ 0.
        epsilon0: dither amplitude ε₀ ∈ [0, 0.5).
        omega_eps: dither frequency ω_ε [rad/s], finite.
        phases: (φ₁, φ₂, φ₃) [rad].
    """

    lambda0: float = 0.01
    mu: float = 10.0
    epsilon0: float = 0.01
    omega_eps: float = math.pi / 2
    phases: tuple[float, float, float] = (0.0, math.pi / 2, math.pi)

    def __post_init__(self) -> None:
        object.__setattr__(self, "lambda0", _check_float(self.lambda0, "lambda0"))
        object.__setattr__(self, "mu", _check_float(self.mu, "mu"))
        object.__setattr__(self, "epsilon0", _check_float(self.epsilon0, "epsilon0", 0.0, 0.5))
        object.__setattr__(
            self, "omega_eps", _check_float(self.omega_eps, "omega_eps", -np.inf, np.inf)
        )
        ph = as_array(self.phases, "phases")  # real and finite (complex/text rejected)
        if ph.shape != (3,):
            raise ValueError(f"phases: expected 3 finite angles [rad], got {self.phases!r}")
        object.__setattr__(self, "phases", tuple(ph.tolist()))

    def dither(self, t: float) -> tuple[float, float, float]:
        """(ε₁, ε₂, ε₃) at time ``t`` [s] (a float, or a JAX scalar: pure)."""
        w, e0 = self.omega_eps, self.epsilon0
        p1, p2, p3 = self.phases
        xp = namespace(t)
        sin = math.sin if is_numpy(xp) else xp.sin
        return (e0 * sin(w * t + p1), e0 * sin(w * t + p2), e0 * sin(w * t + p3))

    def dither_matrix(self, t: float) -> np.ndarray:
        """E(t), ``(3, 3)``."""
        e1, e2, e3 = self.dither(float(t))
        return np.eye(3) + _off_matrix((e3, e2, e1))

    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        xp = namespace(A, hdot_cmd, t)
        if not is_numpy(xp):
            # JAX arrays: the small-batch formula (pure), batched by vmap or broadcasting
            e1, e2, e3 = self.dither(t)
            m, s2 = _measure_and_scale(A)
            lam = self.lambda0 * xp.exp(-self.mu * m * m) * s2
            off = (e3, e2, e1)
            return _apply_right_inverse_small(A, hdot_cmd[..., None], lam, PINV_EPS, off)[..., 0]
        if _use_kernel(self, A):
            return _steer_kernel(self, A, hdot_cmd, t)
        e1, e2, e3 = self.dither(t)
        off = (e3, e2, e1)  # E01, E02, E12
        m, s2, rows = _measure_scale_rows(A)
        lam = self.lambda0 * np.exp(-self.mu * m * m) * s2
        return _apply_right_inverse(A, hdot_cmd[..., None], lam, PINV_EPS, off, rows)[..., 0]


#: the laws with a compiled kernel (:func:`steering_kernel`)
_KERNEL_LAWS = (PseudoInverse, SingularityRobust, GeneralizedSingularityRobust)


def steering_kernel(law: object, cluster: SgcmgPyramid | None = None) -> tuple | None:
    """``(code, params)`` of a steering law with a compiled kernel
    (:func:`spacecraft._kernels.steer_regularised`, :func:`~spacecraft._kernels.sgcmg_command`),
    else ``None``. Exact types only (a subclass may override the formula). The null-motion law
    needs the ``cluster`` it steers."""
    from ._kernels import STEER_GSR, STEER_PINV, STEER_PINV_NULL, STEER_SR
    from .sgcmg import MEASURE_FLOOR

    kind = type(law)
    if kind is PseudoInverse:
        return STEER_PINV, np.array([0.0, 0.0, law.eps, 0.0, 0.0, 0.0, 0.0, 0.0])
    if kind is SingularityRobust:
        return STEER_SR, np.array([law.lambda0, law.mu, PINV_EPS, 0.0, 0.0, 0.0, 0.0, 0.0])
    if kind is GeneralizedSingularityRobust:
        p = [law.lambda0, law.mu, PINV_EPS, law.epsilon0, law.omega_eps, *law.phases]
        return STEER_GSR, np.array(p, dtype=np.float64)
    if kind is PseudoInverseNullMotion and cluster is not None:
        head = [law.k, law.eps, MEASURE_FLOOR, 0.0, 0.0, 0.0, 0.0, 0.0]
        unit = np.concatenate([np.ravel(cluster._S), np.ravel(cluster._C)])
        return STEER_PINV_NULL, np.concatenate([np.array(head), unit])
    return None


# ---------------------------------------------------------------------------- more laws
# Laws for the singular-transit comparison (local gradient, singular-direction avoidance).
# They use only the public functions above, so they are independent of the private solvers.
__all__ += ["LocalGradient", "SingularDirectionAvoidance"]


def _cluster_law_call(
    law: SteeringLaw,
    own: SgcmgPyramid | None,
    A: object,
    hdot_cmd: object,
    delta: object,
    t: object,
    cluster: object,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, SgcmgPyramid]:
    """Validate the call of a law that needs the gimbal angles and the cluster (as
    :class:`PseudoInverseNullMotion` does): returns ``(A, hdot_cmd, delta, t, cluster)``."""
    name = type(law).__name__
    if cluster is not None and not isinstance(cluster, SgcmgPyramid):
        raise ValueError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
    cl = cluster if cluster is not None else own
    if cl is None:
        raise ValueError(f"cluster: {name} needs the SgcmgPyramid")
    if own is not None and cluster is not None and cluster != own:
        raise ValueError("cluster: differs from the law's own cluster")
    if delta is None:
        raise ValueError(f"delta: {name} needs the gimbal angles")
    a, h = _check_inputs(A, hdot_cmd)
    d = as_array(delta, "delta", (4,))
    if d.shape != a.shape[:-2] + a.shape[-1:]:
        raise ValueError(
            f"delta: shape {np.shape(delta)} does not match A's {a.shape} (expected "
            f"{a.shape[:-2] + a.shape[-1:]})"
        )
    return a, h, d, as_scalar(t, "t"), cl


@dataclass(frozen=True)
class LocalGradient(SteeringLaw):
    """Local-gradient steering: pseudo-inverse plus null motion with step control::

        δ̇ = A⁺ḣ_cmd + γ ν,   ν = (I − A⁺A) ∇_δ m,
        γ = min( max(m* − m, 0) / (τ |ν|²),  ν_max / |ν| )   (γ = 0 if |ν| = 0),

    with m = √det(ÂÂᵀ), Â = A/h₀, and ∇_δ m from
    :meth:`SgcmgPyramid.singularity_measure_and_gradient`. This is the gradient method of the
    steering-law literature (Kurokawa, "Survey of theory and steering laws of single-gimbal
    control moment gyros", J. Guidance, Control, and Dynamics 30(5), 2007): the null term lies
    in the null space of A (A(I − A⁺A) = 0, no torque) and, to first order, raises m at the rate
    ṁ = γ |ν|² ≥ 0. The step control is our formulation of the gain choice the survey leaves
    open: below the target m* the null motion asks for the climb rate ṁ = (m* − m)/τ, its
    rate norm is capped at ν_max, and above m* there is no null motion at all (unlike the
    constant-gain :class:`PseudoInverseNullMotion`, which always moves). So |γν| ≤ ν_max:
    the law is as finite as the pseudo-inverse at every singularity (the null term fades with
    ∇m there). Like every null-motion law it cannot leave an elliptic singularity (there the
    null motion cannot keep h fixed), and it realises ḣ_cmd exactly wherever the pseudo-inverse
    does.

    Args:
        m_target: m* > 0, the singularity measure the null motion climbs towards.
        tau: τ > 0 [s], time constant of the climb.
        null_rate_max: ν_max > 0 [rad/s], cap on the null-motion rate norm.
        cluster: the :class:`SgcmgPyramid` (or pass it at each call).
        eps: relative Tikhonov floor of the pseudo-inverse (see :func:`pseudo_inverse`).
    """

    m_target: float = 0.8
    tau: float = 2.0
    null_rate_max: float = 0.1
    cluster: SgcmgPyramid | None = None
    eps: float = PINV_EPS

    def __post_init__(self) -> None:
        for name in ("m_target", "tau", "null_rate_max"):
            v = _check_float(getattr(self, name), name)
            if v <= 0.0:
                raise ValueError(f"{name}: must be > 0, got {v}")
            object.__setattr__(self, name, v)
        object.__setattr__(self, "eps", _check_eps(self.eps))
        if self.cluster is not None and not isinstance(self.cluster, SgcmgPyramid):
            raise ValueError(f"cluster: expected an SgcmgPyramid, got {type(self.cluster)}")

    def __call__(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        a, h, d, tt, cl = _cluster_law_call(self, self.cluster, A, hdot_cmd, delta, t, cluster)
        return _finite_rates(self.steer(a, h, d, tt, cl), h)

    def null_motion(
        self, A: np.ndarray, delta: np.ndarray, cluster: SgcmgPyramid
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(A⁺, γν)``: the pseudo-inverse ``(..., n, 3)`` and the step-controlled null
        motion ``(..., n)`` [rad/s] at ``delta`` (unchecked arrays, as :meth:`steer`)."""
        m, grad = cluster.singularity_measure_and_gradient(delta)
        Ap = pseudo_inverse(A, self.eps)
        Ag = (A * grad[..., None, :]).sum(-1)
        nu = grad - (Ap * Ag[..., None, :]).sum(-1)
        nu2 = (nu * nu).sum(-1)
        ok = nu2 > 1e-24  # |ν| = 0: at a critical point of m on the fibre, nothing to climb
        nu2s = np.where(ok, nu2, 1.0)
        want = np.maximum(self.m_target - m, 0.0) / self.tau
        gamma = np.where(ok, np.minimum(want / nu2s, self.null_rate_max / np.sqrt(nu2s)), 0.0)
        return Ap, gamma[..., None] * nu

    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        cl = cluster if cluster is not None else self.cluster
        Ap, null = self.null_motion(A, delta, cl)
        return (Ap * hdot_cmd[..., None, :]).sum(-1) + null


@dataclass(frozen=True)
class SingularDirectionAvoidance(SteeringLaw):
    """Singular-direction avoidance (Ford & Hall, "Singular direction avoidance steering for
    control-moment gyros", J. Guidance, Control, and Dynamics 23(4), 2000)::

        Â = A/s = Σᵢ σᵢ uᵢ vᵢᵀ (SVD, σ₁ ≥ σ₂ ≥ σ₃),
        δ̇ = (1/s) [ Σ_{i<3} vᵢ uᵢᵀ/σᵢ + σ₃/(σ₃² + λ) v₃ u₃ᵀ ] ḣ_cmd,
        λ = λ₀ (1 − σ₃/σ_t)² for σ₃ < σ_t, else 0,

    with s = √(‖A‖²_F/n) (= h₀ for the pyramid). Only the smallest singular value is damped
    (the SR inverse damps all three), so the torque error A δ̇ − ḣ_cmd =
    −λ/(σ₃² + λ) u₃u₃ᵀḣ_cmd lies along the near-singular direction u₃ alone and the other two
    axes are tracked exactly. Ford & Hall modify the smallest singular value in this way; the
    schedule of λ is our choice (the one the comparison uses): it is exactly 0 for σ₃ ≥ σ_t,
    so away from singularities the law *is* the pseudo-inverse, and λ₀ at σ₃ = 0 bounds the
    rates by |δ̇| ≤ (1/σ₂ + 1/(2√λ₀)) |ḣ_cmd|/s. A relative floor ``PINV_EPS`` on σᵢ² keeps
    every term finite, also with λ₀ = 0 (plain pseudo-inverse). As for SR, an exact
    singularity whose direction u₃ is along ḣ_cmd is not escaped (δ̇ = 0 there).

    Args:
        lambda0: λ₀ ≥ 0 (dimensionless, Â is normalised).
        sigma_t: σ_t > 0, the smallest normalised singular value below which λ is applied.
    """

    lambda0: float = 0.01
    sigma_t: float = 0.3

    def __post_init__(self) -> None:
        object.__setattr__(self, "lambda0", _check_float(self.lambda0, "lambda0"))
        st = _check_float(self.sigma_t, "sigma_t")
        if st <= 0.0:
            raise ValueError(f"sigma_t: must be > 0, got {st}")
        object.__setattr__(self, "sigma_t", st)

    def damping(self, sigma3: np.ndarray | float) -> np.ndarray:
        """λ(σ₃) = λ₀ (1 − σ₃/σ_t)² below σ_t, 0 above (``sigma3`` normalised, ≥ 0)."""
        x = np.maximum(1.0 - np.asarray(sigma3, dtype=float) / self.sigma_t, 0.0)
        return self.lambda0 * x * x

    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        n = A.shape[-1]
        s2 = (A * A).sum(axis=(-2, -1)) / n
        s = np.sqrt(np.where(s2 > 0.0, s2, 1.0))
        U, S, Vt = np.linalg.svd(A / s[..., None, None], full_matrices=False)
        lam = np.zeros_like(S)
        lam[..., -1] = self.damping(S[..., -1])
        gain = S / (S * S + lam + PINV_EPS)
        coef = gain * (U * hdot_cmd[..., :, None]).sum(-2)  # (uᵢᵀḣ) σᵢ/(σᵢ² + λᵢ)
        return (Vt * coef[..., :, None]).sum(-2) / s[..., None]


__all__ += ["StopAware"]


@dataclass(frozen=True)
class StopAware(SteeringLaw):
    """Stop-aware weighting of any steering law: gimbals moving toward a nearby gimbal-angle
    stop get a smaller share of the momentum-rate command, the others take it up.

    Weighted minimum-norm steering by column scaling: with ``W = diag(wᵢ)``,
    ``δ̇ = W^½ law(A W^½, ḣ_cmd)``; for the SR inverse this is the weighted SR inverse
    ``δ̇ = W Aᵀ(A W Aᵀ + λ I)⁻¹ ḣ_cmd`` (Nakamura & Hanafusa, "Inverse kinematic solutions with
    singularity robustness for robot manipulator control", J. Dyn. Sys. Meas. Control 108(3),
    1986, weighted form). ``A W^½ y`` realises the same torque as ``A δ̇``, so the weighting
    changes which gimbals move, not the torque (while the weighted Jacobian keeps rank 3).
    Weights, from a first unweighted solution ``δ̇⁰``: a gimbal whose ``δ̇⁰ᵢ`` points toward a
    stop at distance ``dᵢ`` gets ``wᵢ = max(min(dᵢ / zone, 1), floor)²``; every other gimbal
    ``wᵢ = 1`` (motion away from a stop is never penalised). Only when some ``wᵢ < 1`` is the
    law called a second time.

    This shapes the steering; it does not by itself guarantee the stops. The full CMG model
    (:class:`spacecraft.cmg_dynamics.VscmgActuator`) adds the braking-curve guard on the rate
    command and enforces the stop as a contact constraint at every step
    (:meth:`~spacecraft.cmg_dynamics.VscmgActuator.enforce_stops`).

    Args:
        law: the steering law to weight.
        lower, upper: the stops [rad], scalar or per gimbal ``(n,)``, ``lower < upper``.
        zone: distance to a stop [rad] below which the weight falls (> 0; default 0.2 rad).
        floor: smallest weight's square root, in (0, 1] (default 1e-3; keeps ``A W^½``
            finite and the law's scaling defined).
    """

    law: SteeringLaw
    lower: float | np.ndarray
    upper: float | np.ndarray
    zone: float = 0.2
    floor: float = 1e-3

    def __post_init__(self) -> None:
        if not isinstance(self.law, SteeringLaw):
            raise ValueError(f"law: expected a SteeringLaw, got {type(self.law).__name__}")
        lo = np.atleast_1d(as_array(self.lower, "lower")).astype(np.float64)
        hi = np.atleast_1d(as_array(self.upper, "upper")).astype(np.float64)
        for name, a in (("lower", lo), ("upper", hi)):
            if a.ndim != 1 or a.size == 0:
                raise ValueError(f"{name}: expected a scalar or a 1-D array (n,), got {a.shape}")
        if np.any(lo >= hi):
            raise ValueError("lower: must be < upper for every gimbal")
        lo.setflags(write=False)
        hi.setflags(write=False)
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)
        z = _check_float(self.zone, "zone")
        if z <= 0.0:
            raise ValueError(f"zone: must be > 0, got {self.zone!r}")
        object.__setattr__(self, "zone", z)
        f = _check_float(self.floor, "floor", 0.0, 1.0 + 1e-15)
        if f <= 0.0:
            raise ValueError(f"floor: must be in (0, 1], got {self.floor!r}")
        object.__setattr__(self, "floor", f)

    def weights(self, delta: np.ndarray, rate: np.ndarray) -> np.ndarray:
        """``√wᵢ`` ``(..., n)`` for gimbal angles ``delta`` and an intended rate ``rate``."""
        away = np.where(rate < 0.0, delta - self.lower, np.inf)
        d = np.where(rate > 0.0, self.upper - delta, away)
        return np.clip(d / self.zone, self.floor, 1.0)

    def steer(self, A, hdot_cmd, delta=None, t=0.0, cluster=None) -> np.ndarray:
        if delta is None:
            raise ValueError("delta: StopAware needs the gimbal angles")
        dd0 = self.law.steer(A, hdot_cmd, delta, t, cluster)
        sw = self.weights(delta, dd0)
        if np.all(sw >= 1.0):
            return dd0
        Aw = np.ascontiguousarray(A * sw[..., None, :])
        return sw * self.law.steer(Aw, hdot_cmd, delta, t, cluster)
