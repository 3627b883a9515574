"""The rigid-body attitude plant as a python-control system (optional dependency ``control``).

python-control (``pip install "liecontrol[interop]"`` or ``pip install control``) works on state
vectors, so the attitude is carried in a chart: the modified Rodrigues parameters σ
(``attitude="mrp"``, 6 states, the default) or the unit quaternion q = (w, x, y, z)
(``attitude="quaternion"``, 7 states). The equations (R body → inertial, ω body rates):

    σ̇ = G(σ) ω,   G(σ) = ½[(1 − σᵀσ)/2 · I + σ^ + σσᵀ]         (Schaub & Junkins, §3.8)
    q̇ = ½ q ⊗ (0, ω)
    J ω̇ = −ω × Jω + u                                           (Euler's equation)

Inputs: the body torque u [N·m]; outputs: the full state. The chart is integrated as is — no
MRP shadow switch inside the vector field — which is valid for rotations short of a full turn
(|σ| → ∞ only at 2π); use liecontrol's own simulator for long manoeuvres.

:func:`linearize_attitude` gives the exact Jacobians at a rest equilibrium (R₀, ω = 0, u = 0):

    A = [[0, G(σ₀)], [0, 0]],   B = [[0], [J⁻¹]]     (MRP; for the quaternion ∂q̇/∂ω = ½Ξ(q₀)),

because every term of the σ̇ row that depends on σ is multiplied by ω = 0 and ω × Jω is
quadratic in ω. The tests check them against central finite differences of the nonlinear
vector field and against ``control.linearize``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import check_inertia_3x3
from ..charts import mrp, quaternion
from ..lie import so3

__all__ = [
    "require_control",
    "rigid_body_attitude_system",
    "attitude_equilibrium",
    "linearize_attitude",
    "ATTITUDE_CHARTS",
]

#: The supported state charts and their state dimensions.
ATTITUDE_CHARTS: dict[str, int] = {"mrp": 6, "quaternion": 7}


def require_control() -> Any:
    """Import and return the ``control`` package, or raise ``ImportError`` saying how to get it."""
    try:
        import control
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise ImportError(
            "python-control is not installed; install it with "
            '`pip install "liecontrol[interop]"` (or `pip install control`)'
        ) from None
    return control


def check_name(name: object) -> str:
    """A python-control system name: a non-empty str (raises ``TypeError``/``ValueError``
    naming ``name``)."""
    if not isinstance(name, str):
        raise TypeError(f"name: expected a str, got {type(name).__name__}")
    if not name:
        raise ValueError("name: must not be empty")
    return name


def _chart(attitude: object) -> str:
    if not isinstance(attitude, str) or attitude not in ATTITUDE_CHARTS:
        raise ValueError(
            f"attitude: expected one of {', '.join(map(repr, ATTITUDE_CHARTS))}, got {attitude!r}"
        )
    return attitude


def _state_names(attitude: str) -> list[str]:
    att = [f"sigma[{i}]" for i in range(3)] if attitude == "mrp" else ["q_w", "q_x", "q_y", "q_z"]
    return att + [f"omega[{i}]" for i in range(3)]


def _rigid_body_rhs(J: np.ndarray, J_inv: np.ndarray, attitude: str):  # noqa: ANN202
    k = 3 if attitude == "mrp" else 4

    def updfcn(t: float, x: np.ndarray, u: np.ndarray, params: dict | None = None) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        w = x[k:]
        if attitude == "mrp":
            att_dot = mrp.kinematics(x[:3], w)
        else:
            att_dot = quaternion.kinematics(x[:4], w)
        w_dot = J_inv @ (np.asarray(u, dtype=np.float64) - np.cross(w, J @ w))
        return np.concatenate([att_dot, w_dot])

    return updfcn


def rigid_body_attitude_system(
    J: object, attitude: str = "mrp", name: str = "rigid_body_attitude"
) -> Any:
    """A ``control.NonlinearIOSystem`` of the torque-driven rigid body (module docstring).

    Args:
        J: 3×3 inertia [kg·m²] (symmetric positive definite, physical).
        attitude: ``"mrp"`` (states σ, ω) or ``"quaternion"`` (states q scalar-first, ω).
        name: the system's name in python-control interconnections.

    Inputs ``u[0..2]`` (body torque, N·m); outputs = states.
    """
    ctl = require_control()
    attitude = _chart(attitude)
    check_name(name)
    Jm = np.array(check_inertia_3x3(J, "J"), copy=True)
    J_inv = np.linalg.inv(Jm)
    states = _state_names(attitude)
    return ctl.nlsys(
        _rigid_body_rhs(Jm, J_inv, attitude),
        None,
        inputs=[f"u[{i}]" for i in range(3)],
        outputs=list(states),
        states=states,
        name=name,
    )


def attitude_equilibrium(R0: object = None, attitude: str = "mrp") -> np.ndarray:
    """The state vector of rest at attitude ``R0`` (default identity; a matrix or a scipy
    ``Rotation``): (σ₀, 0) with the short-set MRP, or (q₀, 0) with the canonical quaternion."""
    attitude = _chart(attitude)
    R = np.eye(3) if R0 is None else so3.validate(R0, "R0")
    if R.shape != (3, 3):
        raise ValueError(f"R0: expected one rotation of shape (3, 3), got {R.shape}")
    att = mrp.from_matrix(R) if attitude == "mrp" else quaternion.from_matrix(R)
    return np.concatenate([att, np.zeros(3)])


def linearize_attitude(J: object, R0: object = None, attitude: str = "mrp") -> Any:
    """``control.StateSpace`` (A, B, C = I, D = 0) of the rigid body linearised exactly about
    rest at ``R0`` (module docstring for A and B)."""
    ctl = require_control()
    attitude = _chart(attitude)
    Jm = check_inertia_3x3(J, "J")
    x0 = attitude_equilibrium(R0, attitude)
    k = 3 if attitude == "mrp" else 4
    n = k + 3
    A = np.zeros((n, n))
    if attitude == "mrp":
        A[:3, 3:] = mrp.kinematics_matrix(x0[:3])
    else:
        A[:4, 4:] = quaternion.kinematics_matrix(x0[:4])
    B = np.zeros((n, 3))
    B[k:, :] = np.linalg.inv(Jm)
    names = _state_names(attitude)
    return ctl.ss(
        A,
        B,
        np.eye(n),
        np.zeros((n, 3)),
        inputs=[f"u[{i}]" for i in range(3)],
        outputs=list(names),
        states=list(names),
    )
