"""D4RL-style normalized scores (the reference returns a score is measured against) and rank correlation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .rollout import rollout

# D4RL's reference returns (random, expert), from D4RL's infos.py (REF_MIN_SCORE / REF_MAX_SCORE; maze2d: the -v1 entries).
D4RL_REFERENCES: dict[str, tuple[float, float]] = {
    "hopper": (-20.272305, 3234.3),
    "halfcheetah": (-280.178953, 12135.0),
    "walker2d": (1.629008, 4592.3),
    "ant": (-325.6, 3879.7),
    "maze2d-umaze": (23.85, 161.86),
    "maze2d-medium": (13.13, 277.39),
    "maze2d-large": (6.7, 273.99),
    "maze2d-umaze-dense": (68.537689, 193.66285642381482),
    "maze2d-medium-dense": (44.264742, 297.4552547777125),
    "maze2d-large-dense": (30.569041, 303.4857382709002),
}
_D4RL_FAMILY = {
    "Hopper": "hopper",
    "HalfCheetah": "halfcheetah",
    "Walker2d": "walker2d",
    "Ant": "ant",
    "AntNoContactForces": "ant",
    "PointMazeUMaze": "maze2d-umaze-dense",  # lwail's maze tasks (mazes.py): dense by default, as the authors ran them
    "PointMazeMedium": "maze2d-medium-dense",
    "PointMazeLarge": "maze2d-large-dense",
    "PointMazeUMazeSparse": "maze2d-umaze",
    "PointMazeMediumSparse": "maze2d-medium",
    "PointMazeLargeSparse": "maze2d-large",
}


# The paper's results from ONE expert trajectory, 1M steps, normalized, mean and std over its seeds, by D4RL family and
# embedding kind (lwail-paper.tex, the table "Ablation of different embedding methods": rows LWAIL and No Embedding).
PAPER_ONE_TRAJECTORY: dict[str, dict[str, tuple[float, float]]] = {
    "hopper": {"icvf": (108.84, 0.79), "identity": (108.34, 3.42)},
    "halfcheetah": {"icvf": (90.40, 3.71), "identity": (85.98, 3.42)},
    "walker2d": {"icvf": (106.51, 1.14), "identity": (62.39, 20.43)},
    "ant": {"icvf": (90.53, 3.26), "identity": (40.72, 18.95)},
}


@dataclass(frozen=True)
class Reference:
    random_return: float
    expert_return: float
    source: str  # says which reference was used

    def normalize(self, episode_return: float) -> float:
        return 100.0 * (episode_return - self.random_return) / (self.expert_return - self.random_return)


def paper_score(env_id: str, embedding: str) -> tuple[float, float] | None:
    """The paper's (mean, std) for this task and embedding kind (icvf or identity), or None where it reports none."""
    return PAPER_ONE_TRAJECTORY.get(_d4rl_family(env_id), {}).get(embedding)


def _d4rl_family(env_id: str) -> str | None:
    return _D4RL_FAMILY.get(env_id.split("-v")[0])


def d4rl_reference(env_id: str) -> Reference | None:
    family = _d4rl_family(env_id)
    if family is None:
        return None
    low, high = D4RL_REFERENCES[family]
    return Reference(low, high, f"D4RL {family} reference returns ({low} / {high})")


RANDOM_REFERENCE_EPISODES = 10
RANDOM_REFERENCE_SEED = 12345  # fixed, so a task's measured random-policy reference never changes


def random_policy_return(env_id: str) -> float:
    """The mean return of a uniformly random policy: the 0 of a normalized score without D4RL refs."""
    seeds = range(RANDOM_REFERENCE_SEED, RANDOM_REFERENCE_SEED + RANDOM_REFERENCE_EPISODES)
    return float(rollout(env_id, None, seeds).returns.mean())


def spearman(x: np.ndarray, y: np.ndarray) -> float:
    """Pearson correlation of average ranks (ties share their mean rank); NaN when either side is constant."""
    rx, ry = pd.Series(x).rank().to_numpy(), pd.Series(y).rank().to_numpy()
    if len(rx) < 2 or np.all(rx == rx[0]) or np.all(ry == ry[0]):
        return float("nan")
    return float(np.corrcoef(rx, ry)[0, 1])
