"""liecontrol: geometric control of spacecraft on SO(3) and SE(3).

``JIT_ENABLED`` tells whether the per-step kernels are compiled by numba (``True``) or run as
plain Python (numba missing, or ``LIECONTROL_DISABLE_JIT=1``); see the performance page of the
documentation.
"""

from ._jit import JIT_ENABLED

__version__ = "0.1.0"

__all__ = ["JIT_ENABLED"]
