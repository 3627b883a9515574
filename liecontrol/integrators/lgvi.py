"""Lie-group variational integrator (LGVI) for the rigid body on SO(3).

Lee, Leok & McClamroch's discrete Euler–Poincaré equations, with Π = Jω the body angular
momentum, J_d = ½ tr(J) I − J the nonstandard moment of inertia, step h and body torque M:

    h (Π_k + (h/2) M_k)^ = F_k J_d − J_d F_kᵀ,          F_k ∈ SO(3)   (implicit)
    R_{k+1} = R_k F_k,
    Π_{k+1} = F_kᵀ Π_k + (h/2) F_kᵀ M_k + (h/2) M_{k+1}.

Solving for F_k. Write g = h (Π_k + (h/2) M_k). For F = exp(φ n^) one has
(F J_d − J_d Fᵀ)^∨ = sin φ J n + (1 − cos φ) n × J n, using
n^J_d + J_d n^ = (((tr J_d) I − J_d) n)^ = (J n)^ and n^²J_d − J_d n^² = (n × J n)^.
With the Cayley parameter f = tan(φ/2) n,

    F = (I + f^)(I − f^)⁻¹ = I + 2/(1 + fᵀf) (f^ + f^²),

the equation becomes g (1 + fᵀf) = 2 J f + 2 f × J f, equivalently (Lee, Leok & McClamroch
2005) the quadratic

    G(f) = g + g × f + (g·f) f − 2 J f = 0,   ∂G/∂f = g^ + (g·f) I + f gᵀ − 2 J,

solved by Newton's method from f₀ = ½ J⁻¹ g (the linearisation), stopping when
‖Δf‖ ≤ tol (1 + ‖f‖) for every batch element (or when Newton stalls at the round-off floor
below 10⁴·tol). No convergence within ``max_iter`` raises :class:`LGVIConvergenceError`
(h ω too large; never a silent NaN).

The scheme is symplectic and momentum preserving: R_k Π_k is exactly conserved for M = 0 (up
to the Newton tolerance and round-off), R_k stays on SO(3) to round-off (F_k is an exact
Cayley rotation), and the energy error stays bounded with no secular drift (for M = 0 the
kinetic energy ½ ΠᵀJ⁻¹Π is even kept to round-off — observed in the tests, as for the
Moser–Veselov discrete rigid body). It is 2nd order.

Torque: ``integrate``'s ``torque(t, R) -> M`` may depend on time and attitude (gravity
gradient, scheduled torques), which keeps the scheme explicit in M_{k+1}; an ω-dependent
torque would make M_{k+1} implicit — use :meth:`RigidBodyLGVI.step` with your own M_k, M_{k+1}
(e.g. a zero-order-held command, M_k = M_{k+1}).

Implementation note: the Newton solve is written component-wise (3×3 algebra by hand, Cramer's
rule), so the same kernel runs on Python floats for a batch of one (about 10× faster than
numpy on 1-element arrays — what makes 10⁵-step runs cheap) and on ``(B,)`` numpy arrays for
a batch.

Sources: T. Lee, M. Leok, N. H. McClamroch, "A Lie group variational integrator for the
attitude dynamics of a rigid body with applications to the 3D pendulum", Proc. IEEE CCA 2005,
962–967; "Lie group variational integrators for the full body problem", Comput. Methods Appl.
Mech. Engrg. 196 (2007) 2907–2924.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._validation import (
    as_array,
    as_scalar,
    check_inertia,
    check_positive,
    check_positive_scalar,
    check_rotation_matrix,
)

__all__ = [
    "lgvi_step",
    "lgvi_step_unchecked",
    "RigidBodyLGVI",
    "LGVITrajectory",
    "LGVIConvergenceError",
]

TorqueField = Callable[[float, np.ndarray], np.ndarray]

#: Newton is also accepted as converged when its step stops shrinking below this × tol
#: (round-off floor for badly conditioned J or large ‖f‖).
_STALL_FACTOR = 1e4


class LGVIConvergenceError(RuntimeError):
    """The implicit LGVI equation for F_k did not converge (usually h‖ω‖ too large)."""


def _solve_cayley(g, J, Jinv, tol: float, max_iter: int, scalar: bool):
    """Newton on G(f) = g + g×f + (g·f) f − 2Jf = 0, component-wise; returns (f, fᵀf).

    ``g`` is a 3-tuple and ``J``/``Jinv`` 9-tuples (row-major) of floats or broadcastable arrays.
    """
    g0, g1, g2 = g
    J00, J01, J02, J10, J11, J12, J20, J21, J22 = J
    # f₀ = ½ J⁻¹ g: exact to first order in h
    f0 = 0.5 * (Jinv[0] * g0 + Jinv[1] * g1 + Jinv[2] * g2)
    f1 = 0.5 * (Jinv[3] * g0 + Jinv[4] * g1 + Jinv[5] * g2)
    f2 = 0.5 * (Jinv[6] * g0 + Jinv[7] * g1 + Jinv[8] * g2)
    # constant part of the Jacobian, g^ − 2J
    A00, A01, A02 = -2.0 * J00, -g2 - 2.0 * J01, g1 - 2.0 * J02
    A10, A11, A12 = g2 - 2.0 * J10, -2.0 * J11, -g0 - 2.0 * J12
    A20, A21, A22 = -g1 - 2.0 * J20, g0 - 2.0 * J21, -2.0 * J22
    tol2 = tol * tol
    stall2 = (_STALL_FACTOR * tol) ** 2
    d2_prev = None
    d2 = ff = None
    for _ in range(max_iter):
        gf = g0 * f0 + g1 * f1 + g2 * f2
        # G = g + g × f + (g·f) f − 2 J f
        G0 = g0 + (g1 * f2 - g2 * f1) + gf * f0 - 2.0 * (J00 * f0 + J01 * f1 + J02 * f2)
        G1 = g1 + (g2 * f0 - g0 * f2) + gf * f1 - 2.0 * (J10 * f0 + J11 * f1 + J12 * f2)
        G2 = g2 + (g0 * f1 - g1 * f0) + gf * f2 - 2.0 * (J20 * f0 + J21 * f1 + J22 * f2)
        # D = g^ − 2J + (g·f) I + f gᵀ, columns c0, c1, c2
        D00, D01, D02 = A00 + gf + f0 * g0, A01 + f0 * g1, A02 + f0 * g2
        D10, D11, D12 = A10 + f1 * g0, A11 + gf + f1 * g1, A12 + f1 * g2
        D20, D21, D22 = A20 + f2 * g0, A21 + f2 * g1, A22 + gf + f2 * g2
        # Cramer: rows of D⁻¹ are (c1×c2, c2×c0, c0×c1)/det
        r00, r01, r02 = D11 * D22 - D21 * D12, D21 * D02 - D01 * D22, D01 * D12 - D11 * D02
        r10, r11, r12 = D12 * D20 - D22 * D10, D22 * D00 - D02 * D20, D02 * D10 - D12 * D00
        r20, r21, r22 = D10 * D21 - D20 * D11, D20 * D01 - D00 * D21, D00 * D11 - D10 * D01
        inv_det = 1.0 / (D00 * r00 + D10 * r01 + D20 * r02)
        d0 = (r00 * G0 + r01 * G1 + r02 * G2) * inv_det
        d1 = (r10 * G0 + r11 * G1 + r12 * G2) * inv_det
        dd2 = (r20 * G0 + r21 * G1 + r22 * G2) * inv_det
        f0, f1, f2 = f0 - d0, f1 - d1, f2 - dd2
        d2 = d0 * d0 + d1 * d1 + dd2 * dd2
        ff = f0 * f0 + f1 * f1 + f2 * f2
        lim = 1.0 + ff
        if scalar:
            if d2 <= tol2 * lim or (
                d2_prev is not None and d2 <= stall2 * lim and d2 >= 0.25 * d2_prev
            ):
                return (f0, f1, f2), ff
        else:
            ok = d2 <= tol2 * lim
            if d2_prev is not None:
                ok |= (d2 <= stall2 * lim) & (d2 >= 0.25 * d2_prev)
            if np.all(ok):
                return (f0, f1, f2), ff
        d2_prev = d2
    worst = float(np.sqrt(np.max(d2 / (1.0 + ff)))) if d2 is not None else float("nan")
    raise LGVIConvergenceError(
        f"h: LGVI Newton solve for F_k did not converge in {max_iter} iterations "
        f"(last relative step {worst:.2e} > tol {tol:.0e}); reduce the step h "
        "(h·‖ω‖ must stay well below π)"
    )


def _solve_F(Pi, M0, h: float, J, Jinv, tol: float, max_iter: int, scalar: bool):
    """F_k (9-tuple, row-major) and Π_k + (h/2) M_k (3-tuple) from component tuples."""
    hh = 0.5 * h
    P = (Pi[0] + hh * M0[0], Pi[1] + hh * M0[1], Pi[2] + hh * M0[2])
    (f0, f1, f2), ff = _solve_cayley((h * P[0], h * P[1], h * P[2]), J, Jinv, tol, max_iter, scalar)
    # F = I + s (f^ + f fᵀ − fᵀf I), s = 2/(1 + fᵀf)
    s = 2.0 / (1.0 + ff)
    sf0, sf1, sf2 = s * f0, s * f1, s * f2
    sff = s * ff
    a01, a02, a12 = sf0 * f1, sf0 * f2, sf1 * f2
    F = (
        1.0 + sf0 * f0 - sff, a01 - sf2, a02 + sf1,
        a01 + sf2, 1.0 + sf1 * f1 - sff, a12 - sf0,
        a02 - sf1, a12 + sf0, 1.0 + sf2 * f2 - sff,
    )  # fmt: skip
    return F, P


def _rotate(R, F):
    """R F on 9-tuples (row-major)."""
    R00, R01, R02, R10, R11, R12, R20, R21, R22 = R
    F00, F01, F02, F10, F11, F12, F20, F21, F22 = F
    return (
        R00 * F00 + R01 * F10 + R02 * F20,
        R00 * F01 + R01 * F11 + R02 * F21,
        R00 * F02 + R01 * F12 + R02 * F22,
        R10 * F00 + R11 * F10 + R12 * F20,
        R10 * F01 + R11 * F11 + R12 * F21,
        R10 * F02 + R11 * F12 + R12 * F22,
        R20 * F00 + R21 * F10 + R22 * F20,
        R20 * F01 + R21 * F11 + R22 * F21,
        R20 * F02 + R21 * F12 + R22 * F22,
    )


def _momentum_update(F, P, M1, h: float):
    """Π_{k+1} = F_kᵀ (Π_k + (h/2) M_k) + (h/2) M_{k+1} on tuples."""
    hh = 0.5 * h
    F00, F01, F02, F10, F11, F12, F20, F21, F22 = F
    P0, P1, P2 = P
    return (
        F00 * P0 + F10 * P1 + F20 * P2 + hh * M1[0],
        F01 * P0 + F11 * P1 + F21 * P2 + hh * M1[1],
        F02 * P0 + F12 * P1 + F22 * P2 + hh * M1[2],
    )


def _kernel(R, Pi, M0, M1, h: float, J, Jinv, tol: float, max_iter: int, scalar: bool):
    """One LGVI step on component tuples: R 9-tuple, Pi/M0/M1 3-tuples. Returns (R1, Pi1)."""
    F, P = _solve_F(Pi, M0, h, J, Jinv, tol, max_iter, scalar)
    return _rotate(R, F), _momentum_update(F, P, M1, h)


def _check_h(h: object) -> float:
    a = as_array(h, "h")
    if a.ndim != 0:
        raise ValueError(f"h: must be a scalar, got shape {a.shape}")
    return check_positive_scalar(a, "h")


def _check_vec(v: object, name: str, batch: tuple[int, ...]) -> np.ndarray:
    a = as_array(v, name, (3,))
    if len(a.shape[:-1]) > len(batch) or any(
        s not in (1, b) for s, b in zip(a.shape[-2::-1], batch[::-1], strict=False)
    ):
        raise ValueError(f"{name}: shape {a.shape} does not broadcast to the batch shape {batch}")
    return np.broadcast_to(a, batch + (3,))


def _check_tol(tol: object, max_iter: object) -> tuple[float, int]:
    tol = check_positive(tol, "tol")
    if not isinstance(tol, float):
        raise ValueError(f"tol: must be a scalar, got shape {np.shape(tol)}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ValueError(f"max_iter: must be an integer >= 1, got {max_iter!r}")
    return tol, int(max_iter)


def _split9(A: np.ndarray) -> tuple:
    return tuple(A[..., i, j] for i in range(3) for j in range(3))


def _split3(v: np.ndarray) -> tuple:
    return (v[..., 0], v[..., 1], v[..., 2])


def _step_arrays(R, Pi, M0, M1, h, Jt, Jit, tol, max_iter):
    """Dispatch: Python floats for a single body, component arrays for a batch."""
    batch = R.shape[:-2]
    if R.size == 9:
        R1, Pi1 = _kernel(
            tuple(R.ravel().tolist()), tuple(Pi.ravel().tolist()), tuple(M0.ravel().tolist()),
            tuple(M1.ravel().tolist()), h, Jt, Jit, tol, max_iter, True,
        )
        return np.array(R1).reshape(batch + (3, 3)), np.array(Pi1).reshape(batch + (3,))
    R1, Pi1 = _kernel(
        _split9(R), _split3(Pi), _split3(M0), _split3(M1), h, Jt, Jit, tol, max_iter, False
    )
    return _pack9(R1, batch, False), np.stack(np.broadcast_arrays(*Pi1), axis=-1)


def _pack9(R, batch: tuple[int, ...], scalar: bool) -> np.ndarray:
    if scalar:
        return np.array(R).reshape(batch + (3, 3))
    return np.stack(np.broadcast_arrays(*R), axis=-1).reshape(batch + (3, 3))


def _inertia_parts(J: np.ndarray, Jinv: np.ndarray, batch: tuple[int, ...], scalar: bool):
    """J and J⁻¹ as 9-tuples of floats (shared inertia or one body) or of (B,) arrays."""
    if scalar:
        return tuple(J.ravel().tolist()), tuple(Jinv.ravel().tolist())
    if J.ndim > 2:
        J = np.broadcast_to(J, batch + (3, 3))
        Jinv = np.broadcast_to(Jinv, batch + (3, 3))
        return _split9(J), _split9(Jinv)
    return tuple(J.ravel().tolist()), tuple(Jinv.ravel().tolist())


def _check_J(J: object, batch: tuple[int, ...] | None = None) -> np.ndarray:
    J = check_inertia(J, "J")
    if batch is not None and J.ndim > 2 and J.shape[:-2] != batch:
        raise ValueError(f"J: batch shape {J.shape[:-2]} does not match R's batch shape {batch}")
    return J


def lgvi_step(
    R: np.ndarray,
    Pi: np.ndarray,
    M_k: np.ndarray,
    M_k1: np.ndarray,
    h: float,
    J: np.ndarray,
    *,
    tol: float = 1e-14,
    max_iter: int = 30,
) -> tuple[np.ndarray, np.ndarray]:
    """One LGVI step ``(R_k, Π_k) -> (R_{k+1}, Π_{k+1})`` (module docstring).

    Args:
        R: ``(..., 3, 3)`` attitude (body → inertial).
        Pi: ``(..., 3)`` body angular momentum Π = Jω [N·m·s].
        M_k, M_k1: body torques at t_k and t_{k+1}, ``(..., 3)`` or broadcastable ``(3,)``.
        h: step > 0 [s].
        J: ``(3, 3)`` inertia (or ``(..., 3, 3)`` with R's batch shape) [kg·m²].
        tol, max_iter: Newton tolerance on the Cayley parameter and iteration cap.

    Raises:
        ValueError: bad input (message starts with the argument name).
        LGVIConvergenceError: Newton did not converge (step too large).
    """
    R = check_rotation_matrix(R, "R")
    J = _check_J(J, R.shape[:-2])
    tol, max_iter = _check_tol(tol, max_iter)
    return _validated_step(R, Pi, M_k, M_k1, h, J, np.linalg.inv(J), tol, max_iter)


def _validated_step(R, Pi, M_k, M_k1, h, J, Jinv, tol, max_iter):
    """Validate the per-step arguments (R already checked) and take one step."""
    batch = R.shape[:-2]
    h = _check_h(h)
    Pi = _check_vec(Pi, "Pi", batch)
    M0 = _check_vec(M_k, "M_k", batch)
    M1 = _check_vec(M_k1, "M_k1", batch)
    Jt, Jit = _inertia_parts(J, Jinv, batch, R.size == 9)
    return _step_arrays(R, Pi, M0, M1, h, Jt, Jit, tol, max_iter)


def lgvi_step_unchecked(
    R: np.ndarray,
    Pi: np.ndarray,
    M_k: np.ndarray,
    M_k1: np.ndarray,
    h: float,
    J: np.ndarray,
    Jinv: np.ndarray,
    *,
    tol: float = 1e-14,
    max_iter: int = 30,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`lgvi_step` without any validation, for hot loops whose caller validated once.

    The same step (module docstring) and the same kernel, so the result equals
    :func:`lgvi_step`'s bit for bit. The caller guarantees: ``R`` a finite float64 rotation
    ``(..., 3, 3)``; ``Pi``, ``M_k``, ``M_k1`` finite float64 ``(..., 3)`` broadcastable to R's
    batch shape; ``h`` a Python float > 0; ``J`` a valid ``(3, 3)`` inertia (shared by the batch)
    and ``Jinv`` its inverse; ``tol > 0``, ``max_iter ≥ 1``. A single body (``R.size == 9``)
    runs on Python floats (~10× cheaper than the validated call, which spends most of its time
    checking). Garbage in is garbage out (no ``ValueError``); a Newton failure still raises
    :class:`LGVIConvergenceError`.
    """
    Jt = tuple(J.ravel().tolist())
    Jit = tuple(Jinv.ravel().tolist())
    if R.size == 9:
        R1, Pi1 = _kernel(
            tuple(R.ravel().tolist()), tuple(np.ravel(Pi).tolist()),
            tuple(np.ravel(M_k).tolist()), tuple(np.ravel(M_k1).tolist()),
            h, Jt, Jit, tol, max_iter, True,
        )  # fmt: skip
        return np.array(R1).reshape(R.shape), np.array(Pi1).reshape(R.shape[:-1])
    batch = R.shape[:-2]
    vec = batch + (3,)
    return _step_arrays(
        R,
        np.broadcast_to(Pi, vec),
        np.broadcast_to(M_k, vec),
        np.broadcast_to(M_k1, vec),
        h,
        Jt,
        Jit,
        tol,
        max_iter,
    )


@dataclass(frozen=True)
class LGVITrajectory:
    """Sampled LGVI solution: ``t`` (K,), ``R`` (K, ..., 3, 3), ``Pi`` and ``omega`` (K, ..., 3)."""

    t: np.ndarray
    R: np.ndarray
    Pi: np.ndarray
    omega: np.ndarray


class RigidBodyLGVI:
    """Rigid-body LGVI with a fixed inertia ``J`` (``(3, 3)`` or batched ``(B, 3, 3)``).

    >>> import numpy as np
    >>> lg = RigidBodyLGVI(np.diag([1.0, 2.0, 3.0]))
    >>> tr = lg.integrate(np.eye(3)[None], np.array([[0.1, 1.0, 0.1]]), h=0.01, n_steps=100)
    >>> tr.R.shape
    (101, 1, 3, 3)
    """

    def __init__(self, J: np.ndarray, tol: float = 1e-14, max_iter: int = 30) -> None:
        J = _check_J(J)
        self._J = np.array(J)  # private copy: the caller may mutate theirs
        self._J.setflags(write=False)
        self._Jinv = np.linalg.inv(self._J)
        self._Jinv.setflags(write=False)
        self._tol, self._max_iter = _check_tol(tol, max_iter)

    @property
    def tol(self) -> float:
        """Newton tolerance on the Cayley parameter."""
        return self._tol

    @property
    def max_iter(self) -> int:
        """Newton iteration cap."""
        return self._max_iter

    @property
    def J(self) -> np.ndarray:
        """The inertia matrix (read-only)."""
        return self._J

    def energy(self, Pi: np.ndarray) -> np.ndarray:
        """Kinetic energy ½ Πᵀ J⁻¹ Π, ``(..., 3) -> (...)``."""
        Pi = as_array(Pi, "Pi", (3,))
        return 0.5 * np.einsum("...i,...ij,...j->...", Pi, self._Jinv, Pi)

    def step(
        self, R: np.ndarray, Pi: np.ndarray, M_k: np.ndarray, M_k1: np.ndarray, h: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """One validated LGVI step with this body's inertia (see :func:`lgvi_step`)."""
        R = check_rotation_matrix(R, "R")
        if self._J.ndim > 2 and self._J.shape[:-2] != R.shape[:-2]:
            raise ValueError(
                f"R: batch shape {R.shape[:-2]} does not match J's batch shape "
                f"{self._J.shape[:-2]}"
            )
        return _validated_step(
            R, Pi, M_k, M_k1, h, self._J, self._Jinv, self.tol, self.max_iter
        )

    def integrate(
        self,
        R0: np.ndarray,
        omega0: np.ndarray,
        h: float,
        n_steps: int,
        torque: TorqueField | None = None,
        *,
        t0: float = 0.0,
        save_every: int = 1,
    ) -> LGVITrajectory:
        """Integrate from ``(R0, ω0)`` with ``n_steps`` steps of size ``h``.

        ``torque(t, R) -> M`` (body torque, shape ``R.shape[:-2] + (3,)``) or ``None`` for the
        torque-free body; evaluated once per step (M_{k+1} of one step is M_k of the next).
        Samples every ``save_every`` steps, including the initial state.
        """
        R = check_rotation_matrix(R0, "R0")
        batch = R.shape[:-2]
        if self._J.ndim > 2 and self._J.shape[:-2] != batch:
            raise ValueError(
                f"R0: batch shape {batch} does not match J's batch shape {self._J.shape[:-2]}"
            )
        w0 = _check_vec(omega0, "omega0", batch)
        h = _check_h(h)
        t0 = as_scalar(t0, "t0")
        for name, k, lo in (("n_steps", n_steps, 0), ("save_every", save_every, 1)):
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < lo:
                raise ValueError(f"{name}: must be an integer >= {lo}, got {k!r}")
        if torque is not None and not callable(torque):
            raise ValueError(f"torque: must be callable or None, got {type(torque).__name__}")
        scalar = R.size == 9
        Jt, Jit = _inertia_parts(self._J, self._Jinv, batch, scalar)
        Pi = np.einsum("...ij,...j->...i", self._J, w0)

        def get_torque(t: float, Rk) -> tuple:
            M = np.asarray(torque(t, Rk), dtype=np.float64)
            if M.shape != batch + (3,):
                raise ValueError(f"torque: returned shape {M.shape}, expected {batch + (3,)}")
            if not np.isfinite(M).all():
                raise ValueError(f"torque: returned a non-finite value at t = {t!r}")
            return tuple(M.ravel().tolist()) if scalar else _split3(M)

        K = n_steps // save_every + 1
        ts = t0 + h * save_every * np.arange(K)
        Rs = np.empty((K,) + R.shape)
        Ps = np.empty((K,) + batch + (3,))
        Rs[0], Ps[0] = R, Pi
        if scalar:
            Rc, Pc = tuple(R.ravel().tolist()), tuple(Pi.ravel().tolist())
            zero = (0.0, 0.0, 0.0)
            store_R, store_P = [Rc], [Pc]
        else:
            Rc, Pc = _split9(R), _split3(Pi)
            zero = (np.zeros(batch),) * 3
        M0 = zero if torque is None else get_torque(t0, R)
        M1 = zero
        tol, max_iter = self.tol, self.max_iter
        j = 1
        for k in range(1, n_steps + 1):
            F, P = _solve_F(Pc, M0, h, Jt, Jit, tol, max_iter, scalar)
            Rc = _rotate(Rc, F)
            if torque is not None:
                # R_{k+1} does not depend on M_{k+1}, so the torque stays explicit
                M1 = get_torque(t0 + k * h, _pack9(Rc, batch, scalar))
            Pc = _momentum_update(F, P, M1, h)
            M0 = M1
            if k % save_every == 0:
                if scalar:
                    store_R.append(Rc)
                    store_P.append(Pc)
                else:
                    Rs[j] = _pack9(Rc, batch, scalar)
                    Ps[j] = np.stack(np.broadcast_arrays(*Pc), axis=-1)
                j += 1
        if scalar:
            Rs = np.array(store_R).reshape((K,) + R.shape)
            Ps = np.array(store_P).reshape((K,) + batch + (3,))
        omega = np.einsum("...ij,...j->...i", self._Jinv, Ps)
        return LGVITrajectory(ts, Rs, Ps, omega)
