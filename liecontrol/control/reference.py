"""Reference trajectories: callables ``t -> AttitudeReference``.

Sampling protocol (optional, for speed). The simulator's compiled loop
(:func:`spacecraft.simulator.simulate`) reads the reference at every control sample and logged
step, and samples it before the loop starts. A reference that declares ``time_invariant = True``
(:class:`ConstantAttitude`) is sampled once. A time-varying one is called once per needed step
— a Python call of tens of µs each, more than a compiled step of one spacecraft — unless it
defines::

    def samples(self, times) -> tuple[R_d, omega_d, omega_dot_d]:
        ...

``times`` ``(N,)`` float64 → arrays with a leading time axis: ``R_d`` ``(N, 3, 3)`` or
``(N, B, 3, 3)``, ``omega_d`` and ``omega_dot_d`` ``(N, 3)`` or ``(N, B, 3)``, equal to
``self(times[k])`` sample by sample (to rounding). The simulator validates the arrays as it
validates each call's sample (rotations, finiteness, shapes; anything else sends the run to the
Python loop, which reports the reference's own error). Library references with it:
:class:`spacecraft.orbit.EarthPointingReference`,
:class:`liecontrol.control.adapters.RotatingFrame`,
:class:`liecontrol.control.slew_profile.EigenaxisSlewProfile` and the benchmark's
``ConstantRateReference``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .._validation import check_rotation_matrix
from .base import AttitudeReference

__all__ = ["ConstantAttitude"]


@dataclass(frozen=True)
class ConstantAttitude:
    """Regulation to a fixed attitude ``R_d`` (``(3, 3)`` or ``(B, 3, 3)``).

    ``time_invariant = True`` tells the simulator that every call returns the same reference, so
    its compiled loop samples it once instead of at every step (any reference callable may
    declare it; one that does must not depend on ``t``)."""

    time_invariant: ClassVar[bool] = True
    R_d: np.ndarray
    _ref: AttitudeReference = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        R = check_rotation_matrix(self.R_d, "R_d").copy()
        R.setflags(write=False)
        object.__setattr__(self, "R_d", R)
        object.__setattr__(self, "_ref", AttitudeReference.regulation(R))

    def __call__(self, t: float) -> AttitudeReference:
        return self._ref
