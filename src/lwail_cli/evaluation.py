"""Deterministic rollouts on the true reward and D4RL-style normalized scores."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .envs import make_env

# D4RL's reference returns (random, expert), from D4RL's infos.py.
D4RL_REFERENCES: dict[str, tuple[float, float]] = {
    "hopper": (-20.272305, 3234.3),
    "halfcheetah": (-280.178953, 12135.0),
    "walker2d": (1.629008, 4592.3),
    "ant": (-325.6, 3879.7),
    "maze2d-umaze": (23.85, 161.86),
    "maze2d-medium": (13.13, 277.39),
    "maze2d-large": (6.7, 273.99),
}
_D4RL_FAMILY = {
    "Hopper": "hopper",
    "HalfCheetah": "halfcheetah",
    "Walker2d": "walker2d",
    "Ant": "ant",
    "PointMaze_UMaze": "maze2d-umaze",
    "PointMaze_Medium": "maze2d-medium",
    "PointMaze_Large": "maze2d-large",
}


@dataclass(frozen=True)
class Reference:
    random_return: float
    expert_return: float
    source: str  # says which reference was used

    def normalize(self, episode_return: float) -> float:
        return 100.0 * (episode_return - self.random_return) / (self.expert_return - self.random_return)


def d4rl_reference(env_id: str) -> Reference | None:
    family = _D4RL_FAMILY.get(env_id.split("-v")[0])
    if family is None:
        return None
    low, high = D4RL_REFERENCES[family]
    return Reference(low, high, f"D4RL {family} reference returns ({low} / {high})")


def rollout_returns(
    env_id: str,
    policy: Callable[[np.ndarray], np.ndarray] | None,
    episodes: int,
    seed: int,
) -> np.ndarray:
    """Returns of ``episodes`` episodes run side by side, the policy called once per step on the batch
    of live episodes. ``policy=None`` samples uniformly random actions."""
    envs = [make_env(env_id) for _ in range(episodes)]
    try:
        observations = [env.reset(seed=seed + index)[0] for index, env in enumerate(envs)]
        for index, env in enumerate(envs):
            env.action_space.seed(seed + index)
        returns = np.zeros(episodes)
        live = list(range(episodes))
        while live:
            if policy is None:
                actions = [envs[i].action_space.sample() for i in live]
            else:
                actions = policy(np.stack([observations[i] for i in live]).astype(np.float32))
            still_live = []
            for i, action in zip(live, actions):
                observations[i], reward, terminated, truncated, _ = envs[i].step(action)
                returns[i] += reward
                if not (terminated or truncated):
                    still_live.append(i)
            live = still_live
        return returns
    finally:
        for env in envs:
            env.close()


def random_policy_return(env_id: str, episodes: int = 10, seed: int = 12345) -> float:
    return float(rollout_returns(env_id, None, episodes, seed).mean())
