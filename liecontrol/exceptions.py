"""Exceptions raised by liecontrol."""

from __future__ import annotations

__all__ = ["ChartSingularityError"]


class ChartSingularityError(ValueError):
    """A chart (Euler angles, MRP without switching, ...) is evaluated at its singularity.

    Raised instead of returning NaN or an ill-conditioned result.
    """
