"""Small batched linear-algebra kernels shared by the hot paths.

``np.cross`` and ``np.einsum`` carry per-call overhead (axis handling, parsing) that dominates at
small batch sizes — a single spacecraft is a batch of one — so the simulator, controllers and
charts use these instead.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cross", "matvec"]

_P1 = np.array([1, 2, 0])
_P2 = np.array([2, 0, 1])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b on the last axis of ``(..., 3)`` arrays (broadcasting).

    ``a × b = a[[1,2,0]] b[[2,0,1]] − a[[2,0,1]] b[[1,2,0]]`` with ``take`` and in-place
    arithmetic: about 8× faster than ``np.cross`` for one vector and no slower for 1000.
    """
    p = a.take(_P1, axis=-1) * b.take(_P2, axis=-1)
    p -= a.take(_P2, axis=-1) * b.take(_P1, axis=-1)
    return p


def matvec(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Batched ``M @ v`` for ``(..., n, m)`` and ``(..., m)`` (broadcasting)."""
    return (M @ v[..., None])[..., 0]
