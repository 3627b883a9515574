"""Conversions between liecontrol's attitude conventions and Basilisk's.

Basilisk (the Autonomous Vehicle Systems Lab's spacecraft simulator) follows Schaub & Junkins,
*Analytical Mechanics of Space Systems* (AIAA, 4th ed., 2018), where an attitude is the
direction cosine matrix [BN], mapping **inertial N components to body B components**.
liecontrol's R maps body → inertial, so

    [BN] = Rᵀ,     R = [BN]ᵀ.

With that one transposition every attitude set coincides (``docs/conventions.md`` has the
table):

* Euler parameters β = (β₀, β₁, β₂, β₃) of [BN] (scalar first) are liecontrol's unit quaternion
  q = (w, x, y, z) of R — Schaub's ``[BN](β)`` is the transpose of the Hamilton rotation matrix of
  the same four numbers;
* MRP σ_B/N of [BN] are liecontrol's MRP p of R (both use σ = β_v / (1 + β₀));
* the principal rotation vector (PRV) Φ ê of [BN] is liecontrol's rotation vector θ of R
  ([BN] = cos Φ I − sin Φ ê^ + (1 − cos Φ) ê êᵀ = exp(−Φ ê^), so R = exp(Φ ê^));
* Basilisk's Euler set "ijk" (e.g. "321": [BN] = M₁(θ₃) M₂(θ₂) M₃(θ₁)) is liecontrol's
  *intrinsic* sequence with the same angles in the same order, R = R_i(θ₁) R_j(θ₂) R_k(θ₃)
  (scipy's upper-case notation, :mod:`liecontrol.charts.euler`): "321" ⇄ "ZYX", "313" ⇄ "ZXZ";
* ω_B/N in body components (Basilisk's ``omega_BN_B``) is liecontrol's ω (Ṙ = R ω^).

Where the two differ is only at the branch points: at a half-turn (Φ = π, β₀ = 0, |σ| = 1) the
sign of the returned β, σ or PRV is a convention, and Basilisk's and liecontrol's rules may pick
opposite (equivalent) representatives. liecontrol's quaternions are canonical (w ≥ 0, then the
first non-zero of x, y, z positive, as scipy), its MRPs are the short set |p| ≤ 1.
"""

from __future__ import annotations

import numpy as np

from .._validation import as_array, check_bool, norm_last
from ..charts import euler, mrp, quaternion
from ..lie import so3

__all__ = [
    "EULER_SETS",
    "to_sigma_BN",
    "from_sigma_BN",
    "dcm_BN",
    "from_dcm_BN",
    "euler_set_to_seq",
    "seq_to_euler_set",
    "euler_to_matrix",
    "matrix_to_euler",
    "ep_to_quat",
    "quat_to_ep",
    "prv_to_rotvec",
    "rotvec_to_prv",
]

_DIGIT_TO_AXIS = {"1": "X", "2": "Y", "3": "Z"}
_AXIS_TO_DIGIT = {v: k for k, v in _DIGIT_TO_AXIS.items()}

#: Basilisk's twelve Euler sets (``RigidBodyKinematics.C2Euler121`` … ``C2Euler323``) and the
#: intrinsic liecontrol / scipy sequence each equals.
EULER_SETS: dict[str, str] = {
    s: "".join(_DIGIT_TO_AXIS[c] for c in s)
    for s in (
        "121",
        "123",
        "131",
        "132",
        "212",
        "213",
        "231",
        "232",
        "312",
        "313",
        "321",
        "323",
    )  # fmt: skip
}


def to_sigma_BN(R: object, omega: object) -> tuple[np.ndarray, np.ndarray]:
    """``(sigma_BN, omega_BN_B)`` for Basilisk from liecontrol's ``(R, omega)``.

    ``R``: ``(..., 3, 3)`` rotation body → inertial (or a scipy ``Rotation``); ``omega``:
    ``(..., 3)`` body angular velocity [rad/s]. σ_B/N is the short-set MRP of [BN] = Rᵀ,
    which equals liecontrol's MRP of R (module docstring); ω_B/N in body components is ω.
    Returns new arrays (the inputs are not modified).
    """
    sigma = mrp.from_matrix(R)
    w = np.array(as_array(omega, "omega", (3,)), copy=True)
    return sigma, w


def from_sigma_BN(sigma_BN: object, omega_BN_B: object) -> tuple[np.ndarray, np.ndarray]:
    """liecontrol's ``(R, omega)`` from Basilisk's ``(sigma_BN, omega_BN_B)`` (inverse of
    :func:`to_sigma_BN`; any MRP, short or long set, is accepted)."""
    s = as_array(sigma_BN, "sigma_BN", (3,))
    w = np.array(as_array(omega_BN_B, "omega_BN_B", (3,)), copy=True)
    return mrp.to_matrix(s), w


def dcm_BN(R: object) -> np.ndarray:
    """Basilisk's direction cosine matrix [BN] = Rᵀ of a validated rotation R."""
    return np.array(np.swapaxes(so3.validate(R, "R"), -1, -2), copy=True)


def from_dcm_BN(dcm: object) -> np.ndarray:
    """liecontrol's R = [BN]ᵀ from Basilisk's [BN] (validated as a rotation)."""
    return np.array(np.swapaxes(so3.validate(dcm, "dcm"), -1, -2), copy=True)


def euler_set_to_seq(euler_set: object) -> str:
    """Basilisk's Euler set name (``"321"``; an int 321 is accepted) → liecontrol's intrinsic
    sequence (``"ZYX"``); the angles keep their order. Raises ``ValueError`` naming
    ``euler_set`` for anything but the twelve sets of :data:`EULER_SETS`."""
    key = str(euler_set) if isinstance(euler_set, (str, int, np.integer)) else None
    if isinstance(euler_set, bool) or key not in EULER_SETS:
        raise ValueError(
            f"euler_set: unknown Euler set {euler_set!r}; expected one of {', '.join(EULER_SETS)}"
        )
    return EULER_SETS[key]  # type: ignore[index]


def seq_to_euler_set(seq: object) -> str:
    """liecontrol's intrinsic sequence (``"ZYX"``) → Basilisk's Euler set (``"321"``).

    Basilisk's sets are intrinsic (rotating axes); an extrinsic (lower-case) sequence is
    refused with the intrinsic equivalent in the message (``"xyz"`` with angles (a, b, c) is
    ``"ZYX"`` with (c, b, a)).
    """
    if not isinstance(seq, str) or len(seq) != 3 or not set(seq.upper()) <= set("XYZ"):
        raise ValueError(f"seq: expected a 3-letter sequence over X, Y, Z, got {seq!r}")
    if seq.islower():
        raise ValueError(
            f"seq: {seq!r} is extrinsic (lower case) but Basilisk's Euler sets are intrinsic; "
            f"use {seq[::-1].upper()!r} with the angles in reverse order"
        )
    if not seq.isupper():
        raise ValueError(f"seq: {seq!r} mixes upper and lower case")
    out = "".join(_AXIS_TO_DIGIT[c] for c in seq)
    if out not in EULER_SETS:
        raise ValueError(f"seq: {seq!r} repeats an axis back to back (not an Euler sequence)")
    return out


def euler_to_matrix(angles: object, euler_set: object) -> np.ndarray:
    """liecontrol's R from Basilisk Euler angles ``(..., 3)`` [rad] of ``euler_set``
    (Basilisk's ``euler<set>2C`` gives [BN] = Rᵀ)."""
    return euler.to_matrix(angles, euler_set_to_seq(euler_set))


def matrix_to_euler(R: object, euler_set: object) -> np.ndarray:
    """Basilisk Euler angles ``(..., 3)`` [rad] of ``euler_set`` for liecontrol's R (the same
    numbers as Basilisk's ``C2Euler<set>([BN])`` away from gimbal lock; liecontrol's angle
    ranges are scipy's, see :mod:`liecontrol.charts.euler`)."""
    return euler.from_matrix(R, euler_set_to_seq(euler_set))


def ep_to_quat(beta: object, scalar_first: bool = True) -> np.ndarray:
    """Basilisk Euler parameters β ``(..., 4)`` (scalar first, of [BN]) → liecontrol's unit
    quaternion of R (the same numbers; returned scalar-first unless ``scalar_first=False``).
    β must be unit-norm within liecontrol's quaternion tolerance (raises naming ``beta``)."""
    check_bool(scalar_first, "scalar_first")
    out = np.array(_unit4(beta, "beta"), copy=True)
    return out if scalar_first else np.concatenate([out[..., 1:], out[..., :1]], axis=-1)


def _unit4(x: object, name: str) -> np.ndarray:
    """A finite ``(..., 4)`` array of unit norm within liecontrol's quaternion tolerance."""
    a = as_array(x, name, (4,))
    err = np.abs(norm_last(a) - 1.0) if a.size else np.zeros(0)
    if np.any(err > quaternion.UNIT_TOL):
        raise ValueError(
            f"{name}: not unit-norm (max | |{name}| − 1 | = {float(np.max(err)):.2e} > "
            f"{quaternion.UNIT_TOL:.0e})"
        )
    return a


def quat_to_ep(q: object, scalar_first: bool = True) -> np.ndarray:
    """liecontrol quaternion of R (scalar-first unless ``scalar_first=False``) → Basilisk's
    Euler parameters β of [BN] (always scalar first; the same four numbers)."""
    check_bool(scalar_first, "scalar_first")
    a = _unit4(q, "q")
    return np.array(a if scalar_first else np.concatenate([a[..., 3:], a[..., :3]], axis=-1))


def prv_to_rotvec(prv: object) -> np.ndarray:
    """Basilisk principal rotation vector Φ ê of [BN] ``(..., 3)`` → liecontrol's rotation
    vector of R (the same numbers, returned as a new array)."""
    return np.array(as_array(prv, "prv", (3,)), copy=True)


def rotvec_to_prv(theta: object) -> np.ndarray:
    """liecontrol's rotation vector of R ``(..., 3)`` → Basilisk's PRV of [BN] (the same
    numbers, returned as a new array). Basilisk's ``C2PRV`` returns Φ ∈ [0, π]; wrap a long
    rotation vector first with :func:`liecontrol.charts.rotvec.wrap` to match it."""
    return np.array(as_array(theta, "theta", (3,)), copy=True)
