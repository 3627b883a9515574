"""Speed of the batched SO(3) exp/log against scipy's Rotation (``python -m benchmarks.perf_lie``).

Measures nanoseconds per element (best of several ``timeit`` repeats) of

- ``so3.exp(w)`` vs ``Rotation.from_rotvec(w).as_matrix()`` on N Gaussian rotation vectors
  (angles spread over [0, ~3π], so every branch is hit);
- ``so3.log(R)`` vs ``Rotation.from_matrix(R).as_rotvec()`` on N Haar-random rotations,

and prints a table with the ratio (ours / scipy) and the targets of the Foundation issue:
exp no slower than scipy (ratio ≤ 1), log at most half of scipy's time (ratio ≤ 0.5). It also
reports the largest difference to scipy's result, so a fast but wrong kernel cannot pass.

Then the small-call latency (ns per call on one element, best of interleaved repeats):

- ``so3.exp(w)`` on one vector vs a five-line numpy Rodrigues (``_rodrigues_numpy``), and
  ``so3.log(R)`` on one matrix vs a five-line numpy logarithm (``_log_numpy``): target ≤ 1;
- ``se3.exp`` / ``se3.log`` on one element, against the same numpy lines for the rotation
  part alone (for scale only, no target);

and the batched closed-form SE(3) Jacobian: ``se3.right_jacobian_inv`` against ``se3.exp`` on
the same N twists, ns per element, target ≤ 2.
"""

from __future__ import annotations

import argparse
import timeit
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol.lie import se3, so3

__all__ = ["PerfRow", "run", "run_small", "main"]


@dataclass(frozen=True)
class PerfRow:
    name: str
    ours_ns: float  # ns per element (per call for the single-element rows)
    scipy_ns: float  # the reference's time (named by ``reference``)
    target_ratio: float  # inf: no target (printed for scale)
    max_abs_diff: float  # vs the reference's result (nan where they compute different things)
    reference: str = "scipy"

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


def _rodrigues_numpy(w: np.ndarray) -> np.ndarray:
    """The five-line numpy Rodrigues of the latency comparison (no validation, θ > 0 only)."""
    th = np.linalg.norm(w)
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]) / th
    return np.eye(3) + np.sin(th) * K + (1.0 - np.cos(th)) * (K @ K)


def _log_numpy(R: np.ndarray) -> np.ndarray:
    """The five-line numpy logarithm of the latency comparison (0 < θ < π only)."""
    th = np.arccos(np.clip(0.5 * (np.trace(R) - 1.0), -1.0, 1.0))
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return th / (2.0 * np.sin(th)) * v


def _interleaved_ns(
    fa: Callable[[], object], fb: Callable[[], object], repeat: int, number: int, n: int = 1
) -> tuple[float, float]:
    """Best-of-``repeat`` ns per element of two callables, timed alternately (A, B, A, B, …) so
    that a load change on the shared machine hits both."""
    fa()
    fb()
    ta = tb = float("inf")
    for _ in range(repeat):
        ta = min(ta, timeit.timeit(fa, number=number))
        tb = min(tb, timeit.timeit(fb, number=number))
    return ta / number / n * 1e9, tb / number / n * 1e9


def run_small(repeat: int = 7, number: int = 2000, n_batch: int = 20_000,
              seed: int = 0) -> list[PerfRow]:
    """Single-element latency of so3/se3 exp and log against five-line numpy versions, and
    the batched ``se3.right_jacobian_inv`` against ``se3.exp`` (ns per element)."""
    rng = np.random.default_rng(seed)
    w = np.array([0.3, -0.2, 0.5])
    R = so3.exp(w)
    xi = np.r_[w, 1.0, 2.0, 3.0]
    g = se3.exp(xi)
    rows = []
    a, b = _interleaved_ns(lambda: so3.exp(w), lambda: _rodrigues_numpy(w), repeat, number)
    rows.append(PerfRow("so3.exp one", a, b, 1.0,
                        float(np.abs(so3.exp(w) - _rodrigues_numpy(w)).max()), "numpy 5-line"))
    a, b = _interleaved_ns(lambda: so3.log(R), lambda: _log_numpy(R), repeat, number)
    rows.append(PerfRow("so3.log one", a, b, 1.0,
                        float(np.abs(so3.log(R) - _log_numpy(R)).max()), "numpy 5-line"))
    a, b = _interleaved_ns(lambda: se3.exp(xi), lambda: _rodrigues_numpy(w), repeat, number)
    rows.append(PerfRow("se3.exp one", a, b, float("inf"), float("nan"), "numpy so3 5-line"))
    a, b = _interleaved_ns(lambda: se3.log(g), lambda: _log_numpy(R), repeat, number)
    rows.append(PerfRow("se3.log one", a, b, float("inf"), float("nan"), "numpy so3 5-line"))
    X = rng.standard_normal((n_batch, 6))
    a, b = _interleaved_ns(lambda: se3.right_jacobian_inv(X), lambda: se3.exp(X), repeat,
                           max(1, number // 1000), n_batch)
    # J_r(ξ)⁻¹ J_r(ξ) = I is the correctness check of the closed form here
    err = float(np.abs(se3.right_jacobian_inv(X[:200]) @ se3.right_jacobian(X[:200])
                       - np.eye(6)).max())
    rows.append(PerfRow("se3.Jr⁻¹ batch", a, b, 2.0, err, "se3.exp batch"))
    return rows


def format_small_table(rows: list[PerfRow]) -> str:
    head = (
        f"{'call':<16} {'ours ns':>9} {'ref ns':>9} {'ratio':>7} {'target':>7} {'ok':>4}  "
        f"{'check':>9}  reference"
    )
    lines = ["small calls (one element; last row: batched, ns per element)", head,
             "-" * len(head)]
    for r in rows:
        tgt = "—" if r.target_ratio == float("inf") else "≤" + format(r.target_ratio, "g")
        ok = "—" if r.target_ratio == float("inf") else ("yes" if r.ok else "NO")
        lines.append(
            f"{r.name:<16} {r.ours_ns:>9.0f} {r.scipy_ns:>9.0f} {r.ratio:>7.3f} {tgt:>7} "
            f"{ok:>4}  {r.max_abs_diff:>9.1e}  {r.reference}"
        )
    lines.append("check: max |Δ| vs the reference's result (so3 rows) or max |J⁻¹J − I| (Jr⁻¹)")
    return "\n".join(lines)


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
    small = run_small(args.repeat)
    print()
    print(format_small_table(small))
    return 0 if all(r.ok for r in rows + small) else 1


if __name__ == "__main__":
    raise SystemExit(main())
