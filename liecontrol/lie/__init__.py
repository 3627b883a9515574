"""Lie groups SO(3) and SE(3): batched array functions (``so3``, ``se3``, the fast path) and the
validated object layer (``SO3``, ``SE3``). See ``docs/lie.md``."""

from . import se3, so3
from .groups import SE3, SO3

__all__ = ["so3", "se3", "SO3", "SE3"]
