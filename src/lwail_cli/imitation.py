"""An adversarial reward's schedule inside the TD3 loop: LWAIL's (paper Alg. 1; docs/algorithm.md), GAIfO's and DIFO's.

A new transition is rewarded with the current adversary (LWAIL's critic f, GAIfO's or DIFO's discriminator D) as it enters the
buffer. Its inputs ``[φ(s), φ(s')−φ(s)]`` are cached (φ is frozen) one update window at a time. Every ``update_every``
env steps the adversary is trained on the last ``update_every`` policy transitions against expert transitions, then
every reward in the buffer is relabelled with the new adversary (σ(−f) for LWAIL), so all rewards always come from the
current one. The adversary is a trainer with ``Adversary``'s interface (``discriminator.DiscriminatorTrainer``,
``methods.gaifo.GaifoTrainer``, ``methods.difo.DifoTrainer``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np
import torch

from . import learning_curve as curve
from .discriminator import transition_features
from .evaluation import spearman

if TYPE_CHECKING:
    from torch import nn

    from .icvf import Encoder
    from .replay import ReplayBuffer
    from .rollout import Rollouts

RELABEL_CHUNK = 65_536


class Adversary(Protocol):
    FILE: str  # where a policy artifact keeps the final network
    critic: nn.Module  # the network's raw score of a pair's features

    def train(self, expert: torch.Tensor, policy: torch.Tensor, steps: int) -> torch.Tensor: ...

    def reward(self, features: torch.Tensor) -> torch.Tensor: ...

    def rewarded(self, scores: torch.Tensor) -> torch.Tensor:
        """The reward of raw scores, differentiable."""

    def estimate(self) -> dict[str, float]:
        """What the last update measured, as the learning curve names it."""

    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...


class AdversarialReward:
    def __init__(
        self, encoder: Encoder, trainer: Adversary, expert_features: torch.Tensor, capacity: int, *,
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
        nothing_yet = torch.full((), float("nan"), device=expert_features.device)
        # at the last update of f, on the latest update_every policy pairs (learning_curve names them)
        self.recent = {curve.PSEUDO_REWARD: nothing_yet, curve.PSEUDO_REWARD_STD: nothing_yet,
                       curve.REWARD_SLOPE: nothing_yet, curve.CRITIC_SHIFT: nothing_yet}

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
            f_before = self.trainer.critic(self.features[recent])
            with torch.enable_grad():
                self.trainer.train(self.expert_features, self.features[recent], self.update_steps)
            self.relabel(buffer)
            rewards = buffer.storage["rewards"][recent, 0]
            self.recent = {curve.PSEUDO_REWARD: rewards.mean(), curve.PSEUDO_REWARD_STD: rewards.std(),
                           curve.REWARD_SLOPE: self._reward_slope(buffer, recent),
                           curve.CRITIC_SHIFT: (self.trainer.critic(self.features[recent]) - f_before).abs().mean()}

    def end_episode(self) -> None:
        pass

    @torch.enable_grad()
    def _reward_slope(self, buffer: ReplayBuffer, rows: torch.Tensor) -> torch.Tensor:
        """Mean ‖∂r/∂s'‖ (r = σ(−f) for LWAIL) over the pairs ``rows``: how much the reward changes with what the action reaches."""
        states = buffer.storage["observations"][rows]
        next_states = buffer.storage["next_observations"][rows].clone().requires_grad_(True)
        reward = self.trainer.rewarded(self.trainer.critic(transition_features(self.encoder, states, next_states)))
        (slope,) = torch.autograd.grad(reward.sum(), next_states)
        return slope.norm(dim=-1).mean().detach()

    @torch.no_grad()
    def relabel(self, buffer: ReplayBuffer) -> None:
        rewards = buffer.storage["rewards"]
        for start in range(0, buffer.size, RELABEL_CHUNK):
            stop = min(start + RELABEL_CHUNK, buffer.size)
            rewards[start:stop, 0] = self.trainer.reward(self.features[start:stop])

    @torch.no_grad()
    def metrics(self, evaluation: Rollouts) -> dict[str, float]:
        """What explains a run at an evaluation: the reward the adversary gives expert, recent-policy and random-policy
        pairs, how much it varies over the policy's pairs and how far its score moved at its last update, what its
        last update measured (f's Wasserstein estimate), and whether the pseudo-return ranks the evaluation episodes as their true return does."""
        reward = self.trainer.reward
        pseudo_returns = np.array([self._pseudo_return(episode.observations) for episode in evaluation.episodes])
        return {
            curve.REWARD_EXPERT: float(reward(self.expert_features).mean()),
            curve.REWARD_RANDOM: float(reward(self.random_features).mean()) if self.random_features is not None else float("nan"),
        } | self.trainer.estimate() | {
            curve.PSEUDO_RETURN_SPEARMAN: spearman(pseudo_returns, evaluation.returns),
        } | {name: float(value) for name, value in self.recent.items()}

    def _pseudo_return(self, observations: np.ndarray) -> float:
        states = torch.as_tensor(observations, device=self.expert_features.device)
        return float(self.trainer.reward(transition_features(self.encoder, states[:-1], states[1:])).sum())

    def weights(self) -> dict[str, dict]:
        """The files of learned weights a policy artifact keeps (the final adversary)."""
        return {self.trainer.FILE: self.trainer.critic.state_dict()}

    def state_dict(self) -> dict:
        # features are not saved (they can be GBs): the restored buffer holds the current rewards,
        # and the feature cache is rebuilt from the restored observations on the next step
        return {"trainer": self.trainer.state_dict(), "labeled": self.labeled, "featured": self.featured, "recent": self.recent}

    def load_state_dict(self, state: dict) -> None:
        self.trainer.load_state_dict(state["trainer"])
        self.labeled, self.rebuild_to, self.featured = state["labeled"], state["featured"], 0
        # checkpoints written before the reward-spread diagnostics hold only the mean reward
        recent = state.get("recent", {curve.PSEUDO_REWARD: state.get("recent_reward")})
        self.recent |= {name: value.to(self.features.device) for name, value in recent.items()}
