"""PWIL (Dadashi, Hussenot, Geist & Pietquin 2021, "Primal Wasserstein Imitation Learning"; we follow
google-research/pwil/rewarder.py): a reward from a greedy Wasserstein coupling with the demo, nothing trained.

The expert's pairs (every ``pwil.subsampling``-th, as the reference subsamples) are atoms of equal weight summing to 1,
standardised by the atoms' own mean and spread (the reference's StandardScaler). Within an episode each new
transition's pair, standardised alike, carries mass 1/T and is moved greedily onto the nearest atoms that still have
weight; with ``c`` the cost of that move, its reward is α·exp(−β·T·c/√d) (d: the feature width). The atoms' weights are
restored at each episode's end. State-only departure: the atoms are pair features ``[φ(s), φ(s') − φ(s)]`` (the same
as every method's), not the reference's (s, a). A reward depends on the episode before it, so it is stored as given
and never relabelled.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

from .. import learning_curve as curve
from ..discriminator import transition_features
from ..evaluation import spearman
from .base import Inputs, Method

if TYPE_CHECKING:
    from ..config import PwilConfig
    from ..icvf import Encoder
    from ..replay import ReplayBuffer
    from ..rollout import Rollouts

MASS_MARGIN = 1e-6  # taken off each transition's mass 1/T, as the reference does, so that T of them never outweigh the atoms


class PrimalWassersteinReward:
    def __init__(self, encoder: Encoder, expert: torch.Tensor, config: PwilConfig, random_features: torch.Tensor | None = None):
        self.encoder = encoder
        self.device = expert.device
        atoms = expert[:: config.subsampling].double().cpu().numpy()
        self.shift, self.scale = atoms.mean(axis=0), np.where(atoms.std(axis=0) > 0, atoms.std(axis=0), 1.0)
        self.atoms = (atoms - self.shift) / self.scale
        self.alpha, self.horizon = config.alpha, config.time_horizon
        self.sigma = config.beta * config.time_horizon / np.sqrt(atoms.shape[1])
        self.expert, self.random = expert, random_features  # for diagnostics
        self.remaining = self._fresh()
        self.labeled = 0  # buffer.count up to which rewards are given

    def _fresh(self) -> np.ndarray:
        return np.full(len(self.atoms), 1.0 / len(self.atoms))

    def rewards(self, features: torch.Tensor, remaining: np.ndarray) -> np.ndarray:
        """The reward of each pair in turn, moving its mass onto the atoms' ``remaining`` weights (updated in place)."""
        return np.array([self._couple(pair, remaining) for pair in (features.double().cpu().numpy() - self.shift) / self.scale])

    def _couple(self, pair: np.ndarray, remaining: np.ndarray) -> float:
        distances = np.linalg.norm(self.atoms - pair, axis=1)
        distances[remaining <= 0] = np.inf
        mass, cost = 1.0 / self.horizon - MASS_MARGIN, 0.0
        while mass > 0:
            nearest = int(distances.argmin())
            if remaining[nearest] <= 0:  # every atom spent: an episode longer than T gets nothing more
                return 0.0
            moved = min(mass, remaining[nearest])
            cost += moved * distances[nearest]
            remaining[nearest] -= moved
            mass -= moved
            if remaining[nearest] <= 0:
                distances[nearest] = np.inf
        return self.alpha * float(np.exp(-self.sigma * cost))

    @torch.no_grad()
    def prepare(self, step: int, buffer: ReplayBuffer) -> None:
        buffer.flush()
        if buffer.count > self.labeled:
            index = torch.as_tensor(buffer.rows_since(self.labeled), device=self.device)
            storage = buffer.storage
            features = transition_features(self.encoder, storage["observations"][index], storage["next_observations"][index])
            storage["rewards"][index, 0] = torch.as_tensor(self.rewards(features, self.remaining), dtype=torch.float32, device=self.device)
            self.labeled = buffer.count

    def end_episode(self) -> None:
        self.remaining = self._fresh()

    @torch.no_grad()
    def metrics(self, evaluation: Rollouts) -> dict[str, float]:
        """The reward the demo's own pairs get as one episode, a random-policy pair alone, and the evaluation's
        episodes each (their mean and spread per step), and whether the evaluation's PWIL returns rank its episodes
        as their true returns do."""
        episodes = [self.rewards(self._pairs(episode.observations), self._fresh()) for episode in evaluation.episodes]
        every = np.concatenate(episodes)
        random = [self.rewards(pair[None], self._fresh())[0] for pair in self.random] if self.random is not None else [np.nan]
        return {
            curve.REWARD_EXPERT: float(self.rewards(self.expert, self._fresh()).mean()),
            curve.REWARD_RANDOM: float(np.mean(random)),
            curve.PSEUDO_RETURN_SPEARMAN: spearman(np.array([rewards.sum() for rewards in episodes]), evaluation.returns),
            curve.PSEUDO_REWARD: float(every.mean()),
            curve.PSEUDO_REWARD_STD: float(every.std()),
        }

    def _pairs(self, observations: np.ndarray) -> torch.Tensor:
        states = torch.as_tensor(observations, device=self.device)
        return transition_features(self.encoder, states[:-1], states[1:])

    def weights(self) -> dict[str, dict]:
        return {}  # nothing learned: the reward is the demo's atoms, rebuilt from the demo

    def state_dict(self) -> dict:
        return {"remaining": torch.from_numpy(self.remaining.copy()), "labeled": self.labeled}

    def load_state_dict(self, state: dict) -> None:
        self.remaining, self.labeled = state["remaining"].numpy().copy(), state["labeled"]


def build(inputs: Inputs) -> PrimalWassersteinReward:
    return PrimalWassersteinReward(inputs.encoder, inputs.expert, inputs.config.pwil, random_features=inputs.random)


METHOD = Method("pwil", "PWIL", "PWIL reward α·exp(−β·T·c/√d)", reads_discriminator=False, caches_features=False, build=build,
                reward="α·exp(−β·T·c/√d)")
