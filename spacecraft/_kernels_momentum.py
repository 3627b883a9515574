"""Compiled kernels of cross-product magnetic momentum dumping
(:class:`spacecraft.momentum.CrossProductDumping`) for the simulator's compiled loop. Equations,
assumptions and sources in :mod:`spacecraft.momentum`, whose NumPy methods stay the reference
and the Python loop's route; these are the same formulas on one spacecraft:

- the tilted-dipole field at the orbit position, inertial axes (``CrossProductDumping.
  _field_inertial``: the same operations on floats), and in body axes Rᵀ B;
- the dipole m = sat(k (Δh × B)/‖B‖²), Δh = h − h_target, held over an integration step
  (``CrossProductDumping.dipole``), saturated by one factor on the whole vector;
- the magnetic torque m × B(t, R) at each integration stage, as a torque of the disturbance
  seam (:mod:`spacecraft.disturbance_kernel`) that reads the held dipole from its parameter
  row: the compiled loop adds it to the plant's disturbance through the seam's sum
  (``SumOfDisturbances``' composition) and writes the dipole of each step into the row.

Parameter row of :func:`magnetic_torque` (:data:`N_PARAMS`): the field and orbit constants
(:data:`P_FIELD` …), the gain, the rod limits (3), h_target (3), then the held dipole (3, at
:data:`P_DIPOLE`). Kernels never validate: ``CrossProductDumping.fused_kernel`` builds the row.
"""

from __future__ import annotations

import math

import numpy as np

from liecontrol._jit import njit

# the row: arg_lat0, n, R_orb[0:3, 0:2] (6), longitude + greenwich0, earth_rate, sin(tilt),
# −cos(tilt), k = B₀ (a/r)³; gain; rod limits (3); h_target (3); the held dipole (3)
P_ARG, P_N, P_RO, P_LAM, P_RATE, P_ST, P_MZ, P_K = 0, 1, 2, 8, 9, 10, 11, 12
P_GAIN, P_MMAX, P_HT, P_DIPOLE = 13, 14, 17, 20
#: parameter row length
N_PARAMS = 23


@njit(inline="always")
def field_inertial(t: float, p: np.ndarray) -> tuple[float, float, float]:
    """The tilted-dipole field at the orbit position at ``t``, inertial axes [T]
    (``CrossProductDumping._field_inertial``)."""
    u = p[P_ARG] + p[P_N] * t
    cu, su = math.cos(u), math.sin(u)
    rx = p[P_RO] * cu + p[P_RO + 1] * su
    ry = p[P_RO + 2] * cu + p[P_RO + 3] * su
    rz = p[P_RO + 4] * cu + p[P_RO + 5] * su
    lam = p[P_LAM] + p[P_RATE] * t
    st = p[P_ST]
    mx, my, mz = st * math.cos(lam), st * math.sin(lam), p[P_MZ]
    mr3 = 3.0 * (mx * rx + my * ry + mz * rz)
    k = p[P_K]
    return k * (mr3 * rx - mx), k * (mr3 * ry - my), k * (mr3 * rz - mz)


@njit(inline="always")
def field_body(t: float, R: np.ndarray, p: np.ndarray) -> tuple[float, float, float]:
    """The field in body axes Rᵀ B(t) [T] (``CrossProductDumping.field_body``)."""
    b0, b1, b2 = field_inertial(t, p)
    return (
        b0 * R[0, 0] + b1 * R[1, 0] + b2 * R[2, 0],
        b0 * R[0, 1] + b1 * R[1, 1] + b2 * R[2, 1],
        b0 * R[0, 2] + b1 * R[1, 2] + b2 * R[2, 2],
    )


@njit
def dipole(
    t: float, R: np.ndarray, h0: float, h1: float, h2: float, p: np.ndarray
) -> tuple[float, float, float]:
    """The dipole held over the step from ``t`` for stored momentum ``h`` [A·m²]
    (``CrossProductDumping.dipole``)."""
    B0, B1, B2 = field_body(t, R, p)
    b2 = B0 * B0 + B1 * B1 + B2 * B2
    d0, d1, d2 = h0 - p[P_HT], h1 - p[P_HT + 1], h2 - p[P_HT + 2]
    g = p[P_GAIN]
    m0 = g * (d1 * B2 - d2 * B1) / b2
    m1 = g * (d2 * B0 - d0 * B2) / b2
    m2 = g * (d0 * B1 - d1 * B0) / b2
    ratio = max(
        abs(m0) / p[P_MMAX], max(abs(m1) / p[P_MMAX + 1], abs(m2) / p[P_MMAX + 2])
    )  # fmt: skip
    s = max(ratio, 1.0)
    return m0 / s, m1 / s, m2 / s


@njit
def magnetic_torque(
    t: float, R: np.ndarray, omega: np.ndarray, params: np.ndarray, out: np.ndarray
) -> None:
    """A torque of the disturbance seam: m × B(t, R) [N·m] with the dipole m held in
    ``params[P_DIPOLE:]`` (``CrossProductDumping.torque``)."""
    B0, B1, B2 = field_body(t, R, params)
    m0, m1, m2 = params[P_DIPOLE], params[P_DIPOLE + 1], params[P_DIPOLE + 2]
    out[0] = m1 * B2 - m2 * B1
    out[1] = m2 * B0 - m0 * B2
    out[2] = m0 * B1 - m1 * B0


@njit(inline="always")
def hold_dipole(p: np.ndarray, m0: float, m1: float, m2: float) -> None:
    """Write the dipole held over the next step into the torque's row ``p`` (zeros while the
    compiled loop's log reads the disturbance: the magnetic block then adds exactly 0)."""
    p[P_DIPOLE] = m0
    p[P_DIPOLE + 1] = m1
    p[P_DIPOLE + 2] = m2


@njit(inline="always")
def log_row(
    log_mm: np.ndarray, row: int, b: int, t: float, R: np.ndarray, p: np.ndarray,
    m0: float, m1: float, m2: float,
) -> None:  # fmt: skip
    """The management's log row of spacecraft ``b``: the dipole held from ``t`` and its torque
    m × B(t, R) (``CrossProductDumping.log``)."""
    B0, B1, B2 = field_body(t, R, p)
    log_mm[row, b, 0] = m0
    log_mm[row, b, 1] = m1
    log_mm[row, b, 2] = m2
    log_mm[row, b, 3] = m1 * B2 - m2 * B1
    log_mm[row, b, 4] = m2 * B0 - m0 * B2
    log_mm[row, b, 5] = m0 * B1 - m1 * B0
