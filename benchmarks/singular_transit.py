"""Singular-transit comparison of the SGCMG steering laws:
``python -m benchmarks.singular_transit --out DIR [--dt 0.01]``.

Open-loop momentum-path tracking on the four-SGCMG pyramid (h₀ = 1 N·m·s, β = 54.73°, gimbal
rate limit 1 rad/s): each path prescribes a constant momentum rate ḣ_cmd = r d̂ from a
zero-momentum gimbal set δ₀, and the gimbals are stepped with every steering law (classical
RK4 on δ, the law and the rate limit :func:`spacecraft.steering.saturate_gimbal_rates` applied
at every stage). Without steering trouble the stored momentum would follow
h_cmd(t) = h(δ₀) + r d̂ t exactly. The paths (:data:`PATHS`) were chosen so that the plain
pseudo-inverse runs into an internal singularity: two elliptic ones (where null motion cannot
help) and a hyperbolic one (which null motion can pass); :func:`classify_singularity` computes
the type at the pseudo-inverse's closest approach, so the labels are checked, not assumed.

Per law and path (:func:`track_path`, :func:`transit_table`): the torque error
max_t |A δ̇ − ḣ_cmd|/|ḣ_cmd| with δ̇ the delivered (rate-limited) rates, the final momentum
error |h(δ(T)) − h_cmd(T)|/h₀ (did the momentum get through?), the time spent near a
singularity (m < :data:`NEAR_SINGULAR_M`), the minimum m and the peak gimbal rate. Writes
``table.md`` and ``singular_transit.png`` (m and torque error along each path, one line per
law) into ``--out``. The whole run takes a few seconds.
"""

from __future__ import annotations

import argparse
import math
import pathlib
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from liecontrol._validation import as_array, as_scalar
from spacecraft.sgcmg import SgcmgPyramid
from spacecraft.steering import (
    GeneralizedSingularityRobust,
    LocalGradient,
    PseudoInverse,
    PseudoInverseNullMotion,
    SingularDirectionAvoidance,
    SingularityRobust,
    SteeringLaw,
    saturate_gimbal_rates,
)

__all__ = [
    "NEAR_SINGULAR_M",
    "PATHS",
    "TRANSIT_LAWS",
    "TransitPath",
    "TransitResult",
    "classify_singularity",
    "main",
    "run_comparison",
    "singular_gimbal_angles",
    "track_path",
    "transit_table",
]

#: "Near a singularity": the singularity measure m = √det(ÂÂᵀ) below this (m ≤ 1.54 for the
#: pyramid; 1.09 at the catalogue's starting gimbal set).
NEAR_SINGULAR_M = 0.1

#: The laws compared, by registry name (:func:`benchmarks.runner.build_steering`), each built
#: for a given cluster with its default parameters.
TRANSIT_LAWS: dict[str, Callable[[SgcmgPyramid], SteeringLaw]] = {
    "pinv": lambda cl: PseudoInverse(),
    "pinv-null-motion": lambda cl: PseudoInverseNullMotion(cluster=cl),
    "sr": lambda cl: SingularityRobust(),
    "gsr": lambda cl: GeneralizedSingularityRobust(),
    "local-gradient": lambda cl: LocalGradient(cluster=cl),
    "sda": lambda cl: SingularDirectionAvoidance(),
}


def singular_gimbal_angles(cluster: SgcmgPyramid, u: object, signs: object) -> np.ndarray:
    """Gimbal angles ``(4,)`` [rad] of the singular state with singular direction ``u`` and
    sign pattern ``signs`` (εᵢ = ±1).

    At a singular state every torque axis âᵢ = gᵢ × hᵢ is normal to u, so each unit momentum
    is the normalised projection of u on its gimbal plane: hᵢ = εᵢ (u − (u·gᵢ)gᵢ)/|u − (u·gᵢ)gᵢ|
    (Wie, "Singularity analysis and visualization for single-gimbal control moment gyro
    systems", J. Guidance, Control, and Dynamics 27(2), 2004; Kurokawa 2007). All εᵢ = +1 gives
    the momentum envelope; other patterns give internal singular states. ``u`` must not be
    along a gimbal axis (the projection would vanish).
    """
    if not isinstance(cluster, SgcmgPyramid):
        raise TypeError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
    uu = as_array(u, "u", (3,))
    if uu.shape != (3,) or not np.linalg.norm(uu) > 0.0:
        raise ValueError(f"u: expected a non-zero 3-vector, got {u!r}")
    uu = uu / np.linalg.norm(uu)
    eps = as_array(signs, "signs")
    if eps.shape != (4,) or not np.all(np.abs(eps) == 1.0):
        raise ValueError(f"signs: expected four entries ±1, got {signs!r}")
    G = cluster.gimbal_axes()  # (3, 4)
    # unit momentum hᵢ(δ) = Sᵢ sin δ + Cᵢ cos δ with orthonormal Sᵢ = hᵢ(90°), Cᵢ = hᵢ(0)
    S = cluster.unit_momenta(np.full(4, np.pi / 2))
    C = cluster.unit_momenta(np.zeros(4))
    out = np.empty(4)
    for i in range(4):
        p = uu - (uu @ G[:, i]) * G[:, i]
        norm = float(np.linalg.norm(p))
        if norm < 1e-9:
            raise ValueError(f"u: along gimbal axis {i + 1}, no singular state is defined")
        hi = eps[i] * p / norm
        out[i] = math.atan2(float(hi @ S[:, i]), float(hi @ C[:, i]))
    return out


def classify_singularity(
    cluster: SgcmgPyramid, delta: object
) -> tuple[str, np.ndarray, np.ndarray]:
    """``(kind, eigenvalues, u)`` of the (near-)singular gimbal set ``delta`` ``(4,)``.

    u is the left singular vector of the smallest singular value of A; N ``(4, 2)`` spans the
    null space of the rank-2 part of A (the two smallest right singular vectors) and
    Q = Nᵀ diag(u·hᵢ) N. Moving along a null vector n changes the momentum by
    −½ h₀ Σ (u·hᵢ) nᵢ² along u to second order, so Q definite (``"elliptic"``) means no null
    motion keeps h fixed and the state cannot be left without a torque error, while Q
    indefinite (``"hyperbolic"``) allows null motion through it (Bedrossian, Paradiso,
    Bergmann & Rowell, "Steering law design for redundant single-gimbal control moment gyroscopes",
    J. Guidance, Control, and Dynamics 13(6), 1990). ``"degenerate"`` if an eigenvalue is
    below 1e-6 × the larger one in magnitude.
    """
    if not isinstance(cluster, SgcmgPyramid):
        raise TypeError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
    d = as_array(delta, "delta", (4,))
    if d.shape != (4,):
        raise ValueError(f"delta: expected shape (4,), got {d.shape}")
    U, _, Vt = np.linalg.svd(cluster.jacobian(d) / cluster.h0)
    u = U[:, -1]
    P = np.diag(u @ cluster.unit_momenta(d))
    N = Vt[2:].T
    ev = np.linalg.eigvalsh(N.T @ P @ N)
    if abs(ev[0]) < 1e-6 * abs(ev[1]) or abs(ev[1]) < 1e-6 * abs(ev[0]):
        kind = "degenerate"
    else:
        kind = "elliptic" if ev[0] * ev[1] > 0 else "hyperbolic"
    return kind, ev, u


@dataclass(frozen=True)
class TransitPath:
    """A prescribed momentum path: ḣ_cmd = ``rate`` · d̂ for ``duration`` seconds from
    ``delta0_deg`` (a zero-momentum gimbal set).

    Attributes:
        name: label.
        delta0_deg: initial gimbal angles [deg].
        direction: d̂ (normalised on construction).
        rate: r > 0, |ḣ_cmd| in units of h₀ per second.
        duration: T > 0 [s].
        description: what the pseudo-inverse meets on this path.
    """

    name: str
    delta0_deg: tuple[float, float, float, float]
    direction: tuple[float, float, float]
    rate: float = 0.2
    duration: float = 8.0
    description: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise TypeError(f"name: expected a non-empty string, got {self.name!r}")
        if not isinstance(self.description, str):
            raise TypeError(f"description: expected a string, got {self.description!r}")
        d0 = as_array(self.delta0_deg, "delta0_deg")
        if d0.shape != (4,):
            raise ValueError(f"delta0_deg: expected 4 angles, got {self.delta0_deg!r}")
        v = as_array(self.direction, "direction")
        if v.shape != (3,) or not np.linalg.norm(v) > 0.0:
            raise ValueError(f"direction: expected a non-zero 3-vector, got {self.direction!r}")
        for name in ("rate", "duration"):
            x = as_scalar(getattr(self, name), name)
            if not x > 0.0:
                raise ValueError(f"{name}: must be > 0, got {x}")
            object.__setattr__(self, name, x)
        object.__setattr__(self, "delta0_deg", tuple(d0.tolist()))
        object.__setattr__(self, "direction", tuple((v / np.linalg.norm(v)).tolist()))


#: The comparison's paths. The directions were found by following the plain pseudo-inverse from
#: the start along 600 directions (Fibonacci sphere) and keeping those whose closest approach
#: to a singularity is tightest; the type is recomputed by :func:`run_comparison`.
PATHS: tuple[TransitPath, ...] = (
    TransitPath(
        "elliptic-x",
        (0.0, 0.0, 0.0, 0.0),
        (1.0, 0.0, 0.0),
        duration=8.0,
        description="ḣ along +x from δ = 0: the pseudo-inverse runs exactly into the internal "
        "elliptic singular set δ = (−90°, 0, 90°, 0), |h| = 2 cos β h₀ ≈ 1.15 h₀, with ḣ along "
        "its singular direction",
    ),
    TransitPath(
        "elliptic-oblique",
        (60.0, -60.0, 60.0, -60.0),
        (0.4666, -0.3808, 0.7983),
        duration=8.0,
        description="from the catalogue's start (60°, −60°, 60°, −60°): the pseudo-inverse "
        "meets an internal elliptic singularity at |h| ≈ 1.17 h₀",
    ),
    TransitPath(
        "hyperbolic",
        (60.0, -60.0, 60.0, -60.0),
        (0.0439, 0.2823, 0.9583),
        # ends before the pseudo-inverse meets a second (elliptic) singular set at ≈ 1.64 h₀
        duration=8.0,
        description="from the catalogue's start: the pseudo-inverse passes within m ≈ 0.01 of "
        "an internal hyperbolic singularity at |h| ≈ 1.49 h₀",
    ),
)


@dataclass(frozen=True)
class TransitResult:
    """One law on one path: time series ``(K,)`` (``t`` [s], ``m``, ``torque_error``
    (relative), ``peak_rate`` [rad/s]: max |δ̇ᵢ| per step) and the summary numbers."""

    law: str
    path: str
    t: np.ndarray
    m: np.ndarray
    torque_error: np.ndarray
    peak_rate: np.ndarray
    final_momentum_error: float
    dt: float

    @property
    def max_torque_error(self) -> float:
        """max_t |A δ̇ − ḣ_cmd| / |ḣ_cmd|."""
        return float(self.torque_error.max())

    @property
    def rms_torque_error(self) -> float:
        """RMS over the path of the relative torque error."""
        return float(np.sqrt(np.mean(self.torque_error**2)))

    @property
    def time_near_singularity(self) -> float:
        """Seconds with m < :data:`NEAR_SINGULAR_M`."""
        return float(np.count_nonzero(self.m < NEAR_SINGULAR_M) * self.dt)

    @property
    def min_m(self) -> float:
        return float(self.m.min())

    @property
    def max_gimbal_rate(self) -> float:
        return float(self.peak_rate.max())


def track_path(
    law: SteeringLaw, cluster: SgcmgPyramid, path: TransitPath, dt: float = 0.01, name: str = ""
) -> TransitResult:
    """Step the gimbals along ``path`` with ``law`` (classical RK4, step ``dt`` [s]; the law
    and the cluster's rate limit act at every stage). Torque error, m and rates are sampled at
    the start of each step from the rates the law delivers there."""
    if not isinstance(law, SteeringLaw):
        raise TypeError(f"law: expected a SteeringLaw, got {type(law).__name__}")
    if not isinstance(cluster, SgcmgPyramid):
        raise TypeError(f"cluster: expected an SgcmgPyramid, got {type(cluster).__name__}")
    if not isinstance(path, TransitPath):
        raise TypeError(f"path: expected a TransitPath, got {type(path).__name__}")
    if not isinstance(name, str):
        raise TypeError(f"name: expected a string, got {name!r}")
    h = as_scalar(dt, "dt")
    if not 0.0 < h <= path.duration:
        raise ValueError(f"dt: must lie in (0, duration = {path.duration}], got {dt}")
    hdot = path.rate * cluster.h0 * np.array(path.direction)
    delta = np.deg2rad(np.array(path.delta0_deg))
    h_start = cluster.momentum(delta)
    limit = cluster.gimbal_rate_limit

    def rates(d: np.ndarray, t: float) -> np.ndarray:
        A = cluster.jacobian(d)
        return saturate_gimbal_rates(law(A, hdot, d, t, cluster), limit)[0]

    K = int(round(path.duration / h))
    ts, ms, errs, peaks = (np.empty(K) for _ in range(4))
    for k in range(K):
        t = k * h
        k1 = rates(delta, t)
        A = cluster.jacobian(delta)
        ts[k] = t
        ms[k] = float(cluster.singularity_measure(delta))
        errs[k] = float(np.linalg.norm(A @ k1 - hdot) / np.linalg.norm(hdot))
        peaks[k] = float(np.abs(k1).max())
        k2 = rates(delta + 0.5 * h * k1, t + 0.5 * h)
        k3 = rates(delta + 0.5 * h * k2, t + 0.5 * h)
        k4 = rates(delta + h * k3, t + h)
        delta = delta + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    h_cmd_end = h_start + hdot * (K * h)
    final = float(np.linalg.norm(cluster.momentum(delta) - h_cmd_end) / cluster.h0)
    return TransitResult(name or type(law).__name__, path.name, ts, ms, errs, peaks, final, h)


def run_comparison(
    dt: float = 0.01,
    laws: tuple[str, ...] | None = None,
    paths: tuple[TransitPath, ...] = PATHS,
) -> tuple[list[TransitResult], dict[str, str]]:
    """Every law of ``laws`` (default all of :data:`TRANSIT_LAWS`) on every path; returns the
    results and, per path, the type of the singularity the pseudo-inverse gets closest to."""
    names = tuple(TRANSIT_LAWS) if laws is None else tuple(laws)
    for n in names:
        if n not in TRANSIT_LAWS:
            raise ValueError(f"laws: unknown law {n!r}; valid: {', '.join(TRANSIT_LAWS)}")
    cluster = SgcmgPyramid(h0=1.0, gimbal_rate_limit=1.0)
    results: list[TransitResult] = []
    kinds: dict[str, str] = {}
    for path in paths:
        ref = _closest_pinv_approach(cluster, path, dt)
        kinds[path.name] = classify_singularity(cluster, ref)[0]
        for n in names:
            results.append(track_path(TRANSIT_LAWS[n](cluster), cluster, path, dt, n))
    return results, kinds


def _closest_pinv_approach(cluster: SgcmgPyramid, path: TransitPath, dt: float) -> np.ndarray:
    """The gimbal set of least m on the pseudo-inverse's (unsaturated Euler) path."""
    law = PseudoInverse()
    hdot = path.rate * cluster.h0 * np.array(path.direction)
    d = np.deg2rad(np.array(path.delta0_deg))
    best, best_m = d, np.inf
    for _ in range(int(round(path.duration / dt))):
        dd = law(cluster.jacobian(d), hdot)
        d = d + dt * saturate_gimbal_rates(dd, 10.0 * cluster.gimbal_rate_limit)[0]
        m = float(cluster.singularity_measure(d))
        if m < best_m:
            best, best_m = d, m
    return best


def transit_table(results: list[TransitResult], kinds: dict[str, str] | None = None) -> str:
    """Markdown table: one row per (path, law); ``kinds`` (path → singularity type) labels the
    paths."""
    if not isinstance(results, list | tuple) or not all(
        isinstance(r, TransitResult) for r in results
    ):
        raise TypeError(f"results: expected a list of TransitResult, got {results!r:.80}")
    if kinds is None:
        kinds = {}
    if not isinstance(kinds, dict) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in kinds.items()
    ):
        raise TypeError(f"kinds: expected a dict of path name -> type, got {kinds!r:.80}")
    lines = [
        f"| path | law | max torque error | RMS torque error | final \\|Δh\\|/h₀ | "
        f"time m < {NEAR_SINGULAR_M} [s] | min m | peak \\|δ̇\\| [rad/s] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        label = f"{r.path} ({kinds[r.path]})" if r.path in kinds else r.path
        lines.append(
            f"| {label} | {r.law} | {r.max_torque_error:.3g} | {r.rms_torque_error:.3g} | "
            f"{r.final_momentum_error:.3g} | {r.time_near_singularity:.2f} | {r.min_m:.3g} | "
            f"{r.max_gimbal_rate:.3g} |"
        )
    return "\n".join(lines) + "\n"


def plot_comparison(
    results: list[TransitResult], out: pathlib.Path, name: str = "singular_transit.png"
) -> pathlib.Path:
    """PNG ``out/name``: m (top) and torque error (bottom) along each path, one line per law."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = list(dict.fromkeys(r.path for r in results))
    fig, axes = plt.subplots(2, len(paths), figsize=(4.2 * len(paths), 5.6), squeeze=False)
    for j, p in enumerate(paths):
        for r in (r for r in results if r.path == p):
            axes[0, j].plot(r.t, r.m, label=r.law, lw=1.2)
            axes[1, j].semilogy(r.t, np.maximum(r.torque_error, 1e-14), label=r.law, lw=1.2)
        axes[0, j].axhline(NEAR_SINGULAR_M, color="k", lw=0.6, ls=":")
        axes[0, j].set_title(p)
        axes[0, j].set_ylabel("singularity measure m")
        axes[1, j].set_ylabel("|A δ̇ − ḣ_cmd| / |ḣ_cmd|")
        axes[1, j].set_xlabel("t [s]")
        axes[1, j].set_ylim(1e-14, 2.0)
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    path = pathlib.Path(out) / name
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=pathlib.Path, required=True, help="output directory")
    ap.add_argument("--dt", type=float, default=0.01, help="RK4 step [s] (default 0.01)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    results, kinds = run_comparison(args.dt)
    table = transit_table(results, kinds)
    (args.out / "table.md").write_text(table, encoding="utf-8")
    png = plot_comparison(results, args.out)
    print(table)
    print(f"wrote {args.out / 'table.md'} and {png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
