"""Modified Rodrigues parameters (MRP) with the shadow set.

An MRP ``p`` (shape ``(..., 3)``) is p = v / (1 + w) for the unit quaternion q = (w, v), i.e.
p = tan(θ/4)·axis. It is the stereographic projection of the quaternion sphere from q = (−1, 0),
so p is singular at θ = ±2π only; q and −q give p and its *shadow* p_s = −p/|p|², which describe
the same rotation. The set |p| ≤ 1 (θ ≤ π) is reached by switching to the shadow whenever
|p| > 1 (Schaub & Junkins), which keeps every attitude at a finite, bounded MRP.

Conventions match the quaternion module (``docs/design.md``): ``R = to_matrix(p)`` maps
body → inertial, and ṗ = G(p) ω with ω the body angular velocity (Ṙ = R ω^).

Kinematic matrix:  G(p) = ½[(1 − pᵀp)/2 · I + p^ + p pᵀ].
This is the same as Schaub & Junkins' σ̇ = ¼ B(σ) ω with B(σ) = (1 − σ²) I + 2σ^ + 2σσᵀ
(expand: ½·(1 − p²)/2 = (1 − p²)/4, ½p^ = 2p^/4, ½ppᵀ = 2ppᵀ/4). Schaub's σ parametrises the
DCM [BN] (inertial → body components) whose Euler parameters β equal our Hamilton q of
R = [BN]ᵀ, so σ and p coincide and the formula carries over unchanged.
Because Bᵀ B = (1 + σ²)² I, G⁻¹ = 16 Gᵀ / (1 + pᵀp)² (defined for every finite p).

Numerics: every formula is evaluated through bounded quantities, n = |p| (overflow-safe),
a = 1/(1 + n²) and p·a, so long MRPs (|p| up to 1e300, i.e. rotations within round-off of
2π) give finite results; :func:`kinematics_matrix` (entries ~|p|²) and :func:`kinematics`
raise when the true result exceeds float64.

Sources: Schaub & Junkins, *Analytical Mechanics of Space Systems*, 4th ed., §3.8 (MRP,
eqs. for [C(σ)], B(σ), shadow set); Shuster, "A survey of attitude representations",
J. Astronaut. Sci. 41(4), 1993, §8.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._array_api import namespace, safe_sqrt
from .._validation import (
    as_array,
    as_scalar,
    broadcast_batch,
    check_output_finite,
    norm_last,
)
from ..lie import so3
from . import quaternion as _q

__all__ = [
    "from_matrix",
    "to_matrix",
    "from_quaternion",
    "to_quaternion",
    "shadow",
    "switch",
    "kinematics_matrix",
    "kinematics_matrix_inv",
    "kinematics",
    "compose",
    "relative",
]


def _p(p: object, name: str = "p") -> np.ndarray:
    return as_array(p, name, (3,))


def _from_q(q: np.ndarray) -> np.ndarray:
    """MRP with |p| ≤ 1 from a scalar-first unit quaternion (sign chosen with w ≥ 0)."""
    q = np.where(q[..., :1] < 0.0, -q, q)
    return q[..., 1:] / (1.0 + q[..., :1])


def _scales(p: Any) -> tuple[Any, Any, Any]:
    """(c, pa, a) with a = 1/(1 + n²), c = (1 − n²)/(1 + n²) and pa = p a, n = |p|: all bounded
    (|c| ≤ 1, |pa| ≤ ½) and computed without forming n² for n > 1 (through t = 1/n:
    a = t²/(1 + t²), c = (t² − 1)/(t² + 1)), so no p overflows. Pure (NumPy or JAX; under JAX
    n = √(pᵀp), whose derivative stays finite at p = 0)."""
    xp = namespace(p)
    n = norm_last(p) if xp is np else safe_sqrt(xp.sum(p * p, axis=-1), xp)
    big = n > 1.0
    t = xp.where(big, 1.0 / xp.where(big, n, 1.0), n)  # t = 1/n (n > 1) or n
    with np.errstate(under="ignore"):
        t2 = t * t
    c = xp.where(big, (t2 - 1.0) / (t2 + 1.0), (1.0 - t2) / (1.0 + t2))
    a = xp.where(big, t2 / (1.0 + t2), 1.0 / (1.0 + t2))
    with np.errstate(under="ignore"):
        pa = p * a[..., None]
    return c, pa, a


def _to_q(p: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion ((1 − p²), 2p) / (1 + p²) of an MRP (overflow-safe)."""
    c, pa, _ = _scales(p)
    return np.concatenate((c[..., None], 2.0 * pa), axis=-1)


def from_quaternion(
    q: object, scalar_first: bool = True, norm_tol: float = _q.UNIT_TOL
) -> np.ndarray:
    """p = v / (1 + w) of the sign of q with w ≥ 0, so |p| ≤ 1 (the shorter of p and its shadow).

    ``q``: ``(..., 4)`` unit quaternion (| |q| − 1 | ≤ ``norm_tol``, else ``ValueError``).
    """
    return _from_q(_q._take_unit(q, "q", scalar_first, norm_tol))


def to_quaternion(p: object, scalar_first: bool = True) -> np.ndarray:
    """q = ((1 − |p|²), 2p) / (1 + |p|²): the unit quaternion whose MRP is exactly p.

    Not canonicalised: |p| > 1 gives w < 0 (the shadow's quaternion is −q).
    """
    return _q._give(_to_q(_p(p)), scalar_first)


def from_matrix(R: object) -> np.ndarray:
    """MRP with |p| ≤ 1 of a rotation matrix (via Shepperd's quaternion, accurate everywhere;
    at a half-turn |p| = 1 and either of ±axis is a valid answer)."""
    return _from_q(_q.from_matrix(R))


def to_matrix(p: object) -> np.ndarray:
    """R = I + [8 (p^)² + 4 (1 − |p|²) p^] / (1 + |p|²)² (body → inertial).

    The transpose of Schaub & Junkins' [C(σ)] = [BN] (sign of the p^ term flipped).
    """
    p = _p(p)
    # = I + 8 (pa^)² + 4 c pa^ with pa = p/(1 + |p|²), c = (1 − |p|²)/(1 + |p|²) (bounded)
    c, pa, _ = _scales(p)
    P = so3.hat(pa)
    return np.eye(3) + 8.0 * (P @ P) + 4.0 * c[..., None, None] * P


def shadow(p: object) -> np.ndarray:
    """Shadow MRP p_s = −p / |p|² (same rotation, |p_s| = 1/|p|).

    The shadow of p = 0 lies at infinity: raises ``ValueError`` naming ``p``.
    """
    p = _p(p)
    n = norm_last(p)[..., None]
    if np.any(n == 0.0):
        raise ValueError("p: the shadow of the zero MRP (identity rotation) is at infinity")
    with np.errstate(over="ignore"):
        out = -(p / n) / n  # |p|² itself may overflow or underflow
    return check_output_finite(out, "p", "the shadow −p/|p|²")


def switch(p: object, threshold: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Shadow-set switch: replace p by its shadow where |p| > ``threshold``.

    Returns ``(p_switched, switched_mask)`` (mask of the batch shape). The rotation is unchanged.
    ``threshold`` must be ≥ 1 (a switch below 1 would map into |p_s| > 1 and chatter);
    ``threshold > 1`` adds hysteresis (after a switch |p| = 1/threshold < 1).
    """
    p = _p(p)
    thr = as_scalar(threshold, "threshold")
    if thr < 1.0:
        raise ValueError(
            f"threshold: must be >= 1 (got {thr}); smaller values make the switch chatter"
        )
    n = norm_last(p)
    mask = n > thr
    # where not switched, divide by 1 so p = 0 never produces inf/NaN; −(p/n)/n avoids |p|²
    denom = np.where(mask, n, 1.0)[..., None]
    return np.where(mask[..., None], -(p / denom) / denom, p), mask


def kinematics_matrix(p: object) -> np.ndarray:
    """G(p) = ½[(1 − pᵀp)/2 · I + p^ + p pᵀ] (= ¼ B(σ) of Schaub & Junkins)."""
    p = _p(p)
    with np.errstate(over="ignore", invalid="ignore"):
        G = _kinematics_matrix_unchecked(p)
    return check_output_finite(G, "p", "G(p) (entries ~|p|²)")


def _kinematics_matrix_unchecked(p: Any) -> Any:
    """:func:`kinematics_matrix` of a checked ``(..., 3)`` array, pure (NumPy or JAX)."""
    xp = namespace(p)
    n2 = xp.sum(p * p, axis=-1)[..., None, None]
    pp = p[..., :, None] * p[..., None, :]
    return 0.5 * (0.5 * (1.0 - n2) * np.eye(3) + so3._hat(p, xp) + pp)


def _kinematics_matrix_inv_unchecked(p: Any) -> Any:
    """:func:`kinematics_matrix_inv` of a checked ``(..., 3)`` array, pure (NumPy or JAX)."""
    c, pa, a = _scales(p)
    return 8.0 * (
        0.5 * (c * a)[..., None, None] * np.eye(3)
        - a[..., None, None] * so3._hat(pa, namespace(p))
        + pa[..., :, None] * pa[..., None, :]
    )


def kinematics_matrix_inv(p: object) -> np.ndarray:
    """G(p)⁻¹ = 16 G(p)ᵀ / (1 + pᵀp)² (from Bᵀ B = (1 + σ²)² I); finite for every finite p.

    Evaluated without forming |p|²: with a = 1/(1 + |p|²), c = (1 − |p|²) a and pa = p a,
    G⁻¹ = 8 [½ c a I − a pa^ + pa paᵀ] (all terms bounded).
    """
    return _kinematics_matrix_inv_unchecked(_p(p))


def kinematics(p: object, omega: object) -> np.ndarray:
    """ṗ = G(p) ω with ω the body angular velocity (shapes broadcast)."""
    G = kinematics_matrix(p)
    w = as_array(omega, "omega", (3,))
    broadcast_batch(("p", G.shape[:-2]), ("omega", w.shape[:-1]))
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.einsum("...ij,...j->...i", G, w)
    return check_output_finite(out, "omega", "ṗ = G(p) ω")


def compose(p1: object, p2: object) -> np.ndarray:
    """MRP (|p| ≤ 1) of R(p₁) R(p₂), computed through quaternions (no division singularity)."""
    a = _p(p1, "p1")
    b = _p(p2, "p2")
    broadcast_batch(("p1", a.shape[:-1]), ("p2", b.shape[:-1]))
    return _from_q(_q._mul(_to_q(a), _to_q(b)))


def relative(p: object, p_d: object) -> np.ndarray:
    """Attitude-error MRP (|p| ≤ 1) of R(p_d)ᵀ R(p), consistent with ``quaternion.error``."""
    pp = _p(p)
    pd = _p(p_d, "p_d")
    broadcast_batch(("p", pp.shape[:-1]), ("p_d", pd.shape[:-1]))
    qd = _to_q(pd) * np.array([1.0, -1.0, -1.0, -1.0])
    return _from_q(_q._mul(qd, _to_q(pp)))
