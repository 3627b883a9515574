"""Charts (local coordinates) of SO(3): conversions and kinematics.

Submodules, each a set of pure, batched functions:

* :mod:`~liecontrol.charts.quaternion` — unit quaternions, Hamilton product, scalar-first
  ``(w, x, y, z)`` by default (``scalar_first=False`` for scipy's ``(x, y, z, w)``);
* :mod:`~liecontrol.charts.mrp` — modified Rodrigues parameters with the shadow-set switch;
* :mod:`~liecontrol.charts.euler` — Euler angles, all 12 sequences in scipy notation;
* :mod:`~liecontrol.charts.rotvec` — rotation vector (exponential coordinates).

All use R body → inertial and ω the body angular velocity (Ṙ = R ω^). See ``docs/charts.md``.
"""

from __future__ import annotations

from ..exceptions import ChartSingularityError
from . import euler, mrp, quaternion, rotvec

__all__ = ["quaternion", "mrp", "euler", "rotvec", "ChartSingularityError"]
