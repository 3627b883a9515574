"""Environmental torque sources.

Each source fits the disturbance contract of :mod:`spacecraft.disturbances`: a callable
``source(t, R (B, 3, 3), omega (B, 3)) -> (B, 3)`` body torque [N·m], and composes with
:class:`spacecraft.disturbances.SumOfDisturbances`.

Gravity-gradient torque on a rigid body in a circular orbit:

    T_gg = 3 n² (ĉ × J ĉ),   ĉ = Rᵀ(−r̂) = nadir unit vector in body axes,

since μ/r³ = n² on a circular orbit (Hughes, *Spacecraft Attitude Dynamics*, §8.2; Wie, *Space
Vehicle Dynamics and Control*, §6.3). It vanishes when ĉ is a principal axis of J (in particular
for a principal-axis body aligned with LVLH).

The per-spacecraft formula is compiled once (:func:`gravity_gradient_kernel`, the torque of the
disturbance seam :mod:`spacecraft.disturbance_kernel`, so :class:`GravityGradientTorque` runs in
the simulator's fused loop); :meth:`GravityGradientTorque.__call__` is its batched numpy layer,
held to it at 1e-12 by the tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._array_api import namespace
from liecontrol._jit import njit
from liecontrol._validation import as_array, check_inertia_3x3, check_positive_scalar

from .disturbance_kernel import DisturbanceKernel
from .orbit import CircularOrbit

__all__ = ["GravityGradientTorque", "gravity_gradient_kernel", "gravity_gradient_torque"]


@njit
def gravity_gradient_kernel(
    t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
) -> None:
    """T_gg = 3n² (ĉ × Jĉ) with ĉ = Rᵀ(−r̂), r̂ = cos u p̂ + sin u q̂, u = u₀ + n t (Hughes §8.2;
    Wie §6.3) for one spacecraft: the disturbance seam's torque (:mod:`spacecraft.
    disturbance_kernel`). ``params = (n, u₀, p̂ (3), q̂ (3), J (9, row-major))``: the orbit rate,
    the argument of latitude at t = 0, the orbit plane's first two axes in inertial axes
    (``CircularOrbit._R_orb[:, 0]``, ``[:, 1]``) and the true inertia."""
    n = params[0]
    u = params[1] + n * t
    cu = math.cos(u)
    su = math.sin(u)
    r0 = -(cu * params[2] + su * params[5])
    r1 = -(cu * params[3] + su * params[6])
    r2 = -(cu * params[4] + su * params[7])
    c0 = R[0, 0] * r0 + R[1, 0] * r1 + R[2, 0] * r2
    c1 = R[0, 1] * r0 + R[1, 1] * r1 + R[2, 1] * r2
    c2 = R[0, 2] * r0 + R[1, 2] * r1 + R[2, 2] * r2
    j0 = params[8] * c0 + params[9] * c1 + params[10] * c2
    j1 = params[11] * c0 + params[12] * c1 + params[13] * c2
    j2 = params[14] * c0 + params[15] * c1 + params[16] * c2
    k = 3.0 * n * n
    out[0] = (c1 * j2 - c2 * j1) * k
    out[1] = (c2 * j0 - c0 * j2) * k
    out[2] = (c0 * j1 - c1 * j0) * k


def gravity_gradient_torque(J: object, c: object, n: float) -> np.ndarray:
    """3n² (ĉ × Jĉ) for body-axis nadir unit vectors ``c`` ``(..., 3)`` and inertia ``J``
    ``(3, 3)`` or ``(..., 3, 3)`` [N·m]."""
    J = as_array(J, "J", (3, 3))
    c = as_array(c, "c", (3,))
    n = check_positive_scalar(n, "n")
    with np.errstate(over="ignore", invalid="ignore"):
        Jc = np.einsum("...ij,...j->...i", J, c)
        out = 3.0 * n * n * np.cross(c, Jc)
    if not np.all(np.isfinite(out)):
        raise ValueError(
            f"n: the torque 3n²(c × Jc) overflows float64 (n = {n:.3g})"
            if n > 1e100
            else "c: the torque overflows float64 (c should be unit nadir vectors)"
        )
    return out


@dataclass(frozen=True)
class GravityGradientTorque:
    """Gravity-gradient disturbance source 3n²(ĉ × Jĉ).

    Args:
        J: the **true** body inertia ``(3, 3)`` [kg·m²] (validated: symmetric, positive definite,
            triangle inequality).
        orbit: the :class:`~spacecraft.orbit.CircularOrbit` giving n and the nadir direction.
    """

    J: np.ndarray
    orbit: CircularOrbit

    def __post_init__(self) -> None:
        J = check_inertia_3x3(self.J, "J").copy()
        J.setflags(write=False)
        object.__setattr__(self, "J", J)
        if not isinstance(self.orbit, CircularOrbit):
            raise ValueError(f"orbit: expected CircularOrbit, got {type(self.orbit).__name__}")

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        # hot path (every integration stage): inputs trusted
        return self.torque_at(float(t), np.asarray(R))

    def torque_at(self, t: Any, R: Any) -> Any:
        """3n²(ĉ × Jĉ) ``(..., 3)`` at time ``t`` for attitudes ``R`` ``(..., 3, 3)``, the nadir
        ĉ = Rᵀ(−r̂) from the orbit-plane angle u = u₀ + n t. Pure, NumPy or JAX (the
        differentiable loop, :mod:`spacecraft.differentiable`, evaluates it at every RKMK4
        stage's attitude): a Python float ``t`` takes ``math``'s cos/sin."""
        o = self.orbit
        xp = namespace(R)
        u = o.arg_lat0 + o.n * t
        cos, sin = (math.cos, math.sin) if isinstance(t, float) else (xp.cos, xp.sin)
        nadir = -(cos(u) * o._R_orb[:, 0] + sin(u) * o._R_orb[:, 1])
        c = xp.swapaxes(R, -1, -2) @ nadir
        Jc = c @ self.J.T
        k = 3.0 * o.n * o.n
        return xp.stack(
            (
                k * (c[..., 1] * Jc[..., 2] - c[..., 2] * Jc[..., 1]),
                k * (c[..., 2] * Jc[..., 0] - c[..., 0] * Jc[..., 2]),
                k * (c[..., 0] * Jc[..., 1] - c[..., 1] * Jc[..., 0]),
            ),
            axis=-1,
        )

    def fused_kernel(self) -> DisturbanceKernel:
        """The compiled torque (:func:`gravity_gradient_kernel`) and its parameters, shared by
        the batch (:mod:`spacecraft.disturbance_kernel`)."""
        o = self.orbit
        params = np.concatenate(
            ([o.n, o.arg_lat0], o._R_orb[:, 0], o._R_orb[:, 1], np.asarray(self.J).ravel())
        ).astype(np.float64)
        return DisturbanceKernel(gravity_gradient_kernel, params, uses_attitude=True)
