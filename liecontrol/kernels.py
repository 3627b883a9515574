"""Compiled kernels for a law of your own: the rotation, error and feed-forward functions the
built-in controller kernels are made of, as public API.

These are the functions the library's own compiled laws call (one implementation: importing
them here does not copy them), so a law you write with ``numba.njit`` for the kernel seam
(:mod:`liecontrol.control.kernel`, guide: *Make your controller fast*) computes the same
numbers, in the same order, as the built-in law of the same equation. They work on one
spacecraft and on scalars: a 3-vector is passed as three floats and returned as a tuple, a
rotation as a ``(3, 3)`` C-contiguous float64 array or as the tuple of its nine entries in
row-major order (no array is allocated; inside a ``numba.njit`` function numba inlines the ones
marked ``inline="always"``). Called from plain Python they run as Python (slowly): they are
meant to be called from compiled code. The batched NumPy layer (:mod:`liecontrol.lie.so3`,
:mod:`liecontrol.errors`) is the validated reference they are tested against.

**Rotations** (:mod:`liecontrol.lie.so3` is the reference):

- ``exp9(w0, w1, w2) -> 9-tuple``: exp(ŵ) by Rodrigues' formula in the half-angle form, exact
  to an ulp for every angle (no cancellation at 0); ``exp_into(w0, w1, w2, out)`` writes it into
  ``out (3, 3)``; ``right_multiply_exp_into(R, w0, w1, w2, out)``: ``out = R exp(ŵ)``.
- ``log9(m00, m01, …, m22) -> (θ n)``: the rotation vector with θ ∈ [0, π], the axis from the
  symmetric part near π (no loss of the axis at π); ``log_of(R)`` the same from ``R (3, 3)``.
- ``dexpinv_rkmk4(θ0, θ1, θ2, w0, w1, w2)``: θ̇ of R exp(θ̂) for the body rate w,
  w + ½ θ × w + (1/12) θ × (θ × w) (the right-trivialised dexp⁻¹ truncated after θ²: enough
  for RKMK4).
- ``matvec3(A, x0, x1, x2)``: ``A x`` for a ``(3, 3)`` array.

**Attitude errors** of R̃ = R_dᵀR (:mod:`liecontrol.errors` is the reference). They take
``T = body_from_desired(R, R_d)``, the nine entries of Rᵀ R_d = R̃ᵀ (it maps desired-frame vectors
into the body frame), so one product serves the error and the desired rates:

- ``error_log(T) -> e_R``: log(R̃)^∨ (Bullo & Murray's logarithmic error, Ψ = ½‖e_R‖²).
- ``large_angle_error(T) -> (Ψ, θ, e_R)``: Lee's large-angle error, Ψ = 2 − 2 cos(θ/2),
  e_R = (sin(θ/2)/θ) log(R̃)^∨ (T. Lee, "Exponential stability of an attitude tracking control
  system on SO(3) for large-angle rotational maneuvers", Systems & Control Letters, 2012).
- ``large_angle_error_algebraic(T) -> (Ψ, e_R)``: the same by one square root while θ ≤ π/2
  (the built-in geometric PD's route; beyond π/2 ``large_angle_error``).
- ``half_sinc(θ)``: sin(θ/2)/θ with its Taylor polynomial near 0.

**Tracking** (the geometric PD's feed-forward, T. Lee, M. Leok and N. H. McClamroch, "Geometric
tracking control of a quadrotor UAV on SE(3)", IEEE CDC, 2010):

- ``desired_rates_in_body(T, ω_d, ω̇_d) -> (RᵀR_d ω_d, RᵀR_d ω̇_d)`` (six floats).
- ``tracking_feedforward(J, ω0, ω1, ω2, v0, v1, v2, ω_r0, …, ω̇_r2)``: v × Jω − J(ω × ω_r − ω̇_r);
  with v = ω the exact-cancellation feed-forward of the geometric PD.

**A whole law**: ``geometric_pd_one(error, J, K_R, K_Ω, G, R, ω, R_d, ω_d, ω̇_d, M_out,
diag_out)``, the built-in geometric PD for one spacecraft (``error``: 0 large-angle, 1 log,
2 trace with the weight ``G``; gains as ``(3, 3)`` arrays; ``diag_out (7,) = (Ψ, e_R, e_Ω)``),
to wrap in a law of your own (an outer loop, a gain schedule).

Assumptions: rotations are orthonormal to rounding (the kernels do not re-orthonormalise; the
simulator's states are); non-finite inputs give non-finite outputs, which the compiled loop
catches as a non-finite torque (``NonFiniteTorque`` naming your controller).
"""

from __future__ import annotations

from ._kernels.attitude import (
    body_from_desired,
    desired_rates_in_body,
    error_log,
    half_sinc,
    large_angle_error,
    large_angle_error_algebraic,
    tracking_feedforward,
)
from ._kernels.geometric_pd import geometric_pd_one
from ._kernels.so3 import (
    dexpinv_rkmk4,
    exp9,
    exp_into,
    log9,
    log_of,
    matvec3,
    right_multiply_exp_into,
)

__all__ = [
    "body_from_desired",
    "desired_rates_in_body",
    "dexpinv_rkmk4",
    "error_log",
    "exp9",
    "exp_into",
    "geometric_pd_one",
    "half_sinc",
    "large_angle_error",
    "large_angle_error_algebraic",
    "log9",
    "log_of",
    "matvec3",
    "right_multiply_exp_into",
    "tracking_feedforward",
]
