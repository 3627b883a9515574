"""Environment throughput: ``python -m benchmarks.perf_envs [ID ...]``.

Env steps per second of each Gymnasium environment (``spacecraft.envs``; extra ``[rl]``),
single (``gymnasium.make``) and as the native vector environment
(``gymnasium.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")``) at
N = 64, 256, 1024, stepping zero torque actions (a single environment resets on termination).
Each figure is the best of three runs; the ratio to the single environment is in parentheses.
BLAS/OpenMP threads are pinned to 1 before numpy is imported.
"""

from __future__ import annotations

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

IDS = (
    "liecontrol/AttitudeSlew-v0",
    "liecontrol/AttitudeSlewWheels-v0",
    "liecontrol/AttitudeTracking-v0",
)


def env_steps_per_second(env_id: str, num_envs: int, steps: int) -> float:
    """Env steps per second of one run (``num_envs = 1``: the single environment)."""
    import gymnasium as gym

    import spacecraft.envs  # noqa: F401 - registers the ids

    if num_envs == 1:
        env = gym.make(env_id)
        env.reset(seed=0)
        a = np.zeros(env.action_space.shape)
        for _ in range(5):
            env.step(a)
        t = time.perf_counter()
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()
        return steps / (time.perf_counter() - t)
    env = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    a = np.zeros(env.action_space.shape)
    for _ in range(3):
        env.step(a)
    t = time.perf_counter()
    for _ in range(steps):
        env.step(a)
    return num_envs * steps / (time.perf_counter() - t)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("ids", nargs="*", default=list(IDS))
    args = ap.parse_args(argv)
    print("| environment | single | N = 64 | N = 256 | N = 1024 |\n|---|---|---|---|---|")
    for env_id in args.ids:
        single = max(env_steps_per_second(env_id, 1, 1000) for _ in range(3))
        row = [f"{single / 1e3:.2f} k"]
        for n in (64, 256, 1024):
            v = max(env_steps_per_second(env_id, n, max(20, 20000 // n)) for _ in range(3))
            row.append(f"{v / 1e3:.1f} k ({v / single:.0f}×)")
        print(f"| {env_id.split('/')[1]} | " + " | ".join(row) + " |", flush=True)


if __name__ == "__main__":
    main()
