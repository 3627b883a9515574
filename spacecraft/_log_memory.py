"""The simulation log's memory: every array of one run's log carved from one allocation.

Why one block: a single run logging every step writes a few megabytes of log, and a fresh page
costs a page fault at its first write (≈ 2 µs each on the build machine, a virtual machine:
600 faults, a third of a 6 000-step run of the SGCMG loop with the geometric PD, measured with
``resource.getrusage``; docs/performance.md). Allocated as a dozen separate arrays, each above
glibc's threshold for mapping memory of its own, the log is mapped and unmapped again at every
run, so every run pays the faults anew. As one block, glibc raises its threshold to the block's
size after the first run is freed and serves the next run of that size from memory it keeps; a
block of at least 4 MiB is also one NumPy marks for transparent huge pages (one fault per 2 MiB
where the system allows them). The arrays are disjoint, C-contiguous views; a result keeps the
whole block alive as long as any of its arrays is referenced.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["carve"]

#: each array starts on a cache line
_ALIGN = 64


def carve(shapes: Mapping[str, tuple[tuple[int, ...], Any]]) -> dict[str, np.ndarray]:
    """``{name: array}`` of the given ``(shape, dtype)`` carved from one uninitialised
    allocation (module docstring), in the order given; each array C-contiguous, aligned to
    64 bytes and disjoint from the others."""
    layout = []
    total = 0
    for name, (shape, dtype) in shapes.items():
        dt = np.dtype(dtype)
        count = int(np.prod(shape, dtype=np.int64)) if len(shape) else 1
        if count < 0 or any(int(s) < 0 for s in shape):
            raise ValueError(f"{name}: negative log dimension {shape}")
        layout.append((name, tuple(int(s) for s in shape), dt, total, count * dt.itemsize))
        total += -(-count * dt.itemsize // _ALIGN) * _ALIGN
    block = np.empty(total + _ALIGN, dtype=np.uint8)
    start = (-block.ctypes.data) % _ALIGN
    return {
        name: block[start + off : start + off + nbytes].view(dt).reshape(shape)
        for name, shape, dt, off, nbytes in layout
    }
