"""How good a state embedding φ is, probed without training anything: does latent distance track time apart inside
an episode (``probe_spearman``), and does φ give the critic what it needs (``probe_critic_needs``)? Every trained
embedding holds some episodes of data set I out of training (``split_episodes``) to probe on."""

from __future__ import annotations

from typing import Callable

import numpy as np
import pandas as pd
import torch

from .data import Episode, transition_pairs
from .discriminator import transition_features
from .evaluation import spearman


def split_episodes(episodes: list[Episode], holdout_fraction: float, seed: int) -> tuple[list[Episode], list[Episode]]:
    """Hold out whole episodes (with at least 3 observations) for the probe."""
    candidates = [i for i, e in enumerate(episodes) if len(e.observations) >= 3]
    count = max(1, int(round(holdout_fraction * len(episodes)))) if candidates else 0
    held = set(np.random.default_rng(seed).permutation(candidates)[:count].tolist())
    train = [e for i, e in enumerate(episodes) if i not in held]
    return (train or episodes), [episodes[i] for i in sorted(held)]


def probe_spearman(encode: Callable[[torch.Tensor], torch.Tensor], episodes: list[Episode], max_points: int = 200) -> float:
    """Rank correlation of ``‖φ(s_i) − φ(s_j)‖`` with ``|i − j|`` over pairs inside each episode."""
    latent, temporal = [], []
    for episode in episodes:
        steps = np.unique(np.linspace(0, len(episode.observations) - 1, min(max_points, len(episode.observations))).astype(int))
        with torch.no_grad():
            z = encode(torch.as_tensor(episode.observations[steps], dtype=torch.float32))
        i, j = np.triu_indices(len(steps), k=1)
        latent.append(torch.linalg.vector_norm(z[i] - z[j], dim=-1).cpu().numpy())
        temporal.append(np.abs(steps[i] - steps[j]).astype(float))
    if not latent:
        return float("nan")
    return spearman(np.concatenate(latent), np.concatenate(temporal))


@torch.no_grad()
def probe_critic_needs(encode: Callable[[torch.Tensor], torch.Tensor], expert: list[Episode], random: list[Episode], max_pairs: int = 2000) -> dict[str, float]:
    """What the critic needs from φ, on the critic's own input ``[φ(s), φ(s') − φ(s)]``:

    - ``separation_auc``: how often a random-policy pair lies farther from the first expert trajectory
      than a pair of another expert trajectory does (1 = always, 0.5 = chance; NaN with one trajectory);
    - ``progress_spearman``: rank correlation of ``‖φ(s_t) − φ(s_T)‖`` with the steps to go ``T − t``
      along the first expert trajectory (1 = distance to the goal shrinks at every step)."""

    def pairs(episodes: list[Episode]) -> torch.Tensor:
        states, next_states = (torch.as_tensor(side) for side in transition_pairs(episodes))
        pick = torch.linspace(0, len(states) - 1, min(max_pairs, len(states))).long()
        return transition_features(encode, states[pick], next_states[pick])

    def nearest(candidates: torch.Tensor, reference: torch.Tensor) -> np.ndarray:
        return torch.cat([torch.cdist(chunk, reference).amin(1) for chunk in candidates.split(1024)]).numpy()

    first = expert[0]
    z = encode(torch.as_tensor(first.observations, dtype=torch.float32))
    to_goal = torch.linalg.vector_norm(z - z[-1], dim=-1).numpy()
    progress = spearman(to_goal[:-1], np.arange(len(to_goal) - 1, 0, -1).astype(float))
    separation = float("nan")
    if len(expert) > 1 and random:
        reference = pairs([first])
        near_expert, near_random = nearest(pairs(expert[1:]), reference), nearest(pairs(random), reference)
        ranks = pd.Series(np.concatenate([near_expert, near_random])).rank().to_numpy()[len(near_expert):]
        separation = float((ranks.sum() - len(near_random) * (len(near_random) + 1) / 2) / (len(near_random) * len(near_expert)))
    return {"separation_auc": separation, "progress_spearman": progress}
