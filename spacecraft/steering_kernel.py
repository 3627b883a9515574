"""The compiled-kernel seam for steering laws: how a user's SGCMG steering law runs inside the
simulator's compiled closed loop, as the built-in laws do.

A steering law (a :class:`spacecraft.steering.SteeringLaw`) that wants the compiled loop
defines one more method next to ``steer``::

    def fused_kernel(self, cluster) -> SteeringKernel | None:
        ...

called with the actuator's cluster when the plant is built. It returns a
:class:`SteeringKernel`: a numba ``@njit`` function of the signature below and a flat
``float64`` parameter vector (the law's gains, and whatever of the cluster it needs, e.g. its
unit momenta). ``None`` means "no kernel for this configuration"; the Python loop then runs the
law's ``steer`` and ``simulate`` logs one line naming the steering law.

The kernel, called once per spacecraft at every integration step (the simulator recomputes the
actuator's command at every step from the held torque)::

    steer(t, A, hdot, delta, params, out) -> None

==========  ===========================================================================
``t``       float, the step's time [s]
``A``       ``(3, n)`` C-contiguous float64: the cluster's Jacobian ∂h/∂δ at ``delta``
``hdot``    ``(3,)`` the commanded momentum rate ḣ_cmd = −(ω × h + u) [N·m]
``delta``   ``(n,)`` the gimbal angles [rad]
``params``  ``(n_p,)`` the law's parameters (read only)
``out``     ``(n,)`` the gimbal-rate command δ̇ [rad/s], written by the kernel
==========  ===========================================================================

The loop then scales ``out`` uniformly to the gimbal-rate limit, as for every law. A law is
stateless (a pure function of its arguments, as :class:`~spacecraft.steering.SteeringLaw`
requires). :data:`STEERING_SIGNATURE` is this signature in numba's types; the loop calls the
kernel through a function pointer, so one compiled loop (cached on disk) serves every law.

Which class the kernel speaks for: :func:`resolve` accepts it only when ``steer`` (and
``__call__``) are defined in the class that defines ``fused_kernel`` or above it — a subclass
that overrides ``steer`` in Python does not silently get its parent's kernel.

Before the first run (when the plant is built), :func:`resolve` compiles the kernel for
:data:`STEERING_SIGNATURE`, checks the parameters (a 1-D finite float64 array) and calls the
kernel once at the actuator's initial gimbal angles; a wrong signature, a numba typing error,
parameters of the wrong shape or dtype, or a non-finite rate raise ``ValueError`` naming the
steering law and the argument. What the Python loop runs is the law's own ``steer``: the two
must agree (the tests of ``docs/fast_controllers.md``'s example hold them to 1e-12). Only the
SGCMG pyramid with the ideal gimbal servo flies a user's kernel; the full CMG model
(:class:`spacecraft.cmg_dynamics.VscmgActuator`) runs such a law in the Python loop.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from liecontrol._jit import JIT_ENABLED
from liecontrol.control.kernel import compile_kernel, missing_hook, overridden_below_kernel

__all__ = ["STEERING_SIGNATURE", "SteeringKernel", "resolve"]


def _signature() -> Any:
    if not JIT_ENABLED:
        return None
    from numba import types

    C1 = types.Array(types.float64, 1, "C")
    C2 = types.Array(types.float64, 2, "C")
    return types.void(types.float64, C2, C1, C1, C1, C1)


#: numba signature of a steering kernel (``None`` without numba)
STEERING_SIGNATURE: Any = _signature()


@dataclass(frozen=True)
class SteeringKernel:
    """What a steering law's ``fused_kernel(cluster)`` returns (module docstring).

    Attributes:
        steer: the ``@njit`` kernel of the documented signature.
        params: ``(n_p,)`` float64 parameter vector (copied; read only to the kernel).
        name: the kernel's name in messages (default: the function's name).
    """

    steer: Callable[..., None]
    params: np.ndarray
    name: str = ""


def resolve(
    law: Any, cluster: Any, A0: np.ndarray, delta0: np.ndarray
) -> tuple[SteeringKernel | None, np.ndarray | None, str]:
    """``(kernel, params, "")`` for a steering law with a checked kernel, else ``(None, None,
    reason)`` (why it keeps the Python loop, in words). ``A0`` ``(3, n)`` and ``delta0``
    ``(n,)``: the cluster's Jacobian at the initial gimbal angles, where the kernel is probed.
    Raises ``ValueError`` naming the steering law and the argument for a malformed kernel."""
    label = type(law).__name__
    if not JIT_ENABLED:
        return None, None, "numba is not available"
    hook = getattr(law, "fused_kernel", None)
    if not callable(hook):
        return None, None, f"steering {label} has no compiled kernel ({missing_hook(law)})"
    below = overridden_below_kernel(type(law), ("steer", "__call__"))
    if below is not None:
        attr, owner, k_owner = below
        return (
            None,
            None,
            (
                f"steering {label} overrides {attr}() in {owner.__name__} below "
                f"{k_owner.__name__}.fused_kernel(), whose kernel is not its law (define "
                "fused_kernel on the subclass to compile it)"
            ),
        )
    spec = hook(cluster)
    if spec is None:
        return None, None, f"steering {label} has no compiled kernel for this cluster"
    if not isinstance(spec, SteeringKernel):
        raise ValueError(
            f"steering {label}: fused_kernel() must return a SteeringKernel or None, got "
            f"{type(spec).__name__}"
        )
    return spec, check(law, spec, A0, delta0), ""


def check(law: Any, spec: SteeringKernel, A0: np.ndarray, delta0: np.ndarray) -> np.ndarray:
    """Compile ``spec.steer`` for :data:`STEERING_SIGNATURE`, check its parameters and call it
    once at ``(A0, delta0)`` with a unit momentum-rate command; returns the parameters the loop
    uses. ``ValueError`` naming the steering law and the argument."""
    label = type(law).__name__
    fn = spec.steer
    name = spec.name or getattr(fn, "__name__", repr(fn))
    p = spec.params
    if not isinstance(p, np.ndarray) or p.dtype != np.float64 or p.ndim != 1:
        got = f"dtype {p.dtype}, shape {p.shape}" if isinstance(p, np.ndarray) else type(p).__name__
        raise ValueError(
            f"steering {label}: kernel params must be a 1-D float64 numpy array, got {got}"
        )
    if not np.all(np.isfinite(p)):
        raise ValueError(f"steering {label}: kernel params must be finite")
    params = np.ascontiguousarray(p).copy()
    compile_kernel(
        fn, STEERING_SIGNATURE, f"steering {label}: kernel steer", name,
        "steer(t, A, hdot, delta, params, out) (spacecraft.steering_kernel)",
    )  # fmt: skip
    A = np.ascontiguousarray(A0, dtype=np.float64)
    d = np.ascontiguousarray(delta0, dtype=np.float64)
    out = np.full(d.shape[0], np.nan)
    fn(0.0, A.copy(), np.array([1.0, 0.0, 0.0]), d.copy(), params.copy(), out)
    if not np.all(np.isfinite(out)):
        raise ValueError(
            f"steering {label}: kernel steer {name} returned a non-finite gimbal rate out at "
            "the initial gimbal angles (ḣ_cmd = (1, 0, 0)); check the kernel and its params"
        )
    return params
