"""Wall time per predict+update of the estimation filters vs filterpy's UnscentedKalmanFilter.

Run::

    python -m benchmarks.perf_estimation [--steps 300] [--repeats 5]

Same model for everybody: the gyroless 7-state (q, ω) model of Wang, Li, Zhang, Zhu & Li (2015)
with RK4 at T_s = 1 s and the
3 Euler-angle measurements, same scaled-UT parameters (α = 1, β = 2, κ = 3 − n), same
measurement sequence. filterpy propagates its 2n+1 sigma points one by one through ``fx``
(a Python loop) — ``fx``/``hx`` call the same model functions, so filterpy also gets the
compiled RK4 of the model for each point; ``liecontrol.estimation``'s UKF on this model runs
the whole sigma-point pass (sigma points, RK4, weighted statistics, gain, correction) in a few
compiled calls. The printed ratio is (our UKF time) / (filterpy time) measured in the same
run, best of ``repeats`` interleaved repetitions (the machine is shared, so minima are the
stable statistic); the target is ≤ 0.05.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from liecontrol.charts import quaternion as quat
from liecontrol.estimation import (
    ISTSRUKF,
    MEKF,
    SRUKF,
    STUKF,
    UKF,
    GyrolessAttitudeModel,
    ManifoldUKF,
    wrap_angle,
)

__all__ = ["make_problem", "time_filters", "main"]


def make_problem(steps: int, seed: int = 0) -> dict:
    """Truth, torques and measurements of a gyroless run (``steps`` samples at T_s = 1 s)."""
    m = GyrolessAttitudeModel(np.diag([10.0, 12.0, 15.0]))
    rng = np.random.default_rng(seed)
    x = np.r_[quat.from_rotvec(np.array([0.05, -0.03, 0.1])), 0.001, -0.002, 0.05]
    zs, us = [], []
    for k in range(steps):
        u = 2e-4 * np.array([np.sin(0.01 * k), np.cos(0.013 * k), 0.0])
        x = m.f(x[None], u, 1.0)[0]
        us.append(u)
        zs.append(m.h(x[None])[0] + rng.normal(0.0, 2e-3, 3))
    x0 = np.r_[quat.from_rotvec(np.array([0.05, -0.03, 0.1])), 0.001, -0.002, 0.05]
    return {"model": m, "x0": x0, "u": np.array(us), "z": np.array(zs)}


def _filterpy_ukf(prob: dict, P0: np.ndarray):
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    m = prob["model"]
    n = 7

    def fx(x, dt, u):
        return m.f(x[None], u, dt)[0]

    def hx(x):
        return m.h(x[None])[0]

    def x_mean(sigmas, Wm):
        xm = Wm @ sigmas
        xm[:4] /= np.linalg.norm(xm[:4])
        return xm

    def z_mean(sigmas, Wm):
        return m.z_mean(sigmas, Wm)

    points = MerweScaledSigmaPoints(n, alpha=1.0, beta=2.0, kappa=3.0 - n)
    f = UnscentedKalmanFilter(dim_x=n, dim_z=3, dt=1.0, hx=hx, fx=fx, points=points,
                              x_mean_fn=x_mean, z_mean_fn=z_mean, residual_z=lambda a, b:
                              wrap_angle(a - b))
    f.x = prob["x0"].copy()
    f.P = P0.copy()
    f.Q = m.Q(1.0)
    f.R = m.R
    return f


def _run_ours(cls, prob: dict, P0: np.ndarray) -> tuple[float, np.ndarray]:
    f = cls(prob["model"], prob["x0"], P0)
    t0 = time.perf_counter()
    for u, z in zip(prob["u"], prob["z"], strict=True):
        f.predict(u, 1.0)
        f.update(z)
    return time.perf_counter() - t0, f.x


def _run_filterpy(prob: dict, P0: np.ndarray) -> tuple[float, np.ndarray]:
    f = _filterpy_ukf(prob, P0)
    t0 = time.perf_counter()
    for u, z in zip(prob["u"], prob["z"], strict=True):
        f.predict(u=u)
        f.update(z)
    return time.perf_counter() - t0, f.x.copy()


def time_filters(steps: int = 300, repeats: int = 5) -> dict[str, float]:
    """Best-of-``repeats`` wall time per predict+update [s] for each filter and filterpy."""
    prob = make_problem(steps)
    P_add = np.diag([2.5e-5] * 4 + [4e-6] * 3)
    P_err = np.diag([1e-4] * 3 + [4e-6] * 3)
    ours = {"UKF": (UKF, P_add), "SRUKF": (SRUKF, P_add), "STF": (STUKF, P_add),
            "ISTSRUKF": (ISTSRUKF, P_add), "ManifoldUKF": (ManifoldUKF, P_err),
            "MEKF": (MEKF, P_err)}
    best = {k: np.inf for k in (*ours, "filterpy UKF")}
    final = {}
    for _ in range(repeats):
        for name, (cls, P0) in ours.items():
            t, x = _run_ours(cls, prob, P0)
            best[name] = min(best[name], t / steps)
            final[name] = x
        t, x = _run_filterpy(prob, P_add)
        best["filterpy UKF"] = min(best["filterpy UKF"], t / steps)
        final["filterpy UKF"] = x
    # same filter, same answer: the UKF and filterpy estimates must agree
    best["ukf_vs_filterpy_state_diff"] = float(np.max(np.abs(final["UKF"] - final["filterpy UKF"])))
    return best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="estimation filter timing vs filterpy")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args(argv)
    res = time_filters(a.steps, a.repeats)
    ref = res["filterpy UKF"]
    print(f"wall time per predict+update (7 states, 3 measurements, best of {a.repeats}):")
    for k, v in res.items():
        if k.endswith("_diff"):
            continue
        print(f"  {k:14s} {v * 1e6:9.1f} µs   ({v / ref:5.2f} × filterpy)")
    print(f"ratio our UKF / filterpy UKF = {res['UKF'] / ref:.3f} (target ≤ 0.05)")
    print(f"max |x_UKF − x_filterpy| after the run = {res['ukf_vs_filterpy_state_diff']:.2e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
