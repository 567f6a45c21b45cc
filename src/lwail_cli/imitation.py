"""LWAIL's reward schedule inside the TD3 loop (paper Alg. 1; docs/algorithm.md).

A new transition is rewarded with the current f as it enters the buffer. Critic inputs
``[φ(s), φ(s')−φ(s)]`` are cached (φ is frozen) one update window at a time. Every ``update_every`` env steps f is trained on the last
``update_every`` policy transitions against expert transitions, then every reward in the buffer is
relabelled to σ(−f) with the new f, so all rewards always come from the current f.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

from . import learning_curve as curve
from .discriminator import transition_features
from .evaluation import spearman

if TYPE_CHECKING:
    from .discriminator import DiscriminatorTrainer
    from .icvf import Encoder
    from .replay import ReplayBuffer
    from .rollout import Rollouts

RELABEL_CHUNK = 65_536


class AdversarialReward:
    def __init__(
        self, encoder: Encoder, trainer: DiscriminatorTrainer, expert_features: torch.Tensor, capacity: int, *,
        update_every: int, update_steps: int, random_features: torch.Tensor | None = None,
    ):
        self.encoder = encoder
        self.trainer = trainer
        self.expert_features = expert_features
        self.random_features = random_features  # random-policy pairs, only for diagnostics
        self.update_every = update_every
        self.update_steps = update_steps
        self.features = torch.zeros(capacity, expert_features.shape[1], device=expert_features.device)
        self.labeled = 0  # buffer.count up to which rewards are current
        self.featured = 0  # buffer.count up to which features are cached (a multiple of update_every)
        self.rebuild_to = 0  # after a resume: cache features up to here before they are used
        self.recent_reward = torch.zeros((), device=expert_features.device)

    def _features(self, buffer: ReplayBuffer, rows: np.ndarray) -> torch.Tensor:
        index = torch.as_tensor(rows, device=self.features.device)
        storage = buffer.storage
        return transition_features(self.encoder, storage["observations"][index], storage["next_observations"][index])

    def _cache_features(self, buffer: ReplayBuffer, upto: int) -> None:
        """Features in blocks of one update window each: the same blocks on a resumed run, so
        the same floats (a matmul's rounding depends on its batch size)."""
        window = self.update_every
        for start in range(self.featured, upto, window):
            stop = min(start + window, upto)
            rows = np.arange(max(start, buffer.count - buffer.capacity), stop) % buffer.capacity
            self.features[torch.as_tensor(rows, device=self.features.device)] = self._features(buffer, rows)
        self.featured = upto

    @torch.no_grad()
    def prepare(self, step: int, buffer: ReplayBuffer) -> None:
        buffer.flush()
        if self.featured < self.rebuild_to:
            self._cache_features(buffer, self.rebuild_to)
        if buffer.count > self.labeled:
            rows = buffer.rows_since(self.labeled)
            buffer.storage["rewards"][torch.as_tensor(rows, device=self.features.device), 0] = self.trainer.reward(self._features(buffer, rows))
            self.labeled = buffer.count
        if step % self.update_every == 0:
            self._cache_features(buffer, buffer.count)
            recent = torch.as_tensor(buffer.rows_since(buffer.count - self.update_every), device=self.features.device)
            with torch.enable_grad():
                self.trainer.train(self.expert_features, self.features[recent], self.update_steps)
            self.relabel(buffer)
            self.recent_reward = buffer.storage["rewards"][recent].mean()

    @torch.no_grad()
    def relabel(self, buffer: ReplayBuffer) -> None:
        rewards = buffer.storage["rewards"]
        for start in range(0, buffer.size, RELABEL_CHUNK):
            stop = min(start + RELABEL_CHUNK, buffer.size)
            rewards[start:stop, 0] = self.trainer.reward(self.features[start:stop])

    @torch.no_grad()
    def metrics(self, evaluation: Rollouts) -> dict[str, float]:
        """What explains a run at an evaluation: the reward f gives expert, recent-policy and random-policy
        pairs, the critic's Wasserstein estimate, and whether the pseudo-return ranks the evaluation
        episodes as their true return does."""
        reward = self.trainer.reward
        pseudo_returns = np.array([self._pseudo_return(episode.observations) for episode in evaluation.episodes])
        return {
            curve.REWARD_EXPERT: float(reward(self.expert_features).mean()),
            curve.PSEUDO_REWARD: float(self.recent_reward),  # the latest update_every policy pairs, at the last update of f
            curve.REWARD_RANDOM: float(reward(self.random_features).mean()) if self.random_features is not None else float("nan"),
            curve.WASSERSTEIN: float(self.trainer.last_wasserstein),
            curve.PSEUDO_RETURN_SPEARMAN: spearman(pseudo_returns, evaluation.returns),
        }

    def _pseudo_return(self, observations: np.ndarray) -> float:
        states = torch.as_tensor(observations, device=self.expert_features.device)
        return float(self.trainer.reward(transition_features(self.encoder, states[:-1], states[1:])).sum())

    def state_dict(self) -> dict:
        # features are not saved (they can be GBs): the restored buffer holds the current rewards,
        # and the feature cache is rebuilt from the restored observations on the next step
        return {"trainer": self.trainer.state_dict(), "labeled": self.labeled, "featured": self.featured, "recent_reward": self.recent_reward}

    def load_state_dict(self, state: dict) -> None:
        self.trainer.load_state_dict(state["trainer"])
        self.labeled, self.rebuild_to, self.featured = state["labeled"], state["featured"], 0
        self.recent_reward = state["recent_reward"].to(self.features.device)
