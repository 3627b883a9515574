"""Safe-mode Sun acquisition from a slow tumble in sunlight, through an eclipse.

Scenario (:func:`sun_acquisition_run`): a 30 kg-class small satellite (:data:`SAFE_MODE_J`, a
per-axis torque box of 10 mN·m — reaction wheels or thrusters in safe mode) on a 530 km, 51.6°
circular orbit (RAAN 270°, epoch J2000.0) that starts in sunlight 1630 s before the Earth's
shadow, which it crosses for ≈ 2080 s. Each start is a uniformly random attitude (the Sun may be
behind the array) and a tumble of ``rate_range_deg_s`` about a uniformly random axis
(``default_rng(seed)``). Sensors: six coarse Sun sensors on the cube faces (90° fields of view,
1 % noise, 3 % lit threshold; albedo-free) at 2 Hz and a MEMS-class gyro (white noise 5e-5
rad/s, initial bias 1e-4 rad/s 1σ per axis, bias random walk 1e-6 rad/s^{3/2}) at 2 Hz,
through :class:`spacecraft.sun_sensors.SunSensorGyro`; no star tracker. Law:
:class:`liecontrol.control.sun_acquisition.SunAcquisitionLaw` pointing body +z at the Sun with
:func:`~liecontrol.control.sun_acquisition.sun_acquisition_gains` (ω_n = 0.02 rad/s, ζ = 0.9),
gravity gradient on.

Metrics per start: ``time_to_acquire_s`` — the first time after which the true Sun angle (body
+z to the Sun) stays within ``tol_deg`` until the eclipse; ``sun_angle_error_deg`` — the
largest Sun angle over the last 300 s of sunlight before the eclipse (the acquired pointing
accuracy); ``peak_rate_eclipse_deg_s`` — the largest body rate during the eclipse (the safe
attitude holds: the rate stays bounded); ``sun_angle_exit_deg`` — the Sun angle at the eclipse
exit (how far the attitude drifted in the shadow);
``reacquire_s`` — time after the eclipse exit to be back within ``tol_deg``.

Run: ``python -m benchmarks.safe_mode [--starts 20] [--seed 0] [--eclipse damp|propagate]``.
"""

from __future__ import annotations

import argparse
import functools
import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "SAFE_MODE_J",
    "SunAcquisitionRun",
    "sun_acquisition_run",
    "format_table",
    "main",
]

#: Inertia of the safe-mode scenario's small satellite [kg·m²].
SAFE_MODE_J = np.array([[12.0, 0.3, -0.2], [0.3, 10.0, 0.1], [-0.2, 0.1, 8.0]])
SAFE_MODE_J.setflags(write=False)

_ALTITUDE_M = 530e3
_INCLINATION_DEG = 51.6
_RAAN_DEG = 270.0
_MAX_TORQUE = 0.01


@dataclass(frozen=True)
class SunAcquisitionRun:
    """A safe-mode run of ``B`` starts: ``t`` ``(K,)`` [s], ``sun_angle_deg`` ``(K, B)`` (true
    angle from the pointed axis to the Sun), ``rate_deg_s`` ``(K, B)`` (‖ω‖), ``eclipse``
    ``(K,)`` bool, and per start ``time_to_acquire_s``, ``sun_angle_error_deg``,
    ``peak_rate_eclipse_deg_s``, ``sun_angle_exit_deg``, ``reacquire_s`` ``(B,)`` (NaN: not
    reached; module docstring), with ``tol_deg`` and the eclipse entry/exit times [s]."""

    t: np.ndarray
    sun_angle_deg: np.ndarray
    rate_deg_s: np.ndarray
    eclipse: np.ndarray
    time_to_acquire_s: np.ndarray
    sun_angle_error_deg: np.ndarray
    peak_rate_eclipse_deg_s: np.ndarray
    sun_angle_exit_deg: np.ndarray
    reacquire_s: np.ndarray
    tol_deg: float
    eclipse_entry_s: float
    eclipse_exit_s: float


def _random_rotations(rng: np.random.Generator, n: int) -> np.ndarray:
    from liecontrol.charts import quaternion

    q = rng.standard_normal((n, 4))
    return quaternion.to_matrix(q / np.linalg.norm(q, axis=1, keepdims=True))


def _first_stay(t: np.ndarray, ok: np.ndarray) -> float:
    """First time from which ``ok`` holds to the end of the window (NaN: never)."""
    bad = np.nonzero(~ok)[0]
    if bad.size == 0:
        return float(t[0])
    if bad[-1] + 1 >= t.size:
        return math.nan
    return float(t[bad[-1] + 1])


# the requirements, the runner and the report all ask for the same orbit's window
@functools.lru_cache(maxsize=32)
def _eclipse_window(css: object) -> tuple[float, float]:
    """Entry and exit [s] of the first Earth shadow the sensors ``css`` (a
    :class:`spacecraft.sun_sensors.CoarseSunSensors`) see within one orbit period of t = 0, on a
    1 s grid (the safe-mode scenario is built around it); ``(nan, nan)`` when the orbit never
    enters the shadow, exit ``nan`` when it is still dark a period later."""
    grid = np.arange(0.0, css.orbit.period, 1.0)  # type: ignore[attr-defined]
    dark = np.array([css.sun(x)[1] for x in grid])  # type: ignore[attr-defined]
    if not dark.any():
        return math.nan, math.nan
    i_in = int(np.argmax(dark))
    if dark[i_in:].all():
        return float(grid[i_in]), math.nan
    return float(grid[i_in]), float(grid[i_in + int(np.argmax(~dark[i_in:]))])


def _fly(
    law: object,
    R0: np.ndarray,
    w0: np.ndarray,
    *,
    J: np.ndarray,
    css: object,
    gyro: object,
    body_axis: np.ndarray,
    max_torque: float,
    t_final: float,
    dt: float,
    control_period: float,
    log_every: int,
    seed: int,
    gravity_gradient: bool = True,
) -> object:
    """One safe-mode simulation (the machinery :func:`sun_acquisition_run` and the benchmark's
    ``sun-safe`` cells share): ``J`` the true inertia under an ideal torque box of
    ``max_torque``, gravity gradient on ``css``'s orbit, the law fed by the
    :class:`~spacecraft.sun_sensors.SunSensorGyro` hook of ``css`` and ``gyro``; the sensor
    noise from ``default_rng(seed)``. Returns the :class:`spacecraft.SimulationResult`."""
    from spacecraft import IdealTorqueActuator, RigidBody, Spacecraft, simulate
    from spacecraft.environment import GravityGradientTorque
    from spacecraft.sun_sensors import SunPointingReference, SunSensorGyro

    orbit = css.orbit  # type: ignore[attr-defined]
    plant = Spacecraft(
        RigidBody(J),
        IdealTorqueActuator(max_torque=max_torque),
        disturbance=GravityGradientTorque(J, orbit) if gravity_gradient else None,
    )
    return simulate(
        plant,
        law,  # type: ignore[arg-type]
        SunPointingReference(css, body_axis),  # type: ignore[arg-type]
        plant.initial_state(R0, w0),
        t_final,
        dt,
        control_period=control_period,
        log_every=log_every,
        sensors={"sun": css, "gyro": gyro},
        measurement=SunSensorGyro(css, "sun", "gyro"),  # type: ignore[arg-type]
        rng=np.random.default_rng(int(seed)),
    )


def _sun_angles(res: object, css: object, body_axis: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(t, Sun angle [deg] (K, B), ‖ω‖ [deg/s] (K, B), eclipse (K,))`` of a result: the true
    angle from ``body_axis`` to the Sun (not the measured one)."""
    t = np.asarray(res.t)  # type: ignore[attr-defined]
    sun = [css.sun(x) for x in t]  # type: ignore[attr-defined]
    s_I = np.array([s for s, _ in sun])
    s_b = np.einsum("kbji,kj->kbi", res.R, s_I)  # type: ignore[attr-defined]
    ang = np.degrees(np.arccos(np.clip(s_b @ body_axis, -1.0, 1.0)))
    rate = np.degrees(np.linalg.norm(res.omega, axis=-1))  # type: ignore[attr-defined]
    return t, ang, rate, np.array([d for _, d in sun], dtype=bool)


def _metrics(
    t: np.ndarray,
    ang: np.ndarray,
    rate: np.ndarray,
    ecl: np.ndarray,
    entry: float,
    exit_: float,
    tol_deg: float,
    window_s: float = 300.0,
) -> dict[str, np.ndarray]:
    """Per-start metrics ``(B,)`` of the module docstring, plus ``sun_angle_rms_deg`` (RMS Sun
    angle over the same window). A run that ends before the eclipse entry measures the window
    at its end and has NaN eclipse metrics; one that ends in the shadow has NaN exit metrics."""
    B = ang.shape[1]
    nan = np.full(B, math.nan)
    end_sun = entry if math.isfinite(entry) and entry <= t[-1] else math.inf
    before = t < end_sun
    tta = np.array([_first_stay(t[before], ang[before, j] <= tol_deg) for j in range(B)])
    win = before & (t >= (end_sun if math.isfinite(end_sun) else t[-1]) - window_s)
    err = ang[win].max(axis=0) if win.any() else nan
    rms = np.sqrt(np.mean(ang[win] ** 2, axis=0)) if win.any() else nan
    peak = rate[ecl].max(axis=0) if ecl.any() else nan
    if math.isfinite(exit_) and exit_ <= t[-1]:
        after = t >= exit_
        re = np.array([_first_stay(t[after], ang[after, j] <= tol_deg) for j in range(B)]) - exit_
        at_exit = ang[int(np.searchsorted(t, exit_))]
    else:
        re, at_exit = nan, nan
    return {
        "time_to_acquire_s": tta,
        "sun_angle_error_deg": err,
        "sun_angle_rms_deg": rms,
        "peak_rate_eclipse_deg_s": peak,
        "sun_angle_exit_deg": at_exit,
        "reacquire_s": re,
    }


def sun_acquisition_run(
    n_starts: int = 20,
    seed: int = 0,
    *,
    eclipse: str = "damp",
    rate_range_deg_s: tuple[float, float] = (1.0, 2.0),
    t_final: float = 4800.0,
    tol_deg: float = 5.0,
    dt: float = 0.5,
    omega_n: float = 0.02,
    zeta: float = 0.9,
    starts: tuple[object, object] | None = None,
) -> SunAcquisitionRun:
    """Fly the safe-mode scenario (module docstring) from ``n_starts`` seeded starts.

    ``starts``: ``(R0 (B, 3, 3), ω0 (B, 3))`` to fly instead of the seeded draws (``n_starts``
    is then ``B``; the sensor noise is still ``default_rng(seed + 1)``): the benchmark's
    ``safe-mode-sun-acquisition`` scenario is start 0 of ``seed`` 0 flown this way.

    Raises:
        ValueError: ``n_starts`` < 1, ``tol_deg`` not in (0, 180), a bad ``rate_range_deg_s``,
            ``eclipse`` not a mode of the law, ``t_final`` before the eclipse exit, ``dt``
            that is not a divisor of the 0.5 s sensor period, or ``starts`` of the wrong
            shapes.
    """
    from liecontrol.control.sun_acquisition import SunAcquisitionLaw, sun_acquisition_gains
    from spacecraft.orbit import CircularOrbit
    from spacecraft.sensors import RateGyro
    from spacecraft.sun_sensors import CoarseSunSensors

    if isinstance(n_starts, bool) or not isinstance(n_starts, (int, np.integer)):
        raise ValueError(f"n_starts: expected an integer ≥ 1, got {n_starts!r}")
    if not 1 <= n_starts <= 10_000:
        raise ValueError(f"n_starts: expected 1 to 10000 starts, got {n_starts}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed: expected an integer, got {seed!r}")
    if not (isinstance(tol_deg, (int, float)) and 0.0 < tol_deg < 180.0):
        raise ValueError(f"tol_deg: expected a value in (0, 180), got {tol_deg!r}")
    rr = np.asarray(rate_range_deg_s, dtype=np.float64)
    if rr.shape != (2,) or not (0.0 <= rr[0] <= rr[1] < 30.0):
        raise ValueError(
            f"rate_range_deg_s: expected (low, high) with 0 ≤ low ≤ high < 30, got "
            f"{rate_range_deg_s!r}"
        )
    orbit = CircularOrbit.from_altitude(
        _ALTITUDE_M, inclination=math.radians(_INCLINATION_DEG), raan=math.radians(_RAAN_DEG)
    )
    css = CoarseSunSensors(orbit, noise_std=0.01, threshold=0.03, period=0.5)
    entry, exit_ = _eclipse_window(css)
    t_final = float(t_final)
    if not t_final > exit_ + 60.0:
        raise ValueError(
            f"t_final: must end after the eclipse exit at {exit_:.0f} s (+60 s), got {t_final!r}"
        )
    if starts is None:
        rng = np.random.default_rng(int(seed))
        R0 = _random_rotations(rng, int(n_starts))
        axis = rng.standard_normal((int(n_starts), 3))
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        w0 = axis * np.radians(rng.uniform(rr[0], rr[1], size=(int(n_starts), 1)))
    else:
        R0 = np.asarray(starts[0], dtype=np.float64).reshape(-1, 3, 3)
        w0 = np.asarray(starts[1], dtype=np.float64).reshape(-1, 3)
        if R0.shape[0] != w0.shape[0] or not np.all(np.isfinite(R0)) or not np.all(np.isfinite(w0)):
            raise ValueError(
                "starts: expected finite (R0 (B, 3, 3), omega0 (B, 3)) with the same B, got "
                f"shapes {R0.shape}, {w0.shape}"
            )
    J = np.array(SAFE_MODE_J)
    b = np.array([0.0, 0.0, 1.0])
    law = SunAcquisitionLaw(
        **sun_acquisition_gains(J, omega_n, zeta),
        body_axis=b,
        max_torque=_MAX_TORQUE,
        eclipse=eclipse,
    )
    gyro = RateGyro(white_std=5e-5, initial_bias_std=1e-4, bias_rw_std=1e-6, period=0.5)
    res = _fly(
        law,
        R0,
        w0,
        J=J,
        css=css,
        gyro=gyro,
        body_axis=b,
        max_torque=_MAX_TORQUE,
        t_final=t_final,
        dt=dt,
        control_period=0.5,
        log_every=max(1, int(round(5.0 / dt))),
        seed=int(seed) + 1,
    )
    t, ang, rate, ecl = _sun_angles(res, css, b)
    m = _metrics(t, ang, rate, ecl, entry, exit_, float(tol_deg))
    return SunAcquisitionRun(
        t=t,
        sun_angle_deg=ang,
        rate_deg_s=rate,
        eclipse=ecl,
        time_to_acquire_s=m["time_to_acquire_s"],
        sun_angle_error_deg=m["sun_angle_error_deg"],
        peak_rate_eclipse_deg_s=m["peak_rate_eclipse_deg_s"],
        sun_angle_exit_deg=m["sun_angle_exit_deg"],
        reacquire_s=m["reacquire_s"],
        tol_deg=float(tol_deg),
        eclipse_entry_s=entry,
        eclipse_exit_s=exit_,
    )


def format_table(runs: dict[str, SunAcquisitionRun]) -> str:
    """A Markdown table, one line per eclipse mode: median (min–max) of each metric."""
    if not isinstance(runs, dict) or not all(
        isinstance(r, SunAcquisitionRun) for r in runs.values()
    ):
        raise TypeError("runs: expected a dict mode -> SunAcquisitionRun")

    def mm(a: np.ndarray, fmt: str) -> str:
        a = np.asarray(a, dtype=np.float64)
        ok = a[np.isfinite(a)]
        miss = a.size - ok.size
        if ok.size == 0:
            return f"— ({miss} not reached)"
        s = f"{np.median(ok):{fmt}} ({ok.min():{fmt}}–{ok.max():{fmt}})"
        return s + (f", {miss} not reached" if miss else "")

    lines = [
        "| eclipse mode | starts | time to acquire [s] | Sun angle, last 300 s before eclipse "
        "[°] | peak rate in eclipse [°/s] | Sun angle at eclipse exit [°] | re-acquire after "
        "exit [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for mode, r in runs.items():
        lines.append(
            f"| {mode} | {r.time_to_acquire_s.size} | {mm(r.time_to_acquire_s, '.0f')} | "
            f"{mm(r.sun_angle_error_deg, '.2f')} | {mm(r.peak_rate_eclipse_deg_s, '.3f')} | "
            f"{mm(r.sun_angle_exit_deg, '.1f')} | "
            f"{mm(r.reacquire_s, '.0f')} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Command line: print the table of :func:`sun_acquisition_run` for both eclipse modes."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--eclipse", default=None, help="damp or propagate (default: both)")
    a = ap.parse_args(argv)
    modes = ("damp", "propagate") if a.eclipse is None else (a.eclipse,)
    runs = {m: sun_acquisition_run(a.starts, a.seed, eclipse=m) for m in modes}
    print(format_table(runs), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
