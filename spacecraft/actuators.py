"""The actuator seam between a controller's torque command and the plant (SPEC §1, §5.1, §5.2).

An actuator owns ``n_states`` states appended to the plant's ODE state (the four gimbal angles
of the SGCMG pyramid; none for the ideal torque actuator) and is used in two phases per
simulator step:

1. once per step, before integrating: ``held = actuator.command(u_cmd, omega, x_act, t)`` turns
   the (zero-order-held) controller torque into a hardware command that is then held constant
   over the integration step — for the CMG cluster the gimbal rates δ̇ (ZOH of the gimbal rates,
   as a digital gimbal servo loop would);
2. inside every integration stage: ``state_derivative(x_act, held)`` and
   ``body_torque(omega, x_act, held)``, the internal torque the hardware exerts on the bus.

``momentum(x_act)`` is the stored momentum ``h`` in body axes (what the controller may know), and
``log(x_act, held)`` the actuator quantities to record (``(B, ...)`` arrays).

SGCMG physics (SPEC §5.1–5.2): the cluster stores ``h(δ)``, ``ḣ = A(δ) δ̇``, and the bus feels
``u = −ḣ − ω × h = −A(δ) δ̇ − ω × h(δ)``. The steering law inverts the momentum rate
``ḣ_cmd = −u_cmd − ω × h`` for ``δ̇``; the gimbal-rate limit clips the result (saturation is
logged), so the delivered torque ``u`` differs from ``u_cmd`` near singularities and at the limit.
"""

from __future__ import annotations

import abc
import inspect
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from liecontrol._validation import as_array, check_positive

from .rigid_body import _cross

__all__ = ["Actuator", "IdealTorqueActuator", "SgcmgActuator", "CmgCommand"]


class Actuator(abc.ABC):
    """Interface of an actuator inside :class:`spacecraft.plant.Spacecraft` (see module doc)."""

    #: number of actuator states appended to the plant state
    n_states: int = 0

    def initial_state(self, batch: int) -> np.ndarray:
        """Initial actuator states ``(batch, n_states)``."""
        return np.zeros((int(batch), self.n_states))

    @abc.abstractmethod
    def command(self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float) -> Any:
        """Hardware command held over the next integration step, from the torque command
        ``u_cmd`` ``(B, 3)`` [N·m], body rate ``omega`` ``(B, 3)``, actuator states ``x_act``."""

    @abc.abstractmethod
    def state_derivative(self, x_act: np.ndarray, held: Any) -> np.ndarray:
        """Time derivative of the actuator states ``(B, n_states)``."""

    @abc.abstractmethod
    def body_torque(self, omega: np.ndarray, x_act: np.ndarray, held: Any) -> np.ndarray:
        """Internal torque the actuator exerts on the bus, body axes ``(B, 3)`` [N·m]."""

    def momentum(self, x_act: np.ndarray) -> np.ndarray:
        """Stored actuator momentum in body axes ``(B, 3)`` [N·m·s] (zero by default)."""
        return np.zeros((x_act.shape[0], 3))

    def log(self, x_act: np.ndarray, held: Any) -> dict[str, np.ndarray]:
        """Quantities to log at one sample, as ``(B, ...)`` arrays (empty by default)."""
        return {}

    def derived_log(self, log: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Quantities computed afterwards from the whole log (``(K, B, ...)`` arrays), added to
        it by the simulator. Pure functions of logged states (e.g. the CMG singularity measure of
        the logged gimbal angles) belong here: one vectorized call instead of one per step."""
        return {}


@dataclass(frozen=True)
class IdealTorqueActuator(Actuator):
    """Delivers the commanded torque exactly (papers that assume an ideal actuator, SPEC §5.2).

    Args:
        max_torque: optional per-axis saturation ``|u_i| ≤ max_torque`` [N·m] (scalar or
            ``(3,)``); ``None`` = unlimited. Saturation is logged as ``saturated`` ``(B, 3)``.
    """

    max_torque: float | np.ndarray | None = None
    n_states: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        if self.max_torque is not None:
            m = check_positive(self.max_torque, "max_torque")
            if np.ndim(m) not in (0, 1) or (np.ndim(m) == 1 and np.shape(m) != (3,)):
                raise ValueError(f"max_torque: expected a scalar or shape (3,), got {np.shape(m)}")
            object.__setattr__(self, "max_torque", m)

    def command(self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float) -> Any:
        if self.max_torque is None:
            return np.array(u_cmd, dtype=np.float64)  # own copy: the held value must not alias
        return np.clip(u_cmd, -self.max_torque, self.max_torque)

    def state_derivative(self, x_act: np.ndarray, held: Any) -> np.ndarray:
        return x_act  # shape (B, 0): nothing to integrate

    def body_torque(self, omega: np.ndarray, x_act: np.ndarray, held: Any) -> np.ndarray:
        return held

    def log(self, x_act: np.ndarray, held: Any) -> dict[str, np.ndarray]:
        if self.max_torque is None:
            return {}
        return {"saturated": np.abs(held) >= self.max_torque}


@dataclass(frozen=True)
class CmgCommand:
    """What the SGCMG actuator holds over one integration step.

    Attributes:
        delta_dot: ``(B, 4)`` gimbal rates after the rate limit [rad/s].
        saturated: ``(B,)`` whether the rate vector was scaled down to the limit.
        h_dot_cmd: ``(B, 3)`` momentum rate the steering law was asked for [N·m].
    """

    delta_dot: np.ndarray
    saturated: np.ndarray
    h_dot_cmd: np.ndarray


def _default_steering() -> Any:
    from .steering import SingularityRobust

    return SingularityRobust()


class SgcmgActuator(Actuator):
    """Four-SGCMG pyramid with a steering law and a gimbal-rate limit (SPEC §5.2).

    State: the gimbal angles ``δ`` ``(B, 4)``. Per step (ZOH of gimbal rates):
    ``ḣ_cmd = −u_cmd − ω × h(δ)``, ``δ̇ = steering(A(δ), ḣ_cmd)``, clipped to the cluster's
    gimbal-rate limit. In the integration stages ``δ̇`` is constant and the bus feels
    ``u = −A(δ) δ̇ − ω × h(δ)`` (SPEC §5.1) — which conserves the total inertial momentum
    ``R (J ω + h)`` exactly in continuous time, whatever the steering does.

    Args:
        cluster: an :class:`spacecraft.sgcmg.SgcmgPyramid` (default: ``h0 = 300`` N·m·s,
            β = 54.73°, rate limit 1 rad/s).
        steering: a steering law ``law(A, h_dot_cmd, delta=..., t=..., cluster=...) -> δ̇``
            (default: :class:`spacecraft.steering.SingularityRobust` with its defaults).
        delta0: initial gimbal angles ``(4,)`` or ``(B, 4)`` [rad] (default (45°, −45°, 45°,
            −45°): zero stored momentum, seed 000).
    """

    n_states = 4

    def __init__(
        self,
        cluster: Any = None,
        steering: Any = None,
        delta0: object = (np.pi / 4, -np.pi / 4, np.pi / 4, -np.pi / 4),
    ) -> None:
        if cluster is None:
            from .sgcmg import SgcmgPyramid

            cluster = SgcmgPyramid()
        if steering is None:
            steering = _default_steering()
        if not callable(steering):
            raise ValueError("steering: must be callable as law(A, h_dot_cmd, ...)")
        d0 = as_array(delta0, "delta0", (4,)).copy()
        if d0.ndim not in (1, 2):
            raise ValueError(f"delta0: expected shape (4,) or (B, 4), got {d0.shape}")
        d0.setflags(write=False)
        self.cluster = cluster
        self.steering = steering
        self.delta0 = d0
        self.rate_limit = float(cluster.gimbal_rate_limit)
        from .steering import saturate_gimbal_rates

        self._saturate = saturate_gimbal_rates
        self._fast = self._build_fast_path()
        # pass only the keyword arguments the steering law accepts (stateless laws need none)
        try:
            params = inspect.signature(steering).parameters
        except (TypeError, ValueError):
            params = {}
        takes_kwargs = any(p.kind is p.VAR_KEYWORD for p in params.values())
        self._steer_kw = tuple(k for k in ("delta", "t", "cluster") if takes_kwargs or k in params)

    def _build_fast_path(self) -> np.ndarray | None:
        """``M (8, 3)`` with ``h(δ) = [sin δ, cos δ] M`` and ``A(δ) δ̇ = [cos δ ∘ δ̇, −sin δ ∘ δ̇] M``.

        A single-gimbal CMG's momentum turns in the plane normal to its gimbal axis, so
        ``h_i(δ) = h_i(π/2) sin δ + h_i(0) cos δ`` for any such cluster; the two constant
        matrices are read off the cluster's public ``unit_momenta`` and the identity is checked
        against ``momentum_and_jacobian`` at a generic angle. This replaces the cluster's
        validated calls in every integration stage (they cost ~2× more at B = 1). ``None``
        (use the cluster's methods) if the cluster does not have this form.
        """
        cl = self.cluster
        if not all(hasattr(cl, a) for a in ("unit_momenta", "h0")):
            return None
        quarter = np.full(4, np.pi / 2)
        S = 0.5 * (cl.unit_momenta(quarter) - cl.unit_momenta(-quarter))  # exact: cos(±π/2) cancels
        C = cl.unit_momenta(np.zeros(4))
        h0 = float(cl.h0)
        M = h0 * np.concatenate([S.T, C.T], axis=0)
        self._S0 = h0 * S  # A(δ) = h0 (S ∘ cos δ − C ∘ sin δ), column-wise
        self._C0 = h0 * C
        d = np.array([[0.3, -1.1, 2.0, 0.7]])
        dd = np.array([[0.2, 0.5, -0.4, 0.1]])
        h_ref, A_ref = cl.momentum_and_jacobian(d)
        sn, cs = np.sin(d), np.cos(d)
        A = self._S0 * cs[:, None, :] - self._C0 * sn[:, None, :]
        scale = h0 * 4.0
        ok = np.allclose(np.concatenate([sn, cs], axis=-1) @ M, h_ref, rtol=0, atol=1e-12 * scale)
        ok &= np.allclose(A, A_ref, rtol=0.0, atol=1e-12 * scale)
        ok &= np.allclose(
            np.concatenate([cs * dd, -sn * dd], axis=-1) @ M,
            (A_ref @ dd[0]),
            rtol=0,
            atol=1e-12 * scale,
        )
        if not ok:
            return None
        for a in (M, self._S0, self._C0):
            a.setflags(write=False)
        self._M_rows = tuple(map(tuple, M.tolist()))
        return M

    def _momentum_and_rate(
        self, delta: np.ndarray, delta_dot: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(h(δ), A(δ) δ̇)``, both ``(B, 3)``, from one sin/cos and one matmul."""
        M = self._fast
        if M is None:
            h, A = self.cluster.momentum_and_jacobian(delta)
            return h, np.matmul(A, delta_dot[..., None])[..., 0]
        sn = np.sin(delta)
        cs = np.cos(delta)
        W = np.empty(delta.shape[:-1] + (2, 8))
        W[..., 0, :4] = sn
        W[..., 0, 4:] = cs
        np.multiply(cs, delta_dot, out=W[..., 1, :4])
        np.multiply(sn, delta_dot, out=W[..., 1, 4:])
        np.negative(W[..., 1, 4:], out=W[..., 1, 4:])
        Y = W @ M
        return Y[..., 0, :], Y[..., 1, :]

    def __repr__(self) -> str:
        return (
            f"SgcmgActuator(cluster={self.cluster!r}, steering={self.steering!r}, "
            f"delta0={self.delta0.tolist()})"
        )

    def initial_state(self, batch: int) -> np.ndarray:
        batch = int(batch)
        if self.delta0.ndim == 2 and self.delta0.shape[0] != batch:
            raise ValueError(
                f"delta0: has {self.delta0.shape[0]} rows but the batch has {batch} spacecraft"
            )
        return np.broadcast_to(self.delta0, (batch, 4)).copy()

    def command(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float
    ) -> CmgCommand:
        if self._fast is None:
            h, A = self.cluster.momentum_and_jacobian(x_act)
        else:
            W = np.empty(x_act.shape[:-1] + (8,))
            sn = np.sin(x_act, out=W[..., :4])
            cs = np.cos(x_act, out=W[..., 4:])
            h = W @ self._fast
            A = self._S0 * cs[..., None, :]
            A -= self._C0 * sn[..., None, :]
        h_dot_cmd = _cross(omega, h)
        h_dot_cmd += u_cmd
        np.negative(h_dot_cmd, out=h_dot_cmd)
        kw = {"delta": x_act, "t": t, "cluster": self.cluster}
        delta_dot = self.steering(A, h_dot_cmd, **{k: kw[k] for k in self._steer_kw})
        delta_dot, saturated = self._saturate(delta_dot, self.rate_limit)
        return CmgCommand(delta_dot=delta_dot, saturated=saturated, h_dot_cmd=h_dot_cmd)

    def state_derivative(self, x_act: np.ndarray, held: CmgCommand) -> np.ndarray:
        return held.delta_dot

    def body_torque(self, omega: np.ndarray, x_act: np.ndarray, held: CmgCommand) -> np.ndarray:
        if x_act.shape == (1, 4) and self._fast is not None:
            return self._body_torque_one(omega, x_act, held.delta_dot)
        h, h_dot = self._momentum_and_rate(x_act, held.delta_dot)
        tau = _cross(omega, h)
        tau += h_dot
        np.negative(tau, out=tau)
        return tau

    def _body_torque_one(
        self, omega: np.ndarray, x_act: np.ndarray, delta_dot: np.ndarray
    ) -> np.ndarray:
        """:meth:`body_torque` for one spacecraft on Python floats (~2× faster than numpy on
        1-element arrays); same formula, checked against the batched path by the tests."""
        rows = self._M_rows
        h0 = h1 = h2 = r0 = r1 = r2 = 0.0
        for i, (d, dd) in enumerate(zip(x_act[0].tolist(), delta_dot[0].tolist(), strict=True)):
            sn = math.sin(d)
            cs = math.cos(d)
            s0, s1, s2 = rows[i]  # h0 · h_i(π/2)
            c0, c1, c2 = rows[4 + i]  # h0 · h_i(0)
            h0 += s0 * sn + c0 * cs
            h1 += s1 * sn + c1 * cs
            h2 += s2 * sn + c2 * cs
            a = cs * dd
            b = sn * dd
            r0 += s0 * a - c0 * b
            r1 += s1 * a - c1 * b
            r2 += s2 * a - c2 * b
        w0, w1, w2 = omega[0].tolist()
        return np.array(
            [[-(r0 + w1 * h2 - w2 * h1), -(r1 + w2 * h0 - w0 * h2), -(r2 + w0 * h1 - w1 * h0)]]
        )

    def momentum(self, x_act: np.ndarray) -> np.ndarray:
        if self._fast is None:
            return self.cluster.momentum(x_act)
        W = np.empty(x_act.shape[:-1] + (8,))
        np.sin(x_act, out=W[..., :4])
        np.cos(x_act, out=W[..., 4:])
        return W @ self._fast

    def log(self, x_act: np.ndarray, held: CmgCommand) -> dict[str, np.ndarray]:
        """``delta`` (B,4) [rad], ``delta_dot`` (B,4) [rad/s], ``saturated`` (B,) bool."""
        return {"delta": x_act, "delta_dot": held.delta_dot, "saturated": held.saturated}

    def derived_log(self, log: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``singularity`` m = √det(ÂÂᵀ) (K,B) and ``h`` (K,B,3) [N·m·s] of the logged gimbal
        angles, vectorized over the whole log."""
        delta = log["delta"]
        return {
            "singularity": self.cluster.singularity_measure(delta),
            "h": self.momentum(delta),
        }
