"""Worked example: learn a linear residual policy with the cross-entropy method (numpy only).

Policy: ``a = tanh(W o)`` with ``W ∈ ℝ^{3×n_obs}`` on the residual action mode, so ``W = 0`` is
the untuned baseline geometric PD and the search only has to find a correction. The
cross-entropy method (Rubinstein 1999; de Boer, Kroese, Mannor & Rubinstein, "A tutorial on the
cross-entropy method", Annals of Operations Research 134, 2005) keeps a diagonal Gaussian over
``W``; each iteration draws ``population`` candidates, scores every candidate on the same
``episodes`` start conditions (common random numbers: one vector environment of
``population × episodes`` spacecraft stepped as one batch), and refits the Gaussian to the
``elite`` best (the current mean is one of the candidates).

Score: the undiscounted episode return of the environment (its reward is documented in
:mod:`spacecraft.envs.attitude`); an episode ends at its first termination or truncation.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from liecontrol._validation import as_array, as_int, check_positive_scalar

__all__ = ["LinearPolicy", "CemResult", "episode_returns", "train_cem"]


@dataclass(frozen=True)
class LinearPolicy:
    """``a = tanh(obs @ Wᵀ)`` for ``obs`` ``(B, n_obs)``; ``W`` ``(3, n_obs)`` (copied)."""

    W: np.ndarray

    def __post_init__(self) -> None:
        W = as_array(self.W, "W")
        if W.ndim != 2 or W.shape[0] != 3:
            raise ValueError(f"W: expected shape (3, n_obs), got {W.shape}")
        W = W.copy()
        W.setflags(write=False)
        object.__setattr__(self, "W", W)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return np.tanh(np.asarray(obs) @ self.W.T)


@dataclass
class CemResult:
    """``policy`` (the final mean), per-iteration ``mean_return`` of the mean policy and
    ``elite_return`` (mean of the elite), and the ``baseline_return`` (``W = 0``) on the same
    evaluation episodes."""

    policy: LinearPolicy
    baseline_return: float
    mean_return: list[float] = field(default_factory=list)
    elite_return: list[float] = field(default_factory=list)


def episode_returns(
    env_id: str, weights: np.ndarray, episodes: int, seed: int, **options: Any
) -> np.ndarray:
    """Returns ``(K, episodes)`` of the ``K`` linear policies ``weights`` ``(K, 3, n_obs)``, all
    run in one vector environment of ``K × episodes`` rows (row ``k·episodes + e`` runs policy
    ``k`` on episode seed ``seed + e``)."""
    import gymnasium as gym

    weights = as_array(weights, "weights")
    if weights.ndim != 3 or weights.shape[1] != 3:
        raise ValueError(f"weights: expected shape (K, 3, n_obs), got {weights.shape}")
    episodes = as_int(episodes, "episodes", 1)
    seed = as_int(seed, "seed", 0)
    K = weights.shape[0]
    N = K * episodes
    env = gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point",
                       action="residual", **options)  # fmt: skip
    seeds = [seed + e for _ in range(K) for e in range(episodes)]
    obs, _ = env.reset(seed=seeds)
    Wrow = np.repeat(weights, episodes, axis=0)  # (N, 3, n_obs)
    total = np.zeros(N)
    alive = np.ones(N, dtype=bool)
    while alive.any():
        act = np.tanh(np.einsum("nij,nj->ni", Wrow, obs))
        obs, r, term, trunc, _ = env.step(act)
        total += np.where(alive, r, 0.0)
        alive &= ~(term | trunc)
    env.close()
    return total.reshape(K, episodes)


def train_cem(
    env_id: str = "liecontrol/AttitudeSlew-v0",
    iterations: int = 10,
    population: int = 16,
    elite: int = 4,
    episodes: int = 4,
    sigma0: float = 0.5,
    seed: int = 0,
    **options: Any,
) -> CemResult:
    """Cross-entropy search over ``W`` (module docstring); ``options`` go to the environment
    (e.g. ``max_episode_steps``, ``angle_range_deg``). Training episodes use seeds
    ``seed + 1000·(i+1) + e`` at iteration ``i``; the reported curves evaluate the mean policy
    on the fixed episodes ``seed + e``."""
    import gymnasium as gym

    iterations = as_int(iterations, "iterations", 1)
    population = as_int(population, "population", 1)
    elite = as_int(elite, "elite", 1)
    episodes = as_int(episodes, "episodes", 1)
    sigma0 = check_positive_scalar(sigma0, "sigma0")
    seed = as_int(seed, "seed", 0)
    if not 1 <= elite <= population:
        raise ValueError(f"elite: expected 1 <= elite <= population = {population}, got {elite}")
    rng = np.random.default_rng(seed)
    probe = gym.make(env_id, action="residual", **options)
    n_obs = probe.observation_space.shape[0]
    probe.close()
    mu = np.zeros((3, n_obs))
    sd = np.full((3, n_obs), float(sigma0))
    base = float(episode_returns(env_id, mu[None], episodes, seed, **options).mean())
    result = CemResult(policy=LinearPolicy(mu.copy()), baseline_return=base)
    for i in range(iterations):
        cand = mu + sd * rng.standard_normal((population, 3, n_obs))
        cand[0] = mu  # the current mean competes too: the elite never gets worse in-sample
        score = episode_returns(env_id, cand, episodes, seed + 1000 * (i + 1), **options)
        best = np.argsort(score.mean(axis=1))[::-1][:elite]
        mu = cand[best].mean(axis=0)
        sd = cand[best].std(axis=0) + 0.02 * sigma0  # a floor keeps the search alive
        result.elite_return.append(float(score[best].mean()))
        result.mean_return.append(
            float(episode_returns(env_id, mu[None], episodes, seed, **options).mean())
        )
    result.policy = LinearPolicy(mu)
    return result
