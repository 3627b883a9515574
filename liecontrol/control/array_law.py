"""The array-law seam: how a controller hands the differentiable (JAX) loop its law.

The JAX route of the simulator (:mod:`spacecraft.differentiable`) runs the closed loop as one
``jit(vmap(lax.scan))`` program and differentiates through it. It knows no controller class: a
controller that wants to fly there defines one more method next to ``reset`` and ``command``::

    def array_law(self) -> ArrayLaw: ...

returning an :class:`ArrayLaw`: the law as a **pure array function** of one spacecraft, its
initial internal state (an integrator, an observer: the scan carries it from one control sample
to the next) and the two gains the tuners differentiate. The step is::

    step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T) -> (u, state, diag)

==================  ============================================================================
``k_R``, ``k_Omega``  the differentiable gains (scalars or ``(3, 3)``; the law interprets them,
                    its other parameters it closes over)
``state``           a tuple of arrays, this spacecraft's internal state before the sample
                    (``()`` for a memoryless law)
``R``, ``omega``    ``(3, 3)`` attitude, ``(3,)`` body rate [rad/s]
``R_d`` …           the reference sample (:class:`~liecontrol.control.base.AttitudeReference`)
``T``               the control period [s] (the time since the previous sample)
``params``          keyword, only for a law that declares further tunable parameters
                    (``ArrayLaw.params``: an observer bandwidth, a boundary-layer width): a dict
                    with the same keys, whose values the tuners may replace by traced arrays
``t``               keyword, only for a law declared with ``timed=True``: the sample's time [s]
                    (a law whose formula reads the clock: a funnel, a harmonic regressor)
returns             the torque ``(3,)`` [N·m], the state after the sample (same structure and
                    shapes), and a dict of per-sample diagnostics (scalars or arrays)
==================  ============================================================================

Write it with the ``xp`` namespace of :mod:`liecontrol._array_api` (or plain ``jax.numpy``): no
in-place writes, branches as ``where`` with both sides finite — the same rules as the numpy
layer, whose pure functions the built-in laws call (``geometric_pd_torque``,
``integral_update``/``integral_output``): one source per formula, NumPy and JAX alike.

Which controllers fly: every built-in attitude law but the OSQP MPC, the sampled-data keep-out
filter and the small-angle payload PID — :class:`~liecontrol.control.GeometricPD` (trace, log
and large-angle errors),
:class:`~liecontrol.control.IntrinsicPID`, :class:`~liecontrol.control.IntegralPD`,
:class:`~liecontrol.control.AdaptiveGeometricSO3`,
:class:`~liecontrol.control.PrescribedPerformance`, :class:`~liecontrol.control.FiniteTimeSO3`,
:class:`~liecontrol.control.FixedTimeSO3`,
:class:`~liecontrol.control.fault_tolerant.AdaptiveFaultTolerantSO3`,
:class:`~liecontrol.control.ConstrainedGeometricPD`,
:class:`~liecontrol.control.RateLimitedEigenaxis`, and through the chart adapters' pure
conversion (:class:`~liecontrol.control.adapters.ChartArrayLaw`)
:class:`~liecontrol.control.QuaternionPD`, :class:`~liecontrol.control.MrpPD`,
:class:`~liecontrol.control.MrpADRC` and :class:`~liecontrol.control.TerminalSlidingModeSO3` —
and any controller that defines ``array_law``, a user's own included. A subclass that overrides
``command`` without its own ``array_law`` would fly its parent's law, so it is refused (as the
compiled seam, :mod:`liecontrol.control.kernel`, does).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["ArrayLaw", "array_law_of"]


@dataclass(frozen=True)
class ArrayLaw:
    """A controller's law for the differentiable loop (module docstring).

    Attributes:
        k_R, k_Omega: the gains' values (the defaults of the differentiable arguments).
        state0: one spacecraft's initial internal state, a tuple of NumPy arrays (``()``).
        step: the pure step function of the module docstring.
        params: further differentiable parameters by name (floats or arrays, default none):
            when given, ``step`` receives them as the keyword ``params`` (same keys).
        timed: ``step`` receives the sample's time as the keyword ``t`` (default ``False``).
        member_state0: each spacecraft's own initial state, or ``None`` (all start from
            ``state0``): the structure of ``state0`` with a leading batch axis ``B`` (e.g. a
            quaternion law's per-spacecraft sign hint); the loop then runs batches of exactly
            ``B``.
    """

    k_R: Any
    k_Omega: Any
    state0: tuple
    step: Callable[..., tuple[Any, tuple, dict[str, Any]]]
    params: Mapping[str, Any] = field(default_factory=dict)
    timed: bool = False
    member_state0: tuple | None = None

    def __post_init__(self) -> None:
        if not callable(self.step):
            raise ValueError("step: must be callable as step(k_R, k_Omega, state, R, omega, ...)")
        if not isinstance(self.state0, tuple):
            raise ValueError(
                f"state0: expected a tuple of arrays, got {type(self.state0).__name__}"
            )
        if self.member_state0 is not None:
            m = self.member_state0
            if not isinstance(m, tuple) or len(m) != len(self.state0):
                raise ValueError(
                    f"member_state0: expected a tuple of {len(self.state0)} arrays (the "
                    "structure of state0)"
                )
            sizes = {np.shape(a)[0] if np.ndim(a) else -1 for a in m}
            shapes_ok = all(
                np.shape(a)[1:] == np.shape(b) for a, b in zip(m, self.state0, strict=True)
            )
            if len(sizes) != 1 or -1 in sizes or not shapes_ok:
                raise ValueError(
                    "member_state0: each entry must be its state0 entry with one leading "
                    "batch axis, the same B for all"
                )

    def initial_states(self, B: int) -> tuple:
        """The ``B`` spacecraft's initial states, each entry ``(B, ...)``: ``member_state0``
        (``ValueError`` naming it when its batch is not ``B``), else ``state0`` repeated."""
        if self.member_state0 is None:
            return tuple(np.broadcast_to(np.asarray(a), (B, *np.shape(a))) for a in self.state0)
        n = np.shape(self.member_state0[0])[0]
        if n != B:
            raise ValueError(
                f"member_state0: the law's per-spacecraft initial states are for {n} "
                f"spacecraft, the batch has {B}"
            )
        return tuple(np.asarray(a) for a in self.member_state0)
        if not isinstance(self.params, Mapping) or not all(isinstance(k, str) for k in self.params):
            raise ValueError("params: expected a mapping from parameter names (str) to values")
        for name, value in self.params.items():
            a = np.asarray(value)
            if a.dtype.kind not in "fiu" or not np.isfinite(a).all():
                raise ValueError(f"params[{name!r}]: expected finite real values, got {value!r}")

    def call(
        self, k_R: Any, k_Omega: Any, state: tuple, R: Any, omega: Any, R_d: Any,
        omega_d: Any, omega_dot_d: Any, T: Any, params: Mapping[str, Any] | None = None,
        t: Any = None,
    ) -> tuple[Any, tuple, dict[str, Any]]:  # fmt: skip
        """``step`` with ``params`` (default :attr:`params`) passed when the law declares any,
        and the sample time ``t`` when it is :attr:`timed`."""
        kw: dict[str, Any] = {}
        if self.params:
            kw["params"] = dict(self.params) if params is None else {**self.params, **params}
        if self.timed:
            if t is None:
                raise ValueError("t: this law reads the sample time; pass t")
            kw["t"] = t
        return self.step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T, **kw)


def _owner(cls: type, name: str) -> type | None:
    return next((k for k in cls.__mro__ if name in vars(k)), None)


def array_law_of(controller: Any) -> ArrayLaw:
    """The controller's :class:`ArrayLaw`; ``ValueError`` naming ``controller`` when it has
    none (no ``array_law``, or a subclass whose ``command`` its parent's law does not describe)
    or when its ``array_law`` refuses the configuration (it names the attribute)."""
    cls = type(controller)
    fn = getattr(controller, "array_law", None)
    if not callable(fn):
        raise ValueError(
            f"controller: {cls.__name__} has no array_law (the JAX route flies controllers that "
            "give their law as a pure array function: liecontrol.control.array_law)"
        )
    law_owner, cmd_owner = _owner(cls, "array_law"), _owner(cls, "command")
    if cmd_owner is not None and law_owner is not None and cmd_owner is not law_owner:
        if issubclass(cmd_owner, law_owner):
            raise ValueError(
                f"controller: {cls.__name__} overrides command() but not array_law(): its "
                f"parent's law ({law_owner.__name__}) would not be its own"
            )
    law = fn()
    if not isinstance(law, ArrayLaw):
        raise ValueError(
            f"controller: {cls.__name__}.array_law() returned {type(law).__name__}, expected an "
            "ArrayLaw"
        )
    return law
