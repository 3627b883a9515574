"""Benchmark metrics (SPEC §8.2) computed from a simulation log, per spacecraft.

Every metric is a ``(B,)`` array over the spacecraft of one batched
:class:`spacecraft.simulator.SimulationResult` (duck-typed: only the array attributes listed in
:func:`compute_metrics` are read). Field names carry their unit (``_s``, ``_deg``, ``_deg_s``,
``_Nms`` ...); :data:`UNITS` maps each field to its unit string for reports.

Definitions (``θ(t)`` is the geodesic attitude error angle, ``t₀``/``t_f`` the first/last logged
time, ``T = t_f − t₀``; integrals are trapezoidal over the logged samples):

- attitude error ``E = R_dᵀR``, ``θ = atan2(½‖(E − Eᵀ)^∨‖, ½(tr E − 1)) ∈ [0, π]``;
- body rate error ``e_Ω = ω − RᵀR_d ω_d`` (the velocity of ``E`` on SO(3): ``Ė = E e_Ω^``);
- **settling time**: the first time after which ``θ`` never again exceeds the threshold
  (default 0.1°), linearly interpolated between the last sample above and the next one;
  ``t₀`` when ``θ`` never exceeds it; **NaN ("not settled") when the last sample is above it**;
- **steady-state error**: max and RMS (``√(∫θ²dt / window)``) of ``θ`` over the final
  ``steady_fraction`` (10 %) of the run, ``t ≥ t_f − 0.1 T``;
- **peak / RMS rate**: ``max ‖e_Ω‖`` and ``√(∫‖e_Ω‖²dt / T)``;
- **overshoot**: with ``â₀`` the initial error axis (``log(E(t₀))^∨ = θ₀ â₀``), the largest
  excursion past the target along that axis, ``max(0, −min_t ⟨log(E(t))^∨, â₀⟩)`` [deg] and in
  percent of ``θ₀``; NaN when ``θ₀`` is below ``min_geodesic_deg`` (no manoeuvre);
- **control effort**: ``∫‖u‖dt`` [N·m·s] and ``∫‖u‖²dt`` [N²·m²·s] of the torque delivered on the
  body;
- **peak gimbal rate**: ``max_{t,i} |δ̇_i|``; **minimum singularity measure** ``min_t m``;
  **time in gimbal-rate saturation**: ``Σ_k sat_k (t_{k+1} − t_k)`` (left rectangle: a flagged
  sample counts until the next sample);
- **unwinding ratio** (SPEC §8.1/§8.2): path angle ``∫‖e_Ω‖dt`` over the initial geodesic angle
  ``θ₀``. The path angle is the length of the error trajectory ``E(t)`` on SO(3), so a controller
  taking the short way has ratio ≈ 1 − θ_f/θ₀ ≤ 1 (plus any overshoot); ratio ≥ 1.5 means the
  controller has **unwound**. NaN when ``θ₀ < min_geodesic_deg``.

- **command reversals** (chattering indicator, :mod:`benchmarks.unwinding`): the number of
  consecutive logged commands with ``u_cmd,k · u_cmd,k−1 < 0`` while both have a norm of at least
  ``reversal_floor`` (5 %) of the run's peak command norm — a smooth PD reverses a few times
  (accelerate/brake, overshoot), a law switching between ±q every sample reverses at each one;
  NaN when the log has no ``u_cmd``.

Gimbal metrics are NaN when the log has no SGCMG actuator arrays (e.g. an ideal torque actuator).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol._validation import check_positive

__all__ = [
    "Metrics",
    "UNITS",
    "DESCRIPTIONS",
    "compute_metrics",
    "error_angle",
    "rate_error",
    "trapezoid",
    "settling_time",
]

RAD2DEG = 180.0 / np.pi


def _vee_skew(M: np.ndarray) -> np.ndarray:
    """``(M − Mᵀ)^∨`` for ``(..., 3, 3)``."""
    return np.stack(
        [M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]],
        axis=-1,
    )


def error_angle(R: np.ndarray, R_d: np.ndarray) -> np.ndarray:
    """Geodesic angle [rad] of ``E = R_dᵀR``, shape ``R.shape[:-2]``.

    ``θ = atan2(½‖(E − Eᵀ)^∨‖, ½(tr E − 1))``: accurate at 0 and at π (unlike ``arccos``).
    """
    E = np.swapaxes(R_d, -1, -2) @ R
    s = 0.5 * np.linalg.norm(_vee_skew(E), axis=-1)
    c = 0.5 * (np.trace(E, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(s, c)


def rate_error(
    R: np.ndarray, omega: np.ndarray, R_d: np.ndarray, omega_d: np.ndarray
) -> np.ndarray:
    """Body rate error ``e_Ω = ω − RᵀR_d ω_d`` (SPEC §6 item 1), shape ``omega.shape``."""
    Rt_Rd = np.swapaxes(R, -1, -2) @ R_d
    return omega - (Rt_Rd @ omega_d[..., None])[..., 0]


def trapezoid(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Trapezoidal ``∫ y dt`` over axis 0 (``y`` is ``(K, ...)``, ``t`` is ``(K,)``)."""
    if y.shape[0] < 2:
        return np.zeros(y.shape[1:])
    dt = np.diff(t).reshape((-1,) + (1,) * (y.ndim - 1))
    return np.sum(0.5 * (y[1:] + y[:-1]) * dt, axis=0)


def settling_time(t: np.ndarray, err: np.ndarray, threshold: float) -> np.ndarray:
    """First time after which ``err`` (``(K, B)``) stays ≤ ``threshold``; NaN if never.

    The crossing between the last sample above the threshold and the next one is linearly
    interpolated; if no sample exceeds the threshold the result is ``t[0]``.
    """
    K = err.shape[0]
    above = err > threshold
    # index of the last sample above the threshold (-1 when none)
    rev_first = np.argmax(above[::-1], axis=0)
    any_above = above.any(axis=0)
    last_above = np.where(any_above, K - 1 - rev_first, -1)
    out = np.full(err.shape[1:], np.nan)
    out[~any_above] = t[0]
    inner = any_above & (last_above < K - 1)
    if np.any(inner):
        cols = np.nonzero(inner)[0]
        k = last_above[cols]
        e0, e1 = err[k, cols], err[k + 1, cols]
        frac = (e0 - threshold) / (e0 - e1)  # e0 > threshold >= e1, so the denominator is > 0
        out[cols] = t[k] + frac * (t[k + 1] - t[k])
    return out


@dataclass(frozen=True)
class Metrics:
    """SPEC §8.2 metrics, each a ``(B,)`` float array (booleans for ``settled``/``unwound``).

    See the module docstring for the exact definitions; :data:`UNITS` gives the units.
    """

    initial_error_deg: np.ndarray
    final_error_deg: np.ndarray
    settling_time_s: np.ndarray
    settled: np.ndarray
    steady_error_max_deg: np.ndarray
    steady_error_rms_deg: np.ndarray
    peak_rate_deg_s: np.ndarray
    rms_rate_deg_s: np.ndarray
    overshoot_deg: np.ndarray
    overshoot_pct: np.ndarray
    effort_Nms: np.ndarray
    effort_sq_N2m2s: np.ndarray
    peak_gimbal_rate_rad_s: np.ndarray
    min_singularity: np.ndarray
    saturation_time_s: np.ndarray
    path_angle_deg: np.ndarray
    unwinding_ratio: np.ndarray
    unwound: np.ndarray
    command_reversals: np.ndarray

    @property
    def batch_size(self) -> int:
        return int(self.settling_time_s.shape[0])

    def as_dict(self, b: int) -> dict[str, Any]:
        """Metrics of spacecraft ``b`` as plain Python scalars (NaN stays ``float('nan')``)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)[b]
            out[f.name] = bool(v) if v.dtype == bool else float(v)
        return out

    def records(self) -> list[dict[str, Any]]:
        """One dict per spacecraft."""
        return [self.as_dict(b) for b in range(self.batch_size)]


#: Unit of each :class:`Metrics` field.
UNITS: dict[str, str] = {
    "initial_error_deg": "deg",
    "final_error_deg": "deg",
    "settling_time_s": "s",
    "settled": "bool",
    "steady_error_max_deg": "deg",
    "steady_error_rms_deg": "deg",
    "peak_rate_deg_s": "deg/s",
    "rms_rate_deg_s": "deg/s",
    "overshoot_deg": "deg",
    "overshoot_pct": "%",
    "effort_Nms": "N·m·s",
    "effort_sq_N2m2s": "N²·m²·s",
    "peak_gimbal_rate_rad_s": "rad/s",
    "min_singularity": "-",
    "saturation_time_s": "s",
    "path_angle_deg": "deg",
    "unwinding_ratio": "-",
    "unwound": "bool",
    "command_reversals": "-",
}

#: One-line meaning of each field (for reports).
DESCRIPTIONS: dict[str, str] = {
    "initial_error_deg": "geodesic attitude error θ at the first sample",
    "final_error_deg": "θ at the last sample",
    "settling_time_s": "first time after which θ stays below the threshold (NaN: not settled)",
    "settled": "θ is below the threshold at the end of the run",
    "steady_error_max_deg": "max θ over the final 10 % of the run",
    "steady_error_rms_deg": "RMS θ over the final 10 % of the run",
    "peak_rate_deg_s": "max ‖ω − RᵀR_dω_d‖",
    "rms_rate_deg_s": "RMS ‖ω − RᵀR_dω_d‖ over the run",
    "overshoot_deg": "largest excursion past the target along the initial error axis",
    "overshoot_pct": "overshoot in % of the initial error angle",
    "effort_Nms": "∫‖u‖dt, u = torque delivered on the body",
    "effort_sq_N2m2s": "∫‖u‖²dt",
    "peak_gimbal_rate_rad_s": "max over time and gimbals of |δ̇_i|",
    "min_singularity": "min over time of m = √det(ÂÂᵀ)",
    "saturation_time_s": "time with the gimbal-rate limit active",
    "path_angle_deg": "∫‖ω − RᵀR_dω_d‖dt (length of the error path on SO(3))",
    "unwinding_ratio": "path angle / initial geodesic angle (≥ 1.5: unwound)",
    "unwound": "unwinding ratio ≥ 1.5",
    "command_reversals": "consecutive commands with u_k·u_{k−1} < 0 (both ≥ 5 % of the peak)",
}


def _actuator_array(result: Any, key: str) -> np.ndarray | None:
    act = getattr(result, "actuator", None) or {}
    a = act.get(key) if isinstance(act, dict) else None
    return None if a is None else np.asarray(a)


def compute_metrics(
    result: Any,
    *,
    settle_threshold_deg: float = 0.1,
    steady_fraction: float = 0.1,
    unwinding_threshold: float = 1.5,
    min_geodesic_deg: float = 1.0,
    reversal_floor: float = 0.05,
) -> Metrics:
    """Compute the SPEC §8.2 metrics of every spacecraft of a simulation log.

    Args:
        result: a ``SimulationResult`` (or any object with ``t (K,)``, ``R (K,B,3,3)``,
            ``omega (K,B,3)``, ``R_d (K,B,3,3)``, ``omega_d (K,B,3)``, ``u (K,B,3)`` and an
            ``actuator`` dict optionally holding ``delta_dot (K,B,n)``, ``singularity (K,B)``,
            ``saturated (K,B)`` or per gimbal ``(K,B,n)``).
        settle_threshold_deg: settling threshold on θ [deg] (SPEC §8.2: 0.1°).
        steady_fraction: final fraction of the run used for the steady-state error.
        unwinding_threshold: unwinding ratio from which a run counts as unwound (SPEC §8.1).
        min_geodesic_deg: initial error below which overshoot/unwinding are not defined (NaN).
        reversal_floor: fraction of the peak command norm below which a command does not count
            for ``command_reversals``.

    Returns:
        :class:`Metrics` with ``(B,)`` arrays.
    """
    settle_threshold_deg = check_positive(settle_threshold_deg, "settle_threshold_deg")
    steady_fraction = check_positive(steady_fraction, "steady_fraction")
    if steady_fraction > 1.0:
        raise ValueError(f"steady_fraction: must be in (0, 1], got {steady_fraction}")
    unwinding_threshold = check_positive(unwinding_threshold, "unwinding_threshold")
    min_geodesic_deg = check_positive(min_geodesic_deg, "min_geodesic_deg")
    reversal_floor = check_positive(reversal_floor, "reversal_floor")
    if reversal_floor > 1.0:
        raise ValueError(f"reversal_floor: must be in (0, 1], got {reversal_floor}")

    t = np.asarray(result.t, dtype=np.float64)
    R = np.asarray(result.R, dtype=np.float64)
    omega = np.asarray(result.omega, dtype=np.float64)
    u = np.asarray(result.u, dtype=np.float64)
    if t.ndim != 1 or t.shape[0] < 1:
        raise ValueError(f"result: t must be a non-empty 1-D array, got shape {t.shape}")
    K = t.shape[0]
    if R.ndim != 4 or R.shape[0] != K or R.shape[2:] != (3, 3):
        raise ValueError(f"result: R must have shape (K={K}, B, 3, 3), got {R.shape}")
    B = R.shape[1]
    for name, arr, tail in (("omega", omega, (3,)), ("u", u, (3,))):
        if arr.shape != (K, B) + tail:
            raise ValueError(f"result: {name} must have shape {(K, B) + tail}, got {arr.shape}")
    try:
        R_d = np.broadcast_to(np.asarray(result.R_d, dtype=np.float64), R.shape)
        omega_d = np.broadcast_to(np.asarray(result.omega_d, dtype=np.float64), omega.shape)
    except ValueError:
        raise ValueError(
            f"result: R_d/omega_d shapes {np.shape(result.R_d)}/{np.shape(result.omega_d)} "
            f"do not match R {R.shape} / omega {omega.shape}"
        ) from None

    theta = error_angle(R, R_d)  # (K, B)
    e_omega = rate_error(R, omega, R_d, omega_d)
    rate = np.linalg.norm(e_omega, axis=-1)
    T = float(t[-1] - t[0])

    theta0 = theta[0]
    ts = settling_time(t, theta, np.deg2rad(settle_threshold_deg))
    settled = theta[-1] <= np.deg2rad(settle_threshold_deg)

    t_steady = t[-1] - steady_fraction * T
    win = t >= t_steady - 1e-12 * max(abs(t[-1]), 1.0)
    th_w, t_w = theta[win], t[win]
    steady_max = th_w.max(axis=0)
    T_w = float(t_w[-1] - t_w[0])
    steady_rms = np.sqrt(trapezoid(th_w**2, t_w) / T_w) if T_w > 0 else th_w[-1]

    peak_rate = rate.max(axis=0)
    rms_rate = np.sqrt(trapezoid(rate**2, t) / T) if T > 0 else rate[0]

    # overshoot along the initial error axis (rotation vectors via scipy, robust near π)
    E = np.swapaxes(R_d, -1, -2) @ R
    rv = Rotation.from_matrix(E.reshape(-1, 3, 3)).as_rotvec().reshape(K, B, 3)
    defined = theta0 >= np.deg2rad(min_geodesic_deg)
    axis0 = rv[0] / np.where(defined, np.linalg.norm(rv[0], axis=-1), 1.0)[:, None]
    along = np.einsum("kbi,bi->kb", rv, axis0)
    overshoot = np.maximum(0.0, -along.min(axis=0))
    overshoot_deg = np.where(defined, overshoot * RAD2DEG, np.nan)
    overshoot_pct = np.where(defined, 100.0 * overshoot / np.where(defined, theta0, 1.0), np.nan)

    u_norm = np.linalg.norm(u, axis=-1)
    effort = trapezoid(u_norm, t)
    effort_sq = trapezoid(u_norm**2, t)

    delta_dot = _actuator_array(result, "delta_dot")
    if delta_dot is not None and delta_dot.size:
        peak_gimbal = np.abs(delta_dot).max(axis=(0, 2))
    else:
        peak_gimbal = np.full(B, np.nan)
    sing = _actuator_array(result, "singularity")
    min_sing = sing.min(axis=0) if sing is not None else np.full(B, np.nan)
    sat = _actuator_array(result, "saturated")
    if sat is not None:
        # per-gimbal flags (K, B, 4) count when any gimbal of that spacecraft is limited
        sat = sat.reshape(K, B, -1).any(axis=-1)
        dts = np.diff(t)
        sat_time = (sat[:-1].astype(np.float64) * dts[:, None]).sum(axis=0)
    else:
        sat_time = np.full(B, np.nan)

    u_cmd = getattr(result, "u_cmd", None)
    if u_cmd is not None and np.shape(u_cmd) == (K, B, 3):
        uc = np.asarray(u_cmd, dtype=np.float64)
        un = np.linalg.norm(uc, axis=-1)
        big = un >= reversal_floor * un.max(axis=0, keepdims=True)
        big &= un > 0.0
        flip = np.einsum("kbi,kbi->kb", uc[1:], uc[:-1]) < 0.0
        reversals = np.sum(flip & big[1:] & big[:-1], axis=0).astype(np.float64)
    else:
        reversals = np.full(B, np.nan)

    path = trapezoid(rate, t)
    ratio = np.where(defined, path / np.where(defined, theta0, 1.0), np.nan)
    unwound = np.where(defined, ratio >= unwinding_threshold, False)

    return Metrics(
        initial_error_deg=theta0 * RAD2DEG,
        final_error_deg=theta[-1] * RAD2DEG,
        settling_time_s=ts,
        settled=np.asarray(settled, dtype=bool),
        steady_error_max_deg=steady_max * RAD2DEG,
        steady_error_rms_deg=steady_rms * RAD2DEG,
        peak_rate_deg_s=peak_rate * RAD2DEG,
        rms_rate_deg_s=np.asarray(rms_rate) * RAD2DEG,
        overshoot_deg=overshoot_deg,
        overshoot_pct=overshoot_pct,
        effort_Nms=effort,
        effort_sq_N2m2s=effort_sq,
        peak_gimbal_rate_rad_s=peak_gimbal,
        min_singularity=np.asarray(min_sing, dtype=np.float64),
        saturation_time_s=sat_time,
        path_angle_deg=path * RAD2DEG,
        unwinding_ratio=ratio,
        unwound=np.asarray(unwound, dtype=bool),
        command_reversals=reversals,
    )
