"""Speed of the batched SO(3) exp/log against scipy's Rotation (``python -m benchmarks.perf_lie``).

Measures nanoseconds per element (best of several ``timeit`` repeats) of

- ``so3.exp(w)`` vs ``Rotation.from_rotvec(w).as_matrix()`` on N Gaussian rotation vectors
  (angles spread over [0, ~3π], so every branch is hit);
- ``so3.log(R)`` vs ``Rotation.from_matrix(R).as_rotvec()`` on N Haar-random rotations,

and prints a table with the ratio (ours / scipy) and the targets of the Foundation issue:
exp no slower than scipy (ratio ≤ 1), log at most half of scipy's time (ratio ≤ 0.5). It also
reports the largest difference to scipy's result, so a fast but wrong kernel cannot pass.
"""

from __future__ import annotations

import argparse
import timeit
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol.lie import so3

__all__ = ["PerfRow", "run", "main"]


@dataclass(frozen=True)
class PerfRow:
    name: str
    ours_ns: float  # ns per element
    scipy_ns: float
    target_ratio: float
    max_abs_diff: float

    @property
    def ratio(self) -> float:
        return self.ours_ns / self.scipy_ns

    @property
    def ok(self) -> bool:
        return self.ratio <= self.target_ratio


def _best_ns(f: Callable[[], object], n: int, repeat: int, number: int) -> float:
    f()  # warm up (page faults on first allocation, lazy imports)
    return min(timeit.repeat(f, number=number, repeat=repeat)) / number / n * 1e9


def run(n: int = 100_000, repeat: int = 7, number: int = 5, seed: int = 0) -> list[PerfRow]:
    """Time exp and log on ``n`` elements; returns one :class:`PerfRow` each."""
    rng = np.random.default_rng(seed)
    w = rng.standard_normal((n, 3)) * 2.0
    R = so3.random(rng, n)
    exp_diff = float(np.abs(so3.exp(w) - Rotation.from_rotvec(w).as_matrix()).max())
    log_diff = float(np.abs(so3.log(R) - Rotation.from_matrix(R).as_rotvec()).max())
    return [
        PerfRow(
            "so3.exp",
            _best_ns(lambda: so3.exp(w), n, repeat, number),
            _best_ns(lambda: Rotation.from_rotvec(w).as_matrix(), n, repeat, number),
            1.0,
            exp_diff,
        ),
        PerfRow(
            "so3.log",
            _best_ns(lambda: so3.log(R), n, repeat, number),
            _best_ns(lambda: Rotation.from_matrix(R).as_rotvec(), n, repeat, number),
            0.5,
            log_diff,
        ),
    ]


def format_table(rows: list[PerfRow], n: int) -> str:
    head = (
        f"N = {n}: ns per element, best of repeats\n"
        f"{'function':<10} {'liecontrol':>11} {'scipy':>9} {'ratio':>7} {'target':>7} "
        f"{'ok':>4} {'max|Δ| vs scipy':>16}"
    )
    lines = [head, "-" * len(head.splitlines()[-1])]
    for r in rows:
        lines.append(
            f"{r.name:<10} {r.ours_ns:>11.1f} {r.scipy_ns:>9.1f} {r.ratio:>7.3f} "
            f"{'≤' + format(r.target_ratio, 'g'):>7} {'yes' if r.ok else 'NO':>4} "
            f"{r.max_abs_diff:>16.1e}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100_000, help="batch size (default 100000)")
    parser.add_argument("--repeat", type=int, default=7, help="timeit repeats (best is kept)")
    parser.add_argument("--number", type=int, default=5, help="calls per repeat")
    args = parser.parse_args(argv)
    if args.n <= 0 or args.repeat <= 0 or args.number <= 0:
        parser.error("--n, --repeat and --number must be positive")
    rows = run(args.n, args.repeat, args.number)
    print(format_table(rows, args.n))
    return 0 if all(r.ok for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
