"""Thin object layer over :mod:`so3` / :mod:`se3` (jaxlie-style): immutable, validated elements.

``SO3`` wraps one ``(..., 3, 3)`` array and ``SE3`` one ``(..., 4, 4)`` array (a batch of elements
is one object). Constructing from a user array validates it (finite, orthonormal within
1e-9, det +1, and for SE(3) last row (0, 0, 0, 1)) and raises ``ValueError`` naming the argument;
results of group operations skip re-validation. The stored array is a read-only copy.

The array functions in :mod:`liecontrol.lie.so3` / :mod:`liecontrol.lie.se3` stay the fast path;
this layer is for readable user code::

    R = SO3.exp([0.0, 0.0, np.pi / 2])
    g = SE3.from_rt(R, [1.0, 0.0, 0.0])
    (g @ g.inverse()).log()            # ≈ zeros(6)
    g @ np.array([0.0, 1.0, 0.0])      # acts on points

scipy users find the verbs of ``scipy.spatial.transform.Rotation`` on :class:`SO3`
(``from_quat``/``as_quat``, ``from_euler``/``as_euler``, ``from_rotvec``/``as_rotvec``,
``from_matrix``/``as_matrix``, ``inv``, ``random``, ``magnitude``, ``mean``) and
``from_scipy``/``as_scipy`` on both classes (``SE3`` ⇄ scipy's ``RigidTransform``). Where the
conventions differ it is said on the method; the main one: **our quaternions are scalar-first
(w, x, y, z) by default**, scipy's are scalar-last, and both take ``scalar_first=``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import overload

import numpy as np

from .._validation import as_array, as_int, check_bool
from . import se3, so3

__all__ = ["SO3", "SE3"]


def _rng(rng: object) -> np.random.Generator:
    """scipy's ``rng`` argument: a Generator, an int seed, or ``None`` (fresh OS entropy)."""
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None:
        return np.random.default_rng()
    if isinstance(rng, (bool, np.bool_)) or not isinstance(rng, (int, np.integer)):
        raise TypeError(
            f"rng: expected a numpy.random.Generator, an int seed or None, got {type(rng).__name__}"
        )
    if rng < 0:
        raise ValueError(f"rng: an int seed must be >= 0, got {rng}")
    return np.random.default_rng(int(rng))


def _num_shape(num: object) -> tuple[int, ...]:
    """scipy's ``num``: ``None`` → one element, an int n → a stack of n."""
    return () if num is None else (as_int(num, "num", minimum=0),)


def _deg(x: np.ndarray, degrees: bool, to_rad: bool) -> np.ndarray:
    if not check_bool(degrees, "degrees"):
        return x
    return np.deg2rad(x) if to_rad else np.rad2deg(x)


def _scipy_class(name: str) -> type:
    from scipy.spatial import transform  # scipy is a dependency; imported only when used

    cls = getattr(transform, name, None)
    if cls is None:  # RigidTransform appeared in scipy 1.16
        raise ImportError(
            f"scipy.spatial.transform.{name} is not available in the installed scipy; "
            "upgrade scipy (>= 1.16) to convert rigid motions"
        )
    return cls


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
        """Validated wrapper of a rotation matrix array (same as ``SO3(R)``). Unlike scipy,
        which orthonormalises any matrix, a matrix off SO(3) by more than 1e-9 raises; use
        :meth:`project` for the nearest rotation."""
        return cls(R)

    @classmethod
    def project(cls, M: object) -> SO3:
        """Nearest rotation to M in the Frobenius norm (SVD)."""
        return cls._wrap(so3.project(M))

    @classmethod
    def random(
        cls,
        num: int | None = None,
        rng: np.random.Generator | int | None = None,
        *,
        size: int | tuple[int, ...] | None = None,
    ) -> SO3:
        """Haar-uniform random rotation(s), with scipy's signature ``random(num, rng)``.

        ``num``: ``None`` for one rotation, an int n for a stack of n (``size=`` gives any batch
        shape instead); ``rng``: a ``numpy.random.Generator``, an int seed, or ``None`` for
        fresh OS entropy (as scipy). The older order ``SO3.random(generator, size)`` is still
        accepted. The draws come from :func:`so3.random` (QR of a Gaussian matrix), so they are
        not the same numbers as scipy's for the same seed — the distribution is.
        """
        if isinstance(num, np.random.Generator):  # legacy order random(rng, size)
            if size is not None:
                raise TypeError("size: given twice (positionally after a Generator and by name)")
            gen, shape = num, (() if rng is None else rng)
        else:
            if size is not None and num is not None:
                raise TypeError("num: give either num or size, not both")
            gen = _rng(rng)
            shape = size if size is not None else _num_shape(num)
        return cls._wrap(so3.random(gen, shape))  # type: ignore[arg-type]

    # scipy-style constructors and views
    @classmethod
    def from_scipy(cls, rotation: object) -> SO3:
        """From a ``scipy.spatial.transform.Rotation`` (single → batch shape ``()``, stacked of
        length N → ``(N,)``)."""
        Rot = _scipy_class("Rotation")
        if not isinstance(rotation, Rot):
            raise TypeError(
                f"rotation: expected scipy.spatial.transform.Rotation, got "
                f"{type(rotation).__name__}"
            )
        return cls(np.asarray(rotation.as_matrix(), dtype=np.float64))

    def as_scipy(self) -> object:
        """The same rotation(s) as a ``scipy.spatial.transform.Rotation`` (same batch shape)."""
        return _scipy_class("Rotation").from_matrix(self.R)

    @classmethod
    def from_quat(cls, quat: object, *, scalar_first: bool = True) -> SO3:
        """From quaternions ``(..., 4)``. **Scalar-first (w, x, y, z) by default** — scipy's
        default is scalar-last; pass ``scalar_first=False`` for scipy's order. As scipy,
        non-unit quaternions are normalised (a zero quaternion raises ``"q: zero ..."``)."""
        from ..charts import quaternion

        q = quaternion.normalize(quat, scalar_first=scalar_first)
        return cls._wrap(quaternion.to_matrix(q, scalar_first=scalar_first))

    def as_quat(self, canonical: bool = True, *, scalar_first: bool = True) -> np.ndarray:
        """Unit quaternions ``(..., 4)``, **scalar-first by default** (scipy: scalar-last).

        Always the canonical sign (w ≥ 0; for w = 0 the first non-zero of x, y, z positive,
        as scipy's ``canonical=True``): a rotation matrix does not carry the ±q sign, so
        ``canonical=False`` (accepted for scipy compatibility) returns the same.
        """
        from ..charts import quaternion

        check_bool(canonical, "canonical")
        return quaternion.from_matrix(self.R, scalar_first=scalar_first)

    @classmethod
    def from_euler(cls, seq: str, angles: object, degrees: bool = False) -> SO3:
        """From Euler angles ``(..., 3)``; ``seq`` as scipy: upper case intrinsic (``"ZYX"`` =
        aerospace 3-2-1), lower case extrinsic (see :mod:`liecontrol.charts.euler`)."""
        from ..charts import euler

        a = _deg(as_array(angles, "angles", (3,)), degrees, to_rad=True)
        return cls._wrap(euler.to_matrix(a, seq))

    def as_euler(self, seq: str, degrees: bool = False) -> np.ndarray:
        """Euler angles ``(..., 3)`` of ``seq`` (scipy's ranges and gimbal-lock rule)."""
        from ..charts import euler

        return _deg(euler.from_matrix(self.R, seq), degrees, to_rad=False)

    @classmethod
    def from_rotvec(cls, rotvec: object, degrees: bool = False) -> SO3:
        """From rotation vectors ``(..., 3)`` (= :meth:`exp`)."""
        return cls._wrap(so3.exp(_deg(as_array(rotvec, "rotvec", (3,)), degrees, to_rad=True)))

    def as_rotvec(self, degrees: bool = False) -> np.ndarray:
        """Rotation vectors ``(..., 3)`` with norm in [0, π] (= :meth:`log`)."""
        return _deg(self.log(), degrees, to_rad=False)

    def magnitude(self) -> np.ndarray:
        """Rotation angle(s) in [0, π] (= :meth:`angle`; scipy's name)."""
        return self.angle()

    def inv(self) -> SO3:
        """The inverse (= :meth:`inverse`; scipy's name)."""
        return self.inverse()

    def mean(self, weights: object = None) -> SO3:
        """Chordal L2 mean of a stack ``(N,)``: argmin over R of Σ wᵢ ‖R − Rᵢ‖_F², i.e. the
        rotation nearest (Frobenius) to Σ wᵢ Rᵢ (Markley et al., "Averaging quaternions",
        J. Guid. Control Dyn. 30(4), 2007, show this equals the eigenvector solution scipy
        uses). ``weights``: ``(N,)``, non-negative, not all zero; default equal.
        """
        if len(self.batch_shape) != 1:
            raise ValueError(
                f"self: mean needs a stack of shape (N,), got batch shape {self.batch_shape}"
            )
        n = self.batch_shape[0]
        if n == 0:
            raise ValueError("self: the mean of an empty stack is undefined")
        if weights is None:
            w = np.full(n, 1.0 / n)
        else:
            w = as_array(weights, "weights")
            if w.shape != (n,):
                raise ValueError(f"weights: expected shape ({n},), got {w.shape}")
            if np.any(w < 0):
                raise ValueError("weights: must be non-negative")
            if not np.any(w > 0):
                raise ValueError("weights: must not all be zero")
        M = np.einsum("n,nij->ij", w, self.R)
        return SO3._wrap(so3.project(M))

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
        return cls(g)

    @classmethod
    def from_scipy(cls, transform: object) -> SE3:
        """From a ``scipy.spatial.transform.RigidTransform`` (scipy ≥ 1.16), single or stacked.
        scipy's transform maps x ↦ R x + p like ours, so the matrices are the same."""
        RT = _scipy_class("RigidTransform")
        if not isinstance(transform, RT):
            raise TypeError(
                f"transform: expected scipy.spatial.transform.RigidTransform, got "
                f"{type(transform).__name__}"
            )
        return cls(np.asarray(transform.as_matrix(), dtype=np.float64))

    def as_scipy(self) -> object:
        """The same motion(s) as a ``scipy.spatial.transform.RigidTransform`` (scipy ≥ 1.16).
        Note scipy's twists (``as_exp_coords``) are ordered (ω, v) like ours."""
        return _scipy_class("RigidTransform").from_matrix(self.g)

    def inv(self) -> SE3:
        """The inverse (= :meth:`inverse`; scipy's name)."""
        return self.inverse()

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
