"""Reference trajectories: callables ``t -> AttitudeReference``."""

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
