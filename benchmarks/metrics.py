"""Benchmark metrics computed from a simulation log, per spacecraft.

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
- **overshoot**: with ``â₀`` the approach axis — the initial error axis
  (``log(E(t₀))^∨ = θ₀ â₀``), or, for a run that crossed the antipode (**unwound**, below), the
  error axis at the first sample after its last crossing (it then approaches the target from
  the other side) — the largest excursion past the target along that axis from then on,
  ``max(0, −min_{t ≥ t_s} ⟨log(E(t))^∨, â₀⟩)`` [deg] and in percent of ``θ₀``; NaN when ``θ₀``
  is below ``min_geodesic_deg`` (no manoeuvre);
- **control effort**: ``∫‖u‖dt`` [N·m·s] and ``∫‖u‖²dt`` [N²·m²·s] of the torque delivered on the
  body;
- **peak gimbal rate**: ``max_{t,i} |δ̇_i|``; **minimum singularity measure** ``min_t m``;
  **time in gimbal-rate saturation**: ``Σ_k sat_k (t_{k+1} − t_k)`` (left rectangle: a flagged
  sample counts until the next sample);
- **unwinding ratio**: path angle ``∫‖e_Ω‖dt`` over the initial geodesic angle
  ``θ₀``. The path angle is the length of the error trajectory ``E(t)`` on SO(3): a controller
  taking the short way has ratio ≈ 1 − θ_f/θ₀ ≤ 1 plus twice any overshoot, and a detour (around
  a keep-out cone) lengthens it too, so the ratio is a cost, not the unwinding test. NaN when
  ``θ₀ < min_geodesic_deg``.
- **unwound**: the error trajectory crossed the cut locus θ = π — the rotation went the long
  way round. Detected on consecutive samples whose error rotation vectors
  ``r_k = log(E_k)^∨`` both have ``θ > π/2`` and point into opposite half-spaces
  (``⟨r_k, r_{k+1}⟩ < 0``: the rotation vector jumped across the antipode). Overshoot (``r``
  passes through 0, where θ is small) and a detour that stays below π are not unwinding.
- **RPE / PDE** (ECSS-E-ST-60-10C, :mod:`benchmarks.requirements`): over the final 10 % of the
  run cut into consecutive windows of ``rpe_window_s`` (default 10 s), ``rpe_deg`` =
  ``max_j max_{t∈j} ‖r(t) − r̄_j‖`` and ``pde_deg`` = ``max_j ‖r̄_{j+1} − r̄_j‖`` with ``r̄_j`` the
  mean error vector of window ``j``; NaN when ``rpe_window_s`` is ``None`` (PDE also with fewer
  than two windows). APE is ``steady_error_max_deg``.

- **command reversals** (chattering indicator, :mod:`benchmarks.unwinding`): the number of
  consecutive logged commands with ``u_cmd,k · u_cmd,k−1 < 0`` while both have a norm of at least
  ``reversal_floor`` (5 %) of the run's peak command norm — a smooth PD reverses a few times
  (accelerate/brake, overshoot), a law switching between ±q every sample reverses at each one;
  NaN when the log has no ``u_cmd``.

- **actuator use** (chosen by what the actuator logs; NaN where it does not apply):
  SGCMG pyramid — peak gimbal rate, the same as a fraction of the gimbal-rate limit, minimum
  singularity measure; reaction wheels — peak ``max_{t,i} |Ω_i| / Ω_max,i`` (fraction of the
  speed limit), time with a wheel at its speed limit (``wheel_speed_saturation_time_s``: the
  momentum is saturated) and with a wheel torque clipped (``torque_saturation_time_s``); both
  — peak stored momentum ``max_t ‖h‖``; every actuator — ``saturation_time_s``, the time with
  any limit active (gimbal rate; wheel torque or speed; the ideal actuator's torque box), and
  the peak delivered torque ``max_t ‖u‖``.

- **pointing constraints**: ``min_keep_out_margin_deg`` / ``min_keep_in_margin_deg``, the
  smallest margin of the scenario's cones over the logged samples (angle from the boresight to
  the cone boundary, negative when violated; :mod:`liecontrol.control.constrained`); NaN ("not
  defined") when the scenario has no cone of that kind.

Verdicts: :func:`judge` turns a run's metrics into ``success`` / ``degraded`` / ``failed`` /
``error`` / ``not-applicable`` plus flags, with the scenario's tolerances (rules in its
docstring).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol._validation import (
    as_array,
    as_scalar,
    check_positive,
    check_positive_scalar,
    check_rotation_matrix,
)
from liecontrol.control.constrained import cone_margins_deg

__all__ = [
    "Metrics",
    "UNITS",
    "RUN_UNITS",
    "DESCRIPTIONS",
    "VERDICTS",
    "FLAGS",
    "NEAR_SINGULAR_M",
    "CHATTER_REVERSALS",
    "OVERSHOOT_FLAG_PCT",
    "MOMENTUM_SATURATED_FRACTION",
    "DUMPING_INSUFFICIENT_GROWTH",
    "DIVERGENCE_MARGIN_DEG",
    "judge",
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


#: Tolerance on max |RᵀR − I| of the attitudes given to :func:`error_angle` and
#: :func:`rate_error` (looser than a single input's: a long simulation accumulates round-off).
HISTORY_ROTATION_ATOL = 1e-6


def error_angle(R: np.ndarray, R_d: np.ndarray) -> np.ndarray:
    """Geodesic angle [rad] of ``E = R_dᵀR``, shape ``R.shape[:-2]``.

    ``θ = atan2(½‖(E − Eᵀ)^∨‖, ½(tr E − 1))``: accurate at 0 and at π (unlike ``arccos``).
    """
    # rotations within HISTORY_ROTATION_ATOL: a reflection, a zero or a random matrix would
    # give a plausible-looking angle
    R = check_rotation_matrix(R, "R", HISTORY_ROTATION_ATOL)
    R_d = check_rotation_matrix(R_d, "R_d", HISTORY_ROTATION_ATOL)
    _broadcast("R_d", R_d.shape[:-2], "R", R.shape[:-2])
    E = np.swapaxes(R_d, -1, -2) @ R
    s = 0.5 * np.linalg.norm(_vee_skew(E), axis=-1)
    c = 0.5 * (np.trace(E, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(s, c)


def rate_error(
    R: np.ndarray, omega: np.ndarray, R_d: np.ndarray, omega_d: np.ndarray
) -> np.ndarray:
    """Body rate error ``e_Ω = ω − RᵀR_d ω_d``, shape ``omega.shape``."""
    R = check_rotation_matrix(R, "R", HISTORY_ROTATION_ATOL)  # rotations, as in error_angle
    omega = as_array(omega, "omega", (3,))
    R_d = check_rotation_matrix(R_d, "R_d", HISTORY_ROTATION_ATOL)
    omega_d = as_array(omega_d, "omega_d", (3,))
    _broadcast("omega", omega.shape[:-1], "R", R.shape[:-2])
    _broadcast("R_d", R_d.shape[:-2], "R", R.shape[:-2])
    _broadcast("omega_d", omega_d.shape[:-1], "R", R.shape[:-2])
    Rt_Rd = np.swapaxes(R, -1, -2) @ R_d
    return omega - (Rt_Rd @ omega_d[..., None])[..., 0]


def _broadcast(name: str, shape: tuple[int, ...], other: str, other_shape: tuple) -> None:
    """Raise naming ``name`` unless its batch shape broadcasts with ``other``'s."""
    try:
        np.broadcast_shapes(shape, other_shape)
    except ValueError:
        raise ValueError(
            f"{name}: batch shape {shape} does not broadcast with {other}'s {other_shape}"
        ) from None


def trapezoid(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Trapezoidal ``∫ y dt`` over axis 0 (``y`` is ``(K, ...)``, ``t`` is ``(K,)``; lists are
    accepted)."""
    y = as_array(y, "y")
    t = as_array(t, "t")
    if y.ndim < 1 or y.shape[0] == 0:
        raise ValueError(f"y: expected shape (K, ...) with K >= 1, got {y.shape}")
    if t.shape != (y.shape[0],):
        raise ValueError(f"t: expected shape ({y.shape[0]},) to match y, got {t.shape}")
    if y.shape[0] < 2:
        return np.zeros(y.shape[1:])
    if np.any(np.diff(t) < 0.0):  # a decreasing t would turn the integral's sign
        k = int(np.argmax(np.diff(t) < 0.0))
        raise ValueError(
            f"t: must be non-decreasing, got t[{k + 1}] = {t[k + 1]} < t[{k}] = {t[k]}"
        )
    dt = np.diff(t).reshape((-1,) + (1,) * (y.ndim - 1))
    return np.sum(0.5 * (y[1:] + y[:-1]) * dt, axis=0)


def settling_time(t: np.ndarray, err: np.ndarray, threshold: float) -> np.ndarray:
    """First time after which ``err`` (``(K, B)``) stays ≤ ``threshold``; NaN if never.

    The crossing between the last sample above the threshold and the next one is linearly
    interpolated; if no sample exceeds the threshold the result is ``t[0]``.
    """
    t = as_array(t, "t")
    err = as_array(err, "err")
    threshold = as_scalar(threshold, "threshold")
    if err.ndim not in (1, 2) or err.shape[0] == 0:
        raise ValueError(f"err: expected shape (K,) or (K, B) with K >= 1, got {err.shape}")
    if t.shape != (err.shape[0],):
        raise ValueError(f"t: expected shape ({err.shape[0]},) to match err, got {t.shape}")
    if err.ndim == 1:  # one series: the (K, 1) case, returned as a scalar array
        return settling_time(t, err[:, None], threshold)[0]
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
    """The benchmark metrics (docs/benchmarks.md), each a ``(B,)`` float array (booleans for
    ``settled``/``unwound``).

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
    peak_gimbal_rate_frac: np.ndarray
    peak_wheel_speed_frac: np.ndarray
    wheel_speed_saturation_time_s: np.ndarray
    torque_saturation_time_s: np.ndarray
    peak_momentum_Nms: np.ndarray
    peak_torque_Nm: np.ndarray
    path_angle_deg: np.ndarray
    unwinding_ratio: np.ndarray
    unwound: np.ndarray
    rpe_deg: np.ndarray
    pde_deg: np.ndarray
    command_reversals: np.ndarray
    min_keep_out_margin_deg: np.ndarray
    min_keep_in_margin_deg: np.ndarray
    peak_momentum_fraction: np.ndarray
    final_momentum_fraction: np.ndarray
    stop_contact_time_s: np.ndarray

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
    "peak_gimbal_rate_frac": "-",
    "peak_wheel_speed_frac": "-",
    "wheel_speed_saturation_time_s": "s",
    "torque_saturation_time_s": "s",
    "peak_momentum_Nms": "N·m·s",
    "peak_torque_Nm": "N·m",
    "path_angle_deg": "deg",
    "unwinding_ratio": "-",
    "unwound": "bool",
    "rpe_deg": "deg",
    "pde_deg": "deg",
    "command_reversals": "-",
    "min_keep_out_margin_deg": "deg",
    "min_keep_in_margin_deg": "deg",
    "peak_momentum_fraction": "-",
    "final_momentum_fraction": "-",
    "stop_contact_time_s": "s",
}

#: Units of the quantities the runner adds to a run's metrics (SE(3) runs, timing).
RUN_UNITS: dict[str, str] = {
    "controller_time_us": "µs",
    "sim_wall_time_s": "s",
    "final_position_error_m": "m",
    "steady_position_error_max_m": "m",
    "position_settling_time_s": "s",
    "peak_force_N": "N",
    "force_effort_Ns": "N·s",
    "delta_v_m_s": "m/s",
    "max_range_ratio": "-",
    "force_saturation_time_s": "s",
    "nees_mean": "-",
    "nees_in_bounds": "-",
    "nees_in_bounds_fraction": "-",
    "nees_effective_samples": "-",
    "nees_full_mean": "-",
    "nis_mean": "-",
    "nis_in_bounds": "-",
    "filter_updates": "-",
    "filter_rejections": "-",
    "estimation_error_max_deg": "deg",
    "momentum_growth_per_orbit": "1/orbit",
    "propellant_kg": "kg",
    "propellant_kg_per_orbit": "kg/orbit",
    "fault_detection_delay_s": "s",
    "false_alarms": "-",
    "time_to_detumble_s": "s",
    "initial_rate_deg_s": "deg/s",
    "final_rate_deg_s": "deg/s",
    "electrical_energy_J": "J",
    "kinetic_energy_removed_J": "J",
    "peak_dipole_frac": "-",
    "averaged_detumble_time_s": "s",
    "time_to_acquire_s": "s",
    "sun_angle_error_deg": "deg",
    "sun_angle_rms_deg": "deg",
    "peak_rate_eclipse_deg_s": "deg/s",
    "sun_angle_exit_deg": "deg",
    "reacquire_s": "s",
    "initial_sun_angle_deg": "deg",
    "final_sun_angle_deg": "deg",
    "eclipse_entry_s": "s",
    "eclipse_exit_s": "s",
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
    "saturation_time_s": "time with any actuator limit active (gimbal rate; wheel torque or "
    "speed; torque box)",
    "peak_gimbal_rate_frac": "peak gimbal rate / gimbal-rate limit",
    "peak_wheel_speed_frac": "max over time and wheels of |Ω_i| / Ω_max",
    "wheel_speed_saturation_time_s": "time with a wheel at its speed limit (momentum saturated)",
    "torque_saturation_time_s": "time with a wheel torque clipped at its limit",
    "peak_momentum_Nms": "max over time of the stored actuator momentum ‖h‖",
    "peak_torque_Nm": "max over time of ‖u‖, the torque delivered on the body",
    "path_angle_deg": "∫‖ω − RᵀR_dω_d‖dt (length of the error path on SO(3))",
    "unwinding_ratio": "path angle / initial geodesic angle (a cost: overshoot and detours "
    "lengthen the path too)",
    "unwound": "the error path crossed θ = π (the rotation went the long way round)",
    "rpe_deg": "ECSS relative performance error over the final 10 %: max ‖e − ē_window‖",
    "pde_deg": "ECSS performance drift error: max ‖ē_{j+1} − ē_j‖ between windows",
    "command_reversals": "consecutive commands with u_k·u_{k−1} < 0 (both ≥ 5 % of the peak)",
    "min_keep_out_margin_deg": "smallest angle to a keep-out cone boundary over the run "
    "(< 0: violated; NaN: the scenario has no keep-out cone)",
    "min_keep_in_margin_deg": "smallest angle to a keep-in cone boundary over the run "
    "(< 0: violated; NaN: the scenario has no keep-in cone)",
    "peak_momentum_fraction": "max over time of the stored momentum over the actuator's "
    "envelope in its direction (SGCMG: ‖h‖/σ(ĥ); wheels: max |Ω_i|/Ω_max)",
    "final_momentum_fraction": "the same at the last sample",
    "stop_contact_time_s": "time with a gimbal at a gimbal-angle stop (full CMG model)",
    "controller_time_us": "mean wall time of one controller call per spacecraft",
    "sim_wall_time_s": "wall time of the simulation the run was batched in",
    "final_position_error_m": "SE(3): ‖p − p_d‖ at the last sample",
    "steady_position_error_max_m": "SE(3): max ‖p − p_d‖ over the final 10 % of the run",
    "position_settling_time_s": "SE(3): first time after which ‖p − p_d‖ stays below tolerance",
    "peak_force_N": "SE(3): max ‖F‖ over the run",
    "force_effort_Ns": "SE(3): ∫‖F‖dt, the force delivered on the chaser",
    "delta_v_m_s": "SE(3): ΔV = ∫‖F‖/m dt, the velocity change the thrusters deliver",
    "max_range_ratio": "SE(3): max ‖p − p_d‖ over the run / ‖p₀ − p_d‖ (range excursion)",
    "force_saturation_time_s": "SE(3): time with a force component at the thrust limit",
    "nees_mean": "filtered sensors: time average of the attitude NEES δθᵀP⁻¹δθ (3 states; "
    "3 when the filter is consistent)",
    "nees_in_bounds": "filtered sensors: 1 when nees_mean lies in the two-sided 95 % region "
    "χ²(3K)/K of its time average (K: effective number of independent samples), else 0",
    "nees_in_bounds_fraction": "filtered sensors: share of the NEES samples inside χ²₃'s "
    "two-sided 95 % interval (0.95 when consistent)",
    "nees_effective_samples": "filtered sensors: effective number of independent NEES samples "
    "K/τ (τ: integrated autocorrelation time, Sokal's window) behind nees_in_bounds",
    "nees_full_mean": "filtered sensors: time average of the NEES of attitude and gyro bias "
    "(6 states; 6 when consistent)",
    "nis_mean": "filtered sensors: time average of the star-tracker NIS νᵀS⁻¹ν (3 when "
    "consistent)",
    "nis_in_bounds": "filtered sensors: 1 when nis_mean lies in the two-sided 95 % region "
    "χ²(3K)/K over the K updates, else 0",
    "filter_updates": "filtered sensors: star-tracker updates offered to the filter",
    "filter_rejections": "filtered sensors: updates rejected by the χ² innovation gate",
    "estimation_error_max_deg": "filtered sensors: max attitude estimation error over the "
    "final 10 % of the run (the floor the pointing error cannot beat)",
    "momentum_growth_per_orbit": "momentum management: secular growth per orbit of the stored "
    "momentum's envelope fraction from the end of the first orbit to the first saturation "
    "(least-squares slope × orbit period; NaN under two orbits)",
    "propellant_kg": "thruster unloading: propellant used over the run",
    "propellant_kg_per_orbit": "thruster unloading: propellant used per orbit (run average)",
    "fault_detection_delay_s": "fault scenarios: time from the first fault to the residual "
    "CUSUM's first alarm on a faulty unit (NaN: not detected)",
    "false_alarms": "fault scenarios: units flagged by the residual CUSUM that are not faulty, "
    "or flagged before their fault",
    "time_to_detumble_s": "detumble: first logged time after which ‖ω‖ stays below the "
    "threshold (NaN: not reached within the run)",
    "initial_rate_deg_s": "detumble: ‖ω‖ of the separation tumble",
    "final_rate_deg_s": "detumble: ‖ω‖ at the last sample",
    "electrical_energy_J": "detumble: the rods' electrical energy Σᵢ∫P_i (mᵢ/m_max)² dt",
    "kinetic_energy_removed_J": "detumble: rotational kinetic energy ½ωᵀJω at the start minus "
    "at the end",
    "peak_dipole_frac": "detumble: max over time and rods of |mᵢ|/m_max (1: saturated)",
    "averaged_detumble_time_s": "detumble: the time the gain implies — the averaged "
    "unsaturated dynamics J ω̇ = −(2/3) d k ω from the same tumble to the threshold "
    "(spacecraft.detumble.averaged_detumble_time; a reference, not a measurement)",
    "time_to_acquire_s": "Sun acquisition: first logged time after which the true Sun angle "
    "(body axis to Sun) stays within the spec's threshold until the eclipse entry (NaN: not "
    "acquired)",
    "sun_angle_error_deg": "Sun acquisition: max Sun angle over the spec's window (last "
    "window_s of sunlight before the eclipse entry)",
    "sun_angle_rms_deg": "Sun acquisition: RMS Sun angle over the same window",
    "peak_rate_eclipse_deg_s": "Sun acquisition: max ‖ω‖ in the eclipse (NaN: no eclipse in "
    "the run)",
    "sun_angle_exit_deg": "Sun acquisition: Sun angle at the eclipse exit (the drift in the "
    "shadow; NaN: the run ends before the exit)",
    "reacquire_s": "Sun acquisition: time after the eclipse exit until the Sun angle stays "
    "within the threshold to the end (NaN: not re-acquired, or no exit in the run)",
    "initial_sun_angle_deg": "Sun acquisition: Sun angle at the start",
    "final_sun_angle_deg": "Sun acquisition: Sun angle at the last sample",
    "eclipse_entry_s": "Sun acquisition: the orbit's eclipse entry (1 s grid)",
    "eclipse_exit_s": "Sun acquisition: the orbit's eclipse exit (1 s grid)",
}


def _actuator_array(result: Any, key: str) -> np.ndarray | None:
    act = getattr(result, "actuator", None) or {}
    a = act.get(key) if isinstance(act, dict) else None
    return None if a is None else np.asarray(a)


def _flag_time(t: np.ndarray, flags: np.ndarray | None, K: int, B: int) -> np.ndarray:
    """``Σ_k any_i flag_{k,b,i} (t_{k+1} − t_k)`` per spacecraft (left rectangle: a flagged
    sample counts until the next one); NaN when the log has no such flag."""
    if flags is None:
        return np.full(B, np.nan)
    # per-unit flags (K, B, n) count when any unit of that spacecraft is limited
    f = np.asarray(flags).reshape(K, B, -1).any(axis=-1)
    return (f[:-1].astype(np.float64) * np.diff(t)[:, None]).sum(axis=0)


def compute_metrics(
    result: Any,
    *,
    settle_threshold_deg: float = 0.1,
    steady_fraction: float = 0.1,
    min_geodesic_deg: float = 1.0,
    reversal_floor: float = 0.05,
    gimbal_rate_limit: float | None = None,
    wheel_max_speed: float | np.ndarray | None = None,
    keep_out: Any = (),
    keep_in: Any = (),
    momentum_actuator: Any = None,
    rpe_window_s: float | None = None,
) -> Metrics:
    """Compute the benchmark metrics of every spacecraft of a simulation log.

    Args:
        result: a ``SimulationResult`` (or any object with ``t (K,)``, ``R (K,B,3,3)``,
            ``omega (K,B,3)``, ``R_d (K,B,3,3)``, ``omega_d (K,B,3)``, ``u (K,B,3)`` and an
            ``actuator`` dict optionally holding ``delta_dot (K,B,n)``, ``singularity (K,B)``,
            ``saturated (K,B)`` or per gimbal ``(K,B,n)``).
        settle_threshold_deg: settling threshold on θ [deg] (default 0.1°).
        steady_fraction: final fraction of the run used for the steady-state error.
        min_geodesic_deg: initial error below which overshoot/unwinding are not defined (NaN).
        reversal_floor: fraction of the peak command norm below which a command does not count
            for ``command_reversals``.
        gimbal_rate_limit: the SGCMG gimbal-rate limit [rad/s] for ``peak_gimbal_rate_frac``
            (``None``: NaN).
        wheel_max_speed: the wheels' speed limit [rad/s], scalar or per wheel, for
            ``peak_wheel_speed_frac`` (``None``: NaN). The log's ``actuator`` dict may also
            hold ``wheel_speed (K,B,N)``, ``speed_saturated``/``torque_saturated (K,B,N)`` and
            ``h (K,B,3)``.
        keep_out: :class:`liecontrol.control.constrained.KeepOutCone` sequence: the run's
            ``min_keep_out_margin_deg`` is the smallest margin (angle from the boresight to the
            cone boundary, negative inside) over the logged samples and the cones; NaN ("not
            defined") when there is none.
        keep_in: the same for :class:`~liecontrol.control.constrained.KeepInCone`
            (``min_keep_in_margin_deg``; negative outside).
        momentum_actuator: the plant's actuator, for ``peak_momentum_fraction`` and
            ``final_momentum_fraction`` (:func:`spacecraft.momentum.momentum_fraction` of the
            logged gimbal angles ``delta`` or wheel speeds ``wheel_speed``); NaN when ``None``
            or the actuator stores no momentum.
        rpe_window_s: the RPE/PDE window [s] (``None``: ``rpe_deg``/``pde_deg`` are NaN); it
            must fit in the final ``steady_fraction`` of the run.

    Returns:
        :class:`Metrics` with ``(B,)`` arrays.
    """
    missing = [a for a in ("t", "R", "omega", "R_d", "omega_d", "u") if not hasattr(result, a)]
    if missing:
        raise ValueError(
            f"result: expected a SimulationResult (an object with t, R, omega, R_d, omega_d, u "
            f"and actuator), got {type(result).__name__} without {', '.join(missing)}"
        )
    settle_threshold_deg = check_positive_scalar(settle_threshold_deg, "settle_threshold_deg")
    steady_fraction = check_positive_scalar(steady_fraction, "steady_fraction")
    if steady_fraction > 1.0:
        raise ValueError(f"steady_fraction: must be in (0, 1], got {steady_fraction}")
    min_geodesic_deg = check_positive_scalar(min_geodesic_deg, "min_geodesic_deg")
    reversal_floor = check_positive_scalar(reversal_floor, "reversal_floor")
    if reversal_floor > 1.0:
        raise ValueError(f"reversal_floor: must be in (0, 1], got {reversal_floor}")
    if gimbal_rate_limit is not None:
        gimbal_rate_limit = check_positive_scalar(gimbal_rate_limit, "gimbal_rate_limit")
    if wheel_max_speed is not None:
        wheel_max_speed = check_positive(wheel_max_speed, "wheel_max_speed")

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
    # the approach axis: the initial error axis, or after the last crossing of the antipode
    # (an unwinding run approaches from the other side) the error axis just after it
    start = _after_last_crossing(rv)
    cols = np.arange(B)
    r_s = rv[start, cols]
    n_s = np.linalg.norm(r_s, axis=-1)
    axis0 = r_s / np.where(defined & (n_s > 0), n_s, 1.0)[:, None]
    along = np.einsum("kbi,bi->kb", rv, axis0)
    along = np.where(np.arange(K)[:, None] >= start[None, :], along, np.inf)
    overshoot = np.maximum(0.0, -along.min(axis=0))
    overshoot_deg = np.where(defined, overshoot * RAD2DEG, np.nan)
    overshoot_pct = np.where(defined, 100.0 * overshoot / np.where(defined, theta0, 1.0), np.nan)

    u_norm = np.linalg.norm(u, axis=-1)
    peak_torque = u_norm.max(axis=0)
    effort = trapezoid(u_norm, t)
    effort_sq = trapezoid(u_norm**2, t)

    delta_dot = _actuator_array(result, "delta_dot")
    if delta_dot is not None and delta_dot.size:
        peak_gimbal = np.abs(delta_dot).max(axis=(0, 2))
    else:
        peak_gimbal = np.full(B, np.nan)
    sing = _actuator_array(result, "singularity")
    min_sing = sing.min(axis=0) if sing is not None else np.full(B, np.nan)
    sat_time = _flag_time(t, _actuator_array(result, "saturated"), K, B)
    speed_sat_time = _flag_time(t, _actuator_array(result, "speed_saturated"), K, B)
    torque_sat_time = _flag_time(t, _actuator_array(result, "torque_saturated"), K, B)
    if gimbal_rate_limit is not None and delta_dot is not None and delta_dot.size:
        gimbal_frac = peak_gimbal / gimbal_rate_limit
    else:
        gimbal_frac = np.full(B, np.nan)
    wheel_speed = _actuator_array(result, "wheel_speed")
    if wheel_max_speed is not None and wheel_speed is not None and wheel_speed.size:
        ws = wheel_speed.reshape(K, B, -1)
        lim = np.broadcast_to(np.asarray(wheel_max_speed, dtype=np.float64), ws.shape[-1:])
        wheel_frac = (np.abs(ws) / lim).max(axis=(0, 2))
    else:
        wheel_frac = np.full(B, np.nan)
    h_act = _actuator_array(result, "h")
    if h_act is not None and h_act.shape == (K, B, 3):
        peak_h = np.linalg.norm(h_act, axis=-1).max(axis=0)
    else:
        peak_h = np.full(B, np.nan)

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
    unwound = crossed_antipode(rv)
    if rpe_window_s is not None:
        from .requirements import pointing_errors

        win = check_positive_scalar(rpe_window_s, "rpe_window_s")
        rpe, pde = pointing_errors(t, rv, win, float(t_steady))
        rpe_deg, pde_deg = rpe * RAD2DEG, pde * RAD2DEG
    else:
        rpe_deg = pde_deg = np.full(B, np.nan)

    peak_mfrac = final_mfrac = np.full(B, np.nan)
    from spacecraft.actuators import ReactionWheelAssembly, SgcmgActuator
    from spacecraft.momentum import momentum_fraction

    key = None
    if isinstance(momentum_actuator, SgcmgActuator):
        key = "delta"
    elif isinstance(momentum_actuator, ReactionWheelAssembly):
        key = "wheel_speed"
    elif momentum_actuator is not None and not callable(
        getattr(momentum_actuator, "momentum", None)
    ):
        raise ValueError(
            "momentum_actuator: expected the plant's actuator (spacecraft.actuators), got "
            f"{type(momentum_actuator).__name__}"
        )
    x_log = None if key is None else _actuator_array(result, key)
    if x_log is not None and x_log.ndim == 3 and x_log.shape[:2] == (K, B) and x_log.size:
        frac = momentum_fraction(momentum_actuator, x_log)
        peak_mfrac, final_mfrac = frac.max(axis=0), frac[-1]

    margins = {}
    for name, cones in (("keep_out", keep_out), ("keep_in", keep_in)):
        cones = tuple(_check_cones(cones, name))
        margins[name] = (
            cone_margins_deg(cones, R).min(axis=(0, 2)) if cones else np.full(B, np.nan)
        )

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
        peak_gimbal_rate_frac=np.asarray(gimbal_frac, dtype=np.float64),
        peak_wheel_speed_frac=np.asarray(wheel_frac, dtype=np.float64),
        wheel_speed_saturation_time_s=speed_sat_time,
        torque_saturation_time_s=torque_sat_time,
        peak_momentum_Nms=np.asarray(peak_h, dtype=np.float64),
        peak_torque_Nm=peak_torque,
        path_angle_deg=path * RAD2DEG,
        unwinding_ratio=ratio,
        unwound=np.asarray(unwound, dtype=bool),
        rpe_deg=np.asarray(rpe_deg, dtype=np.float64),
        pde_deg=np.asarray(pde_deg, dtype=np.float64),
        command_reversals=reversals,
        min_keep_out_margin_deg=margins["keep_out"],
        min_keep_in_margin_deg=margins["keep_in"],
        peak_momentum_fraction=np.asarray(peak_mfrac, dtype=np.float64),
        final_momentum_fraction=np.asarray(final_mfrac, dtype=np.float64),
        stop_contact_time_s=_flag_time(t, _actuator_array(result, "stop_contact"), K, B),
    )


def _antipode_jumps(rv: np.ndarray) -> np.ndarray:
    """``(K−1, B)``: sample ``k → k+1`` jumps across the cut locus θ = π."""
    big = np.linalg.norm(rv, axis=-1) > 0.5 * np.pi
    flip = np.einsum("kbi,kbi->kb", rv[1:], rv[:-1]) < 0.0
    return flip & big[1:] & big[:-1]


def _after_last_crossing(rv: np.ndarray) -> np.ndarray:
    """Per spacecraft, the first sample after the last antipode crossing (0 when none)."""
    rv = np.asarray(rv, dtype=np.float64)
    K, B = rv.shape[:2]
    if K < 2:
        return np.zeros(B, dtype=np.intp)
    j = _antipode_jumps(rv)
    last = (K - 2) - np.argmax(j[::-1], axis=0)  # index k of the last jump k → k+1
    return np.where(j.any(axis=0), last + 1, 0).astype(np.intp)


def crossed_antipode(rv: np.ndarray) -> np.ndarray:
    """Per spacecraft: the error rotation vectors ``rv`` ``(K, B, 3)`` jumped across the cut
    locus θ = π between two consecutive samples (both with θ > π/2 and ``⟨r_k, r_{k+1}⟩ < 0``):
    the rotation went the long way round (module docstring, **unwound**)."""
    rv = np.asarray(rv, dtype=np.float64)
    if rv.shape[0] < 2:
        return np.zeros(rv.shape[1], dtype=bool)
    return _antipode_jumps(rv).any(axis=0)


def _check_cones(cones: Any, name: str) -> tuple:
    from liecontrol.control.constrained import KeepInCone, KeepOutCone

    cls = KeepOutCone if name == "keep_out" else KeepInCone
    if isinstance(cones, cls):
        return (cones,)
    if isinstance(cones, str) or not isinstance(cones, (tuple, list)):
        raise ValueError(f"{name}: expected a sequence of {cls.__name__}, got {cones!r}")
    for c in cones:
        if not isinstance(c, cls):
            raise ValueError(f"{name}: expected {cls.__name__} items, got {c!r}")
    return tuple(cones)


# --------------------------------------------------------------------------- verdicts

#: Verdicts of :func:`judge`, best first.
VERDICTS: tuple[str, ...] = ("success", "degraded", "failed", "error", "not-applicable")
#: Flags :func:`judge` can raise (``constraint-violated``: a keep-out/keep-in pointing cone of
#: the scenario was violated).
FLAGS: tuple[str, ...] = (
    "attitude-not-converged",
    "position-not-converged",
    "diverged",
    "unwound",
    "overshoot",
    "actuator-saturated",
    "momentum-saturated",
    "near-singular",
    "chattering",
    "constraint-violated",
    "dumping-insufficient",
    "fault-injected",
    "rate-not-damped",
    "sun-not-acquired",
    "sun-not-reacquired",
    "exception",
)
#: Singularity measure below which a run is flagged ``near-singular``. m = √det(ÂÂᵀ) of the
#: normalised Jacobian is ≈ 1.09 at the pyramid's zero-momentum null-motion equilibrium and 0
#: at a singular gimbal set; the gimbal rate the pseudo-inverse asks for a given torque grows
#: like 1/σ_min, and at m = 0.2 the smallest singular value is already a few times below the
#: equilibrium's, so torque accuracy and gimbal-rate headroom are visibly degraded.
NEAR_SINGULAR_M = 0.2
#: ``overshoot_pct`` above which a run is flagged ``overshoot``: past the target along the
#: initial error axis by more than 10 % of the initial angle (the default overshoot requirement,
#: :data:`benchmarks.requirements.OVERSHOOT_LIMIT_PCT`).
OVERSHOOT_FLAG_PCT = 10.0
#: ``command_reversals`` from which a run is flagged ``chattering``: a smooth law reverses its
#: torque a handful of times (accelerate, brake, one or two overshoots) over a whole run; a law
#: that switches sign from sample to sample reverses hundreds of times.
CHATTER_REVERSALS = 20
#: ``peak_momentum_fraction`` from which a run is flagged ``momentum-saturated``: the SGCMG
#: fraction divides by the cluster's capacity along ĥ, which exceeds the envelope's true radius
#: by up to ~6 % near a gimbal axis (:mod:`spacecraft.momentum`), so a cluster pinned at its
#: envelope can read as low as ~0.94; 0.95 catches the envelope everywhere else.
MOMENTUM_SATURATED_FRACTION = 0.95
#: ``momentum_growth_per_orbit`` from which a run is flagged ``dumping-insufficient``: the
#: stored momentum's envelope fraction grows by 5 % of the envelope per orbit or more after the
#: first orbit — at that rate a cluster holding half its envelope saturates within ten orbits
#: (a held dumping loop leaves a slope of order 0.01 from the cyclic part's run-end phase).
DUMPING_INSUFFICIENT_GROWTH = 0.05
#: A run has ``diverged`` when it ends at least this much farther from the target than it
#: started [deg] (a bounded steady offset under a constant disturbance is not divergence: it is
#: ``attitude-not-converged``).
DIVERGENCE_MARGIN_DEG = 30.0


def _num(m: dict[str, Any], key: str) -> float:
    v = m.get(key)
    if v is None or isinstance(v, bool):
        return float("nan") if v is None else float(v)
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def _judge_detumble(metrics: dict[str, Any]) -> tuple[str, tuple[str, ...]]:
    """A detumble run: ``failed`` (``diverged``) on a non-finite rate or energy, ``failed``
    (``rate-not-damped``) when ‖ω‖ did not stay below the threshold within the run, else
    ``success``. Saturated rods are not flagged: a detumble starts saturated by design."""
    core = [_num(metrics, k) for k in ("final_rate_deg_s", "electrical_energy_J")]
    if not all(math.isfinite(v) for v in core):
        return "failed", ("diverged",)
    if not math.isfinite(_num(metrics, "time_to_detumble_s")):
        return "failed", ("rate-not-damped",)
    return "success", ()


def _judge_sun_acquisition(metrics: dict[str, Any]) -> tuple[str, tuple[str, ...]]:
    """A Sun-acquisition run: ``failed`` (``diverged``) on a non-finite Sun angle or rate,
    ``failed`` (``sun-not-acquired``) when the Sun angle did not stay within the threshold
    before the eclipse (or the end), ``failed`` (``sun-not-reacquired``) when the run leaves
    the eclipse and does not get back within it, else ``success``. The torque box is not
    flagged: safe mode starts saturated by design."""
    core = [_num(metrics, k) for k in ("final_sun_angle_deg", "final_rate_deg_s")]
    if not all(math.isfinite(v) for v in core):
        return "failed", ("diverged",)
    if not math.isfinite(_num(metrics, "time_to_acquire_s")):
        return "failed", ("sun-not-acquired",)
    exited = math.isfinite(_num(metrics, "sun_angle_exit_deg"))
    if exited and not math.isfinite(_num(metrics, "reacquire_s")):
        return "failed", ("sun-not-reacquired",)
    return "success", ()


def judge(
    scenario: Any,
    metrics: dict[str, Any],
    *,
    status: str = "ok",
    error: str | None = None,
) -> tuple[str, tuple[str, ...]]:
    """Verdict and flags of one run of ``scenario`` from its ``metrics`` (a
    :meth:`Metrics.as_dict` record, plus the SE(3) keys the runner adds).

    ``scenario`` needs ``attitude_tolerance_deg``, ``position_tolerance_m`` and ``plant``
    (a :class:`benchmarks.scenarios.Scenario`). ``status``/``error`` are the run's
    (:class:`benchmarks.runner.RunOutcome`): ``"n/a"`` → ``not-applicable``; ``"failed"`` →
    ``error`` (flag ``diverged`` when the simulation stopped on a non-finite state, else
    ``exception``). For a completed run every rule below is checked and the worst verdict wins:

    ============================================================  ======================  =========
    rule                                                          flag                    verdict
    ============================================================  ======================  =========
    ``steady_error_max_deg`` > ``attitude_tolerance_deg`` or NaN  attitude-not-converged  failed
    SE(3): ``steady_position_error_max_m`` > ``position_tol…``    position-not-converged  failed
    a metric is non-finite (NaN/inf state), or the run ends ≥ 30°   diverged                failed
    farther from the target than it started
    ``unwound`` (the error path crossed θ = π: the long way)       unwound                 degraded
    ``overshoot_pct`` > :data:`OVERSHOOT_FLAG_PCT` (10 %)           overshoot               degraded
    ``saturation_time_s`` > 0 (gimbal rate / torque box;           actuator-saturated      degraded
    on wheels ``torque_saturation_time_s`` > 0)
    ``wheel_speed_saturation_time_s`` > 0, or                      momentum-saturated      degraded
    ``peak_momentum_fraction`` ≥ :data:`MOMENTUM_SATURATED_FRACTION`
    ``min_singularity`` < :data:`NEAR_SINGULAR_M` (0.2)            near-singular           degraded
    ``command_reversals`` ≥ :data:`CHATTER_REVERSALS` (20)         chattering              degraded
    ``min_keep_out_margin_deg`` or ``min_keep_in_margin_deg`` < 0  constraint-violated     failed
    (NaN: the scenario has no such cone — not checked)
    ``momentum_growth_per_orbit`` ≥                                 dumping-insufficient    degraded
    :data:`DUMPING_INSUFFICIENT_GROWTH` (0.05 of the envelope per
    orbit; momentum-management scenarios, NaN: not checked)
    the scenario injects actuator faults (``scenario.faults``)      fault-injected          (none)
    detumble (plant ``magnetorquer``): ‖ω‖ not below the threshold  rate-not-damped         failed
    for good within the run (only the detumble rules apply there)
    Sun acquisition (plant ``sun-safe``): the Sun not within the  sun-not-acquired /      failed
    threshold for good before the eclipse, or not again after it  sun-not-reacquired
    (only these rules apply there)
    none of the above                                              —                       success
    ============================================================  ======================  =========

    ``momentum-saturated`` means, per actuator: wheels — a wheel at its speed limit, or a peak
    |Ω_i|/Ω_max ≥ 0.95; SGCMG — stored momentum ‖h‖ at ≥ 95 % of the cluster's momentum
    envelope in its direction (``peak_momentum_fraction``, which the report tabulates).

    ``fault-injected`` is informational: it marks a run that met a fault without changing
    its verdict (a faulty run that still meets every rule is a ``success``).

    So ``success`` needs every error channel of the scenario within its tolerance, no
    divergence, no unwinding, and no actuator limit or near-singularity on the way.

    Returns:
        ``(verdict, flags)`` with ``verdict`` in :data:`VERDICTS` and ``flags`` a tuple of
        :data:`FLAGS` entries in the order of the table.
    """
    if status == "n/a":
        return "not-applicable", ()
    if status != "ok":
        text = (error or "").lower()
        diverged = "diverged" in text or "non-finite" in text or "nan" in text.split()
        return "error", ("diverged",) if diverged else ("exception",)
    if not isinstance(metrics, dict):
        raise TypeError(f"metrics: expected a dict of metric values, got {type(metrics).__name__}")
    if getattr(scenario, "plant", None) == "magnetorquer":
        return _judge_detumble(metrics)
    if getattr(scenario, "plant", None) == "sun-safe":
        return _judge_sun_acquisition(metrics)
    tol = float(scenario.attitude_tolerance_deg)
    flags: list[str] = []
    failed = False
    steady = _num(metrics, "steady_error_max_deg")
    if not steady <= tol:  # NaN counts as not converged
        flags.append("attitude-not-converged")
        failed = True
    is_pose = scenario.plant == "se3"
    if is_pose:
        ptol = float(scenario.position_tolerance_m)
        pos = _num(metrics, "steady_position_error_max_m")
        if math.isnan(pos):
            pos = _num(metrics, "final_position_error_m")
        if not pos <= ptol:
            flags.append("position-not-converged")
            failed = True
    th0, thf = _num(metrics, "initial_error_deg"), _num(metrics, "final_error_deg")
    core = [steady, thf, _num(metrics, "effort_Nms")]
    moved_away = thf >= th0 + DIVERGENCE_MARGIN_DEG
    if is_pose:
        pos_f = _num(metrics, "final_position_error_m")
        core.append(pos_f)
    if not all(math.isfinite(v) for v in core) or moved_away:
        flags.append("diverged")
        failed = True
    if metrics.get("unwound"):
        flags.append("unwound")
    if _num(metrics, "overshoot_pct") > OVERSHOOT_FLAG_PCT:
        flags.append("overshoot")
    sat = _num(metrics, "saturation_time_s")
    wheel_torque = _num(metrics, "torque_saturation_time_s")
    wheel_speed = _num(metrics, "wheel_speed_saturation_time_s")
    # wheels: only a clipped torque (a speed limit is momentum saturation, below); the full CMG
    # model logs its gimbal-motor torque limit too, but its gimbal-rate limit still counts
    full_cmg = getattr(getattr(scenario, "spacecraft", None), "cmg_model", "") == "full"
    if (
        (wheel_torque > 0 or (full_cmg and sat > 0))
        if math.isfinite(wheel_torque)
        else (sat > 0)
    ):
        flags.append("actuator-saturated")
    if wheel_speed > 0 or _num(metrics, "peak_momentum_fraction") >= MOMENTUM_SATURATED_FRACTION:
        flags.append("momentum-saturated")
    if _num(metrics, "min_singularity") < NEAR_SINGULAR_M:
        flags.append("near-singular")
    if _num(metrics, "command_reversals") >= CHATTER_REVERSALS:
        flags.append("chattering")
    # a pointing constraint crossed is a failed run (the sensor was exposed) however well the
    # attitude converged; NaN = no cone of that kind, so nothing to check
    if any(_num(metrics, k) < 0.0 for k in ("min_keep_out_margin_deg", "min_keep_in_margin_deg")):
        flags.append("constraint-violated")
        failed = True
    if _num(metrics, "momentum_growth_per_orbit") >= DUMPING_INSUFFICIENT_GROWTH:
        flags.append("dumping-insufficient")
    info = ("fault-injected",) if getattr(scenario, "faults", ()) else ()  # informational
    if failed:
        return "failed", tuple(flags) + info
    return ("degraded" if flags else "success"), tuple(flags) + info
