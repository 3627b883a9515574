"""Lie groups SO(3) and SE(3): batched array functions (``so3``, ``se3``)."""

from . import so3

__all__ = ["so3"]
