"""Detumble time vs gain and inclination: B-dot and the cross-product law on a 3U CubeSat.

Scenarios (:data:`DETUMBLE_SCENARIOS`): a 3U CubeSat (4 kg, ``J = diag(0.0419, 0.0419,
0.0067)`` kg·m²) after separation, tumbling at 5–10 °/s about uniformly random axes
(:func:`spacecraft.detumble.separation_tumble`, ``seed``), on a 530 km circular orbit at 97.5°
(``detumble-sso``) or 51.6° (``detumble-iss``) in the IGRF-2020 tilted dipole; three 0.2 A·m²
rods (0.2 W each at full dipole), a 2 s control period with the rods on 80 % of it, a
magnetometer with 100 nT noise and a (0.4, −0.2, 0.3) μT bias, a gyro with 1e-5 rad/s noise for
the cross-product law. Detumbled: ``‖ω‖`` below 1 °/s for good
(:func:`spacecraft.detumble.simulate_detumble`).

Per scenario, law and gain ``k`` [N·m·s] (B-dot: ``k_b = k/⟨‖B‖²⟩`` over the orbit, so both laws
have the same averaged damping): the median, minimum and maximum time to detumble over the
tumbles, the median of :func:`spacecraft.detumble.averaged_detumble_time` (the time the gain
implies) and the median electrical energy of the rods.

Run: ``python -m benchmarks.detumble_study [--gains 2.5e-5,5e-5,1e-4] [--out table.md]``.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "CUBESAT_3U_J",
    "DETUMBLE_SCENARIOS",
    "DetumbleScenario",
    "detumble_table",
    "format_table",
    "main",
]

#: Inertia of the 3U CubeSat [kg·m²].
CUBESAT_3U_J = np.diag([0.0419, 0.0419, 0.0067])
CUBESAT_3U_J.setflags(write=False)


@dataclass(frozen=True)
class DetumbleScenario:
    """A detumble case (module docstring): ``name``, orbit ``inclination_deg`` and
    ``altitude_km``, ``n_tumbles`` separation tumbles of ``rate_range_deg_s`` drawn with
    ``seed``, the ``threshold_deg_s`` and the simulated time ``t_final`` [s]."""

    name: str
    inclination_deg: float
    altitude_km: float = 530.0
    n_tumbles: int = 8
    rate_range_deg_s: tuple[float, float] = (5.0, 10.0)
    seed: int = 3
    threshold_deg_s: float = 1.0
    t_final: float = 12000.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"name: expected a non-empty str, got {self.name!r}")
        if not (
            isinstance(self.inclination_deg, (int, float)) and 0 <= self.inclination_deg <= 180
        ):
            raise ValueError(f"inclination_deg: expected [0, 180], got {self.inclination_deg!r}")
        for key in ("n_tumbles", "seed"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                raise ValueError(f"{key}: expected an integer, got {v!r}")
        if not 1 <= self.n_tumbles <= 10_000:
            raise ValueError(f"n_tumbles: expected 1 to 10000, got {self.n_tumbles!r}")
        raw = np.asarray(self.rate_range_deg_s)
        rr = raw.astype(np.float64) if raw.dtype.kind in "iuf" else np.zeros(0)
        if rr.shape != (2,) or not (0.0 <= rr[0] <= rr[1] < 1e3):
            raise ValueError(
                f"rate_range_deg_s: expected (low, high), 0 ≤ low ≤ high, got "
                f"{self.rate_range_deg_s!r}"
            )
        object.__setattr__(self, "rate_range_deg_s", (float(rr[0]), float(rr[1])))
        for key in ("altitude_km", "threshold_deg_s", "t_final"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{key}: must be a finite number > 0, got {v!r}")


#: The two detumble scenarios: a sun-synchronous and a 51.6° orbit at 530 km.
DETUMBLE_SCENARIOS: tuple[DetumbleScenario, ...] = (
    DetumbleScenario("detumble-sso", 97.5),
    DetumbleScenario("detumble-iss", 51.6),
)


def _mean_B2(orbit: Any) -> float:
    from spacecraft.geomagnetic import TiltedDipoleField

    t = np.linspace(0.0, orbit.period, 400)
    B = TiltedDipoleField().inertial(t, orbit.position(t))
    return float(np.mean(np.sum(B * B, axis=-1)))


def detumble_table(
    gains: Sequence[float] = (2.5e-5, 5e-5, 1e-4),
    laws: Sequence[str] = ("bdot", "cross-product"),
    scenarios: Sequence[DetumbleScenario] = DETUMBLE_SCENARIOS,
) -> list[dict[str, Any]]:
    """Rows ``{scenario, inclination_deg, law, k, t_median_s, t_min_s, t_max_s, not_reached,
    t_averaged_median_s, energy_median_J}``, one per scenario × gain × law.

    Raises:
        ValueError: a gain ≤ 0, an unknown law, or scenarios that are not
            :class:`DetumbleScenario`.
    """
    from spacecraft.detumble import (
        DETUMBLE_LAWS,
        DetumbleLaw,
        Magnetometer,
        averaged_detumble_time,
        separation_tumble,
        simulate_detumble,
    )
    from spacecraft.orbit import CircularOrbit

    if isinstance(gains, (str, bytes)) or not isinstance(gains, Sequence) or not gains:
        raise ValueError(f"gains: expected a non-empty sequence of numbers, got {gains!r}")
    for k in gains:
        if not (isinstance(k, (int, float)) and math.isfinite(k) and k > 0):
            raise ValueError(f"gains: every gain must be a finite number > 0, got {k!r}")
    if isinstance(laws, str) or not all(law in DETUMBLE_LAWS for law in laws):
        raise ValueError(f"laws: expected a sequence from {DETUMBLE_LAWS}, got {laws!r}")
    if not all(isinstance(s, DetumbleScenario) for s in scenarios):
        raise ValueError(f"scenarios: expected DetumbleScenario items, got {scenarios!r}")
    rows = []
    for sc in scenarios:
        orbit = CircularOrbit.from_altitude(
            sc.altitude_km * 1e3, inclination=math.radians(sc.inclination_deg)
        )
        B2 = _mean_B2(orbit)
        w0 = separation_tumble(sc.n_tumbles, sc.rate_range_deg_s, seed=sc.seed)
        thr = math.radians(sc.threshold_deg_s)
        for k in gains:
            t_avg = [averaged_detumble_time(CUBESAT_3U_J, k, w, thr, 0.8) for w in w0]
            for law in laws:
                res = simulate_detumble(
                    CUBESAT_3U_J,
                    DetumbleLaw(
                        k if law == "cross-product" else k / B2,
                        m_max=0.2,
                        law=law,
                        period=2.0,
                        duty_cycle=0.8,
                        gyro_noise_std=1e-5,
                        rod_power=0.2,
                    ),
                    w0,
                    sc.t_final,
                    threshold=thr,
                    orbit=orbit,
                    magnetometer=Magnetometer(noise_std=1e-7, bias=(4e-7, -2e-7, 3e-7)),
                    dt=1.0,
                    seed=sc.seed,
                )
                ttt = res.time_to_threshold
                ok = ttt[np.isfinite(ttt)]
                rows.append(
                    {
                        "scenario": sc.name,
                        "inclination_deg": sc.inclination_deg,
                        "law": law,
                        "k": float(k),
                        "t_median_s": float(np.median(ok)) if ok.size else math.nan,
                        "t_min_s": float(ok.min()) if ok.size else math.nan,
                        "t_max_s": float(ok.max()) if ok.size else math.nan,
                        "not_reached": int(ttt.size - ok.size),
                        "t_averaged_median_s": float(np.median(t_avg)),
                        "energy_median_J": float(np.median(res.electrical_energy)),
                    }
                )
    return rows


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    """A Markdown table of :func:`detumble_table`'s rows."""
    if isinstance(rows, (str, bytes)) or not isinstance(rows, Sequence):
        raise TypeError(f"rows: expected a sequence of dicts, got {type(rows).__name__}")
    keys = ("scenario", "inclination_deg", "law", "k", "t_median_s", "t_min_s", "t_max_s")
    lines = [
        "| scenario | inclination | law | k [N·m·s] | t_detumble median (min–max) [s] | "
        "averaged median [s] | electrical energy median [J] |",
        "|---|---|---|---|---|---|---|",
    ]
    for i, r in enumerate(rows):
        if not isinstance(r, dict) or any(k not in r for k in keys):
            raise ValueError(f"rows: item {i} must be a dict with the keys {keys}, got {r!r}")
        miss = f"; {r['not_reached']} not reached" if r.get("not_reached") else ""
        lines.append(
            f"| `{r['scenario']}` | {r['inclination_deg']:g}° | {r['law']} | {r['k']:.1e} | "
            f"{r['t_median_s']:.0f} ({r['t_min_s']:.0f}–{r['t_max_s']:.0f}{miss}) | "
            f"{r.get('t_averaged_median_s', math.nan):.0f} | "
            f"{r.get('energy_median_J', math.nan):.1f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Command line: print (or write with ``--out``) the table of :func:`detumble_table`."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gains", default="2.5e-5,5e-5,1e-4", help="comma-separated k [N·m·s]")
    ap.add_argument("--out", default=None, help="write the Markdown table here")
    a = ap.parse_args(argv)
    table = format_table(detumble_table(tuple(float(g) for g in a.gains.split(",") if g)))
    if a.out:
        with open(a.out, "w", encoding="utf-8") as fh:
            fh.write(table)
    print(table, end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
