"""The compiled-kernel seam: how a controller hands the simulator its per-step law.

A controller that wants to run inside the simulator's compiled closed loop
(:func:`spacecraft.simulator.simulate`) defines one more method next to ``reset`` and
``command``::

    def fused_kernel(self, batch_size: int, control_period: float) -> ControllerKernel | None:
        ...

called after ``reset(t0, batch_size)`` with the run's control period [s] (the law is called
every ``control_period``, so a discretised law can precompute its matrices). It returns a
:class:`ControllerKernel`: a numba ``@njit`` function of the signature below (the *law*), a flat
``float64`` parameter vector, the initial internal state of each spacecraft (an integrator, an
observer, a chart memory: the loop carries it from one control sample to the next), and two
small Python callables that turn the law's diagnostics rows into the controller's
``diagnostics()`` dictionary and write the final state back into the controller. ``None``
means "no kernel for this configuration"; the Python loop then runs and ``simulate`` logs one
line (logger ``spacecraft.simulator``) naming the part that kept it there.

The law, called once per spacecraft at every control sample::

    law(t, R, omega, R_d, omega_d, omega_dot_d, params, state, u_out, diag_out) -> None

==================  ============================================================================
``t``               float, the sample time [s]
``R``               ``(3, 3)`` float64 attitude (body → inertial)
``omega``           ``(3,)`` body rate [rad/s]
``R_d``             ``(3, 3)`` desired attitude; ``omega_d``, ``omega_dot_d`` ``(3,)`` desired
                    rate and acceleration in the desired frame (an
                    :class:`~liecontrol.control.base.AttitudeReference` sample)
``params``          ``(n_p,)`` C-contiguous float64: the controller's parameters (read only)
``state``           ``(n_s,)`` C-contiguous float64: this spacecraft's internal state, read and
                    updated in place; ``n_s`` may be 0
``u_out``           ``(3,)`` body torque command [N·m], written by the law
``diag_out``        ``(n_d,)`` diagnostics row, written by the law (``n_d`` may be 0)
==================  ============================================================================

:data:`LAW_SIGNATURE` is this signature in numba's types; the simulator compiles the law for it
(every array C-contiguous float64, so ``params[1:10].reshape((3, 3))`` is a 3×3 view and
``R_d.T @ R`` runs at full speed). The loop calls the law through a
function pointer, so one compiled loop (cached on disk) serves every law.

Which class the kernel speaks for: :func:`resolve` accepts the kernel only when ``command`` is
defined in the class that defines ``fused_kernel`` or above it. A subclass of
:class:`~liecontrol.control.GeometricPD` that keeps the law inherits the kernel; one that
overrides ``command`` in Python does not silently get its parent's kernel — the Python loop runs
its ``command`` (and the log line says so) until it defines ``fused_kernel`` itself.

Before the loop starts, :func:`check` compiles the law for :data:`LAW_SIGNATURE`, checks the
arrays (dtype, dimensions, finiteness) and calls the law once on the initial state; a wrong
signature, a numba typing error, a parameter of the wrong shape or dtype, or a non-finite torque
raise :class:`ValueError` naming the controller and the argument. The guide
``docs/fast_controllers.md`` walks through a user's law with an integrator, end to end.

This module imports numba only when it is installed (:mod:`liecontrol._jit`); without it no
controller has a kernel and every run takes the Python loop.
"""

from __future__ import annotations

import inspect
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._jit import JIT_ENABLED

__all__ = [
    "ControllerKernel",
    "LAW_SIGNATURE",
    "NonFiniteTorque",
    "check",
    "resolve",
]


def _law_signature() -> Any:
    if not JIT_ENABLED:
        return None
    from numba import types

    C1 = types.Array(types.float64, 1, "C")
    C2 = types.Array(types.float64, 2, "C")
    return types.void(types.float64, C2, C1, C2, C1, C1, C1, C1, C1, C1)


#: numba signature of a law (``None`` without numba)
LAW_SIGNATURE: Any = _law_signature()


def _no_diagnostics(rows: np.ndarray) -> dict[str, np.ndarray]:
    return {}


def _no_finish(state: np.ndarray, diag: np.ndarray) -> None:
    return None


@dataclass(frozen=True)
class ControllerKernel:
    """What :meth:`fused_kernel` returns (module docstring).

    Attributes:
        law: the ``@njit`` law of the documented signature.
        params: ``(n_p,)`` float64 parameter vector (copied, read only to the law).
        state: ``(B, n_s)`` float64 initial internal state per spacecraft (copied; the loop
            carries it); ``np.zeros((B, 0))`` for a stateless law.
        n_diag: width ``n_d`` of the diagnostics row.
        diagnostics: ``rows (..., B, n_d) -> dict`` of arrays: the controller's
            ``diagnostics()`` entries from the rows (used for the log, where ``...`` is the
            row axis, and for the last sample). Must give the same keys, shapes and dtypes as
            the controller's ``diagnostics()`` in the Python loop.
        finish: ``(state (B, n_s), last diagnostics row (B, n_d)) -> None``: writes the final
            internal state back into the controller after the run, so that it ends as the
            Python loop would leave it.
        name: the law's name in messages (default: the function's name).
        preflight: ``(t0, R (B, 3, 3), omega (B, 3), reference) -> None`` or ``None``: called
            once before the loop with the initial state and the reference at ``t0`` — where
            ``command`` would warn about, or refuse, the initial state at its first sample
            (e.g. a start inside a keep-out cone's unrecoverable set), the compiled run does
            so before its first step too.
    """

    law: Callable[..., None]
    params: np.ndarray
    state: np.ndarray
    n_diag: int = 0
    diagnostics: Callable[[np.ndarray], dict[str, np.ndarray]] = field(
        default=_no_diagnostics, repr=False
    )
    finish: Callable[[np.ndarray, np.ndarray], None] = field(default=_no_finish, repr=False)
    name: str = ""
    preflight: Callable[..., None] | None = field(default=None, repr=False)


def _owner(cls: type, attr: str) -> type | None:
    for klass in inspect.getmro(cls):
        if attr in vars(klass):
            return klass
    return None


def overridden_below_kernel(cls: type, laws: tuple[str, ...]) -> tuple[str, type, type] | None:
    """The seams' owner rule: a ``fused_kernel`` speaks for the class that defines it and for
    its subclasses that keep its law. Returns ``(method, overriding class, kernel class)`` for
    the first of ``laws`` (e.g. ``("command",)``) that ``cls`` overrides below the class that
    defines ``fused_kernel``, else ``None``. Shared by the controller, steering
    (:mod:`spacecraft.steering_kernel`) and disturbance (:mod:`spacecraft.disturbance_kernel`)
    seams."""
    k_owner = _owner(cls, "fused_kernel")
    for attr in laws:
        owner = _owner(cls, attr)
        if k_owner is not None and owner is not None and owner is not k_owner:
            if issubclass(owner, k_owner):
                return attr, owner, k_owner
    return None


def compile_kernel(fn: Any, signature: Any, what: str, name: str, documented: str) -> None:
    """Compile the ``@njit`` ``fn`` for the numba ``signature`` (once: a compiled overload is
    reused), or raise ``ValueError``: ``"{what} must be a numba @njit function"`` for anything
    else, ``"{what} {name} does not compile for the documented signature {documented}: …"``
    with numba's typing error in one line. Shared by the three seams (``what`` names the part
    and the argument, e.g. ``"controller MyPD: kernel law"``)."""
    if not callable(getattr(fn, "compile", None)) or not hasattr(fn, "py_func"):
        raise ValueError(f"{what} must be a numba @njit function, got {fn!r}")
    from numba.core.errors import NumbaError

    try:
        if signature.args not in fn.overloads:
            fn.compile(signature)
    except (NumbaError, TypeError, ValueError) as exc:
        raise ValueError(
            f"{what} {name} does not compile for the documented signature {documented}: "
            f"{_summary(exc)}"
        ) from None


#: The largest batch a kernel is built for (a guard against a mistyped size).
_MAX_BATCH = 100_000_000


def missing_hook(obj: Any) -> str:
    """Why ``obj`` offers no ``fused_kernel()`` hook, in words (the simulator's log line): no
    such attribute, or one that is not callable (e.g. ``fused_kernel = None`` on a class)."""
    if not hasattr(obj, "fused_kernel"):
        return "no fused_kernel method"
    return f"its fused_kernel is {obj.fused_kernel!r}, not a method"


def resolve(
    controller: Any, batch_size: int, control_period: float | None = None
) -> tuple[ControllerKernel | None, str]:
    """``(kernel, "")`` for a controller with a kernel, else ``(None, reason)``: why it keeps
    the Python loop, in words (used for the simulator's one log line)."""
    from liecontrol._validation import as_int, check_positive_scalar

    if not callable(getattr(controller, "command", None)):
        raise TypeError(
            f"controller: expected an attitude controller (with command), got "
            f"{type(controller).__name__}"
        )
    batch_size = as_int(batch_size, "batch_size", 1)
    if batch_size > _MAX_BATCH:
        raise ValueError(f"batch_size: at most {_MAX_BATCH} spacecraft, got {batch_size}")
    if control_period is not None:
        control_period = check_positive_scalar(control_period, "control_period")
    label = type(controller).__name__
    if not JIT_ENABLED:
        return None, "numba is not available"
    hook = getattr(controller, "fused_kernel", None)
    if not callable(hook):
        return None, f"controller {label} has no compiled kernel ({missing_hook(controller)})"
    below = overridden_below_kernel(type(controller), ("command",))
    if below is not None:
        _, c_owner, k_owner = below
        return None, (
            f"controller {label} overrides command() in {c_owner.__name__} below "
            f"{k_owner.__name__}.fused_kernel(), whose kernel is not its law (define "
            "fused_kernel on the subclass to compile it)"
        )
    spec = hook(batch_size, control_period)
    if spec is None:
        why = getattr(controller, "_kernel_reason", None)
        why = why() if callable(why) else "this configuration"
        return None, f"controller {label} has no compiled kernel for {why}"
    if not isinstance(spec, ControllerKernel):
        raise ValueError(
            f"controller {label}: fused_kernel() must return a ControllerKernel or None, "
            f"got {type(spec).__name__}"
        )
    return spec, ""


def _array(label: str, name: str, a: Any, ndim: int, shape0: int | None = None) -> np.ndarray:
    if not isinstance(a, np.ndarray):
        raise ValueError(
            f"controller {label}: kernel {name} must be a numpy float64 array, "
            f"got {type(a).__name__}"
        )
    if a.dtype != np.float64:
        raise ValueError(
            f"controller {label}: kernel {name} must have dtype float64, got {a.dtype}"
        )
    if a.ndim != ndim or (shape0 is not None and a.shape[0] != shape0):
        want = "(n,)" if ndim == 1 else f"({shape0}, n)"
        raise ValueError(f"controller {label}: kernel {name} must have shape {want}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"controller {label}: kernel {name} must be finite")
    return np.ascontiguousarray(a).copy()


def _summary(exc: Exception) -> str:
    """The informative lines of a numba typing error, in one line (the header, the failing
    call, the nested reason and the source line)."""
    text = re.sub(r"\x1b\[[0-9;]*m", "", str(exc))
    lines = [x.strip() for x in text.splitlines() if x.strip()]
    if not lines:
        return type(exc).__name__
    keep = lines[:2] + [
        x for x in lines[2:] if x.startswith((">>>", "File ", "During: typing of")) or "Error:" in x
    ]
    out = "; ".join(dict.fromkeys(keep))
    return out if len(out) <= 600 else out[:597] + "..."


def check(
    controller: Any,
    spec: ControllerKernel,
    batch_size: int,
    probe: tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Validate ``spec`` before a run: compile the law for :data:`LAW_SIGNATURE` and, with
    ``probe = (t, R, ω, R_d, ω_d, ω̇_d)``, call it once on the first spacecraft (on copies). Returns
    the ``(params, state)`` arrays the loop uses; raises ``ValueError`` naming the controller
    and the argument."""
    label = type(controller).__name__
    law = spec.law
    lname = spec.name or getattr(law, "__name__", repr(law))
    params = _array(label, "params", spec.params, 1)
    state = _array(label, "state", spec.state, 2, batch_size)
    n_diag = spec.n_diag
    if isinstance(n_diag, bool) or not isinstance(n_diag, (int, np.integer)) or n_diag < 0:
        raise ValueError(f"controller {label}: kernel n_diag must be an int >= 0, got {n_diag!r}")
    compile_kernel(
        law, LAW_SIGNATURE, f"controller {label}: kernel law", lname,
        "law(t, R, omega, R_d, omega_d, omega_dot_d, params, state, u_out, diag_out) "
        "(liecontrol.control.kernel)",
    )  # fmt: skip
    if probe is not None:
        t, R, w, R_d, w_d, dw_d = probe
        u = np.full(3, np.nan)
        d = np.zeros(n_diag)
        law(float(t), R, w, R_d, w_d, dw_d, params.copy(), state[0].copy(), u, d)
        if not np.all(np.isfinite(u)):
            raise non_finite_error(controller, spec, t)
    return params, state


class NonFiniteTorque(ValueError):
    """A law returned a non-finite torque at the first control sample (before any step)."""


def non_finite_error(controller: Any, spec: ControllerKernel, t: float) -> NonFiniteTorque:
    """The error of a law that returns a non-finite torque at the first sample ``t`` (the
    simulator's fused loop checks every sample; the first one is checked before any step).
    Internal: the simulator builds it from a resolved kernel (not an input check)."""
    label = type(controller).__name__
    lname = spec.name or getattr(spec.law, "__name__", repr(spec.law))
    return NonFiniteTorque(
        f"controller {label}: kernel law {lname} returned a non-finite torque u_out at the first "
        f"control sample (t = {t!r}, the initial state); check the law and its params"
    )
