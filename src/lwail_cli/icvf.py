"""ICVF pre-training (Ghosh et al., 2023) of the state embedding φ: the ``icvf`` entry of ``embeddings.py``.

``V(s, s+, z) = Σ A(t ⊙ φ(s)) ⊙ B(t ⊙ ψ(s+))`` with ``t = T(ψ(z))``, an ensemble of independent
value functions trained by expectile regression on action-free transitions (docs/algorithm.md, stage 1).
All ensemble members run as one batched matmul; goal sampling happens on the compute device.
"""

from __future__ import annotations

import copy
from typing import Callable

import numpy as np
import torch
from torch import nn

from .config import ICVFConfig
from .data import Episode, flatten
from .nets import Encoder, StackedMLP, embedding_net, export_encoder, soft_update
from .pretraining import EmbeddingResult, pretrain
from .probes import split_episodes


class ICVF(nn.Module):
    """An ensemble of multilinear intention-conditioned value functions."""

    def __init__(self, obs_dim: int, config: ICVFConfig):
        super().__init__()
        members, dim = config.ensemble, config.embedding_dim
        self.phi = embedding_net(members, obs_dim, config)
        self.psi = embedding_net(members, obs_dim, config)
        self.intention = embedding_net(members, dim, config)  # T
        self.matrix_a = StackedMLP(members, dim, (), dim)
        self.matrix_b = StackedMLP(members, dim, (), dim)

    def value(self, phi_s: torch.Tensor, psi_outcome: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """V for embedded inputs, each (members, B, dim); returns (members, B)."""
        return (self.matrix_a(t * phi_s) * self.matrix_b(t * psi_outcome)).sum(-1)

    def values_for_targets(self, phi_s, phi_next, psi_outcome, psi_intention, t):
        """V(s', s+, z), V(s', z, z) and V(s, z, z), sharing the projection of φ(s') and of ψ(z)."""
        a_next = self.matrix_a(t * phi_next)
        b_intention = self.matrix_b(t * psi_intention)
        return (
            (a_next * self.matrix_b(t * psi_outcome)).sum(-1),
            (a_next * b_intention).sum(-1),
            (self.matrix_a(t * phi_s) * b_intention).sum(-1),
        )


class GoalSampler:
    """Batches of (s, s', s+, z) indices with ICVF's goal mixture, drawn on the device."""

    def __init__(self, episodes: list[Episode], config: ICVFConfig, device: torch.device):
        flat = flatten(episodes)
        self.config = config
        self.observations = torch.as_tensor(flat.observations, device=device)
        self.episode_end = torch.as_tensor(flat.episode_end, device=device)
        self.starts = torch.as_tensor(np.flatnonzero(flat.has_successor), device=device)
        self.device = device

    def _goals(self, index: torch.Tensor) -> torch.Tensor:
        cfg = self.config
        u = torch.rand(index.shape, device=self.device)
        later = index + 1 + (torch.rand(index.shape, device=self.device) * (self.episode_end[index] - index)).long()
        anywhere = torch.randint(0, len(self.observations), index.shape, device=self.device)
        return torch.where(u < cfg.p_goal_current, index, torch.where(u < cfg.p_goal_current + cfg.p_goal_trajectory, later, anywhere))

    def sample(self, batch_size: int) -> dict[str, torch.Tensor]:
        index = self.starts[torch.randint(0, len(self.starts), (batch_size,), device=self.device)]
        intention = self._goals(index)
        outcome = torch.where(torch.rand(index.shape, device=self.device) < self.config.p_outcome_is_goal, intention, self._goals(index))
        reached_outcome = (outcome == index).float()
        reached_intention = (intention == index).float()
        obs = self.observations
        return {
            "s": obs[index], "next_s": obs[index + 1], "outcome": obs[outcome], "intention": obs[intention],
            "outcome_reward": reached_outcome - 1.0, "outcome_mask": 1.0 - reached_outcome,
            "intention_reward": reached_intention - 1.0, "intention_mask": 1.0 - reached_intention,
        }


class ICVFLearner:
    def __init__(self, obs_dim: int, config: ICVFConfig, device: torch.device | str = "cpu"):
        self.config, self.obs_dim = config, obs_dim
        self.model = ICVF(obs_dim, config).to(device)
        self.target = copy.deepcopy(self.model).requires_grad_(False)
        self.optimizer = torch.optim.Adam(self.model.parameters(), lr=config.lr, fused=torch.device(device).type in ("cpu", "cuda"))

    def loss(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        cfg = self.config
        with torch.no_grad():
            target = self.target
            phi_s, phi_next = target.phi(torch.cat([batch["s"], batch["next_s"]])).chunk(2, dim=1)
            psi_outcome, psi_intention = target.psi(torch.cat([batch["outcome"], batch["intention"]])).chunk(2, dim=1)
            t = target.intention(psi_intention)
            next_v_outcome, next_v_intention, v_intention = target.values_for_targets(phi_s, phi_next, psi_outcome, psi_intention, t)
            q_outcome = batch["outcome_reward"] + cfg.gamma * batch["outcome_mask"] * next_v_outcome
            q_intention = batch["intention_reward"] + cfg.gamma * batch["intention_mask"] * next_v_intention.amin(0)
            advantage = q_intention - v_intention.mean(0)
            weight = torch.where(advantage >= 0, cfg.expectile, 1.0 - cfg.expectile)
        model = self.model
        psi_outcome, psi_intention = model.psi(torch.cat([batch["outcome"], batch["intention"]])).chunk(2, dim=1)
        v = model.value(model.phi(batch["s"]), psi_outcome, model.intention(psi_intention))
        return (weight * (q_outcome - v).square()).mean(1).sum()

    def update(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        loss = self.loss(batch)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        with torch.no_grad():
            soft_update(self.target, self.model, self.config.tau)
        return loss.detach()

    def encoder(self) -> Encoder:
        """φ as it is now: member 0 of the ensemble."""
        return export_encoder(self.model.phi, self.obs_dim, self.config).cpu()

    def state_dict(self) -> dict:
        return {"model": self.model.state_dict(), "target": self.target.state_dict(), "optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        self.model.load_state_dict(state["model"])
        self.target.load_state_dict(state["target"])
        self.optimizer.load_state_dict(state["optimizer"])


def pretrain_icvf(
    episodes: list[Episode],
    obs_dim: int,
    config: ICVFConfig,
    seed: int,
    device: torch.device | str = "cpu",
    on_progress: Callable[[int, float | None], None] | None = None,
    resume: dict | None = None,
    on_checkpoint: Callable[[dict], None] | None = None,
    expert: list[Episode] | None = None,
    stop_requested: Callable[[], bool] | None = None,
) -> EmbeddingResult:
    """ICVF on the episodes (those ``split_episodes`` does not hold out for the probe); the loop, its logs,
    checkpoints and resume: ``pretraining.pretrain``."""
    torch.manual_seed(seed)
    train, held_out = split_episodes(episodes, config.holdout_fraction, seed)
    sampler = GoalSampler(train, config, torch.device(device))
    learner = ICVFLearner(obs_dim, config, device)
    return pretrain(learner, sampler.sample, config, held_out, device, on_progress, resume, on_checkpoint, expert, stop_requested)
