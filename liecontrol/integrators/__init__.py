"""Integrators on Lie groups (SPEC §3).

- :mod:`.rk`: classical RK4 on ℝⁿ and RKMK4 (Runge–Kutta–Munthe-Kaas, order 4) on SO(3) × ℝⁿ —
  the plant's integrator; ``*_unchecked`` variants skip validation for hot loops.
- :mod:`.lgvi`: the rigid-body Lie-group variational integrator of Lee, Leok & McClamroch.

See ``docs/integrators.md``.
"""

from .lgvi import LGVIConvergenceError, LGVITrajectory, RigidBodyLGVI, lgvi_step
from .rk import (
    Trajectory,
    integrate,
    rk4_step,
    rk4_step_unchecked,
    rkmk4_step,
    rkmk4_step_unchecked,
)

__all__ = [
    "rk4_step",
    "rk4_step_unchecked",
    "rkmk4_step",
    "rkmk4_step_unchecked",
    "integrate",
    "Trajectory",
    "lgvi_step",
    "RigidBodyLGVI",
    "LGVITrajectory",
    "LGVIConvergenceError",
]
