"""The compiler behind the per-step kernels: numba when it works, plain Python otherwise.

Every per-step formula (rigid-body and actuator dynamics, the RKMK4 step, steering laws, the
geometric PD family, chart conversions) is written once as a scalar kernel in the numba-compatible
subset of Python and decorated with :func:`njit`. With numba installed, kernels are compiled on
first call and cached to disk (``cache=True``), so a second process loads machine code instead of
recompiling. Without numba — or when ``LIECONTROL_DISABLE_JIT=1`` is set, or when numba fails to
compile on the platform — the same functions run as ordinary Python: identical results, slower,
and one :class:`RuntimeWarning` says so.

Kernels never validate: the public numpy API validates at the boundary and hands kernels finite
float64 arrays of the right shapes.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from typing import Any

__all__ = ["JIT_ENABLED", "njit", "prange"]


def _numba() -> Any:
    if os.environ.get("LIECONTROL_DISABLE_JIT", "").strip() not in ("", "0"):
        return None
    try:
        import numba
    except Exception as exc:  # ImportError, or a broken llvmlite on an unsupported platform
        warnings.warn(
            f"liecontrol: numba is unavailable ({exc.__class__.__name__}: {exc}); the per-step "
            "kernels run as plain Python (same results, slower); pip install numba to compile.",
            RuntimeWarning,
            stacklevel=3,
        )
        return None
    return numba


_NUMBA = _numba()

#: True when kernels are compiled by numba; False on the pure-Python fallback.
JIT_ENABLED: bool = _NUMBA is not None


def njit(*args: Any, **kwargs: Any) -> Callable[..., Any]:
    """``numba.njit(cache=True, …)`` when numba is available, else the identity decorator.

    Used bare (``@njit``) or with options (``@njit(parallel=True)``); ``cache`` defaults to True.
    """
    if _NUMBA is None:
        if len(args) == 1 and callable(args[0]) and not kwargs:
            return args[0]
        return lambda f: f
    kwargs.setdefault("cache", True)
    kwargs.setdefault("error_model", "numpy")  # x/0 -> inf/nan (checked by callers), not a raise
    if len(args) == 1 and callable(args[0]) and not kwargs.get("_options_only"):
        return _NUMBA.njit(**kwargs)(args[0])
    return _NUMBA.njit(*args, **kwargs)


prange = range if _NUMBA is None else _NUMBA.prange
