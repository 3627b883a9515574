"""Micro-benchmark of the integrators: ``python -m benchmarks.perf_integrators``.

Prints µs per RKMK4 step (unchecked hot step and validated public step) for B = 1 and
B = 1000 spacecraft with a rigid-body vector field, µs per RK4 step on the same system, and
µs per LGVI step (public validated step and the amortised step inside
``RigidBodyLGVI.integrate``). Timings are best-of-``repeat`` wall-clock means; they depend on
the machine and its load.
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np

from liecontrol.integrators import (
    RigidBodyLGVI,
    lgvi_step,
    rk4_step_unchecked,
    rkmk4_step,
    rkmk4_step_unchecked,
)
from liecontrol.lie import so3

J = np.diag([1.2, 1.7, 2.3])
JINV = np.linalg.inv(J)


def rigid_body(t: float, R: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Torque-free rigid body with ω as the Euclidean state (Euler's equations)."""
    w = x
    Jw = w @ J  # J diagonal/symmetric: (J w)ᵀ = wᵀ J
    c = w[..., [1, 2, 0]] * Jw[..., [2, 0, 1]] - w[..., [2, 0, 1]] * Jw[..., [1, 2, 0]]
    return w, -c @ JINV


def _us(stmt, number: int, repeat: int) -> float:
    return min(timeit.repeat(stmt, number=number, repeat=repeat)) / number * 1e6


def main(argv: list[str] | None = None) -> dict[str, float]:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--scale", type=float, default=1.0, help="multiply the iteration counts")
    args = p.parse_args(argv)
    rng = np.random.default_rng(0)
    out: dict[str, float] = {}
    h = 0.01
    for B, number in ((1, 2000), (1000, 100)):
        number = max(1, int(number * args.scale))
        R = so3.random(rng, B)
        x = rng.normal(size=(B, 3))
        out[f"rkmk4_step_unchecked B={B}"] = _us(
            lambda R=R, x=x: rkmk4_step_unchecked(rigid_body, 0.0, R, x, h), number, args.repeat
        )
        out[f"rkmk4_step (validated) B={B}"] = _us(
            lambda R=R, x=x: rkmk4_step(rigid_body, 0.0, R, x, h), number, args.repeat
        )
        y = np.concatenate((R.reshape(B, 9), x), axis=-1)

        def f_emb(t, y, B=B):
            Rm = y[:, :9].reshape(B, 3, 3)
            w, wd = rigid_body(t, Rm, y[:, 9:])
            return np.concatenate(((Rm @ so3.hat(w)).reshape(B, 9), wd), axis=-1)

        out[f"rk4_step_unchecked (R entries + ω) B={B}"] = _us(
            lambda y=y, f=f_emb: rk4_step_unchecked(f, 0.0, y, h), number, args.repeat
        )
        Pi = x @ J
        zero = np.zeros((B, 3))
        out[f"lgvi_step (validated) B={B}"] = _us(
            lambda R=R, Pi=Pi, z=zero: lgvi_step(R, Pi, z, z, h, J), number, args.repeat
        )
        lg = RigidBodyLGVI(J)
        n_steps = 200 if B == 1 else 20
        run = lambda R=R, x=x, n=n_steps, lg=lg: lg.integrate(R, x, h, n)  # noqa: E731
        out[f"RigidBodyLGVI.integrate per step B={B}"] = _us(run, 1, args.repeat) / n_steps
    width = max(len(k) for k in out)
    for k, v in out.items():
        print(f"{k:<{width}}  {v:10.1f} µs")
    return out


if __name__ == "__main__":
    main()
