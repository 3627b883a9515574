"""RKMK4 (Runge–Kutta–Munthe-Kaas, order 4) on SE(3) × ℝⁿ (SE(3) version).

The mixed system

    ġ = g ξ^,   ẋ = x_dot,     (ξ, x_dot) = f(t, g, x),   g ∈ SE(3), x ∈ ℝⁿ,

with ξ = (ω, v) the **body** twist (rotation first, ``docs/design.md``), is integrated on one step
by writing g(t) = g_k exp(Θ(t)^) and solving the chart ODE in se(3)

    Θ̇ = J_r(Θ)⁻¹ ξ       (right trivialisation; ``liecontrol.lie.se3.right_jacobian_inv``)

with the classical RK4 tableau from Θ = 0; then g_{k+1} = g_k exp(Θ_{k+1}^) with the exact
SE(3) exponential (``se3.exp``), so R stays on SO(3) to round-off. Here dexp⁻¹ is the *exact*
closed form (unlike the truncated series of the SO(3) hot path in :mod:`.rk`), so no order
argument on the truncation is needed. Stages:

    K₁ = ξ(t, g, x)                                         Θ₂ = h/2 K₁
    K₂ = J_r(Θ₂)⁻¹ ξ(t + h/2, g e^Θ₂, x + h/2 ẋ₁)            Θ₃ = h/2 K₂
    K₃ = J_r(Θ₃)⁻¹ ξ(t + h/2, g e^Θ₃, x + h/2 ẋ₂)            Θ₄ = h K₃
    K₄ = J_r(Θ₄)⁻¹ ξ(t + h,   g e^Θ₄, x + h ẋ₃)
    g_{k+1} = g exp(h/6 (K₁ + 2K₂ + 2K₃ + K₄)),  x_{k+1} = x + h/6 (ẋ₁ + 2ẋ₂ + 2ẋ₃ + ẋ₄)

Sources: H. Munthe-Kaas, "High order Runge–Kutta methods on manifolds", Appl. Numer. Math. 29
(1999) 115–127; Iserles, Munthe-Kaas, Nørsett & Zanna, "Lie-group methods", Acta Numerica 9
(2000) §5.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._linalg import matvec as _mv
from .._validation import (
    as_array,
    as_scalar,
    check_positive_scalar,
)
from ..lie import se3
from .rk import _check_record, _checked_lie_field

__all__ = [
    "rkmk4_se3_step",
    "rkmk4_se3_step_unchecked",
    "integrate_se3",
    "SE3Trajectory",
    "SE3Field",
]

#: f(t, g, x) -> (xi, x_dot): g (..., 4, 4), x (..., n) -> xi (..., 6), x_dot (..., n).
SE3Field = Callable[[float, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]



def rkmk4_se3_step_unchecked(
    f: SE3Field, t: float, g: np.ndarray, x: np.ndarray, h: float
) -> tuple[np.ndarray, np.ndarray]:
    """One RKMK4 step on SE(3) × ℝⁿ without validation (the module docstring's stages)."""
    h2 = 0.5 * h
    k1, d1 = f(t, g, x)
    th = h2 * k1
    w, d2 = f(t + h2, g @ se3.exp(th), x + h2 * d1)
    k2 = _mv(se3.right_jacobian_inv(th), w)
    th = h2 * k2
    w, d3 = f(t + h2, g @ se3.exp(th), x + h2 * d2)
    k3 = _mv(se3.right_jacobian_inv(th), w)
    th = h * k3
    w, d4 = f(t + h, g @ se3.exp(th), x + h * d3)
    k4 = _mv(se3.right_jacobian_inv(th), w)
    h6 = h / 6.0
    theta = h6 * (k1 + 2.0 * (k2 + k3) + k4)
    return g @ se3.exp(theta), x + h6 * (d1 + 2.0 * (d2 + d3) + d4)


def _check_h(h: object) -> float:
    a = as_array(h, "h")
    if a.ndim != 0:
        raise ValueError(f"h: must be a scalar, got shape {a.shape}")
    return check_positive_scalar(a, "h")


def _check_state(g: object, x: object, gname: str = "g", xname: str = "x"):
    ga = se3.validate(g, gname)
    xa = as_array(x, xname)
    if xa.ndim < 1 or xa.shape[:-1] != ga.shape[:-2]:
        raise ValueError(
            f"{xname}: expected shape {ga.shape[:-2] + ('n',)} matching the batch shape of "
            f"{gname} {ga.shape}, got {xa.shape}"
        )
    return ga, xa


def _checked_field(f: object, batch: tuple[int, ...], n: int) -> SE3Field:
    if not callable(f):
        raise ValueError(f"f: must be callable, got {type(f).__name__}")
    return _checked_lie_field(f, batch, n, dim=6, name="xi")


def rkmk4_se3_step(
    f: SE3Field, t: float, g: np.ndarray, x: np.ndarray, h: float
) -> tuple[np.ndarray, np.ndarray]:
    """One validated RKMK4 step on SE(3) × ℝⁿ, returning ``(g_next, x_next)``.

    ``g``: ``(..., 4, 4)`` poses, ``x``: ``(..., n)`` (n may be 0) with the same batch shape,
    ``f(t, g, x) -> (xi, x_dot)`` with ġ = g ξ^ (ξ = (ω, v) body twist).
    """
    t = as_scalar(t, "t")
    h = _check_h(h)
    g, x = _check_state(g, x)
    return rkmk4_se3_step_unchecked(_checked_field(f, g.shape[:-2], x.shape[-1]), t, g, x, h)


@dataclass(frozen=True)
class SE3Trajectory:
    """Sampled solution: ``t`` (K,), ``g`` (K, ..., 4, 4), ``x`` (K, ..., n)."""

    t: np.ndarray
    g: np.ndarray
    x: np.ndarray

    def __post_init__(self) -> None:
        t, g, x = _check_record(self.t, self.g, self.x, "g", (4, 4))
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "g", g)
        object.__setattr__(self, "x", x)


def integrate_se3(
    f: SE3Field,
    t0: float,
    g0: np.ndarray,
    x0: np.ndarray,
    h: float,
    n_steps: int,
    *,
    save_every: int = 1,
) -> SE3Trajectory:
    """Integrate ġ = g ξ^, ẋ = x_dot from ``(t0, g0, x0)`` with ``n_steps`` RKMK4 steps.

    ``f``'s output is validated at t0, then the loop runs unchecked; a non-finite state raises
    ``FloatingPointError``. Samples every ``save_every`` steps (initial state included).
    """
    t0 = as_scalar(t0, "t0")
    h = _check_h(h)
    g, x = _check_state(g0, x0, "g0", "x0")
    for name, k, lo in (("n_steps", n_steps, 0), ("save_every", save_every, 1)):
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < lo:
            raise ValueError(f"{name}: must be an integer >= {lo}, got {k!r}")
    _checked_field(f, g.shape[:-2], x.shape[-1])(t0, g, x)
    K = n_steps // save_every + 1
    ts = t0 + h * save_every * np.arange(K)
    gs = np.empty((K,) + g.shape)
    xs = np.empty((K,) + x.shape)
    gs[0], xs[0] = g, x
    j = 1
    for k in range(1, n_steps + 1):
        g, x = rkmk4_se3_step_unchecked(f, t0 + (k - 1) * h, g, x, h)
        if not (np.isfinite(g).all() and np.isfinite(x).all()):
            raise FloatingPointError(f"integrate_se3: non-finite state at t = {t0 + k * h!r}")
        if k % save_every == 0:
            gs[j], xs[j] = g, x
            j += 1
    return SE3Trajectory(ts, gs, xs)
