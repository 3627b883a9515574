"""Lie-group variational integrator on SE(3): a rigid body in a gravity field.

What is implemented (the "full body" LGVI of Lee, Leok & McClamroch 2007, specialised to one
rigid body moving in a *fixed* external field — the central body does not move). State: attitude
R ∈ SO(3) (body → inertial), inertial position x ∈ ℝ³, body angular momentum Π = Jω and
**inertial** linear momentum γ = m ẋ. With step h, inertial force f and body moment M evaluated
at (t_k, R_k, x_k):

    x_{k+1} = x_k + (h/m) (γ_k + (h/2) f_k)                            (translational DEL)
    h (Π_k + (h/2) M_k)^ = F_k J_d − J_d F_kᵀ,   R_{k+1} = R_k F_k        (rotational DEL)
    f_{k+1}, M_{k+1} = force_and_moment(t_{k+1}, R_{k+1}, x_{k+1})
    γ_{k+1} = γ_k + (h/2) (f_k + f_{k+1})
    Π_{k+1} = F_kᵀ (Π_k + (h/2) M_k) + (h/2) M_{k+1}

These are the discrete Euler–Lagrange equations of the discrete Lagrangian
L_d = (m/2h)|x_{k+1} − x_k|² + (1/h) tr((I − F_k) J_d) − (h/2)(U(x_k, R_k) + U(x_{k+1}, R_{k+1}))
when f = −∂U/∂x and M^ = ∂U/∂Rᵀ R − Rᵀ ∂U/∂R (Lee, Leok & McClamroch 2007, §4, there for two
bodies; with the central body fixed the relative coordinates are the body's own). The
translational part is the velocity-Verlet (Störmer) step; the rotational part is exactly the
SO(3) LGVI of :mod:`liecontrol.integrators.lgvi`, which this module calls
(:meth:`~liecontrol.integrators.lgvi.RigidBodyLGVI.step` with M_{k+1} = 0 returns
F_kᵀ(Π_k + (h/2)M_k),
to which (h/2)M_{k+1} is added — Π_{k+1} is affine in M_{k+1}). R_{k+1} and x_{k+1} do not
depend on f_{k+1}, M_{k+1}, so the scheme is explicit apart from the SO(3) Newton solve.

Properties (tested): R stays on SO(3) to round-off (F_k is an exact Cayley rotation); when the
field is conservative and invariant under rotations about the origin (the point-mass field with
its gravity-gradient coupling), the total angular momentum x × γ + R Π is conserved to the Newton
tolerance and round-off (discrete Noether: x × f + R M = 0 for such a field), and the energy
error stays bounded with no secular drift (symplectic, 2nd order). The force may also be
non-conservative (a held body-fixed thrust: f = R F_body, which depends on R only) — the scheme
then is a 2nd-order trapezoidal discretisation of the forcing.

Sources: T. Lee, M. Leok, N. H. McClamroch, "Lie group variational integrators for the full
body problem", Comput. Methods Appl. Mech. Engrg. 196 (2007) 2907–2924; "… in orbital
mechanics", Celest. Mech. Dyn. Astr. 98 (2007) 121–144. The single-body-in-a-fixed-field
reduction and the affine-in-M_{k+1} reuse of the SO(3) step are *reconstructed* here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._validation import (
    as_array,
    as_scalar,
    check_inertia,
    check_inertia_3x3,
    check_positive_scalar,
    check_rotation_matrix,
)
from .lgvi import RigidBodyLGVI

__all__ = ["SE3RigidBodyLGVI", "SE3LGVITrajectory", "lgvi_se3_step", "ForceAndMoment"]

#: force_and_moment(t, R, x) -> (f, M): R (B, 3, 3), x (B, 3) -> inertial force f (B, 3) [N],
#: body moment M (B, 3) [N·m].
ForceAndMoment = Callable[[float, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def _check_h(h: object) -> float:
    a = as_array(h, "h")
    if a.ndim != 0:
        raise ValueError(f"h: must be a scalar, got shape {a.shape}")
    return check_positive_scalar(a, "h")


def _check_mass(m: object) -> float:
    a = as_array(m, "m")
    if a.ndim != 0:
        raise ValueError(f"m: must be a scalar, got shape {a.shape}")
    return check_positive_scalar(a, "m")


def _eval_fm(
    fm: ForceAndMoment, t: float, R: np.ndarray, x: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    out = fm(t, R, x)
    if not (isinstance(out, tuple) and len(out) == 2):
        raise ValueError("force_and_moment: must return a tuple (force, moment)")
    f = np.asarray(out[0], dtype=np.float64)
    M = np.asarray(out[1], dtype=np.float64)
    shape = x.shape
    if f.shape != shape or M.shape != shape:
        raise ValueError(
            f"force_and_moment: returned shapes {f.shape}, {M.shape}, expected {shape} each"
        )
    if not (np.isfinite(f).all() and np.isfinite(M).all()):
        raise ValueError(f"force_and_moment: returned a non-finite value at t = {t!r}")
    return f, M


def _advance(
    t: float,
    R: np.ndarray,
    x: np.ndarray,
    Pi: np.ndarray,
    gamma: np.ndarray,
    f0: np.ndarray,
    M0: np.ndarray,
    h: float,
    m: float,
    rot: RigidBodyLGVI,
    fm: ForceAndMoment,
) -> tuple[np.ndarray, ...]:
    """One step given f_k, M_k; returns (R1, x1, Pi1, gamma1, f1, M1)."""
    hh = 0.5 * h
    gamma_half = gamma + hh * f0
    x1 = x + (h / m) * gamma_half
    # M_{k+1} = 0 here: the SO(3) step then returns F_kᵀ(Π_k + (h/2)M_k), see the module docstring
    R1, Pi_half = rot.step(R, Pi, M0, np.zeros_like(M0), h)
    f1, M1 = _eval_fm(fm, t + h, R1, x1)
    return R1, x1, Pi_half + hh * M1, gamma_half + hh * f1, f1, M1


def _zero_fm(t: float, R: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros(x.shape), np.zeros(x.shape)


def _check_state(R: object, x: object, Pi: object, gamma: object, names: tuple[str, ...]):
    Ra = check_rotation_matrix(R, names[0])
    batch = Ra.shape[:-2]
    out = [Ra]
    for v, name in zip((x, Pi, gamma), names[1:], strict=True):
        a = as_array(v, name, (3,))
        if a.shape[:-1] != batch:
            raise ValueError(
                f"{name}: expected shape {batch + (3,)} matching {names[0]}'s batch, got {a.shape}"
            )
        out.append(a)
    return tuple(out)


def lgvi_se3_step(
    R: np.ndarray,
    x: np.ndarray,
    Pi: np.ndarray,
    gamma: np.ndarray,
    h: float,
    m: float,
    J: np.ndarray,
    force_and_moment: ForceAndMoment | None = None,
    t: float = 0.0,
    *,
    tol: float = 1e-14,
    max_iter: int = 30,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One SE(3) LGVI step ``(R, x, Π, γ)_k -> (R, x, Π, γ)_{k+1}`` (module docstring).

    Args:
        R: ``(..., 3, 3)`` attitude; x: ``(..., 3)`` inertial position [m]; Pi: ``(..., 3)`` body
            angular momentum Jω [N·m·s]; gamma: ``(..., 3)`` inertial linear momentum m ẋ [N·s].
        h: step [s] > 0; m: mass [kg] > 0; J: ``(3, 3)`` inertia [kg·m²].
        force_and_moment: ``(t, R, x) -> (f inertial [N], M body [N·m])``, or ``None`` (free).
            Evaluated at both ends of the step (use :class:`SE3RigidBodyLGVI` to reuse the
            end-of-step value as the next start).
        t: time of the current state [s].

    Raises:
        ValueError: bad input (message starts with the argument name).
        LGVIConvergenceError: the SO(3) Newton solve did not converge (h‖ω‖ too large).
    """
    R, x, Pi, gamma = _check_state(R, x, Pi, gamma, ("R", "x", "Pi", "gamma"))
    h = _check_h(h)
    m = _check_mass(m)
    J = check_inertia(J, "J")
    fm = _zero_fm if force_and_moment is None else force_and_moment
    if not callable(fm):
        raise ValueError("force_and_moment: must be callable or None")
    t = as_scalar(t, "t")
    f0, M0 = _eval_fm(fm, t, R, x)
    rot = RigidBodyLGVI(J, tol=tol, max_iter=max_iter)
    out = _advance(t, R, x, Pi, gamma, f0, M0, h, m, rot, fm)
    return out[0], out[1], out[2], out[3]


@dataclass(frozen=True)
class SE3LGVITrajectory:
    """Sampled SE(3) LGVI solution (K samples).

    Attributes: ``t`` (K,); ``R`` (K, ..., 3, 3); ``x`` (K, ..., 3) inertial position; ``Pi``
    (K, ..., 3) body angular momentum; ``gamma`` (K, ..., 3) inertial linear momentum;
    ``omega`` = J⁻¹Π and ``v`` = Rᵀγ/m (body velocities, the twist ξ = (ω, v) of the SE(3) plant).
    """

    t: np.ndarray
    R: np.ndarray
    x: np.ndarray
    Pi: np.ndarray
    gamma: np.ndarray
    omega: np.ndarray
    v: np.ndarray

    @property
    def g(self) -> np.ndarray:
        """Poses ``(K, ..., 4, 4)``."""
        g = np.zeros(self.R.shape[:-2] + (4, 4))
        g[..., :3, :3] = self.R
        g[..., :3, 3] = self.x
        g[..., 3, 3] = 1.0
        return g


class SE3RigidBodyLGVI:
    """SE(3) LGVI for a rigid body of mass ``m`` and inertia ``J`` in a field
    ``force_and_moment(t, R, x) -> (f inertial, M body)`` (``None``: force- and moment-free).

    >>> import numpy as np
    >>> lg = SE3RigidBodyLGVI(10.0, np.diag([1.0, 2.0, 3.0]))
    >>> tr = lg.integrate(np.eye(3)[None], np.zeros((1, 3)), np.array([[0.1, 0.2, 0.0]]),
    ...                   np.array([[1.0, 0.0, 0.0]]), h=0.1, n_steps=10)
    >>> tr.x[-1].round(12).tolist()
    [[1.0, 0.0, 0.0]]
    """

    def __init__(
        self,
        m: float,
        J: np.ndarray,
        force_and_moment: ForceAndMoment | None = None,
        tol: float = 1e-14,
        max_iter: int = 30,
    ) -> None:
        self._m = _check_mass(m)
        J = check_inertia_3x3(J, "J")
        self._rot = RigidBodyLGVI(J, tol=tol, max_iter=max_iter)
        self._J = self._rot.J
        self._Jinv = np.linalg.inv(self._J)
        self._Jinv.setflags(write=False)
        if force_and_moment is not None and not callable(force_and_moment):
            raise ValueError("force_and_moment: must be callable or None")
        self._fm = _zero_fm if force_and_moment is None else force_and_moment
        self.tol = self._rot.tol
        self.max_iter = self._rot.max_iter

    @property
    def m(self) -> float:
        return self._m

    @property
    def J(self) -> np.ndarray:
        return self._J

    def kinetic_energy(self, Pi: np.ndarray, gamma: np.ndarray) -> np.ndarray:
        """½ ΠᵀJ⁻¹Π + |γ|²/(2m), ``(...)``."""
        Pi = as_array(Pi, "Pi", (3,))
        gamma = as_array(gamma, "gamma", (3,))
        rot = 0.5 * np.einsum("...i,ij,...j->...", Pi, self._Jinv, Pi)
        return rot + 0.5 * np.sum(gamma * gamma, axis=-1) / self._m

    @staticmethod
    def angular_momentum(
        R: np.ndarray, x: np.ndarray, Pi: np.ndarray, gamma: np.ndarray
    ) -> np.ndarray:
        """Total inertial angular momentum about the origin, x × γ + R Π, ``(..., 3)``."""
        return np.cross(x, gamma) + np.einsum("...ij,...j->...i", R, Pi)

    def step(
        self,
        t: float,
        R: np.ndarray,
        x: np.ndarray,
        Pi: np.ndarray,
        gamma: np.ndarray,
        h: float,
        force_and_moment: ForceAndMoment | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One validated step with this body's mass and inertia (:func:`lgvi_se3_step`).

        ``force_and_moment`` overrides the body's field for this step (e.g. a field plus a
        held body-fixed command); ``None`` uses the field given to the constructor.
        """
        R, x, Pi, gamma = _check_state(R, x, Pi, gamma, ("R", "x", "Pi", "gamma"))
        h = _check_h(h)
        t = as_scalar(t, "t")
        fm = self._fm if force_and_moment is None else force_and_moment
        if not callable(fm):
            raise ValueError("force_and_moment: must be callable or None")
        f0, M0 = _eval_fm(fm, t, R, x)
        out = _advance(t, R, x, Pi, gamma, f0, M0, h, self._m, self._rot, fm)
        return out[0], out[1], out[2], out[3]

    def integrate(
        self,
        R0: np.ndarray,
        x0: np.ndarray,
        omega0: np.ndarray,
        v0: np.ndarray,
        h: float,
        n_steps: int,
        *,
        t0: float = 0.0,
        save_every: int = 1,
    ) -> SE3LGVITrajectory:
        """Integrate from attitude ``R0``, inertial position ``x0``, **body** rates ``omega0``
        and **body** velocity ``v0`` (ẋ = R v) with ``n_steps`` steps of size ``h``; one field
        evaluation per step; samples every ``save_every`` steps (initial state included)."""
        R, x, w0, v = _check_state(R0, x0, omega0, v0, ("R0", "x0", "omega0", "v0"))
        h = _check_h(h)
        t0 = as_scalar(t0, "t0")
        for name, k, lo in (("n_steps", n_steps, 0), ("save_every", save_every, 1)):
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < lo:
                raise ValueError(f"{name}: must be an integer >= {lo}, got {k!r}")
        Pi = w0 @ self._J.T
        gamma = self._m * np.einsum("...ij,...j->...i", R, v)
        K = n_steps // save_every + 1
        ts = t0 + h * save_every * np.arange(K)
        Rs = np.empty((K,) + R.shape)
        xs = np.empty((K,) + x.shape)
        Ps = np.empty((K,) + x.shape)
        Gs = np.empty((K,) + x.shape)
        Rs[0], xs[0], Ps[0], Gs[0] = R, x, Pi, gamma
        f, M = _eval_fm(self._fm, t0, R, x)
        j = 1
        for k in range(n_steps):
            R, x, Pi, gamma, f, M = _advance(
                t0 + k * h, R, x, Pi, gamma, f, M, h, self._m, self._rot, self._fm
            )
            if (k + 1) % save_every == 0:
                Rs[j], xs[j], Ps[j], Gs[j] = R, x, Pi, gamma
                j += 1
        omega = Ps @ self._Jinv.T
        vb = np.einsum("...ji,...j->...i", Rs, Gs) / self._m
        return SE3LGVITrajectory(ts, Rs, xs, Ps, Gs, omega, vb)
