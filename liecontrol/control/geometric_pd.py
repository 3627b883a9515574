"""Geometric PD attitude controller on SO(3).

Control law (Lee 2012; Jiang, Meng & Yang 2023 Lemmas 2 and 4 in tracking form)::

    M = −K_R e_R − K_Ω e_Ω + Ω × JΩ − J (Ω^ RᵀR_d Ω_d − RᵀR_d Ω̇_d)

with ``(Ψ, e_R)`` any error function of :mod:`liecontrol.errors` (``"trace"``,
``"large_angle"``, ``"log"``) and ``e_Ω = Ω − RᵀR_d Ω_d``. On the rigid body
``J Ω̇ + Ω × JΩ = M`` with the controller's ``J`` equal to the plant's, the feed-forward terms cancel
the error dynamics exactly (``ė_Ω = Ω̇ + Ω × RᵀR_dΩ_d − RᵀR_dΩ̇_d``) and the closed loop is

    J ė_Ω = −K_R e_R − K_Ω e_Ω,     d/dt R̃ = R̃ e_Ω^.

With scalar gains, ``V = ½ e_Ωᵀ J e_Ω + (k_R / c) Ψ`` (``c`` from
:data:`liecontrol.errors.DERIVATIVE_FACTOR`) gives ``V̇ = −e_Ωᵀ K_Ω e_Ω ≤ 0``; the regions of
attraction that follow are in :mod:`liecontrol.control.region_of_attraction`.

Units: ``J`` [kg·m²], ``k_R`` [N·m per unit of e_R], ``k_Omega`` [N·m·s/rad], torque [N·m].
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._array_api import cross, namespace
from .._jit import JIT_ENABLED
from .._kernels.geometric_pd import (
    ERROR_CODES,
    geometric_pd_batch,
    geometric_pd_law,
    geometric_pd_one,
)
from .._validation import (
    as_array,
    as_scalar,
    check_bool,
    check_inertia_3x3,
    check_positive,
    check_positive_scalar,
    check_rotation_matrix,
    check_spd,
    rotations_pass_fast,
)
from ..errors import _KERNELS, DEFAULT_G, _check_kind, check_error_weight
from .array_law import ArrayLaw
from .base import (
    AttitudeController,
    AttitudeReference,
    AttitudeState,
    _vectors_pass,
    finite_command,
    validated_rotation_and_rate,
)
from .kernel import ControllerKernel

# geometric_pd_torque, the unchecked formula (NumPy or JAX arrays), is not part of __all__
__all__ = ["GeometricPD", "check_gain", "gains_from_bandwidth", "linear_error_slope"]


def check_gain(k: object, name: str) -> float | np.ndarray:
    """Validate a feedback gain: a positive scalar, a positive length-3 vector (diagonal gain) or a
    symmetric positive-definite 3×3 matrix. Scalars come back as ``float``, the others as 3×3."""
    a = as_array(k, name)
    if a.ndim == 0:
        return check_positive(a, name)
    if a.shape == (3,):
        check_positive(a, name)
        return np.diag(a)
    if a.shape != (3, 3):
        raise ValueError(f"{name}: expected a scalar, shape (3,) or (3, 3), got {a.shape}")
    check_spd(a, name, symbol="K", what="gain matrix ")
    return a.copy()


def linear_error_slope(error: str = "large_angle", G: object = None, which: str = "min") -> float:
    """Slope of ``e_R ≈ S δθ`` near ``R = R_d`` (``R̃ = exp(δθ^)``): the smallest (``which="min"``)
    or largest (``"max"``) eigenvalue of ``S``.

    log: ``S = I``; large_angle: ``e_R = sin(θ/2)·axis`` so ``S = ½ I``; trace:
    ``S = ½ (tr G · I − G)`` (eigenvalues ``½(tr G − g_i)``: 0.95 … 1.05 for the default ``G``).
    """
    error = _check_kind(error, "error")
    if not isinstance(which, str) or which not in ("min", "max"):
        raise ValueError(f"which: expected 'min' or 'max', got {which!r}")
    if G is not None:
        G = check_error_weight(G)  # checked even where unused: a bad G is a caller's bug
    if error == "log":
        return 1.0
    if error == "large_angle":
        return 0.5
    G = DEFAULT_G if G is None else G
    g = np.linalg.eigvalsh(G)
    return float(0.5 * (g.sum() - (g[-1] if which == "min" else g[0])))


def gains_from_bandwidth(
    J: object,
    omega_n: float,
    zeta: float = 1.0,
    error: str = "large_angle",
    G: object = None,
    matrix: bool = False,
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """PD gains from a desired natural frequency ``ω_n`` [rad/s] and damping ratio ``ζ``.

    Linearising the closed loop about ``R = R_d`` gives ``J δθ̈ + K_Ω δθ̇ + K_R S δθ = 0`` with
    ``S`` the error's slope, eigenvalues ``s_min ≤ s_max`` (:func:`linear_error_slope`;
    ``S = s I`` except for the trace error). With ``r = √(s_max / s_min)`` (1 unless trace):

    - ``matrix=False`` (scalar gains): ``k_R = ω_n² λ_max(J) / s_min``,
      ``k_Ω = 2 ζ ω_n λ_max(J) r``. For log and large-angle, the principal axis of largest
      inertia gets exactly ``(ω_n, ζ)`` and every other axis is faster and more damped
      (``ω_i = ω_n √(λ_max/J_i)``, ``ζ_i = ζ √(λ_max/J_i)``). For the trace error (J and G with
      common principal axes) every axis has natural frequency ≥ ω_n and damping ≥ ζ.
    - ``matrix=True``: ``K_R = ω_n² J / s_min``, ``K_Ω = 2 ζ ω_n r J``: then
      ``J⁻¹K_R S = ω_n² S / s_min`` for any J, so log and large-angle get exactly
      ``(ω_n, ζ)`` on every axis, and the trace error ω ≥ ω_n (equality on the slowest direction)
      and ζ ≥ ζ.

    The large-angle error saturates (``‖e_R‖ ≤ 1``), so large errors converge more slowly than
    the linear design suggests; check the regions of attraction of the chosen gains with
    :mod:`liecontrol.control.region_of_attraction`.
    """
    J = check_inertia_3x3(J, "J")
    omega_n = check_positive_scalar(omega_n, "omega_n")
    zeta = check_positive_scalar(zeta, "zeta")
    matrix = check_bool(matrix, "matrix")
    s_min = linear_error_slope(error, G, "min")
    r = float(np.sqrt(linear_error_slope(error, G, "max") / s_min))
    lam = float(np.linalg.eigvalsh(J)[-1])
    # the gains scale like ω_n² λ_max(J): check before they overflow (not an OverflowError)
    if not math.isfinite(omega_n * omega_n * lam / s_min) or not math.isfinite(
        2.0 * zeta * omega_n * r * lam
    ):
        raise ValueError(
            f"omega_n: the gains ω_n² λ_max(J)/s and 2 ζ ω_n λ_max(J) overflow float64 "
            f"(ω_n = {omega_n:.3g}, ζ = {zeta:.3g})"
        )
    if matrix:
        return omega_n**2 * J / s_min, 2.0 * zeta * omega_n * r * J
    return omega_n**2 * lam / s_min, 2.0 * zeta * omega_n * r * lam


# the controllers built on this law (constrained, PID, prescribed performance) import it here
_cross = cross


def _apply_gain(K: Any, x: Any) -> Any:
    """K x for a gain that is a scalar (``float`` or a 0-d array, e.g. a traced one) or 3×3."""
    if isinstance(K, float) or getattr(K, "ndim", 0) == 0:
        return K * x
    return x @ K.T


def _law_from_relative(
    Rt: Any, w: Any, w_d: Any, dw_d: Any, J: Any, k_R: Any, k_Omega: Any, error: str, G: Any
) -> tuple[Any, Any, Any, Any]:
    """``(M, Ψ, e_R, e_Ω)`` of the geometric PD law given ``R̃ = R_dᵀR`` ``(..., 3, 3)``; pure,
    NumPy or JAX (see :func:`geometric_pd_torque`). The error function is the unchecked one of
    :mod:`liecontrol.errors` for ``error``."""
    kernel = _KERNELS[error]
    Psi, e_R = kernel(Rt, G) if error == "trace" else kernel(Rt)
    # R̃ᵀ = RᵀR_d maps desired-body vectors into the body frame; (3,) references broadcast
    # against the (..., 3, 3) stack as a column
    RtT = namespace(Rt).swapaxes(Rt, -1, -2)
    w_d_body = (RtT @ w_d[..., None])[..., 0]
    dw_d_body = (RtT @ dw_d[..., None])[..., 0]
    e_W = w - w_d_body
    ff = cross(w, w @ J.T) - (cross(w, w_d_body) - dw_d_body) @ J.T
    M = ff - _apply_gain(k_R, e_R) - _apply_gain(k_Omega, e_W)
    return M, Psi, e_R, e_W


def geometric_pd_torque(
    R: Any,
    omega: Any,
    R_d: Any,
    omega_d: Any,
    omega_dot_d: Any,
    J: Any,
    k_R: Any,
    k_Omega: Any,
    error: str = "large_angle",
    G: Any = None,
) -> tuple[Any, Any, Any, Any]:
    """The geometric PD / tracking law as a pure array function (Lee 2012; Jiang, Meng & Yang
    2023 Lemma 4)::

        M = −K_R e_R − K_Ω e_Ω + Ω × JΩ − J (Ω^ RᵀR_d Ω_d − RᵀR_d Ω̇_d),  e_Ω = Ω − RᵀR_d Ω_d,

    with ``(Ψ, e_R)`` the ``"large_angle"``, ``"log"`` or ``"trace"`` error of ``R̃ = R_dᵀR``
    (:mod:`liecontrol.errors`; ``G`` the trace error's weight, default
    :data:`~liecontrol.errors.DEFAULT_G`, unused by the others). Returns ``(M, Ψ, e_R, e_Ω)``.

    Arrays broadcast over leading batch axes: ``R``, ``R_d`` ``(..., 3, 3)``, the rates
    ``(..., 3)``, ``J`` ``(3, 3)``, gains scalars or ``(3, 3)``. NumPy or JAX arrays alike (the
    same source runs under ``jax.jit``, ``vmap`` and ``grad``, with finite derivatives at
    R = R_d and near the antipodal set; :mod:`spacecraft.differentiable`). No validation (not
    in ``__all__``, like the ``*_unchecked`` functions): :class:`GeometricPD` is the validated
    object; this is the formula it evaluates.

    Sources: T. Lee, "Exponential stability of an attitude tracking control system on SO(3)
    for large-angle rotational maneuvers", Systems & Control Letters 61 (2012); D. E.
    Koditschek, "The application of total energy as a Lyapunov function for mechanical control
    systems", Contemporary Mathematics 97 (1989) (trace error); Jiang, Meng & Yang 2023,
    Lemma 4.
    """
    _check_kind(error, "error")
    if error == "trace" and G is None:
        G = DEFAULT_G
    Rt = namespace(R, R_d).swapaxes(R_d, -1, -2) @ R
    return _law_from_relative(Rt, omega, omega_d, omega_dot_d, J, k_R, k_Omega, error, G)


# ----------------------------------------------------------------------------------- hot path
# The simulator calls ``command`` at every control sample. Validation stays (the API promises
# it), but the common case — float64 arrays of the right shape that pass — is checked with a
# few cheap operations; anything that fails them goes through the canonical validators, which
# raise the usual messages (or convert, e.g. lists). One spacecraft runs on Python floats.


def validated_reference(
    holder: Any, reference: AttitudeReference, B: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(R_d, ω_d, ω̇_d)`` of a reference sample, validated for a batch of ``B``; ``holder``
    (a controller) caches, in ``_checked_R_d``, a read-only ``R_d`` it has already checked."""
    R_d = reference.R_d
    # a read-only array owning its data (e.g. ConstantAttitude's R_d) cannot change between
    # steps, so once validated it is not re-checked on this hot path
    if not (isinstance(R_d, np.ndarray) and R_d is holder._checked_R_d):
        # rotations_pass_fast checks the dtype and the (3, 3) tail itself
        if not (isinstance(R_d, np.ndarray) and R_d.ndim in (2, 3) and rotations_pass_fast(R_d)):
            R_d = check_rotation_matrix(R_d, "R_d")
        if not R_d.flags.writeable and R_d.base is None:
            holder._checked_R_d = R_d
    w_d = reference.omega_d
    if not _vectors_pass(w_d, np.shape(w_d)[:-1] + (3,)):
        w_d = as_array(w_d, "omega_d", (3,))
    dw_d = reference.omega_dot_d
    if not _vectors_pass(dw_d, np.shape(dw_d)[:-1] + (3,)):
        dw_d = as_array(dw_d, "omega_dot_d", (3,))
    for name, a, nd in (("R_d", R_d, 2), ("omega_d", w_d, 1), ("omega_dot_d", dw_d, 1)):
        if a.ndim == nd + 1 and a.shape[0] != B:
            raise ValueError(f"{name}: batch size {a.shape[0]} does not match state's {B}")
        if a.ndim > nd + 1:
            raise ValueError(f"{name}: expected one sample or a (B, ...) batch, got {a.shape}")
    return R_d, w_d, dw_d


def _as_matrix(K: float | np.ndarray) -> np.ndarray:
    """A gain as a contiguous 3×3 float64 matrix (a scalar k as k I)."""
    if isinstance(K, float):
        return K * np.eye(3)
    return np.ascontiguousarray(K, dtype=np.float64)


def _one(a: np.ndarray) -> np.ndarray:
    """The single sample of a reference array given unbatched or with a batch axis of 1."""
    a = np.asarray(a, dtype=np.float64)
    if a.shape in ((1, 3, 3), (1, 3)):
        a = a[0]
    return np.ascontiguousarray(a)


def _batch(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """A reference array broadcast to the batch ``shape`` (contiguous for the kernel)."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=np.float64), shape))


def _pd_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """``Psi``, ``e_R``, ``e_Omega`` from the kernel's rows ``(..., 7)``."""
    return {"Psi": rows[..., 0], "e_R": rows[..., 1:4], "e_Omega": rows[..., 4:7]}


class GeometricPD(AttitudeController):
    """Geometric PD / tracking controller on SO(3) (Jiang, Meng & Yang 2023 Lemmas 2, 4).

    ``M = −K_R e_R − K_Ω e_Ω + Ω × JΩ − J (Ω^ RᵀR_d Ω_d − RᵀR_d Ω̇_d)``.

    Args:
        J: 3×3 inertia the controller assumes [kg·m²] (may differ from the plant's).
        k_R: attitude gain: positive scalar, positive 3-vector (diagonal) or SPD 3×3 matrix.
        k_Omega: rate gain, same forms as ``k_R``.
        error: ``"large_angle"`` (default, Lee 2012), ``"log"`` (Bullo–Murray) or ``"trace"``
            (Koditschek).
        G: weight of the trace error (distinct positive eigenvalues; default
            :data:`liecontrol.errors.DEFAULT_G`); only allowed with ``error="trace"``.

    ``command`` returns ``(B, 3)``; ``diagnostics()`` returns the last ``Psi`` ``(B,)``,
    ``e_R`` ``(B, 3)`` and ``e_Omega`` ``(B, 3)``.
    """

    batched = True

    def __init__(
        self,
        J: object,
        k_R: object,
        k_Omega: object,
        error: str = "large_angle",
        G: object = None,
    ) -> None:
        J = check_inertia_3x3(J, "J")
        self.J = J.copy()
        self.J.setflags(write=False)
        self.k_R = check_gain(k_R, "k_R")
        self.k_Omega = check_gain(k_Omega, "k_Omega")
        self.error = _check_kind(error, "error")
        if G is not None and self.error != "trace":
            raise ValueError(f"G: only used by the 'trace' error function, not {self.error!r}")
        self.G = (
            None
            if self.error != "trace"
            else (DEFAULT_G if G is None else check_error_weight(G).copy())
        )
        self._kernel = _KERNELS[self.error]
        # the compiled kernel's arguments: every gain as a 3×3 matrix (scalar k as k I)
        self._kargs = (
            ERROR_CODES[self.error],
            np.ascontiguousarray(self.J, dtype=np.float64),
            _as_matrix(self.k_R),
            _as_matrix(self.k_Omega),
            _as_matrix(np.zeros((3, 3)) if self.G is None else self.G),
        )
        self._t0: float | None = None
        self._batch: int | None = None
        self._diag: dict[str, np.ndarray] = {}
        self._checked_R_d: np.ndarray | None = None

    def __repr__(self) -> str:
        return (
            f"GeometricPD(error={self.error!r}, k_R={self.k_R!r}, k_Omega={self.k_Omega!r}, "
            f"J=diag≈{np.diag(self.J).tolist()})"
        )

    def reset(self, t0: float, batch_size: int) -> None:
        """Store the start time and batch size; clear the diagnostics."""
        if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)):
            raise ValueError(f"batch_size: expected a positive int, got {batch_size!r}")
        if batch_size < 1:
            raise ValueError(f"batch_size: must be >= 1, got {batch_size}")
        t0 = as_scalar(t0, "t0")
        self._t0 = t0
        self._batch = int(batch_size)
        self._diag = {}

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m] for ``state`` (``R (B,3,3)``, ``omega (B,3)``)."""
        if self._batch is None:
            raise RuntimeError("GeometricPD.command: call reset(t0, batch_size) first")
        as_scalar(t, "t")  # unused by the law, but a NaN time is a caller's bug
        R, w = validated_rotation_and_rate(state)
        if R.ndim != 3 or w.shape != (R.shape[0], 3):
            raise ValueError(
                f"state: expected R (B, 3, 3) and omega (B, 3), got {R.shape} and {w.shape}"
            )
        B = R.shape[0]
        if B != self._batch:
            raise ValueError(f"state: batch size {B} differs from reset(batch_size={self._batch})")
        R_d, w_d, dw_d = validated_reference(self, reference, B)
        if B == 1 or JIT_ENABLED:
            return finite_command(self._command_kernel(R, w, R_d, w_d, dw_d), w)

        # R̃ = R_dᵀR formed directly
        if R_d.ndim == 2:
            # one reference for the batch: R_dᵀR_b for every b as one BLAS product
            # (3, 3) @ (3, 3B); numpy's broadcast (3, 3) @ (B, 3, 3) matmul loops over the small
            # matrices ~3× slower. The (B, 3, 3) result is a transposed view.
            Rt = (R_d.T @ R.transpose(1, 0, 2).reshape(3, 3 * B)).reshape(3, B, 3)
            Rt = Rt.transpose(1, 0, 2)
        else:
            Rt = np.swapaxes(R_d, -1, -2) @ R
        # R, R_d were checked above: the law runs the unchecked errors of liecontrol.errors
        M, Psi, e_R, e_W = _law_from_relative(
            Rt, w, w_d, dw_d, self.J, self.k_R, self.k_Omega, self.error, self.G
        )
        self._diag = {"Psi": Psi, "e_R": e_R, "e_Omega": e_W}
        return finite_command(M, w)

    def _command_kernel(
        self, R: np.ndarray, w: np.ndarray, R_d: np.ndarray, w_d: np.ndarray, dw_d: np.ndarray
    ) -> np.ndarray:
        """:meth:`command` through the compiled kernel
        (:func:`liecontrol._kernels.geometric_pd.geometric_pd_one`), one spacecraft at a time."""
        B = R.shape[0]
        M = np.empty((B, 3))
        diag = np.empty((B, 7))
        err, J, kR, kW, G = self._kargs
        R = np.ascontiguousarray(R, dtype=np.float64)
        w = np.ascontiguousarray(w, dtype=np.float64)
        if B == 1:
            geometric_pd_one(
                err, J, kR, kW, G, R[0], w[0], _one(R_d), _one(w_d), _one(dw_d), M[0], diag[0]
            )
        else:
            geometric_pd_batch(
                err, J, kR, kW, G, R, w,
                _batch(R_d, (B, 3, 3)), _batch(w_d, (B, 3)), _batch(dw_d, (B, 3)), M, diag,
            )  # fmt: skip
        self._set_diagnostics(diag)
        return M

    def _kernel_args(self) -> tuple:
        """``(error code, J, K_R, K_Ω, G)`` of the compiled kernel."""
        return self._kargs

    def array_law(self) -> ArrayLaw:
        """The law as a pure array function (:func:`geometric_pd_torque`) for the
        differentiable loop, through the seam :mod:`liecontrol.control.array_law`; memoryless,
        every error function (large-angle, log, trace with its weight ``G``)."""
        J, error = np.array(self.J), self.error
        G = None if self.G is None else np.array(self.G)

        def step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T):  # noqa: ANN001
            M, Psi, e_R, e_W = geometric_pd_torque(
                R, omega, R_d, omega_d, omega_dot_d, J, k_R, k_Omega, error, G
            )
            return M, state, {"Psi": Psi, "e_R": e_R, "e_Omega": e_W}

        return ArrayLaw(self.k_R, self.k_Omega, (), step)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel:
        """The compiled law (:func:`liecontrol._kernels.geometric_pd.geometric_pd_law`) for the
        simulator's fused loop, through the public seam :mod:`liecontrol.control.kernel`."""
        err, J, kR, kW, G = self._kargs
        params = np.concatenate([[float(err)], J.ravel(), kR.ravel(), kW.ravel(), G.ravel()])
        return ControllerKernel(
            geometric_pd_law, params, np.zeros((batch_size, 0)), 7,
            diagnostics=_pd_rows, finish=lambda state, diag: self._set_diagnostics(diag),
        )  # fmt: skip

    def _set_diagnostics(self, diag: np.ndarray) -> None:
        """Diagnostics from the kernel's ``(B, 7)`` rows ``(Ψ, e_R, e_Ω)``."""
        self._diag = _pd_rows(diag)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last ``Psi`` ``(B,)``, ``e_R`` ``(B, 3)``, ``e_Omega`` ``(B, 3)`` (empty before the
        first command)."""
        return dict(self._diag)
