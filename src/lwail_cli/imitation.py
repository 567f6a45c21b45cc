"""LWAIL's reward schedule inside the TD3 loop (paper Alg. 1, SPEC.md stage 3).

Each transition's critic input ``[φ(s), φ(s')−φ(s)]`` is computed once, when it enters the buffer,
and cached (φ is frozen). Every ``update_every`` env steps f is trained on the last
``update_every`` policy transitions against expert transitions, then every reward in the buffer is
relabelled to σ(−f) with the new f, so all rewards always come from the current f.
"""

from __future__ import annotations

import torch

from .config import DiscriminatorConfig
from .discriminator import DiscriminatorTrainer, transition_features
from .icvf import Encoder
from .replay import ReplayBuffer

RELABEL_CHUNK = 65_536


class AdversarialReward:
    def __init__(self, encoder: Encoder, trainer: DiscriminatorTrainer, expert_features: torch.Tensor, capacity: int, config: DiscriminatorConfig):
        self.encoder = encoder
        self.trainer = trainer
        self.expert_features = expert_features
        self.config = config
        self.features = torch.zeros(capacity, expert_features.shape[1], device=expert_features.device)
        self.labeled = 0  # buffer.count up to which features and rewards are current
        self.recent_reward = torch.zeros((), device=expert_features.device)

    @torch.no_grad()
    def prepare(self, step: int, buffer: ReplayBuffer) -> None:
        if buffer.count > self.labeled:
            buffer.flush()
            rows = torch.as_tensor(buffer.rows_since(self.labeled), device=self.features.device)
            storage = buffer.storage
            x = transition_features(self.encoder, storage["observations"][rows], storage["next_observations"][rows])
            self.features[rows] = x
            storage["rewards"][rows] = self.trainer.reward(x).unsqueeze(1)
            self.labeled = buffer.count
        if step % self.config.update_every == 0:
            recent = torch.as_tensor(buffer.rows_since(buffer.count - self.config.update_every), device=self.features.device)
            with torch.enable_grad():
                self.trainer.train(self.expert_features, self.features[recent], self.config.update_steps)
            self.relabel(buffer)
            self.recent_reward = buffer.storage["rewards"][recent].mean()

    @torch.no_grad()
    def relabel(self, buffer: ReplayBuffer) -> None:
        rewards = buffer.storage["rewards"]
        for start in range(0, buffer.size, RELABEL_CHUNK):
            stop = min(start + RELABEL_CHUNK, buffer.size)
            rewards[start:stop, 0] = self.trainer.reward(self.features[start:stop])

    def metrics(self) -> dict[str, float]:
        return {"pseudo_reward_mean": float(self.recent_reward), "wasserstein_estimate": float(self.trainer.last_wasserstein)}

    def state_dict(self) -> dict:
        return self.trainer.state_dict()

    def load_state_dict(self, state: dict) -> None:
        self.trainer.load_state_dict(state)
        self.labeled = 0  # features are recomputed from the restored buffer on the next step
