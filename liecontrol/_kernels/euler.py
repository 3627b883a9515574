"""Compiled kernels of the Euler-angle chart (:mod:`liecontrol.charts.euler`) for one rotation:
the angles of a matrix (``from_matrix``'s method) and the matrix of the angles (``to_matrix``).
The sensors that output Euler angles (:mod:`spacecraft.sensors`) and the compiled closed loop
(:mod:`spacecraft._fused`) call these, so both routes do the same arithmetic; the numpy/JAX
chart is the reference they are tested against (``tests/test_fused_sensor_forms.py``, all 24
sequences, near gimbal lock included).

A sequence is passed as its intrinsic axis indices ``(i, j, k)`` and an extrinsic flag
(:func:`liecontrol.charts.euler.kernel_axes`). Sources: Shuster, "A survey of attitude
representations", J. Astronaut. Sci. 41(4), 1993, §§4–5; scipy's ``Rotation.as_euler``
conventions (ranges, the gimbal-lock choice a3 = 0).

Kernels never validate: callers pass finite float64 rotation matrices and valid axes.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit


@njit(inline="always")
def _wrap(a: float) -> float:
    """To (−π, π] (``charts.euler._wrap``: π − mod(π − a, 2π))."""
    return math.pi - ((math.pi - a) % (2.0 * math.pi))


@njit(inline="always")
def elem_into(axis: int, a: float, out: np.ndarray) -> None:
    """``out (3, 3)`` = R_axis(a), the elementary rotation (``charts.euler._elem``)."""
    c, s = math.cos(a), math.sin(a)
    m, n = (axis + 1) % 3, (axis + 2) % 3
    for r in range(3):
        for q in range(3):
            out[r, q] = 0.0
    out[axis, axis] = 1.0
    out[m, m] = c
    out[n, n] = c
    out[n, m] = s
    out[m, n] = -s


@njit
def from_matrix_into(
    R: np.ndarray, i: int, j: int, k: int, ext: bool, lock_tol: float, out: np.ndarray
) -> bool:
    """Euler angles ``out (3,)`` of ``R (3, 3)`` for the intrinsic axes (i, j, k) (reversed
    output for an extrinsic sequence, ``ext``); returns the gimbal-lock flag.

    a2 from the i-th row (atan2 form); a1 from the k-th column's direction about axis i; a3
    from the residual R_j(a2)ᵀ R_i(a1)ᵀ R = R_k(a3). At lock (|cos a2| Tait–Bryan, |sin a2|
    proper Euler, < ``lock_tol``) the third angle of the sequence as written is 0."""
    E1 = np.empty((3, 3))
    E2 = np.empty((3, 3))
    d = np.zeros(3)
    if i != k:
        eps = 1.0 if (j == (i + 1) % 3) else -1.0
        a2 = math.atan2(eps * R[i, k], math.hypot(R[i, i], R[i, j]))
        lock = abs(math.cos(a2)) < lock_tol
        d[k] = 1.0
        col = k
    else:
        kk = 3 - i - j
        eps = 1.0 if (j == (i + 1) % 3) else -1.0
        a2 = math.atan2(math.hypot(R[i, j], R[i, kk]), R[i, i])
        lock = abs(math.sin(a2)) < lock_tol
        d[kk] = -eps
        col = k
    m, n = (i + 1) % 3, (i + 2) % 3
    a1 = _wrap(math.atan2(R[n, col], R[m, col]) - math.atan2(d[n], d[m]))
    elem_into(i, a1, E1)
    elem_into(j, a2, E2)
    mk, nk = (k + 1) % 3, (k + 2) % 3
    # column mk of R_j(a2)ᵀ R_i(a1)ᵀ R
    v = np.empty(3)
    for r in range(3):
        v[r] = E1[0, r] * R[0, mk] + E1[1, r] * R[1, mk] + E1[2, r] * R[2, mk]
    u_m = E2[0, mk] * v[0] + E2[1, mk] * v[1] + E2[2, mk] * v[2]
    u_n = E2[0, nk] * v[0] + E2[1, nk] * v[1] + E2[2, nk] * v[2]
    a3 = math.atan2(u_n, u_m)
    if lock:
        if ext:
            # R = R_j(a2) R_k(a3'): column mk of R_j(a2)ᵀ R
            u_m = E2[0, mk] * R[0, mk] + E2[1, mk] * R[1, mk] + E2[2, mk] * R[2, mk]
            u_n = E2[0, nk] * R[0, mk] + E2[1, nk] * R[1, mk] + E2[2, nk] * R[2, mk]
            a1 = 0.0
            a3 = math.atan2(u_n, u_m)
        else:
            # R = R_i(a1') R_j(a2): entries (n, m) and (m, m) of R R_j(a2)ᵀ
            p_n = R[n, 0] * E2[m, 0] + R[n, 1] * E2[m, 1] + R[n, 2] * E2[m, 2]
            p_m = R[m, 0] * E2[m, 0] + R[m, 1] * E2[m, 1] + R[m, 2] * E2[m, 2]
            a1 = math.atan2(p_n, p_m)
            a3 = 0.0
    if ext:
        out[0], out[1], out[2] = a3, a2, a1
    else:
        out[0], out[1], out[2] = a1, a2, a3
    return lock


@njit
def from_matrix_batch(
    R: np.ndarray, i: int, j: int, k: int, ext: bool, lock_tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`from_matrix_into` of every ``R (B, 3, 3)``: ``(angles (B, 3), lock (B,))``."""
    out = np.empty((R.shape[0], 3))
    lock = np.empty(R.shape[0], dtype=np.bool_)
    for b in range(R.shape[0]):
        lock[b] = from_matrix_into(R[b], i, j, k, ext, lock_tol, out[b])
    return out, lock


@njit(inline="always")
def _elem_entry(axis: int, c: float, s: float, r: int, q: int) -> float:
    """Entry (r, q) of R_axis(a) with c = cos a, s = sin a (:func:`elem_into`)."""
    if r == axis or q == axis:
        return 1.0 if r == q else 0.0
    if r == q:
        return c
    return s if r == (axis + 2) % 3 else -s


@njit
def rates_matrix_into(a: np.ndarray, i: int, j: int, k: int, ext: bool, out: np.ndarray) -> float:
    """``out (3, 3)`` = B(a) with ȧ = B(a) ω (``charts.euler.rates_matrix`` without its lock
    check): M(a)'s columns c₁ = (R_k(a3)ᵀ R_j(a2)ᵀ)[:, i], c₂ = R_k(a3)ᵀ[:, j], c₃ = e_k for the
    intrinsic axes (angles and columns reversed for an extrinsic sequence), B's rows c₂×c₃,
    c₃×c₁, c₁×c₂ over det M. Returns det M (0 at gimbal lock: the caller guards it). No
    allocation (the compiled laws call it at every sample)."""
    b1, b2 = (a[1], a[0]) if ext else (a[1], a[2])
    c2_, s2_ = math.cos(b1), math.sin(b1)
    c3_, s3_ = math.cos(b2), math.sin(b2)
    # (R_k(a3)ᵀ R_j(a2)ᵀ)[r, i] = Σ_q R_k[q, r] R_j[i, q]
    m0 = (
        _elem_entry(k, c3_, s3_, 0, 0) * _elem_entry(j, c2_, s2_, i, 0)
        + _elem_entry(k, c3_, s3_, 1, 0) * _elem_entry(j, c2_, s2_, i, 1)
        + _elem_entry(k, c3_, s3_, 2, 0) * _elem_entry(j, c2_, s2_, i, 2)
    )
    m1 = (
        _elem_entry(k, c3_, s3_, 0, 1) * _elem_entry(j, c2_, s2_, i, 0)
        + _elem_entry(k, c3_, s3_, 1, 1) * _elem_entry(j, c2_, s2_, i, 1)
        + _elem_entry(k, c3_, s3_, 2, 1) * _elem_entry(j, c2_, s2_, i, 2)
    )
    m2 = (
        _elem_entry(k, c3_, s3_, 0, 2) * _elem_entry(j, c2_, s2_, i, 0)
        + _elem_entry(k, c3_, s3_, 1, 2) * _elem_entry(j, c2_, s2_, i, 1)
        + _elem_entry(k, c3_, s3_, 2, 2) * _elem_entry(j, c2_, s2_, i, 2)
    )
    ca = (m0, m1, m2)
    cb = (
        _elem_entry(k, c3_, s3_, j, 0),
        _elem_entry(k, c3_, s3_, j, 1),
        _elem_entry(k, c3_, s3_, j, 2),
    )
    cc = (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
    c1, c2, c3 = (cc, cb, ca) if ext else (ca, cb, cc)
    r1 = (c2[1] * c3[2] - c2[2] * c3[1], c2[2] * c3[0] - c2[0] * c3[2],
          c2[0] * c3[1] - c2[1] * c3[0])  # fmt: skip
    r2 = (c3[1] * c1[2] - c3[2] * c1[1], c3[2] * c1[0] - c3[0] * c1[2],
          c3[0] * c1[1] - c3[1] * c1[0])  # fmt: skip
    r3 = (c1[1] * c2[2] - c1[2] * c2[1], c1[2] * c2[0] - c1[0] * c2[2],
          c1[0] * c2[1] - c1[1] * c2[0])  # fmt: skip
    det = c1[0] * r1[0] + c1[1] * r1[1] + c1[2] * r1[2]
    for q in range(3):
        out[0, q] = r1[q] / det
        out[1, q] = r2[q] / det
        out[2, q] = r3[q] / det
    return det


@njit
def to_matrix_into(a: np.ndarray, i: int, j: int, k: int, ext: bool, out: np.ndarray) -> None:
    """``out (3, 3)`` = R_i(a1) R_j(a2) R_k(a3) for the intrinsic axes (i, j, k); for an
    extrinsic sequence (``ext``) the angles are reversed first (``charts.euler.to_matrix``)."""
    b0, b1, b2 = (a[2], a[1], a[0]) if ext else (a[0], a[1], a[2])
    E1 = np.empty((3, 3))
    E2 = np.empty((3, 3))
    E3 = np.empty((3, 3))
    elem_into(i, b0, E1)
    elem_into(j, b1, E2)
    elem_into(k, b2, E3)
    T = np.empty((3, 3))
    for r in range(3):
        for q in range(3):
            T[r, q] = E1[r, 0] * E2[0, q] + E1[r, 1] * E2[1, q] + E1[r, 2] * E2[2, q]
    for r in range(3):
        for q in range(3):
            out[r, q] = T[r, 0] * E3[0, q] + T[r, 1] * E3[1, q] + T[r, 2] * E3[2, q]


@njit
def to_matrix_batch(a: np.ndarray, i: int, j: int, k: int, ext: bool) -> np.ndarray:
    """:func:`to_matrix_into` of every row of ``a (B, 3)``; ``(B, 3, 3)``."""
    out = np.empty((a.shape[0], 3, 3))
    for b in range(a.shape[0]):
        to_matrix_into(a[b], i, j, k, ext, out[b])
    return out
