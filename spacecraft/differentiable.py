"""The closed loop under JAX: compiled, batched, differentiable (``pip install liecontrol[jax]``).

The same numpy-layer formulas that :func:`spacecraft.simulate` checks against — Euler's
equation (:func:`spacecraft.rigid_body.euler_acceleration`), the geometric PD law
(:func:`liecontrol.control.geometric_pd.geometric_pd_torque`, with the large-angle or log error
of :mod:`liecontrol.errors` and the SO(3) logarithm of :mod:`liecontrol.lie.so3`) and the RKMK4
step (:func:`liecontrol.integrators.rk.rkmk4_step_unchecked`) — run here on ``jax.numpy``
arrays: one source per formula, no copy written for JAX. The loop is

    u_k = sat(M(R(t_k), Ω(t_k), ref(t_k))),   held over [t_k, t_k + T) (zero-order hold),
    J Ω̇ + Ω × JΩ = u_k,   Ṙ = R Ω^,   RKMK4 steps of dt, T = n·dt,

written as ``jax.jit(jax.vmap(rollout))`` with ``rollout`` a ``lax.scan`` over the control
periods (an inner ``lax.scan`` over the n steps of one period). Divergence does not raise inside
the compiled program: a member whose state becomes non-finite is flagged (``diverged``).
Everything runs in float64 (``jax.enable_x64`` around each call; JAX's global setting is left
as it is).

Because the loop is a composition of differentiable array functions, ``jax.grad`` gives exact
derivatives of a cost of the trajectory with respect to the controller's gains (reverse mode
through the scan, one backward sweep for all gains); :meth:`JaxClosedLoop.cost` is such a cost
and :func:`tune_gradient` minimises it with Adam (Kingma & Ba, "Adam: a method for stochastic
optimization", ICLR 2015) over a batch of dispersed initial states.

With the SGCMG pyramid the packed state is x = (Ω, δ) and, as in :func:`spacecraft.simulate`,
the actuator's command is recomputed at every integration step from the held torque u_k:
ḣ_cmd = −(Ω × h(δ) + u_k), δ̇ = SR(A(δ), ḣ_cmd) scaled uniformly to the gimbal-rate limit, held
over the step, with the bus torque −(Ω × h(δ) + A(δ) δ̇) in the RKMK4 stages and δ̇ as the
gimbals' rate (ideal servo). The cluster (:mod:`spacecraft.sgcmg`: h, A, bus torque), the
singularity-robust law and the rate limit (:mod:`spacecraft.steering`) are the numpy layer's own
functions, run on ``jax.numpy``.

Supported configurations (others raise ``ValueError`` naming the part): a
:class:`spacecraft.plant.Spacecraft` with a shared inertia ``J`` ``(3, 3)`` or one per member
``(B, 3, 3)``, an :class:`spacecraft.actuators.IdealTorqueActuator` (with or without
``max_torque``), a :class:`spacecraft.actuators.ReactionWheelAssembly` (its own pure command,
speed gate and friction) or an :class:`spacecraft.actuators.SgcmgActuator` with the ideal servo and
:class:`spacecraft.steering.PseudoInverse`, :class:`~spacecraft.steering.SingularityRobust`,
:class:`~spacecraft.steering.GeneralizedSingularityRobust` (its dither at each step's time) or
:class:`~spacecraft.steering.PseudoInverseNullMotion` steering, a
:class:`~spacecraft.disturbances.ConstantTorque` (one for the batch),
:class:`~spacecraft.disturbances.ConstantHarmonicTorque`,
:class:`~spacecraft.environment.GravityGradientTorque`,
:class:`~spacecraft.surface_forces.AerodynamicTorque`,
:class:`~spacecraft.surface_forces.SolarPressureTorque`,
:class:`~spacecraft.surface_forces.ResidualDipoleTorque` or
:class:`~spacecraft.payload.RotatingPayloadTorque` (payloads at a constant rate or on a
:class:`~spacecraft.payload.SpinRamp`) disturbance or a
:class:`~spacecraft.disturbances.SumOfDisturbances` of them (at each RKMK4 stage's time, rate,
and attitude for the attitude-dependent ones, each by its own pure ``torque_at``) or none, no
flexible modes or momentum management; any
controller whose law has an array form (:mod:`liecontrol.control.array_law`: every registered
attitude controller but the OSQP MPC and the small-angle payload PID — the geometric PD with
the trace, log or large-angle error,
the integral, adaptive, prescribed-performance, finite/fixed-time, fault-tolerant, keep-out
and eigenaxis laws, and the chart-based quaternion PD, MRP PD, MRP ADRC and Euler TSM through
their adapters' pure chart conversion — and a user's own), stateful laws carrying their state
(integrators, observers, adaptive estimates, shadow-set and sign memory, a funnel's or a
shaping polynomial's start) from one control sample to the next through the scan; a reference
sampled at the control times before the run, one attitude for the batch (``R_d`` ``(3, 3)``)
or each member its own (``(B, 3, 3)``: the members' samples travel through ``vmap`` with
their states, :attr:`JaxClosedLoop.member_refs`).

Compilation: :meth:`JaxClosedLoop.run` pads the batch to a bucket (:func:`padded_size`: the next
power of two up to 1024, then the next multiple of 1024) so that a Monte Carlo of N members
compiles once per bucket, not once per N; and JAX's persistent compilation cache is switched on
at the first use (:func:`compilation_cache_dir`), so a new process loads a program compiled
before instead of compiling it again.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from liecontrol._array_api import cross
from liecontrol._validation import (
    as_array,
    check_nonnegative,
    check_positive_scalar,
    check_rotation_matrix,
)
from liecontrol.control.array_law import array_law_of
from liecontrol.control.base import AttitudeController, AttitudeReference
from liecontrol.integrators.rk import rkmk4_step_unchecked
from liecontrol.lie import so3

from .actuators import IdealTorqueActuator, ReactionWheelAssembly, SgcmgActuator
from .disturbances import ConstantHarmonicTorque, ConstantTorque, SumOfDisturbances
from .environment import GravityGradientTorque
from .payload import ConstantSpin, RotatingPayloadTorque, SpinRamp
from .plant import Spacecraft
from .rigid_body import euler_acceleration
from .sgcmg import SgcmgPyramid, bus_torque
from .steering import (
    GeneralizedSingularityRobust,
    PseudoInverse,
    PseudoInverseNullMotion,
    SingularityRobust,
    _saturate_unchecked,
)
from .surface_forces import AerodynamicTorque, ResidualDipoleTorque, SolarPressureTorque

__all__ = [
    "JaxClosedLoop",
    "JaxRun",
    "TuningResult",
    "closed_loop",
    "compilation_cache_dir",
    "padded_size",
    "require_jax",
    "simulate_jax",
    "tune_gradient",
]

_PERIOD_RTOL = 1e-9
# the controller's diagnostics in a log row (apart from the actuator's keys of the same name)
_CTRL = "controller/"
_INSTALL = "pip install liecontrol[jax]"
#: environment variable: the persistent compilation cache's directory, or "off"/"0"/"" to opt out
CACHE_ENV = "LIECONTROL_JAX_CACHE"
# JAX caches only programs that took at least this long to compile (its default, 1 s, would
# leave out the closed loop's ≈0.6 s compiles, which are the ones worth keeping)
_CACHE_MIN_COMPILE_S = 0.1
_cache_configured = False


def compilation_cache_dir() -> str | None:
    """The directory of JAX's persistent compilation cache that the JAX route switches on, or
    ``None`` if opted out.

    ``$LIECONTROL_JAX_CACHE`` if set (``off``, ``0``, ``false`` or empty: no cache), else
    ``$XDG_CACHE_HOME/liecontrol/jax`` (``~/.cache/liecontrol/jax`` without ``XDG_CACHE_HOME``).
    A directory the user gave JAX itself (``JAX_COMPILATION_CACHE_DIR`` or
    ``jax.config.update("jax_compilation_cache_dir", ...)``) is left as it is.
    """
    value = os.environ.get(CACHE_ENV)
    if value is not None:
        return None if value.strip().lower() in ("", "0", "off", "false", "no") else value
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "liecontrol", "jax")


def _configure_cache(jax: Any) -> None:
    """Switch JAX's persistent compilation cache on, once per process, unless the user has
    configured one or opted out (:func:`compilation_cache_dir`)."""
    global _cache_configured
    if _cache_configured:
        return
    _cache_configured = True
    if jax.config.jax_compilation_cache_dir is not None:
        return  # the user's own cache (or an earlier configuration) wins
    path = compilation_cache_dir()
    if path is None:
        return
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", _CACHE_MIN_COMPILE_S)


def require_jax() -> Any:
    """The ``jax`` module, or ``ImportError`` saying what is missing and how to install it.
    The first call switches the persistent compilation cache on (:func:`compilation_cache_dir`)."""
    try:
        import jax
        import jax.numpy  # noqa: F401 - the namespace the formulas run in
    except ImportError as exc:
        raise ImportError(
            f"the JAX route of the closed loop needs JAX, which is not installed "
            f"({exc.__class__.__name__}: {exc}); install it with `{_INSTALL}`"
        ) from None
    _configure_cache(jax)
    return jax


def padded_size(batch: int) -> int:
    """The compiled batch size for ``batch`` members: the next power of two up to 1024, then
    the next multiple of 1024 (at most 1/11 padding beyond 1024, and at most twice the work
    below). Members are padded with copies of the first and cut off after the run."""
    batch = int(batch)
    if batch < 1:
        raise ValueError(f"batch: expected at least one member, got {batch}")
    if batch <= 1024:
        return 1 << (batch - 1).bit_length()
    return -(-batch // 1024) * 1024


@dataclass(frozen=True)
class JaxRun:
    """A batched run of :meth:`JaxClosedLoop.run` (NumPy arrays, time-major like
    :class:`spacecraft.simulator.SimulationResult`, whose fields of the same name they equal).

    Attributes:
        t: ``(K,)`` the control sample times t₀ + kT and the final time (K = n_ctrl + 1).
        R: ``(K, B, 3, 3)`` attitudes at those times; omega: ``(K, B, 3)`` body rates.
        u_cmd: ``(K, B, 3)`` the controller's torque at each sample (the last at the final time).
        u: ``(K, B, 3)`` the torque the actuator delivers on the bus at each sample (ideal: the
            command after saturation; SGCMG: −(Ω × h + A δ̇) with the step's gimbal rates;
            wheels: −(Ω × h + A τ) with the gated wheel torques).
        diverged: ``(B,)`` whether the member's state became non-finite.
        diverged_at: ``(B,)`` the first logged time with a non-finite state (NaN if none).
        actuator: the actuator's log ``(K, B, ...)``: ideal with ``max_torque``: ``saturated``
            ``(K, B, 3)``; SGCMG: ``delta``, ``delta_dot`` ``(K, B, 4)``, ``saturated`` ``(K, B)``;
            wheels: the keys of :meth:`ReactionWheelAssembly.log` ``(K, B, N)``.
        controller: the geometric PD's ``Psi`` ``(K, B)``, ``e_R``, ``e_Omega`` ``(K, B, 3)``.
    """

    t: np.ndarray
    R: np.ndarray
    omega: np.ndarray
    u: np.ndarray
    diverged: np.ndarray
    diverged_at: np.ndarray
    u_cmd: np.ndarray | None = None
    actuator: dict = field(default_factory=dict)
    controller: dict = field(default_factory=dict)


def _gain(k: Any, name: str) -> Any:
    """A gain as the law takes it: a float, or a (3, 3) array (JAX arrays pass through)."""
    if isinstance(k, (int, float)) and not isinstance(k, bool):
        return float(k)
    return k


@dataclass(frozen=True)
class JaxClosedLoop:
    """A closed loop prepared for JAX by :func:`closed_loop` (see the module docstring).

    Attributes mirror the validated parts: plant inertia ``J``/``J_inv``, the law's gains
    ``k_R``/``k_Omega`` (floats or 3×3; the law closes over its model inertia and error
    function), ``max_torque`` (``None``, a float or ``(3,)``), the reference samples ``R_d``
    ``(n_ctrl, 3, 3)`` or ``(3, 3)`` when constant (likewise ``omega_d``, ``omega_dot_d``), the
    step ``dt``, ``n_sub`` steps per control period and ``n_ctrl`` periods from ``t0``; with the
    SGCMG cluster its ``cluster``, ``steering`` law, gimbal ``rate_limit`` and ``delta0``
    ``(4,)`` or ``(B, 4)`` (``None`` for the ideal actuator); with reaction wheels the
    :class:`~spacecraft.actuators.ReactionWheelAssembly` as ``wheels`` (its own pure command,
    wheel torques, speed gate and friction run on JAX values) and its initial speeds as
    ``delta0`` ``(N,)`` or ``(B, N)``. The reference arrays hold
    ``n_ctrl + 1`` samples when they vary (the last at the final time). ``J``/``J_inv`` are
    ``(3, 3)`` (one inertia for the batch) or ``(B, 3, 3)`` (each member its own true inertia, as a
    dispersed batch has; the controller keeps its own model). ``checkpoint``: the scan keeps
    only the state at each control sample for the backward sweep and recomputes the steps of a
    period (``jax.checkpoint`` of the period's body): memory ∝ samples instead of steps, for
    about one more forward pass of compute. ``law``: the controller's
    :class:`liecontrol.control.array_law.ArrayLaw` (its pure step and initial state).
    ``disturbance``: the body torque ``(t, R, ω) -> (3,)`` added in every RKMK4 stage at the
    stage's time, attitude and rate (the plant's own ``ConstantTorque``,
    ``ConstantHarmonicTorque``, ``GravityGradientTorque``, the surface-force, dipole and
    rotating-payload torques or their ``SumOfDisturbances``, each by its own formula), or
    ``None``; ``disturbance_source`` the plant's disturbance object (the stage attitudes are
    formed only when it reads them, as the plant does).
    ``member_refs``: the reference gives each member its own samples; ``R_d`` is then
    ``(B, 3, 3)`` if constant, else ``(B, n_ctrl + 1, 3, 3)`` (likewise ``omega_d``,
    ``omega_dot_d``), batches have exactly ``B`` members, and :meth:`rollout` /
    :meth:`cost_terms` take the member's samples as ``ref`` (:meth:`run` and :meth:`cost`
    pass them).
    """

    J: np.ndarray
    J_inv: np.ndarray
    k_R: Any
    k_Omega: Any
    max_torque: Any
    R_d: np.ndarray
    omega_d: np.ndarray
    omega_dot_d: np.ndarray
    dt: float
    n_sub: int
    n_ctrl: int
    t0: float
    cluster: Any = None
    steering: Any = None
    rate_limit: float = math.inf
    delta0: np.ndarray | None = None
    checkpoint: bool = False
    law: Any = None
    disturbance: Any = None
    member_refs: bool = False
    disturbance_source: Any = None
    wheels: Any = None
    _compiled: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def params(self) -> dict[str, Any]:
        """The loop's further differentiable parameters and their values: the law's own
        (:attr:`ArrayLaw.params`, e.g. an observer's bandwidth) and, with the SGCMG cluster,
        the steering law's (``"steering.<field>"``: :class:`SingularityRobust`'s ``lambda0``,
        ``mu``; :class:`PseudoInverseNullMotion`'s ``k``). :meth:`rollout`, :meth:`run` and
        :meth:`cost` take values for any of them (by name); :func:`tune_requirements` tunes
        them."""
        out = {k: v for k, v in self.law.params.items()}
        if self.steering is not None:
            for f in dataclasses.fields(self.steering):
                if f.name in _STEERING_PARAMS.get(type(self.steering), ()):
                    out[f"steering.{f.name}"] = float(getattr(self.steering, f.name))
        return out

    def _split(self, params: Mapping[str, Any] | None) -> tuple[dict[str, Any], Any]:
        """``(law params, steering law)`` with the values in ``params`` (names of
        :attr:`params`; ``ValueError`` naming an unknown one)."""
        if not params:
            return {}, self.steering
        known = self.params
        for name in params:
            if name not in known:
                raise ValueError(
                    f"params: {name!r} is not a parameter of this loop (it has {sorted(known)})"
                )
        steer = {k[len("steering.") :]: v for k, v in params.items() if k.startswith("steering.")}
        law = self.steering
        if steer:
            # a copy with traced values: the steering law's own steer() formula, unvalidated
            # (its __post_init__ checks floats, and a tracer is not one)
            law = copy.copy(self.steering)
            for k, v in steer.items():
                object.__setattr__(law, k, v)
        return {k: v for k, v in params.items() if not k.startswith("steering.")}, law

    @property
    def n_x(self) -> int:
        """Length of the packed state x = (Ω, δ): 3, or 7 with the SGCMG cluster."""
        return 3 if self.cluster is None else 7

    @property
    def control_period(self) -> float:
        return self.n_sub * self.dt

    @property
    def times(self) -> np.ndarray:
        """``(n_ctrl + 1,)`` the logged times (as :func:`spacecraft.simulate` computes them)."""
        return self.t0 + np.arange(self.n_ctrl + 1) * self.n_sub * self.dt

    def _member_reference(self, ref: tuple | None) -> tuple[tuple, bool]:
        """``((R_d, ω_d, ω̇_d), varying)`` one member flies: the loop's, or its own ``ref``."""
        jnp = require_jax().numpy
        if self.member_refs:
            if ref is None:
                raise ValueError(
                    "ref: this loop's reference gives each member its own samples; pass the "
                    "member's (R_d, omega_d, omega_dot_d) (run and cost do)"
                )
            refs = tuple(jnp.asarray(a) for a in ref)
            return refs, refs[0].ndim == 3  # the member's (n, 3, 3) samples, or one (3, 3)
        refs = tuple(jnp.asarray(a) for a in (self.R_d, self.omega_d, self.omega_dot_d))
        return refs, self.R_d.ndim == 3

    def member_references(self, B: int) -> tuple[tuple | None, int | None]:
        """``(references, vmap axis)`` for a batch of ``B``: each member's samples and axis 0
        when the reference differs between members (``B`` must be its member count), else
        ``(None, None)``."""
        if not self.member_refs:
            return None, None
        if self.R_d.shape[0] != B:
            raise ValueError(
                f"R0: the reference gives {self.R_d.shape[0]} members their own samples, got {B} "
                "initial states"
            )
        return (self.R_d, self.omega_d, self.omega_dot_d), 0

    # -- the pure program -------------------------------------------------------------------

    def rollout(
        self, k_R: Any, k_Omega: Any, R0: Any, x0: Any, J: Any = None, J_inv: Any = None,
        params: dict[str, Any] | None = None, cs0: tuple | None = None, ref: tuple | None = None,
    ) -> dict[str, Any]:  # fmt: skip
        """One spacecraft from ``R0`` ``(3, 3)`` and the packed state ``x0`` ``(n_x,)`` = (Ω₀, δ₀)
        with the plant inertia ``J``, ``J_inv`` ``(3, 3)`` (default the loop's shared one):
        the log at the K = n_ctrl + 1 samples as a dict of arrays with a leading ``K`` axis —
        ``R``, ``x``, ``u_cmd``, ``u``, ``Psi``, ``e_R``, ``e_Omega``, and the actuator's
        ``delta_dot``, ``saturated`` (SGCMG) or ``held`` (ideal). ``params``: values for (some
        of) the law's further parameters (:attr:`ArrayLaw.params`, default the law's own);
        ``cs0``: this spacecraft's initial law state (default :attr:`ArrayLaw.state0`);
        ``ref``: this spacecraft's reference samples ``(R_d, ω_d, ω̇_d)`` ``(n_ctrl + 1, ...)``
        when the loop's reference differs between members (:attr:`member_refs`; required
        then). Pure JAX (call under ``jax.enable_x64``): ``jit``, ``vmap`` and ``grad``
        apply."""
        jax = require_jax()
        jnp = jax.numpy
        lax = jax.lax
        J = jnp.asarray(self.J if J is None else J)
        J_inv = jnp.asarray(self.J_inv if J_inv is None else J_inv)
        if J.ndim != 2:
            raise ValueError("J: rollout runs one member; pass its (3, 3) inertia")
        dt, n_sub = self.dt, self.n_sub
        limit = None if self.max_torque is None else jnp.asarray(self.max_torque)
        refs, varying = self._member_reference(ref)
        law_params, law = self._split(params)
        cluster, rate_limit = self.cluster, self.rate_limit
        wheels = self.wheels

        def command(u_cmd: Any, x: Any, t: Any) -> tuple:
            """The actuator's command held over the step from x at time t (simulate's
            per-step call)."""
            if wheels is not None:  # the assembly's own pure command (a WheelCommand)
                return (wheels.command_unchecked(u_cmd, x[:3], x[3:], t),)
            if cluster is None:
                return (u_cmd if limit is None else jnp.clip(u_cmd, -limit, limit),)
            w, d = x[:3], x[3:]
            h, A = cluster._momentum_and_jacobian(d)
            h_dot_cmd = -(cross(w, h) + u_cmd)
            return _saturate_unchecked(law.steer(A, h_dot_cmd, d, t, cluster), rate_limit)

        def torque(x: Any, held: tuple) -> Any:
            if wheels is not None:
                return wheels.body_torque(x[:3], x[3:], held[0])
            if cluster is None:
                return held[0]
            h, A = cluster._momentum_and_jacobian(x[3:])
            return bus_torque(h, A, held[0], x[:3])

        ctrl_law = self.law
        T = self.control_period

        def sample(R: Any, x: Any, cs: tuple, ref: tuple, t: Any) -> tuple[dict, Any, tuple]:
            """The controller at the sample time ``t`` (its state ``cs`` carried from the
            previous sample), and the log row (with the first step's command)."""
            # the controller's own pure law (liecontrol.control.array_law)
            u_cmd, cs, diag = ctrl_law.call(k_R, k_Omega, cs, R, x[:3], *ref, T, law_params, t)
            held = command(u_cmd, x, t)
            row = {"R": R, "x": x, "u_cmd": u_cmd, "u": torque(x, held),
                   **{_CTRL + k: v for k, v in diag.items()}}  # fmt: skip
            if wheels is not None:
                cmd = held[0]
                row.update(wheel_torque=cmd.torque, wheel_torque_cmd=cmd.torque_cmd,
                           torque_saturated=cmd.torque_saturated,
                           speed_saturated=cmd.speed_saturated)  # fmt: skip
                if wheels.has_friction:
                    row["friction_torque"] = wheels._friction(x[3:])
            elif cluster is None:
                row["held"] = held[0]
            else:
                row["delta_dot"], row["saturated"] = held
            return row, u_cmd, cs

        dist = self.disturbance
        dist_reads_attitude = _reads_attitude(self.disturbance_source)
        t0 = self.t0

        def period(carry: tuple, xs: tuple) -> tuple:
            R, x, cs = carry
            k, ref = xs
            row, u_cmd, cs = sample(R, x, cs, ref if varying else refs, t0 + (k * n_sub) * dt)

            def step(c: tuple, j: Any) -> tuple:
                # the step's time as simulate computes it, t₀ + i·dt for the i-th step
                t = t0 + (k * n_sub + j) * dt
                held = command(u_cmd, c[1], t)

                def field_(t: Any, RR: Any, xx: Any) -> tuple[Any, Any]:
                    tau = torque(xx, held)
                    if dist is not None:
                        tau = tau + dist(t, RR, xx[:3])
                    acc = euler_acceleration(J, J_inv, xx[:3], tau)
                    if wheels is not None:
                        rates = wheels.state_derivative(xx[3:], held[0])
                        return xx[:3], jnp.concatenate((acc, rates))
                    return xx[:3], acc if cluster is None else jnp.concatenate((acc, held[0]))

                return rkmk4_step_unchecked(
                    field_, t, c[0], c[1], dt, stage_attitude=dist_reads_attitude
                ), None

            # the sample's own step recomputes its command: one extra steering call per period
            # keeps the scan body free of a first-step special case
            (R1, x1), _ = lax.scan(step, (R, x), jnp.arange(n_sub))
            return (R1, x1, cs), row

        if self.checkpoint:
            period = jax.checkpoint(period)
        scanned = (jnp.arange(self.n_ctrl), tuple(a[:-1] for a in refs) if varying else None)
        cs0 = tuple(jnp.asarray(a) for a in (ctrl_law.state0 if cs0 is None else cs0))
        (Rn, xn, csn), rows = lax.scan(period, (R0, x0, cs0), scanned, length=self.n_ctrl)
        ref_n = tuple(a[-1] for a in refs) if varying else refs
        last, _, _ = sample(Rn, xn, csn, ref_n, t0 + (self.n_ctrl * n_sub) * dt)
        return {k: jnp.concatenate((v, last[k][None]), axis=0) for k, v in rows.items()}

    def inertias(self, B: int) -> tuple[np.ndarray, np.ndarray]:
        """``(J, J_inv)`` of the ``B`` members, ``(B, 3, 3)`` each (the shared inertia repeated,
        or the per-member ones, whose count must then be ``B``)."""
        if self.J.ndim == 3:
            if self.J.shape[0] != B:
                raise ValueError(
                    f"R0: the plant has {self.J.shape[0]} per-spacecraft inertias, got {B} "
                    "initial states"
                )
            return self.J, self.J_inv
        return (np.broadcast_to(self.J, (B, 3, 3)), np.broadcast_to(self.J_inv, (B, 3, 3)))

    @property
    def n_act(self) -> int:
        """Length of the actuator's state: 4 gimbal angles, N wheel speeds, or 0 (ideal)."""
        if self.wheels is not None:
            return int(self.wheels.n_wheels)
        return 0 if self.cluster is None else 4

    def _pack(self, omega0: Any, delta0: Any = None) -> Any:
        """``(B, n_x)``: the body rates ``(B, 3)`` and the actuator's initial state
        (``delta0``: gimbal angles or wheel speeds, by default the actuator's)."""
        if self.n_act == 0:
            return omega0
        xp = require_jax().numpy if not isinstance(omega0, np.ndarray) else np
        d0 = self.delta0 if delta0 is None else delta0
        d0 = xp.broadcast_to(xp.asarray(d0), omega0.shape[:-1] + (self.n_act,))
        return xp.concatenate((omega0, d0), axis=-1)

    def cost_terms(
        self, k_R: Any, k_Omega: Any, R0: Any, x0: Any, J: Any = None, J_inv: Any = None,
        params: Mapping[str, Any] | None = None, cs0: tuple | None = None, ref: tuple | None = None,
    ) -> dict[str, Any]:  # fmt: skip
        """Per-member terms (pure JAX) on the control grid (rectangle rule, step T) from ``R0``
        and the packed state ``x0`` (:meth:`rollout`): ``angle`` = Σ θ_k² T ≈ ∫θ² dt [rad²·s], θ
        the angle of R_dᵀR; ``effort`` = Σ ‖u_k‖² T [(N·m)²·s], u the bus torque;
        ``overshoot`` = Σ max(0, −φ_k·n₀)² T [rad²·s], the error's rotation vector
        φ = log(R_dᵀR)^∨ past the start's error axis n₀ = φ₀/‖φ₀‖ (zero for a start at R_d)."""
        jax = require_jax()
        jnp = jax.numpy
        out = self.rollout(k_R, k_Omega, R0, x0, J, J_inv, params, cs0, ref)
        Rs, us = out["R"][:-1], out["u"][:-1]
        (R_d, _, _), varying = self._member_reference(ref)
        R_d = R_d[:-1] if varying else R_d
        Rt = jnp.swapaxes(R_d, -1, -2) @ Rs
        phi, theta = so3._log_angle_unchecked(Rt)
        n0 = phi[0] / jnp.maximum(theta[0], 1e-12)
        past = jnp.maximum(-(phi @ n0), 0.0)
        T = self.control_period
        return {
            "angle": jnp.sum(theta * theta) * T,
            "effort": jnp.sum(us * us) * T,
            "overshoot": jnp.sum(past * past) * T,
        }

    def cost(
        self,
        k_R: Any,
        k_Omega: Any,
        R0: Any,
        omega0: Any,
        effort_weight: float = 0.0,
        overshoot_weight: float = 0.0,
        params: Mapping[str, Any] | None = None,
    ) -> Any:
        """Mean over the batch ``R0`` ``(B, 3, 3)``, ``omega0`` ``(B, 3)`` of
        ``angle + effort_weight·effort + overshoot_weight·overshoot`` (:meth:`cost_terms`);
        pure JAX, differentiable in the gains and in ``params`` (:attr:`params`)."""
        jax = require_jax()
        x0 = self._pack(omega0)
        J, J_inv = self.inertias(R0.shape[0])
        refs, ax = self.member_references(R0.shape[0])
        terms = jax.vmap(self.cost_terms, in_axes=(None, None, 0, 0, 0, 0, None, 0, ax))(
            k_R, k_Omega, R0, x0, J, J_inv, params, self.law.initial_states(R0.shape[0]), refs
        )
        weights = {"angle": 1.0, "effort": effort_weight, "overshoot": overshoot_weight}
        return sum(weights[k] * terms[k].mean() for k in terms)

    # -- compiled entry points ----------------------------------------------------------------

    def _jit(self, name: str, build: Callable[[], Callable]) -> Callable:
        fn = self._compiled.get(name)
        if fn is None:
            fn = self._compiled[name] = build()
        return fn

    def run(
        self, R0: object, omega0: object | None = None, k_R: Any = None, k_Omega: Any = None,
        pad: bool = True, delta0: object | None = None, params: Mapping[str, Any] | None = None,
    ) -> JaxRun:  # fmt: skip
        """The batch of initial states ``R0`` ``(B, 3, 3)``, ``omega0`` ``(B, 3)`` (default zero;
        the gimbals start at ``delta0`` ``(4,)`` or ``(B, 4)``, default the actuator's) through
        ``jit(vmap(rollout))``; gains
        default to the controller's. With ``pad`` the batch is padded to
        :func:`padded_size` ``(B)`` members (copies of the first, cut off after the run), so a
        new B in the same bucket reuses the compiled program; ``pad=False`` compiles for B
        itself. ``params``: values for (some of) :attr:`params` (default the loop's own).
        Compiled once per (padded) batch size, gain shape and set of ``params`` names."""
        jax = require_jax()
        R0, w0 = _initial(R0, omega0)
        B = R0.shape[0]
        d0 = None
        n_act = self.n_act
        if n_act:
            d0 = self.delta0 if delta0 is None else as_array(delta0, "delta0", (n_act,))
            if d0.ndim not in (1, 2) or (d0.ndim == 2 and d0.shape[0] != B):
                raise ValueError(
                    f"delta0: expected shape ({n_act},) or ({B}, {n_act}) for the {B} spacecraft "
                    f"of R0, got {d0.shape}"
                )
        x0 = self._pack(w0, d0)
        J, J_inv = self.inertias(B)
        cs0 = self.law.initial_states(B)
        refs, ax = self.member_references(B)
        n = padded_size(B) if pad else B
        if n > B:
            R0, x0, J, J_inv, *cs0 = (
                np.concatenate((a, np.broadcast_to(a[:1], (n - B,) + a.shape[1:])))
                for a in (R0, x0, J, J_inv, *cs0, *(refs or ()))
            )
            if refs is not None:
                cs0, refs = cs0[: len(cs0) - 3], tuple(cs0[len(cs0) - 3 :])
            cs0 = tuple(cs0)
        k_R = self.k_R if k_R is None else k_R
        k_Omega = self.k_Omega if k_Omega is None else k_Omega
        with jax.enable_x64(True):
            fn = self._jit(
                "run",
                lambda: jax.jit(
                    jax.vmap(self.rollout, in_axes=(None, None, 0, 0, 0, 0, None, 0, ax))
                ),
            )
            p = _check_params(params)
            out = {
                k: np.moveaxis(np.asarray(v)[:B], 0, 1)
                for k, v in fn(k_R, k_Omega, R0, x0, J, J_inv, p, cs0, refs).items()
            }
        Rs, xs = out["R"], out["x"]
        bad = ~(np.isfinite(Rs).all(axis=(2, 3)) & np.isfinite(xs).all(axis=2))
        diverged = bad.any(axis=0)
        t = self.times
        at = np.where(diverged, t[np.argmax(bad, axis=0)], np.nan)
        if self.wheels is not None:  # the keys and order of ReactionWheelAssembly.log
            act = {"wheel_speed": xs[..., 3:]}
            for k in ("wheel_torque", "wheel_torque_cmd", "torque_saturated", "speed_saturated"):
                act[k] = out[k]
            act["saturated"] = out["torque_saturated"] | out["speed_saturated"]
            if "friction_torque" in out:
                act["friction_torque"] = out["friction_torque"]
        elif self.cluster is not None:
            act = {"delta": xs[..., 3:], "delta_dot": out["delta_dot"],
                   "saturated": out["saturated"]}  # fmt: skip
        elif self.max_torque is not None:
            act = {"saturated": np.abs(out["held"]) >= self.max_torque}
        else:
            act = {}
        ctrl = {k[len(_CTRL) :]: v for k, v in out.items() if k.startswith(_CTRL)}
        return JaxRun(t, Rs, xs[..., :3], out["u"], diverged, at, out["u_cmd"], act, ctrl)

    def value_and_grad(
        self, k_R: Any, k_Omega: Any, R0: object, omega0: object | None = None,
        effort_weight: float = 0.0, overshoot_weight: float = 0.0,
        params: Mapping[str, Any] | None = None,
    ) -> tuple[float, np.ndarray, np.ndarray]:  # fmt: skip
        """``(cost, ∂cost/∂k_R, ∂cost/∂k_Ω)`` of :meth:`cost` (reverse mode, compiled), at
        the values ``params`` of :attr:`params` (default the loop's). For the derivatives in
        ``params`` as well, differentiate :meth:`cost` with ``jax.grad`` (it is pure JAX).
        Raises ``FloatingPointError`` naming the cost term whose gradient is non-finite."""
        jax = require_jax()
        R0, w0 = _initial(R0, omega0)
        kR, kW = np.asarray(k_R, dtype=np.float64), np.asarray(k_Omega, dtype=np.float64)
        x0 = self._pack(w0)
        with jax.enable_x64(True):
            fn = self._jit(
                "value_and_grad",
                lambda: jax.jit(jax.value_and_grad(self.cost, argnums=(0, 1))),
            )
            p = _check_params(params)
            value, (gR, gW) = fn(kR, kW, R0, w0, effort_weight, overshoot_weight, p)
            value, gR, gW = float(value), np.asarray(gR), np.asarray(gW)
            if not (math.isfinite(value) and np.isfinite(gR).all() and np.isfinite(gW).all()):
                self._name_bad_term(kR, kW, R0, x0, p)
        return value, gR, gW

    def _name_bad_term(self, kR: Any, kW: Any, R0: Any, x0: Any, p: Any = None) -> None:
        jax = require_jax()
        for term in ("angle", "effort", "overshoot"):

            def one(a: Any, b: Any, term: str = term) -> Any:
                J, J_inv = self.inertias(R0.shape[0])
                refs, ax = self.member_references(R0.shape[0])
                per = jax.vmap(self.cost_terms, in_axes=(None, None, 0, 0, 0, 0, None, 0, ax))(
                    a, b, R0, x0, J, J_inv, p, self.law.initial_states(R0.shape[0]), refs
                )
                return per[term].mean()

            v, g = jax.value_and_grad(one, argnums=(0, 1))(kR, kW)
            if not (np.isfinite(float(v)) and all(np.isfinite(np.asarray(x)).all() for x in g)):
                raise FloatingPointError(
                    f"cost: the {term!r} term or its gradient is not finite at k_R = {kR}, "
                    f"k_Omega = {kW} (diverging members, or gains out of range)"
                )
        raise FloatingPointError(f"cost: not finite at k_R = {kR}, k_Omega = {kW}")


def _check_params(params: Mapping[str, Any] | None) -> dict[str, np.ndarray] | None:
    """``params`` as float arrays (``ValueError`` naming a non-finite or non-real entry)."""
    if params is None:
        return None
    if not isinstance(params, Mapping):
        raise ValueError(f"params: expected a mapping of names to values, got {params!r}")
    out = {}
    for k, v in params.items():
        if hasattr(v, "aval"):  # a JAX array or tracer: the caller's own
            out[k] = v
            continue
        try:
            a = np.asarray(v, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"params[{k!r}]: expected real values, got {v!r}") from None
        if not np.isfinite(a).all():
            raise ValueError(f"params[{k!r}]: expected finite values, got {v!r}")
        out[k] = a
    return out


#: The steering laws' fields that are differentiable parameters of the loop (floats in the
#: steering formula; the others are switches or tolerances).
_STEERING_PARAMS: dict[type, tuple[str, ...]] = {
    PseudoInverse: (),
    SingularityRobust: ("lambda0", "mu"),
    GeneralizedSingularityRobust: ("lambda0", "mu", "epsilon0"),
    PseudoInverseNullMotion: ("k",),
}


#: the attitude-dependent sources the route flies, each by its own pure ``torque_at(t, R)``
_ATTITUDE_SOURCES = (
    GravityGradientTorque, AerodynamicTorque, SolarPressureTorque, ResidualDipoleTorque
)  # fmt: skip


def _disturbance(dist: Any) -> Callable[[Any, Any, Any], Any] | None:
    """The plant's disturbance as ``(t, R, ω) -> (3,)`` on JAX values (its own formula; ``R``
    the stage's attitude, ``None`` when no source reads it; ``ω`` the stage's rate)."""
    if dist is None:
        return None
    if type(dist) is ConstantTorque:
        torque = np.array(dist.torque)
        return lambda t, R, w: torque
    if type(dist) is ConstantHarmonicTorque:
        return lambda t, R, w: dist.torque_at(t)
    if type(dist) in _ATTITUDE_SOURCES:
        return lambda t, R, w: dist.torque_at(t, R)
    if type(dist) is RotatingPayloadTorque:
        return dist.torque_at
    parts = [_disturbance(s) for _, s in dist._items]  # SumOfDisturbances (checked before)

    def total(t: Any, R: Any, w: Any) -> Any:
        out = parts[0](t, R, w)
        for p in parts[1:]:
            out = out + p(t, R, w)
        return out

    return total


def _reads_attitude(dist: Any) -> bool:
    """Whether the disturbance reads the stage attitude (the integrator forms it then)."""
    if dist is None or type(dist) in (
        ConstantTorque,
        ConstantHarmonicTorque,
        RotatingPayloadTorque,
    ):
        return False
    if type(dist) is SumOfDisturbances:
        return any(_reads_attitude(s) for _, s in dist._items)
    return True


def _check_disturbance(dist: Any, name: str = "plant.disturbance") -> None:
    """``ValueError`` naming a disturbance the JAX route does not fly."""
    if dist is None or type(dist) is ConstantHarmonicTorque or type(dist) in _ATTITUDE_SOURCES:
        return
    if type(dist) is ConstantTorque and dist.torque.ndim == 1:
        return
    if type(dist) is RotatingPayloadTorque:
        for i, p in enumerate(dist.payloads):
            if type(p._profile) not in (ConstantSpin, SpinRamp):
                raise ValueError(
                    f"{name}.payloads[{i}]: the JAX route flies the spin profiles ConstantSpin "
                    f"and SpinRamp, got {type(p._profile).__name__}; run spacecraft.simulate "
                    "with backend='numba'"
                )
        return
    if type(dist) is SumOfDisturbances:
        for k, s in dist._items:
            _check_disturbance(s, f"{name}.sources[{k!r}]")
        return
    raise ValueError(
        f"{name}: the JAX route flies ConstantTorque (one torque for the batch), "
        f"ConstantHarmonicTorque, GravityGradientTorque, AerodynamicTorque, SolarPressureTorque, "
        f"ResidualDipoleTorque, RotatingPayloadTorque and their SumOfDisturbances, got "
        f"{type(dist).__name__}; run spacecraft.simulate with backend='numba'"
    )


def _initial(R0: object, omega0: object | None) -> tuple[np.ndarray, np.ndarray]:
    R0 = check_rotation_matrix(R0, "R0")
    if R0.ndim == 2:
        R0 = R0[None]
    if R0.ndim != 3:
        raise ValueError(f"R0: expected shape (3, 3) or (B, 3, 3), got {R0.shape}")
    w0 = np.zeros((R0.shape[0], 3)) if omega0 is None else as_array(omega0, "omega0", (3,))
    w0 = np.broadcast_to(w0, (R0.shape[0], 3)).astype(np.float64)
    return np.ascontiguousarray(R0, dtype=np.float64), w0


def _reference_samples(
    reference: Callable[[float], AttitudeReference], times: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """The reference at the control times: ``(R_d, ω_d, ω̇_d, per_member)`` — one sample for
    the batch if constant (``(3, 3)``, ``(3,)``), the samples stacked ``(n, ...)`` if they vary
    in time, or, when a sample gives each member its own (``(B, 3, 3)``, ``(B, 3)``), the
    members' own: ``(B, 3, 3)`` if constant, else every member's samples ``(B, n, ...)``, and
    ``per_member`` set."""
    samples = [reference(float(t)) for t in times]
    out = []
    for name, nd in (("R_d", 2), ("omega_d", 1), ("omega_dot_d", 1)):
        parts = [np.asarray(getattr(s, name), dtype=np.float64) for s in samples]
        for a in parts:
            if a.ndim not in (nd, nd + 1) or a.shape[a.ndim - nd :] != (3,) * nd:
                raise ValueError(
                    f"reference: {name} must have shape {(3,) * nd} or (B, {'3, ' * (nd - 1)}3), "
                    f"got {a.shape}"
                )
        out.append(parts)
    # a member axis: R_d (B, 3, 3), omega_d or omega_dot_d (B, 3)
    sizes = {a.shape[0] for parts, nd in zip(out, (2, 1, 1), strict=True) for a in parts
             if a.ndim == nd + 1}  # fmt: skip
    if not sizes:
        stacked = [np.stack(parts) for parts in out]
        if all((a == a[0]).all() for a in stacked):
            return stacked[0][0], stacked[1][0], stacked[2][0], False
        return stacked[0], stacked[1], stacked[2], False
    if len(sizes) > 1:
        raise ValueError(f"reference: the samples' batch sizes differ ({sorted(sizes)})")
    B = sizes.pop()
    member = []
    for parts, nd in zip(out, (2, 1, 1), strict=True):
        member.append(np.stack([np.broadcast_to(x, (B,) + (3,) * nd) for x in parts]))
    if all((a == a[0]).all() for a in member):  # constant: (B, ...) (no copy per sample)
        return member[0][0], member[1][0], member[2][0], True
    # (B, n, ...): each member's samples, the axis vmap maps over first
    R_d, w_d, dw_d = (np.ascontiguousarray(np.moveaxis(a, 1, 0)) for a in member)
    return R_d, w_d, dw_d, True


def closed_loop(
    plant: Spacecraft,
    controller: AttitudeController,
    reference: Callable[[float], AttitudeReference],
    t_final: float,
    dt: float,
    control_period: float | None = None,
    t0: float = 0.0,
    checkpoint: bool = False,
) -> JaxClosedLoop:
    """Prepare ``plant`` + ``controller`` + ``reference`` for the JAX route (arguments as in
    :func:`spacecraft.simulate`; ``t_final − t0`` a multiple of ``control_period``). A plant
    with per-spacecraft inertias ``(B, 3, 3)`` runs batches of exactly ``B`` members.
    ``checkpoint``: recompute each control period's steps in the backward sweep instead of
    storing them (:class:`JaxClosedLoop`).

    Raises ``ImportError`` (naming ``liecontrol[jax]``) without JAX and ``ValueError`` naming
    the part for a configuration the route does not support (module docstring).
    """
    require_jax()
    if not isinstance(plant, Spacecraft):
        raise ValueError(f"plant: expected a Spacecraft, got {type(plant).__name__}")
    act = plant.actuator
    _check_actuator(act)
    dist = plant.disturbance
    _check_disturbance(dist)
    for part in ("modes", "momentum_management"):
        if getattr(plant, part) is not None:
            raise ValueError(
                f"plant.{part}: not supported by the JAX route (got "
                f"{type(getattr(plant, part)).__name__}); run spacecraft.simulate with "
                "backend='numba'"
            )
    law = array_law_of(controller)
    if not callable(reference):
        raise ValueError("reference: must be callable as reference(t) -> AttitudeReference")
    dt = check_positive_scalar(dt, "dt")
    period = (
        dt if control_period is None else check_positive_scalar(control_period, "control_period")
    )
    n_sub = round(period / dt)
    if n_sub < 1 or abs(period / dt - n_sub) > _PERIOD_RTOL * period / dt:
        raise ValueError(
            f"control_period: must be a positive integer multiple of dt = {dt!r}, got {period!r}"
        )
    t0 = float(t0)
    span = check_positive_scalar(float(t_final) - t0, "t_final")
    n_ctrl = round(span / (n_sub * dt))
    if n_ctrl < 1 or abs(span - n_ctrl * n_sub * dt) > _PERIOD_RTOL * span:
        raise ValueError(
            f"t_final: t_final − t0 = {span!r} must be a positive multiple of the control "
            f"period {n_sub * dt!r} on the JAX route"
        )
    times = t0 + np.arange(n_ctrl + 1) * n_sub * dt
    R_d, w_d, dw_d, per_member = _reference_samples(reference, times)
    if per_member and plant.body.J.ndim == 3 and plant.body.J.shape[0] != R_d.shape[0]:
        raise ValueError(
            f"reference: gives {R_d.shape[0]} members their own samples, the plant has "
            f"{plant.body.J.shape[0]} per-spacecraft inertias"
        )
    sgcmg = isinstance(act, SgcmgActuator)
    wheels = act if type(act) is ReactionWheelAssembly else None
    mt = getattr(act, "max_torque", None) if wheels is None else None  # wheels: per wheel
    delta0 = None
    if sgcmg:
        delta0 = np.array(act.delta0)
    elif wheels is not None:
        delta0 = np.array(wheels.initial_speeds)
    return JaxClosedLoop(
        J=np.array(plant.body.J), J_inv=np.array(plant.body.J_inv),
        k_R=_gain(law.k_R, "k_R"), k_Omega=_gain(law.k_Omega, "k_Omega"),
        max_torque=None if mt is None else np.asarray(mt, dtype=float),
        R_d=R_d, omega_d=w_d, omega_dot_d=dw_d, dt=dt, n_sub=n_sub, n_ctrl=n_ctrl, t0=t0,
        cluster=act.cluster if sgcmg else None, steering=act.steering if sgcmg else None,
        rate_limit=act.rate_limit if sgcmg else math.inf,
        delta0=delta0, checkpoint=bool(checkpoint),
        law=law, disturbance=_disturbance(dist), member_refs=per_member,
        disturbance_source=dist, wheels=wheels,
    )  # fmt: skip


def _check_actuator(act: object) -> None:
    """``ValueError`` naming the part of an actuator the JAX route does not run."""
    if type(act) in (IdealTorqueActuator, ReactionWheelAssembly):
        return
    if type(act) is not SgcmgActuator:
        raise ValueError(
            f"plant.actuator: the JAX route supports IdealTorqueActuator, SgcmgActuator and "
            f"ReactionWheelAssembly, got {type(act).__name__}; run spacecraft.simulate with "
            "backend='numba'"
        )
    if act.servo != "ideal":
        raise ValueError(
            f"plant.actuator.servo: the JAX route supports the ideal gimbal servo only, got "
            f"{act.servo!r}; run spacecraft.simulate with backend='numba'"
        )
    if type(act.steering) not in _STEERING_PARAMS:
        raise ValueError(
            f"plant.actuator.steering: the JAX route supports PseudoInverse, SingularityRobust, "
            f"GeneralizedSingularityRobust and PseudoInverseNullMotion steering, got "
            f"{type(act.steering).__name__}; run "
            "spacecraft.simulate with backend='numba'"
        )
    if type(act.cluster) is not SgcmgPyramid:
        raise ValueError(
            f"plant.actuator.cluster: the JAX route runs SgcmgPyramid's own formulas, got "
            f"{type(act.cluster).__name__}; run spacecraft.simulate with backend='numba'"
        )


@dataclass(frozen=True)
class TuningResult:
    """Outcome of :func:`tune_gradient`.

    Attributes:
        k_R, k_Omega: the tuned scalar gains.
        history: ``(steps + 1, 3)`` rows ``(k_R, k_Omega, cost)`` from the start (the last row
            the returned gains).
    """

    k_R: float
    k_Omega: float
    history: np.ndarray


def tune_gradient(
    loop: JaxClosedLoop,
    R0: object,
    omega0: object | None = None,
    k_R: float | None = None,
    k_Omega: float | None = None,
    steps: int = 20,
    learning_rate: float = 0.1,
    effort_weight: float = 0.0,
    overshoot_weight: float = 0.0,
) -> TuningResult:
    """Tune scalar PD gains by gradient descent on :meth:`JaxClosedLoop.cost` over the batch of
    dispersed initial states ``R0`` ``(B, 3, 3)``, ``omega0`` ``(B, 3)``.

    Adam (Kingma & Ba, ICLR 2015; β₁ = 0.9, β₂ = 0.999, ε = 1e-8) on the log-gains
    ``(log k_R, log k_Ω)`` (positive gains, steps relative to their size: ``learning_rate``
    0.1 moves a gain by ≈10 % per step). The cost should carry the requirements, not only the
    error: with ``overshoot_weight = 0`` minimising ∫θ² dt alone trades damping for speed
    (the issue's prototype halved ∫θ² while cutting ζ to 0.33). Returns the gains of the
    lowest cost seen (the last step need not be the best) and the history. Check the result on
    held-out initial states: the tuned gains are only as good as the batch is representative.
    """
    if steps < 1 or isinstance(steps, bool) or not isinstance(steps, int):
        raise ValueError(f"steps: expected a positive int, got {steps!r}")
    learning_rate = check_positive_scalar(learning_rate, "learning_rate")
    effort_weight = float(check_nonnegative(effort_weight, "effort_weight"))
    overshoot_weight = float(check_nonnegative(overshoot_weight, "overshoot_weight"))
    x = np.log([
        check_positive_scalar(loop.k_R if k_R is None else k_R, "k_R"),
        check_positive_scalar(loop.k_Omega if k_Omega is None else k_Omega, "k_Omega"),
    ])  # fmt: skip
    m = np.zeros(2)
    v = np.zeros(2)
    b1, b2, eps = 0.9, 0.999, 1e-8
    rows = []
    for i in range(steps + 1):
        kR, kW = np.exp(x)
        value, gR, gW = loop.value_and_grad(
            kR, kW, R0, omega0, effort_weight=effort_weight, overshoot_weight=overshoot_weight
        )
        rows.append((kR, kW, value))
        if i == steps:
            break
        g = np.array([float(gR), float(gW)]) * np.exp(x)  # chain rule to the log-gains
        m = b1 * m + (1.0 - b1) * g
        v = b2 * v + (1.0 - b2) * g * g
        x = x - learning_rate * (m / (1.0 - b1 ** (i + 1))) / (
            np.sqrt(v / (1.0 - b2 ** (i + 1))) + eps
        )
    history = np.array(rows)
    best = int(np.argmin(history[:, 2]))
    return TuningResult(float(history[best, 0]), float(history[best, 1]), history)


def simulate_jax(
    plant: Spacecraft,
    controller: AttitudeController,
    reference: Callable[[float], AttitudeReference],
    initial_state: Any,
    t_final: float,
    dt: float,
    control_period: float | None = None,
    log_every: int = 1,
    t0: float = 0.0,
    **options: Any,
) -> Any:
    """:func:`spacecraft.simulate` with ``backend="jax"``: the run through
    :meth:`JaxClosedLoop.run`, returned as the :class:`spacecraft.simulator.SimulationResult`
    the NumPy route fills for the same configuration (every field: the actuator's derived log —
    SGCMG singularity measure and momentum — by the actuator's own NumPy function).

    ``log_every`` must log at control samples (a multiple of ``control_period / dt``): the
    compiled loop keeps the state at the samples only. ``options`` are simulate's other
    arguments; each must have its default (``sensors``, ``measurement``, ``rng``,
    ``compute_delay``, ``progress``; ``workers`` is ignored), else ``ValueError`` naming it. A
    member whose state becomes non-finite raises
    :class:`spacecraft.simulator.SimulationDiverged` at the first logged time where it is, with
    the rows before it (the NumPy route reports the step).
    """
    from liecontrol._validation import as_int

    from .simulator import SimulationDiverged, SimulationResult

    defaults = {"sensors": None, "measurement": None, "rng": None, "compute_delay": 0.0,
                "progress": False, "workers": 1}  # fmt: skip
    for name, value in options.items():
        if name not in defaults:
            raise TypeError(f"simulate_jax() got an unexpected keyword argument {name!r}")
        if name != "workers" and not (value is None or value is False or
                                      (name == "compute_delay" and value == 0)):  # fmt: skip
            raise ValueError(
                f"{name}: not supported by backend='jax' (got {value!r}); use backend='numba'"
            )
    loop = closed_loop(plant, controller, reference, t_final, dt, control_period, t0)
    state = plant.check_state(initial_state, "initial_state")
    every = as_int(log_every, "log_every", 1)
    if every % loop.n_sub:
        raise ValueError(
            f"log_every: backend='jax' logs at control samples, a multiple of "
            f"{loop.n_sub} steps here (control_period / dt), got {every}"
        )
    x = state.packed()
    x_act = x[:, plant.act_slice]
    run = loop.run(state.R, x[:, :3], delta0=x_act if loop.n_act else None)
    rows = np.arange(0, loop.n_ctrl + 1, every // loop.n_sub)
    if rows[-1] != loop.n_ctrl:
        rows = np.append(rows, loop.n_ctrl)  # the final time is always logged
    B = state.batch_size
    t = run.t[rows]
    refs = [reference(float(tk)) for tk in t]
    act = {k: v[rows] for k, v in run.actuator.items()}
    dist_log = np.zeros((len(rows), B, 3))
    components: dict[str, np.ndarray] = {}
    if plant.disturbance is not None:
        summed = isinstance(plant.disturbance, SumOfDisturbances)
        for i, r in enumerate(rows):  # the plant's own call at the logged times, as simulate's log
            dist_log[i] = plant.disturbance(float(t[i]), run.R[r], run.omega[r])
            if summed:  # and each source's torque by name, as simulate's log
                parts = plant.disturbance.components(float(t[i]), run.R[r], run.omega[r])
                for name, v in parts.items():
                    components.setdefault(name, np.zeros((len(rows), B, 3)))[i] = v
    derived = getattr(plant.actuator, "derived_log", None)
    if derived is not None:
        act.update(derived(act))
    result = SimulationResult(
        t=t, R=run.R[rows], omega=run.omega[rows],
        R_d=np.stack([np.broadcast_to(r.R_d, (B, 3, 3)) for r in refs]),
        omega_d=np.stack([np.broadcast_to(r.omega_d, (B, 3)) for r in refs]),
        u_cmd=run.u_cmd[rows], u=run.u[rows], disturbance=dist_log,
        disturbance_components=components, actuator=act,
        controller={k: v[rows] for k, v in run.controller.items()},
        dt=loop.dt, control_period=loop.control_period,
    )  # fmt: skip
    if run.diverged.any():
        t_bad = float(np.nanmin(run.diverged_at))
        keep = int(np.searchsorted(t, t_bad))
        cut = SimulationResult(**{
            k: (v[:keep] if isinstance(v, np.ndarray) else
                {n: a[:keep] for n, a in v.items()} if isinstance(v, dict) else v)
            for k, v in vars(result).items()
        })  # fmt: skip
        raise SimulationDiverged(
            f"state became non-finite by t = {t_bad:.6g} s (backend='jax', spacecraft "
            f"{np.flatnonzero(run.diverged).tolist()})",
            time=t_bad,
            result=cut,
        )
    return result
