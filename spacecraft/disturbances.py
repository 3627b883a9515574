"""Disturbance torques on the spacecraft body.

A disturbance source is any callable ``source(t, R, omega) -> (B, 3)`` giving the external torque
about the centre of mass in body axes [N·m], for time ``t`` [s], attitude ``R`` ``(B, 3, 3)``
(body → inertial) and body rate ``omega`` ``(B, 3)``. The plant evaluates it at every integration
stage, so sources must be pure functions of their arguments. The library:

- here: :class:`ZeroDisturbance`, :class:`ConstantTorque`, :class:`ConstantHarmonicTorque` (Wu,
  Huang, Wei & Guo) and the composition :class:`SumOfDisturbances`;
- :class:`spacecraft.environment.GravityGradientTorque` (state-dependent);
- :mod:`spacecraft.surface_forces`: :class:`~spacecraft.surface_forces.AerodynamicTorque`,
  :class:`~spacecraft.surface_forces.SolarPressureTorque` (flat plates, exponential
  atmosphere, Sun ephemeris and eclipse) and :class:`~spacecraft.surface_forces.
  ResidualDipoleTorque` (m × B);
- :class:`spacecraft.payload.RotatingPayloadTorque` (Wang, Chu, Zhang & Yuan 2016);
- flexible appendage modes are not a torque source but extra plant states (they need ω̇):
  :class:`spacecraft.flexible.FlexibleModes`, passed as ``Spacecraft(..., modes=...)``;
- parameter uncertainty is on the controller's side: :func:`spacecraft.rigid_body.
  perturbed_inertia`.

Sources compose with :class:`SumOfDisturbances`, which also reports each source's torque
(:meth:`SumOfDisturbances.components`) for the logs.

Compiled: the simulator's fused loop (:mod:`spacecraft._fused`) runs :class:`ZeroDisturbance`
(or none), :class:`ConstantTorque` with one ``(3,)`` torque and :class:`ConstantHarmonicTorque`
as built-in time-only codes (:func:`disturbance_kernel`), and any source with a
``fused_kernel()`` method — :class:`spacecraft.environment.GravityGradientTorque`, the
surface and magnetic torques of :mod:`spacecraft.surface_forces`, the sources of this module
(inside a sum, or a per-spacecraft :class:`ConstantTorque`) and a user's own — through the
public seam :mod:`spacecraft.disturbance_kernel` (a numba-compiled torque of the stage attitude
and rate, called through a function pointer). A :class:`SumOfDisturbances` whose every source
has a kernel is compiled as their sum (:func:`spacecraft.disturbance_kernel.sum_kernel`, the
Python sum's order); a sum with a source without one keeps the Python loop, and ``simulate``'s
log line names that source.

A source whose torque does not depend on the attitude sets the class attribute
``uses_attitude = False``: the plant then skips forming the attitude at the inner integration
stages (a subclass that does read ``R`` must set it back to ``True``). Sources without the
attribute are assumed to read ``R``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from liecontrol._array_api import namespace
from liecontrol._jit import njit
from liecontrol._validation import as_array, as_scalar, check_positive_scalar

from . import _kernels as K
from .disturbance_kernel import DisturbanceKernel, check, no_torque, resolve, sum_kernel

__all__ = [
    "DisturbanceSource",
    "ZeroDisturbance",
    "ConstantTorque",
    "ConstantHarmonicTorque",
    "SumOfDisturbances",
]

#: Type of a disturbance source: ``(t, R (B,3,3), omega (B,3)) -> torque (B,3)``.
DisturbanceSource = Callable[[float, np.ndarray, np.ndarray], np.ndarray]


@njit
def constant_torque_kernel(
    t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
) -> None:
    """The seam's torque (:mod:`spacecraft.disturbance_kernel`) of :class:`ConstantTorque`:
    ``params = (τ_x, τ_y, τ_z)``, this spacecraft's row."""
    out[0] = params[0]
    out[1] = params[1]
    out[2] = params[2]


@njit
def constant_harmonic_kernel(
    t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
) -> None:
    """The seam's torque of :class:`ConstantHarmonicTorque`, ``params = (n, scale)``: the loop's
    built-in code's formula (:func:`spacecraft._kernels.disturbance_at`), one implementation."""
    a, b, c = K.disturbance_at(K.DIST_CONSTANT_HARMONIC, params, t)
    out[0] = a
    out[1] = b
    out[2] = c


@dataclass(frozen=True)
class ZeroDisturbance:
    """No external torque."""

    uses_attitude: ClassVar[bool] = False

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        return np.zeros(omega.shape)

    def fused_kernel(self) -> DisturbanceKernel:
        """The zero torque of the seam (alone, the loop's built-in code runs instead)."""
        return DisturbanceKernel(no_torque, np.zeros(0), uses_attitude=False)


@dataclass(frozen=True)
class ConstantTorque:
    """A body-fixed constant torque ``(3,)`` (same for every spacecraft) or ``(B, 3)`` [N·m]."""

    uses_attitude: ClassVar[bool] = False

    torque: np.ndarray

    def __post_init__(self) -> None:
        T = as_array(self.torque, "torque", (3,)).copy()
        if T.ndim not in (1, 2):
            raise ValueError(f"torque: expected shape (3,) or (B, 3), got {T.shape}")
        T.setflags(write=False)
        object.__setattr__(self, "torque", T)

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        # broadcast_to gives a read-only view; the plant only reads it
        return np.broadcast_to(self.torque, omega.shape)

    def fused_kernel(self) -> DisturbanceKernel:
        """:func:`constant_torque_kernel` with the torque as parameters, one row per spacecraft
        for a ``(B, 3)`` torque (one ``(3,)`` torque alone runs the loop's built-in code)."""
        return DisturbanceKernel(
            constant_torque_kernel, np.array(self.torque, dtype=np.float64), uses_attitude=False
        )


@dataclass(frozen=True)
class ConstantHarmonicTorque:
    """Constant + harmonic body torque of Wu, Huang, Wei & Guo, orbit rate ``n``:

        T_d = (0.02 + 0.02 sin nt + 0.01 sin 2nt,
               0.08 + 0.04 sin nt + 0.01 sin 2nt,
               0.02 + 0.02 sin nt + 0.01 sin 2nt)  · scale   [N·m]

    Args:
        n: orbit rate [rad/s] (default 0.0011).
        scale: multiplies the whole torque (robustness sweeps; 1 = the paper's values).
    """

    uses_attitude: ClassVar[bool] = False

    n: float = 0.0011
    scale: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "n", check_positive_scalar(self.n, "n"))
        s = as_scalar(self.scale, "scale")
        object.__setattr__(self, "scale", s)

    def torque_at(self, t: float) -> np.ndarray:
        """The ``(3,)`` torque at time ``t`` (identical for every spacecraft). ``t`` may be a
        JAX scalar (the differentiable loop, :mod:`spacecraft.differentiable`): the same
        formula runs on ``jax.numpy``."""
        xp = namespace(t)
        if xp is np:
            t = as_scalar(t, "t")  # a Python float passes at the cost of one type test
            sin = math.sin
        else:
            sin = xp.sin
        s1 = sin(self.n * t)
        s2 = sin(2.0 * self.n * t)
        c = self.scale
        rows = [
            c * (0.02 + 0.02 * s1 + 0.01 * s2),
            c * (0.08 + 0.04 * s1 + 0.01 * s2),
            c * (0.02 + 0.02 * s1 + 0.01 * s2),
        ]
        return np.array(rows) if xp is np else xp.stack(rows)

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        return np.broadcast_to(self.torque_at(t), omega.shape)

    def fused_kernel(self) -> DisturbanceKernel:
        """:func:`constant_harmonic_kernel` with ``(n, scale)`` (alone, the loop's built-in code
        runs instead; in a :class:`SumOfDisturbances` this kernel)."""
        return DisturbanceKernel(
            constant_harmonic_kernel, np.array([self.n, self.scale]), uses_attitude=False
        )


def disturbance_kernel(dist: object) -> tuple[int, np.ndarray] | None:
    """``(code, params)`` of a disturbance with a compiled kernel
    (:func:`spacecraft._kernels.disturbance_at`: none, one constant torque for the batch, the
    constant + harmonic torque), else ``None``. Exact types only (a subclass may override)."""
    from ._kernels import DIST_CONSTANT, DIST_CONSTANT_HARMONIC, DIST_NONE

    if dist is None or type(dist) is ZeroDisturbance:
        return DIST_NONE, np.zeros(3)
    if type(dist) is ConstantHarmonicTorque:
        return DIST_CONSTANT_HARMONIC, np.array([dist.n, dist.scale, 0.0])
    if type(dist) is ConstantTorque and np.shape(dist.torque) == (3,):
        return DIST_CONSTANT, np.array(dist.torque, dtype=np.float64)
    return None


def disturbance_plan(
    dist: object, batch_size: int | None
) -> tuple[tuple[int, np.ndarray, object, np.ndarray, bool] | None, str]:
    """``((code, code params, torque, kernel params (B', n_p), uses attitude), "")`` of a
    disturbance for the compiled steps — a built-in time-only code (:func:`disturbance_kernel`;
    the torque the placeholder :func:`spacecraft.disturbance_kernel.no_torque`) or a torque of
    the seam (:mod:`spacecraft.disturbance_kernel`, code ``DIST_KERNEL``, checked for a batch of
    ``batch_size``: ``ValueError`` naming the disturbance and the argument) — else ``(None,
    why)``. The one resolution behind the momentum model's and the full CMG model's plans."""
    coded = disturbance_kernel(dist)
    if coded is not None:
        return (coded[0], coded[1], no_torque, np.zeros((1, 0)), False), ""
    spec, why = resolve(dist)
    if spec is None:
        return None, why
    params = check(dist, spec, batch_size)
    return (K.DIST_KERNEL, np.zeros(3), spec.torque, params, bool(spec.uses_attitude)), ""


def managed_disturbance_plan(
    dist: object, management: object, batch_size: int | None
) -> tuple[tuple[object, np.ndarray, int] | None, str]:
    """The compiled loops' torque of a plant with momentum management: ``((torque, rows
    (B', n_p), offset), "")`` — the management's torque of the seam (its ``fused_kernel()``,
    e.g. :meth:`spacecraft.momentum.CrossProductDumping.fused_kernel`) composed after the
    disturbance's (as :func:`spacecraft.disturbance_kernel.sum_kernel` composes a sum: the
    disturbance first, then ``+=`` the management's), their rows side by side, ``offset`` the
    column where the management's block starts (the loop writes its held dipole there) — else
    ``(None, why)``."""
    from .disturbance_kernel import _combined

    label = type(management).__name__
    hook = getattr(management, "fused_kernel", None)
    mspec = hook() if callable(hook) else None
    if mspec is None:
        return None, f"the plant's momentum management {label} has no compiled kernel"
    mrow = check(management, mspec, None)
    if dist is None:
        return (mspec.torque, mrow, 0), ""
    dspec, why = resolve(dist)
    if dspec is None:
        return None, why
    drow = check(dist, dspec, batch_size)
    n = max(drow.shape[0], mrow.shape[0])
    rows = np.concatenate(
        [np.broadcast_to(drow, (n, drow.shape[1])), np.broadcast_to(mrow, (n, mrow.shape[1]))],
        axis=1,
    )
    torque = _combined(dspec.torque, mspec.torque, drow.shape[1])
    return (torque, np.ascontiguousarray(rows), drow.shape[1]), ""


def loop_disturbance_plan(
    dist: object, management: object, batch_size: int | None
) -> tuple[tuple[int, np.ndarray, object, np.ndarray, bool] | None, int, str]:
    """The compiled loops' disturbance plan of a plant, ``(plan, mm_at, why)``: with momentum
    management its torque composed after the disturbance's (:func:`managed_disturbance_plan`;
    ``plan`` a seam torque reading the attitude, ``mm_at`` the column where the management's
    block starts), else the disturbance's own plan (:func:`disturbance_plan`, ``mm_at`` −1);
    ``plan`` ``None`` with ``why`` when a part has no kernel. One resolution for the momentum
    model's, the full CMG model's and the wheels' plans."""
    if management is None:
        dk, why = disturbance_plan(dist, batch_size)
        return dk, -1, why
    got, why = managed_disturbance_plan(dist, management, batch_size)
    if got is None:
        return None, -1, why
    torque, rows, at = got
    return (K.DIST_KERNEL, np.zeros(3), torque, rows, True), at, ""


def kernel_rows(dist: object, params: np.ndarray, B: int) -> np.ndarray:
    """The seam torque's parameter rows ``params (B', n_p)`` for a batch of ``B``
    (``ValueError`` naming the disturbance when per-spacecraft rows do not match the batch)."""
    if params.shape[0] not in (1, B):
        raise ValueError(
            f"disturbance {type(dist).__name__}: kernel params must have shape "
            f"(n_p,) or ({B}, n_p) for a batch of {B}, got {params.shape}"
        )
    return params


@dataclass(frozen=True)
class SumOfDisturbances:
    """Sum of named disturbance sources.

    Args:
        sources: mapping ``name -> source`` (or a sequence of sources, named ``"d0"``,
            ``"d1"``, ... ). Each source is a callable ``(t, R, omega) -> (B, 3)``.

    Example:
        >>> d = SumOfDisturbances({"bias": ConstantTorque([0.0, 0.1, 0.0]),
        ...                        "constant_harmonic": ConstantHarmonicTorque()})
        >>> d(0.0, np.eye(3)[None], np.zeros((1, 3)))
        array([[0.02, 0.18, 0.02]])
    """

    sources: Mapping[str, DisturbanceSource]
    _items: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        src = self.sources
        if not isinstance(src, Mapping):
            if isinstance(src, (str, bytes)) or not isinstance(src, Iterable):
                raise ValueError(
                    f"sources: expected a mapping name -> source or a sequence of sources, got "
                    f"{type(src).__name__}"
                )
            src = {f"d{i}": s for i, s in enumerate(src)}
        if len(src) == 0:
            raise ValueError("sources: at least one disturbance source is required")
        for name, s in src.items():
            if not callable(s):
                raise ValueError(f"sources: entry {name!r} is not callable")
        object.__setattr__(self, "sources", dict(src))
        object.__setattr__(self, "_items", tuple(src.items()))

    @property
    def uses_attitude(self) -> bool:
        """Whether any source reads the attitude (see the module docstring)."""
        return any(getattr(src, "uses_attitude", True) for _, src in self._items)

    def fused_kernel(self) -> DisturbanceKernel | None:
        """The compiled sum of the sources' kernels (:func:`spacecraft.disturbance_kernel.
        sum_kernel`, in the order of :meth:`__call__`), or ``None`` when a source has none
        (:meth:`kernel_reason` names it)."""
        return sum_kernel(self._items)[0]

    def kernel_reason(self) -> str:
        """Why the sum has no compiled kernel (``""`` when it has one): the first source
        without one, by name."""
        return sum_kernel(self._items)[1]

    def components(self, t: float, R: np.ndarray, omega: np.ndarray) -> dict[str, np.ndarray]:
        """Each source's torque ``(B, 3)``, by name."""
        return {name: np.asarray(s(t, R, omega)) for name, s in self._items}

    def __call__(self, t: float, R: np.ndarray, omega: np.ndarray) -> np.ndarray:
        items = self._items
        total = np.array(items[0][1](t, R, omega), dtype=np.float64)  # copy: sources may be views
        for _, s in items[1:]:
            total += s(t, R, omega)
        return total
