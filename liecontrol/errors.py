"""Configuration error functions on SO(3) and SE(3).

For an attitude ``R`` and a desired attitude ``R_d`` (both body → inertial) write the relative
rotation ``R̃ = R_dᵀ R`` (``R̃ = I`` exactly when ``R = R_d``) and let ``θ ∈ [0, π]`` be its angle.
Each attitude error function returns ``(Ψ, e_R)``: a configuration error ``Ψ ≥ 0`` (zero only
at ``R = R_d``) and an error vector ``e_R`` with the derivative identity

    d/dt Ψ = c · e_R · e_Ω,        e_Ω = Ω − R̃ᵀ Ω_d = Ω − Rᵀ R_d Ω_d,

along any pair of trajectories ``Ṙ = R Ω^``, ``Ṙ_d = R_d Ω_d^`` (then ``d/dt R̃ = R̃ e_Ω^``). The
factor ``c`` (:data:`DERIVATIVE_FACTOR`) is

- ``trace`` (Koditschek): ``Ψ = tr(G(I − R̃))``, ``e_R = ½ (G R̃ − R̃ᵀ G)^∨``; c = 2;
  ``Ψ ∈ [0, 2(tr G − g_min)]``;
- ``large_angle`` (Lee 2012): ``Ψ = 2 − √(1 + tr R̃)``,
  ``e_R = (R̃ − R̃ᵀ)^∨ / (2√(1 + tr R̃))``; c = 1; ``Ψ ∈ [0, 2]``;
- ``log`` (Bullo–Murray): ``Ψ = ½ ‖log(R̃)^∨‖²``, ``e_R = log(R̃)^∨``; c = 1; ``Ψ ∈ [0, π²/2]``.

Derivation of c (``tr(A ŵ) = −w · (A − Aᵀ)^∨`` for any 3×3 ``A``):

- trace: ``Ψ̇ = −tr(G R̃ e_Ω^) = (G R̃ − R̃ᵀ G)^∨ · e_Ω = 2 e_R · e_Ω``: c = 2 for this
  package's normalisation (Lee et al. write ``Ψ = ½ tr(G(I − R̃))`` and get c = 1);
- large_angle: ``Ψ̇ = −tr(R̃ e_Ω^) / (2√(1 + tr R̃)) = e_R · e_Ω``: c = 1;
- log: ``θ̇ θ = φ · J_r(φ)⁻¹ e_Ω = φ · e_Ω`` because ``J_r(φ)⁻ᵀ φ = φ``: c = 1.

Angle relations (used by the tests, independent of scipy): trace with ``G = g I``:
``Ψ = 2g(1 − cos θ)``; large_angle: ``√(1 + tr R̃) = 2|cos(θ/2)|`` so ``Ψ = 2 − 2 cos(θ/2)``
and ``‖e_R‖ = sin(θ/2) ≤ 1``; log: ``Ψ = θ²/2``, ``‖e_R‖ = θ``.

Singular set (never NaN). At ``θ = π`` the large-angle formula is 0/0 and
the logarithm is two-valued. Both are evaluated through the rotation vector
``φ = log(R̃)^∨`` of :func:`liecontrol.lie.so3.log` (accurate up to and including π, taken from
the symmetric part of ``R̃``): the large-angle error is computed in the equivalent half-angle
form ``Ψ = 4 sin²(θ/4)``, ``e_R = (sin(θ/2)/θ) φ``, which equals ``Ψ = 2 − √(1 + tr R̃)``,
``e_R = (R̃ − R̃ᵀ)^∨ / (2√(1 + tr R̃))`` for θ < π
(tested) without its cancellation near 0 and π. **Choice at the antipodal set** (θ = π):
``e_R`` is the unit vector ``φ/π`` (large-angle) or ``φ`` (log), with the sign of the
deterministic-but-arbitrary branch chosen by ``so3.log``. That is one of the two one-sided limits,
so ``‖e_R‖`` is continuous (= 1, resp. π) and a controller at rest on the antipodal set is pushed
off it instead of stalling; ``Ψ`` is continuous there (its maximum, 2 resp. π²/2) but not
differentiable, so the derivative identity holds only for θ < π. The trace error is smooth
everywhere and needs no special case.

SE(3): ``g = [[R, p], [0, 1]]``, body twist ``ξ = (ω, v)`` (rotation first, ``ġ = g ξ^``,
so ``ṗ = R v``). :func:`se3_error` returns the attitude error above plus the inertial position
and velocity errors ``e_p = p − p_d``, ``e_v = R v − R_d v_d`` (so ``ė_p = e_v`` exactly), and
:func:`se3_log_error` returns the exponential coordinates ``log(g_d⁻¹ g)^∨ = (φ, ρ)``.

Sources: D. E. Koditschek, "The application of total energy as a Lyapunov function for
mechanical control systems" (1989); F. Bullo and R. M. Murray, "Proportional derivative (PD)
control on the Euclidean group" (1995); T. Lee, "Exponential stability of an attitude tracking
control system on SO(3) for large-angle rotational maneuvers", Systems & Control Letters (2012);
Jiang, Meng & Yang 2023 eqs. (7)–(11), (13).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ._array_api import any_true, namespace
from ._validation import as_array, broadcast_batch, check_rotation_matrix, check_spd
from .lie import so3

__all__ = [
    "DEFAULT_G",
    "DERIVATIVE_FACTOR",
    "ATTITUDE_ERRORS",
    "SE3Error",
    "check_error_weight",
    "trace_error",
    "large_angle_error",
    "log_error",
    "angular_velocity_error",
    "attitude_error",
    "se3_error",
    "se3_log_error",
]

#: Default weight of the trace error: distinct eigenvalues (required for the critical points of
#: Ψ to be isolated, Koditschek) close to 1, so that near the identity
#: ``e_R ≈ ½(tr G·I − G) δθ = diag(1.05, 1.0, 0.95) δθ`` behaves like the log error's ``e_R = δθ``
#: and the same gains give about the same linear response for every error function.
DEFAULT_G: np.ndarray = np.diag([0.9, 1.0, 1.1])
DEFAULT_G.setflags(write=False)

#: ``c`` in ``d/dt Ψ = c · e_R · e_Ω`` for each error function (see the module docstring).
DERIVATIVE_FACTOR: dict[str, float] = {"trace": 2.0, "large_angle": 1.0, "log": 1.0}

# Relative eigenvalue gap below which G counts as having repeated eigenvalues.
_G_DISTINCT_RTOL = 1e-6


# ----------------------------------------------------------------------------------------------
# validation helpers


def check_error_weight(G: object, name: str = "G") -> np.ndarray:
    """Validate the trace-error weight: a finite symmetric 3×3 matrix with distinct positive
    eigenvalues (relative gap > 1e-6). Returns it as a float64 array."""
    a = as_array(G, name)
    if a.shape != (3, 3):
        raise ValueError(f"{name}: expected shape (3, 3), got {a.shape}")
    eig = check_spd(a, name, symbol="G")
    gap = float(np.min(np.diff(eig)))
    if gap <= _G_DISTINCT_RTOL * eig[-1]:
        raise ValueError(
            f"{name}: eigenvalues must be distinct (Koditschek's trace error has non-isolated "
            f"critical points otherwise), got {np.array2string(eig, precision=6)}"
        )
    return a


def _check_broadcast(a: np.ndarray, b: np.ndarray, name_a: str, name_b: str) -> None:
    """Raise (naming ``b``) unless the batch shapes of the matrix stacks ``a`` and ``b``
    broadcast."""
    try:
        np.broadcast_shapes(a.shape, b.shape)
    except ValueError:
        raise ValueError(
            f"{name_b}: batch shape {b.shape[:-2]} does not broadcast with "
            f"{name_a}'s {a.shape[:-2]}"
        ) from None


def _check_pair(R: object, R_d: object) -> tuple[np.ndarray, np.ndarray]:
    R = check_rotation_matrix(R, "R")
    R_d = check_rotation_matrix(R_d, "R_d")
    _check_broadcast(R, R_d, "R", "R_d")
    return R, R_d


def _relative(R: np.ndarray, R_d: np.ndarray) -> np.ndarray:
    """R̃ = R_dᵀ R (broadcast over batch dimensions)."""
    return np.swapaxes(R_d, -1, -2) @ R


def _skew_vee(A: np.ndarray) -> np.ndarray:
    """(A − Aᵀ)^∨ without forming the difference matrix."""
    return np.stack(
        (A[..., 2, 1] - A[..., 1, 2], A[..., 0, 2] - A[..., 2, 0], A[..., 1, 0] - A[..., 0, 1]),
        axis=-1,
    )


def _half_sinc(theta: np.ndarray) -> np.ndarray:
    """sin(θ/2)/θ, accurate at and near 0 (Taylor branch below θ = 1e-3); NumPy or JAX.

    The closed form is evaluated at θ = 1 where the series is taken, so neither the value nor
    the derivative of the branch not taken is 0/0 (a NaN there would reach the gradient
    through ``where``)."""
    xp = namespace(theta)
    small = theta < 1e-3
    t = xp.where(small, 1.0, theta)
    out = xp.sin(0.5 * t) / t
    t2 = theta * theta
    return xp.where(small, 0.5 * (1.0 - t2 / 24.0 * (1.0 - t2 / 80.0)), out)


# ----------------------------------------------------------------------------------------------
# unchecked kernels on the relative rotation R̃
#
# No validation: ``Rt`` must already be a finite float64 ``(..., 3, 3)`` rotation (and ``G`` a
# checked weight). The public functions below validate and then call these; controllers that have
# checked R and R_d themselves (GeometricPD.command, at every control sample) call them directly.

_HALF_PI = 0.5 * np.pi


def _trace_error_unchecked(Rt: np.ndarray, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`trace_error` on a checked ``R̃`` and ``G``: ``Ψ = tr G − tr(G R̃)``,
    ``e_R = ½ (G R̃ − (G R̃)ᵀ)^∨`` (``G R̃ − R̃ᵀ G = GR − (GR)ᵀ`` since G is symmetric). Pure:
    NumPy or JAX arrays (a polynomial in ``R̃``: smooth everywhere, its derivatives finite at
    the identity and at the antipodal set alike)."""
    xp = namespace(Rt, G)
    shape = Rt.shape[:-2]
    n = int(np.prod(shape, dtype=np.int64))
    # G R̃_b for every b as one (3, 3) @ (3, 3n) product: numpy's broadcast (3, 3) @ (n, 3, 3)
    # matmul runs a small-matrix loop ~3× slower than this single BLAS call
    GR = (G @ Rt.reshape(n, 3, 3).transpose(1, 0, 2).reshape(3, 3 * n)).reshape(3, n, 3)
    Psi = xp.trace(G) - (GR[0, :, 0] + GR[1, :, 1] + GR[2, :, 2])
    e_R = 0.5 * xp.stack(
        (GR[2, :, 1] - GR[1, :, 2], GR[0, :, 2] - GR[2, :, 0], GR[1, :, 0] - GR[0, :, 1]),
        axis=-1,
    )
    return Psi.reshape(shape), e_R.reshape(shape + (3,))


def _large_angle_error_unchecked(Rt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`large_angle_error` on a checked ``R̃``: ``Ψ = 4 sin²(θ/4)``, ``e_R = (sin(θ/2)/θ) φ``
    with ``φ = log(R̃)^∨`` and θ its angle. Pure: NumPy or JAX arrays (differentiable, finite
    derivatives at the identity and near π; see :func:`liecontrol.lie.so3._log_angle_unchecked`).

    While cos θ ≥ 0 (tr R̃ ≥ 1) by square roots alone, as the compiled kernel
    (:func:`liecontrol._kernels.attitude.large_angle_error_algebraic`, the same operations in
    the same order): with v = (R̃ − R̃ᵀ)^∨ and 1 + tr R̃ = 4 cos²(θ/2),
    ``e_R = v / (2 √(1 + tr R̃))``, ``Ψ = 2 ‖e_R‖² / (1 + ½ √(1 + tr R̃))``; beyond, the angle."""
    xp = namespace(Rt)
    tr = (Rt[..., 0, 0] + Rt[..., 1, 1]) + Rt[..., 2, 2]
    alg = tr >= 1.0
    q = xp.sqrt(xp.maximum(1.0 + tr, 2.0))  # √(1 + tr) on the algebraic side, finite elsewhere
    k = 0.5 / q
    e0 = (Rt[..., 2, 1] - Rt[..., 1, 2]) * k
    e1 = (Rt[..., 0, 2] - Rt[..., 2, 0]) * k
    e2 = (Rt[..., 1, 0] - Rt[..., 0, 1]) * k
    Psi_a = 2.0 * ((e0 * e0 + e1 * e1) + e2 * e2) / (1.0 + 0.5 * q)
    e_a = xp.stack([e0, e1, e2], axis=-1)
    if not any_true(~alg, xp):
        return Psi_a, e_a
    phi, theta = so3._log_angle_unchecked(Rt)
    # 2 − √(1 + tr R̃) = 2 − 2cos(θ/2) = 4 sin²(θ/4): the sine form avoids cancellation at
    # small θ, the cosine form (on θ ≥ π/2 only) gives Ψ = 2 to the last bit at θ = π
    s = xp.sin(0.25 * theta)
    Psi = s * s * 4.0
    big = theta >= _HALF_PI
    if any_true(big, xp):
        Psi = xp.where(big, 2.0 - 2.0 * xp.cos(0.5 * theta), Psi)
    e_R = phi * _half_sinc(theta)[..., None]
    return xp.where(alg, Psi_a, Psi), xp.where(alg[..., None], e_a, e_R)


def _log_error_unchecked(Rt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`log_error` on a checked ``R̃``: ``Ψ = ½ ‖φ‖²``, ``e_R = φ = log(R̃)^∨``; NumPy or
    JAX."""
    xp = namespace(Rt)
    phi = so3._log_angle_unchecked(Rt)[0]
    Psi = 0.5 * xp.einsum("...i,...i->...", phi, phi)
    return Psi, phi


_KERNELS: dict[str, Callable[..., tuple[np.ndarray, np.ndarray]]] = {
    "trace": _trace_error_unchecked,
    "large_angle": _large_angle_error_unchecked,
    "log": _log_error_unchecked,
}


def _check_kind(kind: object, name: str = "kind") -> str:
    if not isinstance(kind, str) or kind not in _KERNELS:
        raise ValueError(
            f"{name}: unknown attitude error function {kind!r}; expected one of {sorted(_KERNELS)}"
        )
    return kind


# ----------------------------------------------------------------------------------------------
# public attitude errors


def trace_error(R: object, R_d: object, G: object = None) -> tuple[np.ndarray, np.ndarray]:
    """Koditschek's trace error (Jiang, Meng & Yang 2023 eq. (7)).

    ``Ψ = tr(G(I − R_dᵀR))``, ``e_R = ½ (G R_dᵀR − RᵀR_d G)^∨``; ``d/dt Ψ = 2 e_R · e_Ω``.

    Args:
        R: ``(..., 3, 3)`` attitude (body → inertial).
        R_d: ``(..., 3, 3)`` desired attitude; batch shapes broadcast.
        G: symmetric 3×3 weight with distinct positive eigenvalues; default :data:`DEFAULT_G`
            ``= diag(0.9, 1.0, 1.1)``.

    Returns:
        ``(Psi, e_R)`` with shapes ``(...)`` and ``(..., 3)``. ``Ψ ∈ [0, 2(tr G − g_min)]``.
    """
    R, R_d = _check_pair(R, R_d)
    G = DEFAULT_G if G is None else check_error_weight(G)
    return _trace_error_unchecked(_relative(R, R_d), G)


def large_angle_error(R: object, R_d: object) -> tuple[np.ndarray, np.ndarray]:
    """Lee's large-angle error (Lee 2012; Jiang, Meng & Yang 2023 eqs. (10)–(11)).

    ``Ψ = 2 − √(1 + tr R̃)``, ``e_R = (R̃ − R̃ᵀ)^∨ / (2√(1 + tr R̃))`` with ``R̃ = R_dᵀR``;
    ``d/dt Ψ = e_R · e_Ω``. Evaluated in the equivalent half-angle form ``Ψ = 2 − 2cos(θ/2)``,
    ``e_R = sin(θ/2) · axis`` (so ``‖e_R‖ ≤ 1``), which is finite at θ = π: there ``Ψ = 2`` and
    ``e_R`` is the unit axis of ``so3.log(R̃)`` (documented choice at the antipodal set, see the
    module docstring).

    Returns:
        ``(Psi, e_R)`` with shapes ``(...)`` and ``(..., 3)``.
    """
    R, R_d = _check_pair(R, R_d)
    return _large_angle_error_unchecked(_relative(R, R_d))


def log_error(R: object, R_d: object) -> tuple[np.ndarray, np.ndarray]:
    """Bullo–Murray logarithmic error (Jiang, Meng & Yang 2023 eq. (8), Lemma 2).

    ``Ψ = ½ ‖log(R_dᵀR)^∨‖² = θ²/2``, ``e_R = log(R_dᵀR)^∨`` (rotation vector);
    ``d/dt Ψ = e_R · e_Ω`` for θ < π. At θ = π, ``e_R`` is the branch chosen by ``so3.log``
    (``‖e_R‖ = π``).

    Returns:
        ``(Psi, e_R)`` with shapes ``(...)`` and ``(..., 3)``.
    """
    R, R_d = _check_pair(R, R_d)
    return _log_error_unchecked(_relative(R, R_d))


def angular_velocity_error(R: object, omega: object, R_d: object, omega_d: object) -> np.ndarray:
    """``e_Ω = Ω − Rᵀ R_d Ω_d`` (Jiang, Meng & Yang 2023 eq. (13)): both rates in the body frame.

    Args:
        R, R_d: ``(..., 3, 3)`` attitude and desired attitude.
        omega: ``(..., 3)`` body angular velocity; omega_d: ``(..., 3)`` desired angular velocity
            in the desired body frame. All batch shapes broadcast.
    """
    R, R_d = _check_pair(R, R_d)
    omega = as_array(omega, "omega", (3,))
    omega_d = as_array(omega_d, "omega_d", (3,))
    broadcast_batch(("R", R.shape[:-2]), ("R_d", R_d.shape[:-2]), ("omega", omega.shape[:-1]),
                    ("omega_d", omega_d.shape[:-1]))  # fmt: skip
    Rt = _relative(R, R_d)
    return omega - np.einsum("...ji,...j->...i", Rt, omega_d)


#: Registry of the attitude error functions by name.
ATTITUDE_ERRORS: dict[str, Callable[..., tuple[np.ndarray, np.ndarray]]] = {
    "trace": trace_error,
    "large_angle": large_angle_error,
    "log": log_error,
}


def attitude_error(
    kind: str, R: object, R_d: object, **kw: object
) -> tuple[np.ndarray, np.ndarray]:
    """Dispatch to :data:`ATTITUDE_ERRORS` ``[kind]``; ``G=`` is accepted by ``"trace"`` only."""
    kind = _check_kind(kind)
    if kind != "trace" and kw:
        raise ValueError(f"{next(iter(kw))}: not a parameter of the {kind!r} error function")
    if kind == "trace":
        extra = set(kw) - {"G"}
        if extra:
            raise ValueError(f"{sorted(extra)[0]}: not a parameter of the 'trace' error function")
    return ATTITUDE_ERRORS[kind](R, R_d, **kw)


# ----------------------------------------------------------------------------------------------
# SE(3)


@dataclass(frozen=True)
class SE3Error:
    """Tracking errors on SE(3) (:func:`se3_error`).

    Attributes:
        Psi: ``(...)`` attitude configuration error of the chosen kind.
        e_R: ``(..., 3)`` attitude error vector.
        e_Omega: ``(..., 3)`` angular velocity error ``ω − R̃ᵀ ω_d`` (body frame).
        e_p: ``(..., 3)`` position error ``p − p_d`` (inertial frame).
        e_v: ``(..., 3)`` velocity error ``R v − R_d v_d`` (inertial frame; ``ė_p = e_v``).
    """

    Psi: np.ndarray
    e_R: np.ndarray
    e_Omega: np.ndarray
    e_p: np.ndarray
    e_v: np.ndarray


def _check_se3(g: object, name: str) -> np.ndarray:
    a = as_array(g, name, (4, 4))
    bottom = a[..., 3, :]
    err = np.abs(bottom - np.array([0.0, 0.0, 0.0, 1.0]))
    if err.size and float(err.max()) > 1e-12:
        raise ValueError(f"{name}: last row must be [0, 0, 0, 1] (max deviation {err.max():.2e})")
    check_rotation_matrix(a[..., :3, :3], name)
    return a


def se3_error(
    g: object,
    g_d: object,
    xi: object,
    xi_d: object,
    kind: str = "large_angle",
    G: object = None,
) -> SE3Error:
    """Attitude and translation tracking errors on SE(3) (SE(3) analogues).

    ``g = [[R, p], [0, 1]]``, body twists ``ξ = (ω, v)`` (rotation first; ``ṗ = R v``). The attitude
    part is ``attitude_error(kind, R, R_d)`` and ``e_Ω = ω − R̃ᵀω_d``; the translational part is
    taken in the inertial frame, ``e_p = p − p_d`` and ``e_v = R v − R_d v_d``, so that
    ``ė_p = e_v`` exactly (as in Lee, Leok & McClamroch's SE(3) tracking controllers).

    Args:
        g, g_d: ``(..., 4, 4)`` pose and desired pose; xi, xi_d: ``(..., 6)`` body twists.
        kind: ``"trace"``, ``"large_angle"`` or ``"log"``; G: trace weight (``"trace"`` only).
    """
    kind = _check_kind(kind)
    g = _check_se3(g, "g")
    g_d = _check_se3(g_d, "g_d")
    xi = as_array(xi, "xi", (6,))
    xi_d = as_array(xi_d, "xi_d", (6,))
    if G is not None and kind != "trace":
        raise ValueError(f"G: only used by the 'trace' error function, not {kind!r}")
    R, p = g[..., :3, :3], g[..., :3, 3]
    R_d, p_d = g_d[..., :3, :3], g_d[..., :3, 3]
    try:
        np.broadcast_shapes(g.shape[:-2], g_d.shape[:-2], xi.shape[:-1], xi_d.shape[:-1])
    except ValueError:
        raise ValueError(
            f"xi: batch shapes do not broadcast (g {g.shape[:-2]}, g_d {g_d.shape[:-2]}, "
            f"xi {xi.shape[:-1]}, xi_d {xi_d.shape[:-1]})"
        ) from None
    Rt = _relative(R, R_d)
    if kind == "trace":
        Psi, e_R = _trace_error_unchecked(Rt, DEFAULT_G if G is None else check_error_weight(G))
    else:
        Psi, e_R = _KERNELS[kind](Rt)
    e_Omega = xi[..., :3] - np.einsum("...ji,...j->...i", Rt, xi_d[..., :3])
    e_p = p - p_d
    e_v = np.einsum("...ij,...j->...i", R, xi[..., 3:]) - np.einsum(
        "...ij,...j->...i", R_d, xi_d[..., 3:]
    )
    return SE3Error(Psi=Psi, e_R=e_R, e_Omega=e_Omega, e_p=e_p, e_v=e_v)


def se3_log_error(g: object, g_d: object) -> np.ndarray:
    """Exponential-coordinate error ``log(g_d⁻¹ g)^∨ = (φ, ρ)``, shape ``(..., 6)``.

    ``g_d⁻¹ g = [[R̃, t], [0, 1]]`` with ``R̃ = R_dᵀR``, ``t = R_dᵀ(p − p_d)``; then
    ``φ = log(R̃)^∨`` and ``ρ = J_l(φ)⁻¹ t`` (the SE(3) closed form, ``V = J_l``), twist ordering
    rotation first. Valid for all poses; at θ = π the rotation part is the ``so3.log`` branch.
    """
    g = _check_se3(g, "g")
    g_d = _check_se3(g_d, "g_d")
    R, p = g[..., :3, :3], g[..., :3, 3]
    R_d, p_d = g_d[..., :3, :3], g_d[..., :3, 3]
    _check_broadcast(g, g_d, "g", "g_d")
    Rt = _relative(R, R_d)
    t = np.einsum("...ji,...j->...i", R_d, p - p_d)
    phi = so3.log_unchecked(Rt)  # g and g_d were checked above
    rho = np.einsum("...ij,...j->...i", so3.left_jacobian_inv(phi), t)
    return np.concatenate((phi, rho), axis=-1)
