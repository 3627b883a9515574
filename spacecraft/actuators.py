"""The actuator seam between a controller's torque command and the plant.

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

SGCMG physics: the cluster stores ``h(δ)``, ``ḣ = A(δ) δ̇``, and the bus feels
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

from liecontrol._array_api import any_true, cross, namespace
from liecontrol._jit import JIT_ENABLED
from liecontrol._validation import as_array, as_scalar, check_nonnegative, check_positive

from ._kernels import cmg_bus_torque_batch, sgcmg_command_batch
from .rigid_body import _cross

__all__ = [
    "Actuator",
    "IdealTorqueActuator",
    "SgcmgActuator",
    "CmgCommand",
    "FirstOrderServo",
    "ReactionWheelAssembly",
    "WheelCommand",
    "orthogonal_wheel_axes",
    "pyramid_wheel_axes",
]


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
        ``u_cmd`` ``(B, 3)`` [N·m], body rate ``omega`` ``(B, 3)``, actuator states ``x_act``.

        The built-in actuators validate here (finite real arrays of matching shapes, a scalar
        ``t``, a finite result) and run the same computation unchecked in
        ``command_unchecked``, which :func:`spacecraft.simulator.simulate` calls at every step
        on its already-validated state (an actuator without it is called through ``command``).
        """

    def _check_command(
        self, u_cmd: object, omega: object, x_act: object, t: object
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """The arguments of :meth:`command`, validated (messages name the argument)."""
        u = as_array(u_cmd, "u_cmd")
        if u.ndim != 2 or u.shape[1] != 3:
            raise ValueError(f"u_cmd: expected shape (B, 3), got {u.shape}")
        w = as_array(omega, "omega")
        if w.shape != u.shape:
            raise ValueError(f"omega: expected shape {u.shape} (as u_cmd), got {w.shape}")
        x = as_array(x_act, "x_act")
        if x.shape != (u.shape[0], self.n_states):
            raise ValueError(f"x_act: expected shape {(u.shape[0], self.n_states)}, got {x.shape}")
        return u, w, x, as_scalar(t, "t")

    def _validated_command(self, u_cmd: object, omega: object, x_act: object, t: object) -> Any:
        """:meth:`command` for actuators with a ``command_unchecked``: validate the arguments,
        run the unchecked computation, and refuse a non-finite result (naming ``u_cmd``)."""
        u, w, x, tt = self._check_command(u_cmd, omega, x_act, t)
        with np.errstate(over="ignore", invalid="ignore"):
            held = self.command_unchecked(u, w, x, tt)  # type: ignore[attr-defined]
        return self._check_held(held, u)

    @staticmethod
    def _check_held(held: Any, u: np.ndarray) -> Any:
        """Raise (naming ``u_cmd``) if the hardware command computed from finite inputs is
        not finite: the torque command overflowed float64 on the way."""
        arrays = [held] if isinstance(held, np.ndarray) else list(vars(held).values())
        for a in arrays:
            if isinstance(a, np.ndarray) and a.dtype.kind == "f" and not np.all(np.isfinite(a)):
                raise ValueError(
                    f"u_cmd: the actuator command overflows float64 (max |u_cmd| = "
                    f"{float(np.abs(u).max()):.3g})"
                )
        return held

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
    """Delivers the commanded torque exactly (papers that assume an ideal actuator).

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
        """Validated :meth:`command_unchecked` (see :meth:`Actuator.command`)."""
        return self._validated_command(u_cmd, omega, x_act, t)

    def command_unchecked(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float
    ) -> Any:
        """:meth:`command` without validation (the simulator's per-step call)."""
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


@dataclass(frozen=True)
class FirstOrderServo:
    """First-order gimbal-rate servo (the gimbal servo is ideal or, here, a first-order lag)::

        δ̈ = (δ̇_cmd − δ̇) / τ,

    i.e. the actual gimbal rate δ̇ follows the commanded (steered, rate-limited) rate with time
    constant τ: after a step in δ̇_cmd from rest, δ̇(t) = δ̇_cmd (1 − e^{−t/τ}) and
    δ(t) = δ(0) + δ̇_cmd (t − τ (1 − e^{−t/τ})). A first-order lag is the usual reduced model
    of a gimbal rate loop (Wie, *Space Vehicle Dynamics and Control*, 2nd ed., §7.3; the
    gimbal inertia is neglected in the bus dynamics). With it the actuator state is
    ``(δ, δ̇_actual)`` ``(B, 8)``. Since δ̇ is a convex combination of past commands, the rate
    limit on δ̇_cmd also bounds the actual rates.

    Args:
        time_constant: τ > 0 [s].
    """

    time_constant: float

    def __post_init__(self) -> None:
        tau = _positive_scalar(self.time_constant, "time_constant")
        object.__setattr__(self, "time_constant", tau)


def _positive_scalar(v: object, name: str) -> float:
    a = check_positive(v, name)
    if not isinstance(a, float):
        raise ValueError(f"{name}: must be a scalar, got shape {np.shape(a)}")
    return a


def _default_steering() -> Any:
    from .steering import SingularityRobust

    return SingularityRobust()


class SgcmgActuator(Actuator):
    """Four-SGCMG pyramid with a steering law and a gimbal-rate limit.

    State: the gimbal angles ``δ`` ``(B, 4)``. Per step (ZOH of gimbal rates):
    ``ḣ_cmd = −u_cmd − ω × h(δ)``, ``δ̇ = steering(A(δ), ḣ_cmd)``, clipped to the cluster's
    gimbal-rate limit. In the integration stages ``δ̇`` is constant and the bus feels
    ``u = −A(δ) δ̇ − ω × h(δ)`` — which conserves the total inertial momentum
    ``R (J ω + h)`` exactly in continuous time, whatever the steering does.

    Gimbal servo: ``"ideal"`` (the gimbals turn at the commanded rate; state ``δ`` ``(B, 4)``)
    or a :class:`FirstOrderServo` (state ``(δ, δ̇)`` ``(B, 8)``, δ̈ = (δ̇_cmd − δ̇)/τ, and the bus
    feels ``−A(δ) δ̇ − ω × h(δ)`` with the *actual* rate δ̇). The steering law and the rate
    limit act on the command; ``t`` is passed to the law (time-varying laws such as
    :class:`spacecraft.steering.GeneralizedSingularityRobust`).

    Hot path: laws derived from :class:`spacecraft.steering.SteeringLaw` are called through
    their unchecked ``steer`` (validated once here), other callables through the keyword API.

    Args:
        cluster: an :class:`spacecraft.sgcmg.SgcmgPyramid` (default: ``h0 = 300`` N·m·s,
            β = 54.73°, rate limit 1 rad/s).
        steering: a steering law ``law(A, h_dot_cmd, delta=..., t=..., cluster=...) -> δ̇``
            (default: :class:`spacecraft.steering.SingularityRobust` with its defaults).
        delta0: initial gimbal angles ``(4,)`` or ``(B, 4)`` [rad] (default (45°, −45°, 45°,
            −45°): zero stored momentum, Wu et al.).
        servo: ``"ideal"`` (default) or :class:`FirstOrderServo` ``(time_constant)``.
    """

    n_states = 4

    def __init__(
        self,
        cluster: Any = None,
        steering: Any = None,
        delta0: object = (np.pi / 4, -np.pi / 4, np.pi / 4, -np.pi / 4),
        servo: str | FirstOrderServo = "ideal",
    ) -> None:
        from .sgcmg import SgcmgPyramid

        if cluster is None:
            cluster = SgcmgPyramid()
        if not isinstance(cluster, SgcmgPyramid):
            raise ValueError(
                f"cluster: expected an SgcmgPyramid (or None for the default), got "
                f"{type(cluster).__name__} {cluster!r}"
            )
        if steering is None:
            steering = _default_steering()
        if not callable(steering):
            raise ValueError("steering: must be callable as law(A, h_dot_cmd, ...)")
        d0 = as_array(delta0, "delta0", (4,)).copy()
        if d0.ndim not in (1, 2):
            raise ValueError(f"delta0: expected shape (4,) or (B, 4), got {d0.shape}")
        d0.setflags(write=False)
        if isinstance(servo, str) and servo == "ideal":
            self.servo: str | FirstOrderServo = "ideal"
            self._tau: float | None = None
            self.n_states = 4
        elif isinstance(servo, FirstOrderServo):
            self.servo = servo
            self._tau = servo.time_constant
            self.n_states = 8  # (δ, δ̇_actual)
        else:
            raise ValueError(f"servo: expected 'ideal' or a FirstOrderServo, got {servo!r}")
        self.cluster = cluster
        self.steering = steering
        self.delta0 = d0
        self.rate_limit = float(cluster.gimbal_rate_limit)
        from .steering import SteeringLaw, _saturate_unchecked

        own = getattr(steering, "cluster", None)
        if own is not None and own != cluster:
            raise ValueError("steering: its own cluster differs from the actuator's cluster")
        self._saturate = _saturate_unchecked
        self._trig_cache: tuple | None = None
        # validated laws have an unchecked entry point; other callables get the keyword API
        self._steer = steering.steer if isinstance(steering, SteeringLaw) else None
        self._fast = self._build_fast_path()
        # the compiled command (spacecraft._kernels.sgcmg_command) for the steering laws that
        # have a kernel, with the sin/cos-separable cluster model
        from .steering import steering_kernel

        self._steer_kernel = None if self._fast is None else steering_kernel(steering, cluster)
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
        self._S0c = np.ascontiguousarray(self._S0)
        self._C0c = np.ascontiguousarray(self._C0)
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
        # [sin δ, cos δ] @ K = [h(δ), A(δ) row-major]: h and the Jacobian from one (B, 8) @
        # (8, 15) product (elementwise S0 ∘ cos δ − C0 ∘ sin δ on (B, 3, 4) costs ~4× more)
        K = np.zeros((8, 15))
        K[:, :3] = M
        for r in range(3):
            for i in range(4):
                K[i, 3 + 4 * r + i] = -self._C0[r, i]
                K[4 + i, 3 + 4 * r + i] = self._S0[r, i]
        self._K = K
        self._M_rate = np.concatenate([M[:4], -M[4:]], axis=0)
        for a in (M, K, self._M_rate, self._S0, self._C0):
            a.setflags(write=False)
        return M

    def _trig(self, delta: np.ndarray) -> tuple[np.ndarray, list]:
        """``W = [sin δ, cos δ]`` ``(B, 8)`` (read-only) for gimbal angles ``delta (B, 4)``, and
        a one-element list holding ``h(δ) = W M`` once computed (``[None]`` before).

        One-entry cache on the angle values: within a simulator step the same δ is seen by
        :meth:`momentum`, :meth:`command` and the first integration stage, and stages 2 and 3
        share δ + h/2 δ̇ bitwise (ideal servo), so 3 of the 6 sin/cos evaluations per step are
        reused (sin/cos are the largest elementwise cost of a batched step). The cache holds a
        copy of δ and is replaced as one tuple, so a reader always sees a consistent entry; a
        comparison costs ~1/20 of the trigonometry it saves.

        sin and cos come from one t = tan(δ/2): sin δ = 2t/(1 + t²), cos δ = (1 − t²)/(1 + t²)
        (numpy's float64 ``tan`` is SIMD-vectorised, ``sin``/``cos`` are not: 2.3× faster
        overall at B = 1000). Accurate to a few ulp in absolute terms for every finite δ (t is
        finite: δ/2 is never exactly an odd multiple of π/2 in floating point), i.e. the
        same values as ``np.sin``/``np.cos`` to round-off; non-finite δ gives NaN as before.
        """
        cached = self._trig_cache
        if cached is not None:
            d, W, h = cached
            if d.shape == delta.shape and (d == delta).all():
                return W, h
        W = np.empty(delta.shape[:-1] + (8,))
        t = np.multiply(delta, 0.5)
        np.tan(t, out=t)
        den = t * t
        np.subtract(1.0, den, out=W[..., 4:])
        den += 1.0
        np.divide(W[..., 4:], den, out=W[..., 4:])  # cos δ
        t += t
        np.divide(t, den, out=W[..., :4])  # sin δ
        W.setflags(write=False)
        h = [None]
        self._trig_cache = (delta.copy(), W, h)
        return W, h

    def _momentum_and_rate(
        self, delta: np.ndarray, delta_dot: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(h(δ), A(δ) δ̇)``, both ``(B, 3)``, from one (cached) sin/cos and one or two
        (B, 8) @ (8, 3) products (h is reused when the same δ was seen before)."""
        M = self._fast
        if M is None:
            h, A = self.cluster.momentum_and_jacobian(delta)
            return h, np.matmul(A, delta_dot[..., None])[..., 0]
        W, hc = self._trig(delta)
        # A δ̇ = [cos δ ∘ δ̇, sin δ ∘ δ̇] @ [M_sin; −M_cos]: the sign sits in the constant matrix
        # (x·(−m) = −(x·m) exactly, so the products and their sum are the same as before)
        V = np.empty(W.shape)
        np.multiply(W[..., 4:], delta_dot, out=V[..., :4])
        np.multiply(W[..., :4], delta_dot, out=V[..., 4:])
        if hc[0] is None:
            h = W @ M
            h.setflags(write=False)
            hc[0] = h
        return hc[0], V @ self._M_rate

    def __repr__(self) -> str:
        return (
            f"SgcmgActuator(cluster={self.cluster!r}, steering={self.steering!r}, "
            f"delta0={self.delta0.tolist()}, servo={self.servo!r})"
        )

    def initial_state(self, batch: int) -> np.ndarray:
        """Gimbal angles ``(batch, 4)``; with a :class:`FirstOrderServo` ``(batch, 8)``: the
        angles then the actual gimbal rates (initially 0)."""
        batch = int(batch)
        if self.delta0.ndim == 2 and self.delta0.shape[0] != batch:
            raise ValueError(
                f"delta0: has {self.delta0.shape[0]} rows but the batch has {batch} spacecraft"
            )
        x = np.zeros((batch, self.n_states))
        x[:, :4] = self.delta0
        return x

    def _rates(self, x_act: np.ndarray, held: CmgCommand) -> np.ndarray:
        """The gimbal rates that move the gimbals: commanded (ideal) or the servo state."""
        return held.delta_dot if self._tau is None else x_act[:, 4:]

    def command(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float
    ) -> CmgCommand:
        """Validated :meth:`command_unchecked` (see :meth:`Actuator.command`)."""
        return self._validated_command(u_cmd, omega, x_act, t)

    def command_unchecked(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float
    ) -> CmgCommand:
        """:meth:`command` without validation (the simulator's per-step call)."""
        delta = x_act if self._tau is None else x_act[:, :4]
        if self._steer_kernel is not None and (JIT_ENABLED or delta.shape[0] == 1):
            return self._command_kernel(u_cmd, omega, delta, t)
        if self._fast is None:
            h, A = self.cluster.momentum_and_jacobian(delta)
        elif delta.shape[0] == 1:
            W = np.empty(delta.shape[:-1] + (8,))
            sn = np.sin(delta, out=W[..., :4])
            cs = np.cos(delta, out=W[..., 4:])
            h = W @ self._fast
            A = self._S0 * cs[..., None, :]
            A -= self._C0 * sn[..., None, :]
        else:
            W, hc = self._trig(delta)
            # computed transposed, (15, B): A is then a (B, 3, 4) view whose entries are
            # contiguous (B,) rows — the layout the batched steering algebra works in
            Y = self._K.T @ W.T
            h = Y[:3].T
            h.setflags(write=False)  # shared through the cache (momentum() returns a copy)
            hc[0] = h
            A = Y[3:].reshape(3, 4, -1).transpose(2, 0, 1)
        h_dot_cmd = _cross(omega, h)
        h_dot_cmd += u_cmd
        np.negative(h_dot_cmd, out=h_dot_cmd)
        if self._steer is not None:
            delta_dot = self._steer(A, h_dot_cmd, delta, float(t), self.cluster)
        else:
            kw = {"delta": delta, "t": t, "cluster": self.cluster}
            delta_dot = np.asarray(
                self.steering(A, h_dot_cmd, **{k: kw[k] for k in self._steer_kw}),
                dtype=np.float64,
            )
        delta_dot, saturated = self._saturate(delta_dot, self.rate_limit)
        return CmgCommand(delta_dot=delta_dot, saturated=saturated, h_dot_cmd=h_dot_cmd)

    def _command_kernel(
        self, u_cmd: np.ndarray, omega: np.ndarray, delta: np.ndarray, t: float
    ) -> CmgCommand:
        """:meth:`command_unchecked` through the compiled kernel
        (:func:`spacecraft._kernels.sgcmg_command`): h(δ) and A(δ), ḣ_cmd = −(ω × h + u_cmd),
        the steering law and the uniform rate limit, one spacecraft at a time."""
        B = delta.shape[0]
        dd = np.empty((B, 4))
        hd = np.empty((B, 3))
        sat = np.empty(B, dtype=bool)
        code, params = self._steer_kernel
        sgcmg_command_batch(
            self._S0c, self._C0c, code, params, self.rate_limit,
            np.ascontiguousarray(u_cmd, dtype=np.float64),
            np.ascontiguousarray(omega, dtype=np.float64),
            np.ascontiguousarray(delta, dtype=np.float64), float(t), dd, hd, sat,
        )  # fmt: skip
        return CmgCommand(delta_dot=dd, saturated=sat, h_dot_cmd=hd)

    def state_derivative(self, x_act: np.ndarray, held: CmgCommand) -> np.ndarray:
        if self._tau is None:
            return held.delta_dot
        rates = x_act[:, 4:]
        out = np.empty(x_act.shape)
        out[:, :4] = rates
        np.subtract(held.delta_dot, rates, out=out[:, 4:])
        out[:, 4:] /= self._tau
        return out

    def body_torque(self, omega: np.ndarray, x_act: np.ndarray, held: CmgCommand) -> np.ndarray:
        rates = self._rates(x_act, held)
        delta = x_act if self._tau is None else x_act[:, :4]
        if self._fast is not None and (JIT_ENABLED or delta.shape[0] == 1):
            out = np.empty(omega.shape)
            cmg_bus_torque_batch(
                self._S0c, self._C0c, np.ascontiguousarray(omega, dtype=np.float64),
                np.ascontiguousarray(delta, dtype=np.float64),
                np.ascontiguousarray(rates, dtype=np.float64), out,
            )  # fmt: skip
            return out
        h, h_dot = self._momentum_and_rate(delta, rates)
        tau = _cross(omega, h)
        tau += h_dot
        np.negative(tau, out=tau)
        return tau

    def momentum(self, x_act: np.ndarray) -> np.ndarray:
        delta = x_act[..., :4]
        if self._fast is None:
            return self.cluster.momentum(delta)
        if delta.ndim == 2 and delta.shape[0] > 1:
            W, hc = self._trig(delta)
            if hc[0] is None:
                h = W @ self._fast
                h.setflags(write=False)
                hc[0] = h
            return hc[0].copy()  # the caller owns its result; the cached h stays intact
        W = np.empty(delta.shape[:-1] + (8,))
        np.sin(delta, out=W[..., :4])
        np.cos(delta, out=W[..., 4:])
        return W @ self._fast

    def log(self, x_act: np.ndarray, held: CmgCommand) -> dict[str, np.ndarray]:
        """``delta`` (B,4) [rad], ``delta_dot`` (B,4) [rad/s] (the rates that move the gimbals),
        ``saturated`` (B,) bool (the commanded rate vector was scaled to the limit); with a
        :class:`FirstOrderServo` also ``delta_dot_cmd`` (B,4), the commanded rates."""
        if self._tau is None:
            return {"delta": x_act, "delta_dot": held.delta_dot, "saturated": held.saturated}
        return {
            "delta": x_act[:, :4],
            "delta_dot": x_act[:, 4:],
            "delta_dot_cmd": held.delta_dot,
            "saturated": held.saturated,
        }

    def derived_log(self, log: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``singularity`` m = √det(ÂÂᵀ) (K,B) and ``h`` (K,B,3) [N·m·s] of the logged gimbal
        angles, vectorized over the whole log (or nothing when the compiled loop already logged
        both, from the same angles: :func:`spacecraft._kernels.cmg_momentum_and_measure`)."""
        if "singularity" in log and "h" in log:
            return {}
        delta = log["delta"]
        return {
            "singularity": self.cluster.singularity_measure(delta),
            "h": self.momentum(delta),
        }


# ---------------------------------------------------------------------------- reaction wheels
#: Default pyramid half-cone angle: arctan √2 ≈ 54.7356°, where the four axes give AAᵀ = (4/3) I
#: (the same torque capability about every body axis).
PYRAMID_ISOTROPIC_BETA = math.atan(math.sqrt(2.0))


def orthogonal_wheel_axes() -> np.ndarray:
    """Three wheels along the body axes: ``I₃`` (columns = spin axes)."""
    return np.eye(3)


def pyramid_wheel_axes(beta: float = PYRAMID_ISOTROPIC_BETA) -> np.ndarray:
    """Four wheels in a pyramid about body +z, ``(3, 4)`` unit columns::

        aᵢ = (sin β cos φᵢ, sin β sin φᵢ, cos β),   φᵢ = 0°, 90°, 180°, 270°,

    with β the half-cone angle from +z (0 < β < π/2). AAᵀ = diag(2 sin²β, 2 sin²β, 4 cos²β);
    the default β = arctan √2 makes it isotropic, (4/3) I. Any three of the four axes span
    ℝ³, so the assembly survives one wheel failure (Markley & Crassidis 2014, §7.8).
    """
    b = as_scalar(beta, "beta")
    if not 0.0 < b < math.pi / 2:
        raise ValueError(f"beta: must lie in (0, π/2), got {beta!r}")
    phi = np.arange(4) * (math.pi / 2)
    s = math.sin(b)
    axes = np.stack([s * np.cos(phi), s * np.sin(phi), np.full(4, math.cos(b))])
    axes[np.abs(axes) < 1e-16] = 0.0  # cos(90°) rounding
    return axes


def _per_wheel(v: object, name: str, n: int) -> np.ndarray:
    """Positive scalar or ``(n,)`` → read-only ``(n,)``."""
    a = np.array(check_positive(v, name), dtype=np.float64)
    if a.ndim == 0:
        a = np.full(n, float(a))
    elif a.shape != (n,):
        raise ValueError(f"{name}: expected a scalar or shape ({n},) (per wheel), got {a.shape}")
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class WheelCommand:
    """What the reaction-wheel assembly holds over one integration step (all ``(B, N)``
    except ``h_dot_cmd``).

    Attributes:
        torque: motor torques on the wheels after the limits, τᵢ = I_w Ω̇ᵢ [N·m].
        torque_cmd: the minimum-norm distribution A⁺ ḣ_cmd before the limits [N·m].
        torque_saturated: |τ_cmd,ᵢ| > max_torque (clipped).
        speed_saturated: the wheel was at max speed and τ_cmd would have pushed it further
            (torque set to 0).
        h_dot_cmd: ``(B, 3)`` momentum rate asked for [N·m].
    """

    torque: np.ndarray
    torque_cmd: np.ndarray
    torque_saturated: np.ndarray
    speed_saturated: np.ndarray
    h_dot_cmd: np.ndarray


@dataclass(frozen=True, eq=False)
class ReactionWheelAssembly(Actuator):
    """N reaction wheels on fixed spin axes (Wang et al.'s (2016) satellite).

    State: the wheel speeds Ω ``(B, N)`` [rad/s]. Stored momentum and dynamics::

        h = Σᵢ I_w,ᵢ Ωᵢ aᵢ = A (I_w ∘ Ω),    I_w,ᵢ Ω̇ᵢ = τᵢ,    ḣ = A τ,
        body torque u = −ḣ − ω × h = −A τ − ω × h

    with A = [a₁ … a_N] the ``axes``. Ωᵢ is the wheel's axial spin rate such that its axial
    momentum is I_w Ωᵢ (Markley & Crassidis 2014, §3.3.5: J is then the spacecraft inertia
    without the wheels' axial inertia; the rate relative to the bus differs by aᵢ·ω, ≪ Ω).

    Bearing friction (optional; Armstrong-Hélouvry, Dupont & Canudas de Wit, "A survey of
    models, analysis tools and compensation methods for the control of machines with friction",
    Automatica 30(7), 1994; for wheels Bialke, "High fidelity mathematical modeling of reaction
    wheel performance", AAS 98-063, 1998) adds to each wheel's motor torque τᵢ::

        τ_f(Ω) = −[τ_c + (τ_s − τ_c) exp(−(Ω/ω_s)²)] tanh(Ω/ε) − c_v Ω

    (Coulomb τ_c, Stribeck breakaway τ_s ≥ τ_c at speeds below ω_s, viscous c_v). The sign
    function of the Coulomb term is smoothed to tanh(Ω/ε) so that a wheel crossing zero speed
    does not chatter in a fixed-step integrator (ε = ``friction_smoothing``, small against the
    operating speeds). Friction acts between wheel and bus, so it enters ḣ and the bus torque
    like the motor torque — total angular momentum is unchanged and the kinetic energy it
    removes is ∫ −τ_f·Ω dt. It is not compensated: the controller sees it as a disturbance.
    Ω is the absolute axial rate (see above); the bus-rate term aᵢ·ω is neglected in τ_f.

    Torque quantisation (``torque_lsb`` q > 0): the motor drive delivers τ = q·round(τ/q)
    (then clipped to ``max_torque``), the resolution of its torque command.

    Per step (ZOH of wheel torques): ḣ_cmd = −u_cmd − ω × h; minimum-norm distribution
    τ_cmd = A⁺ ḣ_cmd, A⁺ = Aᵀ(AAᵀ)⁻¹ (precomputed); per-wheel torque limit
    τ = clip(τ_cmd, ±max_torque) (flagged; clipping one wheel changes the torque direction,
    as real wheel electronics do); speed limit: a wheel at |Ωᵢ| ≥ max_speed gets no torque that
    would speed it up further (flagged). The speed gate is also applied inside every
    integration stage (to the held τ, with the same τ on the wheel and on the bus, so momentum
    exchange stays exact), so a wheel overshoots max_speed by at most max_torque·dt/I_w.

    Args:
        axes: ``(3, N)`` unit spin axes (N ≥ 3, spanning ℝ³): :func:`orthogonal_wheel_axes`,
            :func:`pyramid_wheel_axes` (or the :meth:`orthogonal`/:meth:`pyramid` constructors).
        wheel_inertia: axial inertia I_w > 0 [kg·m²], scalar or ``(N,)``.
        max_torque: motor torque limit > 0 [N·m], scalar or ``(N,)``.
        max_speed: wheel speed limit > 0 [rad/s], scalar or ``(N,)``.
        initial_speeds: Ω(0) ``(N,)`` or ``(B, N)`` [rad/s], |Ω(0)| ≤ max_speed (default 0).
        coulomb_friction: τ_c ≥ 0 [N·m], scalar or ``(N,)``.
        viscous_friction: c_v ≥ 0 [N·m·s/rad], scalar or ``(N,)``.
        stribeck_torque: breakaway torque τ_s ≥ τ_c [N·m] (0: no Stribeck term).
        stribeck_speed: ω_s > 0 [rad/s] (needed when ``stribeck_torque`` > 0).
        friction_smoothing: ε > 0 [rad/s] of the smoothed sign (default 0.01).
        torque_lsb: q ≥ 0 [N·m], torque resolution of the motor drive (0: continuous).

    Logged: ``wheel_speed``, ``wheel_torque`` (delivered motor τ at the step start),
    ``wheel_torque_cmd``, ``torque_saturated``, ``speed_saturated`` and ``saturated`` (either),
    with friction also ``friction_torque`` (τ_f at the step start), all ``(B, N)``; derived
    ``h`` ``(K, B, 3)``.
    """

    axes: np.ndarray
    wheel_inertia: float | np.ndarray = 0.05
    max_torque: float | np.ndarray = 0.2
    max_speed: float | np.ndarray = 600.0
    initial_speeds: object = None
    coulomb_friction: float | np.ndarray = 0.0
    viscous_friction: float | np.ndarray = 0.0
    stribeck_torque: float | np.ndarray = 0.0
    stribeck_speed: float | np.ndarray | None = None
    friction_smoothing: float = 0.01
    torque_lsb: float = 0.0
    n_states: int = field(default=0, init=False)
    #: any friction term non-zero (checked once: _torque runs at every integration stage)
    _friction_on: bool = field(default=False, init=False, repr=False)
    _pinv: np.ndarray = field(init=False, repr=False)
    _AI: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        A = np.array(as_array(self.axes, "axes"), dtype=np.float64)
        if A.ndim != 2 or A.shape[0] != 3 or A.shape[1] < 3:
            raise ValueError(f"axes: expected shape (3, N) with N >= 3 wheels, got {A.shape}")
        n = A.shape[1]
        norms = np.linalg.norm(A, axis=0)
        bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-9)
        if bad.size:
            raise ValueError(
                f"axes: column {int(bad[0])} has norm {norms[bad[0]]:.6g}, expected unit vectors"
            )
        sv = np.linalg.svd(A, compute_uv=False)
        if sv[-1] < 1e-6 * sv[0]:
            raise ValueError(
                f"axes: the spin axes do not span 3-D space (singular values {sv.tolist()})"
            )
        A.setflags(write=False)
        Iw = _per_wheel(self.wheel_inertia, "wheel_inertia", n)
        tmax = _per_wheel(self.max_torque, "max_torque", n)
        wmax = _per_wheel(self.max_speed, "max_speed", n)
        if self.initial_speeds is None:
            w0 = np.zeros(n)
        else:
            w0 = np.array(as_array(self.initial_speeds, "initial_speeds", (n,)))
            if w0.ndim not in (1, 2):
                raise ValueError(
                    f"initial_speeds: expected shape ({n},) or (B, {n}), got {w0.shape}"
                )
            if np.any(np.abs(w0) > wmax):
                raise ValueError(
                    f"initial_speeds: |Ω| = {np.abs(w0).max():.6g} rad/s exceeds max_speed"
                )
        w0.setflags(write=False)
        pinv = A.T @ np.linalg.inv(A @ A.T)
        AI = A * Iw  # h = Ω @ (A ∘ I_w)ᵀ
        for arr in (pinv, AI):
            arr.setflags(write=False)
        for name, v in (
            ("axes", A),
            ("wheel_inertia", Iw),
            ("max_torque", tmax),
            ("max_speed", wmax),
            ("initial_speeds", w0),
            ("n_states", n),
            ("_pinv", pinv),
            ("_AI", AI),
        ):
            object.__setattr__(self, name, v)
        self._init_friction(n)

    def _init_friction(self, n: int) -> None:
        def per_wheel0(v: object, name: str) -> np.ndarray:
            a = np.array(check_nonnegative(v, name), dtype=np.float64)
            a = np.full(n, float(a)) if a.ndim == 0 else a
            if a.shape != (n,):
                raise ValueError(
                    f"{name}: expected a scalar or shape ({n},) (per wheel), got {a.shape}"
                )
            a.setflags(write=False)
            return a

        tc = per_wheel0(self.coulomb_friction, "coulomb_friction")
        cv = per_wheel0(self.viscous_friction, "viscous_friction")
        ts = per_wheel0(self.stribeck_torque, "stribeck_torque")
        ws = None
        if np.any(ts > 0):
            if np.any((ts > 0) & (ts < tc)):
                raise ValueError(
                    "stribeck_torque: the breakaway torque must be >= coulomb_friction where "
                    f"it is set, got {ts.tolist()} < {tc.tolist()}"
                )
            if self.stribeck_speed is None:
                raise ValueError("stribeck_torque: needs stribeck_speed (> 0 rad/s)")
            ws = _per_wheel(self.stribeck_speed, "stribeck_speed", n)
        elif self.stribeck_speed is not None:
            ws = _per_wheel(self.stribeck_speed, "stribeck_speed", n)
        eps = as_scalar(self.friction_smoothing, "friction_smoothing")
        if not eps > 0.0:
            raise ValueError(f"friction_smoothing: must be > 0, got {eps}")
        lsb = float(check_nonnegative(as_scalar(self.torque_lsb, "torque_lsb"), "torque_lsb"))
        for name, v in (
            ("coulomb_friction", tc),
            ("viscous_friction", cv),
            ("stribeck_torque", ts),
            ("stribeck_speed", ws),
            ("friction_smoothing", eps),
            ("torque_lsb", lsb),
            ("_friction_on", bool(np.any(tc > 0) or np.any(cv > 0) or np.any(ts > 0))),
        ):
            object.__setattr__(self, name, v)

    @property
    def has_friction(self) -> bool:
        """Whether any friction term is non-zero."""
        return self._friction_on

    def friction_torque(self, speed: object) -> np.ndarray:
        """τ_f(Ω) ``(..., N)`` [N·m] of wheel speeds ``speed`` ``(..., N)`` [rad/s] (the law in
        the class docstring; zero without friction)."""
        w = as_array(speed, "speed", (self.n_states,))
        return self._friction(w)

    def _friction(self, w: np.ndarray) -> np.ndarray:
        # NumPy or jax.numpy (the JAX route of spacecraft.differentiable): the parameters are
        # NumPy arrays, so their tests stay concrete under tracing
        xp = namespace(w)
        level = self.coulomb_friction
        if self.stribeck_speed is not None and np.any(self.stribeck_torque > 0):
            extra = np.where(self.stribeck_torque > 0, self.stribeck_torque - level, 0.0)
            level = level + extra * xp.exp(-((w / self.stribeck_speed) ** 2))
        return -level * xp.tanh(w / self.friction_smoothing) - self.viscous_friction * w

    @classmethod
    def orthogonal(cls, **kwargs: Any) -> ReactionWheelAssembly:
        """Three wheels along the body axes (keyword arguments as the constructor's)."""
        return cls(orthogonal_wheel_axes(), **kwargs)

    @classmethod
    def pyramid(cls, beta: float = PYRAMID_ISOTROPIC_BETA, **kwargs: Any) -> ReactionWheelAssembly:
        """Four wheels in a pyramid (:func:`pyramid_wheel_axes`)."""
        return cls(pyramid_wheel_axes(beta), **kwargs)

    @property
    def n_wheels(self) -> int:
        return int(self.n_states)

    def initial_state(self, batch: int) -> np.ndarray:
        batch = int(batch)
        w0 = self.initial_speeds
        if w0.ndim == 2 and w0.shape[0] != batch:
            raise ValueError(
                f"initial_speeds: has {w0.shape[0]} rows but the batch has {batch} spacecraft"
            )
        return np.broadcast_to(w0, (batch, self.n_states)).copy()

    def _speed_gate(self, speed: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """True where a wheel at/over max speed would be pushed further by ``torque``."""
        return (abs(speed) >= self.max_speed) & (speed * torque > 0.0)

    def command(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float
    ) -> WheelCommand:
        """Validated :meth:`command_unchecked` (see :meth:`Actuator.command`)."""
        return self._validated_command(u_cmd, omega, x_act, t)

    def command_unchecked(
        self, u_cmd: np.ndarray, omega: np.ndarray, x_act: np.ndarray, t: float
    ) -> WheelCommand:
        """:meth:`command` without validation (the simulator's per-step call). Pure: NumPy or
        jax.numpy arrays (the JAX route of :mod:`spacecraft.differentiable` runs it)."""
        xp = namespace(u_cmd, omega, x_act)
        h = x_act @ self._AI.T
        h_dot_cmd = -(cross(omega, h) + u_cmd)
        tau_cmd = h_dot_cmd @ self._pinv.T
        tau = xp.clip(tau_cmd, -self.max_torque, self.max_torque)
        if self.torque_lsb > 0.0:
            q = self.torque_lsb
            tau = xp.clip(xp.round(tau / q) * q, -self.max_torque, self.max_torque)
        torque_sat = abs(tau_cmd) > self.max_torque
        speed_sat = self._speed_gate(x_act, tau)
        tau = xp.where(speed_sat, 0.0, tau)
        return WheelCommand(tau, tau_cmd, torque_sat, speed_sat, h_dot_cmd)

    def _torque(self, x_act: np.ndarray, held: WheelCommand) -> np.ndarray:
        """Total torque on each wheel: gated motor torque + friction."""
        xp = namespace(x_act, held.torque)
        tau = held.torque
        gate = self._speed_gate(x_act, tau)
        tau = xp.where(gate, 0.0, tau) if any_true(gate, xp) else tau
        if self._friction_on:
            tau = tau + self._friction(x_act)
        return tau

    def state_derivative(self, x_act: np.ndarray, held: WheelCommand) -> np.ndarray:
        return self._torque(x_act, held) / self.wheel_inertia

    def body_torque(self, omega: np.ndarray, x_act: np.ndarray, held: WheelCommand) -> np.ndarray:
        return -(cross(omega, x_act @ self._AI.T) + self._torque(x_act, held) @ self.axes.T)

    def momentum(self, x_act: np.ndarray) -> np.ndarray:
        return x_act @ self._AI.T

    def log(self, x_act: np.ndarray, held: WheelCommand) -> dict[str, np.ndarray]:
        """Wheel speeds, delivered and commanded torques and the limit flags, ``(B, N)``."""
        out = {
            "wheel_speed": x_act,
            "wheel_torque": held.torque,
            "wheel_torque_cmd": held.torque_cmd,
            "torque_saturated": held.torque_saturated,
            "speed_saturated": held.speed_saturated,
            "saturated": held.torque_saturated | held.speed_saturated,
        }
        if self.has_friction:
            out["friction_torque"] = self._friction(x_act)
        return out

    def derived_log(self, log: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``h`` (K, B, 3) [N·m·s] from the logged wheel speeds."""
        return {"h": log["wheel_speed"] @ self._AI.T}


def actuator_kernel(act: object) -> tuple | None:
    """``(code, clip, steering code, steering params, rate limit, S0, C0, steering kernel)`` of
    an actuator with a compiled kernel (:mod:`spacecraft._kernels`), else ``None``: an
    :class:`IdealTorqueActuator` (``clip`` its per-axis limit ``(3,)`` or ``None``) or an
    :class:`SgcmgActuator` with the ideal servo and a steering law with a kernel — a built-in
    law's code, or a user's through the seam :mod:`spacecraft.steering_kernel` (code
    ``STEER_KERNEL`` and the law's numba-compiled kernel; for the others the last entry is
    :func:`spacecraft._kernels.no_steering`, never called). Exact types of the actuators only
    (a subclass may override the formulas)."""
    from ._kernels import ACT_IDEAL, ACT_SGCMG, STEER_KERNEL, STEER_PINV, no_steering

    none = np.zeros((3, 0))
    if type(act) is IdealTorqueActuator:
        clip = None
        if act.max_torque is not None:
            clip = np.broadcast_to(np.asarray(act.max_torque, dtype=np.float64), (3,)).copy()
        return ACT_IDEAL, clip, STEER_PINV, np.zeros(8), math.inf, none, none, no_steering
    if type(act) is SgcmgActuator:
        if act.servo != "ideal" or act._fast is None:
            return None
        S0, C0 = np.ascontiguousarray(act._S0), np.ascontiguousarray(act._C0)
        if act._steer_kernel is not None:
            steer, sp = act._steer_kernel
            return ACT_SGCMG, None, steer, sp, float(act.rate_limit), S0, C0, no_steering
        spec, sp, _ = _user_steering(act)
        if spec is None:
            return None
        return ACT_SGCMG, None, STEER_KERNEL, sp, float(act.rate_limit), S0, C0, spec.steer
    return None


def _user_steering(act: SgcmgActuator) -> tuple:
    """The user steering law's checked kernel (:func:`spacecraft.steering_kernel.resolve`,
    probed at the actuator's initial gimbal angles): ``(kernel, params, reason)``."""
    from .steering_kernel import resolve

    d0 = np.asarray(act.delta0, dtype=np.float64)
    d0 = d0[0] if d0.ndim == 2 else d0  # the first spacecraft's angles probe the kernel
    _, A0 = act.cluster.momentum_and_jacobian(d0)
    return resolve(act.steering, act.cluster, np.asarray(A0), d0)


def steering_reason(act: object) -> str:
    """Why an :class:`SgcmgActuator`'s steering law keeps the Python loop, in words (``""``
    when it has a kernel or the actuator is another)."""
    if type(act) is not SgcmgActuator or act._steer_kernel is not None:
        return ""
    if act.servo != "ideal" or act._fast is None:
        return ""
    return _user_steering(act)[2]
