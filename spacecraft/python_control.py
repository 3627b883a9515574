"""The SGCMG-actuated spacecraft as a python-control system (optional dependency ``control``).

States x = (σ, ω, δ): the MRP σ of R (body → inertial), the body rates ω [rad/s] and the four
gimbal angles δ [rad] of a :class:`~spacecraft.sgcmg.SgcmgPyramid`; inputs: the gimbal rates δ̇
[rad/s] (the ideal gimbal-rate model — no servo lag, no steering law, no rate limit; put a
steering law in front of it in python-control if you need one). The equations are the rigid
body with stored momentum h(δ) (Wie, *Space Vehicle Dynamics and Control*, §7.3; the pyramid
geometry is that of :mod:`spacecraft.sgcmg`):

    σ̇ = G(σ) ω
    J ω̇ = −ω × (J ω + h(δ)) − A(δ) δ̇,     A = ∂h/∂δ (3×4)
    δ̇ = u

Outputs: the full state. :func:`linearize_sgcmg` gives the exact Jacobians about rest
(σ₀, ω = 0, δ₀, u = 0) — with h₀ = h(δ₀) stored in the cluster the body rates are coupled
gyroscopically:

    ∂σ̇/∂ω = G(σ₀),   ∂ω̇/∂ω = J⁻¹ h₀^,   ∂ω̇/∂u = −J⁻¹ A(δ₀),   ∂δ̇/∂u = I₄,

all other blocks zero (each term that depends on σ or δ is multiplied by ω = 0 or u = 0). The
tests check these against central finite differences and against ``control.linearize``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from liecontrol._validation import as_array, check_inertia_3x3
from liecontrol.charts import mrp
from liecontrol.interop.python_control import attitude_equilibrium, check_name, require_control
from liecontrol.lie import so3

from .sgcmg import SgcmgPyramid

__all__ = ["sgcmg_attitude_system", "sgcmg_equilibrium", "linearize_sgcmg"]

_STATES = (
    [f"sigma[{i}]" for i in range(3)]
    + [f"omega[{i}]" for i in range(3)]
    + [f"delta[{i}]" for i in range(4)]
)
_INPUTS = [f"delta_dot[{i}]" for i in range(4)]


def _check_pyramid(pyramid: object) -> SgcmgPyramid:
    if not isinstance(pyramid, SgcmgPyramid):
        raise TypeError(f"pyramid: expected SgcmgPyramid, got {type(pyramid).__name__}")
    return pyramid


def sgcmg_attitude_system(
    J: object, pyramid: SgcmgPyramid | None = None, name: str = "sgcmg_spacecraft"
) -> Any:
    """A ``control.NonlinearIOSystem`` of the SGCMG-actuated spacecraft (module docstring).

    Args:
        J: 3×3 inertia of the spacecraft [kg·m²].
        pyramid: the cluster geometry (default ``SgcmgPyramid()``).
        name: the system's name in python-control interconnections.
    """
    ctl = require_control()
    check_name(name)
    Jm = np.array(check_inertia_3x3(J, "J"), copy=True)
    J_inv = np.linalg.inv(Jm)
    pyr = SgcmgPyramid() if pyramid is None else _check_pyramid(pyramid)

    def updfcn(t: float, x: np.ndarray, u: np.ndarray, params: dict | None = None) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        s, w, d = x[:3], x[3:6], x[6:10]
        h, A = pyr.momentum_and_jacobian(d)
        w_dot = J_inv @ (-np.cross(w, Jm @ w + h) - A @ u)
        return np.concatenate([mrp.kinematics(s, w), w_dot, u])

    return ctl.nlsys(
        updfcn, None, inputs=list(_INPUTS), outputs=list(_STATES), states=list(_STATES), name=name
    )


def sgcmg_equilibrium(delta0: object, R0: object = None) -> np.ndarray:
    """The rest state (σ₀, 0, δ₀) at attitude ``R0`` (default identity; a matrix or a scipy
    ``Rotation``) with gimbal angles ``delta0`` ``(4,)``."""
    d = as_array(delta0, "delta0", (4,))
    if d.shape != (4,):
        raise ValueError(f"delta0: expected shape (4,), got {d.shape}")
    return np.concatenate([attitude_equilibrium(R0, "mrp"), d])


def linearize_sgcmg(
    J: object, delta0: object, pyramid: SgcmgPyramid | None = None, R0: object = None
) -> Any:
    """``control.StateSpace`` (C = I, D = 0) of the SGCMG spacecraft linearised exactly about
    rest at ``R0`` with gimbal angles ``delta0`` (module docstring for the blocks)."""
    ctl = require_control()
    Jm = check_inertia_3x3(J, "J")
    J_inv = np.linalg.inv(Jm)
    pyr = SgcmgPyramid() if pyramid is None else _check_pyramid(pyramid)
    x0 = sgcmg_equilibrium(delta0, R0)
    h0, A0 = pyr.momentum_and_jacobian(x0[6:])
    A = np.zeros((10, 10))
    A[:3, 3:6] = mrp.kinematics_matrix(x0[:3])
    A[3:6, 3:6] = J_inv @ so3.hat(h0)
    B = np.zeros((10, 4))
    B[3:6, :] = -J_inv @ A0
    B[6:, :] = np.eye(4)
    return ctl.ss(
        A,
        B,
        np.eye(10),
        np.zeros((10, 4)),
        inputs=list(_INPUTS),
        outputs=list(_STATES),
        states=list(_STATES),
    )
