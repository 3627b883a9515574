"""Integrators on Lie groups.

- :mod:`.rk`: classical RK4 on ℝⁿ and RKMK4 (Runge–Kutta–Munthe-Kaas, order 4) on SO(3) × ℝⁿ —
  the plant's integrator; ``*_unchecked`` variants skip validation for hot loops.
- :mod:`.lgvi`: the rigid-body Lie-group variational integrator of Lee, Leok & McClamroch.
- :mod:`.lgvi_se3`: the full-body LGVI on SE(3) (attitude–orbit coupled rigid body in gravity).
- :mod:`.rkmk_se3`: RKMK4 on SE(3) × ℝⁿ.

See ``docs/integrators.md``.
"""

from .lgvi import (
    LGVIConvergenceError,
    LGVITrajectory,
    RigidBodyLGVI,
    lgvi_step,
    lgvi_step_unchecked,
)
from .lgvi_se3 import SE3LGVITrajectory, SE3RigidBodyLGVI, lgvi_se3_step
from .rk import (
    Trajectory,
    integrate,
    rk4_step,
    rk4_step_unchecked,
    rkmk4_step,
    rkmk4_step_unchecked,
)
from .rkmk_se3 import SE3Trajectory, integrate_se3, rkmk4_se3_step, rkmk4_se3_step_unchecked

__all__ = [
    "rk4_step",
    "rk4_step_unchecked",
    "rkmk4_step",
    "rkmk4_step_unchecked",
    "integrate",
    "Trajectory",
    "lgvi_step",
    "lgvi_step_unchecked",
    "RigidBodyLGVI",
    "LGVITrajectory",
    "LGVIConvergenceError",
    "SE3RigidBodyLGVI",
    "SE3LGVITrajectory",
    "lgvi_se3_step",
    "rkmk4_se3_step",
    "rkmk4_se3_step_unchecked",
    "integrate_se3",
    "SE3Trajectory",
]
