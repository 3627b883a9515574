"""Thin object layer over :mod:`so3` / :mod:`se3` (jaxlie-style): immutable, validated elements.

``SO3`` wraps one ``(..., 3, 3)`` array and ``SE3`` one ``(..., 4, 4)`` array (a batch of elements
is one object). Constructing from a user array validates it (SPEC §9: finite, orthonormal within
1e-9, det +1, and for SE(3) last row (0, 0, 0, 1)) and raises ``ValueError`` naming the argument;
results of group operations skip re-validation. The stored array is a read-only copy.

The array functions in :mod:`liecontrol.lie.so3` / :mod:`liecontrol.lie.se3` stay the fast path;
this layer is for readable user code::

    R = SO3.exp([0.0, 0.0, np.pi / 2])
    g = SE3.from_rt(R, [1.0, 0.0, 0.0])
    (g @ g.inverse()).log()            # ≈ zeros(6)
    g @ np.array([0.0, 1.0, 0.0])      # acts on points
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import overload

import numpy as np

from . import se3, so3

__all__ = ["SO3", "SE3"]


def _frozen(a: np.ndarray) -> np.ndarray:
    """A read-only float64 copy (the wrappers are immutable, so their arrays must be too)."""
    out = np.array(a, dtype=np.float64, copy=True)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class SO3:
    """Rotation(s) R ∈ SO(3), body → reference, as a ``(..., 3, 3)`` array.

    ``SO3(R)`` validates R (``ValueError`` starting with ``"R:"``); use :meth:`project` for
    matrices that are only approximately orthonormal.
    """

    R: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "R", _frozen(so3.validate(self.R, "R")))

    @classmethod
    def _wrap(cls, R: np.ndarray) -> SO3:
        # results of group operations on valid elements are valid: skip the O(n) re-check
        obj = object.__new__(cls)
        object.__setattr__(obj, "R", _frozen(R))
        return obj

    # constructors
    @classmethod
    def identity(cls, batch_shape: tuple[int, ...] = ()) -> SO3:
        """Identity rotation(s) with the given batch shape."""
        return cls._wrap(so3.identity(batch_shape))

    @classmethod
    def exp(cls, w: object) -> SO3:
        """exp(ω^) for rotation vectors ``(..., 3)`` (Rodrigues)."""
        return cls._wrap(so3.exp(w))

    @classmethod
    def from_matrix(cls, R: object) -> SO3:
        """Validated wrapper of a rotation matrix array (same as ``SO3(R)``)."""
        return cls(np.asarray(R))

    @classmethod
    def project(cls, M: object) -> SO3:
        """Nearest rotation to M in the Frobenius norm (SVD)."""
        return cls._wrap(so3.project(M))

    @classmethod
    def random(cls, rng: np.random.Generator, size: int | tuple[int, ...] = ()) -> SO3:
        """Haar-uniform random rotation(s)."""
        return cls._wrap(so3.random(rng, size))

    # queries
    @property
    def batch_shape(self) -> tuple[int, ...]:
        return tuple(self.R.shape[:-2])

    def __len__(self) -> int:
        if not self.batch_shape:
            raise TypeError("len() of an unbatched SO3")
        return self.batch_shape[0]

    def __getitem__(self, index: object) -> SO3:
        R = self.R[index]
        if R.ndim < 2 or R.shape[-2:] != (3, 3):
            raise IndexError("index: may only select along the batch dimensions")
        return SO3._wrap(R)

    def as_matrix(self) -> np.ndarray:
        """The rotation matrices, ``(..., 3, 3)`` (a writable copy)."""
        return np.array(self.R, copy=True)

    def log(self) -> np.ndarray:
        """Rotation vectors ``(..., 3)`` with norm in [0, π]."""
        return so3.log(self.R)

    def angle(self) -> np.ndarray:
        """Rotation angles in [0, π]."""
        return so3.angle(self.R)

    def adjoint(self) -> np.ndarray:
        """Ad_R = R (3×3)."""
        return so3.adjoint(self.R)

    # group operations
    def inverse(self) -> SO3:
        return SO3._wrap(so3.inverse(self.R))

    def apply(self, p: object) -> np.ndarray:
        """R p for points/vectors ``(..., 3)``."""
        return so3.act(self.R, p)

    @overload
    def __matmul__(self, other: SO3) -> SO3: ...

    @overload
    def __matmul__(self, other: np.ndarray) -> np.ndarray: ...

    def __matmul__(self, other: object) -> SO3 | np.ndarray:
        """``R1 @ R2`` composes; ``R @ p`` rotates points ``(..., 3)``."""
        if isinstance(other, SO3):
            return SO3._wrap(so3.compose(self.R, other.R))
        if isinstance(other, SE3):
            return NotImplemented
        return self.apply(other)

    def distance(self, other: SO3) -> np.ndarray:
        """Geodesic angle between the rotations, in [0, π]."""
        return so3.distance(self.R, other.R)

    def interpolate(self, other: SO3, s: object) -> SO3:
        """Geodesic (slerp) from self (s = 0) to other (s = 1)."""
        return SO3._wrap(so3.interpolate(self.R, other.R, s))

    def __repr__(self) -> str:
        return f"SO3(batch_shape={self.batch_shape}, R={np.array2string(self.R, precision=6)})"


@dataclass(frozen=True, eq=False)
class SE3:
    """Rigid motion(s) g = [[R, p], [0, 1]] ∈ SE(3) as a ``(..., 4, 4)`` array; twists are
    ordered (ω, v). ``SE3(g)`` validates g (``ValueError`` starting with ``"g:"``)."""

    g: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "g", _frozen(se3.validate(self.g, "g")))

    @classmethod
    def _wrap(cls, g: np.ndarray) -> SE3:
        obj = object.__new__(cls)
        object.__setattr__(obj, "g", _frozen(g))
        return obj

    # constructors
    @classmethod
    def identity(cls, batch_shape: tuple[int, ...] = ()) -> SE3:
        return cls._wrap(se3.identity(batch_shape))

    @classmethod
    def exp(cls, xi: object) -> SE3:
        """exp(ξ^) for twists ``(..., 6)`` ordered (ω, v)."""
        return cls._wrap(se3.exp(xi))

    @classmethod
    def from_matrix(cls, g: object) -> SE3:
        """Validated wrapper of a homogeneous matrix array (same as ``SE3(g)``)."""
        return cls(np.asarray(g))

    @classmethod
    def from_rt(cls, R: SO3 | object, p: object) -> SE3:
        """[[R, p], [0, 1]]; a plain array R is validated (error names ``R``)."""
        Rm = R.R if isinstance(R, SO3) else so3.validate(R, "R")
        return cls._wrap(se3.from_rt(Rm, p))

    @classmethod
    def random(
        cls,
        rng: np.random.Generator,
        size: int | tuple[int, ...] = (),
        translation_scale: float = 1.0,
    ) -> SE3:
        """Haar rotation and N(0, translation_scale²) translation components."""
        return cls._wrap(se3.random(rng, size, translation_scale))

    # queries
    @property
    def batch_shape(self) -> tuple[int, ...]:
        return tuple(self.g.shape[:-2])

    def __len__(self) -> int:
        if not self.batch_shape:
            raise TypeError("len() of an unbatched SE3")
        return self.batch_shape[0]

    def __getitem__(self, index: object) -> SE3:
        g = self.g[index]
        if g.ndim < 2 or g.shape[-2:] != (4, 4):
            raise IndexError("index: may only select along the batch dimensions")
        return SE3._wrap(g)

    def as_matrix(self) -> np.ndarray:
        """The homogeneous matrices, ``(..., 4, 4)`` (a writable copy)."""
        return np.array(self.g, copy=True)

    def rotation(self) -> SO3:
        return SO3._wrap(se3.rotation(self.g))

    def translation(self) -> np.ndarray:
        return se3.translation(self.g)

    def log(self) -> np.ndarray:
        """Twists ``(..., 6)`` = (ω, v) with ‖ω‖ ∈ [0, π]."""
        return se3.log(self.g)

    def adjoint(self) -> np.ndarray:
        """Ad_g (6×6, (ω, v) ordering)."""
        return se3.adjoint(self.g)

    # group operations
    def inverse(self) -> SE3:
        return SE3._wrap(se3.inverse(self.g))

    def apply(self, x: object) -> np.ndarray:
        """R x + p for points ``(..., 3)``."""
        return se3.act(self.g, x)

    @overload
    def __matmul__(self, other: SE3) -> SE3: ...

    @overload
    def __matmul__(self, other: np.ndarray) -> np.ndarray: ...

    def __matmul__(self, other: object) -> SE3 | np.ndarray:
        """``g1 @ g2`` composes; ``g @ x`` transforms points ``(..., 3)``."""
        if isinstance(other, SE3):
            return SE3._wrap(se3.compose(self.g, other.g))
        if isinstance(other, SO3):
            return NotImplemented
        return self.apply(other)

    def distance(self, other: SE3, length_scale: float = 1.0) -> np.ndarray:
        """√(θ² + (‖Δp‖/length_scale)²) (see :func:`se3.distance`)."""
        return se3.distance(self.g, other.g, length_scale)

    def interpolate(self, other: SE3, s: object) -> SE3:
        """Screw-motion geodesic from self (s = 0) to other (s = 1)."""
        return SE3._wrap(se3.interpolate(self.g, other.g, s))

    def __repr__(self) -> str:
        return f"SE3(batch_shape={self.batch_shape}, g={np.array2string(self.g, precision=6)})"
