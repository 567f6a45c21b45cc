"""State-only data: episodes of observations with their boundaries, collected, imported or stored.

An episode holds ``T+1`` observations and ``T`` transitions. Pairs ``(s_t, s_{t+1})`` are formed
inside an episode, never across a boundary. Terminations and truncations are kept apart because
later stages bootstrap through a truncation but not through a termination. The files episodes are read from
and written to are ``formats/``'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .envs import EnvInfo
from .errors import LwailError


@dataclass
class Episode:
    observations: np.ndarray  # (T+1, obs_dim)
    actions: np.ndarray | None = None  # (T, act_dim)
    rewards: np.ndarray | None = None  # (T,)
    terminated: bool = False  # the last observation is terminal (no bootstrapping past it)

    @property
    def length(self) -> int:
        return len(self.observations) - 1

    @property
    def episode_return(self) -> float:
        return float(self.rewards.sum()) if self.rewards is not None else float("nan")


@dataclass
class FlatEpisodes:
    """Episodes concatenated for fast index sampling."""

    observations: np.ndarray  # (N, obs_dim) float32, every episode's T+1 observations back to back
    episode_end: np.ndarray  # (N,) index of the last observation of the episode each row belongs to
    episode_start: np.ndarray  # (N,)
    has_successor: np.ndarray  # (N,) bool, False on each episode's last observation


def flatten(episodes: list[Episode]) -> FlatEpisodes:
    lengths = np.array([len(e.observations) for e in episodes])
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    ends = starts + lengths - 1
    observations = np.concatenate([e.observations for e in episodes]).astype(np.float32)
    has_successor = np.ones(len(observations), dtype=bool)
    has_successor[ends] = False
    return FlatEpisodes(
        observations=observations,
        episode_end=np.repeat(ends, lengths),
        episode_start=np.repeat(starts, lengths),
        has_successor=has_successor,
    )


def transition_pairs(episodes: list[Episode]) -> tuple[np.ndarray, np.ndarray]:
    """All ``(s, s')`` pairs inside episodes, as float32 arrays."""
    states = np.concatenate([e.observations[:-1] for e in episodes]).astype(np.float32)
    successors = np.concatenate([e.observations[1:] for e in episodes]).astype(np.float32)
    return states, successors


def transitions_with_actions(episodes: list[Episode]) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """All ``(s, a, s')`` inside episodes as float32 arrays, or None where an episode has no actions or a missing
    (NaN) one: an imported state-only data set stores NaN actions (its format needs some)."""
    if any(e.actions is None or not np.all(np.isfinite(e.actions)) for e in episodes):
        return None
    states, successors = transition_pairs(episodes)
    return states, np.concatenate([e.actions for e in episodes]).astype(np.float32), successors


def validate_episodes(episodes: list[Episode], env: EnvInfo, source: str) -> None:
    if not episodes:
        raise LwailError(f"{source} holds no episodes")
    for episode in episodes:
        obs = episode.observations
        if obs.ndim != 2 or obs.shape[1] != env.obs_dim:
            raise LwailError(
                f"{source} has observations of shape {obs.shape[1:] if obs.ndim == 2 else obs.shape}, "
                f"but {env.id} observations have {env.obs_dim} dims"
            )
        if episode.actions is not None and episode.actions.shape[-1] != env.act_dim:
            raise LwailError(f"{source} has {episode.actions.shape[-1]}-dim actions, but {env.id} has {env.act_dim}")
        if not np.all(np.isfinite(obs)):
            raise LwailError(f"{source} contains NaN or infinite observations")
    if sum(e.length for e in episodes) == 0:
        raise LwailError(f"{source} holds no transitions (every episode has a single observation)")
