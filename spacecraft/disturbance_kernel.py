"""The compiled-kernel seam of disturbances: how a disturbance hands the fused loop its torque.

A disturbance source (:mod:`spacecraft.disturbances`) that wants to run inside the simulator's
compiled closed loop (:func:`spacecraft.simulator.simulate`) defines one more method next to
``__call__``::

    def fused_kernel(self) -> DisturbanceKernel | None:
        ...

It returns a :class:`DisturbanceKernel`: a numba ``@njit`` function of the signature below (the
*torque*), a ``float64`` parameter vector — ``(n_p,)`` shared by the batch or ``(B, n_p)`` one
row per spacecraft — and whether the torque reads the attitude. ``None`` means "no kernel for
this configuration"; the Python loop then runs and ``simulate`` logs one line (logger
``spacecraft.simulator``) naming the disturbance.

The torque, called once per spacecraft at every RKMK4 stage (and at every log row)::

    torque(t, R, omega, params, out) -> None

==========  ====================================================================================
``t``       float, the stage time [s]
``R``       ``(3, 3)`` C-contiguous float64: the stage attitude R_k exp(θ_s) (body → inertial),
            exactly the attitude the Python loop passes at that stage (θ₁ = 0, θ₂ = h/2 K₁,
            θ₃ = h/2 K₂, θ₄ = h K₃; :func:`liecontrol.integrators.rk.rkmk4_step_unchecked`).
            When the kernel says ``uses_attitude=False`` the loop does not form the stage
            attitudes and ``R`` is the step's start attitude: the torque must not read it.
``omega``   ``(3,)`` the stage body rate [rad/s]
``params``  ``(n_p,)`` C-contiguous float64: this spacecraft's parameter row (read only)
``out``     ``(3,)`` body torque [N·m] about the centre of mass, written by the torque
==========  ====================================================================================

:data:`TORQUE_SIGNATURE` is this signature in numba's types; the loop calls the torque through a
function pointer (a numba first-class function), so one compiled loop serves every disturbance.
The built-in time-only sources (:class:`~spacecraft.disturbances.ConstantTorque`,
:class:`~spacecraft.disturbances.ConstantHarmonicTorque`, none) keep their own integer codes in
the loop (:func:`spacecraft._kernels.disturbance_at`, no pointer call); the gravity-gradient
torque (:class:`spacecraft.environment.GravityGradientTorque`) goes through this seam.

Which class the kernel speaks for: :func:`resolve` accepts the kernel only when ``__call__`` is
defined in the class that defines ``fused_kernel`` or above it (a subclass overriding
``__call__`` in Python keeps the Python loop until it defines ``fused_kernel`` itself).

Before the loop starts, :func:`check` compiles the torque for :data:`TORQUE_SIGNATURE`, checks
the parameters (dtype, dimensions, batch size, finiteness) and calls the torque once on the
initial state of the first spacecraft; a wrong signature, a numba typing error, parameters of
the wrong shape or dtype, or a non-finite torque raise :class:`ValueError` naming the
disturbance and the argument. The guide ``docs/fast_controllers.md`` has an example.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._jit import JIT_ENABLED, njit
from liecontrol.control.kernel import compile_kernel, missing_hook, overridden_below_kernel

__all__ = [
    "DisturbanceKernel",
    "TORQUE_SIGNATURE",
    "check",
    "no_torque",
    "resolve",
    "sum_kernel",
]


def _torque_signature() -> Any:
    if not JIT_ENABLED:
        return None
    from numba import types

    C1 = types.Array(types.float64, 1, "C")
    C2 = types.Array(types.float64, 2, "C")
    return types.void(types.float64, C2, C1, C1, C1)


#: numba signature of a disturbance torque (``None`` without numba)
TORQUE_SIGNATURE: Any = _torque_signature()


@njit
def no_torque(
    t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
) -> None:
    """The zero torque: the loop's placeholder pointer when the disturbance has no kernel of
    this seam (a built-in code or none)."""
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0


@dataclass(frozen=True)
class DisturbanceKernel:
    """What ``fused_kernel()`` returns (module docstring).

    Attributes:
        torque: the ``@njit`` torque of the documented signature.
        params: ``(n_p,)`` float64 parameters shared by the batch, or ``(B, n_p)`` one row per
            spacecraft (copied; read only to the torque). ``n_p`` may be 0.
        uses_attitude: whether the torque reads ``R`` (``False``: the loop skips forming the
            stage attitudes, as the Python loop does for ``uses_attitude = False`` sources).
        name: the torque's name in messages (default: the function's name).
    """

    torque: Callable[..., None]
    params: np.ndarray
    uses_attitude: bool = True
    name: str = ""


def resolve(dist: Any) -> tuple[DisturbanceKernel | None, str]:
    """``(kernel, "")`` for a disturbance with a kernel of this seam, else ``(None, reason)``:
    why it keeps the Python loop, in words (the simulator's one log line)."""
    if not callable(dist):
        raise TypeError(
            f"dist: expected a disturbance source (a callable (t, R, omega) -> (B, 3)), got "
            f"{type(dist).__name__}"
        )
    label = type(dist).__name__
    if not JIT_ENABLED:
        return None, "numba is not available"
    hook = getattr(dist, "fused_kernel", None)
    if not callable(hook):
        return None, f"the disturbance {label} has no compiled kernel ({missing_hook(dist)})"
    below = overridden_below_kernel(type(dist), ("__call__",))
    if below is not None:
        _, c_owner, k_owner = below
        return None, (
            f"the disturbance {label} overrides __call__() in {c_owner.__name__} below "
            f"{k_owner.__name__}.fused_kernel(), whose kernel is not its torque (define "
            "fused_kernel on the subclass to compile it)"
        )
    spec = hook()
    if spec is None:
        # a composite source may say which of its parts has no kernel (kernel_reason())
        reason = getattr(dist, "kernel_reason", None)
        why = reason() if callable(reason) else ""
        return None, why or f"the disturbance {label} has no compiled kernel for this configuration"
    if not isinstance(spec, DisturbanceKernel):
        raise ValueError(
            f"disturbance {label}: fused_kernel() must return a DisturbanceKernel or None, "
            f"got {type(spec).__name__}"
        )
    return spec, ""


def check(
    dist: Any,
    spec: DisturbanceKernel,
    batch_size: int | None,
    probe: tuple[float, np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Validate ``spec`` before a run: compile the torque for :data:`TORQUE_SIGNATURE`, check
    ``params`` (float64, ``(n_p,)`` or ``(batch_size, n_p)``, finite) and, with ``probe = (t, R
    (3, 3), ω (3,))``, call it once on copies. Returns the parameters as a C-contiguous
    ``(B', n_p)`` copy (B' = 1 shared, else the batch); raises ``ValueError`` naming the
    disturbance and the argument. ``batch_size=None`` accepts any number of rows."""
    label = type(dist).__name__
    torque = spec.torque
    tname = spec.name or getattr(torque, "__name__", repr(torque))
    p = spec.params
    if not isinstance(p, np.ndarray):
        raise ValueError(
            f"disturbance {label}: kernel params must be a numpy float64 array, "
            f"got {type(p).__name__}"
        )
    if p.dtype != np.float64:
        raise ValueError(
            f"disturbance {label}: kernel params must have dtype float64, got {p.dtype}"
        )
    rows_ok = p.ndim == 2 and (batch_size is None or p.shape[0] in (1, batch_size))
    if p.ndim != 1 and not rows_ok:
        want = "(n_p,) or (B, n_p)" if batch_size is None else f"(n_p,) or ({batch_size}, n_p)"
        raise ValueError(
            f"disturbance {label}: kernel params must have shape {want}, got {p.shape}"
        )
    if not np.all(np.isfinite(p)):
        raise ValueError(f"disturbance {label}: kernel params must be finite")
    params = np.ascontiguousarray(p.reshape(1, -1) if p.ndim == 1 else p).copy()
    if not isinstance(spec.uses_attitude, (bool, np.bool_)):
        raise ValueError(
            f"disturbance {label}: kernel uses_attitude must be a bool, got {spec.uses_attitude!r}"
        )
    compile_kernel(
        torque, TORQUE_SIGNATURE, f"disturbance {label}: kernel torque", tname,
        "torque(t, R, omega, params, out) (spacecraft.disturbance_kernel)",
    )  # fmt: skip
    if probe is not None:
        t, R, w = probe
        out = np.full(3, np.nan)
        torque(
            float(t), np.ascontiguousarray(R, dtype=np.float64).copy(),
            np.ascontiguousarray(w, dtype=np.float64).copy(), params[0].copy(), out,
        )  # fmt: skip
        if not np.all(np.isfinite(out)):
            _raise_for_source(dist, probe)
            raise ValueError(
                f"disturbance {label}: kernel torque {tname} returned a non-finite torque out on "
                f"the initial state (t = {float(t)!r}); check the torque and its params"
            )
    return params


def _raise_for_source(dist: Any, probe: tuple[float, np.ndarray, np.ndarray]) -> None:
    """For a composite source with named ``sources`` (a :class:`spacecraft.disturbances.
    SumOfDisturbances`, nested or not) whose kernel is non-finite on the probe: ``ValueError``
    naming the first source whose own kernel is, with that source's message."""
    sources = getattr(dist, "sources", None)
    if not isinstance(sources, Mapping):
        return
    for name, src in sources.items():
        spec, _ = resolve(src)
        if spec is None:
            continue
        try:
            check(src, spec, None, probe)
        except ValueError as exc:
            raise ValueError(f"disturbance {type(dist).__name__}, source {name!r}: {exc}") from None


def _pair_sum(left: Any, right: Any, n_left: int) -> Any:
    """The compiled ``out = left + right``: ``left``'s torque from ``params[:n_left]``, then
    ``right``'s from ``params[n_left:]``, added in that order (the order of
    :meth:`spacecraft.disturbances.SumOfDisturbances.__call__`, so each component's rounding is
    the Python loop's). Not cached on disk: a closure over other kernels."""
    from liecontrol._jit import _NUMBA

    def pair(
        t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
    ) -> None:
        left(t, R, omega, params[:n_left], out)
        a0 = out[0]
        a1 = out[1]
        a2 = out[2]
        right(t, R, omega, params[n_left:], out)
        out[0] = a0 + out[0]
        out[1] = a1 + out[1]
        out[2] = a2 + out[2]

    # the composed torque's name in messages: its parts' names
    pair.__name__ = pair.__qualname__ = (
        f"{getattr(left, '__name__', 'torque')} + {getattr(right, '__name__', 'torque')}"
    )
    fn = _NUMBA.njit(error_model="numpy")(pair)
    fn.compile(TORQUE_SIGNATURE)
    return fn


def sum_kernel(
    parts: Sequence[tuple[str, Any]] | Mapping[str, Any], label: str = "SumOfDisturbances"
) -> tuple[DisturbanceKernel | None, str]:
    """The kernel of the sum of the named sources ``parts`` (``[(name, source), ...]`` or a
    mapping name -> source, summed in that order; ``ValueError`` naming ``parts`` otherwise):
    ``(kernel, "")`` when every source has a kernel of this seam (each checked as :func:`check`
    does, without a probe), else ``(None, why)`` naming the first source without one. The
    parameters are the parts' rows side by side (``(n_1 + n_2 + …,)``, or one row per
    spacecraft when a part has per-spacecraft rows); ``uses_attitude`` when any part reads the
    attitude. A mismatch of the parts' batch rows raises ``ValueError`` naming both sources.
    ``label`` names the sum in messages. Used by :class:`spacecraft.disturbances.
    SumOfDisturbances` (``fused_kernel``); the composed function is compiled once per
    combination of part kernels and sizes in a process."""
    items = _named_parts(parts)
    if not isinstance(label, str):
        raise ValueError(f"label: expected a str, got {type(label).__name__}")
    if not JIT_ENABLED:
        return None, "numba is not available"
    specs: list[tuple[str, DisturbanceKernel, np.ndarray]] = []
    for name, src in items:
        spec, why = resolve(src)
        if spec is None:
            return None, f"the {label} source {name!r} keeps the Python loop: {why}"
        specs.append((name, spec, check(src, spec, None)))
    rows = {p.shape[0] for _, _, p in specs} - {1}
    if len(rows) > 1:
        per = ", ".join(f"{n!r}: {p.shape[0]}" for n, _, p in specs if p.shape[0] != 1)
        raise ValueError(
            f"disturbance {label}: the sources' kernel params have different batch rows ({per})"
        )
    n_rows = rows.pop() if rows else 1
    params = np.concatenate([np.broadcast_to(p, (n_rows, p.shape[1])) for _, _, p in specs], axis=1)
    torque, width = specs[0][1].torque, specs[0][2].shape[1]
    for _, spec, p in specs[1:]:
        torque = _combined(torque, spec.torque, width)
        width += p.shape[1]
    uses = any(bool(spec.uses_attitude) for _, spec, _ in specs)
    name = " + ".join(
        spec.name or getattr(spec.torque, "__name__", "torque") for _, spec, _ in specs
    )
    return DisturbanceKernel(
        torque, np.ascontiguousarray(params), uses_attitude=uses, name=name
    ), ""


def _named_parts(parts: Any) -> list[tuple[str, Any]]:
    """``parts`` as a list of ``(name, source)`` pairs (a mapping's items, or the pairs), or
    ``ValueError`` naming ``parts``."""
    if isinstance(parts, Mapping):
        parts = list(parts.items())
    if isinstance(parts, (str, bytes)) or not isinstance(parts, Iterable):
        raise ValueError(
            f"parts: expected a mapping name -> source or a sequence of (name, source) pairs, "
            f"got {type(parts).__name__}"
        )
    items = list(parts)
    if not items:
        raise ValueError("parts: at least one source is required")
    for i, item in enumerate(items):
        if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str)):
            raise ValueError(f"parts[{i}]: expected a (name, source) pair, got {item!r}")
        if not callable(item[1]):
            raise ValueError(f"parts[{i}]: source {item[0]!r} is not callable")
    return items


@functools.lru_cache(maxsize=256)
def _combined(left: Any, right: Any, n_left: int) -> Any:
    # one compiled pair per (left, right, split): a Monte Carlo builds its plant once per batch,
    # and compiling the same sum again per batch would cost more than the batch's loop
    return _pair_sum(left, right, n_left)
