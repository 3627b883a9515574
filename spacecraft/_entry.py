"""Compiled entry points of kernels that take first-class functions (a controller's law, a
disturbance torque, a steering kernel): :func:`fn_entry` compiles an ``njit`` function once per
argument types with those arguments typed by their seam's numba signature, so one compiled loop
or step serves every function of that signature. Shared by the fused loop
(:mod:`spacecraft._fused`) and the actuators' own compiled steps
(:meth:`spacecraft.cmg_dynamics.VscmgActuator._rkmk4_kernel`), which must not import the fused
loop."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

#: compiled entry points, per argument types (a function argument's type is its seam's function
#: type, so one compiled loop or step serves every law and every torque)
_ENTRIES: dict[tuple, Callable[..., Any]] = {}  # by a cheap key of the argument types


def torque_signature() -> Any:
    """The seam's :data:`spacecraft.disturbance_kernel.TORQUE_SIGNATURE` (imported on use)."""
    from .disturbance_kernel import TORQUE_SIGNATURE

    return TORQUE_SIGNATURE


def fn_entry(
    func: Any, args: tuple, fn_sigs: dict[int, Any], tag: tuple = ()
) -> Callable[..., Any]:
    """The compiled entry point of the numba dispatcher ``func`` for these argument types, the
    arguments at the indices of ``fn_sigs`` typed as first-class functions of the given numba
    signatures (compiled once per argument types, cached on disk): one compiled loop or step
    serves every law and every disturbance torque."""
    # a cheap key first (numba's typeof costs ~10 µs per argument)
    key = (
        (id(func),)
        + tag
        + tuple(
            (a.dtype.char, a.ndim, a.flags.c_contiguous, a.flags.writeable, a.flags.aligned)
            if isinstance(a, np.ndarray)
            else type(a)
            for i, a in enumerate(args)
            if i not in fn_sigs
        )
    )
    entry = _ENTRIES.get(key)
    if entry is None:
        import numba
        from numba.core import types

        sig = tuple(
            types.FunctionType(fn_sigs[i]) if i in fn_sigs else numba.typeof(a)
            for i, a in enumerate(args)
        )
        if sig not in func.overloads:
            func.compile(sig)
        entry = func.overloads[sig].entry_point
        _ENTRIES[key] = entry
    return entry
