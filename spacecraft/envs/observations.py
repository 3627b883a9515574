"""Observation and action maps shared by the Gymnasium environments and
:class:`~spacecraft.envs.policy.PolicyController` — pure functions, one place, so that a policy
sees exactly the same numbers in training (the environment) and in the benchmark (the
controller).

Attitude error (desired frame to body frame, both to inertial): ``R_e = R_dᵀ R`` and body-rate
error ``e_Ω = Ω − R_eᵀ Ω_d`` (``Ω_d`` in the desired body frame), as in the geometric tracking
law of Lee, Leok & McClamroch (CDC 2010). Observation components (concatenated in the order
given):

- ``"rotvec"`` (3): ``log(R_e)^∨`` [rad], angle in ``[0, π]``;
- ``"quaternion"`` (4): scalar-first unit quaternion of ``R_e`` with the canonical sign
  ``w > 0`` (at a half-turn, ``w = 0``, the first non-zero of ``x, y, z`` is positive) —
  :func:`liecontrol.charts.quaternion.from_matrix`;
- ``"6d"`` (6): the first two columns of ``R_e`` stacked ``(r₁, r₂)`` — the continuous 6D
  representation of Zhou, Barnes, Lu, Yang & Li, "On the continuity of rotation representations
  in neural networks", CVPR 2019;
- ``"rate"`` (3): ``e_Ω / rate_scale`` (dimensionless);
- ``"momentum"`` (3): stored actuator momentum ``h / momentum_scale`` in body axes;
- ``"actuator"``: the actuator's internal state — SGCMG gimbal angles as ``(cos δ, sin δ)``
  (8), reaction-wheel speeds ``Ω / speed_scale`` (one per wheel); empty for an ideal actuator.

Actions ``a ∈ [−1, 1]³`` map to a body torque command by :func:`action_to_torque`:
``"torque"`` mode ``u = u_max a``; ``"residual"`` mode ``u = u_PD + r a``, with ``u_PD`` the
geometric PD torque of :class:`liecontrol.control.GeometricPD` and ``r`` the residual scale.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from liecontrol._validation import as_array, as_int, check_positive_scalar, check_rotation_matrix
from liecontrol.charts import quaternion as _quat
from liecontrol.lie import so3

__all__ = [
    "OBSERVATION_COMPONENTS",
    "ACTION_MODES",
    "ObservationScales",
    "check_components",
    "observation_size",
    "build_observation",
    "check_action",
    "action_to_torque",
]

#: Observation components understood by :func:`build_observation`.
OBSERVATION_COMPONENTS: tuple[str, ...] = (
    "rotvec",
    "quaternion",
    "6d",
    "rate",
    "momentum",
    "actuator",
)
#: Action modes of :func:`action_to_torque`.
ACTION_MODES: tuple[str, ...] = ("torque", "residual")


@dataclass(frozen=True)
class ObservationScales:
    """Normalisations of the observation (all > 0).

    Attributes:
        rate: body-rate scale [rad/s] (``"rate"`` is ``e_Ω / rate``).
        momentum: momentum scale [N·m·s] (``"momentum"`` is ``h / momentum``).
        speed: wheel-speed scale [rad/s] (reaction-wheel ``"actuator"`` entries).
        actuator: ``"sgcmg"``, ``"wheels"`` or ``"ideal"``: how ``"actuator"`` reads ``x_act``.
    """

    rate: float = 0.05
    momentum: float = 1000.0
    speed: float = 600.0
    actuator: str = "sgcmg"

    def __post_init__(self) -> None:
        for name in ("rate", "momentum", "speed"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0 or v == np.inf:
                raise ValueError(f"{name}: must be a finite number > 0, got {v!r}")
            object.__setattr__(self, name, float(v))
        if self.actuator not in ("sgcmg", "wheels", "ideal"):
            raise ValueError(
                f"actuator: expected 'sgcmg', 'wheels' or 'ideal', got {self.actuator!r}"
            )


def check_components(observation: object, name: str = "observation") -> tuple[str, ...]:
    """Validate a sequence of observation component names (non-empty, known, no repeats);
    ``name`` names the argument in the messages."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: expected a non-empty str, got {name!r}")
    if isinstance(observation, str):
        observation = (observation,)
    if not isinstance(observation, Sequence) or not observation:
        raise ValueError(f"{name}: expected a non-empty sequence of {OBSERVATION_COMPONENTS}")
    comps = tuple(observation)
    for c in comps:
        if c not in OBSERVATION_COMPONENTS:
            raise ValueError(
                f"{name}: unknown component {c!r}; valid: {', '.join(OBSERVATION_COMPONENTS)}"
            )
    if len(set(comps)) != len(comps):
        raise ValueError(f"{name}: repeated component in {comps}")
    return comps


def _attitude_error(R: np.ndarray, R_d: np.ndarray) -> np.ndarray:
    """``R_e = R_dᵀ R`` ``(B, 3, 3)`` (body relative to desired)."""
    return np.swapaxes(R_d, -1, -2) @ R


def _rate_error(R_e: np.ndarray, omega: np.ndarray, omega_d: np.ndarray) -> np.ndarray:
    """``e_Ω = Ω − R_eᵀ Ω_d`` ``(B, 3)`` (``Ω_d`` in the desired frame, carried to the body)."""
    return omega - np.einsum("...ji,...j->...i", R_e, np.broadcast_to(omega_d, omega.shape))


def _actuator_size(scales: ObservationScales, n_act: int) -> int:
    if scales.actuator == "sgcmg":
        return 2 * min(n_act, 4)
    return n_act if scales.actuator == "wheels" else 0


def _check_scales(scales: object) -> ObservationScales:
    if not isinstance(scales, ObservationScales):
        raise ValueError(f"scales: expected an ObservationScales, got {type(scales).__name__}")
    return scales


def observation_size(components: Sequence[str], scales: ObservationScales, n_act: int) -> int:
    """Length of the observation of ``components`` (``n_act``: actuator state size)."""
    components = check_components(components, "components")
    scales = _check_scales(scales)
    n_act = as_int(n_act, "n_act", 0)
    sizes = {"rotvec": 3, "quaternion": 4, "6d": 6, "rate": 3, "momentum": 3}
    return sum(_actuator_size(scales, n_act) if c == "actuator" else sizes[c] for c in components)


def build_observation(
    components: Sequence[str],
    scales: ObservationScales,
    R: object,
    omega: object,
    R_d: object,
    omega_d: object,
    h: object | None = None,
    x_act: object | None = None,
) -> np.ndarray:
    """Observation ``(B, n_obs)`` float64 of ``components`` (module docstring) from the body
    state ``R`` ``(B, 3, 3)``, ``omega`` ``(B, 3)``, the reference ``R_d`` ``(3, 3)`` or
    ``(B, 3, 3)``, ``omega_d`` ``(3,)`` or ``(B, 3)`` and the actuator's momentum ``h``
    ``(B, 3)`` and state ``x_act`` ``(B, n)`` (needed only by the ``"momentum"`` and
    ``"actuator"`` components). Validated; the environments and
    :class:`~spacecraft.envs.policy.PolicyController` call the same computation on arrays
    they have validated."""
    components = check_components(components, "components")
    scales = _check_scales(scales)
    R = check_rotation_matrix(R, "R")
    if R.ndim != 3:
        raise ValueError(f"R: expected shape (B, 3, 3), got {R.shape}")
    B = R.shape[0]
    w = as_array(omega, "omega")
    if w.shape != (B, 3):
        raise ValueError(f"omega: expected shape {(B, 3)}, got {w.shape}")
    R_d = check_rotation_matrix(R_d, "R_d")
    if R_d.shape not in ((3, 3), (B, 3, 3)):
        raise ValueError(f"R_d: expected shape (3, 3) or {(B, 3, 3)}, got {R_d.shape}")
    w_d = as_array(omega_d, "omega_d")
    if w_d.shape not in ((3,), (B, 3)):
        raise ValueError(f"omega_d: expected shape (3,) or {(B, 3)}, got {w_d.shape}")
    if h is not None:
        h = as_array(h, "h")
        if h.shape != (B, 3):
            raise ValueError(f"h: expected shape {(B, 3)}, got {h.shape}")
    if x_act is not None:
        x_act = as_array(x_act, "x_act")
        if x_act.ndim != 2 or x_act.shape[0] != B:
            raise ValueError(f"x_act: expected shape ({B}, n), got {x_act.shape}")
        if scales.actuator == "sgcmg" and x_act.shape[1] not in (4, 8):
            raise ValueError(
                f"x_act: the SGCMG state is (B, 4) gimbal angles (or (B, 8) with a gimbal "
                f"servo), got {x_act.shape}"
            )
    return _observe(components, scales, R, w, R_d, w_d, h, x_act)


def _observe(
    components: Sequence[str],
    scales: ObservationScales,
    R: np.ndarray,
    omega: np.ndarray,
    R_d: np.ndarray,
    omega_d: np.ndarray,
    h: np.ndarray | None,
    x_act: np.ndarray | None,
) -> np.ndarray:
    """:func:`build_observation` on validated arrays (the per-step path)."""
    R_e = _attitude_error(R, R_d)
    parts = []
    for c in components:
        if c == "rotvec":
            parts.append(so3.log(R_e))
        elif c == "quaternion":
            parts.append(_quat.from_matrix(R_e))
        elif c == "6d":
            parts.append(np.concatenate((R_e[..., :, 0], R_e[..., :, 1]), axis=-1))
        elif c == "rate":
            parts.append(_rate_error(R_e, omega, omega_d) / scales.rate)
        elif c == "momentum":
            if h is None:
                raise ValueError("h: the 'momentum' observation needs the actuator momentum")
            parts.append(h / scales.momentum)
        else:  # "actuator"
            if scales.actuator == "ideal":
                continue
            if x_act is None:
                raise ValueError("x_act: the 'actuator' observation needs the actuator state")
            if scales.actuator == "sgcmg":
                d = x_act[:, :4]
                parts.append(np.concatenate((np.cos(d), np.sin(d)), axis=-1))
            else:
                parts.append(x_act / scales.speed)
    return np.concatenate(parts, axis=-1) if parts else np.zeros((R.shape[0], 0))


def check_action(action: object, batch: int | None, name: str = "action") -> np.ndarray:
    """The action as float64 ``(3,)`` (``batch`` ``None``) or ``(batch, 3)``: finite and inside
    ``[−1, 1]`` — a wrong shape, a NaN or an out-of-range entry raises ``ValueError`` (no silent
    clipping: wrap the environment in ``gymnasium.wrappers.ClipAction`` to clip). ``name``
    names the argument in the messages."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: expected a non-empty str, got {name!r}")
    if batch is not None:
        batch = as_int(batch, "batch", 1)
    a = _real_array(action, name)
    want = (3,) if batch is None else (batch, 3)
    if a.shape != want:
        raise ValueError(f"{name}: expected shape {want}, got {a.shape}")
    # one reduction: NaN/inf anywhere makes the sum non-finite
    if not np.isfinite(a.sum()):
        raise ValueError(f"{name}: contains NaN or inf: {a.tolist()}")
    big = float(np.max(np.abs(a))) if a.size else 0.0
    if big > 1.0:
        raise ValueError(f"{name}: entries must lie in [-1, 1], got max |a| = {big:.6g}")
    return a


def _real_array(x: object, name: str) -> np.ndarray:
    """``x`` as a float64 array; a non-numeric, complex or ragged input raises ``ValueError``."""
    try:
        a = np.asarray(x)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected an array of real numbers, got {x!r}") from None
    if a.dtype.kind not in "biuf":
        raise ValueError(f"{name}: expected real numbers, got dtype {a.dtype}")
    return a.astype(np.float64, copy=False)


def action_to_torque(
    action: object, mode: str, scale: float, baseline: object | None = None
) -> np.ndarray:
    """Body torque command [N·m] of actions ``(3,)`` or ``(B, 3)`` in ``[−1, 1]``:
    ``scale · a`` (``"torque"``, ``scale`` = ``u_max``) or ``baseline + scale · a``
    (``"residual"``, ``baseline`` the PD torque, same shape as ``action``)."""
    a = _real_array(action, "action")
    a = check_action(a, a.shape[0] if a.ndim == 2 else None)
    if mode not in ACTION_MODES:
        raise ValueError(f"mode: expected one of {ACTION_MODES}, got {mode!r}")
    scale = check_positive_scalar(scale, "scale")
    if mode == "residual":
        if baseline is None:
            raise ValueError("baseline: the 'residual' action mode needs the baseline torque")
        base = as_array(baseline, "baseline")
        if base.shape != a.shape:
            raise ValueError(f"baseline: expected shape {a.shape}, got {base.shape}")
        return _to_torque(a, mode, scale, base)
    if baseline is not None:
        raise ValueError("baseline: only the 'residual' action mode takes a baseline torque")
    return _to_torque(a, mode, scale, None)


def _to_torque(
    action: np.ndarray, mode: str, scale: float, baseline: np.ndarray | None
) -> np.ndarray:
    """:func:`action_to_torque` on validated arrays (the per-step path)."""
    if mode == "torque":
        return scale * action
    return baseline + scale * action
